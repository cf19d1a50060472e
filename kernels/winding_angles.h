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
 * order, so the numbers do not depend on the ray axis.
 *
 * In four files, concatenated in this order (Makefile KERNEL_FILES):
 * winding_angles.h (this one: the constants, the caps' exact solid angles),
 * winding_bounds.h (bounds on the caps' w far from them, the node
 * estimates), winding_inside.h (the inside test: best-first refinement of
 * the cap tree) and winding_rims.h (the rim tree's bound along a ray, grid
 * to scaled coordinates). */
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
/* The winding functions' `axis` (0, 1, 2: the tie rule's first axis) may
 * carry flags. CLVOX_EXACT_SIGNS: p's grid coordinates g (x, y, z) and the
 * caps' (gcaps: clvox__caps.grid, 9 floats a triangle in the caps' order)
 * are given, so a cap's orientation at p and its normal's components get
 * their exact signs (kernels/overlap.h, on the grid's floats): those of the
 * world, which a positive scale per axis keeps, and those the cast takes
 * (kernels/intersect.cl), so that w_caps steps by one exactly where K does.
 * CLVOX_CUBIC: the voxels are cubes and the scaled coordinates are the
 * grid's floats times 2^-k, exactly (src/winding/winding.c
 * clvox__winding_scale; the scale buffer's h[3] != 0); else they are
 * rounded, and the factors' bounds take that in (clvox_cap_angles4_v). */
#define CLVOX_AXIS_OF(a) ((a) & 3u)
#define CLVOX_EXACT_SIGNS 4u
#define CLVOX_CUBIC 8u
#define CLVOX_AXIS_FLAGS(h3) (CLVOX_EXACT_SIGNS | ((h3) != 0 ? CLVOX_CUBIC : 0u))
/* Grid coordinates (u, v, w along the ray's axes) in x, y, z order. */
static inline void clvox_grid_xyz(uint axis, clvox_real gu, clvox_real gv, clvox_real gw, clvox_real *g)
{
    g[axis] = gu;
    g[(axis + 1u) % 3u] = gv;
    g[(axis + 2u) % 3u] = gw;
}
/* A bound on the rounding of a cap factor den + i det (below): |d den| +
 * |d det| <= CLVOX_FACTOR_DELTA * la lb lc, 128 u (u the unit roundoff),
 * counted with the corners' differences from p rounded (u each): the
 * lengths (squares, sums and a 3-ulp sqrt: 5.5 u each, their product 18.5
 * u), the three dot-product terms (5 u of sum |a_i b_i| <= la lb, times a
 * length: 11.5 u of L = la lb lc each), den's three sums (3 u of 4 L): 65 u
 * of L; det, 8 u of its permanent, which is at most |a|_1 |b|_1 |c|_1 <=
 * 3^1.5 L: 42 u of L. */
#if defined(CLVOX_FP64)
#define CLVOX_REAL_U 1.1102230246251565e-16 /* 2^-53 */
#else
#define CLVOX_REAL_U 5.9604644775390625e-8f /* 2^-24 */
#endif
#define CLVOX_FACTOR_DELTA (128 * CLVOX_REAL_U)
/* On voxels that are not cubes the scaled coordinates are rounded: a
 * float device's point p (the grid's coordinates times the float scale,
 * rounded) lies within this of the double kernels' (times the double
 * scale, rounded): u |p| for its own rounding, u |p| for the scale's, and
 * the double's 2^-53 |p|, in the 1-norm, which bounds the 2-norm. 0 on
 * cubic voxels (CLVOX_CUBIC: both exact) and in double. */
static inline clvox_real clvox_point_rounding(clvox_real px, clvox_real py, clvox_real pz, uint axis)
{
#if defined(CLVOX_FP64)
    (void)px, (void)py, (void)pz, (void)axis;
    return 0;
#else
    return (axis & CLVOX_CUBIC) ? 0 : (clvox_real)2.5f * CLVOX_REAL_U * (fabs(px) + fabs(py) + fabs(pz));
#endif
}
/* The sums of up to CLVOX_CAP_STACK (+ a few) bounds, rounded: a relative
 * error below (n + 8) u. */
#if defined(CLVOX_FP64)
#define CLVOX_SUM_ROUND 1.000001
#else
#define CLVOX_SUM_ROUND 1.00002f
#endif
/* An error bound that decides nothing (in w units). */
#define CLVOX_ERR_UNBOUNDED 4
/* Set on an inside test's result (clvox_winding_inside_m) that the float
 * build could not certify: the host decides that point in double. */
#define CLVOX_UNSURE 2

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
static inline double4 clvox_atan2_4(double4 y, double4 x)
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
/* The builtin atan2's error (6 ulp of pi: OpenCL 1.2, 7.4) over 2pi. */
#define CLVOX_ATAN2_ERR 2.5e-7f
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
#if !defined(CLVOX_FP64)
    clvox_real4 err;    /* float: the lanes' argument errors (radians), clvox_cap_angles4_v */
#endif
} clvox_angles;

static inline void clvox_angles_init(clvox_angles *a)
{
    a->re = (clvox_real4)1;
    a->im = (clvox_real4)0;
    a->k = (clvox_mask4)0;
    a->halves = 0;
    a->n = 0;
#if !defined(CLVOX_FP64)
    a->err = (clvox_real4)0;
#endif
}

/* a *= den + i det lane by lane, counting the wraps (den = 1, det = 0:
 * unchanged, exactly). */
static inline void clvox_angles_mul(clvox_angles *a, clvox_real4 den, clvox_real4 det)
{
    const clvox_real4 zr = a->re, zi = a->im;
    clvox_real4 re = zr * den - zi * det, im = zr * det + zi * den;
    const clvox_real4 zero = (clvox_real4)0;
    const clvox_mask4 up = (zi > zero) | ((zi == zero) & (zr < zero));
    const clvox_mask4 up2 = (im > zero) | ((im == zero) & (re < zero));
    /* Vector comparisons only as select's masks, combined with & and |:
     * never as numbers ("k -= mask", true being -1) nor negated with ~
     * (select with the operands swapped instead). Both become operations
     * on vectors of i1 that Oclgrind 21.10 gets wrong (~mask was all true:
     * every cap factor skipped, an open cube at 16^3 lost 36 voxels), the
     * kind of idiom vendor compilers get wrong too. */
    const clvox_mask4 none = (clvox_mask4)0, one = (clvox_mask4)1;
    a->k += select(none, select(one, none, up2), (det > zero) & up); /* up, not up2 */
    a->k -= select(none, one, (det < zero) & (zi < zero) & up2);
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

/* The tie rule of cap triangle t (gt in grid space) seen from p when det
 * == 0: +-1/2 when p is inside it (den < 0), the side of p + e (above).
 * Without exact signs the same arithmetic as clvox_cap_angles4. */
static inline clvox_real clvox_cap_tie(global const clvox_real *t, global const float *gt, clvox_real px,
                                       clvox_real py, clvox_real pz, clvox_real den, uint axis)
{
    if (!(den < 0)) return 0;
    if (axis & CLVOX_EXACT_SIGNS) { /* the normal's signs exactly: N_i = e2 over axes i + 1, i + 2 */
        const uint a0 = CLVOX_AXIS_OF(axis);
        int d = 0;
        for (uint k = 0; k < 3u && d == 0; k++) {
            const uint i = (a0 + k) % 3u, s = (i + 1u) % 3u, r = (i + 2u) % 3u;
            d = -clvox_e2_sign(gt[s], gt[r], gt[3 + s], gt[3 + r], gt[s], gt[r], gt[6 + s], gt[6 + r]);
        }
        return d > 0 ? (clvox_real)0.5 : d < 0 ? (clvox_real)-0.5 : (clvox_real)0;
    }
    axis = CLVOX_AXIS_OF(axis);
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

/* clvox_cap_angles4_v's rare path (inline: out of line, PoCL's double
 * classify on holes was 2 % slower still): lanes i < count whose det (tv)
 * and den (nv) are both within their error bv of 0 get det's exact sign,
 * -orient3d(A, B, C, p) on the grid's floats (gt, g): 0 in the plane, a
 * wrong sign replaced by a small value of the right one, fv[i] = 2 (its
 * error within 2 bv), else 1. */
static inline void clvox_det_signs(global const float *gt, uint count, const clvox_real *g, clvox_real *tv,
                                   const clvox_real *bv, const clvox_real *nv, clvox_real *fv)
{
    for (uint i = 0; i < 4u; i++) fv[i] = 1;
    for (uint i = 0; i < count; i++) {
        if (!(fabs(tv[i]) <= bv[i] && nv[i] <= bv[i])) continue;
        clvox_real v[9];
        for (uint c = 0; c < 9u; c++) v[c] = gt[i * 9u + c];
        const int sg = -clvox_o3_sign(v, g[0], g[1], g[2]);
        if (sg != 0 && tv[i] * (clvox_real)sg > 0) continue;
        tv[i] = (clvox_real)sg * bv[i] * (clvox_real)0x1p-10;
        fv[i] = 2;
    }
}

/* Multiplies in the cap triangles with corners a, b, c (lane by lane, in
 * p's frame: corner - p) seen from p, one per lane: positive when p is
 * behind a triangle (on the side its orientation faces away from). Lanes
 * past `count` multiply by 1; t: the triangles as 9 reals each (scaled x,
 * y, z), gt the same in grid space and g p's grid coordinates (with
 * CLVOX_EXACT_SIGNS), for the exact signs and the tie rule. */
static inline void clvox_cap_angles4_v(clvox_real4 ax, clvox_real4 ay, clvox_real4 az, clvox_real4 bx, clvox_real4 by,
                                       clvox_real4 bz, clvox_real4 cx, clvox_real4 cy, clvox_real4 cz,
                                       global const clvox_real *t, global const float *gt, const clvox_real *g,
                                       uint count, clvox_real px, clvox_real py, clvox_real pz, uint axis,
                                       clvox_angles *a)
{
    const clvox_real4 la = sqrt(ax * ax + ay * ay + az * az);
    const clvox_real4 lb = sqrt(bx * bx + by * by + bz * bz);
    const clvox_real4 lc = sqrt(cx * cx + cy * cy + cz * cz);
    clvox_real4 det = ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx);
    const clvox_real4 L = la * lb * lc;
    clvox_real4 den = L + (ax * bx + ay * by + az * bz) * lc + (bx * cx + by * cy + bz * cz) * la +
                      (cx * ax + cy * ay + cz * az) * lb;
    const clvox_real4 zero = (clvox_real4)0;
    const clvox_mask4 lane = (clvox_mask4)(0, 1, 2, 3) < (clvox_mask4)count;
    const clvox_mask4 past = (clvox_mask4)(0, 1, 2, 3) >= (clvox_mask4)count; /* not ~lane: clvox_angles_mul */
    const clvox_real4 delta = (clvox_real)CLVOX_FACTOR_DELTA * L; /* |d den| + |d det| */
    /* The factor's error dl: delta on cubic voxels. On voxels that are not
     * cubes the corners and p are rounded from the grid's floats times the
     * scale (in double; a float device's are the double's rounded again,
     * clvox_point_rounding), so each difference a is off by eta_a <= u (1.1
     * |a|_1 + 3.5 |p|_1) in the 2-norm besides its own rounding. den and det
     * move by at most 5 (eta_a lb lc + eta_b la lc + eta_c la lb) to first
     * order (|grad_a den| <= 4 lb lc: the gradients of la lb lc, (a.b) lc,
     * (b.c) la and (c.a) lb, each at most lb lc; |grad_a det| = |b x c| <=
     * lb lc), 5.5 with the higher orders while every eta is at most 1/100 of
     * its length (float: else nothing is bounded). With |a|_1 <= sqrt3 la:
     * 5.5 * 1.1 * sqrt3 * 3 < 32 u L, and 5.5 * 3.5 < 19.5 u |p|_1 times
     * lb lc + la lc + la lb (the lengths' own rounding, a few u, is far
     * inside these constants' slack). */
    clvox_real4 dl = delta;
    clvox_mask4 lost = (clvox_mask4)0;
    if (!(axis & CLVOX_CUBIC)) {
        const clvox_real pn = fabs(px) + fabs(py) + fabs(pz);
        dl = (clvox_real)(160 * CLVOX_REAL_U) * L +
             (clvox_real)(19.5f * CLVOX_REAL_U) * pn * (lb * lc + la * (lb + lc));
        /* eta_a > la / 100 (la < 100 u (1.1 sqrt3 la + 3.5 pn)): la < 351 u pn, as 360 */
        const clvox_real lmin = (clvox_real)(360 * CLVOX_REAL_U) * pn;
        lost = (la < lmin) | (lb < lmin) | (lc < lmin);
    }
    clvox_real4 dfac = (clvox_real4)1; /* the factor's error: dl, or 2 dl where det's sign was replaced */
    /* (lanes past count repeat triangle 0: clvox_det_signs looks at i < count only) */
    if (axis & CLVOX_EXACT_SIGNS) {
        if (any(fmax(fabs(det), den) <= dl)) {
            /* rare (p within about 128 u of the cap's plane, and den not
             * surely positive: where it is, f and its rounding lie in the
             * right half-plane and det's sign moves arg f by no more than
             * its bound below): det's sign exactly, and 0 when p lies in
             * the plane; a det of the wrong sign becomes a small one of the
             * right sign, within 2 dl of the true det (its error bound
             * below). Not for slivers seen from afar (den about 4 L): their
             * det is small, and its exact sign would cost (cylinder's rim
             * caps, 256^3: 4x the classify). */
            clvox_real tv[4], bv[4], nv[4], fv[4];
            vstore4(det, 0, tv);
            vstore4(dl, 0, bv);
            vstore4(den, 0, nv);
            clvox_det_signs(gt, count, g, tv, bv, nv, fv);
            det = vload4(0, tv);
            dfac = vload4(0, fv);
        }
    } else {
        /* no exact signs (the probe kernel only): a det within dl of 0
         * where den is not surely positive may lie across the cut, and a
         * flat lane's tie may be wrong -- both unbounded */
        lost |= (fabs(det) <= dl) & (den <= dl);
    }
    const clvox_mask4 flat = lane & (det == zero);
    if (any(flat)) { /* rare: the tie rule, lane by lane (arrays: no run-time vector subscript) */
        clvox_real dv[4], tv[4];
        vstore4(den, 0, dv);
        vstore4(det, 0, tv);
        for (uint i = 0; i < count; i++)
            if (tv[i] == 0) a->halves += clvox_cap_tie(t + i * 9u, gt + i * 9u, px, py, pz, dv[i], axis);
    }
#if !defined(CLVOX_FP64)
    /* The factor's rounding (float: the host's double decides where it
     * matters, clvox_winding_inside_m): with |df| <= dl (2 dl where det's
     * sign was replaced, above), arg f moves by at most asin(rho) <= 1.05
     * rho, rho = |df| / |f| <= 1/2 (|f| taken 1e-4 below its float value,
     * which is within a few u of it) -- det's sign being exact, f stays on
     * its side of the cut -- and the product by sqrt5 u more
     * (clvox_angles_mul). Past 1/2 (p near an edge's line, or at a corner:
     * NaN) nothing is bounded. A flat lane (exact det == 0) multiplies by 1
     * exactly; its tie needs den's sign, certain where |den| > dl. */
    {
        const clvox_real4 rho = (dfac * dl) / (hypot(den, det) * 0.9999f); /* hypot: no overflow */
        clvox_real4 e = select((clvox_real4)CLVOX_ERR_UNBOUNDED, rho * 1.05f + 3 * CLVOX_REAL_U, rho <= 0.5f);
        /* a flat lane: with den < 0, det is exactly 0 (clvox_det_signs) and the tie exact;
         * with den > dl, f lies within dl of den > 0: the bound above */
        e = select(e, select((clvox_real4)CLVOX_ERR_UNBOUNDED, select(e, zero, den < zero), fabs(den) > dl), flat);
        e = select(e, (clvox_real4)CLVOX_ERR_UNBOUNDED, lost);
        a->err += select(e, zero, past);
    }
#else
    (void)lost, (void)dfac;
#endif
    const clvox_mask4 skip = past | (det == zero) | isnan(det) | isnan(den); /* NaN: as atan2's 0 */
    den = select(den, (clvox_real4)1, skip);
    det = select(det, zero, skip);
    clvox_angles_mul(a, den, det);
    a->n += count;
}

/* Multiplies in cap triangles t .. t + count - 1 (count 1 .. 4; 9 reals
 * each, scaled x, y, z; gt the same in grid space) seen from p, one per
 * lane. Lanes past `count` repeat triangle 0 and multiply by 1. */
static inline void clvox_cap_angles4(global const clvox_real *t, global const float *gt, const clvox_real *g,
                                     uint count, clvox_real px, clvox_real py, clvox_real pz, uint axis,
                                     clvox_angles *a)
{
    const uint i1 = count > 1u ? 9u : 0u, i2 = count > 2u ? 18u : 0u, i3 = count > 3u ? 27u : 0u;
#define CLVOX_G4(k, p) ((clvox_real4)(t[k], t[i1 + (k)], t[i2 + (k)], t[i3 + (k)]) - (p))
    clvox_cap_angles4_v(CLVOX_G4(0, px), CLVOX_G4(1, py), CLVOX_G4(2, pz), CLVOX_G4(3, px), CLVOX_G4(4, py),
                        CLVOX_G4(5, pz), CLVOX_G4(6, px), CLVOX_G4(7, py), CLVOX_G4(8, pz), t, gt, g, count, px, py,
                        pz, axis, a);
#undef CLVOX_G4
}

/* The same for a leaf's lane-major copy (clvox_cap_node.block): real k of
 * lane l at blk[4k + l], the same numbers, one vector load each. */
static inline void clvox_cap_block4(global const clvox_real *blk, global const clvox_real *t, global const float *gt,
                                    const clvox_real *g, uint count, clvox_real px, clvox_real py, clvox_real pz,
                                    uint axis, clvox_angles *a)
{
    clvox_cap_angles4_v(vload4(0, blk) - px, vload4(1, blk) - py, vload4(2, blk) - pz, vload4(3, blk) - px,
                        vload4(4, blk) - py, vload4(5, blk) - pz, vload4(6, blk) - px, vload4(7, blk) - py,
                        vload4(8, blk) - pz, t, gt, g, count, px, py, pz, axis, a);
}

/* The solid angle / 4pi of everything multiplied in: the lanes' (arg + 2pi
 * k) / 2pi, summed; adds its error bound to *err. Double: CLVOX_FACTOR_ERR
 * per factor and atan2. Float: the lanes' argument errors over 2pi, the
 * builtin atan2's, and the scaling and the sum's roundings (a few u of the
 * terms' magnitudes). */
static inline clvox_real clvox_angles_value(const clvox_angles *a, clvox_real *err)
{
    const clvox_real4 v =
        clvox_atan2_4(a->im, a->re) * (clvox_real)0.15915494309189535 + clvox_convert_real4(a->k);
    const clvox_real value = (v.s0 + v.s1) + (v.s2 + v.s3) + a->halves;
#if defined(CLVOX_FP64)
    *err += (clvox_real)(a->n + 4u) * (clvox_real)CLVOX_FACTOR_ERR;
#else
    const clvox_real4 av = fabs(v);
    *err += ((a->err.s0 + a->err.s1) + (a->err.s2 + a->err.s3)) * 0.16f + 4 * CLVOX_ATAN2_ERR +
            8 * CLVOX_REAL_U * ((av.s0 + av.s1) + (av.s2 + av.s3) + fabs(a->halves) + fabs(value));
#endif
    return value;
}
