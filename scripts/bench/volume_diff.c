/* SPDX-License-Identifier: Apache-2.0 */
/* Counts the voxels where one channel of two clvox volumes differs (for the
 * benchmarks: what a faster setting changes). Holds A's channel in memory
 * (4 bytes per voxel: 67 MB at 256^3) and streams B against it.
 *
 *   make bench-tools
 *   build/release/bench/volume_diff A.exr B.exr element
 *
 * Prints "<differing> of <voxels>"; exit 0, or 1 with a message on error. */
#include "clvox.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct dense {
    float *v;
    size_t slice;
    uint64_t differ;
} dense;

static int keep(void *user, uint32_t z, const float *v)
{
    dense *d = user;
    memcpy(d->v + (size_t)z * d->slice, v, d->slice * sizeof *v);
    return 0;
}

static int compare(void *user, uint32_t z, const float *v)
{
    dense *d = user;
    const float *a = d->v + (size_t)z * d->slice;
    for (size_t i = 0; i < d->slice; i++) d->differ += v[i] != a[i];
    return 0;
}

int main(int argc, char **argv)
{
    if (argc != 4) {
        fprintf(stderr, "usage: volume_diff A.exr B.exr CHANNEL\n");
        return 1;
    }
    clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
    co.host_only = 1;
    clvox_context *ctx = NULL;
    clvox_volume_info ia = CLVOX_VOLUME_INFO_INIT, ib = CLVOX_VOLUME_INFO_INIT;
    dense d = {NULL, 0, 0};
    clvox_status st = clvox_context_create(&co, &ctx);
    if (st == CLVOX_OK) st = clvox_volume_read(ctx, argv[1], &ia, NULL, 0);
    if (st == CLVOX_OK) st = clvox_volume_read(ctx, argv[2], &ib, NULL, 0);
    if (st == CLVOX_OK && memcmp(ia.dims, ib.dims, sizeof ia.dims) != 0) {
        fprintf(stderr, "volume_diff: the grids differ\n");
        clvox_context_destroy(ctx);
        return 1;
    }
    uint64_t n = 0;
    if (st == CLVOX_OK) {
        d.slice = (size_t)ia.dims[0] * ia.dims[1];
        n = (uint64_t)d.slice * ia.dims[2];
        d.v = malloc(n * sizeof *d.v);
        if (!d.v) {
            fprintf(stderr, "volume_diff: out of memory\n");
            clvox_context_destroy(ctx);
            return 1;
        }
        st = clvox_volume_read_slices(ctx, argv[1], argv[3], NULL, keep, &d);
    }
    if (st == CLVOX_OK) st = clvox_volume_read_slices(ctx, argv[2], argv[3], NULL, compare, &d);
    if (st != CLVOX_OK) {
        fprintf(stderr, "volume_diff: %s\n", clvox_context_error(ctx));
        free(d.v);
        clvox_context_destroy(ctx);
        return 1;
    }
    printf("%llu of %llu\n", (unsigned long long)d.differ, (unsigned long long)n);
    free(d.v);
    clvox_context_destroy(ctx);
    return 0;
}
