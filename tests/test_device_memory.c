/* SPDX-License-Identifier: Apache-2.0 */
/* Device memory limits (src/core/device_memory.c): with the device's
 * largest buffer or global memory believed smaller (the test hooks
 * CLVOX_DEVICE_MAX_ALLOC / CLVOX_DEVICE_GLOBAL_MEM), the ray method casts
 * in smaller batches and the raster methods upload their tasks in windows,
 * and every mode gives the same voxels; where one voxel column does not
 * fit, the run fails with CLVOX_ERR_OUT_OF_MEMORY naming the device, and
 * the CLI exits non-zero and leaves no output file. The launch-group rule
 * (clvox__launch_slabs) for a GPU described by hand. */
#include "meshgen.h"
#include "spawn.h"
#include "test.h"
#include "core/internal.h"
#include "schedule.h"

#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static clvox_mesh *to_mesh(clvox_context *c, const tmesh *t)
{
    clvox_mesh *m = NULL;
    if (clvox_mesh_from_arrays(c, t->xyz, t->nv, t->tri, t->nt, &m) != CLVOX_OK)
        fprintf(stderr, "mesh_from_arrays: %s\n", clvox_context_error(c));
    return m;
}

static size_t nvox(const clvox_grid *g) { return (size_t)g->dims[0] * g->dims[1] * g->dims[2]; }

typedef struct result {
    clvox_status st;
    uint8_t *occ;
    float *cov;
    uint16_t *element;
    clvox_stats stats;
    char error[512];
} result;

static void result_free(result *r)
{
    free(r->occ);
    free(r->cov);
    free(r->element);
}

/* One run on a new context under `hooks` (the limits are read at context
 * creation): occupancy, and coverage or the palette's elements where asked. */
static result run(const clvox__test_hooks *hooks, const tmesh *t, const clvox_grid *g, const clvox_voxelize_options *o)
{
    result r;
    memset(&r, 0, sizeof r);
    r.stats = (clvox_stats)CLVOX_STATS_INIT;
    clvox__set_test_hooks(hooks);
    clvox_context *ctx = test_context();
    clvox_mesh *m = to_mesh(ctx, t);
    const size_t n = nvox(g);
    r.st = CLVOX_ERR_INTERNAL;
    if (m && o->palette) {
        r.element = calloc(n, sizeof *r.element);
        r.st = clvox_voxelize_palette_to_buffers(ctx, m, g, o, r.element, n, NULL, 0, &r.stats);
    } else if (m) {
        if (o->oversample) r.cov = calloc(n, sizeof *r.cov);
        else r.occ = calloc(n, 1);
        r.st = clvox_voxelize_to_buffers(ctx, m, g, o, r.occ, n, r.cov, r.cov ? n : 0, &r.stats);
    }
    snprintf(r.error, sizeof r.error, "%s", clvox_context_error(ctx));
    clvox_mesh_destroy(m);
    clvox_context_destroy(ctx);
    return r;
}

static int same(const result *a, const result *b, const clvox_grid *g)
{
    const size_t n = nvox(g);
    if ((a->occ == NULL) != (b->occ == NULL) || (a->occ && memcmp(a->occ, b->occ, n))) return 0;
    if ((a->cov == NULL) != (b->cov == NULL) || (a->cov && memcmp(a->cov, b->cov, n * sizeof *a->cov))) return 0;
    if ((a->element == NULL) != (b->element == NULL) ||
        (a->element && memcmp(a->element, b->element, n * sizeof *a->element)))
        return 0;
    return a->stats.filled_voxels == b->stats.filled_voxels && a->stats.rays == b->stats.rays &&
           a->stats.overflow_rays == b->stats.overflow_rays;
}

static clvox_grid grid_of(uint32_t n, double lo, double hi)
{
    const double l[3] = {lo, lo, lo}, h[3] = {hi, hi, hi};
    return test_grid(l, h, n, n, n);
}

/* Every mode under smaller limits: the same voxels, smaller batches. */
static void test_same_voxels(const tmesh *closed, const tmesh *open, const clvox_palette *pal)
{
    /* the raster methods: 192 triangles (a soup of 7 kB), tall slabs of
     * small slices, buffers of at most 8 kB */
    const tmesh box = tmesh_box_subdivided(-0.93, -0.71, -0.87, 0.97, 0.83, 0.91, 4);
    const double lo[3] = {-1.2, -1.2, -1.2}, hi[3] = {1.2, 1.2, 1.2};
    const clvox_grid g48 = test_grid(lo, hi, 48, 48, 48), tall = test_grid(lo, hi, 32, 32, 128);
    struct {
        const char *name;
        const tmesh *mesh;
        clvox_axis axis;
        clvox_inside inside;
        uint32_t oversample, hit_capacity;
        int palette;
        clvox_method method;
        clvox_mode mode;
    } cases[] = {
        {"parity x", closed, CLVOX_AXIS_X, CLVOX_INSIDE_PARITY, 0, 0, 0, CLVOX_METHOD_RAY, CLVOX_MODE_SOLID},
        {"parity z", closed, CLVOX_AXIS_Z, CLVOX_INSIDE_PARITY, 0, 0, 0, CLVOX_METHOD_RAY, CLVOX_MODE_SOLID},
        {"overflow y", closed, CLVOX_AXIS_Y, CLVOX_INSIDE_PARITY, 0, 2, 0, CLVOX_METHOD_RAY, CLVOX_MODE_SOLID},
        {"winding open", open, CLVOX_AXIS_X, CLVOX_INSIDE_WINDING, 0, 0, 0, CLVOX_METHOD_RAY, CLVOX_MODE_SOLID},
        {"coverage", closed, CLVOX_AXIS_Z, CLVOX_INSIDE_PARITY, 3, 0, 0, CLVOX_METHOD_RAY, CLVOX_MODE_SOLID},
        {"coverage overflow", closed, CLVOX_AXIS_X, CLVOX_INSIDE_PARITY, 2, 2, 0, CLVOX_METHOD_RAY, CLVOX_MODE_SOLID},
        {"palette", closed, CLVOX_AXIS_Y, CLVOX_INSIDE_PARITY, 2, 0, 1, CLVOX_METHOD_RAY, CLVOX_MODE_SOLID},
        {"tetra", &box, CLVOX_AXIS_X, CLVOX_INSIDE_PARITY, 0, 0, 0, CLVOX_METHOD_TETRA, CLVOX_MODE_SOLID},
        {"surface", &box, CLVOX_AXIS_X, CLVOX_INSIDE_PARITY, 0, 0, 0, CLVOX_METHOD_RAY, CLVOX_MODE_SURFACE},
        {"conservative", &box, CLVOX_AXIS_X, CLVOX_INSIDE_PARITY, 0, 0, 0, CLVOX_METHOD_RAY, CLVOX_MODE_CONSERVATIVE},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        const int raster = cases[i].method == CLVOX_METHOD_TETRA || cases[i].mode == CLVOX_MODE_SURFACE;
        const clvox_grid g = raster ? tall : g48;
        clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
        o.ray_axis = cases[i].axis;
        o.inside = cases[i].inside;
        o.oversample = cases[i].oversample;
        o.hit_capacity = cases[i].hit_capacity;
        o.palette = cases[i].palette ? pal : NULL;
        o.method = cases[i].method;
        o.mode = cases[i].mode;
        clvox__test_hooks h = {0};
        result a = run(&h, cases[i].mesh, &g, &o);
        CHECK_MSG(a.st == CLVOX_OK, "%s: %s", cases[i].name, a.error);
        /* the largest buffer: the mesh's buffers fit (28 kB), a slab's
         * 2304 rays' crossings do not (2 a ray: 36 kB; 32: 590 kB); the
         * global memory: a budget (3/4) of the mesh's buffers (estimated:
         * vertices, triangles, quadtree nodes and references, 8 kB for
         * caps and tables) and half the default run's batches: one set
         * of batches takes half of what the mesh leaves, two sets (several
         * batches a slab, in flight two at a time) a third each */
        const uint64_t leaves = a.stats.quadtree_leaves;
        const uint64_t mesh = (uint64_t)cases[i].mesh->nt * 12 + (uint64_t)cases[i].mesh->nv * 12 +
                              a.stats.quadtree_refs * 4 + (leaves + (leaves ? leaves - 1 : 0) / 3) * 16 + 8192;
        struct {
            uint64_t alloc, global;
        } limits[] = {{o.hit_capacity ? 28672 : raster ? 8192 : 131072, 0},
                      {0, (mesh + a.stats.peak_slab_bytes / 2) / 3 * 4}};
        for (int l = 0; l < 2; l++) {
            h.device_max_alloc = limits[l].alloc;
            h.device_global_mem = limits[l].global;
            result b = run(&h, cases[i].mesh, &g, &o);
            CHECK_MSG(b.st == CLVOX_OK, "%s, limit %d: %s", cases[i].name, l, b.error);
            CHECK_MSG(b.st != CLVOX_OK || same(&a, &b, &g), "%s, limit %d: other voxels", cases[i].name, l);
            if (b.st == CLVOX_OK && cases[i].method == CLVOX_METHOD_RAY && cases[i].mode == CLVOX_MODE_SOLID)
                CHECK_MSG(b.stats.peak_slab_bytes < a.stats.peak_slab_bytes,
                          "%s, limit %d: batches not smaller (%llu, %llu bytes)", cases[i].name, l,
                          (unsigned long long)b.stats.peak_slab_bytes, (unsigned long long)a.stats.peak_slab_bytes);
            result_free(&b);
        }
        result_free(&a);
    }
    tmesh_free((tmesh *)&box);
}

/* One column that does not fit: CLVOX_ERR_OUT_OF_MEMORY with the device named. */
static void test_too_small(void)
{
    tmesh box = tmesh_box(-1, -1, -1, 1, 1, 1);
    const tmesh *closed = &box;
    const clvox_grid g = grid_of(24, -1.2, 1.2);
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    o.oversample = 8; /* 64 rays x 32 crossings x 8 bytes: 16 KiB a column */
    clvox__test_hooks h = {0};
    h.device_max_alloc = 8192;
    result r = run(&h, closed, &g, &o);
    CHECK_STATUS(NULL, r.st, CLVOX_ERR_OUT_OF_MEMORY);
    CHECK_MSG(strstr(r.error, "device '") && strstr(r.error, "largest"), "message: %s", r.error);
    result_free(&r);
    h.device_max_alloc = 0;
    h.device_global_mem = 40000; /* 30 kB for the mesh, the planes and twice a 16 KiB column */
    r = run(&h, closed, &g, &o);
    CHECK_STATUS(NULL, r.st, CLVOX_ERR_OUT_OF_MEMORY);
    CHECK_MSG(strstr(r.error, "device '") && strstr(r.error, "of device memory"), "message: %s", r.error);
    result_free(&r);
    tmesh_free(&box);
}

/* The CLI: exit status, message, no output file. */
static void test_cli(void)
{
    tmesh box = tmesh_box(-1, -1, -1, 1, 1, 1);
    const tmesh *closed = &box;
    const char *bin = getenv("CLVOX_BIN");
    if (!bin) {
        printf("test_cli skipped: CLVOX_BIN is not set (make test sets it)\n");
        tmesh_free(&box);
        return;
    }
    char mesh[1024], out[1024], err[1024], log[1024];
    snprintf(mesh, sizeof mesh, "%s/devmem_sphere.off", test_tmpdir());
    snprintf(out, sizeof out, "%s/devmem_out.exr", test_tmpdir());
    snprintf(log, sizeof log, "%s/devmem.out", test_tmpdir());
    snprintf(err, sizeof err, "%s/devmem.err", test_tmpdir());
    CHECK(tmesh_write_off(closed, mesh) == 0);
    unlink(out);
    const char *args[] = {mesh, "-r", "24", "--oversample", "8", "-o", out, NULL};
    const char **argv = spawn_argv(bin, args);
    setenv("CLVOX_DEVICE_MAX_ALLOC", "8192", 1);
    spawn_result r;
    spawn_opts so = {.timeout_s = 120};
    int code = spawn_run_to(&r, argv, log, err, &so);
    unsetenv("CLVOX_DEVICE_MAX_ALLOC");
    CHECK_MSG(code != 0 && code != -1, "exit %d", code);
    CHECK_MSG(strstr(r.err, "device '") && strstr(r.err, "one voxel column"), "stderr: %s", r.err);
    struct stat sb;
    CHECK_MSG(stat(out, &sb) != 0, "%s exists", out);
    spawn_free(&r);
    /* and a limit that only shrinks the batches: success, the same file as without */
    char out2[1024];
    snprintf(out2, sizeof out2, "%s/devmem_out2.exr", test_tmpdir());
    const char *args2[] = {mesh, "-r", "24", "--oversample", "8", "-o", out2, NULL};
    const char **argv2 = spawn_argv(bin, args2);
    code = spawn_run_to(&r, argv2, log, err, &so);
    CHECK_MSG(code == 0, "exit %d: %s", code, r.err);
    spawn_free(&r);
    setenv("CLVOX_DEVICE_MAX_ALLOC", "65536", 1);
    code = spawn_run_to(&r, argv, log, err, &so);
    unsetenv("CLVOX_DEVICE_MAX_ALLOC");
    CHECK_MSG(code == 0, "exit %d: %s", code, r.err);
    spawn_free(&r);
    FILE *fa = fopen(out, "rb"), *fb = fopen(out2, "rb");
    int equal = fa && fb;
    while (equal) {
        int ca = getc(fa), cb = getc(fb);
        if (ca != cb) equal = 0;
        if (ca == EOF || cb == EOF) break;
    }
    CHECK_MSG(equal, "%s and %s differ", out, out2);
    if (fa) fclose(fa);
    if (fb) fclose(fb);
    free(argv);
    free(argv2);
    tmesh_free(&box);
}

/* The launch-group rule (clvox__launch_slabs, docs/design.md "Several
 * devices"): a GPU gets compute units x 2048 rays a call, bounded by the
 * slabs, its largest buffer and a quarter of its memory budget; CPU
 * devices, z rays and the raster methods one slab; the hook wins. */
static void test_launch_rule(void)
{
    clvox_context *dc = calloc(1, sizeof *dc);
    if (!dc) abort();
    snprintf(dc->device.type, sizeof dc->device.type, "gpu");
    dc->device.compute_units = 132; /* an H100: 270 336 rays a call */
    dc->device.global_mem_bytes = 80ull << 30;
    dc->device.max_alloc_bytes = 20ull << 30;
    clvox_grid g = {0};
    g.dims[0] = g.dims[1] = g.dims[2] = 1024;
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    const uint64_t bits[4] = {32u * 4 * 1024, 0, 0, 0}; /* occupancy rows of one slice */
    /* x rays at slab depth 16: 16 384 rays a slab -> 17 slabs */
    CHECK_MSG(clvox__launch_slabs(dc, 1, &o, &g, 16, bits) == 17, "gpu, x rays, depth 16: %u",
              clvox__launch_slabs(dc, 1, &o, &g, 16, bits));
    o.oversample = 4; /* 16 rays a column: 262 144 a slab -> 2 */
    CHECK_MSG(clvox__launch_slabs(dc, 1, &o, &g, 16, bits) == 2, "gpu, oversample 4: %u",
              clvox__launch_slabs(dc, 1, &o, &g, 16, bits));
    o.oversample = 0;
    o.ray_axis = CLVOX_AXIS_Z; /* a z ray crosses every slab */
    CHECK(clvox__launch_slabs(dc, 1, &o, &g, 16, bits) == 1);
    o.ray_axis = CLVOX_AXIS_DEFAULT;
    CHECK(clvox__launch_slabs(dc, 0, &o, &g, 16, bits) == 1); /* tetra, surface */
    CHECK(clvox__launch_slabs(dc, 1, &o, &g, 1000, bits) == 1); /* 2 slabs of 1000: 1 ray in 1000 each */
    g.dims[2] = 40; /* 3 slabs */
    CHECK(clvox__launch_slabs(dc, 1, &o, &g, 16, bits) == 3);
    g.dims[2] = 1024;
    /* 2 MiB of planes a slab; budget 3/4 of 40 MiB, a quarter of it 7.5 MiB: 3 slabs */
    dc->device.global_mem_bytes = 40ull << 20;
    CHECK_MSG(clvox__launch_slabs(dc, 1, &o, &g, 16, bits) == 3, "gpu, 40 MiB: %u",
              clvox__launch_slabs(dc, 1, &o, &g, 16, bits));
    dc->device.global_mem_bytes = 80ull << 30;
    dc->device.max_alloc_bytes = 5ull << 20; /* two 2 MiB slabs a buffer */
    CHECK(clvox__launch_slabs(dc, 1, &o, &g, 16, bits) == 2);
    dc->device.max_alloc_bytes = 20ull << 30;
    snprintf(dc->device.type, sizeof dc->device.type, "cpu");
    CHECK(clvox__launch_slabs(dc, 1, &o, &g, 16, bits) == 1);
    clvox__test_hooks h = *clvox__hooks();
    h.launch_slabs = 5;
    clvox__set_test_hooks(&h);
    CHECK(clvox__launch_slabs(dc, 0, &o, &g, 16, bits) == 5);
    h.launch_slabs = 0;
    clvox__set_test_hooks(&h);
    /* the window: two groups with one device, 2 groups or 4 slabs a device */
    CHECK(clvox__sched_window(1, 1, 1) == 2 && clvox__sched_window(1, 17, 1) == 34);
    CHECK(clvox__sched_window(2, 1, 1) == 8 && clvox__sched_window(2, 3, 1) == 12);
    CHECK(clvox__sched_window(1, 17, 64ull << 20) == 4); /* 256 MiB of 64 MiB slabs */
    free(dc);
}

int main(void)
{
    clvox__test_hooks none = {0};
    clvox__set_test_hooks(&none); /* the environment's limits are not this test's */
    tmesh closed = tmesh_sphere(0, 0, 0, 1.0, 24);
    tmesh open = tmesh_sphere(0, 0, 0, 1.0, 24);
    open.nt -= 8; /* a hole: the winding caps close it */
    clvox_context *ctx = test_context();
    clvox_palette *pal = NULL;
    CHECK_OK(ctx, clvox_palette_builtin(ctx, "paper46", &pal));
    test_same_voxels(&closed, &open, pal);
    test_too_small();
    test_launch_rule();
    clvox_palette_destroy(pal);
    clvox_context_destroy(ctx);
    test_cli();
    tmesh_free(&closed);
    tmesh_free(&open);
    return test_report();
}
