/* SPDX-License-Identifier: Apache-2.0 */
/* The kernels as built for a device without fp64 (CLVOX_KERNEL_FLOAT,
 * -DCLVOX_NO_FP64) against the double kernels, voxel for voxel, in one
 * process: two contexts on the same device, one with each build
 * (clvox__set_test_hooks before each is created). The modes whose float
 * build decides exactly what double decides (docs/design.md "Devices
 * without double precision"): the ray method's parity (rays along x, y and
 * z), the tetra method, surface and conservative (with ray or tetra) --
 * every one must be byte-identical, on
 *  - every mesh of data/meshes (the CGAL meshes; closed, open, broken;
 *    parity along x and conservative with tetra only, for time),
 *  - grid-aligned meshes whose faces, edges and vertices lie on voxel
 *    centres and cell faces (exact ties everywhere),
 *  - random closed meshes and their soups, and lattice soups.
 * The default winding inside test (and |w| > 1/2 on the generated meshes)
 * must be byte-identical too: the float build decides what its bounds
 * settle and leaves the rest to the host in double
 * (clvox_stats.winding_host_points, counted here). Adversarial points: open
 * boxes whose missing face lies within a few float ulps of a plane of
 * centres, so that w there is 1/2 + O(1e-7), against a long-double
 * reference of w at every centre.
 * A coordinate outside float's exact range refuses a float run.
 * CLVOX_FLOAT_RES=n sets the data meshes' resolution (default 24). */
#include "test.h"
#include "meshgen.h"

#include "core/environment.h"
#include "core/internal.h"
#include "winding/winding.h" /* src/: the cap tree (internal) */

#include <dirent.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static clvox_context *cd, *cf; /* double and float kernels */
static unsigned runs, winding_runs;
static uint64_t host_points; /* the float runs' points decided on the host */

static clvox_context *context_with(int kernels_float)
{
    clvox__test_hooks h = *clvox__hooks();
    h.kernels_float = kernels_float;
    clvox__set_test_hooks(&h);
    return test_context();
}

typedef struct mode_case {
    const char *name;
    clvox_mode mode;
    clvox_method method;
    clvox_inside inside;
    clvox_axis axis;
} mode_case;

static const mode_case exact_cases[] = {
    {"parity x", CLVOX_MODE_SOLID, CLVOX_METHOD_RAY, CLVOX_INSIDE_PARITY, CLVOX_AXIS_X},
    {"parity y", CLVOX_MODE_SOLID, CLVOX_METHOD_RAY, CLVOX_INSIDE_PARITY, CLVOX_AXIS_Y},
    {"parity z", CLVOX_MODE_SOLID, CLVOX_METHOD_RAY, CLVOX_INSIDE_PARITY, CLVOX_AXIS_Z},
    {"tetra", CLVOX_MODE_SOLID, CLVOX_METHOD_TETRA, CLVOX_INSIDE_DEFAULT, CLVOX_AXIS_DEFAULT},
    {"surface", CLVOX_MODE_SURFACE, CLVOX_METHOD_RAY, CLVOX_INSIDE_DEFAULT, CLVOX_AXIS_DEFAULT},
    {"conservative ray", CLVOX_MODE_CONSERVATIVE, CLVOX_METHOD_RAY, CLVOX_INSIDE_PARITY, CLVOX_AXIS_DEFAULT},
    {"conservative tetra", CLVOX_MODE_CONSERVATIVE, CLVOX_METHOD_TETRA, CLVOX_INSIDE_DEFAULT, CLVOX_AXIS_DEFAULT},
};

/* Runs o on both contexts; the number of voxels that differ, or -1 when
 * a run failed (reported). */
static long compare_run(const char *what, const clvox_mesh *mesh, const clvox_grid *g, const clvox_voxelize_options *o)
{
    const size_t n = (size_t)g->dims[0] * g->dims[1] * g->dims[2];
    uint8_t *a = malloc(n), *b = malloc(n);
    CHECK(a && b);
    if (!a || !b) {
        free(a);
        free(b);
        return -1;
    }
    clvox_stats st = CLVOX_STATS_INIT;
    clvox_status sa = clvox_voxelize_to_memory(cd, mesh, g, o, a, n, NULL);
    clvox_status sb = clvox_voxelize_to_memory(cf, mesh, g, o, b, n, &st);
    host_points += st.winding_host_points;
    CHECK_MSG(sa == CLVOX_OK && sb == CLVOX_OK, "%s: double %s, float %s (%s)", what, clvox_status_string(sa),
              clvox_status_string(sb), sb != CLVOX_OK ? clvox_context_error(cf) : clvox_context_error(cd));
    long d = -1;
    if (sa == CLVOX_OK && sb == CLVOX_OK) {
        d = 0;
        for (size_t i = 0; i < n; i++) d += a[i] != b[i];
    }
    free(a);
    free(b);
    return d;
}

/* A column run (coverage, or palette where o->palette) on both contexts:
 * coverage, or element and score, compared bit for bit; the number of
 * voxels that differ, or -1 when a run failed (reported). */
static clvox_palette *g_palette;
static unsigned coverage_runs, palette_runs;
static long compare_columns(const char *what, const clvox_mesh *mesh, const clvox_grid *g,
                            const clvox_voxelize_options *o)
{
    const size_t n = (size_t)g->dims[0] * g->dims[1] * g->dims[2];
    uint16_t *ea = malloc(n * sizeof *ea), *eb = malloc(n * sizeof *eb); /* palette: the elements */
    float *fa = malloc(n * sizeof *fa), *fb = malloc(n * sizeof *fb);    /* coverage or score */
    long d = -1;
    CHECK(ea && eb && fa && fb);
    if (ea && eb && fa && fb) {
        memset(ea, 0, n * sizeof *ea);
        memset(eb, 0, n * sizeof *eb);
        clvox_stats st = CLVOX_STATS_INIT;
        clvox_status ra = o->palette ? clvox_voxelize_palette_to_buffers(cd, mesh, g, o, ea, n, fa, n, NULL)
                                     : clvox_voxelize_to_buffers(cd, mesh, g, o, NULL, 0, fa, n, NULL);
        clvox_status rb = o->palette ? clvox_voxelize_palette_to_buffers(cf, mesh, g, o, eb, n, fb, n, &st)
                                     : clvox_voxelize_to_buffers(cf, mesh, g, o, NULL, 0, fb, n, &st);
        host_points += st.winding_host_points;
        CHECK_MSG(ra == CLVOX_OK && rb == CLVOX_OK, "%s: double %s, float %s (%s)", what, clvox_status_string(ra),
                  clvox_status_string(rb), rb != CLVOX_OK ? clvox_context_error(cf) : clvox_context_error(cd));
        if (ra == CLVOX_OK && rb == CLVOX_OK) {
            d = 0;
            for (size_t i = 0; i < n; i++) d += ea[i] != eb[i] || memcmp(fa + i, fb + i, sizeof *fa) != 0;
        }
    }
    free(ea);
    free(eb);
    free(fa);
    free(fb);
    *(o->palette ? &palette_runs : &coverage_runs) += 1;
    return d;
}

/* The column runs of one mesh with the inside test `inside`: coverage with
 * 2x2 rays x 3 points uniform (strata that are not dyadic: the points are
 * rounded floats) and 2x2x2 stochastic; the planar10 palette with 3x3 x 2
 * uniform and 2x2x3 stochastic. */
static void compare_mesh_columns(const char *name, const clvox_mesh *mesh, const clvox_grid *g, clvox_inside inside)
{
    for (int palette = 0; palette <= 1; palette++)
        for (int stochastic = 0; stochastic <= 1; stochastic++) {
            clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
            o.inside = inside;
            o.palette = palette ? g_palette : NULL;
            o.oversample = palette && !stochastic ? 3 : 2;
            o.oversample_points = palette ? (stochastic ? 3 : 2) : (stochastic ? 2 : 3);
            o.stochastic = stochastic;
            o.seed = palette ? 11 : 7;
            char what[256];
            snprintf(what, sizeof what, "%s %s %s %s %ux%ux%u", name, palette ? "palette" : "coverage",
                     stochastic ? "stochastic" : "uniform", inside == CLVOX_INSIDE_PARITY ? "parity" : "winding",
                     g->dims[0], g->dims[1], g->dims[2]);
            const long d = compare_columns(what, mesh, g, &o);
            CHECK_MSG(d == 0, "%s: %ld voxels differ between the float and double kernels", what, d);
        }
}

/* Every exact mode on one mesh (with `all_axes` 0, parity along x only and
 * conservative with tetra only: the data meshes, to keep the test short):
 * byte-identical; the winding test counted. */
static void compare_mesh(const char *name, const clvox_mesh *mesh, const clvox_grid *g, int all_axes)
{
    for (size_t c = 0; c < sizeof exact_cases / sizeof exact_cases[0]; c++) {
        const char *cn = exact_cases[c].name;
        if (!all_axes && (!strcmp(cn, "parity y") || !strcmp(cn, "parity z") || !strcmp(cn, "conservative ray")))
            continue;
        clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
        o.mode = exact_cases[c].mode;
        o.method = exact_cases[c].method;
        o.inside = exact_cases[c].inside;
        o.ray_axis = exact_cases[c].axis;
        char what[256];
        snprintf(what, sizeof what, "%s %s %ux%ux%u", name, exact_cases[c].name, g->dims[0], g->dims[1], g->dims[2]);
        const long d = compare_run(what, mesh, g, &o);
        CHECK_MSG(d == 0, "%s: %ld voxels differ between the float and double kernels", what, d);
        runs++;
    }
    for (int abs_mode = 0; abs_mode <= all_axes; abs_mode++) {
        clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT; /* the default: winding */
        if (abs_mode) o.inside = CLVOX_INSIDE_WINDING_ABS;
        char what[256];
        snprintf(what, sizeof what, "%s %s", name, abs_mode ? "winding-abs" : "winding");
        const long d = compare_run(what, mesh, g, &o);
        CHECK_MSG(d == 0, "%s: %ld voxels differ between the float and double kernels", what, d);
        winding_runs++;
    }
    compare_mesh_columns(name, mesh, g, CLVOX_INSIDE_PARITY);
    compare_mesh_columns(name, mesh, g, CLVOX_INSIDE_WINDING);
}

static void compare_tmesh(const char *name, const tmesh *m, const clvox_grid *g);

/* The solid angle / 4pi of triangle t (9 doubles: a, b, c) seen from p, in long double
 * (van Oosterom-Strackee). */
static long double ref_cap(const double *t, const double p[3])
{
    long double a[3], b[3], c[3];
    for (int k = 0; k < 3; k++) {
        a[k] = (long double)t[k] - p[k];
        b[k] = (long double)t[3 + k] - p[k];
        c[k] = (long double)t[6 + k] - p[k];
    }
    const long double la = sqrtl(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    const long double lb = sqrtl(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    const long double lc = sqrtl(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    const long double det = a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2]) +
                            a[2] * (b[0] * c[1] - b[1] * c[0]);
    const long double den = la * lb * lc + (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) * lc +
                            (b[0] * c[0] + b[1] * c[1] + b[2] * c[2]) * la + (c[0] * a[0] + c[1] * a[1] + c[2] * a[2]) * lb;
    return 2 * atan2l(det, den) / (4 * 3.14159265358979323846264338327950288L);
}

/* w at p of the triangles, in long double. */
static long double ref_w(const tmesh *m, const double p[3])
{
    long double w = 0;
    for (size_t t = 0; t < m->nt; t++) {
        double v[9];
        for (int c = 0; c < 3; c++)
            for (int k = 0; k < 3; k++) v[3 * c + k] = m->xyz[3 * m->tri[3 * t + c] + k];
        w += ref_cap(v, p);
    }
    return w;
}

/* The box [2.3, 13.7] x [3.1, 12.9] x [2.7, top] without its top face (10
 * triangles). */
static tmesh open_box(double top)
{
    tmesh box = tmesh_box(2.3, 3.1, 2.7, 13.7, 12.9, top), open = {0};
    for (size_t v = 0; v < box.nv; v++) tmesh_add_vertex(&open, box.xyz[3 * v], box.xyz[3 * v + 1], box.xyz[3 * v + 2]);
    for (size_t t = 0; t < box.nt; t++) {
        const uint32_t *c = box.tri + 3 * t;
        int up = 1;
        for (int i = 0; i < 3; i++) up &= box.xyz[3 * c[i] + 2] == (float)top;
        if (!up) tmesh_add_tri(&open, c[0], c[1], c[2]);
    }
    CHECK(open.nt == 10);
    tmesh_free(&box);
    return open;
}

/* Adversarial points: a box open at the top, whose top lies k float ulps
 * (2^-20 at 8) above a plane of centres (z = 8 on cubic voxels). Every
 * centre inside the opening on that plane has w = 1/2 + O(k 1e-7) (on the
 * opening itself w is exactly 1/2: the box fills the half-space below), the
 * float bounds cannot settle them and the host decides them. Float ==
 * double, and both == the long-double reference wherever it is 1e-12 from
 * the threshold. On voxels that are not cubes (1 x 19/16 x 3/2: the scaled
 * coordinates are rounded in float, clvox_point_rounding) the same, about
 * the plane z = 7.75 (ulp 2^-21). */
static void adversarial_on(const char *grid_name, const double lo[3], const double hi[3], double plane, double ulp,
                           int kmax, unsigned *near, unsigned *checked)
{
    const clvox_grid g = test_grid(lo, hi, 16, 16, 16);
    for (int k = -kmax; k <= kmax; k++) {
        const double top = plane + k * ulp;
        tmesh open = open_box(top);
        char name[96];
        snprintf(name, sizeof name, "open box, top %+d ulp from centres, %s", k, grid_name);
        clvox_mesh *mesh = NULL;
        CHECK_OK(cd, clvox_mesh_from_arrays(cd, open.xyz, open.nv, open.tri, open.nt, &mesh));
        uint8_t *a = malloc(16 * 16 * 16);
        CHECK(a != NULL);
        if (mesh && a) {
            compare_mesh(name, mesh, &g, 1);
            clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
            CHECK_OK(cf, clvox_voxelize_to_memory(cf, mesh, &g, &o, a, 16 * 16 * 16, NULL));
            for (int z = 0; z < 16; z++)
                for (int y = 0; y < 16; y++)
                    for (int x = 0; x < 16; x++) {
                        const double p[3] = {g.origin[0] + (x + 0.5) * g.voxel_size[0],
                                             g.origin[1] + (y + 0.5) * g.voxel_size[1],
                                             g.origin[2] + (z + 0.5) * g.voxel_size[2]};
                        const long double w = ref_w(&open, p), d = w - (0.5L + 0x1p-30L);
                        if (fabsl(w - 0.5L) < 1e-6L) (*near)++;
                        if (fabsl(d) < 1e-12L) continue;
                        (*checked)++;
                        const int want = d > 0;
                        CHECK_MSG(a[(z * 16 + y) * 16 + x] == want, "%s: voxel (%d, %d, %d) w - 1/2 = %.3Lg: %d", name,
                                  x, y, z, w - 0.5L, a[(z * 16 + y) * 16 + x]);
                    }
        }
        free(a);
        clvox_mesh_destroy(mesh);
        tmesh_free(&open);
    }
}

static void test_adversarial(void)
{
    const double lo[3] = {-0.5, -0.5, -0.5}, hi[3] = {15.5, 15.5, 15.5}, hi_flat[3] = {15.5, 18.5, 23.5};
    const uint64_t before = host_points;
    unsigned near = 0, checked = 0, near_flat = 0, checked_flat = 0;
    adversarial_on("cubic voxels", lo, hi, 8.0, 0x1p-20, 6, &near, &checked);
    const uint64_t flat_before = host_points;
    adversarial_on("voxels not cubes", lo, hi_flat, 7.75, 0x1p-21, 4, &near_flat, &checked_flat);
    {
        /* the caps' apex in the opening's plane (CLVOX_CAP_APEX=0): the
         * centres of the plane lie within a few ulps of the caps
         * themselves, where det's sign -- which the rounded coordinates
         * cannot give -- is w's whole unit */
        clvox__test_hooks h = *clvox__hooks();
        h.cap_apex_set = 1;
        h.cap_apex = 0;
        clvox__set_test_hooks(&h);
        adversarial_on("voxels not cubes, flat caps", lo, hi_flat, 7.75, 0x1p-21, 2, &near_flat, &checked_flat);
        h.cap_apex_set = 0;
        clvox__set_test_hooks(&h);
    }
    const uint64_t flat_host = host_points - flat_before;
    /* a list with room for 1 point: the batch's consumer runs again with
     * room for all (resolve_unsure), to the same voxels */
    {
        const clvox_grid g = test_grid(lo, hi, 16, 16, 16);
        clvox__test_hooks h = *clvox__hooks();
        h.unsure_room = 1;
        clvox__set_test_hooks(&h);
        tmesh open = open_box(8.0 + 0x1p-20);
        const uint64_t h0 = host_points;
        compare_tmesh("open box, unsure list of 1", &open, &g);
        CHECK_MSG(host_points - h0 > 2, "only %llu host points with a list of 1", (unsigned long long)(host_points - h0));
        h.unsure_room = 0;
        clvox__set_test_hooks(&h);
        tmesh_free(&open);
    }
    printf("adversarial: %u centres within 1e-6 of w = 1/2, %u checked against long double (voxels not cubes: %u "
           "and %u, %llu points on the host), %llu points decided on the host\n",
           near, checked, near_flat, checked_flat, (unsigned long long)flat_host,
           (unsigned long long)(host_points - before));
    CHECK_MSG(near >= 100 && near_flat >= 100, "only %u and %u centres near w = 1/2", near, near_flat);
    CHECK_MSG(host_points > before && flat_host > 0, "no point was left to the host");
}

/* Crossings next to the centres: soups of steep triangles (slopes up to
 * 8 voxels a voxel, in u along each of v and w), one per ray of the grid,
 * whose plane crosses its ray (at a centre's v, w) 1e-7 to 1e-3 voxel to
 * either side of a centre, moved by its corners' rounding to floats. The
 * float estimate of such a crossing is off by more than that: the float
 * cast takes its ceil from the estimate only where the estimate's error
 * bound allows (clvox_ray_crosses_x), else from exact signs. Both builds'
 * volumes byte-identical (with that bound 10 times too small, or trusting
 * every estimate, 20 of the 210 checks fail: 11 to 50 voxels a run). */
static void test_near_centres(void)
{
    const double lo[3] = {-0.5, -0.5, -0.5}, hi[3] = {15.5, 15.5, 15.5};
    const clvox_grid g = test_grid(lo, hi, 16, 16, 16);
    static const double off[] = {1e-7, -1e-7, 3e-7, -3e-7, 1e-6, -1e-6, 1e-5, -1e-5, 1e-3, -1e-3};
    uint64_t seed = 0x5ea7ce17;
    for (int round = 0; round < 4; round++) {
        tmesh m = {0};
        for (int w = 0; w < 16; w++)
            for (int v = 0; v < 16; v++) {
                const double i = 6 + (int)(4 * tmesh_rng_uniform(&seed));
                const double d = off[(size_t)(tmesh_rng_uniform(&seed) * (sizeof off / sizeof off[0]))];
                const double al = 16 * tmesh_rng_uniform(&seed) - 8, be = 16 * tmesh_rng_uniform(&seed) - 8;
                uint32_t c[3];
                for (int k = 0; k < 3; k++) { /* corners about (v, w), the ray inside */
                    const double ang = 2.0943951023931953 * k + tmesh_rng_uniform(&seed);
                    const double dv = 0.4 * cos(ang), dw = 0.4 * sin(ang);
                    c[k] = tmesh_add_vertex(&m, i + d + al * dv + be * dw, v + dv, w + dw);
                }
                tmesh_add_tri(&m, c[0], c[1], c[2]);
            }
        char name[64];
        snprintf(name, sizeof name, "steep triangles next to centres, round %d", round);
        compare_tmesh(name, &m, &g);
        tmesh_free(&m);
    }
}

/* A tilted opening on voxels that are not cubes (1 x 19/16 x 3/2, so that
 * the scaled coordinates are rounded): the tetrahedron (1, 1, 1), (13, 1,
 * 1), (1, 13, 1), (1, 1, 13) in grid coordinates (voxel centres at the
 * integers; its world coordinates, grid times h, and back are exact) without
 * its face x + y + z = 15. At the 55 centres inside that face w is 1/2
 * exactly (the closed tetrahedron's 1/2 on a face, less the missing face's
 * 0): outside. Both builds; every other centre against the long-double
 * reference. With CLVOX_CAP_APEX=0 the caps' fan lies in the face's plane,
 * and the centres inside the caps are ties whose det only an exact sign
 * gets right (on the grid's floats: the rounded coordinates give it either
 * sign); checked there are the face's centres off the fan's spokes (on a
 * spoke den is 0 too: the tie rule does not cover it, and the apex's lift
 * off the plane is what keeps centres off the spokes, src/winding/winding.c). */
static void test_tilted_opening(void)
{
    const double h[3] = {1.0, 19.0 / 16, 1.5};
    clvox_grid g;
    for (int a = 0; a < 3; a++) g.dims[a] = 16, g.voxel_size[a] = h[a], g.origin[a] = -0.5 * h[a];
    tmesh open = {0};
    const double c[4][3] = {{1, 1, 1}, {13, 1, 1}, {1, 13, 1}, {1, 1, 13}};
    for (int v = 0; v < 4; v++) tmesh_add_vertex(&open, c[v][0] * h[0], c[v][1] * h[1], c[v][2] * h[2]);
    tmesh_add_tri(&open, 0, 2, 1); /* the three faces through (1, 1, 1), outward */
    tmesh_add_tri(&open, 0, 1, 3);
    tmesh_add_tri(&open, 0, 3, 2);
    clvox_mesh *mesh = NULL;
    CHECK_OK(cd, clvox_mesh_from_arrays(cd, open.xyz, open.nv, open.tri, open.nt, &mesh));
    uint8_t *a = malloc(16 * 16 * 16);
    CHECK(a != NULL);
    for (int flat = 0; flat < 2 && mesh && a; flat++) {
        clvox__test_hooks hk = *clvox__hooks();
        hk.cap_apex_set = flat;
        hk.cap_apex = 0;
        clvox__set_test_hooks(&hk);
        for (int f = 0; f < 2; f++) {
            clvox_context *ctx = f ? cf : cd;
            char name[96];
            snprintf(name, sizeof name, "tilted opening, %s, %s", f ? "float" : "double", flat ? "flat caps" : "caps");
            clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
            CHECK_OK(ctx, clvox_voxelize_to_memory(ctx, mesh, &g, &o, a, 16 * 16 * 16, NULL));
            int on_face = 0, wrong = 0;
            for (int z = 0; z < 16; z++)
                for (int y = 0; y < 16; y++)
                    for (int x = 0; x < 16; x++) {
                        const int got = a[(z * 16 + y) * 16 + x];
                        if (x + y + z == 15 && x > 1 && y > 1 && z > 1) { /* inside the missing face */
                            /* the fan's spokes, from (5, 5, 5) to the corners: two coordinates equal, the
                             * third 15 - 2 of them */
                            const int spoke = (x == y && z >= 5) || (y == z && x >= 5) || (x == z && y >= 5);
                            if (flat && spoke) continue;
                            on_face++;
                            wrong += got != 0;
                            continue;
                        }
                        if (flat || x == 1 || y == 1 || z == 1) continue; /* on the surface's planes */
                        const double p[3] = {x * h[0], y * h[1], z * h[2]};
                        const long double d = ref_w(&open, p) - (0.5L + 0x1p-30L);
                        if (fabsl(d) < 1e-12L) continue;
                        CHECK_MSG(got == (d > 0), "%s: voxel (%d, %d, %d) w - 1/2 = %.3Lg: %d", name, x, y, z,
                                  d + 0x1p-30L, got);
                    }
            CHECK_MSG(on_face == (flat ? 45 : 55) && wrong == 0,
                      "%s: %d of the %d centres on the missing face (w = 1/2) inside", name, wrong, on_face);
        }
        hk.cap_apex_set = 0;
        clvox__set_test_hooks(&hk);
    }
    free(a);
    clvox_mesh_destroy(mesh);
    tmesh_free(&open);
}

static void compare_tmesh(const char *name, const tmesh *m, const clvox_grid *g)
{
    clvox_mesh *mesh = NULL;
    CHECK_OK(cd, clvox_mesh_from_arrays(cd, m->xyz, m->nv, m->tri, m->nt, &mesh));
    if (mesh) compare_mesh(name, mesh, g, 1);
    clvox_mesh_destroy(mesh);
}

/* Meshes on the voxel lattice: faces on centre planes and on cell faces,
 * vertices on centres and corners, so that every tie rule is exercised. */
static void test_grid_aligned(void)
{
    const double lo[3] = {0, 0, 0}, hi[3] = {16, 16, 16};
    const clvox_grid g = test_grid(lo, hi, 16, 16, 16); /* centres at 0.5 + i */
    tmesh a = tmesh_box(2.5, 3.5, 4.5, 11.5, 12.5, 9.5); /* faces through centres */
    compare_tmesh("box on centres", &a, &g);
    tmesh b = tmesh_box(2, 3, 4, 11, 12, 9); /* faces on cell faces */
    compare_tmesh("box on cell faces", &b, &g);
    tmesh c = tmesh_octahedron(8.5, 8.5, 8.5, 5); /* sloped faces through centres */
    compare_tmesh("octahedron on centres", &c, &g);
    const double p[3] = {1.5, 1.5, 1.5}, q[3] = {14.5, 2.5, 3.5}, r[3] = {3.5, 13.5, 2.5}, s[3] = {2.5, 4.5, 14.5};
    tmesh d = tmesh_tetra(p, q, r, s);
    compare_tmesh("tetrahedron on centres", &d, &g);
    tmesh e = tmesh_box_subdivided(1.5, 1.5, 1.5, 14.5, 14.5, 14.5, 13);
    compare_tmesh("subdivided box on centres", &e, &g);
    tmesh_free(&a);
    tmesh_free(&b);
    tmesh_free(&c);
    tmesh_free(&d);
    tmesh_free(&e);
}

/* Random closed meshes, their soups, and soups on the half-voxel lattice. */
static void test_random(void)
{
    const double lo[3] = {-1.2, -1.1, -1.3}, hi[3] = {1.3, 1.2, 1.1};
    const clvox_grid g = test_grid(lo, hi, 23, 21, 19);
    for (uint64_t seed = 1; seed <= 4; seed++) {
        tmesh m = tmesh_random_closed(seed, 2, 200);
        char name[64];
        snprintf(name, sizeof name, "random closed %llu", (unsigned long long)seed);
        compare_tmesh(name, &m, &g);
        tmesh s = tmesh_soup(&m);
        snprintf(name, sizeof name, "random soup %llu", (unsigned long long)seed);
        compare_tmesh(name, &s, &g);
        tmesh_free(&m);
        tmesh_free(&s);
    }
    const double llo[3] = {0, 0, 0}, lhi[3] = {12, 12, 12};
    const clvox_grid lg = test_grid(llo, lhi, 12, 12, 12);
    uint64_t rng = 99;
    for (int k = 0; k < 4; k++) {
        tmesh t = {0};
        for (int i = 0; i < 60; i++) {
            uint32_t v0 = (uint32_t)t.nv;
            for (int c = 0; c < 3; c++) {
                double x = floor(tmesh_rng_uniform(&rng) * 24) * 0.5, y = floor(tmesh_rng_uniform(&rng) * 24) * 0.5,
                       z = floor(tmesh_rng_uniform(&rng) * 24) * 0.5;
                tmesh_add_vertex(&t, x, y, z);
            }
            tmesh_add_tri(&t, v0, v0 + 1, v0 + 2);
        }
        char name[64];
        snprintf(name, sizeof name, "lattice soup %d", k);
        compare_tmesh(name, &t, &lg);
        tmesh_free(&t);
    }
}

/* Long triangles nearly parallel to x (1024-voxel rows, a band of 24 in y
 * and 8 in z), for the tetra method: the faces' roots along a row move
 * fast with y, so the float kernel's fast bound on a face's root
 * (kernels/tetra.cl, clvox_face_root_x) is widest here, and some rows meet
 * a root within its error of a centre, which it must leave to exact signs.
 * With that bound a hundredth as wide, voxels differ (a tenth: none;
 * it is a worst case over the roundings). */
static void test_steep_soups(void)
{
    const double lo[3] = {0, 0, 0}, hi[3] = {1024, 1024, 8};
    const clvox_grid g = test_grid(lo, hi, 1024, 1024, 8);
    uint64_t rng = 7;
    for (int k = 0; k < 2; k++) {
        tmesh t = {0};
        for (int i = 0; i < 300; i++) {
            uint32_t v0 = (uint32_t)t.nv;
            for (int c = 0; c < 3; c++) {
                const double x = tmesh_rng_uniform(&rng) * 1024, y = 500 + tmesh_rng_uniform(&rng) * 24,
                             z = tmesh_rng_uniform(&rng) * 8;
                tmesh_add_vertex(&t, x, y, z);
            }
            tmesh_add_tri(&t, v0, v0 + 1, v0 + 2);
        }
        clvox_mesh *mesh = NULL;
        CHECK_OK(cd, clvox_mesh_from_arrays(cd, t.xyz, t.nv, t.tri, t.nt, &mesh));
        for (int conservative = 0; mesh && conservative <= 1; conservative++) {
            clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
            o.method = CLVOX_METHOD_TETRA;
            o.mode = conservative ? CLVOX_MODE_CONSERVATIVE : CLVOX_MODE_SOLID;
            char what[96];
            snprintf(what, sizeof what, "steep soup %d, %s", k, conservative ? "conservative tetra" : "tetra");
            const long d = compare_run(what, mesh, &g, &o);
            CHECK_MSG(d == 0, "%s: %ld voxels differ between the float and double kernels", what, d);
            runs++;
        }
        clvox_mesh_destroy(mesh);
        tmesh_free(&t);
    }
}

/* A coordinate outside float's exact range (a vertex 1e-9 voxel from the
 * plane of centre 0): every float run refuses with one line naming it, the
 * double kernels run. */
static void test_range_refused(void)
{
    const double lo[3] = {-0.5, -0.5, -0.5}, hi[3] = {15.5, 15.5, 15.5};
    const clvox_grid g = test_grid(lo, hi, 16, 16, 16);
    tmesh m = tmesh_box(1e-9, 2, 2, 10, 10, 10);
    clvox_mesh *mesh = NULL;
    CHECK_OK(cd, clvox_mesh_from_arrays(cd, m.xyz, m.nv, m.tri, m.nt, &mesh));
    uint8_t *buf = malloc(16 * 16 * 16);
    for (size_t c = 0; mesh && buf && c < sizeof exact_cases / sizeof exact_cases[0]; c++) {
        clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
        o.mode = exact_cases[c].mode;
        o.method = exact_cases[c].method;
        o.inside = exact_cases[c].inside;
        CHECK_OK(cd, clvox_voxelize_to_memory(cd, mesh, &g, &o, buf, 16 * 16 * 16, NULL));
        CHECK_STATUS(cf, clvox_voxelize_to_memory(cf, mesh, &g, &o, buf, 16 * 16 * 16, NULL), CLVOX_ERR_NO_DEVICE);
        const char *e = clvox_context_error(cf);
        CHECK_MSG(strstr(e, "outside the range where float decides exactly") && strstr(e, "1e-09") &&
                      !strchr(e, '\n'),
                  "%s: %s", exact_cases[c].name, e);
    }
    free(buf);
    clvox_mesh_destroy(mesh);
    tmesh_free(&m);
}

/* The float build's cap values and estimates on voxels that are not cubes
 * (0.9 x 1.1 x 1.3), where its caps and points are the double kernels'
 * rounded to floats: every node of the cap tree of a random soup seen from
 * points next to its caps (a cap's point moved off its plane by 1e-7 to
 * 1e-1 of the extent) and at 0.5 to 1000 radii from its centre, each given
 * to the float kernel rounded to floats. The exact value and the estimates
 * must lie within their bounds of the sum over the double configuration
 * (the host's copy of the caps, clvox__caps.host, times the double scale,
 * at the point in double),
 * in long double; without the rounding terms of clvox_point_rounding the
 * points next to the caps break their bounds. */
static void test_cap_rounding(void)
{
    enum { NCAP = 64 };
    float soup[9 * NCAP];
    uint64_t seed = 0xcab5eed;
    for (int t = 0; t < NCAP; t++) {
        double c[3];
        for (int k = 0; k < 3; k++) c[k] = 20 * tmesh_rng_uniform(&seed);
        for (int k = 0; k < 9; k++) soup[9 * t + k] = (float)(c[k % 3] + 4 * (tmesh_rng_uniform(&seed) - 0.5));
    }
    clvox_grid grid;
    memset(&grid, 0, sizeof grid);
    grid.voxel_size[0] = 0.9, grid.voxel_size[1] = 1.1, grid.voxel_size[2] = 1.3;
    clvox__caps caps;
    CHECK_OK(cf, clvox__caps_upload(cf, soup, NCAP, clvox__axes_for(CLVOX_AXIS_X), &grid, &caps));
    cl_kernel k = NULL;
    CHECK_OK(cf, clvox__kernel(cf, "clvox_winding_probe", &k));
    if (!k || !caps.host || caps.host_count != NCAP) {
        CHECK_MSG(0, "cap rounding: no probe kernel or no host copy of the caps (%zu)", caps.host_count);
        if (k) clReleaseKernel(k);
        clvox__caps_release(&caps);
        return;
    }
    const size_t nn = caps.node_count;
    clvox_cap_node *nodes = malloc(nn * sizeof *nodes);
    double s3[3], *host = malloc(NCAP * 9 * sizeof *host); /* the double kernels' caps */
    CHECK(nodes != NULL && host != NULL);
    clvox__winding_scale(&grid, s3);
    for (size_t i = 0; i < NCAP * 9; i++) host[i] = (double)caps.host[i] * s3[i % 3];
    cl_int e = clEnqueueReadBuffer(cf->queue, caps.nodes, CL_TRUE, 0, nn * sizeof *nodes, nodes, 0, NULL, NULL);
    CHECK(e == CL_SUCCESS);
    static const double off[] = {1e-7, -1e-7, 3e-7, 1e-6, -1e-6, 1e-5, 1e-4, 1e-3, 1e-1};
    static const double ratio[] = {0.5, 1.2, 2.5, 4, 10, 100, 1000};
    const size_t no = sizeof off / sizeof off[0], nr = sizeof ratio / sizeof ratio[0], per = 4 * no + 2 * nr;
    const size_t pairs = nn * per;
    double *pd = malloc(pairs * 3 * sizeof *pd);
    float *pf = malloc(pairs * 3 * sizeof *pf), *res = malloc(pairs * 12 * sizeof *res);
    cl_uint *node_of = malloc(pairs * sizeof *node_of);
    CHECK(pd && pf && res && node_of);
    double ext = 0; /* the soup's extent, scaled */
    for (size_t i = 0; i < NCAP * 9; i++) ext = fmax(ext, fabs(host[i]));
    size_t at = 0;
    for (size_t j = 0; j < nn; j++) {
        const clvox_cap_node *nd = &nodes[j];
        for (size_t i = 0; i < 4 * no; i++, at++) { /* next to one of its caps */
            const double *t = host + 9 * (nd->tri_first + (uint32_t)(tmesh_rng_uniform(&seed) * nd->tri_count));
            double u = tmesh_rng_uniform(&seed), v = tmesh_rng_uniform(&seed);
            if (u + v > 1) u = 1 - u, v = 1 - v;
            const double e1[3] = {t[3] - t[0], t[4] - t[1], t[5] - t[2]}, e2[3] = {t[6] - t[0], t[7] - t[1], t[8] - t[2]};
            double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
            const double ln = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            for (int a = 0; a < 3; a++)
                pd[3 * at + a] = t[a] + u * e1[a] + v * e2[a] + (ln > 0 ? n[a] / ln : 0) * off[i % no] * ext;
            node_of[at] = (cl_uint)j;
        }
        for (size_t i = 0; i < 2 * nr; i++, at++) { /* about its centre */
            double d[3], l = 0;
            do {
                l = 0;
                for (int a = 0; a < 3; a++) d[a] = 2 * tmesh_rng_uniform(&seed) - 1, l += d[a] * d[a];
            } while (l > 1 || l < 1e-4);
            for (int a = 0; a < 3; a++) pd[3 * at + a] = nd->centre[a] + ratio[i % nr] * nd->radius * d[a] / sqrt(l);
            node_of[at] = (cl_uint)j;
        }
    }
    for (size_t i = 0; i < pairs * 3; i++) pf[i] = (float)pd[i];
    cl_int ce = CL_SUCCESS;
    cl_mem bn = clCreateBuffer(cf->cl, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, pairs * sizeof *node_of, node_of, &ce);
    cl_mem bp = clCreateBuffer(cf->cl, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, pairs * 3 * sizeof *pf, pf, &ce);
    cl_mem bo = clCreateBuffer(cf->cl, CL_MEM_WRITE_ONLY, pairs * 12 * sizeof *res, NULL, &ce);
    cl_uint cnt = (cl_uint)pairs;
    e = clSetKernelArg(k, 0, sizeof(cl_mem), &caps.nodes);
    e |= clSetKernelArg(k, 1, sizeof(cl_mem), &caps.tris);
    e |= clSetKernelArg(k, 2, sizeof(cl_mem), &bn);
    e |= clSetKernelArg(k, 3, sizeof(cl_mem), &bp);
    e |= clSetKernelArg(k, 4, sizeof(cl_uint), &cnt);
    e |= clSetKernelArg(k, 5, sizeof(cl_mem), &bo);
    size_t global = pairs;
    e |= clEnqueueNDRangeKernel(cf->queue, k, 1, NULL, &global, NULL, 0, NULL, NULL);
    e |= clEnqueueReadBuffer(cf->queue, bo, CL_TRUE, 0, pairs * 12 * sizeof *res, res, 0, NULL, NULL);
    CHECK(ce == CL_SUCCESS && e == CL_SUCCESS);
    size_t bad_exact = 0, bad_est = 0, bounded = 0, unbounded = 0;
    double worst = 0;
    for (size_t i = 0; ce == CL_SUCCESS && e == CL_SUCCESS && i < pairs; i++) {
        const clvox_cap_node *nd = &nodes[node_of[i]];
        long double w = 0;
        for (uint32_t t = nd->tri_first; t < nd->tri_first + nd->tri_count; t++) w += ref_cap(host + 9 * t, pd + 3 * i);
        const float *o = res + 12 * i;
        if (o[7] < 0.6f) { /* an unbounded lane adds CLVOX_ERR_UNBOUNDED x 0.16 */
            bounded++;
            const double gap = (double)fabsl((long double)o[6] - w);
            if (gap > o[7] && bad_exact++ < 5)
                fprintf(stderr, "  cap rounding: node %u, point %zu: exact %.9g +- %.3g, sum %.12Lg\n", node_of[i], i,
                        (double)o[6], (double)o[7], w);
            if (o[7] > 0 && gap / o[7] > worst) worst = gap / o[7];
        } else {
            unbounded++;
        }
        if (!((double)fabsl((long double)o[0] - w) <= o[1]) && bad_est++ < 5)
            fprintf(stderr, "  cap rounding: node %u, point %zu: estimate %.9g +- %.3g, sum %.12Lg\n", node_of[i], i,
                    (double)o[0], (double)o[1], w);
    }
    printf("cap rounding (voxels not cubes, float): %zu points, %zu exact values bounded (worst |sum - value| / "
           "bound %.3f), %zu unbounded (to the host)\n", pairs, bounded, worst, unbounded);
    CHECK_MSG(bad_exact == 0, "cap rounding: %zu of %zu exact values outside their bound", bad_exact, bounded);
    CHECK_MSG(bad_est == 0, "cap rounding: %zu of %zu estimates outside their bound", bad_est, pairs);
    CHECK_MSG(bounded > pairs / 2, "cap rounding: only %zu of %zu values bounded", bounded, pairs);
    clReleaseMemObject(bn);
    clReleaseMemObject(bp);
    clReleaseMemObject(bo);
    clReleaseKernel(k);
    clvox__caps_release(&caps);
    free(nodes);
    free(host);
    free(pd);
    free(pf);
    free(res);
    free(node_of);
}

/* The speed rule (src/core/device_speed.c): a device with fp64 whose double
 * is 8 or more times slower than its float gets the float build
 * (CLVOX_FP64_SLOWDOWN's hook stands in for a consumer GPU) and keeps it
 * for every run, the winding test on voxels that are not cubes included
 * (exact signs on the grid's floats), but switches to double for a run
 * whose coordinates leave float's exact range, and back: every run gives
 * the double context's bytes, and no warning. Below the rule's
 * ratio, double. And the measurement on this device (CLVOX_FP64_MEASURE's
 * hook): a ratio, the same one read back from the kernel cache by the next
 * context. */
static clvox_context *context_slowdown(double slowdown, int measure)
{
    clvox__test_hooks h = *clvox__hooks();
    h.kernels_float = 0;
    h.fp64_slowdown = slowdown;
    h.fp64_measure = measure;
    clvox__set_test_hooks(&h);
    clvox_context *c = test_context();
    h.fp64_slowdown = 0;
    h.fp64_measure = 0;
    clvox__set_test_hooks(&h);
    return c;
}

static void check_same(clvox_context *cs, const char *what, const clvox_mesh *mesh, const clvox_grid *g,
                       const clvox_voxelize_options *o, size_t want_real)
{
    const size_t n = (size_t)g->dims[0] * g->dims[1] * g->dims[2];
    uint8_t *a = malloc(n), *b = malloc(n);
    CHECK(a && b);
    if (a && b) {
        CHECK_OK(cd, clvox_voxelize_to_memory(cd, mesh, g, o, a, n, NULL));
        CHECK_OK(cs, clvox_voxelize_to_memory(cs, mesh, g, o, b, n, NULL));
        long d = 0;
        for (size_t i = 0; i < n; i++) d += a[i] != b[i];
        CHECK_MSG(d == 0, "speed rule, %s: %ld voxels differ from the double context's", what, d);
        CHECK_MSG(cs->real_size == want_real && clvox_context_device(cs)->kernels_float == (want_real == 4),
                  "speed rule, %s: kernels of %zu bytes (device info: float %d), want %zu", what, cs->real_size,
                  clvox_context_device(cs)->kernels_float, want_real);
        const char *w = clvox_context_warnings(cs);
        CHECK_MSG(!strstr(w, "without double precision"), "speed rule, %s: warned '%s'", what, w);
    }
    free(a);
    free(b);
}

static void test_speed_rule(void)
{
    clvox_context *cs = context_slowdown(32, 0);
    CHECK_MSG(cs && cs->real_size == 4 && cs->float_for_speed && clvox_context_device(cs)->kernels_float &&
                  clvox_context_device(cs)->fp64_slowdown == 32.0f,
              "slowdown 32: kernels of %zu bytes, float_for_speed %d", cs ? cs->real_size : 0,
              cs ? cs->float_for_speed : 0);
    tmesh m = tmesh_random_closed(5, 1, 150), box = {0}; /* box: m with every 7th face removed (open) */
    for (size_t v = 0; v < m.nv; v++) tmesh_add_vertex(&box, m.xyz[3 * v], m.xyz[3 * v + 1], m.xyz[3 * v + 2]);
    for (size_t t = 0; t < m.nt; t++)
        if (t % 7 != 3) tmesh_add_tri(&box, m.tri[3 * t], m.tri[3 * t + 1], m.tri[3 * t + 2]);
    clvox_mesh *mesh = NULL, *open = NULL;
    CHECK_OK(cd, clvox_mesh_from_arrays(cd, m.xyz, m.nv, m.tri, m.nt, &mesh));
    CHECK_OK(cd, clvox_mesh_from_arrays(cd, box.xyz, box.nv, box.tri, box.nt, &open));
    const double lo[3] = {-1.3, -1.3, -1.3}, hi[3] = {1.3, 1.3, 1.3};
    const clvox_grid cube = test_grid(lo, hi, 20, 20, 20), flat = test_grid(lo, hi, 23, 21, 19);
    if (cs && mesh && open) {
        clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
        check_same(cs, "winding, cubic voxels", open, &cube, &o, 4);
        check_same(cs, "winding, voxels not cubes", open, &flat, &o, 4);
        check_same(cs, "winding, cubic voxels again", open, &cube, &o, 4);
        o.method = CLVOX_METHOD_TETRA;
        check_same(cs, "tetra, voxels not cubes", mesh, &flat, &o, 4);
        o = (clvox_voxelize_options)CLVOX_VOXELIZE_OPTIONS_INIT;
        o.oversample = 2;
        check_same(cs, "coverage winding, voxels not cubes", open, &flat, &o, 4);
        o.inside = CLVOX_INSIDE_PARITY;
        check_same(cs, "coverage parity, voxels not cubes", mesh, &flat, &o, 4);
    }
    { /* a coordinate outside float's exact range: in double, not refused */
        const double blo[3] = {-0.5, -0.5, -0.5}, bhi[3] = {15.5, 15.5, 15.5};
        const clvox_grid g = test_grid(blo, bhi, 16, 16, 16);
        tmesh t = tmesh_box(1e-9, 2, 2, 10, 10, 10);
        clvox_mesh *tm = NULL;
        CHECK_OK(cd, clvox_mesh_from_arrays(cd, t.xyz, t.nv, t.tri, t.nt, &tm));
        clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
        o.inside = CLVOX_INSIDE_PARITY;
        if (cs && tm) check_same(cs, "a coordinate outside float's range", tm, &g, &o, 8);
        clvox_mesh_destroy(tm);
        tmesh_free(&t);
    }
    clvox_context_destroy(cs);
    clvox_context *c2 = context_slowdown(2, 0);
    CHECK_MSG(c2 && c2->real_size == 8 && !c2->float_for_speed && !clvox_context_device(c2)->kernels_float,
              "slowdown 2: kernels of %zu bytes", c2 ? c2->real_size : 0);
    clvox_context_destroy(c2);
    clvox_context *a = context_slowdown(0, 1), *b = context_slowdown(0, 1);
    const float ra = a ? clvox_context_device(a)->fp64_slowdown : -1, rb = b ? clvox_context_device(b)->fp64_slowdown : -1;
    printf("speed rule: this device's double measured %.2fx slower than its float (%s)\n", (double)ra,
           ra >= CLVOX__FP64_SLOW ? "float kernels" : "double kernels");
    CHECK_MSG(ra > 0 && ra == rb && a->real_size == (ra >= CLVOX__FP64_SLOW ? 4u : 8u),
              "measured slowdowns %g and %g (the second from the cache), kernels of %zu bytes", (double)ra, (double)rb,
              a ? a->real_size : 0);
    clvox_context_destroy(a);
    clvox_context_destroy(b);
    clvox_mesh_destroy(mesh);
    clvox_mesh_destroy(open);
    tmesh_free(&m);
    tmesh_free(&box);
}

static int by_name(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

static void test_data_meshes(void)
{
    DIR *dir = opendir("data/meshes");
    if (!dir) {
        printf("data/meshes missing (scripts/fetch_meshes.sh): skipped\n");
        return;
    }
    char *names[512];
    size_t count = 0;
    for (struct dirent *e; (e = readdir(dir)) && count < 512;) {
        size_t l = strlen(e->d_name);
        if (l > 4 && !strcmp(e->d_name + l - 4, ".off")) names[count++] = strdup(e->d_name);
    }
    closedir(dir);
    qsort(names, count, sizeof *names, by_name);
    const char *res = getenv("CLVOX_FLOAT_RES");
    const uint32_t n = res && atoi(res) > 0 ? (uint32_t)atoi(res) : 24;
    unsigned loaded = 0;
    for (size_t i = 0; i < count; i++) {
        char path[512];
        snprintf(path, sizeof path, "data/meshes/%s", names[i]);
        clvox_mesh *mesh = NULL;
        if (clvox_mesh_load(cd, path, &mesh) != CLVOX_OK) {
            printf("  %s: not loaded (%s)\n", names[i], clvox_context_error(cd));
            free(names[i]);
            continue;
        }
        const clvox_mesh_report *r = clvox_mesh_get_report(mesh);
        clvox_grid_options go = CLVOX_GRID_OPTIONS_INIT;
        go.resolution = n;
        go.padding = 1;
        clvox_grid g;
        if (r->triangles > 0 && clvox_grid_compute(cd, &go, r->bbox_min, r->bbox_max, &g) == CLVOX_OK) {
            compare_mesh(names[i], mesh, &g, 0);
            loaded++;
        }
        clvox_mesh_destroy(mesh);
        free(names[i]);
    }
    printf("data/meshes: %u meshes at %u, every exact mode byte-identical\n", loaded, n);
    CHECK_MSG(loaded >= 100 || count == 0, "only %u of %zu meshes compared", loaded, count);
}

int main(void)
{
    cf = context_with(1);
    cd = context_with(0);
    CHECK_OK(cd, clvox_palette_builtin(cd, "planar10", &g_palette));
    CHECK_MSG(cf->real_size == 4 && cd->real_size == 8, "kernels of %zu and %zu bytes: not a float and a double build",
              cf->real_size, cd->real_size);
    if (cf->real_size != 4 || cd->real_size != 8) return test_report();
    test_grid_aligned();
    test_random();
    test_steep_soups();
    test_cap_rounding();
    test_range_refused();
    test_speed_rule();
    test_adversarial();
    test_tilted_opening();
    test_near_centres();
    { /* the public option (clvox_context_options.float_kernels) builds them so too */
        clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
        co.float_kernels = 1;
        clvox_context *c = NULL;
        CHECK_OK(c, clvox_context_create(&co, &c));
        CHECK_MSG(c && c->real_size == 4 && c->kernels_float, "float_kernels: kernels of %zu bytes",
                  c ? c->real_size : 0);
        clvox_context_destroy(c);
    }
    if (!getenv("CLVOX_QUICK")) test_data_meshes();
    printf("%u runs of the exact modes, %u winding runs, %u coverage runs and %u palette runs compared, "
           "byte-identical; %llu points decided on the host\n",
           runs, winding_runs, coverage_runs, palette_runs, (unsigned long long)host_points);
    clvox_palette_destroy(g_palette);
    clvox_context_destroy(cf);
    clvox_context_destroy(cd);
    return test_report();
}
