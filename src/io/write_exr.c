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
 * Measured with scripts/bench_writer.c (a sphere, the writer alone, wall
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
 */
#if defined(__linux__) && !defined(_GNU_SOURCE)
#define _GNU_SOURCE /* O_TMPFILE, AT_EMPTY_PATH */
#endif
#include "core/internal.h"

#include <OpenEXR/openexr.h>

#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

/* Largest uncompressed chunk: slices up to this size are one tile each. */
#ifndef CLVOX__EXR_CHUNK_BYTES
#define CLVOX__EXR_CHUNK_BYTES (8u << 20)
#endif
/* zlib level for ZIP / ZIPS (1: fastest; OpenEXR's default is zlib's 6). */
#ifndef CLVOX__EXR_ZIP_LEVEL
#define CLVOX__EXR_ZIP_LEVEL 1
#endif
#define CLVOX__EXR_MAX_THREADS 64u
#define CLVOX__EXR_MAX_CHANNELS 4

/* ---- channel table ---- */

typedef struct exr_channel_def {
    const char *name;
    uint32_t mask;  /* CLVOX_CHANNEL_* */
    exr_pixel_type_t type;
    uint32_t bytes; /* per sample in the file */
    uint32_t src_bytes; /* per sample as the caller gives it (bytes < src_bytes never; bytes > src_bytes:
                           widened, a uint16 index stored as UINT) */
    int bits;       /* the caller gives bit rows (clvox__row_words words per row, bit 1 = 1.0), not samples */
    const void *(*plane)(const clvox__slab_planes *p); /* the caller's data for one slab */
} exr_channel_def;

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

enum { SLOT_FREE = 0, SLOT_BUSY, SLOT_DONE };

typedef struct exr_slot {
    int state;
    int initialized;            /* pipe went through exr_encoding_initialize */
    int32_t chunk;              /* tile row index being encoded */
    exr_result_t rv;
    exr_encode_pipeline_t pipe; /* owns the packed/compressed buffers */
    const void *out;            /* what to write: pipe.compressed_buffer or raw */
    uint64_t out_bytes;
    uint8_t *raw, *comp; /* packed samples, RLE output */
    size_t raw_size, comp_size;
} exr_slot;

struct clvox__exr_writer {
    clvox_context *ctx;
    exr_context_t exr;
    char *path;
    clvox__outfile of; /* the file being written (outfile.c) */
    uint32_t dims[3];
    int32_t height;       /* Y*Z image rows */
    int32_t tile_h;       /* rows per chunk */
    int32_t chunk_count;
    exr_compression_t compression;
    int little_endian;
    uint32_t channels;    /* CLVOX_CHANNEL_* mask */
    const exr_channel_def *ch[CLVOX__EXR_MAX_CHANNELS]; /* this file's channels, in file (name) order */
    size_t nch;
    uint32_t pixel_bytes; /* all channels' bytes per voxel in the file */
    uint64_t next_row;    /* image rows received so far */
    uint32_t next_z;      /* next slice expected */
    int failed;           /* a slab failed: only abort is possible */
    clvox_status fail_status;

    /* source of the current slab per channel of ch[] (read by workers) */
    const uint8_t *src[CLVOX__EXR_MAX_CHANNELS];
    uint64_t src_row0;
    /* rows of the chunk that straddles two slabs (row-chunks only) */
    uint8_t *carry[CLVOX__EXR_MAX_CHANNELS];
    uint64_t carry_row0; /* image row of carry[][0] */
    int32_t carry_rows;

    /* worker pool; slots[] also serves the single-threaded path */
    unsigned thread_count, threads_started;
    pthread_t *threads;
    exr_slot *slots;
    unsigned slot_count;
    pthread_mutex_t mu;
    pthread_cond_t work_cv, done_cv;
    int mu_ready;
    int quit;
    int32_t job_next, job_end;
    unsigned busy;

    /* errors from OpenEXRCore callbacks (any thread; guarded by mu) */
    char exr_msg[512];
    int io_errno;
};

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
static clvox_status exr_fail(clvox__exr_writer *w, exr_result_t rv, const char *what)
{
    char msg[512];
    int io = 0;
    pthread_mutex_lock(&w->mu);
    snprintf(msg, sizeof msg, "%s", w->exr_msg[0] ? w->exr_msg : exr_get_default_error_message(rv));
    io = w->io_errno;
    pthread_mutex_unlock(&w->mu);
    return clvox__fail(w->ctx, io ? CLVOX_ERR_IO : CLVOX_ERR_EXR, "OpenEXR: %s '%s': %s", what, w->path, msg);
}

static exr_compression_t map_compression(clvox_compression c)
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

static int host_little_endian(void)
{
    const uint16_t one = 1;
    uint8_t b;
    memcpy(&b, &one, 1);
    return b == 1;
}

static int grow(uint8_t **buf, size_t *size, size_t need)
{
    if (*size >= need) return 1;
    uint8_t *p = realloc(*buf, need);
    if (!p) return 0;
    *buf = p;
    *size = need;
    return 1;
}

/* Bytes of one image row of the writer's channel t as the caller gives it. */
static size_t source_row_bytes(const clvox__exr_writer *w, size_t t)
{
    if (w->ch[t]->bits) return (size_t)clvox__row_words(w->dims[0]) * 4;
    return (size_t)w->dims[0] * w->ch[t]->src_bytes;
}

/* Channel t's data for image row `row` of the current slab (or of the
 * carried-over rows of a chunk begun by the previous slab: such a chunk is
 * whole in carry[], so the rows of one chunk are always contiguous). */
static const uint8_t *channel_rows(const clvox__exr_writer *w, size_t t, uint64_t row)
{
    uint64_t rb = source_row_bytes(w, t);
    if (row < w->src_row0) return w->carry[t] + (size_t)((row - w->carry_row0) * rb);
    return w->src[t] + (size_t)((row - w->src_row0) * rb);
}

/* Bit rows -> HALF 0.0 / 1.0 samples in host order, 8 at a time from a table
 * (a byte of bits -> 16 bytes of samples). */
static uint16_t expand_table[256][8];
static pthread_once_t expand_once = PTHREAD_ONCE_INIT;

static void expand_init(void)
{
    for (unsigned b = 0; b < 256; b++)
        for (unsigned i = 0; i < 8; i++) expand_table[b][i] = (b >> i) & 1u ? 0x3C00 : 0x0000;
}

static void expand_bits_row(uint16_t *dst, const uint32_t *bits, size_t X)
{
    size_t x = 0;
    for (; x + 32 <= X; x += 32) {
        uint32_t v = bits[x / 32];
        for (unsigned k = 0; k < 4; k++) memcpy(dst + x + 8 * k, expand_table[(v >> (8 * k)) & 0xFFu], 16);
    }
    for (; x < X; x++) dst[x] = (bits[x / 32] >> (x % 32)) & 1u ? 0x3C00 : 0x0000;
}

/* Element indices (uint16 from the caller) as the file's UINT samples: in
 * host order (native), else little-endian. dst need not be 4-byte aligned
 * (a HALF channel before it in an odd-width row). */
static void widen_row(uint8_t *dst, const uint8_t *src, size_t X, int native, int little_endian)
{
    const uint16_t *in = (const uint16_t *)(const void *)src;
    if (native || little_endian) {
        for (size_t x = 0; x < X; x++) {
            uint32_t v = in[x];
            memcpy(dst + 4 * x, &v, 4);
        }
    } else {
        for (size_t x = 0; x < X; x++) {
            dst[4 * x] = (uint8_t)(in[x] & 0xFFu);
            dst[4 * x + 1] = (uint8_t)(in[x] >> 8);
            dst[4 * x + 2] = dst[4 * x + 3] = 0;
        }
    }
}

/* A chunk of a single sample channel, stored as given, in that byte order
 * is the caller's data itself (see packed_chunk). */
static int chunk_is_source(const clvox__exr_writer *w, int native)
{
    return w->nch == 1 && !w->ch[0]->bits && w->ch[0]->bytes == w->ch[0]->src_bytes &&
           (w->ch[0]->bytes == 1 || native || w->little_endian);
}

/* The uncompressed chunk: per image row, each channel in file (name-sorted)
 * order, as samples (bit channels expanded, uint16 indices widened to
 * UINT); little-endian as the file
 * stores it, or in host order with `native` (what OpenEXRCore's encoder
 * reads). A single sample channel already in that order is the caller's
 * data itself: no copy. Either way image row y of the chunk starts at
 * (*out)[y * X * pixel_bytes]. */
static exr_result_t packed_chunk(clvox__exr_writer *w, exr_slot *s, uint64_t row0, uint32_t rows, int native,
                                 const uint8_t **out)
{
    const size_t X = w->dims[0];
    if (chunk_is_source(w, native)) {
        *out = channel_rows(w, 0, row0);
        return EXR_ERR_SUCCESS;
    }
    if (!grow(&s->raw, &s->raw_size, (size_t)rows * X * w->pixel_bytes)) return EXR_ERR_OUT_OF_MEMORY;
    uint8_t *dst = s->raw;
    for (uint32_t y = 0; y < rows; y++) {
        for (size_t t = 0; t < w->nch; t++) {
            size_t b = w->ch[t]->bytes, n = X * b;
            const uint8_t *src = channel_rows(w, t, row0 + y);
            if (w->ch[t]->bits) { /* HALF 0.0 / 1.0 */
                pthread_once(&expand_once, expand_init);
                expand_bits_row((uint16_t *)(void *)dst, (const uint32_t *)(const void *)src, X);
                if (!native && !w->little_endian)
                    for (size_t i = 0; i < n; i += 2) {
                        uint8_t tmp = dst[i];
                        dst[i] = dst[i + 1];
                        dst[i + 1] = tmp;
                    }
            } else if (w->ch[t]->bytes != w->ch[t]->src_bytes) { /* uint16 -> UINT */
                widen_row(dst, src, X, native, w->little_endian);
            } else if (native || w->little_endian) {
                memcpy(dst, src, n);
            } else {
                for (size_t i = 0; i < n; i += b)
                    for (size_t j = 0; j < b; j++) dst[i + j] = src[i + b - 1 - j];
            }
            dst += n;
        }
    }
    *out = s->raw;
    return EXR_ERR_SUCCESS;
}

/* ---- RLE, written here for speed (format of OpenEXR's RLE compressor) ----
 * 1. Split the bytes: even-indexed bytes first, then odd-indexed ones.
 * 2. Delta: every byte but the first becomes (b[i] - b[i-1] + 128) mod 256.
 * 3. Runs: a count byte c >= 0 followed by one byte means c+1 copies of it;
 *    c < 0 is followed by -c literal bytes (at most 127).
 * Readers undo it with the library's decoder; the output need not match the
 * library's encoder byte for byte, only decode to the same data.
 * Two encoders: rle_encode_bits for occupancy-only files (from the bits,
 * below) and rle_encode_packed for any other channel set (from the packed
 * chunk, after it). OpenEXRCore's own encoder is about 10x slower than
 * either. */

/* RLE of a chunk of bit rows (one HALF channel, 0.0 / 1.0) straight from the
 * bits, never building the samples: the bytes are 0x00 / 0x3C00 halves, so
 * after step 1 the even half is X*rows zero bytes and the odd half is 0x3C
 * where a bit is set; after step 2 the even half is 0 then 0x80s, the odd
 * half 0x80 except 0x80 +- 0x3C where a bit differs from the one before it
 * (the first from 0). Cost: one pass over the words plus one per change. */
typedef struct rle_out {
    uint8_t *p;
    size_t n;        /* bytes written */
    uint8_t lit[127]; /* pending literal bytes */
    size_t nlit;
} rle_out;

static void rle_flush(rle_out *o)
{
    if (!o->nlit) return;
    o->p[o->n++] = (uint8_t)(256 - o->nlit);
    memcpy(o->p + o->n, o->lit, o->nlit);
    o->n += o->nlit;
    o->nlit = 0;
}

/* Appends `len` copies of v. */
static void rle_put(rle_out *o, uint8_t v, uint64_t len)
{
    if (len < 3) { /* too short for a run token: literal bytes */
        for (; len > 0; len--) {
            if (o->nlit == sizeof o->lit) rle_flush(o);
            o->lit[o->nlit++] = v;
        }
        return;
    }
    rle_flush(o);
    uint64_t full = len / 128; /* tokens of 128: the same two bytes over and over */
    uint8_t *q = o->p + o->n;
    for (uint64_t i = 0; i < full; i++) {
        q[2 * i] = 127;
        q[2 * i + 1] = v;
    }
    o->n += 2 * full;
    if (len % 128) {
        o->p[o->n++] = (uint8_t)(len % 128 - 1);
        o->p[o->n++] = v;
    }
}

/* Capacity rle_encode_bits needs for `samples` values: the even half is at
 * most 4 + 2*samples/128 bytes; the odd half at most one byte per sample
 * plus one per 127 (every sample a change: 127-byte literals; a change
 * between runs of 3 or more costs 2 + 2 bytes per 4 samples or more). */
static size_t rle_bits_bound(uint64_t samples)
{
    return (size_t)(samples + samples / 127 + samples / 64 + 64);
}

/* The odd-half bytes for the changes (bits set in `changes`) of word v,
 * whose bit 0 is sample pos; *last = the sample after the last change. */
static inline void rle_changes(rle_out *o, uint32_t changes, uint32_t v, uint64_t pos, uint64_t *last)
{
    while (changes) {
        unsigned b = (unsigned)__builtin_ctz(changes);
        changes &= changes - 1u;
        uint64_t at = pos + b;
        rle_put(o, 0x80, at - *last); /* unchanged samples before it */
        rle_put(o, (v >> b) & 1u ? 0x80 + 0x3C : 0x80 - 0x3C, 1);
        *last = at + 1;
    }
}

/* The even half of n samples: the first byte stays (0), then deltas of 0. */
static size_t rle_even_half(uint8_t *out, uint64_t n)
{
    rle_out o = { out, 0, {0}, 0 };
    rle_put(&o, 0x00, 1);
    rle_put(&o, 0x80, n - 1);
    rle_flush(&o);
    return o.n;
}

/* Encodes rows [row0, row0 + rows) of bit channel t; returns the size. */
static size_t rle_encode_bits(const clvox__exr_writer *w, size_t t, uint64_t row0, uint32_t rows, uint8_t *out)
{
    const uint64_t X = w->dims[0], n = X * rows;
    const uint32_t full = (uint32_t)(X / 32), rem = (uint32_t)(X % 32);
    rle_out o = { out, 0, {0}, 0 };
    if (n == 0) return 0;
    o.n = rle_even_half(out, n);
    uint64_t last = 0; /* the sample after the last change */
    uint32_t prev = 0; /* the sample before the current one */
    for (uint32_t y = 0; y < rows; y++) {
        const uint32_t *bits = (const uint32_t *)(const void *)channel_rows(w, t, row0 + y);
        uint64_t pos = (uint64_t)y * X;
        for (uint32_t k = 0; k < full; k++, pos += 32) {
            const uint32_t same = 0u - prev; /* a word without changes */
            while (k + 4 <= full && ((bits[k] ^ same) | (bits[k + 1] ^ same) | (bits[k + 2] ^ same) |
                                     (bits[k + 3] ^ same)) == 0) {
                k += 4;
                pos += 128;
            }
            if (k == full) break;
            uint32_t v = bits[k], changes = v ^ ((v << 1) | prev);
            if (changes) rle_changes(&o, changes, v, pos, &last);
            prev = v >> 31;
        }
        if (rem) { /* the row's last word: bits past X are not samples */
            uint32_t valid = (1u << rem) - 1u, v = bits[full] & valid;
            rle_changes(&o, (v ^ ((v << 1) | prev)) & valid, v, pos, &last);
            prev = (v >> (rem - 1)) & 1u;
        }
    }
    rle_put(&o, 0x80, n - last);
    rle_flush(&o);
    return o.n;
}

/* RLE of any packed chunk (n bytes in file order), for channel sets other
 * than occupancy alone. Steps 1 and 2 are never materialised: the split
 * stream is read in place as the bytes of one parity of src, the even ones
 * then the odd ones, and the delta of each from the one before it (the
 * previous byte of the split stream; 128 before the first, so that the
 * first byte stays as it is). A delta of 0x80 means "same byte again": its
 * runs, the long stretches of 0x0000 or 0x3C00 samples of a coverage
 * plane, are skipped 16 bytes of one parity (32 of src) at a time. */
static const uint8_t rle_parity_mask[2][8] = { { 0xFF, 0, 0xFF, 0, 0xFF, 0, 0xFF, 0 },
                                               { 0, 0xFF, 0, 0xFF, 0, 0xFF, 0, 0xFF } };

/* First index k' >= k of the parity-p stream V[k] = src[2k+p] (length m)
 * with V[k'] != v, or m. */
static size_t rle_same_bytes(const uint8_t *src, size_t n, unsigned p, size_t k, size_t m, uint8_t v)
{
    uint64_t mask, b = 0x0101010101010101ull * v;
    memcpy(&mask, rle_parity_mask[p], 8);
    while (2 * k + 32 <= n) {
        uint64_t a[4];
        memcpy(a, src + 2 * k, sizeof a);
        if ((((a[0] ^ b) | (a[1] ^ b) | (a[2] ^ b) | (a[3] ^ b)) & mask) != 0) break;
        k += 16;
    }
    while (k < m && src[2 * k + p] == v) k++; /* at most 16 steps, or the tail */
    return k;
}

/* Tokens for the parity-p bytes of src; *prev: the split stream's byte
 * before them, updated to their last. */
static void rle_half(rle_out *o, const uint8_t *src, size_t n, unsigned p, uint8_t *prev)
{
    const size_t m = (n + 1 - p) / 2;
    uint8_t last = *prev;
    for (size_t j = 0; j < m;) {
        const uint8_t v = src[2 * j + p], d = (uint8_t)(v - last + 128);
        size_t e = j + 1;
        if (d == 0x80) {
            e = rle_same_bytes(src, n, p, e, m, v);
        } else { /* a run of another delta (a ramp): rare, byte by byte */
            while (e < m && (uint8_t)(src[2 * e + p] - src[2 * e - 2 + p] + 128) == d) e++;
        }
        rle_put(o, d, e - j);
        last = src[2 * (e - 1) + p];
        j = e;
    }
    *prev = last;
}

/* Capacity rle_encode_packed needs for n bytes: one per byte, plus a count
 * byte per 127 literals (a run token never costs more than its bytes). */
static size_t rle_packed_bound(size_t n)
{
    return n + n / 127 + 64;
}

static size_t rle_encode_packed(const uint8_t *src, size_t n, uint8_t *out)
{
    rle_out o = { out, 0, {0}, 0 };
    uint8_t prev = 128;
    rle_half(&o, src, n, 0, &prev);
    rle_half(&o, src, n, 1, &prev);
    rle_flush(&o);
    return o.n;
}

/* Readers take a chunk whose stored size equals its unpacked size as
 * uncompressed. OpenEXRCore 3.1.5 keeps compressed output that is exactly as
 * large as the input (it falls back to raw data only when larger), which then
 * decodes to garbage: seen with ZIP on 3x2 slices. Such chunks (and any that
 * do not shrink) are stored raw. */
static exr_result_t store_raw_if_not_smaller(clvox__exr_writer *w, exr_slot *s, uint64_t row0, uint32_t rows,
                                             uint64_t unpacked)
{
    if (s->out_bytes < unpacked) return EXR_ERR_SUCCESS;
    const uint8_t *raw = NULL;
    exr_result_t rv = packed_chunk(w, s, row0, rows, 0, &raw);
    if (rv != EXR_ERR_SUCCESS) return rv;
    s->out = raw;
    s->out_bytes = unpacked;
    return EXR_ERR_SUCCESS;
}

/* ZIP, ZIPS, PIZ: OpenEXRCore's encode pipeline without its write step. */
static exr_result_t library_encode(clvox__exr_writer *w, exr_slot *s, int32_t c, uint64_t row0)
{
    exr_chunk_info_t ci;
    exr_result_t rv = exr_write_tile_chunk_info(w->exr, 0, 0, c, 0, 0, &ci);
    if (rv != EXR_ERR_SUCCESS) return rv;
    if (!s->initialized) {
        rv = exr_encoding_initialize(w->exr, 0, &ci, &s->pipe);
        if (rv != EXR_ERR_SUCCESS) return rv;
        s->initialized = 1;
    } else {
        rv = exr_encoding_update(w->exr, 0, &ci, &s->pipe);
        if (rv != EXR_ERR_SUCCESS) return rv;
    }
    const uint64_t X = w->dims[0];
    /* The chunk packed once in host order (bit channels expanded; a single
     * sample channel is the caller's data); each channel of the pipeline
     * reads its part of every packed row. */
    uint32_t rows = (uint32_t)((uint64_t)w->height - row0 < (uint64_t)w->tile_h ? (uint64_t)w->height - row0
                                                                                : (uint64_t)w->tile_h);
    const uint8_t *packed = NULL;
    rv = packed_chunk(w, s, row0, rows, 1, &packed);
    if (rv != EXR_ERR_SUCCESS) return rv;
    for (int16_t k = 0; k < s->pipe.channel_count; k++) {
        exr_coding_channel_info_t *ch = &s->pipe.channels[k];
        size_t t, offset = 0; /* bytes before channel t in a packed pixel row, per sample */
        for (t = 0; t < w->nch; t++) {
            if (strcmp(ch->channel_name, w->ch[t]->name) == 0) break;
            offset += w->ch[t]->bytes;
        }
        if (t == w->nch) return EXR_ERR_INVALID_ARGUMENT;
        uint32_t b = w->ch[t]->bytes;
        ch->encode_from_ptr = packed + offset * X;
        ch->user_pixel_stride = (int32_t)b;
        ch->user_line_stride = (int32_t)(X * w->pixel_bytes);
        ch->user_bytes_per_element = (int16_t)b;
        ch->user_data_type = (uint16_t)w->ch[t]->type;
    }
    if (!s->pipe.convert_and_pack_fn) {
        rv = exr_encoding_choose_default_routines(w->exr, 0, &s->pipe);
        if (rv != EXR_ERR_SUCCESS) return rv;
        s->pipe.yield_until_ready_fn = NULL; /* chunks are written by the caller, in order */
        s->pipe.write_fn = NULL;
    }
    rv = exr_encoding_run(w->exr, 0, &s->pipe);
    if (rv != EXR_ERR_SUCCESS) return rv;
    s->out = s->pipe.compressed_buffer;
    s->out_bytes = s->pipe.compressed_bytes;
    return EXR_ERR_SUCCESS;
}

/* Packs and compresses chunk c into slot s (no I/O). Any thread. */
static exr_result_t encode_chunk(clvox__exr_writer *w, exr_slot *s, int32_t c)
{
    const uint64_t row0 = (uint64_t)c * (uint64_t)w->tile_h;
    const uint32_t rows = (uint32_t)((uint64_t)w->height - row0 < (uint64_t)w->tile_h ? (uint64_t)w->height - row0
                                                                                        : (uint64_t)w->tile_h);
    const uint64_t unpacked = (uint64_t)rows * w->dims[0] * w->pixel_bytes;
    exr_result_t rv;
    const uint8_t *packed = NULL;

    switch (w->compression) {
    case EXR_COMPRESSION_NONE:
        rv = packed_chunk(w, s, row0, rows, 0, &packed);
        s->out = packed;
        s->out_bytes = unpacked;
        return rv;
#ifndef CLVOX__EXR_LIBRARY_RLE /* defined: OpenEXRCore's RLE encoder, for comparison */
    case EXR_COMPRESSION_RLE:
        if (w->nch == 1 && w->ch[0]->bits) { /* occupancy alone: from the bits */
            if (!grow(&s->comp, &s->comp_size, rle_bits_bound((uint64_t)rows * w->dims[0])))
                return EXR_ERR_OUT_OF_MEMORY;
            s->out = s->comp;
            s->out_bytes = rle_encode_bits(w, 0, row0, rows, s->comp);
            break;
        }
        rv = packed_chunk(w, s, row0, rows, 0, &packed);
        if (rv != EXR_ERR_SUCCESS) return rv;
        if (!grow(&s->comp, &s->comp_size, rle_packed_bound((size_t)unpacked))) return EXR_ERR_OUT_OF_MEMORY;
        s->out = s->comp;
        s->out_bytes = rle_encode_packed(packed, (size_t)unpacked, s->comp);
        break;
#endif
    default:
        rv = library_encode(w, s, c, row0);
        if (rv != EXR_ERR_SUCCESS) return rv;
        break;
    }
    return store_raw_if_not_smaller(w, s, row0, rows, unpacked);
}

static exr_result_t write_chunk(clvox__exr_writer *w, exr_slot *s, int32_t c)
{
    return exr_write_tile_chunk(w->exr, 0, 0, c, 0, 0, s->out, s->out_bytes);
}

static void *worker_main(void *arg)
{
    clvox__exr_writer *w = arg;
    pthread_mutex_lock(&w->mu);
    for (;;) {
        while (!w->quit &&
               !(w->job_next < w->job_end && w->slots[(unsigned)w->job_next % w->slot_count].state == SLOT_FREE))
            pthread_cond_wait(&w->work_cv, &w->mu);
        if (w->quit) break;
        int32_t c = w->job_next++;
        exr_slot *s = &w->slots[(unsigned)c % w->slot_count];
        s->state = SLOT_BUSY;
        s->chunk = c;
        w->busy++;
        pthread_mutex_unlock(&w->mu);
        exr_result_t rv = encode_chunk(w, s, c);
        pthread_mutex_lock(&w->mu);
        s->rv = rv;
        s->state = SLOT_DONE;
        w->busy--;
        pthread_cond_broadcast(&w->done_cv);
    }
    pthread_mutex_unlock(&w->mu);
    return NULL;
}

/* Encodes and writes chunks [first, end). */
static clvox_status run_chunks(clvox__exr_writer *w, int32_t first, int32_t end)
{
    char what[96];
    if (w->threads_started == 0) {
        exr_slot *s = &w->slots[0];
        for (int32_t c = first; c < end; c++) {
            exr_result_t rv = encode_chunk(w, s, c);
            if (rv != EXR_ERR_SUCCESS) {
                snprintf(what, sizeof what, "encoding chunk %d of", (int)c);
                return exr_fail(w, rv, what);
            }
            rv = write_chunk(w, s, c);
            if (rv != EXR_ERR_SUCCESS) {
                snprintf(what, sizeof what, "writing chunk %d of", (int)c);
                return exr_fail(w, rv, what);
            }
        }
        return CLVOX_OK;
    }

    clvox_status st = CLVOX_OK;
    pthread_mutex_lock(&w->mu);
    w->job_next = first;
    w->job_end = end;
    pthread_cond_broadcast(&w->work_cv);
    for (int32_t c = first; c < end; c++) {
        exr_slot *s = &w->slots[(unsigned)c % w->slot_count];
        while (!(s->state == SLOT_DONE && s->chunk == c)) pthread_cond_wait(&w->done_cv, &w->mu);
        pthread_mutex_unlock(&w->mu);
        exr_result_t rv = s->rv;
        if (rv != EXR_ERR_SUCCESS) {
            snprintf(what, sizeof what, "encoding chunk %d of", (int)c);
            st = exr_fail(w, rv, what);
        } else {
            rv = write_chunk(w, s, c);
            if (rv != EXR_ERR_SUCCESS) {
                snprintf(what, sizeof what, "writing chunk %d of", (int)c);
                st = exr_fail(w, rv, what);
            }
        }
        pthread_mutex_lock(&w->mu);
        s->state = SLOT_FREE;
        if (st != CLVOX_OK) {
            w->job_end = w->job_next; /* assign nothing more */
            break;
        }
        pthread_cond_broadcast(&w->work_cv);
    }
    /* Workers must be idle before the caller's slab goes away. */
    while (w->busy > 0) pthread_cond_wait(&w->done_cv, &w->mu);
    for (unsigned i = 0; i < w->slot_count; i++) w->slots[i].state = SLOT_FREE;
    w->job_next = w->job_end = 0;
    pthread_mutex_unlock(&w->mu);
    return st;
}

/* Appends image rows [row0, row0 + nrows) (one pointer per channel of
 * w->ch) to the file. */
static clvox_status write_rows(clvox__exr_writer *w, uint64_t row0, uint64_t nrows, const uint8_t *const *data)
{
    const uint64_t T = (uint64_t)w->tile_h, H = (uint64_t)w->height;
    const uint64_t R0 = row0, R1 = row0 + nrows;
    int32_t first = (int32_t)(R0 / T);

    for (size_t t = 0; t < w->nch; t++) w->src[t] = data[t];
    w->src_row0 = R0;

    if (w->carry_rows > 0) { /* complete the chunk begun by the previous slab */
        uint64_t cstart = (uint64_t)first * T;
        uint64_t cend = cstart + T < H ? cstart + T : H;
        uint64_t take = cend - R0 < nrows ? cend - R0 : nrows;
        for (size_t t = 0; t < w->nch; t++) {
            size_t rb = source_row_bytes(w, t);
            memcpy(w->carry[t] + (size_t)w->carry_rows * rb, data[t], (size_t)take * rb);
        }
        w->carry_rows += (int32_t)take;
        if (cstart + (uint64_t)w->carry_rows < cend) return CLVOX_OK; /* still incomplete */
    }
    int32_t end = R1 == H ? w->chunk_count : (int32_t)(R1 / T);
    clvox_status st = run_chunks(w, first, end);
    if (st != CLVOX_OK) return st;
    w->carry_rows = 0;
    uint64_t tail0 = (uint64_t)end * T;
    if (tail0 < R1) { /* keep the start of the next chunk */
        for (size_t t = 0; t < w->nch; t++) {
            size_t rb = source_row_bytes(w, t);
            memcpy(w->carry[t], data[t] + (size_t)(tail0 - R0) * rb, (size_t)(R1 - tail0) * rb);
        }
        w->carry_rows = (int32_t)(R1 - tail0);
        w->carry_row0 = tail0;
    }
    return CLVOX_OK;
}

static void stop_pool(clvox__exr_writer *w)
{
    if (!w->mu_ready) return;
    pthread_mutex_lock(&w->mu);
    w->quit = 1;
    pthread_cond_broadcast(&w->work_cv);
    pthread_mutex_unlock(&w->mu);
    for (unsigned i = 0; i < w->threads_started; i++) pthread_join(w->threads[i], NULL);
    w->threads_started = 0;
}

static void release_slots(clvox__exr_writer *w)
{
    if (!w->slots) return;
    for (unsigned i = 0; i < w->slot_count; i++) {
        if (w->slots[i].initialized) exr_encoding_destroy(w->exr, &w->slots[i].pipe);
        free(w->slots[i].raw);
        free(w->slots[i].comp);
    }
    free(w->slots);
    w->slots = NULL;
}

/* Frees everything; unlinks the temporary file unless it was renamed. */
static void writer_free(clvox__exr_writer *w)
{
    if (!w) return;
    stop_pool(w);
    if (w->exr) {
        release_slots(w);
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

/* Largest clvoxPaletteSource: an EXR attribute's size is an int32, and
 * OpenEXRCore refuses strings from INT32_MAX bytes on (a user palette file is
 * at most 4 MiB, docs/design.md "Palette files": far below). */
#define CLVOX__EXR_MAX_STRING ((size_t)INT32_MAX - 1)

/* The header the writer would record for meta, checked before any file is
 * made: refused here rather than written broken. */
static clvox_status check_meta(clvox_context *ctx, const char *path, const clvox__exr_meta *meta)
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

static clvox_status define_header(clvox__exr_writer *w, const clvox_grid *grid, const clvox__exr_meta *meta,
                                  clvox_compression compression)
{
    exr_result_t rv;
    int part = 0;
    exr_compression_t ec = map_compression(compression);
    char layout[160];

#define EXR_TRY(call, what) do { rv = (call); if (rv != EXR_ERR_SUCCESS) return exr_fail(w, rv, what); } while (0)
    EXR_TRY(exr_add_part(w->exr, NULL, EXR_STORAGE_TILED, &part), "adding the part of");
    EXR_TRY(exr_initialize_required_attr_simple(w->exr, part, (int32_t)w->dims[0], w->height, ec),
            "setting the header of");
    EXR_TRY(exr_set_tile_descriptor(w->exr, part, w->dims[0], (uint32_t)w->tile_h, EXR_TILE_ONE_LEVEL,
                                    EXR_TILE_ROUND_DOWN),
            "setting the tiles of");
    for (size_t t = 0; t < w->nch; t++) {
        rv = exr_add_channel(w->exr, part, w->ch[t]->name, w->ch[t]->type, EXR_PERCEPTUALLY_LINEAR, 1, 1);
        if (rv != EXR_ERR_SUCCESS) return exr_fail(w, rv, "adding a channel to");
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
    if (meta && meta->palette) { /* sizes checked by check_meta */
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
    clvox_status st = check_meta(ctx, path, meta);
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
    w->compression = map_compression(compression);
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
        st = exr_fail(w, rv, "starting to write");
        writer_free(w);
        return st;
    }
    st = define_header(w, grid, meta, compression);
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
            if (pthread_create(&w->threads[i], NULL, worker_main, w) != 0) break;
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
    clvox_status st = write_rows(w, (uint64_t)z0 * Y, (uint64_t)nz * Y, data);
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
    stop_pool(w);
    release_slots(w);
    exr_result_t rv = exr_finish(&w->exr);
    w->exr = NULL;
    if (rv != EXR_ERR_SUCCESS) {
        st = exr_fail(w, rv, "finishing");
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
