/* The raster file engine of the npy and NRRD writers (write_raster.c). Not installed. */
#ifndef CLVOX_WRITE_RASTER_H
#define CLVOX_WRITE_RASTER_H
#include "internal.h"

typedef struct clvox__raster clvox__raster;

typedef struct clvox__raster_spec {
    int gzip; /* 1: the data is one gzip stream */
    clvox__dtype (*dtype)(const clvox__fmt_info *info, uint32_t channel);
    /* The header of `channel`'s file (malloc'ed text, *len bytes). */
    clvox_status (*header)(clvox_context *ctx, const clvox__fmt_info *info, uint32_t channel, clvox__dtype t,
                           const char *file, void *user, char **out, size_t *len);
    /* NULL, or a sidecar file written and named with the rest (both malloc'ed). */
    clvox_status (*sidecar)(clvox_context *ctx, const clvox__fmt_info *info, void *user, char **path, char **text);
} clvox__raster_spec;

clvox_status clvox__raster_open(clvox_context *ctx, const clvox__fmt_info *info, const clvox__raster_spec *spec,
                                void *user, clvox__raster **out);
clvox_status clvox__raster_write(clvox__raster *r, const clvox__fmt_slab *s);
/* Names every file; frees r (also on failure, leaving nothing). */
clvox_status clvox__raster_finish(clvox__raster *r, uint64_t *bytes);
void clvox__raster_abort(clvox__raster *r); /* NULL-safe */
#endif
