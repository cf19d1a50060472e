/* SPDX-License-Identifier: Apache-2.0 */
/* The whole kernel program, as the library builds it (the embedded sources
 * in order, the same options: src/core/device_checks.c
 * clvox__build_options), compiled by clang (Debian's clang-14, the front
 * end of ROCm's, Intel's and PoCL's compilers) for spir64, nvptx64 and
 * amdgcn at -O0 and -O2, double and float kernels: no function may be left
 * declared but undefined in the module except OpenCL builtins (mangled
 * names, _Z...) and LLVM intrinsics. A helper without a body (a plain C99
 * `inline` function the compiler chose not to emit) would fail to link on
 * a real driver; PoCL hides it by inlining everything. A driver defines
 * __OPENCL_VERSION__; clang alone does not, so it is given here.
 * Needs clang and llvm-nm (scripts/setup.sh: clang, llvm). */
#include "core/internal.h"
#include "spawn.h"
#include "test.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static char g_clang[4096], g_nm[4096];

static int find_tool(const char *a, const char *b, char *buf, size_t size)
{
    return spawn_which(a, buf, size) || spawn_which(b, buf, size);
}

/* Writes the embedded sources, concatenated as clCreateProgramWithSource
 * joins them, to path. */
static int write_program(const char *path)
{
    FILE *f = fopen(path, "w");
    if (!f) return 0;
    for (unsigned i = 0; i < clvox__kernel_source_count; i++) fputs(clvox__kernel_sources[i], f);
    return fclose(f) == 0;
}

/* Compiles src for target at opt with the library's options; counts the
 * defined kernels' and helpers' symbols, lists the undefined non-builtin
 * ones in bad. Returns 0 when clang or llvm-nm failed. */
static int compile(const char *src, const char *target, const char *opt, int kernels_float, char *bad,
                   size_t bad_size, int *defined)
{
    char bc[4096], opts[256];
    snprintf(bc, sizeof bc, "%s/kernel_targets.bc", test_tmpdir());
    snprintf(opts, sizeof opts, "%s", clvox__build_options(kernels_float, 1));
    const char *argv[32];
    int n = 0;
    argv[n++] = g_clang;
    argv[n++] = "-cl-std=CL1.2";
    argv[n++] = "-Xclang";
    argv[n++] = "-finclude-default-header";
    argv[n++] = "-D__OPENCL_VERSION__=120";
    argv[n++] = "-target";
    argv[n++] = target;
    argv[n++] = opt;
    for (char *tok = strtok(opts, " "); tok && n < 24; tok = strtok(NULL, " ")) argv[n++] = tok;
    argv[n++] = "-c";
    argv[n++] = "-emit-llvm";
    argv[n++] = "-o";
    argv[n++] = bc;
    argv[n++] = "-x";
    argv[n++] = "cl";
    argv[n++] = src;
    argv[n] = NULL;
    spawn_result r;
    int code = spawn_run(&r, argv, 600);
    if (code != 0) {
        fprintf(stderr, "FAIL clang %s %s%s (exit %d): %.2000s\n", target, opt, kernels_float ? " float" : "", code,
                r.err);
        spawn_free(&r);
        return 0;
    }
    spawn_free(&r);
    const char *nm_argv[] = {g_nm, bc, NULL};
    code = spawn_run(&r, nm_argv, 120);
    if (code != 0) {
        fprintf(stderr, "FAIL llvm-nm %s: %.2000s\n", bc, r.err);
        spawn_free(&r);
        return 0;
    }
    /* lines "         U name", "-------- T name" (bitcode: no addresses) */
    bad[0] = 0;
    *defined = 0;
    for (char *line = strtok(r.out, "\n"); line; line = strtok(NULL, "\n")) {
        char w[3][512], name[512], type;
        int words = sscanf(line, "%511s %511s %511s", w[0], w[1], w[2]);
        if (words == 3) type = w[1][0], memcpy(name, w[2], sizeof name);
        else if (words == 2) type = w[0][0], memcpy(name, w[1], sizeof name);
        else continue;
        if (!strncmp(name, "clvox_", 6) && type != 'U') (*defined)++;
        if (type != 'U' || !strncmp(name, "_Z", 2) || !strncmp(name, "llvm.", 5)) continue;
        size_t len = strlen(bad);
        snprintf(bad + len, bad_size - len, " %s", name);
    }
    spawn_free(&r);
    return 1;
}

int main(void)
{
    if (!find_tool("clang", "clang-14", g_clang, sizeof g_clang) ||
        !find_tool("llvm-nm", "llvm-nm-14", g_nm, sizeof g_nm)) {
        fprintf(stderr, "FAIL: clang and llvm-nm are needed (Debian: clang llvm; run scripts/setup.sh)\n");
        test_failed++;
        return test_report();
    }
    char src[4096];
    snprintf(src, sizeof src, "%s/kernel_program.cl", test_tmpdir());
    CHECK(write_program(src));
    static const char *const targets[] = {"spir64", "nvptx64", "amdgcn"};
    static const char *const opts[] = {"-O0", "-O2"};
    for (int t = 0; t < 3; t++) {
        int defined_fp64 = 0, defined_float = 0;
        for (int o = 0; o < 2; o++) {
            for (int fl = 0; fl < 2; fl++) {
                char bad[8192];
                int defined = 0;
                int ok = compile(src, targets[t], opts[o], fl, bad, sizeof bad, &defined);
                CHECK(ok);
                if (!ok) continue;
                printf("%s %s %s: %d clvox_ symbols defined, undefined:%s\n", targets[t], opts[o],
                       fl ? "float" : "double", defined, bad[0] ? bad : " none");
                CHECK_MSG(bad[0] == 0, "%s %s %s: functions without a body:%s", targets[t], opts[o],
                          fl ? "float" : "double", bad);
                if (o == 0) *(fl ? &defined_float : &defined_fp64) = defined;
            }
        }
        /* the double build compiled the double-only stages (surface, tetra)
         * too: cl_khr_fp64 was on */
        CHECK_MSG(defined_float >= 10 && defined_fp64 > defined_float, "%s: %d symbols with double, %d with float",
                  targets[t], defined_fp64, defined_float);
    }
    return test_report();
}
