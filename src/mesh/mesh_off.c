/* SPDX-License-Identifier: Apache-2.0 */
/* OFF: binary files are walked face by face here and read by OpenMesh;
 * ASCII files are parsed here, not by OpenMesh (its reader supports no
 * comments, wants the counts on the second line and misreads face colours
 * without a COFF header). */
#include "mesh_internal.h"
#include "mesh_scan.h"

#include <stdlib.h>
#include <string.h>

/* Next line holding data: '#' starts a comment, blank lines are skipped.
 * *line covers the data part of the line; t moves past it. */
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
        if (nc == 3 || !clvox__parse_int(&k, &counts[nc]) || counts[nc] < 0 || counts[nc] > (int64_t)UINT32_MAX)
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
            if (clvox__fast_decimal(&k, &x)) { /* a plain decimal read exactly: checked and converted */
                if (c < 3) store_coord(raw, v, c, x);
                continue;
            }
            clvox_status st = clvox__check_coord(ctx, path, &k, "OFF vertex");
            if (st) return st;
            if (c < 3 && !clvox__token_double(&k, &x))
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
        if (!tok_line(&line, &k) || !clvox__parse_int(&k, &c) || c < 0 || c > (int64_t)((line.end - line.p) / 2 + 1))
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
            if (!clvox__parse_int(&k, &idx))
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
clvox_status clvox__mesh_check_off(clvox_context *ctx, const char *path, const unsigned char *up, size_t n,
                                   clvox__mesh_expect *ex, clvox__raw_mesh *native, int *parsed)
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

    clvox_status st = clvox__check_text(ctx, path, p, n, "OFF");
    if (st) return st;
    locale_t c_locale = (locale_t)0, old = LC_GLOBAL_LOCALE;
    if ((st = clvox__c_locale_begin(ctx, path, &c_locale, &old))) return st;
    st = parse_off_ascii(ctx, path, &t, counts_line, normal, n, native);
    clvox__c_locale_end(c_locale, old);
    return clvox__text_read_done(st, native, parsed);
}
