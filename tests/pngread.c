/* SPDX-License-Identifier: Apache-2.0 */
/* PNG pictures read back with libpng (pngread.h). */
#include "pngread.h"

#include <png.h>

#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct png_jmp {
    jmp_buf jmp;
} png_jmp;

static void png_test_error(png_structp png, png_const_charp msg)
{
    fprintf(stderr, "libpng: %s\n", msg);
    longjmp(((png_jmp *)png_get_error_ptr(png))->jmp, 1);
}

/* 1 when `path` is an 8-bit RGB, non-interlaced PNG; fills pic (free pic->rgb). */
int read_png(const char *path, picture *pic)
{
    memset(pic, 0, sizeof *pic);
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    png_jmp pj;
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &pj, png_test_error, NULL);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    uint8_t *volatile rgb = NULL;
    if (!png || !info || setjmp(pj.jmp)) {
        png_destroy_read_struct(&png, &info, NULL);
        fclose(f);
        free(rgb);
        return 0;
    }
    png_init_io(png, f);
    png_read_info(png, info);
    png_uint_32 w = 0, h = 0;
    int depth = 0, color = 0, interlace = 0;
    png_get_IHDR(png, info, &w, &h, &depth, &color, &interlace, NULL, NULL);
    int ok = depth == 8 && color == PNG_COLOR_TYPE_RGB && interlace == PNG_INTERLACE_NONE && w > 0 && h > 0;
    if (ok) {
        rgb = malloc((size_t)w * h * 3);
        if (!rgb) abort();
        for (png_uint_32 y = 0; y < h; y++) png_read_row(png, rgb + (size_t)y * w * 3, NULL);
        png_read_end(png, NULL);
        pic->w = w;
        pic->h = h;
        pic->rgb = rgb;
    }
    png_destroy_read_struct(&png, &info, NULL);
    fclose(f);
    return ok;
}
