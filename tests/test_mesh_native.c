/* SPDX-License-Identifier: Apache-2.0 */
/* The native binary PLY and STL readers (src/mesh/mesh_ply.c, src/mesh/mesh_stl.c)
 * against OpenMesh's (CLVOX_MESH_READER=openmesh, the reader clvox used
 * before): the same vertices, triangles, offset and report, bit for bit, for
 * generated meshes and the CGAL meshes in data/meshes (when present) written
 * in every encoding: little/big endian PLY, float/double coordinates, extra
 * vertex properties in any order, face lists with uchar/char/ushort/short/
 * int/uint counts and int/uint/short/ushort/char/uchar indices, quads and
 * polygons, other elements before, between and after; ASCII PLY in 4 of
 * those layouts and 5 number spellings; binary STL with and without "solid"
 * at the start of the header, with repeated and degenerate facets; ASCII
 * STL. Also the same failure (status and message) on broken files. */
#include "test.h"
#include "meshgen.h"
#include "core/environment.h"
#include "mesh/mesh_internal.h" /* clvox__mesh_native_enabled */

#include <dirent.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static clvox_context *ctx;
static char dir[1024];
static int compared;

typedef struct bytes { unsigned char *p; size_t n, cap; } bytes;

static void put(bytes *b, const void *src, size_t n)
{
    if (b->n + n > b->cap) {
        b->cap = (b->n + n) * 2 + 256;
        b->p = realloc(b->p, b->cap);
        if (!b->p) exit(1);
    }
    memcpy(b->p + b->n, src, n);
    b->n += n;
}
static void put_str(bytes *b, const char *s) { put(b, s, strlen(s)); }
static void put_uint(bytes *b, uint64_t v, int size, int big)
{
    unsigned char c[8];
    for (int i = 0; i < size; i++) c[big ? size - 1 - i : i] = (unsigned char)(v >> (8 * i));
    put(b, c, (size_t)size);
}
static void put_f32(bytes *b, float f, int big)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    put_uint(b, u, 4, big);
}
static void put_f64(bytes *b, double d, int big)
{
    uint64_t u;
    memcpy(&u, &d, 8);
    put_uint(b, u, 8, big);
}

static const char *write_file(const char *name, const bytes *b)
{
    static char p[1200];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    FILE *f = fopen(p, "wb");
    if (!f || (b->n && fwrite(b->p, 1, b->n, f) != b->n)) {
        fprintf(stderr, "cannot write %s\n", p);
        exit(1);
    }
    fclose(f);
    return p;
}

/* A polygon soup: faces of any size (sizes[f] corners). */
typedef struct poly { const float *xyz; size_t nv; uint32_t *sizes, *idx; size_t nf, ni; } poly;

/* Triangles, merged into fans where consecutive triangles continue one
 * ((a,b,c),(a,c,d) -> (a,b,c,d)), so that fanning gives them back. */
static poly poly_from_tris(const float *xyz, size_t nv, const uint32_t *t, size_t nt, int merge)
{
    poly p = {xyz, nv, malloc((nt + 1) * sizeof(uint32_t)), malloc((3 * nt + 1) * sizeof(uint32_t)), 0, 0};
    for (size_t i = 0; i < nt; i++) {
        const uint32_t *u = t + 3 * i;
        if (merge && p.nf && p.sizes[p.nf - 1] < 9) {
            size_t s = p.sizes[p.nf - 1];
            uint32_t *f = p.idx + p.ni - s;
            if (f[0] == u[0] && f[s - 1] == u[1]) {
                p.idx[p.ni++] = u[2];
                p.sizes[p.nf - 1]++;
                continue;
            }
        }
        p.sizes[p.nf++] = 3;
        for (int c = 0; c < 3; c++) p.idx[p.ni++] = u[c];
    }
    return p;
}

static void poly_free(poly *p)
{
    free(p->sizes);
    free(p->idx);
}

typedef struct ply_style {
    int big, dbl, extras, fextras, elems;
    const char *count_type, *index_type;
    int count_size, index_size;
    int ascii; /* format ascii 1.0 (big, the sizes unused) */
} ply_style;

/* ASCII PLY values: one of several spellings of the same float, so that
 * both the fast path and strtof are used; whitespace varies too. */
static void put_text_f(bytes *b, double x, uint64_t k)
{
    char t[64];
    static const char *const fmt[] = {"%.9g", "%.8e", "%.17g", "%.9G", "%.10e"};
    snprintf(t, sizeof t, fmt[k % 5], x);
    put_str(b, t);
    put_str(b, k % 7 == 3 ? "\t" : " ");
}
static void put_text_u(bytes *b, uint64_t v)
{
    char t[32];
    snprintf(t, sizeof t, "%llu ", (unsigned long long)v);
    put_str(b, t);
}

static bytes ply_bytes(const poly *m, const ply_style *s)
{
    bytes b = {0};
    char line[256];
    put_str(&b, "ply\n");
    put_str(&b, s->ascii ? "format ascii 1.0\n"
                         : s->big ? "format binary_big_endian 1.0\n" : "format binary_little_endian 1.0\n");
    put_str(&b, "comment clvox test_mesh_native\n");
    if (s->elems) put_str(&b, "element camera 1\nproperty float view_x\nproperty uchar flag\n");
    snprintf(line, sizeof line, "element vertex %zu\n", m->nv);
    put_str(&b, line);
    const char *ct = s->dbl ? "double" : "float";
    if (s->extras) {
        snprintf(line, sizeof line,
                 "property float nx\nproperty uchar red\nproperty %s x\nproperty double quality\nproperty %s z\n"
                 "property short label\nproperty %s y\nproperty float ny\n",
                 ct, ct, ct);
    } else {
        snprintf(line, sizeof line, "property %s x\nproperty %s y\nproperty %s z\n", ct, ct, ct);
    }
    put_str(&b, line);
    if (s->elems) put_str(&b, "element edge 2\nproperty int vertex1\nproperty int vertex2\n");
    snprintf(line, sizeof line, "element face %zu\n", m->nf);
    put_str(&b, line);
    if (s->fextras) put_str(&b, "property int flags\n");
    snprintf(line, sizeof line, "property list %s %s vertex_indices\n", s->count_type, s->index_type);
    put_str(&b, line);
    if (s->fextras) put_str(&b, "property list uchar float texcoord\nproperty uchar tag\n");
    if (s->elems) put_str(&b, "element material 1\nproperty list uchar float ambient\n");
    put_str(&b, "end_header\n");
    if (s->ascii) {
        uint64_t k = 0;
        if (s->elems) put_str(&b, "1.5 7\n");
        for (size_t v = 0; v < m->nv; v++) {
            const float *p = m->xyz + 3 * v;
            int order[3] = {0, 1, 2};
            if (s->extras) order[1] = 2, order[2] = 1, put_str(&b, "0.25 200 ");
            for (int c = 0; c < 3; c++) {
                put_text_f(&b, (double)p[order[c]], k++);
                if (s->extras && c == 0) put_str(&b, "-3.0 ");
                if (s->extras && c == 1) put_str(&b, "-2 ");
            }
            if (s->extras) put_str(&b, "-0.5");
            put_str(&b, "\n");
        }
        if (s->elems) put_str(&b, "0 1\n1 2\n");
        size_t pos = 0;
        for (size_t f = 0; f < m->nf; f++) {
            if (s->fextras) put_text_u(&b, f);
            put_text_u(&b, m->sizes[f]);
            for (uint32_t j = 0; j < m->sizes[f]; j++) put_text_u(&b, m->idx[pos + j]);
            pos += m->sizes[f];
            if (s->fextras) put_str(&b, f % 3 ? "2 0.5 0.75 9" : "0 9");
            put_str(&b, "\n");
        }
        if (s->elems) put_str(&b, "2 0.1 0.2\n");
        return b;
    }
    if (s->elems) {
        put_f32(&b, 1.5f, s->big);
        put_uint(&b, 7, 1, s->big);
    }
    for (size_t v = 0; v < m->nv; v++) {
        const float *p = m->xyz + 3 * v;
        if (s->extras) {
            put_f32(&b, 0.25f, s->big);
            put_uint(&b, 200, 1, s->big);
        }
        int order[3] = {0, 1, 2};
        if (s->extras) order[1] = 2, order[2] = 1;
        for (int c = 0; c < 3; c++) {
            float x = p[order[c]];
            if (s->dbl) put_f64(&b, (double)x, s->big);
            else put_f32(&b, x, s->big);
            if (s->extras && c == 0) put_f64(&b, -3.0, s->big);
            if (s->extras && c == 1) put_uint(&b, 0xfffe, 2, s->big);
        }
        if (s->extras) put_f32(&b, -0.5f, s->big);
    }
    if (s->elems)
        for (int e = 0; e < 2; e++) put_uint(&b, (uint64_t)e, 4, s->big), put_uint(&b, (uint64_t)e + 1, 4, s->big);
    size_t pos = 0;
    for (size_t f = 0; f < m->nf; f++) {
        if (s->fextras) put_uint(&b, f, 4, s->big);
        put_uint(&b, m->sizes[f], s->count_size, s->big);
        for (uint32_t j = 0; j < m->sizes[f]; j++) put_uint(&b, m->idx[pos + j], s->index_size, s->big);
        pos += m->sizes[f];
        if (s->fextras) {
            put_uint(&b, f % 3 ? 2 : 0, 1, s->big);
            if (f % 3) put_f32(&b, 0.5f, s->big), put_f32(&b, 0.75f, s->big);
            put_uint(&b, 9, 1, s->big);
        }
    }
    if (s->elems) put_uint(&b, 2, 1, s->big), put_f32(&b, 0.1f, s->big), put_f32(&b, 0.2f, s->big);
    return b;
}

static bytes stl_bytes(const float *xyz, const uint32_t *t, size_t nt, int solid)
{
    bytes b = {0};
    char head[80];
    memset(head, ' ', sizeof head);
    memcpy(head, solid ? "solid clvox test" : "clvox binary test", solid ? 16 : 17);
    put(&b, head, 80);
    put_uint(&b, nt, 4, 0);
    for (size_t i = 0; i < nt; i++) {
        for (int c = 0; c < 3; c++) put_f32(&b, 0.0f, 0);
        for (int c = 0; c < 3; c++)
            for (int a = 0; a < 3; a++) put_f32(&b, xyz[3 * (size_t)t[3 * i + c] + a], 0);
        put_uint(&b, 0, 2, 0);
    }
    return b;
}

/* ASCII STL of the same triangles (number spellings as for ASCII PLY). */
static bytes stl_text(const float *xyz, const uint32_t *t, size_t nt)
{
    bytes b = {0};
    uint64_t k = 0;
    put_str(&b, "solid clvox test\n");
    for (size_t i = 0; i < nt; i++) {
        put_str(&b, i % 5 == 1 ? "  facet normal 0 0 1\n    outer loop\n" : "facet normal 0 0 0\nouter loop\n");
        for (int c = 0; c < 3; c++) {
            put_str(&b, i % 3 == 2 ? "\tvertex  " : "vertex ");
            for (int a = 0; a < 3; a++) put_text_f(&b, (double)xyz[3 * (size_t)t[3 * i + c] + a], k++);
            put_str(&b, "\n");
        }
        put_str(&b, "endloop\nendfacet\n");
    }
    put_str(&b, "endsolid clvox test\n");
    return b;
}

static int set_reader(const char *v)
{
    clvox__test_hooks hooks = *clvox__hooks();
    hooks.mesh_reader_openmesh = v && strcmp(v, "openmesh") == 0;
    clvox__set_test_hooks(&hooks);
    return 0;
}

/* Loads path with both readers and compares everything. */
static void compare(const char *path, const char *what)
{
    clvox_mesh *a = NULL, *b = NULL;
    set_reader(NULL);
    clvox_status sa = clvox_mesh_load(ctx, path, &a);
    char ma[600];
    snprintf(ma, sizeof ma, "%s", clvox_context_error(ctx));
    set_reader("openmesh");
    clvox_status sb = clvox_mesh_load(ctx, path, &b);
    char mb[600];
    snprintf(mb, sizeof mb, "%s", clvox_context_error(ctx));
    set_reader(NULL);
    compared++;
    CHECK_MSG(sa == sb, "%s: native %s (%s), OpenMesh %s (%s)", what, clvox_status_string(sa), ma,
              clvox_status_string(sb), mb);
    if (sa != CLVOX_OK || sb != CLVOX_OK) {
        if (sa == sb) CHECK_MSG(!strcmp(ma, mb), "%s: messages differ: '%s' vs '%s'", what, ma, mb);
        clvox_mesh_destroy(a);
        clvox_mesh_destroy(b);
        return;
    }
    size_t nva, nvb, nta, ntb;
    const float *va = clvox_mesh_vertices(a, &nva), *vb = clvox_mesh_vertices(b, &nvb);
    const uint32_t *ta = clvox_mesh_triangles(a, &nta), *tb = clvox_mesh_triangles(b, &ntb);
    double oa[3], ob[3];
    clvox_mesh_vertex_offset(a, oa);
    clvox_mesh_vertex_offset(b, ob);
    CHECK_MSG(nva == nvb && !memcmp(va, vb, nva * 3 * sizeof *va), "%s: vertices differ (%zu vs %zu)", what, nva, nvb);
    CHECK_MSG(nta == ntb && !memcmp(ta, tb, nta * 3 * sizeof *ta), "%s: triangles differ (%zu vs %zu)", what, nta, ntb);
    CHECK_MSG(!memcmp(oa, ob, sizeof oa), "%s: offsets differ", what);
    CHECK_MSG(!memcmp(clvox_mesh_get_report(a), clvox_mesh_get_report(b), sizeof(clvox_mesh_report)),
              "%s: reports differ", what);
    clvox_mesh_destroy(a);
    clvox_mesh_destroy(b);
}

/* OpenMesh 9.0 reads list counts of type uchar and int only (char, short,
 * ushort, uint, int32: "could not parse"), and misreads a face with a scalar
 * property before its index list or a texcoord list (garbage indices or
 * failure). Those encodings are compared with the uchar/int one instead. */
static const ply_style styles[] = {
    {0, 0, 0, 0, 0, "uchar", "int", 1, 4, 0},    {1, 0, 0, 0, 0, "uchar", "int", 1, 4, 0},
    {0, 1, 1, 0, 1, "int", "uint", 4, 4, 0},     {1, 1, 1, 0, 1, "int", "int", 4, 4, 0},
    {0, 0, 1, 0, 0, "uchar", "ushort", 1, 2, 0}, {1, 0, 0, 0, 1, "int32", "short", 4, 2, 0},
    {0, 1, 0, 0, 0, "uint8", "uchar", 1, 1, 0},  {1, 0, 1, 0, 0, "uchar", "char", 1, 1, 0},
    {0, 0, 0, 0, 0, "uchar", "uint", 1, 4, 0},   {1, 0, 1, 1, 1, "uint", "uint", 4, 4, 0},
    {0, 0, 1, 1, 0, "ushort", "uint", 2, 4, 0},  {1, 0, 0, 0, 1, "short", "int", 2, 4, 0},
    {0, 0, 0, 0, 0, "char", "int", 1, 4, 0},     {0, 1, 1, 1, 1, "uchar", "ushort", 1, 2, 0},
    {1, 0, 1, 1, 0, "int8", "char", 1, 1, 0},    {0, 0, 0, 1, 0, "uchar", "int", 1, 4, 0},
    /* ASCII: x y z float read natively, double by OpenMesh on both sides */
    {0, 0, 0, 0, 0, "uchar", "int", 1, 4, 1}, {0, 0, 1, 0, 1, "int", "int", 4, 4, 1},
    {0, 1, 1, 0, 0, "uchar", "int", 1, 4, 1}, {0, 0, 1, 1, 1, "uchar", "uint", 1, 4, 1},
};

static int openmesh_reads(const ply_style *s)
{
    return !s->fextras && (!strcmp(s->count_type, "uchar") || !strcmp(s->count_type, "uint8") ||
                           !strcmp(s->count_type, "int"));
}

/* Native load of path equals ref (a native load of the same mesh in another
 * encoding) or fails with ref_msg. */
static void same_as(const char *path, clvox_status ref_st, const char *ref_msg, const clvox_mesh *ref, const char *what)
{
    clvox_mesh *a = NULL;
    clvox_status st = clvox_mesh_load(ctx, path, &a);
    compared++;
    CHECK_MSG(st == ref_st, "%s: %s (%s), reference %s", what, clvox_status_string(st), clvox_context_error(ctx),
              clvox_status_string(ref_st));
    if (st != CLVOX_OK || ref_st != CLVOX_OK) {
        if (st == ref_st) CHECK_MSG(!strcmp(clvox_context_error(ctx), ref_msg), "%s: '%s' vs '%s'", what,
                                    clvox_context_error(ctx), ref_msg);
        clvox_mesh_destroy(a);
        return;
    }
    size_t nva, nvb, nta, ntb;
    const float *va = clvox_mesh_vertices(a, &nva), *vb = clvox_mesh_vertices(ref, &nvb);
    const uint32_t *ta = clvox_mesh_triangles(a, &nta), *tb = clvox_mesh_triangles(ref, &ntb);
    CHECK_MSG(nva == nvb && !memcmp(va, vb, nva * 3 * sizeof *va), "%s: vertices differ", what);
    CHECK_MSG(nta == ntb && !memcmp(ta, tb, nta * 3 * sizeof *ta), "%s: triangles differ", what);
    CHECK_MSG(!memcmp(clvox_mesh_get_report(a), clvox_mesh_get_report(ref), sizeof(clvox_mesh_report)),
              "%s: reports differ", what);
    clvox_mesh_destroy(a);
}

/* Every encoding of one triangle mesh (and its fan-merged polygons). */
static void compare_all(const char *name, const float *xyz, size_t nv, const uint32_t *t, size_t nt, int quick)
{
    char what[300], file[300];
    for (int merge = 0; merge < 2; merge++) {
        poly p = poly_from_tris(xyz, nv, t, nt, merge);
        clvox_mesh *ref = NULL;
        clvox_status ref_st = CLVOX_OK;
        char ref_msg[600] = "";
        snprintf(file, sizeof file, "native_%s.ply", name);
        for (size_t s = 0; s < sizeof styles / sizeof styles[0]; s++) {
            const ply_style *st = &styles[s];
            if (quick && s > 3) break;
            uint64_t max_index = st->index_size == 4 ? UINT32_MAX : (uint64_t)1 << (8 * st->index_size - 1);
            if (nv > max_index) continue;
            bytes b = ply_bytes(&p, st);
            snprintf(what, sizeof what, "%s as PLY %s %s/%s%s%s%s%s%s", name, st->ascii ? "ASCII" : st->big ? "BE" : "LE", st->count_type,
                     st->index_type, st->dbl ? " double" : "", st->extras ? " vertex-extras" : "",
                     st->fextras ? " face-extras" : "", st->elems ? " elements" : "", merge ? " polygons" : "");
            const char *path = write_file(file, &b);
            if (openmesh_reads(st)) compare(path, what);
            if (s == 0) {
                ref_st = clvox_mesh_load(ctx, path, &ref);
                snprintf(ref_msg, sizeof ref_msg, "%s", clvox_context_error(ctx));
            } else {
                same_as(path, ref_st, ref_msg, ref, what);
            }
            free(b.p);
        }
        clvox_mesh_destroy(ref);
        poly_free(&p);
    }
    for (size_t i = 0; i < 3 * nt; i++)
        if (t[i] >= nv) return; /* STL has no indices */
    for (int solid = 0; solid < 2; solid++) {
        bytes b = stl_bytes(xyz, t, nt, solid);
        snprintf(file, sizeof file, "native_%s.stl", name);
        snprintf(what, sizeof what, "%s as binary STL%s", name, solid ? " (solid header)" : "");
        compare(write_file(file, &b), what);
        free(b.p);
    }
    bytes b = stl_text(xyz, t, nt);
    snprintf(file, sizeof file, "native_%s.stl", name);
    snprintf(what, sizeof what, "%s as ASCII STL", name);
    compare(write_file(file, &b), what);
    free(b.p);
}

static void compare_tmesh(const char *name, tmesh m)
{
    compare_all(name, m.xyz, m.nv, m.tri, m.nt, 0);
    tmesh_free(&m);
}

static void test_generated(void)
{
    compare_tmesh("box", tmesh_box(0, 0, 0, 1, 2, 3));
    compare_tmesh("box_sub", tmesh_box_subdivided(-1, -1, -1, 1, 1, 1, 5));
    compare_tmesh("sphere", tmesh_sphere(0.5, 0.5, 0.5, 0.4, 12));
    compare_tmesh("torus", tmesh_torus(0, 0, 0, 1.0, 0.3, 24, 12));
    compare_tmesh("random", tmesh_random_closed(7, 3, 4));
    /* Repeated, degenerate, -0 and +0, one vertex far away: STL merging. */
    static const float xyz[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, -0.0f, 0, 0, 1, 0, 0, 1e30f, -1e-30f, 2};
    static const uint32_t tri[] = {0, 1, 2, 0, 2, 3, 4, 1, 3, 5, 1, 2, 0, 4, 1, 1, 3, 6, 2, 6, 0, 0, 1, 2};
    compare_all("odd", xyz, 7, tri, 8, 0);
    /* Out-of-range and negative indices, short faces: the same failure or report. */
    static const uint32_t bad[] = {0, 1, 2, 0, 2, 9};
    compare_all("bad_index", xyz, 7, bad, 2, 1);
    static const uint32_t neg[] = {0, 1, 2, 0, 2, 0xffffffffu};
    compare_all("neg_index", xyz, 7, neg, 2, 1);
    /* Tiny coordinates: the STL reader hands the file to OpenMesh. */
    static const float tiny[] = {0, 0, 0, 1e-38f, 0, 0, 0, 1, 0, 0, 0, 1, 2e-38f, 1e-38f, 0};
    static const uint32_t ttri[] = {0, 1, 2, 0, 2, 3, 4, 1, 3, 0, 4, 3};
    compare_all("tiny", tiny, 5, ttri, 4, 1);
}

/* Truncated and broken binary files: the same error as before. */
static void test_broken(void)
{
    tmesh m = tmesh_sphere(0, 0, 0, 1, 6);
    poly p = poly_from_tris(m.xyz, m.nv, m.tri, m.nt, 1);
    for (size_t s = 0; s < 4; s++) {
        bytes b = ply_bytes(&p, &styles[s]);
        size_t full = b.n;
        size_t cuts[] = {full - 1, full - 5, full / 2, full / 3, 300};
        for (size_t c = 0; c < sizeof cuts / sizeof cuts[0]; c++) {
            b.n = cuts[c];
            char what[100];
            snprintf(what, sizeof what, "PLY style %zu cut at %zu of %zu", s, cuts[c], full);
            compare(write_file("native_cut.ply", &b), what);
        }
        free(b.p);
    }
    bytes b = stl_bytes(m.xyz, m.tri, m.nt, 1);
    size_t full = b.n;
    b.n = full - 10;
    compare(write_file("native_cut.stl", &b), "STL cut (solid header)");
    memcpy(b.p, "XXXXX", 5);
    compare(write_file("native_cut.stl", &b), "STL cut");
    b.n = full;
    float nan = NAN;
    memcpy(b.p + 84 + 50 * 3 + 16, &nan, 4);
    compare(write_file("native_nan.stl", &b), "STL with a NaN");
    free(b.p);
    poly_free(&p);
    tmesh_free(&m);
}

static int by_name(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

/* The CGAL meshes: read (OFF) once, written in every encoding. Big files
 * (over 2 MB) only in the main encodings. */
static void test_cgal(void)
{
    DIR *d = opendir("data/meshes");
    if (!d) {
        printf("data/meshes absent: CGAL comparisons skipped\n");
        return;
    }
    char *names[512];
    int nn = 0;
    struct dirent *e;
    while ((e = readdir(d)) && nn < 512) {
        size_t l = strlen(e->d_name);
        if (l > 4 && (!strcmp(e->d_name + l - 4, ".off") || !strcmp(e->d_name + l - 4, ".ply"))) names[nn++] = strdup(e->d_name);
    }
    closedir(d);
    qsort(names, (size_t)nn, sizeof *names, by_name);
    int done = 0;
    for (int i = 0; i < nn; i++) {
        char path[600];
        snprintf(path, sizeof path, "data/meshes/%s", names[i]);
        struct stat sb;
        int big = stat(path, &sb) == 0 && sb.st_size > 2000000;
        if (sb.st_size > 20000000) { /* armadillo_s3: the benchmark's */
            free(names[i]);
            continue;
        }
        if (strstr(names[i], ".ply")) compare(path, names[i]); /* as shipped */
        clvox_mesh *m = NULL;
        if (clvox_mesh_load(ctx, path, &m) == CLVOX_OK) {
            size_t nv, nt;
            const float *xyz = clvox_mesh_vertices(m, &nv);
            const uint32_t *t = clvox_mesh_triangles(m, &nt);
            compare_all(names[i], xyz, nv, t, nt, big);
            clvox_mesh_destroy(m);
            done++;
        }
        free(names[i]);
    }
    printf("CGAL meshes compared in every encoding: %d\n", done);
}

/* The switch reaches the readers: without it this file would compare the
 * native readers with themselves. */
static void test_reader_switch(void)
{
    set_reader("openmesh");
    CHECK_MSG(!clvox__mesh_native_enabled(), "mesh_reader_openmesh set, but the native readers are on");
    set_reader(NULL);
    CHECK_MSG(clvox__mesh_native_enabled(), "mesh_reader_openmesh cleared, but the native readers are off");
}

int main(void)
{
    clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
    o.host_only = 1;
    if (clvox_context_create(&o, &ctx) != CLVOX_OK) {
        printf("0 passed, 1 failed\n");
        return 1;
    }
    snprintf(dir, sizeof dir, "%s/mesh_native", test_tmpdir());
    mkdir(dir, 0777);
    test_reader_switch();
    test_generated();
    test_broken();
    test_cgal();
    printf("files compared: %d\n", compared);
    clvox_context_destroy(ctx);
    return test_report();
}
