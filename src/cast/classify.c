/* SPDX-License-Identifier: Apache-2.0 */
/* Stage classify: parity of the crossings beyond each voxel centre
 * (kernels/classify.cl). Host side: argument setup and enqueue, and the
 * argument head and launch that the winding classify (winding_classify.c)
 * shares with it. */
#include "core/internal.h"
#include "classify.h"
#include "core/launch.h"

#include <stdio.h>

cl_int clvox__classify_args_set(cl_kernel k, cl_uint *i, const clvox__classify_args *a, const cl_mem *signs)
{
    cl_int err = 0;
    err |= clSetKernelArg(k, (*i)++, sizeof(cl_mem), &a->rays);
    err |= clSetKernelArg(k, (*i)++, sizeof(cl_uint), &a->ray_count);
    err |= clSetKernelArg(k, (*i)++, sizeof(cl_mem), &a->hits);
    if (signs) err |= clSetKernelArg(k, (*i)++, sizeof(cl_mem), signs);
    err |= clSetKernelArg(k, (*i)++, sizeof(cl_mem), &a->counts);
    err |= clSetKernelArg(k, (*i)++, sizeof(cl_uint), &a->capacity);
    err |= clSetKernelArg(k, (*i)++, sizeof(cl_uint), &a->u_begin);
    err |= clSetKernelArg(k, (*i)++, sizeof(cl_uint), &a->u_count);
    err |= clSetKernelArg(k, (*i)++, sizeof(cl_uint), &a->out_stride);
    err |= clSetKernelArg(k, (*i)++, sizeof(cl_mem), &a->out);
    err |= clSetKernelArg(k, (*i)++, sizeof(cl_mem), &a->filled);
    return err;
}

clvox_status clvox__consumer_launch(clvox_context *ctx, cl_kernel k, const char *name, cl_int args_err, cl_uint n,
                                    size_t local, cl_event *ev)
{
    char what[64];
    if (args_err != CL_SUCCESS) {
        snprintf(what, sizeof what, "clSetKernelArg(%s)", name);
        return clvox__cl_fail(ctx, CL_INVALID_KERNEL_ARGS, what);
    }
    return clvox__launch(ctx, k, name, 0, n, local, ev);
}

clvox_status clvox__classify_enqueue(clvox_context *ctx, cl_kernel k, const clvox__classify_args *a,
                                     cl_event *ev)
{
    cl_uint i = 0;
    cl_int err = clvox__classify_args_set(k, &i, a, NULL);
    return clvox__consumer_launch(ctx, k, "clvox_classify", err, a->ray_count, 64, ev);
}
