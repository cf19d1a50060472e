/* SPDX-License-Identifier: Apache-2.0 */
/* The mesh stage's parts: the loader (mesh_load.c), the per-format checks
 * and readers, the build and the report. Internal. */
#ifndef CLVOX_MESH_INTERNAL_H
#define CLVOX_MESH_INTERNAL_H
#include "core/internal.h"

/* What a format's check learnt about the file; the mesh OpenMesh returns
 * must agree. */
typedef struct clvox__mesh_expect {
    int have_vertices, have_faces;
    uint64_t vertices, faces;
} clvox__mesh_expect;

/* The per-format checks (mesh_<format>.c), on the whole file p[0..n) (a NUL
 * after it). Each checks the file the way OpenMesh's reader will consume it,
 * and where clvox reads the format itself (native readers) reads it into
 * *raw and sets *parsed (else OpenMesh reads the file, and *ex, where given,
 * says what it must find). On failure *raw is empty. */
clvox_status clvox__mesh_check_obj(clvox_context *ctx, const char *path, const char *p, size_t n,
                                   clvox__raw_mesh *raw, int *parsed);
clvox_status clvox__mesh_check_off(clvox_context *ctx, const char *path, const unsigned char *p, size_t n,
                                   clvox__mesh_expect *ex, clvox__raw_mesh *raw, int *parsed);
clvox_status clvox__mesh_check_ply(clvox_context *ctx, const char *path, const unsigned char *p, size_t n,
                                   clvox__mesh_expect *ex, clvox__raw_mesh *raw, int *parsed);
clvox_status clvox__mesh_check_stl(clvox_context *ctx, const char *path, const unsigned char *p, size_t n,
                                   clvox__raw_mesh *raw, int *parsed);
clvox_status clvox__mesh_check_om(clvox_context *ctx, const char *path, const unsigned char *p, size_t n);

/* The validated mesh (mesh_build.c). Takes ownership of xyz (freed on
 * failure). sizes == NULL: all faces are triangles. `what` names the source
 * in messages. idx_owned: idx itself, handed over (malloc'ed, freed on
 * failure), when sizes == NULL: the triangles are then compacted in place,
 * so no second index array is made; else NULL. */
clvox_status clvox__mesh_build(clvox_context *ctx, const char *what, float *xyz, const double offset[3], size_t nv,
                               const uint32_t *sizes, const uint32_t *idx, size_t nf, size_t index_count,
                               uint64_t loader_nonmanifold, uint32_t *idx_owned, clvox_mesh **out);


/* clvox_mesh_load up to clvox__mesh_build: the file read into raw (the reader
 * alone; scripts/bench/bench_load.c times it). */
clvox_status clvox__mesh_read_raw(clvox_context *ctx, const char *path, clvox__raw_mesh *raw);

/* 1 unless CLVOX_MESH_READER=openmesh (for tests: compare with OpenMesh). */
int clvox__mesh_native_enabled(void);

/* The report's analysis of validated triangles (mesh_report.c): fills
 * bbox_min/bbox_max (relative to the mesh offset), degenerate_triangles,
 * enclosed_volume, boundary_edges, nonmanifold_faces (without the loader's)
 * and duplicate_triangles of *r. threads: host threads to use (0: the
 * default, clvox__host_threads()); the result does not depend on it.
 * reference != 0: the earlier single-threaded implementation, for tests.
 * nt >= 1. vol gets the signed volume sum and its bound
 * (clvox__mesh_volume). Returns 0, or -1 when memory runs out. */
int clvox__mesh_analyze(const float *xyz, size_t nv, const uint32_t *tris, size_t nt, int threads, int reference,
                        clvox_mesh_report *r, clvox__mesh_volume *vol);
#endif
