/* Stage classify, winding numbers (kernels/winding.h): voxel centre u = i
 * is inside when w > 1/2, w = K - w_caps, K = the signed crossings strictly
 * beyond it (+1 where the ray leaves through a face oriented towards +u).
 * Writes occupancy bits and per-ray filled counts exactly as classify.cl.
 *
 * A ray whose whole segment is far from every cap (clvox_caps_far) is
 * classified by runs from K alone, like parity; on a closed mesh there are
 * no caps and that is every ray. Rays near a cap decide voxel by voxel. */

kernel void clvox_classify_winding(global const clvox_ray *rays, uint ray_count, global const clvox_real *hits,
                                   global const char *signs, global const uint *counts, uint capacity,
                                   uint u_begin, uint u_count, uint out_stride, global uint *out,
                                   global uint *filled, uint abs_mode, uint axis, global const clvox_real *h,
                                   global const clvox_cap_node *nodes, uint node_count,
                                   global const clvox_real *caps, global uint *exact_points,
                                   global const clvox_cap_node *rims, uint rim_count)
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
        /* Voxel by voxel; after an exact answer with margin m, the next
         * voxels up to the next surface crossing keep it while G * h * s <
         * m (w is continuous across caps; G bounds |grad w| there). */
        uint exact = 0, k = 0, keep = 0;
        int inside = 0;
        const clvox_real step = h[axis];
        for (j = 0; j < u_count; j++) {
            const clvox_real u = (clvox_real)(u_begin + j);
            while (k < n && hh[k] <= u) K -= CLVOX_UNIT(sg[k]), k++;
            if (keep) {
                keep--;
            } else {
                clvox_real px, py, pz, m;
                clvox_scaled_xyz(axis, u, rv, rw, h, &px, &py, &pz);
                inside = clvox_winding_inside_m(K, abs_mode, nodes, node_count, caps, px, py, pz, axis, &exact, &m);
                /* voxels before the next surface crossing (strictly) */
                uint k2 = k;
                while (k2 < n && (sg[k2] == 2 || sg[k2] == -2)) k2++;
                uint room = u_count - 1u - j;
                if (k2 < n) {
                    const clvox_real e = ceil(hh[k2]) - 1 - u; /* centres u+1 .. ceil(h)-1 lie before it */
                    if (e < (clvox_real)room) room = e <= 0 ? 0u : (uint)e;
                }
                /* the bound over a shorter segment is smaller: shrink it to
                 * what the last bound allowed, three times at most */
                for (uint it = 0; m > 0 && room > 0 && it < 3u; it++) {
                    const clvox_real g0[3] = {u, rv, rw}, g1[3] = {u + (clvox_real)room, rv, rw};
                    clvox_real q0[3], q1[3];
                    clvox_scaled_box(axis, g0, g1, h, q0, q1);
                    const clvox_real G = clvox_rim_gradient(rims, rim_count, q0, q1, 24u);
                    if (!isfinite(G)) {
                        room /= 4u;
                        continue;
                    }
                    const clvox_real s = G > 0 ? m / (G * step) : (clvox_real)room;
                    if (s >= (clvox_real)room) {
                        keep = room;
                        break;
                    }
                    keep = (uint)s > keep ? (uint)s : keep; /* valid: inside this segment */
                    room = (uint)s < 1u ? 0u : (uint)(s * 2) < room ? (uint)(s * 2) : room - 1u;
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
