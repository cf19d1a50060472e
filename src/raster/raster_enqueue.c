/* SPDX-License-Identifier: Apache-2.0 */
/* The raster methods' shared host side (tetra.c, surface.c): their task
 * lists and the pass over one slab. Both methods' kernels OR or XOR task
 * spans into the slab's bit rows; a chunk of tasks can take long (huge or
 * coincident triangles), so the tasks run in chunks of about
 * RASTER_CHUNK_SECONDS with the driver polled between them. */
#include "raster_enqueue.h"
#include "core/launch.h"

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

/* Target duration of one raster chunk between polls (seconds). */
#define RASTER_CHUNK_SECONDS 0.15

clvox_status clvox__raster_objects(clvox_context *ctx, const char *raster_name, const char *count_name, cl_mem *filled,
                                   cl_kernel *raster, cl_kernel *count)
{
    clvox_status st = CLVOX_OK;
    *filled = clvox__buffer(ctx, CL_MEM_READ_WRITE, sizeof(cl_uint), NULL, &st, "filled count");
    if (st == CLVOX_OK) st = clvox__kernel(ctx, raster_name, raster);
    if (st == CLVOX_OK) st = clvox__kernel(ctx, count_name, count);
    return st;
}

clvox_status clvox__raster_tasks_grow(clvox_context *ctx, clvox__raster_tasks *t)
{
    size_t cap = t->cap ? 2 * t->cap : 4096;
    cl_uint *p = realloc(t->host, cap * 4 * sizeof *p);
    if (!p) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu tasks", cap);
    t->host = p;
    t->cap = cap;
    clvox__release_mem(&t->dev); /* re-created at the new size */
    return CLVOX_OK;
}

clvox_status clvox__raster_tasks_ready(clvox_context *ctx, clvox__raster_tasks *t)
{
    clvox_status st = CLVOX_OK;
    if (!t->dev && t->cap) {
        const uint64_t fit = clvox__device_max_alloc(ctx) / (4 * sizeof(cl_uint));
        t->dev_cap = t->cap < fit ? t->cap : (size_t)fit;
        if (t->dev_cap < 1) return clvox__device_alloc_oom(ctx, 4 * sizeof(cl_uint), "a raster task");
        t->dev = clvox__buffer(ctx, CL_MEM_READ_ONLY, t->dev_cap * 4 * sizeof(cl_uint), NULL, &st, "tasks");
    }
    return st;
}

void clvox__raster_tasks_release(clvox__raster_tasks *t)
{
    clvox__release_mem(&t->dev);
    free(t->host);
    t->host = NULL;
    t->cap = 0;
    t->dev_cap = 0;
}

/* The raster kernel over tasks [0, n) of the device buffer, in chunks, the
 * driver polled between them (with the fraction (done + off) / total of the
 * slab's tasks); the last chunk's event in *last (timed with the others). */
static clvox_status raster_chunks(clvox_context *ctx, const clvox__raster_pass *p, size_t n, size_t done,
                                  size_t total, cl_event *last, clvox__slab_stats *ss)
{
    char what[96];
    size_t local;
    clvox_status st = clvox__local_size(ctx, p->raster, 64, &local);
    size_t off = 0, chunk = n < p->first_chunk ? n : p->first_chunk;
    double raster = 0;
    while (st == CLVOX_OK && off < n) {
        /* Whole work-groups but in the last chunk: the work-items past a
         * chunk's end run too, and must not be the next chunk's (tetra XORs). */
        size_t k = (chunk + local - 1) / local * local;
        if (k > n - off) k = n - off;
        cl_event e = NULL;
        double c0 = clvox__now();
        st = clvox__launch(ctx, p->raster, p->raster_name, off, k, local, &e);
        if (st != CLVOX_OK) break;
        off += k;
        if (off < n) { /* wait, adapt the chunk, ask whether to go on */
            cl_int err = clWaitForEvents(1, &e);
            if (err != CL_SUCCESS) {
                snprintf(what, sizeof what, "running %s", p->raster_name);
                st = clvox__cl_fail(ctx, err, what);
            }
            double dt = clvox__now() - c0;
            raster += clvox__event_seconds(e);
            clReleaseEvent(e);
            double want = dt > 0 ? (double)chunk * RASTER_CHUNK_SECONDS / dt : (double)n;
            chunk = want < 256 ? 256 : want > (double)n ? n : (size_t)want;
            if (st == CLVOX_OK && p->poll && !p->poll(p->poll_user, (double)(done + off) / (double)total))
                st = clvox__fail(ctx, CLVOX_ERR_CANCELLED, "cancelled within slab %u", p->z0);
        } else {
            *last = e; /* timed with the others by the caller */
        }
    }
    ss->classify_seconds += raster;
    return st;
}

clvox_status clvox__raster_run(clvox_context *ctx, const clvox__raster_pass *p, const clvox__raster_tasks *tasks,
                               size_t n, double t_bin, clvox__slab_stats *ss)
{
    if (n > UINT32_MAX) return clvox__fail(ctx, CLVOX_ERR_INTERNAL, "%zu tasks in one slab", n);
    enum { EV_TASKS, EV_CLEAR, EV_ZERO, EV_RASTER, EV_COUNT_BITS, EV_N };
    cl_event ev[EV_N] = {0};
    char what[96];
    clvox_status st = CLVOX_OK;
    cl_int err = CL_SUCCESS;
    cl_uint zero = 0, filled = 0;
    clvox__launch_begin(ctx);
    if (st == CLVOX_OK && p->clear) {
        err = clEnqueueFillBuffer(ctx->queue, p->out, &zero, sizeof zero, 0, p->words * sizeof(cl_uint), 0, NULL,
                                  &ev[EV_CLEAR]);
        if (err != CL_SUCCESS) st = clvox__cl_fail(ctx, err, "clearing the slab bits");
    }
    if (st == CLVOX_OK) {
        err = clEnqueueFillBuffer(ctx->queue, p->filled, &zero, sizeof zero, 0, sizeof zero, 0, NULL, &ev[EV_ZERO]);
        if (err != CL_SUCCESS) st = clvox__cl_fail(ctx, err, "clearing the filled count");
    }
    /* The tasks in windows of the device buffer (one window unless the
     * device's largest buffer is smaller than the list); the in-order
     * queue runs a window's raster before the next upload. */
    double upload_seconds = 0, raster_seconds = 0; /* of the windows before the last */
    for (size_t w0 = 0; st == CLVOX_OK && w0 < n; w0 += tasks->dev_cap) {
        const size_t k = n - w0 < tasks->dev_cap ? n - w0 : tasks->dev_cap;
        const cl_uint count = (cl_uint)k;
        if (w0) { /* the previous window's events: timed, then released */
            err = clWaitForEvents(1, &ev[EV_RASTER]);
            if (err != CL_SUCCESS) {
                snprintf(what, sizeof what, "running %s", p->raster_name);
                st = clvox__cl_fail(ctx, err, what);
                break;
            }
            upload_seconds += clvox__event_seconds(ev[EV_TASKS]);
            raster_seconds += clvox__event_seconds(ev[EV_RASTER]);
            clReleaseEvent(ev[EV_TASKS]);
            clReleaseEvent(ev[EV_RASTER]);
            ev[EV_TASKS] = ev[EV_RASTER] = NULL;
        }
        err = clEnqueueWriteBuffer(ctx->queue, tasks->dev, CL_FALSE, 0, k * 4 * sizeof(cl_uint), tasks->host + 4 * w0, 0,
                                   NULL, &ev[EV_TASKS]);
        if (err != CL_SUCCESS) {
            snprintf(what, sizeof what, "uploading %s tasks", p->method);
            st = clvox__cl_fail(ctx, err, what);
            break;
        }
        err = 0;
        err |= clSetKernelArg(p->raster, 0, sizeof(cl_mem), &p->soup);
        err |= clSetKernelArg(p->raster, 1, sizeof(cl_mem), &tasks->dev);
        err |= clSetKernelArg(p->raster, 2, sizeof(cl_uint), &count);
        if (err != CL_SUCCESS) {
            snprintf(what, sizeof what, "clSetKernelArg(%s)", p->raster_name);
            st = clvox__cl_fail(ctx, CL_INVALID_KERNEL_ARGS, what);
        } else {
            st = raster_chunks(ctx, p, k, w0, n, &ev[EV_RASTER], ss);
        }
    }
    if (st == CLVOX_OK) {
        cl_uint i = 0;
        err = 0;
        err |= clSetKernelArg(p->count, i++, sizeof(cl_mem), &p->out);
        err |= clSetKernelArg(p->count, i++, sizeof(cl_uint), &p->words_per_row);
        if (p->count_x) err |= clSetKernelArg(p->count, i++, sizeof(cl_uint), &p->count_x);
        err |= clSetKernelArg(p->count, i++, sizeof(cl_uint), &p->rows);
        err |= clSetKernelArg(p->count, i++, sizeof(cl_mem), &p->filled);
        if (err != CL_SUCCESS) {
            snprintf(what, sizeof what, "clSetKernelArg(%s)", p->count_name);
            st = clvox__cl_fail(ctx, CL_INVALID_KERNEL_ARGS, what);
        } else {
            st = clvox__launch(ctx, p->count, p->count_name, 0, p->rows, 64, &ev[EV_COUNT_BITS]);
        }
    }
    if (st == CLVOX_OK) {
        err = clEnqueueReadBuffer(ctx->queue, p->filled, CL_TRUE, 0, sizeof filled, &filled, 0, NULL, NULL);
        if (err != CL_SUCCESS) {
            snprintf(what, sizeof what, "running the %s kernels", p->method);
            st = clvox__cl_fail(ctx, err, what);
        }
        if (st == CLVOX_OK) st = clvox__launch_check(ctx);
    }
    if (st == CLVOX_OK) {
        ss->filled += filled;
        ss->cast_seconds += t_bin + upload_seconds + clvox__event_seconds(ev[EV_TASKS]) +
                            clvox__event_seconds(ev[EV_CLEAR]) + clvox__event_seconds(ev[EV_ZERO]);
        ss->classify_seconds += raster_seconds + clvox__event_seconds(ev[EV_RASTER]) + clvox__event_seconds(ev[EV_COUNT_BITS]);
    } else {
        clFinish(ctx->queue); /* the host task array must outlive the upload */
    }
    for (int i = 0; i < EV_N; i++)
        if (ev[i]) clReleaseEvent(ev[i]);
    return st;
}

/* ---- one preparation for the devices of a run ---- */

cl_mem clvox__raster_copy_buffer(clvox_context *ctx, clvox_context *from, cl_mem src, clvox_status *st,
                                 const char *what)
{
    if (*st != CLVOX_OK) return NULL;
    size_t bytes = 0;
    char msg[160];
    cl_int err = clGetMemObjectInfo(src, CL_MEM_SIZE, sizeof bytes, &bytes, NULL);
    void *host = NULL;
    if (err == CL_SUCCESS)
        host = clEnqueueMapBuffer(from->queue, src, CL_TRUE, CL_MAP_READ, 0, bytes, 0, NULL, NULL, &err);
    if (err != CL_SUCCESS || !host) {
        snprintf(msg, sizeof msg, "reading the %s of device '%.40s'", what, from->device.name);
        *st = clvox__cl_fail(ctx, err != CL_SUCCESS ? err : CL_MAP_FAILURE, msg);
        return NULL;
    }
    /* CL_MEM_COPY_HOST_PTR: copied before clCreateBuffer returns */
    cl_mem m = clvox__buffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, bytes, host, st, what);
    err = clEnqueueUnmapMemObject(from->queue, src, host, 0, NULL, NULL);
    if (err == CL_SUCCESS) err = clFinish(from->queue);
    if (err != CL_SUCCESS && *st == CLVOX_OK) {
        clvox__release_mem(&m);
        snprintf(msg, sizeof msg, "clEnqueueUnmapMemObject(the %s of device '%.40s')", what, from->device.name);
        *st = clvox__cl_fail(ctx, err, msg);
    }
    return m;
}

/* The reference count sits before the array (aligned for any int32). */
typedef struct shared_i32 {
    size_t refs;
    int32_t a[];
} shared_i32;

static shared_i32 *shared_of(int32_t *a)
{
    return (shared_i32 *)(void *)((char *)a - offsetof(shared_i32, a));
}

int32_t *clvox__shared_i32_new(size_t n)
{
    if (n > (SIZE_MAX - sizeof(shared_i32)) / sizeof(int32_t) - 1) return NULL;
    shared_i32 *h = malloc(sizeof *h + (n ? n : 1) * sizeof(int32_t));
    if (!h) return NULL;
    h->refs = 1;
    return h->a;
}

int32_t *clvox__shared_i32_ref(int32_t *a)
{
    if (a) shared_of(a)->refs++;
    return a;
}

void clvox__shared_i32_drop(int32_t *a)
{
    if (!a) return;
    shared_i32 *h = shared_of(a);
    if (--h->refs == 0) free(h);
}
