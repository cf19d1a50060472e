/* SPDX-License-Identifier: Apache-2.0 */
/* Palette elements as triangle meshes (element_mesh.c) and the PLY export
 * of a palette volume built on them (element_ply.c). Not installed.
 *
 * The export is public as clvox_ply_export_* (clvox.h, element_ply.c):
 * these are the same objects under the library's internal names.
 * Design: docs/design.md "Element geometry and mesh export". */
#ifndef CLVOX_ELEMENT_MESH_H
#define CLVOX_ELEMENT_MESH_H

#include "clvox.h"

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ---- geometry (element_mesh.c) ---- */

/* The exact geometry of one palette element in unit-voxel coordinates, as
 * disjoint convex pieces, each a closed triangle mesh of its own vertices,
 * oriented outward (counter-clockwise seen from outside). Pieces may touch:
 * two pieces can share (parts of) a face, with opposite orientations. Every
 * directed edge of a piece has its reverse in the same piece. */
typedef struct clvox__element_mesh {
    double *xyz;             /* 3 per vertex, in [0,1]^3 */
    size_t vertex_count;
    uint32_t *tris;          /* 3 vertex indices per triangle (into xyz) */
    size_t triangle_count;
    size_t piece_count;
    size_t *piece_vertex;    /* piece_count + 1 offsets: piece p owns vertices
                                [piece_vertex[p], piece_vertex[p+1]) */
    size_t *piece_triangle;  /* piece_count + 1 offsets, the same for triangles */
    double volume;           /* sum of the pieces' volumes (divergence theorem) */
} clvox__element_mesh;

/* Most convex pieces one element may decompose into (else
 * CLVOX_ERR_INVALID_ARGUMENT: the element is too complex for a mesh). */
#define CLVOX__ELEMENT_MAX_PIECES 4096u

/* Builds the mesh of element `index` of `palette` into *out (zeroed first;
 * free with clvox__element_mesh_free, also after a failure). */
clvox_status clvox__element_mesh_build(clvox_context *ctx, const clvox_palette *palette, size_t index,
                                       clvox__element_mesh *out);
void clvox__element_mesh_free(clvox__element_mesh *m); /* NULL-safe; leaves *m zeroed */

/* ---- PLY export of a palette volume (element_ply.c) ---- */

/* Writes `size` bytes at byte `offset` of the output; returns 0, or an errno
 * value (non-zero) on failure. */
typedef clvox_write_at_fn clvox__write_at_fn;

typedef struct clvox_ply_export clvox__ply_export;

/* The public struct (clvox.h); internally its .size is not used. */
typedef clvox_ply_totals clvox__ply_totals;

/* An export of a volume of dims voxels (voxel (i,j,k) is the box origin +
 * (i,j,k) * voxel_size .. + voxel_size) scored with `palette` (borrowed for
 * the export's life). Builds every element's mesh once. ascii: 0 binary
 * little-endian, 1 ASCII (fixed-width records). */
clvox_status clvox__ply_export_create(clvox_context *ctx, const clvox_palette *palette, const uint32_t dims[3],
                                      const double origin[3], const double voxel_size[3], int ascii,
                                      clvox__ply_export **out);
void clvox__ply_export_destroy(clvox__ply_export *x); /* NULL-safe */

/* Pass 1: slice z (X*Y element indices as floats, x fastest; slices in any
 * order, each once). Fails (CLVOX_ERR_EXR) on a value that is not an index
 * of the palette. */
clvox_status clvox__ply_export_count(clvox__ply_export *x, uint32_t z, const float *element);
/* After pass 1: the totals; fails when the mesh is too large for PLY's int
 * vertex indices. */
clvox_status clvox__ply_export_totals(clvox__ply_export *x, clvox__ply_totals *t);
/* Pass 2: writes the header, then each slice in increasing z (the same
 * slices as pass 1), then finish. Vertices and faces go to their own regions
 * of the file (their offsets are known from the totals), so one pass
 * suffices. A slice that does not match pass 1 fails (CLVOX_ERR_IO: the
 * volume changed). */
clvox_status clvox__ply_export_begin(clvox__ply_export *x, clvox__write_at_fn write_at, void *user);
clvox_status clvox__ply_export_slice(clvox__ply_export *x, uint32_t z, const float *element);
clvox_status clvox__ply_export_finish(clvox__ply_export *x);

#ifdef __cplusplus
}
#endif
#endif /* CLVOX_ELEMENT_MESH_H */
