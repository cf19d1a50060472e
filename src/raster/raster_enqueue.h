/* SPDX-License-Identifier: Apache-2.0 */
/* What the two raster methods (tetra.c, surface.c) share, host side
 * (src/raster/raster_enqueue.c): a slab's task list, grown on the host and
 * on the device together, and one slab's pass: upload the tasks, clear,
 * run the raster kernel in chunks with the driver polled between them, run
 * the kernel that counts the slab's bits, read the count. */
#ifndef CLVOX_RASTER_ENQUEUE_H
#define CLVOX_RASTER_ENQUEUE_H
#include "core/internal.h"

/* A method's filled counter (one cl_uint) and kernels. Both raster
 * kernels are built in double and in float (kernels/overlap.h). */
clvox_status clvox__raster_objects(clvox_context *ctx, const char *raster_name, const char *count_name, cl_mem *filled,
                                   cl_kernel *raster, cl_kernel *count);


/* Tasks of 4 cl_uint each (their meaning is the method's). */
typedef struct clvox__raster_tasks {
    cl_uint *host;
    size_t cap;  /* tasks the host array holds */
    cl_mem dev;  /* NULL until clvox__raster_tasks_ready after each growth */
    size_t dev_cap; /* tasks the device buffer holds: cap, or fewer where the device's largest
                       buffer is smaller (clvox__raster_run then uploads them in windows) */
} clvox__raster_tasks;

/* Doubles the host array (from 4096 tasks); drops the device buffer. */
clvox_status clvox__raster_tasks_grow(clvox_context *ctx, clvox__raster_tasks *t);
/* Makes the device buffer at cap (at most the device's largest buffer),
 * where there is none (after binning). */
clvox_status clvox__raster_tasks_ready(clvox_context *ctx, clvox__raster_tasks *t);
void clvox__raster_tasks_release(clvox__raster_tasks *t);

/* Appends task n (*n += 1). Inline: the binning loops call it per task. */
static inline clvox_status clvox__raster_task_push(clvox_context *ctx, clvox__raster_tasks *t, size_t *n, cl_uint a,
                                                   cl_uint b, cl_uint c, cl_uint d)
{
    if (*n == t->cap) {
        clvox_status st = clvox__raster_tasks_grow(ctx, t);
        if (st != CLVOX_OK) return st;
    }
    cl_uint *q = t->host + 4 * (*n)++;
    q[0] = a;
    q[1] = b;
    q[2] = c;
    q[3] = d;
    return CLVOX_OK;
}

/* One slab's pass. The raster kernel takes (soup, tasks, task count, ...):
 * the pass sets those three, the caller the rest. The count kernel adds the
 * slab's bits to `filled` (clvox_tetra_resolve first turns the presence
 * markers into bits): it takes (bits, words per row, [X,] rows, filled),
 * all set by the pass. */
typedef struct clvox__raster_pass {
    const char *method;        /* "surface", "tetra": for messages */
    cl_kernel raster;
    const char *raster_name;
    cl_mem soup;
    size_t first_chunk;        /* tasks in the first chunk; the next ones are sized by time */
    cl_kernel count;
    const char *count_name;
    cl_uint count_x;           /* the count kernel's X argument; 0: it takes none */
    int clear;                 /* 0: the raster ORs into the slab as the previous method left it */
    cl_mem out;                /* the slab's bits: rows of words_per_row 32-bit words */
    cl_uint words_per_row, rows;
    size_t words;              /* words_per_row * rows */
    cl_mem filled;             /* one cl_uint */
    uint32_t z0;               /* for messages */
    int (*poll)(void *, double); /* clvox__run.poll */
    void *poll_user;
} clvox__raster_pass;

/* n tasks binned in t_bin seconds (counted as cast time). */
clvox_status clvox__raster_run(clvox_context *ctx, const clvox__raster_pass *p, const clvox__raster_tasks *tasks,
                               size_t n, double t_bin, clvox__slab_stats *ss);

/* ---- one preparation for the devices of a run (clvox__run.lead) ----
 * The lead (the method prepared on an earlier device of the run) did the
 * host work; a follower takes its host arrays by reference and copies its
 * device buffers. */

/* A device copy on ctx of `src`, a buffer of the lead's context `from`
 * (each device has a context of its own, maybe of another platform, so no
 * clEnqueueCopyBuffer): mapped for reading on the lead's queue, copied into
 * a new read-only buffer of ctx at creation, unmapped. Nothing is done when
 * *st is not CLVOX_OK; NULL on failure (*st set, the error in ctx). */
cl_mem clvox__raster_copy_buffer(clvox_context *ctx, clvox_context *from, cl_mem src, clvox_status *st,
                                 const char *what);

/* A host array of n int32 shared, read only once prepared, by one method's
 * states on the devices of a run; freed with its last reference. Taken and
 * dropped on the run's calling thread only (prepare, release), never by
 * the slab threads. new: NULL when out of memory. */
int32_t *clvox__shared_i32_new(size_t n);
int32_t *clvox__shared_i32_ref(int32_t *a);
void clvox__shared_i32_drop(int32_t *a); /* NULL-safe */
#endif
