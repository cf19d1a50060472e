/* Driver: runs a method slab by slab and hands each slab (occupancy bit
 * rows, see internal.h), in increasing z, to a sink (EXR writer, caller
 * callback or dense memory). Memory is one slab buffer whatever the number
 * of slices. */
#include "internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Slabs hold about this many voxels: enough to keep the device busy, few
 * enough that the methods' per-ray and per-row buffers stay small and
 * memory does not grow with the grid (the slab's bits take 2 MiB). */
#define SLAB_TARGET_VOXELS (16u << 20)

typedef clvox_status (*sink_fn)(void *user, uint32_t z0, uint32_t nz, const uint32_t *bits);

static uint32_t auto_slab_depth(const clvox_grid *g)
{
    uint64_t slice = (uint64_t)g->dims[0] * g->dims[1];
    uint64_t d = SLAB_TARGET_VOXELS / (slice ? slice : 1);
    if (d < 1) d = 1;
    if (d > g->dims[2]) d = g->dims[2];
    return (uint32_t)d;
}

static clvox_status check_inputs(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                 const clvox_voxelize_options *in, clvox_voxelize_options *o)
{
    clvox_voxelize_options def = CLVOX_VOXELIZE_OPTIONS_INIT;
    *o = def;
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!mesh || !grid) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "NULL mesh or grid");
    if (ctx->host_only || !ctx->program)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "context was created without an OpenCL device");
    if (in) {
        if (in->size < sizeof(size_t) || in->size > sizeof *o)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_voxelize_options.size is %zu", in->size);
        memcpy(o, in, in->size);
    }
    if ((unsigned)o->method >= CLVOX_METHOD_COUNT)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "unknown method %d", (int)o->method);
    if ((unsigned)o->ray_axis > CLVOX_AXIS_Z)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "unknown ray axis %d", (int)o->ray_axis);
    if ((unsigned)o->compression >= CLVOX_COMPRESSION_COUNT)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "unknown compression %d", (int)o->compression);
    for (int a = 0; a < 3; a++)
        if (grid->dims[a] == 0 || grid->dims[a] > CLVOX_MAX_AXIS || !(grid->voxel_size[a] > 0))
            return clvox__fail(ctx, CLVOX_ERR_GRID, "invalid grid (use clvox_grid_compute)");
    if ((uint64_t)grid->dims[0] * grid->dims[1] * grid->dims[2] > CLVOX_MAX_VOXELS)
        return clvox__fail(ctx, CLVOX_ERR_GRID, "grid has more than %llu voxels", (unsigned long long)CLVOX_MAX_VOXELS);
    if (mesh->triangle_count == 0) return clvox__fail(ctx, CLVOX_ERR_MESH_EMPTY, "mesh has no triangles");
    return CLVOX_OK;
}

/* The pipeline. `open_sink` (may be NULL) is called once the method is
 * prepared, with its parameter text, before any slab is computed. */
typedef clvox_status (*open_fn)(void *user, const char *method, const char *params);

static clvox_status run(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                        const clvox_voxelize_options *in, open_fn open_sink, sink_fn sink, void *user,
                        clvox_stats *stats_out)
{
    double t_start = clvox__now();
    clvox_voxelize_options o;
    clvox_stats stats;
    memset(&stats, 0, sizeof stats);
    clvox_status st = check_inputs(ctx, mesh, grid, in, &o);
    if (st != CLVOX_OK) return st;

    const clvox__method *m = o.method == CLVOX_METHOD_TETRA ? &clvox__method_tetra : &clvox__method_ray;
    const uint32_t X = grid->dims[0], Y = grid->dims[1], Z = grid->dims[2];
    uint64_t slice_bytes = (uint64_t)clvox__row_words(X) * Y * sizeof(cl_uint);
    uint64_t max_alloc = ctx->device.max_alloc_bytes ? ctx->device.max_alloc_bytes : (1ull << 31);
    if (slice_bytes > max_alloc)
        return clvox__fail(ctx, CLVOX_ERR_GRID, "one %ux%u slice needs %llu MB, more than the device's largest buffer (%llu MB)",
                           X, Y, (unsigned long long)(slice_bytes >> 20), (unsigned long long)(max_alloc >> 20));
    uint32_t depth = o.slab_depth ? (o.slab_depth < Z ? o.slab_depth : Z) : auto_slab_depth(grid);
    if ((uint64_t)depth * slice_bytes > max_alloc) depth = (uint32_t)(max_alloc / slice_bytes);
    stats.slab_depth = depth;
    stats.total_voxels = (uint64_t)X * Y * Z;

    clvox__method_state *ms = NULL;
    cl_mem out = NULL;
    st = m->prepare(ctx, mesh, grid, &o, depth, &stats, &ms);
    if (st == CLVOX_OK && open_sink) {
        char params[512];
        m->describe(ms, params, sizeof params);
        st = open_sink(user, m->name, params);
    }
    if (st == CLVOX_OK) {
        cl_int err;
        out = clCreateBuffer(ctx->cl, CL_MEM_READ_WRITE | CL_MEM_ALLOC_HOST_PTR, (size_t)(depth * slice_bytes), NULL,
                             &err);
        if (err != CL_SUCCESS) st = clvox__cl_fail(ctx, err, "clCreateBuffer(slab)");
        uint64_t b = depth * slice_bytes;
        stats.peak_slab_bytes += b; /* method working set + slab output */
    }
    uint32_t slabs = (Z + depth - 1) / depth, done = 0;
    for (uint32_t z0 = 0; st == CLVOX_OK && z0 < Z; z0 += depth) {
        uint32_t nz = Z - z0 < depth ? Z - z0 : depth;
        clvox__slab_stats ss;
        memset(&ss, 0, sizeof ss);
        clvox__slab_out planes = {out, NULL};
        st = m->slab(ms, z0, nz, &planes, &ss);
        if (st != CLVOX_OK) break;
        stats.seconds[CLVOX_STAGE_CAST] += ss.cast_seconds;
        stats.seconds[CLVOX_STAGE_CLASSIFY] += ss.classify_seconds;
        stats.filled_voxels += ss.filled;
        stats.rays += ss.rays;
        stats.odd_parity_rays += ss.odd_parity_rays;
        stats.overflow_rays += ss.overflow_rays;
        if (ss.max_crossings > stats.max_crossings) stats.max_crossings = ss.max_crossings;

        cl_int err;
        size_t bytes = (size_t)(nz * slice_bytes);
        void *p = clEnqueueMapBuffer(ctx->queue, out, CL_TRUE, CL_MAP_READ, 0, bytes, 0, NULL, NULL, &err);
        if (err != CL_SUCCESS) {
            st = clvox__cl_fail(ctx, err, "mapping the slab");
            break;
        }
        double t0 = clvox__now();
        st = sink(user, z0, nz, p);
        stats.seconds[CLVOX_STAGE_WRITE] += clvox__now() - t0;
        err = clEnqueueUnmapMemObject(ctx->queue, out, p, 0, NULL, NULL);
        if (err != CL_SUCCESS && st == CLVOX_OK) st = clvox__cl_fail(ctx, err, "unmapping the slab");
        done++;
        if (st == CLVOX_OK && o.progress && !o.progress(o.progress_user, (double)done / slabs))
            st = clvox__fail(ctx, CLVOX_ERR_CANCELLED, "cancelled after %u of %u slabs", done, slabs);
    }
    if (out) {
        clFinish(ctx->queue);
        clReleaseMemObject(out);
    }
    if (ms) m->release(ms);
    stats.seconds[CLVOX_STAGE_TOTAL] = clvox__now() - t_start;
    if (stats_out) *stats_out = stats;
    return st;
}

/* ---- EXR sink ---- */

typedef struct exr_sink {
    clvox_context *ctx;
    const char *path;
    const clvox_grid *grid;
    clvox_compression compression;
    uint32_t threads;
    clvox__exr_writer *w;
} exr_sink;

static clvox_status exr_open(void *user, const char *method, const char *params)
{
    exr_sink *s = user;
    clvox__exr_meta meta = {method, params};
    return clvox__exr_open(s->ctx, s->path, s->grid, &meta, 0, s->compression, s->threads, &s->w);
}

static clvox_status exr_slab(void *user, uint32_t z0, uint32_t nz, const uint32_t *bits)
{
    exr_sink *s = user;
    clvox__slab_planes p = {bits, NULL};
    return clvox__exr_write_slab(s->w, z0, nz, &p);
}

clvox_status clvox_voxelize_to_exr(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                   const clvox_voxelize_options *options, const char *path, clvox_stats *stats)
{
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!path || !*path) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "no output path");
    exr_sink s = {ctx, path, grid, options ? options->compression : CLVOX_COMPRESSION_DEFAULT,
                  options ? options->threads : 0, NULL};
    clvox_stats local;
    clvox_stats *st_out = stats ? stats : &local;
    clvox_status st = run(ctx, mesh, grid, options, exr_open, exr_slab, &s, st_out);
    if (st == CLVOX_OK && s.w) {
        double t0 = clvox__now();
        uint64_t bytes = 0;
        st = clvox__exr_finish(s.w, &bytes); /* frees the writer, also on failure */
        st_out->seconds[CLVOX_STAGE_WRITE] += clvox__now() - t0;
        st_out->seconds[CLVOX_STAGE_TOTAL] += clvox__now() - t0;
        st_out->output_bytes = bytes;
    } else {
        clvox__exr_abort(s.w);
    }
    return st;
}

/* ---- callback and memory sinks ---- */

typedef struct user_sink {
    clvox_context *ctx;
    clvox_slab_fn fn;
    void *user;
    uint8_t *scratch;
    size_t scratch_size;
    uint8_t *dense;  /* memory sink: X*Y*Z */
    uint32_t X, Y;
} user_sink;

/* Bit rows -> one byte (0/1) per voxel, x fastest. */
static void bits_to_u8(uint8_t *dst, const uint32_t *bits, uint32_t X, size_t rows)
{
    const uint32_t W = clvox__row_words(X);
    for (size_t r = 0; r < rows; r++, bits += W, dst += X)
        for (uint32_t x = 0; x < X; x++) dst[x] = (uint8_t)((bits[x >> 5] >> (x & 31)) & 1u);
}

static clvox_status user_slab(void *p, uint32_t z0, uint32_t nz, const uint32_t *bits)
{
    user_sink *s = p;
    size_t slice = (size_t)s->X * s->Y, n = slice * nz;
    if (s->dense) {
        bits_to_u8(s->dense + (size_t)z0 * slice, bits, s->X, (size_t)s->Y * nz);
        return CLVOX_OK;
    }
    if (n > s->scratch_size) {
        uint8_t *q = realloc(s->scratch, n);
        if (!q) return clvox__fail(s->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for a slab");
        s->scratch = q;
        s->scratch_size = n;
    }
    bits_to_u8(s->scratch, bits, s->X, (size_t)s->Y * nz);
    if (s->fn(s->user, z0, nz, s->scratch))
        return clvox__fail(s->ctx, CLVOX_ERR_CANCELLED, "cancelled by the slab callback at slice %u", z0);
    return CLVOX_OK;
}

clvox_status clvox_voxelize_stream(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                   const clvox_voxelize_options *options, clvox_slab_fn fn, void *user,
                                   clvox_stats *stats)
{
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!fn || !grid) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "NULL slab callback or grid");
    user_sink s = {ctx, fn, user, NULL, 0, NULL, grid->dims[0], grid->dims[1]};
    clvox_status st = run(ctx, mesh, grid, options, NULL, user_slab, &s, stats);
    free(s.scratch);
    return st;
}

clvox_status clvox_voxelize_to_memory(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                      const clvox_voxelize_options *options, uint8_t *out, size_t out_size,
                                      clvox_stats *stats)
{
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!out || !grid) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "NULL output buffer or grid");
    uint64_t need = (uint64_t)grid->dims[0] * grid->dims[1] * grid->dims[2];
    if (out_size < need)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "output buffer holds %zu bytes, the grid needs %llu",
                           out_size, (unsigned long long)need);
    user_sink s = {ctx, NULL, NULL, NULL, 0, out, grid->dims[0], grid->dims[1]};
    return run(ctx, mesh, grid, options, NULL, user_slab, &s, stats);
}
