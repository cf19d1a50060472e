/* SPDX-License-Identifier: Apache-2.0 */
/* One raw raster file per channel, streamed slab by slab: the engine under
 * the npy and NRRD writers (write_npy.c, write_nrrd.c). Each file is a
 * header the format makes, then the channel's voxels x fastest, then y, then
 * z, raw or as one gzip stream over all slabs (NRRD "encoding: gzip"). All
 * files are unnamed until every one is complete. Two or more files (or one
 * with a sidecar) are a set with a marker, named last, that records every
 * other member's size and CRC-32: the sidecar (npy's OUT.json), else the main
 * channel's file (NRRD: a "clvox_set:=" line in OUT.nrrd's header). The set is
 * named by clvox__outfile_finish_set (outfile.c): all or nothing, the old
 * files put back if a rename fails midway; readers and batch --skip-existing
 * trust a set only when its marker agrees with every member (output_set.c). */
#include "write_raster.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
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
    uint64_t bytes; /* written so far, and their CRC-32 */
    uint32_t crc;
} raster_file;

struct clvox__raster {
    clvox_context *ctx;
    clvox_grid grid;
    raster_file f[4];
    size_t nf;
    uint8_t *buf, *zbuf;
    size_t buf_size;
    char *sidecar_path;
    const clvox__raster_spec *spec;
    clvox__fmt_info info;   /* for the sidecar; its strings are copies */
    char *method, *parameters;
    void *user;
    size_t main;            /* index of the main channel's file */
    uint64_t set_at;        /* offset of the main file's set line (0: none) */
    size_t set_len;
};

/* Appends to the file, counting its bytes and their CRC-32. */
static clvox_status put(raster_file *f, const void *data, size_t n)
{
    clvox_status st = clvox__outfile_write(&f->of, data, n);
    if (st != CLVOX_OK) return st;
    const Bytef *p = data;
    for (size_t left = n; left > 0;) {
        uInt k = left > (1u << 30) ? (1u << 30) : (uInt)left;
        f->crc = (uint32_t)crc32(f->crc, p, k);
        p += k;
        left -= k;
    }
    f->bytes += n;
    return CLVOX_OK;
}

size_t clvox__raster_set_line(char *buf, size_t size, const clvox__raster_member *m, size_t n, uint32_t main_channel)
{
    size_t at = 0;
    int k = snprintf(buf, size, "clvox_set:=");
    at += k > 0 ? (size_t)k : 0;
    for (size_t i = 0; i < n; i++) {
        if (m[i].channel == main_channel) continue;
        k = snprintf(at < size ? buf + at : NULL, at < size ? size - at : 0, " %s:%020llu:%08x",
                     clvox__channel_name(m[i].channel), (unsigned long long)m[i].bytes, (unsigned)m[i].crc32);
        at += k > 0 ? (size_t)k : 0;
    }
    k = snprintf(at < size ? buf + at : NULL, at < size ? size - at : 0, "\n");
    return at + (k > 0 ? (size_t)k : 0);
}

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
                clvox_status st = put(f, r->zbuf, have);
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
    free(r->method);
    free(r->parameters);
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
    r->spec = spec;
    r->user = user;
    r->info = *info;
    r->info.grid = &r->grid;
    r->info.path = NULL; /* not kept: the sidecar is made from the members */
    r->method = info->method ? strdup(info->method) : NULL;
    r->parameters = info->parameters ? strdup(info->parameters) : NULL;
    r->info.method = r->method;
    r->info.parameters = r->parameters;
    clvox_status st = CLVOX_OK;
    if ((info->method && !r->method) || (info->parameters && !r->parameters))
        st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    const uint32_t main_channel = clvox__main_channel(info->channels);
    int n_channels = 0;
    for (uint32_t c = info->channels; c; c &= c - 1) n_channels++;
    /* a set without sidecar: the main file's header holds the set line */
    char set_line[256] = "";
    if (n_channels > 1 && !spec->sidecar_ext) {
        clvox__raster_member m[4];
        size_t k = 0;
        for (int i = 0; i < 4; i++)
            if (info->channels & (1u << i)) m[k++] = (clvox__raster_member){1u << i, NULL, 0, 0};
        r->set_len = clvox__raster_set_line(set_line, sizeof set_line, m, k, main_channel);
        if (r->set_len >= sizeof set_line) st = clvox__fail(ctx, CLVOX_ERR_INTERNAL, "set line too long");
    }
    static const uint32_t order[4] = {CLVOX_CHANNEL_OCCUPANCY, CLVOX_CHANNEL_COVERAGE, CLVOX_CHANNEL_ELEMENT,
                                      CLVOX_CHANNEL_SCORE};
    for (int i = 0; i < 4 && st == CLVOX_OK; i++) {
        if (!(info->channels & order[i])) continue;
        if (order[i] == main_channel) r->main = r->nf;
        raster_file *f = &r->f[r->nf++];
        f->crc = (uint32_t)crc32(0L, Z_NULL, 0);
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
        const char *sl = r->set_len && order[i] == main_channel ? set_line : NULL;
        if (st == CLVOX_OK) st = spec->header(ctx, info, order[i], f->dtype, f->path, user, sl, &hdr, &hlen);
        if (st == CLVOX_OK && sl) { /* where the line is, to fill it in at the end */
            if (hlen < r->set_len + 1 || memcmp(hdr + hlen - 1 - r->set_len, sl, r->set_len) != 0)
                st = clvox__fail(ctx, CLVOX_ERR_INTERNAL, "'%s': the header does not end with the set line", f->path);
            else
                r->set_at = hlen - 1 - r->set_len;
        }
        if (st == CLVOX_OK) st = put(f, hdr, hlen);
        free(hdr);
        if (st == CLVOX_OK && f->gzip) {
            /* windowBits 15 + 16: a gzip wrapper (NRRD's "gzip" encoding) */
            int zr = deflateInit2(&f->zs, 1, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY);
            if (zr != Z_OK) st = zfail(r, f, zr);
            else f->zs_ready = 1;
        }
    }
    if (st == CLVOX_OK && spec->sidecar_ext) {
        r->sidecar_path = clvox__replace_ext(info->path, spec->sidecar_ext);
        if (!r->sidecar_path) st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
        else st = clvox__outfile_check_target(ctx, r->sidecar_path); /* before any work */
    }
    /* `-o x.json --format npy`: the sidecar would be written over the data */
    for (size_t i = 0; st == CLVOX_OK && r->sidecar_path && i < r->nf; i++)
        if (strcmp(r->f[i].path, r->sidecar_path) == 0)
            st = clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT,
                             "output '%s' is also the name of its sidecar (%s): name the data file otherwise "
                             "(for example .npy)",
                             r->f[i].path, spec->sidecar_ext);

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
        clvox_status st = f->gzip ? deflate_put(r, f, r->buf, need, 0) : put(f, r->buf, need);
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
    clvox__raster_member m[4];
    for (size_t i = 0; i < r->nf; i++) m[i] = (clvox__raster_member){r->f[i].channel, r->f[i].path, r->f[i].bytes,
                                                                     r->f[i].crc};
    if (st == CLVOX_OK && r->set_len) { /* the main file's set line: the other members as they are now */
        char line[256];
        if (clvox__raster_set_line(line, sizeof line, m, r->nf, r->f[r->main].channel) != r->set_len)
            st = clvox__fail(r->ctx, CLVOX_ERR_INTERNAL, "'%s': the set line changed length", r->f[r->main].path);
        else
            st = clvox__outfile_pwrite(&r->f[r->main].of, line, r->set_len, r->set_at);
    }
    clvox__outfile side;
    memset(&side, 0, sizeof side);
    char *text = NULL;
    if (st == CLVOX_OK && r->sidecar_path) {
        st = r->spec->sidecar(r->ctx, &r->info, m, r->nf, r->user, &text);
        if (st == CLVOX_OK) st = clvox__outfile_create(&side, r->ctx, r->sidecar_path);
        if (st == CLVOX_OK) st = clvox__outfile_write(&side, text, strlen(text));
    }
    free(text);
    if (st == CLVOX_OK) {
        if (bytes) *bytes = r->f[0].bytes;
        /* the marker last: the sidecar, else the main file */
        clvox__outfile *set[5];
        size_t n = 0;
        for (size_t i = 0; i < r->nf; i++)
            if (r->sidecar_path || i != r->main) set[n++] = &r->f[i].of;
        set[n++] = r->sidecar_path ? &side : &r->f[r->main].of;
        if (n == 1) st = clvox__outfile_finish(set[0], NULL);
        else st = clvox__outfile_finish_set(set, n);
        if (st != CLVOX_OK && bytes) *bytes = 0;
    }
    clvox__outfile_discard(&side);
    clvox__raster_abort(r);
    return st;
}
