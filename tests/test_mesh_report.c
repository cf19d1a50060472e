/* SPDX-License-Identifier: Apache-2.0 */
/* The mesh report's analysis (src/mesh/mesh_report.c): the default implementation
 * (bucketed passes on the host threads) against the reference (the earlier
 * single-threaded code, kept for this), bit for bit, at 1, 2, 3 and 4
 * threads: box (with the sign of zero), degenerate triangles, volume,
 * boundary edges, non-manifold triangles and duplicates. On generated meshes
 * with every case the report counts (open, flipped, fans of 3+ triangles per
 * edge, shared and separate copies, -0 and +0, many unused vertices, large
 * enough for several threads) and on every mesh in data/meshes when present. */
#include "test.h"
#include "meshgen.h"
#include "mesh/mesh_internal.h"

#include <dirent.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static int compared;

static int same_double(double a, double b) { return !memcmp(&a, &b, sizeof a); }

static void compare(const char *what, const float *xyz, size_t nv, const uint32_t *tris, size_t nt)
{
    clvox_mesh_report ref, fast;
    clvox__mesh_volume vref, vfast;
    memset(&ref, 0, sizeof ref);
    CHECK_MSG(clvox__mesh_analyze(xyz, nv, tris, nt, 1, 1, &ref, &vref) == 0, "%s: reference failed", what);
    /* the signed sum and the permanents' bound, brute force */
    {
        const float *o = xyz + 3 * (size_t)tris[0];
        double v6 = 0, perm = 0;
        for (size_t t = 0; t < nt; t++) {
            double q[3][3];
            for (int c = 0; c < 3; c++)
                for (int a = 0; a < 3; a++) q[c][a] = (double)xyz[3 * (size_t)tris[3 * t + c] + a] - o[a];
            v6 += q[0][0] * (q[1][1] * q[2][2] - q[1][2] * q[2][1]) + q[0][1] * (q[1][2] * q[2][0] - q[1][0] * q[2][2]) +
                  q[0][2] * (q[1][0] * q[2][1] - q[1][1] * q[2][0]);
            perm += fabs(q[0][0]) * (fabs(q[1][1] * q[2][2]) + fabs(q[1][2] * q[2][1])) +
                    fabs(q[0][1]) * (fabs(q[1][2] * q[2][0]) + fabs(q[1][0] * q[2][2])) +
                    fabs(q[0][2]) * (fabs(q[1][0] * q[2][1]) + fabs(q[1][1] * q[2][0]));
        }
        CHECK_MSG(same_double(vref.vol6, v6), "%s: signed volume %.17g, brute force %.17g", what, vref.vol6, v6);
        CHECK_MSG(vref.perm_bound >= perm, "%s: permanents %.17g above their bound %.17g", what, perm,
                  vref.perm_bound);
    }
    for (int threads = 1; threads <= 4; threads++) {
        memset(&fast, 0xAB, sizeof fast);
        CHECK_MSG(clvox__mesh_analyze(xyz, nv, tris, nt, threads, 0, &fast, &vfast) == 0, "%s: failed", what);
        CHECK_MSG(same_double(vfast.vol6, vref.vol6) && same_double(vfast.perm_bound, vref.perm_bound),
                  "%s, %d threads: signed volume %.17g/%.17g bound %.17g/%.17g", what, threads, vfast.vol6, vref.vol6,
                  vfast.perm_bound, vref.perm_bound);
        int ok = fast.degenerate_triangles == ref.degenerate_triangles && fast.boundary_edges == ref.boundary_edges &&
                 fast.nonmanifold_faces == ref.nonmanifold_faces &&
                 fast.duplicate_triangles == ref.duplicate_triangles &&
                 same_double(fast.enclosed_volume, ref.enclosed_volume);
        for (int a = 0; a < 3; a++)
            ok &= same_double(fast.bbox_min[a], ref.bbox_min[a]) && same_double(fast.bbox_max[a], ref.bbox_max[a]);
        CHECK_MSG(ok,
                  "%s, %d threads: degenerate %llu/%llu boundary %llu/%llu nonmanifold %llu/%llu duplicates "
                  "%llu/%llu volume %.17g/%.17g box (%g %g %g)-(%g %g %g) / (%g %g %g)-(%g %g %g)",
                  what, threads, (unsigned long long)fast.degenerate_triangles,
                  (unsigned long long)ref.degenerate_triangles, (unsigned long long)fast.boundary_edges,
                  (unsigned long long)ref.boundary_edges, (unsigned long long)fast.nonmanifold_faces,
                  (unsigned long long)ref.nonmanifold_faces, (unsigned long long)fast.duplicate_triangles,
                  (unsigned long long)ref.duplicate_triangles, fast.enclosed_volume, ref.enclosed_volume,
                  fast.bbox_min[0], fast.bbox_min[1], fast.bbox_min[2], fast.bbox_max[0], fast.bbox_max[1],
                  fast.bbox_max[2], ref.bbox_min[0], ref.bbox_min[1], ref.bbox_min[2], ref.bbox_max[0],
                  ref.bbox_max[1], ref.bbox_max[2]);
        if (!ok) break;
    }
    if (getenv("TEST_VERBOSE")) printf("%s: nt %zu degenerate %llu boundary %llu nonmanifold %llu duplicates %llu\n", what, nt, (unsigned long long)ref.degenerate_triangles, (unsigned long long)ref.boundary_edges, (unsigned long long)ref.nonmanifold_faces, (unsigned long long)ref.duplicate_triangles);
    compared++;
}

static void compare_tmesh(const char *what, const tmesh *m) { compare(what, m->xyz, m->nv, m->tri, m->nt); }

/* Drops triangles with a repeated index (build_mesh does before the report). */
static void drop_repeated(tmesh *m)
{
    size_t k = 0;
    for (size_t t = 0; t < m->nt; t++) {
        uint32_t *u = m->tri + 3 * t;
        if (u[0] == u[1] || u[1] == u[2] || u[0] == u[2]) continue;
        memmove(m->tri + 3 * k++, u, 3 * sizeof *u);
    }
    m->nt = k;
}

static void generated(void)
{
    tmesh box = tmesh_box(0, 0, 0, 1, 1, 1);
    compare_tmesh("box", &box);

    /* Shared copy (every edge used 4 times), flipped shared copy, separate copy. */
    tmesh two = tmesh_box(0, 0, 0, 1, 1, 1);
    for (size_t t = 0; t < 12; t++) tmesh_add_tri(&two, box.tri[3 * t], box.tri[3 * t + 1], box.tri[3 * t + 2]);
    compare_tmesh("box twice (shared)", &two);
    tmesh flip = tmesh_box(0, 0, 0, 1, 1, 1);
    for (size_t t = 0; t < 12; t++) tmesh_add_tri(&flip, box.tri[3 * t], box.tri[3 * t + 2], box.tri[3 * t + 1]);
    compare_tmesh("box + flipped shared copy", &flip);
    tmesh sep = tmesh_box(0, 0, 0, 1, 1, 1);
    tmesh_append(&sep, &box);
    compare_tmesh("box twice (separate)", &sep);

    /* Open: the box without two triangles; one triangle flipped (same direction twice). */
    tmesh open = tmesh_box(0, 0, 0, 1, 1, 1);
    open.nt -= 2;
    compare_tmesh("open box", &open);
    tmesh f1 = tmesh_box(0, 0, 0, 1, 1, 1);
    uint32_t s = f1.tri[1];
    f1.tri[1] = f1.tri[2], f1.tri[2] = s;
    compare_tmesh("box with a flipped triangle", &f1);

    /* A fan of 5 triangles around one edge, and -0 / +0 corners. */
    tmesh fan = {0};
    tmesh_add_vertex(&fan, 0, 0, 0);
    tmesh_add_vertex(&fan, 0, 0, 1);
    for (int k = 0; k < 5; k++) {
        uint32_t v = tmesh_add_vertex(&fan, cos(k * 1.2), sin(k * 1.2), 0.5);
        tmesh_add_tri(&fan, 0, 1, v);
        if (k & 1) tmesh_add_tri(&fan, 1, 0, v);
    }
    fan.xyz[0] = -0.0f; /* vertex 0 at (-0, 0, 0), later vertices at +0 */
    uint32_t z = tmesh_add_vertex(&fan, 0, 0, 0);
    tmesh_add_tri(&fan, z, 2, 3);
    tmesh_add_tri(&fan, 0, 3, 2); /* the same positions as the one before: a duplicate */
    compare_tmesh("fan with -0", &fan);

    /* Large enough for several threads: random shells, doubled in every way,
     * with a few thousand unused vertices at the end and a wide index range. */
    tmesh rnd = tmesh_random_closed(7, 3, 40); /* 3 x 19200 triangles */
    compare_tmesh("random shells", &rnd);
    tmesh mix = tmesh_random_closed(7, 3, 40);
    size_t nt0 = mix.nt;
    for (size_t t = 0; t < nt0; t += 3) { /* shared copies of every third triangle, some flipped */
        uint32_t *u = mix.tri + 3 * t;
        if (t % 2) tmesh_add_tri(&mix, u[0], u[2], u[1]);
        else tmesh_add_tri(&mix, u[1], u[2], u[0]);
    }
    size_t nv0 = mix.nv;
    for (size_t v = 0; v < nv0; v += 5) { /* separate vertices at the same positions */
        const float *p = mix.xyz + 3 * v;
        tmesh_add_vertex(&mix, p[0], p[1], p[2]);
    }
    for (size_t t = 0; t < nt0; t += 7) { /* triangles on them: separate copies */
        uint32_t *u = mix.tri + 3 * t;
        if (u[0] % 5 == 0) tmesh_add_tri(&mix, (uint32_t)(nv0 + u[0] / 5), u[1], u[2]);
    }
    for (int k = 0; k < 5000; k++) tmesh_add_vertex(&mix, 5, 5, 5); /* unused */
    compare_tmesh("random shells with copies", &mix);
    /* Every triangle of a big mesh twice: all edges non-manifold. */
    tmesh dbl = tmesh_random_closed(11, 2, 60);
    nt0 = dbl.nt;
    for (size_t t = 0; t < nt0; t++) {
        uint32_t *u = dbl.tri + 3 * t;
        tmesh_add_tri(&dbl, u[2], u[0], u[1]);
    }
    compare_tmesh("every triangle twice", &dbl);

    /* A triangle soup: random triangles over a small lattice of positions,
     * vertices repeated (so equal positions under different indices). */
    tmesh soup = {0};
    uint64_t rng = 12345;
    for (int v = 0; v < 3000; v++)
        tmesh_add_vertex(&soup, (double)(tmesh_rng_next(&rng) % 6), (double)(tmesh_rng_next(&rng) % 6),
                         (double)(tmesh_rng_next(&rng) % 6));
    for (int t = 0; t < 60000; t++)
        tmesh_add_tri(&soup, (uint32_t)(tmesh_rng_next(&rng) % 3000), (uint32_t)(tmesh_rng_next(&rng) % 3000),
                      (uint32_t)(tmesh_rng_next(&rng) % 3000));
    drop_repeated(&soup);
    compare_tmesh("lattice soup", &soup);
    /* Few vertices, many triangles between them (long runs per edge). */
    tmesh dense = {0};
    for (int v = 0; v < 12; v++) tmesh_add_vertex(&dense, v % 3, v / 3 % 2, v / 6);
    for (int t = 0; t < 30000; t++)
        tmesh_add_tri(&dense, (uint32_t)(tmesh_rng_next(&rng) % 12), (uint32_t)(tmesh_rng_next(&rng) % 12),
                      (uint32_t)(tmesh_rng_next(&rng) % 12));
    drop_repeated(&dense);
    compare_tmesh("dense soup", &dense);
    /* Vertex indices near 2^23: many edge buckets. */
    tmesh wide = tmesh_random_closed(3, 1, 50);
    size_t shift = ((size_t)1 << 23) - wide.nv;
    float *grown = calloc(3 * (wide.nv + shift), sizeof *grown);
    if (!grown) exit(1);
    memcpy(grown + 3 * shift, wide.xyz, 3 * wide.nv * sizeof *grown);
    for (size_t i = 0; i < 3 * wide.nt; i++) wide.tri[i] += (uint32_t)shift;
    compare("random shell at indices near 2^23", grown, wide.nv + shift, wide.tri, wide.nt);
    free(grown);

    tmesh *all[] = {&box, &two, &flip, &sep, &open, &f1, &fan, &rnd, &mix, &dbl, &soup, &dense, &wide};
    for (size_t i = 0; i < sizeof all / sizeof all[0]; i++) tmesh_free(all[i]);
}

static void real_meshes(clvox_context *ctx)
{
    DIR *d = opendir("data/meshes");
    if (!d) {
        printf("SKIP data/meshes: not present\n");
        return;
    }
    struct dirent *e;
    char path[1400];
    int quick = getenv("CLVOX_QUICK") != NULL;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.') continue;
        if (quick && strstr(e->d_name, "_s3")) continue;
        snprintf(path, sizeof path, "data/meshes/%s", e->d_name);
        clvox_mesh *m = NULL;
        if (clvox_mesh_load(ctx, path, &m) != CLVOX_OK) continue; /* some are broken on purpose */
        size_t nv, nt;
        const float *xyz = clvox_mesh_vertices(m, &nv);
        const uint32_t *tris = clvox_mesh_triangles(m, &nt);
        compare(path, xyz, nv, tris, nt);
        clvox_mesh_destroy(m);
    }
    closedir(d);
}

int main(void)
{
    clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
    o.host_only = 1;
    clvox_context *ctx = NULL;
    CHECK_OK(NULL, clvox_context_create(&o, &ctx));
    if (!ctx) return test_report();
    generated();
    real_meshes(ctx);
    printf("%d meshes compared\n", compared);
    CHECK(compared > 12);
    clvox_context_destroy(ctx);
    return test_report();
}
