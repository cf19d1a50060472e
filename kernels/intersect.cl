/* Stage cast: crossings of each ray with the triangles of its leaf.
 * Keeps at most `capacity` crossings per ray but counts all of them, so the
 * host can redo the rays that overflowed with a larger buffer. With `signs`
 * (winding runs) each crossing also gets its orientation: +1 when the
 * triangle faces +u (its corners run counter-clockwise in the (v,w) plane),
 * -1 otherwise. */

kernel void clvox_intersect(global const clvox_ray *rays, uint ray_count,
                            global const uint *leaf_of_ray, global const clvox_qt_node *nodes,
                            global const uint *refs, global const float *soup,
                            uint capacity, global clvox_real *hits, global uint *counts, global char *signs)
{
    uint gid = get_global_id(0);
    if (gid >= ray_count) return;
    float pv = rays[gid].v, pw = rays[gid].w;
    clvox_qt_node leaf = nodes[leaf_of_ray[gid]];
    global clvox_real *out = hits + (size_t)gid * capacity;
    uint n = 0;
    for (uint k = 0; k < leaf.count; k++) {
        uint t = refs[leaf.first + k];
        clvox_real u;
        const int s = clvox_ray_crosses(soup + (size_t)t * 9, pv, pw, &u);
        if (s) {
            if (n < capacity) {
                out[n] = u;
                if (signs) signs[(size_t)gid * capacity + n] = (char)s;
            }
            n++;
        }
    }
    counts[gid] = n;
}
