/* SPDX-License-Identifier: Apache-2.0 */
/*
 * clvox — command-line front end. Uses only the public header.
 *
 *   clvox [MESH] [options]        voxelize MESH into an OpenEXR volume (cli_run.c)
 *   clvox batch [MESH...] [options]     many meshes, one device context (cli_batch.c)
 *   clvox info FILE               header, filled voxel count, coverage sum, elements (cli_info.c; no OpenCL needed)
 *   clvox preview FILE -o OUT.png       slices as a PNG picture (cli_preview.c)
 *   clvox palette list | show NAME|FILE  palettes of sub-voxel elements (cli_palette.c)
 *   clvox instances VOLUME.exr -o OUT.csv  instances of a palette volume, for rendering (cli_instances.c)
 *   clvox mesh VOLUME -o OUT.{ply,obj,stl}  a volume's surface, or a palette volume's elements (cli_mesh.c)
 *   clvox convert IN OUT.EXT      another volume format (cli_convert.c)
 *   clvox --list-devices | --help | --version
 *
 * This file is the entry point: main's dispatch to the subcommands (each
 * ending in cli_finish_stdout, cli_common.c: a failed write is exit 1), --version,
 * --list-devices, and `clvox MESH` itself (cmd_voxelize: the default mesh
 * and output name, then one run of cli_run.c, its summary or --json record).
 * The options and --help are in cli_args.c; each stage has its own file so
 * that one reader holds it.
 *
 * Exit codes (also in --help):
 *   0    success
 *   1    runtime failure (OpenCL, kernel build, EXR, out of memory, internal)
 *   2    usage error (bad arguments)
 *   3    no OpenCL device
 *   4    input error: mesh (or the `info` file) missing, unreadable, bad
 *        format, invalid or empty
 *   5    output error: the output file can not be written
 *   6    grid error: zero or too large grid
 *   130  cancelled (SIGINT / SIGTERM / SIGHUP)
 */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif
#ifndef _XOPEN_SOURCE
#define _XOPEN_SOURCE 700 /* realpath */
#endif

#include "clvox.h"
#include "cli_common.h"
#include "cli_json.h"
#include "cli_vox.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Where the mesh comes from when none is given, tried in order.
 * "$CLVOX_DEFAULT_MESH" is the environment variable (when set and not
 * empty it is used as is, existing or not: an explicit choice never falls
 * back silently); "$EXE_DIR" is the directory of the running executable.
 * The others are used when the file exists. Override at build time with
 * -DCLVOX_DEFAULT_MESH_PATHS='"a", "b"'. */
#ifndef CLVOX_DEFAULT_MESH_PATHS
#define CLVOX_DEFAULT_MESH_PATHS                                                      \
    "$CLVOX_DEFAULT_MESH", "$EXE_DIR/../share/clvox/default.obj",                      \
        "$EXE_DIR/../../tests/data/default.obj", "tests/data/default.obj"
#endif

/* ---- small helpers ------------------------------------------------------ */

static char *dup_string(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = malloc(n);
    if (d) memcpy(d, s, n);
    return d;
}

static void print_version(void)
{
    printf("clvox %s (library %s)\n", CLVOX_VERSION_STRING, clvox_version());
}

/* ---- list devices ----------------------------------------------------------- */

static int cmd_list_devices(void)
{
    size_t count = 0;
    clvox_device_info *devs = NULL;
    size_t cap = 16;
    clvox_status st;
    for (;;) {
        clvox_device_info *grown = realloc(devs, cap * sizeof *devs);
        if (!grown) {
            free(devs);
            return fail(EXIT_RUNTIME, "out of memory");
        }
        devs = grown;
        devs[0].size = sizeof *devs; /* and so the distance between entries */
        st = clvox_list_devices(devs, cap, &count);
        if (st != CLVOX_OK || count <= cap) break;
        cap = count;
    }
    if (st != CLVOX_OK || count == 0) {
        free(devs);
        if (st == CLVOX_OK || st == CLVOX_ERR_NO_DEVICE)
            return fail(EXIT_NO_DEVICE, "no OpenCL device found (for PoCL, POCL_CACHE_DIR must be writable)");
        return fail_status(NULL, st, ROLE_OTHER);
    }
    /* column widths from the data, so long names stay aligned */
    int wn = 4, wp = 8, wv = 7, wt = 4;
    for (size_t i = 0; i < count; i++) {
        int n = (int)strlen(devs[i].name), p = (int)strlen(devs[i].platform), v = (int)strlen(devs[i].version),
            t = (int)strlen(devs[i].type);
        if (n > wn) wn = n;
        if (p > wp) wp = p;
        if (v > wv) wv = v;
        if (t > wt) wt = t;
    }
    printf("%-5s  %-*s  %-*s  %-*s  %-*s  %-4s  %s\n", "index", wt, "type", wn, "name", wp, "platform", wv,
           "version", "fp64", "memory");
    int kinds = 0; /* 1: some device has fp64, 2: some has not */
    for (size_t i = 0; i < count; i++) {
        char mem[32];
        format_bytes(devs[i].global_mem_bytes, mem, sizeof mem);
        printf("%-5u  %-*s  %-*s  %-*s  %-*s  %-4s  %s\n", (unsigned)devs[i].index, wt, devs[i].type, wn,
               devs[i].name, wp, devs[i].platform, wv, devs[i].version, devs[i].fp64 ? "yes" : "no", mem);
        kinds |= devs[i].fp64 ? 1 : 2;
    }
    if (count > 1)
        printf("\nOne run can use several devices: --device 0,1 (indices, types or names) or --device all.\n%s",
               kinds == 3 ? "Devices without fp64 share every run with the others (the same voxels).\n" : "");
    free(devs);
    return EXIT_OK;
}

/* ---- default mesh / output ------------------------------------------------------ */

/* Directory of the running executable (no trailing slash), or "" if unknown. */
static void exe_dir(const char *argv0, char *out, size_t size)
{
    char buf[4096];
    ssize_t n = readlink("/proc/self/exe", buf, sizeof buf - 1);
    if (n > 0) {
        buf[n] = '\0';
    } else if (argv0 && strchr(argv0, '/') && strlen(argv0) < sizeof buf) {
        strcpy(buf, argv0);
    } else {
        out[0] = '\0';
        return;
    }
    char *slash = strrchr(buf, '/');
    if (slash == buf) slash[1] = '\0';
    else if (slash) *slash = '\0';
    snprintf(out, size, "%s", buf);
}

/* Returns a malloc'ed path, or NULL after reporting the error (rc set). */
static char *find_default_mesh(const char *argv0, int *rc)
{
    static const char *const candidates[] = {CLVOX_DEFAULT_MESH_PATHS};
    char dir[4096];
    exe_dir(argv0, dir, sizeof dir);
    char path[8192];
    for (size_t i = 0; i < sizeof candidates / sizeof candidates[0]; i++) {
        const char *c = candidates[i];
        if (strncmp(c, "$CLVOX_DEFAULT_MESH", 19) == 0) {
            const char *env = getenv("CLVOX_DEFAULT_MESH");
            if (env && *env) {
                char *p = dup_string(env);
                if (!p) *rc = fail(EXIT_RUNTIME, "out of memory");
                return p;
            }
            continue;
        }
        if (strncmp(c, "$EXE_DIR", 8) == 0) {
            if (!dir[0]) continue;
            snprintf(path, sizeof path, "%s%s", dir, c + 8);
        } else {
            snprintf(path, sizeof path, "%s", c);
        }
        if (is_readable_file(path)) {
            char *p = realpath(path, NULL); /* "/usr/share/clvox/default.obj", not "/usr/bin/../share/..." */
            if (!p) p = dup_string(path);
            if (!p) *rc = fail(EXIT_RUNTIME, "out of memory");
            return p;
        }
    }
    *rc = fail(EXIT_INPUT, "no MESH given and no default mesh found (set CLVOX_DEFAULT_MESH)");
    return NULL;
}

/* "<basename of mesh without extension>.<ext>" in the current directory. */
static char *default_output(const char *mesh, const char *ext)
{
    const char *base = path_basename(mesh);
    size_t n = strlen(base);
    const char *dot = strrchr(base, '.');
    if (dot && dot != base) n = (size_t)(dot - base);
    if (n == 0) {
        base = "volume";
        n = strlen(base);
    }
    size_t e = strlen(ext);
    char *out = malloc(n + e + 2);
    if (!out) return NULL;
    memcpy(out, base, n);
    out[n] = '.';
    memcpy(out + n + 1, ext, e + 1);
    return out;
}

/* Prints one record as a line on stdout; 0 or -1 (out of memory, write error). */
static int emit_json(const vox_session *s, const vox_job *job, const vox_result *res)
{
    jbuf b;
    jb_init(&b);
    vox_result_json(s, job, res, &b);
    int ok = jb_write_line(&b);
    jb_free(&b);
    cli_flush_stdout();
    return ok;
}

static int cmd_voxelize(const cli_args *a, const char *argv0)
{
    double wall_start = cli_now();
    int rc = EXIT_OK;
    char *mesh_path = NULL, *output = NULL;
    vox_session s;
    vox_result *res = calloc(1, sizeof *res);
    memset(&s, 0, sizeof s);
    if (!res) return fail(EXIT_RUNTIME, "out of memory");

    if (a->mesh) {
        mesh_path = dup_string(a->mesh);
        if (!mesh_path) { rc = fail(EXIT_RUNTIME, "out of memory"); goto done; }
    } else {
        mesh_path = find_default_mesh(argv0, &rc);
        if (!mesh_path) goto done;
        if (!a->quiet) { /* with --json stdout holds only records */
            fprintf(a->json ? stderr : stdout, "clvox: no MESH given, using the default mesh %s\n", mesh_path);
            cli_flush_stdout();
        }
    }
    clvox_format format = a->out.format;
    output = a->output ? dup_string(a->output)
                       : default_output(mesh_path, format ? clvox_format_name(format) : "exr");
    if (!output) { rc = fail(EXIT_RUNTIME, "out of memory"); goto done; }

    vox_job job = {mesh_path, output, 0, CLVOX_GRID_OPTIONS_INIT, -1, NULL, 0, 0, NULL, CLVOX_OK, NULL, 0, 0};
    if ((rc = vox_session_open(&s, a)) != EXIT_OK) {
        res->rc = rc;
        res->status = rc == EXIT_CANCELLED ? "cancelled" : "failed";
        snprintf(res->error, sizeof res->error, "%s", cli_last_error());
        if (a->json) emit_json(&s, &job, res);
        goto done;
    }
    rc = vox_run(&s, &job, res);
    if (a->json) {
        res->wall_seconds = cli_now() - wall_start;
        if (emit_json(&s, &job, res) != 0 && rc == EXIT_OK && !cli_stdout_failed()) rc = fail(EXIT_RUNTIME, "out of memory");
    }
    if (rc != EXIT_OK) goto done;
    if (!a->quiet && !a->json) {
        print_summary(mesh_path, &res->report, &res->source, &res->grid, s.dev, a, s.palette, &res->stats,
                      output, res->setup_seconds, cli_now() - wall_start);
        cli_flush_stdout(); /* the summary before the warnings */
    }
    vox_print_warnings(&s, &job, res);
    rc = cli_finish_stdout(rc, output);

done:
    vox_session_close(&s);
    free(res);
    free(output);
    free(mesh_path);
    return rc;
}

int main(int argc, char **argv)
{
    if (argc >= 2 && strcmp(argv[1], "info") == 0) return cli_finish_stdout(cmd_info(argc - 2, argv + 2), NULL);
    if (argc >= 2 && strcmp(argv[1], "preview") == 0) return cli_finish_stdout(cmd_preview(argc - 2, argv + 2), NULL);
    if (argc >= 2 && strcmp(argv[1], "palette") == 0) return cli_finish_stdout(cmd_palette(argc - 2, argv + 2), NULL);
    if (argc >= 2 && strcmp(argv[1], "instances") == 0) return cli_finish_stdout(cmd_instances(argc - 2, argv + 2), NULL);
    if (argc >= 2 && strcmp(argv[1], "mesh") == 0) return cli_finish_stdout(cmd_mesh(argc - 2, argv + 2), NULL);
    if (argc >= 2 && strcmp(argv[1], "convert") == 0) return cli_finish_stdout(cmd_convert(argc - 2, argv + 2), NULL);

    if (argc >= 2 && strcmp(argv[1], "batch") == 0) return cmd_batch(argc - 2, argv + 2); /* checks stdout itself */

    cli_args a;
    int rc = parse_args(argc, argv, 1, 0, NULL, NULL, &a);
    if (rc != EXIT_OK) return rc;
    if (a.help) {
        print_help();
        return cli_finish_stdout(EXIT_OK, NULL);
    }
    if (a.version) {
        print_version();
        return cli_finish_stdout(EXIT_OK, NULL);
    }
    if (a.list_devices) return cli_finish_stdout(cmd_list_devices(), NULL);
    return cmd_voxelize(&a, argc > 0 ? argv[0] : NULL); /* checks stdout itself */
}
