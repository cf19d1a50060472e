/* SPDX-License-Identifier: Apache-2.0 */
/* Stage cast, a float device's part on the host: the points (binary
 * winding runs) and samples (coverage and palette) whose float bounds
 * could not settle the inside test, decided in double (docs/design.md
 * "Devices without double precision"). */
#include "cast_state.h"
#include "core/launch.h"
#include "winding/winding.h"
#include "../../kernels/sampler.h"

#include <stdlib.h>
#include <string.h>

/* The points a float device left unsure (kernels/winding_inside.h
 * clvox_unsure_push), decided on the host in double as the double kernels
 * decide them (clvox__caps_host_inside): a binary run's inside points then
 * get their bits (clvox_set_bits); a column run (coverage, palette: a
 * voxel's value depends on all its samples) runs its consumer over the
 * batch once more with the host's answers, which rewrites the batch's
 * voxels and tallies. A list that overflowed its room is made again,
 * whole, by running the batch's consumer once more with room for all. */
/* The list of batch b, made again with room for all where it overflowed
 * (*again: the copy to free); NULL on an error. */
static const cl_uint *unsure_list(clvox__method_state *s, batch_set *b, size_t count, cl_uint **again,
                                  clvox_status *st)
{
    clvox_context *ctx = s->ctx;
    *again = NULL;
    if (count <= b->mem.unsure_room) return b->unsure + 2;
    const size_t bytes = (2 + UNSURE_WORDS * count) * sizeof(cl_uint);
    if (count > (SIZE_MAX / sizeof(cl_uint) - 2) / UNSURE_WORDS || !(*again = malloc(bytes))) {
        *st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu unsure points", count);
        return NULL;
    }
    cl_mem tmp = clvox__buffer(ctx, CL_MEM_READ_WRITE, bytes, NULL, st, "unsure points");
    clvox__batch_mem m2 = b->mem;
    m2.unsure = tmp;
    m2.unsure_room = (cl_uint)count;
    const cl_uint head[2] = {0, (cl_uint)count};
    cl_int err = CL_SUCCESS;
    if (*st == CLVOX_OK) {
        err = clEnqueueWriteBuffer(ctx->queue, tmp, CL_TRUE, 0, sizeof head, head, 0, NULL, NULL);
        if (err != CL_SUCCESS) *st = clvox__cl_fail(ctx, err, "clearing the unsure points");
    }
    if (*st == CLVOX_OK) {
        clvox__launch_begin(ctx);
        *st = s->palette    ? clvox__palette_score_enqueue(ctx, &s->pal, &s->cov, &s->wind, &m2, b->n_cols, &b->t, NULL)
              : s->coverage ? clvox__coverage_enqueue(ctx, &s->cov, &s->wind, &m2, b->n_cols, &b->t, NULL)
                            : clvox__winding_classify_enqueue(ctx, s->k_classify, &s->wind, &m2, b->n_rays, &b->t,
                                                              NULL);
        if (*st == CLVOX_OK) *st = clvox__launch_check(ctx);
    }
    if (*st == CLVOX_OK) {
        err = clEnqueueReadBuffer(ctx->queue, tmp, CL_TRUE, 0, bytes, *again, 0, NULL, NULL);
        if (err != CL_SUCCESS) *st = clvox__cl_fail(ctx, err, "reading the unsure points");
        else if ((*again)[0] != count)
            *st = clvox__fail(ctx, CLVOX_ERR_INTERNAL, "the batch's consumer left %u unsure points, then %zu",
                              (unsigned)(*again)[0], count);
    }
    clvox__release_mem(&tmp);
    if (*st != CLVOX_OK) {
        free(*again);
        *again = NULL;
        return NULL;
    }
    return *again + 2;
}

/* Sets the n bits at (word, bits pairs) in `occupancy` (clvox_set_bits),
 * and waits. */
static clvox_status set_bits(clvox_context *ctx, cl_kernel k, cl_mem occupancy, const cl_uint *at, size_t n)
{
    clvox_status st = CLVOX_OK;
    cl_mem tmp = clvox__buffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, 2 * n * sizeof *at, (void *)at, &st,
                               "unsure answers");
    cl_uint nn = (cl_uint)n;
    cl_int err = CL_SUCCESS;
    if (st == CLVOX_OK) {
        err |= clSetKernelArg(k, 0, sizeof(cl_mem), &occupancy);
        err |= clSetKernelArg(k, 1, sizeof(cl_mem), &tmp);
        err |= clSetKernelArg(k, 2, sizeof(cl_uint), &nn);
        if (err != CL_SUCCESS) st = clvox__cl_fail(ctx, CL_INVALID_KERNEL_ARGS, "clSetKernelArg(clvox_set_bits)");
    }
    if (st == CLVOX_OK) {
        clvox__launch_begin(ctx);
        st = clvox__launch(ctx, k, "clvox_set_bits", 0, n, 64, NULL);
        if (st == CLVOX_OK) st = clvox__launch_check(ctx); /* waits: tmp is released below */
    }
    clvox__release_mem(&tmp);
    return st;
}

/* A point's grid coordinates, x, y, z, from u (along the axis), v and w. */
static void unsure_point(const clvox__method_state *s, double u, double v, double w, double g[3])
{
    const unsigned axis = s->wind.axis;
    g[axis] = u;
    g[(axis + 1) % 3] = v;
    g[(axis + 2) % 3] = w;
}

static clvox_status resolve_binary(clvox__method_state *s, batch_set *b, clvox__slab_stats *ss, const cl_uint *list,
                                   size_t count)
{
    clvox_context *ctx = s->ctx;
    double scale[3];
    clvox__winding_scale(&s->grid, scale);
    size_t inside = 0;
    cl_uint *at = malloc(2 * count * sizeof *at);
    if (!at) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu unsure points", count);
    for (size_t i = 0; i < count; i++) {
        const cl_uint *e = list + UNSURE_WORDS * i;
        const cl_uint gid = e[0], j = e[1];
        uint32_t v, w;
        clvox_u32 base, bit;
        if (b->cast_rays) {
            const clvox_ray *r = &b->cast_rays[gid];
            v = (uint32_t)r->v, w = (uint32_t)r->w, base = r->out_base, bit = r->bit;
        } else {
            clvox__slab_column(s, b->z0, b->c0 + gid, &v, &w, &base, &bit);
        }
        double g[3];
        unsure_point(s, (double)(b->t.u_begin + j), v, w, g);
        if (!clvox__caps_host_inside(&s->wind.caps, scale, g, (int)e[2], (int)s->wind.abs_mode, s->wind.axis))
            continue;
        at[2 * inside] = b->t.out_stride == 0 ? base + (j >> 5) : base + j * b->t.out_stride;
        at[2 * inside + 1] = 1u << ((b->t.out_stride == 0 ? j : bit) & 31u);
        inside++;
    }
    clvox_status st = CLVOX_OK;
    if (inside && b->t.out->occupancy)
        st = set_bits(ctx, s->k_set_bits, b->t.out->occupancy, at, inside);
    free(at);
    if (st == CLVOX_OK) ss->filled += inside;
    return st;
}

/* Column run entry e (column, voxel, K, ray << 8 | point): is the sample
 * inside? */
static int sample_inside(const clvox__method_state *s, const batch_set *b, const cl_uint *e, const double scale[3])
{
    const clvox__coverage *c = &s->cov;
    const cl_uint gid = e[0], j = e[1], r = e[3] >> 8, m = e[3] & 255u;
    clvox_column col;
    if (b->cast_cols) {
        col = b->cast_cols[gid];
    } else {
        uint32_t v, w;
        clvox__slab_column(s, b->z0, b->c0 + gid, &v, &w, &col.out_base, &col.bit);
        col.id = w * s->dim_v + v;
    }
    const uint32_t v = col.id % s->dim_v, w = col.id / s->dim_v, u = b->t.u_begin + j;
    float pv, pw;
    clvox_column_ray(v, w, col.id, r, c->N, c->stochastic, c->seed_lo, c->seed_hi, &pv, &pw);
    uint32_t bits[4] = {0, 0, 0, 0};
    if (c->stochastic) clvox_philox4x32_10(col.id, r, u, m >> 2, c->seed_lo, c->seed_hi, bits);
    double g[3];
    unsure_point(s, clvox_sample_u(u, m, c->M, c->stochastic, bits[m & 3u]), pv, pw, g);
    return clvox__caps_host_inside(&s->wind.caps, scale, g, (int)e[2], (int)s->wind.abs_mode, s->wind.axis);
}

static int cmp_answer(const void *pa, const void *pb)
{
    const cl_uint *a = pa, *b = pb;
    for (int i = 0; i < 3; i++) {
        const cl_uint x = i == 2 ? a[i] & 0x7FFFFFFFu : a[i], y = i == 2 ? b[i] & 0x7FFFFFFFu : b[i];
        if (x != y) return x < y ? -1 : 1;
    }
    return 0;
}

/* A column run (coverage, palette): the batch's consumer runs a second
 * time with the host's answers for the samples the first pass left unsure
 * (sorted, for the kernel's binary search, clvox_unsure_answer), which
 * rewrites the batch's voxels and its tallies (read back here: the tally
 * after batch_wait reads them). The second pass meets the same unsure
 * samples and, answered, lists none (checked). Only batches with an unsure
 * sample pay it. */
static clvox_status resolve_columns(clvox__method_state *s, batch_set *b, const cl_uint *list, size_t count)
{
    clvox_context *ctx = s->ctx;
    double scale[3];
    clvox__winding_scale(&s->grid, scale);
    /* [n, the n columns with answers, the answers]: the second pass runs
     * those columns only (clvox_pass_column); a column's voxels and tallies
     * depend on its own samples alone, so the others keep the first pass's */
    cl_uint *buf = malloc((1 + 4 * (count ? count : 1)) * sizeof *buf);
    if (!buf) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu unsure points", count);
    cl_uint *ans = buf + 1 + count; /* the columns take at most count words */
    for (size_t i = 0; i < count; i++) {
        const cl_uint *e = list + UNSURE_WORDS * i;
        ans[3 * i] = e[0];
        ans[3 * i + 1] = e[1];
        ans[3 * i + 2] = e[3] | (sample_inside(s, b, e, scale) ? 0x80000000u : 0u);
    }
    qsort(ans, count, 3 * sizeof *ans, cmp_answer);
    cl_uint n = 0;
    for (size_t i = 0; i < count; i++)
        if (i == 0 || ans[3 * i] != ans[3 * (i - 1)]) buf[1 + n++] = ans[3 * i];
    buf[0] = n;
    memmove(buf + 1 + n, ans, 3 * count * sizeof *ans);
    clvox_status st = CLVOX_OK;
    cl_mem mem = clvox__buffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, (1 + n + 3 * count) * sizeof *buf, buf,
                               &st, "unsure answers");
    free(buf);
    const cl_uint head[2] = {0, b->mem.unsure_room};
    cl_uint again[2] = {0, 0};
    cl_int err = CL_SUCCESS;
    if (st == CLVOX_OK) {
        err = clEnqueueWriteBuffer(ctx->queue, b->mem.unsure, CL_TRUE, 0, sizeof head, head, 0, NULL, NULL);
        if (err != CL_SUCCESS) st = clvox__cl_fail(ctx, err, "clearing the unsure points");
    }
    if (st == CLVOX_OK) {
        s->cov.answers = mem;
        s->cov.n_answers = (cl_uint)count;
        s->cov.n_pass_cols = n;
        clvox__launch_begin(ctx);
        st = s->palette ? clvox__palette_score_enqueue(ctx, &s->pal, &s->cov, &s->wind, &b->mem, b->n_cols, &b->t, NULL)
                        : clvox__coverage_enqueue(ctx, &s->cov, &s->wind, &b->mem, b->n_cols, &b->t, NULL);
        if (st == CLVOX_OK) st = clvox__launch_check(ctx);
        s->cov.answers = NULL;
        s->cov.n_answers = 0;
        s->cov.n_pass_cols = 0;
    }
    const size_t k = b->n_cols;
    if (st == CLVOX_OK) {
        err = clEnqueueReadBuffer(ctx->queue, b->mem.unsure, CL_TRUE, 0, sizeof again, again, 0, NULL, NULL);
        if (err == CL_SUCCESS)
            err = clEnqueueReadBuffer(ctx->queue, b->mem.filled, CL_TRUE, 0, k * sizeof *b->filled, b->filled, 0, NULL,
                                      NULL);
        if (err == CL_SUCCESS)
            err = clEnqueueReadBuffer(ctx->queue, b->mem.sums, CL_TRUE, 0, k * sizeof *b->sums, b->sums, 0, NULL, NULL);
        if (err == CL_SUCCESS && s->palette)
            err = clEnqueueReadBuffer(ctx->queue, b->mem.pstats, CL_TRUE, 0, k * 4 * sizeof *b->pstats, b->pstats, 0,
                                      NULL, NULL);
        if (err == CL_SUCCESS && s->palette)
            err = clEnqueueReadBuffer(ctx->queue, b->mem.pvolume, CL_TRUE, 0, k * sizeof *b->pvolume, b->pvolume, 0,
                                      NULL, NULL);
        if (err != CL_SUCCESS) st = clvox__cl_fail(ctx, err, "reading the batch back");
        else if (again[0])
            st = clvox__fail(ctx, CLVOX_ERR_INTERNAL, "the consumer's second pass left %u samples unsure",
                             (unsigned)again[0]);
    }
    clvox__release_mem(&mem);
    return st;
}

clvox_status clvox__resolve_unsure(clvox__method_state *s, batch_set *b, clvox__slab_stats *ss)
{
    const size_t count = b->unsure[0];
    cl_uint *again = NULL;
    clvox_status st = CLVOX_OK;
    const cl_uint *list = unsure_list(s, b, count, &again, &st);
    if (list) st = s->coverage ? resolve_columns(s, b, list, count) : resolve_binary(s, b, ss, list, count);
    if (st == CLVOX_OK) ss->host_points += count;
    free(again);
    return st;
}
