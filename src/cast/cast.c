/* SPDX-License-Identifier: Apache-2.0 */
/* Stage cast, and the ray method that strings partition -> cast -> consumer
 * together for one slab (Thon et al. 3.3).
 *
 * One cast, three consumers. A batch is a list of rays (any (v,w) positions)
 * that the device runs through leaf lookup, intersection and sort; the
 * sorted crossing lists then go to the consumer kernel:
 *  - classify (binary): one ray per voxel column, at the column centre;
 *    the parity of the crossings beyond each centre gives occupancy bits;
 *  - coverage (grey levels, 3.3.4): N x N rays per column (positions from
 *    kernels/sampler.h), and kernels/coverage.cl counts the points inside
 *    per voxel over the column's rays;
 *  - palette scoring (Cavagnino & Gribaudo): the same rays and points, and
 *    kernels/palette_score.cl picks each voxel's best palette element.
 * Coverage and palette runs are "column runs": their batches hold whole
 * columns of R rays.
 * A binary slab is one batch unless its work is large. A coverage slab is
 * cut into batches of at most max_rays rays (whole columns), so the ray and
 * crossing buffers are those of the binary run whatever N is. Batches are
 * also bounded in work (CLVOX__BATCH_TESTS ray-triangle tests, estimated
 * from the largest quadtree leaf) and the driver is polled between them, so
 * a cancel is honoured within about one batch's time however slow a slab is;
 * a ray with more than CLVOX__MAX_CROSSINGS crossings is an error. Rays with more crossings than the buffer
 * holds are found from the counts and cast again (in coverage runs, with
 * the rest of their column) with a buffer as large as the largest count, in
 * batches of at most max_rays * capacity crossings (at least one column).
 * Where a slab takes several batches they are in flight two at a time (two
 * batch sets, alternating: ray_slab), and column runs' rays are made on the
 * device from the uploaded columns where the kernels compute in double
 * (docs/design.md "Batches in flight", "Ray positions on the device").
 * Rays along z are the same X*Y columns in every slab: when one batch holds
 * them all, they are cast once per device and later slabs run only the
 * consumer on the crossings left in the batch buffers.
 *
 * This file holds the cast and the method; each consumer's host side is in
 * its own file, named after its kernel: classify.c (clvox_classify),
 * winding_classify.c (clvox_classify_winding, and the winding preparation
 * of the cast's triangles, caps and rims), coverage.c (clvox_coverage, and
 * the samples and arguments both column consumers share) and
 * palette_score.c (clvox_palette_score). cast.h is what they get of a
 * batch. A float device's unsure winding points are decided on the host in
 * unsure.c (the state both files share: cast_state.h). */
#include "cast_state.h"
#include "core/launch.h"
#include "../../kernels/sampler.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DEFAULT_HIT_CAPACITY 32u
/* ray_slab: the first batch where there are caps. Near caps a ray may cost
 * milliseconds (a cracked soup: armadillo, 52 k triangles jittered by 1e-6,
 * about 8 ms a ray at 64^3 and 128^3 on 2 cores), so a first batch of 2048
 * rays held the progress bar still for 10-16 s; 32 such rays take about
 * 0.25 s, and the time-sized batches double from there (a few more
 * launches, about a millisecond each, on meshes where rays are cheap). */
#define SLOW_FIRST_RAYS 32u
#define SLOW_BATCH_SECONDS 0.25 /* ... and the wall time a batch is sized for */
static void batch_mem_release(clvox__batch_mem *m)
{
    clvox__release_mem(&m->rays);
    clvox__release_mem(&m->cols);
    clvox__release_mem(&m->leaf);
    clvox__release_mem(&m->hits);
    clvox__release_mem(&m->counts);
    clvox__release_mem(&m->filled);
    clvox__release_mem(&m->sums);
    clvox__release_mem(&m->pstats);
    clvox__release_mem(&m->pvolume);
    clvox__release_mem(&m->signs);
    clvox__release_mem(&m->exact);
    clvox__release_mem(&m->unsure);
}

static clvox_status batch_mem_alloc(clvox_context *ctx, clvox__batch_mem *m, size_t max_rays, size_t max_items,
                                    cl_uint capacity, int coverage, int palette, int winding, int device_rays)
{
    clvox_status st = CLVOX_OK;
    memset(m, 0, sizeof *m);
    m->max_rays = max_rays;
    m->max_items = max_items;
    m->capacity = capacity;
    if (max_rays > SIZE_MAX / ((size_t)capacity * ctx->real_size))
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "crossing buffer for %zu rays x %u too large", max_rays,
                           capacity);
    /* device_rays: written by clvox_column_rays */
    m->rays = clvox__buffer(ctx, device_rays ? CL_MEM_READ_WRITE : CL_MEM_READ_ONLY, max_rays * sizeof(clvox_ray), NULL, &st, "rays");
    if (st == CLVOX_OK) m->leaf = clvox__buffer(ctx, CL_MEM_READ_WRITE, max_rays * sizeof(cl_uint), NULL, &st, "leaves");
    if (st == CLVOX_OK)
        m->hits = clvox__buffer(ctx, CL_MEM_READ_WRITE, max_rays * capacity * ctx->real_size, NULL, &st, "crossings");
    if (st == CLVOX_OK) m->counts = clvox__buffer(ctx, CL_MEM_READ_WRITE, max_rays * sizeof(cl_uint), NULL, &st, "counts");
    if (st == CLVOX_OK)
        m->filled = clvox__buffer(ctx, CL_MEM_READ_WRITE, max_items * sizeof(cl_uint), NULL, &st, "filled");
    if (st == CLVOX_OK && coverage)
        m->cols = clvox__buffer(ctx, CL_MEM_READ_ONLY, max_items * sizeof(clvox_column), NULL, &st, "columns");
    if (st == CLVOX_OK && coverage)
        m->sums = clvox__buffer(ctx, CL_MEM_READ_WRITE, max_items * sizeof(cl_ulong), NULL, &st, "column sums");
    if (st == CLVOX_OK && palette)
        m->pstats = clvox__buffer(ctx, CL_MEM_READ_WRITE, max_items * 4 * sizeof(cl_uint), NULL, &st, "column tallies");
    if (st == CLVOX_OK && palette)
        m->pvolume = clvox__buffer(ctx, CL_MEM_READ_WRITE, max_items * sizeof(cl_ulong), NULL, &st, "column volumes");
    if (st == CLVOX_OK && winding)
        m->signs = clvox__buffer(ctx, CL_MEM_READ_WRITE, max_rays * capacity, NULL, &st, "crossing signs");
    if (st == CLVOX_OK && winding) m->exact = clvox__buffer(ctx, CL_MEM_READ_WRITE, sizeof(cl_uint), NULL, &st, "exact points");
    if (st == CLVOX_OK && winding) {
        /* a float device's unsure points (unsure.c); a double device
         * leaves none, its list has no room */
        const unsigned room = clvox__hooks()->unsure_room;
        m->unsure_room = ctx->real_size == 4 ? (room ? room : UNSURE_ROOM) : 0;
        m->unsure = clvox__buffer(ctx, CL_MEM_READ_WRITE,
                                  (2 + UNSURE_WORDS * (size_t)m->unsure_room) * sizeof(cl_uint), NULL, &st,
                                  "unsure points");
    }
    if (st != CLVOX_OK) batch_mem_release(m);
    return st;
}

static void batch_drop(batch_set *b)
{
    for (int i = 0; i < 5; i++)
        if (b->ev[i]) clReleaseEvent(b->ev[i]), b->ev[i] = NULL;
    clvox__launch_ticket_drop(&b->ticket);
    b->queued = 0;
}

static void batch_set_free(batch_set *b)
{
    batch_drop(b);
    batch_mem_release(&b->mem);
    free(b->rays);
    free(b->cols);
    free(b->counts);
    free(b->filled);
    free(b->sums);
    free(b->pstats);
    free(b->pvolume);
    free(b->unsure);
    memset(b, 0, sizeof *b);
}

/* A batch set of max_rays rays (max_items items) of `capacity` crossings;
 * with_rays: the host ray array too, where the host makes the rays. */
static clvox_status batch_set_alloc(clvox__method_state *s, batch_set *b, size_t max_rays, size_t max_items,
                                    cl_uint capacity, int with_rays)
{
    memset(b, 0, sizeof *b);
    clvox_status st = batch_mem_alloc(s->ctx, &b->mem, max_rays, max_items, capacity, s->coverage, s->palette,
                                      s->winding, s->coverage && s->cov.k_rays);
    if (st != CLVOX_OK) return st;
    const int rays = with_rays && (!s->coverage || !s->cov.k_rays);
    if (rays) b->rays = malloc(max_rays * sizeof *b->rays);
    b->counts = malloc(max_rays * sizeof *b->counts);
    b->filled = malloc(max_items * sizeof *b->filled);
    if (s->coverage) {
        b->cols = malloc(max_items * sizeof *b->cols);
        b->sums = malloc(max_items * sizeof *b->sums);
    }
    if (s->palette) {
        b->pstats = malloc(max_items * 4 * sizeof *b->pstats);
        b->pvolume = malloc(max_items * sizeof *b->pvolume);
    }
    if (b->mem.unsure_room) b->unsure = malloc((2 + UNSURE_WORDS * (size_t)b->mem.unsure_room) * sizeof *b->unsure);
    if ((rays && !b->rays) || !b->counts || !b->filled || (s->coverage && (!b->cols || !b->sums)) ||
        (b->mem.unsure_room && !b->unsure) ||
        (s->palette && (!b->pstats || !b->pvolume)))
        return clvox__fail(s->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu rays", max_rays);
    return CLVOX_OK;
}

/* Device bytes of one batch item (a ray, or a column of R rays) whose rays
 * hold `capacity` crossings each: what batch_mem_alloc allocates per item. */
static uint64_t item_bytes(const clvox_context *ctx, size_t R, cl_uint capacity, int coverage, int palette,
                           int winding)
{
    const uint64_t ray = sizeof(clvox_ray) + 2 * sizeof(cl_uint) + (uint64_t)capacity * (ctx->real_size + !!winding);
    const uint64_t item = sizeof(cl_uint) + (coverage ? sizeof(clvox_column) + sizeof(cl_ulong) : 0) +
                          (palette ? 4 * sizeof(cl_uint) + sizeof(cl_ulong) : 0);
    return R * ray + item;
}

/* The slab planes voxelize.c allocates once the method is prepared: the
 * occupancy bit rows, a uint16 per voxel for each other channel. */
static uint64_t slab_plane_bytes(const clvox_grid *g, uint32_t channels, uint32_t depth)
{
    const uint64_t X = g->dims[0], Y = g->dims[1];
    uint64_t slice = (channels & CLVOX_CHANNEL_OCCUPANCY) ? (uint64_t)clvox__row_words(g->dims[0]) * Y * 4 : 0;
    const uint32_t voxel_planes[] = {CLVOX_CHANNEL_COVERAGE, CLVOX_CHANNEL_ELEMENT, CLVOX_CHANNEL_SCORE};
    for (int i = 0; i < 3; i++)
        if (channels & voxel_planes[i]) slice += X * Y * 2;
    return slice * depth;
}

/* Caps *max_items (items of R rays per fast-pass batch) so that the
 * device holds the batches (device_memory.c): each batch buffer within the
 * device's largest buffer (the crossings, R x capacity reals an item, are
 * the largest), and the fast pass beside the buffers already made (mesh,
 * quadtree, caps, palette) and the slab planes within the run's budget,
 * with as much again left for redo_overflow. Batches only group rays, so
 * smaller ones give the same voxels. CLVOX_ERR_OUT_OF_MEMORY where one item
 * does not fit. */
static clvox_status fit_batches(clvox__method_state *s, const clvox__run *run, uint32_t depth, cl_uint capacity,
                                size_t *max_items, size_t work_items)
{
    clvox_context *ctx = s->ctx;
    const size_t R = s->coverage ? s->cov.R : 1;
    char what[160];
    /* every per-ray buffer's element is at most the larger of a ray and its crossings */
    const uint64_t ray_elem = (uint64_t)capacity * ctx->real_size > sizeof(clvox_ray)
                                  ? (uint64_t)capacity * ctx->real_size
                                  : sizeof(clvox_ray);
    const uint64_t item_elem = s->coverage || s->palette ? 16 : 4; /* columns, tallies; filled */
    uint64_t k = s->max_alloc / (R * ray_elem);
    if (s->max_alloc / item_elem < k) k = s->max_alloc / item_elem;
    if (k < 1) {
        snprintf(what, sizeof what, "one voxel column (%zu ray%s of %u crossings)", R, R == 1 ? "" : "s", capacity);
        return clvox__device_alloc_oom(ctx, R * ray_elem, what);
    }
    const cl_mem held[] = {s->verts,          s->tris,           s->nodes,          s->refs,
                           s->wind.caps.h,    s->wind.caps.nodes, s->wind.caps.tris, s->wind.caps.grid, s->wind.rims.h,
                           s->wind.rims.nodes, s->wind.rims.tris, s->cov.value_of_count, s->pal.elements,
                           s->pal.cells,      s->pal.planes,     s->pal.masks,      s->pal.volume};
    uint64_t fixed = slab_plane_bytes(&s->grid, run->channels, depth);
    for (size_t i = 0; i < sizeof held / sizeof *held; i++) fixed += clvox__mem_bytes(held[i]);
    const uint64_t one = item_bytes(ctx, R, capacity, s->coverage, s->palette, s->winding);
    const uint64_t budget = clvox__device_budget(ctx), avail = budget > fixed ? budget - fixed : 0;
    if (avail / 2 / one < 1) {
        snprintf(what, sizeof what, "the mesh's buffers and the slab planes, %zu ray%s of %u crossings and as much again "
                 "for rays with more", R, R == 1 ? "" : "s", capacity);
        return clvox__device_oom(ctx, fixed + 2 * one, budget, what);
    }
    /* Two sets of batch buffers (batches in flight two at a time,
     * ray_slab) where a slab takes several batches: each within the
     * largest buffer, both beside as much again for redo_overflow within
     * the budget (a third each of what is left, instead of a half), and
     * where memory is what cuts the slab into batches, each half of what
     * one set would be (the same device memory: smaller batches, the same
     * voxels). One set where a slab is one batch (z rays cast once: the
     * crossings of every column in one set), where batches are timed (one
     * at a time, for the cancel), or where an item leaves no room for two. */
    const uint64_t one_set = avail / 2 / one < k ? avail / 2 / one : k;
    uint64_t two_sets = avail / 3 / one < k ? avail / 3 / one : k;
    if (one_set < *max_items && one_set / 2 < two_sets) two_sets = one_set / 2;
    const int several = s->coverage || one_set < *max_items || work_items < *max_items; /* batches a slab */
    s->sets = several && !s->timed && two_sets >= 1 ? 2 : 1;
    k = s->sets == 2 ? two_sets : one_set;
    if (k < *max_items) *max_items = (size_t)k;
    s->held_bytes = fixed + (uint64_t)s->sets * *max_items * one;
    s->redo_room = budget > s->held_bytes ? budget - s->held_bytes : 0;
    return CLVOX_OK;
}

/* A read-only device buffer holding `bytes` of `host` (the mesh's
 * triangles, the quadtree). A device copy written once, blocking, so that
 * the host array may go at once: on a discrete GPU a CL_MEM_USE_HOST_PTR
 * buffer can cost a PCIe transfer on every access; on PoCL the copy costs
 * no measurable time (docs/benchmarks.md). */
static cl_mem upload(clvox_context *ctx, size_t bytes, const void *host, clvox_status *st, const char *what)
{
    cl_mem m = clvox__buffer(ctx, CL_MEM_READ_ONLY, bytes, NULL, st, what);
    if (!m) return NULL;
    cl_int err = bytes ? clEnqueueWriteBuffer(ctx->queue, m, CL_TRUE, 0, bytes, host, 0, NULL, NULL) : CL_SUCCESS;
    if (err != CL_SUCCESS) {
        char msg[96];
        snprintf(msg, sizeof msg, "uploading the %s", what);
        clFinish(ctx->queue); /* the host array must outlive the write */
        clvox__release_mem(&m);
        *st = clvox__cl_fail(ctx, err, msg);
    }
    return m;
}

/* A device copy on ctx of buffer `src` of another device's context (the
 * lead's, set up on this same thread): read back, then uploaded. NULL
 * stays NULL. With `keep`, *keep gets the bytes read back (the caller's to
 * free) where the copy is made. */
static cl_mem copy_from_keep(clvox_context *ctx, clvox_context *from, cl_mem src, clvox_status *st, const char *what,
                             void **keep)
{
    if (!src || *st != CLVOX_OK) return NULL;
    size_t bytes = 0;
    cl_int err = clGetMemObjectInfo(src, CL_MEM_SIZE, sizeof bytes, &bytes, NULL);
    void *host = err == CL_SUCCESS ? malloc(bytes ? bytes : 1) : NULL;
    if (err == CL_SUCCESS && !host) {
        *st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory copying the %s", what);
        return NULL;
    }
    if (err == CL_SUCCESS && bytes) err = clEnqueueReadBuffer(from->queue, src, CL_TRUE, 0, bytes, host, 0, NULL, NULL);
    if (err != CL_SUCCESS) {
        char msg[96];
        snprintf(msg, sizeof msg, "reading the %s back from device '%.40s'", what, from->device.name);
        free(host);
        *st = clvox__cl_fail(ctx, err, msg);
        return NULL;
    }
    cl_mem m = upload(ctx, bytes, host, st, what);
    if (keep && m) {
        *keep = host;
        host = NULL;
    }
    free(host);
    return m;
}

static cl_mem copy_from(clvox_context *ctx, clvox_context *from, cl_mem src, clvox_status *st, const char *what)
{
    return copy_from_keep(ctx, from, src, st, what, NULL);
}

/* copy_from for an array of clvox_real: converted where the two devices'
 * kernels differ (a float device beside a double lead: rounded, which the
 * float kernels' bounds take in, kernels/winding_angles.h). */
static cl_mem copy_reals(clvox_context *ctx, clvox_context *from, cl_mem src, clvox_status *st, const char *what)
{
    if (ctx->real_size == from->real_size) return copy_from(ctx, from, src, st, what);
    if (!src || *st != CLVOX_OK) return NULL;
    size_t bytes = 0;
    cl_int err = clGetMemObjectInfo(src, CL_MEM_SIZE, sizeof bytes, &bytes, NULL);
    const size_t n = bytes / from->real_size;
    double *d = err == CL_SUCCESS ? malloc(n ? n * sizeof *d : 1) : NULL;
    void *conv = err == CL_SUCCESS ? malloc(n ? n * ctx->real_size : 1) : NULL;
    if (err == CL_SUCCESS && (!d || !conv)) {
        free(d);
        free(conv);
        *st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory copying the %s", what);
        return NULL;
    }
    if (err == CL_SUCCESS && n) {
        if (from->real_size == 8) {
            err = clEnqueueReadBuffer(from->queue, src, CL_TRUE, 0, n * sizeof *d, d, 0, NULL, NULL);
        } else {
            float *f = (float *)conv; /* ctx->real_size >= 4: room for n floats */
            err = clEnqueueReadBuffer(from->queue, src, CL_TRUE, 0, n * sizeof *f, f, 0, NULL, NULL);
            for (size_t i = n; err == CL_SUCCESS && i-- > 0;) d[i] = f[i];
        }
    }
    if (err != CL_SUCCESS) {
        char msg[96];
        snprintf(msg, sizeof msg, "reading the %s back from device '%.40s'", what, from->device.name);
        free(d);
        free(conv);
        *st = clvox__cl_fail(ctx, err, msg);
        return NULL;
    }
    for (size_t i = 0; i < n; i++) {
        if (ctx->real_size == 8) ((double *)conv)[i] = d[i];
        else ((float *)conv)[i] = (float)d[i];
    }
    cl_mem m = upload(ctx, n * ctx->real_size, conv, st, what);
    free(conv);
    free(d);
    return m;
}

static void copy_caps(clvox_context *ctx, clvox_context *from, const clvox__caps *src, clvox__caps *dst, int caps,
                      clvox_status *st)
{
    dst->nodes = copy_from(ctx, from, src->nodes, st, "cap tree");
    const int keep = caps && ctx->real_size == 4 && src->cap_count; /* clvox__caps.host */
    dst->tris = copy_reals(ctx, from, src->tris, st, "cap triangles");
    void *host = NULL;
    dst->grid = copy_from_keep(ctx, from, src->grid, st, "caps in grid space", keep ? &host : NULL);
    dst->host = host;
    dst->host_count = dst->host ? src->cap_count : 0;
    dst->h = copy_reals(ctx, from, src->h, st, "cap scale");
    dst->node_count = src->node_count;
    dst->cap_count = src->cap_count;
}

static void ray_release(clvox__method_state *s)
{
    if (!s) return;
    clvox__release_mem(&s->verts);
    clvox__release_mem(&s->tris);
    clvox__release_mem(&s->nodes);
    clvox__release_mem(&s->refs);
    free(s->verts_host);
    s->verts_host = NULL;
    free(s->tris_owned);
    s->tris_owned = NULL;
    clvox__coverage_release(&s->cov);
    clvox__palette_score_release(&s->pal);
    batch_set_free(&s->set[0]);
    batch_set_free(&s->set[1]);
    clvox__winding_classify_release(&s->wind);
    if (s->k_lookup) clReleaseKernel(s->k_lookup);
    if (s->k_intersect) clReleaseKernel(s->k_intersect);
    if (s->k_sort) clReleaseKernel(s->k_sort);
    if (s->k_classify) clReleaseKernel(s->k_classify);
    if (s->k_set_bits) clReleaseKernel(s->k_set_bits);
    clvox__quadtree_free(&s->qt);
    free(s->z_counts);
    free(s);
}

static clvox_status ray_prepare(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                const clvox_voxelize_options *opts, const clvox__run *run, uint32_t slab_depth,
                                clvox_stats *stats, clvox__method_state **out)
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
    s->leaf_size = opts->quadtree_leaf_size ? opts->quadtree_leaf_size : 8;
    s->channels = run->channels;
    s->poll = run->poll;
    s->poll_user = run->poll_user;
    s->max_alloc = clvox__device_max_alloc(ctx);

    /* Columns of one slab: x-rays cover Y*nz columns, y-rays X*nz, z-rays all X*Y. */
    const uint32_t *d = grid->dims;
    size_t columns = s->axis == CLVOX_AXIS_X   ? (size_t)d[1] * slab_depth
                     : s->axis == CLVOX_AXIS_Y ? (size_t)d[0] * slab_depth
                                               : (size_t)d[0] * d[1];

    clvox_status st = CLVOX_OK;
    if (opts->oversample) {
        s->coverage = 1;
        st = clvox__coverage_prepare(ctx, &s->cov, opts, run, grid, s->axis);
    }
    if (st == CLVOX_OK && opts->palette) {
        s->palette = 1;
        st = clvox__palette_score_prepare(ctx, &s->pal, opts, &s->cov, s->axis);
    }
    /* The triangles the cast runs over: grid-space vertices and 3 indices
     * each, the mesh's own unless the winding preparation changed them. */
    clvox__cast_tris ct = {NULL, mesh->vertex_count, mesh->tris, NULL, mesh->triangle_count, {0}, 0};
    double t0 = clvox__now();
    s->winding = opts->inside == CLVOX_INSIDE_WINDING || opts->inside == CLVOX_INSIDE_WINDING_ABS;
    s->wind.abs_mode = opts->inside == CLVOX_INSIDE_WINDING_ABS;
    s->wind.axis = (cl_uint)s->axes.perm[0];
    const clvox__method_state *lead = run->lead;
    if (st == CLVOX_OK && lead) {
        /* Another device of the run has prepared the mesh: copies of its
         * buffers, the host work is not done again. */
        clvox_context *from = lead->ctx;
        s->verts = copy_from(ctx, from, lead->verts, &st, "vertices");
        s->tris = copy_from(ctx, from, lead->tris, &st, "triangles");
        s->nodes = copy_from(ctx, from, lead->nodes, &st, "quadtree");
        s->refs = copy_from(ctx, from, lead->refs, &st, "quadtree refs");
        copy_caps(ctx, from, &lead->wind.caps, &s->wind.caps, 1, &st);
        copy_caps(ctx, from, &lead->wind.rims, &s->wind.rims, 0, &st);
        s->wind.prep = lead->wind.prep;
        s->wind.surface_count = lead->wind.surface_count;
        s->wind.crack_distance = lead->wind.crack_distance;
        s->wind.crack_welded = lead->wind.crack_welded;
        s->wind.crack_pairs = lead->wind.crack_pairs;
        s->wind.crack_holes = lead->wind.crack_holes;
        s->qt.node_count = lead->qt.node_count;
        s->qt.ref_count = lead->qt.ref_count;
        s->qt.depth = lead->qt.depth;
        s->qt.leaf_count = lead->qt.leaf_count;
        s->leaf_max = lead->leaf_max;
        s->float_outside = lead->float_outside;
        s->float_coord = lead->float_coord;
        if (stats) clvox__winding_stats(&s->wind, stats);
    } else if (st == CLVOX_OK && s->winding)
        st = clvox__winding_cast_prepare(ctx, mesh, grid, opts, s->axes, s->dim_v, s->dim_w, s->leaf_size, &s->wind,
                                         stats, &ct);
    else if (st == CLVOX_OK)
        st = clvox__grid_space_vertices(ctx, mesh, grid, s->axes, 0, &ct.verts);
    if (ct.have_tree) s->qt = ct.qt;
    float *verts = ct.verts;
    const uint32_t *tris = ct.tris;
    uint32_t *tris_owned = ct.tris_owned;
    size_t tri_count = ct.tri_count, vert_count = ct.vert_count;
    const int have_tree = ct.have_tree;
    /* held by s from here (ray_release frees them after the buffers) */
    s->verts_host = verts;
    s->tris_owned = tris_owned;
    if (st == CLVOX_OK && !lead) s->float_outside = clvox__float_outside(verts, vert_count * 3, &s->float_coord);
    if (st == CLVOX_OK) st = clvox__float_check(ctx, "the ray method", s->float_outside, s->float_coord);
    if (st == CLVOX_OK && !have_tree && !lead)
        st = clvox__quadtree_build(ctx, verts, tris, tri_count, s->dim_v, s->dim_w, opts->quadtree_max_depth,
                                   s->leaf_size, &s->qt);
    if (st == CLVOX_OK && !lead && (!tri_count || !tris)) { /* nothing to index: bind a valid triangle */
        free(s->tris_owned);
        tris = s->tris_owned = calloc(3, sizeof *tris_owned);
        if (!tris) st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    }
    if (st != CLVOX_OK) {
        ray_release(s);
        return st;
    }
    /* Device copies (upload): the vertices (12 bytes a vertex), the
     * triangles' indices (the mesh's own, 12 bytes a triangle), the
     * quadtree's nodes and references (4 bytes each). */
    if (!lead) {
        s->verts = upload(ctx, vert_count * 3 * sizeof(float), verts, &st, "vertices");
        if (st == CLVOX_OK)
            s->tris = upload(ctx, (tri_count ? tri_count : 1) * 3 * sizeof(uint32_t), tris, &st, "triangles");
        if (st == CLVOX_OK)
            s->nodes = upload(ctx, s->qt.node_count * sizeof(clvox_qt_node), s->qt.nodes, &st, "quadtree");
        if (st == CLVOX_OK)
            s->refs = upload(ctx, s->qt.ref_count * sizeof(uint32_t), s->qt.refs, &st, "quadtree refs");
    }
    if (stats) {
        stats->seconds[CLVOX_STAGE_PARTITION] += clvox__now() - t0;
        stats->quadtree_depth = s->qt.depth;
        stats->quadtree_leaves = s->qt.leaf_count;
        stats->quadtree_refs = s->qt.ref_count;
    }
    if (st == CLVOX_OK) st = clvox__kernel(ctx, "clvox_quadtree_lookup", &s->k_lookup);
    if (st == CLVOX_OK) st = clvox__kernel(ctx, "clvox_intersect", &s->k_intersect);
    if (st == CLVOX_OK) st = clvox__kernel(ctx, "clvox_sort", &s->k_sort);
    if (st == CLVOX_OK && !s->coverage)
        st = clvox__kernel(ctx, s->winding ? "clvox_classify_winding" : "clvox_classify", &s->k_classify);
    if (st == CLVOX_OK && s->winding && !s->coverage && ctx->real_size == 4)
        st = clvox__kernel(ctx, "clvox_set_bits", &s->k_set_bits);
    if (st == CLVOX_OK && s->winding)
        st = clvox__winding_lattice_prepare(ctx, grid, !s->coverage && !s->palette, &s->wind);

    /* A coverage batch holds whole columns: as many rays as a binary slab,
     * and at least one column. */
    size_t max_rays = columns, max_items = columns;
    if (s->coverage) {
        max_items = columns / s->cov.R ? columns / s->cov.R : 1;
        max_rays = max_items * s->cov.R;
    }
    cl_uint capacity = opts->hit_capacity ? opts->hit_capacity : DEFAULT_HIT_CAPACITY;
    if (capacity > CLVOX__MAX_CROSSINGS) capacity = CLVOX__MAX_CROSSINGS;
    /* Batches of bounded work: items x rays per item x the largest leaf. */
    for (size_t i = 0; s->qt.nodes && i < s->qt.node_count; i++)
        if (s->qt.nodes[i].count != CLVOX_QT_INTERNAL && s->qt.nodes[i].count > s->leaf_max)
            s->leaf_max = s->qt.nodes[i].count;
    size_t work_items;
    {
        uint64_t per_item = (uint64_t)(s->coverage ? s->cov.R : 1) * (s->leaf_max ? s->leaf_max : 1);
        uint64_t k = CLVOX__BATCH_TESTS / per_item;
        work_items = k < 1 ? 1 : k > max_items ? max_items : (size_t)k;
        const unsigned hook = clvox__hooks()->batch_items; /* CLVOX_BATCH_ITEMS: many batches a slab (tests) */
        if (hook && hook < work_items) work_items = hook;
    }
    s->timed = s->wind.caps.node_count > 0; /* see below */
    if (st == CLVOX_OK) st = fit_batches(s, run, slab_depth, capacity, &max_items, work_items);
    max_rays = max_items * (s->coverage ? s->cov.R : 1);
    /* The device has its copies: the host arrays go (the tree's counts stay, for describe). */
    free(s->verts_host);
    free(s->tris_owned);
    free(s->qt.nodes);
    free(s->qt.refs);
    s->verts_host = NULL, s->tris_owned = NULL, s->qt.nodes = NULL, s->qt.refs = NULL;
    s->batch_items = work_items < max_items ? work_items : max_items;
    /* Where there are caps the winding classify near them is the cost, not
     * the intersection tests that bound batch_items (b9_mesh: 12 s for the
     * one batch of its one slab at 256^3), and it is between batches that
     * the progress bar moves and SIGINT is heard: there the first batch is
     * SLOW_FIRST_RAYS rays and ray_slab sizes the next ones by time. Near
     * caps a ray's cost also varies a thousandfold, so that on a CPU device
     * work-groups of 4 rays keep a short batch from ending on one group of
     * 64 costly rays (2 cores, cylinder at 256^3 in batches: 0.99 s with
     * 64, 0.82 with 4, 0.94 in one batch of 64; docs/benchmarks.md). */
    const size_t first = SLOW_FIRST_RAYS / (s->coverage ? s->cov.R : 1); /* items: rays or columns */
    s->batch_now = s->timed && first < s->batch_items ? (first ? first : 1) : s->batch_items;
    s->wind.local = s->timed && strcmp(ctx->device.type, "cpu") == 0 ? 4 : 64;
    for (int i = 0; st == CLVOX_OK && i < s->sets; i++)
        st = batch_set_alloc(s, &s->set[i], max_rays, max_items, capacity, 1);
    if (stats) {
        uint64_t b = (uint64_t)max_rays * (sizeof(clvox_ray) * 2 + 3 * 4 + capacity * ctx->real_size) +
                     (uint64_t)max_items * (4 * 2 + (s->coverage ? sizeof(clvox_column) + 8 * 2 : 0));
        b *= (uint64_t)s->sets;
        if (b > stats->peak_slab_bytes) stats->peak_slab_bytes = b;
    }
    if (st != CLVOX_OK) {
        ray_release(s);
        return st;
    }
    *out = s;
    return CLVOX_OK;
}

/* The lookup, intersect and sort kernels' arguments for a batch of n rays in m. */
static cl_int set_cast_args(clvox__method_state *s, const clvox__batch_mem *m, cl_uint n)
{
    cl_uint capacity = m->capacity;
    cl_int err = CL_SUCCESS;
    err |= clSetKernelArg(s->k_lookup, 0, sizeof(cl_mem), &m->rays);
    err |= clSetKernelArg(s->k_lookup, 1, sizeof(cl_uint), &n);
    err |= clSetKernelArg(s->k_lookup, 2, sizeof(cl_mem), &s->nodes);
    err |= clSetKernelArg(s->k_lookup, 3, sizeof(cl_mem), &m->leaf);
    err |= clSetKernelArg(s->k_intersect, 0, sizeof(cl_mem), &m->rays);
    err |= clSetKernelArg(s->k_intersect, 1, sizeof(cl_uint), &n);
    err |= clSetKernelArg(s->k_intersect, 2, sizeof(cl_mem), &m->leaf);
    err |= clSetKernelArg(s->k_intersect, 3, sizeof(cl_mem), &s->nodes);
    err |= clSetKernelArg(s->k_intersect, 4, sizeof(cl_mem), &s->refs);
    err |= clSetKernelArg(s->k_intersect, 5, sizeof(cl_mem), &s->verts);
    err |= clSetKernelArg(s->k_intersect, 6, sizeof(cl_mem), &s->tris);
    err |= clSetKernelArg(s->k_intersect, 7, sizeof(cl_uint), &capacity);
    err |= clSetKernelArg(s->k_intersect, 8, sizeof(cl_mem), &m->hits);
    err |= clSetKernelArg(s->k_intersect, 9, sizeof(cl_mem), &m->counts);
    err |= clSetKernelArg(s->k_intersect, 10, sizeof(cl_mem), &m->signs); /* NULL unless winding */
    /* column runs (coverage, palette): every crossing as the float RU(u)
     * (kernels/intersect.cl clvox_hit_round_up), which the float sample
     * points compare with exactly */
    const cl_uint exact_hits = s->coverage;
    err |= clSetKernelArg(s->k_intersect, 11, sizeof(cl_uint), &s->wind.surface_count);
    err |= clSetKernelArg(s->k_intersect, 12, sizeof(cl_uint), &exact_hits);
    err |= clSetKernelArg(s->k_sort, 0, sizeof(cl_uint), &n);
    err |= clSetKernelArg(s->k_sort, 1, sizeof(cl_uint), &capacity);
    err |= clSetKernelArg(s->k_sort, 2, sizeof(cl_mem), &m->hits);
    err |= clSetKernelArg(s->k_sort, 3, sizeof(cl_mem), &m->counts);
    err |= clSetKernelArg(s->k_sort, 4, sizeof(cl_mem), &m->signs);
    return err;
}

/* Enqueues a batch in b (n rays; coverage: n_cols columns of R rays
 * each, the rays made on the device from the columns where s->cov.k_rays,
 * `rays` then unused): uploads `rays` and `cols`, runs lookup, intersect,
 * sort and the consumer, and reads back, without waiting, the crossing
 * count of every ray, the filled voxels of every item, (coverage) the count
 * sum of every column, (palette) the tallies, and last the launches'
 * completion counts (b->ticket: its read ends the batch). cast = 0: the
 * batch's rays, columns, sorted crossings and counts are already in b->mem
 * (z rays, ray_slab): only the consumer runs, and counts are not read.
 * `rays`, `cols` and b's arrays are the device's until batch_wait, or on an
 * error batch_abandon. */
static clvox_status batch_enqueue(clvox__method_state *s, batch_set *b, int cast, const clvox_ray *rays,
                                  const clvox_column *cols, cl_uint n, cl_uint n_cols, const clvox__slab_target *t)
{
    clvox_context *ctx = s->ctx;
    const clvox__batch_mem *m = &b->mem;
    cl_int err = 0;
    clvox_status st = CLVOX_OK;
    cl_uint capacity = m->capacity;
    const int make_rays = cast && s->coverage && s->cov.k_rays; /* rays made on the device from the columns */
    b->queued = 1; /* from the first enqueue on: an error waits for the queue (batch_abandon) */

    if (cast) {
        err = make_rays ? CL_SUCCESS
                        : clEnqueueWriteBuffer(ctx->queue, m->rays, CL_FALSE, 0, n * sizeof *rays, rays, 0, NULL, NULL);
        if (err == CL_SUCCESS && s->coverage)
            err = clEnqueueWriteBuffer(ctx->queue, m->cols, CL_FALSE, 0, n_cols * sizeof *cols, cols, 0, NULL, NULL);
        if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "uploading rays");
        if (set_cast_args(s, m, n) != CL_SUCCESS)
            return clvox__cl_fail(ctx, CL_INVALID_KERNEL_ARGS, "clSetKernelArg(cast kernels)");
    }
    if (s->winding) {
        cl_uint zero = 0;
        err = clEnqueueFillBuffer(ctx->queue, m->exact, &zero, sizeof zero, 0, sizeof zero, 0, NULL, NULL);
        if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "clearing the exact-point counter");
    }
    b->cast_rays = cast ? rays : NULL;
    b->cast_cols = cast ? cols : NULL;
    b->n_cols = n_cols;
    b->n_rays = n;
    b->t = *t;
    if (m->unsure_room) {
        b->unsure_head[0] = 0;
        b->unsure_head[1] = m->unsure_room;
        err = clEnqueueWriteBuffer(ctx->queue, m->unsure, CL_FALSE, 0, sizeof b->unsure_head, b->unsure_head, 0, NULL,
                                   NULL);
        if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "clearing the unsure points");
    }
    clvox__launch_begin(ctx);
    if (make_rays) {
        st = clvox__column_rays_enqueue(ctx, &s->cov, m, n_cols, &b->ev[4]);
        if (st != CLVOX_OK) return st;
    }
    if (cast) {
        st = clvox__launch(ctx, s->k_lookup, "clvox_quadtree_lookup", 0, n, 64, &b->ev[0]);
        if (st != CLVOX_OK) return st;
        st = clvox__launch(ctx, s->k_intersect, "clvox_intersect", 0, n, 64, &b->ev[1]);
        if (st == CLVOX_OK) st = clvox__launch(ctx, s->k_sort, "clvox_sort", 0, n, 64, &b->ev[2]);
    }
    if (st == CLVOX_OK) {
        if (s->palette) {
            st = clvox__palette_score_enqueue(ctx, &s->pal, &s->cov, &s->wind, m, n_cols, t, &b->ev[3]);
        } else if (s->coverage) {
            st = clvox__coverage_enqueue(ctx, &s->cov, &s->wind, m, n_cols, t, &b->ev[3]);
        } else if (s->winding) {
            st = clvox__winding_classify_enqueue(ctx, s->k_classify, &s->wind, m, n, t, &b->ev[3]);
        } else {
            clvox__classify_args a = {m->rays, n, m->hits, m->counts, capacity, t->u_begin, t->u_count,
                                      t->out_stride, t->out->occupancy, m->filled};
            st = clvox__classify_enqueue(ctx, s->k_classify, &a, &b->ev[3]);
        }
    }
    if (st != CLVOX_OK) return st;
    cl_uint items = s->coverage ? n_cols : n;
    err = cast ? clEnqueueReadBuffer(ctx->queue, m->counts, CL_FALSE, 0, n * sizeof *b->counts, b->counts, 0, NULL,
                                     NULL)
               : CL_SUCCESS;
    if (err == CL_SUCCESS)
        err = clEnqueueReadBuffer(ctx->queue, m->filled, CL_FALSE, 0, items * sizeof *b->filled, b->filled, 0, NULL,
                                  NULL);
    if (err == CL_SUCCESS && s->coverage)
        err = clEnqueueReadBuffer(ctx->queue, m->sums, CL_FALSE, 0, items * sizeof *b->sums, b->sums, 0, NULL, NULL);
    if (err == CL_SUCCESS && s->palette)
        err = clEnqueueReadBuffer(ctx->queue, m->pstats, CL_FALSE, 0, items * 4 * sizeof *b->pstats, b->pstats, 0,
                                  NULL, NULL);
    if (err == CL_SUCCESS && s->palette)
        err = clEnqueueReadBuffer(ctx->queue, m->pvolume, CL_FALSE, 0, items * sizeof *b->pvolume, b->pvolume, 0, NULL,
                                  NULL);
    b->exact = 0;
    if (err == CL_SUCCESS && s->winding)
        err = clEnqueueReadBuffer(ctx->queue, m->exact, CL_FALSE, 0, sizeof b->exact, &b->exact, 0, NULL, NULL);
    if (err == CL_SUCCESS && m->unsure_room)
        err = clEnqueueReadBuffer(ctx->queue, m->unsure, CL_FALSE, 0,
                                  (2 + UNSURE_WORDS * (size_t)m->unsure_room) * sizeof(cl_uint), b->unsure, 0, NULL,
                                  NULL);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "reading the batch back");
    st = clvox__launch_defer(ctx, &b->ticket);
    /* submitted now, so that the device runs it while the host goes on */
    if (st == CLVOX_OK && (err = clFlush(ctx->queue)) != CL_SUCCESS) st = clvox__cl_fail(ctx, err, "clFlush");
    return st;
}

/* Waits for batch b (its last read: the queue is in order), checks that
 * its launches completed, and adds its exact points and kernel times to
 * ss. b's arrays are the host's again. */
static clvox_status batch_wait(clvox__method_state *s, batch_set *b, clvox__slab_stats *ss)
{
    clvox_context *ctx = s->ctx;
    cl_int err = b->ticket.read ? clWaitForEvents(1, &b->ticket.read) : clFinish(ctx->queue);
    clvox_status st = err == CL_SUCCESS ? clvox__launch_verify(ctx, &b->ticket)
                                        : clvox__cl_fail(ctx, err, "running the cast kernels");
    if (st == CLVOX_OK && b->mem.unsure_room && b->unsure[0]) st = clvox__resolve_unsure(s, b, ss);
    if (st == CLVOX_OK) {
        ss->exact_points += b->exact;
        ss->cast_seconds += clvox__event_seconds(b->ev[0]) + clvox__event_seconds(b->ev[1]) +
                            clvox__event_seconds(b->ev[2]) + clvox__event_seconds(b->ev[4]);
        const double consumer = clvox__event_seconds(b->ev[3]);
        ss->classify_seconds += consumer;
        if (b->exact) ss->exact_seconds += consumer; /* clvox_stats.winding_exact_seconds */
    }
    batch_drop(b);
    return st;
}

/* After an error: waits for what is queued (uploads from and read-backs
 * into host arrays that the callers free or refill next; the result of the
 * wait is not the error) and forgets the batches in flight, b too where
 * not NULL (redo_overflow's). */
static void batch_abandon(clvox__method_state *s, batch_set *b)
{
    clFinish(s->ctx->queue);
    clvox__launch_begin(s->ctx);
    for (int i = 0; i < 2; i++)
        if (s->set[i].queued) batch_drop(&s->set[i]);
    if (b) batch_drop(b);
}

/* Asks the driver whether to go on (between batches); 1 = go on. */
static int poll_ok(const clvox__method_state *s, double slab_fraction)
{
    if (!s->poll) return 1;
    if (slab_fraction <= 0.0 || slab_fraction >= 1.0) return 1;
    return s->poll(s->poll_user, slab_fraction);
}

/* Items (rays, or columns of R rays) whose crossings did not fit: cast
 * them again with a buffer as large as the largest count, in batches of at
 * most the fast pass's crossing buffer (at least one item). `rays` holds R
 * rays per item, `cols` (coverage) one column per item; `expect` the counts
 * of the first pass, which the redo must reproduce. */
static clvox_status redo_overflow(clvox__method_state *s, const clvox_ray *rays, const clvox_column *cols,
                                  const uint32_t *expect, size_t items, uint32_t need, const clvox__slab_target *t,
                                  double f0, double f1, clvox__slab_stats *ss)
{
    clvox_context *ctx = s->ctx;
    const size_t R = s->coverage ? s->cov.R : 1;
    if ((uint64_t)need * R * ctx->real_size > s->max_alloc)
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY,
                           "a voxel column's %zu rays with up to %u crossings need %llu MB, more than the device's "
                           "largest buffer (%llu MB)",
                           R, need, (unsigned long long)((uint64_t)need * R * ctx->real_size >> 20),
                           (unsigned long long)(s->max_alloc >> 20));
    size_t per = (s->set[0].mem.max_rays * s->set[0].mem.capacity) / ((size_t)need * R);
    if (per < 1) per = 1;
    /* beside the fast pass's buffers, within the run's budget (fit_batches) */
    const uint64_t one = item_bytes(ctx, R, need, s->coverage, s->palette, s->winding);
    if (s->redo_room / one < 1) {
        char what[160];
        snprintf(what, sizeof what, "the fast pass's buffers and %zu ray%s of %u crossings", R, R == 1 ? "" : "s",
                 need);
        return clvox__device_oom(ctx, s->held_bytes + one, clvox__device_budget(ctx), what);
    }
    if (s->redo_room / one < per) per = (size_t)(s->redo_room / one);
    if (per > s->batch_items) per = s->batch_items;
    if (per > items) per = items;
    /* one batch at a time (rare: the rays with many crossings), behind
     * the fast pass's batch in flight, if any */
    batch_set m;
    clvox_status st = batch_set_alloc(s, &m, per * R, per, need, 0);
    for (size_t i0 = 0; st == CLVOX_OK && i0 < items; i0 += per) {
        size_t k = items - i0 < per ? items - i0 : per;
        st = batch_enqueue(s, &m, 1, rays ? rays + i0 * R : NULL, cols ? cols + i0 : NULL, (cl_uint)(k * R),
                           (cl_uint)k, t);
        if (st == CLVOX_OK) st = batch_wait(s, &m, ss);
        if (st != CLVOX_OK) batch_abandon(s, &m);
        for (size_t i = 0; st == CLVOX_OK && i < k * R; i++)
            if (m.counts[i] != expect[i0 * R + i])
                st = clvox__fail(ctx, CLVOX_ERR_INTERNAL, "overflow redo counted %u crossings instead of %u",
                                 m.counts[i], expect[i0 * R + i]);
        for (size_t i = 0; st == CLVOX_OK && i < k; i++) {
            ss->filled += m.filled[i];
            if (s->coverage) ss->coverage_count += m.sums[i];
            if (s->palette) clvox__palette_tally(ss, m.pstats + 4 * i, m.pvolume[i]);
        }
        if (st == CLVOX_OK && i0 + k < items && !poll_ok(s, f0 + (f1 - f0) * (double)(i0 + k) / (double)items))
            st = clvox__fail(ctx, CLVOX_ERR_CANCELLED, "cancelled while redoing rays with many crossings");
    }
    batch_set_free(&m);
    return st;
}

/* Column i of the slab that starts at z0: its ray-plane position (v, w) and
 * where its voxels go (out_base, bit; see clvox_ray). */
void clvox__slab_column(const clvox__method_state *s, uint32_t z0, size_t i, uint32_t *v, uint32_t *w,
                        clvox_u32 *out_base, clvox_u32 *bit)
{
    const uint32_t X = s->grid.dims[0], Y = s->grid.dims[1], W = clvox__row_words(X);
    if (s->axis == CLVOX_AXIS_X) { /* (v, w) = (y, z) */
        uint32_t y = (uint32_t)(i % Y), dz = (uint32_t)(i / Y);
        *v = y, *w = z0 + dz, *out_base = (dz * Y + y) * W, *bit = 0;
    } else if (s->axis == CLVOX_AXIS_Y) { /* (z, x) */
        uint32_t x = (uint32_t)(i % X), dz = (uint32_t)(i / X);
        *v = z0 + dz, *w = x, *out_base = dz * Y * W + x / 32, *bit = x % 32;
    } else { /* (x, y) */
        uint32_t x = (uint32_t)(i % X), y = (uint32_t)(i / X);
        *v = x, *w = y, *out_base = y * W + x / 32, *bit = x % 32;
    }
}

/* The R = N*N rays of a coverage column (sampler.h). */
void clvox__column_rays(uint32_t N, int stochastic, uint32_t seed_lo, uint32_t seed_hi, uint32_t v, uint32_t w,
                        uint32_t id, clvox_ray *out)
{
    for (uint32_t r = 0; r < N * N; r++) {
        float pv, pw;
        clvox_column_ray(v, w, id, r, N, stochastic, seed_lo, seed_hi, &pv, &pw);
        out[r] = (clvox_ray){pv, pw, 0, 0};
    }
}

/* Item c of the slab that starts at z0 into batch position i: its ray
 * (binary runs), or its column and R rays (column runs). */
static void slab_item(clvox__method_state *s, batch_set *b, uint32_t z0, size_t c, size_t i)
{
    const size_t R = s->coverage ? s->cov.R : 1;
    uint32_t v, w;
    clvox_u32 base, bit;
    clvox__slab_column(s, z0, c, &v, &w, &base, &bit);
    if (!s->coverage) {
        b->rays[i] = (clvox_ray){(float)v, (float)w, base, bit};
    } else {
        uint32_t id = w * s->dim_v + v;
        b->cols[i] = (clvox_column){id, base, bit, 0};
        if (b->rays) /* else made on the device (batch_enqueue) */
            clvox__column_rays(s->cov.N, s->cov.stochastic, s->cov.seed_lo, s->cov.seed_hi, v, w, id,
                               b->rays + i * R);
    }
}

static clvox_status ray_slab(clvox__method_state *s, uint32_t z0, uint32_t nz, const clvox__slab_out *out,
                             clvox__slab_stats *ss)
{
    clvox_context *ctx = s->ctx;
    const uint32_t X = s->grid.dims[0], Y = s->grid.dims[1];
    const uint32_t W = clvox__row_words(X);
    clvox__slab_target t = {0, s->dim_u, 0, out};
    size_t columns = (size_t)Y * nz;
    if (s->axis == CLVOX_AXIS_Y) {
        t.out_stride = W;
        columns = (size_t)X * nz;
    } else if (s->axis == CLVOX_AXIS_Z) {
        t.out_stride = Y * W;
        t.u_begin = z0;
        t.u_count = nz;
        columns = (size_t)X * Y;
    }
    if (t.out_stride != 0 && out->occupancy) { /* these rays only set bits */
        cl_uint zero = 0;
        cl_int err = clEnqueueFillBuffer(ctx->queue, out->occupancy, &zero, sizeof zero, 0,
                                         (size_t)W * Y * nz * sizeof(cl_uint), 0, NULL, NULL);
        if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "clearing the slab");
    }
    if (s->winding) { /* the caps' lattice (winding_lattice.c): the classify's time */
        const double t0 = clvox__now();
        clvox_status lst = clvox__winding_lattice_slab(ctx, &s->grid, &s->wind, z0, nz);
        if (lst != CLVOX_OK) return lst;
        const double dt = clvox__now() - t0;
        ss->classify_seconds += dt;
        ss->exact_seconds += dt;
    }
    /* z-rays are the same for every slab: count them once. */
    const int count_rays = s->axis != CLVOX_AXIS_Z || z0 == 0;
    const size_t R = s->coverage ? s->cov.R : 1;
    /* Items (rays or columns) per batch: s->batch_now, where timed sized
     * from the last batch's wall time to take about SLOW_BATCH_SECONDS (the
     * rays are independent: the same voxels whatever the batches). z rays
     * whose crossings an earlier slab left in set[0] (s->z_cast) are not
     * cast again: one batch runs the consumer on them.
     * Batches in flight: with two sets, batch j + 1 is enqueued before the
     * host waits for batch j, and batch j + 2 (in j's set) once the host
     * has tallied j, so that the host's work (rays, tallies) and the
     * device's read-backs overlap the device's next batch. Timed batches
     * run one at a time: they are sized for the cancel (poll_ok between
     * batches), which a batch queued behind would delay. */
    const int reuse = s->axis == CLVOX_AXIS_Z && s->z_cast;
    const unsigned depth = reuse || s->timed ? 1u : (unsigned)s->sets;
    clvox_status st = CLVOX_OK;
    size_t next = 0;                 /* the first item not yet enqueued */
    unsigned head = 0, inflight = 0; /* the oldest batch in flight (its number in the slab), how many */
    double t_batch = 0.0;
    size_t per = 0;
    while (st == CLVOX_OK) {
        while (st == CLVOX_OK && inflight < depth && next < columns) {
            batch_set *b = &s->set[(head + inflight) % (unsigned)s->sets]; /* batch 0 in set[0] (z_cast) */
            per = reuse ? columns : s->batch_now;
            const size_t k = columns - next < per ? columns - next : per;
            b->c0 = next, b->k = k, b->z0 = z0;
            if (s->timed) t_batch = clvox__now();
            if (reuse)
                memcpy(b->counts, s->z_counts, k * R * sizeof *b->counts);
            else
                for (size_t i = 0; i < k; i++) slab_item(s, b, z0, next + i, i);
            st = batch_enqueue(s, b, !reuse, b->rays, b->cols, (cl_uint)(k * R), (cl_uint)k, &t);
            next += k;
            inflight++;
        }
        if (st != CLVOX_OK || inflight == 0) break;
        batch_set *b = &s->set[head % (unsigned)s->sets];
        head++, inflight--;
        st = batch_wait(s, b, ss);
        if (st != CLVOX_OK) break;
        const size_t c0 = b->c0, k = b->k;
        if (s->axis == CLVOX_AXIS_Z && !reuse && !s->timed && k == columns) {
            /* set[0] now holds every z column's crossings: keep their counts
             * (before the tally below compacts them); without the memory
             * the next slabs cast again, to the same voxels */
            if (!s->z_counts) s->z_counts = malloc(columns * R * sizeof *s->z_counts);
            if (s->z_counts) {
                memcpy(s->z_counts, b->counts, columns * R * sizeof *s->z_counts);
                s->z_cast = 1;
            }
        }
        if (s->timed) { /* one batch at a time: per is this batch's */
            const double dt = clvox__now() - t_batch;
            double nx = dt > 0 ? (double)k * SLOW_BATCH_SECONDS / dt : (double)s->batch_items;
            if (nx > 2.0 * (double)per) nx = 2.0 * (double)per; /* grow gently: a batch's cost varies */
            s->batch_now = nx >= (double)s->batch_items ? s->batch_items : nx < 1.0 ? 1u : (size_t)nx;
        }

        /* Tally; compact the items that overflowed to the front (in place:
         * over <= i), with their rays and first-pass counts. */
        size_t over = 0;
        uint32_t need = 0;
        for (size_t i = 0; i < k; i++) {
            int overflowed = 0;
            for (size_t r = 0; r < R; r++) {
                uint32_t c = b->counts[i * R + r];
                if (count_rays) {
                    ss->odd_parity_rays += c & 1u;
                    if (c > ss->max_crossings) ss->max_crossings = c;
                }
                if (c > b->mem.capacity) {
                    overflowed = 1;
                    if (c > need) need = c;
                }
            }
            if (!overflowed) {
                ss->filled += b->filled[i];
                if (s->coverage) ss->coverage_count += b->sums[i];
                if (s->palette) clvox__palette_tally(ss, b->pstats + 4 * i, b->pvolume[i]);
                continue;
            }
            if (reuse) {
                slab_item(s, b, z0, c0 + i, over); /* its rays were not made for this slab */
                if (over != i) memmove(b->counts + over * R, b->counts + i * R, R * sizeof *b->counts);
            } else if (over != i) {
                if (b->rays) memmove(b->rays + over * R, b->rays + i * R, R * sizeof *b->rays);
                memmove(b->counts + over * R, b->counts + i * R, R * sizeof *b->counts);
                if (s->coverage) b->cols[over] = b->cols[i];
            }
            over++;
        }
        if (count_rays) ss->rays += k * R;
        if (need > CLVOX__MAX_CROSSINGS) {
            st = clvox__fail(ctx, CLVOX_ERR_MESH_INVALID,
                             "a ray crosses the surface %u times (at most %u): the mesh holds many coincident or "
                             "duplicated copies of its surfaces, where the inside test is meaningless",
                             need, CLVOX__MAX_CROSSINGS);
            break;
        }
        if (over) {
            st = redo_overflow(s, b->rays, s->coverage ? b->cols : NULL, b->counts, over, need, &t,
                               (double)c0 / (double)columns, (double)(c0 + k) / (double)columns, ss);
            if (st == CLVOX_OK && count_rays) ss->overflow_rays += over * R;
        }
        if (st == CLVOX_OK && c0 + k < columns && !poll_ok(s, (double)(c0 + k) / (double)columns))
            st = clvox__fail(ctx, CLVOX_ERR_CANCELLED, "cancelled within slab %u", z0);
    }
    if (st != CLVOX_OK) batch_abandon(s, NULL);
    return st;
}

static void ray_describe(const clvox__method_state *s, char *buf, size_t size)
{
    int n = snprintf(buf, size, "axis=%c quadtree_depth=%u quadtree_leaf_size=%u hit_capacity=%u rule=centre-on-surface:+x+y+z",
                     "?xyz"[s->axis], s->qt.depth, s->leaf_size, s->set[0].mem.capacity);
    if (n > 0 && (size_t)n < size) {
        const clvox_winding_report *w = &s->wind.prep;
        int m = s->winding ? snprintf(buf + n, size - (size_t)n,
                                      " inside=%s merged=%llu welded=%llu flipped=%llu cavities=%llu holes=%llu caps=%llu",
                                      s->wind.abs_mode ? "winding-abs" : "winding",
                                      (unsigned long long)w->merged_vertices, (unsigned long long)w->welded_vertices,
                                      (unsigned long long)w->flipped_triangles, (unsigned long long)w->cavities,
                                      (unsigned long long)w->holes, (unsigned long long)w->cap_triangles)
                           : snprintf(buf + n, size - (size_t)n, " inside=parity");
        n += m > 0 ? m : 0;
        if (s->winding && s->wind.crack_pairs && n > 0 && (size_t)n < size) {
            m = snprintf(buf + n, size - (size_t)n, " crack_weld=%.17g crack_pairs=%llu", s->wind.crack_distance,
                         (unsigned long long)s->wind.crack_pairs);
            n += m > 0 ? m : 0;
        }
    }
    if (s->coverage && n > 0 && (size_t)n < size) {
        int m = snprintf(buf + n, size - (size_t)n, " oversample=%ux%u points=%u sampling=%s seed=%llu sampler=philox4x32-10",
                         s->cov.N, s->cov.N, s->cov.M, s->cov.stochastic ? "stratified-jitter" : "uniform",
                         (unsigned long long)s->cov.seed_lo | ((unsigned long long)s->cov.seed_hi << 32));
        n += m > 0 ? m : 0;
        if ((s->channels & CLVOX_CHANNEL_OCCUPANCY) && (size_t)n < size) {
            m = snprintf(buf + n, size - (size_t)n, " occupancy=coverage>%.17g", s->cov.threshold);
            n += m > 0 ? m : 0;
        }
        if (s->palette && (size_t)n < size) {
            static const char *const metric[] = {"nearest", "outer", "inner"};
            snprintf(buf + n, size - (size_t)n, " palette=%s elements=%u metric=%s early_out=%s shortcut=%u..%u%s",
                     s->pal.name, s->pal.n_elements, metric[s->pal.metric % 3], s->pal.early_out ? "on" : "off", s->pal.sc_lo,
                     s->pal.sc_hi, s->cov.stochastic || s->pal.use_masks ? "" : " masks=off");
        }
    }
}

const clvox__method clvox__method_ray = {"ray", ray_prepare, ray_slab, ray_release, ray_describe};
