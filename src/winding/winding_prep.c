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
 *    (|V| <= 1e-12 x the sum of the determinants' permanents: a flat sheet,
 *    a lone triangle of a soup) flips nothing.
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
 * docs/benchmarks.md "Winding numbers"). */
#include "winding.h"

#include <math.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#define NONE UINT32_MAX

/* ---- helpers -------------------------------------------------------------------- */

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

static size_t pow2_at_least(size_t n)
{
    size_t c = 16;
    while (c < n) c <<= 1;
    return c;
}


static int cmp_double(const void *pa, const void *pb)
{
    double a = *(const double *)pa, b = *(const double *)pb;
    return (a > b) - (a < b);
}

static void sort_u64(uint64_t *a, size_t n)
{
    if (n <= 24) clvox__sort_u64_small(a, n);
    else qsort(a, n, sizeof *a, clvox__cmp_u64);
}

/* ---- 1. exact merge --------------------------------------------------------------- */

#if defined(__GNUC__)
#define PREFETCH(p) __builtin_prefetch(p)
#else
#define PREFETCH(p) ((void)(p))
#endif

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
static void merge_exact(const float *xyz, size_t nv, uint32_t *rep, uint32_t *table, size_t cap, uint64_t *merged)
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
static clvox_status weld_vertices(clvox_context *ctx, const float *xyz, size_t nv, const uint32_t *tris, size_t nt,
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

/* ---- 3. orientation: union-find with a parity bit ------------------------------------ */

/* uf[t] = parent << 1 | parity (t's flip relative to its parent); a root
 * is its own parent with parity 0. Roots are the smallest triangle of their
 * set (the larger root is linked under the smaller). */
static uint32_t pf_find(uint32_t *uf, uint32_t x, unsigned *parity)
{
    unsigned p = 0;
    for (;;) {
        uint32_t e = uf[x], y = e >> 1;
        if (y == x) break;
        uint32_t f = uf[y], z = f >> 1;
        if (z == y) {
            p ^= e & 1u;
            x = y;
            break;
        }
        /* path halving: x skips to its grandparent */
        uf[x] = z << 1 | ((e ^ f) & 1u);
        p ^= (e ^ f) & 1u;
        x = z;
    }
    *parity = p;
    return x;
}

/* Joins a and b so that flip(b) = flip(a) ^ rel; returns 1 on a conflict. */
static int pf_union(uint32_t *uf, uint32_t a, uint32_t b, unsigned rel)
{
    unsigned pa, pb;
    uint32_t ra = pf_find(uf, a, &pa), rb = pf_find(uf, b, &pb);
    if (ra == rb) return (pa ^ pb) != rel;
    if (ra < rb) uf[rb] = ra << 1 | (pa ^ pb ^ rel);
    else uf[ra] = rb << 1 | (pa ^ pb ^ rel);
    return 0;
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

static int span_push(span_list *l, uint32_t lo, uint32_t b, uint32_t e)
{
    if (l->n == l->cap) {
        size_t cap = l->cap ? 2 * l->cap : 256;
        span *g = realloc(l->a, cap * sizeof *g);
        if (!g) return -1;
        l->a = g;
        l->cap = cap;
    }
    l->a[l->n].lo = lo;
    l->a[l->n].begin = b;
    l->a[l->n].end = e;
    l->n++;
    return 0;
}

/* One patch's net multiplicity m on edge lo < hi (before the patch signs). */
typedef struct pbound {
    uint32_t lo, hi, patch;
    int32_t m;
} pbound;

typedef struct pbound_list {
    pbound *a;
    size_t n, cap;
} pbound_list;

static int pbound_push(pbound_list *l, uint32_t lo, uint32_t hi, uint32_t patch, int32_t m)
{
    if (l->n == l->cap) {
        size_t cap = l->cap ? 2 * l->cap : 256;
        pbound *g = realloc(l->a, cap * sizeof *g);
        if (!g) return -1;
        l->a = g;
        l->cap = cap;
    }
    pbound *p = &l->a[l->n++];
    p->lo = lo;
    p->hi = hi;
    p->patch = patch;
    p->m = m;
    return 0;
}


/* det(a - o, b - o, d - o) (6 x the signed volume of the tetrahedron) and
 * its permanent, which bounds |v| and, times a few ulps, its rounding error. */
static void vol_term(const float *a, const float *b, const float *d, double ox, double oy, double oz, double *v,
                     double *vabs)
{
    double A0 = a[0] - ox, A1 = a[1] - oy, A2 = a[2] - oz;
    double B0 = b[0] - ox, B1 = b[1] - oy, B2 = b[2] - oz;
    double C0 = d[0] - ox, C1 = d[1] - oy, C2 = d[2] - oz;
    *v = A0 * (B1 * C2 - B2 * C1) + A1 * (B2 * C0 - B0 * C2) + A2 * (B0 * C1 - B1 * C0);
    *vabs = fabs(A0) * (fabs(B1 * C2) + fabs(B2 * C1)) + fabs(A1) * (fabs(B2 * C0) + fabs(B0 * C2)) +
            fabs(A2) * (fabs(B0 * C1) + fabs(B1 * C0));
}

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
            const uint32_t *t = tris + 3 * (size_t)tri_ids[i];
            float tx0 = xyz[3 * t[0]], tx1 = tx0, ty0 = xyz[3 * t[0] + 1], ty1 = ty0;
            for (int c = 1; c < 3; c++) {
                float x = xyz[3 * (size_t)t[c]], y = xyz[3 * (size_t)t[c] + 1];
                if (x < tx0) tx0 = x;
                if (x > tx1) tx1 = x;
                if (y < ty0) ty0 = y;
                if (y > ty1) ty1 = y;
            }
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
            const uint32_t *t = tris + 3 * (size_t)tri_ids[i];
            float tx0 = xyz[3 * t[0]], tx1 = tx0, ty0 = xyz[3 * t[0] + 1], ty1 = ty0;
            for (int c = 1; c < 3; c++) {
                float x = xyz[3 * (size_t)t[c]], y = xyz[3 * (size_t)t[c] + 1];
                if (x < tx0) tx0 = x;
                if (x > tx1) tx1 = x;
                if (y < ty0) ty0 = y;
                if (y > ty1) ty1 = y;
            }
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

/* ---- the preparation ----------------------------------------------------------------------- */

void clvox__winding_mesh_free(clvox__winding_mesh *w)
{
    if (!w) return;
    free(w->tris);
    free(w->caps);
    free(w->apex);
    free(w->rim);
    memset(w, 0, sizeof *w);
}

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
    uint32_t *depth;
    size_t ncomp;
    span_list special;
    pbound_list pb;
    int any_flip;        /* some triangle is reversed relative to its patch's first */
} prep;

#define PATCH(P, t) ((P)->pf[t] >> 1)
#define FLIP(P, t) ((P)->pf[t] & 1u)

static clvox_status oom(prep *P, const char *what)
{
    return clvox__fail(P->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory %s (%zu triangles)", what, P->nt);
}

/* The smallest and the middle corner of triangle t: the smaller vertex of
 * its edges (two start at the smallest corner, one at the middle one). */
static void lo_mid(const uint32_t *tr, uint32_t *lo, uint32_t *mid)
{
    uint32_t a = tr[0], b = tr[1], c = tr[2];
    uint32_t mn = a < b ? a : b, mx = a < b ? b : a;
    *lo = mn < c ? mn : c;
    *mid = c < mn ? mn : c > mx ? mx : c;
}

/* The edges by block of their smaller vertex (vertices v >> shift), as
 * triangle entries: a triangle is entered once in each block that holds the
 * smaller vertex of one of its edges (the block of its smallest corner, and
 * that of its middle corner when it differs), so at most 2 entries a
 * triangle instead of 3 half-edges. Only the offsets are made here: the
 * entries are laid out one chunk of blocks at a time (NCHUNKS chunks of
 * about equal size, orient_patches), each by one more pass over the
 * triangles whose writes go to a few hundred places; orient_patches then
 * sorts each block by vertex in the caches. 3.3 M triangles: 2 chunks of
 * about 13 MB instead of 40 MB of half-edge ids (one gather per triangle
 * entry instead of one per half-edge); 4 chunks took 11 ms more (one pass
 * each) for no lower peak, 1 chunk 2 ms less for 12 MB more. */
#define NCHUNKS 2
static clvox_status build_edges(prep *P)
{
    size_t nt = P->nt, nv = P->nv;
    const uint32_t *tris = P->tris;
    unsigned shift = 0;
    while ((nv >> shift) > 2048) shift++;
    size_t nb = (nv >> shift) + 1;
    P->shift = shift;
    P->nblocks = nb;
    P->bstart = calloc(nb + 1, sizeof *P->bstart);
    P->chunks = malloc((NCHUNKS + 1) * sizeof *P->chunks);
    uint32_t *uses = calloc(nb, sizeof *uses);
    if (!P->bstart || !P->chunks || !uses) {
        free(uses);
        return oom(P, "for the edges");
    }
    uint32_t *bs = P->bstart;
    for (size_t t = 0; t < nt; t++) {
        uint32_t lo, mid;
        lo_mid(tris + 3 * t, &lo, &mid);
        size_t bl = lo >> shift, bm = mid >> shift;
        bs[bl + 1]++;
        if (bm != bl) {
            bs[bm + 1]++;
            uses[bl] += 2;
            uses[bm] += 1;
        } else {
            uses[bl] += 3;
        }
    }
    size_t most = 0;
    for (size_t k = 0; k < nb; k++) {
        if (uses[k] > most) most = uses[k];
        bs[k + 1] += bs[k];
    }
    free(uses);
    P->most = most;
    /* chunks: runs of blocks closed as soon as they hold total / NCHUNKS
     * entries (rounded up), the last one at the last block; when the full
     * ones took every entry, the empty blocks left join the last of them:
     * at most NCHUNKS chunks, none empty */
    size_t total = bs[nb], target = (total + NCHUNKS - 1) / NCHUNKS, nc = 0, cmost = 0;
    P->chunks[0] = 0;
    for (size_t k = 0; k < nb; k++) {
        size_t held = bs[k + 1] - bs[P->chunks[nc]];
        if (k + 1 == nb && !held && nc) {
            P->chunks[nc] = (uint32_t)nb;
        } else if (held >= target || k + 1 == nb) {
            if (held > cmost) cmost = held;
            P->chunks[++nc] = (uint32_t)(k + 1);
        }
    }
    P->nchunks = nc;
    P->chunk_most = cmost;
    return CLVOX_OK;
}

/* Appends the uses e[0..n) of one edge to the special entries; the span
 * (lo, begin, end) indexes them. */
static int special_push(prep *P, uint32_t lo, const uint64_t *e, size_t n)
{
    if (P->nentry + n > P->cap_entry) {
        size_t cap = 2 * (P->nentry + n) + 256;
        uint64_t *g = realloc(P->entry, cap * sizeof *g);
        if (!g) return -1;
        P->entry = g;
        P->cap_entry = cap;
    }
    if (P->nentry + n > UINT32_MAX) return -1;
    memcpy(P->entry + P->nentry, e, n * sizeof *e);
    int bad = span_push(&P->special, lo, (uint32_t)P->nentry, (uint32_t)(P->nentry + n));
    P->nentry += n;
    return bad;
}

/* Pass 1: each vertex's bucket as (larger vertex << 32 | triangle << 1 |
 * (1: the use runs lo -> hi)), sorted; unions across manifold edges, in
 * (smaller vertex, larger vertex) order; the uses of the edges that need the
 * boundary pass are kept (P->entry, spans). */
static clvox_status orient_patches(prep *P, uint64_t *nonmanifold, uint64_t *conflict_out)
{
    size_t nt = P->nt;
    uint32_t *uf = P->uf;
    uint32_t *conflicts = NULL;
    size_t nconf = 0, capconf = 0;
    clvox_status st = CLVOX_OK;
    const uint32_t *tris = P->tris, *bs = P->bstart;
    const unsigned shift = P->shift;
    const size_t most = P->most ? P->most : 1, vspan = (size_t)1 << shift;
    uint64_t *key = malloc(2 * most * sizeof *key), *raw = key ? key + most : NULL;
    uint32_t *loc = malloc(most * sizeof *loc), *cnt = malloc((vspan + 1) * sizeof *cnt);
    uint32_t *ent = malloc((P->chunk_most ? P->chunk_most : 1) * sizeof *ent);
    uint32_t *cur = malloc(P->nblocks * sizeof *cur);
    if (!key || !loc || !cnt || !ent || !cur) goto nomem;
    for (size_t t = 0; t < nt; t++) uf[t] = (uint32_t)t << 1;
    uint64_t nm = 0;
    enum { AHEAD = 16 };
    for (size_t ch = 0; ch < P->nchunks; ch++) {
        /* the chunk's entries, blocks k0..k1-1, in triangle order */
        const size_t k0 = P->chunks[ch], k1 = P->chunks[ch + 1], base = bs[k0];
        const size_t nk = k1 - k0;
        for (size_t k = k0; k < k1; k++) cur[k] = bs[k] - (uint32_t)base;
        for (size_t t = 0; t < nt; t++) {
            uint32_t lo, mid;
            lo_mid(tris + 3 * t, &lo, &mid);
            size_t bl = lo >> shift, bm = mid >> shift;
            if (bl - k0 < nk) ent[cur[bl]++] = (uint32_t)t;
            if (bm != bl && bm - k0 < nk) ent[cur[bm]++] = (uint32_t)t;
        }
        for (size_t blk = k0; blk < k1; blk++) {
            const uint32_t *be = ent + (bs[blk] - base);
            size_t nb_ent = bs[blk + 1] - bs[blk], v0 = blk << shift, m = 0;
            if (!nb_ent) continue;
            /* The block's uses as keys (hi << 32 | triangle << 1 | direction),
             * then by vertex; the sort below orders each vertex's keys in full. */
            memset(cnt, 0, (vspan + 1) * sizeof *cnt);
            for (size_t k = 0; k < nb_ent; k++) {
                uint32_t t = be[k];
                if (k + 32 < nb_ent) PREFETCH(&tris[3 * (size_t)be[k + 32]]); /* little index locality: fetch ahead */
                const uint32_t *tr = tris + 3 * (size_t)t;
                for (int q = 0; q < 3; q++) {
                    uint32_t a = tr[q], c = tr[q == 2 ? 0 : q + 1];
                    uint32_t lo = a < c ? a : c, hi = a < c ? c : a;
                    if ((lo >> shift) != blk) continue;
                    raw[m] = (uint64_t)hi << 32 | (uint64_t)t << 1 | (uint64_t)(a < c);
                    loc[m] = (uint32_t)(lo - v0);
                    cnt[loc[m] + 1]++;
                    m++;
                }
            }
            for (size_t q = 0; q < vspan; q++) cnt[q + 1] += cnt[q];
            for (size_t k = 0; k < m; k++) key[cnt[loc[k]]++] = raw[k];
            /* cnt[q] is now the end of vertex v0 + q's uses. */
            for (size_t q = 0, i0 = 0; q < vspan && i0 < m; i0 = cnt[q], q++) {
                size_t e = cnt[q];
                if (e - i0 > 1) sort_u64(key + i0, e - i0);
                for (size_t i = i0; i < e;) {
                    size_t j = i + 1;
                    while (j < e && key[j] >> 32 == key[i] >> 32) j++;
                    if (j - i == 2) {
                        if (j + AHEAD + 1 < m) {
                            PREFETCH(&uf[(uint32_t)key[j + AHEAD] >> 1]);
                            PREFETCH(&uf[(uint32_t)key[j + AHEAD + 1] >> 1]);
                        }
                        uint32_t u0 = (uint32_t)key[i], u1 = (uint32_t)key[i + 1];
                        unsigned rel = !((u0 ^ u1) & 1u); /* same direction: one must flip */
                        if (pf_union(uf, u0 >> 1, u1 >> 1, rel)) {
                            if (special_push(P, (uint32_t)(v0 + q), key + i, j - i)) goto nomem;
                            if (nconf == capconf) {
                                capconf = capconf ? 2 * capconf : 64;
                                uint32_t *g = realloc(conflicts, capconf * sizeof *g);
                                if (!g) goto nomem;
                                conflicts = g;
                            }
                            conflicts[nconf++] = u0 >> 1;
                        }
                    } else {
                        nm += j - i > 2;
                        if (special_push(P, (uint32_t)(v0 + q), key + i, j - i)) goto nomem;
                    }
                    i = j;
                }
            }
        }
    }
    free(key);
    free(loc);
    free(cnt);
    free(ent);
    free(cur);
    key = NULL;
    loc = cnt = ent = cur = NULL;
    *nonmanifold = nm;
    /* Patches numbered by their roots (their smallest triangles) in
     * triangle order, flips relative to the root. A parent is always
     * smaller than its child (roots link under smaller roots, halving
     * skips to a grandparent), so in triangle order the parent's patch and
     * flip are already final: uf[t] becomes t's patch << 1 | flip in place,
     * without a find. */
    uint32_t *pf = uf, flips = 0;
    size_t nc = 0;
    for (size_t t = 0; t < nt; t++) {
        uint32_t e = uf[t], y = e >> 1;
        pf[t] = y == t ? (uint32_t)nc++ << 1 : (e & 1u) ^ pf[y];
        flips |= pf[t];
    }
    P->any_flip = flips & 1u;
    P->pf = pf;
    P->uf = NULL;
    P->ncomp = nc;
    P->first = malloc((nc ? nc : 1) * sizeof *P->first);
    P->pstate = calloc(nc ? nc : 1, 1);
    P->vol = calloc(nc ? nc : 1, sizeof *P->vol);
    P->vabs = calloc(nc ? nc : 1, sizeof *P->vabs);
    P->org = calloc((nc ? nc : 1) * 3, sizeof *P->org);
    P->depth = calloc(nc ? nc : 1, sizeof *P->depth);
    if (!P->first || !P->pstate || !P->vol || !P->vabs || !P->org || !P->depth) goto nomem;
    for (size_t u = nt; u-- > 0;) P->first[PATCH(P, u)] = (uint32_t)u;
    uint64_t nonor = 0;
    for (size_t k = 0; k < nconf; k++) {
        unsigned char *s = &P->pstate[PATCH(P, conflicts[k])];
        if (!(*s & P_NONORIENT)) nonor++;
        *s |= P_NONORIENT;
    }
    *conflict_out = nonor;
    goto done;
nomem:
    st = oom(P, "for the orientation");
done:
    free(key);
    free(loc);
    free(cnt);
    free(ent);
    free(cur);
    free(conflicts);
    return st;
}

/* Pass 2: each patch's own net multiplicity on the special edges. */
static clvox_status patch_boundaries(prep *P)
{
    uint64_t *scratch = NULL;
    size_t cap = 0;
    double *ends = calloc(P->ncomp ? P->ncomp : 1, sizeof *ends); /* boundary endpoints per patch */
    if (!ends) return oom(P, "for the boundary");
    for (size_t s = 0; s < P->special.n; s++) {
        uint32_t b = P->special.a[s].begin, e = P->special.a[s].end;
        uint32_t lo = P->special.a[s].lo, hi = (uint32_t)(P->entry[b] >> 32);
        size_t n = e - b;
        if (n > cap) {
            cap = 2 * n;
            uint64_t *g = realloc(scratch, cap * sizeof *g);
            if (!g) {
                free(scratch);
                free(ends);
                return oom(P, "for the boundary");
            }
            scratch = g;
        }
        /* (patch << 1 | direction), direction 1 = lo -> hi after the patch-relative flip. */
        for (size_t k = 0; k < n; k++) {
            uint32_t u = (uint32_t)P->entry[b + k], t = u >> 1;
            unsigned dir = (u & 1u) ^ FLIP(P, t);
            scratch[k] = (uint64_t)PATCH(P, t) << 1 | dir;
        }
        sort_u64(scratch, n);
        for (size_t k = 0; k < n;) {
            size_t j = k;
            int32_t m = 0;
            for (; j < n && scratch[j] >> 1 == scratch[k] >> 1; j++) m += (scratch[j] & 1) ? 1 : -1;
            if (m) {
                uint32_t pc = (uint32_t)(scratch[k] >> 1);
                if (pbound_push(&P->pb, lo, hi, pc, m)) {
                    free(scratch);
                    free(ends);
                    return oom(P, "for the boundary");
                }
                P->pstate[pc] |= P_OPEN;
                double w = m > 0 ? m : -m;
                for (int a = 0; a < 3; a++)
                    P->org[3 * pc + a] += w * ((double)P->xyz[3 * (size_t)lo + a] + P->xyz[3 * (size_t)hi + a]);
                ends[pc] += 2 * w;
            }
            k = j;
        }
    }
    free(scratch);
    /* Origins: centroid of the boundary endpoints (open), first vertex (closed). */
    for (size_t c = 0; c < P->ncomp; c++) {
        if (P->pstate[c] & P_OPEN) {
            for (int a = 0; a < 3; a++) P->org[3 * c + a] /= ends[c];
        } else {
            const float *o = P->xyz + 3 * (size_t)P->tris[3 * (size_t)P->first[c]];
            for (int a = 0; a < 3; a++) P->org[3 * c + a] = o[a];
        }
    }
    free(ends);
    return CLVOX_OK;
}

/* 6 x the signed volume of every patch about its origin. */
static void patch_volumes(prep *P)
{
    const uint32_t *tris = P->tris;
    const float *xyz = P->xyz;
    for (size_t t = 0; t < P->nt; t++) {
        uint32_t c = PATCH(P, t);
        const double *o = P->org + 3 * (size_t)c;
        const float *a = xyz + 3 * (size_t)tris[3 * t], *b = xyz + 3 * (size_t)tris[3 * t + 1],
                    *d = xyz + 3 * (size_t)tris[3 * t + 2];
        double v, va;
        vol_term(a, b, d, o[0], o[1], o[2], &v, &va);
        P->vol[c] += FLIP(P, t) ? -v : v;
        P->vabs[c] += va;
    }
}

/* The volume of a mesh that is one closed patch, about the first corner of
 * its first triangle (as the sum the mesh report made, mesh_report.c): when
 * the patch is the mesh's triangles as they are (no vertex merged, no
 * triangle flipped relative to the first) that sum is this one, term for
 * term; its sign is then taken as is when it lies beyond the tolerance of
 * the report's bound on the permanents (so beyond that of their sum, and
 * volume_sign decides as on the sum below). Else summed here. */
static void single_patch_volume(prep *P)
{
    const clvox_mesh *m = P->mesh;
    const uint32_t *tris = P->tris;
    if (tris == m->tris && P->nt == m->triangle_count && !P->any_flip &&
        fabs(m->volume.vol6) > 1e-12 * m->volume.perm_bound) {
        P->vol[0] = m->volume.vol6;
        P->vabs[0] = m->volume.perm_bound;
        return;
    }
    const float *xyz = P->xyz, *o = xyz + 3 * (size_t)tris[0];
    const double ox = o[0], oy = o[1], oz = o[2];
    double vol = 0, vabs = 0;
    for (size_t t = 0; t < P->nt; t++) {
        const float *a = xyz + 3 * (size_t)tris[3 * t], *b = xyz + 3 * (size_t)tris[3 * t + 1],
                    *d = xyz + 3 * (size_t)tris[3 * t + 2];
        double v, va;
        vol_term(a, b, d, ox, oy, oz, &v, &va);
        vol += FLIP(P, t) ? -v : v;
        vabs += va;
    }
    P->vol[0] = vol;
    P->vabs[0] = vabs;
}

/* The sign of a patch's volume, 0 when it is within 1e-12 of the sum of
 * the permanents (zero up to rounding: a flat sheet, one triangle, a
 * back-to-back pair), which then keeps its orientation. */
static int volume_sign(const prep *P, size_t c)
{
    double v = P->vol[c], tol = 1e-12 * P->vabs[c];
    return v > tol ? 1 : v < -tol ? -1 : 0;
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
static clvox_status nesting(prep *P, size_t nclosed)
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

/* Directed boundary edges (from << 32 | to) after the patch signs. */
static clvox_status boundary_edges(prep *P, uint64_t **out, size_t *count, uint64_t *total)
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
static clvox_status cap_loops(prep *P, uint64_t *edges, size_t ne, clvox__winding_mesh *out)
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
    merge_exact(mesh->xyz, nv, rep, ws + nv, cap, &rep_out->merged_vertices);
    if (weld > 0) {
        st = weld_vertices(ctx, mesh->xyz, nv, mesh->tris, nt_in, weld, rep, &rep_out->welded_vertices);
        if (st != CLVOX_OK) goto done;
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
    if ((st = build_edges(&P)) != CLVOX_OK) goto done;
    if ((st = orient_patches(&P, &rep_out->nonmanifold_edges, &rep_out->nonorientable_components)) != CLVOX_OK)
        goto done;
    free(P.bstart);
    free(P.chunks);
    P.bstart = NULL;
    P.chunks = NULL;
    rep_out->components = P.ncomp;
    if ((st = patch_boundaries(&P)) != CLVOX_OK) goto done;
    free(P.entry);
    P.entry = NULL;
    size_t nclosed = 0;
    for (size_t c = 0; c < P.ncomp; c++) nclosed += !(P.pstate[c] & P_OPEN);
    rep_out->closed_components = nclosed;

    /* 4. signs. */
    if (P.ncomp == 1 && nclosed == 1) single_patch_volume(&P);
    else patch_volumes(&P);
    if (nclosed >= 2 && (st = nesting(&P, nclosed)) != CLVOX_OK) goto done; /* boxes first, inside */
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
    if ((st = boundary_edges(&P, &bedges, &nbe, &rep_out->boundary_edges)) != CLVOX_OK) goto done;
    if ((st = cap_loops(&P, bedges, nbe, out)) != CLVOX_OK) goto done;

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
