/* SPDX-License-Identifier: Apache-2.0 */
/* libFuzzer target: clvox_mesh_load on a .obj file of arbitrary bytes, with the
 * property checks of fuzz_mesh.h. Seeds: tests/fuzz/seeds_mesh_obj/; inputs that
 * once failed: tests/fuzz/regress_mesh_obj/ (both replayed by test_fuzz_smoke).
 * Build and run: make fuzz-run FUZZ_ONLY=mesh_obj FUZZ_SECONDS=60 */
#include "fuzz_mesh.h"

FUZZ_MESH_TARGET("obj")
