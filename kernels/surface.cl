/* SPDX-License-Identifier: Apache-2.0 */
/* Stage surface: every voxel whose closed cell meets a triangle (src/raster/surface.c
 * has the argument). Each task rasterises one triangle over a few slices z =
 * k and rows y = j of the current slab: per row, the cells x whose closed box
 * [x -+ 1/2] x [j -+ 1/2] x [k -+ 1/2] meets the closed triangle form one
 * interval [L, U], found with the separating-axis test of a triangle against
 * a box (13 axes: the box normals, the triangle normal, the 9 cross products
 * of box and triangle edges; zero axes dropped, so degenerate triangles work
 * too). Each axis gives two predicates, each the exact sign of an affine
 * function of the cell centre (kernels/overlap.h); along a row one is
 * monotone increasing and one decreasing in x, or both constant. The row's
 * interval is where all hold: L and U are located from the approximate
 * roots and settled by exact evaluation at the integers around them, so
 * the interval is exactly that of the per-cell test. OR-ed into the slab's
 * bit rows with atomic_or; a second kernel counts the slab's filled bits.
 * Rows run along x, y or z, whichever gives the task's box the fewest rows
 * (the triangle is permuted into a frame whose first coordinate is the row
 * axis, and the cells are mapped back; docs/design.md "Row direction"). */

/* Row directions the raster may choose per task: 1 = x only, 2 = x or y,
 * 3 = x, y or z (the fewest rows). */
#ifndef CLVOX_SURFACE_ROW_AXES
#define CLVOX_SURFACE_ROW_AXES 3
#endif

/* In clvox_ovr (kernels/overlap.h): clvox_ovr where the device has fp64,
 * float where it has not; every decision is an exact sign either way, so
 * both give the same voxels. Every operation rounded as written (the
 * filters' error bounds assume it). */
#pragma OPENCL FP_CONTRACT OFF

/* One separating-axis predicate: the sign of an affine function of the
 * cell centre c, which must be >= 0 (want > 0) or <= 0 (want < 0) for the
 * cell to meet the triangle on that side of the axis.
 * kind 0: clvox_e2_sign(a, b, c0, c + o) in the projection (s, t), with
 *         ds, dt = b - a rounded as clvox_e2_sign rounds them;
 * kind 1: clvox_o3_sign(v0, v1, v2, c + o). */
typedef struct clvox_spred {
    clvox_ovr ds, dt, cs, ct; /* kind 0: b - a (rounded), c0 in (s, t) */
    clvox_ovr r0, ry, rz;     /* approximate root along x: r0 + ry*y + rz*z (x-dependent ones) */
    float o[3];            /* corner offset, -+0.5 per axis */
    uchar kind, s, t, a, b, c0;
    char want;
    uchar pad;
} clvox_spred;

static inline clvox_ovr clvox_coord(uint axis, clvox_ovr x, clvox_ovr y, clvox_ovr z) { return axis == 0 ? x : axis == 1 ? y : z; }

static inline int clvox_spred_holds(const clvox_spred *p, const clvox_ovr *v, const clvox_ovr *om, clvox_ovr x, clvox_ovr y,
                                    clvox_ovr z)
{
    int sg;
    if (p->kind == 0) {
        /* clvox_e2_sign with the differences b - a already taken */
        const clvox_ovr Cs = clvox_coord(p->s, x, y, z) + (clvox_ovr)p->o[p->s];
        const clvox_ovr Ct = clvox_coord(p->t, x, y, z) + (clvox_ovr)p->o[p->t];
        const clvox_ovr l = p->ds * (Ct - p->ct), r = p->dt * (Cs - p->cs);
        const clvox_ovr det = l - r, bound = CLVOX_OV_BOUND(CLVOX_OV_E2_ERR * (fabs(l) + fabs(r)));
        if (det > bound) sg = 1;
        else if (-det > bound) sg = -1;
        else
            sg = clvox_e2_exact(v[3 * p->a + p->s], v[3 * p->a + p->t], v[3 * p->b + p->s], v[3 * p->b + p->t], p->cs,
                                p->ct, Cs, Ct);
    } else {
        sg = clvox_o3_sign_pre(v, om, om + 3, x + (clvox_ovr)p->o[0], y + (clvox_ovr)p->o[1], z + (clvox_ovr)p->o[2]);
    }
    return p->want > 0 ? sg >= 0 : sg <= 0;
}

/* clvox_spred_holds out of line: the rows' fallback when a filter cannot
 * decide (rare), kept out of their loops. */
static __attribute__((noinline)) int clvox_spred_holds_cold(const clvox_spred *p, const clvox_ovr *v,
                                                            const clvox_ovr *om, clvox_ovr x, clvox_ovr y, clvox_ovr z)
{
    return clvox_spred_holds(p, v, om, x, y, z);
}

/* All predicates of one group hold at cell x of the row (idx[first] tried first). */
static inline int clvox_group_holds(const clvox_spred *p, const uchar *idx, int n, int first, const clvox_ovr *v,
                                    const clvox_ovr *om, int x, clvox_ovr y, clvox_ovr z)
{
    const clvox_ovr xd = (clvox_ovr)x;
    if (n && !clvox_spred_holds(&p[idx[first]], v, om, xd, y, z)) return 0;
    for (int i = 0; i < n; i++)
        if (i != first && !clvox_spred_holds(&p[idx[i]], v, om, xd, y, z)) return 0;
    return 1;
}

/* An x-dependent predicate specialised to one row (y, z fixed): the same
 * operations as clvox_spred_holds with the row's constant parts hoisted,
 * both kinds in one form, w = (x + off) - base,
 *     value = (w * coef + A) + A2,   bound = err * ((|w| * pcoef + B) + B2):
 * kind 0 (var = coef * w, the other product P): A = -P, A2 = B2 = 0,
 *         pcoef = |coef|, B = |P|, so value = var - P (IEEE: x + (-y) is
 *         x - y, + 0 changes no comparison) = flip * the determinant (IEEE
 *         subtraction is exactly antisymmetric) and bound = E2 * (|P| +
 *         |var|) (|w| |coef| rounds to |w coef|), clvox_e2_sign's filter;
 * kind 1: det = (wx * coef + A) + A2, perm = (|wx| * pcoef + B) + B2, as
 *         clvox_o3_sign_pre sums them.
 * dir = +-1 folds flip and want: the predicate holds iff dir * value >= 0,
 * decided when |value| > bound; otherwise clvox_spred_holds re-evaluates it
 * (filter, then the exact expansion). */
typedef struct clvox_rpred {
    clvox_ovr coef, off, base, A, A2, pcoef, B, B2, err, dir;
    uchar idx;
    uchar pad[7];
} clvox_rpred;

static inline void clvox_rpred_setup(clvox_rpred *r, const clvox_spred *p, uchar idx, const clvox_ovr *v, const clvox_ovr *om,
                                     clvox_ovr y, clvox_ovr z)
{
    r->idx = idx;
    clvox_ovr flip;
    if (p->kind == 0) {
        /* s or t is x (the slope along x is not 0) */
        const int sx = p->s == 0;
        const uint ca = sx ? p->t : p->s; /* the constant coordinate */
        const clvox_ovr Cc = clvox_coord(ca, (clvox_ovr)0, y, z) + (clvox_ovr)p->o[ca];
        clvox_ovr A;
        if (sx) { /* det = ds (Ct - ct) - dt (Cs - cs), Cs = x + os */
            A = p->ds * (Cc - p->ct);
            r->coef = p->dt, r->off = (clvox_ovr)p->o[p->s], r->base = p->cs, flip = -(clvox_ovr)1;
        } else { /* t is x: det = ds (Ct - ct) - dt (Cs - cs), Ct = x + ot */
            A = p->dt * (Cc - p->cs);
            r->coef = p->ds, r->off = (clvox_ovr)p->o[p->t], r->base = p->ct, flip = (clvox_ovr)1;
        }
        /* var - A as (var + (-A)) + 0 and |A| + |var| as (|w| |coef| + |A|)
         * + 0: the same values (|w| |coef| = |w coef| exactly) */
        r->A = -A, r->A2 = (clvox_ovr)0;
        r->pcoef = fabs(r->coef), r->B = fabs(A), r->B2 = (clvox_ovr)0;
        r->err = CLVOX_OV_E2_ERR;
    } else {
        const clvox_ovr wy = (y + (clvox_ovr)p->o[1]) - v[1], wz = (z + (clvox_ovr)p->o[2]) - v[2];
        r->coef = om[0], r->off = (clvox_ovr)p->o[0], r->base = v[0];
        r->A = wy * om[1], r->A2 = wz * om[2];
        r->pcoef = om[3], r->B = fabs(wy) * om[4], r->B2 = fabs(wz) * om[5];
        r->err = CLVOX_OV_O3_ERR;
        flip = (clvox_ovr)1;
    }
    r->dir = p->want > 0 ? flip : -flip; /* holds iff dir * det >= 0 */
}

static inline int clvox_rpred_holds(const clvox_rpred *r, const clvox_spred *p, const clvox_ovr *v, const clvox_ovr *om,
                                    int x, clvox_ovr y, clvox_ovr z)
{
    const clvox_ovr xd = (clvox_ovr)x;
    const clvox_ovr w = (xd + r->off) - r->base;
    /* kind 0: flip * det = var - A; kind 1: det; times dir = +-1 (exact) */
    const clvox_ovr sd = r->dir * ((w * r->coef + r->A) + r->A2);
    const clvox_ovr bound = CLVOX_OV_BOUND(r->err * ((fabs(w) * r->pcoef + r->B) + r->B2));
    if (sd > bound) return 1;
    if (-sd > bound) return 0;
    return clvox_spred_holds_cold(&p[r->idx], v, om, xd, y, z);
}

/* All row predicates hold at x (rp[first] tried first). */
static inline int clvox_rgroup_holds(const clvox_rpred *rp, int n, int first, const clvox_spred *p, const clvox_ovr *v,
                                     const clvox_ovr *om, int x, clvox_ovr y, clvox_ovr z)
{
    if (n && !clvox_rpred_holds(&rp[first], p, v, om, x, y, z)) return 0;
    for (int i = 0; i < n; i++)
        if (i != first && !clvox_rpred_holds(&rp[i], p, v, om, x, y, z)) return 0;
    return 1;
}

/* Smallest i of [lo, hi] with i + 1/2 >= m, or hi + 1; largest with
 * i - 1/2 <= m, or lo - 1 (exact comparisons; m a float). */
static inline int clvox_first_cell(clvox_ovr m, int lo, int hi)
{
    if (m <= (clvox_ovr)lo - (clvox_ovr)0.5) return lo;
    if (!(m <= (clvox_ovr)hi + (clvox_ovr)0.5)) return hi + 1;
    int i = (int)ceil(m - (clvox_ovr)0.5);
    while (i > lo && (clvox_ovr)(i - 1) + (clvox_ovr)0.5 >= m) i--;
    while (i <= hi && (clvox_ovr)i + (clvox_ovr)0.5 < m) i++;
    return i;
}
static inline int clvox_last_cell(clvox_ovr m, int lo, int hi)
{
    if (m >= (clvox_ovr)hi + (clvox_ovr)0.5) return hi;
    if (!(m >= (clvox_ovr)lo - (clvox_ovr)0.5)) return lo - 1;
    int i = (int)floor(m + (clvox_ovr)0.5);
    while (i < hi && (clvox_ovr)(i + 1) - (clvox_ovr)0.5 <= m) i++;
    while (i >= lo && (clvox_ovr)i - (clvox_ovr)0.5 > m) i--;
    return i;
}

/* Sets bits L..U (inclusive) of a row. */
static inline void clvox_row_or(global uint *row, int L, int U)
{
    int wl = L >> 5, wu = U >> 5;
    uint ml = ~0u << (L & 31), mu = ~0u >> (31 - (U & 31));
    if (wl == wu) {
        atomic_or(row + wl, ml & mu);
        return;
    }
    atomic_or(row + wl, ml);
    for (int w = wl + 1; w < wu; w++) atomic_or(row + w, ~0u);
    atomic_or(row + wu, mu);
}

/* tasks: 4 uints each (triangle, first slice, end slice, first row | last
 * row << 16), in grid coordinates. bits: the slab's bit rows, row
 * (k - z0) * Y + j of words_per_row words. */
static void clvox_surface_raster_body(global const float *soup, global const uint *tasks, uint task_count, uint z0,
                                      uint X, uint words_per_row, uint Y, global uint *bits)
{
    uint gid = get_global_id(0);
    if (gid >= task_count) return;
    global const uint *task = tasks + (size_t)gid * 4;
    global const float *tp = soup + (size_t)task[0] * 9;
    clvox_ovr w[9]; /* grid space */
    for (int i = 0; i < 9; i++) w[i] = (clvox_ovr)tp[i];

    /* The task's cells per axis (exact closed-extent ranges; y and z from
     * the host, already clipped to the task). */
    int lo[3], hi[3];
    lo[0] = clvox_first_cell(fmin(fmin(w[0], w[3]), w[6]), 0, (int)X - 1);
    hi[0] = clvox_last_cell(fmax(fmax(w[0], w[3]), w[6]), 0, (int)X - 1);
    if (lo[0] > hi[0]) return;
    const uint jr = task[3];
    lo[1] = (int)(jr & 0xFFFFu), hi[1] = (int)(jr >> 16);
    lo[2] = (int)task[1], hi[2] = (int)task[2] - 1;

    /* Row axis: the one with the fewest rows in the task's box (rows along
     * axis a = the product of the other two extents), x on ties. Each
     * predicate below is built in a frame whose coordinate 0 is the row
     * axis (axis perm[c] of grid space is frame coordinate c; the unit
     * cube and the integer lattice are the same in every frame, and every
     * sign is exact, so the cells found are those of the per-cell test
     * whatever the frame). */
    const long n0 = hi[0] - lo[0] + 1, n1 = hi[1] - lo[1] + 1, n2 = hi[2] - lo[2] + 1;
    int row_axis = 0;
#if CLVOX_SURFACE_ROW_AXES > 1
    {
        long best = n1 * n2;
        if (n0 * n2 < best) best = n0 * n2, row_axis = 1;
#if CLVOX_SURFACE_ROW_AXES > 2
        if (n0 * n1 < best) row_axis = 2;
#endif
    }
#endif
    /* frames: x rows (x, y, z), y rows (y, x, z), z rows (z, x, y) */
    const int perm0 = row_axis, perm1 = row_axis == 0 ? 1 : 0, perm2 = row_axis == 2 ? 1 : 2;
    clvox_ovr v[9];
    for (int i = 0; i < 3; i++) {
        v[3 * i] = w[3 * i + perm0];
        v[3 * i + 1] = w[3 * i + perm1];
        v[3 * i + 2] = w[3 * i + perm2];
    }
    const int xlo = lo[perm0], xhi = hi[perm0]; /* the row's range (frame coordinate 0) */

    /* Exact signs of the normal's components: n_k is the orientation of the
     * triangle projected along axis k, in the cyclic coordinates (s, t). */
    int sn[3];
    clvox_ovr na[3]; /* approximate normal */
    for (int k = 0; k < 3; k++) {
        int s = (k + 1) % 3, t = (k + 2) % 3;
        sn[k] = clvox_e2_sign(v[s], v[t], v[3 + s], v[3 + t], v[s], v[t], v[6 + s], v[6 + t]);
        na[k] = (v[3 + s] - v[s]) * (v[6 + t] - v[t]) - (v[3 + t] - v[t]) * (v[6 + s] - v[s]);
    }

    clvox_spred p[20];
    uchar cst[20], lower[20], upper[20];
    int np = 0, ncst = 0, nlo = 0, nup = 0;
    /* Edge axes: projection along k, edge m = (a -> b), third vertex r;
     * f(X) = (b - a) x (X - a) is 0 on the edge and n_k at r. The box's
     * largest f is at the corner c + o+ (o+ = half the sign of grad f), its
     * smallest at c - o+. Not separated: f(c + o+) >= min(0, n_k) and
     * f(c - o+) <= max(0, n_k). */
    for (int k = 0; k < 3; k++) {
        const int s = (k + 1) % 3, t = (k + 2) % 3;
        for (int m = 0; m < 3; m++) {
            const int a = m, b = (m + 1) % 3, r = (m + 2) % 3;
            const clvox_ovr ds = v[3 * b + s] - v[3 * a + s], dt = v[3 * b + t] - v[3 * a + t];
            const int gs = v[3 * b + t] < v[3 * a + t] ? 1 : v[3 * b + t] > v[3 * a + t] ? -1 : 0; /* sign(-dt) */
            const int gt = v[3 * b + s] > v[3 * a + s] ? 1 : v[3 * b + s] < v[3 * a + s] ? -1 : 0; /* sign(ds) */
            if (!gs && !gt) continue; /* a point in this projection: no axis */
            for (int side = 0; side < 2; side++) {
                /* With n_k != 0 (exactly) the projection along k is a proper
                 * triangle and only the outward side of edge m (c0 = a) is a
                 * facet normal of triangle - box: the side against the third
                 * vertex r never separates alone, so it is skipped (the
                 * volume is the same; ~40 % fewer evaluations per row). */
                if (sn[k] > 0 ? side == 1 : sn[k] < 0 ? side == 0 : 0) continue;
                clvox_spred *q = &p[np];
                const float os = (side ? -0.5f : 0.5f) * (gs ? (float)gs : 1.0f);
                const float ot = (side ? -0.5f : 0.5f) * (gt ? (float)gt : 1.0f);
                q->o[k] = 0.0f;
                q->o[s] = os;
                q->o[t] = ot;
                q->kind = 0;
                q->s = (uchar)s;
                q->t = (uchar)t;
                q->a = (uchar)a;
                q->b = (uchar)b;
                /* side 0: f(c + o+) >= 0 (n_k >= 0) or f(c + o+) - n_k >= 0 (n_k < 0);
                 * side 1: f(c - o+) - n_k <= 0 (n_k >= 0) or f(c - o+) <= 0 (n_k < 0). */
                const int use_r = side == 0 ? sn[k] < 0 : sn[k] >= 0;
                q->c0 = (uchar)(use_r ? r : a);
                q->want = (char)(side ? -1 : 1);
                /* value = ds (C.t - c0.t) - dt (C.s - c0.s), C = c + o */
                clvox_ovr g[3] = {(clvox_ovr)0, (clvox_ovr)0, (clvox_ovr)0};
                g[s] = -dt;
                g[t] = ds;
                const clvox_ovr h = ds * ((clvox_ovr)ot - v[3 * q->c0 + t]) - dt * ((clvox_ovr)os - v[3 * q->c0 + s]);
                q->ds = ds, q->dt = dt, q->cs = v[3 * q->c0 + s], q->ct = v[3 * q->c0 + t];
                const clvox_ovr inv = -(clvox_ovr)1 / g[0]; /* inf when g[0] == 0: then unused */
                q->r0 = h * inv, q->ry = g[1] * inv, q->rz = g[2] * inv;
                /* exact slope along x: ds when t is x, -dt when s is x, none when k is x */
                const int slope = t == 0 ? gt : s == 0 ? gs : 0;
                const int incr = slope * q->want; /* > 0: holds from some x on */
                if (incr == 0) cst[ncst++] = (uchar)np;
                else if (incr > 0) lower[nlo++] = (uchar)np;
                else upper[nup++] = (uchar)np;
                np++;
            }
        }
    }
    /* Triangle normal: n . (c + o+ - v0) >= 0 and n . (c - o+ - v0) <= 0,
     * o+ = half the sign of n; no axis when n == 0 (degenerate triangle). */
    if (sn[0] || sn[1] || sn[2]) {
        for (int side = 0; side < 2; side++) {
            clvox_spred *q = &p[np];
            for (int i = 0; i < 3; i++) q->o[i] = (side ? -0.5f : 0.5f) * (sn[i] ? (float)sn[i] : 1.0f);
            q->kind = 1;
            q->s = q->t = q->a = q->b = q->c0 = 0;
            q->want = (char)(side ? -1 : 1);
            const clvox_ovr h = na[0] * ((clvox_ovr)q->o[0] - v[0]) + na[1] * ((clvox_ovr)q->o[1] - v[1]) +
                             na[2] * ((clvox_ovr)q->o[2] - v[2]);
            q->ds = q->dt = q->cs = q->ct = (clvox_ovr)0;
            const clvox_ovr inv = -(clvox_ovr)1 / na[0];
            q->r0 = h * inv, q->ry = na[1] * inv, q->rz = na[2] * inv;
            const int incr = sn[0] * q->want;
            if (incr == 0) cst[ncst++] = (uchar)np;
            else if (incr > 0) lower[nlo++] = (uchar)np;
            else upper[nup++] = (uchar)np;
            np++;
        }
    }

    clvox_ovr om[6]; /* the triangle's part of the plane predicates' filter */
    clvox_o3_setup(v, om, om + 3);
    const int j0 = lo[perm1], j1 = hi[perm1];
    const clvox_ovr xlod = (clvox_ovr)xlo, xhid = (clvox_ovr)xhi;
    for (int k = lo[perm2]; k <= hi[perm2]; k++) {
        const clvox_ovr kd = (clvox_ovr)k;
        for (int j = j0; j <= j1; j++) {
            const clvox_ovr yd = (clvox_ovr)j;
            if (!clvox_group_holds(p, cst, ncst, 0, v, om, xlo, yd, kd)) continue;
            clvox_rpred rlo[20], rup[20];
            for (int i = 0; i < nlo; i++) clvox_rpred_setup(&rlo[i], &p[lower[i]], lower[i], v, om, yd, kd);
            /* L: first x of [xlo, xhi] where every lower predicate holds;
             * the one with the largest approximate root is tried first */
            clvox_ovr guess = xlod;
            int first = 0;
            for (int i = 0; i < nlo; i++) {
                const clvox_spred *q = &p[lower[i]];
                clvox_ovr root = q->r0 + q->ry * yd + q->rz * kd;
                if (root > guess) guess = root, first = i; /* NaN ignored */
            }
            int L = (int)ceil(fmin(guess, xhid));
            if (clvox_rgroup_holds(rlo, nlo, first, p, v, om, L, yd, kd)) {
                while (L > xlo && clvox_rgroup_holds(rlo, nlo, first, p, v, om, L - 1, yd, kd)) L--;
            } else {
                do L++;
                while (L <= xhi && !clvox_rgroup_holds(rlo, nlo, first, p, v, om, L, yd, kd));
                if (L > xhi) continue;
            }
            /* U: last x of [L, xhi] where every upper predicate holds */
            for (int i = 0; i < nup; i++) clvox_rpred_setup(&rup[i], &p[upper[i]], upper[i], v, om, yd, kd);
            guess = xhid;
            first = 0;
            for (int i = 0; i < nup; i++) {
                const clvox_spred *q = &p[upper[i]];
                clvox_ovr root = q->r0 + q->ry * yd + q->rz * kd;
                if (root < guess) guess = root, first = i;
            }
            int U = (int)floor(fmax(guess, (clvox_ovr)L));
            if (clvox_rgroup_holds(rup, nup, first, p, v, om, U, yd, kd)) {
                while (U < xhi && clvox_rgroup_holds(rup, nup, first, p, v, om, U + 1, yd, kd)) U++;
            } else {
                do U--;
                while (U >= L && !clvox_rgroup_holds(rup, nup, first, p, v, om, U, yd, kd));
                if (U < L) continue;
            }
            /* cells L..U of the row, back in grid space */
            if (row_axis == 0) {
                clvox_row_or(bits + ((size_t)(k - (int)z0) * Y + (size_t)j) * words_per_row, L, U);
            } else if (row_axis == 1) { /* (y, x, z): x = j, z = k, cells along y */
                global uint *word = bits + ((size_t)(k - (int)z0) * Y + (size_t)L) * words_per_row + (j >> 5);
                const uint bit = 1u << (j & 31);
                for (int c = L; c <= U; c++, word += words_per_row) atomic_or(word, bit);
            } else { /* (z, x, y): x = j, y = k, cells along z */
                const size_t stride = (size_t)Y * words_per_row;
                global uint *word = bits + ((size_t)(L - (int)z0) * Y + (size_t)k) * words_per_row + (j >> 5);
                const uint bit = 1u << (j & 31);
                for (int c = L; c <= U; c++, word += stride) atomic_or(word, bit);
            }
        }
    }
}

/* The kernel: the body, then the launch's completion count (clvox_done,
 * prelude.cl). */
kernel void clvox_surface_raster(global const float *soup, global const uint *tasks, uint task_count, uint z0,
                                 uint X, uint words_per_row, uint Y, global uint *bits,
                                 global uint *clvox_done, uint clvox_done_slot)
{
    clvox_surface_raster_body(soup, tasks, task_count, z0, X, words_per_row, Y, bits);
    clvox_done_mark(clvox_done, clvox_done_slot);
}

/* Filled voxels of the slab's bit rows (rows = Y * nz; bits past X are 0). */
static void clvox_surface_count_body(global const uint *bits, uint words_per_row, uint rows, global uint *filled)
{
    uint r = get_global_id(0);
    if (r >= rows) return;
    global const uint *w = bits + (size_t)r * words_per_row;
    uint count = 0;
    for (uint i = 0; i < words_per_row; i++) count += popcount(w[i]);
    if (count) atomic_add(filled, count);
}

/* The kernel: the body, then the launch's completion count (clvox_done,
 * prelude.cl). */
kernel void clvox_surface_count(global const uint *bits, uint words_per_row, uint rows, global uint *filled,
                                global uint *clvox_done, uint clvox_done_slot)
{
    clvox_surface_count_body(bits, words_per_row, rows, filled);
    clvox_done_mark(clvox_done, clvox_done_slot);
}

