/* SPDX-License-Identifier: Apache-2.0 */
/* A certified far field for the caps' winding number: moments, their
 * translation, evaluation with a rigorous remainder bound (far_field.h has
 * the derivation). Host prototype, double; not used by the kernels yet. */
#include "far_field.h"

#include <math.h>
#include <string.h>

#define FOUR_PI (4.0 * 3.14159265358979323846)
#define NDER CLVOX__FF_MONO(CLVOX__FF_MAX_TERMS + 1) /* derivatives of G up to degree MAX_TERMS */

/* 5-point Gauss-Legendre on [0, 1]: exact to degree 9. */
static const double GL_X[5] = {0.04691007703066800, 0.23076534494715845, 0.5, 0.76923465505284155,
                               0.95308992296933200};
static const double GL_W[5] = {0.11846344252809454, 0.23931433524968324, 0.28444444444444444,
                               0.23931433524968324, 0.11846344252809454};

static int clamp_terms(int t) { return t < 1 ? 1 : t > CLVOX__FF_MAX_TERMS ? CLVOX__FF_MAX_TERMS : t; }

void clvox__ff_init(clvox__ff *e, int terms, const double c[3])
{
    memset(e, 0, sizeof *e);
    e->terms = clamp_terms(terms);
    for (int a = 0; a < 3; a++) e->centre[a] = c[a];
}

static double round_up(double x) { return x * (1.0 + 1e-14) + 1e-300; }

void clvox__ff_add_triangles(clvox__ff *e, const double *tri, size_t n)
{
    const int P = e->terms;
    for (size_t t = 0; t < n; t++) {
        const double *v = tri + 9 * t;
        double v0[3], e1[3], e2[3];
        for (int a = 0; a < 3; a++) {
            v0[a] = v[a] - e->centre[a];
            e1[a] = v[3 + a] - v[a];     /* v1 - v0 */
            e2[a] = v[6 + a] - v[3 + a]; /* v2 - v1 */
        }
        /* vector area S = (v1 - v0) x (v2 - v0) / 2 = (v1 - v0) x (v2 - v1) / 2 */
        const double S[3] = {0.5 * (e1[1] * e2[2] - e1[2] * e2[1]), 0.5 * (e1[2] * e2[0] - e1[0] * e2[2]),
                             0.5 * (e1[0] * e2[1] - e1[1] * e2[0])};
        e->area += sqrt(S[0] * S[0] + S[1] * S[1] + S[2] * S[2]);
        for (int c = 0; c < 3; c++) {
            const double dx = v[3 * c] - e->centre[0], dy = v[3 * c + 1] - e->centre[1],
                         dz = v[3 * c + 2] - e->centre[2];
            const double r = round_up(sqrt(dx * dx + dy * dy + dz * dz));
            if (r > e->radius) e->radius = r;
        }
        /* (1/A) int f dA = sum w_s w_t 2 s f(y(s, t)), y = v0 + s (v1 - v0) + s t (v2 - v1):
         * the integrand has degree <= P in s and P - 1 in t */
        double mean[CLVOX__FF_NMOM];
        memset(mean, 0, sizeof mean);
        for (int i = 0; i < 5; i++)
            for (int j = 0; j < 5; j++) {
                const double s = GL_X[i], u = GL_X[j], w = 2.0 * GL_W[i] * GL_W[j] * s;
                double pw[3][CLVOX__FF_MAX_TERMS];
                for (int a = 0; a < 3; a++) {
                    pw[a][0] = 1.0;
                    const double y = v0[a] + s * e1[a] + s * u * e2[a];
                    for (int k = 1; k < P; k++) pw[a][k] = pw[a][k - 1] * y;
                }
                for (int k = 0; k < P; k++)
                    for (int a = k; a >= 0; a--)
                        for (int b = k - a; b >= 0; b--) {
                            const int c = k - a - b;
                            mean[clvox__ff_mono(a, b, c)] += w * pw[0][a] * pw[1][b] * pw[2][c];
                        }
            }
        const int nm = CLVOX__FF_MONO(P);
        for (int j = 0; j < 3; j++)
            for (int m = 0; m < nm; m++) e->m[j][m] += S[j] * mean[m];
    }
}

static const double BINOM[CLVOX__FF_MAX_TERMS][CLVOX__FF_MAX_TERMS] = {
    {1, 0, 0, 0, 0, 0, 0, 0},    {1, 1, 0, 0, 0, 0, 0, 0},     {1, 2, 1, 0, 0, 0, 0, 0},
    {1, 3, 3, 1, 0, 0, 0, 0},    {1, 4, 6, 4, 1, 0, 0, 0},     {1, 5, 10, 10, 5, 1, 0, 0},
    {1, 6, 15, 20, 15, 6, 1, 0}, {1, 7, 21, 35, 35, 21, 7, 1},
};

void clvox__ff_add_shifted(clvox__ff *dst, const clvox__ff *src)
{
    const int P = dst->terms < src->terms ? dst->terms : src->terms;
    double t[3], pw[3][CLVOX__FF_MAX_TERMS];
    for (int a = 0; a < 3; a++) {
        t[a] = src->centre[a] - dst->centre[a];
        pw[a][0] = 1.0;
        for (int k = 1; k < P; k++) pw[a][k] = pw[a][k - 1] * t[a];
    }
    /* (delta_s + t)^alpha = sum_{beta <= alpha} C(alpha, beta) delta_s^beta t^(alpha - beta) */
    for (int k = 0; k < P; k++)
        for (int a = k; a >= 0; a--)
            for (int b = k - a; b >= 0; b--) {
                const int c = k - a - b, id = clvox__ff_mono(a, b, c);
                double acc[3] = {0, 0, 0};
                for (int i = 0; i <= a; i++)
                    for (int j = 0; j <= b; j++)
                        for (int l = 0; l <= c; l++) {
                            const double f = BINOM[a][i] * BINOM[b][j] * BINOM[c][l] * pw[0][a - i] * pw[1][b - j] *
                                             pw[2][c - l];
                            const int is = clvox__ff_mono(i, j, l);
                            for (int q = 0; q < 3; q++) acc[q] += f * src->m[q][is];
                        }
                for (int q = 0; q < 3; q++) dst->m[q][id] += acc[q];
            }
    dst->area += src->area;
    const double r = round_up(sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]) + src->radius);
    if (r > dst->radius) dst->radius = r;
}

/* T[beta] = d^beta (1/|x|) for |beta| <= n, by the recurrence (Leibniz on
 * |x|^2 d_i G + x_i G = 0 with beta = n - e_i, i the first axis of n):
 * |x|^2 T_n = -[(2 n_i - 1) x_i T_{n-e_i} + (n_i - 1)^2 T_{n-2e_i}
 *              + sum_{j != i} (2 n_j x_j T_{n-e_j} + n_j (n_j - 1) T_{n-2e_j})]. */
static void derivatives(const double x[3], double d2, int n, double *T)
{
    T[0] = 1.0 / sqrt(d2);
    const double id2 = 1.0 / d2;
    for (int k = 1; k <= n; k++)
        for (int a = k; a >= 0; a--)
            for (int b = k - a; b >= 0; b--) {
                const int nn[3] = {a, b, k - a - b};
                const int i = a > 0 ? 0 : b > 0 ? 1 : 2;
                double s = 0.0;
                for (int j = 0; j < 3; j++) {
                    if (nn[j] == 0) continue;
                    int m1[3] = {nn[0], nn[1], nn[2]};
                    m1[j]--;
                    const double t1 = T[clvox__ff_mono(m1[0], m1[1], m1[2])];
                    double t2 = 0.0;
                    if (nn[j] >= 2) {
                        m1[j]--;
                        t2 = T[clvox__ff_mono(m1[0], m1[1], m1[2])];
                    }
                    if (j == i) s += (2.0 * nn[j] - 1.0) * x[j] * t1 + (double)(nn[j] - 1) * (nn[j] - 1) * t2;
                    else s += 2.0 * nn[j] * x[j] * t1 + (double)nn[j] * (nn[j] - 1) * t2;
                }
                T[clvox__ff_mono(nn[0], nn[1], nn[2])] = -s * id2;
            }
}

static const double INV_FACT[CLVOX__FF_MAX_TERMS] = {1.0,       1.0,         0.5,          1.0 / 6.0,
                                                     1.0 / 24., 1.0 / 120.0, 1.0 / 720.0, 1.0 / 5040.0};

int clvox__ff_eval(const clvox__ff *e, const double p[3], double *est, double *bound)
{
    const int P = e->terms;
    const double x[3] = {e->centre[0] - p[0], e->centre[1] - p[1], e->centre[2] - p[2]};
    const double d2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2];
    /* d's relative error (a few ulps) is covered by taking it 1e-14 smaller */
    const double d = sqrt(d2) * (1.0 - 1e-14);
    if (!(d > e->radius)) return 0;
    double T[NDER];
    derivatives(x, d2, P, T);
    const double q = e->radius / d, a4 = e->area / FOUR_PI / (d * d) * (1.0 + 1e-13);
    double sum = 0.0, qk = 1.0, round = 0.0, three = 3.0;
    for (int k = 0; k < P; k++) {
        double term = 0.0;
        for (int a = k; a >= 0; a--)
            for (int b = k - a; b >= 0; b--) {
                const int c = k - a - b, id = clvox__ff_mono(a, b, c);
                const double f = INV_FACT[a] * INV_FACT[b] * INV_FACT[c];
                term += f * (T[clvox__ff_mono(a + 1, b, c)] * e->m[0][id] + T[clvox__ff_mono(a, b + 1, c)] * e->m[1][id] +
                             T[clvox__ff_mono(a, b, c + 1)] * e->m[2][id]);
            }
        sum -= term / FOUR_PI;
        round += three * (k + 1) * qk;
        three *= 3.0;
        qk *= q;
        /* after k + 1 terms: the tail from k + 1 on, qk = q^(k+1) */
        const int Pn = k + 1;
        const double tail = qk * (Pn + 1 - Pn * q) / ((1.0 - q) * (1.0 - q));
        est[k] = sum;
        bound[k] = a4 * (tail + CLVOX__FF_ROUND * round) * (1.0 + 1e-12);
    }
    return P;
}

int clvox__ff_best(const clvox__ff *e, const double p[3], double *est, double *bound)
{
    double es[CLVOX__FF_MAX_TERMS], bs[CLVOX__FF_MAX_TERMS];
    const int n = clvox__ff_eval(e, p, es, bs);
    if (n == 0) return 0;
    int best = 0;
    for (int k = 1; k < n; k++)
        if (bs[k] < bs[best]) best = k;
    *est = es[best];
    *bound = bs[best];
    return 1;
}

double clvox__ff_tri_exact(const double *tri, const double p[3])
{
    double a[3], b[3], c[3];
    for (int i = 0; i < 3; i++) {
        a[i] = tri[i] - p[i];
        b[i] = tri[3 + i] - p[i];
        c[i] = tri[6 + i] - p[i];
    }
    const double la = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    const double lb = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    const double lc = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    const double det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                       a[2] * (b[0] * c[1] - b[1] * c[0]);
    const double ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2], ac = a[0] * c[0] + a[1] * c[1] + a[2] * c[2],
                 bc = b[0] * c[0] + b[1] * c[1] + b[2] * c[2];
    const double den = la * lb * lc + ab * lc + ac * lb + bc * la;
    return 2.0 * atan2(det, den) / FOUR_PI;
}
