/* SPDX-License-Identifier: Apache-2.0 */
/* libFuzzer target: clvox's EXR volume reader (clvox_volume_read,
 * clvox_volume_read_slices of every channel clvox writes, and
 * clvox_volume_palette, which parses a palette text from the header) on
 * arbitrary bytes. Every input must give either
 * a volume or a status with a message; never a crash, a hang, an
 * out-of-bounds access or an allocation far beyond what the file describes.
 * Build and run: make fuzz; build/fuzz/fuzz_volume_read -max_total_time=60 tests/fuzz/corpus_exr */
#include "clvox.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static clvox_context *ctx;
static char path[64];

static int count_slice(void *user, uint32_t z, const float *values)
{
    (void)z;
    double *sum = user;
    *sum += values[0];
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (!ctx) {
        clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
        o.host_only = 1;
        if (clvox_context_create(&o, &ctx) != CLVOX_OK) abort();
        snprintf(path, sizeof path, "/dev/shm/clvox-fuzz-%ld.exr", (long)getpid());
    }
    FILE *f = fopen(path, "wb");
    if (!f) abort();
    if (size && fwrite(data, 1, size, f) != size) abort();
    if (fclose(f) != 0) abort();

    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    clvox_status st = clvox_volume_read(ctx, path, &info, NULL, 0);
    if (st != CLVOX_OK && !clvox_context_error(ctx)[0]) abort(); /* every failure says why */
    if (st == CLVOX_OK) {
        uint64_t n = (uint64_t)info.dims[0] * info.dims[1] * info.dims[2];
        if (n <= (1u << 20)) { /* small volumes: read the voxels too */
            uint8_t *occ = malloc((size_t)n);
            if (occ) {
                clvox_volume_read(ctx, path, &info, occ, (size_t)n);
                free(occ);
            }
        }
    }
    double sum = 0;
    static const char *const channels[] = { "coverage", "occupancy", "element", "score" };
    for (size_t i = 0; i < sizeof channels / sizeof channels[0]; i++) {
        st = clvox_volume_read_slices(ctx, path, channels[i], NULL, count_slice, &sum);
        if (st != CLVOX_OK && !clvox_context_error(ctx)[0]) abort();
    }
    clvox_palette *p = NULL;
    st = clvox_volume_palette(ctx, path, &p);
    if ((st == CLVOX_OK) != (p != NULL)) abort(); /* a palette exactly on success */
    if (st != CLVOX_OK && !clvox_context_error(ctx)[0]) abort();
    clvox_palette_destroy(p);
    unlink(path);
    return 0;
}
