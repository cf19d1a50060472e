/* SPDX-License-Identifier: Apache-2.0 */
/* Winding preparation, steps 3 and 4 (winding_prep.c): the edges bucketed
 * by their smaller vertex, orientation patches by union-find with a parity
 * bit, each patch's boundary and signed volume. */
#include "winding_prep.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

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
clvox_status clvox__prep_build_edges(prep *P)
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
clvox_status clvox__prep_orient_patches(prep *P, uint64_t *nonmanifold, uint64_t *conflict_out)
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
    P->odelta = calloc(nc ? nc : 1, sizeof *P->odelta);
    P->nabs = calloc(nc ? nc : 1, sizeof *P->nabs);
    P->depth = calloc(nc ? nc : 1, sizeof *P->depth);
    if (!P->first || !P->pstate || !P->vol || !P->vabs || !P->org || !P->odelta || !P->nabs || !P->depth) goto nomem;
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
clvox_status clvox__prep_patch_boundaries(prep *P)
{
    uint64_t *scratch = NULL;
    size_t cap = 0;
    /* per patch: boundary endpoints (weighted), number of terms summed into
     * org, sum of the weighted endpoints' largest |coordinate| */
    size_t nc1 = P->ncomp ? P->ncomp : 1;
    double *ends = calloc(3 * nc1, sizeof *ends), *nterm = ends ? ends + nc1 : NULL, *sabs = ends ? ends + 2 * nc1 : NULL;
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
                double w = m > 0 ? m : -m, ml = 0, mh = 0;
                for (int a = 0; a < 3; a++) {
                    double xl = P->xyz[3 * (size_t)lo + a], xh = P->xyz[3 * (size_t)hi + a];
                    P->org[3 * pc + a] += w * (xl + xh);
                    ml = fmax(ml, fabs(xl));
                    mh = fmax(mh, fabs(xh));
                }
                ends[pc] += 2 * w;
                nterm[pc] += 1;
                sabs[pc] += w * (ml + mh);
            }
            k = j;
        }
    }
    free(scratch);
    /* Origins: centroid of the boundary endpoints (open), first vertex
     * (closed, exact). The open one's rounding: each term w (x_lo + x_hi)
     * takes 2 roundings, the n-term sum n - 1 more, the division 1, so
     * |org - exact| <= gamma_(n+3) x sum |terms| / ends (gamma_k = k u /
     * (1 - k u), u = 2^-53), and sum |terms| <= sabs; (n + 4) 2^-52
     * covers gamma_(n+3) and the rounding of this bound. */
    for (size_t c = 0; c < P->ncomp; c++) {
        if (P->pstate[c] & P_OPEN) {
            for (int a = 0; a < 3; a++) P->org[3 * c + a] /= ends[c];
            P->odelta[c] = (nterm[c] + 4.0) * 0x1p-52 * (sabs[c] / ends[c]);
        } else {
            const float *o = P->xyz + 3 * (size_t)P->tris[3 * (size_t)P->first[c]];
            for (int a = 0; a < 3; a++) P->org[3 * c + a] = o[a];
        }
    }
    free(ends);
    return CLVOX_OK;
}

/* 6 x the signed volume of every patch about its origin. */
void clvox__prep_patch_volumes(prep *P)
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
        if (P->odelta[c] > 0) { /* |2N|_1, 2N = (b - a) x (d - a), for the origin's rounding (volume_sign) */
            double u0 = (double)b[0] - a[0], u1 = (double)b[1] - a[1], u2 = (double)b[2] - a[2];
            double w0 = (double)d[0] - a[0], w1 = (double)d[1] - a[1], w2 = (double)d[2] - a[2];
            P->nabs[c] += fabs(u1 * w2 - u2 * w1) + fabs(u2 * w0 - u0 * w2) + fabs(u0 * w1 - u1 * w0);
        }
    }
}

/* The volume of a mesh that is one closed patch, about the first corner of
 * its first triangle (as the sum the mesh report made, mesh_report.c): when
 * the patch is the mesh's triangles as they are (no vertex merged, no
 * triangle flipped relative to the first) that sum is this one, term for
 * term; its sign is then taken as is when it lies beyond the tolerance of
 * the report's bound on the permanents (so beyond that of their sum, and
 * volume_sign decides as on the sum below). Else summed here. */
void clvox__prep_single_patch_volume(prep *P)
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
