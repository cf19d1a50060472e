/* SPDX-License-Identifier: Apache-2.0 */
/* Stage tetra: solid voxelization by simplicial coverings (A. J. Rueda,
 * C. Ogayar, R. J. Segura, F. R. Feito, "Fast and Simple Hardware
 * Accelerated Voxelizations Using Simplicial Coverings"), the second solid
 * method beside the ray method (cast.c). kernels/tetra.cl does the device work.
 *
 * Method. Every mesh triangle (a,b,c) and one common point O span the
 * tetrahedron T = (O,a,b,c). A voxel centre covered by an odd number of them
 * is inside the mesh (Lemma 1). Binning: prepare computes each
 * tetrahedron's slice range once; per slab, the host lists tasks (triangle,
 * a run of at most `slices_per_task` slices), chunk of slices by chunk of
 * slices, so tasks running together touch the same slices of presence bits.
 * Raster: each task scan-converts its tetrahedron slice by slice: at z = k
 * the cross-section is a triangle or a quad (paper, section 4, Table 1),
 * whose rows y = j are spans [L, U) of voxel centres, XOR-ed into a
 * one-bit-per-voxel presence buffer as two difference markers (atomic_xor on
 * 32-bit words); the resolve kernel's prefix XOR along x gives the presence
 * bits, in place: the presence buffer is the driver's slab buffer itself.
 * Memory: that buffer (X*Y*nz/8 bytes), the triangle soup, one task list:
 * bounded like the ray method.
 * Several devices (clvox__run.lead): the first device of a run does the
 * host work above; the others take its slice ranges (one host array,
 * shared) and copy its device soup (raster_enqueue.h).
 *
 * Grid space and O. The soup comes from clvox__grid_space_soup (one rounding
 * per vertex, x,y,z order: slices are z = const). O is chosen in world
 * coordinates (area-weighted surface centroid by default, bounding-box
 * centre, or a given point) and rounded to grid space once, like a vertex.
 *
 * Exactness. A centre P is in T when the four face functions of T have the
 * signs of T's orientation. Each face is judged by F(P) = n.(P - A) with
 *   - internal faces (O,p,q): A = O, n = (p-O) x (q-O) for p < q in
 *     lexicographic (x,y,z) order of the float coordinates, negated for the
 *     other orientation; the face (O,a,b) shared by the tetrahedra of the two
 *     triangles on edge ab depends only on the set {O,a,b}, so both compute
 *     bit for bit the same F (same products, same order) with opposite
 *     required signs: every centre goes to exactly one side;
 *   - mesh faces: the three vertices sorted the same way (a duplicated
 *     triangle gives the same function);
 *   - F = n.x*(x-A.x) + (n.y*(y-A.y) + n.z*(z-A.z)) in double, in exactly
 *     that order, which is monotone in x (rounding is monotone), so along
 *     a row each face's sign flips at one integer threshold and T covers an
 *     interval [L, U) of centres: L the largest threshold of the faces that
 *     bound T from below in x, U the smallest of the others. The kernel
 *     takes the bound from the extreme closed-form root (first integer
 *     beyond it), and evaluates F at the integers only when that root lies
 *     within a tolerance (1e-7 voxel and more, far above the rounding) of an
 *     integer, so the spans are exactly those of the per-point test. Double
 *     precision has a 53-bit mantissa: for grid-aligned meshes (small dyadic
 *     coordinates) every F is exact.
 * Ties (F == 0: P on a mesh face, on a plane through O and a mesh edge, or
 * P == O) are broken by the symbolic perturbation P' = P + e*t0 + e^2*t1 +
 * e^3*t2 (e -> 0+), where (t0,t1,t2) are the ray method's axes (u,v,w) (x,y,z
 * by default): F(P') has the sign of the first non-zero of F(P), n.t0, n.t1,
 * n.t2. P' is a real point in general position for all planes at once, so
 * the count is Lemma 1's count for P' and the parity is exact for any closed
 * mesh (every edge used by an even number of triangles) and any O: inside
 * O, outside, on a voxel centre or on the surface (tetrahedra flat through O
 * cover nothing). The ray method classifies a centre on the surface as the
 * point moved by e along u and then (e, e^2) in (v,w) (design.md), which is
 * the same P': the two methods agree bit for bit, and a box [lo,hi] holds
 * exactly the centres with lo <= c < hi. Degenerate triangles give flat
 * tetrahedra and cover nothing, as they give no crossing in the ray method.
 * Self-intersecting or overlapping shells: the result is the parity of the
 * number of shells around the centre (inside an odd number of them), as
 * for the ray method.
 *
 * Limits: with rounding (non-dyadic input), F can be wrong for points
 * within about 1e-11 voxel of a plane; the shared-face consistency still
 * holds, so only such points can be misclassified. The ray method computes
 * its crossings in double too, so the two methods agree bit for bit on
 * every test (tests/test_tetra.c compares every voxel, no tolerance).
 * Without cl_khr_fp64 the kernel takes every sign exactly in float
 * (kernels/overlap.h): the exact F, which the double F equals wherever its
 * rounding does not matter (docs/design.md "Devices without double
 * precision"); coordinates outside float's exact range refuse the run
 * (clvox__float_check). */
#include "raster_enqueue.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Slices of one tetrahedron per task: enough work per task to amortise its
 * set-up, small enough to balance long and short tetrahedra. */
#define DEFAULT_SLICES_PER_TASK 32u
/* Same margin as CLVOX_TETRA_MARGIN in kernels/tetra.cl (voxel units). */
#define BIN_MARGIN 1e-3

struct clvox__method_state {
    clvox_context *ctx;
    clvox_grid grid;
    clvox_tetra_origin origin_kind;
    double origin[3];    /* world */
    float origin_g[3];   /* grid space */
    clvox_axis tie_axis; /* X, Y or Z (resolved) */
    cl_uint tie_order;   /* axes u | v << 2 | w << 4 */
    size_t tri_count;    /* tetrahedra kept (those that meet the grid), in Morton order */
    int32_t *bins;       /* klo then khi: shared with the run's other devices (clvox__shared_i32) */
    int32_t *klo, *khi;  /* slices of each tetrahedron (in bins) */
    uint32_t slices_per_task;
    uint32_t words_per_row;
    size_t float_outside; /* clvox__float_outside over O and the kept soup */
    float float_coord;
    clvox__raster_tasks tasks; /* the slab's (tetrahedron, first slice, end slice, 0) */
    cl_mem soup, filled; /* the presence bits live in the driver's slab buffer */
    cl_kernel k_raster, k_resolve;
    int (*poll)(void *, double); /* clvox__run.poll */
    void *poll_user;
};

static void tetra_release(clvox__method_state *s)
{
    if (!s) return;
    clvox__release_mem(&s->soup);
    clvox__raster_tasks_release(&s->tasks);
    clvox__release_mem(&s->filled);
    if (s->k_raster) clReleaseKernel(s->k_raster);
    if (s->k_resolve) clReleaseKernel(s->k_resolve);
    clvox__shared_i32_drop(s->bins);
    free(s);
}

/* O in world coordinates (the mesh's vertices are relative to mesh->offset). */
static clvox_status choose_origin(clvox_context *ctx, const clvox_mesh *mesh, const clvox_voxelize_options *opts,
                                  double o[3])
{
    const float *v = mesh->xyz;
    const uint32_t *t = mesh->tris;
    size_t nt = mesh->triangle_count;
    if (opts->tetra_origin == CLVOX_TETRA_ORIGIN_POINT) {
        for (int a = 0; a < 3; a++) {
            if (!isfinite(opts->tetra_point[a]))
                return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "tetra_point is not finite");
            o[a] = opts->tetra_point[a];
        }
        return CLVOX_OK;
    }
    if (opts->tetra_origin == CLVOX_TETRA_ORIGIN_BBOX_CENTER) {
        double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (size_t i = 0; i < 3 * nt; i++)
            for (int a = 0; a < 3; a++) {
                double x = v[(size_t)t[i] * 3 + a];
                if (x < lo[a]) lo[a] = x;
                if (x > hi[a]) hi[a] = x;
            }
        for (int a = 0; a < 3; a++) o[a] = 0.5 * (lo[a] + hi[a]) + mesh->offset[a];
        return CLVOX_OK;
    }
    if (opts->tetra_origin != CLVOX_TETRA_ORIGIN_CENTROID)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "unknown tetra origin %d", (int)opts->tetra_origin);
    /* Area-weighted centroid of the surface; the corner mean if it has no area. */
    double sum[3] = {0, 0, 0}, mean[3] = {0, 0, 0}, area = 0;
    for (size_t i = 0; i < nt; i++) {
        const float *p = v + (size_t)t[3 * i] * 3, *q = v + (size_t)t[3 * i + 1] * 3, *r = v + (size_t)t[3 * i + 2] * 3;
        double u[3], w[3];
        for (int a = 0; a < 3; a++) {
            u[a] = (double)q[a] - p[a];
            w[a] = (double)r[a] - p[a];
        }
        double cx = u[1] * w[2] - u[2] * w[1], cy = u[2] * w[0] - u[0] * w[2], cz = u[0] * w[1] - u[1] * w[0];
        double ar = 0.5 * sqrt(cx * cx + cy * cy + cz * cz);
        area += ar;
        for (int a = 0; a < 3; a++) {
            double c = ((double)p[a] + q[a] + r[a]) / 3.0;
            sum[a] += ar * c;
            mean[a] += c;
        }
    }
    for (int a = 0; a < 3; a++) o[a] = (area > 0 ? sum[a] / area : mean[a] / (double)nt) + mesh->offset[a];
    return CLVOX_OK;
}

/* 10 bits of x spread to every third bit. */
static uint32_t spread3(uint32_t x)
{
    x &= 0x3FF;
    x = (x | x << 16) & 0x030000FF;
    x = (x | x << 8) & 0x0300F00F;
    x = (x | x << 4) & 0x030C30C3;
    x = (x | x << 2) & 0x09249249;
    return x;
}

/* Keeps the tetrahedra that meet the grid (lo[i] <= hi[i], the slices of
 * the tri_count tetrahedra of *soup) and sorts them by the Morton code of
 * their triangle's centroid (grid space), so that tasks run together read
 * nearby triangles and touch nearby rows of presence bits: *soup is
 * replaced, s->bins, klo, khi and tri_count are set. Stable LSD radix
 * sort, 2 x 15 bits. */
static clvox_status sort_tetrahedra(clvox__method_state *s, float **soup, const int32_t *lo, const int32_t *hi)
{
    size_t n = 0, nt = s->tri_count;
    for (size_t i = 0; i < nt; i++) n += lo[i] <= hi[i];
    size_t cap = n ? n : 1;
    uint32_t *key = malloc(cap * sizeof *key), *idx = malloc(cap * sizeof *idx);
    uint32_t *key2 = malloc(cap * sizeof *key2), *idx2 = malloc(cap * sizeof *idx2);
    uint32_t *cnt = calloc(1u << 15, sizeof *cnt);
    float *out = malloc(cap * 9 * sizeof *out);
    int32_t *bins = clvox__shared_i32_new(2 * cap);
    clvox_status st = CLVOX_OK;
    if (!key || !idx || !key2 || !idx2 || !cnt || !out || !bins) {
        st = clvox__fail(s->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory sorting %zu tetrahedra", n);
        goto done;
    }
    double scale[3];
    for (int a = 0; a < 3; a++) scale[a] = 1023.0 / (s->grid.dims[a] > 1 ? s->grid.dims[a] - 1 : 1);
    n = 0;
    for (size_t i = 0; i < nt; i++) {
        if (lo[i] > hi[i]) continue;
        const float *t = *soup + i * 9;
        uint32_t code = 0;
        for (int a = 0; a < 3; a++) {
            double c = ((double)t[a] + t[3 + a] + t[6 + a]) / 3.0 * scale[a];
            code |= spread3((uint32_t)(c < 0 ? 0 : c > 1023 ? 1023 : c)) << a;
        }
        key[n] = code;
        idx[n++] = (uint32_t)i;
    }
    for (int pass = 0; pass < 2; pass++) {
        memset(cnt, 0, (1u << 15) * sizeof *cnt);
        for (size_t i = 0; i < n; i++) cnt[(key[i] >> (15 * pass)) & 0x7FFF]++;
        uint32_t sum = 0;
        for (uint32_t b = 0; b < 1u << 15; b++) {
            uint32_t c = cnt[b];
            cnt[b] = sum;
            sum += c;
        }
        for (size_t i = 0; i < n; i++) {
            uint32_t d = cnt[(key[i] >> (15 * pass)) & 0x7FFF]++;
            key2[d] = key[i];
            idx2[d] = idx[i];
        }
        uint32_t *t = key;
        key = key2;
        key2 = t;
        t = idx;
        idx = idx2;
        idx2 = t;
    }
    s->bins = bins;
    s->klo = bins;
    s->khi = bins + cap;
    bins = NULL;
    for (size_t i = 0; i < n; i++) {
        memcpy(out + i * 9, *soup + (size_t)idx[i] * 9, 9 * sizeof *out);
        s->klo[i] = lo[idx[i]];
        s->khi[i] = hi[idx[i]];
    }
    free(*soup);
    *soup = out;
    out = NULL;
    s->tri_count = n;
done:
    free(key);
    free(idx);
    free(key2);
    free(idx2);
    free(cnt);
    free(out);
    clvox__shared_i32_drop(bins);
    return st;
}

/* The host work, done once for a run (by its first device): O, the
 * grid-space soup, each tetrahedron's slices, the Morton order. The soup,
 * sorted, in *soup (the caller uploads and frees it). */
static clvox_status tetra_host(clvox__method_state *s, const clvox_mesh *mesh, const clvox_grid *grid,
                               const clvox_voxelize_options *opts, float **soup)
{
    clvox_context *ctx = s->ctx;
    const uint32_t X = grid->dims[0], Y = grid->dims[1], Z = grid->dims[2];
    clvox_status st = choose_origin(ctx, mesh, opts, s->origin);
    for (int a = 0; st == CLVOX_OK && a < 3; a++) {
        double g = (s->origin[a] - grid->origin[a]) / grid->voxel_size[a] - 0.5;
        s->origin_g[a] = (float)g;
        if (!isfinite(s->origin_g[a]))
            st = clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "tetra origin %g on axis %c is out of range",
                             s->origin[a], "xyz"[a]);
    }
    if (st == CLVOX_OK) st = clvox__grid_space_soup(ctx, mesh, grid, clvox__axes_for(CLVOX_AXIS_X), soup);
    int32_t *klo = NULL, *khi = NULL;
    if (st == CLVOX_OK) {
        klo = malloc((s->tri_count ? s->tri_count : 1) * sizeof *klo);
        khi = malloc((s->tri_count ? s->tri_count : 1) * sizeof *khi);
        if (!klo || !khi) st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for tetrahedra");
    }
    /* Slices each tetrahedron spans (closed range widened by the margin);
     * tetrahedra that miss the grid's centres altogether are dropped. */
    const double m = BIN_MARGIN;
    const double lim[3] = {(double)X - 1, (double)Y - 1, (double)Z - 1};
    for (size_t i = 0; st == CLVOX_OK && i < s->tri_count; i++) {
        double lo[3], hi[3];
        for (int a = 0; a < 3; a++) lo[a] = hi[a] = s->origin_g[a];
        for (int c = 0; c < 3; c++)
            for (int a = 0; a < 3; a++) {
                double x = (*soup)[i * 9 + c * 3 + a];
                if (x < lo[a]) lo[a] = x;
                if (x > hi[a]) hi[a] = x;
            }
        int miss = 0;
        for (int a = 0; a < 3; a++) miss |= hi[a] + m < 0 || lo[a] - m > lim[a];
        if (miss) {
            klo[i] = 1;
            khi[i] = 0;
            continue;
        }
        double kl = ceil(lo[2] - m), kh = floor(hi[2] + m);
        klo[i] = (int32_t)(kl < 0 ? 0 : kl);
        khi[i] = (int32_t)(kh > lim[2] ? lim[2] : kh);
    }
    if (st == CLVOX_OK) st = sort_tetrahedra(s, soup, klo, khi);
    if (st == CLVOX_OK) {
        s->float_outside = clvox__float_outside(s->origin_g, 3, &s->float_coord);
        if (!s->float_outside)
            s->float_outside = clvox__float_outside(*soup, s->tri_count * 9, &s->float_coord);
    }
    free(klo);
    free(khi);
    return st;
}

static clvox_status tetra_prepare(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                  const clvox_voxelize_options *opts, const clvox__run *run, uint32_t slab_depth,
                                  clvox_stats *stats, clvox__method_state **out)
{
    /* occupancy only: the driver refuses coverage for tetra */
    (void)slab_depth; /* per-slab memory is the driver's slab buffer */
    *out = NULL;
    clvox__method_state *s = calloc(1, sizeof *s);
    if (!s) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    s->ctx = ctx;
    s->poll = run->poll;
    s->poll_user = run->poll_user;
    s->grid = *grid;
    s->origin_kind = opts->tetra_origin;
    s->tri_count = mesh->triangle_count;
    s->slices_per_task = DEFAULT_SLICES_PER_TASK;
    s->tie_axis = opts->ray_axis == CLVOX_AXIS_DEFAULT ? CLVOX_AXIS_X : opts->ray_axis;
    clvox__axes tie = clvox__axes_for(s->tie_axis);
    s->tie_order = (cl_uint)(tie.perm[0] | tie.perm[1] << 2 | tie.perm[2] << 4);
    s->words_per_row = (grid->dims[0] + 31) / 32;

    double t0 = clvox__now();
    clvox_status st = CLVOX_OK;
    const clvox__method_state *lead = run->lead;
    if (lead) {
        /* Another device of the run did the host work: its O, its slice
         * ranges (shared), a copy of its soup. */
        memcpy(s->origin, lead->origin, sizeof s->origin);
        memcpy(s->origin_g, lead->origin_g, sizeof s->origin_g);
        s->tri_count = lead->tri_count;
        s->float_outside = lead->float_outside;
        s->float_coord = lead->float_coord;
        s->bins = clvox__shared_i32_ref(lead->bins);
        s->klo = lead->klo;
        s->khi = lead->khi;
        s->soup = clvox__raster_copy_buffer(ctx, lead->ctx, lead->soup, &st, "triangles");
    } else {
        float *soup = NULL;
        st = tetra_host(s, mesh, grid, opts, &soup);
        cl_mem_flags ro = CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR;
        if (st == CLVOX_OK)
            s->soup = clvox__buffer(ctx, ro, s->tri_count * 9 * sizeof(float), soup, &st, "triangles");
        free(soup);
    }
    if (stats) stats->seconds[CLVOX_STAGE_PARTITION] += clvox__now() - t0;

    if (st == CLVOX_OK)
        st = clvox__raster_objects(ctx, "clvox_tetra_raster", "clvox_tetra_resolve", &s->filled,
                                   &s->k_raster, &s->k_resolve);
    if (st == CLVOX_OK) st = clvox__float_check(ctx, "method tetra", s->float_outside, s->float_coord);
    if (stats) {
        uint64_t b = (uint64_t)s->tri_count * (9 * 4 + 8); /* + the slab's bits, counted by the driver */
        if (b > stats->peak_slab_bytes) stats->peak_slab_bytes = b;
    }
    if (st != CLVOX_OK) {
        tetra_release(s);
        return st;
    }
    *out = s;
    return CLVOX_OK;
}

/* The slab's tasks into s->tasks, chunk of slices by chunk of slices (so
 * that tasks run together touch the same few slices of presence bits);
 * grows the host and device buffers. */
static clvox_status bin_slab(clvox__method_state *s, uint32_t z0, uint32_t nz, size_t *count)
{
    const int32_t per = (int32_t)s->slices_per_task;
    size_t n = 0;
    for (int32_t c0 = (int32_t)z0; c0 < (int32_t)(z0 + nz); c0 += per) {
        int32_t c1 = c0 + per - 1 < (int32_t)(z0 + nz) - 1 ? c0 + per - 1 : (int32_t)(z0 + nz) - 1;
        for (size_t i = 0; i < s->tri_count; i++) {
            int32_t a = s->klo[i] > c0 ? s->klo[i] : c0;
            int32_t b = s->khi[i] < c1 ? s->khi[i] : c1;
            if (a > b) continue;
            clvox_status st =
                clvox__raster_task_push(s->ctx, &s->tasks, &n, (cl_uint)i, (cl_uint)a, (cl_uint)(b + 1), 0);
            if (st != CLVOX_OK) return st;
        }
    }
    *count = n;
    return clvox__raster_tasks_ready(s->ctx, &s->tasks);
}

static clvox_status tetra_slab(clvox__method_state *s, uint32_t z0, uint32_t nz, const clvox__slab_out *planes,
                               clvox__slab_stats *ss)
{
    cl_mem out = planes->occupancy;
    clvox_context *ctx = s->ctx;
    const cl_uint X = s->grid.dims[0], Y = s->grid.dims[1], W = s->words_per_row;
    double t0 = clvox__now();
    size_t n = 0;
    clvox_status st = bin_slab(s, z0, nz, &n);
    if (st != CLVOX_OK) return st;
    double t_bin = clvox__now() - t0;

    /* (soup, tasks, task count: clvox__raster_run) */
    cl_uint tie = s->tie_order, rows = Y * nz, i = 3;
    cl_float ox = s->origin_g[0], oy = s->origin_g[1], oz = s->origin_g[2];
    cl_int err = 0;
    err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_float), &ox);
    err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_float), &oy);
    err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_float), &oz);
    err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_uint), &tie);
    err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_uint), &z0);
    err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_uint), &X);
    err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_uint), &Y);
    err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_uint), &W);
    err |= clSetKernelArg(s->k_raster, i++, sizeof(cl_mem), &out);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, CL_INVALID_KERNEL_ARGS, "clSetKernelArg(clvox_tetra_raster)");
    /* chunks of tasks: the first 1024, then sized from its time (clvox__raster_run) */
    const clvox__raster_pass pass = {"tetra", s->k_raster, "clvox_tetra_raster", s->soup, 1024,
                                     s->k_resolve, "clvox_tetra_resolve", X, 1,
                                     out, W, rows, (size_t)W * Y * nz, s->filled, z0, s->poll, s->poll_user};
    return clvox__raster_run(ctx, &pass, &s->tasks, n, t_bin, ss);
}

static void tetra_describe(const clvox__method_state *s, char *buf, size_t size)
{
    static const char *kind[] = {"centroid", "bbox_center", "point"};
    const char *k = (unsigned)s->origin_kind < 3 ? kind[s->origin_kind] : "?";
    clvox__axes t = clvox__axes_for(s->tie_axis);
    snprintf(buf, size, "origin=%s(%.9g,%.9g,%.9g)%s slices_per_task=%u tie=+%c>+%c>+%c rule=centre-on-surface:+x+y+z",
             k, s->origin[0], s->origin[1], s->origin[2],
             s->origin_kind == CLVOX_TETRA_ORIGIN_CENTROID ? " centroid=area-weighted-surface" : "",
             s->slices_per_task, "xyz"[t.perm[0]], "xyz"[t.perm[1]], "xyz"[t.perm[2]]);
}

const clvox__method clvox__method_tetra = {"tetra", tetra_prepare, tetra_slab, tetra_release, tetra_describe};
