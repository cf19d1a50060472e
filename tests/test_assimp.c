/* SPDX-License-Identifier: Apache-2.0 */
/* Formats read through Assimp (src/mesh/mesh_assimp.cpp): one scene written
 * by tests/make_scenes.py as GLB, glTF + .bin, 3MF and DAE (a cube placed by
 * two nodes, a tetrahedron under the second one, a line in the glTF files)
 * and the same triangles flattened into an OBJ; the GLB exported to FBX
 * here by Assimp's own exporters (make_fbx: ASCII "fbxa", binary "fbx"
 * repaired, the ASCII one with UnitScaleFactor 2.54).
 *   - the library: 28 triangles, per-triangle source meshes (24 from the
 *     cube, 4 from the tetrahedron), placements, the line counted and left
 *     out, metres for glTF, UnitScaleFactor / 100 for FBX (1 -> 0.01 m,
 *     2.54 -> 2.54 / 100 m, though Assimp keeps it as a float); the child process (what clvox_mesh_load uses)
 *     gives what the shim gives in this process; a 3MF on which Debian's
 *     Assimp aborts (found by fuzz_mesh_assimp) is one error, the caller
 *     lives on;
 *   - the CLI: each scene's .exr and .npy byte-identical to the OBJ's (FBX
 *     too, the one stating inches included: coordinates are never rescaled);
 *   - bad input, each one "clvox: error:" line, exit 1..127, no file: a
 *     truncated GLB; a 270 KB GLB placing one 20,000-triangle mesh 2,000
 *     times (the flattened-scene bound); .gltf buffers naming a directory, a
 *     FIFO (opening it would block) and a link to /dev/zero; Assimp 5.2's
 *     own binary FBX export as written, when its reader refuses it;
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

#include <assimp/cexport.h>
#include <assimp/cimport.h>
#include <assimp/scene.h>
#include <assimp/version.h>

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

/* The FBX files, from scene.glb by Assimp's exporters (no FBX is written by
 * hand): scene_ascii.fbx ("fbxa"), export_binary.fbx ("fbx", as Assimp
 * writes it), scene_binary.fbx (that one with its null records restored,
 * fbx_add_null_records) and scene_inch.fbx (scene_ascii.fbx stating
 * UnitScaleFactor 2.54, i.e. inches). */

static uint64_t get64(const unsigned char *p)
{
    uint64_t v = 0;
    for (int i = 7; i >= 0; i--) v = v << 8 | p[i];
    return v;
}

static void put64(unsigned char *p, uint64_t v)
{
    for (int i = 0; i < 8; i++, v >>= 8) p[i] = (unsigned char)v;
}

#define FBX_NULL_RECORD 25 /* a 7500+ node record header, all zero */

/* One node of a binary FBX (7500+: 64-bit header) from f[*pos] to its end
 * offset, copied to o with a null record after its children, offsets
 * rewritten; *pos = its end. o has room for 2 x the input. 0 on a record
 * that does not fit. */
static int fbx_node(const unsigned char *f, size_t end_limit, size_t *pos, unsigned char *o, size_t *on,
                    unsigned depth)
{
    static const unsigned char zero[FBX_NULL_RECORD];
    size_t at = *pos;
    if (depth > 64 || end_limit < at || end_limit - at < FBX_NULL_RECORD) return 0;
    uint64_t end = get64(f + at), plen = get64(f + at + 16);
    size_t body = at + FBX_NULL_RECORD + f[at + 24];
    if (end > end_limit || end <= at || body > end || plen > end - body) return 0;
    body += (size_t)plen;
    size_t head = *on;
    memcpy(o + *on, f + at, body - at);
    *on += body - at;
    size_t c = body;
    while (c < end) {
        if (end - c == FBX_NULL_RECORD && !memcmp(f + c, zero, FBX_NULL_RECORD)) break; /* already there */
        if (!fbx_node(f, (size_t)end, &c, o, on, depth + 1)) return 0;
    }
    if (body < end) { /* it has children: they end with a null record */
        memset(o + *on, 0, FBX_NULL_RECORD);
        *on += FBX_NULL_RECORD;
    }
    put64(o + head, (uint64_t)*on);
    *pos = (size_t)end;
    return 1;
}

/* Assimp 5.2's binary FBX exporter writes its null records as empty strings
 * (NULL_RECORD through a std::string: assimp#4686, fixed by assimp#4824 in
 * Dec 2022, after 5.2.5), so every node with children lacks the 25 zero
 * bytes that end them, and Assimp's own reader refuses the file ("block
 * offset is out of range"). This puts them back: a node tree copied as it
 * is, nothing else changed. 1 on success. */
static int fbx_add_null_records(const char *in, const char *out)
{
    long long n = file_size(in);
    unsigned char *f = (unsigned char *)read_all(in);
    if (n < 27 + FBX_NULL_RECORD || memcmp(f, "Kaydara FBX Binary  ", 20) ||
        (f[23] | f[24] << 8 | f[25] << 16 | (uint32_t)f[26] << 24) < 7500) {
        free(f);
        return 0;
    }
    size_t size = (size_t)n, pos = 27, on = 27;
    unsigned char *o = malloc(2 * size + FBX_NULL_RECORD); /* each node adds at most one record, 25+ bytes */
    int ok = o != NULL;
    if (ok) memcpy(o, f, 27);
    while (ok && size - pos >= FBX_NULL_RECORD) {
        uint64_t end = get64(f + pos);
        if (end == 0 || end > size || end <= pos) break; /* the top level's null record, or the footer */
        ok = fbx_node(f, size, &pos, o, &on, 0);
    }
    if (ok && (size - pos < 8 || get64(f + pos) != 0)) { /* the top level's own null record */
        memset(o + on, 0, FBX_NULL_RECORD);
        on += FBX_NULL_RECORD;
    }
    if (ok) {
        memcpy(o + on, f + pos, size - pos); /* the footer */
        on += size - pos;
        FILE *w = fopen(out, "wb");
        ok = w && fwrite(o, 1, on, w) == on;
        if (w && fclose(w) != 0) ok = 0;
    }
    free(o);
    free(f);
    return ok;
}

static int make_fbx(void)
{
    char glb[PATH_MAX], ascii[PATH_MAX], raw[PATH_MAX], fixed[PATH_MAX], inch[PATH_MAX];
    path_join(glb, sizeof glb, g_in, "scene.glb");
    path_join(ascii, sizeof ascii, g_in, "scene_ascii.fbx");
    path_join(raw, sizeof raw, g_in, "export_binary.fbx");
    path_join(fixed, sizeof fixed, g_in, "scene_binary.fbx");
    path_join(inch, sizeof inch, g_in, "scene_inch.fbx");
    const struct aiScene *s = aiImportFile(glb, 0);
    CHECK_MSG(s != NULL, "Assimp cannot read %s: %s", glb, aiGetErrorString());
    if (!s) return 0;
    aiReturn ra = aiExportScene(s, "fbxa", ascii, 0), rb = aiExportScene(s, "fbx", raw, 0);
    aiReleaseImport(s);
    CHECK_MSG(ra == aiReturn_SUCCESS && rb == aiReturn_SUCCESS, "Assimp's FBX export: %s", aiGetErrorString());
    int ok = ra == aiReturn_SUCCESS && rb == aiReturn_SUCCESS && fbx_add_null_records(raw, fixed);
    CHECK(ok);

    /* the same scene stating inches: 1 unit = 2.54 cm */
    char *text = read_text(ascii);
    static const char unit[] = "\"UnitScaleFactor\", \"double\", \"Number\", \"\", 1\n";
    char *at = text ? strstr(text, unit) : NULL;
    CHECK_MSG(at != NULL, "no UnitScaleFactor 1 in %s", ascii);
    if (at) {
        FILE *w = fopen(inch, "wb");
        size_t head = (size_t)(at - text) + sizeof unit - 3, tail = strlen(at + sizeof unit - 2);
        int wrote = w && fwrite(text, 1, head, w) == head && fputs("2.54", w) >= 0 &&
                    fwrite(at + sizeof unit - 2, 1, tail, w) == tail;
        if (w && fclose(w) != 0) wrote = 0;
        CHECK(wrote);
        ok = ok && wrote;
    }
    free(text);
    return ok;
}

/* The scene as clvox_mesh_load reads it: 28 triangles from two source
 * meshes (the cube placed twice), placements, lines, unit. */
static void check_scene(clvox_context *ctx, const char *name, unsigned meshes, unsigned lines, double unit)
{
    char p[PATH_MAX];
    path_join(p, sizeof p, g_in, name);
    clvox_mesh *m = NULL;
    CHECK_OK(ctx, clvox_mesh_load(ctx, p, &m));
    if (!m) return;
    const clvox_mesh_report *r = clvox_mesh_get_report(m);
    CHECK_MSG(r->triangles == 28, "%s: %llu triangles", name, (unsigned long long)r->triangles);
    clvox_mesh_source_info si = CLVOX_MESH_SOURCE_INFO_INIT;
    CHECK_OK(ctx, clvox_mesh_get_source_info(m, &si));
    CHECK(!strcmp(si.reader, "assimp"));
    CHECK_MSG(si.meshes == meshes && si.placements == 3, "%s: %u meshes, %llu placements", name, si.meshes,
              (unsigned long long)si.placements);
    CHECK_MSG(si.ignored_lines == lines && si.ignored_points == 0, "%s: %llu lines, %llu points", name,
              (unsigned long long)si.ignored_lines, (unsigned long long)si.ignored_points);
    CHECK_MSG(si.unit_metres == unit, "%s: unit %.17g m, expected %.17g", name, si.unit_metres, unit);
    clvox_mesh_source_info bad = CLVOX_MESH_SOURCE_INFO_INIT;
    bad.size = 8;
    CHECK(clvox_mesh_get_source_info(m, &bad) == CLVOX_ERR_INVALID_ARGUMENT);

    size_t nt = 0, ns = 0;
    const uint32_t *src = clvox_mesh_triangle_sources(m, &ns);
    clvox_mesh_triangles(m, &nt);
    CHECK(src && ns == nt);
    size_t per[4] = {0};
    for (size_t t = 0; src && t < ns; t++) per[src[t] < 3 ? src[t] : 3]++;
    /* two sources: 24 triangles of the cube (one mesh placed twice: the
     * instancing kept), 4 of the tetrahedron */
    CHECK_MSG((per[0] == 24 && per[1] == 4) || (per[0] == 4 && per[1] == 24) || (per[0] == 24 && per[2] == 4) ||
                  (per[0] == 4 && per[2] == 24) || (per[1] == 24 && per[2] == 4) || (per[1] == 4 && per[2] == 24),
              "%s: per source %zu %zu %zu %zu", name, per[0], per[1], per[2], per[3]);
    clvox_mesh_destroy(m);
}

static void test_library(clvox_context *ctx, int have_fbx)
{
    char p[PATH_MAX];
    clvox_mesh *m = NULL;
    check_scene(ctx, "scene.glb", 3, 1, 1.0);
    if (have_fbx) {
        /* Assimp's exporter states centimetres (UnitScaleFactor 1); the line
         * goes through FBX as a mesh of one 2-index face */
        check_scene(ctx, "scene_ascii.fbx", 3, 1, 0.01);
        check_scene(ctx, "scene_binary.fbx", 3, 1, 0.01);
        check_scene(ctx, "scene_inch.fbx", 3, 1, 2.54 / 100); /* not 2.54f / 100: Assimp's float, as written */
        /* Assimp 5.2's binary export as it writes it: read if a fixed Assimp
         * reads it, else refused with Assimp's one-line reason */
        path_join(p, sizeof p, g_in, "export_binary.fbx");
        clvox_status st = clvox_mesh_load(ctx, p, &m);
        CHECK_MSG(st == CLVOX_OK || (st == CLVOX_ERR_MESH_FORMAT && strstr(clvox_context_error(ctx), "FBX")),
                  "%s: %s", clvox_status_string(st), clvox_context_error(ctx));
        if (st != CLVOX_OK)
            fprintf(stderr, "note: Assimp %u.%u.%u cannot read its own binary FBX export (%s): repaired for the test\n",
                    aiGetVersionMajor(), aiGetVersionMinor(), aiGetVersionPatch(), clvox_context_error(ctx));
        clvox_mesh_destroy(m);
        m = NULL;
    }
    path_join(p, sizeof p, g_in, "scene.glb");

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
    size_t ns = 1;
    CHECK(clvox_mesh_triangle_sources(m, &ns) == NULL && ns == 0);
    clvox_mesh_destroy(m);

    /* What the fuzzer found in Assimp itself (tests/fuzz/findings_mesh_assimp,
     * first byte mod 4: 0 .glb, 1 .gltf, 2 .3mf, 3 .fbx): through clvox_mesh_load this
     * process lives on, and a failure is one line. */
    static const char *const findings[] = {"3mf_assert_abort", "glb_strlen_heap_overflow", "oom_00",
                                           "glb_null_deref_segv", "glb_malloc_4g", "glb_heap_overflow_read",
                                           "fbx_stack_overflow"};
    for (size_t k = 0; k < sizeof findings / sizeof findings[0]; k++) {
        static const char *const exts[4] = {"glb", "gltf", "3mf", "fbx"};
        char src_path[PATH_MAX], copy[PATH_MAX], name[96];
        snprintf(src_path, sizeof src_path, "tests/fuzz/findings_mesh_assimp/%s", findings[k]);
        long long fn = file_size(src_path);
        char *fb = read_all(src_path);
        CHECK_MSG(fn > 1, "%s missing", src_path);
        if (fn <= 1) {
            free(fb);
            continue;
        }
        snprintf(name, sizeof name, "%s.%s", findings[k], exts[(unsigned char)fb[0] % 4]);
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
static void test_same_voxels(int have_fbx)
{
    static const char *const scenes[] = {"scene.glb",       "scene.gltf",       "scene.3mf",     "scene.dae",
                                         "scene_ascii.fbx", "scene_binary.fbx", "scene_inch.fbx"};
    static const char *const outs[] = {"exr", "npy"};
    size_t nscenes = have_fbx ? sizeof scenes / sizeof scenes[0] : 4;
    for (size_t o = 0; o < 2; o++) {
        char in[PATH_MAX], ref[PATH_MAX], name[64];
        path_join(in, sizeof in, g_in, "flat.obj");
        snprintf(name, sizeof name, "flat.%s", outs[o]);
        path_join(ref, sizeof ref, g_out, name);
        spawn_result r;
        CHECK_MSG(run(&r, (const char *const[]){in, "-r", "40", "-o", ref, NULL}, NULL) == 0, "%s", r.err);
        spawn_free(&r);
        for (size_t k = 0; k < nscenes; k++) {
            char out[PATH_MAX];
            snprintf(name, sizeof name, "%s.%s", scenes[k], outs[o]);
            path_join(in, sizeof in, g_in, scenes[k]);
            path_join(out, sizeof out, g_out, name);
            int code = run(&r, (const char *const[]){in, "-r", "40", "-o", out, NULL}, NULL);
            CHECK_MSG(code == 0, "%s: %s", scenes[k], r.err);
            CHECK_MSG(strstr(r.out, "scene ") != NULL, "%s: no scene line in\n%s", scenes[k], r.out);
            if (strstr(scenes[k], ".fbx"))
                CHECK_MSG(strstr(r.out, strstr(scenes[k], "inch") ? "1 unit = 0.0254 m" : "1 unit = 0.01 m"),
                          "%s: %s", scenes[k], r.out);
            spawn_free(&r);
            CHECK_MSG(same_bytes(ref, out), "%s differs from %s", out, ref);
        }
    }
}

/* A file clvox must refuse: one "clvox: error:" line naming it and saying
 * why (why: a part of that line), exit 1..127, no output. */
static void check_refused(const char *name, const char *why)
{
    char in[PATH_MAX], out[PATH_MAX], outname[PATH_MAX];
    path_join(in, sizeof in, g_in, name);
    snprintf(outname, sizeof outname, "%s.exr", name);
    path_join(out, sizeof out, g_out, outname);
    spawn_result r;
    int code = run(&r, (const char *const[]){in, "-o", out, NULL}, NULL);
    CHECK_MSG(code > 0 && code < 128, "%s: exit %d", name, code);
    CHECK_MSG(count_lines(r.err) == 1 && !strncmp(r.err, "clvox: error: ", 14) && strstr(r.err, name) &&
                  strstr(r.err, why),
              "%s: stderr (wanted '%s'): %s", name, why, r.err);
    CHECK_MSG(!file_exists(out), "%s: %s written", name, out);
    spawn_free(&r);
}

static void test_refused(int have_fbx)
{
    check_refused("truncated.glb", "Assimp");
    /* 2,000 placements of a 20,000-triangle mesh in 270 KB: 724 MB flattened */
    check_refused("many_placements.glb", "exceeds the bound for a file of this size");
    /* buffers that are not regular files: never opened for reading (a FIFO
     * would block), the reason added to Assimp's message */
    check_refused("buffer_dir.gltf", "Is a directory");
    check_refused("buffer_fifo.gltf", "not a regular file");
    check_refused("buffer_zero.gltf", "not a regular file");
    if (have_fbx) {
        char raw[PATH_MAX];
        path_join(raw, sizeof raw, g_in, "export_binary.fbx");
        clvox__raw_mesh probe;
        char e[512];
        char *bytes = read_all(raw);
        int rc = clvox__assimp_read_isolated(raw, "fbx", (const unsigned char *)bytes, (size_t)file_size(raw),
                                             &probe, e, sizeof e);
        free(bytes);
        clvox__raw_mesh_free(&probe);
        if (rc != 0) check_refused("export_binary.fbx", "FBX-Tokenize");
    }
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

    int have_fbx = make_fbx();
    clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
    o.host_only = 1;
    clvox_context *ctx = NULL;
    CHECK_OK(ctx, clvox_context_create(&o, &ctx));
    test_library(ctx, have_fbx);
    clvox_context_destroy(ctx);
    test_same_voxels(have_fbx);
    test_refused(have_fbx);
    test_batch_crash();
    return test_report();
}
