/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Structs shared by the host (C11) and the OpenCL kernels.
 * Only fixed-width scalars, explicit padding; sizes pinned on the host.
 */
#ifndef CLVOX_TYPES_H
#define CLVOX_TYPES_H

#ifdef __OPENCL_VERSION__
typedef uint clvox_u32;
typedef float clvox_f32;
#else
#include <stdint.h>
typedef uint32_t clvox_u32;
typedef float clvox_f32;
#endif

/* Quadtree node over the ray plane (v,w), in grid coordinates.
 * Internal node: count == CLVOX_QT_INTERNAL, first = index of its 4 children
 * (child q holds points with (v >= split_v) + 2*(w >= split_w) == q).
 * Leaf: refs[first .. first+count) are the triangles it holds. */
#define CLVOX_QT_INTERNAL 0xFFFFFFFFu

/* Completion counts of kernel launches (src/core/launch.c, prelude.cl
 * clvox_done_mark): the buffer's slots, launches between two checks. */
#define CLVOX_LAUNCH_SLOTS 64u
typedef struct clvox_qt_node {
    clvox_f32 split_v, split_w;
    clvox_u32 first, count;
} clvox_qt_node;

/* One ray parallel to the u axis at (v,w) of the ray plane, in grid
 * coordinates (voxel centres at integers). Its classified voxels are bits
 * of the slab's bit rows: rays along x own the row at word out_base; other
 * rays set bit `bit` of word out_base + (u - u_begin) * out_stride. */
typedef struct clvox_ray {
    clvox_f32 v, w;
    clvox_u32 out_base;
    clvox_u32 bit;
} clvox_ray;

/* One voxel column of a coverage run: its rays are rays[c*R .. c*R+R) of
 * the batch (R = N*N); `id` is the sampler's column key (sampler.h); its
 * voxels go to the slab as for a ray (out_base, bit: see clvox_ray). */
typedef struct clvox_column {
    clvox_u32 id;
    clvox_u32 out_base;
    clvox_u32 bit;
    clvox_u32 pad;
} clvox_column;

/* Node of the cap tree (winding numbers, kernels/winding_*.h), in scaled
 * grid space (x, y, z order; grid coordinates times the voxel size, so that
 * solid angles are those of the world). Triangles tri_first ..
 * tri_first+tri_count-1 of the cap array lie in it (every subtree is a
 * contiguous range); child == 0: a leaf, else the children are child and
 * child+1. Rounded so that bounds stay bounds: the box outwards, area4pi >=
 * their area / 4pi, the sphere (centre, radius) holds them; normal4pi is
 * their vector area / 4pi (for the dipole term); half_count = tri_count / 2
 * (no triangle subtends more than half the sphere). About the (float)
 * centre c, in double, then stored: second4pi >= the integral of |y - c|^2
 * dA / 4pi (rounded up), quad4pi = tr(M) I - 3 sym(M) in the order xx, yy,
 * zz, xy, xz, yz (rounded to nearest), M_ij = the integral of n_i (y -
 * c)_j dA / 4pi (n dA: the vector area element), for the first-order term
 * (kernels/winding_bounds.h clvox_cap_estimate); both 0 in the rims' tree, and
 * so is area4pi there, where normal4pi[a] bounds the edges' length across
 * axis a / 4pi (clvox_rim_box_bound; rounded up). block:
 * on a cap leaf, where its caps are again, lane-major (the index of the
 * first real: real k of lane l at block + 4k + l, lanes past tri_count
 * repeating the first), after the caps themselves in the same buffer; 0
 * elsewhere.
 * Weld pairs (src/winding/crack_weld.c): a node holding them has radius
 * CLVOX_PAIR_RADIUS, which turns off the estimates (only the box bound
 * holds), area4pi >= the sum of its pairs' (per(T) + 6 delta) delta / 4pi
 * (kernels/winding_bounds.h), half_count = its pairs (no pair changes w by
 * more than 1), the moments 0; its box holds both triangles of each pair,
 * which lie next to each other in the caps (rev T, then T'), two pairs a
 * leaf. Where the caps and the pairs share a tree, the root's children are
 * the caps' tree and the pairs' tree, and the root has the pairs' radius.
 * A tree whose root has it is a pair tree (CLVOX_PAIR_TREE). */
#define CLVOX_PAIR_RADIUS 1e30f
typedef struct clvox_cap_node {
    clvox_f32 lo[3], area4pi;
    clvox_f32 hi[3], half_count;
    clvox_f32 centre[3], radius;
    clvox_f32 normal4pi[3], second4pi;
    clvox_u32 child, tri_first, tri_count, block;
    clvox_f32 quad4pi[6];
} clvox_cap_node;

/* A block of the winding classify's lattice (kernels/winding_lattice.h,
 * src/cast/winding_lattice.c sizes the buffer): M2 along x, y and z, the
 * caps' bound where it decides alone, whether it interpolates. */
#define CLVOX_BLOCK_WORDS 5u
/* A block split in near and far caps: its near caps' w_caps at its 8
 * corners (value, error bound), then the far caps' M2; its near caps: a
 * count, then up to CLVOX_NEAR_MAX cap tree leaves. */
#define CLVOX_SPLIT_WORDS 17u
#define CLVOX_NEAR_MAX 32u

#if defined(__cplusplus)
static_assert(sizeof(clvox_cap_node) == 104, "clvox_cap_node layout");
static_assert(sizeof(clvox_qt_node) == 16, "clvox_qt_node layout");
static_assert(sizeof(clvox_ray) == 16, "clvox_ray layout");
static_assert(sizeof(clvox_column) == 16, "clvox_column layout");
#elif !defined(__OPENCL_VERSION__)
_Static_assert(sizeof(clvox_cap_node) == 104, "clvox_cap_node layout");
_Static_assert(sizeof(clvox_qt_node) == 16, "clvox_qt_node layout");
_Static_assert(sizeof(clvox_ray) == 16, "clvox_ray layout");
_Static_assert(sizeof(clvox_column) == 16, "clvox_column layout");
#endif

#endif /* CLVOX_TYPES_H */
