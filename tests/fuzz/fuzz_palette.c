/* SPDX-License-Identifier: Apache-2.0 */
/* libFuzzer target: clvox's palette file parser (clvox_palette_parse, the
 * core of clvox_palette_load) on arbitrary bytes. Every input must give
 * either a palette whose index 0 is empty and 1 full (checked at the voxel
 * centre and corners), with element info for every index, or a status with
 * a one-line message ("SOURCE:LINE: why" for a malformed file); never a
 * crash, a hang, an out-of-bounds access or unbounded work.
 * Build and run: make fuzz-run FUZZ_SECONDS=60 FUZZ_ONLY=palette */
#include "clvox.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static clvox_context *palette_ctx;

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (!palette_ctx) {
        clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
        o.host_only = 1;
        if (clvox_context_create(&o, &palette_ctx) != CLVOX_OK) abort();
    }
    clvox_palette *p = NULL;
    clvox_status st = clvox_palette_parse(palette_ctx, "fuzz.txt", (const char *)data, size, &p);
    if (st != CLVOX_OK) {
        const char *msg = clvox_context_error(palette_ctx);
        if (p || !msg[0] || strchr(msg, '\n')) abort(); /* every failure says why, on one line */
        if (st == CLVOX_ERR_PALETTE_FORMAT && strncmp(msg, "fuzz.txt:", 9) != 0) abort();
        if (st != CLVOX_ERR_PALETTE_FORMAT && st != CLVOX_ERR_OUT_OF_MEMORY) abort();
        return 0;
    }
    size_t n = clvox_palette_count(p);
    if (n < 2) abort();
    static const float pts[3] = {0.0f, 0.5f, 1.0f};
    for (int i = 0; i < 27; i++) {
        float x = pts[i % 3], y = pts[i / 3 % 3], z = pts[i / 9];
        if (clvox_palette_contains(p, 0, x, y, z) || !clvox_palette_contains(p, 1, x, y, z)) abort();
    }
    for (size_t e = 0; e < n; e++) {
        clvox_palette_element_info info = CLVOX_PALETTE_ELEMENT_INFO_INIT;
        /* volumes are sampled on 64^3 points: only for the first few */
        if (e < 4) {
            if (clvox_palette_element_info_get(palette_ctx, p, e, &info) != CLVOX_OK) abort();
            if (!(info.volume >= 0 && info.volume <= 1) || info.basic >= n || info.symmetry >= 48) abort();
        }
        (void)clvox_palette_contains(p, e, 0.25f, 0.5f, 0.75f);
    }
    clvox_palette_destroy(p);
    return 0;
}
