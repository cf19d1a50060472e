/* SPDX-License-Identifier: Apache-2.0 */
/* libFuzzer target: clvox_mesh_load on a .ply file of arbitrary bytes, with the
 * property checks of fuzz_mesh.h. Seeds: tests/fuzz/seeds_mesh_ply/; inputs that
 * once failed: tests/fuzz/regress_mesh_ply/ (both replayed by test_fuzz_smoke).
 * Build and run: make fuzz-run FUZZ_ONLY=mesh_ply FUZZ_SECONDS=60 */
#include "fuzz_mesh.h"

FUZZ_MESH_TARGET("ply")
