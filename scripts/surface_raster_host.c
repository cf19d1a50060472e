/* SPDX-License-Identifier: Apache-2.0 */
/* Host build of the surface raster (kernels/surface.cl), for profiling and
 * counting, not a test: compiles the kernel as C (OpenCL qualifiers and
 * atomics as plain C), makes the tasks as src/raster/surface.c does (slabs of 76
 * slices, tasks of SPT slices x RPT rows) and runs every task on one thread,
 * best of REPS, thread CPU time (less disturbed by a loaded machine than
 * PoCL's device time). "filled" must equal clvox's count for the same mesh
 * and -r N (the grid is computed from the vertices' bounding box).
 *
 *   cc -std=gnu11 -fgnu89-inline -O2 -w -DCLVOX_SURFACE_ROW_AXES=3 -Iinclude -Ikernels \
 *      -o build/tools/surface_raster_host scripts/surface_raster_host.c build/release/libclvox.a \
 *      -lOpenCL -lOpenEXRCore-3_1 -lOpenMeshCore -lstdc++ -lm -lpthread
 *   build/tools/surface_raster_host MESH N [REPS [SPT [RPT]]]
 *
 * (gcc's code, not PoCL's: relative numbers only; -DCLVOX_SURFACE_ROW_AXES=1
 * gives rows along x only.) */
#include "clvox.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <stdint.h>
#include <time.h>
#define cl_khr_fp64 1
typedef unsigned char uchar;
typedef unsigned int uint;
#define kernel
#define global
static size_t g_gid;
static size_t get_global_id(int d) { (void)d; return g_gid; }
static void atomic_or(uint *p, uint v) { *p |= v; }
static void atomic_add(uint *p, uint v) { *p += v; }
#define popcount __builtin_popcount
#include "overlap.h"
#include "surface.cl"

/* src/raster/surface.c's cell_range, through the kernel's own clvox_first_cell /
 * clvox_last_cell (the same rule). */
static int cell_range(double mn, double mx, uint32_t n, int32_t *lo, int32_t *hi)
{
    const int l = clvox_first_cell(mn, 0, (int)n - 1), h = clvox_last_cell(mx, 0, (int)n - 1);
    if (l > h) return 0;
    *lo = l; *hi = h; return 1;
}
static double now(void) { struct timespec t; clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t); return t.tv_sec + 1e-9 * t.tv_nsec; }
int main(int argc, char **argv)
{
    if (argc < 3) { fprintf(stderr, "usage: %s MESH N [REPS [SPT [RPT]]]\n", argv[0]); return 2; }
    const char *path = argv[1]; uint32_t N = (uint32_t)atoi(argv[2]); int reps = argc > 3 ? atoi(argv[3]) : 5;
    int spt = argc > 4 ? atoi(argv[4]) : 8, rpt = argc > 5 ? atoi(argv[5]) : 32;
    clvox_context *ctx = NULL;
    if (clvox_context_create(NULL, &ctx) != CLVOX_OK) return 1;
    clvox_mesh *mesh = NULL;
    if (clvox_mesh_load(ctx, path, &mesh) != CLVOX_OK) { fprintf(stderr, "cannot load %s\n", path); return 1; }
    size_t nv, nt; const float *xyz = clvox_mesh_vertices(mesh, &nv); const uint32_t *tri = clvox_mesh_triangles(mesh, &nt);
    double off[3]; clvox_mesh_vertex_offset(mesh, off);
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
    for (size_t i = 0; i < nv; i++) for (int a = 0; a < 3; a++) { double x = xyz[3 * i + a] + off[a]; if (x < lo[a]) lo[a] = x; if (x > hi[a]) hi[a] = x; }
    clvox_grid_options o = CLVOX_GRID_OPTIONS_INIT; o.resolution = N;
    clvox_grid g; if (clvox_grid_compute(ctx, &o, lo, hi, &g) != CLVOX_OK) return 1;
    uint32_t X = g.dims[0], Y = g.dims[1], Z = g.dims[2], W = (X + 31) / 32;
    float *soup = malloc((nt ? nt : 1) * 9 * sizeof *soup); int32_t *rng = malloc((nt ? nt : 1) * 4 * sizeof *rng); size_t kept = 0;
    if (!soup || !rng) { fprintf(stderr, "out of memory\n"); return 1; }
    for (size_t t = 0; t < nt; t++) {
        float *s = soup + kept * 9; int32_t r[6]; int in = 1;
        for (int c = 0; c < 3; c++) for (int a = 0; a < 3; a++)
            s[c * 3 + a] = (float)(((double)xyz[(size_t)tri[3 * t + c] * 3 + a] - (g.origin[a] - off[a])) / g.voxel_size[a] - 0.5);
        for (int a = 0; a < 3 && in; a++) {
            double mn = fmin(fmin(s[a], s[3 + a]), s[6 + a]), mx = fmax(fmax(s[a], s[3 + a]), s[6 + a]);
            in = cell_range(mn, mx, g.dims[a], &r[2 * a], &r[2 * a + 1]);
        }
        if (!in) continue;
        int32_t *q = rng + 4 * kept; q[0] = r[4], q[1] = r[5], q[2] = r[2], q[3] = r[3]; kept++;
    }
    const uint32_t slab = 76;
    size_t cap = 1 << 20, n = 0; uint *tasks = malloc(cap * 16);
    uint *bits = calloc((size_t)W * Y * slab, 4);
    if (!tasks || !bits) { fprintf(stderr, "out of memory\n"); return 1; }
    double best = 1e30; uint64_t filled = 0; size_t ntask = 0;
    for (int rep = 0; rep < reps; rep++) {
        double t = 0; filled = 0; ntask = 0;
        for (uint32_t z0 = 0; z0 < Z; z0 += slab) {
            uint32_t nz = Z - z0 < slab ? Z - z0 : slab; int32_t zend = (int32_t)(z0 + nz); n = 0;
            for (int32_t c0 = (int32_t)z0; c0 < zend; c0 += spt) {
                for (size_t i = 0; i < kept; i++) {
                    /* as bin_slab in src/raster/surface.c: runs of spt slices from the triangle's first slice in
                     * the slab, listed by the chunk of spt slices their first slice is in */
                    const int32_t *r = rng + 4 * i;
                    const int32_t first = r[0] > (int32_t)z0 ? r[0] : (int32_t)z0, last = r[1] < zend - 1 ? r[1] : zend - 1;
                    if (first > last || first > c0 + spt - 1) continue;
                    const int32_t a = first >= c0 ? first : first + (c0 - first + spt - 1) / spt * spt;
                    if (a > c0 + spt - 1 || a > last) continue;
                    const int32_t b = a + spt - 1 < last ? a + spt - 1 : last;
                    for (int32_t j = r[2]; j <= r[3]; j += rpt) {
                        int32_t j1 = j + rpt - 1 < r[3] ? j + rpt - 1 : r[3];
                        if (n == cap) { uint *t2 = realloc(tasks, cap * 2 * 16); if (!t2) { fprintf(stderr, "out of memory\n"); return 1; } tasks = t2, cap *= 2; }
                        uint *q = tasks + 4 * n++; q[0] = (uint)i, q[1] = (uint)a, q[2] = (uint)b + 1, q[3] = (uint)j | (uint)j1 << 16;
                    }
                }
            }
            memset(bits, 0, (size_t)W * Y * nz * 4);
            double t0 = now();
            for (g_gid = 0; g_gid < n; g_gid++) clvox_surface_raster(soup, tasks, (uint)n, z0, X, W, Y, bits);
            t += now() - t0;
            for (size_t w = 0; w < (size_t)W * Y * nz; w++) filled += (uint64_t)__builtin_popcount(bits[w]);
            ntask += n;
        }
        if (t < best) best = t;
    }
    printf("grid %ux%ux%u tasks %zu filled %llu raster cpu best %.4f s\n", X, Y, Z, ntask, (unsigned long long)filled, best);
    free(soup), free(rng), free(tasks), free(bits);
    clvox_mesh_destroy(mesh);
    clvox_context_destroy(ctx);
    return 0;
}
