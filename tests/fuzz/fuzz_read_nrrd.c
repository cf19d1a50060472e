/* SPDX-License-Identifier: Apache-2.0 */
/* libFuzzer target: the NRRD reader (src/io/read_volume.c): OUT.nrrd and
 * the other channels' files of its set, and a detached OUT.nhdr with its
 * data file (fuzz_read.h says how an input becomes files). Build and run:
 * make fuzz-run FUZZ_ONLY=read_nrrd */
#include "fuzz_read.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const char *const names[] = {"fz.nrrd", "fz.coverage.nrrd", "fz.score.nrrd", "fz.element.nrrd",
                                        "fz.nhdr", "fz.raw"};
    static const char *const entries[] = {"fz.nrrd", "fz.nhdr"};
    return fuzz_read_run(data, size, names, 6, entries, 2);
}
