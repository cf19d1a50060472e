/* SPDX-License-Identifier: Apache-2.0 */
/* The mesh report in one thread (the reference): per-vertex buckets of
 * edges (counting sort, then a sort per bucket) and one hash set of
 * triangles over the whole mesh. It was the only implementation before the
 * bucketed passes of mesh_report.c, which give the same results bit for bit;
 * it stays for the meshes whose vertex indices do not fit those passes'
 * edge buckets (more than 2^25 vertices) and as the reference that
 * tests/test_mesh_report.c compares them with. */
#include "mesh_report.h"

#include <math.h>
#include <stdlib.h>

/* Open-addressing table of 2^k slots for n entries (load <= 0.8). */
static size_t table_size(size_t n)
{
    size_t t = 16;
    while (t < n + n / 4) t *= 2;
    return t;
}

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

int clvox__mesh_analyze_serial(const float *xyz, size_t nv, const uint32_t *tris, size_t nt, clvox_mesh_report *r,
                               double *vol6)
{
    ref_geometry(xyz, tris, nt, r, vol6);
    if (ref_edge_analysis(tris, nt, nv, &r->boundary_edges, &r->nonmanifold_faces) != 0) return -1;
    if (ref_duplicate_analysis(xyz, nv, tris, nt, &r->duplicate_triangles) != 0) return -1;
    return 0;
}
