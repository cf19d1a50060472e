/* SPDX-License-Identifier: Apache-2.0 */
/* scripts/tools/blender_instances.py, run by Blender when `blender` is on PATH
 * (CLVOX_WITH_BLENDER=1 scripts/setup.sh installs it; CI does). Without it
 * the test prints a SKIP line and "0 passed, 0 failed": nothing was checked.
 *
 * A small paper46 volume (tests/exrgen.c: mirrors, rotations, anisotropic
 * voxels) goes through `clvox instances` with a render map that has both
 * frames; the script builds, saves and renders the scene; a second headless
 * Blender opens the saved .blend and prints every instance (row, source,
 * matrix_world). Checks: exactly one instance per CSV row, each a linked
 * duplicate of its object's source (one mesh per object, shared), its
 * matrix = translate(x,y,z) diag(hx,hy,hz) S (frame basic) or without S
 * (frame element) within 1e-5, a camera; the PNG is an 8-bit RGB picture of
 * the requested size that is not uniform; bad inputs fail with one line and
 * leave no file. Prints how long each Blender run took. */
#ifndef _XOPEN_SOURCE
#define _XOPEN_SOURCE 700 /* realpath */
#endif
#include "exrgen.h"
#include "spawn.h"
#include "testio.h"
#include "pngread.h"
#include "test.h"

#include <dirent.h>
#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#define BLENDER_TIMEOUT_S 300.0
#define W 160
#define H 120

static char g_blender[PATH_MAX], g_bin[PATH_MAX], g_script[PATH_MAX];
static char g_dir[PATH_MAX], g_out[PATH_MAX];

/* blender -b --factory-startup [blend] --python script -- args... */
static int run_blender(spawn_result *r, const char *blend, const char *script, const char *const *args,
                       double *seconds)
{
    const char *argv[40];
    int n = 0;
    argv[n++] = g_blender;
    argv[n++] = "-b";
    argv[n++] = "--factory-startup";
    if (blend) argv[n++] = blend;
    argv[n++] = "--python";
    argv[n++] = script;
    argv[n++] = "--";
    for (int i = 0; args && args[i] && n < 39; i++) argv[n++] = args[i];
    argv[n] = NULL;
    double t0 = now_s();
    spawn_run(r, argv, BLENDER_TIMEOUT_S);
    if (seconds) *seconds = now_s() - t0;
    return r->code;
}

#define ARGS(...) ((const char *const[]){__VA_ARGS__, NULL})

/* ---- the CSV ----------------------------------------------------------------------------- */

typedef struct row {
    double x, y, z, h[3];
    int s[9];
    char object[64], frame[16];
} row;

static int parse_csv(const char *text, row *rows, int cap)
{
    const char *p = text ? strchr(text, '\n') : NULL; /* after the header */
    if (!p) return -1;
    p++;
    int n = 0;
    while (*p && n < cap) {
        row *r = &rows[n];
        unsigned i, j, k, e;
        char name[64], basic[64];
        float score;
        int used = 0;
        if (sscanf(p,
                   "%u,%u,%u,%lf,%lf,%lf,%lf,%lf,%lf,%u,%63[^,],%63[^,],%d,%d,%d,%d,%d,%d,%d,%d,%d,%f,%63[^,],%15[^\n]%n",
                   &i, &j, &k, &r->x, &r->y, &r->z, &r->h[0], &r->h[1], &r->h[2], &e, name, basic, &r->s[0], &r->s[1],
                   &r->s[2], &r->s[3], &r->s[4], &r->s[5], &r->s[6], &r->s[7], &r->s[8], &score, r->object, r->frame,
                   &used) != 24)
            return -1;
        p += used;
        if (*p == '\n') p++;
        n++;
    }
    return n;
}

/* ---- the PNG ----------------------------------------------------------------------------- */

/* 1 when path is an 8-bit RGB PNG of w x h; *distinct gets the number of
 * pixels that differ from the top-left one by more than 8 in some channel. */
static int check_png(const char *path, uint32_t w, uint32_t h, long *distinct)
{
    picture pic;
    if (!read_png(path, &pic)) return 0;
    int ok = pic.w == w && pic.h == h;
    if (ok) {
        const unsigned char *rgb = pic.rgb;
        long n = 0;
        for (size_t q = 0; q < (size_t)w * h; q++)
            for (int c = 0; c < 3; c++)
                if (abs((int)rgb[3 * q + c] - (int)rgb[c]) > 8) {
                    n++;
                    break;
                }
        *distinct = n;
    } else {
        fprintf(stderr, "%s: %ux%u, not %ux%u\n", path, (unsigned)pic.w, (unsigned)pic.h, (unsigned)w, (unsigned)h);
    }
    free(pic.rgb);
    return ok;
}

/* ---- the check snippet: every instance of the saved scene ------------------------------- */

static const char CHECK_PY[] =
    "import bpy\n"
    "coll = bpy.data.collections.get('clvox_instances')\n"
    "obs = sorted(coll.objects, key=lambda o: o['clvox_row']) if coll else []\n"
    "srcs = bpy.data.collections.get('clvox_sources')\n"
    "by_data = {o.data.name: o.name for o in (srcs.objects if srcs else []) if o.data}\n"
    "print('CLVOX COUNT %d' % len(obs))\n"
    "print('CLVOX SOURCES %d' % (len(srcs.objects) if srcs else -1))\n"
    "print('CLVOX MESHES %d' % len({o.data.name if o.data else 'c:' + o.instance_collection.name for o in obs}))\n"
    "print('CLVOX CAMERA %d' % (bpy.context.scene.camera is not None))\n"
    "for o in obs:\n"
    "    src = by_data.get(o.data.name, '?') if o.data else ('collection:' + o.instance_collection.name\n"
    "                                                         if o.instance_collection else '?')\n"
    "    m = o.matrix_world\n"
    "    print('CLVOX ROW %d %s %s' % (o['clvox_row'], src, ' '.join('%.9g' % m[i][j] for i in range(4) for j in range(4))))\n";

static const char *find_line(const char *text, const char *prefix)
{
    size_t n = strlen(prefix);
    for (const char *p = text; p && *p;) {
        if (strncmp(p, prefix, n) == 0) return p + n;
        p = strchr(p, '\n');
        if (p) p++;
    }
    return NULL;
}

static void check_scene(const char *blend, const row *rows, int nrows, int objects, int sources_expected)
{
    char check_py[PATH_MAX];
    path_join(check_py, sizeof check_py, g_dir, "check_instances.py");
    CHECK(write_text(check_py, CHECK_PY));
    spawn_result r;
    double secs = 0;
    run_blender(&r, blend, check_py, NULL, &secs);
    printf("blender: opening the .blend and listing its instances took %.1f s\n", secs);
    CHECK_MSG(r.code == 0, "check snippet: exit %d: %s", r.code, r.err);
    const char *v;
    int count = -1, sources = -1, meshes = -1, camera = -1;
    if ((v = find_line(r.out, "CLVOX COUNT "))) count = atoi(v);
    if ((v = find_line(r.out, "CLVOX SOURCES "))) sources = atoi(v);
    if ((v = find_line(r.out, "CLVOX MESHES "))) meshes = atoi(v);
    if ((v = find_line(r.out, "CLVOX CAMERA "))) camera = atoi(v);
    CHECK_MSG(count == nrows, "%d instances in the .blend, %d rows in the CSV", count, nrows);
    CHECK_MSG(sources == sources_expected && meshes == objects,
              "%d sources (%d expected), %d meshes or collections shared by the instances, %d objects in the CSV",
              sources,
              sources_expected, meshes, objects);
    CHECK(camera == 1);
    int seen = 0, bad = 0;
    for (const char *p = r.out; (p = strstr(p, "CLVOX ROW ")) != NULL; p++) {
        int idx = -1, used = 0;
        char src[96];
        double m[16];
        if (sscanf(p + 10, "%d %95s%n", &idx, src, &used) != 2 || idx < 0 || idx >= nrows) {
            bad++;
            continue;
        }
        const char *q = p + 10 + used;
        int got = 0;
        for (int t = 0; t < 16; t++) {
            char *end = NULL;
            m[t] = strtod(q, &end);
            if (end == q) break;
            q = end;
            got++;
        }
        const row *w = &rows[idx];
        char want_src[96], want_coll[96];
        snprintf(want_src, sizeof want_src, "clvox_src_%s", w->object);
        snprintf(want_coll, sizeof want_coll, "collection:%s", w->object);
        int ok = got == 16 && (strcmp(src, want_src) == 0 || strcmp(src, want_coll) == 0);
        const double c[3] = {w->x, w->y, w->z};
        int basic = strcmp(w->frame, "basic") == 0;
        for (int i = 0; i < 3 && ok; i++) {
            for (int j = 0; j < 3; j++) {
                double want = w->h[i] * (basic ? w->s[3 * i + j] : (double)(i == j));
                ok &= fabs(m[4 * i + j] - want) <= 1e-5;
            }
            ok &= fabs(m[4 * i + 3] - c[i]) <= 1e-5;
            ok &= fabs(m[12 + i]) <= 1e-5;
        }
        ok &= fabs(m[15] - 1) <= 1e-5;
        if (!ok && bad++ < 5) fprintf(stderr, "instance %d (%s) does not match its row: %s\n", idx, src, p);
        seen++;
    }
    CHECK_MSG(seen == nrows && bad == 0, "%d instances listed, %d wrong, %d rows", seen, bad, nrows);
    spawn_free(&r);
}

/* ---- the test ----------------------------------------------------------------------------- */

static int g_rows_n;
static row g_rows[256];

/* The CSV: clvox instances on a hand-made paper46 volume. */
static int make_csv(const char *csv, const char *map)
{
    enum { X = 4, Y = 3, Z = 3, N = X * Y * Z };
    /* paper46 indices: 1 full, 2 wedge, 5 wedge_s3, 7 wedge_s9, 17 roof_s10, 21 roof_s26, 29 column_s3,
       35 column_s13, 38 corner, 45 corner_s7 */
    static const uint32_t pick[] = {1, 2, 5, 7, 17, 21, 29, 35, 38, 45};
    static const uint16_t scores[] = {0x3C00, 0x3A00, 0x3800, 0x38CD, 0x3400, 0x0000};
    uint32_t element[N];
    uint16_t score[N];
    for (size_t q = 0; q < N; q++) {
        element[q] = q % 3 == 1 ? 0 : pick[(q * 7) % 10];
        score[q] = scores[(q * 5) % 6];
    }
    char vol[PATH_MAX];
    path_join(vol, sizeof vol, g_dir, "blender.exr");
    exrgen_channel ch[2] = {{"element", EXR_PIXEL_UINT, element}, {"score", EXR_PIXEL_HALF, score}};
    if (!exrgen_write(vol, X, Y, Z, ch, 2, 0, 0, EXR_COMPRESSION_ZIP, 1)) return 0;
    if (!write_text(map, "# both frames: basic rules carry S, the element rule does not\n"
                         "basic wedge\n object cheese 0.6\n object door_stop 0\n"
                         "basic corner\n object pyramid 0.5\n object cone 0\n"
                         "element roof_s26\n object tent 0\n"
                         "element unused_never\n"))
        return 0;
    /* the last line is a mistake on purpose: instances must refuse the map... */
    spawn_result r;
    const char *bad_argv[] = {g_bin, "instances", vol, "--palette", "paper46", "--render-map", map, "-o", csv, NULL};
    spawn_run(&r, bad_argv, 60);
    CHECK_MSG(r.code == 4 && strstr(r.err, ":10: no element 'unused_never'"), "bad map: exit %d: %s", r.code, r.err);
    spawn_free(&r);
    /* ... then take it without that line */
    if (!write_text(map, "basic wedge\n object cheese 0.6\n object door_stop 0\n"
                         "basic corner\n object pyramid 0.5\n object cone 0\n"
                         "element roof_s26\n object tent 0\n"
                         "element full\n object crate 0\n"
                         "element corner_s1\n object never_used 0\n")) /* not in the volume */
        return 0;
    const char *argv[] = {g_bin, "instances", vol, "--palette", "paper46", "--render-map", map, "-o", csv, NULL};
    spawn_run(&r, argv, 60);
    CHECK_MSG(r.code == 0, "clvox instances: exit %d: %s", r.code, r.err);
    spawn_free(&r);
    char *text = read_text(csv);
    g_rows_n = parse_csv(text, g_rows, 256);
    free(text);
    CHECK_MSG(g_rows_n == 24, "%d rows (24 non-empty voxels)", g_rows_n);
    return g_rows_n > 0;
}

static int distinct_objects(void)
{
    int n = 0;
    for (int i = 0; i < g_rows_n; i++) {
        int seen = 0;
        for (int j = 0; j < i && !seen; j++) seen = strcmp(g_rows[i].object, g_rows[j].object) == 0;
        n += !seen;
    }
    return n;
}

static void expect_failure(const char *what, int code, const char *needle, const char *const *args)
{
    spawn_result r;
    run_blender(&r, NULL, g_script, args, NULL);
    const char *line = strstr(r.err, "blender_instances: error: ");
    CHECK_MSG(r.code == code && line, "%s: exit %d (expected %d): %s", what, r.code, code, r.err);
    if (line) {
        const char *nl = strchr(line, '\n');
        CHECK_MSG(!nl || !strstr(nl, "blender_instances: error"), "%s: more than one error line: %s", what, r.err);
        if (needle) CHECK_MSG(strstr(line, needle) && (!nl || strstr(line, needle) < nl), "%s: %s", what, line);
    }
    CHECK_MSG(dir_is_empty(g_out), "%s: a file was left behind", what);
    spawn_free(&r);
}

/* A .vdb volume opens in Blender as a volume object: one FLOAT grid
 * "density", placed where the mesh is (its active voxels inside the box
 * voxelized, spanning the mesh's extent: a wrong scale or origin fails). */
static const char VDB_PY[] =
    "import bpy, sys\n"
    "path = sys.argv[sys.argv.index('--') + 1]\n"
    "bpy.ops.object.volume_import(filepath=path)\n"
    "ob = bpy.context.selected_objects[0]\n"
    "ob.data.grids.load()\n"
    "print('VDBGRIDS', ' '.join(g.name + ':' + g.data_type for g in ob.data.grids))\n"
    "bb = [ob.matrix_world @ __import__('mathutils').Vector(c) for c in ob.bound_box]\n"
    "lo = [min(v[i] for v in bb) for i in range(3)]; hi = [max(v[i] for v in bb) for i in range(3)]\n"
    "print('VDBBOX %.6f %.6f %.6f %.6f %.6f %.6f' % (lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]))\n";

static void test_vdb_volume(void)
{
    char vdb[PATH_MAX], py[PATH_MAX];
    path_join(vdb, sizeof vdb, g_dir, "volume.vdb");
    path_join(py, sizeof py, g_dir, "vdb_check.py");
    unlink(vdb);
    spawn_result r;
    spawn_run(&r, ARGS(g_bin, "tests/data/default.obj", "--box", "-2,-2,-2,2,2,2", "-r", "32", "--oversample", "2", "-o",
                       vdb, "-q"),
              60);
    if (r.code != 0 && strstr(r.err, "without OpenVDB")) {
        printf("SKIP: clvox was built without OpenVDB: no .vdb to load\n");
        spawn_free(&r);
        return;
    }
    CHECK_MSG(r.code == 0, "clvox -o volume.vdb: exit %d: %s", r.code, r.err);
    spawn_free(&r);
    CHECK(write_text(py, VDB_PY));
    double secs = 0;
    run_blender(&r, NULL, py, ARGS(vdb), &secs);
    printf("blender: loading a .vdb volume took %.1f s\n", secs);
    const char *grids = find_line(r.out, "VDBGRIDS ");
    CHECK_MSG(r.code == 0 && grids && strncmp(grids, "density:FLOAT", 13) == 0, "vdb grids: exit %d, [%s] %s",
              r.code, grids ? grids : r.out, r.err);
    const char *box = find_line(r.out, "VDBBOX ");
    double b[6] = {0, 0, 0, 0, 0, 0};
    int n = box ? sscanf(box, "%lf %lf %lf %lf %lf %lf", &b[0], &b[1], &b[2], &b[3], &b[4], &b[5]) : 0;
    /* the default mesh spans about 3.2 x 3.2 x 1.6 inside [-2, 2]^3 (voxel 0.125) */
    CHECK_MSG(n == 6 && b[0] >= -2.0001 && b[1] >= -2.0001 && b[2] >= -2.0001 && b[3] <= 2.0001 && b[4] <= 2.0001 &&
                  b[5] <= 2.0001 && b[3] - b[0] > 3.0 && b[4] - b[1] > 3.0 && b[5] - b[2] > 1.4 && b[5] - b[2] < 2.0,
              "vdb bounds in Blender: %s", box ? box : "(none)");
    spawn_free(&r);
}

int main(void)
{
    if (!spawn_which("blender", g_blender, sizeof g_blender)) {
        printf("SKIP: blender is not on PATH (CLVOX_WITH_BLENDER=1 scripts/setup.sh installs it): nothing checked\n");
        return test_report(); /* 0 passed, 0 failed */
    }
    const char *bin = getenv("CLVOX_BIN");
    if (!bin || !*bin) bin = "build/release/clvox";
    if (!realpath(bin, g_bin) || !realpath("scripts/tools/blender_instances.py", g_script)) {
        fprintf(stderr, "cannot find the clvox binary '%s' (CLVOX_BIN) or scripts/tools/blender_instances.py (run from the "
                        "repository root)\n", bin);
        test_failed++;
        return test_report();
    }
    path_join(g_dir, sizeof g_dir, test_tmpdir(), "blender");
    mkdir(g_dir, 0777);
    path_join(g_out, sizeof g_out, g_dir, "out");
    mkdir(g_out, 0777);

    char csv[PATH_MAX], map[PATH_MAX], blend[PATH_MAX], png[PATH_MAX];
    path_join(csv, sizeof csv, g_dir, "scene.csv");
    path_join(map, sizeof map, g_dir, "scene.render");
    path_join(blend, sizeof blend, g_dir, "scene.blend");
    path_join(png, sizeof png, g_dir, "scene.png");
    unlink(blend);
    unlink(png);
    if (!make_csv(csv, map)) return test_report();

    /* the scene: exact placeholders (paper46), saved and rendered */
    spawn_result r;
    double secs = 0;
    char size[32];
    snprintf(size, sizeof size, "%dx%d", W, H);
    run_blender(&r, NULL, g_script,
                ARGS("--csv", csv, "--render-map", map, "--palette", "paper46", "--save", blend, "--render", png,
                     "--size", size, "--samples", "8"),
                &secs);
    printf("blender: building, saving and rendering %d instances (%dx%d, 8 samples) took %.1f s\n", g_rows_n, W, H,
           secs);
    CHECK_MSG(r.code == 0, "blender_instances.py: exit %d: %s", r.code, r.err);
    const char *summary = find_line(r.out, "blender_instances: ");
    CHECK_MSG(summary && strstr(summary, "24 instances of 9 objects (0 from the library, 8 exact, 1 stand-ins)"),
              "summary: %s", summary ? summary : r.out);
    spawn_free(&r);
    long distinct = -1;
    CHECK_MSG(check_png(png, W, H, &distinct), "%s is not an 8-bit RGB PNG of %dx%d", png, W, H);
    CHECK_MSG(distinct > (long)(W * H / 50), "the picture is (nearly) uniform: %ld pixels differ from the corner",
              distinct);
    /* a source for every object: the CSV's and the map's unused one */
    check_scene(blend, g_rows, g_rows_n, distinct_objects(), distinct_objects() + 1);

    /* stand-ins, render only, the default size */
    unlink(png);
    run_blender(&r, NULL, g_script, ARGS("--csv", csv, "--render", png), &secs);
    printf("blender: the same with stand-ins, render only, took %.1f s\n", secs);
    CHECK_MSG(r.code == 0 && strstr(r.out, "(0 from the library, 0 exact, 8 stand-ins)"), "stand-ins: exit %d: %s%s",
              r.code, r.out, r.err);
    spawn_free(&r);
    CHECK(check_png(png, 160, 120, &distinct) && distinct > 160 * 120 / 50);

    /* a library: a mesh object "cheese" and a collection "tent" (two objects in it) */
    static const char MAKE_LIB_PY[] =
        "import bpy, os, sys\n"
        "for o in list(bpy.data.objects): bpy.data.objects.remove(o, do_unlink=True)\n"
        "bpy.ops.mesh.primitive_cone_add(radius1=0.5, depth=1.0)\n"
        "bpy.context.object.name = 'cheese'\n"
        "c = bpy.data.collections.new('tent')\n"
        "bpy.context.scene.collection.children.link(c)\n"
        "for x in (-0.25, 0.25):\n"
        "    bpy.ops.mesh.primitive_cube_add(size=0.4, location=(x, 0, 0))\n"
        "    ob = bpy.context.object\n"
        "    for cc in list(ob.users_collection): cc.objects.unlink(ob)\n"
        "    c.objects.link(ob)\n"
        "bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(sys.argv[sys.argv.index('--') + 1]))\n";
    char lib_py[PATH_MAX], lib[PATH_MAX];
    path_join(lib_py, sizeof lib_py, g_dir, "make_lib.py");
    path_join(lib, sizeof lib, g_dir, "lib.blend");
    unlink(lib);
    CHECK(write_text(lib_py, MAKE_LIB_PY));
    run_blender(&r, NULL, lib_py, ARGS(lib), NULL);
    CHECK_MSG(r.code == 0, "making lib.blend: exit %d: %s", r.code, r.err);
    spawn_free(&r);
    unlink(blend);
    run_blender(&r, NULL, g_script, ARGS("--csv", csv, "--objects", lib, "--palette", "paper46", "--save", blend),
                &secs);
    printf("blender: the scene with library objects, saved only, took %.1f s\n", secs);
    CHECK_MSG(r.code == 0 && strstr(r.out, "24 instances of 8 objects (2 from the library, 6 exact, 0 stand-ins)"),
              "library: exit %d: %s%s", r.code, r.out, r.err);
    spawn_free(&r);
    check_scene(blend, g_rows, g_rows_n, distinct_objects(), distinct_objects() - 1); /* tent: no source object */

    /* failures: one error line, nothing left behind */
    char out_blend[PATH_MAX], out_png[PATH_MAX], bad_csv[PATH_MAX];
    path_join(out_blend, sizeof out_blend, g_out, "x.blend");
    path_join(out_png, sizeof out_png, g_out, "x.png");
    path_join(bad_csv, sizeof bad_csv, g_dir, "bad.csv");
    expect_failure("missing CSV", 1, "cannot open", ARGS("--csv", "no/such.csv", "--save", out_blend));
    char *text = read_text(csv);
    if (text) {
        char *third = strchr(text, '\n');
        third = third ? strchr(third + 1, '\n') : NULL;
        if (third) strcpy(third + 1, "1,2,3,oops\n");
        CHECK(write_text(bad_csv, text));
        free(text);
    }
    expect_failure("bad CSV row", 1, "bad.csv:3: 4 fields, expected 24",
                   ARGS("--csv", bad_csv, "--save", out_blend, "--render", out_png));
    expect_failure("output is a directory", 1, "is not a regular file", ARGS("--csv", csv, "--save", g_out));
    expect_failure("bad size", 2, "--size", ARGS("--csv", csv, "--render", out_png, "--size", "0x5"));
    test_vdb_volume();
    return test_report();
}
