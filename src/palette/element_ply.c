/* SPDX-License-Identifier: Apache-2.0 */
/*
 * PLY export of a palette volume: every non-empty voxel (element != 0)
 * replaced by its element's mesh (element_mesh.c) scaled onto the voxel box,
 * in world coordinates. Used by `clvox mesh` (cli_mesh.c); design:
 * docs/design.md "Element geometry and mesh export".
 *
 * Bounded memory, two passes over the element channel. PLY puts the counts
 * in the header and all vertices before all faces, so pass 1 counts the
 * voxels of each element (and rejects values that are not indices of the
 * palette); then the counts, the header and the exact file size are known.
 * Every record has a fixed size (binary little-endian: 12-byte float32
 * vertices, 13-byte faces of a uchar count 3 and three int indices; ASCII:
 * 48-byte vertex lines "%+.8e %+.8e %+.8e\n", which round-trip float32, and
 * 35-byte face lines "3 %10u %10u %10u\n"), so in pass 2 the n-th vertex
 * and the n-th face have known offsets: both streams are written in the
 * same pass, each through its own buffer, to its region of the file
 * (write_at). Memory: the element meshes, two 1 MiB buffers, and the
 * caller's slice.
 *
 * Order: voxels in z, y, x order (x fastest), each voxel's vertices and
 * triangles in the order of its element mesh (piece by piece). Vertex
 * coordinates are origin + (i + u) * h per axis, in double, rounded once to
 * float: a voxel face at i + 1 gives the same float from both voxels.
 * Vertices are not shared between voxels or pieces, so each piece stays a
 * closed shell of its own (see element_mesh.c on touching shells).
 */
#include "core/internal.h"
#include "element_mesh.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define BUF_BYTES (1u << 20)
#define BIN_VERTEX 12u
#define BIN_FACE 13u
#define ASCII_VERTEX 48u /* 3 x 15 + 2 spaces + newline */
#define ASCII_FACE 35u   /* "3" + 3 x (space + 10 digits) + newline */
#define MAX_PLY_VERTICES 0x7FFFFFFFull /* int vertex indices */

typedef struct stream {
    unsigned char *buf;
    size_t len;
    uint64_t offset; /* file offset of buf[0] */
} stream;

struct clvox_ply_export { /* clvox__ply_export (element_mesh.h) */
    clvox_context *ctx;
    const clvox_palette *palette;
    size_t count;
    clvox__element_mesh *mesh; /* one per element */
    uint32_t dims[3];
    double origin[3], h[3];
    int ascii;
    uint64_t *voxels;          /* pass 1: voxels per element */
    unsigned char *counted;    /* pass 1: slice z counted */
    int have_totals;
    clvox__ply_totals totals;
    char header[1024];
    /* pass 2 */
    clvox__write_at_fn write_at;
    void *user;
    int begun;
    uint32_t next_z;
    uint64_t vertices, triangles, voxels_written;
    stream vs, fs;
};

void clvox__ply_export_destroy(clvox__ply_export *x)
{
    if (!x) return;
    for (size_t e = 0; x->mesh && e < x->count; e++) clvox__element_mesh_free(&x->mesh[e]);
    free(x->mesh);
    free(x->voxels);
    free(x->counted);
    free(x->vs.buf);
    free(x->fs.buf);
    free(x);
}

clvox_status clvox__ply_export_create(clvox_context *ctx, const clvox_palette *palette, const uint32_t dims[3],
                                      const double origin[3], const double voxel_size[3], int ascii,
                                      clvox__ply_export **out)
{
    if (!out) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox__ply_export_create: out is NULL");
    *out = NULL;
    if (!palette || !dims || !origin || !voxel_size)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox__ply_export_create: NULL argument");
    for (int a = 0; a < 3; a++) {
        if (dims[a] == 0 || dims[a] > CLVOX_MAX_AXIS)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "mesh export: %u voxels on axis %c", dims[a], "xyz"[a]);
        double lo = origin[a], hi = origin[a] + (double)dims[a] * voxel_size[a];
        if (!(voxel_size[a] > 0) || !isfinite(lo) || !isfinite(hi) || fabs(lo) > FLT_MAX || fabs(hi) > FLT_MAX)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT,
                               "mesh export: the grid on axis %c (origin %.6g, voxel size %.6g) does not fit in "
                               "float32 coordinates",
                               "xyz"[a], origin[a], voxel_size[a]);
    }
    clvox__ply_export *x = calloc(1, sizeof *x);
    if (!x) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "mesh export: out of memory");
    x->ctx = ctx;
    x->palette = palette;
    x->count = clvox_palette_count(palette);
    x->ascii = ascii ? 1 : 0;
    for (int a = 0; a < 3; a++) {
        x->dims[a] = dims[a];
        x->origin[a] = origin[a];
        x->h[a] = voxel_size[a];
    }
    x->mesh = calloc(x->count ? x->count : 1, sizeof *x->mesh);
    x->voxels = calloc(x->count ? x->count : 1, sizeof *x->voxels);
    x->counted = calloc(dims[2], 1);
    x->vs.buf = malloc(BUF_BYTES);
    x->fs.buf = malloc(BUF_BYTES);
    if (!x->mesh || !x->voxels || !x->counted || !x->vs.buf || !x->fs.buf) {
        clvox__ply_export_destroy(x);
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "mesh export: out of memory");
    }
    for (size_t e = 0; e < x->count; e++) {
        clvox_status st = clvox__element_mesh_build(ctx, palette, e, &x->mesh[e]);
        if (st != CLVOX_OK) {
            clvox__ply_export_destroy(x);
            return st;
        }
    }
    *out = x;
    return CLVOX_OK;
}

/* The element index at slice position i (y * X + x) of slice z, checked. */
static clvox_status element_at(clvox__ply_export *x, uint32_t z, const float *element, size_t i, uint32_t *e)
{
    float v = element[i];
    if (v >= 0.0f && v < (float)x->count && v == floorf(v)) {
        *e = (uint32_t)v;
        return CLVOX_OK;
    }
    return clvox__fail(x->ctx, CLVOX_ERR_EXR,
                       "voxel (%zu, %zu, %u) has element %.9g, not an index of palette '%s' (%zu elements)",
                       i % x->dims[0], i / x->dims[0], z, (double)v, clvox_palette_name(x->palette), x->count);
}

clvox_status clvox__ply_export_count(clvox__ply_export *x, uint32_t z, const float *element)
{
    if (!x || !element) return CLVOX_ERR_INVALID_ARGUMENT;
    if (x->begun || x->have_totals)
        return clvox__fail(x->ctx, CLVOX_ERR_INVALID_ARGUMENT, "mesh export: counting after the totals");
    if (z >= x->dims[2] || x->counted[z])
        return clvox__fail(x->ctx, CLVOX_ERR_INVALID_ARGUMENT, "mesh export: slice %u counted twice or out of range", z);
    size_t n = (size_t)x->dims[0] * x->dims[1];
    for (size_t i = 0; i < n; i++) {
        uint32_t e;
        clvox_status st = element_at(x, z, element, i, &e);
        if (st != CLVOX_OK) return st;
        x->voxels[e]++;
    }
    x->counted[z] = 1;
    return CLVOX_OK;
}

/* Printable, blank-free text for a header comment. */
static void header_safe(const char *in, char *out, size_t size)
{
    size_t n = 0;
    for (; in && in[n] && n + 1 < size; n++) {
        unsigned char c = (unsigned char)in[n];
        out[n] = c > 0x20 && c < 0x7f ? (char)c : '_';
    }
    out[n] = '\0';
}

clvox_status clvox__ply_export_totals(clvox__ply_export *x, clvox__ply_totals *t)
{
    if (!x || !t) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!x->have_totals) {
        for (uint32_t z = 0; z < x->dims[2]; z++)
            if (!x->counted[z])
                return clvox__fail(x->ctx, CLVOX_ERR_INVALID_ARGUMENT, "mesh export: slice %u was not counted", z);
        clvox__ply_totals s;
        memset(&s, 0, sizeof s);
        for (size_t e = 1; e < x->count; e++) {
            s.voxels += x->voxels[e];
            s.vertices += x->voxels[e] * x->mesh[e].vertex_count; /* <= 2^40 voxels x a few thousand */
            s.triangles += x->voxels[e] * x->mesh[e].triangle_count;
        }
        if (s.vertices > MAX_PLY_VERTICES)
            return clvox__fail(x->ctx, CLVOX_ERR_INVALID_ARGUMENT,
                               "the mesh would have %llu vertices, more than PLY's int vertex indices can address "
                               "(%llu)",
                               (unsigned long long)s.vertices, MAX_PLY_VERTICES);
        char name[80];
        header_safe(clvox_palette_name(x->palette), name, sizeof name);
        int n = snprintf(x->header, sizeof x->header,
                         "ply\nformat %s 1.0\n"
                         "comment clvox %s palette mesh: palette %s (%zu elements), %llu voxels\n"
                         "comment grid %u x %u x %u voxels, origin %.17g %.17g %.17g, voxel size %.17g %.17g %.17g\n"
                         "element vertex %llu\nproperty float x\nproperty float y\nproperty float z\n"
                         "element face %llu\nproperty list uchar int vertex_indices\nend_header\n",
                         x->ascii ? "ascii" : "binary_little_endian", CLVOX_VERSION_STRING, name, x->count,
                         (unsigned long long)s.voxels, x->dims[0], x->dims[1], x->dims[2], x->origin[0], x->origin[1],
                         x->origin[2], x->h[0], x->h[1], x->h[2], (unsigned long long)s.vertices,
                         (unsigned long long)s.triangles);
        if (n < 0 || (size_t)n >= sizeof x->header)
            return clvox__fail(x->ctx, CLVOX_ERR_INTERNAL, "mesh export: PLY header too long");
        s.header_bytes = (uint64_t)n;
        uint64_t rv = x->ascii ? ASCII_VERTEX : BIN_VERTEX, rf = x->ascii ? ASCII_FACE : BIN_FACE;
        s.bytes = s.header_bytes + s.vertices * rv + s.triangles * rf;
        x->totals = s;
        x->have_totals = 1;
    }
    *t = x->totals;
    return CLVOX_OK;
}

static clvox_status flush(clvox__ply_export *x, stream *s)
{
    if (!s->len) return CLVOX_OK;
    int err = x->write_at(x->user, s->offset, s->buf, s->len);
    if (err) return clvox__fail(x->ctx, CLVOX_ERR_IO, "writing the mesh failed: %s", strerror(err));
    s->offset += s->len;
    s->len = 0;
    return CLVOX_OK;
}

clvox_status clvox__ply_export_begin(clvox__ply_export *x, clvox__write_at_fn write_at, void *user)
{
    if (!x || !write_at) return CLVOX_ERR_INVALID_ARGUMENT;
    if (x->begun) return clvox__fail(x->ctx, CLVOX_ERR_INVALID_ARGUMENT, "mesh export: begun twice");
    clvox__ply_totals t;
    clvox_status st = clvox__ply_export_totals(x, &t);
    if (st != CLVOX_OK) return st;
    x->write_at = write_at;
    x->user = user;
    x->begun = 1;
    x->vs.len = x->fs.len = 0;
    x->vs.offset = t.header_bytes;
    x->fs.offset = t.header_bytes + t.vertices * (x->ascii ? ASCII_VERTEX : BIN_VERTEX);
    int err = write_at(user, 0, x->header, (size_t)t.header_bytes);
    if (err) return clvox__fail(x->ctx, CLVOX_ERR_IO, "writing the mesh failed: %s", strerror(err));
    return CLVOX_OK;
}

static void put_le32(unsigned char *b, uint32_t u)
{
    b[0] = (unsigned char)(u & 0xFFu);
    b[1] = (unsigned char)((u >> 8) & 0xFFu);
    b[2] = (unsigned char)((u >> 16) & 0xFFu);
    b[3] = (unsigned char)(u >> 24);
}

/* Room for one record of `size` bytes in s (flushing it when full). */
static clvox_status room(clvox__ply_export *x, stream *s, size_t size, unsigned char **at)
{
    if (s->len + size > BUF_BYTES) {
        clvox_status st = flush(x, s);
        if (st != CLVOX_OK) return st;
    }
    *at = s->buf + s->len;
    s->len += size;
    return CLVOX_OK;
}

static clvox_status put_voxel(clvox__ply_export *x, uint32_t i, uint32_t j, uint32_t k, const clvox__element_mesh *m)
{
    if (x->vertices + m->vertex_count > x->totals.vertices || x->triangles + m->triangle_count > x->totals.triangles)
        return clvox__fail(x->ctx, CLVOX_ERR_IO, "the volume changed while it was read (more voxels than counted)");
    uint64_t base = x->vertices;
    const double cell[3] = {(double)i, (double)j, (double)k};
    clvox_status st = CLVOX_OK;
    for (size_t v = 0; v < m->vertex_count && st == CLVOX_OK; v++) {
        float f[3];
        for (int a = 0; a < 3; a++) f[a] = (float)(x->origin[a] + (cell[a] + m->xyz[3 * v + a]) * x->h[a]);
        unsigned char *b;
        if ((st = room(x, &x->vs, x->ascii ? ASCII_VERTEX : BIN_VERTEX, &b)) != CLVOX_OK) break;
        if (x->ascii) {
            char line[ASCII_VERTEX + 16];
            int n = snprintf(line, sizeof line, "%+.8e %+.8e %+.8e\n", (double)f[0], (double)f[1], (double)f[2]);
            if (n != (int)ASCII_VERTEX) return clvox__fail(x->ctx, CLVOX_ERR_INTERNAL, "mesh export: vertex record");
            memcpy(b, line, ASCII_VERTEX);
        } else {
            for (int a = 0; a < 3; a++) {
                uint32_t u;
                memcpy(&u, &f[a], sizeof u);
                put_le32(b + 4 * a, u);
            }
        }
    }
    for (size_t t = 0; t < m->triangle_count && st == CLVOX_OK; t++) {
        unsigned char *b;
        if ((st = room(x, &x->fs, x->ascii ? ASCII_FACE : BIN_FACE, &b)) != CLVOX_OK) break;
        uint32_t idx[3];
        for (int c = 0; c < 3; c++) idx[c] = (uint32_t)(base + m->tris[3 * t + c]); /* < 2^31: checked */
        if (x->ascii) {
            char line[ASCII_FACE + 16];
            int n = snprintf(line, sizeof line, "3 %10u %10u %10u\n", (unsigned)idx[0], (unsigned)idx[1],
                             (unsigned)idx[2]);
            if (n != (int)ASCII_FACE) return clvox__fail(x->ctx, CLVOX_ERR_INTERNAL, "mesh export: face record");
            memcpy(b, line, ASCII_FACE);
        } else {
            b[0] = 3;
            for (int c = 0; c < 3; c++) put_le32(b + 1 + 4 * c, idx[c]);
        }
    }
    x->vertices += m->vertex_count;
    x->triangles += m->triangle_count;
    x->voxels_written++;
    return st;
}

clvox_status clvox__ply_export_slice(clvox__ply_export *x, uint32_t z, const float *element)
{
    if (!x || !element) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!x->begun) return clvox__fail(x->ctx, CLVOX_ERR_INVALID_ARGUMENT, "mesh export: slice before begin");
    if (z != x->next_z)
        return clvox__fail(x->ctx, CLVOX_ERR_INVALID_ARGUMENT, "mesh export: slice %u, expected slice %u", z, x->next_z);
    uint32_t X = x->dims[0], Y = x->dims[1];
    for (uint32_t j = 0; j < Y; j++)
        for (uint32_t i = 0; i < X; i++) {
            uint32_t e;
            clvox_status st = element_at(x, z, element, (size_t)j * X + i, &e);
            if (st == CLVOX_OK && e != 0) st = put_voxel(x, i, j, z, &x->mesh[e]);
            if (st != CLVOX_OK) return st;
        }
    x->next_z++;
    return CLVOX_OK;
}

clvox_status clvox__ply_export_finish(clvox__ply_export *x)
{
    if (!x) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!x->begun) return clvox__fail(x->ctx, CLVOX_ERR_INVALID_ARGUMENT, "mesh export: finish before begin");
    if (x->next_z != x->dims[2])
        return clvox__fail(x->ctx, CLVOX_ERR_INVALID_ARGUMENT, "mesh export: %u of %u slices written", x->next_z,
                           x->dims[2]);
    if (x->vertices != x->totals.vertices || x->triangles != x->totals.triangles)
        return clvox__fail(x->ctx, CLVOX_ERR_IO, "the volume changed while it was read (fewer voxels than counted)");
    clvox_status st = flush(x, &x->vs);
    if (st == CLVOX_OK) st = flush(x, &x->fs);
    return st;
}

/* ---- the public names (clvox.h), for the command line and other callers ---- */

clvox_status clvox_ply_export_create(clvox_context *ctx, const clvox_palette *palette, const uint32_t dims[3],
                                     const double origin[3], const double voxel_size[3], int ascii,
                                     clvox_ply_export **out)
{
    return clvox__ply_export_create(ctx, palette, dims, origin, voxel_size, ascii, out);
}

void clvox_ply_export_destroy(clvox_ply_export *x) { clvox__ply_export_destroy(x); }

clvox_status clvox_ply_export_count(clvox_ply_export *x, uint32_t z, const float *element)
{
    return clvox__ply_export_count(x, z, element);
}

clvox_status clvox_ply_export_totals(clvox_ply_export *x, clvox_ply_totals *totals)
{
    if (!x) return CLVOX_ERR_INVALID_ARGUMENT;
    clvox_ply_totals full = CLVOX_PLY_TOTALS_INIT;
    clvox_status st = clvox__out_begin(x->ctx, totals, sizeof full, CLVOX__PLY_TOTALS_SIZE_0, "clvox_ply_totals");
    if (st != CLVOX_OK) return st;
    st = clvox__ply_export_totals(x, &full);
    if (st == CLVOX_OK) {
        full.size = sizeof full;
        clvox__out_end(totals, &full);
    }
    return st;
}

clvox_status clvox_ply_export_begin(clvox_ply_export *x, clvox_write_at_fn write_at, void *user)
{
    return clvox__ply_export_begin(x, write_at, user);
}

clvox_status clvox_ply_export_slice(clvox_ply_export *x, uint32_t z, const float *element)
{
    return clvox__ply_export_slice(x, z, element);
}

clvox_status clvox_ply_export_finish(clvox_ply_export *x) { return clvox__ply_export_finish(x); }
