/* SPDX-License-Identifier: Apache-2.0 */
/* Mesh preparation for the winding-number inside test (host only, no
 * OpenCL): clvox__winding_prepare turns the validated mesh into an oriented
 * surface plus cap triangles such that surface + caps is a closed chain.
 *
 * Steps, in order (each rule is what the report counts):
 *
 * 1. Exact merge. Vertices at exactly equal float positions (-0.0 == 0.0)
 *    are merged into the lowest-numbered one (hash of the bit patterns,
 *    O(V)). Triangles are re-indexed; positions never change.
 * 2. Weld (weld > 0). Distinct positions used by a triangle and within
 *    Euclidean distance <= weld of each other (double), transitively, are
 *    merged into the lowest-numbered vertex of their group: union-find over
 *    the pairs found in a hash grid (cells of 2 weld, or of half the median
 *    edge length when larger; each vertex meets the lower-numbered vertices
 *    of the cells its weld ball touches). A triangle left with two
 *    equal corners (by welding, or by the exact merge of distinct indices)
 *    has no area and is dropped.
 * 3. Orientation. Undirected edges are bucketed by their smaller vertex
 *    (a counting sort into blocks of vertices, then by vertex inside each
 *    block) and sorted by the larger one inside each bucket. An
 *    edge of exactly two triangles is manifold; of more, non-manifold.
 *    Orientation propagates across manifold edges only: the two triangles of
 *    one must traverse it in opposite directions. Union-find over triangles
 *    with a parity bit (relative flip), edges taken in (smaller vertex,
 *    larger vertex) order, the larger root linked under the smaller, so each
 *    patch (triangles joined by manifold edges) keeps the orientation of its
 *    lowest-numbered triangle before step 4. An edge whose two triangles are
 *    already in one patch with the wrong relative parity is a conflict
 *    (Moebius-like): it is ignored (the assignment made first stands), the
 *    patch counts as non-orientable, and that edge becomes a boundary edge
 *    of the patch (both triangles traverse it the same way).
 * 4. Patch sign. A patch is closed when its own triangles leave no edge
 *    with non-zero net multiplicity (a non-orientable patch never is).
 *    Nesting: closed patch A is nested in closed patch B (A != B) when A's
 *    bounding box lies in B's and every vertex of A is inside B by B's ray
 *    parity. The ray runs from the vertex p towards +z; a triangle is
 *    crossed when p, projected on the xy plane, is inside its projection by
 *    the three 2D edge functions E = (a-p) x (b-p) (double, no contraction:
 *    an edge shared by two triangles gets exactly negated values from
 *    both, so a closed B is crossed consistently), with the tie rule of the
 *    cast (docs/design.md "The exact crossing test"): E == 0 takes the sign E has when p moves by an
 *    infinitesimal (1, eps) step in the xy plane; and the crossing counts
 *    when its height z_hit (barycentric, double) is > p.z, so a vertex on
 *    B's surface is judged as moved infinitesimally towards +z. B's
 *    triangles are bucketed in a uniform 2D grid over B's xy box, and A's
 *    test stops at its first vertex found outside. Depth of A = number of
 *    closed patches A is nested in. A closed patch must end with signed
 *    volume sum det(a-o, b-o, c-o)/6 > 0 (o = first vertex of its first
 *    triangle, double) when its depth is even, < 0 when odd (a cavity);
 *    otherwise all its triangles are flipped. Open patches never count as
 *    shells; each is flipped when its signed volume about the centroid of
 *    its own boundary edges' endpoints (i.e. the patch closed by one fan
 *    from that centroid) is < 0. A volume that is zero up to rounding
 *    (|V| <= 1e-12 x the sum of the determinants' permanents, plus, open,
 *    the bound on what the centroid's rounding moves it by: volume_sign in
 *    winding_prep.h; a flat sheet, a lone triangle of a soup) flips nothing.
 *    Parts that merely intersect (a vertex outside) are not nested: both
 *    face outwards, and the winding number gives their union.
 * 5. Boundary chain and caps. For every undirected edge {a,b} of the
 *    oriented surface, m = #(a->b) - #(b->a); edges with m != 0 are
 *    boundary edges, |m| times in the direction of the sign. In- and
 *    out-degree agree at every vertex, so the chain splits into simple
 *    loops: directed edges sorted by (from, to); a walk from the lowest
 *    vertex with unused edges takes each vertex's next unused out-edge and
 *    cuts off a loop whenever it comes back to a vertex on its path. Loop k
 *    gets apex k = the mean of its vertices (double, rounded to float) and
 *    one cap (b, a, vertex_count + k) per loop edge a->b: every directed
 *    edge of surface + caps cancels.
 *
 * Cost: O(V + T) plus the small sorts per vertex bucket (and the point
 * tests of nested-box candidates); the hash probes, triangle and union-find
 * reads are prefetched, since big meshes have little index locality. A
 * closed, consistently oriented mesh takes the fast path: no edge needs the
 * boundary pass, the patches come out of the union-find in one pass that
 * also sums the volume of a lone patch, and the nesting test runs only
 * with two or more closed patches (it stops at the box test unless boxes
 * nest). Outward closed meshes without wrongly oriented nested shells come
 * out bit for bit (same triangles, same order, no caps); with
 * CLVOX__PREP_BORROW such a result is not even copied. Host memory at the
 * peak: the larger of the merge (12-20 bytes per vertex: rep and its table)
 * and the orientation (4 bytes per triangle for the union-find, then each
 * triangle's patch and flip, in the merge's array shrunk; plus one chunk of
 * the edge buckets, whose 1-2 entries of 4 bytes a triangle (1.8 on
 * armadillo_s3) are laid out 1 / NCHUNKS at a time), plus 12 per triangle
 * for the prepared triangles unless borrowed (3.3 M triangles: ~23 MB
 * borrowed, ~63 MB copied; it was ~66 / ~106 MB with all the half-edges at
 * once and a flip array, ~180 MB before that).
 * Measured: armadillo_s3 (3.3 M triangles, closed) 0.19-0.23 s of CPU on
 * the shared 2-core development box, load 4 (0.24-0.27 s before; see
 * docs/benchmarks.md "Winding on closed meshes").
 *
 * The steps are in winding_merge.c (1-2), winding_orient.c (3-4),
 * winding_nesting.c (4) and winding_caps.c (5), their shared state in
 * winding_prep.h; this file runs them. */
#include "winding_prep.h"

#include <math.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

/* ---- the preparation ----------------------------------------------------------------------- */

void clvox__winding_mesh_free(clvox__winding_mesh *w)
{
    if (!w) return;
    free(w->tris);
    free(w->caps);
    free(w->apex);
    free(w->rim);
    free(w->rep);
    memset(w, 0, sizeof *w);
}

clvox_status clvox__winding_prepare(clvox_context *ctx, const clvox_mesh *mesh, double weld,
                                    clvox__winding_mesh *out)
{
    return clvox__winding_prepare_flags(ctx, mesh, weld, 0, out);
}

clvox_status clvox__winding_mesh_own_tris(clvox_context *ctx, const clvox_mesh *mesh, clvox__winding_mesh *w)
{
    if (w->tris || !w->triangle_count) return CLVOX_OK;
    w->tris = malloc(3 * w->triangle_count * sizeof *w->tris);
    if (!w->tris)
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu triangles", w->triangle_count);
    memcpy(w->tris, mesh->tris, 3 * w->triangle_count * sizeof *w->tris);
    return CLVOX_OK;
}

static int weld_ok(double weld) { return weld >= 0 && isfinite(weld); }

static clvox_status weld_fail(clvox_context *ctx, double weld)
{
    return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "weld distance %g: must be 0 or a finite positive number",
                       weld);
}

clvox_status clvox__winding_prepare_flags(clvox_context *ctx, const clvox_mesh *mesh, double weld, unsigned flags,
                                          clvox__winding_mesh *out)
{
    double t0 = clvox__now();
    if (!out) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "winding preparation: no output");
    memset(out, 0, sizeof *out);
    if (!mesh) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "winding preparation: no mesh");
    if (!weld_ok(weld)) return weld_fail(ctx, weld);
    size_t nv = mesh->vertex_count, nt_in = mesh->triangle_count;
    if (nt_in > UINT32_MAX / 3 || nv >= UINT32_MAX)
        return clvox__fail(ctx, CLVOX_ERR_MESH_INVALID, "winding preparation: mesh too large (%zu triangles)", nt_in);
    clvox_winding_report *rep_out = &out->report;
    clvox_status st = CLVOX_OK;
    prep P;
    memset(&P, 0, sizeof P);
    P.ctx = ctx;
    P.mesh = mesh;
    P.xyz = mesh->xyz;
    P.nv = nv;
    uint64_t *bedges = NULL;
    uint32_t *ws = NULL;

    /* 1-2. merge, weld, re-index, drop. One scratch array (ws) serves the
     * merge (rep, its table) and then, shrunk to one word a triangle, the
     * union-find (uf, then the patches): fewer fresh pages to fault in. */
    size_t cap = pow2_at_least(2 * nv), nws = nv + cap;
    if (nws < nt_in) nws = nt_in;
    ws = malloc(nws * sizeof *ws);
    if (!ws) {
        st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory preparing %zu triangles", nt_in);
        goto done;
    }
    uint32_t *rep = ws;
    clvox__prep_merge_exact(mesh->xyz, nv, rep, ws + nv, cap, &rep_out->merged_vertices);
    if (weld > 0) {
        st = clvox__prep_weld_vertices(ctx, mesh->xyz, nv, mesh->tris, nt_in, weld, rep, &rep_out->welded_vertices);
        if (st != CLVOX_OK) goto done;
    }
    if (flags & CLVOX__PREP_KEEP_REP) {
        out->rep = malloc((nv ? nv : 1) * sizeof *out->rep);
        if (!out->rep) {
            st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory preparing %zu vertices", nv);
            goto done;
        }
        memcpy(out->rep, rep, nv * sizeof *rep);
    }
    size_t nt = 0;
    if (rep_out->merged_vertices == 0 && rep_out->welded_vertices == 0) {
        P.tris = mesh->tris; /* copied (or borrowed) after the signs */
        nt = nt_in;
    } else {
        out->tris = malloc((nt_in ? nt_in : 1) * 3 * sizeof *out->tris);
        if (!out->tris) {
            st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory preparing %zu triangles", nt_in);
            goto done;
        }
        for (size_t t = 0; t < nt_in; t++) {
            uint32_t a = rep[mesh->tris[3 * t]], b = rep[mesh->tris[3 * t + 1]], c = rep[mesh->tris[3 * t + 2]];
            if (a == b || b == c || a == c) continue;
            out->tris[3 * nt] = a;
            out->tris[3 * nt + 1] = b;
            out->tris[3 * nt + 2] = c;
            nt++;
        }
        P.tris = out->tris;
    }
    rep = NULL;
    rep_out->dropped_triangles = nt_in - nt;
    out->triangle_count = nt;
    if (!nt) {
        st = weld > 0 ? clvox__fail(ctx, CLVOX_ERR_MESH_EMPTY, "welding within %g left no triangle of %zu", weld, nt_in)
                      : clvox__fail(ctx, CLVOX_ERR_MESH_EMPTY,
                                    "merging vertices at equal positions left no triangle of %zu", nt_in);
        goto done;
    }
    P.nt = nt;
    /* rep and the table are done with: the rest goes back to the system
     * (glibc keeps a shrunk block's tail resident below its adaptive mmap
     * threshold; 10 MB on armadillo_s3) */
    if (nt < nws) {
        uint32_t *g = realloc(ws, nt * sizeof *ws);
        if (g) ws = g;
#if defined(__GLIBC__)
        malloc_trim(0);
#endif
    }
    P.uf = ws;

    /* 3. edges and orientation patches. */
    if ((st = clvox__prep_build_edges(&P)) != CLVOX_OK) goto done;
    if ((st = clvox__prep_orient_patches(&P, &rep_out->nonmanifold_edges, &rep_out->nonorientable_components)) != CLVOX_OK)
        goto done;
    free(P.bstart);
    free(P.chunks);
    P.bstart = NULL;
    P.chunks = NULL;
    rep_out->components = P.ncomp;
    if ((st = clvox__prep_patch_boundaries(&P)) != CLVOX_OK) goto done;
    free(P.entry);
    P.entry = NULL;
    size_t nclosed = 0;
    for (size_t c = 0; c < P.ncomp; c++) nclosed += !(P.pstate[c] & P_OPEN);
    rep_out->closed_components = nclosed;

    /* 4. signs. */
    if (P.ncomp == 1 && nclosed == 1) clvox__prep_single_patch_volume(&P);
    else clvox__prep_patch_volumes(&P);
    if (nclosed >= 2 && (st = clvox__prep_nesting(&P, nclosed)) != CLVOX_OK) goto done; /* boxes first, inside */
    for (size_t c = 0; c < P.ncomp; c++) {
        int odd = (P.pstate[c] & P_OPEN) ? 0 : (int)(P.depth[c] & 1u);
        rep_out->cavities += (uint64_t)odd;
        if (volume_sign(&P, c) == (odd ? 1 : -1)) P.pstate[c] |= P_FLIP;
    }
    uint64_t flipped = 0;
    for (size_t t = 0; t < nt; t++) flipped += FLIP(&P, t) ^ !!(P.pstate[PATCH(&P, t)] & P_FLIP);
    rep_out->flipped_triangles = flipped;
    if (!out->tris && (flipped || !(flags & CLVOX__PREP_BORROW))) {
        out->tris = malloc(3 * nt * sizeof *out->tris);
        if (!out->tris) {
            st = oom(&P, "for the oriented triangles");
            goto done;
        }
        memcpy(out->tris, mesh->tris, 3 * nt * sizeof *out->tris);
    }
    for (size_t t = 0; flipped && t < nt; t++) {
        if (!(FLIP(&P, t) ^ !!(P.pstate[PATCH(&P, t)] & P_FLIP))) continue;
        uint32_t *tr = out->tris + 3 * t, s = tr[1];
        tr[1] = tr[2];
        tr[2] = s;
    }

    /* 5. boundary chain and caps. */
    size_t nbe = 0;
    if ((st = clvox__prep_boundary_edges(&P, &bedges, &nbe, &rep_out->boundary_edges)) != CLVOX_OK) goto done;
    if ((st = clvox__prep_cap_loops(&P, bedges, nbe, out)) != CLVOX_OK) goto done;

done:
    free(ws);
    free(bedges);
    free(P.bstart);
    free(P.chunks);
    free(P.entry);
    free(P.first);
    free(P.pstate);
    free(P.vol);
    free(P.vabs);
    free(P.org);
    free(P.odelta);
    free(P.nabs);
    free(P.depth);
    free(P.special.a);
    free(P.pb.a);
    rep_out->seconds = clvox__now() - t0;
    return st;
}

/* ---- the preparation ahead ---------------------------------------------------------------- */

/* Started by clvox_mesh_prepare_winding while the caller does other work
 * (the command-line tool: creating the device context, about 30 ms on one
 * core with the other idle), taken by the cast's speculation in place of
 * its own preparation (src/cast/cast.c). Its messages go to a context of its
 * own (the caller's may be in use meanwhile). */
typedef struct clvox__prep_ahead {
    pthread_t thread;
    const clvox_mesh *mesh;
    double weld;
    clvox_status st;
    clvox__winding_mesh wm;
    clvox_context msg;
} clvox__prep_ahead;

static void *prep_ahead_main(void *arg)
{
    clvox__prep_ahead *a = arg;
    a->st = clvox__winding_prepare_flags(&a->msg, a->mesh, a->weld, CLVOX__PREP_BORROW, &a->wm);
#if defined(__GLIBC__)
    malloc_trim(0); /* its scratch back to the system before the partition's peak */
#endif
    return NULL;
}

/* Waits for a and frees it, result and all. */
static void prep_ahead_free(clvox__prep_ahead *a)
{
    if (!a) return;
    pthread_join(a->thread, NULL);
    clvox__winding_mesh_free(&a->wm);
    free(a);
}

clvox_status clvox_mesh_prepare_winding(clvox_context *ctx, clvox_mesh *mesh, const clvox_voxelize_options *options)
{
    if (!mesh) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "winding preparation: no mesh");
    double weld;
    if (!clvox__options_winding(options, &weld)) return CLVOX_OK; /* nothing to prepare */
    if (!weld_ok(weld)) return weld_fail(ctx, weld);
    clvox__prep_ahead *old = __atomic_exchange_n(&mesh->ahead, NULL, __ATOMIC_ACQ_REL);
    if (old && old->weld == weld) { /* already on its way */
        __atomic_store_n(&mesh->ahead, old, __ATOMIC_RELEASE);
        return CLVOX_OK;
    }
    prep_ahead_free(old);
    clvox__prep_ahead *a = calloc(1, sizeof *a);
    if (!a) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    a->mesh = mesh;
    a->weld = weld;
    a->msg.host_only = 1;
    if (pthread_create(&a->thread, NULL, prep_ahead_main, a) != 0) {
        free(a);
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "winding preparation: cannot start a thread");
    }
    __atomic_store_n(&mesh->ahead, a, __ATOMIC_RELEASE);
    return CLVOX_OK;
}

clvox_status clvox__winding_prepare_or_take(clvox_context *ctx, const clvox_mesh *mesh, double weld, unsigned flags,
                                            clvox__winding_mesh *out)
{
    /* the mesh is the caller's const one; the holder is the mesh's own
     * scratch, taken by one caller only (the exchange) */
    clvox__prep_ahead *a = mesh ? __atomic_exchange_n(&((clvox_mesh *)mesh)->ahead, NULL, __ATOMIC_ACQ_REL) : NULL;
    if (a && a->weld != weld) {
        prep_ahead_free(a);
        a = NULL;
    }
    if (!a) return clvox__winding_prepare_flags(ctx, mesh, weld, flags, out);
    pthread_join(a->thread, NULL);
    clvox_status st = a->st;
    if (st != CLVOX_OK) clvox__fail(ctx, st, "%s", a->msg.error);
    *out = a->wm; /* moved */
    free(a);
    if (st == CLVOX_OK && !(flags & CLVOX__PREP_BORROW)) st = clvox__winding_mesh_own_tris(ctx, mesh, out);
    return st;
}

void clvox__prep_ahead_drop(clvox_mesh *mesh)
{
    if (mesh) prep_ahead_free(__atomic_exchange_n(&mesh->ahead, NULL, __ATOMIC_ACQ_REL));
}
