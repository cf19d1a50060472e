/* SPDX-License-Identifier: Apache-2.0 */
/* The certified crack weld (crack_weld.c, docs/design.md "Cracks"): a
 * faster way to the same voxels on cracked meshes and triangle soups.
 * Internal. */
#ifndef CLVOX_CRACK_WELD_H
#define CLVOX_CRACK_WELD_H
#include "winding.h"

/* The welded preparation and the pairs that carry the difference back to
 * the mesh as given. Pair k is pairs[6k .. 6k+5]: an input triangle as the
 * unwelded preparation orients it (3 mesh vertex indices), then its welded
 * copy (the 3 representatives, in T's orientation; two equal when welding
 * collapsed it). Triangles whose welded copy has the same positions have
 * no pair. */
typedef struct clvox__crack_weld {
    int used;                       /* 1: cast `welded` and add the pairs to the cap tree */
    clvox__winding_mesh welded;
    uint32_t *pairs;
    size_t pair_count;
    uint32_t *extra;                /* ordinary caps (3 indices each): T' twice for each triangle
                                       the two preparations orient differently */
    size_t extra_count;
    double distance;                /* the weld distance (mesh units) */
    double seconds;                 /* host time of the welded preparation, used or not (kept by _free) */
} clvox__crack_weld;

/* The weld distance tried for a grid of voxel size h (mesh units): a
 * hundredth of the smallest side. */
double clvox__crack_weld_distance(const double h[3]);

/* Tries the weld on a mesh whose preparation `soup` (weld 0, its own
 * triangles) left holes. cw->used = 1 when it pays: many boundary edges
 * before, at most half the caps after (counting `extra`). Fails only for
 * want of memory. */
clvox_status clvox__crack_weld_try(clvox_context *ctx, const clvox_mesh *mesh, const clvox__winding_mesh *soup,
                                   double distance, clvox__crack_weld *cw);
void clvox__crack_weld_free(clvox__crack_weld *cw);
#endif
