/* SPDX-License-Identifier: Apache-2.0 */
/* Driver: runs a method slab by slab and hands each slab's planes
 * (occupancy bit rows and/or coverage values, see internal.h), in
 * increasing z, to a sink (a file format of io/output.c's table, caller
 * callback or dense memory).
 * Memory is one slab of each plane whatever the number of slices. */
#include "core/internal.h"
#include "schedule.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Slabs hold about this many voxels: enough to keep the device busy, few
 * enough that the methods' per-ray and per-row buffers stay small and
 * memory does not grow with the grid (the slab's bits take 2 MiB). */
#define SLAB_TARGET_VOXELS (16u << 20)

/* A GPU's launch: at least this many rays per compute unit (a large GPU
 * holds about 2048 threads on each), so that one call fills it. */
#define LAUNCH_RAYS_PER_UNIT 2048u

typedef clvox__sink_fn sink_fn;

static uint32_t auto_slab_depth(const clvox_grid *g)
{
    uint64_t slice = (uint64_t)g->dims[0] * g->dims[1];
    uint64_t d = SLAB_TARGET_VOXELS / (slice ? slice : 1);
    if (d < 1) d = 1;
    if (d > g->dims[2]) d = g->dims[2];
    return (uint32_t)d;
}

/* Slabs per method call on device dc (schedule.h). */
uint32_t clvox__launch_slabs(const clvox_context *dc, int ray, const clvox_voxelize_options *o, const clvox_grid *g,
                             uint32_t depth, const uint64_t plane_slice[4])
{
    const uint32_t X = g->dims[0], Y = g->dims[1], Z = g->dims[2];
    const uint32_t nslabs = (Z + depth - 1) / depth;
    uint64_t n = clvox__hooks()->launch_slabs;
    if (!n && ray && strcmp(dc->device.type, "gpu") == 0 && dc->device.compute_units) {
        const clvox_axis axis = o->ray_axis == CLVOX_AXIS_DEFAULT ? CLVOX_AXIS_X : o->ray_axis;
        /* rays of one slab: a z-ray crosses every slab, so more slabs add none */
        uint64_t rays = axis == CLVOX_AXIS_X ? (uint64_t)Y * depth : axis == CLVOX_AXIS_Y ? (uint64_t)X * depth : 0;
        rays *= o->oversample ? (uint64_t)o->oversample * o->oversample : 1u;
        const uint64_t target = (uint64_t)dc->device.compute_units * LAUNCH_RAYS_PER_UNIT;
        n = rays ? (target + rays - 1) / rays : 1;
    }
    if (n < 1) n = 1;
    if (n > nslabs) n = nslabs;
    uint64_t all = 0;
    const uint64_t max_alloc = clvox__device_max_alloc(dc), budget = clvox__device_budget(dc) / 4;
    for (int p = 0; p < 4; p++) {
        all += plane_slice[p] * depth;
        while (n > 1 && plane_slice[p] * depth * n > max_alloc) n--;
    }
    while (n > 1 && all * n > budget) n--;
    return (uint32_t)n;
}

/* Palette runs: t = p = 16 samples unless the caller says (N = 4). */
#define PALETTE_DEFAULT_N 4u
#define PALETTE_DEFAULT_M 16u

/* The palette, metric and shortcut of a palette run; fills the sampling
 * defaults and the shortcut's default constants into o. */
static clvox_status check_palette(clvox_context *ctx, clvox_voxelize_options *o)
{
    if (!o->palette) {
        if (o->channels & (CLVOX_CHANNEL_ELEMENT | CLVOX_CHANNEL_SCORE))
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "the element and score channels need a palette");
        return CLVOX_OK;
    }
    if (o->method == CLVOX_METHOD_TETRA)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "palette voxelization needs the ray method (its samples are rays)");
    if ((unsigned)o->metric >= CLVOX_METRIC_COUNT)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "unknown metric %d", (int)o->metric);
    size_t n = clvox_palette_count(o->palette);
    if (n < 2 || n > 1024)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "palette with %zu elements (2 .. 1024)", n);
    if (!o->oversample) {
        if (o->oversample_points)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "points per voxel given without rays (oversample)");
        o->oversample = PALETTE_DEFAULT_N;
        o->oversample_points = PALETTE_DEFAULT_M;
    }
    const uint32_t N = o->oversample, M = o->oversample_points ? o->oversample_points : N;
    if ((uint64_t)N * N * M > CLVOX_MAX_PALETTE_SAMPLES)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT,
                           "%u rays x %u points = %llu samples per voxel: palette scoring takes at most %u",
                           N * N, M, (unsigned long long)N * N * M, CLVOX_MAX_PALETTE_SAMPLES);
    if (o->nearest_shortcut) {
        if (o->metric != CLVOX_METRIC_NEAREST)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "the alpha/beta shortcut is for the nearest metric only");
        if (o->shortcut_alpha == 0.0 && o->shortcut_beta == 0.0) {
            /* alpha << p_min, beta >> p_max (3.1): a tenth of the way */
            double pmin = 0.5, pmax = 0.5;
            if (n > 2) pmin = 1.0, pmax = 0.0;
            for (size_t i = 2; i < n; i++) {
                clvox_palette_element_info info = CLVOX_PALETTE_ELEMENT_INFO_INIT;
                clvox_status st = clvox_palette_element_info_get(ctx, o->palette, i, &info);
                if (st != CLVOX_OK) return st;
                if (info.volume < pmin) pmin = info.volume;
                if (info.volume > pmax) pmax = info.volume;
            }
            o->shortcut_alpha = pmin / 10.0;
            o->shortcut_beta = 1.0 - (1.0 - pmax) / 10.0;
        }
        if (!(o->shortcut_alpha > 0.0 && o->shortcut_alpha < o->shortcut_beta && o->shortcut_beta < 1.0))
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "shortcut needs 0 < alpha (%g) < beta (%g) < 1",
                               o->shortcut_alpha, o->shortcut_beta);
    }
    return CLVOX_OK;
}

/* Oversampling, channels and threshold. */
static clvox_status check_sampling(clvox_context *ctx, clvox_voxelize_options *o)
{
    if (o->channels & ~(CLVOX_CHANNEL_OCCUPANCY | CLVOX_CHANNEL_COVERAGE | CLVOX_CHANNEL_ELEMENT | CLVOX_CHANNEL_SCORE))
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "unknown channels 0x%x", o->channels);
    clvox_status pst = check_palette(ctx, o);
    if (pst != CLVOX_OK) return pst;
    const uint32_t N = o->oversample, M = o->oversample_points ? o->oversample_points : o->oversample;
    if (N == 0) {
        if (o->oversample_points || o->stochastic)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "points per voxel and stochastic sampling need oversample >= 1");
        if (o->channels & CLVOX_CHANNEL_COVERAGE)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "the coverage channel needs oversample >= 1");
    } else {
        if (o->method == CLVOX_METHOD_TETRA)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT,
                               "the tetra method does not compute coverage (oversampling is the ray method's)");
        if (N > CLVOX_MAX_OVERSAMPLE)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "oversample %u: at most %u (x %u rays per voxel column)",
                               N, CLVOX_MAX_OVERSAMPLE, CLVOX_MAX_OVERSAMPLE);
        if (M > CLVOX_MAX_POINTS)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "%u points per voxel: at most %u", M, CLVOX_MAX_POINTS);
        if ((uint64_t)N * N * M > CLVOX_MAX_SAMPLES)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "%u x %u rays x %u points = %llu samples per voxel: at most %u",
                               N, N, M, (unsigned long long)N * N * M, CLVOX_MAX_SAMPLES);
    }
    if (o->threshold_set && !(o->threshold >= 0.0 && o->threshold <= 1.0))
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "threshold %g is outside [0, 1]", o->threshold);
    return CLVOX_OK;
}

/* The channels a run produces when the caller does not say. */
static uint32_t auto_channels(const clvox_voxelize_options *o)
{
    if (o->channels) return o->channels;
    if (o->palette) return CLVOX_CHANNEL_ELEMENT | CLVOX_CHANNEL_SCORE;
    if (!o->oversample) return CLVOX_CHANNEL_OCCUPANCY;
    /* the paper's use of a threshold: a binary volume from the grey levels */
    return o->threshold_set ? CLVOX_CHANNEL_OCCUPANCY : CLVOX_CHANNEL_COVERAGE;
}

uint16_t clvox__half_from_unit(double x)
{
    if (!(x > 0.0)) return 0;
    if (x >= 1.0) return 0x3C00;
    int e;
    double m = frexp(x, &e); /* x = m * 2^e, m in [0.5, 1) */
    if (e >= -13) {          /* normal: 1.f * 2^(e-1), 10 fraction bits */
        double r = nearbyint(ldexp(m, 11)); /* in [1024, 2048], ties to even */
        if (r == 2048.0) r = 1024.0, e++;
        return (uint16_t)(((unsigned)(e + 14) << 10) | ((unsigned)r - 1024u));
    }
    return (uint16_t)nearbyint(ldexp(x, 24)); /* subnormal: k * 2^-24 (1024 = the smallest normal) */
}

/* Whether a voxelization with these options runs the winding test: the
 * ray method in a solid or conservative mode with a winding inside (or the
 * default), as check_inputs resolves it; *weld its weld. 0 for options it
 * would refuse by their size. */
int clvox__options_winding(const clvox_voxelize_options *in, double *weld)
{
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    if (in) {
        if (in->size < sizeof(size_t) || in->size > sizeof o) return 0;
        memcpy(&o, in, in->size);
    }
    *weld = o.weld;
    return o.method == CLVOX_METHOD_RAY && o.mode != CLVOX_MODE_SURFACE &&
           (o.inside == CLVOX_INSIDE_DEFAULT || o.inside == CLVOX_INSIDE_WINDING ||
            o.inside == CLVOX_INSIDE_WINDING_ABS);
}

static clvox_status check_inputs(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                 const clvox_voxelize_options *in, clvox_voxelize_options *o)
{
    clvox_voxelize_options def = CLVOX_VOXELIZE_OPTIONS_INIT;
    *o = def;
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!mesh || !grid) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "NULL mesh or grid");
    if (ctx->host_only || !ctx->program)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "context was created without an OpenCL device");
    if (in) {
        if (in->size < sizeof(size_t) || in->size > sizeof *o)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_voxelize_options.size is %zu", in->size);
        memcpy(o, in, in->size);
    }
    if ((unsigned)o->method >= CLVOX_METHOD_COUNT)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "unknown method %d", (int)o->method);
    if ((unsigned)o->ray_axis > CLVOX_AXIS_Z)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "unknown ray axis %d", (int)o->ray_axis);
    if ((unsigned)o->compression >= CLVOX_COMPRESSION_COUNT)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "unknown compression %d", (int)o->compression);
    for (int a = 0; a < 3; a++)
        if (grid->dims[a] == 0 || grid->dims[a] > CLVOX_MAX_AXIS || !(grid->voxel_size[a] > 0))
            return clvox__fail(ctx, CLVOX_ERR_GRID, "invalid grid (use clvox_grid_compute)");
    if ((uint64_t)grid->dims[0] * grid->dims[1] * grid->dims[2] > CLVOX_MAX_VOXELS)
        return clvox__fail(ctx, CLVOX_ERR_GRID, "grid has more than %llu voxels", (unsigned long long)CLVOX_MAX_VOXELS);
    if (mesh->triangle_count == 0) return clvox__fail(ctx, CLVOX_ERR_MESH_EMPTY, "mesh has no triangles");
    if ((unsigned)o->mode >= CLVOX_MODE_COUNT)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "unknown mode %d", (int)o->mode);
    if (o->mode != CLVOX_MODE_SOLID) { /* binary: one occupancy bit per voxel */
        const char *mode = clvox_mode_name(o->mode);
        if (o->palette)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "palette voxelization is a solid mode (not %s)", mode);
        if (o->oversample || o->oversample_points || o->stochastic || o->threshold_set)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "%s mode is binary: no oversampling or threshold", mode);
        if (o->channels & ~CLVOX_CHANNEL_OCCUPANCY)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "%s mode writes occupancy only (channels 0x%x)", mode,
                               o->channels);
    }
    /* The inside test: winding for the ray method unless asked otherwise;
     * the tetra raster is parity by construction (an XOR), and the surface
     * mode has none. */
    if ((unsigned)o->inside >= CLVOX_INSIDE_COUNT)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "unknown inside test %d", (int)o->inside);
    if (!(o->weld >= 0) || !isfinite(o->weld))
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "weld distance %g: must be >= 0", o->weld);
    if (o->method == CLVOX_METHOD_TETRA && o->mode != CLVOX_MODE_SURFACE) {
        if (o->inside == CLVOX_INSIDE_WINDING || o->inside == CLVOX_INSIDE_WINDING_ABS)
            return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT,
                               "the tetra method is a parity method (an XOR of tetrahedra): use --inside parity or "
                               "the ray method for winding numbers");
        o->inside = CLVOX_INSIDE_PARITY;
    }
    if (o->inside == CLVOX_INSIDE_DEFAULT) o->inside = CLVOX_INSIDE_WINDING;
    if (o->weld > 0 && o->inside == CLVOX_INSIDE_PARITY)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "welding (%g) is part of the winding inside test, not parity",
                           o->weld);
    return check_sampling(ctx, o);
}

/* The pipeline. `open_sink` (may be NULL) is called once the method is
 * prepared, with its parameter text, before any slab is computed. */
typedef clvox__open_fn open_fn;

/* What a sink asks of the run: the channels it needs beyond those the
 * options produce (forced), and coverage as counts rather than HALF bits. */
typedef struct sink_needs {
    uint32_t forced;
    int counts;
    uint32_t *channels_out; /* receives the channels produced (may be NULL) */
    uint32_t *samples_out;  /* receives the samples per voxel (may be NULL) */
} sink_needs;

static clvox_status run(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                        const clvox_voxelize_options *in, const sink_needs *needs, open_fn open_sink, sink_fn sink,
                        void *user, clvox_stats *stats_out)
{
    double t_start = clvox__now();
    clvox_voxelize_options o;
    clvox_stats stats;
    memset(&stats, 0, sizeof stats);
    /* filled whole here, then as much of it as the caller's struct holds */
    clvox_status st = clvox__out_begin(ctx, stats_out, sizeof stats, CLVOX__STATS_SIZE_0, "clvox_stats");
    if (st != CLVOX_OK) return st;
    st = check_inputs(ctx, mesh, grid, in, &o);
    if (st != CLVOX_OK) return st;

    const clvox__method *m = o.method == CLVOX_METHOD_TETRA ? &clvox__method_tetra : &clvox__method_ray;
    /* surface: the surface method alone; conservative: the solid method,
     * then the surface ORed over its slab (m2) */
    const clvox__method *m2 = o.mode == CLVOX_MODE_CONSERVATIVE ? &clvox__method_surface : NULL;
    if (o.mode == CLVOX_MODE_SURFACE) m = &clvox__method_surface;
    const uint32_t X = grid->dims[0], Y = grid->dims[1], Z = grid->dims[2];
    clvox__run req = {auto_channels(&o) | needs->forced, needs->counts, clvox__sched_poll, NULL, 0, NULL};
    o.channels = req.channels;
    if (needs->channels_out) *needs->channels_out = req.channels;
    /* The slab's device planes: occupancy bit rows; coverage, element and
     * score one uint16 per voxel. */
    const uint64_t voxel_slice = (uint64_t)X * Y * sizeof(cl_ushort);
    const uint32_t plane_channel[4] = {CLVOX_CHANNEL_OCCUPANCY, CLVOX_CHANNEL_COVERAGE, CLVOX_CHANNEL_ELEMENT,
                                       CLVOX_CHANNEL_SCORE};
    static const char *const plane_name[4] = {"occupancy", "coverage", "element", "score"};
    uint64_t plane_slice[4];
    uint64_t slice_bytes = 0, all_slices = 0; /* the largest plane bounds the slab depth */
    for (int i = 0; i < 4; i++) {
        plane_slice[i] = !(req.channels & plane_channel[i]) ? 0
                         : i == 0 ? (uint64_t)clvox__row_words(X) * Y * sizeof(cl_uint)
                                  : voxel_slice;
        if (plane_slice[i] > slice_bytes) slice_bytes = plane_slice[i];
        all_slices += plane_slice[i];
    }
    uint64_t max_alloc = ctx->device.max_alloc_bytes ? ctx->device.max_alloc_bytes : (1ull << 31);
    if (slice_bytes > max_alloc)
        return clvox__fail(ctx, CLVOX_ERR_GRID, "one %ux%u slice needs %llu MB, more than the device's largest buffer (%llu MB)",
                           X, Y, (unsigned long long)(slice_bytes >> 20), (unsigned long long)(max_alloc >> 20));
    /* Several devices share the slices: slabs of at most Z / (8 devices),
     * so that each takes several and the last ones are short. The volume is
     * the same at any depth. */
    const uint32_t ndev = ctx->member_count; /* >= 1: check_inputs refused a context without a device */
    uint32_t depth = o.slab_depth ? (o.slab_depth < Z ? o.slab_depth : Z) : auto_slab_depth(grid);
    if (!o.slab_depth && ndev > 1) {
        uint32_t share = (Z + 8 * ndev - 1) / (8 * ndev);
        if (share < depth) depth = share;
    }
    if ((uint64_t)depth * slice_bytes > max_alloc) depth = (uint32_t)(max_alloc / slice_bytes);
    stats.slab_depth = depth;
    stats.total_voxels = (uint64_t)X * Y * Z;
    stats.inside = o.inside;

    stats.channels = req.channels;
    stats.samples_per_voxel = o.oversample ? o.oversample * o.oversample * (o.oversample_points ? o.oversample_points : o.oversample) : 1;
    if (needs->samples_out) *needs->samples_out = stats.samples_per_voxel;

    /* Each device prepares its methods (the first one's statistics are the
     * run's); a device whose preparation fails is left out with a warning,
     * unless it is the only one or the failure is the input's. */
    ctx->warnings[ctx->warnings_kept] = 0;
    clvox__sched_device dev[CLVOX_MAX_DEVICES];
    memset(dev, 0, sizeof dev);
    /* Each device's launch unit, and the reorder window that keeps every
     * device's next group computing while the last one is written. */
    /* Every build decides every voxel exactly (docs/design.md "Devices
     * without double precision"): a float device shares every run. A
     * device in float by the speed rule (device_speed.c) runs in float,
     * unless the mesh leaves float's exact range (below). */
    for (uint32_t d = 0; d < ndev && st == CLVOX_OK; d++) {
        st = clvox__select_build(ctx->member[d], 0);
        if (st != CLVOX_OK && ctx->member[d] != ctx) clvox__fail(ctx, st, "%s", ctx->member[d]->error);
    }
    if (st != CLVOX_OK) return st;
    uint32_t group_max = 1;
    for (uint32_t d = 0; d < ndev; d++) {
        dev[d].group = clvox__launch_slabs(ctx->member[d], m == &clvox__method_ray, &o, grid, depth, plane_slice);
        if (dev[d].group > group_max) group_max = dev[d].group;
    }
    const uint32_t window = clvox__sched_window(ndev, group_max, depth * all_slices);
    for (uint32_t d = 0; d < ndev; d++) { /* a window too small for two groups a device: smaller groups */
        uint32_t fit = window / (2 * ndev);
        if (dev[d].group > fit) dev[d].group = fit ? fit : 1;
    }
    clvox_stats first = stats;
    int have_first = 0;
    uint32_t first_group = 1;
    st = CLVOX_OK;
    for (uint32_t d = 0; d < ndev; d++) {
        clvox_context *dc = ctx->member[d];
        dev[d].ctx = dc;
        clvox_stats mine = stats;
        clvox__run rd = req;
        rd.poll_user = &dev[d];
        for (uint32_t e = 0; e < d && !rd.lead; e++) rd.lead = dev[e].ms; /* the mesh prepared once */
        const uint32_t gdepth = depth * dev[d].group; /* its planes' slices */
        clvox_status sd = m->prepare(dc, mesh, grid, &o, &rd, gdepth, &mine, &dev[d].ms);
        if (sd == CLVOX_OK && m2) {
            clvox__run r2 = rd;
            r2.lead = NULL;
            for (uint32_t e = 0; e < d && !r2.lead; e++) r2.lead = dev[e].ms2;
            r2.accumulate = 1;
            sd = m2->prepare(dc, mesh, grid, &o, &r2, gdepth, &mine, &dev[d].ms2);
        }
        if (sd == CLVOX_OK && clvox__hook_fails_device(dc->position, CLVOX__FAIL_PREPARE))
            sd = clvox__fail(dc, CLVOX_ERR_OPENCL, "CLVOX_TEST_FAIL_DEVICE=%u:prepare: a simulated OpenCL error",
                             dc->position);
        for (int i = 0; i < 4 && sd == CLVOX_OK; i++) {
            if (!plane_slice[i]) continue;
            cl_int err = CL_SUCCESS;
            dev[d].plane[i] = clCreateBuffer(dc->cl, CL_MEM_READ_WRITE, (size_t)(gdepth * plane_slice[i]), NULL, &err);
            if (err != CL_SUCCESS) {
                char what[64];
                snprintf(what, sizeof what, "clCreateBuffer(slab %s)", plane_name[i]);
                sd = clvox__cl_fail(dc, err, what);
            }
        }
        if (sd == CLVOX_OK) {
            if (!have_first) first = mine, have_first = 1, first_group = dev[d].group;
            continue;
        }
        if (dev[d].ms) m->release(dev[d].ms);
        if (dev[d].ms2) m2->release(dev[d].ms2);
        dev[d].ms = dev[d].ms2 = NULL;
        for (int i = 0; i < 4; i++) clvox__release_mem(&dev[d].plane[i]);
        /* a coordinate outside float's exact range (clvox__float_check) on a
         * device in float by the speed rule: again in double */
        if (sd == CLVOX_ERR_NO_DEVICE && dc->float_for_speed && dc->real_size == 4) {
            sd = clvox__select_build(dc, 1);
            if (sd == CLVOX_OK) {
                d--; /* the loop's d++: this device again, in double */
                continue;
            }
        }
        /* the input's fault (or the only device): the run's error */
        if (ndev == 1 || (sd != CLVOX_ERR_OPENCL && sd != CLVOX_ERR_OUT_OF_MEMORY && sd != CLVOX_ERR_KERNEL_BUILD)) {
            if (dc != ctx) clvox__fail(ctx, sd, "%s", dc->error);
            st = sd;
            break;
        }
        clvox__warn(ctx, "device %u '%s' left out: %s", dc->position, dc->device.name, dc->error);
        if (d == ndev - 1 && !have_first) {
            clvox__fail(ctx, sd, "no device could prepare the run; device %u: %s", dc->position, dc->error);
            st = sd;
        }
    }
    if (have_first) stats = first;
    clvox__sched_device *lead = NULL;
    for (uint32_t d = 0; d < ndev && !lead; d++)
        if (dev[d].ms) lead = &dev[d];
    if (st == CLVOX_OK && open_sink && lead) {
        char params[512], name[32];
        m->describe(lead->ms, params, sizeof params);
        snprintf(name, sizeof name, "%s", m->name);
        if (m2) {
            size_t used = strlen(params);
            snprintf(params + used, sizeof params - used, " mode=conservative surface: ");
            used = strlen(params);
            m2->describe(lead->ms2, params + used, sizeof params - used);
            snprintf(name, sizeof name, "%s+%s", m->name, m2->name);
        }
        st = open_sink(user, name, params);
    }
    /* one device's: method working set + its planes (the host's reorder
     * buffer is stats.reorder_bytes) */
    stats.peak_slab_bytes += (uint64_t)depth * first_group * all_slices;
    if (st == CLVOX_OK) {
        clvox__sched_job job = {ctx, m, m2, dev, ndev, {0}, Z, depth, window, sink, user, o.progress, o.progress_user};
        memcpy(job.plane_slice, plane_slice, sizeof plane_slice);
        st = clvox__sched_run(&job, &stats);
    }
    for (uint32_t d = 0; d < ndev; d++) {
        for (int i = 0; i < 4; i++) clvox__release_mem(&dev[d].plane[i]);
        if (dev[d].ms) m->release(dev[d].ms);
        if (dev[d].ms2) m2->release(dev[d].ms2);
    }
    const int want_cov = (req.channels & CLVOX_CHANNEL_COVERAGE) != 0;
    /* coverage in voxel units: samples inside / samples per voxel */
    stats.coverage_sum = want_cov || o.palette ? stats.coverage_sum / stats.samples_per_voxel : (double)stats.filled_voxels;
    stats.seconds[CLVOX_STAGE_TOTAL] = clvox__now() - t_start;
    clvox__out_end(stats_out, &stats);
    return st;
}

/* ---- callback and memory sinks ---- */

typedef struct user_sink {
    clvox_context *ctx;
    clvox_slab_fn fn;              /* occupancy bytes (clvox_voxelize_stream) */
    clvox_slab_channels_fn fn_all; /* every channel (clvox_voxelize_slabs)    */
    void *user;
    uint8_t *occ_scratch;
    float *cov_scratch, *score_scratch;
    size_t occ_size, cov_size, score_size; /* elements */
    uint8_t *dense_occ;            /* memory sinks: X*Y*Z, or NULL */
    float *dense_cov;
    uint16_t *dense_element;
    float *dense_score;
    uint32_t X, Y;
    uint32_t channels;             /* produced (set by run) */
    float *value;                  /* coverage of count t: t / samples, exactly rounded */
    uint32_t samples;
} user_sink;

/* Bit rows -> one byte (0/1) per voxel, x fastest. */
static void bits_to_u8(uint8_t *dst, const uint32_t *bits, uint32_t X, size_t rows)
{
    const uint32_t W = clvox__row_words(X);
    for (size_t r = 0; r < rows; r++, bits += W, dst += X)
        for (uint32_t x = 0; x < X; x++) dst[x] = (uint8_t)((bits[x >> 5] >> (x & 31)) & 1u);
}

static void counts_to_float(float *dst, const uint16_t *counts, size_t n, const float *value)
{
    for (size_t i = 0; i < n; i++) dst[i] = value[counts[i]];
}

static int grow_scratch(void **buf, size_t *size, size_t n, size_t elem)
{
    if (n <= *size) return 1;
    void *q = realloc(*buf, n * elem);
    if (!q) return 0;
    *buf = q;
    *size = n;
    return 1;
}

static clvox_status user_slab(void *p, uint32_t z0, uint32_t nz, const clvox__slab_planes *planes)
{
    user_sink *s = p;
    size_t slice = (size_t)s->X * s->Y, n = slice * nz;
    if (!s->value && (planes->coverage_half || planes->score_half)) { /* the count -> fraction table, once */
        s->value = malloc(((size_t)s->samples + 1) * sizeof *s->value);
        if (!s->value) return clvox__fail(s->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
        for (uint32_t t = 0; t <= s->samples; t++) s->value[t] = (float)t / (float)s->samples;
    }
    uint8_t *occ = NULL;
    float *cov = NULL;
    if (planes->occupancy_bits && (s->dense_occ || s->fn || s->fn_all)) {
        if (s->dense_occ) {
            occ = s->dense_occ + (size_t)z0 * slice;
        } else {
            if (!grow_scratch((void **)&s->occ_scratch, &s->occ_size, n, 1))
                return clvox__fail(s->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for a slab");
            occ = s->occ_scratch;
        }
        bits_to_u8(occ, planes->occupancy_bits, s->X, (size_t)s->Y * nz);
    }
    if (planes->coverage_half && (s->dense_cov || s->fn_all)) {
        if (s->dense_cov) {
            cov = s->dense_cov + (size_t)z0 * slice;
        } else {
            if (!grow_scratch((void **)&s->cov_scratch, &s->cov_size, n, sizeof(float)))
                return clvox__fail(s->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for a slab");
            cov = s->cov_scratch;
        }
        counts_to_float(cov, planes->coverage_half, n, s->value);
    }
    float *score = NULL;
    if (planes->score_half && (s->dense_score || s->fn_all)) {
        if (s->dense_score) {
            score = s->dense_score + (size_t)z0 * slice;
        } else {
            if (!grow_scratch((void **)&s->score_scratch, &s->score_size, n, sizeof(float)))
                return clvox__fail(s->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for a slab");
            score = s->score_scratch;
        }
        counts_to_float(score, planes->score_half, n, s->value);
    }
    if (planes->element && s->dense_element)
        memcpy(s->dense_element + (size_t)z0 * slice, planes->element, n * sizeof *planes->element);
    int stop = 0;
    if (s->fn) stop = s->fn(s->user, z0, nz, occ);
    if (s->fn_all) {
        clvox_slab slab = {z0, nz, occ, cov, planes->element, score};
        stop = s->fn_all(s->user, &slab);
    }
    if (stop) return clvox__fail(s->ctx, CLVOX_ERR_CANCELLED, "cancelled by the slab callback at slice %u", z0);
    return CLVOX_OK;
}

static clvox_status run_user(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                             const clvox_voxelize_options *options, uint32_t forced, user_sink *s, clvox_stats *stats)
{
    /* coverage and score arrive as counts of s->samples (set by run) */
    sink_needs needs = {forced, 1, &s->channels, &s->samples};
    clvox_status st = run(ctx, mesh, grid, options, &needs, NULL, user_slab, s, stats);
    free(s->occ_scratch);
    free(s->cov_scratch);
    free(s->score_scratch);
    free(s->value);
    return st;
}

/* Legacy occupancy calls: occupancy is always produced (coverage > threshold,
 * 0.5 by default, when oversampled); no coverage plane unless asked for. */
static uint32_t occupancy_channels(const clvox_voxelize_options *o)
{
    return (o && o->channels ? o->channels : 0u) | CLVOX_CHANNEL_OCCUPANCY;
}

clvox_status clvox_voxelize_stream(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                   const clvox_voxelize_options *options, clvox_slab_fn fn, void *user,
                                   clvox_stats *stats)
{
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!fn || !grid) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "NULL slab callback or grid");
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    if (options && options->size >= sizeof(size_t) && options->size <= sizeof o) memcpy(&o, options, options->size);
    o.size = sizeof o; /* the fields set below are read whatever the caller's size */
    o.channels = occupancy_channels(&o);
    user_sink s = {.ctx = ctx, .fn = fn, .user = user, .X = grid->dims[0], .Y = grid->dims[1]};
    return run_user(ctx, mesh, grid, options ? &o : NULL, o.channels, &s, stats);
}

clvox_status clvox_voxelize_slabs(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                  const clvox_voxelize_options *options, clvox_slab_channels_fn fn, void *user,
                                  clvox_stats *stats)
{
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!fn || !grid) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "NULL slab callback or grid");
    user_sink s = {.ctx = ctx, .fn_all = fn, .user = user, .X = grid->dims[0], .Y = grid->dims[1]};
    return run_user(ctx, mesh, grid, options, 0, &s, stats);
}

static clvox_status check_dense(clvox_context *ctx, const clvox_grid *grid, size_t have, const char *what)
{
    uint64_t need = (uint64_t)grid->dims[0] * grid->dims[1] * grid->dims[2];
    if (have < need)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "%s buffer holds %zu values, the grid needs %llu", what,
                           have, (unsigned long long)need);
    return CLVOX_OK;
}

clvox_status clvox_voxelize_to_memory(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                      const clvox_voxelize_options *options, uint8_t *out, size_t out_size,
                                      clvox_stats *stats)
{
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!out || !grid) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "NULL output buffer or grid");
    clvox_status st = check_dense(ctx, grid, out_size, "output");
    if (st != CLVOX_OK) return st;
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    if (options && options->size >= sizeof(size_t) && options->size <= sizeof o) memcpy(&o, options, options->size);
    o.size = sizeof o; /* the fields set below are read whatever the caller's size */
    o.channels = occupancy_channels(&o) & ~CLVOX_CHANNEL_COVERAGE; /* nowhere to put coverage */
    user_sink s = {.ctx = ctx, .dense_occ = out, .X = grid->dims[0], .Y = grid->dims[1]};
    return run_user(ctx, mesh, grid, options ? &o : NULL, CLVOX_CHANNEL_OCCUPANCY, &s, stats);
}

clvox_status clvox_voxelize_to_buffers(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                       const clvox_voxelize_options *options, uint8_t *occupancy,
                                       size_t occupancy_count, float *coverage, size_t coverage_count,
                                       clvox_stats *stats)
{
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!grid || (!occupancy && !coverage))
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "NULL grid, or no output buffer at all");
    clvox_status st = CLVOX_OK;
    if (occupancy) st = check_dense(ctx, grid, occupancy_count, "occupancy");
    if (st == CLVOX_OK && coverage) st = check_dense(ctx, grid, coverage_count, "coverage");
    if (st != CLVOX_OK) return st;
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    if (options && options->size >= sizeof(size_t) && options->size <= sizeof o) memcpy(&o, options, options->size);
    o.size = sizeof o; /* the fields set below are read whatever the caller's size */
    uint32_t produced = auto_channels(&o);
    if ((occupancy && !(produced & CLVOX_CHANNEL_OCCUPANCY)) || (coverage && !(produced & CLVOX_CHANNEL_COVERAGE)))
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT,
                           "a %s buffer was given but the options do not produce that channel (channels 0x%x)",
                           occupancy && !(produced & CLVOX_CHANNEL_OCCUPANCY) ? "occupancy" : "coverage", produced);
    user_sink s = {.ctx = ctx, .dense_occ = occupancy, .dense_cov = coverage, .X = grid->dims[0], .Y = grid->dims[1]};
    return run_user(ctx, mesh, grid, options, 0, &s, stats);
}

clvox_status clvox_voxelize_palette_to_buffers(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                               const clvox_voxelize_options *options, uint16_t *element,
                                               size_t element_count, float *score, size_t score_count,
                                               clvox_stats *stats)
{
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!grid || (!element && !score))
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "NULL grid, or no output buffer at all");
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    if (options && options->size >= sizeof(size_t) && options->size <= sizeof o) memcpy(&o, options, options->size);
    if (!o.palette) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_voxelize_palette_to_buffers: no palette");
    clvox_status st = CLVOX_OK;
    if (element) st = check_dense(ctx, grid, element_count, "element");
    if (st == CLVOX_OK && score) st = check_dense(ctx, grid, score_count, "score");
    if (st != CLVOX_OK) return st;
    o.size = sizeof o;
    uint32_t forced = (element ? CLVOX_CHANNEL_ELEMENT : 0u) | (score ? CLVOX_CHANNEL_SCORE : 0u);
    if (!o.channels) o.channels = forced;
    user_sink s = {.ctx = ctx, .dense_element = element, .dense_score = score, .X = grid->dims[0], .Y = grid->dims[1]};
    return run_user(ctx, mesh, grid, &o, forced, &s, stats);
}

clvox_status clvox__voxelize_to_sink(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                     const clvox_voxelize_options *options, int counts, clvox__open_fn open_sink,
                                     clvox__sink_fn sink, void *user, uint32_t *channels, uint32_t *samples,
                                     clvox_stats *stats)
{
    sink_needs needs = {0, counts, channels, samples};
    return run(ctx, mesh, grid, options, &needs, open_sink, sink, user, stats);
}

const char *clvox_inside_name(clvox_inside inside)
{
    switch (inside) {
    case CLVOX_INSIDE_DEFAULT: return "default";
    case CLVOX_INSIDE_WINDING: return "winding";
    case CLVOX_INSIDE_WINDING_ABS: return "winding-abs";
    case CLVOX_INSIDE_PARITY: return "parity";
    default: return NULL;
    }
}
