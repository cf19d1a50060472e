/* SPDX-License-Identifier: Apache-2.0 */
/*
 * The exact geometry of a palette element as triangle meshes (unit-voxel
 * coordinates). Element semantics: kernels/palette.h; design:
 * docs/design.md "Element geometry and mesh export".
 *
 * Decomposition into disjoint convex pieces. An element is a union of
 * convex cells C_0 .. C_{n-1} (each an intersection of half-spaces
 * a.p <= d, clipped to the voxel V = [0,1]^3), optionally complemented in
 * V. The union is written as the disjoint pieces C_i \ (C_0 u .. u C_{i-1});
 * a complement is V \ (C_0 u .. u C_{n-1}). Subtracting a convex cell K with
 * planes k_1 .. k_m from a convex piece P keeps
 *     P n {k_1 >},  P n {k_1 <=} n {k_2 >},  ...,  P n {k_1 <=} .. n {k_{m-1} <=} n {k_m >}
 * and drops P n K (P is kept whole when it does not meet K). Only the
 * closures matter for a mesh: {k >} is taken as the closed half-space of the
 * opposite plane, so neighbouring pieces share faces. Pieces of volume below
 * MIN_VOLUME are dropped.
 *
 * Convex pieces. A piece is built from the cube's six face polygons by
 * clipping with each of its planes in turn (Sutherland-Hodgman per face, and
 * a cap polygon on the cutting plane: the points on the plane sorted by
 * angle around their centroid, counter-clockwise seen from outside). All in
 * double. A point is on a plane when |a.p - d| <= EPS_ON |a|; a plane that
 * leaves no point strictly outside does not cut (the piece is kept), one
 * that leaves none strictly inside empties it. An edge crossing the plane is
 * cut at p + t (q - p), t = s_p / (s_p - s_q), always from its inside end p,
 * so the two faces sharing the edge compute the same point bit for bit.
 *
 * Mesh of a piece. Its points are merged (within EPS_MERGE, max norm), each
 * face becomes a cycle of vertex indices (repeats removed, fewer than three
 * dropped) and is fanned into triangles; every face is convex, so the fan is
 * too. Each piece is checked to be closed and consistently oriented (every
 * directed edge has its reverse in the same piece, as often) and of
 * positive volume; a piece that is not fails with CLVOX_ERR_INTERNAL (the
 * plane arrangement was too degenerate for the tolerances).
 *
 * The union of the pieces is "closed shells that touch": a shared face
 * appears once in each piece with opposite orientations, so a ray crossing
 * it crosses twice (parity unchanged) and winding numbers add up to 1 inside
 * the element, 0 outside.
 */
#include "core/internal.h"
#include "element_mesh.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define EPS_ON 1e-9      /* on-plane tolerance, times |a| */
#define EPS_MERGE 1e-10  /* vertex merge tolerance, max norm */
#define MIN_VOLUME 1e-15 /* pieces below this (fraction of the voxel) are dropped */

/* ---- convex polytopes as face polygons ---- */

typedef struct face {
    size_t first, count; /* points [first, first + count) of the polytope, counter-clockwise from outside */
} face;

typedef struct ptope {
    double (*pt)[3];
    size_t npt, ptcap;
    face *f;
    size_t nf, fcap;
} ptope;

static void ptope_free(ptope *p)
{
    free(p->pt);
    free(p->f);
    memset(p, 0, sizeof *p);
}

static int pt_push(ptope *p, const double q[3])
{
    if (p->npt == p->ptcap) {
        size_t n = p->ptcap ? 2 * p->ptcap : 64;
        double(*g)[3] = realloc(p->pt, n * sizeof *g);
        if (!g) return -1;
        p->pt = g;
        p->ptcap = n;
    }
    memcpy(p->pt[p->npt++], q, sizeof(double[3]));
    return 0;
}

/* Closes the face begun at point `first`: kept when it has 3 points or more. */
static int face_close(ptope *p, size_t first, int keep)
{
    size_t count = p->npt - first;
    if (!keep || count < 3) {
        p->npt = first;
        return 0;
    }
    if (p->nf == p->fcap) {
        size_t n = p->fcap ? 2 * p->fcap : 16;
        face *g = realloc(p->f, n * sizeof *g);
        if (!g) return -1;
        p->f = g;
        p->fcap = n;
    }
    p->f[p->nf].first = first;
    p->f[p->nf].count = count;
    p->nf++;
    return 0;
}

static int ptope_copy(const ptope *in, ptope *out)
{
    out->npt = out->nf = 0;
    for (size_t i = 0; i < in->nf; i++) {
        size_t first = out->npt;
        for (size_t k = 0; k < in->f[i].count; k++)
            if (pt_push(out, in->pt[in->f[i].first + k]) != 0) return -1;
        if (face_close(out, first, 1) != 0) return -1;
    }
    return 0;
}

static int ptope_cube(ptope *p)
{
    static const unsigned char corner[6][4] = {
        {0, 4, 6, 2}, /* x = 0 */
        {1, 3, 7, 5}, /* x = 1 */
        {0, 1, 5, 4}, /* y = 0 */
        {2, 6, 7, 3}, /* y = 1 */
        {0, 2, 3, 1}, /* z = 0 */
        {4, 5, 7, 6}, /* z = 1 */
    };                /* corner c = x + 2y + 4z; each face counter-clockwise seen from outside */
    p->npt = p->nf = 0;
    for (int f = 0; f < 6; f++) {
        size_t first = p->npt;
        for (int k = 0; k < 4; k++) {
            unsigned c = corner[f][k];
            double q[3] = {(double)(c & 1u), (double)((c >> 1) & 1u), (double)((c >> 2) & 1u)};
            if (pt_push(p, q) != 0) return -1;
        }
        if (face_close(p, first, 1) != 0) return -1;
    }
    return 0;
}

static double ptope_volume(const ptope *p)
{
    if (!p->nf) return 0.0;
    const double *r = p->pt[p->f[0].first];
    double v = 0;
    for (size_t i = 0; i < p->nf; i++) {
        const face *f = &p->f[i];
        const double *a = p->pt[f->first];
        for (size_t k = 1; k + 1 < f->count; k++) {
            const double *b = p->pt[f->first + k], *c = p->pt[f->first + k + 1];
            double u[3] = {a[0] - r[0], a[1] - r[1], a[2] - r[2]};
            double s[3] = {b[0] - r[0], b[1] - r[1], b[2] - r[2]};
            double t[3] = {c[0] - r[0], c[1] - r[1], c[2] - r[2]};
            v += u[0] * (s[1] * t[2] - s[2] * t[1]) + u[1] * (s[2] * t[0] - s[0] * t[2]) +
                 u[2] * (s[0] * t[1] - s[1] * t[0]);
        }
    }
    return v / 6.0;
}

static double plane_value(const double pl[4], const double q[3])
{
    return pl[0] * q[0] + pl[1] * q[1] + pl[2] * q[2] - pl[3];
}

/* The point where edge (in, out) meets the plane; s_in < 0 < s_out. */
static void cut_point(const double in[3], double s_in, const double out[3], double s_out, double x[3])
{
    double t = s_in / (s_in - s_out);
    for (int k = 0; k < 3; k++) x[k] = in[k] + t * (out[k] - in[k]);
}

static int near_point(const double a[3], const double b[3])
{
    return fabs(a[0] - b[0]) <= EPS_MERGE && fabs(a[1] - b[1]) <= EPS_MERGE && fabs(a[2] - b[2]) <= EPS_MERGE;
}

/* Appends the cap on plane pl (outward normal (pl[0], pl[1], pl[2])) from
 * the points cap[0 .. n): duplicates merged, sorted by angle. */
static int add_cap(ptope *out, double (*cap)[3], size_t n, const double pl[4])
{
    size_t m = 0;
    for (size_t i = 0; i < n; i++) {
        size_t j = 0;
        while (j < m && !near_point(cap[j], cap[i])) j++;
        if (j == m) memmove(cap[m++], cap[i], sizeof cap[i]);
    }
    if (m < 3) return 0;
    double c[3] = {0, 0, 0};
    for (size_t i = 0; i < m; i++)
        for (int k = 0; k < 3; k++) c[k] += cap[i][k] / (double)m;
    double len = sqrt(pl[0] * pl[0] + pl[1] * pl[1] + pl[2] * pl[2]);
    double nrm[3] = {pl[0] / len, pl[1] / len, pl[2] / len};
    /* u: perpendicular to the normal, from the axis least aligned with it; v = n x u */
    int ax = fabs(nrm[0]) <= fabs(nrm[1]) ? (fabs(nrm[0]) <= fabs(nrm[2]) ? 0 : 2) : (fabs(nrm[1]) <= fabs(nrm[2]) ? 1 : 2);
    double e[3] = {0, 0, 0};
    e[ax] = 1;
    double u[3] = {nrm[1] * e[2] - nrm[2] * e[1], nrm[2] * e[0] - nrm[0] * e[2], nrm[0] * e[1] - nrm[1] * e[0]};
    double v[3] = {nrm[1] * u[2] - nrm[2] * u[1], nrm[2] * u[0] - nrm[0] * u[2], nrm[0] * u[1] - nrm[1] * u[0]};
    double ang[64], *heap = NULL, *a = ang;
    if (m > 64) {
        heap = malloc(m * sizeof *heap);
        if (!heap) return -1;
        a = heap;
    }
    for (size_t i = 0; i < m; i++) {
        double d[3] = {cap[i][0] - c[0], cap[i][1] - c[1], cap[i][2] - c[2]};
        a[i] = atan2(d[0] * v[0] + d[1] * v[1] + d[2] * v[2], d[0] * u[0] + d[1] * u[1] + d[2] * u[2]);
    }
    for (size_t i = 1; i < m; i++) { /* insertion sort by angle, points along */
        double ai = a[i], pi[3];
        memcpy(pi, cap[i], sizeof pi);
        size_t j = i;
        for (; j > 0 && a[j - 1] > ai; j--) {
            a[j] = a[j - 1];
            memcpy(cap[j], cap[j - 1], sizeof cap[j]);
        }
        a[j] = ai;
        memcpy(cap[j], pi, sizeof pi);
    }
    free(heap);
    size_t first = out->npt;
    for (size_t i = 0; i < m; i++)
        if (pt_push(out, cap[i]) != 0) return -1;
    return face_close(out, first, 1);
}

/* out = in n {pl . p <= pl[3]} (out->nf == 0: empty). 0, or -1 out of memory. */
static int ptope_clip(const ptope *in, const double pl[4], ptope *out)
{
    out->npt = out->nf = 0;
    double tol = EPS_ON * sqrt(pl[0] * pl[0] + pl[1] * pl[1] + pl[2] * pl[2]);
    double smin = INFINITY, smax = -INFINITY;
    for (size_t i = 0; i < in->npt; i++) {
        double s = plane_value(pl, in->pt[i]);
        smin = fmin(smin, s);
        smax = fmax(smax, s);
    }
    if (in->nf == 0 || smin >= -tol) return 0; /* nothing strictly inside: empty */
    if (smax <= tol) return ptope_copy(in, out); /* nothing strictly outside: not cut */
    double(*cap)[3] = NULL;
    size_t ncap = 0, capcap = 0;
#define CAP_PUSH(q)                                                        \
    do {                                                                   \
        if (ncap == capcap) {                                              \
            size_t n_ = capcap ? 2 * capcap : 32;                          \
            double(*g_)[3] = realloc(cap, n_ * sizeof *g_);                \
            if (!g_) goto oom;                                             \
            cap = g_;                                                      \
            capcap = n_;                                                   \
        }                                                                  \
        memcpy(cap[ncap++], (q), sizeof(double[3]));                       \
    } while (0)
    for (size_t fi = 0; fi < in->nf; fi++) {
        const face *f = &in->f[fi];
        size_t first = out->npt;
        int all_on = 1;
        for (size_t i = 0; i < f->count; i++) {
            const double *p = in->pt[f->first + i], *q = in->pt[f->first + (i + 1) % f->count];
            double sp = plane_value(pl, p), sq = plane_value(pl, q), x[3];
            if (sp <= tol) {
                if (pt_push(out, p) != 0) goto oom;
                if (sp >= -tol) CAP_PUSH(p);
                else all_on = 0;
                if (sp < -tol && sq > tol) {
                    cut_point(p, sp, q, sq, x);
                    if (pt_push(out, x) != 0) goto oom;
                    CAP_PUSH(x);
                }
            } else if (sq < -tol) {
                cut_point(q, sq, p, sp, x);
                if (pt_push(out, x) != 0) goto oom;
                CAP_PUSH(x);
            }
        }
        /* a face left with its points on the plane only is a segment or a point there */
        if (face_close(out, first, !all_on) != 0) goto oom;
    }
#undef CAP_PUSH
    if (add_cap(out, cap, ncap, pl) != 0) goto oom;
    free(cap);
    return 0;
oom:
    free(cap);
    return -1;
}

/* ---- pieces ---- */

typedef struct plist {
    ptope *p;
    size_t n, cap;
} plist;

static void plist_free(plist *l)
{
    for (size_t i = 0; i < l->n; i++) ptope_free(&l->p[i]);
    free(l->p);
    memset(l, 0, sizeof *l);
}

/* Moves *p into the list (p is left empty). */
static int plist_take(plist *l, ptope *p)
{
    if (l->n == l->cap) {
        size_t n = l->cap ? 2 * l->cap : 8;
        ptope *g = realloc(l->p, n * sizeof *g);
        if (!g) return -1;
        l->p = g;
        l->cap = n;
    }
    l->p[l->n++] = *p;
    memset(p, 0, sizeof *p);
    return 0;
}

typedef struct builder {
    clvox_context *ctx;
    const clvox_halfspace *planes;
    size_t max_pieces;
    const char *name;
    size_t index;
} builder;

static void plane_of(const clvox_halfspace *h, int flip, double pl[4])
{
    double s = flip ? -1.0 : 1.0;
    pl[0] = s * (double)h->a;
    pl[1] = s * (double)h->b;
    pl[2] = s * (double)h->c;
    pl[3] = s * (double)h->d;
}

static clvox_status oom(builder *b)
{
    return clvox__fail(b->ctx, CLVOX_ERR_OUT_OF_MEMORY, "element mesh: out of memory");
}

static int big_enough(const ptope *p) { return p->nf > 0 && ptope_volume(p) >= MIN_VOLUME; }

/* Clips *p by the planes of cell c in place (p->nf == 0 afterwards: empty). */
static int clip_cell(builder *b, const clvox_cell *c, ptope *p, ptope *tmp)
{
    for (uint32_t k = 0; k < c->plane_count && p->nf; k++) {
        double pl[4];
        plane_of(&b->planes[c->first_plane + k], 0, pl);
        if (ptope_clip(p, pl, tmp) != 0) return -1;
        ptope t = *p;
        *p = *tmp;
        *tmp = t;
    }
    if (p->nf && !big_enough(p)) p->nf = 0;
    return 0;
}

/* Appends P \ K to out (K = cell c) and consumes *P. */
static clvox_status subtract(builder *b, ptope *P, const clvox_cell *c, plist *out)
{
    ptope meet = {0}, rest = {0}, tmp = {0}, part = {0};
    clvox_status st = CLVOX_OK;
    if (ptope_copy(P, &meet) != 0 || clip_cell(b, c, &meet, &tmp) != 0) {
        st = oom(b);
        goto done;
    }
    if (!meet.nf) { /* P does not meet K: kept whole */
        if (plist_take(out, P) != 0) st = oom(b);
        goto done;
    }
    ptope_free(&meet);
    rest = *P;
    memset(P, 0, sizeof *P);
    for (uint32_t k = 0; k < c->plane_count && rest.nf; k++) {
        double pl[4], op[4];
        plane_of(&b->planes[c->first_plane + k], 0, pl);
        plane_of(&b->planes[c->first_plane + k], 1, op);
        if (ptope_clip(&rest, op, &part) != 0) {
            st = oom(b);
            goto done;
        }
        if (big_enough(&part) && plist_take(out, &part) != 0) {
            st = oom(b);
            goto done;
        }
        if (ptope_clip(&rest, pl, &tmp) != 0) {
            st = oom(b);
            goto done;
        }
        ptope t = rest;
        rest = tmp;
        tmp = t;
        if (rest.nf && !big_enough(&rest)) rest.nf = 0;
    }
    if (out->n > b->max_pieces)
        st = clvox__fail(b->ctx, CLVOX_ERR_INVALID_ARGUMENT,
                         "element %zu '%s' decomposes into more than %zu convex pieces: too complex for a mesh",
                         b->index, b->name, b->max_pieces);
done:
    ptope_free(&meet);
    ptope_free(&rest);
    ptope_free(&tmp);
    ptope_free(&part);
    ptope_free(P);
    return st;
}

/* *frags = union over f of f \ K; consumes the old list. */
static clvox_status subtract_all(builder *b, plist *frags, const clvox_cell *c)
{
    plist next = {0};
    clvox_status st = CLVOX_OK;
    for (size_t i = 0; i < frags->n && st == CLVOX_OK; i++) st = subtract(b, &frags->p[i], c, &next);
    plist_free(frags);
    *frags = next;
    return st;
}

/* ---- meshes ---- */

static int grow_mesh(clvox__element_mesh *m, size_t *vcap, size_t *tcap, size_t nv, size_t nt)
{
    if (m->vertex_count + nv > *vcap) {
        size_t n = *vcap ? *vcap : 64;
        while (n < m->vertex_count + nv) n *= 2;
        double *g = realloc(m->xyz, 3 * n * sizeof *g);
        if (!g) return -1;
        m->xyz = g;
        *vcap = n;
    }
    if (m->triangle_count + nt > *tcap) {
        size_t n = *tcap ? *tcap : 64;
        while (n < m->triangle_count + nt) n *= 2;
        uint32_t *g = realloc(m->tris, 3 * n * sizeof *g);
        if (!g) return -1;
        m->tris = g;
        *tcap = n;
    }
    return 0;
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* 1 when every directed edge of triangles [t0, t1) has its reverse as often. */
static int closed_oriented(const uint32_t *tris, size_t t0, size_t t1, uint64_t *edges)
{
    size_t n = 0;
    for (size_t t = t0; t < t1; t++)
        for (int k = 0; k < 3; k++) edges[n++] = (uint64_t)tris[3 * t + k] << 32 | tris[3 * t + (k + 1) % 3];
    qsort(edges, n, sizeof *edges, cmp_u64);
    for (size_t i = 0; i < n;) {
        size_t j = i;
        while (j < n && edges[j] == edges[i]) j++;
        uint64_t rev = (edges[i] & 0xFFFFFFFFu) << 32 | edges[i] >> 32;
        size_t lo = 0, hi = n; /* first >= rev */
        while (lo < hi) {
            size_t mid = lo + (hi - lo) / 2;
            if (edges[mid] < rev) lo = mid + 1;
            else hi = mid;
        }
        size_t r = lo;
        while (r < n && edges[r] == rev) r++;
        if (r - lo != j - i) return 0;
        i = j;
    }
    return 1;
}

/* Appends piece p to the mesh (merged vertices, fanned faces) and checks it. */
static clvox_status add_piece(builder *b, const ptope *p, clvox__element_mesh *m, size_t *vcap, size_t *tcap,
                              size_t pieces_cap)
{
    size_t *map = malloc((p->npt ? p->npt : 1) * sizeof *map);
    size_t tri_bound = 0;
    for (size_t i = 0; i < p->nf; i++) tri_bound += p->f[i].count - 2;
    uint64_t *edges = malloc((3 * tri_bound + 1) * sizeof *edges);
    uint32_t *cyc = malloc((p->npt ? p->npt : 1) * sizeof *cyc);
    clvox_status st = CLVOX_OK;
    if (!map || !edges || !cyc || grow_mesh(m, vcap, tcap, p->npt, tri_bound) != 0) {
        st = oom(b);
        goto done;
    }
    size_t v0 = m->vertex_count, t0 = m->triangle_count;
    if (v0 + p->npt > UINT32_MAX) {
        st = clvox__fail(b->ctx, CLVOX_ERR_INVALID_ARGUMENT, "element %zu '%s': too many vertices", b->index, b->name);
        goto done;
    }
    for (size_t i = 0; i < p->npt; i++) {
        size_t j = v0;
        while (j < m->vertex_count && !near_point(&m->xyz[3 * j], p->pt[i])) j++;
        if (j == m->vertex_count) {
            for (int k = 0; k < 3; k++) {
                double c = p->pt[i][k];
                m->xyz[3 * j + k] = c < 0 ? 0 : c > 1 ? 1 : c;
            }
            m->vertex_count++;
        }
        map[i] = j;
    }
    for (size_t i = 0; i < p->nf; i++) {
        const face *f = &p->f[i];
        size_t n = 0;
        for (size_t k = 0; k < f->count; k++) {
            uint32_t v = (uint32_t)map[f->first + k];
            if (n == 0 || cyc[n - 1] != v) cyc[n++] = v;
        }
        while (n > 1 && cyc[n - 1] == cyc[0]) n--;
        for (size_t k = 1; k + 1 < n; k++) {
            uint32_t *t = &m->tris[3 * m->triangle_count++];
            t[0] = cyc[0];
            t[1] = cyc[k];
            t[2] = cyc[k + 1];
        }
    }
    double vol = 0;
    {
        const double *r = &m->xyz[3 * v0];
        for (size_t t = t0; t < m->triangle_count; t++) {
            const double *a = &m->xyz[3 * m->tris[3 * t]], *bb = &m->xyz[3 * m->tris[3 * t + 1]],
                         *c = &m->xyz[3 * m->tris[3 * t + 2]];
            double u[3] = {a[0] - r[0], a[1] - r[1], a[2] - r[2]};
            double s[3] = {bb[0] - r[0], bb[1] - r[1], bb[2] - r[2]};
            double w[3] = {c[0] - r[0], c[1] - r[1], c[2] - r[2]};
            vol += (u[0] * (s[1] * w[2] - s[2] * w[1]) + u[1] * (s[2] * w[0] - s[0] * w[2]) +
                    u[2] * (s[0] * w[1] - s[1] * w[0])) / 6.0;
        }
    }
    if (!closed_oriented(m->tris, t0, m->triangle_count, edges) || !(vol > 0)) {
        st = clvox__fail(b->ctx, CLVOX_ERR_INTERNAL,
                         "element %zu '%s': convex piece %zu is not a closed, outward surface (volume %.3g): its planes "
                         "are too degenerate for the mesh tolerances",
                         b->index, b->name, m->piece_count, vol);
        goto done;
    }
    if (m->piece_count >= pieces_cap) {
        st = clvox__fail(b->ctx, CLVOX_ERR_INTERNAL, "element mesh: piece table overflow");
        goto done;
    }
    m->volume += vol;
    m->piece_count++;
    m->piece_vertex[m->piece_count] = m->vertex_count;
    m->piece_triangle[m->piece_count] = m->triangle_count;
done:
    free(map);
    free(edges);
    free(cyc);
    return st;
}

void clvox__element_mesh_free(clvox__element_mesh *m)
{
    if (!m) return;
    free(m->xyz);
    free(m->tris);
    free(m->piece_vertex);
    free(m->piece_triangle);
    memset(m, 0, sizeof *m);
}

clvox_status clvox__element_mesh_build(clvox_context *ctx, const clvox_palette *palette, size_t index,
                                       clvox__element_mesh *out)
{
    if (!out) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox__element_mesh_build: out is NULL");
    memset(out, 0, sizeof *out);
    if (!palette) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox__element_mesh_build: palette is NULL");
    clvox_palette_element_info info = CLVOX_PALETTE_ELEMENT_INFO_INIT;
    clvox_status st = clvox_palette_element_info_get(ctx, palette, index, &info);
    if (st != CLVOX_OK) return st;
    const clvox_element *els;
    const clvox_cell *cells;
    const clvox_halfspace *planes;
    size_t ne, nc, np;
    clvox__palette_arrays(palette, &els, &ne, &cells, &nc, &planes, &np);
    const clvox_element *e = &els[index];
    builder b = {ctx, planes, CLVOX__ELEMENT_MAX_PIECES, info.name, index};

    plist pieces = {0}, frags = {0};
    ptope work = {0}, tmp = {0};
    if (e->complement) {
        if (ptope_cube(&work) != 0 || plist_take(&frags, &work) != 0) st = oom(&b);
        for (uint32_t j = 0; j < e->cell_count && st == CLVOX_OK; j++)
            st = subtract_all(&b, &frags, &cells[e->first_cell + j]);
        if (st == CLVOX_OK) {
            pieces = frags;
            memset(&frags, 0, sizeof frags);
        }
    } else {
        for (uint32_t i = 0; i < e->cell_count && st == CLVOX_OK; i++) {
            if (ptope_cube(&work) != 0 || clip_cell(&b, &cells[e->first_cell + i], &work, &tmp) != 0) {
                st = oom(&b);
                break;
            }
            if (!work.nf) continue;
            if (plist_take(&frags, &work) != 0) {
                st = oom(&b);
                break;
            }
            for (uint32_t j = 0; j < i && st == CLVOX_OK && frags.n; j++)
                st = subtract_all(&b, &frags, &cells[e->first_cell + j]);
            for (size_t k = 0; k < frags.n && st == CLVOX_OK; k++)
                if (plist_take(&pieces, &frags.p[k]) != 0) st = oom(&b);
            plist_free(&frags);
            if (st == CLVOX_OK && pieces.n > b.max_pieces)
                st = clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT,
                                 "element %zu '%s' decomposes into more than %zu convex pieces: too complex for a mesh",
                                 index, info.name, b.max_pieces);
        }
    }
    if (st == CLVOX_OK) {
        out->piece_vertex = calloc(pieces.n + 1, sizeof *out->piece_vertex);
        out->piece_triangle = calloc(pieces.n + 1, sizeof *out->piece_triangle);
        if (!out->piece_vertex || !out->piece_triangle) st = oom(&b);
    }
    size_t vcap = 0, tcap = 0;
    for (size_t k = 0; k < pieces.n && st == CLVOX_OK; k++) st = add_piece(&b, &pieces.p[k], out, &vcap, &tcap, pieces.n);
    plist_free(&pieces);
    plist_free(&frags);
    ptope_free(&work);
    ptope_free(&tmp);
    if (st != CLVOX_OK) clvox__element_mesh_free(out);
    return st;
}
