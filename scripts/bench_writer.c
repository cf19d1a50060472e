/* Times the EXR writer alone (no OpenCL): a sphere of radius 0.4 N in an N^3
 * grid, streamed in slabs of occupancy bits, for each compression and thread
 * count. Not a test; numbers for src/write_exr.c and README.
 *
 *   cc -std=c11 -O2 -Iinclude -Isrc -Ikernels scripts/bench_writer.c build/release/libclvox.a \
 *      -lOpenCL -lOpenEXRCore-3_1 -lOpenMeshCore -lstdc++ -lm -lpthread -o build/tools/bench_writer
 *   build/tools/bench_writer [N ...]        (default 512 1024; files go to build/bench/)
 *
 * Prints: N, compression, threads, writer seconds (wall, best of 2, making
 * the bits excluded), file MB. */
#define _POSIX_C_SOURCE 200809L
#include "internal.h"

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
    printf("| N | compression | threads | writer s | file MB |\n|---:|---|---:|---:|---:|\n");
    for (int a = 0; a < nsizes; a++) {
        uint32_t N = argc > 1 ? (uint32_t)atoi(argv[a + 1]) : (a ? 1024u : 512u);
        const uint32_t nz = 16, W = clvox__row_words(N);
        uint32_t slabs = (N + nz - 1) / nz;
        uint32_t *bits = malloc((size_t)W * N * N * sizeof *bits); /* all slabs, made before timing */
        if (!bits) return 1;
        for (uint32_t z0 = 0; z0 < N; z0 += nz) sphere_bits(bits + (size_t)z0 * W * N, N, z0, N - z0 < nz ? N - z0 : nz);
        clvox_grid g = {{N, N, N}, {0, 0, 0}, {1.0 / N, 1.0 / N, 1.0 / N}};
        clvox__exr_meta meta = {"ray", "bench"};
        for (size_t c = 0; c < sizeof comps / sizeof comps[0]; c++)
            for (uint32_t threads = 1; threads <= 2; threads++) {
                double best = 1e30;
                uint64_t bytes = 0;
                for (int rep = 0; rep < 2; rep++) {
                    clvox__exr_writer *w = NULL;
                    double t0 = now();
                    clvox_status st = clvox__exr_open(ctx, "build/bench/writer.exr", &g, &meta, 0, comps[c], threads, &w);
                    for (uint32_t s = 0; st == CLVOX_OK && s < slabs; s++) {
                        uint32_t z0 = s * nz;
                        st = clvox__exr_write_slab(w, z0, N - z0 < nz ? N - z0 : nz, &(clvox__slab_planes){bits + (size_t)z0 * W * N, NULL});
                    }
                    if (st == CLVOX_OK) st = clvox__exr_finish(w, &bytes);
                    else clvox__exr_abort(w);
                    if (st != CLVOX_OK) {
                        fprintf(stderr, "bench_writer: %s\n", clvox_context_error(ctx));
                        return 1;
                    }
                    double t = now() - t0;
                    if (t < best) best = t;
                }
                printf("| %u | %s | %u | %.3f | %.1f |\n", N, names[c], threads, best, bytes / 1e6);
                fflush(stdout);
            }
        free(bits);
    }
    unlink("build/bench/writer.exr");
    clvox_context_destroy(ctx);
    return 0;
}
