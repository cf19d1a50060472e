#include "reference.h"

#include <stdlib.h>
#include <string.h>

#include "../kernels/clvox_types.h"
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

/* Sorted crossings of the ray at (fpv, fpw) with every triangle. */
static size_t ray_crossings(const float *gv, const uint32_t *tri, size_t nt, float fpv, float fpw, double *hits)
{
    double pv = fpv, pw = fpw;
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
        double den = eab + ebc + eca;
        hits[n++] = au + num / den;
    }
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
    double *hits = malloc((nt + 1) * sizeof *hits);
    if (!hits) abort();
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
                    size_t n = ray_crossings(gv, tri, nt, pv, pw, hits);
                    for (uint32_t i = 0; i < du; i++)
                        for (uint32_t m = 0; m < M; m++) { /* every point, no shortcut */
                            uint32_t pb = stochastic ? clvox_point_bits(slo, shi, id, r, i, m) : 0;
                            double p = ((double)i - 0.5) + clvox_stratum(m, M, stochastic, pb);
                            size_t beyond = 0;
                            for (size_t k = 0; k < n; k++) beyond += hits[k] > p;
                            counts[voxel_index(g, perm, i, jv, jw)] += (uint32_t)(beyond & 1);
                        }
                }
        }
    free(gv);
    free(hits);
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
    double *hits = malloc((nt + 1) * sizeof *hits);
    const uint32_t du = g->dims[perm[0]], dv = g->dims[perm[1]], dw = g->dims[perm[2]];
    const uint32_t R = N * N, S = R * M, slo = (uint32_t)seed, shi = (uint32_t)(seed >> 32);
    const size_t ne = clvox_palette_count(pal);
    /* one column at a time: o and the unit-voxel position of every sample */
    uint8_t *o = malloc((size_t)du * S);
    float *pos = malloc((size_t)du * S * 3 * sizeof *pos);
    if (!hits || !o || !pos) abort();
    for (uint32_t jw = 0; jw < dw; jw++)
        for (uint32_t jv = 0; jv < dv; jv++) {
            const uint32_t id = jw * dv + jv;
            for (uint32_t b = 0; b < N; b++)
                for (uint32_t a = 0; a < N; a++) {
                    uint32_t r = a + N * b, bits[4] = {0, 0, 0, 0};
                    if (stochastic) clvox_philox4x32_10(id, r, CLVOX_SAMPLER_RAY_WORD, 0, slo, shi, bits);
                    double sv = clvox_stratum(a, N, stochastic, bits[0]), sw = clvox_stratum(b, N, stochastic, bits[1]);
                    float pv = (float)(((double)jv - 0.5) + sv), pw = (float)(((double)jw - 0.5) + sw);
                    size_t n = ray_crossings(gv, tri, nt, pv, pw, hits);
                    for (uint32_t i = 0; i < du; i++)
                        for (uint32_t m = 0; m < M; m++) {
                            uint32_t pb = stochastic ? clvox_point_bits(slo, shi, id, r, i, m) : 0;
                            double su = clvox_stratum(m, M, stochastic, pb);
                            double p = ((double)i - 0.5) + su;
                            size_t beyond = 0;
                            for (size_t k = 0; k < n; k++) beyond += hits[k] > p;
                            size_t at = (size_t)i * S + r * M + m;
                            o[at] = (uint8_t)(beyond & 1);
                            float *q = pos + at * 3;
                            q[perm[0]] = (float)su, q[perm[1]] = (float)sv, q[perm[2]] = (float)sw;
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
    free(hits);
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
