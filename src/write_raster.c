/* One raw raster file per channel, streamed slab by slab: the engine under
 * the npy and NRRD writers (write_npy.c, write_nrrd.c). Each file is a
 * header the format makes, then the channel's voxels x fastest, then y, then
 * z, raw or as one gzip stream over all slabs (NRRD "encoding: gzip"). All
 * files (and a sidecar, if any) are unnamed until every one is complete; then
 * they are named together, and those already named are removed again if a
 * later one fails. */
#include "write_raster.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <zlib.h>

#define ZCHUNK (1u << 20)

typedef struct raster_file {
    clvox__outfile of;
    char *path;
    uint32_t channel;
    clvox__dtype dtype;
    uint32_t next_z;
    int gzip;
    z_stream zs;
    int zs_ready;
} raster_file;

struct clvox__raster {
    clvox_context *ctx;
    clvox_grid grid;
    raster_file f[4];
    size_t nf;
    uint8_t *buf, *zbuf;
    size_t buf_size;
    char *sidecar_path, *sidecar;
};

static clvox_status zfail(clvox__raster *r, raster_file *f, int zr)
{
    return clvox__fail(r->ctx, zr == Z_MEM_ERROR ? CLVOX_ERR_OUT_OF_MEMORY : CLVOX_ERR_INTERNAL,
                       "zlib: compressing '%s' failed (%d)", f->path, zr);
}

/* Deflates `n` bytes and writes what comes out; finish: ends the stream. */
static clvox_status deflate_put(clvox__raster *r, raster_file *f, const uint8_t *data, size_t n, int finish)
{
    size_t left = n;
    for (;;) {
        uInt in = left > (1u << 30) ? (1u << 30) : (uInt)left;
        int mode = finish && in == left ? Z_FINISH : Z_NO_FLUSH;
        f->zs.next_in = (Bytef *)(uintptr_t)data;
        f->zs.avail_in = in;
        int zr;
        do {
            f->zs.next_out = r->zbuf;
            f->zs.avail_out = ZCHUNK;
            zr = deflate(&f->zs, mode);
            if (zr == Z_STREAM_ERROR) return zfail(r, f, zr);
            size_t have = ZCHUNK - f->zs.avail_out;
            if (have) {
                clvox_status st = clvox__outfile_write(&f->of, r->zbuf, have);
                if (st != CLVOX_OK) return st;
            }
        } while (mode == Z_FINISH ? zr != Z_STREAM_END : f->zs.avail_out == 0);
        data += in;
        left -= in;
        if (left == 0) return CLVOX_OK;
    }
}

void clvox__raster_abort(clvox__raster *r)
{
    if (!r) return;
    for (size_t i = 0; i < r->nf; i++) {
        if (r->f[i].zs_ready) deflateEnd(&r->f[i].zs);
        clvox__outfile_discard(&r->f[i].of);
        free(r->f[i].path);
    }
    free(r->buf);
    free(r->zbuf);
    free(r->sidecar_path);
    free(r->sidecar);
    free(r);
}

clvox_status clvox__raster_open(clvox_context *ctx, const clvox__fmt_info *info, const clvox__raster_spec *spec,
                                void *user, clvox__raster **out)
{
    *out = NULL;
    clvox__raster *r = calloc(1, sizeof *r);
    if (!r) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    r->ctx = ctx;
    r->grid = *info->grid;
    clvox_status st = CLVOX_OK;
    static const uint32_t order[4] = {CLVOX_CHANNEL_OCCUPANCY, CLVOX_CHANNEL_COVERAGE, CLVOX_CHANNEL_ELEMENT,
                                      CLVOX_CHANNEL_SCORE};
    for (int i = 0; i < 4 && st == CLVOX_OK; i++) {
        if (!(info->channels & order[i])) continue;
        raster_file *f = &r->f[r->nf++];
        f->channel = order[i];
        f->dtype = spec->dtype(info, order[i]);
        f->gzip = spec->gzip;
        f->path = clvox__channel_path(info->path, order[i], info->channels);
        if (!f->path) {
            st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
            break;
        }
        st = clvox__outfile_create(&f->of, ctx, f->path);
        char *hdr = NULL;
        size_t hlen = 0;
        if (st == CLVOX_OK) st = spec->header(ctx, info, order[i], f->dtype, f->path, user, &hdr, &hlen);
        if (st == CLVOX_OK) st = clvox__outfile_write(&f->of, hdr, hlen);
        free(hdr);
        if (st == CLVOX_OK && f->gzip) {
            /* windowBits 15 + 16: a gzip wrapper (NRRD's "gzip" encoding) */
            int zr = deflateInit2(&f->zs, 1, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY);
            if (zr != Z_OK) st = zfail(r, f, zr);
            else f->zs_ready = 1;
        }
    }
    if (st == CLVOX_OK && spec->sidecar) {
        st = spec->sidecar(ctx, info, user, &r->sidecar_path, &r->sidecar);
        if (st == CLVOX_OK && r->sidecar_path) st = clvox__outfile_check_target(ctx, r->sidecar_path);
    }
    if (st == CLVOX_OK && spec->gzip && !(r->zbuf = malloc(ZCHUNK)))
        st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    if (st != CLVOX_OK) {
        clvox__raster_abort(r);
        return st;
    }
    *out = r;
    return CLVOX_OK;
}

clvox_status clvox__raster_write(clvox__raster *r, const clvox__fmt_slab *s)
{
    const uint32_t X = r->grid.dims[0], Y = r->grid.dims[1], Z = r->grid.dims[2];
    for (size_t i = 0; i < r->nf; i++) {
        raster_file *f = &r->f[i];
        size_t rows = (size_t)Y * s->nz, rb = clvox__dtype_row_bytes(f->dtype, X), need = rows * rb;
        if (need > r->buf_size) {
            free(r->buf);
            r->buf = malloc(need);
            r->buf_size = r->buf ? need : 0;
            if (!r->buf) return clvox__fail(r->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for a slab of '%s'", f->path);
        }
        if (!clvox__encode_rows(s, f->channel, f->dtype, X, rows, r->buf)) continue; /* not in this slab */
        if (s->z0 != f->next_z || s->nz > Z - s->z0)
            return clvox__fail(r->ctx, CLVOX_ERR_INTERNAL, "'%s': slab z0=%u nz=%u out of order (expected z0=%u)",
                               f->path, s->z0, s->nz, f->next_z);
        clvox_status st = f->gzip ? deflate_put(r, f, r->buf, need, 0)
                                  : clvox__outfile_write(&f->of, r->buf, need);
        if (st != CLVOX_OK) return st;
        f->next_z += s->nz;
    }
    return CLVOX_OK;
}

clvox_status clvox__raster_finish(clvox__raster *r, uint64_t *bytes)
{
    if (bytes) *bytes = 0;
    clvox_status st = CLVOX_OK;
    for (size_t i = 0; i < r->nf && st == CLVOX_OK; i++) {
        raster_file *f = &r->f[i];
        if (f->next_z != r->grid.dims[2])
            st = clvox__fail(r->ctx, CLVOX_ERR_INTERNAL, "'%s': only %u of %u slices were written; no file written",
                             f->path, f->next_z, r->grid.dims[2]);
        else if (f->gzip)
            st = deflate_put(r, f, NULL, 0, 1);
    }
    clvox__outfile side;
    memset(&side, 0, sizeof side);
    if (st == CLVOX_OK && r->sidecar_path) {
        st = clvox__outfile_create(&side, r->ctx, r->sidecar_path);
        if (st == CLVOX_OK) st = clvox__outfile_write(&side, r->sidecar, strlen(r->sidecar));
    }
    /* Name them all; remove again those already named if one fails. */
    size_t named = 0;
    while (st == CLVOX_OK && named < r->nf) {
        uint64_t b = 0;
        st = clvox__outfile_finish(&r->f[named].of, &b);
        if (st != CLVOX_OK) break;
        if (named == 0 && bytes) *bytes = b;
        named++;
    }
    if (st == CLVOX_OK && r->sidecar_path) st = clvox__outfile_finish(&side, NULL);
    clvox__outfile_discard(&side);
    if (st != CLVOX_OK)
        for (size_t i = 0; i < named; i++) unlink(r->f[i].path);
    clvox__raster_abort(r);
    return st;
}
