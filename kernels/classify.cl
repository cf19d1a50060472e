/* Stage classify: voxel centre u = i is inside when the number of crossings
 * strictly beyond it (u_hit > i) is odd (Thon et al. 3.3.3). Writes half
 * values 0 / 1 (0x3C00) and the number of filled voxels of each ray. */

#define CLVOX_HALF_ONE ((ushort)0x3C00)

kernel void clvox_classify(global const clvox_ray *rays, uint ray_count,
                           global const float *hits, global const uint *counts, uint capacity,
                           uint u_begin, uint u_count, uint out_stride,
                           global ushort *out, global uint *filled)
{
    uint gid = get_global_id(0);
    if (gid >= ray_count) return;
    uint n = counts[gid];
    if (n > capacity) return; /* overflowed: redone by the host */
    global const float *h = hits + (size_t)gid * capacity;
    global ushort *o = out + rays[gid].out_base;
    /* k = number of crossings at or before the current centre. */
    uint k = 0;
    uint cnt = 0;
    for (uint j = 0; j < u_count; j++) {
        float c = (float)(u_begin + j);
        while (k < n && h[k] <= c) k++;
        uint inside = (n - k) & 1u;
        o[(size_t)j * out_stride] = inside ? CLVOX_HALF_ONE : (ushort)0;
        cnt += inside;
    }
    filled[gid] = cnt;
}
