/* SPDX-License-Identifier: Apache-2.0 */
/* NRRD (NRRD0004) writer: one file per channel (OUT.nrrd the main channel,
 * OUT.<channel>.nrrd the others, as for npy), attached header, data raw or
 * one gzip stream over all slabs, x fastest. occupancy uint8 0/1, coverage
 * and score float (exactly count/samples), element ushort. The header
 * places the volume in the mesh's coordinates: "space: left-posterior-
 * superior" (so ITK/SimpleITK and 3D Slicer take the mesh coordinates as
 * given, as Slicer loads meshes in LPS), space directions diag(h), and space
 * origin = the centre of voxel (0,0,0) = clvox origin + h/2 (NRRD positions
 * are sample centres; clvox's origin is the corner of the first voxel).
 * With two or more channels, OUT.nrrd is the set's marker, named last: its
 * header's last line "clvox_set:= coverage:<bytes>:<crc32> ..." records the
 * size and CRC-32 of each other channel's file (output_set.c checks them). */
#include "write_raster.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static clvox__dtype nrrd_dtype(const clvox__fmt_info *info, uint32_t channel)
{
    (void)info;
    switch (channel) {
    case CLVOX_CHANNEL_OCCUPANCY: return CLVOX__U8;
    case CLVOX_CHANNEL_ELEMENT: return CLVOX__U16;
    default: return CLVOX__F32;
    }
}

static int nrrd_gzip(clvox_compression c) { return c != CLVOX_COMPRESSION_NONE; }

static clvox_status nrrd_header(clvox_context *ctx, const clvox__fmt_info *info, uint32_t channel, clvox__dtype t,
                                const char *file, void *user, const char *set_line, char **out, size_t *len)
{
    (void)file, (void)user;
    const clvox_grid *g = info->grid;
    const double *o = g->origin, *h = g->voxel_size;
    size_t size = 2048;
    char *s = malloc(size);
    if (!s) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    int n = snprintf(s, size,
                     "NRRD0004\n"
                     "# clvox %s: channel %s; voxel (i,j,k) centre = space origin + (i,j,k) * h\n"
                     "type: %s\n"
                     "dimension: 3\n"
                     "space: left-posterior-superior\n"
                     "sizes: %u %u %u\n"
                     "space directions: (%.17g,0,0) (0,%.17g,0) (0,0,%.17g)\n"
                     "kinds: domain domain domain\n"
                     "endian: little\n"
                     "encoding: %s\n"
                     "space origin: (%.17g,%.17g,%.17g)\n"
                     "clvox_version:=%s\n"
                     "clvox_channel:=%s\n"
                     "clvox_origin_corner:=%.17g %.17g %.17g\n"
                     "clvox_method:=%s\n"
                     "%s"
                     "\n",
                     CLVOX_VERSION_STRING, clvox__channel_name(channel),
                     t == CLVOX__U8 ? "uint8" : t == CLVOX__U16 ? "uint16" : "float", g->dims[0], g->dims[1],
                     g->dims[2], h[0], h[1], h[2], nrrd_gzip(info->compression) ? "gzip" : "raw",
                     o[0] + 0.5 * h[0], o[1] + 0.5 * h[1], o[2] + 0.5 * h[2], CLVOX_VERSION_STRING,
                     clvox__channel_name(channel), o[0], o[1], o[2], info->method ? info->method : "",
                     set_line ? set_line : "");
    if (n < 0 || (size_t)n >= size || strchr(info->method ? info->method : "", '\n')) {
        free(s);
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "cannot make the NRRD header of '%s'", info->path);
    }
    *out = s;
    *len = (size_t)n;
    return CLVOX_OK;
}

static const clvox__raster_spec nrrd_raw = {0, nrrd_dtype, nrrd_header, NULL, NULL};
static const clvox__raster_spec nrrd_gz = {1, nrrd_dtype, nrrd_header, NULL, NULL};

static clvox_status nrrd_open(clvox_context *ctx, const clvox__fmt_info *info, void **state)
{
    return clvox__raster_open(ctx, info, nrrd_gzip(info->compression) ? &nrrd_gz : &nrrd_raw, NULL,
                              (clvox__raster **)state);
}
static clvox_status nrrd_write(void *state, const clvox__fmt_slab *s) { return clvox__raster_write(state, s); }
static clvox_status nrrd_finish(void *state, uint64_t *bytes) { return clvox__raster_finish(state, bytes); }
static void nrrd_abort(void *state) { clvox__raster_abort(state); }

const clvox__fmt_ops clvox__fmt_nrrd = {
    "NRRD", CLVOX_CHANNEL_OCCUPANCY | CLVOX_CHANNEL_COVERAGE | CLVOX_CHANNEL_ELEMENT | CLVOX_CHANNEL_SCORE, 1, 0,
    nrrd_open, nrrd_write, nrrd_finish, nrrd_abort};
