/* SPDX-License-Identifier: Apache-2.0 */
/* The EXR reader's decoding: one channel, one row of chunks at a time, into
 * a band that the caller's consumer takes (read_exr.c); clvox's own fast
 * path for NONE and RLE, OpenEXRCore's decoder for everything else. */
#include "io/exr_reader.h"

#include <stdlib.h>
#include <string.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

/* Makes `e` the channel clvox__exrr_read_channel decodes. */
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
 * RLE format: see exr_write_encode.c. */

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
    if (rv != EXR_ERR_SUCCESS) return clvox__exrr_fail(r, rv, "reading a chunk of");
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
        if (rv != EXR_ERR_SUCCESS) return clvox__exrr_fail(r, rv, "starting to decode");
        *initialized = 1;
    } else {
        rv = exr_decoding_update(r->exr, 0, ci, dec);
        if (rv != EXR_ERR_SUCCESS) return clvox__exrr_fail(r, rv, "decoding");
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
    if (rv != EXR_ERR_SUCCESS) return clvox__exrr_fail(r, rv, "choosing a decoder for");
    rv = exr_decoding_run(r->exr, 0, dec);
    if (rv != EXR_ERR_SUCCESS) return clvox__exrr_fail(r, rv, "decoding");
    return CLVOX_OK;
}

/* Decodes channel `e` one row of chunks at a time, in increasing y, and hands
 * each band to `consume`. */
clvox_status clvox__exrr_read_channel(reader *r, const clvox_volume_info *info, const exr_attr_chlist_entry_t *e,
                                 band_fn consume, void *user)
{
    clvox_status st = select_channel(r, e);
    if (st != CLVOX_OK) return st;
    exr_result_t rv;
    exr_storage_t storage;
    rv = exr_get_storage(r->exr, 0, &storage);
    if (rv != EXR_ERR_SUCCESS) return clvox__exrr_fail(r, rv, "reading the storage type of");
    if (storage != EXR_STORAGE_SCANLINE && storage != EXR_STORAGE_TILED)
        return clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s': deep images are not clvox volumes", r->path);

    const uint64_t X = info->dims[0];
    const uint64_t H = (uint64_t)info->dims[1] * info->dims[2];
    const uint32_t bytes = r->ch_bytes;
    exr_attr_box2i_t dw;
    rv = exr_get_data_window(r->exr, 0, &dw);
    if (rv != EXR_ERR_SUCCESS) return clvox__exrr_fail(r, rv, "reading the data window of");

    uint64_t band_rows;
    int32_t tile_w = 0, tile_h = 0;
    if (storage == EXR_STORAGE_TILED) {
        rv = exr_get_tile_sizes(r->exr, 0, 0, 0, &tile_w, &tile_h);
        if (rv != EXR_ERR_SUCCESS || tile_w <= 0 || tile_h <= 0) return clvox__exrr_fail(r, rv, "reading the tiles of");
        band_rows = (uint64_t)tile_h;
    } else {
        int32_t lpc = 0;
        rv = exr_get_scanlines_per_chunk(r->exr, 0, &lpc);
        if (rv != EXR_ERR_SUCCESS || lpc <= 0) return clvox__exrr_fail(r, rv, "reading the chunk size of");
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
                    st = clvox__exrr_fail(r, rv, "locating a tile of");
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
                st = clvox__exrr_fail(r, rv, "locating a chunk of");
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

