/* SPDX-License-Identifier: Apache-2.0 */
/* Mesh report (build_mesh in mesh.c): the bounding box of the vertices in
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
 * tests/test_mesh_report.c compares the two on every mesh it can find. */
#include "mesh_internal.h"
#include "core/parallel.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- shared helpers -------------------------------------------------------------- */

/* 64-bit finaliser (MurmurHash3 fmix64): the slot comes from the low bits,
 * a 32-bit tag from the high bits. */
static uint64_t mix64(uint64_t h)
{
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ull;
    h ^= h >> 33;
    return h;
}

static uint64_t hash3(uint32_t a, uint32_t b, uint32_t c)
{
    return mix64(((uint64_t)a << 32 | b) * 0x9e3779b97f4a7c15ull ^ (uint64_t)c * 0xbf58476d1ce4e5b9ull);
}

static uint32_t float_key(float f)
{
    uint32_t u;
    if (f == 0.0f) f = 0.0f; /* -0 and +0 are the same position */
    memcpy(&u, &f, sizeof u);
    return u;
}

/* Open-addressing table of 2^k slots for n entries (load <= 0.8). */
static size_t table_size(size_t n)
{
    size_t t = 16;
    while (t < n + n / 4) t *= 2;
    return t;
}

/* Lexicographic order of two vertex positions (as float_key triples). */
static int pos_less(const uint32_t *a, const uint32_t *b)
{
    if (a[0] != b[0]) return a[0] < b[0];
    if (a[1] != b[1]) return a[1] < b[1];
    return a[2] < b[2];
}

/* The corner positions of triangle t, sorted: the duplicate key. */
static void sorted_corners(const float *xyz, const uint32_t *tris, size_t t, uint32_t k[3][3])
{
    for (int c = 0; c < 3; c++)
        for (int a = 0; a < 3; a++) k[c][a] = float_key(xyz[3 * (size_t)tris[3 * t + c] + a]);
    uint32_t s[3];
#define SWAP_IF(i, j) \
    if (pos_less(k[j], k[i])) memcpy(s, k[i], sizeof s), memcpy(k[i], k[j], sizeof s), memcpy(k[j], s, sizeof s)
    SWAP_IF(0, 1);
    SWAP_IF(1, 2);
    SWAP_IF(0, 1);
#undef SWAP_IF
}

/* ---- reference implementation ----------------------------------------------------- */

/* Box, degenerate triangles, volume, as one loop (apex at the first vertex
 * used: cancellation stays small far from the origin; the sum does not
 * depend on the apex when the mesh is closed). */
static void ref_geometry(const float *xyz, const uint32_t *tris, size_t kept, clvox_mesh_report *r, double *vol6_out)
{
    const float *o = xyz + 3 * (size_t)tris[0];
    double apex[3] = {o[0], o[1], o[2]};
    for (int a = 0; a < 3; a++) r->bbox_min[a] = r->bbox_max[a] = apex[a];
    double vol6 = 0.0;
    for (size_t t = 0; t < kept; t++) {
        double q[3][3];
        for (int c = 0; c < 3; c++) {
            const float *p = xyz + 3 * (size_t)tris[3 * t + c];
            for (int a = 0; a < 3; a++) {
                q[c][a] = p[a];
                if (q[c][a] < r->bbox_min[a]) r->bbox_min[a] = q[c][a];
                if (q[c][a] > r->bbox_max[a]) r->bbox_max[a] = q[c][a];
            }
        }
        double e1[3], e2[3], cr[3];
        for (int a = 0; a < 3; a++) e1[a] = q[1][a] - q[0][a], e2[a] = q[2][a] - q[0][a];
        cr[0] = e1[1] * e2[2] - e1[2] * e2[1];
        cr[1] = e1[2] * e2[0] - e1[0] * e2[2];
        cr[2] = e1[0] * e2[1] - e1[1] * e2[0];
        if (cr[0] == 0.0 && cr[1] == 0.0 && cr[2] == 0.0) r->degenerate_triangles++;
        /* (a-o) . ((b-o) x (c-o)) */
        double A[3], B[3], C[3];
        for (int a = 0; a < 3; a++) A[a] = q[0][a] - apex[a], B[a] = q[1][a] - apex[a], C[a] = q[2][a] - apex[a];
        vol6 += A[0] * (B[1] * C[2] - B[2] * C[1]) + A[1] * (B[2] * C[0] - B[0] * C[2]) +
                A[2] * (B[0] * C[1] - B[1] * C[0]);
    }
    r->enclosed_volume = fabs(vol6) / 6.0;
    *vol6_out = vol6;
}


/* Boundary edges (used by an odd number of triangles) and non-manifold
 * triangles. Edges are bucketed by their smaller vertex (counting sort, O(T))
 * and each bucket sorted by (other vertex, use index), so the uses of one
 * edge are adjacent and in input order.
 *
 * Non-manifold counts what OpenMesh calls a "complex edge" (it then re-adds
 * the face with duplicated vertices): taking triangles in input order, one is
 * rejected when an edge it uses is already used in the same direction, or
 * twice, by triangles accepted before it; rejected triangles use nothing.
 * Only edges with more than two uses or two uses in the same direction can
 * reject anything, so just the triangles on such edges are replayed.
 * (OpenMesh also rejects some faces at non-manifold vertices: not counted.)
 * Returns -1 when memory runs out. */
static int ref_edge_analysis(const uint32_t *tris, size_t nt, size_t nv, uint64_t *boundary, uint64_t *nonmanifold)
{
    size_t ne = 3 * nt; /* <= UINT32_MAX, checked by the caller */
    uint32_t *start = calloc(nv + 1, sizeof *start);
    uint64_t *entry = malloc(ne * sizeof *entry);
    uint64_t *cx = NULL;      /* uses of complex edges: tri << 33 | group << 1 | dir */
    size_t ncx = 0, cap = 0;
    unsigned char *gstate = NULL;
    int rc = -1;
    if (!start || !entry) goto done;
#define OTHER(i) tris[(i) % 3 == 2 ? (i) - 2 : (i) + 1]
    for (size_t i = 0; i < ne; i++) {
        uint32_t a = tris[i], b = OTHER(i);
        start[a < b ? a : b]++;
    }
    uint32_t sum = 0;
    for (size_t v = 0; v <= nv; v++) {
        uint32_t c = start[v];
        start[v] = sum;
        sum += c;
    }
    /* start[v] runs ahead as the fill cursor: afterwards bucket v is
     * [start[v-1], start[v]) with start[-1] = 0. */
    for (size_t i = 0; i < ne; i++) {
        uint32_t a = tris[i], b = OTHER(i);
        uint32_t lo = a < b ? a : b, hi = a < b ? b : a;
        entry[start[lo]++] = (uint64_t)hi << 32 | (uint64_t)i;
    }
    uint64_t nb = 0, groups = 0;
    size_t begin = 0;
    for (size_t v = 0; v < nv; v++) {
        size_t end = start[v], len = end - begin;
        if (len > 1) {
            if (len <= 24) clvox__sort_u64_small(entry + begin, len);
            else qsort(entry + begin, len, sizeof *entry, clvox__cmp_u64);
        }
        for (size_t i = begin; i < end;) {
            size_t j = i + 1;
            while (j < end && entry[j] >> 32 == entry[i] >> 32) j++;
            size_t uses = j - i;
            nb += uses & 1;
            int complex = uses > 2;
            if (uses == 2) {
                size_t u0 = (uint32_t)entry[i], u1 = (uint32_t)entry[i + 1];
                complex = (tris[u0] > OTHER(u0)) == (tris[u1] > OTHER(u1));
            }
            if (complex) {
                if (ncx + uses > cap) {
                    cap = (ncx + uses) * 2 + 64;
                    uint64_t *grown = realloc(cx, cap * sizeof *cx);
                    if (!grown) goto done;
                    cx = grown;
                }
                for (size_t q = i; q < j; q++) {
                    size_t u = (uint32_t)entry[q];
                    cx[ncx++] = (uint64_t)(u / 3) << 33 | groups << 1 | (uint64_t)(tris[u] > OTHER(u));
                }
                groups++;
            }
            i = j;
        }
        begin = end;
    }
#undef OTHER
    free(entry);
    entry = NULL;
    free(start);
    start = NULL;

    uint64_t nm = 0;
    if (ncx) {
        /* Replay in triangle order. State per complex edge: bit 0/1 = used in
         * direction 0/1, bits 2-3 = number of uses (saturating at 2). */
        qsort(cx, ncx, sizeof *cx, clvox__cmp_u64);
        gstate = calloc(groups, 1);
        if (!gstate) goto done;
        for (size_t i = 0; i < ncx;) {
            size_t j = i;
            int reject = 0;
            for (; j < ncx && cx[j] >> 33 == cx[i] >> 33; j++) {
                unsigned char s = gstate[(cx[j] >> 1) & 0xFFFFFFFFu];
                if ((s >> 2) >= 2 || (s >> (cx[j] & 1) & 1)) reject = 1;
            }
            if (reject) {
                nm++;
            } else {
                for (size_t q = i; q < j; q++) {
                    unsigned char *s = &gstate[(cx[q] >> 1) & 0xFFFFFFFFu];
                    *s = (unsigned char)((*s | 1u << (cx[q] & 1)) + 4);
                }
            }
            i = j;
        }
    }
    *boundary = nb;
    *nonmanifold = nm;
    rc = 0;
done:
    free(start);
    free(entry);
    free(cx);
    free(gstate);
    return rc;
}

/* Duplicate triangles: triangles whose three corner positions (in any order
 * or orientation) are those of an earlier triangle, whether they share its
 * vertices or repeat them. Each vertex gets a hash of its exact position; a
 * triangle's hash is the mixed sum of its corners' (order does not matter),
 * looked up in an open-addressing set of 8-byte slots (32-bit hash tag,
 * index + 1); only a tag match compares the sorted corner positions.
 * O(V + T) expected, one random access per triangle, prefetched in blocks.
 * Copies of one triangle are never inserted, so they do not cluster.
 * Returns -1 when memory runs out. */
static int ref_duplicate_analysis(const float *xyz, size_t nv, const uint32_t *tris, size_t nt, uint64_t *duplicates)
{
    size_t ts = table_size(nt), mask = ts - 1;
    uint64_t *vh = malloc((nv ? nv : 1) * sizeof *vh);
    uint64_t *slot = calloc(ts, sizeof *slot);
    int rc = -1;
    if (!vh || !slot) goto done;
    for (size_t v = 0; v < nv; v++) {
        const float *p = xyz + 3 * v;
        vh[v] = hash3(float_key(p[0]), float_key(p[1]), float_key(p[2]));
    }
    enum { BLOCK = 64 };
    uint64_t h[BLOCK], dup = 0;
    for (size_t t0 = 0; t0 < nt; t0 += BLOCK) {
        size_t nb = nt - t0 < BLOCK ? nt - t0 : BLOCK;
        for (size_t j = 0; j < nb; j++) {
            const uint32_t *u = tris + 3 * (t0 + j);
            h[j] = mix64(vh[u[0]] + vh[u[1]] + vh[u[2]]);
#if defined(__GNUC__)
            __builtin_prefetch(&slot[(size_t)h[j] & mask], 1);
#endif
        }
        for (size_t j = 0; j < nb; j++) {
            size_t t = t0 + j;
            uint64_t tag = h[j] >> 32;
            int have_key = 0;
            uint32_t k[3][3], q[3][3];
            for (size_t i = (size_t)h[j] & mask;; i = (i + 1) & mask) {
                if (!slot[i]) {
                    slot[i] = tag << 32 | (uint64_t)(t + 1);
                    break;
                }
                if (slot[i] >> 32 != tag) continue;
                if (!have_key) sorted_corners(xyz, tris, t, k), have_key = 1;
                sorted_corners(xyz, tris, (size_t)(uint32_t)slot[i] - 1, q);
                if (!memcmp(k, q, sizeof k)) {
                    dup++;
                    break;
                }
            }
        }
    }
    *duplicates = dup;
    rc = 0;
done:
    free(vh);
    free(slot);
    return rc;
}

static int analyze_reference(const float *xyz, size_t nv, const uint32_t *tris, size_t nt, clvox_mesh_report *r,
                             double *vol6)
{
    ref_geometry(xyz, tris, nt, r, vol6);
    if (ref_edge_analysis(tris, nt, nv, &r->boundary_edges, &r->nonmanifold_faces) != 0) return -1;
    if (ref_duplicate_analysis(xyz, nv, tris, nt, &r->duplicate_triangles) != 0) return -1;
    return 0;
}

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
        rc = analyze_reference(xyz, nv, tris, nt, r, &vol6);
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
