/* SPDX-License-Identifier: Apache-2.0 */
/* The float build of kernels/overlap.h (what devices without fp64 run for
 * surface and conservative modes, and the tetra method) against GMP
 * rationals: random, nearly degenerate and exactly degenerate inputs over
 * the float range where the predicates are exact (0 or 2^-24 .. 2^36 in
 * magnitude, kernels/overlap.h "Range"), including its ends. The test can
 * fail: the same inputs through the plain float formula (no filter, no
 * expansion) must disagree with GMP many times, and the exact path must be
 * taken (exact zeros and near-zeros). */
#define CLVOX_OV_FLOAT 1
#include "test.h"
#include "meshgen.h"

#include <math.h>
#include <stdint.h>

#include "../kernels/overlap.h"
#include "gmp_predicates.h"

_Static_assert(sizeof(clvox_ovr) == sizeof(float), "the float build of overlap.h");

static uint64_t rng = 777;
static double uni(void) { return tmesh_rng_uniform(&rng); }

/* A float in the exact range: ordinary, on the half-integer lattice, near
 * the range's ends, zero, or a copy. */
static float rand_coord(void)
{
    double r = uni();
    if (r < 0.3) return (float)((uni() - 0.5) * 4096.0);
    if (r < 0.5) return (float)(floor(uni() * 64.0) * 0.5 - 16.0);
    if (r < 0.58) return (float)((uni() < 0.5 ? -1 : 1) * ldexp(1.0 + uni(), -24)); /* the low end */
    if (r < 0.62) return (float)((uni() < 0.5 ? -1 : 1) * ldexp(1.0 + uni() * 0.99, 35)); /* the high end */
    if (r < 0.66) return 0.0f;
    return (float)((uni() - 0.5) * 4.0);
}

/* The plain float formulas: what the kernels computed before (or without)
 * the filter and the expansion. */
static int naive_e2(const float *p)
{
    float d = (p[2] - p[0]) * (p[7] - p[5]) - (p[3] - p[1]) * (p[6] - p[4]);
    return (d > 0) - (d < 0);
}
static int naive_o3(const float *v, const float *q)
{
    float a[3], b[3], w[3];
    for (int i = 0; i < 3; i++) a[i] = v[3 + i] - v[i], b[i] = v[6 + i] - v[i], w[i] = q[i] - v[i];
    float d = w[0] * (a[1] * b[2] - a[2] * b[1]) + w[1] * (a[2] * b[0] - a[0] * b[2]) +
              w[2] * (a[0] * b[1] - a[1] * b[0]);
    return (d > 0) - (d < 0);
}

static void test_e2(void)
{
    int bad = 0, naive_bad = 0, zeros = 0;
    const int N = 300000;
    for (int it = 0; it < N; it++) {
        float p[8];
        for (int i = 0; i < 8; i++) p[i] = rand_coord();
        if (it % 3 == 1) { /* d nearly on the line a b (rounded to float), c = a */
            double t = uni() * 3 - 1;
            p[6] = (float)(p[0] + t * ((double)p[2] - p[0]));
            p[7] = (float)(p[1] + t * ((double)p[3] - p[1]));
            p[4] = p[0], p[5] = p[1];
        }
        if (it % 7 == 2) p[2] = p[0]; /* an edge parallel to an axis */
        if (it % 11 == 3) /* a small lattice: many exact zeros */
            for (int i = 0; i < 8; i++) p[i] = (float)(floor(uni() * 6) * 0.5);
        double d[8];
        for (int i = 0; i < 8; i++) d[i] = p[i];
        int g = gmp_e2(d), s = clvox_e2_sign(p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]);
        zeros += g == 0;
        naive_bad += naive_e2(p) != g;
        if (g != s && bad++ < 3)
            fprintf(stderr, "  e2 float %d vs gmp %d: %a %a %a %a %a %a %a %a\n", s, g, p[0], p[1], p[2], p[3], p[4],
                    p[5], p[6], p[7]);
    }
    CHECK_MSG(bad == 0, "%d of %d float 2x2 signs differ from GMP", bad, N);
    CHECK_MSG(zeros > 1000, "only %d exact zeros: the degenerate cases were not exercised", zeros);
    CHECK_MSG(naive_bad > 1000, "the plain float formula is wrong only %d times: the inputs are too easy", naive_bad);
    printf("e2: %d inputs, %d exact zeros, the plain float formula wrong on %d\n", N, zeros, naive_bad);
}

static void test_o3(void)
{
    int bad = 0, naive_bad = 0, zeros = 0;
    const int N = 150000;
    for (int it = 0; it < N; it++) {
        float v[9], q[3];
        for (int i = 0; i < 9; i++) v[i] = rand_coord();
        for (int i = 0; i < 3; i++) q[i] = rand_coord();
        if (it % 3 == 1) { /* q nearly in the plane: an affine combination rounded to float */
            double s = uni() * 2 - 0.5, t = uni() * 2 - 0.5;
            for (int i = 0; i < 3; i++)
                q[i] = (float)(v[i] + s * ((double)v[3 + i] - v[i]) + t * ((double)v[6 + i] - v[i]));
        }
        if (it % 5 == 2) /* a lattice triangle and corner: many exact zeros */
            for (int i = 0; i < 3; i++) {
                v[i] = (float)(floor(uni() * 8) * 0.5), v[3 + i] = (float)(floor(uni() * 8) * 0.5);
                v[6 + i] = (float)(floor(uni() * 8) * 0.5), q[i] = (float)(floor(uni() * 8) * 0.5 - 0.5);
            }
        double dv[9], dq[3];
        for (int i = 0; i < 9; i++) dv[i] = v[i];
        for (int i = 0; i < 3; i++) dq[i] = q[i];
        int g = gmp_o3(dv, dq), s = clvox_o3_sign(v, q[0], q[1], q[2]);
        zeros += g == 0;
        naive_bad += naive_o3(v, q) != g;
        if (g != s && bad++ < 3) fprintf(stderr, "  o3 float %d vs gmp %d (case %d)\n", s, g, it);
    }
    CHECK_MSG(bad == 0, "%d of %d float 3x3 signs differ from GMP", bad, N);
    CHECK_MSG(zeros > 500, "only %d exact zeros: the degenerate cases were not exercised", zeros);
    CHECK_MSG(naive_bad > 1000, "the plain float formula is wrong only %d times: the inputs are too easy", naive_bad);
    printf("o3: %d inputs, %d exact zeros, the plain float formula wrong on %d\n", N, zeros, naive_bad);
}

/* The range's ends exactly: the smallest magnitudes in monomials of three
 * (their low parts near 2^-141) and the largest (near 2^108), against GMP. */
static void test_range_ends(void)
{
    int bad = 0;
    for (int it = 0; it < 20000; it++) {
        float v[9], q[3];
        for (int i = 0; i < 9; i++) {
            const int e = uni() < 0.5 ? -24 : 35;
            v[i] = (float)((uni() < 0.5 ? -1 : 1) * ldexp(1.0 + floor(uni() * 8388608.0) / 8388608.0, e));
        }
        for (int i = 0; i < 3; i++) q[i] = uni() < 0.5 ? v[3 * (it % 3) + i] : (float)ldexp(1.0 + uni(), -24);
        double dv[9], dq[3];
        for (int i = 0; i < 9; i++) dv[i] = v[i];
        for (int i = 0; i < 3; i++) dq[i] = q[i];
        bad += gmp_o3(dv, dq) != clvox_o3_sign(v, q[0], q[1], q[2]);
        const float p[8] = {v[0], v[1], v[2], v[3], q[0], q[1], v[4], v[5]};
        const double dp[8] = {p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]};
        bad += gmp_e2(dp) != clvox_e2_sign(p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]);
    }
    CHECK_MSG(bad == 0, "%d signs at the range's ends differ from GMP", bad);
}

int main(void)
{
    test_e2();
    test_o3();
    test_range_ends();
    return test_report();
}
