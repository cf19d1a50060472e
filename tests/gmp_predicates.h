/* SPDX-License-Identifier: Apache-2.0 */
/* The exact signs of kernels/overlap.h's predicates in GMP rationals (the
 * tests' oracle: tests/test_surface.c, tests/test_overlap_float.c). Every
 * argument is a double holding a float (or any double: mpq_set_d is exact). */
#ifndef CLVOX_GMP_PREDICATES_H
#define CLVOX_GMP_PREDICATES_H

#include <gmp.h>

/* sign((b.s - a.s)(d.t - c.t) - (b.t - a.t)(d.s - c.s)), p = as at bs bt cs ct ds dt */
static int gmp_e2(const double *p)
{
    mpq_t q[8], d1, d2, l, r;
    for (int i = 0; i < 8; i++) mpq_init(q[i]), mpq_set_d(q[i], p[i]);
    mpq_inits(d1, d2, l, r, NULL);
    /* (b.s - a.s)(d.t - c.t) - (b.t - a.t)(d.s - c.s); p = as at bs bt cs ct ds dt */
    mpq_sub(d1, q[2], q[0]);
    mpq_sub(d2, q[7], q[5]);
    mpq_mul(l, d1, d2);
    mpq_sub(d1, q[3], q[1]);
    mpq_sub(d2, q[6], q[4]);
    mpq_mul(r, d1, d2);
    mpq_sub(l, l, r);
    int s = mpq_sgn(l);
    for (int i = 0; i < 8; i++) mpq_clear(q[i]);
    mpq_clears(d1, d2, l, r, NULL);
    return s;
}

/* sign(((v1 - v0) x (v2 - v0)) . (q - v0)), v = v0 v1 v2 (x, y, z each) */
static int gmp_o3(const double *v, const double *qp)
{
    mpq_t a[3], b[3], w[3], t, u, det;
    mpq_inits(t, u, det, NULL);
    for (int i = 0; i < 3; i++) {
        mpq_inits(a[i], b[i], w[i], NULL);
        mpq_set_d(t, v[i]);
        mpq_set_d(a[i], v[3 + i]);
        mpq_sub(a[i], a[i], t);
        mpq_set_d(b[i], v[6 + i]);
        mpq_sub(b[i], b[i], t);
        mpq_set_d(w[i], qp[i]);
        mpq_sub(w[i], w[i], t);
    }
    mpq_set_ui(det, 0, 1);
    for (int i = 0; i < 3; i++) { /* w_i * (a x b)_i */
        int j = (i + 1) % 3, k = (i + 2) % 3;
        mpq_mul(t, a[j], b[k]);
        mpq_mul(u, a[k], b[j]);
        mpq_sub(t, t, u);
        mpq_mul(t, t, w[i]);
        mpq_add(det, det, t);
    }
    int s = mpq_sgn(det);
    for (int i = 0; i < 3; i++) mpq_clears(a[i], b[i], w[i], NULL);
    mpq_clears(t, u, det, NULL);
    return s;
}

#endif /* CLVOX_GMP_PREDICATES_H */
