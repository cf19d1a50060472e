/* SPDX-License-Identifier: Apache-2.0 */
/* Winding preparation, step 4 (winding_prep.c): which closed patch lies
 * inside which (boxes, then every vertex by ray parity), hence each closed
 * patch's depth. */
#include "winding_prep.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- 4. point in a closed patch ---------------------------------------------------------- */

typedef struct pgrid {
    const float *xyz;
    const uint32_t *tris;
    const uint32_t *tri_ids; /* the patch's triangles */
    uint32_t *start;         /* nx*ny + 1 */
    uint32_t *refs;          /* indices into tri_ids */
    uint32_t nx, ny;
    double x0, y0, sx, sy;   /* cell = floor((x - x0) * sx) */
    float lo[3], hi[3];      /* the patch's box */
} pgrid;

static uint32_t grid_cell(double x, double x0, double s, uint32_t n)
{
    double q = floor((x - x0) * s);
    if (!(q > 0)) return 0;
    if (q >= (double)n) return n - 1;
    return (uint32_t)q;
}

static void pgrid_free(pgrid *g)
{
    free(g->start);
    free(g->refs);
    g->start = g->refs = NULL;
}

/* The (x, y) box of triangle t. */
static void tri_xy_box(const float *xyz, const uint32_t *t, float *x0, float *x1, float *y0, float *y1)
{
    *x0 = *x1 = xyz[3 * (size_t)t[0]];
    *y0 = *y1 = xyz[3 * (size_t)t[0] + 1];
    for (int c = 1; c < 3; c++) {
        float x = xyz[3 * (size_t)t[c]], y = xyz[3 * (size_t)t[c] + 1];
        if (x < *x0) *x0 = x;
        if (x > *x1) *x1 = x;
        if (y < *y0) *y0 = y;
        if (y > *y1) *y1 = y;
    }
}

/* Buckets the patch's triangles (tri_ids[0..nt)) by their xy boxes; the
 * grid has about nt cells, coarsened while triangles would span too many. */
static int pgrid_build(pgrid *g, const float *xyz, const uint32_t *tris, const uint32_t *tri_ids, size_t nt,
                       const float *lo, const float *hi)
{
    memset(g, 0, sizeof *g);
    g->xyz = xyz;
    g->tris = tris;
    g->tri_ids = tri_ids;
    for (int a = 0; a < 3; a++) g->lo[a] = lo[a], g->hi[a] = hi[a];
    double wx = (double)hi[0] - lo[0], wy = (double)hi[1] - lo[1];
    double fx, fy;
    if (wx > 0 && wy > 0) {
        fx = ceil(sqrt((double)nt * wx / wy));
        fy = ceil(sqrt((double)nt * wy / wx));
    } else {
        fx = wx > 0 ? (double)nt : 1;
        fy = wy > 0 ? (double)nt : 1;
    }
    uint32_t nx = (uint32_t)(fx < 1 ? 1 : fx > 2048 ? 2048 : fx);
    uint32_t ny = (uint32_t)(fy < 1 ? 1 : fy > 2048 ? 2048 : fy);
    for (;;) {
        double sx = wx > 0 ? nx / wx : 0, sy = wy > 0 ? ny / wy : 0;
        uint64_t total = 0;
        for (size_t i = 0; i < nt; i++) {
            float tx0, tx1, ty0, ty1;
            tri_xy_box(xyz, tris + 3 * (size_t)tri_ids[i], &tx0, &tx1, &ty0, &ty1);
            uint64_t cx = grid_cell(tx1, lo[0], sx, nx) - grid_cell(tx0, lo[0], sx, nx) + 1;
            uint64_t cy = grid_cell(ty1, lo[1], sy, ny) - grid_cell(ty0, lo[1], sy, ny) + 1;
            total += cx * cy;
        }
        if ((total > 16 * (uint64_t)nt + 4096 || total > UINT32_MAX) && (nx > 1 || ny > 1)) {
            nx = nx > 1 ? nx / 2 : 1;
            ny = ny > 1 ? ny / 2 : 1;
            continue;
        }
        if (total > UINT32_MAX) return -1;
        g->nx = nx;
        g->ny = ny;
        g->x0 = lo[0];
        g->y0 = lo[1];
        g->sx = sx;
        g->sy = sy;
        g->start = calloc((size_t)nx * ny + 1, sizeof *g->start);
        g->refs = malloc((total ? total : 1) * sizeof *g->refs);
        if (!g->start || !g->refs) {
            pgrid_free(g);
            return -1;
        }
        break;
    }
    for (int pass = 0; pass < 2; pass++) {
        for (size_t i = 0; i < nt; i++) {
            float tx0, tx1, ty0, ty1;
            tri_xy_box(xyz, tris + 3 * (size_t)tri_ids[i], &tx0, &tx1, &ty0, &ty1);
            uint32_t i0 = grid_cell(tx0, g->x0, g->sx, nx), i1 = grid_cell(tx1, g->x0, g->sx, nx);
            uint32_t j0 = grid_cell(ty0, g->y0, g->sy, ny), j1 = grid_cell(ty1, g->y0, g->sy, ny);
            for (uint32_t j = j0; j <= j1; j++)
                for (uint32_t k = i0; k <= i1; k++) {
                    size_t cell = (size_t)j * nx + k;
                    if (pass == 0) g->start[cell + 1]++;
                    else g->refs[g->start[cell]++] = (uint32_t)i;
                }
        }
        size_t ncell = (size_t)nx * ny;
        if (pass == 0) {
            for (size_t c = 0; c < ncell; c++) g->start[c + 1] += g->start[c];
        } else {
            for (size_t c = ncell; c > 0; c--) g->start[c] = g->start[c - 1];
            g->start[0] = 0;
        }
    }
    return 0;
}

/* The sign of the 2D edge function E = A x B (A = a - p, B = b - p), ties
 * broken as p moved by an infinitesimal (1, eps) step (docs/design.md). */
static int edge_sign(double e, double ay, double by, double ax, double bx)
{
    if (e > 0) return 1;
    if (e < 0) return -1;
    double t = ay - by;
    if (t != 0) return t > 0 ? 1 : -1;
    t = bx - ax;
    return (t > 0) - (t < 0);
}

/* 1 when p is inside the grid's closed patch by the parity of the +z ray. */
static int pgrid_inside(const pgrid *g, const float *p)
{
    for (int a = 0; a < 3; a++)
        if (p[a] < g->lo[a] || p[a] > g->hi[a]) return 0;
    double px = p[0], py = p[1], pz = p[2];
    size_t cell = (size_t)grid_cell(px, g->x0, g->sx, g->nx) + (size_t)grid_cell(py, g->y0, g->sy, g->ny) * g->nx;
    unsigned parity = 0;
    for (uint32_t r = g->start[cell]; r < g->start[cell + 1]; r++) {
        const uint32_t *t = g->tris + 3 * (size_t)g->tri_ids[g->refs[r]];
        const float *a = g->xyz + 3 * (size_t)t[0], *b = g->xyz + 3 * (size_t)t[1], *c = g->xyz + 3 * (size_t)t[2];
        double ax = a[0] - px, ay = a[1] - py, bx = b[0] - px, by = b[1] - py, cx = c[0] - px, cy = c[1] - py;
        double eab = ax * by - ay * bx, ebc = bx * cy - by * cx, eca = cx * ay - cy * ax;
        int sab = edge_sign(eab, ay, by, ax, bx);
        if (sab == 0) continue;
        if (edge_sign(ebc, by, cy, bx, cx) != sab || edge_sign(eca, cy, ay, cx, ax) != sab) continue;
        double s = eab + ebc + eca;
        if (s == 0) continue;
        double zh = (double)a[2] + (eca * ((double)b[2] - a[2]) + eab * ((double)c[2] - a[2])) / s;
        parity ^= zh > pz;
    }
    return (int)parity;
}


typedef struct cbox {
    float lo[3], hi[3];
    uint32_t patch;
} cbox;

/* 1 when every vertex of the triangles tl[0..n) is inside g's patch; stops
 * at the first one outside. stamp[v] == pair: v already tested. */
static int all_inside(const pgrid *g, const uint32_t *tris, const uint32_t *tl, size_t n, uint32_t *stamp,
                      uint32_t pair)
{
    for (size_t q = 0; q < n; q++) {
        const uint32_t *t = tris + 3 * (size_t)tl[q];
        for (int c = 0; c < 3; c++) {
            if (stamp[t[c]] == pair) continue;
            stamp[t[c]] = pair;
            if (!pgrid_inside(g, g->xyz + 3 * (size_t)t[c])) return 0;
        }
    }
    return 1;
}

/* Nesting depth of every closed patch (called with two or more). Candidate
 * pairs come from a grid over the boxes' (lo.x, lo.y) corners: the A whose
 * box lies in B's have their corner in B's x and y range. */
clvox_status clvox__prep_nesting(prep *P, size_t nclosed)
{
    clvox_status st = CLVOX_OK;
    size_t nc = P->ncomp, nt = P->nt;
    const uint32_t *tris = P->tris;
    const float *xyz = P->xyz;
    cbox *box = malloc(nclosed * sizeof *box);
    uint32_t *slot = malloc((nc ? nc : 1) * sizeof *slot);
    uint32_t *tstart = NULL, *tlist = NULL, *stamp = NULL, *gstart = NULL, *gitems = NULL, *cand = NULL;
    pgrid g = {0};
    if (!box || !slot) goto nomem;
    size_t k = 0;
    for (size_t c = 0; c < nc; c++) {
        slot[c] = NONE;
        if (P->pstate[c] & P_OPEN) continue;
        slot[c] = (uint32_t)k;
        box[k].patch = (uint32_t)c;
        const float *o = xyz + 3 * (size_t)tris[3 * (size_t)P->first[c]];
        for (int a = 0; a < 3; a++) box[k].lo[a] = box[k].hi[a] = o[a];
        k++;
    }
    for (size_t t = 0; t < nt; t++) {
        uint32_t s = slot[PATCH(P, t)];
        if (s == NONE) continue;
        cbox *bx = &box[s];
        for (int q = 0; q < 3; q++) {
            const float *p = xyz + 3 * (size_t)tris[3 * t + q];
            for (int a = 0; a < 3; a++) {
                if (p[a] < bx->lo[a]) bx->lo[a] = p[a];
                if (p[a] > bx->hi[a]) bx->hi[a] = p[a];
            }
        }
    }
    uint32_t G = 1;
    while ((size_t)G * G < nclosed && G < 4096) G++;
    double gx0 = box[0].lo[0], gx1 = gx0, gy0 = box[0].lo[1], gy1 = gy0;
    for (size_t i = 1; i < nclosed; i++) {
        if (box[i].lo[0] < gx0) gx0 = box[i].lo[0];
        if (box[i].lo[0] > gx1) gx1 = box[i].lo[0];
        if (box[i].lo[1] < gy0) gy0 = box[i].lo[1];
        if (box[i].lo[1] > gy1) gy1 = box[i].lo[1];
    }
    double gsx = gx1 > gx0 ? G / (gx1 - gx0) : 0, gsy = gy1 > gy0 ? G / (gy1 - gy0) : 0;
    size_t ncell = (size_t)G * G;
    gstart = calloc(ncell + 1, sizeof *gstart);
    gitems = malloc(nclosed * sizeof *gitems);
    cand = malloc(nclosed * sizeof *cand);
    if (!gstart || !gitems || !cand) goto nomem;
#define BOX_CELL(b) (grid_cell((b)->lo[0], gx0, gsx, G) + (size_t)G * grid_cell((b)->lo[1], gy0, gsy, G))
    for (size_t i = 0; i < nclosed; i++) gstart[BOX_CELL(&box[i]) + 1]++;
    for (size_t c = 0; c < ncell; c++) gstart[c + 1] += gstart[c];
    for (size_t i = 0; i < nclosed; i++) gitems[gstart[BOX_CELL(&box[i])]++] = (uint32_t)i;
#undef BOX_CELL
    for (size_t c = ncell; c > 0; c--) gstart[c] = gstart[c - 1];
    gstart[0] = 0;

    uint32_t pair = 0;
    for (size_t ib = 0; ib < nclosed; ib++) {
        const cbox *B = &box[ib];
        uint32_t i0 = grid_cell(B->lo[0], gx0, gsx, G), i1 = grid_cell(B->hi[0], gx0, gsx, G);
        uint32_t j0 = grid_cell(B->lo[1], gy0, gsy, G), j1 = grid_cell(B->hi[1], gy0, gsy, G);
        size_t ncand = 0;
        for (uint32_t gj = j0; gj <= j1; gj++)
            for (size_t gk = gstart[i0 + (size_t)G * gj]; gk < gstart[i1 + (size_t)G * gj + 1]; gk++) {
                const cbox *A = &box[gitems[gk]];
                int inbox = gitems[gk] != ib;
                for (int a = 0; a < 3; a++)
                    if (A->lo[a] < B->lo[a] || A->hi[a] > B->hi[a]) inbox = 0;
                if (inbox) cand[ncand++] = gitems[gk];
            }
        if (!ncand) continue;
        if (!tstart) { /* triangles by patch, once */
            tstart = calloc(nc + 1, sizeof *tstart);
            tlist = malloc((nt ? nt : 1) * sizeof *tlist);
            stamp = malloc((P->nv ? P->nv : 1) * sizeof *stamp);
            if (!tstart || !tlist || !stamp) goto nomem;
            for (size_t t = 0; t < nt; t++) tstart[PATCH(P, t) + 1]++;
            for (size_t c = 0; c < nc; c++) tstart[c + 1] += tstart[c];
            for (size_t t = 0; t < nt; t++) tlist[tstart[PATCH(P, t)]++] = (uint32_t)t;
            for (size_t c = nc; c > 0; c--) tstart[c] = tstart[c - 1];
            tstart[0] = 0;
            memset(stamp, 0xFF, (P->nv ? P->nv : 1) * sizeof *stamp);
        }
        uint32_t pb = B->patch;
        if (pgrid_build(&g, xyz, tris, tlist + tstart[pb], tstart[pb + 1] - tstart[pb], B->lo, B->hi)) goto nomem;
        for (size_t q = 0; q < ncand; q++) {
            uint32_t pa = box[cand[q]].patch;
            P->depth[pa] += (uint32_t)all_inside(&g, tris, tlist + tstart[pa], tstart[pa + 1] - tstart[pa], stamp, ++pair);
        }
        pgrid_free(&g);
    }
    goto done;
nomem:
    st = oom(P, "for the nesting test");
done:
    pgrid_free(&g);
    free(box);
    free(slot);
    free(tstart);
    free(tlist);
    free(stamp);
    free(gstart);
    free(gitems);
    free(cand);
    return st;
}

