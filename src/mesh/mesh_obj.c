/* SPDX-License-Identifier: Apache-2.0 */
/* OBJ, parsed here (not by OpenMesh): see below why, and what is read. */
#include "mesh_internal.h"
#include "mesh_scan.h"

#include <stdlib.h>
#include <string.h>

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
    if (!n || !clvox__parse_int(&part, &v))
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
                if (clvox__fast_decimal(&k, &x)) {
                    store_coord(raw, so_far[OBJ_V], c, x);
                    continue;
                }
                clvox_status st = clvox__check_coord(ctx, path, &k, "vertex");
                if (st) return st;
                if (!clvox__token_double(&k, &x))
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

clvox_status clvox__mesh_check_obj(clvox_context *ctx, const char *path, const char *p, size_t n,
                                   clvox__raw_mesh *native, int *parsed)
{
    clvox_status st = clvox__check_text(ctx, path, p, n, "OBJ");
    if (st) return st;
    locale_t c_locale = (locale_t)0, old = LC_GLOBAL_LOCALE;
    if ((st = clvox__c_locale_begin(ctx, path, &c_locale, &old))) return st;
    st = parse_obj(ctx, path, p, n, native);
    clvox__c_locale_end(c_locale, old);
    return clvox__text_read_done(st, native, parsed);
}
