/* SPDX-License-Identifier: Apache-2.0 */
/* Kernel launches: local sizes from the device's and the kernel's limits,
 * and completion counts (launch.h). A runtime may stop a kernel without
 * returning an error to the host (Oclgrind does on an instruction it cannot
 * run); every kernel then counts its finished work-groups into a slot of a
 * small buffer, and the host compares the counts with what it launched. */
#include "launch.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct clvox__launch_state {
    cl_mem done;    /* CLVOX__LAUNCH_SLOTS completion counts */
    size_t dev_max; /* min(CL_DEVICE_MAX_WORK_GROUP_SIZE, CL_DEVICE_MAX_WORK_ITEM_SIZES[0]) */
    unsigned pending; /* launches since the last check (their slots) */
    cl_uint expect[CLVOX__LAUNCH_SLOTS];
    cl_uint got[CLVOX__LAUNCH_SLOTS];
    char name[CLVOX__LAUNCH_SLOTS][40];
};

static const cl_uint zeros[CLVOX__LAUNCH_SLOTS]; /* the counts before a batch; static: outlives any upload */

static clvox_status state(clvox_context *ctx, struct clvox__launch_state **out)
{
    if (ctx->launch) {
        *out = ctx->launch;
        return CLVOX_OK;
    }
    struct clvox__launch_state *s = calloc(1, sizeof *s);
    if (!s) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for the launch state");
    size_t wg = 0, items[3] = {0};
    cl_uint dims = 0;
    cl_int err = clGetDeviceInfo(ctx->device_id, CL_DEVICE_MAX_WORK_GROUP_SIZE, sizeof wg, &wg, NULL);
    if (err == CL_SUCCESS)
        err = clGetDeviceInfo(ctx->device_id, CL_DEVICE_MAX_WORK_ITEM_DIMENSIONS, sizeof dims, &dims, NULL);
    if (err == CL_SUCCESS && dims >= 1 && dims <= 3)
        err = clGetDeviceInfo(ctx->device_id, CL_DEVICE_MAX_WORK_ITEM_SIZES, dims * sizeof(size_t), items, NULL);
    else if (err == CL_SUCCESS)
        items[0] = wg; /* more than 3 dimensions: the first is all we use; the group limit still holds */
    if (err != CL_SUCCESS) {
        free(s);
        return clvox__cl_fail(ctx, err, "clGetDeviceInfo(work-group limits)");
    }
    s->dev_max = wg < items[0] ? wg : items[0];
    if (s->dev_max < 1) s->dev_max = 1;
    clvox_status st = CLVOX_OK;
    s->done = clvox__buffer(ctx, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, sizeof zeros, (void *)zeros, &st,
                            "completion counts");
    if (st != CLVOX_OK) {
        free(s);
        return st;
    }
    ctx->launch = *out = s;
    return CLVOX_OK;
}

clvox_status clvox__local_size(clvox_context *ctx, cl_kernel k, size_t want, size_t *local)
{
    struct clvox__launch_state *s = NULL;
    clvox_status st = state(ctx, &s);
    if (st != CLVOX_OK) return st;
    size_t kmax = 0;
    cl_int err = clGetKernelWorkGroupInfo(k, ctx->device_id, CL_KERNEL_WORK_GROUP_SIZE, sizeof kmax, &kmax, NULL);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "clGetKernelWorkGroupInfo(CL_KERNEL_WORK_GROUP_SIZE)");
    size_t cap = want < s->dev_max ? want : s->dev_max;
    if (kmax && kmax < cap) cap = kmax;
    unsigned forced = clvox__hooks()->local_size;
    if (forced && forced < cap) cap = forced;
    size_t l = 1;
    while (l * 2 <= cap) l *= 2;
    *local = l;
    return CLVOX_OK;
}

void clvox__launch_begin(clvox_context *ctx)
{
    if (ctx->launch) ctx->launch->pending = 0;
}

clvox_status clvox__launch(clvox_context *ctx, cl_kernel k, const char *name, size_t offset, size_t n,
                           size_t want, cl_event *ev)
{
    char what[96];
    if (ev) *ev = NULL;
    if (n == 0) return CLVOX_OK;
    size_t local;
    clvox_status st = clvox__local_size(ctx, k, want, &local);
    if (st != CLVOX_OK) return st;
    struct clvox__launch_state *s = ctx->launch;
    if (s->pending == CLVOX__LAUNCH_SLOTS && (st = clvox__launch_check(ctx)) != CLVOX_OK) return st;
    size_t global = (n + local - 1) / local * local, groups = global / local;
    if (groups > UINT32_MAX) return clvox__fail(ctx, CLVOX_ERR_INTERNAL, "%zu work-groups in one launch", groups);
    cl_uint nargs = 0, slot = s->pending;
    cl_int err = clGetKernelInfo(k, CL_KERNEL_NUM_ARGS, sizeof nargs, &nargs, NULL);
    if (err == CL_SUCCESS && nargs < 2) err = CL_INVALID_KERNEL_ARGS;
    if (err == CL_SUCCESS) err = clSetKernelArg(k, nargs - 2, sizeof(cl_mem), &s->done);
    if (err == CL_SUCCESS) err = clSetKernelArg(k, nargs - 1, sizeof(cl_uint), &slot);
    if (err != CL_SUCCESS) {
        snprintf(what, sizeof what, "clSetKernelArg(%s, completion count)", name);
        return clvox__cl_fail(ctx, err, what);
    }
    if (slot == 0) { /* the batch's first launch: every count from 0 */
        err = clEnqueueWriteBuffer(ctx->queue, s->done, CL_FALSE, 0, sizeof zeros, zeros, 0, NULL, NULL);
        if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "clearing the completion counts");
    }
    err = clEnqueueNDRangeKernel(ctx->queue, k, 1, &offset, &global, &local, 0, NULL, ev);
    if (err != CL_SUCCESS) {
        snprintf(what, sizeof what, "enqueue %s (local size %zu)", name, local);
        return clvox__cl_fail(ctx, err, what);
    }
    s->expect[slot] = (cl_uint)groups;
    snprintf(s->name[slot], sizeof s->name[slot], "%s", name);
    s->pending++;
    return CLVOX_OK;
}

clvox_status clvox__launch_check(clvox_context *ctx)
{
    struct clvox__launch_state *s = ctx->launch;
    if (!s || !s->pending) return CLVOX_OK;
    unsigned n = s->pending;
    s->pending = 0;
    cl_int err = clEnqueueReadBuffer(ctx->queue, s->done, CL_TRUE, 0, n * sizeof(cl_uint), s->got, 0, NULL, NULL);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "reading the completion counts");
    for (unsigned i = 0; i < n; i++)
        if (s->got[i] != s->expect[i])
            return clvox__fail(ctx, CLVOX_ERR_OPENCL,
                               "kernel %s did not complete on device %s (%u of %u work-groups finished)",
                               s->name[i], ctx->device.name, (unsigned)s->got[i], (unsigned)s->expect[i]);
    return CLVOX_OK;
}

clvox_status clvox__launch_defer(clvox_context *ctx, clvox__launch_ticket *t)
{
    struct clvox__launch_state *s = ctx->launch;
    t->n = 0;
    t->read = NULL;
    if (!s || !s->pending) return CLVOX_OK;
    unsigned n = s->pending;
    s->pending = 0;
    memcpy(t->expect, s->expect, n * sizeof *t->expect);
    memcpy(t->name, s->name, n * sizeof *t->name);
    cl_int err = clEnqueueReadBuffer(ctx->queue, s->done, CL_FALSE, 0, n * sizeof(cl_uint), t->got, 0, NULL, &t->read);
    if (err != CL_SUCCESS) {
        t->read = NULL;
        return clvox__cl_fail(ctx, err, "reading the completion counts");
    }
    t->n = n;
    return CLVOX_OK;
}

clvox_status clvox__launch_verify(clvox_context *ctx, clvox__launch_ticket *t)
{
    if (!t->read) return CLVOX_OK;
    cl_int err = clWaitForEvents(1, &t->read);
    clvox__launch_ticket_drop(t);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "reading the completion counts");
    for (unsigned i = 0; i < t->n; i++)
        if (t->got[i] != t->expect[i])
            return clvox__fail(ctx, CLVOX_ERR_OPENCL,
                               "kernel %s did not complete on device %s (%u of %u work-groups finished)",
                               t->name[i], ctx->device.name, (unsigned)t->got[i], (unsigned)t->expect[i]);
    return CLVOX_OK;
}

void clvox__launch_ticket_drop(clvox__launch_ticket *t)
{
    if (t->read) clReleaseEvent(t->read);
    t->read = NULL;
}

void clvox__launch_release(clvox_context *ctx)
{
    if (!ctx || !ctx->launch) return;
    clvox__release_mem(&ctx->launch->done);
    free(ctx->launch);
    ctx->launch = NULL;
}
