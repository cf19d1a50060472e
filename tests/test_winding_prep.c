/* SPDX-License-Identifier: Apache-2.0 */
/* Past 800 lines on purpose: one test program per stage: each preparation
 * step's cases share the generated meshes. */
/* Mesh preparation for the winding inside test (src/winding/winding_prep.c):
 * merging, welding, orientation repair, patch signs with nesting (cavities),
 * boundary loops and caps. Host only; also times the 3.3 M-triangle
 * armadillo (printed, not asserted). */
#include "test.h"
#include "meshgen.h"
#include "core/internal.h"
#include "winding/winding.h"

#include <math.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>

static clvox_context *ctx;

typedef struct prepared {
    clvox_mesh *mesh;
    clvox__winding_mesh w;
    clvox_status st;
} prepared;

static prepared prep_tmesh(const tmesh *m, double weld)
{
    prepared p;
    memset(&p, 0, sizeof p);
    clvox_status st = clvox_mesh_from_arrays(ctx, m->xyz, m->nv, m->tri, m->nt, &p.mesh);
    CHECK_OK(ctx, st);
    if (st != CLVOX_OK) {
        p.st = st;
        return p;
    }
    p.st = clvox__winding_prepare(ctx, p.mesh, weld, &p.w);
    return p;
}

static void prep_free(prepared *p)
{
    clvox__winding_mesh_free(&p->w);
    clvox_mesh_destroy(p->mesh);
}

/* A triangle as its rotation starting at the smallest index: equal for
 * equal oriented triangles. */
static void canon(const uint32_t *t, uint32_t o[3])
{
    int k = t[0] < t[1] ? (t[0] < t[2] ? 0 : 2) : (t[1] < t[2] ? 1 : 2);
    for (int i = 0; i < 3; i++) o[i] = t[(k + i) % 3];
}

static int same_oriented(const uint32_t *a, const uint32_t *b)
{
    uint32_t x[3], y[3];
    canon(a, x);
    canon(b, y);
    return x[0] == y[0] && x[1] == y[1] && x[2] == y[2];
}

/* Number of triangles [t0, t1) of w equal (as oriented triangles) to m's. */
static size_t count_same(const clvox__winding_mesh *w, const tmesh *m, size_t t0, size_t t1)
{
    size_t n = 0;
    for (size_t t = t0; t < t1 && t < w->triangle_count && t < m->nt; t++)
        n += (size_t)same_oriented(w->tris + 3 * t, m->tri + 3 * t);
    return n;
}

/* 6 x signed volume of w's triangles [t0, t1) about the origin. */
static double vol6(const prepared *p, size_t t0, size_t t1)
{
    size_t nv;
    const float *xyz = clvox_mesh_vertices(p->mesh, &nv);
    double v = 0;
    for (size_t t = t0; t < t1; t++) {
        const float *a = xyz + 3 * (size_t)p->w.tris[3 * t], *b = xyz + 3 * (size_t)p->w.tris[3 * t + 1],
                    *c = xyz + 3 * (size_t)p->w.tris[3 * t + 2];
        v += a[0] * ((double)b[1] * c[2] - (double)b[2] * c[1]) + a[1] * ((double)b[2] * c[0] - (double)b[0] * c[2]) +
             a[2] * ((double)b[0] * c[1] - (double)b[1] * c[0]);
    }
    return v;
}

static int cmp_u64(const void *pa, const void *pb)
{
    uint64_t a = *(const uint64_t *)pa, b = *(const uint64_t *)pb;
    return (a > b) - (a < b);
}

/* Surface + caps is a closed chain: the multiset of directed edges equals
 * the multiset of the reversed ones. Also checks cap indices. */
static int chain_closed(const prepared *p)
{
    size_t nv = p->mesh ? clvox_mesh_get_report(p->mesh)->vertices : 0;
    size_t n = 3 * (p->w.triangle_count + p->w.cap_count);
    uint64_t *fw = malloc((n ? n : 1) * sizeof *fw), *bw = malloc((n ? n : 1) * sizeof *bw);
    if (!fw || !bw) exit(1);
    size_t k = 0;
    int ok = 1;
    for (int part = 0; part < 2; part++) {
        const uint32_t *tr = part ? p->w.caps : p->w.tris;
        size_t cnt = part ? p->w.cap_count : p->w.triangle_count;
        for (size_t t = 0; t < cnt; t++)
            for (int c = 0; c < 3; c++) {
                uint64_t a = tr[3 * t + c], b = tr[3 * t + (c + 1) % 3];
                if (a >= nv + p->w.apex_count || (!part && a >= nv)) ok = 0;
                fw[k] = a << 32 | b;
                bw[k] = b << 32 | a;
                k++;
            }
    }
    qsort(fw, n, sizeof *fw, cmp_u64);
    qsort(bw, n, sizeof *bw, cmp_u64);
    if (memcmp(fw, bw, n * sizeof *fw)) ok = 0;
    free(fw);
    free(bw);
    return ok;
}

/* m without the triangles whose corners all have coordinate `axis` == v. */
static tmesh without_face(const tmesh *m, int axis, float v)
{
    tmesh o = {0};
    for (size_t i = 0; i < m->nv; i++) tmesh_add_vertex(&o, m->xyz[3 * i], m->xyz[3 * i + 1], m->xyz[3 * i + 2]);
    for (size_t t = 0; t < m->nt; t++) {
        const uint32_t *tr = m->tri + 3 * t;
        int on = 1;
        for (int c = 0; c < 3; c++) on &= m->xyz[3 * tr[c] + axis] == v;
        if (!on) tmesh_add_tri(&o, tr[0], tr[1], tr[2]);
    }
    return o;
}

static void flip_tri(tmesh *m, size_t t)
{
    uint32_t *tr = m->tri + 3 * t, s = tr[1];
    tr[1] = tr[2];
    tr[2] = s;
}

/* ---- tests ---- */

static void test_closed_sphere(void)
{
    tmesh s = tmesh_sphere(0.1, -0.2, 0.3, 1.0, 12);
    prepared p = prep_tmesh(&s, 0);
    CHECK_OK(ctx, p.st);
    const clvox_winding_report *r = &p.w.report;
    CHECK(p.w.triangle_count == s.nt);
    CHECK(count_same(&p.w, &s, 0, s.nt) == s.nt);
    CHECK(memcmp(p.w.tris, s.tri, 3 * s.nt * sizeof *s.tri) == 0); /* bit for bit, same order */
    CHECK(r->flipped_triangles == 0 && r->cap_triangles == 0 && r->holes == 0 && r->boundary_edges == 0);
    CHECK(r->components == 1 && r->closed_components == 1 && r->cavities == 0);
    CHECK(r->merged_vertices == 0 && r->dropped_triangles == 0 && r->nonmanifold_edges == 0);
    CHECK(r->nonorientable_components == 0);
    CHECK(p.w.cap_count == 0 && p.w.apex_count == 0);
    CHECK(r->seconds >= 0);
    prep_free(&p);

    /* Half the triangles flipped at random: repaired to exactly the original. */
    tmesh f = tmesh_sphere(0.1, -0.2, 0.3, 1.0, 12);
    uint64_t seed = 42, nflip = 0;
    for (size_t t = 0; t < f.nt; t++)
        if (tmesh_rng_next(&seed) & 1) {
            flip_tri(&f, t);
            nflip++;
        }
    p = prep_tmesh(&f, 0);
    CHECK_OK(ctx, p.st);
    CHECK(count_same(&p.w, &s, 0, s.nt) == s.nt);
    CHECK_MSG(p.w.report.flipped_triangles == nflip, "%llu vs %llu",
              (unsigned long long)p.w.report.flipped_triangles, (unsigned long long)nflip);
    CHECK(p.w.report.cap_triangles == 0 && p.w.report.closed_components == 1 && p.w.report.components == 1);
    CHECK(chain_closed(&p));
    prep_free(&p);
    tmesh_free(&f);

    /* Wholly inverted: every triangle flipped back. */
    tmesh inv = tmesh_sphere(0.1, -0.2, 0.3, 1.0, 12);
    tmesh_flip(&inv);
    p = prep_tmesh(&inv, 0);
    CHECK_OK(ctx, p.st);
    CHECK(p.w.report.flipped_triangles == s.nt);
    CHECK(count_same(&p.w, &s, 0, s.nt) == s.nt);
    CHECK(vol6(&p, 0, p.w.triangle_count) > 0);
    prep_free(&p);
    tmesh_free(&inv);
    tmesh_free(&s);
}

static void test_unchanged_closed(void)
{
    /* Closed, consistent, outward meshes come out bit for bit. */
    tmesh ms[5];
    ms[0] = tmesh_torus(0.5, 0.5, 0.5, 0.3, 0.1, 24, 12);
    ms[1] = tmesh_random_closed(7, 5, 4);
    double c1[3], c2[3];
    ms[2] = tmesh_random_overlap(3, 4, c1, c2);
    ms[3] = tmesh_hollow_sphere(0, 0, 0, 2, 1, 10);
    ms[4] = tmesh_box_subdivided(-1, -2, -3, 1, 2, 3, 5);
    for (int i = 0; i < 5; i++) {
        prepared p = prep_tmesh(&ms[i], 0);
        CHECK_OK(ctx, p.st);
        CHECK_MSG(p.w.triangle_count == ms[i].nt &&
                      memcmp(p.w.tris, ms[i].tri, 3 * ms[i].nt * sizeof *ms[i].tri) == 0,
                  "mesh %d changed", i);
        CHECK_MSG(p.w.report.flipped_triangles == 0 && p.w.cap_count == 0, "mesh %d: %llu flipped, %zu caps", i,
                  (unsigned long long)p.w.report.flipped_triangles, p.w.cap_count);
        CHECK(p.w.report.components == p.w.report.closed_components);
        prep_free(&p);
        tmesh_free(&ms[i]);
    }
}

static void test_hollow(void)
{
    for (int variant = 0; variant < 4; variant++) {
        /* variant bit 0: inner shell stored outwards; bit 1: everything inverted */
        tmesh outer = tmesh_sphere(0, 0, 0, 2.0, 10), inner = tmesh_sphere(0.1, 0, 0, 1.0, 8);
        if (!(variant & 1)) tmesh_flip(&inner);
        tmesh m = {0};
        tmesh_append(&m, &outer);
        tmesh_append(&m, &inner);
        if (variant & 2) tmesh_flip(&m);
        prepared p = prep_tmesh(&m, 0);
        CHECK_OK(ctx, p.st);
        const clvox_winding_report *r = &p.w.report;
        CHECK_MSG(r->components == 2 && r->closed_components == 2 && r->cavities == 1, "variant %d: %llu %llu %llu",
                  variant, (unsigned long long)r->components, (unsigned long long)r->closed_components,
                  (unsigned long long)r->cavities);
        CHECK_MSG(vol6(&p, 0, outer.nt) > 0, "variant %d: outer not outwards", variant);
        CHECK_MSG(vol6(&p, outer.nt, m.nt) < 0, "variant %d: inner not inwards", variant);
        uint64_t expect = (variant == 0) ? 0 : variant == 1 ? inner.nt : variant == 2 ? m.nt : outer.nt;
        CHECK_MSG(r->flipped_triangles == expect, "variant %d: %llu flipped, expected %llu", variant,
                  (unsigned long long)r->flipped_triangles, (unsigned long long)expect);
        CHECK(r->cap_triangles == 0);
        prep_free(&p);
        tmesh_free(&m);
        tmesh_free(&outer);
        tmesh_free(&inner);
    }
}

static void test_intersecting_boxes(void)
{
    /* Overlapping, not nested: both outwards (the union), whatever the input. */
    for (int variant = 0; variant < 3; variant++) {
        tmesh a = tmesh_box(0, 0, 0, 2, 2, 2), b = tmesh_box(1, 0.5, 0.5, 3, 1.5, 1.5);
        if (variant == 1) tmesh_flip(&b);
        if (variant == 2) tmesh_flip(&a);
        tmesh m = {0};
        tmesh_append(&m, &a);
        tmesh_append(&m, &b);
        prepared p = prep_tmesh(&m, 0);
        CHECK_OK(ctx, p.st);
        CHECK(p.w.report.cavities == 0 && p.w.report.closed_components == 2);
        CHECK(vol6(&p, 0, 12) > 0 && vol6(&p, 12, 24) > 0);
        CHECK(p.w.report.flipped_triangles == (variant ? 12u : 0u));
        prep_free(&p);
        tmesh_free(&m);
        tmesh_free(&a);
        tmesh_free(&b);
    }
    /* A box whose box lies in the other's but which pokes out of it (an L
     * shape around it): the bounding-box test passes, the vertices do not. */
    tmesh big = tmesh_tetra((double[3]){0, 0, 0}, (double[3]){4, 0, 0}, (double[3]){0, 4, 0}, (double[3]){0, 0, 4});
    tmesh small = tmesh_box(2, 2, 0.1, 3, 3, 0.5); /* in big's box, outside big (x + y > 4) */
    tmesh m = {0};
    tmesh_append(&m, &big);
    tmesh_append(&m, &small);
    prepared p = prep_tmesh(&m, 0);
    CHECK_OK(ctx, p.st);
    CHECK(p.w.report.cavities == 0 && p.w.report.flipped_triangles == 0);
    prep_free(&p);
    tmesh_free(&m);
    tmesh_free(&big);
    tmesh_free(&small);
}

static void test_nested_boxes(void)
{
    /* Depths 0, 1, 2: out, in, out, from any stored orientation. */
    for (int variant = 0; variant < 8; variant++) {
        tmesh b[3] = {tmesh_box(0, 0, 0, 10, 10, 10), tmesh_box(2, 2, 2, 8, 8, 8), tmesh_box(4, 4, 4, 6, 6, 6)};
        tmesh m = {0};
        /* appended innermost first, so that patch order differs from depth order */
        for (int i = 2; i >= 0; i--) {
            if (variant >> i & 1) tmesh_flip(&b[i]);
            tmesh_append(&m, &b[i]);
        }
        prepared p = prep_tmesh(&m, 0);
        CHECK_OK(ctx, p.st);
        CHECK(p.w.report.closed_components == 3 && p.w.report.cavities == 1);
        CHECK_MSG(vol6(&p, 0, 12) > 0 && vol6(&p, 12, 24) < 0 && vol6(&p, 24, 36) > 0, "variant %d", variant);
        prep_free(&p);
        tmesh_free(&m);
        for (int i = 0; i < 3; i++) tmesh_free(&b[i]);
    }
    /* Tie rule: a vertex on B's surface counts as moved infinitesimally
     * towards +z (and (1, eps) in the xy plane). An inner box standing on
     * B's floor is nested (a cavity); one touching B's ceiling is not. */
    for (int top = 0; top < 2; top++) {
        tmesh o = tmesh_box(0, 0, 0, 10, 10, 10);
        tmesh i = top ? tmesh_box(2, 2, 5, 8, 8, 10) : tmesh_box(2, 2, 0, 8, 8, 5);
        tmesh m2 = {0};
        tmesh_append(&m2, &o);
        tmesh_append(&m2, &i);
        prepared q = prep_tmesh(&m2, 0);
        CHECK_OK(ctx, q.st);
        CHECK_MSG(q.w.report.cavities == (top ? 0u : 1u), "top %d: %llu cavities", top,
                  (unsigned long long)q.w.report.cavities);
        prep_free(&q);
        tmesh_free(&m2);
        tmesh_free(&o);
        tmesh_free(&i);
    }
    /* ... and on B's -x wall it is inside, on the +x wall outside. */
    for (int plus = 0; plus < 2; plus++) {
        tmesh o = tmesh_box(0, 0, 0, 10, 10, 10);
        tmesh i = plus ? tmesh_box(5, 2, 2, 10, 8, 8) : tmesh_box(0, 2, 2, 5, 8, 8);
        tmesh m2 = {0};
        tmesh_append(&m2, &o);
        tmesh_append(&m2, &i);
        prepared q = prep_tmesh(&m2, 0);
        CHECK_OK(ctx, q.st);
        CHECK_MSG(q.w.report.cavities == (plus ? 0u : 1u), "plus %d: %llu cavities", plus,
                  (unsigned long long)q.w.report.cavities);
        prep_free(&q);
        tmesh_free(&m2);
        tmesh_free(&o);
        tmesh_free(&i);
    }
    /* Many disjoint closed parts (CAD-like), some with holes inside. */
    tmesh m = {0};
    size_t expect_cav = 0;
    for (int i = 0; i < 20; i++)
        for (int j = 0; j < 20; j++) {
            tmesh b = tmesh_box(3 * i, 3 * j, 0, 3 * i + 2, 3 * j + 2, 2);
            tmesh_append(&m, &b);
            tmesh_free(&b);
            if ((i + j) % 7 == 0) {
                tmesh c = tmesh_sphere(3 * i + 1, 3 * j + 1, 1, 0.5, 4); /* stored outwards */
                tmesh_append(&m, &c);
                tmesh_free(&c);
                expect_cav++;
            }
        }
    prepared p = prep_tmesh(&m, 0);
    CHECK_OK(ctx, p.st);
    CHECK(p.w.report.closed_components == 400 + expect_cav);
    CHECK(p.w.report.cavities == expect_cav);
    CHECK(p.w.report.flipped_triangles == expect_cav * 4 * 4 * 3);
    prep_free(&p);
    tmesh_free(&m);
}

/* The nesting test's point-in-patch parity against the independent oracle
 * (tmesh_point_inside: tilted rays, majority of three): tiny octahedra at
 * random points of a star-shaped shell's and a torus's box are cavities
 * exactly when all their vertices are inside. */
static void test_nesting_oracle(void)
{
    int agree = 0, total = 0, inside = 0;
    for (int shape = 0; shape < 4; shape++) {
        tmesh shell = shape < 3 ? tmesh_random_closed(500 + (uint64_t)shape, 1, 6)
                                : tmesh_torus(0.5, 0.5, 0.5, 0.3, 0.12, 32, 16);
        float lo[3], hi[3];
        for (int a = 0; a < 3; a++) lo[a] = hi[a] = shell.xyz[a];
        for (size_t v = 0; v < shell.nv; v++)
            for (int a = 0; a < 3; a++) {
                if (shell.xyz[3 * v + a] < lo[a]) lo[a] = shell.xyz[3 * v + a];
                if (shell.xyz[3 * v + a] > hi[a]) hi[a] = shell.xyz[3 * v + a];
            }
        tmesh m = {0};
        tmesh_append(&m, &shell);
        uint64_t seed = 900 + (uint64_t)shape;
        enum { POINTS = 300 };
        int expect[POINTS];
        for (int k = 0; k < POINTS; k++) {
            double c[3];
            for (int a = 0; a < 3; a++) c[a] = lo[a] + (hi[a] - lo[a]) * tmesh_rng_uniform(&seed);
            tmesh o = tmesh_octahedron(c[0], c[1], c[2], 1e-4);
            int all = 1;
            for (size_t v = 0; v < o.nv; v++) {
                double q[3] = {o.xyz[3 * v], o.xyz[3 * v + 1], o.xyz[3 * v + 2]};
                all &= tmesh_point_inside(&shell, q);
            }
            expect[k] = all;
            inside += all;
            tmesh_append(&m, &o);
            tmesh_free(&o);
        }
        prepared p = prep_tmesh(&m, 0);
        CHECK_OK(ctx, p.st);
        if (p.st == CLVOX_OK) {
            for (int k = 0; k < POINTS; k++) {
                size_t t0 = shell.nt + 8 * (size_t)k;
                int cavity = vol6(&p, t0, t0 + 8) < 0;
                agree += cavity == expect[k];
                total++;
            }
            CHECK(vol6(&p, 0, shell.nt) > 0);
        }
        prep_free(&p);
        tmesh_free(&m);
        tmesh_free(&shell);
    }
    CHECK_MSG(agree == total, "%d of %d octahedra as the oracle", agree, total);
    CHECK(inside > total / 10 && inside < total - total / 10); /* both kinds tested */
}

static void test_open_cube(void)
{
    for (int inverted = 0; inverted < 2; inverted++) {
        tmesh box = tmesh_box(0, 0, 0, 1, 1, 1);
        tmesh m = without_face(&box, 2, 1.0f);
        CHECK(m.nt == 10);
        if (inverted) tmesh_flip(&m);
        prepared p = prep_tmesh(&m, 0);
        CHECK_OK(ctx, p.st);
        const clvox_winding_report *r = &p.w.report;
        CHECK(r->holes == 1 && r->boundary_edges == 4 && r->cap_triangles == 4);
        CHECK(r->components == 1 && r->closed_components == 0);
        CHECK(p.w.cap_count == 4 && p.w.apex_count == 1);
        /* the apex: the centroid moved off the loop's plane by 0.0731 x its size */
        CHECK(p.w.apex[0] == 0.5f && p.w.apex[1] == 0.5f && fabs(fabs(p.w.apex[2] - 1.0) - 0.0731 * sqrt(0.5)) < 1e-6);
        CHECK(chain_closed(&p));
        CHECK(r->flipped_triangles == (inverted ? 10u : 0u));
        CHECK(vol6(&p, 0, p.w.triangle_count) > 0);
        for (size_t c = 0; c < p.w.cap_count; c++) CHECK(p.w.caps[3 * c + 2] == 8);
        prep_free(&p);
        tmesh_free(&m);
        tmesh_free(&box);
    }
    /* A sphere missing its top cap, partly flipped: repaired, one hole. */
    tmesh s = tmesh_sphere(0, 0, 0, 1, 10);
    tmesh open = {0};
    for (size_t i = 0; i < s.nv; i++) tmesh_add_vertex(&open, s.xyz[3 * i], s.xyz[3 * i + 1], s.xyz[3 * i + 2]);
    size_t kept = 0;
    for (size_t t = 0; t < s.nt; t++) {
        const uint32_t *tr = s.tri + 3 * t;
        int top = s.xyz[3 * tr[0] + 2] > 0.7f && s.xyz[3 * tr[1] + 2] > 0.7f && s.xyz[3 * tr[2] + 2] > 0.7f;
        if (top) continue;
        tmesh_add_tri(&open, tr[0], tr[1], tr[2]);
        kept++;
    }
    tmesh ref = {0};
    tmesh_append(&ref, &open);
    for (size_t t = 0; t < open.nt; t += 3) flip_tri(&open, t);
    prepared p = prep_tmesh(&open, 0);
    CHECK_OK(ctx, p.st);
    CHECK(p.w.report.holes == 1 && p.w.report.closed_components == 0);
    CHECK(count_same(&p.w, &ref, 0, ref.nt) == ref.nt);
    CHECK(chain_closed(&p));
    prep_free(&p);
    tmesh_free(&open);
    tmesh_free(&ref);
    tmesh_free(&s);
}

/* A tube (sphere without its polar caps, so two holes), stored inwards:
 * one open patch, flipped outwards as a whole (its volume about the
 * centroid of both rims), two loops with an apex each. */
static void test_tube(void)
{
    tmesh s = tmesh_sphere(0, 0, 0, 1, 12);
    tmesh tube = {0}, ref = {0};
    for (size_t i = 0; i < s.nv; i++) tmesh_add_vertex(&tube, s.xyz[3 * i], s.xyz[3 * i + 1], s.xyz[3 * i + 2]);
    for (size_t t = 0; t < s.nt; t++) {
        const uint32_t *tr = s.tri + 3 * t;
        int polar = 0;
        for (int c = 0; c < 3; c++) polar |= fabsf(s.xyz[3 * tr[c] + 2]) > 0.9f;
        if (!polar) tmesh_add_tri(&tube, tr[0], tr[1], tr[2]);
    }
    tmesh_append(&ref, &tube);
    tmesh_flip(&tube);
    prepared p = prep_tmesh(&tube, 0);
    CHECK_OK(ctx, p.st);
    CHECK(p.w.report.components == 1 && p.w.report.closed_components == 0 && p.w.report.holes == 2);
    CHECK(p.w.report.flipped_triangles == tube.nt && count_same(&p.w, &ref, 0, ref.nt) == ref.nt);
    CHECK(p.w.apex_count == 2 && fabsf(p.w.apex[2]) > 0.5f && fabsf(p.w.apex[5]) > 0.5f &&
          p.w.apex[2] * p.w.apex[5] < 0);
    CHECK(chain_closed(&p));
    prep_free(&p);
    tmesh_free(&tube);
    tmesh_free(&ref);
    tmesh_free(&s);
}

/* Every triangle with its own three vertices (STL-like). */
static tmesh soup_of(const tmesh *m)
{
    tmesh o = {0};
    for (size_t t = 0; t < m->nt; t++) {
        uint32_t v[3];
        for (int c = 0; c < 3; c++) {
            const float *p = m->xyz + 3 * m->tri[3 * t + c];
            v[c] = tmesh_add_vertex(&o, p[0], p[1], p[2]);
        }
        tmesh_add_tri(&o, v[0], v[1], v[2]);
    }
    return o;
}

static void test_soup(void)
{
    tmesh box = tmesh_box(-1, -1, -1, 1, 1, 1);
    /* -0.0 equals 0.0: a box with a vertex at -0.0 in the soup. */
    tmesh soup = soup_of(&box);
    prepared p = prep_tmesh(&soup, 0);
    CHECK_OK(ctx, p.st);
    const clvox_winding_report *r = &p.w.report;
    CHECK(r->merged_vertices == 36 - 8);
    CHECK(r->closed_components == 1 && r->components == 1 && r->cap_triangles == 0 && r->flipped_triangles == 0);
    CHECK(chain_closed(&p));
    /* merged into the lowest-numbered copy: indices are first occurrences */
    for (size_t t = 0; t < p.w.triangle_count; t++)
        for (int c = 0; c < 3; c++) {
            uint32_t v = p.w.tris[3 * t + c];
            for (uint32_t u = 0; u < v; u++) {
                const float *a = soup.xyz + 3 * u, *b = soup.xyz + 3 * (size_t)v;
                CHECK(!(a[0] == b[0] && a[1] == b[1] && a[2] == b[2]));
            }
        }
    prep_free(&p);
    tmesh_free(&soup);

    tmesh z = {0};
    uint32_t a = tmesh_add_vertex(&z, 0, 0, 0), b = tmesh_add_vertex(&z, 1, 0, 0), c = tmesh_add_vertex(&z, 0, 1, 0);
    uint32_t d = tmesh_add_vertex(&z, -0.0, -0.0, 0.0), e = tmesh_add_vertex(&z, 0, 0, 1);
    tmesh_add_tri(&z, a, c, b);
    tmesh_add_tri(&z, d, b, e);
    prepared q = prep_tmesh(&z, 0);
    CHECK_OK(ctx, q.st);
    CHECK(q.w.report.merged_vertices == 1 && q.w.tris[3] == a);
    prep_free(&q);
    tmesh_free(&z);
    tmesh_free(&box);
}

/* Patches whose volume is zero up to rounding keep their orientation: the
 * lone triangles of a jittered, unwelded soup, and a flat sheet either way. */
static void test_zero_volume(void)
{
    tmesh s = tmesh_sphere(0.3, 0.2, 0.1, 1, 10);
    tmesh soup = soup_of(&s);
    uint64_t seed = 3;
    for (size_t v = 0; v < soup.nv; v++)
        for (int a = 0; a < 3; a++) soup.xyz[3 * v + a] += (float)((tmesh_rng_uniform(&seed) - 0.5) * 2e-6);
    prepared p = prep_tmesh(&soup, 0);
    CHECK_OK(ctx, p.st);
    CHECK(p.w.report.components == soup.nt && p.w.report.flipped_triangles == 0);
    CHECK(p.w.report.holes == soup.nt && chain_closed(&p));
    prep_free(&p);
    tmesh_free(&soup);
    tmesh_free(&s);
    for (int down = 0; down < 2; down++) {
        tmesh sheet = {0};
        for (int j = 0; j <= 8; j++)
            for (int i = 0; i <= 8; i++) tmesh_add_vertex(&sheet, 0.1 * i + 0.013, 0.1 * j - 0.7, 0.37);
        for (uint32_t j = 0; j < 8; j++)
            for (uint32_t i = 0; i < 8; i++) {
                uint32_t a = 9 * j + i, b = a + 1, c = a + 10, d = a + 9;
                tmesh_add_tri(&sheet, a, b, c);
                tmesh_add_tri(&sheet, a, c, d);
            }
        if (down) tmesh_flip(&sheet);
        p = prep_tmesh(&sheet, 0);
        CHECK_OK(ctx, p.st);
        CHECK(p.w.report.flipped_triangles == 0 && p.w.report.holes == 1 && p.w.report.components == 1);
        CHECK(chain_closed(&p));
        prep_free(&p);
        tmesh_free(&sheet);
    }
    /* One closed patch of zero volume (a back-to-back pair, the mesh's only
     * patch: the report's volume is within its tolerance, so the sum is
     * made again) keeps its orientation, either way round. */
    for (int way = 0; way < 2; way++) {
        tmesh pair = {0};
        tmesh_add_vertex(&pair, 0.1f, 0.2f, 0.3f);
        tmesh_add_vertex(&pair, 0.9f, 0.25f, 0.35f);
        tmesh_add_vertex(&pair, 0.4f, 0.8f, 0.3f);
        tmesh_add_tri(&pair, 0, way ? 2 : 1, way ? 1 : 2);
        tmesh_add_tri(&pair, 0, way ? 1 : 2, way ? 2 : 1);
        p = prep_tmesh(&pair, 0);
        CHECK_OK(ctx, p.st);
        CHECK(p.w.report.components == 1 && p.w.report.closed_components == 1);
        CHECK_MSG(p.w.report.flipped_triangles == 0, "back-to-back pair %d: %llu flipped", way,
                  (unsigned long long)p.w.report.flipped_triangles);
        CHECK(p.w.report.holes == 0 && chain_closed(&p));
        prep_free(&p);
        tmesh_free(&pair);
    }
}

static void test_crack_and_weld(void)
{
    /* The top face with its own copies of its vertices, shifted by 1e-6. */
    tmesh box = tmesh_box(0, 0, 0, 1, 1, 1);
    tmesh m = {0};
    tmesh_append(&m, &box);
    uint32_t copy[8];
    for (uint32_t v = 0; v < 8; v++) {
        const float *p = box.xyz + 3 * v;
        copy[v] = p[2] == 1.0f ? tmesh_add_vertex(&m, p[0] + 1e-6, p[1] - 1e-6, p[2]) : v;
    }
    for (size_t t = 0; t < m.nt; t++) {
        uint32_t *tr = m.tri + 3 * t;
        if (box.xyz[3 * tr[0] + 2] == 1.0f && box.xyz[3 * tr[1] + 2] == 1.0f && box.xyz[3 * tr[2] + 2] == 1.0f)
            for (int c = 0; c < 3; c++) tr[c] = copy[tr[c]];
    }
    prepared p = prep_tmesh(&m, 0);
    CHECK_OK(ctx, p.st);
    CHECK(p.w.report.closed_components == 0 && p.w.report.components == 2);
    CHECK(p.w.report.holes == 2 && p.w.report.boundary_edges == 8 && p.w.report.welded_vertices == 0);
    CHECK(chain_closed(&p));
    prep_free(&p);
    p = prep_tmesh(&m, 1e-5);
    CHECK_OK(ctx, p.st);
    CHECK(p.w.report.welded_vertices == 4 && p.w.report.dropped_triangles == 0);
    CHECK(p.w.report.closed_components == 1 && p.w.report.components == 1 && p.w.report.cap_triangles == 0);
    CHECK(count_same(&p.w, &box, 0, box.nt) == box.nt); /* welded into the lower-numbered originals */
    prep_free(&p);
    /* Too small a weld changes nothing. */
    p = prep_tmesh(&m, 1e-7);
    CHECK_OK(ctx, p.st);
    CHECK(p.w.report.welded_vertices == 0 && p.w.report.holes == 2);
    prep_free(&p);
    tmesh_free(&m);

    /* Welding collapses a sliver triangle (two corners 1e-7 apart): dropped. */
    tmesh s = tmesh_box(0, 0, 0, 1, 1, 1);
    uint32_t a = tmesh_add_vertex(&s, 5, 5, 5), b = tmesh_add_vertex(&s, 5 + 1e-6, 5, 5),
             c = tmesh_add_vertex(&s, 5, 6, 5);
    tmesh_add_tri(&s, a, b, c);
    p = prep_tmesh(&s, 1e-5);
    CHECK_OK(ctx, p.st);
    CHECK(p.w.report.welded_vertices == 1 && p.w.report.dropped_triangles == 1);
    CHECK(p.w.triangle_count == 12 && p.w.report.cap_triangles == 0 && p.w.report.components == 1);
    prep_free(&p);
    /* A chain of vertices each within the weld of the next merges transitively. */
    tmesh ch = {0};
    for (int i = 0; i < 5; i++) {
        uint32_t v = tmesh_add_vertex(&ch, 0.9e-5 * i, 0, 0);
        uint32_t f = tmesh_add_vertex(&ch, cos(i), sin(i), 1), g = tmesh_add_vertex(&ch, cos(i + 0.5), sin(i + 0.5), 1);
        tmesh_add_tri(&ch, v, f, g);
    }
    p = prep_tmesh(&ch, 1e-5);
    CHECK_OK(ctx, p.st);
    CHECK(p.w.report.welded_vertices == 4 && p.w.report.dropped_triangles == 0);
    for (int i = 0; i < 5; i++) CHECK(p.w.tris[3 * i] == 0);
    prep_free(&p);
    tmesh_free(&ch);
    /* Unreferenced vertices do not bridge: 0 and 3e-5 stay apart. */
    tmesh un = {0};
    for (int i = 0; i < 4; i++) tmesh_add_vertex(&un, 0.9e-5 * i, 0, 0);
    tmesh_add_vertex(&un, 0, 1, 0);
    tmesh_add_vertex(&un, 1, 1, 0);
    tmesh_add_tri(&un, 0, 5, 4);
    tmesh_add_tri(&un, 3, 5, 4);
    p = prep_tmesh(&un, 1e-5);
    CHECK_OK(ctx, p.st);
    CHECK(p.w.report.welded_vertices == 0 && p.w.report.components == 1);
    prep_free(&p);
    tmesh_free(&un);
    /* All triangles collapsing is an error, not a crash. */
    tmesh tiny = {0};
    tmesh_add_vertex(&tiny, 0, 0, 0);
    tmesh_add_vertex(&tiny, 1e-7, 0, 0);
    tmesh_add_vertex(&tiny, 0, 1e-7, 0);
    tmesh_add_tri(&tiny, 0, 1, 2);
    p = prep_tmesh(&tiny, 1e-3);
    CHECK(p.st == CLVOX_ERR_MESH_EMPTY);
    CHECK(strstr(clvox_context_error(ctx), "welding within") != NULL);
    prep_free(&p);
    /* Exact merging can collapse triangles too (distinct indices, equal
     * positions): dropped and counted; nothing left is the same error. */
    tmesh eq = {0};
    tmesh_add_vertex(&eq, 0, 0, 0);
    tmesh_add_vertex(&eq, 0, 0, 0);
    tmesh_add_vertex(&eq, 1, 0, 0);
    tmesh_add_tri(&eq, 0, 1, 2);
    p = prep_tmesh(&eq, 0);
    CHECK(p.st == CLVOX_ERR_MESH_EMPTY && p.w.report.dropped_triangles == 1 && p.w.report.merged_vertices == 1);
    CHECK(strstr(clvox_context_error(ctx), "equal positions") != NULL);
    prep_free(&p);
    tmesh_add_vertex(&eq, 0, 1, 0);
    tmesh_add_tri(&eq, 0, 2, 3);
    p = prep_tmesh(&eq, 0);
    CHECK_OK(ctx, p.st);
    CHECK(p.w.report.dropped_triangles == 1 && p.w.triangle_count == 1 && p.w.report.cap_triangles == 3);
    prep_free(&p);
    tmesh_free(&eq);
    tmesh_free(&tiny);
    /* A tiny weld on big coordinates: no int64 clamping, no crowding. */
    tmesh far = tmesh_box_subdivided(1e9, 1e9, 1e9, 1.5e9, 1.5e9, 1.5e9, 20);
    double cpu0 = test_cpu_seconds(); /* CPU, not the report's wall seconds: load stretches those */
    p = prep_tmesh(&far, 1e-20);
    double cpu = test_cpu_seconds() - cpu0;
    CHECK_OK(ctx, p.st);
    CHECK(p.w.report.welded_vertices == 0 && p.w.report.closed_components == 1);
    CHECK_MSG(cpu < 5, "a tiny weld on big coordinates took %.2f s of CPU", cpu);
    prep_free(&p);
    tmesh_free(&far);
    /* Bad weld distances. */
    clvox_mesh *bm = NULL;
    CHECK_OK(ctx, clvox_mesh_from_arrays(ctx, s.xyz, s.nv, s.tri, s.nt, &bm));
    clvox__winding_mesh w;
    CHECK_STATUS(ctx, clvox__winding_prepare(ctx, bm, -1, &w), CLVOX_ERR_INVALID_ARGUMENT);
    clvox__winding_mesh_free(&w);
    CHECK_STATUS(ctx, clvox__winding_prepare(ctx, bm, NAN, &w), CLVOX_ERR_INVALID_ARGUMENT);
    clvox__winding_mesh_free(&w);
    CHECK_STATUS(ctx, clvox__winding_prepare(ctx, bm, INFINITY, &w), CLVOX_ERR_INVALID_ARGUMENT);
    clvox__winding_mesh_free(&w);
    clvox__winding_mesh_free(NULL);
    clvox_mesh_destroy(bm);
    tmesh_free(&s);
    tmesh_free(&box);
}

static uint32_t bf_find(uint32_t *par, uint32_t x)
{
    while (par[x] != x) x = par[x];
    return x;
}

/* Welding against brute force: all pairs within the distance, transitively,
 * merged into the lowest index; triangles re-indexed, collapsed ones dropped.
 * Vertices near a coarse lattice, so clusters form at every weld size
 * (below, around and above half the edge length). */
static void test_weld_oracle(void)
{
    const double welds[] = {1e-4, 0.004, 0.02, 0.05, 0.2};
    int ok = 0, total = 0;
    for (int r = 0; r < 10; r++)
        for (size_t wi = 0; wi < sizeof welds / sizeof *welds; wi++) {
            uint64_t seed = 77 + (uint64_t)r;
            tmesh m = {0};
            for (int i = 0; i < 240; i++) {
                double x = (double)(tmesh_rng_next(&seed) % 6) * 0.1, y = (double)(tmesh_rng_next(&seed) % 6) * 0.1,
                       z = (double)(tmesh_rng_next(&seed) % 3) * 0.1;
                x += (tmesh_rng_uniform(&seed) - 0.5) * 0.02;
                y += (tmesh_rng_uniform(&seed) - 0.5) * 0.02;
                tmesh_add_vertex(&m, x, y, z);
            }
            for (int t = 0; t < 200; t++) {
                uint32_t a = (uint32_t)(tmesh_rng_next(&seed) % 240), b = (uint32_t)(tmesh_rng_next(&seed) % 240),
                         c = (uint32_t)(tmesh_rng_next(&seed) % 240);
                if (a != b && b != c && a != c) tmesh_add_tri(&m, a, b, c);
            }
            double weld = welds[wi];
            /* the oracle: exact merge and weld among used vertices */
            uint32_t par[240];
            int used[240] = {0};
            for (uint32_t v = 0; v < 240; v++) par[v] = v;
            for (size_t i = 0; i < 3 * m.nt; i++) used[m.tri[i]] = 1;
            for (uint32_t v = 0; v < 240; v++)
                for (uint32_t u = 0; u < v; u++) {
                    const float *p = m.xyz + 3 * v, *q = m.xyz + 3 * u;
                    double dx = (double)p[0] - q[0], dy = (double)p[1] - q[1], dz = (double)p[2] - q[2];
                    int same = p[0] == q[0] && p[1] == q[1] && p[2] == q[2];
                    if (!same && !(used[u] && used[v] && dx * dx + dy * dy + dz * dz <= weld * weld)) continue;
                    uint32_t a = bf_find(par, u), b = bf_find(par, v);
                    if (a < b) par[b] = a;
                    else if (b < a) par[a] = b;
                }
            tmesh want = {0};
            for (size_t t = 0; t < m.nt; t++) {
                uint32_t a = bf_find(par, m.tri[3 * t]), b = bf_find(par, m.tri[3 * t + 1]),
                         c = bf_find(par, m.tri[3 * t + 2]);
                if (a != b && b != c && a != c) tmesh_add_tri(&want, a, b, c);
            }
            prepared p = prep_tmesh(&m, weld);
            total++;
            if (!want.nt) {
                ok += p.st == CLVOX_ERR_MESH_EMPTY;
            } else if (p.st == CLVOX_OK && p.w.triangle_count == want.nt &&
                       p.w.report.dropped_triangles == m.nt - want.nt) {
                size_t same = 0;
                for (size_t t = 0; t < want.nt; t++) {
                    uint32_t x[3], y[3];
                    memcpy(x, p.w.tris + 3 * t, sizeof x);
                    memcpy(y, want.tri + 3 * t, sizeof y);
                    /* orientation may have been repaired: compare as sets */
                    int hit = 0;
                    for (int i = 0; i < 3; i++)
                        for (int j = 0; j < 3; j++) hit += x[i] == y[j];
                    same += hit == 3;
                }
                if (same == want.nt && chain_closed(&p)) ok++;
                else fprintf(stderr, "weld %g round %d: %zu of %zu triangles\n", weld, r, same, want.nt);
            } else {
                fprintf(stderr, "weld %g round %d: status %d, %zu vs %zu triangles\n", weld, r, (int)p.st,
                        p.w.triangle_count, want.nt);
            }
            prep_free(&p);
            tmesh_free(&want);
            tmesh_free(&m);
        }
    CHECK_MSG(ok == total, "%d of %d welds as brute force", ok, total);
}

/* A Moebius strip of 2n triangles. */
static tmesh moebius_mesh(int n)
{
    const double pi = 3.14159265358979323846;
    tmesh m = {0};
    for (int i = 0; i < n; i++) {
        double t = 2 * pi * i / n, h = 0.3;
        for (int s = -1; s <= 1; s += 2) {
            double r = 1 + s * h * cos(t / 2), z = s * h * sin(t / 2);
            tmesh_add_vertex(&m, r * cos(t), r * sin(t), z);
        }
    }
    for (int i = 0; i < n; i++) {
        uint32_t a = 2 * i, b = 2 * i + 1, c, d;
        if (i + 1 < n) c = 2 * (i + 1), d = 2 * (i + 1) + 1;
        else c = 1, d = 0; /* the half twist */
        tmesh_add_tri(&m, a, c, b);
        tmesh_add_tri(&m, b, c, d);
    }
    return m;
}

static void test_moebius(void)
{
    const int n = 24;
    tmesh m = moebius_mesh(n);
    prepared p = prep_tmesh(&m, 0);
    CHECK_OK(ctx, p.st);
    const clvox_winding_report *r = &p.w.report;
    CHECK(r->nonorientable_components == 1 && r->components == 1 && r->closed_components == 0);
    CHECK(r->holes >= 1 && r->cap_triangles == r->boundary_edges);
    CHECK(r->boundary_edges == (uint64_t)2 * n + 2); /* the rim, and the seam twice */
    CHECK(chain_closed(&p));
    prep_free(&p);
    tmesh_free(&m);
}

static void test_nonmanifold(void)
{
    /* Three fins on one edge. */
    tmesh f = {0};
    uint32_t a = tmesh_add_vertex(&f, 0, 0, 0), b = tmesh_add_vertex(&f, 0, 0, 1);
    for (int i = 0; i < 3; i++) {
        double t = 2.0 * i;
        uint32_t c = tmesh_add_vertex(&f, cos(t), sin(t), 0.5);
        tmesh_add_tri(&f, a, b, c);
    }
    prepared p = prep_tmesh(&f, 0);
    CHECK_OK(ctx, p.st);
    CHECK(p.w.report.nonmanifold_edges == 1 && p.w.report.components == 3 && p.w.report.closed_components == 0);
    CHECK(chain_closed(&p));
    prep_free(&p);
    tmesh_free(&f);

    /* Two boxes sharing an edge: 4 uses, each box still closed and untouched. */
    tmesh x = tmesh_box(0, 0, 0, 1, 1, 1), y = tmesh_box(1, 1, 0, 2, 2, 1), m = {0};
    tmesh_append(&m, &x);
    tmesh_append(&m, &y);
    p = prep_tmesh(&m, 0);
    CHECK_OK(ctx, p.st);
    CHECK(p.w.report.merged_vertices == 2 && p.w.report.nonmanifold_edges == 1);
    CHECK(p.w.report.components == 2 && p.w.report.closed_components == 2 && p.w.report.cap_triangles == 0);
    CHECK(p.w.report.flipped_triangles == 0 && p.w.report.cavities == 0);
    prep_free(&p);
    tmesh_free(&m);
    tmesh_free(&x);
    tmesh_free(&y);
}

static void test_one_triangle(void)
{
    tmesh t = {0};
    tmesh_add_vertex(&t, 0, 0, 0);
    tmesh_add_vertex(&t, 3, 0, 0);
    tmesh_add_vertex(&t, 0, 3, 0);
    tmesh_add_tri(&t, 0, 1, 2);
    prepared p = prep_tmesh(&t, 0);
    CHECK_OK(ctx, p.st);
    CHECK(p.w.report.holes == 1 && p.w.report.cap_triangles == 3 && p.w.report.boundary_edges == 3);
    CHECK(p.w.report.components == 1 && p.w.report.closed_components == 0 && p.w.report.flipped_triangles == 0);
    CHECK(p.w.apex_count == 1 && p.w.apex[0] == 1.0f && p.w.apex[1] == 1.0f &&
          fabs(fabs(p.w.apex[2]) - 0.0731 * sqrt(5.0)) < 1e-6);
    CHECK(chain_closed(&p));
    prep_free(&p);
    tmesh_free(&t);
}

/* Lone triangles far from the coordinate origin and nearly parallel to a
 * coordinate plane (a jittered soup's): their volume about their own
 * boundary's centroid is exactly 0, but the centroid rounds in double and
 * moved it by up to 1e-10 of the permanent, beyond the 1e-12 tolerance --
 * such triangles were flipped (issue 35: cube.off's soup at 1e-6 jitter).
 * The tolerance now bounds the origin's rounding: none is flipped. */
static void test_far_flat_triangles(void)
{
    tmesh t = {0};
    uint64_t seed = 12345;
    for (int i = 0; i < 3000; i++) {
        double cx = 100.0 + (i % 10), cy = 50.0 + (i / 10 % 10), cz = 30.0 + i / 100, s = 0.05;
        uint32_t v[3];
        for (int c = 0; c < 3; c++) {
            double j[3];
            for (int a = 0; a < 3; a++) {
                seed = seed * 6364136223846793005ull + 1442695040888963407ull;
                j[a] = ((double)(seed >> 11) * 0x1p-53 - 0.5) * 2e-6;
            }
            int ax = i % 3; /* the plane: x, y or z = const */
            double p[3] = {cx + j[0], cy + j[1], cz + j[2]};
            double du = c == 1 ? s : 0, dv = c == 2 ? s : 0;
            p[(ax + 1) % 3] += du;
            p[(ax + 2) % 3] += dv;
            v[c] = tmesh_add_vertex(&t, (float)p[0], (float)p[1], (float)p[2]);
        }
        tmesh_add_tri(&t, v[0], v[1], v[2]);
    }
    prepared p = prep_tmesh(&t, 0);
    CHECK_OK(ctx, p.st);
    CHECK(p.w.report.components == 3000 && p.w.report.closed_components == 0);
    CHECK_MSG(p.w.report.flipped_triangles == 0, "%llu of 3000 lone triangles flipped",
              (unsigned long long)p.w.report.flipped_triangles);
    prep_free(&p);
    tmesh_free(&t);
}

static void time_armadillo(void)
{
    const char *path = "data/meshes/armadillo_s3.ply";
    struct stat sb;
    if (stat(path, &sb) != 0) {
        printf("SKIP armadillo_s3 timing: %s missing\n", path);
        return;
    }
    clvox_mesh *m = NULL;
    CHECK_OK(ctx, clvox_mesh_load(ctx, path, &m));
    if (!m) return;
    double best = 1e30;
    clvox_winding_report r;
    memset(&r, 0, sizeof r);
    for (int rep = 0; rep < 3; rep++) {
        clvox__winding_mesh w;
        CHECK_OK(ctx, clvox__winding_prepare(ctx, m, 0, &w));
        if (w.report.seconds < best) best = w.report.seconds;
        r = w.report;
        clvox__winding_mesh_free(&w);
    }
    const clvox_mesh_report *mr = clvox_mesh_get_report(m);
    printf("armadillo_s3: %llu triangles, prepared in %.3f s (best of 3): %llu components, %llu closed, "
           "%llu flipped, %llu caps, %llu merged\n",
           (unsigned long long)mr->triangles, best, (unsigned long long)r.components,
           (unsigned long long)r.closed_components, (unsigned long long)r.flipped_triangles,
           (unsigned long long)r.cap_triangles, (unsigned long long)r.merged_vertices);
    if (mr->closed) CHECK(r.cap_triangles == 0);
    clvox_mesh_destroy(m);
}

/* Oriented triangle t of the output and of the input the same, judged by
 * positions (indices may have been merged). */
static int same_by_position(const float *xyz, const uint32_t *a, const uint32_t *b)
{
    for (int k = 0; k < 3; k++) {
        int all = 1;
        for (int c = 0; c < 3 && all; c++)
            for (int d = 0; d < 3; d++)
                if (xyz[3 * a[c] + d] != xyz[3 * b[(c + k) % 3] + d]) {
                    all = 0;
                    break;
                }
        if (all) return 1;
    }
    return 0;
}

static int same_bytes(const void *a, const void *b, size_t n) { return n == 0 || !memcmp(a, b, n); }

/* Random damage to random closed meshes: flips, soup copies, removed and
 * duplicated triangles. Invariants: no failure, surface + caps closed, the
 * flip count is what it says, the result is deterministic; undamaged but
 * flipped and souped ones come back exactly in the original orientation. */
static void test_random_damage(void)
{
    int exact_ok = 0, chains_ok = 0, counts_ok = 0, det_ok = 0;
    const int rounds = 60;
    for (int r = 0; r < rounds; r++) {
        uint64_t seed = 1000 + (uint64_t)r;
        tmesh base = tmesh_random_closed(seed, 1 + r % 4, 2 + r % 3);
        tmesh m = {0};
        tmesh_append(&m, &base);
        int damage = r % 2; /* 0: flips and soup only (stays closed) */
        size_t nt0 = m.nt;
        for (size_t t = 0; t < nt0; t++) {
            uint64_t x = tmesh_rng_next(&seed);
            if (x % 3 == 0) flip_tri(&m, t);
            if ((x >> 8) % 5 == 0) { /* own copies of its corners */
                for (int c = 0; c < 3; c++) {
                    const float *p = base.xyz + 3 * base.tri[3 * t + c];
                    m.tri[3 * t + c] = tmesh_add_vertex(&m, p[0], p[1], p[2]);
                }
            }
        }
        if (damage) {
            tmesh d = {0};
            for (size_t i = 0; i < m.nv; i++) tmesh_add_vertex(&d, m.xyz[3 * i], m.xyz[3 * i + 1], m.xyz[3 * i + 2]);
            for (size_t t = 0; t < m.nt; t++) {
                uint64_t x = tmesh_rng_next(&seed);
                if (x % 17 == 0) continue; /* removed */
                const uint32_t *tr = m.tri + 3 * t;
                tmesh_add_tri(&d, tr[0], tr[1], tr[2]);
                if ((x >> 8) % 23 == 0) tmesh_add_tri(&d, tr[0], tr[2], tr[1]); /* a back-to-back copy */
                if ((x >> 16) % 29 == 0) tmesh_add_tri(&d, tr[0], tr[1], tr[2]); /* a duplicate */
            }
            tmesh_free(&m);
            m = d;
        }
        prepared p = prep_tmesh(&m, 0), q = prep_tmesh(&m, 0);
        CHECK_OK(ctx, p.st);
        CHECK_OK(ctx, q.st);
        if (p.st != CLVOX_OK || q.st != CLVOX_OK) {
            prep_free(&p);
            prep_free(&q);
            tmesh_free(&m);
            tmesh_free(&base);
            continue;
        }
        chains_ok += chain_closed(&p);
        uint64_t differ = 0;
        for (size_t t = 0; t < p.w.triangle_count; t++)
            differ += !same_by_position(m.xyz, p.w.tris + 3 * t, m.tri + 3 * t);
        counts_ok += p.w.triangle_count == m.nt && differ == p.w.report.flipped_triangles;
        det_ok += p.w.triangle_count == q.w.triangle_count && p.w.cap_count == q.w.cap_count &&
                  same_bytes(p.w.tris, q.w.tris, 3 * p.w.triangle_count * sizeof *p.w.tris) &&
                  same_bytes(p.w.caps, q.w.caps, 3 * p.w.cap_count * sizeof *p.w.caps) &&
                  same_bytes(p.w.apex, q.w.apex, 3 * p.w.apex_count * sizeof *p.w.apex);
        if (!damage) {
            size_t same = 0;
            for (size_t t = 0; t < base.nt; t++) same += same_by_position(m.xyz, p.w.tris + 3 * t, base.tri + 3 * t);
            int ok = same == base.nt && p.w.cap_count == 0 && p.w.report.cavities == 0 &&
                     p.w.report.closed_components == p.w.report.components;
            if (!ok)
                fprintf(stderr, "round %d: %zu of %zu as the original, %zu caps, %llu cavities\n", r, same, base.nt,
                        p.w.cap_count, (unsigned long long)p.w.report.cavities);
            exact_ok += ok;
        }
        prep_free(&p);
        prep_free(&q);
        tmesh_free(&m);
        tmesh_free(&base);
    }
    CHECK_MSG(chains_ok == rounds, "%d of %d chains closed", chains_ok, rounds);
    CHECK_MSG(counts_ok == rounds, "%d of %d flip counts right", counts_ok, rounds);
    CHECK_MSG(det_ok == rounds, "%d of %d deterministic", det_ok, rounds);
    CHECK_MSG(exact_ok == rounds / 2, "%d of %d repaired exactly", exact_ok, rounds / 2);
}

/* Two preparations of the same surface the same: report (but seconds),
 * triangles, caps, apexes, rims; b's mesh has `extra` more vertices (unused,
 * after a's), so its apex indices in the caps are shifted by that. */
static int same_prep(const clvox__winding_mesh *a, const clvox__winding_mesh *b, size_t nva, size_t extra)
{
    const clvox_winding_report *x = &a->report, *y = &b->report;
    if (x->merged_vertices != y->merged_vertices || x->welded_vertices != y->welded_vertices ||
        x->dropped_triangles != y->dropped_triangles || x->components != y->components ||
        x->closed_components != y->closed_components || x->cavities != y->cavities ||
        x->flipped_triangles != y->flipped_triangles || x->nonmanifold_edges != y->nonmanifold_edges ||
        x->nonorientable_components != y->nonorientable_components || x->boundary_edges != y->boundary_edges ||
        x->holes != y->holes || x->cap_triangles != y->cap_triangles || x->exact_points != y->exact_points)
        return 0;
    if (a->triangle_count != b->triangle_count || a->cap_count != b->cap_count || a->apex_count != b->apex_count ||
        a->rim_count != b->rim_count)
        return 0;
    if (!same_bytes(a->tris, b->tris, 3 * a->triangle_count * sizeof *a->tris) ||
        !same_bytes(a->apex, b->apex, 3 * a->apex_count * sizeof *a->apex) ||
        !same_bytes(a->rim, b->rim, 2 * a->rim_count * sizeof *a->rim))
        return 0;
    for (size_t i = 0; i < 3 * a->cap_count; i++) {
        uint32_t c = a->caps[i];
        if (b->caps[i] != (c >= nva ? c + extra : c)) return 0;
    }
    return 1;
}

/* A damaged random mesh (flips, soup copies, removed, back-to-back and
 * duplicated triangles), deterministic in the seed. */
static tmesh damaged_mesh(uint64_t seed, unsigned shells, unsigned n)
{
    tmesh base = tmesh_random_closed(seed, shells, n), m = {0};
    for (size_t i = 0; i < base.nv; i++)
        tmesh_add_vertex(&m, base.xyz[3 * i], base.xyz[3 * i + 1], base.xyz[3 * i + 2]);
    for (size_t t = 0; t < base.nt; t++) {
        uint64_t x = tmesh_rng_next(&seed);
        uint32_t a = base.tri[3 * t], b = base.tri[3 * t + 1], c = base.tri[3 * t + 2];
        if (x % 19 == 0) continue;
        if ((x >> 8) % 3 == 0) {
            uint32_t s = b;
            b = c;
            c = s;
        }
        if ((x >> 12) % 7 == 0) { /* own copies of its corners */
            const float *pa = base.xyz + 3 * a, *pb = base.xyz + 3 * b, *pc = base.xyz + 3 * c;
            a = tmesh_add_vertex(&m, pa[0], pa[1], pa[2]);
            b = tmesh_add_vertex(&m, pb[0], pb[1], pb[2]);
            c = tmesh_add_vertex(&m, pc[0], pc[1], pc[2]);
        }
        tmesh_add_tri(&m, a, b, c);
        if ((x >> 16) % 23 == 0) tmesh_add_tri(&m, a, c, b);
        if ((x >> 24) % 29 == 0) tmesh_add_tri(&m, a, b, c);
    }
    tmesh_free(&base);
    return m;
}

/* The edge pass sorts half-edges by blocks of vertices (v >> shift, shift
 * growing with the vertex count; 0 -- one vertex a block -- up to 2048
 * vertices). Unused vertices appended far away change the blocks and
 * nothing else: every mesh gives the same preparation at 0, 1, 4 and 10
 * block bits (and with welding). */
static void test_vertex_blocks(void)
{
    tmesh ms[9];
    int k = 0;
    for (int r = 0; r < 4; r++) ms[k++] = damaged_mesh(500 + (uint64_t)r, 1 + (unsigned)r % 3, 3 + (unsigned)r % 2);
    ms[k++] = tmesh_hollow_sphere(0, 0, 0, 2, 1, 10);
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    ms[k++] = tmesh_open_box(3, lo, hi, 4, 2, NULL);
    ms[k++] = tmesh_sphere_holes(7, 0, 0, 0, 1, 16, 5);
    ms[k++] = tmesh_sphere_flipped(8, 0, 0, 0, 1, 16, 40);
    ms[k++] = moebius_mesh(40); /* a conflict: which edge takes it depends on the edge order */
    int ok = 0, total = 0;
    for (int i = 0; i < k; i++) {
        CHECK_MSG(ms[i].nv <= 2048, "mesh %d has %zu vertices: not one vertex a block", i, ms[i].nv);
        for (int w = 0; w < 2; w++) {
            double weld = w ? 1e-3 : 0;
            prepared p = prep_tmesh(&ms[i], weld);
            CHECK_OK(ctx, p.st);
            static const size_t pad[3] = {2049, 8 * 2049, 512 * 2049}; /* shifts 1, 4, 10 */
            for (int q = 0; q < 3 && p.st == CLVOX_OK; q++) {
                tmesh big = {0};
                tmesh_append(&big, &ms[i]);
                size_t extra = pad[q] - ms[i].nv;
                for (size_t v = 0; v < extra; v++) tmesh_add_vertex(&big, 1000.0 + (double)v, -500.0, 250.0);
                prepared b = prep_tmesh(&big, weld);
                CHECK_OK(ctx, b.st);
                total++;
                if (b.st == CLVOX_OK && same_prep(&p.w, &b.w, ms[i].nv, extra)) ok++;
                else fprintf(stderr, "mesh %d weld %g: %zu vertices differ from %zu\n", i, weld, big.nv, ms[i].nv);
                prep_free(&b);
                tmesh_free(&big);
            }
            prep_free(&p);
        }
        tmesh_free(&ms[i]);
    }
    CHECK_MSG(ok == total && total == 9 * 2 * 3, "%d of %d block layouts agree", ok, total);
}

/* CLVOX__PREP_BORROW: the same preparation; the triangles left to the mesh
 * exactly when they would be its own, and clvox__winding_mesh_own_tris
 * then copies them. */
static void test_borrow(void)
{
    tmesh ms[6];
    ms[0] = tmesh_torus(0.5, 0.5, 0.5, 0.3, 0.1, 24, 12);
    ms[1] = tmesh_sphere_flipped(8, 0, 0, 0, 1, 16, 40);
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    ms[2] = tmesh_open_box(3, lo, hi, 4, 2, NULL);
    ms[3] = soup_of(&ms[0]);
    ms[4] = damaged_mesh(77, 2, 3);
    ms[5] = tmesh_hollow_sphere(0, 0, 0, 2, 1, 10); /* a cavity, already inwards */
    int borrowed = 0;
    for (int i = 0; i < 6; i++) {
        prepared p = prep_tmesh(&ms[i], 0);
        CHECK_OK(ctx, p.st);
        if (p.st != CLVOX_OK) {
            prep_free(&p);
            tmesh_free(&ms[i]);
            continue;
        }
        clvox__winding_mesh b;
        CHECK_OK(ctx, clvox__winding_prepare_flags(ctx, p.mesh, 0, CLVOX__PREP_BORROW, &b));
        const clvox_winding_report *r = &p.w.report;
        int own = r->merged_vertices == 0 && r->welded_vertices == 0 && r->dropped_triangles == 0 &&
                  r->flipped_triangles == 0;
        CHECK_MSG((b.tris == NULL) == own, "mesh %d: borrowed %d, expected %d", i, b.tris == NULL, own);
        if (own) CHECK(same_bytes(p.w.tris, ms[i].tri, 3 * ms[i].nt * sizeof *ms[i].tri));
        borrowed += b.tris == NULL;
        CHECK_OK(ctx, clvox__winding_mesh_own_tris(ctx, p.mesh, &b));
        CHECK_MSG(b.tris && same_prep(&p.w, &b, ms[i].nv, 0), "mesh %d: borrowed preparation differs", i);
        clvox__winding_mesh_free(&b);
        prep_free(&p);
        tmesh_free(&ms[i]);
    }
    CHECK_MSG(borrowed == 3, "%d borrowed", borrowed); /* the torus, the open box, the hollow sphere */
}

/* The nesting test on big shells: a 1.3 M-triangle hollow sphere, the
 * inner shell stored outwards (every inner vertex is tested). */
static void time_nesting(void)
{
    tmesh outer = tmesh_sphere(0, 0, 0, 2, 400), inner = tmesh_sphere(0.01, 0.02, 0.03, 1, 400), m = {0};
    tmesh_append(&m, &outer);
    tmesh_append(&m, &inner);
    prepared p = prep_tmesh(&m, 0);
    CHECK_OK(ctx, p.st);
    CHECK(p.w.report.cavities == 1 && p.w.report.flipped_triangles == inner.nt);
    printf("hollow sphere, %zu triangles, inner shell stored outwards: prepared in %.3f s\n", m.nt,
           p.w.report.seconds);
    prep_free(&p);
    tmesh_free(&m);
    tmesh_free(&outer);
    tmesh_free(&inner);
}

int main(void)
{
    clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
    o.host_only = 1;
    if (clvox_context_create(&o, &ctx) != CLVOX_OK) {
        fprintf(stderr, "cannot create a host-only context: %s\n", clvox_context_error(ctx));
        printf("0 passed, 1 failed\n");
        return 1;
    }
    test_closed_sphere();
    test_unchanged_closed();
    test_hollow();
    test_intersecting_boxes();
    test_nested_boxes();
    test_nesting_oracle();
    test_open_cube();
    test_tube();
    test_soup();
    test_zero_volume();
    test_crack_and_weld();
    test_weld_oracle();
    test_moebius();
    test_nonmanifold();
    test_one_triangle();
    test_far_flat_triangles();
    test_random_damage();
    test_vertex_blocks();
    test_borrow();
    time_nesting();
    time_armadillo();
    clvox_context_destroy(ctx);
    return test_report();
}
