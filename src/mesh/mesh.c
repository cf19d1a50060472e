/* SPDX-License-Identifier: Apache-2.0 */
/* Mesh stage: guarded loading, validation, fan triangulation and the report.
 *
 * Loading = check the file ourselves, let OpenMesh read it
 * (mesh_openmesh.cpp), cross-check what came back. OpenMesh 9.0 hangs,
 * throws, aborts or silently reads garbage on many bad inputs (NOTES-deps),
 * so nothing reaches it before the checks below say its reader will cope:
 *   - a regular, non-empty file with a known extension;
 *   - PLY: the header is parsed here (bounded, strict); binary bodies are
 *     walked record by record so a truncated file is caught; ASCII bodies are
 *     scanned token by token exactly as OpenMesh's reader consumes them;
 *   - OFF: ASCII files are parsed here, not by OpenMesh (its reader supports
 *     no comments, wants the counts on the second line and misreads face
 *     colours without a COFF header); binary ones are walked face by face;
 *   - OBJ: parsed here, not by OpenMesh (its reader aborts on "f /1", wraps
 *     bad indices, skips bad vertex lines and opens the material library);
 *   - ASCII STL: every vertex line must hold three finite numbers and the
 *     file must end with endsolid;
 *   - binary STL: the size must be exactly 84 + 50 n, coordinates finite;
 *     a file that is neither that nor a well-formed ASCII STL is rejected;
 *   - OM: the chunk sequence is walked as OpenMesh's reader consumes it (it
 *     asserts on odd chunk headers and accepts a file cut at a chunk end).
 * Numbers are checked the way iostream's operator>> reads a float: the whole
 * token must be a decimal number within float range (it fails on nan, inf and
 * overflow, and a failed read desynchronises everything after it). The check
 * does not depend on the C locale.
 *
 * Validation common to files and arrays (build_mesh): finite coordinates,
 * indices in range, faces with fewer than 3 corners and triangles with a
 * repeated index dropped, polygons fanned, zero-area triangles kept (they
 * matter for parity), at least one triangle. */
#include "mesh_internal.h"
#include "winding/winding.h"

#include <errno.h>
#include <fcntl.h>
#include <locale.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* ---- small helpers ------------------------------------------------------- */

enum mesh_format { FMT_UNKNOWN = 0, FMT_OBJ, FMT_OFF, FMT_PLY, FMT_STL, FMT_OM };

static enum mesh_format format_of(const char *path, const char **ext_out)
{
    const char *dot = strrchr(path, '.');
    const char *slash = strrchr(path, '/');
    *ext_out = "";
    if (!dot || (slash && dot < slash)) return FMT_UNKNOWN;
    *ext_out = dot + 1;
    static const struct { const char *ext; enum mesh_format fmt; } known[] = {
        {"obj", FMT_OBJ}, {"off", FMT_OFF}, {"ply", FMT_PLY}, {"stl", FMT_STL}, {"om", FMT_OM},
    };
    for (size_t k = 0; k < sizeof known / sizeof known[0]; k++) {
        const char *a = dot + 1, *b = known[k].ext;
        while (*a && *b && (*a | 0x20) == *b) a++, b++;
        if (!*a && !*b) return known[k].fmt;
    }
    return FMT_UNKNOWN;
}

int clvox__is_mesh_path(const char *path)
{
    const char *ext;
    return path && format_of(path, &ext) != FMT_UNKNOWN;
}

static uint32_t le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static float le_float(const unsigned char *p)
{
    uint32_t u = le32(p);
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

/* What the checks learnt about the file; the mesh OpenMesh returns must agree. */
typedef struct expect {
    int have_vertices, have_faces;
    uint64_t vertices, faces;
} expect;

/* ---- text scanning ----------------------------------------------------------- */

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
static int is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }
static int is_digit(char c) { return c >= '0' && c <= '9'; }

/* Next token on the current line; 0 at the end of the line (p stays on '\n'). */
static int tok_line(text *t, tok *k)
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
static int tok_any(text *t, tok *k)
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

static void skip_line(text *t)
{
    const char *nl = memchr(t->p, '\n', (size_t)(t->end - t->p));
    if (nl) {
        t->p = nl + 1;
        t->line++;
    } else {
        t->p = t->end;
    }
}

static int tok_is(const tok *k, const char *word)
{
    size_t n = strlen(word);
    return k->n == n && memcmp(k->s, word, n) == 0;
}

enum { NUM_BAD = 0, NUM_OK, NUM_NONFINITE };

/* Whether the whole token reads as a float with operator>>: NUM_NONFINITE for
 * nan/inf spellings and values beyond FLT_MAX (the read fails), NUM_BAD for
 * anything that is not a plain decimal number. Underflow is fine (reads 0). */
static int classify_float(const tok *k)
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
static int parse_int(const tok *k, int64_t *out)
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

static int tok_print_len(const tok *k) { return k->n > 40 ? 40 : (int)k->n; }

/* Text formats must not contain NUL bytes (random or binary data). */
static clvox_status check_text(clvox_context *ctx, const char *path, const char *p, size_t n, const char *what)
{
    const char *z = memchr(p, 0, n);
    if (z)
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s' is not a valid %s file: binary data (NUL byte) at offset %zu",
                           path, what, (size_t)(z - p));
    return CLVOX_OK;
}

/* A coordinate token: a finite float. */
static clvox_status check_coord(clvox_context *ctx, const char *path, const tok *k, const char *where)
{
    int c = classify_float(k);
    if (c == NUM_OK) return CLVOX_OK;
    if (c == NUM_NONFINITE)
        return clvox__fail(ctx, CLVOX_ERR_MESH_INVALID,
                           "'%s': non-finite coordinate '%.*s' at line %llu (%s)", path, tok_print_len(k), k->s,
                           (unsigned long long)k->line, where);
    return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': expected a number at line %llu (%s), found '%.*s'", path,
                       (unsigned long long)k->line, where, tok_print_len(k), k->s);
}

/* ---- STL ------------------------------------------------------------------------ */

static int token_float(const tok *k, float *out);

/* ASCII STL read natively (after check_stl_ascii accepted it): the facets'
 * corners, as strtof reads them (OpenMesh's operator>>), laid out as a binary
 * STL in memory and merged by the binary reader (clvox__stl_read_binary:
 * OpenMesh's vertex merging, the same for both). Only for the plain layout
 * OpenMesh surely reads the same way: one "solid" line first, one
 * "endsolid" line last; else *parsed stays 0 and OpenMesh reads the file.
 * The same when a coordinate is tiny (the binary reader's return 1). */
static clvox_status read_stl_ascii(clvox_context *ctx, const char *path, const char *p, size_t n,
                                   clvox__raw_mesh *raw, int *parsed)
{
    text t = {p, p + n, 1};
    tok k;
    uint64_t facets = 0, solids = 0, ended = 0, after_end = 0;
    while (t.p < t.end) {
        if (tok_line(&t, &k)) {
            if (ended) after_end = 1;
            if (tok_is(&k, "facet")) facets++;
            else if (tok_is(&k, "solid")) solids++;
            else if (tok_is(&k, "endsolid")) ended = 1;
        }
        skip_line(&t);
    }
    if (solids != 1 || after_end || facets > (SIZE_MAX - 84) / 50) return CLVOX_OK; /* OpenMesh reads it */
    size_t bytes = 84 + 50 * (size_t)facets;
    unsigned char *img = calloc(bytes, 1);
    if (!img) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", path);
    uint32_t nf32 = (uint32_t)facets;
    for (int b = 0; b < 4; b++) img[80 + b] = (unsigned char)(nf32 >> (8 * b));
    t = (text){p, p + n, 1};
    uint64_t f = 0, corner = 0;
    while (t.p < t.end) {
        if (tok_line(&t, &k)) {
            if (tok_is(&k, "facet")) {
                f++;
                corner = 0;
            } else if (tok_is(&k, "vertex") && f && corner < 3) { /* the check made sure of 3 numbers */
                unsigned char *r = img + 84 + 50 * (f - 1) + 12 + 12 * corner++;
                for (int c = 0; c < 3; c++) {
                    float x = 0;
                    if (!tok_line(&t, &k) || !token_float(&k, &x)) {
                        free(img);
                        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", path);
                    }
                    uint32_t u;
                    memcpy(&u, &x, sizeof u);
                    for (int b = 0; b < 4; b++) r[4 * c + b] = (unsigned char)(u >> (8 * b)); /* little endian */
                }
            }
        }
        skip_line(&t);
    }
    int rc = clvox__stl_read_binary(img, bytes, raw);
    free(img);
    if (rc == -2) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", path);
    *parsed = rc == 0;
    return CLVOX_OK;
}

static clvox_status check_stl_ascii(clvox_context *ctx, const char *path, const char *p, size_t n,
                                    const char *binary_note)
{
    /* Structure errors are reported with the binary reading as well: a
     * truncated binary STL whose header starts with "solid" lands here. */
    const char *z = memchr(p, 0, n);
    if (z)
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                           "'%s' is not a valid STL: %s; as ASCII: binary data at offset %zu", path, binary_note,
                           (size_t)(z - p));
    text t = {p, p + n, 1};
    tok k;
    uint64_t facets = 0, in_facet = 0;
    int first = 1, ended = 0;
    while (t.p < t.end) {
        if (tok_line(&t, &k)) {
            if (first && !tok_is(&k, "solid"))
                return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s' is not a valid STL: %s", path, binary_note);
            first = 0;
            ended = tok_is(&k, "endsolid");
            if (tok_is(&k, "vertex")) {
                if (!in_facet)
                    return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': ASCII STL vertex outside a facet at line %llu",
                                       path, (unsigned long long)k.line);
                for (int c = 0; c < 3; c++) {
                    if (!tok_line(&t, &k))
                        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                                           "'%s': ASCII STL vertex at line %llu has fewer than 3 coordinates", path,
                                           (unsigned long long)t.line);
                    clvox_status st = check_coord(ctx, path, &k, "STL vertex");
                    if (st) return st;
                }
                in_facet++;
            } else if (tok_is(&k, "facet")) {
                if (in_facet)
                    return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': ASCII STL facet not closed before line %llu",
                                       path, (unsigned long long)k.line);
                in_facet = 1;
                facets++;
            } else if (tok_is(&k, "endfacet")) {
                if (in_facet != 4)
                    return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                                       "'%s': ASCII STL facet ending at line %llu has %llu vertices, not 3", path,
                                       (unsigned long long)k.line, (unsigned long long)(in_facet ? in_facet - 1 : 0));
                in_facet = 0;
            } else if (!tok_is(&k, "solid") && !tok_is(&k, "endsolid") && !tok_is(&k, "outer") &&
                       !tok_is(&k, "endloop")) {
                return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                                   "'%s' is not a valid STL: %s; as ASCII: unexpected '%.*s' at line %llu", path,
                                   binary_note, tok_print_len(&k), k.s, (unsigned long long)k.line);
            }
        }
        skip_line(&t);
    }
    if (in_facet)
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': ASCII STL is truncated inside facet %llu", path,
                           (unsigned long long)facets);
    if (!ended)
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': ASCII STL is truncated (it does not end with endsolid)",
                           path);
    return CLVOX_OK;
}

static clvox_status check_stl(clvox_context *ctx, const char *path, const unsigned char *p, size_t n)
{
    char note[160] = "too short for a binary STL";
    if (n >= 84) {
        uint64_t count = le32(p + 80);
        uint64_t want = 84 + 50 * count;
        if (want == n) { /* binary, whatever the header says */
            for (uint64_t t = 0; t < count; t++) {
                const unsigned char *r = p + 84 + 50 * t + 12; /* skip the normal */
                for (int c = 0; c < 9; c++)
                    if (!isfinite(le_float(r + 4 * c)))
                        return clvox__fail(ctx, CLVOX_ERR_MESH_INVALID,
                                           "'%s': non-finite coordinate in triangle %llu of the binary STL", path,
                                           (unsigned long long)t);
            }
            return CLVOX_OK;
        }
        snprintf(note, sizeof note, "as binary it declares %llu triangles (%llu bytes) but has %zu bytes (truncated?)",
                 (unsigned long long)count, (unsigned long long)want, n);
    }
    size_t i = 0;
    while (i < n && (is_space((char)p[i]) || p[i] == '\n')) i++;
    if (n - i < 5 || memcmp(p + i, "solid", 5) != 0)
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s' is not a valid STL: %s, and it does not start with 'solid'",
                           path, note);
    return check_stl_ascii(ctx, path, (const char *)p, n, note);
}

/* ---- OFF ------------------------------------------------------------------------ */

/* Next line holding data: '#' starts a comment, blank lines are skipped.
 * *line covers the data part of the line; t moves past it. */
/* The native text readers run under the C numeric locale, so that strtod
 * reads '.' decimals whatever the caller's locale is. */
static clvox_status c_locale_begin(clvox_context *ctx, const char *path, locale_t *c, locale_t *old)
{
    *c = newlocale(LC_NUMERIC_MASK, "C", (locale_t)0);
    if (!*c) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "cannot create the C locale to read '%s'", path);
    *old = uselocale(*c);
    return CLVOX_OK;
}

static void c_locale_end(locale_t c, locale_t old)
{
    uselocale(old);
    freelocale(c);
}

/* Ends a native read: the partial mesh is freed on failure, *parsed set on success. */
static clvox_status text_read_done(clvox_status st, clvox__raw_mesh *native, int *parsed)
{
    if (st) {
        clvox__raw_mesh_free(native);
        return st;
    }
    *parsed = 1;
    return CLVOX_OK;
}

static int next_data_line(text *t, text *line)
{
    while (t->p < t->end) {
        const char *s = t->p, *nl = memchr(s, '\n', (size_t)(t->end - s));
        const char *e = nl ? nl : t->end;
        const char *hash = memchr(s, '#', (size_t)(e - s));
        line->p = s;
        line->end = hash ? hash : e;
        line->line = t->line;
        skip_line(t);
        for (const char *c = line->p; c < line->end; c++)
            if (!is_space(*c)) return 1;
    }
    return 0;
}

/* A float token already accepted by classify_float, converted in the C
 * locale (as iostream does) whatever LC_NUMERIC the caller set. */
/* A text coordinate in double, so that it keeps the file's precision until it
 * is stored relative to the mesh's first vertex (build_mesh). Refused as
 * before when it is not finite as a float. */
static int token_double(const tok *k, double *out)
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
 * classify_float accepts (finite as a float). Returns 0 for anything else
 * (the caller checks and converts it the slow way, with the same result or
 * error as before). */
static int fast_decimal(const tok *k, double *out)
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

/* Stores coordinate c of vertex v relative to vertex 0 (which sets the offset). */
static void store_coord(clvox__raw_mesh *raw, uint64_t v, int c, double x)
{
    if (v == 0) raw->offset[c] = x;
    raw->xyz[3 * v + (size_t)c] = (float)(x - raw->offset[c]);
}

/* ASCII OFF is parsed here rather than by OpenMesh, whose reader supports no
 * comments, wants the counts on a line of their own and misreads face
 * colours without a COFF header - all common in real files (10 of the 138
 * CGAL sample meshes). One vertex or face per line, '#' comments anywhere,
 * extra values (normals, colours, texture coordinates) ignored. */
static clvox_status parse_off_ascii(clvox_context *ctx, const char *path, text *t, text counts_line, int normal,
                                    size_t n, clvox__raw_mesh *raw)
{
    text line;
    tok k;
    int64_t counts[3] = {0, 0, 0};
    int have_counts = counts_line.p != NULL;
    if (!have_counts && !next_data_line(t, &counts_line))
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': OFF file ends before its vertex and face counts", path);
    int nc = 0;
    while (tok_line(&counts_line, &k)) {
        if (nc == 3 || !parse_int(&k, &counts[nc]) || counts[nc] < 0 || counts[nc] > (int64_t)UINT32_MAX)
            return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': invalid OFF counts at line %llu ('%.*s')", path,
                               (unsigned long long)k.line, tok_print_len(&k), k.s);
        nc++;
    }
    if (nc < 2)
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': OFF counts line %llu needs vertex and face counts", path,
                           (unsigned long long)counts_line.line);
    uint64_t nv = (uint64_t)counts[0], nf = (uint64_t)counts[1];
    /* A vertex needs at least "0 0 0\n", a face "0\n". */
    if (nv > n / 6 || nf > n / 2 || 6 * nv + 2 * nf > n)
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                           "'%s' declares %llu vertices and %llu faces, more than a file of %zu bytes can hold", path,
                           (unsigned long long)nv, (unsigned long long)nf, n);
    raw->xyz = malloc((nv ? nv : 1) * 3 * sizeof *raw->xyz);
    raw->face_sizes = malloc((nf ? nf : 1) * sizeof *raw->face_sizes);
    size_t cap = 3 * nf + 16;
    raw->face_indices = malloc(cap * sizeof *raw->face_indices);
    if (!raw->xyz || !raw->face_sizes || !raw->face_indices)
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", path);
    raw->vertex_count = nv;
    for (uint64_t v = 0; v < nv; v++) {
        if (!next_data_line(t, &line))
            return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                               "'%s' is truncated: declares %llu vertices, the file ends after %llu", path,
                               (unsigned long long)nv, (unsigned long long)v);
        for (int c = 0; c < (normal ? 6 : 3); c++) {
            if (!tok_line(&line, &k))
                return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': vertex %llu at line %llu has fewer than %d values",
                                   path, (unsigned long long)v, (unsigned long long)line.line, normal ? 6 : 3);
            double x = 0;
            if (fast_decimal(&k, &x)) { /* a plain decimal read exactly: checked and converted */
                if (c < 3) store_coord(raw, v, c, x);
                continue;
            }
            clvox_status st = check_coord(ctx, path, &k, "OFF vertex");
            if (st) return st;
            if (c < 3 && !token_double(&k, &x))
                return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': cannot convert '%.*s' at line %llu", path,
                                   tok_print_len(&k), k.s, (unsigned long long)k.line);
            if (c < 3) store_coord(raw, v, c, x);
        }
    }
    size_t ni = 0;
    for (uint64_t f = 0; f < nf; f++) {
        int64_t c;
        if (!next_data_line(t, &line))
            return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s' is truncated: declares %llu faces, the file ends after %llu",
                               path, (unsigned long long)nf, (unsigned long long)f);
        if (!tok_line(&line, &k) || !parse_int(&k, &c) || c < 0 || c > (int64_t)((line.end - line.p) / 2 + 1))
            return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': invalid corner count '%.*s' for face %llu at line %llu",
                               path, tok_print_len(&k), k.s, (unsigned long long)f, (unsigned long long)line.line);
        if (ni + (size_t)c > cap) {
            cap = (ni + (size_t)c) * 2;
            uint32_t *grown = realloc(raw->face_indices, cap * sizeof *grown);
            if (!grown) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", path);
            raw->face_indices = grown;
        }
        for (int64_t j = 0; j < c; j++) {
            int64_t idx;
            if (!tok_line(&line, &k))
                return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': face %llu at line %llu has fewer than %lld indices",
                                   path, (unsigned long long)f, (unsigned long long)line.line, (long long)c);
            if (!parse_int(&k, &idx))
                return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': invalid vertex index '%.*s' in face %llu at line %llu",
                                   path, tok_print_len(&k), k.s, (unsigned long long)f, (unsigned long long)k.line);
            if (idx < 0 || (uint64_t)idx >= nv)
                return clvox__fail(ctx, CLVOX_ERR_MESH_INVALID,
                                   "'%s': face %llu at line %llu references vertex %lld, the file has %llu vertices", path,
                                   (unsigned long long)f, (unsigned long long)k.line, (long long)idx,
                                   (unsigned long long)nv);
            raw->face_indices[ni++] = (uint32_t)idx;
        }
        raw->face_sizes[f] = (uint32_t)c;
        raw->face_count = f + 1;
    }
    raw->index_count = ni;
    return CLVOX_OK;
}

/* OFF: binary bodies are walked and read by OpenMesh; ASCII is parsed here
 * into *native. */
static clvox_status check_off(clvox_context *ctx, const char *path, const unsigned char *up, size_t n, expect *ex,
                              clvox__raw_mesh *native, int *parsed)
{
    const char *p = (const char *)up;
    text t = {p, p + n, 1}, head;
    tok k;
    /* Header: [ST][C][N][4][n]OFF, then BINARY, or the counts, or nothing.
     * Comment lines may come first (not in binary files: OpenMesh reads them). */
    if (!next_data_line(&t, &head) || !tok_line(&head, &k))
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s' is not a valid OFF file: no 'OFF' keyword", path);
    size_t i = 0;
    int normal = 0, extended = 0;
    if (k.n >= 2 && k.s[0] == 'S' && k.s[1] == 'T') i += 2;
    if (i < k.n && k.s[i] == 'C') i++;
    if (i < k.n && k.s[i] == 'N') normal = 1, i++;
    if (i < k.n && k.s[i] == '4') extended = 1, i++;
    if (i < k.n && k.s[i] == 'n') extended = 1, i++;
    if (k.n - i != 3 || memcmp(k.s + i, "OFF", 3) != 0)
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s' is not a valid OFF file: line %llu starts with '%.*s', not 'OFF'",
                           path, (unsigned long long)k.line, tok_print_len(&k), k.s);
    if (extended)
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': OFF variant '%.*s' (4D / n-D) is not supported", path,
                           tok_print_len(&k), k.s);
    text counts_line = {NULL, NULL, 1};
    const char *rest = head.p;
    if (tok_line(&head, &k)) {
        if (!tok_is(&k, "BINARY")) {
            counts_line = (text){rest, head.end, head.line};
        } else {
            /* OpenMesh takes a file for binary only when "BINARY" starts at
             * byte 4 (after "OFF" and one separator); otherwise it reads the
             * binary body as ASCII and reserves and grows without bound
             * ("OFF \rBINARY", "OFF  BINARY": a fuzz finding). */
            if (i || k.line != 1 || n < 10 || memcmp(p, "OFF", 3) != 0 || memcmp(p + 4, "BINARY", 6) != 0)
                return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                                   "'%s': binary OFF must start with a plain 'OFF BINARY' line", path);
            if (tok_line(&head, &k))
                return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': unexpected '%.*s' on the OFF header line", path,
                                   tok_print_len(&k), k.s);
            /* The body starts after the first newline (t is there already). */
            const unsigned char *b = up + (t.p - p), *end = up + n;
            if (end - b < 12)
                return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': binary OFF is truncated in its counts", path);
            uint64_t nv = le32(b), nf = le32(b + 4);
            b += 12;
            if ((uint64_t)(end - b) / 12 < nv)
                return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                                   "'%s': binary OFF declares %llu vertices, more than its %zu bytes hold (truncated?)",
                                   path, (unsigned long long)nv, n);
            b += 12 * nv;
            for (uint64_t f = 0; f < nf; f++) {
                if (end - b < 4)
                    return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                                       "'%s': binary OFF is truncated: declares %llu faces, the file ends in face %llu",
                                       path, (unsigned long long)nf, (unsigned long long)f);
                uint64_t c = le32(b);
                b += 4;
                if ((uint64_t)(end - b) / 4 < c)
                    return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                                       "'%s': binary OFF is truncated: face %llu has %llu corners past the end of the file",
                                       path, (unsigned long long)f, (unsigned long long)c);
                b += 4 * c;
            }
            ex->have_vertices = ex->have_faces = 1;
            ex->vertices = nv;
            ex->faces = nf;
            return CLVOX_OK;
        }
    }

    clvox_status st = check_text(ctx, path, p, n, "OFF");
    if (st) return st;
    locale_t c_locale = (locale_t)0, old = LC_GLOBAL_LOCALE;
    if ((st = c_locale_begin(ctx, path, &c_locale, &old))) return st;
    st = parse_off_ascii(ctx, path, &t, counts_line, normal, n, native);
    c_locale_end(c_locale, old);
    return text_read_done(st, native, parsed);
}

/* ---- OBJ ------------------------------------------------------------------------ */

/* OBJ is read here, not by OpenMesh. Its reader aborts the whole process
 * (assert) on a face corner that starts with '/' ("f /1"), reads an
 * unparsable or overflowing index into an uninitialised or wrapped int,
 * skips a malformed vertex line silently (every later index then points at
 * the wrong vertex) and opens the material library (a FIFO there blocks it
 * forever). Checking every line so that reader is safe would mean
 * re-implementing it anyway; clvox needs only the geometry, and a native
 * reader gives one-line errors with line numbers (as for OFF). What is read:
 *   v x y z ...     three finite coordinates; extra values (w, colours) ignored
 *   f c c c ...     corners v, v/vt, v//vn or v/vt/vn; indices start at 1,
 *                   negative ones count back from the last vertex (texture
 *                   coordinate, normal) read so far; positive ones may refer
 *                   to later vertices (OpenMesh reads all vertices first)
 *   '#' at the start of a token starts a comment; every other statement (vt, vn,
 *   o, g, s, usemtl, mtllib, l, p, ...) is skipped, and no other file is
 *   opened. vt/vn indices are checked against the vt/vn lines, never used.
 * A face with no corners, a malformed corner, index 0 or an index out of
 * range is an error; faces of one or two corners are dropped (reported) as
 * for the other formats. Lines continued with '\' are not supported. */

enum { OBJ_V, OBJ_VT, OBJ_VN, OBJ_KINDS };
static const char *const obj_kind_name[OBJ_KINDS] = {"vertex", "texture coordinate", "normal"};

/* Resolves OBJ index token part s[0..n) of kind `kind`: *out is 0-based. */
static clvox_status obj_index(clvox_context *ctx, const char *path, const tok *corner, const char *s, size_t n,
                              int kind, const uint64_t so_far[OBJ_KINDS], const uint64_t total[OBJ_KINDS],
                              uint64_t *out)
{
    tok part = {s, n, corner->line};
    int64_t v;
    if (!n || !parse_int(&part, &v))
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': invalid %s index in face corner '%.*s' at line %llu",
                           path, obj_kind_name[kind], tok_print_len(corner), corner->s,
                           (unsigned long long)corner->line);
    if (v == 0)
        return clvox__fail(ctx, CLVOX_ERR_MESH_INVALID,
                           "'%s': face corner '%.*s' at line %llu has %s index 0 (OBJ indices start at 1)", path,
                           tok_print_len(corner), corner->s, (unsigned long long)corner->line, obj_kind_name[kind]);
    if (v > 0 && (uint64_t)v > total[kind])
        return clvox__fail(ctx, CLVOX_ERR_MESH_INVALID,
                           "'%s': face at line %llu references %s %lld, the file has %llu", path,
                           (unsigned long long)corner->line, obj_kind_name[kind], (long long)v,
                           (unsigned long long)total[kind]);
    if (v < 0 && (uint64_t)-(v + 1) >= so_far[kind]) /* -(v+1): no overflow at INT64_MIN */
        return clvox__fail(ctx, CLVOX_ERR_MESH_INVALID,
                           "'%s': face at line %llu references %s %lld (relative), only %llu precede it", path,
                           (unsigned long long)corner->line, obj_kind_name[kind], (long long)v,
                           (unsigned long long)so_far[kind]);
    *out = v > 0 ? (uint64_t)v - 1 : so_far[kind] - (uint64_t)-(v + 1) - 1;
    return CLVOX_OK;
}

/* Next OBJ line holding data, as next_data_line but a comment starts only at
 * a '#' that begins a token ("v 0 1.#INF 0" is a non-finite coordinate, not
 * a vertex with two coordinates). */
static int obj_next_line(text *t, text *line)
{
    while (t->p < t->end) {
        const char *s = t->p, *nl = memchr(s, '\n', (size_t)(t->end - s));
        const char *e = nl ? nl : t->end, *c = s;
        line->p = s;
        line->line = t->line;
        skip_line(t);
        while (c < e && is_space(*c)) c++;
        if (c == e || *c == '#') continue;
        for (; c < e; c++)
            if (*c == '#' && is_space(c[-1])) break;
        line->end = c;
        return 1;
    }
    return 0;
}

static int obj_kind_of(const tok *k)
{
    if (tok_is(k, "v")) return OBJ_V;
    if (tok_is(k, "vt")) return OBJ_VT;
    if (tok_is(k, "vn")) return OBJ_VN;
    return -1;
}

static clvox_status parse_obj(clvox_context *ctx, const char *path, const char *p, size_t n, clvox__raw_mesh *raw)
{
    text t = {p, p + n, 1}, line;
    tok k;
    /* Pass 1: how many v / vt / vn lines (positive indices may point ahead). */
    uint64_t total[OBJ_KINDS] = {0, 0, 0}, so_far[OBJ_KINDS] = {0, 0, 0};
    while (obj_next_line(&t, &line)) {
        tok_line(&line, &k);
        int kind = obj_kind_of(&k);
        if (kind >= 0) total[kind]++;
    }
    if (total[OBJ_V] > UINT32_MAX - 1)
        return clvox__fail(ctx, CLVOX_ERR_MESH_INVALID, "'%s' has %llu vertices, more than clvox supports", path,
                           (unsigned long long)total[OBJ_V]);
    raw->xyz = malloc((total[OBJ_V] ? total[OBJ_V] : 1) * 3 * sizeof *raw->xyz);
    if (!raw->xyz) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", path);
    raw->vertex_count = total[OBJ_V];
    size_t cap_f = 0, cap_i = 0;

    /* Pass 2: vertices and faces. */
    t = (text){p, p + n, 1};
    while (obj_next_line(&t, &line)) {
        tok_line(&line, &k);
        int kind = obj_kind_of(&k);
        if (kind == OBJ_V) {
            for (int c = 0; c < 3; c++) {
                if (!tok_line(&line, &k))
                    return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                                       "'%s': vertex at line %llu has fewer than 3 coordinates", path,
                                       (unsigned long long)line.line);
                double x;
                if (fast_decimal(&k, &x)) {
                    store_coord(raw, so_far[OBJ_V], c, x);
                    continue;
                }
                clvox_status st = check_coord(ctx, path, &k, "vertex");
                if (st) return st;
                if (!token_double(&k, &x))
                    return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': cannot convert '%.*s' at line %llu", path,
                                       tok_print_len(&k), k.s, (unsigned long long)k.line);
                store_coord(raw, so_far[OBJ_V], c, x);
            }
        }
        if (kind >= 0) {
            so_far[kind]++;
            continue;
        }
        if (!tok_is(&k, "f")) continue;
        uint32_t corners = 0;
        while (tok_line(&line, &k)) {
            /* v, v/vt, v//vn, v/vt/vn */
            const char *s1 = memchr(k.s, '/', k.n), *end = k.s + k.n;
            const char *s2 = s1 ? memchr(s1 + 1, '/', (size_t)(end - s1 - 1)) : NULL;
            if (s2 && memchr(s2 + 1, '/', (size_t)(end - s2 - 1)))
                return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': malformed face corner '%.*s' at line %llu "
                                   "(expected v, v/vt, v//vn or v/vt/vn)", path, tok_print_len(&k), k.s,
                                   (unsigned long long)k.line);
            uint64_t vi, unused;
            const char *ve = s1 ? s1 : end;
            clvox_status st = obj_index(ctx, path, &k, k.s, (size_t)(ve - k.s), OBJ_V, so_far, total, &vi);
            if (!st && s1) {
                const char *te = s2 ? s2 : end;
                /* v/vt needs vt; v//vn may leave it out, not both */
                if (te > s1 + 1 || !s2) st = obj_index(ctx, path, &k, s1 + 1, (size_t)(te - s1 - 1), OBJ_VT, so_far,
                                                        total, &unused);
            }
            if (!st && s2) st = obj_index(ctx, path, &k, s2 + 1, (size_t)(end - s2 - 1), OBJ_VN, so_far, total, &unused);
            if (st) return st;
            if (raw->index_count == cap_i) {
                cap_i = cap_i ? 2 * cap_i : 1024;
                uint32_t *grown = realloc(raw->face_indices, cap_i * sizeof *grown);
                if (!grown) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", path);
                raw->face_indices = grown;
            }
            raw->face_indices[raw->index_count++] = (uint32_t)vi;
            corners++;
        }
        if (!corners)
            return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': face at line %llu has no corners", path,
                               (unsigned long long)line.line);
        if (raw->face_count == cap_f) {
            cap_f = cap_f ? 2 * cap_f : 1024;
            uint32_t *grown = realloc(raw->face_sizes, cap_f * sizeof *grown);
            if (!grown) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", path);
            raw->face_sizes = grown;
        }
        raw->face_sizes[raw->face_count++] = corners;
    }
    return CLVOX_OK;
}

static clvox_status check_obj(clvox_context *ctx, const char *path, const char *p, size_t n, clvox__raw_mesh *native,
                              int *parsed)
{
    clvox_status st = check_text(ctx, path, p, n, "OBJ");
    if (st) return st;
    locale_t c_locale = (locale_t)0, old = LC_GLOBAL_LOCALE;
    if ((st = c_locale_begin(ctx, path, &c_locale, &old))) return st;
    st = parse_obj(ctx, path, p, n, native);
    c_locale_end(c_locale, old);
    return text_read_done(st, native, parsed);
}

/* ---- PLY ------------------------------------------------------------------------ */

static const ply_type ply_types[] = {
    {"char", 1, 0, 1}, {"int8", 1, 0, 1}, {"uchar", 1, 0, 0}, {"uint8", 1, 0, 0},
    {"short", 2, 0, 1}, {"int16", 2, 0, 1}, {"ushort", 2, 0, 0}, {"uint16", 2, 0, 0},
    {"int", 4, 0, 1}, {"int32", 4, 0, 1}, {"uint", 4, 0, 0}, {"uint32", 4, 0, 0},
    {"float", 4, 1, 1}, {"float32", 4, 1, 1}, {"double", 8, 1, 1}, {"float64", 8, 1, 1},
};

static const ply_type *ply_type_of(const tok *k)
{
    for (size_t i = 0; i < sizeof ply_types / sizeof ply_types[0]; i++)
        if (tok_is(k, ply_types[i].name)) return &ply_types[i];
    return NULL;
}

static int copy_name(char dst[PLY_NAME], const tok *k)
{
    if (k->n >= PLY_NAME) return 0;
    memcpy(dst, k->s, k->n);
    dst[k->n] = 0;
    return 1;
}

static int is_index_list(const char *name) { return !strcmp(name, "vertex_indices") || !strcmp(name, "vertex_index"); }

/* Parses and checks the header strictly: OpenMesh loops forever on a header
 * without end_header, truncated in the header or with a malformed property
 * list, so anything unusual is an error here. */
static clvox_status ply_parse_header(clvox_context *ctx, const char *path, const char *p, size_t n, ply_header *h)
{
    size_t limit = n < PLY_MAX_HEADER ? n : PLY_MAX_HEADER;
    text t = {p, p + limit, 1};
    tok k;
    memset(h, 0, sizeof *h);
    h->vertex = h->face = -1;
    int have_format = 0;
#define BAD_LINE(why) \
    clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': invalid PLY header at line %llu: %s", path, \
                (unsigned long long)t.line, why)
    if (limit < 4 || memcmp(p, "ply", 3) != 0 || (p[3] != '\n' && p[3] != '\r'))
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s' is not a PLY file (it does not start with 'ply')", path);
    skip_line(&t);
    for (;;) {
        if (t.p >= t.end || !memchr(t.p, '\n', (size_t)(t.end - t.p))) {
            if (limit < n)
                return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': PLY header has no end_header in its first %u bytes",
                                   path, PLY_MAX_HEADER);
            return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': PLY file is truncated inside its header (no end_header)",
                               path);
        }
        if (!tok_line(&t, &k)) return BAD_LINE("empty line");
        if (!have_format && !tok_is(&k, "format")) /* OpenMesh wants it on line 2 */
            return BAD_LINE("the second line must be the format line");
        if (tok_is(&k, "comment") || tok_is(&k, "obj_info")) {
            skip_line(&t);
            continue;
        }
        if (tok_is(&k, "end_header")) {
            const char *word_end = k.s + k.n;
            if (tok_line(&t, &k)) return BAD_LINE("text after end_header");
            const char *nl = memchr(t.p, '\n', (size_t)(t.end - t.p));
            /* The binary body starts right after the newline. */
            if (h->format != PLY_ASCII && nl != word_end) return BAD_LINE("end_header must be followed by \\n alone");
            h->body = (size_t)(nl + 1 - p);
            break;
        }
        tok a[5];
        int na = 0;
        a[na++] = k;
        while (na < 5 && tok_line(&t, &a[na])) na++;
        tok extra;
        if (tok_line(&t, &extra)) return BAD_LINE("too many words");
        if (tok_is(&a[0], "format")) {
            if (have_format) return BAD_LINE("second format line");
            if (na != 3 || !tok_is(&a[2], "1.0")) return BAD_LINE("expected 'format <type> 1.0'");
            if (tok_is(&a[1], "ascii")) h->format = PLY_ASCII;
            else if (tok_is(&a[1], "binary_little_endian")) h->format = PLY_LE;
            else if (tok_is(&a[1], "binary_big_endian")) h->format = PLY_BE;
            else return BAD_LINE("unknown format");
            have_format = 1;
        } else if (tok_is(&a[0], "element")) {
            int64_t count;
            if (na != 3) return BAD_LINE("expected 'element <name> <count>'");
            if (h->nelems == PLY_MAX_ELEMENTS) return BAD_LINE("too many elements");
            if (!parse_int(&a[2], &count) || count < 0 || count > (int64_t)UINT32_MAX || a[2].s[0] == '+')
                return BAD_LINE("invalid element count");
            ply_elem *e = &h->elems[h->nelems];
            if (!copy_name(e->name, &a[1])) return BAD_LINE("element name too long");
            e->count = (uint64_t)count;
            if (!strcmp(e->name, "vertex")) {
                if (h->vertex >= 0) return BAD_LINE("second vertex element");
                h->vertex = h->nelems;
            } else if (!strcmp(e->name, "face")) {
                if (h->face >= 0) return BAD_LINE("second face element");
                h->face = h->nelems;
            }
            h->nelems++;
        } else if (tok_is(&a[0], "property")) {
            if (!h->nelems) return BAD_LINE("property before any element");
            ply_elem *e = &h->elems[h->nelems - 1];
            if (e->nprops == PLY_MAX_PROPS) return BAD_LINE("too many properties");
            ply_prop *pr = &e->props[e->nprops];
            if (tok_is(&a[1], "list")) {
                if (na != 5) return BAD_LINE("expected 'property list <count type> <item type> <name>'");
                pr->count_type = ply_type_of(&a[2]);
                pr->type = ply_type_of(&a[3]);
                if (!pr->count_type || !pr->type) return BAD_LINE("unknown type in property list");
                if (pr->count_type->is_float) return BAD_LINE("list count type must be an integer type");
                if (!copy_name(pr->name, &a[4])) return BAD_LINE("property name too long");
            } else {
                if (na != 3) return BAD_LINE("expected 'property <type> <name>'");
                pr->type = ply_type_of(&a[1]);
                if (!pr->type) return BAD_LINE("unknown property type");
                if (!copy_name(pr->name, &a[2])) return BAD_LINE("property name too long");
            }
            for (int q = 0; q < e->nprops; q++)
                if (!strcmp(e->props[q].name, pr->name)) return BAD_LINE("duplicate property");
            e->nprops++;
        } else {
            return BAD_LINE("unknown keyword");
        }
        skip_line(&t);
    }
#undef BAD_LINE
    if (h->vertex < 0) return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': PLY file has no vertex element", path);
    if (h->face >= 0 && h->face < h->vertex)
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': PLY face element comes before the vertex element", path);

    /* What OpenMesh's reader can follow: lists only as face corner indices or
     * face texture coordinates, among the elements it reads. */
    int last = h->face >= 0 ? h->face : h->nelems - 1;
    for (int ei = 0; ei <= last; ei++) {
        const ply_elem *e = &h->elems[ei];
        for (int q = 0; q < e->nprops; q++) {
            const ply_prop *pr = &e->props[q];
            if (!pr->count_type) {
                if (ei == h->face && is_index_list(pr->name))
                    return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': PLY face property '%s' must be a list", path,
                                       pr->name);
                continue;
            }
            int ok = ei == h->face && (is_index_list(pr->name) || !strcmp(pr->name, "texcoord"));
            if (!ok)
                return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                                   "'%s': PLY list property '%s' in element '%s' is not supported", path, pr->name,
                                   e->name);
            if (is_index_list(pr->name) && pr->type->is_float)
                return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': PLY face indices must have an integer type", path);
        }
    }
    if (h->face >= 0) {
        const ply_elem *fe = &h->elems[h->face];
        int found = 0;
        for (int q = 0; q < fe->nprops; q++) found |= is_index_list(fe->props[q].name);
        if (!found && fe->count)
            return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': PLY face element has no vertex_indices list", path);
    }
    const ply_elem *ve = &h->elems[h->vertex];
    static const char *const axes[3] = {"x", "y", "z"};
    for (int a = 0; a < 3; a++) {
        int found = 0;
        for (int q = 0; q < ve->nprops; q++)
            if (!strcmp(ve->props[q].name, axes[a])) {
                if (!ve->props[q].type->is_float)
                    return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                                       "'%s': PLY vertex coordinate '%s' must be float or double", path, axes[a]);
                found = 1;
            }
        if (!found)
            return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': PLY vertex element has no '%s' property", path, axes[a]);
    }
    return CLVOX_OK;
}

static uint64_t ply_read_count(const unsigned char *b, const ply_type *ty, enum ply_format f, int *negative)
{
    uint64_t v = 0;
    for (int i = 0; i < ty->size; i++) v |= (uint64_t)b[f == PLY_BE ? ty->size - 1 - i : i] << (8 * i);
    *negative = 0;
    if (ty->is_signed && (v >> (8 * ty->size - 1)) & 1) *negative = 1;
    return v;
}

/* Binary body: fixed-size records are checked by size, the face element is
 * walked list by list, so a truncated file is caught exactly. */
static clvox_status ply_check_binary(clvox_context *ctx, const char *path, const unsigned char *p, size_t n,
                                     const ply_header *h)
{
    uint64_t pos = h->body;
    int last = h->face >= 0 ? h->face : h->nelems - 1;
    for (int ei = 0; ei <= last; ei++) {
        const ply_elem *e = &h->elems[ei];
        uint64_t fixed = 0;
        int lists = 0;
        for (int q = 0; q < e->nprops; q++) {
            if (e->props[q].count_type) lists = 1;
            else fixed += (uint64_t)e->props[q].type->size;
        }
        if (!lists) {
            if (fixed && (n - pos) / fixed < e->count)
                return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                                   "'%s': binary PLY is truncated: element '%s' declares %llu entries of %llu bytes, "
                                   "only %llu bytes are left",
                                   path, e->name, (unsigned long long)e->count, (unsigned long long)fixed,
                                   (unsigned long long)(n - pos));
            pos += fixed * e->count;
            continue;
        }
        for (uint64_t r = 0; r < e->count; r++) {
            for (int q = 0; q < e->nprops; q++) {
                const ply_prop *pr = &e->props[q];
                uint64_t need = (uint64_t)(pr->count_type ? pr->count_type->size : pr->type->size);
                if (n - pos < need) goto truncated;
                if (pr->count_type) {
                    int neg;
                    uint64_t c = ply_read_count(p + pos, pr->count_type, h->format, &neg);
                    if (neg)
                        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': negative list length in %s %llu", path,
                                           e->name, (unsigned long long)r);
                    pos += need;
                    if ((n - pos) / (uint64_t)pr->type->size < c) goto truncated;
                    pos += c * (uint64_t)pr->type->size;
                } else {
                    pos += need;
                }
            }
            continue;
        truncated:
            return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                               "'%s': binary PLY is truncated: element '%s' declares %llu entries, the file ends in entry %llu",
                               path, e->name, (unsigned long long)e->count, (unsigned long long)r);
        }
    }
    return CLVOX_OK;
}

/* A float coordinate token (classify_float said NUM_OK) as operator>>
 * (strtof) reads it. The fast path: Clinger's double d (strtod's value)
 * rounded to float is strtof's value unless d is exactly half-way between
 * two floats (double rounding can only go wrong there: any other half-way
 * point between the true value and d would be a double nearer to it) or
 * below the normal floats; those, and all others, go to strtof (C locale:
 * the caller set it). */
static int token_float(const tok *k, float *out)
{
    double d;
    if (fast_decimal(k, &d)) {
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

/* ASCII body, token by token as OpenMesh reads it (operator>>). raw != NULL:
 * also read it (the native ASCII reader: x, y, z of type float as strtof
 * reads them, the last vertex_indices/vertex_index list of each face, as
 * OpenMesh's reader hands them over; the caller sets the C locale). */
static clvox_status ply_check_ascii(clvox_context *ctx, const char *path, const char *p, size_t n,
                                    const ply_header *h, clvox__raw_mesh *raw)
{
    clvox_status st = check_text(ctx, path, p + h->body, n - h->body, "PLY");
    if (st) return st;
    text t = {p + h->body, p + n, 1};
    for (const char *c = p; c < p + h->body; c++) t.line += *c == '\n';
    uint64_t nv = h->elems[h->vertex].count;
    int last = h->face >= 0 ? h->face : h->nelems - 1;
    tok k;
    size_t cap = 0, ni = 0;
    for (int ei = 0; ei <= last; ei++) {
        const ply_elem *e = &h->elems[ei];
        /* A value needs at least two bytes ("0 "): reject absurd counts before scanning. */
        if (e->count && e->nprops && e->count > (uint64_t)(n - h->body) / 2)
            return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                               "'%s': PLY element '%s' declares %llu entries, more than the file can hold", path, e->name,
                               (unsigned long long)e->count);
        if (raw && ei == h->vertex) {
            raw->xyz = malloc((e->count ? e->count : 1) * 3 * sizeof *raw->xyz);
            if (!raw->xyz) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", path);
            raw->vertex_count = (size_t)e->count;
        }
        if (raw && ei == h->face) {
            cap = (size_t)e->count * 3 + 16;
            raw->face_indices = malloc(cap * sizeof *raw->face_indices);
            if (!raw->face_indices) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", path);
            raw->face_count = (size_t)e->count;
        }
        for (uint64_t r = 0; r < e->count; r++) {
            size_t face_start = ni, face_n = 0; /* this face's index list in raw (the last one wins) */
            for (int q = 0; q < e->nprops; q++) {
                const ply_prop *pr = &e->props[q];
                uint64_t items = 1;
                if (pr->count_type) {
                    int64_t c;
                    if (!tok_any(&t, &k)) goto truncated;
                    if (!parse_int(&k, &c) || c < 0 || c > (1 << 24))
                        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                                           "'%s': invalid list length '%.*s' for '%s' of %s %llu at line %llu", path,
                                           tok_print_len(&k), k.s, pr->name, e->name, (unsigned long long)r,
                                           (unsigned long long)k.line);
                    items = (uint64_t)c;
                }
                int indices = pr->count_type && ei == h->face && is_index_list(pr->name);
                int coord = ei == h->vertex && (!strcmp(pr->name, "x") || !strcmp(pr->name, "y") || !strcmp(pr->name, "z"));
                if (raw && indices) { /* a later list replaces an earlier one */
                    ni = face_start;
                    face_n = (size_t)items;
                    if (ni + face_n > cap) {
                        size_t c2 = (ni + face_n) * 2;
                        uint32_t *g = realloc(raw->face_indices, c2 * sizeof *g);
                        if (!g) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", path);
                        raw->face_indices = g;
                        cap = c2;
                    }
                }
                for (uint64_t j = 0; j < items; j++) {
                    if (!tok_any(&t, &k)) goto truncated;
                    if (pr->type->is_float) {
                        float *slot = raw && coord ? &raw->xyz[3 * r + (size_t)(pr->name[0] - 'x')] : NULL;
                        double d;
                        if (slot && fast_decimal(&k, &d)) { /* a plain decimal: finite and below FLT_MAX */
                            if (!token_float(&k, slot)) goto oom;
                            continue;
                        }
                        int c = classify_float(&k);
                        if (c == NUM_NONFINITE)
                            return clvox__fail(ctx, CLVOX_ERR_MESH_INVALID,
                                               "'%s': non-finite %s '%.*s' at line %llu (%s %llu, property '%s')", path,
                                               coord ? "coordinate" : "value", tok_print_len(&k), k.s,
                                               (unsigned long long)k.line, e->name, (unsigned long long)r, pr->name);
                        if (c == NUM_BAD) goto not_a_number;
                        if (slot && !token_float(&k, slot)) goto oom;
                    } else {
                        int64_t v;
                        if (!parse_int(&k, &v)) goto not_a_number;
                        if (indices && (v < 0 || (uint64_t)v >= nv))
                            return clvox__fail(ctx, CLVOX_ERR_MESH_INVALID,
                                               "'%s': face %llu at line %llu references vertex %lld, the file has %llu vertices",
                                               path, (unsigned long long)r, (unsigned long long)k.line, (long long)v,
                                               (unsigned long long)nv);
                        if (raw && indices) raw->face_indices[ni++] = (uint32_t)v;
                    }
                }
                continue;
            not_a_number:
                return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                                   "'%s': expected %s for '%s' of %s %llu at line %llu, found '%.*s'", path,
                                   pr->type->is_float ? "a number" : "an integer", pr->name, e->name,
                                   (unsigned long long)r, (unsigned long long)k.line, tok_print_len(&k), k.s);
            }
            if (raw && ei == h->face) {
                if (face_n != 3 && !raw->face_sizes) {
                    /* The first face that is not a triangle: from here on, sizes. */
                    raw->face_sizes = malloc((e->count ? e->count : 1) * sizeof *raw->face_sizes);
                    if (!raw->face_sizes)
                        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", path);
                    for (uint64_t g = 0; g < r; g++) raw->face_sizes[g] = 3;
                }
                if (raw->face_sizes) raw->face_sizes[r] = (uint32_t)face_n;
                raw->index_count = ni;
            }
            continue;
        truncated:
            return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                               "'%s' is truncated: PLY element '%s' declares %llu entries, the file ends in entry %llu",
                               path, e->name, (unsigned long long)e->count, (unsigned long long)r);
        }
    }
    return CLVOX_OK;
oom:
    return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", path);
}

static clvox_status check_ply(clvox_context *ctx, const char *path, const unsigned char *p, size_t n, expect *ex,
                              clvox__raw_mesh *native, int *parsed)
{
    ply_header *h = malloc(sizeof *h); /* about 300 KB: keep it off the stack */
    if (!h) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory checking '%s'", path);
    clvox_status st = ply_parse_header(ctx, path, (const char *)p, n, h);
    if (!st && h->format == PLY_ASCII) {
        /* Read natively when the coordinates are floats (OpenMesh reads them
         * with operator>>: strtof); double coordinates stay with OpenMesh. */
        int use_native = clvox__mesh_native_enabled();
        const ply_elem *ve = &h->elems[h->vertex];
        for (int q = 0; q < ve->nprops; q++) {
            const char *nm = ve->props[q].name;
            if ((!strcmp(nm, "x") || !strcmp(nm, "y") || !strcmp(nm, "z")) && ve->props[q].type->size != 4) use_native = 0;
        }
        if (use_native) {
            locale_t c_locale = (locale_t)0, old = LC_GLOBAL_LOCALE;
            if (!(st = c_locale_begin(ctx, path, &c_locale, &old))) {
                st = ply_check_ascii(ctx, path, (const char *)p, n, h, native);
                c_locale_end(c_locale, old);
            }
            if (!st && !native->face_indices) { /* no face element */
                native->face_indices = malloc(sizeof *native->face_indices);
                if (!native->face_indices) st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", path);
            }
            st = text_read_done(st, native, parsed);
        } else {
            st = ply_check_ascii(ctx, path, (const char *)p, n, h, NULL);
        }
    } else if (!st) {
        st = ply_check_binary(ctx, path, p, n, h);
    }
    if (!st && h->format != PLY_ASCII && clvox__mesh_native_enabled()) {
        st = clvox__ply_read_binary(ctx, path, p, n, h, native);
        if (!st) *parsed = 1;
    }
    if (!st) {
        ex->have_vertices = 1;
        ex->vertices = h->elems[h->vertex].count;
        ex->have_faces = 1;
        ex->faces = h->face >= 0 ? h->elems[h->face].count : 0;
    }
    free(h);
    return st;
}

/* ---- OM ------------------------------------------------------------------------- */

/* OpenMesh's OM reader asserts (abort()) on chunk headers with unexpected
 * dimensions and, without an end marker, accepts a truncated file. So the
 * chunk sequence is walked here exactly as OMReader.cc consumes it (OM files
 * are little endian): every chunk must fit the file, asserted dimensions must
 * hold, and the sentinel chunk must be reached. Halfedge ids are checked when
 * faces are rebuilt (mesh_openmesh.cpp), vertex ids by build_mesh. */
static clvox_status check_om(clvox_context *ctx, const char *path, const unsigned char *p, size_t n)
{
    if (n < 16 || p[0] != 'O' || p[1] != 'M' || (p[2] != 'T' && p[2] != 'Q' && p[2] != 'P'))
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s' is not an OpenMesh OM file (bad magic)", path);
    unsigned version = p[3], mesh_type = p[2];
    uint64_t nv = le32(p + 4), nf = le32(p + 8), ne = le32(p + 12);
    if (version > 0x42) /* OM 2.2, what OpenMesh 9.0 writes and reads */
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': OM format version %u.%u is not supported", path,
                           version >> 5, version & 31);
    /* Positions take at least 12 bytes a vertex. */
    if (nv > n / 12)
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                           "'%s': OM header declares %llu vertices, more than its %zu bytes hold", path,
                           (unsigned long long)nv, n);
    size_t pos = 16;
    for (unsigned chunk = 0;; chunk++) {
        if (n - pos < 2)
            return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': OM file is truncated (no end marker after chunk %u)",
                               path, chunk);
        unsigned h = (unsigned)p[pos] | (unsigned)p[pos + 1] << 8;
        pos += 2;
        unsigned named = h >> 1 & 1, entity = h >> 2 & 7, type = h >> 5 & 15, is_float = h >> 10 & 1;
        unsigned dims = (h >> 11 & 7) + 1, bits = h >> 14 & 3, isz = 1u << bits;
        if (entity == 7) return CLVOX_OK; /* sentinel */
        if (named) {
            if (n - pos < 1 || n - pos - 1 < p[pos]) goto truncated;
            pos += 1 + (size_t)p[pos];
        }
        uint64_t count;
        switch (entity) {
        case 0: count = nv; break;
        case 1: count = 1; break;
        case 2: count = nf; break;
        case 4: count = ne; break;
        case 6: count = 2 * ne; break;
        default:
            return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': OM chunk %u has an unknown entity %u", path, chunk,
                               entity);
        }
        uint64_t scalar = is_float ? (1u << bits) : (4u << bits);
        uint64_t size = count * dims * scalar; /* the reader's skip size for other chunks */
        int need_dims = 0, must_consume = entity == 1 || entity == 4 || entity == 6;
        if (type == 6) { /* custom property: [type name,] uint32 block size, block */
            if (version > 0x41) {
                if (n - pos < 1 || n - pos - 1 < p[pos]) goto truncated;
                pos += 1 + (size_t)p[pos];
            }
            if (n - pos < 4) goto truncated;
            size = le32(p + pos);
            pos += 4;
            must_consume = 0;
        } else if (entity == 0 || (entity == 2 && (type == 1 || type == 3 || type == 4 || type == 7))) {
            switch (type) {
            case 0: /* positions (vertices only) */
            case 1: /* normals */
                if (type == 0 && entity == 2) break;
                need_dims = 3;
                if (bits == 0) size = 12 * count;
                else if (bits == 1) size = 24 * count;
                else if (count)
                    return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': OM chunk %u has an unsupported scalar size",
                                       path, chunk);
                else size = 0;
                break;
            case 2: need_dims = 2, size = 8 * count; break;
            case 3: need_dims = 1, size = 4 * count; break;
            case 4: need_dims = 3, size = 3 * count; break;
            case 7: /* topology */
                if (entity == 2 && version < 0x40) { /* faces as vertex index lists */
                    uint64_t corners = mesh_type == 'T' ? 3 : 4;
                    for (uint64_t f = 0; f < nf; f++) {
                        if (mesh_type == 'P') {
                            if (n - pos < 2) goto truncated;
                            corners = (uint64_t)p[pos] | (uint64_t)p[pos + 1] << 8;
                            pos += 2;
                        }
                        if ((n - pos) / isz < corners) goto truncated;
                        pos += corners * isz;
                    }
                    size = 0;
                } else {
                    size = count * isz;
                }
                break;
            default: break;
            }
        } else if (entity == 6 && type == 2) {
            need_dims = 2, size = 8 * count;
        } else if (entity == 6 && type == 7) {
            size = ne * 6 * isz;
        } else if ((entity == 4 || entity == 6) && type == 3) {
            need_dims = 1, size = 4 * count;
        }
        if (need_dims && dims != (unsigned)need_dims)
            return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': OM chunk %u is corrupt (%u-D data where %d-D is required)",
                               path, chunk, dims, need_dims);
        if (must_consume && size == 0)
            return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': OM chunk %u is empty", path, chunk);
        if (size > n - pos) goto truncated;
        pos += size;
        continue;
    truncated:
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': OM file is truncated in chunk %u", path, chunk);
    }
}

/* ---- building the validated mesh ------------------------------------------------ */

void clvox__raw_mesh_free(clvox__raw_mesh *raw)
{
    if (!raw) return;
    free(raw->xyz);
    free(raw->face_sizes);
    free(raw->face_indices);
    memset(raw, 0, sizeof *raw);
}

/* Takes ownership of xyz (freed on failure). sizes == NULL: all faces are
 * triangles. `what` names the source in messages. */
/* idx_owned: idx itself, handed over (malloc'ed, freed on failure), when
 * sizes == NULL: the triangles are then compacted in place, so no second
 * index array is made; else NULL. */
static clvox_status build_mesh(clvox_context *ctx, const char *what, float *xyz, const double offset[3], size_t nv,
                               const uint32_t *sizes, const uint32_t *idx, size_t nf, size_t index_count,
                               uint64_t loader_nonmanifold, uint32_t *idx_owned, clvox_mesh **out)
{
    clvox_status st = CLVOX_OK;
    uint32_t *tris = NULL;
    clvox_mesh *m = NULL;
    clvox_mesh_report r;
    clvox__mesh_volume volume;
    memset(&r, 0, sizeof r);
    r.input_vertices = r.vertices = nv;
    r.input_faces = nf;

    for (size_t v = 0; v < nv; v++) {
        const float *p = xyz + 3 * v;
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) {
            st = clvox__fail(ctx, CLVOX_ERR_MESH_INVALID, "%s: vertex %zu has a non-finite coordinate (%g, %g, %g)", what,
                             v, (double)p[0], (double)p[1], (double)p[2]);
            goto fail;
        }
    }
    /* Indices in range; triangle count after fanning. */
    size_t nt = 0, pos = 0;
    for (size_t f = 0; f < nf; f++) {
        size_t k = sizes ? sizes[f] : 3;
        if (k > index_count - pos) {
            st = clvox__fail(ctx, CLVOX_ERR_INTERNAL, "%s: face %zu runs past the index array", what, f);
            goto fail;
        }
        for (size_t j = 0; j < k; j++)
            if (idx[pos + j] >= nv) {
                st = clvox__fail(ctx, CLVOX_ERR_MESH_INVALID,
                                 "%s: face %zu references vertex %lu, but there are only %zu vertices", what, f,
                                 (unsigned long)idx[pos + j], nv);
                goto fail;
            }
        if (k >= 3) {
            nt += k - 2;
            if (k > 3) r.polygons_triangulated++;
        } else {
            r.dropped_faces++;
        }
        pos += k;
    }
    if (nt > UINT32_MAX / 3) {
        st = clvox__fail(ctx, CLVOX_ERR_MESH_INVALID, "%s: %zu triangles, more than clvox supports (%u)", what, nt,
                         (unsigned)(UINT32_MAX / 3));
        goto fail;
    }
    if (idx_owned && !sizes) {
        tris = idx_owned; /* triangle t is read before slot t (or later) is written */
        idx_owned = NULL;
    } else {
        free(idx_owned);
        idx_owned = NULL;
        tris = malloc((nt ? nt : 1) * 3 * sizeof *tris);
    }
    if (!tris) {
        st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "%s: out of memory for %zu triangles", what, nt);
        goto fail;
    }
    size_t kept = 0;
    pos = 0;
    for (size_t f = 0; f < nf; f++) {
        size_t k = sizes ? sizes[f] : 3;
        for (size_t j = 1; j + 1 < k; j++) {
            uint32_t a = idx[pos], b = idx[pos + j], c = idx[pos + j + 1];
            if (a == b || b == c || a == c) {
                r.dropped_faces++;
                continue;
            }
            tris[3 * kept] = a;
            tris[3 * kept + 1] = b;
            tris[3 * kept + 2] = c;
            kept++;
        }
        pos += k;
    }
    if (!kept) {
        st = clvox__fail(ctx, CLVOX_ERR_MESH_EMPTY,
                         "%s: mesh has no triangles (%zu vertices, %zu faces read, %llu dropped)", what, nv, nf,
                         (unsigned long long)r.dropped_faces);
        goto fail;
    }
    if (kept < nt) {
        uint32_t *shrunk = realloc(tris, kept * 3 * sizeof *tris);
        if (shrunk) tris = shrunk;
    }
    r.triangles = kept;

    /* Box of the vertices in use, degenerate triangles, volume, boundary and
     * non-manifold edges, duplicates (mesh_report.c). */
    if (clvox__mesh_analyze(xyz, nv, tris, kept, 0, 0, &r, &volume) != 0) {
        st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "%s: out of memory for the report on %zu triangles", what, kept);
        goto fail;
    }
    for (int a = 0; a < 3; a++) { /* the box in absolute coordinates */
        r.bbox_min[a] += offset[a];
        r.bbox_max[a] += offset[a];
    }
    r.nonmanifold_faces += loader_nonmanifold;
    r.closed = r.boundary_edges == 0;

    m = malloc(sizeof *m);
    if (!m) {
        st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "%s: out of memory", what);
        goto fail;
    }
    m->xyz = xyz;
    for (int a = 0; a < 3; a++) m->offset[a] = offset[a];
    m->vertex_count = nv;
    m->tris = tris;
    m->triangle_count = kept;
    m->report = r;
    m->volume = volume;
    m->ahead = NULL;
    *out = m;
    return CLVOX_OK;

fail:
    free(xyz);
    free(tris);
    free(idx_owned);
    return st;
}

/* ---- public API ----------------------------------------------------------------- */

/* Binary PLY and binary STL are read natively (mesh_ply.c, mesh_stl.c);
 * CLVOX_MESH_READER=openmesh sends them to OpenMesh as before. For tests,
 * which compare the two bit for bit; not a user setting. */
int clvox__mesh_native_enabled(void)
{
    const char *e = getenv("CLVOX_MESH_READER");
    return !(e && !strcmp(e, "openmesh"));
}

/* The same file, unchanged: inode, size, modification and change times
 * (a write or a truncation moves them). */
static int same_file_state(const struct stat *a, const struct stat *b)
{
    return a->st_dev == b->st_dev && a->st_ino == b->st_ino && a->st_size == b->st_size &&
           a->st_mtim.tv_sec == b->st_mtim.tv_sec && a->st_mtim.tv_nsec == b->st_mtim.tv_nsec &&
           a->st_ctim.tv_sec == b->st_ctim.tv_sec && a->st_ctim.tv_nsec == b->st_ctim.tv_nsec;
}

/* now: the file's fstat or stat after the read (NULL: it has no name any more). */
static clvox_status changed_while_reading(clvox_context *ctx, const char *path, const struct stat *before,
                                          const struct stat *now)
{
    if (!now)
        return clvox__fail(ctx, CLVOX_ERR_IO, "cannot read mesh '%s': file changed or truncated while reading (%s)",
                           path, "removed or renamed");
    return clvox__fail(ctx, CLVOX_ERR_IO,
                       "cannot read mesh '%s': file changed or truncated while reading (%lld bytes when opened, "
                       "%lld now)",
                       path, (long long)before->st_size, (long long)now->st_size);
}

/* The whole of fd, whose fstat was *before, into a malloc'd buffer of
 * st_size + 1 bytes (a NUL after the end). Read, not mapped: a mapped file
 * that shrinks (another program still writing it, a network file system)
 * kills the process with SIGBUS at the first page past its new end, and a
 * library cannot catch that. A file that ends early, grows, or whose fstat
 * differs afterwards (size, mtime, ctime) is CLVOX_ERR_IO "changed or
 * truncated while reading". */
static clvox_status read_whole_file(clvox_context *ctx, const char *path, int fd, const struct stat *before,
                                    unsigned char **out)
{
    *out = NULL;
    size_t n = (size_t)before->st_size;
    unsigned char *buf = malloc(n + 1);
    if (!buf) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s' (%zu bytes)", path, n);
    size_t done = 0;
    while (done <= n) { /* n + 1 bytes asked for: one more tells a file that grew */
        size_t want = n + 1 - done;
        if (want > ((size_t)1 << 30)) want = (size_t)1 << 30;
        ssize_t got = read(fd, buf + done, want);
        if (got < 0 && errno == EINTR) continue;
        if (got < 0) {
            int e = errno;
            free(buf);
            return clvox__fail(ctx, CLVOX_ERR_IO, "cannot read mesh '%s': %s", path, strerror(e));
        }
        if (got == 0) break;
        done += (size_t)got;
    }
    struct stat after;
    if (fstat(fd, &after) != 0) {
        int e = errno;
        free(buf);
        return clvox__fail(ctx, CLVOX_ERR_IO, "cannot stat mesh '%s': %s", path, strerror(e));
    }
    if (done != n || !same_file_state(before, &after)) {
        free(buf);
        return changed_while_reading(ctx, path, before, &after);
    }
    buf[n] = 0;
    *out = buf;
    return CLVOX_OK;
}

/* Everything clvox_mesh_load does before build_mesh: open, check, read
 * (natively or through OpenMesh) into *raw (freed on failure). */
clvox_status clvox__mesh_read_raw(clvox_context *ctx, const char *path, clvox__raw_mesh *out_raw)
{
    memset(out_raw, 0, sizeof *out_raw);

    const char *ext;
    enum mesh_format fmt = format_of(path, &ext);
    /* Only a regular file: a directory named x.stl makes OpenMesh loop
     * forever; FIFOs and devices could block or never end. */
    struct stat sb;
    const char *why = NULL;
    int fd = clvox__open_regular_read(path, &sb, &why);
    if (fd < 0) return clvox__fail(ctx, CLVOX_ERR_IO, "cannot open mesh '%s': %s", path, why);
    if (fmt == FMT_UNKNOWN) {
        close(fd);
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                           "'%s': unknown extension '%s' (expected .obj, .off, .ply, .stl or .om)", path, ext);
    }
    if (sb.st_size == 0) {
        close(fd);
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s' is empty", path);
    }
    if ((uint64_t)sb.st_size > (uint64_t)SIZE_MAX / 2) {
        close(fd);
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s' is too large", path);
    }
    size_t n = (size_t)sb.st_size;
    unsigned char *data = NULL;
    clvox_status st = read_whole_file(ctx, path, fd, &sb, &data);
    if (st) {
        close(fd);
        return st;
    }

    expect ex;
    memset(&ex, 0, sizeof ex);
    clvox__raw_mesh raw;
    memset(&raw, 0, sizeof raw);
    int parsed = 0; /* read here, not by OpenMesh (OBJ, ASCII OFF) */
    const unsigned char *p = data;
    switch (fmt) {
    case FMT_OBJ: st = check_obj(ctx, path, (const char *)p, n, &raw, &parsed); break;
    case FMT_OFF: st = check_off(ctx, path, p, n, &ex, &raw, &parsed); break;
    case FMT_PLY: st = check_ply(ctx, path, p, n, &ex, &raw, &parsed); break;
    case FMT_STL:
        st = check_stl(ctx, path, p, n);
        if (!st && n >= 84 && 84 + 50 * (uint64_t)le32(p + 80) == n && clvox__mesh_native_enabled()) {
            int rc = clvox__stl_read_binary(p, n, &raw); /* 1: a tiny coordinate, OpenMesh reads it */
            if (rc == -2) st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", path);
            parsed = rc == 0;
        } else if (!st && clvox__mesh_native_enabled()) { /* ASCII (check_stl accepted it as such) */
            locale_t c_locale = (locale_t)0, old = LC_GLOBAL_LOCALE;
            if (!(st = c_locale_begin(ctx, path, &c_locale, &old))) {
                st = read_stl_ascii(ctx, path, (const char *)p, n, &raw, &parsed);
                c_locale_end(c_locale, old);
            }
            if (st) clvox__raw_mesh_free(&raw);
        }
        break;
    case FMT_OM: st = check_om(ctx, path, p, n); break;
    default: st = clvox__fail(ctx, CLVOX_ERR_INTERNAL, "unhandled format"); break;
    }
    free(data);
    if (st) {
        close(fd);
        return st;
    }

    if (!parsed) {
        /* OpenMesh opens the file again by name (through iostreams: a
         * shorter file is an early end there, not SIGBUS): the checked bytes
         * must still be what it reads, so the file must be unchanged
         * before, and after, as seen through fd and through the name. */
        struct stat now;
        int named = stat(path, &now) == 0;
        if (!named || !same_file_state(&sb, &now)) {
            close(fd);
            return changed_while_reading(ctx, path, &sb, named ? &now : NULL);
        }
        char err[512];
        err[0] = 0;
        int rc = clvox__openmesh_read(path, &raw, err, sizeof err);
        struct stat now_fd;
        int same = fstat(fd, &now_fd) == 0 && same_file_state(&sb, &now_fd);
        named = stat(path, &now) == 0;
        close(fd);
        if (!same || !named || !same_file_state(&sb, &now)) {
            clvox__raw_mesh_free(&raw);
            return changed_while_reading(ctx, path, &sb, named ? &now : NULL);
        }
        if (rc == -2) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "cannot read '%s': %s", path, err);
        if (rc != 0) return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "cannot read '%s': %s", path, err);
    } else {
        close(fd);
    }

    if ((ex.have_vertices && raw.vertex_count != ex.vertices) || (ex.have_faces && raw.face_count != ex.faces)) {
        st = clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                         "'%s': OpenMesh read %zu vertices and %zu faces, the file declares %llu and %llu", path,
                         raw.vertex_count, raw.face_count, (unsigned long long)ex.vertices,
                         (unsigned long long)ex.faces);
        clvox__raw_mesh_free(&raw);
        return st;
    }
    *out_raw = raw;
    return CLVOX_OK;
}

clvox_status clvox_mesh_load(clvox_context *ctx, const char *path, clvox_mesh **out)
{
    if (out) *out = NULL;
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!path || !out)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_mesh_load: NULL %s", path ? "out" : "path");
    if (!*path) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_mesh_load: empty path");
    clvox__raw_mesh raw;
    clvox_status st = clvox__mesh_read_raw(ctx, path, &raw);
    if (st) return st;
    char what[4200];
    snprintf(what, sizeof what, "'%s'", path);
    float *xyz = raw.xyz;
    raw.xyz = NULL; /* build_mesh owns it now */
    uint32_t *owned = NULL;
    if (!raw.face_sizes) { /* all triangles: build_mesh compacts the indices in place */
        owned = raw.face_indices;
        raw.face_indices = NULL;
    }
    st = build_mesh(ctx, what, xyz, raw.offset, raw.vertex_count, raw.face_sizes, owned ? owned : raw.face_indices,
                    raw.face_count, raw.index_count, raw.nonmanifold_faces, owned, out);
    clvox__raw_mesh_free(&raw);
    return st;
}

clvox_status clvox_mesh_from_arrays(clvox_context *ctx, const float *xyz, size_t vertex_count,
                                    const uint32_t *triangles, size_t triangle_count, clvox_mesh **out)
{
    if (out) *out = NULL;
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!out) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_mesh_from_arrays: NULL out");
    if ((!xyz && vertex_count) || (!triangles && triangle_count))
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_mesh_from_arrays: NULL %s with a non-zero count",
                           !xyz && vertex_count ? "xyz" : "triangles");
    if (vertex_count > SIZE_MAX / (3 * sizeof(float)) || triangle_count > SIZE_MAX / (3 * sizeof(uint32_t)))
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_mesh_from_arrays: counts too large");
    float *copy = malloc((vertex_count ? vertex_count : 1) * 3 * sizeof *copy);
    if (!copy) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory copying %zu vertices", vertex_count);
    if (vertex_count) memcpy(copy, xyz, vertex_count * 3 * sizeof *copy);
    static const double no_offset[3] = {0, 0, 0};
    return build_mesh(ctx, "mesh arrays", copy, no_offset, vertex_count, NULL, triangles, triangle_count, 3 * triangle_count, 0,
                      NULL, out);
}

void clvox_mesh_destroy(clvox_mesh *mesh)
{
    if (!mesh) return;
    clvox__prep_ahead_drop(mesh); /* its thread reads the mesh */
    free(mesh->xyz);
    free(mesh->tris);
    free(mesh);
}

const clvox_mesh_report *clvox_mesh_get_report(const clvox_mesh *mesh) { return mesh ? &mesh->report : NULL; }

void clvox_mesh_vertex_offset(const clvox_mesh *mesh, double offset[3])
{
    for (int a = 0; a < 3; a++) offset[a] = mesh ? mesh->offset[a] : 0.0;
}

const float *clvox_mesh_vertices(const clvox_mesh *mesh, size_t *vertex_count)
{
    if (vertex_count) *vertex_count = mesh ? mesh->vertex_count : 0;
    return mesh ? mesh->xyz : NULL;
}

const uint32_t *clvox_mesh_triangles(const clvox_mesh *mesh, size_t *triangle_count)
{
    if (triangle_count) *triangle_count = mesh ? mesh->triangle_count : 0;
    return mesh ? mesh->tris : NULL;
}
