/* SPDX-License-Identifier: Apache-2.0 */
#include "exrgen.h"

#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

double exrgen_half_value(uint16_t h)
{
    int e = (h >> 10) & 31, m = h & 1023;
    double v;
    if (e == 31) v = m ? NAN : INFINITY;
    else if (e == 0) v = ldexp((double)m, -24);
    else v = ldexp((double)(m + 1024), e - 25);
    return (h & 0x8000) ? -v : v;
}

static size_t type_bytes(exr_pixel_type_t t)
{
    return t == EXR_PIXEL_HALF ? 2 : 4;
}

#define TRY(call)                                                                         \
    do {                                                                                  \
        exr_result_t rv_ = (call);                                                        \
        if (rv_ != EXR_ERR_SUCCESS) {                                                     \
            fprintf(stderr, "exrgen: %s: %s\n", #call, exr_get_default_error_message(rv_)); \
            goto fail;                                                                    \
        }                                                                                 \
    } while (0)

exrgen_attrs exrgen_default_attrs(uint32_t X, uint32_t Y, uint32_t Z)
{
    exrgen_attrs a = { { (int32_t)X, (int32_t)Y, (int32_t)Z },
                       { EXRGEN_ORIGIN_X, EXRGEN_ORIGIN_Y, EXRGEN_ORIGIN_Z },
                       { EXRGEN_H_X, EXRGEN_H_Y, EXRGEN_H_Z },
                       NULL,
                       NULL,
                       0 };
    return a;
}

static exr_result_t set_attrs(exr_context_t e, int part, const exrgen_attrs *a)
{
    exr_attr_v3i_t d = { .arr = { a->dims[0], a->dims[1], a->dims[2] } };
    exr_attr_v3d_t o = { .arr = { a->origin[0], a->origin[1], a->origin[2] } };
    exr_attr_v3d_t h = { .arr = { a->voxel_size[0], a->voxel_size[1], a->voxel_size[2] } };
    exr_result_t rv;
    if ((rv = exr_attr_set_v3i(e, part, "clvoxDims", &d)) != EXR_ERR_SUCCESS) return rv;
    if ((rv = exr_attr_set_v3d(e, part, "clvoxOrigin", &o)) != EXR_ERR_SUCCESS) return rv;
    if ((rv = exr_attr_set_v3d(e, part, "clvoxVoxelSize", &h)) != EXR_ERR_SUCCESS) return rv;
    if ((rv = exr_attr_set_string(e, part, "clvoxMethod", EXRGEN_METHOD)) != EXR_ERR_SUCCESS) return rv;
    if ((rv = exr_attr_set_string(e, part, "clvoxParameters", "written by tests/exrgen.c")) != EXR_ERR_SUCCESS)
        return rv;
    if ((rv = exr_attr_set_string(e, part, "clvoxVersion", EXRGEN_VERSION)) != EXR_ERR_SUCCESS) return rv;
    if (a->layout && (rv = exr_attr_set_string(e, part, "clvoxLayout", a->layout)) != EXR_ERR_SUCCESS) return rv;
    for (int i = 0; i < a->extra_count; i++) {
        const exrgen_extra *x = &a->extra[i];
        rv = x->string ? exr_attr_set_string(e, part, x->name, x->string) : exr_attr_set_int(e, part, x->name, x->value);
        if (rv != EXR_ERR_SUCCESS) return rv;
    }
    return EXR_ERR_SUCCESS;
}

int exrgen_write(const char *path, uint32_t X, uint32_t Y, uint32_t Z, const exrgen_channel *channels,
                 int channel_count, int tile_w, int tile_h, exr_compression_t comp, int attributes)
{
    exrgen_attrs a = exrgen_default_attrs(X, Y, Z);
    return exrgen_write_ex(path, X, Y, Z, channels, channel_count, tile_w, tile_h, comp, attributes ? &a : NULL);
}

int exrgen_write_ex(const char *path, uint32_t X, uint32_t Y, uint32_t Z, const exrgen_channel *channels,
                    int channel_count, int tile_w, int tile_h, exr_compression_t comp, const exrgen_attrs *attrs)
{
    exr_context_t e = NULL;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    int part = 0, first = 1, enc_ready = 0;
    const int H = (int)(Y * Z);
    TRY(exr_start_write(&e, path, EXR_WRITE_FILE_DIRECTLY, &init));
    TRY(exr_add_part(e, NULL, tile_w ? EXR_STORAGE_TILED : EXR_STORAGE_SCANLINE, &part));
    TRY(exr_initialize_required_attr_simple(e, part, (int)X, H, comp));
    if (tile_w)
        TRY(exr_set_tile_descriptor(e, part, (uint32_t)tile_w, (uint32_t)tile_h, EXR_TILE_ONE_LEVEL,
                                    EXR_TILE_ROUND_DOWN));
    for (int c = 0; c < channel_count; c++)
        TRY(exr_add_channel(e, part, channels[c].name, channels[c].type, EXR_PERCEPTUALLY_LINEAR, 1, 1));
    if (attrs) TRY(set_attrs(e, part, attrs));
    TRY(exr_write_header(e));
    int32_t lpc = 1;
    if (!tile_w) TRY(exr_get_scanlines_per_chunk(e, part, &lpc));
    const int step_y = tile_w ? tile_h : lpc, step_x = tile_w ? tile_w : (int)X;
    for (int y0 = 0; y0 < H; y0 += step_y)
        for (int x0 = 0; x0 < (int)X; x0 += step_x) {
            exr_chunk_info_t ci;
            if (tile_w) TRY(exr_write_tile_chunk_info(e, part, x0 / tile_w, y0 / tile_h, 0, 0, &ci));
            else TRY(exr_write_scanline_chunk_info(e, part, y0, &ci));
            if (first) {
                TRY(exr_encoding_initialize(e, part, &ci, &enc));
                enc_ready = 1;
            } else TRY(exr_encoding_update(e, part, &ci, &enc));
            for (int k = 0; k < enc.channel_count; k++) {
                exr_coding_channel_info_t *ch = &enc.channels[k];
                const exrgen_channel *src = NULL;
                for (int c = 0; c < channel_count; c++)
                    if (strcmp(channels[c].name, ch->channel_name) == 0) src = &channels[c];
                if (!src) goto fail;
                size_t b = type_bytes(src->type);
                ch->encode_from_ptr = (const uint8_t *)src->data + ((size_t)y0 * X + (size_t)x0) * b;
                ch->user_pixel_stride = (int32_t)b;
                ch->user_line_stride = (int32_t)(X * b);
                ch->user_bytes_per_element = (int16_t)b;
                ch->user_data_type = (uint16_t)src->type;
            }
            if (first) TRY(exr_encoding_choose_default_routines(e, part, &enc));
            first = 0;
            TRY(exr_encoding_run(e, part, &enc));
        }
    enc_ready = 0;
    TRY(exr_encoding_destroy(e, &enc));
    TRY(exr_finish(&e));
    return 1;
fail:
    if (enc_ready) exr_encoding_destroy(e, &enc);
    if (e) exr_finish(&e);
    unlink(path);
    return 0;
}

/* ---- header-only files ---- */

typedef struct header_sink {
    int fd;
    int frozen; /* after the header: further writes (the chunk table) are dropped */
} header_sink;

static int64_t sink_write(exr_const_context_t c, void *ud, const void *buf, uint64_t size, uint64_t offset,
                          exr_stream_error_func_ptr_t err)
{
    (void)c;
    (void)err;
    header_sink *k = ud;
    if (k->frozen) return (int64_t)size;
    return pwrite(k->fd, buf, (size_t)size, (off_t)offset) == (ssize_t)size ? (int64_t)size : -1;
}

int exrgen_write_header(const char *path, int64_t width, int64_t height, int tile_w, int tile_h,
                        exr_compression_t comp, const exrgen_attrs *attrs, size_t extra_bytes)
{
    header_sink k = { -1, 0 };
    exr_context_t e = NULL;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    int part = 0;
    k.fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (k.fd < 0) return 0;
    init.user_data = &k;
    init.write_fn = sink_write;
    TRY(exr_start_write(&e, path, EXR_WRITE_FILE_DIRECTLY, &init));
    TRY(exr_add_part(e, NULL, tile_w ? EXR_STORAGE_TILED : EXR_STORAGE_SCANLINE, &part));
    TRY(exr_initialize_required_attr_simple(e, part, (int32_t)width, (int32_t)height, comp));
    if (tile_w)
        TRY(exr_set_tile_descriptor(e, part, (uint32_t)tile_w, (uint32_t)tile_h, EXR_TILE_ONE_LEVEL,
                                    EXR_TILE_ROUND_DOWN));
    TRY(exr_add_channel(e, part, "occupancy", EXR_PIXEL_HALF, EXR_PERCEPTUALLY_LINEAR, 1, 1));
    if (attrs) TRY(set_attrs(e, part, attrs));
    TRY(exr_write_header(e));
    k.frozen = 1;
    exr_finish(&e);
    off_t end = lseek(k.fd, 0, SEEK_END);
    uint8_t zero[256] = { 0 };
    for (size_t left = extra_bytes; left > 0;) {
        size_t n = left < sizeof zero ? left : sizeof zero;
        if (pwrite(k.fd, zero, n, end) != (ssize_t)n) goto fail;
        end += (off_t)n;
        left -= n;
    }
    close(k.fd);
    return 1;
fail:
    if (e) exr_finish(&e);
    if (k.fd >= 0) close(k.fd);
    unlink(path);
    return 0;
}
