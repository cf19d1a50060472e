/* SPDX-License-Identifier: Apache-2.0 */
/* PLY: the header parsed here (bounded, strict), binary bodies walked
 * record by record so that a truncated file is caught, ASCII bodies scanned
 * token by token exactly as OpenMesh's reader consumes them (and read
 * natively when the coordinates are floats), and the native binary reader
 * (little and big endian).
 *
 * The binary reader: the header is parsed strictly and the body walked
 * record by record (ply_check_binary) before it runs, so every record is known to be inside
 * the file; the reader still never reads past n. It hands over what
 * OpenMesh 9.0's PLY reader (through RawImporter, mesh_openmesh.cpp) would:
 *   - elements are read in file order up to the face element; elements other
 *     than vertex and face (edges, materials, ...) are skipped by size;
 *     elements after the face element are not read at all;
 *   - vertex: x, y, z in any position among other properties (skipped by
 *     size); float or double. double is rounded to the nearest float (as
 *     OpenMesh does: its importer takes Vec3f), so precision beyond float is
 *     lost and the vertex offset stays 0;
 *   - face: the list named vertex_indices or vertex_index (if both are
 *     present the last one wins, as OpenMesh overwrites its handles); counts
 *     of any integer type, indices of any integer type: signed ones are
 *     sign-extended, and the index is kept as its 32-bit pattern (a negative
 *     index becomes >= 2^31, out of range, reported by clvox__mesh_build);
 *     other face properties (texcoord lists, flags) are skipped by size.
 * Faces with other than 3 corners are kept with their size;
 * clvox__mesh_build drops the short ones and fans polygons exactly as for
 * the other readers. While every face is a triangle, no face_sizes array is
 * made (NULL: all triangles), and clvox__mesh_build turns the index array
 * into the triangle array in place: one copy of the vertices and one of the
 * indices. */
#include "mesh_internal.h"
#include "mesh_scan.h"

#include <stdlib.h>
#include <string.h>

#define PLY_MAX_HEADER (64u * 1024u)
#define PLY_MAX_ELEMENTS 16
#define PLY_MAX_PROPS 64
#define PLY_NAME 64

enum ply_format { PLY_ASCII, PLY_LE, PLY_BE };

typedef struct ply_type { const char *name; int size, is_float, is_signed; } ply_type;

typedef struct ply_prop {
    char name[PLY_NAME];
    const ply_type *type;       /* value (list item) type */
    const ply_type *count_type; /* NULL: scalar */
} ply_prop;

typedef struct ply_elem {
    char name[PLY_NAME];
    uint64_t count;
    ply_prop props[PLY_MAX_PROPS];
    int nprops;
} ply_elem;

typedef struct ply_header {
    enum ply_format format;
    ply_elem elems[PLY_MAX_ELEMENTS];
    int nelems, vertex, face; /* element indices, -1 if absent */
    size_t body;              /* offset of the first byte after the header */
} ply_header;

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
#define HOST_LE 1
#else
#define HOST_LE 0
#endif

static uint64_t rd_uint(const unsigned char *b, int size, int big)
{
    switch (size) {
    case 1: return b[0];
    case 2: return big ? (uint64_t)b[0] << 8 | b[1] : (uint64_t)b[1] << 8 | b[0];
    case 4:
        return big ? (uint64_t)b[0] << 24 | (uint64_t)b[1] << 16 | (uint64_t)b[2] << 8 | b[3]
                   : (uint64_t)b[3] << 24 | (uint64_t)b[2] << 16 | (uint64_t)b[1] << 8 | b[0];
    default: {
        uint64_t v = 0;
        for (int i = 0; i < size; i++) v |= (uint64_t)b[big ? size - 1 - i : i] << (8 * i);
        return v;
    }
    }
}

/* An integer value as OpenMesh's readInteger stores it in an int/unsigned:
 * its low 32 bits after sign extension. */
static uint32_t rd_int32(const unsigned char *b, const ply_type *t, int big)
{
    uint64_t v = rd_uint(b, t->size, big);
    if (t->is_signed && t->size < 4 && (v >> (8 * t->size - 1)) & 1) v |= ~(uint64_t)0 << (8 * t->size);
    return (uint32_t)v;
}

static float rd_coord(const unsigned char *b, const ply_type *t, int big)
{
    if (t->size == 4) {
        uint32_t u = (uint32_t)rd_uint(b, 4, big);
        float f;
        memcpy(&f, &u, sizeof f);
        return f;
    }
    uint64_t u = rd_uint(b, 8, big);
    double d;
    memcpy(&d, &u, sizeof d);
    return (float)d;
}

static clvox_status oom(clvox_context *ctx, const char *path)
{
    return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", path);
}

static clvox_status truncated(clvox_context *ctx, const char *path, const ply_elem *e, uint64_t r)
{
    /* Unreachable after ply_check_binary; kept so that the reader is safe alone. */
    return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                       "'%s': binary PLY is truncated: element '%s' declares %llu entries, the file ends in entry %llu",
                       path, e->name, (unsigned long long)e->count, (unsigned long long)r);
}

static int is_index_list(const char *name) { return !strcmp(name, "vertex_indices") || !strcmp(name, "vertex_index"); }

static clvox_status read_vertices(clvox_context *ctx, const char *path, const unsigned char *p, size_t n, uint64_t *pos,
                                  const ply_elem *e, int big, clvox__raw_mesh *raw)
{
    size_t off[3] = {0, 0, 0}, stride = 0;
    const ply_type *ty[3] = {NULL, NULL, NULL};
    static const char *const axes[3] = {"x", "y", "z"};
    for (int q = 0; q < e->nprops; q++) {
        for (int a = 0; a < 3; a++)
            if (!strcmp(e->props[q].name, axes[a])) off[a] = stride, ty[a] = e->props[q].type;
        stride += (size_t)e->props[q].type->size;
    }
    if (!ty[0] || !ty[1] || !ty[2])
        return clvox__fail(ctx, CLVOX_ERR_INTERNAL, "'%s': PLY vertex element without x, y, z", path);
    uint64_t nv = e->count;
    if (nv && (!stride || (n - *pos) / stride < nv)) return truncated(ctx, path, e, 0);
    raw->xyz = malloc((nv ? nv : 1) * 3 * sizeof *raw->xyz);
    if (!raw->xyz) return oom(ctx, path);
    raw->vertex_count = (size_t)nv;
    const unsigned char *b = p + *pos;
    float *o = raw->xyz;
    if (HOST_LE && !big && ty[0]->size == 4 && ty[1]->size == 4 && ty[2]->size == 4) {
        if (stride == 12 && off[0] == 0 && off[1] == 4 && off[2] == 8) {
            memcpy(o, b, (size_t)nv * 12); /* little-endian float x y z only: the file is the array */
        } else {
            for (uint64_t v = 0; v < nv; v++, b += stride, o += 3) {
                memcpy(o, b + off[0], 4);
                memcpy(o + 1, b + off[1], 4);
                memcpy(o + 2, b + off[2], 4);
            }
        }
    } else {
        for (uint64_t v = 0; v < nv; v++, b += stride, o += 3)
            for (int a = 0; a < 3; a++) o[a] = rd_coord(b + off[a], ty[a], big);
    }
    *pos += stride * nv;
    return CLVOX_OK;
}

/* Grows the index array to hold `need` entries. */
static int grow_indices(clvox__raw_mesh *raw, size_t need, size_t *cap)
{
    if (need <= *cap) return 1;
    size_t c = *cap * 2 > need ? *cap * 2 : need;
    uint32_t *g = realloc(raw->face_indices, c * sizeof *g);
    if (!g) return 0;
    raw->face_indices = g;
    *cap = c;
    return 1;
}

static clvox_status read_faces(clvox_context *ctx, const char *path, const unsigned char *p, size_t n, uint64_t pos,
                               const ply_elem *e, int big, clvox__raw_mesh *raw)
{
    uint64_t nf = e->count;
    /* One uint32 index per index byte at most: the file bounds the array. */
    size_t cap = nf <= (n - pos) / 4 ? (size_t)nf * 3 : (size_t)(n - pos);
    if (cap < 16) cap = 16;
    raw->face_indices = malloc(cap * sizeof *raw->face_indices);
    if (!raw->face_indices) return oom(ctx, path);
    size_t ni = 0;
    const unsigned char *end = p + n, *b = p + pos;

    /* The common case: one property, list uchar int|uint vertex_indices,
     * little endian, all triangles. Leaves at the first other face. */
    uint64_t f = 0;
    if (e->nprops == 1 && is_index_list(e->props[0].name) && e->props[0].count_type->size == 1 &&
        e->props[0].type->size == 4 && !big && HOST_LE) {
        for (; f < nf && end - b >= 13 && b[0] == 3; f++, b += 13) {
            memcpy(raw->face_indices + ni, b + 1, 12);
            ni += 3;
        }
    }

    for (; f < nf; f++) {
        uint64_t corners = 0;
        const unsigned char *list = NULL;
        const ply_type *ity = NULL;
        for (int q = 0; q < e->nprops; q++) {
            const ply_prop *pr = &e->props[q];
            if (!pr->count_type) {
                if (end - b < pr->type->size) return truncated(ctx, path, e, f);
                b += pr->type->size;
                continue;
            }
            if (end - b < pr->count_type->size) return truncated(ctx, path, e, f);
            uint64_t c = rd_uint(b, pr->count_type->size, big);
            if (pr->count_type->is_signed && (c >> (8 * pr->count_type->size - 1)) & 1)
                return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': negative list length in %s %llu", path, e->name,
                                   (unsigned long long)f);
            b += pr->count_type->size;
            if ((uint64_t)(end - b) / (uint64_t)pr->type->size < c) return truncated(ctx, path, e, f);
            if (is_index_list(pr->name)) corners = c, list = b, ity = pr->type;
            b += c * (uint64_t)pr->type->size;
        }
        if (!ity) continue; /* ply_check_binary refuses this (no index list) */
        if (!grow_indices(raw, ni + (size_t)corners, &cap)) return oom(ctx, path);
        if (corners != 3 && !raw->face_sizes) {
            /* The first face that is not a triangle: from here on, sizes. */
            raw->face_sizes = malloc((nf ? nf : 1) * sizeof *raw->face_sizes);
            if (!raw->face_sizes) return oom(ctx, path);
            for (uint64_t g = 0; g < f; g++) raw->face_sizes[g] = 3;
        }
        if (raw->face_sizes) raw->face_sizes[f] = (uint32_t)corners;
        uint32_t *o = raw->face_indices + ni;
        for (uint64_t j = 0; j < corners; j++) o[j] = rd_int32(list + j * (uint64_t)ity->size, ity, big);
        ni += (size_t)corners;
    }
    raw->face_count = (size_t)nf;
    raw->index_count = ni;
    return CLVOX_OK;
}

/* Binary PLY body (little or big endian) into raw, as OpenMesh's reader
 * would hand it over. The header is parsed and the body walked
 * (ply_check_binary) before this is called. */
static clvox_status ply_read_binary(clvox_context *ctx, const char *path, const unsigned char *p, size_t n,
                                    const ply_header *h, clvox__raw_mesh *raw)
{
    memset(raw, 0, sizeof *raw);
    int big = h->format == PLY_BE;
    uint64_t pos = h->body;
    int last = h->face >= 0 ? h->face : h->nelems - 1;
    clvox_status st = CLVOX_OK;
    for (int ei = 0; ei <= last && !st; ei++) {
        const ply_elem *e = &h->elems[ei];
        if (ei == h->vertex) {
            st = read_vertices(ctx, path, p, n, &pos, e, big, raw);
        } else if (ei == h->face) {
            st = read_faces(ctx, path, p, n, pos, e, big, raw);
        } else {
            /* Skipped element: fixed-size records (lists are refused here). */
            uint64_t fixed = 0;
            for (int q = 0; q < e->nprops; q++) {
                if (e->props[q].count_type)
                    return clvox__fail(ctx, CLVOX_ERR_INTERNAL, "'%s': list in skipped PLY element", path);
                fixed += (uint64_t)e->props[q].type->size;
            }
            if (fixed && (n - pos) / fixed < e->count) st = truncated(ctx, path, e, 0);
            else pos += fixed * e->count;
        }
    }
    if (!st && !raw->face_indices) { /* no face element */
        raw->face_indices = malloc(sizeof *raw->face_indices);
        if (!raw->face_indices) st = oom(ctx, path);
    }
    if (st) clvox__raw_mesh_free(raw);
    return st;
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
            if (!clvox__parse_int(&a[2], &count) || count < 0 || count > (int64_t)UINT32_MAX || a[2].s[0] == '+')
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

/* ASCII body, token by token as OpenMesh reads it (operator>>). raw != NULL:
 * also read it (the native ASCII reader: x, y, z of type float as strtof
 * reads them, the last vertex_indices/vertex_index list of each face, as
 * OpenMesh's reader hands them over; the caller sets the C locale). */
static clvox_status ply_check_ascii(clvox_context *ctx, const char *path, const char *p, size_t n,
                                    const ply_header *h, clvox__raw_mesh *raw)
{
    clvox_status st = clvox__check_text(ctx, path, p + h->body, n - h->body, "PLY");
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
                    if (!clvox__parse_int(&k, &c) || c < 0 || c > (1 << 24))
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
                        if (slot && clvox__fast_decimal(&k, &d)) { /* a plain decimal: finite and below FLT_MAX */
                            if (!clvox__token_float(&k, slot)) goto oom;
                            continue;
                        }
                        int c = clvox__classify_float(&k);
                        if (c == NUM_NONFINITE)
                            return clvox__fail(ctx, CLVOX_ERR_MESH_INVALID,
                                               "'%s': non-finite %s '%.*s' at line %llu (%s %llu, property '%s')", path,
                                               coord ? "coordinate" : "value", tok_print_len(&k), k.s,
                                               (unsigned long long)k.line, e->name, (unsigned long long)r, pr->name);
                        if (c == NUM_BAD) goto not_a_number;
                        if (slot && !clvox__token_float(&k, slot)) goto oom;
                    } else {
                        int64_t v;
                        if (!clvox__parse_int(&k, &v)) goto not_a_number;
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

clvox_status clvox__mesh_check_ply(clvox_context *ctx, const char *path, const unsigned char *p, size_t n,
                                   clvox__mesh_expect *ex, clvox__raw_mesh *native, int *parsed)
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
            if (!(st = clvox__c_locale_begin(ctx, path, &c_locale, &old))) {
                st = ply_check_ascii(ctx, path, (const char *)p, n, h, native);
                clvox__c_locale_end(c_locale, old);
            }
            if (!st && !native->face_indices) { /* no face element */
                native->face_indices = malloc(sizeof *native->face_indices);
                if (!native->face_indices) st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", path);
            }
            st = clvox__text_read_done(st, native, parsed);
        } else {
            st = ply_check_ascii(ctx, path, (const char *)p, n, h, NULL);
        }
    } else if (!st) {
        st = ply_check_binary(ctx, path, p, n, h);
    }
    if (!st && h->format != PLY_ASCII && clvox__mesh_native_enabled()) {
        st = ply_read_binary(ctx, path, p, n, h, native);
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
