/* SPDX-License-Identifier: Apache-2.0 */
/* What a device must support (src/core/device_checks.c): the build options
 * follow CL_DEVICE_SINGLE_FP_CONFIG, and a device without correctly rounded
 * float division still gives the same voxels with double kernels; the
 * contraction self-test passes on this device with the program as built,
 * and refuses the same device when the program is built with contraction
 * on (FP_CONTRACT ON and -cl-mad-enable, so that PoCL emits FMAs: this
 * needs a CPU with FMA, else that part is skipped with the reason). */
#include "core/internal.h"
#include "spawn.h"
#include "test.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* "fma" among the flags of /proc/cpuinfo. */
static int cpu_has_fma(void)
{
    FILE *f = fopen("/proc/cpuinfo", "r");
    char line[8192];
    int yes = 0;
    while (f && !yes && fgets(line, sizeof line, f))
        if (!strncmp(line, "flags", 5) && strstr(line, " fma ")) yes = 1;
    if (f) fclose(f);
    return yes;
}

static void test_options(void)
{
    CHECK(!strcmp(clvox__build_options(0, 1), "-cl-fp32-correctly-rounded-divide-sqrt"));
    CHECK(!strcmp(clvox__build_options(1, 1), "-cl-fp32-correctly-rounded-divide-sqrt -DCLVOX_NO_FP64"));
    CHECK(!strcmp(clvox__build_options(0, 0), ""));
    CHECK(!strcmp(clvox__build_options(1, 0), "-DCLVOX_NO_FP64"));
}

/* types + prelude (the probe's sources) with the pragma turned ON, built
 * for ctx's device with -cl-mad-enable: a program without the guarantee. */
static cl_program fused_program(clvox_context *ctx)
{
    const char *prelude = NULL, *types = NULL;
    for (unsigned i = 0; i < clvox__kernel_source_count; i++) {
        if (!strcmp(clvox__kernel_names[i], "prelude.cl")) prelude = clvox__kernel_sources[i];
        if (!strcmp(clvox__kernel_names[i], "clvox_types.h")) types = clvox__kernel_sources[i];
    }
    CHECK(prelude && types);
    if (!prelude || !types) return NULL;
    const char *off = strstr(prelude, "#pragma OPENCL FP_CONTRACT OFF");
    CHECK(off != NULL);
    if (!off) return NULL;
    size_t n = strlen(prelude);
    char *src = malloc(n + 1);
    if (!src) return NULL;
    memcpy(src, prelude, n + 1);
    memcpy(src + (off - prelude), "#pragma OPENCL FP_CONTRACT ON ", 30); /* same length as "... OFF" */
    const char *srcs[2] = {types, src};
    cl_int err;
    cl_program p = clCreateProgramWithSource(ctx->cl, 2, srcs, NULL, &err);
    free(src);
    CHECK(err == CL_SUCCESS);
    if (err != CL_SUCCESS) return NULL;
    char opts[256];
    snprintf(opts, sizeof opts, "%s -cl-mad-enable", clvox__build_options(ctx->kernels_float, ctx->fp32_rounded));
    err = clBuildProgram(p, 1, &ctx->device_id, opts, NULL, NULL);
    CHECK_MSG(err == CL_SUCCESS, "building the fused probe: %s", clvox__cl_error_name(err));
    if (err != CL_SUCCESS) {
        clReleaseProgram(p);
        return NULL;
    }
    return p;
}

static void test_contraction(void)
{
    clvox_context *ctx = test_context(); /* its creation ran the self-test */
    double t0 = clvox__now();
    CHECK_OK(ctx, clvox__device_checks(ctx));
    printf("contraction self-test on '%s' (%s kernels): %.2f ms\n", ctx->device.name,
           ctx->real_size == 8 ? "double" : "float", 1e3 * (clvox__now() - t0));
    cl_device_fp_config fp = 0;
    CHECK(clGetDeviceInfo(ctx->device_id, CL_DEVICE_SINGLE_FP_CONFIG, sizeof fp, &fp, NULL) == CL_SUCCESS);
    CHECK(ctx->fp32_rounded == ((fp & CL_FP_CORRECTLY_ROUNDED_DIVIDE_SQRT) != 0));
    CHECK(clvox__kernel_rules(ctx) == (ctx->real_size == 8 ? 8 : ctx->fp32_rounded ? 4 : 3));
    if (!cpu_has_fma() || strcmp(ctx->device.type, "cpu") != 0) {
        printf("skipped: the fused build (the device is not a CPU with FMA, so it may not fuse)\n");
    } else {
        cl_program p = fused_program(ctx);
        if (p) {
            clvox_status st = clvox__contraction_check(ctx, p);
            CHECK_MSG(st == CLVOX_ERR_NO_DEVICE, "contraction on: %s", clvox_status_string(st));
            CHECK_MSG(strstr(clvox_context_error(ctx), "fuses a*b-c*d despite FP_CONTRACT OFF") != NULL, "%s",
                      clvox_context_error(ctx));
            printf("with contraction on: %s\n", clvox_context_error(ctx));
            clReleaseProgram(p);
        }
    }
    clvox_context_destroy(ctx);
}

/* A context as for a device without correctly rounded float divide/sqrt
 * (the test hook): no such option, the self-test still passes, and the
 * kernels' rules are those of double kernels: equal. */
static void test_unrounded(void)
{
    clvox__test_hooks h = *clvox__hooks();
    clvox__test_hooks saved = h;
    h.fp32_unrounded = 1;
    clvox__set_test_hooks(&h);
    clvox_context *ctx = test_context();
    CHECK(ctx->fp32_rounded == 0);
    CHECK(clvox__kernel_rules(ctx) == (ctx->real_size == 8 ? 8 : 3));
    clvox_context_destroy(ctx);
    clvox__set_test_hooks(&saved);
}

/* The same voxels from the CLI with and without the hook (double kernels;
 * PoCL's division is correctly rounded either way, so this checks that the
 * build without the option works end to end). */
static void test_unrounded_cli(void)
{
    const char *bin = getenv("CLVOX_BIN");
    if (!bin || !*bin) bin = "build/release/clvox";
    char a[4096], b[4096];
    snprintf(a, sizeof a, "%s/device_checks_a.exr", test_tmpdir());
    snprintf(b, sizeof b, "%s/device_checks_b.exr", test_tmpdir());
    const char *argv_a[] = {bin, "tests/data/default.obj", "-r", "40", "-q", "-o", a, NULL};
    const char *argv_b[] = {bin, "tests/data/default.obj", "-r", "40", "-q", "-o", b, NULL};
    spawn_result r;
    unsetenv("CLVOX_TEST_FP32_UNROUNDED");
    CHECK_MSG(spawn_run(&r, argv_a, 120) == 0, "%s", r.err);
    spawn_free(&r);
    setenv("CLVOX_TEST_FP32_UNROUNDED", "1", 1);
    CHECK_MSG(spawn_run(&r, argv_b, 120) == 0, "%s", r.err);
    spawn_free(&r);
    unsetenv("CLVOX_TEST_FP32_UNROUNDED");
    FILE *fa = fopen(a, "rb"), *fb = fopen(b, "rb");
    int same = fa && fb;
    while (same) {
        int ca = fgetc(fa), cb = fgetc(fb);
        if (ca != cb) same = 0;
        if (ca == EOF || cb == EOF) break;
    }
    if (fa) fclose(fa);
    if (fb) fclose(fb);
    CHECK_MSG(same, "%s and %s differ", a, b);
}

int main(void)
{
    test_options();
    test_contraction();
    test_unrounded();
    test_unrounded_cli();
    return test_report();
}
