/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Reading clvox volumes back (clvox_volume_read, clvox_volume_read_slices).
 *
 * Accepts any single-resolution EXR image X wide and Y*Z tall that carries
 * the clvox attributes (see the layout comment in write_exr.c): tiled (any
 * tile size, level 0) or scanline, any compression, any other channels.
 *
 * One code path reads a channel: read_channel decodes one row of chunks at a
 * time into a band buffer (the channel's samples as stored: HALF, FLOAT or
 * UINT, row stride X) and hands each band to a consumer, so memory is bounded
 * by one chunk row, whatever Z is. The consumers:
 *  - count_band: voxels > 0.5 (the "filled" count; optionally stores 0/1),
 *    with an SSE range test for HALF; sums coverage too when asked;
 *  - sum_band: the coverage sum;
 *  - slice_band: converts rows to float into a one-slice buffer and calls the
 *    user's function each time a slice is complete (a band may end inside a
 *    slice or span several: rows are placed by their own z and y).
 * A voxel is filled when its "occupancy" sample is > 0.5, or, in a file
 * without occupancy, its "coverage" sample; in a file with neither (a
 * palette run's element and score), when its "element" is not 0 (index 0
 * is the empty element in every palette).
 *
 * Coverage sum. HALF samples are multiples of 2^-24 and finite ones are below
 * 2^16, so each is an integer times 2^-24 with |integer| < 2^40: they are
 * added exactly as integers (a 128-bit accumulator, int64 partial sums of at
 * most 2^22 samples), and the total is converted to double once at the end
 * (exact while the sum is below 2^29; otherwise one rounding). Infinite or
 * NaN samples (never written by clvox) are added as floats, so they show in
 * the result. FLOAT and UINT coverage samples are summed in double.
 */
#include "core/internal.h"

#include <OpenEXR/openexr.h>

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

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

static void reader_error_handler(exr_const_context_t ectx, exr_result_t code, const char *msg)
{
    void *ud = NULL;
    if (!ectx || exr_get_user_data(ectx, &ud) != EXR_ERR_SUCCESS || !ud) return;
    reader *r = ud;
    snprintf(r->msg, sizeof r->msg, "%s", msg ? msg : exr_get_default_error_message(code));
}

static int64_t reader_read_fn(exr_const_context_t ectx, void *ud, void *buffer, uint64_t size, uint64_t offset,
                              exr_stream_error_func_ptr_t error_cb)
{
    reader *r = ud;
    uint8_t *p = buffer;
    uint64_t done = 0;
    while (done < size) {
        size_t n = size - done > (1u << 30) ? (1u << 30) : (size_t)(size - done);
        ssize_t got = pread(r->fd, p + done, n, (off_t)(offset + done));
        if (got < 0 && errno == EINTR) continue;
        if (got < 0) {
            if (error_cb) error_cb(ectx, EXR_ERR_READ_IO, "read from '%s' failed: %s", r->path, strerror(errno));
            return -1;
        }
        if (got == 0) break; /* end of file: a short read, as pread gives */
        done += (uint64_t)got;
    }
    return (int64_t)done;
}

static int64_t reader_size_fn(exr_const_context_t ectx, void *ud)
{
    (void)ectx;
    return (int64_t)((reader *)ud)->file_size;
}

/* At most this many bytes of samples per byte of file for compression c: a
 * larger claim cannot be true, and would only make us allocate for it. RLE:
 * a 2-byte token gives at most 128 bytes; zlib (ZIP, ZIPS, PXR24) at most
 * about 1032 per byte, PIZ's Huffman runs about 410, B44 11; DWA (lossy,
 * zlib over DCT runs) is given room. */
static uint64_t max_expansion(exr_compression_t c)
{
    switch (c) {
    case EXR_COMPRESSION_NONE: return 1;
    case EXR_COMPRESSION_RLE: return 64;
    case EXR_COMPRESSION_DWAA:
    case EXR_COMPRESSION_DWAB: return 1u << 17;
    default: return 2048;
    }
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

/* 1 when the n bytes hold a control character (NUL, newline, DEL, ...). */
static int has_control(const char *s, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if ((unsigned char)s[i] < 0x20 || s[i] == 0x7F) return 1;
    return 0;
}

/* An optional string attribute: *present = 0 when the header lacks it;
 * else it must be a string of fewer than `size` bytes without control
 * characters (so that messages quoting it stay one line). */
static clvox_status optional_string(reader *r, const char *name, char *dst, size_t size, int *present)
{
    const exr_attribute_t *a = NULL;
    *present = 0;
    dst[0] = '\0';
    exr_result_t rv = exr_get_attribute_by_name(r->exr, 0, name, &a);
    if (rv == EXR_ERR_NO_ATTR_BY_NAME) return CLVOX_OK;
    if (rv != EXR_ERR_SUCCESS || !a) return exr_fail(r, rv, "reading the header of");
    if (a->type != EXR_ATTR_STRING || !a->string || a->string->length < 0 || !a->string->str)
        return clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s' is corrupt: attribute %s is not a string", r->path, name);
    size_t n = (size_t)a->string->length;
    if (n >= size || has_control(a->string->str, n))
        return clvox__fail(r->ctx, CLVOX_ERR_EXR,
                           "'%s' is corrupt: attribute %s is %s (at most %zu bytes, no control characters)", r->path,
                           name, n >= size ? "too long" : "not text", size - 1);
    copy_str(dst, size, a->string->str, a->string->length);
    *present = 1;
    return CLVOX_OK;
}

/* The palette attributes of a palette run (write_exr.c), each optional:
 * clvoxPalette, clvoxPaletteCount (int, 1..65536), clvoxPaletteHash (16
 * lower-case hex digits), clvoxMetric. Present but malformed: corrupt. */
static clvox_status read_palette_attrs(reader *r, clvox_volume_info *info)
{
    int present = 0;
    clvox_status st = optional_string(r, "clvoxPalette", info->palette, sizeof info->palette, &present);
    if (st == CLVOX_OK) st = optional_string(r, "clvoxMetric", info->metric, sizeof info->metric, &present);
    if (st != CLVOX_OK) return st;
    char hash[17];
    st = optional_string(r, "clvoxPaletteHash", hash, sizeof hash, &present);
    if (st != CLVOX_OK) return st;
    if (present) {
        uint64_t h = 0;
        size_t i = 0;
        for (; hash[i]; i++) {
            char c = hash[i];
            if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) break;
            h = h << 4 | (uint64_t)(c <= '9' ? c - '0' : c - 'a' + 10);
        }
        if (i != 16 || hash[i])
            return clvox__fail(r->ctx, CLVOX_ERR_EXR,
                               "'%s' is corrupt: attribute clvoxPaletteHash \"%s\" is not 16 lower-case hex digits",
                               r->path, hash);
        info->palette_hash = h;
        r->has_palette_hash = 1;
    }
    const exr_attribute_t *a = NULL;
    exr_result_t rv = exr_get_attribute_by_name(r->exr, 0, "clvoxPaletteCount", &a);
    if (rv == EXR_ERR_SUCCESS && a) {
        if (a->type != EXR_ATTR_INT || a->i < 1 || a->i > 65536)
            return clvox__fail(r->ctx, CLVOX_ERR_EXR,
                               "'%s' is corrupt: attribute clvoxPaletteCount is not an int in 1..65536", r->path);
        info->palette_count = (uint32_t)a->i;
        r->has_palette_count = 1;
    } else if (rv != EXR_ERR_NO_ATTR_BY_NAME) {
        return exr_fail(r, rv, "reading the header of");
    }
    return CLVOX_OK;
}

/* What the file can hold: the samples the header declares (all channels)
 * at most max_expansion times the file size, the chunk offset table (8 bytes
 * per chunk) inside the file; with clvox's own layouts (clvoxLayout and
 * tiles X wide, as clvox writes them), tiles Y tall for "tile-per-slice" (so
 * the tiles confirm clvoxDims' Y), fewer rows than Y for "row-chunks". Every buffer
 * the reader allocates is bounded by the samples, so by the file size. */
static clvox_status check_size(reader *r, const clvox_volume_info *info, uint64_t H)
{
    uint64_t pixel = 0;
    for (int c = 0; c < r->chl->num_channels; c++)
        pixel += r->chl->entries[c].pixel_type == EXR_PIXEL_HALF ? 2u : 4u;
    const uint64_t X = info->dims[0], limit = max_expansion(r->compression) * r->file_size;
    if (pixel == 0) pixel = 1;
    if (X * H > limit / pixel) /* X*H < 2^62 */
        return clvox__fail(r->ctx, CLVOX_ERR_EXR,
                           "'%s' is corrupt: its header declares %llu x %llu pixels of %llu bytes, more than a "
                           "%llu-byte file with %s compression can hold",
                           r->path, (unsigned long long)X, (unsigned long long)H, (unsigned long long)pixel,
                           (unsigned long long)r->file_size, info->compression);
    int32_t chunks = 0;
    exr_result_t rv = exr_get_chunk_count(r->exr, 0, &chunks);
    if (rv != EXR_ERR_SUCCESS || chunks <= 0) return exr_fail(r, rv, "counting the chunks of");
    if ((uint64_t)chunks * 8 > r->file_size)
        return clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s' is corrupt: %d chunks do not fit in %llu bytes", r->path,
                           (int)chunks, (unsigned long long)r->file_size);

    int32_t len = 0;
    const char *layout = NULL;
    if (exr_attr_get_string(r->exr, 0, "clvoxLayout", &len, &layout) != EXR_ERR_SUCCESS || !layout) return CLVOX_OK;
    const int per_slice = len >= 14 && strncmp(layout, "tile-per-slice", 14) == 0;
    const int row_chunks = len >= 10 && strncmp(layout, "row-chunks", 10) == 0;
    if (!per_slice && !row_chunks) return CLVOX_OK; /* a layout of some later version */
    /* Only tiles X wide are clvox's: a file re-saved by another tool keeps
     * the attribute with tiles (or scanlines) of its own, and is read as any
     * other layout. */
    int32_t tw = 0, th = 0;
    exr_storage_t storage;
    if (exr_get_storage(r->exr, 0, &storage) != EXR_ERR_SUCCESS || storage != EXR_STORAGE_TILED ||
        exr_get_tile_sizes(r->exr, 0, 0, 0, &tw, &th) != EXR_ERR_SUCCESS || (uint64_t)tw != X)
        return CLVOX_OK;
    if ((per_slice && (uint32_t)th != info->dims[1]) || (row_chunks && (th <= 0 || (uint32_t)th >= info->dims[1])))
        return clvox__fail(r->ctx, CLVOX_ERR_EXR,
                           "'%s' is corrupt: %d x %d tiles do not fit clvoxDims %u x %u x %u in its layout \"%.*s\"",
                           r->path, (int)tw, (int)th, info->dims[0], info->dims[1], info->dims[2],
                           len > 40 ? 40 : (int)len, layout);
    return CLVOX_OK;
}

/* Reads the header into info (every field but the counts) and checks the
 * image geometry. Channels are looked up afterwards (find_channel). */
static clvox_status read_header(reader *r, clvox_volume_info *info)
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
    if ((st = read_palette_attrs(r, info)) != CLVOX_OK) return st;
    for (int i = 0; i < 3; i++) {
        if (dims.arr[i] <= 0)
            return clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s': clvoxDims %d x %d x %d is not a valid grid", r->path,
                               dims.x, dims.y, dims.z);
        if (!isfinite(origin.arr[i]))
            return clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s': clvoxOrigin (%g, %g, %g) is not finite", r->path,
                               origin.x, origin.y, origin.z);
        if (!isfinite(h.arr[i]) || !(h.arr[i] > 0))
            return clvox__fail(r->ctx, CLVOX_ERR_EXR,
                               "'%s': clvoxVoxelSize (%g, %g, %g) is not finite and positive", r->path, h.x, h.y,
                               h.z);
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
    r->chl = chl;
    info->channels[0] = '\0';
    r->all_full = 1;
    for (int c = 0; c < chl->num_channels; c++) {
        const exr_attr_chlist_entry_t *e = &chl->entries[c];
        size_t used = strlen(info->channels);
        char name[64];
        copy_str(name, sizeof name, e->name.str, e->name.length);
        snprintf(info->channels + used, sizeof info->channels - used, "%s%s", used ? "," : "", name);
        if (e->x_sampling != 1 || e->y_sampling != 1) r->all_full = 0; /* rows of differing sizes: library */
    }
    r->compression = comp;

    exr_attr_box2i_t dw;
    rv = exr_get_data_window(r->exr, 0, &dw);
    if (rv != EXR_ERR_SUCCESS) return exr_fail(r, rv, "reading the data window of");
    int64_t w = (int64_t)dw.max.x - dw.min.x + 1, hgt = (int64_t)dw.max.y - dw.min.y + 1;
    if (w != (int64_t)info->dims[0] || hgt != (int64_t)info->dims[1] * info->dims[2])
        return clvox__fail(r->ctx, CLVOX_ERR_EXR,
                           "'%s': data window %lld x %lld does not match clvoxDims %u x %u x %u (expected %u x %llu)",
                           r->path, (long long)w, (long long)hgt, info->dims[0], info->dims[1], info->dims[2],
                           info->dims[0], (unsigned long long)info->dims[1] * info->dims[2]);
    return check_size(r, info, (uint64_t)hgt);
}

static const exr_attr_chlist_entry_t *find_channel(const reader *r, const char *name)
{
    size_t n = strlen(name);
    for (int c = 0; c < r->chl->num_channels; c++) {
        const exr_attr_chlist_entry_t *e = &r->chl->entries[c];
        if (e->name.length >= 0 && (size_t)e->name.length == n && memcmp(e->name.str, name, n) == 0) return e;
    }
    return NULL;
}

/* Makes `e` the channel read_channel decodes. */
static clvox_status select_channel(reader *r, const exr_attr_chlist_entry_t *e)
{
    if (e->x_sampling != 1 || e->y_sampling != 1)
        return clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s': channel %s is subsampled", r->path, e->name.str);
    if (e->pixel_type != EXR_PIXEL_HALF && e->pixel_type != EXR_PIXEL_FLOAT && e->pixel_type != EXR_PIXEL_UINT)
        return clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s': channel %s has an unknown pixel type %d", r->path,
                           e->name.str, (int)e->pixel_type);
    r->ch_name = e->name.str;
    r->ch_type = (int)e->pixel_type;
    r->ch_bytes = e->pixel_type == EXR_PIXEL_HALF ? 2u : 4u;
    r->fast = r->all_full && (r->compression == EXR_COMPRESSION_NONE || r->compression == EXR_COMPRESSION_RLE);
    r->pixel_bytes = r->ch_offset = 0;
    for (int c = 0; c < r->chl->num_channels; c++) {
        const exr_attr_chlist_entry_t *o = &r->chl->entries[c];
        if (o == e) r->ch_offset = r->pixel_bytes;
        r->pixel_bytes += o->pixel_type == EXR_PIXEL_HALF ? 2u : 4u;
    }
    return CLVOX_OK;
}

/* ---- sample conversion and sums ------------------------------------------ */

static float half_to_float(uint16_t h)
{
    uint32_t s = (uint32_t)(h & 0x8000u) << 16, e = (h >> 10) & 31u, m = h & 1023u, f;
    if (e == 31) {
        f = s | 0x7F800000u | (m << 13);
    } else if (e) {
        f = s | ((e + 112u) << 23) | (m << 13);
    } else if (!m) {
        f = s;
    } else { /* subnormal: m * 2^-24, normalised */
        e = 113;
        while (!(m & 1024u)) {
            m <<= 1;
            e--;
        }
        f = s | (e << 23) | ((m & 1023u) << 13);
    }
    float v;
    memcpy(&v, &f, sizeof v);
    return v;
}

/* A finite HALF value times 2^24, exactly (|result| < 2^40). */
static int64_t half_scaled(uint16_t h)
{
    uint32_t e = (h >> 10) & 31u, m = h & 1023u;
    int64_t mag = e ? (int64_t)(m | 1024u) << (e - 1) : (int64_t)m;
    return (h & 0x8000u) ? -mag : mag;
}

typedef struct coverage_sum {
    uint64_t lo;   /* exact part: (hi * 2^64 + lo) * 2^-24, two's complement */
    int64_t hi;
    double other;  /* FLOAT/UINT samples and non-finite HALF samples */
} coverage_sum;

static void sum_add_exact(coverage_sum *s, int64_t v)
{
    uint64_t u = (uint64_t)v;
    s->lo += u;
    s->hi += (s->lo < u) - (v < 0);
}

static double sum_value(const coverage_sum *s)
{
    /* |hi * 2^64 + lo| as a double (hi is 0 for any real volume), then 2^-24 */
    uint64_t lo = s->lo, hi = (uint64_t)s->hi;
    const int negative = s->hi < 0;
    if (negative) { /* two's complement negation of the 128-bit value */
        lo = ~lo + 1;
        hi = ~hi + (lo == 0);
    }
    double mag = (double)hi * 18446744073709551616.0 + (double)lo;
    return (negative ? -mag : mag) * (1.0 / 16777216.0) + s->other;
}

static void sum_samples(coverage_sum *s, const uint8_t *band, int type, size_t n)
{
    if (type == EXR_PIXEL_HALF) {
        const uint16_t *v = (const uint16_t *)(const void *)band;
        for (size_t i0 = 0; i0 < n; i0 += (size_t)1 << 22) { /* 2^22 samples of < 2^40: fits int64 */
            size_t i1 = n - i0 < ((size_t)1 << 22) ? n : i0 + ((size_t)1 << 22);
            int64_t part = 0;
            for (size_t i = i0; i < i1; i++) {
                if ((v[i] & 0x7C00u) == 0x7C00u) s->other += half_to_float(v[i]);
                else part += half_scaled(v[i]);
            }
            sum_add_exact(s, part);
        }
    } else if (type == EXR_PIXEL_FLOAT) {
        const float *v = (const float *)(const void *)band;
        double part = 0;
        for (size_t i = 0; i < n; i++) part += v[i];
        s->other += part;
    } else {
        const uint32_t *v = (const uint32_t *)(const void *)band;
        double part = 0;
        for (size_t i = 0; i < n; i++) part += v[i];
        s->other += part;
    }
}

/* Converts n samples to float (UINT exactly below 2^24). */
static void to_float(float *out, const uint8_t *band, int type, size_t n)
{
    if (type == EXR_PIXEL_HALF) {
        const uint16_t *v = (const uint16_t *)(const void *)band;
        for (size_t i = 0; i < n; i++) out[i] = half_to_float(v[i]);
    } else if (type == EXR_PIXEL_FLOAT) {
        memcpy(out, band, n * sizeof *out);
    } else {
        const uint32_t *v = (const uint32_t *)(const void *)band;
        for (size_t i = 0; i < n; i++) out[i] = (float)v[i];
    }
}

/* Counts (and stores) rows [row0, row0+nrows) of the band: a voxel is filled
 * when its sample is > 0.5 (NaN is not; +infinity is). */
static uint64_t count_filled(const uint8_t *band, int type, uint64_t X, uint64_t row0, uint64_t nrows,
                             uint8_t *occupancy)
{
    const size_t n = (size_t)(X * nrows);
    uint8_t *out = occupancy ? occupancy + row0 * X : NULL;
    uint64_t filled = 0;
    if (type == EXR_PIXEL_HALF) {
        /* half bits in (0x3800 = 0.5, 0x7C00 = +inf]: one unsigned range test */
        const uint16_t *v = (const uint16_t *)(const void *)band;
        size_t i0 = 0;
#ifdef __SSE2__
        /* (v - 0x3801) <= 0x43FF unsigned, as a signed compare after flipping bit 15 */
        const __m128i off = _mm_set1_epi16(0x3801), flip = _mm_set1_epi16((short)0x8000);
        const __m128i lim = _mm_set1_epi16((short)(0x4400 ^ 0x8000)), one = _mm_set1_epi8(1);
        for (; i0 + 16 <= n; i0 += 16) {
            __m128i a = _mm_loadu_si128((const __m128i *)(const void *)(v + i0));
            __m128i b = _mm_loadu_si128((const __m128i *)(const void *)(v + i0 + 8));
            __m128i fa = _mm_cmplt_epi16(_mm_xor_si128(_mm_sub_epi16(a, off), flip), lim);
            __m128i fb = _mm_cmplt_epi16(_mm_xor_si128(_mm_sub_epi16(b, off), flip), lim);
            __m128i f = _mm_packs_epi16(fa, fb); /* 0xFF or 0 per voxel */
            filled += (uint64_t)__builtin_popcount((unsigned)_mm_movemask_epi8(f));
            if (out) _mm_storeu_si128((__m128i *)(void *)(out + i0), _mm_and_si128(f, one));
        }
#endif
        v += i0;
        if (out) out += i0;
        const size_t rest = n - i0;
        if (out) {
            for (size_t i = 0; i < rest; i++) {
                uint8_t f = (uint16_t)(v[i] - 0x3801u) <= 0x7C00u - 0x3801u;
                out[i] = f;
                filled += f;
            }
        } else {
            for (size_t i = 0; i < rest; i++) filled += (uint16_t)(v[i] - 0x3801u) <= 0x7C00u - 0x3801u;
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

/* ---- band consumers ---------------------------------------------------------- */

/* Receives rows [row0, row0+rows) of the image, X samples each of `type`. */
typedef clvox_status (*band_fn)(void *user, const uint8_t *band, int type, uint64_t row0, uint64_t rows);

typedef struct count_state {
    uint64_t X;
    uint8_t *occupancy;   /* NULL: count only */
    uint64_t filled;
    coverage_sum *sum;    /* not NULL: the channel is coverage, sum it too */
} count_state;

static clvox_status count_band(void *user, const uint8_t *band, int type, uint64_t row0, uint64_t rows)
{
    count_state *c = user;
    c->filled += count_filled(band, type, c->X, row0, rows, c->occupancy);
    if (c->sum) sum_samples(c->sum, band, type, (size_t)(c->X * rows));
    return CLVOX_OK;
}

static clvox_status sum_band(void *user, const uint8_t *band, int type, uint64_t row0, uint64_t rows)
{
    count_state *c = user;
    (void)row0;
    sum_samples(c->sum, band, type, (size_t)(c->X * rows));
    return CLVOX_OK;
}

typedef struct slice_state {
    reader *r;
    uint64_t X, Y;
    float *slice;         /* X*Y */
    clvox_volume_slice_fn fn;
    void *user;
} slice_state;

static clvox_status slice_band(void *user, const uint8_t *band, int type, uint64_t row0, uint64_t rows)
{
    slice_state *s = user;
    const size_t bytes = type == EXR_PIXEL_HALF ? 2 : 4;
    for (uint64_t k = 0; k < rows; k++) {
        uint64_t row = row0 + k, z = row / s->Y, y = row % s->Y;
        to_float(s->slice + y * s->X, band + (size_t)(k * s->X * bytes), type, (size_t)s->X);
        if (y + 1 == s->Y && s->fn(s->user, (uint32_t)z, s->slice) != 0)
            return clvox__fail(s->r->ctx, CLVOX_ERR_CANCELLED, "reading '%s' cancelled after slice %llu",
                               s->r->path, (unsigned long long)z);
    }
    return CLVOX_OK;
}

/* ---- decoding ------------------------------------------------------------------ */

static int grow(uint8_t **buf, size_t *size, size_t need)
{
    if (*size >= need) return 1;
    uint8_t *p = realloc(*buf, need ? need : 1);
    if (!p) return 0;
    *buf = p;
    *size = need;
    return 1;
}

/* ---- fast path for the two layouts clvox writes quickly: NONE and RLE ----
 * (OpenEXRCore 3.1.5's RLE decoder takes most of the reading time otherwise.)
 * RLE format: see write_exr.c. */

/* Expands RLE tokens; 0 when they fill exactly out[0..n). */
static int rle_expand(uint8_t *restrict out, size_t n, const uint8_t *restrict in, size_t len)
{
    size_t i = 0, o = 0;
    while (i < len) {
        int c = (int8_t)in[i++];
        if (c < 0) {
            size_t k = (size_t)-c;
            if (k > len - i || k > n - o) return -1;
            memcpy(out + o, in + i, k);
            i += k;
            o += k;
        } else {
            size_t k = (size_t)c + 1;
            if (i >= len || k > n - o) return -1;
            memset(out + o, in[i++], k);
            o += k;
        }
    }
    return o == n ? 0 : -1;
}

/* Undoes the delta (in place in t) and the even/odd split (into out). */
static void rle_reconstruct(uint8_t *restrict out, uint8_t *restrict t, size_t n)
{
    if (n == 0) return;
    size_t i = 0;
    uint8_t prev = 0;
    t[0] = (uint8_t)(t[0] + 128); /* the first byte is not a delta: make the loop below leave it */
#ifdef __SSE2__
    const __m128i bias = _mm_set1_epi8((char)0x80);
    __m128i carry = _mm_setzero_si128();
    for (; i + 16 <= n; i += 16) {
        __m128i d = _mm_sub_epi8(_mm_loadu_si128((const __m128i *)(const void *)(t + i)), bias);
        d = _mm_add_epi8(d, _mm_slli_si128(d, 1)); /* prefix sum in 4 steps */
        d = _mm_add_epi8(d, _mm_slli_si128(d, 2));
        d = _mm_add_epi8(d, _mm_slli_si128(d, 4));
        d = _mm_add_epi8(d, _mm_slli_si128(d, 8));
        /* byte 15 of the local sums in every lane: off the carry chain, since
         * broadcast(local + carry) = broadcast(local) + carry */
        __m128i last = _mm_shufflehi_epi16(d, 0xFF);                   /* word 7 in words 4-7 */
        last = _mm_srli_epi16(_mm_unpackhi_epi64(last, last), 8);        /* byte 15 in every word */
        last = _mm_or_si128(last, _mm_slli_epi16(last, 8));              /* ... and every byte */
        _mm_storeu_si128((__m128i *)(void *)(t + i), _mm_add_epi8(d, carry));
        carry = _mm_add_epi8(carry, last);
    }
    prev = (uint8_t)(_mm_cvtsi128_si32(carry) & 0xFF);
#endif
    for (; i < n; i++) {
        prev = (uint8_t)(prev + t[i] - 128);
        t[i] = prev;
    }
    const size_t h = (n + 1) / 2, pairs = n / 2;
    size_t k = 0;
#ifdef __SSE2__
    for (; k + 16 <= pairs; k += 16) {
        __m128i e = _mm_loadu_si128((const __m128i *)(const void *)(t + k));
        __m128i o = _mm_loadu_si128((const __m128i *)(const void *)(t + h + k));
        _mm_storeu_si128((__m128i *)(void *)(out + 2 * k), _mm_unpacklo_epi8(e, o));
        _mm_storeu_si128((__m128i *)(void *)(out + 2 * k + 16), _mm_unpackhi_epi8(e, o));
    }
#endif
    for (; k < pairs; k++) {
        out[2 * k] = t[k];
        out[2 * k + 1] = t[h + k];
    }
    if (n & 1) out[n - 1] = t[h - 1];
}

/* Reads a chunk and copies the selected channel's samples (little-endian in
 * the file) into dst (row stride X samples). */
static clvox_status fast_chunk(reader *r, const exr_chunk_info_t *ci, uint8_t *dst, uint64_t X)
{
    const uint32_t bytes = r->ch_bytes;
    const uint64_t w = (uint64_t)ci->width, h = (uint64_t)ci->height;
    const uint64_t n = w * h * r->pixel_bytes;
    if (ci->unpacked_size != n || ci->packed_size == 0 || ci->packed_size > n || n > (uint64_t)SIZE_MAX / 2)
        return clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s': chunk %d has inconsistent sizes (%llu packed, %llu unpacked)",
                           r->path, ci->idx, (unsigned long long)ci->packed_size,
                           (unsigned long long)ci->unpacked_size);
    if (!grow(&r->packed, &r->packed_size, (size_t)ci->packed_size))
        return clvox__fail(r->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", r->path);
    exr_result_t rv = exr_read_chunk(r->exr, 0, ci, r->packed);
    if (rv != EXR_ERR_SUCCESS) return exr_fail(r, rv, "reading a chunk of");
    const uint8_t *raw = r->packed;
    if (ci->packed_size < n) { /* compressed; equal sizes mean stored raw */
        if (r->compression != EXR_COMPRESSION_RLE) return CLVOX_ERR_INTERNAL;
        if (!grow(&r->tmp, &r->tmp_size, (size_t)n) || !grow(&r->raw, &r->raw_size, (size_t)n))
            return clvox__fail(r->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", r->path);
        if (rle_expand(r->tmp, (size_t)n, r->packed, (size_t)ci->packed_size) != 0)
            return clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s': chunk %d is corrupt (bad RLE data)", r->path, ci->idx);
        rle_reconstruct(r->raw, r->tmp, (size_t)n);
        raw = r->raw;
    }
    /* raw: per row, every channel in file order, ci->width samples each */
    const size_t row_bytes = (size_t)(w * r->pixel_bytes), off = (size_t)(w * r->ch_offset);
    const size_t len = (size_t)(w * bytes);
    const uint16_t one = 1;
    uint8_t little;
    memcpy(&little, &one, 1);
    for (uint64_t y = 0; y < h; y++) {
        const uint8_t *src = raw + (size_t)y * row_bytes + off;
        uint8_t *d = dst + (size_t)(y * X * bytes);
        if (little) {
            memcpy(d, src, len);
        } else {
            for (size_t i = 0; i < len; i += bytes)
                for (size_t j = 0; j < bytes; j++) d[i + j] = src[i + bytes - 1 - j];
        }
    }
    return CLVOX_OK;
}

/* Decodes one chunk's samples of the selected channel into the band (row stride X). */
static clvox_status decode_chunk(reader *r, exr_decode_pipeline_t *dec, int *initialized,
                                 const exr_chunk_info_t *ci, uint8_t *dst, uint64_t X)
{
    exr_result_t rv;
    if (r->fast) return fast_chunk(r, ci, dst, X);
    const uint32_t bytes = r->ch_bytes;
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
        if (strcmp(ch->channel_name, r->ch_name) == 0) {
            ch->decode_to_ptr = dst;
            ch->user_pixel_stride = (int32_t)bytes;
            ch->user_line_stride = (int32_t)(X * bytes);
            ch->user_bytes_per_element = (int16_t)bytes;
            ch->user_data_type = (uint16_t)r->ch_type;
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

/* Decodes channel `e` one row of chunks at a time, in increasing y, and hands
 * each band to `consume`. */
static clvox_status read_channel(reader *r, const clvox_volume_info *info, const exr_attr_chlist_entry_t *e,
                                 band_fn consume, void *user)
{
    clvox_status st = select_channel(r, e);
    if (st != CLVOX_OK) return st;
    exr_result_t rv;
    exr_storage_t storage;
    rv = exr_get_storage(r->exr, 0, &storage);
    if (rv != EXR_ERR_SUCCESS) return exr_fail(r, rv, "reading the storage type of");
    if (storage != EXR_STORAGE_SCANLINE && storage != EXR_STORAGE_TILED)
        return clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s': deep images are not clvox volumes", r->path);

    const uint64_t X = info->dims[0];
    const uint64_t H = (uint64_t)info->dims[1] * info->dims[2];
    const uint32_t bytes = r->ch_bytes;
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
                if ((uint64_t)ci.height != rows || (uint64_t)ci.width > X - x0 || ci.packed_size > r->file_size) {
                    st = clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s': tile (%d,%d) has an unexpected size %dx%d",
                                     r->path, tx, ty, ci.width, ci.height);
                    break;
                }
                st = decode_chunk(r, &dec, &initialized, &ci, band + x0 * bytes, X);
            }
        } else {
            rv = exr_read_scanline_chunk_info(r->exr, 0, dw.min.y + (int)row0, &ci);
            if (rv != EXR_ERR_SUCCESS) {
                st = exr_fail(r, rv, "locating a chunk of");
                break;
            }
            if ((uint64_t)ci.height != rows || (uint64_t)ci.width != X || ci.packed_size > r->file_size) {
                st = clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s': chunk at row %llu has an unexpected size %dx%d",
                                 r->path, (unsigned long long)row0, ci.width, ci.height);
                break;
            }
            st = decode_chunk(r, &dec, &initialized, &ci, band, X);
        }
        if (st == CLVOX_OK) st = consume(user, band, r->ch_type, row0, rows);
    }
    if (initialized) exr_decoding_destroy(r->exr, &dec);
    free(band);
    return st;
}

/* ---- opening ------------------------------------------------------------------- */

static void reader_close(reader *r)
{
    if (r->exr) exr_finish(&r->exr);
    if (r->fd >= 0) close(r->fd);
    r->fd = -1;
    free(r->packed);
    free(r->tmp);
    free(r->raw);
}

/* Opens `path` and reads its header into info (zeroed first). reader_close
 * afterwards in every case. */
static clvox_status reader_open(reader *r, clvox_context *ctx, const char *path, clvox_volume_info *info)
{
    memset(r, 0, sizeof *r);
    r->ctx = ctx;
    r->path = path;
    r->fd = -1;
    memset(info, 0, sizeof *info);

    /* Opened once, without blocking (a FIFO would block in open), and only a
     * regular file is read: the library reads through this descriptor. */
    struct stat sb;
    const char *why = NULL;
    r->fd = clvox__open_regular_read(path, &sb, &why);
    if (r->fd < 0) return clvox__fail(ctx, CLVOX_ERR_IO, "cannot read '%s': %s", path, why);
    r->file_size = (uint64_t)sb.st_size;

    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = reader_error_handler;
    init.user_data = r;
    init.read_fn = reader_read_fn;
    init.size_fn = reader_size_fn;
    init.flags = EXR_CONTEXT_FLAG_DISABLE_CHUNK_RECONSTRUCTION;
    exr_result_t rv = exr_start_read(&r->exr, path, &init);
    if (rv != EXR_ERR_SUCCESS) {
        clvox_status st = (rv == EXR_ERR_FILE_ACCESS) ? CLVOX_ERR_IO : CLVOX_ERR_EXR;
        /* a mesh given where a volume belongs: name the mix-up, not the magic number */
        if (st == CLVOX_ERR_EXR && clvox__is_mesh_path(path))
            return clvox__fail(ctx, st, "'%s' is a mesh, not a volume (an OpenEXR file written by clvox)", path);
        return clvox__fail(ctx, st, "'%s' is not a readable OpenEXR file: %s", path,
                           r->msg[0] ? r->msg : exr_get_default_error_message(rv));
    }
    return read_header(r, info);
}

clvox_status clvox_volume_read(clvox_context *ctx, const char *path, clvox_volume_info *info,
                               uint8_t *occupancy, size_t occupancy_size)
{
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!path || !*path) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_volume_read: no path");
    clvox_volume_info local;
    if (!info) info = &local;

    reader r;
    clvox_status st = reader_open(&r, ctx, path, info);
    const exr_attr_chlist_entry_t *occ = NULL, *cov = NULL, *elem = NULL;
    if (st == CLVOX_OK) {
        occ = find_channel(&r, "occupancy");
        cov = find_channel(&r, "coverage");
        elem = find_channel(&r, "element");
        if (!occ && !cov && !elem)
            st = clvox__fail(ctx, CLVOX_ERR_EXR,
                             "'%s' is not a clvox volume: no channel \"occupancy\", \"coverage\" or \"element\" "
                             "(has: %s)",
                             path, info->channels);
    }
    if (st == CLVOX_OK && occupancy) {
        uint64_t total = (uint64_t)info->dims[0] * info->dims[1] * info->dims[2];
        if (total > (uint64_t)SIZE_MAX || occupancy_size < (size_t)total)
            st = clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT,
                             "occupancy buffer holds %zu bytes, '%s' needs %u x %u x %u = %llu", occupancy_size, path,
                             info->dims[0], info->dims[1], info->dims[2], (unsigned long long)total);
    }
    coverage_sum sum = { 0, 0, 0.0 };
    count_state cs = { info->dims[0], occupancy, 0, NULL };
    if (st == CLVOX_OK) {
        /* Filled voxels from occupancy, else from coverage (summed in the
         * same pass), else from element (UINT > 0: element != 0). */
        if (!occ && cov) cs.sum = &sum;
        st = read_channel(&r, info, occ ? occ : cov ? cov : elem, count_band, &cs);
    }
    if (st == CLVOX_OK && occ && cov) {
        /* Both channels: a second pass over the file for the coverage sum. It
         * decodes every chunk again; one pass decoding two channels would be
         * faster but needs a band per channel and a two-channel consumer. */
        cs.sum = &sum;
        st = read_channel(&r, info, cov, sum_band, &cs);
    }
    if (st == CLVOX_OK) {
        info->filled_voxels = cs.filled;
        info->coverage_sum = cov ? sum_value(&sum) : 0.0;
    }
    reader_close(&r);
    return st;
}

clvox_status clvox_volume_read_slices(clvox_context *ctx, const char *path, const char *channel,
                                      clvox_volume_info *info, clvox_volume_slice_fn fn, void *user)
{
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!path || !*path) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_volume_read_slices: no path");
    if (!channel || !*channel)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_volume_read_slices: no channel name");
    if (!fn) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_volume_read_slices: no slice function");
    clvox_volume_info local;
    if (!info) info = &local;

    /* info gets the header only (filled_voxels and coverage_sum stay 0). It
     * is filled before the channel is looked up, so after a missing-channel
     * error info->channels says what the file has, and before the first call
     * of fn, which can size its buffers from info->dims (clvox preview relies
     * on both; the public header does not promise it yet). */
    reader r;
    clvox_status st = reader_open(&r, ctx, path, info);
    const exr_attr_chlist_entry_t *e = NULL;
    if (st == CLVOX_OK && !(e = find_channel(&r, channel)))
        st = clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' has no channel \"%s\" (has: %s)", path, channel, info->channels);
    float *slice = NULL;
    if (st == CLVOX_OK) {
        uint64_t n = (uint64_t)info->dims[0] * info->dims[1];
        if (n > (uint64_t)SIZE_MAX / sizeof *slice || !(slice = malloc((size_t)n * sizeof *slice)))
            st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for a %u x %u slice of '%s'", info->dims[0],
                             info->dims[1], path);
    }
    if (st == CLVOX_OK) {
        slice_state s = { &r, info->dims[0], info->dims[1], slice, fn, user };
        st = read_channel(&r, info, e, slice_band, &s);
    }
    free(slice);
    reader_close(&r);
    return st;
}

/* ---- the palette of a palette run ----------------------------------------------- */

clvox_status clvox_volume_palette(clvox_context *ctx, const char *path, clvox_palette **out)
{
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!out) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_volume_palette: out is NULL");
    *out = NULL;
    if (!path || !*path) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_volume_palette: no path");
    clvox_volume_info info;
    reader r;
    clvox_status st = reader_open(&r, ctx, path, &info);
    if (st != CLVOX_OK) {
        reader_close(&r);
        return st;
    }
    if (!info.palette[0] || !r.has_palette_hash) {
        reader_close(&r);
        return clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' has no palette: attribute %s is missing (not a palette run)",
                           path, info.palette[0] ? "clvoxPaletteHash" : "clvoxPalette");
    }
    const exr_attribute_t *a = NULL;
    exr_result_t rv = exr_get_attribute_by_name(r.exr, 0, "clvoxPaletteSource", &a);
    clvox_palette *p = NULL;
    char why[512];
    if (rv == EXR_ERR_NO_ATTR_BY_NAME) { /* a built-in palette, by name */
        st = clvox_palette_builtin(ctx, info.palette, &p);
        if (st != CLVOX_OK)
            st = clvox__fail(ctx, CLVOX_ERR_EXR,
                             "'%s': its palette \"%s\" is not a built-in palette, and the file has no "
                             "clvoxPaletteSource to rebuild it from",
                             path, info.palette);
    } else if (rv != EXR_ERR_SUCCESS || !a) {
        st = exr_fail(&r, rv, "reading the header of");
    } else if (a->type != EXR_ATTR_STRING || !a->string || a->string->length < 0 ||
               (a->string->length > 0 && !a->string->str)) {
        st = clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' is corrupt: attribute clvoxPaletteSource is not a string", path);
    } else {
        /* named so that the rebuilt palette gets the recorded name (the
         * parser drops the last extension) and messages say where the text is */
        char source[sizeof info.palette + 32];
        snprintf(source, sizeof source, "%s.clvoxPaletteSource", info.palette);
        st = clvox_palette_parse(ctx, source, a->string->str, (size_t)a->string->length, &p);
        if (st != CLVOX_OK) {
            snprintf(why, sizeof why, "%s", clvox_context_error(ctx));
            st = clvox__fail(ctx, CLVOX_ERR_EXR, "'%s': the palette text in its header is not a valid palette: %s",
                             path, why);
        }
    }
    reader_close(&r);
    if (st != CLVOX_OK) {
        clvox_palette_destroy(p);
        return st;
    }
    const uint64_t h = clvox_palette_hash(p);
    const size_t count = clvox_palette_count(p);
    if (h != info.palette_hash || (r.has_palette_count && count != info.palette_count)) {
        st = clvox__fail(ctx, CLVOX_ERR_EXR,
                         "'%s': palette \"%s\" rebuilt from its header (%zu elements, hash %016llx) is not the one the "
                         "file was written with (%u elements, hash %016llx)",
                         path, info.palette, count, (unsigned long long)h, info.palette_count,
                         (unsigned long long)info.palette_hash);
        clvox_palette_destroy(p);
        return st;
    }
    *out = p;
    return CLVOX_OK;
}
