/* SPDX-License-Identifier: Apache-2.0 */
/* binvox writer (Patrick Min's format; ShapeNet, viewvox, trimesh): occupancy
 * only, a cubic grid of cubic voxels (dims N N N, one scale). Header
 *   #binvox 1 / dim N N N / translate tx ty tz / scale s / data
 * with the format's own convention: translate = the grid's corner (clvox
 * origin), scale = N * h, voxel i centred at translate + (i + 0.5) * s / N.
 * Data: (value, count) byte pairs, count 1..255, over the voxels in the
 * format's order, index = x * N*N + z * N + y (y fastest, then z, then x).
 * That order runs x slowest while clvox computes z slabs, so the writer
 * keeps the whole volume as bits (N^3 / 8 bytes: 2 MiB at 256^3, 128 MiB at
 * 1024^3) and encodes it at finish, 32 x values at a time. */
#include "core/internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct binvox_writer {
    clvox_context *ctx;
    clvox_grid grid;
    char *path;
    clvox__outfile of;
    uint32_t *bits; /* Y*Z bit rows of W words: the whole volume */
    uint32_t next_z;
} binvox_writer;

static void bv_abort(void *state)
{
    binvox_writer *w = state;
    if (!w) return;
    clvox__outfile_discard(&w->of);
    free(w->bits);
    free(w->path);
    free(w);
}

static clvox_status bv_open(clvox_context *ctx, const clvox__fmt_info *info, void **state)
{
    const clvox_grid *g = info->grid;
    const uint32_t N = g->dims[0];
    const double h = g->voxel_size[0];
    if (g->dims[1] != N || g->dims[2] != N)
        return clvox__fail(ctx, CLVOX_ERR_GRID,
                           "cannot write '%s': binvox needs a cubic grid, this one is %ux%ux%u (--cube makes the box a "
                           "cube around its centre; or give a cubic --box and -r N or --dims N,N,N)",
                           info->path, g->dims[0], g->dims[1], g->dims[2]);
    for (int a = 1; a < 3; a++)
        if (fabs(g->voxel_size[a] - h) > 1e-9 * h)
            return clvox__fail(ctx, CLVOX_ERR_GRID,
                               "cannot write '%s': binvox holds one voxel size, this grid has %g x %g x %g (use -r N, "
                               "or --cube)",
                               info->path, g->voxel_size[0], g->voxel_size[1], g->voxel_size[2]);
    uint64_t words = (uint64_t)clvox__row_words(N) * N * N;
    if (words > (uint64_t)SIZE_MAX / 4)
        return clvox__fail(ctx, CLVOX_ERR_GRID, "cannot write '%s': %u^3 is too large for binvox here", info->path, N);
    binvox_writer *w = calloc(1, sizeof *w);
    if (!w) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    w->ctx = ctx;
    w->grid = *g;
    w->path = strdup(info->path);
    w->bits = malloc((size_t)words * 4);
    if (!w->path || !w->bits) {
        char sz[32];
        clvox__format_size(words * 4, sz, sizeof sz);
        bv_abort(w);
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory: a binvox %u^3 volume is held whole (%s)", N,
                           sz);
    }
    clvox_status st = clvox__outfile_create(&w->of, ctx, info->path);
    if (st != CLVOX_OK) {
        bv_abort(w);
        return st;
    }
    *state = w;
    return CLVOX_OK;
}

static clvox_status bv_write(void *state, const clvox__fmt_slab *s)
{
    binvox_writer *w = state;
    const uint32_t N = w->grid.dims[0];
    if (!s->occupancy_bits) return CLVOX_OK;
    if (s->z0 != w->next_z || s->nz > N - s->z0)
        return clvox__fail(w->ctx, CLVOX_ERR_INTERNAL, "'%s': slab z0=%u out of order", w->path, s->z0);
    size_t row = clvox__row_words(N);
    memcpy(w->bits + row * N * s->z0, s->occupancy_bits, row * N * s->nz * sizeof *w->bits);
    w->next_z += s->nz;
    return CLVOX_OK;
}

typedef struct rle {
    binvox_writer *w;
    uint8_t buf[1 << 16];
    size_t n;
    int value;
    unsigned count;
    clvox_status st;
} rle;

static void rle_emit(rle *r)
{
    if (!r->count) return;
    r->buf[r->n++] = (uint8_t)r->value;
    r->buf[r->n++] = (uint8_t)r->count;
    r->count = 0;
    if (r->n == sizeof r->buf) {
        if (r->st == CLVOX_OK) r->st = clvox__outfile_write(&r->w->of, r->buf, r->n);
        r->n = 0;
    }
}

static clvox_status bv_finish(void *state, uint64_t *bytes)
{
    binvox_writer *w = state;
    const uint32_t N = w->grid.dims[0];
    clvox_status st = CLVOX_OK;
    if (w->next_z != N) {
        st = clvox__fail(w->ctx, CLVOX_ERR_INTERNAL, "'%s': only %u of %u slices were written; no file written",
                         w->path, w->next_z, N);
        bv_abort(w);
        return st;
    }
    char hdr[512];
    const double *o = w->grid.origin;
    int hn = snprintf(hdr, sizeof hdr, "#binvox 1\ndim %u %u %u\ntranslate %.17g %.17g %.17g\nscale %.17g\ndata\n", N,
                      N, N, o[0], o[1], o[2], (double)N * w->grid.voxel_size[0]);
    st = clvox__outfile_write(&w->of, hdr, (size_t)hn);
    const size_t W = clvox__row_words(N), plane = (size_t)N * N;
    uint32_t *pw = st == CLVOX_OK ? malloc(plane * sizeof *pw) : NULL;
    if (st == CLVOX_OK && !pw) st = clvox__fail(w->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    rle *r = st == CLVOX_OK ? calloc(1, sizeof *r) : NULL;
    if (st == CLVOX_OK && !r) st = clvox__fail(w->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    if (st == CLVOX_OK) {
        r->w = w;
        r->st = CLVOX_OK;
        for (size_t wx = 0; wx < W && r->st == CLVOX_OK; wx++) {
            /* the word of x block wx of every (z, y), in the format's (z, y) order */
            for (size_t z = 0; z < N; z++)
                for (size_t y = 0; y < N; y++) pw[z * N + y] = w->bits[(z * N + y) * W + wx];
            for (unsigned b = 0; b < 32 && wx * 32 + b < N; b++)
                for (size_t i = 0; i < plane; i++) {
                    int v = (int)((pw[i] >> b) & 1u);
                    if (r->count && (v != r->value || r->count == 255)) rle_emit(r);
                    r->value = v;
                    r->count++;
                }
        }
        rle_emit(r);
        if (r->st == CLVOX_OK && r->n) r->st = clvox__outfile_write(&w->of, r->buf, r->n);
        st = r->st;
    }
    free(r);
    free(pw);
    if (st == CLVOX_OK) st = clvox__outfile_finish(&w->of, bytes);
    bv_abort(w);
    return st;
}

const clvox__fmt_ops clvox__fmt_binvox = {"binvox", CLVOX_CHANNEL_OCCUPANCY, 0, 0, bv_open, bv_write, bv_finish, bv_abort};
