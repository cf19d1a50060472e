/* SPDX-License-Identifier: Apache-2.0 */
/*
 * The sampler of grey-level (coverage) voxelization, in the common subset of
 * C11 and OpenCL C: the kernels (kernels/coverage.cl), the host (ray
 * positions, src/cast/cast.c) and the CPU reference (tests/reference.c) compile
 * this same source, so they draw the same samples bit for bit.
 *
 * Generator: Philox4x32-10, the counter-based generator of Salmon, Moraes,
 * Dror and Shaw, "Parallel random numbers: as easy as 1, 2, 3" (SC 2011),
 * written from its published description: a 4 x 32-bit counter and a
 * 2 x 32-bit key; each of 10 rounds multiplies counter words 0 and 2 by
 * M0 = 0xD2511F53 and M1 = 0xCD9E8D57 and mixes the high and low halves with
 * the other words and the key; the key is bumped by the Weyl constants
 * W0 = 0x9E3779B9, W1 = 0xBB67AE85 between rounds. Checked against the
 * published known-answer vectors (tests/test_coverage.c).
 *
 * Keys and counters (the key is the seed; nothing depends on the device,
 * the slab depth, the work-group size or the order in which columns run):
 *   ray jitter:   counter (column, ray, 0xFFFFFFFF, 0) -> word 0 along v, word 1 along w
 *   point jitter: counter (column, ray, u, point / 4)  -> word point % 4
 * column = w * dim_v + v (the voxel column in the ray plane), ray = a + N*b
 * for the sub-column (a, b) of N x N, u = the voxel index along the ray
 * (< 65536, so never 0xFFFFFFFF), point = 0 .. M-1.
 *
 * Stratification (Thon et al. 3.3.4, Figure 8): sample i of n along one axis
 * of a unit cell sits at (i + j) / n from the cell's lower side, j = 1/2
 * (uniform) or j = bits * 2^-32 in [0, 1) (stochastic: one jittered sample
 * per stratum). Ray (a, b) of column (v, w) runs at v - 1/2 + (a + j)/N,
 * w - 1/2 + (b + j')/N (grid space: centres at integers; rounded to float
 * once); point m of voxel u at u - 1/2 + (m + j)/M (double on fp64 devices).
 * With N = M = 1 uniform these are exactly the voxel centres.
 */
#ifndef CLVOX_SAMPLER_H
#define CLVOX_SAMPLER_H

#ifdef __OPENCL_VERSION__
typedef ulong clvox_u64;
#define CLVOX_SAMPLER_FN static inline /* static: see CLVOX_OV_FN (overlap.h) */
#define CLVOX_SAMPLER_LDEXP ldexp
#define CLVOX_SAMPLER_FBITS(f) as_uint(f)
#if defined(CLVOX_FP64)
#define CLVOX_SAMPLER_POW2(e) as_double((ulong)((e) + 1023) << 52) /* 2^e, e in the normal range */
#endif
#else
#include <math.h>
#include <stdint.h>
typedef uint64_t clvox_u64;
#include <string.h>
#define CLVOX_SAMPLER_LDEXP ldexpf
static inline uint32_t clvox_sampler_fbits(float f)
{
    uint32_t b;
    memcpy(&b, &f, sizeof b);
    return b;
}
static inline double clvox_sampler_pow2(int e)
{
    const uint64_t b = (uint64_t)(e + 1023) << 52;
    double d;
    memcpy(&d, &b, sizeof d);
    return d;
}
#define CLVOX_SAMPLER_FBITS(f) clvox_sampler_fbits(f)
#define CLVOX_SAMPLER_POW2(e) clvox_sampler_pow2(e)
typedef double clvox_real; /* the kernels' type on fp64 devices (prelude.cl) */
#define CLVOX_SAMPLER_FN static inline
#endif

/* Philox4x32-10 of counter c with key (k0, k1) into out[0..3]. */
CLVOX_SAMPLER_FN void clvox_philox4x32_10(clvox_u32 c0, clvox_u32 c1, clvox_u32 c2, clvox_u32 c3,
                                           clvox_u32 k0, clvox_u32 k1, clvox_u32 *out)
{
    for (int r = 0; r < 10; r++) {
        if (r > 0) {
            k0 += 0x9E3779B9u;
            k1 += 0xBB67AE85u;
        }
        clvox_u64 p0 = (clvox_u64)0xD2511F53u * c0, p1 = (clvox_u64)0xCD9E8D57u * c2;
        clvox_u32 hi0 = (clvox_u32)(p0 >> 32), lo0 = (clvox_u32)p0;
        clvox_u32 hi1 = (clvox_u32)(p1 >> 32), lo1 = (clvox_u32)p1;
        c0 = hi1 ^ c1 ^ k0;
        c1 = lo1;
        c2 = hi0 ^ c3 ^ k1;
        c3 = lo0;
    }
    out[0] = c0;
    out[1] = c1;
    out[2] = c2;
    out[3] = c3;
}

#define CLVOX_SAMPLER_RAY_WORD 0xFFFFFFFFu

/* Jitter bits of the point `point` of voxel u on ray `ray` of `column`. */
CLVOX_SAMPLER_FN clvox_u32 clvox_point_bits(clvox_u32 seed_lo, clvox_u32 seed_hi, clvox_u32 column, clvox_u32 ray,
                                             clvox_u32 u, clvox_u32 point)
{
    clvox_u32 out[4];
    clvox_philox4x32_10(column, ray, u, point >> 2, seed_lo, seed_hi, out);
    return out[point & 3u];
}

/* Offset of stratum i of n inside a unit cell: (i + j) / n, j = 1/2 when
 * uniform, bits * 2^-32 when stochastic. */
CLVOX_SAMPLER_FN clvox_real clvox_stratum(clvox_u32 i, clvox_u32 n, int stochastic, clvox_u32 bits)
{
    clvox_real j = stochastic ? (clvox_real)bits * (clvox_real)2.3283064365386963e-10 : (clvox_real)0.5;
    return ((clvox_real)i + j) / (clvox_real)n;
}

/* A / (M 2^32) as the nearest float (ties to even), A > 0, exactly in
 * integers (A < 2^61, M <= 255): Q + R / M = A / M, then 24 bits of it. */
CLVOX_SAMPLER_FN float clvox_ratio_float(clvox_u64 A, clvox_u32 M)
{
    clvox_u64 Q = A / M, R = A % M;
    int e = -32;
    if (Q >= 0x1000000u) { /* 25 bits or more: keep 24, round on the rest */
        int s = 0;
        while ((Q >> s) >= 0x1000000u) s++;
        const clvox_u64 low = Q & ((((clvox_u64)1) << s) - 1u), rest2 = 2u * (low * M + R), half2 = (clvox_u64)M << s;
        Q >>= s;
        e += s;
        if (rest2 > half2 || (rest2 == half2 && (Q & 1u))) Q++;
    } else { /* fewer: more bits from the remainder */
        while (Q < 0x800000u) {
            R *= 2u;
            Q = 2u * Q + (R >= M);
            if (R >= M) R -= M;
            e--;
        }
        if (2u * R > M || (2u * R == M && (Q & 1u))) Q++;
    }
    return CLVOX_SAMPLER_LDEXP((float)Q, e); /* Q <= 2^24: exact */
}

/* Point m of M of voxel u along a ray (grid space, centres at integers):
 * u - 1/2 + (m + j) / M, j = bits * 2^-32 (stochastic) or 1/2, as the
 * nearest float (ties to even), 0 where that is below 2^-24 in magnitude.
 * Computed exactly in integers, so that every device, either precision and
 * the host get the same float; a float because the crossings are compared
 * with it exactly (kernels/intersect.cl clvox_hit_round_up) and the float
 * range of kernels/overlap.h's exact signs holds for it. The value is
 * X / (M 2^32), X = (M (2u - 1) + 2m) 2^31 + j 2^32, |X| < 2^61 for
 * u < 2^20 and M <= 255 (the largest oversample_points). */
CLVOX_SAMPLER_FN float clvox_sample_u_exact(clvox_u32 u, clvox_u32 m, clvox_u32 M, int stochastic, clvox_u32 bits)
{
    const clvox_u64 J = stochastic ? (clvox_u64)bits : (clvox_u64)0x80000000u;
    const clvox_u64 pos = ((clvox_u64)M * (2u * (clvox_u64)u) + 2u * (clvox_u64)m) * 0x80000000u + J;
    const clvox_u64 neg = (clvox_u64)M * 0x80000000u; /* X = pos - neg */
    const int negative = pos < neg;
    const clvox_u64 A = negative ? neg - pos : pos - neg;
    if (A < (clvox_u64)M * 256u) return 0.0f; /* |x| < 2^-24 (and 0) */
    const float x = clvox_ratio_float(A, M);
    return negative ? -x : x;
}

/* Offset of stratum i of n inside a unit cell, (i + j) / n as
 * clvox_stratum, as the nearest float computed exactly (so the same in
 * every build): the palette's positions in the unit voxel, which its
 * elements are tested at. */
CLVOX_SAMPLER_FN float clvox_stratum_float(clvox_u32 i, clvox_u32 n, int stochastic, clvox_u32 bits)
{
    const clvox_u64 A = ((clvox_u64)i << 32) + (stochastic ? (clvox_u64)bits : (clvox_u64)0x80000000u);
    return A ? clvox_ratio_float(A, n) : 0.0f;
}

/* The same float, faster where double is at hand (the host, fp64 devices):
 * for u >= 1, x = (u - 1/2) + t in double, t = (m 2^32 + j) / (M 2^32)
 * rounded, is within 3 * 2^-53 |x| of the exact value (t's rounding is
 * at most 2^-53 t, t < 1 <= 2 x; the sum's 2^-53 x), so its float is the
 * exact value's wherever x lies farther than 2^-50 x from both midpoints
 * next to that float (half a spacing from it, the spacing from the float's
 * exponent bits); else, for u = 0 and in float builds,
 * clvox_sample_u_exact. */
CLVOX_SAMPLER_FN float clvox_sample_u(clvox_u32 u, clvox_u32 m, clvox_u32 M, int stochastic, clvox_u32 bits)
{
#if !defined(__OPENCL_VERSION__) || defined(CLVOX_FP64)
    if (u >= 1u) {
        const double J = stochastic ? (double)bits : 2147483648.0;
        const double t = ((double)m * 4294967296.0 + J) / ((double)M * 4294967296.0);
        const double x = ((double)u - 0.5) + t;
        const float f = (float)x; /* >= 1/2, normal */
        const unsigned fb = CLVOX_SAMPLER_FBITS(f);
        /* the float spacing above f, and below it (half that at a power of two) */
        const double up = CLVOX_SAMPLER_POW2((int)((fb >> 23) & 0xFFu) - 150);
        const double down = (fb & 0x7FFFFFu) ? up : up * 0.5;
        const double d = x - (double)f; /* exact: x and f are within a spacing */
        const double err = x * 0x1p-50;
        if (d >= 0 ? d + err < up * 0.5 : err - d < down * 0.5) return f;
    }
#endif
    return clvox_sample_u_exact(u, m, M, stochastic, bits);
}

/* Ray r = a + N*b of column (v, w), id = w * dim_v + v: its ray-plane
 * position, computed in clvox_real and rounded to float once. The host
 * (src/cast/cast.c column_rays) and, on fp64 devices, the kernel
 * clvox_column_rays (kernels/coverage.cl) run this same code in double, so
 * that rays made on either side are bit for bit the same. */
CLVOX_SAMPLER_FN void clvox_column_ray(clvox_u32 v, clvox_u32 w, clvox_u32 id, clvox_u32 r, clvox_u32 N, int stochastic,
                                       clvox_u32 seed_lo, clvox_u32 seed_hi, float *pv, float *pw)
{
    clvox_u32 bits[4] = {0, 0, 0, 0};
    if (stochastic) clvox_philox4x32_10(id, r, CLVOX_SAMPLER_RAY_WORD, 0, seed_lo, seed_hi, bits);
    clvox_real v_ = ((clvox_real)v - (clvox_real)0.5) + clvox_stratum(r % N, N, stochastic, bits[0]);
    clvox_real w_ = ((clvox_real)w - (clvox_real)0.5) + clvox_stratum(r / N, N, stochastic, bits[1]);
    *pv = (float)v_;
    *pw = (float)w_;
}

#endif /* CLVOX_SAMPLER_H */
