/* SPDX-License-Identifier: Apache-2.0 */
/* Stage coverage (grey levels, Thon et al. 3.3.4), host side
 * (src/cast/coverage.c): the sampling of the column runs (N x N rays per
 * voxel column, M points per voxel), which the palette consumer shares, and
 * kernels/coverage.cl's argument set-up and enqueue. clvox__column_enqueue
 * sets the arguments both column consumers take (kernels/palette_score.cl
 * takes coverage.cl's with blocks of its own between them). */
#ifndef CLVOX_COVERAGE_H
#define CLVOX_COVERAGE_H
#include "cast.h"
#include "winding_classify.h"

typedef struct clvox__coverage {
    uint32_t N, M, R;            /* R = N*N rays per column, M points per voxel */
    int stochastic;
    uint32_t seed_lo, seed_hi;
    double threshold;            /* occupancy: coverage > threshold ... */
    uint32_t occ_min;            /* ... i.e. count >= occ_min */
    cl_mem value_of_count;       /* ushort[R*M+1]: HALF bits, or the count itself */
    cl_uint X, W;                /* the grid's row: voxels, bit-row words */
    cl_uint vox_stride;          /* voxels between consecutive voxels of a ray in the coverage plane */
    cl_kernel k;                 /* clvox_coverage; NULL on palette runs */
    /* Ray positions: made on the device by clvox_column_rays from the
     * uploaded columns (k_rays) where the kernels compute in double, as the
     * host does (sampler.h clvox_column_ray), so that both give the same
     * floats; else (float kernels, CLVOX_KERNEL_FLOAT=1, or CLVOX_HOST_RAYS=1)
     * by the host (clvox__column_rays) and uploaded, 16 bytes a ray. */
    cl_kernel k_rays;            /* NULL: host rays */
    cl_uint dim_v;               /* columns along v: id = w * dim_v + v */
    /* a float device's second pass over a batch (src/cast/unsure.c): the
     * host's answers for the samples the first left unsure (NULL, 0: none;
     * both column consumers) */
    cl_mem answers;
    cl_uint n_answers;
    cl_uint n_pass_cols; /* the second pass's work-items: its columns (answers' head); 0: the batch's */
} clvox__coverage;

/* Also for palette runs (then without the coverage kernel). */
clvox_status clvox__coverage_prepare(clvox_context *ctx, clvox__coverage *c, const clvox_voxelize_options *o,
                                     const clvox__run *run, const clvox_grid *grid, clvox_axis axis);
void clvox__coverage_release(clvox__coverage *c);
/* The R = N*N rays of column (v, w), id = w * dim_v + v, into out[0..R)
 * (sampler.h; out_base and bit 0): the host's rays, and the reference of the
 * device's (tests/test_device_rays.c). */
void clvox__column_rays(uint32_t N, int stochastic, uint32_t seed_lo, uint32_t seed_hi, uint32_t v, uint32_t w,
                        uint32_t id, clvox_ray *out);
/* Enqueues clvox_column_rays (c->k_rays, not NULL): the R rays of each of
 * the n_cols columns in m->cols into m->rays, ray r of column i at i*R + r. */
clvox_status clvox__column_rays_enqueue(clvox_context *ctx, const clvox__coverage *c, const clvox__batch_mem *m,
                                        cl_uint n_cols, cl_event *ev);
clvox_status clvox__coverage_enqueue(clvox_context *ctx, const clvox__coverage *c, const clvox__winding_classify *w,
                                     const clvox__batch_mem *m, cl_uint n_cols, const clvox__slab_target *t,
                                     cl_event *ev);

/* One kernel argument as clSetKernelArg takes it (value NULL: a NULL buffer). */
typedef struct clvox__karg {
    size_t size;
    const void *value;
} clvox__karg;
typedef struct clvox__karg_span {
    const clvox__karg *arg;
    size_t count;
} clvox__karg_span;
/* The span of a whole array of clvox__karg, in an initializer. */
#define CLVOX__KARGS(a) {(a), sizeof(a) / sizeof *(a)}

/* A column consumer's own arguments, where they stand among the shared
 * ones: after the seeds, before and after the coverage and occupancy
 * planes, after the filled counts; and whether the winding arguments carry
 * the ray axis. */
typedef struct clvox__column_extra {
    clvox__karg_span after_seeds, before_planes, after_planes, after_tallies;
    int winding_axis;
} clvox__column_extra;

/* Sets k's arguments (per_column: the kernel's rays-per-column argument)
 * and enqueues it over n_cols columns; `name` is the kernel's, for messages. */
clvox_status clvox__column_enqueue(clvox_context *ctx, cl_kernel k, const char *name, cl_uint per_column,
                                   const clvox__coverage *c, const clvox__winding_classify *w,
                                   const clvox__batch_mem *m, cl_uint n_cols, const clvox__slab_target *t,
                                   const clvox__column_extra *x, cl_event *ev);
#endif
