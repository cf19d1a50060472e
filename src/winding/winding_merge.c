/* SPDX-License-Identifier: Apache-2.0 */
/* Winding preparation, steps 1 and 2 (winding_prep.c): vertices at equal
 * positions merged, then those within the weld distance. */
#include "winding_prep.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static uint64_t mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static uint32_t float_key(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u == 0x80000000u ? 0u : u; /* -0.0 == 0.0 */
}

static int cmp_double(const void *pa, const void *pb)
{
    double a = *(const double *)pa, b = *(const double *)pb;
    return (a > b) - (a < b);
}

/* ---- 1. exact merge --------------------------------------------------------------- */

static uint64_t pos_hash(const float *p)
{
    return mix64(((uint64_t)float_key(p[0]) << 32 | float_key(p[1])) ^
                 mix64((uint64_t)float_key(p[2]) + 0x9e3779b97f4a7c15ull));
}

/* Slots of the merge table: index | tag. The index takes the low `ib` bits
 * (enough for 0..nv, so that no slot equals NONE), the rest holds bits of the
 * position's hash, so that most occupied slots of other positions are passed
 * by without reading their vertex. */
static unsigned index_bits(size_t nv)
{
    unsigned b = 1;
    while (b < 32 && ((size_t)1 << b) <= nv) b++;
    return b;
}

/* rep[v] = the lowest-numbered vertex at v's position; table: cap (a power
 * of two >= 2 nv) slots of scratch. */
void clvox__prep_merge_exact(const float *xyz, size_t nv, uint32_t *rep, uint32_t *table, size_t cap, uint64_t *merged)
{
    size_t mask = cap - 1;
    unsigned ib = index_bits(nv);
    uint32_t imask = ib >= 32 ? UINT32_MAX : ((uint32_t)1 << ib) - 1;
    memset(table, 0xFF, cap * sizeof *table);
    uint64_t n = 0;
    enum { AHEAD = 16 };
    uint64_t ring[AHEAD];
    for (size_t v = 0; v < nv && v < AHEAD; v++) ring[v] = pos_hash(xyz + 3 * v);
    for (size_t v = 0; v < nv; v++) {
        const float *p = xyz + 3 * v;
        uint64_t h = ring[v % AHEAD];
        if (v + AHEAD < nv) { /* the table is far larger than the caches: fetch ahead */
            uint64_t g = pos_hash(xyz + 3 * (v + AHEAD));
            ring[v % AHEAD] = g;
            PREFETCH(&table[(size_t)g & mask]);
        }
        uint32_t tag = (uint32_t)(h >> 32) & ~imask;
        for (size_t s = (size_t)h & mask;; s = (s + 1) & mask) {
            uint32_t u = table[s];
            if (u == NONE) {
                table[s] = (uint32_t)v | tag;
                rep[v] = (uint32_t)v;
                break;
            }
            if ((u & ~imask) != tag) continue;
            const float *q = xyz + 3 * (size_t)(u & imask);
            if (q[0] == p[0] && q[1] == p[1] && q[2] == p[2]) {
                rep[v] = u & imask;
                n++;
                break;
            }
        }
    }
    *merged = n;
}

/* ---- 2. weld ------------------------------------------------------------------------ */

static uint32_t uf_find(uint32_t *parent, uint32_t x)
{
    while (parent[x] != x) {
        parent[x] = parent[parent[x]]; /* path halving */
        x = parent[x];
    }
    return x;
}

static int64_t weld_cell(double x, double size)
{
    double q = floor(x / size);
    const double lim = 1152921504606846976.0; /* 2^60: far cells share one, distances still decide */
    if (q > lim) q = lim;
    if (q < -lim) q = -lim;
    return (int64_t)q;
}

static uint64_t cell_hash(const int64_t *c)
{
    return mix64((uint64_t)c[0] * 0x9e3779b97f4a7c15ull ^ mix64((uint64_t)c[1] + 0x632be59bd9b4e019ull) ^
                 mix64(mix64((uint64_t)c[2]) + 0x8cb92ba72f3d8dd7ull));
}

/* Looks cell c up in the open-addressing table (cell ids); NONE if absent. */
static uint32_t cell_lookup(const uint32_t *table, size_t mask, const int64_t *keys, const int64_t *c)
{
    for (size_t s = (size_t)cell_hash(c) & mask;; s = (s + 1) & mask) {
        uint32_t id = table[s];
        if (id == NONE) return NONE;
        const int64_t *k = keys + 3 * (size_t)id;
        if (k[0] == c[0] && k[1] == c[1] && k[2] == c[2]) return id;
    }
}

/* Merges rep[] further: used distinct positions within `weld`, transitively,
 * into the lowest-numbered vertex of their group. */
clvox_status clvox__prep_weld_vertices(clvox_context *ctx, const float *xyz, size_t nv, const uint32_t *tris, size_t nt,
                                       double weld, uint32_t *rep, uint64_t *welded)
{
    clvox_status st = CLVOX_OK;
    uint32_t *parent = malloc((nv ? nv : 1) * sizeof *parent);
    uint32_t *cand = NULL, *vcell = NULL, *table = NULL, *cstart = NULL, *items = NULL;
    int64_t *keys = NULL;
    unsigned char *used = calloc(nv ? nv : 1, 1);
    if (!parent || !used) goto oom;
    for (size_t i = 0; i < 3 * nt; i++) used[rep[tris[i]]] = 1;
    size_t nc = 0;
    for (size_t v = 0; v < nv; v++) nc += used[v];
    cand = malloc((nc ? nc : 1) * sizeof *cand);
    vcell = malloc((nc ? nc : 1) * sizeof *vcell);
    keys = malloc((nc ? nc : 1) * 3 * sizeof *keys);
    size_t cap = pow2_at_least(2 * nc), mask = cap - 1;
    table = malloc(cap * sizeof *table);
    if (!cand || !vcell || !keys || !table) goto oom;
    memset(table, 0xFF, cap * sizeof *table);
    nc = 0;
    for (size_t v = 0; v < nv; v++) {
        parent[v] = (uint32_t)v;
        if (used[v]) cand[nc++] = (uint32_t)v;
    }
    /* Cell size: at least 2 weld (a ball of radius weld meets at most 2
     * cells per axis), and half the median edge length when that is larger,
     * so that most balls lie in their own cell and need no lookup (median
     * over the edges of a fixed sample of at most 2048 triangles: a few
     * huge triangles do not make the cells of a dense part huge). */
    size_t samples = nt < 2048 ? nt : 2048, ns = 0;
    double *len = malloc((3 * samples + 1) * sizeof *len);
    if (!len) goto oom;
    for (size_t i = 0; i < samples; i++) {
        const uint32_t *t = tris + 3 * (i * (nt / samples));
        for (int c = 0; c < 3; c++) {
            const float *p = xyz + 3 * (size_t)t[c], *q = xyz + 3 * (size_t)t[(c + 1) % 3];
            double dx = (double)p[0] - q[0], dy = (double)p[1] - q[1], dz = (double)p[2] - q[2];
            len[ns++] = sqrt(dx * dx + dy * dy + dz * dz);
        }
    }
    qsort(len, ns, sizeof *len, cmp_double);
    double cs = ns ? 0.5 * len[ns / 2] : 0;
    free(len);
    if (!(cs >= 2 * weld) || isinf(cs)) cs = 2 * weld;
    /* and at least 2^-40 of the largest coordinate, so that cell indices stay
     * far from the int64 clamp (a tiny weld on big coordinates) */
    double big = 0;
    for (size_t i = 0; i < 3 * nv; i++) big = fabs((double)xyz[i]) > big ? fabs((double)xyz[i]) : big;
    if (cs < big * 0x1p-40) cs = big * 0x1p-40;
    /* Cells, numbered in order of first appearance. */
    size_t ncell = 0;
    enum { AHEAD = 16 };
    for (size_t k = 0; k < nc; k++) {
        const float *p = xyz + 3 * (size_t)cand[k];
        int64_t c[3] = {weld_cell(p[0], cs), weld_cell(p[1], cs), weld_cell(p[2], cs)};
        if (k + AHEAD < nc) { /* fetch the slot of a later vertex ahead */
            const float *f = xyz + 3 * (size_t)cand[k + AHEAD];
            int64_t g[3] = {weld_cell(f[0], cs), weld_cell(f[1], cs), weld_cell(f[2], cs)};
            PREFETCH(&table[(size_t)cell_hash(g) & mask]);
        }
        size_t s = (size_t)cell_hash(c) & mask;
        for (;; s = (s + 1) & mask) {
            uint32_t id = table[s];
            if (id == NONE) {
                table[s] = (uint32_t)ncell;
                memcpy(keys + 3 * ncell, c, sizeof c);
                vcell[k] = (uint32_t)ncell++;
                break;
            }
            const int64_t *q = keys + 3 * (size_t)id;
            if (q[0] == c[0] && q[1] == c[1] && q[2] == c[2]) {
                vcell[k] = id;
                break;
            }
        }
    }
    cstart = calloc(ncell + 1, sizeof *cstart);
    items = malloc((nc ? nc : 1) * sizeof *items);
    if (!cstart || !items) goto oom;
    for (size_t k = 0; k < nc; k++) cstart[vcell[k] + 1]++;
    for (size_t c = 0; c < ncell; c++) cstart[c + 1] += cstart[c];
    for (size_t k = 0; k < nc; k++) items[cstart[vcell[k]]++] = cand[k];
    for (size_t c = ncell; c > 0; c--) cstart[c] = cstart[c - 1];
    cstart[0] = 0;

    /* Each vertex against the lower-numbered ones in the cells its ball meets. */
    double w2 = weld * weld;
    for (size_t k = 0; k < nc; k++) {
        uint32_t v = cand[k];
        const float *p = xyz + 3 * (size_t)v;
        int64_t lo[3], hi[3];
        for (int a = 0; a < 3; a++) {
            lo[a] = weld_cell((double)p[a] - weld, cs);
            hi[a] = weld_cell((double)p[a] + weld, cs);
        }
        int64_t c[3];
        for (c[0] = lo[0]; c[0] <= hi[0]; c[0]++)
            for (c[1] = lo[1]; c[1] <= hi[1]; c[1]++)
                for (c[2] = lo[2]; c[2] <= hi[2]; c[2]++) {
                    const int64_t *own = keys + 3 * (size_t)vcell[k];
                    uint32_t d = (c[0] == own[0] && c[1] == own[1] && c[2] == own[2])
                                     ? vcell[k]
                                     : cell_lookup(table, mask, keys, c);
                    if (d == NONE) continue;
                    for (uint32_t j = cstart[d]; j < cstart[d + 1] && items[j] < v; j++) {
                        uint32_t w = items[j];
                        const float *q = xyz + 3 * (size_t)w;
                        double dx = (double)p[0] - q[0], dy = (double)p[1] - q[1], dz = (double)p[2] - q[2];
                        if (dx * dx + dy * dy + dz * dz > w2) continue;
                        uint32_t rv = uf_find(parent, v), rw = uf_find(parent, w);
                        if (rv < rw) parent[rw] = rv;
                        else if (rw < rv) parent[rv] = rw;
                    }
                }
    }
    uint64_t n = 0;
    for (size_t k = 0; k < nc; k++) n += uf_find(parent, cand[k]) != cand[k];
    for (size_t v = 0; v < nv; v++) rep[v] = uf_find(parent, rep[v]);
    *welded = n;
    goto done;
oom:
    st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory welding %zu vertices", nv);
done:
    free(parent);
    free(used);
    free(cand);
    free(vcell);
    free(keys);
    free(table);
    free(cstart);
    free(items);
    return st;
}

