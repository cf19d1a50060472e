/* SPDX-License-Identifier: Apache-2.0 */
/* Winding numbers (winding_angles.h): the rim tree's bound on how fast w
 * can change along a ray segment (the classify's smooth stretches), and the
 * ray method's grid space to the scaled x, y, z the winding code works in. */

/* Lower bound on the distance between the segments [p0, p1] and [a, b]
 * (closest points as in Ericson, Real-Time Collision Detection 5.1.9, then
 * shrunk by more than their rounding); 0 when they may touch. */
static inline clvox_real clvox_segment_distance(const clvox_real *p0, const clvox_real *p1, global const clvox_real *a,
                                                global const clvox_real *b)
{
    clvox_real d1[3], d2[3], r[3], mag = 0;
    for (uint i = 0; i < 3u; i++) {
        d1[i] = p1[i] - p0[i];
        d2[i] = b[i] - a[i];
        r[i] = p0[i] - a[i];
        mag = fmax(mag, fmax(fmax(fabs(p0[i]), fabs(p1[i])), fmax(fabs(a[i]), fabs(b[i]))));
    }
    const clvox_real A = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2];
    const clvox_real E = d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2];
    const clvox_real F = d2[0] * r[0] + d2[1] * r[1] + d2[2] * r[2];
    clvox_real s = 0, t = 0;
    if (A <= 0 && E <= 0) {
        s = t = 0;
    } else if (A <= 0) {
        t = clamp(F / E, (clvox_real)0, (clvox_real)1);
    } else {
        const clvox_real C = d1[0] * r[0] + d1[1] * r[1] + d1[2] * r[2];
        if (E <= 0) {
            s = clamp(-C / A, (clvox_real)0, (clvox_real)1);
        } else {
            const clvox_real B = d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2];
            const clvox_real den = A * E - B * B;
            s = den > 0 ? clamp((B * F - C * E) / den, (clvox_real)0, (clvox_real)1) : 0;
            t = (B * s + F) / E;
            if (t < 0) {
                t = 0;
                s = clamp(-C / A, (clvox_real)0, (clvox_real)1);
            } else if (t > 1) {
                t = 1;
                s = clamp((B - C) / A, (clvox_real)0, (clvox_real)1);
            }
        }
    }
    clvox_real d2s = 0;
    for (uint i = 0; i < 3u; i++) {
        const clvox_real g = (p0[i] + d1[i] * s) - (a[i] + d2[i] * t);
        d2s += g * g;
    }
    /* the closest points are found to within rounding (a relative error of
     * about 1e-15 of the coordinates' size for doubles, 1e-6 for floats);
     * being near them, not exactly at them, only makes the distance larger */
    const clvox_real slack = mag * (sizeof(clvox_real) == 8 ? (clvox_real)1e-9 : (clvox_real)1e-4);
    const clvox_real d = sqrt(d2s) * (clvox_real)(1 - 1e-6) - slack;
    return d > 0 ? d : 0;
}

/* A rim leaf's bound along axis `axis`: the sum over its edges of 1.5
 * |e x u| / (4pi d^3), |e x u| the edge's length across the axis, d its
 * own distance to the segment [q0, q1] (clvox_rim_bound). */
static inline clvox_real clvox_rim_leaf_bound(global const clvox_cap_node *nd, global const clvox_real *edges,
                                              const clvox_real *q0, const clvox_real *q1, uint axis)
{
    const uint a1 = (axis + 1u) % 3u, a2 = (axis + 2u) % 3u;
    clvox_real G = 0;
    for (uint e = 0; e < nd->tri_count; e++) {
        global const clvox_real *ed = edges + (size_t)(nd->tri_first + e) * 9u;
        const clvox_real d = clvox_segment_distance(q0, q1, ed, ed + 3);
        if (!(d > 0)) return (clvox_real)INFINITY;
        const clvox_real x1 = ed[3 + a1] - ed[a1], x2 = ed[3 + a2] - ed[a2];
        G += (clvox_real)1.5 * sqrt(x1 * x1 + x2 * x2) * (clvox_real)(0.07957747154594767 * 1.000001) / (d * d * d);
    }
    return G;
}

/* A rim node's bound from its box: 1.5 (its edges' length across the axis,
 * over 4pi) / d^3, d the boxes' distance. */
static inline clvox_real clvox_rim_box_bound(global const clvox_cap_node *nd, const clvox_real *q0,
                                             const clvox_real *q1, uint axis)
{
    const clvox_real d2 = clvox_node_box_d2(nd, q0, q1);
    return d2 > 0 ? (clvox_real)1.5 * (clvox_real)nd->normal4pi[axis] / (d2 * sqrt(d2)) : (clvox_real)INFINITY;
}

/* Upper bound on w's second derivative along axis `axis` (x, y or z: the
 * ray's) over the segment [q0, q1] (q0 <= q1, a point or a segment along
 * that axis) away from the rim: w's gradient is the field of the rim (the
 * surface's boundary edges) as a current loop, the line integral of dl x
 * F(y - p) / 4pi with F(x) = x / |x|^3, so along the unit axis u
 * d^2 w / du^2 = (1/4pi) integral of 3 (x.u) (x.(u x dl)) / |x|^5, x = y -
 * p. With x.u = |x| cos t, x.(u x dl) <= |x| sin t |u x dl| and |cos t sin
 * t| <= 1/2, |d^2 w / du^2| <= (1.5/4pi) sum of |e x u| / distance^3 over
 * the edges e (rims: a tree of the boundary edges, normal4pi[a] holding
 * the nodes' edge lengths across axis a over 4pi, edges its leaves'
 * edges). It holds across the surface too, where w steps by the
 * crossing's unit: w minus those steps is smooth along a ray away from the
 * rim. Refined best-first, `budget` steps at most: a node's box bound is
 * replaced by its children's, a leaf's by its edges' own; stops when the
 * largest refinable term is under 5 % of the total. INFINITY when the
 * segment may touch a rim edge, or the budget runs out before the bound
 * is finite. */
#define CLVOX_RIM_FINAL 0x80000000u /* an entry bounded edge by edge */
#define CLVOX_RIM_LEAF 0x40000000u  /* a leaf bounded by its box */
static inline clvox_real clvox_rim_bound(global const clvox_cap_node *rims, uint rim_count,
                                         global const clvox_real *edges, const clvox_real *q0, const clvox_real *q1,
                                         uint axis, uint budget)
{
    if (rim_count == 0) return 0;
    uint stack[CLVOX_CAP_STACK];
    clvox_real sb[CLVOX_CAP_STACK];
    uint sp = 1, inf = 0;
    stack[0] = rims[0].child == 0 ? CLVOX_RIM_LEAF : 0u;
    sb[0] = clvox_rim_box_bound(rims, q0, q1, axis);
    clvox_real G = 0; /* the finite entries' sum; inf: how many are infinite */
    if (isfinite(sb[0])) G = sb[0];
    else inf = 1;
    for (uint it = 0;; it++) {
        uint best = CLVOX_CAP_STACK;
        for (uint i = 0; i < sp; i++)
            if (!(stack[i] & CLVOX_RIM_FINAL) && (best == CLVOX_CAP_STACK || sb[i] > sb[best])) best = i;
        if (best == CLVOX_CAP_STACK || it >= budget || sp + 1u >= CLVOX_CAP_STACK || (inf == 0 && sb[best] < G * (clvox_real)0.05)) {
            if (inf) return (clvox_real)INFINITY;
            G = 0; /* the exact sum (the running one drifts by subtraction) */
            for (uint i = 0; i < sp; i++) G += sb[i];
            return G * (clvox_real)CLVOX_SUM_ROUND;
        }
        const uint e = stack[best], nd = e & ~(CLVOX_RIM_FINAL | CLVOX_RIM_LEAF);
        if (isfinite(sb[best])) G -= sb[best];
        else inf--;
        if (e & CLVOX_RIM_LEAF) {
            sb[best] = clvox_rim_leaf_bound(rims + nd, edges, q0, q1, axis);
            if (!isfinite(sb[best])) return (clvox_real)INFINITY; /* an edge may touch the segment */
            stack[best] = nd | CLVOX_RIM_FINAL;
            G += sb[best];
            continue;
        }
        const uint child = rims[nd].child;
        for (uint c = 0; c < 2u; c++) {
            const uint slot = c == 0 ? best : sp++;
            stack[slot] = (child + c) | (rims[child + c].child == 0 ? CLVOX_RIM_LEAF : 0u);
            sb[slot] = clvox_rim_box_bound(rims + child + c, q0, q1, axis);
            if (isfinite(sb[slot])) G += sb[slot];
            else inf++;
        }
    }
}

/* Grid-space (u, v, w) of the ray method to scaled x, y, z: u is axis
 * `axis` (x-rays: u,v,w = x,y,z; y-rays y,z,x; z-rays z,x,y). */
static inline void clvox_scaled_xyz(uint axis, clvox_real gu, clvox_real gv, clvox_real gw, global const clvox_real *h,
                                    clvox_real *x, clvox_real *y, clvox_real *z)
{
    clvox_real g[3];
    g[axis] = gu;
    g[(axis + 1u) % 3u] = gv;
    g[(axis + 2u) % 3u] = gw;
    *x = g[0] * h[0];
    *y = g[1] * h[1];
    *z = g[2] * h[2];
}

/* Scaled box of the grid-space (u, v, w) box [g0, g1]. */
static inline void clvox_scaled_box(uint axis, const clvox_real *g0, const clvox_real *g1, global const clvox_real *h,
                                    clvox_real *q0, clvox_real *q1)
{
    clvox_scaled_xyz(axis, g0[0], g0[1], g0[2], h, &q0[0], &q0[1], &q0[2]);
    clvox_scaled_xyz(axis, g1[0], g1[1], g1[2], h, &q1[0], &q1[1], &q1[2]);
}

/* clvox_scaled_box for the caps' bounds over a box: on voxels that are not
 * cubes (h[3] == 0) a float device's box is widened by the scaled
 * coordinates' rounding (clvox_point_rounding), so that it holds the
 * double kernels' points too. */
static inline void clvox_cap_box(uint axis, const clvox_real *g0, const clvox_real *g1, global const clvox_real *h,
                                 clvox_real *q0, clvox_real *q1)
{
    clvox_scaled_box(axis, g0, g1, h, q0, q1);
#if !defined(CLVOX_FP64)
    if (h[3] == 0) {
        const clvox_real d = fmax(clvox_point_rounding(q0[0], q0[1], q0[2], 0u),
                                  clvox_point_rounding(q1[0], q1[1], q1[2], 0u)) * (clvox_real)1.01f;
        for (uint a = 0; a < 3u; a++) {
            q0[a] -= d;
            q1[a] += d;
        }
    }
#endif
}
