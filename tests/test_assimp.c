/* SPDX-License-Identifier: Apache-2.0 */
/* Formats read through Assimp (src/mesh/mesh_assimp.cpp): one scene written
 * by tests/make_scenes.py as GLB, glTF + .bin, 3MF and DAE (a cube placed by
 * two nodes, a tetrahedron under the second one, a line in the glTF files)
 * and the same triangles flattened into an OBJ.
 *   - the library: 28 triangles, per-triangle source meshes (24 from the
 *     cube, 4 from the tetrahedron), placements, the line counted and left
 *     out, metres for glTF; the child process (what clvox_mesh_load uses)
 *     gives what the shim gives in this process; a 3MF on which Debian's
 *     Assimp aborts (found by fuzz_mesh_assimp) is one error, the caller
 *     lives on;
 *   - the CLI: each scene's .exr and .npy byte-identical to the OBJ's;
 *   - a truncated GLB: one "clvox: error:" line, non-zero exit, no file;
 *   - batch over meshes one of which kills the reader
 *     (CLVOX_TEST_ASSIMP_CRASH): the others are written, that one fails
 *     with "the reader crashed".
 * Needs python3 (scripts/setup.sh installs it) to write the scenes. */
#ifndef _XOPEN_SOURCE
#define _XOPEN_SOURCE 700
#endif
#include "spawn.h"
#include "test.h"
#include "testio.h"
#include "core/internal.h"

#include <limits.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define RUN_TIMEOUT_S 300.0

static char g_bin[PATH_MAX], g_dir[PATH_MAX], g_in[PATH_MAX], g_out[PATH_MAX], g_logs[PATH_MAX];
static unsigned g_run;

static int run(spawn_result *r, const char *const *args, const char *const *env)
{
    char out_path[PATH_MAX], err_path[PATH_MAX];
    spawn_log_paths(g_logs, g_run++, out_path, err_path);
    const char **argv = spawn_argv(g_bin, args);
    spawn_opts o = {0};
    o.timeout_s = RUN_TIMEOUT_S;
    o.env = env;
    int code = spawn_run_to(r, argv, out_path, err_path, &o);
    free(argv);
    return code;
}

static int same_bytes(const char *a, const char *b)
{
    long long na = file_size(a), nb = file_size(b);
    if (na < 0 || na != nb) return 0;
    FILE *fa = fopen(a, "rb"), *fb = fopen(b, "rb");
    int same = fa && fb;
    for (int ca = 0, cb = 0; same && ca != EOF; same = ca == cb) {
        ca = fgetc(fa);
        cb = fgetc(fb);
    }
    if (fa) fclose(fa);
    if (fb) fclose(fb);
    return same;
}

static void test_library(clvox_context *ctx)
{
    char p[PATH_MAX];
    path_join(p, sizeof p, g_in, "scene.glb");
    clvox_mesh *m = NULL;
    CHECK_OK(ctx, clvox_mesh_load(ctx, p, &m));
    if (!m) return;
    const clvox_mesh_report *r = clvox_mesh_get_report(m);
    CHECK(r->triangles == 28);
    clvox_mesh_source_info si = CLVOX_MESH_SOURCE_INFO_INIT;
    CHECK_OK(ctx, clvox_mesh_get_source_info(m, &si));
    CHECK(!strcmp(si.reader, "assimp"));
    CHECK_MSG(si.meshes == 3 && si.placements == 3, "%u meshes, %llu placements", si.meshes,
              (unsigned long long)si.placements);
    CHECK(si.ignored_lines == 1 && si.ignored_points == 0);
    CHECK(si.unit_metres == 1.0);
    clvox_mesh_source_info bad = CLVOX_MESH_SOURCE_INFO_INIT;
    bad.size = 8;
    CHECK(clvox_mesh_get_source_info(m, &bad) == CLVOX_ERR_INVALID_ARGUMENT);

    size_t nt = 0, ns = 0;
    const uint32_t *src = clvox_mesh_triangle_sources(m, &ns);
    clvox_mesh_triangles(m, &nt);
    CHECK(src && ns == nt);
    size_t per[4] = {0};
    for (size_t t = 0; src && t < ns; t++) per[src[t] < 3 ? src[t] : 3]++;
    /* two sources: 24 triangles of the cube (placed twice), 4 of the tetrahedron */
    CHECK_MSG((per[0] == 24 && per[1] == 4) || (per[0] == 4 && per[1] == 24) || (per[0] == 24 && per[2] == 4) ||
                  (per[0] == 4 && per[2] == 24) || (per[1] == 24 && per[2] == 4) || (per[1] == 4 && per[2] == 24),
              "per source %zu %zu %zu %zu", per[0], per[1], per[2], per[3]);

    clvox_mesh_destroy(m);

    /* the child process hands back what the shim reads in this one, bit for bit */
    char *bytes = read_all(p);
    size_t n = (size_t)file_size(p);
    clvox__raw_mesh here, child;
    char e1[512], e2[512];
    CHECK(clvox__assimp_read(p, "glb", (const unsigned char *)bytes, n, &here, e1, sizeof e1) == 0);
    CHECK(clvox__assimp_read_isolated(p, "glb", (const unsigned char *)bytes, n, &child, e2, sizeof e2) == 0);
    CHECK(here.vertex_count == child.vertex_count && here.face_count == child.face_count && here.face_count == 28 &&
          !memcmp(here.xyz, child.xyz, 3 * here.vertex_count * sizeof(float)) &&
          !memcmp(here.face_indices, child.face_indices, 3 * here.face_count * sizeof(uint32_t)) &&
          !memcmp(here.face_source, child.face_source, here.face_count * sizeof(uint32_t)) &&
          !memcmp(here.offset, child.offset, sizeof here.offset) &&
          !memcmp(&here.source, &child.source, sizeof here.source));
    clvox__raw_mesh_free(&here);
    clvox__raw_mesh_free(&child);
    free(bytes);

    /* Debian's Assimp aborts on this 3MF (an assertion, D3MFOpcPackage.cpp:170) */
    CHECK_STATUS(ctx, clvox_mesh_load(ctx, "tests/data/assimp_abort.3mf", &m), CLVOX_ERR_MESH_FORMAT);
    CHECK_MSG(strstr(clvox_context_error(ctx), "the reader crashed (signal 6"), "%s", clvox_context_error(ctx));

    /* clvox's own readers: one source, no per-triangle index */
    path_join(p, sizeof p, g_in, "flat.obj");
    CHECK_OK(ctx, clvox_mesh_load(ctx, p, &m));
    clvox_mesh_source_info so = CLVOX_MESH_SOURCE_INFO_INIT;
    CHECK_OK(ctx, clvox_mesh_get_source_info(m, &so));
    CHECK(!strcmp(so.reader, "obj") && so.meshes == 1 && so.unit_metres == 0);
    CHECK(clvox_mesh_triangle_sources(m, &ns) == NULL && ns == 0);
    clvox_mesh_destroy(m);

    /* What the fuzzer found in Assimp itself (tests/fuzz/findings_mesh_assimp,
     * first byte: 0 .glb, 1 .gltf, 2 .3mf): through clvox_mesh_load this
     * process lives on, and a failure is one line. */
    static const char *const findings[] = {"3mf_assert_abort", "glb_strlen_heap_overflow", "oom_00"};
    for (size_t k = 0; k < sizeof findings / sizeof findings[0]; k++) {
        static const char *const exts[3] = {"glb", "gltf", "3mf"};
        char src_path[PATH_MAX], copy[PATH_MAX], name[96];
        snprintf(src_path, sizeof src_path, "tests/fuzz/findings_mesh_assimp/%s", findings[k]);
        long long fn = file_size(src_path);
        char *fb = read_all(src_path);
        CHECK_MSG(fn > 1, "%s missing", src_path);
        if (fn <= 1) {
            free(fb);
            continue;
        }
        snprintf(name, sizeof name, "%s.%s", findings[k], exts[(unsigned char)fb[0] % 3]);
        path_join(copy, sizeof copy, g_in, name);
        FILE *cf = fopen(copy, "wb");
        CHECK(cf && fwrite(fb + 1, 1, (size_t)fn - 1, cf) == (size_t)fn - 1);
        if (cf) fclose(cf);
        free(fb);
        clvox_mesh *fm = NULL;
        clvox_status fst = clvox_mesh_load(ctx, copy, &fm);
        const char *msg = clvox_context_error(ctx);
        CHECK_MSG(fst == CLVOX_OK || ((fst == CLVOX_ERR_MESH_FORMAT || fst == CLVOX_ERR_MESH_EMPTY ||
                                      fst == CLVOX_ERR_MESH_INVALID) && *msg && !strchr(msg, '\n')),
                  "%s: %s: %s", name, clvox_status_string(fst), msg);
        clvox_mesh_destroy(fm);
    }

    /* a truncated GLB and an unknown extension: clear errors */
    path_join(p, sizeof p, g_in, "truncated.glb");
    CHECK_STATUS(ctx, clvox_mesh_load(ctx, p, &m), CLVOX_ERR_MESH_FORMAT);
    CHECK(m == NULL);
}

/* Each scene's volume, as .exr and .npy, byte-identical to the OBJ's. */
static void test_same_voxels(void)
{
    static const char *const scenes[] = {"scene.glb", "scene.gltf", "scene.3mf", "scene.dae"};
    static const char *const outs[] = {"exr", "npy"};
    for (size_t o = 0; o < 2; o++) {
        char in[PATH_MAX], ref[PATH_MAX], name[64];
        path_join(in, sizeof in, g_in, "flat.obj");
        snprintf(name, sizeof name, "flat.%s", outs[o]);
        path_join(ref, sizeof ref, g_out, name);
        spawn_result r;
        CHECK_MSG(run(&r, (const char *const[]){in, "-r", "40", "-o", ref, NULL}, NULL) == 0, "%s", r.err);
        spawn_free(&r);
        for (size_t k = 0; k < sizeof scenes / sizeof scenes[0]; k++) {
            char out[PATH_MAX];
            snprintf(name, sizeof name, "%s.%s", scenes[k], outs[o]);
            path_join(in, sizeof in, g_in, scenes[k]);
            path_join(out, sizeof out, g_out, name);
            int code = run(&r, (const char *const[]){in, "-r", "40", "-o", out, NULL}, NULL);
            CHECK_MSG(code == 0, "%s: %s", scenes[k], r.err);
            CHECK_MSG(strstr(r.out, "scene ") != NULL, "%s: no scene line in\n%s", scenes[k], r.out);
            spawn_free(&r);
            CHECK_MSG(same_bytes(ref, out), "%s differs from %s", out, ref);
        }
    }
}

static void test_truncated(void)
{
    char in[PATH_MAX], out[PATH_MAX];
    path_join(in, sizeof in, g_in, "truncated.glb");
    path_join(out, sizeof out, g_out, "truncated.exr");
    spawn_result r;
    int code = run(&r, (const char *const[]){in, "-o", out, NULL}, NULL);
    CHECK(code != 0 && code > 0 && code < 128);
    CHECK_MSG(count_lines(r.err) == 1 && !strncmp(r.err, "clvox: error: ", 14) && strstr(r.err, "truncated.glb"),
              "stderr: %s", r.err);
    CHECK(!file_exists(out));
    spawn_free(&r);
}

/* A reader that kills its process: batch goes on with the others. */
static void test_batch_crash(void)
{
    char a[PATH_MAX], crash[PATH_MAX], obj[PATH_MAX], tmpl[PATH_MAX + 16];
    path_join(a, sizeof a, g_in, "scene.glb");
    path_join(crash, sizeof crash, g_in, "crash_me.glb");
    path_join(obj, sizeof obj, g_in, "flat.obj");
    char *bytes = read_all(a);
    FILE *f = fopen(crash, "wb");
    long long n = file_size(a);
    CHECK(f && n > 0 && fwrite(bytes, 1, (size_t)n, f) == (size_t)n);
    if (f) fclose(f);
    free(bytes);
    snprintf(tmpl, sizeof tmpl, "%s/{stem}.npy", g_out);

    extern char **environ;
    size_t ne = 0;
    while (environ[ne]) ne++;
    const char **env = calloc(ne + 2, sizeof *env);
    for (size_t i = 0; i < ne; i++) env[i] = environ[i];
    env[ne] = "CLVOX_TEST_ASSIMP_CRASH=crash_me";
    spawn_result r;
    int code = run(&r, (const char *const[]){"batch", a, crash, obj, "-r", "16", "-o", tmpl, NULL}, env);
    free(env);
    CHECK_MSG(code != 0 && code < 128, "exit %d", code); /* one mesh failed; not killed */
    CHECK_MSG(strstr(r.err, "crash_me.glb") && strstr(r.err, "the reader crashed"), "stderr: %s", r.err);
    char p[PATH_MAX];
    path_join(p, sizeof p, g_out, "scene.npy");
    CHECK(file_exists(p));
    path_join(p, sizeof p, g_out, "flat.npy");
    CHECK(file_exists(p));
    path_join(p, sizeof p, g_out, "crash_me.npy");
    CHECK(!file_exists(p));
    spawn_free(&r);
}

int main(void)
{
    const char *bin = getenv("CLVOX_BIN");
    char bin_abs[PATH_MAX];
    if (!test_cli_dirs(bin ? bin : "build/release/clvox", "assimp", bin_abs, g_dir, g_in, g_out, g_logs))
        return test_report();
    snprintf(g_bin, sizeof g_bin, "%s", bin_abs);

    /* the scenes, written by the script next to this file */
    char script[PATH_MAX];
    snprintf(script, sizeof script, "%s", __FILE__);
    char *slash = strrchr(script, '/');
    if (slash) snprintf(slash + 1, sizeof script - (size_t)(slash + 1 - script), "make_scenes.py");
    else snprintf(script, sizeof script, "tests/make_scenes.py");
    spawn_result r;
    int code = spawn_run(&r, (const char *const[]){"python3", script, g_in, NULL}, RUN_TIMEOUT_S);
    CHECK_MSG(code == 0, "python3 %s %s: exit %d: %s", script, g_in, code, r.err);
    spawn_free(&r);
    if (code != 0) return test_report();

    clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
    o.host_only = 1;
    clvox_context *ctx = NULL;
    CHECK_OK(ctx, clvox_context_create(&o, &ctx));
    test_library(ctx);
    clvox_context_destroy(ctx);
    test_same_voxels();
    test_truncated();
    test_batch_crash();
    return test_report();
}
