/* SPDX-License-Identifier: Apache-2.0 */
/* A certified far field for the caps' winding number (issue 35): a
 * prototype on the host, in double, not used by the kernels yet.
 *
 * The winding number of a set of oriented triangles (a cap-tree node's caps)
 * seen from p is the double-layer potential
 *   w(p) = (1/4pi) int n . (y - p) / |y - p|^3 dA(y)
 *        = -(1/4pi) int n . grad G(y - p) dA(y),   G(x) = 1/|x|.
 * About the node's centre c, with x = c - p, d = |x|, delta = y - c,
 * Taylor's series of grad G(x + delta) in delta gives
 *   w(p) = sum_k -(1/4pi) sum_{|alpha| = k} sum_j (1/alpha!)
 *          d^alpha d_j G(x) M_{j,alpha},   M_{j,alpha} = int n_j delta^alpha dA
 * (k = 0: the dipole N . x / (4pi d^3); k = 1: the quadrupole that
 * kernels/winding_bounds.h already uses). The moments M are signed: caps
 * that nearly cancel (the two sides of a hairline crack, a closed box)
 * cancel in them, and the expansion of their sum is small.
 *
 * The remainder after P terms (k = 0 .. P-1) is bounded for every point p
 * with d > r (r: every point of the triangles within r of c), not on
 * average:
 *   |R_P(p)| <= (A / 4pi) / d^2 * q^P (P + 1 - P q) / (1 - q)^2,  q = r / d,
 * A the total absolute area. Proof. For one y, g(t) = n . grad G(x + t
 * delta) is analytic in t for |t| < d / |delta| (the complex zeros of
 * |x + t delta|^2 = d^2 + 2 t x.delta + t^2 |delta|^2 have |t| = d / |delta|),
 * so its Taylor series at 0 converges at t = 1 to g(1), and its k-th
 * coefficient is (1/k!) D^(k+1) G(x)[delta^k, n]. The (k+1)-th derivative
 * of 1/|x| as a symmetric (k+1)-linear form has norm (k+1)! / d^(k+2): on
 * the diagonal it is (k+1)! P_(k+1)(cos) / d^(k+2) up to sign (the
 * generating function of the Legendre polynomials, |P_k| <= 1), and a
 * symmetric form's norm is its sup on the diagonal (Banach 1938). So the
 * k-th coefficient is at most (k+1) |delta|^k / d^(k+2) and the tail k >= P
 * at most sum_{k >= P} (k+1) q^k / d^2 = q^P (P + 1 - P q) / ((1 - q)^2
 * d^2) (the derivative of q^(P+1) / (1 - q)). Integrate over the triangles
 * (|delta| <= r, |n| = 1) and divide by 4pi. The bound is tight as q -> 0
 * for a small triangle on the axis with its normal along x (then every
 * derivative meets its norm); the Lagrange form (P+1) A r^P / (4pi (d -
 * r)^(P+2)) (kernels/winding_bounds.h's, P = 1, 2) is larger by (1 -
 * q)^-P about.
 *
 * Rounding (documented margin, not a formal proof): the moments are exact
 * integrals (Gauss rules exact for the degree) up to rounding; the
 * derivatives d^beta G come from a three-term recurrence; each product in
 * term k is at most |T_beta| |M| / alpha! <= (k+1)! / d^(k+2) * A r^k /
 * alpha!, and sum_alpha k! / alpha! = 3^k, so term k's products add up to
 * at most 3^(k+1) (k+1) A r^k / d^(k+2). The margin
 * CLVOX__FF_ROUND (1e-10, about 1e6 ulps) of that sum, over 4pi, is added
 * to every bound. */
#ifndef CLVOX_FAR_FIELD_H
#define CLVOX_FAR_FIELD_H
#include <stddef.h>

#define CLVOX__FF_MAX_TERMS 8                        /* P: terms k = 0 .. P-1 */
#define CLVOX__FF_MONO(k) ((k) * ((k) + 1) * ((k) + 2) / 6) /* monomials of degree < k */
#define CLVOX__FF_NMOM CLVOX__FF_MONO(CLVOX__FF_MAX_TERMS)  /* 120: degree <= 7 */
#define CLVOX__FF_ROUND 1e-10

/* Index of the monomial x^a y^b z^c: degree-major, then by b + c, then c. */
static inline int clvox__ff_mono(int a, int b, int c)
{
    const int k = a + b + c, s = b + c;
    return CLVOX__FF_MONO(k) + s * (s + 1) / 2 + c;
}

/* A node's expansion: moments about `centre`, radius and absolute area. */
typedef struct clvox__ff {
    int terms;                       /* P, 1 .. CLVOX__FF_MAX_TERMS */
    double centre[3];
    double radius;                   /* every point of the triangles is within radius of centre */
    double area;                     /* sum of the triangles' areas */
    double m[3][CLVOX__FF_NMOM];     /* M_{j,alpha} = int n_j (y - c)^alpha dA, |alpha| < terms */
} clvox__ff;

/* An empty expansion about c with P terms (clamped to 1 .. MAX_TERMS). */
void clvox__ff_init(clvox__ff *e, int terms, const double c[3]);
/* Adds n triangles (9 doubles each: a, b, c; counter-clockwise seen from
 * the side their normal points to): moments, area and radius. */
void clvox__ff_add_triangles(clvox__ff *e, const double *tri, size_t n);
/* Adds src's moments shifted to dst's centre (binomial translation), its
 * area, and grows dst's radius to |c_src - c_dst| + r_src where that is
 * larger (exact in exact arithmetic; the radius is rounded up). The terms
 * used are min(dst, src). */
void clvox__ff_add_shifted(clvox__ff *dst, const clvox__ff *src);

/* The expansion at p truncated after 1 .. terms terms: est[P-1] and its
 * rigorous error bound bound[P-1] (the header's), for P = 1 .. terms.
 * Returns terms, or 0 when p is not outside the sphere (d <= r: no bound). */
int clvox__ff_eval(const clvox__ff *e, const double p[3], double *est, double *bound);
/* The truncation (1 .. terms terms) with the smallest bound: 0 when d <= r,
 * else 1 with *est and *bound set. */
int clvox__ff_best(const clvox__ff *e, const double p[3], double *est, double *bound);

/* The signed solid angle / 4pi of triangle (a, b, c) seen from p (van
 * Oosterom-Strackee, double). */
double clvox__ff_tri_exact(const double *tri, const double p[3]);
#endif
