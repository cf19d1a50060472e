/* SPDX-License-Identifier: Apache-2.0 */
/*
 * clvox mesh VOLUME -o OUT.{ply,obj,stl} [--faces | --smooth] [--iso V]
 *            [--channel NAME] [--ascii]
 *
 * Any volume: its surface, from the library (clvox_volume_to_mesh,
 * src/mesh_out/): voxel faces of occupancy, marching cubes of coverage (or
 * of occupancy with --smooth). A palette volume written as PLY without
 * --faces/--smooth/--channel keeps its exact element geometry (below).
 *
 * Palette volumes: the geometry as a triangle mesh: every voxel whose
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
#include <math.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

static void print_mesh_help(void)
{
    fputs(
"Usage: clvox mesh VOLUME -o OUT.{ply,obj,stl} [--faces | --smooth] [--iso V]\n"
"                  [--channel NAME] [--ascii]\n"
"\n"
"Writes a triangle mesh of a clvox volume, in the volume's world coordinates\n"
"(its grid's origin and voxel size), read slice by slice:\n"
"  occupancy  voxel faces (default): the faces between inside and outside\n"
"             voxels (outside the grid is outside), outward normals, shared\n"
"             vertices; where inside voxels touch only along an edge or at a\n"
"             corner each keeps its own vertices there, so the mesh is a\n"
"             closed, oriented 2-manifold that voxelizes back (same grid) to\n"
"             the same voxels\n"
"  coverage   marching cubes (default): the isosurface at 0.5 through the\n"
"             voxel centres, vertices on the edges between centres, closed\n"
"             (values outside the grid count as 0)\n"
"  element    palette volumes, OUT.ply: every voxel whose element is not 0\n"
"             becomes its element's exact shape on the voxel's box (the\n"
"             palette is rebuilt from the header); disjoint convex pieces,\n"
"             each a closed outward shell with its own vertices; shared faces\n"
"             appear once per side (mesh tools may report duplicated faces)\n"
"\n"
"Options:\n"
"  -o, --output OUT         the mesh (required): .ply, .obj or .stl; written\n"
"                           without a name in the same directory and named OUT\n"
"                           on success; never replaces anything but a regular file\n"
"  --faces                  voxel faces (of occupancy, else of coverage > iso,\n"
"                           else of element != 0)\n"
"  --smooth                 marching cubes (of coverage, else of occupancy)\n"
"  --iso V                  inside: value > V (default 0.5)\n"
"  --channel NAME           the channel to read (occupancy, coverage, element, ...)\n"
"  --ascii                  ASCII PLY (fixed-width numbers) or ASCII STL instead\n"
"                           of binary little-endian (PLY: float32 vertices,\n"
"                           uchar-count int faces); OBJ is always text\n"
"  -h, --help               print this help and exit\n"
"\n"
"Memory: two slices and two planes of vertex numbers (the element geometry:\n"
"one slice and the elements' meshes). PLY reads the volume twice (the first\n"
"pass counts, for the header); OBJ and STL once. Needs no OpenCL device. One\n"
"summary line goes to stdout.\n"
"\n"
"Exit codes: 0 ok, 2 usage error, 4 VOLUME missing or unreadable, a channel it\n"
"lacks, a bad element value, or a mesh too large for PLY's int indices, 5 OUT\n"
"can not be written, 1 other failures. Errors are one line on stderr; a failed\n"
"run leaves no file.\n",
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

/* The extension of OUT: "ply", "obj", "stl" or NULL. */
static const char *mesh_ext(const char *path)
{
    const char *base = path_basename(path), *dot = strrchr(base, '.');
    if (!dot) return NULL;
    static const char *const ext[] = {"ply", "obj", "stl"};
    for (size_t i = 0; i < 3; i++)
        if (strcasecmp(dot + 1, ext[i]) == 0) return ext[i];
    return NULL;
}

/* Any volume's surface (clvox_volume_to_mesh). */
static int surface_mesh(clvox_context *ctx, const char *file, const char *output, const clvox_surface_options *o)
{
    clvox_surface_totals t = CLVOX_SURFACE_TOTALS_INIT;
    clvox_status st = clvox_volume_to_mesh(ctx, file, output, o, &t);
    if (st != CLVOX_OK) {
        /* the volume was readable at the start: an I/O error is the output's
         * (or a volume that changed under us); a bad argument is the volume's
         * (a mesh too large for the format) */
        role r = st == CLVOX_ERR_IO && is_readable_file(file) ? ROLE_OUTPUT : ROLE_INPUT;
        int code = st == CLVOX_ERR_INVALID_ARGUMENT ? EXIT_INPUT : exit_code_for(st, r);
        const char *msg = clvox_context_error(ctx);
        return fail(code, "%s", msg && *msg ? msg : clvox_status_string(st));
    }
    char vol[64];
    format_volume(t.enclosed_volume, 9, vol, sizeof vol);
    printf("wrote %s: %s of %s, %llu inside of %u x %u x %u voxels, %llu vertices, %llu triangles, enclosed volume "
           "%s, %llu bytes\n",
           output, t.kind == CLVOX_SURFACE_SMOOTH ? "marching cubes" : "voxel faces", t.channel,
           (unsigned long long)t.inside_voxels, t.dims[0], t.dims[1], t.dims[2], (unsigned long long)t.vertices,
           (unsigned long long)t.triangles, vol, (unsigned long long)t.bytes);
    return EXIT_OK;
}

/* 1: the volume has an element channel (a palette run); 0: it has not; -1:
 * it could not be read (reported). */
static int is_palette_volume(clvox_context *ctx, const char *file, int *rc)
{
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    clvox_status st = clvox_volume_read_slices(ctx, file, "element", &info, stop_at_first, NULL);
    if (st == CLVOX_OK || st == CLVOX_ERR_CANCELLED) return 1;
    if (info.dims[0] && info.channels[0] && !has_channel(info.channels, "element")) return 0;
    *rc = fail_status(ctx, st, ROLE_INPUT);
    return -1;
}

int cmd_mesh(int argc, char **argv)
{
    const char *file = NULL, *output = NULL;
    int ascii = 0;
    clvox_surface_options so = CLVOX_SURFACE_OPTIONS_INIT;
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
        } else if (match_value(argc, argv, &i, NULL, "--channel", &v, &missing)) {
            if (missing || !*v) return MESH_USAGE("mesh: --channel needs a channel name (see clvox mesh --help)");
            so.channel = v;
        } else if (match_value(argc, argv, &i, NULL, "--iso", &v, &missing)) {
            char *end = NULL;
            double x = missing ? 0 : strtod(v, &end);
            if (missing || !*v || *end || !isfinite(x) || fabs(x) > 1e30)
                return MESH_USAGE("mesh: --iso needs a number, not '%s' (see clvox mesh --help)", missing ? "" : v);
            so.iso_set = 1;
            so.iso = x;
        } else if (strcmp(a, "--ascii") == 0) {
            ascii = 1;
        } else if (strcmp(a, "--faces") == 0 || strcmp(a, "--smooth") == 0) {
            clvox_surface_kind k = a[2] == 'f' ? CLVOX_SURFACE_FACES : CLVOX_SURFACE_SMOOTH;
            if (so.kind != CLVOX_SURFACE_AUTO && so.kind != k)
                return MESH_USAGE("mesh: --faces and --smooth exclude each other (see clvox mesh --help)");
            so.kind = k;
        } else {
            return MESH_USAGE("mesh: unknown option '%s' (see clvox mesh --help)", a);
        }
    }
    if (!file) return MESH_USAGE("mesh: missing VOLUME (see clvox mesh --help)");
    if (!output) return MESH_USAGE("mesh: missing -o OUT.ply|.obj|.stl (see clvox mesh --help)");
    int rc = check_output(output);
    if (rc != EXIT_OK) return rc;
    struct stat in_sb, out_sb;
    if (lstat(output, &out_sb) == 0 && stat(file, &in_sb) == 0 && in_sb.st_dev == out_sb.st_dev &&
        in_sb.st_ino == out_sb.st_ino)
        return MESH_USAGE("mesh: the output '%s' is the input volume", output);
    const char *ext = mesh_ext(output);
    if (!ext) return MESH_USAGE("mesh: '%s': unknown mesh extension (use .ply, .obj or .stl)", output);
    so.ascii = ascii;

    clvox_context *ctx = NULL;
    clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
    co.host_only = 1;
    clvox_status st = clvox_context_create(&co, &ctx);
    if (st != CLVOX_OK) {
        rc = fail_status(ctx, st, ROLE_OTHER);
    } else if (so.kind != CLVOX_SURFACE_AUTO || so.channel || so.iso_set) {
        rc = surface_mesh(ctx, file, output, &so);
    } else {
        int palette = is_palette_volume(ctx, file, &rc);
        if (palette == 1 && strcmp(ext, "ply") != 0)
            rc = fail(EXIT_USAGE,
                      "mesh: '%s' is a palette volume: its element geometry is written as PLY only (or give --faces "
                      "or --smooth for its voxel surface)",
                      file);
        else if (palette == 1)
            rc = export_mesh(ctx, file, output, ascii);
        else if (palette == 0)
            rc = surface_mesh(ctx, file, output, &so);
    }
    clvox_context_destroy(ctx);
    return rc;
}
