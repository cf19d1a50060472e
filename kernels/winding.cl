/* Stage classify, winding numbers (kernels/winding.h): voxel centre u = i
 * is inside when w > 1/2, w = K - w_caps, K = the signed crossings strictly
 * beyond it (+1 where the ray leaves through a face oriented towards +u).
 * Writes occupancy bits and per-ray filled counts exactly as classify.cl.
 *
 * A ray whose whole segment is far from every cap (clvox_caps_far) is
 * classified by runs from K alone, like parity; on a closed mesh there are
 * no caps and that is every ray. Rays near a cap decide voxel by voxel. */

#define CLVOX_RIM_TRIES 4u
#define CLVOX_RIM_BUDGET 12u
kernel void clvox_classify_winding(global const clvox_ray *rays, uint ray_count, global const clvox_real *hits,
                                   global const char *signs, global const uint *counts, uint capacity,
                                   uint u_begin, uint u_count, uint out_stride, global uint *out,
                                   global uint *filled, uint abs_mode, uint axis, global const clvox_real *h,
                                   global const clvox_cap_node *nodes, uint node_count,
                                   global const clvox_real *caps, global uint *exact_points,
                                   global const clvox_cap_node *rims, uint rim_count,
                                   global const clvox_real *rim_edges)
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
    clvox_scaled_box(axis, g0, g1, h, q0, q1);
    const int far = clvox_caps_far(nodes, node_count, q0, q1, 16u);
    uint j = 0, cnt = 0, word = 0;
    if (far) {
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
        /* Voxel by voxel, sparsely: an evaluation at u0 gives an interval
         * [lo, hi] that holds w(u0). Along the ray w changes smoothly (|grad
         * w| <= G over a segment: the rims' field, clvox_rim_gradient)
         * except at surface crossings, where it steps by exactly the
         * crossing's -unit sign (K changes and w_caps does not; at cap
         * crossings K and w_caps step together). So on the segment w(u) lies
         * in [lo + J - G d, hi + J + G d], J the surface steps since u0, d
         * = |u - u0| h: while that interval is on one side of the
         * threshold, the voxel needs no evaluation. */
        uint exact = 0, k = 0, have = 0, j0 = 0, seg_end = 0, cool = 0, wait = 0;
        uint cut[CLVOX_CUT_MAX], cut_n = 0, jcut = 0, fresh_exact = 0;
        clvox_real lo = 0, hi = 0, J = 0, G = 0, Gp = 0;
        const clvox_real step = h[axis];
        for (j = 0; j < u_count; j++) {
            const clvox_real u = (clvox_real)(u_begin + j);
            while (k < n && hh[k] <= u) {
                const int un = CLVOX_UNIT(sg[k]);
                K -= un;
                if (sg[k] == 1 || sg[k] == -1) J -= (clvox_real)un;
                k++;
            }
            int inside = -1;
            if (have && j <= seg_end) {
                const clvox_real d = G * step * (clvox_real)(j - j0) * (clvox_real)1.000001;
                inside = clvox_interval_inside(lo + J - d, hi + J + d, abs_mode);
            }
            if (inside < 0) {
                clvox_real px, py, pz;
                clvox_scaled_xyz(axis, u, rv, rw, h, &px, &py, &pz);
                /* where the last search found no segment, the next voxels
                 * are evaluated alone, without the search or the tighter
                 * interval it needs (1, 2, 4, 8 voxels as it keeps failing) */
                const int alone = wait > 0;
                /* the last point's tree cut, when it is near (8 voxels) and has not
                 * grown much past a fresh start's (it only refines) */
                if (j > jcut + 8u) cut_n = 0;
                const int fresh = cut_n == 0;
                inside = clvox_winding_inside_m(K, abs_mode, nodes, node_count, caps, px, py, pz, axis,
                                                alone ? 0u : CLVOX_TIGHT, &exact, &lo, &hi, cut, &cut_n);
                jcut = j;
                uint cut_exact = 0;
                for (uint i = 0; i < cut_n; i++) cut_exact += (cut[i] & CLVOX_CUT_EXACT) != 0;
                if (fresh) fresh_exact = cut_exact;
                else if (cut_exact > fresh_exact + fresh_exact / 2u + 2u) cut_n = 0;
                /* the next segment: as long as the margin lasts at the
                 * segment's own gradient bound (CLVOX_RIM_TRIES tries) */
                const clvox_real thr = (clvox_real)0.5 + (clvox_real)CLVOX_WINDING_TIE;
                clvox_real m = inside ? (lo > thr ? lo - thr : -thr - hi) : (abs_mode ? fmin(thr - hi, lo + thr) : thr - hi);
                have = 0;
                J = 0;
                j0 = j;
                uint r = u_count - 1u - j, bad = r + 1u;
                if (Gp > 0) { /* the last bound predicts this one: G changes slowly along the ray */
                    const clvox_real guess = m / (Gp * step) * (clvox_real)1.25;
                    if (guess < (clvox_real)r) r = guess < 1 ? 1u : (uint)guess;
                } else if (r > 64u) { /* no bound yet on this ray */
                    r = 64u;
                }
                if (alone) {
                    wait--;
                    r = 0;
                }
                for (uint it = 0; m > 0 && r > 0 && it < CLVOX_RIM_TRIES; it++) {
                    const clvox_real g0[3] = {u, rv, rw}, g1[3] = {u + (clvox_real)r, rv, rw};
                    clvox_real q0[3], q1[3];
                    clvox_scaled_box(axis, g0, g1, h, q0, q1);
                    const clvox_real Gs = clvox_rim_gradient(rims, rim_count, rim_edges, q0, q1, CLVOX_RIM_BUDGET);
                    const clvox_real s = !isfinite(Gs) ? 0 : Gs > 0 ? m / (Gs * step) : (clvox_real)r;
                    uint next;
                    if (isfinite(Gs)) Gp = Gs;
                    if (s >= (clvox_real)r) { /* valid for r; a longer one, up to the last that failed */
                        G = Gs;
                        have = 1;
                        seg_end = j + r;
                        next = s < (clvox_real)(bad - 1u) ? (uint)s : bad - 1u;
                        if (next <= r + r / 4u) break;
                        r = next;
                    } else { /* too long: as long as its bound allows (shorter: a smaller bound) */
                        bad = r;
                        next = !isfinite(Gs) ? r / 4u : (uint)s;
                        if (have && next <= seg_end - j) break;
                        r = next;
                    }
                }
                if (!alone) {
                    cool = have ? 0u : (cool == 0u ? 1u : cool < 8u ? cool * 2u : 8u);
                    wait = cool;
                }
            }
            cnt += (uint)inside;
            if (out_stride == 0) {
                if (inside) word |= 1u << (j & 31u);
                if ((j & 31u) == 31u) {
                    o[j >> 5] = word;
                    word = 0;
                }
            } else if (inside) {
                atomic_or(o + (size_t)j * out_stride, bit);
            }
        }
        if (exact) atomic_add(exact_points, exact);
    }
    if (out_stride == 0 && (j & 31u)) o[j >> 5] = word; /* the last, partial word */
    filled[gid] = cnt;
}

/* For tests/test_winding.c only: pair i's node nodes[node_of[i]] seen from
 * point pts[3i ..] (scaled x, y, z), 12 reals per pair: the estimate and
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
    clvox_real e[4], b[4], e1, b1;
    global clvox_real *o = out + (size_t)i * 12u;
    clvox_cap_estimate(nd, px, py, pz, &e1, &b1);
    o[0] = e1;
    o[1] = b1;
    clvox_cap_estimate2(nd, nd, px, py, pz, e, b);
    o[2] = e[0];
    o[3] = b[0];
    o[4] = e[1];
    o[5] = b[1];
    uint factors = 0;
    o[6] = clvox_cap_node_exact(nd, caps, px, py, pz, 0u, &factors);
    o[7] = (clvox_real)factors;
    clvox_cap_estimate4(nd, nodes, nodes, nd, px, py, pz, e, b);
    o[8] = e[0];
    o[9] = b[0];
    o[10] = e[3];
    o[11] = b[3];
}
