/* SPDX-License-Identifier: Apache-2.0 */
/* Triangle soups against a brute-force exact winding-number oracle
 * (issue 35): every closed mesh of data/meshes in the list below is turned
 * into a soup -- each triangle gets three vertices of its own, none shared,
 * as an STL or a mesh saved per face gives -- jittered by 0, 1e-7, 1e-6,
 * 1e-5 and 1e-4 of its bounding box's largest side (each coordinate moved
 * by a uniform offset in [-rel, rel] x extent, seeded, in double then
 * rounded to float), and, unjittered, with 1 % and 10 % of its triangles
 * removed (at least one; seeded). Each case is voxelized with the default
 * inside test (winding, ray method) and compared voxel for voxel with
 *
 *   w(p) = (1/4pi) sum over the soup's triangles of their solid angles at
 *   the voxel centre p (van Oosterom--Strackee in double, in the library's
 *   own space: ref_winding_space), inside when w > 1/2 + 2^-30,
 *
 * the triangles as given: a soup's patches are single triangles (or, where
 * jitter left vertices equal, small pieces), whose orientation the
 * preparation keeps. The oracle carries an error bound for every centre
 * (oracle_w below); a centre whose interval w +- err contains the threshold
 * 1/2 + 2^-30 is one the oracle cannot decide (a centre on the surface, or
 * as good as): it is counted, printed and excluded, never guessed.
 *
 * Meshes: the closed meshes of data/meshes (by their edges: no edge used an
 * odd number of times) with at most 10 000 triangles, one of each group of
 * copies (the cube variants are one cube, tetrahedra one tetrahedron, ...),
 * at N voxels along the longest side with N from the triangle count, so
 * that the oracle (O(voxels x triangles x 7 cases)) stays near 60 s on 2
 * cores: N = 20 up to 500 triangles, 16 up to 2 000, 12 beyond. Larger
 * closed meshes (bull, fandisk, cheese, camel, armadillo, ...) are left out
 * only for time; scripts/bench/bench_winding_soup.sh times the armadillo
 * soup. CLVOX_SOUPS_ONLY=NAME runs the meshes whose name contains NAME.
 */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <string.h>
#include <unistd.h>

#include "reference.h"
#include "test.h"

static clvox_context *ctx;

/* closed meshes, fewest triangles first (see the top) */
static const char *const meshes[] = {
    "tetrahedron.off", "pyramid.off", "octahedron.off", "cube.off", "icosahedron.off", "star.off",
    "corner.off", "hole.off", "tripod.off", "3torus.off", "torus_quad.off", "P.off", "cross.off",
    "u.off", "mpi.off", "blob-closed.off", "dragknob.off", "ellipsoid.off", "geosphere.off", "itemb.off",
    "pipe.off", "part.off", "joint.off", "double-torus-example.off", "eight.off", "oblong.off", "helmet.off",
    "anchor.off", "rotor.off", "spool.off", "pinion.off", "larger_sphere.off", "cube-meshed.off",
    "sphere966.off", "handle.off", "hand.off", "ellipe0.003.off", "elk.off", "couplingdown.off", "blobby.off",
    "knot.off", "bones.off", "rotor_small.off", "elephant.off", "triceratops.off", "cow.off", "knot1.off",
    "retinal.off", "anchor_dense.off", "femur.off", "homer.off",
};

static uint32_t grid_n(size_t nt)
{
    return nt <= 500 ? 20u : nt <= 2000 ? 16u : 12u;
}

static uint64_t splitmix64(uint64_t *state)
{
    uint64_t z = (*state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static double uniform01(uint64_t *state)
{
    return (double)(splitmix64(state) >> 11) * 0x1p-53;
}

/* ---- the oracle ---------------------------------------------------------- */

/* w(p) and a bound on its error. Per triangle (a, b, c = corners - p,
 * M = |a||b||c|): the computed det = a.(b x c) and den = M + (a.b)|c| +
 * (b.c)|a| + (c.a)|b| are each within 64 eps M of the exact ones (each is
 * a sum of terms bounded by a small multiple of M with a few roundings per
 * term: a generous bound), so the angle atan2(det, den) is within
 * (pi/2) (|ddet| + |dden|) / hypot(det, den) of the exact one when that is
 * below 1 (else the triangle is undecidable: err = infinity), plus 2 ulp of
 * pi for atan2; the solid angle is twice it. The sum of n terms adds at
 * most n eps sum|omega|, and the division by 4 pi one more rounding. */
typedef struct oracle_job {
    const double *q; /* vertices in the library's space (ref_winding_space) */
    const uint32_t *tri;
    size_t nt;
    const clvox_grid *g;
    size_t v0, v1;   /* voxels [v0, v1) */
    double *w, *err;
} oracle_job;

static void oracle_w(const double *q, const uint32_t *tri, size_t nt, const double p[3], double *w, double *err)
{
    const double eps = 0x1p-53;
    double sum = 0, abs_sum = 0, e = 0;
    for (size_t t = 0; t < nt; t++) {
        const double *A = q + 3 * (size_t)tri[3 * t], *B = q + 3 * (size_t)tri[3 * t + 1],
                     *C = q + 3 * (size_t)tri[3 * t + 2];
        double a[3] = {A[0] - p[0], A[1] - p[1], A[2] - p[2]}, b[3] = {B[0] - p[0], B[1] - p[1], B[2] - p[2]},
               c[3] = {C[0] - p[0], C[1] - p[1], C[2] - p[2]};
        double la = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]), lb = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]),
               lc = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
        double bxc0 = b[1] * c[2] - b[2] * c[1], bxc1 = b[2] * c[0] - b[0] * c[2], bxc2 = b[0] * c[1] - b[1] * c[0];
        double det = a[0] * bxc0 + a[1] * bxc1 + a[2] * bxc2;
        double M = la * lb * lc;
        double den = M + (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) * lc + (b[0] * c[0] + b[1] * c[1] + b[2] * c[2]) * la +
                     (c[0] * a[0] + c[1] * a[1] + c[2] * a[2]) * lb;
        double om = 2.0 * atan2(det, den);
        double r = hypot(det, den), d = 128.0 * eps * M;
        if (M == 0 || !(d < r)) { /* p on a corner, or too near the triangle to tell */
            e = INFINITY;
        } else {
            e += 2.0 * (1.5707963267948966 * d / r * 1.0001 + 4.0 * eps * 3.1415926535897931);
        }
        sum += om;
        abs_sum += fabs(om);
    }
    *w = sum / (4.0 * 3.1415926535897931);
    *err = (e + (double)(nt + 1) * eps * abs_sum) / (4.0 * 3.1415926535897931) + 2.0 * eps * fabs(*w);
}

static void *oracle_thread(void *arg)
{
    oracle_job *j = arg;
    const uint32_t X = j->g->dims[0], Y = j->g->dims[1];
    for (size_t v = j->v0; v < j->v1; v++) {
        uint32_t i = (uint32_t)(v % X), jj = (uint32_t)(v / X % Y), k = (uint32_t)(v / X / Y);
        double p[3] = {i * j->g->voxel_size[0], jj * j->g->voxel_size[1], k * j->g->voxel_size[2]};
        oracle_w(j->q, j->tri, j->nt, p, &j->w[v], &j->err[v]);
    }
    return NULL;
}

/* w and err at every voxel centre, on two threads. */
static void oracle(const float *xyz, size_t nv, const uint32_t *tri, size_t nt, const clvox_grid *g, double *w,
                   double *err)
{
    double *q = ref_winding_space(xyz, nv, g);
    size_t n = (size_t)g->dims[0] * g->dims[1] * g->dims[2];
    oracle_job jobs[2] = {{q, tri, nt, g, 0, n / 2, w, err}, {q, tri, nt, g, n / 2, n, w, err}};
    pthread_t th;
    int started = pthread_create(&th, NULL, oracle_thread, &jobs[1]) == 0;
    oracle_thread(&jobs[0]);
    if (started) pthread_join(th, NULL);
    else oracle_thread(&jobs[1]);
    free(q);
}

/* ---- cases --------------------------------------------------------------- */

typedef struct tally {
    unsigned cases, passed;
    size_t voxels, undecided;
} tally;

/* Voxelizes the soup (xyz: 3 vertices per triangle, nt triangles) and
 * compares it with the oracle; returns the number of differing voxels. */
static size_t soup_case(const char *name, const char *what, const float *xyz, size_t nt, uint32_t N, tally *ty)
{
    size_t nv = nt * 3;
    uint32_t *tri = malloc((nv ? nv : 1) * sizeof *tri);
    if (!tri) abort();
    for (size_t i = 0; i < nv; i++) tri[i] = (uint32_t)i;
    clvox_mesh *m = NULL;
    CHECK_OK(ctx, clvox_mesh_from_arrays(ctx, xyz, nv, tri, nt, &m));
    if (!m) {
        free(tri);
        return 1;
    }
    clvox_grid g = test_padded_grid(ctx, clvox_mesh_get_report(m), N), gref = test_reference_grid(m, &g);
    const size_t n = (size_t)g.dims[0] * g.dims[1] * g.dims[2];
    uint8_t *dev = malloc(n);
    double *w = malloc(n * sizeof *w), *err = malloc(n * sizeof *err);
    if (!dev || !w || !err) abort();
    clvox_stats s = CLVOX_STATS_INIT;
    clvox_status st = clvox_voxelize_to_memory(ctx, m, &g, NULL, dev, n, &s);
    CHECK_MSG(st == CLVOX_OK, "%s %s: %s: %s", name, what, clvox_status_string(st), clvox_context_error(ctx));
    size_t diff = 0, undecided = 0, inside = 0;
    if (st == CLVOX_OK) {
        oracle(xyz, nv, tri, nt, &gref, w, err);
        const double th = 0.5 + REF_WINDING_EPS;
        for (size_t v = 0; v < n; v++) {
            if (!(w[v] - err[v] > th) && !(w[v] + err[v] <= th)) {
                undecided++;
                if (undecided <= 3)
                    printf("  %s %s: voxel (%zu, %zu, %zu) undecided by the oracle: w = %.17g +- %.3g, device %u\n",
                           name, what, v % g.dims[0], v / g.dims[0] % g.dims[1], v / g.dims[0] / g.dims[1], w[v],
                           err[v], dev[v]);
                continue;
            }
            uint8_t ref = w[v] > th;
            inside += ref;
            if (ref != dev[v]) {
                if (diff < 5)
                    printf("  DIFF %s %s: voxel (%zu, %zu, %zu): w = %.17g +- %.3g, oracle %s, device %s\n", name, what,
                           v % g.dims[0], v / g.dims[0] % g.dims[1], v / g.dims[0] / g.dims[1], w[v], err[v],
                           ref ? "inside" : "outside", dev[v] ? "inside" : "outside");
                diff++;
            }
        }
    }
    printf("%-26s %-14s %5zu tris %ux%ux%u: %zu inside, %zu undecided, %zu differ; prep %llu merged, %llu flipped, "
           "%llu caps, %llu exact points\n",
           name, what, nt, g.dims[0], g.dims[1], g.dims[2], inside, undecided, diff,
           (unsigned long long)s.winding.merged_vertices, (unsigned long long)s.winding.flipped_triangles,
           (unsigned long long)s.winding.cap_triangles, (unsigned long long)s.winding.exact_points);
    CHECK_MSG(st == CLVOX_OK && diff == 0, "%s %s: %zu voxels differ from the exact winding number", name, what, diff);
    /* the comparison above can fail: one decided voxel flipped is seen */
    if (st == CLVOX_OK && ty->cases == 0) {
        size_t flipped = 0;
        for (size_t v = 0; v < n; v++)
            if (w[v] - err[v] > 0.5 + REF_WINDING_EPS || w[v] + err[v] <= 0.5 + REF_WINDING_EPS) {
                flipped += (uint8_t)!dev[v] != (uint8_t)(w[v] > 0.5 + REF_WINDING_EPS);
            }
        CHECK_MSG(flipped == n - undecided - diff, "the self-check saw %zu of %zu flipped voxels", flipped,
                  n - undecided - diff);
    }
    ty->cases++;
    ty->passed += st == CLVOX_OK && diff == 0;
    ty->voxels += n;
    ty->undecided += undecided;
    free(dev);
    free(w);
    free(err);
    free(tri);
    clvox_mesh_destroy(m);
    return diff;
}

static void soup_mesh(const char *name, tally *ty)
{
    char path[256];
    snprintf(path, sizeof path, "data/meshes/%s", name);
    clvox_mesh *m = NULL;
    if (access(path, R_OK) != 0 || clvox_mesh_load(ctx, path, &m) != CLVOX_OK) {
        CHECK_MSG(0, "cannot load %s (run scripts/fetch_meshes.sh)", path);
        return;
    }
    size_t nv, nt;
    const float *xyz = clvox_mesh_vertices(m, &nv);
    const uint32_t *tri = clvox_mesh_triangles(m, &nt);
    CHECK_MSG(clvox_mesh_get_report(m)->closed, "%s is not closed", name);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY}, extent = 0;
    for (size_t i = 0; i < nv; i++)
        for (int a = 0; a < 3; a++) {
            if (xyz[3 * i + a] < lo[a]) lo[a] = xyz[3 * i + a];
            if (xyz[3 * i + a] > hi[a]) hi[a] = xyz[3 * i + a];
        }
    for (int a = 0; a < 3; a++)
        if (hi[a] - lo[a] > extent) extent = hi[a] - lo[a];
    const uint32_t N = grid_n(nt);
    float *soup = malloc(nt * 9 * sizeof *soup);
    if (!soup) abort();
    static const double jitter[] = {0, 1e-7, 1e-6, 1e-5, 1e-4};
    for (size_t j = 0; j < sizeof jitter / sizeof jitter[0]; j++) {
        uint64_t seed = 0x5eed0000u + j;
        for (size_t i = 0; i < nt * 3; i++)
            for (int a = 0; a < 3; a++)
                soup[3 * i + a] = (float)((double)xyz[3 * (size_t)tri[i] + a] +
                                          (2.0 * uniform01(&seed) - 1.0) * jitter[j] * extent);
        char what[32];
        snprintf(what, sizeof what, "jitter %g", jitter[j]);
        soup_case(name, what, soup, nt, N, ty);
    }
    /* unjittered, with 1 % and 10 % of the triangles removed */
    static const double removed[] = {0.01, 0.10};
    uint8_t *drop = malloc(nt);
    if (!drop) abort();
    for (size_t r = 0; r < sizeof removed / sizeof removed[0]; r++) {
        size_t k = (size_t)lround(removed[r] * (double)nt), kept = 0;
        if (k < 1) k = 1;
        memset(drop, 0, nt);
        uint64_t seed = 0xd40b0000u + r;
        for (size_t d = 0; d < k;) { /* k distinct triangles */
            size_t t = (size_t)(uniform01(&seed) * (double)nt);
            if (t < nt && !drop[t]) drop[t] = 1, d++;
        }
        for (size_t t = 0; t < nt; t++) {
            if (drop[t]) continue;
            for (int c = 0; c < 3; c++) memcpy(soup + 9 * kept + 3 * c, xyz + 3 * (size_t)tri[3 * t + c], 3 * sizeof *soup);
            kept++;
        }
        char what[32];
        snprintf(what, sizeof what, "%g%% removed", removed[r] * 100);
        soup_case(name, what, soup, kept, N, ty);
    }
    free(drop);
    free(soup);
    clvox_mesh_destroy(m);
}

int main(void)
{
    ctx = test_context();
    const char *only = getenv("CLVOX_SOUPS_ONLY");
    tally ty = {0, 0, 0, 0};
    for (size_t i = 0; i < sizeof meshes / sizeof meshes[0]; i++)
        if (!only || strstr(meshes[i], only)) soup_mesh(meshes[i], &ty);
    printf("soups: %u of %u cases equal to the exact winding number; %zu of %zu voxels undecided by the oracle "
           "(excluded)\n",
           ty.passed, ty.cases, ty.undecided, ty.voxels);
    clvox_context_destroy(ctx);
    return test_report();
}
