/* SPDX-License-Identifier: Apache-2.0 */
/* Several devices in one run (issue 34; docs/design.md "Several devices";
 * src/schedule.c). The program runs itself once per PoCL device pair --
 * POCL_DEVICES = "basic basic" (two equal single-threaded devices),
 * "pthread basic" (two of different speed), "pthread pthread" -- and in
 * each child checks, through the public API:
 *  - every mode gives the same volume, byte for byte, on one device and on
 *    the set ("all"), at slab depths 1, 3 and auto, on closed, open and
 *    unevenly expensive meshes; every slab reaches the callback once, in
 *    increasing z, contiguous;
 *  - the mesh is prepared once on the host: in every mode the set's
 *    first device takes the mesh to grid space as often as one device
 *    alone, the second never (it copies the first's buffers);
 *  - a device failing at its 1st, 2nd or last slab (CLVOX_TEST_FAIL_DEVICE
 *    through clvox__set_test_hooks): the run succeeds with the same volume
 *    and one warning naming it; alone, or with every device failing, the
 *    run fails; a device whose kernel build fails is left out of the set;
 *  - a device failing its preparation ("K:prepare"), in the ray, tetra,
 *    surface and conservative modes: the other device does the run alone,
 *    preparing the mesh itself when the failing one was the first;
 *  - the reorder buffer stays within reorder_slabs whatever the slices;
 *  - a cancelled run returns CLVOX_ERR_CANCELLED with its threads joined;
 *  - under "basic basic", the command-line tool: --device all writes the
 *    same EXR and .npy files as one device, a failing device is a warning,
 *    a failing run keeps an older file, --json lists the devices,
 *    --list-devices shows fp64 and the hint.
 * The parent adds the children's counts up and checks that the reorder
 * buffer's size does not depend on how unequal the devices are. */
#include "core/environment.h"
#include "core/internal.h" /* clvox_context.grid_space_count */
#include "meshgen.h"
#include "spawn.h"
#include "test.h"
#include "testio.h"

#include <limits.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

extern char **environ;

#define CHILD_TIMEOUT_S 600.0
#define CLI_TIMEOUT_S 120.0

static const char *const g_configs[] = {"basic basic", "pthread basic", "pthread pthread"};
#define NCONFIG (sizeof g_configs / sizeof g_configs[0])

static const char *g_config;              /* the child's POCL_DEVICES */
static clvox_context *g_one, *g_all;      /* device "0"; device "all" */
static clvox__test_hooks g_hooks;         /* the hooks with no device failing */
static clvox_palette *g_palette;

/* ---- environment for children ---- */

/* environ without the variables named in drop (NULL-terminated), plus add. */
static const char **child_env(const char *const *drop, const char *const *add)
{
    size_t n = 0, m = 0;
    while (environ[n]) n++;
    while (add && add[m]) m++;
    const char **env = malloc((n + m + 1) * sizeof *env);
    if (!env) abort();
    size_t k = 0;
    for (size_t i = 0; i < n; i++) {
        int skip = 0;
        for (size_t j = 0; drop && drop[j]; j++) {
            size_t len = strlen(drop[j]);
            if (strncmp(environ[i], drop[j], len) == 0 && environ[i][len] == '=') skip = 1;
        }
        if (!skip) env[k++] = environ[i];
    }
    for (size_t j = 0; j < m; j++) env[k++] = add[j];
    env[k] = NULL;
    return env;
}

/* ---- capturing a run's slabs ---- */

typedef struct capture {
    uint32_t X, Y, Z;
    size_t n;          /* X*Y*Z */
    uint8_t *occ;
    float *cov, *score;
    uint16_t *elem;
    unsigned present;  /* CLVOX_CHANNEL_* seen */
    uint32_t next_z;   /* the next slice expected */
    uint32_t calls, out_of_order, bad_extent, max_nz;
    uint32_t *seen;    /* per slice: how many times it arrived */
    int cancel_at;     /* progress: return 0 at this call (0: never) */
    int progress_calls;
} capture;

static void capture_init(capture *c, const clvox_grid *g)
{
    memset(c, 0, sizeof *c);
    c->X = g->dims[0], c->Y = g->dims[1], c->Z = g->dims[2];
    c->n = (size_t)c->X * c->Y * c->Z;
    c->occ = calloc(c->n, 1);
    c->cov = calloc(c->n, sizeof *c->cov);
    c->score = calloc(c->n, sizeof *c->score);
    c->elem = calloc(c->n, sizeof *c->elem);
    c->seen = calloc(c->Z, sizeof *c->seen);
    if (!c->occ || !c->cov || !c->score || !c->elem || !c->seen) abort();
}

static void capture_free(capture *c)
{
    free(c->occ), free(c->cov), free(c->score), free(c->elem), free(c->seen);
    memset(c, 0, sizeof *c);
}

static int on_slab(void *user, const clvox_slab *s)
{
    capture *c = user;
    c->calls++;
    if (s->z0 != c->next_z) c->out_of_order++;
    if (s->nz == 0 || s->z0 >= c->Z || s->nz > c->Z - s->z0) {
        c->bad_extent++;
        return 0;
    }
    if (s->nz > c->max_nz) c->max_nz = s->nz;
    c->next_z = s->z0 + s->nz;
    size_t at = (size_t)s->z0 * c->X * c->Y, cnt = (size_t)s->nz * c->X * c->Y;
    for (uint32_t z = s->z0; z < s->z0 + s->nz; z++) c->seen[z]++;
    if (s->occupancy) c->present |= CLVOX_CHANNEL_OCCUPANCY, memcpy(c->occ + at, s->occupancy, cnt);
    if (s->coverage) c->present |= CLVOX_CHANNEL_COVERAGE, memcpy(c->cov + at, s->coverage, cnt * sizeof(float));
    if (s->element) c->present |= CLVOX_CHANNEL_ELEMENT, memcpy(c->elem + at, s->element, cnt * sizeof(uint16_t));
    if (s->score) c->present |= CLVOX_CHANNEL_SCORE, memcpy(c->score + at, s->score, cnt * sizeof(float));
    return 0;
}

static int on_progress(void *user, double fraction)
{
    (void)fraction;
    capture *c = user;
    c->progress_calls++;
    return !(c->cancel_at && c->progress_calls >= c->cancel_at);
}

static clvox_status run_capture(clvox_context *ctx, const clvox_mesh *m, const clvox_grid *g,
                                const clvox_voxelize_options *o, capture *c, clvox_stats *st)
{
    clvox_voxelize_options oo = *o;
    if (c->cancel_at) oo.progress = on_progress, oo.progress_user = c;
    return clvox_voxelize_slabs(ctx, m, g, &oo, on_slab, c, st);
}

/* Every slab once, in increasing z, contiguous, the whole volume. */
static void check_order(const capture *c, const char *what)
{
    CHECK_MSG(c->out_of_order == 0 && c->bad_extent == 0, "%s: %u slabs out of order, %u with a bad extent", what,
              c->out_of_order, c->bad_extent);
    uint32_t wrong = 0;
    for (uint32_t z = 0; z < c->Z; z++) wrong += c->seen[z] != 1;
    CHECK_MSG(wrong == 0 && c->next_z == c->Z, "%s: %u slices not seen exactly once (ended at %u of %u)", what, wrong,
              c->next_z, c->Z);
}

/* b equal to a, channel by channel. */
static void check_same(const capture *a, const capture *b, const char *what)
{
    CHECK_MSG(a->present == b->present && a->present, "%s: channels %#x vs %#x", what, a->present, b->present);
    size_t diff = 0, first = SIZE_MAX;
    for (size_t i = 0; i < a->n; i++) {
        int d = a->occ[i] != b->occ[i] || a->elem[i] != b->elem[i] ||
                memcmp(&a->cov[i], &b->cov[i], sizeof(float)) || memcmp(&a->score[i], &b->score[i], sizeof(float));
        if (d && first == SIZE_MAX) first = i;
        diff += (size_t)d;
    }
    CHECK_MSG(diff == 0, "%s: %zu voxels differ from the one-device volume (first at index %zu)", what, diff, first);
}

/* The device shares of a run on g_all add up to the volume. */
static void check_shares(const clvox_stats *st, uint32_t Z, const char *what)
{
    uint64_t slices = 0;
    uint32_t slabs = 0;
    for (uint32_t i = 0; i < st->device_count && i < CLVOX_MAX_DEVICES; i++)
        slices += st->devices[i].slices, slabs += st->devices[i].slabs;
    uint32_t nslabs = st->slab_depth ? (Z + st->slab_depth - 1) / st->slab_depth : 0;
    CHECK_MSG(st->device_count == 2 && slices == Z && slabs == nslabs,
              "%s: %u devices, %llu slices of %u, %u slabs of %u", what, st->device_count,
              (unsigned long long)slices, Z, slabs, nslabs);
    CHECK_MSG(st->reorder_peak <= st->reorder_slabs && st->reorder_slabs >= 3,
              "%s: reorder buffer held %u of %u slabs", what, st->reorder_peak, st->reorder_slabs);
}

static void set_fail(int k, unsigned n)
{
    clvox__test_hooks h = g_hooks;
    h.fail_device_k = k;
    h.fail_device_n = n ? n : CLVOX__FAIL_BUILD; /* 0: the build, as in CLVOX_TEST_FAIL_DEVICE */
    clvox__set_test_hooks(&h);
}

static void clear_fail(void) { clvox__set_test_hooks(&g_hooks); }

static void set_fail_prepare(int k)
{
    clvox__test_hooks h = g_hooks;
    h.fail_device_k = k;
    h.fail_device_n = CLVOX__FAIL_PREPARE;
    clvox__set_test_hooks(&h);
}

/* Meshes taken to grid space on the host (the host preparation): by the
 * one-device context, by each device of the set. */
typedef struct prep_count {
    uint64_t one, dev[2];
} prep_count;

static prep_count prep_now(void)
{
    prep_count c = {g_one->grid_space_count, {g_all->member[0]->grid_space_count, g_all->member[1]->grid_space_count}};
    return c;
}

static prep_count prep_since(prep_count before)
{
    prep_count c = prep_now();
    c.one -= before.one, c.dev[0] -= before.dev[0], c.dev[1] -= before.dev[1];
    return c;
}

/* ---- meshes ---- */

typedef struct mesh_case {
    const char *name;
    clvox_mesh *mesh;
    clvox_grid grid;
} mesh_case;

static clvox_mesh *from_tmesh(const tmesh *t)
{
    clvox_mesh *m = NULL;
    CHECK_OK(g_one, clvox_mesh_from_arrays(g_one, t->xyz, t->nv, t->tri, t->nt, &m));
    return m;
}

/* Dense at the bottom, sparse above: a 16,000-triangle sphere under a
 * 12-triangle box, so that the low slabs cost far more than the high ones. */
static tmesh lopsided(void)
{
    tmesh t = tmesh_sphere(0.5, 0.5, 0.16, 0.13, 64);
    tmesh box = tmesh_box(0.2, 0.25, 0.36, 0.8, 0.75, 0.96);
    tmesh_append(&t, &box);
    tmesh_free(&box);
    return t;
}

static const double g_lo[3] = {0, 0, 0}, g_hi[3] = {1, 1, 1};

static int load_case(mesh_case *mc, const char *file, uint32_t res)
{
    char path[PATH_MAX];
    snprintf(path, sizeof path, "data/meshes/%s", file);
    mc->name = file;
    if (access(path, R_OK) != 0) {
        printf("skipped %s: not found (scripts/fetch_meshes.sh fetches it)\n", path);
        return 0;
    }
    mc->mesh = NULL;
    CHECK_OK(g_one, clvox_mesh_load(g_one, path, &mc->mesh));
    if (!mc->mesh) return 0;
    mc->grid = test_padded_grid(g_one, clvox_mesh_get_report(mc->mesh), res);
    return 1;
}

/* ---- modes ---- */

typedef struct mode_case {
    const char *name;
    clvox_voxelize_options o;
} mode_case;

static size_t make_modes(mode_case *mc)
{
    size_t n = 0;
    clvox_voxelize_options base = CLVOX_VOXELIZE_OPTIONS_INIT;
    mc[n].name = "ray parity", mc[n].o = base, mc[n].o.inside = CLVOX_INSIDE_PARITY, n++;
    mc[n].name = "ray winding", mc[n].o = base, n++;
    mc[n].name = "tetra", mc[n].o = base, mc[n].o.method = CLVOX_METHOD_TETRA, n++;
    mc[n].name = "coverage", mc[n].o = base, mc[n].o.oversample = 2, n++;
    mc[n].name = "stochastic coverage", mc[n].o = base, mc[n].o.oversample = 2, mc[n].o.stochastic = 1;
    mc[n].o.seed = 12345, n++;
    mc[n].name = "palette", mc[n].o = base, mc[n].o.palette = g_palette, mc[n].o.oversample = 2, n++;
    mc[n].name = "surface", mc[n].o = base, mc[n].o.mode = CLVOX_MODE_SURFACE, n++;
    mc[n].name = "conservative", mc[n].o = base, mc[n].o.mode = CLVOX_MODE_CONSERVATIVE, n++;
    return n;
}

/* ---- 1. the same volume on one device and on the set ---- */

static void test_same_volume(const mesh_case *meshes, size_t nmesh)
{
    mode_case modes[8];
    size_t nmode = make_modes(modes);
    static const uint32_t depths[] = {1, 3, 0};
    for (size_t i = 0; i < nmesh; i++) {
        const mesh_case *mc = &meshes[i];
        const uint32_t Z = mc->grid.dims[2];
        for (size_t k = 0; k < nmode; k++) {
            capture ref;
            capture_init(&ref, &mc->grid);
            clvox_stats rs = CLVOX_STATS_INIT;
            char what[256];
            snprintf(what, sizeof what, "[%s] %s, %s, one device", g_config, mc->name, modes[k].name);
            prep_count p0 = prep_now();
            CHECK_OK(g_one, run_capture(g_one, mc->mesh, &mc->grid, &modes[k].o, &ref, &rs));
            const uint64_t once = prep_since(p0).one;
            CHECK_MSG(once >= 1, "%s: the mesh was never taken to grid space", what);
            check_order(&ref, what);
            CHECK_MSG(rs.device_count == 1 && rs.reorder_slabs == 2 && rs.reorder_peak <= 2,
                      "%s: %u devices, reorder %u/%u", what, rs.device_count, rs.reorder_peak, rs.reorder_slabs);
            for (size_t d = 0; d < sizeof depths / sizeof depths[0]; d++) {
                clvox_voxelize_options o = modes[k].o;
                o.slab_depth = depths[d];
                snprintf(what, sizeof what, "[%s] %s, %s, two devices, slab depth %u", g_config, mc->name,
                         modes[k].name, depths[d]);
                capture c;
                capture_init(&c, &mc->grid);
                clvox_stats st = CLVOX_STATS_INIT;
                p0 = prep_now();
                CHECK_OK(g_all, run_capture(g_all, mc->mesh, &mc->grid, &o, &c, &st));
                /* the host work once, on the first device; the second copies */
                prep_count p = prep_since(p0);
                CHECK_MSG(p.dev[0] == once && p.dev[1] == 0,
                          "%s: mesh taken to grid space %llu times on device 0 and %llu on device 1 (one device: %llu)",
                          what, (unsigned long long)p.dev[0], (unsigned long long)p.dev[1], (unsigned long long)once);
                check_order(&c, what);
                check_same(&ref, &c, what);
                check_shares(&st, Z, what);
                CHECK_MSG(st.filled_voxels == rs.filled_voxels && st.coverage_sum == rs.coverage_sum &&
                              st.rays == rs.rays,
                          "%s: filled %llu vs %llu, coverage %.17g vs %.17g, rays %llu vs %llu", what,
                          (unsigned long long)st.filled_voxels, (unsigned long long)rs.filled_voxels, st.coverage_sum,
                          rs.coverage_sum, (unsigned long long)st.rays, (unsigned long long)rs.rays);
                uint32_t want = depths[d] ? depths[d] : (Z + 15) / 16; /* auto: at most Z / (8 devices) */
                CHECK_MSG(depths[d] ? st.slab_depth == want && c.max_nz == want : st.slab_depth <= want,
                          "%s: slab depth %u (largest slab %u), expected %s %u", what, st.slab_depth, c.max_nz,
                          depths[d] ? "" : "at most", want);
                CHECK_MSG(!*clvox_context_warnings(g_all), "%s: warnings '%s'", what, clvox_context_warnings(g_all));
                capture_free(&c);
            }
            capture_free(&ref);
        }
    }
}

/* ---- 2. failing devices ---- */

/* Device k of two fails at its n-th slab; n = 0: at its last (found from a
 * run without failure, again from the failed run's count when the device
 * took fewer slabs this time). */
/* The runs of the failure and cancelling tests: slabs of one slice, enough
 * work in each that both devices take some. */
static clvox_voxelize_options fault_options(void)
{
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    o.slab_depth = 1;
    o.oversample = 3;
    return o;
}

static void fail_one_of_two(const mesh_case *mc, const capture *ref, int k, unsigned n)
{
    clvox_voxelize_options o = fault_options();
    unsigned at = n;
    char what[256];
    if (!at) {
        clvox_stats st = CLVOX_STATS_INIT;
        capture c;
        capture_init(&c, &mc->grid);
        CHECK_OK(g_all, run_capture(g_all, mc->mesh, &mc->grid, &o, &c, &st));
        capture_free(&c);
        at = st.devices[k].slabs + st.devices[k].discarded_slabs;
        CHECK_MSG(at >= 3, "[%s] device %d took %u slabs of %u: too few for a 'last' distinct from the 2nd",
                  g_config, k, at, mc->grid.dims[2]);
    }
    int failed = 0;
    for (int attempt = 0; attempt < 8 && !failed; attempt++) {
        snprintf(what, sizeof what, "[%s] %s, device %d failing at its %s slab (%u)", g_config, mc->name, k,
                 n == 1 ? "1st" : n == 2 ? "2nd" : "last", at);
        capture c;
        capture_init(&c, &mc->grid);
        clvox_stats st = CLVOX_STATS_INIT;
        set_fail(k, at);
        clvox_status s = run_capture(g_all, mc->mesh, &mc->grid, &o, &c, &st);
        clear_fail();
        CHECK_MSG(s == CLVOX_OK, "%s: %s: %s", what, clvox_status_string(s), clvox_context_error(g_all));
        failed = st.devices[k].failed;
        if (failed) {
            CHECK_MSG(failed && !st.devices[1 - k].failed, "%s: failed flags %d %d", what, st.devices[0].failed,
                      st.devices[1].failed);
            check_order(&c, what);
            check_same(ref, &c, what);
            const char *w = clvox_context_warnings(g_all);
            char name[32];
            snprintf(name, sizeof name, "device %d '", k);
            CHECK_MSG(strstr(w, name) == w && strstr(w, "failed") && count_lines(w) == 1,
                      "%s: warnings '%s'", what, w);
            uint64_t slices = 0;
            for (int e = 0; e < 2; e++) slices += st.devices[e].slices;
            CHECK_MSG(slices == mc->grid.dims[2], "%s: %llu slices written of %u", what, (unsigned long long)slices,
                      mc->grid.dims[2]);
        } else if (!n) {
            /* it took fewer slabs this time: its last is this run's count
             * (one earlier after a few tries: the shares vary with the load) */
            at = st.devices[k].slabs + st.devices[k].discarded_slabs;
            if (attempt >= 3 && at > 1) at--;
            if (!at) at = 1;
        }
        capture_free(&c);
    }
    CHECK_MSG(failed, "[%s] device %d never reached the slab it was to fail at (%u)", g_config, k, at);
    /* the next run has no warning left */
    capture c;
    capture_init(&c, &mc->grid);
    CHECK_OK(g_all, run_capture(g_all, mc->mesh, &mc->grid, &o, &c, NULL));
    CHECK_MSG(!*clvox_context_warnings(g_all), "[%s] after a failure: warnings '%s'", g_config,
              clvox_context_warnings(g_all));
    check_same(ref, &c, "after a device failure");
    capture_free(&c);
}

static void test_failures(const mesh_case *mc)
{
    clvox_voxelize_options o = fault_options();
    capture ref;
    capture_init(&ref, &mc->grid);
    CHECK_OK(g_one, run_capture(g_one, mc->mesh, &mc->grid, &o, &ref, NULL));
    /* both devices' kernels compiled (PoCL compiles them on first use) */
    capture warm;
    capture_init(&warm, &mc->grid);
    CHECK_OK(g_all, run_capture(g_all, mc->mesh, &mc->grid, &o, &warm, NULL));
    capture_free(&warm);

    for (int k = 0; k < 2; k++) {
        fail_one_of_two(mc, &ref, k, 1);
        fail_one_of_two(mc, &ref, k, 2);
        fail_one_of_two(mc, &ref, k, 0);
    }

    /* one device: its failure is the run's */
    for (unsigned n = 1; n <= 2; n++) {
        capture c;
        capture_init(&c, &mc->grid);
        set_fail(0, n);
        clvox_status s = run_capture(g_one, mc->mesh, &mc->grid, &o, &c, NULL);
        clear_fail();
        CHECK_MSG(s == CLVOX_ERR_OPENCL && strstr(clvox_context_error(g_one), "CLVOX_TEST_FAIL_DEVICE"),
                  "[%s] one device failing at slab %u: %s: '%s'", g_config, n, clvox_status_string(s),
                  clvox_context_error(g_one));
        CHECK_MSG(c.calls < n, "[%s] one device failing at slab %u: %u slabs reached the callback", g_config, n,
                  c.calls);
        capture_free(&c);
    }
    /* every device of two */
    {
        capture c;
        capture_init(&c, &mc->grid);
        clvox_stats st = CLVOX_STATS_INIT;
        set_fail(CLVOX__FAIL_EVERY_DEVICE, 2);
        clvox_status s = run_capture(g_all, mc->mesh, &mc->grid, &o, &c, &st);
        clear_fail();
        CHECK_MSG(s == CLVOX_ERR_OPENCL && strstr(clvox_context_error(g_all), "every device failed"),
                  "[%s] every device failing: %s: '%s'", g_config, clvox_status_string(s), clvox_context_error(g_all));
        CHECK_MSG(st.devices[0].failed && st.devices[1].failed, "[%s] every device failing: flags %d %d", g_config,
                  st.devices[0].failed, st.devices[1].failed);
        capture_free(&c);
    }
    /* both contexts still work */
    for (int i = 0; i < 2; i++) {
        clvox_context *ctx = i ? g_all : g_one;
        capture c;
        capture_init(&c, &mc->grid);
        CHECK_OK(ctx, run_capture(ctx, mc->mesh, &mc->grid, &o, &c, NULL));
        check_order(&c, "after failed runs");
        check_same(&ref, &c, "after failed runs");
        capture_free(&c);
    }

    /* kernel build failures at context creation */
    for (int k = 0; k < 2; k++) {
        clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
        co.device = "all";
        clvox_context *ctx = NULL;
        set_fail(k, 0);
        clvox_status s = clvox_context_create(&co, &ctx);
        clear_fail();
        CHECK_MSG(s == CLVOX_OK, "[%s] build of device %d failing: %s: %s", g_config, k, clvox_status_string(s),
                  clvox_context_error(ctx));
        const char *w = clvox_context_warnings(ctx);
        char name[32];
        snprintf(name, sizeof name, "device %d '", k);
        CHECK_MSG(clvox_context_device_count(ctx) == 1 && strstr(w, name) == w && strstr(w, "left out") &&
                      count_lines(w) == 1,
                  "[%s] build of device %d failing: %zu devices, warnings '%s'", g_config, k,
                  clvox_context_device_count(ctx), w);
        if (s == CLVOX_OK) {
            capture c;
            capture_init(&c, &mc->grid);
            clvox_stats st = CLVOX_STATS_INIT;
            CHECK_OK(ctx, run_capture(ctx, mc->mesh, &mc->grid, &o, &c, &st));
            check_same(&ref, &c, "on the device left");
            CHECK(st.device_count == 1);
            /* the creation's warning stays with the context */
            CHECK_MSG(strstr(clvox_context_warnings(ctx), name) != NULL, "warnings after a run: '%s'",
                      clvox_context_warnings(ctx));
            capture_free(&c);
        }
        clvox_context_destroy(ctx);
    }
    {
        clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
        co.device = "all";
        clvox_context *ctx = NULL;
        set_fail(CLVOX__FAIL_EVERY_DEVICE, 0);
        clvox_status s = clvox_context_create(&co, &ctx);
        clear_fail();
        CHECK_MSG(s == CLVOX_ERR_KERNEL_BUILD && strstr(clvox_context_error(ctx), "none of the 2 devices"),
                  "[%s] every build failing: %s: '%s'", g_config, clvox_status_string(s), clvox_context_error(ctx));
        clvox_context_destroy(ctx);
    }
    capture_free(&ref);
}

/* A device failing its preparation, in the modes whose methods copy the
 * first device's preparation: the run goes on the other device alone (the
 * same volume, one warning); when the first device failed, the second
 * prepared the mesh itself. Alone, or with every device failing, the run
 * fails. */
static void test_prepare_failures(const mesh_case *mc)
{
    mode_case modes[8];
    const size_t nall = make_modes(modes);
    size_t n = 0;
    for (size_t i = 0; i < nall; i++)
        if (!strcmp(modes[i].name, "ray parity") || !strcmp(modes[i].name, "tetra") ||
            !strcmp(modes[i].name, "surface") || !strcmp(modes[i].name, "conservative"))
            modes[n++] = modes[i];
    CHECK(n == 4);
    for (size_t i = 0; i < n; i++) {
        char what[256];
        capture ref;
        capture_init(&ref, &mc->grid);
        prep_count p0 = prep_now();
        CHECK_OK(g_one, run_capture(g_one, mc->mesh, &mc->grid, &modes[i].o, &ref, NULL));
        const uint64_t once = prep_since(p0).one;
        for (int k = 0; k < 2; k++) {
            snprintf(what, sizeof what, "[%s] %s, %s, device %d failing its preparation", g_config, mc->name,
                     modes[i].name, k);
            capture c;
            capture_init(&c, &mc->grid);
            clvox_stats st = CLVOX_STATS_INIT;
            set_fail_prepare(k);
            p0 = prep_now();
            clvox_status s = run_capture(g_all, mc->mesh, &mc->grid, &modes[i].o, &c, &st);
            prep_count p = prep_since(p0);
            clear_fail();
            CHECK_MSG(s == CLVOX_OK, "%s: %s: %s", what, clvox_status_string(s), clvox_context_error(g_all));
            check_order(&c, what);
            check_same(&ref, &c, what);
            const char *w = clvox_context_warnings(g_all);
            char name[32];
            snprintf(name, sizeof name, "device %d '", k);
            CHECK_MSG(strstr(w, name) == w && strstr(w, "left out") && strstr(w, "CLVOX_TEST_FAIL_DEVICE") &&
                          count_lines(w) == 1,
                      "%s: warnings '%s'", what, w);
            CHECK_MSG(st.device_count == 2 && st.devices[k].left_out && st.devices[k].slabs == 0 &&
                          st.devices[1 - k].slices == mc->grid.dims[2],
                      "%s: %u devices, device %d left out %d with %u slabs, the other %llu slices", what,
                      st.device_count, k, st.devices[k].left_out, st.devices[k].slabs,
                      (unsigned long long)st.devices[1 - k].slices);
            /* device 0 prepared before failing; device 1 copied it, or had no lead and prepared itself */
            CHECK_MSG(p.dev[0] == once && p.dev[1] == (k == 0 ? once : 0),
                      "%s: mesh taken to grid space %llu times on device 0 and %llu on device 1 (one device: %llu)",
                      what, (unsigned long long)p.dev[0], (unsigned long long)p.dev[1], (unsigned long long)once);
            capture_free(&c);
        }
        /* alone, or every device: the run's error */
        for (int every = 0; every < 2; every++) {
            clvox_context *ctx = every ? g_all : g_one;
            capture c;
            capture_init(&c, &mc->grid);
            set_fail_prepare(every ? CLVOX__FAIL_EVERY_DEVICE : 0);
            clvox_status s = run_capture(ctx, mc->mesh, &mc->grid, &modes[i].o, &c, NULL);
            clear_fail();
            const char *e = clvox_context_error(ctx);
            CHECK_MSG(s == CLVOX_ERR_OPENCL && strstr(e, "CLVOX_TEST_FAIL_DEVICE") && c.calls == 0 &&
                          (!every || strstr(e, "no device could prepare the run")),
                      "[%s] %s, %s: %s failing its preparation: %s: '%s', %u slabs", g_config, mc->name,
                      modes[i].name, every ? "every device" : "one device", clvox_status_string(s), e, c.calls);
            capture_free(&c);
        }
        capture_free(&ref);
    }
}

/* ---- 3. the reorder buffer's bound ---- */

static void test_reorder_bound(clvox_mesh *m)
{
    uint32_t slabs[2] = {0, 0}, peak[2] = {0, 0};
    uint64_t bytes[2] = {0, 0};
    static const uint32_t Zs[2] = {64, 1024};
    for (int i = 0; i < 2; i++) {
        clvox_grid g = test_grid(g_lo, g_hi, 16, 16, Zs[i]);
        clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
        o.slab_depth = 1;
        capture c;
        capture_init(&c, &g);
        clvox_stats st = CLVOX_STATS_INIT;
        char what[128];
        snprintf(what, sizeof what, "[%s] reorder, Z = %u", g_config, Zs[i]);
        CHECK_OK(g_all, run_capture(g_all, m, &g, &o, &c, &st));
        check_order(&c, what);
        check_shares(&st, Zs[i], what);
        slabs[i] = st.reorder_slabs, bytes[i] = st.reorder_bytes, peak[i] = st.reorder_peak;
        capture_free(&c);
    }
    CHECK_MSG(slabs[0] == slabs[1] && bytes[0] == bytes[1] && bytes[0] > 0,
              "[%s] reorder buffer: %u slabs, %llu bytes at Z = 64; %u, %llu at Z = 1024", g_config, slabs[0],
              (unsigned long long)bytes[0], slabs[1], (unsigned long long)bytes[1]);
    /* for the parent: the same under every pair of devices */
    printf("reorder slabs=%u bytes=%llu peak=%u,%u\n", slabs[1], (unsigned long long)bytes[1], peak[0], peak[1]);
}

/* ---- 4. cancelling ---- */

static int thread_count(void)
{
    char *s = read_all("/proc/self/status");
    const char *t = strstr(s, "\nThreads:");
    int n = t ? atoi(t + 9) : -1;
    free(s);
    return n;
}

/* The thread count once it falls to at most `before`, or after about 10 s.
 * A thread the run joined can still be listed for a moment: the kernel
 * wakes pthread_join before it removes the thread from /proc (CI saw 4
 * against 3 once). A thread the run leaked stays, so the check still fails. */
static int threads_settled(int before)
{
    int n = thread_count();
    for (int i = 0; i < 1000 && n > before; i++) {
        struct timespec ts = {0, 10 * 1000 * 1000};
        nanosleep(&ts, NULL);
        n = thread_count();
    }
    return n;
}

static void test_cancel(const mesh_case *mc)
{
    clvox_voxelize_options o = fault_options();
    capture ref;
    capture_init(&ref, &mc->grid);
    CHECK_OK(g_one, run_capture(g_one, mc->mesh, &mc->grid, &o, &ref, NULL));
    for (int at = 1; at <= 2; at++) {
        int before = thread_count();
        capture c;
        capture_init(&c, &mc->grid);
        c.cancel_at = at;
        clvox_status s = run_capture(g_all, mc->mesh, &mc->grid, &o, &c, NULL);
        CHECK_MSG(s == CLVOX_ERR_CANCELLED, "[%s] cancelled at progress call %d: %s: %s", g_config, at,
                  clvox_status_string(s), clvox_context_error(g_all));
        CHECK_MSG(c.progress_calls == at && c.next_z < c.Z, "[%s] cancelled at call %d: %d calls, %u of %u slices",
                  g_config, at, c.progress_calls, c.next_z, c.Z);
        int after = threads_settled(before);
        CHECK_MSG(after <= before, "[%s] threads: %d before the cancelled run, %d after", g_config, before, after);
        capture_free(&c);
        capture_init(&c, &mc->grid);
        CHECK_OK(g_all, run_capture(g_all, mc->mesh, &mc->grid, &o, &c, NULL));
        check_order(&c, "after a cancelled run");
        check_same(&ref, &c, "after a cancelled run");
        capture_free(&c);
    }
    capture_free(&ref);
}

/* ---- 5. launch groups: several slabs per method call ---- */

static void set_group(unsigned n)
{
    clvox__test_hooks h = g_hooks;
    h.launch_slabs = n;
    clvox__set_test_hooks(&h);
}

/* The run's totals, which must not depend on how slabs are grouped. */
static void check_totals(const clvox_stats *a, const clvox_stats *b, const char *what)
{
    CHECK_MSG(a->filled_voxels == b->filled_voxels && a->coverage_sum == b->coverage_sum && a->rays == b->rays &&
                  a->odd_parity_rays == b->odd_parity_rays && a->overflow_rays == b->overflow_rays &&
                  a->max_crossings == b->max_crossings && a->winding.exact_points == b->winding.exact_points &&
                  a->palette_scored_voxels == b->palette_scored_voxels &&
                  a->palette_nonempty_voxels == b->palette_nonempty_voxels && a->palette_volume == b->palette_volume,
              "%s: totals differ: filled %llu vs %llu, coverage %.17g vs %.17g, rays %llu vs %llu, odd %llu vs %llu, "
              "overflow %llu vs %llu, exact %llu vs %llu, scored %llu vs %llu",
              what, (unsigned long long)a->filled_voxels, (unsigned long long)b->filled_voxels, a->coverage_sum,
              b->coverage_sum, (unsigned long long)a->rays, (unsigned long long)b->rays,
              (unsigned long long)a->odd_parity_rays, (unsigned long long)b->odd_parity_rays,
              (unsigned long long)a->overflow_rays, (unsigned long long)b->overflow_rays,
              (unsigned long long)a->winding.exact_points, (unsigned long long)b->winding.exact_points,
              (unsigned long long)a->palette_scored_voxels, (unsigned long long)b->palette_scored_voxels);
}

/* CLVOX_LAUNCH_SLABS = 1, 2, 3, 5 at slab depths 1, 3 and auto, on one
 * device and on the pair: the same bytes, every slab once and in order,
 * the same totals as one slab per call. */
static void test_groups_same(const mesh_case *mc)
{
    mode_case modes[10];
    size_t n = 0;
    clvox_voxelize_options base = CLVOX_VOXELIZE_OPTIONS_INIT;
    modes[n].name = "ray parity", modes[n].o = base, modes[n].o.inside = CLVOX_INSIDE_PARITY, n++;
    modes[n].name = "ray winding", modes[n].o = base, n++;
    modes[n].name = "ray winding, z rays", modes[n].o = base, modes[n].o.ray_axis = CLVOX_AXIS_Z, n++;
    modes[n].name = "coverage", modes[n].o = base, modes[n].o.oversample = 2, n++;
    modes[n].name = "coverage, y rays", modes[n].o = base, modes[n].o.oversample = 3;
    modes[n].o.ray_axis = CLVOX_AXIS_Y, n++;
    modes[n].name = "palette", modes[n].o = base, modes[n].o.palette = g_palette, modes[n].o.oversample = 2, n++;
    modes[n].name = "tetra", modes[n].o = base, modes[n].o.method = CLVOX_METHOD_TETRA, n++;
    modes[n].name = "surface", modes[n].o = base, modes[n].o.mode = CLVOX_MODE_SURFACE, n++;
    modes[n].name = "conservative", modes[n].o = base, modes[n].o.mode = CLVOX_MODE_CONSERVATIVE, n++;
    static const uint32_t depths[] = {1, 3, 0};
    static const unsigned groups[] = {2, 3, 5};
    for (size_t k = 0; k < n; k++)
        for (size_t d = 0; d < sizeof depths / sizeof depths[0]; d++) {
            clvox_voxelize_options o = modes[k].o;
            o.slab_depth = depths[d];
            char what[256];
            capture ref;
            capture_init(&ref, &mc->grid);
            clvox_stats rs = CLVOX_STATS_INIT;
            set_group(1);
            CHECK_OK(g_one, run_capture(g_one, mc->mesh, &mc->grid, &o, &ref, &rs));
            for (size_t gi = 0; gi < sizeof groups / sizeof groups[0]; gi++)
                for (int all = 0; all < 2; all++) {
                    snprintf(what, sizeof what, "[%s] %s, %s, slab depth %u, %u slabs a call, %s", g_config, mc->name,
                             modes[k].name, depths[d], groups[gi], all ? "two devices" : "one device");
                    capture c;
                    capture_init(&c, &mc->grid);
                    clvox_stats st = CLVOX_STATS_INIT;
                    set_group(groups[gi]);
                    clvox_context *ctx = all ? g_all : g_one;
                    CHECK_OK(ctx, run_capture(ctx, mc->mesh, &mc->grid, &o, &c, &st));
                    clear_fail();
                    check_order(&c, what);
                    check_same(&ref, &c, what);
                    check_totals(&rs, &st, what);
                    CHECK_MSG(st.slab_depth == rs.slab_depth || all, "%s: slab depth %u vs %u", what, st.slab_depth,
                              rs.slab_depth);
                    if (all) check_shares(&st, mc->grid.dims[2], what);
                    else /* two groups: one computed while the other is written */
                        CHECK_MSG(st.reorder_peak <= st.reorder_slabs &&
                                      st.reorder_slabs == 2 * (groups[gi] < (mc->grid.dims[2] + st.slab_depth - 1) /
                                                                                   st.slab_depth
                                                                   ? groups[gi]
                                                                   : (mc->grid.dims[2] + st.slab_depth - 1) /
                                                                         st.slab_depth),
                                  "%s: reorder buffer %u of %u slabs", what, st.reorder_peak, st.reorder_slabs);
                    CHECK_MSG(!*clvox_context_warnings(ctx), "%s: warnings '%s'", what, clvox_context_warnings(ctx));
                    capture_free(&c);
                }
            capture_free(&ref);
        }
    clear_fail();
}

/* A device failing in the middle of a group (its 2nd slab of a group of
 * 3): the whole group goes back; alone, the run fails before any slab of
 * the group reaches the callback; a cancel stops the run. */
static void test_groups_faults(const mesh_case *mc)
{
    clvox_voxelize_options o = fault_options();
    capture ref;
    capture_init(&ref, &mc->grid);
    set_group(1);
    CHECK_OK(g_one, run_capture(g_one, mc->mesh, &mc->grid, &o, &ref, NULL));
    for (int k = 0; k < 2; k++) {
        int failed = 0;
        for (int attempt = 0; attempt < 8 && !failed; attempt++) {
            char what[160];
            snprintf(what, sizeof what, "[%s] groups of 3, device %d failing at its 2nd slab", g_config, k);
            capture c;
            capture_init(&c, &mc->grid);
            clvox_stats st = CLVOX_STATS_INIT;
            set_group(3);
            clvox__test_hooks h = *clvox__hooks();
            h.fail_device_k = k, h.fail_device_n = 2;
            clvox__set_test_hooks(&h);
            clvox_status s = run_capture(g_all, mc->mesh, &mc->grid, &o, &c, &st);
            set_group(3);
            CHECK_MSG(s == CLVOX_OK, "%s: %s: %s", what, clvox_status_string(s), clvox_context_error(g_all));
            failed = st.devices[k].failed;
            if (failed) {
                check_order(&c, what);
                check_same(&ref, &c, what);
                CHECK_MSG(!st.devices[1 - k].failed && st.devices[k].slabs == 0 &&
                              st.devices[0].slices + st.devices[1].slices == mc->grid.dims[2],
                          "%s: device %d won %u slabs (%llu slices), the other %llu", what, k, st.devices[k].slabs,
                          (unsigned long long)st.devices[k].slices, (unsigned long long)st.devices[1 - k].slices);
                const char *w = clvox_context_warnings(g_all);
                CHECK_MSG(strstr(w, "failed") && count_lines(w) == 1, "%s: warnings '%s'", what, w);
            }
            capture_free(&c);
        }
        CHECK_MSG(failed, "[%s] groups of 3: device %d never started a group", g_config, k);
    }
    /* one device: the group of slabs 1-3 fails as a whole */
    {
        capture c;
        capture_init(&c, &mc->grid);
        set_group(3);
        clvox__test_hooks h = *clvox__hooks();
        h.fail_device_k = 0, h.fail_device_n = 2;
        clvox__set_test_hooks(&h);
        clvox_status s = run_capture(g_one, mc->mesh, &mc->grid, &o, &c, NULL);
        set_group(3);
        CHECK_MSG(s == CLVOX_ERR_OPENCL && c.calls == 0, "[%s] one device, groups of 3, failing at slab 2: %s, %u slabs "
                  "reached the callback", g_config, clvox_status_string(s), c.calls);
        capture_free(&c);
    }
    /* cancelling between batches of a group */
    for (int at = 1; at <= 2; at++) {
        capture c;
        capture_init(&c, &mc->grid);
        c.cancel_at = at;
        set_group(3);
        clvox_status s = run_capture(g_all, mc->mesh, &mc->grid, &o, &c, NULL);
        CHECK_MSG(s == CLVOX_ERR_CANCELLED && c.progress_calls == at && c.next_z < c.Z,
                  "[%s] groups of 3, cancelled at progress call %d: %s, %d calls, %u of %u slices", g_config, at,
                  clvox_status_string(s), c.progress_calls, c.next_z, c.Z);
        capture_free(&c);
        capture_init(&c, &mc->grid);
        CHECK_OK(g_all, run_capture(g_all, mc->mesh, &mc->grid, &o, &c, NULL));
        check_order(&c, "groups of 3, after a cancelled run");
        check_same(&ref, &c, "groups of 3, after a cancelled run");
        capture_free(&c);
    }
    clear_fail();
    capture_free(&ref);
}

/* ---- 6. the command-line tool ---- */

static char g_bin[PATH_MAX], g_dir[PATH_MAX], g_in[PATH_MAX], g_out[PATH_MAX], g_logs[PATH_MAX];
static unsigned g_run_id;

#define ARGS(...) ((const char *const[]){__VA_ARGS__, NULL})

static int cli(spawn_result *r, const char *fail, const char *const *args)
{
    const char **argv = spawn_argv(g_bin, args);
    char fail_var[64];
    snprintf(fail_var, sizeof fail_var, "CLVOX_TEST_FAIL_DEVICE=%s", fail ? fail : "");
    const char *const add[] = {fail_var, NULL};
    const char **env = child_env(ARGS("CLVOX_TEST_FAIL_DEVICE", "CLVOX_DEVICE"), fail ? add : NULL);
    char out_path[PATH_MAX], err_path[PATH_MAX];
    spawn_log_paths(g_logs, ++g_run_id, out_path, err_path);
    spawn_opts so;
    memset(&so, 0, sizeof so);
    so.env = env;
    so.timeout_s = CLI_TIMEOUT_S;
    int code = spawn_run_to(r, argv, out_path, err_path, &so);
    free(argv);
    free(env);
    return code;
}

/* Whole file; *size its length; NULL when unreadable. */
static unsigned char *slurp(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    unsigned char *buf = NULL;
    size_t n = 0, cap = 0;
    for (;;) {
        if (n == cap) {
            cap = cap ? 2 * cap : 65536;
            unsigned char *q = realloc(buf, cap);
            if (!q) abort();
            buf = q;
        }
        size_t got = fread(buf + n, 1, cap - n, f);
        n += got;
        if (!got) break;
    }
    fclose(f);
    *size = n;
    return buf;
}

static int same_file(const char *a, const char *b)
{
    size_t na = 0, nb = 0;
    unsigned char *x = slurp(a, &na), *y = slurp(b, &nb);
    int same = x && y && na == nb && na > 0 && memcmp(x, y, na) == 0;
    free(x), free(y);
    return same;
}

static void test_cli(void)
{
    const char *bin = getenv("CLVOX_BIN");
    if (!bin || !*bin) bin = "build/release/clvox";
    if (!test_cli_dirs(bin, "devices", g_bin, g_dir, g_in, g_out, g_logs)) return;
    char mesh[PATH_MAX], p[6][PATH_MAX];
    path_join(mesh, sizeof mesh, g_in, "lopsided.off");
    tmesh t = lopsided();
    CHECK(tmesh_write_off(&t, mesh) == 0);
    tmesh_free(&t);
    static const char *const names[6] = {"one.exr", "all.exr", "one.npy", "all.npy", "fail.exr", "old.exr"};
    for (int i = 0; i < 6; i++) path_join(p[i], sizeof p[i], g_out, names[i]);
    spawn_result r;

    /* --device all: the same files as one device */
    for (int i = 0; i < 4; i++) {
        cli(&r, NULL, ARGS(mesh, "-r", "40", "--device", i & 1 ? "all" : "0", "-q", "-o", p[i]));
        CHECK_MSG(r.code == 0 && !*r.err, "clvox --device %s -o %s: exit %d, stderr '%s'", i & 1 ? "all" : "0",
                  names[i], r.code, r.err);
        spawn_free(&r);
    }
    CHECK_MSG(same_file(p[0], p[1]), "--device all wrote another EXR file than --device 0");
    CHECK_MSG(same_file(p[2], p[3]), "--device all wrote another .npy file than --device 0");

    /* a device failing: a warning, the same file */
    /* (device 0 may start no slab at all when device 1 is quicker to start:
     * then no warning, and the run is tried again) */
    for (int attempt = 0; attempt < 3; attempt++) {
        cli(&r, "0:1", ARGS(mesh, "-r", "40", "--device", "all", "-q", "-o", p[4]));
        if (r.code != 0 || *r.err) break;
        spawn_free(&r);
    }
    CHECK_MSG(r.code == 0 && lines_starting(r.err, "clvox: warning: device 0 ") == 1 && count_lines(r.err) == 1,
              "CLVOX_TEST_FAIL_DEVICE=0:1 --device all: exit %d, stderr '%s'", r.code, r.err);
    spawn_free(&r);
    CHECK_MSG(same_file(p[0], p[4]), "with device 0 failing, --device all wrote another file");

    /* the tetra method and the conservative mode (whose surface pass has a
     * lead of its own): the same file on the set, and with either device
     * failing its preparation (one warning) */
    static const char *const raster_args[2][2] = {{"--method", "tetra"}, {"--mode", "conservative"}};
    for (int m = 0; m < 2; m++) {
        char q[4][PATH_MAX];
        for (int i = 0; i < 4; i++) {
            char leaf[32];
            snprintf(leaf, sizeof leaf, "raster%d-%d.npy", m, i);
            path_join(q[i], sizeof q[i], g_out, leaf);
            static const char *const fail_at[4] = {NULL, NULL, "0:prepare", "1:prepare"};
            cli(&r, fail_at[i], ARGS(mesh, "-r", "40", raster_args[m][0], raster_args[m][1], "--device",
                                     i ? "all" : "0", "-q", "-o", q[i]));
            char lead[32];
            snprintf(lead, sizeof lead, "clvox: warning: device %d ", i - 2);
            CHECK_MSG(r.code == 0 && (i < 2 ? !*r.err : lines_starting(r.err, lead) == 1 && count_lines(r.err) == 1),
                      "%s %s, CLVOX_TEST_FAIL_DEVICE=%s: exit %d, stderr '%s'", raster_args[m][0], raster_args[m][1],
                      fail_at[i] ? fail_at[i] : "", r.code, r.err);
            spawn_free(&r);
            if (i) CHECK_MSG(same_file(q[0], q[i]), "%s %s: run %d wrote another file than one device",
                             raster_args[m][0], raster_args[m][1], i);
        }
    }

    /* every device failing: an error, no file, an older one kept */
    static const char old_text[] = "an older file of that name\n";
    CHECK(write_text(p[5], old_text));
    const char *fails[2] = {"0:1", "*:1"}, *devs[2] = {"0", "all"};
    for (int i = 0; i < 2; i++) {
        char fresh[PATH_MAX];
        path_join(fresh, sizeof fresh, g_out, "fresh.exr");
        cli(&r, fails[i], ARGS(mesh, "-r", "40", "--device", devs[i], "-q", "-o", p[5]));
        CHECK_MSG(r.code != 0 && r.code != -1 && lines_starting(r.err, "clvox: error: ") == 1 &&
                      (i == 0 || strstr(r.err, "every device failed")),
                  "CLVOX_TEST_FAIL_DEVICE=%s --device %s: exit %d, stderr '%s'", fails[i], devs[i], r.code, r.err);
        spawn_free(&r);
        char *kept = read_text(p[5]);
        CHECK_MSG(kept && !strcmp(kept, old_text), "a failed run did not keep the older file: '%s'",
                  kept ? kept : "(missing)");
        free(kept);
        cli(&r, fails[i], ARGS(mesh, "-r", "40", "--device", devs[i], "-q", "-o", fresh));
        CHECK_MSG(r.code != 0 && !file_exists(fresh), "a failed run left %s (exit %d)", fresh, r.code);
        spawn_free(&r);
    }

    /* --json: a "devices" array of 2 */
    cli(&r, NULL, ARGS(mesh, "-r", "32", "--device", "all", "--json", "-o", p[1]));
    const char *a = strstr(r.out, "\"devices\":[");
    int objects = -1;
    if (a) {
        const char *end = strchr(a, ']');
        objects = 0;
        for (const char *q = a; end && q < end; q++) objects += *q == '{';
    }
    CHECK_MSG(r.code == 0 && objects == 2 && strstr(r.out, "\"scheduling_efficiency\":"),
              "--json --device all: exit %d, %d device objects: '%.300s'", r.code, objects, r.out);
    spawn_free(&r);

    /* --list-devices: the fp64 column, both devices, the hint */
    cli(&r, NULL, ARGS("--list-devices"));
    CHECK_MSG(r.code == 0 && strstr(r.out, "fp64") && lines_starting(r.out, "0 ") == 1 &&
                  lines_starting(r.out, "1 ") == 1 && strstr(r.out, "--device all"),
              "--list-devices: exit %d: '%s'", r.code, r.out);
    spawn_free(&r);
}

/* ---- a device without fp64 beside one with it ---- */

/* Device 1 built as a device without fp64 (CLVOX_KERNEL_FLOAT_DEVICE=1):
 * the set keeps both; every mode (parity, tetra, surface, coverage with
 * parity, and winding, conservative, coverage and palette on cubic voxels
 * and on others) uses both and gives the one-device volume, with no
 * warning, and device 1 alone gives it too (device 0 made to fail at its
 * first slab). */
static void test_mixed_precision(const mesh_case *mc)
{
    clvox__test_hooks h = g_hooks;
    h.kernels_float_device = 2; /* device 1 */
    clvox__set_test_hooks(&h);
    clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
    co.device = "all";
    clvox_context *mixed = NULL;
    clvox_status cs = clvox_context_create(&co, &mixed);
    clear_fail();
    CHECK_MSG(cs == CLVOX_OK && clvox_context_device_count(mixed) == 2 && !*clvox_context_warnings(mixed) &&
                  mixed->member[0]->real_size == 8 && mixed->member[1]->real_size == 4,
              "[%s] a float device beside a double one: %s, %zu devices, warnings '%s'", g_config,
              clvox_status_string(cs), cs == CLVOX_OK ? clvox_context_device_count(mixed) : 0,
              cs == CLVOX_OK ? clvox_context_warnings(mixed) : clvox_context_error(mixed));
    if (cs != CLVOX_OK || clvox_context_device_count(mixed) != 2) {
        clvox_context_destroy(mixed);
        return;
    }
    mode_case modes[10];
    size_t nmode = make_modes(modes);
    modes[nmode].name = "coverage parity", modes[nmode].o = modes[3].o; /* "coverage" */
    modes[nmode].o.inside = CLVOX_INSIDE_PARITY, modes[nmode].o.oversample_points = 3, nmode++;
    for (size_t k = 0; k < nmode; k++) {
        const char *name = modes[k].name;
        char what[256];
        snprintf(what, sizeof what, "[%s] %s, %s, a float device beside a double one", g_config, mc->name, name);
        capture ref, c;
        capture_init(&ref, &mc->grid);
        capture_init(&c, &mc->grid);
        CHECK_OK(g_one, run_capture(g_one, mc->mesh, &mc->grid, &modes[k].o, &ref, NULL));
        clvox_stats st = CLVOX_STATS_INIT;
        clvox_voxelize_options o = modes[k].o;
        o.slab_depth = 2; /* several slabs a device */
        clvox_status s = run_capture(mixed, mc->mesh, &mc->grid, &o, &c, &st);
        CHECK_MSG(s == CLVOX_OK, "%s: %s: %s", what, clvox_status_string(s), clvox_context_error(mixed));
        check_order(&c, what);
        check_same(&ref, &c, what);
        const char *w = clvox_context_warnings(mixed);
        {
            /* it takes part (how many slabs it gets depends on the load) */
            CHECK_MSG(!*w && st.device_count == 2, "%s: warnings '%s'", what, w);
            /* device 0 failing at its first slab: device 1, in float,
             * computes the whole volume */
            capture c1;
            capture_init(&c1, &mc->grid);
            clvox_stats s1 = CLVOX_STATS_INIT;
            set_fail(0, 1);
            s = run_capture(mixed, mc->mesh, &mc->grid, &o, &c1, &s1);
            clear_fail();
            CHECK_MSG(s == CLVOX_OK && s1.devices[1].slices == mc->grid.dims[2], "%s, device 0 failing: %s, %llu slices",
                      what, clvox_status_string(s), (unsigned long long)s1.devices[1].slices);
            check_same(&ref, &c1, what);
            capture_free(&c1);
        }
        capture_free(&ref);
        capture_free(&c);
    }
    clvox_context_destroy(mixed);
}

/* ---- the speed rule on a set ---- */

/* Both devices taken to run double 32x slower than float
 * (CLVOX_FP64_SLOWDOWN's hook): each gets the float build by the speed rule
 * (src/core/device_speed.c) and keeps it, and neither is left out of a
 * run for its build, the winding test on voxels that are not cubes
 * included. Every mode gives the one-device double volume, with no
 * warning. */
static void test_speed_rule_set(const mesh_case *mc)
{
    clvox__test_hooks h = g_hooks;
    h.fp64_slowdown = 32;
    clvox__set_test_hooks(&h);
    clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
    co.device = "all";
    clvox_context *set = NULL;
    clvox_status cs = clvox_context_create(&co, &set);
    clear_fail(); /* g_hooks again */
    CHECK_MSG(cs == CLVOX_OK && clvox_context_device_count(set) == 2 && set->member[0]->real_size == 4 &&
                  set->member[1]->real_size == 4 && clvox_context_device_at(set, 1)->kernels_float,
              "[%s] the speed rule on two devices: %s, %zu devices", g_config, clvox_status_string(cs),
              cs == CLVOX_OK ? clvox_context_device_count(set) : 0);
    if (cs != CLVOX_OK || clvox_context_device_count(set) != 2) {
        clvox_context_destroy(set);
        return;
    }
    mode_case modes[10];
    const size_t nmode = make_modes(modes);
    const clvox_grid *g = &mc->grid;
    for (size_t k = 0; k < nmode; k++) {
        const char *name = modes[k].name;
        const clvox_voxelize_options *mo = &modes[k].o;
        char what[256];
        snprintf(what, sizeof what, "[%s] %s, %s, the speed rule on two devices", g_config, mc->name, name);
        capture ref, c;
        capture_init(&ref, g);
        capture_init(&c, g);
        CHECK_OK(g_one, run_capture(g_one, mc->mesh, g, mo, &ref, NULL));
        clvox_stats st = CLVOX_STATS_INIT;
        clvox_voxelize_options o = *mo;
        o.slab_depth = 2;
        clvox_status s = run_capture(set, mc->mesh, g, &o, &c, &st);
        CHECK_MSG(s == CLVOX_OK, "%s: %s: %s", what, clvox_status_string(s), clvox_context_error(set));
        check_order(&c, what);
        check_same(&ref, &c, what);
        const char *w = clvox_context_warnings(set);
        const size_t want = 4;
        /* no device left out for its build (that warns; the scheduler's
         * own "too slow to pay" depends on the load and does not) */
        CHECK_MSG(!*w && st.device_count == 2 && set->member[0]->real_size == want &&
                      set->member[1]->real_size == want,
                  "%s: warnings '%s', %u devices, kernels of %zu and %zu bytes (want %zu)", what, w,
                  (unsigned)st.device_count, set->member[0]->real_size, set->member[1]->real_size, want);
        capture_free(&ref);
        capture_free(&c);
    }
    clvox_context_destroy(set);
}

/* ---- the child: one pair of devices ---- */

static int child(const char *config)
{
    g_config = config;
    g_hooks = *clvox__hooks();
    g_hooks.fail_device_k = -1;
    clear_fail();
    clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
    co.device = "0";
    CHECK_OK(g_one, clvox_context_create(&co, &g_one));
    co.device = "all";
    CHECK_OK(g_all, clvox_context_create(&co, &g_all));
    size_t ndev = clvox_context_device_count(g_all);
    CHECK_MSG(ndev == 2 && !*clvox_context_warnings(g_all), "[%s] device \"all\": %zu devices, warnings '%s'",
              config, ndev, clvox_context_warnings(g_all));
    CHECK(clvox_context_device_count(g_one) == 1);
    if (ndev != 2 || clvox_context_device_count(g_one) != 1) {
        clvox_context_destroy(g_one);
        clvox_context_destroy(g_all);
        return test_report();
    }
    CHECK_OK(g_one, clvox_palette_builtin(g_one, "planar10", &g_palette));

    mesh_case meshes[5];
    size_t n = 0;
    static const char *const files[] = {"cow.off", "armadillo.off", "elephant-with-holes.off", "mech-holes-shark.off"};
    for (size_t i = 0; i < 4; i++) n += load_case(&meshes[n], files[i], 32);
    tmesh t = lopsided();
    meshes[n].name = "lopsided (dense bottom)";
    meshes[n].mesh = from_tmesh(&t);
    meshes[n].grid = test_grid(g_lo, g_hi, 32, 32, 64);
    mesh_case *lop = &meshes[n];
    n += meshes[n].mesh != NULL;
    tmesh_free(&t);
    if (lop->mesh) {
        mesh_case fault = *lop;
        fault.grid = test_grid(g_lo, g_hi, 48, 48, 64);
        test_failures(&fault);
        test_prepare_failures(&fault);
        test_reorder_bound(lop->mesh);
        test_cancel(&fault);
    }
    test_same_volume(meshes, n);
    if (strcmp(config, "pthread pthread")) { /* one device, two equal ones, two unequal ones */
        if (lop->mesh) {
            mesh_case fault = *lop;
            fault.grid = test_grid(g_lo, g_hi, 48, 48, 64);
            test_groups_faults(&fault);
        }
        for (size_t i = 0; i < n; i++)
            if (meshes[i].mesh && (!strcmp(meshes[i].name, "armadillo.off") || meshes[i].mesh == lop->mesh))
                test_groups_same(&meshes[i]);
    }
    if (!strcmp(config, "basic basic")) {
        test_cli();
        if (lop->mesh) test_mixed_precision(lop);
        for (size_t i = 0; i < n; i++) /* an open mesh on cubic voxels */
            if (meshes[i].mesh && !strcmp(meshes[i].name, "elephant-with-holes.off")) test_mixed_precision(&meshes[i]);
        if (lop->mesh) test_speed_rule_set(lop);
    }

    for (size_t i = 0; i < n; i++) clvox_mesh_destroy(meshes[i].mesh);
    clvox_palette_destroy(g_palette);
    clvox_context_destroy(g_all);
    clvox_context_destroy(g_one);
    return test_report();
}

/* ---- the parent: a child per pair ---- */

int main(int argc, char **argv)
{
    if (argc == 3 && !strcmp(argv[1], "--child")) return child(argv[2]);
    char self[PATH_MAX], dir[PATH_MAX], logs[PATH_MAX];
    ssize_t len = readlink("/proc/self/exe", self, sizeof self - 1);
    if (len <= 0) {
        fprintf(stderr, "cannot find this program (/proc/self/exe)\n");
        test_failed++;
        return test_report();
    }
    self[len] = 0;
    path_join(dir, sizeof dir, test_tmpdir(), "devices-children");
    rm_tree(dir);
    mkdir(dir, 0777);
    path_join(logs, sizeof logs, dir, "logs");
    mkdir(logs, 0777);
    unsigned reorder_slabs[NCONFIG] = {0};
    unsigned long long reorder_bytes[NCONFIG] = {0};
    for (size_t i = 0; i < NCONFIG; i++) {
        char var[64];
        snprintf(var, sizeof var, "POCL_DEVICES=%s", g_configs[i]);
        const char **env = child_env(ARGS("POCL_DEVICES", "CLVOX_TEST_FAIL_DEVICE", "CLVOX_DEVICE"), ARGS(var));
        const char **cargv = spawn_argv(self, ARGS("--child", g_configs[i]));
        char out_path[PATH_MAX], err_path[PATH_MAX];
        spawn_log_paths(logs, (unsigned)i, out_path, err_path);
        spawn_opts so;
        memset(&so, 0, sizeof so);
        so.env = env;
        so.timeout_s = CHILD_TIMEOUT_S;
        spawn_result r;
        double t0 = now_s();
        spawn_run_to(&r, cargv, out_path, err_path, &so);
        double secs = now_s() - t0;
        free(cargv);
        free(env);
        /* its summary line (the last), its reorder line */
        int p = -1, f = -1;
        for (const char *line = r.out; line && *line;) {
            int a, b;
            unsigned s;
            unsigned long long by;
            if (sscanf(line, "%d passed, %d failed", &a, &b) == 2) p = a, f = b;
            if (sscanf(line, "reorder slabs=%u bytes=%llu", &s, &by) == 2) reorder_slabs[i] = s, reorder_bytes[i] = by;
            if (!strncmp(line, "skipped ", 8)) printf("  [%s] %.*s", g_configs[i], (int)strcspn(line, "\n") + 1, line);
            const char *nl = strchr(line, '\n');
            line = nl ? nl + 1 : NULL;
        }
        if (p < 0 || r.code != (f > 0)) {
            fprintf(stderr, "FAIL: POCL_DEVICES='%s': exit %d, %s\n%s\n", g_configs[i], r.code,
                    p < 0 ? "no summary line" : "exit status and summary disagree", r.err);
            test_failed++;
        } else {
            test_passed += p, test_failed += f;
            if (f) fputs(r.err, stderr);
        }
        printf("  [%s] %d passed, %d failed (%.1f s)\n", g_configs[i], p, f, secs);
        spawn_free(&r);
    }
    CHECK_MSG(reorder_slabs[0] && reorder_slabs[0] == reorder_slabs[1] && reorder_slabs[1] == reorder_slabs[2] &&
                  reorder_bytes[0] == reorder_bytes[1] && reorder_bytes[1] == reorder_bytes[2],
              "reorder buffer (slabs, bytes) by device pair: (%u, %llu) (%u, %llu) (%u, %llu)", reorder_slabs[0],
              reorder_bytes[0], reorder_slabs[1], reorder_bytes[1], reorder_slabs[2], reorder_bytes[2]);
    return test_report();
}
