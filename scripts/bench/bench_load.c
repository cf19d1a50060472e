/* SPDX-License-Identifier: Apache-2.0 */
/* Mesh load throughput, not a test: clvox_mesh_load on each file with the
 * native readers and with OpenMesh's (CLVOX_MESH_READER=openmesh), best of R
 * runs, page cache warm (one untimed load first). MB/s = file bytes / best
 * seconds of the whole clvox_mesh_load (read + validation + mesh report).
 * "reader" columns time clvox__mesh_read_raw, the load up to build_mesh
 * (mmap, checks, parse into the final arrays), which is what the reader
 * choice changes; the rest (build_mesh: validation, edge and duplicate
 * analysis for the report) is the same for both readers.
 *   bench_load [-r R] FILE...
 *   bench_load --stl IN OUT.stl   writes IN's triangles as a binary STL
 *   bench_load --ascii obj|off|ply|stl IN OUT   writes them as text (%.9g: exact) */
#define _POSIX_C_SOURCE 200809L
#include "clvox.h"
#include "core/environment.h" /* the mesh_reader_openmesh switch */
#include "mesh/mesh_internal.h" /* clvox__mesh_read_raw: the reader alone (needs -Isrc) */

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static double best_raw(clvox_context *ctx, const char *path, int reps)
{
    double best = 1e30;
    for (int r = 0; r <= reps; r++) {
        clvox__raw_mesh raw;
        double t0 = now();
        if (clvox__mesh_read_raw(ctx, path, &raw) != CLVOX_OK) exit(1);
        double t = now() - t0;
        clvox__raw_mesh_free(&raw);
        if (r && t < best) best = t;
    }
    return best;
}

static double best_load(clvox_context *ctx, const char *path, int reps, size_t *nt)
{
    double best = 1e30;
    for (int r = 0; r <= reps; r++) {
        clvox_mesh *m = NULL;
        double t0 = now();
        if (clvox_mesh_load(ctx, path, &m) != CLVOX_OK) {
            fprintf(stderr, "%s: %s\n", path, clvox_context_error(ctx));
            exit(1);
        }
        double t = now() - t0;
        clvox_mesh_triangles(m, nt);
        clvox_mesh_destroy(m);
        if (r && t < best) best = t; /* run 0 warms the page cache */
    }
    return best;
}

int main(int argc, char **argv)
{
    clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
    o.host_only = 1;
    clvox_context *ctx;
    if (clvox_context_create(&o, &ctx) != CLVOX_OK) return 1;
    if (argc == 5 && !strcmp(argv[1], "--ascii")) { /* --ascii obj|off|ply|stl IN OUT */
        clvox_mesh *m = NULL;
        if (clvox_mesh_load(ctx, argv[3], &m) != CLVOX_OK) return fprintf(stderr, "%s\n", clvox_context_error(ctx)), 1;
        size_t nv, nt;
        const float *xyz = clvox_mesh_vertices(m, &nv);
        const uint32_t *t = clvox_mesh_triangles(m, &nt);
        double off[3];
        clvox_mesh_vertex_offset(m, off);
        FILE *f = fopen(argv[4], "w");
        if (!f) return perror(argv[4]), 1;
        const char *fmt = argv[2];
        /* %.9g: the float's value, read back exactly */
#define X(v, a) ((double)xyz[3 * (size_t)(v) + (a)] + off[a])
        if (!strcmp(fmt, "obj")) {
            fprintf(f, "# written by bench_load\n");
            for (size_t v = 0; v < nv; v++) fprintf(f, "v %.9g %.9g %.9g\n", X(v, 0), X(v, 1), X(v, 2));
            for (size_t i = 0; i < nt; i++) fprintf(f, "f %u %u %u\n", t[3 * i] + 1, t[3 * i + 1] + 1, t[3 * i + 2] + 1);
        } else if (!strcmp(fmt, "off") || !strcmp(fmt, "ply")) {
            if (fmt[0] == 'o') fprintf(f, "OFF\n%zu %zu 0\n", nv, nt);
            else
                fprintf(f, "ply\nformat ascii 1.0\nelement vertex %zu\nproperty float x\nproperty float y\n"
                           "property float z\nelement face %zu\nproperty list uchar int vertex_indices\nend_header\n",
                        nv, nt);
            for (size_t v = 0; v < nv; v++) fprintf(f, "%.9g %.9g %.9g\n", X(v, 0), X(v, 1), X(v, 2));
            for (size_t i = 0; i < nt; i++) fprintf(f, "3 %u %u %u\n", t[3 * i], t[3 * i + 1], t[3 * i + 2]);
        } else if (!strcmp(fmt, "stl")) {
            fprintf(f, "solid bench_load\n");
            for (size_t i = 0; i < nt; i++) {
                fprintf(f, "facet normal 0 0 0\nouter loop\n");
                for (int c = 0; c < 3; c++) {
                    uint32_t v = t[3 * i + c];
                    fprintf(f, "vertex %.9g %.9g %.9g\n", X(v, 0), X(v, 1), X(v, 2));
                }
                fprintf(f, "endloop\nendfacet\n");
            }
            fprintf(f, "endsolid bench_load\n");
        } else {
            return fprintf(stderr, "unknown format %s\n", fmt), 2;
        }
#undef X
        fclose(f);
        clvox_mesh_destroy(m);
        clvox_context_destroy(ctx);
        return 0;
    }
    if (argc == 4 && !strcmp(argv[1], "--stl")) {
        clvox_mesh *m = NULL;
        if (clvox_mesh_load(ctx, argv[2], &m) != CLVOX_OK) return fprintf(stderr, "%s\n", clvox_context_error(ctx)), 1;
        size_t nv, nt;
        const float *xyz = clvox_mesh_vertices(m, &nv);
        const uint32_t *t = clvox_mesh_triangles(m, &nt);
        FILE *f = fopen(argv[3], "wb");
        char head[80] = "solid binary STL written by bench_load";
        uint32_t n32 = (uint32_t)nt;
        fwrite(head, 1, 80, f);
        fwrite(&n32, 4, 1, f);
        for (size_t i = 0; i < nt; i++) {
            float rec[12] = {0};
            for (int c = 0; c < 3; c++) memcpy(rec + 3 + 3 * c, xyz + 3 * (size_t)t[3 * i + c], 12);
            fwrite(rec, 4, 12, f);
            fwrite("\0", 1, 2, f);
        }
        fclose(f);
        clvox_mesh_destroy(m);
        clvox_context_destroy(ctx);
        return 0;
    }
    int reps = 5, first = 1;
    if (argc > 2 && !strcmp(argv[1], "-r")) reps = atoi(argv[2]), first = 3;
    printf("| file | MB | triangles | load native s | load OpenMesh s | reader native s | reader native MB/s | "
           "reader OpenMesh s | reader OpenMesh MB/s | reader speed-up |\n");
    printf("|---|---|---|---|---|---|---|---|---|---|\n");
    for (int i = first; i < argc; i++) {
        struct stat sb;
        if (stat(argv[i], &sb) != 0) continue;
        double mb = (double)sb.st_size / 1e6;
        size_t nt = 0;
        clvox__test_hooks native = *clvox__hooks(), openmesh = native;
        native.mesh_reader_openmesh = 0;
        openmesh.mesh_reader_openmesh = 1;
        clvox__set_test_hooks(&native);
        double tn = best_load(ctx, argv[i], reps, &nt);
        double rn = best_raw(ctx, argv[i], reps);
        clvox__set_test_hooks(&openmesh);
        double to = best_load(ctx, argv[i], reps < 3 ? reps : 3, &nt);
        double ro = best_raw(ctx, argv[i], reps < 3 ? reps : 3);
        clvox__set_test_hooks(NULL);
        const char *name = strrchr(argv[i], '/');
        printf("| %s | %.1f | %zu | %.3f | %.3f | %.4f | %.0f | %.3f | %.0f | %.1fx |\n", name ? name + 1 : argv[i], mb,
               nt, tn, to, rn, mb / rn, ro, mb / ro, ro / rn);
        fflush(stdout);
    }
    clvox_context_destroy(ctx);
    return 0;
}
