/* SPDX-License-Identifier: Apache-2.0 */
/* Mesh readers shared between mesh.c (checks, dispatch, build) and the native
 * binary readers (mesh_ply.c, mesh_stl.c). Internal. */
#ifndef CLVOX_MESH_INTERNAL_H
#define CLVOX_MESH_INTERNAL_H
#include "core/internal.h"

#define PLY_MAX_HEADER (64u * 1024u)
#define PLY_MAX_ELEMENTS 16
#define PLY_MAX_PROPS 64
#define PLY_NAME 64

enum ply_format { PLY_ASCII, PLY_LE, PLY_BE };

typedef struct ply_type { const char *name; int size, is_float, is_signed; } ply_type;

typedef struct ply_prop {
    char name[PLY_NAME];
    const ply_type *type;       /* value (list item) type */
    const ply_type *count_type; /* NULL: scalar */
} ply_prop;

typedef struct ply_elem {
    char name[PLY_NAME];
    uint64_t count;
    ply_prop props[PLY_MAX_PROPS];
    int nprops;
} ply_elem;

typedef struct ply_header {
    enum ply_format format;
    ply_elem elems[PLY_MAX_ELEMENTS];
    int nelems, vertex, face; /* element indices, -1 if absent */
    size_t body;              /* offset of the first byte after the header */
} ply_header;


/* clvox_mesh_load up to build_mesh: the file read into raw (the reader
 * alone; scripts/bench_load.c times it). */
clvox_status clvox__mesh_read_raw(clvox_context *ctx, const char *path, clvox__raw_mesh *raw);

/* 1 unless CLVOX_MESH_READER=openmesh (for tests: compare with OpenMesh). */
int clvox__mesh_native_enabled(void);

/* Binary PLY body (little or big endian) into raw, as OpenMesh's reader
 * would hand it over. The header is parsed and the body walked
 * (ply_check_binary) before this is called. */
clvox_status clvox__ply_read_binary(clvox_context *ctx, const char *path, const unsigned char *p, size_t n,
                                    const ply_header *h, clvox__raw_mesh *raw);

/* Binary STL (n == 84 + 50 count, finite coordinates: checked before) into
 * raw, vertices merged as OpenMesh's reader merges them. Returns 0 on
 * success, 1 when the file holds a coordinate that OpenMesh's tolerant
 * comparison could merge with a different value (|x| < 2^-100, x != 0: the
 * caller falls back to OpenMesh), -2 when memory runs out. */
int clvox__stl_read_binary(const unsigned char *p, size_t n, clvox__raw_mesh *raw);

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
