/* SPDX-License-Identifier: Apache-2.0 */
/* Stage classify, host side (src/cast/classify.c). */
#ifndef CLVOX_CLASSIFY_H
#define CLVOX_CLASSIFY_H
#include "core/internal.h"

typedef struct clvox__classify_args {
    cl_mem rays;        /* clvox_ray[ray_count]                       */
    cl_uint ray_count;
    cl_mem hits;        /* sorted crossings, `capacity` per ray         */
    cl_mem counts;      /* crossings per ray (rays above capacity skipped) */
    cl_uint capacity;
    cl_uint u_begin, u_count, out_stride; /* out_stride 0: rays along x, one bit row each */
    cl_mem out;         /* slab bit rows (src/core/internal.h)             */
    cl_mem filled;      /* cl_uint per ray: voxels set                 */
} clvox__classify_args;

clvox_status clvox__classify_enqueue(clvox_context *ctx, cl_kernel k, const clvox__classify_args *a,
                                     cl_event *ev);
#endif
