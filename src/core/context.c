/* SPDX-License-Identifier: Apache-2.0 */
/* Context: status strings, error messages, OpenCL device selection and the
 * kernel program (built once per context from the embedded sources). */
#include "internal.h"
#include "launch.h"

#include <ctype.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

static const char *const status_strings[CLVOX_STATUS_COUNT] = {
    [CLVOX_OK] = "success",
    [CLVOX_ERR_INVALID_ARGUMENT] = "invalid argument",
    [CLVOX_ERR_OUT_OF_MEMORY] = "out of memory",
    [CLVOX_ERR_IO] = "input/output error",
    [CLVOX_ERR_MESH_FORMAT] = "unreadable mesh file",
    [CLVOX_ERR_MESH_INVALID] = "invalid mesh",
    [CLVOX_ERR_MESH_EMPTY] = "empty mesh",
    [CLVOX_ERR_GRID] = "invalid grid",
    [CLVOX_ERR_NO_DEVICE] = "no OpenCL device",
    [CLVOX_ERR_OPENCL] = "OpenCL error",
    [CLVOX_ERR_KERNEL_BUILD] = "kernel build failed",
    [CLVOX_ERR_EXR] = "OpenEXR error",
    [CLVOX_ERR_CANCELLED] = "cancelled",
    [CLVOX_ERR_INTERNAL] = "internal error",
    [CLVOX_ERR_PALETTE_FORMAT] = "malformed palette file",
};

const char *clvox_status_string(clvox_status status)
{
    if ((unsigned)status >= CLVOX_STATUS_COUNT) return "unknown status";
    return status_strings[status];
}

const char *clvox_version(void) { return CLVOX_VERSION_STRING; }

static const char *const stage_names[CLVOX_STAGE_COUNT] = {
    "load", "partition", "cast", "classify", "write", "total",
};

const char *clvox_stage_name(clvox_stage stage)
{
    if ((unsigned)stage >= CLVOX_STAGE_COUNT) return "unknown";
    return stage_names[stage];
}

clvox_status clvox__fail(clvox_context *ctx, clvox_status status, const char *fmt, ...)
{
    if (ctx) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(ctx->error, sizeof ctx->error, fmt, ap);
        va_end(ap);
    }
    return status;
}

const char *clvox__cl_error_name(cl_int err)
{
    switch (err) {
#define E(x) case x: return #x;
    E(CL_SUCCESS) E(CL_DEVICE_NOT_FOUND) E(CL_DEVICE_NOT_AVAILABLE) E(CL_COMPILER_NOT_AVAILABLE)
    E(CL_MEM_OBJECT_ALLOCATION_FAILURE) E(CL_OUT_OF_RESOURCES) E(CL_OUT_OF_HOST_MEMORY)
    E(CL_PROFILING_INFO_NOT_AVAILABLE) E(CL_MEM_COPY_OVERLAP) E(CL_IMAGE_FORMAT_MISMATCH)
    E(CL_IMAGE_FORMAT_NOT_SUPPORTED) E(CL_BUILD_PROGRAM_FAILURE) E(CL_MAP_FAILURE)
    E(CL_MISALIGNED_SUB_BUFFER_OFFSET) E(CL_EXEC_STATUS_ERROR_FOR_EVENTS_IN_WAIT_LIST)
    E(CL_COMPILE_PROGRAM_FAILURE) E(CL_LINKER_NOT_AVAILABLE) E(CL_LINK_PROGRAM_FAILURE)
    E(CL_INVALID_VALUE) E(CL_INVALID_DEVICE_TYPE) E(CL_INVALID_PLATFORM) E(CL_INVALID_DEVICE)
    E(CL_INVALID_CONTEXT) E(CL_INVALID_QUEUE_PROPERTIES) E(CL_INVALID_COMMAND_QUEUE)
    E(CL_INVALID_HOST_PTR) E(CL_INVALID_MEM_OBJECT) E(CL_INVALID_IMAGE_FORMAT_DESCRIPTOR)
    E(CL_INVALID_IMAGE_SIZE) E(CL_INVALID_SAMPLER) E(CL_INVALID_BINARY) E(CL_INVALID_BUILD_OPTIONS)
    E(CL_INVALID_PROGRAM) E(CL_INVALID_PROGRAM_EXECUTABLE) E(CL_INVALID_KERNEL_NAME)
    E(CL_INVALID_KERNEL_DEFINITION) E(CL_INVALID_KERNEL) E(CL_INVALID_ARG_INDEX)
    E(CL_INVALID_ARG_VALUE) E(CL_INVALID_ARG_SIZE) E(CL_INVALID_KERNEL_ARGS)
    E(CL_INVALID_WORK_DIMENSION) E(CL_INVALID_WORK_GROUP_SIZE) E(CL_INVALID_WORK_ITEM_SIZE)
    E(CL_INVALID_GLOBAL_OFFSET) E(CL_INVALID_EVENT_WAIT_LIST) E(CL_INVALID_EVENT)
    E(CL_INVALID_OPERATION) E(CL_INVALID_GL_OBJECT) E(CL_INVALID_BUFFER_SIZE)
    E(CL_INVALID_MIP_LEVEL) E(CL_INVALID_GLOBAL_WORK_SIZE) E(CL_INVALID_PROPERTY)
#undef E
    case -1001: return "CL_PLATFORM_NOT_FOUND_KHR";
    default: return "unknown OpenCL error";
    }
}

clvox_status clvox__cl_fail(clvox_context *ctx, cl_int err, const char *what)
{
    clvox_status st = CLVOX_ERR_OPENCL;
    if (err == CL_OUT_OF_HOST_MEMORY || err == CL_MEM_OBJECT_ALLOCATION_FAILURE) st = CLVOX_ERR_OUT_OF_MEMORY;
    if ((err == CL_OUT_OF_RESOURCES || err == CL_MEM_OBJECT_ALLOCATION_FAILURE) && ctx && !ctx->host_only)
        return clvox__device_cl_oom(ctx, err, what); /* device_memory.c */
    return clvox__fail(ctx, st, "%s: %s (%d)", what, clvox__cl_error_name(err), (int)err);
}

void clvox__format_size(uint64_t bytes, char *buf, size_t size)
{
    static const char *const units[] = {"bytes", "KB", "MB", "GB", "TB", "PB", "EB"};
    double v = (double)bytes;
    int u = 0;
    while (v >= 999.5 && u < 6) v /= 1000.0, u++; /* 999.6 KB is "1 MB", not "1e+03 KB" */
    if (u == 0) snprintf(buf, size, "%llu bytes", (unsigned long long)bytes);
    else snprintf(buf, size, "%.3g %s", v, units[u]);
}

double clvox__now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

double clvox__event_seconds(cl_event ev)
{
    cl_ulong t0 = 0, t1 = 0;
    if (!ev) return 0.0;
    if (clGetEventProfilingInfo(ev, CL_PROFILING_COMMAND_START, sizeof t0, &t0, NULL) != CL_SUCCESS ||
        clGetEventProfilingInfo(ev, CL_PROFILING_COMMAND_END, sizeof t1, &t1, NULL) != CL_SUCCESS ||
        t1 < t0)
        return 0.0;
    return 1e-9 * (double)(t1 - t0);
}

/* ---- device enumeration ---- */

typedef struct device_entry {
    cl_platform_id platform;
    cl_device_id device;
    clvox_device_info info;
} device_entry;

static void copy_trimmed(char *dst, size_t size, const char *src)
{
    while (*src && isspace((unsigned char)*src)) src++;
    snprintf(dst, size, "%s", src);
    size_t n = strlen(dst);
    while (n && isspace((unsigned char)dst[n - 1])) dst[--n] = 0;
}

/* Enumerates every device of every platform. *out is malloc'ed. */
static clvox_status enumerate(device_entry **out, size_t *count, char *why, size_t why_size)
{
    *out = NULL;
    *count = 0;
    cl_uint np = 0;
    cl_int err = clGetPlatformIDs(0, NULL, &np);
    if (err != CL_SUCCESS || np == 0) {
        snprintf(why, why_size, "no OpenCL platform found (%s); install an ICD such as pocl-opencl-icd",
                 err == CL_SUCCESS ? "0 platforms" : clvox__cl_error_name(err));
        return CLVOX_ERR_NO_DEVICE;
    }
    cl_platform_id *plats = calloc(np, sizeof *plats);
    if (!plats) return CLVOX_ERR_OUT_OF_MEMORY;
    if ((err = clGetPlatformIDs(np, plats, NULL)) != CL_SUCCESS) {
        free(plats);
        snprintf(why, why_size, "clGetPlatformIDs: %s", clvox__cl_error_name(err));
        return CLVOX_ERR_NO_DEVICE;
    }
    device_entry *list = NULL;
    size_t n = 0;
    for (cl_uint p = 0; p < np; p++) {
        cl_uint nd = 0;
        if (clGetDeviceIDs(plats[p], CL_DEVICE_TYPE_ALL, 0, NULL, &nd) != CL_SUCCESS || nd == 0) continue;
        cl_device_id *devs = calloc(nd, sizeof *devs);
        device_entry *grown = realloc(list, (n + nd) * sizeof *list);
        if (!devs || !grown) {
            free(devs);
            free(grown ? grown : list);
            free(plats);
            return CLVOX_ERR_OUT_OF_MEMORY;
        }
        list = grown;
        if (clGetDeviceIDs(plats[p], CL_DEVICE_TYPE_ALL, nd, devs, NULL) != CL_SUCCESS) {
            free(devs);
            continue;
        }
        char pname[128] = "";
        char buf[256];
        if (clGetPlatformInfo(plats[p], CL_PLATFORM_NAME, sizeof buf, buf, NULL) == CL_SUCCESS)
            copy_trimmed(pname, sizeof pname, buf);
        for (cl_uint d = 0; d < nd; d++) {
            device_entry *e = &list[n];
            memset(e, 0, sizeof *e);
            e->platform = plats[p];
            e->device = devs[d];
            e->info.size = sizeof e->info; /* clvox_context_device hands this one out */
            e->info.index = (uint32_t)n;
            snprintf(e->info.platform, sizeof e->info.platform, "%s", pname);
            if (clGetDeviceInfo(devs[d], CL_DEVICE_NAME, sizeof buf, buf, NULL) == CL_SUCCESS)
                copy_trimmed(e->info.name, sizeof e->info.name, buf);
            if (clGetDeviceInfo(devs[d], CL_DEVICE_VERSION, sizeof buf, buf, NULL) == CL_SUCCESS)
                copy_trimmed(e->info.version, sizeof e->info.version, buf);
            cl_device_type type = 0;
            clGetDeviceInfo(devs[d], CL_DEVICE_TYPE, sizeof type, &type, NULL);
            snprintf(e->info.type, sizeof e->info.type, "%s",
                     (type & CL_DEVICE_TYPE_GPU) ? "gpu"
                     : (type & CL_DEVICE_TYPE_CPU) ? "cpu"
                     : (type & CL_DEVICE_TYPE_ACCELERATOR) ? "accelerator" : "other");
            cl_uint cu = 0;
            cl_ulong mem = 0, alloc = 0;
            clGetDeviceInfo(devs[d], CL_DEVICE_MAX_COMPUTE_UNITS, sizeof cu, &cu, NULL);
            clGetDeviceInfo(devs[d], CL_DEVICE_GLOBAL_MEM_SIZE, sizeof mem, &mem, NULL);
            clGetDeviceInfo(devs[d], CL_DEVICE_MAX_MEM_ALLOC_SIZE, sizeof alloc, &alloc, NULL);
            e->info.compute_units = cu;
            e->info.global_mem_bytes = mem;
            e->info.max_alloc_bytes = alloc;
            cl_device_fp_config fp64 = 0;
            if (clGetDeviceInfo(devs[d], CL_DEVICE_DOUBLE_FP_CONFIG, sizeof fp64, &fp64, NULL) != CL_SUCCESS) fp64 = 0;
            e->info.fp64 = fp64 != 0;
            n++;
        }
        free(devs);
    }
    free(plats);
    if (n == 0) {
        free(list);
        snprintf(why, why_size,
                 "no OpenCL device found (%u platform%s, no device; for PoCL check that POCL_CACHE_DIR "
                 "or ~/.cache/pocl is writable)", np, np == 1 ? "" : "s");
        return CLVOX_ERR_NO_DEVICE;
    }
    *out = list;
    *count = n;
    return CLVOX_OK;
}

clvox_status clvox_list_devices(clvox_device_info *out, size_t capacity, size_t *count)
{
    device_entry *list;
    size_t n;
    char why[256];
    if (!count) return CLVOX_ERR_INVALID_ARGUMENT;
    *count = 0;
    if (!out) capacity = 0;
    /* the caller's struct may be an earlier, smaller one: out[0].size apart */
    clvox_status st = capacity ? clvox__out_begin(NULL, out, sizeof *out, CLVOX__DEVICE_INFO_SIZE_0, "clvox_device_info")
                               : CLVOX_OK;
    if (st != CLVOX_OK) return st;
    size_t stride = capacity ? out[0].size : 0;
    st = enumerate(&list, &n, why, sizeof why);
    if (st != CLVOX_OK) return st;
    for (size_t i = 0; i < n && i < capacity; i++) {
        clvox_device_info *e = (clvox_device_info *)(void *)((char *)out + i * stride);
        e->size = stride;
        clvox__out_end(e, &list[i].info);
    }
    *count = n;
    free(list);
    return CLVOX_OK;
}

static int contains_nocase(const char *hay, const char *needle)
{
    size_t nl = strlen(needle);
    for (; *hay; hay++) {
        size_t i = 0;
        while (i < nl && hay[i] && tolower((unsigned char)hay[i]) == tolower((unsigned char)needle[i])) i++;
        if (i == nl) return 1;
    }
    return nl == 0;
}

/* Picks the device for `sel` (see clvox_context_options.device). */
static clvox_status select_device(clvox_context *ctx, const char *sel, device_entry *list, size_t n,
                                  size_t *pick)
{
    if (!sel || !*sel || !strcmp(sel, "auto")) {
        for (size_t i = 0; i < n; i++)
            if (!strcmp(list[i].info.type, "gpu")) return *pick = i, CLVOX_OK;
        for (size_t i = 0; i < n; i++)
            if (!strcmp(list[i].info.type, "cpu")) return *pick = i, CLVOX_OK;
        return *pick = 0, CLVOX_OK;
    }
    if (!strcmp(sel, "gpu") || !strcmp(sel, "cpu") || !strcmp(sel, "accelerator")) {
        for (size_t i = 0; i < n; i++)
            if (!strcmp(list[i].info.type, sel)) return *pick = i, CLVOX_OK;
        return clvox__fail(ctx, CLVOX_ERR_NO_DEVICE, "no OpenCL device of type '%s' (%zu device%s present)",
                           sel, n, n == 1 ? "" : "s");
    }
    char *end;
    unsigned long idx = strtoul(sel, &end, 10);
    if (*sel >= '0' && *sel <= '9' && *end == 0) {
        if (idx < n) return *pick = idx, CLVOX_OK;
        return clvox__fail(ctx, CLVOX_ERR_NO_DEVICE, "no OpenCL device with index %lu (%zu present)", idx, n);
    }
    for (size_t i = 0; i < n; i++)
        if (contains_nocase(list[i].info.name, sel) || contains_nocase(list[i].info.platform, sel))
            return *pick = i, CLVOX_OK;
    return clvox__fail(ctx, CLVOX_ERR_NO_DEVICE, "no OpenCL device matches '%s' (see clvox --list-devices)", sel);
}

/* PoCL's CPU drivers (3.1) share one cache of loaded work-group functions
 * between every device of the process, found at launch by the kernel's
 * build hash, local size and grid width but released by hash and local
 * size alone: two devices with the same build launching one kernel over
 * different grids at once release each other's entry, and PoCL aborts
 * (assertion `found->ref_count > 0' in pocl_release_dlhandle_cache).
 * Device k > 0 of a set on PoCL builds with an unused -DCLVOX_DEVICE_SLOT=k,
 * so that its build hash, and its cache entries, are its own. The kernels
 * are the same code: the same voxels. */
static int pocl_slot(const clvox_context *ctx)
{
    return strstr(ctx->device.platform, "Portable Computing Language") ? (int)ctx->position : 0;
}

static clvox_status build_program(clvox_context *ctx)
{
    cl_int err;
    /* Correctly rounded division where the device has it (device_checks.c).
     * CLVOX_KERNEL_FLOAT=1 builds the kernels as on a device without fp64
     * (a developer's check of the float path on PoCL). */
    const char *base;
    clvox_status st = clvox__program_options(ctx, &base); /* device_checks.c */
    if (st != CLVOX_OK) return st;
    char opts[160];
    if (pocl_slot(ctx)) snprintf(opts, sizeof opts, "%s -DCLVOX_DEVICE_SLOT=%d", base, pocl_slot(ctx));
    else snprintf(opts, sizeof opts, "%s", base);
    if ((ctx->program = clvox__program_cache_load(ctx, opts)) != NULL) {
        ctx->program_cached = 1;
        return CLVOX_OK;
    }
    ctx->program = clCreateProgramWithSource(ctx->cl, clvox__kernel_source_count,
                                             (const char **)clvox__kernel_sources, NULL, &err);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "clCreateProgramWithSource");
    err = clBuildProgram(ctx->program, 1, &ctx->device_id, opts, NULL, NULL);
    if (err == CL_SUCCESS) {
        clvox__program_cache_store(ctx, ctx->program, opts);
        return CLVOX_OK;
    }
    size_t len = 0;
    char log[6000] = "";
    clGetProgramBuildInfo(ctx->program, ctx->device_id, CL_PROGRAM_BUILD_LOG, sizeof log - 1, log, &len);
    log[sizeof log - 1] = 0;
    for (char *c = log; *c; c++)
        if (*c == '\n') *c = ' '; /* one-line message */
    return clvox__fail(ctx, CLVOX_ERR_KERNEL_BUILD, "clBuildProgram: %s (%d): %s", clvox__cl_error_name(err),
                       (int)err, log);
}

size_t clvox__float_outside(const float *v, size_t n, float *bad)
{
    for (size_t i = 0; i < n; i++) {
        const float a = fabsf(v[i]);
        if (a != 0.0f && !(a >= 0x1p-24f && a <= 0x1p36f)) {
            *bad = v[i];
            return i + 1;
        }
    }
    return 0;
}

clvox_status clvox__float_check(clvox_context *ctx, const char *what, size_t outside, float bad)
{
    if (ctx->real_size != 4 || !outside) return CLVOX_OK;
    return clvox__fail(ctx, CLVOX_ERR_NO_DEVICE,
                       "%s in float (%s): grid coordinate %g is outside the range where float decides exactly "
                       "(0, or 2^-24 to 2^36 voxels); use a device with double precision",
                       what, ctx->kernels_float ? "kernels built without double precision" : "the device has no cl_khr_fp64",
                       (double)bad);
}

/* The kernels compute crossings in double when the device compiler offers
 * cl_khr_fp64; ask the compiled program rather than guess. */
static clvox_status query_real_size(clvox_context *ctx)
{
    cl_kernel k = NULL;
    clvox_status st = clvox__kernel(ctx, "clvox_real_size", &k);
    if (st != CLVOX_OK) return st;
    cl_int err;
    cl_uint size = 0;
    cl_mem m = clCreateBuffer(ctx->cl, CL_MEM_WRITE_ONLY, sizeof size, NULL, &err);
    if (err == CL_SUCCESS) err = clSetKernelArg(k, 0, sizeof m, &m);
    size_t one = 1;
    if (err == CL_SUCCESS) err = clEnqueueNDRangeKernel(ctx->queue, k, 1, NULL, &one, &one, 0, NULL, NULL);
    if (err == CL_SUCCESS) err = clEnqueueReadBuffer(ctx->queue, m, CL_TRUE, 0, sizeof size, &size, 0, NULL, NULL);
    if (m) clReleaseMemObject(m);
    clReleaseKernel(k);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "probing the kernel precision");
    if (size != 4 && size != 8)
        return clvox__fail(ctx, CLVOX_ERR_INTERNAL, "kernel real size %u", (unsigned)size);
    ctx->real_size = size;
    return CLVOX_OK;
}

/* Opens the device of `e` in ctx: context, queue, kernels. */
static clvox_status open_device(clvox_context *ctx, const device_entry *e)
{
    ctx->platform = e->platform;
    ctx->device_id = e->device;
    ctx->device = e->info;
    clvox__device_memory_hooks(&ctx->device); /* device_memory.c */
    if (clvox__hook_fails_device(ctx->position, CLVOX__FAIL_BUILD))
        return clvox__fail(ctx, CLVOX_ERR_KERNEL_BUILD, "clBuildProgram: CLVOX_TEST_FAIL_DEVICE=%u:0 failed it",
                           ctx->position);
    cl_int err;
    cl_context_properties props[] = {CL_CONTEXT_PLATFORM, (cl_context_properties)ctx->platform, 0};
    ctx->cl = clCreateContext(props, 1, &ctx->device_id, NULL, NULL, &err);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "clCreateContext");
    ctx->queue = clCreateCommandQueue(ctx->cl, ctx->device_id, CL_QUEUE_PROFILING_ENABLE, &err);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, err, "clCreateCommandQueue");
    /* The build (device_speed.c): float where asked or where the device
     * has no fp64 (the program then has no choice), or where its double is
     * slow; else double. */
    const clvox__test_hooks *hk = clvox__hooks();
    const int asked = ctx->want_float || hk->kernels_float ||
                      (hk->kernels_float_device > 0 && (uint32_t)hk->kernels_float_device == ctx->position + 1);
    ctx->device.fp64_slowdown = clvox__fp64_slowdown(ctx);
    ctx->float_for_speed = !asked && ctx->device.fp64 && ctx->device.fp64_slowdown >= CLVOX__FP64_SLOW;
    ctx->kernels_float = asked || ctx->float_for_speed;
    clvox_status st = build_program(ctx);
    if (st == CLVOX_OK) st = query_real_size(ctx);
    if (st == CLVOX_OK) st = clvox__device_checks(ctx); /* device_checks.c: the contraction self-test */
    ctx->device.kernels_float = ctx->real_size == 4;
    return st;
}

/* Puts program p, of the double build or the float one, in use: what
 * follows from which build it is. */
static void use_build(clvox_context *ctx, cl_program p, int is_double)
{
    ctx->program = p;
    ctx->real_size = is_double ? 8 : 4;
    ctx->kernels_float = !is_double;
    ctx->device.kernels_float = !is_double;
}

clvox_status clvox__select_build(clvox_context *ctx, int need_double)
{
    need_double = need_double != 0;
    if (!ctx->float_for_speed || (ctx->real_size == 8) == need_double) return CLVOX_OK;
    cl_program other = ctx->program_other, mine = ctx->program;
    if (!other) { /* the other build, once: built and checked in ctx's place */
        const int cached = ctx->program_cached;
        ctx->program = NULL;
        ctx->kernels_float = !need_double;
        clvox_status st = build_program(ctx);
        if (st == CLVOX_OK) st = query_real_size(ctx);
        if (st == CLVOX_OK) st = clvox__device_checks(ctx);
        if (st == CLVOX_OK && (ctx->real_size == 8) != need_double)
            st = clvox__fail(ctx, CLVOX_ERR_INTERNAL, "the %s build of the kernels has reals of %zu bytes",
                             need_double ? "double" : "float", ctx->real_size);
        other = ctx->program;
        ctx->program_cached = cached;
        if (st != CLVOX_OK) {
            if (other) clReleaseProgram(other);
            use_build(ctx, mine, !need_double);
            return st;
        }
    }
    ctx->program_other = mine;
    use_build(ctx, other, need_double);
    return CLVOX_OK;
}

static void close_device(clvox_context *ctx)
{
    clvox__launch_release(ctx);
    if (ctx->program) clReleaseProgram(ctx->program);
    if (ctx->program_other) clReleaseProgram(ctx->program_other);
    ctx->program_other = NULL;
    if (ctx->queue) clReleaseCommandQueue(ctx->queue);
    if (ctx->cl) clReleaseContext(ctx->cl);
    ctx->program = NULL;
    ctx->queue = NULL;
    ctx->cl = NULL;
}

void clvox__warn(clvox_context *ctx, const char *fmt, ...)
{
    size_t used = strlen(ctx->warnings);
    if (used + 2 >= sizeof ctx->warnings) return;
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(ctx->warnings + used, sizeof ctx->warnings - used - 1, fmt, ap);
    va_end(ap);
    if (n < 0) {
        ctx->warnings[used] = 0;
        return;
    }
    used = strlen(ctx->warnings);
    ctx->warnings[used] = '\n';
    ctx->warnings[used + 1] = 0;
}

/* The devices a selector list names, in its order: "all", or selectors
 * (select_device's) separated by commas. */
static clvox_status select_devices(clvox_context *ctx, const char *sel, device_entry *list, size_t n,
                                   size_t *picks, uint32_t *count)
{
    *count = 0;
    if (sel && !strcmp(sel, "all")) {
        if (n > CLVOX_MAX_DEVICES)
            return clvox__fail(ctx, CLVOX_ERR_NO_DEVICE, "%zu devices: a run takes at most %u (name them)", n,
                               CLVOX_MAX_DEVICES);
        for (size_t i = 0; i < n; i++) picks[(*count)++] = i;
        return CLVOX_OK;
    }
    if (!sel || !strchr(sel, ',')) return select_device(ctx, sel, list, n, &picks[(*count)++]);
    const char *p = sel;
    for (;;) {
        const char *comma = strchr(p, ',');
        size_t len = comma ? (size_t)(comma - p) : strlen(p);
        char one[256];
        if (len == 0 || len >= sizeof one)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "device list '%s': %s selector", sel,
                               len ? "too long a" : "an empty");
        memcpy(one, p, len);
        one[len] = 0;
        if (*count == CLVOX_MAX_DEVICES)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "device list '%s': more than %u devices", sel,
                               CLVOX_MAX_DEVICES);
        size_t pick;
        clvox_status st = select_device(ctx, one, list, n, &pick);
        if (st != CLVOX_OK) return st;
        for (uint32_t i = 0; i < *count; i++)
            if (picks[i] == pick)
                return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT,
                                   "device list '%s': '%s' names device %zu (%s) again", sel, one, pick,
                                   list[pick].info.name);
        picks[(*count)++] = pick;
        if (!comma) return CLVOX_OK;
        p = comma + 1;
    }
}

/* Opens every device of a set (count > 1) as members of ctx; a device that
 * cannot be opened, or computes differently from the others, is left out
 * with a warning. */
static clvox_status open_set(clvox_context *ctx, const device_entry *list, const size_t *picks, uint32_t count)
{
    clvox_context *open[CLVOX_MAX_DEVICES];
    uint32_t n = 0;
    char first_error[512] = "";
    clvox_status first_st = CLVOX_OK;
    for (uint32_t i = 0; i < count; i++) {
        clvox_context *c = calloc(1, sizeof *c);
        if (!c) {
            for (uint32_t j = 0; j < n; j++) close_device(open[j]), free(open[j]);
            return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
        }
        c->position = i;
        c->want_float = ctx->want_float;
        clvox_status st = open_device(c, &list[picks[i]]);
        if (st == CLVOX_OK) {
            open[n++] = c;
            continue;
        }
        clvox__warn(ctx, "device %u '%s' left out: %s", i, list[picks[i]].info.name, c->error);
        if (first_st == CLVOX_OK) first_st = st, snprintf(first_error, sizeof first_error, "%.500s", c->error);
        close_device(c);
        free(c);
    }
    if (n == 0)
        return clvox__fail(ctx, first_st, "none of the %u devices could be used; device 0: %s", count, first_error);
    /* Kernels with and without fp64, or float kernels with and without
     * correctly rounded division, decide every voxel the same
     * (docs/design.md "Device requirements", "Devices without double
     * precision"): all stay in the set, those with the best rules present
     * (double, else rounded float) first, so that the lead prepares the
     * mesh in double where a device can. */
    int best = 0;
    for (uint32_t i = 0; i < n; i++)
        if (clvox__kernel_rules(open[i]) > best) best = clvox__kernel_rules(open[i]);
    clvox_context *order[CLVOX_MAX_DEVICES];
    uint32_t kept = 0;
    for (int pass = 0; pass < 2; pass++)
        for (uint32_t i = 0; i < n; i++)
            if ((clvox__kernel_rules(open[i]) == best) == (pass == 0)) order[kept++] = open[i];
    memcpy(open, order, kept * sizeof *open);
    /* member 0 becomes ctx itself: all of it but the warnings so far */
    clvox_context *first = open[0];
    memcpy(first->warnings, ctx->warnings, sizeof ctx->warnings);
    *ctx = *first;
    free(first);
    ctx->member[0] = ctx;
    for (uint32_t i = 1; i < kept; i++) ctx->member[i] = open[i];
    ctx->member_count = kept;
    return CLVOX_OK;
}

clvox_status clvox_context_create(const clvox_context_options *options, clvox_context **out)
{
    if (!out) return CLVOX_ERR_INVALID_ARGUMENT;
    clvox_context *ctx = calloc(1, sizeof *ctx);
    *out = ctx;
    if (!ctx) return CLVOX_ERR_OUT_OF_MEMORY;
    clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
    if (options) {
        if (options->size < sizeof(size_t) || options->size > sizeof o)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_context_options.size is %zu", options->size);
        memcpy(&o, options, options->size);
    }
    ctx->host_only = o.host_only;
    if (o.host_only) return CLVOX_OK;
    ctx->want_float = o.float_kernels != 0;

    const char *sel = o.device;
    if (!sel || !*sel) sel = clvox__setting_value(CLVOX__ENV_DEVICE);

    device_entry *list;
    size_t n, picks[CLVOX_MAX_DEVICES];
    uint32_t count = 0;
    char why[256];
    clvox_status st = enumerate(&list, &n, why, sizeof why);
    if (st == CLVOX_ERR_OUT_OF_MEMORY) return clvox__fail(ctx, st, "out of memory listing OpenCL devices");
    if (st != CLVOX_OK) return clvox__fail(ctx, st, "%s", why);
    st = select_devices(ctx, sel, list, n, picks, &count);
    if (st == CLVOX_OK && count == 1) {
        ctx->member[0] = ctx;
        ctx->member_count = 1;
        st = open_device(ctx, &list[picks[0]]);
    } else if (st == CLVOX_OK) {
        st = open_set(ctx, list, picks, count);
    }
    free(list);
    ctx->warnings_kept = strlen(ctx->warnings);
    return st;
}

void clvox_context_destroy(clvox_context *ctx)
{
    if (!ctx) return;
    for (uint32_t i = 1; i < ctx->member_count; i++) {
        close_device(ctx->member[i]);
        free(ctx->member[i]);
    }
    close_device(ctx);
    free(ctx);
}

size_t clvox_context_device_count(const clvox_context *ctx)
{
    return ctx && !ctx->host_only && ctx->program ? ctx->member_count : 0;
}

const clvox_device_info *clvox_context_device_at(const clvox_context *ctx, size_t i)
{
    return i < clvox_context_device_count(ctx) ? &ctx->member[i]->device : NULL;
}

const char *clvox_context_warnings(const clvox_context *ctx) { return ctx ? ctx->warnings : ""; }

const char *clvox_context_error(const clvox_context *ctx) { return ctx ? ctx->error : ""; }

const clvox_device_info *clvox_context_device(const clvox_context *ctx)
{
    return (ctx && !ctx->host_only) ? &ctx->device : NULL;
}

clvox_status clvox__kernel(clvox_context *ctx, const char *name, cl_kernel *out)
{
    cl_int err;
    *out = NULL;
    if (ctx->host_only || !ctx->program)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "context was created without an OpenCL device");
    *out = clCreateKernel(ctx->program, name, &err);
    if (err != CL_SUCCESS) {
        char what[160];
        snprintf(what, sizeof what, "clCreateKernel(%s)", name);
        return clvox__cl_fail(ctx, err, what);
    }
    return CLVOX_OK;
}

cl_mem clvox__buffer(clvox_context *ctx, cl_mem_flags flags, size_t bytes, void *host, clvox_status *st,
                     const char *what)
{
    cl_int err;
    if (bytes == 0) bytes = 16;
    if (bytes > clvox__device_max_alloc(ctx)) { /* device_memory.c */
        *st = clvox__device_alloc_oom(ctx, bytes, what);
        return NULL;
    }
    cl_mem m = clCreateBuffer(ctx->cl, flags, bytes, host, &err);
    if (err != CL_SUCCESS) {
        char msg[160];
        snprintf(msg, sizeof msg, "clCreateBuffer(%s, %zu bytes)", what, bytes);
        *st = clvox__cl_fail(ctx, err, msg);
        return NULL;
    }
    return m;
}

void clvox__release_mem(cl_mem *m)
{
    if (*m) clReleaseMemObject(*m);
    *m = NULL;
}

clvox_status clvox__out_begin(clvox_context *ctx, const void *out, size_t full_size, size_t min_size,
                              const char *what)
{
    if (!out) return CLVOX_OK;
    size_t size;
    memcpy(&size, out, sizeof size); /* every such struct begins with size_t size */
    if (size < min_size || size > full_size)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "%s.size is %zu, not %zu..%zu (set it to sizeof(%s))",
                           what, size, min_size, full_size, what);
    return CLVOX_OK;
}

void clvox__out_end(void *out, const void *full)
{
    if (!out) return;
    size_t size;
    memcpy(&size, out, sizeof size);
    memcpy((char *)out + sizeof size, (const char *)full + sizeof size, size - sizeof size);
}

int clvox_open_regular_read(const char *path, const char **why)
{
    const char *local;
    if (!why) why = &local;
    if (!path) {
        *why = strerror(EINVAL);
        return -1;
    }
    return clvox__open_regular_read(path, NULL, why);
}

int clvox__open_regular_read(const char *path, struct stat *sb, const char **why)
{
    struct stat local;
    if (!sb) sb = &local;
    int fd;
    do fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    while (fd < 0 && errno == EINTR);
    if (fd < 0) {
        *why = strerror(errno);
        return -1;
    }
    int flags;
    if (fstat(fd, sb) != 0 || (S_ISREG(sb->st_mode) && ((flags = fcntl(fd, F_GETFL)) < 0 ||
                                                         fcntl(fd, F_SETFL, flags & ~O_NONBLOCK) != 0))) {
        *why = strerror(errno);
        close(fd);
        return -1;
    }
    if (!S_ISREG(sb->st_mode)) {
        *why = S_ISDIR(sb->st_mode) ? strerror(EISDIR) : "not a regular file (a FIFO, socket or device)";
        close(fd);
        return -1;
    }
    return fd;
}

clvox_status clvox__read_text_file(clvox_context *ctx, const char *path, const char *what, size_t max_bytes,
                                   char **data, size_t *size)
{
    *data = NULL;
    *size = 0;
    const char *why = NULL;
    int fd = clvox__open_regular_read(path, NULL, &why);
    if (fd < 0) return clvox__fail(ctx, CLVOX_ERR_IO, "cannot open %s '%.3000s': %s", what, path, why);
    char *buf = malloc(max_bytes + 1);
    if (!buf) {
        close(fd);
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "%s: out of memory", what);
    }
    size_t n = 0; /* one byte more than max_bytes: tells a file that is too large */
    int err = 0;
    while (n < max_bytes + 1) {
        ssize_t got = read(fd, buf + n, max_bytes + 1 - n);
        if (got < 0 && errno == EINTR) continue; /* a regular file: the read goes on */
        if (got < 0) err = errno;
        if (got <= 0) break;
        n += (size_t)got;
    }
    close(fd);
    clvox_status st = CLVOX_OK;
    if (err) st = clvox__fail(ctx, CLVOX_ERR_IO, "cannot read %s '%.3000s': %s", what, path, strerror(err));
    else if (n > max_bytes)
        st = clvox__fail(ctx, CLVOX_ERR_PALETTE_FORMAT, "%.3000s: larger than %zu bytes", path, max_bytes);
    if (st != CLVOX_OK) {
        free(buf);
        return st;
    }
    *data = buf;
    *size = n;
    return CLVOX_OK;
}
