/* SPDX-License-Identifier: Apache-2.0 */
/* Scanning the bytes of a mesh file, shared by the per-format checks and
 * readers (mesh_stl.c, mesh_off.c, mesh_obj.c, mesh_ply.c, mesh_om.c): text
 * lines and tokens as iostream's operator>> finds them, numbers checked and
 * converted as it reads them (mesh_scan.c), little-endian words. The
 * tokenizer steps are inline: they run once per character of a text mesh.
 * Internal. */
#ifndef CLVOX_MESH_SCAN_H
#define CLVOX_MESH_SCAN_H
#include "core/internal.h"

#include <locale.h>
#include <string.h>

static inline uint32_t le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static inline float le_float(const unsigned char *p)
{
    uint32_t u = le32(p);
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

typedef struct text {
    const char *p, *end;
    uint64_t line; /* 1-based line of p */
} text;

typedef struct tok {
    const char *s;
    size_t n;
    uint64_t line;
} tok;

/* The characters operator>> skips (isspace in the C locale). */
static inline int is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }
static inline int is_digit(char c) { return c >= '0' && c <= '9'; }

/* Next token on the current line; 0 at the end of the line (p stays on '\n'). */
static inline int tok_line(text *t, tok *k)
{
    while (t->p < t->end && is_space(*t->p)) t->p++;
    if (t->p >= t->end || *t->p == '\n') return 0;
    k->s = t->p;
    k->line = t->line;
    while (t->p < t->end && !is_space(*t->p) && *t->p != '\n') t->p++;
    k->n = (size_t)(t->p - k->s);
    return 1;
}

/* Next token anywhere, as operator>> would find it; 0 at the end of the file. */
static inline int tok_any(text *t, tok *k)
{
    for (;;) {
        while (t->p < t->end && is_space(*t->p)) t->p++;
        if (t->p >= t->end) return 0;
        if (*t->p != '\n') break;
        t->p++;
        t->line++;
    }
    return tok_line(t, k);
}

static inline void skip_line(text *t)
{
    const char *nl = memchr(t->p, '\n', (size_t)(t->end - t->p));
    if (nl) {
        t->p = nl + 1;
        t->line++;
    } else {
        t->p = t->end;
    }
}

static inline int tok_is(const tok *k, const char *word)
{
    size_t n = strlen(word);
    return k->n == n && memcmp(k->s, word, n) == 0;
}

static inline int tok_print_len(const tok *k) { return k->n > 40 ? 40 : (int)k->n; }

/* Stores coordinate c of vertex v relative to vertex 0 (which sets the offset). */
static inline void store_coord(clvox__raw_mesh *raw, uint64_t v, int c, double x)
{
    if (v == 0) raw->offset[c] = x;
    raw->xyz[3 * v + (size_t)c] = (float)(x - raw->offset[c]);
}

enum { NUM_BAD = 0, NUM_OK, NUM_NONFINITE };

/* Whether the whole token reads as a float with operator>>: NUM_NONFINITE for
 * nan/inf spellings and values beyond FLT_MAX (the read fails), NUM_BAD for
 * anything that is not a plain decimal number. Underflow is fine (reads 0). */
int clvox__classify_float(const tok *k);

/* Integer token as operator>> reads it into an int/unsigned: [+-]digits.
 * Returns 1 and the value (negative allowed), 0 if not an integer or beyond
 * 64-bit range. */
int clvox__parse_int(const tok *k, int64_t *out);

/* Text formats must not contain NUL bytes (random or binary data). */
clvox_status clvox__check_text(clvox_context *ctx, const char *path, const char *p, size_t n, const char *what);

/* A coordinate token: a finite float. */
clvox_status clvox__check_coord(clvox_context *ctx, const char *path, const tok *k, const char *where);

/* The native text readers run under the C numeric locale, so that strtod
 * reads '.' decimals whatever the caller's locale is. */
clvox_status clvox__c_locale_begin(clvox_context *ctx, const char *path, locale_t *c, locale_t *old);
void clvox__c_locale_end(locale_t c, locale_t old);

/* Ends a native read: the partial mesh is freed on failure, *parsed set on success. */
clvox_status clvox__text_read_done(clvox_status st, clvox__raw_mesh *native, int *parsed);

/* A text coordinate in double (strtod), finite as a float, else 0. */
int clvox__token_double(const tok *k, double *out);

/* Clinger's fast path: a plain decimal token read exactly into a double;
 * 0 when it is not one (mesh_scan.c). */
int clvox__fast_decimal(const tok *k, double *out);

/* A float coordinate token (clvox__classify_float said NUM_OK) as operator>>
 * (strtof) reads it; 0 when memory runs out. */
int clvox__token_float(const tok *k, float *out);
#endif
