/* SPDX-License-Identifier: Apache-2.0 */
/* Stage palette scoring (Cavagnino & Gribaudo), host side: the palette's
 * elements on the device, each element's mask over the uniform sample
 * positions (the same in every voxel), the metric and the shortcut's
 * counts, and kernels/palette_score.cl's own arguments among those it
 * shares with coverage.cl (clvox__column_enqueue). */
#include "palette_score.h"
#include "../../kernels/sampler.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Unit-voxel position of sample (ray r, point m) under uniform sampling,
 * as (x, y, z) for the run's ray axis: the kernel's clvox_unit_xyz. */
static void uniform_sample_xyz(const clvox__coverage *c, clvox__axes axes, uint32_t r, uint32_t m, float p[3])
{
    float fu = clvox_stratum_float(m, c->M, 0, 0);
    float fv = clvox_stratum_float(r % c->N, c->N, 0, 0), fw = clvox_stratum_float(r / c->N, c->N, 0, 0);
    p[axes.perm[0]] = fu;
    p[axes.perm[1]] = fv;
    p[axes.perm[2]] = fw;
}

clvox_status clvox__palette_score_prepare(clvox_context *ctx, clvox__palette_score *p, const clvox_voxelize_options *o,
                                          const clvox__coverage *c, clvox_axis axis)
{
    const clvox_element *el;
    const clvox_cell *cells;
    const clvox_halfspace *planes;
    size_t ne, nc, np;
    clvox__palette_arrays(o->palette, &el, &ne, &cells, &nc, &planes, &np);
    const clvox__axes axes = clvox__axes_for(axis);
    p->axis = (cl_uint)axis;
    p->n_elements = (uint32_t)ne;
    snprintf(p->name, sizeof p->name, "%s", clvox_palette_name(o->palette));
    p->metric = (cl_uint)o->metric;
    p->early_out = !o->palette_no_early_out;
    const uint32_t S = c->R * c->M, words = (S + 31u) / 32u;
    p->sc_lo = 0;
    p->sc_hi = S;
    if (o->nearest_shortcut && o->metric == CLVOX_METRIC_NEAREST) {
        p->sc_lo = (cl_uint)ceil(o->shortcut_alpha * S);  /* cnt < alpha S */
        p->sc_hi = (cl_uint)floor(o->shortcut_beta * S);  /* cnt > beta S  */
    }
    clvox_status st = CLVOX_OK;
    cl_mem_flags ro = CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR;
    /* (an empty array gets a small unused buffer: binary has no planes) */
    p->elements = clvox__buffer(ctx, ro, ne * sizeof *el, (void *)el, &st, "palette elements");
    if (st == CLVOX_OK)
        p->cells = clvox__buffer(ctx, nc ? ro : CL_MEM_READ_ONLY, nc * sizeof *cells, nc ? (void *)cells : NULL, &st,
                                 "palette cells");
    if (st == CLVOX_OK)
        p->planes = clvox__buffer(ctx, np ? ro : CL_MEM_READ_ONLY, np * sizeof *planes, np ? (void *)planes : NULL,
                                  &st, "palette planes");
    /* The palette_no_masks switch (CLVOX_BENCH_NO_MASKS=1; benchmarks and
     * tests only) scores uniform samples one by one as stochastic ones are:
     * same result, the cost the masks save. */
    p->use_masks = !c->stochastic && !clvox__hooks()->palette_no_masks;
    uint32_t *masks = NULL;
    if (st == CLVOX_OK && p->use_masks) {
        masks = calloc((size_t)ne * words, sizeof *masks);
        if (!masks) st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for palette masks");
        for (size_t e = 0; st == CLVOX_OK && e < ne; e++)
            for (uint32_t r = 0; r < c->R; r++)
                for (uint32_t m = 0; m < c->M; m++) {
                    float q[3];
                    uniform_sample_xyz(c, axes, r, m, q);
                    uint32_t b = r * c->M + m;
                    if (clvox_palette_contains(o->palette, e, q[0], q[1], q[2])) masks[e * words + b / 32] |= 1u << (b % 32);
                }
    }
    if (st == CLVOX_OK)
        p->masks = clvox__buffer(ctx, masks ? ro : CL_MEM_READ_ONLY, masks ? ne * words * sizeof *masks : 0, masks,
                                 &st, "palette masks");
    free(masks);
    /* element volumes in 2^-32 voxels, for the run's volume estimate */
    uint64_t *vol = malloc(ne * sizeof *vol);
    if (st == CLVOX_OK && !vol) st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    for (size_t e = 0; st == CLVOX_OK && e < ne; e++) {
        clvox_palette_element_info info = CLVOX_PALETTE_ELEMENT_INFO_INIT;
        st = clvox_palette_element_info_get(ctx, o->palette, e, &info);
        if (st == CLVOX_OK) vol[e] = (uint64_t)llround(info.volume * 4294967296.0);
    }
    if (st == CLVOX_OK) p->volume = clvox__buffer(ctx, ro, ne * sizeof *vol, vol, &st, "element volumes");
    free(vol);
    if (st == CLVOX_OK) st = clvox__kernel(ctx, "clvox_palette_score", &p->k);
    return st;
}

void clvox__palette_score_release(clvox__palette_score *p)
{
    clvox__release_mem(&p->elements);
    clvox__release_mem(&p->cells);
    clvox__release_mem(&p->planes);
    clvox__release_mem(&p->masks);
    clvox__release_mem(&p->volume);
    if (p->k) clReleaseKernel(p->k);
    p->k = NULL;
}

clvox_status clvox__palette_score_enqueue(clvox_context *ctx, const clvox__palette_score *p, const clvox__coverage *c,
                                          const clvox__winding_classify *w, const clvox__batch_mem *m, cl_uint n_cols,
                                          const clvox__slab_target *t, cl_event *ev)
{
    cl_mem el = t->out->element, sc = t->out->score;
    const clvox__karg scoring[] = {
        {sizeof(cl_uint), &p->axis},      {sizeof(cl_mem), &p->elements},   {sizeof(cl_mem), &p->cells},
        {sizeof(cl_mem), &p->planes},     {sizeof(cl_uint), &p->n_elements}, {sizeof(cl_uint), &p->use_masks},
        {sizeof(cl_mem), &p->masks},      {sizeof(cl_uint), &p->metric},    {sizeof(cl_uint), &p->early_out},
        {sizeof(cl_uint), &p->sc_lo},     {sizeof(cl_uint), &p->sc_hi},
    };
    const clvox__karg outputs[] = {{sizeof(cl_mem), el ? &el : NULL}, {sizeof(cl_mem), sc ? &sc : NULL}};
    const clvox__karg volume[] = {{sizeof(cl_mem), &p->volume}};
    const clvox__karg tallies[] = {{sizeof(cl_mem), &m->pstats}, {sizeof(cl_mem), &m->pvolume}};
    /* the kernel has its own ray axis (1..3) among the scoring arguments */
    const clvox__column_extra x = {CLVOX__KARGS(scoring), CLVOX__KARGS(outputs), CLVOX__KARGS(volume),
                                   CLVOX__KARGS(tallies), 0};
    return clvox__column_enqueue(ctx, p->k, "clvox_palette_score", c->N, c, w, m, n_cols, t, &x, ev);
}

void clvox__palette_tally(clvox__slab_stats *ss, const uint32_t *p, uint64_t volume)
{
    ss->palette_early += p[0];
    ss->palette_shortcut += p[1];
    ss->palette_scored += p[2];
    ss->palette_nonempty += p[3];
    ss->palette_volume += (double)volume * (1.0 / 4294967296.0);
}
