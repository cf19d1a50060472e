/* SPDX-License-Identifier: Apache-2.0 */
/* Native binary PLY reader (little and big endian).
 *
 * mesh.c parses the header strictly and walks the body record by record
 * (ply_check_binary) before this runs, so every record is known to be inside
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
 *     index becomes >= 2^31, out of range, reported by build_mesh); other
 *     face properties (texcoord lists, flags) are skipped by size.
 * Faces with other than 3 corners are kept with their size; build_mesh drops
 * the short ones and fans polygons exactly as for the other readers.
 * While every face is a triangle, no face_sizes array is made (NULL: all
 * triangles), and build_mesh turns the index array into the triangle array
 * in place: one copy of the vertices and one of the indices. */
#include "mesh_internal.h"

#include <stdlib.h>
#include <string.h>

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

clvox_status clvox__ply_read_binary(clvox_context *ctx, const char *path, const unsigned char *p, size_t n,
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
