/* SPDX-License-Identifier: Apache-2.0 */
/* Past 800 lines on purpose: one end-to-end program for the tool's commands;
 * cases share the spawn fixtures (tests/spawn.c) and one temporary tree. */
#ifndef _XOPEN_SOURCE
#define _XOPEN_SOURCE 700 /* mknod */
#endif
/* End-to-end tests of the clvox command-line tool: runs the binary
 * ($CLVOX_BIN, default build/release/clvox) with fork/execve (no shell),
 * stdout and stderr captured into files, a 60 s limit per run, and checks
 * exit codes, the one-line error contract and that failed runs leave no
 * file behind. `clvox preview` pictures are decoded with libpng and compared
 * pixel by pixel with the layout its --help documents. */
#include "meshgen.h"
#include "spawn.h"
#include "test.h"
#include "testio.h"
#include "pngread.h"
#include "exrgen.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <signal.h>
#include <stdint.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

extern char **environ;

#define RUN_TIMEOUT_S 60.0
#define ARGS(...) ((const char *const[]){__VA_ARGS__, NULL})
#define ENV(...) ((const char *const[]){__VA_ARGS__, NULL})

/* code: exit status, 128 + signal if killed by one, -1 timeout or spawn
 * failure; out, err: captured stdout and stderr (never NULL) */
typedef spawn_result run_result;

static char g_bin[PATH_MAX];  /* absolute path of the binary */
static char g_dir[PATH_MAX];  /* <tmp>/cli */
static char g_in[PATH_MAX];   /* input meshes */
static char g_out[PATH_MAX];  /* outputs of runs that must fail: stays empty */
static char g_logs[PATH_MAX]; /* captured stdout/stderr */
static unsigned g_run_id;
static const char *g_stdout_file; /* when set, the child's stdout (e.g. /dev/full) */

/* ---- files ---- */

static int write_file(const char *path, const void *data, size_t size)
{
    FILE *f = fopen(path, "wb");
    if (!f) return 0;
    int ok = fwrite(data, 1, size, f) == size;
    ok &= fclose(f) == 0;
    return ok;
}

static int write_text_at(const char *dir, const char *name, const char *text)
{
    char p[PATH_MAX];
    path_join(p, sizeof p, dir, name);
    return write_file(p, text, strlen(text));
}

/* Names of the entries of `dir` ("" if empty), for messages. */
static void dir_entries(const char *dir, char *buf, size_t size)
{
    buf[0] = '\0';
    DIR *d = opendir(dir);
    if (!d) {
        snprintf(buf, size, "(cannot open the directory)");
        return;
    }
    size_t used = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0) continue;
        int n = snprintf(buf + used, size - used, "%s ", e->d_name);
        if (n < 0 || (size_t)n >= size - used) break;
        used += (size_t)n;
    }
    closedir(d);
}

/* ---- running the binary ---- */

/* Environment = the test's own, with `extra` entries ("NAME=VALUE" sets,
 * "NAME" unsets) applied. Returns a malloc'ed array (strings borrowed). */
static const char **make_env(const char *const *extra)
{
    size_t n = 0, m = 0;
    while (environ[n]) n++;
    while (extra && extra[m]) m++;
    const char **env = malloc((n + m + 1) * sizeof *env);
    if (!env) abort();
    size_t k = 0;
    for (size_t i = 0; i < n; i++) {
        int replaced = 0;
        for (size_t j = 0; j < m; j++) {
            size_t len = strcspn(extra[j], "=");
            if (strncmp(environ[i], extra[j], len) == 0 && environ[i][len] == '=') replaced = 1;
        }
        if (!replaced) env[k++] = environ[i];
    }
    for (size_t j = 0; j < m; j++)
        if (strchr(extra[j], '=')) env[k++] = extra[j];
    env[k] = NULL;
    return env;
}

/* What run_cli_ex sends after sigint_after seconds: g_signal (SIGINT unless
 * set), g_signal_count times 0.2 s apart; with g_signal_when_open, only once
 * the child has a file open in g_out (its output being written). */
static int g_signal = SIGINT, g_signal_count = 1, g_signal_when_open;
/* How many signals the last run_cli_ex sent. */
static int g_signals_sent;
/* Set for the next runs: the child starts with SIGHUP ignored (as under
 * nohup); with a file size limit (RLIMIT_FSIZE, SIGXFSZ ignored: a write
 * past it fails with EFBIG, a full disk without a file system to fill). */
static int g_child_ignore_sighup;
static long g_child_fsize_limit;

/* 1 when process pid has a descriptor open on a file under g_out. */
static int has_output_open(pid_t pid)
{
    char fd_dir[64];
    snprintf(fd_dir, sizeof fd_dir, "/proc/%ld/fd", (long)pid);
    DIR *d = opendir(fd_dir);
    if (!d) return 0;
    int found = 0;
    struct dirent *e;
    size_t n = strlen(g_out);
    while (!found && (e = readdir(d)) != NULL) {
        char link[PATH_MAX + 64], target[PATH_MAX];
        snprintf(link, sizeof link, "%s/%s", fd_dir, e->d_name);
        ssize_t len = readlink(link, target, sizeof target - 1);
        if (len <= 0) continue;
        target[len] = '\0';
        found = strncmp(target, g_out, n) == 0 && target[n] == '/';
    }
    closedir(d);
    return found;
}

static int output_open(pid_t pid, void *arg)
{
    (void)arg;
    return has_output_open(pid);
}

/* Runs clvox with `args` (argv[1..], NULL-terminated). cwd may be NULL.
 * If sigint_after > 0, sends SIGINT (g_signal) after that many seconds. */
static void run_cli_ex(run_result *r, const char *cwd, const char *const *env_extra, const char *const *args,
                       double sigint_after)
{
    const char **argv = spawn_argv(g_bin, args);
    const char **env = make_env(env_extra);

    char out_path[PATH_MAX], err_path[PATH_MAX];
    spawn_log_paths(g_logs, ++g_run_id, out_path, err_path);

    spawn_opts o;
    memset(&o, 0, sizeof o);
    o.cwd = cwd;
    o.env = env;
    o.stdout_file = g_stdout_file;
    o.ignore_sighup = g_child_ignore_sighup;
    o.fsize_limit = g_child_fsize_limit;
    o.timeout_s = RUN_TIMEOUT_S;
    o.signal_after = sigint_after;
    o.signal_gap = 0.2;
    o.signal = g_signal;
    o.signal_count = g_signal_count;
    o.signal_ready = g_signal_when_open ? output_open : NULL;
    spawn_run_to(r, argv, out_path, err_path, &o);
    g_signals_sent = o.signals_sent;
    free(argv);
    free(env);
}

static void run_cli(run_result *r, const char *const *env_extra, const char *const *args)
{
    run_cli_ex(r, NULL, env_extra, args, 0);
}

/* Pointer to the text after "label" at the start of a line, or NULL. */
static const char *find_field(const char *text, const char *label)
{
    size_t n = strlen(label);
    for (const char *line = text; line && *line;) {
        if (strncmp(line, label, n) == 0 && (line[n] == ' ' || line[n] == '\t')) {
            const char *v = line + n;
            while (*v == ' ' || *v == '\t') v++;
            return v;
        }
        line = strchr(line, '\n');
        if (line) line++;
    }
    return NULL;
}

/* "filled   N of M voxels" -> N (or -1). */
static long long filled_count(const char *text, long long *total)
{
    const char *v = find_field(text, "filled");
    unsigned long long f = 0, t = 0;
    if (!v || sscanf(v, "%llu of %llu", &f, &t) != 2) return -1;
    if (total) *total = (long long)t;
    return (long long)f;
}

/* ---- the error contract ---- */

/* Runs a command that must fail: exit code `expected` (-1: any non-zero),
 * exactly one stderr line "clvox: error: ...", containing `needle` unless
 * NULL, and nothing in g_out. */
static void expect_failure_msg(const char *what, int expected, const char *const *env, const char *const *args,
                               const char *needle)
{
    run_result r;
    run_cli(&r, env, args);
    if (needle) CHECK_MSG(strstr(r.err, needle) != NULL, "%s: stderr lacks '%s': %s", what, needle, r.err);
    if (expected < 0)
        CHECK_MSG(r.code > 0 && r.code != 127, "%s: exit %d, expected non-zero; stderr: %s", what, r.code, r.err);
    else
        CHECK_MSG(r.code == expected, "%s: exit %d, expected %d; stderr: %s", what, r.code, expected, r.err);
    CHECK_MSG(count_lines(r.err) == 1 && strncmp(r.err, "clvox: error: ", 14) == 0,
              "%s: stderr must be one 'clvox: error:' line, got: [%s]", what, r.err);
    char left[1024];
    dir_entries(g_out, left, sizeof left);
    CHECK_MSG(left[0] == '\0', "%s: files left in the output directory: %s", what, left);
    rm_tree(g_out);
    mkdir(g_out, 0777);
    spawn_free(&r);
}

static void expect_failure(const char *what, int expected, const char *const *env, const char *const *args)
{
    expect_failure_msg(what, expected, env, args, NULL);
}

/* ---- inputs ---- */

static const char CUBE_OBJ[] =
    "# unit cube, quads (fan-triangulated by the loader)\n"
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
    "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

static uint32_t g_rng = 0x12345678u;
static uint32_t next_random(void)
{
    g_rng ^= g_rng << 13;
    g_rng ^= g_rng >> 17;
    g_rng ^= g_rng << 5;
    return g_rng;
}

static void write_random(const char *name, size_t size)
{
    unsigned char *b = malloc(size);
    if (!b) abort();
    for (size_t i = 0; i < size; i++) b[i] = (unsigned char)next_random();
    char p[PATH_MAX];
    path_join(p, sizeof p, g_in, name);
    CHECK(write_file(p, b, size));
    free(b);
}

/* Binary STL claiming `claimed` triangles but holding only `present`. */
static void write_truncated_stl(const char *name, uint32_t claimed, uint32_t present)
{
    size_t size = 84 + (size_t)present * 50;
    unsigned char *b = calloc(1, size);
    if (!b) abort();
    memcpy(b, "binary stl, truncated", 21);
    b[80] = (unsigned char)(claimed & 0xff);
    b[81] = (unsigned char)((claimed >> 8) & 0xff);
    b[82] = (unsigned char)((claimed >> 16) & 0xff);
    b[83] = (unsigned char)(claimed >> 24);
    for (uint32_t t = 0; t < present; t++) {
        float v[12] = {0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0};
        v[3] = (float)t;
        memcpy(b + 84 + (size_t)t * 50, v, sizeof v);
    }
    char p[PATH_MAX];
    path_join(p, sizeof p, g_in, name);
    CHECK(write_file(p, b, size));
    free(b);
}

static void make_inputs(void)
{
    CHECK(write_text_at(g_in, "cube.obj", CUBE_OBJ));
    CHECK(write_text_at(g_in, "unitbox.obj", CUBE_OBJ));
    CHECK(write_text_at(g_in, "cube.xyz", CUBE_OBJ));
    CHECK(write_text_at(g_in, "empty.obj", ""));
    CHECK(write_text_at(g_in, "empty.off", ""));
    CHECK(write_text_at(g_in, "points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"));
    write_random("random.stl", 3000);
    write_random("random.ply", 3000);
    write_random("random.off", 3000);
    write_random("random.obj", 3000);
    write_random("random.exr", 3000);
    write_truncated_stl("truncated.stl", 12, 5);
    CHECK(write_text_at(g_in, "noend.ply",
                     "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                     "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                     "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"));
    CHECK(write_text_at(g_in, "nan.obj", "v 0 0 0\nv 1 0 0\nv nan 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n"));
    CHECK(write_text_at(g_in, "inf.stl",
                     "solid inf\n"
                     " facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n   vertex 0 inf 0\n"
                     "  endloop\n endfacet\n"
                     " facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n   vertex 0 0 1\n"
                     "  endloop\n endfacet\n"
                     "endsolid inf\n"));
    CHECK(write_text_at(g_in, "badindex.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 99\n"));
    /* 5 bytes that aborted OpenMesh's OBJ reader (assert, SIGABRT; issue 7). */
    CHECK(write_text_at(g_in, "slash.obj", "f /1\n"));
    CHECK(write_text_at(g_in, "badindex.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 7\n"));
    /* The cube without its top face; the cube twice, on the same or on its own vertices. */
    CHECK(write_text_at(g_in, "open_cube.obj",
                     "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
                     "f 1 4 3 2\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n"));
    static const char faces[] = "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
    static const char faces2[] = "f 9 12 11 10\nf 13 14 15 16\nf 9 10 14 13\nf 10 11 15 14\nf 11 12 16 15\nf 12 9 13 16\n";
    static const char verts[] = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n";
    char text[1024];
    snprintf(text, sizeof text, "%s%s%s", verts, faces, faces);
    CHECK(write_text_at(g_in, "cube_twice_shared.obj", text));
    snprintf(text, sizeof text, "%s%s%s%s", verts, verts, faces, faces2);
    CHECK(write_text_at(g_in, "cube_twice.obj", text));
    char p[PATH_MAX];
    path_join(p, sizeof p, g_in, "adir.obj");
    CHECK(mkdir(p, 0777) == 0 || errno == EEXIST);
}

/* ---- tests ---- */

static void test_help_version(void)
{
    run_result r;
    run_cli(&r, NULL, ARGS("--help"));
    CHECK_MSG(r.code == 0, "--help exit %d", r.code);
    CHECK_MSG(r.err[0] == '\0', "--help wrote to stderr: %s", r.err);
    static const char *const needed[] = {
        "-o", "--output", "-r", "--dims", "--voxel-size", "--box", "--pad", "--method", "ray", "tetra",
        "--axis", "--depth", "--leaf", "--slab", "--compression", "none", "rle", "zips", "piz",
        "--tetra-origin", "centroid", "bbox", "--threads", "--device", "--list-devices", "-q", "--quiet",
        "--no-progress", "--help", "--version", "clvox info", "CLVOX_DEVICE", "POCL_CACHE_DIR",
        "CLVOX_DEFAULT_MESH", "Exit codes", "130", "default 256", "centre", "longest axis", NULL};
    for (int i = 0; needed[i]; i++)
        CHECK_MSG(strstr(r.out, needed[i]) != NULL, "--help does not mention '%s'", needed[i]);
    spawn_free(&r);

    run_cli(&r, NULL, ARGS("-h"));
    CHECK(r.code == 0 && strstr(r.out, "--voxel-size"));
    spawn_free(&r);

    run_cli(&r, NULL, ARGS("--version"));
    CHECK_MSG(r.code == 0, "--version exit %d", r.code);
    CHECK_MSG(strstr(r.out, CLVOX_VERSION_STRING) != NULL, "--version printed: %s", r.out);
    CHECK(count_lines(r.out) == 1);
    spawn_free(&r);
}

/* Voxelizes the cube at -r N --pad 1 with extra options; returns the filled
 * count reported by `clvox info` (or -1) and checks the run. */
static long long run_cube(const char *what, const char *out_name, const char *const *extra)
{
    char mesh[PATH_MAX], out[PATH_MAX];
    path_join(mesh, sizeof mesh, g_in, "cube.obj");
    path_join(out, sizeof out, g_dir, out_name);
    unlink(out);
    const char *args[32];
    int n = 0;
    args[n++] = mesh;
    args[n++] = "-o";
    args[n++] = out;
    args[n++] = "--pad";
    args[n++] = "1";
    for (int i = 0; extra[i] && n < 30; i++) args[n++] = extra[i];
    args[n] = NULL;

    run_result r;
    run_cli(&r, NULL, args);
    CHECK_MSG(r.code == 0, "%s: exit %d; stderr: %s", what, r.code, r.err);
    CHECK_MSG(file_exists(out), "%s: no output file %s", what, out);
    long long summary = filled_count(r.out, NULL);
    spawn_free(&r);
    if (!file_exists(out)) return -1;

    run_cli(&r, NULL, ARGS("info", out));
    CHECK_MSG(r.code == 0, "%s: info exit %d; stderr: %s", what, r.code, r.err);
    long long info = filled_count(r.out, NULL);
    CHECK_MSG(info == summary, "%s: info reports %lld filled voxels, the run reported %lld", what, info, summary);
    spawn_free(&r);
    return info;
}

static void test_real_run(void)
{
    char mesh[PATH_MAX], out[PATH_MAX];
    path_join(mesh, sizeof mesh, g_in, "cube.obj");
    path_join(out, sizeof out, g_dir, "cube.exr");
    unlink(out);

    /* Unit cube, 16 voxels along the longest axis + 1 voxel of padding:
     * 18^3 grid, the 16^3 centres inside the cube are filled. */
    run_result r;
    run_cli(&r, NULL, ARGS(mesh, "-r", "16", "--pad", "1", "-o", out, "--no-progress"));
    CHECK_MSG(r.code == 0, "real run: exit %d; stderr: %s", r.code, r.err);
    CHECK_MSG(file_exists(out) && file_size(out) > 0, "real run: no output %s", out);
    long long total = 0;
    long long filled = filled_count(r.out, &total);
    CHECK_MSG(filled == 4096 && total == 18 * 18 * 18, "real run: filled %lld of %lld, expected 4096 of 5832; "
              "stdout:\n%s", filled, total, r.out);
    CHECK_MSG(strstr(r.out, "18 x 18 x 18") != NULL, "real run: grid not in summary:\n%s", r.out);
    CHECK_MSG(strstr(r.out, "cube.obj") != NULL, "real run: mesh not in summary");
    CHECK_MSG(find_field(r.out, "time") && find_field(r.out, "output") && find_field(r.out, "device") &&
              find_field(r.out, "volume") && find_field(r.out, "method"),
              "real run: summary incomplete:\n%s", r.out);
    CHECK_MSG(strstr(r.out, " closed") != NULL, "real run: the cube is closed:\n%s", r.out);
    CHECK_MSG(r.err[0] == '\0', "real run: unexpected stderr: %s", r.err);
    CHECK_MSG(count_lines(r.out) <= 16, "real run: summary has %d lines", count_lines(r.out));
    spawn_free(&r);

    /* info: same count and dims; works without any OpenCL device */
    static const char *const no_cl[][3] = {
        {NULL, NULL, NULL},
        {"CLVOX_DEVICE=no-such-device", "OCL_ICD_VENDORS=/nonexistent-clvox-test", NULL},
    };
    for (int k = 0; k < 2; k++) {
        run_cli(&r, no_cl[k][0] ? no_cl[k] : NULL, ARGS("info", out));
        CHECK_MSG(r.code == 0, "info (%d): exit %d; stderr: %s", k, r.code, r.err);
        CHECK_MSG(filled_count(r.out, NULL) == filled, "info (%d): filled %lld, run said %lld:\n%s", k,
                  filled_count(r.out, NULL), filled, r.out);
        CHECK_MSG(strstr(r.out, "18 x 18 x 18") != NULL, "info (%d): dims missing:\n%s", k, r.out);
        CHECK_MSG(strstr(r.out, "ray") != NULL, "info (%d): method missing:\n%s", k, r.out);
        CHECK_MSG(strstr(r.out, CLVOX_VERSION_STRING) != NULL, "info (%d): version missing:\n%s", k, r.out);
        spawn_free(&r);
    }

    /* -q: nothing on stdout, the file is still written */
    unlink(out);
    run_cli(&r, NULL, ARGS("-q", mesh, "-r", "8", "-o", out));
    CHECK_MSG(r.code == 0 && r.out[0] == '\0' && r.err[0] == '\0', "-q: exit %d, stdout [%s], stderr [%s]", r.code,
              r.out, r.err);
    CHECK(file_exists(out));
    spawn_free(&r);

    /* --dims and --voxel-size give the grid they say; options with '=' */
    run_cli(&r, NULL, ARGS(mesh, "--dims=4,5,6", "-o", out));
    CHECK_MSG(r.code == 0 && strstr(r.out, "4 x 5 x 6"), "--dims: exit %d; %s%s", r.code, r.out, r.err);
    spawn_free(&r);
    run_cli(&r, NULL, ARGS(mesh, "--voxel-size", "0.25", "--box=-1,-1,-1,2,2,2", "-o", out));
    CHECK_MSG(r.code == 0 && strstr(r.out, "12 x 12 x 12") && filled_count(r.out, NULL) == 64,
              "--voxel-size/--box: exit %d; %s%s", r.code, r.out, r.err);
    spawn_free(&r);
}

static void test_options(void)
{
    /* every compression and ray axis gives the same volume */
    static const char *const comp[] = {"none", "rle", "zips", "zip", "piz"};
    for (int i = 0; i < 5; i++) {
        char what[64];
        snprintf(what, sizeof what, "--compression %s", comp[i]);
        long long f = run_cube(what, "comp.exr", ARGS("-r", "8", "--compression", comp[i]));
        CHECK_MSG(f == 512, "%s: %lld filled, expected 512", what, f);
    }
    static const char *const axes[] = {"x", "y", "z"};
    for (int i = 0; i < 3; i++) {
        char what[64];
        snprintf(what, sizeof what, "--axis %s", axes[i]);
        long long f = run_cube(what, "axis.exr", ARGS("-r", "8", "--axis", axes[i], "--slab", "3"));
        CHECK_MSG(f == 512, "%s: %lld filled, expected 512", what, f);
    }
    long long f = run_cube("quadtree options", "qt.exr", ARGS("-r", "8", "--depth", "2", "--leaf", "1", "--threads", "1"));
    CHECK_MSG(f == 512, "quadtree options: %lld filled, expected 512", f);
    f = run_cube("--method tetra", "tetra.exr", ARGS("-r", "8", "--method", "tetra"));
    CHECK_MSG(f == 512, "--method tetra: %lld filled, expected 512", f);
    f = run_cube("--tetra-origin", "tetra2.exr", ARGS("-r", "8", "--method", "tetra", "--tetra-origin", "0.1,0.2,0.3"));
    CHECK_MSG(f == 512, "--tetra-origin point: %lld filled, expected 512", f);
}

static void test_default_mesh(void)
{
    /* No MESH: CLVOX_DEFAULT_MESH is used, output <basename>.exr in the cwd. */
    char cwd[PATH_MAX], mesh[PATH_MAX], env[PATH_MAX + 32], out[PATH_MAX];
    path_join(cwd, sizeof cwd, g_dir, "cwd");
    mkdir(cwd, 0777);
    path_join(mesh, sizeof mesh, g_in, "unitbox.obj");
    path_join(out, sizeof out, cwd, "unitbox.exr");
    unlink(out);
    snprintf(env, sizeof env, "CLVOX_DEFAULT_MESH=%s", mesh);
    run_result r;
    run_cli_ex(&r, cwd, ENV(env), ARGS("-r", "8"), 0);
    CHECK_MSG(r.code == 0, "default mesh: exit %d; stderr: %s", r.code, r.err);
    CHECK_MSG(file_exists(out), "default mesh: %s not written", out);
    CHECK_MSG(strstr(r.out, "unitbox.obj") != NULL, "default mesh: mesh path not printed:\n%s", r.out);
    spawn_free(&r);
}

static void test_list_devices(void)
{
    run_result r;
    run_cli(&r, NULL, ARGS("--list-devices"));
    CHECK_MSG(r.code == 0 || r.code == 3, "--list-devices: exit %d", r.code);
    if (r.code == 0) CHECK_MSG(strstr(r.out, "index") && count_lines(r.out) >= 2, "--list-devices: %s", r.out);
    else CHECK(count_lines(r.err) == 1 && strncmp(r.err, "clvox: error: ", 14) == 0);
    spawn_free(&r);
}

static void test_errors(void)
{
    char out[PATH_MAX], cube[PATH_MAX], p[PATH_MAX];
    path_join(out, sizeof out, g_out, "x.exr");
    path_join(cube, sizeof cube, g_in, "cube.obj");

    /* input mesh errors: exit 4 */
    static const char *const bad_meshes[] = {
        "nope.obj", "adir.obj", "cube.xyz", "empty.obj", "empty.off", "points.obj",
        "random.stl", "random.ply", "random.off", "random.obj", "truncated.stl", "noend.ply",
        "nan.obj", "inf.stl", "badindex.obj", "badindex.off", "slash.obj", NULL};
    for (int i = 0; bad_meshes[i]; i++) {
        path_join(p, sizeof p, g_in, bad_meshes[i]);
        char what[128];
        snprintf(what, sizeof what, "mesh %s", bad_meshes[i]);
        expect_failure(what, 4, NULL, ARGS(p, "-r", "16", "-o", out));
    }
    /* the default output name is not created either */
    {
        path_join(p, sizeof p, g_in, "nan.obj");
        run_result r;
        run_cli_ex(&r, g_out, NULL, ARGS(p, "-r", "16"), 0);
        CHECK_MSG(r.code == 4, "nan.obj, default output: exit %d", r.code);
        char left[512];
        dir_entries(g_out, left, sizeof left);
        CHECK_MSG(left[0] == '\0', "nan.obj, default output: files left: %s", left);
        spawn_free(&r);
    }

    /* usage errors: exit 2 */
    expect_failure("-r 0", 2, NULL, ARGS(cube, "-r", "0", "-o", out));
    expect_failure("-r -5", 2, NULL, ARGS(cube, "-r", "-5", "-o", out));
    expect_failure("-r abc", 2, NULL, ARGS(cube, "-r", "abc", "-o", out));
    expect_failure("-r 16x", 2, NULL, ARGS(cube, "-r", "16x", "-o", out));
    expect_failure("-r ''", 2, NULL, ARGS(cube, "-r", "", "-o", out));
    expect_failure("-r ' 16'", 2, NULL, ARGS(cube, "-r", " 16", "-o", out));
    expect_failure("-r 2^70", 2, NULL, ARGS(cube, "-r", "1180591620717411303424", "-o", out));
    expect_failure("-r 2^32", 2, NULL, ARGS(cube, "-r", "4294967296", "-o", out));
    expect_failure("--dims 0,1,1", 2, NULL, ARGS(cube, "--dims", "0,1,1", "-o", out));
    expect_failure("--dims 1,2", 2, NULL, ARGS(cube, "--dims", "1,2", "-o", out));
    expect_failure("--dims 1,2,3,4", 2, NULL, ARGS(cube, "--dims", "1,2,3,4", "-o", out));
    expect_failure("--dims -1,2,3", 2, NULL, ARGS(cube, "--dims", "-1,2,3", "-o", out));
    expect_failure("--voxel-size 0", 2, NULL, ARGS(cube, "--voxel-size", "0", "-o", out));
    expect_failure("--voxel-size -1", 2, NULL, ARGS(cube, "--voxel-size", "-1", "-o", out));
    expect_failure("--voxel-size nan", 2, NULL, ARGS(cube, "--voxel-size", "nan", "-o", out));
    expect_failure("--voxel-size inf", 2, NULL, ARGS(cube, "--voxel-size", "inf", "-o", out));
    expect_failure("--voxel-size 1e999", 2, NULL, ARGS(cube, "--voxel-size", "1e999", "-o", out));
    expect_failure("--voxel-size 1,1", 2, NULL, ARGS(cube, "--voxel-size", "1,1", "-o", out));
    expect_failure("--box 5 values", 2, NULL, ARGS(cube, "--box", "0,0,0,1,1", "-o", out));
    expect_failure("--box empty range", 2, NULL, ARGS(cube, "--box", "1,0,0,0,1,1", "-o", out));
    expect_failure("--pad -1", 2, NULL, ARGS(cube, "--pad", "-1", "-o", out));
    expect_failure("-r and --dims", 2, NULL, ARGS(cube, "-r", "16", "--dims", "4,4,4", "-o", out));
    expect_failure("--dims and --voxel-size", 2, NULL, ARGS(cube, "--dims", "4,4,4", "--voxel-size", "0.1", "-o", out));
    expect_failure("--voxel-size and -r", 2, NULL, ARGS(cube, "--voxel-size", "0.1", "-r", "8", "-o", out));
    expect_failure("--method foo", 2, NULL, ARGS(cube, "--method", "foo", "-o", out));
    expect_failure("--axis w", 2, NULL, ARGS(cube, "--axis", "w", "-o", out));
    expect_failure("--compression lzma", 2, NULL, ARGS(cube, "--compression", "lzma", "-o", out));
    expect_failure("--tetra-origin foo", 2, NULL, ARGS(cube, "--tetra-origin", "foo", "-o", out));
    expect_failure("--threads x", 2, NULL, ARGS(cube, "--threads", "x", "-o", out));
    expect_failure("-o without value", 2, NULL, ARGS(cube, "-r", "8", "-o"));
    expect_failure("unknown option", 2, NULL, ARGS(cube, "--frobnicate", "-o", out));
    expect_failure("unknown short option", 2, NULL, ARGS(cube, "-Z", "-o", out));
    expect_failure("two meshes", 2, NULL, ARGS(cube, cube, "-o", out));
    expect_failure("output is the input", 2, NULL, ARGS(cube, "-r", "8", "-o", cube));
    CHECK_MSG(file_size(cube) == (long long)strlen(CUBE_OBJ), "the input mesh was overwritten");

    /* grid errors: exit 6 */
    expect_failure("-r 100000000", 6, NULL, ARGS(cube, "-r", "100000000", "-o", out));
    expect_failure("--dims too large", 6, NULL, ARGS(cube, "--dims", "65536,65536,65536", "-o", out));
    expect_failure("--voxel-size tiny", 6, NULL, ARGS(cube, "--voxel-size", "1e-9", "-o", out));

    /* output errors: exit 5, nothing created */
    expect_failure("output /proc/nope/x.exr", 5, NULL, ARGS(cube, "-r", "8", "-o", "/proc/nope/x.exr"));
    CHECK(!file_exists("/proc/nope/x.exr"));
    path_join(p, sizeof p, g_dir, "missing-dir/x.exr");
    expect_failure("output in a missing directory", 5, NULL, ARGS(cube, "-r", "8", "-o", p));
    path_join(p, sizeof p, g_dir, "missing-dir");
    CHECK(!file_exists(p));
    expect_failure("output is a directory", 5, NULL, ARGS(cube, "-r", "8", "-o", g_out));

    /* no OpenCL device: exit 3 */
    expect_failure("CLVOX_DEVICE=no-such-device", 3, ENV("CLVOX_DEVICE=no-such-device"),
                   ARGS(cube, "-r", "8", "-o", out));
    expect_failure("--device no-such-device", 3, NULL, ARGS(cube, "-r", "8", "--device", "no-such-device", "-o", out));

    /* info errors */
    path_join(p, sizeof p, g_in, "nope.exr");
    expect_failure("info missing file", 4, NULL, ARGS("info", p));
    path_join(p, sizeof p, g_in, "random.exr");
    expect_failure("info random bytes", 4, NULL, ARGS("info", p));
    expect_failure_msg("info on a mesh", 4, NULL, ARGS("info", cube), "is a mesh, not a volume");
    expect_failure_msg("preview of a mesh", 4, NULL, ARGS("preview", cube, "-o", out), "is a mesh, not a volume");
    expect_failure_msg("info random bytes, not named like a mesh", 4, NULL, ARGS("info", p), "is not a volume clvox reads");
    expect_failure("info without file", 2, NULL, ARGS("info"));
    expect_failure("info with two files", 2, NULL, ARGS("info", cube, cube));
}

/* Warnings come from the mesh report, with either method, one line each,
 * and the run still succeeds. */
static void test_warnings(void)
{
    char out[PATH_MAX], p[PATH_MAX];
    path_join(out, sizeof out, g_dir, "warn.exr");
    static const char *const methods[] = {"ray", "tetra"};
    for (int m = 0; m < 2; m++) {
        run_result r;
        /* A doubled cube (shared or separate vertices) voxelizes as empty:
         * the copies cancel. Say so. */
        static const char *const twice[] = {"cube_twice.obj", "cube_twice_shared.obj"};
        for (int k = 0; k < 2; k++) {
            path_join(p, sizeof p, g_in, twice[k]);
            run_cli(&r, NULL, ARGS(p, "-r", "8", "--method", methods[m], "--inside", "parity", "-o", out));
            CHECK_MSG(r.code == 0, "%s %s: exit %d: %s", twice[k], methods[m], r.code, r.err);
            CHECK_MSG(filled_count(r.out, NULL) == 0, "%s %s: not empty:\n%s", twice[k], methods[m], r.out);
            CHECK_MSG(count_lines(r.err) == 1 && lines_starting(r.err, "clvox: warning: ") == 1 &&
                          strstr(r.err, "12 triangles repeat") && strstr(r.err, "cancel"),
                      "%s %s: expected one duplicate warning, stderr: [%s]", twice[k], methods[m], r.err);
            CHECK_MSG(strstr(r.out, ", 12 duplicate triangles") != NULL, "%s %s: summary lacks the duplicates:\n%s",
                      twice[k], methods[m], r.out);
            spawn_free(&r);
        }
        /* An open mesh: one warning from the report, for tetra too; the ray
         * method's odd-parity count (rays along z miss the missing top face)
         * stays in the summary and joins that line, no second warning. */
        path_join(p, sizeof p, g_in, "open_cube.obj");
        const char *axis = m == 0 ? "--axis=z" : "--slab=0";
        run_cli(&r, NULL, ARGS(p, "-r", "8", "--method", methods[m], "--inside", "parity", axis, "-o", out));
        CHECK_MSG(r.code == 0, "open cube %s: exit %d: %s", methods[m], r.code, r.err);
        CHECK_MSG(count_lines(r.err) == 1 &&
                      lines_starting(r.err, "clvox: warning: the mesh is not closed (4 boundary edges") == 1,
                  "open cube %s: expected one 'not closed' warning, stderr: [%s]", methods[m], r.err);
        if (m == 0) {
            const char *rays = find_field(r.out, "rays");
            CHECK_MSG(strstr(r.err, "; 64 rays crossed it an odd number of times") && rays &&
                          strstr(rays, " 64 odd parity"),
                      "open cube ray: odd parity count missing: [%s]\n%s", r.err, r.out);
        }
        spawn_free(&r);
        /* -q keeps the warning */
        run_cli(&r, NULL, ARGS(p, "-r", "8", "--method", methods[m], "--inside", "parity", "-o", out, "-q"));
        CHECK_MSG(r.code == 0 && r.out[0] == '\0' && count_lines(r.err) == 1 && strstr(r.err, "not closed"),
                  "open cube %s -q: exit %d [%s] [%s]", methods[m], r.code, r.out, r.err);
        spawn_free(&r);
        if (m == 0) {
            /* the winding number (default): the doubled cubes are the cube (their union), the open cube is
             * closed by a cap; no warnings */
            for (int k = 0; k < 2; k++) {
                path_join(p, sizeof p, g_in, twice[k]);
                run_cli(&r, NULL, ARGS(p, "-r", "8", "-o", out));
                CHECK_MSG(r.code == 0 && filled_count(r.out, NULL) == 512 && r.err[0] == '\0',
                          "%s winding: exit %d, [%s]\n%s", twice[k], r.code, r.err, r.out);
                spawn_free(&r);
            }
            path_join(p, sizeof p, g_in, "open_cube.obj");
            run_cli(&r, NULL, ARGS(p, "-r", "8", "--axis=z", "-o", out));
            const char *w = find_field(r.out, "winding");
            CHECK_MSG(r.code == 0 && filled_count(r.out, NULL) == 512 && r.err[0] == '\0' && w &&
                          strstr(w, "1 holes closed by 4 caps"),
                      "open cube winding: exit %d, [%s]\n%s", r.code, r.err, r.out);
            spawn_free(&r);
            /* tetra is parity by construction */
            run_cli(&r, NULL, ARGS(p, "-r", "8", "--method", "tetra", "--inside", "winding", "-o", out));
            CHECK_MSG(r.code != 0 && count_lines(r.err) == 1 && strstr(r.err, "parity method"),
                      "tetra --inside winding: exit %d [%s]", r.code, r.err);
            spawn_free(&r);
            run_cli(&r, NULL, ARGS(p, "-r", "8", "--inside", "even", "-o", out));
            CHECK_MSG(r.code == 2 && count_lines(r.err) == 1 && strstr(r.err, "--inside 'even'"),
                      "--inside even: exit %d [%s]", r.code, r.err);
            spawn_free(&r);
            run_cli(&r, NULL, ARGS(p, "-r", "8", "--weld", "-1", "-o", out));
            CHECK_MSG(r.code == 2 && count_lines(r.err) == 1 && strstr(r.err, "--weld"), "--weld -1: exit %d [%s]",
                      r.code, r.err);
            spawn_free(&r);
            continue;
        }
        spawn_free(&r);
    }
    unlink(out);
}

/* Numbers in messages stay short; overflowing grids say so; a summary that
 * can not be written is an error. */
static void test_messages(void)
{
    char out[PATH_MAX], cube[PATH_MAX];
    path_join(out, sizeof out, g_out, "x.exr");
    path_join(cube, sizeof cube, g_in, "cube.obj");
    run_result r;

    run_cli(&r, NULL, ARGS(cube, "--voxel-size", "1e-300", "-o", out));
    CHECK_MSG(r.code == 6 && count_lines(r.err) == 1 && strlen(r.err) < 160 && strstr(r.err, "1e+300 voxels"),
              "--voxel-size 1e-300: exit %d, stderr [%s]", r.code, r.err);
    spawn_free(&r);
    expect_failure("--voxel-size 1e-300", 6, NULL, ARGS(cube, "--voxel-size", "1e-300", "-o", out));
    expect_failure_msg("--box +-1e308", 6, NULL, ARGS(cube, "--box=-1e308,-1e308,-1e308,1e308,1e308,1e308", "-o", out),
                       "extent on axis x overflows");
    expect_failure_msg("--box near -DBL_MAX with --pad", 6, NULL,
                       ARGS(cube, "--box=-1.7e308,0,0,1,1,1", "--pad", "1", "-r", "2", "-o", out),
                       "origin on axis x overflows");

    /* A voxel so large that its volume overflows: no nan in the summary. */
    char big[PATH_MAX];
    path_join(big, sizeof big, g_dir, "big.exr");
    run_cli(&r, NULL, ARGS(cube, "--voxel-size", "1e300", "-o", big));
    CHECK_MSG(r.code == 0 && find_field(r.out, "volume") && !strstr(r.out, "nan"), "--voxel-size 1e300: exit %d\n%s%s",
              r.code, r.out, r.err);
    spawn_free(&r);
    run_cli(&r, NULL, ARGS("info", big));
    CHECK_MSG(r.code == 0 && find_field(r.out, "volume") && !strstr(r.out, "nan"), "info 1e300: exit %d\n%s%s",
              r.code, r.out, r.err);
    spawn_free(&r);
    /* (A filled voxel whose volume overflows needs a mesh larger than float
     * coordinates allow: the summary would say "too large for a double".) */
    run_cli(&r, NULL, ARGS(cube, "--voxel-size", "1e300", "--box=-1e300,-1e300,-1e300,1e300,1e300,1e300", "-o", big));
    CHECK_MSG(r.code == 0 && find_field(r.out, "volume") && !strstr(r.out, "nan"),
              "--voxel-size 1e300, 8 voxels: exit %d\n%s%s", r.code, r.out, r.err);
    spawn_free(&r);
    unlink(big);

    /* stdout that can not be written: exit 1, one error line; the volume is there. */
    if (access("/dev/full", W_OK) != 0) {
        printf("skip: no /dev/full\n");
        return;
    }
    g_stdout_file = "/dev/full";
    char vol[PATH_MAX];
    path_join(vol, sizeof vol, g_dir, "full.exr");
    unlink(vol);
    run_cli(&r, NULL, ARGS(cube, "-r", "8", "-o", vol));
    CHECK_MSG(r.code == 1 && count_lines(r.err) == 1 && strncmp(r.err, "clvox: error: ", 14) == 0 &&
                  strstr(r.err, "volume was written") && strstr(r.err, "No space left"),
              "> /dev/full: exit %d, stderr [%s]", r.code, r.err);
    CHECK_MSG(file_exists(vol), "> /dev/full: the volume %s is missing", vol);
    spawn_free(&r);
    const char *const cmds[][3] = {{"--help", NULL, NULL}, {"--version", NULL, NULL}, {"info", vol, NULL}};
    for (int i = 0; i < 3; i++) {
        run_cli(&r, NULL, cmds[i]);
        CHECK_MSG(r.code == 1 && count_lines(r.err) == 1 && strstr(r.err, "clvox: error: cannot write to stdout"),
                  "%s > /dev/full: exit %d, stderr [%s]", cmds[i][0], r.code, r.err);
        spawn_free(&r);
    }
    /* -q prints nothing: nothing to fail */
    run_cli(&r, NULL, ARGS(cube, "-r", "8", "-o", vol, "-q"));
    CHECK_MSG(r.code == 0 && r.err[0] == '\0', "-q > /dev/full: exit %d, stderr [%s]", r.code, r.err);
    spawn_free(&r);
    g_stdout_file = NULL;
    unlink(vol);
}

static void test_cancel(void)
{
    /* SIGINT during a long run (4000^3 voxels, one slice per slab, ZIP:
     * minutes of work): exit 130, one error line, no file left. */
    char cube[PATH_MAX], out[PATH_MAX];
    path_join(cube, sizeof cube, g_in, "cube.obj");
    path_join(out, sizeof out, g_out, "big.exr");
    run_result r;
    run_cli_ex(&r, NULL, NULL, ARGS(cube, "-r", "4000", "--slab", "1", "--compression", "zip", "-o", out), 1.5);
    CHECK_MSG(r.code == 130, "SIGINT: exit %d, expected 130; stderr: %s", r.code, r.err);
    CHECK_MSG(count_lines(r.err) == 1 && strncmp(r.err, "clvox: error: ", 14) == 0,
              "SIGINT: stderr must be one error line: [%s]", r.err);
    char left[1024];
    dir_entries(g_out, left, sizeof left);
    CHECK_MSG(left[0] == '\0', "SIGINT: files left: %s", left);
    rm_tree(g_out);
    mkdir(g_out, 0777);
    spawn_free(&r);
}

/* A long run killed while its output is being written (g_signal_when_open)
 * by `sig`, `count` times: exit `expected` (-1: killed by sig), and nothing
 * at all left in the output directory. */
static void killed_run(const char *what, int sig, int count, int expected)
{
    char cube[PATH_MAX], out[PATH_MAX];
    path_join(cube, sizeof cube, g_in, "cube.obj");
    path_join(out, sizeof out, g_out, "big.exr");
    g_signal = sig;
    g_signal_count = count;
    g_signal_when_open = 1;
    run_result r;
    run_cli_ex(&r, NULL, NULL, ARGS(cube, "-r", "4000", "--slab", "1", "--compression", "zip", "-o", out), 0.3);
    g_signal = SIGINT;
    g_signal_count = 1;
    g_signal_when_open = 0;
    int want = expected < 0 ? 128 + sig : expected;
    CHECK_MSG(r.code == want, "%s: exit %d, expected %d; stderr: %s", what, r.code, want, r.err);
    if (expected >= 0)
        CHECK_MSG(count_lines(r.err) == 1 && strncmp(r.err, "clvox: error: ", 14) == 0,
                  "%s: stderr must be one error line: [%s]", what, r.err);
    char left[1024];
    dir_entries(g_out, left, sizeof left);
    CHECK_MSG(left[0] == '\0', "%s: files left: %s", what, left);
    rm_tree(g_out);
    mkdir(g_out, 0777);
    spawn_free(&r);
}

static void test_kill(void)
{
    killed_run("SIGHUP", SIGHUP, 1, 130);
    killed_run("SIGTERM", SIGTERM, 1, 130);
    killed_run("second SIGINT", SIGINT, 2, -1);
    killed_run("kill -9", SIGKILL, 1, -1);
}

/* -o naming something that is not a regular file: exit 5, left as it is;
 * clvox info on a FIFO: exit 4 at once; 250- and 255-byte output names. */
static void test_special_outputs(void)
{
    char cube[PATH_MAX], p[PATH_MAX], exr[PATH_MAX], target[PATH_MAX];
    path_join(cube, sizeof cube, g_in, "cube.obj");
    path_join(exr, sizeof exr, g_dir, "special-in.exr");
    run_result r;
    run_cli(&r, NULL, ARGS(cube, "-r", "8", "-q", "-o", exr));
    CHECK_MSG(r.code == 0, "special-in.exr: exit %d: %s", r.code, r.err);
    spawn_free(&r);
    struct stat sb;

    for (int preview = 0; preview < 2; preview++) {
        const char *ext = preview ? "png" : "exr";
        char name[64];
        /* FIFO (before: replaced by a regular file) */
        snprintf(name, sizeof name, "fifo.%s", ext);
        path_join(p, sizeof p, g_dir, name);
        unlink(p);
        CHECK(mkfifo(p, 0666) == 0);
        if (preview) expect_failure("preview -o FIFO", 5, NULL, ARGS("preview", exr, "-o", p));
        else expect_failure("-o FIFO", 5, NULL, ARGS(cube, "-r", "8", "-o", p));
        CHECK_MSG(lstat(p, &sb) == 0 && S_ISFIFO(sb.st_mode), "-o FIFO (%s): the FIFO was replaced", ext);
        unlink(p);
        /* character device node (as root; else skipped) */
        snprintf(name, sizeof name, "null.%s", ext);
        path_join(p, sizeof p, g_dir, name);
        unlink(p);
        if (mknod(p, S_IFCHR | 0666, makedev(1, 3)) == 0) {
            if (preview) expect_failure("preview -o char device", 5, NULL, ARGS("preview", exr, "-o", p));
            else expect_failure("-o char device", 5, NULL, ARGS(cube, "-r", "8", "-o", p));
            CHECK_MSG(lstat(p, &sb) == 0 && S_ISCHR(sb.st_mode), "-o device (%s): the node was replaced", ext);
            unlink(p);
        } else if (!preview) {
            printf("skip: -o character device (mknod: %s)\n", strerror(errno));
        }
        /* symbolic link: refused, the link and its target untouched */
        snprintf(name, sizeof name, "symlink.%s", ext);
        path_join(p, sizeof p, g_dir, name);
        path_join(target, sizeof target, g_dir, "symlink-target");
        CHECK(write_text_at(g_dir, "symlink-target", "keep"));
        unlink(p);
        CHECK(symlink(target, p) == 0);
        if (preview) expect_failure("preview -o symlink", 5, NULL, ARGS("preview", exr, "-o", p));
        else expect_failure("-o symlink", 5, NULL, ARGS(cube, "-r", "8", "-o", p));
        CHECK(lstat(p, &sb) == 0 && S_ISLNK(sb.st_mode) && file_size(target) == 4);
        unlink(p);
        unlink(target);

        /* long names: 250 and 255 bytes (NAME_MAX), new and replacing */
        for (int len = 250; len <= 255; len += 5) {
            char longname[256];
            memset(longname, 'x', (size_t)len);
            memcpy(longname + len - 4, preview ? ".png" : ".exr", 4);
            longname[len] = '\0';
            path_join(p, sizeof p, g_out, longname);
            for (int again = 0; again < 2; again++) {
                if (preview) run_cli(&r, NULL, ARGS("preview", exr, "-o", p));
                else run_cli(&r, NULL, ARGS(cube, "-r", "8", "-q", "-o", p));
                CHECK_MSG(r.code == 0 && file_size(p) > 0, "%s output with a %d-byte name%s: exit %d: %s", ext,
                          len, again ? ", replacing" : "", r.code, r.err);
                spawn_free(&r);
            }
            char left[1024];
            dir_entries(g_out, left, sizeof left);
            CHECK_MSG(strstr(left, ".tmp") == NULL && strstr(left, ".clvox-") == NULL,
                      "long names: temporary files left: %s", left);
            unlink(p);
        }
    }

    /* clvox info on a FIFO: refused at once (before: blocked in open, which
     * the runner's RUN_TIMEOUT_S turns into a failed check, not a hang) */
    path_join(p, sizeof p, g_dir, "info-fifo.exr");
    unlink(p);
    CHECK(mkfifo(p, 0666) == 0);
    expect_failure("info on a FIFO", 4, NULL, ARGS("info", p));
    expect_failure("preview of a FIFO", 4, NULL, ARGS("preview", p, "-o", exr));
    unlink(p);
    unlink(exr);
}

/* Inputs that are not regular files (issue 32): a FIFO as the palette of
 * `palette show` or as --like (.nrrd, .nhdr, .json) is refused at once with
 * the reason, exit 4 (before: open blocked until the run's 60 s limit; a
 * run's --palette FIFO was a usage error, exit 2); a
 * directory says why ("Is a directory"; before: "cannot read palette
 * 'd.txt'" and nothing more). */
static void test_special_inputs(void)
{
    char cube[PATH_MAX], out[PATH_MAX], p[PATH_MAX], what[96];
    path_join(cube, sizeof cube, g_in, "cube.obj");
    path_join(out, sizeof out, g_out, "x.exr");
    const char *exts[] = {"txt", "nrrd", "nhdr", "json"};
    for (size_t i = 0; i < sizeof exts / sizeof *exts; i++) {
        char name[32];
        snprintf(name, sizeof name, "in-fifo.%s", exts[i]);
        path_join(p, sizeof p, g_dir, name);
        unlink(p);
        CHECK(mkfifo(p, 0666) == 0);
        if (i == 0) {
            expect_failure_msg("palette show FIFO", 4, NULL, ARGS("palette", "show", p), "not a regular file");
            /* before: exit 2, "not a built-in palette ... and not a readable file" */
            expect_failure_msg("--palette FIFO", 4, NULL, ARGS(cube, "--palette", p, "-o", out), "not a regular file");
        } else {
            snprintf(what, sizeof what, "--like FIFO.%s", exts[i]);
            expect_failure_msg(what, 4, NULL, ARGS(cube, "--like", p, "-o", out), "not a regular file");
        }
        unlink(p);
    }
    const char *dirs[] = {"in-dir.txt", "in-dir.nrrd"};
    for (size_t i = 0; i < 2; i++) {
        path_join(p, sizeof p, g_dir, dirs[i]);
        rmdir(p);
        CHECK(mkdir(p, 0777) == 0);
        if (i == 0) expect_failure_msg("palette show DIR", 4, NULL, ARGS("palette", "show", p), strerror(EISDIR));
        else expect_failure_msg("--like DIR.nrrd", 4, NULL, ARGS(cube, "--like", p, "-o", out), strerror(EISDIR));
        rmdir(p);
    }
}

/* `nohup clvox ... &` (issue 32): a SIGHUP the process inherited ignored
 * stays ignored, so the run completes (before: the handler was installed
 * over SIG_IGN and the hang-up cancelled it, exit 130, no output). The
 * SIGHUPs are sent while the output is being written (the handlers are in
 * place by then); the check that one was sent keeps a run that ended too
 * soon from passing unchecked. */
static void test_nohup(void)
{
    char cube[PATH_MAX], out[PATH_MAX];
    path_join(cube, sizeof cube, g_in, "cube.obj");
    path_join(out, sizeof out, g_out, "nohup.exr"); /* g_out: has_output_open looks there */
    unlink(out);
    g_child_ignore_sighup = 1;
    g_signal = SIGHUP;
    g_signal_count = 3;
    g_signal_when_open = 1;
    run_result r;
    run_cli_ex(&r, NULL, NULL, ARGS(cube, "-r", "700", "--slab", "1", "--compression", "zip", "-o", out), 0.001);
    g_child_ignore_sighup = 0;
    g_signal = SIGINT;
    g_signal_count = 1;
    g_signal_when_open = 0;
    CHECK_MSG(g_signals_sent >= 1, "nohup: the run ended (exit %d) before its output was open: no SIGHUP was sent",
              r.code);
    CHECK_MSG(r.code == 0 && file_size(out) > 0 && filled_count(r.out, NULL) > 0,
              "nohup: %d SIGHUP sent: exit %d, expected 0 and the volume; stderr: %s", g_signals_sent, r.code, r.err);
    spawn_free(&r);
    unlink(out);
}

/* A write that fails (RLIMIT_FSIZE: EFBIG, as a full disk gives ENOSPC) is
 * reported with its cause and the file (issue 32): `clvox convert` said
 * "reading 'IN.exr' cancelled after slice N"; the VDB writer (when built)
 * said "basic_ios::clear: iostream error". */
static void test_write_failure_messages(void)
{
    char cube[PATH_MAX], in[PATH_MAX], out[PATH_MAX], plugin[PATH_MAX], what[64];
    path_join(cube, sizeof cube, g_in, "cube.obj");
    path_join(in, sizeof in, g_dir, "convert-in.exr");
    run_result r;
    run_cli(&r, NULL, ARGS(cube, "-r", "64", "--compression", "none", "-q", "-o", in));
    CHECK_MSG(r.code == 0 && file_size(in) > 65536, "convert input: exit %d: %s", r.code, r.err);
    spawn_free(&r);
    snprintf(plugin, sizeof plugin, "%s", g_bin);
    char *slash = strrchr(plugin, '/');
    if (slash) snprintf(slash + 1, sizeof plugin - (size_t)(slash + 1 - plugin), "libclvox-vdb.so");
    int have_vdb = file_exists(plugin);
    if (!have_vdb) printf("test_cli: %s not built: the VDB writer's message is not checked\n", plugin);
    const char *outs[] = {"x.npy", "x.nrrd", "x.vdb"};
    char want[PATH_MAX + 64];
    for (size_t i = 0; i < sizeof outs / sizeof *outs; i++) {
        if (i == 2 && !have_vdb) continue;
        path_join(out, sizeof out, g_out, outs[i]);
        snprintf(what, sizeof what, "convert to %s past RLIMIT_FSIZE", outs[i]);
        snprintf(want, sizeof want, "'%s' failed: %s", out, strerror(EFBIG));
        g_child_fsize_limit = 16384;
        expect_failure_msg(what, 5, NULL,
                           ARGS("convert", in, out, "--compression", "none"), want);
        g_child_fsize_limit = 0;
    }
    unlink(in);
}

/* ---- preview ---- */

/* A volume as grey levels (what the documented mapping gives for its
 * channel), or as colours (rgb set: 3 bytes per voxel; g unused). */
typedef struct grey_volume {
    uint32_t X, Y, Z;
    uint8_t *g;   /* x fastest, then y, then z */
    uint8_t *rgb; /* NULL: grey levels */
} grey_volume;

static void put_voxel(picture *pic, const grey_volume *v, uint32_t px, uint32_t py, size_t i)
{
    uint8_t *d = pic->rgb + 3 * ((size_t)py * pic->w + px);
    if (v->rgb) memcpy(d, v->rgb + 3 * i, 3);
    else memset(d, v->g[i], 3);
}

static uint8_t grey_level(double v)
{
    if (!(v > 0)) return 0; /* also NaN */
    if (v >= 1) return 255;
    return (uint8_t)floor(255.0 * v + 0.5);
}

/* round(a * px / max(a, b)), halves up, at least 1 (as documented) */
static uint32_t doc_scaled(uint32_t a, uint32_t b, uint32_t px)
{
    uint32_t l = a > b ? a : b;
    uint32_t v = (uint32_t)floor((double)a * px / l + 0.5);
    return v ? v : 1;
}

/* The documented layout (clvox preview --help): cells of GUT + w by
 * CAP + h + CAP pixels, BORDER apart; the 3-D view (PX x PX) and the legend
 * on top, the montage, the row of central slices. */
enum { PV_B = 2, PV_CAP = 9, PV_GUT = 7, PV_LEGEND = 5 };
typedef struct pv_rect {
    uint32_t x0, y0, w, h;
} pv_rect;
typedef struct pv_layout {
    uint32_t W, H, n, C, R;
    pv_rect view, ortho[3];
    pv_rect *mont; /* n panels */
} pv_layout;

static void doc_layout(uint32_t X, uint32_t Y, uint32_t Z, uint32_t N, uint32_t PX, pv_layout *L)
{
    const uint32_t B = PV_B, CAP = PV_CAP, GUT = PV_GUT;
    L->n = N < Z ? N : Z;
    L->C = (uint32_t)ceil(sqrt((double)L->n));
    L->R = (L->n + L->C - 1) / L->C;
    uint32_t w[3] = { doc_scaled(X, Y, PX), doc_scaled(X, Z, PX), doc_scaled(Y, Z, PX) };
    uint32_t h[3] = { doc_scaled(Y, X, PX), doc_scaled(Z, X, PX), doc_scaled(Z, Y, PX) };
    uint32_t top = CAP + PX + CAP > PV_LEGEND * CAP ? CAP + PX + CAP : PV_LEGEND * CAP;
    uint32_t my = B + top + B;
    L->view = (pv_rect){ B + GUT, B + CAP, PX, PX };
    L->mont = malloc(L->n * sizeof *L->mont);
    if (!L->mont) abort();
    for (uint32_t k = 0; k < L->n; k++)
        L->mont[k] = (pv_rect){ B + (k % L->C) * (GUT + w[0] + B) + GUT, my + (k / L->C) * (CAP + h[0] + CAP + B) + CAP,
                                w[0], h[0] };
    uint32_t oy = my + L->R * (CAP + h[0] + CAP + B), x = B, oh = 0;
    for (int i = 0; i < 3; i++) {
        L->ortho[i] = (pv_rect){ x + GUT, oy + CAP, w[i], h[i] };
        x += GUT + w[i] + B;
        if (CAP + h[i] + CAP > oh) oh = CAP + h[i] + CAP;
    }
    uint32_t mw = B + L->C * (GUT + w[0] + B), tw = B + GUT + PX + B;
    L->W = mw > x ? mw : x;
    if (tw > L->W) L->W = tw;
    L->H = oy + oh + B;
}

/* The slice panels the documentation of `clvox preview --help` describes
 * (y and z up: panel row j from the top shows cell floor((h-1-j) * n / h));
 * pixels outside every panel are marked 0,0,1 (border or label). The 3-D
 * view is left 0,0,2 (checked by test_preview_view). */
static void expected_preview(const grey_volume *v, uint32_t N, uint32_t PX, picture *pic, pv_layout *L)
{
    const uint32_t X = v->X, Y = v->Y, Z = v->Z;
    doc_layout(X, Y, Z, N, PX, L);
    pic->w = L->W;
    pic->h = L->H;
    pic->rgb = malloc((size_t)pic->w * pic->h * 3);
    if (!pic->rgb) abort();
    for (size_t i = 0; i < (size_t)pic->w * pic->h; i++) {
        pic->rgb[3 * i] = 0;
        pic->rgb[3 * i + 1] = 0;
        pic->rgb[3 * i + 2] = 1;
    }
    for (uint32_t j = 0; j < PX; j++)
        for (uint32_t i = 0; i < PX; i++) pic->rgb[3 * ((size_t)(L->view.y0 + j) * pic->w + L->view.x0 + i) + 2] = 2;
#define PUT(px_, py_, i_) put_voxel(pic, v, (px_), (py_), (i_))
#define VOX(x_, y_, z_) (((size_t)(z_) * Y + (y_)) * X + (x_))
    for (uint32_t k = 0; k < L->n; k++) {
        uint32_t z = (uint32_t)floor((k + 0.5) * Z / L->n);
        const pv_rect *r = &L->mont[k];
        for (uint32_t j = 0; j < r->h; j++)
            for (uint32_t i = 0; i < r->w; i++) PUT(r->x0 + i, r->y0 + j, VOX(i * X / r->w, (r->h - 1 - j) * Y / r->h, z));
    }
    const pv_rect *r = &L->ortho[0];
    for (uint32_t j = 0; j < r->h; j++)
        for (uint32_t i = 0; i < r->w; i++) PUT(r->x0 + i, r->y0 + j, VOX(i * X / r->w, (r->h - 1 - j) * Y / r->h, Z / 2));
    r = &L->ortho[1];
    for (uint32_t j = 0; j < r->h; j++)
        for (uint32_t i = 0; i < r->w; i++) PUT(r->x0 + i, r->y0 + j, VOX(i * X / r->w, Y / 2, (r->h - 1 - j) * Z / r->h));
    r = &L->ortho[2];
    for (uint32_t j = 0; j < r->h; j++)
        for (uint32_t i = 0; i < r->w; i++) PUT(r->x0 + i, r->y0 + j, VOX(X / 2, i * Y / r->w, (r->h - 1 - j) * Z / r->h));
#undef PUT
#undef VOX
}

/* Runs clvox preview (args after "preview") and compares the PNG with the
 * documented picture of v; want_w/want_h: 0 = not checked. */
static void check_preview(const char *what, const grey_volume *v, const char *exr, uint32_t N, uint32_t PX,
                          uint32_t want_w, uint32_t want_h, const char *const *extra)
{
    char png[PATH_MAX];
    path_join(png, sizeof png, g_dir, "preview.png");
    unlink(png);
    const char *args[16];
    int na = 0;
    args[na++] = "preview";
    args[na++] = exr;
    args[na++] = "-o";
    args[na++] = png;
    for (int i = 0; extra && extra[i] && na < 15; i++) args[na++] = extra[i];
    args[na] = NULL;
    run_result r;
    run_cli(&r, NULL, args);
    CHECK_MSG(r.code == 0 && r.err[0] == '\0', "%s: exit %d; stderr: %s", what, r.code, r.err);
    CHECK_MSG(count_lines(r.out) == 1 && strstr(r.out, png), "%s: stdout: %s", what, r.out);
    spawn_free(&r);
    picture got, want;
    pv_layout L;
    int ok = read_png(png, &got);
    CHECK_MSG(ok, "%s: %s is not an 8-bit RGB PNG", what, png);
    expected_preview(v, N, PX, &want, &L);
    if (want_w) CHECK_MSG(want.w == want_w && want.h == want_h, "%s: the documented size is %u x %u, test says %u x %u",
                          what, want.w, want.h, want_w, want_h);
    if (ok) {
        CHECK_MSG(got.w == want.w && got.h == want.h, "%s: %u x %u pixels, expected %u x %u", what, got.w, got.h,
                  want.w, want.h);
        if (got.w == want.w && got.h == want.h) {
            /* slice panels exactly; elsewhere border (0,0,128) or label (255,255,96) */
            static const uint8_t border[3] = { 0, 0, 128 }, text[3] = { 255, 255, 96 };
            size_t bad = 0, first = 0, n = (size_t)got.w * got.h, labels = 0;
            for (size_t i = 0; i < n; i++) {
                const uint8_t *g = got.rgb + 3 * i, *w = want.rgb + 3 * i;
                int ok_px;
                if (w[0] == 0 && w[1] == 0 && w[2] == 2) ok_px = 1; /* the 3-D view */
                else if (w[0] == 0 && w[1] == 0 && w[2] == 1) {
                    ok_px = memcmp(g, border, 3) == 0 || memcmp(g, text, 3) == 0;
                    labels += memcmp(g, text, 3) == 0;
                } else ok_px = memcmp(g, w, 3) == 0;
                if (!ok_px && bad++ == 0) first = i;
            }
            CHECK_MSG(bad == 0, "%s: %zu of %zu pixels differ, first at (%zu, %zu): %u,%u,%u instead of %u,%u,%u",
                      what, bad, n, first % got.w, first / got.w, got.rgb[3 * first], got.rgb[3 * first + 1],
                      got.rgb[3 * first + 2], want.rgb[3 * first], want.rgb[3 * first + 1], want.rgb[3 * first + 2]);
            CHECK_MSG(labels > 0, "%s: no label pixels", what);
        }
    }
    free(L.mont);
    /* nothing but the picture next to it */
    char left[1024];
    dir_entries(g_dir, left, sizeof left);
    CHECK_MSG(strstr(left, ".tmp") == NULL && strstr(left, ".clvox-") == NULL, "%s: temporary files left: %s", what,
              left);
    free(got.rgb);
    free(want.rgb);
    unlink(png);
}

/* A coverage file written by the tests' own EXR writer (tests/exrgen.c). */
typedef struct coverage_file {
    uint32_t X, Y, Z;
    uint16_t *cov, *occ;
    float *score;
} coverage_file;

static void make_coverage_file(coverage_file *cf, uint32_t X, uint32_t Y, uint32_t Z)
{
    size_t n = (size_t)X * Y * Z;
    cf->X = X;
    cf->Y = Y;
    cf->Z = Z;
    cf->cov = malloc(n * 2);
    cf->occ = malloc(n * 2);
    cf->score = malloc(n * sizeof(float));
    if (!cf->cov || !cf->occ || !cf->score) abort();
    for (size_t i = 0; i < n; i++) {
        uint32_t k = next_random();
        /* every HALF in [0, 1], and the halfway grey 0.5 (127.5: rounds up) often */
        cf->cov[i] = (k & 7) == 0 ? 0x3800 : (uint16_t)((k >> 3) % 0x3C01u);
        cf->occ[i] = (next_random() & 1) ? 0x3C00 : 0;
        float s = (float)((int32_t)(next_random() % 4001u) - 1000) / 2000.0f; /* -0.5 .. 1.5 */
        cf->score[i] = (k % 97 == 0) ? NAN : s;
    }
}

static void coverage_grey(const coverage_file *cf, int which, grey_volume *v)
{
    size_t n = (size_t)cf->X * cf->Y * cf->Z;
    v->X = cf->X;
    v->Y = cf->Y;
    v->Z = cf->Z;
    v->rgb = NULL;
    v->g = malloc(n);
    if (!v->g) abort();
    for (size_t i = 0; i < n; i++) {
        if (which == 0) v->g[i] = grey_level(exrgen_half_value(cf->cov[i]));
        else if (which == 1) v->g[i] = exrgen_half_value(cf->occ[i]) > 0.5 ? 255 : 0;
        else v->g[i] = grey_level(cf->score[i]);
    }
}

/* ---- clvox palette ---- */

/* Lines of `text` whose first non-blank character is a digit (table rows). */
static int count_rows(const char *text)
{
    int n = 0;
    for (const char *line = text; line && *line;) {
        const char *c = line;
        while (*c == ' ') c++;
        n += *c >= '0' && *c <= '9';
        line = strchr(line, '\n');
        if (line) line++;
    }
    return n;
}

static void test_palette_cli(void)
{
    run_result r;
    run_cli(&r, NULL, ARGS("palette", "list"));
    CHECK_MSG(r.code == 0 && count_lines(r.out) == 5 && strstr(r.out, "paper78") && strstr(r.out, "planar10") &&
                  r.err[0] == '\0',
              "palette list: exit %d, out [%s] err [%s]", r.code, r.out, r.err);
    spawn_free(&r);
    run_cli(&r, NULL, ARGS("palette", "show", "paper46"));
    CHECK_MSG(r.code == 0 && count_rows(r.out) == 46 && strstr(r.out, "corner_s7") && strstr(r.out, "(1-x,1-y,1-z)"),
              "palette show paper46: exit %d, %d rows, err [%s]", r.code, count_rows(r.out), r.err);
    spawn_free(&r);
    run_cli(&r, NULL, ARGS("palette", "show", "palettes/blocks.txt"));
    CHECK_MSG(r.code == 0 && count_rows(r.out) == 12 && strstr(r.out, "stairs_down_south"),
              "palette show blocks.txt: exit %d, %d rows, err [%s]", r.code, count_rows(r.out), r.err);
    spawn_free(&r);
    run_cli(&r, NULL, ARGS("palette", "--help"));
    CHECK(r.code == 0 && strstr(r.out, "palette show NAME|FILE"));
    spawn_free(&r);
    run_cli(&r, NULL, ARGS("--help"));
    CHECK(r.code == 0 && strstr(r.out, "clvox palette list"));
    spawn_free(&r);
    expect_failure_msg("palette show unknown", 2, NULL, ARGS("palette", "show", "paper47"), "paper47");
    expect_failure_msg("palette no subcommand", 2, NULL, ARGS("palette"), "palette");
    expect_failure_msg("palette bad subcommand", 2, NULL, ARGS("palette", "draw"), "draw");
    expect_failure_msg("palette show two", 2, NULL, ARGS("palette", "show", "binary", "paper46"), "more than one");
    write_text_at(g_in, "bad_palette.txt", "element a\n  cell\n  1 0 0\nend\n");
    char bad[PATH_MAX];
    path_join(bad, sizeof bad, g_in, "bad_palette.txt");
    expect_failure_msg("palette show bad file", 4, NULL, ARGS("palette", "show", bad), "bad_palette.txt:3:");
}

/* A palette run: summary lines, the file's channels and palette. */
static void test_palette_run(void)
{
    char out[PATH_MAX], cube[PATH_MAX];
    path_join(out, sizeof out, g_dir, "pal.exr");
    path_join(cube, sizeof cube, g_in, "cube.obj");
    run_result r;
    run_cli(&r, NULL, ARGS(cube, "-r", "12", "--pad", "1", "--palette", "paper46", "--metric", "outer", "--samples",
                           "9,5", "--channels", "element,score,coverage", "-o", out));
    CHECK_MSG(r.code == 0 && strstr(r.out, "paper46 (46 elements), metric outer, 9 rays x 5 points") &&
                  strstr(r.out, "decided by early-out") && strstr(r.out, "coverage, element, score") != NULL &&
                  strstr(r.out, "1728 of 2744 voxels") && strstr(r.out, "volume       1 of the elements"),
              "palette run: exit %d, out [%s] err [%s]", r.code, r.out, r.err);
    spawn_free(&r);
    clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
    co.host_only = 1;
    clvox_context *c = NULL;
    CHECK_OK(c, clvox_context_create(&co, &c));
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    CHECK_OK(c, clvox_volume_read(c, out, &info, NULL, 0));
    CHECK_MSG(strcmp(info.channels, "coverage,element,score") == 0 && strcmp(info.palette, "paper46") == 0 &&
                  info.palette_count == 46 && strcmp(info.metric, "outer") == 0,
              "palette file: channels '%s', palette '%s' (%u), metric '%s'", info.channels, info.palette,
              info.palette_count, info.metric);
    clvox_palette *p = NULL;
    CHECK_OK(c, clvox_volume_palette(c, out, &p));
    CHECK(p && clvox_palette_count(p) == 46);
    clvox_palette_destroy(p);
    clvox_context_destroy(c);
    unlink(out);
}

/* Palette runs: bad options and files get one line, the right exit code
 * and no file. */
static void test_palette_run_errors(void)
{
    char out[PATH_MAX], cube[PATH_MAX], bad[PATH_MAX];
    path_join(out, sizeof out, g_out, "p.exr");
    path_join(cube, sizeof cube, g_in, "cube.obj");
    path_join(bad, sizeof bad, g_in, "bad_palette.txt"); /* from test_palette_cli */
    expect_failure_msg("unknown palette", 2, NULL, ARGS(cube, "-r", "8", "--palette", "paper47", "-o", out), "paper47");
    expect_failure_msg("bad palette file", 4, NULL, ARGS(cube, "-r", "8", "--palette", bad, "-o", out),
                       "bad_palette.txt:3:");
    expect_failure_msg("unknown metric", 2, NULL, ARGS(cube, "-r", "8", "--palette", "binary", "--metric", "best", "-o", out),
                       "best");
    expect_failure_msg("samples T not square", 2, NULL,
                       ARGS(cube, "-r", "8", "--palette", "binary", "--samples", "10,4", "-o", out), "square");
    expect_failure_msg("samples zero", 2, NULL, ARGS(cube, "-r", "8", "--palette", "binary", "--samples", "0,4", "-o", out),
                       "--samples");
    expect_failure_msg("samples P zero", 2, NULL, ARGS(cube, "-r", "8", "--palette", "binary", "--samples", "4,0", "-o", out),
                       "--samples");
    expect_failure_msg("samples too many", 2, NULL,
                       ARGS(cube, "-r", "8", "--palette", "binary", "--samples", "256,17", "-o", out), "4096");
    expect_failure_msg("samples one value", 2, NULL, ARGS(cube, "-r", "8", "--palette", "binary", "--samples", "16", "-o", out),
                       "--samples");
    expect_failure_msg("samples and oversample", 2, NULL,
                       ARGS(cube, "-r", "8", "--palette", "binary", "--samples", "4,4", "--oversample", "2", "-o", out),
                       "give one");
    expect_failure_msg("metric without palette", 2, NULL, ARGS(cube, "-r", "8", "--metric", "outer", "-o", out), "--palette");
    expect_failure_msg("samples without palette", 2, NULL, ARGS(cube, "-r", "8", "--samples", "4,4", "-o", out), "--palette");
    expect_failure_msg("shortcut with outer", 2, NULL,
                       ARGS(cube, "-r", "8", "--palette", "paper46", "--metric", "outer", "--shortcut", "auto", "-o", out),
                       "nearest");
    expect_failure_msg("shortcut bad", 2, NULL,
                       ARGS(cube, "-r", "8", "--palette", "paper46", "--shortcut", "0.6,0.5", "-o", out), "ALPHA");
    expect_failure_msg("palette with tetra", 2, NULL,
                       ARGS(cube, "-r", "8", "--palette", "paper46", "--method", "tetra", "-o", out), "ray");
    expect_failure_msg("element channel without palette", 2, NULL, ARGS(cube, "-r", "8", "--channels", "element", "-o", out),
                       "--palette");
}

/* Writes an occupancy volume (HALF 1 inside the box [lo, hi), 0 elsewhere;
 * lo == hi: empty) with the tests' own EXR writer. */
static void write_box(const char *path, uint32_t X, uint32_t Y, uint32_t Z, const uint32_t lo[3], const uint32_t hi[3])
{
    size_t n = (size_t)X * Y * Z;
    uint16_t *occ = calloc(n, 2);
    if (!occ) abort();
    for (uint32_t z = lo[2]; z < hi[2]; z++)
        for (uint32_t y = lo[1]; y < hi[1]; y++)
            for (uint32_t x = lo[0]; x < hi[0]; x++) occ[((size_t)z * Y + y) * X + x] = 0x3C00;
    exrgen_channel ch = { "occupancy", EXR_PIXEL_HALF, occ };
    CHECK(exrgen_write(path, X, Y, Z, &ch, 1, 0, 0, EXR_COMPRESSION_ZIP, 1));
    free(occ);
}

static const uint8_t *pic_at(const picture *pic, uint32_t x, uint32_t y)
{
    return pic->rgb + 3 * ((size_t)y * pic->w + x);
}

/* Runs clvox preview exr -o png --size PX --slices N; 1 when it worked and
 * the picture has the documented size. */
static int run_preview(const char *exr, const char *png, uint32_t N, uint32_t PX, const pv_layout *L, picture *pic)
{
    char n_s[16], px_s[16];
    snprintf(n_s, sizeof n_s, "%u", N);
    snprintf(px_s, sizeof px_s, "%u", PX);
    run_result r;
    unlink(png);
    run_cli(&r, NULL, ARGS("preview", exr, "-o", png, "--slices", n_s, "--size", px_s));
    int ok = r.code == 0;
    CHECK_MSG(ok, "preview %s: exit %d; %s", exr, r.code, r.err);
    spawn_free(&r);
    if (!ok || !read_png(png, pic)) return 0;
    CHECK_MSG(pic->w == L->W && pic->h == L->H, "preview %s: %u x %u, expected %u x %u", exr, pic->w, pic->h, L->W,
              L->H);
    return pic->w == L->W && pic->h == L->H;
}

/* Whether the caption strips above two panels (the cell's full width less
 * the gutter's first pixel, CAP - 1 rows) hold the same pixels. */
static int same_caption(const picture *a, const pv_rect *ra, const picture *b, const pv_rect *rb, size_t *text_px)
{
    if (ra->w != rb->w) return 0;
    *text_px = 0;
    for (uint32_t j = 1; j < PV_CAP - 1; j++)
        for (uint32_t i = 1; i < PV_GUT + ra->w; i++) {
            const uint8_t *pa = pic_at(a, ra->x0 - PV_GUT + i, ra->y0 - PV_CAP + j);
            const uint8_t *pb = pic_at(b, rb->x0 - PV_GUT + i, rb->y0 - PV_CAP + j);
            if (memcmp(pa, pb, 3) != 0) return 0;
            *text_px += pa[0] == 255 && pa[1] == 255 && pa[2] == 96;
        }
    return 1;
}

/* The view's documented projection: the pixel whose centre is nearest the
 * projection of (x, y, z) (in voxel units). */
static void view_pixel(const pv_layout *L, uint32_t X, uint32_t Y, uint32_t Z, double x, double y, double z,
                       uint32_t *pi, uint32_t *pj)
{
    const double wu = (X + Z) / sqrt(2.0), hv = (X + Z + 2.0 * Y) / sqrt(6.0), PX = L->view.w;
    const double s = PX / (wu > hv ? wu : hv);
    const double u = (x - z) / sqrt(2.0), v = (2 * y - x - z) / sqrt(6.0);
    *pi = (uint32_t)floor((u + Z / sqrt(2.0)) * s + (PX - wu * s) / 2);
    *pj = (uint32_t)floor((2.0 * Y / sqrt(6.0) - v) * s + (PX - hv * s) / 2);
}

/* Pixel tests of the picture on boxes: y up, labels, the 3-D view's faces and
 * their documented shades, an empty volume, the same bytes twice. */
static void test_preview_view(void)
{
    char box[PATH_MAX], empty[PATH_MAX], png[PATH_MAX], png2[PATH_MAX];
    path_join(box, sizeof box, g_dir, "box.exr");
    path_join(empty, sizeof empty, g_dir, "empty.exr");
    path_join(png, sizeof png, g_dir, "view.png");
    path_join(png2, sizeof png2, g_dir, "view2.png");
    const uint32_t X = 16, Y = 16, Z = 16, PX = 96, N = 16;
    const uint32_t lo[3] = { 4, 10, 4 }, hi[3] = { 12, 15, 12 }; /* towards +y */
    write_box(box, X, Y, Z, lo, hi);
    pv_layout L;
    doc_layout(X, Y, Z, N, PX, &L);
    picture pic;
    if (run_preview(box, png, N, PX, &L, &pic)) {
        /* slice z = 8 (panel 8): white only in the upper half, and some */
        const pv_rect *r = &L.mont[8];
        size_t upper = 0, lower = 0;
        for (uint32_t j = 0; j < r->h; j++)
            for (uint32_t i = 0; i < r->w; i++)
                if (pic_at(&pic, r->x0 + i, r->y0 + j)[0] == 255) *(j < r->h / 2 ? &upper : &lower) += 1;
        CHECK_MSG(upper > 0 && lower == 0, "a box towards +y: %zu white pixels in the upper half of its slice, %zu in "
                  "the lower", upper, lower);
        /* the y = Y/2 panel (x right, z up) is empty (the box starts at y = 10); x = X/2 (y right, z up): right half */
        r = &L.ortho[2];
        size_t left = 0, right = 0;
        for (uint32_t j = 0; j < r->h; j++)
            for (uint32_t i = 0; i < r->w; i++)
                if (pic_at(&pic, r->x0 + i, r->y0 + j)[0] == 255) *(i < r->w / 2 ? &left : &right) += 1;
        CHECK_MSG(right > 0 && left == 0, "x = X/2 panel: %zu white pixels left, %zu right (y to the right)", left,
                  right);
        /* labels: panel 8 shows z = 8 = Z/2, as the bottom row's first panel does: the same caption; slice 9's differs */
        size_t t8 = 0, t9 = 0;
        CHECK_MSG(same_caption(&pic, &L.mont[8], &pic, &L.ortho[0], &t8) && t8 > 20,
                  "slice z=8's caption differs from the z = Z/2 panel's (%zu label pixels)", t8);
        CHECK_MSG(!same_caption(&pic, &L.mont[8], &pic, &L.mont[9], &t9), "slices 8 and 9 have the same caption");
        /* axis letters: the gutter holds the up arrow and 'y', the strip below 'x>' */
        size_t gut = 0, below = 0;
        for (uint32_t j = 0; j < 15; j++)
            for (uint32_t i = 0; i < PV_GUT; i++) gut += pic_at(&pic, r->x0 - PV_GUT + i, r->y0 + j)[2] == 96;
        for (uint32_t j = 0; j < PV_CAP; j++)
            for (uint32_t i = 0; i < 11; i++) below += pic_at(&pic, r->x0 + r->w - 11 + i, r->y0 + r->h + j)[2] == 96;
        CHECK_MSG(gut > 10 && below > 10, "axis labels: %zu pixels in the gutter, %zu below", gut, below);

        /* the 3-D view: the box's three visible faces, at their centres */
        const double D = X + Y + Z, amb = 0.3, ln = sqrt(14.0);
        const struct { const char *name; double x, y, z, nl; } face[3] = {
            { "+x", hi[0], (lo[1] + hi[1]) / 2.0, (lo[2] + hi[2]) / 2.0, 1 },
            { "+y", (lo[0] + hi[0]) / 2.0, hi[1], (lo[2] + hi[2]) / 2.0, 3 },
            { "+z", (lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0, hi[2], 2 },
        };
        int shade[3];
        for (int f = 0; f < 3; f++) {
            uint32_t i, j;
            view_pixel(&L, X, Y, Z, face[f].x, face[f].y, face[f].z, &i, &j);
            const uint8_t *c = pic_at(&pic, L.view.x0 + i, L.view.y0 + j);
            shade[f] = c[0];
            double want = 255 * (amb + (1 - amb) * face[f].nl / ln) * (0.5 + 0.5 * (face[f].x + face[f].y + face[f].z) / D);
            CHECK_MSG(c[0] == c[1] && c[1] == c[2] && fabs(c[0] - want) <= 4,
                      "3-D view, face %s at (%u, %u): %u,%u,%u, expected a grey of about %.1f", face[f].name, i, j,
                      c[0], c[1], c[2], want);
        }
        CHECK_MSG(shade[1] > shade[2] && shade[2] > shade[0],
                  "3-D view: lit from (1,3,2), expected +y brighter than +z brighter than +x: %d %d %d", shade[1],
                  shade[2], shade[0]);
        /* corners of the view: background */
        CHECK(pic_at(&pic, L.view.x0, L.view.y0)[0] == 0 && pic_at(&pic, L.view.x0 + PX - 1, L.view.y0 + PX - 1)[2] == 0);
        /* the same bytes twice */
        run_result rr;
        run_cli(&rr, NULL, ARGS("preview", box, "-o", png2, "--slices", "16", "--size", "96"));
        CHECK_MSG(rr.code == 0, "second run: exit %d", rr.code);
        spawn_free(&rr);
        char *b1 = read_all(png), *b2 = read_all(png2);
        CHECK_MSG(b1 && b2 && file_size(png) == file_size(png2) &&
                      memcmp(b1, b2, (size_t)file_size(png)) == 0,
                  "two runs on the same volume give different PNG bytes");
        free(b1);
        free(b2);
        unlink(png2);
        free(pic.rgb);
    }

    /* an empty volume: a black 3-D view */
    const uint32_t none[3] = { 0, 0, 0 };
    write_box(empty, X, Y, Z, none, none);
    if (run_preview(empty, png, N, PX, &L, &pic)) {
        size_t lit = 0;
        for (uint32_t j = 0; j < PX; j++)
            for (uint32_t i = 0; i < PX; i++) {
                const uint8_t *c = pic_at(&pic, L.view.x0 + i, L.view.y0 + j);
                lit += c[0] || c[1] || c[2];
            }
        CHECK_MSG(lit == 0, "an empty volume: %zu pixels of the 3-D view are not black", lit);
        free(pic.rgb);
    }
    free(L.mont);
    unlink(png);
    unlink(box);
    unlink(empty);
}

static void test_preview(void)
{
    char p[PATH_MAX], mesh[PATH_MAX], occ_exr[PATH_MAX], cov_exr[PATH_MAX], both_exr[PATH_MAX];
    clvox_context *ctx = NULL;
    clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
    co.host_only = 1;
    CHECK_OK(ctx, clvox_context_create(&co, &ctx));

    /* help */
    run_result r;
    run_cli(&r, NULL, ARGS("preview", "--help"));
    CHECK_MSG(r.code == 0 && r.err[0] == '\0', "preview --help: exit %d", r.code);
    static const char *const needed[] = { "--slices", "--size", "--channel", "-o", "z_k = floor((k + 0.5) * Z / N)",
                                          "ceil(sqrt(N))", "z = Z/2", "y = Y/2", "x = X/2", "round(255 * value)",
                                          "2-pixel", "floor(p * cells / pixels)", "default 16", "default 256", NULL };
    for (int i = 0; needed[i]; i++)
        CHECK_MSG(strstr(r.out, needed[i]) != NULL, "preview --help does not mention '%s'", needed[i]);
    spawn_free(&r);
    run_cli(&r, NULL, ARGS("--help"));
    CHECK_MSG(strstr(r.out, "clvox preview") != NULL && strstr(r.out, "coverage sum"),
              "--help does not describe preview and info's coverage");
    spawn_free(&r);

    /* an occupancy volume made by clvox itself: the bundled mesh at -r 32 */
    if (!absolute_path("tests/data/default.obj", mesh, sizeof mesh)) {
        CHECK(!"tests/data/default.obj not found (run from the repository root)");
        clvox_context_destroy(ctx);
        return;
    }
    path_join(occ_exr, sizeof occ_exr, g_dir, "knot.exr");
    run_cli(&r, NULL, ARGS(mesh, "-r", "32", "-o", occ_exr, "-q"));
    CHECK_MSG(r.code == 0, "voxelize default.obj: exit %d; %s", r.code, r.err);
    spawn_free(&r);
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    CHECK_OK(ctx, clvox_volume_read(ctx, occ_exr, &info, NULL, 0));
    grey_volume v = { info.dims[0], info.dims[1], info.dims[2], NULL, NULL };
    size_t nv = (size_t)v.X * v.Y * v.Z;
    v.g = malloc(nv ? nv : 1);
    if (!v.g) abort();
    CHECK_OK(ctx, clvox_volume_read(ctx, occ_exr, &info, v.g, nv));
    for (size_t i = 0; i < nv; i++) v.g[i] = v.g[i] ? 255 : 0;
    CHECK(info.filled_voxels > 0 && info.filled_voxels < nv);
    check_preview("occupancy, defaults", &v, occ_exr, 16, 256, 0, 0, NULL);
    check_preview("occupancy, --slices 5 --size 40", &v, occ_exr, 5, 40, 0, 0, ARGS("--slices", "5", "--size", "40"));
    check_preview("occupancy, --slices 100 --size 7 (fewer slices)", &v, occ_exr, 100, 7, 0, 0,
                  ARGS("--slices=100", "--size=7", "--channel", "occupancy"));
    check_preview("occupancy, --slices 1 --size 1", &v, occ_exr, 1, 1, 0, 0, ARGS("--slices", "1", "--size", "1"));
    /* info of an occupancy-only file: no coverage line */
    run_cli(&r, NULL, ARGS("info", occ_exr));
    CHECK_MSG(r.code == 0 && find_field(r.out, "coverage") == NULL && find_field(r.out, "filled"),
              "info of an occupancy file:\n%s", r.out);
    spawn_free(&r);
    free(v.g);

    /* coverage (+ occupancy, + a FLOAT channel) from the test writer */
    coverage_file cf;
    make_coverage_file(&cf, 20, 9, 37);
    path_join(cov_exr, sizeof cov_exr, g_dir, "coverage.exr");
    path_join(both_exr, sizeof both_exr, g_dir, "both.exr");
    exrgen_channel ch[] = { { "coverage", EXR_PIXEL_HALF, cf.cov }, { "occupancy", EXR_PIXEL_HALF, cf.occ },
                            { "score", EXR_PIXEL_FLOAT, cf.score } };
    CHECK(exrgen_write(cov_exr, cf.X, cf.Y, cf.Z, ch, 1, 20, 4, EXR_COMPRESSION_ZIP, 1)); /* chunks span slices */
    CHECK(exrgen_write(both_exr, cf.X, cf.Y, cf.Z, ch, 3, 0, 0, EXR_COMPRESSION_RLE, 1));
    grey_volume gc, go, gs;
    coverage_grey(&cf, 0, &gc);
    coverage_grey(&cf, 1, &go);
    coverage_grey(&cf, 2, &gs);
    /* 20 x 9 panels of 256 x 115, 4 x 4; 256 x 115, 138 x 256, 62 x 256 below; cells 7 + w wide, 9 + h + 9
     * tall, 2 apart; the 3-D view 256 x 256 on top: 2 + 4 * 265 = 1062 x 2 + 274 + 2 + 4 * 135 + 274 + 2 = 1094 */
    check_preview("coverage only, defaults", &gc, cov_exr, 16, 256, 1062, 1094, NULL);
    check_preview("coverage + occupancy: coverage by default", &gc, both_exr, 16, 256, 1062, 1094, NULL);
    check_preview("--channel occupancy", &go, both_exr, 7, 33, 0, 0, ARGS("--channel", "occupancy", "--slices", "7",
                                                                          "--size", "33"));
    check_preview("--channel score (FLOAT, clamped, NaN)", &gs, both_exr, 3, 100, 0, 0,
                  ARGS("--channel", "score", "--slices", "3", "--size", "100"));
    /* replacing an existing regular file is fine */
    path_join(p, sizeof p, g_dir, "preview.png");
    CHECK(write_text_at(g_dir, "preview.png", "old"));
    run_cli(&r, NULL, ARGS("preview", cov_exr, "-o", p));
    CHECK_MSG(r.code == 0 && file_size(p) > 100, "replacing a file: exit %d %s", r.code, r.err);
    spawn_free(&r);
    unlink(p);

    /* info shows the coverage sum and the estimated volume */
    size_t n = (size_t)cf.X * cf.Y * cf.Z;
    double sum = 0;
    for (size_t i = 0; i < n; i++) sum += exrgen_half_value(cf.cov[i]);
    const double voxel_volume = EXRGEN_H_X * EXRGEN_H_Y * EXRGEN_H_Z;
    for (int k = 0; k < 2; k++) {
        run_cli(&r, NULL, ARGS("info", k ? both_exr : cov_exr));
        const char *f = find_field(r.out, "coverage");
        double got_sum = -1, got_vol = -1;
        CHECK_MSG(r.code == 0 && f && sscanf(f, "%lf voxels (sum of coverage), estimated volume %lf", &got_sum,
                                             &got_vol) == 2,
                  "info coverage line (%d):\n%s", k, r.out);
        CHECK_MSG(fabs(got_sum - sum) <= 1e-8 * sum && fabs(got_vol - sum * voxel_volume) <= 1e-8 * sum,
                  "info (%d): sum %.9g volume %.9g, expected %.9g and %.9g", k, got_sum, got_vol, sum,
                  sum * voxel_volume);
        uint64_t filled = 0;
        for (size_t i = 0; i < n; i++) filled += k ? cf.occ[i] == 0x3C00 : exrgen_half_value(cf.cov[i]) > 0.5;
        CHECK_MSG(filled_count(r.out, NULL) == (long long)filled, "info (%d): filled %lld, expected %llu", k,
                  filled_count(r.out, NULL), (unsigned long long)filled);
        spawn_free(&r);
    }

    /* errors: one line, the documented exit code, nothing left in g_out */
    char out[PATH_MAX];
    path_join(out, sizeof out, g_out, "x.png");
    path_join(p, sizeof p, g_out, "x.exr");
    CHECK(write_text_at(g_in, "x.exr", "this is a text file, not an EXR\n"));
    path_join(p, sizeof p, g_in, "x.exr");
    expect_failure("preview of a text file", 4, NULL, ARGS("preview", p, "-o", out));
    path_join(p, sizeof p, g_in, "plain.exr");
    CHECK(exrgen_write(p, cf.X, cf.Y, cf.Z, ch, 1, 0, 0, EXR_COMPRESSION_NONE, 0));
    expect_failure("preview of an EXR without clvox attributes", 4, NULL, ARGS("preview", p, "-o", out));
    path_join(p, sizeof p, g_in, "nope.exr");
    expect_failure("preview of a missing file", 4, NULL, ARGS("preview", p, "-o", out));
    expect_failure("preview of a directory", 4, NULL, ARGS("preview", g_in, "-o", out));
    expect_failure("preview --channel missing", 4, NULL, ARGS("preview", cov_exr, "-o", out, "--channel", "score"));
    path_join(p, sizeof p, g_in, "score.exr");
    CHECK(exrgen_write(p, cf.X, cf.Y, cf.Z, &ch[2], 1, 0, 0, EXR_COMPRESSION_NONE, 1));
    expect_failure("preview, neither coverage nor occupancy", 4, NULL, ARGS("preview", p, "-o", out));
    /* a truncated volume: the header reads, the pixels do not; no temporary file */
    path_join(p, sizeof p, g_in, "truncated.exr");
    CHECK(exrgen_write(p, cf.X, cf.Y, cf.Z, ch, 3, 0, 0, EXR_COMPRESSION_NONE, 1));
    CHECK(truncate(p, file_size(p) * 2 / 3) == 0);
    expect_failure("preview of a truncated volume", 4, NULL, ARGS("preview", p, "-o", out));
    expect_failure("preview --slices 0", 2, NULL, ARGS("preview", cov_exr, "-o", out, "--slices", "0"));
    expect_failure("preview --slices huge", 2, NULL, ARGS("preview", cov_exr, "-o", out, "--slices", "1000000"));
    expect_failure("preview --slices -3", 2, NULL, ARGS("preview", cov_exr, "-o", out, "--slices", "-3"));
    expect_failure("preview --size 0", 2, NULL, ARGS("preview", cov_exr, "-o", out, "--size", "0"));
    expect_failure("preview --size huge", 2, NULL, ARGS("preview", cov_exr, "-o", out, "--size", "99999999999"));
    expect_failure("preview --size x", 2, NULL, ARGS("preview", cov_exr, "-o", out, "--size", "x"));
    expect_failure("preview picture too large", 2, NULL,
                   ARGS("preview", cov_exr, "-o", out, "--slices", "4096", "--size", "8192"));
    expect_failure("preview without -o", 2, NULL, ARGS("preview", cov_exr));
    expect_failure("preview without file", 2, NULL, ARGS("preview", "-o", out));
    expect_failure("preview two files", 2, NULL, ARGS("preview", cov_exr, cov_exr, "-o", out));
    expect_failure("preview unknown option", 2, NULL, ARGS("preview", cov_exr, "-o", out, "--frobnicate"));
    path_join(p, sizeof p, g_dir, "missing-dir/x.png");
    expect_failure("preview into a missing directory", 5, NULL, ARGS("preview", cov_exr, "-o", p));
    path_join(p, sizeof p, g_dir, "missing-dir");
    CHECK(!file_exists(p));
    expect_failure("preview output is a directory", 5, NULL, ARGS("preview", cov_exr, "-o", g_out));
    expect_failure("preview output /proc/x.png", 5, NULL, ARGS("preview", cov_exr, "-o", "/proc/x.png"));
    /* a symbolic link at the output name is not replaced (nor its target written) */
    char target[PATH_MAX], link_path[PATH_MAX];
    path_join(target, sizeof target, g_dir, "link-target.txt");
    path_join(link_path, sizeof link_path, g_dir, "link.png");
    CHECK(write_text_at(g_dir, "link-target.txt", "keep"));
    unlink(link_path);
    CHECK(symlink(target, link_path) == 0);
    expect_failure("preview output is a symlink", 5, NULL, ARGS("preview", cov_exr, "-o", link_path));
    struct stat sb;
    CHECK(lstat(link_path, &sb) == 0 && S_ISLNK(sb.st_mode) && file_size(target) == 4);
    char left[1024];
    dir_entries(g_dir, left, sizeof left);
    CHECK_MSG(strstr(left, ".tmp") == NULL && strstr(left, ".clvox-") == NULL,
              "preview errors: temporary files left: %s", left);
    expect_failure("preview output is the input", 2, NULL, ARGS("preview", cov_exr, "-o", cov_exr));

    free(gc.g);
    free(go.g);
    free(gs.g);
    free(cf.cov);
    free(cf.occ);
    free(cf.score);
    clvox_context_destroy(ctx);
}

/* ---- palette runs: element colours and clvox info ---- */

/* The element colour as `clvox preview --help` documents it. */
static void doc_element_rgb(double v, uint8_t rgb[3])
{
    if (!(v >= 1) || v != floor(v) || v >= 4294967296.0) {
        rgb[0] = rgb[1] = rgb[2] = 0;
        return;
    }
    if (v == 1) {
        rgb[0] = rgb[1] = rgb[2] = 224;
        return;
    }
    const uint64_t e = (uint64_t)v;
    const uint32_t H = (uint32_t)((e - 2) * 949u % 1536u), f = H % 256;
    const uint8_t up = (uint8_t)(50 + 180 * f / 255), down = (uint8_t)(230 - 180 * f / 255);
    const uint8_t t[6][3] = { { 230, up, 50 }, { down, 230, 50 }, { 50, 230, up },
                              { 50, down, 230 }, { up, 50, 230 }, { 230, 50, down } };
    memcpy(rgb, t[H / 256], 3);
}

static int count_line_prefix(const char *text, const char *prefix)
{
    int n = 0;
    for (const char *line = text; line && *line;) {
        n += strncmp(line, prefix, strlen(prefix)) == 0;
        line = strchr(line, '\n');
        if (line) line++;
    }
    return n;
}

/* Palette files from the test writer (element UINT, score HALF, the palette
 * attributes): preview colours (default channel, --shade, grey channels),
 * and clvox info's palette line and element histogram. */
static void test_palette_files(void)
{
    const uint32_t X = 11, Y = 7, Z = 5;
    const size_t n = (size_t)X * Y * Z;
    uint32_t *elem = malloc(n * 4);
    uint16_t *score = malloc(n * 2), *cov = malloc(n * 2);
    grey_volume colours = { X, Y, Z, NULL, malloc(n * 3) }, shaded = { X, Y, Z, NULL, malloc(n * 3) };
    grey_volume grey = { X, Y, Z, malloc(n), NULL };
    if (!elem || !score || !cov || !colours.rgb || !shaded.rgb || !grey.g) abort();
    uint64_t per[46] = { 0 };
    for (size_t i = 0; i < n; i++) {
        elem[i] = i % 4 == 0 ? 0 : i % 4 == 1 ? 1 : 2 + (uint32_t)(i / 4) % 44;
        per[elem[i]]++;
        uint32_t k = next_random();
        score[i] = k % 29 == 0 ? 0x7E00 /* NaN */ : k % 31 == 0 ? 0x4000 /* 2 */ : (uint16_t)(k % 0x3C01u);
        cov[i] = (uint16_t)(next_random() % 0x3C01u);
        doc_element_rgb(elem[i], colours.rgb + 3 * i);
        double sv = exrgen_half_value(score[i]);
        uint32_t g = !(sv > 0) ? 0 : sv >= 1 ? 255 : (uint32_t)floor(255.0 * sv + 0.5);
        for (int c = 0; c < 3; c++)
            shaded.rgb[3 * i + c] = (uint8_t)((colours.rgb[3 * i + c] * (255 + g) + 255) / 510); /* c (1 + s) / 2 */
        grey.g[i] = (uint8_t)g;
    }
    /* the documented colours, by hand: 0 black, 1 light grey, 2 red, 3 blue, 4 green */
    uint8_t c[3];
    doc_element_rgb(0, c);
    CHECK(c[0] == 0 && c[1] == 0 && c[2] == 0);
    doc_element_rgb(1, c);
    CHECK(c[0] == 224 && c[1] == 224 && c[2] == 224);
    doc_element_rgb(2, c);
    CHECK(c[0] == 230 && c[1] == 50 && c[2] == 50);
    doc_element_rgb(3, c); /* H = 949: sector 3, f = 181 */
    CHECK(c[0] == 50 && c[1] == 103 && c[2] == 230);
    doc_element_rgb(4, c); /* H = 362: sector 1, f = 106 */
    CHECK(c[0] == 156 && c[1] == 230 && c[2] == 50);
    for (uint32_t a = 2; a < 1538; a++) /* distinct, and never the border's blue or a grey */
        for (uint32_t b = a + 1; b < 1538; b += 97) {
            uint8_t ca[3], cb[3];
            doc_element_rgb(a, ca);
            doc_element_rgb(b, cb);
            if (memcmp(ca, cb, 3) == 0 || (ca[0] == 0 && ca[1] == 0 && ca[2] == 128) || (ca[0] == ca[1] && ca[1] == ca[2])) {
                CHECK_MSG(0, "element colours %u and %u", a, b);
                a = b = 1538;
            }
        }

    clvox_context *ctx = NULL;
    clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
    co.host_only = 1;
    CHECK_OK(ctx, clvox_context_create(&co, &ctx));
    clvox_palette *p46 = NULL;
    CHECK_OK(ctx, clvox_palette_builtin(ctx, "paper46", &p46));
    char hash[32], bad_hash[32];
    snprintf(hash, sizeof hash, "%016llx", (unsigned long long)clvox_palette_hash(p46));
    snprintf(bad_hash, sizeof bad_hash, "%016llx", (unsigned long long)clvox_palette_hash(p46) ^ 1u);
    clvox_palette_destroy(p46);
    clvox_context_destroy(ctx);
    const exrgen_extra attrs[] = { { "clvoxPalette", "paper46", 0 }, { "clvoxPaletteCount", NULL, 46 },
                                   { "clvoxPaletteHash", hash, 0 }, { "clvoxMetric", "nearest", 0 } };
    exrgen_extra tampered[4];
    memcpy(tampered, attrs, sizeof attrs);
    tampered[2].string = bad_hash;
    const exrgen_channel ch[] = { { "element", EXR_PIXEL_UINT, elem }, { "score", EXR_PIXEL_HALF, score },
                                  { "coverage", EXR_PIXEL_HALF, cov } };
    char pal[PATH_MAX], pal_cov[PATH_MAX], pal_bad[PATH_MAX];
    path_join(pal, sizeof pal, g_dir, "palette.exr");
    path_join(pal_cov, sizeof pal_cov, g_dir, "palette_cov.exr");
    path_join(pal_bad, sizeof pal_bad, g_dir, "palette_bad.exr");
    exrgen_attrs a = exrgen_default_attrs(X, Y, Z);
    a.extra = attrs;
    a.extra_count = 4;
    CHECK(exrgen_write_ex(pal, X, Y, Z, ch, 2, 11, 3, EXR_COMPRESSION_NONE, &a)); /* chunks span slices */
    CHECK(exrgen_write_ex(pal_cov, X, Y, Z, ch, 3, 0, 0, EXR_COMPRESSION_ZIP, &a));
    a.extra = tampered;
    CHECK(exrgen_write_ex(pal_bad, X, Y, Z, ch, 2, 0, 0, EXR_COMPRESSION_NONE, &a));

    /* preview: element colours by default (also next to coverage), shaded, grey channels */
    check_preview("element colours, defaults", &colours, pal, 16, 256, 0, 0, NULL);
    check_preview("element colours before coverage", &colours, pal_cov, 3, 40, 0, 0,
                  ARGS("--slices", "3", "--size", "40"));
    check_preview("--channel element --shade", &shaded, pal, 4, 50, 0, 0,
                  ARGS("--channel", "element", "--shade", "--slices", "4", "--size", "50"));
    check_preview("--shade, tampered palette (not needed)", &shaded, pal_bad, 16, 64, 0, 0,
                  ARGS("--shade", "--size", "64"));
    check_preview("--channel score: grey levels", &grey, pal_cov, 5, 30, 0, 0,
                  ARGS("--channel", "score", "--slices", "5", "--size", "30"));
    char out[PATH_MAX];
    path_join(out, sizeof out, g_out, "x.png");
    expect_failure_msg("--shade with a grey channel", 2, NULL, ARGS("preview", pal, "-o", out, "--shade", "--channel",
                                                                    "coverage"), "--shade");
    char p[PATH_MAX];
    path_join(p, sizeof p, g_in, "element_only.exr");
    CHECK(exrgen_write(p, X, Y, Z, ch, 1, 0, 0, EXR_COMPRESSION_RLE, 1));
    expect_failure_msg("--shade without score", 4, NULL, ARGS("preview", p, "-o", out, "--shade"), "score");
    path_join(p, sizeof p, g_in, "coverage_only.exr");
    CHECK(exrgen_write(p, X, Y, Z, &ch[2], 1, 0, 0, EXR_COMPRESSION_RLE, 1));
    expect_failure_msg("--shade without element", 4, NULL, ARGS("preview", p, "-o", out, "--shade"), "element");
    run_result r;
    run_cli(&r, NULL, ARGS("preview", "--help"));
    CHECK_MSG(strstr(r.out, "--shade") && strstr(r.out, "949 mod 1536") && strstr(r.out, "default: element"),
              "preview --help does not describe element colours:\n%s", r.out);
    spawn_free(&r);

    /* info: the palette line and the voxels per element, named */
    run_cli(&r, NULL, ARGS("info", pal));
    char want[160];
    snprintf(want, sizeof want, "paper46: 46 elements, hash %s, metric nearest\n", hash);
    const char *f = find_field(r.out, "palette");
    CHECK_MSG(r.code == 0 && f && strncmp(f, want, strlen(want)) == 0, "info palette line:\n%s%s", r.out, r.err);
    f = find_field(r.out, "elements");
    CHECK_MSG(f && strncmp(f, "46 of 46 used", 13) == 0, "info elements line:\n%s", r.out);
    CHECK_MSG(filled_count(r.out, NULL) == (long long)(n - per[0]), "info: filled %lld, expected %llu (element != 0)",
              filled_count(r.out, NULL), (unsigned long long)(n - per[0]));
    snprintf(want, sizeof want, "    0 empty %*s %12llu", 18, "", (unsigned long long)per[0]);
    CHECK_MSG(strstr(r.out, want) != NULL, "info: no row '%s':\n%s", want, r.out);
    snprintf(want, sizeof want, "    1 full %*s %12llu", 19, "", (unsigned long long)per[1]);
    CHECK_MSG(strstr(r.out, want) != NULL, "info: no row '%s':\n%s", want, r.out);
    CHECK_MSG(strstr(r.out, "    2 wedge ") != NULL && strstr(r.out, "36 more elements: "), "info rows:\n%s", r.out);
    CHECK_MSG(count_line_prefix(r.out, "             ") == 11, "info: %d element rows:\n%s",
              count_line_prefix(r.out, "             "), r.out);
    CHECK(r.err[0] == '\0');
    spawn_free(&r);
    /* a palette that cannot be rebuilt: said on the palette line, rows without names */
    run_cli(&r, NULL, ARGS("info", pal_bad));
    f = find_field(r.out, "palette");
    CHECK_MSG(r.code == 0 && f && strstr(f, "cannot be rebuilt: ") && strstr(f, "is not the one"),
              "info of a tampered file:\n%s%s", r.out, r.err);
    CHECK_MSG(strstr(r.out, "    1 full") == NULL && strstr(r.out, "46 of 46 used"), "info of a tampered file:\n%s",
              r.out);
    spawn_free(&r);
    /* not a palette run: no palette line, elements counted */
    path_join(p, sizeof p, g_in, "element_only.exr");
    run_cli(&r, NULL, ARGS("info", p));
    CHECK_MSG(r.code == 0 && !find_field(r.out, "palette") && find_field(r.out, "elements") &&
                  strncmp(find_field(r.out, "elements"), "46 used", 7) == 0,
              "info without palette attributes:\n%s%s", r.out, r.err);
    spawn_free(&r);

    free(elem);
    free(score);
    free(cov);
    free(colours.rgb);
    free(shaded.rgb);
    free(grey.g);
}

/* ---- grey levels (coverage) ---- */

static int same_file(const char *a, const char *b)
{
    char *x = read_all(a), *y = read_all(b);
    long long na = file_size(a), nb = file_size(b);
    int same = x && y && na == nb && memcmp(x, y, (size_t)na) == 0;
    free(x);
    free(y);
    return same;
}

static void test_coverage_options(void)
{
    char mesh[PATH_MAX], a[PATH_MAX], b[PATH_MAX], c[PATH_MAX], out[PATH_MAX];
    path_join(mesh, sizeof mesh, g_in, "cube.obj");
    path_join(a, sizeof a, g_dir, "cov_a.exr");
    path_join(b, sizeof b, g_dir, "cov_b.exr");
    path_join(c, sizeof c, g_dir, "cov_c.exr");
    path_join(out, sizeof out, g_out, "x.exr");

    /* K = 1 with threshold 0.5 is the binary run; only occupancy is written */
    long long bin = run_cube("binary", "cov_bin.exr", ARGS("-r", "20", NULL));
    long long k1 = run_cube("oversample 1", "cov_k1.exr", ARGS("-r", "20", "--oversample", "1", "--threshold", "0.5", NULL));
    CHECK_MSG(bin > 0 && k1 == bin, "K=1 + threshold 0.5 filled %lld, binary %lld", k1, bin);

    run_result r;
    run_cli(&r, NULL, ARGS(mesh, "-r", "20", "--oversample", "4", "-o", a));
    CHECK_MSG(r.code == 0, "oversample 4: exit %d: %s", r.code, r.err);
    CHECK(strstr(r.out, "sampling     4x4 rays x 4 points per voxel (64 samples), uniform; channels coverage") != NULL);
    CHECK(strstr(r.out, "estimated (sum of coverage)") != NULL);
    spawn_free(&r);
    run_cli(&r, NULL, ARGS("info", a));
    CHECK_MSG(r.code == 0 && strstr(r.out, "channels coverage\n") && strstr(r.out, "coverage     "), "info: %s%s", r.out,
              r.err);
    CHECK(strstr(r.out, "oversample=4x4 points=4 sampling=uniform") != NULL);
    spawn_free(&r);

    /* stochastic: the same seed gives the same file, another seed another one */
    run_cli(&r, NULL, ARGS(mesh, "-r", "20", "--oversample", "2,3", "--stochastic", "--seed", "5", "-o", a, "-q"));
    CHECK(r.code == 0);
    spawn_free(&r);
    run_cli(&r, NULL, ARGS(mesh, "-r", "20", "--oversample", "2,3", "--stochastic", "--seed=5", "--slab", "3", "-o", b, "-q"));
    CHECK(r.code == 0);
    spawn_free(&r);
    run_cli(&r, NULL, ARGS(mesh, "-r", "20", "--oversample", "2,3", "--stochastic", "--seed", "6", "-o", c, "-q"));
    CHECK(r.code == 0);
    spawn_free(&r);
    CHECK_MSG(same_file(a, b), "seed 5 twice (slab auto and 3) gave different files");
    CHECK_MSG(!same_file(a, c), "seeds 5 and 6 gave the same file");

    /* both channels on request */
    run_cli(&r, NULL, ARGS(mesh, "-r", "20", "--oversample", "3", "--channels", "occupancy,coverage", "-o", a, "-q"));
    CHECK(r.code == 0);
    spawn_free(&r);
    run_cli(&r, NULL, ARGS("info", a));
    CHECK_MSG(strstr(r.out, "channels coverage,occupancy") != NULL, "info: %s", r.out);
    spawn_free(&r);
    unlink(a);
    unlink(b);
    unlink(c);

    /* bad values: exit 2, one line, nothing left behind */
    static const char *const bad[][4] = {
        {"--oversample", "0", NULL, NULL},           {"--oversample", "17", NULL, NULL},
        {"--oversample", "2,0", NULL, NULL},         {"--oversample", "2,256", NULL, NULL},
        {"--oversample", "x", NULL, NULL},           {"--oversample", "2,3,4", NULL, NULL},
        {"--oversample", "-2", NULL, NULL},          {"--oversample", "2", "--threshold", "1.5"},
        {"--oversample", "2", "--threshold", "-0.1"}, {"--oversample", "2", "--threshold", "abc"},
        {"--oversample", "2", "--threshold", "nan"}, {"--oversample", "2", "--stochastic", "--seed=abc"},
        {"--oversample", "2", "--stochastic", "--seed=-1"},
        {"--oversample", "2", "--stochastic", "--seed=18446744073709551616"},
        {"--stochastic", NULL, NULL, NULL},          {"--oversample", "2", "--seed", "3"},
        {"--threshold", "0.5", NULL, NULL},          {"--oversample", "2", "--method", "tetra"},
        {"--oversample", "2", "--channels", "foo"},  {"--channels", "coverage", NULL, NULL},
        {"--oversample", "2", "--channels", ""},     {"--oversample", "2", "--channels", "coverage,"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        const char *args[12] = {mesh, "-r", "8", "-o", out};
        int n = 5;
        for (int k = 0; k < 4 && bad[i][k]; k++) args[n++] = bad[i][k];
        args[n] = NULL;
        char what[160];
        snprintf(what, sizeof what, "%s %s %s %s", bad[i][0], bad[i][1] ? bad[i][1] : "", bad[i][2] ? bad[i][2] : "",
                 bad[i][3] ? bad[i][3] : "");
        expect_failure(what, 2, NULL, args);
    }
}

/* A small mesh far from the origin (issue 7): a 0.1-unit cube at x = 1e6.
 * OBJ (text) keeps its precision: exact volume, no warning, and the same
 * voxels as the cube at x = 0. Binary STL holds float32: the spacing there is
 * 0.0625, 1000 % of a voxel, which gets a warning. */
static void test_precision_warning(void)
{
    static const char far_fmt[] =
        "v %s 0 0\nv %s.1 0 0\nv %s.1 0.1 0\nv %s 0.1 0\nv %s 0 0.1\nv %s.1 0 0.1\nv %s.1 0.1 0.1\nv %s 0.1 0.1\n"
        "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";
    const char *where[2] = {"1000000", "0"};
    long long filled[2] = {-1, -2};
    for (int i = 0; i < 2; i++) {
        char text[1024], name[32], mesh[PATH_MAX], out[PATH_MAX];
        const char *w = where[i];
        snprintf(text, sizeof text, far_fmt, w, w, w, w, w, w, w, w);
        snprintf(name, sizeof name, "far%d.obj", i);
        write_text_at(g_in, name, text);
        path_join(mesh, sizeof mesh, g_in, name);
        path_join(out, sizeof out, g_dir, "far.exr");
        run_result r;
        run_cli(&r, NULL, ARGS(mesh, "-r", "16", "--pad", "1", "-o", out));
        CHECK_MSG(r.code == 0 && !strstr(r.err, "warning"), "OBJ cube at x=%s: exit %d, stderr: %s", w, r.code, r.err);
        CHECK_MSG(strstr(r.out, "(+0.00 %)") != NULL, "OBJ cube at x=%s: %s", w, r.out);
        filled[i] = filled_count(r.out, NULL);
        spawn_free(&r);
        unlink(out);
    }
    CHECK_MSG(filled[0] == filled[1] && filled[0] == 16 * 16 * 16, "filled %lld at 1e6, %lld at 0", filled[0], filled[1]);
    tmesh t = tmesh_box(1e6, 0, 0, 1e6 + 0.1, 0.1, 0.1);
    char stl[PATH_MAX], out[PATH_MAX];
    path_join(stl, sizeof stl, g_in, "far.stl");
    path_join(out, sizeof out, g_dir, "far.exr");
    CHECK(tmesh_write_stl_binary(&t, stl) == 0);
    tmesh_free(&t);
    run_result r;
    run_cli(&r, NULL, ARGS(stl, "-r", "16", "-o", out, "-q"));
    CHECK_MSG(r.code == 0 && strstr(r.err, "clvox: warning: vertices are stored as 32-bit floats"),
              "STL cube at 1e6: exit %d, stderr: %s", r.code, r.err);
    spawn_free(&r);
    unlink(out);
}

static void test_help_examples(void);

/* `--format npy -o x.json`: the data file and its sidecar would be one
 * file (the sidecar was written over the data and the run said ok). Refused
 * before any work; an existing x.json is left as it was. */
static void test_npy_sidecar_name(void)
{
    char cube[PATH_MAX];
    path_join(cube, sizeof cube, g_in, "cube.obj");
    CHECK(write_text_at(g_dir, "clash.json", "keep"));
    char p[PATH_MAX];
    path_join(p, sizeof p, g_dir, "clash.json");
    expect_failure_msg("--format npy -o x.json", 2, NULL, ARGS(cube, "-r", "8", "--format", "npy", "-o", p),
                       "is also the name of its sidecar");
    char *t = read_text(p);
    CHECK_MSG(t && strcmp(t, "keep") == 0, "--format npy -o x.json: the old x.json changed: %s", t ? t : "(gone)");
    free(t);
    path_join(p, sizeof p, g_dir, "clash2.json");
    unlink(p);
    expect_failure_msg("--format npy --oversample 2 -o y.json", 2, NULL,
                       ARGS(cube, "-r", "8", "--oversample", "2", "--format", "npy", "-o", p), "sidecar");
    struct stat sb;
    CHECK_MSG(lstat(p, &sb) != 0, "--format npy -o y.json: y.json was left");
}

/* --float-kernels: the kernels built without double precision on a
 * device that has it; the default run's, a coverage run's, a palette run's
 * and a run on voxels that are not cubes' files unchanged, no warning. */
static void test_float_kernels_flag(void)
{
    char mesh[PATH_MAX], a[PATH_MAX], b[PATH_MAX];
    path_join(mesh, sizeof mesh, g_in, "cube.obj");
    path_join(a, sizeof a, g_dir, "fk_a.exr");
    path_join(b, sizeof b, g_dir, "fk_b.exr");
    run_result r;
    run_cli(&r, NULL, ARGS(mesh, "-r", "20", "-o", a, "-q"));
    CHECK_MSG(r.code == 0, "default: exit %d: %s", r.code, r.err);
    spawn_free(&r);
    run_cli(&r, NULL, ARGS(mesh, "-r", "20", "-o", b, "-q", "--float-kernels"));
    CHECK_MSG(r.code == 0 && !*r.err, "--float-kernels: exit %d: %s", r.code, r.err);
    spawn_free(&r);
    CHECK_MSG(same_file(a, b), "--float-kernels changed the default run's file");
    run_cli(&r, NULL, ARGS(mesh, "-r", "12", "--oversample", "2,3", "-o", a, "-q"));
    CHECK_MSG(r.code == 0, "coverage: exit %d: %s", r.code, r.err);
    spawn_free(&r);
    run_cli(&r, NULL, ARGS(mesh, "-r", "12", "--oversample", "2,3", "-o", b, "-q", "--float-kernels"));
    CHECK_MSG(r.code == 0 && !*r.err, "--float-kernels coverage: exit %d: %s", r.code, r.err);
    spawn_free(&r);
    CHECK_MSG(same_file(a, b), "--float-kernels changed the coverage run's file");
    run_cli(&r, NULL, ARGS(mesh, "-r", "8", "--palette", "planar10", "--samples", "4,4", "-o", a, "-q"));
    CHECK_MSG(r.code == 0, "palette: exit %d: %s", r.code, r.err);
    spawn_free(&r);
    run_cli(&r, NULL, ARGS(mesh, "-r", "8", "--palette", "planar10", "--samples", "4,4", "-o", b, "-q",
                           "--float-kernels"));
    CHECK_MSG(r.code == 0 && !*r.err, "--float-kernels palette: exit %d: %s", r.code, r.err);
    spawn_free(&r);
    CHECK_MSG(same_file(a, b), "--float-kernels changed the palette run's file");
    run_cli(&r, NULL, ARGS(mesh, "--voxel-size", "0.1,0.1,0.15", "-o", a, "-q"));
    CHECK_MSG(r.code == 0, "voxels that are not cubes: exit %d: %s", r.code, r.err);
    spawn_free(&r);
    run_cli(&r, NULL, ARGS(mesh, "--voxel-size", "0.1,0.1,0.15", "-o", b, "-q", "--float-kernels"));
    CHECK_MSG(r.code == 0 && !*r.err, "--float-kernels, voxels that are not cubes: exit %d: %s", r.code, r.err);
    spawn_free(&r);
    CHECK_MSG(same_file(a, b), "--float-kernels changed the file of a run on voxels that are not cubes");
}

int main(void)
{
    const char *bin = getenv("CLVOX_BIN");
    if (!bin || !*bin) bin = "build/release/clvox";
    if (!test_cli_dirs(bin, "cli", g_bin, g_dir, g_in, g_out, g_logs)) return test_report();

    make_inputs();
    test_help_version();
    test_errors();
    test_real_run();
    test_options();
    test_warnings();
    test_messages();
    test_coverage_options();
    test_precision_warning();
    test_default_mesh();
    test_list_devices();
    test_float_kernels_flag();
    test_preview();
    test_preview_view();
    test_palette_files();
    test_palette_cli();
    test_palette_run();
    test_palette_run_errors();
    test_special_outputs();
    test_npy_sidecar_name();
    test_special_inputs();
    test_write_failure_messages();
    test_nohup();
    test_cancel();
    test_kill();
    test_help_examples();
    return test_report();
}

/* `clvox --help` ends with an EXAMPLES section: solid, grey levels, palette,
 * batch and a format. Each example ("  clvox ARGS" up to two spaces) runs, in
 * order, in an empty directory holding a copy of the default mesh (the batch
 * example's *.obj), and must succeed. */
static void test_help_examples(void)
{
    run_result h;
    run_cli(&h, NULL, ARGS("--help"));
    const char *ex = strstr(h.out, "\nEXAMPLES");
    CHECK_MSG(h.code == 0 && ex != NULL, "--help has no EXAMPLES section");
    if (!ex) {
        spawn_free(&h);
        return;
    }
    CHECK_MSG(strstr(ex + 1, "\n\n") == NULL, "--help: EXAMPLES is not the last section");
    static const char *const kinds[] = {"--oversample", "--palette", "clvox batch", ".npy", NULL};
    for (int i = 0; kinds[i]; i++)
        CHECK_MSG(strstr(ex, kinds[i]) != NULL, "--help EXAMPLES has no '%s' example", kinds[i]);

    char dir[PATH_MAX], mesh[PATH_MAX];
    path_join(dir, sizeof dir, g_dir, "examples");
    rm_tree(dir);
    mkdir(dir, 0777);
    char *obj = read_all("tests/data/default.obj");
    path_join(mesh, sizeof mesh, dir, "default.obj");
    CHECK_MSG(obj[0] && write_file(mesh, obj, strlen(obj)), "cannot copy tests/data/default.obj");
    free(obj);

    int runs = 0;
    for (const char *line = strchr(ex + 1, '\n'); line && line[1]; line = strchr(line + 1, '\n')) {
        if (strncmp(line + 1, "  clvox ", 8) != 0) continue;
        char cmd[256];
        const char *start = line + 9, *end = start;
        while (*end && *end != '\n' && !(end[0] == ' ' && end[1] == ' ')) end++;
        size_t len = (size_t)(end - start);
        if (len >= sizeof cmd) len = sizeof cmd - 1;
        memcpy(cmd, start, len);
        cmd[len] = '\0';
        const char *args[32];
        char files[8][PATH_MAX];
        int na = 0, nf = 0;
        for (char *tok = strtok(cmd, " "); tok && na < 31; tok = strtok(NULL, " ")) {
            size_t tl = strlen(tok);
            if (tl >= 2 && tok[0] == '\'' && tok[tl - 1] == '\'') {
                tok[tl - 1] = '\0';
                tok++;
            }
            if (tok[0] != '*') {
                args[na++] = tok;
                continue;
            }
            DIR *d = opendir(dir); /* a glob: the directory's files with that suffix */
            struct dirent *e;
            while (d && (e = readdir(d)) != NULL && na < 31 && nf < 8) {
                size_t el = strlen(e->d_name), sl = strlen(tok + 1);
                if (el > sl && strcmp(e->d_name + el - sl, tok + 1) == 0) {
                    path_join(files[nf], sizeof files[nf], dir, e->d_name);
                    args[na++] = files[nf++];
                }
            }
            if (d) closedir(d);
        }
        args[na] = NULL;
        run_result r;
        run_cli_ex(&r, dir, NULL, args, 0);
        CHECK_MSG(r.code == 0, "--help example 'clvox %.*s' exit %d: %s", (int)len, start, r.code, r.err);
        spawn_free(&r);
        runs++;
    }
    CHECK_MSG(runs >= 5, "--help EXAMPLES: %d examples, expected at least 5", runs);
    spawn_free(&h);
    rm_tree(dir);
}
