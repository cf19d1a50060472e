/* SPDX-License-Identifier: Apache-2.0 */
/* libFuzzer target: clvox's render map parser (clvox_render_map_parse, the
 * core of clvox_render_map_load) on arbitrary bytes, against two built-in
 * palettes (paper78: symmetry images and complements; planar10: few names).
 * Every input must give either a map that draws every non-empty element with
 * a valid object name, never element 0, the first object for a score of 1
 * (and above) and the last one for a score of 0 (and below, and NaN); or a
 * status with a one-line message ("SOURCE:LINE: why" for a malformed map);
 * never a crash, a hang, an out-of-bounds access or unbounded work.
 * Build and run: make fuzz-run FUZZ_SECONDS=60 FUZZ_ONLY=render_map */
#include "clvox.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static clvox_context *render_map_ctx;
static clvox_palette *render_map_palettes[2];

static void render_map_check(const clvox_palette *p, const uint8_t *data, size_t size)
{
    clvox_render_map *m = NULL;
    clvox_status st = clvox_render_map_parse(render_map_ctx, "fuzz.render", (const char *)data, size, p, &m);
    if (st != CLVOX_OK) {
        const char *msg = clvox_context_error(render_map_ctx);
        if (m || !msg[0] || strchr(msg, '\n')) abort(); /* every failure says why, on one line */
        if (st == CLVOX_ERR_PALETTE_FORMAT && strncmp(msg, "fuzz.render:", 12) != 0) abort();
        if (st != CLVOX_ERR_PALETTE_FORMAT && st != CLVOX_ERR_OUT_OF_MEMORY) abort();
        return;
    }
    size_t n = clvox_palette_count(p), objects = clvox_render_map_object_count(m);
    if (objects < 1 || clvox_render_map_object_name(m, objects)) abort();
    for (size_t o = 0; o < objects; o++) {
        const char *name = clvox_render_map_object_name(m, o);
        if (!name || !name[0] || strlen(name) > 63) abort();
    }
    if (clvox_render_map_choose(m, 0, 1.0, NULL) != CLVOX_PALETTE_NONE) abort();
    if (clvox_render_map_choose(m, (uint32_t)n, 1.0, NULL) != CLVOX_PALETTE_NONE) abort();
    static const double falling[] = {1.0, 0.999, 0.75, 0.5, 0.25, 0.125, 1e-9, 0.0};
    for (uint32_t e = 1; e < n; e++) {
        clvox_render_frame f = (clvox_render_frame)-1;
        uint32_t top = clvox_render_map_choose(m, e, 1.0, &f);
        if (top >= objects || (f != CLVOX_RENDER_FRAME_BASIC && f != CLVOX_RENDER_FRAME_ELEMENT)) abort();
        if (clvox_render_map_choose(m, e, 2.0, NULL) != top) abort();
        uint32_t bottom = clvox_render_map_choose(m, e, 0.0, NULL);
        if (bottom >= objects || clvox_render_map_choose(m, e, -1.0, NULL) != bottom ||
            clvox_render_map_choose(m, e, NAN, NULL) != bottom)
            abort();
        for (size_t i = 0; i < sizeof falling / sizeof falling[0]; i++)
            if (clvox_render_map_choose(m, e, falling[i], NULL) >= objects) abort();
        (void)clvox_render_map_rule_line(m, e);
    }
    clvox_render_map_destroy(m);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (!render_map_ctx) {
        clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
        o.host_only = 1;
        if (clvox_context_create(&o, &render_map_ctx) != CLVOX_OK) abort();
        if (clvox_palette_builtin(render_map_ctx, "paper78", &render_map_palettes[0]) != CLVOX_OK ||
            clvox_palette_builtin(render_map_ctx, "planar10", &render_map_palettes[1]) != CLVOX_OK)
            abort();
    }
    for (int i = 0; i < 2; i++) render_map_check(render_map_palettes[i], data, size);
    return 0;
}
