/* SPDX-License-Identifier: Apache-2.0 */
/*
 * clvox_volume_to_mesh: a volume's surface (surface_extract.c) written as
 * PLY, OBJ or STL (docs/design.md "Meshes from volumes").
 *
 * The volume is read only through the public clvox_volume_read_slices, so
 * every format that reader accepts works here. The file is written without
 * a name (clvox_output_file_*) and named only when complete.
 *  - PLY: two passes. The first counts vertices and triangles, which fixes
 *    the header and where the face list starts; the second writes the
 *    vertices and the faces, interleaved as they are made, each at its known
 *    offset (binary records, or fixed-width ASCII records). Memory stays
 *    that of the extraction and two write buffers.
 *  - OBJ: one pass, "v" and "f" lines interleaved (every face after its
 *    vertices; 1-based indices).
 *  - STL: one pass, binary (the triangle count written at the end) or ASCII;
 *    STL has no shared vertices.
 */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include "mesh_out/surface_extract.h"

#include "core/internal.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#define SURFACE_TOTALS_SIZE_0 (offsetof(clvox_surface_totals, bytes) + sizeof(uint64_t))
#define STREAM_BUF (1u << 16)

typedef enum mesh_format { FMT_PLY, FMT_OBJ, FMT_STL } mesh_format;

typedef struct stream {
    uint64_t off; /* file offset of buf[0] */
    size_t used;
    char buf[STREAM_BUF];
} stream;

typedef struct writer {
    int fd;
    int err;          /* first errno */
    mesh_format fmt;
    int ascii;
    stream *v, *f;    /* PLY: vertex and face regions; else f only */
    uint64_t nv;      /* vertices written (OBJ: numbering) */
    uint64_t nt;
    uint64_t end;     /* highest byte written + 1 */
} writer;

const char *clvox_surface_kind_name(clvox_surface_kind kind)
{
    switch (kind) {
    case CLVOX_SURFACE_AUTO: return "auto";
    case CLVOX_SURFACE_FACES: return "faces";
    case CLVOX_SURFACE_SMOOTH: return "smooth";
    default: return "?";
    }
}

static int write_all_at(int fd, uint64_t off, const char *b, size_t n)
{
    while (n) {
        ssize_t k = pwrite(fd, b, n, (off_t)off);
        if (k < 0) {
            if (errno == EINTR) continue;
            return errno ? errno : EIO;
        }
        if (k == 0) return EIO;
        b += k;
        n -= (size_t)k;
        off += (uint64_t)k;
    }
    return 0;
}

static int flush(writer *w, stream *s)
{
    if (!w->err && s->used) w->err = write_all_at(w->fd, s->off, s->buf, s->used);
    if (s->off + s->used > w->end) w->end = s->off + s->used;
    s->off += s->used;
    s->used = 0;
    return w->err;
}

static int put(writer *w, stream *s, const void *data, size_t n)
{
    if (w->err) return w->err;
    if (s->used + n > sizeof s->buf && flush(w, s)) return w->err;
    memcpy(s->buf + s->used, data, n);
    s->used += n;
    return 0;
}

static int putf(writer *w, stream *s, const char *fmt, ...) CLVOX__PRINTF(3, 4);
static int putf(writer *w, stream *s, const char *fmt, ...)
{
    char line[512];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    if (n < 0 || (size_t)n >= sizeof line) return w->err = EOVERFLOW;
    return put(w, s, line, (size_t)n);
}

static void le32(unsigned char *p, uint32_t x)
{
    p[0] = (unsigned char)x;
    p[1] = (unsigned char)(x >> 8);
    p[2] = (unsigned char)(x >> 16);
    p[3] = (unsigned char)(x >> 24);
}

static void lef(unsigned char *p, double x)
{
    float f = (float)x;
    uint32_t u;
    memcpy(&u, &f, 4);
    le32(p, u);
}

/* ASCII PLY vertex records have a fixed width, so that pass 2 knows where
 * the faces begin: 3 x "%+.8e" of a float (always a 2-digit exponent). */
#define PLY_ASCII_VERTEX 48

static int on_vertex(void *user, const double xyz[3])
{
    writer *w = user;
    w->nv++;
    if (w->fmt == FMT_OBJ) return putf(w, w->f, "v %.9g %.9g %.9g\n", (float)xyz[0], (float)xyz[1], (float)xyz[2]);
    if (!w->ascii) {
        unsigned char b[12];
        for (int a = 0; a < 3; a++) lef(b + 4 * a, xyz[a]);
        return put(w, w->v, b, sizeof b);
    }
    char line[64];
    int n = snprintf(line, sizeof line, "%+.8e %+.8e %+.8e\n", (double)(float)xyz[0], (double)(float)xyz[1],
                     (double)(float)xyz[2]);
    if (n != PLY_ASCII_VERTEX) return w->err = EOVERFLOW;
    return put(w, w->v, line, (size_t)n);
}

static int on_triangle(void *user, const uint64_t v[3], const double p[9])
{
    writer *w = user;
    w->nt++;
    if (w->fmt == FMT_OBJ)
        return putf(w, w->f, "f %llu %llu %llu\n", (unsigned long long)v[0] + 1, (unsigned long long)v[1] + 1,
                    (unsigned long long)v[2] + 1);
    if (w->fmt == FMT_PLY) {
        if (w->ascii)
            return putf(w, w->f, "3 %10u %10u %10u\n", (unsigned)v[0], (unsigned)v[1], (unsigned)v[2]);
        unsigned char b[13];
        b[0] = 3;
        for (int i = 0; i < 3; i++) le32(b + 1 + 4 * i, (uint32_t)v[i]);
        return put(w, w->f, b, sizeof b);
    }
    /* STL: the facet normal from the float vertices */
    float q[9];
    for (int i = 0; i < 9; i++) q[i] = (float)p[i];
    double e1[3], e2[3], n[3];
    for (int a = 0; a < 3; a++) {
        e1[a] = (double)q[3 + a] - q[a];
        e2[a] = (double)q[6 + a] - q[a];
    }
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int a = 0; a < 3; a++) n[a] = len > 0 ? n[a] / len : 0.0;
    if (w->ascii)
        return putf(w, w->f,
                    "  facet normal %.9g %.9g %.9g\n    outer loop\n      vertex %.9g %.9g %.9g\n      vertex %.9g %.9g "
                    "%.9g\n      vertex %.9g %.9g %.9g\n    endloop\n  endfacet\n",
                    n[0], n[1], n[2], q[0], q[1], q[2], q[3], q[4], q[5], q[6], q[7], q[8]);
    unsigned char b[50];
    for (int a = 0; a < 3; a++) lef(b + 4 * a, n[a]);
    for (int i = 0; i < 9; i++) lef(b + 12 + 4 * i, q[i]);
    b[48] = b[49] = 0;
    return put(w, w->f, b, sizeof b);
}

/* ---- reading ---------------------------------------------------------------- */

typedef struct feed {
    clvox__surface *s;
    clvox_status st;
    char why[1024];
    const clvox_context *ctx;
} feed;

static int on_slice(void *user, uint32_t z, const float *values)
{
    feed *f = user;
    f->st = clvox__surface_slice(f->s, z, values);
    if (f->st == CLVOX_OK) return 0;
    snprintf(f->why, sizeof f->why, "%s", clvox_context_error(f->ctx));
    return 1;
}

static int stop_at_first(void *user, uint32_t z, const float *values)
{
    (void)user;
    (void)z;
    (void)values;
    return 1;
}

static int list_has(const char *list, const char *name)
{
    size_t n = strlen(name);
    for (const char *p = list; *p;) {
        const char *e = strchr(p, ',');
        size_t len = e ? (size_t)(e - p) : strlen(p);
        if (len == n && strncmp(p, name, n) == 0) return 1;
        if (!e) break;
        p = e + 1;
    }
    return 0;
}

/* One pass over the volume's channel through a new extractor. */
static clvox_status run_pass(clvox_context *ctx, const char *path, const char *channel, int smooth, float iso,
                             const clvox_volume_info *want, const clvox__surface_sink *sink, clvox__surface_counts *out)
{
    clvox__surface *s = NULL;
    clvox_status st = clvox__surface_create(ctx, smooth, want->dims, want->origin, want->voxel_size, iso, sink, &s);
    if (st != CLVOX_OK) return st;
    feed f = {s, CLVOX_OK, "", ctx};
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    st = clvox_volume_read_slices(ctx, path, channel, &info, on_slice, &f);
    if (f.st != CLVOX_OK) st = clvox__fail(ctx, f.st, "%s", f.why);
    else if (st == CLVOX_OK && memcmp(info.dims, want->dims, sizeof info.dims) != 0)
        st = clvox__fail(ctx, CLVOX_ERR_IO, "'%s' changed while it was read", path);
    if (st == CLVOX_OK) st = clvox__surface_finish(s);
    if (st == CLVOX_OK) clvox__surface_get_counts(s, out);
    clvox__surface_destroy(s);
    return st;
}

static int mesh_format_of(const char *path, mesh_format *f)
{
    const char *slash = strrchr(path, '/');
    const char *dot = strrchr(slash ? slash + 1 : path, '.');
    if (!dot) return 0;
    if (strcasecmp(dot, ".ply") == 0) *f = FMT_PLY;
    else if (strcasecmp(dot, ".obj") == 0) *f = FMT_OBJ;
    else if (strcasecmp(dot, ".stl") == 0) *f = FMT_STL;
    else return 0;
    return 1;
}

static clvox_status write_failed(clvox_context *ctx, const char *mesh, int err)
{
    return clvox__fail(ctx, CLVOX_ERR_IO, "writing '%s' failed: %s", mesh, strerror(err));
}

static clvox_status to_mesh(clvox_context *ctx, const char *volume, const char *mesh, const clvox_surface_options *o,
                            clvox_surface_totals *t)
{
    mesh_format fmt;
    if (!mesh_format_of(mesh, &fmt))
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "'%s': unknown mesh extension (use .ply, .obj or .stl)",
                           mesh);
    if ((unsigned)o->kind >= CLVOX_SURFACE_KIND_COUNT)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_volume_to_mesh: bad surface kind %d", (int)o->kind);
    double iso = o->iso_set ? o->iso : 0.5;
    if (!isfinite(iso) || fabs(iso) > 1e30)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_volume_to_mesh: bad iso value %g", iso);

    /* the header, and which channels there are */
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    clvox_status st = clvox_volume_read_slices(ctx, volume, o->channel ? o->channel : "occupancy", &info,
                                               stop_at_first, NULL);
    if (st != CLVOX_OK && st != CLVOX_ERR_CANCELLED && (o->channel || !info.channels[0] || !info.dims[0])) return st;
    const char *channel = o->channel;
    if (!channel) {
        int cov = list_has(info.channels, "coverage"), occ = list_has(info.channels, "occupancy");
        if (cov && o->kind != CLVOX_SURFACE_FACES) channel = "coverage";
        else if (occ) channel = "occupancy";
        else if (cov) channel = "coverage";
        else if (list_has(info.channels, "element")) channel = "element";
        else
            return clvox__fail(ctx, CLVOX_ERR_EXR,
                               "'%s' has no channel \"occupancy\", \"coverage\" or \"element\" (has: %s)", volume,
                               info.channels);
    }
    int smooth = o->kind == CLVOX_SURFACE_SMOOTH || (o->kind == CLVOX_SURFACE_AUTO && strcmp(channel, "coverage") == 0);
    snprintf(t->channel, sizeof t->channel, "%s", channel);
    t->kind = smooth ? CLVOX_SURFACE_SMOOTH : CLVOX_SURFACE_FACES;
    memcpy(t->dims, info.dims, sizeof t->dims);

    writer *w = calloc(1, sizeof *w);
    stream *sv = malloc(sizeof *sv), *sf = malloc(sizeof *sf);
    clvox_output_file *of = NULL;
    if (!w || !sv || !sf) {
        st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
        goto done;
    }
    sv->off = sv->used = sf->off = sf->used = 0;
    w->fmt = fmt;
    w->ascii = fmt == FMT_OBJ ? 1 : o->ascii;
    w->v = sv;
    w->f = sf;
    clvox__surface_counts c1, c2;
    if (fmt == FMT_PLY) { /* pass 1: the counts */
        st = run_pass(ctx, volume, channel, smooth, (float)iso, &info, NULL, &c1);
        if (st != CLVOX_OK) goto done;
        if (c1.vertices > INT32_MAX || c1.triangles > INT32_MAX) {
            st = clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT,
                             "the mesh of '%s' has %llu vertices and %llu triangles: too many for PLY's int indices "
                             "(write .obj or .stl)",
                             volume, (unsigned long long)c1.vertices, (unsigned long long)c1.triangles);
            goto done;
        }
    }
    st = clvox_output_file_create(ctx, mesh, &of);
    if (st != CLVOX_OK) goto done;
    w->fd = clvox_output_file_fd(of);
    char what[160];
    snprintf(what, sizeof what, "%s of channel %s", smooth ? "marching cubes" : "voxel faces", channel);
    if (smooth) snprintf(what + strlen(what), sizeof what - strlen(what), " at %.9g", iso);
    if (fmt == FMT_PLY) {
        putf(w, sf,
             "ply\nformat %s 1.0\ncomment clvox %s mesh: %s\nelement vertex %llu\nproperty float x\nproperty float "
             "y\nproperty float z\nelement face %llu\nproperty list uchar int vertex_indices\nend_header\n",
             w->ascii ? "ascii" : "binary_little_endian", CLVOX_VERSION_STRING, what,
             (unsigned long long)c1.vertices, (unsigned long long)c1.triangles);
        uint64_t header = sf->used;
        sv->off = header;
        flush(w, sf);
        sf->off = header + c1.vertices * (w->ascii ? PLY_ASCII_VERTEX : 12);
    } else if (fmt == FMT_OBJ) {
        putf(w, sf, "# clvox %s mesh: %s\n", CLVOX_VERSION_STRING, what);
    } else if (w->ascii) {
        putf(w, sf, "solid clvox\n");
    } else {
        char head[84];
        memset(head, 0, sizeof head);
        snprintf(head, 80, "clvox %.8s mesh: %.60s", CLVOX_VERSION_STRING, what); /* binary: never "solid" */
        put(w, sf, head, sizeof head);
    }
    clvox__surface_sink sink = {w, fmt == FMT_STL ? NULL : on_vertex, on_triangle};
    st = run_pass(ctx, volume, channel, smooth, (float)iso, &info, &sink, &c2);
    if (w->err) {
        st = write_failed(ctx, mesh, w->err);
        goto done;
    }
    if (st != CLVOX_OK) goto done;
    if (fmt == FMT_PLY && (c2.vertices != c1.vertices || c2.triangles != c1.triangles)) {
        st = clvox__fail(ctx, CLVOX_ERR_IO, "'%s' changed while it was read", volume);
        goto done;
    }
    if (fmt == FMT_STL && w->ascii) putf(w, sf, "endsolid clvox\n");
    flush(w, sv);
    flush(w, sf);
    if (fmt == FMT_STL && !w->ascii && !w->err) {
        if (c2.triangles > UINT32_MAX) {
            st = clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "the mesh of '%s' has %llu triangles: too many for STL",
                             volume, (unsigned long long)c2.triangles);
            goto done;
        }
        unsigned char n[4];
        le32(n, (uint32_t)c2.triangles);
        w->err = write_all_at(w->fd, 80, (const char *)n, 4);
    }
    if (w->err) {
        st = write_failed(ctx, mesh, w->err);
        goto done;
    }
    st = clvox_output_file_commit(of, &t->bytes);
    of = NULL;
    if (st != CLVOX_OK) goto done;
    t->inside_voxels = c2.inside_voxels;
    t->value_sum = c2.value_sum;
    t->vertices = c2.vertices;
    t->triangles = c2.triangles;
    t->enclosed_volume = c2.enclosed_volume;
done:
    clvox_output_file_discard(of);
    free(sv);
    free(sf);
    free(w);
    return st;
}

clvox_status clvox_volume_to_mesh(clvox_context *ctx, const char *volume, const char *mesh,
                                  const clvox_surface_options *options, clvox_surface_totals *totals)
{
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!volume || !*volume || !mesh || !*mesh)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_volume_to_mesh: no volume or mesh path");
    clvox_surface_options o = CLVOX_SURFACE_OPTIONS_INIT;
    if (options) {
        if (options->size < sizeof(size_t) || options->size > sizeof o)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_surface_options.size is %zu", options->size);
        memcpy(&o, options, options->size);
    }
    clvox_status st = clvox__out_begin(ctx, totals, sizeof(clvox_surface_totals), SURFACE_TOTALS_SIZE_0,
                                       "clvox_surface_totals");
    if (st != CLVOX_OK) return st;
    clvox_surface_totals full = CLVOX_SURFACE_TOTALS_INIT;
    st = to_mesh(ctx, volume, mesh, &o, &full);
    clvox__out_end(totals, &full);
    return st;
}
