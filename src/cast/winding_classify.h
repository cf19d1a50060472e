/* SPDX-License-Identifier: Apache-2.0 */
/* The winding inside test of the ray method, host side
 * (src/cast/winding_classify.c): the cast's triangles and caps for a
 * winding run, the winding arguments every consumer takes, and the binary
 * consumer kernels/winding.cl (clvox_classify_winding). */
#ifndef CLVOX_WINDING_CLASSIFY_H
#define CLVOX_WINDING_CLASSIFY_H
#include "cast.h"
#include "winding/winding.h"

/* All zero (no caps, NULL buffers) on parity runs: the column consumers
 * take the winding arguments either way. */
typedef struct clvox__winding_classify {
    cl_uint abs_mode;            /* |w| > 1/2 */
    cl_uint axis;                /* the ray axis u (0..2) */
    clvox__caps caps, rims;
    clvox_winding_report prep;   /* what the preparation did (for the file's parameters) */
    cl_uint surface_count;       /* soup triangles before the caps (the cast signs these) */
    double crack_distance;       /* the certified crack weld (src/winding/crack_weld.c), when crack_pairs */
    uint64_t crack_welded, crack_pairs, crack_holes;
    size_t local;                /* work-group size of clvox_classify_winding */
    /* The slab's block lattice (kernels/winding_lattice.h, src/cast/winding_lattice.c): binary runs with
     * caps, no weld pairs, cubic voxels. lat[0] < 2 (nx): none for the slab. */
    int lattice_on;
    cl_kernel k_blocks, k_lattice;
    cl_mem lat_points, lat_blocks;
    cl_mem lat_split, lat_near;  /* the blocks split in near and far caps (kernels/winding_lattice.h) */
    cl_uint lat[5];              /* nx, ny, nz, z0 (in lattice planes), S (voxels between points) */
} clvox__winding_classify;

/* The triangles the cast runs over: grid-space vertices and 3 indices each
 * (the mesh's own, tris_owned NULL, unless the preparation changed them),
 * and the quadtree over them where it was built on the way (have_tree).
 * The caller sets the mesh's own before clvox__winding_cast_prepare and
 * owns verts, tris_owned and qt after it, on failure too. */
typedef struct clvox__cast_tris {
    float *verts;
    size_t vert_count;
    const uint32_t *tris;
    uint32_t *tris_owned;
    size_t tri_count;
    clvox__quadtree qt;
    int have_tree;
} clvox__cast_tris;

/* The winding preparation of a run (orientation, caps, rims), beside the
 * parity quadtree of the mesh as given; fills w (caps, rims, report,
 * surface_count) and out. */
clvox_status clvox__winding_cast_prepare(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                         const clvox_voxelize_options *opts, clvox__axes axes, uint32_t dim_v,
                                         uint32_t dim_w, uint32_t leaf_size, clvox__winding_classify *w,
                                         clvox_stats *stats, clvox__cast_tris *out);
void clvox__winding_classify_release(clvox__winding_classify *w);
/* The preparation's report and the crack weld's figures into stats. */
void clvox__winding_stats(const clvox__winding_classify *w, clvox_stats *stats);

/* From argument *i on: abs_mode, the ray axis (with_axis), the cap tree and
 * the exact-point counter, as the winding kernels' consumers (kernels/winding_*.h) take them. */
cl_int clvox__winding_args(cl_kernel k, cl_uint *i, const clvox__winding_classify *w, const clvox__batch_mem *m,
                           int with_axis);

/* The block lattice: whether the run uses one (lattice_on, its kernels
 * made), from clvox__winding_cast_prepare's results and the grid. */
clvox_status clvox__winding_lattice_prepare(clvox_context *ctx, const clvox_grid *grid, int binary,
                                            clvox__winding_classify *w);
/* Builds the lattice of the slab of grid planes z in [z0, z0 + nz) and
 * waits for it (nothing where !lattice_on, or where its points, blocks or
 * split blocks' data would take more than 64 MiB or a quarter of the
 * device's largest buffer: it is an aid). */
clvox_status clvox__winding_lattice_slab(clvox_context *ctx, const clvox_grid *grid, clvox__winding_classify *w,
                                         uint32_t z0, uint32_t nz);

/* The binary consumer: n rays of one ray per voxel column. */
clvox_status clvox__winding_classify_enqueue(clvox_context *ctx, cl_kernel k, const clvox__winding_classify *w,
                                             const clvox__batch_mem *m, cl_uint n, const clvox__slab_target *t,
                                             cl_event *ev);
#endif
