/* SPDX-License-Identifier: Apache-2.0 */
/* Several devices, one volume, in order (schedule.c; docs/design.md
 * "Several devices"): the slabs of a run are computed on every device of
 * the context at once, each device on a host thread of its own, and the
 * calling thread writes them in increasing z from a bounded reorder buffer
 * while the devices compute the next ones. Internal. */
#ifndef CLVOX_SCHEDULE_H
#define CLVOX_SCHEDULE_H

#include "core/internal.h"

#include <pthread.h>

/* One device of a run: what voxelize.c prepares for it, then the
 * scheduler's record of it. */
typedef struct clvox__sched_device {
    clvox_context *ctx;            /* its context (a member of the run's) */
    clvox__method_state *ms, *ms2; /* its prepared method(s); NULL ms: not in the run */
    cl_mem plane[4];               /* its planes (occupancy, coverage, element, score), `group` slabs deep */
    uint32_t group;                /* slabs per method call (its launch unit, >= 1): consecutive slabs of
                                    * its packet computed at once, then read back slab by slab */
    /* ---- the scheduler's (schedule.c) ---- */
    struct clvox__sched *sched;
    uint32_t index;
    pthread_t thread;
    int started, dead, left_out;
    uint32_t pk_next, pk_end;      /* its packet: slabs [pk_next, pk_end) */
    uint32_t current, current_end; /* the slabs it computes, [current, current_end); current UINT32_MAX: none */
    double fraction;               /* of the current call, as the method polls */
    uint32_t slabs_started;        /* for CLVOX_TEST_FAIL_DEVICE (a group counts its slabs) */
    uint32_t slabs_won, slabs_lost;
    uint64_t slices_won;
    double busy_won, busy_all;
} clvox__sched_device;

typedef struct clvox__sched_job {
    clvox_context *ctx;                /* the run's: errors, warnings */
    const clvox__method *m, *m2;       /* m2: the surface pass of conservative runs, or NULL */
    clvox__sched_device *dev;
    uint32_t ndev;
    uint64_t plane_slice[4];           /* bytes per slice of each plane (0: not produced) */
    uint32_t Z, depth;                 /* slices, slices per slab */
    uint32_t window;                   /* reorder buffer, slabs (>= 2) */
    clvox__sink_fn sink;
    void *sink_user;
    clvox_progress_fn progress;        /* the caller's, or NULL */
    void *progress_user;
} clvox__sched_job;

/* The poll callback of every device's methods (clvox__run.poll), with its
 * clvox__sched_device as the user pointer: 0 when the run is stopping or
 * another device has already finished this slab. */
int clvox__sched_poll(void *device, double slab_fraction);

/* The reorder buffer's size in slabs for ndev devices computing up to
 * `group` slabs per call, and slabs of slab_bytes: 2 groups with one device
 * (one written while the next is computed), else 4 slabs or 2 groups per
 * device, whichever is more; fewer when that passes 256 MiB, but at least
 * ndev + 1 (a group never waits for room it cannot get: it is cut at the
 * window's end). */
uint32_t clvox__sched_window(uint32_t ndev, uint32_t group, uint64_t slab_bytes);

/* Slabs per method call on device dc (docs/design.md "Several devices",
 * launch groups; voxelize.c): CLVOX_LAUNCH_SLABS where set; the ray method
 * (ray != 0) on a GPU, enough slabs that a call casts compute units x 2048
 * rays (x and y rays: the slab's columns x oversample^2; z rays: one slab);
 * else one (CPU devices: PoCL measured no gain, docs/benchmarks.md). At
 * most the run's slabs of `depth`, and the group's planes (plane_slice:
 * bytes per slice of each) within the device's largest buffer and a
 * quarter of its memory budget. */
uint32_t clvox__launch_slabs(const clvox_context *dc, int ray, const clvox_voxelize_options *o, const clvox_grid *g,
                             uint32_t depth, const uint64_t plane_slice[4]);

/* Runs the job: every slab computed once (more where a straggler is
 * re-issued: the first result is kept) and handed to the sink once, in
 * increasing z. A device that fails is dropped with a warning in the
 * run's context and its slabs are redone on the others; when all have
 * failed, the run fails with the first device's error. Adds the slab
 * statistics, the write time and the device shares to *stats. */
clvox_status clvox__sched_run(const clvox__sched_job *job, clvox_stats *stats);

#endif
