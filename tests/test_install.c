/* SPDX-License-Identifier: Apache-2.0 */
/* `make install` into a scratch DESTDIR, then use what was installed the way
 * a user would: the files are there, clvox.pc gives flags that build a
 * program against the static and against the shared library, that program
 * runs, and the installed clvox voxelizes its bundled default mesh with no
 * source tree beside it. Runs from the repository root (tests/run_tests.sh
 * does); $CONFIG names the build (default release). */
#include "test.h"

#include <stdarg.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static char root[1024];   /* DESTDIR */
static char prefix[1100]; /* DESTDIR + PREFIX */

/* Runs a shell command built from fmt; 1 when it exits 0. */
__attribute__((format(printf, 1, 2))) static int run(const char *fmt, ...)
{
    static char cmd[16384];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(cmd, sizeof cmd, fmt, ap);
    va_end(ap);
    if (n < 0 || (size_t)n >= sizeof cmd) {
        fprintf(stderr, "command too long: %s\n", fmt);
        return 0;
    }
    int rc = system(cmd);
    if (rc != 0) fprintf(stderr, "command failed (%d): %s\n", rc, cmd);
    return rc == 0;
}

static int is_file(const char *rel, int executable)
{
    char p[1300];
    struct stat st;
    snprintf(p, sizeof p, "%s/%s", prefix, rel);
    return stat(p, &st) == 0 && S_ISREG(st.st_mode) && st.st_size > 0 && (!executable || (st.st_mode & 0100));
}

/* Smallest useful library user: version, then a unit cube from arrays
 * voxelized in memory at 4^3 (every centre inside: 64 voxels). */
static const char program[] =
    "#include <clvox.h>\n"
    "#include <stdio.h>\n"
    "#include <string.h>\n"
    "int main(void) {\n"
    "  if (strcmp(clvox_version(), CLVOX_VERSION_STRING)) return 1;\n"
    "  const float v[] = {0,0,0, 1,0,0, 1,1,0, 0,1,0, 0,0,1, 1,0,1, 1,1,1, 0,1,1};\n"
    "  const uint32_t t[] = {0,2,1, 0,3,2, 4,5,6, 4,6,7, 0,1,5, 0,5,4, 1,2,6, 1,6,5,\n"
    "                        2,3,7, 2,7,6, 3,0,4, 3,4,7};\n"
    "  clvox_context *ctx = NULL; clvox_mesh *m = NULL;\n"
    "  if (clvox_context_create(NULL, &ctx) != CLVOX_OK) { printf(\"no context: %s\\n\", clvox_context_error(ctx)); return 2; }\n"
    "  if (clvox_mesh_from_arrays(ctx, v, 8, t, 12, &m) != CLVOX_OK) return 3;\n"
    "  clvox_grid g = {{4, 4, 4}, {0, 0, 0}, {0.25, 0.25, 0.25}};\n"
    "  uint8_t vox[64];\n"
    "  clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;\n"
    "  clvox_stats s = CLVOX_STATS_INIT;\n"
    "  if (clvox_voxelize_to_memory(ctx, m, &g, &o, vox, sizeof vox, &s) != CLVOX_OK) return 4;\n"
    "  printf(\"filled %llu\\n\", (unsigned long long)s.filled_voxels);\n"
    "  clvox_mesh_destroy(m); clvox_context_destroy(ctx);\n"
    "  return s.filled_voxels == 64 ? 0 : 5;\n"
    "}\n";

int main(void)
{
    const char *config = getenv("CONFIG");
    if (!config || !*config) config = "release";
    const char *tmp = test_tmpdir();
    char cwd[512] = "";
    if (tmp[0] != '/' && !getcwd(cwd, sizeof cwd)) return 1;
    snprintf(root, sizeof root, "%s%s%s/install", cwd, *cwd ? "/" : "", tmp);
    snprintf(prefix, sizeof prefix, "%s/usr", root);
    int installed = run("rm -rf '%s' && make -s install CONFIG=%s PREFIX=/usr DESTDIR='%s' >'%s.log' 2>&1", root,
                        config, root, root);
    CHECK(installed);
    if (!installed) { /* nothing below can work */
        run("cat '%s.log' >&2", root);
        return test_report();
    }

    static const char *files[] = {"include/clvox.h", "lib/libclvox.a", "lib/libclvox.so", "lib/pkgconfig/clvox.pc",
                                  "share/clvox/default.obj"};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++)
        CHECK_MSG(is_file(files[i], 0), "%s not installed", files[i]);
    CHECK(is_file("bin/clvox", 1));
    char so[64];
    snprintf(so, sizeof so, "lib/libclvox.so.%s", CLVOX_VERSION_STRING);
    CHECK_MSG(is_file(so, 1), "%s not installed", so);

    /* Build against the installed tree only (sysroot = DESTDIR). Sanitizer
     * builds need the sanitizer runtime in the user program too. */
    const char *san = strcmp(config, "sanitize") == 0 ? "-fsanitize=address,undefined" : "";
    char pc[3000];
    snprintf(pc, sizeof pc, "PKG_CONFIG_PATH='%s/lib/pkgconfig' PKG_CONFIG_SYSROOT_DIR='%s' pkg-config", prefix, root);
    char src[1200];
    snprintf(src, sizeof src, "%s/user.c", root);
    FILE *f = fopen(src, "w");
    CHECK(f && fputs(program, f) >= 0);
    if (f) CHECK(fclose(f) == 0);
    CHECK(run("cc -std=c11 %s -o '%s/user_static' '%s' $(%s --cflags clvox) '%s/lib/libclvox.a' "
              "$(%s --libs-only-l --static clvox | sed 's/-lclvox//')", san, root, src, pc, prefix, pc));
    CHECK(run("cc -std=c11 %s -o '%s/user_shared' '%s' $(%s --cflags --libs clvox)", san, root, src, pc));
    CHECK(run("'%s/user_static' >/dev/null", root));
    /* The shared build must find libclvox.so.<major> through the soname link. */
    CHECK(run("LD_LIBRARY_PATH='%s/lib' '%s/user_shared' >/dev/null", prefix, root));
    CHECK(run("LD_LIBRARY_PATH='%s/lib' ldd '%s/user_shared' | grep -q '%s/lib/libclvox.so'", prefix, root, prefix));

    /* The installed binary, run from an empty directory: the default mesh
     * comes from <prefix>/share/clvox, the kernels from the binary. */
    CHECK(run("mkdir -p '%s/run' && cd '%s/run' && env -u CLVOX_DEFAULT_MESH '%s/bin/clvox' -r 32 -q && "
              "test -s default.exr && '%s/bin/clvox' info default.exr | grep -q '32 x'",
              root, root, prefix, prefix));
    /* The .vdb writer plugin (when the build made one): installed in lib/clvox,
     * and the installed binary loads that copy, not the build tree's. */
    char built_plugin[1200];
    snprintf(built_plugin, sizeof built_plugin, "build/%s/libclvox-vdb.so", config);
    if (access(built_plugin, F_OK) == 0) {
        CHECK_MSG(is_file("lib/clvox/libclvox-vdb.so", 1), "lib/clvox/libclvox-vdb.so not installed");
        CHECK(run("cd '%s/run' && LD_DEBUG=files '%s/bin/clvox' -r 16 -q -o v.vdb 2>'%s/run/ld.log' && test -s v.vdb && "
                  "grep -q 'file=%s/lib/clvox/libclvox-vdb.so ' '%s/run/ld.log'",
                  root, prefix, root, prefix, root));
    }
    if (test_failed == 0) run("rm -rf '%s' '%s.log'", root, root);
    return test_report();
}
