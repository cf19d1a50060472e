/* SPDX-License-Identifier: Apache-2.0 */
/* The stages of the winding preparation (winding_prep.c runs them, in the
 * order of its top comment): 1-2 merge and weld (winding_merge.c), 3-4
 * orientation, patches and their volumes (winding_orient.c), 4 nesting of
 * closed patches (winding_nesting.c), 5 boundary loops and caps
 * (winding_caps.c), and the state they share. Internal. */
#ifndef CLVOX_WINDING_PREP_H
#define CLVOX_WINDING_PREP_H
#include "winding.h"

#include <stdlib.h>

#define NONE UINT32_MAX

#if defined(__GNUC__)
#define PREFETCH(p) __builtin_prefetch(p)
#else
#define PREFETCH(p) ((void)(p))
#endif

static inline size_t pow2_at_least(size_t n)
{
    size_t c = 16;
    while (c < n) c <<= 1;
    return c;
}

static inline void sort_u64(uint64_t *a, size_t n)
{
    if (n <= 24) clvox__sort_u64_small(a, n);
    else qsort(a, n, sizeof *a, clvox__cmp_u64);
}

/* A group of uses of one undirected edge that needs the boundary pass:
 * entries [begin, end) of the edge array. */
typedef struct span {
    uint32_t lo, begin, end;
} span;

typedef struct span_list {
    span *a;
    size_t n, cap;
} span_list;

typedef struct pbound {
    uint32_t lo, hi, patch;
    int32_t m;
} pbound;

typedef struct pbound_list {
    pbound *a;
    size_t n, cap;
} pbound_list;

/* Per-patch state. */
#define P_OPEN 1u
#define P_NONORIENT 2u
#define P_FLIP 4u

typedef struct prep {
    clvox_context *ctx;
    const clvox_mesh *mesh;
    const float *xyz;
    size_t nv;
    const uint32_t *tris; /* the mesh's triangles, or out->tris after merging */
    size_t nt;
    uint32_t *uf;        /* orientation union-find, then the patches (ws: pf) */
    uint32_t *bstart;    /* nblocks + 1: each block's triangle entries (build_edges) */
    uint32_t *chunks;    /* nchunks + 1: first block of each chunk */
    size_t nblocks, nchunks;
    size_t most;         /* the most edge uses in one block */
    size_t chunk_most;   /* the most entries in one chunk */
    unsigned shift;      /* block of vertex v: v >> shift */
    uint64_t *entry;     /* uses of the special edges: hi << 32 | triangle << 1 | (1: the use runs lo -> hi) */
    size_t nentry, cap_entry;
    uint32_t *pf;        /* each triangle's patch << 1 | flip (1: reversed relative to the
                            patch's first triangle), in place of uf (in ws) */
    uint32_t *first;     /* first triangle of each patch */
    unsigned char *pstate;
    double *vol;         /* 6 x signed volume per patch */
    double *vabs;        /* sum of the permanents of those determinants */
    double *org;         /* 3 per patch: volume origin */
    double *odelta;      /* per patch: bound on each coordinate's rounding in org (0: exact, closed) */
    double *nabs;        /* per patch with odelta > 0: sum of |2 x area vector|_1 of its triangles */
    uint32_t *depth;
    size_t ncomp;
    span_list special;
    pbound_list pb;
    int any_flip;        /* some triangle is reversed relative to its patch's first */
} prep;

#define PATCH(P, t) ((P)->pf[t] >> 1)
#define FLIP(P, t) ((P)->pf[t] & 1u)

static inline clvox_status oom(prep *P, const char *what)
{
    return clvox__fail(P->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory %s (%zu triangles)", what, P->nt);
}

/* The sign of a patch's volume, 0 when it is within 1e-12 of the sum of
 * the permanents (zero up to rounding: a flat sheet, one triangle, a
 * back-to-back pair), which then keeps its orientation. An open patch's
 * volume is taken about the exact centroid of its boundary, which double
 * rounds: 6V is linear in the origin o (sum det(a-o, b-o, c-o) =
 * sum det(a, b, c) - o . sum 2N, 2N = (b-a) x (c-a)), so the rounding moves
 * it by at most odelta x sum |2N|_1 -- twice that is added (for the rounding
 * of the sum itself). A lone triangle or a flat sheet, whose exact volume
 * about a point of its plane is 0, then never gets a sign from rounding
 * (a soup's triangle far from the coordinate origin, nearly parallel to a
 * coordinate plane: up to 1e-10 of the permanent). Closed patches: exact
 * origin, odelta = 0, the tolerance is the permanents' alone. */
static inline int volume_sign(const prep *P, size_t c)
{
    double v = P->vol[c], tol = 1e-12 * P->vabs[c] + 2.0 * P->odelta[c] * P->nabs[c];
    return v > tol ? 1 : v < -tol ? -1 : 0;
}

/* 1. Exact merge: rep[v] = the lowest-numbered vertex at v's position
 * (table: cap >= 2 nv slots of scratch, cap a power of 2). */
void clvox__prep_merge_exact(const float *xyz, size_t nv, uint32_t *rep, uint32_t *table, size_t cap, uint64_t *merged);
/* 2. Weld within `weld` (> 0), on top of the exact merge in rep. */
clvox_status clvox__prep_weld_vertices(clvox_context *ctx, const float *xyz, size_t nv, const uint32_t *tris, size_t nt,
                                       double weld, uint32_t *rep, uint64_t *welded);
/* 3. The edges by block of their smaller vertex, then the orientation
 * patches (winding_orient.c). */
clvox_status clvox__prep_build_edges(prep *P);
clvox_status clvox__prep_orient_patches(prep *P, uint64_t *nonmanifold, uint64_t *conflict_out);
clvox_status clvox__prep_patch_boundaries(prep *P);
/* 4. 6 x the signed volume of every patch; the single-patch variant when the
 * mesh is one closed patch. */
void clvox__prep_patch_volumes(prep *P);
void clvox__prep_single_patch_volume(prep *P);
/* 4. The depth of every closed patch (nclosed >= 2). */
clvox_status clvox__prep_nesting(prep *P, size_t nclosed);
/* 5. Directed boundary edges after the signs, then their loops capped. */
clvox_status clvox__prep_boundary_edges(prep *P, uint64_t **out, size_t *count, uint64_t *total);
clvox_status clvox__prep_cap_loops(prep *P, uint64_t *edges, size_t ne, clvox__winding_mesh *out);
#endif
