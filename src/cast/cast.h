/* SPDX-License-Identifier: Apache-2.0 */
/* What the cast (src/cast/cast.c: leaf lookup, intersection, sort) hands
 * the consumer kernels that read its sorted crossings (classify.c,
 * winding_classify.c, coverage.c, palette_score.c): one batch's device
 * buffers and where its voxels go in the slab. */
#ifndef CLVOX_CAST_H
#define CLVOX_CAST_H
#include "core/internal.h"

/* Device buffers of one batch. */
typedef struct clvox__batch_mem {
    cl_mem rays, cols, leaf, hits, counts, filled, sums, pstats, pvolume;
    cl_mem signs, exact; /* winding: a sign per crossing; points evaluated exactly */
    cl_mem unsure;       /* binary winding runs: the float build's unsure points (kernels/winding.cl) */
    cl_uint unsure_room; /* entries it holds (0: a double device, which leaves none) */
    size_t max_rays, max_items; /* items: rays (binary) or columns (coverage) */
    cl_uint capacity;
} clvox__batch_mem;

/* Where one batch's voxels go in the slab. */
typedef struct clvox__slab_target {
    cl_uint u_begin, u_count; /* voxels along the rays covered by the slab */
    cl_uint out_stride;       /* bit-row words between voxels of a ray; 0: one row */
    const clvox__slab_out *out;
} clvox__slab_target;

#endif
