/* SPDX-License-Identifier: Apache-2.0 */
/* Stage classify: parity of the crossings beyond each voxel centre
 * (kernels/classify.cl). Host side: argument setup and enqueue. */
#include "core/internal.h"
#include "classify.h"

clvox_status clvox__classify_enqueue(clvox_context *ctx, cl_kernel k, const clvox__classify_args *a,
                                     cl_event *ev)
{
    cl_int err = 0;
    cl_uint i = 0;
    err |= clSetKernelArg(k, i++, sizeof(cl_mem), &a->rays);
    err |= clSetKernelArg(k, i++, sizeof(cl_uint), &a->ray_count);
    err |= clSetKernelArg(k, i++, sizeof(cl_mem), &a->hits);
    err |= clSetKernelArg(k, i++, sizeof(cl_mem), &a->counts);
    err |= clSetKernelArg(k, i++, sizeof(cl_uint), &a->capacity);
    err |= clSetKernelArg(k, i++, sizeof(cl_uint), &a->u_begin);
    err |= clSetKernelArg(k, i++, sizeof(cl_uint), &a->u_count);
    err |= clSetKernelArg(k, i++, sizeof(cl_uint), &a->out_stride);
    err |= clSetKernelArg(k, i++, sizeof(cl_mem), &a->out);
    err |= clSetKernelArg(k, i++, sizeof(cl_mem), &a->filled);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, CL_INVALID_KERNEL_ARGS, "clSetKernelArg(clvox_classify)");
    size_t local = 64, global = ((size_t)a->ray_count + local - 1) / local * local;
    err = clEnqueueNDRangeKernel(ctx->queue, k, 1, NULL, &global, &local, 0, NULL, ev);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "enqueue clvox_classify");
    return CLVOX_OK;
}
