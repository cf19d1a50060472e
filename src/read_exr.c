/*
 * Reading clvox volumes back (clvox_volume_read).
 *
 * Accepts any single-resolution EXR image X wide and Y*Z tall that carries
 * the clvox attributes (see the layout comment in write_exr.c): tiled (any
 * tile size, level 0) or scanline, any compression. It decodes one row of
 * chunks at a time into a band buffer, so memory is bounded by one chunk row,
 * whatever Z is. A voxel is filled when its "occupancy" sample is > 0.5.
 */
#include "internal.h"

#include <OpenEXR/openexr.h>

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

typedef struct reader {
    clvox_context *ctx;
    const char *path;
    exr_context_t exr;
    char msg[512]; /* last OpenEXRCore message */
} reader;

static void reader_error_handler(exr_const_context_t ectx, exr_result_t code, const char *msg)
{
    void *ud = NULL;
    if (!ectx || exr_get_user_data(ectx, &ud) != EXR_ERR_SUCCESS || !ud) return;
    reader *r = ud;
    snprintf(r->msg, sizeof r->msg, "%s", msg ? msg : exr_get_default_error_message(code));
}

static clvox_status exr_fail(reader *r, exr_result_t rv, const char *what)
{
    return clvox__fail(r->ctx, CLVOX_ERR_EXR, "OpenEXR: %s '%s': %s", what, r->path,
                       r->msg[0] ? r->msg : exr_get_default_error_message(rv));
}

static void copy_str(char *dst, size_t size, const char *src, int32_t len)
{
    size_t n = len < 0 ? 0 : (size_t)len;
    if (n >= size) n = size - 1;
    if (n) memcpy(dst, src, n);
    dst[n] = '\0';
}

static const char *compression_name(exr_compression_t c)
{
    static const char *const names[] = { "none", "rle", "zips", "zip", "piz", "pxr24", "b44", "b44a", "dwaa", "dwab" };
    return (unsigned)c < sizeof names / sizeof names[0] ? names[c] : "unknown";
}

static clvox_status get_string(reader *r, const char *name, char *dst, size_t size)
{
    int32_t len = 0;
    const char *s = NULL;
    exr_result_t rv = exr_attr_get_string(r->exr, 0, name, &len, &s);
    if (rv != EXR_ERR_SUCCESS || !s)
        return clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s' is not a clvox volume: string attribute %s is missing",
                           r->path, name);
    copy_str(dst, size, s, len);
    return CLVOX_OK;
}

/* Reads the header into info and checks the image geometry. */
static clvox_status read_header(reader *r, clvox_volume_info *info, const exr_attr_chlist_entry_t **occ)
{
    exr_result_t rv;
    int parts = 0;
    rv = exr_get_count(r->exr, &parts);
    if (rv != EXR_ERR_SUCCESS || parts < 1) return exr_fail(r, rv, "counting the parts of");

    exr_attr_v3i_t dims;
    exr_attr_v3d_t origin, h;
    if (exr_attr_get_v3i(r->exr, 0, "clvoxDims", &dims) != EXR_ERR_SUCCESS)
        return clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s' is not a clvox volume: no v3i attribute clvoxDims",
                           r->path);
    if (exr_attr_get_v3d(r->exr, 0, "clvoxOrigin", &origin) != EXR_ERR_SUCCESS)
        return clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s' is not a clvox volume: no v3d attribute clvoxOrigin",
                           r->path);
    if (exr_attr_get_v3d(r->exr, 0, "clvoxVoxelSize", &h) != EXR_ERR_SUCCESS)
        return clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s' is not a clvox volume: no v3d attribute clvoxVoxelSize",
                           r->path);
    clvox_status st;
    if ((st = get_string(r, "clvoxMethod", info->method, sizeof info->method)) != CLVOX_OK) return st;
    if ((st = get_string(r, "clvoxParameters", info->parameters, sizeof info->parameters)) != CLVOX_OK)
        return st;
    if ((st = get_string(r, "clvoxVersion", info->version, sizeof info->version)) != CLVOX_OK) return st;
    for (int i = 0; i < 3; i++) {
        if (dims.arr[i] <= 0)
            return clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s': clvoxDims %d x %d x %d is not a valid grid", r->path,
                               dims.x, dims.y, dims.z);
        info->dims[i] = (uint32_t)dims.arr[i];
        info->origin[i] = origin.arr[i];
        info->voxel_size[i] = h.arr[i];
    }

    exr_compression_t comp;
    rv = exr_get_compression(r->exr, 0, &comp);
    if (rv != EXR_ERR_SUCCESS) return exr_fail(r, rv, "reading the compression of");
    snprintf(info->compression, sizeof info->compression, "%s", compression_name(comp));

    const exr_attr_chlist_t *chl = NULL;
    rv = exr_get_channels(r->exr, 0, &chl);
    if (rv != EXR_ERR_SUCCESS || !chl) return exr_fail(r, rv, "reading the channels of");
    info->channels[0] = '\0';
    *occ = NULL;
    for (int c = 0; c < chl->num_channels; c++) {
        const exr_attr_chlist_entry_t *e = &chl->entries[c];
        size_t used = strlen(info->channels);
        char name[64];
        copy_str(name, sizeof name, e->name.str, e->name.length);
        snprintf(info->channels + used, sizeof info->channels - used, "%s%s", used ? "," : "", name);
        if (strcmp(name, "occupancy") == 0) *occ = e;
    }
    if (!*occ)
        return clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s' is not a clvox volume: no channel \"occupancy\" (has: %s)",
                           r->path, info->channels);
    if ((*occ)->x_sampling != 1 || (*occ)->y_sampling != 1)
        return clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s': channel occupancy is subsampled", r->path);

    exr_attr_box2i_t dw;
    rv = exr_get_data_window(r->exr, 0, &dw);
    if (rv != EXR_ERR_SUCCESS) return exr_fail(r, rv, "reading the data window of");
    int64_t w = (int64_t)dw.max.x - dw.min.x + 1, hgt = (int64_t)dw.max.y - dw.min.y + 1;
    if (w != (int64_t)info->dims[0] || hgt != (int64_t)info->dims[1] * info->dims[2])
        return clvox__fail(r->ctx, CLVOX_ERR_EXR,
                           "'%s': data window %lld x %lld does not match clvoxDims %u x %u x %u (expected %u x %llu)",
                           r->path, (long long)w, (long long)hgt, info->dims[0], info->dims[1], info->dims[2],
                           info->dims[0], (unsigned long long)info->dims[1] * info->dims[2]);
    return CLVOX_OK;
}

/* Counts (and stores) rows [row0, row0+nrows) of the band: a voxel is filled
 * when its sample is > 0.5 (NaN is not; +infinity is). */
static uint64_t consume_band(const uint8_t *band, int type, uint64_t X, uint64_t row0, uint64_t nrows,
                             uint8_t *occupancy)
{
    const size_t n = (size_t)(X * nrows);
    uint8_t *out = occupancy ? occupancy + row0 * X : NULL;
    uint64_t filled = 0;
    if (type == EXR_PIXEL_HALF) {
        /* half bits in (0x3800 = 0.5, 0x7C00 = +inf]: one unsigned range test */
        const uint16_t *v = (const uint16_t *)(const void *)band;
        if (out) {
            for (size_t i = 0; i < n; i++) {
                uint8_t f = (uint16_t)(v[i] - 0x3801u) <= 0x7C00u - 0x3801u;
                out[i] = f;
                filled += f;
            }
        } else {
            for (size_t i = 0; i < n; i++) filled += (uint16_t)(v[i] - 0x3801u) <= 0x7C00u - 0x3801u;
        }
    } else if (type == EXR_PIXEL_FLOAT) {
        const float *v = (const float *)(const void *)band;
        for (size_t i = 0; i < n; i++) {
            uint8_t f = v[i] > 0.5f;
            if (out) out[i] = f;
            filled += f;
        }
    } else {
        const uint32_t *v = (const uint32_t *)(const void *)band;
        for (size_t i = 0; i < n; i++) {
            uint8_t f = v[i] > 0;
            if (out) out[i] = f;
            filled += f;
        }
    }
    return filled;
}

/* Decodes one chunk's occupancy samples into the band (row stride X). */
static clvox_status decode_chunk(reader *r, exr_decode_pipeline_t *dec, int *initialized,
                                 const exr_chunk_info_t *ci, uint8_t *dst, uint64_t X, uint32_t bytes, int type)
{
    exr_result_t rv;
    if (!*initialized) {
        rv = exr_decoding_initialize(r->exr, 0, ci, dec);
        if (rv != EXR_ERR_SUCCESS) return exr_fail(r, rv, "starting to decode");
        *initialized = 1;
    } else {
        rv = exr_decoding_update(r->exr, 0, ci, dec);
        if (rv != EXR_ERR_SUCCESS) return exr_fail(r, rv, "decoding");
    }
    for (int16_t c = 0; c < dec->channel_count; c++) {
        exr_coding_channel_info_t *ch = &dec->channels[c];
        if (strcmp(ch->channel_name, "occupancy") == 0) {
            ch->decode_to_ptr = dst;
            ch->user_pixel_stride = (int32_t)bytes;
            ch->user_line_stride = (int32_t)(X * bytes);
            ch->user_bytes_per_element = (int16_t)bytes;
            ch->user_data_type = (uint16_t)type;
        } else {
            ch->decode_to_ptr = NULL;
        }
    }
    rv = exr_decoding_choose_default_routines(r->exr, 0, dec);
    if (rv != EXR_ERR_SUCCESS) return exr_fail(r, rv, "choosing a decoder for");
    rv = exr_decoding_run(r->exr, 0, dec);
    if (rv != EXR_ERR_SUCCESS) return exr_fail(r, rv, "decoding");
    return CLVOX_OK;
}

static clvox_status read_pixels(reader *r, clvox_volume_info *info, const exr_attr_chlist_entry_t *occ,
                                uint8_t *occupancy)
{
    exr_result_t rv;
    exr_storage_t storage;
    rv = exr_get_storage(r->exr, 0, &storage);
    if (rv != EXR_ERR_SUCCESS) return exr_fail(r, rv, "reading the storage type of");
    if (storage != EXR_STORAGE_SCANLINE && storage != EXR_STORAGE_TILED)
        return clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s': deep images are not clvox volumes", r->path);

    const uint64_t X = info->dims[0];
    const uint64_t H = (uint64_t)info->dims[1] * info->dims[2];
    const int type = (int)occ->pixel_type;
    const uint32_t bytes = type == EXR_PIXEL_HALF ? 2u : 4u;
    exr_attr_box2i_t dw;
    rv = exr_get_data_window(r->exr, 0, &dw);
    if (rv != EXR_ERR_SUCCESS) return exr_fail(r, rv, "reading the data window of");

    uint64_t band_rows;
    int32_t tile_w = 0, tile_h = 0;
    if (storage == EXR_STORAGE_TILED) {
        rv = exr_get_tile_sizes(r->exr, 0, 0, 0, &tile_w, &tile_h);
        if (rv != EXR_ERR_SUCCESS || tile_w <= 0 || tile_h <= 0) return exr_fail(r, rv, "reading the tiles of");
        band_rows = (uint64_t)tile_h;
    } else {
        int32_t lpc = 0;
        rv = exr_get_scanlines_per_chunk(r->exr, 0, &lpc);
        if (rv != EXR_ERR_SUCCESS || lpc <= 0) return exr_fail(r, rv, "reading the chunk size of");
        band_rows = (uint64_t)lpc;
    }
    if (band_rows > H) band_rows = H;
    uint64_t band_bytes = X * band_rows * bytes;
    if (band_bytes > (uint64_t)SIZE_MAX / 2)
        return clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s': chunks of %llu bytes are too large", r->path,
                           (unsigned long long)band_bytes);
    uint8_t *band = malloc((size_t)band_bytes);
    if (!band) return clvox__fail(r->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for a %llu-byte chunk buffer",
                                  (unsigned long long)band_bytes);

    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int initialized = 0;
    clvox_status st = CLVOX_OK;
    uint64_t filled = 0;
    for (uint64_t row0 = 0; row0 < H && st == CLVOX_OK; row0 += band_rows) {
        uint64_t rows = H - row0 < band_rows ? H - row0 : band_rows;
        exr_chunk_info_t ci;
        if (storage == EXR_STORAGE_TILED) {
            int ty = (int)(row0 / band_rows);
            for (uint64_t x0 = 0; x0 < X && st == CLVOX_OK; x0 += (uint64_t)tile_w) {
                int tx = (int)(x0 / (uint64_t)tile_w);
                rv = exr_read_tile_chunk_info(r->exr, 0, tx, ty, 0, 0, &ci);
                if (rv != EXR_ERR_SUCCESS) {
                    st = exr_fail(r, rv, "locating a tile of");
                    break;
                }
                if ((uint64_t)ci.height != rows || (uint64_t)ci.width > X - x0) {
                    st = clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s': tile (%d,%d) has an unexpected size %dx%d",
                                     r->path, tx, ty, ci.width, ci.height);
                    break;
                }
                st = decode_chunk(r, &dec, &initialized, &ci, band + x0 * bytes, X, bytes, type);
            }
        } else {
            rv = exr_read_scanline_chunk_info(r->exr, 0, dw.min.y + (int)row0, &ci);
            if (rv != EXR_ERR_SUCCESS) {
                st = exr_fail(r, rv, "locating a chunk of");
                break;
            }
            if ((uint64_t)ci.height != rows || (uint64_t)ci.width != X) {
                st = clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s': chunk at row %llu has an unexpected size %dx%d",
                                 r->path, (unsigned long long)row0, ci.width, ci.height);
                break;
            }
            st = decode_chunk(r, &dec, &initialized, &ci, band, X, bytes, type);
        }
        if (st == CLVOX_OK) filled += consume_band(band, type, X, row0, rows, occupancy);
    }
    if (initialized) exr_decoding_destroy(r->exr, &dec);
    free(band);
    if (st == CLVOX_OK) info->filled_voxels = filled;
    return st;
}

clvox_status clvox_volume_read(clvox_context *ctx, const char *path, clvox_volume_info *info,
                               uint8_t *occupancy, size_t occupancy_size)
{
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!path || !*path) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_volume_read: no path");
    clvox_volume_info local;
    if (!info) info = &local;
    memset(info, 0, sizeof *info);

    struct stat sb;
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) return clvox__fail(ctx, CLVOX_ERR_IO, "cannot open '%s': %s", path, strerror(errno));
    int is_dir = fstat(fd, &sb) == 0 && S_ISDIR(sb.st_mode);
    close(fd);
    if (is_dir) return clvox__fail(ctx, CLVOX_ERR_IO, "cannot read '%s': it is a directory", path);

    reader r = { .ctx = ctx, .path = path };
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = reader_error_handler;
    init.user_data = &r;
    init.flags = EXR_CONTEXT_FLAG_DISABLE_CHUNK_RECONSTRUCTION;
    exr_result_t rv = exr_start_read(&r.exr, path, &init);
    if (rv != EXR_ERR_SUCCESS) {
        clvox_status st = (rv == EXR_ERR_FILE_ACCESS) ? CLVOX_ERR_IO : CLVOX_ERR_EXR;
        clvox__fail(ctx, st, "'%s' is not a readable OpenEXR file: %s", path,
                    r.msg[0] ? r.msg : exr_get_default_error_message(rv));
        if (r.exr) exr_finish(&r.exr);
        return st;
    }

    const exr_attr_chlist_entry_t *occ = NULL;
    clvox_status st = read_header(&r, info, &occ);
    if (st == CLVOX_OK && occupancy) {
        uint64_t total = (uint64_t)info->dims[0] * info->dims[1] * info->dims[2];
        if (total > (uint64_t)SIZE_MAX || occupancy_size < (size_t)total)
            st = clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT,
                             "occupancy buffer holds %zu bytes, '%s' needs %u x %u x %u = %llu", occupancy_size, path,
                             info->dims[0], info->dims[1], info->dims[2], (unsigned long long)total);
    }
    if (st == CLVOX_OK) st = read_pixels(&r, info, occ, occupancy);
    exr_finish(&r.exr);
    return st;
}
