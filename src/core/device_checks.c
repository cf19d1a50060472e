/* SPDX-License-Identifier: Apache-2.0 */
/* What a device must do for the kernels' results to be the ones the CPU
 * reference and every other device get (docs/library.md "Device
 * requirements"), checked when a context is created:
 *
 * - OpenCL C 1.2 (the helpers are `static inline`, the host uses
 *   clEnqueueFillBuffer): an older device is refused before the build.
 * - -cl-fp32-correctly-rounded-divide-sqrt only where
 *   CL_DEVICE_SINGLE_FP_CONFIG offers it (a build with it fails elsewhere).
 *   Only float kernels divide and take square roots in float where it
 *   matters (the crossing's u = ua + num / den, the sampler's strata), so a
 *   device without it computes the same voxels as the others when its
 *   kernels are in double, and possibly not when they are in float:
 *   clvox__kernel_rules tells such devices apart.
 * - No contraction of a*b - c*d into an FMA under FP_CONTRACT OFF: the
 *   exact predicates' E(b,a) = -E(a,b), hence the shared-edge rule, depend
 *   on it. A small kernel of the program (clvox_contraction_probe,
 *   kernels/prelude.cl) computes the predicates' products on inputs where a
 *   fused result differs from the unfused one, and a device whose results
 *   differ from the host's is refused. */
#include "internal.h"

#include <stdio.h>
#include <string.h>

const char *clvox__build_options(int kernels_float, int fp32_rounded)
{
    static const char *const opts[2][2] = {
        {"", "-cl-fp32-correctly-rounded-divide-sqrt"},
        {"-DCLVOX_NO_FP64", "-cl-fp32-correctly-rounded-divide-sqrt -DCLVOX_NO_FP64"},
    };
    return opts[kernels_float != 0][fp32_rounded != 0];
}

clvox_status clvox__program_options(clvox_context *ctx, const char **opts)
{
    char cver[128] = "";
    cl_int err = clGetDeviceInfo(ctx->device_id, CL_DEVICE_OPENCL_C_VERSION, sizeof cver - 1, cver, NULL);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "clGetDeviceInfo(CL_DEVICE_OPENCL_C_VERSION)");
    int major = 0, minor = 0;
    if (sscanf(cver, "OpenCL C %d.%d", &major, &minor) != 2 || major < 1 || (major == 1 && minor < 2))
        return clvox__fail(ctx, CLVOX_ERR_NO_DEVICE, "device '%s' compiles '%s': clvox's kernels need OpenCL C 1.2",
                           ctx->device.name, cver);
    cl_device_fp_config fp = 0;
    err = clGetDeviceInfo(ctx->device_id, CL_DEVICE_SINGLE_FP_CONFIG, sizeof fp, &fp, NULL);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "clGetDeviceInfo(CL_DEVICE_SINGLE_FP_CONFIG)");
    ctx->fp32_rounded = (fp & CL_FP_CORRECTLY_ROUNDED_DIVIDE_SQRT) && !clvox__hooks()->fp32_unrounded;
    *opts = clvox__build_options(ctx->kernels_float, ctx->fp32_rounded);
    return CLVOX_OK;
}

int clvox__kernel_rules(const clvox_context *ctx)
{
    if (ctx->real_size == 8) return 8;
    return ctx->fp32_rounded ? 4 : 3;
}

/* Products a*b and c*d whose rounding errors do not cancel: the fused
 * a*b - c*d (either product kept exact) differs from the unfused one. The
 * first rows are E(a,a)-like (unfused: exactly 0, fused: the rounding
 * error of a*b), the others E(a,b) and E(b,a), which must be opposite. */
#define PROBES 6
static void probe_inputs(double d[PROBES * 4], float f[PROBES * 4])
{
    const double x = 1.0 + 0x1p-30, y = 1.0 - 0x1p-29; /* x*x, x*y inexact in double */
    const float xf = 1.0f + 0x1p-13f, yf = 1.0f - 0x1p-12f;
    const double dv[PROBES * 4] = {x, x, x, x, x, y, y, x, 0.1, 0.7, 0.3, 0.9, 0.3, 0.9, 0.1, 0.7,
                                   x, 3.0 * y, y, 3.0 * x, y, 3.0 * x, x, 3.0 * y};
    const float fv[PROBES * 4] = {xf, xf, xf, xf, xf, yf, yf, xf, 0.1f, 0.7f, 0.3f, 0.9f, 0.3f, 0.9f, 0.1f, 0.7f,
                                  xf, 3.0f * yf, yf, 3.0f * xf, yf, 3.0f * xf, xf, 3.0f * yf};
    memcpy(d, dv, sizeof dv);
    memcpy(f, fv, sizeof fv);
}

/* The host's a*b - c*d, each product rounded (volatile: whatever the
 * compiler's contraction setting). */
static double unfused_d(const double *v)
{
    volatile double p = v[0] * v[1], q = v[2] * v[3];
    return p - q;
}
static float unfused_f(const float *v)
{
    volatile float p = v[0] * v[1], q = v[2] * v[3];
    return p - q;
}

clvox_status clvox__contraction_check(clvox_context *ctx, cl_program program)
{
    double din[PROBES * 4], dout[PROBES];
    float fin[PROBES * 4], fout[PROBES];
    probe_inputs(din, fin);
    const size_t rs = ctx->real_size == 8 ? 8 : 4;
    unsigned char rin[PROBES * 4 * 8], rout[PROBES * 8];
    for (int i = 0; i < PROBES * 4; i++) {
        if (rs == 8) memcpy(rin + 8 * i, &din[i], 8);
        else memcpy(rin + 4 * i, &fin[i], 4);
    }
    cl_int err;
    cl_kernel k = clCreateKernel(program, "clvox_contraction_probe", &err);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "clCreateKernel(clvox_contraction_probe)");
    cl_mem m[4] = {NULL, NULL, NULL, NULL};
    const size_t bytes[4] = {PROBES * 4 * rs, PROBES * rs, sizeof fin, sizeof fout};
    void *host[4] = {rin, NULL, fin, NULL};
    err = CL_SUCCESS;
    for (int i = 0; i < 4 && err == CL_SUCCESS; i++) {
        m[i] = clCreateBuffer(ctx->cl, host[i] ? CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR : CL_MEM_WRITE_ONLY,
                              bytes[i], host[i], &err);
        if (err == CL_SUCCESS) err = clSetKernelArg(k, (cl_uint)i, sizeof m[i], &m[i]);
    }
    size_t n = PROBES;
    if (err == CL_SUCCESS) err = clEnqueueNDRangeKernel(ctx->queue, k, 1, NULL, &n, NULL, 0, NULL, NULL);
    if (err == CL_SUCCESS) err = clEnqueueReadBuffer(ctx->queue, m[1], CL_TRUE, 0, bytes[1], rout, 0, NULL, NULL);
    if (err == CL_SUCCESS) err = clEnqueueReadBuffer(ctx->queue, m[3], CL_TRUE, 0, bytes[3], fout, 0, NULL, NULL);
    for (int i = 0; i < 4; i++)
        if (m[i]) clReleaseMemObject(m[i]);
    clReleaseKernel(k);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "running the contraction self-test");
    int fused = 0;
    for (int i = 0; i < PROBES; i++) {
        if (rs == 8) {
            double want = unfused_d(din + 4 * i);
            memcpy(&dout[i], rout + 8 * i, 8);
            fused |= memcmp(&dout[i], &want, 8) != 0;
        } else {
            float want = unfused_f(fin + 4 * i), got;
            memcpy(&got, rout + 4 * i, 4);
            fused |= memcmp(&got, &want, 4) != 0;
        }
        float wantf = unfused_f(fin + 4 * i);
        fused |= memcmp(&fout[i], &wantf, 4) != 0;
    }
    if (fused)
        return clvox__fail(ctx, CLVOX_ERR_NO_DEVICE,
                           "device '%s' fuses a*b-c*d despite FP_CONTRACT OFF: its exact predicates would be wrong",
                           ctx->device.name);
    return CLVOX_OK;
}

clvox_status clvox__device_checks(clvox_context *ctx)
{
    return clvox__contraction_check(ctx, ctx->program);
}
