/* Stage classify: voxel centre u = i is inside when the number of crossings
 * strictly beyond it (u_hit > i) is odd (Thon et al. 3.3.3). Writes half
 * values 0 / 1 (0x3C00) and the number of filled voxels of each ray. */

#define CLVOX_HALF_ONE ((ushort)0x3C00)

kernel void clvox_classify(global const clvox_ray *rays, uint ray_count,
                           global const clvox_real *hits, global const uint *counts, uint capacity,
                           uint u_begin, uint u_count, uint out_stride,
                           global ushort *out, global uint *filled)
{
    uint gid = get_global_id(0);
    if (gid >= ray_count) return;
    uint n = counts[gid];
    if (n > capacity) return; /* overflowed: redone by the host */
    global const clvox_real *h = hits + (size_t)gid * capacity;
    global ushort *o = out + rays[gid].out_base;
    /* Run k: the centres c with h[k-1] <= c < h[k] have n-k crossings
     * beyond them; the integer centres c < h are those below ceil(h). */
    uint j = 0, cnt = 0;
    for (uint k = 0; k <= n && j < u_count; k++) {
        uint end = u_count;
        if (k < n) {
            clvox_real e = ceil(h[k]) - (clvox_real)u_begin;
            end = e <= 0 ? 0u : (e >= (clvox_real)u_count ? u_count : (uint)e);
        }
        if (end <= j) continue;
        ushort val = ((n - k) & 1u) ? CLVOX_HALF_ONE : (ushort)0;
        if (val) cnt += end - j;
        if (out_stride == 1) {
            for (; j < end; j++) o[j] = val;
        } else {
            for (; j < end; j++) o[(size_t)j * out_stride] = val;
        }
    }
    filled[gid] = cnt;
}
