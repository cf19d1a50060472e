/* SPDX-License-Identifier: Apache-2.0 */
/* STL: the checks (binary: exact size and finite coordinates; ASCII: every
 * vertex line holds three finite numbers, the file ends with endsolid) and
 * the native readers, binary and ASCII (laid out as binary in memory).
 *
 * The binary reader: OpenMesh 9.0's binary STL reader (what clvox used
 * before) merges a corner into an earlier vertex when a std::map with a
 * tolerant comparison (CmpVec, eps = FLT_MIN: |a - b| <= FLT_MIN per
 * coordinate) finds one, adds vertices in first-seen order and drops a
 * facet whose three corners do not map to three different vertices. For coordinates that are 0 or of magnitude
 * >= 2^-100, that comparison is exact equality with -0 == +0 (two different
 * such floats differ by at least 2^-123 > FLT_MIN, and b - FLT_MIN rounds to
 * b), so a hash on the bit patterns (-0 folded into +0) gives the same
 * vertices, in the same order, and the same triangles. A file with a tiny
 * non-zero coordinate (|x| < 2^-100) returns 1 and is read by OpenMesh. The
 * stored vertex is the first corner seen, as in OpenMesh (-0 stays -0).
 *
 * Memory: the mapped file, the vertex array (capacity 3 per facet, shrunk at
 * the end; untouched pages are never resident), the index array (3 per
 * facet, becomes the triangle array in place) and a hash table of 4-byte
 * vertex ids, at most half full. */
#include "mesh_internal.h"
#include "mesh_scan.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static uint32_t key_bits(uint32_t u) { return (u & 0x7fffffffu) ? u : 0; } /* -0 -> +0 */

static uint64_t hash_key(uint32_t a, uint32_t b, uint32_t c)
{
    uint64_t h = (uint64_t)a * 0x9E3779B97F4A7C15ull ^ ((uint64_t)b * 0xC2B2AE3D27D4EB4Full + (uint64_t)c);
    h ^= (uint64_t)c * 0x165667B19E3779F9ull;
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
    return h;
}

/* |x| < 2^-100 and x != 0: OpenMesh's tolerance could merge it with a neighbour. */
static int tiny(uint32_t u)
{
    uint32_t m = u & 0x7fffffffu;
    return m && m < 0x0d800000u; /* 2^-100 = exponent field 27 */
}

/* Binary STL (n == 84 + 50 count, finite coordinates: checked before) into
 * raw, vertices merged as OpenMesh's reader merges them. Returns 0 on
 * success, 1 when the file holds a coordinate that OpenMesh's tolerant
 * comparison could merge with a different value (|x| < 2^-100, x != 0: the
 * caller falls back to OpenMesh), -2 when memory runs out. */
static int stl_read_binary(const unsigned char *p, size_t n, clvox__raw_mesh *raw)
{
    memset(raw, 0, sizeof *raw);
    if (n < 84) return 1;
    uint64_t count = le32(p + 80);
    if (84 + 50 * count != n) return 1;
    size_t corners = (size_t)count * 3;
    float *xyz = malloc((corners ? corners : 1) * 3 * sizeof *xyz);
    uint32_t *idx = malloc((corners ? corners : 1) * sizeof *idx);
    size_t ts = 1024;
    while (ts < count) ts <<= 1; /* about 2 slots per expected vertex (V ~ T/2 for closed meshes) */
    uint32_t *slot = calloc(ts, sizeof *slot);
    if (!xyz || !idx || !slot) goto oom;
    size_t nv = 0, ni = 0, mask = ts - 1;
    enum { BLOCK = 32 }; /* facets whose slots are prefetched together */
    uint32_t key[BLOCK * 3][3], raw_bits[BLOCK * 3][3];
    uint64_t hash[BLOCK * 3];
    for (uint64_t t0 = 0; t0 < count; t0 += BLOCK) {
        size_t nb = count - t0 < BLOCK ? (size_t)(count - t0) : BLOCK;
        for (size_t j = 0; j < 3 * nb; j++) {
            const unsigned char *r = p + 84 + 50 * (t0 + j / 3) + 12 + 12 * (j % 3);
            for (int a = 0; a < 3; a++) {
                uint32_t u = le32(r + 4 * a);
                if (tiny(u)) goto fallback;
                raw_bits[j][a] = u;
                key[j][a] = key_bits(u);
            }
            hash[j] = hash_key(key[j][0], key[j][1], key[j][2]);
#if defined(__GNUC__)
            __builtin_prefetch(&slot[(size_t)hash[j] & mask]);
#endif
        }
        for (size_t f = 0; f < nb; f++) {
            uint32_t h3[3];
            for (int c = 0; c < 3; c++) {
                size_t j = 3 * f + (size_t)c;
                const uint32_t *k = key[j];
                size_t i = (size_t)hash[j] & mask;
                for (;; i = (i + 1) & mask) {
                    uint32_t s = slot[i];
                    if (!s) break;
                    uint32_t q[3];
                    memcpy(q, xyz + 3 * (size_t)(s - 1), sizeof q);
                    if (key_bits(q[0]) == k[0] && key_bits(q[1]) == k[1] && key_bits(q[2]) == k[2]) break;
                }
                if (slot[i]) {
                    h3[c] = slot[i] - 1;
                    continue;
                }
                if (nv >= UINT32_MAX - 1) goto oom;
                memcpy(xyz + 3 * nv, raw_bits[j], sizeof raw_bits[j]);
                h3[c] = (uint32_t)nv;
                slot[i] = (uint32_t)++nv;
                if (2 * nv > ts) { /* grow: keep the table at most half full */
                    size_t nts = ts * 2;
                    uint32_t *ns = calloc(nts, sizeof *ns);
                    if (!ns) goto oom;
                    size_t nmask = nts - 1;
                    for (size_t v = 0; v < nv; v++) {
                        uint32_t q[3];
                        memcpy(q, xyz + 3 * v, sizeof q);
                        size_t m = (size_t)hash_key(key_bits(q[0]), key_bits(q[1]), key_bits(q[2])) & nmask;
                        while (ns[m]) m = (m + 1) & nmask;
                        ns[m] = (uint32_t)(v + 1);
                    }
                    free(slot);
                    slot = ns;
                    ts = nts;
                    mask = nmask;
                }
            }
            if (h3[0] != h3[1] && h3[0] != h3[2] && h3[1] != h3[2]) {
                idx[ni++] = h3[0];
                idx[ni++] = h3[1];
                idx[ni++] = h3[2];
            }
        }
    }
    free(slot);
    float *shr = realloc(xyz, (nv ? nv : 1) * 3 * sizeof *shr);
    if (shr) xyz = shr;
    raw->xyz = xyz;
    raw->vertex_count = nv;
    raw->face_indices = idx;
    raw->face_count = ni / 3;
    raw->index_count = ni;
    raw->face_sizes = NULL; /* all triangles */
    return 0;
fallback:
    free(slot);
    free(xyz);
    free(idx);
    return 1;
oom:
    free(slot);
    free(xyz);
    free(idx);
    return -2;
}

/* ASCII STL read natively (after check_stl_ascii accepted it): the facets'
 * corners, as strtof reads them (OpenMesh's operator>>), laid out as a binary
 * STL in memory and merged by the binary reader (stl_read_binary:
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
                    if (!tok_line(&t, &k) || !clvox__token_float(&k, &x)) {
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
    int rc = stl_read_binary(img, bytes, raw);
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
                    clvox_status st = clvox__check_coord(ctx, path, &k, "STL vertex");
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

clvox_status clvox__mesh_check_stl(clvox_context *ctx, const char *path, const unsigned char *p, size_t n,
                                   clvox__raw_mesh *raw, int *parsed)
{
    clvox_status st = check_stl(ctx, path, p, n);
    if (!st && n >= 84 && 84 + 50 * (uint64_t)le32(p + 80) == n && clvox__mesh_native_enabled()) {
        int rc = stl_read_binary(p, n, raw); /* 1: a tiny coordinate, OpenMesh reads it */
        if (rc == -2) st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", path);
        *parsed = rc == 0;
    } else if (!st && clvox__mesh_native_enabled()) { /* ASCII (check_stl accepted it as such) */
        locale_t c_locale = (locale_t)0, old = LC_GLOBAL_LOCALE;
        if (!(st = clvox__c_locale_begin(ctx, path, &c_locale, &old))) {
            st = read_stl_ascii(ctx, path, (const char *)p, n, raw, parsed);
            clvox__c_locale_end(c_locale, old);
        }
        if (st) clvox__raw_mesh_free(raw);
    }
    return st;
}
