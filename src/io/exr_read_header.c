/* SPDX-License-Identifier: Apache-2.0 */
/* The EXR reader's side of a file: opening it (read through our own
 * callbacks), reading and checking its header (the clvox* attributes, the
 * palette attributes of a palette run, what the file can hold) and looking
 * up its channels. */
#include "io/exr_reader.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

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

clvox_status clvox__exrr_fail(reader *r, exr_result_t rv, const char *what)
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
    if (rv != EXR_ERR_SUCCESS || !a) return clvox__exrr_fail(r, rv, "reading the header of");
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
        return clvox__exrr_fail(r, rv, "reading the header of");
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
    if (rv != EXR_ERR_SUCCESS || chunks <= 0) return clvox__exrr_fail(r, rv, "counting the chunks of");
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
 * image geometry. Channels are looked up afterwards (clvox__exrr_find_channel). */
static clvox_status read_header(reader *r, clvox_volume_info *info)
{
    exr_result_t rv;
    int parts = 0;
    rv = exr_get_count(r->exr, &parts);
    if (rv != EXR_ERR_SUCCESS || parts < 1) return clvox__exrr_fail(r, rv, "counting the parts of");

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
    if (rv != EXR_ERR_SUCCESS) return clvox__exrr_fail(r, rv, "reading the compression of");
    snprintf(info->compression, sizeof info->compression, "%s", compression_name(comp));

    const exr_attr_chlist_t *chl = NULL;
    rv = exr_get_channels(r->exr, 0, &chl);
    if (rv != EXR_ERR_SUCCESS || !chl) return clvox__exrr_fail(r, rv, "reading the channels of");
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
    if (rv != EXR_ERR_SUCCESS) return clvox__exrr_fail(r, rv, "reading the data window of");
    int64_t w = (int64_t)dw.max.x - dw.min.x + 1, hgt = (int64_t)dw.max.y - dw.min.y + 1;
    if (w != (int64_t)info->dims[0] || hgt != (int64_t)info->dims[1] * info->dims[2])
        return clvox__fail(r->ctx, CLVOX_ERR_EXR,
                           "'%s': data window %lld x %lld does not match clvoxDims %u x %u x %u (expected %u x %llu)",
                           r->path, (long long)w, (long long)hgt, info->dims[0], info->dims[1], info->dims[2],
                           info->dims[0], (unsigned long long)info->dims[1] * info->dims[2]);
    return check_size(r, info, (uint64_t)hgt);
}


const exr_attr_chlist_entry_t *clvox__exrr_find_channel(const reader *r, const char *name)
{
    size_t n = strlen(name);
    for (int c = 0; c < r->chl->num_channels; c++) {
        const exr_attr_chlist_entry_t *e = &r->chl->entries[c];
        if (e->name.length >= 0 && (size_t)e->name.length == n && memcmp(e->name.str, name, n) == 0) return e;
    }
    return NULL;
}


/* ---- opening ------------------------------------------------------------------- */

void clvox__exrr_close(reader *r)
{
    if (r->exr) exr_finish(&r->exr);
    if (r->fd >= 0) close(r->fd);
    r->fd = -1;
    free(r->packed);
    free(r->tmp);
    free(r->raw);
}

/* Opens `path` and reads its header into info (zeroed first). clvox__exrr_close
 * afterwards in every case. */
clvox_status clvox__exrr_open(reader *r, clvox_context *ctx, const char *path, clvox_volume_info *info)
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

