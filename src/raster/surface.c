/* SPDX-License-Identifier: Apache-2.0 */
/* Stage surface: surface voxelization, every voxel whose closed cell meets a
 * triangle of the mesh (CLVOX_MODE_SURFACE), and, OR-ed over a solid slab,
 * the conservative volume solid | surface (CLVOX_MODE_CONSERVATIVE, composed
 * by the driver). kernels/surface.cl does the device work, with the exact
 * predicates of kernels/overlap.h.
 *
 * Rule. In grid space (clvox__grid_space_soup: voxel centres at integers,
 * each vertex rounded once to float) cell (i,j,k) is the closed box
 * [i - 1/2, i + 1/2] x [j - 1/2, j + 1/2] x [k - 1/2, k + 1/2] and a triangle
 * is the closed convex hull of its three float vertices. A voxel is marked
 * when the two intersect, decided exactly for those floats: a triangle that
 * only touches a cell's face, edge or corner marks it, so a face lying on
 * the plane between two cells marks both, and a vertex on a cell corner
 * marks the 8 cells around it. Degenerate triangles (a segment, a point) are
 * their convex hulls and mark the cells they touch. No parity, no
 * orientation: open meshes and soups are fine.
 *
 * Test. The separating-axis theorem for a triangle and a box (13 axes:
 * the 3 box normals, the triangle normal n, the 9 products e_k x d_m of box
 * axes and triangle edges; Akenine-Moller 2001): two compact convex
 * polytopes are disjoint iff one of the facet normals of their Minkowski
 * difference strictly separates them, and those normals are among the 13
 * (for a degenerate triangle, among the non-zero ones), so overlap is "no
 * axis separates", with touching (equal projections' ends) counted as
 * overlap. Each axis is two predicates, the signs of polynomials of degree
 * 2 (box normals: comparisons of floats with half-integers; edge axes: a 2x2
 * determinant in the projection along e_k) or 3 (n . (corner - v0)), each
 * evaluated exactly (kernels/overlap.h: Shewchuk's error bounds, then an
 * exact expansion), at the box corner extreme along the axis, which is
 * chosen from exact signs (float comparisons, exact signs of n's
 * components). Along a row (j, k fixed) each predicate is the sign of an
 * affine function of x with an exactly known slope sign, so the row's cells
 * form an interval [L, U]; the kernel finds L and U from approximate roots
 * and settles them by exact evaluation at the integers around them, walking
 * until the predicate flips (approximations only choose where to look).
 * Rows run along the axis with the fewest rows in each task's box (x, y or
 * z: the kernel permutes the triangle's coordinates; exact signs make the
 * frame irrelevant to the result).
 * The result is the per-cell test for every cell, bit for bit, on any
 * device, with fp64 or without (the predicates in float: overlap.h;
 * coordinates outside float's exact range refuse a float run); tests/test_surface.c compares it with a CPU reference that clips
 * each triangle by each cell in GMP rationals.
 *
 * Streaming (as the tetra method): prepare computes each triangle's exact
 * cell ranges once and drops those outside the grid; per slab the host lists
 * tasks (triangle, at most SLICES_PER_TASK slices, at most ROWS_PER_TASK
 * rows), the kernel ORs each task's intervals into the slab's bit rows
 * (atomic_or), and a count kernel adds up the slab's bits. Slabs are
 * independent: the same volume in any slab depth and order. Memory: the
 * soup, the ranges, one slab's task list and the driver's slab buffer.
 * Several devices (clvox__run.lead): the first device of a run computes
 * the soup and the ranges; the others share its ranges (one host array)
 * and copy its device soup (raster_enqueue.h). */
#include "raster_enqueue.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SLICES_PER_TASK 8
#define ROWS_PER_TASK 32

struct clvox__method_state {
    clvox_context *ctx;
    clvox_grid grid;
    int accumulate;      /* 1: OR over the slab the previous method left (conservative) */
    size_t tri_count;    /* triangles kept (those meeting the grid) */
    int32_t *range;      /* 4 per triangle: first slice, last slice, first row, last row;
                          * shared with the run's other devices (clvox__shared_i32) */
    uint32_t words_per_row;
    size_t float_outside;  /* first kept triangle + 1 with a coordinate outside float's exact range (0: none) */
    float float_coord;     /* that coordinate */
    clvox__raster_tasks tasks; /* the slab's (triangle, first slice, end slice, rows first | last << 16) */
    cl_mem soup, filled;
    cl_kernel k_raster, k_count;
    int (*poll)(void *, double);
    void *poll_user;
};

static void surface_release(clvox__method_state *s)
{
    if (!s) return;
    clvox__release_mem(&s->soup);
    clvox__raster_tasks_release(&s->tasks);
    clvox__release_mem(&s->filled);
    if (s->k_raster) clReleaseKernel(s->k_raster);
    if (s->k_count) clReleaseKernel(s->k_count);
    clvox__shared_i32_drop(s->range);
    free(s);
}

/* Cells i of [0, n-1] whose closed extent [i - 1/2, i + 1/2] meets [mn, mx]
 * (floats): *lo .. *hi, exact comparisons; 0 when none. Same rule as
 * clvox_first_cell / clvox_last_cell in kernels/surface.cl. */
static int cell_range(double mn, double mx, uint32_t n, int32_t *lo, int32_t *hi)
{
    const double top = (double)n - 1.0;
    if (!(mn <= top + 0.5) || !(mx >= -0.5)) return 0;
    double l = mn <= -0.5 ? 0.0 : ceil(mn - 0.5);
    while (l > 0 && (l - 1.0) + 0.5 >= mn) l -= 1.0;
    while (l <= top && l + 0.5 < mn) l += 1.0;
    double h = mx >= top + 0.5 ? top : floor(mx + 0.5);
    while (h < top && (h + 1.0) - 0.5 <= mx) h += 1.0;
    while (h >= 0 && h - 0.5 > mx) h -= 1.0;
    if (l > h) return 0;
    *lo = (int32_t)l;
    *hi = (int32_t)h;
    return 1;
}

/* The host work, done once for a run (by its first device): the grid-space
 * soup, each triangle's cell ranges, the triangles outside the grid
 * dropped; the soup uploaded. */
static clvox_status surface_host(clvox__method_state *s, const clvox_mesh *mesh, const clvox_grid *grid)
{
    clvox_context *ctx = s->ctx;
    float *soup = NULL;
    clvox_status st = clvox__grid_space_soup(ctx, mesh, grid, clvox__axes_for(CLVOX_AXIS_X), &soup);
    size_t nt = mesh->triangle_count, cap = nt ? nt : 1;
    if (st == CLVOX_OK) {
        s->range = cap <= SIZE_MAX / 4 ? clvox__shared_i32_new(cap * 4) : NULL;
        if (!s->range) st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu triangles", nt);
    }
    size_t kept = 0;
    for (size_t i = 0; st == CLVOX_OK && i < nt; i++) {
        const float *t = soup + i * 9;
        int32_t r[6];
        int in = 1;
        for (int a = 0; a < 3 && in; a++) {
            double mn = fmin(fmin(t[a], t[3 + a]), t[6 + a]), mx = fmax(fmax(t[a], t[3 + a]), t[6 + a]);
            in = cell_range(mn, mx, grid->dims[a], &r[2 * a], &r[2 * a + 1]);
        }
        if (!in) continue;
        if (!s->float_outside) s->float_outside = clvox__float_outside(t, 9, &s->float_coord) ? kept + 1 : 0;
        int32_t *q = s->range + 4 * kept;
        q[0] = r[4], q[1] = r[5], q[2] = r[2], q[3] = r[3];
        if (kept != i) memcpy(soup + kept * 9, t, 9 * sizeof *soup); /* compact in place (kept <= i) */
        kept++;
    }
    s->tri_count = kept;
    cl_mem_flags ro = CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR;
    if (st == CLVOX_OK) s->soup = clvox__buffer(ctx, ro, kept * 9 * sizeof(float), soup, &st, "triangles");
    free(soup);
    return st;
}

static clvox_status surface_prepare(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                    const clvox_voxelize_options *opts, const clvox__run *run, uint32_t slab_depth,
                                    clvox_stats *stats, clvox__method_state **out)
{
    (void)opts;
    (void)slab_depth;
    *out = NULL;
    clvox__method_state *s = calloc(1, sizeof *s);
    if (!s) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    s->ctx = ctx;
    s->grid = *grid;
    s->accumulate = run->accumulate;
    s->poll = run->poll;
    s->poll_user = run->poll_user;
    s->words_per_row = clvox__row_words(grid->dims[0]);

    double t0 = clvox__now();
    clvox_status st = CLVOX_OK;
    const clvox__method_state *lead = run->lead;
    if (lead) {
        /* Another device of the run did the host work: its ranges
         * (shared), a copy of its soup. */
        s->tri_count = lead->tri_count;
        s->float_outside = lead->float_outside;
        s->float_coord = lead->float_coord;
        s->range = clvox__shared_i32_ref(lead->range);
        s->soup = clvox__raster_copy_buffer(ctx, lead->ctx, lead->soup, &st, "triangles");
    } else {
        st = surface_host(s, mesh, grid);
    }
    if (stats) stats->seconds[CLVOX_STAGE_PARTITION] += clvox__now() - t0;
    if (st == CLVOX_OK)
        st = clvox__raster_objects(ctx, "clvox_surface_raster", "clvox_surface_count", &s->filled,
                                   &s->k_raster, &s->k_count);
    if (st == CLVOX_OK) st = clvox__float_check(ctx, "surface mode", s->float_outside, s->float_coord);
    if (stats) {
        uint64_t b = (uint64_t)s->tri_count * (9 * 4 + 16 + 4);
        if (b > stats->peak_slab_bytes) stats->peak_slab_bytes = b;
    }
    if (st != CLVOX_OK) {
        surface_release(s);
        return st;
    }
    *out = s;
    return CLVOX_OK;
}

/* The slab's tasks. A triangle's slices in the slab, from its first one,
 * are cut into runs of SLICES_PER_TASK (so one that spans at most that many
 * slices is one task, not two when it crosses a multiple of
 * SLICES_PER_TASK: 27 % fewer tasks on armadillo at 512^3); the tasks are
 * listed by the chunk of SLICES_PER_TASK slices their first slice is in, so
 * that tasks run together touch nearby slices of bits. */
static clvox_status bin_slab(clvox__method_state *s, uint32_t z0, uint32_t nz, size_t *count)
{
    size_t n = 0;
    const int32_t zend = (int32_t)(z0 + nz);
    for (int32_t c0 = (int32_t)z0; c0 < zend; c0 += SLICES_PER_TASK) {
        const int32_t c1 = c0 + SLICES_PER_TASK - 1; /* the chunk of first slices */
        for (size_t i = 0; i < s->tri_count; i++) {
            const int32_t *r = s->range + 4 * i;
            const int32_t first = r[0] > (int32_t)z0 ? r[0] : (int32_t)z0, last = r[1] < zend - 1 ? r[1] : zend - 1;
            if (first > last || first > c1) continue;
            /* the run starting in [c0, c1], if any (runs start every SLICES_PER_TASK from first) */
            const int32_t a =
                first >= c0 ? first : first + (c0 - first + SLICES_PER_TASK - 1) / SLICES_PER_TASK * SLICES_PER_TASK;
            if (a > c1 || a > last) continue;
            const int32_t b = a + SLICES_PER_TASK - 1 < last ? a + SLICES_PER_TASK - 1 : last;
            for (int32_t j = r[2]; j <= r[3]; j += ROWS_PER_TASK) {
                int32_t j1 = j + ROWS_PER_TASK - 1 < r[3] ? j + ROWS_PER_TASK - 1 : r[3];
                clvox_status st = clvox__raster_task_push(s->ctx, &s->tasks, &n, (cl_uint)i, (cl_uint)a,
                                                          (cl_uint)(b + 1), (cl_uint)j | (cl_uint)j1 << 16);
                if (st != CLVOX_OK) return st;
            }
        }
    }
    *count = n;
    return clvox__raster_tasks_ready(s->ctx, &s->tasks);
}

static clvox_status surface_slab(clvox__method_state *s, uint32_t z0, uint32_t nz, const clvox__slab_out *planes,
                                 clvox__slab_stats *ss)
{
    cl_mem out = planes->occupancy;
    clvox_context *ctx = s->ctx;
    const cl_uint X = s->grid.dims[0], Y = s->grid.dims[1], W = s->words_per_row;
    if (!out) return clvox__fail(ctx, CLVOX_ERR_INTERNAL, "surface mode without an occupancy plane");
    double t0 = clvox__now();
    size_t n = 0;
    clvox_status st = bin_slab(s, z0, nz, &n);
    if (st != CLVOX_OK) return st;
    double t_bin = clvox__now() - t0;

    /* (soup, tasks, task count: clvox__raster_run) */
    cl_uint rows = Y * nz, i = 3;
    cl_int err = 0;
    err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_uint), &z0);
    err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_uint), &X);
    err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_uint), &W);
    err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_uint), &Y);
    err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_mem), &out);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, CL_INVALID_KERNEL_ARGS, "clSetKernelArg(clvox_surface_raster)");
    const clvox__raster_pass pass = {"surface", s->k_raster, "clvox_surface_raster", s->soup, 4096,
                                     s->k_count, "clvox_surface_count", 0, !s->accumulate,
                                     out, W, rows, (size_t)W * Y * nz, s->filled, z0, s->poll, s->poll_user};
    return clvox__raster_run(ctx, &pass, &s->tasks, n, t_bin, ss);
}

static void surface_describe(const clvox__method_state *s, char *buf, size_t size)
{
    snprintf(buf, size, "rule=closed-cell-meets-triangle exact=sat13 triangles=%zu slices_per_task=%d rows_per_task=%d",
             s->tri_count, SLICES_PER_TASK, ROWS_PER_TASK);
}

const clvox__method clvox__method_surface = {"surface", surface_prepare, surface_slab, surface_release,
                                              surface_describe};

const char *clvox_mode_name(clvox_mode mode)
{
    static const char *const names[] = {"solid", "surface", "conservative"};
    return (unsigned)mode < CLVOX_MODE_COUNT ? names[mode] : NULL;
}
