/* SPDX-License-Identifier: Apache-2.0 */
/* libFuzzer target: clvox_mesh_load on a .off file of arbitrary bytes, with the
 * property checks of fuzz_mesh.h. Seeds: tests/fuzz/seeds_mesh_off/; inputs that
 * once failed: tests/fuzz/regress_mesh_off/ (both replayed by test_fuzz_smoke).
 * Build and run: make fuzz-run FUZZ_ONLY=mesh_off FUZZ_SECONDS=60 */
#include "fuzz_mesh.h"

FUZZ_MESH_TARGET("off")
