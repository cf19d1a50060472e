/* SPDX-License-Identifier: Apache-2.0 */
/* Stage grid: the voxel grid from the user's choice of resolution, dims or
 * voxel size, and the mesh in grid space (voxel centres at integers). */
#include "core/internal.h"
#include "core/parallel.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static int finite3(const double v[3]) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

clvox_status clvox_grid_compute(clvox_context *ctx, const clvox_grid_options *options,
                                const double bbox_min[3], const double bbox_max[3], clvox_grid *out)
{
    if (!out || !bbox_min || !bbox_max) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "NULL argument");
    clvox_grid_options o = CLVOX_GRID_OPTIONS_INIT;
    if (options) {
        if (options->size < sizeof(size_t) || options->size > sizeof o)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_grid_options.size is %zu", options->size);
        memcpy(&o, options, options->size);
    }
    memset(out, 0, sizeof *out);

    double lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = o.use_box ? o.box_min[a] : bbox_min[a];
        hi[a] = o.use_box ? o.box_max[a] : bbox_max[a];
    }
    if (!finite3(lo) || !finite3(hi))
        return clvox__fail(ctx, CLVOX_ERR_GRID, "bounding box is not finite");
    for (int a = 0; a < 3; a++)
        if (hi[a] < lo[a])
            return clvox__fail(ctx, CLVOX_ERR_GRID, "box max < min on axis %c", "xyz"[a]);

    int has_dims = o.dims[0] || o.dims[1] || o.dims[2];
    int has_size = o.voxel_size[0] != 0 || o.voxel_size[1] != 0 || o.voxel_size[2] != 0;
    int modes = (o.resolution != 0) + has_dims + has_size;
    if (modes > 1)
        return clvox__fail(ctx, CLVOX_ERR_GRID, "give only one of resolution, dims and voxel size");
    if (modes == 0) o.resolution = 256;

    double ext[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
    for (int a = 0; a < 3; a++)
        if (!isfinite(ext[a]))
            return clvox__fail(ctx, CLVOX_ERR_GRID,
                               "the box extent on axis %c overflows a double (%.6g to %.6g): use a smaller box",
                               "xyz"[a], lo[a], hi[a]);
    double longest = fmax(ext[0], fmax(ext[1], ext[2]));
    if (o.cube) {
        if (has_dims && (o.dims[0] != o.dims[1] || o.dims[0] != o.dims[2]))
            return clvox__fail(ctx, CLVOX_ERR_GRID, "a cubic grid needs equal dims (got %u,%u,%u)", o.dims[0],
                               o.dims[1], o.dims[2]);
        double s1 = o.voxel_size[1] != 0 ? o.voxel_size[1] : o.voxel_size[0];
        double s2 = o.voxel_size[2] != 0 ? o.voxel_size[2] : o.voxel_size[0];
        if (has_size && (o.voxel_size[0] != s1 || o.voxel_size[0] != s2))
            return clvox__fail(ctx, CLVOX_ERR_GRID, "a cubic grid needs one voxel size (got %.6g,%.6g,%.6g)",
                               o.voxel_size[0], o.voxel_size[1], o.voxel_size[2]);
        /* binvox's cube: the longest edge on every axis, around the box's
         * centre; an axis already that long keeps its bounds exactly */
        for (int a = 0; a < 3; a++) {
            if (ext[a] == longest) continue;
            double c = lo[a] + 0.5 * ext[a];
            lo[a] = c - 0.5 * longest;
            hi[a] = lo[a] + longest;
            ext[a] = longest;
            if (!isfinite(lo[a]) || !isfinite(hi[a]))
                return clvox__fail(ctx, CLVOX_ERR_GRID, "the cube around the box overflows a double on axis %c",
                                   "xyz"[a]);
        }
    }
    uint64_t dims[3];
    double h[3];

    if (o.resolution) {
        if (o.resolution > CLVOX_MAX_AXIS)
            return clvox__fail(ctx, CLVOX_ERR_GRID, "resolution %u exceeds the maximum %u voxels per axis",
                               o.resolution, CLVOX_MAX_AXIS);
        if (!(longest > 0))
            return clvox__fail(ctx, CLVOX_ERR_GRID,
                               "the box has zero extent (at %.9g, %.9g, %.9g; vertices are 32-bit floats, so points "
                               "closer than their spacing there coincide): give --box, --dims or --voxel-size",
                               lo[0], lo[1], lo[2]);
        int la = ext[0] >= ext[1] ? (ext[0] >= ext[2] ? 0 : 2) : (ext[1] >= ext[2] ? 1 : 2);
        double hh = longest / o.resolution;
        for (int a = 0; a < 3; a++) {
            /* The longest axis gets exactly N; the others ceil(ext*N/longest),
             * computed as a ratio so rounding cannot exceed N. */
            if (a == la) {
                dims[a] = o.resolution;
            } else {
                double n = ceil(ext[a] / longest * o.resolution);
                if (n > o.resolution) n = o.resolution;
                dims[a] = n < 1 ? 1 : (uint64_t)n;
            }
            h[a] = hh;
        }
    } else if (has_dims) {
        for (int a = 0; a < 3; a++) {
            if (o.dims[a] == 0)
                return clvox__fail(ctx, CLVOX_ERR_GRID, "dims must all be >= 1 (got %u,%u,%u)", o.dims[0],
                                   o.dims[1], o.dims[2]);
            if (o.dims[a] > CLVOX_MAX_AXIS)
                return clvox__fail(ctx, CLVOX_ERR_GRID, "dims %u on axis %c exceeds the maximum %u", o.dims[a],
                                   "xyz"[a], CLVOX_MAX_AXIS);
            dims[a] = o.dims[a];
            /* A flat axis still needs a voxel size: use the longest extent's. */
            h[a] = ext[a] > 0 ? ext[a] / o.dims[a] : (longest > 0 ? longest / o.dims[a] : 1.0);
        }
    } else {
        for (int a = 0; a < 3; a++) {
            double s = o.voxel_size[a] != 0 ? o.voxel_size[a] : o.voxel_size[0];
            if (!(s > 0) || !isfinite(s))
                return clvox__fail(ctx, CLVOX_ERR_GRID, "voxel size must be > 0 (axis %c)", "xyz"[a]);
            double n = ceil(ext[a] / s);
            if (n < 1) n = 1;
            if (n > CLVOX_MAX_AXIS)
                return clvox__fail(ctx, CLVOX_ERR_GRID, "voxel size %.6g gives %.3g voxels on axis %c (maximum %u)",
                                   s, n, "xyz"[a], CLVOX_MAX_AXIS);
            dims[a] = (uint64_t)n;
            h[a] = s;
        }
    }
    for (int a = 0; a < 3; a++) {
        uint64_t d = dims[a] + 2ull * o.padding;
        if (d > CLVOX_MAX_AXIS)
            return clvox__fail(ctx, CLVOX_ERR_GRID, "%llu voxels on axis %c (with padding) exceeds the maximum %u",
                               (unsigned long long)d, "xyz"[a], CLVOX_MAX_AXIS);
        out->dims[a] = (uint32_t)d;
        out->voxel_size[a] = h[a];
        out->origin[a] = lo[a] - (double)o.padding * h[a];
        if (!(h[a] > 0) || !isfinite(h[a]))
            return clvox__fail(ctx, CLVOX_ERR_GRID, "voxel size %.6g on axis %c is not representable (extent %.6g)",
                               h[a], "xyz"[a], ext[a]);
        if (!isfinite(out->origin[a]))
            return clvox__fail(ctx, CLVOX_ERR_GRID,
                               "the grid origin on axis %c overflows a double (box minimum %.6g, padding %u x %.6g)",
                               "xyz"[a], lo[a], o.padding, h[a]);
    }
    /* Each factor <= 2^16, so the products cannot overflow 64 bits. */
    uint64_t total = (uint64_t)out->dims[0] * out->dims[1] * out->dims[2];
    if (total > CLVOX_MAX_VOXELS)
        return clvox__fail(ctx, CLVOX_ERR_GRID, "grid %ux%ux%u has %llu voxels, more than the maximum %llu",
                           out->dims[0], out->dims[1], out->dims[2], (unsigned long long)total,
                           (unsigned long long)CLVOX_MAX_VOXELS);
    if ((uint64_t)out->dims[1] * out->dims[2] > 0x7FFFFFFFull)
        return clvox__fail(ctx, CLVOX_ERR_GRID, "grid %ux%ux%u: Y*Z exceeds the EXR image height limit 2^31-1",
                           out->dims[0], out->dims[1], out->dims[2]);
    return CLVOX_OK;
}

clvox__axes clvox__axes_for(clvox_axis axis)
{
    clvox__axes ax = {{0, 1, 2}};
    if (axis == CLVOX_AXIS_Y) ax = (clvox__axes){{1, 2, 0}};
    if (axis == CLVOX_AXIS_Z) ax = (clvox__axes){{2, 0, 1}};
    return ax;
}

typedef struct soup_job {
    const clvox_mesh *mesh;
    const clvox_grid *grid;
    clvox__axes axes;
    double o[3];
    float *gv, *soup;
} soup_job;

/* Each vertex transformed once (double, one rounding), permuted to u,v,w.
 * Vertices are relative to mesh->offset: the origin is moved instead
 * (origin - offset, exactly the origin when the offset is 0). */
static void soup_vertices(void *arg, int i, int n)
{
    soup_job *J = arg;
    size_t v0, v1;
    clvox__part_range(J->mesh->vertex_count, i, n, &v0, &v1);
    const float *xyz = J->mesh->xyz;
    for (size_t v = v0; v < v1; v++)
        for (int k = 0; k < 3; k++) {
            int a = J->axes.perm[k];
            J->gv[v * 3 + k] = clvox__grid_coord(xyz[v * 3 + a], J->o[a], J->grid->voxel_size[a]);
        }
}

static void soup_triangles(void *arg, int i, int n)
{
    soup_job *J = arg;
    size_t t0, t1;
    clvox__part_range(J->mesh->triangle_count, i, n, &t0, &t1);
    const uint32_t *tris = J->mesh->tris;
    for (size_t t = t0; t < t1; t++)
        for (int c = 0; c < 3; c++)
            memcpy(&J->soup[t * 9 + c * 3], &J->gv[(size_t)tris[t * 3 + c] * 3], 3 * sizeof(float));
}

/* Page-aligned: a device buffer can use it in place (CL_MEM_USE_HOST_PTR, cast.c). */
static float *page_floats(size_t n)
{
    size_t bytes = ((n ? n : 1) * sizeof(float) + 4095) / 4096 * 4096;
    return aligned_alloc(4096, bytes);
}

clvox_status clvox__grid_space_vertices(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                        clvox__axes axes, int threads, float **out_vertices)
{
    *out_vertices = NULL;
    size_t nv = mesh->vertex_count;
    if (nv > SIZE_MAX / (3 * sizeof(float)) - 4096)
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "mesh too large");
    float *gv = page_floats(nv * 3);
    if (!gv) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu vertices in grid space", nv);
    ctx->grid_space_count++;
    if (threads <= 0) threads = clvox__host_threads();
    if (nv < 10000) threads = 1;
    soup_job J = {.mesh = mesh, .grid = grid, .axes = axes, .gv = gv};
    for (int a = 0; a < 3; a++) J.o[a] = grid->origin[a] - mesh->offset[a];
    clvox__parallel(threads, soup_vertices, &J);
    *out_vertices = gv;
    return CLVOX_OK;
}

clvox_status clvox__grid_space_soup_threads(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                            clvox__axes axes, int threads, float **out_soup)
{
    *out_soup = NULL;
    size_t nt = mesh->triangle_count;
    if (nt > SIZE_MAX / (9 * sizeof(float)) - 4096)
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "mesh too large");
    if (threads <= 0) threads = clvox__host_threads();
    if (nt < 20000) threads = 1;
    float *gv = NULL;
    clvox_status st = clvox__grid_space_vertices(ctx, mesh, grid, axes, threads, &gv);
    if (st != CLVOX_OK) return st;
    float *soup = page_floats(nt * 9);
    if (!soup) {
        free(gv);
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu triangles in grid space", nt);
    }
    soup_job J = {.mesh = mesh, .grid = grid, .axes = axes, .gv = gv, .soup = soup};
    clvox__parallel(threads, soup_triangles, &J);
    free(gv);
    *out_soup = soup;
    return CLVOX_OK;
}

clvox_status clvox__grid_space_soup(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                    clvox__axes axes, float **out_soup)
{
    return clvox__grid_space_soup_threads(ctx, mesh, grid, axes, 0, out_soup);
}
