/* SPDX-License-Identifier: Apache-2.0 */
/* Past 800 lines on purpose: one test program for the EXR writer and reader,
 * whose round trips share the generated volumes. */
#ifndef _XOPEN_SOURCE
#define _XOPEN_SOURCE 700 /* mknod, S_IFCHR */
#endif
/* EXR writer and reader: round trips for every compression and several
 * grid shapes and slab splits, header attributes, exrheader, failure paths
 * (no file and no temporary file left), and bounded memory. No OpenCL. */
#include "test.h"
#include "exrgen.h"
#include "core/internal.h"

#include <OpenEXR/openexr.h>

#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <string.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

static clvox_context *ctx;
static char dir[1024];

/* ---- helpers ---- */

static uint64_t rng_state = 0x9E3779B97F4A7C15ull;
static uint32_t rnd(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (uint32_t)(rng_state >> 11);
}

static int exists(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0;
}

static long long file_size(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0 ? (long long)sb.st_size : -1;
}

/* Number of temporary files in dir: the writer's ".clvox-*" names and the
 * old "<base>.tmp-*" ones. */
static int temp_files(const char *path)
{
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    char prefix[512];
    snprintf(prefix, sizeof prefix, "%s.tmp-", base);
    DIR *d = opendir(dir);
    int n = 0;
    if (!d) return -1;
    struct dirent *e;
    while ((e = readdir(d)) != NULL)
        if (strncmp(e->d_name, prefix, strlen(prefix)) == 0 || strncmp(e->d_name, ".clvox-", 7) == 0) n++;
    closedir(d);
    return n;
}

/* Number of entries of dir (without . and ..); *longest = the longest name. */
static int dir_count(const char *d_path, size_t *longest)
{
    DIR *d = opendir(d_path);
    int n = 0;
    if (longest) *longest = 0;
    if (!d) return -1;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0) continue;
        n++;
        if (longest && strlen(e->d_name) > *longest) *longest = strlen(e->d_name);
    }
    closedir(d);
    return n;
}

static clvox_grid make_grid(uint32_t X, uint32_t Y, uint32_t Z)
{
    clvox_grid g;
    g.dims[0] = X;
    g.dims[1] = Y;
    g.dims[2] = Z;
    g.origin[0] = -1.25;
    g.origin[1] = 0.1;          /* not exact in binary: must round trip bit for bit */
    g.origin[2] = 1e-300;
    g.voxel_size[0] = 0.5;
    g.voxel_size[1] = 1.0 / 3.0;
    g.voxel_size[2] = 12345.678;
    return g;
}

static const clvox__exr_meta test_meta = { .method = "ray",
                                            .parameters = "axis=x depth=9 leaf=8 \"quoted\" utf8: \xc3\xa9" };

/* Packs rows of X bytes 0/1 into the slab format's bit rows. */
static void pack_bits(uint32_t *dst, const uint8_t *vol, uint32_t X, size_t rows)
{
    const uint32_t W = clvox__row_words(X);
    memset(dst, 0, rows * W * sizeof *dst);
    for (size_t r = 0; r < rows; r++)
        for (uint32_t x = 0; x < X; x++)
            if (vol[r * X + x]) dst[r * W + x / 32] |= 1u << (x % 32);
}

/* The per-voxel data of a test volume, X*Y*Z values each, x fastest; NULL:
 * that plane is not given. */
typedef struct test_planes {
    const uint8_t *occ;    /* 0/1 bytes (given to the writer as bit rows) */
    const uint16_t *cov;   /* HALF bits */
    const uint16_t *elem;  /* element indices */
    const uint16_t *score; /* HALF bits */
} test_planes;

/* Writes the planes of tp in slabs of the given depths (cycled); channels:
 * the mask to open the writer with, meta: its header. */
static clvox_status write_all(const char *path, const clvox_grid *g, const clvox__exr_meta *meta, uint32_t channels,
                              clvox_compression comp, uint32_t threads, const test_planes *tp, const uint32_t *depths,
                              size_t ndepths, uint64_t *bytes)
{
    clvox__exr_writer *w = NULL;
    clvox_status st = clvox__exr_open(ctx, path, g, meta, channels, comp, threads, &w);
    if (st != CLVOX_OK) return st;
    const size_t XY = (size_t)g->dims[0] * g->dims[1], WY = (size_t)clvox__row_words(g->dims[0]) * g->dims[1];
    uint32_t *bits = NULL;
    size_t bits_cap = 0;
    size_t k = 0;
    for (uint32_t z0 = 0; z0 < g->dims[2];) {
        uint32_t nz = depths[k++ % ndepths];
        if (nz > g->dims[2] - z0) nz = g->dims[2] - z0;
        if (WY * nz > bits_cap) {
            free(bits);
            bits_cap = WY * nz;
            bits = malloc(bits_cap * sizeof *bits);
            if (!bits) {
                clvox__exr_abort(w);
                return CLVOX_ERR_OUT_OF_MEMORY;
            }
        }
        const size_t at = (size_t)z0 * XY;
        if (tp->occ) pack_bits(bits, tp->occ + at, g->dims[0], (size_t)g->dims[1] * nz);
        clvox__slab_planes planes = { .occupancy_bits = tp->occ ? bits : NULL,
                                      .coverage_half = tp->cov ? tp->cov + at : NULL,
                                      .element = tp->elem ? tp->elem + at : NULL,
                                      .score_half = tp->score ? tp->score + at : NULL };
        st = clvox__exr_write_slab(w, z0, nz, &planes);
        if (st != CLVOX_OK) {
            free(bits);
            clvox__exr_abort(w);
            return st;
        }
        z0 += nz;
    }
    free(bits);
    return clvox__exr_finish(w, bytes);
}

/* Writes vol (X*Y*Z bytes 0/1) as occupancy and cov (X*Y*Z HALF bits) as
 * coverage, those given (write_all with test_meta). */
static clvox_status write_planes(const char *path, const clvox_grid *g, uint32_t channels, clvox_compression comp,
                                 uint32_t threads, const uint8_t *vol, const uint16_t *cov, const uint32_t *depths,
                                 size_t ndepths, uint64_t *bytes)
{
    const test_planes tp = { .occ = vol, .cov = cov };
    return write_all(path, g, &test_meta, channels, comp, threads, &tp, depths, ndepths, bytes);
}

/* Writes vol (X*Y*Z bytes 0/1) as an occupancy-only file. */
static clvox_status write_volume(const char *path, const clvox_grid *g, clvox_compression comp, uint32_t threads,
                                 const uint8_t *vol, const uint32_t *depths, size_t ndepths, uint64_t *bytes)
{
    return write_planes(path, g, 0, comp, threads, vol, NULL, depths, ndepths, bytes);
}

static void fill_random(uint8_t *vol, size_t n)
{
    for (size_t i = 0; i < n; i++) vol[i] = (uint8_t)(rnd() & 1);
}

static void fill_structured(uint8_t *vol, uint32_t X, uint32_t Y, uint32_t Z)
{
    double cx = X / 2.0, cy = Y / 2.0, cz = Z / 2.0;
    double r = (X < Y ? (X < Z ? X : Z) : (Y < Z ? Y : Z)) / 2.5 + 0.5;
    for (uint32_t z = 0; z < Z; z++)
        for (uint32_t y = 0; y < Y; y++)
            for (uint32_t x = 0; x < X; x++) {
                double dx = x + 0.5 - cx, dy = y + 0.5 - cy, dz = z + 0.5 - cz;
                int in = dx * dx + dy * dy + dz * dz < r * r;
                in |= (x < X / 4 && y >= Y / 2 && z % 3 == 0); /* a slab of plates */
                vol[((size_t)z * Y + y) * X + x] = (uint8_t)in;
            }
}

static uint64_t count(const uint8_t *v, size_t n)
{
    uint64_t c = 0;
    for (size_t i = 0; i < n; i++) c += v[i];
    return c;
}

static const char *comp_names[CLVOX_COMPRESSION_COUNT] = { "rle", "none", "rle", "zips", "zip", "piz" };

/* Writes, reads back and compares everything. */
static void round_trip(uint32_t X, uint32_t Y, uint32_t Z, int structured, clvox_compression comp, uint32_t threads,
                       const uint32_t *depths, size_t ndepths)
{
    char path[2048];
    snprintf(path, sizeof path, "%s/rt_%ux%ux%u_%d_%d_%u.exr", dir, X, Y, Z, structured, (int)comp, threads);
    size_t n = (size_t)X * Y * Z;
    uint8_t *vol = malloc(n), *back = malloc(n + 1);
    if (!vol || !back) {
        CHECK(!"out of memory");
        free(vol);
        free(back);
        return;
    }
    if (structured == 3) { /* alternating: every sample a change, RLE's worst case */
        for (size_t i = 0; i < n; i++) vol[i] = (uint8_t)(i & 1);
    } else if (structured == 2) memset(vol, 1, n); /* full: no change across rows or slices */
    else if (structured) fill_structured(vol, X, Y, Z);
    else fill_random(vol, n);
    clvox_grid g = make_grid(X, Y, Z);
    uint64_t bytes = 0;
    clvox_status st = write_volume(path, &g, comp, threads, vol, depths, ndepths, &bytes);
    CHECK_MSG(st == CLVOX_OK, "%s: %s: %s", path, clvox_status_string(st), clvox_context_error(ctx));
    CHECK_MSG(bytes > 0 && (long long)bytes == file_size(path), "%s: bytes %llu, file %lld", path,
              (unsigned long long)bytes, file_size(path));
    CHECK(temp_files(path) == 0);

    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    memset(back, 0xAB, n + 1);
    st = clvox_volume_read(ctx, path, &info, back, n);
    CHECK_MSG(st == CLVOX_OK, "%s: %s: %s", path, clvox_status_string(st), clvox_context_error(ctx));
    CHECK_MSG(memcmp(vol, back, n) == 0, "%s: voxels differ", path);
    CHECK(back[n] == 0xAB); /* nothing written past the buffer */
    CHECK_MSG(info.filled_voxels == count(vol, n), "%s: filled %llu, expected %llu", path,
              (unsigned long long)info.filled_voxels, (unsigned long long)count(vol, n));
    CHECK(info.dims[0] == X && info.dims[1] == Y && info.dims[2] == Z);
    CHECK(memcmp(info.origin, g.origin, sizeof g.origin) == 0);
    CHECK(memcmp(info.voxel_size, g.voxel_size, sizeof g.voxel_size) == 0);
    CHECK(strcmp(info.method, test_meta.method) == 0);
    CHECK(strcmp(info.parameters, test_meta.parameters) == 0);
    CHECK(strcmp(info.version, CLVOX_VERSION_STRING) == 0);
    CHECK_MSG(strcmp(info.compression, comp_names[comp]) == 0, "compression %s", info.compression);
    CHECK(strcmp(info.channels, "occupancy") == 0);

    /* count only, no buffer */
    clvox_volume_info info2 = CLVOX_VOLUME_INFO_INIT;
    CHECK_OK(ctx, clvox_volume_read(ctx, path, &info2, NULL, 0));
    CHECK(info2.filled_voxels == info.filled_voxels);
    unlink(path);
    free(vol);
    free(back);
}

/* ---- coverage: HALF samples, decoded with OpenEXRCore's generic pipeline ---- */

/* Coverage test data as HALF bits. pattern 0: runs of random length (1 to
 * 3000) of 0 and 1 mostly, of special values (subnormals, 0.5, -0, just
 * under 1), of arbitrary bit patterns and ramps (RLE runs of a delta other
 * than 0x80); pattern 1: a sphere's coverage, 0 outside, 1 inside and a
 * grey shell (bits 0 .. 0x3C00 are HALF 0 .. 1, increasing). */
static void fill_coverage(uint16_t *cov, uint32_t X, uint32_t Y, uint32_t Z, int pattern)
{
    static const uint16_t special[] = { 0x0000, 0x3C00, 0x0001, 0x03FF, 0x0200, 0x3800,
                                        0x0400, 0x3BFF, 0x2E66, 0x8000, 0x3801, 0x37FF };
    const size_t n = (size_t)X * Y * Z;
    if (pattern == 1) {
        double c[3] = { X / 2.0, Y / 2.0, Z / 2.0 };
        double r = (X < Y ? (X < Z ? X : Z) : (Y < Z ? Y : Z)) / 2.5 + 0.5;
        for (uint32_t z = 0; z < Z; z++)
            for (uint32_t y = 0; y < Y; y++)
                for (uint32_t x = 0; x < X; x++) {
                    double dx = x + 0.5 - c[0], dy = y + 0.5 - c[1], dz = z + 0.5 - c[2];
                    double f = r + 0.5 - sqrt(dx * dx + dy * dy + dz * dz);
                    f = f < 0 ? 0 : f > 1 ? 1 : f;
                    cov[((size_t)z * Y + y) * X + x] = (uint16_t)(f * 0x3C00);
                }
        return;
    }
    for (size_t i = 0; i < n;) {
        uint32_t r = rnd() % 8, k = rnd() % 16;
        size_t len = r < 3 ? 1 + rnd() % 3 : r < 6 ? 1 + rnd() % 40 : 100 + rnd() % 2900;
        uint16_t v = k < 6 ? 0x0000 : k < 10 ? 0x3C00 : k < 14 ? special[rnd() % 12] : (uint16_t)rnd();
        for (size_t j = 0; j < len && i < n; j++, i++) cov[i] = k == 15 ? (uint16_t)(v + j * 3) : v;
    }
}

/* Decodes a clvox file with OpenEXRCore's generic decoding pipeline (not
 * clvox's reader) into the raw HALF bits of "coverage" (cov) and
 * "occupancy" (occ), each NULL to skip; names: the file's channels,
 * comma-separated; *tile_h: the tile height. Returns 1 when the file is
 * one tiled part of n HALF pixels and everything decoded. */
static int decode_halves(const char *path, size_t n, uint16_t *cov, uint16_t *occ, char *names, size_t names_size,
                         uint32_t *tile_h)
{
    exr_context_t e = NULL;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    if (exr_start_read(&e, path, &init) != EXR_ERR_SUCCESS) return 0;
    int ok = 1, count = 0;
    const exr_attr_chlist_t *chl = NULL;
    exr_attr_box2i_t dw;
    uint32_t tw = 0, th = 0;
    exr_tile_level_mode_t lm;
    exr_tile_round_mode_t rm;
    int32_t ntx = 0, nty = 0;
    ok = exr_get_count(e, &count) == EXR_ERR_SUCCESS && count == 1 &&
         exr_get_channels(e, 0, &chl) == EXR_ERR_SUCCESS && exr_get_data_window(e, 0, &dw) == EXR_ERR_SUCCESS &&
         exr_get_tile_descriptor(e, 0, &tw, &th, &lm, &rm) == EXR_ERR_SUCCESS && tw > 0 && th > 0 &&
         lm == EXR_TILE_ONE_LEVEL;
    const int64_t W = ok ? (int64_t)dw.max.x - dw.min.x + 1 : 0, H = ok ? (int64_t)dw.max.y - dw.min.y + 1 : 0;
    ok = ok && dw.min.x == 0 && dw.min.y == 0 && (uint64_t)W * (uint64_t)H == n;
    if (ok) {
        ntx = (int32_t)((W + tw - 1) / tw);
        nty = (int32_t)((H + th - 1) / th);
    }
    names[0] = '\0';
    for (int i = 0; ok && i < chl->num_channels; i++) {
        size_t len = strlen(names);
        snprintf(names + len, names_size - len, "%s%s", i ? "," : "", chl->entries[i].name.str);
        ok = chl->entries[i].pixel_type == EXR_PIXEL_HALF;
    }
    if (tile_h) *tile_h = th;
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int initialized = 0;
    for (int32_t ty = 0; ok && ty < nty; ty++)
        for (int32_t tx = 0; ok && tx < ntx; tx++) {
            exr_chunk_info_t ci;
            ok = exr_read_tile_chunk_info(e, 0, tx, ty, 0, 0, &ci) == EXR_ERR_SUCCESS;
            if (ok) ok = (initialized ? exr_decoding_update(e, 0, &ci, &dec)
                                      : exr_decoding_initialize(e, 0, &ci, &dec)) == EXR_ERR_SUCCESS;
            if (!ok) break;
            initialized = 1;
            for (int16_t c = 0; c < dec.channel_count; c++) {
                exr_coding_channel_info_t *ch = &dec.channels[c];
                uint16_t *dst = strcmp(ch->channel_name, "coverage") == 0    ? cov
                                : strcmp(ch->channel_name, "occupancy") == 0 ? occ
                                                                             : NULL;
                /* (ci.start_x/y of a tile are tile indices in OpenEXRCore 3.1.5, not pixels) */
                size_t at = (size_t)ty * th * (size_t)W + (size_t)tx * tw;
                ch->decode_to_ptr = dst ? (uint8_t *)(dst + at) : NULL;
                ch->user_pixel_stride = 2;
                ch->user_line_stride = (int32_t)(2 * W);
                ch->user_bytes_per_element = 2;
                ch->user_data_type = EXR_PIXEL_HALF;
            }
            ok = exr_decoding_choose_default_routines(e, 0, &dec) == EXR_ERR_SUCCESS &&
                 exr_decoding_run(e, 0, &dec) == EXR_ERR_SUCCESS;
        }
    if (initialized) exr_decoding_destroy(e, &dec);
    exr_finish(&e);
    return ok;
}

/* Index of the first difference of a and b (n HALF samples), or n. */
static size_t first_diff(const uint16_t *a, const uint16_t *b, size_t n)
{
    size_t i = 0;
    while (i < n && a[i] == b[i]) i++;
    return i;
}

/* Writes coverage (and occupancy when `channels` has it) and compares every
 * sample bit for bit, decoded by OpenEXRCore. row_chunks: the layout
 * expected (tile height below Y). */
static void coverage_round_trip(uint32_t X, uint32_t Y, uint32_t Z, uint32_t channels, int pattern,
                                clvox_compression comp, uint32_t threads, const uint32_t *depths, size_t ndepths,
                                int row_chunks)
{
    char path[2048], names[256];
    snprintf(path, sizeof path, "%s/cov_%ux%ux%u_%u_%d_%d_%u.exr", dir, X, Y, Z, channels, pattern, (int)comp,
             threads);
    const size_t n = (size_t)X * Y * Z;
    const int with_occ = (channels & CLVOX_CHANNEL_OCCUPANCY) != 0, with_cov = (channels & CLVOX_CHANNEL_COVERAGE) != 0;
    uint16_t *cov = malloc(n * 2), *cov_back = malloc(n * 2), *occ_back = malloc(n * 2);
    uint8_t *vol = malloc(n);
    if (!cov || !cov_back || !occ_back || !vol) {
        CHECK(!"out of memory");
        goto done;
    }
    fill_coverage(cov, X, Y, Z, pattern);
    if (pattern == 1)
        for (size_t i = 0; i < n; i++) vol[i] = cov[i] >= 0x3800; /* coverage >= 0.5 */
    else
        fill_random(vol, n);
    clvox_grid g = make_grid(X, Y, Z);
    uint64_t bytes = 0;
    clvox_status st = write_planes(path, &g, channels, comp, threads, with_occ ? vol : NULL, with_cov ? cov : NULL,
                                   depths, ndepths, &bytes);
    CHECK_MSG(st == CLVOX_OK, "%s: %s: %s", path, clvox_status_string(st), clvox_context_error(ctx));
    CHECK(bytes > 0 && (long long)bytes == file_size(path) && temp_files(path) == 0);
    memset(cov_back, 0xEE, n * 2);
    memset(occ_back, 0xEE, n * 2);
    uint32_t th = 0;
    CHECK_MSG(decode_halves(path, n, cov_back, occ_back, names, sizeof names, &th), "%s: OpenEXRCore cannot decode it",
              path);
    const char *want = with_cov && with_occ ? "coverage,occupancy" : with_cov ? "coverage" : "occupancy";
    CHECK_MSG(strcmp(names, want) == 0, "%s: channels '%s', expected '%s'", path, names, want);
    CHECK_MSG((th < Y) == (row_chunks != 0), "%s: tile height %u for Y = %u", path, th, Y);
    if (with_cov) {
        size_t i = first_diff(cov, cov_back, n);
        CHECK_MSG(i == n, "%s: coverage differs at sample %zu: %#x, read %#x", path, i, i < n ? cov[i] : 0,
                  i < n ? cov_back[i] : 0);
    }
    if (with_occ) {
        for (size_t i = 0; i < n; i++) cov[i] = vol[i] ? 0x3C00 : 0x0000; /* what occupancy must read */
        size_t i = first_diff(cov, occ_back, n);
        CHECK_MSG(i == n, "%s: occupancy differs at sample %zu: %#x, read %#x", path, i, i < n ? cov[i] : 0,
                  i < n ? occ_back[i] : 0);
    }
    unlink(path);
done:
    free(cov);
    free(cov_back);
    free(occ_back);
    free(vol);
}

/* ---- element (UINT) and score (HALF): decoded by OpenEXRCore and by clvox ---- */

/* Element test data (uint16 indices). pattern 0: runs of random length (1
 * to 3000) of 0, 1, palette-sized indices, indices with a high byte, and
 * ramps; pattern 1: a sphere: 0 outside, 1 inside, a shell of indices 2..45
 * by position. */
static void fill_elements(uint16_t *elem, uint32_t X, uint32_t Y, uint32_t Z, int pattern)
{
    static const uint16_t special[] = { 0x0100, 0x00FF, 0xFFFF, 0x8000, 0x0101, 0xFF00 };
    const size_t n = (size_t)X * Y * Z;
    if (pattern == 1) {
        double c[3] = { X / 2.0, Y / 2.0, Z / 2.0 };
        double r = (X < Y ? (X < Z ? X : Z) : (Y < Z ? Y : Z)) / 2.5 + 0.5;
        for (uint32_t z = 0; z < Z; z++)
            for (uint32_t y = 0; y < Y; y++)
                for (uint32_t x = 0; x < X; x++) {
                    double dx = x + 0.5 - c[0], dy = y + 0.5 - c[1], dz = z + 0.5 - c[2];
                    double d = sqrt(dx * dx + dy * dy + dz * dz);
                    elem[((size_t)z * Y + y) * X + x] =
                        d < r - 0.5 ? 1 : d < r + 0.5 ? (uint16_t)(2 + (x + 3 * y + 7 * z) % 44) : 0;
                }
        return;
    }
    for (size_t i = 0; i < n;) {
        uint32_t r = rnd() % 8, k = rnd() % 16;
        size_t len = r < 3 ? 1 + rnd() % 3 : r < 6 ? 1 + rnd() % 40 : 100 + rnd() % 2900;
        uint16_t v = k < 5 ? 0 : k < 9 ? 1 : k < 12 ? (uint16_t)(2 + rnd() % 76) : k < 14 ? special[rnd() % 6]
                                                                                     : (uint16_t)rnd();
        for (size_t j = 0; j < len && i < n; j++, i++) elem[i] = k == 15 ? (uint16_t)(v + j) : v;
    }
}

/* One channel to decode: n samples of `type` (HALF as uint16 bits, UINT as
 * uint32) into dst (NULL: skipped). */
typedef struct decoded {
    const char *name;
    exr_pixel_type_t type;
    void *dst;
} decoded;

/* Decodes a clvox file with OpenEXRCore's generic decoding pipeline (not
 * clvox's reader) into the channels of d: every channel of the file must be
 * one of them, of that type. names: the file's channels, comma-separated;
 * *tile_h: the tile height. Returns 1 when the file is one tiled part of n
 * pixels and everything decoded. */
static int decode_channels(const char *path, size_t n, const decoded *d, size_t nd, char *names, size_t names_size,
                           uint32_t *tile_h)
{
    exr_context_t e = NULL;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    if (exr_start_read(&e, path, &init) != EXR_ERR_SUCCESS) return 0;
    int count = 0;
    const exr_attr_chlist_t *chl = NULL;
    exr_attr_box2i_t dw;
    uint32_t tw = 0, th = 0;
    exr_tile_level_mode_t lm;
    exr_tile_round_mode_t rm;
    int ok = exr_get_count(e, &count) == EXR_ERR_SUCCESS && count == 1 &&
             exr_get_channels(e, 0, &chl) == EXR_ERR_SUCCESS && exr_get_data_window(e, 0, &dw) == EXR_ERR_SUCCESS &&
             exr_get_tile_descriptor(e, 0, &tw, &th, &lm, &rm) == EXR_ERR_SUCCESS && tw > 0 && th > 0 &&
             lm == EXR_TILE_ONE_LEVEL;
    const int64_t W = ok ? (int64_t)dw.max.x - dw.min.x + 1 : 0, H = ok ? (int64_t)dw.max.y - dw.min.y + 1 : 0;
    ok = ok && dw.min.x == 0 && dw.min.y == 0 && (uint64_t)W * (uint64_t)H == n;
    names[0] = '\0';
    for (int i = 0; ok && i < chl->num_channels; i++) {
        size_t len = strlen(names);
        snprintf(names + len, names_size - len, "%s%s", i ? "," : "", chl->entries[i].name.str);
        int known = 0;
        for (size_t k = 0; k < nd; k++)
            known |= strcmp(chl->entries[i].name.str, d[k].name) == 0 && chl->entries[i].pixel_type == d[k].type;
        ok = known;
    }
    if (tile_h) *tile_h = th;
    const int32_t ntx = ok ? (int32_t)((W + tw - 1) / tw) : 0, nty = ok ? (int32_t)((H + th - 1) / th) : 0;
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int initialized = 0;
    for (int32_t ty = 0; ok && ty < nty; ty++)
        for (int32_t tx = 0; ok && tx < ntx; tx++) {
            exr_chunk_info_t ci;
            ok = exr_read_tile_chunk_info(e, 0, tx, ty, 0, 0, &ci) == EXR_ERR_SUCCESS;
            if (ok) ok = (initialized ? exr_decoding_update(e, 0, &ci, &dec)
                                      : exr_decoding_initialize(e, 0, &ci, &dec)) == EXR_ERR_SUCCESS;
            if (!ok) break;
            initialized = 1;
            for (int16_t c = 0; c < dec.channel_count; c++) {
                exr_coding_channel_info_t *ch = &dec.channels[c];
                const decoded *want = NULL;
                for (size_t k = 0; k < nd; k++)
                    if (strcmp(ch->channel_name, d[k].name) == 0) want = &d[k];
                const size_t b = want && want->type == EXR_PIXEL_HALF ? 2 : 4;
                /* (ci.start_x/y of a tile are tile indices in OpenEXRCore 3.1.5, not pixels) */
                size_t at = (size_t)ty * th * (size_t)W + (size_t)tx * tw;
                ch->decode_to_ptr = want && want->dst ? (uint8_t *)want->dst + at * b : NULL;
                ch->user_pixel_stride = (int32_t)b;
                ch->user_line_stride = (int32_t)(b * (size_t)W);
                ch->user_bytes_per_element = (int16_t)b;
                ch->user_data_type = (uint16_t)(want ? want->type : EXR_PIXEL_UINT);
            }
            ok = exr_decoding_choose_default_routines(e, 0, &dec) == EXR_ERR_SUCCESS &&
                 exr_decoding_run(e, 0, &dec) == EXR_ERR_SUCCESS;
        }
    if (initialized) exr_decoding_destroy(e, &dec);
    exr_finish(&e);
    return ok;
}

/* A channel as clvox_volume_read_slices hands it out, into a dense volume. */
typedef struct slices {
    size_t XY;
    uint32_t Z, calls;
    float *vol;
} slices;

static int on_slice(void *user, uint32_t z, const float *values)
{
    slices *s = user;
    if (z >= s->Z || z != s->calls) return 1;
    memcpy(s->vol + (size_t)z * s->XY, values, s->XY * sizeof *values);
    s->calls++;
    return 0;
}

static int same_value(float got, double want)
{
    return isnan(want) ? isnan(got) : (double)got == want;
}

/* Reads `channel` with clvox's reader and compares every value with want
 * (n doubles); 1 when all agree. */
static int clvox_reads(const char *path, const char *channel, const clvox_grid *g, const double *want)
{
    const size_t XY = (size_t)g->dims[0] * g->dims[1], n = XY * g->dims[2];
    slices s = { XY, g->dims[2], 0, malloc(n * sizeof(float)) };
    if (!s.vol) return 0;
    clvox_status st = clvox_volume_read_slices(ctx, path, channel, NULL, on_slice, &s);
    CHECK_MSG(st == CLVOX_OK && s.calls == g->dims[2], "%s: reading %s: %s: %s", path, channel,
              clvox_status_string(st), clvox_context_error(ctx));
    size_t bad = 0, first = 0;
    for (size_t i = 0; st == CLVOX_OK && i < n; i++)
        if (!same_value(s.vol[i], want[i]) && bad++ == 0) first = i;
    CHECK_MSG(bad == 0, "%s: %s: %zu values differ, first at %zu: %.9g instead of %.9g", path, channel, bad, first,
              bad ? (double)s.vol[first] : 0.0, bad ? want[first] : 0.0);
    free(s.vol);
    return st == CLVOX_OK && bad == 0;
}

/* Writes the channel set `channels` (element and/or score with any of
 * occupancy and coverage) and compares every sample: bit for bit as
 * OpenEXRCore decodes it, value for value as clvox's reader returns it;
 * the filled count and the header (meta's palette). row_chunks: the layout
 * expected. */
static void palette_round_trip(uint32_t X, uint32_t Y, uint32_t Z, uint32_t channels, int pattern,
                               clvox_compression comp, uint32_t threads, const uint32_t *depths, size_t ndepths,
                               const clvox__exr_meta *meta, int row_chunks)
{
    char path[2048], names[256], want_names[256] = "";
    snprintf(path, sizeof path, "%s/pal_%ux%ux%u_%u_%d_%d_%u.exr", dir, X, Y, Z, channels, pattern, (int)comp,
             threads);
    const size_t n = (size_t)X * Y * Z;
    const int with_occ = (channels & CLVOX_CHANNEL_OCCUPANCY) != 0, with_cov = (channels & CLVOX_CHANNEL_COVERAGE) != 0;
    const int with_elem = (channels & CLVOX_CHANNEL_ELEMENT) != 0, with_score = (channels & CLVOX_CHANNEL_SCORE) != 0;
    uint16_t *cov = malloc(n * 2), *elem = malloc(n * 2), *score = malloc(n * 2);
    uint16_t *cov_back = malloc(n * 2), *occ_back = malloc(n * 2), *score_back = malloc(n * 2);
    uint32_t *elem_back = malloc(n * 4);
    uint8_t *vol = malloc(n), *filled = malloc(n + 1), *filled_back = malloc(n + 1);
    double *want = malloc(n * sizeof(double));
    if (!cov || !elem || !score || !cov_back || !occ_back || !score_back || !elem_back || !vol || !filled ||
        !filled_back || !want) {
        CHECK(!"out of memory");
        goto done;
    }
    fill_coverage(cov, X, Y, Z, pattern);
    fill_elements(elem, X, Y, Z, pattern);
    fill_coverage(score, X, Y, Z, 0); /* any HALF bits, NaN and infinities included */
    if (pattern == 1)
        for (size_t i = 0; i < n; i++) vol[i] = elem[i] != 0;
    else
        fill_random(vol, n);
    clvox_grid g = make_grid(X, Y, Z);
    const test_planes tp = { .occ = with_occ ? vol : NULL, .cov = with_cov ? cov : NULL,
                             .elem = with_elem ? elem : NULL, .score = with_score ? score : NULL };
    uint64_t bytes = 0;
    clvox_status st = write_all(path, &g, meta, channels, comp, threads, &tp, depths, ndepths, &bytes);
    CHECK_MSG(st == CLVOX_OK, "%s: %s: %s", path, clvox_status_string(st), clvox_context_error(ctx));
    if (st != CLVOX_OK) goto done;
    CHECK(bytes > 0 && (long long)bytes == file_size(path) && temp_files(path) == 0);

    /* OpenEXRCore: the raw samples */
    memset(cov_back, 0xEE, n * 2);
    memset(occ_back, 0xEE, n * 2);
    memset(score_back, 0xEE, n * 2);
    memset(elem_back, 0xEE, n * 4);
    const decoded d[] = { { "coverage", EXR_PIXEL_HALF, cov_back },
                          { "element", EXR_PIXEL_UINT, elem_back },
                          { "occupancy", EXR_PIXEL_HALF, occ_back },
                          { "score", EXR_PIXEL_HALF, score_back } };
    uint32_t th = 0;
    CHECK_MSG(decode_channels(path, n, d, 4, names, sizeof names, &th), "%s: OpenEXRCore cannot decode it", path);
    static const char *const order[4] = { "coverage", "element", "occupancy", "score" };
    const int has[4] = { with_cov, with_elem, with_occ, with_score };
    for (int k = 0; k < 4; k++)
        if (has[k]) snprintf(want_names + strlen(want_names), sizeof want_names - strlen(want_names), "%s%s",
                             want_names[0] ? "," : "", order[k]);
    CHECK_MSG(strcmp(names, want_names) == 0, "%s: channels '%s', expected '%s'", path, names, want_names);
    CHECK_MSG((th < Y) == (row_chunks != 0), "%s: tile height %u for Y = %u", path, th, Y);
    size_t bad = 0, first = 0;
    if (with_cov) CHECK_MSG((first = first_diff(cov, cov_back, n)) == n, "%s: coverage differs at %zu", path, first);
    if (with_score)
        CHECK_MSG((first = first_diff(score, score_back, n)) == n, "%s: score differs at %zu: %#x, read %#x", path,
                  first, first < n ? score[first] : 0, first < n ? score_back[first] : 0);
    if (with_elem) {
        for (size_t i = 0; i < n; i++)
            if (elem_back[i] != elem[i] && bad++ == 0) first = i;
        CHECK_MSG(bad == 0, "%s: %zu elements differ, first at %zu: %u, read %u", path, bad, first,
                  bad ? elem[first] : 0, bad ? elem_back[first] : 0);
    }
    if (with_occ) {
        bad = 0;
        for (size_t i = 0; i < n; i++) bad += occ_back[i] != (vol[i] ? 0x3C00 : 0x0000);
        CHECK_MSG(bad == 0, "%s: %zu occupancy samples differ", path, bad);
    }

    /* clvox's reader: every channel as floats (element indices exactly) */
    if (with_cov) {
        for (size_t i = 0; i < n; i++) want[i] = exrgen_half_value(cov[i]);
        clvox_reads(path, "coverage", &g, want);
    }
    if (with_elem) {
        for (size_t i = 0; i < n; i++) want[i] = elem[i];
        clvox_reads(path, "element", &g, want);
    }
    if (with_occ) {
        for (size_t i = 0; i < n; i++) want[i] = vol[i];
        clvox_reads(path, "occupancy", &g, want);
    }
    if (with_score) {
        for (size_t i = 0; i < n; i++) want[i] = exrgen_half_value(score[i]);
        clvox_reads(path, "score", &g, want);
    }

    /* filled voxels: occupancy, else coverage > 0.5, else element != 0 */
    uint64_t want_filled = 0;
    for (size_t i = 0; i < n; i++) {
        filled[i] = with_occ ? vol[i] : with_cov ? exrgen_half_value(cov[i]) > 0.5 : elem[i] != 0;
        want_filled += filled[i];
    }
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    memset(filled_back, 0xAB, n + 1);
    st = clvox_volume_read(ctx, path, &info, filled_back, n);
    if (!with_occ && !with_cov && !with_elem) {
        CHECK_MSG(st == CLVOX_ERR_EXR && strstr(clvox_context_error(ctx), "element"), "%s: score only: %s: %s", path,
                  clvox_status_string(st), clvox_context_error(ctx));
        CHECK(strcmp(info.channels, "score") == 0); /* the header still given */
    } else {
        CHECK_MSG(st == CLVOX_OK, "%s: %s: %s", path, clvox_status_string(st), clvox_context_error(ctx));
        CHECK_MSG(info.filled_voxels == want_filled, "%s: filled %llu, expected %llu", path,
                  (unsigned long long)info.filled_voxels, (unsigned long long)want_filled);
        CHECK_MSG(memcmp(filled, filled_back, n) == 0 && filled_back[n] == 0xAB, "%s: filled voxels differ", path);
        CHECK(strcmp(info.channels, want_names) == 0);
    }
    const clvox_palette *p = meta ? meta->palette : NULL;
    CHECK(strcmp(info.palette, p ? clvox_palette_name(p) : "") == 0);
    CHECK(info.palette_count == (p ? clvox_palette_count(p) : 0));
    CHECK(info.palette_hash == (p ? clvox_palette_hash(p) : 0));
    CHECK(strcmp(info.metric, p && meta->metric ? meta->metric : "") == 0);
    /* the default is ZIP for files with an element channel (RLE cannot shrink UINT) */
    const char *want_comp = comp == CLVOX_COMPRESSION_DEFAULT && with_elem ? "zip" : comp_names[comp];
    CHECK(strcmp(info.method, meta->method) == 0 && strcmp(info.compression, want_comp) == 0);
    unlink(path);
done:
    free(cov);
    free(elem);
    free(score);
    free(cov_back);
    free(occ_back);
    free(score_back);
    free(elem_back);
    free(vol);
    free(filled);
    free(filled_back);
    free(want);
}

/* ---- tests ---- */

static void test_round_trips(void)
{
    static const uint32_t dims[][3] = {
        { 1, 1, 1 }, { 17, 5, 9 }, { 8, 8, 8 }, { 33, 1, 7 }, { 1, 40, 3 }, { 64, 48, 20 }, { 3, 2, 31 }, { 300, 7, 3 },
    };
    static const uint32_t one[] = { 1 }, mixed[] = { 2, 1, 5, 3 }, big[] = { 1000 };
    for (size_t d = 0; d < sizeof dims / sizeof dims[0]; d++)
        for (int c = 0; c < CLVOX_COMPRESSION_COUNT; c++)
            for (int s = 0; s < 2; s++) {
                const uint32_t *dp = s ? mixed : (c & 1 ? one : big);
                size_t nd = s ? 4 : 1;
                uint32_t threads = (uint32_t)((d + (size_t)c + (size_t)s) % 4); /* 0 (= all cores), 1, 2, 3 */
                round_trip(dims[d][0], dims[d][1], dims[d][2], s, (clvox_compression)c, threads, dp, nd);
            }
    /* Full volumes: one run of ones through every row and slice (RLE runs
     * longer than 128, row ends inside words). */
    static const uint32_t full[][3] = { { 37, 3, 4 }, { 64, 2, 2 }, { 300, 5, 2 } };
    for (size_t d = 0; d < sizeof full / sizeof full[0]; d++)
        for (int c = 0; c < CLVOX_COMPRESSION_COUNT; c++) {
            round_trip(full[d][0], full[d][1], full[d][2], 2, (clvox_compression)c, 2, one, 1);
            round_trip(full[d][0], full[d][1], full[d][2], 3, (clvox_compression)c, 2, one, 1);
        }
}

/* Slices larger than one chunk: tiles of fewer rows than Y, which straddle
 * slices and slabs (the writer carries rows over). */
static void test_row_chunks(void)
{
    static const uint32_t d12[] = { 1, 2 }, d3[] = { 3 };
    round_trip(4099, 1031, 3, 0, CLVOX_COMPRESSION_RLE, 2, d12, 2);
    round_trip(4099, 1031, 3, 1, CLVOX_COMPRESSION_ZIP, 1, d3, 1);
    round_trip(4099, 1031, 3, 1, CLVOX_COMPRESSION_NONE, 3, d12, 2);
}

/* Coverage alone and with occupancy, every compression, tile-per-slice,
 * slabs of varying depth; occupancy alone through the same decoder. */
static void test_coverage(void)
{
    static const uint32_t dims[][3] = { { 1, 1, 1 }, { 17, 5, 9 }, { 64, 48, 20 }, { 3, 2, 31 }, { 300, 7, 3 } };
    static const uint32_t sets[] = { CLVOX_CHANNEL_COVERAGE, CLVOX_CHANNEL_COVERAGE | CLVOX_CHANNEL_OCCUPANCY,
                                     CLVOX_CHANNEL_OCCUPANCY };
    static const uint32_t one[] = { 1 }, mixed[] = { 2, 1, 5, 3 }, big[] = { 1000 };
    for (size_t d = 0; d < sizeof dims / sizeof dims[0]; d++)
        for (size_t k = 0; k < sizeof sets / sizeof sets[0]; k++)
            for (int c = 0; c < CLVOX_COMPRESSION_COUNT; c++)
                for (int pattern = 0; pattern < 2; pattern++) {
                    const uint32_t *dp = pattern ? mixed : (c & 1 ? one : big);
                    uint32_t threads = (uint32_t)((d + k + (size_t)c + (size_t)pattern) % 4);
                    coverage_round_trip(dims[d][0], dims[d][1], dims[d][2], sets[k], pattern, (clvox_compression)c,
                                        threads, dp, pattern ? 4 : 1, 0);
                }
}

/* Row chunks with coverage: slices over CLVOX__EXR_CHUNK_BYTES (8 MiB) counting
 * all channels' bytes, so tiles of fewer rows than Y that straddle slices
 * and slabs (1500 x 1500 at 4 bytes per voxel: tiles of 1398 rows; 2900 x
 * 1500 at 2 bytes: 1446 rows). */
static void test_coverage_row_chunks(void)
{
    static const uint32_t d12[] = { 1, 2 }, d1[] = { 1 };
    static const clvox_compression comps[] = { CLVOX_COMPRESSION_RLE, CLVOX_COMPRESSION_NONE, CLVOX_COMPRESSION_ZIP,
                                               CLVOX_COMPRESSION_PIZ };
    const uint32_t both = CLVOX_CHANNEL_COVERAGE | CLVOX_CHANNEL_OCCUPANCY;
    for (size_t c = 0; c < sizeof comps / sizeof comps[0]; c++)
        coverage_round_trip(1500, 1500, 3, both, (int)(c & 1), comps[c], (uint32_t)(c % 3), d12, 2, 1);
    coverage_round_trip(2900, 1500, 2, CLVOX_CHANNEL_COVERAGE, 0, CLVOX_COMPRESSION_RLE, 2, d1, 1, 1);
    coverage_round_trip(2900, 1500, 2, CLVOX_CHANNEL_COVERAGE, 1, CLVOX_COMPRESSION_ZIPS, 1, d1, 1, 1);
    /* the same slice size with coverage alone is one tile (2 bytes per voxel) */
    coverage_round_trip(1500, 1500, 2, CLVOX_CHANNEL_COVERAGE, 0, CLVOX_COMPRESSION_RLE, 2, d1, 1, 0);
}

/* Palette runs' headers: a built-in and a user palette (set up by main). */
static clvox_palette *pal46, *pal_blocks;
static clvox__exr_meta meta46, meta_blocks;

/* Element and score alone, together, and with occupancy and/or coverage;
 * every compression, tile-per-slice, slabs of varying depth; odd widths (a
 * UINT row after a HALF one starts at an odd multiple of 2 bytes). */
static void test_palette_channels(void)
{
    static const uint32_t dims[][3] = { { 1, 1, 1 }, { 17, 5, 9 }, { 64, 48, 20 }, { 3, 2, 31 }, { 300, 7, 3 },
                                        { 33, 1, 7 } };
    const uint32_t E = CLVOX_CHANNEL_ELEMENT, S = CLVOX_CHANNEL_SCORE, O = CLVOX_CHANNEL_OCCUPANCY,
                   C = CLVOX_CHANNEL_COVERAGE;
    const uint32_t sets[] = { E, S, E | S, E | S | O, E | S | C, E | O, S | C, E | C, E | S | O | C };
    static const uint32_t one[] = { 1 }, mixed[] = { 2, 1, 5, 3 }, big[] = { 1000 };
    for (size_t d = 0; d < sizeof dims / sizeof dims[0]; d++)
        for (size_t k = 0; k < sizeof sets / sizeof sets[0]; k++)
            for (int c = 0; c < CLVOX_COMPRESSION_COUNT; c++) {
                const int pattern = (int)((d + k + (size_t)c) % 2);
                const uint32_t *dp = pattern ? mixed : (c & 1 ? one : big);
                const uint32_t threads = (uint32_t)((d + k + (size_t)c) % 4);
                const clvox__exr_meta *meta = (k + (size_t)c) % 3 == 0 ? &test_meta : (k % 2 ? &meta46 : &meta_blocks);
                palette_round_trip(dims[d][0], dims[d][1], dims[d][2], sets[k], pattern, (clvox_compression)c, threads,
                                   dp, pattern ? 4 : 1, meta, 0);
            }
}

/* Row chunks with element: all four channels are 10 bytes per voxel, so a
 * 1000 x 1000 slice (10 MB) is split in tiles of 838 rows that straddle
 * slices and slabs; element alone at 1500 x 1500 (9 MB) too. */
static void test_palette_row_chunks(void)
{
    static const uint32_t d12[] = { 1, 2 }, d1[] = { 1 };
    static const clvox_compression comps[] = { CLVOX_COMPRESSION_RLE, CLVOX_COMPRESSION_NONE, CLVOX_COMPRESSION_ZIP,
                                               CLVOX_COMPRESSION_PIZ };
    const uint32_t all = CLVOX_CHANNEL_COVERAGE | CLVOX_CHANNEL_OCCUPANCY | CLVOX_CHANNEL_ELEMENT | CLVOX_CHANNEL_SCORE;
    for (size_t c = 0; c < sizeof comps / sizeof comps[0]; c++)
        palette_round_trip(1000, 1000, 3, all, (int)(c & 1), comps[c], (uint32_t)(c % 3), d12, 2, &meta46, 1);
    palette_round_trip(1500, 1500, 2, CLVOX_CHANNEL_ELEMENT, 0, CLVOX_COMPRESSION_RLE, 2, d1, 1, &meta_blocks, 1);
    palette_round_trip(1500, 1500, 2, CLVOX_CHANNEL_ELEMENT, 1, CLVOX_COMPRESSION_ZIPS, 1, d1, 1, &meta_blocks, 1);
}

/* Reads a whole file; *n its size. */
static uint8_t *slurp(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    long long size = file_size(path);
    uint8_t *b = f && size >= 0 ? malloc((size_t)size + 1) : NULL;
    *n = b && fread(b, 1, (size_t)size, f) == (size_t)size ? (size_t)size : 0;
    if (f) fclose(f);
    return b;
}

static int spill(const char *path, const uint8_t *b, size_t n)
{
    FILE *f = fopen(path, "wb");
    int ok = f && fwrite(b, 1, n, f) == n;
    if (f && fclose(f) != 0) ok = 0;
    return ok;
}

/* Replaces the first `from` in the file's bytes by `to` (same length). */
static int tamper(const char *path, const char *from, const char *to)
{
    size_t n = 0, len = strlen(from);
    uint8_t *b = slurp(path, &n);
    int done = 0;
    for (size_t i = 0; b && !done && i + len <= n; i++)
        if (memcmp(b + i, from, len) == 0) {
            memcpy(b + i, to, len);
            done = 1;
        }
    done = done && spill(path, b, n);
    free(b);
    return done;
}

/* The palette is the one written: same count, hash, source and element names. */
static void check_same_palette(const char *what, const clvox_palette *want, const clvox_palette *got)
{
    CHECK_MSG(got != NULL, "%s: no palette", what);
    if (!got) return;
    CHECK_MSG(strcmp(clvox_palette_name(got), clvox_palette_name(want)) == 0, "%s: name '%s', expected '%s'", what,
              clvox_palette_name(got), clvox_palette_name(want));
    CHECK(clvox_palette_count(got) == clvox_palette_count(want));
    CHECK(clvox_palette_hash(got) == clvox_palette_hash(want));
    const char *a = clvox_palette_source(want), *b = clvox_palette_source(got);
    CHECK_MSG(a ? b && strcmp(a, b) == 0 : b == NULL, "%s: the palette text differs", what);
    size_t bad = 0;
    for (size_t i = 0; i < clvox_palette_count(want) && i < clvox_palette_count(got); i++) {
        clvox_palette_element_info x = CLVOX_PALETTE_ELEMENT_INFO_INIT, y = CLVOX_PALETTE_ELEMENT_INFO_INIT;
        if (clvox_palette_element_info_get(ctx, want, i, &x) != CLVOX_OK ||
            clvox_palette_element_info_get(ctx, got, i, &y) != CLVOX_OK || strcmp(x.name, y.name) != 0 ||
            x.volume != y.volume)
            bad++;
    }
    CHECK_MSG(bad == 0, "%s: %zu elements differ", what, bad);
}

/* Writes a small element + score file with `meta`. */
static clvox_status write_palette_file(const char *path, const clvox__exr_meta *meta, clvox_compression comp)
{
    const uint32_t X = 7, Y = 3, Z = 4;
    uint16_t elem[7 * 3 * 4], score[7 * 3 * 4];
    for (size_t i = 0; i < sizeof elem / sizeof elem[0]; i++) {
        elem[i] = (uint16_t)(i % 5 == 0 ? 0 : i % 12);
        score[i] = (uint16_t)(0x3800 + i);
    }
    clvox_grid g = make_grid(X, Y, Z);
    const test_planes tp = { .elem = elem, .score = score };
    static const uint32_t depths[] = { 3 };
    return write_all(path, &g, meta, CLVOX_CHANNEL_ELEMENT | CLVOX_CHANNEL_SCORE, comp, 2, &tp, depths, 1, NULL);
}

/* clvoxPalette* and clvoxMetric: written, read into clvox_volume_info, and
 * the palette rebuilt by clvox_volume_palette (a built-in by name, a user
 * palette from its text, a 4 MiB palette text); tampered headers (hash,
 * geometry, syntax) and files without a palette fail with one line. */
static void test_palette_header(void)
{
    char path[2048];
    snprintf(path, sizeof path, "%s/palette.exr", dir);
    const clvox__exr_meta *metas[2] = { &meta46, &meta_blocks };
    for (int m = 0; m < 2; m++)
        for (int c = 0; c < CLVOX_COMPRESSION_COUNT; c++) {
            const clvox__exr_meta *meta = metas[m];
            CHECK_OK(ctx, write_palette_file(path, meta, (clvox_compression)c));
            clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
            CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, NULL, 0));
            CHECK(strcmp(info.palette, clvox_palette_name(meta->palette)) == 0);
            CHECK(info.palette_count == clvox_palette_count(meta->palette));
            CHECK(info.palette_hash == clvox_palette_hash(meta->palette));
            CHECK(strcmp(info.metric, meta->metric) == 0);
            CHECK(strcmp(info.channels, "element,score") == 0);
            CHECK(info.filled_voxels == 84 - 22); /* element 0: i % 5 == 0 (17 of 84) or i % 12 == 0 (7, 2 of them
                                                     already counted) */
            clvox_palette *p = (clvox_palette *)&p;
            CHECK_OK(ctx, clvox_volume_palette(ctx, path, &p));
            check_same_palette(meta == &meta46 ? "paper46" : "blocks", meta->palette, p);
            clvox_palette_destroy(p);
        }
    /* the user palette's text is in the file; the built-in's is not */
    size_t n = 0;
    uint8_t *bytes = slurp(path, &n);
    const char *text = clvox_palette_source(pal_blocks);
    int found = 0;
    for (size_t i = 0; bytes && text && i + strlen(text) <= n && !found; i++)
        found = memcmp(bytes + i, text, strlen(text)) == 0;
    CHECK_MSG(found, "the palette text of blocks.txt is not in the file");
    free(bytes);

    /* exrheader (the C++ library) sees the attributes and channel types */
    char cmd[2200], line[512];
    if (system("command -v exrheader >/dev/null 2>&1") == 0) {
        for (int m = 0; m < 2; m++) {
            CHECK_OK(ctx, write_palette_file(path, metas[m], CLVOX_COMPRESSION_RLE));
            char hash[32];
            snprintf(hash, sizeof hash, "\"%016llx\"", (unsigned long long)clvox_palette_hash(metas[m]->palette));
            snprintf(cmd, sizeof cmd, "exrheader '%s' 2>&1", path);
            FILE *pp = popen(cmd, "r");
            int seen = 0;
            while (pp && fgets(line, sizeof line, pp)) {
                if (strstr(line, "clvoxPalette (type string)") &&
                    strstr(line, m ? "\"blocks\"" : "\"paper46\""))
                    seen |= 1;
                if (strstr(line, "clvoxPaletteCount (type int)") && strstr(line, m ? ": 12" : ": 46")) seen |= 2;
                if (strstr(line, "clvoxPaletteHash (type string)") && strstr(line, hash)) seen |= 4;
                if (strstr(line, "clvoxPaletteSource (type string)")) seen |= 8;
                if (strstr(line, "clvoxMetric (type string)") && strstr(line, metas[m]->metric)) seen |= 16;
                if (strstr(line, "element, 32-bit unsigned integer")) seen |= 32;
                if (strstr(line, "score, 16-bit floating-point")) seen |= 64;
            }
            int rc = pp ? pclose(pp) : -1;
            CHECK_MSG(rc != -1 && WIFEXITED(rc) && WEXITSTATUS(rc) == 0, "exrheader exit status %d", rc);
            int want = 1 | 2 | 4 | (m ? 8 : 0) | 16 | 32 | 64;
            CHECK_MSG(seen == want, "exrheader: attributes mask %#x, expected %#x", seen, want);
        }
    } else {
        printf("skip: exrheader is not installed\n");
    }

    /* a palette text of 4 MiB (the palette files' limit) round trips */
    const size_t big = 4u << 20;
    char *huge = malloc(big + 1);
    if (huge && text) {
        size_t len = strlen(text);
        memcpy(huge, text, len);
        for (size_t i = len; i < big; i++) { /* comment lines of 80 bytes */
            size_t col = (i - len) % 80;
            huge[i] = col == 0 ? '#' : col == 79 ? '\n' : 'x';
        }
        huge[big - 1] = '\n';
        huge[big] = '\0';
        clvox_palette *hp = NULL, *back = NULL;
        CHECK_OK(ctx, clvox_palette_parse(ctx, "palettes/huge.txt", huge, big, &hp));
        clvox__exr_meta meta = { .method = "ray", .parameters = "", .palette = hp, .metric = "nearest" };
        CHECK_OK(ctx, write_palette_file(path, &meta, CLVOX_COMPRESSION_ZIP));
        CHECK_MSG(file_size(path) > (long long)big, "a %lld-byte file holds a 4 MiB text", file_size(path));
        CHECK_OK(ctx, clvox_volume_palette(ctx, path, &back));
        check_same_palette("4 MiB palette", hp, back);
        if (system("command -v exrheader >/dev/null 2>&1") == 0) {
            snprintf(cmd, sizeof cmd, "exrheader '%s' >/dev/null 2>&1", path);
            int rc = system(cmd);
            CHECK_MSG(rc != -1 && WIFEXITED(rc) && WEXITSTATUS(rc) == 0, "exrheader on a 4 MiB attribute: %d", rc);
        }
        clvox_palette_destroy(back);
        clvox_palette_destroy(hp);
    } else {
        CHECK(!"out of memory");
    }
    free(huge);

    /* tampered: the hash, the geometry, the syntax of the text */
    for (int m = 0; m < 2; m++) {
        CHECK_OK(ctx, write_palette_file(path, metas[m], CLVOX_COMPRESSION_RLE));
        char hash[32], other[32];
        snprintf(hash, sizeof hash, "%016llx", (unsigned long long)clvox_palette_hash(metas[m]->palette));
        snprintf(other, sizeof other, "%s", hash);
        other[7] = other[7] == '0' ? '1' : '0';
        CHECK(tamper(path, hash, other));
        clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
        CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, NULL, 0)); /* still a volume */
        CHECK(info.palette_hash != clvox_palette_hash(metas[m]->palette));
        clvox_palette *p = (clvox_palette *)&p;
        CHECK_STATUS(ctx, clvox_volume_palette(ctx, path, &p), CLVOX_ERR_EXR);
        CHECK(p == NULL);
        CHECK_MSG(strstr(clvox_context_error(ctx), "is not the one") && strstr(clvox_context_error(ctx), other) &&
                      !strchr(clvox_context_error(ctx), '\n'),
                  "tampered hash: %s", clvox_context_error(ctx));
    }
    CHECK_OK(ctx, write_palette_file(path, &meta_blocks, CLVOX_COMPRESSION_NONE));
    CHECK(tamper(path, "0 0 1 0.5", "0 0 1 0.4")); /* slab_bottom is lower: same text size, other geometry */
    clvox_palette *p = NULL;
    CHECK_STATUS(ctx, clvox_volume_palette(ctx, path, &p), CLVOX_ERR_EXR);
    CHECK(p == NULL && strstr(clvox_context_error(ctx), "is not the one"));
    CHECK_OK(ctx, write_palette_file(path, &meta_blocks, CLVOX_COMPRESSION_NONE));
    CHECK(tamper(path, "element slab_top", "elemenX slab_top"));
    CHECK_STATUS(ctx, clvox_volume_palette(ctx, path, &p), CLVOX_ERR_EXR);
    CHECK_MSG(p == NULL && strstr(clvox_context_error(ctx), "not a valid palette") &&
                  strstr(clvox_context_error(ctx), "blocks.clvoxPaletteSource:") &&
                  !strchr(clvox_context_error(ctx), '\n'),
              "tampered text: %s", clvox_context_error(ctx));

    /* not a palette run; bad arguments */
    CHECK_OK(ctx, write_palette_file(path, &test_meta, CLVOX_COMPRESSION_RLE));
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, NULL, 0));
    CHECK(info.palette[0] == '\0' && info.palette_count == 0 && info.palette_hash == 0 && info.metric[0] == '\0');
    p = (clvox_palette *)&p;
    CHECK_STATUS(ctx, clvox_volume_palette(ctx, path, &p), CLVOX_ERR_EXR);
    CHECK(p == NULL && strstr(clvox_context_error(ctx), "has no palette"));
    CHECK_STATUS(ctx, clvox_volume_palette(ctx, path, NULL), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(ctx, clvox_volume_palette(ctx, NULL, &p), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(NULL, clvox_volume_palette(NULL, path, &p), CLVOX_ERR_INVALID_ARGUMENT);
    unlink(path);
    CHECK_STATUS(ctx, clvox_volume_palette(ctx, path, &p), CLVOX_ERR_IO);
    /* a header the writer refuses: before any file is made */
    clvox__exr_meta bad = meta46;
    bad.metric = "a-metric-name-far-too-long";
    clvox_grid g = make_grid(4, 4, 4);
    clvox__exr_writer *w = (clvox__exr_writer *)&w;
    CHECK_STATUS(ctx, clvox__exr_open(ctx, path, &g, &bad, CLVOX_CHANNEL_ELEMENT, CLVOX_COMPRESSION_RLE, 1, &w),
                 CLVOX_ERR_INVALID_ARGUMENT);
    CHECK(w == NULL && !exists(path) && temp_files(path) == 0);
    bad.metric = "near\nest"; /* the reader would refuse it: so does the writer */
    CHECK_STATUS(ctx, clvox__exr_open(ctx, path, &g, &bad, CLVOX_CHANNEL_ELEMENT, CLVOX_COMPRESSION_RLE, 1, &w),
                 CLVOX_ERR_INVALID_ARGUMENT);
    CHECK(w == NULL && !exists(path) && strstr(clvox_context_error(ctx), "control character"));
    clvox_palette *odd = NULL; /* a palette file named "two<newline>lines.txt" */
    CHECK_OK(ctx, clvox_palette_parse(ctx, "dir/two\nlines.txt", "", 0, &odd));
    bad = meta46;
    bad.palette = odd;
    CHECK_STATUS(ctx, clvox__exr_open(ctx, path, &g, &bad, CLVOX_CHANNEL_ELEMENT, CLVOX_COMPRESSION_RLE, 1, &w),
                 CLVOX_ERR_INVALID_ARGUMENT);
    CHECK(w == NULL && !exists(path) && temp_files(path) == 0);
    clvox_palette_destroy(odd);
}


/* A plane missing for a channel of the writer, or given for a channel it
 * was not opened with, is CLVOX_ERR_INVALID_ARGUMENT; the writer has failed
 * then and leaves no file. Unknown channel bits are refused at open. */
static void test_bad_planes(void)
{
    const uint32_t X = 6, Y = 5, Z = 4;
    clvox_grid g = make_grid(X, Y, Z);
    uint32_t bits[5 * 4] = { 0 };
    uint16_t cov[6 * 5 * 4] = { 0 };
    char path[2048];
    snprintf(path, sizeof path, "%s/planes.exr", dir);
    unlink(path);
    static const struct {
        uint32_t channels;
        int bits, cov;
    } bad[] = {
        { 0, 0, 0 },
        { 0, 0, 1 },
        { 0, 1, 1 },
        { CLVOX_CHANNEL_OCCUPANCY, 0, 1 },
        { CLVOX_CHANNEL_COVERAGE, 0, 0 },
        { CLVOX_CHANNEL_COVERAGE, 1, 0 },
        { CLVOX_CHANNEL_COVERAGE, 1, 1 },
        { CLVOX_CHANNEL_COVERAGE | CLVOX_CHANNEL_OCCUPANCY, 1, 0 },
        { CLVOX_CHANNEL_COVERAGE | CLVOX_CHANNEL_OCCUPANCY, 0, 1 },
        { CLVOX_CHANNEL_COVERAGE | CLVOX_CHANNEL_OCCUPANCY, 0, 0 },
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        for (uint32_t threads = 1; threads <= 2; threads++) {
            clvox__exr_writer *w = NULL;
            clvox__slab_planes good = { .occupancy_bits = bad[i].channels & CLVOX_CHANNEL_COVERAGE ? NULL : bits,
                                        .coverage_half = bad[i].channels & CLVOX_CHANNEL_COVERAGE ? cov : NULL };
            if (bad[i].channels == (CLVOX_CHANNEL_COVERAGE | CLVOX_CHANNEL_OCCUPANCY)) good.occupancy_bits = bits;
            clvox__slab_planes planes = { .occupancy_bits = bad[i].bits ? bits : NULL,
                                          .coverage_half = bad[i].cov ? cov : NULL };
            CHECK_OK(ctx, clvox__exr_open(ctx, path, &g, &test_meta, bad[i].channels, CLVOX_COMPRESSION_RLE, threads,
                                          &w));
            CHECK_OK(ctx, clvox__exr_write_slab(w, 0, 1, &good)); /* a good slab first: the bad one is the second */
            CHECK_STATUS(ctx, clvox__exr_write_slab(w, 1, 1, &planes), CLVOX_ERR_INVALID_ARGUMENT);
            CHECK_MSG(strstr(clvox_context_error(ctx), "plane") != NULL, "case %zu: %s", i, clvox_context_error(ctx));
            CHECK(clvox__exr_write_slab(w, 1, 3, &good) != CLVOX_OK); /* the writer has failed */
            CHECK_STATUS(ctx, clvox__exr_finish(w, NULL), CLVOX_ERR_INVALID_ARGUMENT);
            CHECK(!exists(path) && temp_files(path) == 0);
        }
    /* every channel set, with one plane too many or missing: element and
     * score planes are checked like the others */
    uint16_t elem[6 * 5 * 4] = { 0 }, score[6 * 5 * 4] = { 0 };
    for (uint32_t set = 1; set < 16; set++)
        for (uint32_t flip = 1; flip < 16; flip <<= 1) {
            const uint32_t given = set ^ flip;
            clvox__slab_planes good = { .occupancy_bits = set & CLVOX_CHANNEL_OCCUPANCY ? bits : NULL,
                                        .coverage_half = set & CLVOX_CHANNEL_COVERAGE ? cov : NULL,
                                        .element = set & CLVOX_CHANNEL_ELEMENT ? elem : NULL,
                                        .score_half = set & CLVOX_CHANNEL_SCORE ? score : NULL };
            clvox__slab_planes planes = { .occupancy_bits = given & CLVOX_CHANNEL_OCCUPANCY ? bits : NULL,
                                          .coverage_half = given & CLVOX_CHANNEL_COVERAGE ? cov : NULL,
                                          .element = given & CLVOX_CHANNEL_ELEMENT ? elem : NULL,
                                          .score_half = given & CLVOX_CHANNEL_SCORE ? score : NULL };
            clvox__exr_writer *w = NULL;
            CHECK_OK(ctx, clvox__exr_open(ctx, path, &g, &test_meta, set, CLVOX_COMPRESSION_ZIP, 1 + (set & 1), &w));
            CHECK_OK(ctx, clvox__exr_write_slab(w, 0, 1, &good));
            CHECK_STATUS(ctx, clvox__exr_write_slab(w, 1, 1, &planes), CLVOX_ERR_INVALID_ARGUMENT);
            const char *name = flip == CLVOX_CHANNEL_OCCUPANCY ? "occupancy"
                               : flip == CLVOX_CHANNEL_COVERAGE ? "coverage"
                               : flip == CLVOX_CHANNEL_ELEMENT  ? "element"
                                                                : "score";
            CHECK_MSG(strstr(clvox_context_error(ctx), name) != NULL, "set %#x given %#x: %s", set, given,
                      clvox_context_error(ctx));
            CHECK_STATUS(ctx, clvox__exr_finish(w, NULL), CLVOX_ERR_INVALID_ARGUMENT);
            CHECK(!exists(path) && temp_files(path) == 0);
        }
    /* no planes at all */
    clvox__exr_writer *w = NULL;
    CHECK_OK(ctx, clvox__exr_open(ctx, path, &g, &test_meta, CLVOX_CHANNEL_COVERAGE, CLVOX_COMPRESSION_ZIP, 1, &w));
    CHECK_STATUS(ctx, clvox__exr_write_slab(w, 0, Z, NULL), CLVOX_ERR_INVALID_ARGUMENT);
    clvox__exr_abort(w);
    CHECK(!exists(path) && temp_files(path) == 0);
    /* channels the writer does not know */
    w = (clvox__exr_writer *)&w;
    CHECK_STATUS(ctx, clvox__exr_open(ctx, path, &g, &test_meta, 0x10, CLVOX_COMPRESSION_RLE, 1, &w),
                 CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_MSG(strstr(clvox_context_error(ctx), "element") && strstr(clvox_context_error(ctx), "score"), "%s",
              clvox_context_error(ctx));
    CHECK(w == NULL && !exists(path) && temp_files(path) == 0);
    CHECK_STATUS(ctx, clvox__exr_open(ctx, path, &g, &test_meta, CLVOX_CHANNEL_COVERAGE | 0x80000000u,
                                      CLVOX_COMPRESSION_RLE, 1, &w),
                 CLVOX_ERR_INVALID_ARGUMENT);
    CHECK(!exists(path) && temp_files(path) == 0);
}

/* The file does not depend on the number of threads (occupancy alone, and
 * coverage with occupancy). */
static void test_threads_identical(void)
{
    const uint32_t X = 40, Y = 30, Z = 50;
    size_t n = (size_t)X * Y * Z;
    uint8_t *vol = malloc(n);
    uint16_t *cov = malloc(n * 2);
    if (!vol || !cov) {
        CHECK(!"out of memory");
        free(vol);
        free(cov);
        return;
    }
    uint16_t *elem = malloc(n * 2), *score = malloc(n * 2);
    if (!elem || !score) {
        CHECK(!"out of memory");
        free(vol);
        free(cov);
        free(elem);
        free(score);
        return;
    }
    fill_structured(vol, X, Y, Z);
    fill_coverage(cov, X, Y, Z, 0);
    fill_elements(elem, X, Y, Z, 0);
    fill_coverage(score, X, Y, Z, 1);
    clvox_grid g = make_grid(X, Y, Z);
    static const uint32_t depths[] = { 7, 1, 12 };
    char p1[2048], p2[2048];
    const uint32_t all = CLVOX_CHANNEL_COVERAGE | CLVOX_CHANNEL_OCCUPANCY | CLVOX_CHANNEL_ELEMENT | CLVOX_CHANNEL_SCORE;
    for (int k = 0; k < 4 * CLVOX_COMPRESSION_COUNT; k++) {
        int c = k % CLVOX_COMPRESSION_COUNT;
        const uint32_t sets[4] = { CLVOX_CHANNEL_OCCUPANCY, CLVOX_CHANNEL_COVERAGE | CLVOX_CHANNEL_OCCUPANCY,
                                   CLVOX_CHANNEL_ELEMENT | CLVOX_CHANNEL_SCORE, all };
        uint32_t channels = sets[k / CLVOX_COMPRESSION_COUNT];
        const test_planes tp = { .occ = channels & CLVOX_CHANNEL_OCCUPANCY ? vol : NULL,
                                 .cov = channels & CLVOX_CHANNEL_COVERAGE ? cov : NULL,
                                 .elem = channels & CLVOX_CHANNEL_ELEMENT ? elem : NULL,
                                 .score = channels & CLVOX_CHANNEL_SCORE ? score : NULL };
        const clvox__exr_meta *meta = channels & CLVOX_CHANNEL_ELEMENT ? &meta_blocks : &test_meta;
        snprintf(p1, sizeof p1, "%s/thr1.exr", dir);
        snprintf(p2, sizeof p2, "%s/thr4.exr", dir);
        CHECK_OK(ctx, write_all(p1, &g, meta, channels, (clvox_compression)c, 1, &tp, depths, 3, NULL));
        CHECK_OK(ctx, write_all(p2, &g, meta, channels, (clvox_compression)c, 4, &tp, depths, 3, NULL));
        FILE *a = fopen(p1, "rb"), *b = fopen(p2, "rb");
        int same = a && b;
        while (same) {
            int ca = fgetc(a), cb = fgetc(b);
            if (ca != cb) same = 0;
            if (ca == EOF || cb == EOF) break;
        }
        CHECK_MSG(same, "compression %d, channels %#x: 1 and 4 threads give different files", c, channels);
        if (a) fclose(a);
        if (b) fclose(b);
        unlink(p1);
        unlink(p2);
    }
    free(vol);
    free(cov);
    free(elem);
    free(score);
}

static void test_exrheader(void)
{
    if (system("command -v exrheader >/dev/null 2>&1") != 0) {
        printf("skip: exrheader is not installed\n");
        return;
    }
    const uint32_t X = 17, Y = 5, Z = 9;
    uint8_t vol[17 * 5 * 9];
    uint16_t cov[17 * 5 * 9];
    fill_structured(vol, X, Y, Z);
    fill_coverage(cov, X, Y, Z, 1);
    clvox_grid g = make_grid(X, Y, Z);
    static const uint32_t depths[] = { 4 };
    char path[2048], cmd[2200], line[512];
    /* every compression for occupancy; then coverage with occupancy, and alone */
    for (int k = 0; k < CLVOX_COMPRESSION_COUNT + 2; k++) {
        int c = k % CLVOX_COMPRESSION_COUNT;
        uint32_t channels = k < CLVOX_COMPRESSION_COUNT        ? CLVOX_CHANNEL_OCCUPANCY
                            : k == CLVOX_COMPRESSION_COUNT ? CLVOX_CHANNEL_COVERAGE | CLVOX_CHANNEL_OCCUPANCY
                                                           : CLVOX_CHANNEL_COVERAGE;
        int with_occ = (channels & CLVOX_CHANNEL_OCCUPANCY) != 0, with_cov = (channels & CLVOX_CHANNEL_COVERAGE) != 0;
        snprintf(path, sizeof path, "%s/hdr.exr", dir);
        CHECK_OK(ctx, write_planes(path, &g, channels, (clvox_compression)c, 2, with_occ ? vol : NULL,
                                   with_cov ? cov : NULL, depths, 1, NULL));
        snprintf(cmd, sizeof cmd, "exrheader '%s' 2>&1", path);
        FILE *p = popen(cmd, "r");
        CHECK(p != NULL);
        if (!p) continue;
        int seen = 0;
        while (fgets(line, sizeof line, p)) {
            if (strstr(line, "clvoxDims")) seen |= 1;
            if (strstr(line, "clvoxOrigin")) seen |= 2;
            if (strstr(line, "clvoxVoxelSize")) seen |= 4;
            if (strstr(line, "clvoxMethod")) seen |= 8;
            if (strstr(line, "clvoxParameters")) seen |= 16;
            if (strstr(line, "clvoxVersion") && strstr(line, CLVOX_VERSION_STRING)) seen |= 32;
            if (strstr(line, "clvoxLayout")) seen |= 64;
            if (strstr(line, "(17 5 9)")) seen |= 128;
            if (strstr(line, "tiledimage")) seen |= 256;
            if (strstr(line, "occupancy, 16-bit floating-point")) seen |= 512;
            if (strstr(line, "coverage, 16-bit floating-point")) seen |= 1024;
        }
        int rc = pclose(p);
        CHECK_MSG(rc != -1 && WIFEXITED(rc) && WEXITSTATUS(rc) == 0, "exrheader exit status %d", rc);
        int want = 511 | (with_occ ? 512 : 0) | (with_cov ? 1024 : 0);
        CHECK_MSG(seen == want, "exrheader output: attributes or channels mask %#x, expected %#x", seen, want);
        unlink(path);
    }
}

static void test_unwritable(void)
{
    clvox_grid g = make_grid(4, 4, 4);
    clvox__exr_writer *w = (clvox__exr_writer *)&w; /* must be reset to NULL */
    char path[2048];

    CHECK_STATUS(ctx, clvox__exr_open(ctx, "/proc/x.exr", &g, &test_meta, 0, CLVOX_COMPRESSION_DEFAULT, 1, &w),
                 CLVOX_ERR_IO);
    CHECK(w == NULL);
    CHECK(strstr(clvox_context_error(ctx), "/proc/x.exr") != NULL);
    CHECK(strchr(clvox_context_error(ctx), '\n') == NULL);
    CHECK(!exists("/proc/x.exr"));

    snprintf(path, sizeof path, "%s/no/such/dir/x.exr", dir);
    CHECK_STATUS(ctx, clvox__exr_open(ctx, path, &g, &test_meta, 0, CLVOX_COMPRESSION_DEFAULT, 1, &w), CLVOX_ERR_IO);
    CHECK(strstr(clvox_context_error(ctx), path) != NULL);
    CHECK(!exists(path));

    /* a directory as the output */
    CHECK_STATUS(ctx, clvox__exr_open(ctx, dir, &g, &test_meta, 0, CLVOX_COMPRESSION_DEFAULT, 1, &w), CLVOX_ERR_IO);

    /* a read-only directory (root ignores permissions: skip then) */
    char ro[1100];
    snprintf(ro, sizeof ro, "%s/readonly", dir);
    mkdir(ro, 0755);
    chmod(ro, 0555);
    snprintf(path, sizeof path, "%s/x.exr", ro);
    if (access(ro, W_OK) == 0) {
        printf("skip: read-only directory check (running as root)\n");
    } else {
        CHECK_STATUS(ctx, clvox__exr_open(ctx, path, &g, &test_meta, 0, CLVOX_COMPRESSION_DEFAULT, 1, &w),
                     CLVOX_ERR_IO);
        CHECK(!exists(path));
    }
    chmod(ro, 0755);
    rmdir(ro);

    /* bad arguments */
    snprintf(path, sizeof path, "%s/bad.exr", dir);
    clvox_grid empty = make_grid(0, 4, 4);
    CHECK_STATUS(ctx, clvox__exr_open(ctx, path, &empty, &test_meta, 0, CLVOX_COMPRESSION_DEFAULT, 1, &w),
                 CLVOX_ERR_GRID);
    clvox_grid tall = make_grid(4, 65536, 65536);
    CHECK_STATUS(ctx, clvox__exr_open(ctx, path, &tall, &test_meta, 0, CLVOX_COMPRESSION_DEFAULT, 1, &w),
                 CLVOX_ERR_GRID);
    CHECK_STATUS(ctx, clvox__exr_open(ctx, path, &g, &test_meta, 0, CLVOX_COMPRESSION_COUNT, 1, &w),
                 CLVOX_ERR_INVALID_ARGUMENT);
    CHECK(!exists(path) && temp_files(path) == 0);
}

static void test_abort_and_incomplete(void)
{
    clvox_grid g = make_grid(6, 5, 4);
    uint8_t pattern[6 * 5 * 4];
    uint32_t slab[5 * 4]; /* one word per row */
    for (size_t i = 0; i < sizeof pattern; i++) pattern[i] = (i % 3) != 0;
    pack_bits(slab, pattern, 6, 5 * 4);
    char path[2048];
    snprintf(path, sizeof path, "%s/abort.exr", dir);
    unlink(path);
    for (uint32_t threads = 1; threads <= 2; threads++) {
        /* abort after some slices */
        clvox__exr_writer *w = NULL;
        CHECK_OK(ctx, clvox__exr_open(ctx, path, &g, &test_meta, 0, CLVOX_COMPRESSION_RLE, threads, &w));
        CHECK(!exists(path));          /* not renamed while writing */
        CHECK(temp_files(path) == 0);  /* the file being written has no name (O_TMPFILE) */
        CHECK_OK(ctx, clvox__exr_write_slab(w, 0, 2, &(clvox__slab_planes){ .occupancy_bits = slab }));
        CHECK(!exists(path));
        clvox__exr_abort(w);
        CHECK(!exists(path));
        CHECK(temp_files(path) == 0);

        /* finish with missing slices */
        CHECK_OK(ctx, clvox__exr_open(ctx, path, &g, &test_meta, 0, CLVOX_COMPRESSION_ZIP, threads, &w));
        CHECK_OK(ctx, clvox__exr_write_slab(w, 0, 3, &(clvox__slab_planes){ .occupancy_bits = slab }));
        uint64_t bytes = 123;
        clvox_status st = clvox__exr_finish(w, &bytes);
        CHECK(st != CLVOX_OK);
        CHECK(strstr(clvox_context_error(ctx), "3 of 4") != NULL);
        CHECK(bytes == 0);
        CHECK(!exists(path) && temp_files(path) == 0);

        /* no slice at all */
        CHECK_OK(ctx, clvox__exr_open(ctx, path, &g, &test_meta, 0, CLVOX_COMPRESSION_NONE, threads, &w));
        CHECK(clvox__exr_finish(w, NULL) != CLVOX_OK);
        CHECK(!exists(path) && temp_files(path) == 0);

        /* slices out of order: error, then finish fails, nothing left */
        CHECK_OK(ctx, clvox__exr_open(ctx, path, &g, &test_meta, 0, CLVOX_COMPRESSION_RLE, threads, &w));
        CHECK_OK(ctx, clvox__exr_write_slab(w, 0, 1, &(clvox__slab_planes){ .occupancy_bits = slab }));
        CHECK(clvox__exr_write_slab(w, 2, 1, &(clvox__slab_planes){ .occupancy_bits = slab }) != CLVOX_OK);  /* gap */
        CHECK(clvox__exr_write_slab(w, 1, 3, &(clvox__slab_planes){ .occupancy_bits = slab }) != CLVOX_OK);  /* writer has failed */
        CHECK(clvox__exr_finish(w, NULL) != CLVOX_OK);
        CHECK(!exists(path) && temp_files(path) == 0);

        CHECK_OK(ctx, clvox__exr_open(ctx, path, &g, &test_meta, 0, CLVOX_COMPRESSION_RLE, threads, &w));
        CHECK(clvox__exr_write_slab(w, 0, 5, &(clvox__slab_planes){ .occupancy_bits = slab }) != CLVOX_OK);  /* past Z */
        clvox__exr_abort(w);
        CHECK(!exists(path) && temp_files(path) == 0);
    }
    clvox__exr_abort(NULL); /* NULL-safe */

    /* an existing file is replaced only by finish */
    FILE *f = fopen(path, "w");
    CHECK(f != NULL);
    if (f) {
        fputs("old", f);
        fclose(f);
    }
    clvox__exr_writer *w = NULL;
    CHECK_OK(ctx, clvox__exr_open(ctx, path, &g, &test_meta, 0, CLVOX_COMPRESSION_RLE, 2, &w));
    CHECK_OK(ctx, clvox__exr_write_slab(w, 0, 4, &(clvox__slab_planes){ .occupancy_bits = slab }));
    CHECK(file_size(path) == 3);
    clvox__exr_abort(w);
    CHECK(file_size(path) == 3); /* abort keeps the old file */
    CHECK_OK(ctx, clvox__exr_open(ctx, path, &g, &test_meta, 0, CLVOX_COMPRESSION_RLE, 2, &w));
    CHECK_OK(ctx, clvox__exr_write_slab(w, 0, 1, &(clvox__slab_planes){ .occupancy_bits = slab }));
    CHECK_OK(ctx, clvox__exr_write_slab(w, 1, 3, &(clvox__slab_planes){ .occupancy_bits = slab + 5 }));
    CHECK(file_size(path) == 3);
    uint64_t bytes = 0;
    CHECK_OK(ctx, clvox__exr_finish(w, &bytes));
    CHECK((long long)bytes == file_size(path) && bytes > 3);
    CHECK(temp_files(path) == 0);
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, NULL, 0));
    CHECK(info.filled_voxels == 80); /* 2 of every 3 of 120 */
    unlink(path);
}

/* Writes the 6x5x4 pattern to `path` through the writer; between open and
 * finish the directory `d_path` must hold exactly `during` entries. */
static clvox_status write_small(const char *path, const char *d_path, int during, const char *what)
{
    clvox_grid g = make_grid(6, 5, 4);
    uint8_t pattern[6 * 5 * 4];
    uint32_t slab[5 * 4];
    for (size_t i = 0; i < sizeof pattern; i++) pattern[i] = (i % 3) != 0;
    pack_bits(slab, pattern, 6, 5 * 4);
    clvox__exr_writer *w = NULL;
    clvox_status st = clvox__exr_open(ctx, path, &g, &test_meta, 0, CLVOX_COMPRESSION_RLE, 1, &w);
    if (st != CLVOX_OK) return st;
    st = clvox__exr_write_slab(w, 0, 4, &(clvox__slab_planes){ .occupancy_bits = slab });
    size_t longest = 0;
    int n = dir_count(d_path, &longest);
    CHECK_MSG(n == during, "%s: %d entries in the directory while writing, expected %d", what, n, during);
    CHECK_MSG(longest <= 255, "%s: a %zu-byte name in the directory", what, longest);
    if (st != CLVOX_OK) {
        clvox__exr_abort(w);
        return st;
    }
    return clvox__exr_finish(w, NULL);
}

/* Outputs that are not regular files are refused and left alone; the file
 * being written is invisible (O_TMPFILE) or, in the fallback, one short
 * hidden name; names up to NAME_MAX work, new or replacing a file. */
static void test_output_files(void)
{
    char sub[1100], path[2048], target[2048];
    snprintf(sub, sizeof sub, "%s/outfiles", dir);
    mkdir(sub, 0777);
    clvox_grid g = make_grid(4, 4, 4);
    clvox__exr_writer *w = NULL;
    struct stat sb;

    for (int mode = 0; mode < 2; mode++) {
        clvox__exr_no_tmpfile = mode; /* 1: the named fallback */
        const char *m = mode ? "named temporary" : "O_TMPFILE";

        /* invisible while written: nothing but what was there before */
        snprintf(path, sizeof path, "%s/new.exr", sub);
        CHECK_MSG(write_small(path, sub, mode ? 1 : 0, m) == CLVOX_OK, "%s: %s", m, clvox_context_error(ctx));
        CHECK(exists(path) && dir_count(sub, NULL) == 1);
        /* replacing an existing file: the same, and nothing else left */
        CHECK_MSG(write_small(path, sub, mode ? 2 : 1, m) == CLVOX_OK, "%s: %s", m, clvox_context_error(ctx));
        CHECK(dir_count(sub, NULL) == 1);
        clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
        CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, NULL, 0));
        CHECK(info.filled_voxels == 80);
        unlink(path);

        /* a FIFO: refused at open, left as it is */
        snprintf(path, sizeof path, "%s/fifo.exr", sub);
        CHECK(mkfifo(path, 0666) == 0);
        CHECK_STATUS(ctx, clvox__exr_open(ctx, path, &g, &test_meta, 0, CLVOX_COMPRESSION_RLE, 1, &w), CLVOX_ERR_IO);
        CHECK(w == NULL && strstr(clvox_context_error(ctx), "not a regular file") != NULL);
        CHECK(lstat(path, &sb) == 0 && S_ISFIFO(sb.st_mode));
        unlink(path);

        /* a character device node (needs privileges: skipped otherwise) */
        snprintf(path, sizeof path, "%s/null.exr", sub);
        if (mknod(path, S_IFCHR | 0666, makedev(1, 3)) == 0) {
            CHECK_STATUS(ctx, clvox__exr_open(ctx, path, &g, &test_meta, 0, CLVOX_COMPRESSION_RLE, 1, &w),
                         CLVOX_ERR_IO);
            CHECK(lstat(path, &sb) == 0 && S_ISCHR(sb.st_mode));
            unlink(path);
        } else if (mode == 0) {
            printf("skip: character device output (mknod: %s)\n", strerror(errno));
        }

        /* a symbolic link, to a regular file or dangling: refused, the link and its target untouched */
        snprintf(target, sizeof target, "%s/target.exr", sub);
        FILE *f = fopen(target, "w");
        CHECK(f != NULL);
        if (f) {
            fputs("old", f);
            fclose(f);
        }
        snprintf(path, sizeof path, "%s/link.exr", sub);
        CHECK(symlink("target.exr", path) == 0);
        CHECK_STATUS(ctx, clvox__exr_open(ctx, path, &g, &test_meta, 0, CLVOX_COMPRESSION_RLE, 1, &w), CLVOX_ERR_IO);
        CHECK(strstr(clvox_context_error(ctx), "symbolic link") != NULL);
        CHECK(lstat(path, &sb) == 0 && S_ISLNK(sb.st_mode) && file_size(target) == 3);
        unlink(target);
        CHECK_STATUS(ctx, clvox__exr_open(ctx, path, &g, &test_meta, 0, CLVOX_COMPRESSION_RLE, 1, &w), CLVOX_ERR_IO);
        CHECK(lstat(path, &sb) == 0 && S_ISLNK(sb.st_mode) && !exists(target));
        unlink(path);

        /* a FIFO that appears while the file is written: refused at finish */
        snprintf(path, sizeof path, "%s/late.exr", sub);
        clvox_grid g6 = make_grid(6, 5, 4);
        uint32_t slab[5 * 4] = { 0 };
        CHECK_OK(ctx, clvox__exr_open(ctx, path, &g6, &test_meta, 0, CLVOX_COMPRESSION_RLE, 1, &w));
        CHECK_OK(ctx, clvox__exr_write_slab(w, 0, 4, &(clvox__slab_planes){ .occupancy_bits = slab }));
        CHECK(mkfifo(path, 0666) == 0);
        CHECK_STATUS(ctx, clvox__exr_finish(w, NULL), CLVOX_ERR_IO);
        CHECK(lstat(path, &sb) == 0 && S_ISFIFO(sb.st_mode));
        unlink(path);
        CHECK_MSG(dir_count(sub, NULL) == 0, "%s: files left after the refusals", m);

        /* 250- and 255-byte names (NAME_MAX): new, then replacing the file */
        for (int len = 250; len <= 255; len += 5) {
            char name[256];
            memset(name, 'n', (size_t)len);
            memcpy(name + len - 4, ".exr", 4);
            name[len] = '\0';
            snprintf(path, sizeof path, "%s/%s", sub, name);
            CHECK_MSG(write_small(path, sub, mode ? 1 : 0, m) == CLVOX_OK, "%s, %d-byte name: %s", m, len,
                      clvox_context_error(ctx));
            CHECK_MSG(write_small(path, sub, mode ? 2 : 1, m) == CLVOX_OK, "%s, %d-byte name, replacing: %s", m,
                      len, clvox_context_error(ctx));
            CHECK(exists(path) && dir_count(sub, NULL) == 1);
            unlink(path);
        }
    }
    clvox__exr_no_tmpfile = 0;
    CHECK_MSG(rmdir(sub) == 0, "%s is not empty", sub);
}

/* A write error (here: the file size limit, as for a full disk) is
 * CLVOX_ERR_IO, and leaves neither the file nor the temporary file. Runs in a
 * child process because of setrlimit. */
static void test_write_error(void)
{
    char path[2048];
    snprintf(path, sizeof path, "%s/full.exr", dir);
    unlink(path);
    fflush(NULL);
    pid_t pid = fork();
    if (pid == 0) {
        struct rlimit rl = { 64 * 1024, 64 * 1024 };
        signal(SIGXFSZ, SIG_IGN);
        if (setrlimit(RLIMIT_FSIZE, &rl) != 0) _exit(10);
        const uint32_t X = 64, Y = 64, Z = 64;
        uint8_t *vol = malloc((size_t)X * Y * Z);
        if (!vol) _exit(11);
        fill_random(vol, (size_t)X * Y * Z);
        clvox_grid g = make_grid(X, Y, Z);
        static const uint32_t depths[] = { 5 };
        int code = 0;
        for (int c = 0; c < 2 && !code; c++) {
            clvox_compression comp = c ? CLVOX_COMPRESSION_RLE : CLVOX_COMPRESSION_NONE;
            clvox_status st = write_volume(path, &g, comp, 2, vol, depths, 1, NULL);
            if (st != CLVOX_ERR_IO) code = 20 + (int)st;
            else if (!strstr(clvox_context_error(ctx), "full.exr") || strchr(clvox_context_error(ctx), '\n'))
                code = 12;
            else if (exists(path) || temp_files(path) != 0) code = 13;
            else if (c == 1) printf("write error reported as: %s\n", clvox_context_error(ctx));
        }
        free(vol);
        fflush(stdout);
        _exit(code);
    }
    int status = -1;
    if (pid > 0) waitpid(pid, &status, 0);
    CHECK_MSG(pid > 0 && WIFEXITED(status) && WEXITSTATUS(status) == 0, "write error child: status %#x", status);
    CHECK(!exists(path) && temp_files(path) == 0);
}

/* OpenEXR's C++ library decodes what clvox writes: exrmaketiled reads every
 * pixel of the file (any compression, our RLE from bits included) and
 * writes a copy in 64x64 tiles, uncompressed, keeping the header; clvox's
 * reader must then find exactly the voxels written. */
static void test_cxx_decoder(void)
{
    if (system("command -v exrmaketiled >/dev/null 2>&1") != 0) {
        printf("skip: exrmaketiled is not installed\n");
        return;
    }
    const uint32_t X = 70, Y = 33, Z = 11; /* rows end inside words; several tiles across */
    const size_t n = (size_t)X * Y * Z;
    uint8_t *vol = malloc(n), *back = malloc(n);
    if (!vol || !back) {
        CHECK(!"out of memory");
        free(vol);
        free(back);
        return;
    }
    clvox_grid g = make_grid(X, Y, Z);
    static const uint32_t depths[] = { 4 };
    char in[2048], out[2048], cmd[4200];
    snprintf(in, sizeof in, "%s/cxx_in.exr", dir);
    snprintf(out, sizeof out, "%s/cxx_out.exr", dir);
    for (int pattern = 0; pattern < 2; pattern++) {
        if (pattern) fill_random(vol, n);
        else fill_structured(vol, X, Y, Z);
        for (int c = 0; c < CLVOX_COMPRESSION_COUNT; c++) {
            CHECK_OK(ctx, write_volume(in, &g, (clvox_compression)c, 2, vol, depths, 1, NULL));
            snprintf(cmd, sizeof cmd, "exrmaketiled -o -t 64 64 -z none '%s' '%s' >/dev/null 2>&1", in, out);
            int rc = system(cmd);
            CHECK_MSG(rc == 0, "exrmaketiled failed (%d) on %s compression", rc, comp_names[c]);
            clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
            memset(back, 7, n);
            CHECK_OK(ctx, clvox_volume_read(ctx, out, &info, back, n));
            CHECK_MSG(memcmp(back, vol, n) == 0 && info.filled_voxels == count(vol, n),
                      "%s, pattern %d: the C++ decoder sees other voxels", comp_names[c], pattern);
            unlink(in);
            unlink(out);
        }
    }
    /* coverage with occupancy, decoded from the C++ library's copy by
     * OpenEXRCore's generic pipeline */
    uint16_t *cov = malloc(n * 2), *cov_back = malloc(n * 2), *occ_back = malloc(n * 2);
    if (cov && cov_back && occ_back) {
        fill_coverage(cov, X, Y, Z, 0);
        fill_random(vol, n);
        for (int c = 0; c < CLVOX_COMPRESSION_COUNT; c++) {
            CHECK_OK(ctx, write_planes(in, &g, CLVOX_CHANNEL_COVERAGE | CLVOX_CHANNEL_OCCUPANCY, (clvox_compression)c,
                                       2, vol, cov, depths, 1, NULL));
            snprintf(cmd, sizeof cmd, "exrmaketiled -o -t 64 64 -z none '%s' '%s' >/dev/null 2>&1", in, out);
            int rc = system(cmd);
            CHECK_MSG(rc == 0, "exrmaketiled failed (%d) on coverage, %s compression", rc, comp_names[c]);
            char names[256];
            uint32_t th = 0;
            memset(cov_back, 7, n * 2);
            memset(occ_back, 7, n * 2);
            CHECK(decode_halves(out, n, cov_back, occ_back, names, sizeof names, &th) && th == 64);
            CHECK(strcmp(names, "coverage,occupancy") == 0);
            CHECK_MSG(first_diff(cov, cov_back, n) == n, "%s: the C++ decoder sees other coverage", comp_names[c]);
            size_t bad = 0;
            for (size_t i = 0; i < n; i++) bad += occ_back[i] != (vol[i] ? 0x3C00 : 0x0000);
            CHECK_MSG(bad == 0, "%s: the C++ decoder sees %zu other occupancy samples", comp_names[c], bad);
            unlink(in);
            unlink(out);
        }
    } else {
        CHECK(!"out of memory");
    }
    free(cov);
    free(cov_back);
    free(occ_back);
    free(vol);
    free(back);
}

/* An uncompressed volume larger than the free space of the output's file
 * system is refused at open (before any work) with CLVOX_ERR_IO, no file
 * left; the same grid with RLE is accepted (its size is unknown). */
static void test_disk_space(void)
{
    char path[2048];
    snprintf(path, sizeof path, "%s/huge.exr", dir);
    struct statvfs vfs;
    CHECK(statvfs(dir, &vfs) == 0);
    uint64_t avail = (uint64_t)vfs.f_bavail * (vfs.f_frsize ? vfs.f_frsize : vfs.f_bsize);
    const uint32_t X = 4096, Y = 4096;
    uint64_t slice = (uint64_t)X * Y * 2, z = avail / slice + 2;
    if (z > 65536) {
        printf("skip: %llu GB free, more than the largest grid\n", (unsigned long long)(avail >> 30));
        return;
    }
    clvox_grid g = make_grid(X, Y, (uint32_t)z);
    clvox__exr_writer *w = NULL;
    CHECK_STATUS(ctx, clvox__exr_open(ctx, path, &g, &test_meta, 0, CLVOX_COMPRESSION_NONE, 1, &w), CLVOX_ERR_IO);
    CHECK_MSG(strstr(clvox_context_error(ctx), "not enough disk space") != NULL, "message: %s",
              clvox_context_error(ctx));
    CHECK(w == NULL && !exists(path) && temp_files(path) == 0);
    CHECK_OK(ctx, clvox__exr_open(ctx, path, &g, &test_meta, 0, CLVOX_COMPRESSION_RLE, 1, &w));
    clvox__exr_abort(w);
    CHECK(!exists(path) && temp_files(path) == 0);
}

/* An EXR written with OpenEXRCore directly: X x (Y*Z) pixels of vol,
 * scanline (tile_w == 0) or tiled, with or without the clvox attributes. */
static void write_foreign_exr(const char *path, uint32_t X, uint32_t Y, uint32_t Z, const uint16_t *half,
                              int tile_w, int tile_h, exr_compression_t comp, int attributes)
{
    exr_context_t e = NULL;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    int part = 0, H = (int)(Y * Z);
    CHECK(exr_start_write(&e, path, EXR_WRITE_FILE_DIRECTLY, &init) == EXR_ERR_SUCCESS);
    CHECK(exr_add_part(e, NULL, tile_w ? EXR_STORAGE_TILED : EXR_STORAGE_SCANLINE, &part) == EXR_ERR_SUCCESS);
    CHECK(exr_initialize_required_attr_simple(e, part, (int)X, H, comp) == EXR_ERR_SUCCESS);
    if (tile_w)
        CHECK(exr_set_tile_descriptor(e, part, (uint32_t)tile_w, (uint32_t)tile_h, EXR_TILE_ONE_LEVEL,
                                      EXR_TILE_ROUND_DOWN) == EXR_ERR_SUCCESS);
    CHECK(exr_add_channel(e, part, "a_other", EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LINEAR, 1, 1) == EXR_ERR_SUCCESS);
    CHECK(exr_add_channel(e, part, "occupancy", EXR_PIXEL_HALF, EXR_PERCEPTUALLY_LINEAR, 1, 1) == EXR_ERR_SUCCESS);
    if (attributes) {
        exr_attr_v3i_t d = { .arr = { (int32_t)X, (int32_t)Y, (int32_t)Z } };
        exr_attr_v3d_t o = { .arr = { 1, 2, 3 } }, h = { .arr = { 0.25, 0.25, 0.25 } };
        exr_attr_set_v3i(e, part, "clvoxDims", &d);
        exr_attr_set_v3d(e, part, "clvoxOrigin", &o);
        exr_attr_set_v3d(e, part, "clvoxVoxelSize", &h);
        exr_attr_set_string(e, part, "clvoxMethod", "tetra");
        exr_attr_set_string(e, part, "clvoxParameters", "");
        exr_attr_set_string(e, part, "clvoxVersion", "9.9.9");
    }
    CHECK(exr_write_header(e) == EXR_ERR_SUCCESS);
    float *other = calloc((size_t)X * H, sizeof(float));
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    int first = 1;
    int32_t lpc = 1;
    if (!tile_w) exr_get_scanlines_per_chunk(e, part, &lpc);
    int step_y = tile_w ? tile_h : lpc, step_x = tile_w ? tile_w : (int)X;
    for (int y0 = 0; y0 < H; y0 += step_y)
        for (int x0 = 0; x0 < (int)X; x0 += step_x) {
            exr_chunk_info_t ci;
            exr_result_t rv = tile_w ? exr_write_tile_chunk_info(e, part, x0 / tile_w, y0 / tile_h, 0, 0, &ci)
                                     : exr_write_scanline_chunk_info(e, part, y0, &ci);
            CHECK(rv == EXR_ERR_SUCCESS);
            rv = first ? exr_encoding_initialize(e, part, &ci, &enc) : exr_encoding_update(e, part, &ci, &enc);
            CHECK(rv == EXR_ERR_SUCCESS);
            for (int c = 0; c < enc.channel_count; c++) {
                exr_coding_channel_info_t *ch = &enc.channels[c];
                int is_occ = strcmp(ch->channel_name, "occupancy") == 0;
                size_t b = is_occ ? 2 : 4;
                ch->encode_from_ptr = is_occ ? (const uint8_t *)(half + (size_t)y0 * X + x0)
                                             : (const uint8_t *)(other + (size_t)y0 * X + x0);
                ch->user_pixel_stride = (int32_t)b;
                ch->user_line_stride = (int32_t)(X * b);
                ch->user_bytes_per_element = (int16_t)b;
                ch->user_data_type = is_occ ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT;
            }
            if (first) CHECK(exr_encoding_choose_default_routines(e, part, &enc) == EXR_ERR_SUCCESS);
            first = 0;
            CHECK(exr_encoding_run(e, part, &enc) == EXR_ERR_SUCCESS);
        }
    exr_encoding_destroy(e, &enc);
    CHECK(exr_finish(&e) == EXR_ERR_SUCCESS);
    free(other);
}

/* The reader takes any single-level layout, other channels, and counts
 * exactly the samples > 0.5. */
static void test_reader_layouts(void)
{
    const uint32_t X = 13, Y = 7, Z = 5;
    const size_t n = (size_t)X * Y * Z;
    static const uint16_t special[] = { 0x0000, 0x3800 /* 0.5 */, 0x3801, 0x3C00, 0x7C00 /* +inf */,
                                        0x7C01 /* NaN */, 0x7E00 /* NaN */, 0xBC00 /* -1 */, 0x8000 /* -0 */,
                                        0x0001, 0x7BFF /* 65504 */, 0x37FF };
    static const uint8_t expect[] = { 0, 0, 1, 1, 1, 0, 0, 0, 0, 0, 1, 0 };
    uint16_t half[13 * 7 * 5];
    uint8_t want[13 * 7 * 5], back[13 * 7 * 5];
    uint64_t filled = 0;
    for (size_t i = 0; i < n; i++) {
        size_t k = rnd() % (sizeof special / sizeof special[0]);
        half[i] = special[k];
        want[i] = expect[k];
        filled += expect[k];
    }
    char path[2048];
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    static const struct { int tw, th; exr_compression_t c; } layouts[] = {
        { 0, 0, EXR_COMPRESSION_NONE }, { 0, 0, EXR_COMPRESSION_ZIP }, { 0, 0, EXR_COMPRESSION_PIZ },
        { 4, 4, EXR_COMPRESSION_RLE },  { 13, 7, EXR_COMPRESSION_ZIPS }, { 5, 35, EXR_COMPRESSION_NONE },
        { 64, 64, EXR_COMPRESSION_PIZ },
    };
    snprintf(path, sizeof path, "%s/foreign.exr", dir);
    for (size_t l = 0; l < sizeof layouts / sizeof layouts[0]; l++) {
        write_foreign_exr(path, X, Y, Z, half, layouts[l].tw, layouts[l].th, layouts[l].c, 1);
        memset(back, 7, sizeof back);
        CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, back, sizeof back));
        CHECK_MSG(info.filled_voxels == filled, "layout %zu: filled %llu, expected %llu", l,
                  (unsigned long long)info.filled_voxels, (unsigned long long)filled);
        CHECK_MSG(memcmp(back, want, n) == 0, "layout %zu: voxels differ", l);
        CHECK(strcmp(info.channels, "a_other,occupancy") == 0);
        CHECK(strcmp(info.method, "tetra") == 0 && strcmp(info.version, "9.9.9") == 0);
        CHECK(info.parameters[0] == '\0');
        CHECK(info.origin[2] == 3 && info.voxel_size[0] == 0.25);
    }
    /* what they mean, through clvox's writer (which takes bits) */
    clvox_grid g = make_grid(X, Y, Z);
    clvox__exr_writer *w = NULL;
    uint32_t bits[7 * 5];
    pack_bits(bits, want, X, (size_t)Y * Z);
    for (int c = 0; c < CLVOX_COMPRESSION_COUNT; c++) {
        CHECK_OK(ctx, clvox__exr_open(ctx, path, &g, &test_meta, 0, (clvox_compression)c, 2, &w));
        CHECK_OK(ctx, clvox__exr_write_slab(w, 0, Z, &(clvox__slab_planes){ .occupancy_bits = bits }));
        CHECK_OK(ctx, clvox__exr_finish(w, NULL));
        CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, back, sizeof back));
        CHECK(info.filled_voxels == filled && memcmp(back, want, n) == 0);
    }
    /* without the attributes: not a clvox volume */
    write_foreign_exr(path, X, Y, Z, half, 0, 0, EXR_COMPRESSION_NONE, 0);
    CHECK_STATUS(ctx, clvox_volume_read(ctx, path, &info, NULL, 0), CLVOX_ERR_EXR);
    CHECK(strstr(clvox_context_error(ctx), "not a clvox volume") != NULL);
    unlink(path);
}

static void test_reader_rejects(void)
{
    char path[2048];
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;

    snprintf(path, sizeof path, "%s/missing.exr", dir);
    unlink(path);
    CHECK_STATUS(ctx, clvox_volume_read(ctx, path, &info, NULL, 0), CLVOX_ERR_IO);
    CHECK(strstr(clvox_context_error(ctx), path) != NULL);
    CHECK_STATUS(ctx, clvox_volume_read(ctx, dir, &info, NULL, 0), CLVOX_ERR_IO);
    CHECK_STATUS(ctx, clvox_volume_read(ctx, NULL, &info, NULL, 0), CLVOX_ERR_INVALID_ARGUMENT);

    snprintf(path, sizeof path, "%s/text.exr", dir);
    FILE *f = fopen(path, "w");
    if (f) {
        fputs("this is not an EXR file\n", f);
        fclose(f);
    }
    CHECK_STATUS(ctx, clvox_volume_read(ctx, path, &info, NULL, 0), CLVOX_ERR_EXR);
    unlink(path);

    /* buffer too small; truncated file */
    const uint32_t X = 20, Y = 10, Z = 30;
    uint8_t vol[20 * 10 * 30], back[20 * 10 * 30];
    fill_random(vol, sizeof vol);
    clvox_grid g = make_grid(X, Y, Z);
    static const uint32_t depths[] = { 8 };
    snprintf(path, sizeof path, "%s/small.exr", dir);
    CHECK_OK(ctx, write_volume(path, &g, CLVOX_COMPRESSION_NONE, 1, vol, depths, 1, NULL));
    CHECK_STATUS(ctx, clvox_volume_read(ctx, path, &info, back, sizeof back - 1), CLVOX_ERR_INVALID_ARGUMENT);
    long long size = file_size(path);
    CHECK(size > 0 && truncate(path, size * 2 / 3) == 0);
    CHECK(clvox_volume_read(ctx, path, &info, back, sizeof back) != CLVOX_OK);
    CHECK(strchr(clvox_context_error(ctx), '\n') == NULL);
    unlink(path);
}

static long vm_hwm_kb(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    long kb = -1;
    if (!f) return -1;
    while (fgets(line, sizeof line, f))
        if (sscanf(line, "VmHWM: %ld kB", &kb) == 1) break;
    fclose(f);
    return kb;
}

/* Streams a 256x256xZ sphere in slabs of 16 slices. */
static clvox_status stream_sphere(const char *path, uint32_t Z, uint32_t *slab)
{
    const uint32_t X = 256, Y = 256, NZ = 16, W = 256 / 32;
    clvox_grid g = make_grid(X, Y, Z);
    clvox__exr_writer *w = NULL;
    clvox_status st = clvox__exr_open(ctx, path, &g, &test_meta, 0, CLVOX_COMPRESSION_DEFAULT, 2, &w);
    if (st != CLVOX_OK) return st;
    for (uint32_t z0 = 0; z0 < Z; z0 += NZ) {
        for (uint32_t k = 0; k < NZ; k++)
            for (uint32_t y = 0; y < Y; y++)
                for (uint32_t x = 0; x < X; x++) {
                    double dx = x - 128.0, dy = y - 128.0, dz = ((z0 + k) % 256) - 128.0;
                    uint32_t *word = &slab[((size_t)k * Y + y) * W + x / 32], bit = 1u << (x % 32);
                    *word = dx * dx + dy * dy + dz * dz < 100.0 * 100.0 ? *word | bit : *word & ~bit;
                }
        st = clvox__exr_write_slab(w, z0, NZ, &(clvox__slab_planes){ .occupancy_bits = slab });
        if (st != CLVOX_OK) {
            clvox__exr_abort(w);
            return st;
        }
    }
    return clvox__exr_finish(w, NULL);
}

/* Peak memory must not grow with the number of slices: writing (and then
 * reading) 4096 slices may use at most BOUND_KB more than 64 slices (the
 * offset table is 8 bytes per slice, 32 KiB here). Runs in a child process
 * so that the other tests' allocations do not hide the growth. */
#if defined(__SANITIZE_THREAD__) /* its shadow memory: 2.2-2.3 MB measured (scripts/check_threads.sh) */
#define BOUND_KB 8192L
#else
#define BOUND_KB 2048L
#endif
static void test_peak_memory(void)
{
    char path[2048];
    snprintf(path, sizeof path, "%s/mem.exr", dir);
    int fds[2];
    if (pipe(fds) != 0) {
        CHECK(!"pipe");
        return;
    }
    fflush(NULL);
    pid_t pid = fork();
    if (pid == 0) {
        long r[4] = { -1, -1, -1, -1 };
        uint32_t *slab = malloc((size_t)256 / 32 * 256 * 16 * sizeof *slab);
        clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
        if (slab && stream_sphere(path, 64, slab) == CLVOX_OK && stream_sphere(path, 64, slab) == CLVOX_OK &&
            clvox_volume_read(ctx, path, &info, NULL, 0) == CLVOX_OK) {
            r[0] = vm_hwm_kb();
            if (stream_sphere(path, 4096, slab) == CLVOX_OK) r[1] = vm_hwm_kb();
            if (clvox_volume_read(ctx, path, &info, NULL, 0) == CLVOX_OK && info.dims[2] == 4096)
                r[2] = vm_hwm_kb();
            r[3] = (long)info.filled_voxels;
        }
        free(slab);
        ssize_t wr = write(fds[1], r, sizeof r);
        _exit(wr == (ssize_t)sizeof r ? 0 : 1);
    }
    close(fds[1]);
    long r[4] = { -1, -1, -1, -1 };
    ssize_t got = pid > 0 ? read(fds[0], r, sizeof r) : -1;
    close(fds[0]);
    int status = 0;
    if (pid > 0) waitpid(pid, &status, 0);
    CHECK(got == (ssize_t)sizeof r && r[0] > 0 && r[1] > 0 && r[2] > 0);
    CHECK_MSG(r[1] - r[0] < BOUND_KB, "VmHWM grew by %ld kB writing 4096 slices instead of 64 (bound %ld kB)",
              r[1] - r[0], BOUND_KB);
    CHECK_MSG(r[2] - r[0] < BOUND_KB, "VmHWM grew by %ld kB reading 4096 slices (bound %ld kB)", r[2] - r[0],
              BOUND_KB);
    CHECK(r[3] > 0);
    printf("peak memory: VmHWM %ld kB after 64 slices, %ld kB after writing 4096, %ld kB after reading them "
           "(bound +%ld kB)\n", r[0], r[1], r[2], BOUND_KB);
    unlink(path);
}

int main(void)
{
    clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
    o.host_only = 1;
    clvox_status st = clvox_context_create(&o, &ctx);
    if (st != CLVOX_OK) {
        fprintf(stderr, "host-only context: %s\n", clvox_context_error(ctx));
        printf("0 passed, 1 failed\n");
        return 1;
    }
    snprintf(dir, sizeof dir, "%s/exr-%ld", test_tmpdir(), (long)getpid()); /* parallel runs do not collide */
    mkdir(dir, 0777);

    test_round_trips();
    test_row_chunks();
    test_coverage();
    test_coverage_row_chunks();
    if (clvox_palette_builtin(ctx, "paper46", &pal46) != CLVOX_OK ||
        clvox_palette_load(ctx, "palettes/blocks.txt", &pal_blocks) != CLVOX_OK) {
        fprintf(stderr, "FAIL: palettes: %s\n", clvox_context_error(ctx));
        test_failed++;
    } else {
        meta46 = (clvox__exr_meta){ .method = "ray", .parameters = "p46", .palette = pal46, .metric = "outer" };
        meta_blocks = (clvox__exr_meta){ .method = "ray", .parameters = "blocks", .palette = pal_blocks,
                                         .metric = "inner" };
        test_palette_channels();
        test_palette_row_chunks();
        test_palette_header();
    }
    test_bad_planes();
    test_threads_identical();
    test_exrheader();
    test_cxx_decoder();
    test_unwritable();
    test_abort_and_incomplete();
    test_output_files();
    test_write_error();
    test_disk_space();
    test_reader_rejects();
    test_reader_layouts();
    test_peak_memory();

    CHECK_MSG(rmdir(dir) == 0, "%s is not empty: a file was left behind", dir);
    clvox_palette_destroy(pal46);
    clvox_palette_destroy(pal_blocks);
    clvox_context_destroy(ctx);
    return test_report();
}
