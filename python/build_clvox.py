# SPDX-License-Identifier: Apache-2.0
"""cffi (API mode) builder for clvox._clvox.

Links the clvox C library statically, so the extension needs only the system
libraries clvox itself uses (OpenCL ICD loader, OpenEXRCore, OpenMesh, Assimp).
Where the library comes from, first match wins:

  CLVOX_LIB=/path/libclvox.a CLVOX_INCLUDE=/path/include   explicit
  ../build/release/libclvox.a and ../include                the repository this
                                                            folder sits in (run
                                                            `make` there first)
  pkg-config clvox                                          `make install`

Used by setup.py (pip install ./python, pip wheel ./python) and directly by
tests/python_tests.sh:  python3 build_clvox.py OUTDIR  (compiles into OUTDIR).
"""
import os
import shlex
import subprocess
import sys

from cffi import FFI

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
SYSTEM_LIBS = ["OpenCL", "OpenEXRCore-3_1", "OpenMeshCore", "assimp", "stdc++", "m", "pthread"]

CDEF = r"""
typedef enum clvox_status {
    CLVOX_OK = 0, CLVOX_ERR_INVALID_ARGUMENT, CLVOX_ERR_OUT_OF_MEMORY, CLVOX_ERR_IO,
    CLVOX_ERR_MESH_FORMAT, CLVOX_ERR_MESH_INVALID, CLVOX_ERR_MESH_EMPTY, CLVOX_ERR_GRID,
    CLVOX_ERR_NO_DEVICE, CLVOX_ERR_OPENCL, CLVOX_ERR_KERNEL_BUILD, CLVOX_ERR_EXR,
    CLVOX_ERR_CANCELLED, CLVOX_ERR_INTERNAL, CLVOX_ERR_PALETTE_FORMAT, CLVOX_STATUS_COUNT
} clvox_status;
const char *clvox_status_string(clvox_status status);
const char *clvox_version(void);

typedef struct clvox_context clvox_context;
typedef struct clvox_context_options { size_t size; const char *device; int host_only; int float_kernels; ...; } clvox_context_options;
typedef struct clvox_device_info {
    size_t size; uint32_t index; char name[128]; char platform[128]; char type[16]; char version[64];
    uint32_t compute_units; uint64_t global_mem_bytes; uint64_t max_alloc_bytes; int fp64;
    int kernels_float; float fp64_slowdown; ...;
} clvox_device_info;
clvox_status clvox_list_devices(clvox_device_info *out, size_t capacity, size_t *count);
clvox_status clvox_context_create(const clvox_context_options *options, clvox_context **out);
void clvox_context_destroy(clvox_context *ctx);
const char *clvox_context_error(const clvox_context *ctx);
const clvox_device_info *clvox_context_device(const clvox_context *ctx);
size_t clvox_context_device_count(const clvox_context *ctx);
const clvox_device_info *clvox_context_device_at(const clvox_context *ctx, size_t i);
const char *clvox_context_warnings(const clvox_context *ctx);

typedef struct clvox_mesh clvox_mesh;
typedef struct clvox_mesh_report {
    uint64_t input_vertices; uint64_t input_faces; uint64_t polygons_triangulated;
    uint64_t vertices; uint64_t triangles; uint64_t dropped_faces; uint64_t degenerate_triangles;
    uint64_t nonmanifold_faces; uint64_t boundary_edges; int closed;
    double bbox_min[3]; double bbox_max[3]; double enclosed_volume; uint64_t duplicate_triangles; ...;
} clvox_mesh_report;
clvox_status clvox_mesh_load(clvox_context *ctx, const char *path, clvox_mesh **out);
clvox_status clvox_mesh_from_arrays(clvox_context *ctx, const float *xyz, size_t vertex_count,
                                    const uint32_t *triangles, size_t triangle_count, clvox_mesh **out);
void clvox_mesh_destroy(clvox_mesh *mesh);
const clvox_mesh_report *clvox_mesh_get_report(const clvox_mesh *mesh);

typedef struct clvox_grid_options {
    size_t size; uint32_t resolution; uint32_t dims[3]; double voxel_size[3];
    int use_box; double box_min[3]; double box_max[3]; uint32_t padding; int cube; ...;
} clvox_grid_options;
typedef struct clvox_grid { uint32_t dims[3]; double origin[3]; double voxel_size[3]; } clvox_grid;
clvox_status clvox_grid_compute(clvox_context *ctx, const clvox_grid_options *options,
                                const double bbox_min[3], const double bbox_max[3], clvox_grid *out);

typedef enum clvox_method { CLVOX_METHOD_RAY = 0, CLVOX_METHOD_TETRA, CLVOX_METHOD_COUNT } clvox_method;
typedef enum clvox_axis { CLVOX_AXIS_DEFAULT = 0, CLVOX_AXIS_X, CLVOX_AXIS_Y, CLVOX_AXIS_Z } clvox_axis;
typedef enum clvox_compression {
    CLVOX_COMPRESSION_DEFAULT = 0, CLVOX_COMPRESSION_NONE, CLVOX_COMPRESSION_RLE, CLVOX_COMPRESSION_ZIPS,
    CLVOX_COMPRESSION_ZIP, CLVOX_COMPRESSION_PIZ, CLVOX_COMPRESSION_COUNT
} clvox_compression;
typedef enum clvox_tetra_origin { CLVOX_TETRA_ORIGIN_CENTROID = 0, CLVOX_TETRA_ORIGIN_BBOX_CENTER,
                                  CLVOX_TETRA_ORIGIN_POINT } clvox_tetra_origin;
typedef enum clvox_stage { CLVOX_STAGE_LOAD = 0, CLVOX_STAGE_PARTITION, CLVOX_STAGE_CAST, CLVOX_STAGE_CLASSIFY,
                           CLVOX_STAGE_WRITE, CLVOX_STAGE_TOTAL, CLVOX_STAGE_COUNT } clvox_stage;
const char *clvox_stage_name(clvox_stage stage);
typedef int (*clvox_progress_fn)(void *user, double fraction);
typedef struct clvox_palette clvox_palette;
typedef enum clvox_metric { CLVOX_METRIC_NEAREST = 0, CLVOX_METRIC_OUTER, CLVOX_METRIC_INNER,
                            CLVOX_METRIC_COUNT } clvox_metric;
typedef enum clvox_mode { CLVOX_MODE_SOLID = 0, CLVOX_MODE_SURFACE, CLVOX_MODE_CONSERVATIVE,
                          CLVOX_MODE_COUNT } clvox_mode;

typedef enum clvox_inside { CLVOX_INSIDE_DEFAULT = 0, CLVOX_INSIDE_WINDING, CLVOX_INSIDE_WINDING_ABS,
                            CLVOX_INSIDE_PARITY, CLVOX_INSIDE_COUNT } clvox_inside;
const char *clvox_inside_name(clvox_inside inside);

typedef struct clvox_voxelize_options {
    size_t size; clvox_method method; clvox_axis ray_axis; uint32_t quadtree_max_depth;
    uint32_t quadtree_leaf_size; uint32_t slab_depth; uint32_t hit_capacity; clvox_compression compression;
    uint32_t threads; clvox_tetra_origin tetra_origin; double tetra_point[3];
    clvox_progress_fn progress; void *progress_user;
    uint32_t oversample; uint32_t oversample_points; int stochastic; uint64_t seed; uint32_t channels;
    int threshold_set; double threshold; const clvox_palette *palette; clvox_metric metric;
    int palette_no_early_out; int nearest_shortcut; double shortcut_alpha, shortcut_beta; clvox_mode mode;
    clvox_inside inside; double weld; ...;
} clvox_voxelize_options;

#define CLVOX_CHANNEL_OCCUPANCY ...
#define CLVOX_CHANNEL_COVERAGE ...
#define CLVOX_CHANNEL_ELEMENT ...
#define CLVOX_CHANNEL_SCORE ...

typedef struct clvox_winding_report {
    uint64_t merged_vertices; uint64_t welded_vertices; uint64_t dropped_triangles; uint64_t components;
    uint64_t closed_components; uint64_t cavities; uint64_t flipped_triangles; uint64_t nonmanifold_edges;
    uint64_t nonorientable_components; uint64_t boundary_edges; uint64_t holes; uint64_t cap_triangles;
    uint64_t exact_points; double seconds; ...;
} clvox_winding_report;

typedef struct clvox_device_share {
    uint32_t device; uint32_t slabs; uint64_t slices; double busy_seconds; uint32_t discarded_slabs;
    int failed; int left_out; ...;
} clvox_device_share;

typedef struct clvox_stats {
    size_t size; double seconds[6]; uint64_t filled_voxels; uint64_t total_voxels; uint64_t rays; uint64_t odd_parity_rays;
    uint64_t overflow_rays; uint32_t max_crossings; uint32_t quadtree_depth; uint64_t quadtree_leaves;
    uint64_t quadtree_refs; uint32_t slab_depth; uint64_t peak_slab_bytes; uint64_t output_bytes;
    uint32_t channels; uint32_t samples_per_voxel; double coverage_sum;
    uint64_t palette_early_voxels; uint64_t palette_shortcut_voxels; uint64_t palette_scored_voxels;
    uint64_t palette_nonempty_voxels; double palette_volume; clvox_inside inside;
    clvox_winding_report winding; uint32_t device_count; clvox_device_share devices[16];
    double scheduling_efficiency; uint32_t reorder_slabs; uint64_t reorder_bytes; uint32_t reorder_peak;
    double winding_exact_seconds; double crack_weld_distance; uint64_t crack_welded_vertices;
    uint64_t crack_pairs; uint64_t crack_holes; uint64_t winding_host_points; ...;
} clvox_stats;

clvox_status clvox_voxelize_to_exr(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                   const clvox_voxelize_options *options, const char *path, clvox_stats *stats);
typedef enum clvox_format { CLVOX_FORMAT_AUTO = 0, CLVOX_FORMAT_EXR, CLVOX_FORMAT_NPY, CLVOX_FORMAT_NRRD,
                             CLVOX_FORMAT_BINVOX, CLVOX_FORMAT_VDB, CLVOX_FORMAT_COUNT } clvox_format;
const char *clvox_format_name(clvox_format format);
clvox_format clvox_format_from_name(const char *name);
clvox_format clvox_format_from_path(const char *path);
#define CLVOX_OUTPUT_PACK_BITS ...
#define CLVOX_OUTPUT_FLOAT32 ...
#define CLVOX_OUTPUT_UINT32 ...
typedef struct clvox_output_options {
    size_t size; clvox_format format; uint32_t flags; clvox_compression compression; uint32_t threads;
    const char *method; const char *parameters; ...;
} clvox_output_options;
clvox_status clvox_voxelize_to_file(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                    const clvox_voxelize_options *options, const clvox_output_options *output,
                                    const char *path, clvox_stats *stats);
typedef struct clvox_slab {
    uint32_t z0, nz; const uint8_t *occupancy; const float *coverage; const uint16_t *element; const float *score;
} clvox_slab;
typedef int (*clvox_slab_channels_fn)(void *user, const clvox_slab *slab);
clvox_status clvox_voxelize_slabs(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                  const clvox_voxelize_options *options, clvox_slab_channels_fn fn,
                                  void *user, clvox_stats *stats);

typedef struct clvox_volume_info {
    size_t size; uint32_t dims[3]; double origin[3]; double voxel_size[3]; char method[32]; char parameters[256];
    char version[32]; char compression[16]; char channels[64]; uint64_t filled_voxels; double coverage_sum;
    char palette[64]; uint32_t palette_count; uint64_t palette_hash; char metric[16]; ...;
} clvox_volume_info;
typedef int (*clvox_volume_slice_fn)(void *user, uint32_t z, const float *values);
clvox_status clvox_volume_read_slices(clvox_context *ctx, const char *path, const char *channel,
                                      clvox_volume_info *info, clvox_volume_slice_fn fn, void *user);

const char *clvox_palette_builtin_name(size_t i);
clvox_status clvox_palette_builtin(clvox_context *ctx, const char *name, clvox_palette **out);
clvox_status clvox_palette_load(clvox_context *ctx, const char *path, clvox_palette **out);
void clvox_palette_destroy(clvox_palette *palette);
const char *clvox_palette_name(const clvox_palette *palette);
size_t clvox_palette_count(const clvox_palette *palette);

/* ---- the binding's own C helpers (set_source below) ---- */
typedef struct pyclvox_run {
    uint64_t X, Y, Z;
    uint8_t *occupancy; float *coverage; uint16_t *element; float *score; /* malloc'd, owned by Python after */
    int out_of_memory;
    int call_python;          /* progress: call pyclvox_py_progress(handle, f) */
    void *handle;
    volatile int cancel;      /* set from Python (another thread) to stop the run */
    float *read_dest;         /* clvox.read: the float volume being filled      */
} pyclvox_run;
int pyclvox_slab_to_dense(void *user, const clvox_slab *slab);
int pyclvox_progress(void *user, double fraction);
int pyclvox_slice_to_dense(void *user, uint32_t z, const float *values);
int pyclvox_slice_probe(void *user, uint32_t z, const float *values);
void free(void *);
extern "Python" int pyclvox_py_progress(void *handle, double fraction);
extern "Python" int pyclvox_py_slab(void *user, const clvox_slab *slab);
"""

SOURCE = r"""
#include <stdlib.h>
#include <string.h>
#include <clvox.h>

typedef struct pyclvox_run {
    uint64_t X, Y, Z;
    uint8_t *occupancy; float *coverage; uint16_t *element; float *score;
    int out_of_memory;
    int call_python;
    void *handle;
    volatile int cancel;
    float *read_dest;
} pyclvox_run;

static int pyclvox_py_progress(void *handle, double fraction);

/* One channel of a slab into its dense X*Y*Z array, allocated on first use
 * (no GIL needed: plain C). */
static int pyclvox_copy(void **dst, const void *src, size_t elem, const pyclvox_run *r, const clvox_slab *s,
                        int *oom)
{
    if (!src) return 0;
    size_t plane = (size_t)(r->X * r->Y);
    if (!*dst) {
        *dst = malloc((size_t)(r->X * r->Y * r->Z) * elem);
        if (!*dst) { *oom = 1; return 1; }
    }
    memcpy((char *)*dst + (size_t)s->z0 * plane * elem, src, (size_t)s->nz * plane * elem);
    return 0;
}

static int pyclvox_slab_to_dense(void *user, const clvox_slab *s)
{
    pyclvox_run *r = user;
    if (r->cancel) return 1;
    if (pyclvox_copy((void **)&r->occupancy, s->occupancy, 1, r, s, &r->out_of_memory)) return 1;
    if (pyclvox_copy((void **)&r->coverage, s->coverage, sizeof(float), r, s, &r->out_of_memory)) return 1;
    if (pyclvox_copy((void **)&r->element, s->element, sizeof(uint16_t), r, s, &r->out_of_memory)) return 1;
    if (pyclvox_copy((void **)&r->score, s->score, sizeof(float), r, s, &r->out_of_memory)) return 1;
    return 0;
}

/* The library's progress callback: 0 cancels. Python is entered (GIL taken)
 * only at the library's rate (each slab, at most 10 times a second), where
 * pending signals (Ctrl-C) and the user's callback are handled. */
static int pyclvox_progress(void *user, double fraction)
{
    pyclvox_run *r = user;
    if (r->cancel) return 0;
    if (r->call_python && !pyclvox_py_progress(r->handle, fraction)) { r->cancel = 1; return 0; }
    return 1;
}

static int pyclvox_slice_to_dense(void *user, uint32_t z, const float *values)
{
    pyclvox_run *r = user;
    if (r->cancel) return 1;
    size_t plane = (size_t)(r->X * r->Y);
    memcpy(r->read_dest + (size_t)z * plane, values, plane * sizeof(float));
    return 0;
}

/* Stops at once: used to read a volume's header alone. */
static int pyclvox_slice_probe(void *user, uint32_t z, const float *values)
{
    (void)user; (void)z; (void)values;
    return 1;
}
"""


def _pkg_config():
    try:
        cflags = subprocess.check_output(["pkg-config", "--cflags", "clvox"], text=True)
        libs = subprocess.check_output(["pkg-config", "--libs", "--static", "clvox"], text=True)
    except (OSError, subprocess.CalledProcessError):
        return None
    return shlex.split(cflags), shlex.split(libs)


def _configure():
    lib = os.environ.get("CLVOX_LIB")
    inc = os.environ.get("CLVOX_INCLUDE")
    if not lib:
        cand = os.path.join(REPO, "build", "release", "libclvox.a")
        if os.path.exists(cand):
            lib, inc = cand, inc or os.path.join(REPO, "include")
    if lib:
        libs = SYSTEM_LIBS
        # the Makefile's link line (with -lopenvdb ... when built with OpenVDB), next to the archive
        side = os.path.join(os.path.dirname(lib), "libclvox.libs")
        if os.path.exists(side):
            with open(side) as f:
                libs = [t[2:] for t in f.read().split() if t.startswith("-l")]
        return dict(include_dirs=[inc or os.path.join(REPO, "include")], extra_objects=[lib],
                    libraries=libs)
    pc = _pkg_config()
    if pc:
        cflags, libs = pc
        return dict(extra_compile_args=cflags, extra_link_args=libs)
    raise RuntimeError("clvox: no library found: run `make` in the repository (build/release/libclvox.a), "
                       "`make install` (pkg-config clvox), or set CLVOX_LIB and CLVOX_INCLUDE")


ffibuilder = FFI()
ffibuilder.cdef(CDEF)
ffibuilder.set_source("clvox._clvox", SOURCE, **_configure())

if __name__ == "__main__":
    out = sys.argv[1] if len(sys.argv) > 1 else "."
    os.makedirs(out, exist_ok=True)
    ffibuilder.compile(tmpdir=out, verbose=False)
