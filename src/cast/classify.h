/* SPDX-License-Identifier: Apache-2.0 */
/* Stage classify, host side (src/cast/classify.c); the argument head and
 * launch the other consumers share. */
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

/* From argument *i on: a's arguments in order, with signs (winding
 * crossings' signs) after the crossings where not NULL. */
cl_int clvox__classify_args_set(cl_kernel k, cl_uint *i, const clvox__classify_args *a, const cl_mem *signs);
/* Fails with args_err (from setting k's arguments), else enqueues k over n
 * items in work-groups of `local`; `name` is k's, for messages. */
clvox_status clvox__consumer_launch(clvox_context *ctx, cl_kernel k, const char *name, cl_int args_err, cl_uint n,
                                    size_t local, cl_event *ev);
clvox_status clvox__classify_enqueue(clvox_context *ctx, cl_kernel k, const clvox__classify_args *a,
                                     cl_event *ev);
#endif
