/* SPDX-License-Identifier: Apache-2.0 */
/* libFuzzer target: the npy reader (src/io/read_volume.c): OUT.npy, its
 * OUT.json sidecar and the other channels' files (fuzz_read.h says how an
 * input becomes files). Build and run: make fuzz-run FUZZ_ONLY=read_npy */
#include "fuzz_read.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const char *const names[] = {"fz.npy", "fz.json", "fz.coverage.npy", "fz.score.npy", "fz.element.npy"};
    static const char *const entries[] = {"fz.npy"};
    return fuzz_read_run(data, size, names, 5, entries, 1);
}
