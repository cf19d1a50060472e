/* SPDX-License-Identifier: Apache-2.0 */
/* Private interfaces between clvox's pipeline stages. Not installed. */
#ifndef CLVOX_INTERNAL_H
#define CLVOX_INTERNAL_H

#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include "clvox.h"
#include "../../kernels/clvox_types.h"
#include "../../kernels/palette.h"
#include "environment.h"

#ifdef __cplusplus
extern "C" {
#endif

#if defined(__GNUC__)
#define CLVOX__PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define CLVOX__PRINTF(a, b)
#endif

/* ---- context (context.c) ---- */

struct clvox_context {
    char error[8192];
    int host_only;
    clvox_device_info device;
    cl_platform_id platform;
    cl_device_id device_id;
    cl_context cl;
    cl_command_queue queue; /* in-order, profiling enabled */
    struct clvox__launch_state *launch; /* launch.c: work-group limits, completion counts */
    cl_program program;     /* all kernels, built once per context */
    int program_cached;     /* 1: program made from the cached binary (program_cache.c) */
    size_t real_size;       /* sizeof(clvox_real) in the kernels: 8 with fp64, else 4 */
    int kernels_float;      /* 1: built without fp64 on a device that has it (build_program) */
    int want_float;         /* clvox_context_options.float_kernels */
    int float_for_speed;    /* 1: float by the speed rule on a device with fp64 (device_speed.c): a run
                             * that needs double switches builds (clvox__select_build) */
    cl_program program_other; /* float_for_speed: the build not in use, once a run has needed it */
    /* The run's devices (clvox_context_options.device "a,b" or "all"):
     * member[0] is this context; member[1..] are contexts of their own, one
     * per device (devices of different platforms cannot share a
     * cl_context), owned by member[0]. One device: member_count 1. */
    struct clvox_context *member[CLVOX_MAX_DEVICES];
    uint32_t member_count;
    uint32_t position;      /* where the selector list named this device (CLVOX_TEST_FAIL_DEVICE's K) */
    /* Warnings, one per line: the context's creation's (the first
     * warnings_kept bytes, kept) and then the latest run's. */
    char warnings[4096];
    size_t warnings_kept;
    int fp32_rounded;       /* 1: built with -cl-fp32-correctly-rounded-divide-sqrt (device_checks.c) */
    /* Meshes this context took to grid space (clvox__grid_space_vertices
     * calls): a device of a set that copies the lead's preparation takes
     * none (test_devices). */
    uint64_t grid_space_count;
};

/* Appends one line to ctx->warnings (dropped when full). */
void clvox__warn(clvox_context *ctx, const char *fmt, ...) CLVOX__PRINTF(2, 3);

/* Records the message and returns `status`, so that reporting and returning
 * an error is one expression: return clvox__fail(ctx, CLVOX_ERR_IO, "…", …); */
clvox_status clvox__fail(clvox_context *ctx, clvox_status status, const char *fmt, ...)
    CLVOX__PRINTF(3, 4);
/* ---- output structs that may grow (clvox.h "Conventions"; context.c) ---- */

/* The least .size a caller may pass: the struct as clvox 0.1, the first
 * version with .size, had it. Frozen: members are appended after these,
 * and code that writes a member appended later must check the caller's
 * size first (the begin/end pair below does: it writes a prefix). */
#define CLVOX__STATS_SIZE_0 (offsetof(clvox_stats, winding) + sizeof(clvox_winding_report))
#define CLVOX__VOLUME_INFO_SIZE_0 (offsetof(clvox_volume_info, metric) + 16)
#define CLVOX__DEVICE_INFO_SIZE_0 (offsetof(clvox_device_info, max_alloc_bytes) + sizeof(uint64_t))
#define CLVOX__ELEMENT_INFO_SIZE_0 (offsetof(clvox_palette_element_info, complement) + sizeof(int))
#define CLVOX__PLY_TOTALS_SIZE_0 (offsetof(clvox_ply_totals, header_bytes) + sizeof(uint64_t))
#define CLVOX__MESH_SOURCE_INFO_SIZE_0 (offsetof(clvox_mesh_source_info, unit_metres) + sizeof(double))
/* Checks the .size of the caller's struct `out` (NULL is fine: nothing to
 * check) against [min_size, full_size]: CLVOX_ERR_INVALID_ARGUMENT naming
 * `what`, else CLVOX_OK. The library then fills a whole struct of its own
 * and clvox__out_end copies the caller's size of it, .size kept. */
clvox_status clvox__out_begin(clvox_context *ctx, const void *out, size_t full_size, size_t min_size,
                              const char *what);
void clvox__out_end(void *out, const void *full); /* NULL-safe */

/* Same for an OpenCL error: "<what>: CL_OUT_OF_RESOURCES (-5)". */
clvox_status clvox__cl_fail(clvox_context *ctx, cl_int err, const char *what);
/* Float kernels (devices without fp64) decide their predicates exactly
 * for grid coordinates that are 0 or of magnitude in [2^-24, 2^36]
 * (kernels/overlap.h "Range"). clvox__float_outside: 1 + the index of the
 * first of v[0 .. n) outside it (its value in *bad), 0 when all are
 * inside. clvox__float_check: where ctx's kernels are float and
 * `outside`, CLVOX_ERR_NO_DEVICE saying so (`what`: the mode or method);
 * else CLVOX_OK. */
size_t clvox__float_outside(const float *v, size_t n, float *bad);
clvox_status clvox__float_check(clvox_context *ctx, const char *what, size_t outside, float bad);
const char *clvox__cl_error_name(cl_int err);
/* The kernel program's binary kept between processes (program_cache.c):
 * the program built from the cached binary for ctx's device, or NULL (off,
 * a miss, a bad file, a binary the driver refuses: build from source); and
 * storing a program built from source. Neither ever fails the caller. */
cl_program clvox__program_cache_load(clvox_context *ctx, const char *options);
void clvox__program_cache_store(clvox_context *ctx, cl_program program, const char *options);
/* Small facts about ctx's device kept the same way, under the name `what`
 * in place of the build options (device_speed.c): get copies exactly size
 * bytes into out and returns 1, else 0; put never fails the caller. */
int clvox__cache_get(clvox_context *ctx, const char *what, void *out, size_t size);
/* The speed rule (device_speed.c): a device with fp64 whose double
 * arithmetic is this many times slower than its float gets the float build. */
#define CLVOX__FP64_SLOW 8.0f
/* How many times slower ctx's device runs double than float: measured once
 * per device and driver and cached, or CLVOX_FP64_SLOWDOWN; 0 where not
 * measured (no fp64, CPU devices) or where measuring failed. */
float clvox__fp64_slowdown(clvox_context *ctx);
/* For a float_for_speed context: the double build (need_double) or the
 * float one in ctx->program, building it the first time. Else nothing. */
clvox_status clvox__select_build(clvox_context *ctx, int need_double);
void clvox__cache_put(clvox_context *ctx, const char *what, const void *data, size_t size);
/* A cache file's n bytes: 1 when it is whole and for `identity`, with the
 * binary at file + *bin_off, *bin_len bytes; else 0 (fuzzed: fuzz_program_cache). */
int clvox__program_cache_parse(const unsigned char *file, size_t n, const char *identity, size_t *bin_off,
                               size_t *bin_len);
/* ---- device requirements (device_checks.c) ---- */

/* The kernel program's build options: float kernels (-DCLVOX_NO_FP64)
 * or not, correctly rounded float division and sqrt or not. */
const char *clvox__build_options(int kernels_float, int fp32_rounded);
/* The device's build options (*opts, static): refuses a device below
 * OpenCL C 1.2; sets ctx->fp32_rounded from CL_DEVICE_SINGLE_FP_CONFIG. */
clvox_status clvox__program_options(clvox_context *ctx, const char **opts);
/* After the build: the contraction self-test on ctx->program.
 * CLVOX_ERR_NO_DEVICE when the device fuses a*b - c*d. */
clvox_status clvox__device_checks(clvox_context *ctx);
/* The same test on any build of the program for ctx's device (a test
 * builds one without the pragma). */
clvox_status clvox__contraction_check(clvox_context *ctx, cl_program program);
/* Which rules the device's kernels compute by: devices of a run must give
 * equal values. 8: double kernels (the same voxels whatever the float
 * rounding); 4: float kernels, correctly rounded division and sqrt; 3:
 * float kernels without (divisions may round differently). */
int clvox__kernel_rules(const clvox_context *ctx);

/* Creates kernel `name` from the context's program. */
clvox_status clvox__kernel(clvox_context *ctx, const char *name, cl_kernel *out);
/* clCreateBuffer with the error recorded in ctx (status in *st, NULL
 * returned); zero bytes allocate a small buffer so it can still be bound. */
cl_mem clvox__buffer(clvox_context *ctx, cl_mem_flags flags, size_t bytes, void *host, clvox_status *st,
                     const char *what);
/* ---- device memory (device_memory.c) ---- */

/* What a run may hold on a device at once: NUM/DEN of its global memory. */
#define CLVOX_DEVICE_BUDGET_NUM 3
#define CLVOX_DEVICE_BUDGET_DEN 4
/* Lowers info's limits to the test hooks' (CLVOX_DEVICE_MAX_ALLOC,
 * CLVOX_DEVICE_GLOBAL_MEM), at context creation: the limits the library
 * then believes, everywhere. */
void clvox__device_memory_hooks(clvox_device_info *info);
/* The device's largest buffer (CL_DEVICE_MAX_MEM_ALLOC_SIZE; 2 GiB when unknown). */
uint64_t clvox__device_max_alloc(const clvox_context *ctx);
/* The run's budget: NUM/DEN of CL_DEVICE_GLOBAL_MEM_SIZE (UINT64_MAX when unknown). */
uint64_t clvox__device_budget(const clvox_context *ctx);
/* Bytes of a buffer (CL_MEM_SIZE); 0 for NULL. */
uint64_t clvox__mem_bytes(cl_mem m);
/* CLVOX_ERR_OUT_OF_MEMORY: "device 'D': the run needs NEED of device memory
 * (WHAT), it has HAVE (...)". */
clvox_status clvox__device_oom(clvox_context *ctx, uint64_t need, uint64_t have, const char *what);
/* CLVOX_ERR_OUT_OF_MEMORY: "device 'D': WHAT needs a buffer of NEED, more
 * than the largest the device allows (MAX)". */
clvox_status clvox__device_alloc_oom(clvox_context *ctx, uint64_t need, const char *what);
/* CL_OUT_OF_RESOURCES / CL_MEM_OBJECT_ALLOCATION_FAILURE from an enqueue,
 * a finish or a create: CLVOX_ERR_OUT_OF_MEMORY naming the device's memory
 * (clvox__cl_fail calls it). */
clvox_status clvox__device_cl_oom(clvox_context *ctx, cl_int err, const char *what);
/* Releases *m if set and clears it. */
void clvox__release_mem(cl_mem *m);
/* Seconds of device time an event took (0 if profiling info is missing). */
double clvox__event_seconds(cl_event ev);
double clvox__now(void); /* monotonic seconds */
/* A name the mesh loader reads by its extension (obj, off, ply, stl, om; any case). */
int clvox__is_mesh_path(const char *path);
/* Opens `path` for reading only if it is a regular file, never blocking on
 * the way (a FIFO would block in open(2) until a writer comes: it is opened
 * O_NONBLOCK, checked with fstat, then put back in blocking mode). Returns
 * the descriptor (O_CLOEXEC), *sb filled when sb is not NULL; or -1 with
 * *why the reason for a message: strerror(errno) of the failing call, "Is
 * a directory", or "not a regular file (a FIFO, socket or device)". Every
 * file the library reads by name is opened through this. */
struct stat;
int clvox__open_regular_read(const char *path, struct stat *sb, const char **why);
/* Reads a small text file (palette, render map) whole into a malloc'ed
 * buffer (*data, *size bytes; free it). `what` names it in messages
 * ("cannot open palette 'P': ..."); a file over max_bytes is
 * CLVOX_ERR_PALETTE_FORMAT "P: larger than N bytes". */
clvox_status clvox__read_text_file(clvox_context *ctx, const char *path, const char *what, size_t max_bytes,
                                   char **data, size_t *size);
/* "512 bytes", "12.3 KB", "999 MB", "2.1 GB": decimal units, 3 digits, for messages. */
void clvox__format_size(uint64_t bytes, char *buf, size_t size);

/* Ascending insertion sort of a few 64-bit keys, and qsort's comparison
 * for them (mesh report, winding preparation). */
static inline void clvox__sort_u64_small(uint64_t *a, size_t n)
{
    for (size_t i = 1; i < n; i++) {
        uint64_t v = a[i];
        size_t j = i;
        for (; j > 0 && a[j - 1] > v; j--) a[j] = a[j - 1];
        a[j] = v;
    }
}
static inline int clvox__cmp_u64(const void *pa, const void *pb)
{
    uint64_t a = *(const uint64_t *)pa, b = *(const uint64_t *)pb;
    return (a > b) - (a < b);
}

/* 64-bit FNV-1a over n bytes, continuing from h (start: CLVOX__FNV_BASIS):
 * palette and render-map identities. */
#define CLVOX__FNV_BASIS 0xcbf29ce484222325ull
static inline uint64_t clvox__fnv1a(uint64_t h, const void *data, size_t n)
{
    const unsigned char *b = (const unsigned char *)data; /* also C++ (write_vdb.cpp) */
    for (size_t i = 0; i < n; i++) h = (h ^ b[i]) * 0x100000001b3ull;
    return h;
}

/* SHA-256 (sha256.c, FIPS 180-4): the program cache's identity and entry
 * checksum. init, update any number of times, final; or all at once. */
typedef struct clvox__sha256_state {
    uint32_t h[8];
    uint64_t bytes;
    unsigned char buf[64];
    size_t used;
} clvox__sha256_state;
void clvox__sha256_init(clvox__sha256_state *s);
void clvox__sha256_update(clvox__sha256_state *s, const void *data, size_t n);
void clvox__sha256_final(clvox__sha256_state *s, unsigned char out[32]);
void clvox__sha256(const void *data, size_t n, unsigned char out[32]);

/* ---- palettes (palette.c) ---- */

/* The palette's flat arrays (kernels/palette.h layout), borrowed: valid
 * while the palette lives; for upload to the scoring kernel. */
void clvox__palette_arrays(const clvox_palette *p, const clvox_element **elements, size_t *element_count,
                           const clvox_cell **cells, size_t *cell_count, const clvox_halfspace **planes,
                           size_t *plane_count);

/* Embedded kernel sources (generated from kernels/ at build time). */
extern const char *const clvox__kernel_sources[];
extern const char *const clvox__kernel_names[];
extern const unsigned clvox__kernel_source_count;

/* ---- mesh (src/mesh/: mesh_load.c, mesh_build.c, mesh_openmesh.cpp) ---- */

/* The report's signed volume, for the winding preparation's sign of a mesh
 * that is one closed patch (it would sum the same terms again): vol6 =
 * sum over the triangles, in order, of (a-o).((b-o)x(c-o)) in double, o =
 * the first corner of the first triangle (mesh_report.c); perm_bound >=
 * the sum of those determinants' permanents (12 nt Mx My Mz, M = the
 * vertices' largest distance from o along each axis). */
typedef struct clvox__mesh_volume {
    double vol6, perm_bound;
} clvox__mesh_volume;

struct clvox_mesh {
    float *xyz;          /* 3 per vertex, relative to offset */
    double offset[3];    /* added to xyz: the first vertex of an OFF/OBJ file (read
                            in double), else 0, so far-off meshes keep their precision */
    size_t vertex_count;
    uint32_t *tris;      /* 3 per triangle */
    size_t triangle_count;
    clvox_mesh_report report;
    clvox__mesh_volume volume;
    clvox_mesh_source_info source; /* the file's scene: meshes, units, lines and points ignored */
    uint32_t *tri_source; /* per triangle, the scene mesh it came from (Assimp formats), or NULL */
    struct clvox__prep_ahead *ahead; /* winding preparation on its way (winding_prep.c), or NULL */
};

/* What the OpenMesh shim hands back: polygons as read (not validated). */
typedef struct clvox__raw_mesh {
    float *xyz;               /* malloc'ed, 3 per vertex, relative to offset */
    double offset[3];         /* 0, or the first vertex (text readers parse in double) */
    size_t vertex_count;
    uint32_t *face_sizes;     /* malloc'ed, corners per face */
    uint32_t *face_indices;   /* malloc'ed, all corners concatenated */
    size_t face_count;
    size_t index_count;
    uint64_t nonmanifold_faces;
    uint32_t *face_source;    /* malloc'ed, per face the scene mesh it came from (Assimp), or NULL */
    clvox_mesh_source_info source; /* .size unset: a single-mesh file read natively */
} clvox__raw_mesh;

/* C++ shim around OpenMesh::IO::read_mesh. Never throws. Returns 0 on
 * success, else writes a one-line reason into err. */
int clvox__openmesh_read(const char *path, clvox__raw_mesh *out, char *err, size_t err_size);
void clvox__raw_mesh_free(clvox__raw_mesh *raw);

/* C++ shim around Assimp (mesh_assimp.cpp). Never throws. ext: the file's
 * extension (no dot). clvox__assimp_supports: 1 when Assimp has a reader for
 * it. clvox__assimp_read: the scene in data[0..n) (the file at path, already
 * read; .gltf buffers and other files it names are opened beside it, regular
 * files only; path NULL: nothing else can be opened, for the fuzzer)
 * flattened into *out: triangles only (sizes NULL), face_source set, every
 * node's transform applied (in double, relative to the first vertex).
 * Returns 0, -2 when out of memory, else -1 (a bad file, or a flattened
 * scene over the bound of mesh_assimp.cpp),
 * with a one-line reason in err. */
int clvox__assimp_supports(const char *ext);
int clvox__assimp_read(const char *path, const char *ext, const unsigned char *data, size_t n,
                       clvox__raw_mesh *out, char *err, size_t err_size);
/* clvox__assimp_read in a forked child (mesh_isolate.c), what
 * clvox_mesh_load uses: the same result, or -1 with "the reader crashed
 * (...)" when the child dies. */
int clvox__assimp_read_isolated(const char *path, const char *ext, const unsigned char *data, size_t n,
                                clvox__raw_mesh *out, char *err, size_t err_size);

/* ---- winding preparation (winding_prep.c) ---- */

/* The mesh made ready for the winding-number inside test (docs/design.md
 * "Winding numbers"): vertices at equal positions merged (and welded within
 * `weld`), triangles oriented by propagation across manifold edges with one
 * sign per patch (outwards, cavities inwards), and the boundary chain left
 * after that -- the edges whose net multiplicity is not zero -- split into
 * loops, each closed by a fan of cap triangles from an apex, so that
 * surface + caps is a closed chain. */
typedef struct clvox__winding_mesh {
    uint32_t *tris;        /* 3 per triangle, oriented; indices into the mesh's vertices (after merging) */
    size_t triangle_count; /* the mesh's count minus report.dropped_triangles */
    uint32_t *caps;        /* 3 per cap triangle: an index < the mesh's vertex_count is a mesh vertex,
                              index vertex_count + a is apex a */
    size_t cap_count;
    float *apex;           /* 3 per apex, the mesh's coordinates (relative to its offset) */
    size_t apex_count;
    uint32_t *rim;         /* 2 per directed boundary edge (from, to): the caps' loops as given */
    size_t rim_count;
    uint32_t *rep;         /* with CLVOX__PREP_KEEP_REP: each mesh vertex's representative after the
                              merge and weld (its index, or the one it was merged into); else NULL */
    clvox_winding_report report; /* all but exact_points */
} clvox__winding_mesh;

/* weld: 0 or the weld distance (mesh units). Fills *out (free it with
 * clvox__winding_mesh_free, also after a failure). */
clvox_status clvox__winding_prepare(clvox_context *ctx, const clvox_mesh *mesh, double weld,
                                    clvox__winding_mesh *out);
void clvox__winding_mesh_free(clvox__winding_mesh *w);

/* ---- grid space ---- */

/* The ray axis u and the ray plane (v,w) as a permutation of (x,y,z):
 * perm[0] = u, perm[1] = v, perm[2] = w. */
typedef struct clvox__axes {
    int perm[3];
} clvox__axes;
clvox__axes clvox__axes_for(clvox_axis axis);

/* One grid-space coordinate: x (the mesh's, relative to its offset) on an
 * axis whose origin is o (the grid's origin minus the mesh's offset) and
 * voxel size h, in double, rounded once (voxel centres at integers). */
static inline float clvox__grid_coord(float x, double o, double h) { return (float)(((double)x - o) / h - 0.5); }

/* Triangle soup in grid coordinates (voxel centres at integers, permuted so
 * that index 0 is u): 9 floats per triangle (a.uvw, b.uvw, c.uvw). Each
 * vertex is transformed once, so shared vertices stay bit-identical and a
 * closed mesh stays closed. */
clvox_status clvox__grid_space_soup(clvox_context *ctx, const clvox_mesh *mesh,
                                    const clvox_grid *grid, clvox__axes axes, float **out_soup);
/* The same on `threads` host threads (0: clvox__host_threads()); the same floats. */
clvox_status clvox__grid_space_soup_threads(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                            clvox__axes axes, int threads, float **out_soup);
/* The soup's vertices alone, indexed as the mesh's: 3 floats (u,v,w) per
 * vertex, the same floats the soup holds at each of its corners. 4096-byte
 * aligned, so that a device buffer can use them in place. `threads` as above. */
clvox_status clvox__grid_space_vertices(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                        clvox__axes axes, int threads, float **out_vertices);

/* ---- partition (partition.c) ---- */

typedef struct clvox__quadtree {
    clvox_qt_node *nodes;
    size_t node_count;
    uint32_t *refs;
    size_t ref_count;
    uint32_t depth;       /* deepest level reached */
    size_t leaf_count;
} clvox__quadtree;

/* Builds the quadtree over the (v,w) projection of the triangles, covering
 * the ray plane [-0.5, dim_v-0.5] x [-0.5, dim_w-0.5]. max_depth/leaf_size
 * 0 = auto. Triangles: `tris` (3 indices each) into `verts` (grid space,
 * 3 floats each, clvox__grid_space_vertices), or with tris NULL, `verts` is
 * a soup (9 floats each, clvox__grid_space_soup): the same tree. */
clvox_status clvox__quadtree_build(clvox_context *ctx, const float *verts, const uint32_t *tris, size_t tri_count,
                                   uint32_t dim_v, uint32_t dim_w, uint32_t max_depth,
                                   uint32_t leaf_size, clvox__quadtree *out);
/* The same on `threads` host threads (0: clvox__host_threads()): the same
 * tree, node for node and reference for reference, at any count. */
clvox_status clvox__quadtree_build_threads(clvox_context *ctx, const float *verts, const uint32_t *tris,
                                           size_t tri_count,
                                           uint32_t dim_v, uint32_t dim_w, uint32_t max_depth,
                                           uint32_t leaf_size, int threads, clvox__quadtree *out);
void clvox__quadtree_free(clvox__quadtree *qt);
uint32_t clvox__quadtree_auto_depth(uint32_t dim_v, uint32_t dim_w, size_t tri_count);

/* ---- methods: each fills slabs of occupancy bits ---- */

/* One slab: slices z0 .. z0+nz-1 of the output as bit rows: row (z - z0, y)
 * is clvox__row_words(X) 32-bit words at ((z - z0) * Y + y) * words, voxel
 * x is bit x % 32 of word x / 32 (1 = inside), bits past X are 0. One bit
 * per voxel: the device writes, and the writer reads, 16 times less than
 * half values would take. */
static inline uint32_t clvox__row_words(uint32_t X) { return (X + 31u) / 32u; }

/* Device planes of one slab; a plane is NULL when the run does not produce
 * that channel. coverage: one HALF (as uint16 bits) per voxel, x fastest,
 * X*Y per slice. */
typedef struct clvox__slab_out {
    cl_mem occupancy; /* bit rows (above) */
    cl_mem coverage;  /* HALF bits */
    cl_mem element;   /* palette runs: uint16 element index per voxel, x fastest */
    cl_mem score;     /* palette runs: HALF bits of the score (or the equivalence count) */
} clvox__slab_out;

/* The same planes mapped on the host, as the sinks get them. */
typedef struct clvox__slab_planes {
    const uint32_t *occupancy_bits; /* bit rows, or NULL */
    const uint16_t *coverage_half;  /* HALF bits per voxel, or NULL */
    const uint16_t *element;        /* element index per voxel, or NULL */
    const uint16_t *score_half;     /* HALF bits of the score per voxel, or NULL */
} clvox__slab_planes;

typedef struct clvox__slab_stats {
    double cast_seconds, classify_seconds;
    uint64_t filled, rays, odd_parity_rays, overflow_rays;
    uint64_t coverage_count; /* samples inside, summed over the slab's voxels */
    uint64_t palette_early, palette_shortcut, palette_scored; /* voxels decided by each step */
    uint64_t palette_nonempty; /* voxels whose element is not empty */
    double palette_volume;     /* sum of the chosen elements' volumes (voxel units) */
    uint64_t exact_points;     /* winding: points whose cap solid angles were evaluated */
    double exact_seconds;      /* winding: consumer kernel time of the batches with exact points */
    uint64_t host_points;      /* winding, float devices: points decided on the host (clvox_stats.winding_host_points) */
    uint32_t max_crossings;
} clvox__slab_stats;

/* What the driver asks of a method beyond the options. */
typedef struct clvox__run {
    uint32_t channels;    /* CLVOX_CHANNEL_* planes the slabs must hold */
    int coverage_counts;  /* 1: the coverage and score planes hold sample counts
                             (uint16) rather than HALF bits of count / samples */
    /* Called between the batches of a long slab with the fraction of the
     * slab done, in (0, 1); returns 0 to stop, and the method then fails
     * with CLVOX_ERR_CANCELLED. NULL: never called. */
    int (*poll)(void *user, double slab_fraction);
    void *poll_user;
    /* 1: the slab's occupancy plane already holds another method's bits
     * (conservative mode: the solid); OR into them, do not clear, and count
     * the union. Only the surface method takes it. */
    int accumulate;
    /* The same method prepared for the same run on another device (device
     * sets), or NULL: a method that can copies the lead's device buffers
     * instead of preparing the mesh again on the host (the ray, tetra and
     * surface methods; the driver passes each method's own lead). */
    const struct clvox__method_state *lead;
} clvox__run;

/* Most crossings one ray may have (the ray method fails with
 * CLVOX_ERR_MESH_INVALID beyond it: that many surfaces on one line are
 * duplicated or coincident copies, whose parity is meaningless, and their
 * buffers and sorting would cost seconds per ray). 8 bytes each. */
#define CLVOX__MAX_CROSSINGS 65536u
/* Ray-triangle tests per batch of rays, at most (estimated from the largest
 * quadtree leaf): about 0.25 s on a 2-core CPU device, so a cancel is seen
 * within that time however slow a slab is. */
#define CLVOX__BATCH_TESTS (128ull << 20)

typedef struct clvox__method_state clvox__method_state;

typedef struct clvox__method {
    const char *name;
    clvox_status (*prepare)(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                            const clvox_voxelize_options *opts, const clvox__run *run, uint32_t slab_depth,
                            clvox_stats *stats, clvox__method_state **out);
    /* Computes the slab into the device planes of `out` (those not NULL)
     * and may leave commands queued; the driver reads them back. */
    clvox_status (*slab)(clvox__method_state *st, uint32_t z0, uint32_t nz, const clvox__slab_out *out,
                         clvox__slab_stats *ss);
    void (*release)(clvox__method_state *st);
    /* Text for the EXR "clvoxParameters" attribute. */
    void (*describe)(const clvox__method_state *st, char *buf, size_t size);
} clvox__method;

extern const clvox__method clvox__method_ray;   /* cast.c  */
extern const clvox__method clvox__method_tetra; /* tetra.c */
extern const clvox__method clvox__method_surface; /* surface.c */

/* 1 when a voxelization with these options runs the winding test, *weld
 * its weld distance (voxelize.c). */
int clvox__options_winding(const clvox_voxelize_options *options, double *weld);

/* HALF bit pattern of x in [0, 1], rounded to nearest even (voxelize.c). */
uint16_t clvox__half_from_unit(double x);

/* ---- EXR (write_exr.c, read_exr.c) ---- */

typedef struct clvox__exr_writer clvox__exr_writer;

typedef struct clvox__exr_meta {
    const char *method;      /* "ray" | "tetra" */
    const char *parameters;  /* free text, e.g. "axis=x depth=9 leaf=8" */
    const clvox_palette *palette; /* palette runs: recorded in the header, else NULL */
    const char *metric;      /* palette runs: clvox_metric_name */
} clvox__exr_meta;

/* Opens `path` for streaming: the data goes to an unnamed file in the same
 * directory (O_TMPFILE; a short named temporary where the file system lacks
 * it), given the name `path` by clvox__exr_finish. Anything at `path` that
 * is not a regular file (directory, symbolic link, device, FIFO, socket) is
 * refused with CLVOX_ERR_IO, here and again just before the rename. `channels` is a
 * CLVOX_CHANNEL_* mask (0 = occupancy), any combination of "occupancy" HALF
 * 0.0/1.0, "coverage" HALF, "element" UINT and "score" HALF. meta->palette
 * adds the palette attributes (a palette whose text does not fit an EXR
 * string is refused here). Layout: see docs/formats.md "Output format (EXR)". */
clvox_status clvox__exr_open(clvox_context *ctx, const char *path, const clvox_grid *grid,
                             const clvox__exr_meta *meta, uint32_t channels, clvox_compression compression,
                             uint32_t threads, clvox__exr_writer **out);
/* Slices must arrive in increasing z, without gaps. planes holds the
 * channels the writer was opened with: occupancy as Y*nz bit rows (the slab
 * format above; the file gets HALF 0.0 / 1.0), coverage and score as X*Y*nz
 * HALF bits, element as X*Y*nz uint16 indices (the file gets UINT). */
clvox_status clvox__exr_write_slab(clvox__exr_writer *w, uint32_t z0, uint32_t nz,
                                   const clvox__slab_planes *planes);
/* Completes the file and renames it into place; *bytes = file size. Frees w. */
clvox_status clvox__exr_finish(clvox__exr_writer *w, uint64_t *bytes);
/* Deletes the temporary file and frees w. NULL-safe. */
void clvox__exr_abort(clvox__exr_writer *w);
/* Tests only: nonzero makes the writer use the named temporary file (the
 * fallback for file systems without O_TMPFILE). */
extern int clvox__exr_no_tmpfile;

/* ---- output files (outfile.c) ---- */

/* A file written without a name and named only when complete (outfile.c). */
typedef struct clvox__outfile {
    clvox_context *ctx; /* NULL until created, and again after discard */
    char *path, *dir, *tmp;
    int fd, unnamed;
    uint64_t written;   /* bytes written by clvox__outfile_write */
} clvox__outfile;
/* Refuses an existing `path` that is not a regular file. */
clvox_status clvox__outfile_check_target(clvox_context *ctx, const char *path);
/* Creates the unnamed file in the directory of `path` (CLVOX_ERR_IO). */
clvox_status clvox__outfile_create(clvox__outfile *f, clvox_context *ctx, const char *path);
/* Appends (every byte checked); pwrite at an offset. */
clvox_status clvox__outfile_write(clvox__outfile *f, const void *data, size_t size);
clvox_status clvox__outfile_pwrite(clvox__outfile *f, const void *data, size_t size, uint64_t offset);
/* Syncs the complete file and names it `path`; *bytes = its size. Discards
 * it on failure; either way nothing is left to discard. */
clvox_status clvox__outfile_finish(clvox__outfile *f, uint64_t *bytes);
/* Closes and removes the unnamed file. NULL-safe, idempotent. */
void clvox__outfile_discard(clvox__outfile *f);
/* Names a set of complete files together, files[n-1] (the marker) last: every
 * target is checked before any is touched, and a failure midway renames back
 * the old files that members already placed had replaced; nothing this run
 * did not create is unlinked (outfile.c). Discards every file, either way. */
clvox_status clvox__outfile_finish_set(clvox__outfile *const *files, size_t n);
/* Tests only: k > 0 makes the rename of member k-1 of the next sets fail (EIO). */
extern int clvox__outset_fail_at;

/* ---- other output formats (output.c, write_npy.c, write_nrrd.c, write_binvox.c) ---- */

/* One slab as the format writers take it: any plane may be NULL (not in this
 * slab). coverage and score come both as HALF bits and as floats. */
typedef struct clvox__fmt_slab {
    uint32_t z0, nz;
    const uint32_t *occupancy_bits; /* bit rows (the slab format above) */
    const uint16_t *coverage_half;
    const float *coverage;
    const uint16_t *element;
    const uint16_t *score_half;
    const float *score;
} clvox__fmt_slab;

typedef struct clvox__fmt_info {
    const char *path;
    const clvox_grid *grid;
    uint32_t channels;    /* CLVOX_CHANNEL_* */
    uint32_t flags;       /* CLVOX_OUTPUT_* */
    clvox_compression compression;
    const char *method, *parameters;
    const clvox_palette *palette; /* palette runs: recorded where the format can (EXR), else NULL */
    const char *metric;           /* palette runs: clvox_metric_name */
    uint32_t threads;             /* encoder threads (EXR; 0 = online CPUs) */
} clvox__fmt_info;

typedef struct clvox__fmt_ops {
    const char *name;
    uint32_t channels;    /* the channels the format can hold */
    int one_channel;      /* 1: one channel per file */
    /* 1: coverage and score as the device's HALF bits, straight into the
     * file (no counts, no float copies: EXR); 0: as counts, which the file
     * sink turns into both HALF bits and floats (output.c). */
    int half_bits;
    clvox_status (*open)(clvox_context *ctx, const clvox__fmt_info *info, void **state);
    clvox_status (*write)(void *state, const clvox__fmt_slab *slab);
    clvox_status (*finish)(void *state, uint64_t *bytes);
    void (*abort)(void *state);
} clvox__fmt_ops;
/* EXR (write_exr.c, over clvox__exr_open and the rest above) and the raster formats. */
extern const clvox__fmt_ops clvox__fmt_exr, clvox__fmt_npy, clvox__fmt_nrrd, clvox__fmt_binvox;
/* OpenVDB (.vdb), optional at build time (CLVOX_HAVE_OPENVDB). The writer
 * (write_vdb.cpp) is a plugin, libclvox-vdb.so, that vdb_plugin.c loads on
 * the first .vdb: linked in, libopenvdb cost every run 27 MB of resident
 * memory and 40 ms at start. clvox__fmt_vdb forwards to the plugin's ops;
 * clvox__vdb_load (called before any work) loads it, or fails with the
 * reason: built without OpenVDB, or the plugin not found or not matching. */
extern const clvox__fmt_ops clvox__fmt_vdb;
clvox_status clvox__vdb_load(clvox_context *ctx, const char *path);

/* What the plugin calls back into the library (it links no clvox code), and
 * its one exported entry point, which returns its ops or NULL when `abi` or
 * `version` is not the one it was built with. */
typedef struct clvox__vdb_host {
    clvox_status (*fail)(clvox_context *ctx, clvox_status status, const char *fmt, ...);
    clvox_status (*outfile_create)(clvox__outfile *f, clvox_context *ctx, const char *path);
    clvox_status (*outfile_write)(clvox__outfile *f, const void *data, size_t size);
    clvox_status (*outfile_finish)(clvox__outfile *f, uint64_t *bytes);
    void (*outfile_discard)(clvox__outfile *f);
} clvox__vdb_host;
#define CLVOX__VDB_PLUGIN_NAME "libclvox-vdb.so"
#define CLVOX__VDB_PLUGIN_ENTRY "clvox__vdb_plugin"
/* Changes when a struct the two sides share changes size. */
#define CLVOX__VDB_ABI                                                                                                \
    ((uint32_t)(sizeof(clvox__vdb_host) | sizeof(clvox__outfile) << 8 | sizeof(clvox__fmt_info) << 16 |             \
                (sizeof(clvox__fmt_slab) + sizeof(clvox__fmt_ops) + sizeof(clvox_grid)) << 24))
typedef const clvox__fmt_ops *(*clvox__vdb_plugin_fn)(const clvox__vdb_host *host, uint32_t abi, const char *version);

/* Reading a .vdb back (read_volume.c): the plugin's second entry point
 * returns these, with the same host table and checks. A channel comes as
 * FLOAT bands of whole z slices (read_volume.c's clvox__band_fn). */
typedef clvox_status (*clvox__vdb_band_fn)(void *user, const uint8_t *band, int type, uint64_t row0, uint64_t rows);
typedef struct clvox__vdb_reader_ops {
    /* the header into info (dims, origin, voxel_size, method, parameters, version, channels) */
    clvox_status (*open)(clvox_context *ctx, const char *path, clvox_volume_info *info, void **state);
    int (*has)(void *state, const char *channel);
    clvox_status (*read)(void *state, const char *channel, clvox__vdb_band_fn fn, void *user);
    void (*close)(void *state);
} clvox__vdb_reader_ops;
#define CLVOX__VDB_READER_ENTRY "clvox__vdb_plugin_reader"
#define CLVOX__VDB_READER_ABI                                                                                         \
    ((uint32_t)(sizeof(clvox__vdb_host) | sizeof(clvox__vdb_reader_ops) << 8 | sizeof(clvox_volume_info) << 16))
typedef const clvox__vdb_reader_ops *(*clvox__vdb_reader_fn)(const clvox__vdb_host *host, uint32_t abi,
                                                             const char *version);
/* vdb_plugin.c: loads the plugin and opens `path` with its reader (a clear
 * CLVOX_ERR_EXR when clvox has no OpenVDB or the plugin is missing). */
clvox_status clvox__vdb_reader_open(clvox_context *ctx, const char *path, clvox_volume_info *info, void **state);
int clvox__vdb_reader_has(void *state, const char *channel);
clvox_status clvox__vdb_reader_read(void *state, const char *channel, clvox__vdb_band_fn fn, void *user);
void clvox__vdb_reader_close(void *state);

/* Sample types of the raster formats (npy, NRRD). */
typedef enum clvox__dtype { CLVOX__U8, CLVOX__BITS, CLVOX__F16, CLVOX__F32, CLVOX__U16, CLVOX__U32 } clvox__dtype;
size_t clvox__dtype_row_bytes(clvox__dtype t, uint32_t X);
/* Rows of the slab's `channel` as the file stores them (little-endian): rows
 * = Y*nz, each clvox__dtype_row_bytes; 0 when the slab lacks that plane. */
int clvox__encode_rows(const clvox__fmt_slab *s, uint32_t channel, clvox__dtype t, uint32_t X, size_t rows,
                       uint8_t *out);
/* "occupancy", "coverage", "element", "score" for one CLVOX_CHANNEL_* bit. */
const char *clvox__channel_name(uint32_t channel);
/* The file's main channel: occupancy, else element, else coverage, else score. */
uint32_t clvox__main_channel(uint32_t channels);
/* The file of `channel`: `path` for the main channel, else the channel's name
 * before the extension ("out.npy" -> "out.coverage.npy"); malloc'ed, NULL when out of memory. */
char *clvox__channel_path(const char *path, uint32_t channel, uint32_t channels);
/* `path` with its extension replaced by `ext` ("out.npy" -> "out.json"). */
char *clvox__replace_ext(const char *path, const char *ext);

/* The pipeline for output.c's file formats: coverage and score as sample
 * counts (counts = 1; samples per voxel in *samples) or as HALF bits
 * (counts = 0), the sink opened once the method is prepared. */
typedef clvox_status (*clvox__open_fn)(void *user, const char *method, const char *params);
typedef clvox_status (*clvox__sink_fn)(void *user, uint32_t z0, uint32_t nz, const clvox__slab_planes *planes);
clvox_status clvox__voxelize_to_sink(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                     const clvox_voxelize_options *options, int counts, clvox__open_fn open_sink,
                                     clvox__sink_fn sink, void *user, uint32_t *channels, uint32_t *samples,
                                     clvox_stats *stats);

#ifdef __cplusplus
}
#endif
#endif /* CLVOX_INTERNAL_H */
