/* SPDX-License-Identifier: Apache-2.0 */
/* libFuzzer target: the binvox reader (src/io/read_volume.c; fuzz_read.h).
 * Build and run: make fuzz-run FUZZ_ONLY=read_binvox */
#include "fuzz_read.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const char *const names[] = {"fz.binvox"};
    return fuzz_read_run(data, size, names, 1, names, 1);
}
