/* SPDX-License-Identifier: Apache-2.0 */
/* libFuzzer target: the Assimp shim (src/mesh/mesh_assimp.cpp) in this
 * process, on arbitrary bytes, so that libFuzzer sees Assimp's coverage and
 * its crashes (clvox_mesh_load runs the shim in a child process, where a
 * crash is contained: mesh_isolate.c). The first byte picks the extension
 * (mod 4: .glb, .gltf, .3mf, .fbx), the rest is the file, read from memory only
 * (a .gltf's external buffers are not there). Checks on success: at least
 * one triangle, a source per triangle below the scene's mesh count, every
 * index below the vertex count or UINT32_MAX (an out-of-range index, left
 * for mesh_build.c to report), placements >= 1 when there are triangles; on failure: a non-empty
 * one-line message, no out-of-memory (inputs are small: memory bounded by
 * the file size). Assimp aborts on some inputs (its assertions are on in
 * Debian's build): run with -fork=1 -ignore_crashes=1 to go on past them.
 * Inputs on which Debian's Assimp 5.2.5 itself fails (a 3MF assertion's
 * abort, GLB heap overflows and a NULL dereference, 2-4 GB mallocs from small
 * GLB files, an ASCII FBX nested deep enough to overflow the stack; its 3MF
 * reader also leaks ~100 bytes on some bad inputs: run with
 * ASAN_OPTIONS=detect_leaks=0): tests/fuzz/findings_mesh_assimp/, the
 * first byte picking the extension as here (test_assimp loads them through
 * clvox_mesh_load: contained in the child). Seeds: tests/fuzz/seeds_mesh_assimp/ (tests/fuzz/make_assimp_seeds.py),
 * replayed by test_fuzz_smoke. Build and run:
 *   make fuzz FUZZ_ONLY=mesh_assimp
 *   ASAN_OPTIONS=detect_leaks=0 build/fuzz/fuzz_mesh_assimp -fork=1 -ignore_crashes=1 -max_total_time=300 \
 *       build/fuzz/corpus_mesh_assimp tests/fuzz/seeds_mesh_assimp */
#include "core/internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const char *const exts[4] = {"glb", "gltf", "3mf", "fbx"};
    if (!size) return 0;
    const char *ext = exts[data[0] % 4];
    clvox__raw_mesh raw;
    char err[512];
    int rc = clvox__assimp_read(NULL, ext, data + 1, size - 1, &raw, err, sizeof err);
    const char *why = NULL;
    if (rc == 0) {
        /* no triangles (a scene of lines only) is fine: mesh_build.c says "no triangles" */
        if (!raw.xyz || !raw.face_indices || !raw.face_source || raw.face_sizes) why = "success without arrays";
        for (size_t i = 0; !why && i < 3 * raw.face_count; i++)
            if (raw.face_indices[i] >= raw.vertex_count && raw.face_indices[i] != UINT32_MAX) why = "index range";
        for (size_t f = 0; !why && f < raw.face_count; f++)
            if (raw.face_source[f] >= raw.source.meshes) why = "source mesh out of range";
        /* no placement only with no triangle (a scene of lines, of no meshes:
         * fuzzing found such GLB, glTF and FBX files at once) */
        if (!why && ((raw.source.placements < 1 && raw.face_count > 0) || strcmp(raw.source.reader, "assimp")))
            why = "source info";
        clvox__raw_mesh_free(&raw);
    } else {
        if (!err[0] || strchr(err, '\n')) why = "no one-line message";
        else if (rc == -2) why = "out of memory on a small input";
        if (raw.xyz || raw.face_indices || raw.face_source) why = "a result left on failure";
    }
    if (why) {
        fprintf(stderr, "fuzz_mesh_assimp (.%s): %s (%s)\n", ext, why, err);
        abort();
    }
    return 0;
}
