/* SPDX-License-Identifier: Apache-2.0 */
/* Stage classify: voxel centre u = i is inside when the number of crossings
 * strictly beyond it (u_hit > i) is odd (Thon et al. 3.3.3). Writes
 * occupancy bits (the slab format of src/core/internal.h) and the number of
 * filled voxels of each ray.
 *  - out_stride == 0: the ray runs along x and is one bit row, which it
 *    writes whole, word by word (no atomics, no clearing needed);
 *  - else the ray crosses one row per step and sets its bit there with
 *    atomic_or (neighbouring rays share words), in a buffer the host has
 *    cleared. */

static void clvox_classify_body(global const clvox_ray *rays, uint ray_count,
                                global const clvox_real *hits, global const uint *counts, uint capacity,
                                uint u_begin, uint u_count, uint out_stride,
                                global uint *out, global uint *filled)
{
    uint gid = get_global_id(0);
    if (gid >= ray_count) return;
    uint n = counts[gid];
    if (n > capacity) return; /* overflowed: redone by the host */
    global const clvox_real *h = hits + (size_t)gid * capacity;
    global uint *o = out + rays[gid].out_base;
    const uint bit = 1u << (rays[gid].bit & 31u);
    /* Run k: the centres c with h[k-1] <= c < h[k] have n-k crossings
     * beyond them; the integer centres c < h are those below ceil(h). */
    uint j = 0, cnt = 0, word = 0;
    for (uint k = 0; k <= n && j < u_count; k++) {
        uint end = u_count;
        if (k < n) {
            clvox_real e = ceil(h[k]) - (clvox_real)u_begin;
            end = e <= 0 ? 0u : (e >= (clvox_real)u_count ? u_count : (uint)e);
        }
        if (end <= j) continue;
        const int inside = (n - k) & 1u;
        if (inside) cnt += end - j;
        if (out_stride == 0) { /* bits j .. end-1 of the row */
            const uint fill = inside ? 0xFFFFFFFFu : 0u;
            if (j & 31u) { /* complete the word begun by the previous run */
                uint b = j & 31u, take = min(32u - b, end - j);
                word |= fill & (((1u << take) - 1u) << b); /* take < 32 */
                j += take;
                if ((j & 31u) == 0) o[(j >> 5) - 1] = word;
            }
            for (; j + 32u <= end; j += 32u) o[j >> 5] = fill; /* whole words */
            if (j < end) { /* begin a word */
                word = fill & ((1u << (end - j)) - 1u);
                j = end;
            }
        } else {
            if (inside)
                for (uint i = j; i < end; i++) atomic_or(o + (size_t)i * out_stride, bit);
            j = end;
        }
    }
    if (out_stride == 0 && (j & 31u)) o[j >> 5] = word; /* the last, partial word */
    filled[gid] = cnt;
}

/* The kernel: the body, then the launch's completion count (clvox_done,
 * prelude.cl). */
kernel void clvox_classify(global const clvox_ray *rays, uint ray_count,
                           global const clvox_real *hits, global const uint *counts, uint capacity,
                           uint u_begin, uint u_count, uint out_stride,
                           global uint *out, global uint *filled,
                           global uint *clvox_done, uint clvox_done_slot)
{
    clvox_classify_body(rays, ray_count, hits, counts, capacity, u_begin, u_count, out_stride, out, filled);
    clvox_done_mark(clvox_done, clvox_done_slot);
}
