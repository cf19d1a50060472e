/* SPDX-License-Identifier: Apache-2.0 */
/* libFuzzer target: the kernel program cache's file check
 * (clvox__program_cache_parse, src/core/program_cache.c) on arbitrary bytes, for
 * the identity "fuzz identity\n". An accepted file must be exactly magic,
 * length, that identity, length, a non-empty binary and the SHA-256 of all
 * that (clvox__sha256, checked against FIPS 180-4's vectors in
 * test_program_cache), with the binary inside the input; never a crash, an
 * out-of-bounds read or a wrong acceptance.
 * Build and run: make fuzz-run FUZZ_SECONDS=60 FUZZ_ONLY=program_cache */
#include "core/internal.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const char identity[] = "fuzz identity\n";
    static const char magic[] = "clvox program binary 2\n";
    /* a private copy, exactly `size` bytes: reads past it are caught */
    uint8_t *copy = malloc(size ? size : 1);
    if (!copy) return 0;
    if (size) memcpy(copy, data, size);
    size_t off = 0, len = 0;
    if (clvox__program_cache_parse(copy, size, identity, &off, &len)) {
        const size_t m = sizeof magic - 1, il = sizeof identity - 1;
        if (off != m + 8 + il + 8 || len == 0 || off + len + 32 != size) abort();
        if (memcmp(copy, magic, m) != 0 || memcmp(copy + m + 8, identity, il) != 0) abort();
        uint64_t l = 0;
        for (int i = 0; i < 8; i++) l |= (uint64_t)copy[m + 8 + il + i] << (8 * i);
        unsigned char sum[32];
        clvox__sha256(copy, size - 32, sum);
        if (l != len || memcmp(sum, copy + size - 32, 32) != 0) abort();
    }
    free(copy);
    return 0;
}
