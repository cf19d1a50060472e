/* SPDX-License-Identifier: Apache-2.0 */
/* The ray method's batches (src/cast/cast.c ray_slab):
 *  - ray positions of column runs made on the device (kernels/coverage.cl
 *    clvox_column_rays) are the host's bit for bit: directly, on many
 *    columns, and through whole coverage and palette runs compared with
 *    CLVOX_HOST_RAYS=1 (every axis, N = 2..5, M != N, uniform and
 *    stochastic, slab depths, overflow redo with a crossing capacity of 1);
 *  - batches in flight: the same voxels and stats with 1..7 and many
 *    batches a slab (CLVOX_BATCH_ITEMS), binary, winding and column runs;
 *  - a cancel between batches stops the run. */
#include "test.h"
#include "meshgen.h"
#include "cast/coverage.h"
#include "core/environment.h"
#include "core/launch.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static clvox_context *ctx;

static clvox_mesh *to_mesh(clvox_context *c, const tmesh *t)
{
    clvox_mesh *m = NULL;
    if (clvox_mesh_from_arrays(c, t->xyz, t->nv, t->tri, t->nt, &m) != CLVOX_OK)
        fprintf(stderr, "mesh_from_arrays: %s\n", clvox_context_error(c));
    return m;
}

static clvox_grid make_grid(const double lo[3], const double h[3], uint32_t nx, uint32_t ny, uint32_t nz)
{
    clvox_grid g;
    uint32_t n[3] = {nx, ny, nz};
    for (int a = 0; a < 3; a++) g.dims[a] = n[a], g.origin[a] = lo[a], g.voxel_size[a] = h[a];
    return g;
}

static size_t nvox(const clvox_grid *g) { return (size_t)g->dims[0] * g->dims[1] * g->dims[2]; }

static void set_hooks(int host_rays, unsigned batch_items)
{
    clvox__test_hooks h = *clvox__hooks();
    h.host_rays = host_rays;
    h.batch_items = batch_items;
    clvox__set_test_hooks(&h);
}

/* The device's rays of `n` columns (ids) == the host's, for N, stochastic, seed. */
static size_t compare_direct(uint32_t N, int stochastic, uint64_t seed, uint32_t dim_v, const clvox_column *cols,
                             uint32_t n)
{
    clvox__coverage c;
    memset(&c, 0, sizeof c);
    c.N = N, c.R = N * N, c.stochastic = stochastic, c.seed_lo = (uint32_t)seed, c.seed_hi = (uint32_t)(seed >> 32);
    c.dim_v = dim_v;
    clvox__batch_mem m;
    memset(&m, 0, sizeof m);
    const size_t rays = (size_t)n * c.R;
    clvox_status st = clvox__kernel(ctx, "clvox_column_rays", &c.k_rays);
    if (st == CLVOX_OK)
        m.cols = clvox__buffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, n * sizeof *cols, (void *)cols, &st, "columns");
    if (st == CLVOX_OK) m.rays = clvox__buffer(ctx, CL_MEM_READ_WRITE, rays * sizeof(clvox_ray), NULL, &st, "rays");
    clvox_ray *dev = calloc(rays, sizeof *dev), *host = calloc(rays, sizeof *host);
    size_t bad = rays;
    if (st == CLVOX_OK && dev && host) {
        clvox__launch_begin(ctx);
        st = clvox__column_rays_enqueue(ctx, &c, &m, n, NULL);
        cl_int err = st == CLVOX_OK ? clEnqueueReadBuffer(ctx->queue, m.rays, CL_TRUE, 0, rays * sizeof *dev, dev, 0,
                                                          NULL, NULL)
                                    : CL_SUCCESS;
        if (st == CLVOX_OK) st = clvox__launch_check(ctx);
        CHECK_MSG(st == CLVOX_OK && err == CL_SUCCESS, "column rays: %s (%d)", clvox_context_error(ctx), (int)err);
        for (uint32_t i = 0; i < n; i++)
            clvox__column_rays(N, stochastic, c.seed_lo, c.seed_hi, cols[i].id % dim_v, cols[i].id / dim_v, cols[i].id,
                               host + (size_t)i * c.R);
        bad = 0;
        for (size_t i = 0; i < rays; i++)
            if (memcmp(&dev[i], &host[i], sizeof *dev) != 0 && bad++ < 3)
                fprintf(stderr, "N=%u stochastic=%d ray %zu: device (%.9g, %.9g), host (%.9g, %.9g)\n", N, stochastic,
                        i, dev[i].v, dev[i].w, host[i].v, host[i].w);
    }
    CHECK_MSG(st == CLVOX_OK, "%s", clvox_context_error(ctx));
    free(dev);
    free(host);
    clvox__release_mem(&m.cols);
    clvox__release_mem(&m.rays);
    if (c.k_rays) clReleaseKernel(c.k_rays);
    return bad;
}

static void test_direct(void)
{
    if (ctx->real_size != 8) {
        printf("SKIP direct ray comparison: the device's kernels compute in float (host rays there)\n");
        return;
    }
    /* many columns: a large ray plane (ids up to 2^32 - 1), the corners, random ones */
    const uint32_t dim_v = 65521, n = 4096;
    clvox_column *cols = calloc(n, sizeof *cols);
    uint64_t x = 0x9E3779B97F4A7C15ull;
    for (uint32_t i = 0; i < n; i++) {
        x ^= x << 13, x ^= x >> 7, x ^= x << 17;
        uint32_t id = i < 8 ? (uint32_t[]){0, 1, dim_v - 1, dim_v, dim_v + 1, 4294967295u, 4294967295u - dim_v, 12345}[i]
                            : (uint32_t)x;
        cols[i] = (clvox_column){id, 0, 0, 0};
    }
    const uint64_t seeds[] = {0, 1, 0x123456789abcull, 0xFFFFFFFFFFFFFFFFull};
    for (uint32_t N = 1; N <= 16; N++)
        for (int stochastic = 0; stochastic <= 1; stochastic++)
            for (size_t k = 0; k < (stochastic ? 4u : 1u); k++) {
                uint32_t cn = N <= 6 ? n : 512; /* R up to 256: 131 k rays */
                size_t bad = compare_direct(N, stochastic, seeds[k], dim_v, cols, cn);
                CHECK_MSG(bad == 0, "N=%u stochastic=%d seed %zu: %zu of %u rays differ", N, stochastic, k, bad,
                          cn * N * N);
            }
    free(cols);
}

/* One run's outputs, dense, and its stats. */
typedef struct result {
    uint16_t *element;
    float *score, *coverage;
    uint8_t *occupancy;
    clvox_stats stats;
    clvox_status status;
} result;

typedef struct collect {
    const clvox_grid *g;
    result *r;
    uint32_t next_z;
    int order_ok;
    int cancel_after; /* > 0: cancel once this many slabs came */
} collect;

static int on_slab(void *user, const clvox_slab *s)
{
    collect *c = user;
    size_t slice = (size_t)c->g->dims[0] * c->g->dims[1], at = (size_t)s->z0 * slice, n = slice * s->nz;
    if (s->z0 != c->next_z) c->order_ok = 0;
    c->next_z = s->z0 + s->nz;
    if (s->element) memcpy(c->r->element + at, s->element, n * sizeof *s->element);
    if (s->score) memcpy(c->r->score + at, s->score, n * sizeof *s->score);
    if (s->coverage) memcpy(c->r->coverage + at, s->coverage, n * sizeof *s->coverage);
    if (s->occupancy) memcpy(c->r->occupancy + at, s->occupancy, n);
    return 0;
}

static result run(const clvox_mesh *m, const clvox_grid *g, const clvox_voxelize_options *o)
{
    result r;
    memset(&r, 0, sizeof r);
    size_t n = nvox(g);
    r.element = calloc(n, sizeof *r.element);
    r.score = calloc(n, sizeof *r.score);
    r.coverage = calloc(n, sizeof *r.coverage);
    r.occupancy = calloc(n, 1);
    collect col = {g, &r, 0, 1, 0};
    r.stats.size = sizeof r.stats;
    r.status = clvox_voxelize_slabs(ctx, m, g, o, on_slab, &col, &r.stats);
    CHECK_MSG(r.status == CLVOX_OK, "%s", clvox_context_error(ctx));
    CHECK(col.order_ok && col.next_z == g->dims[2]);
    return r;
}

static void result_free(result *r)
{
    free(r->element);
    free(r->score);
    free(r->coverage);
    free(r->occupancy);
}

static int same(const result *a, const result *b, const clvox_grid *g)
{
    size_t n = nvox(g);
    const clvox_stats *s = &a->stats, *t = &b->stats;
    return memcmp(a->element, b->element, n * sizeof *a->element) == 0 &&
           memcmp(a->score, b->score, n * sizeof *a->score) == 0 &&
           memcmp(a->coverage, b->coverage, n * sizeof *a->coverage) == 0 &&
           memcmp(a->occupancy, b->occupancy, n) == 0 && s->filled_voxels == t->filled_voxels &&
           s->rays == t->rays && s->odd_parity_rays == t->odd_parity_rays && s->overflow_rays == t->overflow_rays &&
           s->max_crossings == t->max_crossings && s->coverage_sum == t->coverage_sum &&
           s->palette_early_voxels == t->palette_early_voxels &&
           s->palette_shortcut_voxels == t->palette_shortcut_voxels &&
           s->palette_scored_voxels == t->palette_scored_voxels &&
           s->palette_nonempty_voxels == t->palette_nonempty_voxels && s->palette_volume == t->palette_volume &&
           s->winding.exact_points == t->winding.exact_points;
}

/* Runs o with host rays and device rays, unbatched, and with the batch
 * sizes of `batches` (0-terminated; device rays): every result the same. */
static void compare_ways(const clvox_mesh *m, const clvox_grid *g, const clvox_voxelize_options *o,
                         const unsigned *batches, const char *what)
{
    set_hooks(1, 0);
    result ref = run(m, g, o);
    if (o->hit_capacity == 1 && o->oversample) CHECK_MSG(ref.stats.overflow_rays > 0, "%s: no overflow", what);
    set_hooks(0, 0);
    result dev = run(m, g, o);
    CHECK_MSG(same(&ref, &dev, g), "%s: device rays differ from host rays", what);
    result_free(&dev);
    for (size_t i = 0; batches && batches[i]; i++) {
        for (int host = 0; host <= 1; host++) {
            set_hooks(host, batches[i]);
            result b = run(m, g, o);
            CHECK_MSG(same(&ref, &b, g), "%s: %s rays, batches of %u items differ", what, host ? "host" : "device",
                      batches[i]);
            result_free(&b);
        }
    }
    set_hooks(0, 0);
    result_free(&ref);
}

static void test_runs(void)
{
    const double lo[3] = {0, 0, 0}, h[3] = {1.0 / 17, 1.0 / 13, 1.0 / 11};
    clvox_grid g = make_grid(lo, h, 17, 13, 11);
    tmesh t = tmesh_random_closed(7, 2, 3);
    clvox_mesh *m = to_mesh(ctx, &t);
    const uint32_t slabs[] = {0, 1, 3};
    const unsigned few[] = {5, 0};
    char what[160];
    int k = 0;
    for (uint32_t N = 2; N <= 5; N++)
        for (int axis = CLVOX_AXIS_X; axis <= CLVOX_AXIS_Z; axis++)
            for (int stochastic = 0; stochastic <= 1; stochastic++, k++) {
                clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
                o.ray_axis = (clvox_axis)axis;
                o.oversample = N;
                o.oversample_points = k % 2 ? N + 1 : (N > 2 ? N - 1 : 0);
                o.stochastic = stochastic;
                o.seed = stochastic ? 0x5eed0000ull + (uint64_t)k * 7919 : 0;
                o.slab_depth = slabs[k % 3];
                o.hit_capacity = k % 4 == 1 ? 1 : 0;
                o.channels = CLVOX_CHANNEL_OCCUPANCY | CLVOX_CHANNEL_COVERAGE;
                snprintf(what, sizeof what, "coverage N=%u M=%u axis %c %s slab %u capacity %u", N, o.oversample_points,
                         "?xyz"[axis], stochastic ? "stochastic" : "uniform", o.slab_depth, o.hit_capacity);
                compare_ways(m, &g, &o, k % 5 == 0 ? few : NULL, what);
            }
    /* overflow redo on every axis, uniform and stochastic */
    for (int axis = CLVOX_AXIS_X; axis <= CLVOX_AXIS_Z; axis++)
        for (int stochastic = 0; stochastic <= 1; stochastic++) {
            clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
            o.ray_axis = (clvox_axis)axis;
            o.oversample = 3;
            o.oversample_points = 2;
            o.stochastic = stochastic;
            o.seed = 99;
            o.slab_depth = 2;
            o.hit_capacity = 1;
            o.channels = CLVOX_CHANNEL_OCCUPANCY | CLVOX_CHANNEL_COVERAGE;
            snprintf(what, sizeof what, "coverage overflow axis %c %s", "?xyz"[axis], stochastic ? "stochastic" : "uniform");
            compare_ways(m, &g, &o, few, what);
        }
    /* palette: every axis, uniform (masks) and stochastic */
    clvox_palette *pal = NULL;
    CHECK_OK(ctx, clvox_palette_builtin(ctx, "paper46", &pal));
    for (int axis = CLVOX_AXIS_X; axis <= CLVOX_AXIS_Z; axis++)
        for (int stochastic = 0; stochastic <= 1; stochastic++) {
            clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
            o.ray_axis = (clvox_axis)axis;
            o.oversample = stochastic ? 3 : 4;
            o.oversample_points = stochastic ? 5 : 0;
            o.stochastic = stochastic;
            o.seed = 1234567;
            o.palette = pal;
            o.slab_depth = stochastic ? 0 : 2;
            o.hit_capacity = axis == CLVOX_AXIS_Y ? 1 : 0;
            o.channels = CLVOX_CHANNEL_ELEMENT | CLVOX_CHANNEL_SCORE | CLVOX_CHANNEL_COVERAGE | CLVOX_CHANNEL_OCCUPANCY;
            snprintf(what, sizeof what, "palette axis %c %s capacity %u", "?xyz"[axis],
                     stochastic ? "stochastic" : "uniform", o.hit_capacity);
            compare_ways(m, &g, &o, few, what);
        }
    clvox_palette_destroy(pal);
    clvox_mesh_destroy(m);
    tmesh_free(&t);
}

/* Slabs of 1..7 batches and many (CLVOX_BATCH_ITEMS): the same voxels and
 * stats, binary (parity and winding, every axis) and column runs. */
static void test_batches(void)
{
    const double lo[3] = {0, 0, 0}, h[3] = {1.0 / 23, 1.0 / 19, 1.0 / 21};
    clvox_grid g = make_grid(lo, h, 23, 19, 21);
    tmesh t = tmesh_random_closed(11, 2, 4);
    clvox_mesh *m = to_mesh(ctx, &t);
    char what[160];
    for (int axis = CLVOX_AXIS_X; axis <= CLVOX_AXIS_Z; axis++)
        for (int mode = 0; mode < 3; mode++) {
            clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
            o.ray_axis = (clvox_axis)axis;
            o.slab_depth = 3;
            o.inside = mode == 1 ? CLVOX_INSIDE_WINDING : CLVOX_INSIDE_PARITY;
            if (mode == 2) o.oversample = 2, o.stochastic = 1, o.seed = 77, o.hit_capacity = 2;
            o.channels = mode == 2 ? CLVOX_CHANNEL_OCCUPANCY | CLVOX_CHANNEL_COVERAGE : CLVOX_CHANNEL_OCCUPANCY;
            /* items a slab: rays (binary) or columns (coverage) */
            const unsigned items = axis == CLVOX_AXIS_X ? 19 * 3 : axis == CLVOX_AXIS_Y ? 23 * 3 : 23 * 19;
            unsigned batches[10] = {0};
            for (unsigned nb = 1; nb <= 7; nb++) batches[nb - 1] = (items + nb - 1) / nb;
            batches[7] = 1, batches[8] = 2;
            snprintf(what, sizeof what, "batches axis %c %s", "?xyz"[axis],
                     mode == 0 ? "parity" : mode == 1 ? "winding" : "coverage");
            compare_ways(m, &g, &o, batches, what);
        }
    clvox_mesh_destroy(m);
    tmesh_free(&t);
}

/* A cancel between the batches of a slab (CLVOX_BATCH_ITEMS: many): the
 * run stops with CLVOX_ERR_CANCELLED, asked within the slab (fraction < 1),
 * and the context runs again. */
typedef struct cancel_state {
    int polls;
    double fraction;
} cancel_state;

static int on_progress(void *user, double fraction)
{
    cancel_state *c = user;
    c->polls++;
    c->fraction = fraction;
    return 0; /* cancel */
}

static void test_cancel(void)
{
    const double lo[3] = {0, 0, 0}, h[3] = {1.0 / 23, 1.0 / 19, 1.0 / 21};
    clvox_grid g = make_grid(lo, h, 23, 19, 21);
    tmesh t = tmesh_random_closed(11, 2, 4);
    clvox_mesh *m = to_mesh(ctx, &t);
    const size_t n = nvox(&g);
    for (int mode = 0; mode < 3; mode++)
        for (unsigned items = 1; items <= 3; items++) {
            set_hooks(0, items);
            clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
            o.slab_depth = 21; /* one slab: the cancel comes between its batches */
            o.channels = CLVOX_CHANNEL_OCCUPANCY;
            if (mode == 1) o.oversample = 2;
            if (mode == 2) o.oversample = 3, o.hit_capacity = 1, o.stochastic = 1;
            cancel_state c = {0, 0};
            o.progress = on_progress;
            o.progress_user = &c;
            uint8_t *occ = calloc(n, 1);
            clvox_status st = clvox_voxelize_to_buffers(ctx, m, &g, &o, occ, n, NULL, 0, NULL);
            CHECK_MSG(st == CLVOX_ERR_CANCELLED && c.polls == 1 && c.fraction > 0 && c.fraction < 1,
                      "mode %d, batches of %u: status %d (%s), %d polls, fraction %g", mode, items, (int)st,
                      clvox_context_error(ctx), c.polls, c.fraction);
            set_hooks(0, 0);
            o.progress = NULL;
            CHECK_OK(ctx, clvox_voxelize_to_buffers(ctx, m, &g, &o, occ, n, NULL, 0, NULL));
            free(occ);
        }
    set_hooks(0, 0);
    clvox_mesh_destroy(m);
    tmesh_free(&t);
}

int main(void)
{
    ctx = test_context();
    test_direct();
    test_runs();
    test_batches();
    test_cancel();
    clvox_context_destroy(ctx);
    return test_report();
}
