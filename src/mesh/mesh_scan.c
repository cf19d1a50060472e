/* SPDX-License-Identifier: Apache-2.0 */
/* Numbers in the text mesh formats, read the way OpenMesh's iostream
 * operator>> reads them (whole token, float range, C locale), and the C
 * locale the native text readers run under (mesh_scan.h). */
#include "mesh_scan.h"

#include <math.h>
#include <stdlib.h>

/* Whether the whole token reads as a float with operator>>: NUM_NONFINITE for
 * nan/inf spellings and values beyond FLT_MAX (the read fails), NUM_BAD for
 * anything that is not a plain decimal number. Underflow is fine (reads 0). */
int clvox__classify_float(const tok *k)
{
    const char *s = k->s;
    size_t n = k->n, i = 0;
    if (i < n && (s[i] == '+' || s[i] == '-')) i++;
    /* nan, inf, infinity (any case), MSVC's 1.#INF / 1.#IND / 1.#QNAN */
    if (n - i >= 3) {
        char a = (char)(s[i] | 0x20), b = (char)(s[i + 1] | 0x20), c = (char)(s[i + 2] | 0x20);
        if ((a == 'n' && b == 'a' && c == 'n') || (a == 'i' && b == 'n' && c == 'f')) return NUM_NONFINITE;
    }
    if (memchr(s, '#', n)) return NUM_NONFINITE;
    long lead = 0;       /* decimal exponent of the first significant digit */
    int have_sig = 0, digits = 0;
    uint64_t sig9 = 0;   /* first 9 significant digits */
    int sig_count = 0;
    for (; i < n && is_digit(s[i]); i++, digits++) {
        if (!have_sig && s[i] != '0') have_sig = 1, lead = -1;
        if (have_sig) {
            lead++;
            if (sig_count < 9) sig9 = sig9 * 10 + (uint64_t)(s[i] - '0'), sig_count++;
        }
    }
    if (i < n && s[i] == '.') {
        i++;
        long pos = 0;
        for (; i < n && is_digit(s[i]); i++, digits++) {
            pos++;
            if (!have_sig && s[i] != '0') have_sig = 1, lead = -pos;
            if (have_sig && sig_count < 9) sig9 = sig9 * 10 + (uint64_t)(s[i] - '0'), sig_count++;
        }
    }
    if (!digits) return NUM_BAD;
    if (i < n && (s[i] == 'e' || s[i] == 'E')) {
        i++;
        int neg = 0;
        if (i < n && (s[i] == '+' || s[i] == '-')) neg = s[i] == '-', i++;
        if (i >= n || !is_digit(s[i])) return NUM_BAD;
        long e = 0;
        for (; i < n && is_digit(s[i]); i++)
            if (e < 100000) e = e * 10 + (s[i] - '0');
        lead += neg ? -e : e;
    }
    if (i != n) return NUM_BAD;
    if (!have_sig || lead < 38) return NUM_OK;
    if (lead > 38) return NUM_NONFINITE;
    while (sig_count < 9) sig9 *= 10, sig_count++;
    return sig9 > 340282346u ? NUM_NONFINITE : NUM_OK; /* FLT_MAX = 3.40282346e38 */
}

/* Integer token as operator>> reads it into an int/unsigned: [+-]digits.
 * Returns 1 and the value (negative allowed), 0 if not an integer or beyond
 * 64-bit range. */
int clvox__parse_int(const tok *k, int64_t *out)
{
    size_t i = 0;
    int neg = 0;
    if (k->n && (k->s[0] == '+' || k->s[0] == '-')) neg = k->s[0] == '-', i++;
    if (i >= k->n) return 0;
    uint64_t v = 0;
    for (; i < k->n; i++) {
        if (!is_digit(k->s[i])) return 0;
        if (v > (uint64_t)INT64_MAX / 10) return 0;
        v = v * 10 + (uint64_t)(k->s[i] - '0');
        if (v > (uint64_t)INT64_MAX) return 0;
    }
    *out = neg ? -(int64_t)v : (int64_t)v;
    return 1;
}

/* Text formats must not contain NUL bytes (random or binary data). */
clvox_status clvox__check_text(clvox_context *ctx, const char *path, const char *p, size_t n, const char *what)
{
    const char *z = memchr(p, 0, n);
    if (z)
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s' is not a valid %s file: binary data (NUL byte) at offset %zu",
                           path, what, (size_t)(z - p));
    return CLVOX_OK;
}

/* A coordinate token: a finite float. */
clvox_status clvox__check_coord(clvox_context *ctx, const char *path, const tok *k, const char *where)
{
    int c = clvox__classify_float(k);
    if (c == NUM_OK) return CLVOX_OK;
    if (c == NUM_NONFINITE)
        return clvox__fail(ctx, CLVOX_ERR_MESH_INVALID,
                           "'%s': non-finite coordinate '%.*s' at line %llu (%s)", path, tok_print_len(k), k->s,
                           (unsigned long long)k->line, where);
    return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': expected a number at line %llu (%s), found '%.*s'", path,
                       (unsigned long long)k->line, where, tok_print_len(k), k->s);
}

/* The native text readers run under the C numeric locale, so that strtod
 * reads '.' decimals whatever the caller's locale is. */
clvox_status clvox__c_locale_begin(clvox_context *ctx, const char *path, locale_t *c, locale_t *old)
{
    *c = newlocale(LC_NUMERIC_MASK, "C", (locale_t)0);
    if (!*c) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "cannot create the C locale to read '%s'", path);
    *old = uselocale(*c);
    return CLVOX_OK;
}

void clvox__c_locale_end(locale_t c, locale_t old)
{
    uselocale(old);
    freelocale(c);
}

/* Ends a native read: the partial mesh is freed on failure, *parsed set on success. */
clvox_status clvox__text_read_done(clvox_status st, clvox__raw_mesh *native, int *parsed)
{
    if (st) {
        clvox__raw_mesh_free(native);
        return st;
    }
    *parsed = 1;
    return CLVOX_OK;
}

/* A float token already accepted by clvox__classify_float, converted in the C
 * locale (as iostream does) whatever LC_NUMERIC the caller set. */
/* A text coordinate in double, so that it keeps the file's precision until it
 * is stored relative to the mesh's first vertex (clvox__mesh_build). Refused as
 * before when it is not finite as a float. */
int clvox__token_double(const tok *k, double *out)
{
    char buf[64];
    if (k->n >= sizeof buf) return 0;
    memcpy(buf, k->s, k->n);
    buf[k->n] = 0;
    char *end;
    *out = strtod(buf, &end);
    return end == buf + k->n && isfinite((float)*out);
}

/* Clinger's fast path: a token [+-]digits[.digits][(e|E)[+-]digits] whose
 * significant digits make an integer m <= 2^53 and whose decimal exponent e
 * is within +-22 is m * 10^e or m / 10^-e, both operands exact in double, so
 * the one rounding of that operation is the correctly rounded value: what
 * strtod returns. Such a value is below 1e38, so it is also one that
 * clvox__classify_float accepts (finite as a float). Returns 0 for anything else
 * (the caller checks and converts it the slow way, with the same result or
 * error as before). */
int clvox__fast_decimal(const tok *k, double *out)
{
    static const double pow10[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                     1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
    const char *s = k->s, *end = k->s + k->n;
    int neg = 0;
    if (s < end && (*s == '+' || *s == '-')) neg = *s++ == '-';
    uint64_t m = 0;
    int digits = 0, sig = 0; /* digits read; significant ones (from the first non-zero) */
    long e = 0;
    for (; s < end && is_digit(*s); s++, digits++) {
        if (sig || *s != '0') {
            if (++sig > 19) return 0;
            m = m * 10 + (uint64_t)(*s - '0');
        }
    }
    if (s < end && *s == '.') {
        for (s++; s < end && is_digit(*s); s++, digits++) {
            if (sig || *s != '0') {
                if (++sig > 19) return 0;
                m = m * 10 + (uint64_t)(*s - '0');
            }
            e--;
        }
    }
    if (!digits) return 0;
    if (s < end && (*s == 'e' || *s == 'E')) {
        s++;
        int eneg = 0;
        if (s < end && (*s == '+' || *s == '-')) eneg = *s++ == '-';
        if (s >= end || !is_digit(*s)) return 0;
        long x = 0;
        for (; s < end && is_digit(*s); s++) {
            if (x > 1000) return 0;
            x = x * 10 + (*s - '0');
        }
        e += eneg ? -x : x;
    }
    if (s != end || m > ((uint64_t)1 << 53) || e < -22 || e > 22) return 0;
    double v = (double)m;
    v = e < 0 ? v / pow10[-e] : v * pow10[e];
    *out = neg ? -v : v;
    return 1;
}

/* A float coordinate token (clvox__classify_float said NUM_OK) as operator>>
 * (strtof) reads it. The fast path: Clinger's double d (strtod's value)
 * rounded to float is strtof's value unless d is exactly half-way between
 * two floats (double rounding can only go wrong there: any other half-way
 * point between the true value and d would be a double nearer to it) or
 * below the normal floats; those, and all others, go to strtof (C locale:
 * the caller set it). */
int clvox__token_float(const tok *k, float *out)
{
    double d;
    if (clvox__fast_decimal(k, &d)) {
        uint64_t u;
        memcpy(&u, &d, sizeof u);
        if ((u & 0x1FFFFFFFu) != 0x10000000u && (fabs(d) >= 0x1p-125 || d == 0.0)) {
            *out = (float)d;
            return 1;
        }
    }
    char buf[64], *s = buf;
    if (k->n >= sizeof buf && !(s = malloc(k->n + 1))) return 0; /* a long spelling ("0.000...1") */
    memcpy(s, k->s, k->n);
    s[k->n] = 0;
    *out = strtof(s, NULL);
    if (s != buf) free(s);
    return 1;
}
