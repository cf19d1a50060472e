/* SPDX-License-Identifier: Apache-2.0 */
/* How many of today's exact winding points a certified far field would
 * decide (issue 35; src/winding/far_field.c). Not a test.
 *
 *   bench_far_field MESH [N [JITTER [TERMS]]]
 *       MESH made a soup (every triangle its own three vertices), each
 *       vertex jittered by JITTER (default 1e-6) of the box's longest
 *       extent, prepared as the library prepares it for winding numbers
 *       (clvox__winding_prepare: caps), and every voxel centre of the N^3
 *       grid (default 64, clvox_grid_compute) classified w = K - w_caps >
 *       1/2 + 2^-30 three times, by best-first refinement of a cap tree built as
 *       src/winding/winding.c builds it (median splits, 4 caps a leaf,
 *       leaves evaluated exactly, a frontier of at most 256 nodes):
 *         today: each node 0 +- min(count/2, area / 4pi dbox^2), or the
 *                dipole +- 2ar/(d-r)^3, or dipole + quadrupole +- 3s/(d-r)^4
 *                (kernels/winding_bounds.h, in double, without its float margins);
 *         today4k: the same with a frontier of 4096 nodes (a full
 *                frontier evaluates the node it would split exactly);
 *         ff:    the same candidates plus the expansion truncated after 1 ..
 *                TERMS (default 6) terms with far_field.h's tail bound.
 *       K (the signed crossings of surface + caps beyond the centre along
 *       +z) comes from a plain double crossing test (ties counted).
 *       Prints, per method, the points that needed exact caps, the exact
 *       cap evaluations, the node estimates, and how many of today's exact
 *       points the far field decides without any exact cap. Every point is
 *       evaluated alone (the kernels' interpolation along rays and the
 *       rays decided by clvox_caps_far are left out: both methods would
 *       gain from them alike). */
#include "clvox.h"
#include "core/internal.h"
#include "winding/far_field.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define FOUR_PI (4.0 * 3.14159265358979323846)
#define LEAF 4
#define FRONTIER 256
#define FRONTIER_BIG 4096
#define TIE 9.313225746154785e-10

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static uint64_t rng = 0x243f6a8885a308d3ull;
static double rnds(void)
{
    uint64_t z = (rng += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return 2.0 * ((double)(z >> 11) * 0x1p-53) - 1.0;
}

typedef struct node {
    double lo[3], hi[3];
    double area, half, second; /* second: int |y - c|^2 dA */
    uint32_t child, first, count;
    clvox__ff ff;              /* about the box centre: moments, radius */
} node;

static double *caps; /* 9 per cap */
static uint32_t *order;
static node *nodes;
static size_t node_count;

typedef struct key {
    double k;
    uint32_t i;
} key;
static int cmp_key(const void *a, const void *b)
{
    const key *x = a, *y = b;
    return x->k < y->k ? -1 : x->k > y->k ? 1 : (x->i > y->i) - (x->i < y->i);
}

static void build(size_t n, int terms)
{
    order = malloc(n * sizeof *order);
    nodes = malloc(2 * (n / LEAF + 2) * sizeof *nodes);
    key *keys = malloc(n * sizeof *keys);
    uint32_t *stack = malloc(2 * (n / LEAF + 2) * sizeof *stack), *post = malloc(2 * (n / LEAF + 2) * sizeof *post);
    if (!order || !nodes || !keys || !stack || !post) exit((fprintf(stderr, "out of memory\n"), 1));
    for (size_t i = 0; i < n; i++) order[i] = (uint32_t)i;
    size_t sp = 0, np = 0;
    node_count = 1;
    nodes[0].first = 0, nodes[0].count = (uint32_t)n;
    stack[sp++] = 0;
    while (sp) {
        const uint32_t id = stack[--sp];
        post[np++] = id;
        node *nd = &nodes[id];
        double clo[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, chi[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
        for (int a = 0; a < 3; a++) nd->lo[a] = DBL_MAX, nd->hi[a] = -DBL_MAX;
        for (uint32_t i = nd->first; i < nd->first + nd->count; i++) {
            const double *p = caps + 9 * (size_t)order[i];
            for (int a = 0; a < 3; a++) {
                for (int c = 0; c < 3; c++) nd->lo[a] = fmin(nd->lo[a], p[3 * c + a]), nd->hi[a] = fmax(nd->hi[a], p[3 * c + a]);
                const double m = p[a] + p[3 + a] + p[6 + a];
                clo[a] = fmin(clo[a], m), chi[a] = fmax(chi[a], m);
            }
        }
        nd->child = 0;
        nd->half = 0.5 * nd->count;
        if (nd->count <= LEAF) continue;
        int ax = 0;
        for (int a = 1; a < 3; a++)
            if (chi[a] - clo[a] > chi[ax] - clo[ax]) ax = a;
        for (uint32_t i = 0; i < nd->count; i++) {
            const double *p = caps + 9 * (size_t)order[nd->first + i];
            keys[i].k = p[ax] + p[3 + ax] + p[6 + ax];
            keys[i].i = order[nd->first + i];
        }
        qsort(keys, nd->count, sizeof *keys, cmp_key);
        for (uint32_t i = 0; i < nd->count; i++) order[nd->first + i] = keys[i].i;
        const uint32_t half = (nd->count + LEAF - 1) / LEAF / 2 * LEAF;
        const uint32_t c = (uint32_t)node_count;
        node_count += 2;
        nd->child = c;
        nodes[c].first = nd->first, nodes[c].count = half;
        nodes[c + 1].first = nd->first + half, nodes[c + 1].count = nd->count - half;
        stack[sp++] = c;
        stack[sp++] = c + 1;
    }
    /* expansions bottom-up: leaves from their caps, the others by shifting
     * their children's; radius and second moment exact from the caps */
    for (size_t k = np; k-- > 0;) {
        node *nd = &nodes[post[k]];
        double c[3];
        for (int a = 0; a < 3; a++) c[a] = 0.5 * (nd->lo[a] + nd->hi[a]);
        clvox__ff_init(&nd->ff, terms, c);
        double r = 0.0, second = 0.0;
        for (uint32_t i = nd->first; i < nd->first + nd->count; i++) {
            const double *p = caps + 9 * (size_t)order[i];
            double g[3], gc2 = 0, spread = 0, e1[3], e2[3];
            for (int a = 0; a < 3; a++) {
                g[a] = (p[a] + p[3 + a] + p[6 + a]) / 3.0;
                gc2 += (g[a] - c[a]) * (g[a] - c[a]);
                e1[a] = p[3 + a] - p[a], e2[a] = p[6 + a] - p[a];
            }
            for (int v = 0; v < 3; v++) {
                double d2 = 0;
                for (int a = 0; a < 3; a++) d2 += (p[3 * v + a] - c[a]) * (p[3 * v + a] - c[a]), spread += (p[3 * v + a] - g[a]) * (p[3 * v + a] - g[a]);
                r = fmax(r, sqrt(d2));
            }
            const double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2], cz = e1[0] * e2[1] - e1[1] * e2[0];
            second += 0.5 * sqrt(cx * cx + cy * cy + cz * cz) * (gc2 + spread / 12.0);
        }
        if (nd->child == 0) {
            clvox__ff_add_triangles(&nd->ff, caps + 0, 0);
            for (uint32_t i = nd->first; i < nd->first + nd->count; i++)
                clvox__ff_add_triangles(&nd->ff, caps + 9 * (size_t)order[i], 1);
        } else {
            clvox__ff_add_shifted(&nd->ff, &nodes[nd->child].ff);
            clvox__ff_add_shifted(&nd->ff, &nodes[nd->child + 1].ff);
        }
        nd->ff.radius = r * (1.0 + 1e-12); /* the exact one: tighter than the shifts' */
        nd->area = nd->ff.area;
        nd->second = second * (1.0 + 1e-12);
    }
    free(keys), free(stack), free(post);
}

/* A node's estimate and bound seen from p: today's candidates, and with
 * `ff` the far field's too. */
static void estimate(const node *nd, const double p[3], int ff, double *est, double *err)
{
    double db2 = 0;
    for (int a = 0; a < 3; a++) {
        const double g = fmax(fmax(nd->lo[a] - p[a], p[a] - nd->hi[a]), 0.0);
        db2 += g * g;
    }
    double e = 0, b = nd->half;
    if (db2 > 0) b = fmin(b, nd->area / FOUR_PI / db2 * 1.000001);
    const double *c = nd->ff.centre, r = nd->ff.radius, a = nd->area / FOUR_PI;
    const double x[3] = {c[0] - p[0], c[1] - p[1], c[2] - p[2]};
    const double d2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2], d = sqrt(d2), dm = d * (1 - 1e-14) - r;
    if (dm > 0) {
        const double N[3] = {nd->ff.m[0][0] / FOUR_PI, nd->ff.m[1][0] / FOUR_PI, nd->ff.m[2][0] / FOUR_PI};
        const double nx = N[0] * x[0] + N[1] * x[1] + N[2] * x[2];
        const double e1 = a / (dm * dm) * (2 * r / dm * 1.000001 + 8e-6);
        if (e1 < b) e = nx / (d2 * d), b = e1;
        if (nd->ff.terms >= 2) {
            double M[3][3], tr = 0, qf = 0; /* M_ji = int n_j delta_i dA / 4pi */
            for (int j = 0; j < 3; j++)
                for (int i = 0; i < 3; i++) M[j][i] = nd->ff.m[j][clvox__ff_mono(i == 0, i == 1, i == 2)] / FOUR_PI;
            for (int i = 0; i < 3; i++) tr += M[i][i];
            for (int i = 0; i < 3; i++)
                for (int j = 0; j < 3; j++) qf += x[i] * x[j] * ((i == j ? tr : 0.0) - 1.5 * (M[i][j] + M[j][i]));
            const double e2 = 3 * nd->second / FOUR_PI / (dm * dm * dm * dm) * 1.000001 + a / (dm * dm) * (8e-6 + 4e-5 * r / dm);
            if (e2 < b) e = (nx * d2 + qf) / (d2 * d2 * d), b = e2;
        }
        if (ff) {
            double fe, fb;
            if (clvox__ff_best(&nd->ff, p, &fe, &fb) && fb < b) e = fe, b = fb;
        }
    }
    *est = e;
    *err = b;
}

typedef struct result {
    long exact_points, exact_caps, estimates;
} result;

/* Best-first refinement at p (kernels/winding_inside.h's order: the
 * largest bound first); returns inside (1) / outside (0); *caps_used: the
 * caps evaluated exactly. */
static int inside(int K, const double p[3], int ff, int frontier, long *caps_used, long *ests)
{
    const double thr = 0.5 + TIE;
    static uint32_t st[FRONTIER_BIG];
    static double se[FRONTIER_BIG], sb[FRONTIER_BIG];
    int sp = 1;
    st[0] = 0;
    estimate(&nodes[0], p, ff, &se[0], &sb[0]);
    (*ests)++;
    double S = 0;
    long nf = 0; /* exact caps */
    for (;;) {
        double B = 0, E = 0;
        int best = 0;
        for (int i = 0; i < sp; i++) {
            B += sb[i], E += se[i];
            if (sb[i] > sb[best]) best = i;
        }
        B = B * 1.000001 + 1e-12 + (double)nf * 4e-16;
        const double w = K - S - E;
        if (w - B > thr) return *caps_used = nf, 1;
        if (w + B <= thr) return *caps_used = nf, 0;
        if (sp == 0) return *caps_used = nf, w > thr;
        const uint32_t id = st[best];
        st[best] = st[sp - 1], se[best] = se[sp - 1], sb[best] = sb[sp - 1];
        sp--;
        const node *nd = &nodes[id];
        if (nd->child == 0 || sp + 2 > frontier) {
            for (uint32_t i = nd->first; i < nd->first + nd->count; i++) S += clvox__ff_tri_exact(caps + 9 * (size_t)order[i], p);
            nf += nd->count;
        } else {
            for (int c = 0; c < 2; c++) {
                st[sp] = nd->child + (uint32_t)c;
                estimate(&nodes[st[sp]], p, ff, &se[sp], &sb[sp]);
                (*ests)++;
                sp++;
            }
        }
    }
}

typedef struct cross {
    float z;
    int8_t s;
} cross;

int main(int argc, char **argv)
{
    if (argc < 2) return fprintf(stderr, "usage: bench_far_field MESH [N [JITTER [TERMS]]]\n"), 2;
    const uint32_t N = argc > 2 ? (uint32_t)atoi(argv[2]) : 64;
    const double jitter = argc > 3 ? atof(argv[3]) : 1e-6;
    const int terms = argc > 4 ? atoi(argv[4]) : 6;
    clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
    co.host_only = 1;
    clvox_context *ctx = NULL;
    clvox_mesh *in = NULL, *soup = NULL;
    if (clvox_context_create(&co, &ctx) != CLVOX_OK || clvox_mesh_load(ctx, argv[1], &in) != CLVOX_OK)
        return fprintf(stderr, "%s\n", ctx ? clvox_context_error(ctx) : "no context"), 1;
    size_t nv, nt;
    const float *xyz = clvox_mesh_vertices(in, &nv);
    const uint32_t *tri = clvox_mesh_triangles(in, &nt);
    const clvox_mesh_report *rep = clvox_mesh_get_report(in);
    double ext = 0;
    for (int a = 0; a < 3; a++) ext = fmax(ext, rep->bbox_max[a] - rep->bbox_min[a]);
    float *sx = malloc(9 * nt * sizeof *sx);
    uint32_t *si = malloc(3 * nt * sizeof *si);
    if (!sx || !si) return 1;
    for (size_t t = 0; t < nt; t++)
        for (int c = 0; c < 3; c++) {
            si[3 * t + c] = (uint32_t)(3 * t + c);
            for (int a = 0; a < 3; a++) sx[9 * t + 3 * c + a] = (float)(xyz[3 * tri[3 * t + c] + a] + jitter * ext * rnds());
        }
    if (clvox_mesh_from_arrays(ctx, sx, 3 * nt, si, nt, &soup) != CLVOX_OK) return fprintf(stderr, "%s\n", clvox_context_error(ctx)), 1;
    double t0 = now();
    clvox__winding_mesh wm;
    if (clvox__winding_prepare(ctx, soup, 0.0, &wm) != CLVOX_OK) return fprintf(stderr, "%s\n", clvox_context_error(ctx)), 1;
    const float *V = soup->xyz;
    const size_t snv = soup->vertex_count;
    printf("soup: %zu triangles, jitter %g of %g, %zu caps, %zu oriented triangles (prep %.2f s)\n", nt, jitter, ext,
           wm.cap_count, wm.triangle_count, now() - t0);
    caps = malloc(9 * wm.cap_count * sizeof *caps);
    if (!caps) return 1;
    for (size_t c = 0; c < wm.cap_count; c++)
        for (int v = 0; v < 3; v++) {
            const uint32_t i = wm.caps[3 * c + v];
            const float *q = i < snv ? V + 3 * (size_t)i : wm.apex + 3 * (size_t)(i - snv);
            for (int a = 0; a < 3; a++) caps[9 * c + 3 * v + a] = q[a];
        }
    t0 = now();
    build(wm.cap_count, terms);
    printf("cap tree: %zu nodes, terms %d (build %.2f s)\n", node_count, terms, now() - t0);

    clvox_grid_options go = CLVOX_GRID_OPTIONS_INIT;
    go.resolution = N;
    clvox_grid g;
    if (clvox_grid_compute(ctx, &go, rep->bbox_min, rep->bbox_max, &g) != CLVOX_OK) return 1;
    double o[3];
    for (int a = 0; a < 3; a++) o[a] = g.origin[a] - in->offset[a] + 0.5 * g.voxel_size[a];
    /* K: signed crossings along +z per column (surface + caps) */
    const size_t ncol = (size_t)g.dims[0] * g.dims[1], nall = wm.triangle_count + wm.cap_count;
    size_t *cn = calloc(ncol + 1, sizeof *cn);
    cross **cl = calloc(ncol, sizeof *cl);
    size_t *cc = calloc(ncol, sizeof *cc);
    if (!cn || !cl || !cc) return 1;
    long ties = 0;
    for (size_t t = 0; t < nall; t++) {
        double P[3][3];
        for (int v = 0; v < 3; v++)
            for (int a = 0; a < 3; a++) {
                if (t < wm.triangle_count) P[v][a] = V[3 * (size_t)wm.tris[3 * t + v] + a];
                else P[v][a] = caps[9 * (t - wm.triangle_count) + 3 * v + a];
            }
        double lo[2], hi[2];
        for (int a = 0; a < 2; a++) lo[a] = fmin(P[0][a], fmin(P[1][a], P[2][a])), hi[a] = fmax(P[0][a], fmax(P[1][a], P[2][a]));
        long i0 = (long)ceil((lo[0] - o[0]) / g.voxel_size[0]), i1 = (long)floor((hi[0] - o[0]) / g.voxel_size[0]);
        long j0 = (long)ceil((lo[1] - o[1]) / g.voxel_size[1]), j1 = (long)floor((hi[1] - o[1]) / g.voxel_size[1]);
        for (long j = j0 < 0 ? 0 : j0; j <= j1 && j < (long)g.dims[1]; j++)
            for (long i = i0 < 0 ? 0 : i0; i <= i1 && i < (long)g.dims[0]; i++) {
                const double px = o[0] + i * g.voxel_size[0], py = o[1] + j * g.voxel_size[1];
                double e[3];
                for (int k = 0; k < 3; k++) { /* canonical edge functions: shared edges agree */
                    const double *A = P[k], *Bv = P[(k + 1) % 3];
                    const int sw = A[0] > Bv[0] || (A[0] == Bv[0] && A[1] > Bv[1]);
                    const double *a = sw ? Bv : A, *b = sw ? A : Bv;
                    const double f = (b[0] - a[0]) * (py - a[1]) - (b[1] - a[1]) * (px - a[0]);
                    e[k] = sw ? -f : f;
                }
                int s = 0;
                if (e[0] > 0 && e[1] > 0 && e[2] > 0) s = 1;
                else if (e[0] < 0 && e[1] < 0 && e[2] < 0) s = -1;
                else {
                    if ((e[0] == 0 || e[1] == 0 || e[2] == 0)) ties++;
                    continue;
                }
                const double sum = e[0] + e[1] + e[2];
                const double z = (e[1] * P[0][2] + e[2] * P[1][2] + e[0] * P[2][2]) / sum;
                const size_t col = (size_t)j * g.dims[0] + (size_t)i;
                if (cn[col] == cc[col]) {
                    cc[col] = cc[col] ? 2 * cc[col] : 8;
                    cl[col] = realloc(cl[col], cc[col] * sizeof **cl);
                    if (!cl[col]) return 1;
                }
                cl[col][cn[col]++] = (cross){(float)z, (int8_t)s};
            }
    }
    printf("grid %ux%ux%u, h %.4g; crossing ties %ld\n", g.dims[0], g.dims[1], g.dims[2], g.voxel_size[0], ties);
    result R[3];
    memset(R, 0, sizeof R);
    long today_exact = 0, ff_decided = 0, differ = 0, inside_n = 0;
    long hist[3][5] = {{0}}; /* exact caps: 0, 1-16, 17-256, 257-4096, more */
    double tm[3] = {0, 0, 0};
    for (uint32_t j = 0; j < g.dims[1]; j++)
        for (uint32_t i = 0; i < g.dims[0]; i++) {
            const size_t col = (size_t)j * g.dims[0] + i;
            for (uint32_t k = 0; k < g.dims[2]; k++) {
                const double p[3] = {o[0] + i * g.voxel_size[0], o[1] + j * g.voxel_size[1], o[2] + k * g.voxel_size[2]};
                int K = 0;
                for (size_t c = 0; c < cn[col]; c++) K += (double)cl[col][c].z > p[2] ? cl[col][c].s : 0;
                int ans[3];
                long used[3];
                for (int m = 0; m < 3; m++) {
                    const double ts = now();
                    ans[m] = inside(K, p, m == 2, m == 1 ? FRONTIER_BIG : FRONTIER, &used[m], &R[m].estimates);
                    tm[m] += now() - ts;
                    R[m].exact_caps += used[m];
                    R[m].exact_points += used[m] > 0;
                    long *h = hist[m];
                    h[used[m] == 0 ? 0 : used[m] <= 16 ? 1 : used[m] <= 256 ? 2 : used[m] <= 4096 ? 3 : 4]++;
                }
                differ += ans[0] != ans[1] || ans[0] != ans[2];
                inside_n += ans[0];
                if (used[0] > 0) {
                    today_exact++;
                    ff_decided += used[2] == 0;
                }
            }
        }
    const double pts = (double)g.dims[0] * g.dims[1] * g.dims[2];
    printf("points %.0f, inside %ld (volume %.6g; the mesh's %.6g), answers differing %ld\n", pts, inside_n,
           inside_n * g.voxel_size[0] * g.voxel_size[1] * g.voxel_size[2], rep->enclosed_volume, differ);
    const char *nm[3] = {"today", "today4k", "ff"};
    for (int m = 0; m < 3; m++) {
        long *h = hist[m];
        printf("%-7s exact points %ld, exact caps %ld (%.0f per exact point), node estimates %ld, host %.2f s; "
               "exact caps per point: 0: %ld, 1-16: %ld, 17-256: %ld, 257-4096: %ld, more: %ld\n",
               nm[m], R[m].exact_points, R[m].exact_caps, R[m].exact_points ? (double)R[m].exact_caps / R[m].exact_points : 0.0,
               R[m].estimates, tm[m], h[0], h[1], h[2], h[3], h[4]);
    }
    printf("of today's %ld exact points the far field decides %ld with no exact cap\n", today_exact, ff_decided);
    clvox__winding_mesh_free(&wm);
    clvox_mesh_destroy(soup);
    clvox_mesh_destroy(in);
    clvox_context_destroy(ctx);
    return 0;
}
