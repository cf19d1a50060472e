/* SPDX-License-Identifier: Apache-2.0 */
/* Surfaces of a volume, fed slice by slice (surface_extract.c): the voxel
 * faces between inside and outside voxels, or a marching-cubes isosurface
 * through the voxel centres. Design: docs/design.md "Meshes from volumes". */
#ifndef CLVOX_SURFACE_EXTRACT_H
#define CLVOX_SURFACE_EXTRACT_H

#include "clvox.h"

/* Receives the mesh as it is made. Vertices are numbered 0, 1, 2, ... in
 * the order vertex() is called; a triangle only names vertices already
 * given. Positions are world coordinates (origin + lattice * voxel size).
 * Either function returns 0 to go on, or an errno value to stop (the
 * extraction then fails with CLVOX_ERR_IO). Either may be NULL. */
typedef struct clvox__surface_sink {
    void *user;
    int (*vertex)(void *user, const double xyz[3]);
    int (*triangle)(void *user, const uint64_t v[3], const double xyz[9]);
} clvox__surface_sink;

typedef struct clvox__surface clvox__surface;

/* smooth: 0 voxel faces of the voxels with value > iso, 1 marching cubes of
 * the values at iso (values outside the grid are 0, so the surface closes
 * half a voxel beyond a grid it touches). */
clvox_status clvox__surface_create(clvox_context *ctx, int smooth, const uint32_t dims[3], const double origin[3],
                                   const double voxel_size[3], float iso, const clvox__surface_sink *sink,
                                   clvox__surface **out);
void clvox__surface_destroy(clvox__surface *s); /* NULL-safe */
/* Slice z (X*Y values, x fastest), in increasing z from 0, each once. */
clvox_status clvox__surface_slice(clvox__surface *s, uint32_t z, const float *values);
/* After the last slice: closes the surface at the top of the grid. */
clvox_status clvox__surface_finish(clvox__surface *s);

typedef struct clvox__surface_counts {
    uint64_t vertices, triangles;
    uint64_t inside_voxels;   /* values > iso */
    double value_sum;         /* sum of the values (the coverage sum, voxel units) */
    double enclosed_volume;   /* signed volume of the triangles, world units */
} clvox__surface_counts;
void clvox__surface_get_counts(const clvox__surface *s, clvox__surface_counts *c);

#endif
