/* SPDX-License-Identifier: Apache-2.0 */
/* An independent writer of clvox-layout EXR volumes for the tests: uses
 * OpenEXRCore directly (not clvox's src/io/write_exr.c), any channels and types,
 * scanline or tiled, any compression. X x (Y*Z) pixels; voxel (x,y,z) is
 * pixel (x, y + z*Y). */
#ifndef CLVOX_TEST_EXRGEN_H
#define CLVOX_TEST_EXRGEN_H
#include <OpenEXR/openexr.h>
#include <stddef.h>
#include <stdint.h>

typedef struct exrgen_channel {
    const char *name;
    exr_pixel_type_t type; /* EXR_PIXEL_HALF (data: uint16_t bits), _FLOAT (float), _UINT (uint32_t) */
    const void *data;      /* X*Y*Z samples, x fastest, then y, then z */
} exrgen_channel;

/* Attributes written when `attributes` is 1 (else none: not a clvox volume). */
#define EXRGEN_ORIGIN_X 1.0
#define EXRGEN_ORIGIN_Y 2.0
#define EXRGEN_ORIGIN_Z 3.0
#define EXRGEN_H_X 0.25
#define EXRGEN_H_Y 0.5
#define EXRGEN_H_Z 2.0
#define EXRGEN_METHOD "ray"
#define EXRGEN_VERSION "9.9.9"

/* tile_w == 0: scanline (OpenEXR's lines per chunk for `comp`), else tiles
 * tile_w x tile_h. Returns 1 on success; on failure prints why and removes
 * the file. */
int exrgen_write(const char *path, uint32_t X, uint32_t Y, uint32_t Z, const exrgen_channel *channels,
                 int channel_count, int tile_w, int tile_h, exr_compression_t comp, int attributes);

/* One more header attribute: a string when `string` is set, else an int. */
typedef struct exrgen_extra {
    const char *name;
    const char *string;
    int32_t value;
} exrgen_extra;

/* The clvox attributes, to write them wrong on purpose. layout: clvoxLayout
 * (NULL: not written); extra: extra_count more attributes (e.g. clvoxPalette*). */
typedef struct exrgen_attrs {
    int32_t dims[3];
    double origin[3], voxel_size[3];
    const char *layout;
    const exrgen_extra *extra;
    int extra_count;
} exrgen_attrs;
/* dims X, Y, Z, origin EXRGEN_ORIGIN_*, voxel size EXRGEN_H_*, no layout, no extras. */
exrgen_attrs exrgen_default_attrs(uint32_t X, uint32_t Y, uint32_t Z);
/* exrgen_write with these attributes (NULL: none). */
int exrgen_write_ex(const char *path, uint32_t X, uint32_t Y, uint32_t Z, const exrgen_channel *channels,
                    int channel_count, int tile_w, int tile_h, exr_compression_t comp, const exrgen_attrs *attrs);
/* A header alone (one HALF channel "occupancy", a width x height image),
 * then extra_bytes zero bytes; no chunk table, no chunks: a crafted file. */
int exrgen_write_header(const char *path, int64_t width, int64_t height, int tile_w, int tile_h,
                        exr_compression_t comp, const exrgen_attrs *attrs, size_t extra_bytes);

/* The value of HALF bits, computed with ldexp (independent of clvox's conversion). */
double exrgen_half_value(uint16_t h);
#endif
