/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Streaming EXR writer: slabs of occupancy bits and/or coverage samples in,
 * one OpenEXR file out.
 *
 * File layout (attribute clvoxLayout says which variant was used)
 * ----------------------------------------------------------------
 *  - One part, tiled, ONE_LEVEL, ROUND_DOWN, lineOrder INCREASING_Y.
 *  - dataWindow = displayWindow = (0,0) - (X-1, Y*Z-1): an image X pixels
 *    wide and Y*Z rows tall in which the Z slices are stacked in increasing z.
 *    Voxel (x,y,z) is pixel (x, y + z*Y): x runs along an image row, y down
 *    the rows of one slice, z selects the slice. Reading the pixels in file
 *    order therefore gives the same x-fastest, then y, then z order as
 *    clvox_voxelize_to_memory.
 *  - B = bytes per voxel, all channels together (2 per HALF channel).
 *  - "tile-per-slice" (every grid with X*Y*B <= CLVOX__EXR_CHUNK_BYTES,
 *    i.e. slices up to 2048 x 2048 for one channel, 1448 x 1448 for two):
 *    the tile size is X x Y, so tile (0, z) is exactly slice z and the file
 *    holds one chunk per slice.
 *  - "row-chunks" (larger slices): the tile size is X x T with
 *    T = CLVOX__EXR_CHUNK_BYTES / (B*X) rows; tile (0, r) covers image rows
 *    r*T .. r*T+T-1 (the last one may be shorter) and may span two slices.
 *    The writer carries the rows of an incomplete chunk over to the next slab.
 *  - Memory: OpenEXRCore keeps the chunk offset table (8 bytes per chunk) until
 *    the file is complete, i.e. 8 bytes per slice for tile-per-slice and at
 *    most 8*X*Y*Z*B / CLVOX__EXR_CHUNK_BYTES bytes in all for row-chunks.
 *    Everything else is bounded by the chunk size times the number of
 *    encoder slots (threads + 2), whatever Z is.
 *  - Channels: those the writer was opened with (CLVOX_CHANNEL_* mask, any
 *    non-empty subset), in one part, in name order as EXR requires:
 *    "coverage" HALF (the caller's HALF bits, stored as given), "element"
 *    UINT (the caller's uint16 palette indices, widened to 32 bits),
 *    "occupancy" HALF 0.0 (outside) or 1.0 (inside) (the caller gives bits),
 *    "score" HALF (the caller's HALF bits). The channel table below lists
 *    them; everything else walks the writer's list of channels.
 *  - Attributes: clvoxDims (v3i X,Y,Z), clvoxOrigin (v3d, corner of voxel
 *    (0,0,0)), clvoxVoxelSize (v3d), clvoxMethod, clvoxParameters,
 *    clvoxVersion, clvoxLayout (strings); palette runs (meta->palette) add
 *    clvoxPalette (its name), clvoxPaletteCount (int), clvoxPaletteHash (16
 *    lower-case hex digits of clvox_palette_hash), clvoxPaletteSource (the
 *    palette file's text; user palettes only, built-ins are rebuilt by name)
 *    and clvoxMetric (strings). A string attribute holds up to INT32_MAX - 1
 *    bytes (OpenEXRCore; checked at open, before any file is made).
 *  - Limits: Y*Z <= 2^31-1 (EXR coordinates are int32), else CLVOX_ERR_GRID.
 *
 * Writing
 * -------
 * The file is created in clvox__exr_open (so a missing or unwritable
 * directory fails before any compute work) in the directory of `path`, and
 * written through our own write callback, so OpenEXRCore never opens,
 * truncates or deletes files itself (src/core/outfile.c):
 *  - Linux: open(dir, O_TMPFILE), a file without a name: no exit, crash or
 *    kill -9 can leave it behind. clvox__exr_finish, after checking that
 *    every chunk was written and exr_finish succeeded, links it to `path`
 *    (linkat through /proc/self/fd) when nothing is there, else to a short
 *    unique name in the directory that is renamed over `path` at once.
 *  - Where the file system has no O_TMPFILE (EOPNOTSUPP, EISDIR, EINVAL) or
 *    /proc is missing: a named temporary ".clvox-<pid>-<n>.tmp" (O_EXCL; short,
 *    so every valid output name works), renamed to `path` by finish and
 *    unlinked on every other exit; only a kill -9 can leave it.
 * Only regular files are replaced: anything else at `path` (directory,
 * symbolic link, device node, FIFO, socket) is refused in open and again just
 * before the rename; a symbolic link is neither replaced nor written through.
 *
 * Encoding runs in `threads` worker threads (0 = online CPUs), each chunk in
 * one of threads+2 ring slots; the calling thread writes the finished chunks
 * strictly in order with exr_write_tile_chunk (packed data), then returns when
 * the whole slab is in the file. The input is occupancy bits (the slab format
 * of internal.h), coverage and score HALF bits and uint16 element indices
 * (X*Y per slice). A chunk is "packed" as the file stores it uncompressed:
 * per image row, each channel's X samples in file order (bits expanded to
 * HALF, indices widened to UINT); coverage or score alone needs no copy.
 * Per compression:
 *  - RLE (the default): clvox's own encoders, same format as OpenEXR's.
 *    Occupancy alone: straight from the bits (rle_encode_bits: the tokens
 *    follow from where a bit changes; no HALF sample is ever made). Any
 *    other channel set: from the packed chunk (rle_encode_packed, which
 *    skips runs of equal bytes 32 input bytes at a time). EXR's RLE splits
 *    the chunk's bytes into even and odd ones whatever the sample size, so
 *    a UINT element e in 1..255 alternates e, 0 in the even half: a run of
 *    a non-zero element is about 2 bytes per voxel there (zeros, element 0,
 *    compress like any run; ZIP compresses both).
 *  - NONE: the packed chunk.
 *  - ZIP, ZIPS, PIZ: the chunk packed in host order, each channel of
 *    OpenEXRCore's encode pipeline pointed at its part of the packed rows,
 *    then exr_encoding_run with its write step removed. ZIP and ZIPS
 *    use zlib level CLVOX__EXR_ZIP_LEVEL; in a tiled file both compress a
 *    whole tile, so they are the same.
 *  - Any chunk that does not shrink is stored raw (see
 *    store_raw_if_not_smaller for the OpenEXRCore 3.1.5 bug this avoids).
 * Measured with scripts/bench/bench_writer.c (a sphere, the writer alone, wall
 * seconds including the fdatasync, 1 thread / 2 threads; 2-core VM shared
 * with other jobs, so the figures vary by 20 % or more):
 *   512^3:  NONE 0.52 / 0.64 s 268 MB (mostly the fdatasync of 268 MB);
 *           RLE 0.031 / 0.038 s 5.0 MB; ZIP level 1 0.95 / 0.58 s 1.8 MB;
 *           PIZ 1.05 / 0.70 s 1.3 MB
 *   1024^3: NONE 7.2 / 4.9 s (I/O) 2.1 GB; RLE 0.19 / 0.19 s 37 MB;
 *           ZIP level 1 7.6 / 3.9 s 13 MB; PIZ 8.0 / 5.0 s 7.7 MB
 * (RLE from HALF samples, before the bits: 0.036 s at 512^3, 0.26 s at 1024^3;
 * OpenEXRCore's own RLE encoder 0.44 s and 3.0 s.)
 * The sphere's coverage (grey shell) at 512^3, 1 / 2 threads: coverage alone
 *   NONE 0.12 / 0.17 s 268 MB; RLE 0.038 / 0.038 s 6.8 MB (OpenEXRCore's RLE
 *   0.38 / 0.25 s); ZIP 0.56 / 0.31 s 4.1 MB; PIZ 0.49 / 0.29 s 3.9 MB;
 *   with occupancy: NONE 0.29 / 0.32 s 537 MB; RLE 0.11 / 0.08 s 11.8 MB
 *   (mostly packing the chunk); ZIP 1.1 / 0.60 s 6.3 MB; PIZ 0.91 / 0.58 s.
 * Library messages go to our error handler, never to stderr. The file is
 * fdatasync'ed before the rename.
 * Files: this one (the channel table, open, slabs, finish, abort and the
 * entry of output.c's format table), exr_write_header.c (the header and its
 * attributes), exr_write_encode.c (packing and compressing a chunk: the RLE
 * encoders, OpenEXRCore's for ZIP and PIZ), exr_write_pool.c (the encoder
 * threads, the in-order chunk writes, the rows carried between slabs);
 * exr_writer.h holds the state they share.
 */
#if defined(__linux__) && !defined(_GNU_SOURCE)
#define _GNU_SOURCE /* O_TMPFILE, AT_EMPTY_PATH */
#endif
#include "io/exr_writer.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

/* ---- channel table ---- */

static const void *plane_occupancy(const clvox__slab_planes *p) { return p->occupancy_bits; }
static const void *plane_coverage(const clvox__slab_planes *p) { return p->coverage_half; }
static const void *plane_element(const clvox__slab_planes *p) { return p->element; }
static const void *plane_score(const clvox__slab_planes *p) { return p->score_half; }

/* Every channel clvox can write; a writer keeps those it was opened with, in
 * file order (sorted by name, as EXR requires). Add entries here (and a
 * plane in clvox__slab_planes) to store more per-voxel values. Everything
 * else walks the writer's list. */
static const exr_channel_def channel_table[] = {
    { "coverage", CLVOX_CHANNEL_COVERAGE, EXR_PIXEL_HALF, 2, 2, 0, plane_coverage },
    { "element", CLVOX_CHANNEL_ELEMENT, EXR_PIXEL_UINT, 4, 2, 0, plane_element },
    { "occupancy", CLVOX_CHANNEL_OCCUPANCY, EXR_PIXEL_HALF, 2, 0, 1, plane_occupancy },
    { "score", CLVOX_CHANNEL_SCORE, EXR_PIXEL_HALF, 2, 2, 0, plane_score },
};
#define CHANNEL_TABLE_SIZE (sizeof channel_table / sizeof channel_table[0])
_Static_assert(CHANNEL_TABLE_SIZE <= CLVOX__EXR_MAX_CHANNELS, "too many EXR channels");

/* ---- writer ---- */

static void writer_error_handler(exr_const_context_t ectx, exr_result_t code, const char *msg)
{
    void *ud = NULL;
    if (!ectx || exr_get_user_data(ectx, &ud) != EXR_ERR_SUCCESS || !ud) return;
    clvox__exr_writer *w = ud;
    pthread_mutex_lock(&w->mu);
    if (!w->exr_msg[0])
        snprintf(w->exr_msg, sizeof w->exr_msg, "%s", msg ? msg : exr_get_default_error_message(code));
    pthread_mutex_unlock(&w->mu);
}

static int64_t writer_write_fn(exr_const_context_t ectx, void *ud, const void *buffer, uint64_t size,
                               uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
    clvox__exr_writer *w = ud;
    const uint8_t *p = buffer;
    uint64_t left = size;
    while (left > 0) {
        size_t n = left > (1u << 30) ? (1u << 30) : (size_t)left;
        ssize_t got = pwrite(w->of.fd, p, n, (off_t)offset);
        if (got < 0 && errno == EINTR) continue;
        if (got <= 0) {
            int e = got < 0 ? errno : EIO;
            pthread_mutex_lock(&w->mu);
            if (!w->io_errno) w->io_errno = e;
            pthread_mutex_unlock(&w->mu);
            if (error_cb) error_cb(ectx, EXR_ERR_WRITE_IO, "write to '%s' failed: %s", w->path, strerror(e));
            return -1;
        }
        p += got;
        offset += (uint64_t)got;
        left -= (uint64_t)got;
    }
    return (int64_t)size;
}

/* "OpenEXR: <what>: <library message or default message for rv>" */
clvox_status clvox__exrw_fail(clvox__exr_writer *w, exr_result_t rv, const char *what)
{
    char msg[512];
    int io = 0;
    pthread_mutex_lock(&w->mu);
    snprintf(msg, sizeof msg, "%s", w->exr_msg[0] ? w->exr_msg : exr_get_default_error_message(rv));
    io = w->io_errno;
    pthread_mutex_unlock(&w->mu);
    return clvox__fail(w->ctx, io ? CLVOX_ERR_IO : CLVOX_ERR_EXR, "OpenEXR: %s '%s': %s", what, w->path, msg);
}

static int host_little_endian(void)
{
    const uint16_t one = 1;
    uint8_t b;
    memcpy(&b, &one, 1);
    return b == 1;
}

/* Frees everything; unlinks the temporary file unless it was renamed. */
static void writer_free(clvox__exr_writer *w)
{
    if (!w) return;
    clvox__exrw_stop_pool(w);
    if (w->exr) {
        clvox__exrw_release_slots(w);
        exr_finish(&w->exr); /* our write_fn: nothing is deleted or renamed by the library */
    }
    free(w->slots);
    clvox__outfile_discard(&w->of);
    for (size_t t = 0; t < CLVOX__EXR_MAX_CHANNELS; t++) free(w->carry[t]);
    free(w->threads);
    if (w->mu_ready) {
        pthread_cond_destroy(&w->done_cv);
        pthread_cond_destroy(&w->work_cv);
        pthread_mutex_destroy(&w->mu);
    }
    free(w->path);
    free(w);
}

/* An uncompressed file has a known size: refuse it up front when the file
 * system cannot hold it, instead of failing after minutes of work. (For
 * compressed files the size is unknown; a write error is caught per chunk.) */
static clvox_status check_disk_space(clvox__exr_writer *w)
{
    if (w->compression != EXR_COMPRESSION_NONE) return CLVOX_OK;
    struct statvfs vfs;
    if (fstatvfs(w->of.fd, &vfs) != 0) return CLVOX_OK; /* unknown: let the writes tell */
    uint64_t need = (uint64_t)w->dims[0] * w->dims[1] * w->dims[2] * w->pixel_bytes + 8ull * (uint64_t)w->chunk_count;
    uint64_t avail = (uint64_t)vfs.f_bavail * (uint64_t)(vfs.f_frsize ? vfs.f_frsize : vfs.f_bsize);
    if (need <= avail) return CLVOX_OK;
    char need_s[32], avail_s[32];
    clvox__format_size(need, need_s, sizeof need_s);
    clvox__format_size(avail, avail_s, sizeof avail_s);
    return clvox__fail(w->ctx, CLVOX_ERR_IO,
                       "not enough disk space for '%s': the uncompressed volume needs %s, %s are free "
                       "(compressed output, rle by default, is far smaller)",
                       w->path, need_s, avail_s);
}

static unsigned online_cpus(void)
{
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n < 1 ? 1u : (unsigned)n;
}

clvox_status clvox__exr_open(clvox_context *ctx, const char *path, const clvox_grid *grid,
                             const clvox__exr_meta *meta, uint32_t channels, clvox_compression compression,
                             uint32_t threads, clvox__exr_writer **out)
{
    if (out) *out = NULL;
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    /* The default: RLE, fastest to write; ZIP when there is an element
     * channel, which RLE cannot shrink (a UINT index splits into e, 0, e, 0
     * ... bytes that never run: about 2 bytes per voxel, 9x the ZIP file). */
    if (compression == CLVOX_COMPRESSION_DEFAULT)
        compression = (channels & CLVOX_CHANNEL_ELEMENT) ? CLVOX_COMPRESSION_ZIP : CLVOX_COMPRESSION_RLE;
    if (!path || !*path || !grid || !out)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox__exr_open: missing path, grid or output");
    if (channels == 0) channels = CLVOX_CHANNEL_OCCUPANCY;
    uint32_t known = 0;
    for (size_t t = 0; t < CHANNEL_TABLE_SIZE; t++) known |= channel_table[t].mask;
    if (channels & ~known)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT,
                           "clvox__exr_open: channels 0x%x: the EXR writer knows occupancy (0x%x), coverage (0x%x), "
                           "element (0x%x) and score (0x%x)",
                           channels, CLVOX_CHANNEL_OCCUPANCY, CLVOX_CHANNEL_COVERAGE, CLVOX_CHANNEL_ELEMENT,
                           CLVOX_CHANNEL_SCORE);
    clvox_status st = clvox__exrw_check_meta(ctx, path, meta);
    if (st != CLVOX_OK) return st;
    if ((unsigned)compression >= CLVOX_COMPRESSION_COUNT)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "unknown compression %d", (int)compression);
    const uint32_t X = grid->dims[0], Y = grid->dims[1], Z = grid->dims[2];
    if (X == 0 || Y == 0 || Z == 0)
        return clvox__fail(ctx, CLVOX_ERR_GRID, "grid %ux%ux%u has no voxels", X, Y, Z);
    if ((uint64_t)Y * Z > (uint64_t)INT32_MAX || X > (uint32_t)INT32_MAX)
        return clvox__fail(ctx, CLVOX_ERR_GRID,
                           "grid %ux%ux%u does not fit in an EXR image: Y*Z = %llu rows (at most 2^31-1)", X, Y, Z,
                           (unsigned long long)Y * Z);
    st = clvox__outfile_check_target(ctx, path);
    if (st != CLVOX_OK) return st;

    clvox__exr_writer *w = calloc(1, sizeof *w);
    if (!w) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    w->ctx = ctx;
    w->of.fd = -1;
    w->dims[0] = X;
    w->dims[1] = Y;
    w->dims[2] = Z;
    w->height = (int32_t)((uint64_t)Y * Z);
    w->compression = clvox__exrw_compression(compression);
    w->little_endian = host_little_endian();
    w->channels = channels;
    for (size_t t = 0; t < CHANNEL_TABLE_SIZE; t++) { /* insertion sort by name: the file's channel order */
        if (!(channels & channel_table[t].mask)) continue;
        size_t k = w->nch++;
        while (k > 0 && strcmp(w->ch[k - 1]->name, channel_table[t].name) > 0) {
            w->ch[k] = w->ch[k - 1];
            k--;
        }
        w->ch[k] = &channel_table[t];
        w->pixel_bytes += channel_table[t].bytes;
    }
    uint64_t row_bytes = (uint64_t)X * w->pixel_bytes;
    uint64_t slice_bytes = row_bytes * Y;
    if (slice_bytes <= CLVOX__EXR_CHUNK_BYTES) {
        w->tile_h = (int32_t)Y;
    } else {
        uint64_t t = CLVOX__EXR_CHUNK_BYTES / row_bytes;
        w->tile_h = (int32_t)(t < 1 ? 1 : t);
    }
    w->chunk_count = (int32_t)(((uint64_t)w->height + (uint64_t)w->tile_h - 1) / (uint64_t)w->tile_h);
    if (pthread_mutex_init(&w->mu, NULL) != 0) {
        free(w);
        return clvox__fail(ctx, CLVOX_ERR_INTERNAL, "pthread_mutex_init failed");
    }
    pthread_cond_init(&w->work_cv, NULL);
    pthread_cond_init(&w->done_cv, NULL);
    w->mu_ready = 1;
    w->path = strdup(path);
    if (!w->path) {
        writer_free(w);
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    }
    if (w->tile_h != (int32_t)Y) {
        for (size_t t = 0; t < w->nch; t++) {
            w->carry[t] = malloc(source_row_bytes(w, t) * (size_t)w->tile_h);
            if (!w->carry[t]) {
                writer_free(w);
                return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for the EXR row buffer");
            }
        }
    }

    st = clvox__outfile_create(&w->of, ctx, path);
    if (st == CLVOX_OK) st = check_disk_space(w);
    if (st != CLVOX_OK) {
        writer_free(w);
        return st;
    }

    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = writer_error_handler;
    init.user_data = w;
    init.write_fn = writer_write_fn;
    exr_result_t rv = exr_start_write(&w->exr, w->path, EXR_WRITE_FILE_DIRECTLY, &init); /* the name: for messages only */
    if (rv != EXR_ERR_SUCCESS) {
        w->exr = NULL;
        st = clvox__exrw_fail(w, rv, "starting to write");
        writer_free(w);
        return st;
    }
    st = clvox__exrw_define_header(w, grid, meta, compression);
    if (st != CLVOX_OK) {
        writer_free(w);
        return st;
    }

    unsigned n = threads ? threads : online_cpus();
    if (w->compression == EXR_COMPRESSION_NONE && chunk_is_source(w, 0))
        n = 1; /* nothing to compute: chunks are the caller's data */
    if (n > CLVOX__EXR_MAX_THREADS) n = CLVOX__EXR_MAX_THREADS;
    if ((uint32_t)n > (uint32_t)w->chunk_count) n = (unsigned)w->chunk_count;
    w->thread_count = n;
    w->slot_count = n > 1 ? n + 2 : 1;
    w->slots = calloc(w->slot_count, sizeof *w->slots);
    if (!w->slots) {
        writer_free(w);
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    }
    if (n > 1) {
        w->threads = calloc(n, sizeof *w->threads);
        if (!w->threads) {
            writer_free(w);
            return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
        }
        for (unsigned i = 0; i < n; i++) {
            if (pthread_create(&w->threads[i], NULL, clvox__exrw_worker_main, w) != 0) break;
            w->threads_started++;
        }
        /* Fewer threads than asked still works; none means the inline path. */
    }
    *out = w;
    return CLVOX_OK;
}

clvox_status clvox__exr_write_slab(clvox__exr_writer *w, uint32_t z0, uint32_t nz, const clvox__slab_planes *planes)
{
    if (!w) return CLVOX_ERR_INVALID_ARGUMENT;
    if (w->failed)
        return clvox__fail(w->ctx, w->fail_status, "EXR writer for '%s' already failed", w->path);
    if (nz == 0 || z0 != w->next_z || nz > w->dims[2] - z0) {
        w->failed = 1;
        w->fail_status = CLVOX_ERR_INTERNAL;
        return clvox__fail(w->ctx, CLVOX_ERR_INTERNAL, "EXR slab z0=%u nz=%u out of order (expected z0=%u, Z=%u)",
                           z0, nz, w->next_z, w->dims[2]);
    }
    /* Exactly the planes of the writer's channels. */
    for (size_t t = 0; t < CHANNEL_TABLE_SIZE; t++) {
        const exr_channel_def *def = &channel_table[t];
        int given = planes && def->plane(planes), wanted = (w->channels & def->mask) != 0;
        if (given != wanted) {
            w->failed = 1;
            w->fail_status = CLVOX_ERR_INVALID_ARGUMENT;
            return clvox__fail(w->ctx, CLVOX_ERR_INVALID_ARGUMENT,
                               "EXR slab z0=%u: the %s plane is %s (the writer for '%s' was opened %s it)", z0,
                               def->name, given ? "given" : "missing", w->path, wanted ? "with" : "without");
        }
    }
    const uint8_t *data[CLVOX__EXR_MAX_CHANNELS];
    for (size_t t = 0; t < w->nch; t++) data[t] = w->ch[t]->plane(planes);
    uint64_t Y = w->dims[1];
    clvox_status st = clvox__exrw_write_rows(w, (uint64_t)z0 * Y, (uint64_t)nz * Y, data);
    if (st != CLVOX_OK) {
        w->failed = 1;
        w->fail_status = st;
        return st;
    }
    w->next_z = z0 + nz;
    w->next_row = (uint64_t)w->next_z * Y;
    return CLVOX_OK;
}

clvox_status clvox__exr_finish(clvox__exr_writer *w, uint64_t *bytes)
{
    if (bytes) *bytes = 0;
    if (!w) return CLVOX_ERR_INVALID_ARGUMENT;
    clvox_context *ctx = w->ctx;
    clvox_status st = CLVOX_OK;
    if (w->failed) {
        st = clvox__fail(ctx, w->fail_status, "EXR writer for '%s' failed earlier; no file written", w->path);
        writer_free(w);
        return st;
    }
    if (w->next_z != w->dims[2]) {
        st = clvox__fail(ctx, CLVOX_ERR_INTERNAL, "EXR '%s': only %u of %u slices were written; no file written",
                         w->path, w->next_z, w->dims[2]);
        writer_free(w);
        return st;
    }
    clvox__exrw_stop_pool(w);
    clvox__exrw_release_slots(w);
    exr_result_t rv = exr_finish(&w->exr);
    w->exr = NULL;
    if (rv != EXR_ERR_SUCCESS) {
        st = clvox__exrw_fail(w, rv, "finishing");
        writer_free(w);
        return st;
    }
    pthread_mutex_lock(&w->mu);
    int io = w->io_errno;
    pthread_mutex_unlock(&w->mu);
    if (io) {
        st = clvox__fail(ctx, CLVOX_ERR_IO, "writing '%s' failed: %s", w->path, strerror(io));
        writer_free(w);
        return st;
    }
    st = clvox__outfile_finish(&w->of, bytes); /* syncs, names it `path`; or removes it */
    writer_free(w);
    return st;
}

void clvox__exr_abort(clvox__exr_writer *w)
{
    writer_free(w);
}

/* ---- the entry of output.c's format table ---- */

static clvox_status fmt_open(clvox_context *ctx, const clvox__fmt_info *info, void **state)
{
    clvox__exr_meta meta = {info->method, info->parameters, info->palette, info->metric};
    clvox__exr_writer *w = NULL;
    clvox_status st = clvox__exr_open(ctx, info->path, info->grid, &meta, info->channels, info->compression,
                                      info->threads, &w);
    *state = w;
    return st;
}

static clvox_status fmt_write(void *state, const clvox__fmt_slab *s)
{
    clvox__slab_planes p = {s->occupancy_bits, s->coverage_half, s->element, s->score_half};
    return clvox__exr_write_slab(state, s->z0, s->nz, &p);
}

static clvox_status fmt_finish(void *state, uint64_t *bytes) { return clvox__exr_finish(state, bytes); }
static void fmt_abort(void *state) { clvox__exr_abort(state); }

/* Every channel in one file, but the slice writer (clvox convert) gives one
 * at a time (one_channel 0); coverage and score go in as the device's HALF
 * bits (half_bits 1). */
const clvox__fmt_ops clvox__fmt_exr = {
    "EXR", CLVOX_CHANNEL_OCCUPANCY | CLVOX_CHANNEL_COVERAGE | CLVOX_CHANNEL_ELEMENT | CLVOX_CHANNEL_SCORE, 0, 1,
    fmt_open, fmt_write, fmt_finish, fmt_abort};

