/* SPDX-License-Identifier: Apache-2.0 */
/* Writes the occupancy of a clvox volume as raw bytes (0/1, x fastest, then
 * y, then z) for the benchmarks' comparison with other voxelizers
 * (scripts/bench/bench_surface_trimesh.py reads it with numpy).
 *
 *   make bench-tools
 *   build/release/bench/volume_raw IN.exr OUT.raw
 *
 * Prints "X Y Z filled"; exit 0, or 1 with a message on error. */
#include "clvox.h"

#include <stdio.h>
#include <stdlib.h>

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: volume_raw IN.exr OUT.raw\n");
        return 1;
    }
    clvox_context *ctx = NULL;
    clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
    co.host_only = 1;
    clvox_status st = clvox_context_create(&co, &ctx);
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    uint8_t *v = NULL;
    size_t n = 0;
    if (st == CLVOX_OK) st = clvox_volume_read(ctx, argv[1], &info, NULL, 0);
    if (st == CLVOX_OK) {
        n = (size_t)info.dims[0] * info.dims[1] * info.dims[2];
        v = malloc(n ? n : 1);
        if (!v) st = CLVOX_ERR_OUT_OF_MEMORY;
    }
    if (st == CLVOX_OK) st = clvox_volume_read(ctx, argv[1], &info, v, n);
    if (st != CLVOX_OK) {
        fprintf(stderr, "volume_raw: %s: %s\n", clvox_status_string(st), ctx ? clvox_context_error(ctx) : "");
        free(v);
        clvox_context_destroy(ctx);
        return 1;
    }
    FILE *f = fopen(argv[2], "wb");
    int ok = f && fwrite(v, 1, n, f) == n;
    if (f && fclose(f) != 0) ok = 0;
    if (!ok) fprintf(stderr, "volume_raw: cannot write %s\n", argv[2]);
    else printf("%u %u %u %llu\n", info.dims[0], info.dims[1], info.dims[2], (unsigned long long)info.filled_voxels);
    free(v);
    clvox_context_destroy(ctx);
    return ok ? 0 : 1;
}
