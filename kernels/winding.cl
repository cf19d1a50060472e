/* SPDX-License-Identifier: Apache-2.0 */
/* Stage classify, winding numbers (kernels/winding_*.h): voxel centre u = i
 * is inside when w > 1/2, w = K - w_caps, K = the signed crossings strictly
 * beyond it (+1 where the ray leaves through a face oriented towards +u).
 * Writes occupancy bits and per-ray filled counts exactly as classify.cl.
 *
 * A ray whose whole segment is far from every cap (clvox_caps_far) is
 * classified by runs from K alone, like parity; on a closed mesh there are
 * no caps and that is every ray. Rays near a cap decide voxel by voxel. */

#define CLVOX_SEG_MAX 256u /* voxels between anchors at most */

/* Moves K (the signed crossings beyond) and Jc (the surface steps so far)
 * along the ray to voxel centre u: crossings at or before u are passed. */
static inline void clvox_winding_advance(global const clvox_real *hh, global const char *sg, uint n, clvox_real u,
                                         uint *k, int *K, clvox_real *Jc)
{
    while (*k < n && hh[*k] <= u) {
        const int un = CLVOX_UNIT(sg[*k]);
        *K -= un;
        if (sg[*k] == 1 || sg[*k] == -1) *Jc -= (clvox_real)un;
        (*k)++;
    }
}

/* The inside test at ray voxel j (centre u_begin + j), from the last
 * evaluation's tree cut (clvox_winding_inside_cut); an unsure answer goes
 * to the host's list too. */
static inline int clvox_winding_at(int K, uint abs_mode, global const clvox_cap_node *nodes, uint node_count,
                                   global const clvox_real *caps, global const float *gcaps, uint axis,
                                   global const clvox_real *h, global uint *unsure, uint gid, uint u_begin, uint j,
                                   clvox_real rv, clvox_real rw, uint tight, uint *exact, clvox_real *lo,
                                   clvox_real *hi, uint *cut, uint *cut_n, uint *fresh_exact)
{
    clvox_real px, py, pz, g[3];
    clvox_scaled_xyz(axis, (clvox_real)(u_begin + j), rv, rw, h, &px, &py, &pz);
    clvox_grid_xyz(axis, (clvox_real)(u_begin + j), rv, rw, g);
    const uint flags = CLVOX_AXIS_FLAGS(h[3]);
    const int in = clvox_winding_inside_cut(K, abs_mode, nodes, node_count, caps, gcaps, g, px, py, pz, axis | flags,
                                            tight, exact, lo, hi, cut, cut_n, fresh_exact);
    if (!(in & CLVOX_UNSURE)) return in;
    clvox_unsure_push(unsure, gid, j, (uint)K, 0u);
    return 0; /* the host sets the voxel where it is inside */
}

/* clvox_winding_at where the slab's lattice does not decide voxel j
 * (clvox_lattice_inside; [*lo, *hi] then its interval). */
static inline int clvox_winding_at_lattice(const clvox_lattice *lt, int K, uint abs_mode,
                                           global const clvox_cap_node *nodes, uint node_count,
                                           global const clvox_real *caps, global const float *gcaps, uint axis,
                                           global const clvox_real *h, global uint *unsure, uint gid, uint u_begin,
                                           uint j, clvox_real rv, clvox_real rw, uint tight, uint *exact,
                                           clvox_real *lo, clvox_real *hi, uint *cut, uint *cut_n, uint *fresh_exact)
{
    clvox_real g[3];
    clvox_grid_xyz(axis, (clvox_real)(u_begin + j), rv, rw, g);
    const int in = clvox_lattice_inside(lt, h, g, K, abs_mode, lo, hi);
    if (in >= 0) return in;
    return clvox_winding_at(K, abs_mode, nodes, node_count, caps, gcaps, axis, h, unsure, gid, u_begin, j, rv, rw,
                            tight, exact, lo, hi, cut, cut_n, fresh_exact);
}

/* How far an evaluation's interval [lo, hi] lies from the threshold thr
 * on its answer's side (for |w| > 1/2, from both -thr and thr). */
static inline clvox_real clvox_margin(int inside, clvox_real lo, clvox_real hi, clvox_real thr, uint abs_mode)
{
    return inside ? (lo > thr ? lo - thr : -thr - hi) : (abs_mode ? fmin(thr - hi, lo + thr) : thr - hi);
}

/* Voxel j's answer into the ray's bits and count. */
static inline void clvox_emit(global uint *o, uint out_stride, uint bit, uint j, int inside, uint *word, uint *cnt)
{
    *cnt += (uint)inside;
    if (out_stride == 0) {
        if (inside) *word |= 1u << (j & 31u);
        if ((j & 31u) == 31u) {
            o[j >> 5] = *word;
            *word = 0;
        }
    } else if (inside) {
        atomic_or(o + (size_t)j * out_stride, bit);
    }
}
/* Voxels [a, b) of the ray all `inside` into its bits and count (b
 * ending a word leaves no stale bits for clvox_emit). */
static inline void clvox_emit_run(global uint *o, uint out_stride, uint bit, uint a, uint b, int inside, uint *word,
                                  uint *cnt)
{
    if (inside) *cnt += b - a;
    if (out_stride == 0) {
        clvox_row_bits(o, word, a, b, inside);
        if ((b & 31u) == 0) *word = 0;
    } else if (inside) {
        for (uint i = a; i < b; i++) atomic_or(o + (size_t)i * out_stride, bit);
    }
}

#define CLVOX_RUN_STACK 40u   /* halvings of a run (weld pairs) */
#define CLVOX_RUN_BUDGET 48u  /* node steps of a run's bound (weld pairs) */

static void clvox_classify_winding_body(global const clvox_ray *rays, uint ray_count, global const clvox_real *hits,
                                        global const char *signs, global const uint *counts, uint capacity,
                                        uint u_begin, uint u_count, uint out_stride, global uint *out,
                                        global uint *filled, uint abs_mode, uint axis, global const clvox_real *h,
                                        global const clvox_cap_node *nodes, uint node_count,
                                        global const clvox_real *caps, global const float *gcaps,
                                        global uint *exact_points, global const clvox_cap_node *rims, uint rim_count,
                                        global const clvox_real *rim_edges, global uint *unsure,
                                        const clvox_lattice *lt)
{
    uint gid = get_global_id(0);
    if (gid >= ray_count) return;
    uint n = counts[gid];
    if (n > capacity) return; /* overflowed: redone by the host */
    global const clvox_real *hh = hits + (size_t)gid * capacity;
    global const char *sg = signs + (size_t)gid * capacity;
    global uint *o = out + rays[gid].out_base;
    const uint bit = 1u << (rays[gid].bit & 31u);
    const clvox_real rv = rays[gid].v, rw = rays[gid].w;
    int K = 0; /* signed crossings beyond the current run */
    for (uint k = 0; k < n; k++) K += CLVOX_UNIT(sg[k]);

    /* the segment of the ray's centres, scaled */
    const clvox_real g0[3] = {(clvox_real)u_begin, rv, rw}, g1[3] = {(clvox_real)(u_begin + u_count - 1u), rv, rw};
    clvox_real q0[3], q1[3];
    clvox_cap_box(axis, g0, g1, h, q0, q1);
    const int pairs = CLVOX_PAIR_TREE(nodes, node_count);
    const int far = !pairs && clvox_caps_far(nodes, node_count, q0, q1, 16u);
    uint j = 0, cnt = 0, word = 0;
    if (pairs) {
        /* Weld pairs (src/winding/crack_weld.c): w - K is not smooth along
         * the ray (a pair steps where T and T' do, not where K does), so no
         * line between anchors. K is constant between crossings: a run of
         * centres whose box the tree's bounds keep under 1/2 is decided by
         * K at once; else it is halved, down to single centres, which are
         * evaluated (each from the last one's cut). */
        uint exact = 0, cut[CLVOX_CUT_MAX], cut_n = 0, fresh_exact = 0;
        clvox_real lo, hi;
        for (uint k = 0; k <= n && j < u_count; k++) {
            uint end = u_count;
            if (k < n) {
                clvox_real e = ceil(hh[k]) - (clvox_real)u_begin;
                end = e <= 0 ? 0u : (e >= (clvox_real)u_count ? u_count : (uint)e);
            }
            if (end > j) {
                const int kin = clvox_k_inside(K, abs_mode);
                /* The centres next to the crossings first, alone: the rest of
                 * the run is then mostly decided in one piece. */
                uint a0 = j, b0 = end;
                int last = -1;
                if (k > 0u && b0 - a0 >= 2u) {
                    const int in = clvox_winding_at(K, abs_mode, nodes, node_count, caps, gcaps, axis, h,
                                                    unsure, gid, u_begin, a0, rv, rw, 0u, &exact, &lo, &hi, cut,
                                                    &cut_n, &fresh_exact);
                    clvox_emit(o, out_stride, bit, a0, in, &word, &cnt);
                    a0++;
                }
                if (k < n && b0 - a0 >= 2u) {
                    last = clvox_winding_at(K, abs_mode, nodes, node_count, caps, gcaps, axis, h,
                                            unsure, gid, u_begin, b0 - 1u, rv, rw, 0u, &exact, &lo, &hi, cut,
                                            &cut_n, &fresh_exact);
                    b0--;
                }
                uint ra[CLVOX_RUN_STACK], rb[CLVOX_RUN_STACK], rsp = 1;
                ra[0] = a0;
                rb[0] = b0;
                while (rsp) {
                    rsp--;
                    const uint a = ra[rsp], b = rb[rsp];
                    if (b - a == 1u) {
                        const int in = clvox_winding_at(K, abs_mode, nodes, node_count, caps, gcaps, axis, h,
                                                        unsure, gid, u_begin, a, rv, rw, 0u, &exact, &lo, &hi,
                                                        cut, &cut_n, &fresh_exact);
                        clvox_emit(o, out_stride, bit, a, in, &word, &cnt);
                        continue;
                    }
                    const clvox_real r0[3] = {(clvox_real)(u_begin + a), rv, rw},
                                     r1[3] = {(clvox_real)(u_begin + b - 1u), rv, rw};
                    clvox_real p0[3], p1[3];
                    clvox_cap_box(axis, r0, r1, h, p0, p1);
                    if (rsp + 2u > CLVOX_RUN_STACK || clvox_caps_far(nodes, node_count, p0, p1, CLVOX_RUN_BUDGET)) {
                        /* (a full stack cannot happen: halving 2^32 centres takes 32 levels) */
                        clvox_emit_run(o, out_stride, bit, a, b, kin, &word, &cnt);
                        continue;
                    }
                    const uint m = a + (b - a) / 2u;
                    ra[rsp] = m; /* the right half after the left */
                    rb[rsp++] = b;
                    ra[rsp] = a;
                    rb[rsp++] = m;
                }
                if (last >= 0) clvox_emit(o, out_stride, bit, end - 1u, last, &word, &cnt);
                j = end;
            }
            if (k < n) K -= CLVOX_UNIT(sg[k]);
        }
        j = u_count;
        if (exact) atomic_add(exact_points, exact);
    } else if (far) {
        for (uint k = 0; k <= n && j < u_count; k++) {
            uint end = u_count;
            if (k < n) {
                clvox_real e = ceil(hh[k]) - (clvox_real)u_begin;
                end = e <= 0 ? 0u : (e >= (clvox_real)u_count ? u_count : (uint)e);
            }
            if (end > j) {
                const int inside = clvox_k_inside(K, abs_mode);
                if (inside) cnt += end - j;
                if (out_stride == 0) {
                    clvox_row_bits(o, &word, j, end, inside);
                    j = end;
                } else {
                    if (inside)
                        for (uint i = j; i < end; i++) atomic_or(o + (size_t)i * out_stride, bit);
                    j = end;
                }
            }
            if (k < n) K -= CLVOX_UNIT(sg[k]);
        }
    } else {
        /* Voxel by voxel, sparsely. Along the ray w minus the surface
         * steps (the crossings' -units since the ray's start, Jc: K changes
         * there and w_caps does not; at cap crossings K and w_caps step
         * together) is a smooth function g of u away from the rim, with
         * |g''| <= M2 on a segment (the slab's lattice's blocks' bound or
         * the ray's rim terms, kernels/winding_lattice.h and
         * winding_rims.h). So between
         * two evaluated voxels (anchors) a and b, g lies within M2 (u - ua)
         * (ub - u) / 2 of the line through their intervals: a voxel whose
         * interval from that is on one side of the threshold needs no
         * evaluation. One that is not is evaluated and becomes the next
         * anchor a, the segment's M2 still holding. The next segment's
         * length is the one at which the line's error at its middle is
         * 3/8 of the last anchor's margin. Every voxel the line leaves
         * undecided tries the slab's lattice before it is evaluated
         * (clvox_winding_at_lattice): an anchor's interval may come from
         * either. */
        uint exact = 0, k = 0, cut[CLVOX_CUT_MAX], cut_n = 0, fresh_exact = 0, s = 16u, wait = 0, cool = 0;
        clvox_real Jc = 0, lo = 0, hi = 0;
        const clvox_real step = h[axis], thr = (clvox_real)0.5 + (clvox_real)CLVOX_WINDING_TIE;
        clvox_winding_advance(hh, sg, n, (clvox_real)u_begin, &k, &K, &Jc);
        int inside = clvox_winding_at_lattice(lt, K, abs_mode, nodes, node_count, caps, gcaps, axis, h, unsure, gid,
                                              u_begin, 0u, rv, rw, CLVOX_TIGHT, &exact, &lo, &hi, cut, &cut_n,
                                              &fresh_exact);
        clvox_real la = lo - Jc, ha = hi - Jc; /* anchor a: g's interval */
        clvox_emit(o, out_stride, bit, 0u, inside, &word, &cnt);
        j = 0;
        clvox_real ma = clvox_margin(inside, lo, hi, thr, abs_mode); /* anchor a's */
        clvox_rim_terms rt; /* the rims' bound along this ray, built when first needed */
        uint have_rt = 0; /* the steps its terms were refined in (0: not built) */
        while (j + 1u < u_count) {
            uint jb = j + s < u_count - 1u ? j + s : u_count - 1u;
            /* The segment's M2; where its line's error at the middle, M2 (L
             * h)^2 / 8, is over 4 times a's margin, the ray nears a rim (M2 is
             * the largest at the segment's far end) and nearly every voxel
             * between would fail and be evaluated: the segment is cut to the
             * length whose error is 3/8 of that margin, the same M2 holding
             * on it (recomputing it for the shorter segment saved 1 % more
             * evaluations and cost more than it saved). Under 2 voxels it is
             * left, voxel by voxel anyway (b alone there made more segments,
             * each with its own M2: elephant-with-holes 7 % slower). */
            clvox_real M2 = (clvox_real)INFINITY;
            if (jb > j + 1u) {
                const clvox_real g0[3] = {(clvox_real)(u_begin + j), rv, rw},
                                 g1[3] = {(clvox_real)(u_begin + jb), rv, rw};
                const clvox_real L = (clvox_real)(jb - j) * step;
                /* The lattice's blocks' M2 (cheap) where they all interpolate
                 * (the voxels the line leaves, the lattice mostly decides)
                 * or where it keeps the line's error at the middle within
                 * half a's margin; else the ray's rim terms (built for the
                 * ray when first needed; tighter near the rims). */
                clvox_real gx[3];
                int usable;
                clvox_grid_xyz(axis, g0[0], rv, rw, gx);
                M2 = clvox_lattice_segment_m2(lt, axis, gx, jb - j, &usable);
                if (!(isfinite(M2) && usable) && !(M2 * L * L * (clvox_real)0.125 <= (clvox_real)0.5 * ma)) {
                    /* the full refinement where this ray's exact evaluations
                     * are costly (CLVOX_RIM_COSTLY; built again once they
                     * turn out so), else half of it */
                    const uint steps = fresh_exact > CLVOX_RIM_COSTLY ? CLVOX_RIM_STEPS : CLVOX_RIM_STEPS / 2u;
                    if (have_rt < steps) {
                        const clvox_real r0[3] = {(clvox_real)u_begin, rv, rw},
                                         r1[3] = {(clvox_real)(u_begin + u_count - 1u), rv, rw};
                        clvox_real p0[3], p1[3];
                        clvox_scaled_box(axis, r0, r1, h, p0, p1);
                        clvox_rim_ray_terms(rims, rim_count, rim_edges, p0, p1, axis, steps, &rt);
                        have_rt = steps;
                    }
                    clvox_real q0[3], q1[3];
                    clvox_scaled_box(axis, g0, g1, h, q0, q1);
                    M2 = fmin(M2, clvox_rim_terms_bound(&rt, q0, q1, axis));
                }
                if (ma > 0 && isfinite(M2) && M2 * L * L * (clvox_real)0.125 > 4 * ma) {
                    const clvox_real w = sqrt((clvox_real)3 * ma / M2) / step;
                    if (w >= (clvox_real)2) jb = j + (uint)w;
                }
            }
            uint kb = k;
            int Kb = K;
            clvox_real Jb = Jc;
            clvox_winding_advance(hh, sg, n, (clvox_real)(u_begin + jb), &kb, &Kb, &Jb);
            const int ib = clvox_winding_at_lattice(lt, Kb, abs_mode, nodes, node_count, caps, gcaps, axis, h,
                                                    unsure, gid, u_begin, jb, rv, rw, CLVOX_TIGHT, &exact, &lo, &hi,
                                                    cut, &cut_n, &fresh_exact);
            const clvox_real lb = lo - Jb, hb = hi - Jb;
            const clvox_real mb = clvox_margin(ib, lo, hi, thr, abs_mode); /* b's */
            const int smooth = isfinite(M2);
            uint ja = j;
            for (uint i = j + 1u; i < jb; i++) {
                clvox_winding_advance(hh, sg, n, (clvox_real)(u_begin + i), &k, &K, &Jc);
                inside = -1;
                if (smooth) {
                    const clvox_real t = (clvox_real)(i - ja) / (clvox_real)(jb - ja);
                    const clvox_real e = (clvox_real)((i - ja) * (jb - i)) * (step * step) * (clvox_real)0.5 * M2 *
                                             (clvox_real)1.000001 +
                                         (clvox_real)CLVOX_LERP_ERR *
                                             ((clvox_real)1 + fabs(la) + fabs(ha) + fabs(lb) + fabs(hb) + fabs(Jc));
                    const clvox_real l = la + t * (lb - la) + Jc, u = ha + t * (hb - ha) + Jc;
                    inside = clvox_interval_inside(l - e, u + e, abs_mode);
                }
                if (inside < 0) {
                    inside = clvox_winding_at_lattice(lt, K, abs_mode, nodes, node_count, caps, gcaps, axis, h,
                                                      unsure, gid, u_begin, i, rv, rw, smooth ? CLVOX_TIGHT : 0u,
                                                      &exact, &lo, &hi, cut, &cut_n, &fresh_exact);
                    ja = i;
                    la = lo - Jc;
                    ha = hi - Jc;
                }
                clvox_emit(o, out_stride, bit, i, inside, &word, &cnt);
            }
            clvox_winding_advance(hh, sg, n, (clvox_real)(u_begin + jb), &k, &K, &Jc);
            clvox_emit(o, out_stride, bit, jb, ib, &word, &cnt);
            la = lb;
            ha = hb;
            ma = mb;
            const uint len = jb - j;
            j = jb;
            /* the next length: error M2 (L h)^2 / 8 at the middle = 3/8 of the
             * margin (about the lengths that 1/2 gave with the older M2, 4/3
             * of this one; 1/2 with this M2 made longer segments, which
             * failed more often: cylinder +26 % evaluations). Under 2 no
             * voxel lies between: voxel by voxel for a while
             * (1, 2, 4, 8 as it keeps failing), then a segment of 4 again
             * for a fresh M2. */
            if (len == 1u && wait > 0u) {
                wait--;
                s = 1u;
            } else {
                uint want = 4u;
                if (len > 1u && !smooth) {
                    want = len / 2u;
                } else if (len > 1u && mb > 0) {
                    const clvox_real w = sqrt((clvox_real)3 * mb / M2) / step;
                    want = w >= (clvox_real)(2u * len + 2u) ? 2u * len + 2u : (uint)w;
                } else if (!(mb > 0)) {
                    want = 0u;
                }
                if (want >= 2u) {
                    s = want < CLVOX_SEG_MAX ? want : CLVOX_SEG_MAX;
                    cool = 0u;
                } else {
                    s = 1u;
                    cool = cool == 0u ? 1u : cool < 8u ? cool * 2u : 8u;
                    wait = cool - 1u;
                }
            }
        }
        j = u_count;
        if (exact) atomic_add(exact_points, exact);
    }
    if (out_stride == 0 && (j & 31u)) o[j >> 5] = word; /* the last, partial word */
    filled[gid] = cnt;
}

/* The kernel: the body, then the launch's completion count (clvox_done,
 * prelude.cl). */
kernel void clvox_classify_winding(global const clvox_ray *rays, uint ray_count, global const clvox_real *hits,
                                   global const char *signs, global const uint *counts, uint capacity,
                                   uint u_begin, uint u_count, uint out_stride, global uint *out,
                                   global uint *filled, uint abs_mode, uint axis, global const clvox_real *h,
                                   global const clvox_cap_node *nodes, uint node_count,
                                   global const clvox_real *caps, global const float *gcaps,
                                   global uint *exact_points, global const clvox_cap_node *rims, uint rim_count,
                                   global const clvox_real *rim_edges, global uint *unsure,
                                   global const clvox_real *lat_points, global const clvox_real *lat_blocks,
                                   uint lat_nx, uint lat_ny, uint lat_nz, uint lat_z0, uint lat_s,
                                   global const clvox_real *lat_split, global const uint *lat_near,
                                   global uint *clvox_done, uint clvox_done_slot)
{
    const clvox_lattice lt = {lat_points, lat_blocks, lat_nx, lat_ny, lat_nz, lat_z0, lat_s, lat_split, lat_near,
                              nodes, caps, gcaps, axis | CLVOX_AXIS_FLAGS(h[3])};
    clvox_classify_winding_body(rays, ray_count, hits, signs, counts, capacity, u_begin, u_count, out_stride, out,
        filled, abs_mode, axis, h, nodes, node_count, caps, gcaps, exact_points, rims, rim_count, rim_edges, unsure,
        &lt);
    clvox_done_mark(clvox_done, clvox_done_slot);
}

/* For tests/test_winding.c and tests/test_float_kernels.c only: pair i's
 * node nodes[node_of[i]] seen from point pts[3i ..] (scaled x, y, z; with
 * the axis flags of voxels that are not cubes), 12 reals per pair: the estimate and
 * bound of clvox_cap_estimate, of clvox_cap_estimate2 (both lanes the same
 * node: lane 0, lane 1), the exact clvox_cap_node_exact and its factors,
 * and of clvox_cap_estimate4 with the node in lanes 0 and 3 (the root in
 * 1 and 2). */
kernel void clvox_winding_probe(global const clvox_cap_node *nodes, global const clvox_real *caps,
                                global const uint *node_of, global const clvox_real *pts, uint count,
                                global clvox_real *out)
{
    const uint i = get_global_id(0);
    if (i >= count) return;
    global const clvox_cap_node *nd = nodes + node_of[i];
    const clvox_real px = pts[3 * i], py = pts[3 * i + 1], pz = pts[3 * i + 2];
    const clvox_real dp = clvox_point_rounding(px, py, pz, 0u); /* the axis flags of voxels that are not cubes */
    clvox_real e[4], b[4], e1, b1;
    global clvox_real *o = out + (size_t)i * 12u;
    clvox_cap_estimate(nd, px, py, pz, dp, 1, &e1, &b1);
    o[0] = e1;
    o[1] = b1;
    clvox_cap_estimate2(nd, nd, px, py, pz, dp, 1, e, b);
    o[2] = e[0];
    o[3] = b[0];
    o[4] = e[1];
    o[5] = b[1];
    clvox_real err = 0;
    const clvox_real g[3] = {px, py, pz}; /* unused: axis 0u, no exact signs */
    o[6] = clvox_cap_node_exact(nd, caps, (global const float *)0, g, px, py, pz, 0u, &err);
    o[7] = err;
    clvox_cap_estimate4(nd, nodes, nodes, nd, px, py, pz, dp, 1, e, b);
    o[8] = e[0];
    o[9] = b[0];
    o[10] = e[3];
    o[11] = b[3];
}

/* For tests/test_winding.c only: the rims' bound over segment segs[6i ..]
 * (q0 then q1, scaled x, y, z, along the axis where they differ) into
 * out[i], as the classify bounds a segment of a ray: the rim terms
 * prepared for a ray through it (clvox_rim_ray_terms; here the segment
 * extended by twice its length on either side), then summed over it. */
kernel void clvox_rim_probe(global const clvox_cap_node *rims, uint rim_count, global const clvox_real *edges,
                            global const clvox_real *segs, uint count, global clvox_real *out)
{
    const uint i = get_global_id(0);
    if (i >= count) return;
    clvox_real q0[3], q1[3], r0[3], r1[3];
    for (uint a = 0; a < 3u; a++) {
        q0[a] = r0[a] = segs[6 * i + a];
        q1[a] = r1[a] = segs[6 * i + 3 + a];
    }
    const uint axis = q1[1] != q0[1] ? 1u : (q1[2] != q0[2] ? 2u : 0u);
    const clvox_real len = q1[axis] - q0[axis];
    r0[axis] -= 2 * len;
    r1[axis] += 2 * len;
    clvox_rim_terms t;
    clvox_rim_ray_terms(rims, rim_count, edges, r0, r1, axis, CLVOX_RIM_STEPS, &t);
    out[i] = clvox_rim_terms_bound(&t, q0, q1, axis);
}

/* The host's answers for the points the float build left unsure
 * (src/cast/unsure.c): words at[2i] of out get the bits
 * at[2i + 1] (atomic: several points may share a word). */
kernel void clvox_set_bits(global uint *out, global const uint *at, uint n, global uint *clvox_done,
                           uint clvox_done_slot)
{
    const uint i = get_global_id(0);
    if (i < n) atomic_or(out + at[2u * i], at[2u * i + 1u]);
    clvox_done_mark(clvox_done, clvox_done_slot);
}
