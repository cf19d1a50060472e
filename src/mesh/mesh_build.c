/* SPDX-License-Identifier: Apache-2.0 */
/* The validated mesh from what a reader or the caller's arrays hold:
 * finite coordinates, indices in range, faces with fewer than 3 corners and
 * triangles with a repeated index dropped, polygons fanned into triangles,
 * zero-area triangles kept (they matter for parity), at least one triangle;
 * then the report (mesh_report.c). */
#include "mesh_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Takes ownership of xyz (freed on failure). sizes == NULL: all faces are
 * triangles. `what` names the source in messages. */
/* idx_owned: idx itself, handed over (malloc'ed, freed on failure), when
 * sizes == NULL: the triangles are then compacted in place, so no second
 * index array is made; else NULL. */
clvox_status clvox__mesh_build(clvox_context *ctx, const char *what, float *xyz, const double offset[3], size_t nv,
                               const uint32_t *sizes, const uint32_t *idx, size_t nf, size_t index_count,
                               uint64_t loader_nonmanifold, uint32_t *idx_owned, clvox_mesh **out)
{
    clvox_status st = CLVOX_OK;
    uint32_t *tris = NULL;
    clvox_mesh *m = NULL;
    clvox_mesh_report r;
    clvox__mesh_volume volume;
    memset(&r, 0, sizeof r);
    r.input_vertices = r.vertices = nv;
    r.input_faces = nf;

    for (size_t v = 0; v < nv; v++) {
        const float *p = xyz + 3 * v;
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) {
            st = clvox__fail(ctx, CLVOX_ERR_MESH_INVALID, "%s: vertex %zu has a non-finite coordinate (%g, %g, %g)", what,
                             v, (double)p[0], (double)p[1], (double)p[2]);
            goto fail;
        }
    }
    /* Indices in range; triangle count after fanning. */
    size_t nt = 0, pos = 0;
    for (size_t f = 0; f < nf; f++) {
        size_t k = sizes ? sizes[f] : 3;
        if (k > index_count - pos) {
            st = clvox__fail(ctx, CLVOX_ERR_INTERNAL, "%s: face %zu runs past the index array", what, f);
            goto fail;
        }
        for (size_t j = 0; j < k; j++)
            if (idx[pos + j] >= nv) {
                st = clvox__fail(ctx, CLVOX_ERR_MESH_INVALID,
                                 "%s: face %zu references vertex %lu, but there are only %zu vertices", what, f,
                                 (unsigned long)idx[pos + j], nv);
                goto fail;
            }
        if (k >= 3) {
            nt += k - 2;
            if (k > 3) r.polygons_triangulated++;
        } else {
            r.dropped_faces++;
        }
        pos += k;
    }
    if (nt > UINT32_MAX / 3) {
        st = clvox__fail(ctx, CLVOX_ERR_MESH_INVALID, "%s: %zu triangles, more than clvox supports (%u)", what, nt,
                         (unsigned)(UINT32_MAX / 3));
        goto fail;
    }
    if (idx_owned && !sizes) {
        tris = idx_owned; /* triangle t is read before slot t (or later) is written */
        idx_owned = NULL;
    } else {
        free(idx_owned);
        idx_owned = NULL;
        tris = malloc((nt ? nt : 1) * 3 * sizeof *tris);
    }
    if (!tris) {
        st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "%s: out of memory for %zu triangles", what, nt);
        goto fail;
    }
    size_t kept = 0;
    pos = 0;
    for (size_t f = 0; f < nf; f++) {
        size_t k = sizes ? sizes[f] : 3;
        for (size_t j = 1; j + 1 < k; j++) {
            uint32_t a = idx[pos], b = idx[pos + j], c = idx[pos + j + 1];
            if (a == b || b == c || a == c) {
                r.dropped_faces++;
                continue;
            }
            tris[3 * kept] = a;
            tris[3 * kept + 1] = b;
            tris[3 * kept + 2] = c;
            kept++;
        }
        pos += k;
    }
    if (!kept) {
        st = clvox__fail(ctx, CLVOX_ERR_MESH_EMPTY,
                         "%s: mesh has no triangles (%zu vertices, %zu faces read, %llu dropped)", what, nv, nf,
                         (unsigned long long)r.dropped_faces);
        goto fail;
    }
    if (kept < nt) {
        uint32_t *shrunk = realloc(tris, kept * 3 * sizeof *tris);
        if (shrunk) tris = shrunk;
    }
    r.triangles = kept;

    /* Box of the vertices in use, degenerate triangles, volume, boundary and
     * non-manifold edges, duplicates (mesh_report.c). */
    if (clvox__mesh_analyze(xyz, nv, tris, kept, 0, 0, &r, &volume) != 0) {
        st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "%s: out of memory for the report on %zu triangles", what, kept);
        goto fail;
    }
    for (int a = 0; a < 3; a++) { /* the box in absolute coordinates */
        r.bbox_min[a] += offset[a];
        r.bbox_max[a] += offset[a];
    }
    r.nonmanifold_faces += loader_nonmanifold;
    r.closed = r.boundary_edges == 0;

    m = malloc(sizeof *m);
    if (!m) {
        st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "%s: out of memory", what);
        goto fail;
    }
    m->xyz = xyz;
    for (int a = 0; a < 3; a++) m->offset[a] = offset[a];
    m->vertex_count = nv;
    m->tris = tris;
    m->triangle_count = kept;
    m->report = r;
    m->volume = volume;
    m->ahead = NULL;
    memset(&m->source, 0, sizeof m->source);
    m->source.size = sizeof m->source;
    snprintf(m->source.reader, sizeof m->source.reader, "arrays");
    m->source.meshes = 1;
    m->source.placements = 1;
    m->tri_source = NULL;
    *out = m;
    return CLVOX_OK;

fail:
    free(xyz);
    free(tris);
    free(idx_owned);
    return st;
}
