/* SPDX-License-Identifier: Apache-2.0 */
/* Grids of other volumes, for `clvox --like` (grid_like.c). Library-internal
 * (not installed), shared with the CLI and the fuzz target: no OpenCL types. */
#ifndef CLVOX_GRID_LIKE_H
#define CLVOX_GRID_LIKE_H

#include <stddef.h>

#include "clvox.h"

/* The grid of a NRRD header (.nrrd or .nhdr): `data` holds the file's first
 * `len` bytes (not NUL-terminated; the header ends at the first blank line,
 * or at the end of `data` when it names a "data file"). Only 3-D scalar,
 * axis-aligned grids with positive steps; the clvox origin is "space origin"
 * minus h/2 (or clvox_origin_corner:= when it agrees). *note gets "" or one
 * line on what was assumed (a space other than LPS). Errors: CLVOX_ERR_GRID,
 * one line "NAME: why". */
clvox_status clvox__grid_from_nrrd(clvox_context *ctx, const char *name, const char *data, size_t len,
                                   clvox_grid *out, char *note, size_t note_size);
/* The grid of the JSON sidecar clvox writes next to a .npy ("format": "npy",
 * dims, origin, voxel_size; shape checked when present). Same errors. */
clvox_status clvox__grid_from_npy_json(clvox_context *ctx, const char *name, const char *data, size_t len,
                                       clvox_grid *out);

#endif
