/* SPDX-License-Identifier: Apache-2.0 */
/* The tetra method (Rueda et al.) against the ray method: two independent
 * algorithms, so any disagreement is a bug in one of them. Closed meshes in
 * general position: equal voxel for voxel, except centres within the ray
 * method's float rounding of the surface (about 1e-6 voxel), where tetra must
 * match the crossings counted in double (compare()). Grid-aligned meshes:
 * equal everywhere and the exact counts of the rule lo <= c < hi. Also: O
 * anywhere (centroid, bbox centre, inside, outside, on a voxel centre, on the
 * surface) gives the same voxels, slab depth does not matter, cavities stay
 * empty, overlapping shells give parity, the EXR records the method.
 * CLVOX_TETRA_STRESS=n adds n random meshes; CLVOX_TETRA_REAL_RES=n runs the
 * real meshes (data/meshes, scripts/fetch_meshes.sh) at n instead of 128. */
#include "test.h"
#include "meshgen.h"

#include <math.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>

static clvox_context *ctx;

static clvox_mesh *to_mesh(const tmesh *m)
{
    clvox_mesh *mesh = NULL;
    CHECK_OK(ctx, clvox_mesh_from_arrays(ctx, m->xyz, m->nv, m->tri, m->nt, &mesh));
    return mesh;
}

/* Grid: dims over box [lo, hi] (anisotropic allowed). */
static clvox_grid grid_dims(const double lo[3], const double hi[3], uint32_t x, uint32_t y, uint32_t z)
{
    clvox_grid_options o = CLVOX_GRID_OPTIONS_INIT;
    o.dims[0] = x;
    o.dims[1] = y;
    o.dims[2] = z;
    clvox_grid g;
    memset(&g, 0, sizeof g);
    CHECK_OK(ctx, clvox_grid_compute(ctx, &o, lo, hi, &g));
    return g;
}

static size_t voxels(const clvox_grid *g) { return (size_t)g->dims[0] * g->dims[1] * g->dims[2]; }

/* Voxelizes into a fresh buffer (caller frees). NULL on failure. */
static uint8_t *run(const clvox_mesh *mesh, const clvox_grid *g, const clvox_voxelize_options *o, uint64_t *filled)
{
    size_t n = voxels(g);
    uint8_t *v = malloc(n);
    clvox_stats st = CLVOX_STATS_INIT;
    clvox_status s = clvox_voxelize_to_memory(ctx, mesh, g, o, v, n, &st);
    CHECK_OK(ctx, s);
    if (s != CLVOX_OK) {
        free(v);
        return NULL;
    }
    uint64_t c = 0;
    for (size_t i = 0; i < n; i++) c += v[i];
    CHECK_MSG(c == st.filled_voxels, "counted %llu, stats %llu", (unsigned long long)c,
              (unsigned long long)st.filled_voxels);
    if (filled) *filled = c;
    return v;
}

/* Ray and tetra compared as the two parity methods (the ray method's
 * default winding number unions overlapping parts, the XOR cannot). */
static clvox_voxelize_options opts(clvox_method m)
{
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    o.method = m;
    o.inside = CLVOX_INSIDE_PARITY;
    return o;
}

/* Number of voxels where a and b differ; prints the first few. */
static size_t diff(const clvox_grid *g, const uint8_t *a, const uint8_t *b, const char *what)
{
    size_t n = voxels(g), d = 0;
    for (size_t i = 0; i < n; i++)
        if (a[i] != b[i]) {
            if (d < 4)
                fprintf(stderr, "  %s: voxel (%zu,%zu,%zu) %d vs %d\n", what, i % g->dims[0],
                        i / g->dims[0] % g->dims[1], i / ((size_t)g->dims[0] * g->dims[1]), a[i], b[i]);
            d++;
        }
    return d;
}

/* Edge sign with the ray method's tie rule (design.md), in double. */
static int edge_sign(double av, double aw, double bv, double bw, double *e)
{
    *e = av * bw - aw * bv;
    if (*e != 0) return *e > 0 ? 1 : -1;
    if (aw != bw) return aw > bw ? 1 : -1;
    if (bv != av) return bv > av ? 1 : -1;
    return 0;
}

/* The ray method's classification of centre (i,j,k) redone in double (grid
 * space as in grid.c: one float rounding per vertex): parity of the
 * crossings beyond the centre along +x. *dist = distance along x from the
 * centre to the nearest crossing. Reliable when *dist > ~1e-12. */
static int ray_double(const clvox_mesh *mesh, const clvox_grid *g, size_t i, size_t j, size_t k, double *dist)
{
    size_t nv, nt;
    const float *xyz = clvox_mesh_vertices(mesh, &nv);
    const uint32_t *tri = clvox_mesh_triangles(mesh, &nt);
    double off[3]; /* vertices are relative to it (grid.c moves the origin) */
    clvox_mesh_vertex_offset(mesh, off);
    int odd = 0;
    *dist = INFINITY;
    for (size_t t = 0; t < nt; t++) {
        double p[3][3];
        for (int c = 0; c < 3; c++)
            for (int a = 0; a < 3; a++)
                p[c][a] = (float)(((double)xyz[(size_t)tri[3 * t + c] * 3 + a] - (g->origin[a] - off[a])) / g->voxel_size[a] -
                                  0.5);
        double A[2] = {p[0][1] - (double)j, p[0][2] - (double)k};
        double B[2] = {p[1][1] - (double)j, p[1][2] - (double)k};
        double C[2] = {p[2][1] - (double)j, p[2][2] - (double)k};
        double eab, ebc, eca;
        int s1 = edge_sign(A[0], A[1], B[0], B[1], &eab);
        int s2 = edge_sign(B[0], B[1], C[0], C[1], &ebc);
        int s3 = edge_sign(C[0], C[1], A[0], A[1], &eca);
        if (s1 == 0 || s1 != s2 || s1 != s3) continue;
        double u = p[0][0] + (eca * (p[1][0] - p[0][0]) + eab * (p[2][0] - p[0][0])) / (eab + ebc + eca);
        odd ^= u > (double)i;
        if (fabs(u - (double)i) < *dist) *dist = fabs(u - (double)i);
    }
    return odd;
}

/* Compares ray (a) and tetra (b): every voxel must be equal. Both compute
 * in double and break ties by the same rule, so any difference is a bug in
 * one of them; the diagnostic shows the crossing count redone in double and
 * how far the centre is from the surface. */
static void compare(const char *name, const clvox_mesh *mesh, const clvox_grid *g, const uint8_t *a,
                    const uint8_t *b)
{
    size_t n = voxels(g), bad = 0, X = g->dims[0], Y = g->dims[1];
    for (size_t v = 0; v < n; v++) {
        if (a[v] == b[v]) continue;
        size_t i = v % X, j = v / X % Y, k = v / (X * Y);
        double dist;
        int exact = ray_double(mesh, g, i, j, k, &dist);
        if (bad++ < 4)
            fprintf(stderr,
                    "  %s %ux%ux%u: voxel (%zu,%zu,%zu) ray %d tetra %d (double count %d, %.3g from the surface)\n",
                    name, g->dims[0], g->dims[1], g->dims[2], i, j, k, a[v], b[v], exact, dist);
    }
    CHECK_MSG(bad == 0, "%s %ux%ux%u: %zu voxels differ between ray and tetra", name, g->dims[0], g->dims[1],
              g->dims[2], bad);
}

/* Runs ray and tetra with options `o` (method overwritten) and compares. */
static void equal_methods(const char *name, const clvox_mesh *mesh, const clvox_grid *g, clvox_voxelize_options o,
                          uint64_t *filled)
{
    o.method = CLVOX_METHOD_RAY;
    uint64_t fr = 0, ft = 0;
    uint8_t *a = run(mesh, g, &o, &fr);
    o.method = CLVOX_METHOD_TETRA;
    uint8_t *b = run(mesh, g, &o, &ft);
    if (a && b) compare(name, mesh, g, a, b);
    free(a);
    free(b);
    if (filled) *filled = ft;
}

/* tetra == ray on mesh m over its bounding box (+3%) at dims. */
static void same_as_ray(const char *name, const tmesh *m, uint32_t x, uint32_t y, uint32_t z)
{
    clvox_mesh *mesh = to_mesh(m);
    if (!mesh) return;
    const clvox_mesh_report *r = clvox_mesh_get_report(mesh);
    double lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        double e = (r->bbox_max[a] - r->bbox_min[a]) * 0.03;
        lo[a] = r->bbox_min[a] - e;
        hi[a] = r->bbox_max[a] + e;
    }
    clvox_grid g = grid_dims(lo, hi, x, y, z);
    uint64_t filled = 0;
    equal_methods(name, mesh, &g, opts(CLVOX_METHOD_TETRA), &filled);
    CHECK(filled > 0);
    clvox_mesh_destroy(mesh);
}

/* Grid with cubic voxels of size 1 and origin 0 over [0, x] x [0, y] x [0, z]:
 * voxel centres at i + 0.5, grid coordinate = world - 0.5 exactly. */
static clvox_grid unit_grid(uint32_t x, uint32_t y, uint32_t z)
{
    const double lo[3] = {0, 0, 0}, hi[3] = {x, y, z};
    return grid_dims(lo, hi, x, y, z);
}

/* ---- closed meshes in general position: tetra == ray bit for bit ---- */

static void test_general_position(void)
{
    static const uint32_t sizes[][3] = {{17, 17, 17}, {32, 20, 25}, {64, 64, 64}, {128, 128, 128}};
    enum { NM = 8 };
    tmesh m[NM];
    const char *names[NM] = {"sphere", "torus", "octahedron", "random1", "random3", "two-shells", "hollow",
                             "fine-sphere"};
    m[0] = tmesh_sphere(0.3183, 0.2718, 0.1414, 1.0, 12);
    m[1] = tmesh_torus(0.1, -0.2, 0.05, 1.0, 0.35, 24, 12);
    m[2] = tmesh_octahedron(0.31831, 0.27183, 0.14142, 1.1);
    m[3] = tmesh_random_closed(7, 1, 4);
    m[4] = tmesh_random_closed(11, 3, 3);
    m[5] = tmesh_sphere(0.1, 0.2, 0.3, 0.4, 6);
    tmesh other = tmesh_torus(1.3, 1.1, 0.9, 0.5, 0.2, 16, 8);
    tmesh_append(&m[5], &other);
    tmesh_free(&other);
    m[6] = tmesh_hollow_sphere(0.01, 0.02, 0.03, 1.0, 0.55, 10);
    m[7] = tmesh_sphere(-0.123, 0.456, 0.0789, 1.0, 64);
    for (int i = 0; i < NM; i++) {
        CHECK(tmesh_is_closed(&m[i]));
        size_t ns = sizeof sizes / sizeof sizes[0];
        /* 128^3 for a few meshes only, to keep the run short. */
        for (size_t k = 0; k < ns; k++)
            if (k + 1 < ns || i == 1 || i == 4 || i == 6 || i == 7)
                same_as_ray(names[i], &m[i], sizes[k][0], sizes[k][1], sizes[k][2]);
        tmesh_free(&m[i]);
    }
}

/* CLVOX_TETRA_STRESS=n: n more random meshes and grids (not in the default run). */
static void test_stress(void)
{
    const char *e = getenv("CLVOX_TETRA_STRESS");
    int n = e ? atoi(e) : 0;
    uint64_t rng = 12345;
    for (int i = 0; i < n; i++) {
        unsigned shells = 1 + (unsigned)(tmesh_rng_next(&rng) % 3), sub = 1 + (unsigned)(tmesh_rng_next(&rng) % 6);
        tmesh m = tmesh_random_closed(1000 + (uint64_t)i, shells, sub);
        uint32_t d[3];
        for (int a = 0; a < 3; a++) d[a] = 8 + (uint32_t)(tmesh_rng_next(&rng) % 200);
        same_as_ray("stress", &m, d[0], d[1], d[2]);
        tmesh_free(&m);
    }
}

/* ---- grid-aligned meshes: the documented rule, exact counts ---- */

static void test_grid_aligned(void)
{
    clvox_grid g = unit_grid(24, 20, 22);
    clvox_voxelize_options o = opts(CLVOX_METHOD_TETRA);
    struct { double lo[3], hi[3]; unsigned n; } boxes[] = {
        {{2.5, 3.5, 4.5}, {9.5, 8.5, 15.5}, 0},    /* corners on voxel centres */
        {{2, 3, 4}, {9, 8, 15}, 0},                /* corners on voxel corners */
        {{2.5, 3, 4.5}, {19, 8.5, 15}, 3},         /* mixed, subdivided: edges on rays */
        {{0.5, 0.5, 0.5}, {23.5, 19.5, 21.5}, 4},  /* touching the first and last centres */
        {{-3, -2.5, 1.5}, {5.5, 30, 6.5}, 2},      /* sticking out of the grid */
        {{3.25, 1.75, 2.5}, {11.75, 17.5, 9.125}, 5},
    };
    for (size_t i = 0; i < sizeof boxes / sizeof boxes[0]; i++) {
        tmesh t = boxes[i].n ? tmesh_box_subdivided(boxes[i].lo[0], boxes[i].lo[1], boxes[i].lo[2], boxes[i].hi[0],
                                                    boxes[i].hi[1], boxes[i].hi[2], boxes[i].n)
                             : tmesh_box(boxes[i].lo[0], boxes[i].lo[1], boxes[i].lo[2], boxes[i].hi[0],
                                         boxes[i].hi[1], boxes[i].hi[2]);
        clvox_mesh *mesh = to_mesh(&t);
        uint64_t want = expected_box_voxels(&g, boxes[i].lo, boxes[i].hi), got = 0;
        static const clvox_tetra_origin kinds[] = {CLVOX_TETRA_ORIGIN_CENTROID, CLVOX_TETRA_ORIGIN_BBOX_CENTER};
        for (int k = 0; mesh && k < 2; k++) {
            o.tetra_origin = kinds[k];
            equal_methods("box", mesh, &g, o, &got);
            CHECK_MSG(got == want && want > 0, "box %zu origin %d: %llu voxels, want %llu", i, k,
                      (unsigned long long)got, (unsigned long long)want);
        }
        clvox_mesh_destroy(mesh);
        tmesh_free(&t);
    }
    /* Slanted faces through many centres, edges along rays, vertices on
     * centres: the tie rule must be the ray method's, for every ray axis. */
    tmesh oct = tmesh_octahedron(12.5, 10.5, 11.5, 8);
    clvox_mesh *mesh = to_mesh(&oct);
    for (int axis = CLVOX_AXIS_DEFAULT; mesh && axis <= CLVOX_AXIS_Z; axis++) {
        o = opts(CLVOX_METHOD_TETRA);
        o.ray_axis = (clvox_axis)axis;
        uint64_t filled = 0;
        equal_methods("grid octahedron", mesh, &g, o, &filled);
        CHECK(filled > 0);
    }
    clvox_mesh_destroy(mesh);
    tmesh_free(&oct);
}

/* ---- the result does not depend on O ---- */

static void invariance(const char *name, const tmesh *t, const clvox_grid *g, const double (*points)[3], int np)
{
    clvox_mesh *mesh = to_mesh(t);
    if (!mesh) return;
    clvox_voxelize_options o = opts(CLVOX_METHOD_TETRA);
    uint64_t f0 = 0;
    uint8_t *ref = run(mesh, g, &o, &f0);
    CHECK(ref && f0 > 0);
    clvox_voxelize_options r = opts(CLVOX_METHOD_RAY);
    uint8_t *ray = run(mesh, g, &r, NULL);
    if (ref && ray) compare(name, mesh, g, ray, ref);
    for (int i = -1; ref && i < np; i++) {
        if (i < 0) {
            o.tetra_origin = CLVOX_TETRA_ORIGIN_BBOX_CENTER;
        } else {
            o.tetra_origin = CLVOX_TETRA_ORIGIN_POINT;
            memcpy(o.tetra_point, points[i], sizeof o.tetra_point);
        }
        uint8_t *v = run(mesh, g, &o, NULL);
        if (v) CHECK_MSG(diff(g, ref, v, name) == 0, "%s: origin %d changes the result", name, i);
        free(v);
    }
    free(ref);
    free(ray);
    clvox_mesh_destroy(mesh);
}

static void test_origin_invariance(void)
{
    /* General position, grid 40^3 over [0,1]^3 -> h = 1/40, centres at (i+0.5)/40. */
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    clvox_grid g = grid_dims(lo, hi, 40, 40, 40);
    tmesh t = tmesh_random_closed(21, 2, 3);
    const double pts[][3] = {
        {0.5, 0.5, 0.5},
        {11.5 / 40, 17.5 / 40, 23.5 / 40}, /* exactly a voxel centre */
        {-7.3, 12.1, 3.9},                  /* far outside the mesh and the grid */
        {2.0, -0.4, 0.45},
        {t.xyz[0], t.xyz[1], t.xyz[2]},     /* a mesh vertex: on the surface */
        {(2.0 * t.xyz[3 * t.tri[0]] + t.xyz[3 * t.tri[1]]) / 3,
         (2.0 * t.xyz[3 * t.tri[0] + 1] + t.xyz[3 * t.tri[1] + 1]) / 3,
         (2.0 * t.xyz[3 * t.tri[0] + 2] + t.xyz[3 * t.tri[1] + 2]) / 3}, /* on an edge */
    };
    invariance("random", &t, &g, pts, (int)(sizeof pts / sizeof pts[0]));
    tmesh_free(&t);

    /* Grid-aligned: every tie at once. Voxel centres at i + 0.5. */
    clvox_grid u = unit_grid(20, 18, 16);
    tmesh box = tmesh_box_subdivided(2.5, 3, 4.5, 15.5, 14, 12.5, 3);
    tmesh oct = tmesh_octahedron(10.5, 8.5, 8.5, 6);
    const double bp[][3] = {
        {9.0, 8.5, 8.5},   /* centre of the box: a voxel corner, half-integers */
        {7.5, 6.5, 5.5},   /* a voxel centre inside */
        {2.5, 7.5, 7.5},   /* a voxel centre on a box face */
        {2.5, 3, 4.5},     /* a box corner */
        {15.5, 14, 8.5},   /* on an edge */
        {40.5, -30.5, 3.5}, /* far outside, a voxel centre of the extended lattice */
        {0.5, 0.5, 0.5},   /* the first voxel centre, outside */
    };
    invariance("grid box", &box, &u, bp, (int)(sizeof bp / sizeof bp[0]));
    const double op[][3] = {
        {10.5, 8.5, 8.5},  /* the centre: a voxel centre on all internal planes */
        {10.5, 8.5, 14.5}, /* a vertex */
        {13.5, 8.5, 11.5}, /* a voxel centre on a face */
        {1.5, 1.5, 1.5},   /* outside, on a voxel centre */
        {10.5, 8.5, -20.5},
    };
    invariance("grid octahedron", &oct, &u, op, (int)(sizeof op / sizeof op[0]));
    tmesh_free(&box);
    tmesh_free(&oct);
}

/* ---- overlapping shells, cavities ---- */

static uint8_t at(const clvox_grid *g, const uint8_t *v, const double p[3])
{
    size_t i[3];
    for (int a = 0; a < 3; a++) i[a] = (size_t)floor((p[a] - g->origin[a]) / g->voxel_size[a]);
    return v[(i[2] * g->dims[1] + i[1]) * g->dims[0] + i[0]];
}

static void test_parity(void)
{
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    clvox_grid g = grid_dims(lo, hi, 48, 48, 48);
    double c1[3], c2[3];
    tmesh t = tmesh_random_overlap(5, 4, c1, c2);
    clvox_mesh *mesh = to_mesh(&t);
    if (mesh) {
        equal_methods("overlap", mesh, &g, opts(CLVOX_METHOD_TETRA), NULL);
        clvox_voxelize_options o = opts(CLVOX_METHOD_TETRA);
        uint8_t *v = run(mesh, &g, &o, NULL);
        double mid[3], only1[3], d = 0;
        for (int a = 0; a < 3; a++) d += (c1[a] - c2[a]) * (c1[a] - c2[a]);
        d = sqrt(d);
        for (int a = 0; a < 3; a++) {
            mid[a] = 0.5 * (c1[a] + c2[a]);
            only1[a] = c1[a] + 0.15 * (c1[a] - c2[a]) / d;
        }
        /* Parity: inside an odd number of shells. */
        if (v) CHECK(at(&g, v, mid) == 0 && at(&g, v, only1) == 1 && tmesh_point_inside(&t, mid) == 0);
        free(v);
    }
    clvox_mesh_destroy(mesh);
    tmesh_free(&t);

    tmesh h = tmesh_hollow_sphere(0.5, 0.5, 0.5, 0.45, 0.25, 12);
    mesh = to_mesh(&h);
    if (mesh) {
        clvox_voxelize_options o = opts(CLVOX_METHOD_TETRA);
        uint8_t *v = run(mesh, &g, &o, NULL);
        const double centre[3] = {0.5, 0.5, 0.5}, shell[3] = {0.5, 0.5, 0.85};
        if (v) CHECK(at(&g, v, centre) == 0 && at(&g, v, shell) == 1);
        /* The cavity holds O (centroid): still empty. With O in the shell too. */
        o.tetra_origin = CLVOX_TETRA_ORIGIN_POINT;
        o.tetra_point[0] = 0.5;
        o.tetra_point[1] = 0.5;
        o.tetra_point[2] = 0.85;
        uint8_t *w = run(mesh, &g, &o, NULL);
        if (v && w) CHECK(diff(&g, v, w, "hollow") == 0);
        free(v);
        free(w);
        equal_methods("hollow", mesh, &g, opts(CLVOX_METHOD_TETRA), NULL);
    }
    clvox_mesh_destroy(mesh);
    tmesh_free(&h);
}

/* ---- slabs are independent ---- */

static void test_slabs(void)
{
    const double lo[3] = {-1.1, -1.2, -1.05}, hi[3] = {1.15, 1.1, 1.2};
    clvox_grid g = grid_dims(lo, hi, 37, 33, 41);
    tmesh t = tmesh_torus(0.02, 0.01, -0.03, 0.8, 0.3, 20, 10);
    tmesh s = tmesh_sphere(0.03, 0.02, 0.01, 0.25, 8);
    tmesh_append(&t, &s);
    clvox_mesh *mesh = to_mesh(&t);
    clvox_voxelize_options o = opts(CLVOX_METHOD_TETRA);
    uint8_t *ref = mesh ? run(mesh, &g, &o, NULL) : NULL;
    static const uint32_t depths[] = {1, 3, 7, 41, 100};
    for (size_t i = 0; ref && i < sizeof depths / sizeof depths[0]; i++) {
        o.slab_depth = depths[i];
        uint8_t *v = run(mesh, &g, &o, NULL);
        if (v) CHECK_MSG(diff(&g, ref, v, "slabs") == 0, "slab depth %u differs", depths[i]);
        free(v);
    }
    free(ref);
    clvox_mesh_destroy(mesh);
    tmesh_free(&t);
    tmesh_free(&s);
}

/* ---- arguments, parameters text ---- */

static void test_arguments(void)
{
    tmesh t = tmesh_sphere(0.5, 0.5, 0.5, 0.4, 6);
    clvox_mesh *mesh = to_mesh(&t);
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    clvox_grid g = grid_dims(lo, hi, 8, 8, 8);
    uint8_t v[512];
    clvox_voxelize_options o = opts(CLVOX_METHOD_TETRA);
    o.tetra_origin = CLVOX_TETRA_ORIGIN_POINT;
    o.tetra_point[1] = NAN;
    CHECK_STATUS(ctx, clvox_voxelize_to_memory(ctx, mesh, &g, &o, v, sizeof v, NULL), CLVOX_ERR_INVALID_ARGUMENT);
    o.tetra_point[1] = 1e300; /* finite but out of float range in grid space */
    CHECK_STATUS(ctx, clvox_voxelize_to_memory(ctx, mesh, &g, &o, v, sizeof v, NULL), CLVOX_ERR_INVALID_ARGUMENT);
    o.tetra_origin = (clvox_tetra_origin)7;
    CHECK_STATUS(ctx, clvox_voxelize_to_memory(ctx, mesh, &g, &o, v, sizeof v, NULL), CLVOX_ERR_INVALID_ARGUMENT);
    clvox_mesh_destroy(mesh);
    tmesh_free(&t);

    /* Degenerate triangles (collinear corners, kept by the loader) give
     * flat tetrahedra: nothing, as they give no crossing to the ray method. */
    clvox_grid u = unit_grid(16, 16, 16);
    const double blo[3] = {2.5, 3.5, 4.5}, bhi[3] = {12.5, 11.5, 13};
    tmesh b = tmesh_box(blo[0], blo[1], blo[2], bhi[0], bhi[1], bhi[2]);
    uint32_t p = tmesh_add_vertex(&b, 3.5, 4.5, 5.5), q = tmesh_add_vertex(&b, 7.5, 8.5, 9.5),
             r = tmesh_add_vertex(&b, 9.5, 10.5, 11.5);
    tmesh_add_tri(&b, p, q, r);
    tmesh_add_tri(&b, 0, 1, 1 + 0 * r); /* repeated index: dropped by the loader */
    mesh = to_mesh(&b);
    uint64_t filled = 0;
    if (mesh) {
        equal_methods("degenerate", mesh, &u, opts(CLVOX_METHOD_TETRA), &filled);
        CHECK(filled == expected_box_voxels(&u, blo, bhi));
    }
    clvox_mesh_destroy(mesh);
    tmesh_free(&b);

    /* Not closed (a sphere with one triangle missing): any answer, but no failure. */
    tmesh soup = tmesh_sphere(8, 8, 8, 5, 6);
    soup.nt--;
    mesh = to_mesh(&soup);
    if (mesh) {
        clvox_voxelize_options to = opts(CLVOX_METHOD_TETRA);
        uint8_t *w = run(mesh, &u, &to, NULL);
        free(w);
    }
    clvox_mesh_destroy(mesh);
    tmesh_free(&soup);
}

/* ---- the EXR file says how it was made ---- */

static void test_exr(void)
{
    tmesh t = tmesh_torus(0.1, 0.2, 0.3, 0.7, 0.25, 16, 8);
    clvox_mesh *mesh = to_mesh(&t);
    const double lo[3] = {-0.9, -0.8, -0.1}, hi[3] = {1.1, 1.2, 0.7};
    clvox_grid g = grid_dims(lo, hi, 30, 28, 13);
    char path[512];
    snprintf(path, sizeof path, "%s/tetra.exr", test_tmpdir());
    clvox_voxelize_options o = opts(CLVOX_METHOD_TETRA);
    o.tetra_origin = CLVOX_TETRA_ORIGIN_BBOX_CENTER;
    clvox_stats st = CLVOX_STATS_INIT;
    uint8_t *mem = mesh ? run(mesh, &g, &o, NULL) : NULL;
    uint8_t *back = malloc(voxels(&g));
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    if (mem) {
        CHECK_OK(ctx, clvox_voxelize_to_exr(ctx, mesh, &g, &o, path, &st));
        CHECK_OK(ctx, clvox_volume_read(ctx, path, &info, back, voxels(&g)));
        CHECK_MSG(!strcmp(info.method, "tetra") && !strncmp(info.parameters, "origin=bbox_center(", 19),
                  "method '%s' parameters '%s'", info.method, info.parameters);
        CHECK(info.filled_voxels == st.filled_voxels && st.filled_voxels > 0);
        CHECK(diff(&g, mem, back, "exr") == 0);
        remove(path);
    }
    free(mem);
    free(back);
    clvox_mesh_destroy(mesh);
    tmesh_free(&t);
}

/* ---- real meshes (scripts/fetch_meshes.sh); CLVOX_TETRA_REAL_RES=n: grid n ---- */

static void test_real_meshes(void)
{
    static const char *names[] = {"cow", "bunny00", "armadillo", "knot1"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        char path[256];
        snprintf(path, sizeof path, "data/meshes/%s.off", names[i]);
        struct stat sb;
        if (stat(path, &sb) != 0) {
            printf("skip %s: %s missing (scripts/fetch_meshes.sh)\n", names[i], path);
            continue;
        }
        clvox_mesh *mesh = NULL;
        clvox_status st = clvox_mesh_load(ctx, path, &mesh);
        if (st != CLVOX_OK) {
            printf("skip %s: cannot load: %s\n", names[i], clvox_context_error(ctx));
            continue;
        }
        const clvox_mesh_report *r = clvox_mesh_get_report(mesh);
        clvox_grid_options go = CLVOX_GRID_OPTIONS_INIT;
        const char *res = getenv("CLVOX_TETRA_REAL_RES"); /* default 128 */
        go.resolution = res && atoi(res) > 0 ? (uint32_t)atoi(res) : 128;
        go.padding = 1;
        clvox_grid g;
        CHECK_OK(ctx, clvox_grid_compute(ctx, &go, r->bbox_min, r->bbox_max, &g));
        uint64_t filled = 0;
        CHECK(r->closed);
        equal_methods(names[i], mesh, &g, opts(CLVOX_METHOD_TETRA), &filled);
        printf("%s: %llu triangles, %ux%ux%u, %llu voxels filled, tetra == ray\n", names[i],
               (unsigned long long)r->triangles, g.dims[0], g.dims[1], g.dims[2], (unsigned long long)filled);
        clvox_mesh_destroy(mesh);
    }
}

int main(void)
{
    ctx = test_context();
    test_general_position();
    test_stress();
    test_grid_aligned();
    test_origin_invariance();
    test_parity();
    test_slabs();
    test_arguments();
    test_exr();
    test_real_meshes();
    clvox_context_destroy(ctx);
    return test_report();
}
