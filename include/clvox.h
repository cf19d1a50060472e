/* SPDX-License-Identifier: Apache-2.0 */
/* Past 800 lines on purpose: the whole public API in one header, as users
 * include it; sections follow the pipeline. */
/*
 * clvox — OpenCL voxelization of triangle meshes, streamed to OpenEXR.
 *
 * Pipeline: mesh -> grid -> partition -> cast -> consumer (classify: occupancy
 * bits, or coverage: grey levels) -> write; or the tetra raster -> write.
 *
 * Conventions
 *  - Every function that can fail returns a clvox_status; the detail message
 *    of the last failure is clvox_context_error(ctx). Nothing is printed.
 *  - Option structs: zero means "default". Initialise them with the
 *    CLVOX_*_INIT macros (they set .size for binary stability).
 *  - Output structs that may grow (clvox_stats, clvox_volume_info,
 *    clvox_device_info, clvox_palette_element_info, clvox_ply_totals,
 *    clvox_mesh_source_info) also
 *    begin with `size_t size`: the caller sets it to sizeof the struct it
 *    was compiled with (the CLVOX_*_INIT macros do) before the call, and the
 *    library writes only that many bytes, so a program built against this
 *    header keeps working with a later library whose struct has grown at the
 *    end. A size smaller than the struct of the first version with .size
 *    (this one) or larger than the library's is CLVOX_ERR_INVALID_ARGUMENT,
 *    nothing written. The library sets .size in what it returns by pointer.
 *    New members are only ever appended.
 *  - Only the functions marked CLVOX_API are exported by the shared library.
 *  - Arrays passed in are borrowed for the duration of the call, never kept.
 *  - Voxel (i,j,k) covers [origin + (i,j,k)*h, origin + (i+1,j+1,k+1)*h) and is
 *    sampled at its centre origin + (i+0.5, j+0.5, k+0.5)*h.
 */
#ifndef CLVOX_H
#define CLVOX_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define CLVOX_VERSION_MAJOR 0
#define CLVOX_VERSION_MINOR 1
#define CLVOX_VERSION_PATCH 0
#define CLVOX_VERSION_STRING "0.1.0"

/* Marks the exported functions. The library is compiled with
 * -fvisibility=hidden and CLVOX_BUILD_LIBRARY, so libclvox.so exports these
 * and nothing else (its internals, clvox__*, stay inside); for a program
 * using the library the macro is empty. */
#if defined(CLVOX_BUILD_LIBRARY) && (defined(__GNUC__) || defined(__clang__))
#define CLVOX_API __attribute__((visibility("default")))
#else
#define CLVOX_API
#endif

/* ---- status ------------------------------------------------------------ */

typedef enum clvox_status {
    CLVOX_OK = 0,
    CLVOX_ERR_INVALID_ARGUMENT, /* a bad parameter from the caller            */
    CLVOX_ERR_OUT_OF_MEMORY,    /* host or device allocation failed           */
    CLVOX_ERR_IO,               /* file missing, unreadable or unwritable     */
    CLVOX_ERR_MESH_FORMAT,      /* unknown extension, garbage, truncated file */
    CLVOX_ERR_MESH_INVALID,     /* non-finite coordinates, bad indices        */
    CLVOX_ERR_MESH_EMPTY,       /* no usable triangle                         */
    CLVOX_ERR_GRID,             /* zero, negative or too large grid           */
    CLVOX_ERR_NO_DEVICE,        /* no OpenCL platform/device matches          */
    CLVOX_ERR_OPENCL,           /* an OpenCL call failed                      */
    CLVOX_ERR_KERNEL_BUILD,     /* kernel compilation failed (log in message) */
    CLVOX_ERR_EXR,              /* OpenEXR encode/decode/format failure       */
    CLVOX_ERR_CANCELLED,        /* the progress callback asked to stop        */
    CLVOX_ERR_INTERNAL,         /* a bug in clvox                             */
    CLVOX_ERR_PALETTE_FORMAT,   /* malformed palette or render map file (line in message) */
    CLVOX_STATUS_COUNT
} clvox_status;

/* Static, never NULL. */
CLVOX_API const char *clvox_status_string(clvox_status status);
CLVOX_API const char *clvox_version(void);

/* ---- context and devices ------------------------------------------------ */

typedef struct clvox_context clvox_context;

typedef struct clvox_context_options {
    size_t size;
    /* Device selection. NULL or "" = the environment variable CLVOX_DEVICE if
     * set, else "auto": the first GPU if any, else the first CPU device
     * (PoCL). Otherwise one of: "auto", "gpu", "cpu", "accelerator", a
     * global device index as listed by clvox_list_devices ("0", "1", ...),
     * or a case-insensitive substring of the device or platform name. */
    const char *device;
    /* 1: open no OpenCL device; enough for loading meshes, computing grids
     * and reading volumes (clvox info), not for voxelizing. */
    int host_only;
    /* appended in 0.3: 1 = build every device's kernels without double
     * precision, as on a device without cl_khr_fp64 (which always gets
     * them): the same voxels in every mode (docs/design.md "Devices
     * without double precision"), and faster where double is slow (most
     * consumer GPUs run it at 1/16 to 1/64 of float). 0: by speed: double
     * where the device has it, unless its double measures 8 or more times
     * slower than its float (then float, but for a mesh with a coordinate
     * outside float's exact range; clvox_device_info.kernels_float). */
    int float_kernels;
} clvox_context_options;
#define CLVOX_CONTEXT_OPTIONS_INIT { sizeof(clvox_context_options), NULL, 0, 0 }

typedef struct clvox_device_info {
    size_t size;           /* sizeof(clvox_device_info): set by the caller (see Conventions) */
    uint32_t index;        /* global index, usable as the device selector */
    char name[128];
    char platform[128];
    char type[16];         /* "gpu", "cpu", "accelerator", "other" */
    char version[64];      /* CL_DEVICE_VERSION */
    uint32_t compute_units;
    uint64_t global_mem_bytes;
    uint64_t max_alloc_bytes;
    /* appended in 0.2: 1 when the device has double precision
     * (CL_DEVICE_DOUBLE_FP_CONFIG); one without it gets kernels built in
     * float (clvox_context_options.float_kernels). */
    int fp64;
    /* appended in 0.3, set in a context's devices (clvox_context_device_at;
     * 0 in clvox_list_devices): 1 when the context runs the kernels in
     * float there: the device has no fp64, float_kernels asked for it, or
     * its double arithmetic measured 8 or more times slower than its float
     * (then a run whose mesh has a coordinate outside float's exact range
     * switches to double). The voxels are the same either way
     * (docs/design.md "Which build a device gets"). */
    int kernels_float;
    /* how many times slower the device ran double than float (the same
     * chains of multiply-adds), once per device and driver, kept in the
     * kernel cache; 0 where not measured: no fp64, or a CPU (they keep
     * double). CLVOX_FP64_SLOWDOWN=R sets it. */
    float fp64_slowdown;
} clvox_device_info;
#define CLVOX_DEVICE_INFO_INIT { .size = sizeof(clvox_device_info) }

/* Fills up to `capacity` entries; *count receives the number of devices
 * present (may exceed capacity). Returns CLVOX_ERR_NO_DEVICE when none.
 * With capacity > 0, out[0].size is the size of the caller's struct, and so
 * the distance between entries: every entry written gets that size. */
CLVOX_API clvox_status clvox_list_devices(clvox_device_info *out, size_t capacity, size_t *count);

/* Creates a context on the selected device and builds the kernels.
 * On failure *out is still set to a context that holds the error message
 * (so clvox_context_error works) and must be destroyed; it can not be
 * used for anything else. */
CLVOX_API clvox_status clvox_context_create(const clvox_context_options *options, clvox_context **out);
CLVOX_API void clvox_context_destroy(clvox_context *ctx);            /* NULL-safe */
CLVOX_API const char *clvox_context_error(const clvox_context *ctx);  /* "" if none */
CLVOX_API const clvox_device_info *clvox_context_device(const clvox_context *ctx);

/* Device sets. clvox_context_options.device may also be a comma-separated
 * list of the selectors above ("0,1", "cpu,gpu") or "all" (every device of
 * every platform): the context then holds each of those devices (one
 * OpenCL context and queue each, kernels built per device), and every
 * voxelization spreads its slabs over them (docs/design.md "Several
 * devices"); the volume is the same, bit for bit, whatever the set. A
 * device of a set that cannot be used is left out with a warning: its
 * kernels fail to build, or its kernels would compute differently from the
 * first device's (today: one has cl_khr_fp64 and the other not). At most
 * CLVOX_MAX_DEVICES devices. clvox_context_device is the first of them. */
#define CLVOX_MAX_DEVICES 16u
CLVOX_API size_t clvox_context_device_count(const clvox_context *ctx); /* 0 for host_only */
CLVOX_API const clvox_device_info *clvox_context_device_at(const clvox_context *ctx, size_t i); /* NULL past the end */
/* What the context's creation and its latest voxelization warn of, one
 * line each ("device 1 'X' left out: ..."), or "". Not errors: the run
 * succeeded without the device named. */
CLVOX_API const char *clvox_context_warnings(const clvox_context *ctx);

/* ---- mesh ---------------------------------------------------------------- */

/* A mesh holds no reference to the context that made it: it may be loaded on
 * a host_only context and voxelized on another. */
typedef struct clvox_mesh clvox_mesh;

typedef struct clvox_mesh_report {
    uint64_t input_vertices;
    uint64_t input_faces;         /* polygons as read, before triangulation     */
    uint64_t polygons_triangulated; /* faces with more than 3 corners (fanned)  */
    uint64_t vertices;
    uint64_t triangles;           /* triangles kept                              */
    uint64_t dropped_faces;       /* repeated vertex index: no area, removed     */
    uint64_t degenerate_triangles;/* zero area (collinear corners), kept         */
    uint64_t nonmanifold_faces;   /* triangles on a "complex" (non-manifold) edge, kept */
    uint64_t boundary_edges;      /* edges used by an odd number of triangles    */
    int closed;                   /* 1 when boundary_edges == 0                  */
    double bbox_min[3], bbox_max[3];
    double enclosed_volume;       /* |sum of signed tetra volumes|; exact only when closed */
    uint64_t duplicate_triangles; /* same three corner positions (any order or orientation)
                                     as an earlier triangle, shared vertices or not; kept.
                                     Coincident copies cancel under the parity rule */
} clvox_mesh_report;

/* Loads OBJ, OFF, PLY (ascii/binary), STL (ascii/binary), OM by extension
 * with clvox's own readers, and every other format Assimp reads (glTF 2.0
 * .gltf/.glb, 3MF, FBX, DAE, 3DS, ...) through Assimp: the scene flattened
 * with every node's transform (a mesh placed by two nodes appears twice),
 * all its meshes one mesh, lines and points left out (counted in
 * clvox_mesh_get_source_info). Assimp parses in a child process (fork):
 * its readers abort or crash on some bad files, which is then
 * CLVOX_ERR_MESH_FORMAT ("the reader crashed ..."), not the end of the
 * caller. Validates: non-finite coordinates and out-of-range indices are
 * errors, empty meshes are errors; polygons are fan-triangulated. */
CLVOX_API clvox_status clvox_mesh_load(clvox_context *ctx, const char *path, clvox_mesh **out);

/* Where a mesh came from: one file's scene. */
typedef struct clvox_mesh_source_info {
    size_t size;              /* sizeof(clvox_mesh_source_info): set by the caller (see Conventions) */
    char reader[16];          /* "obj", "off", "ply", "stl", "om" (clvox's readers), "assimp" or "arrays" */
    uint32_t meshes;          /* meshes in the scene (Assimp: after splitting by primitive type) */
    uint64_t placements;      /* mesh placements flattened (node references; >= meshes used) */
    uint64_t ignored_lines;   /* line and point primitives left out, over all placements */
    uint64_t ignored_points;
    double unit_metres;       /* metres per file unit where the format states it (glTF: 1,
                                 FBX: UnitScaleFactor / 100), else 0 */
} clvox_mesh_source_info;
#define CLVOX_MESH_SOURCE_INFO_INIT { .size = sizeof(clvox_mesh_source_info) }
CLVOX_API clvox_status clvox_mesh_get_source_info(const clvox_mesh *mesh, clvox_mesh_source_info *out);
/* Per triangle (clvox_mesh_triangles' order), the index of the scene mesh it
 * came from (Assimp's mesh index: one material each), or NULL where the mesh
 * has one source (clvox's own readers, arrays). */
CLVOX_API const uint32_t *clvox_mesh_triangle_sources(const clvox_mesh *mesh, size_t *triangle_count);

/* Copies the caller's arrays (borrowed): xyz has 3*vertex_count floats,
 * triangles has 3*triangle_count indices. Same validation as loading. */
CLVOX_API clvox_status clvox_mesh_from_arrays(clvox_context *ctx, const float *xyz, size_t vertex_count,
                                              const uint32_t *triangles, size_t triangle_count,
                                              clvox_mesh **out);
CLVOX_API void clvox_mesh_destroy(clvox_mesh *mesh); /* NULL-safe */
CLVOX_API const clvox_mesh_report *clvox_mesh_get_report(const clvox_mesh *mesh);
/* Borrowed views of the validated triangle soup (valid while the mesh lives).
 * The vertices are relative to clvox_mesh_vertex_offset: OFF and OBJ files
 * are read in double and stored relative to their first vertex, so a mesh far
 * from the origin keeps the precision of its file (a float at 1e6 is only
 * 0.0625 precise); other formats (float32 in the file) and meshes from arrays
 * have offset 0. The report's bounding box is absolute. */
CLVOX_API const float *clvox_mesh_vertices(const clvox_mesh *mesh, size_t *vertex_count);
CLVOX_API void clvox_mesh_vertex_offset(const clvox_mesh *mesh, double offset[3]);
CLVOX_API const uint32_t *clvox_mesh_triangles(const clvox_mesh *mesh, size_t *triangle_count);

/* ---- grid ---------------------------------------------------------------- */

typedef struct clvox_grid_options {
    size_t size;
    /* Exactly one of resolution / dims / voxel_size may be set (0 = unset);
     * none set means resolution 256. */
    uint32_t resolution;   /* N voxels along the longest box axis, cubic voxels */
    uint32_t dims[3];      /* voxels per axis, box divided evenly (anisotropic) */
    double voxel_size[3];  /* voxel size per axis; ceil(extent / size) voxels   */
    int use_box;           /* 1: box_min/box_max replace the mesh bounding box  */
    double box_min[3], box_max[3];
    uint32_t padding;      /* empty voxels added on every side                  */
    /* 1: the box (the mesh's, or box_min/box_max) is first made a cube around
     * its centre, as binvox does: every axis gets the longest edge L, from
     * centre - L/2 to centre + L/2 (the longest axis keeps its own bounds).
     * -r N then gives N x N x N voxels of size L/N, a voxel size S gives
     * ceil(L/S) per axis; dims must be N,N,N and voxel_size one value
     * (CLVOX_ERR_GRID otherwise). Padding is added after, on every side. */
    int cube;
} clvox_grid_options;
#define CLVOX_GRID_OPTIONS_INIT { sizeof(clvox_grid_options), 0, {0,0,0}, {0,0,0}, 0, {0,0,0}, {0,0,0}, 0, 0 }

typedef struct clvox_grid {
    uint32_t dims[3];      /* voxels along x, y, z                           */
    double origin[3];      /* corner of voxel (0,0,0)                        */
    double voxel_size[3];  /* h per axis                                     */
} clvox_grid;

/* Largest grid accepted: each axis <= CLVOX_MAX_AXIS and the total voxel
 * count <= CLVOX_MAX_VOXELS (2^40, about 2 TB of half values uncompressed). */
#define CLVOX_MAX_AXIS 65536u
#define CLVOX_MAX_VOXELS (1ull << 40)

CLVOX_API clvox_status clvox_grid_compute(clvox_context *ctx, const clvox_grid_options *options,
                                          const double bbox_min[3], const double bbox_max[3],
                                          clvox_grid *out);

/* The grid of an existing volume, to make another on the same voxels
 * (clvox --like; grid_like.c). The caller reads the file; `name` names it
 * in messages. Errors: CLVOX_ERR_GRID with one line "NAME: why".
 * From a NRRD header (.nrrd or .nhdr, clvox's or another tool's): `data`
 * holds the file's first `len` bytes (not NUL-terminated; the header ends at
 * the first blank line, or at the end of `data` when it names a "data
 * file"). Only 3-D scalar, axis-aligned grids with positive steps; the clvox
 * origin is "space origin" minus h/2 (or clvox_origin_corner:= when it
 * agrees). *note (may be NULL) gets "" or one line on what was assumed (a
 * space other than LPS). */
CLVOX_API clvox_status clvox_grid_from_nrrd_header(clvox_context *ctx, const char *name, const char *data,
                                                   size_t len, clvox_grid *out, char *note, size_t note_size);
/* From the JSON sidecar clvox writes next to a .npy (the whole file in
 * `data`: "format": "npy", dims, origin, voxel_size; shape checked when
 * present). Whether the .npy files agree with it is clvox_npy_set_complete. */
CLVOX_API clvox_status clvox_grid_from_npy_sidecar(clvox_context *ctx, const char *name, const char *data,
                                                   size_t len, clvox_grid *out);

/* ---- voxelization ---------------------------------------------------------- */

typedef enum clvox_method {
    CLVOX_METHOD_RAY = 0,   /* Thon et al.: quadtree + ray parity (default) */
    CLVOX_METHOD_TETRA,     /* Rueda et al.: XOR of centroid tetrahedra       */
    CLVOX_METHOD_COUNT
} clvox_method;

typedef enum clvox_axis {
    CLVOX_AXIS_DEFAULT = 0, /* x: slabs are independent, one ray per image row */
    CLVOX_AXIS_X,
    CLVOX_AXIS_Y,
    CLVOX_AXIS_Z
} clvox_axis;

typedef enum clvox_compression {
    CLVOX_COMPRESSION_DEFAULT = 0, /* RLE: fastest to write, see README; ZIP for files
                                      with an element channel (RLE cannot shrink UINT) */
    CLVOX_COMPRESSION_NONE,
    CLVOX_COMPRESSION_RLE,
    CLVOX_COMPRESSION_ZIPS,
    CLVOX_COMPRESSION_ZIP,
    CLVOX_COMPRESSION_PIZ,
    CLVOX_COMPRESSION_COUNT
} clvox_compression;

typedef enum clvox_tetra_origin {
    CLVOX_TETRA_ORIGIN_CENTROID = 0, /* area-weighted surface centroid (default) */
    CLVOX_TETRA_ORIGIN_BBOX_CENTER,
    CLVOX_TETRA_ORIGIN_POINT         /* tetra_point */
} clvox_tetra_origin;

typedef enum clvox_stage {
    CLVOX_STAGE_LOAD = 0,  /* filled by the CLI / caller, not by clvox_voxelize */
    CLVOX_STAGE_PARTITION, /* quadtree build and upload (ray); binning (tetra)   */
    CLVOX_STAGE_CAST,      /* leaf lookup + intersection + sort (device time)    */
    CLVOX_STAGE_CLASSIFY,  /* parity classification / XOR raster (device time)   */
    CLVOX_STAGE_WRITE,     /* EXR encode + write (host)                          */
    CLVOX_STAGE_TOTAL,     /* wall time of the whole call                        */
    CLVOX_STAGE_COUNT
} clvox_stage;

CLVOX_API const char *clvox_stage_name(clvox_stage stage);

/* Called after each slab, and at most 10 times a second between the
 * batches of a slow slab (so a cancel is seen within about 0.3 s on a 2-core
 * CPU device), with the fraction done in (0,1], increasing. Return 0 to
 * cancel (the call then returns CLVOX_ERR_CANCELLED, no file is left). */
typedef int (*clvox_progress_fn)(void *user, double fraction);

typedef struct clvox_palette clvox_palette;

/* Palette scoring metrics (Cavagnino & Gribaudo, Table 1). */
typedef enum clvox_metric {
    CLVOX_METRIC_NEAREST = 0, /* most sample points where element and object agree      */
    CLVOX_METRIC_OUTER,       /* the same, among elements holding every object sample   */
    CLVOX_METRIC_INNER,       /* the same, among elements holding no empty-space sample */
    CLVOX_METRIC_COUNT
} clvox_metric;

/* What a voxel holds (clvox_voxelize_options.mode). */
typedef enum clvox_mode {
    CLVOX_MODE_SOLID = 0,    /* inside: the voxel centre is inside the mesh (parity; default) */
    CLVOX_MODE_SURFACE,      /* the voxel's closed cell meets a triangle (exact; any soup) */
    CLVOX_MODE_CONSERVATIVE, /* solid or surface: every voxel the solid touches */
    CLVOX_MODE_COUNT
} clvox_mode;
/* "solid", "surface", "conservative"; NULL for a bad value. */
CLVOX_API const char *clvox_mode_name(clvox_mode mode);

/* The inside test of solid voxels and samples (clvox_voxelize_options.inside;
 * docs/design.md "Winding numbers"). */
typedef enum clvox_inside {
    CLVOX_INSIDE_DEFAULT = 0, /* winding for the ray method; tetra is parity by construction */
    CLVOX_INSIDE_WINDING,     /* generalized winding number w(p) > 1/2 after mesh preparation:
                                 exact on open, cracked, mis-oriented and overlapping meshes;
                                 the same voxels as parity on closed, consistent meshes */
    CLVOX_INSIDE_WINDING_ABS, /* |w(p)| > 1/2: also keeps wholly inverted parts */
    CLVOX_INSIDE_PARITY,      /* odd number of crossings beyond the point (Thon 3.3.3) */
    CLVOX_INSIDE_COUNT
} clvox_inside;
/* "winding", "winding-abs", "parity" ("default" for DEFAULT); NULL for a bad value. */
CLVOX_API const char *clvox_inside_name(clvox_inside inside);

typedef struct clvox_voxelize_options {
    size_t size;
    clvox_method method;
    clvox_axis ray_axis;
    uint32_t quadtree_max_depth;   /* 0 = auto (docs/design.md)                   */
    uint32_t quadtree_leaf_size;   /* split while a leaf holds more; 0 = auto    */
    uint32_t slab_depth;           /* slices per slab; 0 = auto (memory-bounded) */
    uint32_t hit_capacity;         /* crossings kept per ray in the fast pass; 0 = auto (32);
                                      rays with more are redone with a larger buffer */
    clvox_compression compression;
    uint32_t threads;              /* host encoder threads; 0 = number of cores  */
    clvox_tetra_origin tetra_origin;
    double tetra_point[3];
    clvox_progress_fn progress;
    void *progress_user;
    /* Grey levels (coverage; Thon et al. 3.3.4; ray method only). Each voxel
     * column gets oversample x oversample rays, each ray oversample_points
     * points per voxel; coverage = points inside / (oversample^2 * points).
     * 0 = no oversampling: one sample at the voxel centre (binary). */
    uint32_t oversample;           /* N: N x N rays per voxel column (1 .. CLVOX_MAX_OVERSAMPLE) */
    uint32_t oversample_points;    /* M: points per voxel along each ray; 0 = N      */
    int stochastic;                /* 1: stratified jitter of rays and points, from seed */
    uint64_t seed;                 /* sampler seed (stochastic only); default 0      */
    uint32_t channels;             /* CLVOX_CHANNEL_* mask; 0 = auto: occupancy when binary,
                                      coverage when oversampled, occupancy (= coverage > threshold)
                                      when oversampled with threshold_set */
    int threshold_set;             /* 1: occupancy = coverage > threshold when oversampled */
    double threshold;              /* in [0,1]; used when threshold_set (else 0.5)   */
    /* Palette voxelization (Cavagnino & Gribaudo; ray method only). Each
     * voxel gets the element of `palette` with the best score under
     * `metric`, estimated from t = oversample^2 rays x p = oversample_points
     * points per voxel (the coverage sampler; oversample 0 = t = p = 16).
     * NULL: no palette scoring. Borrowed for the call. */
    const clvox_palette *palette;
    clvox_metric metric;
    int palette_no_early_out;      /* 1: score every voxel, even wholly inside or outside ones */
    /* Nearest only, off by default (the paper's alpha/beta shortcut): empty
     * when fewer than alpha*t*p samples are inside, full when more than
     * beta*t*p are, without scoring; 0 < alpha < beta < 1. */
    int nearest_shortcut;
    double shortcut_alpha, shortcut_beta;
    /* Solid (default), surface or conservative (docs/design.md "Surface
     * voxelization"). Surface and conservative are binary (occupancy only:
     * no oversampling, no palette); surface ignores the method, conservative
     * ORs the surface over the method's solid. */
    clvox_mode mode;
    /* Inside test (ray method): winding by default, parity on request. */
    clvox_inside inside;
    /* Winding only: vertices within distance `weld` of each other (mesh
     * units, Euclidean; transitively) are merged into the lowest-numbered one
     * before orientation repair, closing cracks; 0 = only vertices at exactly
     * equal positions are merged. */
    double weld;
} clvox_voxelize_options;
#define CLVOX_VOXELIZE_OPTIONS_INIT { sizeof(clvox_voxelize_options), CLVOX_METHOD_RAY, \
    CLVOX_AXIS_DEFAULT, 0, 0, 0, 0, CLVOX_COMPRESSION_DEFAULT, 0, CLVOX_TETRA_ORIGIN_CENTROID, \
    {0,0,0}, NULL, NULL, 0, 0, 0, 0, 0, 0, 0.0, NULL, CLVOX_METRIC_NEAREST, 0, 0, 0.0, 0.0, CLVOX_MODE_SOLID, \
    CLVOX_INSIDE_DEFAULT, 0.0 }

/* Optional, for a caller with other work to do meanwhile: when a
 * voxelization with `options` (NULL: the defaults) runs the winding inside
 * test -- the default of the ray method's solid and conservative modes --
 * starts its mesh preparation (merging, welding within options->weld,
 * orientation, holes and their caps; docs/design.md "Winding numbers") on
 * a host thread of its own and returns at once; else does nothing. The
 * next voxelization of this mesh with the winding test takes it when its
 * weld is the same (else drops it and prepares), waiting for it if need
 * be; its errors are that voxelization's. clvox_mesh_destroy waits for it.
 * The command-line tool starts it while it creates the device context. The
 * result is the same either way. Returns CLVOX_OK (also when one for this
 * weld is on its way), or an error for a bad weld or when no thread could
 * be started (nothing changed). */
CLVOX_API clvox_status clvox_mesh_prepare_winding(clvox_context *ctx, clvox_mesh *mesh, const clvox_voxelize_options *options);

/* Per-voxel channels a run can produce (clvox_voxelize_options.channels). */
#define CLVOX_CHANNEL_OCCUPANCY 0x1u /* 0/1: inside (binary), or coverage > threshold */
#define CLVOX_CHANNEL_COVERAGE 0x2u  /* fraction of the voxel's samples inside, [0,1] */
#define CLVOX_CHANNEL_ELEMENT 0x4u   /* palette runs: index of the chosen element (0 = empty) */
#define CLVOX_CHANNEL_SCORE 0x8u     /* palette runs: its score B_v in [0,1] (docs/design.md) */
/* Palette runs take at most CLVOX_MAX_PALETTE_SAMPLES samples per voxel (the
 * object's values at a voxel's samples are one bit mask on the device). */
#define CLVOX_MAX_PALETTE_SAMPLES 4096u
/* Limits of oversampling: at most CLVOX_MAX_OVERSAMPLE^2 = 256 rays per
 * column, CLVOX_MAX_POINTS points per voxel and CLVOX_MAX_SAMPLES samples per
 * voxel in all (counts are 16-bit on the device). */
#define CLVOX_MAX_OVERSAMPLE 16u
#define CLVOX_MAX_POINTS 255u
#define CLVOX_MAX_SAMPLES 65535u

/* What the winding inside test did to the mesh and how often it needed the
 * exact cap solid angles (clvox_stats.winding; zero for parity runs). */
typedef struct clvox_winding_report {
    uint64_t merged_vertices;    /* merged into an earlier vertex at exactly the same position */
    uint64_t welded_vertices;    /* merged into another within the weld distance (options.weld) */
    uint64_t dropped_triangles;  /* two corners merged by welding: no area, left out */
    uint64_t components;         /* orientation patches: triangles joined across manifold edges */
    uint64_t closed_components;  /* patches with no boundary edge of their own */
    uint64_t cavities;           /* closed patches nested inside an odd number of others: face inwards */
    uint64_t flipped_triangles;  /* triangles whose orientation was reversed */
    uint64_t nonmanifold_edges;  /* edges of more than two triangles: orientation does not cross them */
    uint64_t nonorientable_components; /* patches where propagation met a conflict (Moebius-like) */
    uint64_t boundary_edges;     /* directed boundary edges (non-zero net multiplicity, counted with it) */
    uint64_t holes;              /* boundary loops, each closed by a fan of cap triangles */
    uint64_t cap_triangles;
    uint64_t exact_points;       /* centres / samples whose cap solid angles were evaluated exactly */
    double seconds;              /* host time of the preparation */
} clvox_winding_report;

/* One device's part of a run (clvox_stats.devices). */
typedef struct clvox_device_share {
    uint32_t device;          /* its position in the context's devices (clvox_context_device_at) */
    uint32_t slabs;           /* slabs it computed that were written */
    uint64_t slices;          /* their slices */
    double busy_seconds;      /* wall time spent computing and reading back slabs, discarded ones included */
    uint32_t discarded_slabs; /* slabs it also computed (a straggler re-issued) whose other copy came first */
    int failed;               /* 1: it failed during the run; its slabs were redone on the other devices */
    int left_out;             /* 1: measured too slow to pay (docs/design.md "Several devices"), it took no more */
} clvox_device_share;

typedef struct clvox_stats {
    size_t size;                   /* sizeof(clvox_stats): set by the caller (see Conventions) */
    double seconds[CLVOX_STAGE_COUNT];
    uint64_t filled_voxels;        /* inside (binary); coverage > threshold (0.5 unless set) when oversampled */
    uint64_t total_voxels;
    uint64_t rays;                 /* rays cast (ray method)                    */
    uint64_t odd_parity_rays;      /* rays with an odd number of crossings: the mesh is not closed */
    uint64_t overflow_rays;        /* rays redone with a larger crossing buffer */
    uint32_t max_crossings;        /* most crossings on one ray                 */
    uint32_t quadtree_depth;       /* depth reached                             */
    uint64_t quadtree_leaves;
    uint64_t quadtree_refs;        /* triangle references stored in leaves      */
    uint32_t slab_depth;           /* slices per slab used                      */
    uint64_t peak_slab_bytes;      /* largest working set of a slab on one device (+ reorder_bytes on the host) */
    uint64_t output_bytes;         /* size of the EXR file written              */
    uint32_t channels;             /* CLVOX_CHANNEL_* produced                  */
    uint32_t samples_per_voxel;    /* N^2 * M (1 when binary)                   */
    double coverage_sum;           /* sum of coverage over all voxels (voxel units; times the
                                      voxel volume = estimated volume); filled_voxels when binary */
    /* palette runs: voxels decided by each step (they add up to total_voxels) */
    uint64_t palette_early_voxels; /* all segments wholly inside or outside: full/empty unscored */
    uint64_t palette_shortcut_voxels; /* alpha/beta shortcut (Nearest, when on)             */
    uint64_t palette_scored_voxels;   /* every element scored                                */
    uint64_t palette_nonempty_voxels; /* voxels given an element other than empty            */
    double palette_volume;            /* sum of the chosen elements' volumes, voxel units (times
                                         the voxel volume: the volume of the element approximation) */
    clvox_inside inside;              /* the inside test used (never DEFAULT) */
    clvox_winding_report winding;     /* mesh preparation and exact evaluations (winding runs) */
    /* Devices (appended in 0.2): each device's part of the run, in the
     * context's device order (clvox_context_device_at). */
    uint32_t device_count;
    clvox_device_share devices[CLVOX_MAX_DEVICES];
    /* Achieved speed-up over the fastest device alone divided by the ideal
     * one from the devices' measured throughputs (EngineCL's efficiency):
     * slices / (sum of the devices' slices per busy second x wall time of
     * the computing). 1 = no device ever waited; with one device, the
     * fraction of the time it computed. */
    double scheduling_efficiency;
    /* The writer takes slabs in increasing z from a reorder buffer of at
     * most reorder_slabs slabs (reorder_bytes of host memory), whatever the
     * number of slices or how unequal the devices are; reorder_peak is the
     * most it held at once. */
    uint32_t reorder_slabs;
    uint64_t reorder_bytes;
    uint32_t reorder_peak;
    /* Winding runs (appended after reorder_peak): the device time (profiling
     * events) of the consumer kernel -- classify, coverage or palette -- of
     * every batch of rays in which at least one point was evaluated exactly
     * (winding.exact_points). It includes the other rays of those batches,
     * so winding_exact_seconds / winding.exact_points is an upper bound on
     * the time per exact point (on a cracked soup nearly all of it is that
     * work). Measured from events the run takes anyway: nothing is added
     * to the kernels. 0 on parity runs and where no point was exact. */
    double winding_exact_seconds;
    /* The certified crack weld of winding runs (appended after
     * winding_exact_seconds; docs/design.md "Cracks"): on a cracked mesh or
     * a triangle soup, without options.weld, the cast runs over the mesh
     * welded within crack_weld_distance, and the difference to the mesh as
     * given is evaluated where it could change a voxel: the voxels are
     * those of the mesh as given (winding.* describes it), only faster.
     * crack_pairs 0: not used. */
    double crack_weld_distance;     /* mesh units: 1/100 of the smallest voxel side */
    uint64_t crack_welded_vertices; /* vertices it merged */
    uint64_t crack_pairs;           /* triangles it moved (or collapsed) */
    uint64_t crack_holes;           /* holes left after it (winding.holes: before it) */
    /* Winding runs on a device without fp64 (appended after crack_holes;
     * docs/design.md "Devices without double precision"): the voxel centres
     * whose float bounds could not settle the inside test, decided on the
     * host in double -- the same voxels as a double device's. */
    uint64_t winding_host_points;
} clvox_stats;
/* Every function taking a clvox_stats * (may be NULL) needs its .size set. */
#define CLVOX_STATS_INIT { .size = sizeof(clvox_stats) }

/* Receives consecutive slabs in increasing z: slices z0 .. z0+nz-1, each an
 * X*Y image, x fastest: occupancy[(z-z0)*X*Y + y*X + x] is 0 or 1. The
 * pointer is valid only during the call. Return non-zero to cancel. */
typedef int (*clvox_slab_fn)(void *user, uint32_t z0, uint32_t nz, const uint8_t *occupancy);

/* Voxelizes and streams the volume to an EXR file (written to a temporary
 * name in the same directory and renamed on success). stats may be NULL. */
CLVOX_API clvox_status clvox_voxelize_to_exr(clvox_context *ctx, const clvox_mesh *mesh,
                                             const clvox_grid *grid,
                                             const clvox_voxelize_options *options,
                                             const char *path, clvox_stats *stats);

/* Voxelizes and hands each slab to `fn` (nothing written to disk). */
CLVOX_API clvox_status clvox_voxelize_stream(clvox_context *ctx, const clvox_mesh *mesh,
                                             const clvox_grid *grid,
                                             const clvox_voxelize_options *options,
                                             clvox_slab_fn fn, void *user, clvox_stats *stats);

/* Dense result for small grids: `out` holds X*Y*Z bytes (x fastest, then y, then z). */
CLVOX_API clvox_status clvox_voxelize_to_memory(clvox_context *ctx, const clvox_mesh *mesh,
                                                const clvox_grid *grid,
                                                const clvox_voxelize_options *options,
                                                uint8_t *out, size_t out_size, clvox_stats *stats);

/* All channels of one slab, for clvox_voxelize_slabs: slices z0 .. z0+nz-1,
 * each X*Y values, x fastest; a pointer is NULL when the run does not produce
 * that channel. coverage is exactly (samples inside) / (samples per voxel)
 * as a float (the EXR file holds the same value rounded to HALF). */
typedef struct clvox_slab {
    uint32_t z0, nz;
    const uint8_t *occupancy;  /* 0 or 1 */
    const float *coverage;     /* in [0,1] */
    const uint16_t *element;   /* palette runs: element index */
    const float *score;        /* palette runs: score in [0,1], exactly equivalences / samples */
} clvox_slab;
typedef int (*clvox_slab_channels_fn)(void *user, const clvox_slab *slab);

/* Like clvox_voxelize_stream, with every channel the options ask for. */
CLVOX_API clvox_status clvox_voxelize_slabs(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                            const clvox_voxelize_options *options, clvox_slab_channels_fn fn,
                                            void *user, clvox_stats *stats);

/* Dense results for small grids: each non-NULL array holds X*Y*Z values (x
 * fastest, then y, then z; sizes in elements). A NULL array is not wanted;
 * a wanted channel the options do not produce is an error. */
CLVOX_API clvox_status clvox_voxelize_to_buffers(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                                 const clvox_voxelize_options *options, uint8_t *occupancy,
                                                 size_t occupancy_count, float *coverage, size_t coverage_count,
                                                 clvox_stats *stats);

/* Dense palette results for small grids: element and/or score (X*Y*Z
 * values each, x fastest; NULL = not wanted). options->palette must be set. */
CLVOX_API clvox_status clvox_voxelize_palette_to_buffers(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                                         const clvox_voxelize_options *options, uint16_t *element,
                                                         size_t element_count, float *score, size_t score_count,
                                                         clvox_stats *stats);

/* ---- other output formats (output.c, write_npy.c, write_nrrd.c, write_binvox.c, write_vdb.cpp) ---- */
/* Besides EXR (the default, clvox_voxelize_to_exr): NumPy .npy, NRRD and
 * binvox, streamed slab by slab except binvox (a bit per voxel held until the
 * end: its voxel order runs x slowest) and OpenVDB (a sparse FLOAT grid
 * "density", built slab by slab, written at the end). What each holds, file names, headers
 * and the voxel-centre conventions: docs/formats.md. */
typedef enum clvox_format {
    CLVOX_FORMAT_AUTO = 0, /* from the path's extension: .exr .npy .nrrd .binvox .vdb (any case) */
    CLVOX_FORMAT_EXR,
    CLVOX_FORMAT_NPY,
    CLVOX_FORMAT_NRRD,
    CLVOX_FORMAT_BINVOX,
    CLVOX_FORMAT_VDB,      /* OpenVDB, when clvox was built with it (else refused with a message) */
    CLVOX_FORMAT_COUNT
} clvox_format;
/* "exr", "npy", "nrrd", "binvox", "vdb"; NULL for AUTO or a bad value. */
CLVOX_API const char *clvox_format_name(clvox_format format);
/* The format named `name` ("npy", ...) or, with from_path, the format of the
 * path's extension; CLVOX_FORMAT_AUTO when it is none of them. */
CLVOX_API clvox_format clvox_format_from_name(const char *name);
CLVOX_API clvox_format clvox_format_from_path(const char *path);

/* clvox_output_options.flags */
#define CLVOX_OUTPUT_PACK_BITS 0x1u /* npy occupancy: 8 voxels per byte along x, bit x%8 of byte x/8
                                       (shape (Z, Y, ceil(X/8)); np.unpackbits(a, axis=2, bitorder='little')) */
#define CLVOX_OUTPUT_FLOAT32 0x2u   /* npy coverage and score as float32 (exactly count/samples) instead of float16 */
#define CLVOX_OUTPUT_UINT32 0x4u    /* npy element as uint32 instead of uint16 */

typedef struct clvox_output_options {
    size_t size;
    clvox_format format;           /* AUTO: from the path's extension */
    uint32_t flags;                /* CLVOX_OUTPUT_* */
    /* 0 = default. EXR: as clvox_voxelize_options.compression. NRRD: NONE =
     * raw, DEFAULT / ZIP / ZIPS = gzip (zlib level 1); RLE and PIZ are refused. npy and
     * binvox: DEFAULT or NONE only. clvox_voxelize_to_file takes the voxelize
     * options' compression when this is DEFAULT. */
    clvox_compression compression;
    uint32_t threads;              /* EXR encoder threads (0 = cores) */
    const char *method;            /* for the file's header / sidecar (clvox_volume_writer only) */
    const char *parameters;
} clvox_output_options;
#define CLVOX_OUTPUT_OPTIONS_INIT { sizeof(clvox_output_options), CLVOX_FORMAT_AUTO, 0, CLVOX_COMPRESSION_DEFAULT, 0, NULL, NULL }

/* Voxelizes into `path` in the format of `output` (NULL: by extension).
 * A format that cannot hold the channels the options produce is refused
 * before any work (CLVOX_ERR_INVALID_ARGUMENT); a failed or cancelled run
 * leaves no file. EXR is clvox_voxelize_to_exr. */
CLVOX_API clvox_status clvox_voxelize_to_file(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                              const clvox_voxelize_options *options, const clvox_output_options *output,
                                              const char *path, clvox_stats *stats);

/* Writes a volume from float slices (clvox convert): open with the grid and
 * the CLVOX_CHANNEL_* mask, give every slice of every channel, finish. Each
 * channel's slices come in increasing z from 0. npy and NRRD, one file per
 * channel, take the channels one after another or interleaved; EXR and
 * binvox take exactly one channel. Values: occupancy is filled where > 0.5,
 * element is rounded to 0..65535, coverage and score are in [0, 1] (EXR and
 * npy float16 hold them as HALF). Nothing is left at `path` unless finish succeeds. */
typedef struct clvox_volume_writer clvox_volume_writer;
CLVOX_API clvox_status clvox_volume_writer_open(clvox_context *ctx, const char *path, const clvox_grid *grid,
                                                uint32_t channels, const clvox_output_options *output,
                                                clvox_volume_writer **out);
CLVOX_API clvox_status clvox_volume_writer_slice(clvox_volume_writer *w, uint32_t channel, uint32_t z, const float *values);
/* *bytes (may be NULL) = size of the main file. Frees w, also on failure. */
CLVOX_API clvox_status clvox_volume_writer_finish(clvox_volume_writer *w, uint64_t *bytes);
CLVOX_API void clvox_volume_writer_abort(clvox_volume_writer *w); /* NULL-safe; removes everything */

/* ---- output files (outfile.c) ------------------------------------------------ */

/* 1 when the output clvox names `path` can be trusted as the whole result of
 * one run: a regular file, and where it belongs to a set (npy: OUT.json and
 * the channels' files; NRRD with several channels: OUT.nrrd and
 * OUT.<channel>.nrrd), every member agrees with the size and CRC-32 its
 * marker records. 0 otherwise, with one line in `why` (may be NULL): no such
 * file; not a regular file; a member that does not match, as a failed or
 * killed run leaves; a marker without identities, as earlier clvox versions wrote.
 * (clvox batch --skip-existing.) */
CLVOX_API int clvox_output_complete(const char *path, char *why, size_t why_size);
/* The same for the npy set whose marker (OUT.json) is `json`: every member
 * it lists agrees, and `member` (NULL: any), when given, is one of them. */
CLVOX_API int clvox_npy_set_complete(const char *json, const char *member, char *why, size_t why_size);

/* A file of the caller's written the way clvox writes its volumes: without
 * a name in the directory of `path` until it is complete (on Linux an
 * O_TMPFILE, elsewhere a hidden ".clvox-<pid>-<n>.tmp"), then synced and
 * named `path` at once, so that a failure, a crash or a kill never leaves a
 * partial file there. Only a regular file at `path` is ever replaced
 * (anything else is refused at create and again at commit, CLVOX_ERR_IO),
 * and a symbolic link is not written through. */
typedef struct clvox_output_file clvox_output_file;
CLVOX_API clvox_status clvox_output_file_create(clvox_context *ctx, const char *path, clvox_output_file **out);
/* The descriptor to write to (O_WRONLY, O_CLOEXEC; pwrite, fallocate and a
 * dup for a stdio stream are fine). It stays the file's: do not close it. */
CLVOX_API int clvox_output_file_fd(const clvox_output_file *file);
/* Syncs the file and names it `path`; *bytes (may be NULL) = its size. An
 * empty file is refused. Frees `file`, on failure too (then nothing is left). */
CLVOX_API clvox_status clvox_output_file_commit(clvox_output_file *file, uint64_t *bytes);
/* Closes and removes the unnamed file and frees it. NULL-safe. */
CLVOX_API void clvox_output_file_discard(clvox_output_file *file);

/* Opens `path` for reading only if it is a regular file, never blocking on
 * the way (a FIFO is opened O_NONBLOCK and refused, never read), as the
 * library opens every file it reads: the descriptor (O_CLOEXEC, blocking
 * reads), or -1 with *why (static) the reason for a message: strerror of
 * the failing call, "Is a directory" or "not a regular file (a FIFO,
 * socket or device)". */
CLVOX_API int clvox_open_regular_read(const char *path, const char **why);

/* ---- reading volumes back ---------------------------------------------------- */

typedef struct clvox_volume_info {
    size_t size;              /* sizeof(clvox_volume_info): set by the caller (see Conventions) */
    uint32_t dims[3];
    double origin[3];
    double voxel_size[3];
    char method[32];          /* "ray", "tetra"                          */
    char parameters[256];     /* method parameters as written            */
    char version[32];         /* clvox version that wrote the file       */
    char compression[16];
    char channels[64];        /* comma-separated channel names           */
    uint64_t filled_voxels;   /* counted by reading every slice: occupancy > 0.5, or
                                 coverage > 0.5 in a file without occupancy, or
                                 element != 0 in a file with neither (palette runs) */
    double coverage_sum;      /* sum of coverage (voxel units), 0 without a coverage channel */
    char palette[64];         /* palette runs: the palette's name, else ""          */
    uint32_t palette_count;   /* its number of elements, else 0                     */
    uint64_t palette_hash;    /* clvox_palette_hash of it, else 0                   */
    char metric[16];          /* "nearest" | "outer" | "inner", else ""             */
} clvox_volume_info;
#define CLVOX_VOLUME_INFO_INIT { .size = sizeof(clvox_volume_info) }

/* Reads the header and counts filled voxels slice by slice (bounded memory).
 * If occupancy is not NULL it must hold X*Y*Z bytes and receives 0/1 values
 * (filled as in info->filled_voxels). The file must have an "occupancy",
 * "coverage" or "element" channel. */
CLVOX_API clvox_status clvox_volume_read(clvox_context *ctx, const char *path, clvox_volume_info *info,
                                         uint8_t *occupancy, size_t occupancy_size);

/* Streams one channel ("occupancy", "coverage", ...) as floats, one whole
 * slice (X*Y values, x fastest) per call in increasing z; memory is one slice
 * plus one chunk. info (may be NULL) gets the header. Return non-zero from fn
 * to stop (CLVOX_ERR_CANCELLED). */
typedef int (*clvox_volume_slice_fn)(void *user, uint32_t z, const float *values);
CLVOX_API clvox_status clvox_volume_read_slices(clvox_context *ctx, const char *path, const char *channel,
                                                clvox_volume_info *info, clvox_volume_slice_fn fn, void *user);

/* ---- palettes (palette.c) ----------------------------------------------- */
/* A palette is an ordered set of sub-voxel elements for palette
 * voxelization (Cavagnino & Gribaudo). Geometry, boundary rule and layout:
 * kernels/palette.h; file format and built-ins: docs/design.md "Palettes".
 * In every palette index 0 is the empty element and index 1 the full one.
 * A palette is immutable and needs no OpenCL device (host_only contexts
 * work); it does not keep the context. */
#define CLVOX_PALETTE_NONE 0xFFFFFFFFu

typedef struct clvox_palette_element_info {
    size_t size;            /* sizeof(clvox_palette_element_info): set by the caller (see Conventions) */
    char name[64];
    double volume;          /* fraction of the unit voxel                              */
    int volume_exact;       /* 1: exact (built-ins); 0: estimated from 64^3 offset points */
    uint32_t basic;         /* index of the basic element this one is an image of
                               (itself when it is not an image)                        */
    uint32_t symmetry;      /* 0..47, which cube symmetry maps basic onto this; 0 = identity */
    int32_t matrix[3][3];   /* that symmetry as a signed permutation S: this element is
                               { S (p - 1/2) + 1/2 : p in basic }                     */
    uint32_t complement_of; /* the element this one is the complement of, or CLVOX_PALETTE_NONE */
    uint32_t cell_count;    /* convex cells in the union                              */
    uint32_t plane_count;   /* half-spaces in all its cells                           */
    int complement;         /* 1: the element is the complement of the union          */
} clvox_palette_element_info;
#define CLVOX_PALETTE_ELEMENT_INFO_INIT { .size = sizeof(clvox_palette_element_info) }

/* Names of the built-in palettes, i = 0, 1, ...; NULL past the last
 * ("binary", "planar10", "paper46", "paper78"). */
CLVOX_API const char *clvox_palette_builtin_name(size_t i);
/* A built-in palette by name; CLVOX_ERR_INVALID_ARGUMENT for an unknown name. */
CLVOX_API clvox_status clvox_palette_builtin(clvox_context *ctx, const char *name, clvox_palette **out);
/* A user palette from a text file (docs/design.md "Palette files"): empty and
 * full first, then the file's elements in order (symmetry images after their
 * element), duplicates dropped. CLVOX_ERR_IO when unreadable,
 * CLVOX_ERR_PALETTE_FORMAT with "PATH:LINE: why" for a malformed line. */
CLVOX_API clvox_status clvox_palette_load(clvox_context *ctx, const char *path, clvox_palette **out);
/* Same from text in memory; `source` names it in messages. */
CLVOX_API clvox_status clvox_palette_parse(clvox_context *ctx, const char *source, const char *text, size_t size,
                                           clvox_palette **out);
CLVOX_API void clvox_palette_destroy(clvox_palette *palette); /* NULL-safe */

CLVOX_API const char *clvox_palette_name(const clvox_palette *palette);
CLVOX_API size_t clvox_palette_count(const clvox_palette *palette);
/* CLVOX_ERR_INVALID_ARGUMENT for an index past the count. */
CLVOX_API clvox_status clvox_palette_element_info_get(clvox_context *ctx, const clvox_palette *palette, size_t index,
                                                      clvox_palette_element_info *info);
/* 1 when the point (x, y, z) of the unit voxel lies in element `index`
 * (kernels/palette.h clvox_element_contains), 0 when not or the index is bad. */
CLVOX_API int clvox_palette_contains(const clvox_palette *palette, size_t index, float x, float y, float z);
/* 64-bit FNV-1a hash of the palette's geometry (its flat element, cell and
 * half-space arrays, kernels/palette.h layout): equal hashes, same elements. */
CLVOX_API uint64_t clvox_palette_hash(const clvox_palette *palette);
/* The text a palette was parsed from (NUL-terminated, borrowed), or NULL for
 * a built-in palette. */
CLVOX_API const char *clvox_palette_source(const clvox_palette *palette);
/* The palette a volume was scored with, rebuilt from the file's header (a
 * built-in by name, or the palette file text the header carries) and
 * checked against the hash recorded there. CLVOX_ERR_EXR when the file has
 * no palette or the rebuilt one does not match. */
CLVOX_API clvox_status clvox_volume_palette(clvox_context *ctx, const char *path, clvox_palette **out);
/* "nearest", "outer", "inner"; NULL for a bad value. */
CLVOX_API const char *clvox_metric_name(clvox_metric metric);

/* ---- a palette volume as a mesh (element_ply.c) ---------------------------- */
/* The geometry of a palette volume as a PLY triangle mesh (clvox mesh):
 * every voxel whose element is not 0 becomes its element's exact shape
 * (disjoint convex pieces, each a closed outward shell) on the voxel's box,
 * in world coordinates. Two passes over the element channel, slice by slice
 * (clvox_volume_read_slices): the first counts, which fixes the header and
 * the exact file size; the second writes every voxel's vertices and faces
 * at their known offsets. Design: docs/design.md "Element geometry and mesh
 * export". */
typedef struct clvox_ply_export clvox_ply_export;

typedef struct clvox_ply_totals {
    size_t size;             /* sizeof(clvox_ply_totals): set by the caller (see Conventions) */
    uint64_t voxels;         /* non-empty voxels (element != 0) */
    uint64_t vertices;
    uint64_t triangles;
    uint64_t bytes;          /* exact size of the file */
    uint64_t header_bytes;
} clvox_ply_totals;
#define CLVOX_PLY_TOTALS_INIT { .size = sizeof(clvox_ply_totals) }

/* Writes `size` bytes at byte `offset` of the output; returns 0, or an errno
 * value (non-zero) on failure. */
typedef int (*clvox_write_at_fn)(void *user, uint64_t offset, const void *data, size_t size);

/* An export of a volume of dims voxels (voxel (i,j,k) is the box origin +
 * (i,j,k) * voxel_size .. + voxel_size) scored with `palette` (borrowed for
 * the export's life). Builds every element's mesh once (CLVOX_ERR_INVALID_ARGUMENT
 * for an element too complex for a mesh, or a bad grid). ascii: 0 binary
 * little-endian (float32 x, y, z; faces "list uchar int"), 1 ASCII
 * (fixed-width records). */
CLVOX_API clvox_status clvox_ply_export_create(clvox_context *ctx, const clvox_palette *palette,
                                               const uint32_t dims[3], const double origin[3],
                                               const double voxel_size[3], int ascii, clvox_ply_export **out);
CLVOX_API void clvox_ply_export_destroy(clvox_ply_export *x); /* NULL-safe */
/* Pass 1: slice z (X*Y element indices as floats, x fastest; slices in any
 * order, each once). CLVOX_ERR_EXR for a value that is not an index of the
 * palette. */
CLVOX_API clvox_status clvox_ply_export_count(clvox_ply_export *x, uint32_t z, const float *element);
/* After pass 1: the totals; CLVOX_ERR_INVALID_ARGUMENT when the mesh is too
 * large for PLY's int vertex indices. */
CLVOX_API clvox_status clvox_ply_export_totals(clvox_ply_export *x, clvox_ply_totals *totals);
/* Pass 2: the header, then each slice in increasing z (the same slices as
 * pass 1; one that differs is CLVOX_ERR_IO: the volume changed), then finish. */
CLVOX_API clvox_status clvox_ply_export_begin(clvox_ply_export *x, clvox_write_at_fn write_at, void *user);
CLVOX_API clvox_status clvox_ply_export_slice(clvox_ply_export *x, uint32_t z, const float *element);
CLVOX_API clvox_status clvox_ply_export_finish(clvox_ply_export *x);

/* ---- meshes from volumes (src/mesh_out) ------------------------------------ */
/* A triangle mesh of any clvox volume (clvox mesh; docs/design.md "Meshes
 * from volumes"), read slice by slice through clvox_volume_read_slices (any
 * format it reads) and written as PLY, OBJ or STL (from the extension of
 * `mesh`) the way clvox writes its volumes (clvox_output_file_*: a failed
 * run leaves no file). Vertices are in the volume's world coordinates.
 *  - FACES: the faces between inside (value > iso) and outside voxels (the
 *    grid's outside is outside), outward, vertices shared; split where inside
 *    voxels touch only along an edge or at a corner, so the surface is a
 *    closed oriented 2-manifold that voxelizes back to the same voxels.
 *  - SMOOTH: marching cubes through the voxel centres at iso (values outside
 *    the grid count as 0, so it is closed), vertices on the edges between
 *    centres; the ambiguous faces always separate the inside corners.
 * Memory: two slices of values and two planes of vertex numbers. PLY reads
 * the volume twice (the first pass counts for the header). */
typedef enum clvox_surface_kind {
    CLVOX_SURFACE_AUTO = 0, /* SMOOTH for a channel "coverage", else FACES */
    CLVOX_SURFACE_FACES,
    CLVOX_SURFACE_SMOOTH,
    CLVOX_SURFACE_KIND_COUNT
} clvox_surface_kind;
CLVOX_API const char *clvox_surface_kind_name(clvox_surface_kind kind); /* "auto", "faces", "smooth" */

typedef struct clvox_surface_options {
    size_t size;              /* sizeof(clvox_surface_options) */
    clvox_surface_kind kind;
    const char *channel;      /* NULL: "coverage" for SMOOTH and AUTO when the volume has
                                 one, else "occupancy", else "element" (non-zero = inside) */
    int iso_set;              /* 1: iso below; 0: 0.5 */
    double iso;
    int ascii;                /* PLY and STL: ASCII instead of binary little-endian */
} clvox_surface_options;
#define CLVOX_SURFACE_OPTIONS_INIT { sizeof(clvox_surface_options), CLVOX_SURFACE_AUTO, NULL, 0, 0.0, 0 }

typedef struct clvox_surface_totals {
    size_t size;              /* sizeof(clvox_surface_totals): set by the caller (see Conventions) */
    clvox_surface_kind kind;  /* FACES or SMOOTH: what was made */
    char channel[32];         /* the channel read */
    uint32_t dims[3];
    uint64_t inside_voxels;   /* values > iso */
    double value_sum;         /* sum of the channel's values (voxel units: the coverage sum) */
    uint64_t vertices;
    uint64_t triangles;
    double enclosed_volume;   /* signed volume of the mesh, world units (FACES: inside_voxels
                                 x voxel volume) */
    uint64_t bytes;           /* size of the file */
} clvox_surface_totals;
#define CLVOX_SURFACE_TOTALS_INIT { .size = sizeof(clvox_surface_totals) }

/* CLVOX_ERR_INVALID_ARGUMENT: an unknown mesh extension (.ply, .obj, .stl),
 * a bad option, a mesh too large for PLY's int indices; the reader's errors
 * for the volume (a channel it lacks: CLVOX_ERR_EXR); CLVOX_ERR_IO for the
 * output (or a volume that changed between PLY's two passes). */
CLVOX_API clvox_status clvox_volume_to_mesh(clvox_context *ctx, const char *volume, const char *mesh,
                                            const clvox_surface_options *options, clvox_surface_totals *totals);

/* ---- render maps (render_map.c) ------------------------------------------ */
/* A render map gives each element E_v of a palette an ordered list of render
 * objects R_v,1 .. R_v,T with thresholds 1 = D_v,0 > D_v,1 > ... > D_v,T = 0
 * (Cavagnino & Gribaudo, section 4): a voxel of element v and score B_v is
 * drawn with R_v,j when D_v,j <= B_v < D_v,j-1, the top interval closed (B_v
 * = 1 gets R_v,1). Objects are names; how they look is up to the renderer
 * (scripts/tools/blender_instances.py). File format, precedence of the rules and
 * the default object: docs/design.md "Render maps, instances and Blender".
 * A map is bound to the palette it was read for (element names resolved to
 * indices), immutable, and keeps neither the palette nor the context. */
typedef struct clvox_render_map clvox_render_map;

/* How an object is modelled, hence how an instance is placed. */
typedef enum clvox_render_frame {
    CLVOX_RENDER_FRAME_BASIC = 0, /* as the element's basic element: the instance applies the
                                     element's symmetry S (clvox_palette_element_info.matrix) */
    CLVOX_RENDER_FRAME_ELEMENT    /* as the element itself: the instance applies no symmetry */
} clvox_render_frame;

/* Reads a render map file for `palette` (borrowed for the call).
 * CLVOX_ERR_IO when unreadable, CLVOX_ERR_PALETTE_FORMAT with
 * "PATH:LINE: why" for a malformed line or a name the palette lacks. */
CLVOX_API clvox_status clvox_render_map_load(clvox_context *ctx, const char *path, const clvox_palette *palette,
                                             clvox_render_map **out);
/* Same from text in memory; `source` names it in messages. */
CLVOX_API clvox_status clvox_render_map_parse(clvox_context *ctx, const char *source, const char *text, size_t size,
                                              const clvox_palette *palette, clvox_render_map **out);
/* The map used without a file: every element is drawn with one object named
 * after its basic element (frame BASIC), whatever its score. */
CLVOX_API clvox_status clvox_render_map_default(clvox_context *ctx, const clvox_palette *palette, clvox_render_map **out);
CLVOX_API void clvox_render_map_destroy(clvox_render_map *map); /* NULL-safe */

/* Distinct object names, in order of first use (the file's objects, then the
 * default ones the map falls back on); names are 1-63 of A-Z a-z 0-9 _ - . */
CLVOX_API size_t clvox_render_map_object_count(const clvox_render_map *map);
/* NULL past the count. */
CLVOX_API const char *clvox_render_map_object_name(const clvox_render_map *map, size_t object);
/* The object for a voxel of element `element` with score `score`: the first
 * R_j with score >= D_j. A score above 1 counts as 1; below 0 or NaN as 0
 * (the last object). CLVOX_PALETTE_NONE for element 0 (empty: nothing is
 * drawn) or an index past the palette. frame (may be NULL) gets the frame of
 * the rule used. */
CLVOX_API uint32_t clvox_render_map_choose(const clvox_render_map *map, uint32_t element, double score,
                                           clvox_render_frame *frame);
/* The line of the rule used for `element` (0: the built-in default). */
CLVOX_API unsigned clvox_render_map_rule_line(const clvox_render_map *map, uint32_t element);

#ifdef __cplusplus
}
#endif
#endif /* CLVOX_H */
