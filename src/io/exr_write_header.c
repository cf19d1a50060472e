/* SPDX-License-Identifier: Apache-2.0 */
/* The EXR writer's header: the part, tiles and channels, the clvox*
 * attributes (clvoxDims ... clvoxLayout, the palette of a palette run),
 * checked before any file is made (write_exr.c describes the layout). */
#include "io/exr_writer.h"

#include <stdio.h>
#include <string.h>

exr_compression_t clvox__exrw_compression(clvox_compression c)
{
    switch (c) {
    case CLVOX_COMPRESSION_NONE: return EXR_COMPRESSION_NONE;
    case CLVOX_COMPRESSION_ZIPS: return EXR_COMPRESSION_ZIPS;
    case CLVOX_COMPRESSION_ZIP: return EXR_COMPRESSION_ZIP;
    case CLVOX_COMPRESSION_PIZ: return EXR_COMPRESSION_PIZ;
    case CLVOX_COMPRESSION_RLE:
    case CLVOX_COMPRESSION_DEFAULT:
    default: return EXR_COMPRESSION_RLE;
    }
}

/* Largest clvoxPaletteSource: an EXR attribute's size is an int32, and
 * OpenEXRCore refuses strings from INT32_MAX bytes on (a user palette file is
 * at most 4 MiB, docs/design.md "Palette files": far below). */
#define CLVOX__EXR_MAX_STRING ((size_t)INT32_MAX - 1)

/* The header the writer would record for meta, checked before any file is
 * made: refused here rather than written broken. */
clvox_status clvox__exrw_check_meta(clvox_context *ctx, const char *path, const clvox__exr_meta *meta)
{
    if (!meta || !meta->palette) return CLVOX_OK;
    const clvox_palette *p = meta->palette;
    size_t count = clvox_palette_count(p);
    if (count == 0 || count > 65536u)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT,
                           "cannot write '%s': palette \"%s\" has %zu elements (the element channel holds indices "
                           "0..65535)",
                           path, clvox_palette_name(p), count);
    const char *src = clvox_palette_source(p);
    size_t len = src ? strlen(src) : 0;
    if (len > CLVOX__EXR_MAX_STRING)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT,
                           "cannot write '%s': the text of palette \"%s\" is %zu bytes, more than an EXR string "
                           "attribute (clvoxPaletteSource) can hold (%zu)",
                           path, clvox_palette_name(p), len, CLVOX__EXR_MAX_STRING);
    if (meta->metric && strlen(meta->metric) >= sizeof ((clvox_volume_info *)0)->metric)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "cannot write '%s': metric name '%.40s' is too long",
                           path, meta->metric);
    /* what the reader accepts (read_exr.c read_palette_attrs): no control characters */
    const char *texts[2] = { clvox_palette_name(p), meta->metric ? meta->metric : "" };
    for (int k = 0; k < 2; k++)
        for (const char *c = texts[k]; *c; c++)
            if ((unsigned char)*c < 0x20 || *c == 0x7F)
                return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT,
                                   "cannot write '%s': the palette's %s holds a control character", path,
                                   k ? "metric name" : "name");
    return CLVOX_OK;
}

clvox_status clvox__exrw_define_header(clvox__exr_writer *w, const clvox_grid *grid, const clvox__exr_meta *meta,
                                  clvox_compression compression)
{
    exr_result_t rv;
    int part = 0;
    exr_compression_t ec = clvox__exrw_compression(compression);
    char layout[160];

#define EXR_TRY(call, what) do { rv = (call); if (rv != EXR_ERR_SUCCESS) return clvox__exrw_fail(w, rv, what); } while (0)
    EXR_TRY(exr_add_part(w->exr, NULL, EXR_STORAGE_TILED, &part), "adding the part of");
    EXR_TRY(exr_initialize_required_attr_simple(w->exr, part, (int32_t)w->dims[0], w->height, ec),
            "setting the header of");
    EXR_TRY(exr_set_tile_descriptor(w->exr, part, w->dims[0], (uint32_t)w->tile_h, EXR_TILE_ONE_LEVEL,
                                    EXR_TILE_ROUND_DOWN),
            "setting the tiles of");
    for (size_t t = 0; t < w->nch; t++) {
        rv = exr_add_channel(w->exr, part, w->ch[t]->name, w->ch[t]->type, EXR_PERCEPTUALLY_LINEAR, 1, 1);
        if (rv != EXR_ERR_SUCCESS) return clvox__exrw_fail(w, rv, "adding a channel to");
    }
    if (ec == EXR_COMPRESSION_ZIP || ec == EXR_COMPRESSION_ZIPS)
        EXR_TRY(exr_set_zip_compression_level(w->exr, part, CLVOX__EXR_ZIP_LEVEL), "setting the zip level of");

    exr_attr_v3i_t dims = { .arr = { (int32_t)w->dims[0], (int32_t)w->dims[1], (int32_t)w->dims[2] } };
    exr_attr_v3d_t origin = { .arr = { grid->origin[0], grid->origin[1], grid->origin[2] } };
    exr_attr_v3d_t h = { .arr = { grid->voxel_size[0], grid->voxel_size[1], grid->voxel_size[2] } };
    if (w->tile_h == (int32_t)w->dims[1])
        snprintf(layout, sizeof layout, "tile-per-slice: pixel (x, y + z*Y), tile X x Y = slice z");
    else
        snprintf(layout, sizeof layout, "row-chunks: pixel (x, y + z*Y), tile X x %d rows", (int)w->tile_h);
    EXR_TRY(exr_attr_set_v3i(w->exr, part, "clvoxDims", &dims), "setting clvoxDims in");
    EXR_TRY(exr_attr_set_v3d(w->exr, part, "clvoxOrigin", &origin), "setting clvoxOrigin in");
    EXR_TRY(exr_attr_set_v3d(w->exr, part, "clvoxVoxelSize", &h), "setting clvoxVoxelSize in");
    EXR_TRY(exr_attr_set_string(w->exr, part, "clvoxMethod", meta && meta->method ? meta->method : ""),
            "setting clvoxMethod in");
    EXR_TRY(exr_attr_set_string(w->exr, part, "clvoxParameters",
                                meta && meta->parameters ? meta->parameters : ""),
            "setting clvoxParameters in");
    EXR_TRY(exr_attr_set_string(w->exr, part, "clvoxVersion", CLVOX_VERSION_STRING), "setting clvoxVersion in");
    EXR_TRY(exr_attr_set_string(w->exr, part, "clvoxLayout", layout), "setting clvoxLayout in");
    if (meta && meta->palette) { /* sizes checked by clvox__exrw_check_meta */
        const clvox_palette *p = meta->palette;
        char hash[24];
        snprintf(hash, sizeof hash, "%016llx", (unsigned long long)clvox_palette_hash(p));
        EXR_TRY(exr_attr_set_string(w->exr, part, "clvoxPalette", clvox_palette_name(p)), "setting clvoxPalette in");
        EXR_TRY(exr_attr_set_int(w->exr, part, "clvoxPaletteCount", (int32_t)clvox_palette_count(p)),
                "setting clvoxPaletteCount in");
        EXR_TRY(exr_attr_set_string(w->exr, part, "clvoxPaletteHash", hash), "setting clvoxPaletteHash in");
        if (clvox_palette_source(p))
            EXR_TRY(exr_attr_set_string(w->exr, part, "clvoxPaletteSource", clvox_palette_source(p)),
                    "setting clvoxPaletteSource in");
        EXR_TRY(exr_attr_set_string(w->exr, part, "clvoxMetric", meta->metric ? meta->metric : ""),
                "setting clvoxMetric in");
    }
    EXR_TRY(exr_write_header(w->exr), "writing the header of");
#undef EXR_TRY
    return CLVOX_OK;
}
