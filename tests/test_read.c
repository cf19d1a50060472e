/* SPDX-License-Identifier: Apache-2.0 */
/* Reading volumes back, any channel: clvox_volume_read_slices returns every
 * sample (HALF, FLOAT, UINT) of files written by an independent writer
 * (tests/exrgen.c, OpenEXRCore directly) in every layout, including chunks
 * spanning two slices; coverage_sum is exact; the filled-voxel rules; a
 * coverage-only file through clvox_volume_read; missing channels and cancel.
 * No OpenCL. */
#include "test.h"
#include "exrgen.h"

#include <math.h>
#include <stdint.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

static clvox_context *ctx;
static char dir[1024];

static uint64_t rng_state = 0x2545F4914F6CDD1Dull;
static uint32_t rnd(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (uint32_t)(rng_state >> 11);
}

/* HALF bits of a random value in [0,1]: every bit pattern of that range is
 * possible (subnormals included), plus exact 0, 0.5, 1 often. */
static uint16_t random_coverage(void)
{
    uint32_t k = rnd() % 8;
    if (k == 0) return 0x0000;
    if (k == 1) return 0x3C00;
    if (k == 2) return 0x3800;
    return (uint16_t)(rnd() % 0x3C01u); /* 0 .. 0x3C00 = [0, 1] */
}

/* Collects the slices the reader hands out into a dense float volume. */
typedef struct collect {
    uint32_t X, Y, Z;
    float *vol;
    uint32_t calls, next_z;
    int out_of_order;
    uint32_t cancel_at; /* return 1 at this z (UINT32_MAX: never) */
} collect;

static int on_slice(void *user, uint32_t z, const float *values)
{
    collect *c = user;
    if (z != c->next_z || z >= c->Z) {
        c->out_of_order = 1;
        return 1;
    }
    c->next_z++;
    c->calls++;
    memcpy(c->vol + (size_t)z * c->X * c->Y, values, (size_t)c->X * c->Y * sizeof(float));
    return z == c->cancel_at;
}

static int same_float(float a, double want)
{
    if (isnan(want)) return isnan(a);
    return (double)a == want;
}

/* Streams `channel` and checks it against want (doubles); returns 1 when all equal. */
static int check_stream(const char *what, const char *path, const char *channel, uint32_t X, uint32_t Y, uint32_t Z,
                        const double *want)
{
    size_t n = (size_t)X * Y * Z;
    collect c = { X, Y, Z, malloc(n * sizeof(float)), 0, 0, 0, UINT32_MAX };
    if (!c.vol) abort();
    for (size_t i = 0; i < n; i++) c.vol[i] = -12345.0f;
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    clvox_status st = clvox_volume_read_slices(ctx, path, channel, &info, on_slice, &c);
    CHECK_MSG(st == CLVOX_OK, "%s: %s: %s", what, clvox_status_string(st), clvox_context_error(ctx));
    CHECK_MSG(c.calls == Z && !c.out_of_order, "%s: %u calls for %u slices%s", what, c.calls, Z,
              c.out_of_order ? ", out of order" : "");
    CHECK(info.dims[0] == X && info.dims[1] == Y && info.dims[2] == Z);
    size_t bad = 0, first_bad = 0;
    for (size_t i = 0; i < n; i++)
        if (!same_float(c.vol[i], want[i]) && bad++ == 0) first_bad = i;
    CHECK_MSG(bad == 0, "%s: %zu of %zu values differ, first at %zu: %.9g, expected %.9g", what, bad, n, first_bad,
              bad ? (double)c.vol[first_bad] : 0.0, bad ? want[first_bad] : 0.0);
    free(c.vol);
    return bad == 0 && st == CLVOX_OK;
}

typedef struct layout {
    int tw, th; /* 0,0: scanline */
    exr_compression_t comp;
} layout;

/* Channels of every type in every layout; tiles that are not slices (rows
 * of 3 with Y = 7: chunks span two slices; 5 x 35: five slices per chunk). */
static void test_layouts(void)
{
    const uint32_t X = 13, Y = 7, Z = 6;
    const size_t n = (size_t)X * Y * Z;
    uint16_t *cov = malloc(n * 2), *occ = malloc(n * 2);
    float *score = malloc(n * 4);
    uint32_t *elem = malloc(n * 4);
    double *want_cov = malloc(n * sizeof(double)), *want_occ = malloc(n * sizeof(double));
    double *want_score = malloc(n * sizeof(double)), *want_elem = malloc(n * sizeof(double));
    uint8_t *back = malloc(n), *want_filled_occ = malloc(n);
    if (!cov || !occ || !score || !elem || !want_cov || !want_occ || !want_score || !want_elem || !back ||
        !want_filled_occ)
        abort();
    int64_t exact = 0; /* coverage sum times 2^24 */
    uint64_t filled_occ = 0;
    for (size_t i = 0; i < n; i++) {
        cov[i] = random_coverage();
        occ[i] = (rnd() & 1) ? 0x3C00 : 0x0000; /* independent of coverage on purpose */
        score[i] = (float)((double)(int32_t)rnd() / 1024.0);
        elem[i] = (i % 5 == 0) ? 0xFFFFFFu - (uint32_t)i : rnd() % (1u << 24); /* < 2^24: exact in float */
        want_cov[i] = exrgen_half_value(cov[i]);
        want_occ[i] = exrgen_half_value(occ[i]);
        want_score[i] = score[i];
        want_elem[i] = elem[i];
        want_filled_occ[i] = occ[i] == 0x3C00;
        filled_occ += want_filled_occ[i];
        exact += (int64_t)ldexp(want_cov[i], 24);
    }
    const double want_sum = ldexp((double)exact, -24);
    const exrgen_channel all[] = {
        { "occupancy", EXR_PIXEL_HALF, occ }, { "coverage", EXR_PIXEL_HALF, cov },
        { "score", EXR_PIXEL_FLOAT, score },  { "element", EXR_PIXEL_UINT, elem },
    };
    static const layout layouts[] = {
        { 0, 0, EXR_COMPRESSION_NONE }, { 0, 0, EXR_COMPRESSION_RLE },  { 0, 0, EXR_COMPRESSION_ZIP },
        { 0, 0, EXR_COMPRESSION_PIZ },  { 13, 7, EXR_COMPRESSION_RLE }, { 13, 7, EXR_COMPRESSION_NONE },
        { 4, 4, EXR_COMPRESSION_ZIPS }, { 13, 3, EXR_COMPRESSION_RLE }, { 13, 3, EXR_COMPRESSION_NONE },
        { 5, 35, EXR_COMPRESSION_ZIP }, { 64, 64, EXR_COMPRESSION_PIZ }, { 6, 11, EXR_COMPRESSION_RLE },
    };
    char path[1200];
    snprintf(path, sizeof path, "%s/layouts.exr", dir);
    for (size_t l = 0; l < sizeof layouts / sizeof layouts[0]; l++) {
        char what[96];
        snprintf(what, sizeof what, "layout %zu (tile %dx%d, compression %d)", l, layouts[l].tw, layouts[l].th,
                 (int)layouts[l].comp);
        CHECK(exrgen_write(path, X, Y, Z, all, 4, layouts[l].tw, layouts[l].th, layouts[l].comp, 1));
        check_stream(what, path, "coverage", X, Y, Z, want_cov);
        check_stream(what, path, "occupancy", X, Y, Z, want_occ);
        check_stream(what, path, "score", X, Y, Z, want_score);
        check_stream(what, path, "element", X, Y, Z, want_elem);

        /* occupancy present: filled from occupancy, coverage summed (second pass) */
        clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
        memset(back, 7, n);
        CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, back, n));
        CHECK_MSG(info.filled_voxels == filled_occ, "%s: filled %llu, expected %llu", what,
                  (unsigned long long)info.filled_voxels, (unsigned long long)filled_occ);
        CHECK_MSG(memcmp(back, want_filled_occ, n) == 0, "%s: occupancy output differs", what);
        CHECK_MSG(info.coverage_sum == want_sum, "%s: coverage_sum %.17g, expected %.17g", what, info.coverage_sum,
                  want_sum);
        CHECK(strcmp(info.channels, "coverage,element,occupancy,score") == 0);
        CHECK(strcmp(info.method, EXRGEN_METHOD) == 0 && strcmp(info.version, EXRGEN_VERSION) == 0);
        CHECK(info.voxel_size[2] == EXRGEN_H_Z && info.origin[1] == EXRGEN_ORIGIN_Y);
    }

    /* coverage only: clvox_volume_read reads it; filled = coverage > 0.5 */
    uint64_t filled_cov = 0;
    uint8_t *want_filled_cov = malloc(n);
    if (!want_filled_cov) abort();
    for (size_t i = 0; i < n; i++) filled_cov += (want_filled_cov[i] = want_cov[i] > 0.5);
    for (size_t l = 0; l < sizeof layouts / sizeof layouts[0]; l++) {
        CHECK(exrgen_write(path, X, Y, Z, &all[1], 1, layouts[l].tw, layouts[l].th, layouts[l].comp, 1));
        clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
        memset(back, 7, n);
        CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, back, n));
        CHECK_MSG(info.filled_voxels == filled_cov, "coverage-only layout %zu: filled %llu, expected %llu", l,
                  (unsigned long long)info.filled_voxels, (unsigned long long)filled_cov);
        CHECK_MSG(memcmp(back, want_filled_cov, n) == 0, "coverage-only layout %zu: occupancy output differs", l);
        CHECK_MSG(info.coverage_sum == want_sum, "coverage-only layout %zu: coverage_sum %.17g, expected %.17g", l,
                  info.coverage_sum, want_sum);
        CHECK(strcmp(info.channels, "coverage") == 0);
        /* no NULL info needed either */
        CHECK_OK(ctx, clvox_volume_read(ctx, path, NULL, NULL, 0));
    }
    /* occupancy only: coverage_sum stays 0 */
    CHECK(exrgen_write(path, X, Y, Z, &all[0], 1, 0, 0, EXR_COMPRESSION_RLE, 1));
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, NULL, 0));
    CHECK(info.filled_voxels == filled_occ && info.coverage_sum == 0.0);
    unlink(path);
    free(want_filled_cov);
    free(cov);
    free(occ);
    free(score);
    free(elem);
    free(want_cov);
    free(want_occ);
    free(want_score);
    free(want_elem);
    free(back);
    free(want_filled_occ);
}

/* Special HALF values: > 0.5 is filled (NaN is not, +inf is), the sum
 * carries inf/NaN, negative values subtract, subnormals count exactly. */
static void test_special_values(void)
{
    const uint32_t X = 4, Y = 3, Z = 2;
    static const uint16_t sub[24] = { 0x0001, 0x0001, 0x0001, 0x0001, 0x03FF, 0x3800, 0x3801, 0x3C00,
                                      0x37FF, 0x0000, 0x8000, 0x0400, 0x3BFF, 0x3BFF, 0x3BFF, 0x3BFF,
                                      0x3BFF, 0x3BFF, 0x3BFF, 0x3BFF, 0x3BFF, 0x3BFF, 0x3BFF, 0xBC00 };
    char path[1200];
    snprintf(path, sizeof path, "%s/special.exr", dir);
    exrgen_channel ch = { "coverage", EXR_PIXEL_HALF, sub };
    CHECK(exrgen_write(path, X, Y, Z, &ch, 1, 0, 0, EXR_COMPRESSION_NONE, 1));
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, NULL, 0));
    int64_t exact = 0;
    uint64_t filled = 0;
    for (int i = 0; i < 24; i++) {
        exact += (int64_t)ldexp(exrgen_half_value(sub[i]), 24);
        filled += exrgen_half_value(sub[i]) > 0.5;
    }
    CHECK_MSG(info.coverage_sum == ldexp((double)exact, -24), "coverage_sum %.17g, expected %.17g",
              info.coverage_sum, ldexp((double)exact, -24));
    CHECK(info.filled_voxels == filled && filled == 13);
    double want[24];
    for (int i = 0; i < 24; i++) want[i] = exrgen_half_value(sub[i]);
    check_stream("special values", path, "coverage", X, Y, Z, want);

    uint16_t inf[24];
    memcpy(inf, sub, sizeof inf);
    inf[3] = 0x7C00; /* +inf: filled, sum infinite */
    inf[4] = 0x7E00; /* NaN would make the sum NaN: keep it out here */
    ch.data = inf;
    CHECK(exrgen_write(path, X, Y, Z, &ch, 1, 2, 2, EXR_COMPRESSION_RLE, 1));
    CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, NULL, 0));
    CHECK(isnan(info.coverage_sum));
    CHECK(info.filled_voxels == 14); /* +inf in, NaN not, 0x03FF was not filled anyway */
    for (int i = 0; i < 24; i++) want[i] = exrgen_half_value(inf[i]);
    check_stream("inf and NaN", path, "coverage", X, Y, Z, want);
    inf[4] = 0x0000;
    CHECK(exrgen_write(path, X, Y, Z, &ch, 1, 0, 0, EXR_COMPRESSION_ZIP, 1));
    CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, NULL, 0));
    CHECK(isinf(info.coverage_sum) && info.coverage_sum > 0);
    unlink(path);
}

/* A sum that float or naive double accumulation would round: 2^20 voxels of
 * the smallest subnormal plus ones. */
static void test_exact_sum(void)
{
    const uint32_t X = 1024, Y = 64, Z = 17;
    const size_t n = (size_t)X * Y * Z;
    uint16_t *cov = malloc(n * 2);
    if (!cov) abort();
    int64_t exact = 0;
    for (size_t i = 0; i < n; i++) {
        cov[i] = (i % 3 == 0) ? 0x3BFF /* 1 - 2^-11 */ : (i % 3 == 1) ? 0x0001 /* 2^-24 */ : 0x3C00;
        exact += (int64_t)ldexp(exrgen_half_value(cov[i]), 24);
    }
    char path[1200];
    snprintf(path, sizeof path, "%s/sum.exr", dir);
    exrgen_channel ch = { "coverage", EXR_PIXEL_HALF, cov };
    CHECK(exrgen_write(path, X, Y, Z, &ch, 1, 1024, 64, EXR_COMPRESSION_RLE, 1));
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, NULL, 0));
    CHECK_MSG(info.coverage_sum == ldexp((double)exact, -24), "coverage_sum %.17g, expected %.17g",
              info.coverage_sum, ldexp((double)exact, -24));
    float fsum = 0;
    for (size_t i = 0; i < n; i++) fsum += (float)exrgen_half_value(cov[i]);
    CHECK((double)fsum != info.coverage_sum); /* the test can tell an inexact sum */
    unlink(path);
    free(cov);
}

static void test_errors_and_cancel(void)
{
    const uint32_t X = 5, Y = 4, Z = 9;
    const size_t n = (size_t)X * Y * Z;
    uint16_t cov[5 * 4 * 9];
    uint32_t elem[5 * 4 * 9];
    for (size_t i = 0; i < n; i++) {
        cov[i] = random_coverage();
        elem[i] = (uint32_t)i;
    }
    char path[1200];
    snprintf(path, sizeof path, "%s/err.exr", dir);
    exrgen_channel ch[] = { { "coverage", EXR_PIXEL_HALF, cov }, { "element", EXR_PIXEL_UINT, elem } };
    CHECK(exrgen_write(path, X, Y, Z, ch, 2, 5, 3, EXR_COMPRESSION_RLE, 1));

    float vol[5 * 4 * 9];
    collect c = { X, Y, Z, vol, 0, 0, 0, UINT32_MAX };
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    /* missing channel: the message lists what the file has */
    CHECK_STATUS(ctx, clvox_volume_read_slices(ctx, path, "occupancy", &info, on_slice, &c), CLVOX_ERR_EXR);
    CHECK(strstr(clvox_context_error(ctx), "occupancy") != NULL);
    CHECK(strstr(clvox_context_error(ctx), "coverage,element") != NULL);
    CHECK(c.calls == 0);
    CHECK(strcmp(info.channels, "coverage,element") == 0 && info.dims[2] == Z); /* header still given */
    CHECK_STATUS(ctx, clvox_volume_read_slices(ctx, path, "Coverage", &info, on_slice, &c), CLVOX_ERR_EXR);
    /* bad arguments */
    CHECK_STATUS(ctx, clvox_volume_read_slices(ctx, path, NULL, &info, on_slice, &c), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(ctx, clvox_volume_read_slices(ctx, path, "", &info, on_slice, &c), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(ctx, clvox_volume_read_slices(ctx, path, "coverage", &info, NULL, &c), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(ctx, clvox_volume_read_slices(ctx, NULL, "coverage", &info, on_slice, &c),
                 CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(NULL, clvox_volume_read_slices(NULL, path, "coverage", &info, on_slice, &c),
                 CLVOX_ERR_INVALID_ARGUMENT);
    CHECK(c.calls == 0);

    /* cancel from the callback at z = 2: exactly three calls */
    c.cancel_at = 2;
    CHECK_STATUS(ctx, clvox_volume_read_slices(ctx, path, "coverage", NULL, on_slice, &c), CLVOX_ERR_CANCELLED);
    CHECK(c.calls == 3 && !c.out_of_order);
    CHECK(strstr(clvox_context_error(ctx), "cancelled") != NULL);
    /* cancel at the last slice still reports it */
    c.calls = c.next_z = 0;
    c.cancel_at = Z - 1;
    CHECK_STATUS(ctx, clvox_volume_read_slices(ctx, path, "element", NULL, on_slice, &c), CLVOX_ERR_CANCELLED);
    CHECK(c.calls == Z);

    /* element without occupancy or coverage (a palette run): filled = element != 0 */
    CHECK(exrgen_write(path, X, Y, Z, &ch[1], 1, 0, 0, EXR_COMPRESSION_NONE, 1));
    uint8_t filled[5 * 4 * 9];
    memset(filled, 7, sizeof filled);
    CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, filled, sizeof filled));
    CHECK(info.filled_voxels == n - 1 && filled[0] == 0 && filled[1] == 1 && filled[n - 1] == 1);
    CHECK(info.coverage_sum == 0.0 && strcmp(info.channels, "element") == 0);
    /* none of the three: not a clvox volume for clvox_volume_read, still streamable */
    float score[5 * 4 * 9];
    for (size_t i = 0; i < n; i++) score[i] = (float)i;
    exrgen_channel sc = { "score", EXR_PIXEL_FLOAT, score };
    CHECK(exrgen_write(path, X, Y, Z, &sc, 1, 0, 0, EXR_COMPRESSION_NONE, 1));
    CHECK_STATUS(ctx, clvox_volume_read(ctx, path, &info, NULL, 0), CLVOX_ERR_EXR);
    CHECK(strstr(clvox_context_error(ctx), "has: score") != NULL);
    CHECK(exrgen_write(path, X, Y, Z, &ch[1], 1, 0, 0, EXR_COMPRESSION_NONE, 1));
    c.calls = c.next_z = 0;
    c.cancel_at = UINT32_MAX;
    CHECK_OK(ctx, clvox_volume_read_slices(ctx, path, "element", NULL, on_slice, &c));
    CHECK(c.calls == Z && vol[n - 1] == (float)(n - 1));

    /* not a clvox volume, not an EXR, a directory, missing */
    CHECK(exrgen_write(path, X, Y, Z, ch, 1, 0, 0, EXR_COMPRESSION_NONE, 0));
    CHECK_STATUS(ctx, clvox_volume_read_slices(ctx, path, "coverage", &info, on_slice, &c), CLVOX_ERR_EXR);
    CHECK(strstr(clvox_context_error(ctx), "not a clvox volume") != NULL);
    FILE *f = fopen(path, "w");
    if (f) {
        fputs("not an EXR\n", f);
        fclose(f);
    }
    CHECK_STATUS(ctx, clvox_volume_read_slices(ctx, path, "coverage", &info, on_slice, &c), CLVOX_ERR_EXR);
    CHECK_STATUS(ctx, clvox_volume_read_slices(ctx, dir, "coverage", &info, on_slice, &c), CLVOX_ERR_IO);
    unlink(path);
    CHECK_STATUS(ctx, clvox_volume_read_slices(ctx, path, "coverage", &info, on_slice, &c), CLVOX_ERR_IO);
}

static long vm_kb(const char *key)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    long kb = -1;
    size_t n = strlen(key);
    if (!f) return -1;
    while (fgets(line, sizeof line, f))
        if (strncmp(line, key, n) == 0) kb = strtol(line + n, NULL, 10);
    fclose(f);
    return kb;
}

/* Resets VmHWM to the current RSS (Linux >= 4.0); *rss gets it. */
static int peak_reset(long *rss)
{
    FILE *f = fopen("/proc/self/clear_refs", "w");
    int ok = f && fputs("5", f) >= 0;
    if (f && fclose(f) != 0) ok = 0;
    *rss = vm_kb("VmRSS:");
    return ok && *rss > 0;
}

/* Both readers refuse `path` with CLVOX_ERR_EXR and a message containing
 * `needle` (NULL: any message), and the peak RSS grows by less than 32 MiB. */
static void expect_corrupt(const char *what, const char *path, const char *needle)
{
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    long base = 0;
    int reset = peak_reset(&base);
    clvox_status st = clvox_volume_read(ctx, path, &info, NULL, 0);
    if (!needle) needle = "'";
    CHECK_MSG(st == CLVOX_ERR_EXR && strstr(clvox_context_error(ctx), needle), "%s: %s: %s", what,
              clvox_status_string(st), clvox_context_error(ctx));
    CHECK_MSG(strchr(clvox_context_error(ctx), '\n') == NULL, "%s: message on several lines", what);
    float vol[1];
    collect c = { 1, 1, 1, vol, 0, 0, 0, UINT32_MAX };
    st = clvox_volume_read_slices(ctx, path, "occupancy", &info, on_slice, &c);
    CHECK_MSG(st == CLVOX_ERR_EXR && strstr(clvox_context_error(ctx), needle) && c.calls == 0,
              "%s (slices): %s: %s", what, clvox_status_string(st), clvox_context_error(ctx));
    long grew = vm_kb("VmHWM:") - base;
    if (reset) CHECK_MSG(grew < 32 * 1024, "%s: peak RSS grew by %ld kB", what, grew);
}

/* Crafted headers (tests/exrgen.c): sizes the file cannot hold, bad
 * attributes, dims that contradict clvox's own tile layout; a FIFO. */
static void test_crafted(void)
{
    char path[1200];
    snprintf(path, sizeof path, "%s/crafted.exr", dir);
#ifndef __SANITIZE_ADDRESS__
    /* an address-space limit: a giant allocation fails as OUT_OF_MEMORY instead of ERR_EXR */
    struct rlimit old, lim;
    int limited = getrlimit(RLIMIT_AS, &old) == 0;
    if (limited) {
        lim = old;
        long vm = vm_kb("VmSize:");
        lim.rlim_cur = (rlim_t)(vm > 0 ? vm : 1 << 20) * 1024 + ((rlim_t)1 << 30); /* + 1 GiB */
        limited = setrlimit(RLIMIT_AS, &lim) == 0;
    }
#endif
    static const struct { exr_compression_t comp; int tw, th; } kinds[] = {
        { EXR_COMPRESSION_PIZ, 0, 0 },  { EXR_COMPRESSION_RLE, 0, 0 },           { EXR_COMPRESSION_NONE, 0, 0 },
        { EXR_COMPRESSION_ZIP, 0, 0 },  { EXR_COMPRESSION_RLE, 1 << 16, 1 }, { EXR_COMPRESSION_PIZ, 4096, 4096 },
    };
    for (size_t k = 0; k < sizeof kinds / sizeof kinds[0]; k++) {
        char what[96];
        /* 1e9 x 1e9 (grid 1e9 x 1e9 x 1), and 1e9 x 1 (one 2 GB row) */
        for (int tall = 0; tall < 2; tall++) {
            int64_t Wd = 1000000000, Hd = tall ? 1000000000 : 1;
            exrgen_attrs a = exrgen_default_attrs((uint32_t)Wd, (uint32_t)Hd, 1);
            CHECK(exrgen_write_header(path, Wd, Hd, kinds[k].tw, kinds[k].th, kinds[k].comp, &a, 64));
            snprintf(what, sizeof what, "%s header %lld x %lld, compression %d, tiles %dx%d", tall ? "tall" : "wide",
                     (long long)Wd, (long long)Hd, (int)kinds[k].comp, kinds[k].tw, kinds[k].th);
            expect_corrupt(what, path, NULL); /* OpenEXRCore itself refuses some */
        }
    }
#ifndef __SANITIZE_ADDRESS__
    if (limited) setrlimit(RLIMIT_AS, &old);
#endif

    /* attributes: origin finite, voxel size finite and > 0 */
    const uint32_t X = 5, Y = 4, Z = 6;
    uint16_t occ[5 * 4 * 6];
    for (size_t i = 0; i < sizeof occ / sizeof occ[0]; i++) occ[i] = (i % 3) ? 0x3C00 : 0;
    exrgen_channel ch = { "occupancy", EXR_PIXEL_HALF, occ };
    const double bad[] = { NAN, INFINITY, -INFINITY, -1.0, 0.0 };
    for (size_t b = 0; b < sizeof bad / sizeof bad[0]; b++) {
        for (int which = 0; which < 2; which++) {
            exrgen_attrs a = exrgen_default_attrs(X, Y, Z);
            if (which == 0 && (b >= 3)) continue; /* a negative or zero origin is fine */
            if (which == 0) a.origin[b % 3] = bad[b];
            else a.voxel_size[b % 3] = bad[b];
            CHECK(exrgen_write_ex(path, X, Y, Z, &ch, 1, 0, 0, EXR_COMPRESSION_NONE, &a));
            char what[64];
            snprintf(what, sizeof what, "%s %g", which ? "voxel size" : "origin", bad[b]);
            expect_corrupt(what, path, which ? "clvoxVoxelSize" : "clvoxOrigin");
        }
    }
    {
        exrgen_attrs a = exrgen_default_attrs(X, Y, Z);
        a.origin[0] = -7.5;
        CHECK(exrgen_write_ex(path, X, Y, Z, &ch, 1, 0, 0, EXR_COMPRESSION_NONE, &a));
        clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
        CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, NULL, 0));
        CHECK(info.origin[0] == -7.5);
    }

    /* clvox's own layouts: tiles must agree with clvoxDims (Y*Z alone cannot tell 5x4x6 from 5x6x4) */
    {
        exrgen_attrs a = exrgen_default_attrs(X, Y, Z);
        a.layout = "tile-per-slice: pixel (x, y + z*Y), tile X x Y = slice z";
        CHECK(exrgen_write_ex(path, X, Y, Z, &ch, 1, (int)X, (int)Y, EXR_COMPRESSION_RLE, &a));
        clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
        CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, NULL, 0)); /* the right dims */
        CHECK(info.dims[1] == Y && info.dims[2] == Z);
        a.dims[1] = (int32_t)Z;
        a.dims[2] = (int32_t)Y;
        CHECK(exrgen_write_ex(path, X, Y, Z, &ch, 1, (int)X, (int)Y, EXR_COMPRESSION_RLE, &a));
        expect_corrupt("permuted clvoxDims, tile-per-slice", path, "tiles do not fit");
        a = exrgen_default_attrs(X, Y, Z);
        a.layout = "row-chunks: pixel (x, y + z*Y), tile X x 4 rows";
        CHECK(exrgen_write_ex(path, X, Y, Z, &ch, 1, (int)X, 4, EXR_COMPRESSION_RLE, &a));
        expect_corrupt("row-chunks with tiles of a whole slice", path, "tiles do not fit");
        a.layout = "tile-per-slice: pixel (x, y + z*Y), tile X x Y = slice z";
        /* re-tiled by another tool (the attribute kept): read like any layout */
        a = exrgen_default_attrs(X, Y, Z);
        a.layout = "tile-per-slice: pixel (x, y + z*Y), tile X x Y = slice z";
        CHECK(exrgen_write_ex(path, X, Y, Z, &ch, 1, 2, 3, EXR_COMPRESSION_RLE, &a));
        CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, NULL, 0));
        CHECK(exrgen_write_ex(path, X, Y, Z, &ch, 1, 0, 0, EXR_COMPRESSION_ZIP, &a));
        CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, NULL, 0));
    }
    unlink(path);

    /* a FIFO: refused at once (alarm: a blocking open would hang the test) */
    CHECK(mkfifo(path, 0666) == 0);
    alarm(20);
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    CHECK_STATUS(ctx, clvox_volume_read(ctx, path, &info, NULL, 0), CLVOX_ERR_IO);
    CHECK(strstr(clvox_context_error(ctx), "not a regular file") != NULL);
    float vol[1];
    collect c = { 1, 1, 1, vol, 0, 0, 0, UINT32_MAX };
    CHECK_STATUS(ctx, clvox_volume_read_slices(ctx, path, "occupancy", &info, on_slice, &c), CLVOX_ERR_IO);
    CHECK_STATUS(ctx, clvox_volume_read(ctx, "/dev/zero", &info, NULL, 0), CLVOX_ERR_IO);
    alarm(0);
    unlink(path);
}

/* The palette attributes as another writer puts them (tests/exrgen.c):
 * read into clvox_volume_info and rebuilt by clvox_volume_palette when
 * right; every malformed one refused with one line, never a crash. */
static void test_palette_attrs(void)
{
    const uint32_t X = 6, Y = 5, Z = 3;
    const size_t n = (size_t)X * Y * Z;
    uint32_t elem[6 * 5 * 3];
    uint16_t score[6 * 5 * 3];
    uint64_t nonzero = 0;
    for (size_t i = 0; i < n; i++) {
        elem[i] = (uint32_t)(i % 7 == 0 ? 0 : i % 46);
        score[i] = (uint16_t)(0x3400 + i);
        nonzero += elem[i] != 0;
    }
    const exrgen_channel ch[] = { { "element", EXR_PIXEL_UINT, elem }, { "score", EXR_PIXEL_HALF, score } };
    clvox_palette *p46 = NULL, *blocks = NULL;
    CHECK_OK(ctx, clvox_palette_builtin(ctx, "paper46", &p46));
    CHECK_OK(ctx, clvox_palette_load(ctx, "palettes/blocks.txt", &blocks));
    if (!p46 || !blocks) {
        clvox_palette_destroy(p46);
        clvox_palette_destroy(blocks);
        return;
    }
    char h46[32], hblocks[32], path[1200];
    snprintf(h46, sizeof h46, "%016llx", (unsigned long long)clvox_palette_hash(p46));
    snprintf(hblocks, sizeof hblocks, "%016llx", (unsigned long long)clvox_palette_hash(blocks));
    snprintf(path, sizeof path, "%s/palette.exr", dir);

    /* right: a built-in by name, a user palette from its text */
    const exrgen_extra good46[] = { { "clvoxPalette", "paper46", 0 }, { "clvoxPaletteCount", NULL, 46 },
                                    { "clvoxPaletteHash", h46, 0 }, { "clvoxMetric", "nearest", 0 } };
    const exrgen_extra good_blocks[] = { { "clvoxPalette", "blocks", 0 }, { "clvoxPaletteCount", NULL, 12 },
                                         { "clvoxPaletteHash", hblocks, 0 },
                                         { "clvoxPaletteSource", clvox_palette_source(blocks), 0 },
                                         { "clvoxMetric", "outer", 0 } };
    for (int k = 0; k < 2; k++) {
        exrgen_attrs a = exrgen_default_attrs(X, Y, Z);
        a.extra = k ? good_blocks : good46;
        a.extra_count = k ? 5 : 4;
        CHECK(exrgen_write_ex(path, X, Y, Z, ch, 2, k ? 6 : 0, 5, EXR_COMPRESSION_RLE, &a));
        clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
        CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, NULL, 0));
        CHECK(strcmp(info.palette, k ? "blocks" : "paper46") == 0 && info.palette_count == (k ? 12u : 46u));
        CHECK(info.palette_hash == clvox_palette_hash(k ? blocks : p46));
        CHECK(strcmp(info.metric, k ? "outer" : "nearest") == 0);
        CHECK(info.filled_voxels == nonzero && strcmp(info.channels, "element,score") == 0);
        clvox_palette *p = NULL;
        CHECK_OK(ctx, clvox_volume_palette(ctx, path, &p));
        CHECK(p && clvox_palette_hash(p) == clvox_palette_hash(k ? blocks : p46));
        CHECK(p && strcmp(clvox_palette_name(p), k ? "blocks" : "paper46") == 0);
        CHECK(p && (k ? clvox_palette_source(p) && strcmp(clvox_palette_source(p), clvox_palette_source(blocks)) == 0
                      : clvox_palette_source(p) == NULL));
        clvox_palette_destroy(p);
    }
    /* a name with a dot keeps it (the text is parsed under that name) */
    {
        const exrgen_extra x[] = { { "clvoxPalette", "my.blocks", 0 }, { "clvoxPaletteHash", hblocks, 0 },
                                   { "clvoxPaletteSource", clvox_palette_source(blocks), 0 } };
        exrgen_attrs a = exrgen_default_attrs(X, Y, Z);
        a.extra = x;
        a.extra_count = 3;
        CHECK(exrgen_write_ex(path, X, Y, Z, ch, 2, 0, 0, EXR_COMPRESSION_NONE, &a));
        clvox_palette *p = NULL;
        CHECK_OK(ctx, clvox_volume_palette(ctx, path, &p));
        CHECK(p && strcmp(clvox_palette_name(p), "my.blocks") == 0);
        clvox_palette_destroy(p);
    }

    /* malformed attributes: clvox_volume_read refuses the file */
    static const struct {
        exrgen_extra x;
        const char *needle;
    } corrupt[] = {
        { { "clvoxPaletteHash", "0123456789ABCDEF", 0 }, "clvoxPaletteHash" },
        { { "clvoxPaletteHash", "0123456789abcde", 0 }, "clvoxPaletteHash" },
        { { "clvoxPaletteHash", "0123456789abcdef0", 0 }, "clvoxPaletteHash" },
        { { "clvoxPaletteHash", "0x23456789abcdef", 0 }, "clvoxPaletteHash" },
        { { "clvoxPaletteHash", "", 0 }, "clvoxPaletteHash" },
        { { "clvoxPaletteHash", NULL, 5 }, "clvoxPaletteHash" },
        { { "clvoxPaletteCount", NULL, 0 }, "clvoxPaletteCount" },
        { { "clvoxPaletteCount", NULL, -46 }, "clvoxPaletteCount" },
        { { "clvoxPaletteCount", NULL, 65537 }, "clvoxPaletteCount" },
        { { "clvoxPaletteCount", "46", 0 }, "clvoxPaletteCount" },
        { { "clvoxPalette", NULL, 46 }, "clvoxPalette" },
        { { "clvoxPalette", "a-palette-name-of-sixty-four-bytes-or-more-which-is-one-too-many-for-it", 0 }, "too long" },
        { { "clvoxMetric", "nearest-and-more", 0 }, "clvoxMetric" },
        { { "clvoxPalette", "two\nlines", 0 }, "clvoxPalette is not text" },
        { { "clvoxPaletteHash", "0123456789abcd\nf", 0 }, "clvoxPaletteHash is not text" },
        { { "clvoxMetric", "tab\there", 0 }, "clvoxMetric is not text" },
        { { "clvoxMetric", NULL, 1 }, "clvoxMetric" },
    };
    for (size_t i = 0; i < sizeof corrupt / sizeof corrupt[0]; i++) {
        exrgen_attrs a = exrgen_default_attrs(X, Y, Z);
        a.extra = &corrupt[i].x;
        a.extra_count = 1;
        CHECK(exrgen_write_ex(path, X, Y, Z, ch, 2, 0, 0, EXR_COMPRESSION_ZIP, &a));
        char what[96];
        snprintf(what, sizeof what, "corrupt palette attribute %zu (%s)", i, corrupt[i].x.name);
        expect_corrupt(what, path, corrupt[i].needle);
        clvox_palette *p = (clvox_palette *)&p;
        CHECK_STATUS(ctx, clvox_volume_palette(ctx, path, &p), CLVOX_ERR_EXR);
        CHECK(p == NULL);
    }

    /* well formed, but no palette to be had: clvox_volume_read is fine, clvox_volume_palette is not */
    static const char bad_text[] = "element a\n  cell\n    1 0 0\nend\n";
    const exrgen_extra wrong_hash[] = { { "clvoxPalette", "paper46", 0 }, { "clvoxPaletteHash", hblocks, 0 } };
    const exrgen_extra wrong_count[] = { { "clvoxPalette", "paper46", 0 }, { "clvoxPaletteCount", NULL, 45 },
                                         { "clvoxPaletteHash", h46, 0 } };
    const exrgen_extra unknown[] = { { "clvoxPalette", "paper47", 0 }, { "clvoxPaletteHash", h46, 0 } };
    const exrgen_extra bad_source[] = { { "clvoxPalette", "mine", 0 }, { "clvoxPaletteHash", h46, 0 },
                                        { "clvoxPaletteSource", bad_text, 0 } };
    const exrgen_extra other_source[] = { { "clvoxPalette", "blocks", 0 }, { "clvoxPaletteHash", h46, 0 },
                                          { "clvoxPaletteSource", clvox_palette_source(blocks), 0 } };
    const exrgen_extra empty_source[] = { { "clvoxPalette", "e", 0 }, { "clvoxPaletteHash", h46, 0 },
                                          { "clvoxPaletteSource", "", 0 } };
    const exrgen_extra no_hash[] = { { "clvoxPalette", "paper46", 0 }, { "clvoxPaletteCount", NULL, 46 } };
    const exrgen_extra no_name[] = { { "clvoxPaletteHash", h46, 0 }, { "clvoxPaletteCount", NULL, 46 } };
    const struct {
        const exrgen_extra *x;
        int count;
        const char *needle;
    } fails[] = {
        { wrong_hash, 2, "is not the one" },       { wrong_count, 3, "is not the one" },
        { unknown, 2, "not a built-in palette" },  { bad_source, 3, "mine.clvoxPaletteSource:3:" },
        { other_source, 3, "is not the one" },     { empty_source, 3, "is not the one" },
        { no_hash, 2, "clvoxPaletteHash is missing" }, { no_name, 2, "clvoxPalette is missing" },
        { NULL, 0, "has no palette" },
    };
    for (size_t i = 0; i < sizeof fails / sizeof fails[0]; i++) {
        exrgen_attrs a = exrgen_default_attrs(X, Y, Z);
        a.extra = fails[i].x;
        a.extra_count = fails[i].count;
        /* (tiles of 3 x 2 would make chunks OpenEXRCore 3.1.5 compresses to exactly their raw size, which it
         * then mis-reads: see exr_write_encode.c store_raw_if_not_smaller) */
        CHECK(exrgen_write_ex(path, X, Y, Z, ch, 2, 3, 2, EXR_COMPRESSION_NONE, &a));
        clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
        CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, NULL, 0));
        CHECK_MSG(info.filled_voxels == nonzero, "palette case %zu: filled %llu, expected %llu", i,
                  (unsigned long long)info.filled_voxels, (unsigned long long)nonzero);
        clvox_palette *p = (clvox_palette *)&p;
        clvox_status st = clvox_volume_palette(ctx, path, &p);
        const char *msg = clvox_context_error(ctx);
        CHECK_MSG(st == CLVOX_ERR_EXR && p == NULL && strstr(msg, fails[i].needle) && !strchr(msg, '\n') &&
                      strstr(msg, path),
                  "palette case %zu: %s: %s", i, clvox_status_string(st), msg);
    }
    unlink(path);
    clvox_palette_destroy(p46);
    clvox_palette_destroy(blocks);
}

int main(void)
{
    clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
    o.host_only = 1;
    if (clvox_context_create(&o, &ctx) != CLVOX_OK) {
        fprintf(stderr, "host-only context: %s\n", clvox_context_error(ctx));
        printf("0 passed, 1 failed\n");
        return 1;
    }
    snprintf(dir, sizeof dir, "%s/read-%ld", test_tmpdir(), (long)getpid());
    mkdir(dir, 0777);

    test_layouts();
    test_special_values();
    test_exact_sum();
    test_errors_and_cancel();
    test_crafted();
    test_palette_attrs();

    CHECK_MSG(rmdir(dir) == 0, "%s is not empty: a file was left behind", dir);
    clvox_context_destroy(ctx);
    return test_report();
}
