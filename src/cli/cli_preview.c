/* SPDX-License-Identifier: Apache-2.0 */
/*
 * clvox preview FILE -o OUT.png [--slices N] [--size PX] [--channel NAME] [--shade]
 *
 * A picture of a clvox volume, an 8-bit RGB PNG (libpng): a shaded 3-D view
 * of the occupied voxels with a legend, a montage of N evenly spaced z
 * slices and the three central orthogonal slices, every panel labelled. The
 * layout is documented in print_preview_help (and docs/cli.md); in short:
 *  - every panel sits in a cell: a CAP-pixel caption strip above it, a
 *    GUT-pixel gutter left of it (the vertical axis: an arrow and a letter)
 *    and a CAP-pixel strip below it (the horizontal axis, "x>" at its right
 *    end); cells are BORDER pixels apart and from the picture's edge;
 *  - top row: the 3-D view (PX x PX) and the legend text;
 *  - slices z_k = floor((k + 0.5) * Z / N), k = 0..N-1 (N is first lowered to
 *    Z when larger, so that no slice repeats), in a grid of C = ceil(sqrt(N))
 *    columns and R = ceil(N / C) rows, row by row; x right, y up;
 *  - below it one row: z = Z/2 (x right, y up), y = Y/2 (x right, z up),
 *    x = X/2 (y right, z up), integer halves;
 *  - each slice panel is resampled by nearest neighbour so that its longer
 *    side is PX: an n_a x n_b source becomes round(n_a*PX/L) x round(n_b*PX/L)
 *    pixels (L = max(n_a, n_b), halves up, at least 1), pixel p (columns from
 *    the left, rows from the bottom) takes source index floor(p * n_src /
 *    n_dst); voxel sizes are ignored (one voxel, one cell);
 *  - BORDER_RGB around and between the cells, TEXT_RGB for the labels.
 * Grey levels: "occupancy" 255 when > 0.5 else 0 (the filled rule); any other
 * channel round(255 * v) clamped to [0, 255], NaN 0. "element" (palette
 * runs; the default when the file has it) is drawn in colour, a fixed
 * colour per element index (element_rgb), optionally shaded by "score"
 * (--shade: a second pass over the file that darkens each slice pixel in
 * place).
 *
 * The 3-D view: voxels with value > 0.5 (element: index >= 1) as unit cubes,
 * seen orthographically from the direction (1, 1, 1) with y up on the
 * picture. Only the +x, +y and +z faces can face the viewer; a face is drawn
 * when the voxel beyond it is empty (or outside the grid). Each face is
 * rasterised into a per-pixel depth buffer (nearest wins), shaded
 * Lambert-like by a light from (1, 3, 2) and darkened with depth. The +x and
 * +y neighbours are in the same slice; the +z face of slice z-1 is drawn when
 * slice z arrives (one slice kept), those of the last slice after it. Memory:
 * the picture (panels, the depth buffer) plus one slice, whatever Z is.
 *
 * Streaming: one pass over the file (clvox_volume_read_slices); each slice
 * fills the panels that sample it, so memory is the panels plus one slice
 * (the library's and a copy) whatever Z is. The layout needs the dimensions,
 * which the library has put into `info` before the first slice arrives.
 *
 * The PNG is written to a file without a name in the directory of OUT
 * (O_TMPFILE; where the file system lacks it, ".clvox-<pid>-<n>.tmp"),
 * flushed to disk and only then named OUT (clvox_output_file_*); any
 * failure removes it. Nothing that is not a regular file at OUT is ever
 * replaced. The same input gives the same bytes (no time stamps; every
 * computation is in a fixed order).
 */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include "cli_common.h"

#include <png.h>

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define DEFAULT_SLICES 16u
#define DEFAULT_SIZE 256u
#define MAX_SLICES 4096u
#define MAX_SIZE 8192u
#define MAX_PIXELS (1ull << 27) /* 128 M pixels: 128 MiB of grey panels (384 MiB in colour) */
#define BORDER 2u
#define CAP 9u          /* caption strip above and axis strip below a panel: 1 + 7 + 1 */
#define GUT 7u          /* gutter left of a panel: 1 + 5 + 1 */
#define GLYPH_W 5u
#define GLYPH_H 7u
#define ADVANCE 6u      /* glyph plus one blank column */
#define LEGEND_LINES 5u
static const unsigned char BORDER_RGB[3] = { 0, 0, 128 }; /* dark blue: no grey level is blue */
static const unsigned char TEXT_RGB[3] = { 255, 255, 96 }; /* light yellow: no grey level either */

/* The 3-D view: seen from VIEW_DIR, lit from LIGHT_DIR (documented in --help). */
#define AMBIENT 0.3
#define LIGHT_X 1.0
#define LIGHT_Y 3.0
#define LIGHT_Z 2.0

/* ---- a 5 x 7 bitmap font for the labels ------------------------------------ */

/* Each glyph: 7 rows of 5 pixels, '#' set; characters without a glyph are
 * drawn as '?', upper case as lower case. '^' and '>' are arrows. */
typedef struct glyph {
    char c;
    const char *rows[7];
} glyph;

static const glyph FONT[] = {
    { ' ', { ".....", ".....", ".....", ".....", ".....", ".....", "....." } },
    { '0', { ".###.", "#...#", "#..##", "#.#.#", "##..#", "#...#", ".###." } },
    { '1', { "..#..", ".##..", "..#..", "..#..", "..#..", "..#..", ".###." } },
    { '2', { ".###.", "#...#", "....#", "...#.", "..#..", ".#...", "#####" } },
    { '3', { "#####", "...#.", "..#..", "...#.", "....#", "#...#", ".###." } },
    { '4', { "...#.", "..##.", ".#.#.", "#..#.", "#####", "...#.", "...#." } },
    { '5', { "#####", "#....", "####.", "....#", "....#", "#...#", ".###." } },
    { '6', { "..##.", ".#...", "#....", "####.", "#...#", "#...#", ".###." } },
    { '7', { "#####", "....#", "...#.", "..#..", ".#...", ".#...", ".#..." } },
    { '8', { ".###.", "#...#", "#...#", ".###.", "#...#", "#...#", ".###." } },
    { '9', { ".###.", "#...#", "#...#", ".####", "....#", "...#.", ".##.." } },
    { 'a', { ".....", ".....", ".###.", "....#", ".####", "#...#", ".####" } },
    { 'b', { "#....", "#....", "#.##.", "##..#", "#...#", "#...#", "####." } },
    { 'c', { ".....", ".....", ".###.", "#....", "#....", "#...#", ".###." } },
    { 'd', { "....#", "....#", ".##.#", "#..##", "#...#", "#...#", ".####" } },
    { 'e', { ".....", ".....", ".###.", "#...#", "#####", "#....", ".###." } },
    { 'f', { "..##.", ".#..#", ".#...", "###..", ".#...", ".#...", ".#..." } },
    { 'g', { ".....", ".####", "#...#", "#...#", ".####", "....#", ".###." } },
    { 'h', { "#....", "#....", "#.##.", "##..#", "#...#", "#...#", "#...#" } },
    { 'i', { "..#..", ".....", ".##..", "..#..", "..#..", "..#..", ".###." } },
    { 'j', { "...#.", ".....", "..##.", "...#.", "...#.", "#..#.", ".##.." } },
    { 'k', { "#....", "#....", "#..#.", "#.#..", "##...", "#.#..", "#..#." } },
    { 'l', { ".##..", "..#..", "..#..", "..#..", "..#..", "..#..", ".###." } },
    { 'm', { ".....", ".....", "##.#.", "#.#.#", "#.#.#", "#...#", "#...#" } },
    { 'n', { ".....", ".....", "#.##.", "##..#", "#...#", "#...#", "#...#" } },
    { 'o', { ".....", ".....", ".###.", "#...#", "#...#", "#...#", ".###." } },
    { 'p', { ".....", ".....", "####.", "#...#", "####.", "#....", "#...." } },
    { 'q', { ".....", ".....", ".##.#", "#..##", ".####", "....#", "....#" } },
    { 'r', { ".....", ".....", "#.##.", "##..#", "#....", "#....", "#...." } },
    { 's', { ".....", ".....", ".###.", "#....", ".###.", "....#", "####." } },
    { 't', { ".#...", ".#...", "###..", ".#...", ".#...", ".#..#", "..##." } },
    { 'u', { ".....", ".....", "#...#", "#...#", "#...#", "#..##", ".##.#" } },
    { 'v', { ".....", ".....", "#...#", "#...#", "#...#", ".#.#.", "..#.." } },
    { 'w', { ".....", ".....", "#...#", "#...#", "#.#.#", "#.#.#", ".#.#." } },
    { 'x', { ".....", ".....", "#...#", ".#.#.", "..#..", ".#.#.", "#...#" } },
    { 'y', { ".....", ".....", "#...#", "#...#", ".####", "....#", ".###." } },
    { 'z', { ".....", ".....", "#####", "...#.", "..#..", ".#...", "#####" } },
    { '.', { ".....", ".....", ".....", ".....", ".....", ".##..", ".##.." } },
    { ',', { ".....", ".....", ".....", ".....", ".##..", "..#..", ".#..." } },
    { ':', { ".....", ".##..", ".##..", ".....", ".##..", ".##..", "....." } },
    { ';', { ".....", ".##..", ".##..", ".....", ".##..", "..#..", ".#..." } },
    { '-', { ".....", ".....", ".....", "#####", ".....", ".....", "....." } },
    { '+', { ".....", "..#..", "..#..", "#####", "..#..", "..#..", "....." } },
    { '=', { ".....", ".....", "#####", ".....", "#####", ".....", "....." } },
    { '(', { "...#.", "..#..", ".#...", ".#...", ".#...", "..#..", "...#." } },
    { ')', { ".#...", "..#..", "...#.", "...#.", "...#.", "..#..", ".#..." } },
    { '/', { ".....", "....#", "...#.", "..#..", ".#...", "#....", "....." } },
    { '^', { "..#..", ".###.", "#.#.#", "..#..", "..#..", "..#..", "..#.." } },
    { '>', { ".....", "..#..", "...#.", "#####", "...#.", "..#..", "....." } },
    { '?', { ".###.", "#...#", "....#", "...#.", "..#..", ".....", "..#.." } },
};

static const glyph *find_glyph(char c)
{
    if (c >= 'A' && c <= 'Z') c = (char)(c - 'A' + 'a');
    const glyph *unknown = NULL;
    for (size_t i = 0; i < sizeof FONT / sizeof FONT[0]; i++) {
        if (FONT[i].c == c) return &FONT[i];
        if (FONT[i].c == '?') unknown = &FONT[i];
    }
    return unknown;
}

/* A line of text at (x, y) (its top left) in the picture; glyphs that would
 * cross x + w are left out. */
typedef struct text_item {
    uint32_t x, y, w;
    char s[112];
} text_item;

/* ---- layout ---------------------------------------------------------------- */

typedef struct panel {
    uint32_t x0, y0;      /* top-left corner in the picture */
    uint32_t w, h;        /* pixels */
    uint32_t src_w, src_h;/* source cells along the panel's x and y */
    uint8_t *pix;         /* w*h pixels of bpp bytes: grey, or RGB */
} panel;

/* What a pass over the file puts into the panels. */
typedef enum draw_mode {
    DRAW_GREY = 0, /* round(255 * v) */
    DRAW_BINARY,   /* occupancy: 255 when > 0.5 */
    DRAW_ELEMENT,  /* element_rgb of the index */
    DRAW_SHADE     /* score: darkens the element colours already drawn */
} draw_mode;

typedef struct preview {
    uint32_t X, Y, Z;
    uint32_t n;           /* z slices in the montage */
    uint32_t cols, rows;
    uint32_t *zk;         /* n slice indices */
    panel *panels;        /* n montage panels, then XY (z = Z/2), XZ (y = Y/2), YZ (x = X/2), then the 3-D view */
    uint32_t width, height;
    uint32_t bpp;         /* bytes per panel pixel: 1 (grey) or 3 (element colours) */
    draw_mode mode;       /* of the current pass */
    /* the 3-D view */
    uint32_t *depth;      /* per pixel of the view: 0 nothing drawn, else 1 + quantised depth (larger: nearer) */
    double *col_a;        /* per view column: x - z of the pixel centre's ray */
    double *row_b;        /* per view row: 2y - x - z of the pixel centre's ray */
    double view_scale;    /* view pixels per unit of x - z (both s / sqrt 2) */
    double view_off_i, view_off_j; /* pixel position (before the centre's 0.5) of x - z = -Z, 2y - x - z = 2Y */
    float *prev;          /* slice z - 1 (its +z faces are drawn when slice z arrives) */
    int have_prev;
    /* set by the first slice callback */
    const clvox_volume_info *info;
    int ready;            /* layout made */
    int failed;           /* a later pass refused (message in why) */
    int too_large;        /* layout refused (message in why) */
    char why[256];
} preview;

#define VIEW(pv) (&(pv)->panels[(pv)->n + 3])

/* round(n * px / longest), halves up, at least 1 */
static uint32_t scaled(uint32_t n, uint32_t longest, uint32_t px)
{
    uint64_t v = (2ull * n * px + longest) / (2ull * longest);
    return v < 1 ? 1u : (uint32_t)v;
}

static void panel_size(panel *p, uint32_t src_w, uint32_t src_h, uint32_t px)
{
    uint32_t longest = src_w > src_h ? src_w : src_h;
    p->src_w = src_w;
    p->src_h = src_h;
    p->w = scaled(src_w, longest, px);
    p->h = scaled(src_h, longest, px);
}

static void preview_free(preview *pv)
{
    if (pv->panels)
        for (uint32_t k = 0; k < pv->n + 4; k++) free(pv->panels[k].pix);
    free(pv->panels);
    free(pv->zk);
    free(pv->depth);
    free(pv->col_a);
    free(pv->row_b);
    free(pv->prev);
}

/* The view's projection (documented in --help): a point (x, y, z) in voxel
 * units goes to a = x - z, b = 2y - x - z; a / sqrt 2 and b / sqrt 6 are its
 * lengths along the picture's right and up directions for the view direction
 * (1, 1, 1). The box [0,X] x [0,Y] x [0,Z] spans (X + Z) / sqrt 2 across and
 * (X + Z + 2Y) / sqrt 6 up; it is scaled so that the longer fits PX and
 * centred. Column i's centre sees a = col_a[i], row j's b = row_b[j]. */
static void view_projection(preview *pv, uint32_t px)
{
    const double r2 = sqrt(2.0), r6 = sqrt(6.0);
    const double wu = (double)((uint64_t)pv->X + pv->Z) / r2;
    const double hv = (double)((uint64_t)pv->X + pv->Z + 2ull * pv->Y) / r6;
    const double s = (double)px / (wu > hv ? wu : hv); /* pixels per unit length */
    pv->view_scale = s;
    pv->view_off_i = ((double)px - wu * s) / 2;
    pv->view_off_j = ((double)px - hv * s) / 2;
    for (uint32_t i = 0; i < px; i++) pv->col_a[i] = r2 * (((double)i + 0.5 - pv->view_off_i) / s) - (double)pv->Z;
    for (uint32_t j = 0; j < px; j++)
        pv->row_b[j] = 2.0 * (double)pv->Y - r6 * (((double)j + 0.5 - pv->view_off_j) / s);
}

/* Cell geometry: a panel of w x h pixels needs (GUT + w) x (CAP + h + CAP). */
static uint64_t cell_w(const panel *p) { return (uint64_t)GUT + p->w; }
static uint64_t cell_h(const panel *p) { return (uint64_t)CAP + p->h + CAP; }

/* Computes the layout for an X x Y x Z volume; 0 on success, else why is set
 * (too_large: the picture would be too large; else out of memory). */
static int preview_layout(preview *pv, uint32_t X, uint32_t Y, uint32_t Z, uint32_t slices, uint32_t px)
{
    pv->X = X;
    pv->Y = Y;
    pv->Z = Z;
    pv->n = slices < Z ? slices : Z;
    uint32_t c = 1;
    while ((uint64_t)c * c < pv->n) c++;
    pv->cols = c;
    pv->rows = (pv->n + c - 1) / c;

    panel sz[4];
    memset(sz, 0, sizeof sz);
    panel_size(&sz[0], X, Y, px); /* montage panels and the z = Z/2 panel */
    panel_size(&sz[1], X, Z, px); /* y = Y/2 */
    panel_size(&sz[2], Y, Z, px); /* x = X/2 */
    sz[3].w = sz[3].h = px;       /* the 3-D view */
    const uint64_t top_h_view = cell_h(&sz[3]), top_h_legend = (uint64_t)LEGEND_LINES * CAP;
    const uint64_t top_h = top_h_view > top_h_legend ? top_h_view : top_h_legend;
    const uint64_t montage_y = BORDER + top_h + BORDER;
    const uint64_t montage_w = BORDER + (uint64_t)pv->cols * (cell_w(&sz[0]) + BORDER);
    const uint64_t ortho_y = montage_y + (uint64_t)pv->rows * (cell_h(&sz[0]) + BORDER);
    uint64_t ortho_w = BORDER, ortho_h = 0;
    for (int i = 0; i < 3; i++) {
        ortho_w += cell_w(&sz[i]) + BORDER;
        if (cell_h(&sz[i]) > ortho_h) ortho_h = cell_h(&sz[i]);
    }
    const uint64_t top_w = BORDER + cell_w(&sz[3]) + BORDER;
    uint64_t W = montage_w > ortho_w ? montage_w : ortho_w, H = ortho_y + ortho_h + BORDER;
    if (top_w > W) W = top_w;
    if (W > PNG_UINT_31_MAX || H > PNG_UINT_31_MAX || W * H > MAX_PIXELS) {
        pv->too_large = 1;
        snprintf(pv->why, sizeof pv->why,
                 "the preview of a %u x %u x %u volume with --slices %u --size %u would be %llu x %llu pixels "
                 "(at most %llu in all): lower --slices or --size",
                 X, Y, Z, slices, px, (unsigned long long)W, (unsigned long long)H,
                 (unsigned long long)MAX_PIXELS);
        return 1;
    }
    pv->width = (uint32_t)W;
    pv->height = (uint32_t)H;

    pv->zk = malloc((size_t)pv->n * sizeof *pv->zk);
    pv->panels = calloc((size_t)pv->n + 4, sizeof *pv->panels);
    pv->depth = calloc((size_t)px * px, sizeof *pv->depth);
    pv->col_a = malloc((size_t)px * sizeof *pv->col_a);
    pv->row_b = malloc((size_t)px * sizeof *pv->row_b);
    pv->prev = malloc((size_t)X * Y * sizeof *pv->prev);
    if (!pv->zk || !pv->panels || !pv->depth || !pv->col_a || !pv->row_b || !pv->prev) goto oom;
    for (uint32_t k = 0; k < pv->n; k++) {
        pv->zk[k] = (uint32_t)(((2ull * k + 1) * Z) / (2ull * pv->n)); /* floor((k + 0.5) * Z / N) */
        panel *p = &pv->panels[k];
        *p = sz[0];
        p->x0 = (uint32_t)(BORDER + (k % pv->cols) * (cell_w(&sz[0]) + BORDER) + GUT);
        p->y0 = (uint32_t)(montage_y + (k / pv->cols) * (cell_h(&sz[0]) + BORDER) + CAP);
    }
    uint64_t x = BORDER;
    for (int i = 0; i < 3; i++) {
        panel *p = &pv->panels[pv->n + (uint32_t)i];
        *p = sz[i];
        p->x0 = (uint32_t)(x + GUT);
        p->y0 = (uint32_t)(ortho_y + CAP);
        x += cell_w(p) + BORDER;
    }
    panel *v = VIEW(pv);
    *v = sz[3];
    v->x0 = BORDER + GUT;
    v->y0 = BORDER + CAP;
    for (uint32_t k = 0; k < pv->n + 4; k++) {
        panel *p = &pv->panels[k];
        p->pix = calloc((size_t)p->w * p->h, pv->bpp);
        if (!p->pix) goto oom;
    }
    view_projection(pv, px);
    return 0;
oom:
    snprintf(pv->why, sizeof pv->why, "out of memory for a %u x %u preview", pv->width, pv->height);
    return 1;
}

/* ---- filling the panels ------------------------------------------------------ */

static uint8_t grey_level(float v)
{
    if (!(v > 0)) return 0; /* also NaN */
    if (v >= 1) return 255;
    return (uint8_t)floor(255.0 * (double)v + 0.5);
}

/* Element colours (documented in print_preview_help and README): index 0
 * (empty) black, 1 (full) light grey, any other index e a hue of the
 * sequence H = (e - 2) * 949 mod 1536 (six sectors of 256 steps; 949 / 1536
 * is about the golden ratio's 0.618, so neighbouring indices get distant
 * hues and the first 1536 all differ) at full colour 230 and least 50:
 * with f = H mod 256, up = 50 + 180 f / 255 and down = 230 - 180 f / 255
 * (integer division), sectors 0..5 are (230, up, 50), (down, 230, 50),
 * (50, 230, up), (50, down, 230), (up, 50, 230), (230, 50, down). A value
 * that is not an index (not an integer >= 0) is drawn as 0. */
static const uint8_t FULL_RGB[3] = { 224, 224, 224 };

static void element_rgb(float v, uint8_t rgb[3])
{
    if (!(v >= 1) || v >= 4294967296.0f || v != floorf(v)) { /* 0, and not an index */
        rgb[0] = rgb[1] = rgb[2] = 0;
        return;
    }
    const uint32_t e = (uint32_t)v;
    if (e == 1) {
        memcpy(rgb, FULL_RGB, 3);
        return;
    }
    const uint32_t h = (uint32_t)(((uint64_t)(e - 2) * 949u) % 1536u), f = h % 256;
    const uint8_t hi = 230, lo = 50;
    const uint8_t up = (uint8_t)(lo + (hi - lo) * f / 255), down = (uint8_t)(hi - (hi - lo) * f / 255);
    const uint8_t table[6][3] = { { hi, up, lo }, { down, hi, lo }, { lo, hi, up },
                                  { lo, down, hi }, { up, lo, hi }, { hi, lo, down } };
    memcpy(rgb, table[h / 256], 3);
}

/* Draws value v into the panel pixel at px (bpp bytes) by the pass's mode. */
static void draw(const preview *pv, uint8_t *px, float v)
{
    switch (pv->mode) {
    case DRAW_BINARY: *px = v > 0.5f ? 255 : 0; break;
    case DRAW_GREY: *px = grey_level(v); break;
    case DRAW_ELEMENT: element_rgb(v, px); break;
    case DRAW_SHADE: { /* c (1 + s) / 2, s = round(255 score) / 255, rounded half up */
        const uint32_t g = grey_level(v);
        for (int c = 0; c < 3; c++) px[c] = (uint8_t)((px[c] * (255u + g) + 255u) / 510u);
        break;
    }
    }
}

/* ---- the 3-D view ---------------------------------------------------------------- */

/* Whether the 3-D view shows a voxel of value v: an element index >= 1, or
 * (any other channel) a value > 0.5. */
static int occupied(const preview *pv, float v)
{
    if (pv->mode == DRAW_ELEMENT) return v >= 1 && v < 4294967296.0f && v == floorf(v);
    return v > 0.5f;
}

enum { FACE_X = 0, FACE_Y, FACE_Z };

/* Draws the +x, +y or +z face of voxel (x, y, z) (value v) into the view:
 * every pixel whose centre's ray meets the face, nearer than what is there,
 * takes the face's colour: base * (AMBIENT + (1 - AMBIENT) * n.l) * (1/2 + d / 2D),
 * d = x + y + z of the point hit, D = X + Y + Z (the nearest corner 1, the
 * farthest 1/2), rounded half up. */
static void draw_face(preview *pv, int face, uint32_t x, uint32_t y, uint32_t z, float v)
{
    panel *p = VIEW(pv);
    const double r2 = sqrt(2.0), r6 = sqrt(6.0);
    const double x0 = x, y0 = y, z0 = z;
    /* the pixel ranges that can see the voxel: a in [a0 - 1, a0 + 1], b in [b0 - 2, b0 + 2] */
    const double a0 = x0 - z0, b0 = 2 * y0 - x0 - z0, s = pv->view_scale;
    const double i_lo = (a0 - 1 + pv->Z) * s / r2 + pv->view_off_i - 0.5;
    const double i_hi = (a0 + 1 + pv->Z) * s / r2 + pv->view_off_i - 0.5;
    const double j_lo = (2.0 * pv->Y - (b0 + 2)) * s / r6 + pv->view_off_j - 0.5;
    const double j_hi = (2.0 * pv->Y - (b0 - 2)) * s / r6 + pv->view_off_j - 0.5;
    if (i_hi < 0 || j_hi < 0 || i_lo > p->w || j_lo > p->h) return;
    const uint32_t i0 = i_lo < 1 ? 0 : (uint32_t)i_lo - 1, j0 = j_lo < 1 ? 0 : (uint32_t)j_lo - 1;
    const uint32_t i1 = i_hi + 2 > p->w ? p->w : (uint32_t)i_hi + 2, j1 = j_hi + 2 > p->h ? p->h : (uint32_t)j_hi + 2;
    static const double normal_light[3] = { LIGHT_X, LIGHT_Y, LIGHT_Z };
    const double ln = sqrt(LIGHT_X * LIGHT_X + LIGHT_Y * LIGHT_Y + LIGHT_Z * LIGHT_Z);
    const double lambert = AMBIENT + (1 - AMBIENT) * normal_light[face] / ln;
    const double D = (double)pv->X + pv->Y + pv->Z;
    uint8_t base[3] = { 255, 255, 255 };
    if (pv->bpp == 3) element_rgb(v, base);
    for (uint32_t j = j0; j < j1; j++) {
        const double b = pv->row_b[j];
        for (uint32_t i = i0; i < i1; i++) {
            const double a = pv->col_a[i];
            double hx, hy, hz; /* the point of the face the ray meets */
            if (face == FACE_X) {
                hx = x0 + 1;
                hz = hx - a;
                hy = (b + hx + hz) / 2;
                if (!(hz >= z0 && hz < z0 + 1 && hy >= y0 && hy < y0 + 1)) continue;
            } else if (face == FACE_Y) {
                hy = y0 + 1;
                const double sum = 2 * hy - b; /* x + z */
                hx = (sum + a) / 2;
                hz = (sum - a) / 2;
                if (!(hx >= x0 && hx < x0 + 1 && hz >= z0 && hz < z0 + 1)) continue;
            } else {
                hz = z0 + 1;
                hx = a + hz;
                hy = (b + hx + hz) / 2;
                if (!(hx >= x0 && hx < x0 + 1 && hy >= y0 && hy < y0 + 1)) continue;
            }
            const double d = (hx + hy + hz) / D; /* 0 .. 1 */
            const uint32_t q = 1u + (uint32_t)(d * 4294967000.0);
            uint32_t *dp = &pv->depth[(size_t)j * p->w + i];
            if (q <= *dp) continue;
            *dp = q;
            const double k = lambert * (0.5 + 0.5 * d);
            uint8_t *px = p->pix + ((size_t)j * p->w + i) * pv->bpp;
            for (uint32_t c = 0; c < pv->bpp; c++) px[c] = (uint8_t)floor(base[c] * k + 0.5);
        }
    }
}

/* Adds slice z to the view: the +z faces of slice z - 1 that slice z does
 * not cover, the +x and +y faces of slice z, and after the last slice its
 * +z faces. */
static void view_slice(preview *pv, uint32_t z, const float *values)
{
    const uint32_t X = pv->X, Y = pv->Y;
    if (pv->have_prev)
        for (uint32_t y = 0; y < Y; y++)
            for (uint32_t x = 0; x < X; x++) {
                const size_t at = (size_t)y * X + x;
                if (occupied(pv, pv->prev[at]) && !occupied(pv, values[at]))
                    draw_face(pv, FACE_Z, x, y, z - 1, pv->prev[at]);
            }
    for (uint32_t y = 0; y < Y; y++)
        for (uint32_t x = 0; x < X; x++) {
            const size_t at = (size_t)y * X + x;
            if (!occupied(pv, values[at])) continue;
            if (x + 1 == X || !occupied(pv, values[at + 1])) draw_face(pv, FACE_X, x, y, z, values[at]);
            if (y + 1 == Y || !occupied(pv, values[at + X])) draw_face(pv, FACE_Y, x, y, z, values[at]);
            if (z + 1 == pv->Z) draw_face(pv, FACE_Z, x, y, z, values[at]);
        }
    memcpy(pv->prev, values, (size_t)X * Y * sizeof *values);
    pv->have_prev = 1;
}

static int on_slice(void *user, uint32_t z, const float *values)
{
    preview *pv = user;
    if (!pv->ready) return 1; /* cannot happen: the layout is made before reading */
    const uint32_t X = pv->X, Y = pv->Y, Z = pv->Z, bpp = pv->bpp;
    if (pv->mode != DRAW_SHADE) view_slice(pv, z, values);
    /* montage panels: the whole slice, y up (row j from the top shows y = floor((h-1-j) * Y / h)) */
    for (uint32_t k = 0; k <= pv->n; k++) {
        panel *p = k < pv->n ? &pv->panels[k] : &pv->panels[pv->n]; /* k == n: the z = Z/2 panel */
        if (k < pv->n ? pv->zk[k] != z : z != Z / 2) continue;
        for (uint32_t j = 0; j < p->h; j++) {
            uint32_t y = (uint32_t)((uint64_t)(p->h - 1 - j) * Y / p->h);
            for (uint32_t i = 0; i < p->w; i++) {
                uint32_t x = (uint32_t)((uint64_t)i * X / p->w);
                draw(pv, p->pix + ((size_t)j * p->w + i) * bpp, values[(size_t)y * X + x]);
            }
        }
    }
    /* y = Y/2 (x right, z up) and x = X/2 (y right, z up): the panel rows that sample z */
    for (int which = 1; which <= 2; which++) {
        panel *p = &pv->panels[pv->n + (uint32_t)which];
        for (uint32_t j = 0; j < p->h; j++) {
            if ((uint32_t)((uint64_t)(p->h - 1 - j) * Z / p->h) != z) continue;
            uint8_t *row = p->pix + (size_t)j * p->w * bpp;
            for (uint32_t i = 0; i < p->w; i++) {
                size_t at = which == 1 ? (size_t)(Y / 2) * X + (size_t)((uint64_t)i * X / p->w)
                                       : (size_t)((uint64_t)i * Y / p->w) * X + X / 2;
                draw(pv, row + (size_t)i * bpp, values[at]);
            }
        }
    }
    return 0;
}

/* ---- labels ------------------------------------------------------------------ */

static void add_text(text_item *t, size_t *n, uint32_t x, uint32_t y, uint32_t w, const char *fmt, ...)
    __attribute__((format(printf, 6, 7)));

static void add_text(text_item *t, size_t *n, uint32_t x, uint32_t y, uint32_t w, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(t[*n].s, sizeof t[*n].s, fmt, ap);
    va_end(ap);
    t[*n].x = x;
    t[*n].y = y;
    t[*n].w = w;
    (*n)++;
}

/* The labels of a panel p: a caption above it (from the gutter's left edge,
 * as wide as the cell less one pixel), the vertical axis's arrow and letter
 * in the gutter from the panel's top (when the panel is at least 15 pixels
 * tall), the horizontal axis's letter and arrow under the panel's right end
 * (when they fit in the cell). */
static void panel_labels(text_item *t, size_t *n, const panel *p, const char *caption, char right, char up)
{
    const uint32_t cx = p->x0 - GUT;
    add_text(t, n, cx + 1, p->y0 - CAP + 1, GUT + p->w - 1, "%s", caption);
    if (up && p->h >= 2 * GLYPH_H + 1) {
        add_text(t, n, cx + 1, p->y0, GLYPH_W, "^");
        add_text(t, n, cx + 1, p->y0 + GLYPH_H + 1, GLYPH_W, "%c", up);
    }
    const uint32_t tw = ADVANCE + GLYPH_W;
    if (right && GUT + p->w >= tw + 1) add_text(t, n, p->x0 + p->w - tw, p->y0 + p->h + 1, tw, "%c>", right);
}

/* World coordinate of the centre of voxel index i along `axis`. */
static double centre(const clvox_volume_info *in, int axis, uint32_t i)
{
    return in->origin[axis] + ((double)i + 0.5) * in->voxel_size[axis];
}

/* Every label of the picture, in drawing order; returns how many (t holds
 * 4 * (n + 3) + 1 + LEGEND_LINES). */
static size_t make_labels(const preview *pv, const char *channel, text_item *t)
{
    const clvox_volume_info *in = pv->info;
    size_t n = 0;
    char cap[64];
    for (uint32_t k = 0; k < pv->n; k++) {
        snprintf(cap, sizeof cap, "z=%u %.4g", pv->zk[k], centre(in, 2, pv->zk[k]));
        panel_labels(t, &n, &pv->panels[k], cap, 'x', 'y');
    }
    snprintf(cap, sizeof cap, "z=%u %.4g", pv->Z / 2, centre(in, 2, pv->Z / 2));
    panel_labels(t, &n, &pv->panels[pv->n], cap, 'x', 'y');
    snprintf(cap, sizeof cap, "y=%u %.4g", pv->Y / 2, centre(in, 1, pv->Y / 2));
    panel_labels(t, &n, &pv->panels[pv->n + 1], cap, 'x', 'z');
    snprintf(cap, sizeof cap, "x=%u %.4g", pv->X / 2, centre(in, 0, pv->X / 2));
    panel_labels(t, &n, &pv->panels[pv->n + 2], cap, 'y', 'z');
    const panel *v = VIEW(pv);
    panel_labels(t, &n, v, "3-d view", 0, 0);
    /* the legend, right of the view */
    const uint32_t lx = v->x0 + v->w + BORDER + 2, lw = pv->width > lx + BORDER ? pv->width - lx - BORDER : 0;
    uint32_t ly = BORDER + 1;
    add_text(t, &n, lx, ly, lw, "%u x %u x %u voxels, channel %s", pv->X, pv->Y, pv->Z, channel);
    add_text(t, &n, lx, ly += CAP, lw, "origin (%.4g, %.4g, %.4g), voxel %.4g x %.4g x %.4g", in->origin[0],
             in->origin[1], in->origin[2], in->voxel_size[0], in->voxel_size[1], in->voxel_size[2]);
    add_text(t, &n, lx, ly += CAP, lw, "3-d: seen from (1,1,1), y up, lit from (1,3,2)");
    add_text(t, &n, lx, ly += CAP, lw, "slices: x right, y up; z=index, then world z of the voxel centres");
    add_text(t, &n, lx, ly += CAP, lw, "bottom row: z=z/2 (x,y), y=y/2 (x,z), x=x/2 (y,z)");
    return n;
}

/* Draws the labels' pixels of picture row y into `row` (RGB). */
static void draw_labels(const text_item *t, size_t n, uint32_t width, uint32_t y, uint8_t *row)
{
    for (size_t k = 0; k < n; k++) {
        if (y < t[k].y || y >= t[k].y + GLYPH_H) continue;
        const uint32_t r = y - t[k].y;
        for (size_t c = 0; t[k].s[c]; c++) {
            const uint64_t gx = t[k].x + c * ADVANCE;
            if (gx + GLYPH_W > (uint64_t)t[k].x + t[k].w || gx + GLYPH_W > width) break;
            const glyph *g = find_glyph(t[k].s[c]);
            for (uint32_t b = 0; b < GLYPH_W; b++)
                if (g->rows[r][b] == '#') memcpy(row + 3 * (gx + b), TEXT_RGB, 3);
        }
    }
}

/* ---- the PNG ------------------------------------------------------------------ */

typedef struct png_failure {
    jmp_buf jmp;
    char msg[256];
} png_failure;

static void png_on_error(png_structp png, png_const_charp msg)
{
    png_failure *f = png_get_error_ptr(png);
    snprintf(f->msg, sizeof f->msg, "%s", msg ? msg : "libpng error");
    longjmp(f->jmp, 1);
}

static void png_on_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg; /* warnings are not errors; stay quiet */
}

/* Writes the picture to `f` row by row (one RGB row buffer), the labels t
 * (nt) drawn over the border. 0 on success, else the message is in fail_msg. */
static int write_png(FILE *f, const preview *pv, const text_item *t, size_t nt, uint8_t *row, char *fail_msg,
                     size_t size)
{
    png_failure failure;
    failure.msg[0] = '\0';
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &failure, png_on_error, png_on_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        png_destroy_write_struct(&png, &info);
        snprintf(fail_msg, size, "out of memory in libpng");
        return 1;
    }
    if (setjmp(failure.jmp)) {
        png_destroy_write_struct(&png, &info);
        snprintf(fail_msg, size, "libpng: %s", failure.msg);
        return 1;
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, pv->width, pv->height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    for (uint32_t y = 0; y < pv->height; y++) {
        for (uint32_t x = 0; x < pv->width; x++) memcpy(row + 3 * (size_t)x, BORDER_RGB, 3);
        for (uint32_t k = 0; k < pv->n + 4; k++) {
            const panel *p = &pv->panels[k];
            if (y < p->y0 || y >= p->y0 + p->h) continue;
            const uint8_t *g = p->pix + (size_t)(y - p->y0) * p->w * pv->bpp;
            uint8_t *d = row + 3 * (size_t)p->x0;
            if (pv->bpp == 3) memcpy(d, g, 3 * (size_t)p->w);
            else
                for (uint32_t i = 0; i < p->w; i++) d[3 * i] = d[3 * i + 1] = d[3 * i + 2] = g[i];
        }
        draw_labels(t, nt, pv->width, y, row);
        png_write_row(png, row);
    }
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    return 0;
}

/* Writes the picture to a file without a name in the directory of `path`
 * and names it `path` once it is complete and synced (clvox_output_file_*). */
static int save_png(clvox_context *ctx, const char *path, const preview *pv, const char *channel)
{
    uint8_t *row = malloc((size_t)pv->width * 3);
    text_item *t = malloc((4 * ((size_t)pv->n + 3) + 1 + LEGEND_LINES) * sizeof *t);
    if (!row || !t) {
        free(row);
        free(t);
        return fail(EXIT_RUNTIME, "out of memory");
    }
    const size_t nt = make_labels(pv, channel, t);
    clvox_output_file *of = NULL;
    char why[320] = "";
    clvox_status st = clvox_output_file_create(ctx, path, &of);
    if (st != CLVOX_OK) {
        free(row);
        free(t);
        return fail_status(ctx, st, ROLE_OUTPUT);
    }
    int fd2 = dup(clvox_output_file_fd(of)); /* the stream's own descriptor: the file's stays open for the commit */
    FILE *f = fd2 >= 0 ? fdopen(fd2, "wb") : NULL;
    if (!f) {
        int e = errno;
        if (fd2 >= 0) close(fd2);
        clvox_output_file_discard(of);
        free(row);
        free(t);
        return fail(EXIT_RUNTIME, "cannot write '%s': %s", path, strerror(e));
    }
    int bad = write_png(f, pv, t, nt, row, why, sizeof why);
    free(row);
    free(t);
    if (!bad && fflush(f) != 0) {
        bad = 1;
        snprintf(why, sizeof why, "%s", strerror(errno));
    }
    if (!bad && fsync(fileno(f)) != 0) { /* on disk before it gets its name */
        bad = 1;
        snprintf(why, sizeof why, "%s", strerror(errno));
    }
    if (fclose(f) != 0 && !bad) {
        bad = 1;
        snprintf(why, sizeof why, "%s", strerror(errno));
    }
    if (bad) {
        clvox_output_file_discard(of);
        return fail(EXIT_OUTPUT, "writing '%s' failed: %s", path, why);
    }
    st = clvox_output_file_commit(of, NULL);
    return st == CLVOX_OK ? EXIT_OK : fail_status(ctx, st, ROLE_OUTPUT);
}

/* ---- command ------------------------------------------------------------------- */

static void print_preview_help(void)
{
    printf(
"Usage: clvox preview FILE -o OUT.png [--slices N] [--size PX]\n"
"                     [--channel NAME] [--shade]\n"
"\n"
"Draws a clvox volume as an 8-bit RGB PNG: a shaded 3-D view of the object,\n"
"N evenly spaced z slices and the three central orthogonal slices, each\n"
"labelled. Reads the file once, slice by slice (memory: the picture's panels,\n"
"a depth buffer and one slice). Needs no OpenCL device. The same file gives\n"
"the same bytes.\n"
"\n"
"Options:\n"
"  -o, --output OUT.png     the picture (required); written without a name in\n"
"                           the same directory and named OUT.png on success;\n"
"                           never replaces anything but a regular file\n"
"  --slices N               z slices in the montage, 1..%u (default %u); more\n"
"                           than Z is lowered to Z\n"
"  --size PX                longer side of every panel in pixels, 1..%u\n"
"                           (default %u); the whole picture may have at most\n"
"                           %llu pixels\n"
"  --channel NAME           channel to draw (default: element if the file has\n"
"                           it, else coverage if it has that, else occupancy)\n"
"  --shade                  element colours of the slices shaded by the score\n"
"                           channel (palette runs): c * (1 + s) / 2, s = the\n"
"                           score's grey level / 255, rounded half up\n"
"  -h, --help               print this help and exit\n"
"\n"
"Layout (X, Y, Z: the volume's dimensions; integer division throughout):\n"
"  - Every panel of w x h pixels sits in a cell of (%u + w) x (%u + h + %u):\n"
"    a %u-pixel caption strip above it, a %u-pixel gutter left of it (the\n"
"    vertical axis: an arrow and its letter, when h >= 15) and a %u-pixel\n"
"    strip below it (the horizontal axis, e.g. 'x>', at its right end).\n"
"    Labels use a 5 x 7 pixel font in light yellow (RGB %u,%u,%u).\n"
"  - Top: the 3-D view, PX x PX (caption '3-d view'), and right of it a\n"
"    legend (dimensions, channel, origin, voxel size, directions).\n"
"  - Montage: slices z_k = floor((k + 0.5) * Z / N) for k = 0..N-1, in a grid\n"
"    of C = ceil(sqrt(N)) columns and R = ceil(N / C) rows, filled row by row\n"
"    from the top left (N = 16: 4 x 4). Each panel shows x to the right and y\n"
"    up (the volume's own frame); its caption 'z=K W' gives the slice index\n"
"    K and the world z W of its voxel centres (origin + (K + 0.5) * voxel).\n"
"  - Below the montage, one row, left to right: z = Z/2 (x right, y up),\n"
"    y = Y/2 (x right, z up), x = X/2 (y right, z up), captioned the same way.\n"
"  - Slice panel size: a source of a x b cells becomes round(a*PX/L) x\n"
"    round(b*PX/L) pixels, L = max(a, b) (halves up, at least 1), so the\n"
"    longer side is PX; nearest neighbour: pixel p (columns from the left,\n"
"    rows from the bottom) shows cell floor(p * cells / pixels). Voxel sizes\n"
"    are ignored: every voxel is drawn square (and as a cube in 3-D).\n"
"  - A %u-pixel dark blue (RGB %u,%u,%u) border around and between all cells;\n"
"    the same colour fills the rest. Top row at y = %u, its cell at x = %u;\n"
"    montage cell k at x = %u + (k %% C) * (%u + w + %u),\n"
"    y = T + (k / C) * (%u + h + %u + %u) with T = %u + max(%u + PX + %u, %u) + %u;\n"
"    the bottom row at y = T + R * (%u + h + %u + %u), its cells from x = %u,\n"
"    each after the last one's width plus %u. Picture width = the widest row\n"
"    plus %u, height = the bottom row's y + its tallest cell + %u. The legend\n"
"    is cut at the picture's width.\n"
        , MAX_SLICES, DEFAULT_SLICES, MAX_SIZE, DEFAULT_SIZE, (unsigned long long)MAX_PIXELS,
        GUT, CAP, CAP, CAP, GUT, CAP, (unsigned)TEXT_RGB[0], (unsigned)TEXT_RGB[1], (unsigned)TEXT_RGB[2],
        BORDER, (unsigned)BORDER_RGB[0], (unsigned)BORDER_RGB[1], (unsigned)BORDER_RGB[2], BORDER, BORDER,
        BORDER, GUT, BORDER, CAP, CAP, BORDER, BORDER, CAP, CAP, LEGEND_LINES * CAP, BORDER,
        CAP, CAP, BORDER, BORDER, BORDER, BORDER, BORDER);
    printf(
"  - 3-D view: the voxels with value > 0.5 (element: index >= 1) as unit\n"
"    cubes, orthographic, seen from the direction (1,1,1) (from +x, +y, +z\n"
"    towards the origin) with y up on the picture: a point (x, y, z) lands at\n"
"    right = (x - z) / sqrt 2, up = (2y - x - z) / sqrt 6, the whole grid box\n"
"    scaled to fit PX x PX and centred. Each visible face is lit from the\n"
"    direction l = (1,3,2) / sqrt 14: grey (or element colour) *\n"
"    (0.3 + 0.7 * n.l) * (0.5 + 0.5 * d / (X + Y + Z)), n the face's normal,\n"
"    d = x + y + z of the point seen (nearer is brighter), rounded; so tops\n"
"    (+y) are brightest, fronts (+z) middle, right sides (+x) darkest. Empty\n"
"    background is black; an empty volume gives a black view. Built while\n"
"    streaming, with a depth buffer of PX x PX.\n"
"  - Grey levels: occupancy 255 (white) when > 0.5, else 0 (black); any other\n"
"    channel round(255 * value), clamped to 0..255 (NaN: 0).\n"
"  - Element colours (channel element): index 0 (empty) black, 1 (full) RGB\n"
"    %u,%u,%u, any other index e the hue H = (e - 2) * 949 mod 1536 (the first\n"
"    1536 all differ, neighbours far apart): with f = H mod 256,\n"
"    up = 50 + 180 * f / 255, down = 230 - 180 * f / 255, sector H / 256 =\n"
"    0..5 gives (230,up,50) (down,230,50) (50,230,up) (50,down,230)\n"
"    (up,50,230) (230,50,down); a value that is not an integer >= 0 is drawn\n"
"    as 0.\n"
"\n"
"Exit codes: 0 ok, 2 usage error, 4 FILE missing, not a clvox volume or\n"
"without the channel, 5 OUT.png can not be written, 1 other failures. Errors\n"
"are one line on stderr; a failed run leaves no file.\n",
        (unsigned)FULL_RGB[0], (unsigned)FULL_RGB[1], (unsigned)FULL_RGB[2]);
}

#define PREVIEW_USAGE(...) fail(EXIT_USAGE, __VA_ARGS__)

/* A wrapper that makes the layout when the first slice arrives (the header
 * is in pv->info by then). */
typedef struct reading {
    preview *pv;
    uint32_t slices, px;
} reading;

static int on_first_slice(void *user, uint32_t z, const float *values)
{
    reading *rd = user;
    preview *pv = rd->pv;
    const clvox_volume_info *in = pv->info;
    if (!pv->ready) {
        if (preview_layout(pv, in->dims[0], in->dims[1], in->dims[2], rd->slices, rd->px) != 0) return 1;
        pv->ready = 1;
    } else if (in->dims[0] != pv->X || in->dims[1] != pv->Y || in->dims[2] != pv->Z) { /* a second pass */
        snprintf(pv->why, sizeof pv->why, "the volume changed between two passes over it");
        pv->failed = 1;
        return 1;
    }
    return on_slice(pv, z, values);
}

int cmd_preview(int argc, char **argv)
{
    const char *file = NULL, *output = NULL, *channel = NULL;
    uint32_t slices = DEFAULT_SLICES, px = DEFAULT_SIZE;
    int shade = 0;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        const char *v = NULL, *why = NULL;
        int missing = 0;
        if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
            print_preview_help();
            return EXIT_OK;
        }
        if (a[0] != '-' || a[1] == '\0') {
            if (file)
                return PREVIEW_USAGE("preview: more than one file given: '%s' and '%s' (see clvox preview --help)",
                                     file, a);
            file = a;
        } else if (match_value(argc, argv, &i, "-o", "--output", &v, &missing)) {
            if (missing || !*v) return PREVIEW_USAGE("preview: -o needs a file name (see clvox preview --help)");
            output = v;
        } else if (match_value(argc, argv, &i, NULL, "--slices", &v, &missing)) {
            if (missing) return PREVIEW_USAGE("preview: --slices needs a value (see clvox preview --help)");
            if ((why = parse_u32(v, 1, &slices, NULL)) || slices > MAX_SLICES)
                return PREVIEW_USAGE("preview: --slices '%s': %s (1 to %u)", v, why ? why : "too large", MAX_SLICES);
        } else if (match_value(argc, argv, &i, NULL, "--size", &v, &missing)) {
            if (missing) return PREVIEW_USAGE("preview: --size needs a value (see clvox preview --help)");
            if ((why = parse_u32(v, 1, &px, NULL)) || px > MAX_SIZE)
                return PREVIEW_USAGE("preview: --size '%s': %s (1 to %u pixels)", v, why ? why : "too large",
                                     MAX_SIZE);
        } else if (match_value(argc, argv, &i, NULL, "--channel", &v, &missing)) {
            if (missing || !*v) return PREVIEW_USAGE("preview: --channel needs a name (see clvox preview --help)");
            channel = v;
        } else if (strcmp(a, "--shade") == 0) {
            shade = 1;
        } else {
            return PREVIEW_USAGE("preview: unknown option '%s' (see clvox preview --help)", a);
        }
    }
    if (!file) return PREVIEW_USAGE("preview: missing FILE (see clvox preview --help)");
    if (!output) return PREVIEW_USAGE("preview: missing -o OUT.png (see clvox preview --help)");
    if (shade && channel && strcmp(channel, "element") != 0)
        return PREVIEW_USAGE("preview: --shade shades element colours; --channel %s is drawn in grey levels", channel);
    int rc = check_output(output);
    if (rc != EXIT_OK) return rc;
    struct stat in_sb, out_sb;
    if (lstat(output, &out_sb) == 0) {
        if (!S_ISREG(out_sb.st_mode)) return fail(EXIT_OUTPUT, "cannot write '%s': it is not a regular file", output);
        if (stat(file, &in_sb) == 0 && in_sb.st_dev == out_sb.st_dev && in_sb.st_ino == out_sb.st_ino)
            return PREVIEW_USAGE("preview: the output '%s' is the input file", output);
    }

    clvox_context *ctx = NULL;
    clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
    co.host_only = 1;
    clvox_status st = clvox_context_create(&co, &ctx);
    if (st != CLVOX_OK) {
        rc = fail_status(ctx, st, ROLE_OTHER);
        clvox_context_destroy(ctx);
        return rc;
    }

    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    preview pv;
    memset(&pv, 0, sizeof pv);
    pv.info = &info;
    reading rd = { &pv, slices, px };
    /* default channel: element, else coverage, else occupancy; a failed
     * attempt still reads the header (info.dims set), so the next default
     * is chosen only when the channel is missing, not on a read error */
    static const char *const defaults[] = { "element", "coverage", "occupancy" };
    const char *ch = channel ? channel : defaults[0];
    for (size_t k = 0;; k++) {
        pv.mode = strcmp(ch, "element") == 0 ? DRAW_ELEMENT : strcmp(ch, "occupancy") == 0 ? DRAW_BINARY : DRAW_GREY;
        pv.bpp = pv.mode == DRAW_ELEMENT ? 3 : 1;
        st = clvox_volume_read_slices(ctx, file, ch, &info, on_first_slice, &rd);
        if (channel || st != CLVOX_ERR_EXR || !info.dims[0] || has_channel(info.channels, ch)) break;
        while (k + 1 < sizeof defaults / sizeof defaults[0] && !has_channel(info.channels, defaults[k + 1])) k++;
        if (k + 1 == sizeof defaults / sizeof defaults[0]) {
            rc = fail(EXIT_INPUT, "'%s' has neither an element, a coverage nor an occupancy channel (has: %s): "
                      "choose one with --channel", file, info.channels);
            goto done;
        }
        ch = defaults[k + 1];
        if (shade) {
            rc = fail(EXIT_INPUT, "preview: --shade needs an element channel; '%s' has: %s", file, info.channels);
            goto done;
        }
    }
    if (st == CLVOX_OK && shade) { /* second pass: darken by the score */
        if (!has_channel(info.channels, "score")) {
            rc = fail(EXIT_INPUT, "preview: --shade needs a score channel; '%s' has: %s", file, info.channels);
            goto done;
        }
        pv.mode = DRAW_SHADE;
        st = clvox_volume_read_slices(ctx, file, "score", &info, on_first_slice, &rd);
    }
    if (pv.too_large) {
        rc = fail(EXIT_USAGE, "preview: %s", pv.why);
        goto done;
    }
    if (st == CLVOX_ERR_CANCELLED && (!pv.ready || pv.failed)) {
        rc = fail(pv.failed ? EXIT_INPUT : EXIT_RUNTIME, "%s", pv.why);
        goto done;
    }
    if (st != CLVOX_OK) {
        rc = fail_status(ctx, st, ROLE_INPUT);
        goto done;
    }
    rc = save_png(ctx, output, &pv, ch);
    if (rc == EXIT_OK)
        printf("wrote %s: %u x %u pixels, channel %s%s, a 3-D view, %u z slices and the 3 central slices of %u x %u x %u\n",
               output, pv.width, pv.height, ch, shade ? " shaded by score" : "", pv.n, pv.X, pv.Y, pv.Z);
done:
    preview_free(&pv);
    clvox_context_destroy(ctx);
    return rc;
}
