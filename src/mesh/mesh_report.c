/* SPDX-License-Identifier: Apache-2.0 */
/* Mesh report (clvox__mesh_build, mesh_build.c): the bounding box of the vertices in
 * use, degenerate triangles, the enclosed volume, boundary edges,
 * non-manifold triangles and duplicate triangles of the validated triangles.
 *
 * Two implementations with the same results, bit for bit:
 *   - the reference: one thread, per-vertex buckets of edges (counting sort,
 *     then a sort per bucket) and one hash set of triangles over the whole
 *     mesh: both are a random access into a table of tens of MB per edge or
 *     triangle (about 0.4 s for 3.3 M triangles);
 *   - the default: passes over parts of the triangles on the host threads
 *     (parallel.h) that only stream through memory, and work on buckets that
 *     fit the cache:
 *       1. geometry: corners gathered once per triangle for the box, the
 *          degenerate test, the signed volume term and an order-independent
 *          hash of the three corner positions; histograms of the edge and
 *          triangle buckets;
 *       2. one thread: the volume terms summed in triangle order (the same
 *          double sum as the reference), bucket offsets;
 *       3. scatter: triangle hashes, then edge keys, into their buckets;
 *       4. per bucket (a bucket's edges share the high bits of their smaller
 *          vertex): uses per edge counted in a small hash table (in cache);
 *          triangles put in a small hash set per bucket: distinct corner sets
 *          counted (duplicates = triangles - distinct sets, whatever order
 *          they are met in);
 *       5. only when an edge is non-manifold: the reference's replay in
 *          triangle order, over those edges.
 *     Every count is a sum over buckets or parts, the box a merge in part
 *     order, so the result does not depend on the number of threads.
 * The reference is in mesh_report_serial.c.
 * tests/test_mesh_report.c compares the two on every mesh it can find. */
#include "mesh_report.h"
#include "core/parallel.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- default implementation ------------------------------------------------------- */

/* Buckets hold about this many edge keys or triangles, so that the work on
 * one (radix sort, hash set) stays in the L1/L2 cache. */
#define EDGE_BUCKET 4096
#define TRI_BUCKET 2048
/* At most 2^20 edge buckets: vertex indices of up to 25 bits (32 M vertices)
 * then leave 32 bits of key per bucket; larger meshes use the reference. */
#define MAX_EDGE_BUCKET_BITS 20
/* Below this many triangles one thread does it all. */
#define MIN_PARALLEL_TRIANGLES 20000

static unsigned bits_for(uint64_t n) /* bits to hold 0..n-1, at least 1 */
{
    unsigned b = 1;
    while (b < 64 && (n - 1) >> b) b++;
    return b;
}

static unsigned ceil_log2(uint64_t n) /* smallest b with 2^b >= n */
{
    unsigned b = 0;
    while (b < 63 && ((uint64_t)1 << b) < n) b++;
    return b;
}

typedef struct analysis {
    const float *xyz;
    const uint32_t *tris;
    size_t nv, nt;
    int n; /* parts (= threads) */
    double apex[3];
    /* edge keys: lo << (bv + 1) | hi << 1 | (a > b) for a half-edge a -> b with
     * lo = min(a,b), hi = max(a,b); bucket = key >> rb, stored: the low rb bits */
    unsigned bv, rb;
    size_t ebuckets;
    uint32_t *ecount;   /* n x ebuckets: counts, then each part's write cursors */
    size_t *estart;     /* ebuckets + 1 */
    uint32_t *ekeys;    /* 3 nt */
    /* triangles: 64-bit hash of the corner positions; bucket = top tb bits */
    unsigned tb;
    size_t tbuckets;
    uint32_t *tcount;   /* n x tbuckets */
    size_t *tstart;     /* tbuckets + 1 */
    uint64_t *th;       /* nt hashes */
    uint64_t *tent;     /* nt: hash low 32 bits << 32 | triangle; first the volume terms (double) */
    /* per part */
    double bmin[CLVOX__MAX_HOST_THREADS][3], bmax[CLVOX__MAX_HOST_THREADS][3];
    uint64_t degenerate[CLVOX__MAX_HOST_THREADS], boundary[CLVOX__MAX_HOST_THREADS];
    uint64_t distinct[CLVOX__MAX_HOST_THREADS];
    uint64_t *complex[CLVOX__MAX_HOST_THREADS]; /* lo << 32 | hi, ascending */
    size_t ncomplex[CLVOX__MAX_HOST_THREADS];
    int failed[CLVOX__MAX_HOST_THREADS];
} analysis;

static uint64_t edge_key(const analysis *A, uint32_t a, uint32_t b)
{
    uint64_t lo = a < b ? a : b, hi = a < b ? b : a;
    return lo << (A->bv + 1) | hi << 1 | (uint64_t)(a > b);
}

static size_t tri_bucket(const analysis *A, uint64_t h) { return A->tb ? (size_t)(h >> (64 - A->tb)) : 0; }

/* The corner positions' hash, independent of their order. */
static uint64_t corner_hash(const float *p0, const float *p1, const float *p2)
{
    uint64_t h0 = hash3(float_key(p0[0]), float_key(p0[1]), float_key(p0[2]));
    uint64_t h1 = hash3(float_key(p1[0]), float_key(p1[1]), float_key(p1[2]));
    uint64_t h2 = hash3(float_key(p2[0]), float_key(p2[1]), float_key(p2[2]));
    return mix64(h0 + h1 + h2);
}

/* Pass 1 over part i of the triangles. The box is kept in float (the
 * corners are floats; the comparisons and the first extreme met are the
 * same as the reference's in double). */
static void pass_geometry(void *arg, int i, int n)
{
    analysis *A = arg;
    size_t t0, t1;
    clvox__part_range(A->nt, i, n, &t0, &t1);
    const float *xyz = A->xyz;
    const uint32_t *tris = A->tris;
    double *term = (double *)A->tent;
    uint64_t *th = A->th;
    uint32_t *ec = A->ecount + (size_t)i * A->ebuckets, *tc = A->tcount + (size_t)i * A->tbuckets;
    const double ax = A->apex[0], ay = A->apex[1], az = A->apex[2];
    float lx = (float)ax, ly = (float)ay, lz = (float)az, hx = lx, hy = ly, hz = lz;
    const unsigned rb = A->rb, sh = A->bv + 1, tsh = 64 - A->tb;
    const int tb = A->tb != 0;
    uint64_t degenerate = 0;
    enum { AHEAD = 16 };
    for (size_t t = t0; t < t1; t++) {
#if defined(__GNUC__)
        if (t + AHEAD < t1) {
            const uint32_t *f = tris + 3 * (t + AHEAD);
            __builtin_prefetch(xyz + 3 * (size_t)f[0]);
            __builtin_prefetch(xyz + 3 * (size_t)f[1]);
            __builtin_prefetch(xyz + 3 * (size_t)f[2]);
        }
#endif
        const uint32_t u0 = tris[3 * t], u1 = tris[3 * t + 1], u2 = tris[3 * t + 2];
        const float *p0 = xyz + 3 * (size_t)u0, *p1 = xyz + 3 * (size_t)u1, *p2 = xyz + 3 * (size_t)u2;
        float f[9] = {p0[0], p0[1], p0[2], p1[0], p1[1], p1[2], p2[0], p2[1], p2[2]};
        for (int c = 0; c < 9; c += 3) {
            if (f[c] < lx) lx = f[c];
            if (f[c] > hx) hx = f[c];
            if (f[c + 1] < ly) ly = f[c + 1];
            if (f[c + 1] > hy) hy = f[c + 1];
            if (f[c + 2] < lz) lz = f[c + 2];
            if (f[c + 2] > hz) hz = f[c + 2];
        }
        /* The same operations, in the same order, as ref_geometry. */
        double q[3][3];
        for (int c = 0; c < 3; c++)
            for (int a = 0; a < 3; a++) q[c][a] = f[3 * c + a];
        double e1[3], e2[3], cr[3];
        for (int a = 0; a < 3; a++) e1[a] = q[1][a] - q[0][a], e2[a] = q[2][a] - q[0][a];
        cr[0] = e1[1] * e2[2] - e1[2] * e2[1];
        cr[1] = e1[2] * e2[0] - e1[0] * e2[2];
        cr[2] = e1[0] * e2[1] - e1[1] * e2[0];
        degenerate += cr[0] == 0.0 && cr[1] == 0.0 && cr[2] == 0.0;
        double P[3], Q[3], R[3];
        P[0] = q[0][0] - ax, Q[0] = q[1][0] - ax, R[0] = q[2][0] - ax;
        P[1] = q[0][1] - ay, Q[1] = q[1][1] - ay, R[1] = q[2][1] - ay;
        P[2] = q[0][2] - az, Q[2] = q[1][2] - az, R[2] = q[2][2] - az;
        term[t] = P[0] * (Q[1] * R[2] - Q[2] * R[1]) + P[1] * (Q[2] * R[0] - Q[0] * R[2]) +
                  P[2] * (Q[0] * R[1] - Q[1] * R[0]);
        uint64_t h = corner_hash(f, f + 3, f + 6);
        th[t] = h;
        tc[tb ? (size_t)(h >> tsh) : 0]++;
        uint64_t lo01 = u0 < u1 ? u0 : u1, hi01 = u0 < u1 ? u1 : u0;
        uint64_t lo12 = u1 < u2 ? u1 : u2, hi12 = u1 < u2 ? u2 : u1;
        uint64_t lo20 = u2 < u0 ? u2 : u0, hi20 = u2 < u0 ? u0 : u2;
        ec[(lo01 << sh | hi01 << 1) >> rb]++;
        ec[(lo12 << sh | hi12 << 1) >> rb]++;
        ec[(lo20 << sh | hi20 << 1) >> rb]++;
    }
    A->bmin[i][0] = lx, A->bmin[i][1] = ly, A->bmin[i][2] = lz;
    A->bmax[i][0] = hx, A->bmax[i][1] = hy, A->bmax[i][2] = hz;
    A->degenerate[i] = degenerate;
}

/* Counts of n parts x buckets into each part's write cursor (in place) and
 * the bucket starts. */
static void bucket_offsets(uint32_t *count, size_t buckets, int n, size_t *start)
{
    size_t pos = 0;
    for (size_t b = 0; b < buckets; b++) {
        start[b] = pos;
        for (int i = 0; i < n; i++) {
            uint32_t c = count[(size_t)i * buckets + b];
            count[(size_t)i * buckets + b] = (uint32_t)pos;
            pos += c;
        }
    }
    start[buckets] = pos;
}

static void pass_scatter_triangles(void *arg, int i, int n)
{
    analysis *A = arg;
    size_t t0, t1;
    clvox__part_range(A->nt, i, n, &t0, &t1);
    uint32_t *cur = A->tcount + (size_t)i * A->tbuckets;
    for (size_t t = t0; t < t1; t++) {
        uint64_t h = A->th[t];
        A->tent[cur[tri_bucket(A, h)]++] = (h & 0xFFFFFFFFu) << 32 | (uint64_t)t;
    }
}

static void pass_scatter_edges(void *arg, int i, int n)
{
    analysis *A = arg;
    size_t t0, t1;
    clvox__part_range(A->nt, i, n, &t0, &t1);
    uint32_t *cur = A->ecount + (size_t)i * A->ebuckets;
    uint64_t mask = A->rb >= 32 ? 0xFFFFFFFFu : (((uint64_t)1 << A->rb) - 1);
    for (size_t t = t0; t < t1; t++) {
        const uint32_t *u = A->tris + 3 * t;
        for (int c = 0; c < 3; c++) {
            uint64_t k = edge_key(A, u[c], u[c == 2 ? 0 : c + 1]);
            A->ekeys[cur[k >> A->rb]++] = (uint32_t)(k & mask);
        }
    }
}

static int push_complex(analysis *A, int i, size_t *cap, uint64_t edge)
{
    if (A->ncomplex[i] == *cap) {
        size_t nc = *cap ? 2 * *cap : 256;
        uint64_t *g = realloc(A->complex[i], nc * sizeof *g);
        if (!g) return 0;
        A->complex[i] = g;
        *cap = nc;
    }
    A->complex[i][A->ncomplex[i]++] = edge;
    return 1;
}

/* [*b0, *b1): the buckets of part i, split so that each part gets about the
 * same number of items. */
static void bucket_share(const size_t *start, size_t buckets, int i, int n, size_t *b0, size_t *b1)
{
    size_t total = start[buckets], lo, hi;
    clvox__part_range(total, i, n, &lo, &hi);
    size_t b = 0;
    /* first bucket starting at or after lo (part 0 starts at bucket 0) */
    size_t l = 0, r = buckets;
    while (l < r) {
        size_t mid = l + (r - l) / 2;
        if (start[mid] < lo) l = mid + 1;
        else r = mid;
    }
    b = i == 0 ? 0 : l;
    l = 0, r = buckets;
    while (l < r) {
        size_t mid = l + (r - l) / 2;
        if (start[mid] < hi) l = mid + 1;
        else r = mid;
    }
    *b0 = b;
    *b1 = i == n - 1 ? buckets : l;
}

static void pass_buckets(void *arg, int i, int n)
{
    analysis *A = arg;
    uint64_t *etab = NULL;
    uint32_t *table = NULL;
    size_t cap = 0;
    /* Edges: uses counted per edge in a hash table per bucket. Slot: edge + 1
     * in the high 32 bits, then bits 0-1 min(uses, 3), bit 2 uses odd, bit 3
     * direction of the first use, bit 4 the second use in that direction. */
    size_t b0, b1, most = 0;
    bucket_share(A->estart, A->ebuckets, i, n, &b0, &b1);
    for (size_t b = b0; b < b1; b++)
        if (A->estart[b + 1] - A->estart[b] > most) most = A->estart[b + 1] - A->estart[b];
    size_t es = 16;
    while (es < most + most / 4) es *= 2; /* load <= 0.8 when every use is a distinct edge */
    etab = malloc(es * sizeof *etab);
    if (!etab) goto fail;
    uint64_t nb = 0;
    unsigned vb = A->bv;
    uint64_t vmask = ((uint64_t)1 << vb) - 1;
    for (size_t b = b0; b < b1; b++) {
        const uint32_t *key = A->ekeys + A->estart[b];
        size_t m = A->estart[b + 1] - A->estart[b], size = 16;
        unsigned lg = 4;
        while (size < m + m / 4) size *= 2, lg++;
        size_t mask = size - 1;
        memset(etab, 0, size * sizeof *etab);
        for (size_t j = 0; j < m; j++) {
            uint32_t e = key[j] >> 1;
            uint64_t d = key[j] & 1, tag = (uint64_t)e + 1;
            size_t s = (uint32_t)(e * 0x9E3779B1u) >> (32 - lg);
            uint64_t v = etab[s];
            while (v && v >> 32 != tag) { /* another edge's slot: rare at this load */
                s = (s + 1) & mask;
                v = etab[s];
            }
            /* Without branches on whether this is the edge's first use: an
             * empty slot reads as the edge with no uses yet. */
            uint64_t u = v ? v : (tag << 32 | d << 3);
            uint64_t c = u & 3, same = (uint64_t)(c == 1) & ~((u >> 3) ^ d) & 1;
            etab[s] = ((u & ~(uint64_t)3) | (c + (c < 3))) ^ 4u ^ (same << 4);
        }
        for (size_t s = 0; s < size; s++) {
            uint64_t v = etab[s]; /* 0 when empty: counts nothing (no branch, half the slots are empty) */
            nb += (v >> 2) & 1;
            unsigned c = (unsigned)v & 3u;
            if ((c == 3) | ((c == 2) & (unsigned)(v >> 4))) { /* rare: keep it one predictable branch */
                uint64_t k = (uint64_t)b << A->rb | ((v >> 32) - 1) << 1;
                uint64_t lo = k >> (vb + 1), hi = (k >> 1) & vmask;
                if (!push_complex(A, i, &cap, lo << 32 | hi)) goto fail;
            }
        }
    }
    A->boundary[i] = nb;
    free(etab);
    etab = NULL;

    /* Triangles: distinct corner sets per bucket. */
    bucket_share(A->tstart, A->tbuckets, i, n, &b0, &b1);
    most = 0;
    for (size_t b = b0; b < b1; b++)
        if (A->tstart[b + 1] - A->tstart[b] > most) most = A->tstart[b + 1] - A->tstart[b];
    size_t ts = 16;
    while (ts < 2 * most) ts *= 2;
    table = malloc(ts * sizeof *table);
    if (!table) goto fail;
    uint64_t distinct = 0;
    for (size_t b = b0; b < b1; b++) {
        const uint64_t *ent = A->tent + A->tstart[b];
        size_t m = A->tstart[b + 1] - A->tstart[b];
        size_t size = 16;
        while (size < 2 * m) size *= 2;
        size_t mask = size - 1;
        memset(table, 0, size * sizeof *table);
        for (size_t j = 0; j < m; j++) {
            uint32_t tag = (uint32_t)(ent[j] >> 32);
            int have_key = 0;
            uint32_t k[3][3], q[3][3];
            for (size_t s = tag & mask;; s = (s + 1) & mask) {
                if (!table[s]) {
                    table[s] = (uint32_t)j + 1;
                    distinct++;
                    break;
                }
                uint64_t other = ent[table[s] - 1];
                if ((uint32_t)(other >> 32) != tag) continue;
                if (!have_key) sorted_corners(A->xyz, A->tris, (uint32_t)ent[j], k), have_key = 1;
                sorted_corners(A->xyz, A->tris, (uint32_t)other, q);
                if (!memcmp(k, q, sizeof k)) break; /* a copy of a set already counted */
            }
        }
    }
    A->distinct[i] = distinct;
    free(table);
    return;
fail:
    free(etab);
    free(table);
    A->failed[i] = 1;
}

static int cmp_edge(const void *pa, const void *pb)
{
    uint64_t a = *(const uint64_t *)pa, b = *(const uint64_t *)pb;
    return (a > b) - (a < b);
}

/* The reference's replay (ref_edge_analysis) over the complex edges
 * cx[0..ncx) (lo << 32 | hi, ascending): triangles in input order, one is
 * rejected when an edge it uses is already used in the same direction, or
 * twice, by triangles accepted before it. */
static int replay_complex(const uint32_t *tris, size_t nt, const uint64_t *cx, size_t ncx, uint64_t *nonmanifold)
{
    unsigned char *gstate = calloc(ncx, 1); /* bit 0/1: used in direction 0/1, bits 2-3: uses (saturating at 2) */
    if (!gstate) return -1;
    uint64_t nm = 0;
    for (size_t t = 0; t < nt; t++) {
        size_t g[3];
        unsigned dir[3];
        int nu = 0, reject = 0;
        for (int c = 0; c < 3; c++) {
            uint32_t a = tris[3 * t + c], b = tris[3 * t + (c == 2 ? 0 : c + 1)];
            uint64_t e = (uint64_t)(a < b ? a : b) << 32 | (a < b ? b : a);
            const uint64_t *hit = bsearch(&e, cx, ncx, sizeof *cx, cmp_edge);
            if (!hit) continue;
            g[nu] = (size_t)(hit - cx);
            dir[nu] = a > b;
            unsigned char s = gstate[g[nu]];
            if ((s >> 2) >= 2 || (s >> dir[nu] & 1)) reject = 1;
            nu++;
        }
        if (!nu) continue;
        if (reject) {
            nm++;
            continue;
        }
        for (int q = 0; q < nu; q++) gstate[g[q]] = (unsigned char)((gstate[g[q]] | 1u << dir[q]) + 4);
    }
    free(gstate);
    *nonmanifold = nm;
    return 0;
}

typedef void (*pass_fn)(void *, int, int);

static int analyze_fast(const float *xyz, size_t nv, const uint32_t *tris, size_t nt, int threads,
                        clvox_mesh_report *r, double *vol6_out)
{
    analysis *A = calloc(1, sizeof *A);
    if (!A) return -1;
    int rc = -1;
    A->xyz = xyz;
    A->tris = tris;
    A->nv = nv;
    A->nt = nt;
    A->n = nt < MIN_PARALLEL_TRIANGLES ? 1 : threads;
    const float *o = xyz + 3 * (size_t)tris[0];
    for (int a = 0; a < 3; a++) A->apex[a] = o[a];

    A->bv = bits_for(nv);
    unsigned kbits = 2 * A->bv + 1, eb = ceil_log2(3 * (uint64_t)nt / EDGE_BUCKET);
    if (kbits > 32 && kbits - 32 > eb) eb = kbits - 32;
    if (eb > kbits - 1) eb = kbits - 1; /* the direction bit stays in the stored key */
    A->rb = kbits - eb;
    A->ebuckets = (size_t)1 << eb;
    A->tb = ceil_log2(nt / TRI_BUCKET);
    if (A->tb > 16) A->tb = 16;
    A->tbuckets = (size_t)1 << A->tb;

    int n = A->n;
    A->ecount = calloc((size_t)n * A->ebuckets, sizeof *A->ecount);
    A->tcount = calloc((size_t)n * A->tbuckets, sizeof *A->tcount);
    A->estart = malloc((A->ebuckets + 1) * sizeof *A->estart);
    A->tstart = malloc((A->tbuckets + 1) * sizeof *A->tstart);
    A->th = malloc(nt * sizeof *A->th);
    A->tent = malloc(nt * sizeof *A->tent);
    if (!A->ecount || !A->tcount || !A->estart || !A->tstart || !A->th || !A->tent) goto done;

    clvox__parallel(n, pass_geometry, A);
    for (int a = 0; a < 3; a++) r->bbox_min[a] = A->bmin[0][a], r->bbox_max[a] = A->bmax[0][a];
    for (int i = 0; i < n; i++) {
        r->degenerate_triangles += A->degenerate[i];
        if (!i) continue;
        for (int a = 0; a < 3; a++) { /* strict: the first extreme in triangle order wins, as in one pass */
            if (A->bmin[i][a] < r->bbox_min[a]) r->bbox_min[a] = A->bmin[i][a];
            if (A->bmax[i][a] > r->bbox_max[a]) r->bbox_max[a] = A->bmax[i][a];
        }
    }
    const double *term = (const double *)A->tent;
    double vol6 = 0.0;
    for (size_t t = 0; t < nt; t++) vol6 += term[t];
    r->enclosed_volume = fabs(vol6) / 6.0;
    *vol6_out = vol6;

    bucket_offsets(A->tcount, A->tbuckets, n, A->tstart);
    clvox__parallel(n, pass_scatter_triangles, A);
    free(A->th);
    A->th = NULL;
    A->ekeys = malloc(3 * nt * sizeof *A->ekeys);
    if (!A->ekeys) goto done;
    bucket_offsets(A->ecount, A->ebuckets, n, A->estart);
    clvox__parallel(n, pass_scatter_edges, A);
    free(A->ecount);
    A->ecount = NULL;
    clvox__parallel(n, pass_buckets, A);
    uint64_t distinct = 0;
    size_t ncx = 0;
    for (int i = 0; i < n; i++) {
        if (A->failed[i]) goto done;
        r->boundary_edges += A->boundary[i];
        distinct += A->distinct[i];
        ncx += A->ncomplex[i];
    }
    r->duplicate_triangles = nt - distinct;
    free(A->ekeys);
    A->ekeys = NULL;
    free(A->tent);
    A->tent = NULL;
    r->nonmanifold_faces = 0;
    if (ncx) {
        uint64_t *cx = A->complex[0];
        if (n > 1) {
            cx = malloc(ncx * sizeof *cx);
            if (!cx) goto done;
            size_t pos = 0;
            for (int i = 0; i < n; i++) {
                if (A->ncomplex[i]) memcpy(cx + pos, A->complex[i], A->ncomplex[i] * sizeof *cx);
                pos += A->ncomplex[i];
            }
        }
        qsort(cx, ncx, sizeof *cx, cmp_edge);
        int bad = replay_complex(tris, nt, cx, ncx, &r->nonmanifold_faces);
        if (cx != A->complex[0]) free(cx);
        if (bad) goto done;
    }
    rc = 0;
done:
    for (int i = 0; i < CLVOX__MAX_HOST_THREADS; i++) free(A->complex[i]);
    free(A->ecount);
    free(A->tcount);
    free(A->estart);
    free(A->tstart);
    free(A->th);
    free(A->tent);
    free(A->ekeys);
    free(A);
    return rc;
}

int clvox__mesh_analyze(const float *xyz, size_t nv, const uint32_t *tris, size_t nt, int threads, int reference,
                        clvox_mesh_report *r, clvox__mesh_volume *vol)
{
    r->degenerate_triangles = r->boundary_edges = r->nonmanifold_faces = r->duplicate_triangles = 0;
    vol->vol6 = vol->perm_bound = 0.0;
    if (!nt) {
        for (int a = 0; a < 3; a++) r->bbox_min[a] = r->bbox_max[a] = 0.0;
        r->enclosed_volume = 0.0;
        return 0;
    }
    if (threads <= 0) threads = clvox__host_threads();
    if (threads > CLVOX__MAX_HOST_THREADS) threads = CLVOX__MAX_HOST_THREADS;
    double vol6 = 0.0;
    int rc;
    /* Vertex indices beyond 25 bits do not fit the edge buckets. */
    if (reference || bits_for(nv) > (32 + MAX_EDGE_BUCKET_BITS - 1) / 2)
        rc = clvox__mesh_analyze_serial(xyz, nv, tris, nt, r, &vol6);
    else
        rc = analyze_fast(xyz, nv, tris, nt, threads, r, &vol6);
    if (rc == 0) {
        /* Each term's permanent is at most 6 Mx My Mz (|A0| (|B1 C2| +
         * |B2 C1|) + ...); twice that covers its rounding and the sum's. */
        const float *o = xyz + 3 * (size_t)tris[0];
        double m = 12.0 * (double)nt;
        for (int a = 0; a < 3; a++) {
            double lo = (double)o[a] - r->bbox_min[a], hi = r->bbox_max[a] - (double)o[a];
            m *= lo > hi ? lo : hi;
        }
        vol->vol6 = vol6;
        vol->perm_bound = m;
    }
    return rc;
}
