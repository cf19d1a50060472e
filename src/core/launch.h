/* SPDX-License-Identifier: Apache-2.0 */
/* Kernel launches sized to the device and checked for completion
 * (launch.c). Every clvox kernel run by the library goes through
 * clvox__launch. Internal. */
#ifndef CLVOX_LAUNCH_H
#define CLVOX_LAUNCH_H

#include "internal.h"

/* Launches between two checks at most: CLVOX_LAUNCH_SLOTS
 * (kernels/clvox_types.h; a batch has 4 or 5, the raster chunks are
 * checked when this many are pending). */
#define CLVOX__LAUNCH_SLOTS CLVOX_LAUNCH_SLOTS

/* The local size for kernel k: the largest power of two <= want that the
 * kernel (CL_KERNEL_WORK_GROUP_SIZE) and the device
 * (CL_DEVICE_MAX_WORK_GROUP_SIZE, CL_DEVICE_MAX_WORK_ITEM_SIZES[0]) allow,
 * and at most CLVOX_LOCAL_SIZE (a test switch, environment.h). The kernels'
 * results do not depend on it: none uses local memory or barriers. */
clvox_status clvox__local_size(clvox_context *ctx, cl_kernel k, size_t want, size_t *local);

/* Starts a batch of launches: forgets those of an earlier batch that
 * failed before its check. */
void clvox__launch_begin(clvox_context *ctx);

/* Enqueues k over the work-items [offset, offset + n) in work-groups of
 * clvox__local_size(want), the global size rounded up to a whole number of
 * groups (every kernel ignores the work-items >= its count). Sets k's last
 * two arguments, the completion count buffer and this launch's slot in it
 * (kernels/prelude.cl clvox_done_mark), so that clvox__launch_check can
 * tell whether every work-group ran. n == 0 launches nothing (*ev NULL).
 * name: the kernel's, for messages. */
clvox_status clvox__launch(clvox_context *ctx, cl_kernel k, const char *name, size_t offset, size_t n,
                           size_t want, cl_event *ev);

/* Once the queue has run the batch's launches (or to wait for them): reads
 * the completion counts back, CLVOX_ERR_OPENCL "kernel X did not complete
 * on device Y" where a launch's count is short. Forgets the launches. */
clvox_status clvox__launch_check(clvox_context *ctx);

/* The check of launches still running, for batches in flight (the ray
 * method, src/cast/cast.c): clvox__launch_defer enqueues the read of the
 * completion counts of the launches since the last check into t, without
 * waiting (t->read: its event; the queue is in order, so that the read
 * completes after them, and before the next launches clear the counts),
 * and forgets them, as clvox__launch_check does; once t->read has
 * completed, clvox__launch_verify compares them as clvox__launch_check does
 * and releases t->read. t must stay in place until then. */
typedef struct clvox__launch_ticket {
    unsigned n;
    cl_uint expect[CLVOX__LAUNCH_SLOTS];
    cl_uint got[CLVOX__LAUNCH_SLOTS];
    char name[CLVOX__LAUNCH_SLOTS][40];
    cl_event read; /* NULL: nothing to verify */
} clvox__launch_ticket;
clvox_status clvox__launch_defer(clvox_context *ctx, clvox__launch_ticket *t);
clvox_status clvox__launch_verify(clvox_context *ctx, clvox__launch_ticket *t);
/* Releases t->read without a check (error paths, once the queue is finished). */
void clvox__launch_ticket_drop(clvox__launch_ticket *t);

/* Frees the launch state (clvox_context_destroy). NULL-safe. */
void clvox__launch_release(clvox_context *ctx);
#endif
