/* SPDX-License-Identifier: Apache-2.0 */
/* Device memory: the limits a run sizes its buffers by, and the messages
 * for running out of them (internal.h "device memory").
 *
 * Two limits: CL_DEVICE_MAX_MEM_ALLOC_SIZE bounds each buffer (the ray
 * method sizes its batches so that its crossing buffer fits), and
 * CLVOX_DEVICE_BUDGET_NUM/DEN of CL_DEVICE_GLOBAL_MEM_SIZE bounds what a run
 * holds at once (the mesh's buffers, the slab planes, the batches), leaving
 * the rest to the driver and to other programs. Drivers that allocate
 * lazily (NVIDIA) report a lack of memory only at the first enqueue that
 * uses the buffer, as CL_OUT_OF_RESOURCES or CL_MEM_OBJECT_ALLOCATION_FAILURE:
 * clvox__cl_fail turns those into CLVOX_ERR_OUT_OF_MEMORY naming the
 * device's memory (clvox__device_cl_oom). */
#include "internal.h"

#include <stdio.h>

void clvox__device_memory_hooks(clvox_device_info *info)
{
    const clvox__test_hooks *h = clvox__hooks();
    if (h->device_max_alloc && (!info->max_alloc_bytes || h->device_max_alloc < info->max_alloc_bytes))
        info->max_alloc_bytes = h->device_max_alloc;
    if (h->device_global_mem && (!info->global_mem_bytes || h->device_global_mem < info->global_mem_bytes))
        info->global_mem_bytes = h->device_global_mem;
    /* no buffer is larger than the memory that holds it */
    if (info->global_mem_bytes && info->max_alloc_bytes > info->global_mem_bytes)
        info->max_alloc_bytes = info->global_mem_bytes;
}

uint64_t clvox__device_max_alloc(const clvox_context *ctx)
{
    return ctx->device.max_alloc_bytes ? ctx->device.max_alloc_bytes : (1ull << 31);
}

uint64_t clvox__device_budget(const clvox_context *ctx)
{
    const uint64_t g = ctx->device.global_mem_bytes;
    return g ? g / CLVOX_DEVICE_BUDGET_DEN * CLVOX_DEVICE_BUDGET_NUM : UINT64_MAX;
}

uint64_t clvox__mem_bytes(cl_mem m)
{
    size_t n = 0;
    if (m && clGetMemObjectInfo(m, CL_MEM_SIZE, sizeof n, &n, NULL) != CL_SUCCESS) n = 0;
    return n;
}

clvox_status clvox__device_oom(clvox_context *ctx, uint64_t need, uint64_t have, const char *what)
{
    char n[32], h[32], g[32];
    clvox__format_size(need, n, sizeof n);
    clvox__format_size(have, h, sizeof h);
    clvox__format_size(ctx->device.global_mem_bytes, g, sizeof g);
    return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY,
                       "device '%s': the run needs %s of device memory (%s), it has %s (%d/%d of its %s; use a "
                       "smaller grid, slab depth or oversampling)",
                       ctx->device.name, n, what, h, CLVOX_DEVICE_BUDGET_NUM, CLVOX_DEVICE_BUDGET_DEN, g);
}

clvox_status clvox__device_alloc_oom(clvox_context *ctx, uint64_t need, const char *what)
{
    char n[32], h[32];
    clvox__format_size(need, n, sizeof n);
    clvox__format_size(clvox__device_max_alloc(ctx), h, sizeof h);
    return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY,
                       "device '%s': %s needs a buffer of %s, more than the largest the device allows (%s)",
                       ctx->device.name, what, n, h);
}

clvox_status clvox__device_cl_oom(clvox_context *ctx, cl_int err, const char *what)
{
    char g[32], a[32];
    clvox__format_size(ctx->device.global_mem_bytes, g, sizeof g);
    clvox__format_size(clvox__device_max_alloc(ctx), a, sizeof a);
    return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY,
                       "%s: %s (%d): device '%s' is out of memory (it has %s, buffers of at most %s; drivers that "
                       "allocate on first use report it here, and some report a kernel fault the same way)",
                       what, clvox__cl_error_name(err), (int)err, ctx->device.name, g, a);
}
