/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Exact predicates of surface voxelization (triangle / closed voxel cell
 * overlap), in the common subset of C11 and OpenCL C: the kernel
 * (kernels/surface.cl) and the tests (tests/test_surface.c, which checks
 * them against GMP rationals) compile this same source.
 *
 * Every argument holds a float value (grid-space vertex coordinates from
 * clvox__grid_space_soup, or cell corners: half-integers below 2^17, exact
 * in float), converted to double. Each predicate returns the exact sign of
 * a polynomial in those values:
 *
 *   clvox_e2_sign(a, b, c, d) = sign((b.s - a.s)(d.t - c.t) - (b.t - a.t)(d.s - c.s))
 *   clvox_o3_sign(v0, v1, v2, q) = sign(n . (q - v0)),  n = (v1 - v0) x (v2 - v0)
 *
 * Evaluation: first in double with Shewchuk's forward error bounds
 * ("Adaptive Precision Floating-Point Arithmetic and Fast Robust Geometric
 * Predicates", 1997: ccwerrboundA = (3 + 16u)u for the 2x2 form with its
 * four differences rounded, o3derrboundA = (7 + 56u)u for the 3x3 one,
 * u = 2^-53, times the permanent computed alongside); when the value is
 * within the bound of 0, exactly: the polynomial is expanded into monomials
 * of the float inputs. A product of two floats (24-bit significands) is
 * exact in double; a third factor is split off with two_product (fma, exact
 * in OpenCL C and C11's fma), and the sign of the sum of those doubles is
 * that of the largest component of its nonoverlapping expansion, built with
 * Shewchuk's Grow-Expansion (Two-Sum, zero elimination). Float inputs keep
 * every term far from double overflow (|term| < 2^400) and underflow
 * (|term| > 2^-500), so no step loses a bit. No step depends on the
 * device, the work-group or the order of anything: the host and every
 * device get the same signs.
 */
#ifndef CLVOX_OVERLAP_H
#define CLVOX_OVERLAP_H

#if !defined(__OPENCL_VERSION__) || defined(CLVOX_FP64)

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

#define CLVOX_OV_U 1.1102230246251565e-16 /* 2^-53 */
#define CLVOX_OV_E2_ERR ((3.0 + 16.0 * CLVOX_OV_U) * CLVOX_OV_U)
#define CLVOX_OV_O3_ERR ((7.0 + 56.0 * CLVOX_OV_U) * CLVOX_OV_U)
/* Terms of the longest exact sum (clvox_o3_exact). */
#define CLVOX_OV_MAX_TERMS 48

/* Sign of the exact sum of t[0 .. n): Grow-Expansion with zero elimination
 * keeps e nonoverlapping and increasing in magnitude, so its last component
 * has the sign of the sum. */
CLVOX_OV_FN int clvox_exact_sum_sign(const double *t, int n)
{
    double e[CLVOX_OV_MAX_TERMS];
    int m = 0;
    for (int i = 0; i < n; i++) {
        double q = t[i];
        int k = 0;
        for (int j = 0; j < m; j++) {
            double a = q, b = e[j];
            double s = a + b, bv = s - a, av = s - bv;
            double err = (a - av) + (b - bv); /* Two-Sum: a + b = s + err exactly */
            if (err != 0.0) e[k++] = err;
            q = s;
        }
        if (q != 0.0) e[k++] = q;
        m = k;
    }
    return m == 0 ? 0 : (e[m - 1] > 0.0 ? 1 : -1);
}

/* Exact sign of (b.s - a.s)(d.t - c.t) - (b.t - a.t)(d.s - c.s): eight
 * products of two floats, each exact in double. */
CLVOX_OV_COLD int clvox_e2_exact(double as, double at, double bs, double bt, double cs, double ct, double ds,
                                 double dt)
{
    double t[8];
    t[0] = bs * dt;
    t[1] = -(bs * ct);
    t[2] = -(as * dt);
    t[3] = as * ct;
    t[4] = -(bt * ds);
    t[5] = bt * cs;
    t[6] = at * ds;
    t[7] = -(at * cs);
    return clvox_exact_sum_sign(t, 8);
}

CLVOX_OV_FN int clvox_e2_sign(double as, double at, double bs, double bt, double cs, double ct, double ds,
                              double dt)
{
    double l = (bs - as) * (dt - ct), r = (bt - at) * (ds - cs);
    double det = l - r, bound = CLVOX_OV_E2_ERR * (fabs(l) + fabs(r));
    if (det > bound) return 1;
    if (-det > bound) return -1;
    return clvox_e2_exact(as, at, bs, bt, cs, ct, ds, dt);
}

/* p * q * r (p*q exact in double) as two doubles, exactly. */
CLVOX_OV_FN void clvox_ov_product3(double p, double q, double r, double sign, double *out)
{
    double pq = sign * (p * q);
    double hi = pq * r;
    out[0] = hi;
    out[1] = fma(pq, r, -hi);
}

/* Exact sign of n . q - v0 . (v1 x v2), n = v0 x v1 + v1 x v2 + v2 x v0
 * (= n . (q - v0)): 24 monomials of three floats, two doubles each. v holds
 * v0, v1, v2 (x, y, z each). */
CLVOX_OV_COLD int clvox_o3_exact(const double *v, double qx, double qy, double qz)
{
    double t[CLVOX_OV_MAX_TERMS];
    const double q[3] = {qx, qy, qz};
    int n = 0;
    for (int i = 0; i < 3; i++) {
        int a = (i + 1) % 3, b = (i + 2) % 3; /* (p x r)_i = p_a r_b - p_b r_a */
        for (int e = 0; e < 3; e++) {
            const double *p = v + 3 * e, *r = v + 3 * ((e + 1) % 3); /* v0 x v1, v1 x v2, v2 x v0 */
            clvox_ov_product3(p[a], r[b], q[i], 1.0, t + n);
            clvox_ov_product3(p[b], r[a], q[i], -1.0, t + n + 2);
            n += 4;
        }
    }
    /* - v0 . (v1 x v2) */
    for (int i = 0; i < 3; i++) {
        int a = (i + 1) % 3, b = (i + 2) % 3;
        clvox_ov_product3(v[3 + a], v[6 + b], v[i], -1.0, t + n);
        clvox_ov_product3(v[3 + b], v[6 + a], v[i], 1.0, t + n + 2);
        n += 4;
    }
    return clvox_exact_sum_sign(t, n);
}

/* The triangle's part of the 3x3 filter: the rounded minors of
 * a = v1 - v0, b = v2 - v0 (m) and their absolute products (pm), for
 * clvox_o3_sign_pre. */
CLVOX_OV_FN void clvox_o3_setup(const double *v, double *m, double *pm)
{
    double ax = v[3] - v[0], ay = v[4] - v[1], az = v[5] - v[2];
    double bx = v[6] - v[0], by = v[7] - v[1], bz = v[8] - v[2];
    double aybz = ay * bz, azby = az * by, azbx = az * bx, axbz = ax * bz, axby = ax * by, aybx = ay * bx;
    m[0] = aybz - azby;
    m[1] = azbx - axbz;
    m[2] = axby - aybx;
    pm[0] = fabs(aybz) + fabs(azby);
    pm[1] = fabs(azbx) + fabs(axbz);
    pm[2] = fabs(axby) + fabs(aybx);
}

/* clvox_o3_sign with clvox_o3_setup's values (the same operations). */
CLVOX_OV_FN int clvox_o3_sign_pre(const double *v, const double *m, const double *pm, double qx, double qy,
                                  double qz)
{
    double wx = qx - v[0], wy = qy - v[1], wz = qz - v[2];
    double det = wx * m[0] + wy * m[1] + wz * m[2];
    double perm = fabs(wx) * pm[0] + fabs(wy) * pm[1] + fabs(wz) * pm[2];
    double bound = CLVOX_OV_O3_ERR * perm;
    if (det > bound) return 1;
    if (-det > bound) return -1;
    return clvox_o3_exact(v, qx, qy, qz);
}

CLVOX_OV_FN int clvox_o3_sign(const double *v, double qx, double qy, double qz)
{
    double m[3], pm[3];
    clvox_o3_setup(v, m, pm);
    return clvox_o3_sign_pre(v, m, pm, qx, qy, qz);
}

#endif /* !__OPENCL_VERSION__ || CLVOX_FP64 */
#endif /* CLVOX_OVERLAP_H */
