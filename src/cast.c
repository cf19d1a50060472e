/* Stage cast, and the ray method that strings partition -> cast -> classify
 * together for one slab (Thon et al. 3.3).
 *
 * Per slab: the host lists the slab's rays (one per voxel column, at the
 * column centre; the kernels accept any (v,w) so later jittered rays reuse
 * them), then the device runs leaf lookup, intersection, sort and classify.
 * Rays with more crossings than the buffer holds are found from the counts
 * and cast again with a buffer as large as the largest count. */
#include "internal.h"
#include "classify.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DEFAULT_HIT_CAPACITY 32u

struct clvox__method_state {
    clvox_context *ctx;
    clvox_grid grid;
    clvox_axis axis;       /* X, Y or Z (resolved) */
    clvox__axes axes;
    uint32_t dim_u, dim_v, dim_w;
    clvox__quadtree qt;
    cl_mem soup, nodes, refs;
    cl_kernel k_lookup, k_intersect, k_sort, k_classify;
    uint32_t capacity;
    size_t max_rays;
    cl_mem rays, leaf, hits, counts, filled;
    clvox_ray *rays_host;
    uint32_t *counts_host, *filled_host;
    uint32_t leaf_size;
};

static void ray_release(clvox__method_state *s)
{
    if (!s) return;
    clvox__release_mem(&s->soup);
    clvox__release_mem(&s->nodes);
    clvox__release_mem(&s->refs);
    clvox__release_mem(&s->rays);
    clvox__release_mem(&s->leaf);
    clvox__release_mem(&s->hits);
    clvox__release_mem(&s->counts);
    clvox__release_mem(&s->filled);
    if (s->k_lookup) clReleaseKernel(s->k_lookup);
    if (s->k_intersect) clReleaseKernel(s->k_intersect);
    if (s->k_sort) clReleaseKernel(s->k_sort);
    if (s->k_classify) clReleaseKernel(s->k_classify);
    clvox__quadtree_free(&s->qt);
    free(s->rays_host);
    free(s->counts_host);
    free(s->filled_host);
    free(s);
}

static clvox_status ray_prepare(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                const clvox_voxelize_options *opts, uint32_t slab_depth, clvox_stats *stats,
                                clvox__method_state **out)
{
    *out = NULL;
    clvox__method_state *s = calloc(1, sizeof *s);
    if (!s) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    s->ctx = ctx;
    s->grid = *grid;
    s->axis = opts->ray_axis == CLVOX_AXIS_DEFAULT ? CLVOX_AXIS_X : opts->ray_axis;
    s->axes = clvox__axes_for(s->axis);
    s->dim_u = grid->dims[s->axes.perm[0]];
    s->dim_v = grid->dims[s->axes.perm[1]];
    s->dim_w = grid->dims[s->axes.perm[2]];
    s->capacity = opts->hit_capacity ? opts->hit_capacity : DEFAULT_HIT_CAPACITY;
    s->leaf_size = opts->quadtree_leaf_size ? opts->quadtree_leaf_size : 8;

    /* Rays of one slab: x-rays cover Y*nz columns, y-rays X*nz, z-rays all X*Y. */
    const uint32_t *d = grid->dims;
    s->max_rays = s->axis == CLVOX_AXIS_X   ? (size_t)d[1] * slab_depth
                  : s->axis == CLVOX_AXIS_Y ? (size_t)d[0] * slab_depth
                                            : (size_t)d[0] * d[1];

    clvox_status st;
    float *soup = NULL;
    double t0 = clvox__now();
    st = clvox__grid_space_soup(ctx, mesh, grid, s->axes, &soup);
    if (st == CLVOX_OK)
        st = clvox__quadtree_build(ctx, soup, mesh->triangle_count, s->dim_v, s->dim_w, opts->quadtree_max_depth,
                                   s->leaf_size, &s->qt);
    if (st != CLVOX_OK) {
        free(soup);
        ray_release(s);
        return st;
    }
    cl_mem_flags ro = CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR;
    s->soup = clvox__buffer(ctx, ro, mesh->triangle_count * 9 * sizeof(float), soup, &st, "triangles");
    free(soup);
    if (st == CLVOX_OK)
        s->nodes = clvox__buffer(ctx, ro, s->qt.node_count * sizeof(clvox_qt_node), s->qt.nodes, &st, "quadtree");
    if (st == CLVOX_OK)
        s->refs = clvox__buffer(ctx, ro, (s->qt.ref_count ? s->qt.ref_count : 1) * sizeof(uint32_t), s->qt.refs, &st,
                              "quadtree refs");
    if (stats) {
        stats->seconds[CLVOX_STAGE_PARTITION] += clvox__now() - t0;
        stats->quadtree_depth = s->qt.depth;
        stats->quadtree_leaves = s->qt.leaf_count;
        stats->quadtree_refs = s->qt.ref_count;
    }
    if (st == CLVOX_OK) st = clvox__kernel(ctx, "clvox_quadtree_lookup", &s->k_lookup);
    if (st == CLVOX_OK) st = clvox__kernel(ctx, "clvox_intersect", &s->k_intersect);
    if (st == CLVOX_OK) st = clvox__kernel(ctx, "clvox_sort", &s->k_sort);
    if (st == CLVOX_OK) st = clvox__kernel(ctx, "clvox_classify", &s->k_classify);

    size_t nr = s->max_rays;
    if (st == CLVOX_OK && nr > SIZE_MAX / (s->capacity * ctx->real_size))
        st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "crossing buffer too large");
    if (st == CLVOX_OK) s->rays = clvox__buffer(ctx, CL_MEM_READ_ONLY, nr * sizeof(clvox_ray), NULL, &st, "rays");
    if (st == CLVOX_OK) s->leaf = clvox__buffer(ctx, CL_MEM_READ_WRITE, nr * sizeof(cl_uint), NULL, &st, "leaves");
    if (st == CLVOX_OK)
        s->hits = clvox__buffer(ctx, CL_MEM_READ_WRITE, nr * s->capacity * ctx->real_size, NULL, &st, "crossings");
    if (st == CLVOX_OK) s->counts = clvox__buffer(ctx, CL_MEM_READ_WRITE, nr * sizeof(cl_uint), NULL, &st, "counts");
    if (st == CLVOX_OK) s->filled = clvox__buffer(ctx, CL_MEM_READ_WRITE, nr * sizeof(cl_uint), NULL, &st, "filled");
    if (st == CLVOX_OK) {
        s->rays_host = malloc(nr * sizeof *s->rays_host);
        s->counts_host = malloc(nr * sizeof *s->counts_host);
        s->filled_host = malloc(nr * sizeof *s->filled_host);
        if (!s->rays_host || !s->counts_host || !s->filled_host)
            st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu rays", nr);
    }
    if (stats) {
        uint64_t b = (uint64_t)nr * (sizeof(clvox_ray) * 2 + 4 * 4 + s->capacity * ctx->real_size);
        if (b > stats->peak_slab_bytes) stats->peak_slab_bytes = b;
    }
    if (st != CLVOX_OK) {
        ray_release(s);
        return st;
    }
    *out = s;
    return CLVOX_OK;
}

/* Enqueues lookup, intersect, sort and classify for `n` rays. */
static clvox_status cast_rays(clvox__method_state *s, cl_mem rays, cl_uint n, cl_mem leaf, cl_mem hits,
                              cl_uint capacity, cl_mem counts, cl_mem filled, cl_uint u_begin, cl_uint u_count,
                              cl_uint out_stride, cl_mem out, clvox__slab_stats *ss)
{
    clvox_context *ctx = s->ctx;
    size_t local = 64, global = ((size_t)n + local - 1) / local * local;
    cl_event ev[4] = {0};
    cl_int err = 0;
    clvox_status st = CLVOX_OK;

    err |= clSetKernelArg(s->k_lookup, 0, sizeof(cl_mem), &rays);
    err |= clSetKernelArg(s->k_lookup, 1, sizeof(cl_uint), &n);
    err |= clSetKernelArg(s->k_lookup, 2, sizeof(cl_mem), &s->nodes);
    err |= clSetKernelArg(s->k_lookup, 3, sizeof(cl_mem), &leaf);

    err |= clSetKernelArg(s->k_intersect, 0, sizeof(cl_mem), &rays);
    err |= clSetKernelArg(s->k_intersect, 1, sizeof(cl_uint), &n);
    err |= clSetKernelArg(s->k_intersect, 2, sizeof(cl_mem), &leaf);
    err |= clSetKernelArg(s->k_intersect, 3, sizeof(cl_mem), &s->nodes);
    err |= clSetKernelArg(s->k_intersect, 4, sizeof(cl_mem), &s->refs);
    err |= clSetKernelArg(s->k_intersect, 5, sizeof(cl_mem), &s->soup);
    err |= clSetKernelArg(s->k_intersect, 6, sizeof(cl_uint), &capacity);
    err |= clSetKernelArg(s->k_intersect, 7, sizeof(cl_mem), &hits);
    err |= clSetKernelArg(s->k_intersect, 8, sizeof(cl_mem), &counts);

    err |= clSetKernelArg(s->k_sort, 0, sizeof(cl_uint), &n);
    err |= clSetKernelArg(s->k_sort, 1, sizeof(cl_uint), &capacity);
    err |= clSetKernelArg(s->k_sort, 2, sizeof(cl_mem), &hits);
    err |= clSetKernelArg(s->k_sort, 3, sizeof(cl_mem), &counts);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, CL_INVALID_KERNEL_ARGS, "clSetKernelArg(cast kernels)");

    err = clEnqueueNDRangeKernel(ctx->queue, s->k_lookup, 1, NULL, &global, &local, 0, NULL, &ev[0]);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "enqueue clvox_quadtree_lookup");
    err = clEnqueueNDRangeKernel(ctx->queue, s->k_intersect, 1, NULL, &global, &local, 0, NULL, &ev[1]);
    if (err != CL_SUCCESS) st = clvox__cl_fail(ctx, err, "enqueue clvox_intersect");
    if (st == CLVOX_OK) {
        err = clEnqueueNDRangeKernel(ctx->queue, s->k_sort, 1, NULL, &global, &local, 0, NULL, &ev[2]);
        if (err != CL_SUCCESS) st = clvox__cl_fail(ctx, err, "enqueue clvox_sort");
    }
    if (st == CLVOX_OK) {
        clvox__classify_args a = {rays, n, hits, counts, capacity, u_begin, u_count, out_stride, out, filled};
        st = clvox__classify_enqueue(ctx, s->k_classify, &a, &ev[3]);
    }
    if (st == CLVOX_OK) {
        err = clWaitForEvents(1, &ev[3]);
        if (err != CL_SUCCESS) st = clvox__cl_fail(ctx, err, "running the cast kernels");
    }
    if (st == CLVOX_OK) {
        ss->cast_seconds += clvox__event_seconds(ev[0]) + clvox__event_seconds(ev[1]) + clvox__event_seconds(ev[2]);
        ss->classify_seconds += clvox__event_seconds(ev[3]);
    }
    for (int i = 0; i < 4; i++)
        if (ev[i]) clReleaseEvent(ev[i]);
    return st;
}

/* Rays whose crossings did not fit: cast them again, all together, with a
 * buffer as large as the largest count. */
static clvox_status redo_overflow(clvox__method_state *s, const uint32_t *idx, size_t m, uint32_t need,
                                  cl_uint u_begin, cl_uint u_count, cl_uint out_stride, cl_mem out,
                                  clvox__slab_stats *ss)
{
    clvox_context *ctx = s->ctx;
    clvox_status st = CLVOX_OK;
    clvox_ray *r = malloc(m * sizeof *r);
    uint32_t *cnt = malloc(m * sizeof *cnt), *fil = malloc(m * sizeof *fil);
    cl_mem rays = NULL, leaf = NULL, hits = NULL, counts = NULL, filled = NULL;
    if (!r || !cnt || !fil) st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory redoing %zu rays", m);
    if (st == CLVOX_OK && (size_t)need > SIZE_MAX / ctx->real_size / m)
        st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "crossing buffer for %zu rays x %u too large", m, need);
    for (size_t i = 0; st == CLVOX_OK && i < m; i++) r[i] = s->rays_host[idx[i]];
    if (st == CLVOX_OK)
        rays = clvox__buffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, m * sizeof *r, r, &st, "overflow rays");
    if (st == CLVOX_OK) leaf = clvox__buffer(ctx, CL_MEM_READ_WRITE, m * 4, NULL, &st, "overflow leaves");
    if (st == CLVOX_OK)
        hits = clvox__buffer(ctx, CL_MEM_READ_WRITE, m * need * ctx->real_size, NULL, &st, "overflow crossings");
    if (st == CLVOX_OK) counts = clvox__buffer(ctx, CL_MEM_READ_WRITE, m * 4, NULL, &st, "overflow counts");
    if (st == CLVOX_OK) filled = clvox__buffer(ctx, CL_MEM_READ_WRITE, m * 4, NULL, &st, "overflow filled");
    if (st == CLVOX_OK)
        st = cast_rays(s, rays, (cl_uint)m, leaf, hits, need, counts, filled, u_begin, u_count, out_stride, out, ss);
    if (st == CLVOX_OK) {
        cl_int err = clEnqueueReadBuffer(ctx->queue, counts, CL_TRUE, 0, m * 4, cnt, 0, NULL, NULL);
        if (err == CL_SUCCESS) err = clEnqueueReadBuffer(ctx->queue, filled, CL_TRUE, 0, m * 4, fil, 0, NULL, NULL);
        if (err != CL_SUCCESS) st = clvox__cl_fail(ctx, err, "reading overflow results");
    }
    for (size_t i = 0; st == CLVOX_OK && i < m; i++) {
        if (cnt[i] != s->counts_host[idx[i]])
            st = clvox__fail(ctx, CLVOX_ERR_INTERNAL, "overflow redo counted %u crossings instead of %u", cnt[i],
                             s->counts_host[idx[i]]);
        else
            ss->filled += fil[i];
    }
    clvox__release_mem(&rays);
    clvox__release_mem(&leaf);
    clvox__release_mem(&hits);
    clvox__release_mem(&counts);
    clvox__release_mem(&filled);
    free(r);
    free(cnt);
    free(fil);
    return st;
}

static clvox_status ray_slab(clvox__method_state *s, uint32_t z0, uint32_t nz, const clvox__slab_out *planes,
                            clvox__slab_stats *ss)
{
    cl_mem out = planes->occupancy;
    clvox_context *ctx = s->ctx;
    const uint32_t X = s->grid.dims[0], Y = s->grid.dims[1];
    const uint32_t W = clvox__row_words(X);
    size_t n = 0;
    cl_uint u_begin = 0, u_count = s->dim_u, stride = 0;
    /* The slab's rays and where each one's voxels go in the slab's bit rows
     * (stride 0: the ray is a whole row). */
    if (s->axis == CLVOX_AXIS_X) {
        for (uint32_t z = z0; z < z0 + nz; z++)
            for (uint32_t y = 0; y < Y; y++)
                s->rays_host[n++] = (clvox_ray){(float)y, (float)z, ((z - z0) * Y + y) * W, 0};
    } else if (s->axis == CLVOX_AXIS_Y) {
        stride = W;
        for (uint32_t z = z0; z < z0 + nz; z++)
            for (uint32_t x = 0; x < X; x++)
                s->rays_host[n++] = (clvox_ray){(float)z, (float)x, (z - z0) * Y * W + x / 32, x % 32};
    } else {
        stride = Y * W;
        u_begin = z0;
        u_count = nz;
        for (uint32_t y = 0; y < Y; y++)
            for (uint32_t x = 0; x < X; x++)
                s->rays_host[n++] = (clvox_ray){(float)x, (float)y, y * W + x / 32, x % 32};
    }
    cl_int err = CL_SUCCESS;
    if (stride != 0) { /* these rays only set bits */
        cl_uint zero = 0;
        err = clEnqueueFillBuffer(ctx->queue, out, &zero, sizeof zero, 0, (size_t)W * Y * nz * sizeof(cl_uint), 0,
                                  NULL, NULL);
        if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "clearing the slab");
    }
    err = clEnqueueWriteBuffer(ctx->queue, s->rays, CL_TRUE, 0, n * sizeof(clvox_ray), s->rays_host, 0, NULL, NULL);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "uploading rays");
    clvox_status st = cast_rays(s, s->rays, (cl_uint)n, s->leaf, s->hits, s->capacity, s->counts, s->filled, u_begin,
                                u_count, stride, out, ss);
    if (st != CLVOX_OK) return st;
    err = clEnqueueReadBuffer(ctx->queue, s->counts, CL_TRUE, 0, n * 4, s->counts_host, 0, NULL, NULL);
    if (err == CL_SUCCESS)
        err = clEnqueueReadBuffer(ctx->queue, s->filled, CL_TRUE, 0, n * 4, s->filled_host, 0, NULL, NULL);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "reading ray results");

    /* z-rays are the same for every slab: count them once. */
    int count_rays = s->axis != CLVOX_AXIS_Z || z0 == 0;
    size_t over = 0;
    uint32_t need = 0;
    for (size_t i = 0; i < n; i++) {
        uint32_t c = s->counts_host[i];
        if (count_rays) {
            ss->odd_parity_rays += c & 1u;
            if (c > ss->max_crossings) ss->max_crossings = c;
        }
        if (c > s->capacity) {
            s->rays_host[over] = s->rays_host[i]; /* compact in place: over <= i */
            s->counts_host[over] = c;
            over++;
            if (c > need) need = c;
        } else {
            ss->filled += s->filled_host[i];
        }
    }
    if (count_rays) ss->rays += n;
    if (over) {
        uint32_t *idx = malloc(over * sizeof *idx);
        if (!idx) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
        for (size_t i = 0; i < over; i++) idx[i] = (uint32_t)i;
        st = redo_overflow(s, idx, over, need, u_begin, u_count, stride, out, ss);
        free(idx);
        if (st != CLVOX_OK) return st;
        if (count_rays) ss->overflow_rays += over;
    }
    return CLVOX_OK;
}

static void ray_describe(const clvox__method_state *s, char *buf, size_t size)
{
    snprintf(buf, size, "axis=%c quadtree_depth=%u quadtree_leaf_size=%u hit_capacity=%u rule=centre-on-surface:+x+y+z",
             "?xyz"[s->axis], s->qt.depth, s->leaf_size, s->capacity);
}

const clvox__method clvox__method_ray = {"ray", ray_prepare, ray_slab, ray_release, ray_describe};
