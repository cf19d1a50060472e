/* SPDX-License-Identifier: Apache-2.0 */
/* What clvox batch writes where (issue 36): binvox's cube (--cube, and
 * automatic for .binvox outputs) over 20 of Debian's CGAL meshes
 * (data/meshes, scripts/fetch_meshes.sh), each .binvox checked against an
 * independent computation of the cube (dims, translate, scale) and, voxel
 * for voxel, against the same batch written as .npy and as .exr with --cube;
 * the grid options that forbid the cube; and the output directories a batch
 * creates (mkdir -p below the template's name, never replacing a file or a
 * link, a clear error when a component is not a directory, nothing that
 * looks valid left by a failed mesh). Runs the binary ($CLVOX_BIN). */
#ifndef _XOPEN_SOURCE
#define _XOPEN_SOURCE 700
#endif
#include "spawn.h"
#include "test.h"
#include "testio.h"

#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define RUN_TIMEOUT_S 300.0
#define N 32u

static char g_bin[PATH_MAX], g_dir[PATH_MAX], g_in[PATH_MAX], g_out[PATH_MAX], g_logs[PATH_MAX];
static unsigned g_run_id;

/* 20 small meshes of libcgal-demo; most have boxes that are not cubes (the
 * batch below failed on 17 of them before --cube). */
static const char *const MESHES[] = {
    "3torus",    "ALSTOM_TEST4", "anchor",      "beam",  "blob-closed",          "blob",    "cactus",
    "cheese-box", "cow",         "cross",       "cube-meshed", "cylinder", "double-torus-example", "dragknob",
    "eight",     "ellipsoid",    "fandisk-box", "geosphere",   "hand",  "helmet"};
#define MESH_COUNT (sizeof MESHES / sizeof MESHES[0])

static clvox_context *g_host;

static int run(spawn_result *r, const char *const *args)
{
    const char **argv = spawn_argv(g_bin, args);
    char out_path[PATH_MAX], err_path[PATH_MAX];
    spawn_log_paths(g_logs, ++g_run_id, out_path, err_path);
    spawn_opts o;
    memset(&o, 0, sizeof o);
    o.timeout_s = RUN_TIMEOUT_S;
    int code = spawn_run_to(r, argv, out_path, err_path, &o);
    free(argv);
    return code;
}

static void out_path(char *dst, const char *name) { path_join(dst, PATH_MAX, g_out, name); }

/* ---- files ---- */

static uint8_t *read_bytes(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    size_t cap = 1 << 16, n = 0;
    uint8_t *b = malloc(cap);
    for (size_t got; b && (got = fread(b + n, 1, cap - n, f)) > 0;) {
        n += got;
        if (n == cap) {
            uint8_t *g = realloc(b, cap *= 2);
            if (!g) { free(b); b = NULL; }
            b = g;
        }
    }
    fclose(f);
    *len = n;
    return b;
}

/* A .binvox file, decoded: dims, translate, scale and the voxels in clvox's
 * order (x fastest, then y, then z). */
typedef struct binvox {
    unsigned d[3];
    double t[3], s;
    uint8_t *v;
} binvox;

static int read_binvox(const char *path, binvox *bv)
{
    memset(bv, 0, sizeof *bv);
    size_t len = 0;
    uint8_t *b = read_bytes(path, &len);
    if (!b) return 0;
    const char *data = NULL;
    for (size_t i = 0; i + 5 < len; i++)
        if (memcmp(b + i, "\ndata\n", 6) == 0) { data = (const char *)b + i + 6; break; }
    char hdr[600] = "";
    if (data) snprintf(hdr, sizeof hdr, "%.*s", (int)(data - (const char *)b), (const char *)b);
    int ok = data && sscanf(hdr, "#binvox 1\ndim %u %u %u\ntranslate %lf %lf %lf\nscale %lf\ndata\n", &bv->d[0],
                            &bv->d[1], &bv->d[2], &bv->t[0], &bv->t[1], &bv->t[2], &bv->s) == 7;
    if (ok && bv->d[0] == bv->d[1] && bv->d[0] == bv->d[2] && bv->d[0] > 0 && bv->d[0] <= 1024) {
        size_t n = bv->d[0], total = n * n * n, k = 0;
        bv->v = calloc(total, 1);
        const uint8_t *p = (const uint8_t *)data, *end = b + len;
        /* (value, count) pairs over index x*N*N + z*N + y */
        for (; ok && bv->v && p + 1 < end; p += 2) {
            if (p[1] == 0 || p[0] > 1 || k + p[1] > total) { ok = 0; break; }
            for (unsigned c = 0; c < p[1]; c++, k++) {
                size_t x = k / (n * n), z = (k / n) % n, y = k % n;
                bv->v[(z * n + y) * n + x] = p[0];
            }
        }
        ok = ok && bv->v && k == total && p == end;
    } else {
        ok = 0;
    }
    free(b);
    if (!ok) { free(bv->v); bv->v = NULL; }
    return ok;
}

/* A clvox .npy of uint8 occupancy, shape (Z, Y, X): its voxels (x fastest). */
static uint8_t *read_npy_u8(const char *path, unsigned d[3])
{
    size_t len = 0;
    uint8_t *b = read_bytes(path, &len);
    if (!b || len < 12 || memcmp(b, "\x93NUMPY", 6) != 0) { free(b); return NULL; }
    size_t hl = b[6] == 1 ? (size_t)(b[8] | b[9] << 8) : (size_t)(b[8] | b[9] << 8 | b[10] << 16 | (size_t)b[11] << 24);
    size_t off = b[6] == 1 ? 10 : 12;
    uint8_t *out = NULL;
    if (off + hl <= len) {
        char hdr[512];
        snprintf(hdr, sizeof hdr, "%.*s", (int)(hl < 511 ? hl : 511), (const char *)b + off);
        const char *sh = strstr(hdr, "'shape': (");
        unsigned z, y, x;
        if (strstr(hdr, "'descr': '|u1'") && strstr(hdr, "'fortran_order': False") && sh &&
            sscanf(sh, "'shape': (%u, %u, %u)", &z, &y, &x) == 3 && (size_t)x * y * z == len - off - hl) {
            d[0] = x, d[1] = y, d[2] = z;
            out = malloc(len - off - hl + 1);
            if (out) memcpy(out, b + off + hl, len - off - hl);
        }
    }
    free(b);
    return out;
}

/* The cube binvox makes, computed here from the mesh's box (the library's
 * report: the box it voxelizes): every axis the longest edge L, centred,
 * an axis that long keeping its bounds; pad voxels of L/N around. */
static int expected_cube(const char *mesh, unsigned pad, double t[3], double *scale, unsigned *dims)
{
    clvox_mesh *m = NULL;
    if (clvox_mesh_load(g_host, mesh, &m) != CLVOX_OK) return 0;
    const clvox_mesh_report *r = clvox_mesh_get_report(m);
    double L = 0;
    for (int a = 0; a < 3; a++) L = fmax(L, r->bbox_max[a] - r->bbox_min[a]);
    double h = L / N;
    for (int a = 0; a < 3; a++) {
        double e = r->bbox_max[a] - r->bbox_min[a];
        double lo = e == L ? r->bbox_min[a] : r->bbox_min[a] + 0.5 * e - 0.5 * L;
        t[a] = lo - pad * h;
    }
    *scale = (N + 2 * pad) * h;
    *dims = N + 2 * pad;
    clvox_mesh_destroy(m);
    return 1;
}

static int cubic_box(const char *mesh)
{
    clvox_mesh *m = NULL;
    if (clvox_mesh_load(g_host, mesh, &m) != CLVOX_OK) return 0;
    const clvox_mesh_report *r = clvox_mesh_get_report(m);
    double e[3];
    for (int a = 0; a < 3; a++) e[a] = r->bbox_max[a] - r->bbox_min[a];
    clvox_mesh_destroy(m);
    return e[0] == e[1] && e[1] == e[2];
}

static int close_to(double a, double b, double scale) { return fabs(a - b) <= 1e-12 * (fabs(scale) + 1); }

/* ---- binvox's cube ---- */

static void test_binvox_batch(void)
{
    char mesh[MESH_COUNT][PATH_MAX];
    const char *args[3 * MESH_COUNT + 16];
    int have_all = 1, not_cubes = 0;
    for (size_t i = 0; i < MESH_COUNT; i++) {
        snprintf(mesh[i], PATH_MAX, "data/meshes/%s.off", MESHES[i]);
        if (access(mesh[i], R_OK) != 0) {
            fprintf(stderr, "missing %s (run scripts/fetch_meshes.sh): counted as a failure\n", mesh[i]);
            have_all = 0;
        } else {
            not_cubes += !cubic_box(mesh[i]);
        }
    }
    CHECK(have_all);
    if (!have_all) return;
    CHECK_MSG(not_cubes >= 15, "only %d of the meshes have boxes that are not cubes", not_cubes);

    /* one batch per format: .binvox (the cube by default; its folder made
     * by the batch), .npy and .exr with --cube */
    static const char *const tpl[3] = {"bv/{stem}.binvox", "np/{stem}.npy", "ex/{stem}.exr"};
    char tpl_path[3][PATH_MAX];
    for (int f = 0; f < 3; f++) {
        out_path(tpl_path[f], tpl[f]);
        size_t k = 0;
        args[k++] = "batch";
        for (size_t i = 0; i < MESH_COUNT; i++) args[k++] = mesh[i];
        args[k++] = "-r";
        args[k++] = "32";
        if (f > 0) args[k++] = "--cube";
        args[k++] = "-o";
        args[k++] = tpl_path[f];
        args[k++] = "-q";
        args[k] = NULL;
        spawn_result r;
        int code = run(&r, args);
        CHECK_MSG(code == 0, "batch %s: exit %d: %s", tpl[f], code, r.err);
        spawn_free(&r);
    }
    int ok = 0;
    for (size_t i = 0; i < MESH_COUNT; i++) {
        char p[PATH_MAX], name[PATH_MAX];
        snprintf(name, sizeof name, "bv/%s.binvox", MESHES[i]);
        out_path(p, name);
        binvox bv;
        if (!read_binvox(p, &bv)) {
            CHECK_MSG(0, "%s: not a readable binvox file", p);
            continue;
        }
        double t[3], s;
        unsigned d;
        CHECK(expected_cube(mesh[i], 0, t, &s, &d));
        int good = bv.d[0] == d && bv.d[1] == d && bv.d[2] == d && close_to(bv.s, s, s);
        for (int a = 0; a < 3; a++) good = good && close_to(bv.t[a], t[a], s);
        CHECK_MSG(good, "%s: dim %u %u %u translate %.17g %.17g %.17g scale %.17g; expected dim %u translate %.17g "
                  "%.17g %.17g scale %.17g", MESHES[i], bv.d[0], bv.d[1], bv.d[2], bv.t[0], bv.t[1], bv.t[2], bv.s,
                  d, t[0], t[1], t[2], s);
        size_t total = (size_t)N * N * N, filled = 0;
        for (size_t v = 0; v < total; v++) filled += bv.v[v];
        CHECK_MSG(filled > 0, "%s: no voxel filled", MESHES[i]);

        /* the .npy of the same batch with --cube: the same voxels */
        snprintf(name, sizeof name, "np/%s.npy", MESHES[i]);
        out_path(p, name);
        unsigned nd[3] = {0, 0, 0};
        uint8_t *npy = read_npy_u8(p, nd);
        CHECK_MSG(npy && nd[0] == N && nd[1] == N && nd[2] == N, "%s: npy %u x %u x %u", p, nd[0], nd[1], nd[2]);
        int same = npy && memcmp(npy, bv.v, total) == 0;
        CHECK_MSG(same, "%s: binvox and npy voxels differ", MESHES[i]);

        /* the .exr with --cube: the cubic grid (dims, origin, voxel size) and the same voxels */
        snprintf(name, sizeof name, "ex/%s.exr", MESHES[i]);
        out_path(p, name);
        clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
        uint8_t *occ = calloc(total, 1);
        CHECK_OK(g_host, clvox_volume_read(g_host, p, &info, occ, total));
        int grid = info.dims[0] == N && info.dims[1] == N && info.dims[2] == N;
        for (int a = 0; a < 3; a++)
            grid = grid && close_to(info.origin[a], t[a], s) && close_to(info.voxel_size[a], s / N, s);
        CHECK_MSG(grid, "%s: exr grid %u x %u x %u origin %.17g %.17g %.17g h %.17g", MESHES[i], info.dims[0],
                  info.dims[1], info.dims[2], info.origin[0], info.origin[1], info.origin[2], info.voxel_size[0]);
        CHECK_MSG(memcmp(occ, bv.v, total) == 0, "%s: binvox and exr voxels differ", MESHES[i]);
        ok += good && same;
        free(occ);
        free(npy);
        free(bv.v);
    }
    printf("binvox batch: %d of %zu meshes with the cube's header and the npy's voxels\n", ok, MESH_COUNT);

    /* --pad: the cube, then padding around it (dims N + 2p, the same h) */
    char p[PATH_MAX];
    out_path(p, "pad/cow.binvox");
    spawn_result r;
    int code = run(&r, (const char *const[]){"batch", mesh[8], "-r", "32", "--pad", "2", "-o", p, "-q", NULL});
    CHECK_MSG(code == 0, "--pad 2: exit %d: %s", code, r.err);
    spawn_free(&r);
    binvox bv;
    double t[3], s;
    unsigned d;
    CHECK(expected_cube(mesh[8], 2, t, &s, &d));
    CHECK_MSG(read_binvox(p, &bv) && bv.d[0] == d && close_to(bv.s, s, s) && close_to(bv.t[0], t[0], s) &&
                  close_to(bv.t[1], t[1], s) && close_to(bv.t[2], t[2], s),
              "--pad 2: dim %u translate %.17g %.17g %.17g scale %.17g; expected %u, %.17g %.17g %.17g, %.17g",
              bv.d[0], bv.t[0], bv.t[1], bv.t[2], bv.s, d, t[0], t[1], t[2], s);
    free(bv.v);
}

/* The grid options that forbid the automatic cube keep binvox's error; the
 * explicit --cube makes a --box a cube around its centre. */
static void test_cube_options(void)
{
    const char *cow = "data/meshes/cow.off";
    if (access(cow, R_OK) != 0) return; /* counted in test_binvox_batch */
    char p[PATH_MAX];
    out_path(p, "opt/x.binvox");
    mkdir(g_out, 0777);
    char d[PATH_MAX];
    out_path(d, "opt");
    mkdir(d, 0777);
    spawn_result r;
    struct {
        const char *const *args;
        int code;
        const char *needle;
    } cases[] = {
        {(const char *const[]){cow, "--dims", "8,8,9", "-o", p, "-q", NULL}, 6, "binvox needs a cubic grid"},
        {(const char *const[]){cow, "--box", "-1,-1,-1,1,1,2", "-r", "8", "-o", p, "-q", NULL}, 6,
         "binvox needs a cubic grid"},
        {(const char *const[]){cow, "--voxel-size", "0.1,0.1,0.2", "-o", p, "-q", NULL}, 6, "binvox"},
        {(const char *const[]){cow, "--dims", "8,8,9", "--cube", "-o", p, "-q", NULL}, 2, "--cube needs"},
        {(const char *const[]){cow, "--voxel-size", "0.1,0.1,0.2", "--cube", "-o", p, "-q", NULL}, 2,
         "--cube needs cubic voxels"},
        {(const char *const[]){cow, "--like", "nothing.exr", "--cube", "-o", p, "-q", NULL}, 2,
         "--like and --cube"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        int code = run(&r, cases[i].args);
        CHECK_MSG(code == cases[i].code && strstr(r.err, cases[i].needle) && count_lines(r.err) == 1,
                  "case %zu: exit %d (expected %d): %s", i, code, cases[i].code, r.err);
        CHECK_MSG(dir_count(d) == 0, "case %zu left a file", i);
        spawn_free(&r);
    }
    /* --cube with a box: the box made a cube around its centre (0, 0, 0.5), edge 3 */
    int code = run(&r, (const char *const[]){cow, "--box", "-1,-1,-1,1,1,2", "-r", "12", "--cube", "-o", p, "-q",
                                             NULL});
    CHECK_MSG(code == 0, "--box --cube: exit %d: %s", code, r.err);
    spawn_free(&r);
    binvox bv;
    CHECK_MSG(read_binvox(p, &bv) && bv.d[0] == 12 && bv.s == 3 && bv.t[0] == -1.5 && bv.t[1] == -1.5 &&
                  bv.t[2] == -1,
              "--box --cube: dim %u translate %g %g %g scale %g", bv.d[0], bv.t[0], bv.t[1], bv.t[2], bv.s);
    free(bv.v);
    /* a single run gets the cube for .binvox too, and --dims N,N,N applies to it */
    code = run(&r, (const char *const[]){cow, "--dims", "10,10,10", "-o", p, "-q", NULL});
    double t[3], s;
    unsigned dd;
    CHECK(expected_cube(cow, 0, t, &s, &dd));
    CHECK_MSG(code == 0 && read_binvox(p, &bv) && bv.d[0] == 10 && close_to(bv.s, s, s) &&
                  close_to(bv.t[1], t[1], s) && close_to(bv.t[2], t[2], s),
              "--dims 10,10,10: exit %d %s", code, r.err);
    free(bv.v);
    spawn_free(&r);
}

/* ---- folders ---- */

static int count_of_errors(const char *err)
{
    int n = 0;
    for (const char *p = err; (p = strstr(p, "clvox: error:")) != NULL; p++) n++;
    return n;
}

static void test_batch_folders(void)
{
    const char *cow = "data/meshes/cow.off", *beam = "data/meshes/beam.off";
    if (access(cow, R_OK) != 0 || access(beam, R_OK) != 0) return; /* counted in test_binvox_batch */
    rm_tree(g_out);
    mkdir(g_out, 0777);
    char tpl[PATH_MAX], p[PATH_MAX], q[PATH_MAX];
    spawn_result r;

    /* nested folders, made as the template names them */
    out_path(tpl, "a/b//c/{stem}.npy");
    int code = run(&r, (const char *const[]){"batch", cow, beam, "-r", "8", "-o", tpl, "-q", NULL});
    CHECK_MSG(code == 0, "nested: exit %d: %s", code, r.err);
    spawn_free(&r);
    out_path(p, "a/b/c/cow.npy");
    out_path(q, "a/b/c/beam.json");
    CHECK(file_size(p) > 0 && file_size(q) > 0);
    out_path(p, "a/b/c");
    CHECK(dir_count(p) == 4); /* cow.npy cow.json beam.npy beam.json */

    /* a component that is a file: one clear line per mesh, the file untouched */
    out_path(p, "plain");
    CHECK(write_text(p, "not a folder\n"));
    out_path(tpl, "plain/sub/{stem}.exr");
    code = run(&r, (const char *const[]){"batch", cow, beam, "-r", "8", "-o", tpl, NULL});
    CHECK_MSG(code == 5 && count_of_errors(r.err) == 2 && strstr(r.err, "plain' exists and is not a directory"),
              "file component: exit %d: %s", code, r.err);
    spawn_free(&r);
    char *text = read_all(p);
    CHECK(strcmp(text, "not a folder\n") == 0);
    free(text);

    /* a dangling link: kept, nothing made where it points */
    out_path(p, "dangling");
    out_path(q, "nowhere");
    CHECK(symlink(q, p) == 0);
    out_path(tpl, "dangling/{stem}.exr");
    code = run(&r, (const char *const[]){"batch", cow, "-r", "8", "-o", tpl, "-q", NULL});
    CHECK_MSG(code == 5 && strstr(r.err, "dangling' exists and is not a directory"), "dangling: exit %d: %s", code,
              r.err);
    spawn_free(&r);
    struct stat sb;
    CHECK(lstat(p, &sb) == 0 && S_ISLNK(sb.st_mode) && !file_exists(q));

    /* a link to a folder is a folder */
    out_path(p, "real");
    CHECK(mkdir(p, 0777) == 0);
    out_path(q, "link");
    CHECK(symlink(p, q) == 0);
    out_path(tpl, "link/x/{stem}.exr");
    code = run(&r, (const char *const[]){"batch", cow, "-r", "8", "-o", tpl, "-q", NULL});
    CHECK_MSG(code == 0, "link: exit %d: %s", code, r.err);
    spawn_free(&r);
    out_path(p, "real/x/cow.exr");
    CHECK(file_size(p) > 0);

    /* a mesh that fails leaves no file in the folder made for it */
    out_path(p, "bad.off");
    CHECK(write_text(p, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"));
    out_path(tpl, "failed/{stem}.npy");
    code = run(&r, (const char *const[]){"batch", p, "-r", "8", "-o", tpl, "-q", NULL});
    CHECK_MSG(code == 4, "bad mesh: exit %d: %s", code, r.err);
    spawn_free(&r);
    out_path(q, "failed");
    CHECK(dir_count(q) <= 0);
}

int main(void)
{
    const char *bin = getenv("CLVOX_BIN");
    if (!bin) bin = "build/release/clvox";
    if (!test_cli_dirs(bin, "batch_outputs", g_bin, g_dir, g_in, g_out, g_logs)) return test_report();
    clvox_context_options ho = CLVOX_CONTEXT_OPTIONS_INIT;
    ho.host_only = 1;
    CHECK_OK(NULL, clvox_context_create(&ho, &g_host));
    if (!g_host) return test_report();
    test_binvox_batch();
    test_cube_options();
    test_batch_folders();
    clvox_context_destroy(g_host);
    return test_report();
}
