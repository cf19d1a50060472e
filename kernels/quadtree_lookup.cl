/* SPDX-License-Identifier: Apache-2.0 */
/* Stage partition (device side): find the quadtree leaf under each ray. */

static void clvox_quadtree_lookup_body(global const clvox_ray *rays, uint ray_count,
                                       global const clvox_qt_node *nodes, global uint *leaf_of_ray)
{
    uint gid = get_global_id(0);
    if (gid >= ray_count) return;
    float v = rays[gid].v, w = rays[gid].w;
    uint i = 0;
    while (nodes[i].count == CLVOX_QT_INTERNAL) {
        uint q = (v >= nodes[i].split_v ? 1u : 0u) | (w >= nodes[i].split_w ? 2u : 0u);
        i = nodes[i].first + q;
    }
    leaf_of_ray[gid] = i;
}

/* The kernel: the body, then the launch's completion count (clvox_done,
 * prelude.cl). */
kernel void clvox_quadtree_lookup(global const clvox_ray *rays, uint ray_count,
                                  global const clvox_qt_node *nodes, global uint *leaf_of_ray,
                                  global uint *clvox_done, uint clvox_done_slot)
{
    clvox_quadtree_lookup_body(rays, ray_count, nodes, leaf_of_ray);
    clvox_done_mark(clvox_done, clvox_done_slot);
}
