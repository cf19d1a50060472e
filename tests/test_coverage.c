/* SPDX-License-Identifier: Apache-2.0 */
/* Grey-level voxelization (coverage, Thon et al. 3.3.4): the sampler against
 * its published known answers, HALF rounding against every HALF value,
 * exact fractions of boxes, the CPU reference bit for bit (uniform and
 * stochastic, every axis), K = 1 against the binary volume, determinism
 * across slab depths, overflow and devices, convergence with K, an unbiased
 * mean over seeds, and bad options. */
#include "meshgen.h"
#include "reference.h"
#include "test.h"
#include "core/internal.h"
#include "../kernels/sampler.h"

#include <gmp.h>
#include <math.h>
#include <string.h>

static clvox_context *ctx;

static clvox_mesh *to_mesh(clvox_context *c, const tmesh *t)
{
    clvox_mesh *m = NULL;
    if (clvox_mesh_from_arrays(c, t->xyz, t->nv, t->tri, t->nt, &m) != CLVOX_OK) {
        fprintf(stderr, "mesh_from_arrays: %s\n", clvox_context_error(c));
        return NULL;
    }
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

static double half_to_double(uint16_t h)
{
    int e = (h >> 10) & 31, f = h & 1023;
    double v = e ? ldexp(1024 + f, e - 25) : ldexp(f, -24);
    return (h & 0x8000) ? -v : v;
}

/* Coverage (and occupancy) of one run into new arrays. */
static float *coverage_run(clvox_context *c, const clvox_mesh *m, const clvox_grid *g, const clvox_voxelize_options *o,
                           uint8_t **occ, clvox_stats *stats)
{
    float *cov = calloc(nvox(g), sizeof *cov);
    if (occ) *occ = calloc(nvox(g), 1);
    clvox_stats local = CLVOX_STATS_INIT;
    CHECK_OK(c, clvox_voxelize_to_buffers(c, m, g, o, occ ? *occ : NULL, nvox(g), cov, nvox(g), stats ? stats : &local));
    return cov;
}

static void test_philox_known_answers(void)
{
    /* Salmon et al.'s published vectors for Philox4x32-10 (counter, key -> output). */
    static const uint32_t kat[3][10] = {
        {0, 0, 0, 0, 0, 0, 0x6627e8d5, 0xe169c58d, 0xbc57ac4c, 0x9b00dbd8},
        {0xffffffff, 0xffffffff, 0xffffffff, 0xffffffff, 0xffffffff, 0xffffffff, 0x408f276d, 0x41c83b0e, 0xa20bc7c6,
         0x6d5451fd},
        {0x243f6a88, 0x85a308d3, 0x13198a2e, 0x03707344, 0xa4093822, 0x299f31d0, 0xd16cfe09, 0x94fdcceb, 0x5001e420,
         0x24126ea1},
    };
    for (int i = 0; i < 3; i++) {
        uint32_t out[4];
        clvox_philox4x32_10(kat[i][0], kat[i][1], kat[i][2], kat[i][3], kat[i][4], kat[i][5], out);
        CHECK_MSG(out[0] == kat[i][6] && out[1] == kat[i][7] && out[2] == kat[i][8] && out[3] == kat[i][9],
                  "vector %d: %08x %08x %08x %08x", i, out[0], out[1], out[2], out[3]);
    }
    /* strata: uniform centres, stochastic in [i/n, (i+1)/n) */
    CHECK(clvox_stratum(0, 1, 0, 123) == 0.5);
    CHECK(clvox_stratum(3, 4, 0, 0) == 0.875);
    CHECK(clvox_stratum(2, 4, 1, 0) == 0.5);
    CHECK(clvox_stratum(3, 4, 1, 0xFFFFFFFFu) < 1.0);
}

/* clvox_sample_u_exact (the points along a ray, the same float in every
 * build; in integers) against GMP, and clvox_sample_u (double where it
 * can) equal to it: the nearest float, ties to even, of u - 1/2 + (m + j) / M,
 * j = bits 2^-32 or 1/2, and 0 below 2^-24 in magnitude; voxel centres
 * (M = 1, uniform) exactly u. */
static void test_sample_points(void)
{
    uint64_t rng = 0x9E3779B97F4A7C15u;
    int bad = 0, n = 0;
    mpq_t x, t, mid;
    mpq_inits(x, t, mid, NULL);
    for (int i = 0; i < 200000; i++) {
        rng = rng * 6364136223846793005u + 1442695040888963407u;
        const uint32_t r = (uint32_t)(rng >> 32), r2 = (uint32_t)rng;
        const uint32_t u = i % 3 == 0 ? r % 4u : (i % 3 == 1 ? r % 70000u : r % (1u << 20));
        const uint32_t M = i % 5 == 0 ? 255u : 1u + r2 % 16u, m = (r >> 8) % M;
        const int st = i & 1;
        const uint32_t bits = st ? r2 * 2654435761u : 0;
        const float f = clvox_sample_u_exact(u, m, M, st, bits), fast = clvox_sample_u(u, m, M, st, bits);
        if (memcmp(&f, &fast, sizeof f) && bad++ < 3)
            fprintf(stderr, "sample u %u m %u M %u bits %08x: %.9g, the fast path %.9g\n", u, m, M, bits, f, fast);
        /* x = (2u - 1)/2 + (m 2^32 + J) / (M 2^32) */
        mpq_set_si(x, 2 * (long)u - 1, 2);
        mpz_set_ui(mpq_numref(t), m);
        mpz_mul_2exp(mpq_numref(t), mpq_numref(t), 32);
        mpz_add_ui(mpq_numref(t), mpq_numref(t), st ? bits : 0x80000000u);
        mpz_set_ui(mpq_denref(t), M);
        mpz_mul_2exp(mpq_denref(t), mpq_denref(t), 32);
        mpq_canonicalize(t);
        mpq_add(x, x, t);
        int ok;
        mpq_set_d(mid, 0x1p-24);
        mpq_abs(t, x);
        if (mpq_cmp(t, mid) < 0) {
            ok = f == 0.0f;
        } else {
            const float lo = nextafterf(f, -INFINITY), hi = nextafterf(f, INFINITY);
            uint32_t fb;
            memcpy(&fb, &f, sizeof fb);
            const int even = (fb & 1u) == 0;
            mpq_set_d(mid, ((double)lo + (double)f) / 2); /* exact in double */
            const int c1 = mpq_cmp(x, mid);
            mpq_set_d(mid, ((double)f + (double)hi) / 2);
            const int c2 = mpq_cmp(x, mid);
            ok = f != 0.0f && (c1 > 0 || (c1 == 0 && even)) && (c2 < 0 || (c2 == 0 && even));
        }
        if (!ok && bad++ < 3) fprintf(stderr, "sample u %u m %u M %u bits %08x: %.9g\n", u, m, M, bits, f);
        n++;
    }
    mpq_clears(x, t, mid, NULL);
    CHECK_MSG(bad == 0, "%d of %d sample points not the nearest float", bad, n);
    int centres = 0;
    for (uint32_t u = 0; u < 70000; u++) centres += clvox_sample_u(u, 0, 1, 0, 0) == (float)u;
    CHECK_MSG(centres == 70000, "%d of 70000 centres exact", centres);
    CHECK(clvox_sample_u(5, 1, 2, 0, 0) == 5.25f && clvox_sample_u(0, 0, 2, 0, 0) == -0.25f);
}

static void test_half_rounding(void)
{
    /* every HALF value in [0, 1] converts to itself; midpoints go to the even neighbour */
    int bad = 0, bad_mid = 0;
    for (uint32_t h = 0; h <= 0x3C00; h++) {
        double v = half_to_double((uint16_t)h);
        if (clvox__half_from_unit(v) != h) bad++;
        if (h < 0x3C00) {
            double mid = (v + half_to_double((uint16_t)(h + 1))) / 2;
            uint16_t want = (uint16_t)((h & 1) ? h + 1 : h);
            if (clvox__half_from_unit(mid) != want) bad_mid++;
        }
    }
    CHECK_MSG(bad == 0, "%d HALF values do not round to themselves", bad);
    CHECK_MSG(bad_mid == 0, "%d midpoints not rounded to even", bad_mid);
    CHECK(clvox__half_from_unit(0.3) == 0x34CD);
    CHECK(clvox__half_from_unit(0.0) == 0 && clvox__half_from_unit(1.0) == 0x3C00);
}

/* Box [1, 2.3] x [1, 2.6] x [1, 2.5] in a unit-voxel grid: voxel (2,y,z)
 * holds 3 of 10 x-strata, (x,2,z) 6 of 10 y-strata, (x,y,2) 5 of 10
 * z-strata, so K = 10 gives exact fractions (0.3, 0.6, 0.5, their products). */
static void test_exact_fractions(void)
{
    tmesh t = tmesh_box(1.0, 1.0, 1.0, 2.3, 2.6, 2.5);
    clvox_mesh *m = to_mesh(ctx, &t);
    double lo[3] = {0, 0, 0}, h[3] = {1, 1, 1};
    clvox_grid g = make_grid(lo, h, 4, 4, 4);
    const double fx[4] = {0, 1, 0.3, 0}, fy[4] = {0, 1, 0.6, 0}, fz[4] = {0, 1, 0.5, 0};
    for (int axis = CLVOX_AXIS_X; axis <= CLVOX_AXIS_Z; axis++) {
        clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
        o.oversample = 10;
        o.ray_axis = (clvox_axis)axis;
        clvox_stats s = CLVOX_STATS_INIT;
        float *cov = coverage_run(ctx, m, &g, &o, NULL, &s);
        int bad = 0;
        double sum = 0;
        for (uint32_t z = 0; z < 4; z++)
            for (uint32_t y = 0; y < 4; y++)
                for (uint32_t x = 0; x < 4; x++) {
                    float want = (float)(uint32_t)lround(fx[x] * fy[y] * fz[z] * 1000) / 1000.0f;
                    float got = cov[(z * 4 + y) * 4 + x];
                    if (got != want) {
                        if (bad++ < 5) fprintf(stderr, "axis %d voxel %u,%u,%u: %.9g, want %.9g\n", axis, x, y, z, got, want);
                    }
                    sum += fx[x] * fy[y] * fz[z];
                }
        CHECK_MSG(bad == 0, "axis %d: %d voxels off", axis, bad);
        CHECK(s.samples_per_voxel == 1000);
        CHECK_MSG(fabs(s.coverage_sum - sum) < 1e-9, "coverage sum %.12g, want %.12g", s.coverage_sum, sum);
        CHECK(cov[(1 * 4 + 1) * 4 + 2] == 0.3f);                      /* face at 0.3 of the voxel */
        CHECK(cov[(2 * 4 + 2) * 4 + 2] == 90.0f / 1000.0f);           /* corner 0.3 x 0.6 x 0.5 */
        CHECK(cov[(1 * 4 + 1) * 4 + 1] == 1.0f && cov[0] == 0.0f);    /* inside, outside */
        free(cov);
    }
    /* Through the file: HALF of the exact fraction. */
    char path[512];
    snprintf(path, sizeof path, "%s/coverage_exact.exr", test_tmpdir());
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    o.oversample = 10;
    CHECK_OK(ctx, clvox_voxelize_to_exr(ctx, m, &g, &o, path, NULL));
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    uint8_t occ[64];
    CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, occ, sizeof occ));
    CHECK(strcmp(info.channels, "coverage") == 0);
    double want_sum = 0;
    for (int v = 0; v < 64; v++) {
        int x = v % 4, y = v / 4 % 4, z = v / 16;
        want_sum += half_to_double(clvox__half_from_unit(fx[x] * fy[y] * fz[z]));
    }
    CHECK_MSG(info.coverage_sum == want_sum, "file coverage sum %.12g, want %.12g", info.coverage_sum, want_sum);
    CHECK(info.filled_voxels == 2); /* coverage > 0.5: 1 and 0.6 */
    remove(path);
    clvox_mesh_destroy(m);
    tmesh_free(&t);
}

/* Device == CPU reference, count for count. */
/* The inside test of compare_reference's runs: the default (winding) equals
 * the parity reference on closed, consistently oriented meshes; overlapping
 * shells need parity. */
static clvox_inside g_inside = CLVOX_INSIDE_DEFAULT;

static int compare_reference(clvox_context *c, const tmesh *t, const clvox_grid *g, clvox_axis axis, uint32_t N,
                             uint32_t M, int stochastic, uint64_t seed, uint32_t slab, uint32_t capacity)
{
    clvox_mesh *m = to_mesh(c, t);
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    o.ray_axis = axis;
    o.oversample = N;
    o.oversample_points = M;
    o.stochastic = stochastic;
    o.seed = seed;
    o.slab_depth = slab;
    o.hit_capacity = capacity;
    o.inside = g_inside;
    float *cov = coverage_run(c, m, g, &o, NULL, NULL);
    if (M == 0) M = N;
    uint32_t *ref = malloc(nvox(g) * sizeof *ref);
    ref_coverage(t->xyz, t->nv, t->tri, t->nt, g, axis, N, M, stochastic, seed, ref);
    const float S = (float)(N * N * M);
    int bad = 0;
    for (size_t i = 0; i < nvox(g); i++)
        if (cov[i] != (float)ref[i] / S) {
            if (bad++ < 3) fprintf(stderr, "voxel %zu: %.9g, reference %u/%g\n", i, cov[i], ref[i], S);
        }
    free(cov);
    free(ref);
    clvox_mesh_destroy(m);
    return bad;
}

static void test_reference(void)
{
    double lo[3] = {0, 0, 0}, h[3] = {1.0 / 13, 1.0 / 11, 1.0 / 9};
    clvox_grid g = make_grid(lo, h, 13, 11, 9);
    for (uint64_t seed = 1; seed <= 3; seed++) {
        tmesh t = tmesh_random_closed(seed, 2, 3);
        for (int axis = CLVOX_AXIS_X; axis <= CLVOX_AXIS_Z; axis++) {
            int b1 = compare_reference(ctx, &t, &g, (clvox_axis)axis, 3, 0, 0, 0, 0, 0);
            CHECK_MSG(b1 == 0, "uniform 3x3x3, mesh %llu axis %d: %d voxels differ", (unsigned long long)seed, axis, b1);
            int b2 = compare_reference(ctx, &t, &g, (clvox_axis)axis, 2, 5, 1, seed * 977, 0, 0);
            CHECK_MSG(b2 == 0, "stochastic 2x2x5, mesh %llu axis %d: %d voxels differ", (unsigned long long)seed, axis, b2);
        }
        tmesh_free(&t);
    }
    /* grid-aligned vertices and edges on ray positions: the tie rules */
    tmesh box = tmesh_box_subdivided(0.25, 0.25, 0.25, 0.75, 0.75, 0.75, 4);
    double glo[3] = {0, 0, 0}, gh[3] = {1.0 / 8, 1.0 / 8, 1.0 / 8};
    clvox_grid gg = make_grid(glo, gh, 8, 8, 8);
    for (int axis = CLVOX_AXIS_X; axis <= CLVOX_AXIS_Z; axis++) {
        int b = compare_reference(ctx, &box, &gg, (clvox_axis)axis, 2, 2, 0, 0, 0, 0);
        CHECK_MSG(b == 0, "aligned box, axis %d: %d voxels differ", axis, b);
    }
    tmesh_free(&box);
    /* faces on the sample points and rays themselves (2 x 2 rays x 2 points:
     * samples at grid k -+ 1/4, here 1.75 and 5.25): every comparison of a
     * point with a crossing a tie, decided by the exact rule (the
     * crossings rounded up to floats, kernels/intersect.cl), against the
     * reference's exact sign per point and triangle, in parity and winding */
    tmesh onpts = tmesh_box_subdivided(2.25 / 8, 2.25 / 8, 2.25 / 8, 5.75 / 8, 5.75 / 8, 5.75 / 8, 3);
    for (int inside = 0; inside <= 1; inside++) {
        g_inside = inside ? CLVOX_INSIDE_PARITY : CLVOX_INSIDE_DEFAULT;
        for (int axis = CLVOX_AXIS_X; axis <= CLVOX_AXIS_Z; axis++) {
            int b = compare_reference(ctx, &onpts, &gg, (clvox_axis)axis, 2, 2, 0, 0, 0, 0);
            CHECK_MSG(b == 0, "box on the sample points, axis %d, %s: %d voxels differ", axis,
                      inside ? "parity" : "winding", b);
        }
    }
    /* sloped: the octahedron |x - 4| + |y - 4| + |z - 4| = 2.75 (grid
     * space) holds many samples of the rays on its faces: the tie rule on
     * sloped faces (its crossings are dyadic, so exact either way; the
     * rounding up itself is held by test_float_kernels' lattice soups) */
    tmesh octa = tmesh_octahedron(4.5 / 8, 4.5 / 8, 4.5 / 8, 2.75 / 8);
    for (int axis = CLVOX_AXIS_X; axis <= CLVOX_AXIS_Z; axis++) {
        g_inside = CLVOX_INSIDE_PARITY;
        int b = compare_reference(ctx, &octa, &gg, (clvox_axis)axis, 2, 2, 0, 0, 0, 0);
        CHECK_MSG(b == 0, "octahedron through the sample points, axis %d: %d voxels differ", axis, b);
    }
    tmesh_free(&octa);
    g_inside = CLVOX_INSIDE_DEFAULT;
    tmesh_free(&onpts);
    /* overlapping shells (parity, not union), slab depth 1 and crossing capacity 1 */
    double c1[3], c2[3];
    tmesh ov = tmesh_random_overlap(5, 3, c1, c2);
    g_inside = CLVOX_INSIDE_PARITY;
    int b = compare_reference(ctx, &ov, &g, CLVOX_AXIS_Z, 3, 2, 1, 42, 1, 1);
    CHECK_MSG(b == 0, "overlap, slab 1, capacity 1: %d voxels differ", b);
    b = compare_reference(ctx, &ov, &g, CLVOX_AXIS_X, 4, 1, 1, 43, 2, 1);
    CHECK_MSG(b == 0, "overlap, x, capacity 1: %d voxels differ", b);
    g_inside = CLVOX_INSIDE_DEFAULT;
    tmesh_free(&ov);
}

/* K = 1 uniform is the binary volume, coverage and thresholded occupancy alike. */
static void test_k1_is_binary(void)
{
    double lo[3] = {0, 0, 0}, h[3] = {1.0 / 40, 1.0 / 37, 1.0 / 33};
    clvox_grid g = make_grid(lo, h, 40, 37, 33);
    tmesh t = tmesh_random_closed(11, 3, 4);
    clvox_mesh *m = to_mesh(ctx, &t);
    for (int axis = CLVOX_AXIS_X; axis <= CLVOX_AXIS_Z; axis++) {
        clvox_voxelize_options b = CLVOX_VOXELIZE_OPTIONS_INIT;
        b.ray_axis = (clvox_axis)axis;
        uint8_t *bin = calloc(nvox(&g), 1);
        clvox_stats sb = CLVOX_STATS_INIT;
        CHECK_OK(ctx, clvox_voxelize_to_memory(ctx, m, &g, &b, bin, nvox(&g), &sb));
        clvox_voxelize_options o = b;
        o.oversample = 1;
        o.threshold_set = 1;
        o.channels = CLVOX_CHANNEL_OCCUPANCY | CLVOX_CHANNEL_COVERAGE;
        o.threshold = 0.5;
        uint8_t *occ = NULL;
        clvox_stats sc = CLVOX_STATS_INIT;
        float *cov = coverage_run(ctx, m, &g, &o, &occ, &sc);
        int bad_cov = 0, bad_occ = 0;
        for (size_t i = 0; i < nvox(&g); i++) {
            bad_cov += cov[i] != (float)bin[i];
            bad_occ += occ[i] != bin[i];
        }
        CHECK_MSG(bad_cov == 0 && bad_occ == 0, "axis %d: %d coverage, %d occupancy voxels differ from binary", axis,
                  bad_cov, bad_occ);
        CHECK(sc.filled_voxels == sb.filled_voxels && sc.coverage_sum == (double)sb.filled_voxels);
        CHECK(sc.rays == sb.rays && sc.odd_parity_rays == 0);
        /* the legacy occupancy call with oversampling: coverage > 0.5 */
        clvox_voxelize_options o2 = b;
        o2.oversample = 1;
        uint8_t *occ2 = calloc(nvox(&g), 1);
        CHECK_OK(ctx, clvox_voxelize_to_memory(ctx, m, &g, &o2, occ2, nvox(&g), NULL));
        CHECK(memcmp(occ2, bin, nvox(&g)) == 0);
        free(occ2);
        free(bin);
        free(occ);
        free(cov);
    }
    clvox_mesh_destroy(m);
    tmesh_free(&t);
}

typedef struct slab_log {
    uint64_t occ_sum;
    double cov_sum;
    uint32_t next_z;
    int order_ok, both;
} slab_log;

static int on_slab(void *user, const clvox_slab *s)
{
    slab_log *l = user;
    if (s->z0 != l->next_z) l->order_ok = 0;
    l->next_z = s->z0 + s->nz;
    if (s->occupancy && s->coverage) l->both++;
    size_t n = (size_t)s->nz * 30 * 30;
    for (size_t i = 0; i < n; i++) {
        if (s->occupancy) l->occ_sum += s->occupancy[i];
        if (s->coverage) l->cov_sum += s->coverage[i];
    }
    return 0;
}

/* Same seed, same volume: across runs, slab depths, crossing capacities,
 * sinks and devices; another seed differs. */
static void test_determinism(void)
{
    double lo[3] = {0, 0, 0}, h[3] = {1.0 / 30, 1.0 / 30, 1.0 / 30};
    clvox_grid g = make_grid(lo, h, 30, 30, 30);
    tmesh t = tmesh_random_closed(21, 2, 4);
    clvox_mesh *m = to_mesh(ctx, &t);
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    o.oversample = 3;
    o.stochastic = 1;
    o.seed = 0x123456789abcull;
    o.threshold_set = 1;
    o.channels = CLVOX_CHANNEL_OCCUPANCY | CLVOX_CHANNEL_COVERAGE;
    o.threshold = 0.25;
    uint8_t *occ0 = NULL;
    clvox_stats s0 = CLVOX_STATS_INIT;
    float *a = coverage_run(ctx, m, &g, &o, &occ0, &s0);
    const uint32_t slabs[] = {1, 4, 7, 30};
    const uint32_t caps[] = {1, 2, 0};
    for (size_t i = 0; i < sizeof slabs / sizeof slabs[0]; i++)
        for (size_t j = 0; j < sizeof caps / sizeof caps[0]; j++) {
            clvox_voxelize_options p = o;
            p.slab_depth = slabs[i];
            p.hit_capacity = caps[j];
            uint8_t *occ = NULL;
            clvox_stats s = CLVOX_STATS_INIT;
            float *b = coverage_run(ctx, m, &g, &p, &occ, &s);
            CHECK_MSG(memcmp(a, b, nvox(&g) * sizeof *a) == 0 && memcmp(occ0, occ, nvox(&g)) == 0,
                      "slab %u capacity %u differs", slabs[i], caps[j]);
            CHECK(s.coverage_sum == s0.coverage_sum && s.filled_voxels == s0.filled_voxels);
            if (caps[j] == 1) CHECK(s.overflow_rays > 0);
            free(b);
            free(occ);
        }
    /* the slab callback gets both channels, the same values */
    slab_log l = {0, 0, 0, 1, 0};
    clvox_voxelize_options p = o;
    p.slab_depth = 4;
    CHECK_OK(ctx, clvox_voxelize_slabs(ctx, m, &g, &p, on_slab, &l, NULL));
    double sum = 0;
    uint64_t filled = 0;
    for (size_t i = 0; i < nvox(&g); i++) sum += a[i], filled += occ0[i];
    CHECK(l.order_ok && l.next_z == 30 && l.both == 8);
    CHECK_MSG(fabs(l.cov_sum - sum) < 1e-9 && l.occ_sum == filled, "callback sums %.9g / %llu", l.cov_sum,
              (unsigned long long)l.occ_sum);
    /* occupancy is coverage > threshold */
    int bad = 0;
    for (size_t i = 0; i < nvox(&g); i++) bad += occ0[i] != (a[i] > 0.25f);
    CHECK(bad == 0);
    /* another seed */
    p = o;
    p.seed = o.seed + 1;
    float *c = coverage_run(ctx, m, &g, &p, NULL, NULL);
    CHECK(memcmp(a, c, nvox(&g) * sizeof *a) != 0);
    free(c);

    /* every device (POCL_DEVICES="pthread pthread" gives two PoCL devices) */
    clvox_device_info devs[8] = { CLVOX_DEVICE_INFO_INIT };
    size_t ndev = 0;
    if (clvox_list_devices(devs, 8, &ndev) == CLVOX_OK) {
        CHECK(ndev >= 2);
        for (size_t d = 0; d < ndev && d < 8; d++) {
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
            clvox_mesh *m2 = to_mesh(c2, &t);
            float *b = coverage_run(c2, m2, &g, &o, NULL, NULL);
            CHECK_MSG(memcmp(a, b, nvox(&g) * sizeof *a) == 0, "device %s (%s) differs", sel, devs[d].name);
            free(b);
            clvox_mesh_destroy(m2);
            clvox_context_destroy(c2);
        }
    }
    free(a);
    free(occ0);
    clvox_mesh_destroy(m);
    tmesh_free(&t);
}

/* Sum of coverage x voxel volume converges to the enclosed volume. */
static void test_convergence(void)
{
    const unsigned n = 24;
    tmesh t = tmesh_sphere(0.5, 0.5, 0.5, 0.37, n);
    double exact = tmesh_sphere_poly_volume(0.37, n);
    clvox_mesh *m = to_mesh(ctx, &t);
    double lo[3] = {0, 0, 0}, h[3] = {1.0 / 12, 1.0 / 12, 1.0 / 12};
    clvox_grid g = make_grid(lo, h, 12, 12, 12);
    const double vv = h[0] * h[1] * h[2];
    double err[5];
    const uint32_t ks[5] = {1, 2, 4, 8, 16};
    for (int i = 0; i < 5; i++) {
        clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
        o.oversample = ks[i];
        o.oversample_points = ks[i] == 16 ? 16 : 0;
        clvox_stats s = CLVOX_STATS_INIT;
        float *c = coverage_run(ctx, m, &g, &o, NULL, &s);
        err[i] = fabs(s.coverage_sum * vv - exact) / exact;
        fprintf(stderr, "uniform K=%u: relative volume error %.3e\n", ks[i], err[i]);
        free(c);
    }
    CHECK_MSG(err[4] < err[2] && err[2] < err[0] && err[4] < 1e-3, "uniform errors %.3e %.3e %.3e", err[0], err[2],
              err[4]);
    /* stochastic: RMS error over seeds falls at least as 1/sqrt(samples) */
    double rms[3];
    const uint32_t sk[3] = {1, 2, 4};
    for (int i = 0; i < 3; i++) {
        double acc = 0;
        const int seeds = 12;
        for (int sd = 0; sd < seeds; sd++) {
            clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
            o.oversample = sk[i];
            o.stochastic = 1;
            o.seed = (uint64_t)(1000 + sd);
            clvox_stats s = CLVOX_STATS_INIT;
            float *c = coverage_run(ctx, m, &g, &o, NULL, &s);
            double e = (s.coverage_sum * vv - exact) / exact;
            acc += e * e;
            free(c);
        }
        rms[i] = sqrt(acc / seeds);
        fprintf(stderr, "stochastic K=%u (%u samples): RMS relative error %.3e\n", sk[i], sk[i] * sk[i] * sk[i], rms[i]);
    }
    CHECK_MSG(rms[1] < rms[0] / sqrt(8.0) * 1.5 && rms[2] < rms[1] / sqrt(8.0) * 1.5, "stochastic RMS %.3e %.3e %.3e",
              rms[0], rms[1], rms[2]);
    clvox_mesh_destroy(m);
    tmesh_free(&t);
}

/* Volume of {p in [0,1]^3 : n.p <= d}, n > 0 (inclusion-exclusion over the corners). */
static double cube_below_plane(const double n[3], double d)
{
    double v = 0;
    for (int c = 0; c < 8; c++) {
        int bits = (c & 1) + (c >> 1 & 1) + (c >> 2 & 1);
        double r = d - ((c & 1) * n[0] + (c >> 1 & 1) * n[1] + (c >> 2 & 1) * n[2]);
        if (r > 0) v += (bits & 1 ? -1 : 1) * r * r * r;
    }
    return v / (6 * n[0] * n[1] * n[2]);
}

/* Over many seeds the mean coverage of a voxel cut by an oblique plane is
 * its exact coverage (stratified jitter is unbiased). */
static void test_unbiased(void)
{
    const double n[3] = {1.0, 0.5, 0.25}, d = 0.8;
    /* a large tetrahedron whose face n.p = d cuts the unit voxel [0,1]^3 */
    double p1[3] = {d + 5 + 2.5, -10, -10}, p2[3] = {d - 5 + 2.5, 10, -10}, p3[3] = {d - 5, 0, 20};
    double q[3] = {-100, 0, 0};
    tmesh t = tmesh_tetra(p1, p2, p3, q);
    clvox_mesh *m = to_mesh(ctx, &t);
    double lo[3] = {0, 0, 0}, h[3] = {1, 1, 1};
    clvox_grid g = make_grid(lo, h, 1, 1, 1);
    const double exact = cube_below_plane(n, d);
    const int seeds = 300;
    double sum = 0, sum2 = 0;
    for (int s = 0; s < seeds; s++) {
        clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
        o.oversample = 2;
        o.stochastic = 1;
        o.seed = (uint64_t)s * 7919u + 1;
        float c = 0;
        CHECK_OK(ctx, clvox_voxelize_to_buffers(ctx, m, &g, &o, NULL, 0, &c, 1, NULL));
        sum += c;
        sum2 += (double)c * c;
    }
    double mean = sum / seeds, var = sum2 / seeds - mean * mean, se = sqrt(var / seeds);
    fprintf(stderr, "oblique cut: exact %.6f, mean of %d seeds %.6f (standard error %.2e)\n", exact, seeds, mean, se);
    CHECK_MSG(fabs(mean - exact) < 4 * se + 1e-6 && se > 0, "mean %.6f vs exact %.6f (se %.2e)", mean, exact, se);
    /* uniform sampling of the same voxel is a fixed value: zero spread, and near */
    clvox_voxelize_options u = CLVOX_VOXELIZE_OPTIONS_INIT;
    u.oversample = 16;
    u.oversample_points = 32;
    float cu = 0;
    CHECK_OK(ctx, clvox_voxelize_to_buffers(ctx, m, &g, &u, NULL, 0, &cu, 1, NULL));
    CHECK_MSG(fabs(cu - exact) < 0.01, "uniform 16x16x32: %.6f vs %.6f", cu, exact);
    clvox_mesh_destroy(m);
    tmesh_free(&t);
}

static void test_bad_options(void)
{
    tmesh t = tmesh_box(0.2, 0.2, 0.2, 0.8, 0.8, 0.8);
    clvox_mesh *m = to_mesh(ctx, &t);
    double lo[3] = {0, 0, 0}, h[3] = {0.25, 0.25, 0.25};
    clvox_grid g = make_grid(lo, h, 4, 4, 4);
    float cov[64];
    uint8_t occ[64];
    clvox_voxelize_options o;
#define BAD(field_setup)                                                                                   \
    do {                                                                                                   \
        clvox_voxelize_options d = CLVOX_VOXELIZE_OPTIONS_INIT;                                           \
        o = d;                                                                                             \
        field_setup;                                                                                       \
        CHECK_STATUS(ctx, clvox_voxelize_to_buffers(ctx, m, &g, &o, NULL, 0, cov, 64, NULL),               \
                     CLVOX_ERR_INVALID_ARGUMENT);                                                          \
    } while (0)
    BAD(o.oversample = 17);
    BAD((o.oversample = 2, o.oversample_points = 256));
    BAD((o.oversample = 2, o.threshold_set = 1, o.threshold = -0.1));
    BAD((o.oversample = 2, o.threshold_set = 1, o.threshold = 1.5));
    BAD((o.oversample = 2, o.threshold_set = 1, o.threshold = NAN));
    BAD(o.stochastic = 1);                                   /* no oversampling */
    BAD((o.oversample = 2, o.method = CLVOX_METHOD_TETRA)); /* tetra: no coverage */
    BAD((o.oversample = 2, o.channels = 0x8));
    BAD(o.channels = CLVOX_CHANNEL_COVERAGE);                /* coverage without oversampling */
    BAD((void)0);                                            /* binary run has no coverage */
#undef BAD
    /* an occupancy buffer for a coverage-only run, a short buffer */
    o = (clvox_voxelize_options)CLVOX_VOXELIZE_OPTIONS_INIT;
    o.oversample = 2;
    CHECK_STATUS(ctx, clvox_voxelize_to_buffers(ctx, m, &g, &o, occ, 64, NULL, 0, NULL), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(ctx, clvox_voxelize_to_buffers(ctx, m, &g, &o, NULL, 0, cov, 63, NULL), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(ctx, clvox_voxelize_to_buffers(ctx, m, &g, &o, NULL, 0, NULL, 0, NULL), CLVOX_ERR_INVALID_ARGUMENT);
    /* the largest allowed: 16x16 rays, 255 points (65280 samples) */
    o.oversample = 16;
    o.oversample_points = 255;
    CHECK_OK(ctx, clvox_voxelize_to_buffers(ctx, m, &g, &o, NULL, 0, cov, 64, NULL));
    /* voxel 0 holds the box's corner [0.2, 0.25)^3: 51 of 255 points, 3 of 16 rays per side */
    CHECK_MSG(cov[(1 * 4 + 1) * 4 + 1] == 1.0f && cov[0] == (float)(51 * 3 * 3) / (float)(255 * 256), "%.9g %.9g",
              cov[(1 * 4 + 1) * 4 + 1], cov[0]);
    /* nothing written for a bad run */
    char path[512];
    snprintf(path, sizeof path, "%s/coverage_bad.exr", test_tmpdir());
    remove(path);
    o.oversample = 99;
    CHECK_STATUS(ctx, clvox_voxelize_to_exr(ctx, m, &g, &o, path, NULL), CLVOX_ERR_INVALID_ARGUMENT);
    FILE *f = fopen(path, "rb");
    CHECK(f == NULL);
    if (f) fclose(f);
    clvox_mesh_destroy(m);
    tmesh_free(&t);
}

int main(void)
{
    setenv("POCL_DEVICES", "pthread pthread", 0); /* two devices for test_determinism */
    test_philox_known_answers();
    test_sample_points();
    test_half_rounding();
    ctx = test_context();
    test_exact_fractions();
    test_reference();
    test_k1_is_binary();
    test_determinism();
    test_convergence();
    test_unbiased();
    test_bad_options();
    clvox_context_destroy(ctx);
    return test_report();
}
