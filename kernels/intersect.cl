/* SPDX-License-Identifier: Apache-2.0 */
/* Stage cast: crossings of each ray with the triangles of its leaf.
 * Keeps at most `capacity` crossings per ray but counts all of them, so the
 * host can redo the rays that overflowed with a larger buffer. With `signs`
 * (winding runs) each crossing also gets its orientation: +1 when the
 * triangle faces +u (its corners run counter-clockwise in the (v,w) plane),
 * -1 otherwise; doubled on caps (triangles from surface_count on), whose
 * crossings leave the winding number continuous.
 * Triangles are indexed: tris holds 3 vertex indices per triangle into
 * verts (grid space, u,v,w per vertex), the floats a soup would repeat at
 * every corner (src/grid/grid.c), so the crossings are the soup's bit for bit. */

static void clvox_intersect_body(global const clvox_ray *rays, uint ray_count,
                                 global const uint *leaf_of_ray, global const clvox_qt_node *nodes,
                                 global const uint *refs, global const float *verts, global const uint *tris,
                                 uint capacity, global clvox_real *hits, global uint *counts, global char *signs,
                                 uint surface_count)
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
        global const uint *k3 = tris + (size_t)t * 3;
        const int s = clvox_ray_crosses(verts + (size_t)k3[0] * 3, verts + (size_t)k3[1] * 3, verts + (size_t)k3[2] * 3,
                                        pv, pw, &u);
        if (s) {
            if (n < capacity) {
                out[n] = u;
                if (signs) signs[(size_t)gid * capacity + n] = (char)(t < surface_count ? s : 2 * s);
            }
            n++;
        }
    }
    counts[gid] = n;
}

/* The kernel: the body, then the launch's completion count (clvox_done,
 * prelude.cl). */
kernel void clvox_intersect(global const clvox_ray *rays, uint ray_count,
                            global const uint *leaf_of_ray, global const clvox_qt_node *nodes,
                            global const uint *refs, global const float *verts, global const uint *tris,
                            uint capacity, global clvox_real *hits, global uint *counts, global char *signs,
                            uint surface_count,
                            global uint *clvox_done, uint clvox_done_slot)
{
    clvox_intersect_body(rays, ray_count, leaf_of_ray, nodes, refs, verts, tris, capacity, hits, counts, signs,
        surface_count);
    clvox_done_mark(clvox_done, clvox_done_slot);
}
