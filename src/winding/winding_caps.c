/* SPDX-License-Identifier: Apache-2.0 */
/* Winding preparation, step 5 (winding_prep.c): the boundary chain of the
 * oriented surface split into simple loops, each closed by a fan of caps. */
#include "winding_prep.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

clvox_status clvox__prep_boundary_edges(prep *P, uint64_t **out, size_t *count, uint64_t *total)
{
    size_t n = 0, cap = 0;
    uint64_t *e = NULL, tot = 0;
    const pbound *pb = P->pb.a;
    for (size_t i = 0; i < P->pb.n;) {
        size_t j = i;
        int64_t m = 0;
        for (; j < P->pb.n && pb[j].lo == pb[i].lo && pb[j].hi == pb[i].hi; j++)
            m += (P->pstate[pb[j].patch] & P_FLIP) ? -(int64_t)pb[j].m : (int64_t)pb[j].m;
        uint64_t key = m > 0 ? (uint64_t)pb[i].lo << 32 | pb[i].hi : (uint64_t)pb[i].hi << 32 | pb[i].lo;
        uint64_t reps = (uint64_t)(m > 0 ? m : -m);
        if (n + reps > cap) {
            cap = 2 * (n + reps) + 64;
            uint64_t *g = realloc(e, cap * sizeof *g);
            if (!g) {
                free(e);
                return oom(P, "for the boundary chain");
            }
            e = g;
        }
        for (uint64_t r = 0; r < reps; r++) e[n++] = key;
        tot += reps;
        i = j;
    }
    *out = e;
    *count = n;
    *total = tot;
    return CLVOX_OK;
}

/* Splits the directed boundary edges into simple loops and caps them. */
clvox_status clvox__prep_cap_loops(prep *P, uint64_t *edges, size_t ne, clvox__winding_mesh *out)
{
    clvox_status st = CLVOX_OK;
    size_t nv = P->nv;
    uint32_t *next = NULL, *pos = NULL, *path = NULL;
    uint32_t *pedge = NULL;
    size_t nloops = 0, nverts = 0, loop_cap = 0;
    size_t *loop_start = NULL;
    uint32_t *loop_verts = NULL;
    if (!ne) return CLVOX_OK;
    if (ne >= UINT32_MAX) return clvox__fail(P->ctx, CLVOX_ERR_MESH_INVALID, "too many boundary edges (%zu)", ne);
    sort_u64(edges, ne);
    next = malloc(nv * sizeof *next); /* next unused out-edge of each vertex */
    pos = malloc(nv * sizeof *pos);   /* position on the current path */
    path = malloc((ne + 1) * sizeof *path);
    pedge = malloc((ne + 1) * sizeof *pedge);
    if (!next || !pos || !path || !pedge) goto nomem;
    for (size_t i = 0; i < ne; i++) next[(uint32_t)edges[i]] = (uint32_t)ne; /* none, unless set below */
    for (size_t i = ne; i-- > 0;) next[edges[i] >> 32] = (uint32_t)i;
    for (size_t i = 0; i < ne; i++) pos[edges[i] >> 32] = NONE, pos[(uint32_t)edges[i]] = NONE;
#define FROM(i) ((uint32_t)(edges[i] >> 32))
#define TO(i) ((uint32_t)edges[i])
#define HAS_OUT(v) (next[v] < ne && FROM(next[v]) == (v))
    loop_verts = malloc(ne * sizeof *loop_verts); /* each edge starts one loop vertex */
    if (!loop_verts) goto nomem;
    for (size_t s = 0; s < ne; s++) {
        uint32_t v0 = FROM(s);
        while (HAS_OUT(v0)) {
            size_t depth = 0; /* path[0..depth] vertices, pedge[0..depth) edges */
            path[0] = v0;
            pos[v0] = 0;
            uint32_t cur = v0;
            for (;;) {
                if (!HAS_OUT(cur)) {
                    st = clvox__fail(P->ctx, CLVOX_ERR_INTERNAL, "boundary chain is not balanced at vertex %u", cur);
                    goto done;
                }
                uint32_t e = next[cur]++;
                uint32_t w = TO(e);
                pedge[depth] = e;
                if (pos[w] == NONE) {
                    path[++depth] = w;
                    pos[w] = (uint32_t)depth;
                    cur = w;
                    continue;
                }
                /* Loop: edges pedge[pos[w] .. depth]; its vertices, in order. */
                size_t b = pos[w];
                if (nloops + 1 >= loop_cap) {
                    loop_cap = 2 * loop_cap + 64;
                    size_t *g = realloc(loop_start, loop_cap * sizeof *g);
                    if (!g) goto nomem;
                    loop_start = g;
                }
                loop_start[nloops++] = nverts;
                for (size_t q = b; q <= depth; q++) loop_verts[nverts++] = FROM(pedge[q]);
                for (size_t q = b + 1; q <= depth; q++) pos[path[q]] = NONE;
                depth = b;
                cur = w;
                if (depth == 0) {
                    pos[v0] = NONE;
                    break;
                }
            }
        }
    }
#undef FROM
#undef TO
#undef HAS_OUT
    if (nloops) {
        loop_start[nloops] = nverts;
        st = clvox__winding_cap_loops(P->ctx, P->mesh, loop_verts, loop_start, nloops, out);
    }
    goto done;
nomem:
    st = oom(P, "for the caps");
done:
    free(loop_verts);
    free(loop_start);
    free(next);
    free(pos);
    free(path);
    free(pedge);
    return st;
}
