/* SPDX-License-Identifier: Apache-2.0 */
/* Winding numbers (winding_angles.h): upper bounds on the caps' |w| from a
 * point or a box (distance to the nodes' boxes), the cap tree's node
 * estimates, and the interval test against the threshold. */

/* The gap between the intervals [lo, hi] and [a, b] (0 when they meet). */
static inline clvox_real clvox_interval_gap(clvox_real lo, clvox_real hi, clvox_real a, clvox_real b)
{
    return lo > b ? lo - b : (a > hi ? a - hi : 0);
}

/* Squared distance between the node's box and the box [q0, q1] (0 when
 * they meet); the cap tree's and the rim tree's bounds both start from it. */
static inline clvox_real clvox_node_box_d2(global const clvox_cap_node *n, const clvox_real *q0, const clvox_real *q1)
{
    clvox_real d2 = 0;
    for (uint a = 0; a < 3u; a++) {
        const clvox_real g = clvox_interval_gap(n->lo[a], n->hi[a], q0[a], q1[a]);
        d2 += g * g;
    }
    return d2;
}

/* A weld-pair node's slab (clvox_cap_node): every corner y of its pairs
 * has n . y in [smin, smax] (n = normal4pi, unit; smin, smax = quad4pi[0],
 * quad4pi[1]; none: -+FLT_MAX), so no triangle between T and T' comes
 * nearer to p than the slab does. The distance from the box [q0, q1] to
 * it, a lower bound: the dot products' rounding (a few ulps of the terms'
 * magnitudes) is taken off, and |n| may exceed 1 by its float rounding. */
#if defined(CLVOX_FP64)
#define CLVOX_SLAB_ERR 1e-14
#else
#define CLVOX_SLAB_ERR 1e-6f
#endif
static inline clvox_real clvox_pair_slab_gap(global const clvox_cap_node *n, const clvox_real *q0, const clvox_real *q1)
{
    clvox_real lo = 0, hi = 0, mag = 0;
    for (uint a = 0; a < 3u; a++) {
        const clvox_real na = n->normal4pi[a], u = na * q0[a], v = na * q1[a];
        lo += fmin(u, v);
        hi += fmax(u, v);
        mag += fmax(fabs(q0[a]), fabs(q1[a]));
    }
    const clvox_real smin = n->quad4pi[0], smax = n->quad4pi[1];
    const clvox_real gap = fmax(fmax(smin - hi, lo - smax), (clvox_real)0);
    const clvox_real g = gap - (clvox_real)CLVOX_SLAB_ERR * (mag + fmax(fabs(smin), fabs(smax)));
    return g > 0 ? g * (clvox_real)(1 - 1e-6) : 0;
}

/* Upper bound on |w| of the node's caps seen from any point of the box
 * [q0, q1] (a point when q0 == q1). */
static inline clvox_real clvox_cap_bound_box(global const clvox_cap_node *n, const clvox_real *q0, const clvox_real *q1)
{
    clvox_real d2 = clvox_node_box_d2(n, q0, q1);
    if (n->radius >= CLVOX_PAIR_RADIUS) {
        const clvox_real g = clvox_pair_slab_gap(n, q0, q1);
        d2 = fmax(d2, g * g);
    }
    const clvox_real cap = (clvox_real)n->half_count;
    if (d2 == 0) return cap;
    const clvox_real b = (clvox_real)n->area4pi / d2 * (clvox_real)1.000001;
    return b < cap ? b : cap;
}

/* A tree with weld pairs (clvox_cap_node, src/winding/crack_weld.c): its
 * root has CLVOX_PAIR_RADIUS. A pair node's estimate is 0 and its bound
 * the box bound alone (the radius makes d - r negative in
 * clvox_cap_estimate4): area4pi / D^2 with area4pi the sum of (per(T) +
 * 6 delta) delta / 4pi, which bounds |Omega(T) - Omega(T')| / 4pi of each
 * pair seen from outside the box, and half_count (1 a pair) inside it. */
#define CLVOX_PAIR_TREE(nodes, count) ((count) > 0u && (nodes)[0].radius >= CLVOX_PAIR_RADIUS)

#define CLVOX_COLUMN_BUDGET 48u /* node steps of a column stretch's bound (kernels/coverage.cl) */

/* Inside from K alone (no caps near): w = K exactly, K >= 1 (abs: K != 0). */
static inline int clvox_k_inside(int K, uint abs_mode) { return abs_mode ? K != 0 : K >= 1; }

/* The caps' bound over the box [q0, q1]: the tree refined best first until
 * the bound (times its sums' rounding) is under `stop`, or after `budget`
 * steps, or at a leaf. */
static inline clvox_real clvox_caps_box_bound(global const clvox_cap_node *nodes, const clvox_real *q0,
                                              const clvox_real *q1, uint budget, clvox_real stop)
{
    uint stack[CLVOX_CAP_STACK];
    clvox_real sb[CLVOX_CAP_STACK];
    uint sp = 1;
    stack[0] = 0;
    sb[0] = clvox_cap_bound_box(nodes, q0, q1);
    for (uint it = 0;; it++) {
        clvox_real B = 0;
        uint best = 0;
        for (uint i = 0; i < sp; i++) {
            B += sb[i];
            if (sb[i] > sb[best]) best = i;
        }
        const uint nd = stack[best];
        B *= (clvox_real)CLVOX_SUM_ROUND;
        if (B < stop || it >= budget || sp + 1u >= CLVOX_CAP_STACK || nodes[nd].child == 0) return B;
        stack[best] = stack[sp - 1u];
        sb[best] = sb[sp - 1u];
        sp--;
        for (uint c = 0; c < 2u; c++) {
            const uint ch = nodes[nd].child + c;
            stack[sp] = ch;
            sb[sp++] = clvox_cap_bound_box(nodes + ch, q0, q1);
        }
    }
}

/* The caps' bound under which K alone decides: 1/2 - 2^-29. */
#define CLVOX_CAPS_FAR_LIMIT ((clvox_real)0.5 - (clvox_real)CLVOX_WINDING_TIE * 2)

/* Is the box [q0, q1] decided by K alone? 1 when the caps' bound over
 * it is below 1/2 - 2^-29, so that every point of it is inside exactly
 * when clvox_k_inside. Refines at most `budget` nodes. */
static inline int clvox_caps_far(global const clvox_cap_node *nodes, uint node_count, const clvox_real *q0,
                                 const clvox_real *q1, uint budget)
{
    if (node_count == 0) return 1;
    return clvox_caps_box_bound(nodes, q0, q1, budget, CLVOX_CAPS_FAR_LIMIT) < CLVOX_CAPS_FAR_LIMIT;
}

/* The node's caps' w seen from p as an estimate and an error bound: the
 * tightest of three, each valid on its own (which one is only a matter of
 * tightness). w_node(p) is the integral of n . F(y - p) dA / 4pi over the
 * node's caps (n dA the vector area element), F(x) = x / |x|^3 = -grad
 * 1/|x|. With x = c - p (c: the node's centre), d = |x|, delta = y - c,
 * |delta| <= r (its sphere), Taylor's formula at x with the integral
 * remainder:
 *   F(x + delta) = F(x) + DF(x) delta + R,  DF(x)_ij = (delta_ij |x|^2 -
 *   3 x_i x_j) / |x|^5,  |n . R| <= sup |D^3 (1/|xi|)| |delta|^2 / 2,
 * xi on the segment, |xi| >= d - r. The k-th derivative of 1/|x| as a
 * symmetric k-linear form has norm k! / |x|^(k+1): on the diagonal it is
 * k! P_k(cos) / |x|^(k+1) with |P_k| <= 1, and a symmetric form's norm is
 * its sup on the diagonal (Banach, 1938). Integrated, with a = area / 4pi,
 * N = normal4pi, s = second4pi, Q' = quad4pi (clvox_cap_node):
 *   0. |w| <= b0, the box bound (clvox_cap_bound_box at p);
 *   1. w = N . x / d^3 +- 2 a r / (d - r)^3 (the dipole; |D^2| = 2 / d^3);
 *   2. w = (N . x d^2 + x^T Q' x) / d^5 +- 3 s / (d - r)^4 (the first-
 *      order term is the sum of M_ij DF_ij = x^T (tr(M) I - 3 sym(M)) x /
 *      d^5; s <= a r^2): tighter than 1 where d - r > 1.5 s / (a r), far
 *      nodes by about 1.5 r / d.
 * Rounding (u the unit roundoff of clvox_real; a float device's sqrt and
 * divide may be 3 ulp = 6 u off), covered so:
 * - d - r is taken as dm = d (1 - CLVOX_EST_DREL) - r: d's relative error
 *   (the rounded x, the squares' sum, sqrt: below 10 u) and the product's
 *   are below DREL, so d (1 - DREL) <= the true d and dm <= the true d - r
 *   (exact by Sterbenz where it is below r, else within u); dm <= 0: only
 *   bound 0.
 * - The bounds' own few products and one division: about 25 u relative,
 *   their factor CLVOX_EST_ROUND.
 * - The stored floats (N and Q' rounded to nearest: |N| <= a, |Q'_ij| <= 4
 *   P, P the integral of |delta| dA / 4pi <= a r; so at most 1.1e-7 a /
 *   d^2 and 12 2^-24 P / d^3 = 7.2e-7 a r / d^3) and the estimates'
 *   evaluation (N . x, d^2 and the powers of 1/d: about 90 u of a / d^2;
 *   x^T Q' x: about 9 u of sum |Q'_ij x_i x_j| <= 12 P d^2, and its
 *   scaling by 1/d^5 about 75 u of |x^T Q' x| <= 4 P d^2: about 410 u of P
 *   / d^3) are covered by the margins 8e-6 a / (d - r)^2 (bounds 1 and 2)
 *   and 4e-5 a r / (d - r)^3 (bound 2). In double the stored floats
 *   dominate; in float (u = 6e-8) the evaluation, 5.5e-6 and 2.5e-5 at
 *   most. The box bound's one division and few products are covered by its
 *   factor 1.000001. */
#if defined(CLVOX_FP64)
#define CLVOX_EST_DREL 1e-14
#define CLVOX_EST_ROUND 1.000001
#else
#define CLVOX_EST_DREL 2e-6f
#define CLVOX_EST_ROUND 1.0001f
#endif
#define CLVOX_EST_M0 8e-6 /* of a / (d - r)^2 */
#define CLVOX_EST_M1 4e-5 /* of a r / (d - r)^3 */
/* The estimates and bounds above for four nodes at once, lane by lane (the
 * zeroth-order one is clvox_cap_bound_box's at a point: the box distance
 * per axis is max(lo - p, p - hi, 0), exactly its branches' value). */
static inline void clvox_cap_estimate4(global const clvox_cap_node *k, global const clvox_cap_node *l,
                                       global const clvox_cap_node *m, global const clvox_cap_node *n, clvox_real px,
                                       clvox_real py, clvox_real pz, clvox_real dp, int pairs, clvox_real *est,
                                       clvox_real *err)
{
#define CLVOX_N4(f) ((clvox_real4)(k->f, l->f, m->f, n->f))
    const clvox_real4 zero = (clvox_real4)0;
    const clvox_real4 gx = fmax(fmax(CLVOX_N4(lo[0]) - px, px - CLVOX_N4(hi[0])), zero);
    const clvox_real4 gy = fmax(fmax(CLVOX_N4(lo[1]) - py, py - CLVOX_N4(hi[1])), zero);
    const clvox_real4 gz = fmax(fmax(CLVOX_N4(lo[2]) - pz, pz - CLVOX_N4(hi[2])), zero);
    clvox_real4 db2 = gx * gx + gy * gy + gz * gz;
    const clvox_real4 r = CLVOX_N4(radius);
    const clvox_mask4 pair = r >= (clvox_real4)CLVOX_PAIR_RADIUS;
    if (pairs && any(pair)) { /* weld pairs (a tree that has them: `pairs`): the slab too (clvox_pair_slab_gap) */
        const clvox_real4 dot = CLVOX_N4(normal4pi[0]) * px + CLVOX_N4(normal4pi[1]) * py + CLVOX_N4(normal4pi[2]) * pz;
        const clvox_real4 smin = CLVOX_N4(quad4pi[0]), smax = CLVOX_N4(quad4pi[1]);
        const clvox_real4 gap = fmax(fmax(smin - dot, dot - smax), zero);
        const clvox_real4 g = gap - (clvox_real)CLVOX_SLAB_ERR * ((clvox_real4)(fabs(px) + fabs(py) + fabs(pz)) +
                                                                  fmax(fabs(smin), fabs(smax)));
        const clvox_real4 gs = fmax(g, zero) * (clvox_real)(1 - 1e-6);
        db2 = select(db2, fmax(db2, gs * gs), pair);
    }
#if !defined(CLVOX_FP64)
    if (dp > 0) { /* the true point lies within dp of p: its box distance at least this less dp */
        const clvox_real4 db = sqrt(db2) * (clvox_real)(1 - 1e-6) - dp;
        db2 = select(zero, db * db, db > zero);
    }
#endif
    const clvox_real4 a = CLVOX_N4(area4pi), cap = CLVOX_N4(half_count);
    const clvox_real4 bb = a / db2 * (clvox_real)1.000001;
    const clvox_real4 b0 = select(select(cap, bb, bb < cap), cap, db2 == zero);
    const clvox_real4 x = CLVOX_N4(centre[0]) - px, y = CLVOX_N4(centre[1]) - py, z = CLVOX_N4(centre[2]) - pz;
    const clvox_real4 d2 = x * x + y * y + z * z, d = sqrt(d2);
#if defined(CLVOX_FP64)
    const clvox_real4 dm = d * (1 - (clvox_real)CLVOX_EST_DREL) - r;
#else
    const clvox_real4 dm = d * (1 - (clvox_real)CLVOX_EST_DREL) - r - dp;
#endif
    const clvox_real4 idr = (clvox_real)1 / dm, idr2 = idr * idr;
    clvox_real4 e1 = a * idr2 * ((2 * r) * idr * (clvox_real)CLVOX_EST_ROUND + (clvox_real)CLVOX_EST_M0);
    clvox_real4 e2 = (3 * CLVOX_N4(second4pi)) * (idr2 * idr2) * (clvox_real)CLVOX_EST_ROUND +
                     a * idr2 * ((clvox_real)CLVOX_EST_M0 + (clvox_real)CLVOX_EST_M1 * r * idr);
#if !defined(CLVOX_FP64)
    if (dp > 0) { /* w_node moves by at most |grad w_node| dp <= 2 a dp / dm^3 between p and the true point */
        const clvox_real4 move = (2 * dp * (clvox_real)CLVOX_EST_ROUND) * a * (idr2 * idr);
        e1 += move;
        e2 += move;
    }
#endif
    const clvox_real4 id = (clvox_real)1 / d, id2 = id * id, id3 = id2 * id;
    const clvox_real4 nx = CLVOX_N4(normal4pi[0]) * x + CLVOX_N4(normal4pi[1]) * y + CLVOX_N4(normal4pi[2]) * z;
    const clvox_real4 qf =
        (CLVOX_N4(quad4pi[0]) * x * x + CLVOX_N4(quad4pi[1]) * y * y + CLVOX_N4(quad4pi[2]) * z * z) +
        2 * (CLVOX_N4(quad4pi[3]) * x * y + CLVOX_N4(quad4pi[4]) * x * z + CLVOX_N4(quad4pi[5]) * y * z);
#undef CLVOX_N4
    const clvox_mask4 ok = dm > zero;
    const clvox_mask4 use1 = ok & (e1 < b0);
    clvox_real4 es = select(zero, nx * id3, use1), er = select(b0, e1, use1);
    const clvox_mask4 use2 = ok & (e2 < er);
    es = select(es, (nx * d2 + qf) * (id3 * id2), use2);
    er = select(er, e2, use2);
    vstore4(es, 0, est);
    vstore4(er, 0, err);
}

/* The same for one node (the root; a frontier's odd one out): every lane
 * the node, one body for all. */
static inline void clvox_cap_estimate(global const clvox_cap_node *n, clvox_real px, clvox_real py, clvox_real pz,
                                      clvox_real dp, int pairs, clvox_real *est, clvox_real *err)
{
    clvox_real e[4], b[4];
    clvox_cap_estimate4(n, n, n, n, px, py, pz, dp, pairs, e, b);
    *est = e[0];
    *err = b[0];
}

/* The same for two nodes (a node's children): lanes 2 and 3 repeat them
 * (on the CPU devices a vector of four doubles costs what one of two does). */
static inline void clvox_cap_estimate2(global const clvox_cap_node *m, global const clvox_cap_node *n, clvox_real px,
                                       clvox_real py, clvox_real pz, clvox_real dp, int pairs, clvox_real *est,
                                       clvox_real *err)
{
    clvox_real e[4], b[4];
    clvox_cap_estimate4(m, n, m, n, px, py, pz, dp, pairs, e, b);
    est[0] = e[0];
    est[1] = e[1];
    err[0] = b[0];
    err[1] = b[1];
}

/* Inside (1), outside (0) or undecided (-1) for every w in [lo, hi]. */
static inline int clvox_interval_inside(clvox_real lo, clvox_real hi, uint abs_mode)
{
    const clvox_real thr = (clvox_real)0.5 + (clvox_real)CLVOX_WINDING_TIE;
    if (lo > thr) return 1;
    if (abs_mode) {
        if (hi < -thr) return 1;
        return hi <= thr && lo >= -thr ? 0 : -1;
    }
    return hi <= thr ? 0 : -1;
}
