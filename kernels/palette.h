/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Palettes of sub-voxel elements (Cavagnino & Gribaudo), in the common
 * subset of C11 and OpenCL C: the host (src/palette/palette.c, the CPU reference of
 * the scoring) and the palette-scoring kernel compile this same source, so
 * both decide membership bit for bit alike.
 *
 * Geometry. An element lives in the unit voxel V = [0,1]^3 (the scoring
 * scales the voxel box onto V, so anisotropic voxels need nothing here). It
 * is the union of its convex cells, optionally complemented (with respect to
 * V); a cell is the intersection of its half-spaces a*x + b*y + c*z <= d.
 * Points handed to clvox_element_contains are assumed to lie in V: the
 * constraints are intersected with the voxel, never checked against it.
 *
 * Boundary rule. Half-spaces are closed (<=), so a cell is closed, a union of
 * cells is closed, and a complemented element is open. A cell without
 * half-spaces is the whole voxel; an element without cells is empty (so
 * index 0, "empty", is 0 cells, and index 1, "full", is 1 cell of 0 planes).
 *
 * Arithmetic. The test is evaluated in float as ((a*x + b*y) + c*z) <= d,
 * left to right, with no contraction (prelude.cl sets FP_CONTRACT OFF; the
 * host builds with -ffp-contract=off). The built-in palettes use only
 * coefficients a, b, c in {0, +-1, +-2} and d a multiple of 1/2, so every
 * product is exact (a power-of-two scaling) and a fused multiply-add could
 * not change a result anyway; with dyadic sample points the sums are exact
 * too (src/palette/palette.c relies on this for its duplicate test).
 *
 * Layout. Three flat arrays: elements, cells, planes. Element e owns cells
 * [first_cell, first_cell + cell_count); cell c owns planes
 * [first_plane, first_plane + plane_count). Structs hold only fixed-width
 * scalars with explicit padding and are pinned below.
 */
#ifndef CLVOX_PALETTE_H
#define CLVOX_PALETTE_H

#ifdef __OPENCL_VERSION__
#ifndef CLVOX_PALETTE_MEM
#define CLVOX_PALETTE_MEM __global /* a kernel may define __constant before this file */
#endif
#define CLVOX_PALETTE_FN static inline /* static: see CLVOX_OV_FN (overlap.h) */
#else
#include "clvox_types.h"
#define CLVOX_PALETTE_MEM
#define CLVOX_PALETTE_FN static inline
#endif

/* The closed half-space a*x + b*y + c*z <= d. */
typedef struct clvox_halfspace {
    clvox_f32 a, b, c, d;
} clvox_halfspace;

/* A convex cell: the intersection of planes[first_plane .. + plane_count). */
typedef struct clvox_cell {
    clvox_u32 first_plane;
    clvox_u32 plane_count;
} clvox_cell;

/* An element: the union of cells[first_cell .. + cell_count), the
 * complement of that union (in the voxel) when complement is 1. */
typedef struct clvox_element {
    clvox_u32 first_cell;
    clvox_u32 cell_count;
    clvox_u32 complement; /* 0 or 1 */
    clvox_u32 pad;
} clvox_element;

#if defined(__cplusplus)
static_assert(sizeof(clvox_halfspace) == 16, "clvox_halfspace layout");
static_assert(sizeof(clvox_cell) == 8, "clvox_cell layout");
static_assert(sizeof(clvox_element) == 16, "clvox_element layout");
#elif !defined(__OPENCL_VERSION__)
_Static_assert(sizeof(clvox_halfspace) == 16, "clvox_halfspace layout");
_Static_assert(sizeof(clvox_cell) == 8, "clvox_cell layout");
_Static_assert(sizeof(clvox_element) == 16, "clvox_element layout");
#endif

/* 1 when the point (px, py, pz) of the unit voxel lies in element e, else 0. */
CLVOX_PALETTE_FN int clvox_element_contains(const CLVOX_PALETTE_MEM clvox_element *elements,
                                            const CLVOX_PALETTE_MEM clvox_cell *cells,
                                            const CLVOX_PALETTE_MEM clvox_halfspace *planes, clvox_u32 e,
                                            clvox_f32 px, clvox_f32 py, clvox_f32 pz)
{
    clvox_element el = elements[e];
    int in = 0;
    for (clvox_u32 c = 0; c < el.cell_count && !in; c++) {
        clvox_cell cell = cells[el.first_cell + c];
        int all = 1;
        for (clvox_u32 k = 0; k < cell.plane_count && all; k++) {
            clvox_halfspace h = planes[cell.first_plane + k];
            clvox_f32 s = h.a * px + h.b * py;
            s = s + h.c * pz;
            all = s <= h.d;
        }
        in = all;
    }
    return el.complement ? !in : in;
}

#endif /* CLVOX_PALETTE_H */
