/* SPDX-License-Identifier: Apache-2.0 */
/* The winding inside test of the ray method, host side: the winding
 * preparation of a run and the cast's triangles it gives (the prepared
 * surface, then the caps), the cap and rim trees on the device, the winding
 * arguments all consumers take, and the binary consumer kernels/winding.cl
 * (clvox_classify_winding). */
#include "winding_classify.h"
#include "classify.h"
#include "core/parallel.h"
#include "winding/crack_weld.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <stdlib.h>
#include <string.h>

#define SPECULATE_MAX (4u << 20) /* triangles: see clvox__winding_cast_prepare */

/* The winding preparation (part 1, on a second thread) beside the parity
 * vertices and quadtree of the mesh as given (part 0, on the calling thread
 * as in a parity run, on a copy of the context for its messages). This way
 * round the partition's lists come from the allocator's main arena as in
 * parity runs: on the second thread they came from a second arena whose
 * freed memory stayed resident (armadillo_s3 at 512^3: 20 MB more than
 * parity after the partition, through the cast). The preparation's own
 * freed scratch is handed back (glibc) as soon as it is done, before the
 * partition's peak at the end of its build. */
typedef struct speculation {
    clvox_context *ctx;
    const clvox_mesh *mesh;
    const clvox_grid *grid;
    clvox__axes axes;
    const clvox_voxelize_options *opts;
    uint32_t dim_v, dim_w, leaf_size;
    clvox_context *side;
    float *verts;
    clvox__winding_mesh *wm;
    clvox_status prep_st, tree_st;
    clvox__quadtree qt;
} speculation;

static void speculate(void *arg, int i, int n)
{
    speculation *sp = arg;
    (void)n;
    if (i == 1) {
        /* (or the one started ahead, clvox_mesh_prepare_winding) */
        sp->prep_st = clvox__winding_prepare_or_take(sp->ctx, sp->mesh, sp->opts->weld, CLVOX__PREP_BORROW, sp->wm);
#if defined(__GLIBC__)
        malloc_trim(0);
#endif
        return;
    }
    sp->tree_st = clvox__grid_space_vertices(sp->side, sp->mesh, sp->grid, sp->axes, 0, &sp->verts);
    if (sp->tree_st == CLVOX_OK)
        sp->tree_st = clvox__quadtree_build(sp->side, sp->verts, sp->mesh->tris, sp->mesh->triangle_count, sp->dim_v,
                                            sp->dim_w, sp->opts->quadtree_max_depth, sp->leaf_size, &sp->qt);
}

/* The cast's triangles for a winding run, indexed: the prepared triangles,
 * then the caps, over the mesh's vertices followed by the apexes (each
 * vertex through the same grid transform as parity's, so the caps share the
 * boundary's floats). Without caps the index array is wm->tris itself
 * (taken). */
static clvox_status winding_indexed(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                    clvox__axes axes, clvox__winding_mesh *wm, float **out_verts, size_t *out_vert_count,
                                    uint32_t **out_tris, size_t *out_count)
{
    *out_verts = NULL;
    *out_tris = NULL;
    size_t nt = wm->triangle_count + wm->cap_count;
    if (nt > SIZE_MAX / (3 * sizeof(uint32_t)) || wm->apex_count > (SIZE_MAX / 12) - mesh->vertex_count)
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "mesh too large");
    clvox_mesh view = *mesh;
    float *xyz = NULL;
    if (wm->apex_count) {
        xyz = malloc((mesh->vertex_count + wm->apex_count) * 3 * sizeof *xyz);
        if (!xyz) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu cap apexes", wm->apex_count);
        memcpy(xyz, mesh->xyz, mesh->vertex_count * 3 * sizeof *xyz);
        memcpy(xyz + mesh->vertex_count * 3, wm->apex, wm->apex_count * 3 * sizeof *xyz);
        view.xyz = xyz;
        view.vertex_count = mesh->vertex_count + wm->apex_count;
    }
    clvox_status st = clvox__grid_space_vertices(ctx, &view, grid, axes, 0, out_verts);
    free(xyz);
    if (st != CLVOX_OK) return st;
    uint32_t *tris = NULL;
    if (!wm->cap_count) {
        tris = wm->tris;
        wm->tris = NULL;
    } else if ((tris = malloc(nt * 3 * sizeof *tris)) != NULL) {
        if (wm->triangle_count) memcpy(tris, wm->tris, wm->triangle_count * 3 * sizeof *tris);
        memcpy(tris + wm->triangle_count * 3, wm->caps, wm->cap_count * 3 * sizeof *tris);
    } else {
        free(*out_verts);
        *out_verts = NULL;
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu triangles and caps", nt);
    }
    *out_vert_count = view.vertex_count;
    *out_tris = tris;
    *out_count = nt;
    return CLVOX_OK;
}

/* clvox__caps_upload_pairs from the indexed triangles: the caps follow the
 * wm->triangle_count surface triangles; the crack weld's pairs (6 mesh
 * vertex indices each) over the same vertices. */
static clvox_status caps_upload_indexed(clvox_context *ctx, const float *verts, const uint32_t *tris,
                                        const clvox__winding_mesh *wm, const clvox__crack_weld *cw,
                                        clvox__axes axes, const clvox_grid *grid, clvox__caps *out)
{
    size_t nw = wm->cap_count, n = nw + (cw->used ? cw->extra_count : 0), np = cw->used ? cw->pair_count : 0;
    float *soup = malloc((n + 2 * np ? n + 2 * np : 1) * 9 * sizeof *soup);
    if (!soup) {
        memset(out, 0, sizeof *out);
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu caps", n + 2 * np);
    }
    const uint32_t *cap = tris + wm->triangle_count * 3;
    for (size_t t = 0; t < n; t++) {
        const uint32_t *tri = t < nw ? cap + t * 3 : cw->extra + (t - nw) * 3;
        for (int c = 0; c < 3; c++) memcpy(soup + t * 9 + c * 3, verts + (size_t)tri[c] * 3, 3 * sizeof *soup);
    }
    float *pairs = soup + n * 9;
    for (size_t t = 0; t < np; t++)
        for (int c = 0; c < 6; c++)
            memcpy(pairs + t * 18 + c * 3, verts + (size_t)cw->pairs[t * 6 + c] * 3, 3 * sizeof *soup);
    clvox_status st = clvox__caps_upload_pairs(ctx, soup, n, pairs, np, axes, grid, out);
    free(soup);
    return st;
}

clvox_status clvox__winding_cast_prepare(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                         const clvox_voxelize_options *opts, clvox__axes axes, uint32_t dim_v,
                                         uint32_t dim_w, uint32_t leaf_size, clvox__winding_classify *w,
                                         clvox_stats *stats, clvox__cast_tris *out)
{
    /* surface (oriented) + caps: a closed chain (src/winding/winding_prep.c).
     * The preparation runs beside the parity vertices and quadtree of the
     * mesh as given: when it changes nothing that the cast sees (no
     * flip, no cap, no triangle dropped; merged vertices have the same
     * positions) those are the prepared ones, bit for bit. Up to
     * SPECULATE_MAX triangles: both at once cost the preparation's
     * memory on top of the partition's (armadillo_s3, 3.3 M triangles,
     * 512^3: 1.13 -> 1.00 s when it was added; the preparation borrows
     * the mesh's triangles and holds about 26 MB at a time, see
     * src/winding/winding_prep.c and docs/benchmarks.md). */
    clvox_status st = CLVOX_OK;
    clvox__winding_mesh wm;
    speculation sp = {ctx, mesh, grid, axes, opts, dim_v, dim_w, leaf_size, NULL, NULL, &wm,
                      CLVOX_OK, CLVOX_OK, {0}};
    sp.side = mesh->triangle_count <= SPECULATE_MAX ? malloc(sizeof *sp.side) : NULL;
    if (mesh->triangle_count > SPECULATE_MAX) {
        st = clvox__winding_prepare_or_take(ctx, mesh, opts->weld, 0, &wm);
    } else if (!sp.side) {
        memset(&wm, 0, sizeof wm);
        st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    } else {
        *sp.side = *ctx; /* the parity branch's own error message */
        const uint64_t counted = ctx->grid_space_count;
        clvox__parallel(2, speculate, &sp);
        ctx->grid_space_count += sp.side->grid_space_count - counted; /* the side's transforms are ctx's */
        st = sp.prep_st;
        const int same = st == CLVOX_OK && sp.tree_st == CLVOX_OK && wm.cap_count == 0 &&
                         wm.report.flipped_triangles == 0 && wm.triangle_count == mesh->triangle_count;
        if (same) {
            out->verts = sp.verts;
            out->qt = sp.qt;
            out->have_tree = 1;
        } else {
            free(sp.verts);
            clvox__quadtree_free(&sp.qt);
            if (st == CLVOX_OK) st = clvox__winding_mesh_own_tris(ctx, mesh, &wm); /* borrowed: copy */
        }
        free(sp.side);
    }
    /* A cracked mesh or a soup: the same voxels through the welded mesh
     * and the pairs that certify it (src/winding/crack_weld.c). The report
     * stays the mesh's as given. */
    clvox__crack_weld cw;
    memset(&cw, 0, sizeof cw);
    clvox_winding_report report = wm.report;
    if (st == CLVOX_OK && !out->have_tree && opts->weld == 0 && wm.cap_count) {
        const double h[3] = {grid->voxel_size[0], grid->voxel_size[1], grid->voxel_size[2]};
        st = clvox__crack_weld_try(ctx, mesh, &wm, clvox__crack_weld_distance(h), &cw);
        report.seconds += cw.seconds;
        if (st == CLVOX_OK && cw.used) {
            w->crack_distance = cw.distance;
            w->crack_welded = cw.welded.report.welded_vertices;
            w->crack_pairs = cw.pair_count;
            w->crack_holes = cw.welded.report.holes;
            clvox__winding_mesh_free(&wm);
            wm = cw.welded; /* moved: the cast's surface and caps */
            memset(&cw.welded, 0, sizeof cw.welded);
        }
    }
    if (st == CLVOX_OK && !out->have_tree) {
        st = winding_indexed(ctx, mesh, grid, axes, &wm, &out->verts, &out->vert_count, &out->tris_owned,
                             &out->tri_count);
        out->tris = out->tris_owned;
    }
    if (st == CLVOX_OK) st = caps_upload_indexed(ctx, out->verts, out->tris, &wm, &cw, axes, grid, &w->caps);
    if (st == CLVOX_OK) st = clvox__rims_upload(ctx, mesh, grid, wm.rim, wm.rim_count, &w->rims);
    w->surface_count = (cl_uint)wm.triangle_count;
    w->prep = report;
    if (stats) clvox__winding_stats(w, stats);
    clvox__winding_mesh_free(&wm);
    clvox__crack_weld_free(&cw);
    return st;
}

void clvox__winding_stats(const clvox__winding_classify *w, clvox_stats *stats)
{
    stats->winding = w->prep;
    stats->crack_weld_distance = w->crack_pairs ? w->crack_distance : 0.0;
    stats->crack_welded_vertices = w->crack_welded;
    stats->crack_pairs = w->crack_pairs;
    stats->crack_holes = w->crack_holes;
}

void clvox__winding_classify_release(clvox__winding_classify *w)
{
    clvox__caps_release(&w->caps);
    clvox__caps_release(&w->rims);
    clvox__release_mem(&w->lat_points);
    clvox__release_mem(&w->lat_blocks);
    clvox__release_mem(&w->lat_split);
    clvox__release_mem(&w->lat_near);
    if (w->k_blocks) clReleaseKernel(w->k_blocks);
    if (w->k_lattice) clReleaseKernel(w->k_lattice);
    w->k_blocks = w->k_lattice = NULL;
}

cl_int clvox__winding_args(cl_kernel k, cl_uint *i, const clvox__winding_classify *w, const clvox__batch_mem *m,
                           int with_axis)
{
    cl_int err = 0;
    err |= clSetKernelArg(k, (*i)++, sizeof(cl_uint), &w->abs_mode);
    if (with_axis) err |= clSetKernelArg(k, (*i)++, sizeof(cl_uint), &w->axis);
    err |= clSetKernelArg(k, (*i)++, sizeof(cl_mem), &w->caps.h);
    err |= clSetKernelArg(k, (*i)++, sizeof(cl_mem), &w->caps.nodes);
    err |= clSetKernelArg(k, (*i)++, sizeof(cl_uint), &w->caps.node_count);
    err |= clSetKernelArg(k, (*i)++, sizeof(cl_mem), &w->caps.tris);
    err |= clSetKernelArg(k, (*i)++, sizeof(cl_mem), &w->caps.grid);
    err |= clSetKernelArg(k, (*i)++, sizeof(cl_mem), &m->exact);
    return err;
}

clvox_status clvox__winding_classify_enqueue(clvox_context *ctx, cl_kernel k, const clvox__winding_classify *w,
                                             const clvox__batch_mem *m, cl_uint n, const clvox__slab_target *t,
                                             cl_event *ev)
{
    clvox__classify_args a = {m->rays, n, m->hits, m->counts, m->capacity, t->u_begin, t->u_count,
                              t->out_stride, t->out->occupancy, m->filled};
    cl_uint i = 0;
    cl_int err = clvox__classify_args_set(k, &i, &a, &m->signs);
    err |= clvox__winding_args(k, &i, w, m, 1);
    err |= clSetKernelArg(k, i++, sizeof(cl_mem), &w->rims.nodes);
    err |= clSetKernelArg(k, i++, sizeof(cl_uint), &w->rims.node_count);
    err |= clSetKernelArg(k, i++, sizeof(cl_mem), &w->rims.tris);
    err |= clSetKernelArg(k, i++, sizeof(cl_mem), &m->unsure);
    const int lat = w->lattice_on && w->lat[0] >= 2;
    err |= clSetKernelArg(k, i++, sizeof(cl_mem), lat ? &w->lat_points : &w->caps.h); /* bound, unread */
    err |= clSetKernelArg(k, i++, sizeof(cl_mem), lat ? &w->lat_blocks : &w->caps.h);
    for (int d = 0; d < 5; d++) {
        const cl_uint v = lat ? w->lat[d] : 0u;
        err |= clSetKernelArg(k, i++, sizeof v, &v);
    }
    err |= clSetKernelArg(k, i++, sizeof(cl_mem), lat ? &w->lat_split : &w->caps.h);
    err |= clSetKernelArg(k, i++, sizeof(cl_mem), lat ? &w->lat_near : &w->caps.h);
    return clvox__consumer_launch(ctx, k, "clvox_classify_winding", err, n, w->local, ev);
}
