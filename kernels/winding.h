/* Winding numbers: the inside test of the cast's consumers when the mesh is
 * open (docs/design.md "Winding numbers").
 *
 * The host closes every hole of the (oriented) surface with a fan of cap
 * triangles, and the cast runs over surface + caps, a closed chain: the
 * signed crossings beyond a point p give an exact integer K(p), and the
 * surface's generalized winding number is w(p) = K(p) - w_caps(p), where
 * w_caps is the caps' solid angle / 4pi. Inside: w > 1/2 + 2^-30 (or
 * |w| > 1/2 + 2^-30); values within 2^-30 of 1/2 count as 1/2.
 *
 * Most points are decided from K alone: |w_caps(p)| <= sum of area / (4pi
 * d^2) over the caps (d = distance from p to the cap, from its box), and
 * when that bound is below |K - 1/2| - 2^-30 the answer is that of K. Near
 * the caps the tree of caps is refined best-first: a node's exact solid
 * angles (van Oosterom-Strackee) replace its bound until the interval
 * [K - S - B, K - S + B] (S: exact part, B: the bounds left) lies on one
 * side of the threshold. All of it happens in scaled grid space, x, y, z
 * order, so the numbers do not depend on the ray axis. */
#define CLVOX_WINDING_TIE 9.313225746154785e-10 /* 2^-30 */
/* Crossing signs: +-1 on the surface, +-2 on a cap (kernels/intersect.cl);
 * K counts them all as +-1. */
#define CLVOX_UNIT(s) ((s) > 0 ? 1 : -1)
#define CLVOX_CAP_STACK 48

/* Solid angle / 4pi of cap triangle t (9 reals, scaled x, y, z) seen from
 * p; positive when p is behind it (on the side its orientation faces away
 * from). p exactly in its plane and inside it (det == 0, den < 0) is taken
 * on the side of p + e1*u + e2*v + e3*w (e1 >> e2 >> e3 > 0), as the
 * cast's tie rules take it: det(p + e) = det(p) - e . N. */
inline clvox_real clvox_cap_solid(global const clvox_real *t, clvox_real px, clvox_real py, clvox_real pz,
                                  uint axis)
{
    const clvox_real ax = t[0] - px, ay = t[1] - py, az = t[2] - pz;
    const clvox_real bx = t[3] - px, by = t[4] - py, bz = t[5] - pz;
    const clvox_real cx = t[6] - px, cy = t[7] - py, cz = t[8] - pz;
    const clvox_real la = sqrt(ax * ax + ay * ay + az * az);
    const clvox_real lb = sqrt(bx * bx + by * by + bz * bz);
    const clvox_real lc = sqrt(cx * cx + cy * cy + cz * cz);
    const clvox_real det = ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx);
    const clvox_real den =
        la * lb * lc + (ax * bx + ay * by + az * bz) * lc + (bx * cx + by * cy + bz * cz) * la +
        (cx * ax + cy * ay + cz * az) * lb;
    if (det == 0) {
        if (!(den < 0)) return 0;
        /* N = (b - a) x (c - a), in u, v, w order */
        const clvox_real ux = bx - ax, uy = by - ay, uz = bz - az, vx = cx - ax, vy = cy - ay, vz = cz - az;
        const clvox_real n[3] = {uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx};
        const clvox_real nu = n[axis], nv = n[(axis + 1u) % 3u], nw = n[(axis + 2u) % 3u];
        const clvox_real d = nu != 0 ? -nu : nv != 0 ? -nv : -nw;
        return d > 0 ? (clvox_real)0.5 : d < 0 ? (clvox_real)-0.5 : (clvox_real)0;
    }
    return atan2(det, den) * (clvox_real)0.15915494309189535; /* 2 atan2 / 4pi */
}

/* Upper bound on |w| of the node's caps seen from any point of the box
 * [q0, q1] (a point when q0 == q1). */
inline clvox_real clvox_cap_bound_box(global const clvox_cap_node *n, const clvox_real *q0, const clvox_real *q1)
{
    clvox_real d2 = 0;
    for (uint a = 0; a < 3u; a++) {
        const clvox_real lo = n->lo[a], hi = n->hi[a];
        const clvox_real g = lo > q1[a] ? lo - q1[a] : (q0[a] > hi ? q0[a] - hi : 0);
        d2 += g * g;
    }
    const clvox_real cap = (clvox_real)n->half_count;
    if (d2 == 0) return cap;
    const clvox_real b = (clvox_real)n->area4pi / d2 * (clvox_real)1.000001;
    return b < cap ? b : cap;
}

inline clvox_real clvox_cap_bound(global const clvox_cap_node *n, clvox_real px, clvox_real py, clvox_real pz)
{
    const clvox_real q[3] = {px, py, pz};
    return clvox_cap_bound_box(n, q, q);
}

/* Inside from K alone (no caps near): w = K exactly, K >= 1 (abs: K != 0). */
inline int clvox_k_inside(int K, uint abs_mode) { return abs_mode ? K != 0 : K >= 1; }

/* Is the box [q0, q1] decided by K alone? 1 when the caps' bound over
 * it is below 1/2 - 2^-29, so that every point of it is inside exactly
 * when clvox_k_inside. Refines at most `budget` nodes. */
inline int clvox_caps_far(global const clvox_cap_node *nodes, uint node_count, const clvox_real *q0,
                          const clvox_real *q1, uint budget)
{
    if (node_count == 0) return 1;
    const clvox_real limit = (clvox_real)0.5 - (clvox_real)CLVOX_WINDING_TIE * 2;
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
        if (B * (clvox_real)1.000001 < limit) return 1;
        if (it >= budget || sp + 1u >= CLVOX_CAP_STACK) return 0;
        const uint nd = stack[best];
        if (nodes[nd].child == 0) return 0; /* a leaf's own bound is too large */
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

/* The node's caps' w seen from p as an estimate and an error bound: the
 * dipole term N . (c - p) / |c - p|^3 when p is outside the node's sphere
 * and that is tighter -- the kernel x / |x|^3 changes by at most 2 r /
 * (d - r)^3 over the sphere, so the error is at most 2 A r / (4pi (d -
 * r)^3), plus a margin for the float N -- else 0 and the zeroth-order
 * bound. */
inline void clvox_cap_estimate(global const clvox_cap_node *n, clvox_real px, clvox_real py, clvox_real pz,
                               clvox_real *est, clvox_real *err)
{
    const clvox_real b0 = clvox_cap_bound(n, px, py, pz);
    const clvox_real x = n->centre[0] - px, y = n->centre[1] - py, z = n->centre[2] - pz;
    const clvox_real d = sqrt(x * x + y * y + z * z), r = n->radius;
    if (d > r) {
        const clvox_real dr = d - r, a = n->area4pi;
        const clvox_real e1 = 2 * a * r / (dr * dr * dr) * (clvox_real)1.000001 + (clvox_real)1e-6 * a / (dr * dr);
        if (e1 < b0) {
            *est = (n->normal4pi[0] * x + n->normal4pi[1] * y + n->normal4pi[2] * z) / (d * d * d);
            *err = e1;
            return;
        }
    }
    *est = 0;
    *err = b0;
}

/* The inside test at p (scaled grid space, x, y, z) given K there:
 * best-first refinement of the cap tree, each frontier node an estimate
 * and an error bound, until [K - S - sum est -+ sum err] lies on one side
 * of the threshold (S: the caps evaluated exactly). Adds 1 to *exact when
 * cap solid angles had to be evaluated. */
inline int clvox_winding_inside_m(int K, uint abs_mode, global const clvox_cap_node *nodes, uint node_count,
                                  global const clvox_real *caps, clvox_real px, clvox_real py, clvox_real pz,
                                  uint axis, uint *exact, clvox_real *margin)
{
    const clvox_real thr = (clvox_real)0.5 + (clvox_real)CLVOX_WINDING_TIE;
    *margin = 0;
    if (node_count == 0) return abs_mode ? K != 0 : K >= 1;
    uint stack[CLVOX_CAP_STACK];
    clvox_real se[CLVOX_CAP_STACK], sb[CLVOX_CAP_STACK];
    uint sp = 1;
    stack[0] = 0;
    clvox_cap_estimate(nodes, px, py, pz, &se[0], &sb[0]);
    clvox_real S = 0;
    int evaluated = 0;
    for (;;) {
        clvox_real B = 0, E = 0;
        uint best = 0;
        for (uint i = 0; i < sp; i++) {
            B += sb[i];
            E += se[i];
            if (sb[i] > sb[best]) best = i;
        }
        B = B * (clvox_real)1.000001 + (clvox_real)1e-12; /* the sums' own rounding */
        const clvox_real w = (clvox_real)K - S - E;
        int decided = -1;
        clvox_real m = 0; /* how far w may move before the answer changes */
        if (abs_mode) {
            if (w - B > thr) decided = 1, m = w - B - thr;
            else if (w + B < -thr) decided = 1, m = -thr - (w + B);
            else if (w + B <= thr && w - B >= -thr) decided = 0, m = fmin(thr - (w + B), (w - B) + thr);
        } else {
            if (w - B > thr) decided = 1, m = w - B - thr;
            else if (w + B <= thr) decided = 0, m = thr - (w + B);
        }
        if (decided >= 0 || sp == 0) {
            if (evaluated) (*exact)++;
            *margin = m;
            if (decided >= 0) return decided;
            return abs_mode ? (w > thr || w < -thr) : w > thr;
        }
        const uint nd = stack[best];
        stack[best] = stack[sp - 1u];
        sb[best] = sb[sp - 1u];
        se[best] = se[sp - 1u];
        sp--;
        const uint child = nodes[nd].child;
        if (child == 0 || sp + 2u > CLVOX_CAP_STACK) { /* evaluate the node's caps exactly */
            const uint first = nodes[nd].tri_first, count = nodes[nd].tri_count;
            for (uint t = 0; t < count; t++)
                S += clvox_cap_solid(caps + (size_t)(first + t) * 9u, px, py, pz, axis);
            evaluated = 1;
        } else {
            for (uint c = 0; c < 2u; c++) {
                stack[sp] = child + c;
                clvox_cap_estimate(nodes + child + c, px, py, pz, &se[sp], &sb[sp]);
                sp++;
            }
        }
    }
}

inline int clvox_winding_inside(int K, uint abs_mode, global const clvox_cap_node *nodes, uint node_count,
                                global const clvox_real *caps, clvox_real px, clvox_real py, clvox_real pz,
                                uint axis, uint *exact)
{
    clvox_real m;
    return clvox_winding_inside_m(K, abs_mode, nodes, node_count, caps, px, py, pz, axis, exact, &m);
}

/* Upper bound on |grad w| over the box [q0, q1] away from the surface: w's
 * gradient is the field of the rim (the surface's boundary edges) as a
 * current loop, |grad w| <= (1/4pi) sum of length / distance^2 (rims:
 * a tree of the boundary edges, area4pi holding length / 4pi). INFINITY
 * when a rim node touches the box after `budget` refinements. */
inline clvox_real clvox_rim_gradient(global const clvox_cap_node *rims, uint rim_count, const clvox_real *q0,
                                     const clvox_real *q1, uint budget)
{
    if (rim_count == 0) return 0;
    uint stack[CLVOX_CAP_STACK];
    clvox_real sb[CLVOX_CAP_STACK];
    uint sp = 1;
    stack[0] = 0;
    for (uint it = 0;; it++) {
        clvox_real G = 0;
        uint best = 0;
        for (uint i = 0; i < sp; i++) {
            const uint nd = stack[i];
            clvox_real d2 = 0;
            for (uint a = 0; a < 3u; a++) {
                const clvox_real lo = rims[nd].lo[a], hi = rims[nd].hi[a];
                const clvox_real g = lo > q1[a] ? lo - q1[a] : (q0[a] > hi ? q0[a] - hi : 0);
                d2 += g * g;
            }
            sb[i] = d2 > 0 ? (clvox_real)rims[nd].area4pi / d2 : (clvox_real)INFINITY;
            G += sb[i];
            if (sb[i] > sb[best]) best = i;
        }
        if (isfinite(G) && (it >= budget || sp + 1u >= CLVOX_CAP_STACK)) return G * (clvox_real)1.000001;
        if (it >= budget || sp + 1u >= CLVOX_CAP_STACK) return (clvox_real)INFINITY;
        const uint nd = stack[best];
        if (rims[nd].child == 0) {
            if (!isfinite(sb[best])) return (clvox_real)INFINITY;
            return G * (clvox_real)1.000001;
        }
        stack[best] = rims[nd].child;
        stack[sp++] = rims[nd].child + 1u;
    }
}

/* Grid-space (u, v, w) of the ray method to scaled x, y, z: u is axis
 * `axis` (x-rays: u,v,w = x,y,z; y-rays y,z,x; z-rays z,x,y). */
inline void clvox_scaled_xyz(uint axis, clvox_real gu, clvox_real gv, clvox_real gw, global const clvox_real *h,
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
inline void clvox_scaled_box(uint axis, const clvox_real *g0, const clvox_real *g1, global const clvox_real *h,
                             clvox_real *q0, clvox_real *q1)
{
    clvox_scaled_xyz(axis, g0[0], g0[1], g0[2], h, &q0[0], &q0[1], &q0[2]);
    clvox_scaled_xyz(axis, g1[0], g1[1], g1[2], h, &q1[0], &q1[1], &q1[2]);
}
