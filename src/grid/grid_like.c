/* SPDX-License-Identifier: Apache-2.0 */
/* Grids of other volumes, for `clvox --like`: the header of a NRRD file
 * (.nrrd attached or .nhdr detached; clvox's own and those of other tools
 * such as 3D Slicer) and the JSON sidecar clvox writes next to a .npy.
 * Only the grid is read (dims, origin = corner of voxel 0, voxel size),
 * never the samples. Both parsers work on a bounded buffer that need not be
 * NUL-terminated, and every malformed, truncated or unsupported input gives
 * CLVOX_ERR_GRID with one line "NAME: why" (docs/cli.md "Grid alignment"). */
#include "grid_like.h"
#include "core/internal.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define LIKE_MAX_HEADER (1u << 20) /* bytes of header looked at */

/* One-line copy of untrusted text for a message: printable ASCII, at most 40 characters. */
static void printable(char *dst, size_t size, const char *s, size_t n)
{
    size_t k = 0;
    for (size_t i = 0; i < n && k + 4 < size && i < 40; i++)
        dst[k++] = (s[i] >= 0x20 && s[i] < 0x7f) ? s[i] : '?';
    if (n > 40 && k + 4 < size) dst[k++] = '.', dst[k++] = '.', dst[k++] = '.';
    dst[k] = '\0';
}

static clvox_status check_grid(clvox_context *ctx, const char *name, const clvox_grid *g)
{
    uint64_t total = 1;
    for (int a = 0; a < 3; a++) {
        if (g->dims[a] == 0 || g->dims[a] > CLVOX_MAX_AXIS)
            return clvox__fail(ctx, CLVOX_ERR_GRID, "%s: %u samples along %c (1 to %u supported)", name, g->dims[a],
                               "xyz"[a], CLVOX_MAX_AXIS);
        total *= g->dims[a];
        if (!isfinite(g->origin[a]) || !isfinite(g->voxel_size[a]) || !(g->voxel_size[a] > 0) ||
            !isfinite(g->origin[a] + g->voxel_size[a] * g->dims[a]))
            return clvox__fail(ctx, CLVOX_ERR_GRID, "%s: the grid along %c is not finite and positive", name,
                               "xyz"[a]);
    }
    if (total > CLVOX_MAX_VOXELS)
        return clvox__fail(ctx, CLVOX_ERR_GRID, "%s: %llu voxels (at most %llu supported)", name,
                           (unsigned long long)total, (unsigned long long)CLVOX_MAX_VOXELS);
    return CLVOX_OK;
}

/* ---- NRRD ------------------------------------------------------------------ */

static const char *skip_ws(const char *p)
{
    while (*p == ' ' || *p == '\t') p++;
    return p;
}

/* A finite number at *p (strtod on a NUL-terminated line), advancing *p. */
static int parse_number(const char **p, double *v)
{
    const char *s = skip_ws(*p);
    if (!(*s == '-' || *s == '+' || *s == '.' || (*s >= '0' && *s <= '9'))) return 0; /* no nan/inf words */
    char *end;
    *v = strtod(s, &end);
    if (end == s || !isfinite(*v)) return 0;
    for (const char *q = s; q < end; q++)
        if (*q == 'x' || *q == 'X') return 0; /* no hex floats */
    *p = end;
    return 1;
}

/* "(a,b,c)" with optional blanks; 1 when it is a vector of 3 finite numbers. */
static int parse_vector(const char **p, double v[3])
{
    const char *s = skip_ws(*p);
    if (*s++ != '(') return 0;
    for (int i = 0; i < 3; i++) {
        if (!parse_number(&s, &v[i])) return 0;
        s = skip_ws(s);
        if (*s++ != (i < 2 ? ',' : ')')) return 0;
    }
    *p = s;
    return 1;
}

static int at_end(const char *p) { return *skip_ws(p) == '\0'; }

static int word_is(const char *s, size_t n, const char *w) { return strlen(w) == n && strncmp(s, w, n) == 0; }

clvox_status clvox__grid_from_nrrd(clvox_context *ctx, const char *name, const char *data, size_t len, clvox_grid *out,
                                   char *note, size_t note_size)
{
    if (note && note_size) note[0] = '\0';
    if (!name) name = "NRRD header";
    if (len > LIKE_MAX_HEADER) len = LIKE_MAX_HEADER;
    if (len < 8 || memcmp(data, "NRRD000", 7) != 0 || data[7] < '1' || data[7] > '9')
        return clvox__fail(ctx, CLVOX_ERR_GRID, "%s: not a NRRD file (no NRRD000N magic)", name);
    char *text = malloc(len + 1);
    if (!text) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    memcpy(text, data, len);
    text[len] = '\0';

    clvox_status st = CLVOX_OK;
    int have_dim = 0, have_sizes = 0, have_dirs = 0, have_origin = 0, have_space = 0, have_data_file = 0;
    int have_kinds = 0, have_corner = 0, ended = 0;
    unsigned long long sizes[3] = {0, 0, 0};
    double dirs[3][3] = {{0}}, origin[3] = {0}, corner[3] = {0};
    char space[64] = "";
    size_t line_no = 1;
    char *line = strchr(text, '\n');
    line = line ? line + 1 : text + len; /* the magic line */

    while (line < text + len) {
        line_no++;
        char *nl = memchr(line, '\n', (size_t)(text + len - line));
        char *end = nl ? nl : text + len;
        if (memchr(line, '\0', (size_t)(end - line))) {
            st = clvox__fail(ctx, CLVOX_ERR_GRID, "%s: line %zu: a NUL byte in the header", name, line_no);
            goto done;
        }
        if (end > line && end[-1] == '\r') end[-1] = '\0';
        *end = '\0';
        char *cur = line;
        line = nl ? nl + 1 : text + len;
        if (cur[0] == '\0') { /* the blank line: the data follows */
            ended = 1;
            break;
        }
        if (cur[0] == '#') continue;
        char *colon = strstr(cur, ": ");
        char *kv = strstr(cur, ":=");
        if (kv && (!colon || kv < colon)) { /* key:=value */
            if (strncmp(cur, "clvox_origin_corner:=", 21) == 0) {
                const char *p = kv + 2;
                have_corner = parse_number(&p, &corner[0]) && parse_number(&p, &corner[1]) &&
                              parse_number(&p, &corner[2]) && at_end(p);
            }
            continue;
        }
        if (!colon) {
            char shown[64];
            printable(shown, sizeof shown, cur, strlen(cur));
            st = clvox__fail(ctx, CLVOX_ERR_GRID, "%s: line %zu: not 'field: value' ('%s')", name, line_no, shown);
            goto done;
        }
        const char *field = cur;
        size_t flen = (size_t)(colon - cur);
        const char *v = skip_ws(colon + 2);
        int dup = 0;
        if (word_is(field, flen, "dimension")) {
            dup = have_dim++;
            char *e;
            long d = strtol(v, &e, 10);
            if (e == v || !at_end(e)) {
                st = clvox__fail(ctx, CLVOX_ERR_GRID, "%s: line %zu: bad dimension", name, line_no);
                goto done;
            }
            if (d != 3) {
                st = clvox__fail(ctx, CLVOX_ERR_GRID, "%s: dimension %ld: only 3-D scalar volumes can be --like grids",
                                 name, d);
                goto done;
            }
        } else if (word_is(field, flen, "sizes")) {
            dup = have_sizes++;
            const char *p = v;
            for (int i = 0; i < 3; i++) {
                p = skip_ws(p);
                char *e;
                if (*p < '0' || *p > '9') goto bad_sizes;
                sizes[i] = strtoull(p, &e, 10);
                if (e == p) goto bad_sizes;
                p = e;
            }
            if (!at_end(p)) {
            bad_sizes:
                st = clvox__fail(ctx, CLVOX_ERR_GRID, "%s: line %zu: 'sizes' must be 3 non-negative integers", name,
                                 line_no);
                goto done;
            }
        } else if (word_is(field, flen, "space directions")) {
            dup = have_dirs++;
            const char *p = v;
            for (int i = 0; i < 3; i++)
                if (!parse_vector(&p, dirs[i])) {
                    st = clvox__fail(ctx, CLVOX_ERR_GRID,
                                     "%s: line %zu: 'space directions' must be 3 vectors (a,b,c) ('none' axes are not "
                                     "supported)",
                                     name, line_no);
                    goto done;
                }
            if (!at_end(p)) {
                st = clvox__fail(ctx, CLVOX_ERR_GRID, "%s: line %zu: more than 3 space directions", name, line_no);
                goto done;
            }
        } else if (word_is(field, flen, "space origin")) {
            dup = have_origin++;
            const char *p = v;
            if (!parse_vector(&p, origin) || !at_end(p)) {
                st = clvox__fail(ctx, CLVOX_ERR_GRID, "%s: line %zu: 'space origin' must be one vector (x,y,z)", name,
                                 line_no);
                goto done;
            }
        } else if (word_is(field, flen, "space")) {
            dup = have_space++;
            static const char *const known[] = {"left-posterior-superior", "LPS", "right-anterior-superior", "RAS",
                                                "left-anterior-superior", "LAS", "scanner-xyz", "3D-right-handed",
                                                "3D-left-handed"};
            size_t n = strlen(v);
            while (n && (v[n - 1] == ' ' || v[n - 1] == '\t')) n--;
            int ok = 0;
            for (size_t i = 0; i < sizeof known / sizeof known[0]; i++) ok |= word_is(v, n, known[i]);
            if (!ok) {
                char shown[64];
                printable(shown, sizeof shown, v, n);
                st = clvox__fail(ctx, CLVOX_ERR_GRID,
                                 "%s: space '%s': only 3-D spaces (LPS, RAS, LAS, scanner-xyz, 3D-right-handed, "
                                 "3D-left-handed) are supported",
                                 name, shown);
                goto done;
            }
            printable(space, sizeof space, v, n);
        } else if (word_is(field, flen, "space dimension")) {
            dup = have_space++;
            char *e;
            long d = strtol(v, &e, 10);
            if (e == v || !at_end(e) || d != 3) {
                st = clvox__fail(ctx, CLVOX_ERR_GRID, "%s: line %zu: only 'space dimension: 3' is supported", name,
                                 line_no);
                goto done;
            }
            snprintf(space, sizeof space, "space dimension 3");
        } else if (word_is(field, flen, "kinds")) {
            dup = have_kinds++;
            const char *p = v;
            int n = 0;
            while (*(p = skip_ws(p))) {
                const char *w = p;
                while (*p && *p != ' ' && *p != '\t') p++;
                size_t wl = (size_t)(p - w);
                if (++n > 3 || !(word_is(w, wl, "domain") || word_is(w, wl, "space") || word_is(w, wl, "???") ||
                                 word_is(w, wl, "none"))) {
                    char shown[64];
                    printable(shown, sizeof shown, w, wl);
                    st = clvox__fail(ctx, CLVOX_ERR_GRID,
                                     "%s: kinds: '%s': only 3-D scalar volumes (kinds domain domain domain) can be "
                                     "--like grids",
                                     name, n > 3 ? "(more than 3)" : shown);
                    goto done;
                }
            }
            if (n != 3) {
                st = clvox__fail(ctx, CLVOX_ERR_GRID, "%s: line %zu: 'kinds' must name 3 axes", name, line_no);
                goto done;
            }
        } else if (word_is(field, flen, "data file") || word_is(field, flen, "datafile")) {
            have_data_file = 1;
        } else if (word_is(field, flen, "spacings") || word_is(field, flen, "axis mins")) {
            /* per-axis fields: only meaningful without a space; checked below */
        }
        /* every other field (type, encoding, endian, centerings, space units,
         * measurement frame, content, byte skip, line skip, ...) is ignored:
         * only the grid is read */
        if (dup) {
            char shown[64];
            printable(shown, sizeof shown, field, flen);
            st = clvox__fail(ctx, CLVOX_ERR_GRID, "%s: line %zu: field '%s' given twice", name, line_no, shown);
            goto done;
        }
    }
    if (!ended && !have_data_file) {
        st = clvox__fail(ctx, CLVOX_ERR_GRID, "%s: truncated header (no blank line before the data)", name);
        goto done;
    }
    if (!have_dim || !have_sizes) {
        st = clvox__fail(ctx, CLVOX_ERR_GRID, "%s: no '%s' field", name, !have_dim ? "dimension" : "sizes");
        goto done;
    }
    if (!have_space || !have_dirs || !have_origin) {
        st = clvox__fail(ctx, CLVOX_ERR_GRID, "%s: no '%s' field (the grid needs space, space directions and space "
                         "origin)", name, !have_space ? "space" : !have_dirs ? "space directions" : "space origin");
        goto done;
    }
    for (int i = 0; i < 3; i++) {
        double h = dirs[i][i];
        for (int j = 0; j < 3; j++)
            if (j != i && !(fabs(dirs[i][j]) <= 1e-9 * fabs(h))) {
                st = clvox__fail(ctx, CLVOX_ERR_GRID,
                                 "%s: space directions are rotated or sheared: only axis-aligned grids (diagonal "
                                 "space directions) are supported",
                                 name);
                goto done;
            }
        if (!(h > 0)) {
            st = clvox__fail(ctx, CLVOX_ERR_GRID,
                             "%s: space direction %d points backwards (%.17g): only axis-aligned grids with positive "
                             "steps are supported",
                             name, i + 1, h);
            goto done;
        }
        if (sizes[i] == 0 || sizes[i] > CLVOX_MAX_AXIS) {
            st = clvox__fail(ctx, CLVOX_ERR_GRID, "%s: %llu samples along axis %d (1 to %u supported)", name, sizes[i],
                             i + 1, CLVOX_MAX_AXIS);
            goto done;
        }
    }
    memset(out, 0, sizeof *out);
    for (int i = 0; i < 3; i++) {
        out->dims[i] = (uint32_t)sizes[i];
        out->voxel_size[i] = dirs[i][i];
        out->origin[i] = origin[i] - 0.5 * dirs[i][i]; /* NRRD positions are sample centres */
    }
    /* clvox's own files also carry the corner exactly: use it when it agrees */
    if (have_corner) {
        int agrees = 1;
        for (int i = 0; i < 3; i++)
            agrees &= fabs(corner[i] + 0.5 * dirs[i][i] - origin[i]) <= 1e-9 * (fabs(origin[i]) + dirs[i][i]);
        if (agrees)
            for (int i = 0; i < 3; i++) out->origin[i] = corner[i];
    }
    if ((st = check_grid(ctx, name, out)) != CLVOX_OK) goto done;
    if (note && note_size && strcmp(space, "left-posterior-superior") != 0 && strcmp(space, "LPS") != 0)
        snprintf(note, note_size,
                 "%s: space '%s': its coordinates are taken as they are, in the mesh's own frame (no conversion "
                 "to LPS)",
                 name, space);
done:
    free(text);
    return st;
}

/* ---- the NumPy sidecar (JSON) ---------------------------------------------- */

typedef struct jreader {
    const char *p, *end;
    int depth;
} jreader;

static void jws(jreader *r)
{
    while (r->p < r->end && (*r->p == ' ' || *r->p == '\t' || *r->p == '\n' || *r->p == '\r')) r->p++;
}

/* A JSON string; copies at most size-1 bytes of it (escapes kept as read). */
static int jstring(jreader *r, char *buf, size_t size)
{
    jws(r);
    if (r->p >= r->end || *r->p != '"') return 0;
    r->p++;
    size_t k = 0;
    while (r->p < r->end && *r->p != '"') {
        unsigned char c = (unsigned char)*r->p;
        if (c < 0x20) return 0;
        if (c == '\\') {
            if (++r->p >= r->end) return 0;
            if (!*r->p || !strchr("\"\\/bfnrtu", *r->p)) return 0;
        }
        if (buf && k + 1 < size) buf[k++] = *r->p;
        r->p++;
    }
    if (r->p >= r->end) return 0;
    r->p++;
    if (buf && size) buf[k] = '\0';
    return 1;
}

static int jnumber(jreader *r, double *v)
{
    jws(r);
    char buf[64];
    size_t k = 0;
    while (r->p < r->end && k + 1 < sizeof buf && *r->p && strchr("+-0123456789.eE", *r->p)) buf[k++] = *r->p++;
    buf[k] = '\0';
    if (k == 0 || k + 1 == sizeof buf) return 0;
    char *e;
    *v = strtod(buf, &e);
    return *e == '\0' && isfinite(*v);
}

static int jvalue(jreader *r); /* skips any value */

static int jskip_container(jreader *r, char open, char close)
{
    if (++r->depth > 16) return 0;
    r->p++; /* open */
    jws(r);
    if (r->p < r->end && *r->p == close) {
        r->p++;
        r->depth--;
        return 1;
    }
    for (;;) {
        if (open == '{') {
            if (!jstring(r, NULL, 0)) return 0;
            jws(r);
            if (r->p >= r->end || *r->p++ != ':') return 0;
        }
        if (!jvalue(r)) return 0;
        jws(r);
        if (r->p >= r->end) return 0;
        char c = *r->p++;
        if (c == close) break;
        if (c != ',') return 0;
    }
    r->depth--;
    return 1;
}

static int jvalue(jreader *r)
{
    jws(r);
    if (r->p >= r->end) return 0;
    char c = *r->p;
    if (c == '"') return jstring(r, NULL, 0);
    if (c == '{') return jskip_container(r, '{', '}');
    if (c == '[') return jskip_container(r, '[', ']');
    static const char *const words[] = {"true", "false", "null"};
    for (int i = 0; i < 3; i++) {
        size_t n = strlen(words[i]);
        if ((size_t)(r->end - r->p) >= n && memcmp(r->p, words[i], n) == 0) {
            r->p += n;
            return 1;
        }
    }
    double v;
    return jnumber(r, &v);
}

/* [a, b, c] of finite numbers. */
static int jtriple(jreader *r, double v[3])
{
    jws(r);
    if (r->p >= r->end || *r->p++ != '[') return 0;
    for (int i = 0; i < 3; i++) {
        if (!jnumber(r, &v[i])) return 0;
        jws(r);
        if (r->p >= r->end || *r->p++ != (i < 2 ? ',' : ']')) return 0;
    }
    return 1;
}

clvox_status clvox__grid_from_npy_json(clvox_context *ctx, const char *name, const char *data, size_t len,
                                       clvox_grid *out)
{
    if (!name) name = "sidecar";
    if (len > LIKE_MAX_HEADER)
        return clvox__fail(ctx, CLVOX_ERR_GRID, "%s: longer than %u bytes: not a clvox .npy sidecar", name,
                           LIKE_MAX_HEADER);
    jreader r = {data, data + len, 0};
    jws(&r);
    if (r.p >= r.end || *r.p != '{')
        return clvox__fail(ctx, CLVOX_ERR_GRID, "%s: not a clvox .npy sidecar (not a JSON object)", name);
    r.p++;
    r.depth = 1;
    int have_format = 0, have_dims = 0, have_origin = 0, have_h = 0, have_shape = 0, npy = 0;
    double dims[3], origin[3], h[3], shape[3];
    jws(&r);
    if (r.p < r.end && *r.p == '}') r.p++;
    else
        for (;;) {
            char key[32];
            if (!jstring(&r, key, sizeof key)) goto bad;
            jws(&r);
            if (r.p >= r.end || *r.p++ != ':') goto bad;
            int dup = 0;
            if (strcmp(key, "format") == 0) {
                char f[16];
                dup = have_format++;
                if (!jstring(&r, f, sizeof f)) goto bad;
                npy = strcmp(f, "npy") == 0;
            } else if (strcmp(key, "dims") == 0) {
                dup = have_dims++;
                if (!jtriple(&r, dims)) goto bad_field;
            } else if (strcmp(key, "origin") == 0) {
                dup = have_origin++;
                if (!jtriple(&r, origin)) goto bad_field;
            } else if (strcmp(key, "voxel_size") == 0) {
                dup = have_h++;
                if (!jtriple(&r, h)) goto bad_field;
            } else if (strcmp(key, "shape") == 0) {
                dup = have_shape++;
                if (!jtriple(&r, shape)) goto bad_field;
            } else if (!jvalue(&r))
                goto bad;
            if (dup)
                return clvox__fail(ctx, CLVOX_ERR_GRID, "%s: key '%s' given twice", name, key);
            jws(&r);
            if (r.p >= r.end) goto bad;
            char c = *r.p++;
            if (c == '}') break;
            if (c != ',') goto bad;
            continue;
        bad_field:
            return clvox__fail(ctx, CLVOX_ERR_GRID, "%s: '%s' must be an array of 3 finite numbers", name, key);
        }
    jws(&r);
    if (r.p != r.end) goto bad;
    if (!have_format || !npy)
        return clvox__fail(ctx, CLVOX_ERR_GRID, "%s: not a clvox .npy sidecar (no \"format\": \"npy\")", name);
    if (!have_dims || !have_origin || !have_h)
        return clvox__fail(ctx, CLVOX_ERR_GRID, "%s: no \"%s\" in the sidecar", name,
                           !have_dims ? "dims" : !have_origin ? "origin" : "voxel_size");
    memset(out, 0, sizeof *out);
    for (int a = 0; a < 3; a++) {
        if (!(dims[a] >= 1 && dims[a] <= CLVOX_MAX_AXIS && dims[a] == floor(dims[a])))
            return clvox__fail(ctx, CLVOX_ERR_GRID, "%s: dims[%d] is not an integer from 1 to %u", name, a,
                               CLVOX_MAX_AXIS);
        out->dims[a] = (uint32_t)dims[a];
        out->origin[a] = origin[a];
        out->voxel_size[a] = h[a];
    }
    if (have_shape && (shape[0] != dims[2] || shape[1] != dims[1] || shape[2] != dims[0]))
        return clvox__fail(ctx, CLVOX_ERR_GRID, "%s: \"shape\" is not \"dims\" reversed", name);
    return check_grid(ctx, name, out);
bad:
    return clvox__fail(ctx, CLVOX_ERR_GRID, "%s: malformed or truncated JSON (byte %zu): not a clvox .npy sidecar",
                       name, (size_t)(r.p - data));
}

/* ---- the public names (clvox.h), for clvox --like and other callers ---- */

clvox_status clvox_grid_from_nrrd_header(clvox_context *ctx, const char *name, const char *data, size_t len,
                                         clvox_grid *out, char *note, size_t note_size)
{
    if (!data || !out) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_grid_from_nrrd_header: NULL");
    return clvox__grid_from_nrrd(ctx, name, data, len, out, note, note_size);
}

clvox_status clvox_grid_from_npy_sidecar(clvox_context *ctx, const char *name, const char *data, size_t len,
                                         clvox_grid *out)
{
    if (!data || !out) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_grid_from_npy_sidecar: NULL");
    return clvox__grid_from_npy_json(ctx, name, data, len, out);
}
