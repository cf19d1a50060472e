/* SPDX-License-Identifier: Apache-2.0 */
/* The winding preparation alone (scripts/bench/bench_winding_closed.sh --prep),
 * not a test: loads a mesh, runs clvox__winding_prepare R times (with
 * -DCLVOX_BENCH_BORROW: clvox__winding_prepare_flags with CLVOX__PREP_BORROW,
 * as the cast's speculation does) and prints the median and the minimum of
 * its wall and thread CPU time (user + sys, page faults included).
 *
 *   bench_winding_prep MESH [R]    (R default 9, at most 64) */
#include "core/internal.h"
#include "winding/winding.h"

#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static double thread_cpu(void)
{
    struct timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int cmp_double(const void *pa, const void *pb)
{
    double a = *(const double *)pa, b = *(const double *)pb;
    return (a > b) - (a < b);
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: %s MESH [R]\n", argv[0]);
        return 2;
    }
    int reps = argc > 2 ? atoi(argv[2]) : 9;
    if (reps < 1) reps = 1;
    if (reps > 64) reps = 64;
    clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
    o.host_only = 1;
    clvox_context *ctx = NULL;
    if (clvox_context_create(&o, &ctx) != CLVOX_OK) {
        fprintf(stderr, "no context\n");
        return 1;
    }
    clvox_mesh *m = NULL;
    if (clvox_mesh_load(ctx, argv[1], &m) != CLVOX_OK) {
        fprintf(stderr, "%s\n", clvox_context_error(ctx));
        clvox_context_destroy(ctx);
        return 1;
    }
    double wall[64], cpu[64];
    clvox_winding_report r = {0};
    for (int i = 0; i < reps; i++) {
        clvox__winding_mesh w;
        double t0 = clvox__now(), c0 = thread_cpu();
#ifdef CLVOX_BENCH_BORROW
        clvox_status st = clvox__winding_prepare_flags(ctx, m, 0, CLVOX__PREP_BORROW, &w);
#else
        clvox_status st = clvox__winding_prepare(ctx, m, 0, &w);
#endif
        wall[i] = clvox__now() - t0;
        cpu[i] = thread_cpu() - c0;
        r = w.report;
        clvox__winding_mesh_free(&w);
        if (st != CLVOX_OK) {
            fprintf(stderr, "%s\n", clvox_context_error(ctx));
            return 1;
        }
    }
    qsort(wall, (size_t)reps, sizeof *wall, cmp_double);
    qsort(cpu, (size_t)reps, sizeof *cpu, cmp_double);
    printf("%s: %llu patches, %llu flipped, %llu caps; wall median %.4f min %.4f s, CPU median %.4f min %.4f s\n",
           argv[1], (unsigned long long)r.components, (unsigned long long)r.flipped_triangles,
           (unsigned long long)r.cap_triangles, wall[reps / 2], wall[0], cpu[reps / 2], cpu[0]);
    clvox_mesh_destroy(m);
    clvox_context_destroy(ctx);
    return 0;
}
