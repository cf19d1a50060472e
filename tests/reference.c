/* SPDX-License-Identifier: Apache-2.0 */
#include "reference.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "../kernels/clvox_types.h"
#include "../kernels/overlap.h"
#include "../kernels/sampler.h"

/* Edge sign with the symbolic tie rule (design.md), in double as the
 * kernels do on devices with fp64 (PoCL has it). */
static int edge_sign(double av, double aw, double bv, double bw, double *e)
{
    *e = av * bw - aw * bv;
    if (*e != 0.0) return *e > 0.0 ? 1 : -1;
    if (aw - bw != 0.0) return aw - bw > 0.0 ? 1 : -1;
    if (bv - av != 0.0) return bv - av > 0.0 ? 1 : -1;
    return 0;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Grid-space vertices (permuted: index 0 = u), as the library computes them. */
static float *grid_vertices(const float *xyz, size_t nv, const clvox_grid *g, const int perm[3])
{
    float *gv = malloc((nv ? nv : 1) * 3 * sizeof *gv);
    if (!gv) abort();
    for (size_t i = 0; i < nv; i++)
        for (int k = 0; k < 3; k++) {
            int a = perm[k];
            gv[i * 3 + k] = (float)(((double)xyz[i * 3 + a] - g->origin[a]) / g->voxel_size[a] - 0.5);
        }
    return gv;
}

static void axis_perm(clvox_axis axis, int perm[3])
{
    perm[0] = 0, perm[1] = 1, perm[2] = 2; /* u, v, w */
    if (axis == CLVOX_AXIS_Y) perm[0] = 1, perm[1] = 2, perm[2] = 0;
    if (axis == CLVOX_AXIS_Z) perm[0] = 2, perm[1] = 0, perm[2] = 1;
}

/* Does the ray at (pv, pw) cross triangle (a, b, c)? Its orientation (0:
 * no), and in *u where, as the kernels compute it in double. */
static int tri_crossing(const float *a, const float *b, const float *c, double pv, double pw, double *u)
{
    double Av = a[1] - pv, Aw = a[2] - pw, Bv = b[1] - pv, Bw = b[2] - pw, Cv = c[1] - pv, Cw = c[2] - pw;
    double eab, ebc, eca;
    int s1 = edge_sign(Av, Aw, Bv, Bw, &eab);
    int s2 = edge_sign(Bv, Bw, Cv, Cw, &ebc);
    int s3 = edge_sign(Cv, Cw, Av, Aw, &eca);
    if (s1 == 0 || s1 != s2 || s1 != s3) return 0;
    double au = a[0];
    double num = eca * ((double)b[0] - au) + eab * ((double)c[0] - au);
    double den = eab + ebc + eca;
    *u = au + num / den;
    return s1;
}

/* Sorted crossings of the ray at (fpv, fpw) with every triangle. */
static size_t ray_crossings(const float *gv, const uint32_t *tri, size_t nt, float fpv, float fpw, double *hits)
{
    size_t n = 0;
    for (size_t t = 0; t < nt; t++)
        if (tri_crossing(gv + 3 * (size_t)tri[3 * t], gv + 3 * (size_t)tri[3 * t + 1], gv + 3 * (size_t)tri[3 * t + 2],
                         fpv, fpw, &hits[n]))
            n++;
    qsort(hits, n, sizeof *hits, cmp_double);
    return n;
}

static size_t voxel_index(const clvox_grid *g, const int perm[3], uint32_t i, uint32_t jv, uint32_t jw)
{
    uint32_t idx[3];
    idx[perm[0]] = i;
    idx[perm[1]] = jv;
    idx[perm[2]] = jw;
    return ((size_t)idx[2] * g->dims[1] + idx[1]) * g->dims[0] + idx[0];
}

/* The crossings of the ray at (pv, pw), unsorted, as the triangles
 * crossed (their corners, 9 each) and the crossings' orientations: the
 * coverage reference tests each sample against each exactly. */
static size_t ray_crossing_tris(const float *gv, const uint32_t *tri, size_t nt, float fpv, float fpw, double *corners,
                                int *orient)
{
    size_t n = 0;
    for (size_t t = 0; t < nt; t++) {
        const float *c3[3] = {gv + 3 * (size_t)tri[3 * t], gv + 3 * (size_t)tri[3 * t + 1], gv + 3 * (size_t)tri[3 * t + 2]};
        double u;
        const int s = tri_crossing(c3[0], c3[1], c3[2], fpv, fpw, &u);
        if (!s) continue;
        for (int k = 0; k < 9; k++) corners[9 * n + k] = c3[k / 3][k % 3];
        orient[n++] = s;
    }
    return n;
}

/* Is the crossing of orientation s with the triangle of corners v strictly
 * beyond the float point u of the ray (pv, pw)? The plane function n . (q -
 * v0) at q = (u, pv, pw) is n_u (u - u_hit), n_u of sign s: exact sign. */
static int crossing_beyond(const double *v, int s, float u, float pv, float pw)
{
    return s * clvox_o3_sign(v, u, pv, pw) < 0;
}

uint64_t ref_voxelize(const float *xyz, size_t nv, const uint32_t *tri, size_t nt, const clvox_grid *g,
                      clvox_axis axis, uint8_t *out)
{
    int perm[3];
    axis_perm(axis, perm);
    float *gv = grid_vertices(xyz, nv, g, perm);
    double *hits = malloc((nt + 1) * sizeof *hits);
    if (!hits) abort();
    uint32_t du = g->dims[perm[0]], dv = g->dims[perm[1]], dw = g->dims[perm[2]];
    uint64_t odd = 0;
    for (uint32_t jw = 0; jw < dw; jw++)
        for (uint32_t jv = 0; jv < dv; jv++) {
            size_t n = ray_crossings(gv, tri, nt, (float)jv, (float)jw, hits);
            odd += n & 1;
            for (uint32_t i = 0; i < du; i++) {
                size_t beyond = 0;
                for (size_t k = 0; k < n; k++) beyond += hits[k] > (double)i;
                out[voxel_index(g, perm, i, jv, jw)] = (uint8_t)(beyond & 1);
            }
        }
    free(gv);
    free(hits);
    return odd;
}

void ref_coverage(const float *xyz, size_t nv, const uint32_t *tri, size_t nt, const clvox_grid *g,
                  clvox_axis axis, uint32_t N, uint32_t M, int stochastic, uint64_t seed, uint32_t *counts)
{
    int perm[3];
    axis_perm(axis, perm);
    float *gv = grid_vertices(xyz, nv, g, perm);
    double *corners = malloc((nt + 1) * 9 * sizeof *corners);
    int *orient = malloc((nt + 1) * sizeof *orient);
    if (!corners || !orient) abort();
    const uint32_t du = g->dims[perm[0]], dv = g->dims[perm[1]], dw = g->dims[perm[2]];
    const uint32_t slo = (uint32_t)seed, shi = (uint32_t)(seed >> 32);
    memset(counts, 0, (size_t)du * dv * dw * sizeof *counts);
    for (uint32_t jw = 0; jw < dw; jw++)
        for (uint32_t jv = 0; jv < dv; jv++) {
            const uint32_t id = jw * dv + jv;
            for (uint32_t b = 0; b < N; b++)
                for (uint32_t a = 0; a < N; a++) {
                    uint32_t r = a + N * b, bits[4] = {0, 0, 0, 0};
                    if (stochastic) clvox_philox4x32_10(id, r, CLVOX_SAMPLER_RAY_WORD, 0, slo, shi, bits);
                    float pv = (float)(((double)jv - 0.5) + clvox_stratum(a, N, stochastic, bits[0]));
                    float pw = (float)(((double)jw - 0.5) + clvox_stratum(b, N, stochastic, bits[1]));
                    size_t n = ray_crossing_tris(gv, tri, nt, pv, pw, corners, orient);
                    for (uint32_t i = 0; i < du; i++)
                        for (uint32_t m = 0; m < M; m++) { /* every point, no shortcut */
                            uint32_t pb = stochastic ? clvox_point_bits(slo, shi, id, r, i, m) : 0;
                            const float p = clvox_sample_u(i, m, M, stochastic, pb);
                            size_t beyond = 0;
                            for (size_t k = 0; k < n; k++) beyond += crossing_beyond(corners + 9 * k, orient[k], p, pv, pw);
                            counts[voxel_index(g, perm, i, jv, jw)] += (uint32_t)(beyond & 1);
                        }
                }
        }
    free(gv);
    free(corners);
    free(orient);
}

/* Both palette references: score every element (given == NULL), or count
 * the samples where the given elements break the metric's constraint. */
static uint64_t palette_columns(const float *xyz, size_t nv, const uint32_t *tri, size_t nt, const clvox_grid *g,
                                clvox_axis axis, uint32_t N, uint32_t M, int stochastic, uint64_t seed,
                                const clvox_palette *pal, clvox_metric metric, uint16_t *element, uint32_t *equal,
                                uint32_t *inside, const uint16_t *given)
{
    uint64_t violations = 0;
    int perm[3];
    axis_perm(axis, perm);
    float *gv = grid_vertices(xyz, nv, g, perm);
    double *corners = malloc((nt + 1) * 9 * sizeof *corners);
    int *orient = malloc((nt + 1) * sizeof *orient);
    const uint32_t du = g->dims[perm[0]], dv = g->dims[perm[1]], dw = g->dims[perm[2]];
    const uint32_t R = N * N, S = R * M, slo = (uint32_t)seed, shi = (uint32_t)(seed >> 32);
    const size_t ne = clvox_palette_count(pal);
    /* one column at a time: o and the unit-voxel position of every sample */
    uint8_t *o = malloc((size_t)du * S);
    float *pos = malloc((size_t)du * S * 3 * sizeof *pos);
    if (!corners || !orient || !o || !pos) abort();
    for (uint32_t jw = 0; jw < dw; jw++)
        for (uint32_t jv = 0; jv < dv; jv++) {
            const uint32_t id = jw * dv + jv;
            for (uint32_t b = 0; b < N; b++)
                for (uint32_t a = 0; a < N; a++) {
                    uint32_t r = a + N * b, bits[4] = {0, 0, 0, 0};
                    if (stochastic) clvox_philox4x32_10(id, r, CLVOX_SAMPLER_RAY_WORD, 0, slo, shi, bits);
                    const double sv = clvox_stratum(a, N, stochastic, bits[0]), sw = clvox_stratum(b, N, stochastic, bits[1]);
                    const float pv = (float)(((double)jv - 0.5) + sv), pw = (float)(((double)jw - 0.5) + sw);
                    const float fv = clvox_stratum_float(a, N, stochastic, bits[0]),
                                fw = clvox_stratum_float(b, N, stochastic, bits[1]);
                    size_t n = ray_crossing_tris(gv, tri, nt, pv, pw, corners, orient);
                    for (uint32_t i = 0; i < du; i++)
                        for (uint32_t m = 0; m < M; m++) {
                            uint32_t pb = stochastic ? clvox_point_bits(slo, shi, id, r, i, m) : 0;
                            const float p = clvox_sample_u(i, m, M, stochastic, pb);
                            size_t beyond = 0;
                            for (size_t k = 0; k < n; k++) beyond += crossing_beyond(corners + 9 * k, orient[k], p, pv, pw);
                            size_t at = (size_t)i * S + r * M + m;
                            o[at] = (uint8_t)(beyond & 1);
                            float *q = pos + at * 3;
                            q[perm[0]] = clvox_stratum_float(m, M, stochastic, pb), q[perm[1]] = fv, q[perm[2]] = fw;
                        }
                }
            for (uint32_t i = 0; i < du && given; i++) {
                const uint8_t *ov = o + (size_t)i * S;
                const float *pv = pos + (size_t)i * S * 3;
                size_t e = given[voxel_index(g, perm, i, jv, jw)];
                for (uint32_t k = 0; k < S; k++) {
                    int ev = clvox_palette_contains(pal, e, pv[3 * k], pv[3 * k + 1], pv[3 * k + 2]);
                    violations += (metric == CLVOX_METRIC_OUTER && ov[k] && !ev) ||
                                  (metric == CLVOX_METRIC_INNER && !ov[k] && ev);
                }
            }
            for (uint32_t i = 0; i < du && !given; i++) {
                const uint8_t *ov = o + (size_t)i * S;
                const float *pv = pos + (size_t)i * S * 3;
                long best = -1;
                size_t best_e = 0;
                uint32_t in = 0;
                for (uint32_t k = 0; k < S; k++) in += ov[k];
                for (size_t e = 0; e < ne; e++) { /* Table 1, every sample, no early stop */
                    long score = 0;
                    int minus_inf = 0;
                    for (uint32_t k = 0; k < S; k++) {
                        int ev = clvox_palette_contains(pal, e, pv[3 * k], pv[3 * k + 1], pv[3 * k + 2]);
                        if (ev == ov[k]) score++;
                        else if ((metric == CLVOX_METRIC_OUTER && ov[k]) || (metric == CLVOX_METRIC_INNER && ev))
                            minus_inf = 1;
                    }
                    if (!minus_inf && score > best) best = score, best_e = e;
                }
                size_t v = voxel_index(g, perm, i, jv, jw);
                element[v] = (uint16_t)best_e;
                if (equal) equal[v] = (uint32_t)best;
                if (inside) inside[v] = in;
            }
        }
    free(gv);
    free(corners);
    free(orient);
    free(o);
    free(pos);
    return violations;
}

void ref_palette(const float *xyz, size_t nv, const uint32_t *tri, size_t nt, const clvox_grid *g, clvox_axis axis,
                 uint32_t N, uint32_t M, int stochastic, uint64_t seed, const clvox_palette *pal, clvox_metric metric,
                 uint16_t *element, uint32_t *equal, uint32_t *inside)
{
    palette_columns(xyz, nv, tri, nt, g, axis, N, M, stochastic, seed, pal, metric, element, equal, inside, NULL);
}

uint64_t ref_palette_violations(const float *xyz, size_t nv, const uint32_t *tri, size_t nt, const clvox_grid *g,
                                clvox_axis axis, uint32_t N, uint32_t M, int stochastic, uint64_t seed,
                                const clvox_palette *pal, clvox_metric metric, const uint16_t *element)
{
    return palette_columns(xyz, nv, tri, nt, g, axis, N, M, stochastic, seed, pal, metric, NULL, NULL, NULL, element);
}

/* ---- generalized winding numbers ---- */

#define REF_PI 3.14159265358979323846

static double wdot(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static double wnorm(const double a[3]) { return sqrt(wdot(a, a)); }

double ref_solid_angle(const double a[3], const double b[3], const double c[3])
{
    double bxc[3] = {b[1] * c[2] - b[2] * c[1], b[2] * c[0] - b[0] * c[2], b[0] * c[1] - b[1] * c[0]};
    double la = wnorm(a), lb = wnorm(b), lc = wnorm(c);
    double det = wdot(a, bxc);
    double den = la * lb * lc + wdot(a, b) * lc + wdot(b, c) * la + wdot(c, a) * lb;
    return 2.0 * atan2(det, den);
}

/* Sum over triangles with the corner vectors and their lengths computed once
 * per vertex (scratch: 4 doubles per vertex). */
static double gwn_sum(const double *q, size_t nv, const uint32_t *tri, size_t nt, const double p[3], double *scratch)
{
    for (size_t i = 0; i < nv; i++) {
        double *s = scratch + 4 * i;
        s[0] = q[3 * i] - p[0], s[1] = q[3 * i + 1] - p[1], s[2] = q[3 * i + 2] - p[2];
        s[3] = sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    }
    double sum = 0.0;
    for (size_t t = 0; t < nt; t++) {
        const double *a = scratch + 4 * (size_t)tri[3 * t], *b = scratch + 4 * (size_t)tri[3 * t + 1],
                     *c = scratch + 4 * (size_t)tri[3 * t + 2];
        double bxc0 = b[1] * c[2] - b[2] * c[1], bxc1 = b[2] * c[0] - b[0] * c[2], bxc2 = b[0] * c[1] - b[1] * c[0];
        double det = a[0] * bxc0 + a[1] * bxc1 + a[2] * bxc2;
        double den = a[3] * b[3] * c[3] + (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) * c[3] +
                     (b[0] * c[0] + b[1] * c[1] + b[2] * c[2]) * a[3] + (c[0] * a[0] + c[1] * a[1] + c[2] * a[2]) * b[3];
        sum += 2.0 * atan2(det, den);
    }
    return sum / (4.0 * REF_PI);
}

double ref_winding_number_d(const double *xyz, size_t nv, const uint32_t *tri, size_t nt, const double p[3])
{
    double *scratch = malloc((nv ? nv : 1) * 4 * sizeof *scratch);
    if (!scratch) abort();
    double w = gwn_sum(xyz, nv, tri, nt, p, scratch);
    free(scratch);
    return w;
}

double ref_winding_number(const float *xyz, size_t nv, const uint32_t *tri, size_t nt, const double p[3])
{
    double *q = malloc((nv ? nv : 1) * 3 * sizeof *q);
    if (!q) abort();
    for (size_t i = 0; i < 3 * nv; i++) q[i] = xyz[i];
    double w = ref_winding_number_d(q, nv, tri, nt, p);
    free(q);
    return w;
}

static int cmp_u64_key(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

double ref_winding_number_rays(const double *xyz, size_t nv, const uint32_t *tri, size_t nt, const double p[3])
{
    (void)nv;
    /* signed crossings of the +x ray beyond p */
    long crossings = 0;
    for (size_t t = 0; t < nt; t++) {
        const double *a = xyz + 3 * (size_t)tri[3 * t], *b = xyz + 3 * (size_t)tri[3 * t + 1],
                     *c = xyz + 3 * (size_t)tri[3 * t + 2];
        double Ay = a[1] - p[1], Az = a[2] - p[2], By = b[1] - p[1], Bz = b[2] - p[2], Cy = c[1] - p[1],
               Cz = c[2] - p[2];
        double eab = Ay * Bz - Az * By, ebc = By * Cz - Bz * Cy, eca = Cy * Az - Cz * Ay;
        int pos = eab > 0 && ebc > 0 && eca > 0, neg = eab < 0 && ebc < 0 && eca < 0;
        if (!pos && !neg) continue;
        double x = (eab * c[0] + ebc * a[0] + eca * b[0]) / (eab + ebc + eca); /* barycentric */
        if (x > p[0]) crossings += pos ? 1 : -1; /* eab + ebc + eca = normal.x */
    }
    /* the boundary chain: net multiplicity of each undirected edge (lo, hi), +1 for lo -> hi */
    size_t ne = 3 * nt;
    uint64_t *key = malloc((ne ? ne : 1) * sizeof *key);
    if (!key) abort();
    for (size_t i = 0; i < ne; i++) {
        uint32_t u = tri[i], v = tri[i - i % 3 + (i + 1) % 3];
        /* key: lo << 33 | hi << 1 | (1 when the edge runs hi -> lo) */
        key[i] = u < v ? ((uint64_t)u << 33 | (uint64_t)v << 1) : ((uint64_t)v << 33 | (uint64_t)u << 1 | 1u);
    }
    qsort(key, ne, sizeof *key, cmp_u64_key);
    const double dir[3] = {-1.0, 0.0, 0.0}; /* the strip's corner at infinity */
    double strips = 0.0;
    for (size_t i = 0; i < ne;) {
        size_t j = i;
        long net = 0;
        while (j < ne && key[j] >> 1 == key[i] >> 1) net += key[j] & 1 ? -1 : 1, j++;
        if (net != 0) {
            uint32_t lo = (uint32_t)(key[i] >> 33), hi = (uint32_t)(key[i] >> 1 & 0xFFFFFFFFu);
            double A[3], B[3];
            for (int k = 0; k < 3; k++) A[k] = xyz[3 * (size_t)lo + k] - p[k], B[k] = xyz[3 * (size_t)hi + k] - p[k];
            strips += (double)net * ref_solid_angle(A, B, dir);
        }
        i = j;
    }
    free(key);
    return (double)crossings + strips / (4.0 * REF_PI);
}

int ref_winding_inside(double w, int abs_rule)
{
    return (abs_rule ? fabs(w) : w) > 0.5 + REF_WINDING_EPS;
}

double *ref_winding_space(const float *xyz, size_t nv, const clvox_grid *g)
{
    double *q = malloc((nv ? nv : 1) * 3 * sizeof *q);
    if (!q) abort();
    for (size_t i = 0; i < nv; i++)
        for (int a = 0; a < 3; a++) {
            float gs = (float)(((double)xyz[i * 3 + a] - g->origin[a]) / g->voxel_size[a] - 0.5);
            q[i * 3 + a] = (double)gs * g->voxel_size[a];
        }
    return q;
}

void ref_winding_voxelize(const float *xyz, size_t nv, const uint32_t *tri, size_t nt, const clvox_grid *g,
                          int abs_rule, uint8_t *out, double *w)
{
    double *q = ref_winding_space(xyz, nv, g);
    double *scratch = malloc((nv ? nv : 1) * 4 * sizeof *scratch);
    if (!scratch) abort();
    size_t at = 0;
    for (uint32_t k = 0; k < g->dims[2]; k++)
        for (uint32_t j = 0; j < g->dims[1]; j++)
            for (uint32_t i = 0; i < g->dims[0]; i++, at++) {
                double p[3] = {i * g->voxel_size[0], j * g->voxel_size[1], k * g->voxel_size[2]};
                double wp = gwn_sum(q, nv, tri, nt, p, scratch);
                out[at] = (uint8_t)ref_winding_inside(wp, abs_rule);
                if (w) w[at] = wp;
            }
    free(scratch);
    free(q);
}

uint64_t ref_winding_coverage(const float *xyz, size_t nv, const uint32_t *tri, size_t nt, const clvox_grid *g,
                              clvox_axis axis, uint32_t N, uint32_t M, int stochastic, uint64_t seed, int abs_rule,
                              double near, uint32_t *counts)
{
    int perm[3];
    axis_perm(axis, perm);
    double *q = ref_winding_space(xyz, nv, g);
    double *scratch = malloc((nv ? nv : 1) * 4 * sizeof *scratch);
    if (!scratch) abort();
    const uint32_t du = g->dims[perm[0]], dv = g->dims[perm[1]], dw = g->dims[perm[2]];
    const uint32_t slo = (uint32_t)seed, shi = (uint32_t)(seed >> 32);
    uint64_t ties = 0;
    memset(counts, 0, (size_t)du * dv * dw * sizeof *counts);
    for (uint32_t jw = 0; jw < dw; jw++)
        for (uint32_t jv = 0; jv < dv; jv++) {
            const uint32_t id = jw * dv + jv;
            for (uint32_t b = 0; b < N; b++)
                for (uint32_t a = 0; a < N; a++) {
                    uint32_t r = a + N * b, bits[4] = {0, 0, 0, 0};
                    if (stochastic) clvox_philox4x32_10(id, r, CLVOX_SAMPLER_RAY_WORD, 0, slo, shi, bits);
                    /* exactly ref_coverage's positions (grid space) */
                    float pv = (float)(((double)jv - 0.5) + clvox_stratum(a, N, stochastic, bits[0]));
                    float pw = (float)(((double)jw - 0.5) + clvox_stratum(b, N, stochastic, bits[1]));
                    for (uint32_t i = 0; i < du; i++)
                        for (uint32_t m = 0; m < M; m++) {
                            uint32_t pb = stochastic ? clvox_point_bits(slo, shi, id, r, i, m) : 0;
                            const double pu = clvox_sample_u(i, m, M, stochastic, pb);
                            double s[3], p[3];
                            s[perm[0]] = pu, s[perm[1]] = pv, s[perm[2]] = pw;
                            for (int k = 0; k < 3; k++) p[k] = s[k] * g->voxel_size[k];
                            double wp = gwn_sum(q, nv, tri, nt, p, scratch);
                            ties += fabs((abs_rule ? fabs(wp) : wp) - 0.5) < near;
                            counts[voxel_index(g, perm, i, jv, jw)] += (uint32_t)ref_winding_inside(wp, abs_rule);
                        }
                }
        }
    free(scratch);
    free(q);
    return ties;
}

/* Sorts vertex indices by position (x, y, z as floats). */
static const float *sort_xyz;
static int cmp_vertex(const void *a, const void *b)
{
    const float *p = sort_xyz + 3 * (size_t)*(const uint32_t *)a, *q = sort_xyz + 3 * (size_t)*(const uint32_t *)b;
    for (int k = 0; k < 3; k++)
        if (p[k] != q[k]) return p[k] < q[k] ? -1 : 1;
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

size_t ref_winding_voxelize_rays(const float *xyz, size_t nv, const uint32_t *tri, size_t nt, const clvox_grid *g,
                                 int abs_rule, uint8_t *out, double *w)
{
    /* representative of each vertex: the lowest index at the same position */
    uint32_t *order = malloc((nv ? nv : 1) * sizeof *order), *rep = malloc((nv ? nv : 1) * sizeof *rep);
    if (!order || !rep) abort();
    for (size_t i = 0; i < nv; i++) order[i] = (uint32_t)i;
    sort_xyz = xyz;
    qsort(order, nv, sizeof *order, cmp_vertex);
    for (size_t i = 0; i < nv;) {
        size_t j = i;
        while (j < nv && memcmp(xyz + 3 * (size_t)order[j], xyz + 3 * (size_t)order[i], 3 * sizeof(float)) == 0)
            rep[order[j++]] = order[i];
        i = j;
    }
    free(order);
    /* boundary chain on the merged indices */
    size_t ne = 3 * nt, nb = 0;
    uint64_t *key = malloc((ne ? ne : 1) * sizeof *key);
    uint32_t *be = malloc((ne ? ne : 1) * 2 * sizeof *be);
    long *bm = malloc((ne ? ne : 1) * sizeof *bm);
    if (!key || !be || !bm) abort();
    for (size_t i = 0; i < ne; i++) {
        uint32_t u = rep[tri[i]], v = rep[tri[i - i % 3 + (i + 1) % 3]];
        key[i] = u < v ? ((uint64_t)u << 33 | (uint64_t)v << 1) : ((uint64_t)v << 33 | (uint64_t)u << 1 | 1u);
    }
    qsort(key, ne, sizeof *key, cmp_u64_key);
    for (size_t i = 0; i < ne;) {
        size_t j = i;
        long net = 0;
        while (j < ne && key[j] >> 1 == key[i] >> 1) net += key[j] & 1 ? -1 : 1, j++;
        if (net != 0 && key[i] >> 33 != (key[i] >> 1 & 0xFFFFFFFFu)) {
            be[2 * nb] = (uint32_t)(key[i] >> 33), be[2 * nb + 1] = (uint32_t)(key[i] >> 1 & 0xFFFFFFFFu);
            bm[nb++] = net;
        }
        i = j;
    }
    free(key);
    free(rep);
    const int perm[3] = {0, 1, 2};
    float *gv = grid_vertices(xyz, nv, g, perm); /* grid space, for the crossings */
    double *q = ref_winding_space(xyz, nv, g);   /* isotropic space, for the strips */
    double *hits = malloc((nt + 1) * sizeof *hits);
    int *sign = malloc((nt + 1) * sizeof *sign);
    if (!hits || !sign) abort();
    const double dir[3] = {-1.0, 0.0, 0.0};
    const uint32_t X = g->dims[0], Y = g->dims[1], Z = g->dims[2];
    for (uint32_t k = 0; k < Z; k++)
        for (uint32_t j = 0; j < Y; j++) {
            /* signed crossings of the column's ray (ray_crossings' arithmetic, with the sign kept) */
            double pv = (float)j, pw = (float)k;
            size_t n = 0;
            for (size_t t = 0; t < nt; t++) {
                const float *a = gv + 3 * (size_t)tri[3 * t], *b = gv + 3 * (size_t)tri[3 * t + 1],
                            *c = gv + 3 * (size_t)tri[3 * t + 2];
                double Av = a[1] - pv, Aw = a[2] - pw, Bv = b[1] - pv, Bw = b[2] - pw, Cv = c[1] - pv, Cw = c[2] - pw;
                double eab, ebc, eca;
                int s1 = edge_sign(Av, Aw, Bv, Bw, &eab);
                int s2 = edge_sign(Bv, Bw, Cv, Cw, &ebc);
                int s3 = edge_sign(Cv, Cw, Av, Aw, &eca);
                if (s1 == 0 || s1 != s2 || s1 != s3) continue;
                double au = a[0];
                double num = eca * ((double)b[0] - au) + eab * ((double)c[0] - au);
                hits[n] = au + num / (eab + ebc + eca);
                sign[n++] = s1;
            }
            for (uint32_t i = 0; i < X; i++) {
                long K = 0;
                for (size_t h = 0; h < n; h++) K += hits[h] > (double)i ? sign[h] : 0;
                double p[3] = {i * g->voxel_size[0], j * g->voxel_size[1], k * g->voxel_size[2]}, strips = 0.0;
                for (size_t e = 0; e < nb; e++) {
                    const double *qa = q + 3 * (size_t)be[2 * e], *qb = q + 3 * (size_t)be[2 * e + 1];
                    double A[3] = {qa[0] - p[0], qa[1] - p[1], qa[2] - p[2]}, B[3] = {qb[0] - p[0], qb[1] - p[1], qb[2] - p[2]};
                    strips += (double)bm[e] * ref_solid_angle(A, B, dir);
                }
                double wp = (double)K + strips / (4.0 * REF_PI);
                size_t at = ((size_t)k * Y + j) * X + i;
                out[at] = (uint8_t)ref_winding_inside(wp, abs_rule);
                if (w) w[at] = wp;
            }
        }
    free(gv);
    free(q);
    free(hits);
    free(sign);
    free(be);
    free(bm);
    return nb;
}
