/* SPDX-License-Identifier: Apache-2.0 */
/* The output formats: the format table, file names per channel, the slab
 * conversions shared by the writers, the file sink every format is written
 * through (clvox_voxelize_to_file, clvox_voxelize_to_exr) and the slice
 * writer of clvox convert (clvox_volume_writer). The writers themselves:
 * write_exr.c, write_npy.c, write_nrrd.c, write_binvox.c, write_vdb.cpp. */
#include "core/internal.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

static const char *const format_names[CLVOX_FORMAT_COUNT] = {NULL, "exr", "npy", "nrrd", "binvox", "vdb"};

const char *clvox_format_name(clvox_format format)
{
    return (unsigned)format < CLVOX_FORMAT_COUNT ? format_names[format] : NULL;
}

clvox_format clvox_format_from_name(const char *name)
{
    if (!name) return CLVOX_FORMAT_AUTO;
    for (int f = 1; f < CLVOX_FORMAT_COUNT; f++)
        if (strcasecmp(name, format_names[f]) == 0) return (clvox_format)f;
    return CLVOX_FORMAT_AUTO;
}

clvox_format clvox_format_from_path(const char *path)
{
    if (!path) return CLVOX_FORMAT_AUTO;
    const char *slash = strrchr(path, '/'), *dot = strrchr(path, '.');
    if (!dot || (slash && dot < slash) || dot == path || (slash && dot == slash + 1)) return CLVOX_FORMAT_AUTO;
    return clvox_format_from_name(dot + 1);
}

static const clvox__fmt_ops *format_ops(clvox_format f)
{
    switch (f) {
    case CLVOX_FORMAT_EXR: return &clvox__fmt_exr;
    case CLVOX_FORMAT_NPY: return &clvox__fmt_npy;
    case CLVOX_FORMAT_NRRD: return &clvox__fmt_nrrd;
    case CLVOX_FORMAT_BINVOX: return &clvox__fmt_binvox;
    case CLVOX_FORMAT_VDB: return &clvox__fmt_vdb;
    default: return NULL;
    }
}

const char *clvox__channel_name(uint32_t channel)
{
    switch (channel) {
    case CLVOX_CHANNEL_OCCUPANCY: return "occupancy";
    case CLVOX_CHANNEL_COVERAGE: return "coverage";
    case CLVOX_CHANNEL_ELEMENT: return "element";
    case CLVOX_CHANNEL_SCORE: return "score";
    default: return "?";
    }
}

uint32_t clvox__main_channel(uint32_t channels)
{
    static const uint32_t order[4] = {CLVOX_CHANNEL_OCCUPANCY, CLVOX_CHANNEL_ELEMENT, CLVOX_CHANNEL_COVERAGE,
                                      CLVOX_CHANNEL_SCORE};
    for (int i = 0; i < 4; i++)
        if (channels & order[i]) return order[i];
    return 0;
}

/* Offset of the extension's dot in path, or its length when it has none. */
static size_t ext_at(const char *path)
{
    const char *slash = strrchr(path, '/'), *dot = strrchr(path, '.');
    if (!dot || (slash && dot < slash) || dot == path || (slash && dot == slash + 1)) return strlen(path);
    return (size_t)(dot - path);
}

char *clvox__channel_path(const char *path, uint32_t channel, uint32_t channels)
{
    size_t n = strlen(path), e = ext_at(path);
    const char *name = channel == clvox__main_channel(channels) ? NULL : clvox__channel_name(channel);
    size_t extra = name ? strlen(name) + 1 : 0;
    char *out = malloc(n + extra + 1);
    if (!out) return NULL;
    memcpy(out, path, e);
    if (name) {
        out[e] = '.';
        memcpy(out + e + 1, name, extra - 1);
    }
    memcpy(out + e + extra, path + e, n - e + 1);
    return out;
}

char *clvox__replace_ext(const char *path, const char *ext)
{
    size_t e = ext_at(path), m = strlen(ext);
    char *out = malloc(e + m + 1);
    if (!out) return NULL;
    memcpy(out, path, e);
    memcpy(out + e, ext, m + 1);
    return out;
}

size_t clvox__dtype_row_bytes(clvox__dtype t, uint32_t X)
{
    switch (t) {
    case CLVOX__BITS: return ((size_t)X + 7) / 8;
    case CLVOX__U8: return X;
    case CLVOX__F16: case CLVOX__U16: return (size_t)X * 2;
    default: return (size_t)X * 4;
    }
}

static void put16(uint8_t *p, uint16_t v) { p[0] = (uint8_t)v; p[1] = (uint8_t)(v >> 8); }
static void put32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v; p[1] = (uint8_t)(v >> 8); p[2] = (uint8_t)(v >> 16); p[3] = (uint8_t)(v >> 24);
}

int clvox__encode_rows(const clvox__fmt_slab *s, uint32_t channel, clvox__dtype t, uint32_t X, size_t rows,
                       uint8_t *out)
{
    const size_t n = (size_t)X * rows;
    if (channel == CLVOX_CHANNEL_OCCUPANCY) {
        const uint32_t *bits = s->occupancy_bits;
        if (!bits) return 0;
        const uint32_t W = clvox__row_words(X);
        for (size_t r = 0; r < rows; r++, bits += W) {
            if (t == CLVOX__BITS) {
                size_t nb = ((size_t)X + 7) / 8;
                for (size_t j = 0; j < nb; j++) *out++ = (uint8_t)(bits[j >> 2] >> (8 * (j & 3)));
            } else {
                for (uint32_t x = 0; x < X; x++) *out++ = (uint8_t)((bits[x >> 5] >> (x & 31)) & 1u);
            }
        }
        return 1;
    }
    if (channel == CLVOX_CHANNEL_ELEMENT) {
        if (!s->element) return 0;
        for (size_t i = 0; i < n; i++) {
            if (t == CLVOX__U32) put32(out + 4 * i, s->element[i]);
            else put16(out + 2 * i, s->element[i]);
        }
        return 1;
    }
    const uint16_t *half = channel == CLVOX_CHANNEL_COVERAGE ? s->coverage_half : s->score_half;
    const float *f = channel == CLVOX_CHANNEL_COVERAGE ? s->coverage : s->score;
    if (!half || !f) return 0;
    for (size_t i = 0; i < n; i++) {
        if (t == CLVOX__F16) {
            put16(out + 2 * i, half[i]);
        } else {
            uint32_t u;
            memcpy(&u, &f[i], 4);
            put32(out + 4 * i, u);
        }
    }
    return 1;
}

/* ---- the file sink: clvox_voxelize_to_file, clvox_voxelize_to_exr ---- */

typedef struct file_sink {
    clvox_context *ctx;
    const clvox__fmt_ops *ops;
    clvox__fmt_info info;
    uint32_t channels, samples;    /* set by the pipeline before open */
    void *state;
    uint16_t *half_of;             /* count -> HALF bits of count / samples */
    float *value_of;               /* count -> count / samples */
    uint16_t *cov_half, *score_half;
    float *cov, *score;
    size_t scratch;                /* voxels the scratch planes hold */
} file_sink;

static clvox_status sink_open(void *user, const char *method, const char *params)
{
    file_sink *s = user;
    s->info.channels = s->channels;
    s->info.method = method;
    s->info.parameters = params;
    if (s->channels & ~s->ops->channels) {
        uint32_t bad = s->channels & ~s->ops->channels;
        return clvox__fail(s->ctx, CLVOX_ERR_INVALID_ARGUMENT, "cannot write '%s': %s holds no %s channel",
                           s->info.path, s->ops->name, clvox__channel_name(bad & (~bad + 1u)));
    }
    if (!s->ops->half_bits && (s->channels & (CLVOX_CHANNEL_COVERAGE | CLVOX_CHANNEL_SCORE))) {
        uint32_t n = s->samples ? s->samples : 1;
        s->half_of = malloc(((size_t)n + 1) * sizeof *s->half_of);
        s->value_of = malloc(((size_t)n + 1) * sizeof *s->value_of);
        if (!s->half_of || !s->value_of) return clvox__fail(s->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
        for (uint32_t t = 0; t <= n; t++) {
            s->value_of[t] = (float)t / (float)n;
            s->half_of[t] = clvox__half_from_unit((double)t / n);
        }
    }
    return s->ops->open(s->ctx, &s->info, &s->state);
}

static int counts_to(file_sink *s, const uint16_t *counts, size_t n, uint16_t **half, float **val)
{
    if (n > s->scratch) {
        free(*half);
        free(*val);
        *half = malloc(n * sizeof **half);
        *val = malloc(n * sizeof **val);
        if (!*half || !*val) return 0;
    }
    for (size_t i = 0; i < n; i++) {
        uint16_t c = counts[i] > s->samples ? (uint16_t)s->samples : counts[i];
        (*half)[i] = s->half_of[c];
        (*val)[i] = s->value_of[c];
    }
    return 1;
}

static clvox_status sink_slab(void *user, uint32_t z0, uint32_t nz, const clvox__slab_planes *p)
{
    file_sink *s = user;
    size_t n = (size_t)s->info.grid->dims[0] * s->info.grid->dims[1] * nz;
    clvox__fmt_slab fs = {z0, nz, p->occupancy_bits, NULL, NULL, p->element, NULL, NULL};
    if (s->ops->half_bits) { /* the device's HALF bits, as they are */
        fs.coverage_half = p->coverage_half;
        fs.score_half = p->score_half;
        return s->ops->write(s->state, &fs);
    }
    if (p->coverage_half) {
        if (!counts_to(s, p->coverage_half, n, &s->cov_half, &s->cov))
            return clvox__fail(s->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for a slab");
        fs.coverage_half = s->cov_half;
        fs.coverage = s->cov;
    }
    if (p->score_half) {
        if (!counts_to(s, p->score_half, n, &s->score_half, &s->score))
            return clvox__fail(s->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for a slab");
        fs.score_half = s->score_half;
        fs.score = s->score;
    }
    if (n > s->scratch && (p->coverage_half || p->score_half)) s->scratch = n;
    return s->ops->write(s->state, &fs);
}

/* Checks what can be checked before any work: format, compression. */
static clvox_status resolve_format(clvox_context *ctx, const char *path, const clvox_output_options *in,
                                   clvox_output_options *o)
{
    clvox_output_options def = CLVOX_OUTPUT_OPTIONS_INIT;
    *o = def;
    if (in) {
        if (in->size < sizeof(size_t) || in->size > sizeof *o)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_output_options.size is %zu", in->size);
        memcpy(o, in, in->size);
    }
    if ((unsigned)o->format >= CLVOX_FORMAT_COUNT)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "unknown output format %d", (int)o->format);
    if (o->format == CLVOX_FORMAT_AUTO) o->format = clvox_format_from_path(path);
    if (o->format == CLVOX_FORMAT_AUTO)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT,
                           "cannot tell the format of '%s' from its extension (.exr, .npy, .nrrd, .binvox or .vdb)", path);
    if ((unsigned)o->compression >= CLVOX_COMPRESSION_COUNT)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "unknown compression %d", (int)o->compression);
    if (o->flags & ~(CLVOX_OUTPUT_PACK_BITS | CLVOX_OUTPUT_FLOAT32 | CLVOX_OUTPUT_UINT32))
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "unknown output flags 0x%x", o->flags);
    if (o->flags && o->format != CLVOX_FORMAT_NPY)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "packed bits, float32 and uint32 are npy options (not %s)",
                           clvox_format_name(o->format));
    if (o->format == CLVOX_FORMAT_VDB) { /* loads the writer: a missing one fails here, before any work */
        clvox_status st = clvox__vdb_load(ctx, path);
        if (st != CLVOX_OK) return st;
    }
    const clvox_compression c = o->compression;
    if (o->format == CLVOX_FORMAT_NRRD && (c == CLVOX_COMPRESSION_RLE || c == CLVOX_COMPRESSION_PIZ))
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "NRRD is written raw (none) or gzip (zip), not %s",
                           c == CLVOX_COMPRESSION_RLE ? "rle" : "piz");
    if ((o->format == CLVOX_FORMAT_NPY || o->format == CLVOX_FORMAT_BINVOX || o->format == CLVOX_FORMAT_VDB) &&
        c != CLVOX_COMPRESSION_DEFAULT && c != CLVOX_COMPRESSION_NONE)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT,
                           o->format == CLVOX_FORMAT_VDB ? "%s files take --compression none or the default (OpenVDB's)"
                                                         : "%s files are not compressed (no --compression)",
                           clvox_format_name(o->format));
    return CLVOX_OK;
}

/* Runs the voxelization into the file of format ops; o holds the resolved
 * compression and flags. */
static clvox_status write_file(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                               const clvox_voxelize_options *options, const clvox__fmt_ops *ops,
                               const clvox_output_options *o, const char *path, clvox_stats *stats)
{
    file_sink s;
    memset(&s, 0, sizeof s);
    s.ctx = ctx;
    s.ops = ops;
    s.info.path = path;
    s.info.grid = grid;
    s.info.flags = o->flags;
    s.info.compression = o->compression;
    if (options && options->size >= offsetof(clvox_voxelize_options, threads) + sizeof options->threads)
        s.info.threads = options->threads;
    if (options && options->size >= offsetof(clvox_voxelize_options, metric) + sizeof options->metric &&
        options->palette) {
        s.info.palette = options->palette;
        s.info.metric = clvox_metric_name(options->metric);
    }
    clvox_stats local = CLVOX_STATS_INIT;
    clvox_stats *so = stats ? stats : &local;
    clvox_status st = clvox__voxelize_to_sink(ctx, mesh, grid, options, !ops->half_bits, sink_open, sink_slab, &s,
                                              &s.channels, &s.samples, so);
    if (st == CLVOX_OK && s.state) {
        double t0 = clvox__now();
        uint64_t bytes = 0;
        st = s.ops->finish(s.state, &bytes); /* frees the state, also on failure */
        so->seconds[CLVOX_STAGE_WRITE] += clvox__now() - t0;
        so->seconds[CLVOX_STAGE_TOTAL] += clvox__now() - t0;
        so->output_bytes = bytes;
    } else if (s.state) {
        s.ops->abort(s.state);
    }
    free(s.half_of);
    free(s.value_of);
    free(s.cov_half);
    free(s.cov);
    free(s.score_half);
    free(s.score);
    return st;
}

clvox_status clvox_voxelize_to_file(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                    const clvox_voxelize_options *options, const clvox_output_options *output,
                                    const char *path, clvox_stats *stats)
{
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!path || !*path) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "no output path");
    if (!grid) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "NULL grid");
    clvox_output_options o;
    clvox_status st = resolve_format(ctx, path, output, &o);
    if (st != CLVOX_OK) return st;
    if (o.compression == CLVOX_COMPRESSION_DEFAULT && options) o.compression = options->compression;
    clvox_output_options chk = o; /* the voxelize options' compression must suit the format too */
    st = resolve_format(ctx, path, &chk, &o);
    if (st != CLVOX_OK) return st;
    st = clvox__outfile_check_target(ctx, path); /* before any work */
    if (st != CLVOX_OK) return st;
    return write_file(ctx, mesh, grid, options, format_ops(o.format), &o, path, stats);
}

/* EXR whatever the path's extension, the compression of the options. */
clvox_status clvox_voxelize_to_exr(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                   const clvox_voxelize_options *options, const char *path, clvox_stats *stats)
{
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!path || !*path) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "no output path");
    clvox_output_options o = CLVOX_OUTPUT_OPTIONS_INIT;
    o.format = CLVOX_FORMAT_EXR;
    o.compression = options ? options->compression : CLVOX_COMPRESSION_DEFAULT;
    return write_file(ctx, mesh, grid, options, &clvox__fmt_exr, &o, path, stats);
}

/* ---- clvox_volume_writer ---- */

struct clvox_volume_writer {
    clvox_context *ctx;
    clvox_grid grid;
    uint32_t channels;
    const clvox__fmt_ops *ops;
    void *state;
    uint32_t *bits;
    uint16_t *u16;
    float *f32;
};

clvox_status clvox_volume_writer_open(clvox_context *ctx, const char *path, const clvox_grid *grid,
                                      uint32_t channels, const clvox_output_options *output,
                                      clvox_volume_writer **out)
{
    if (out) *out = NULL;
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!path || !*path || !grid || !out)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_volume_writer_open: missing path, grid or output");
    clvox_output_options o;
    clvox_status st = resolve_format(ctx, path, output, &o);
    if (st != CLVOX_OK) return st;
    const uint32_t all = CLVOX_CHANNEL_OCCUPANCY | CLVOX_CHANNEL_COVERAGE | CLVOX_CHANNEL_ELEMENT | CLVOX_CHANNEL_SCORE;
    if (!channels || (channels & ~all))
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_volume_writer_open: channels 0x%x", channels);
    for (int a = 0; a < 3; a++)
        if (grid->dims[a] == 0 || grid->dims[a] > CLVOX_MAX_AXIS || !(grid->voxel_size[a] > 0) ||
            !isfinite(grid->origin[a]))
            return clvox__fail(ctx, CLVOX_ERR_GRID, "invalid grid");
    const clvox__fmt_ops *ops = format_ops(o.format);
    if (!ops->one_channel && (channels & (channels - 1)))
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT,
                           "cannot write '%s': one channel at a time into %s (choose one with --channel)", path,
                           clvox_format_name(o.format));
    if (channels & ~ops->channels) {
        uint32_t bad = channels & ~ops->channels;
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "cannot write '%s': %s holds no %s channel", path,
                           ops->name, clvox__channel_name(bad & (~bad + 1u)));
    }
    clvox_volume_writer *w = calloc(1, sizeof *w);
    if (!w) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    w->ctx = ctx;
    w->grid = *grid;
    w->channels = channels;
    w->ops = ops;
    size_t n = (size_t)grid->dims[0] * grid->dims[1];
    w->bits = malloc((size_t)clvox__row_words(grid->dims[0]) * grid->dims[1] * sizeof *w->bits);
    w->u16 = malloc(n * sizeof *w->u16);
    w->f32 = malloc(n * sizeof *w->f32);
    if (!w->bits || !w->u16 || !w->f32) {
        clvox_volume_writer_abort(w);
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for a %u x %u slice", grid->dims[0],
                           grid->dims[1]);
    }
    clvox__fmt_info info = {path, &w->grid, channels, o.flags, o.compression, o.method, o.parameters,
                            NULL, NULL, o.threads};
    st = ops->open(ctx, &info, &w->state);
    if (st != CLVOX_OK) {
        clvox_volume_writer_abort(w);
        return st;
    }
    *out = w;
    return CLVOX_OK;
}

clvox_status clvox_volume_writer_slice(clvox_volume_writer *w, uint32_t channel, uint32_t z, const float *values)
{
    if (!w) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!values || !(w->channels & channel) || (channel & (channel - 1)))
        return clvox__fail(w->ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_volume_writer_slice: channel 0x%x not open",
                           channel);
    const uint32_t X = w->grid.dims[0], Y = w->grid.dims[1];
    const size_t n = (size_t)X * Y;
    clvox__fmt_slab fs = {z, 1, NULL, NULL, NULL, NULL, NULL, NULL};
    if (channel == CLVOX_CHANNEL_OCCUPANCY) {
        const uint32_t W = clvox__row_words(X);
        memset(w->bits, 0, (size_t)W * Y * sizeof *w->bits);
        for (uint32_t y = 0; y < Y; y++)
            for (uint32_t x = 0; x < X; x++)
                if (values[(size_t)y * X + x] > 0.5f) w->bits[(size_t)y * W + (x >> 5)] |= 1u << (x & 31);
        fs.occupancy_bits = w->bits;
    } else if (channel == CLVOX_CHANNEL_ELEMENT) {
        for (size_t i = 0; i < n; i++) {
            float v = values[i];
            w->u16[i] = !(v > 0.0f) ? 0 : v >= 65535.0f ? 65535 : (uint16_t)lrintf(v);
        }
        fs.element = w->u16;
    } else {
        for (size_t i = 0; i < n; i++) {
            float v = values[i];
            v = !(v > 0.0f) ? 0.0f : v > 1.0f ? 1.0f : v;
            w->f32[i] = v;
            w->u16[i] = clvox__half_from_unit(v);
        }
        if (channel == CLVOX_CHANNEL_COVERAGE) fs.coverage_half = w->u16, fs.coverage = w->f32;
        else fs.score_half = w->u16, fs.score = w->f32;
    }
    return w->ops->write(w->state, &fs);
}

clvox_status clvox_volume_writer_finish(clvox_volume_writer *w, uint64_t *bytes)
{
    if (bytes) *bytes = 0;
    if (!w) return CLVOX_ERR_INVALID_ARGUMENT;
    clvox_status st = w->ops->finish(w->state, bytes);
    w->state = NULL;
    clvox_volume_writer_abort(w);
    return st;
}

void clvox_volume_writer_abort(clvox_volume_writer *w)
{
    if (!w) return;
    if (w->state) w->ops->abort(w->state);
    free(w->bits);
    free(w->u16);
    free(w->f32);
    free(w);
}
