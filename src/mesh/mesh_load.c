/* SPDX-License-Identifier: Apache-2.0 */
/* Mesh stage, loading: the public API, the file read whole, its format told
 * by the extension, checked by the per-format code, then read natively or
 * by OpenMesh, and the mesh built (mesh_build.c).
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
 * Where: mesh_stl.c, mesh_off.c, mesh_obj.c, mesh_ply.c, mesh_om.c (a file
 * a format, checks and native readers), mesh_scan.c (tokens and numbers as
 * operator>> reads them), mesh_build.c (validation common to files and
 * arrays, fan triangulation), mesh_report.c (the report). */
#include "mesh_internal.h"
#include "winding/winding.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* ---- format (by extension) ------------------------------------------------------ */

enum mesh_format { FMT_UNKNOWN = 0, FMT_OBJ, FMT_OFF, FMT_PLY, FMT_STL, FMT_OM, FMT_ASSIMP };
static const char *const format_name[] = {"", "obj", "off", "ply", "stl", "om", "assimp"};

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
    return clvox__assimp_supports(dot + 1) ? FMT_ASSIMP : FMT_UNKNOWN;
}

int clvox__is_mesh_path(const char *path)
{
    const char *ext;
    return path && format_of(path, &ext) != FMT_UNKNOWN;
}

void clvox__raw_mesh_free(clvox__raw_mesh *raw)
{
    if (!raw) return;
    free(raw->xyz);
    free(raw->face_sizes);
    free(raw->face_indices);
    free(raw->face_source);
    memset(raw, 0, sizeof *raw);
}

/* ---- public API ----------------------------------------------------------------- */

/* Binary PLY and binary STL are read natively (mesh_ply.c, mesh_stl.c);
 * CLVOX_MESH_READER=openmesh sends them to OpenMesh as before. For tests,
 * which compare the two bit for bit; not a user setting. */
int clvox__mesh_native_enabled(void)
{
    return !clvox__hooks()->mesh_reader_openmesh;
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

/* Everything clvox_mesh_load does before clvox__mesh_build: open, check, read
 * (natively, through OpenMesh or through Assimp) into *raw (freed on
 * failure). */
static clvox_status read_raw(clvox_context *ctx, const char *path, clvox__raw_mesh *out_raw)
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
                           "'%s': unknown extension '%s' (expected .obj, .off, .ply, .stl, .om, or a format "
                           "Assimp reads: .glb, .gltf, .3mf, .fbx, .dae, .3ds, ...)",
                           path, ext);
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

    clvox__mesh_expect ex;
    memset(&ex, 0, sizeof ex);
    clvox__raw_mesh raw;
    memset(&raw, 0, sizeof raw);
    int parsed = 0; /* read here, not by OpenMesh (OBJ, ASCII OFF) */
    const unsigned char *p = data;
    switch (fmt) {
    case FMT_OBJ: st = clvox__mesh_check_obj(ctx, path, (const char *)p, n, &raw, &parsed); break;
    case FMT_OFF: st = clvox__mesh_check_off(ctx, path, p, n, &ex, &raw, &parsed); break;
    case FMT_PLY: st = clvox__mesh_check_ply(ctx, path, p, n, &ex, &raw, &parsed); break;
    case FMT_STL: st = clvox__mesh_check_stl(ctx, path, p, n, &raw, &parsed); break;
    case FMT_OM: st = clvox__mesh_check_om(ctx, path, p, n); break;
    case FMT_ASSIMP: {
        /* Assimp parses the bytes just read (the file cannot change under
         * it), in a child process (mesh_isolate.c: it aborts on some bad
         * files); a .gltf's buffers are opened beside it. */
        char err[512];
        err[0] = 0;
        int rc = clvox__assimp_read_isolated(path, ext, p, n, &raw, err, sizeof err);
        if (rc == -2) st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "cannot read '%s': %s", path, err);
        else if (rc != 0) st = clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "cannot read '%s': %s", path, err);
        else parsed = 1;
        break;
    }
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
    if (!raw.source.size) {
        raw.source.size = sizeof raw.source;
        snprintf(raw.source.reader, sizeof raw.source.reader, "%s", format_name[fmt]);
        raw.source.meshes = 1;
        raw.source.placements = 1;
    }
    *out_raw = raw;
    return CLVOX_OK;
}

clvox_status clvox__mesh_read_raw(clvox_context *ctx, const char *path, clvox__raw_mesh *out_raw)
{
    return read_raw(ctx, path, out_raw);
}

clvox_status clvox_mesh_load(clvox_context *ctx, const char *path, clvox_mesh **out)
{
    if (out) *out = NULL;
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!path || !out)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_mesh_load: NULL %s", path ? "out" : "path");
    if (!*path) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_mesh_load: empty path");
    clvox__raw_mesh raw;
    clvox_status st = read_raw(ctx, path, &raw);
    if (st) return st;
    /* The scene mesh of each triangle clvox__mesh_build keeps: it drops
     * those with a repeated index (Assimp's faces are all triangles). */
    uint32_t *tri_source = NULL;
    if (raw.face_source && !raw.face_sizes) {
        tri_source = malloc((raw.face_count ? raw.face_count : 1) * sizeof *tri_source);
        if (!tri_source) {
            clvox__raw_mesh_free(&raw);
            return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu triangles", raw.face_count);
        }
        size_t kept = 0;
        for (size_t f = 0; f < raw.face_count; f++) {
            const uint32_t *t = raw.face_indices + 3 * f;
            if (t[0] != t[1] && t[1] != t[2] && t[0] != t[2]) tri_source[kept++] = raw.face_source[f];
        }
    }
    clvox_mesh_source_info source = raw.source;
    char what[4200];
    snprintf(what, sizeof what, "'%s'", path);
    float *xyz = raw.xyz;
    raw.xyz = NULL; /* clvox__mesh_build owns it now */
    uint32_t *owned = NULL;
    if (!raw.face_sizes) { /* all triangles: clvox__mesh_build compacts the indices in place */
        owned = raw.face_indices;
        raw.face_indices = NULL;
    }
    st = clvox__mesh_build(ctx, what, xyz, raw.offset, raw.vertex_count, raw.face_sizes,
                           owned ? owned : raw.face_indices, raw.face_count, raw.index_count, raw.nonmanifold_faces,
                           owned, out);
    clvox__raw_mesh_free(&raw);
    if (st) {
        free(tri_source);
        return st;
    }
    (*out)->source = source;
    (*out)->tri_source = tri_source;
    return CLVOX_OK;
}


clvox_status clvox_mesh_get_source_info(const clvox_mesh *mesh, clvox_mesh_source_info *out)
{
    if (!mesh || !out || out->size < CLVOX__MESH_SOURCE_INFO_SIZE_0 || out->size > sizeof *out)
        return CLVOX_ERR_INVALID_ARGUMENT;
    size_t size = out->size;
    clvox_mesh_source_info full = mesh->source;
    full.size = size;
    memcpy(out, &full, size);
    return CLVOX_OK;
}

const uint32_t *clvox_mesh_triangle_sources(const clvox_mesh *mesh, size_t *triangle_count)
{
    if (triangle_count) *triangle_count = mesh && mesh->tri_source ? mesh->triangle_count : 0;
    return mesh ? mesh->tri_source : NULL;
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
    return clvox__mesh_build(ctx, "mesh arrays", copy, no_offset, vertex_count, NULL, triangles, triangle_count,
                             3 * triangle_count, 0, NULL, out);
}

void clvox_mesh_destroy(clvox_mesh *mesh)
{
    if (!mesh) return;
    clvox__prep_ahead_drop(mesh); /* its thread reads the mesh */
    free(mesh->xyz);
    free(mesh->tris);
    free(mesh->tri_source);
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
