/* SPDX-License-Identifier: Apache-2.0 */
/* The volume formats clvox writes besides EXR, read back (read_volume.c):
 * npy (+ OUT.json), NRRD/NHDR, binvox, and OpenVDB through the plugin.
 * read_exr.c sniffs every file it opens and hands these to a source, whose
 * channels arrive as the same bands as an EXR channel's, so the counting,
 * sums and slice conversion are shared. Private to src/io. */
#ifndef CLVOX_VOLUME_SOURCE_H
#define CLVOX_VOLUME_SOURCE_H

#include "core/internal.h"

/* Sample types of a band: OpenEXR's EXR_PIXEL_UINT, _HALF, _FLOAT values
 * (read_exr.c checks they agree). */
enum { CLVOX__SAMPLE_UINT = 0, CLVOX__SAMPLE_HALF = 1, CLVOX__SAMPLE_FLOAT = 2 };

/* Receives rows [row0, row0+rows) of the volume (row = z*Y + y), X samples
 * each of `type`, native byte order. */
typedef clvox_status (*clvox__band_fn)(void *user, const uint8_t *band, int type, uint64_t row0, uint64_t rows);

typedef struct clvox__vsrc clvox__vsrc;

/* Opens `path` by its first bytes (not its extension). An OpenEXR file:
 * CLVOX_OK with *out = NULL (read_exr.c reads it). Any other format clvox
 * writes: its header into info (zeroed first) and *out. Anything else, or a
 * malformed file: CLVOX_ERR_EXR (CLVOX_ERR_IO when unreadable) with one line. */
clvox_status clvox__vsrc_open(clvox_context *ctx, const char *path, clvox_volume_info *info, clvox__vsrc **out);
/* 1 when the source has `channel`. */
int clvox__vsrc_has(const clvox__vsrc *s, const char *channel);
/* Streams `channel` in increasing z, one slice (Y rows) per call. */
clvox_status clvox__vsrc_read(clvox__vsrc *s, const char *channel, clvox__band_fn fn, void *user);
void clvox__vsrc_close(clvox__vsrc *s); /* NULL-safe */

#endif
