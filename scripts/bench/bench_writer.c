/* SPDX-License-Identifier: Apache-2.0 */
/* Times the EXR writer alone (no OpenCL): a sphere of radius 0.4 N in an N^3
 * grid, streamed in slabs of occupancy bits, for each compression and thread
 * count; then, for N <= 512, the sphere's coverage (HALF: 0 outside, 1
 * inside, the fraction r + 0.5 - distance on a one-voxel shell) alone and
 * with occupancy; then a palette run's planes: element (0 outside, 1 inside,
 * 2..45 on the shell by position) alone and with score (HALF 1 off the
 * shell, the coverage's grey on it), and all four channels. Not a test;
 * numbers for src/io/write_exr.c and README. Built with -DBENCH_BASELINE
 * (against an older clvox whose writer has no element and score) it runs the
 * first three sets only; BENCH_SETS=035 in the environment runs sets 0, 3
 * and 5 of the six.
 *
 *   make bench-tools
 *   build/release/bench/bench_writer [N ...]   (default 512 1024; files go to build/bench/)
 *
 * Prints: N, channels, compression, threads, writer seconds (wall, best of 2,
 * making the data excluded), the CPU seconds of that run, file MB. */
#define _POSIX_C_SOURCE 200809L
#include "core/internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Slices z0 .. z0+nz-1 of the sphere as bit rows. */
static void sphere_bits(uint32_t *bits, uint32_t N, uint32_t z0, uint32_t nz)
{
    const uint32_t W = clvox__row_words(N);
    const double c = N / 2.0, r2 = 0.16 * N * (double)N;
    memset(bits, 0, (size_t)W * N * nz * sizeof *bits);
    for (uint32_t k = 0; k < nz; k++)
        for (uint32_t y = 0; y < N; y++) {
            double dy = y + 0.5 - c, dz = z0 + k + 0.5 - c, rest = r2 - dy * dy - dz * dz;
            uint32_t *row = bits + ((size_t)k * N + y) * W;
            for (uint32_t x = 0; x < N && rest > 0; x++) {
                double dx = x + 0.5 - c;
                if (dx * dx < rest) row[x / 32] |= 1u << (x % 32);
            }
        }
}

/* HALF bits of f in [0, 1], rounded to nearest. */
static uint16_t half_bits(double f)
{
    if (f <= 0) return 0;
    if (f >= 1) return 0x3C00;
    int e;
    double m = frexp(f, &e);                                     /* f = m 2^e, m in [0.5, 1) */
    if (e < -13) return (uint16_t)lrint(ldexp(f, 24));           /* subnormal: multiples of 2^-24 */
    uint32_t mant = (uint32_t)lrint((2 * m - 1) * 1024);         /* 1024 carries into the exponent */
    return (uint16_t)(((uint32_t)(e + 14) << 10) + mant);
}

/* Slices z0 .. z0+nz-1 of the sphere's coverage. */
static void sphere_coverage(uint16_t *cov, uint32_t N, uint32_t z0, uint32_t nz)
{
    const double c = N / 2.0, r = 0.4 * N;
    for (uint32_t k = 0; k < nz; k++)
        for (uint32_t y = 0; y < N; y++)
            for (uint32_t x = 0; x < N; x++) {
                double dx = x + 0.5 - c, dy = y + 0.5 - c, dz = z0 + k + 0.5 - c;
                cov[((size_t)k * N + y) * N + x] = half_bits(r + 0.5 - sqrt(dx * dx + dy * dy + dz * dz));
            }
}

/* Slices z0 .. z0+nz-1 of the sphere's palette planes (element, score). */
static void sphere_palette(uint16_t *elem, uint16_t *score, uint32_t N, uint32_t z0, uint32_t nz)
{
    const double c = N / 2.0, r = 0.4 * N;
    for (uint32_t k = 0; k < nz; k++)
        for (uint32_t y = 0; y < N; y++)
            for (uint32_t x = 0; x < N; x++) {
                double dx = x + 0.5 - c, dy = y + 0.5 - c, dz = z0 + k + 0.5 - c;
                double f = r + 0.5 - sqrt(dx * dx + dy * dy + dz * dz);
                size_t i = ((size_t)k * N + y) * N + x;
                elem[i] = f >= 1 ? 1 : f <= 0 ? 0 : (uint16_t)(2 + (x + 3 * y + 7 * (z0 + k)) % 44);
                score[i] = f >= 1 || f <= 0 ? 0x3C00 : half_bits(0.5 + 0.5 * f);
            }
}

typedef struct bench_case {
    uint32_t N, channels;
    const uint32_t *bits;
    const uint16_t *cov, *elem, *score;
} bench_case;

static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Best of 2 wall seconds for writing the whole volume; *cpu: the process's
 * CPU seconds (all threads) of that run, which a busy machine disturbs less;
 * *bytes: file size. */
static double time_writer(clvox_context *ctx, const bench_case *b, clvox_compression comp, uint32_t threads,
                          uint64_t *bytes, double *cpu)
{
    const uint32_t N = b->N, nz = 16, W = clvox__row_words(N), slabs = (N + nz - 1) / nz;
    clvox_grid g = {{N, N, N}, {0, 0, 0}, {1.0 / N, 1.0 / N, 1.0 / N}};
    clvox__exr_meta meta = { .method = "ray", .parameters = "bench" };
    double best = 1e30;
    for (int rep = 0; rep < 2; rep++) {
        clvox__exr_writer *w = NULL;
        double t0 = now(), c0 = cpu_now();
        clvox_status st = clvox__exr_open(ctx, "build/bench/writer.exr", &g, &meta, b->channels, comp, threads, &w);
        for (uint32_t s = 0; st == CLVOX_OK && s < slabs; s++) {
            uint32_t z0 = s * nz;
            const size_t at = (size_t)z0 * N * N;
            clvox__slab_planes planes;
            memset(&planes, 0, sizeof planes); /* a baseline build's struct may have fewer planes */
            planes.occupancy_bits = b->bits ? b->bits + (size_t)z0 * W * N : NULL;
            planes.coverage_half = b->cov ? b->cov + at : NULL;
#ifndef BENCH_BASELINE
            planes.element = b->elem ? b->elem + at : NULL;
            planes.score_half = b->score ? b->score + at : NULL;
#endif
            st = clvox__exr_write_slab(w, z0, N - z0 < nz ? N - z0 : nz, &planes);
        }
        if (st == CLVOX_OK) st = clvox__exr_finish(w, bytes);
        else clvox__exr_abort(w);
        if (st != CLVOX_OK) {
            fprintf(stderr, "bench_writer: %s\n", clvox_context_error(ctx));
            exit(1);
        }
        double t = now() - t0, c = cpu_now() - c0;
        if (t < best) {
            best = t;
            *cpu = c;
        }
    }
    return best;
}

int main(int argc, char **argv)
{
    clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
    co.host_only = 1;
    clvox_context *ctx = NULL;
    if (clvox_context_create(&co, &ctx) != CLVOX_OK) return 1;
    mkdir("build", 0777);
    mkdir("build/bench", 0777);
    static const char *names[] = {"none", "rle", "zip", "piz"};
    static const clvox_compression comps[] = {CLVOX_COMPRESSION_NONE, CLVOX_COMPRESSION_RLE, CLVOX_COMPRESSION_ZIP,
                                              CLVOX_COMPRESSION_PIZ};
    int nsizes = argc > 1 ? argc - 1 : 2;
    printf("| N | channels | compression | threads | writer s | cpu s | file MB |\n|---:|---|---|---:|---:|---:|---:|\n");
    for (int a = 0; a < nsizes; a++) {
        uint32_t N = argc > 1 ? (uint32_t)atoi(argv[a + 1]) : (a ? 1024u : 512u);
        const uint32_t nz = 16, W = clvox__row_words(N);
        uint32_t *bits = malloc((size_t)W * N * N * sizeof *bits); /* all slabs, made before timing */
        uint16_t *cov = N <= 512 ? malloc((size_t)N * N * N * sizeof *cov) : NULL;
#ifdef BENCH_BASELINE
        uint16_t *elem = NULL, *score = NULL;
        const size_t sets = cov ? 3u : 1u;
#else
        uint16_t *elem = cov ? malloc((size_t)N * N * N * sizeof *elem) : NULL;
        uint16_t *score = cov ? malloc((size_t)N * N * N * sizeof *score) : NULL;
        const size_t sets = cov && elem && score ? 6u : 1u;
#endif
        if (!bits) return 1;
        for (uint32_t z0 = 0; z0 < N; z0 += nz) {
            uint32_t k = N - z0 < nz ? N - z0 : nz;
            sphere_bits(bits + (size_t)z0 * W * N, N, z0, k);
            if (cov) sphere_coverage(cov + (size_t)z0 * N * N, N, z0, k);
            if (elem && score) sphere_palette(elem + (size_t)z0 * N * N, score + (size_t)z0 * N * N, N, z0, k);
        }
        const uint32_t E = 0x4u, S = 0x8u; /* CLVOX_CHANNEL_ELEMENT, _SCORE */
        const bench_case cases[] = {
            { N, CLVOX_CHANNEL_OCCUPANCY, bits, NULL, NULL, NULL },
            { N, CLVOX_CHANNEL_COVERAGE, NULL, cov, NULL, NULL },
            { N, CLVOX_CHANNEL_COVERAGE | CLVOX_CHANNEL_OCCUPANCY, bits, cov, NULL, NULL },
            { N, E, NULL, NULL, elem, NULL },
            { N, E | S, NULL, NULL, elem, score },
            { N, CLVOX_CHANNEL_COVERAGE | CLVOX_CHANNEL_OCCUPANCY | E | S, bits, cov, elem, score },
        };
        static const char *set_names[] = { "occupancy", "coverage", "coverage+occupancy", "element",
                                           "element+score", "all four" };
        const char *only = getenv("BENCH_SETS"); /* e.g. "0,3": the sets to run */
        for (size_t k = 0; k < sets; k++)
            if (!only || strchr(only, (int)('0' + k)))
            for (size_t c = 0; c < sizeof comps / sizeof comps[0]; c++)
                for (uint32_t threads = 1; threads <= 2; threads++) {
                    uint64_t bytes = 0;
                    double cpu = 0;
                    double t = time_writer(ctx, &cases[k], comps[c], threads, &bytes, &cpu);
                    printf("| %u | %s | %s | %u | %.3f | %.3f | %.1f |\n", N, set_names[k], names[c], threads, t,
                           cpu, bytes / 1e6);
                    fflush(stdout);
                }
        free(bits);
        free(cov);
        free(elem);
        free(score);
    }
    unlink("build/bench/writer.exr");
    clvox_context_destroy(ctx);
    return 0;
}
