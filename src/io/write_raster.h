/* SPDX-License-Identifier: Apache-2.0 */
/* The raster file engine of the npy and NRRD writers (write_raster.c). Not installed. */
#ifndef CLVOX_WRITE_RASTER_H
#define CLVOX_WRITE_RASTER_H
#include "core/internal.h"

typedef struct clvox__raster clvox__raster;

/* One member of a set as its marker records it: the file's size and the
 * CRC-32 (zlib's) of all its bytes. */
typedef struct clvox__raster_member {
    uint32_t channel;
    const char *path;
    uint64_t bytes;
    uint32_t crc32;
} clvox__raster_member;

typedef struct clvox__raster_spec {
    int gzip; /* 1: the data is one gzip stream */
    clvox__dtype (*dtype)(const clvox__fmt_info *info, uint32_t channel);
    /* The header of `channel`'s file (malloc'ed text, *len bytes). set_line:
     * NULL, or (main file of a set that has no sidecar) a line the header
     * holds verbatim just before its last byte, filled in at the end with the
     * other members' identities (clvox__raster_set_line). */
    clvox_status (*header)(clvox_context *ctx, const clvox__fmt_info *info, uint32_t channel, clvox__dtype t,
                           const char *file, void *user, const char *set_line, char **out, size_t *len);
    /* NULL, or the extension of a sidecar (".json"), the set's marker: its text
     * is made at the end from every member's identity (malloc'ed). */
    const char *sidecar_ext;
    clvox_status (*sidecar)(clvox_context *ctx, const clvox__fmt_info *info, const clvox__raster_member *m,
                            size_t n, void *user, char **text);
} clvox__raster_spec;

/* The set line of a main file without sidecar: "clvox_set:=" then, for each
 * other member, " <channel>:<bytes, 20 digits>:<crc32, 8 hex digits>", then
 * "\n" (fixed width: written at open with zeros, overwritten at the end).
 * Returns its length; writes at most size bytes (NUL-terminated). */
size_t clvox__raster_set_line(char *buf, size_t size, const clvox__raster_member *m, size_t n, uint32_t main_channel);

clvox_status clvox__raster_open(clvox_context *ctx, const clvox__fmt_info *info, const clvox__raster_spec *spec,
                                void *user, clvox__raster **out);
clvox_status clvox__raster_write(clvox__raster *r, const clvox__fmt_slab *s);
/* Names every file, the set's marker last (clvox__outfile_finish_set); frees r.
 * On failure nothing new is left and the previous set is as it was. */
clvox_status clvox__raster_finish(clvox__raster *r, uint64_t *bytes);
void clvox__raster_abort(clvox__raster *r); /* NULL-safe */
#endif
