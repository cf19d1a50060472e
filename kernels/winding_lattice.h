/* SPDX-License-Identifier: Apache-2.0 */
/* Winding numbers (winding_angles.h): the caps' solid angle interpolated
 * across blocks of voxels, so that one traversal of the cap tree serves
 * many voxels (kernels/winding_lattice.cl builds it per slab; the classify,
 * kernels/winding.cl, reads it).
 *
 * w = K - w_caps, K the signed crossings beyond the voxel (the ray's,
 * exact), w_caps the caps' solid angle / 4pi. In a block of S^3 voxels
 * (corners on the lattice of every S-th voxel centre, S a power of two
 * chosen per run, src/cast/winding_lattice.c) whose closed box no
 * cap touches, w_caps is smooth: its gradient is the rims' field (winding_
 * rims.h), so |d^2 w_caps / dx_a^2| <= M2_a over the block (the rim tree
 * refined against the block's box). Trilinear interpolation of f = w_caps
 * from the corners is off by at most the sum over the axes of the 1-D
 * errors, M2_a (x_a - a_a)(b_a - x_a) / 2 (f - I_x I_y I_z f = (f - I_x f)
 * + I_x (f - I_y f) + I_x I_y (f - I_z f), each I a convex combination of
 * values inside the block). The corners hold certified intervals of w_caps
 * (to about CLVOX_LATTICE_EPS), so a voxel's w lies in an interval that
 * decides it where it lies on one side of the threshold; where not, the
 * classify evaluates it as before. A block the caps' bound keeps under 1/2
 * everywhere is decided by K alone (its bound stored, for the interval).
 * Used on cubic voxels only (CLVOX_CUBIC: the lattice points' scaled
 * coordinates are exact). */
#define CLVOX_LATTICE_EPS 2e-2    /* a lattice value's interval width aimed at, at least */
#define CLVOX_LATTICE_STEPS 256u  /* its refinement steps at most */
#define CLVOX_BLOCK_STEPS 96u     /* a block's rim refinement steps */
#define CLVOX_BLOCK_FAR_BUDGET 24u
#define CLVOX_BLOCK_USABLE 0.4    /* a block's largest interpolation error (at its centre) worth its points */
#define CLVOX_BLOCK_ENOUGH 0.02   /* an error there small enough to stop refining its M2 */
#define CLVOX_BLOCK_SPLIT 2       /* word 4 of a block split in near and far caps (else 1 interpolates, 0 not) */
#define CLVOX_NEAR_BLOCKS 2u      /* the near caps' reach, in blocks */
#define CLVOX_NEAR_AREA 8.0       /* the near caps' area at most, in (reach)^2: larger caps are left to the ray */
#if defined(CLVOX_FP64)
#define CLVOX_LERP_ERR 1e-12 /* an interpolation's rounding, of the values' size (here and along a ray) */
#else
#define CLVOX_LERP_ERR 1e-5f
#endif

/* The caps' w_caps at p (scaled x, y, z; g its grid coordinates) within
 * [*lo, *hi]: the cap tree refined best first (as clvox_winding_inside_m)
 * until the interval is `width` wide or the steps run out (the interval
 * holds either way). */
static inline void clvox_caps_interval(global const clvox_cap_node *nodes, global const clvox_real *caps,
                                       global const float *gcaps, const clvox_real *g, clvox_real px, clvox_real py,
                                       clvox_real pz, uint axis, clvox_real width, clvox_real *lo, clvox_real *hi)
{
    const clvox_real dp = clvox_point_rounding(px, py, pz, axis);
    uint stack[CLVOX_CAP_STACK];
    clvox_real se[CLVOX_CAP_STACK], sb[CLVOX_CAP_STACK];
    uint sp = 1;
    stack[0] = 0;
    clvox_cap_estimate(nodes, px, py, pz, dp, 0, &se[0], &sb[0]);
    clvox_real S = 0, serr = 0, Br = sb[0]; /* Br: the frontier's bounds, a running sum */
    for (uint it = 0;; it++) {
        /* the running sum only picks when to sum afresh (as
         * clvox_winding_inside_m): the interval is the fresh sums' */
        if (sp == 0 || Br * (clvox_real)CLVOX_SUM_ROUND + serr <= width * (clvox_real)0.5 ||
            it >= CLVOX_LATTICE_STEPS) {
            clvox_real B = 0, E = 0, EA = 0;
            for (uint i = 0; i < sp; i++) {
                B += sb[i];
                E += se[i];
                EA += fabs(se[i]);
            }
            Br = B;
            B = B * (clvox_real)CLVOX_SUM_ROUND + (clvox_real)1e-12 + serr;
#if !defined(CLVOX_FP64)
            B += (clvox_real)1.01f * CLVOX_REAL_U * ((clvox_real)(sp + 2u) * EA + 2 * (fabs(S) + fabs(E)));
#else
            (void)EA;
#endif
            if (sp == 0 || B <= width * (clvox_real)0.5 || it >= CLVOX_LATTICE_STEPS) {
                *lo = S + E - B;
                *hi = S + E + B;
                return;
            }
        }
        uint best = 0;
        for (uint i = 1; i < sp; i++) best = sb[i] > sb[best] ? i : best;
        Br -= sb[best];
        const uint nd = stack[best];
        stack[best] = stack[sp - 1u];
        sb[best] = sb[sp - 1u];
        se[best] = se[sp - 1u];
        sp--;
        const uint child = nodes[nd].child;
        if (child == 0 || sp + 2u > CLVOX_CAP_STACK) {
            S += clvox_cap_node_exact(nodes + nd, caps, gcaps, g, px, py, pz, axis, &serr);
#if !defined(CLVOX_FP64)
            serr += CLVOX_REAL_U * fabs(S);
#endif
        } else {
            stack[sp] = child;
            stack[sp + 1u] = child + 1u;
            clvox_cap_estimate2(nodes + child, nodes + child + 1u, px, py, pz, dp, 0, se + sp, sb + sp);
            Br += sb[sp] + sb[sp + 1u];
            sp += 2u;
        }
    }
}

/* Is triangle t (scaled x, y, z, 9 reals) clear of the box [q0, q1] by
 * more than `margin`? Separating axes (the box's, the triangle's normal and
 * the 9 edge-by-axis crosses), each projection's gap taken as clear only
 * beyond the margin and its rounding. */
static inline int clvox_triangle_clear(global const clvox_real *t, const clvox_real *q0, const clvox_real *q1,
                                       clvox_real margin)
{
    clvox_real c[3], e[3], v[3][3], mag = 0;
    for (uint a = 0; a < 3u; a++) {
        c[a] = (q0[a] + q1[a]) * (clvox_real)0.5;
        e[a] = (q1[a] - q0[a]) * (clvox_real)0.5;
        mag = fmax(mag, fmax(fabs(q0[a]), fabs(q1[a])));
    }
    for (uint k = 0; k < 3u; k++)
        for (uint a = 0; a < 3u; a++) {
            v[k][a] = t[3 * k + a] - c[a];
            mag = fmax(mag, fabs(t[3 * k + a]));
        }
    const clvox_real tol = margin + mag * (sizeof(clvox_real) == 8 ? (clvox_real)1e-12 : (clvox_real)1e-5);
    /* the box's axes */
    for (uint a = 0; a < 3u; a++) {
        const clvox_real lo = fmin(v[0][a], fmin(v[1][a], v[2][a])), hi = fmax(v[0][a], fmax(v[1][a], v[2][a]));
        if (lo > e[a] + tol || hi < -e[a] - tol) return 1;
    }
    clvox_real f[3][3];
    for (uint k = 0; k < 3u; k++)
        for (uint a = 0; a < 3u; a++) f[k][a] = v[(k + 1u) % 3u][a] - v[k][a];
    /* the normal, then the crosses: axis x with p_k = x . v_k, r = e . |x| */
    for (uint q = 0; q < 10u; q++) {
        clvox_real x[3];
        if (q == 9u) {
            x[0] = f[0][1] * f[1][2] - f[0][2] * f[1][1];
            x[1] = f[0][2] * f[1][0] - f[0][0] * f[1][2];
            x[2] = f[0][0] * f[1][1] - f[0][1] * f[1][0];
        } else {
            const uint a = q / 3u, k = q % 3u; /* unit axis a cross edge k */
            x[a] = 0;
            x[(a + 1u) % 3u] = -f[k][(a + 2u) % 3u];
            x[(a + 2u) % 3u] = f[k][(a + 1u) % 3u];
        }
        const clvox_real len = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
        if (!(len > 0)) continue;
        clvox_real lo = (clvox_real)INFINITY, hi = -(clvox_real)INFINITY;
        for (uint k = 0; k < 3u; k++) {
            const clvox_real p = x[0] * v[k][0] + x[1] * v[k][1] + x[2] * v[k][2];
            lo = fmin(lo, p);
            hi = fmax(hi, p);
        }
        const clvox_real r = e[0] * fabs(x[0]) + e[1] * fabs(x[1]) + e[2] * fabs(x[2]);
        if (lo > r + tol * len * 4 || hi < -r - tol * len * 4) return 1;
    }
    return 0;
}

/* Does a cap come within `margin` of the box [q0, q1]? The tree's boxes,
 * then each leaf's caps (clvox_triangle_clear). */
static inline int clvox_caps_touch(global const clvox_cap_node *nodes, global const clvox_real *caps,
                                   const clvox_real *q0, const clvox_real *q1, clvox_real margin)
{
    uint stack[CLVOX_CAP_STACK];
    uint sp = 1;
    stack[0] = 0;
    const clvox_real m2 = margin * margin;
    while (sp) {
        const uint nd = stack[--sp];
        if (clvox_node_box_d2(nodes + nd, q0, q1) > m2) continue;
        const uint child = nodes[nd].child;
        if (child == 0) {
            for (uint t = 0; t < nodes[nd].tri_count; t++)
                if (!clvox_triangle_clear(caps + (size_t)(nodes[nd].tri_first + t) * 9u, q0, q1, margin)) return 1;
            continue;
        }
        if (sp + 2u > CLVOX_CAP_STACK) return 1;
        stack[sp++] = child;
        stack[sp++] = child + 1u;
    }
    return 0;
}

/* The rims' bound on |d^2 w / dx_a^2| over the box [q0, q1] for a = x, y,
 * z (winding_rims.h, with distances between boxes: a node's box, a leaf
 * edge's extent), the tree refined best first on their sum until it is
 * under `enough` (or as winding_rims.h's rays). INFINITY where a rim may
 * touch the box. */
static inline void clvox_rim_box_m2(global const clvox_cap_node *rims, uint rim_count, global const clvox_real *edges,
                                    const clvox_real *q0, const clvox_real *q1, clvox_real enough, clvox_real *m2)
{
    m2[0] = m2[1] = m2[2] = 0;
    if (rim_count == 0) return;
    uint cut[CLVOX_BLOCK_STEPS + 2u];
    clvox_real sb[CLVOX_BLOCK_STEPS + 2u][3];
    uint sp = 1;
    cut[0] = 0;
    for (uint a = 0; a < 3u; a++) sb[0][a] = clvox_rim_box_bound(rims, q0, q1, a);
    for (uint it = 0; it < CLVOX_BLOCK_STEPS; it++) {
        uint best = sp;
        clvox_real bv = 0, G = 0;
        for (uint i = 0; i < sp; i++) {
            const clvox_real v = sb[i][0] + sb[i][1] + sb[i][2];
            G += v;
            if (!(cut[i] & CLVOX_RIM_FINAL) && (best == sp || !(v <= bv))) best = i, bv = v;
        }
        if (best == sp || (isfinite(G) && (bv < G * CLVOX_RIM_CUT_F || G < enough))) break;
        const uint nd = cut[best];
        if (rims[nd].child == 0) { /* a leaf: edge by edge */
            clvox_real s[3] = {0, 0, 0};
            for (uint e = 0; e < rims[nd].tri_count; e++) {
                global const clvox_real *a = edges + (size_t)(rims[nd].tri_first + e) * 9u, *b = a + 3;
                clvox_real d2 = 0;
                for (uint k = 0; k < 3u; k++) {
                    const clvox_real gk = clvox_interval_gap(fmin(a[k], b[k]), fmax(a[k], b[k]), q0[k], q1[k]);
                    d2 += gk * gk;
                }
                for (uint k = 0; k < 3u; k++) {
                    const clvox_real x1 = b[(k + 1u) % 3u] - a[(k + 1u) % 3u], x2 = b[(k + 2u) % 3u] - a[(k + 2u) % 3u];
                    s[k] += d2 > 0 ? (clvox_real)1.5 * sqrt(x1 * x1 + x2 * x2) *
                                         (clvox_real)(0.07957747154594767 * 1.00001) / (d2 * sqrt(d2))
                                   : (clvox_real)INFINITY;
                }
            }
            for (uint k = 0; k < 3u; k++) sb[best][k] = s[k];
            cut[best] = nd | CLVOX_RIM_FINAL;
            if (!isfinite(s[0] + s[1] + s[2])) break; /* an edge may touch the box: INFINITY whatever follows */
            continue;
        }
        const uint child = rims[nd].child;
        for (uint c = 0; c < 2u; c++) {
            const uint slot = c == 0 ? best : sp++;
            cut[slot] = child + c;
            for (uint a = 0; a < 3u; a++) sb[slot][a] = clvox_rim_box_bound(rims + child + c, q0, q1, a);
        }
    }
    for (uint i = 0; i < sp; i++)
        for (uint a = 0; a < 3u; a++) m2[a] += sb[i][a];
    for (uint a = 0; a < 3u; a++) m2[a] *= (clvox_real)CLVOX_SUM_ROUND;
}

/* The near caps of a block, and the far caps' bound on w_caps'' over it
 * (clvox_winding_blocks): the cap tree's leaves whose boxes lie within R
 * of the block's box [q0, q1] are its near part, into list[1 ..] (list[0]
 * their count); every other cap is at least R away, and their w_caps is
 * smooth over the block with |d^2 / dx_a^2| <= 6 area4pi / d^4 a node
 * (w_caps is the integral of n . F(y - p) dA / 4pi, F = -grad 1/|x|, and
 * the norm of D^3 (1/|x|) is 3! / |x|^4: winding_bounds.h), summed into
 * *m2 over the nodes beyond 2R and the leaves beyond R (opening the nodes
 * out to 4R gave a few more split blocks and cost more time). 0 where the
 * near part has more than CLVOX_NEAR_MAX leaves or more area than
 * CLVOX_NEAR_AREA R^2 (or the stack fills): summing large caps at every
 * voxel costs as much as the rays' own evaluations (holes, whose 7 holes
 * are large: 3-12 % slower with them split when split blocks refined
 * their own corners, no faster since they share the lattice's; elephant-
 * with-holes's 171 small ones gain). Splitting them anyway, with far
 * leaves bounded by their edges' field where that is tighter, removed a
 * fifth to a half of the exact points and no time (2026-12-08,
 * docs/benchmarks.md). */
static inline int clvox_caps_split(global const clvox_cap_node *nodes, const clvox_real *q0, const clvox_real *q1,
                                   clvox_real R, global uint *list, clvox_real *m2)
{
    uint stack[CLVOX_CAP_STACK];
    uint sp = 1, n = 0;
    stack[0] = 0;
    const clvox_real R2 = R * R, F2 = 4 * R2;
    clvox_real M = 0, An = 0;
    const clvox_real Amax = (clvox_real)CLVOX_NEAR_AREA * R2 * (clvox_real)0.07957747154594767; /* over 4pi */
    while (sp) {
        const uint nd = stack[--sp];
        const clvox_real d2 = clvox_node_box_d2(nodes + nd, q0, q1);
        const uint child = nodes[nd].child;
        if (d2 >= F2 || (child == 0 && d2 >= R2)) {
            M += (clvox_real)6 * (clvox_real)nodes[nd].area4pi / (d2 * d2);
            continue;
        }
        if (child == 0) {
            if (n == CLVOX_NEAR_MAX) return 0;
            list[1u + n++] = nd;
            An += (clvox_real)nodes[nd].area4pi;
            if (An > Amax) return 0;
            continue;
        }
        if (sp + 2u > CLVOX_CAP_STACK) return 0;
        stack[sp++] = child;
        stack[sp++] = child + 1u;
    }
    list[0] = n;
    *m2 = M * (clvox_real)1.000001 * (clvox_real)CLVOX_SUM_ROUND;
    return 1;
}

/* A block near the rims (its M2 too large, or INFINITY) may be split:
 * w_caps = w_near + w_far, w_near the caps of the leaves within
 * CLVOX_NEAR_BLOCKS blocks of it, summed exactly at each voxel that needs
 * it (clvox_cap_node_angles, the exact evaluation's own solid angles and
 * tie rule), w_far interpolated from the block's own corners (there the
 * lattice point's w_caps, shared with the blocks around, less the block's
 * near caps summed exactly: an exact sum of a few caps costs far less than
 * a refinement of the far caps alone at every corner of every split block,
 * elephant-with-holes 1.16x) with the far caps' bound on its M2. The steps
 * and the rims are in the near part; the far part is smooth. Blocks whose
 * interpolation error is under CLVOX_BLOCK_USABLE but that a cap crosses
 * are not split, nor are blocks with large caps near (clvox_caps_split):
 * the rays' line and evaluations decide their voxels more cheaply (holes,
 * mech-holes-shark: splitting them cost 3-12 %). */

/* A split block's near caps (list: a count, then cap tree leaves) summed
 * exactly at grid point g (x, y, z; h: the scaled spacing; axis with its
 * flags, for the tie rule), at the voxels that need it and at the block's
 * corners alike; adds the sum's error bound to *err. */
static inline clvox_real clvox_near_sum(global const clvox_cap_node *nodes, global const clvox_real *caps,
                                        global const float *gcaps, global const uint *list, const clvox_real *g,
                                        global const clvox_real *h, uint axis, clvox_real *err)
{
    clvox_angles an;
    clvox_angles_init(&an);
    for (uint i = 0; i < list[0]; i++)
        clvox_cap_node_angles(nodes + list[1u + i], caps, gcaps, g, g[0] * h[0], g[1] * h[1], g[2] * h[2], axis,
                              &an);
    return clvox_angles_value(&an, err);
}

/* The lattice of one slab (kernels/winding_lattice.cl): points every S-th
 * voxel centre along x, y and z, nx by ny by nz of them from lattice
 * plane z0 (z = z0 S) on; blocks between them, (nx - 1)(ny - 1)(nz - 1). */
typedef struct clvox_lattice {
    global const clvox_real *points; /* w_caps's interval per point: lo, hi (NAN: not computed) */
    global const clvox_real *blocks; /* CLVOX_BLOCK_WORDS per block */
    uint nx, ny, nz, z0, s; /* s: S */
    global const clvox_real *split; /* CLVOX_SPLIT_WORDS per block */
    global const uint *near;        /* CLVOX_NEAR_MAX + 1 per block: count, leaves */
    global const clvox_cap_node *nodes;
    global const clvox_real *caps;
    global const float *gcaps;
    uint axis; /* the ray axis with its flags (the near caps' tie rule) */
} clvox_lattice;

/* The block of the voxel at grid x, y, z (its first corner c, the voxel's
 * steps k from it; a voxel on a block's face finds the block above it
 * where there is one), NULL where the slab's lattice has none. */
static inline global const clvox_real *clvox_lattice_block(const clvox_lattice *lt, const clvox_real *g, uint *c,
                                                          uint *k)
{
    if (lt->nx < 2u) return 0;
    const uint n[3] = {lt->nx, lt->ny, lt->nz}, base[3] = {0u, 0u, lt->z0}, S = lt->s;
    for (uint a = 0; a < 3u; a++) {
        const uint x = (uint)g[a], b = x / S;
        if (b < base[a]) return 0;
        c[a] = b - base[a];
        k[a] = x % S;
        if (c[a] + 1u >= n[a]) { /* on the last lattice plane: the block before it */
            if (c[a] + 1u > n[a] || k[a] != 0u || c[a] == 0u) return 0;
            c[a]--;
            k[a] = S;
        }
    }
    return lt->blocks + ((size_t)(c[2] * (n[1] - 1u) + c[1]) * (n[0] - 1u) + c[0]) * CLVOX_BLOCK_WORDS;
}

/* The inside test of the voxel at grid x, y, z from the lattice, given K
 * there: 1 inside, 0 outside with w in [*lo, *hi]; -1 undecided (the
 * caller evaluates it). */
static inline int clvox_lattice_inside(const clvox_lattice *lt, global const clvox_real *h, const clvox_real *g, int K,
                                       uint abs_mode, clvox_real *lo, clvox_real *hi)
{
    uint c[3], k[3];
    global const clvox_real *bw = clvox_lattice_block(lt, g, c, k);
    if (!bw) return -1;
    const uint n[3] = {lt->nx, lt->ny, lt->nz}, S = lt->s;
    const clvox_real Kr = (clvox_real)K;
    if (bw[3] < CLVOX_CAPS_FAR_LIMIT) { /* K alone */
        *lo = Kr - bw[3];
        *hi = Kr + bw[3];
        return clvox_k_inside(K, abs_mode);
    }
    if (bw[4] == 0) return -1;
    /* w_caps interpolated from the lattice's points, or in a split block
     * its far part from them less the block's near caps at its corners,
     * plus its near caps summed here */
    const int split = bw[4] == (clvox_real)CLVOX_BLOCK_SPLIT;
    const size_t bi = (size_t)(c[2] * (n[1] - 1u) + c[1]) * (n[0] - 1u) + c[0];
    global const clvox_real *sw = lt->split + bi * CLVOX_SPLIT_WORDS;
    clvox_real L = 0, U = 0, mag = 1 + fabs(Kr);
    for (uint q = 0; q < 8u; q++) {
        const uint dx = q & 1u, dy = (q >> 1) & 1u, dz = q >> 2;
        const size_t p = ((size_t)(c[2] + dz) * n[1] + c[1] + dy) * n[0] + c[0] + dx;
        global const clvox_real *wp = lt->points + 2 * p;
        clvox_real v[2] = {wp[0], wp[1]};
        if (split) { /* the far part: w_caps less the block's near caps there, and the difference's rounding */
            const clvox_real d = (clvox_real)CLVOX_LERP_ERR * (fabs(v[0]) + fabs(v[1]) + fabs(sw[2u * q]));
            v[0] -= sw[2u * q] + sw[2u * q + 1u] + d;
            v[1] -= sw[2u * q] - sw[2u * q + 1u] - d;
        }
        const clvox_real t = (clvox_real)((dx ? k[0] : S - k[0]) * (dy ? k[1] : S - k[1]) *
                                          (dz ? k[2] : S - k[2])) *
                             ((clvox_real)1 / (clvox_real)(S * S * S));
        L += t * v[0];
        U += t * v[1];
        mag += fabs(v[0]) + fabs(v[1]);
    }
    if (!(L <= U)) return -1; /* a corner not computed (NAN): cannot happen next to a usable block */
    clvox_real E = 0;
    for (uint a = 0; a < 3u; a++)
        E += (split ? sw[16] : bw[a]) * (clvox_real)(k[a] * (S - k[a])) * (h[a] * h[a]);
    E = E * (clvox_real)0.5 * (clvox_real)1.000001;
    clvox_real err = 0, near = 0;
    global const uint *list = lt->near + bi * (CLVOX_NEAR_MAX + 1u);
    if (split && list[0]) {
        /* the near caps' bound at the voxel first (clvox_cap_bound_box):
         * where it decides, no solid angle is needed */
        const clvox_real p3[3] = {g[0] * h[0], g[1] * h[1], g[2] * h[2]};
        clvox_real B = 0;
        for (uint i = 0; i < list[0]; i++) B += clvox_cap_bound_box(lt->nodes + list[1u + i], p3, p3);
        B = B * (clvox_real)CLVOX_SUM_ROUND + (clvox_real)CLVOX_LERP_ERR * (mag + B);
        const int in = clvox_interval_inside(Kr - U - E - B, Kr - L + E + B, abs_mode);
        if (in >= 0) {
            *lo = Kr - U - E - B;
            *hi = Kr - L + E + B;
            return in;
        }
        near = clvox_near_sum(lt->nodes, lt->caps, lt->gcaps, list, g, h, lt->axis, &err);
    }
    /* E: the interpolation's error, the near sum's, and the sums' rounding */
    E += err + (clvox_real)CLVOX_LERP_ERR * (mag + fabs(near));
    *lo = Kr - near - U - E;
    *hi = Kr - near - L + E;
    return clvox_interval_inside(*lo, *hi, abs_mode);
}

/* The blocks' bound on |d^2 w / du^2| along the ray axis `axis` over the
 * ray segment from grid point g0 (x, y, z) to len voxels further along it:
 * the largest of the blocks' M2 there (their closed boxes cover it);
 * INFINITY where the slab's lattice does not. *usable: whether every one
 * of those blocks interpolates (clvox_lattice_inside decides nearly every
 * voxel there). */
static inline clvox_real clvox_lattice_segment_m2(const clvox_lattice *lt, uint axis, const clvox_real *g0, uint len,
                                                  int *usable)
{
    *usable = 0;
    if (lt->nx < 2u) return (clvox_real)INFINITY;
    const uint n[3] = {lt->nx, lt->ny, lt->nz}, base[3] = {0u, 0u, lt->z0}, S = lt->s;
    uint c[3];
    for (uint a = 0; a < 3u; a++) {
        if (a == axis) continue;
        const uint x = (uint)g0[a], b = x / S;
        if (b < base[a]) return (clvox_real)INFINITY;
        c[a] = b - base[a];
        if (c[a] + 1u >= n[a]) { /* on the last lattice plane: the block before it */
            if (c[a] + 1u > n[a] || x % S != 0u || c[a] == 0u) return (clvox_real)INFINITY;
            c[a]--;
        }
    }
    const uint x0 = (uint)g0[axis], x1 = x0 + len;
    const uint b0 = x0 / S, b1 = (x1 + S - 1u) / S - 1u; /* the blocks whose closed boxes cover [x0, x1] */
    if (b0 < base[axis] || b1 - base[axis] + 2u > n[axis]) return (clvox_real)INFINITY;
    clvox_real M = 0;
    int all = 1;
    for (uint b = b0; b <= b1; b++) {
        c[axis] = b - base[axis];
        global const clvox_real *bw =
            lt->blocks + ((size_t)(c[2] * (n[1] - 1u) + c[1]) * (n[0] - 1u) + c[0]) * CLVOX_BLOCK_WORDS;
        M = fmax(M, bw[axis]);
        all &= bw[4] != 0;
    }
    *usable = all;
    return M;
}
