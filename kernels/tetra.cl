/* SPDX-License-Identifier: Apache-2.0 */
/* Stage tetra: Rueda et al., sections 3-4. Every mesh triangle
 * (a,b,c) and the common point O span a tetrahedron; a voxel centre covered
 * by an odd number of them is inside (Lemma 1). Each task scan-converts one
 * tetrahedron over a few slices z = k of the current slab; the resolve
 * kernel turns the difference markers into the slab's occupancy bits.
 *
 * Presence bits are stored as differences along x: a tetrahedron covers the
 * centres x in [L, U) of a row, and flipping those is XOR-ing a marker at L
 * and one at U (when U < X); the resolve kernel's prefix XOR along the row
 * gives the presence bit of each voxel. Two markers per (tetrahedron, row)
 * whatever the length of the span.
 *
 * Exactness (see src/raster/tetra.c for the argument): every face of a tetrahedron
 * is judged by an affine function F(P) = n.(P - A) in double precision,
 * where (n, A) depend only on the unordered vertex set of the face (O, p, q
 * with p < q in lexicographic order, or the sorted triangle), so the face
 * shared by the tetrahedra of two neighbouring triangles gives both exactly
 * the same thresholds. F is evaluated as
 *     F = n.x*(x - A.x) + (n.y*(y - A.y) + n.z*(z - A.z))
 * in exactly this order (FP_CONTRACT OFF, prelude), which is monotone in x:
 * along a row its sign changes at most once. F == 0 is broken by the
 * symbolic perturbation P + e*t0 + e^2*t1 + e^3*t2 (t = the ray axes u,v,w):
 * the sign of the first non-zero of n.t0, n.t1, n.t2. */

/* Slices and rows within this distance (voxel units) of a tetrahedron are
 * visited, far more than the rounding of F (about 1e-11 voxel). */
#ifndef CLVOX_TETRA_MARGIN
#define CLVOX_TETRA_MARGIN 1e-3
#endif

/* p < q in lexicographic (x, y, z) order; bit-identical shared vertices
 * compare the same way from every triangle. */
static inline int clvox_lex_less(float px, float py, float pz, float qx, float qy, float qz)
{
    return px < qx || (px == qx && (py < qy || (py == qy && pz < qz)));
}

/* Swaps two points; returns -1 (the parity change). */
static inline int clvox_swap3(float *p, float *q)
{
    for (int i = 0; i < 3; i++) {
        float t = p[i];
        p[i] = q[i];
        q[i] = t;
    }
    return -1;
}

#if defined(CLVOX_FP64)

/* One face of a tetrahedron, ready for thresholds along x. */
typedef struct clvox_tface {
    double nx, ny, nz;  /* normal of the canonical orientation */
    double ax, ay, az;  /* anchor A */
    double inv_nx;      /* 1 / nx (0 when nx == 0) */
    double slope;       /* -ny / nx: d(root)/dy */
    int want;           /* sign F must have inside the tetrahedron */
    int tie;            /* sign of F when F == 0 (0: degenerate face) */
} clvox_tface;

/* Sign of F(P') when F(P) == 0: the first non-zero of n.t0, n.t1, n.t2,
 * where order holds the axes t0, t1, t2 in 2 bits each. */
static inline int clvox_tie_sign(double nx, double ny, double nz, uint order)
{
    double n[3] = {nx, ny, nz};
    for (int i = 0; i < 3; i++) {
        double v = n[(order >> (2 * i)) & 3u];
        if (v != 0.0) return v > 0.0 ? 1 : -1;
    }
    return 0;
}

/* Face through A = (ax,ay,az), P1, P2: n = (P1 - A) x (P2 - A). */
static inline void clvox_face_set(clvox_tface *f, double ax, double ay, double az, double p1x, double p1y, double p1z,
                                  double p2x, double p2y, double p2z, uint order)
{
    double ux = p1x - ax, uy = p1y - ay, uz = p1z - az;
    double vx = p2x - ax, vy = p2y - ay, vz = p2z - az;
    f->nx = uy * vz - uz * vy;
    f->ny = uz * vx - ux * vz;
    f->nz = ux * vy - uy * vx;
    f->ax = ax;
    f->ay = ay;
    f->az = az;
    f->inv_nx = f->nx != 0.0 ? 1.0 / f->nx : 0.0;
    f->slope = -f->ny * f->inv_nx;
    f->tie = clvox_tie_sign(f->nx, f->ny, f->nz, order);
}

/* Internal face (O, p, q): canonical order p < q. Returns the sign relating
 * F_Opq to the canonical function. */
static inline int clvox_face_internal(clvox_tface *f, float ox, float oy, float oz, float px, float py, float pz,
                                      float qx, float qy, float qz, uint order)
{
    if (clvox_lex_less(qx, qy, qz, px, py, pz)) {
        clvox_face_set(f, ox, oy, oz, qx, qy, qz, px, py, pz, order);
        return -1;
    }
    clvox_face_set(f, ox, oy, oz, px, py, pz, qx, qy, qz, order);
    return 1;
}

/* Sign of F at (x, y, k), given C = ny*(y - ay) + nz*(k - az) of the row:
 * exactly the per-point F, ties broken by the perturbation. */
static inline int clvox_face_sign_at(const clvox_tface *f, double C, int x)
{
    double F = f->nx * ((double)x - f->ax) + C;
    return F > 0.0 ? 1 : (F < 0.0 ? -1 : f->tie);
}

/* First x in [0, X] where sign(nx) * sign(F(x)) > 0 (X when none), by
 * evaluating F at the integers around the approximate root xs: F is
 * monotone along x, so this is where the face's sign flips. */
static inline int clvox_face_threshold(const clvox_tface *f, double yd, double kd, double xs, int X)
{
    double C = f->ny * (yd - f->ay) + f->nz * (kd - f->az);
    int sx = f->nx > 0.0 ? 1 : -1;
    int t = (int)fmin(fmax(rint(xs), 0.0), (double)X); /* NaN -> 0 */
    while (t > 0 && sx * clvox_face_sign_at(f, C, t - 1) > 0) t--;
    while (t < X && sx * clvox_face_sign_at(f, C, t) <= 0) t++;
    return t;
}

/* The bound of a row from a group of faces, evaluated exactly: L = the
 * largest threshold of the lower faces, U = the smallest of the upper ones. */
static inline int clvox_group_bound(const clvox_tface *f, const int *idx, int n, double yd, double kd, int X, int upper)
{
    int b = upper ? X : 0;
    for (int a = 0; a < n; a++) {
        const clvox_tface *g = &f[idx[a]];
        double xs = g->ax - (g->ny * (yd - g->ay) + g->nz * (kd - g->az)) * g->inv_nx;
        int t = clvox_face_threshold(g, yd, kd, xs, X);
        b = upper ? min(b, t) : max(b, t);
    }
    return b;
}

/* floor(x) for |x| < 2^31 (here x is within [-1.5, X + 0.5]): truncate,
 * then step down where that rounded up. Cheaper than floor(), which must
 * handle every double. */
static inline int4 clvox_floor_small4(double4 x)
{
    int4 t = convert_int4(x); /* towards zero */
    return select(t, t - 1, convert_int4(convert_double4(t) > x)); /* a mask, not "+ (true = -1)" */
}

/* The same bound from the extreme root xe of the group (the largest root
 * of the lower faces, the smallest of the upper ones): the threshold of
 * each face is the first integer beyond its root wherever the root is more
 * than tol from an integer (the rounded F then has the sign of x - root at
 * every integer x; its rounding moves the root by < 1e-10 voxel, and the
 * error of xe is below 1e-3 tol), and that is monotone in the root, so the
 * bound is the first integer beyond xe. Gives -1 when xe is within tol of
 * an integer: then each threshold must be evaluated. Four rows at once. */
static inline int4 clvox_bound_fast4(double4 xe, double tol, double Xd)
{
    /* Roots below -0.5 give 0, above X - 0.5 give X (all centres on one side). */
    double4 c = min(max(xe, -0.5), Xd - 0.5);
    int4 lo = clvox_floor_small4(c - tol), hi = clvox_floor_small4(c + tol);
    return select((int4)(-1), hi + 1, lo == hi);
}

#endif /* CLVOX_FP64 */

/* Flips the centres [L, U) of one row of presence differences. */
static inline void clvox_span_xor(global uint *row, int L, int U, int X)
{
    atomic_xor(row + (L >> 5), 1u << (L & 31));
    if (U < X) atomic_xor(row + (U >> 5), 1u << (U & 31));
}

/* y-range of the cross-section at height h, D.z <= h <= A.z, of the
 * tetrahedron with vertices A, B, C, D sorted by decreasing z (vy, vz) and
 * edge slopes e = dy/dz of AB, AC, AD, BC, BD, CD (0 for flat edges). Paper,
 * section 4 and Table 1: the plane cuts AD always, AB and AC for
 * B.z <= h <= A.z, BD and CD for h < C.z, and AD, AC, BD, BC in between (the
 * paper's table lists CD for P2 there, but that plane separates {A,B} from
 * {C,D}: it is AC). Each point is interpolated from the edge's lower end,
 * so at a vertex's height it is that vertex, and a flat edge gives its
 * lower-indexed end (the other is on another edge). */
static inline void clvox_section(const clvox_ovr *vy, const clvox_ovr *vz, clvox_ovr h, const clvox_ovr *e, clvox_ovr *lo, clvox_ovr *hi)
{
    clvox_ovr p0 = vy[3] + (h - vz[3]) * e[2], p1, p2, p3;
    if (h >= vz[1]) {
        p1 = vy[1] + (h - vz[1]) * e[0];
        p2 = vy[2] + (h - vz[2]) * e[1];
        p3 = p2;
    } else if (h >= vz[2]) {
        p1 = vy[3] + (h - vz[3]) * e[4];
        p2 = vy[2] + (h - vz[2]) * e[1];
        p3 = vy[2] + (h - vz[2]) * e[3];
    } else {
        p1 = vy[3] + (h - vz[3]) * e[4];
        p2 = vy[3] + (h - vz[3]) * e[5];
        p3 = p2;
    }
    *lo = fmin(fmin(p0, p1), fmin(p2, p3));
    *hi = fmax(fmax(p0, p1), fmax(p2, p3));
}

/* The cross-sections' data: the vertices O, a, b, c (their y and z) sorted
 * by decreasing z into vy, vz, and e = dy/dz of the edges AB, AC, AD, BC,
 * BD, CD (0 when flat: not used). */
static inline void clvox_section_setup(float oy, float oz, float a1, float a2, float b1, float b2, float c1, float c2,
                                       clvox_ovr *vy, clvox_ovr *vz, clvox_ovr *e)
{
    const float y0[4] = {oy, a1, b1, c1}, z0[4] = {oz, a2, b2, c2};
    for (int i = 0; i < 4; i++) vy[i] = y0[i], vz[i] = z0[i];
    for (int i = 1; i < 4; i++)
        for (int j = i; j > 0 && vz[j] > vz[j - 1]; j--) {
            clvox_ovr ty = vy[j], tz = vz[j];
            vy[j] = vy[j - 1];
            vz[j] = vz[j - 1];
            vy[j - 1] = ty;
            vz[j - 1] = tz;
        }
    const clvox_ovr zero = 0;
    e[0] = vz[0] > vz[1] ? (vy[0] - vy[1]) / (vz[0] - vz[1]) : zero;
    e[1] = vz[0] > vz[2] ? (vy[0] - vy[2]) / (vz[0] - vz[2]) : zero;
    e[2] = vz[0] > vz[3] ? (vy[0] - vy[3]) / (vz[0] - vz[3]) : zero;
    e[3] = vz[1] > vz[2] ? (vy[1] - vy[2]) / (vz[1] - vz[2]) : zero;
    e[4] = vz[1] > vz[3] ? (vy[1] - vy[3]) / (vz[1] - vz[3]) : zero;
    e[5] = vz[2] > vz[3] ? (vy[2] - vy[3]) / (vz[2] - vz[3]) : zero;
}

/* Sorts the mesh face's vertices p, q, r lexicographically (so that a
 * duplicated triangle gives the same face function); returns the parity of
 * the permutation (+-1). */
static inline int clvox_sort3(float *p, float *q, float *r)
{
    int par = 1;
    if (clvox_lex_less(q[0], q[1], q[2], p[0], p[1], p[2])) par *= clvox_swap3(p, q);
    if (clvox_lex_less(r[0], r[1], r[2], q[0], q[1], q[2])) par *= clvox_swap3(q, r);
    if (clvox_lex_less(q[0], q[1], q[2], p[0], p[1], p[2])) par *= clvox_swap3(p, q);
    return par;
}

/* Four lanes of clvox_ovr, and the mask type of their comparisons. */
#if defined(CLVOX_FP64)
typedef double4 clvox_ovr4;
typedef long4 clvox_ovm4;
#define clvox_convert_ovr4 convert_double4
#else
typedef float4 clvox_ovr4;
typedef int4 clvox_ovm4;
#define clvox_convert_ovr4 convert_float4
#endif

/* clvox_section at four heights at once (each within [D.z, A.z]). */
static inline void clvox_section4(const clvox_ovr *vy, const clvox_ovr *vz, clvox_ovr4 h, const clvox_ovr *e,
                                  clvox_ovr4 *lo, clvox_ovr4 *hi)
{
    clvox_ovm4 top = h >= vz[1], mid = h >= vz[2];
    clvox_ovr4 bd = h - vz[3], cd = h - vz[2];
    clvox_ovr4 p0 = vy[3] + bd * e[2];
    clvox_ovr4 p1 = select(vy[3] + bd * e[4], vy[1] + (h - vz[1]) * e[0], top);
    clvox_ovr4 p2 = select(vy[3] + bd * e[5], vy[2] + cd * e[1], top | mid);
    clvox_ovr4 p3 = select(p2, vy[2] + cd * e[3], select(mid, (clvox_ovm4)0, top)); /* mid & !top; no ~ (winding_angles.h) */
    *lo = fmin(fmin(p0, p1), fmin(p2, p3));
    *hi = fmax(fmax(p0, p1), fmax(p2, p3));
}

#if defined(CLVOX_FP64)

/* ---- the double build's faces, for the shared raster below ---- */

typedef clvox_tface clvox_face;

/* Sign of det[a-O; b-O; c-O] from face 0 = (O, a, b) in its canonical
 * order (s0 relates the two), in double as the faces judge it. */
static inline int clvox_tetra_orientation(const clvox_face *f0, int s0, float c0, float c1, float c2)
{
    double vol = (double)s0 * (f0->nx * ((double)c0 - f0->ax) +
                               (f0->ny * ((double)c1 - f0->ay) + f0->nz * ((double)c2 - f0->az)));
    return vol > 0.0 ? 1 : (vol < 0.0 ? -1 : 0);
}
#define clvox_face_set_any clvox_face_set
#define clvox_face_internal_any clvox_face_internal

/* 1: F is constant along x (the face is parallel to x); 1: a lower face
 * (bounds the span from the left). */
static inline int clvox_face_constant(const clvox_face *f) { return f->nx == 0.0; }
static inline int clvox_face_lower(const clvox_face *f) { return (f->want > 0) == (f->nx > 0.0); }

/* The face's root along x in row (y, k) as A + (k - Az)*c1 + (y - Ay)*slope;
 * in double Az = Ay = 0 and A = c0 = ax + (nz*az + ny*ay)/nx. Returns tol:
 * a few ulps of the magnitudes summed (with the rounding of F itself), far
 * below it; 1 from 0.5 on (or NaN): no root is far enough from an integer. */
static inline double clvox_face_root(const clvox_face *g, double Dy, double k0, double K, double Y, double *A,
                                     double *Ay, double *Az, double *c1, double *slope)
{
    (void)Dy;
    (void)k0;
    *A = g->ax + (g->nz * g->az + g->ny * g->ay) * g->inv_nx;
    *Ay = *Az = 0.0;
    *c1 = -g->nz * g->inv_nx;
    *slope = g->slope;
    double M = fabs(g->ax) + (fabs(g->nz) * (fabs(g->az) + K) + fabs(g->ny) * (fabs(g->ay) + Y)) * fabs(g->inv_nx);
    double tol = 1e-7 + 1e-12 * M;
    return tol < 1.0 ? tol : 1.0;
}

/* 1: a face constant along the row leaves it out of the tetrahedron. */
static inline int clvox_row_outside(const clvox_face *f, const int *cst, int ncst, double yd, double kd)
{
    for (int a = 0; a < ncst; a++) {
        const clvox_face *g = &f[cst[a]];
        double C = g->ny * (yd - g->ay) + g->nz * (kd - g->az);
        int sg = C > 0.0 ? 1 : (C < 0.0 ? -1 : g->tie);
        if (sg != g->want) return 1;
    }
    return 0;
}

#define clvox_group_exact clvox_group_bound
#define clvox_bound4 clvox_bound_fast4

#else /* !CLVOX_FP64: float, every sign exact (kernels/overlap.h) */

/* One face of a tetrahedron on a device without fp64. The face function is
 * the exact F(P) = n.(P - A), n = (P1 - A) x (P2 - A), of the same
 * canonical (A, P1, P2) as in double, its sign taken with clvox_o3_sign_pre
 * (a float filter, then the exact expansion), and F == 0 broken by the same
 * perturbation from the exact signs of n's components (clvox_e2_sign). The
 * float n only guesses where a row's threshold is: four rows at once from
 * each face's root as an affine function of the row with a rigorous error
 * bound (clvox_face_root_x, clvox_bound_fast4f), and where that leaves an
 * integer in doubt, by exact signs at the integers around the guess. */
typedef struct clvox_tface_x {
    float v[9];        /* A, P1, P2 */
    float m[3], pm[3]; /* clvox_o3_setup(v) */
    float nx, ny, nz;  /* n to about a float's precision (guesses only; clvox_normal_x) */
    float dn[3];       /* bounds on |n - (nx, ny, nz)| */
    float inv_nx;      /* 1 / nx (0 when nx == 0) */
    int snx;           /* the exact sign of n.x */
    int want;          /* sign F must have inside the tetrahedron */
    int tie;           /* sign of F when F == 0 (0: degenerate face) */
} clvox_tface_x;

/* n = (P1 - A) x (P2 - A) (v: A, P1, P2) to about a float's precision
 * even where its products cancel, as in the long thin tetrahedra from O to
 * small faces (the rounded minors of clvox_o3_setup can lose every digit
 * there): each difference as an exact sum hi + lo (Two-Sum), each minor as
 * hi*hi' - hi*hi' exactly (products by fma, their difference by Two-Sum)
 * plus the cross terms hi*lo in float. dn[k] bounds |n_k - nk's float|:
 * u of the result, plus 32 u^2 of the permanent |P| + |Q| for the small
 * terms' rounding (below 19 u^2 of it: four products, six sums of terms
 * each under 4 u of it; lo*lo, dropped, is under 2 u^2), plus 2^-110 for
 * products near underflow. */
static inline void clvox_normal_x(const float *v, float *n, float *dn)
{
    const float u = CLVOX_OV_U;
    float h[6], l[6]; /* a = P1 - A, b = P2 - A */
    for (int i = 0; i < 6; i++) {
        const float p = v[3 + i], q = -v[i % 3];
        const float s = p + q, bv = s - p, av = s - bv;
        h[i] = s;
        l[i] = (p - av) + (q - bv);
    }
    for (int k = 0; k < 3; k++) {
        const int s = (k + 1) % 3, t = (k + 2) % 3;
        const float P = h[s] * h[3 + t], Q = -(h[t] * h[3 + s]);
        const float eP = fma(h[s], h[3 + t], -P), eQ = fma(-h[t], h[3 + s], -Q);
        const float d = P + Q, bv = d - P, av = d - bv, eD = (P - av) + (Q - bv);
        const float cross = (h[s] * l[3 + t] + l[s] * h[3 + t]) - (h[t] * l[3 + s] + l[t] * h[3 + s]);
        n[k] = d + (((eP + eQ) + eD) + cross);
        dn[k] = 1.01f * u * fabs(n[k]) + 32.0f * u * u * (fabs(P) + fabs(Q)) + 0x1p-110f;
    }
}

/* Face through A, P1, P2 (floats in grid space). */
static inline void clvox_face_set_x(clvox_tface_x *f, float ax, float ay, float az, float p1x, float p1y, float p1z,
                                    float p2x, float p2y, float p2z, uint order)
{
    const float v[9] = {ax, ay, az, p1x, p1y, p1z, p2x, p2y, p2z};
    for (int i = 0; i < 9; i++) f->v[i] = v[i];
    clvox_o3_setup(f->v, f->m, f->pm);
    float n[3];
    clvox_normal_x(v, n, f->dn);
    f->nx = n[0], f->ny = n[1], f->nz = n[2];
    f->inv_nx = f->nx != 0.0f ? 1.0f / f->nx : 0.0f;
    /* exact signs of n's components: n_k is the 2x2 determinant in the
     * cyclic coordinates (s, t) = (k + 1, k + 2); its sign is the guess's
     * where that is farther from 0 than its bound, else exact */
    int sn[3];
    for (int k = 0; k < 3; k++) {
        const int s = (k + 1) % 3, t = (k + 2) % 3;
        sn[k] = n[k] > f->dn[k]    ? 1
                : -n[k] > f->dn[k] ? -1
                                   : clvox_e2_sign(v[s], v[t], v[3 + s], v[3 + t], v[s], v[t], v[6 + s], v[6 + t]);
    }
    f->snx = sn[0];
    f->tie = 0;
    for (int i = 2; i >= 0; i--) { /* the first non-zero of n.t0, n.t1, n.t2 */
        const int c = sn[(order >> (2 * i)) & 3u];
        if (c) f->tie = c;
    }
}

/* Internal face (O, p, q): canonical order p < q, as in double. Returns the
 * sign relating F_Opq to the canonical function. */
static inline int clvox_face_internal_x(clvox_tface_x *f, float ox, float oy, float oz, float px, float py, float pz,
                                        float qx, float qy, float qz, uint order)
{
    if (clvox_lex_less(qx, qy, qz, px, py, pz)) {
        clvox_face_set_x(f, ox, oy, oz, qx, qy, qz, px, py, pz, order);
        return -1;
    }
    clvox_face_set_x(f, ox, oy, oz, px, py, pz, qx, qy, qz, order);
    return 1;
}

/* The exact sign of F at (x, y, k), ties broken by the perturbation. */
static inline int clvox_face_sign_x(const clvox_tface_x *f, float x, float y, float k)
{
    const int s = clvox_o3_sign_pre(f->v, f->m, f->pm, x, y, k);
    return s ? s : f->tie;
}

/* First x in [0, X] where snx * sign(F(x)) > 0 (X when none): F is affine
 * in x with slope n.x, so that sign flips once along the row, after the
 * root r: the threshold is the first integer above r. Where a rigorous
 * bound E on the float root's error leaves no integer within E of it, that
 * is floor(xs) + 1 at once. E counts: n's error (dn, clvox_normal_x), the
 * differences, products and sum of the numerator (3.1 u of its terms), the
 * quotient (n.x's relative error, a reciprocal within 2.5 ulp = 5 u and
 * the product: 6 u), the last subtraction (u), all doubled;
 * only where n.x's own relative error is below 1 %. Elsewhere, or near an
 * integer, the walk starts at the guessed root and steps, by exact signs,
 * until it has found the flip. */
static inline int clvox_face_threshold_x(const clvox_tface_x *f, float yd, float kd, int X)
{
    const float dy = yd - f->v[1], dz = kd - f->v[2];
    const float ty = f->ny * dy, tz = f->nz * dz, q = (ty + tz) * f->inv_nx;
    const float xs = f->v[0] - q;
    const float u = CLVOX_OV_U, anx = fabs(f->nx), rx = f->dn[0] / anx;
    if (f->snx != 0 && rx < 0.01f) {
        const float E = 2.0f * (((f->dn[1] * fabs(dy) + f->dn[2] * fabs(dz)) +
                                 3.1f * u * (fabs(ty) + fabs(tz))) / anx +
                                fabs(q) * (rx + 6.0f * u) + u * (fabs(q) + fabs(xs))) +
                        0x1p-100f;
        if (xs - E >= (float)X) return X; /* r >= X: no integer of [0, X) above it */
        if (xs + E < 0.0f) return 0;      /* r < 0: 0 is above it */
        const float lo = floor(xs - E), hi = floor(xs + E);
        if (lo == hi) return clamp((int)lo + 1, 0, X); /* no integer within E of r */
    }
    int t = (int)fmin(fmax(rint(xs), 0.0f), (float)X); /* NaN -> 0 */
    while (t > 0 && f->snx * clvox_face_sign_x(f, (float)(t - 1), yd, kd) > 0) t--;
    while (t < X && f->snx * clvox_face_sign_x(f, (float)t, yd, kd) <= 0) t++;
    return t;
}

/* The span of a row: L = the largest threshold of the lower faces, U = the
 * smallest of the upper ones. */
static inline int clvox_group_bound_x(const clvox_tface_x *f, const int *idx, int n, float yd, float kd, int X,
                                      int upper)
{
    int b = upper ? X : 0;
    for (int a = 0; a < n; a++) {
        const int t = clvox_face_threshold_x(&f[idx[a]], yd, kd, X);
        b = upper ? min(b, t) : max(b, t);
    }

    return b;
}

/* A face's root along x as an affine function of the row, root(y, k) =
 * A.x + (k - A.z)*c1 + (y - A.y)*slope in float from n's float, for the
 * fast bound of four rows at once (clvox_bound_fast4f). Dy and Dz bound
 * |y - A.y| and |k - A.z| over the rows of the task. Returns tol, at least
 * twice a rigorous bound on that value's distance from the exact root over
 * those rows, or 1 where none below 1/2 is known (then c1 = slope = 0, so
 * that nothing is NaN). The bound: n's error (|n - m| <= dn, m its float,
 * clvox_normal_x) moves the root by at most
 *   En = (Dy*|ny - my| + Dz*|nz - mz| + Q*|nx - mx|/|mx|) / |nx|,
 * with Q = |my| Dy + |mz| Dz and |nx| >= 0.99 |mx| (required:
 * dn[0] < 0.01 |mx|); the evaluation rounds by at most 10 u of
 * M = |A.x| + Q/|mx| (a reciprocal within 2.5 ulp: 5 u; the differences,
 * products and sums: u each), taken as 16 u. */
static inline float clvox_face_root_x(const clvox_tface_x *f, float Dy, float Dz, float *c1, float *slope)
{
    const float u = CLVOX_OV_U, anx = fabs(f->nx), rx = f->dn[0] / anx;
    *c1 = *slope = 0.0f;
    if (f->snx == 0 || !(rx < 0.01f)) return 1.0f;
    const float Q = fabs(f->ny) * Dy + fabs(f->nz) * Dz, M = fabs(f->v[0]) + Q / anx;
    const float En = (f->dn[1] * Dy + f->dn[2] * Dz + Q * rx) / (0.99f * anx);
    const float tol = 2.0f * (16.0f * u * M + En) + 0x1p-100f;
    if (!(tol < 0.5f)) return 1.0f; /* also NaN */
    *c1 = -f->nz * f->inv_nx;
    *slope = -f->ny * f->inv_nx;
    return tol;
}

/* clvox_bound_fast4 in float: the first integer beyond the extreme root
 * xe of a group, for four rows, or -1 where an integer lies within tol of
 * xe (then the row's thresholds are settled by exact signs). tol < 1/2 is
 * at least twice the roots' error, which covers the rounding of xe -+ tol
 * (their magnitude is below M, and tol >= 32 u M). */
static inline int4 clvox_bound_fast4f(float4 xe, float tol, float Xd)
{
    const float4 c = min(max(xe, -0.5f), Xd - 0.5f);
    const int4 lo = convert_int4(floor(c - tol)), hi = convert_int4(floor(c + tol));
    return select((int4)(-1), hi + 1, lo == hi);
}

/* ---- the float build's faces, for the shared raster below ---- */

typedef clvox_tface_x clvox_face;

/* Sign of det[a-O; b-O; c-O], exactly (clvox_o3_sign_pre on face 0). */
static inline int clvox_tetra_orientation(const clvox_face *f0, int s0, float c0, float c1, float c2)
{
    return s0 * clvox_o3_sign_pre(f0->v, f0->m, f0->pm, c0, c1, c2);
}
#define clvox_face_set_any clvox_face_set_x
#define clvox_face_internal_any clvox_face_internal_x

static inline int clvox_face_constant(const clvox_face *f) { return f->snx == 0; }
static inline int clvox_face_lower(const clvox_face *f) { return f->want == f->snx; }

/* clvox_face_root_x, anchored at the face's A; Dz from the task's slices
 * [k0, K). */
static inline float clvox_face_root(const clvox_face *f, float Dy, float k0, float K, float Y, float *A, float *Ay,
                                    float *Az, float *c1, float *slope)
{
    (void)Y;
    *A = f->v[0], *Ay = f->v[1], *Az = f->v[2];
    const float Dz = fmax(fabs(k0 - f->v[2]), fabs(K - f->v[2])) * (1.0f + 0x1p-20f);
    return clvox_face_root_x(f, Dy, Dz, c1, slope);
}

/* 1: a face constant along the row leaves it out of the tetrahedron. */
static inline int clvox_row_outside(const clvox_face *f, const int *cst, int ncst, float yd, float kd)
{
    for (int a = 0; a < ncst; a++)
        if (clvox_face_sign_x(&f[cst[a]], 0.0f, yd, kd) != f[cst[a]].want) return 1;
    return 0;
}

#define clvox_group_exact clvox_group_bound_x
#define clvox_bound4 clvox_bound_fast4f

#endif /* CLVOX_FP64 */

/* ---- the raster of one task, in either build ---- */

/* The tetrahedron's four faces with the signs F must have inside; 0 when it
 * is flat and covers nothing. Faces (O,a,b), (O,b,c), (O,c,a): inside,
 * F_Oab, F_Obc, F_Oca all have the sign s of the tetrahedron's orientation
 * det[a-O; b-O; c-O]. The mesh face, vertices sorted: F_abc = par *
 * F_sorted, and inside F_abc has the sign -s. */
static inline int clvox_tetra_faces(clvox_face *f, float ox, float oy, float oz, float a0, float a1, float a2,
                                    float b0, float b1, float b2, float c0, float c1, float c2, uint tie_order)
{
    int s0 = clvox_face_internal_any(&f[0], ox, oy, oz, a0, a1, a2, b0, b1, b2, tie_order);
    int s1 = clvox_face_internal_any(&f[1], ox, oy, oz, b0, b1, b2, c0, c1, c2, tie_order);
    int s2 = clvox_face_internal_any(&f[2], ox, oy, oz, c0, c1, c2, a0, a1, a2, tie_order);
    const int s = clvox_tetra_orientation(&f[0], s0, c0, c1, c2);
    if (s == 0) return 0; /* flat: covers nothing */
    f[0].want = s * s0;
    f[1].want = s * s1;
    f[2].want = s * s2;
    float p[3] = {a0, a1, a2}, q[3] = {b0, b1, b2}, r[3] = {c0, c1, c2};
    const int par = clvox_sort3(p, q, r);
    clvox_face_set_any(&f[3], p[0], p[1], p[2], q[0], q[1], q[2], r[0], r[1], r[2], tie_order);
    f[3].want = -s * par;
    return 1;
}


/* tasks: 4 uints each (triangle, first slice, end slice, unused), slices in
 * grid z. bits: words_per_row words per row, row (k - z0) * Y + y.
 *
 * Lower faces bound the rows' spans from the left, upper ones from the
 * right; faces parallel to x are constant along a row. A face's root
 * along x in row (y, k) is A + (k - Az)*c1 + (y - Ay)*slope
 * (clvox_face_root, with its error bound tol); groups are padded to 3 with
 * roots at -+inf. Slices go four at a time, lane q handling row r of slice
 * k + q: the bound of the lane's row is the first integer beyond the
 * group's extreme root (clvox_bound4) unless an integer lies within tol of
 * it, then each face's threshold (clvox_group_exact). Rows: within the
 * cross-sections widened by a margin (below) and within one voxel of the
 * tetrahedron's y-range [ylo, yhi] (so |y - Ay| <= Dy for every face's
 * anchor, a vertex). */
static void clvox_tetra_raster_body(global const float *soup, global const uint *tasks, uint task_count, float ox,
                                    float oy, float oz, uint tie_order, uint z0, uint X, uint Y, uint words_per_row,
                                    global uint *bits)
{
    uint gid = get_global_id(0);
    if (gid >= task_count) return;
    global const uint *task = tasks + (size_t)gid * 4;
    global const float *t = soup + (size_t)task[0] * 9;
    float a0 = t[0], a1 = t[1], a2 = t[2];
    float b0 = t[3], b1 = t[4], b2 = t[5];
    float c0 = t[6], c1 = t[7], c2 = t[8];
    clvox_face f[4];
    if (!clvox_tetra_faces(f, ox, oy, oz, a0, a1, a2, b0, b1, b2, c0, c1, c2, tie_order)) return;

    /* Cross-sections: vertices sorted by decreasing z (clvox_section). The
     * margin m: CLVOX_TETRA_MARGIN, and in float 2^-19 of the largest
     * coordinate, which covers the sections' rounding (below 13 u of it). */
    clvox_ovr vy[4], vz[4], e[6];
    clvox_section_setup(oy, oz, a1, a2, b1, b2, c1, c2, vy, vz, e);
#if defined(CLVOX_FP64)
    const clvox_ovr m = CLVOX_TETRA_MARGIN;
#else
    float big = fmax((float)Y, (float)task[2]);
    for (int i = 0; i < 4; i++) big = fmax(big, fmax(fabs(vy[i]), fabs(vz[i])));
    const float m = (float)CLVOX_TETRA_MARGIN + 0x1p-19f * big;
#endif
    const clvox_ovr ylo = fmin(fmin(vy[0], vy[1]), fmin(vy[2], vy[3])), yhi = fmax(fmax(vy[0], vy[1]), fmax(vy[2], vy[3]));
    const clvox_ovr Dy = (yhi - ylo + (clvox_ovr)1) * ((clvox_ovr)1 + (clvox_ovr)0x1p-20);

    int lo_idx[4], up_idx[4], cst_idx[4], nlo = 0, nup = 0, ncst = 0;
    clvox_ovr lax[3] = {-INFINITY, -INFINITY, -INFINITY}, lay[3] = {0, 0, 0}, laz[3] = {0, 0, 0};
    clvox_ovr lc1[3] = {0, 0, 0}, ls[3] = {0, 0, 0};
    clvox_ovr uax[3] = {INFINITY, INFINITY, INFINITY}, uay[3] = {0, 0, 0}, uaz[3] = {0, 0, 0};
    clvox_ovr uc1[3] = {0, 0, 0}, us[3] = {0, 0, 0};
    clvox_ovr tol_lo = 0, tol_up = 0;
    for (int i = 0; i < 4; i++) {
        if (clvox_face_constant(&f[i])) {
            cst_idx[ncst++] = i;
            continue;
        }
        const int lower = clvox_face_lower(&f[i]);
        if ((lower ? nlo : nup) == 3) return; /* all four on one side: cannot cover anything */
        clvox_ovr A, Ay, Az, c1, sl;
        const clvox_ovr tol = clvox_face_root(&f[i], Dy, (clvox_ovr)task[1], (clvox_ovr)task[2], (clvox_ovr)Y, &A, &Ay,
                                              &Az, &c1, &sl);
        if (lower) {
            lax[nlo] = A, lay[nlo] = Ay, laz[nlo] = Az, lc1[nlo] = c1, ls[nlo] = sl, tol_lo = fmax(tol_lo, tol);
            lo_idx[nlo++] = i;
        } else {
            uax[nup] = A, uay[nup] = Ay, uaz[nup] = Az, uc1[nup] = c1, us[nup] = sl, tol_up = fmax(tol_up, tol);
            up_idx[nup++] = i;
        }
    }

    const clvox_ovr Yd = (clvox_ovr)Y, Xd = (clvox_ovr)X, Kend = (clvox_ovr)task[2];
    const clvox_ovr widen = (clvox_ovr)2 * m * fmax(fmax(fmax(fabs(e[0]), fabs(e[1])), fmax(fabs(e[2]), fabs(e[3]))),
                                                    fmax(fabs(e[4]), fabs(e[5])));
    const int iX = (int)X;
    for (uint k4 = task[1]; k4 < task[2]; k4 += 4) {
        /* Four slices at a time. Rows: the y-range of the part of the
         * tetrahedron between the planes k - m and k + m. With kc = k clamped
         * to [D.z, A.z] (k itself or a vertex within m), that is the section
         * at kc widened by 2m times the steepest edge; with steep (nearly
         * horizontal) edges, the sections at k -+ m and the vertices in
         * between. Then m more. */
        const clvox_ovr4 kd4 = (clvox_ovr)k4 + (clvox_ovr4)((clvox_ovr)0, (clvox_ovr)1, (clvox_ovr)2, (clvox_ovr)3);
        clvox_ovr4 lo4, hi4;
        if (widen < (clvox_ovr)0.5) {
            const clvox_ovr4 kc = fmin(fmax(kd4, vz[3]), vz[0]);
            clvox_section4(vy, vz, kc, e, &lo4, &hi4);
            const clvox_ovm4 far = fabs(kd4 - kc) > m;
            lo4 = select(lo4 - widen, (clvox_ovr4)((clvox_ovr)INFINITY), far);
            hi4 = select(hi4 + widen, (clvox_ovr4)((clvox_ovr)-INFINITY), far);
        } else {
            clvox_ovr los[4], his[4];
            for (int q = 0; q < 4; q++) {
                const clvox_ovr kd = (clvox_ovr)(k4 + q);
                clvox_ovr lo = INFINITY, hi = -INFINITY;
                for (int i = 0; i < 4; i++)
                    if (fabs(vz[i] - kd) <= m) {
                        lo = fmin(lo, vy[i]);
                        hi = fmax(hi, vy[i]);
                    }
                for (int i = -1; i <= 1; i += 2) {
                    clvox_ovr h = kd + (clvox_ovr)i * m, l2, h2;
                    if (h < vz[3] || h > vz[0]) continue;
                    clvox_section(vy, vz, h, e, &l2, &h2);
                    lo = fmin(lo, l2);
                    hi = fmax(hi, h2);
                }
                los[q] = lo;
                his[q] = hi;
            }
            lo4 = vload4(0, los);
            hi4 = vload4(0, his);
        }
        /* Rows r = 0, 1, ... of the four slices at once: lane q handles row
         * j0_q + r of slice k4 + q while there is one. */
        const clvox_ovr4 jlo4 = fmax(fmax(ceil(lo4 - m), ceil(ylo - (clvox_ovr)1)), (clvox_ovr)0);
        clvox_ovr4 jhi4 = fmin(fmin(floor(hi4 + m), floor(yhi + (clvox_ovr)1)), Yd - (clvox_ovr)1);
        jhi4 = select(jhi4, (clvox_ovr4)((clvox_ovr)-1), kd4 >= Kend); /* past the task */
        const clvox_ovr4 nr4 = fmax(jhi4 - jlo4 + (clvox_ovr)1, (clvox_ovr)0); /* 0 for empty (also inf) */
        const clvox_ovr rmax = fmax(fmax(nr4.s0, nr4.s1), fmax(nr4.s2, nr4.s3));
        if (rmax == (clvox_ovr)0) continue;
        const clvox_ovr4 lb0 = lax[0] + (kd4 - laz[0]) * lc1[0], lb1 = lax[1] + (kd4 - laz[1]) * lc1[1],
                         lb2 = lax[2] + (kd4 - laz[2]) * lc1[2];
        const clvox_ovr4 ub0 = uax[0] + (kd4 - uaz[0]) * uc1[0], ub1 = uax[1] + (kd4 - uaz[1]) * uc1[1],
                         ub2 = uax[2] + (kd4 - uaz[2]) * uc1[2];
        const int4 nr = convert_int4(nr4), j0 = convert_int4(select(jlo4, (clvox_ovr4)((clvox_ovr)0), nr4 == (clvox_ovr)0));
        const clvox_ovr4 y0 = clvox_convert_ovr4(j0);
        for (int r = 0; r < (int)rmax; r++) {
            const clvox_ovr4 y4 = y0 + (clvox_ovr)r;
            /* max/min, not fmax/fmin: no root is NaN (finite face data,
             * padding at -+inf) and they compile to single instructions. */
            const clvox_ovr4 xl = max(max(lb0 + (y4 - lay[0]) * ls[0], lb1 + (y4 - lay[1]) * ls[1]),
                                      lb2 + (y4 - lay[2]) * ls[2]);
            const clvox_ovr4 xu = min(min(ub0 + (y4 - uay[0]) * us[0], ub1 + (y4 - uay[1]) * us[1]),
                                      ub2 + (y4 - uay[2]) * us[2]);
            const int4 L4 = clvox_bound4(xl, tol_lo, Xd), U4 = clvox_bound4(xu, tol_up, Xd);
            /* Lanes with a row and a span that may be non-empty (or unknown). */
            const int4 live = ((int4)(r) < nr) & ((L4 < U4) | (L4 < 0) | (U4 < 0) | (int4)(ncst ? -1 : 0));
            if (!any(live)) continue;
            const int4 jr = j0 + r;
            if (!ncst && !any(L4 < 0) && !any(U4 < 0)) {
                /* The common case: every span known, live lanes non-empty.
                 * Lanes taken apart statically (no private arrays indexed
                 * at run time). */
                size_t base = (size_t)(k4 - z0) * Y;
                if (live.s0) clvox_span_xor(bits + (base + (size_t)jr.s0) * words_per_row, L4.s0, U4.s0, iX);
                if (live.s1) clvox_span_xor(bits + (base + Y + (size_t)jr.s1) * words_per_row, L4.s1, U4.s1, iX);
                if (live.s2) clvox_span_xor(bits + (base + 2 * Y + (size_t)jr.s2) * words_per_row, L4.s2, U4.s2, iX);
                if (live.s3) clvox_span_xor(bits + (base + 3 * Y + (size_t)jr.s3) * words_per_row, L4.s3, U4.s3, iX);
                continue;
            }
            int Ls[4], Us[4], Js[4], lv[4];
            vstore4(L4, 0, Ls);
            vstore4(U4, 0, Us);
            vstore4(jr, 0, Js);
            vstore4(live, 0, lv);
            for (int q = 0; q < 4; q++) {
                if (!lv[q]) continue;
                const int j = Js[q];
                const uint k = k4 + (uint)q;
                const clvox_ovr yd = (clvox_ovr)j, kd = (clvox_ovr)k;
                if (ncst && clvox_row_outside(f, cst_idx, ncst, yd, kd)) continue;
                const int L = Ls[q] >= 0 ? Ls[q] : clvox_group_exact(f, lo_idx, nlo, yd, kd, iX, 0);
                const int U = Us[q] >= 0 ? Us[q] : clvox_group_exact(f, up_idx, nup, yd, kd, iX, 1);
                if (L >= U) continue;
                clvox_span_xor(bits + ((size_t)(k - z0) * Y + (size_t)j) * words_per_row, L, U, iX);
            }
        }
    }
}

/* The kernel: the body, then the launch's completion count (clvox_done,
 * prelude.cl). */
kernel void clvox_tetra_raster(global const float *soup, global const uint *tasks, uint task_count, float ox,
                               float oy, float oz, uint tie_order, uint z0, uint X, uint Y, uint words_per_row,
                               global uint *bits,
                               global uint *clvox_done, uint clvox_done_slot)
{
    clvox_tetra_raster_body(soup, tasks, task_count, ox, oy, oz, tie_order, z0, X, Y, words_per_row, bits);
    clvox_done_mark(clvox_done, clvox_done_slot);
}


/* Prefix XOR along each row, in place: difference markers -> occupancy bits
 * (the slab format of src/core/internal.h, bits past X cleared), and the count
 * of filled voxels. rows = Y * nz. */
static void clvox_tetra_resolve_body(global uint *bits, uint words_per_row, uint X, uint rows, global uint *filled)
{
    uint r = get_global_id(0);
    if (r >= rows) return;
    global uint *w = bits + (size_t)r * words_per_row;
    uint carry = 0, count = 0;
    for (uint i = 0; i < words_per_row; i++) {
        uint v = w[i];
        v ^= v << 1;
        v ^= v << 2;
        v ^= v << 4;
        v ^= v << 8;
        v ^= v << 16;
        if (carry) v = ~v;
        carry = v >> 31;
        uint n = min(32u, X - i * 32u);
        if (n < 32u) v &= (1u << n) - 1u;
        count += popcount(v);
        w[i] = v;
    }
    if (count) atomic_add(filled, count);
}

/* The kernel: the body, then the launch's completion count (clvox_done,
 * prelude.cl). */
kernel void clvox_tetra_resolve(global uint *bits, uint words_per_row, uint X, uint rows, global uint *filled,
                                global uint *clvox_done, uint clvox_done_slot)
{
    clvox_tetra_resolve_body(bits, words_per_row, X, rows, filled);
    clvox_done_mark(clvox_done, clvox_done_slot);
}

