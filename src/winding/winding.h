/* SPDX-License-Identifier: Apache-2.0 */
/* Winding numbers, host side (src/winding/winding.c, src/winding/winding_prep.c). */
#ifndef CLVOX_WINDING_H
#define CLVOX_WINDING_H
#include "core/internal.h"

/* The cap tree on the device (kernels/winding_*.h): nodes, the cap triangles
 * in its leaf order as scaled x, y, z reals, the same triangles in grid
 * space (grid: 9 floats each, x, y, z, for the exact signs; not in the
 * rims' tree), and the scale h (4 reals, always set: clvox__winding_scale's
 * s, then 1 on cubic voxels, else 0). node_count 0: no caps. */
typedef struct clvox__caps {
    cl_mem nodes, tris, grid, h;
    cl_uint node_count;
    size_t cap_count;
    float *host;       /* float devices: the grid triangles (9 each, leaf order) for clvox__caps_host_inside */
    size_t host_count; /* triangles in host */
} clvox__caps;

/* The inside test at the point of grid coordinates g (x, y, z) given K
 * there, in double on the host over every cap triangle, as the double
 * kernels take it (the float ones leave it the points they cannot certify,
 * kernels/winding.cl): w = K - the caps' solid angles / 4pi at g times s
 * (clvox__winding_scale), w > 1/2 + 2^-30 (abs_mode: |w|); the signs exact
 * on the grid's floats. axis: the tie rule's. */
int clvox__caps_host_inside(const clvox__caps *c, const double s[3], const double g[3], int K, int abs_mode,
                            unsigned axis);

/* The winding code's scale (kernels/winding_*.h "scaled grid space"):
 * s[a] = h[a] / max(h) * 2^-k, grid coordinates times s being the world's up
 * to one uniform scale, which keeps every solid angle; 2^k >= the largest
 * dimension (winding.c, winding_scale_shift) keeps the coordinates near 1, where
 * the products of the cap factors (kernels/winding_angles.h
 * clvox_angles_mul) seldom need rescaling (at grid scale, up to 2^11, they
 * did: 5 % of an open mesh's classify in double, more in float). Returns 1
 * when the voxels are cubes: then the scaled coordinates are the grid's
 * floats times 2^-k, exactly, on which the kernels take exact signs (and a
 * float device is exact). */
int clvox__winding_scale(const clvox_grid *grid, double s[3]);

/* cap_soup: n cap triangles of the cast's soup (grid space, u,v,w order). */
clvox_status clvox__caps_upload(clvox_context *ctx, const float *cap_soup, size_t n, clvox__axes axes,
                                const clvox_grid *grid, clvox__caps *out);
/* The same with np weld pairs (src/winding/crack_weld.c): pair_soup holds
 * 18 floats a pair, grid space like cap_soup: the input triangle T as
 * oriented, then its welded copy T'. Caps and pairs get a tree each under
 * one root (clvox_cap_node, CLVOX_PAIR_RADIUS). */
clvox_status clvox__caps_upload_pairs(clvox_context *ctx, const float *cap_soup, size_t n, const float *pair_soup,
                                      size_t np, clvox__axes axes, const clvox_grid *grid, clvox__caps *out);
void clvox__caps_release(clvox__caps *c);
/* The rims' tree: n boundary edges (rim, 2 vertex indices each) in scaled
 * grid space, area4pi = length / 4pi (kernels/winding_rims.h clvox_rim_bound);
 * tris holds the edges in leaf order, 9 reals each (end, start, start). */
clvox_status clvox__rims_upload(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                const uint32_t *rim, size_t n, clvox__caps *out);
#endif

/* clvox__winding_prepare with flags. CLVOX__PREP_BORROW: out->tris is left
 * NULL when the prepared triangles are the mesh's own, index for index (no
 * vertex merged or welded, no triangle dropped or flipped; caps and the
 * report as always); clvox__winding_mesh_own_tris then makes the copy. */
#define CLVOX__PREP_BORROW 1u
/* CLVOX__PREP_KEEP_REP: out->rep keeps every vertex's representative
 * (src/winding/crack_weld.c maps each input triangle to its welded copy). */
#define CLVOX__PREP_KEEP_REP 2u
clvox_status clvox__winding_prepare_flags(clvox_context *ctx, const clvox_mesh *mesh, double weld, unsigned flags,
                                          clvox__winding_mesh *out);
clvox_status clvox__winding_mesh_own_tris(clvox_context *ctx, const clvox_mesh *mesh, clvox__winding_mesh *w);

/* The preparation ahead (clvox_mesh_prepare_winding): a borrowing
 * (CLVOX__PREP_BORROW) preparation on its own host thread, held by the
 * mesh. clvox__winding_prepare_or_take is clvox__winding_prepare_flags for
 * the cast: it waits for the mesh's preparation ahead, if any, and takes it
 * when it was for `weld` (its status, its message in ctx; a copy of the
 * triangles it borrowed unless flags has CLVOX__PREP_BORROW), else drops it
 * and prepares. clvox__prep_ahead_drop waits for it and frees it
 * (clvox_mesh_destroy). */
clvox_status clvox__winding_prepare_or_take(clvox_context *ctx, const clvox_mesh *mesh, double weld, unsigned flags,
                                            clvox__winding_mesh *out);
void clvox__prep_ahead_drop(clvox_mesh *mesh);
/* Closes boundary loops with caps (src/winding/winding.c, "caps"): loop k is the
 * vertices verts[start[k] .. start[k+1]) (edges v[i] -> v[i+1], the last
 * back to the first; the array is used as scratch). Appends to wm->caps and
 * wm->apex, adds to report.holes, sets report.cap_triangles. */
clvox_status clvox__winding_cap_loops(clvox_context *ctx, const clvox_mesh *mesh, uint32_t *verts,
                                      const size_t *start, size_t loops, clvox__winding_mesh *wm);
