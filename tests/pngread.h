/* SPDX-License-Identifier: Apache-2.0 */
/* PNG pictures read back with libpng, for the tests of what writes them
 * (test_cli: clvox preview; test_blender: Blender's renders). */
#ifndef CLVOX_TEST_PNGREAD_H
#define CLVOX_TEST_PNGREAD_H
#include <stdint.h>

/* An 8-bit RGB picture decoded with libpng. */
typedef struct picture {
    uint32_t w, h;
    uint8_t *rgb;
} picture;

/* 1 when `path` is an 8-bit RGB, non-interlaced PNG; fills pic (free pic->rgb). */
int read_png(const char *path, picture *pic);
#endif
