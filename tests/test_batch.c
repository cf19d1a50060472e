/* SPDX-License-Identifier: Apache-2.0 */
/* Past 800 lines on purpose: one test program for the batch command; its cases
 * share the spawned-binary fixtures. */
/* End-to-end tests of --json, clvox info --json, --like and clvox batch: runs
 * the binary ($CLVOX_BIN, default build/release/clvox) with fork/execve,
 * stdout and stderr captured into files, and parses the JSON records with
 * Python's json module (an independent, strict parser: NaN/Infinity
 * refused, the bytes must be valid UTF-8). Failed runs must give one
 * "clvox: error:" line and leave no file behind. Without python3 the JSON
 * checks print SKIP and count as neither passed nor failed. */
#ifndef _XOPEN_SOURCE
#define _XOPEN_SOURCE 700
#endif
#include "exrgen.h"
#include "meshgen.h"
#include "spawn.h"
#include "test.h"
#include "testio.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <stdarg.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#define ARGS(...) ((const char *const[]){__VA_ARGS__, NULL})
#define RUN_TIMEOUT_S 120.0

static char g_bin[PATH_MAX], g_dir[PATH_MAX], g_in[PATH_MAX], g_out[PATH_MAX], g_logs[PATH_MAX];
static unsigned g_run_id;
static int g_have_python;

typedef struct run_result {
    int code;
    char *out, *err;
    char out_path[PATH_MAX]; /* the captured stdout, for the Python checks */
} run_result;

static void reset_out(void)
{
    rm_tree(g_out);
    mkdir(g_out, 0777);
}

/* What run_prog sends (SIGINT unless set), whether the child starts with
 * SIGHUP ignored (as under nohup), and how many signals the last run got. */
static int g_signal = SIGINT, g_child_ignore_sighup, g_signals_sent;

/* The batch is under way: a file under g_out exists. */
static int batch_under_way(pid_t pid, void *arg)
{
    (void)pid;
    (void)arg;
    return dir_count(g_out) > 0;
}

/* Runs argv (argv[0] is the program) in cwd (NULL: ours). sigint_after > 0:
 * g_signal once that many seconds have passed and the batch is under way. */
static void run_prog(run_result *r, const char *cwd, const char *const *argv, double sigint_after)
{
    char err_path[PATH_MAX];
    spawn_log_paths(g_logs, ++g_run_id, r->out_path, err_path);
    spawn_opts o;
    memset(&o, 0, sizeof o);
    o.cwd = cwd;
    o.ignore_sighup = g_child_ignore_sighup;
    o.timeout_s = RUN_TIMEOUT_S;
    o.signal_after = sigint_after;
    o.signal = g_signal;
    o.signal_count = 1;
    o.signal_ready = batch_under_way;
    spawn_result s;
    spawn_run_to(&s, argv, r->out_path, err_path, &o);
    g_signals_sent = o.signals_sent;
    r->code = s.code;
    r->out = s.out;
    r->err = s.err;
}

static void run_cli_ex(run_result *r, const char *cwd, const char *const *args, double sigint_after)
{
    const char **argv = spawn_argv(g_bin, args);
    run_prog(r, cwd, argv, sigint_after);
    free(argv);
}

static void run_cli(run_result *r, const char *const *args) { run_cli_ex(r, NULL, args, 0); }

static void run_free(run_result *r)
{
    free(r->out);
    free(r->err);
    r->out = r->err = NULL;
}

static int count_of(const char *text, const char *needle)
{
    int n = 0;
    for (const char *t = text; (t = strstr(t, needle)) != NULL; t++) n++;
    return n;
}

/* Runs a Python check: the script gets the records file as sys.argv[1] and
 * the extra arguments after it; it must exit 0. Every record line is parsed
 * strictly (recs: a list of dicts) before the script's own statements. */
static void py_check(const char *what, const char *file, const char *script, ...)
{
    if (!g_have_python) return;
    static const char prelude[] =
        "import json, sys\n"
        "def bad(c): raise ValueError('non-finite number ' + c)\n"
        "raw = open(sys.argv[1], 'rb').read()\n"
        "text = raw.decode('utf-8')\n"
        "assert text == '' or text.endswith('\\n'), 'last record without a newline'\n"
        "recs = [json.loads(l, parse_constant=bad) for l in text.split('\\n') if l != '']\n"
        "assert all(isinstance(r, dict) for r in recs)\n"
        "A = sys.argv[2:]\n";
    size_t n = strlen(prelude) + strlen(script) + 2;
    char *code = malloc(n);
    if (!code) abort();
    snprintf(code, n, "%s%s\n", prelude, script);
    const char *argv[16] = {"python3", "-c", code, file};
    int k = 4;
    va_list ap;
    va_start(ap, script);
    const char *extra;
    while (k < 15 && (extra = va_arg(ap, const char *)) != NULL) argv[k++] = extra;
    va_end(ap);
    argv[k] = NULL;
    run_result r;
    run_prog(&r, NULL, argv, 0);
    CHECK_MSG(r.code == 0, "%s: the Python check failed (exit %d): %s", what, r.code, r.err);
    run_free(&r);
    free(code);
}

/* A run that must fail: exit `expected`, one "clvox: error:" line holding
 * `needle`, nothing left in g_out. */
static void expect_failure(const char *what, int expected, const char *needle, const char *const *args)
{
    run_result r;
    run_cli(&r, args);
    CHECK_MSG(r.code == expected, "%s: exit %d, expected %d; stderr: %s", what, r.code, expected, r.err);
    CHECK_MSG(count_lines(r.err) == 1 && strncmp(r.err, "clvox: error: ", 14) == 0,
              "%s: stderr must be one 'clvox: error:' line, got: [%s]", what, r.err);
    if (needle) CHECK_MSG(strstr(r.err, needle) != NULL, "%s: stderr lacks '%s': %s", what, needle, r.err);
    CHECK_MSG(dir_count(g_out) == 0, "%s: files left in the output directory", what);
    reset_out();
    run_free(&r);
}

static const char CUBE_OBJ[] =
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
    "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
/* A box [0,2]x[0,1]x[0,1]. */
static const char BOX_OBJ[] =
    "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 0 1 0\nv 0 0 1\nv 2 0 1\nv 2 1 1\nv 0 1 1\n"
    "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

static void in_path(char *dst, const char *name) { path_join(dst, PATH_MAX, g_in, name); }
static void out_path(char *dst, const char *name) { path_join(dst, PATH_MAX, g_out, name); }

/* ---- --json ---- */

static void test_json_single(void)
{
    char cube[PATH_MAX], out[PATH_MAX];
    in_path(cube, "cube.obj");
    out_path(out, "cube.exr");
    run_result r;
    run_cli(&r, ARGS(cube, "-r", "8", "-o", out, "--json"));
    CHECK_MSG(r.code == 0, "--json: exit %d: %s", r.code, r.err);
    CHECK_MSG(count_lines(r.out) == 1, "--json: stdout must be one line, got: %s", r.out);
    CHECK_MSG(r.err[0] == '\0', "--json: stderr: %s", r.err);
    char size[32];
    snprintf(size, sizeof size, "%lld", file_size(out));
    py_check("--json single", r.out_path,
             "assert len(recs) == 1, recs\n"
             "r = recs[0]\n"
             "assert r['type'] == 'mesh' and r['status'] == 'ok' and r['exit_code'] == 0 and r['error'] is None, r\n"
             "assert r['input'] == A[0] and r['output'] == A[1] and r['output_size'] == int(A[2]), r\n"
             "assert r['n'] is None\n"
             "g = r['grid']\n"
             "assert g['dims'] == [8, 8, 8] and g['origin'] == [0, 0, 0] and g['voxel_size'] == [0.125] * 3, g\n"
             "assert g['voxels'] == 512 and g['like'] is None\n"
             "assert r['filled_voxels'] == 512 and r['total_voxels'] == 512, r\n"
             "assert r['volume']['voxels'] == 1.0 and abs(r['volume']['mesh'] - 1.0) < 1e-12, r['volume']\n"
             "m = r['mesh']\n"
             "assert m['triangles'] == 12 and m['vertices'] == 8 and m['closed'] is True, m\n"
             "assert m['bbox_min'] == [0, 0, 0] and m['bbox_max'] == [1, 1, 1], m\n"
             "assert r['mode'] == 'solid' and r['method'] == 'ray' and r['parameters']['axis'] == 'x', r\n"
             "assert r['channels'] == ['occupancy'] and r['coverage_sum'] is None and r['palette'] is None\n"
             "assert r['rays']['cast'] == 64 and r['rays']['odd_parity'] == 0, r['rays']\n"
             "assert r['device']['type'] in ('cpu', 'gpu', 'accelerator', 'other'), r['device']\n"
             "s = r['seconds']\n"
             "assert set(s) == {'load','setup','partition','cast','classify','write','total','wall'}, s\n"
             "assert all(isinstance(v, (int, float)) and v >= 0 for v in s.values()), s\n"
             "assert r['warnings'] == []\n",
             cube, out, size, NULL);
    run_free(&r);
    reset_out();

    /* coverage and tetra: their parameters and fields */
    run_cli(&r, ARGS(cube, "-r", "8", "-o", out, "--json", "--oversample", "2", "--stochastic", "--seed", "5"));
    CHECK_MSG(r.code == 0, "--json --oversample: exit %d: %s", r.code, r.err);
    py_check("--json coverage", r.out_path,
             "r = recs[0]\n"
             "p = r['parameters']\n"
             "assert p['oversample'] == 2 and p['oversample_points'] == 2 and p['stochastic'] is True, p\n"
             "assert p['seed'] == 5 and r['samples_per_voxel'] == 8 and r['channels'] == ['coverage'], r\n"
             "assert abs(r['coverage_sum'] - 512) < 1e-9 and abs(r['volume']['coverage'] - 1) < 1e-9, r\n",
             NULL);
    run_free(&r);
    reset_out();

    /* an open mesh: the warning on stderr and in the record */
    char open_cube[PATH_MAX];
    in_path(open_cube, "open_cube.obj");
    run_cli(&r, ARGS(open_cube, "-r", "4", "-o", out, "--json", "--method", "tetra"));
    CHECK_MSG(r.code == 0 && lines_starting(r.err, "clvox: warning: the mesh is not closed") == 1,
              "--json open mesh: exit %d: %s", r.code, r.err);
    py_check("--json warnings", r.out_path,
             "r = recs[0]\n"
             "assert r['method'] == 'tetra' and r['parameters']['tetra_origin'] == 'centroid', r\n"
             "assert len(r['warnings']) == 1 and r['warnings'][0].startswith('the mesh is not closed'), r\n"
             "assert r['mesh']['closed'] is False and r['mesh']['boundary_edges'] == 4, r['mesh']\n",
             NULL);
    run_free(&r);
    reset_out();
}

/* Names with a quote, a backslash, a control byte and a byte that is not
 * UTF-8: the record is valid JSON and UTF-8, the name comes back exactly
 * through "<key>_hex". */
static void test_json_escaping(void)
{
    static const char name[] = "we\"ird\\na me\x01\x7f\xff\xc3\xa9.obj"; /* é is valid UTF-8 */
    char mesh[PATH_MAX], out[PATH_MAX];
    in_path(mesh, name);
    out_path(out, "we\"ird\\\t\xfe.exr");
    CHECK(write_text(mesh, CUBE_OBJ));
    run_result r;
    run_cli(&r, ARGS(mesh, "-r", "4", "-o", out, "--json"));
    CHECK_MSG(r.code == 0, "odd names: exit %d: %s", r.code, r.err);
    CHECK_MSG(count_lines(r.out) == 1, "odd names: one line: %s", r.out);
    py_check("--json escaping", r.out_path,
             "import os\n"
             "r = recs[0]\n"
             "assert os.fsencode(A[0]) == bytes.fromhex(r['input_hex']), r\n"
             "assert os.fsencode(A[1]) == bytes.fromhex(r['output_hex']), r\n"
             "assert r['input'].endswith('we\"ird\\\\na me\\x01\\x7f\\ufffd\\u00e9.obj'), ascii(r['input'])\n"
             "assert r['output'].endswith('we\"ird\\\\\\t\\ufffd.exr'), ascii(r['output'])\n"
             "assert '\\x01' not in raw.decode() or '\\\\u0001' in raw.decode()\n"
             "assert b'\\x01' not in raw and b'\\x7f' not in raw and b'\\t' not in raw\n",
             mesh, out, NULL);
    /* a valid UTF-8 name has no _hex member */
    char plain[PATH_MAX];
    in_path(plain, "cube.obj");
    run_free(&r);
    run_cli(&r, ARGS(plain, "-r", "4", "-o", out, "--json"));
    py_check("--json no _hex", r.out_path, "assert 'input_hex' not in recs[0] and 'output_hex' in recs[0]\n", NULL);
    run_free(&r);
    unlink(mesh);
    reset_out();
}

static void test_json_failure(void)
{
    char missing[PATH_MAX], out[PATH_MAX], cube[PATH_MAX];
    in_path(missing, "missing.obj");
    in_path(cube, "cube.obj");
    out_path(out, "x.exr");
    run_result r;
    run_cli(&r, ARGS(missing, "-o", out, "--json"));
    CHECK_MSG(r.code == 4, "--json missing mesh: exit %d", r.code);
    CHECK_MSG(count_lines(r.err) == 1 && strncmp(r.err, "clvox: error: ", 14) == 0, "--json missing: %s", r.err);
    CHECK_MSG(dir_count(g_out) == 0, "--json missing: files left");
    py_check("--json failed record", r.out_path,
             "assert len(recs) == 1\n"
             "r = recs[0]\n"
             "assert r['status'] == 'failed' and r['exit_code'] == 4 and 'missing.obj' in r['error'], r\n"
             "assert r['mesh'] is None and r['grid'] is None and r['filled_voxels'] is None, r\n"
             "assert r['output_size'] is None and r['device'] is None\n",
             NULL);
    run_free(&r);
    /* a grid error: the mesh is known, the grid is not */
    run_cli(&r, ARGS(cube, "--dims", "70000,1,1", "-o", out, "--json"));
    CHECK_MSG(r.code == 6, "--json grid error: exit %d: %s", r.code, r.err);
    py_check("--json grid error", r.out_path,
             "r = recs[0]\n"
             "assert r['status'] == 'failed' and r['exit_code'] == 6 and r['mesh']['triangles'] == 12, r\n"
             "assert r['grid'] is None\n",
             NULL);
    run_free(&r);
    /* usage errors print no record */
    run_cli(&r, ARGS(cube, "-r", "x", "--json"));
    CHECK_MSG(r.code == 2 && r.out[0] == '\0', "--json usage error: exit %d, stdout %s", r.code, r.out);
    run_free(&r);
    reset_out();
}

static void test_info_json(void)
{
    char box[PATH_MAX], out[PATH_MAX];
    in_path(box, "box.obj");
    out_path(out, "box.exr");
    run_result r;
    run_cli(&r, ARGS(box, "-r", "8", "-o", out, "--oversample", "2", "--channels", "occupancy,coverage", "-q"));
    CHECK_MSG(r.code == 0, "box: exit %d: %s", r.code, r.err);
    run_free(&r);
    run_cli(&r, ARGS("info", out, "--json"));
    CHECK_MSG(r.code == 0 && count_lines(r.out) == 1, "info --json: exit %d: %s %s", r.code, r.out, r.err);
    char size[32];
    snprintf(size, sizeof size, "%lld", file_size(out));
    py_check("info --json", r.out_path,
             "r = recs[0]\n"
             "assert r['type'] == 'volume' and r['file'] == A[0] and r['file_size'] == int(A[1]), r\n"
             "g = r['grid']\n"
             "assert g['dims'] == [8, 4, 4] and g['origin'] == [0, 0, 0] and g['voxel_size'] == [0.25] * 3, g\n"
             "assert r['channels'] == ['coverage', 'occupancy'], r['channels']\n"
             "assert r['filled_voxels'] == 128 and r['total_voxels'] == 128 and r['coverage_sum'] == 128, r\n"
             "assert r['volume'] == {'voxels': 2, 'coverage': 2}, r['volume']\n"
             "assert r['method'] == 'ray' and r['version'] and r['compression'] == 'rle' and r['palette'] is None\n",
             out, size, NULL);
    run_free(&r);
    reset_out();
    char random_exr[PATH_MAX];
    in_path(random_exr, "random.exr");
    expect_failure("info --json on garbage", 4, NULL, ARGS("info", random_exr, "--json"));
    reset_out();
}

/* ---- --like ---- */

static void test_like(void)
{
    char box[PATH_MAX], cube[PATH_MAX], ref[PATH_MAX], out[PATH_MAX];
    in_path(box, "box.obj");
    in_path(cube, "cube.obj");
    in_path(ref, "ref.exr"); /* kept in g_in: g_out must stay empty after failures */
    out_path(out, "aligned.exr");
    run_result r;
    run_cli(&r, ARGS(box, "--dims", "9,5,3", "--pad", "1", "-o", ref, "-q"));
    CHECK_MSG(r.code == 0, "like ref: exit %d: %s", r.code, r.err);
    run_free(&r);
    run_cli(&r, ARGS("info", ref, "--json"));
    char ref_json[PATH_MAX];
    snprintf(ref_json, sizeof ref_json, "%s", r.out_path);
    run_result r2;
    run_cli(&r2, ARGS(cube, "--like", ref, "-o", out, "--json"));
    CHECK_MSG(r2.code == 0, "--like: exit %d: %s", r2.code, r2.err);
    py_check("--like grid", r2.out_path,
             "ref = json.loads(open(A[0]).read())['grid']\n"
             "g = recs[0]['grid']\n"
             "assert g['dims'] == ref['dims'] == [11, 7, 5], (g, ref)\n"
             "assert g['origin'] == ref['origin'] and g['voxel_size'] == ref['voxel_size'], (g, ref)\n"
             "assert g['like'] == A[1]\n",
             ref_json, ref, NULL);
    run_free(&r2);
    run_cli(&r2, ARGS("info", out, "--json"));
    py_check("--like file", r2.out_path,
             "ref = json.loads(open(A[0]).read())['grid']\n"
             "assert recs[0]['grid'] == ref, (recs[0]['grid'], ref)\n",
             ref_json, NULL);
    run_free(&r2);
    run_free(&r);
    reset_out();

    /* conflicts, files without a grid, formats not read yet */
    static const char *const conflicts[][2] = {{"-r", "8"}, {"--dims", "2,2,2"}, {"--voxel-size", "0.5"},
                                               {"--box", "0,0,0,1,1,1"}, {"--pad", "0"}};
    for (size_t i = 0; i < sizeof conflicts / sizeof conflicts[0]; i++) {
        char what[64];
        snprintf(what, sizeof what, "--like with %s", conflicts[i][0]);
        expect_failure(what, 2, "can not be combined", ARGS(cube, "--like", ref, conflicts[i][0], conflicts[i][1], "-o", out));
        expect_failure(what, 2, "can not be combined", ARGS(cube, conflicts[i][0], conflicts[i][1], "--like", ref, "-o", out));
    }
    char random_exr[PATH_MAX], plain_exr[PATH_MAX], nrrd[PATH_MAX], missing[PATH_MAX];
    in_path(random_exr, "random.exr");
    in_path(plain_exr, "plain.exr");
    in_path(nrrd, "scan.nrrd");
    in_path(missing, "missing.exr");
    expect_failure("--like garbage", 4, "--like", ARGS(cube, "--like", random_exr, "-o", out));
    expect_failure("--like EXR without a grid", 4, "not a clvox volume", ARGS(cube, "--like", plain_exr, "-o", out));
    expect_failure("--like NRRD without a space", 4, "no 'space' field", ARGS(cube, "--like", nrrd, "-o", out));
    expect_failure("--like mesh", 4, "expected a clvox volume", ARGS(cube, "--like", cube, "-o", out));
    expect_failure("--like missing", 4, "missing.exr", ARGS(cube, "--like", missing, "-o", out));
    expect_failure("--like empty", 2, NULL, ARGS(cube, "--like", "", "-o", out));
    expect_failure("--like no value", 2, NULL, ARGS(cube, "-o", out, "--like"));
}

static int same_bytes(const char *a, const char *b)
{
    FILE *fa = fopen(a, "rb"), *fb = fopen(b, "rb");
    int same = fa && fb;
    while (same) {
        int ca = getc(fa), cb = getc(fb);
        if (ca != cb) same = 0;
        if (ca == EOF || cb == EOF) break;
    }
    if (fa) fclose(fa);
    if (fb) fclose(fb);
    return same;
}

static int copy_bytes(const char *from, const char *to)
{
    FILE *a = fopen(from, "rb"), *b = fopen(to, "wb");
    int ok = a && b, c;
    while (ok && (c = getc(a)) != EOF) ok = putc(c, b) != EOF;
    if (a) fclose(a);
    if (b && fclose(b) != 0) ok = 0;
    return ok;
}

/* A set of files (npy; NRRD with two channels) mixed from two runs, as a
 * kill between two renames leaves it: batch --skip-existing voxelizes it
 * again (with a warning) instead of skipping it for ever, --like refuses it;
 * once redone, the set is skipped. */
static void test_batch_mixed_sets(void)
{
    char box[PATH_MAX], cube[PATH_MAX];
    in_path(box, "box.obj");
    in_path(cube, "cube.obj");
    static const char *const exts[2] = {"npy", "nrrd"};
    for (int e = 0; e < 2; e++) {
        char m[PATH_MAX], o[PATH_MAX], mixed_from[PATH_MAX], mixed_to[PATH_MAX], keep[PATH_MAX], name[64];
        snprintf(name, sizeof name, "m.%s", exts[e]);
        out_path(m, name);
        snprintf(name, sizeof name, "o.%s", exts[e]);
        out_path(o, name);
        /* npy: another run's OUT.npy beside this set's OUT.json; NRRD:
         * another run's OUT.coverage.nrrd beside this set's OUT.nrrd */
        snprintf(name, sizeof name, e == 0 ? "o.%s" : "o.coverage.%s", exts[e]);
        out_path(mixed_from, name);
        snprintf(name, sizeof name, e == 0 ? "m.%s" : "m.coverage.%s", exts[e]);
        out_path(mixed_to, name);
        out_path(keep, "keep.bin");
        run_result r;
        run_cli(&r, ARGS("batch", box, "-r", "8", "--box", "0,0,0,2,2,2", "--oversample", "2", "--channels",
                         "occupancy,coverage", "-o", m, "-q"));
        CHECK_MSG(r.code == 0, "mixed %s: exit %d: %s", exts[e], r.code, r.err);
        run_free(&r);
        run_cli(&r, ARGS(cube, "-r", "8", "--box", "0,0,0,2,2,2", "--oversample", "2", "--channels",
                         "occupancy,coverage", "-o", o, "-q"));
        CHECK_MSG(r.code == 0, "mixed %s: exit %d: %s", exts[e], r.code, r.err);
        run_free(&r);
        CHECK(copy_bytes(mixed_to, keep) && !same_bytes(mixed_to, mixed_from));
        CHECK(copy_bytes(mixed_from, mixed_to));
        if (e == 0) {
            char like[PATH_MAX];
            out_path(like, "like.npy");
            run_cli(&r, ARGS(cube, "--like", m, "-o", like));
            CHECK_MSG(r.code == 4 && count_lines(r.err) == 1 && strstr(r.err, "mixed set") && !file_exists(like),
                      "--like a mixed npy set: exit %d: %s", r.code, r.err);
            run_free(&r);
        }
        run_cli(&r, ARGS("batch", box, "-r", "8", "--box", "0,0,0,2,2,2", "--oversample", "2", "--channels",
                         "occupancy,coverage", "-o", m, "--skip-existing"));
        CHECK_MSG(r.code == 0 && strstr(r.out, "1 meshes: 1 ok, 0 failed, 0 skipped"),
                  "--skip-existing on a mixed %s set: exit %d: %s", exts[e], r.code, r.out);
        CHECK_MSG(strstr(r.err, "mixed set") && strstr(r.err, "voxelizing it again"), "%s", r.err);
        CHECK_MSG(same_bytes(mixed_to, keep), "%s: not redone", mixed_to);
        run_free(&r);
        run_cli(&r, ARGS("batch", box, "-r", "8", "--box", "0,0,0,2,2,2", "--oversample", "2", "--channels",
                         "occupancy,coverage", "-o", m, "--skip-existing"));
        CHECK_MSG(r.code == 0 && strstr(r.out, "1 meshes: 0 ok, 0 failed, 1 skipped"),
                  "--skip-existing on a whole %s set: exit %d: %s", exts[e], r.code, r.out);
        run_free(&r);
        reset_out();
    }
}

/* --like on clvox's own NRRD and NumPy outputs (same volume again), a
 * Slicer-style NRRD header, and malformed headers (exit 4, one line). */
static void test_like_formats(void)
{
    char box[PATH_MAX], ref_nrrd[PATH_MAX], ref_npy[PATH_MAX], ref_json[PATH_MAX], ref_cov[PATH_MAX], out[PATH_MAX];
    in_path(box, "box.obj");
    in_path(ref_nrrd, "grid.nrrd");
    in_path(ref_npy, "grid.npy");
    in_path(ref_json, "grid.json");
    in_path(ref_cov, "grid.coverage.npy");
    run_result r;
    run_cli(&r, ARGS(box, "--dims", "9,5,3", "--pad", "1", "-o", ref_nrrd, "-q"));
    CHECK_MSG(r.code == 0, "like ref nrrd: exit %d: %s", r.code, r.err);
    run_free(&r);
    run_cli(&r, ARGS(box, "--dims", "9,5,3", "--pad", "1", "--oversample", "2", "--channels", "occupancy,coverage", "-o", ref_npy, "-q"));
    CHECK_MSG(r.code == 0, "like ref npy: exit %d: %s", r.code, r.err);
    run_free(&r);
    const char *const likes[][3] = {{ref_nrrd, "a.nrrd", ref_nrrd}, {ref_npy, "b.npy", ref_npy},
                                    {ref_json, "c.npy", ref_npy}, {ref_cov, "d.npy", ref_npy}};
    for (size_t i = 0; i < 4; i++) {
        out_path(out, likes[i][1]);
        int npy = strstr(likes[i][1], ".npy") != NULL;
        run_cli(&r, npy ? ARGS(box, "--like", likes[i][0], "--oversample", "2", "--channels", "occupancy,coverage", "-o", out, "-q")
                        : ARGS(box, "--like", likes[i][0], "-o", out, "-q"));
        CHECK_MSG(r.code == 0 && r.err[0] == '\0', "--like %s: exit %d: %s", likes[i][0], r.code, r.err);
        CHECK_MSG(same_bytes(out, likes[i][2]), "--like %s: %s differs from %s", likes[i][0], out, likes[i][2]);
        if (npy) {
            char a[PATH_MAX], b[PATH_MAX];
            /* (the sidecars differ only in the file names they list) */
            out_path(a, likes[i][1]);
            strcpy(strrchr(a, '.'), ".coverage.npy");
            in_path(b, "grid.coverage.npy");
            CHECK_MSG(same_bytes(a, b), "--like %s: the coverage differs", likes[i][0]);
        }
        run_free(&r);
        reset_out();
    }

    /* a header as 3D Slicer writes it (gzip data after the blank line) */
    char slicer[PATH_MAX];
    in_path(slicer, "slicer_seg.nrrd");
    FILE *f = fopen(slicer, "wb");
    CHECK(f != NULL);
    if (f) {
        fputs("NRRD0004\r\n# Complete NRRD file format specification at:\r\n"
              "# http://teem.sourceforge.net/nrrd/format.html\r\n"
              "type: short\r\ndimension: 3\r\nspace: right-anterior-superior\r\nsizes: 4 3 2\r\n"
              "space directions: (0.5,0,0) (0, 0.25, 0) (0,0,2)\r\nkinds: domain domain domain\r\n"
              "endian: little\r\nencoding: gzip\r\nspace units: \"mm\" \"mm\" \"mm\"\r\n"
              "space origin: (10,-20.5,30)\r\nSegment0_Color:=0.5 0.68 0.5\r\nSegment0_Name:=liver\r\n\r\n", f);
        static const unsigned char gz[] = {0x1f, 0x8b, 0x08, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x03, 0x0a, 0x00};
        fwrite(gz, 1, sizeof gz, f);
        CHECK(fclose(f) == 0);
    }
    out_path(out, "slicer.exr");
    run_cli(&r, ARGS(box, "--like", slicer, "-o", out, "--json"));
    CHECK_MSG(r.code == 0, "--like Slicer NRRD: exit %d: %s", r.code, r.err);
    CHECK_MSG(count_lines(r.err) == 1 && strstr(r.err, "warning") && strstr(r.err, "right-anterior-superior"),
              "--like Slicer NRRD: expected one warning about the space: [%s]", r.err);
    py_check("--like Slicer NRRD", r.out_path,
             "g = recs[0]['grid']\n"
             "assert g['dims'] == [4, 3, 2], g\n"
             "assert g['origin'] == [9.75, -20.625, 29.0] and g['voxel_size'] == [0.5, 0.25, 2.0], g\n",
             NULL);
    run_free(&r);
    reset_out();

    /* malformed headers: each one line, exit 4 */
    static const char *const bad[][2] = {
        {"NRRD0004\ndimension: 3\nsizes: 2 2 2\nspace: RAS\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n", "truncated"},
        {"NRRD0004\ndimension: 3\nsizes: 2 2 2\nspace: RAS\nspace directions: (1,0.5,0) (0,1,0) (0,0,1)\n"
         "space origin: (0,0,0)\n\n", "only axis-aligned grids"},
        {"NRRD0004\ndimension: 3\nsizes: 2 2 2\nspace: RAS\nspace directions: (-1,0,0) (0,1,0) (0,0,1)\n"
         "space origin: (0,0,0)\n\n", "only axis-aligned grids"},
        {"NRRD0004\ndimension: 4\nsizes: 3 2 2 2\n\n", "only 3-D scalar"},
        {"NRRD0004\ndimension: 3\nsizes: 2 2\n\n", "sizes"},
        {"NRRD0004\ndimension: 3\nsizes: 2 2 2\nspace: RAS\nspace directions: (1,0,0) none (0,0,1)\n"
         "space origin: (0,0,0)\n\n", "space directions"},
        {"NRRD0004\ndimension: 3\nsizes: 2 2 2\nspace: RAS\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n"
         "space origin: (nan,0,0)\n\n", "space origin"},
        {"NRRD0004\ndimension: 3\nsizes: 2 2 2\nspace: RAS\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n\n", "space origin"},
        {"NRRD0004\ndimension: 3\nsizes: 2 2 2\nspace: RAST\n\n", "RAST"},
        {"NRRD0004\ndimension: 3\nsizes: 2 2 2\nkinds: vector domain domain\n\n", "only 3-D scalar"},
        {"NRRD0004\ngarbage\n\n", "not 'field: value'"},
        {"P6 not nrrd\n", "NRRD000N"},
        {"", "NRRD000N"},
    };
    char p[PATH_MAX];
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        char name[32], what[64];
        snprintf(name, sizeof name, "bad%zu.nrrd", i);
        in_path(p, name);
        CHECK(write_text(p, bad[i][0]));
        snprintf(what, sizeof what, "--like bad NRRD %zu", i);
        out_path(out, "x.exr");
        expect_failure(what, 4, bad[i][1], ARGS(box, "--like", p, "-o", out));
    }
    static const char *const bad_json[][2] = {
        {"{\"format\": \"npy\", \"dims\": [2, 2], \"origin\": [0, 0, 0], \"voxel_size\": [1, 1, 1]}", "dims"},
        {"{\"format\": \"npy\", \"dims\": [2, 2, 2], \"origin\": [0, 0, 0], \"voxel_size\": [1, 0, 1]}", "positive"},
        {"{\"format\": \"npy\", \"dims\": [2, 2, 2], \"origin\": [0, 0, 0]", "truncated"},
        {"{\"format\": \"nrrd\", \"dims\": [2, 2, 2], \"origin\": [0, 0, 0], \"voxel_size\": [1, 1, 1]}", "not a clvox .npy sidecar"},
        {"[1, 2, 3]", "not a JSON object"},
        {"{\"format\": \"npy\", \"dims\": [2.5, 2, 2], \"origin\": [0, 0, 0], \"voxel_size\": [1, 1, 1]}", "integer"},
    };
    for (size_t i = 0; i < sizeof bad_json / sizeof bad_json[0]; i++) {
        char name[32], what[64];
        snprintf(name, sizeof name, "bad%zu.json", i);
        in_path(p, name);
        CHECK(write_text(p, bad_json[i][0]));
        snprintf(what, sizeof what, "--like bad sidecar %zu", i);
        out_path(out, "x.exr");
        expect_failure(what, 4, bad_json[i][1], ARGS(box, "--like", p, "-o", out));
    }
    in_path(p, "lonely.npy");
    CHECK(write_text(p, "not read"));
    expect_failure("--like .npy without a sidecar", 4, "no readable sidecar", ARGS(box, "--like", p, "-o", out));
}


/* ---- clvox batch ---- */

static long long filled_of(const char *exr)
{
    run_result r;
    run_cli(&r, ARGS("info", exr));
    long long f = -1;
    const char *p = strstr(r.out, "filled");
    if (r.code == 0 && p) sscanf(p + 6, " %lld", &f);
    run_free(&r);
    return f;
}

static void test_batch_basic(void)
{
    char cube[PATH_MAX], box[PATH_MAX], open_cube[PATH_MAX], tpl[PATH_MAX], p[PATH_MAX];
    in_path(cube, "cube.obj");
    in_path(box, "box.obj");
    in_path(open_cube, "open_cube.obj");
    out_path(tpl, "{stem}_{n}.exr");
    run_result r;
    run_cli(&r, ARGS("batch", cube, box, open_cube, "-r", "8", "-o", tpl, "--json"));
    CHECK_MSG(r.code == 0, "batch: exit %d: %s", r.code, r.err);
    /* the open cube is closed by a cap for the winding number: no warning */
    CHECK_MSG(lines_starting(r.err, "clvox: [") == 3 && lines_starting(r.err, "clvox: warning: ") == 0 &&
                  count_lines(r.err) == 3,
              "batch: stderr: %s", r.err);
    CHECK_MSG(count_lines(r.out) == 4, "batch: 3 records and the batch record: %s", r.out);
    out_path(p, "cube_0.exr");
    CHECK(filled_of(p) == 512);
    out_path(p, "box_1.exr");
    CHECK(filled_of(p) == 8 * 4 * 4);
    out_path(p, "open_cube_2.exr");
    CHECK(filled_of(p) == 512);
    py_check("batch records", r.out_path,
             "m = recs[:3]\n"
             "assert [x['n'] for x in m] == [0, 1, 2] and all(x['status'] == 'ok' for x in m), m\n"
             "assert [x['input'] for x in m] == A[0:3], m\n"
             "assert m[1]['grid']['dims'] == [8, 4, 4] and m[0]['filled_voxels'] == 512\n"
             "assert m[0]['seconds']['setup'] > 0 and m[1]['seconds']['setup'] == 0 == m[2]['seconds']['setup']\n"
             "assert all(x['seconds']['load'] > 0 for x in m), m  # the later ones loaded ahead\n"
             "assert len(m[2]['warnings']) == 0 and m[2]['filled_voxels'] == 512\n"
             "b = recs[3]\n"
             "assert b['type'] == 'batch' and b['meshes'] == 3 and b['ok'] == 3 and b['failed'] == 0, b\n"
             "assert b['skipped'] == 0 and b['not_run'] == 0 and b['cancelled'] is False and b['exit_code'] == 0, b\n"
             "assert b['shard'] == [0, 1] and b['meshes_per_second'] > 0\n",
             cube, box, open_cube, NULL);
    run_free(&r);

    /* --skip-existing: nothing is voxelized again */
    out_path(p, "cube_0.exr");
    struct stat before, after;
    CHECK(stat(p, &before) == 0);
    run_cli(&r, ARGS("batch", cube, box, open_cube, "-r", "8", "-o", tpl, "--skip-existing"));
    CHECK_MSG(r.code == 0 && strstr(r.out, "3 meshes: 0 ok, 0 failed, 3 skipped, 0 not run"),
              "--skip-existing: exit %d: %s", r.code, r.out);
    CHECK(stat(p, &after) == 0 && after.st_ino == before.st_ino && after.st_mtime == before.st_mtime);
    CHECK_MSG(lines_starting(r.err, "clvox: [") == 3 && strstr(r.err, "skipped"), "skip: %s", r.err);
    run_free(&r);
    /* -q: nothing but errors */
    unlink(p);
    run_cli(&r, ARGS("batch", cube, box, open_cube, "-r", "8", "-o", tpl, "--skip-existing", "-q"));
    CHECK_MSG(r.code == 0 && r.out[0] == '\0' && lines_starting(r.err, "clvox: [") == 0, "-q: %s %s", r.out, r.err);
    CHECK(filled_of(p) == 512);
    run_free(&r);
    reset_out();

    /* a fixed --box: one frame for all */
    run_cli(&r, ARGS("batch", cube, box, "-r", "4", "--box", "0,0,0,2,2,2", "-o", tpl, "--json"));
    py_check("batch --box", r.out_path,
             "assert recs[0]['grid'] == recs[1]['grid'] and recs[0]['grid']['dims'] == [4, 4, 4], recs\n"
             "assert recs[0]['filled_voxels'] == 8 and recs[1]['filled_voxels'] == 16\n",
             NULL);
    run_free(&r);
    reset_out();

    run_cli(&r, ARGS("batch", "--help"));
    CHECK_MSG(r.code == 0 && strncmp(r.out, "Usage: clvox batch", 18) == 0 && r.err[0] == '\0', "batch --help: %s",
              r.err);
    static const char *const needed[] = {"--dir", "--manifest", "--shard", "--skip-existing", "--keep-going",
                                         "--no-keep-going", "{stem}", "{dir}", "{n}", "--json"};
    for (size_t i = 0; i < sizeof needed / sizeof needed[0]; i++)
        CHECK_MSG(strstr(r.out, needed[i]) != NULL, "batch --help lacks %s", needed[i]);
    run_free(&r);
}

static void test_batch_failures(void)
{
    char cube[PATH_MAX], box[PATH_MAX], empty[PATH_MAX], missing[PATH_MAX], tpl[PATH_MAX], p[PATH_MAX];
    in_path(cube, "cube.obj");
    in_path(box, "box.obj");
    in_path(empty, "empty.obj");
    in_path(missing, "missing.obj");
    out_path(tpl, "{stem}.exr");
    run_result r;
    /* keep going (default): the bad meshes are recorded, the rest written */
    run_cli(&r, ARGS("batch", cube, empty, missing, box, "-r", "4", "-o", tpl, "--json"));
    CHECK_MSG(r.code == 4, "keep going: exit %d: %s", r.code, r.err);
    CHECK_MSG(lines_starting(r.err, "clvox: error: ") == 2, "keep going: two error lines: %s", r.err);
    CHECK_MSG(strstr(r.err, "clvox: error: ") && strstr(r.err, empty), "the error names the mesh: %s", r.err);
    CHECK(dir_count(g_out) == 2);
    py_check("keep going", r.out_path,
             "s = [x['status'] for x in recs[:4]]\n"
             "assert s == ['ok', 'failed', 'failed', 'ok'], s\n"
             "assert recs[1]['exit_code'] == 4 and recs[1]['error'] and recs[1]['output_size'] is None\n"
             "assert 'missing.obj' in recs[2]['error']\n"
             "b = recs[4]\n"
             "assert b['ok'] == 2 and b['failed'] == 2 and b['exit_code'] == 4, b\n",
             NULL);
    run_free(&r);
    reset_out();
    /* --no-keep-going: stops at the first failure */
    run_cli(&r, ARGS("batch", cube, empty, box, "-r", "4", "-o", tpl, "--no-keep-going"));
    CHECK_MSG(r.code == 4 && strstr(r.out, "3 meshes: 1 ok, 1 failed, 0 skipped, 1 not run"),
              "--no-keep-going: exit %d: %s", r.code, r.out);
    out_path(p, "box.exr");
    CHECK(!file_exists(p));
    run_free(&r);
    reset_out();
    /* an unwritable output is that mesh's failure */
    char sub[PATH_MAX];
    out_path(sub, "cube.exr");
    mkdir(sub, 0777); /* a directory where cube's output goes */
    run_cli(&r, ARGS("batch", cube, box, "-r", "4", "-o", tpl));
    CHECK_MSG(r.code == 5 && strstr(r.out, "2 meshes: 1 ok, 1 failed"), "unwritable: exit %d: %s", r.code, r.out);
    run_free(&r);
    reset_out();

    /* bad arguments: one line, exit 2, nothing written */
    char t_bad[PATH_MAX], t_brace[PATH_MAX];
    out_path(t_bad, "{foo}.exr");
    out_path(t_brace, "a}.exr");
    expect_failure("unknown template field", 2, "unknown field", ARGS("batch", cube, "-o", t_bad));
    expect_failure("single brace", 2, "'}'", ARGS("batch", cube, "-o", t_brace));
    expect_failure("unclosed field", 2, "unknown field", ARGS("batch", cube, "-o", "x{stem"));
    static const char *const shards[] = {"1/0", "2/2", "a/b", "1", "-1/2", "1/2/3", "/2", ""};
    for (size_t i = 0; i < sizeof shards / sizeof shards[0]; i++) {
        char what[64];
        snprintf(what, sizeof what, "--shard '%s'", shards[i]);
        expect_failure(what, 2, "--shard", ARGS("batch", cube, "--shard", shards[i], "-o", tpl));
    }
    expect_failure("no meshes", 2, "no meshes", ARGS("batch", "-o", tpl));
    char nodir[PATH_MAX];
    in_path(nodir, "nodir");
    expect_failure("missing --dir", 4, "nodir", ARGS("batch", "--dir", nodir, "-o", tpl));
    expect_failure("missing --manifest", 4, "nodir", ARGS("batch", "--manifest", nodir, "-o", tpl));
    /* two meshes, one output */
    char d2[PATH_MAX], cube2[PATH_MAX];
    in_path(d2, "d2");
    mkdir(d2, 0777);
    path_join(cube2, sizeof cube2, d2, "cube.obj");
    CHECK(write_text(cube2, CUBE_OBJ));
    expect_failure("same output", 2, "would both be written", ARGS("batch", cube, cube2, "-o", tpl));
    expect_failure("unknown batch option", 2, "--frobnicate", ARGS("batch", cube, "--frobnicate"));
    expect_failure("--dir twice", 2, "twice", ARGS("batch", "--dir", g_in, "--dir", g_in, "-o", tpl));
}

static void test_batch_lists(void)
{
    char tpl[PATH_MAX], man[PATH_MAX], p[PATH_MAX];
    out_path(tpl, "{n}_{stem}.exr");
    run_result r;
    /* --dir: the mesh files, sorted; shards split them with stable names */
    char d[PATH_MAX];
    in_path(d, "set");
    mkdir(d, 0777);
    static const char *const names[] = {"b.obj", "a.OBJ", "c.obj", "d.obj", "e.obj"};
    for (size_t i = 0; i < 5; i++) {
        path_join(p, sizeof p, d, names[i]);
        CHECK(write_text(p, CUBE_OBJ));
    }
    path_join(p, sizeof p, d, "notes.txt");
    CHECK(write_text(p, "not a mesh"));
    run_cli(&r, ARGS("batch", "--dir", d, "-r", "2", "-o", tpl, "--shard", "0/2", "-q"));
    CHECK_MSG(r.code == 0, "shard 0/2: exit %d: %s", r.code, r.err);
    run_free(&r);
    run_cli(&r, ARGS("batch", "--dir", d, "-r", "2", "-o", tpl, "--shard", "1/2", "--json"));
    CHECK_MSG(r.code == 0, "shard 1/2: exit %d: %s", r.code, r.err);
    py_check("shard 1/2", r.out_path,
             "assert [x['n'] for x in recs[:-1]] == [1, 3], recs\n"
             "assert recs[-1]['listed'] == 5 and recs[-1]['meshes'] == 2 and recs[-1]['shard'] == [1, 2]\n",
             NULL);
    run_free(&r);
    static const char *const expect[] = {"0_a.exr", "1_b.exr", "2_c.exr", "3_d.exr", "4_e.exr"};
    CHECK(dir_count(g_out) == 5);
    for (size_t i = 0; i < 5; i++) {
        out_path(p, expect[i]);
        CHECK_MSG(file_exists(p), "missing %s", expect[i]);
    }
    reset_out();

    /* a manifest: overrides, comments, quotes, a missing mesh recorded with its line */
    char cube[PATH_MAX], box[PATH_MAX], spaced[PATH_MAX], o1[PATH_MAX];
    in_path(cube, "cube.obj");
    in_path(box, "box.obj");
    in_path(spaced, "with space.obj");
    CHECK(write_text(spaced, CUBE_OBJ));
    out_path(o1, "own name.exr");
    static char text[6 * PATH_MAX + 256];
    snprintf(text, sizeof text,
             "# meshes\n"
             "%s -r 4\n"
             "\n"
             "   \t\n"
             "\"%s\" -o \"%s\"\r\n"
             "%s --dims 2,2,2\n"
             "%s/missing.obj\n",
             cube, spaced, o1, box, g_in);
    in_path(man, "list.txt");
    CHECK(write_text(man, text));
    run_cli(&r, ARGS("batch", "--manifest", man, "-r", "8", "-o", tpl, "--json"));
    CHECK_MSG(r.code == 4, "manifest: exit %d: %s", r.code, r.err);
    char needle[PATH_MAX + 64];
    snprintf(needle, sizeof needle, "clvox: error: %s:7: ", man);
    CHECK_MSG(strstr(r.err, needle) != NULL, "manifest: the error has FILE:LINE: %s", r.err);
    py_check("manifest", r.out_path,
             "m = recs[:-1]\n"
             "assert [x['line'] for x in m] == [2, 5, 6, 7], m\n"
             "assert m[0]['grid']['dims'] == [4, 4, 4] and m[1]['grid']['dims'] == [8, 8, 8], m\n"
             "assert m[2]['grid']['dims'] == [2, 2, 2] and m[1]['output'] == A[0], m\n"
             "assert m[1]['input'].endswith('with space.obj')\n"
             "assert [x['status'] for x in m] == ['ok', 'ok', 'ok', 'failed']\n"
             "assert m[3]['manifest'] == A[1] + ':7'\n",
             o1, man, NULL);
    run_free(&r);
    reset_out();

    /* malformed lines: FILE:LINE, exit 2, nothing voxelized */
    char ref[PATH_MAX];
    in_path(ref, "ref.exr");
    static const char *const bad[][2] = {
        {"%s -x 3\n", "unknown option"},
        {"%s -o\n", "needs a value"},
        {"\"%s -r 4\n", "unterminated"},
        {"%s -r 4 --dims 2,2,2\n", "more than one"},
        {"%s -r 0\n", "-r '0'"},
        {"%s -o a.exr -o b.exr\n", "twice"},
        {"-r 4 %s\n", "must start with the mesh"},
        {"", "NUL"}, /* written below: "x\0y" */
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        char line[2 * PATH_MAX + 128];
        int n = snprintf(line, sizeof line, "%s\n", cube); /* a good first line */
        n += snprintf(line + n, sizeof line - (size_t)n, bad[i][0], cube);
        if (i == 7) {
            memcpy(line + n, "x\0y\n", 4);
            n += 4;
        }
        FILE *f = fopen(man, "wb");
        CHECK(f && fwrite(line, 1, (size_t)n, f) == (size_t)n && fclose(f) == 0);
        char what[64], where[PATH_MAX + 64];
        snprintf(what, sizeof what, "manifest line %zu", i);
        snprintf(where, sizeof where, "%s:2: ", man);
        run_cli(&r, ARGS("batch", "--manifest", man, "-o", tpl));
        CHECK_MSG(r.code == 2 && count_lines(r.err) == 1 && strstr(r.err, where) && strstr(r.err, bad[i][1]),
                  "%s: exit %d: %s", what, r.code, r.err);
        CHECK_MSG(dir_count(g_out) == 0, "%s: files written", what);
        run_free(&r);
        reset_out();
    }
    snprintf(text, sizeof text, "%s -r 4\n", cube);
    CHECK(write_text(man, text));
    run_cli(&r, ARGS("batch", "--manifest", man, "--like", ref, "-o", tpl));
    CHECK_MSG(r.code == 2 && strstr(r.err, ":1: ") && strstr(r.err, "--like"), "override with --like: %d %s", r.code,
              r.err);
    run_free(&r);
    reset_out();
}

/* A manifest whose lines are the given strings; then runs the batch on it
 * with args after "--manifest FILE". */
static void run_manifest(run_result *r, const char *text, const char *const *args)
{
    char man[PATH_MAX];
    in_path(man, "same.txt");
    CHECK(write_text(man, text));
    const char *argv[16] = {"batch", "--manifest", man};
    size_t k = 3;
    for (size_t i = 0; args[i] && k < 15; i++) argv[k++] = args[i];
    argv[k] = NULL;
    run_cli(r, argv);
}

/* A collision must be refused before anything runs: exit 2, one line
 * holding `needle`, nothing written. */
static void expect_same_file(const char *what, const run_result *r, const char *needle)
{
    CHECK_MSG(r->code == 2, "%s: exit %d, expected 2 (one file written twice); stderr: %s", what, r->code, r->err);
    CHECK_MSG(count_lines(r->err) == 1 && strstr(r->err, needle), "%s: one error line with '%s': %s", what, needle,
              r->err);
    CHECK_MSG(dir_count(g_out) == 0, "%s: files written", what);
    reset_out();
}

/* Quoted "#x.obj" is a mesh, not a comment; one output file under two
 * spellings (./, a symbolic link to the directory, dir/.., a .npy's
 * sidecar or channel file, two spellings of one mesh through {dir}, lines
 * of two shards) is refused like two equal names. */
static void test_batch_same_file(void)
{
    char hash[PATH_MAX], cube[PATH_MAX], box[PATH_MAX], o1[PATH_MAX], o2[PATH_MAX], lnk[PATH_MAX], p[PATH_MAX];
    static char text[8 * PATH_MAX];
    in_path(hash, "#x.obj");
    CHECK(write_text(hash, CUBE_OBJ));
    in_path(cube, "cube.obj");
    in_path(box, "box.obj");
    run_result r;

    /* "#x.obj" quoted is run (relative: the line starts with '#' inside
     * the quotes); an unquoted '#' line is still a comment */
    out_path(o1, "hash.exr");
    snprintf(text, sizeof text, "# %s -o %s\n\"#x.obj\" -o \"%s\"\n  #%s\n", box, o1, o1, box);
    in_path(p, "same.txt");
    CHECK(write_text(p, text));
    run_cli_ex(&r, g_in, ARGS("batch", "--manifest", "same.txt", "-r", "8", "--json"), 0);
    CHECK_MSG(r.code == 0, "quoted #x.obj: exit %d: %s", r.code, r.err);
    CHECK_MSG(filled_of(o1) == 512, "quoted #x.obj: its output");
    py_check("quoted #x.obj", r.out_path,
             "assert recs[0]['input'] == A[0] and recs[0]['line'] == 2 and recs[0]['status'] == 'ok', recs\n"
             "assert len(recs) == 2 and recs[1]['meshes'] == 1, recs\n",
             "#x.obj",
             NULL);
    run_free(&r);
    reset_out();

    /* out/x.exr and out/./x.exr */
    out_path(o1, "x.exr");
    out_path(o2, "./x.exr");
    snprintf(text, sizeof text, "%s -o %s\n%s -o %s\n", cube, o1, box, o2);
    run_manifest(&r, text, ARGS("-r", "4"));
    expect_same_file("out/./x.exr", &r, "are the same file");
    CHECK_MSG(strstr(r.err, "same.txt:1") && strstr(r.err, "same.txt:2"), "the error names both lines: %s", r.err);
    run_free(&r);
    /* a symbolic link to the directory; out//x.exr; in/../out/x.exr */
    path_join(lnk, sizeof lnk, g_dir, "lnk");
    unlink(lnk);
    CHECK(symlink(g_out, lnk) == 0);
    const char *name[] = {"x.exr", "/x.exr", "../out/x.exr"}; /* g_out is DIR/out, g_in DIR/in */
    const char *base[] = {lnk, g_out, g_in};
    for (int i = 0; i < 3; i++) {
        path_join(o2, sizeof o2, base[i], name[i]);
        snprintf(text, sizeof text, "%s -o %s\n%s -o %s\n", cube, o1, box, o2);
        run_manifest(&r, text, ARGS("-r", "4"));
        expect_same_file(o2, &r, "are the same file");
        run_free(&r);
    }
    /* a directory that does not exist yet, spelled two ways */
    out_path(o1, "new/x.exr");
    out_path(o2, "new/./x.exr");
    snprintf(text, sizeof text, "%s -o %s\n%s -o %s\n", cube, o1, box, o2);
    run_manifest(&r, text, ARGS("-r", "4"));
    expect_same_file("missing directory", &r, "are the same file");
    run_free(&r);
    /* a .npy writes OUT.json and OUT.<channel>.npy beside it */
    out_path(o1, "v.npy");
    static const char *const beside[] = {"v.json", "v.coverage.npy"};
    for (int i = 0; i < 2; i++) {
        snprintf(p, sizeof p, "./%s", beside[i]);
        out_path(o2, p);
        snprintf(text, sizeof text, "%s -o %s\n%s -o %s\n", cube, o1, box, o2);
        run_manifest(&r, text, ARGS("-r", "4"));
        expect_same_file(beside[i], &r, "written with");
        run_free(&r);
    }
    /* one mesh spelled two ways, one template: in/cube.obj, in/d2/../cube.obj */
    char d2[PATH_MAX], cube_b[PATH_MAX], tpl[PATH_MAX];
    in_path(d2, "d2");
    mkdir(d2, 0777);
    path_join(cube_b, sizeof cube_b, d2, "../cube.obj");
    snprintf(tpl, sizeof tpl, "{dir}/../%s/{stem}.exr", strrchr(g_out, '/') + 1);
    run_cli(&r, ARGS("batch", cube, cube_b, "-r", "4", "-o", tpl));
    expect_same_file("{dir} of one mesh spelled twice", &r, "are the same file");
    CHECK_MSG(strstr(r.err, "{dir} or {n}"), "template outputs: the hint: %s", r.err);
    run_free(&r);
    /* two shards: each refuses the list (they would run at once) */
    out_path(o1, "x.exr");
    out_path(o2, "./x.exr");
    snprintf(text, sizeof text, "%s -o %s\n%s -o %s\n", cube, o1, box, o2);
    for (int i = 0; i < 2; i++) {
        run_manifest(&r, text, ARGS("-r", "4", "--shard", i ? "1/2" : "0/2"));
        expect_same_file("across shards", &r, "are the same file");
        run_free(&r);
    }
    /* different files under odd spellings are fine */
    out_path(o2, "./y.exr");
    snprintf(text, sizeof text, "%s -o %s\n%s -o %s\n", cube, o1, box, o2);
    run_manifest(&r, text, ARGS("-r", "4"));
    CHECK_MSG(r.code == 0 && dir_count(g_out) == 2, "x.exr and ./y.exr: exit %d: %s", r.code, r.err);
    out_path(p, "y.exr");
    CHECK(filled_of(p) == 4 * 2 * 2); /* box at -r 4: 4x2x2 voxels */
    run_free(&r);
    reset_out();
    unlink(lnk);
}

/* `nohup clvox batch ... &` (issue 32): a SIGHUP inherited ignored stays
 * ignored, so the batch runs to the end (before: the hang-up cancelled it,
 * exit 130). The SIGHUP is sent once the first volume exists. */
static void test_batch_nohup(void)
{
    char man[PATH_MAX], tpl[PATH_MAX], mesh[PATH_MAX];
    const char *def = getenv("CLVOX_TEST_MESH");
    if (!def || !*def) def = "tests/data/default.obj";
    if (!absolute_path(def, mesh, sizeof mesh)) {
        printf("SKIP: no %s for the nohup test\n", def);
        return;
    }
    enum { MESHES = 24 };
    in_path(man, "nohup.txt");
    FILE *f = fopen(man, "w");
    CHECK(f != NULL);
    if (!f) return;
    for (int i = 0; i < MESHES; i++) fprintf(f, "%s\n", mesh);
    CHECK(fclose(f) == 0);
    out_path(tpl, "{n}.exr");
    g_signal = SIGHUP;
    g_child_ignore_sighup = 1;
    run_result r;
    run_cli_ex(&r, NULL, ARGS("batch", "--manifest", man, "-r", "96", "-o", tpl), 0.001);
    g_signal = SIGINT;
    g_child_ignore_sighup = 0;
    CHECK_MSG(g_signals_sent == 1, "nohup batch: ended (exit %d) before its first volume existed: no SIGHUP sent",
              r.code);
    CHECK_MSG(r.code == 0 && dir_count(g_out) == MESHES, "nohup batch: exit %d, %d of %d volumes: %s", r.code,
              dir_count(g_out), MESHES, r.err);
    run_free(&r);
    reset_out();
}

/* Ctrl-C in the middle of a batch: exit 130, the summary says so, every
 * file left is a complete volume, no temporary. */
static void test_batch_cancel(void)
{
    char man[PATH_MAX], tpl[PATH_MAX], mesh[PATH_MAX];
    const char *def = getenv("CLVOX_TEST_MESH");
    if (!def || !*def) def = "tests/data/default.obj";
    if (!absolute_path(def, mesh, sizeof mesh)) {
        printf("SKIP: no %s for the cancel test\n", def);
        return;
    }
    in_path(man, "many.txt");
    FILE *f = fopen(man, "w");
    CHECK(f != NULL);
    if (!f) return;
    for (int i = 0; i < 400; i++) fprintf(f, "%s\n", mesh);
    CHECK(fclose(f) == 0);
    out_path(tpl, "{n}.exr");
    run_result r;
    run_cli_ex(&r, NULL, ARGS("batch", "--manifest", man, "-r", "96", "-o", tpl), 0.5);
    CHECK_MSG(r.code == 130, "cancel: exit %d: %s", r.code, r.err);
    CHECK_MSG(strstr(r.out, "(cancelled)") != NULL, "cancel: summary: %s", r.out);
    int n = dir_count(g_out);
    CHECK_MSG(n > 0 && n < 400, "cancel: %d files", n);
    DIR *d = opendir(g_out);
    struct dirent *e;
    int bad = 0, checked = 0;
    while (d && (e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.') {
            bad += strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0;
            continue;
        }
        const char *dot = strrchr(e->d_name, '.');
        if (!dot || strcmp(dot, ".exr") != 0) bad++;
        else if (checked < 3) { /* the last ones written are complete */
            char p[PATH_MAX];
            out_path(p, e->d_name);
            CHECK_MSG(filled_of(p) > 0, "cancel: %s is not a complete volume", e->d_name);
            checked++;
        }
    }
    if (d) closedir(d);
    CHECK_MSG(bad == 0, "cancel: %d stray files", bad);
    run_free(&r);
    reset_out();
}

/* A mesh that another program keeps cutting and writing back while the
 * batch reads it (a file still being written, a network file system): the
 * batch records each of its loads as ok or failed (exit 4, "changed or
 * truncated while reading" or a truncated-file error) and goes on with the
 * rest. The old reader mapped the file: a page past the new end was SIGBUS
 * and the whole batch died (exit 135), the meshes after it not written. */
static void test_batch_changing_mesh(void)
{
    char changing[PATH_MAX], cube[PATH_MAX], box[PATH_MAX], tpl[PATH_MAX], p[PATH_MAX];
    in_path(changing, "changing.off");
    in_path(cube, "cube.obj");
    in_path(box, "box.obj");
    out_path(tpl, "{n}_{stem}.exr");
    tmesh sphere = tmesh_sphere(0, 0, 0, 1, 160); /* 102 k triangles, 3.9 MB of OFF */
    CHECK(tmesh_write_off(&sphere, changing) == 0);
    tmesh_free(&sphere);
    char *data = read_all(changing);
    size_t n = strlen(data), cut = n / 2;
    CHECK(n > 1000000);

    fflush(stdout);
    fflush(stderr);
    pid_t parent = getpid(), trunc = fork();
    if (trunc == 0) { /* cut, write back, a millisecond whole; until killed */
        int fd = open(changing, O_WRONLY | O_CLOEXEC);
        if (fd < 0) _exit(2);
        for (;;) {
            if (getppid() != parent) _exit(0);
            if (ftruncate(fd, (off_t)cut) != 0) _exit(2);
            for (size_t done = cut; done < n;) {
                ssize_t w = pwrite(fd, data + done, n - done, (off_t)done);
                if (w <= 0) _exit(2);
                done += (size_t)w;
            }
            struct timespec whole = {0, 1000 * 1000};
            nanosleep(&whole, NULL);
        }
    }
    CHECK(trunc > 0);
    run_result r;
    run_cli(&r, ARGS("batch", cube, changing, changing, changing, changing, changing, changing, box, "-r", "4", "-o",
                     tpl, "--json"));
    if (trunc > 0) {
        kill(trunc, SIGKILL);
        waitpid(trunc, NULL, 0);
    }
    free(data);
    CHECK_MSG(r.code == 0 || r.code == 4, "changing mesh: batch exit %d (135: SIGBUS): %s", r.code, r.err);
    CHECK_MSG(strstr(r.out, "{\"type\":\"batch\",\"meshes\":8,") != NULL, "changing mesh: no batch record: %s", r.out);
    out_path(p, "0_cube.exr");
    CHECK(filled_of(p) == 64);
    out_path(p, "7_box.exr");
    CHECK(filled_of(p) == 4 * 2 * 2);
    py_check("changing mesh", r.out_path,
             "m = recs[:8]\n"
             "assert len(recs) == 9 and [x['n'] for x in m] == list(range(8)), recs\n"
             "assert m[0]['status'] == 'ok' and m[7]['status'] == 'ok', m\n"
             "c = m[1:7]\n"
             "assert all(x['status'] in ('ok', 'failed') for x in c), c\n"
             "bad = [x for x in c if x['status'] == 'failed']\n"
             "assert all(x['exit_code'] == 4 and A[0] in x['error'] and x['output_size'] is None for x in bad), bad\n"
             "good = [x for x in c if x['status'] == 'ok']\n"
             "assert len(set(x['filled_voxels'] for x in good)) <= 1, good  # all the whole sphere\n"
             "b = recs[8]\n"
             "assert b['meshes'] == 8 and b['ok'] == 2 + len(good) and b['failed'] == len(bad), b\n"
             "assert b['exit_code'] == (4 if bad else 0), b\n",
             changing, NULL);
    printf("batch with a changing mesh: exit %d, %d of its 6 loads failed (%d 'changed or truncated')\n", r.code,
           lines_starting(r.err, "clvox: error: "), count_of(r.err, "changed or truncated while reading"));
    run_free(&r);
    unlink(changing);
    reset_out();
}

static void make_inputs(void)
{
    char p[PATH_MAX];
    in_path(p, "cube.obj");
    CHECK(write_text(p, CUBE_OBJ));
    in_path(p, "box.obj");
    CHECK(write_text(p, BOX_OBJ));
    in_path(p, "open_cube.obj");
    CHECK(write_text(p, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
                        "f 1 4 3 2\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n"));
    in_path(p, "empty.obj");
    CHECK(write_text(p, ""));
    in_path(p, "scan.nrrd");
    CHECK(write_text(p, "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n"));
    unsigned char junk[3000];
    uint32_t x = 0x9e3779b9u;
    for (size_t i = 0; i < sizeof junk; i++) {
        x ^= x << 13, x ^= x >> 17, x ^= x << 5;
        junk[i] = (unsigned char)x;
    }
    in_path(p, "random.exr");
    FILE *f = fopen(p, "wb");
    CHECK(f && fwrite(junk, 1, sizeof junk, f) == sizeof junk && fclose(f) == 0);
    /* an OpenEXR file without clvox's grid attributes */
    uint16_t half_one[8] = {0x3C00, 0x3C00, 0x3C00, 0x3C00, 0x3C00, 0x3C00, 0x3C00, 0x3C00};
    exrgen_channel ch = {"occupancy", EXR_PIXEL_HALF, half_one};
    in_path(p, "plain.exr");
    CHECK(exrgen_write(p, 2, 2, 2, &ch, 1, 0, 0, EXR_COMPRESSION_NONE, 0));
}

int main(void)
{
    const char *bin = getenv("CLVOX_BIN");
    if (!bin || !*bin) bin = "build/release/clvox";
    if (!test_cli_dirs(bin, "batch", g_bin, g_dir, g_in, g_out, g_logs)) return test_report();

    {
        const char *argv[] = {"python3", "-c", "import json", NULL};
        run_result r;
        run_prog(&r, NULL, argv, 0);
        g_have_python = r.code == 0;
        run_free(&r);
        if (!g_have_python) printf("SKIP: no python3: the JSON records are not parsed\n");
    }
    make_inputs();
    test_json_single();
    test_json_escaping();
    test_json_failure();
    test_info_json();
    test_like();
    test_like_formats();
    test_batch_basic();
    test_batch_failures();
    test_batch_lists();
    test_batch_same_file();
    test_batch_cancel();
    test_batch_changing_mesh();
    test_batch_mixed_sets();
    test_batch_nohup();
    return test_report();
}
