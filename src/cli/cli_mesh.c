/* SPDX-License-Identifier: Apache-2.0 */
/*
 * clvox mesh VOLUME.exr -o OUT.ply [--ascii]
 *
 * The geometry of a palette volume as a triangle mesh: every voxel whose
 * element is not 0 (empty) is replaced by its element's exact shape
 * (element_mesh.c: disjoint convex pieces, each a closed outward shell)
 * scaled onto the voxel's box, origin + (i, j, k) * voxel size (anisotropic
 * voxels too), in world coordinates. The palette is rebuilt from the
 * volume's header (clvox_volume_palette). PLY: binary little-endian by
 * default (float32 x, y, z; faces "list uchar int vertex_indices"), or
 * ASCII with --ascii (fixed-width records).
 *
 * Bounded memory: the element channel is streamed twice, slice by slice
 * (clvox_volume_read_slices): pass 1 counts the voxels of each element,
 * which gives the header's counts and the exact file size; pass 2 writes
 * each voxel's vertices and faces at their known offsets in the file
 * (clvox_ply_export_*, element_ply.c). The file is written without a name
 * in the directory of OUT (clvox_output_file_*), reserved to its full size
 * first (posix_fallocate, so a full disk fails early), synced, and only then
 * named OUT; a failed run leaves no file, and nothing that is not a regular
 * file at OUT is replaced.
 */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include "cli_common.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static void print_mesh_help(void)
{
    fputs(
"Usage: clvox mesh VOLUME.exr -o OUT.ply [--ascii]\n"
"\n"
"Writes the geometry of a palette volume (clvox MESH --palette NAME|FILE) as a\n"
"PLY triangle mesh: every voxel whose element is not 0 (empty) becomes its\n"
"element's exact shape scaled onto the voxel's box, in world coordinates. The\n"
"palette is rebuilt from the volume's header. Each element is a union of\n"
"disjoint convex pieces, each a closed, outward-oriented shell with its own\n"
"vertices; pieces and neighbouring voxels touch along shared faces, which\n"
"appear once per side (ray parity and winding numbers count them right;\n"
"mesh tools may report them as duplicated faces).\n"
"\n"
"Options:\n"
"  -o, --output OUT.ply     the mesh (required); written without a name in the\n"
"                           same directory and named OUT.ply on success; never\n"
"                           replaces anything but a regular file\n"
"  --ascii                  ASCII PLY (fixed-width numbers) instead of binary\n"
"                           little-endian (float32 vertices, uchar-count int faces)\n"
"  -h, --help               print this help and exit\n"
"\n"
"Reads the element channel twice, slice by slice (memory: one slice and the\n"
"elements' meshes). Needs no OpenCL device. One summary line goes to stdout.\n"
"\n"
"Exit codes: 0 ok, 2 usage error, 4 VOLUME missing, not a palette volume\n"
"(no element channel or palette), a bad element value, or a mesh too large\n"
"for PLY's int indices, 5 OUT.ply can not be written, 1 other failures.\n"
"Errors are one line on stderr; a failed run leaves no file.\n",
        stdout);
}

#define MESH_USAGE(...) fail(EXIT_USAGE, __VA_ARGS__)

typedef struct pass {
    clvox_context *ctx;
    clvox_ply_export *x;
    int writing;       /* 0: counting (pass 1), 1: writing (pass 2) */
    clvox_status st;   /* the exporter's failure, if any */
    char why[1024];    /* its message (the reader overwrites the context's) */
} pass;

static int on_slice(void *user, uint32_t z, const float *values)
{
    pass *p = user;
    p->st = p->writing ? clvox_ply_export_slice(p->x, z, values) : clvox_ply_export_count(p->x, z, values);
    if (p->st == CLVOX_OK) return 0;
    snprintf(p->why, sizeof p->why, "%s", clvox_context_error(p->ctx));
    return 1;
}

static int stop_at_first(void *user, uint32_t z, const float *values)
{
    (void)user;
    (void)z;
    (void)values;
    return 1;
}

/* pwrite in full; 0 or an errno value. */
static int fd_write_at(void *user, uint64_t offset, const void *data, size_t size)
{
    int fd = *(const int *)user;
    const char *b = data;
    while (size) {
        ssize_t n = pwrite(fd, b, size, (off_t)offset);
        if (n < 0) {
            if (errno == EINTR) continue;
            return errno ? errno : EIO;
        }
        if (n == 0) return EIO;
        b += n;
        size -= (size_t)n;
        offset += (uint64_t)n;
    }
    return 0;
}

/* Streams the element channel through the exporter; the reader's or the
 * exporter's failure reported as one line. EXIT_OK or the exit code. */
static int read_pass(clvox_context *ctx, const char *file, pass *p, role exporter_role)
{
    p->st = CLVOX_OK;
    p->why[0] = '\0';
    clvox_status st = clvox_volume_read_slices(ctx, file, "element", NULL, on_slice, p);
    if (p->st != CLVOX_OK) {
        int code = p->st == CLVOX_ERR_EXR ? EXIT_INPUT : exit_code_for(p->st, exporter_role);
        return fail(code, "'%s': %s", file, p->why[0] ? p->why : clvox_status_string(p->st));
    }
    return st == CLVOX_OK ? EXIT_OK : fail_status(ctx, st, ROLE_INPUT);
}

static int export_mesh(clvox_context *ctx, const char *file, const char *output, int ascii)
{
    /* the header, and whether there is an element channel at all */
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    clvox_status st = clvox_volume_read_slices(ctx, file, "element", &info, stop_at_first, NULL);
    if (st != CLVOX_OK && st != CLVOX_ERR_CANCELLED) {
        if (st == CLVOX_ERR_EXR && info.dims[0] && !has_channel(info.channels, "element"))
            return fail(EXIT_INPUT,
                        "'%s' has no element channel (channels: %s): not a palette volume (make one with clvox MESH "
                        "--palette NAME|FILE)",
                        file, info.channels);
        return fail_status(ctx, st, ROLE_INPUT);
    }
    clvox_palette *palette = NULL;
    st = clvox_volume_palette(ctx, file, &palette);
    if (st != CLVOX_OK) return fail_status(ctx, st, ROLE_INPUT);

    clvox_ply_export *x = NULL;
    pass p = {ctx, NULL, 0, CLVOX_OK, ""};
    clvox_output_file *of = NULL;
    int rc = EXIT_OK;
    st = clvox_ply_export_create(ctx, palette, info.dims, info.origin, info.voxel_size, ascii, &x);
    if (st != CLVOX_OK) {
        rc = st == CLVOX_ERR_INVALID_ARGUMENT ? fail(EXIT_INPUT, "'%s': %s", file, clvox_context_error(ctx))
                                              : fail_status(ctx, st, ROLE_OTHER);
        goto done;
    }
    p.x = x;
    if ((rc = read_pass(ctx, file, &p, ROLE_INPUT)) != EXIT_OK) goto done;
    clvox_ply_totals t = CLVOX_PLY_TOTALS_INIT;
    st = clvox_ply_export_totals(x, &t);
    if (st != CLVOX_OK) {
        rc = fail(st == CLVOX_ERR_INVALID_ARGUMENT ? EXIT_INPUT : exit_code_for(st, ROLE_OTHER), "'%s': %s", file,
                  clvox_context_error(ctx));
        goto done;
    }

    st = clvox_output_file_create(ctx, output, &of);
    if (st != CLVOX_OK) {
        rc = fail_status(ctx, st, ROLE_OUTPUT);
        goto done;
    }
    int fd = clvox_output_file_fd(of);
    if (t.bytes > 0) {
        int err = posix_fallocate(fd, 0, (off_t)t.bytes); /* a full disk fails here, before any work */
        if (err != 0 && err != EINVAL && err != EOPNOTSUPP) {
            rc = fail(EXIT_OUTPUT, "cannot write '%s' (%llu bytes): %s", output, (unsigned long long)t.bytes,
                      strerror(err));
            goto done;
        }
    }
    st = clvox_ply_export_begin(x, fd_write_at, &fd);
    if (st != CLVOX_OK) {
        rc = fail(exit_code_for(st, ROLE_OUTPUT), "writing '%s' failed: %s", output, clvox_context_error(ctx));
        goto done;
    }
    p.writing = 1;
    if ((rc = read_pass(ctx, file, &p, ROLE_OUTPUT)) != EXIT_OK) goto done;
    st = clvox_ply_export_finish(x);
    if (st != CLVOX_OK) {
        rc = fail(exit_code_for(st, ROLE_OUTPUT), "writing '%s' failed: %s", output, clvox_context_error(ctx));
        goto done;
    }
    st = clvox_output_file_commit(of, NULL); /* synced, then named */
    of = NULL;
    if (st != CLVOX_OK) {
        rc = fail_status(ctx, st, ROLE_OUTPUT);
        goto done;
    }
    printf("wrote %s: %llu voxels of %u x %u x %u (palette %s, %zu elements), %llu vertices, %llu triangles, %llu "
           "bytes (%s)\n",
           output, (unsigned long long)t.voxels, info.dims[0], info.dims[1], info.dims[2], clvox_palette_name(palette),
           clvox_palette_count(palette), (unsigned long long)t.vertices, (unsigned long long)t.triangles,
           (unsigned long long)t.bytes, ascii ? "ascii" : "binary little-endian");
done:
    clvox_output_file_discard(of);
    clvox_ply_export_destroy(x);
    clvox_palette_destroy(palette);
    return rc;
}

int cmd_mesh(int argc, char **argv)
{
    const char *file = NULL, *output = NULL;
    int ascii = 0;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        const char *v = NULL;
        int missing = 0;
        if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
            print_mesh_help();
            return EXIT_OK;
        }
        if (a[0] != '-' || a[1] == '\0') {
            if (file)
                return MESH_USAGE("mesh: more than one volume given: '%s' and '%s' (see clvox mesh --help)", file, a);
            file = a;
        } else if (match_value(argc, argv, &i, "-o", "--output", &v, &missing)) {
            if (missing || !*v) return MESH_USAGE("mesh: -o needs a file name (see clvox mesh --help)");
            output = v;
        } else if (strcmp(a, "--ascii") == 0) {
            ascii = 1;
        } else {
            return MESH_USAGE("mesh: unknown option '%s' (see clvox mesh --help)", a);
        }
    }
    if (!file) return MESH_USAGE("mesh: missing VOLUME.exr (see clvox mesh --help)");
    if (!output) return MESH_USAGE("mesh: missing -o OUT.ply (see clvox mesh --help)");
    int rc = check_output(output);
    if (rc != EXIT_OK) return rc;
    struct stat in_sb, out_sb;
    if (lstat(output, &out_sb) == 0 && stat(file, &in_sb) == 0 && in_sb.st_dev == out_sb.st_dev &&
        in_sb.st_ino == out_sb.st_ino)
        return MESH_USAGE("mesh: the output '%s' is the input volume", output);

    clvox_context *ctx = NULL;
    clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
    co.host_only = 1;
    clvox_status st = clvox_context_create(&co, &ctx);
    rc = st == CLVOX_OK ? export_mesh(ctx, file, output, ascii) : fail_status(ctx, st, ROLE_OTHER);
    clvox_context_destroy(ctx);
    return rc;
}
