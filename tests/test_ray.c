/* SPDX-License-Identifier: Apache-2.0 */
/* The ray method (Thon et al.) against exact answers, the CPU reference, and
 * itself (axes, slabs, overflow, determinism). */
#include "meshgen.h"
#include "reference.h"
#include "test.h"
#include "core/internal.h"

#include <math.h>
#include <string.h>

static clvox_context *ctx;

static clvox_mesh *to_mesh(const tmesh *t)
{
    clvox_mesh *m = NULL;
    clvox_status st = clvox_mesh_from_arrays(ctx, t->xyz, t->nv, t->tri, t->nt, &m);
    if (st != CLVOX_OK) {
        fprintf(stderr, "mesh_from_arrays: %s\n", clvox_context_error(ctx));
        return NULL;
    }
    return m;
}

static size_t nvox(const clvox_grid *g) { return (size_t)g->dims[0] * g->dims[1] * g->dims[2]; }

static uint64_t count(const uint8_t *v, size_t n)
{
    uint64_t c = 0;
    for (size_t i = 0; i < n; i++) c += v[i];
    return c;
}

/* Voxelizes with the given axis (and optional extra options); returns a malloc'ed volume. */
static uint8_t *run_opts(const clvox_mesh *m, const clvox_grid *g, const clvox_voxelize_options *o, clvox_stats *s)
{
    uint8_t *v = calloc(nvox(g), 1);
    clvox_stats local = CLVOX_STATS_INIT;
    CHECK_OK(ctx, clvox_voxelize_to_memory(ctx, m, g, o, v, nvox(g), s ? s : &local));
    return v;
}

static uint8_t *run_axis(const clvox_mesh *m, const clvox_grid *g, clvox_axis axis)
{
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    o.ray_axis = axis;
    return run_opts(m, g, &o, NULL);
}

/* Device result == CPU reference, for each axis. */
static void check_against_reference(const tmesh *t, const clvox_grid *g, const char *what)
{
    clvox_mesh *m = to_mesh(t);
    CHECK(m != NULL);
    if (!m) return;
    uint8_t *ref = malloc(nvox(g));
    for (clvox_axis a = CLVOX_AXIS_X; a <= CLVOX_AXIS_Z; a++) {
        ref_voxelize(t->xyz, t->nv, t->tri, t->nt, g, a, ref);
        uint8_t *dev = run_axis(m, g, a);
        size_t diff = 0;
        for (size_t i = 0; i < nvox(g); i++) diff += dev[i] != ref[i];
        CHECK_MSG(diff == 0, "%s axis %c: %zu of %zu voxels differ from the CPU reference", what, "?xyz"[a], diff,
                  nvox(g));
        free(dev);
    }
    free(ref);
    clvox_mesh_destroy(m);
}

/* Boxes whose corners sit exactly on voxel centres and column positions,
 * subdivided so rays pass exactly through edges and vertices. */
static void test_grid_aligned_boxes(void)
{
    double glo[3] = {0, 0, 0}, ghi[3] = {16, 16, 16};
    clvox_grid g = test_grid(glo, ghi, 16, 16, 16); /* h = 1, centres at k + 0.5 */
    struct { double lo[3], hi[3]; unsigned sub; } cases[] = {
        {{2, 3, 4}, {9, 7, 12}, 1},          /* faces between centres: exactly covers whole voxels */
        {{1.5, 2.5, 3.5}, {6.5, 9.5, 7.5}, 1}, /* faces through centres: edges/vertices on rays */
        {{1.5, 2.5, 3.5}, {6.5, 9.5, 7.5}, 5}, /* plus interior edges/vertices on rays */
        {{0.5, 0.5, 0.5}, {15.5, 15.5, 15.5}, 3},
        {{4.5, 4.5, 4.5}, {5.5, 5.5, 5.5}, 2}, /* one voxel centre inside, on the low corner */
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        tmesh t = tmesh_box_subdivided(cases[c].lo[0], cases[c].lo[1], cases[c].lo[2], cases[c].hi[0],
                                       cases[c].hi[1], cases[c].hi[2], cases[c].sub);
        clvox_mesh *m = to_mesh(&t);
        uint64_t want = expected_box_voxels(&g, cases[c].lo, cases[c].hi);
        for (clvox_axis a = CLVOX_AXIS_X; a <= CLVOX_AXIS_Z; a++) {
            clvox_stats s = CLVOX_STATS_INIT;
            clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
            o.ray_axis = a;
            uint8_t *v = run_opts(m, &g, &o, &s);
            uint64_t got = count(v, nvox(&g));
            CHECK_MSG(got == want, "box case %zu axis %c: %llu voxels, expected %llu", c, "?xyz"[a],
                      (unsigned long long)got, (unsigned long long)want);
            CHECK_MSG(s.filled_voxels == got, "stats.filled_voxels %llu != %llu", (unsigned long long)s.filled_voxels,
                      (unsigned long long)got);
            CHECK_MSG(s.odd_parity_rays == 0, "closed box gave %llu odd-parity rays",
                      (unsigned long long)s.odd_parity_rays);
            free(v);
        }
        check_against_reference(&t, &g, "grid-aligned box");
        clvox_mesh_destroy(m);
        tmesh_free(&t);
    }
}

/* Closed meshes in general position: bit-for-bit against the reference,
 * and the same occupancy for x, y and z rays. */
static void test_random_closed(void)
{
    double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    clvox_grid grids[] = {test_grid(lo, hi, 17, 17, 17), test_grid(lo, hi, 32, 20, 25), test_grid(lo, hi, 40, 40, 40)};
    for (uint64_t seed = 1; seed <= 6; seed++) {
        tmesh t = tmesh_random_closed(seed, 1 + (unsigned)(seed % 3), 2 + (unsigned)(seed % 4));
        const clvox_grid *g = &grids[seed % 3];
        char what[64];
        snprintf(what, sizeof what, "random closed mesh seed %llu", (unsigned long long)seed);
        check_against_reference(&t, g, what);
        clvox_mesh *m = to_mesh(&t);
        uint8_t *vx = run_axis(m, g, CLVOX_AXIS_X), *vy = run_axis(m, g, CLVOX_AXIS_Y), *vz = run_axis(m, g, CLVOX_AXIS_Z);
        CHECK_MSG(memcmp(vx, vy, nvox(g)) == 0 && memcmp(vx, vz, nvox(g)) == 0, "%s: x/y/z rays disagree", what);
        CHECK(count(vx, nvox(g)) > 0);
        free(vx);
        free(vy);
        free(vz);
        clvox_mesh_destroy(m);
        tmesh_free(&t);
    }
}

/* Analytic volumes: polyhedral sphere / torus / octahedron; cavity; two shells. */
static double filled_volume(const tmesh *t, uint32_t n, const double lo[3], const double hi[3], uint8_t **keep,
                            clvox_grid *gout)
{
    clvox_mesh *m = to_mesh(t);
    clvox_grid g = test_grid(lo, hi, n, n, n);
    uint8_t *v = run_axis(m, &g, CLVOX_AXIS_DEFAULT);
    double vol = (double)count(v, nvox(&g)) * g.voxel_size[0] * g.voxel_size[1] * g.voxel_size[2];
    if (keep) *keep = v; else free(v);
    if (gout) *gout = g;
    clvox_mesh_destroy(m);
    return vol;
}

static void test_shapes(void)
{
    double lo[3] = {-1.1, -1.1, -1.1}, hi[3] = {1.1, 1.1, 1.1};
    /* Torus: the error must shrink as N grows. */
    tmesh torus = tmesh_torus(0.013, -0.007, 0.021, 0.7, 0.3, 96, 48);
    double exact = tmesh_torus_poly_volume(0.7, 0.3, 96, 48);
    double e32 = fabs(filled_volume(&torus, 32, lo, hi, NULL, NULL) - exact) / exact;
    double e64 = fabs(filled_volume(&torus, 64, lo, hi, NULL, NULL) - exact) / exact;
    double e128 = fabs(filled_volume(&torus, 128, lo, hi, NULL, NULL) - exact) / exact;
    CHECK_MSG(e128 < 0.01 && e128 < e32, "torus volume error 32:%.4f 64:%.4f 128:%.4f", e32, e64, e128);
    tmesh_free(&torus);

    tmesh oct = tmesh_octahedron(0.0123, 0.0311, -0.0207, 1.0);
    double eo = fabs(filled_volume(&oct, 128, lo, hi, NULL, NULL) - 4.0 / 3.0) / (4.0 / 3.0);
    CHECK_MSG(eo < 0.01, "octahedron volume error %.4f", eo);
    tmesh_free(&oct);

    double a[3] = {-0.9, -0.8, -0.7}, b[3] = {0.95, -0.6, -0.5}, c[3] = {0.1, 0.9, -0.6}, d[3] = {0.05, 0.1, 0.93};
    tmesh tet = tmesh_tetra(a, b, c, d);
    double vt = tmesh_volume(&tet);
    double et = fabs(filled_volume(&tet, 128, lo, hi, NULL, NULL) - vt) / vt;
    CHECK_MSG(et < 0.02, "tetrahedron volume error %.4f", et);
    tmesh_free(&tet);

    /* Hollow sphere: the cavity stays empty, the volume is outer - inner. */
    tmesh hs = tmesh_hollow_sphere(0.011, 0.017, -0.013, 1.0, 0.6, 24);
    uint8_t *v;
    clvox_grid g;
    double vh = filled_volume(&hs, 96, lo, hi, &v, &g);
    double want = tmesh_sphere_poly_volume(1.0, 24) - tmesh_sphere_poly_volume(0.6, 24);
    CHECK_MSG(fabs(vh - want) / want < 0.02, "hollow sphere volume %.4f want %.4f", vh, want);
    size_t mid = ((size_t)48 * 96 + 48) * 96 + 48;
    CHECK_MSG(v[mid] == 0, "cavity centre is filled");
    uint64_t cavity = 0;
    for (uint32_t k = 0; k < 96; k++)
        for (uint32_t j = 0; j < 96; j++)
            for (uint32_t i = 0; i < 96; i++) {
                double x = g.origin[0] + (i + 0.5) * g.voxel_size[0] - 0.011;
                double y = g.origin[1] + (j + 0.5) * g.voxel_size[1] - 0.017;
                double z = g.origin[2] + (k + 0.5) * g.voxel_size[2] + 0.013;
                if (x * x + y * y + z * z < 0.5 * 0.5) cavity += v[((size_t)k * 96 + j) * 96 + i];
            }
    CHECK_MSG(cavity == 0, "%llu voxels filled well inside the cavity", (unsigned long long)cavity);
    free(v);
    tmesh_free(&hs);

    /* Two disjoint shells: volumes add up. */
    tmesh s1 = tmesh_sphere(-0.5, 0.01, 0.02, 0.45, 20), s2 = tmesh_sphere(0.52, -0.03, 0.01, 0.4, 20);
    double v1 = filled_volume(&s1, 96, lo, hi, NULL, NULL), v2 = filled_volume(&s2, 96, lo, hi, NULL, NULL);
    tmesh_append(&s1, &s2);
    double v12 = filled_volume(&s1, 96, lo, hi, NULL, NULL);
    CHECK_MSG(fabs(v12 - (v1 + v2)) < 1e-12, "two shells %.6f != %.6f + %.6f", v12, v1, v2);
    tmesh_free(&s1);
    tmesh_free(&s2);
}

/* Rays with more crossings than the fast buffer are redone, not truncated. */
static void test_overflow_and_slabs(void)
{
    tmesh t = tmesh_random_closed(42, 6, 3);
    double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    clvox_grid g = test_grid(lo, hi, 48, 40, 36);
    clvox_mesh *m = to_mesh(&t);
    clvox_stats s0 = CLVOX_STATS_INIT, s1 = CLVOX_STATS_INIT;
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    uint8_t *base = run_opts(m, &g, &o, &s0);
    CHECK(s0.overflow_rays == 0);
    CHECK(s0.max_crossings >= 4);
    o.hit_capacity = 2;
    uint8_t *small = run_opts(m, &g, &o, &s1);
    CHECK_MSG(s1.overflow_rays > 0, "capacity 2 should overflow (max crossings %u)", s1.max_crossings);
    CHECK_MSG(memcmp(base, small, nvox(&g)) == 0, "overflow redo changed the result");
    CHECK(s1.filled_voxels == s0.filled_voxels);
    for (clvox_axis a = CLVOX_AXIS_X; a <= CLVOX_AXIS_Z; a++)
        for (uint32_t depth = 1; depth <= 7; depth += 3) {
            clvox_voxelize_options os = CLVOX_VOXELIZE_OPTIONS_INIT;
            os.ray_axis = a;
            os.slab_depth = depth;
            os.hit_capacity = depth == 4 ? 3 : 0;
            os.quadtree_max_depth = depth;
            os.quadtree_leaf_size = depth;
            uint8_t *v = run_opts(m, &g, &os, NULL);
            CHECK_MSG(memcmp(base, v, nvox(&g)) == 0, "axis %c slab depth %u differs", "?xyz"[a], depth);
            free(v);
        }
    /* Determinism. */
    uint8_t *again = run_opts(m, &g, &o, NULL);
    CHECK(memcmp(small, again, nvox(&g)) == 0);
    free(again);
    free(base);
    free(small);
    clvox_mesh_destroy(m);
    tmesh_free(&t);
}

/* An open mesh is reported through odd-parity rays. */
static void test_open_mesh(void)
{
    tmesh t = tmesh_box(0.2, 0.2, 0.2, 0.8, 0.8, 0.8);
    t.nt -= 2; /* drop one face */
    clvox_mesh *m = to_mesh(&t);
    double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    clvox_grid g = test_grid(lo, hi, 20, 20, 20);
    CHECK(clvox_mesh_get_report(m)->closed == 0);
    /* Only rays along the missing face's normal cross the hole; the others run parallel to it. */
    int seen = 0;
    for (clvox_axis a = CLVOX_AXIS_X; a <= CLVOX_AXIS_Z; a++) {
        clvox_stats s = CLVOX_STATS_INIT;
        clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
        o.ray_axis = a;
        o.inside = CLVOX_INSIDE_PARITY; /* winding closes the hole with a cap */
        uint8_t *v = run_opts(m, &g, &o, &s);
        seen += s.odd_parity_rays > 0;
        free(v);
    }
    CHECK_MSG(seen == 1, "open box: odd-parity rays on %d axes, expected exactly 1", seen);
    clvox_mesh_destroy(m);
    tmesh_free(&t);
}

/* The grid seen through the public grid API. */
static void test_grid_api(void)
{
    clvox_grid g;
    clvox_grid_options o = CLVOX_GRID_OPTIONS_INIT;
    double lo[3] = {0, 0, 0}, hi[3] = {2.0, 1.0, 0.3};
    o.resolution = 100;
    CHECK_OK(ctx, clvox_grid_compute(ctx, &o, lo, hi, &g));
    CHECK(g.dims[0] == 100 && g.dims[1] == 50 && g.dims[2] == 15);
    CHECK(g.voxel_size[0] == 0.02 && g.origin[0] == 0.0);
    double hi2[3] = {1.0, 1.0, 1.0};
    o.resolution = 7;
    CHECK_OK(ctx, clvox_grid_compute(ctx, &o, lo, hi2, &g));
    CHECK(g.dims[0] == 7 && g.dims[1] == 7 && g.dims[2] == 7);
    o.padding = 2;
    CHECK_OK(ctx, clvox_grid_compute(ctx, &o, lo, hi2, &g));
    CHECK(g.dims[0] == 11 && fabs(g.origin[1] + 2.0 / 7) < 1e-15);
    o = (clvox_grid_options)CLVOX_GRID_OPTIONS_INIT;
    o.dims[0] = 4; o.dims[1] = 5; o.dims[2] = 6;
    CHECK_OK(ctx, clvox_grid_compute(ctx, &o, lo, hi, &g));
    CHECK(g.dims[2] == 6 && fabs(g.voxel_size[2] - 0.05) < 1e-15);
    o = (clvox_grid_options)CLVOX_GRID_OPTIONS_INIT;
    o.voxel_size[0] = 0.1;
    CHECK_OK(ctx, clvox_grid_compute(ctx, &o, lo, hi, &g));
    CHECK(g.dims[0] == 20 && g.dims[1] == 10 && g.dims[2] == 3);
    o = (clvox_grid_options)CLVOX_GRID_OPTIONS_INIT;
    o.resolution = 70000;
    CHECK_STATUS(ctx, clvox_grid_compute(ctx, &o, lo, hi2, &g), CLVOX_ERR_GRID);
    o.resolution = 65536; /* 2^48 voxels: over the total limit */
    CHECK_STATUS(ctx, clvox_grid_compute(ctx, &o, lo, hi2, &g), CLVOX_ERR_GRID);
    o.resolution = 10;
    o.dims[0] = 3;
    CHECK_STATUS(ctx, clvox_grid_compute(ctx, &o, lo, hi2, &g), CLVOX_ERR_GRID);
    o = (clvox_grid_options)CLVOX_GRID_OPTIONS_INIT;
    o.dims[0] = 3; o.dims[1] = 0; o.dims[2] = 3;
    CHECK_STATUS(ctx, clvox_grid_compute(ctx, &o, lo, hi2, &g), CLVOX_ERR_GRID);
    o = (clvox_grid_options)CLVOX_GRID_OPTIONS_INIT;
    o.voxel_size[0] = -1;
    CHECK_STATUS(ctx, clvox_grid_compute(ctx, &o, lo, hi2, &g), CLVOX_ERR_GRID);
    double flat[3] = {1, 1, 0};
    o = (clvox_grid_options)CLVOX_GRID_OPTIONS_INIT;
    o.resolution = 8;
    CHECK_OK(ctx, clvox_grid_compute(ctx, &o, lo, flat, &g));
    CHECK(g.dims[2] == 1);
}

/* Many crossings per ray: nested boxes (each ray through the middle crosses
 * 2 faces per box) give lists far longer than the private sort buffer; the
 * heap sort must order them exactly (the CPU reference), in the fast pass
 * (large capacity) and in the overflow redo (default capacity). */
static void test_long_crossing_lists(void)
{
    tmesh t = {0};
    for (int k = 0; k < 90; k++) {
        double e = 0.005 * k;
        tmesh b = tmesh_box(0.05 + e, 0.05 + e * 0.9, 0.05 + e * 0.8, 0.95 - e * 0.7, 0.95 - e, 0.95 - e * 0.6);
        if (k & 1) tmesh_flip(&b);
        tmesh_append(&t, &b);
        tmesh_free(&b);
    }
    double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    clvox_grid g = test_grid(lo, hi, 29, 23, 19);
    clvox_mesh *m = to_mesh(&t);
    uint8_t *ref = malloc(nvox(&g));
    ref_voxelize(t.xyz, t.nv, t.tri, t.nt, &g, CLVOX_AXIS_X, ref);
    const uint32_t caps[2] = {512, 0};
    for (int i = 0; i < 2; i++) {
        clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
        o.hit_capacity = caps[i];
        clvox_stats s = CLVOX_STATS_INIT;
        uint8_t *v = run_opts(m, &g, &o, &s);
        CHECK_MSG(memcmp(v, ref, nvox(&g)) == 0, "nested boxes, capacity %u: differs from the reference", caps[i]);
        CHECK_MSG(s.max_crossings == 180 && (caps[i] ? s.overflow_rays == 0 : s.overflow_rays > 0),
                  "max crossings %u, overflow %llu", s.max_crossings, (unsigned long long)s.overflow_rays);
        free(v);
    }
    free(ref);
    clvox_mesh_destroy(m);
    tmesh_free(&t);
}

/* A closed box repeated `copies` times (coincident surfaces). */
static tmesh repeated_box(unsigned copies)
{
    tmesh one = tmesh_box(0.1, 0.2, 0.15, 0.9, 0.8, 0.85), t = {0};
    for (unsigned c = 0; c < copies; c++) tmesh_append(&t, &one);
    tmesh_free(&one);
    return t;
}

static int cancel_calls, saw_partial;
static double first_partial_cpu; /* test_cpu_seconds() at the first partial progress call */

static int note_partial(void *user, double f)
{
    (void)user;
    if (f < 1.0 && first_partial_cpu == 0) first_partial_cpu = test_cpu_seconds();
    return 1;
}

static int cancel_on_partial(void *user, double f)
{
    (void)user;
    if (f < 1.0 && first_partial_cpu == 0) first_partial_cpu = test_cpu_seconds();
    cancel_calls++;
    if (f < 1.0) saw_partial = 1;
    return f >= 1.0; /* stop at the first call inside the (only) slab */
}

/* Coincident copies: a clear error past CLVOX__MAX_CROSSINGS crossings per
 * ray (not minutes of sorting or gigabytes of buffers), the quadtree does
 * not multiply its references, and a slow slab is cancelled within a
 * fraction of a second. */
static void test_coincident_surfaces(void)
{
    double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    clvox_grid g8 = test_grid(lo, hi, 8, 8, 8);
    /* 32769 copies: 65538 crossings per ray through the box, one more than allowed */
    tmesh big = repeated_box(32769);
    clvox_mesh *m = to_mesh(&big);
    uint8_t v[512];
    double t0 = test_cpu_seconds(); /* CPU seconds: see the cancel below */
    CHECK_STATUS(ctx, clvox_voxelize_to_memory(ctx, m, &g8, NULL, v, sizeof v, NULL), CLVOX_ERR_MESH_INVALID);
    CHECK(strstr(clvox_context_error(ctx), "coincident") != NULL);
    CHECK_MSG(test_cpu_seconds() - t0 < 10.0, "the refusal took %.1f s of CPU", test_cpu_seconds() - t0);
    clvox_mesh_destroy(m);
    tmesh_free(&big);

    /* 30000 copies: allowed; the copies cancel (parity): empty, in bounded time and memory */
    tmesh ok = repeated_box(30000);
    m = to_mesh(&ok);
    clvox_stats s = CLVOX_STATS_INIT;
    t0 = test_cpu_seconds();
    clvox_voxelize_options par = CLVOX_VOXELIZE_OPTIONS_INIT;
    par.inside = CLVOX_INSIDE_PARITY;
    CHECK_OK(ctx, clvox_voxelize_to_memory(ctx, m, &g8, &par, v, sizeof v, &s));
    CHECK(count(v, sizeof v) == 0 && s.max_crossings == 60000 && s.overflow_rays > 0);
    CHECK_MSG(test_cpu_seconds() - t0 < 10.0, "30000 coincident boxes took %.1f s of CPU", test_cpu_seconds() - t0);
    /* references: no split multiplies them (was 4x per level) */
    clvox_grid g256 = test_grid(lo, hi, 256, 256, 1);
    uint8_t *w = malloc(nvox(&g256));
    CHECK_OK(ctx, clvox_voxelize_to_memory(ctx, m, &g256, NULL, w, nvox(&g256), &s));
    CHECK_MSG(s.quadtree_refs <= 8 * ok.nt, "%llu quadtree references for %zu triangles",
              (unsigned long long)s.quadtree_refs, ok.nt);
    free(w);
    clvox_mesh_destroy(m);
    tmesh_free(&ok);

    /* cancel inside one slow slab: 2000 copies at 160^2 rays, one slab. The
     * run must stop inside the slab: one progress call (the partial one that
     * asked to stop), and after it a small part of the CPU time that the rest
     * of the slab costs from the same point when it is not cancelled
     * (measured here, same machine). CPU time, not wall time: a loaded
     * machine stretches the wall clock (a 1.5 s wall bound failed at 1.71 s
     * under load), not the work this process does. */
    tmesh slow = repeated_box(2000);
    m = to_mesh(&slow);
    clvox_grid g = test_grid(lo, hi, 160, 160, 40);
    uint8_t *big_v = malloc(nvox(&g));
    for (int method = CLVOX_METHOD_RAY; method <= CLVOX_METHOD_TETRA; method++) {
        clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
        o.method = (clvox_method)method;
        o.slab_depth = 40;
        o.progress = note_partial;
        first_partial_cpu = 0;
        CHECK_OK(ctx, clvox_voxelize_to_memory(ctx, m, &g, &o, big_v, nvox(&g), NULL));
        double rest = test_cpu_seconds() - first_partial_cpu;
        CHECK_MSG(first_partial_cpu > 0, "method %d: no partial progress call", method);
        o.progress = cancel_on_partial;
        cancel_calls = saw_partial = 0;
        first_partial_cpu = 0;
        CHECK_STATUS(ctx, clvox_voxelize_to_memory(ctx, m, &g, &o, big_v, nvox(&g), NULL), CLVOX_ERR_CANCELLED);
        double took = test_cpu_seconds() - first_partial_cpu;
        CHECK_MSG(saw_partial && cancel_calls == 1, "method %d: progress calls %d, partial %d", method,
                  cancel_calls, saw_partial);
        CHECK_MSG(took < 0.25 * rest, "method %d: %.2f s of CPU after the cancel, the rest of the slab %.2f s", method,
                  took, rest);
        printf("coincident surfaces, %s: cancel honoured after %.3f s of CPU (the rest of the slab: %.2f s)\n",
               method ? "tetra" : "ray", took, rest);
    }
    free(big_v);
    clvox_mesh_destroy(m);
    tmesh_free(&slow);
}

int main(void)
{
    ctx = test_context();
    test_grid_api();
    test_grid_aligned_boxes();
    test_random_closed();
    test_shapes();
    test_overflow_and_slabs();
    test_open_mesh();
    test_long_crossing_lists();
    test_coincident_surfaces();
    clvox_context_destroy(ctx);
    return test_report();
}
