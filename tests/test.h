/* SPDX-License-Identifier: Apache-2.0 */
/* Minimal test harness: CHECK / CHECK_OK print file:line on failure; each
 * test program ends with one "N passed, N failed" line (tests/run_tests.sh
 * adds them up). */
#ifndef CLVOX_TEST_H
#define CLVOX_TEST_H
#include <stdio.h>
#include <stdlib.h>
#include "clvox.h"

extern int test_passed, test_failed;

#define CHECK(expr) do { \
    if (expr) { test_passed++; } \
    else { test_failed++; fprintf(stderr, "FAIL %s:%d: %s\n", __FILE__, __LINE__, #expr); } \
} while (0)

#define CHECK_MSG(expr, ...) do { \
    if (expr) { test_passed++; } \
    else { test_failed++; fprintf(stderr, "FAIL %s:%d: %s: ", __FILE__, __LINE__, #expr); \
           fprintf(stderr, __VA_ARGS__); fputc('\n', stderr); } \
} while (0)

/* ctx may be NULL. */
#define CHECK_OK(ctx, call) do { \
    clvox_status st_ = (call); \
    if (st_ == CLVOX_OK) { test_passed++; } \
    else { test_failed++; fprintf(stderr, "FAIL %s:%d: %s -> %s: %s\n", __FILE__, __LINE__, #call, \
           clvox_status_string(st_), (ctx) ? clvox_context_error(ctx) : ""); } \
} while (0)

#define CHECK_STATUS(ctx, call, expected) do { \
    clvox_status st_ = (call); \
    if (st_ == (expected)) { test_passed++; } \
    else { test_failed++; fprintf(stderr, "FAIL %s:%d: %s -> %s (expected %s): %s\n", __FILE__, __LINE__, \
           #call, clvox_status_string(st_), clvox_status_string(expected), (ctx) ? clvox_context_error(ctx) : ""); } \
} while (0)

/* Prints the summary line; returns the exit code. */
int test_report(void);
/* Context on the default device (CLVOX_DEVICE honoured); aborts the test
 * program with a message when none can be created. */
clvox_context *test_context(void);
/* Scratch directory for test outputs (created): $CLVOX_TEST_TMP or build/test-tmp. */
const char *test_tmpdir(void);
/* nx x ny x nz voxels dividing the box [lo, hi] evenly. */
clvox_grid test_grid(const double lo[3], const double hi[3], uint32_t nx, uint32_t ny, uint32_t nz);
/* n voxels along the longest axis of the mesh box, one empty voxel around
 * (clvox_grid_compute; a failure is a failed check). */
clvox_grid test_padded_grid(clvox_context *ctx, const clvox_mesh_report *r, uint32_t n);
/* The library's vertices are relative to the mesh's offset (its first
 * vertex for OFF files): a CPU reference working on them needs the grid's
 * origin moved likewise, which is exactly what the library computes
 * (origin - offset, in double). */
clvox_grid test_reference_grid(const clvox_mesh *m, const clvox_grid *g);
/* CPU seconds this process has used so far (user + system, every thread,
 * PoCL's workers included). Tests bound work by CPU time, never by wall
 * time: another process's load stretches the wall clock, not this one's
 * CPU time, so a bound on it does not turn red on a busy machine. */
double test_cpu_seconds(void);
#endif
