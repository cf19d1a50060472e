/* SPDX-License-Identifier: Apache-2.0 */
/* Winding numbers, host side (docs/design.md "Winding numbers"): the caps
 * that close the prepared surface's holes, the cap tree the consumers
 * refine near the caps and the rims' tree for the derivative bounds
 * (kernels/winding_*.h). The cast's indexed triangles over surface + caps are
 * made in src/cast/cast.c (winding_indexed). */
#include "winding.h"

#include "../../kernels/overlap.h" /* the exact signs, in double */

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define CAP_LEAF 4 /* cap triangles per leaf */

typedef struct cap_key {
    double key;
    uint32_t index;
} cap_key;

static int cmp_cap_key(const void *pa, const void *pb)
{
    const cap_key *a = pa, *b = pb;
    if (a->key != b->key) return a->key < b->key ? -1 : 1;
    return a->index < b->index ? -1 : a->index > b->index;
}

static float round_down(double x)
{
    float f = (float)x;
    return (double)f > x ? nextafterf(f, -INFINITY) : f;
}

static float round_up(double x)
{
    float f = (float)x;
    return (double)f < x ? nextafterf(f, INFINITY) : f;
}

void clvox__caps_release(clvox__caps *c)
{
    clvox__release_mem(&c->nodes);
    clvox__release_mem(&c->tris);
    clvox__release_mem(&c->grid);
    clvox__release_mem(&c->h);
    free(c->host);
    c->host = NULL;
    c->node_count = 0;
    c->cap_count = 0;
}

/* Cap triangle tg's (grid space) solid angle / 4pi at p (scaled; g in grid
 * space) as the double kernels take it (kernels/winding_angles.h
 * clvox_cap_angles4_v, one triangle): van Oosterom-Strackee on the scaled
 * corners tg times s, det's sign exact on the grid's floats, the tie rule
 * where it is 0, NaN as 0. */
static double cap_w(const float *tg, const double s[3], const double *p, const double *g, unsigned axis)
{
    double t[9], a[3], b[3], c[3];
    for (int k = 0; k < 9; k++) t[k] = (double)tg[k] * s[k % 3];
    for (int k = 0; k < 3; k++) a[k] = t[k] - p[k], b[k] = t[3 + k] - p[k], c[k] = t[6 + k] - p[k];
    const double la = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    const double lb = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    const double lc = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    double det = a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2]) +
                 a[2] * (b[0] * c[1] - b[1] * c[0]);
    const double L = la * lb * lc;
    const double den = L + (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) * lc +
                       (b[0] * c[0] + b[1] * c[1] + b[2] * c[2]) * la + (c[0] * a[0] + c[1] * a[1] + c[2] * a[2]) * lb;
    double v[9];
    for (int k = 0; k < 9; k++) v[k] = tg[k];
    const int sg = -clvox_o3_sign(v, g[0], g[1], g[2]);
    if (sg == 0) det = 0;
    else if (det * sg <= 0) det = sg * L * 0x1p-50;
    if (det == 0) {
        if (!(den < 0)) return 0;
        int d = 0;
        for (unsigned k = 0; k < 3 && d == 0; k++) {
            const unsigned i = (axis + k) % 3, j = (i + 1) % 3, r = (i + 2) % 3;
            d = -clvox_e2_sign(v[j], v[r], v[3 + j], v[3 + r], v[j], v[r], v[6 + j], v[6 + r]);
        }
        return d > 0 ? 0.5 : d < 0 ? -0.5 : 0;
    }
    if (isnan(det) || isnan(den)) return 0;
    return atan2(det, den) / (2.0 * 3.14159265358979323846);
}

int clvox__caps_host_inside(const clvox__caps *c, const double s[3], const double g[3], int K, int abs_mode,
                            unsigned axis)
{
    const double p[3] = {g[0] * s[0], g[1] * s[1], g[2] * s[2]}; /* as the kernels' clvox_scaled_xyz */
    double w = 0;
    for (size_t t = 0; t < c->host_count; t++) w += cap_w(c->host + t * 9, s, p, g, axis);
    w = (double)K - w;
    const double thr = 0.5 + 0x1p-30;
    return abs_mode ? (w > thr || w < -thr) : w > thr;
}

#define FOUR_PI (4.0 * 3.14159265358979323846)

/* Real i of a device array of doubles (rs 8) or floats (rs 4). */
static void put_real(void *arr, size_t rs, size_t i, double v)
{
    if (rs == 8) ((double *)arr)[i] = v;
    else ((float *)arr)[i] = (float)v;
}

/* A tree built on the host: nodes, and its reals (rs bytes each): the
 * triangles in leaf order (9 each), then the leaves' lane-major copies;
 * grid: the triangles again in grid space (9 floats each; not for edges). */
typedef struct tree {
    clvox_cap_node *nodes;
    size_t node_count;
    float *grid;
    void *reals;
    size_t real_count, tri_count, block_reals;
} tree;

enum { TREE_CAPS, TREE_SEGMENTS, TREE_PAIRS };

static void tree_free(tree *t)
{
    free(t->nodes);
    free(t->grid);
    free(t->reals);
    memset(t, 0, sizeof *t);
}

/* The tree over n items (q, consumed; scaled by s, clvox__winding_scale): cap triangles (9 scaled reals each),
 * edges (TREE_SEGMENTS: q[0..2] -> q[3..5], q[6..8] = q[3..5], whose "area"
 * is their length), or weld pairs (TREE_PAIRS: 18 reals, T then T', see
 * clvox_cap_node). */
static clvox_status tree_build(clvox_context *ctx, double *q, size_t n, int mode, const double s[3], tree *out);
/* Uploads t (freed) into out, which holds the voxel size already. */
static clvox_status tree_send(clvox_context *ctx, tree *t, int segments, clvox__caps *out);
static clvox_status tree_upload(clvox_context *ctx, double *q, size_t n, int segments, const double s[3],
                               clvox__caps *out)
{
    tree t;
    clvox_status st = tree_build(ctx, q, n, segments ? TREE_SEGMENTS : TREE_CAPS, s, &t);
    if (st == CLVOX_OK) st = tree_send(ctx, &t, segments, out);
    if (st != CLVOX_OK) clvox__caps_release(out);
    return st;
}

/* k with 2^k >= the grid's largest dimension (clvox__winding_scale). */
static int winding_scale_shift(const clvox_grid *grid)
{
    const uint32_t n = grid->dims[0] > grid->dims[1] ? (grid->dims[0] > grid->dims[2] ? grid->dims[0] : grid->dims[2])
                                                      : (grid->dims[1] > grid->dims[2] ? grid->dims[1] : grid->dims[2]);
    int k = 0;
    while (k < 31 && (1u << k) < n) k++;
    return k;
}

int clvox__winding_scale(const clvox_grid *grid, double s[3])
{
    const double *h = grid->voxel_size;
    const double m = fmax(h[0], fmax(h[1], h[2]));
    const double unit = ldexp(1.0, -winding_scale_shift(grid));
    for (int a = 0; a < 3; a++) s[a] = (m > 0 ? h[a] / m : 1.0) * unit;
    return h[0] == h[1] && h[0] == h[2];
}

/* The scale buffer every cap tree carries (the kernels take it): s, then
 * 1 where the scaled coordinates are the grid's floats times 2^-k exactly
 * (cubic voxels; kernels/winding_angles.h CLVOX_CUBIC), else 0. */
static clvox_status upload_h(clvox_context *ctx, const clvox_grid *grid, clvox__caps *out)
{
    clvox_status st = CLVOX_OK;
    double hb[4], s[3];
    const int exact = clvox__winding_scale(grid, s);
    for (int a = 0; a < 3; a++) put_real(hb, ctx->real_size, (size_t)a, s[a]);
    put_real(hb, ctx->real_size, 3, exact ? 1.0 : 0.0);
    out->h = clvox__buffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, 4 * ctx->real_size, hb, &st, "voxel scale");
    return st;
}

/* Grid-space triangles (u, v, w order, 9 floats each) to scaled x, y, z. */
static void scaled(const float *soup, size_t n, clvox__axes axes, const double h3[3], double *q)
{
    for (size_t t = 0; t < n; t++)
        for (int c = 0; c < 3; c++)
            for (int k = 0; k < 3; k++) {
                int a = axes.perm[k];
                q[t * 9 + c * 3 + a] = (double)soup[t * 9 + c * 3 + k] * h3[a];
            }
}

clvox_status clvox__caps_upload(clvox_context *ctx, const float *cap_soup, size_t n, clvox__axes axes,
                                const clvox_grid *grid, clvox__caps *out)
{
    return clvox__caps_upload_pairs(ctx, cap_soup, n, NULL, 0, axes, grid, out);
}

/* The root over the caps' tree c and the pairs' tree p (both non-empty):
 * [root, c's root, p's root, c's other nodes, p's other nodes]; the reals
 * [c's triangles, p's triangles, c's blocks, p's blocks]. */
static clvox_status tree_join(clvox_context *ctx, tree *c, tree *p, tree *out)
{
    memset(out, 0, sizeof *out);
    const size_t rs = ctx->real_size, nc = c->node_count, np = p->node_count;
    const size_t ct = c->tri_count * 9, pt = p->tri_count * 9;
    size_t total = ct + pt + c->block_reals + p->block_reals;
    const int blocks = total <= UINT32_MAX;
    if (!blocks) total = ct + pt;
    out->nodes = malloc((1 + nc + np) * sizeof *out->nodes);
    out->reals = malloc(total * rs);
    out->grid = malloc((ct + pt) * sizeof *out->grid);
    if (!out->nodes || !out->reals || !out->grid) {
        tree_free(out);
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for a tree of %zu caps",
                           c->tri_count + p->tri_count);
    }
    memcpy(out->grid, c->grid, ct * sizeof *out->grid);
    memcpy(out->grid + ct, p->grid, pt * sizeof *out->grid);
    char *r = out->reals;
    memcpy(r, c->reals, ct * rs);
    memcpy(r + ct * rs, p->reals, pt * rs);
    if (blocks) {
        memcpy(r + (ct + pt) * rs, (char *)c->reals + ct * rs, c->block_reals * rs);
        memcpy(r + (ct + pt + c->block_reals) * rs, (char *)p->reals + pt * rs, p->block_reals * rs);
    }
    for (size_t k = 0; k < nc; k++) {
        clvox_cap_node nd = c->nodes[k];
        if (nd.child) nd.child = nd.child + 2;
        nd.block = blocks && nd.block ? (uint32_t)(nd.block + pt) : 0;
        out->nodes[k == 0 ? 1 : k + 2] = nd;
    }
    for (size_t k = 0; k < np; k++) {
        clvox_cap_node nd = p->nodes[k];
        if (nd.child) nd.child = (uint32_t)(nd.child + nc + 1);
        nd.tri_first += (uint32_t)c->tri_count;
        nd.block = blocks && nd.block ? (uint32_t)(nd.block + ct + c->block_reals) : 0;
        out->nodes[k == 0 ? 2 : k + nc + 1] = nd;
    }
    const clvox_cap_node *a = &c->nodes[0], *b = &p->nodes[0];
    clvox_cap_node *root = &out->nodes[0];
    memset(root, 0, sizeof *root);
    for (int k = 0; k < 3; k++) {
        root->lo[k] = a->lo[k] < b->lo[k] ? a->lo[k] : b->lo[k];
        root->hi[k] = a->hi[k] > b->hi[k] ? a->hi[k] : b->hi[k];
        root->centre[k] = 0.5f * (root->lo[k] + root->hi[k]);
    }
    root->area4pi = round_up(((double)a->area4pi + (double)b->area4pi) * (1.0 + 1e-9));
    root->half_count = round_up((double)a->half_count + (double)b->half_count);
    root->radius = CLVOX_PAIR_RADIUS;
    root->quad4pi[0] = -FLT_MAX; /* no slab */
    root->quad4pi[1] = FLT_MAX;
    root->child = 1;
    root->tri_first = 0;
    root->tri_count = (uint32_t)(c->tri_count + p->tri_count);
    out->node_count = 1 + nc + np;
    out->tri_count = c->tri_count + p->tri_count;
    out->real_count = total;
    out->block_reals = total - ct - pt;
    return CLVOX_OK;
}

clvox_status clvox__caps_upload_pairs(clvox_context *ctx, const float *cap_soup, size_t n, const float *pair_soup,
                                      size_t np, clvox__axes axes, const clvox_grid *grid, clvox__caps *out)
{
    memset(out, 0, sizeof *out);
    clvox_status st = upload_h(ctx, grid, out);
    if (st != CLVOX_OK || (n == 0 && np == 0)) {
        if (st == CLVOX_OK) { /* bind something: the kernels read no node when node_count is 0 */
            clvox_cap_node dummy;
            memset(&dummy, 0, sizeof dummy);
            out->nodes = clvox__buffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof dummy, &dummy, &st,
                                       "cap tree");
            if (st == CLVOX_OK) out->tris = clvox__buffer(ctx, CL_MEM_READ_ONLY, 9 * ctx->real_size, NULL, &st, "caps");
            if (st == CLVOX_OK) out->grid = clvox__buffer(ctx, CL_MEM_READ_ONLY, 9 * sizeof(float), NULL, &st, "caps");
        }
        if (st != CLVOX_OK) clvox__caps_release(out);
        return st;
    }
    if (n > UINT32_MAX / 4 || np > UINT32_MAX / 8) {
        clvox__caps_release(out);
        return clvox__fail(ctx, CLVOX_ERR_MESH_INVALID, "%zu cap triangles: too many", n + 2 * np);
    }
    /* Scaled x, y, z (grid coordinates times s, clvox__winding_scale):
     * solid angles of the world, which a uniform scale keeps. */
    double h3[3];
    clvox__winding_scale(grid, h3);
    tree c = {0}, p = {0}, j = {0};
    if (n) {
        double *q = malloc(n * 9 * sizeof *q);
        if (!q) st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu cap triangles", n);
        if (st == CLVOX_OK) {
            scaled(cap_soup, n, axes, h3, q);
            st = tree_build(ctx, q, n, TREE_CAPS, h3, &c);
        }
    }
    if (st == CLVOX_OK && np) {
        double *q = malloc(np * 18 * sizeof *q);
        if (!q) st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu weld pairs", np);
        if (st == CLVOX_OK) {
            scaled(pair_soup, 2 * np, axes, h3, q);
            st = tree_build(ctx, q, np, TREE_PAIRS, h3, &p);
        }
    }
    if (st == CLVOX_OK) {
        if (n && np) {
            st = tree_join(ctx, &c, &p, &j);
            tree_free(&c);
            tree_free(&p);
        } else {
            j = n ? c : p;
            memset(n ? &c : &p, 0, sizeof c);
        }
    }
    if (st == CLVOX_OK) st = tree_send(ctx, &j, 0, out);
    tree_free(&c);
    tree_free(&p);
    tree_free(&j);
    if (st != CLVOX_OK) clvox__caps_release(out);
    return st;
}

clvox_status clvox__rims_upload(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                const uint32_t *rim, size_t n, clvox__caps *out)
{
    memset(out, 0, sizeof *out);
    if (n == 0) return CLVOX_OK;
    if (n > UINT32_MAX / 2) return clvox__fail(ctx, CLVOX_ERR_MESH_INVALID, "%zu boundary edges: too many", n);
    double *q = malloc(n * 9 * sizeof *q);
    if (!q) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu boundary edges", n);
    /* grid space (clvox__grid_coord, as the soup), times s */
    double s3[3];
    clvox__winding_scale(grid, s3);
    for (size_t e = 0; e < n; e++)
        for (int c = 0; c < 3; c++) {
            const float *p = mesh->xyz + 3 * (size_t)rim[2 * e + (c ? 1 : 0)];
            for (int a = 0; a < 3; a++) {
                float g = clvox__grid_coord(p[a], grid->origin[a] - mesh->offset[a], grid->voxel_size[a]);
                q[e * 9 + c * 3 + a] = (double)g * s3[a];
            }
        }
    return tree_upload(ctx, q, n, 1, s3, out);
}

/* (per(T) + 6 delta) delta of pair p (18 scaled reals: T, then T'):
 * the bound's numerator (src/winding/crack_weld.c), rounded up. */
static double pair_sweep(const double *p)
{
    double delta = 0.0, per = 0.0;
    for (int c = 0; c < 3; c++) {
        double d2 = 0.0, e2 = 0.0;
        for (int a = 0; a < 3; a++) {
            const double d = p[9 + c * 3 + a] - p[c * 3 + a], e = p[((c + 1) % 3) * 3 + a] - p[c * 3 + a];
            d2 += d * d;
            e2 += e * e;
        }
        if (sqrt(d2) > delta) delta = sqrt(d2);
        per += sqrt(e2);
    }
    return (per + 6.0 * delta) * delta * (1.0 + 1e-12);
}

/* A pair node's slab (clvox_cap_node; kernels/winding_bounds.h
 * clvox_pair_slab_gap): n the unit sum of its T's vector areas, in float,
 * and [smin, smax] holding n . y of every corner (T and T'), computed in
 * double with that float n and rounded outwards. None (-+FLT_MAX) where
 * the areas cancel. */
static void pair_slab(const double *q, const uint32_t *items, uint32_t count, clvox_cap_node *nd)
{
    double v[3] = {0, 0, 0};
    for (uint32_t i = 0; i < count; i++) {
        const double *p = q + (size_t)items[i] * 18;
        double e1[3], e2[3];
        for (int a = 0; a < 3; a++) e1[a] = p[3 + a] - p[a], e2[a] = p[6 + a] - p[a];
        v[0] += e1[1] * e2[2] - e1[2] * e2[1];
        v[1] += e1[2] * e2[0] - e1[0] * e2[2];
        v[2] += e1[0] * e2[1] - e1[1] * e2[0];
    }
    const double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    memset(nd->normal4pi, 0, sizeof nd->normal4pi);
    memset(nd->quad4pi, 0, sizeof nd->quad4pi);
    nd->second4pi = 0;
    nd->quad4pi[0] = -FLT_MAX;
    nd->quad4pi[1] = FLT_MAX;
    if (!(len > 1e-300) || !isfinite(len)) return;
    float n[3];
    for (int a = 0; a < 3; a++) n[a] = (float)(v[a] / len);
    double lo = DBL_MAX, hi = -DBL_MAX;
    for (uint32_t i = 0; i < count; i++) {
        const double *p = q + (size_t)items[i] * 18;
        for (int c = 0; c < 6; c++) {
            const double d = (double)n[0] * p[3 * c] + (double)n[1] * p[3 * c + 1] + (double)n[2] * p[3 * c + 2];
            if (d < lo) lo = d;
            if (d > hi) hi = d;
        }
    }
    const double m = 1e-12 * (fabs(lo) > fabs(hi) ? fabs(lo) : fabs(hi)) + 1e-300;
    for (int a = 0; a < 3; a++) nd->normal4pi[a] = n[a];
    nd->quad4pi[0] = round_down(lo - m);
    nd->quad4pi[1] = round_up(hi + m);
}

/* What a node needs of an item, summed or bounded over its items: box,
 * centroid (times 3: the split key), area (pairs: the bound's numerator),
 * vector area (segments: length across each axis). */
typedef struct item {
    double lo[3], hi[3], key[3], area, vec[3];
} item;

static void item_summary(const double *p, int per_item, int mode, item *it)
{
    memset(it->vec, 0, sizeof it->vec);
    it->area = 0.0;
    for (int a = 0; a < 3; a++) {
        it->lo[a] = DBL_MAX, it->hi[a] = -DBL_MAX;
        for (int c = 0; c < 3 * per_item; c++) {
            if (p[c * 3 + a] < it->lo[a]) it->lo[a] = p[c * 3 + a];
            if (p[c * 3 + a] > it->hi[a]) it->hi[a] = p[c * 3 + a];
        }
        it->key[a] = p[a] + p[3 + a] + p[6 + a];
    }
    if (mode == TREE_PAIRS) {
        it->area = pair_sweep(p);
        return;
    }
    double e1[3], e2[3];
    for (int a = 0; a < 3; a++) e1[a] = p[3 + a] - p[a], e2[a] = p[6 + a] - p[a];
    if (mode == TREE_SEGMENTS) {
        for (int a = 0; a < 3; a++) {
            const double x1 = e1[(a + 1) % 3], x2 = e1[(a + 2) % 3];
            it->vec[a] = sqrt(x1 * x1 + x2 * x2);
        }
        return;
    }
    double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2], cz = e1[0] * e2[1] - e1[1] * e2[0];
    it->area = 0.5 * sqrt(cx * cx + cy * cy + cz * cz);
    it->vec[0] = 0.5 * cx, it->vec[1] = 0.5 * cy, it->vec[2] = 0.5 * cz;
}

static int key_less(const cap_key *a, const cap_key *b)
{
    return a->key < b->key || (a->key == b->key && a->index < b->index);
}

/* Rearranges a[0 .. n) so that its k first are the k smallest in (key,
 * index) order (a total order), in O(n) on average: quickselect, median
 * of three; past 2 log2(n) + 16 rounds the rest is sorted. */
static void select_keys(cap_key *a, size_t n, size_t k)
{
    size_t lo = 0, hi = n, rounds = 16;
    for (size_t m = n; m > 1; m >>= 1) rounds += 2;
    while (hi - lo > 16 && k > lo && k < hi) {
        if (rounds-- == 0) {
            qsort(a + lo, hi - lo, sizeof *a, cmp_cap_key);
            return;
        }
        cap_key *x = &a[lo], *y = &a[lo + (hi - lo) / 2], *z = &a[hi - 1];
        const cap_key p = key_less(x, y) ? (key_less(y, z) ? *y : key_less(x, z) ? *z : *x)
                                         : (key_less(x, z) ? *x : key_less(y, z) ? *z : *y);
        size_t i = lo, j = hi - 1;
        for (;;) { /* Hoare: [lo, j] <= p <= [j + 1, hi) */
            while (key_less(&a[i], &p)) i++;
            while (key_less(&p, &a[j])) j--;
            if (i >= j) break;
            const cap_key t = a[i];
            a[i] = a[j];
            a[j] = t;
            i++;
            j--;
        }
        if (k <= j) hi = j + 1;
        else lo = j + 1;
    }
    if (hi - lo > 1 && k > lo && k < hi) qsort(a + lo, hi - lo, sizeof *a, cmp_cap_key);
}

static clvox_status tree_build(clvox_context *ctx, double *q, size_t n, int mode, const double s[3], tree *out)
{
    memset(out, 0, sizeof *out);
    clvox_status st = CLVOX_OK;
    const int segments = mode == TREE_SEGMENTS, pairs = mode == TREE_PAIRS;
    const size_t stride = pairs ? 18 : 9, per_item = pairs ? 2 : 1;         /* reals, triangles an item */
    const uint32_t leaf_items = pairs ? CAP_LEAF / 2 : CAP_LEAF;
    size_t rs = ctx->real_size;
    cap_key *keys = malloc(n * sizeof *keys);
    uint32_t *order = malloc(n * sizeof *order);
    clvox_cap_node *nodes = malloc(2 * n * sizeof *nodes);
    uint32_t *stack = malloc(2 * n * sizeof *stack);
    void *tris = malloc(n * per_item * 9 * rs);
    item *sum = malloc(n * sizeof *sum);
    if (!keys || !order || !nodes || !stack || !tris || !sum) {
        st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for a tree of %zu caps", n * per_item);
        goto done;
    }
    for (size_t t = 0; t < n; t++) {
        order[t] = (uint32_t)t;
        item_summary(q + t * stride, (int)per_item, mode, &sum[t]);
    }
    /* Top-down median split on the longest axis of the centroids' box. */
    size_t node_count = 1, sp = 0;
    nodes[0].tri_first = 0;
    nodes[0].tri_count = (uint32_t)n;
    stack[sp++] = 0;
    while (sp) {
        clvox_cap_node *nd = &nodes[stack[--sp]];
        uint32_t first = nd->tri_first, count = nd->tri_count;
        double lo[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, hi[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
        double clo[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, chi[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
        double area = 0.0, vec[3] = {0, 0, 0};
        for (uint32_t i = first; i < first + count; i++) {
            const item *it = &sum[order[i]];
            for (int a = 0; a < 3; a++) {
                if (it->lo[a] < lo[a]) lo[a] = it->lo[a];
                if (it->hi[a] > hi[a]) hi[a] = it->hi[a];
                const double m = it->key[a] / 3.0;
                if (m < clo[a]) clo[a] = m;
                if (m > chi[a]) chi[a] = m;
                vec[a] += it->vec[a];
            }
            area += it->area;
        }
        for (int a = 0; a < 3; a++) {
            nd->lo[a] = round_down(lo[a]);
            nd->hi[a] = round_up(hi[a]);
            nd->centre[a] = (float)(0.5 * (lo[a] + hi[a]));
            /* rims: an upper bound (clvox_rim_box_bound) */
            nd->normal4pi[a] = segments ? round_up(vec[a] / FOUR_PI * (1.0 + 1e-9)) : (float)(vec[a] / FOUR_PI);
        }
        /* the sphere, and the moments about the float centre c the kernels
         * use (clvox_cap_node): per flat triangle (area A, vector area S,
         * centroid g, corners v), M += S (g - c)^T exactly and the second
         * moment is A (|g - c|^2 + sum |v - g|^2 / 12) */
        double r2 = 0.0, M[3][3] = {{0}}, second = 0.0;
        int continue_pairs = 0;
        const double cc[3] = {nd->centre[0], nd->centre[1], nd->centre[2]};
        for (uint32_t i = first; i < first + count && !pairs; i++) {
            const double *p = q + (size_t)order[i] * 9;
            for (int c = 0; c < 3; c++) {
                double dx = p[c * 3] - cc[0], dy = p[c * 3 + 1] - cc[1], dz = p[c * 3 + 2] - cc[2];
                double d2 = dx * dx + dy * dy + dz * dz;
                if (d2 > r2) r2 = d2;
            }
            if (segments) continue;
            double g[3], e1[3], e2[3], spread = 0.0, gc2 = 0.0;
            for (int a = 0; a < 3; a++) {
                g[a] = (p[a] + p[3 + a] + p[6 + a]) / 3.0;
                e1[a] = p[3 + a] - p[a], e2[a] = p[6 + a] - p[a];
                gc2 += (g[a] - cc[a]) * (g[a] - cc[a]);
                for (int c = 0; c < 3; c++) spread += (p[c * 3 + a] - g[a]) * (p[c * 3 + a] - g[a]);
            }
            const double S[3] = {0.5 * (e1[1] * e2[2] - e1[2] * e2[1]), 0.5 * (e1[2] * e2[0] - e1[0] * e2[2]),
                                 0.5 * (e1[0] * e2[1] - e1[1] * e2[0])};
            const double A = sqrt(S[0] * S[0] + S[1] * S[1] + S[2] * S[2]);
            second += A * (gc2 + spread / 12.0);
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 3; b++) M[a][b] += S[a] * (g[b] - cc[b]);
        }
        nd->radius = pairs ? CLVOX_PAIR_RADIUS : round_up(sqrt(r2) * (1.0 + 1e-9));
        if (pairs) { /* the slab (clvox_cap_node), set in place of the moments below */
            pair_slab(q, order + first, count, nd);
            continue_pairs = 1;
        }
        if (!continue_pairs) {
            const double k = 1.0 / FOUR_PI;
            const double tr = M[0][0] + M[1][1] + M[2][2];
            const int ia[6] = {0, 1, 2, 0, 0, 1}, ib[6] = {0, 1, 2, 1, 2, 2};
            for (int e = 0; e < 6; e++)
                nd->quad4pi[e] = (float)(k * ((ia[e] == ib[e] ? tr : 0.0) - 1.5 * (M[ia[e]][ib[e]] + M[ib[e]][ia[e]])));
            nd->second4pi = round_up(second * k * (1.0 + 1e-9));
        }
        nd->area4pi = round_up(area / FOUR_PI * (1.0 + 1e-9));
        nd->half_count = round_up(0.5 * count * per_item); /* a pair: at most 1 */
        nd->child = 0;
        nd->block = 0;
        if (count <= leaf_items) continue;
        int axis = 0;
        for (int a = 1; a < 3; a++)
            if (chi[a] - clo[a] > chi[axis] - clo[axis]) axis = a;
        for (uint32_t i = 0; i < count; i++) {
            keys[i].key = sum[order[first + i]].key[axis];
            keys[i].index = order[first + i];
        }
        /* caps and pairs: the split falls on a multiple of a leaf, so that
         * the leaves hold CAP_LEAF caps (one per vector lane,
         * kernels/winding_angles.h) but for at most one per node; rim
         * edges: halves */
        uint32_t half = count / 2;
        if (!segments) {
            uint32_t blocks = (count + leaf_items - 1) / leaf_items;
            half = blocks / 2 * leaf_items;
        }
        /* the `half` first in (key, index) order, as a full sort would put
         * them; a child that is a leaf keeps that order inside it */
        select_keys(keys, count, half);
        if (half <= leaf_items) qsort(keys, half, sizeof *keys, cmp_cap_key);
        if (count - half <= leaf_items) qsort(keys + half, count - half, sizeof *keys, cmp_cap_key);
        for (uint32_t i = 0; i < count; i++) order[first + i] = keys[i].index;
        uint32_t c = (uint32_t)node_count;
        node_count += 2;
        nd->child = c;
        nodes[c].tri_first = first;
        nodes[c].tri_count = half;
        nodes[c + 1].tri_first = first + half;
        nodes[c + 1].tri_count = count - half;
        stack[sp++] = c;
        stack[sp++] = c + 1;
    }
    const size_t nt = n * per_item; /* triangles */
    if (pairs)
        for (size_t i = 0; i < node_count; i++) nodes[i].tri_first *= 2, nodes[i].tri_count *= 2;
    /* the triangles in leaf order: a pair as rev T, then T' (a point where
     * the weld collapsed it: no area, no tie, exactly 0) */
    double *tv = malloc(nt * 9 * sizeof *tv);
    if (!tv) {
        st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for a tree of %zu caps", nt);
        goto done;
    }
    for (size_t i = 0; i < n; i++) {
        const double *p = q + (size_t)order[i] * stride;
        if (!pairs) {
            memcpy(tv + i * 9, p, 9 * sizeof *tv);
            continue;
        }
        double *r = tv + i * 18;
        static const int rev[3] = {0, 2, 1};
        for (int c = 0; c < 3; c++) memcpy(r + 3 * c, p + 3 * rev[c], 3 * sizeof *r);
        const double *w = p + 9;
        const int collapsed = !memcmp(w, w + 3, 3 * sizeof *w) || !memcmp(w + 3, w + 6, 3 * sizeof *w) ||
                              !memcmp(w, w + 6, 3 * sizeof *w);
        for (int c = 0; c < 3; c++) memcpy(r + 9 + 3 * c, collapsed ? w : w + 3 * c, 3 * sizeof *r);
    }
    /* caps: in grid space too, for the kernels' exact signs (clvox__caps.grid):
     * every scaled real is a grid float times s rounded (scaled(), the
     * rims' upload), from which the float is recovered exactly -- a
     * relative error of 2^-52 is far below float's half spacing; checked */
    float *grid = NULL;
    if (!segments) {
        grid = malloc(nt * 9 * sizeof *grid);
        if (!grid) {
            free(tv);
            st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for a tree of %zu caps", nt);
            goto done;
        }
        for (size_t i = 0; i < nt * 9; i++) {
            grid[i] = (float)(tv[i] / s[i % 3]);
            if ((double)grid[i] * s[i % 3] != tv[i]) {
                const double bad = tv[i]; /* for the message, before tv goes */
                free(tv);
                free(grid);
                st = clvox__fail(ctx, CLVOX_ERR_INTERNAL, "a cap corner's grid coordinate is not a float (%.17g)",
                                 bad);
                goto done;
            }
        }
    }
    /* caps: after them, each leaf's caps again, lane-major (36 reals a
     * leaf, clvox_cap_node.block), for the kernels' vector loads */
    size_t leaves = 0, reals = nt * 9;
    if (!segments) {
        for (size_t i = 0; i < node_count; i++) leaves += nodes[i].child == 0;
        if (nt * 9 + leaves * 36 <= UINT32_MAX) reals += leaves * 36;
        else leaves = 0; /* too many for a u32 index: the kernels read the caps one by one */
    }
    if (reals > nt * 9) {
        void *t = realloc(tris, reals * rs);
        if (!t) {
            free(tv);
            st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for a tree of %zu caps", nt);
            goto done;
        }
        tris = t;
    }
    for (size_t i = 0; i < nt * 9; i++) put_real(tris, rs, i, tv[i]);
    if (leaves) {
        size_t at = nt * 9;
        for (size_t i = 0; i < node_count; i++) {
            clvox_cap_node *nd = &nodes[i];
            if (nd->child != 0) continue;
            nd->block = (uint32_t)at;
            for (int k = 0; k < 9; k++)
                for (uint32_t l = 0; l < 4; l++) {
                    uint32_t t = nd->tri_first + (l < nd->tri_count ? l : 0);
                    put_real(tris, rs, at + 4 * (size_t)k + l, tv[(size_t)t * 9 + k]);
                }
            at += 36;
        }
    }
    free(tv);
    out->grid = grid;
    out->nodes = nodes;
    out->node_count = node_count;
    out->reals = tris;
    out->real_count = reals;
    out->tri_count = nt;
    out->block_reals = reals - nt * 9;
    nodes = NULL;
    tris = NULL;
done:
    free(q);
    free(keys);
    free(order);
    free(nodes);
    free(stack);
    free(tris);
    free(sum);
    return st;
}

static clvox_status tree_send(clvox_context *ctx, tree *t, int segments, clvox__caps *out)
{
    clvox_status st = CLVOX_OK;
    out->nodes = clvox__buffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, t->node_count * sizeof *t->nodes,
                               t->nodes, &st, "cap tree");
    if (st == CLVOX_OK)
        out->tris = clvox__buffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, t->real_count * ctx->real_size,
                                  t->reals, &st, segments ? "boundary edges" : "caps");
    if (st == CLVOX_OK && !segments)
        out->grid = clvox__buffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, t->tri_count * 9 * sizeof(float),
                                  t->grid, &st, "caps in grid space");
    out->node_count = (cl_uint)t->node_count;
    out->cap_count = t->tri_count;
    if (st == CLVOX_OK && !segments && ctx->real_size == 4 && t->tri_count) {
        /* a float device's unsure points are decided on the host, in
         * double, over the same triangles (clvox__caps_host_inside) */
        out->host = t->grid;
        t->grid = NULL;
        out->host_count = t->tri_count;
    }
    tree_free(t);
    return st;
}

/* ---- caps ---------------------------------------------------------------- */

/* Caps of one loop (edges v[i] -> v[i+1], the last back to the first). A
 * fan from one apex over a long loop would put every cap triangle near
 * every point of the hole, so that each of them needs all of its solid
 * angles; instead the loop is halved until at most 8 corners are left: each
 * pass cuts off the triangles (v[2i+2], v[2i+1], v[2i]) -- thin slivers
 * along the rim, where only points near the rim see them -- and keeps every
 * other corner; the last polygon is closed by a fan from an apex at its
 * centroid, moved off its plane by 0.0731 times its size (so that a flat
 * hole's fan does not lie in a plane of voxel centres, where the centres
 * on its spokes would be ties). Every new edge is cut off again by the next
 * pass, so surface + caps stays a closed chain. */
typedef struct cap_out {
    uint32_t *tris;
    size_t count, cap;
    float *apex;
    size_t apex_count, apex_cap;
} cap_out;

static int cap_emit(cap_out *o, uint32_t a, uint32_t b, uint32_t c)
{
    if (o->count == o->cap) {
        size_t cap = o->cap * 2 + 64;
        uint32_t *t = realloc(o->tris, cap * 3 * sizeof *t);
        if (!t) return -1;
        o->tris = t;
        o->cap = cap;
    }
    o->tris[o->count * 3] = a;
    o->tris[o->count * 3 + 1] = b;
    o->tris[o->count * 3 + 2] = c;
    o->count++;
    return 0;
}

/* The apex's offset off the plane, in units of the polygon's size: 0.0731;
 * the cap_apex test hook (CLVOX_CAP_APEX=F) moves it (tests: the volume must not change). */
static double apex_offset(void)
{
    const clvox__test_hooks *h = clvox__hooks();
    return h->cap_apex_set ? h->cap_apex : 0.0731;
}

static int cap_loop(const clvox_mesh *mesh, uint32_t *v, size_t n, double offset, cap_out *o)
{
    while (n > 8) {
        size_t k = 0, i = 0;
        for (; i + 2 <= n; i += 2) {
            uint32_t a = v[i], b = v[i + 1], c = v[(i + 2) % n];
            if (cap_emit(o, c, b, a) != 0) return -1;
            v[k++] = a;
        }
        if (i < n) v[k++] = v[i]; /* odd n: the last corner stays */
        n = k;
    }
    if (n < 3) return 0; /* a -> b -> a: the two edges cancel */
    double c[3] = {0, 0, 0}, nrm[3] = {0, 0, 0}, ext = 0;
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) c[a] += mesh->xyz[3 * (size_t)v[i] + a] / (double)n;
    for (size_t i = 0; i < n; i++) {
        const float *p = mesh->xyz + 3 * (size_t)v[i], *q = mesh->xyz + 3 * (size_t)v[(i + 1) % n];
        double d[3] = {p[0] - c[0], p[1] - c[1], p[2] - c[2]}, e[3] = {q[0] - c[0], q[1] - c[1], q[2] - c[2]};
        nrm[0] += d[1] * e[2] - d[2] * e[1];
        nrm[1] += d[2] * e[0] - d[0] * e[2];
        nrm[2] += d[0] * e[1] - d[1] * e[0];
        double r = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        if (r > ext) ext = r;
    }
    double len = sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
    if (!(len > 0)) nrm[0] = 0.267, nrm[1] = 0.534, nrm[2] = 0.802, len = 1.0;
    if (o->apex_count == o->apex_cap) {
        size_t cap = o->apex_cap * 2 + 16;
        float *t = realloc(o->apex, cap * 3 * sizeof *t);
        if (!t) return -1;
        o->apex = t;
        o->apex_cap = cap;
    }
    uint32_t apex = (uint32_t)(mesh->vertex_count + o->apex_count);
    for (int a = 0; a < 3; a++) o->apex[o->apex_count * 3 + a] = (float)(c[a] + offset * ext * nrm[a] / len);
    o->apex_count++;
    for (size_t i = 0; i < n; i++)
        if (cap_emit(o, v[(i + 1) % n], v[i], apex) != 0) return -1;
    return 0;
}

clvox_status clvox__winding_cap_loops(clvox_context *ctx, const clvox_mesh *mesh, uint32_t *verts,
                                      const size_t *start, size_t loops, clvox__winding_mesh *wm)
{
    cap_out o = {wm->caps, wm->cap_count, wm->cap_count, wm->apex, wm->apex_count, wm->apex_count};
    int rc = 0;
    /* the rims (the loops' edges) bound the winding number's derivatives */
    size_t edges = start[loops];
    uint32_t *rim = realloc(wm->rim, (wm->rim_count + edges) * 2 * sizeof *rim + 1);
    if (!rim) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu boundary edges", edges);
    wm->rim = rim;
    for (size_t k = 0; k < loops; k++)
        for (size_t i = start[k]; i < start[k + 1]; i++) {
            rim[2 * wm->rim_count] = verts[i];
            rim[2 * wm->rim_count + 1] = verts[i + 1 < start[k + 1] ? i + 1 : start[k]];
            wm->rim_count++;
        }
    const double offset = apex_offset();
    for (size_t k = 0; rc == 0 && k < loops; k++)
        rc = cap_loop(mesh, verts + start[k], start[k + 1] - start[k], offset, &o);
    wm->caps = o.tris;
    wm->cap_count = o.count;
    wm->apex = o.apex;
    wm->apex_count = o.apex_count;
    wm->report.holes += loops;
    wm->report.cap_triangles = o.count;
    if (rc != 0) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for the caps of %zu holes", loops);
    if (mesh->vertex_count + wm->apex_count > UINT32_MAX)
        return clvox__fail(ctx, CLVOX_ERR_MESH_INVALID, "too many vertices with the caps' apexes");
    return CLVOX_OK;
}
