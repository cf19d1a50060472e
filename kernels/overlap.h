/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Exact predicates of surface voxelization (triangle / closed voxel cell
 * overlap), in the common subset of C11 and OpenCL C: the kernel
 * (kernels/surface.cl) and the tests (tests/test_surface.c, which checks
 * them against GMP rationals) compile this same source.
 *
 * Every argument holds a float value (grid-space vertex coordinates from
 * clvox__grid_space_soup, or cell corners: half-integers below 2^17, exact
 * in float), converted to clvox_ovr. Each predicate returns the exact sign
 * of a polynomial in those values:
 *
 *   clvox_e2_sign(a, b, c, d) = sign((b.s - a.s)(d.t - c.t) - (b.t - a.t)(d.s - c.s))
 *   clvox_o3_sign(v0, v1, v2, q) = sign(n . (q - v0)),  n = (v1 - v0) x (v2 - v0)
 *
 * One source, two precisions (clvox_ovr): double where the device has fp64
 * (and on the host), float on devices without it (CLVOX_FP64 unset; the
 * host tests get it with CLVOX_OV_FLOAT). The signs are exact in both, so
 * both give the same voxels bit for bit.
 *
 * Evaluation: first in clvox_ovr with Shewchuk's forward error bounds
 * ("Adaptive Precision Floating-Point Arithmetic and Fast Robust Geometric
 * Predicates", 1997: ccwerrboundA = (3 + 16u)u for the 2x2 form with its
 * four differences rounded, o3derrboundA = (7 + 56u)u for the 3x3 one,
 * u = 2^-53 in double, 2^-24 in float, times the permanent computed
 * alongside; in float plus CLVOX_OV_ABS_ERR, which covers the absolute
 * error of results near underflow); when the value is within the bound of
 * 0, exactly: the polynomial is expanded into monomials of the float
 * inputs, each an exact sum of clvox_ovr: in double a product of two
 * floats is exact and a third factor is split off with two_product (fma,
 * exact in OpenCL C and C11's fma); in float every product is split with
 * two_product (2 terms for two factors, 4 for three). The sign of the sum
 * is that of the largest component of its nonoverlapping expansion, built
 * with Shewchuk's Grow-Expansion (Two-Sum, zero elimination).
 * Range: in double, float inputs keep every term far from overflow (|term|
 * < 2^400) and underflow (|term| > 2^-500), so no step loses a bit. In
 * float that holds when every input is 0 or of magnitude in
 * [CLVOX_OV_FLOAT_MIN, CLVOX_OV_FLOAT_MAX] = [2^-24, 2^36]: a monomial's
 * parts are then multiples of 2^-141 (above float's 2^-149) and below
 * 2^108; the host checks it before a float run (src/raster/surface.c
 * clvox__surface_float_exact). No step depends on the device, the
 * work-group or the order of anything: the host and every device get the
 * same signs.
 */
#ifndef CLVOX_OVERLAP_H
#define CLVOX_OVERLAP_H

#if defined(__OPENCL_VERSION__) ? !defined(CLVOX_FP64) : defined(CLVOX_OV_FLOAT)
#define CLVOX_OV_IS_FLOAT 1
#else
#define CLVOX_OV_IS_FLOAT 0
#endif

#ifdef __OPENCL_VERSION__
/* The exact expansions are rarely reached: kept out of line so that the
 * filters' loops in kernels/surface.cl stay small (about 1.4x faster on
 * PoCL). Static, as every helper: a plain C99 `inline` function need not
 * get a body, and then the program fails to link on some drivers. */
#define CLVOX_OV_FN static inline
#define CLVOX_OV_COLD static __attribute__((noinline))
#else
#include <math.h>
#define CLVOX_OV_FN static inline
#define CLVOX_OV_COLD static inline
#endif

#if CLVOX_OV_IS_FLOAT
typedef float clvox_ovr;
#define CLVOX_OV_U 5.9604644775390625e-8f /* 2^-24 */
#define CLVOX_OV_E2_ERR ((3.0f + 16.0f * CLVOX_OV_U) * CLVOX_OV_U)
#define CLVOX_OV_O3_ERR ((7.0f + 56.0f * CLVOX_OV_U) * CLVOX_OV_U)
/* Results below 2^-120 go to the exact path: a few roundings near
 * underflow (each at most 2^-150 absolute) stay far inside it. */
#define CLVOX_OV_ABS_ERR 0x1p-120f
#define CLVOX_OV_FLOAT_MIN 0x1p-24f
#define CLVOX_OV_FLOAT_MAX 0x1p36f
/* Terms of the longest exact sum (clvox_o3_exact: 24 monomials of 4). */
#define CLVOX_OV_MAX_TERMS 96
#ifdef __OPENCL_VERSION__
#define CLVOX_OV_FMA fma
#define CLVOX_OV_FABS fabs
#else
#define CLVOX_OV_FMA fmaf
#define CLVOX_OV_FABS fabsf
#endif
#else
typedef double clvox_ovr;
#define CLVOX_OV_U 1.1102230246251565e-16 /* 2^-53 */
#define CLVOX_OV_E2_ERR ((3.0 + 16.0 * CLVOX_OV_U) * CLVOX_OV_U)
#define CLVOX_OV_O3_ERR ((7.0 + 56.0 * CLVOX_OV_U) * CLVOX_OV_U)
#define CLVOX_OV_ABS_ERR 0.0 /* none: float inputs never come near double's underflow */
/* Terms of the longest exact sum (clvox_o3_exact). */
#define CLVOX_OV_MAX_TERMS 48
#define CLVOX_OV_FMA fma
#define CLVOX_OV_FABS fabs
#endif

/* Sign of the exact sum of t[0 .. n): Grow-Expansion with zero elimination
 * keeps e nonoverlapping and increasing in magnitude, so its last component
 * has the sign of the sum. */
CLVOX_OV_FN int clvox_exact_sum_sign(const clvox_ovr *t, int n)
{
    clvox_ovr e[CLVOX_OV_MAX_TERMS];
    int m = 0;
    for (int i = 0; i < n; i++) {
        clvox_ovr q = t[i];
        int k = 0;
        for (int j = 0; j < m; j++) {
            clvox_ovr a = q, b = e[j];
            clvox_ovr s = a + b, bv = s - a, av = s - bv;
            clvox_ovr err = (a - av) + (b - bv); /* Two-Sum: a + b = s + err exactly */
            if (err != (clvox_ovr)0) e[k++] = err;
            q = s;
        }
        if (q != (clvox_ovr)0) e[k++] = q;
        m = k;
    }
    return m == 0 ? 0 : (e[m - 1] > (clvox_ovr)0 ? 1 : -1);
}

#if CLVOX_OV_IS_FLOAT
#define CLVOX_OV_BOUND(x) ((x) + CLVOX_OV_ABS_ERR)
#define CLVOX_OV_P2 2 /* terms of a product of two floats */
#define CLVOX_OV_P3 4 /* and of three */
/* sign * p * q as two floats, exactly (two_product; the range above). */
CLVOX_OV_FN void clvox_ov_product2(clvox_ovr p, clvox_ovr q, clvox_ovr sign, clvox_ovr *out)
{
    const clvox_ovr pq = p * q;
    out[0] = sign * pq;
    out[1] = sign * CLVOX_OV_FMA(p, q, -pq);
}
/* sign * p * q * r as four floats, exactly: (pq + e) r, each part split. */
CLVOX_OV_FN void clvox_ov_product3(clvox_ovr p, clvox_ovr q, clvox_ovr r, clvox_ovr sign, clvox_ovr *out)
{
    clvox_ovr pq[2];
    clvox_ov_product2(p, q, sign, pq);
    for (int i = 0; i < 2; i++) {
        const clvox_ovr hi = pq[i] * r;
        out[2 * i] = hi;
        out[2 * i + 1] = CLVOX_OV_FMA(pq[i], r, -hi);
    }
}
#else
#define CLVOX_OV_BOUND(x) (x)
#define CLVOX_OV_P2 1
#define CLVOX_OV_P3 2
/* sign * p * q: exact in double. */
CLVOX_OV_FN void clvox_ov_product2(clvox_ovr p, clvox_ovr q, clvox_ovr sign, clvox_ovr *out) { out[0] = sign * (p * q); }
/* p * q * r (p*q exact in clvox_ovr) as two clvox_ovrs, exactly. */
CLVOX_OV_FN void clvox_ov_product3(clvox_ovr p, clvox_ovr q, clvox_ovr r, clvox_ovr sign, clvox_ovr *out)
{
    clvox_ovr pq = sign * (p * q);
    clvox_ovr hi = pq * r;
    out[0] = hi;
    out[1] = CLVOX_OV_FMA(pq, r, -hi);
}
#endif

/* Exact sign of (b.s - a.s)(d.t - c.t) - (b.t - a.t)(d.s - c.s): eight
 * products of two floats. */
CLVOX_OV_COLD int clvox_e2_exact(clvox_ovr as, clvox_ovr at, clvox_ovr bs, clvox_ovr bt, clvox_ovr cs, clvox_ovr ct,
                                 clvox_ovr ds, clvox_ovr dt)
{
    const clvox_ovr one = 1;
    clvox_ovr t[8 * CLVOX_OV_P2];
    clvox_ov_product2(bs, dt, one, t);
    clvox_ov_product2(bs, ct, -one, t + CLVOX_OV_P2);
    clvox_ov_product2(as, dt, -one, t + 2 * CLVOX_OV_P2);
    clvox_ov_product2(as, ct, one, t + 3 * CLVOX_OV_P2);
    clvox_ov_product2(bt, ds, -one, t + 4 * CLVOX_OV_P2);
    clvox_ov_product2(bt, cs, one, t + 5 * CLVOX_OV_P2);
    clvox_ov_product2(at, ds, one, t + 6 * CLVOX_OV_P2);
    clvox_ov_product2(at, cs, -one, t + 7 * CLVOX_OV_P2);
    return clvox_exact_sum_sign(t, 8 * CLVOX_OV_P2);
}

CLVOX_OV_FN int clvox_e2_sign(clvox_ovr as, clvox_ovr at, clvox_ovr bs, clvox_ovr bt, clvox_ovr cs, clvox_ovr ct,
                              clvox_ovr ds, clvox_ovr dt)
{
    clvox_ovr l = (bs - as) * (dt - ct), r = (bt - at) * (ds - cs);
    clvox_ovr det = l - r, bound = CLVOX_OV_BOUND(CLVOX_OV_E2_ERR * (CLVOX_OV_FABS(l) + CLVOX_OV_FABS(r)));
    if (det > bound) return 1;
    if (-det > bound) return -1;
    return clvox_e2_exact(as, at, bs, bt, cs, ct, ds, dt);
}

/* Exact sign of n . q - v0 . (v1 x v2), n = v0 x v1 + v1 x v2 + v2 x v0
 * (= n . (q - v0)): 24 monomials of three floats, CLVOX_OV_P3 terms each.
 * v holds v0, v1, v2 (x, y, z each). */
CLVOX_OV_COLD int clvox_o3_exact(const clvox_ovr *v, clvox_ovr qx, clvox_ovr qy, clvox_ovr qz)
{
    const clvox_ovr one = 1;
    clvox_ovr t[CLVOX_OV_MAX_TERMS];
    const clvox_ovr q[3] = {qx, qy, qz};
    int n = 0;
    for (int i = 0; i < 3; i++) {
        int a = (i + 1) % 3, b = (i + 2) % 3; /* (p x r)_i = p_a r_b - p_b r_a */
        for (int e = 0; e < 3; e++) {
            const clvox_ovr *p = v + 3 * e, *r = v + 3 * ((e + 1) % 3); /* v0 x v1, v1 x v2, v2 x v0 */
            clvox_ov_product3(p[a], r[b], q[i], one, t + n);
            clvox_ov_product3(p[b], r[a], q[i], -one, t + n + CLVOX_OV_P3);
            n += 2 * CLVOX_OV_P3;
        }
    }
    /* - v0 . (v1 x v2) */
    for (int i = 0; i < 3; i++) {
        int a = (i + 1) % 3, b = (i + 2) % 3;
        clvox_ov_product3(v[3 + a], v[6 + b], v[i], -one, t + n);
        clvox_ov_product3(v[3 + b], v[6 + a], v[i], one, t + n + CLVOX_OV_P3);
        n += 2 * CLVOX_OV_P3;
    }
    return clvox_exact_sum_sign(t, n);
}

/* The triangle's part of the 3x3 filter: the rounded minors of
 * a = v1 - v0, b = v2 - v0 (m) and their absolute products (pm), for
 * clvox_o3_sign_pre. */
CLVOX_OV_FN void clvox_o3_setup(const clvox_ovr *v, clvox_ovr *m, clvox_ovr *pm)
{
    clvox_ovr ax = v[3] - v[0], ay = v[4] - v[1], az = v[5] - v[2];
    clvox_ovr bx = v[6] - v[0], by = v[7] - v[1], bz = v[8] - v[2];
    clvox_ovr aybz = ay * bz, azby = az * by, azbx = az * bx, axbz = ax * bz, axby = ax * by, aybx = ay * bx;
    m[0] = aybz - azby;
    m[1] = azbx - axbz;
    m[2] = axby - aybx;
    pm[0] = CLVOX_OV_FABS(aybz) + CLVOX_OV_FABS(azby);
    pm[1] = CLVOX_OV_FABS(azbx) + CLVOX_OV_FABS(axbz);
    pm[2] = CLVOX_OV_FABS(axby) + CLVOX_OV_FABS(aybx);
}

/* clvox_o3_sign with clvox_o3_setup's values (the same operations). */
CLVOX_OV_FN int clvox_o3_sign_pre(const clvox_ovr *v, const clvox_ovr *m, const clvox_ovr *pm, clvox_ovr qx, clvox_ovr qy,
                                  clvox_ovr qz)
{
    clvox_ovr wx = qx - v[0], wy = qy - v[1], wz = qz - v[2];
    clvox_ovr det = wx * m[0] + wy * m[1] + wz * m[2];
    clvox_ovr perm = CLVOX_OV_FABS(wx) * pm[0] + CLVOX_OV_FABS(wy) * pm[1] + CLVOX_OV_FABS(wz) * pm[2];
    clvox_ovr bound = CLVOX_OV_BOUND(CLVOX_OV_O3_ERR * perm);
    if (det > bound) return 1;
    if (-det > bound) return -1;
    return clvox_o3_exact(v, qx, qy, qz);
}

CLVOX_OV_FN int clvox_o3_sign(const clvox_ovr *v, clvox_ovr qx, clvox_ovr qy, clvox_ovr qz)
{
    clvox_ovr m[3], pm[3];
    clvox_o3_setup(v, m, pm);
    return clvox_o3_sign_pre(v, m, pm, qx, qy, qz);
}

#endif /* CLVOX_OVERLAP_H */
