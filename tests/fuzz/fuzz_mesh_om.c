/* SPDX-License-Identifier: Apache-2.0 */
/* libFuzzer target: clvox_mesh_load on a .om file of arbitrary bytes, with the
 * property checks of fuzz_mesh.h. Seeds: tests/fuzz/seeds_mesh_om/; inputs that
 * once failed: tests/fuzz/regress_mesh_om/ (both replayed by test_fuzz_smoke).
 * Build and run: make fuzz-run FUZZ_ONLY=mesh_om FUZZ_SECONDS=60 */
#include "fuzz_mesh.h"

FUZZ_MESH_TARGET("om")
