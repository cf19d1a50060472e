/* SPDX-License-Identifier: Apache-2.0 */
/* One chunk of the EXR writer, packed as the file stores it and compressed:
 * clvox's own RLE encoders (from the bits, or from the packed chunk),
 * OpenEXRCore's pipeline for ZIP, ZIPS and PIZ, raw where that does not
 * shrink. Called from the encoder threads (exr_write_pool.c): no I/O here. */
#include "io/exr_writer.h"

#include <stdlib.h>
#include <string.h>

static int grow(uint8_t **buf, size_t *size, size_t need)
{
    if (*size >= need) return 1;
    uint8_t *p = realloc(*buf, need);
    if (!p) return 0;
    *buf = p;
    *size = need;
    return 1;
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
exr_result_t clvox__exrw_encode_chunk(clvox__exr_writer *w, exr_slot *s, int32_t c)
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
