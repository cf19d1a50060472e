/* SPDX-License-Identifier: Apache-2.0 */
/* The EXR reader's state, shared by its files: read_exr.c (the API, the
 * sample conversions and the band consumers; how a volume is read is
 * described there), exr_read_header.c (opening a file, its header and
 * attributes) and exr_read_decode.c (decoding a channel chunk by chunk).
 * Private to those three. */
#ifndef CLVOX_EXR_READER_H
#define CLVOX_EXR_READER_H

#include "core/internal.h"

#include <OpenEXR/openexr.h>

typedef struct reader {
    clvox_context *ctx;
    const char *path;
    int fd;             /* the file, opened once (read_fn reads through it) */
    uint64_t file_size;
    exr_context_t exr;
    char msg[512]; /* last OpenEXRCore message */
    const exr_attr_chlist_t *chl;
    int all_full;  /* no channel is subsampled */
    /* the channel being read (select_channel) */
    const char *ch_name;
    int ch_type;            /* EXR_PIXEL_* */
    uint32_t ch_bytes;      /* 2 or 4 */
    /* fast path (NONE, RLE): raw chunk layout, see fast_chunk */
    int fast;
    exr_compression_t compression;
    uint32_t pixel_bytes, ch_offset; /* per pixel: all channels, channels before the selected one */
    uint8_t *packed, *tmp, *raw;
    size_t packed_size, tmp_size, raw_size;
    int has_palette_hash, has_palette_count; /* the header has clvoxPaletteHash, clvoxPaletteCount */
} reader;

/* Receives rows [row0, row0+rows) of the image, X samples each of `type`. */
typedef clvox_status (*band_fn)(void *user, const uint8_t *band, int type, uint64_t row0, uint64_t rows);

/* exr_read_header.c */
clvox_status clvox__exrr_fail(reader *r, exr_result_t rv, const char *what);
/* Opens `path` and reads its header into info (zeroed first). clvox__exrr_close
 * afterwards in every case. */
clvox_status clvox__exrr_open(reader *r, clvox_context *ctx, const char *path, clvox_volume_info *info);
void clvox__exrr_close(reader *r);
const exr_attr_chlist_entry_t *clvox__exrr_find_channel(const reader *r, const char *name);

/* exr_read_decode.c: decodes channel `e` one row of chunks at a time, in
 * increasing y, and hands each band to `consume`. */
clvox_status clvox__exrr_read_channel(reader *r, const clvox_volume_info *info, const exr_attr_chlist_entry_t *e,
                                      band_fn consume, void *user);

#endif /* CLVOX_EXR_READER_H */
