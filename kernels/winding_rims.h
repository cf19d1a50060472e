/* SPDX-License-Identifier: Apache-2.0 */
/* Winding numbers (winding_angles.h): the rim tree's bound on how fast w
 * can change along a ray segment (the classify's smooth stretches), and the
 * ray method's grid space to the scaled x, y, z the winding code works in. */

/* The squared distance across axis `axis` from the line through q0 along
 * it to the edge [a, b]: the 2-D distance from q0's (v, w) to the edge's
 * projection, at the point the rounded projection finds (near the closest
 * one: being off it only makes the distance larger, by about the
 * coordinates' rounding). */
static inline clvox_real clvox_axis_edge_d2(const clvox_real *q0, uint axis, global const clvox_real *a,
                                            global const clvox_real *b)
{
    const uint a1 = (axis + 1u) % 3u, a2 = (axis + 2u) % 3u;
    const clvox_real dv = b[a1] - a[a1], dw = b[a2] - a[a2], rv = q0[a1] - a[a1], rw = q0[a2] - a[a2];
    const clvox_real dd = dv * dv + dw * dw;
    const clvox_real t = dd > 0 ? clamp((rv * dv + rw * dw) / dd, (clvox_real)0, (clvox_real)1) : (clvox_real)0;
    const clvox_real ev = rv - t * dv, ew = rw - t * dw;
    return ev * ev + ew * ew;
}

/* How much the distances below are shrunk for their rounding: far more
 * than it, for coordinates of magnitude up to mag. */
#define CLVOX_RIM_SLACK(mag) ((mag) * (sizeof(clvox_real) == 8 ? (clvox_real)1e-9 : (clvox_real)1e-4))

/* Lower bound on the distance between the segment [q0, q1] along axis
 * `axis` (q0 and q1 differ only there) and the edge [a, b]: at every point
 * of the edge the distance across the axis is at least the 2-D distance
 * (clvox_axis_edge_d2), and the distance along it at least the gap gap
 * between their extents, so the distance is at least sqrt(d2 + gap^2)
 * (shrunk by more than its rounding, slack: CLVOX_RIM_SLACK of a
 * magnitude at least the coordinates'; 0 when they may touch). About a
 * third of the cost of the closest points in 3-D, used until 2026-12-07. */
static inline clvox_real clvox_axis_edge_distance(const clvox_real *q0, const clvox_real *q1, uint axis,
                                                  global const clvox_real *a, global const clvox_real *b,
                                                  clvox_real slack)
{
    const clvox_real gap = clvox_interval_gap(fmin(a[axis], b[axis]), fmax(a[axis], b[axis]), q0[axis], q1[axis]);
    const clvox_real d = sqrt(clvox_axis_edge_d2(q0, axis, a, b) + gap * gap) * (clvox_real)(1 - 1e-6) - slack;
    return d > 0 ? d : 0;
}

/* A rim leaf's bound along axis `axis`: the sum over its edges of 1.5
 * |e x u| / (4pi d^3), |e x u| the edge's length across the axis, d its
 * own distance to the segment [q0, q1] along the axis (the bound below). */
static inline clvox_real clvox_rim_leaf_bound(global const clvox_cap_node *nd, global const clvox_real *edges,
                                              const clvox_real *q0, const clvox_real *q1, uint axis,
                                              clvox_real slack)
{
    const uint a1 = (axis + 1u) % 3u, a2 = (axis + 2u) % 3u;
    clvox_real G = 0;
    for (uint e = 0; e < nd->tri_count; e++) {
        global const clvox_real *ed = edges + (size_t)(nd->tri_first + e) * 9u;
        const clvox_real d = clvox_axis_edge_distance(q0, q1, axis, ed, ed + 3, slack);
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
 * ray's) over a segment of a ray away from the rim: w's gradient is the
 * field of the rim (the surface's boundary edges) as a current loop, the
 * line integral of dl x F(y - p) / 4pi with F(x) = x / |x|^3, so along the
 * unit axis u d^2 w / du^2 = (1/4pi) integral of 3 (x.u) (x.(u x dl)) /
 * |x|^5, x = y - p. With x.u = |x| cos t, x.(u x dl) <= |x| sin t |u x dl|
 * and |cos t sin t| <= 1/2, |d^2 w / du^2| <= (1.5/4pi) sum of |e x u| /
 * distance^3 over the edges e (rims: a tree of the boundary edges,
 * normal4pi[a] holding the nodes' edge lengths across axis a over 4pi,
 * edges its leaves' edges). It holds across the surface too, where w
 * steps by the crossing's unit: w minus those steps is smooth along a ray
 * away from the rim.
 *
 * Prepared once per ray (clvox_rim_ray_terms), summed per segment
 * (clvox_rim_terms_bound): the classify bounds 10-40 segments of a ray
 * near the rims, and until 2026-12-07 refined the tree from its root for
 * each (12 steps; 18 % of elephant-with-holes' classify at 256^3 went to
 * its leaves' 3-D distances, and deeper refinement cost more than the
 * evaluations it saved). The tree is refined best first against the whole
 * ray (a node's box bound replaced by its children's, a leaf's by its
 * edges' own; `steps` at most, until the largest refinable term is
 * under CLVOX_RIM_CUT_F of the total), and its CLVOX_RIM_TERMS largest
 * entries (a leaf bounded edge by edge as its edges) become terms w /
 * dist^3 whose distance to a segment [ua, ub] of the ray splits into what
 * does not depend on the segment, d2 (the squared 2-D distance across the
 * axis from the ray to the node's box or the edge's projection), and the
 * gap between [ua, ub] and the term's extent [lo, hi] along the axis:
 * dist^2 >= d2 + gap^2 (as clvox_axis_edge_distance). The other entries'
 * bounds over the whole ray, which hold on every part of it, are summed
 * once into `far`. Every edge lies under exactly one entry whatever the
 * refinement, so the bound holds; refining for the whole ray rather than
 * the segment only makes the far part coarser. */
#define CLVOX_RIM_STEPS 64u
/* A ray refines its terms CLVOX_RIM_STEPS steps where its last fresh exact
 * evaluation needed more exact cap nodes than this, else half as many, and
 * builds them again in full once its evaluations turn out costly: tighter
 * terms save evaluations, worth it where those are costly (32 steps
 * everywhere: b9_mesh 1.04 M -> 1.26 M exact points, 9 % slower;
 * mech-holes-shark and elephant-with-holes 10-26 % faster; this rule:
 * b9_mesh 1.05 M, the same time, the others 7-8 % faster). */
#define CLVOX_RIM_COSTLY 2u
#define CLVOX_RIM_TERMS 64u
#define CLVOX_RIM_CUT_F ((clvox_real)0.002)
#define CLVOX_RIM_FINAL 0x80000000u /* an entry bounded edge by edge */
#define CLVOX_RIM_LEAF 0x40000000u  /* a leaf bounded by its box */
typedef struct clvox_rim_terms {
    clvox_real d2[CLVOX_RIM_TERMS]; /* the squared distance across the axis */
    clvox_real lo[CLVOX_RIM_TERMS], hi[CLVOX_RIM_TERMS];
    clvox_real w[CLVOX_RIM_TERMS]; /* a node's box: negated (sign bit set), so that d2 stays exact */
    clvox_real far;   /* the other entries' bound over the whole ray */
    clvox_real slack; /* the edges' distances' rounding (clvox_axis_edge_distance) */
    uint n;
} clvox_rim_terms;

/* The terms of the ray segment [q0, q1] along axis `axis` (the whole ray:
 * its segments are bounded from them). */
static inline void clvox_rim_ray_terms(global const clvox_cap_node *rims, uint rim_count,
                                       global const clvox_real *edges, const clvox_real *q0, const clvox_real *q1,
                                       uint axis, uint steps, clvox_rim_terms *t)
{
    t->n = 0;
    t->far = 0;
    t->slack = 0;
    if (rim_count == 0) return;
    const uint a1 = (axis + 1u) % 3u, a2 = (axis + 2u) % 3u;
    /* the distances' rounding, for coordinates up to the ray's and the
     * rims' box's (every edge lies in it) */
    clvox_real mag = 0;
    for (uint i = 0; i < 3u; i++)
        mag = fmax(mag, fmax(fmax(fabs(q0[i]), fabs(q1[i])),
                             fmax(fabs((clvox_real)rims[0].lo[i]), fabs((clvox_real)rims[0].hi[i]))));
    t->slack = CLVOX_RIM_SLACK(mag);
    uint cut[CLVOX_RIM_STEPS + 2u]; /* a step adds one entry at most */
    clvox_real sb[CLVOX_RIM_STEPS + 2u];
    /* entries [0, r) may be refined, [r, sp) are bounded edge by edge:
     * the search for the largest looks at the first only */
    uint sp = 1, r = 1, inf = 0;
    cut[0] = rims[0].child == 0 ? CLVOX_RIM_LEAF : 0u;
    sb[0] = clvox_rim_box_bound(rims, q0, q1, axis);
    clvox_real G = 0;
    if (isfinite(sb[0])) G = sb[0];
    else inf = 1;
    for (uint it = 0; it < steps && r > 0; it++) {
        uint best = 0;
        for (uint i = 1; i < r; i++) best = sb[i] > sb[best] ? i : best;
        if (inf == 0 && sb[best] < G * CLVOX_RIM_CUT_F) break;
        const uint e = cut[best], nd = e & ~(CLVOX_RIM_FINAL | CLVOX_RIM_LEAF);
        if (isfinite(sb[best])) G -= sb[best];
        else inf--;
        if (e & CLVOX_RIM_LEAF) {
            const clvox_real b = clvox_rim_leaf_bound(rims + nd, edges, q0, q1, axis, t->slack);
            if (isfinite(b)) G += b;
            else inf++;
            r--; /* to the bounded ones: the last refinable entry takes its place */
            cut[best] = cut[r];
            sb[best] = sb[r];
            cut[r] = nd | CLVOX_RIM_FINAL;
            sb[r] = b;
            continue;
        }
        const uint child = rims[nd].child;
        /* the first child in its place, the second at r (the bounded
         * entry there, if any, to the end) */
        cut[sp] = cut[r];
        sb[sp] = sb[r];
        sp++;
        for (uint c = 0; c < 2u; c++) {
            const uint slot = c == 0 ? best : r++;
            cut[slot] = (child + c) | (rims[child + c].child == 0 ? CLVOX_RIM_LEAF : 0u);
            sb[slot] = clvox_rim_box_bound(rims + child + c, q0, q1, axis);
            if (isfinite(sb[slot])) G += sb[slot];
            else inf++;
        }
    }
    /* the largest entries into terms, while they fit (selection: the
     * infinite ones first), the rest into far; where all fit, in any
     * order (no selection) */
    uint all = 0;
    for (uint i = 0; i < sp; i++)
        all += (cut[i] & CLVOX_RIM_FINAL) ? rims[cut[i] & ~(CLVOX_RIM_FINAL | CLVOX_RIM_LEAF)].tri_count : 1u;
    const int select = all > CLVOX_RIM_TERMS;
    for (uint k = 0; k < sp; k++) {
        uint best = k;
        if (select)
            for (uint i = k + 1u; i < sp; i++) best = sb[i] > sb[best] ? i : best;
        const uint e = cut[best], nd = e & ~(CLVOX_RIM_FINAL | CLVOX_RIM_LEAF);
        const uint need = (e & CLVOX_RIM_FINAL) ? rims[nd].tri_count : 1u;
        if (t->n + need > CLVOX_RIM_TERMS) {
            for (uint i = k; i < sp; i++) t->far += sb[i];
            return;
        }
        cut[best] = cut[k];
        sb[best] = sb[k];
        global const clvox_cap_node *r = rims + nd;
        if (e & CLVOX_RIM_FINAL) {
            for (uint j = 0; j < r->tri_count; j++) {
                global const clvox_real *a = edges + (size_t)(r->tri_first + j) * 9u, *b = a + 3;
                const clvox_real dv = b[a1] - a[a1], dw = b[a2] - a[a2];
                const uint i = t->n++;
                t->d2[i] = clvox_axis_edge_d2(q0, axis, a, b);
                t->lo[i] = fmin(a[axis], b[axis]);
                t->hi[i] = fmax(a[axis], b[axis]);
                t->w[i] = (clvox_real)1.5 * sqrt(dv * dv + dw * dw) * (clvox_real)(0.07957747154594767 * 1.000001);
            }
        } else {
            const clvox_real g1 = clvox_interval_gap(r->lo[a1], r->hi[a1], q0[a1], q0[a1]);
            const clvox_real g2 = clvox_interval_gap(r->lo[a2], r->hi[a2], q0[a2], q0[a2]);
            const uint i = t->n++;
            t->d2[i] = g1 * g1 + g2 * g2;
            t->lo[i] = r->lo[axis];
            t->hi[i] = r->hi[axis];
            t->w[i] = -((clvox_real)1.5 * (clvox_real)r->normal4pi[axis]); /* a box: w's sign bit set */
        }
    }
}

/* The rims' bound over the segment [q0, q1] of the ray of t. */
static inline clvox_real clvox_rim_terms_bound(const clvox_rim_terms *t, const clvox_real *q0, const clvox_real *q1,
                                               uint axis)
{
    clvox_real G = t->far;
    for (uint i = 0; i < t->n; i++) {
        const clvox_real gap = clvox_interval_gap(t->lo[i], t->hi[i], q0[axis], q1[axis]);
        if (signbit(t->w[i])) {
            const clvox_real d2 = t->d2[i] + gap * gap; /* a node's box, as clvox_rim_box_bound */
            if (!(d2 > 0)) return (clvox_real)INFINITY;
            G -= t->w[i] / (d2 * sqrt(d2));
        } else { /* an edge (as clvox_axis_edge_distance) */
            const clvox_real d = sqrt(t->d2[i] + gap * gap) * (clvox_real)(1 - 1e-6) - t->slack;
            if (!(d > 0)) return (clvox_real)INFINITY;
            G += t->w[i] / (d * d * d);
        }
    }
    return G * (clvox_real)CLVOX_SUM_ROUND;
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
