/* SPDX-License-Identifier: Apache-2.0 */
/* libFuzzer target: clvox_mesh_load through Assimp (src/mesh/mesh_assimp.cpp)
 * on arbitrary bytes, with the property checks of fuzz_mesh.h. The first
 * byte picks the extension (mod 3: .glb, .gltf, .3mf), the rest is the
 * file, written under /dev/shm (a .gltf's buffers named by a relative uri
 * are looked for beside it and are not there). Seeds:
 * tests/fuzz/seeds_mesh_assimp/ (tests/fuzz/make_assimp_seeds.py), replayed
 * by test_fuzz_smoke. Build and run:
 *   make fuzz-run FUZZ_ONLY=mesh_assimp FUZZ_SECONDS=300 */
#include "fuzz_mesh.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const char *const ext[3] = {"glb", "gltf", "3mf"};
    if (!size) return 0;
    const char *e = ext[data[0] % 3];
    const char *why = fuzz_mesh_check(e, data + 1, size - 1);
    if (why) {
        fprintf(stderr, "fuzz_mesh (.%s): %s\n", e, why);
        abort();
    }
    return 0;
}
