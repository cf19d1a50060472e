/* SPDX-License-Identifier: Apache-2.0 */
/* libFuzzer target: the --like grid readers (src/grid/grid_like.c) on arbitrary
 * bytes, both the NRRD header parser and the .npy JSON sidecar parser. Every
 * input must give either a valid grid (dims 1..CLVOX_MAX_AXIS, finite
 * origin, positive finite voxel size) or CLVOX_ERR_GRID / out of memory with
 * a one-line message; never a crash, a hang or an out-of-bounds access.
 * Build and run: make fuzz-run FUZZ_SECONDS=60 FUZZ_ONLY=like_header */
#include "clvox.h"
#include "grid/grid_like.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static clvox_context *like_ctx;

static void like_check(clvox_status st, const clvox_grid *g, const char *note)
{
    if (st != CLVOX_OK) {
        const char *msg = clvox_context_error(like_ctx);
        if (!msg[0] || strchr(msg, '\n') || strchr(msg, '\r')) abort(); /* one line saying why */
        if (st != CLVOX_ERR_GRID && st != CLVOX_ERR_OUT_OF_MEMORY) abort();
        return;
    }
    for (int a = 0; a < 3; a++)
        if (g->dims[a] == 0 || g->dims[a] > CLVOX_MAX_AXIS || !isfinite(g->origin[a]) ||
            !isfinite(g->voxel_size[a]) || !(g->voxel_size[a] > 0))
            abort();
    if (note && strchr(note, '\n')) abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (!like_ctx) {
        clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
        o.host_only = 1;
        if (clvox_context_create(&o, &like_ctx) != CLVOX_OK) abort();
    }
    /* an exact-size copy, so reading past the end is caught */
    char *copy = malloc(size ? size : 1);
    if (!copy) return 0;
    memcpy(copy, data, size);
    clvox_grid g;
    char note[256];
    memset(&g, 0, sizeof g);
    like_check(clvox__grid_from_nrrd(like_ctx, "fuzz.nrrd", copy, size, &g, note, sizeof note), &g, note);
    memset(&g, 0, sizeof g);
    like_check(clvox__grid_from_npy_json(like_ctx, "fuzz.json", copy, size, &g), &g, NULL);
    free(copy);
    return 0;
}
