/* SPDX-License-Identifier: Apache-2.0 */
/* The certified far field (src/winding/far_field.c, issue 35), host only:
 * the expansion truncated after P = 1 .. 8 terms against the exact sum of
 * solid angles (tests/reference.c) on random triangle sets -- soups, nearly
 * cancelling pairs (the two faces of a hairline crack), soup triangles
 * closed by tents as the caps close them, closed boxes, and a small
 * triangle placed where the bound is tight -- from random points just
 * outside the sphere (d = r (1 + 1e-3)) to far away. Every error must be
 * within its bound (the worst ratio error / bound is printed); the bound
 * made 10x smaller must fail somewhere (so the test can fail); shifted
 * moments equal direct ones; the dipole term is N . x / (4pi d^3). */
#include "meshgen.h"
#include "reference.h"
#include "test.h"
#include "winding/far_field.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static uint64_t rng_state = 0x9e3779b97f4a7c15ull;
static double rnd(void) /* splitmix64, [0, 1) */
{
    uint64_t z = (rng_state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return (double)(z >> 11) * 0x1p-53;
}
static double rnds(void) { return 2.0 * rnd() - 1.0; }
static void rnd_dir(double v[3])
{
    double n2;
    do {
        for (int a = 0; a < 3; a++) v[a] = rnds();
        n2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    } while (n2 < 1e-3 || n2 > 1.0);
    for (int a = 0; a < 3; a++) v[a] /= sqrt(n2);
}

static double exact_sum(const double *tri, size_t n, const double p[3])
{
    double s = 0.0;
    for (size_t t = 0; t < n; t++) {
        double a[3], b[3], c[3];
        for (int i = 0; i < 3; i++) {
            a[i] = tri[9 * t + i] - p[i];
            b[i] = tri[9 * t + 3 + i] - p[i];
            c[i] = tri[9 * t + 6 + i] - p[i];
        }
        s += ref_solid_angle(a, b, c);
    }
    return s / (4.0 * 3.14159265358979323846);
}

typedef struct stats {
    double worst[CLVOX__FF_MAX_TERMS]; /* worst error / bound per P */
    long points, over, over10;         /* evaluations; errors above the bound; above bound / 10 */
} stats;

/* Checks the expansion of tri[0 .. n) about c from `pts` random points at
 * distances r (1 + eps) for a spread of eps. */
static void check_set(const char *name, const double *tri, size_t n, const double c[3], stats *S, int pts)
{
    clvox__ff e;
    clvox__ff_init(&e, CLVOX__FF_MAX_TERMS, c);
    clvox__ff_add_triangles(&e, tri, n);
    static const double eps[] = {1e-3, 0.01, 0.05, 0.2, 0.5, 1.0, 3.0, 10.0, 100.0};
    for (int i = 0; i < pts; i++) {
        double u[3], p[3], est[CLVOX__FF_MAX_TERMS], bd[CLVOX__FF_MAX_TERMS];
        rnd_dir(u);
        const double R = e.radius * (1.0 + eps[i % (int)(sizeof eps / sizeof *eps)]);
        for (int a = 0; a < 3; a++) p[a] = c[a] + R * u[a];
        const int k = clvox__ff_eval(&e, p, est, bd);
        if (k == 0) continue; /* rounding put p on the sphere */
        const double w = exact_sum(tri, n, p);
        S->points++;
        for (int P = 0; P < k; P++) {
            const double err = fabs(w - est[P]), ratio = err / bd[P];
            if (ratio > S->worst[P]) S->worst[P] = ratio;
            if (err > bd[P]) {
                if (S->over++ < 5)
                    fprintf(stderr, "  %s: P=%d R/r=%.4g err %.3e > bound %.3e\n", name, P + 1, R / e.radius, err,
                            bd[P]);
            }
            if (err > 0.1 * bd[P]) S->over10++;
        }
    }
}

static void tri_set(double *t, const double a[3], const double b[3], const double c[3])
{
    for (int i = 0; i < 3; i++) t[i] = a[i], t[3 + i] = b[i], t[6 + i] = c[i];
}

/* A triangle's closing tent as the caps make it (winding_caps.c): the
 * reversed fan from an apex at the centroid moved off the plane by 0.0731 x
 * its size; tri + tent is closed. Writes 3 triangles. */
static void tent(const double *tri, double *out)
{
    double g[3], e1[3], e2[3], nrm[3];
    for (int a = 0; a < 3; a++) {
        g[a] = (tri[a] + tri[3 + a] + tri[6 + a]) / 3.0;
        e1[a] = tri[3 + a] - tri[a];
        e2[a] = tri[6 + a] - tri[a];
    }
    nrm[0] = e1[1] * e2[2] - e1[2] * e2[1];
    nrm[1] = e1[2] * e2[0] - e1[0] * e2[2];
    nrm[2] = e1[0] * e2[1] - e1[1] * e2[0];
    const double ln = sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
    const double size = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
    for (int a = 0; a < 3; a++) g[a] += 0.0731 * size * nrm[a] / ln;
    for (int i = 0; i < 3; i++) { /* edge v_i -> v_{i+1} reversed, to the apex */
        const double *v = tri + 3 * i, *w = tri + 3 * ((i + 1) % 3);
        tri_set(out + 9 * i, w, v, g);
    }
}

int main(void)
{
    stats S;
    memset(&S, 0, sizeof S);
    double *tri = malloc(400 * 9 * sizeof *tri);
    if (!tri) return 1;

    /* 1. soups: up to 60 random triangles in a unit ball about a random centre */
    for (int s = 0; s < 40; s++) {
        double c[3] = {10 * rnds(), 10 * rnds(), 10 * rnds()};
        size_t n = 1 + (size_t)(rnd() * 60);
        for (size_t t = 0; t < n; t++)
            for (int v = 0; v < 3; v++) {
                double u[3];
                rnd_dir(u);
                const double rr = rnd();
                for (int a = 0; a < 3; a++) tri[9 * t + 3 * v + a] = c[a] + rr * u[a];
            }
        check_set("soup", tri, n, c, &S, 90);
    }
    /* 2. hairline cracks: sheets of soup triangles, each with its mirror
     * (reversed) 1e-6 away, and soups of triangles closed by their tents
     * (what the caps of a cracked soup are); expansion centres off the middle */
    for (int s = 0; s < 30; s++) {
        double c[3] = {rnds(), rnds(), rnds()}, nrm[3];
        rnd_dir(nrm);
        size_t n = 0;
        const size_t pairs = 1 + (size_t)(rnd() * 40);
        for (size_t t = 0; t < pairs; t++) {
            double v[3][3];
            for (int k = 0; k < 3; k++)
                for (int a = 0; a < 3; a++) v[k][a] = c[a] + 0.6 * rnds();
            tri_set(tri + 9 * n++, v[0], v[1], v[2]);
            for (int k = 0; k < 3; k++)
                for (int a = 0; a < 3; a++) v[k][a] += 1e-6 * nrm[a];
            tri_set(tri + 9 * n++, v[0], v[2], v[1]);
        }
        check_set("crack pairs", tri, n, c, &S, 90);
        n = 0;
        const size_t faces = 1 + (size_t)(rnd() * 40);
        for (size_t t = 0; t < faces; t++) { /* a wavy sheet of small faces, each with its tent */
            double v[3][3];
            const double x0 = rnds(), y0 = rnds();
            for (int k = 0; k < 3; k++) {
                const double x = x0 + 0.2 * rnds(), y = y0 + 0.2 * rnds();
                v[k][0] = c[0] + x, v[k][1] = c[1] + y, v[k][2] = c[2] + 0.1 * sin(3 * x + 2 * y) + 1e-6 * rnds();
            }
            tri_set(tri + 9 * n, v[0], v[1], v[2]);
            tent(tri + 9 * n, tri + 9 * (n + 1));
            n += 4;
        }
        check_set("tents", tri, n, c, &S, 90);
        n = 0; /* the tents alone: the caps of a cracked soup */
        for (size_t t = 0; t < faces; t++) {
            double v[9];
            for (int k = 0; k < 3; k++) {
                const double x = 0.5 * rnds(), y = 0.5 * rnds();
                v[3 * k] = c[0] + x, v[3 * k + 1] = c[1] + y, v[3 * k + 2] = c[2] + 0.2 * x * y;
            }
            tent(v, tri + 9 * n);
            n += 3;
        }
        check_set("caps", tri, n, c, &S, 90);
    }
    /* 3. closed boxes (w = 0 outside): 12 triangles, centred or not */
    for (int s = 0; s < 20; s++) {
        tmesh b = tmesh_box(rnds(), rnds(), rnds(), 1 + rnd(), 1 + rnd(), 1 + rnd());
        for (size_t t = 0; t < b.nt; t++)
            for (int v = 0; v < 3; v++)
                for (int a = 0; a < 3; a++) tri[9 * t + 3 * v + a] = b.xyz[3 * b.tri[3 * t + v] + a];
        double c[3] = {0.3 * rnds(), 0.3 * rnds(), 0.3 * rnds()};
        check_set("box", tri, b.nt, c, &S, 120);
        tmesh_free(&b);
    }
    printf("worst error / bound on the random sets, P = 1 .. %d:", CLVOX__FF_MAX_TERMS);
    for (int P = 0; P < CLVOX__FF_MAX_TERMS; P++) printf(" %.3f", S.worst[P]);
    printf("\n");
    /* 4. where the bound is tight: a small triangle at distance rho from c
     * along x with its normal along x, seen from the -x axis (every
     * derivative meets its norm there as rho / d -> 0) */
    for (int s = 0; s < 8; s++) {
        const double c[3] = {0, 0, 0}, h = 1e-3;
        const double a[3] = {1, -h, -h}, b2[3] = {1, h, -h}, c2[3] = {1, 0, h};
        tri_set(tri, a, b2, c2);
        clvox__ff e;
        clvox__ff_init(&e, CLVOX__FF_MAX_TERMS, c);
        clvox__ff_add_triangles(&e, tri, 1);
        const double R = e.radius * (4.0 + 6.0 * s);
        const double p[3] = {-R, 0, 0};
        double est[CLVOX__FF_MAX_TERMS], bd[CLVOX__FF_MAX_TERMS];
        CHECK(clvox__ff_eval(&e, p, est, bd) == CLVOX__FF_MAX_TERMS);
        const double w = exact_sum(tri, 1, p);
        for (int P = 0; P < CLVOX__FF_MAX_TERMS; P++) {
            const double err = fabs(w - est[P]);
            if (err / bd[P] > S.worst[P]) S.worst[P] = err / bd[P];
            if (err > bd[P]) S.over++;
            if (err > 0.1 * bd[P]) S.over10++;
        }
        S.points++;
    }
    printf("far field: %ld points x %d truncations, %ld over the bound, %ld over bound/10\n", S.points,
           CLVOX__FF_MAX_TERMS, S.over, S.over10);
    printf("worst error / bound, P = 1 .. %d:", CLVOX__FF_MAX_TERMS);
    for (int P = 0; P < CLVOX__FF_MAX_TERMS; P++) printf(" %.3f", S.worst[P]);
    printf("\n");
    CHECK(S.points > 10000);
    CHECK_MSG(S.over == 0, "%ld errors above their bound", S.over);
    CHECK_MSG(S.over10 > 0, "a bound 10x smaller never fails: the test cannot fail");
    for (int P = 0; P < 3; P++) CHECK_MSG(S.worst[P] > 0.1, "P=%d: worst ratio %.3g", P + 1, S.worst[P]);

    /* 5. translation: two halves shifted into one expansion = the direct one */
    {
        const double c[3] = {0.1, -0.2, 0.3}, c1[3] = {0.5, 0.5, 0}, c2[3] = {-0.4, 0.2, -0.6};
        size_t n = 30;
        for (size_t t = 0; t < n; t++)
            for (int v = 0; v < 9; v++) tri[9 * t + v] = rnds();
        clvox__ff d, h1, h2, s;
        clvox__ff_init(&d, CLVOX__FF_MAX_TERMS, c);
        clvox__ff_add_triangles(&d, tri, n);
        clvox__ff_init(&h1, CLVOX__FF_MAX_TERMS, c1);
        clvox__ff_add_triangles(&h1, tri, n / 2);
        clvox__ff_init(&h2, CLVOX__FF_MAX_TERMS, c2);
        clvox__ff_add_triangles(&h2, tri + 9 * (n / 2), n - n / 2);
        clvox__ff_init(&s, CLVOX__FF_MAX_TERMS, c);
        clvox__ff_add_shifted(&s, &h1);
        clvox__ff_add_shifted(&s, &h2);
        double worst = 0.0, scale = 0.0;
        for (int j = 0; j < 3; j++)
            for (int m = 0; m < CLVOX__FF_NMOM; m++) {
                worst = fmax(worst, fabs(d.m[j][m] - s.m[j][m]));
                scale = fmax(scale, fabs(d.m[j][m]));
            }
        CHECK_MSG(worst <= 1e-12 * scale, "shifted moments off by %.3g of %.3g", worst, scale);
        CHECK(fabs(d.area - s.area) <= 1e-13 * d.area);
        CHECK(s.radius >= d.radius);
        /* the shifted expansion's bound holds too */
        long over = 0;
        for (int i = 0; i < 500; i++) {
            double u[3], p[3], est[CLVOX__FF_MAX_TERMS], bd[CLVOX__FF_MAX_TERMS];
            rnd_dir(u);
            for (int a = 0; a < 3; a++) p[a] = c[a] + s.radius * (1.0 + 0.01 * (i % 50)) * u[a];
            if (!clvox__ff_eval(&s, p, est, bd)) continue;
            const double w = exact_sum(tri, n, p);
            for (int P = 0; P < CLVOX__FF_MAX_TERMS; P++) over += fabs(w - est[P]) > bd[P];
        }
        CHECK_MSG(over == 0, "%ld shifted evaluations over their bound", over);
    }
    /* 6. the dipole term and the exact solid angle agree with the references */
    {
        const double c[3] = {0, 0, 0}, p[3] = {3, -2, 5};
        for (int v = 0; v < 9; v++) tri[v] = 0.3 * rnds();
        clvox__ff e;
        clvox__ff_init(&e, 2, c);
        clvox__ff_add_triangles(&e, tri, 1);
        double est[2], bd[2], x[3] = {-3, 2, -5};
        CHECK(clvox__ff_eval(&e, p, est, bd) == 2);
        const double d = sqrt(38.0);
        const double dip = (e.m[0][0] * x[0] + e.m[1][0] * x[1] + e.m[2][0] * x[2]) / (4 * 3.14159265358979323846 * d * d * d);
        CHECK_MSG(fabs(est[0] - dip) <= 1e-15 + 1e-13 * fabs(dip), "%.17g vs %.17g", est[0], dip);
        CHECK(fabs(clvox__ff_tri_exact(tri, p) - exact_sum(tri, 1, p)) <= 1e-15);
        /* d <= r: no bound */
        const double q[3] = {0.01, 0.0, 0.0};
        CHECK(clvox__ff_eval(&e, q, est, bd) == 0);
    }
    free(tri);
    return test_report();
}
