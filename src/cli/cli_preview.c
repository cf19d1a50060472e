/* SPDX-License-Identifier: Apache-2.0 */
/*
 * clvox preview FILE -o OUT.png [--slices N] [--size PX] [--channel NAME] [--shade]
 *
 * A picture of a clvox volume: a montage of N evenly spaced z slices and the
 * three central orthogonal slices, as an 8-bit RGB PNG (libpng). The layout
 * is documented in print_preview_help (and README); in short:
 *  - slices z_k = floor((k + 0.5) * Z / N), k = 0..N-1 (N is first lowered to
 *    Z when larger, so that no slice repeats), in a grid of C = ceil(sqrt(N))
 *    columns and R = ceil(N / C) rows, row by row;
 *  - below it one row: z = Z/2 (x right, y down), y = Y/2 (x right, z down),
 *    x = X/2 (y right, z down), integer halves;
 *  - each panel is resampled by nearest neighbour so that its longer side is
 *    PX: an n_a x n_b source becomes round(n_a*PX/L) x round(n_b*PX/L) pixels
 *    (L = max(n_a, n_b), halves up, at least 1), pixel p takes source index
 *    floor(p * n_src / n_dst); voxel sizes are ignored (one voxel, one cell);
 *  - a BORDER-pixel border of BORDER_RGB around and between panels, and the
 *    same colour where the rows leave the image empty.
 * Grey levels: "occupancy" 255 when > 0.5 else 0 (the filled rule); any other
 * channel round(255 * v) clamped to [0, 255], NaN 0. "element" (palette
 * runs; the default when the file has it) is drawn in colour, a fixed
 * colour per element index (element_rgb), optionally shaded by "score"
 * (--shade: a second pass over the file that darkens each pixel in place).
 *
 * Streaming: one pass over the file (clvox_volume_read_slices); each slice
 * fills the panels that sample it, so memory is the panels plus one slice
 * (the library's) whatever Z is. The layout needs the dimensions, which the
 * library has put into `info` before the first slice arrives.
 *
 * The PNG is written to a file without a name in the directory of OUT
 * (O_TMPFILE; where the file system lacks it, ".clvox-<pid>-<n>.tmp"),
 * flushed to disk and only then named OUT (clvox_output_file_*); any
 * failure removes it. Nothing that is not a regular file at OUT is ever
 * replaced.
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
static const unsigned char BORDER_RGB[3] = { 0, 0, 128 }; /* dark blue: no grey level is blue */

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
    panel *panels;        /* n montage panels, then XY (z = Z/2), XZ (y = Y/2), YZ (x = X/2) */
    uint32_t width, height;
    uint32_t bpp;         /* bytes per panel pixel: 1 (grey) or 3 (element colours) */
    draw_mode mode;       /* of the current pass */
    /* set by the first slice callback */
    const clvox_volume_info *info;
    int ready;            /* layout made */
    int failed;           /* a later pass refused (message in why) */
    int too_large;        /* layout refused (message in why) */
    char why[256];
} preview;

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
        for (uint32_t k = 0; k < pv->n + 3; k++) free(pv->panels[k].pix);
    free(pv->panels);
    free(pv->zk);
}

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
    uint64_t montage_w = BORDER + (uint64_t)pv->cols * (sz[0].w + BORDER);
    uint64_t montage_h = BORDER + (uint64_t)pv->rows * (sz[0].h + BORDER);
    uint64_t ortho_w = BORDER + (uint64_t)sz[0].w + BORDER + sz[1].w + BORDER + sz[2].w + BORDER;
    uint64_t ortho_h = 0;
    for (int i = 0; i < 3; i++)
        if (sz[i].h > ortho_h) ortho_h = sz[i].h;
    ortho_h += BORDER;
    uint64_t W = montage_w > ortho_w ? montage_w : ortho_w, H = montage_h + ortho_h;
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
    pv->panels = calloc((size_t)pv->n + 3, sizeof *pv->panels);
    if (!pv->zk || !pv->panels) goto oom;
    for (uint32_t k = 0; k < pv->n; k++) {
        pv->zk[k] = (uint32_t)(((2ull * k + 1) * Z) / (2ull * pv->n)); /* floor((k + 0.5) * Z / N) */
        panel *p = &pv->panels[k];
        *p = sz[0];
        p->x0 = BORDER + (k % pv->cols) * (sz[0].w + BORDER);
        p->y0 = BORDER + (k / pv->cols) * (sz[0].h + BORDER);
    }
    uint32_t x = BORDER;
    for (int i = 0; i < 3; i++) {
        panel *p = &pv->panels[pv->n + (uint32_t)i];
        *p = sz[i];
        p->x0 = x;
        p->y0 = (uint32_t)montage_h;
        x += p->w + BORDER;
    }
    for (uint32_t k = 0; k < pv->n + 3; k++) {
        panel *p = &pv->panels[k];
        p->pix = calloc((size_t)p->w * p->h, pv->bpp);
        if (!p->pix) goto oom;
    }
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

static int on_slice(void *user, uint32_t z, const float *values)
{
    preview *pv = user;
    if (!pv->ready) return 1; /* cannot happen: the layout is made before reading */
    const uint32_t X = pv->X, Y = pv->Y, Z = pv->Z, bpp = pv->bpp;
    /* montage panels: the whole slice */
    for (uint32_t k = 0; k <= pv->n; k++) {
        panel *p = k < pv->n ? &pv->panels[k] : &pv->panels[pv->n]; /* k == n: the z = Z/2 panel */
        if (k < pv->n ? pv->zk[k] != z : z != Z / 2) continue;
        for (uint32_t j = 0; j < p->h; j++) {
            uint32_t y = (uint32_t)((uint64_t)j * Y / p->h);
            for (uint32_t i = 0; i < p->w; i++) {
                uint32_t x = (uint32_t)((uint64_t)i * X / p->w);
                draw(pv, p->pix + ((size_t)j * p->w + i) * bpp, values[(size_t)y * X + x]);
            }
        }
    }
    /* y = Y/2 (x right, z down) and x = X/2 (y right, z down): the panel rows that sample z */
    for (int which = 1; which <= 2; which++) {
        panel *p = &pv->panels[pv->n + (uint32_t)which];
        for (uint32_t j = 0; j < p->h; j++) {
            if ((uint32_t)((uint64_t)j * Z / p->h) != z) continue;
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

/* Writes the picture to `f` row by row (one RGB row buffer). 0 on success,
 * else the message is in fail_msg. */
static int write_png(FILE *f, const preview *pv, uint8_t *row, char *fail_msg, size_t size)
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
        for (uint32_t k = 0; k < pv->n + 3; k++) {
            const panel *p = &pv->panels[k];
            if (y < p->y0 || y >= p->y0 + p->h) continue;
            const uint8_t *g = p->pix + (size_t)(y - p->y0) * p->w * pv->bpp;
            uint8_t *d = row + 3 * (size_t)p->x0;
            if (pv->bpp == 3) memcpy(d, g, 3 * (size_t)p->w);
            else
                for (uint32_t i = 0; i < p->w; i++) d[3 * i] = d[3 * i + 1] = d[3 * i + 2] = g[i];
        }
        png_write_row(png, row);
    }
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    return 0;
}

/* Writes the picture to a file without a name in the directory of `path`
 * and names it `path` once it is complete and synced (clvox_output_file_*). */
static int save_png(clvox_context *ctx, const char *path, const preview *pv)
{
    uint8_t *row = malloc((size_t)pv->width * 3);
    if (!row) return fail(EXIT_RUNTIME, "out of memory");
    clvox_output_file *of = NULL;
    char why[320] = "";
    clvox_status st = clvox_output_file_create(ctx, path, &of);
    if (st != CLVOX_OK) {
        free(row);
        return fail_status(ctx, st, ROLE_OUTPUT);
    }
    int fd2 = dup(clvox_output_file_fd(of)); /* the stream's own descriptor: the file's stays open for the commit */
    FILE *f = fd2 >= 0 ? fdopen(fd2, "wb") : NULL;
    if (!f) {
        int e = errno;
        if (fd2 >= 0) close(fd2);
        clvox_output_file_discard(of);
        free(row);
        return fail(EXIT_RUNTIME, "cannot write '%s': %s", path, strerror(e));
    }
    int bad = write_png(f, pv, row, why, sizeof why);
    free(row);
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
"Draws a clvox volume as an 8-bit RGB PNG: N evenly spaced z slices and the\n"
"three central orthogonal slices. Reads the file once, slice by slice (memory:\n"
"the picture's panels plus one slice). Needs no OpenCL device.\n"
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
"  --shade                  element colours shaded by the score channel\n"
"                           (palette runs): c * (1 + s) / 2, s = the score's\n"
"                           grey level / 255, rounded half up\n"
"  -h, --help               print this help and exit\n"
"\n"
"Layout (X, Y, Z: the volume's dimensions; integer division throughout):\n"
"  - Montage: slices z_k = floor((k + 0.5) * Z / N) for k = 0..N-1, in a grid\n"
"    of C = ceil(sqrt(N)) columns and R = ceil(N / C) rows, filled row by row\n"
"    from the top left (N = 16: 4 x 4). Each panel shows x to the right and y\n"
"    down.\n"
"  - Below the montage, one row, left to right: z = Z/2 (x right, y down),\n"
"    y = Y/2 (x right, z down), x = X/2 (y right, z down).\n"
"  - Panel size: a source of a x b cells becomes round(a*PX/L) x round(b*PX/L)\n"
"    pixels, L = max(a, b) (halves up, at least 1), so the longer side is PX;\n"
"    nearest neighbour: pixel p shows cell floor(p * cells / pixels). Voxel\n"
"    sizes are ignored: every voxel is drawn square.\n"
"  - A %u-pixel dark blue (RGB %u,%u,%u) border around and between all panels;\n"
"    the same colour fills what the two rows leave empty. Montage panel k\n"
"    starts at x = %u + (k %% C) * (w + %u), y = %u + (k / C) * (h + %u); the\n"
"    bottom row starts at y = %u + R * (h + %u), its panels at x = %u, then\n"
"    after each panel's width plus %u. Picture width = the larger of the two\n"
"    rows, height = montage + tallest bottom panel + %u.\n"
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
        MAX_SLICES, DEFAULT_SLICES, MAX_SIZE, DEFAULT_SIZE, (unsigned long long)MAX_PIXELS, BORDER,
        (unsigned)BORDER_RGB[0], (unsigned)BORDER_RGB[1], (unsigned)BORDER_RGB[2], BORDER, BORDER, BORDER, BORDER, BORDER, BORDER, BORDER,
        BORDER, BORDER, (unsigned)FULL_RGB[0], (unsigned)FULL_RGB[1], (unsigned)FULL_RGB[2]);
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
    rc = save_png(ctx, output, &pv);
    if (rc == EXIT_OK)
        printf("wrote %s: %u x %u pixels, channel %s%s, %u z slices and the 3 central slices of %u x %u x %u\n",
               output, pv.width, pv.height, ch, shade ? " shaded by score" : "", pv.n, pv.X, pv.Y, pv.Z);
done:
    preview_free(&pv);
    clvox_context_destroy(ctx);
    return rc;
}
