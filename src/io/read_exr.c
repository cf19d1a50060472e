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
 * Files: this one (the API, the sample conversions and sums, the band
 * consumers), exr_read_header.c (opening the file, the header, the
 * attributes and the size checks), exr_read_decode.c (read_channel: the
 * chunk decoding, with its fast path for NONE and RLE); exr_reader.h holds
 * the state they share.
 */
#include "io/exr_reader.h"
#include "io/volume_source.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

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
    clvox_context *ctx;
    const char *path;
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
            return clvox__fail(s->ctx, CLVOX_ERR_CANCELLED, "reading '%s' cancelled after slice %llu",
                               s->path, (unsigned long long)z);
    }
    return CLVOX_OK;
}


_Static_assert((int)CLVOX__SAMPLE_UINT == (int)EXR_PIXEL_UINT && (int)CLVOX__SAMPLE_HALF == (int)EXR_PIXEL_HALF &&
                   (int)CLVOX__SAMPLE_FLOAT == (int)EXR_PIXEL_FLOAT,
               "band sample types are OpenEXR's");

/* What every volume read needs, whatever the format: a channel the filled
 * count comes from, and room for the occupancy asked for. */
static clvox_status check_read(clvox_context *ctx, const char *path, const clvox_volume_info *info, int has_channel,
                               const uint8_t *occupancy, size_t occupancy_size)
{
    if (!has_channel)
        return clvox__fail(ctx, CLVOX_ERR_EXR,
                           "'%s' is not a clvox volume: no channel \"occupancy\", \"coverage\" or \"element\" (has: %s)",
                           path, info->channels);
    if (occupancy) {
        uint64_t total = (uint64_t)info->dims[0] * info->dims[1] * info->dims[2];
        if (total > (uint64_t)SIZE_MAX || occupancy_size < (size_t)total)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT,
                               "occupancy buffer holds %zu bytes, '%s' needs %u x %u x %u = %llu", occupancy_size,
                               path, info->dims[0], info->dims[1], info->dims[2], (unsigned long long)total);
    }
    return CLVOX_OK;
}

/* The other formats (read_volume.c): the same consumers over the source's bands. */
static clvox_status source_read(clvox_context *ctx, clvox__vsrc *src, const char *path, clvox_volume_info *info,
                                uint8_t *occupancy, size_t occupancy_size)
{
    const int occ = clvox__vsrc_has(src, "occupancy"), cov = clvox__vsrc_has(src, "coverage"),
              elem = clvox__vsrc_has(src, "element");
    clvox_status st = check_read(ctx, path, info, occ || cov || elem, occupancy, occupancy_size);
    coverage_sum sum = { 0, 0, 0.0 };
    count_state cs = { info->dims[0], occupancy, 0, NULL };
    if (st == CLVOX_OK) {
        if (!occ && cov) cs.sum = &sum;
        st = clvox__vsrc_read(src, occ ? "occupancy" : cov ? "coverage" : "element", count_band, &cs);
    }
    if (st == CLVOX_OK && occ && cov) {
        cs.sum = &sum;
        st = clvox__vsrc_read(src, "coverage", sum_band, &cs);
    }
    if (st == CLVOX_OK) {
        info->filled_voxels = cs.filled;
        info->coverage_sum = cov ? sum_value(&sum) : 0.0;
    }
    return st;
}

static clvox_status source_read_slices(clvox_context *ctx, clvox__vsrc *src, const char *path, const char *channel,
                                       clvox_volume_info *info, clvox_volume_slice_fn fn, void *user)
{
    if (!clvox__vsrc_has(src, channel))
        return clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' has no channel \"%s\" (has: %s)", path, channel, info->channels);
    float *slice = NULL;
    uint64_t n = (uint64_t)info->dims[0] * info->dims[1];
    if (n > (uint64_t)SIZE_MAX / sizeof *slice || !(slice = malloc((size_t)n * sizeof *slice)))
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for a %u x %u slice of '%s'", info->dims[0],
                           info->dims[1], path);
    slice_state s = { ctx, path, info->dims[0], info->dims[1], slice, fn, user };
    clvox_status st = clvox__vsrc_read(src, channel, slice_band, &s);
    free(slice);
    return st;
}

static clvox_status volume_read(clvox_context *ctx, const char *path, clvox_volume_info *info,
                                uint8_t *occupancy, size_t occupancy_size)
{
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!path || !*path) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_volume_read: no path");
    clvox_volume_info local;
    if (!info) info = &local;

    clvox__vsrc *src = NULL;
    clvox_status st = clvox__vsrc_open(ctx, path, info, &src);
    if (st != CLVOX_OK || src) {
        if (st == CLVOX_OK) st = source_read(ctx, src, path, info, occupancy, occupancy_size);
        clvox__vsrc_close(src);
        return st;
    }
    reader r;
    st = clvox__exrr_open(&r, ctx, path, info);
    const exr_attr_chlist_entry_t *occ = NULL, *cov = NULL, *elem = NULL;
    if (st == CLVOX_OK) {
        occ = clvox__exrr_find_channel(&r, "occupancy");
        cov = clvox__exrr_find_channel(&r, "coverage");
        elem = clvox__exrr_find_channel(&r, "element");
        st = check_read(ctx, path, info, occ || cov || elem, occupancy, occupancy_size);
    }
    coverage_sum sum = { 0, 0, 0.0 };
    count_state cs = { info->dims[0], occupancy, 0, NULL };
    if (st == CLVOX_OK) {
        /* Filled voxels from occupancy, else from coverage (summed in the
         * same pass), else from element (UINT > 0: element != 0). */
        if (!occ && cov) cs.sum = &sum;
        st = clvox__exrr_read_channel(&r, info, occ ? occ : cov ? cov : elem, count_band, &cs);
    }
    if (st == CLVOX_OK && occ && cov) {
        /* Both channels: a second pass over the file for the coverage sum. It
         * decodes every chunk again; one pass decoding two channels would be
         * faster but needs a band per channel and a two-channel consumer. */
        cs.sum = &sum;
        st = clvox__exrr_read_channel(&r, info, cov, sum_band, &cs);
    }
    if (st == CLVOX_OK) {
        info->filled_voxels = cs.filled;
        info->coverage_sum = cov ? sum_value(&sum) : 0.0;
    }
    clvox__exrr_close(&r);
    return st;
}

static clvox_status volume_read_slices(clvox_context *ctx, const char *path, const char *channel,
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
    clvox__vsrc *src = NULL;
    clvox_status st = clvox__vsrc_open(ctx, path, info, &src);
    if (st != CLVOX_OK || src) {
        if (st == CLVOX_OK) st = source_read_slices(ctx, src, path, channel, info, fn, user);
        clvox__vsrc_close(src);
        return st;
    }
    reader r;
    st = clvox__exrr_open(&r, ctx, path, info);
    const exr_attr_chlist_entry_t *e = NULL;
    if (st == CLVOX_OK && !(e = clvox__exrr_find_channel(&r, channel)))
        st = clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' has no channel \"%s\" (has: %s)", path, channel, info->channels);
    float *slice = NULL;
    if (st == CLVOX_OK) {
        uint64_t n = (uint64_t)info->dims[0] * info->dims[1];
        if (n > (uint64_t)SIZE_MAX / sizeof *slice || !(slice = malloc((size_t)n * sizeof *slice)))
            st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for a %u x %u slice of '%s'", info->dims[0],
                             info->dims[1], path);
    }
    if (st == CLVOX_OK) {
        slice_state s = { ctx, path, info->dims[0], info->dims[1], slice, fn, user };
        st = clvox__exrr_read_channel(&r, info, e, slice_band, &s);
    }
    free(slice);
    clvox__exrr_close(&r);
    return st;
}

/* The public entry points: the header is read into a whole struct, then as
 * much of it as the caller's holds is copied (clvox.h "Conventions"), also
 * after a failure (clvox preview reads info->channels then). */
clvox_status clvox_volume_read(clvox_context *ctx, const char *path, clvox_volume_info *info,
                               uint8_t *occupancy, size_t occupancy_size)
{
    clvox_status st = clvox__out_begin(ctx, info, sizeof *info, CLVOX__VOLUME_INFO_SIZE_0, "clvox_volume_info");
    if (st != CLVOX_OK) return st;
    clvox_volume_info full;
    memset(&full, 0, sizeof full);
    st = volume_read(ctx, path, &full, occupancy, occupancy_size);
    clvox__out_end(info, &full);
    return st;
}

/* The caller's header before its first slice (clvox preview and instances
 * size their buffers from it in the first call). */
typedef struct header_first {
    clvox_volume_info *caller;
    const clvox_volume_info *full;
    clvox_volume_slice_fn fn;
    void *user;
    int copied;
} header_first;

static int header_then_slice(void *user, uint32_t z, const float *values)
{
    header_first *h = user;
    if (!h->copied) {
        clvox__out_end(h->caller, h->full);
        h->copied = 1;
    }
    return h->fn(h->user, z, values);
}

clvox_status clvox_volume_read_slices(clvox_context *ctx, const char *path, const char *channel,
                                      clvox_volume_info *info, clvox_volume_slice_fn fn, void *user)
{
    clvox_status st = clvox__out_begin(ctx, info, sizeof *info, CLVOX__VOLUME_INFO_SIZE_0, "clvox_volume_info");
    if (st != CLVOX_OK) return st;
    clvox_volume_info full;
    memset(&full, 0, sizeof full);
    header_first h = { info, &full, fn, user, 0 };
    st = volume_read_slices(ctx, path, channel, &full, fn ? header_then_slice : NULL, &h);
    clvox__out_end(info, &full);
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
    clvox__vsrc *src = NULL;
    clvox_status st = clvox__vsrc_open(ctx, path, &info, &src);
    clvox__vsrc_close(src);
    if (st != CLVOX_OK) return st;
    if (src)
        return clvox__fail(ctx, CLVOX_ERR_EXR,
                           "'%s' has no palette: only clvox's EXR records it (npy, NRRD, binvox and OpenVDB do not)",
                           path);
    reader r;
    st = clvox__exrr_open(&r, ctx, path, &info);
    if (st != CLVOX_OK) {
        clvox__exrr_close(&r);
        return st;
    }
    if (!info.palette[0] || !r.has_palette_hash) {
        clvox__exrr_close(&r);
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
        st = clvox__exrr_fail(&r, rv, "reading the header of");
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
    clvox__exrr_close(&r);
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

