/* SPDX-License-Identifier: Apache-2.0 */
/* Stage coverage (grey levels, Thon et al. 3.3.4), host side: the column
 * runs' samples and count -> value table, and the arguments the two column
 * consumers (kernels/coverage.cl, kernels/palette_score.cl) share, set in
 * one place so that the two lists cannot drift apart. */
#include "coverage.h"
#include "classify.h"
#include "core/launch.h"

#include <stdlib.h>

/* Smallest count whose fraction count / samples is > threshold. */
static uint32_t occupancy_min_count(double threshold, uint32_t samples)
{
    uint32_t t = 0;
    while (t <= samples && !((double)t / samples > threshold)) t++;
    return t; /* samples + 1: never occupied */
}

clvox_status clvox__coverage_prepare(clvox_context *ctx, clvox__coverage *c, const clvox_voxelize_options *o,
                                     const clvox__run *run, const clvox_grid *grid, clvox_axis axis)
{
    c->N = o->oversample;
    c->M = o->oversample_points ? o->oversample_points : o->oversample;
    c->R = c->N * c->N;
    c->stochastic = o->stochastic != 0;
    c->seed_lo = (uint32_t)o->seed;
    c->seed_hi = (uint32_t)(o->seed >> 32);
    const cl_uint X = grid->dims[0], Y = grid->dims[1];
    c->X = X;
    c->W = clvox__row_words(X);
    c->vox_stride = axis == CLVOX_AXIS_X ? 0 : axis == CLVOX_AXIS_Y ? X : X * Y;
    const uint32_t S = c->R * c->M;
    c->threshold = o->threshold_set ? o->threshold : 0.5;
    c->occ_min = occupancy_min_count(c->threshold, S);
    uint16_t *table = malloc(((size_t)S + 1) * sizeof *table);
    if (!table) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    for (uint32_t t = 0; t <= S; t++)
        table[t] = run->coverage_counts ? (uint16_t)t : clvox__half_from_unit((double)t / S);
    clvox_status st = CLVOX_OK;
    c->value_of_count = clvox__buffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, ((size_t)S + 1) * sizeof *table,
                                      table, &st, "coverage table");
    free(table);
    if (st == CLVOX_OK && !o->palette) st = clvox__kernel(ctx, "clvox_coverage", &c->k);
    /* Rays made on the device only where its kernels compute in double:
     * clvox_column_ray's double arithmetic (correctly rounded +, -, / in
     * OpenCL's fp64, no contraction) then gives the host's floats bit for
     * bit. A float build would round the strata differently, so the rays,
     * hence the voxels, would depend on the device: there the host makes
     * them (and the kernel is not even built, kernels/coverage.cl). */
    c->dim_v = grid->dims[clvox__axes_for(axis).perm[1]];
    if (st == CLVOX_OK && ctx->real_size == 8 && !clvox__hooks()->host_rays)
        st = clvox__kernel(ctx, "clvox_column_rays", &c->k_rays);
    return st;
}

void clvox__coverage_release(clvox__coverage *c)
{
    clvox__release_mem(&c->value_of_count);
    if (c->k) clReleaseKernel(c->k);
    c->k = NULL;
    if (c->k_rays) clReleaseKernel(c->k_rays);
    c->k_rays = NULL;
}

clvox_status clvox__column_rays_enqueue(clvox_context *ctx, const clvox__coverage *c, const clvox__batch_mem *m,
                                        cl_uint n_cols, cl_event *ev)
{
    cl_uint N = c->N, st_flag = (cl_uint)c->stochastic;
    cl_int err = 0;
    err |= clSetKernelArg(c->k_rays, 0, sizeof(cl_mem), &m->cols);
    err |= clSetKernelArg(c->k_rays, 1, sizeof(cl_uint), &n_cols);
    err |= clSetKernelArg(c->k_rays, 2, sizeof(cl_uint), &N);
    err |= clSetKernelArg(c->k_rays, 3, sizeof(cl_uint), &c->dim_v);
    err |= clSetKernelArg(c->k_rays, 4, sizeof(cl_uint), &st_flag);
    err |= clSetKernelArg(c->k_rays, 5, sizeof(cl_uint), &c->seed_lo);
    err |= clSetKernelArg(c->k_rays, 6, sizeof(cl_uint), &c->seed_hi);
    err |= clSetKernelArg(c->k_rays, 7, sizeof(cl_mem), &m->rays);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, CL_INVALID_KERNEL_ARGS, "clSetKernelArg(clvox_column_rays)");
    return clvox__launch(ctx, c->k_rays, "clvox_column_rays", 0, (size_t)n_cols * c->R, 64, ev);
}

static cl_int set_kargs(cl_kernel k, cl_uint *i, clvox__karg_span s)
{
    cl_int err = 0;
    for (size_t j = 0; j < s.count; j++) err |= clSetKernelArg(k, (*i)++, s.arg[j].size, s.arg[j].value);
    return err;
}

clvox_status clvox__column_enqueue(clvox_context *ctx, cl_kernel k, const char *name, cl_uint per_column,
                                   const clvox__coverage *c, const clvox__winding_classify *w,
                                   const clvox__batch_mem *m, cl_uint n_cols, const clvox__slab_target *t,
                                   const clvox__column_extra *x, cl_event *ev)
{
    cl_uint M = c->M, st_flag = (cl_uint)c->stochastic;
    cl_mem cov = t->out->coverage, occ = t->out->occupancy;
    const clvox__karg samples[] = {
        {sizeof(cl_mem), &m->cols},       {sizeof(cl_uint), &n_cols},     {sizeof(cl_uint), &per_column},
        {sizeof(cl_uint), &M},            {sizeof(cl_mem), &m->hits},     {sizeof(cl_mem), &m->counts},
        {sizeof(cl_uint), &m->capacity},  {sizeof(cl_uint), &t->u_begin}, {sizeof(cl_uint), &t->u_count},
        {sizeof(cl_uint), &st_flag},      {sizeof(cl_uint), &c->seed_lo}, {sizeof(cl_uint), &c->seed_hi},
    };
    const clvox__karg voxels[] = {
        {sizeof(cl_mem), &c->value_of_count}, {sizeof(cl_uint), &c->occ_min},    {sizeof(cl_uint), &c->X},
        {sizeof(cl_uint), &c->W},             {sizeof(cl_uint), &c->vox_stride}, {sizeof(cl_uint), &t->out_stride},
    };
    const clvox__karg planes[] = {{sizeof(cl_mem), cov ? &cov : NULL}, {sizeof(cl_mem), occ ? &occ : NULL}};
    const clvox__karg tallies[] = {{sizeof(cl_mem), &m->sums}, {sizeof(cl_mem), &m->filled}};
    const clvox__karg crossings[] = {{sizeof(cl_mem), &m->signs}, {sizeof(cl_mem), &m->rays}};
    const clvox__karg_span order[] = {
        CLVOX__KARGS(samples), x->after_seeds,  CLVOX__KARGS(voxels),  x->before_planes, CLVOX__KARGS(planes),
        x->after_planes,       CLVOX__KARGS(tallies), x->after_tallies, CLVOX__KARGS(crossings),
    };
    cl_int err = 0;
    cl_uint i = 0;
    for (size_t j = 0; j < sizeof order / sizeof *order; j++) err |= set_kargs(k, &i, order[j]);
    err |= clvox__winding_args(k, &i, w, m, x->winding_axis);
    /* a float device's unsure samples: the list, the host's answers (src/cast/unsure.c) */
    err |= clSetKernelArg(k, i++, sizeof(cl_mem), m->unsure ? &m->unsure : NULL);
    err |= clSetKernelArg(k, i++, sizeof(cl_mem), c->answers ? &c->answers : NULL);
    err |= clSetKernelArg(k, i++, sizeof(cl_uint), &c->n_answers);
    return clvox__consumer_launch(ctx, k, name, err, c->n_pass_cols ? c->n_pass_cols : n_cols, 64, ev);
}

clvox_status clvox__coverage_enqueue(clvox_context *ctx, const clvox__coverage *c, const clvox__winding_classify *w,
                                     const clvox__batch_mem *m, cl_uint n_cols, const clvox__slab_target *t,
                                     cl_event *ev)
{
    /* nothing of its own; the ray axis among the winding arguments */
    static const clvox__column_extra none = {.winding_axis = 1};
    return clvox__column_enqueue(ctx, c->k, "clvox_coverage", c->R, c, w, m, n_cols, t, &none, ev);
}
