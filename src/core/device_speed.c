/* SPDX-License-Identifier: Apache-2.0 */
/* Which build of the kernels a device with fp64 gets: by speed, not only
 * by capability (issue 37).
 *
 * Every mode gives the same voxels in either build but one, the winding
 * test on voxels that are not cubes (docs/design.md "Devices without double
 * precision"). The float build does more work per point (bounds, exact
 * signs, the host's unsure points): on PoCL it takes 1.0-1.6x the double
 * build's time, 2x on a palette of an open mesh. A GPU whose double
 * arithmetic runs at 1/16 to 1/64 of its float (most consumer cards) gains
 * far more than that from it.
 *
 * The rule (clvox__choose_build): a device without fp64, or a context
 * asked for float kernels, gets the float build, as before. A device with
 * fp64 gets the float build when its double arithmetic measures
 * CLVOX__FP64_SLOW (8) or more times slower than its float, else double.
 * CPU devices are not measured and keep double: their double runs at half
 * their float's rate at worst (the vector width), where the float build
 * does not pay. Nor is Oclgrind (a simulator: 1.6 s of it, to time
 * nothing). A run whose mode does not decide the same in float gets the
 * double build on such a device (clvox__select_build, built then).
 *
 * The measurement: chains of dependent multiply-adds, four a work-item, on
 * enough work-items to fill the device, in float and in double, each timed
 * by its profiling events (the fastest of two runs, after a warm-up, the
 * loop lengthened until the float run takes 2 ms): 0.08 s on PoCL with its
 * build, once per device and driver: the ratio is kept in the kernel cache
 * (program_cache.c) like the program's binary. CLVOX_FP64_SLOWDOWN=R sets
 * the ratio of every device instead (tests; a user who knows better), and
 * CLVOX_FP64_MEASURE=1 measures CPU devices too. A measurement that fails
 * keeps double: the rule is only about speed. */
#include "environment.h"
#include "internal.h"

#include <stdio.h>
#include <string.h>

static const char speed_source[] =
    "#pragma OPENCL EXTENSION cl_khr_fp64 : enable\n"
    "kernel void clvox_speed_float(global float *out, float a, float b, int n)\n"
    "{\n"
    "    float x = (float)get_global_id(0) * 1e-9f, y = x + 0.5f, z = x + 0.25f, w = x + 0.125f;\n"
    "    for (int i = 0; i < n; i++) {\n"
    "        x = x * a + b; y = y * a + b; z = z * a + b; w = w * a + b;\n"
    "    }\n"
    "    out[get_global_id(0)] = x + y + z + w;\n"
    "}\n"
    "kernel void clvox_speed_double(global double *out, double a, double b, int n)\n"
    "{\n"
    "    double x = (double)get_global_id(0) * 1e-9, y = x + 0.5, z = x + 0.25, w = x + 0.125;\n"
    "    for (int i = 0; i < n; i++) {\n"
    "        x = x * a + b; y = y * a + b; z = z * a + b; w = w * a + b;\n"
    "    }\n"
    "    out[get_global_id(0)] = x + y + z + w;\n"
    "}\n";

/* Seconds one launch of k took on the device (its profiling events), or a
 * negative number on an OpenCL error. */
static double timed(clvox_context *ctx, cl_kernel k, size_t global)
{
    cl_event ev = NULL;
    cl_ulong t0 = 0, t1 = 0;
    cl_int err = clEnqueueNDRangeKernel(ctx->queue, k, 1, NULL, &global, NULL, 0, NULL, &ev);
    if (err == CL_SUCCESS) err = clWaitForEvents(1, &ev);
    if (err == CL_SUCCESS) err = clGetEventProfilingInfo(ev, CL_PROFILING_COMMAND_START, sizeof t0, &t0, NULL);
    if (err == CL_SUCCESS) err = clGetEventProfilingInfo(ev, CL_PROFILING_COMMAND_END, sizeof t1, &t1, NULL);
    if (ev) clReleaseEvent(ev);
    return err == CL_SUCCESS && t1 >= t0 ? (double)(t1 - t0) * 1e-9 : -1.0;
}

/* The fastest of a warm-up and two timed launches. */
static double best_of(clvox_context *ctx, cl_kernel k, size_t global)
{
    double best = -1.0;
    for (int i = 0; i < 3; i++) {
        const double t = timed(ctx, k, global);
        if (t < 0) return -1.0;
        if (i > 0 && (best < 0 || t < best)) best = t;
    }
    return best;
}

static int set_args(cl_kernel k, cl_mem out, int dbl, int n)
{
    const float af = 0.999f, bf = 1e-3f;
    const double ad = 0.999, bd = 1e-3;
    cl_int err = clSetKernelArg(k, 0, sizeof out, &out);
    if (err == CL_SUCCESS) err = dbl ? clSetKernelArg(k, 1, sizeof ad, &ad) : clSetKernelArg(k, 1, sizeof af, &af);
    if (err == CL_SUCCESS) err = dbl ? clSetKernelArg(k, 2, sizeof bd, &bd) : clSetKernelArg(k, 2, sizeof bf, &bf);
    if (err == CL_SUCCESS) err = clSetKernelArg(k, 3, sizeof n, &n);
    return err == CL_SUCCESS;
}

/* Double's time over float's for the same chains, or 0 where it could not
 * be measured. */
static float measure(clvox_context *ctx)
{
    cl_int err;
    const char *src = speed_source;
    cl_program p = clCreateProgramWithSource(ctx->cl, 1, &src, NULL, &err);
    if (err != CL_SUCCESS) return 0.0f;
    cl_kernel kf = NULL, kd = NULL;
    cl_mem out = NULL;
    float ratio = 0.0f;
    const size_t global = (size_t)(ctx->device.compute_units ? ctx->device.compute_units : 1) * 4096;
    if (clBuildProgram(p, 1, &ctx->device_id, "", NULL, NULL) != CL_SUCCESS) goto done;
    kf = clCreateKernel(p, "clvox_speed_float", &err);
    if (err == CL_SUCCESS) kd = clCreateKernel(p, "clvox_speed_double", &err);
    if (err == CL_SUCCESS) out = clCreateBuffer(ctx->cl, CL_MEM_WRITE_ONLY, global * sizeof(double), NULL, &err);
    if (err != CL_SUCCESS) goto done;
    int n = 64;
    double tf = -1.0;
    for (;;) { /* long enough that the launch's own cost does not count */
        if (!set_args(kf, out, 0, n) || (tf = best_of(ctx, kf, global)) < 0) goto done;
        if (tf >= 2e-3 || n >= (1 << 20)) break;
        n *= 4;
    }
    double td;
    if (!set_args(kd, out, 1, n) || (td = best_of(ctx, kd, global)) < 0) goto done;
    if (tf > 0) ratio = (float)(td / tf);
    if (!(ratio >= 0.01f && ratio <= 1e4f)) ratio = 0.0f;
done:
    if (out) clReleaseMemObject(out);
    if (kf) clReleaseKernel(kf);
    if (kd) clReleaseKernel(kd);
    clReleaseProgram(p);
    return ratio;
}

float clvox__fp64_slowdown(clvox_context *ctx)
{
    const clvox__test_hooks *hk = clvox__hooks();
    if (!ctx->device.fp64) return 0.0f;
    if (hk->fp64_slowdown > 0) return (float)hk->fp64_slowdown;
    if (!strcmp(ctx->device.type, "cpu") && !hk->fp64_measure) return 0.0f;
    if (strstr(ctx->device.platform, "Oclgrind") && !hk->fp64_measure) return 0.0f; /* a simulator's times say nothing */
    float r = 0.0f;
    if (clvox__cache_get(ctx, "fp64 slowdown 1", &r, sizeof r) && r >= 0.01f && r <= 1e4f) return r;
    r = measure(ctx);
    if (r > 0) clvox__cache_put(ctx, "fp64 slowdown 1", &r, sizeof r);
    return r;
}
