/* SPDX-License-Identifier: Apache-2.0 */
/* Host threads for the stages that run on the CPU before the device work
 * (mesh report, grid-space transform, quadtree). Internal. */
#ifndef CLVOX_PARALLEL_H
#define CLVOX_PARALLEL_H
#include <stddef.h>

/* Upper bound on host threads: past it the passes are memory bound. */
#define CLVOX__MAX_HOST_THREADS 16

/* The number of host threads to use: CLVOX_HOST_THREADS when set (1..16, environment.h;
 * for benchmarks and tests), else the online cores, at most 8. */
int clvox__host_threads(void);

/* Runs fn(arg, i, n) for i = 0..n-1, on up to n threads (the caller's
 * included), and returns when all are done. When a thread cannot be
 * started its part runs on the caller's, so the work is always done; the
 * callers make their results independent of n anyway. */
void clvox__parallel(int n, void (*fn)(void *arg, int i, int n), void *arg);

/* [*begin, *end) of part i of n of [0, count). */
void clvox__part_range(size_t count, int i, int n, size_t *begin, size_t *end);
#endif
