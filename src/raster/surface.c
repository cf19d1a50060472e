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
 * device; tests/test_surface.c compares it with a CPU reference that clips
 * each triangle by each cell in GMP rationals.
 *
 * Streaming (as the tetra method): prepare computes each triangle's exact
 * cell ranges once and drops those outside the grid; per slab the host lists
 * tasks (triangle, at most SLICES_PER_TASK slices, at most ROWS_PER_TASK
 * rows), the kernel ORs each task's intervals into the slab's bit rows
 * (atomic_or), and a count kernel adds up the slab's bits. Slabs are
 * independent: the same volume in any slab depth and order. Memory: the
 * soup, the ranges, one slab's task list and the driver's slab buffer. */
#include "core/internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SLICES_PER_TASK 8
#define ROWS_PER_TASK 32
/* Target duration of one raster chunk between polls (seconds). */
#define RASTER_CHUNK_SECONDS 0.15

struct clvox__method_state {
    clvox_context *ctx;
    clvox_grid grid;
    int accumulate;      /* 1: OR over the slab the previous method left (conservative) */
    size_t tri_count;    /* triangles kept (those meeting the grid) */
    int32_t *range;      /* 4 per triangle: first slice, last slice, first row, last row */
    uint32_t words_per_row;
    cl_uint *tasks_host; /* 4 per task */
    size_t task_cap;
    cl_mem soup, tasks, filled;
    cl_kernel k_raster, k_count;
    int (*poll)(void *, double);
    void *poll_user;
};

static void surface_release(clvox__method_state *s)
{
    if (!s) return;
    clvox__release_mem(&s->soup);
    clvox__release_mem(&s->tasks);
    clvox__release_mem(&s->filled);
    if (s->k_raster) clReleaseKernel(s->k_raster);
    if (s->k_count) clReleaseKernel(s->k_count);
    free(s->range);
    free(s->tasks_host);
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
    float *soup = NULL;
    clvox_status st = clvox__grid_space_soup(ctx, mesh, grid, clvox__axes_for(CLVOX_AXIS_X), &soup);
    size_t nt = mesh->triangle_count, cap = nt ? nt : 1;
    if (st == CLVOX_OK) {
        s->range = malloc(cap * 4 * sizeof *s->range);
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
        int32_t *q = s->range + 4 * kept;
        q[0] = r[4], q[1] = r[5], q[2] = r[2], q[3] = r[3];
        if (kept != i) memcpy(soup + kept * 9, t, 9 * sizeof *soup); /* compact in place (kept <= i) */
        kept++;
    }
    s->tri_count = kept;
    cl_mem_flags ro = CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR;
    if (st == CLVOX_OK) s->soup = clvox__buffer(ctx, ro, kept * 9 * sizeof(float), soup, &st, "triangles");
    free(soup);
    if (stats) stats->seconds[CLVOX_STAGE_PARTITION] += clvox__now() - t0;
    if (st == CLVOX_OK) s->filled = clvox__buffer(ctx, CL_MEM_READ_WRITE, sizeof(cl_uint), NULL, &st, "filled count");
    if (st == CLVOX_OK) {
        cl_int err;
        s->k_raster = clCreateKernel(ctx->program, "clvox_surface_raster", &err);
        if (err == CL_INVALID_KERNEL_NAME)
            st = clvox__need_fp64(ctx, "surface mode");
        else if (err != CL_SUCCESS)
            st = clvox__cl_fail(ctx, err, "clCreateKernel(clvox_surface_raster)");
    }
    if (st == CLVOX_OK) st = clvox__kernel(ctx, "clvox_surface_count", &s->k_count);
    if (stats) {
        uint64_t b = (uint64_t)kept * (9 * 4 + 16 + 4);
        if (b > stats->peak_slab_bytes) stats->peak_slab_bytes = b;
    }
    if (st != CLVOX_OK) {
        surface_release(s);
        return st;
    }
    *out = s;
    return CLVOX_OK;
}

static clvox_status push_task(clvox__method_state *s, size_t *n, size_t tri, int32_t k0, int32_t k1, int32_t j0,
                              int32_t j1)
{
    if (*n == s->task_cap) {
        size_t cap = s->task_cap ? 2 * s->task_cap : 4096;
        cl_uint *p = realloc(s->tasks_host, cap * 4 * sizeof *p);
        if (!p) return clvox__fail(s->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu tasks", cap);
        s->tasks_host = p;
        s->task_cap = cap;
        clvox__release_mem(&s->tasks); /* re-created at the new size */
    }
    cl_uint *q = s->tasks_host + 4 * (*n)++;
    q[0] = (cl_uint)tri;
    q[1] = (cl_uint)k0;
    q[2] = (cl_uint)k1;
    q[3] = (cl_uint)j0 | (cl_uint)j1 << 16;
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
                clvox_status st = push_task(s, &n, i, a, b + 1, j, j1);
                if (st != CLVOX_OK) return st;
            }
        }
    }
    *count = n;
    if (!s->tasks && s->task_cap) {
        clvox_status st = CLVOX_OK;
        s->tasks = clvox__buffer(s->ctx, CL_MEM_READ_ONLY, s->task_cap * 4 * sizeof(cl_uint), NULL, &st, "tasks");
        if (st != CLVOX_OK) return st;
    }
    return CLVOX_OK;
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
    if (n > UINT32_MAX) return clvox__fail(ctx, CLVOX_ERR_INTERNAL, "%zu tasks in one slab", n);
    double t_bin = clvox__now() - t0;

    enum { EV_TASKS, EV_CLEAR, EV_ZERO, EV_RASTER, EV_COUNT_BITS, EV_N };
    cl_event ev[EV_N] = {0};
    cl_int err = CL_SUCCESS;
    cl_uint zero = 0, filled = 0, count = (cl_uint)n;
    size_t words = (size_t)W * Y * nz;
    if (n) {
        err = clEnqueueWriteBuffer(ctx->queue, s->tasks, CL_FALSE, 0, n * 4 * sizeof(cl_uint), s->tasks_host, 0, NULL,
                                   &ev[EV_TASKS]);
        if (err != CL_SUCCESS) st = clvox__cl_fail(ctx, err, "uploading surface tasks");
    }
    if (st == CLVOX_OK && !s->accumulate) {
        err = clEnqueueFillBuffer(ctx->queue, out, &zero, sizeof zero, 0, words * sizeof(cl_uint), 0, NULL,
                                  &ev[EV_CLEAR]);
        if (err != CL_SUCCESS) st = clvox__cl_fail(ctx, err, "clearing the slab bits");
    }
    if (st == CLVOX_OK) {
        err = clEnqueueFillBuffer(ctx->queue, s->filled, &zero, sizeof zero, 0, sizeof zero, 0, NULL, &ev[EV_ZERO]);
        if (err != CL_SUCCESS) st = clvox__cl_fail(ctx, err, "clearing the filled count");
    }
    if (st == CLVOX_OK && n) {
        cl_uint i = 0;
        err = 0;
        err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_mem), &s->soup);
        err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_mem), &s->tasks);
        err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_uint), &count);
        err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_uint), &z0);
        err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_uint), &X);
        err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_uint), &W);
        err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_uint), &Y);
        err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_mem), &out);
        if (err != CL_SUCCESS) {
            st = clvox__cl_fail(ctx, CL_INVALID_KERNEL_ARGS, "clSetKernelArg(clvox_surface_raster)");
        } else {
            /* Chunks of tasks of about RASTER_CHUNK_SECONDS, the driver
             * polled between them (cancel within a slab of huge triangles). */
            const size_t local = 64;
            size_t off = 0, chunk = n < 4096 ? n : 4096;
            double raster = 0;
            while (st == CLVOX_OK && off < n) {
                size_t k = n - off < chunk ? n - off : chunk;
                size_t global = (k + local - 1) / local * local, goff = off;
                cl_event e = NULL;
                double c0 = clvox__now();
                err = clEnqueueNDRangeKernel(ctx->queue, s->k_raster, 1, &goff, &global, &local, 0, NULL, &e);
                if (err != CL_SUCCESS) {
                    st = clvox__cl_fail(ctx, err, "enqueue clvox_surface_raster");
                    break;
                }
                off += k;
                if (off < n) {
                    err = clWaitForEvents(1, &e);
                    if (err != CL_SUCCESS) st = clvox__cl_fail(ctx, err, "running clvox_surface_raster");
                    double dt = clvox__now() - c0;
                    raster += clvox__event_seconds(e);
                    clReleaseEvent(e);
                    double want = dt > 0 ? (double)chunk * RASTER_CHUNK_SECONDS / dt : (double)n;
                    chunk = want < 256 ? 256 : want > (double)n ? n : (size_t)want;
                    chunk = (chunk + local - 1) / local * local;
                    if (st == CLVOX_OK && s->poll && !s->poll(s->poll_user, (double)off / (double)n))
                        st = clvox__fail(ctx, CLVOX_ERR_CANCELLED, "cancelled within slab %u", z0);
                } else {
                    ev[EV_RASTER] = e;
                }
            }
            ss->classify_seconds += raster;
        }
    }
    if (st == CLVOX_OK) {
        cl_uint rows = Y * nz, i = 0;
        err = 0;
        err |= clSetKernelArg(s->k_count, i++, sizeof(cl_mem), &out);
        err |= clSetKernelArg(s->k_count, i++, sizeof(cl_uint), &W);
        err |= clSetKernelArg(s->k_count, i++, sizeof(cl_uint), &rows);
        err |= clSetKernelArg(s->k_count, i++, sizeof(cl_mem), &s->filled);
        if (err != CL_SUCCESS) {
            st = clvox__cl_fail(ctx, CL_INVALID_KERNEL_ARGS, "clSetKernelArg(clvox_surface_count)");
        } else {
            size_t local = 64, global = ((size_t)rows + local - 1) / local * local;
            err = clEnqueueNDRangeKernel(ctx->queue, s->k_count, 1, NULL, &global, &local, 0, NULL, &ev[EV_COUNT_BITS]);
            if (err != CL_SUCCESS) st = clvox__cl_fail(ctx, err, "enqueue clvox_surface_count");
        }
    }
    if (st == CLVOX_OK) {
        err = clEnqueueReadBuffer(ctx->queue, s->filled, CL_TRUE, 0, sizeof filled, &filled, 0, NULL, NULL);
        if (err != CL_SUCCESS) st = clvox__cl_fail(ctx, err, "running the surface kernels");
    }
    if (st == CLVOX_OK) {
        ss->filled += filled;
        ss->cast_seconds += t_bin + clvox__event_seconds(ev[EV_TASKS]) + clvox__event_seconds(ev[EV_CLEAR]) +
                            clvox__event_seconds(ev[EV_ZERO]);
        ss->classify_seconds += clvox__event_seconds(ev[EV_RASTER]) + clvox__event_seconds(ev[EV_COUNT_BITS]);
    } else {
        clFinish(ctx->queue); /* the host task array must outlive the upload */
    }
    for (int i = 0; i < EV_N; i++)
        if (ev[i]) clReleaseEvent(ev[i]);
    return st;
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
