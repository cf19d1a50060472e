/* SPDX-License-Identifier: Apache-2.0 */
/* Past 800 lines on purpose: one test program per mode, its oracles (GMP
 * predicates, brute force) shared by every case. */
/* Surface and conservative voxelization (docs/design.md "Surface
 * voxelization"). Oracles nobody tuned:
 *  - the exact predicates of kernels/overlap.h against GMP rationals, on
 *    random, nearly degenerate and exactly degenerate inputs;
 *  - a CPU reference that clips each triangle by each closed cell of its
 *    bounding box (Sutherland-Hodgman in GMP rationals: a different
 *    algorithm from the kernel's separating axes), compared bit for bit
 *    with the device on random soups (degenerate triangles, vertices on the
 *    cell lattice, triangles leaving the grid), grid-aligned boxes, closed
 *    meshes, anisotropic grids and the real meshes (data/meshes);
 *  - analytic counts: a point on a cell corner / edge / face / inside marks
 *    8 / 4 / 2 / 1 cells (and one float step off the corner 1, 2 or 4), a
 *    segment on a cell edge, boxes with faces on cell faces ((n+2)^3 -
 *    (n-2)^3 surface, (n+2)^3 conservative) and between centres (n^3 -
 *    (n-2)^3, n^3);
 *  - containment: points sampled on every triangle fall in marked voxels;
 *    reach: every marked voxel's centre is within sqrt(3)/2 of a triangle;
 *  - conservative == solid | surface (ray and tetra), slab depth and ray
 *    axis do not matter, the EXR records the mode, bad arguments, the CLI.
 * CLVOX_SURFACE_REAL_RES=n sets the real meshes' resolution (default 40). */
#include "test.h"
#include "meshgen.h"

#include <gmp.h>
#include <math.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include "../kernels/overlap.h"
#include "gmp_predicates.h"

static clvox_context *ctx;

/* ---- exact predicates vs GMP (tests/gmp_predicates.h) ------------------- */

static uint64_t rng = 12345;
static double uni(void) { return tmesh_rng_uniform(&rng); }
/* A float: ordinary, tiny, huge, on the half-integer lattice, or a copy. */
static float rand_coord(void)
{
    double r = uni();
    if (r < 0.3) return (float)((uni() - 0.5) * 64.0);
    if (r < 0.5) return (float)(floor(uni() * 64.0) * 0.5 - 16.0);
    if (r < 0.6) return (float)((uni() - 0.5) * 1e-20);
    if (r < 0.7) return (float)((uni() - 0.5) * 1e25);
    return (float)((uni() - 0.5) * 4.0);
}

static void test_predicates(void)
{
    int bad_e2 = 0, bad_o3 = 0, zeros = 0;
    for (int it = 0; it < 200000; it++) {
        double p[8];
        for (int i = 0; i < 8; i++) p[i] = rand_coord();
        if (it % 3 == 1) { /* d nearly on the line a b (rounded to float) */
            double t = uni() * 3 - 1;
            p[6] = (float)(p[0] + t * (p[2] - p[0]));
            p[7] = (float)(p[1] + t * (p[3] - p[1]));
            p[4] = p[0], p[5] = p[1];
        }
        if (it % 7 == 2) p[2] = p[0]; /* vertical edge */
        int g = gmp_e2(p), s = clvox_e2_sign(p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]);
        zeros += g == 0;
        if (g != s && bad_e2++ < 3) fprintf(stderr, "  e2 %d vs gmp %d\n", s, g);
    }
    for (int it = 0; it < 100000; it++) {
        double v[9], q[3];
        for (int i = 0; i < 9; i++) v[i] = rand_coord();
        for (int i = 0; i < 3; i++) q[i] = rand_coord();
        if (it % 3 == 1) { /* q nearly in the plane: an affine combination rounded to float */
            double s = uni() * 2 - 0.5, t = uni() * 2 - 0.5;
            for (int i = 0; i < 3; i++) q[i] = (float)(v[i] + s * (v[3 + i] - v[i]) + t * (v[6 + i] - v[i]));
        }
        if (it % 5 == 2) /* a lattice triangle and corner: many exact zeros */
            for (int i = 0; i < 3; i++) {
                v[i] = floor(uni() * 8) * 0.5, v[3 + i] = floor(uni() * 8) * 0.5, v[6 + i] = floor(uni() * 8) * 0.5;
                q[i] = floor(uni() * 8) * 0.5 - 0.5;
            }
        int g = gmp_o3(v, q), s = clvox_o3_sign(v, q[0], q[1], q[2]);
        zeros += g == 0;
        if (g != s && bad_o3++ < 3) fprintf(stderr, "  o3 %d vs gmp %d\n", s, g);
    }
    CHECK_MSG(bad_e2 == 0, "%d of 200000 2x2 signs differ from GMP", bad_e2);
    CHECK_MSG(bad_o3 == 0, "%d of 100000 3x3 signs differ from GMP", bad_o3);
    CHECK_MSG(zeros > 500, "only %d exact zeros: the degenerate cases were not exercised", zeros);
}

/* ---- CPU reference: exact clipping in rationals ---------------------------- */

static mpq_t poly[2][12][3], rq_t, rq_u, rq_b;

static void ref_init(void)
{
    for (int b = 0; b < 2; b++)
        for (int i = 0; i < 12; i++)
            for (int a = 0; a < 3; a++) mpq_init(poly[b][i][a]);
    mpq_inits(rq_t, rq_u, rq_b, NULL);
}
static void ref_done(void)
{
    for (int b = 0; b < 2; b++)
        for (int i = 0; i < 12; i++)
            for (int a = 0; a < 3; a++) mpq_clear(poly[b][i][a]);
    mpq_clears(rq_t, rq_u, rq_b, NULL);
}

/* Does the closed triangle v (grid space) meet the closed cell c +- 1/2? A
 * vertex inside is a yes; otherwise the triangle is clipped by the cell's
 * six closed half-spaces and the answer is whether anything is left. */
static int ref_overlap(const double *v, const int c[3])
{
    for (int p = 0; p < 3; p++) {
        int in = 1;
        for (int a = 0; a < 3; a++) in &= v[3 * p + a] >= c[a] - 0.5 && v[3 * p + a] <= c[a] + 0.5;
        if (in) return 1;
    }
    int n = 3, cur = 0;
    for (int p = 0; p < 3; p++)
        for (int a = 0; a < 3; a++) mpq_set_d(poly[0][p][a], v[3 * p + a]);
    for (int a = 0; a < 3 && n; a++)
        for (int side = 0; side < 2 && n; side++) {
            /* keep sg * (x_a - b) >= 0 */
            const int sg = side ? -1 : 1;
            mpq_set_d(rq_b, c[a] + (side ? 0.5 : -0.5));
            int m = 0;
            for (int i = 0; i < n; i++) {
                mpq_t *S = poly[cur][(i + n - 1) % n], *E = poly[cur][i];
                int dS = sg * mpq_cmp(S[a], rq_b), dE = sg * mpq_cmp(E[a], rq_b);
                if ((dE >= 0) != (dS >= 0)) { /* the edge crosses: S + t (E - S), t = (b - S_a) / (E_a - S_a) */
                    mpq_sub(rq_t, rq_b, S[a]);
                    mpq_sub(rq_u, E[a], S[a]);
                    mpq_div(rq_t, rq_t, rq_u);
                    for (int k = 0; k < 3; k++) {
                        mpq_sub(rq_u, E[k], S[k]);
                        mpq_mul(rq_u, rq_u, rq_t);
                        mpq_add(poly[!cur][m][k], S[k], rq_u);
                    }
                    m++;
                }
                if (dE >= 0) {
                    for (int k = 0; k < 3; k++) mpq_set(poly[!cur][m][k], E[k]);
                    m++;
                }
            }
            n = m;
            cur = !cur;
        }
    return n > 0;
}

/* Grid-space soup exactly as src/grid/grid.c makes it. Caller frees. */
static double *grid_soup(const clvox_mesh *mesh, const clvox_grid *g, size_t *nt_out)
{
    size_t nv, nt;
    const float *xyz = clvox_mesh_vertices(mesh, &nv);
    const uint32_t *tri = clvox_mesh_triangles(mesh, &nt);
    double off[3];
    clvox_mesh_vertex_offset(mesh, off);
    double *s = malloc((nt ? nt : 1) * 9 * sizeof *s);
    if (!s) abort();
    for (size_t t = 0; t < nt; t++)
        for (int c = 0; c < 3; c++)
            for (int a = 0; a < 3; a++)
                s[t * 9 + c * 3 + a] = (float)(((double)xyz[(size_t)tri[3 * t + c] * 3 + a] - (g->origin[a] - off[a])) /
                                                   g->voxel_size[a] -
                                               0.5);
    *nt_out = nt;
    return s;
}

static size_t voxels(const clvox_grid *g) { return (size_t)g->dims[0] * g->dims[1] * g->dims[2]; }

/* Reference surface volume (X*Y*Z bytes, caller frees); *count = marked. */
static uint8_t *ref_surface(const clvox_mesh *mesh, const clvox_grid *g, uint64_t *count)
{
    size_t nt;
    double *s = grid_soup(mesh, g, &nt);
    uint8_t *out = calloc(voxels(g), 1);
    if (!out) abort();
    for (size_t t = 0; t < nt; t++) {
        const double *v = s + 9 * t;
        int lo[3], hi[3], empty = 0;
        for (int a = 0; a < 3; a++) {
            double mn = fmin(fmin(v[a], v[3 + a]), v[6 + a]), mx = fmax(fmax(v[a], v[3 + a]), v[6 + a]);
            /* cells whose closed extent meets [mn, mx], within the grid */
            double l = fmin(fmax(floor(mn) - 1, 0.0), (double)g->dims[a]); /* fails the test below, or 0 */
            double h = fmax(fmin(ceil(mx) + 1, (double)g->dims[a] - 1), -1.0);
            lo[a] = (int)l, hi[a] = (int)h;
            while (lo[a] < (int)g->dims[a] && lo[a] + 0.5 < mn) lo[a]++; /* cell i: i + 1/2 >= mn, i - 1/2 <= mx */
            while (hi[a] >= 0 && hi[a] - 0.5 > mx) hi[a]--;
            empty |= lo[a] > hi[a];
        }
        if (empty) continue;
        int c[3];
        for (c[2] = lo[2]; c[2] <= hi[2]; c[2]++)
            for (c[1] = lo[1]; c[1] <= hi[1]; c[1]++)
                for (c[0] = lo[0]; c[0] <= hi[0]; c[0]++) {
                    size_t i = ((size_t)c[2] * g->dims[1] + (size_t)c[1]) * g->dims[0] + (size_t)c[0];
                    if (!out[i] && ref_overlap(v, c)) out[i] = 1;
                }
    }
    free(s);
    uint64_t n = 0;
    for (size_t i = 0; i < voxels(g); i++) n += out[i];
    if (count) *count = n;
    return out;
}

/* ---- device runs -------------------------------------------------------- */

static clvox_mesh *to_mesh(const tmesh *m)
{
    clvox_mesh *mesh = NULL;
    CHECK_OK(ctx, clvox_mesh_from_arrays(ctx, m->xyz, m->nv, m->tri, m->nt, &mesh));
    return mesh;
}

static clvox_grid grid_box(double x0, double y0, double z0, double x1, double y1, double z1, uint32_t X, uint32_t Y,
                           uint32_t Z)
{
    clvox_grid_options o = CLVOX_GRID_OPTIONS_INIT;
    o.dims[0] = X, o.dims[1] = Y, o.dims[2] = Z;
    double lo[3] = {x0, y0, z0}, hi[3] = {x1, y1, z1};
    clvox_grid g;
    memset(&g, 0, sizeof g);
    CHECK_OK(ctx, clvox_grid_compute(ctx, &o, lo, hi, &g));
    return g;
}

static uint8_t *run_mode(const clvox_mesh *mesh, const clvox_grid *g, clvox_mode mode, clvox_method method,
                         uint32_t slab, clvox_axis axis, uint64_t *filled)
{
    size_t n = voxels(g);
    uint8_t *v = malloc(n);
    if (!v) abort();
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    o.mode = mode;
    o.method = method;
    o.slab_depth = slab;
    o.ray_axis = axis;
    clvox_stats st = CLVOX_STATS_INIT;
    clvox_status s = clvox_voxelize_to_memory(ctx, mesh, g, &o, v, n, &st);
    CHECK_OK(ctx, s);
    if (s != CLVOX_OK) memset(v, 0, n);
    uint64_t c = 0;
    for (size_t i = 0; i < n; i++) c += v[i];
    CHECK_MSG(s != CLVOX_OK || c == st.filled_voxels, "counted %llu, stats %llu", (unsigned long long)c,
              (unsigned long long)st.filled_voxels);
    if (filled) *filled = c;
    return v;
}

static size_t diff(const clvox_grid *g, const uint8_t *a, const uint8_t *b, const char *what)
{
    size_t n = voxels(g), d = 0;
    for (size_t i = 0; i < n; i++)
        if (a[i] != b[i]) {
            if (d < 4)
                fprintf(stderr, "  %s: voxel (%zu,%zu,%zu) %d vs %d\n", what, i % g->dims[0],
                        i / g->dims[0] % g->dims[1], i / ((size_t)g->dims[0] * g->dims[1]), a[i], b[i]);
            d++;
        }
    return d;
}

/* Device surface == reference, bit for bit; returns the device volume. */
static uint8_t *check_vs_reference(const char *name, const clvox_mesh *mesh, const clvox_grid *g, uint32_t slab)
{
    uint64_t nd = 0, nr = 0;
    uint8_t *d = run_mode(mesh, g, CLVOX_MODE_SURFACE, CLVOX_METHOD_RAY, slab, CLVOX_AXIS_DEFAULT, &nd);
    uint8_t *r = ref_surface(mesh, g, &nr);
    size_t bad = diff(g, d, r, name);
    CHECK_MSG(bad == 0, "%s: %zu voxels differ from the reference (device %llu, reference %llu marked)", name, bad,
              (unsigned long long)nd, (unsigned long long)nr);
    free(r);
    return d;
}

/* ---- analytic cases --------------------------------------------------------- */

/* One triangle (grid-space corners; grid [0,16]^3 with h = 1, so grid
 * coordinate g is world g + 1/2): marked count. */
static uint64_t one_triangle(const double a[3], const double b[3], const double c[3])
{
    tmesh m = {0};
    tmesh_add_vertex(&m, a[0] + 0.5, a[1] + 0.5, a[2] + 0.5);
    tmesh_add_vertex(&m, b[0] + 0.5, b[1] + 0.5, b[2] + 0.5);
    tmesh_add_vertex(&m, c[0] + 0.5, c[1] + 0.5, c[2] + 0.5);
    tmesh_add_tri(&m, 0, 1, 2);
    clvox_mesh *mesh = to_mesh(&m);
    clvox_grid g = grid_box(0, 0, 0, 16, 16, 16, 16, 16, 16);
    uint64_t n = 0;
    if (mesh) {
        free(check_vs_reference("one triangle", mesh, &g, 0));
        free(run_mode(mesh, &g, CLVOX_MODE_SURFACE, CLVOX_METHOD_RAY, 0, CLVOX_AXIS_DEFAULT, &n));
    }
    clvox_mesh_destroy(mesh);
    tmesh_free(&m);
    return n;
}

static void test_touching(void)
{
    double corner[3] = {4.5, 6.5, 8.5}, edge[3] = {4.5, 6.5, 8.0}, face[3] = {4.5, 6.25, 8.0}, in[3] = {4.25, 6.0, 8.1};
    CHECK(one_triangle(corner, corner, corner) == 8); /* a point on a cell corner: the 8 cells around it */
    CHECK(one_triangle(edge, edge, edge) == 4);
    CHECK(one_triangle(face, face, face) == 2);
    CHECK(one_triangle(in, in, in) == 1);
    double off[3] = {nextafterf(4.5f, 5.0f), 6.5, 8.5}; /* one float step off the corner along +x */
    CHECK(one_triangle(off, off, off) == 4);
    double off2[3] = {nextafterf(4.5f, 5.0f), nextafterf(6.5f, 0.0f), 8.5};
    CHECK(one_triangle(off2, off2, off2) == 2);
    /* a segment on the cell edge x = 4.5, y = 6.5 from z = 1.2 to 4.7: 4 columns x cells 1..5 */
    double s0[3] = {4.5, 6.5, 1.25}, s1[3] = {4.5, 6.5, 4.75};
    CHECK(one_triangle(s0, s1, s1) == 20);
    /* a triangle in the cell face plane x = 4.5: both sides of it */
    double f0[3] = {4.5, 2.0, 2.0}, f1[3] = {4.5, 2.0, 5.0}, f2[3] = {4.5, 5.0, 2.0};
    uint64_t both = one_triangle(f0, f1, f2);
    double g0[3] = {4.4, 2.0, 2.0}, g1[3] = {4.4, 2.0, 5.0}, g2[3] = {4.4, 5.0, 2.0};
    uint64_t one = one_triangle(g0, g1, g2);
    CHECK_MSG(both == 2 * one && one == 13, "face plane: %llu cells, just inside one cell layer %llu",
              (unsigned long long)both, (unsigned long long)one);
    /* touching a cell only at its corner from outside: the triangle ends at
     * the corner (4.5,6.5,8.5) and goes away towards -x-y-z */
    double t0[3] = {4.5, 6.5, 8.5}, t1[3] = {3.7, 6.4, 8.2}, t2[3] = {4.2, 5.8, 8.4};
    CHECK(one_triangle(t0, t1, t2) == 8);
}

/* Box [A - d, B + d] in grid space (A, B integers) on a padded grid. */
static void test_boxes(void)
{
    const int A = 3, B = 12, n = B - A + 1;
    for (int onface = 0; onface < 2; onface++) {
        double d = onface ? 0.5 : 0.3;
        tmesh m = tmesh_box_subdivided(A - d + 0.5, A - d + 0.5, A - d + 0.5, B + d + 0.5, B + d + 0.5, B + d + 0.5, 3);
        clvox_mesh *mesh = to_mesh(&m);
        clvox_grid g = grid_box(0, 0, 0, 18, 17, 16, 18, 17, 16);
        if (mesh) {
            uint64_t ns = 0, nc = 0, nsol = 0, nt = 0;
            uint8_t *s = check_vs_reference(onface ? "box on cell faces" : "box between centres", mesh, &g, 0);
            for (size_t i = 0; i < voxels(&g); i++) ns += s[i];
            uint8_t *c = run_mode(mesh, &g, CLVOX_MODE_CONSERVATIVE, CLVOX_METHOD_RAY, 0, CLVOX_AXIS_DEFAULT, &nc);
            uint8_t *so = run_mode(mesh, &g, CLVOX_MODE_SOLID, CLVOX_METHOD_RAY, 0, CLVOX_AXIS_DEFAULT, &nsol);
            uint8_t *ct = run_mode(mesh, &g, CLVOX_MODE_CONSERVATIVE, CLVOX_METHOD_TETRA, 0, CLVOX_AXIS_DEFAULT, &nt);
            uint64_t outer = onface ? (uint64_t)(n + 2) * (n + 2) * (n + 2) : (uint64_t)n * n * n;
            uint64_t inner = (uint64_t)(n - 2) * (n - 2) * (n - 2);
            CHECK_MSG(ns == outer - inner, "box d=%g: surface %llu, expected %llu", d, (unsigned long long)ns,
                      (unsigned long long)(outer - inner));
            CHECK_MSG(nc == outer && nt == outer, "box d=%g: conservative %llu (tetra %llu), expected %llu", d,
                      (unsigned long long)nc, (unsigned long long)nt, (unsigned long long)outer);
            CHECK(nsol == (uint64_t)n * n * n);
            CHECK(diff(&g, c, ct, "conservative ray vs tetra") == 0);
            free(s), free(c), free(so), free(ct);
        }
        clvox_mesh_destroy(mesh);
        tmesh_free(&m);
    }
}

/* ---- random soups and closed meshes ------------------------------------- */

static tmesh random_soup(uint64_t seed, int count, double X, double Y, double Z)
{
    uint64_t r = seed;
    tmesh m = {0};
    for (int t = 0; t < count; t++) {
        double kind = tmesh_rng_uniform(&r), c[3], v[3][3];
        double size = kind < 0.6 ? 1.5 : kind < 0.85 ? 6.0 : 30.0;
        for (int a = 0; a < 3; a++) c[a] = (tmesh_rng_uniform(&r) * 1.2 - 0.1) * (a == 0 ? X : a == 1 ? Y : Z);
        int lattice = tmesh_rng_uniform(&r) < 0.4;
        for (int p = 0; p < 3; p++)
            for (int a = 0; a < 3; a++) {
                double x = c[a] + (tmesh_rng_uniform(&r) - 0.5) * size;
                if (lattice) x = floor(x * 2.0) * 0.5; /* cell faces and centres (world = grid + 1/2) */
                v[p][a] = x;
            }
        double d = tmesh_rng_uniform(&r);
        if (d < 0.05) memcpy(v[1], v[0], sizeof v[0]), memcpy(v[2], v[0], sizeof v[0]);  /* a point */
        else if (d < 0.1) memcpy(v[2], v[1], sizeof v[0]);                                /* a segment */
        else if (d < 0.15) for (int a = 0; a < 3; a++) v[2][a] = 2 * v[1][a] - v[0][a];   /* collinear */
        uint32_t i0 = tmesh_add_vertex(&m, v[0][0], v[0][1], v[0][2]);
        uint32_t i1 = tmesh_add_vertex(&m, v[1][0], v[1][1], v[1][2]);
        uint32_t i2 = tmesh_add_vertex(&m, v[2][0], v[2][1], v[2][2]);
        tmesh_add_tri(&m, i0, i1, i2);
    }
    return m;
}

static void test_random_soups(void)
{
    for (uint64_t seed = 1; seed <= 6; seed++) {
        const uint32_t X = 20 + (uint32_t)seed * 3, Y = 17, Z = 23 - (uint32_t)seed;
        tmesh m = random_soup(seed, 120, X, Y, Z);
        clvox_mesh *mesh = to_mesh(&m);
        /* anisotropic voxels for even seeds: world box stretched per axis */
        double sx = seed & 1 ? 1.0 : 0.75, sy = seed & 1 ? 1.0 : 1.5;
        if (seed % 2 == 0) {
            for (size_t i = 0; i < m.nv; i++) m.xyz[3 * i] *= (float)sx, m.xyz[3 * i + 1] *= (float)sy;
            clvox_mesh_destroy(mesh);
            mesh = to_mesh(&m);
        }
        clvox_grid g = grid_box(0, 0, 0, X * sx, Y * sy, Z, X, Y, Z);
        if (mesh) {
            char name[64];
            snprintf(name, sizeof name, "random soup %llu", (unsigned long long)seed);
            uint8_t *a = check_vs_reference(name, mesh, &g, 0);
            uint8_t *b = run_mode(mesh, &g, CLVOX_MODE_SURFACE, CLVOX_METHOD_RAY, 1, CLVOX_AXIS_DEFAULT, NULL);
            uint8_t *c = run_mode(mesh, &g, CLVOX_MODE_SURFACE, CLVOX_METHOD_TETRA, 5, CLVOX_AXIS_Z, NULL);
            CHECK(diff(&g, a, b, "slab 1") == 0);
            CHECK(diff(&g, a, c, "slab 5, tetra, z") == 0);
            free(a), free(b), free(c);
        }
        clvox_mesh_destroy(mesh);
        tmesh_free(&m);
    }
}

/* Triangles whose projection along some axis k is a segment (n_k = 0
 * exactly: c = a + lambda e_k), and slivers: the kernel keeps both sides of
 * the edge axes in that projection and only the outward side where n_k != 0
 * (kernels/surface.cl); both against the reference. */
static void test_projection_soups(void)
{
    for (uint64_t seed = 11; seed <= 14; seed++) {
        uint64_t r = seed;
        const uint32_t X = 19, Y = 16, Z = 14;
        tmesh m = {0};
        for (int t = 0; t < 150; t++) {
            double v[3][3];
            const int lattice = tmesh_rng_uniform(&r) < 0.5, k = (int)(tmesh_rng_uniform(&r) * 3.0) % 3;
            const double size = tmesh_rng_uniform(&r) < 0.7 ? 2.0 : 8.0;
            for (int a = 0; a < 3; a++) {
                const double c = tmesh_rng_uniform(&r) * (a == 0 ? X : a == 1 ? Y : Z);
                for (int p = 0; p < 2; p++) {
                    double x = c + (tmesh_rng_uniform(&r) - 0.5) * size;
                    v[p][a] = lattice ? floor(x * 2.0) * 0.5 : x;
                }
            }
            const int base = tmesh_rng_uniform(&r) < 0.5 ? 0 : 1;
            const double lambda = (tmesh_rng_uniform(&r) - 0.5) * size;
            memcpy(v[2], v[base], sizeof v[0]);
            if (t % 3 == 2) { /* a sliver: c just off the line a + lambda e_k */
                for (int a = 0; a < 3; a++) v[2][a] += (a == k ? lambda : 1e-3 * (tmesh_rng_uniform(&r) - 0.5));
            } else {
                v[2][k] += lattice ? floor(lambda * 2.0) * 0.5 : lambda;
            }
            uint32_t i0 = tmesh_add_vertex(&m, v[0][0], v[0][1], v[0][2]);
            uint32_t i1 = tmesh_add_vertex(&m, v[1][0], v[1][1], v[1][2]);
            uint32_t i2 = tmesh_add_vertex(&m, v[2][0], v[2][1], v[2][2]);
            tmesh_add_tri(&m, i0, i1, i2);
        }
        clvox_mesh *mesh = to_mesh(&m);
        clvox_grid g = grid_box(0, 0, 0, X, Y, Z, X, Y, Z);
        if (mesh) {
            char name[64];
            snprintf(name, sizeof name, "axis-parallel soup %llu", (unsigned long long)seed);
            uint8_t *a = check_vs_reference(name, mesh, &g, 3);
            free(a);
        }
        clvox_mesh_destroy(mesh);
        tmesh_free(&m);
    }
}

/* Row directions (kernels/surface.cl rasterises each task along the axis
 * with the fewest rows in its box: x, y or z; a y or z row sets one bit per
 * cell). Triangles facing each axis: flat on a cell face (world integers
 * here), flat on a plane of cell centres, tilted a little, slivers, and long
 * ones that cross the tasks' row (32) and slice (8) chunks and the slabs;
 * against the reference with slab depths 0 (auto), 1 and 5. The data must
 * give each row direction many triangles (counted with the rule on whole
 * triangle boxes, each triangle's exact cell ranges). */
static void test_row_axes(void)
{
    for (uint64_t seed = 21; seed <= 24; seed++) {
        uint64_t r = seed;
        const uint32_t X = 38, Y = 41, Z = 37;
        tmesh m = {0};
        for (int t = 0; t < 180; t++) {
            const int a = t % 3, b = (a + 1) % 3, c = (a + 2) % 3; /* the normal is mostly along a */
            const int shape = (t / 3) % 5;
            const double dims[3] = {X, Y, Z};
            const double size = shape == 4 ? 36.0 : tmesh_rng_uniform(&r) < 0.6 ? 4.0 : 12.0;
            double v[3][3], plane = floor(tmesh_rng_uniform(&r) * dims[a]);
            if (shape == 1) plane += 0.5;                     /* cell centres */
            double cb = tmesh_rng_uniform(&r) * dims[b], cc = tmesh_rng_uniform(&r) * dims[c];
            for (int q = 0; q < 3; q++) {
                v[q][b] = cb + (tmesh_rng_uniform(&r) - 0.5) * size;
                v[q][c] = cc + (tmesh_rng_uniform(&r) - 0.5) * size;
                v[q][a] = plane;
                if (shape == 2) v[q][a] += (tmesh_rng_uniform(&r) - 0.5) * 0.3 * size; /* tilted */
            }
            if (shape == 3) /* a sliver: the third vertex just off the first edge */
                for (int k = 0; k < 3; k++)
                    v[2][k] = 0.5 * (v[0][k] + v[1][k]) + (k == a ? 0.0 : 1e-3 * (tmesh_rng_uniform(&r) - 0.5));
            if (shape == 4 && tmesh_rng_uniform(&r) < 0.5) /* long along b or c, on a lattice */
                for (int q = 0; q < 3; q++) v[q][b] = floor(v[q][b] * 2.0) * 0.5, v[q][c] = floor(v[q][c] * 2.0) * 0.5;
            uint32_t i0 = tmesh_add_vertex(&m, v[0][0], v[0][1], v[0][2]);
            uint32_t i1 = tmesh_add_vertex(&m, v[1][0], v[1][1], v[1][2]);
            uint32_t i2 = tmesh_add_vertex(&m, v[2][0], v[2][1], v[2][2]);
            tmesh_add_tri(&m, i0, i1, i2);
        }
        clvox_mesh *mesh = to_mesh(&m);
        clvox_grid g = grid_box(0, 0, 0, X, Y, Z, X, Y, Z);
        if (mesh) {
            size_t nt = 0, by_axis[3] = {0, 0, 0};
            double *soup = grid_soup(mesh, &g, &nt);
            for (size_t t = 0; t < nt; t++) {
                long n[3];
                int in = 1;
                for (int k = 0; k < 3; k++) {
                    const double *s = soup + 9 * t;
                    double mn = fmin(fmin(s[k], s[3 + k]), s[6 + k]), mx = fmax(fmax(s[k], s[3 + k]), s[6 + k]);
                    double lo = fmax(0.0, ceil(mn - 0.5)), hi = fmin((double)g.dims[k] - 1.0, floor(mx + 0.5));
                    n[k] = (long)(hi - lo) + 1;
                    in = in && hi >= lo;
                }
                if (!in) continue;
                int ax = 0;
                long best = n[1] * n[2];
                if (n[0] * n[2] < best) best = n[0] * n[2], ax = 1;
                if (n[0] * n[1] < best) ax = 2;
                by_axis[ax]++;
            }
            free(soup);
            CHECK_MSG(by_axis[0] >= 20 && by_axis[1] >= 20 && by_axis[2] >= 20,
                      "row directions x/y/z: %zu/%zu/%zu triangles", by_axis[0], by_axis[1], by_axis[2]);
            char name[64];
            snprintf(name, sizeof name, "row-axis soup %llu", (unsigned long long)seed);
            uint8_t *d = check_vs_reference(name, mesh, &g, seed == 21 ? 1 : seed == 22 ? 5 : 0);
            uint8_t *e = run_mode(mesh, &g, CLVOX_MODE_SURFACE, CLVOX_METHOD_RAY, 3, CLVOX_AXIS_DEFAULT, NULL);
            CHECK(diff(&g, d, e, "slab 3") == 0);
            free(d), free(e);
        }
        clvox_mesh_destroy(mesh);
        tmesh_free(&m);
    }
}

/* Closest point on triangle to p (Ericson, Real-Time Collision Detection 5.1.5): squared distance. */
static double dist2_point_triangle(const double *p, const double *a, const double *b, const double *c)
{
    double ab[3], ac[3], ap[3], q[3];
    for (int i = 0; i < 3; i++) ab[i] = b[i] - a[i], ac[i] = c[i] - a[i], ap[i] = p[i] - a[i];
#define DOT(u, w) ((u)[0] * (w)[0] + (u)[1] * (w)[1] + (u)[2] * (w)[2])
    double d1 = DOT(ab, ap), d2 = DOT(ac, ap);
    double bp[3], cp[3];
    for (int i = 0; i < 3; i++) bp[i] = p[i] - b[i], cp[i] = p[i] - c[i];
    double d3 = DOT(ab, bp), d4 = DOT(ac, bp), d5 = DOT(ab, cp), d6 = DOT(ac, cp);
    double vc = d1 * d4 - d3 * d2, vb = d5 * d2 - d1 * d6, va = d3 * d6 - d5 * d4;
    double u, w;
    if (d1 <= 0 && d2 <= 0) u = 0, w = 0;
    else if (d3 >= 0 && d4 <= d3) u = 1, w = 0;
    else if (vc <= 0 && d1 >= 0 && d3 <= 0) u = d1 / (d1 - d3), w = 0;
    else if (d6 >= 0 && d5 <= d6) u = 0, w = 1;
    else if (vb <= 0 && d2 >= 0 && d6 <= 0) u = 0, w = d2 / (d2 - d6);
    else if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
        double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        for (int i = 0; i < 3; i++) q[i] = b[i] + t * (c[i] - b[i]) - p[i];
        return DOT(q, q);
    } else {
        double den = va + vb + vc;
        if (!(den > 0)) { /* degenerate: nearest of the three edges' ends and midpoints, coarse but safe */
            double best = INFINITY;
            const double *pts[3] = {a, b, c};
            for (int e = 0; e < 3; e++)
                for (int k = 0; k <= 64; k++) {
                    for (int i = 0; i < 3; i++)
                        q[i] = pts[e][i] + (pts[(e + 1) % 3][i] - pts[e][i]) * k / 64.0 - p[i];
                    best = fmin(best, DOT(q, q));
                }
            return best;
        }
        u = vb / den, w = vc / den;
    }
    for (int i = 0; i < 3; i++) q[i] = a[i] + u * ab[i] + w * ac[i] - p[i];
    return DOT(q, q);
#undef DOT
}

/* Containment (sampled points fall in marked voxels) and reach (marked
 * voxels are within sqrt(3)/2 of the surface), in grid space. */
static void check_contain_reach(const char *name, const clvox_mesh *mesh, const clvox_grid *g, const uint8_t *vol)
{
    size_t nt;
    double *s = grid_soup(mesh, g, &nt);
    size_t missed = 0, samples = 0, far = 0;
    const int S = 12;
    for (size_t t = 0; t < nt; t++) {
        const double *v = s + 9 * t;
        for (int i = 0; i <= S; i++)
            for (int j = 0; i + j <= S; j++) {
                double p[3];
                int c[3], ok = 1;
                for (int a = 0; a < 3; a++) {
                    p[a] = v[a] + (v[3 + a] - v[a]) * i / S + (v[6 + a] - v[a]) * j / S;
                    double f = p[a] + 0.5;
                    if (fabs(f - floor(f + 0.5)) < 1e-6) ok = 0; /* on a cell face: either side */
                    c[a] = (int)floor(f);
                    ok &= c[a] >= 0 && c[a] < (int)g->dims[a];
                }
                if (!ok) continue;
                samples++;
                if (!vol[((size_t)c[2] * g->dims[1] + (size_t)c[1]) * g->dims[0] + (size_t)c[0]]) missed++;
            }
    }
    const double reach = 0.75 + 1e-6; /* (sqrt(3)/2)^2 */
    for (size_t i = 0; i < voxels(g); i++) {
        if (!vol[i]) continue;
        double p[3] = {(double)(i % g->dims[0]), (double)(i / g->dims[0] % g->dims[1]),
                       (double)(i / ((size_t)g->dims[0] * g->dims[1]))};
        double best = INFINITY;
        for (size_t t = 0; t < nt && best > reach; t++)
            best = fmin(best, dist2_point_triangle(p, s + 9 * t, s + 9 * t + 3, s + 9 * t + 6));
        far += best > reach;
    }
    CHECK_MSG(missed == 0 && samples > 100, "%s: %zu of %zu surface samples in unmarked voxels", name, missed, samples);
    CHECK_MSG(far == 0, "%s: %zu marked voxels farther than sqrt(3)/2 from every triangle", name, far);
    free(s);
}

static void test_closed_meshes(void)
{
    tmesh meshes[3];
    const char *names[3] = {"sphere", "torus", "random closed"};
    meshes[0] = tmesh_sphere(15.3, 14.1, 13.7, 11.2, 12);
    meshes[1] = tmesh_torus(15.1, 15.2, 15.3, 9.0, 3.1, 24, 12);
    meshes[2] = tmesh_random_closed(7, 3, 4);
    for (size_t i = 0; i < meshes[2].nv * 3; i++) meshes[2].xyz[i] *= 30.0f;
    for (int k = 0; k < 3; k++) {
        clvox_mesh *mesh = to_mesh(&meshes[k]);
        clvox_grid g = grid_box(0, 0, 0, 30, 30, 30, 30, 29, 31);
        if (mesh) {
            uint8_t *surf = check_vs_reference(names[k], mesh, &g, 0);
            check_contain_reach(names[k], mesh, &g, surf);
            for (int method = 0; method < 2; method++) {
                clvox_method me = method ? CLVOX_METHOD_TETRA : CLVOX_METHOD_RAY;
                uint8_t *sol = run_mode(mesh, &g, CLVOX_MODE_SOLID, me, 0, CLVOX_AXIS_DEFAULT, NULL);
                uint8_t *con = run_mode(mesh, &g, CLVOX_MODE_CONSERVATIVE, me, 7, CLVOX_AXIS_Y, NULL);
                uint8_t *sol_y = run_mode(mesh, &g, CLVOX_MODE_SOLID, me, 7, CLVOX_AXIS_Y, NULL);
                size_t bad = 0, sub = 0;
                for (size_t i = 0; i < voxels(&g); i++) {
                    bad += con[i] != (sol_y[i] | surf[i]);
                    sub += con[i] < sol_y[i] || con[i] < surf[i];
                }
                CHECK_MSG(bad == 0 && sub == 0, "%s %s: conservative != solid | surface at %zu voxels", names[k],
                          method ? "tetra" : "ray", bad);
                free(sol), free(con), free(sol_y);
            }
            free(surf);
        }
        clvox_mesh_destroy(mesh);
        tmesh_free(&meshes[k]);
    }
}

/* ---- real meshes ------------------------------------------------------------ */

static void test_real_meshes(void)
{
    const char *names[] = {"bunny00.off", "armadillo.off", "fandisk.off"};
    const char *res_env = getenv("CLVOX_SURFACE_REAL_RES");
    uint32_t res = res_env && atoi(res_env) > 0 ? (uint32_t)atoi(res_env) : 40;
    for (size_t k = 0; k < sizeof names / sizeof *names; k++) {
        char path[256];
        snprintf(path, sizeof path, "data/meshes/%s", names[k]);
        struct stat sb;
        if (stat(path, &sb) != 0) {
            printf("real mesh %s missing (scripts/fetch_meshes.sh): skipped\n", path);
            continue;
        }
        clvox_mesh *mesh = NULL;
        CHECK_OK(ctx, clvox_mesh_load(ctx, path, &mesh));
        if (!mesh) continue;
        const clvox_mesh_report *r = clvox_mesh_get_report(mesh);
        clvox_grid_options go = CLVOX_GRID_OPTIONS_INIT;
        go.resolution = res;
        go.padding = 1;
        clvox_grid g;
        CHECK_OK(ctx, clvox_grid_compute(ctx, &go, r->bbox_min, r->bbox_max, &g));
        uint8_t *s = check_vs_reference(names[k], mesh, &g, 0);
        uint8_t *c = run_mode(mesh, &g, CLVOX_MODE_CONSERVATIVE, CLVOX_METHOD_RAY, 0, CLVOX_AXIS_DEFAULT, NULL);
        uint8_t *so = run_mode(mesh, &g, CLVOX_MODE_SOLID, CLVOX_METHOD_RAY, 0, CLVOX_AXIS_DEFAULT, NULL);
        size_t bad = 0;
        for (size_t i = 0; i < voxels(&g); i++) bad += c[i] != (so[i] | s[i]);
        CHECK_MSG(bad == 0, "%s: conservative != solid | surface at %zu voxels", names[k], bad);
        free(s), free(c), free(so);
        clvox_mesh_destroy(mesh);
    }
}

/* ---- API and CLI ------------------------------------------------------------ */

static int cancel_at_once(void *user, double fraction)
{
    (void)user, (void)fraction;
    return 0;
}

static void test_api(void)
{
    tmesh m = tmesh_octahedron(8, 8, 8, 5);
    clvox_mesh *mesh = to_mesh(&m);
    clvox_grid g = grid_box(0, 0, 0, 16, 16, 16, 16, 16, 16);
    uint8_t *buf = malloc(voxels(&g));
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    o.mode = (clvox_mode)7;
    CHECK_STATUS(ctx, clvox_voxelize_to_memory(ctx, mesh, &g, &o, buf, voxels(&g), NULL), CLVOX_ERR_INVALID_ARGUMENT);
    o.mode = CLVOX_MODE_SURFACE;
    o.oversample = 2;
    CHECK_STATUS(ctx, clvox_voxelize_to_memory(ctx, mesh, &g, &o, buf, voxels(&g), NULL), CLVOX_ERR_INVALID_ARGUMENT);
    o.oversample = 0;
    o.channels = CLVOX_CHANNEL_COVERAGE;
    char bad_path[512];
    snprintf(bad_path, sizeof bad_path, "%s/surface_bad.exr", test_tmpdir());
    CHECK_STATUS(ctx, clvox_voxelize_to_exr(ctx, mesh, &g, &o, bad_path, NULL), CLVOX_ERR_INVALID_ARGUMENT);
    o.channels = 0;
    clvox_palette *pal = NULL;
    CHECK_OK(ctx, clvox_palette_builtin(ctx, "binary", &pal));
    o.palette = pal;
    o.mode = CLVOX_MODE_CONSERVATIVE;
    CHECK_STATUS(ctx, clvox_voxelize_to_memory(ctx, mesh, &g, &o, buf, voxels(&g), NULL), CLVOX_ERR_INVALID_ARGUMENT);
    clvox_palette_destroy(pal);
    CHECK(strcmp(clvox_mode_name(CLVOX_MODE_CONSERVATIVE), "conservative") == 0 && !clvox_mode_name(CLVOX_MODE_COUNT));
    /* an options struct from before the mode field: solid */
    clvox_voxelize_options old = CLVOX_VOXELIZE_OPTIONS_INIT;
    old.mode = CLVOX_MODE_SURFACE; /* past the old size: not read */
    old.size = offsetof(clvox_voxelize_options, mode);
    uint64_t solid = 0, got = 0;
    free(run_mode(mesh, &g, CLVOX_MODE_SOLID, CLVOX_METHOD_RAY, 0, CLVOX_AXIS_DEFAULT, &solid));
    CHECK_OK(ctx, clvox_voxelize_to_memory(ctx, mesh, &g, &old, buf, voxels(&g), NULL));
    for (size_t i = 0; i < voxels(&g); i++) got += buf[i];
    CHECK(got == solid && solid > 0);
    /* EXR: the mode is recorded, the count read back */
    char path[512];
    const char *methods[3] = {"ray", "surface", "ray+surface"};
    for (int mode = 0; mode < 3; mode++) {
        snprintf(path, sizeof path, "%s/surface_%d.exr", test_tmpdir(), mode);
        clvox_voxelize_options e = CLVOX_VOXELIZE_OPTIONS_INIT;
        e.mode = (clvox_mode)mode;
        clvox_stats st = CLVOX_STATS_INIT;
        CHECK_OK(ctx, clvox_voxelize_to_exr(ctx, mesh, &g, &e, path, &st));
        clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
        CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, NULL, 0));
        CHECK_MSG(strcmp(info.method, methods[mode]) == 0 && info.filled_voxels == st.filled_voxels,
                  "mode %d: method '%s', %llu vs %llu filled", mode, info.method,
                  (unsigned long long)info.filled_voxels, (unsigned long long)st.filled_voxels);
        remove(path);
    }
    /* cancel from the progress callback: the documented status, no file left */
    snprintf(path, sizeof path, "%s/surface_cancel.exr", test_tmpdir());
    remove(path);
    clvox_voxelize_options e = CLVOX_VOXELIZE_OPTIONS_INIT;
    e.mode = CLVOX_MODE_SURFACE;
    e.slab_depth = 2;
    e.progress = cancel_at_once;
    CHECK_STATUS(ctx, clvox_voxelize_to_exr(ctx, mesh, &g, &e, path, NULL), CLVOX_ERR_CANCELLED);
    struct stat sb;
    CHECK(stat(path, &sb) != 0);
    free(buf);
    clvox_mesh_destroy(mesh);
    tmesh_free(&m);
}

/* Runs the CLI through the shell; returns its exit code, stderr in err. */
static int cli(const char *args, char *err, size_t size)
{
    const char *bin = getenv("CLVOX_BIN");
    if (!bin) bin = "build/release/clvox";
    char cmd[2048], errpath[512];
    snprintf(errpath, sizeof errpath, "%s/surface_cli.err", test_tmpdir());
    snprintf(cmd, sizeof cmd, "'%s' %s > '%s/surface_cli.out' 2> '%s'", bin, args, test_tmpdir(), errpath);
    int rc = system(cmd);
    err[0] = 0;
    FILE *f = fopen(errpath, "rb");
    if (f) {
        size_t n = fread(err, 1, size - 1, f);
        err[n] = 0;
        fclose(f);
    }
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

static void test_cli(void)
{
    char err[4096], args[2048], mesh[512], out[512];
    snprintf(mesh, sizeof mesh, "%s/surface_open.off", test_tmpdir());
    snprintf(out, sizeof out, "%s/surface_open.exr", test_tmpdir());
    tmesh m = {0}; /* an open mesh: one triangle */
    tmesh_add_vertex(&m, 0, 0, 0);
    tmesh_add_vertex(&m, 1, 0, 0);
    tmesh_add_vertex(&m, 0, 1, 0.5);
    tmesh_add_tri(&m, 0, 1, 2);
    CHECK(tmesh_write_off(&m, mesh) == 0);
    tmesh_free(&m);
    snprintf(args, sizeof args, "'%s' -r 16 --mode surface -o '%s' --no-progress", mesh, out);
    CHECK(cli(args, err, sizeof err) == 0);
    CHECK_MSG(!strstr(err, "not closed"), "surface mode warned about an open mesh: %s", err);
    snprintf(args, sizeof args, "'%s' -r 16 --mode solid --inside parity -o '%s' --no-progress", mesh, out);
    CHECK(cli(args, err, sizeof err) == 0 && strstr(err, "not closed"));
    snprintf(args, sizeof args, "'%s' -r 16 --mode bogus -o '%s'", mesh, out);
    CHECK(cli(args, err, sizeof err) == 2 && strstr(err, "--mode"));
    snprintf(args, sizeof args, "'%s' -r 16 --mode conservative --oversample 2 -o '%s'", mesh, out);
    CHECK(cli(args, err, sizeof err) == 2);
    remove(mesh);
    remove(out);
}

int main(void)
{
    ctx = test_context();
    ref_init();
    test_predicates();
    test_touching();
    test_boxes();
    test_random_soups();
    test_projection_soups();
    test_row_axes();
    test_closed_meshes();
    test_api();
    test_cli();
    if (!getenv("CLVOX_QUICK")) test_real_meshes();
    ref_done();
    clvox_context_destroy(ctx);
    return test_report();
}
