/* SPDX-License-Identifier: Apache-2.0 */
/* The property check shared by the mesh fuzz targets (fuzz_mesh_<ext>.c:
 * libFuzzer, clang) and the replay test (tests/test_fuzz_smoke.c: gcc, every
 * seed and regression input, in `make test`).
 *
 * fuzz_mesh_check writes the input to a file with the given extension under
 * /dev/shm (else /tmp), loads it with clvox_mesh_load on a host-only context
 * and checks what came back. On success: a mesh whose vertex and triangle
 * views agree with its report, at least one triangle, every coordinate
 * finite, every index below the vertex count and no triangle with a repeated
 * index, every used vertex inside the report's bounding box, consistent
 * counts (triangles + dropped faces >= input faces, degenerate <= triangles,
 * closed == no boundary edge). On failure: no mesh, a one-line non-empty
 * message, and neither an internal error nor out-of-memory (inputs here are
 * small; an allocation they can drive to failure is a bug). Returns NULL when
 * all of that holds, else what failed (in a static buffer). */
#ifndef CLVOX_FUZZ_MESH_H
#define CLVOX_FUZZ_MESH_H
#include "clvox.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static clvox_context *fuzz_mesh_ctx;

static const char *fuzz_mesh_write(const char *ext, const uint8_t *data, size_t size)
{
    static char path[96];
    static const char *const dirs[] = {"/dev/shm", "/tmp"};
    for (int d = 0; d < 2; d++) {
        snprintf(path, sizeof path, "%s/clvox-fuzz-%ld.%s", dirs[d], (long)getpid(), ext);
        FILE *f = fopen(path, "wb");
        if (!f) continue;
        int ok = (!size || fwrite(data, 1, size, f) == size);
        ok &= fclose(f) == 0;
        if (ok) return path;
        unlink(path);
    }
    return NULL;
}

static const char *fuzz_mesh_check(const char *ext, const uint8_t *data, size_t size)
{
    static char why[600];
    if (!fuzz_mesh_ctx) {
        clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
        o.host_only = 1;
        if (clvox_context_create(&o, &fuzz_mesh_ctx) != CLVOX_OK) return "cannot create a host-only context";
    }
    clvox_context *ctx = fuzz_mesh_ctx;
    const char *path = fuzz_mesh_write(ext, data, size);
    if (!path) return "cannot write the input file";
    clvox_mesh *m = (clvox_mesh *)&why; /* must be overwritten */
    clvox_status st = clvox_mesh_load(ctx, path, &m);
    unlink(path);
    const char *msg = clvox_context_error(ctx);
#define FUZZ_FAIL(...) do { snprintf(why, sizeof why, __VA_ARGS__); clvox_mesh_destroy(st == CLVOX_OK ? m : NULL); \
                            return why; } while (0)
    if (st != CLVOX_OK) {
        if (m != NULL) FUZZ_FAIL("status %s but out is not NULL", clvox_status_string(st));
        if (!msg || !msg[0]) FUZZ_FAIL("status %s without a message", clvox_status_string(st));
        if (strchr(msg, '\n')) FUZZ_FAIL("message is not one line: %s", msg);
        if (st == CLVOX_ERR_INTERNAL || st == CLVOX_ERR_OUT_OF_MEMORY || st == CLVOX_ERR_INVALID_ARGUMENT)
            FUZZ_FAIL("status %s on a %zu-byte input: %s", clvox_status_string(st), size, msg);
        return NULL;
    }
    if (!m) FUZZ_FAIL("CLVOX_OK without a mesh");
    const clvox_mesh_report *r = clvox_mesh_get_report(m);
    size_t nv = 0, nt = 0;
    const float *xyz = clvox_mesh_vertices(m, &nv);
    const uint32_t *tri = clvox_mesh_triangles(m, &nt);
    if (!r || !xyz || !tri) FUZZ_FAIL("mesh without report, vertices or triangles");
    if (nt == 0 || nt != r->triangles) FUZZ_FAIL("%zu triangles, report says %llu", nt, (unsigned long long)r->triangles);
    if (nv != r->vertices || r->vertices > r->input_vertices)
        FUZZ_FAIL("%zu vertices, report says %llu (input %llu)", nv, (unsigned long long)r->vertices,
                  (unsigned long long)r->input_vertices);
    if (r->triangles + r->dropped_faces < r->input_faces || r->polygons_triangulated > r->input_faces)
        FUZZ_FAIL("report: %llu input faces, %llu triangles, %llu dropped, %llu polygons", (unsigned long long)r->input_faces,
                  (unsigned long long)r->triangles, (unsigned long long)r->dropped_faces,
                  (unsigned long long)r->polygons_triangulated);
    if (r->degenerate_triangles > r->triangles || r->nonmanifold_faces > r->triangles ||
        r->boundary_edges > 3 * r->triangles || r->closed != (r->boundary_edges == 0))
        FUZZ_FAIL("report: degenerate %llu, non-manifold %llu, boundary %llu, closed %d of %llu triangles",
                  (unsigned long long)r->degenerate_triangles, (unsigned long long)r->nonmanifold_faces,
                  (unsigned long long)r->boundary_edges, r->closed, (unsigned long long)r->triangles);
    if (!isfinite(r->enclosed_volume) || r->enclosed_volume < 0) FUZZ_FAIL("enclosed volume %g", r->enclosed_volume);
    for (int a = 0; a < 3; a++)
        if (!isfinite(r->bbox_min[a]) || !isfinite(r->bbox_max[a]) || r->bbox_min[a] > r->bbox_max[a])
            FUZZ_FAIL("bounding box axis %d: [%g, %g]", a, r->bbox_min[a], r->bbox_max[a]);
    double off[3];
    clvox_mesh_vertex_offset(m, off);
    for (int a = 0; a < 3; a++)
        if (!isfinite(off[a])) FUZZ_FAIL("vertex offset axis %d is %g", a, off[a]);
    for (size_t i = 0; i < 3 * nv; i++)
        if (!isfinite(xyz[i])) FUZZ_FAIL("vertex %zu has a non-finite coordinate", i / 3);
    for (size_t t = 0; t < nt; t++) {
        const uint32_t *c = tri + 3 * t;
        if (c[0] >= nv || c[1] >= nv || c[2] >= nv)
            FUZZ_FAIL("triangle %zu (%u %u %u) indexes past %zu vertices", t, c[0], c[1], c[2], nv);
        if (c[0] == c[1] || c[1] == c[2] || c[0] == c[2])
            FUZZ_FAIL("triangle %zu (%u %u %u) repeats a vertex", t, c[0], c[1], c[2]);
        for (int k = 0; k < 3; k++)
            for (int a = 0; a < 3; a++) {
                double v = xyz[3 * (size_t)c[k] + a] + off[a]; /* vertices are relative to the offset */
                if (v < r->bbox_min[a] || v > r->bbox_max[a])
                    FUZZ_FAIL("vertex %u outside the bounding box on axis %d", c[k], a);
            }
    }
#undef FUZZ_FAIL
    clvox_mesh_destroy(m);
    return NULL;
}

/* The libFuzzer entry point of one target: abort() on a failed property so
 * libFuzzer reports it and keeps the input. */
#define FUZZ_MESH_TARGET(ext)                                                  \
    int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);              \
    int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)               \
    {                                                                          \
        const char *why = fuzz_mesh_check(ext, data, size);                    \
        if (why) {                                                             \
            fprintf(stderr, "fuzz_mesh (.%s): %s\n", ext, why);                \
            abort();                                                           \
        }                                                                      \
        return 0;                                                              \
    }
#endif
