/* SPDX-License-Identifier: Apache-2.0 */
/* Past 800 lines on purpose: one test program per consumer: the CPU oracle and
 * every device case share the generated meshes. */
/* The winding-number inside test (issue 9, docs/design.md "Winding
 * numbers"): the CPU oracle against itself and closed forms, then the
 * device through the public API against the oracle, voxel for voxel, on a
 * corpus of open, cracked, mis-oriented, overlapping and non-manifold
 * meshes; invariants (axis, slab, device); closed meshes bit-identical to
 * parity; unions; cavities; coverage samples; options and the report.
 *
 * `test_winding oracle` runs only the CPU part (no OpenCL context).
 *
 * What the oracle is compared with: the device's result is w(p) of the mesh
 * AFTER preparation (vertices merged or welded, orientation repaired). For
 * meshes whose triangles are consistently oriented the preparation changes
 * no triangle's orientation, so the oracle evaluates the mesh as given; for
 * mis-oriented ones (random flips, wholly inverted, nested shells stored the
 * wrong way) it evaluates the repaired mesh the generator knows ("truth");
 * the Moebius strip has no orientation to repair to and only the
 * invariants are checked. */
#include "meshgen.h"
#include "reference.h"
#include "test.h"
#include "cast/winding_classify.h" /* src/: the lattice (internal) */
#include "winding/winding.h" /* src/: the cap tree (internal) */

#include <math.h>
#include <string.h>
#include <unistd.h>

#define PI 3.14159265358979323846
/* Oracle values this close to 1/2 are not compared: which side they land
 * on is within the rounding of two different exact evaluations. */
#define NEAR_HALF 1e-7

static clvox_context *ctx;

static size_t nvox(const clvox_grid *g) { return (size_t)g->dims[0] * g->dims[1] * g->dims[2]; }

static uint64_t count(const uint8_t *v, size_t n)
{
    uint64_t c = 0;
    for (size_t i = 0; i < n; i++) c += v[i];
    return c;
}

/* ================= the oracle alone (CPU) ================= */

static double *to_double(const tmesh *m)
{
    double *q = malloc((m->nv ? m->nv : 1) * 3 * sizeof *q);
    if (!q) abort();
    for (size_t i = 0; i < 3 * m->nv; i++) q[i] = m->xyz[i];
    return q;
}

static double wn(const tmesh *m, double x, double y, double z)
{
    double p[3] = {x, y, z};
    return ref_winding_number(m->xyz, m->nv, m->tri, m->nt, p);
}

static void test_oracle_closed_forms(void)
{
    /* closed sphere: 1 inside, 0 outside; inverted: -1 */
    tmesh s = tmesh_sphere(0.1, -0.2, 0.3, 1.0, 16);
    double in = wn(&s, 0.3, -0.1, 0.2), out = wn(&s, 1.7, 0.4, -0.5);
    CHECK_MSG(fabs(in - 1) < 1e-12 && fabs(out) < 1e-12, "sphere: w inside %.17g, outside %.17g", in, out);
    tmesh_flip(&s);
    double inv = wn(&s, 0.3, -0.1, 0.2);
    CHECK_MSG(fabs(inv + 1) < 1e-12, "inverted sphere: w inside %.17g", inv);
    tmesh_flip(&s);

    /* two overlapping spheres: 2 in the overlap, 1 in one only */
    tmesh two = tmesh_copy(&s), b = tmesh_sphere(0.9, -0.2, 0.3, 1.0, 16);
    tmesh_append(&two, &b);
    double w2 = wn(&two, 0.5, -0.2, 0.3), w1 = wn(&two, -0.6, -0.2, 0.3);
    CHECK_MSG(fabs(w2 - 2) < 1e-12 && fabs(w1 - 1) < 1e-12, "overlapping spheres: %.17g (overlap), %.17g", w2, w1);
    tmesh_free(&two);
    tmesh_free(&b);
    tmesh_free(&s);

    /* cube missing one face: 5/6 at its centre (each face subtends 4pi/6) */
    double lo[3] = {-1, -1, -1}, hi[3] = {1, 1, 1};
    for (unsigned n = 1; n <= 3; n++) {
        unsigned mask = 0;
        tmesh ob = tmesh_open_box(n, lo, hi, n, 1, &mask);
        double w = wn(&ob, 0, 0, 0);
        CHECK_MSG(fabs(w - 5.0 / 6.0) < 1e-14, "open cube (n %u, faces %#x): w(centre) = %.17g", n, mask, w);
        tmesh_free(&ob);
    }
    unsigned mask3 = 0;
    tmesh ob3 = tmesh_open_box(9, lo, hi, 2, 3, &mask3);
    double w3 = wn(&ob3, 0, 0, 0);
    CHECK_MSG(fabs(w3 - 0.5) < 1e-14, "cube without 3 faces: w(centre) = %.17g", w3);
    tmesh_free(&ob3);

    /* a square [-a,a]^2 at z = 0, normal +z, from (0, 0, d): -Omega/4pi in
     * front, +Omega/4pi behind, Omega = 4 asin(a^2 / (a^2 + d^2)) */
    const double a = 0.75; /* exact in float */
    tmesh sq = {0};
    tmesh_add_vertex(&sq, -a, -a, 0);
    tmesh_add_vertex(&sq, a, -a, 0);
    tmesh_add_vertex(&sq, a, a, 0);
    tmesh_add_vertex(&sq, -a, a, 0);
    tmesh_add_tri(&sq, 0, 1, 2);
    tmesh_add_tri(&sq, 0, 2, 3);
    const double ds[4] = {0.01, 0.3, 1.0, 25.0};
    for (int i = 0; i < 4; i++) {
        double om = 4 * asin(a * a / (a * a + ds[i] * ds[i])) / (4 * PI);
        double f = wn(&sq, 0, 0, ds[i]), k = wn(&sq, 0, 0, -ds[i]);
        CHECK_MSG(fabs(f + om) < 1e-13 && fabs(k - om) < 1e-13, "square at d %g: %.17g / %.17g, want -/+%.17g",
                  ds[i], f, k, om);
    }
    tmesh_free(&sq);

    /* open hemisphere: w jumps by 1 across the shell (just inside > 1/2,
     * just outside < 0); at the centre 1/2 by symmetry */
    tmesh hs = tmesh_open_hemisphere(0, 0, 0, 1.0, 24);
    double wc = wn(&hs, 0, 0, 0), wi = wn(&hs, 0.96 * 0.6, 0, 0.96 * 0.8), wo = wn(&hs, 1.01 * 0.6, 0, 1.01 * 0.8);
    CHECK_MSG(fabs(wc - 0.5) < 1e-12 && wi > 0.5 && wo < 0 && fabs(wi - wo - 1) < 0.02,
              "hemisphere: centre %.17g, inside %.6f, outside %.6f", wc, wi, wo);
    tmesh_free(&hs);
}

/* Random points around each mesh: the solid-angle sum and the
 * crossings-plus-strips formula agree to 1e-9. */
static void cross_check(const char *what, const tmesh *m, uint64_t seed, unsigned points)
{
    double lo[3] = {1e30, 1e30, 1e30}, hi[3] = {-1e30, -1e30, -1e30};
    for (size_t i = 0; i < m->nv; i++)
        for (int k = 0; k < 3; k++) lo[k] = fmin(lo[k], m->xyz[3 * i + k]), hi[k] = fmax(hi[k], m->xyz[3 * i + k]);
    double *q = to_double(m);
    uint64_t s = seed;
    unsigned bad = 0;
    double worst = 0;
    for (unsigned i = 0; i < points; i++) {
        double p[3];
        for (int k = 0; k < 3; k++) {
            double e = hi[k] - lo[k];
            p[k] = lo[k] - 0.15 * e + 1.3 * e * tmesh_rng_uniform(&s);
        }
        double w1 = ref_winding_number_d(q, m->nv, m->tri, m->nt, p);
        double w2 = ref_winding_number_rays(q, m->nv, m->tri, m->nt, p);
        double d = fabs(w1 - w2);
        if (d > worst) worst = d;
        if (!(d < 1e-9)) {
            if (bad++ < 3)
                fprintf(stderr, "  %s at (%.9g %.9g %.9g): sum %.17g, rays %.17g\n", what, p[0], p[1], p[2], w1, w2);
        }
    }
    CHECK_MSG(bad == 0, "%s: the two formulas differ at %u of %u points", what, bad, points);
    printf("oracle cross-check %-22s %u points, largest difference %.2e\n", what, points, worst);
    free(q);
}

static void test_oracle_two_formulas(void)
{
    double lo[3] = {0.13, 0.17, 0.11}, hi[3] = {0.86, 0.79, 0.91};
    tmesh ms[12];
    const char *names[12] = {"open box", "open box 3 faces", "hemisphere", "open cylinder", "sphere with holes",
                             "flipped faces", "shifted shells", "cad union", "moebius", "membrane",
                             "cracked box", "soup"};
    ms[0] = tmesh_open_box(1, lo, hi, 3, 1, NULL);
    ms[1] = tmesh_open_box(2, lo, hi, 2, 3, NULL);
    ms[2] = tmesh_open_hemisphere(0.5, 0.5, 0.5, 0.4, 12);
    double cc[3] = {0.5, 0.48, 0.12};
    ms[3] = tmesh_cylinder(cc, 2, 0.35, 0.75, 24, 3, 0);
    ms[4] = tmesh_sphere_holes(3, 0.5, 0.5, 0.5, 0.4, 10, 9);
    ms[5] = tmesh_sphere_flipped(5, 0.5, 0.5, 0.5, 0.4, 10, 15);
    ms[6] = tmesh_shifted_shells(0.45, 0.47, 0.49, 0.3, 10, 0.12);
    ms[7] = tmesh_cad_union(11);
    ms[8] = tmesh_moebius(0.5, 0.5, 0.5, 0.3, 0.1, 48, 4);
    ms[9] = tmesh_sphere_membrane(0.5, 0.5, 0.5, 0.4, 10);
    ms[10] = tmesh_cracked_box(7, lo, hi, 1e-5);
    tmesh sp = tmesh_sphere(0.5, 0.5, 0.5, 0.4, 8);
    ms[11] = tmesh_soup(&sp);
    tmesh_free(&sp);
    for (int i = 0; i < 12; i++) {
        cross_check(names[i], &ms[i], 100 + (uint64_t)i, 300);
        tmesh_free(&ms[i]);
    }
}

/* The generators are what they claim (edges, orientation). */
static void test_corpus_shapes(void)
{
    uint64_t bnd, nm, conf;
    double lo[3] = {0.13, 0.17, 0.11}, hi[3] = {0.86, 0.79, 0.91};
    tmesh ob = tmesh_open_box(1, lo, hi, 3, 1, NULL);
    tmesh_edge_stats(&ob, &bnd, &nm, &conf);
    CHECK_MSG(bnd == 12 && nm == 0 && conf == 0, "open box: %llu boundary, %llu nm, %llu conflicts",
              (unsigned long long)bnd, (unsigned long long)nm, (unsigned long long)conf);
    tmesh_free(&ob);
    tmesh fl = tmesh_sphere_flipped(5, 0.5, 0.5, 0.5, 0.4, 10, 15);
    tmesh_edge_stats(&fl, &bnd, &nm, &conf);
    CHECK(bnd == 0 && nm == 0 && conf > 0);
    tmesh_free(&fl);
    tmesh mo = tmesh_moebius(0.5, 0.5, 0.5, 0.3, 0.1, 48, 4);
    tmesh_edge_stats(&mo, &bnd, &nm, &conf);
    CHECK_MSG(bnd == 2 * 48 && nm == 0 && conf > 0, "moebius: %llu boundary, %llu conflicts", (unsigned long long)bnd,
              (unsigned long long)conf);
    tmesh_free(&mo);
    tmesh mb = tmesh_sphere_membrane(0.5, 0.5, 0.5, 0.4, 10);
    tmesh_edge_stats(&mb, &bnd, &nm, &conf);
    CHECK_MSG(bnd == 0 && nm == 20 && conf == 20, "membrane: %llu boundary, %llu non-manifold, %llu conflicts",
              (unsigned long long)bnd, (unsigned long long)nm, (unsigned long long)conf);
    tmesh_free(&mb);
    tmesh cad = tmesh_cad_union(11);
    CHECK(tmesh_is_closed(&cad));
    tmesh_free(&cad);
    tmesh cyl = tmesh_cylinder(lo, 1, 0.2, 0.5, 16, 2, 1);
    double want = 16 * 0.5 * 0.2 * 0.2 * sin(2 * PI / 16) * 0.5;
    CHECK_MSG(tmesh_is_closed(&cyl) && fabs(tmesh_volume(&cyl) - want) < 1e-6, "cylinder volume %.9f want %.9f",
              tmesh_volume(&cyl), want);
    tmesh_free(&cyl);
    tmesh cb = tmesh_cracked_box(7, lo, hi, 1e-5);
    CHECK(cb.nv == 24 && cb.nt == 12);
    tmesh_free(&cb);
}

/* The voxel oracle on an isotropic and an anisotropic grid: the centres of
 * a closed sphere agree with an independent ray-parity point test wherever
 * they are not within rounding of the surface. */
static void test_oracle_voxelize(void)
{
    tmesh s = tmesh_sphere(0.51, 0.47, 0.53, 0.37, 12);
    double lo[3] = {0.013, -0.021, 0.007}, hi[3] = {1.031, 0.993, 1.017};
    clvox_grid gs[2] = {test_grid(lo, hi, 20, 20, 20), test_grid(lo, hi, 24, 17, 13)};
    for (int i = 0; i < 2; i++) {
        clvox_grid *g = &gs[i];
        uint8_t *v = malloc(nvox(g));
        double *w = malloc(nvox(g) * sizeof *w);
        ref_winding_voxelize(s.xyz, s.nv, s.tri, s.nt, g, 0, v, w);
        size_t diff = 0, at = 0, notint = 0;
        for (uint32_t k = 0; k < g->dims[2]; k++)
            for (uint32_t j = 0; j < g->dims[1]; j++)
                for (uint32_t x = 0; x < g->dims[0]; x++, at++) {
                    double p[3] = {g->origin[0] + (x + 0.5) * g->voxel_size[0], g->origin[1] + (j + 0.5) * g->voxel_size[1],
                                   g->origin[2] + (k + 0.5) * g->voxel_size[2]};
                    diff += v[at] != tmesh_point_inside(&s, p);
                    notint += fabs(w[at] - round(w[at])) > 1e-9;
                }
        CHECK_MSG(diff == 0 && notint == 0, "sphere grid %d: %zu centres differ from the point test, %zu not integer",
                  i, diff, notint);
        free(v);
        free(w);
    }
    tmesh_free(&s);
}

/* The fast voxel oracle (crossings with the library's tie rule + strips)
 * equals the brute-force one on an anisotropic grid. */
static void test_oracle_fast_voxelize(void)
{
    double lo[3] = {-0.017, -0.023, -0.011}, hi[3] = {1.019, 1.013, 1.027};
    clvox_grid g = test_grid(lo, hi, 30, 22, 17);
    double blo[3] = {0.13, 0.17, 0.11}, bhi[3] = {0.86, 0.79, 0.91}, cc[3] = {0.5, 0.48, 0.12};
    tmesh sp = tmesh_sphere(0.5, 0.49, 0.52, 0.4, 10);
    tmesh ms[7] = {tmesh_open_box(2, blo, bhi, 2, 3, NULL), tmesh_cylinder(cc, 2, 0.35, 0.75, 24, 3, 0),
                   tmesh_sphere_holes(3, 0.5, 0.49, 0.52, 0.4, 10, 9), tmesh_moebius(0.5, 0.5, 0.5, 0.3, 0.12, 48, 4),
                   tmesh_cad_union(11), tmesh_cracked_box(7, blo, bhi, 1e-5), tmesh_soup(&sp)};
    const char *names[7] = {"open box", "open cylinder", "sphere with holes", "moebius", "cad union", "cracked box",
                            "soup"};
    size_t n = nvox(&g);
    uint8_t *a = malloc(n), *b = malloc(n);
    double *wa = malloc(n * sizeof *wa), *wb = malloc(n * sizeof *wb);
    for (int i = 0; i < 7; i++) {
        ref_winding_voxelize(ms[i].xyz, ms[i].nv, ms[i].tri, ms[i].nt, &g, 0, a, wa);
        size_t nb = ref_winding_voxelize_rays(ms[i].xyz, ms[i].nv, ms[i].tri, ms[i].nt, &g, 0, b, wb);
        size_t diff = 0;
        double worst = 0;
        for (size_t k = 0; k < n; k++) {
            diff += a[k] != b[k];
            worst = fmax(worst, fabs(wa[k] - wb[k]));
        }
        CHECK_MSG(diff == 0 && worst < 1e-9, "%s: fast oracle differs on %zu voxels (largest |dw| %.3g)", names[i],
                  diff, worst);
        printf("oracle fast voxels    %-18s %zu boundary edges, largest difference %.2e\n", names[i], nb, worst);
        tmesh_free(&ms[i]);
    }
    tmesh_free(&sp);
    free(a);
    free(b);
    free(wa);
    free(wb);
}

/* ================= the corpus (tmesh_winding_corpus) ================= */

#define MAX_CASES 32
static tmesh_case cases[MAX_CASES];
static size_t ncases;

/* ================= the device ================= */

static clvox_mesh *to_mesh_in(clvox_context *c, const tmesh *t)
{
    clvox_mesh *m = NULL;
    if (clvox_mesh_from_arrays(c, t->xyz, t->nv, t->tri, t->nt, &m) != CLVOX_OK) {
        fprintf(stderr, "mesh_from_arrays: %s\n", clvox_context_error(c));
        return NULL;
    }
    return m;
}
static clvox_mesh *to_mesh(const tmesh *t) { return to_mesh_in(ctx, t); }

static uint8_t *run_in(clvox_context *c, const clvox_mesh *m, const clvox_grid *g, const clvox_voxelize_options *o,
                       clvox_stats *s, clvox_status *st)
{
    uint8_t *v = calloc(nvox(g), 1);
    clvox_stats local = CLVOX_STATS_INIT;
    clvox_status r = clvox_voxelize_to_memory(c, m, g, o, v, nvox(g), s ? s : &local);
    if (st) *st = r;
    return v;
}

/* Runs and CHECKs the status. */
static uint8_t *run(const clvox_mesh *m, const clvox_grid *g, const clvox_voxelize_options *o, clvox_stats *s)
{
    clvox_status st;
    uint8_t *v = run_in(ctx, m, g, o, s, &st);
    CHECK_MSG(st == CLVOX_OK, "voxelize: %s: %s", clvox_status_string(st), clvox_context_error(ctx));
    return v;
}

static uint8_t *run_inside(const clvox_mesh *m, const clvox_grid *g, clvox_inside inside, clvox_stats *s)
{
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    o.inside = inside;
    return run(m, g, &o, s);
}

static size_t ndiff(const uint8_t *a, const uint8_t *b, size_t n)
{
    size_t d = 0;
    for (size_t i = 0; i < n; i++) d += a[i] != b[i];
    return d;
}

/* Device == oracle except centres within NEAR_HALF of 1/2 (printed, < 0.1 %). */
static void compare_with_oracle(const char *what, const float *xyz, size_t nv, const uint32_t *tri, size_t nt,
                                const clvox_grid *gref, const uint8_t *dev, int abs_rule)
{
    size_t n = nvox(gref);
    uint8_t *ref = malloc(n);
    double *w = malloc(n * sizeof *w);
    ref_winding_voxelize(xyz, nv, tri, nt, gref, abs_rule, ref, w);
    size_t near = 0, diff = 0, first = SIZE_MAX;
    for (size_t i = 0; i < n; i++) {
        double d = (abs_rule ? fabs(w[i]) : w[i]) - 0.5;
        if (fabs(d) < NEAR_HALF) { near++; continue; }
        if (dev[i] != ref[i]) {
            diff++;
            if (first == SIZE_MAX) first = i;
        }
    }
    printf("%-34s %ux%ux%u %s: %llu of %zu inside, %zu near 1/2 not compared, %zu differ\n", what, gref->dims[0],
           gref->dims[1], gref->dims[2], abs_rule ? "winding-abs" : "winding", (unsigned long long)count(ref, n), n,
           near, diff);
    CHECK_MSG(near * 1000 < n, "%s: %zu centres within %g of 1/2", what, near, NEAR_HALF);
    if (first != SIZE_MAX) {
        uint32_t X = gref->dims[0], Y = gref->dims[1];
        CHECK_MSG(diff == 0, "%s: %zu voxels differ from the oracle (first (%zu,%zu,%zu): device %d, w = %.17g)", what,
                  diff, first % X, first / X % Y, first / X / Y, dev[first], w[first]);
    } else {
        CHECK(diff == 0);
    }
    free(ref);
    free(w);
}

static void test_corpus_against_oracle(void)
{
    double lo[3] = {-0.017, -0.023, -0.011}, hi[3] = {1.019, 1.013, 1.027};
    clvox_grid grids[3] = {test_grid(lo, hi, 32, 32, 32), test_grid(lo, hi, 40, 32, 24), test_grid(lo, hi, 48, 48, 48)};
    for (size_t c = 0; c < ncases; c++) {
        tmesh_case *wc = &cases[c];
        /* CLVOX_WINDING_RAW=1: compare with the mesh as given (no orientation repair), a diagnostic */
        const tmesh *want = getenv("CLVOX_WINDING_RAW") ? &wc->mesh : &wc->truth;
        if (!wc->truth.nt) continue;
        clvox_mesh *m = to_mesh(&wc->mesh);
        CHECK(m != NULL);
        if (!m) continue;
        for (int gi = 0; gi < 3; gi++) {
            if (gi == 2 && c % 3) continue; /* 48^3 on every third mesh: the oracle is brute force */
            for (int abs_rule = 0; abs_rule <= 1; abs_rule++) {
                if (abs_rule && gi) continue;
                clvox_stats s = CLVOX_STATS_INIT;
                uint8_t *dev = run_inside(m, &grids[gi], abs_rule ? CLVOX_INSIDE_WINDING_ABS : CLVOX_INSIDE_DEFAULT, &s);
                CHECK_MSG(s.inside == (abs_rule ? CLVOX_INSIDE_WINDING_ABS : CLVOX_INSIDE_WINDING),
                          "%s: stats.inside %d", wc->name, (int)s.inside);
                compare_with_oracle(wc->name, want->xyz, want->nv, want->tri, want->nt, &grids[gi], dev, abs_rule);
                free(dev);
            }
        }
        clvox_mesh_destroy(m);
    }
}

/* The same volume for every ray axis, slab depth and device, and with every
 * face flipped (orientation repair). */
/* Moving the caps' apexes (CLVOX_CAP_APEX: the offset off the plane, in
 * units of the hole's size) changes no voxel: w does not depend on the caps. */
static void test_apex(void)
{
    double lo[3] = {-0.017, -0.023, -0.011}, hi[3] = {1.019, 1.013, 1.027};
    clvox_grid g = test_grid(lo, hi, 36, 30, 26);
    static const double offsets[] = {0.31, -0.2, 0.004, 1.5};
    for (size_t c = 0; c < ncases; c++) {
        tmesh_case *wc = &cases[c];
        clvox_mesh *m = to_mesh(&wc->mesh);
        if (!m) { CHECK(m != NULL); continue; }
        clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
        clvox_stats s = CLVOX_STATS_INIT;
        uint8_t *base = run(m, &g, &o, &s);
        if (s.winding.cap_triangles) {
            for (size_t k = 0; k < sizeof offsets / sizeof offsets[0]; k++) {
                clvox__test_hooks hooks = *clvox__hooks();
                hooks.cap_apex_set = 1;
                hooks.cap_apex = offsets[k];
                clvox__set_test_hooks(&hooks);
                for (clvox_axis a = CLVOX_AXIS_X; a <= CLVOX_AXIS_Z; a += 2) {
                    clvox_voxelize_options oa = CLVOX_VOXELIZE_OPTIONS_INIT;
                    oa.ray_axis = a;
                    uint8_t *v = run(m, &g, &oa, NULL);
                    size_t dd = ndiff(base, v, nvox(&g));
                    CHECK_MSG(dd == 0, "%s: apex offset %g, axis %c: %zu voxels differ", wc->name, offsets[k],
                              "?xyz"[a], dd);
                    free(v);
                }
                clvox__set_test_hooks(NULL);
            }
        }
        free(base);
        clvox_mesh_destroy(m);
    }
}

static void test_invariance(void)
{
    double lo[3] = {-0.017, -0.023, -0.011}, hi[3] = {1.019, 1.013, 1.027};
    clvox_grid g = test_grid(lo, hi, 36, 30, 26);
    clvox_device_info devs[8] = { CLVOX_DEVICE_INFO_INIT };
    size_t ndev = 0;
    if (clvox_list_devices(devs, 8, &ndev) != CLVOX_OK) ndev = 0;
    for (size_t c = 0; c < ncases; c++) {
        tmesh_case *wc = &cases[c];
        clvox_mesh *m = to_mesh(&wc->mesh);
        if (!m) { CHECK(m != NULL); continue; }
        clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
        uint8_t *base = run(m, &g, &o, NULL);
        size_t worst = 0;
        for (clvox_axis a = CLVOX_AXIS_X; a <= CLVOX_AXIS_Z; a++)
            for (int d = 0; d < 3; d++) {
                static const uint32_t depth[3] = {1, 5, 0};
                clvox_voxelize_options oa = CLVOX_VOXELIZE_OPTIONS_INIT;
                oa.ray_axis = a;
                oa.slab_depth = depth[d];
                uint8_t *v = run(m, &g, &oa, NULL);
                size_t dd = ndiff(base, v, nvox(&g));
                if (dd > worst) worst = dd;
                CHECK_MSG(dd == 0, "%s: axis %c slab depth %u: %zu voxels differ from the default run", wc->name,
                          "?xyz"[a], depth[d], dd);
                free(v);
            }
        /* every face flipped: orientation repair gives the same volume */
        tmesh flipped = tmesh_copy(&wc->mesh);
        tmesh_flip(&flipped);
        clvox_mesh *mf = to_mesh(&flipped);
        uint8_t *vf = run(mf, &g, &o, NULL);
        size_t df = ndiff(base, vf, nvox(&g));
        CHECK_MSG(df == 0, "%s: with every face flipped %zu voxels differ", wc->name, df);
        free(vf);
        clvox_mesh_destroy(mf);
        tmesh_free(&flipped);
        for (size_t d = 0; d < ndev && d < 8 && c % 4 == 0; d++) { /* every fourth mesh on every device */
            char sel[16];
            snprintf(sel, sizeof sel, "%u", devs[d].index);
            clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
            co.device = sel;
            clvox_context *c2 = NULL;
            if (clvox_context_create(&co, &c2) != CLVOX_OK) {
                fprintf(stderr, "device %s: %s\n", sel, clvox_context_error(c2));
                clvox_context_destroy(c2);
                continue;
            }
            clvox_mesh *m2 = to_mesh_in(c2, &wc->mesh);
            clvox_status st;
            uint8_t *v = run_in(c2, m2, &g, &o, NULL, &st);
            CHECK_MSG(st == CLVOX_OK && ndiff(base, v, nvox(&g)) == 0, "%s: device %s (%s) differs", wc->name, sel,
                      devs[d].name);
            free(v);
            clvox_mesh_destroy(m2);
            clvox_context_destroy(c2);
        }
        printf("invariance %-34s axes x/y/z, slab depths 1/5/auto%s: largest difference %zu voxels; all flipped: %zu\n",
               wc->name, ndev > 1 && c % 4 == 0 ? ", devices" : "", worst, df);
        free(base);
        clvox_mesh_destroy(m);
    }
}

/* Closed, consistently oriented meshes: winding == parity bit for bit, no caps. */
/* Closed, consistently oriented meshes: winding == parity bit for bit, no
 * caps -- except where the surface overlaps itself (w >= 2, or w <= -1:
 * parity is the XOR there, winding the union). The fast oracle (exact
 * crossings, no boundary: w = K) says where; winding must equal it
 * everywhere. Generated meshes must have no such voxel; real ones may
 * (cow.off self-intersects: 10 voxels with w = 2 at 96^3). truth (may be
 * NULL): the repaired mesh for the oracle, when the stored one is not. */
static void check_same_as_parity(const char *what, const clvox_mesh *m, const clvox_grid *g, int allow_overlap,
                                 const tmesh *truth)
{
    size_t nv, nt, n = nvox(g);
    const float *xyz = clvox_mesh_vertices(m, &nv);
    const uint32_t *tri = clvox_mesh_triangles(m, &nt);
    clvox_grid gref = test_reference_grid(m, g);
    if (truth) xyz = truth->xyz, nv = truth->nv, tri = truth->tri, nt = truth->nt, gref = *g; /* repaired mesh */
    uint8_t *ref = malloc(n);
    double *wo = malloc(n * sizeof *wo);
    size_t edges = ref_winding_voxelize_rays(xyz, nv, tri, nt, &gref, 0, ref, wo), overlap = 0;
    for (size_t i = 0; i < n; i++) overlap += wo[i] > 1.5 || wo[i] < -0.5;
    CHECK_MSG(edges == 0, "%s: %zu boundary edges: not closed", what, edges);
    CHECK_MSG(allow_overlap || overlap == 0, "%s: %zu voxels covered more than once", what, overlap);
    if (overlap) printf("%s: %zu voxels covered twice or more (parity's XOR, winding's union)\n", what, overlap);
    for (clvox_axis a = CLVOX_AXIS_X; a <= CLVOX_AXIS_Z; a += 2) {
        clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
        clvox_stats sw = CLVOX_STATS_INIT, sp = CLVOX_STATS_INIT;
        o.ray_axis = a;
        uint8_t *w = run(m, g, &o, &sw);
        o.inside = CLVOX_INSIDE_PARITY;
        uint8_t *p = run(m, g, &o, &sp);
        size_t d = 0, dref = ndiff(w, ref, n);
        for (size_t i = 0; i < n; i++) d += w[i] != p[i] && !(wo[i] > 1.5 || wo[i] < -0.5);
        CHECK_MSG(d == 0, "%s axis %c: winding and parity differ on %zu voxels", what, "?xyz"[a], d);
        CHECK_MSG(dref == 0, "%s axis %c: winding differs from the oracle on %zu voxels", what, "?xyz"[a], dref);
        CHECK_MSG(sw.winding.cap_triangles == 0 && sw.winding.holes == 0, "%s: %llu cap triangles, %llu holes", what,
                  (unsigned long long)sw.winding.cap_triangles, (unsigned long long)sw.winding.holes);
        CHECK(sw.inside == CLVOX_INSIDE_WINDING && sp.inside == CLVOX_INSIDE_PARITY);
        CHECK(sp.winding.cap_triangles == 0 && sp.winding.exact_points == 0);
        CHECK(overlap || sw.filled_voxels == sp.filled_voxels);
        free(w);
        free(p);
    }
    free(ref);
    free(wo);
}

static void check_tmesh_same_as_parity(const char *what, const tmesh *t, const clvox_grid *g, const tmesh *truth)
{
    clvox_mesh *m = to_mesh(t);
    if (!m) { CHECK(m != NULL); return; }
    check_same_as_parity(what, m, g, 0, truth);
    clvox_mesh_destroy(m);
}

static clvox_mesh *load_real(const char *name)
{
    char path[256];
    snprintf(path, sizeof path, "data/meshes/%s", name);
    clvox_mesh *m = NULL;
    if (access(path, R_OK) != 0 || clvox_mesh_load(ctx, path, &m) != CLVOX_OK) {
        CHECK_MSG(0, "cannot load %s (run scripts/fetch_meshes.sh)", path);
        return NULL;
    }
    return m;
}

static void test_closed_same_as_parity(void)
{
    double lo[3] = {-1.1, -1.1, -1.1}, hi[3] = {1.1, 1.1, 1.1};
    clvox_grid g = test_grid(lo, hi, 48, 40, 44), g96 = test_grid(lo, hi, 64, 64, 64);
    tmesh t = tmesh_torus(0.013, -0.007, 0.021, 0.7, 0.3, 96, 48);
    check_tmesh_same_as_parity("torus", &t, &g96, NULL);
    tmesh_free(&t);
    t = tmesh_sphere(0.011, 0.017, -0.013, 1.0, 24);
    check_tmesh_same_as_parity("sphere", &t, &g, NULL);
    tmesh_free(&t);
    t = tmesh_octahedron(0.0123, 0.0311, -0.0207, 1.0);
    check_tmesh_same_as_parity("octahedron", &t, &g, NULL);
    tmesh_free(&t);
    /* hollow sphere with the inner shell stored either way: parity ignores
     * orientation; winding must keep the cavity */
    t = tmesh_hollow_sphere(0.011, 0.017, -0.013, 1.0, 0.6, 24);
    check_tmesh_same_as_parity("hollow sphere", &t, &g96, NULL);
    tmesh_free(&t);
    t = tmesh_sphere(0.011, 0.017, -0.013, 1.0, 24);
    tmesh in = tmesh_sphere(0.011, 0.017, -0.013, 0.6, 24), hollow = tmesh_hollow_sphere(0.011, 0.017, -0.013, 1.0, 0.6, 24);
    tmesh_append(&t, &in);
    check_tmesh_same_as_parity("hollow sphere, inner outwards", &t, &g96, &hollow);
    tmesh_free(&t);
    tmesh_free(&in);
    tmesh_free(&hollow);
    /* two disjoint shells */
    t = tmesh_sphere(-0.5, 0.01, 0.02, 0.45, 20);
    tmesh s2 = tmesh_sphere(0.52, -0.03, 0.01, 0.4, 20);
    tmesh_append(&t, &s2);
    check_tmesh_same_as_parity("two shells", &t, &g, NULL);
    tmesh_free(&t);
    tmesh_free(&s2);
    /* random closed shells (test_ray.c's) */
    double ulo[3] = {0, 0, 0}, uhi[3] = {1, 1, 1};
    clvox_grid ug[3] = {test_grid(ulo, uhi, 17, 17, 17), test_grid(ulo, uhi, 32, 20, 25), test_grid(ulo, uhi, 40, 40, 40)};
    for (uint64_t seed = 1; seed <= 6; seed++) {
        t = tmesh_random_closed(seed, 1 + (unsigned)(seed % 3), 2 + (unsigned)(seed % 4));
        char what[64];
        snprintf(what, sizeof what, "random closed seed %llu", (unsigned long long)seed);
        check_tmesh_same_as_parity(what, &t, &ug[seed % 3], NULL);
        tmesh_free(&t);
    }
    /* grid-aligned boxes (vertices and edges exactly on rays and centres) */
    double glo[3] = {0, 0, 0}, ghi[3] = {16, 16, 16};
    clvox_grid g16 = test_grid(glo, ghi, 16, 16, 16);
    t = tmesh_box_subdivided(1.5, 2.5, 3.5, 6.5, 9.5, 7.5, 5);
    check_tmesh_same_as_parity("grid-aligned box", &t, &g16, NULL);
    tmesh_free(&t);
    /* the real closed meshes of tests/test_real_meshes.c */
    if (getenv("CLVOX_QUICK")) return;
    static const struct { const char *name; uint32_t n; } real[] = {
        {"cow.off", 96}, {"bunny00.off", 64}, {"armadillo.off", 64}, {"knot1.off", 64}};
    for (size_t i = 0; i < sizeof real / sizeof real[0]; i++) {
        clvox_mesh *m = load_real(real[i].name);
        if (!m) continue;
        clvox_grid rg = test_padded_grid(ctx, clvox_mesh_get_report(m), real[i].n);
        check_same_as_parity(real[i].name, m, &rg, 1, NULL);
        clvox_mesh_destroy(m);
    }
}

/* Connected components by shared vertices, each a tmesh. */
static size_t components(const tmesh *t, tmesh *out, size_t max)
{
    uint32_t *parent = malloc((t->nv ? t->nv : 1) * sizeof *parent);
    if (!parent) abort();
    for (size_t i = 0; i < t->nv; i++) parent[i] = (uint32_t)i;
    for (size_t i = 0; i < 3 * t->nt; i++) {
        uint32_t a = t->tri[i], b = t->tri[i - i % 3 + (i + 1) % 3];
        while (parent[a] != a) a = parent[a];
        while (parent[b] != b) b = parent[b];
        if (a != b) parent[a > b ? a : b] = a < b ? a : b;
    }
    size_t n = 0;
    uint32_t roots[64];
    for (size_t f = 0; f < t->nt; f++) {
        uint32_t r = t->tri[3 * f];
        while (parent[r] != r) r = parent[r];
        size_t k = 0;
        while (k < n && roots[k] != r) k++;
        if (k == n) {
            if (n == max || n == 64) abort();
            roots[n] = r;
            out[n++] = (tmesh){0};
            for (size_t i = 0; i < t->nv; i++)
                tmesh_add_vertex(&out[k], t->xyz[3 * i], t->xyz[3 * i + 1], t->xyz[3 * i + 2]);
        }
        tmesh_add_tri(&out[k], t->tri[3 * f], t->tri[3 * f + 1], t->tri[3 * f + 2]);
    }
    free(parent);
    return n;
}

/* Overlapping closed parts: winding = the union (the OR of the parts
 * voxelized alone), parity = their XOR, and the two differ. */
static void check_union(const char *what, const tmesh *t, size_t want_parts)
{
    double lo[3] = {-0.017, -0.023, -0.011}, hi[3] = {1.019, 1.013, 1.027};
    clvox_grid g = test_grid(lo, hi, 40, 36, 32);
    tmesh parts[8];
    size_t np = components(t, parts, 8);
    CHECK_MSG(np == want_parts, "%s: %zu parts, expected %zu", what, np, want_parts);
    size_t n = nvox(&g);
    uint8_t *or_ = calloc(n, 1), *xor_ = calloc(n, 1);
    for (size_t i = 0; i < np; i++) {
        clvox_mesh *m = to_mesh(&parts[i]);
        uint8_t *v = run_inside(m, &g, CLVOX_INSIDE_PARITY, NULL);
        for (size_t k = 0; k < n; k++) or_[k] |= v[k], xor_[k] ^= v[k];
        free(v);
        clvox_mesh_destroy(m);
        tmesh_free(&parts[i]);
    }
    clvox_mesh *m = to_mesh(t);
    uint8_t *w = run_inside(m, &g, CLVOX_INSIDE_DEFAULT, NULL), *p = run_inside(m, &g, CLVOX_INSIDE_PARITY, NULL);
    size_t dw = ndiff(w, or_, n), dp = ndiff(p, xor_, n), dwp = ndiff(w, p, n);
    CHECK_MSG(dw == 0, "%s: winding differs from the union of the parts on %zu voxels", what, dw);
    CHECK_MSG(dp == 0, "%s: parity differs from the XOR of the parts on %zu voxels", what, dp);
    CHECK_MSG(dwp > 0 && dwp == count(or_, n) - count(xor_, n), "%s: winding and parity differ on %zu voxels (%llu)",
              what, dwp, (unsigned long long)(count(or_, n) - count(xor_, n)));
    printf("union %-20s %zu parts: union %llu voxels, XOR %llu\n", what, np, (unsigned long long)count(or_, n),
           (unsigned long long)count(xor_, n));
    compare_with_oracle(what, t->xyz, t->nv, t->tri, t->nt, &g, w, 0);
    free(w);
    free(p);
    free(or_);
    free(xor_);
    clvox_mesh_destroy(m);
}

static void test_unions(void)
{
    tmesh cad = tmesh_cad_union(11);
    check_union("cad union", &cad, 4);
    tmesh_free(&cad);
    cad = tmesh_cad_union(12);
    check_union("cad union seed 12", &cad, 4);
    tmesh_free(&cad);
    tmesh sh = tmesh_shifted_shells(0.45, 0.47, 0.49, 0.3, 16, 0.12);
    check_union("shifted shells", &sh, 2);
    tmesh_free(&sh);
}

/* Cavities stay cavities: nested shells stored either way; winding ==
 * parity == the expected hollow (the oracle on the repaired mesh). */
static void test_cavities(void)
{
    double lo[3] = {-0.017, -0.023, -0.011}, hi[3] = {1.019, 1.013, 1.027};
    clvox_grid g = test_grid(lo, hi, 40, 36, 32);
    size_t n = nvox(&g);
    double s[3] = {0.41, 0.27, 0.13};
    tmesh want = tmesh_nested_boxes(0.5, 0.5, 0.5, s, 0);
    uint8_t *ref = malloc(n);
    ref_winding_voxelize(want.xyz, want.nv, want.tri, want.nt, &g, 0, ref, NULL);
    for (unsigned flags = 0; flags < 4; flags++) {
        tmesh t = tmesh_nested_boxes(0.5, 0.5, 0.5, s, flags);
        clvox_mesh *m = to_mesh(&t);
        clvox_stats st = CLVOX_STATS_INIT;
        uint8_t *w = run_inside(m, &g, CLVOX_INSIDE_DEFAULT, &st), *p = run_inside(m, &g, CLVOX_INSIDE_PARITY, NULL);
        CHECK_MSG(ndiff(w, p, n) == 0 && ndiff(w, ref, n) == 0, "nested boxes flags %u: winding/parity %zu, "
                  "winding/expected %zu voxels differ", flags, ndiff(w, p, n), ndiff(w, ref, n));
        /* the middle box is a cavity: its centre region is empty only between the inner and middle shells */
        size_t mid = ((size_t)(g.dims[2] / 2) * g.dims[1] + g.dims[1] / 2) * g.dims[0] + g.dims[0] / 2;
        CHECK(w[mid] == 1); /* inside the inner box */
        CHECK_MSG(st.winding.cavities == 1 && st.winding.closed_components == 3 && st.winding.cap_triangles == 0,
                  "nested boxes flags %u: %llu cavities, %llu closed patches, %llu caps", flags,
                  (unsigned long long)st.winding.cavities, (unsigned long long)st.winding.closed_components,
                  (unsigned long long)st.winding.cap_triangles);
        unsigned want_flips = (flags & 1 ? 12u : 0u) + (flags & 2 ? 12u : 0u);
        CHECK_MSG(st.winding.flipped_triangles == want_flips, "nested boxes flags %u: %llu flipped, expected %u", flags,
                  (unsigned long long)st.winding.flipped_triangles, want_flips);
        free(w);
        free(p);
        clvox_mesh_destroy(m);
        tmesh_free(&t);
    }
    free(ref);
    tmesh_free(&want);
}

/* Grey levels and palettes: every sample of a coverage or palette run takes
 * the winding rule (the lead may land these after solid: the checks marked
 * [coverage] and [palette] wait for it). */
static void test_coverage_samples(void)
{
    double lo[3] = {-0.017, -0.023, -0.011}, hi[3] = {1.019, 1.013, 1.027};
    clvox_grid g = test_grid(lo, hi, 24, 20, 18);
    size_t n = nvox(&g);
    double blo[3] = {0.13, 0.17, 0.11}, bhi[3] = {0.86, 0.79, 0.91};
    tmesh t = tmesh_open_box(1, blo, bhi, 3, 1, NULL);
    clvox_mesh *m = to_mesh(&t);
    float *cov = calloc(n, sizeof *cov);
    uint32_t *ref = malloc(n * sizeof *ref);
    uint16_t *el = calloc(n, sizeof *el);
    clvox_palette *pal = NULL;
    CHECK_OK(ctx, clvox_palette_builtin(ctx, "binary", &pal));
    for (int stochastic = 0; stochastic <= 1; stochastic++)
        for (clvox_axis a = CLVOX_AXIS_X; a <= CLVOX_AXIS_Z; a += 2) {
            clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
            o.oversample = 2;
            o.oversample_points = 2;
            o.stochastic = stochastic;
            o.seed = 7;
            o.ray_axis = a;
            clvox_stats s = CLVOX_STATS_INIT;
            CHECK_OK(ctx, clvox_voxelize_to_buffers(ctx, m, &g, &o, NULL, 0, cov, n, &s));
            uint64_t ties = ref_winding_coverage(t.xyz, t.nv, t.tri, t.nt, &g, a, 2, 2, stochastic, 7, 0, NEAR_HALF, ref);
            size_t diff = 0;
            for (size_t i = 0; i < n; i++) diff += cov[i] != (float)ref[i] / 8.0f;
            CHECK_MSG(ties == 0, "coverage samples within %g of 1/2: %llu", NEAR_HALF, (unsigned long long)ties);
            CHECK_MSG(diff == 0 && s.inside == CLVOX_INSIDE_WINDING,
                      "[coverage, waits on the device code] open box N=2 M=2 %s axis %c: %zu voxels differ",
                      stochastic ? "stochastic" : "uniform", "?xyz"[a], diff);
            /* palette samples: the binary palette picks "full" exactly where more than half are inside */
            o.palette = pal;
            CHECK_OK(ctx, clvox_voxelize_palette_to_buffers(ctx, m, &g, &o, el, n, NULL, 0, NULL));
            size_t pdiff = 0;
            for (size_t i = 0; i < n; i++) pdiff += el[i] != (ref[i] * 2 > 8);
            CHECK_MSG(pdiff == 0, "[palette, waits on the device code] open box binary palette %s axis %c: %zu voxels "
                      "differ from winding samples > 1/2", stochastic ? "stochastic" : "uniform", "?xyz"[a], pdiff);
        }
    free(cov);
    free(ref);
    free(el);
    clvox_palette_destroy(pal);
    clvox_mesh_destroy(m);
    tmesh_free(&t);
}

static void test_options(void)
{
    double lo[3] = {-0.017, -0.023, -0.011}, hi[3] = {1.019, 1.013, 1.027};
    clvox_grid g = test_grid(lo, hi, 32, 28, 30);
    size_t n = nvox(&g);
    double blo[3] = {0.13, 0.17, 0.11}, bhi[3] = {0.86, 0.79, 0.91};
    /* --weld: the cracked box is the closed box */
    tmesh box = tmesh_box(blo[0], blo[1], blo[2], bhi[0], bhi[1], bhi[2]);
    tmesh cr = tmesh_cracked_box(7, blo, bhi, 1e-5);
    clvox_mesh *mb = to_mesh(&box), *mc = to_mesh(&cr);
    uint8_t *want = run_inside(mb, &g, CLVOX_INSIDE_PARITY, NULL);
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    o.weld = 1e-4;
    clvox_stats s = CLVOX_STATS_INIT;
    uint8_t *v = run(mc, &g, &o, &s);
    CHECK_MSG(ndiff(v, want, n) == 0, "cracked box welded at 1e-4: %zu voxels differ from the closed box",
              ndiff(v, want, n));
    CHECK_MSG(s.winding.merged_vertices + s.winding.welded_vertices == 16 && s.winding.welded_vertices > 0 &&
                  s.winding.holes == 0 && s.winding.cap_triangles == 0 && s.winding.boundary_edges == 0,
              "cracked box welded: %llu merged, %llu welded, %llu holes, %llu boundary edges",
              (unsigned long long)s.winding.merged_vertices, (unsigned long long)s.winding.welded_vertices,
              (unsigned long long)s.winding.holes, (unsigned long long)s.winding.boundary_edges);
    free(v);
    /* unwelded it has cracks (boundary edges) but the same volume away from them */
    v = run_inside(mc, &g, CLVOX_INSIDE_DEFAULT, &s);
    CHECK_MSG(s.winding.boundary_edges > 0 && s.winding.welded_vertices == 0, "cracked box: %llu boundary edges",
              (unsigned long long)s.winding.boundary_edges);
    CHECK(ndiff(v, want, n) == 0);
    free(v);
    free(want);
    /* bad values */
    uint8_t *buf = malloc(n);
    o = (clvox_voxelize_options)CLVOX_VOXELIZE_OPTIONS_INIT;
    o.inside = (clvox_inside)99;
    CHECK_STATUS(ctx, clvox_voxelize_to_memory(ctx, mb, &g, &o, buf, n, NULL), CLVOX_ERR_INVALID_ARGUMENT);
    o.inside = CLVOX_INSIDE_COUNT;
    CHECK_STATUS(ctx, clvox_voxelize_to_memory(ctx, mb, &g, &o, buf, n, NULL), CLVOX_ERR_INVALID_ARGUMENT);
    o.inside = CLVOX_INSIDE_DEFAULT;
    o.weld = -1;
    CHECK_STATUS(ctx, clvox_voxelize_to_memory(ctx, mb, &g, &o, buf, n, NULL), CLVOX_ERR_INVALID_ARGUMENT);
    o.weld = NAN;
    CHECK_STATUS(ctx, clvox_voxelize_to_memory(ctx, mb, &g, &o, buf, n, NULL), CLVOX_ERR_INVALID_ARGUMENT);
    /* tetra is parity by construction: winding asked for explicitly is refused, the default runs parity */
    o = (clvox_voxelize_options)CLVOX_VOXELIZE_OPTIONS_INIT;
    o.method = CLVOX_METHOD_TETRA;
    o.inside = CLVOX_INSIDE_WINDING;
    CHECK_STATUS(ctx, clvox_voxelize_to_memory(ctx, mb, &g, &o, buf, n, NULL), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK(strstr(clvox_context_error(ctx), "tetra") != NULL || strstr(clvox_context_error(ctx), "winding") != NULL);
    o.inside = CLVOX_INSIDE_WINDING_ABS;
    CHECK_STATUS(ctx, clvox_voxelize_to_memory(ctx, mb, &g, &o, buf, n, NULL), CLVOX_ERR_INVALID_ARGUMENT);
    /* double and float kernels alike (tetra runs exactly in float too) */
    o.inside = CLVOX_INSIDE_DEFAULT;
    CHECK_OK(ctx, clvox_voxelize_to_memory(ctx, mb, &g, &o, buf, n, &s));
    CHECK(s.inside == CLVOX_INSIDE_PARITY);
    o.inside = CLVOX_INSIDE_PARITY;
    CHECK_OK(ctx, clvox_voxelize_to_memory(ctx, mb, &g, &o, buf, n, &s));
    CHECK(s.inside == CLVOX_INSIDE_PARITY);
    CHECK(strcmp(clvox_inside_name(CLVOX_INSIDE_WINDING), "winding") == 0 &&
          strcmp(clvox_inside_name(CLVOX_INSIDE_WINDING_ABS), "winding-abs") == 0 &&
          strcmp(clvox_inside_name(CLVOX_INSIDE_PARITY), "parity") == 0 &&
          clvox_inside_name((clvox_inside)99) == NULL);
    free(buf);
    clvox_mesh_destroy(mb);
    clvox_mesh_destroy(mc);
    tmesh_free(&box);
    tmesh_free(&cr);
}

/* What preparation reports for meshes whose answer is known. */
static void test_winding_report(void)
{
    double lo[3] = {-0.017, -0.023, -0.011}, hi[3] = {1.019, 1.013, 1.027};
    clvox_grid g = test_grid(lo, hi, 24, 24, 24);
    double blo[3] = {0.13, 0.17, 0.11}, bhi[3] = {0.86, 0.79, 0.91};
    clvox_stats s = CLVOX_STATS_INIT;
#define STATS_OF(tm)                                                                 \
    do {                                                                             \
        clvox_mesh *m_ = to_mesh(&(tm));                                             \
        uint8_t *v_ = run_inside(m_, &g, CLVOX_INSIDE_DEFAULT, &s);                  \
        free(v_);                                                                    \
        clvox_mesh_destroy(m_);                                                      \
    } while (0)
#define U(x) ((unsigned long long)(x))
    tmesh t = tmesh_open_box(1, blo, bhi, 3, 1, NULL);
    STATS_OF(t);
    CHECK_MSG(s.winding.holes == 1 && s.winding.boundary_edges == 12 && s.winding.cap_triangles >= 1 &&
                  s.winding.flipped_triangles == 0 && s.winding.components == 1 && s.winding.closed_components == 0,
              "open box: %llu holes, %llu boundary edges, %llu caps, %llu flipped, %llu/%llu components", U(s.winding.holes),
              U(s.winding.boundary_edges), U(s.winding.cap_triangles), U(s.winding.flipped_triangles),
              U(s.winding.components), U(s.winding.closed_components));
    tmesh_free(&t);
    t = tmesh_open_box(2, blo, bhi, 2, 3, NULL); /* 3 faces missing: still one hole */
    STATS_OF(t);
    CHECK_MSG(s.winding.holes == 1 && s.winding.flipped_triangles == 0, "open box 3 faces: %llu holes, %llu flipped",
              U(s.winding.holes), U(s.winding.flipped_triangles));
    tmesh_free(&t);
    t = tmesh_sphere_flipped(5, 0.5, 0.49, 0.52, 0.4, 16, 20);
    STATS_OF(t);
    CHECK_MSG(s.winding.flipped_triangles == 20 && s.winding.holes == 0 && s.winding.cap_triangles == 0 &&
                  s.winding.closed_components == 1,
              "sphere with 20 flipped faces: %llu flipped, %llu holes, %llu caps", U(s.winding.flipped_triangles),
              U(s.winding.holes), U(s.winding.cap_triangles));
    tmesh_free(&t);
    t = tmesh_sphere(0.49, 0.52, 0.5, 0.41, 16);
    tmesh_flip(&t);
    STATS_OF(t);
    CHECK_MSG(s.winding.flipped_triangles == t.nt && s.winding.cavities == 0, "inverted sphere: %llu of %zu flipped",
              U(s.winding.flipped_triangles), t.nt);
    tmesh_free(&t);
    t = tmesh_sphere_holes(3, 0.5, 0.49, 0.52, 0.4, 16, 12);
    uint64_t bnd, nm, conf;
    tmesh_edge_stats(&t, &bnd, &nm, &conf);
    STATS_OF(t);
    CHECK_MSG(s.winding.holes >= 1 && s.winding.holes <= 12 && s.winding.boundary_edges == bnd &&
                  s.winding.flipped_triangles == 0,
              "sphere with holes: %llu holes, %llu boundary edges (%llu)", U(s.winding.holes), U(s.winding.boundary_edges),
              U(bnd));
    tmesh_free(&t);
    tmesh sp = tmesh_sphere(0.5, 0.49, 0.52, 0.4, 12);
    t = tmesh_soup(&sp);
    STATS_OF(t);
    CHECK_MSG(s.winding.merged_vertices == t.nv - sp.nv && s.winding.holes == 0 && s.winding.boundary_edges == 0,
              "soup: %llu merged (want %zu), %llu holes", U(s.winding.merged_vertices), t.nv - sp.nv, U(s.winding.holes));
    tmesh_free(&t);
    tmesh_free(&sp);
    t = tmesh_sphere_membrane(0.5, 0.49, 0.52, 0.4, 16);
    STATS_OF(t);
    CHECK_MSG(s.winding.nonmanifold_edges == 32, "membrane: %llu non-manifold edges, want 32",
              U(s.winding.nonmanifold_edges));
    tmesh_free(&t);
    t = tmesh_moebius(0.5, 0.5, 0.5, 0.3, 0.12, 64, 4);
    STATS_OF(t);
    CHECK_MSG(s.winding.nonorientable_components == 1, "moebius: %llu non-orientable patches",
              U(s.winding.nonorientable_components));
    tmesh_free(&t);
    t = tmesh_sphere(0.49, 0.5, 0.51, 0.42, 14);
    tmesh in = tmesh_sphere(0.49, 0.5, 0.51, 0.23, 14);
    tmesh_append(&t, &in);
    STATS_OF(t);
    CHECK_MSG(s.winding.cavities == 1 && s.winding.flipped_triangles == in.nt,
              "hollow sphere, inner outwards: %llu cavities, %llu flipped (want %zu)", U(s.winding.cavities),
              U(s.winding.flipped_triangles), in.nt);
    tmesh_free(&t);
    tmesh_free(&in);
#undef STATS_OF
#undef U
}

/* Real open meshes (libcgal-demo): device == oracle voxel for voxel.
 * Only meshes whose triangles are consistently oriented (no directed edge
 * used twice, no non-manifold edge); the repaired orientation the oracle
 * assumes is, per connected component, the one with positive total winding
 * over the grid's centres (outwards; these meshes have no cavities), so
 * w = sum over components of sign_c * w_c. (mask_cone.off is left out: its
 * open cone part has positive signed volume about the origin but negative
 * total winding, so "outwards" is not defined well enough to test.) */
static void test_real_open(void)
{
    if (getenv("CLVOX_QUICK")) return;
    static const struct { const char *name; uint32_t n; } real[] = {
        {"corner_with_hole.off", 40}, {"cube-ouvert.off", 40},  {"blob.off", 40},      {"nefertiti.off", 36},
        {"pig.off", 32},              {"mushroom.off", 32},      {"head.off", 28},      {"elephant-with-holes.off", 28},
        {"mech-holes-shark.off", 24},
    };
    for (size_t i = 0; i < sizeof real / sizeof real[0]; i++) {
        clvox_mesh *m = load_real(real[i].name);
        if (!m) continue;
        size_t nv, nt;
        const float *xyz = clvox_mesh_vertices(m, &nv);
        const uint32_t *tri = clvox_mesh_triangles(m, &nt);
        tmesh view = {(float *)xyz, nv, nv, (uint32_t *)tri, nt, nt};
        uint64_t bnd, nm, conf;
        tmesh_edge_stats(&view, &bnd, &nm, &conf);
        clvox_grid g = test_padded_grid(ctx, clvox_mesh_get_report(m), real[i].n), gref = test_reference_grid(m, &g);
        const size_t n = nvox(&g);
        clvox_stats s = CLVOX_STATS_INIT;
        uint8_t *v = run_inside(m, &g, CLVOX_INSIDE_DEFAULT, &s);
        uint32_t *label = malloc(nt * sizeof *label), *sub = malloc(3 * nt * sizeof *sub);
        size_t ncomp = tmesh_components_of(xyz, nv, tri, nt, label), flipped = 0, flipped_tris = 0;
        double *w = calloc(n, sizeof *w), *wc = malloc(n * sizeof *wc);
        uint8_t *ref = malloc(n), *tmp = malloc(n);
        for (size_t c = 0; c < ncomp && conf == 0 && nm == 0; c++) {
            size_t ns = 0;
            for (size_t t = 0; t < nt; t++)
                if (label[t] == c) memcpy(sub + 3 * ns++, tri + 3 * t, 3 * sizeof *sub);
            ref_winding_voxelize(xyz, nv, sub, ns, &gref, 0, tmp, wc);
            double total = 0;
            for (size_t k = 0; k < n; k++) total += wc[k];
            double sign = total < 0 ? -1.0 : 1.0;
            flipped += total < 0, flipped_tris += total < 0 ? ns : 0;
            for (size_t k = 0; k < n; k++) w[k] += sign * wc[k];
        }
        printf("%s: %zu triangles, %zu components (%zu inverted), %llu boundary edges, %llu non-manifold, "
               "%llu orientation conflicts; prep: %llu holes, %llu caps, %llu flipped, %llu exact points\n",
               real[i].name, nt, ncomp, flipped, (unsigned long long)bnd, (unsigned long long)nm,
               (unsigned long long)conf, (unsigned long long)s.winding.holes,
               (unsigned long long)s.winding.cap_triangles, (unsigned long long)s.winding.flipped_triangles,
               (unsigned long long)s.winding.exact_points);
        if (conf == 0 && nm == 0) {
            size_t near = 0, diff = 0, inside = 0;
            for (size_t k = 0; k < n; k++) {
                ref[k] = (uint8_t)ref_winding_inside(w[k], 0);
                inside += ref[k];
                if (fabs(w[k] - 0.5) < NEAR_HALF) near++;
                else diff += ref[k] != v[k];
            }
            printf("%-34s %ux%ux%u winding: %zu of %zu inside, %zu near 1/2 not compared, %zu differ\n", real[i].name,
                   g.dims[0], g.dims[1], g.dims[2], inside, n, near, diff);
            CHECK_MSG(diff == 0 && near * 1000 < n, "%s: %zu voxels differ from the oracle (%zu near 1/2)",
                      real[i].name, diff, near);
            CHECK_MSG(s.winding.flipped_triangles == flipped_tris, "%s: %llu triangles flipped, expected %zu",
                      real[i].name, (unsigned long long)s.winding.flipped_triangles, flipped_tris);
        }
        for (clvox_axis a = CLVOX_AXIS_Y; a <= CLVOX_AXIS_Z; a++) {
            clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
            o.ray_axis = a;
            uint8_t *va = run(m, &g, &o, NULL);
            CHECK_MSG(ndiff(v, va, n) == 0, "%s: axis %c differs from x on %zu voxels", real[i].name, "?xyz"[a],
                      ndiff(v, va, n));
            free(va);
        }
        free(label);
        free(sub);
        free(w);
        free(wc);
        free(ref);
        free(tmp);
        free(v);
        clvox_mesh_destroy(m);
    }
}

/* ---- the cap tree's node estimates (kernels/winding_bounds.h clvox_cap_estimate) ---- */

static void emit_cap(float *out, size_t *n, size_t max, const double *a, const double *b, const double *c)
{
    if (*n >= max) return;
    float *t = out + 9 * (*n)++;
    for (int k = 0; k < 3; k++) t[k] = (float)a[k], t[3 + k] = (float)b[k], t[6 + k] = (float)c[k];
}

/* Cap soups made in code (grid space, x, y, z): a curved dome, a random
 * soup, a wavy fan with rim slivers as src/winding/winding.c makes them, thin
 * needles. Returns the triangle count (9 floats each in out). */
static size_t estimate_soup(int kind, float *out, size_t max, uint64_t *s)
{
    size_t n = 0;
    if (kind == 0) { /* a dome: the sphere of radius 10 about (20, 20, 10) above 30 degrees latitude */
        const int rings = 8, sectors = 24;
        for (int i = 0; i < rings; i++)
            for (int j = 0; j < sectors; j++) {
                double v[4][3];
                for (int c = 0; c < 4; c++) {
                    double t = PI / 3 * (i + (c == 1 || c == 2)) / rings, f = 2 * PI * (j + (c >= 2)) / sectors;
                    v[c][0] = 20 + 10 * sin(t) * cos(f), v[c][1] = 20 + 10 * sin(t) * sin(f), v[c][2] = 10 + 10 * cos(t);
                }
                emit_cap(out, &n, max, v[0], v[1], v[2]);
                if (i > 0) emit_cap(out, &n, max, v[0], v[2], v[3]);
            }
    } else if (kind == 1) { /* a random soup in a box of 20 */
        for (int t = 0; t < 96; t++) {
            double c[3], v[9];
            for (int k = 0; k < 3; k++) c[k] = 20 * tmesh_rng_uniform(s);
            for (int k = 0; k < 9; k++) v[k] = c[k % 3] + 3 * (tmesh_rng_uniform(s) - 0.5);
            emit_cap(out, &n, max, v, v + 3, v + 6);
        }
    } else if (kind == 2) { /* a wavy loop of 64 corners: slivers cut off as src/winding/winding.c does, then a fan */
        double v[64][3];
        const double apex[3] = {15, 15, 7.3};
        size_t m = 64;
        for (size_t i = 0; i < m; i++) {
            double f = 2 * PI * (double)i / (double)m;
            v[i][0] = 15 + 12 * cos(f), v[i][1] = 15 + 9 * sin(f), v[i][2] = 6 + 2.5 * sin(3 * f);
        }
        while (m > 8) {
            size_t k = 0;
            for (size_t i = 0; i + 2 <= m; i += 2) {
                emit_cap(out, &n, max, v[(i + 2) % m], v[i + 1], v[i]);
                memmove(v[k++], v[i], sizeof v[i]);
            }
            m = k;
        }
        for (size_t i = 0; i < m; i++) emit_cap(out, &n, max, v[(i + 1) % m], v[i], apex);
    } else { /* needles: long thin triangles, random directions */
        for (int t = 0; t < 40; t++) {
            double a[3], b[3], c[3];
            for (int k = 0; k < 3; k++) {
                a[k] = 5 + 10 * tmesh_rng_uniform(s);
                b[k] = a[k] + 8 * (tmesh_rng_uniform(s) - 0.5);
                c[k] = a[k] + 0.3 * (tmesh_rng_uniform(s) - 0.5);
            }
            emit_cap(out, &n, max, a, b, c);
        }
    }
    return n;
}

/* Every node of the cap tree of each soup, seen from points at d = t r
 * from its centre (t from 0.5 to 1000, several near 2.5) in random
 * directions: the device's estimate must lie within its bound of the
 * brute-force sum of the node's solid angles (ref_solid_angle, double),
 * the two- and four-lane estimates must equal the single one, and the node's exact
 * value the sum. The first-order estimate must be the one taken far off. */
static void test_cap_estimates(void)
{
    if (ctx->real_size != 8) {
        printf("cap estimates: skipped (the device has no double)\n");
        return;
    }
    static const double ratio[] = {0.5, 0.9, 1.02, 1.2, 1.5, 1.8, 2.2, 2.4, 2.5, 2.6, 2.8, 3, 4, 6, 10, 30, 100, 1000};
    const size_t nr = sizeof ratio / sizeof ratio[0], dirs = 3;
    static const char *const names[] = {"dome", "random soup", "wavy fan", "needles"};
    cl_kernel k = NULL;
    CHECK_OK(ctx, clvox__kernel(ctx, "clvox_winding_probe", &k));
    if (!k) return;
    uint64_t seed = 0x5eedcafe;
    for (int kind = 0; kind < 4; kind++) {
        float soup[9 * 512];
        const size_t n = estimate_soup(kind, soup, 512, &seed);
        clvox_grid grid;
        memset(&grid, 0, sizeof grid);
        grid.voxel_size[0] = 0.9, grid.voxel_size[1] = 1.1, grid.voxel_size[2] = 1.3;
        clvox__caps caps;
        CHECK_OK(ctx, clvox__caps_upload(ctx, soup, n, clvox__axes_for(CLVOX_AXIS_X), &grid, &caps));
        const size_t nn = caps.node_count, pairs = nn * nr * dirs;
        clvox_cap_node *nodes = malloc(nn * sizeof *nodes);
        double *tris = malloc(n * 9 * sizeof *tris), *pts = malloc(pairs * 3 * sizeof *pts),
               *res = malloc(pairs * 12 * sizeof *res);
        cl_uint *node_of = malloc(pairs * sizeof *node_of);
        CHECK(nodes && tris && pts && res && node_of);
        cl_int e = clEnqueueReadBuffer(ctx->queue, caps.nodes, CL_TRUE, 0, nn * sizeof *nodes, nodes, 0, NULL, NULL);
        e |= clEnqueueReadBuffer(ctx->queue, caps.tris, CL_TRUE, 0, n * 9 * sizeof *tris, tris, 0, NULL, NULL);
        CHECK(e == CL_SUCCESS);
        size_t at = 0;
        for (size_t j = 0; j < nn; j++)
            for (size_t i = 0; i < nr; i++)
                for (size_t r = 0; r < dirs; r++, at++) {
                    double u[3], l = 0;
                    do {
                        l = 0;
                        for (int a = 0; a < 3; a++) u[a] = 2 * tmesh_rng_uniform(&seed) - 1, l += u[a] * u[a];
                    } while (l > 1 || l < 1e-4);
                    const double t = ratio[i] * (1 + 0.01 * (tmesh_rng_uniform(&seed) - 0.5));
                    for (int a = 0; a < 3; a++) pts[3 * at + a] = nodes[j].centre[a] + t * nodes[j].radius * u[a] / sqrt(l);
                    node_of[at] = (cl_uint)j;
                }
        cl_int ce = CL_SUCCESS;
        cl_mem bn = clCreateBuffer(ctx->cl, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, pairs * sizeof *node_of, node_of, &ce);
        cl_mem bp = clCreateBuffer(ctx->cl, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, pairs * 3 * sizeof *pts, pts, &ce);
        cl_mem bo = clCreateBuffer(ctx->cl, CL_MEM_WRITE_ONLY, pairs * 12 * sizeof *res, NULL, &ce);
        cl_uint cnt = (cl_uint)pairs;
        e = clSetKernelArg(k, 0, sizeof(cl_mem), &caps.nodes);
        e |= clSetKernelArg(k, 1, sizeof(cl_mem), &caps.tris);
        e |= clSetKernelArg(k, 2, sizeof(cl_mem), &bn);
        e |= clSetKernelArg(k, 3, sizeof(cl_mem), &bp);
        e |= clSetKernelArg(k, 4, sizeof(cl_uint), &cnt);
        e |= clSetKernelArg(k, 5, sizeof(cl_mem), &bo);
        size_t global = pairs;
        e |= clEnqueueNDRangeKernel(ctx->queue, k, 1, NULL, &global, NULL, 0, NULL, NULL);
        e |= clEnqueueReadBuffer(ctx->queue, bo, CL_TRUE, 0, pairs * 12 * sizeof *res, res, 0, NULL, NULL);
        CHECK(ce == CL_SUCCESS && e == CL_SUCCESS);
        size_t bad = 0, unpaired = 0, inexact = 0, first = 0, far = 0, far_first = 0;
        double worst = 0, worst_first = 0, worst_near = 0;
        for (size_t i = 0; i < pairs; i++) {
            const clvox_cap_node *nd = &nodes[node_of[i]];
            const double *p = pts + 3 * i, *o = res + 12 * i;
            double w = 0, dc[3], db2 = 0;
            for (uint32_t t = nd->tri_first; t < nd->tri_first + nd->tri_count; t++) {
                double A[3], B[3], C[3];
                for (int a = 0; a < 3; a++) {
                    A[a] = tris[9 * t + a] - p[a];
                    B[a] = tris[9 * t + 3 + a] - p[a];
                    C[a] = tris[9 * t + 6 + a] - p[a];
                }
                w += ref_solid_angle(A, B, C) / (4 * PI);
            }
            for (int a = 0; a < 3; a++) {
                dc[a] = nd->centre[a] - p[a];
                double g = fmax(fmax(nd->lo[a] - p[a], p[a] - nd->hi[a]), 0.0);
                db2 += g * g;
            }
            const double d = sqrt(dc[0] * dc[0] + dc[1] * dc[1] + dc[2] * dc[2]), r = nd->radius;
            /* the bounds 0 and 1 without margins: smaller than either, it is bound 2 */
            const double b0 = db2 > 0 ? fmin(nd->area4pi / db2, nd->half_count) : nd->half_count;
            const double e1 = d > r ? 2 * nd->area4pi * r / ((d - r) * (d - r) * (d - r)) : INFINITY;
            const int is_first = o[1] < 0.999 * fmin(b0, e1);
            const double gap = fabs(w - o[0]), rel = o[1] > 0 ? gap / o[1] : 0;
            if (!(gap <= o[1] + 1e-13)) {
                if (bad++ < 5)
                    fprintf(stderr, "  %s node %u at d/r %.3g: sum %.17g, estimate %.17g +- %.3g\n", names[kind],
                            node_of[i], d / r, w, o[0], o[1]);
            }
            if (o[0] != o[2] || o[0] != o[4] || o[1] != o[3] || o[1] != o[5] || o[0] != o[8] || o[0] != o[10] ||
                o[1] != o[9] || o[1] != o[11])
                unpaired++;
            if (!(fabs(o[6] - w) <= 1e-12)) inexact++;
            if (rel > worst) worst = rel;
            if (is_first) {
                first++;
                if (rel > worst_first) worst_first = rel;
                if (d < 3 * r && rel > worst_near) worst_near = rel;
            }
            if (d >= 4 * r && nd->tri_count > 0) {
                far++;
                far_first += (size_t)is_first;
            }
        }
        CHECK_MSG(bad == 0, "%s: %zu of %zu estimates outside their bound", names[kind], bad, pairs);
        CHECK_MSG(unpaired == 0, "%s: %zu estimates of two or four lanes differ from the single one", names[kind], unpaired);
        CHECK_MSG(inexact == 0, "%s: %zu exact node values differ from the brute-force sum", names[kind], inexact);
        CHECK_MSG(far_first == far && far > 0, "%s: the first-order estimate taken at %zu of %zu pairs at d >= 4 r",
                  names[kind], far_first, far);
        printf("cap estimates %-12s %zu caps, %zu nodes, %zu pairs (%zu first-order): |sum - estimate| / bound "
               "at most %.3f, first-order %.3f (%.3f at d < 3 r)\n",
               names[kind], n, nn, pairs, first, worst, worst_first, worst_near);
        clReleaseMemObject(bn);
        clReleaseMemObject(bp);
        clReleaseMemObject(bo);
        clvox__caps_release(&caps);
        free(nodes);
        free(tris);
        free(pts);
        free(res);
        free(node_of);
    }
    clReleaseKernel(k);
}

/* clvox_mesh_prepare_winding: a preparation started ahead gives the same
 * voxels and report as one made by the voxelization; one for another weld
 * is dropped; its errors are the voxelization's; destroying the mesh waits
 * for it (ASan: nothing leaks, nothing read after free). */
static int same_report(const clvox_winding_report *a, const clvox_winding_report *b)
{
    return a->flipped_triangles == b->flipped_triangles && a->cap_triangles == b->cap_triangles &&
           a->holes == b->holes && a->components == b->components && a->merged_vertices == b->merged_vertices &&
           a->welded_vertices == b->welded_vertices && a->cavities == b->cavities;
}

/* clvox_mesh_prepare_winding with the default options but for the weld */
static clvox_status start_ahead(clvox_mesh *m, double weld)
{
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    o.weld = weld;
    return clvox_mesh_prepare_winding(ctx, m, &o);
}

static void test_prepare_ahead(void)
{
    for (size_t i = 0; i < ncases; i++) {
        clvox_mesh *m = to_mesh(&cases[i].mesh);
        if (!m) continue;
        clvox_grid g = test_padded_grid(ctx, clvox_mesh_get_report(m), 24);
        const size_t n = nvox(&g);
        clvox_stats s0 = CLVOX_STATS_INIT, s1 = CLVOX_STATS_INIT;
        uint8_t *plain = run_inside(m, &g, CLVOX_INSIDE_DEFAULT, &s0);
        CHECK_OK(ctx, start_ahead(m, 0.0));
        CHECK_OK(ctx, start_ahead(m, 0.0)); /* on its way: kept */
        uint8_t *ahead = run_inside(m, &g, CLVOX_INSIDE_DEFAULT, &s1);
        CHECK_MSG(ndiff(plain, ahead, n) == 0 && same_report(&s0.winding, &s1.winding),
                  "%s: prepared ahead, %zu voxels differ", cases[i].name, ndiff(plain, ahead, n));
        free(ahead);
        /* for another weld: dropped, prepared again */
        CHECK_OK(ctx, start_ahead(m, 0.5));
        CHECK_OK(ctx, start_ahead(m, 1e-4)); /* replaces the first */
        ahead = run_inside(m, &g, CLVOX_INSIDE_WINDING, &s1);
        CHECK_MSG(ndiff(plain, ahead, n) == 0 && same_report(&s0.winding, &s1.winding),
                  "%s: prepared ahead for another weld, %zu voxels differ", cases[i].name, ndiff(plain, ahead, n));
        free(ahead);
        /* a parity run leaves it for the winding run after it */
        CHECK_OK(ctx, start_ahead(m, 0.0));
        free(run_inside(m, &g, CLVOX_INSIDE_PARITY, NULL));
        ahead = run_inside(m, &g, CLVOX_INSIDE_DEFAULT, &s1);
        CHECK_MSG(ndiff(plain, ahead, n) == 0 && same_report(&s0.winding, &s1.winding),
                  "%s: prepared ahead of a parity run, %zu voxels differ", cases[i].name, ndiff(plain, ahead, n));
        free(ahead);
        free(plain);
        CHECK_OK(ctx, start_ahead(m, 0.0));
        clvox_mesh_destroy(m); /* waits for it */
    }
    /* errors: a weld that leaves no triangle fails the voxelization alike */
    tmesh s = tmesh_sphere(0, 0, 0, 1, 6);
    clvox_mesh *m = to_mesh(&s);
    if (m) {
        clvox_grid g = test_padded_grid(ctx, clvox_mesh_get_report(m), 16);
        clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
        o.weld = 100.0;
        clvox_status st0, st1;
        free(run_in(ctx, m, &g, &o, NULL, &st0));
        char msg0[512];
        snprintf(msg0, sizeof msg0, "%s", clvox_context_error(ctx));
        CHECK_OK(ctx, start_ahead(m, 100.0));
        free(run_in(ctx, m, &g, &o, NULL, &st1));
        CHECK_MSG(st0 == CLVOX_ERR_MESH_EMPTY && st1 == st0 && strcmp(msg0, clvox_context_error(ctx)) == 0,
                  "weld 100: %s (%s) then %s (%s)", clvox_status_string(st0), msg0, clvox_status_string(st1),
                  clvox_context_error(ctx));
        CHECK(start_ahead(m, -1.0) == CLVOX_ERR_INVALID_ARGUMENT);
        CHECK(clvox_mesh_prepare_winding(ctx, NULL, NULL) == CLVOX_ERR_INVALID_ARGUMENT);
        /* options without the winding test start nothing */
        o = (clvox_voxelize_options)CLVOX_VOXELIZE_OPTIONS_INIT;
        o.inside = CLVOX_INSIDE_PARITY;
        CHECK_OK(ctx, clvox_mesh_prepare_winding(ctx, m, &o));
        CHECK(m->ahead == NULL);
        o = (clvox_voxelize_options)CLVOX_VOXELIZE_OPTIONS_INIT;
        o.method = CLVOX_METHOD_TETRA;
        CHECK_OK(ctx, clvox_mesh_prepare_winding(ctx, m, &o));
        CHECK(m->ahead == NULL);
        o = (clvox_voxelize_options)CLVOX_VOXELIZE_OPTIONS_INIT;
        o.mode = CLVOX_MODE_SURFACE;
        CHECK_OK(ctx, clvox_mesh_prepare_winding(ctx, m, &o));
        CHECK(m->ahead == NULL);
        o = (clvox_voxelize_options)CLVOX_VOXELIZE_OPTIONS_INIT;
        o.mode = CLVOX_MODE_CONSERVATIVE; /* its solid part is the ray method's */
        CHECK_OK(ctx, clvox_mesh_prepare_winding(ctx, m, &o));
        CHECK(m->ahead != NULL);
        CHECK_OK(ctx, clvox_mesh_prepare_winding(ctx, m, NULL)); /* the defaults: the same weld, kept */
        CHECK(m->ahead != NULL);
        clvox_mesh_destroy(m);
    }
    tmesh_free(&s);
}

/* Where there are caps, a slab's rays go in batches sized to take about a
 * quarter of a second (src/cast/cast.c ray_slab): the progress callback is called
 * inside a single slab and can cancel it there, and the voxels do not depend
 * on the batches (one slab of 9216 rays, then slabs of 5 slices). */
static int batch_calls, batch_partial, batch_cancel;
static int batch_progress(void *user, double f)
{
    (void)user;
    batch_calls++;
    if (f < 1.0) batch_partial = 1;
    return !(batch_cancel && f < 1.0);
}

/* Does the segment [q0, q0 + len e_axis] come within `eps` of triangle
 * (a, b, c)? (Conservative: near an edge or the plane's ends counts.) */
static int segment_near_triangle(const double *q0, int axis, double len, const double *a, const double *b,
                                 const double *c, double eps)
{
    const int i = (axis + 1) % 3, j = (axis + 2) % 3;
    const double px = q0[i], py = q0[j];
    const double d1 = (b[i] - a[i]) * (py - a[j]) - (b[j] - a[j]) * (px - a[i]);
    const double d2 = (c[i] - b[i]) * (py - b[j]) - (c[j] - b[j]) * (px - b[i]);
    const double d3 = (a[i] - c[i]) * (py - c[j]) - (a[j] - c[j]) * (px - c[i]);
    const double area = (b[i] - a[i]) * (c[j] - a[j]) - (b[j] - a[j]) * (c[i] - a[i]);
    const double m = eps * (fabs(area) + 1e-300) * 8;
    if (!((d1 >= -m && d2 >= -m && d3 >= -m) || (d1 <= m && d2 <= m && d3 <= m))) return 0;
    if (fabs(area) < 1e-14) return 1; /* edge-on */
    /* the plane's coordinate along the axis at (px, py), barycentric */
    const double l1 = d2 / area, l2 = d3 / area, l3 = d1 / area;
    const double t = l1 * a[axis] + l2 * b[axis] + l3 * c[axis];
    return t >= q0[axis] - eps && t <= q0[axis] + len + eps;
}

/* The distance between the segment q0 + [0, len] along axis `axis` and
 * the segment [a, b], by bisection on the convex distance along [a, b]
 * (the distance from a point to an axis-aligned segment is exact). */
static double point_axis_segment_distance(const double *p, const double *q0, int axis, double len)
{
    double d2 = 0;
    for (int c = 0; c < 3; c++) {
        double g = p[c] - q0[c];
        if (c == axis) g = g < 0 ? g : (g > len ? g - len : 0);
        d2 += g * g;
    }
    return sqrt(d2);
}
static double axis_segment_edge_distance(const double *q0, int axis, double len, const double *a, const double *b)
{
    double lo = 0, hi = 1;
    for (int it = 0; it < 200 && hi - lo > 1e-15; it++) { /* ternary search on a convex function */
        const double m1 = lo + (hi - lo) / 3, m2 = hi - (hi - lo) / 3;
        double p1[3], p2[3];
        for (int c = 0; c < 3; c++) {
            p1[c] = a[c] + m1 * (b[c] - a[c]);
            p2[c] = a[c] + m2 * (b[c] - a[c]);
        }
        if (point_axis_segment_distance(p1, q0, axis, len) <= point_axis_segment_distance(p2, q0, axis, len)) hi = m2;
        else lo = m1;
    }
    double p[3];
    for (int c = 0; c < 3; c++) p[c] = a[c] + lo * (b[c] - a[c]);
    return point_axis_segment_distance(p, q0, axis, len);
}

/* The boundary edges of t (those of one triangle only: these meshes are
 * manifold), directed as that triangle has them, into rim (2 indices
 * each, room for 3 nt); keys: scratch of 3 nt. */
static size_t boundary_edges(const tmesh *t, uint64_t *keys, uint32_t *rim)
{
    for (size_t f = 0; f < t->nt; f++)
        for (int e = 0; e < 3; e++) {
            uint64_t a = t->tri[3 * f + e], b = t->tri[3 * f + (e + 1) % 3];
            keys[3 * f + e] = a < b ? a << 32 | b : b << 32 | a;
        }
    size_t nrim = 0;
    for (size_t x = 0; x < t->nt * 3; x++) {
        size_t same = 0;
        for (size_t y = 0; y < t->nt * 3; y++) same += keys[y] == keys[x];
        if (same == 1) {
            rim[2 * nrim] = t->tri[3 * (x / 3) + x % 3];
            rim[2 * nrim + 1] = t->tri[3 * (x / 3) + (x % 3 + 1) % 3];
            nrim++;
        }
    }
    return nrim;
}

/* The rims' second-derivative bound (clvox_rim_bound, which the
 * classify's along-ray interpolation rests on) against the exact winding
 * number's own differences: along a segment that crosses no face, w is
 * smooth, and a second difference (w(t + d) - 2 w(t) + w(t - d)) / d^2 is
 * w'' somewhere between, so it may not exceed the segment's bound. */
static void test_rim_bounds(void)
{
    if (ctx->real_size != 8) {
        printf("rim bounds: skipped (the device has no fp64)\n");
        return;
    }
    cl_kernel k = NULL;
    CHECK_OK(ctx, clvox__kernel(ctx, "clvox_rim_probe", &k));
    if (!k) return;
    const double cyl_c[3] = {0.3, 0.5, 0.5};
    /* the third has more rim edges than a ray's terms hold (CLVOX_RIM_TERMS,
     * kernels/winding_rims.h): its rays' far parts are bounded over the
     * whole ray */
    tmesh shapes[3] = {tmesh_sphere_holes(7, 0.5, 0.5, 0.5, 0.4, 16, 12), tmesh_cylinder(cyl_c, 0, 0.3, 0.4, 24, 6, 0),
                       tmesh_sphere_holes(11, 0.5, 0.5, 0.5, 0.4, 24, 160)};
    static const char *const names[] = {"sphere with 12 holes", "open tube", "sphere with 160 holes"};
    uint64_t seed = 0x7157b0d5;
    for (int sh = 0; sh < 3; sh++) {
        tmesh *t = &shapes[sh];
        clvox_mesh *m = to_mesh(t);
        if (!m) continue;
        clvox_grid g = {{64, 64, 64}, {0, 0, 0}, {1.0 / 64, 1.0 / 64, 1.0 / 64}};
        /* scaled grid space, as clvox__rims_upload puts the edges */
        double *v = malloc(t->nv * 3 * sizeof *v);
        uint64_t *keys = malloc(t->nt * 3 * sizeof *keys);
        uint32_t *rim = malloc(t->nt * 3 * 2 * sizeof *rim);
        CHECK(v && keys && rim);
        double sc[3]; /* the kernels' scale (clvox__winding_scale) */
        clvox__winding_scale(&g, sc);
        for (size_t i = 0; i < t->nv * 3; i++)
            v[i] = (double)clvox__grid_coord(t->xyz[i], g.origin[i % 3], g.voxel_size[i % 3]) * sc[i % 3];
        const size_t nrim = boundary_edges(t, keys, rim);
        clvox__caps rims;
        CHECK_OK(ctx, clvox__rims_upload(ctx, m, &g, rim, nrim, &rims));
        enum { SEGS = 600, STEPS = 8 };
        double *segs = malloc(SEGS * 6 * sizeof *segs), *res = malloc(SEGS * sizeof *res);
        double *len = malloc(SEGS * sizeof *len);
        int *axis = malloc(SEGS * sizeof *axis);
        CHECK(segs && res && len && axis);
        for (int i = 0; i < SEGS; i++) {
            axis[i] = (int)(tmesh_rng_uniform(&seed) * 3);
            len[i] = 0.01 + 0.3 * tmesh_rng_uniform(&seed);
            for (int a = 0; a < 3; a++) segs[6 * i + a] = segs[6 * i + 3 + a] = -0.1 + 1.2 * tmesh_rng_uniform(&seed);
            segs[6 * i + 3 + axis[i]] += len[i];
            /* in world units so far: to the scaled space (cubic voxels: a
             * factor 1 / h) */
            for (int a = 0; a < 6; a++) segs[6 * i + a] *= sc[a % 3] / g.voxel_size[a % 3];
            len[i] *= sc[axis[i]] / g.voxel_size[axis[i]];
        }
        cl_int ce = CL_SUCCESS;
        cl_mem bs = clCreateBuffer(ctx->cl, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, SEGS * 6 * sizeof *segs, segs, &ce);
        cl_mem bo = clCreateBuffer(ctx->cl, CL_MEM_WRITE_ONLY, SEGS * sizeof *res, NULL, &ce);
        cl_uint cnt = SEGS;
        cl_int e = clSetKernelArg(k, 0, sizeof(cl_mem), &rims.nodes);
        e |= clSetKernelArg(k, 1, sizeof(cl_uint), &rims.node_count);
        e |= clSetKernelArg(k, 2, sizeof(cl_mem), &rims.tris);
        e |= clSetKernelArg(k, 3, sizeof(cl_mem), &bs);
        e |= clSetKernelArg(k, 4, sizeof(cl_uint), &cnt);
        e |= clSetKernelArg(k, 5, sizeof(cl_mem), &bo);
        size_t global = SEGS;
        e |= clEnqueueNDRangeKernel(ctx->queue, k, 1, NULL, &global, NULL, 0, NULL, NULL);
        e |= clEnqueueReadBuffer(ctx->queue, bo, CL_TRUE, 0, SEGS * sizeof *res, res, 0, NULL, NULL);
        CHECK(ce == CL_SUCCESS && e == CL_SUCCESS);
        size_t tested = 0, crossing = 0, infinite = 0, bad = 0, below = 0;
        double worst = 0;
        for (int i = 0; i < SEGS; i++) {
            const double *q0 = segs + 6 * i;
            /* every node and term of the tree bounds its edges' own sum from
             * below their distances, so the whole bound is at least the sum
             * over every edge at its exact distance (a term or a far part
             * left out falls under it) */
            double exact_sum = 0;
            for (size_t r = 0; r < nrim; r++) {
                const double *a = v + 3 * (size_t)rim[2 * r], *b = v + 3 * (size_t)rim[2 * r + 1];
                const int a1 = (axis[i] + 1) % 3, a2 = (axis[i] + 2) % 3;
                const double across = hypot(b[a1] - a[a1], b[a2] - a[a2]);
                const double d = axis_segment_edge_distance(q0, axis[i], len[i], a, b);
                exact_sum += 1.5 * across / (4 * PI * d * d * d);
            }
            if (!(res[i] >= exact_sum * (1 - 1e-6)) && below++ < 3)
                fprintf(stderr, "  %s: segment %d: bound %.6g below the edges' own sum %.6g\n", names[sh], i, res[i],
                        exact_sum);
            int near = 0;
            for (size_t f = 0; f < t->nt && !near; f++)
                near = segment_near_triangle(q0, axis[i], len[i], v + 3 * t->tri[3 * f], v + 3 * t->tri[3 * f + 1],
                                             v + 3 * t->tri[3 * f + 2], 1e-9);
            if (near) {
                crossing++;
                continue;
            }
            if (!isfinite(res[i])) {
                infinite++;
                continue;
            }
            double w[STEPS + 1];
            const double d = len[i] / STEPS;
            for (int s = 0; s <= STEPS; s++) {
                double p[3] = {q0[0], q0[1], q0[2]};
                p[axis[i]] += d * s;
                w[s] = 0;
                for (size_t f = 0; f < t->nt; f++) {
                    double A[3], B[3], C[3];
                    for (int a = 0; a < 3; a++) {
                        A[a] = v[3 * t->tri[3 * f] + a] - p[a];
                        B[a] = v[3 * t->tri[3 * f + 1] + a] - p[a];
                        C[a] = v[3 * t->tri[3 * f + 2] + a] - p[a];
                    }
                    w[s] += ref_solid_angle(A, B, C) / (4 * PI);
                }
            }
            tested++;
            const double tol = 1e-12 / (d * d);
            for (int s = 1; s < STEPS; s++) {
                const double g2 = fabs(w[s + 1] - 2 * w[s] + w[s - 1]) / (d * d);
                if (!(g2 <= res[i] + tol) && bad++ < 3)
                    fprintf(stderr, "  %s: segment %d: second difference %.6g > bound %.6g\n", names[sh], i, g2, res[i]);
                if (res[i] > 0 && g2 / res[i] > worst) worst = g2 / res[i];
            }
        }
        CHECK_MSG(bad == 0, "%s: %zu second differences above the rims' bound", names[sh], bad);
        CHECK_MSG(below == 0, "%s: %zu segments' bounds below the sum over every rim edge", names[sh], below);
        CHECK_MSG(tested > SEGS / 2, "%s: only %zu of %d segments tested (%zu cross a face, %zu infinite)", names[sh],
                  tested, SEGS, crossing, infinite);
        /* a bound that is never approached would be useless: the worst
         * difference reaches a fair part of it */
        CHECK_MSG(worst > 0.02, "%s: second differences at most %.3g of the bound", names[sh], worst);
        printf("rim bound %-22s %zu rim edges, %zu segments tested (%zu cross a face, %zu may touch a rim): "
               "second differences at most %.3f of the bound\n",
               names[sh], nrim, tested, crossing, infinite, worst);
        clReleaseMemObject(bs);
        clReleaseMemObject(bo);
        clvox__caps_release(&rims);
        free(segs);
        free(res);
        free(len);
        free(axis);
        free(v);
        free(keys);
        free(rim);
        clvox_mesh_destroy(m);
    }
    tmesh_free(&shapes[0]);
    tmesh_free(&shapes[1]);
    tmesh_free(&shapes[2]);
    clReleaseKernel(k);
}

/* The caps' block lattice (kernels/winding_lattice.h), built by its own
 * kernels for an open surface taken as the caps (its solid angle w_caps,
 * its boundary the rims), against w_caps summed exactly on the host:
 * every interval the lattice gives (K = 0: it holds -w_caps) must hold it,
 * and w_caps's second differences along x in a block must stay within the
 * block's M2. Then whole runs with the lattice (CLVOX_WINDING_LATTICE=1:
 * on these small grids too) and without (=0) give the same voxels on open
 * meshes, and the lattice decides some. */
static uint8_t *run_lattice(const clvox_mesh *m, const clvox_grid *g, int mode, clvox_stats *s)
{
    clvox__test_hooks h = *clvox__hooks(), saved = h;
    h.lattice = mode; /* -1 off, 1 on grids of any size, 0 the library's rule (from 192 voxels) */
    clvox__set_test_hooks(&h);
    *s = (clvox_stats)CLVOX_STATS_INIT;
    uint8_t *v = run_inside(m, g, CLVOX_INSIDE_DEFAULT, s);
    clvox__set_test_hooks(&saved);
    return v;
}

static void test_lattice(void)
{
    if (ctx->real_size != 8) {
        printf("lattice: bounds skipped (the device has no fp64)\n");
    } else {
        cl_kernel k = NULL;
        CHECK_OK(ctx, clvox__kernel(ctx, "clvox_lattice_probe", &k));
        if (!k) return;
        clvox__test_hooks hk = *clvox__hooks(), saved = hk;
        hk.lattice = 1; /* on these small grids too */
        clvox__set_test_hooks(&hk);
        const double cyl_c[3] = {0.3, 0.5, 0.5};
        tmesh shapes[2] = {tmesh_sphere_holes(7, 0.5, 0.5, 0.5, 0.4, 16, 12),
                           tmesh_cylinder(cyl_c, 0, 0.3, 0.4, 24, 6, 0)};
        static const char *const names[] = {"sphere with 12 holes", "open tube"};
        static const uint32_t sizes[] = {64, 160}; /* S = 4 and 8 (winding_lattice.c, CLVOX_WINDING_LATTICE=1) */
        uint64_t seed = 0x1a771ce5;
        size_t split_all = 0;
        for (int sh = 0; sh < 2; sh++)
            for (int gi = 0; gi < 2; gi++) {
                tmesh *t = &shapes[sh];
                clvox_mesh *m = to_mesh(t);
                if (!m) continue;
                const uint32_t N = sizes[gi];
                clvox_grid g = {{N, N, N}, {0, 0, 0}, {1.0 / N, 1.0 / N, 1.0 / N}};
                double sc[3];
                clvox__winding_scale(&g, sc);
                double *v = malloc(t->nv * 3 * sizeof *v);
                float *soup = malloc(t->nt * 9 * sizeof *soup);
                uint64_t *keys = malloc(t->nt * 3 * sizeof *keys);
                uint32_t *rim = malloc(t->nt * 3 * 2 * sizeof *rim);
                CHECK(v && soup && keys && rim);
                for (size_t i = 0; i < t->nv * 3; i++)
                    v[i] = (double)clvox__grid_coord(t->xyz[i], g.origin[i % 3], g.voxel_size[i % 3]) * sc[i % 3];
                for (size_t f = 0; f < t->nt; f++)
                    for (int c = 0; c < 3; c++)
                        for (int a = 0; a < 3; a++)
                            soup[9 * f + 3 * c + a] = clvox__grid_coord(t->xyz[3 * t->tri[3 * f + c] + a], 0, 1.0 / N);
                const size_t nrim = boundary_edges(t, keys, rim);
                clvox__winding_classify w;
                memset(&w, 0, sizeof w);
                CHECK_OK(ctx, clvox__caps_upload(ctx, soup, t->nt, clvox__axes_for(CLVOX_AXIS_X), &g, &w.caps));
                CHECK_OK(ctx, clvox__rims_upload(ctx, m, &g, rim, nrim, &w.rims));
                CHECK_OK(ctx, clvox__winding_lattice_prepare(ctx, &g, 1, &w));
                /* a slab from a plane between the lattice's: z0 = N/4 + 1 */
                const uint32_t z0 = N / 4 + 1, nz = N / 2;
                CHECK_OK(ctx, clvox__winding_lattice_slab(ctx, &g, &w, z0, nz));
                CHECK_MSG(w.lattice_on && w.lat[0] >= 2, "%s at %u: no lattice", names[sh], N);
                enum { PTS = 8000 };
                double *gp = malloc(PTS * 3 * sizeof *gp), *res = malloc(PTS * 5 * sizeof *res);
                CHECK(gp && res);
                /* half at random, half at blocks' centres (where the
                 * interpolation's error bound is the largest) */
                const uint32_t S = w.lat[4];
                for (int i = 0; i < PTS; i++) {
                    gp[3 * i] = (double)(uint32_t)(tmesh_rng_uniform(&seed) * N);
                    gp[3 * i + 1] = (double)(uint32_t)(tmesh_rng_uniform(&seed) * N);
                    gp[3 * i + 2] = (double)(z0 + (uint32_t)(tmesh_rng_uniform(&seed) * nz));
                    if (i % 2)
                        for (int q = 0; q < 3; q++) {
                            const double c = floor(gp[3 * i + q] / S) * S + S / 2;
                            gp[3 * i + q] = q < 2 ? (c < N ? c : c - S) : (c < z0 + nz ? c : c - S);
                        }
                }
                cl_int ce = CL_SUCCESS;
                cl_mem bg = clCreateBuffer(ctx->cl, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, PTS * 3 * sizeof *gp, gp,
                                           &ce);
                cl_mem bo = clCreateBuffer(ctx->cl, CL_MEM_WRITE_ONLY, PTS * 5 * sizeof *res, NULL, &ce);
                cl_uint cnt = PTS, a = 0;
                cl_int e = clSetKernelArg(k, a++, sizeof(cl_mem), &w.caps.h);
                e |= clSetKernelArg(k, a++, sizeof(cl_mem), &w.lat_points);
                e |= clSetKernelArg(k, a++, sizeof(cl_mem), &w.lat_blocks);
                for (int d = 0; d < 5; d++) e |= clSetKernelArg(k, a++, sizeof(cl_uint), &w.lat[d]);
                e |= clSetKernelArg(k, a++, sizeof(cl_mem), &w.lat_split);
                e |= clSetKernelArg(k, a++, sizeof(cl_mem), &w.lat_near);
                e |= clSetKernelArg(k, a++, sizeof(cl_mem), &w.caps.nodes);
                e |= clSetKernelArg(k, a++, sizeof(cl_mem), &w.caps.tris);
                e |= clSetKernelArg(k, a++, sizeof(cl_mem), &w.caps.grid);
                e |= clSetKernelArg(k, a++, sizeof(cl_uint), &w.axis);
                e |= clSetKernelArg(k, a++, sizeof(cl_mem), &bg);
                e |= clSetKernelArg(k, a++, sizeof(cl_uint), &cnt);
                e |= clSetKernelArg(k, a++, sizeof(cl_mem), &bo);
                size_t global = PTS;
                e |= clEnqueueNDRangeKernel(ctx->queue, k, 1, NULL, &global, NULL, 0, NULL, NULL);
                e |= clEnqueueReadBuffer(ctx->queue, bo, CL_TRUE, 0, PTS * 5 * sizeof *res, res, 0, NULL, NULL);
                CHECK(ce == CL_SUCCESS && e == CL_SUCCESS);
                size_t kind[3] = {0, 0, 0}, split = 0, outside = 0, m2_tested = 0, m2_bad = 0;
                double worst = 0, worst_m2 = 0;
                for (int i = 0; i < PTS; i++) {
                    const int how = (int)res[5 * i + 2], in_split = res[5 * i + 4] == 2; /* CLVOX_BLOCK_SPLIT */
                    kind[how]++;
                    if (how == 0) continue;
                    split += (size_t)in_split;
                    /* w_caps at grid point x + dx along x */
                    double wc[3];
                    for (int d = 0; d < 3; d++) {
                        const double p[3] = {(gp[3 * i] + d - 1) * sc[0], gp[3 * i + 1] * sc[1], gp[3 * i + 2] * sc[2]};
                        wc[d] = 0;
                        for (size_t f = 0; f < t->nt; f++) {
                            double A[3], B[3], C[3];
                            for (int q = 0; q < 3; q++) {
                                A[q] = v[3 * t->tri[3 * f] + q] - p[q];
                                B[q] = v[3 * t->tri[3 * f + 1] + q] - p[q];
                                C[q] = v[3 * t->tri[3 * f + 2] + q] - p[q];
                            }
                            wc[d] += ref_solid_angle(A, B, C) / (4 * PI);
                        }
                    }
                    const double lo = res[5 * i], hi = res[5 * i + 1], mid = (lo + hi) / 2, half = (hi - lo) / 2;
                    if (!(-wc[1] >= lo - 1e-12 && -wc[1] <= hi + 1e-12) && outside++ < 3)
                        fprintf(stderr, "  %s at %u: point (%g %g %g): -w_caps %.9g outside [%.9g, %.9g] (%s)\n",
                                names[sh], N, gp[3 * i], gp[3 * i + 1], gp[3 * i + 2], -wc[1], lo, hi,
                                in_split ? "split: near caps summed, far ones interpolated"
                                         : how == 1 ? "interpolated" : "caps' bound");
                    if (how == 1 && !in_split && half > 0 && fabs(-wc[1] - mid) / half > worst)
                        worst = fabs(-wc[1] - mid) / half;
                    /* w_caps is smooth in an interpolating block (no cap near) */
                    const uint32_t xk = (uint32_t)gp[3 * i] % S;
                    if (how == 1 && !in_split && xk != 0) {
                        const double g2 = fabs(wc[2] - 2 * wc[1] + wc[0]) / (sc[0] * sc[0]);
                        m2_tested++;
                        if (!(g2 <= res[5 * i + 3] * (1 + 1e-9) + 1e-9) && m2_bad++ < 3)
                            fprintf(stderr, "  %s at %u: second difference %.6g > block M2 %.6g\n", names[sh], N,
                                    g2, res[5 * i + 3]);
                        if (res[5 * i + 3] > 0 && g2 / res[5 * i + 3] > worst_m2) worst_m2 = g2 / res[5 * i + 3];
                    }
                }
                CHECK_MSG(outside == 0, "%s at %u: %zu lattice intervals miss -w_caps", names[sh], N, outside);
                CHECK_MSG(m2_bad == 0, "%s at %u: %zu second differences above the blocks' M2", names[sh], N, m2_bad);
                CHECK_MSG(kind[1] > PTS / 10 && (sh == 0 || kind[2] > 0), /* the sphere's w_caps is never small */
                          "%s at %u: %zu points interpolated, %zu by the caps' bound, of %d", names[sh], N, kind[1],
                          kind[2], PTS);
                /* intervals that are never approached would decide little */
                CHECK_MSG(worst > 0.05 && worst_m2 > 0.01, "%s at %u: -w_caps within %.3g of the half-widths, "
                          "second differences within %.3g of M2", names[sh], N, worst, worst_m2);
                printf("lattice %-22s %3u^3 (S = %u): %zu of %d points interpolated (%zu in split blocks), %zu by "
                       "the caps' bound; -w_caps at most %.3f of the half-width from the middle; second differences "
                       "at most %.3f of M2 (%zu)\n",
                       names[sh], N, S, kind[1], PTS, split, kind[2], worst, worst_m2, m2_tested);
                split_all += split;
                clReleaseMemObject(bg);
                clReleaseMemObject(bo);
                clvox__winding_classify_release(&w);
                free(gp);
                free(res);
                free(v);
                free(soup);
                free(keys);
                free(rim);
                clvox_mesh_destroy(m);
            }
        /* the blocks near the rims split in near and far caps: their
         * intervals are checked above with the rest */
        CHECK_MSG(split_all > 0, "lattice: no point decided in a split block");
        tmesh_free(&shapes[0]);
        tmesh_free(&shapes[1]);
        clReleaseKernel(k);
        clvox__set_test_hooks(&saved);
    }
    /* whole runs: the same voxels with the lattice and without */
    tmesh t = tmesh_sphere_holes(5, 0.5, 0.5, 0.5, 0.45, 24, 8);
    static const struct { const char *name; uint32_t n; } real[] = {
        {NULL, 72}, {NULL, 136}, {NULL, 200}, {"elephant-with-holes.off", 96}, {"mech-holes-shark.off", 80},
        {"mushroom.off", 72}};
    for (size_t i = 0; i < sizeof real / sizeof real[0]; i++) {
        if (real[i].name && getenv("CLVOX_QUICK")) continue;
        clvox_mesh *m = real[i].name ? load_real(real[i].name) : to_mesh(&t);
        if (!m) continue;
        const uint32_t N = real[i].n;
        clvox_grid g = {{N, N, N}, {0, 0, 0}, {1.0 / N, 1.0 / N, 1.0 / N}};
        if (real[i].name) { /* the mesh's box, cubic voxels (the lattice's) */
            const clvox_mesh_report *r = clvox_mesh_get_report(m);
            double ext = 0;
            for (int a = 0; a < 3; a++) ext = fmax(ext, r->bbox_max[a] - r->bbox_min[a]);
            for (int a = 0; a < 3; a++) {
                g.voxel_size[a] = ext * 1.02 / N;
                g.origin[a] = (r->bbox_min[a] + r->bbox_max[a]) / 2 - g.voxel_size[a] * N / 2;
            }
        }
        clvox_stats on = CLVOX_STATS_INIT, off = CLVOX_STATS_INIT;
        /* at 200 by the library's own rule, below it forced on */
        uint8_t *a = run_lattice(m, &g, N >= 192 ? 0 : 1, &on), *b = run_lattice(m, &g, -1, &off);
        const size_t d = a && b ? ndiff(a, b, nvox(&g)) : 1;
        const char *name = real[i].name ? real[i].name : "sphere with 8 holes";
        CHECK_MSG(d == 0, "%s at %u: %zu voxels differ with the lattice", name, N, d);
        CHECK_MSG(on.winding.exact_points < off.winding.exact_points,
                  "%s at %u: %llu exact points with the lattice, %llu without", name, N,
                  (unsigned long long)on.winding.exact_points, (unsigned long long)off.winding.exact_points);
        printf("lattice run %-24s %3u^3: same voxels, %llu exact points (%llu without)\n", name, N,
               (unsigned long long)on.winding.exact_points, (unsigned long long)off.winding.exact_points);
        free(a);
        free(b);
        clvox_mesh_destroy(m);
    }
    tmesh_free(&t);
}

static void test_batches(void)
{
    tmesh t = tmesh_sphere_holes(5, 0.5, 0.5, 0.5, 0.45, 24, 8);
    clvox_mesh *m = to_mesh(&t);
    if (!m) return;
    clvox_grid g = {{96, 96, 96}, {0, 0, 0}, {1.0 / 96, 1.0 / 96, 1.0 / 96}};
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    o.ray_axis = CLVOX_AXIS_X;
    o.slab_depth = 96;
    o.progress = batch_progress;
    batch_calls = batch_partial = batch_cancel = 0;
    clvox_stats s1 = CLVOX_STATS_INIT, s2 = CLVOX_STATS_INIT;
    uint8_t *one = run(m, &g, &o, &s1);
    CHECK_MSG(s1.winding.cap_triangles > 0 && batch_partial, "one slab: %d progress calls, none inside it (%llu caps)", batch_calls, (unsigned long long)s1.winding.cap_triangles);
    o.slab_depth = 5;
    o.progress = NULL;
    uint8_t *many = run(m, &g, &o, &s2);
    CHECK_MSG(ndiff(one, many, nvox(&g)) == 0 && s1.winding.exact_points == s2.winding.exact_points,
              "one slab vs slabs of 5: %zu voxels differ, exact points %llu vs %llu", ndiff(one, many, nvox(&g)),
              (unsigned long long)s1.winding.exact_points, (unsigned long long)s2.winding.exact_points);
    o.slab_depth = 96;
    o.progress = batch_progress;
    batch_cancel = 1;
    clvox_status st;
    free(run_in(ctx, m, &g, &o, NULL, &st));
    CHECK_MSG(st == CLVOX_ERR_CANCELLED && strstr(clvox_context_error(ctx), "within slab"),
              "cancelled inside the slab: %s (%s)", clvox_status_string(st), clvox_context_error(ctx));
    free(one);
    free(many);
    clvox_mesh_destroy(m);
    tmesh_free(&t);
}

int main(int argc, char **argv)
{
    /* test_winding [oracle | SECTION]: only the CPU oracle, or only the
     * device sections whose name contains SECTION (e.g. real, union) */
    const char *only = argc > 1 ? argv[1] : NULL;
    int oracle_only = only && strcmp(only, "oracle") == 0;
    if (!only || oracle_only) {
        test_oracle_closed_forms();
        test_oracle_two_formulas();
        test_corpus_shapes();
        test_oracle_voxelize();
        test_oracle_fast_voxelize();
    }
    if (oracle_only) return test_report();
    setenv("POCL_DEVICES", "pthread pthread", 0); /* two devices for test_invariance */
    ctx = test_context();
    ncases = tmesh_winding_corpus(cases, MAX_CASES);
    static const struct { const char *name; void (*fn)(void); } sections[] = {
        {"options", test_options},         {"corpus", test_corpus_against_oracle},
        {"invariance", test_invariance},   {"closed", test_closed_same_as_parity},
        {"union", test_unions},            {"cavities", test_cavities},
        {"report", test_winding_report},   {"real", test_real_open},
        {"coverage", test_coverage_samples}, {"apex", test_apex},
        {"estimates", test_cap_estimates}, {"ahead", test_prepare_ahead},
        {"batches", test_batches},         {"rims", test_rim_bounds},
        {"lattice", test_lattice},
    };
    for (size_t i = 0; i < sizeof sections / sizeof sections[0]; i++)
        if (!only || strstr(sections[i].name, only)) sections[i].fn();
    for (size_t i = 0; i < ncases; i++) tmesh_case_free(&cases[i]);
    clvox_context_destroy(ctx);
    return test_report();
}
