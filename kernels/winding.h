/* SPDX-License-Identifier: Apache-2.0 */
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
/* The refinement's frontier: where it is full, the node it would open is
 * evaluated exactly, whole (at 48, that was most of the exact work on
 * meshes full of holes: elephant-with-holes; at 128 on b9_mesh, whose caps
 * lie near every centre: 256 took its classify from 8.6 to 5.6 s at 256^3,
 * 512 gave 6.1 s, the other open meshes the same within the noise). */
#define CLVOX_CAP_STACK 256
#define CLVOX_TIGHT 8u
#define CLVOX_TIGHT_F 0.5

/* atan2(y, x) in [-pi, pi], lane by lane, for the cap solid angles, where
 * the runtime's double atan2 was most of the winding time (PoCL: 56 % of a
 * run on a mesh with many holes). Octant reduction, then atan(r) = pi/6 +
 * atan((r sqrt3 - 1) / (r + sqrt3)) above tan(pi/12), so |r| <= 0.268, and
 * the odd series to r^27 (the first term left out is below 1e-18):
 * absolute error a few 1e-16, far inside the 2^-30 the inside test leaves
 * at w = 1/2. (0, 0) gives 0. Float devices use the builtin. */
#if defined(CLVOX_FP64)
typedef double4 clvox_real4;
typedef long4 clvox_mask4; /* comparisons of clvox_real4: -1 true, 0 false */
inline double4 clvox_atan2_4(double4 y, double4 x)
{
    const double4 ax = fabs(x), ay = fabs(y);
    const double4 mx = fmax(ax, ay), mn = fmin(ax, ay);
    const long4 ok = mx > 0.0;
    double4 t = mn / select((double4)1.0, mx, ok);
    const long4 shift = t > 0.2679491924311227;
    t = select(t, (t * 1.7320508075688772 - 1.0) / (t + 1.7320508075688772), shift);
    const double4 off = select((double4)0.0, (double4)0.5235987755982989, shift); /* pi/6 */
    const double4 t2 = t * t;
    double4 p = (double4)(-1.0 / 27);
    p = p * t2 + 1.0 / 25;
    p = p * t2 - 1.0 / 23;
    p = p * t2 + 1.0 / 21;
    p = p * t2 - 1.0 / 19;
    p = p * t2 + 1.0 / 17;
    p = p * t2 - 1.0 / 15;
    p = p * t2 + 1.0 / 13;
    p = p * t2 - 1.0 / 11;
    p = p * t2 + 1.0 / 9;
    p = p * t2 - 1.0 / 7;
    p = p * t2 + 1.0 / 5;
    p = p * t2 - 1.0 / 3;
    double4 a = off + (t + t * t2 * p);
    a = select(a, 1.5707963267948966 - a, ay > ax);
    a = select(a, 3.141592653589793 - a, x < 0.0);
    a = select(a, -a, y < 0.0);
    return select((double4)0.0, a, ok);
}
#define clvox_convert_real4 convert_double4
/* the rounding of S per complex factor or atan2, over 2pi (clvox_angles_mul) */
#define CLVOX_FACTOR_ERR 2e-16
#else
typedef float4 clvox_real4;
typedef int4 clvox_mask4;
#define clvox_atan2_4 atan2
#define clvox_convert_real4 convert_float4
#define CLVOX_FACTOR_ERR 1.5e-7f /* sqrt5 u, u = 2^-24, plus the builtin atan2's few ulp */
#endif

/* The solid angles of several cap triangles at once, four lanes (the CPU
 * devices' SIMD). Triangle t's is 2 arg(den + i det) (van Oosterom-
 * Strackee), so a sum of them is 2 arg of the product of the factors den +
 * i det, plus 2pi for each time the partial product's argument wraps past
 * pi: each lane multiplies its triangles' factors, and one atan2 per lane
 * ends a node or a reused cut, not one per triangle. Wraps are counted
 * from the signs of the imaginary parts: with arg z, arg f in (-pi, pi],
 * the true sum arg z + arg f is above pi exactly when both lie in (0, pi]
 * and the product does not, below -pi exactly when both are negative and
 * the product's lies in (0, pi]. Where the rounded product's sign is
 * ambiguous (sum near +-pi) the wrap and the final atan2 see the same
 * rounded number and agree; near 0 and +-2pi the imaginary part is a sum
 * of two products of one sign, so its sign is exact. Error: each product
 * is z f (1 + eta), |eta| <= sqrt5 u (Brent, Percival, Zimmermann 2007; no
 * contraction), which moves its argument by at most 1.0001 |eta| < 2.5e-16
 * per factor in double; rescaling by powers of two is exact (it keeps the
 * products away from under- and overflow). A point exactly in a cap's
 * plane and inside it (det == 0, den < 0) is taken on the side of p +
 * e1*u + e2*v + e3*w (e1 >> e2 >> e3 > 0), as the cast's tie rules take
 * it -- det(p + e) = det(p) - e . N -- and adds +-1/2 to `halves`, not a
 * factor. */
typedef struct clvox_angles {
    clvox_real4 re, im; /* the lanes' products */
    clvox_mask4 k;      /* the lanes' wraps: the sum is arg(re + i im) + 2pi k */
    clvox_real halves;  /* the in-plane halves */
    uint n;             /* factors (for the error bound) */
} clvox_angles;

inline void clvox_angles_init(clvox_angles *a)
{
    a->re = (clvox_real4)1;
    a->im = (clvox_real4)0;
    a->k = (clvox_mask4)0;
    a->halves = 0;
    a->n = 0;
}

/* a *= den + i det lane by lane, counting the wraps (den = 1, det = 0:
 * unchanged, exactly). */
inline void clvox_angles_mul(clvox_angles *a, clvox_real4 den, clvox_real4 det)
{
    const clvox_real4 zr = a->re, zi = a->im;
    clvox_real4 re = zr * den - zi * det, im = zr * det + zi * den;
    const clvox_real4 zero = (clvox_real4)0;
    const clvox_mask4 up = (zi > zero) | ((zi == zero) & (zr < zero));
    const clvox_mask4 up2 = (im > zero) | ((im == zero) & (re < zero));
    a->k -= (det > zero) & up & ~up2; /* true is -1 */
    a->k += (det < zero) & (zi < zero) & up2;
    const clvox_real4 m = fmax(fabs(re), fabs(im));
#if defined(CLVOX_FP64)
    const clvox_real big = 0x1p200, small = 0x1p-200;
#else
    const clvox_real big = 0x1p40f, small = 0x1p-40f;
#endif
    if (any((m > big) | (m < small))) { /* exact: powers of two */
        const int4 e = select(ilogb(m), (int4)0, convert_int4(m == zero)); /* 0: no factor makes it */
        re = ldexp(re, -e);
        im = ldexp(im, -e);
    }
    a->re = re;
    a->im = im;
}

/* The tie rule of cap triangle t seen from p when det == 0: +-1/2 when p
 * is inside it (den < 0), the side of p + e (above). The same arithmetic
 * as clvox_cap_angles4. */
inline clvox_real clvox_cap_tie(global const clvox_real *t, clvox_real px, clvox_real py, clvox_real pz,
                                clvox_real den, uint axis)
{
    if (!(den < 0)) return 0;
    const clvox_real ax = t[0] - px, ay = t[1] - py, az = t[2] - pz;
    const clvox_real bx = t[3] - px, by = t[4] - py, bz = t[5] - pz;
    const clvox_real cx = t[6] - px, cy = t[7] - py, cz = t[8] - pz;
    /* N = (b - a) x (c - a), in u, v, w order */
    const clvox_real ux = bx - ax, uy = by - ay, uz = bz - az, vx = cx - ax, vy = cy - ay, vz = cz - az;
    const clvox_real n[3] = {uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx};
    const clvox_real nu = n[axis], nv = n[(axis + 1u) % 3u], nw = n[(axis + 2u) % 3u];
    const clvox_real d = nu != 0 ? -nu : nv != 0 ? -nv : -nw;
    return d > 0 ? (clvox_real)0.5 : d < 0 ? (clvox_real)-0.5 : (clvox_real)0;
}

/* Multiplies in the cap triangles with corners a, b, c (lane by lane, in
 * p's frame: corner - p) seen from p, one per lane: positive when p is
 * behind a triangle (on the side its orientation faces away from). Lanes
 * past `count` multiply by 1; t: the triangles as 9 reals each (scaled x,
 * y, z), for the tie rule. */
inline void clvox_cap_angles4_v(clvox_real4 ax, clvox_real4 ay, clvox_real4 az, clvox_real4 bx, clvox_real4 by,
                                clvox_real4 bz, clvox_real4 cx, clvox_real4 cy, clvox_real4 cz,
                                global const clvox_real *t, uint count, clvox_real px, clvox_real py, clvox_real pz,
                                uint axis, clvox_angles *a)
{
    const clvox_real4 la = sqrt(ax * ax + ay * ay + az * az);
    const clvox_real4 lb = sqrt(bx * bx + by * by + bz * bz);
    const clvox_real4 lc = sqrt(cx * cx + cy * cy + cz * cz);
    clvox_real4 det = ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx);
    clvox_real4 den = la * lb * lc + (ax * bx + ay * by + az * bz) * lc + (bx * cx + by * cy + bz * cz) * la +
                      (cx * ax + cy * ay + cz * az) * lb;
    const clvox_real4 zero = (clvox_real4)0;
    const clvox_mask4 lane = (clvox_mask4)(0, 1, 2, 3) < (clvox_mask4)count;
    const clvox_mask4 flat = lane & (det == zero);
    if (any(flat)) { /* rare: the tie rule, lane by lane */
        clvox_real dv[4];
        vstore4(den, 0, dv);
        for (uint i = 0; i < count; i++)
            if (flat[i]) a->halves += clvox_cap_tie(t + i * 9u, px, py, pz, dv[i], axis);
    }
    const clvox_mask4 skip = ~lane | (det == zero) | isnan(det) | isnan(den); /* NaN: as atan2's 0 */
    den = select(den, (clvox_real4)1, skip);
    det = select(det, zero, skip);
    clvox_angles_mul(a, den, det);
    a->n += count;
}

/* Multiplies in cap triangles t .. t + count - 1 (count 1 .. 4; 9 reals
 * each, scaled x, y, z) seen from p, one per lane. Lanes past `count`
 * repeat triangle 0 and multiply by 1. */
inline void clvox_cap_angles4(global const clvox_real *t, uint count, clvox_real px, clvox_real py, clvox_real pz,
                              uint axis, clvox_angles *a)
{
    const uint i1 = count > 1u ? 9u : 0u, i2 = count > 2u ? 18u : 0u, i3 = count > 3u ? 27u : 0u;
#define CLVOX_G4(k, p) ((clvox_real4)(t[k], t[i1 + (k)], t[i2 + (k)], t[i3 + (k)]) - (p))
    clvox_cap_angles4_v(CLVOX_G4(0, px), CLVOX_G4(1, py), CLVOX_G4(2, pz), CLVOX_G4(3, px), CLVOX_G4(4, py),
                        CLVOX_G4(5, pz), CLVOX_G4(6, px), CLVOX_G4(7, py), CLVOX_G4(8, pz), t, count, px, py, pz,
                        axis, a);
#undef CLVOX_G4
}

/* The same for a leaf's lane-major copy (clvox_cap_node.block): real k of
 * lane l at blk[4k + l], the same numbers, one vector load each. */
inline void clvox_cap_block4(global const clvox_real *blk, global const clvox_real *t, uint count, clvox_real px,
                             clvox_real py, clvox_real pz, uint axis, clvox_angles *a)
{
    clvox_cap_angles4_v(vload4(0, blk) - px, vload4(1, blk) - py, vload4(2, blk) - pz, vload4(3, blk) - px,
                        vload4(4, blk) - py, vload4(5, blk) - pz, vload4(6, blk) - px, vload4(7, blk) - py,
                        vload4(8, blk) - pz, t, count, px, py, pz, axis, a);
}

/* The solid angle / 4pi of everything multiplied in: the lanes' (arg + 2pi
 * k) / 2pi, summed. */
inline clvox_real clvox_angles_value(const clvox_angles *a)
{
    const clvox_real4 v =
        clvox_atan2_4(a->im, a->re) * (clvox_real)0.15915494309189535 + clvox_convert_real4(a->k);
    return (v.s0 + v.s1) + (v.s2 + v.s3) + a->halves;
}

/* Squared distance between the node's box and the box [q0, q1] (0 when
 * they meet); the cap tree's and the rim tree's bounds both start from it. */
inline clvox_real clvox_node_box_d2(global const clvox_cap_node *n, const clvox_real *q0, const clvox_real *q1)
{
    clvox_real d2 = 0;
    for (uint a = 0; a < 3u; a++) {
        const clvox_real lo = n->lo[a], hi = n->hi[a];
        const clvox_real g = lo > q1[a] ? lo - q1[a] : (q0[a] > hi ? q0[a] - hi : 0);
        d2 += g * g;
    }
    return d2;
}

/* Upper bound on |w| of the node's caps seen from any point of the box
 * [q0, q1] (a point when q0 == q1). */
inline clvox_real clvox_cap_bound_box(global const clvox_cap_node *n, const clvox_real *q0, const clvox_real *q1)
{
    const clvox_real d2 = clvox_node_box_d2(n, q0, q1);
    const clvox_real cap = (clvox_real)n->half_count;
    if (d2 == 0) return cap;
    const clvox_real b = (clvox_real)n->area4pi / d2 * (clvox_real)1.000001;
    return b < cap ? b : cap;
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
inline void clvox_cap_estimate4(global const clvox_cap_node *k, global const clvox_cap_node *l,
                                global const clvox_cap_node *m, global const clvox_cap_node *n, clvox_real px,
                                clvox_real py, clvox_real pz, clvox_real *est, clvox_real *err)
{
#define CLVOX_N4(f) ((clvox_real4)(k->f, l->f, m->f, n->f))
    const clvox_real4 zero = (clvox_real4)0;
    const clvox_real4 gx = fmax(fmax(CLVOX_N4(lo[0]) - px, px - CLVOX_N4(hi[0])), zero);
    const clvox_real4 gy = fmax(fmax(CLVOX_N4(lo[1]) - py, py - CLVOX_N4(hi[1])), zero);
    const clvox_real4 gz = fmax(fmax(CLVOX_N4(lo[2]) - pz, pz - CLVOX_N4(hi[2])), zero);
    const clvox_real4 db2 = gx * gx + gy * gy + gz * gz;
    const clvox_real4 a = CLVOX_N4(area4pi), cap = CLVOX_N4(half_count);
    const clvox_real4 bb = a / db2 * (clvox_real)1.000001;
    const clvox_real4 b0 = select(select(cap, bb, bb < cap), cap, db2 == zero);
    const clvox_real4 x = CLVOX_N4(centre[0]) - px, y = CLVOX_N4(centre[1]) - py, z = CLVOX_N4(centre[2]) - pz;
    const clvox_real4 r = CLVOX_N4(radius);
    const clvox_real4 d2 = x * x + y * y + z * z, d = sqrt(d2);
    const clvox_real4 dm = d * (1 - (clvox_real)CLVOX_EST_DREL) - r;
    const clvox_real4 idr = (clvox_real)1 / dm, idr2 = idr * idr;
    const clvox_real4 e1 = a * idr2 * ((2 * r) * idr * (clvox_real)CLVOX_EST_ROUND + (clvox_real)CLVOX_EST_M0);
    const clvox_real4 e2 = (3 * CLVOX_N4(second4pi)) * (idr2 * idr2) * (clvox_real)CLVOX_EST_ROUND +
                           a * idr2 * ((clvox_real)CLVOX_EST_M0 + (clvox_real)CLVOX_EST_M1 * r * idr);
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
inline void clvox_cap_estimate(global const clvox_cap_node *n, clvox_real px, clvox_real py, clvox_real pz,
                               clvox_real *est, clvox_real *err)
{
    clvox_real e[4], b[4];
    clvox_cap_estimate4(n, n, n, n, px, py, pz, e, b);
    *est = e[0];
    *err = b[0];
}

/* The same for two nodes (a node's children): lanes 2 and 3 repeat them
 * (on the CPU devices a vector of four doubles costs what one of two does). */
inline void clvox_cap_estimate2(global const clvox_cap_node *m, global const clvox_cap_node *n, clvox_real px,
                                clvox_real py, clvox_real pz, clvox_real *est, clvox_real *err)
{
    clvox_real e[4], b[4];
    clvox_cap_estimate4(m, n, m, n, px, py, pz, e, b);
    est[0] = e[0];
    est[1] = e[1];
    err[0] = b[0];
    err[1] = b[1];
}

/* Inside (1), outside (0) or undecided (-1) for every w in [lo, hi]. */
inline int clvox_interval_inside(clvox_real lo, clvox_real hi, uint abs_mode)
{
    const clvox_real thr = (clvox_real)0.5 + (clvox_real)CLVOX_WINDING_TIE;
    if (lo > thr) return 1;
    if (abs_mode) {
        if (hi < -thr) return 1;
        return hi <= thr && lo >= -thr ? 0 : -1;
    }
    return hi <= thr ? 0 : -1;
}

/* A cut of the cap tree kept from one point to the next along a ray
 * (clvox_winding_inside_m): node ids, CLVOX_CUT_EXACT on those evaluated
 * exactly. Any cut (frontier + exact nodes covering every leaf once) is a
 * valid start; a neighbour's saves most of the descent. */
#define CLVOX_CUT_MAX 384 /* above the frontier's CLVOX_CAP_STACK: a cut holds it and the exact nodes */
#define CLVOX_CUT_EXACT 0x80000000u

/* Multiplies the node's caps into a. */
inline void clvox_cap_node_angles(global const clvox_cap_node *nd, global const clvox_real *caps, clvox_real px,
                                  clvox_real py, clvox_real pz, uint axis, clvox_angles *a)
{
    const uint first = nd->tri_first, count = nd->tri_count;
    if (nd->block) { /* a leaf (at most 4 caps) */
        clvox_cap_block4(caps + nd->block, caps + (size_t)first * 9u, count, px, py, pz, axis, a);
        return;
    }
    for (uint t = 0; t < count; t += 4u)
        clvox_cap_angles4(caps + (size_t)(first + t) * 9u, min(count - t, 4u), px, py, pz, axis, a);
}

/* The node's caps' solid angles / 4pi at p, exactly. */
inline clvox_real clvox_cap_node_exact(global const clvox_cap_node *nd, global const clvox_real *caps, clvox_real px,
                                       clvox_real py, clvox_real pz, uint axis, uint *factors)
{
    clvox_angles a;
    clvox_angles_init(&a);
    clvox_cap_node_angles(nd, caps, px, py, pz, axis, &a);
    *factors += a.n + 4u;
    return clvox_angles_value(&a);
}

/* The inside test at p (scaled grid space, x, y, z) given K there:
 * best-first refinement of the cap tree, each frontier node an estimate
 * and an error bound, until [K - S - sum est -+ sum err] lies on one side
 * of the threshold (S: the caps evaluated exactly). Adds 1 to *exact when
 * cap solid angles had to be evaluated; [*wlo, *whi] holds w. With `tight`
 * the refinement goes on past the decision (at most `tight` steps) until
 * the error bound is at most CLVOX_TIGHT_F of w's distance from the
 * threshold, so that the caller can reuse the interval nearby. cut (may be
 * 0): in, a cut to start from (*cut_n entries; 0: the root); out, this
 * point's (*cut_n = 0 when it does not fit). */
inline int clvox_winding_inside_m(int K, uint abs_mode, global const clvox_cap_node *nodes, uint node_count,
                                  global const clvox_real *caps, clvox_real px, clvox_real py, clvox_real pz,
                                  uint axis, uint tight, uint *exact, clvox_real *wlo, clvox_real *whi, uint *cut,
                                  uint *cut_n)
{
    const clvox_real thr = (clvox_real)0.5 + (clvox_real)CLVOX_WINDING_TIE;
    *wlo = *whi = (clvox_real)K;
    if (node_count == 0) return abs_mode ? K != 0 : K >= 1;
    uint stack[CLVOX_CAP_STACK];
    clvox_real se[CLVOX_CAP_STACK], sb[CLVOX_CAP_STACK];
    uint ex[CLVOX_CUT_MAX];
    uint sp = 0, nex = 0;
    clvox_real S = 0;
    uint factors = 0; /* factors and atan2s behind S (its error bound) */
    int evaluated = 0, answer = -1, lost = 0; /* lost: the exact nodes do not fit ex */
    if (cut && *cut_n) {
        clvox_angles all; /* the cut's exact nodes: one product, one atan2 */
        clvox_angles_init(&all);
        for (uint i = 0; i < *cut_n; i++) {
            const uint nd = cut[i] & ~CLVOX_CUT_EXACT;
            if (cut[i] & CLVOX_CUT_EXACT) {
                clvox_cap_node_angles(nodes + nd, caps, px, py, pz, axis, &all);
                ex[nex++] = nd;
                evaluated = 1;
            } else {
                stack[sp++] = nd;
            }
        }
        uint i = 0; /* the frontier's estimates, four or two at a time */
        for (; i + 3u < sp; i += 4u)
            clvox_cap_estimate4(nodes + stack[i], nodes + stack[i + 1u], nodes + stack[i + 2u], nodes + stack[i + 3u],
                                px, py, pz, se + i, sb + i);
        for (; i + 1u < sp; i += 2u)
            clvox_cap_estimate2(nodes + stack[i], nodes + stack[i + 1u], px, py, pz, se + i, sb + i);
        if (i < sp) clvox_cap_estimate(nodes + stack[i], px, py, pz, &se[i], &sb[i]);
        S = clvox_angles_value(&all);
        factors = all.n + 4u;
    } else {
        stack[sp] = 0;
        clvox_cap_estimate(nodes, px, py, pz, &se[sp], &sb[sp]);
        sp++;
    }
    uint extra = 0;
    /* Running sums of the frontier's bounds and estimates pick the steps
     * at which to look: only where they decide (or once decided, in the
     * tight phase) are the sums taken afresh, in frontier order, and it is
     * those that decide and bound w. The running ones drift by their
     * subtractions, which can only cost a step or a fresh sum, never the
     * rigour of the answer. */
    clvox_real Br = 0, Er = 0;
    for (uint i = 0; i < sp; i++) {
        Br += sb[i];
        Er += se[i];
    }
    for (;;) {
        uint best = 0;
        clvox_real bv = sb[0]; /* the first largest bound (sp == 0: unused) */
        for (uint i = 1; i < sp; i++) {
            const int gt = sb[i] > bv;
            best = gt ? i : best;
            bv = gt ? sb[i] : bv;
        }
        /* the sums' own rounding, and S's: CLVOX_FACTOR_ERR per factor
         * (clvox_angles_mul) and per atan2 */
        const clvox_real slack = (clvox_real)1e-12 + (clvox_real)factors * (clvox_real)CLVOX_FACTOR_ERR;
        const clvox_real wr = (clvox_real)K - S - Er, Bq = Br * (clvox_real)1.000001 + slack;
        /* decided: the tight phase ends after `tight` steps, or where the
         * bound is within CLVOX_TIGHT_F of w's distance from the threshold */
        int last = 0, look;
        if (answer >= 0) {
            last = extra++ >= tight;
            const clvox_real dr = abs_mode ? fmin(fabs(wr - thr), fabs(wr + thr)) : fabs(wr - thr);
            look = sp == 0 || last || Bq <= (clvox_real)CLVOX_TIGHT_F * dr;
        } else {
            look = sp == 0 || clvox_interval_inside(wr - Bq, wr + Bq, abs_mode) >= 0;
        }
        if (look) {
            clvox_real B = 0, E = 0;
            for (uint i = 0; i < sp; i++) {
                B += sb[i];
                E += se[i];
            }
            Br = B;
            Er = E;
            B = B * (clvox_real)1.000001 + slack;
            const clvox_real w = (clvox_real)K - S - E;
            if (answer < 0) {
                answer = clvox_interval_inside(w - B, w + B, abs_mode);
                if (answer >= 0) last = extra++ >= tight;
            }
            const clvox_real dist = abs_mode ? fmin(fabs(w - thr), fabs(w + thr)) : fabs(w - thr);
            if (sp == 0 || (answer >= 0 && (last || B <= (clvox_real)CLVOX_TIGHT_F * dist))) {
                if (evaluated) (*exact)++;
                *wlo = w - B;
                *whi = w + B; /* w lies in [w - B, w + B] */
                if (cut) {
                    if (lost || sp + nex > CLVOX_CUT_MAX) {
                        *cut_n = 0;
                    } else {
                        for (uint i = 0; i < sp; i++) cut[i] = stack[i];
                        for (uint i = 0; i < nex; i++) cut[sp + i] = ex[i] | CLVOX_CUT_EXACT;
                        *cut_n = sp + nex;
                    }
                }
                if (answer >= 0) return answer;
                return abs_mode ? (w > thr || w < -thr) : w > thr;
            }
        }
        Br -= sb[best];
        Er -= se[best];
        const uint nd = stack[best];
        stack[best] = stack[sp - 1u];
        sb[best] = sb[sp - 1u];
        se[best] = se[sp - 1u];
        sp--;
        const uint child = nodes[nd].child;
        if (child == 0 || sp + 2u > CLVOX_CAP_STACK) { /* evaluate the node's caps exactly */
            S += clvox_cap_node_exact(nodes + nd, caps, px, py, pz, axis, &factors);
            evaluated = 1;
            if (nex < CLVOX_CUT_MAX) ex[nex++] = nd;
            else lost = 1;
        } else {
            stack[sp] = child;
            stack[sp + 1u] = child + 1u;
            clvox_cap_estimate2(nodes + child, nodes + child + 1u, px, py, pz, se + sp, sb + sp);
            Br += sb[sp] + sb[sp + 1u];
            Er += se[sp] + se[sp + 1u];
            sp += 2u;
        }
    }
}

inline int clvox_winding_inside(int K, uint abs_mode, global const clvox_cap_node *nodes, uint node_count,
                                global const clvox_real *caps, clvox_real px, clvox_real py, clvox_real pz,
                                uint axis, uint *exact)
{
    clvox_real lo, hi;
    return clvox_winding_inside_m(K, abs_mode, nodes, node_count, caps, px, py, pz, axis, 0u, exact, &lo, &hi, 0, 0);
}

/* Lower bound on the distance between the segments [p0, p1] and [a, b]
 * (closest points as in Ericson, Real-Time Collision Detection 5.1.9, then
 * shrunk by more than their rounding); 0 when they may touch. */
inline clvox_real clvox_segment_distance(const clvox_real *p0, const clvox_real *p1, global const clvox_real *a,
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
inline clvox_real clvox_rim_leaf_bound(global const clvox_cap_node *nd, global const clvox_real *edges,
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
inline clvox_real clvox_rim_box_bound(global const clvox_cap_node *nd, const clvox_real *q0, const clvox_real *q1,
                                      uint axis)
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
inline clvox_real clvox_rim_bound(global const clvox_cap_node *rims, uint rim_count, global const clvox_real *edges,
                                  const clvox_real *q0, const clvox_real *q1, uint axis, uint budget)
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
            return G * (clvox_real)1.000001;
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
