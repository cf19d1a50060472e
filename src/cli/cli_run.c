/* SPDX-License-Identifier: Apache-2.0 */
/* Past 800 lines on purpose: one mesh's run from parsed options to the
 * summary, read top to bottom as one story; its parts (session, --like, run,
 * summary) are sections and share the vox_run state. */
/*
 * One mesh's voxelization, shared by `clvox MESH` (cli.c) and `clvox batch`
 * (cli_batch.c): the session (host context, palette, --like grid, signal
 * handlers) and vox_run with its progress bar, warnings, text summary and
 * JSON record. Split from cli.c unchanged: it is the pipeline stage after
 * the options (cli_args.c) and before the output of the result.
 *
 * Order of work: check the output directory (creates nothing), load the
 * mesh and compute the grid on a host-only context (so mesh and grid errors
 * need no OpenCL device), then open the device and voxelize. The library
 * writes a file without a name and names it only on success, so a failed,
 * cancelled or killed run leaves no file.
 */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include "clvox.h"
#include "cli_common.h"
#include "cli_json.h"
#include "cli_vox.h"

#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#define PROGRESS_INTERVAL_S 0.1 /* at most 10 redraws per second */
#define BAR_WIDTH 30

static volatile sig_atomic_t g_interrupted;

/* ---- small helpers ------------------------------------------------------ */

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void on_signal(int sig)
{
    if (g_interrupted) { /* second request: stop now */
        signal(sig, SIG_DFL);
        raise(sig);
        return;
    }
    g_interrupted = 1;
}

/* SIGINT, SIGTERM and SIGHUP (a closed terminal) cancel the run, except a
 * signal the process inherited ignored: `nohup clvox ... &` (SIGHUP) and a
 * background job of a non-interactive shell (SIGINT) asked not to be
 * stopped by it. No SA_RESTART: a call blocked in the kernel returns EINTR
 * and the run ends as cancelled (fail_message). */
static void install_signal_handlers(void)
{
    static const int sigs[] = {SIGINT, SIGTERM, SIGHUP};
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    for (size_t i = 0; i < sizeof sigs / sizeof *sigs; i++) {
        struct sigaction old;
        if (sigaction(sigs[i], NULL, &old) == 0 && old.sa_handler == SIG_IGN) continue;
        sigaction(sigs[i], &sa, NULL);
    }
}

static void format_duration(double s, char *buf, size_t size)
{
    if (!(s >= 0) || s > 1e7) snprintf(buf, size, "?");
    else if (s < 1) snprintf(buf, size, "<1 s");
    else if (s < 120) snprintf(buf, size, "%.0f s", s);
    else if (s < 7200) snprintf(buf, size, "%d min %02d s", (int)(s / 60), (int)fmod(s, 60));
    else snprintf(buf, size, "%d h %02d min", (int)(s / 3600), (int)fmod(s / 60, 60));
}

/* Prints "clvox: warning: <message>" as one line on stderr. */
static void warn(const char *fmt, ...) CLI_PRINTF(1, 2);
static void warn(const char *fmt, ...)
{
    char buf[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    progress_erase();
    fprintf(stderr, "clvox: warning: %s\n", buf);
}

/* ---- summary helpers --------------------------------------------------------- */

/* The EXR compression a run uses: the default is ZIP for palette runs
 * (an element channel; see clvox.h), else RLE. */
static clvox_compression effective_compression(const cli_args *a)
{
    if (a->vox.compression != CLVOX_COMPRESSION_DEFAULT) return a->vox.compression;
    uint32_t ch = a->vox.channels ? a->vox.channels : a->palette ? CLVOX_CHANNEL_ELEMENT : 0u;
    return (ch & CLVOX_CHANNEL_ELEMENT) ? CLVOX_COMPRESSION_ZIP : CLVOX_COMPRESSION_RLE;
}

static const char *compression_name(clvox_compression c)
{
    switch (c) {
    case CLVOX_COMPRESSION_NONE: return "none";
    case CLVOX_COMPRESSION_DEFAULT:
    case CLVOX_COMPRESSION_RLE: return "rle";
    case CLVOX_COMPRESSION_ZIPS: return "zips";
    case CLVOX_COMPRESSION_ZIP: return "zip";
    case CLVOX_COMPRESSION_PIZ: return "piz";
    case CLVOX_COMPRESSION_COUNT: break;
    }
    return "?";
}

static void auto_or_value(uint32_t v, char *buf, size_t size)
{
    if (v) snprintf(buf, size, "%u", (unsigned)v);
    else snprintf(buf, size, "auto");
}

/* ---- progress ------------------------------------------------------------------ */

typedef struct progress_state {
    int draw;            /* 1: draw a bar on stderr */
    double start;        /* when voxelization began */
    double last_draw;
} progress_state;

static int on_progress(void *user, double fraction)
{
    progress_state *p = user;
    if (g_interrupted) return 0;
    if (!p->draw) return 1;

    if (!(fraction >= 0)) fraction = 0;
    if (fraction > 1) fraction = 1;

    double now = now_seconds();
    if (fraction < 1 && now - p->last_draw < PROGRESS_INTERVAL_S) return 1;
    p->last_draw = now;

    char bar[BAR_WIDTH + 1];
    int full = (int)(fraction * BAR_WIDTH);
    for (int k = 0; k < BAR_WIDTH; k++) bar[k] = k < full ? '#' : '.';
    bar[BAR_WIDTH] = '\0';
    double elapsed = now - p->start;
    char eta[32];
    if (fraction > 0) format_duration(elapsed * (1 - fraction) / fraction, eta, sizeof eta);
    else snprintf(eta, sizeof eta, "?");
    char line[160];
    /* the library calls after each slab and between the batches of a long one */
    int n = snprintf(line, sizeof line, "[%s] %3d%%  eta %s", bar, (int)(fraction * 100), eta);
    if (n < 0) return 1;
    if (n >= (int)sizeof line) n = (int)sizeof line - 1;
    /* pad so that a shorter line overwrites a longer one completely */
    fprintf(stderr, "\r%s%*s", line, g_progress_line_len > n ? g_progress_line_len - n : 0, "");
    fflush(stderr);
    if (n > g_progress_line_len) g_progress_line_len = n;
    return 1;
}

/* ---- the run --------------------------------------------------------------------- */

/* "coverage, element, occupancy, score" (those in the mask). */
static const char *channel_list(uint32_t mask)
{
    static char buf[64];
    static const char *const names[] = {"occupancy", "coverage", "element", "score"};
    size_t n = 0;
    buf[0] = '\0';
    for (int i = 0; i < 4; i++)
        if (mask & (1u << i)) n += (size_t)snprintf(buf + n, sizeof buf - n, "%s%s", n ? ", " : "", names[i]);
    return buf;
}

/* A scene read through Assimp: its meshes, placements, units and what was
 * left out. Nothing for clvox's own formats (their output is unchanged). */
static void print_scene(const clvox_mesh_source_info *src)
{
    if (!src || strcmp(src->reader, "assimp") != 0) return;
    char unit[64];
    if (src->unit_metres > 0) snprintf(unit, sizeof unit, "1 unit = %g m (stated by the file)", src->unit_metres);
    else snprintf(unit, sizeof unit, "units not stated by the file");
    printf(LABEL "%u meshes, %llu placed (node transforms applied), %s, %llu lines and %llu points ignored\n",
           "scene", src->meshes, (unsigned long long)src->placements, unit, (unsigned long long)src->ignored_lines,
           (unsigned long long)src->ignored_points);
}

void print_summary(const char *mesh_path, const clvox_mesh_report *r, const clvox_mesh_source_info *src,
                   const clvox_grid *grid,
                   const clvox_context *devices, const cli_args *a, const clvox_palette *pal,
                   const clvox_stats *s, const char *output, double setup_seconds, double wall_seconds)
{
    const clvox_device_info *dev = clvox_context_device(devices);
    char extra[256] = "";
    size_t used = 0;
    if (r->polygons_triangulated)
        used += (size_t)snprintf(extra + used, sizeof extra - used, ", %llu polygons fanned",
                                 (unsigned long long)r->polygons_triangulated);
    if (r->nonmanifold_faces && used < sizeof extra)
        used += (size_t)snprintf(extra + used, sizeof extra - used, ", %llu non-manifold faces",
                                 (unsigned long long)r->nonmanifold_faces);
    if (r->duplicate_triangles && used < sizeof extra)
        snprintf(extra + used, sizeof extra - used, ", %llu duplicate triangles",
                 (unsigned long long)r->duplicate_triangles);
    char closed[64];
    if (r->closed) snprintf(closed, sizeof closed, "closed");
    else snprintf(closed, sizeof closed, "NOT closed (%llu boundary edges)", (unsigned long long)r->boundary_edges);
    printf(LABEL "%s\n", "mesh", mesh_path);
    printf(LABEL "%llu triangles, %llu vertices, %llu dropped faces, %llu degenerate%s, %s\n", "",
           (unsigned long long)r->triangles, (unsigned long long)r->vertices, (unsigned long long)r->dropped_faces,
           (unsigned long long)r->degenerate_triangles, extra, closed);
    print_scene(src);

    print_grid_line(grid->dims, grid->origin, grid->voxel_size);
    char build[128] = "";
    if (dev && dev->kernels_float)
        snprintf(build, sizeof build, dev->fp64_slowdown >= 8 ? ", kernels in float: its double measured %.0fx slower"
                                      : dev->fp64 ? ", kernels in float"
                                                  : ", kernels in float: no fp64",
                 (double)dev->fp64_slowdown);
    printf(LABEL "%s (%s, %s%s)\n", "device", dev ? dev->name : "?", dev ? dev->type : "?",
           dev ? dev->platform : "?", build);
    if (s->device_count > 1) { /* a device set: what each did, and how well they shared */
        uint64_t slices = 0;
        for (uint32_t i = 0; i < s->device_count; i++) slices += s->devices[i].slices;
        for (uint32_t i = 0; i < s->device_count; i++) {
            const clvox_device_share *d = &s->devices[i];
            const clvox_device_info *di = clvox_context_device_at(devices, d->device);
            char note[64] = "";
            if (d->failed) snprintf(note, sizeof note, ", failed");
            else if (d->left_out) snprintf(note, sizeof note, ", left out");
            if (d->discarded_slabs)
                snprintf(note + strlen(note), sizeof note - strlen(note), ", %u re-issued slabs lost",
                         (unsigned)d->discarded_slabs);
            printf(LABEL "%u %s: %u slabs, %.1f %% of the slices, busy %.3f s%s\n", i ? "" : "devices",
                   (unsigned)d->device, di ? di->name : "?", (unsigned)d->slabs,
                   slices ? 100.0 * (double)d->slices / (double)slices : 0.0, d->busy_seconds, note);
        }
        printf(LABEL "scheduling efficiency %.2f (speed-up over the fastest device / the ideal one)\n", "",
               s->scheduling_efficiency);
    }

    char slab[32];
    snprintf(slab, sizeof slab, "%u", (unsigned)s->slab_depth);
    if (a->vox.mode == CLVOX_MODE_SURFACE) {
        printf(LABEL "surface: closed cells meeting a triangle (exact), slab %s slices, %s compression\n", "method",
               slab, compression_name(effective_compression(a)));
    } else if (a->vox.method == CLVOX_METHOD_TETRA) {
        char origin[128];
        if (a->vox.tetra_origin == CLVOX_TETRA_ORIGIN_BBOX_CENTER) snprintf(origin, sizeof origin, "bbox centre");
        else if (a->vox.tetra_origin == CLVOX_TETRA_ORIGIN_POINT)
            snprintf(origin, sizeof origin, "(%.6g, %.6g, %.6g)", a->vox.tetra_point[0], a->vox.tetra_point[1],
                     a->vox.tetra_point[2]);
        else snprintf(origin, sizeof origin, "centroid");
        printf(LABEL "tetra: origin %s, slab %s slices, %s compression\n", "method", origin, slab,
               compression_name(effective_compression(a)));
    } else {
        static const char axes[] = {'x', 'x', 'y', 'z'};
        char depth[16], leaf[16];
        auto_or_value(a->vox.quadtree_max_depth, depth, sizeof depth);
        auto_or_value(a->vox.quadtree_leaf_size, leaf, sizeof leaf);
        int ax = (int)a->vox.ray_axis;
        printf(LABEL "ray along %c: quadtree depth %u (max %s), %llu leaves, leaf size %s, slab %s slices, %s "
                     "compression\n",
               "method", axes[ax >= 0 && ax <= 3 ? ax : 0], (unsigned)s->quadtree_depth, depth,
               (unsigned long long)s->quadtree_leaves, leaf, slab, compression_name(effective_compression(a)));
    }
    if (a->vox.mode == CLVOX_MODE_CONSERVATIVE)
        printf(LABEL "conservative: the solid above OR the surface (closed cells meeting a triangle, exact)\n", "mode");

    const int grey = (s->channels & CLVOX_CHANNEL_COVERAGE) != 0;
    if (pal) {
        uint32_t N = a->vox.oversample ? a->vox.oversample : 4, M = a->vox.oversample_points ? a->vox.oversample_points
                                                                    : a->vox.oversample ? N : 16;
        char seed[48] = "";
        if (a->vox.stochastic) snprintf(seed, sizeof seed, ", seed %llu", (unsigned long long)a->vox.seed);
        printf(LABEL "%s (%zu elements), metric %s, %u rays x %u points per voxel (%u samples), %s%s\n", "palette",
               clvox_palette_name(pal), clvox_palette_count(pal), clvox_metric_name(a->vox.metric), N * N, M,
               (unsigned)s->samples_per_voxel, a->vox.stochastic ? "stratified jitter" : "uniform", seed);
        double T = s->total_voxels ? (double)s->total_voxels : 1.0;
        char sc[96] = "";
        if (a->vox.nearest_shortcut)
            snprintf(sc, sizeof sc, ", %llu (%.1f %%) by the shortcut", (unsigned long long)s->palette_shortcut_voxels,
                     100.0 * (double)s->palette_shortcut_voxels / T);
        printf(LABEL "%llu voxels (%.1f %%) decided by early-out (wholly inside or outside)%s, %llu (%.1f %%) "
                     "scored\n",
               "", (unsigned long long)s->palette_early_voxels, 100.0 * (double)s->palette_early_voxels / T, sc,
               (unsigned long long)s->palette_scored_voxels, 100.0 * (double)s->palette_scored_voxels / T);
        printf(LABEL "%s\n", "channels", channel_list(s->channels));
    } else if (a->vox.oversample) {
        uint32_t N = a->vox.oversample, M = a->vox.oversample_points ? a->vox.oversample_points : N;
        char seed[48] = "";
        if (a->vox.stochastic) snprintf(seed, sizeof seed, ", seed %llu", (unsigned long long)a->vox.seed);
        char occ[64] = "";
        if (s->channels & CLVOX_CHANNEL_OCCUPANCY)
            snprintf(occ, sizeof occ, " (= coverage > %g)",
                     a->vox.threshold_set ? a->vox.threshold : 0.5);
        printf(LABEL "%ux%u rays x %u points per voxel (%u samples), %s%s; channels %s%s\n", "sampling", N, N, M,
               (unsigned)s->samples_per_voxel, a->vox.stochastic ? "stratified jitter" : "uniform", seed,
               grey && (s->channels & CLVOX_CHANNEL_OCCUPANCY) ? "coverage, occupancy" : grey ? "coverage" : "occupancy",
               occ);
    }
    if (pal) {
        double pct = s->total_voxels ? 100.0 * (double)s->palette_nonempty_voxels / (double)s->total_voxels : 0.0;
        printf(LABEL "%llu of %llu voxels (%.2f %%) got an element other than empty\n", "filled",
               (unsigned long long)s->palette_nonempty_voxels, (unsigned long long)s->total_voxels, pct);
    } else {
        print_filled_line(s->filled_voxels, s->total_voxels);
    }

    double filled_volume = voxels_volume(pal    ? s->palette_volume
                                         : grey ? s->coverage_sum
                                                : (double)s->filled_voxels,
                                         grid->voxel_size);
    const char *what = pal ? "of the elements" : grey ? "estimated (sum of coverage)" : "filled";
    char fv[48];
    format_volume(filled_volume, 6, fv, sizeof fv);
    if (r->enclosed_volume > 0 && isfinite(filled_volume)) {
        double rel = 100.0 * (filled_volume - r->enclosed_volume) / r->enclosed_volume;
        if (fabs(rel) < 0.005) rel = 0; /* no "-0.00 %" */
        printf(LABEL "%s %s vs %.6g enclosed by the mesh (%+.2f %%)%s\n", "volume", fv, what, r->enclosed_volume,
               rel, r->closed ? "" : " (mesh not closed: approximate)");
    } else if (r->enclosed_volume > 0) {
        printf(LABEL "%s %s vs %.6g enclosed by the mesh\n", "volume", fv, what, r->enclosed_volume);
    } else {
        printf(LABEL "%s %s (the mesh encloses no volume)\n", "volume", fv, what);
    }
    if ((a->vox.method == CLVOX_METHOD_RAY && a->vox.mode != CLVOX_MODE_SURFACE) || s->rays)
        printf(LABEL "%llu cast, %llu odd parity, %llu overflow redone, at most %u crossings per ray\n", "rays",
               (unsigned long long)s->rays, (unsigned long long)s->odd_parity_rays,
               (unsigned long long)s->overflow_rays, (unsigned)s->max_crossings);
    if (s->inside == CLVOX_INSIDE_WINDING || s->inside == CLVOX_INSIDE_WINDING_ABS) {
        const clvox_winding_report *w = &s->winding;
        printf(LABEL "%s: %llu vertices merged (%llu welded), %llu of %llu patches closed, %llu cavities, "
                     "%llu triangles flipped, %llu holes closed by %llu caps, %llu points exact (%.3f s)\n",
               "winding", s->inside == CLVOX_INSIDE_WINDING ? "w > 1/2" : "|w| > 1/2",
               (unsigned long long)(w->merged_vertices + w->welded_vertices), (unsigned long long)w->welded_vertices,
               (unsigned long long)w->closed_components, (unsigned long long)w->components,
               (unsigned long long)w->cavities, (unsigned long long)w->flipped_triangles,
               (unsigned long long)w->holes, (unsigned long long)w->cap_triangles,
               (unsigned long long)w->exact_points, w->seconds);
        if (s->crack_pairs)
            printf(LABEL "welded within %.3g (1/100 voxel) to find the same voxels faster: %llu vertices merged, "
                         "%llu of %llu holes left, %llu moved triangles checked where they could change a voxel\n",
                   "cracks", s->crack_weld_distance, (unsigned long long)s->crack_welded_vertices,
                   (unsigned long long)s->crack_holes, (unsigned long long)w->holes,
                   (unsigned long long)s->crack_pairs);
        if (w->exact_points)
            printf(LABEL "%llu points evaluated exactly: %.3f s of device time in the batches that had any, "
                         "at most %.1f us a point\n",
                   "exact", (unsigned long long)w->exact_points, s->winding_exact_seconds,
                   1e6 * s->winding_exact_seconds / (double)w->exact_points);
        if (s->winding_host_points)
            printf(LABEL "%llu points decided on the host in double (%.2g of the voxels): the float device's "
                         "bounds could not settle them\n",
                   "host", (unsigned long long)s->winding_host_points,
                   (double)s->winding_host_points / (double)(s->total_voxels ? s->total_voxels : 1));
    } else if (s->inside == CLVOX_INSIDE_PARITY && a->vox.mode != CLVOX_MODE_SURFACE) {
        printf(LABEL "parity (odd number of crossings beyond the centre)\n", "inside");
    }
    printf(LABEL "load %.3f  setup %.3f  partition %.3f  cast %.3f  classify %.3f  write %.3f  "
                 "total %.3f s (wall %.3f s)\n",
           "time", s->seconds[CLVOX_STAGE_LOAD], setup_seconds, s->seconds[CLVOX_STAGE_PARTITION],
           s->seconds[CLVOX_STAGE_CAST], s->seconds[CLVOX_STAGE_CLASSIFY], s->seconds[CLVOX_STAGE_WRITE],
           s->seconds[CLVOX_STAGE_TOTAL], wall_seconds);
    uint64_t bytes = s->output_bytes;
    struct stat sb;
    if (bytes == 0 && stat(output, &sb) == 0) bytes = (uint64_t)sb.st_size;
    char size[48];
    format_bytes(bytes, size, sizeof size);
    printf(LABEL "%s (%s)\n", "output", output, size);
}

/* ---- one mesh's run (shared with clvox batch, cli_batch.c) ------------------------ */

int cli_interrupted(void) { return g_interrupted != 0; }
double cli_now(void) { return now_seconds(); }

static int stop_at_first_slice(void *user, uint32_t z, const float *values)
{
    (void)user, (void)z, (void)values;
    return 1;
}

/* The first `max` bytes of `path` (malloc'ed, *len set; *whole: the file
 * ended within them), or NULL with the one-line error already printed. */
static char *like_read_head(const char *path, size_t max, size_t *len, int *whole)
{
    const char *why = NULL;
    int fd = clvox_open_regular_read(path, &why);
    if (fd < 0) {
        fail(EXIT_INPUT, "--like '%s': cannot open: %s", path, why);
        return NULL;
    }
    char *b = malloc(max + 1);
    if (!b) {
        close(fd);
        fail(EXIT_RUNTIME, "--like '%s': out of memory", path);
        return NULL;
    }
    size_t n = 0; /* one byte more than max: tells a longer file */
    int err = 0;
    while (n < max + 1) {
        ssize_t got = read(fd, b + n, max + 1 - n);
        if (got < 0 && errno == EINTR && !g_interrupted) continue;
        if (got < 0) err = errno;
        if (got <= 0) break;
        n += (size_t)got;
    }
    close(fd);
    if (err) {
        free(b);
        fail(EXIT_INPUT, "--like '%s': cannot read: %s", path, strerror(err));
        return NULL;
    }
    *whole = n <= max;
    *len = n > max ? max : n;
    return b;
}

#define LIKE_HEAD_MAX (1u << 20)

/* --like FILE: dims, origin and voxel size of an existing volume, one branch
 * per extension, each filling `out` or failing with one line (exit 4):
 *   .exr          a clvox EXR (its header and the first slice of one channel)
 *   .nrrd, .nhdr  a NRRD header, clvox's or another tool's (clvox_grid_from_nrrd_header)
 *   .json         the sidecar clvox writes next to a .npy
 *   .npy          its sidecar: OUT.json (for OUT.<channel>.npy also OUT.json),
 *                 once OUT.json agrees with every file of the set (clvox_npy_set_complete) */
static int like_read_grid(clvox_context *host, const char *path, clvox_grid *out)
{
    const char *base = path_basename(path);
    const char *dot = strrchr(base, '.');
    char ext[16] = "";
    if (dot && dot != base && strlen(dot + 1) < sizeof ext)
        for (size_t i = 0; dot[i + 1]; i++) ext[i] = (char)(dot[i + 1] >= 'A' && dot[i + 1] <= 'Z' ? dot[i + 1] + 32 : dot[i + 1]);
    int nrrd = strcmp(ext, "nrrd") == 0 || strcmp(ext, "nhdr") == 0;
    if (nrrd || strcmp(ext, "npy") == 0 || strcmp(ext, "json") == 0) {
        char *file = NULL; /* the file read: path, or the .npy's sidecar */
        if (strcmp(ext, "npy") == 0) {
            size_t stem = (size_t)(dot - path);
            static const char *const channels[] = {".occupancy", ".coverage", ".element", ".score"};
            file = malloc(stem + 6);
            if (!file) return fail(EXIT_INPUT, "--like: out of memory");
            memcpy(file, path, stem);
            strcpy(file + stem, ".json");
            for (size_t c = 0; c < 4 && !is_readable_file(file); c++) { /* OUT.coverage.npy -> OUT.json */
                size_t cl = strlen(channels[c]);
                if (stem > cl && strncmp(path + stem - cl, channels[c], cl) == 0 && path + stem - cl > base)
                    strcpy(file + stem - cl, ".json");
            }
            if (!is_readable_file(file)) {
                int rc = fail(EXIT_INPUT, "--like '%s': no readable sidecar '%s' next to it (clvox writes OUT.json "
                                          "with every OUT.npy)",
                              path, file);
                free(file);
                return rc;
            }
        }
        if (file) { /* the grid of OUT.json is that of the .npy only when the set is whole */
            char why[1024];
            if (!clvox_npy_set_complete(file, path, why, sizeof why)) {
                int rc = fail(EXIT_INPUT, "--like '%s': %s (--like '%s' takes its grid anyway)", path, why, file);
                free(file);
                return rc;
            }
        }
        const char *name = file ? file : path;
        size_t len = 0;
        int whole = 0;
        char *head = like_read_head(name, LIKE_HEAD_MAX, &len, &whole);
        if (!head) {
            free(file);
            return EXIT_INPUT;
        }
        char note[512] = "";
        clvox_status st;
        if (!nrrd && !whole)
            st = CLVOX_ERR_GRID, fail(EXIT_INPUT, "--like '%s': longer than %u bytes: not a clvox .npy sidecar",
                                      name, LIKE_HEAD_MAX);
        else if (nrrd) st = clvox_grid_from_nrrd_header(host, name, head, len, out, note, sizeof note);
        else st = clvox_grid_from_npy_sidecar(host, name, head, len, out);
        free(head);
        free(file);
        if (st != CLVOX_OK) {
            if (!(!nrrd && !whole)) {
                const char *msg = clvox_context_error(host);
                fail(EXIT_INPUT, "--like: %s", msg && *msg ? msg : clvox_status_string(st));
            }
            return EXIT_INPUT;
        }
        if (note[0]) warn("--like: %s", note);
        return EXIT_OK;
    }
    if (strcmp(ext, "exr") != 0)
        return fail(EXIT_INPUT, "--like '%s': expected a clvox volume (.exr, .nrrd, .nhdr, .npy or its .json sidecar)", path);
    static const char *const channels[] = {"occupancy", "coverage", "element"};
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    clvox_status st = CLVOX_ERR_EXR;
    for (size_t c = 0; c < 3; c++) {
        memset(&info, 0, sizeof info);
        info.size = sizeof info;
        st = clvox_volume_read_slices(host, path, channels[c], &info, stop_at_first_slice, NULL);
        if (st == CLVOX_OK || st == CLVOX_ERR_CANCELLED) break;
    }
    if (st != CLVOX_OK && st != CLVOX_ERR_CANCELLED) {
        const char *msg = clvox_context_error(host);
        return fail(EXIT_INPUT, "--like: %s", msg && *msg ? msg : clvox_status_string(st));
    }
    memset(out, 0, sizeof *out);
    for (int k = 0; k < 3; k++) {
        out->dims[k] = info.dims[k];
        out->origin[k] = info.origin[k];
        out->voxel_size[k] = info.voxel_size[k];
    }
    return EXIT_OK;
}

int vox_session_open(vox_session *s, const cli_args *a)
{
    memset(s, 0, sizeof *s);
    s->a = a;
    install_signal_handlers();
    clvox_status st;
    clvox_context_options ho = CLVOX_CONTEXT_OPTIONS_INIT;
    ho.host_only = 1; /* mesh and grid errors need no device */
    if ((st = clvox_context_create(&ho, &s->host)) != CLVOX_OK) return fail_status(s->host, st, ROLE_OTHER);
    if (a->palette) { /* a built-in name, else a palette file */
        int builtin = 0;
        for (size_t i = 0; clvox_palette_builtin_name(i); i++) builtin |= strcmp(a->palette, clvox_palette_builtin_name(i)) == 0;
        if (builtin) st = clvox_palette_builtin(s->host, a->palette, &s->palette);
        else if (access(a->palette, F_OK) != 0 && errno == ENOENT) /* anything there: the loader says what is wrong */
            return usage_error("--palette '%s': not a built-in palette (binary, planar10, paper46, paper78) and no "
                               "such file",
                               a->palette);
        else st = clvox_palette_load(s->host, a->palette, &s->palette);
        if (st != CLVOX_OK) return fail_status(s->host, st, ROLE_INPUT);
    }
    if (a->like) {
        int rc = like_read_grid(s->host, a->like, &s->like);
        if (rc != EXIT_OK) return rc;
        s->have_like = 1;
    }
    return EXIT_OK;
}

void vox_session_close(vox_session *s)
{
    clvox_palette_destroy(s->palette);
    clvox_context_destroy(s->dev);
    clvox_context_destroy(s->host);
    memset(s, 0, sizeof *s);
}

static void record_warning(vox_result *res, const char *fmt, ...) CLI_PRINTF(2, 3);
static void record_warning(vox_result *res, const char *fmt, ...)
{
    if (res->warning_count >= VOX_MAX_WARNINGS) return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(res->warnings[res->warning_count++], sizeof res->warnings[0], fmt, ap);
    va_end(ap);
}

/* A .binvox output gets the cube (--cube) unless its grid options ask for
 * something else: --box, or dims or voxel sizes that differ per axis. */
static int grid_allows_cube(const clvox_grid_options *g)
{
    const uint32_t *d = g->dims;
    const double *v = g->voxel_size;
    if (g->use_box) return 0;
    if ((d[0] || d[1] || d[2]) && (d[0] != d[1] || d[0] != d[2])) return 0;
    if ((v[0] != 0 || v[1] != 0 || v[2] != 0) && (v[0] != v[1] || v[0] != v[2])) return 0;
    return 1;
}

int vox_run(vox_session *s, const vox_job *job, vox_result *res)
{
    const cli_args *a = s->a;
    double wall_start = now_seconds();
    memset(res, 0, sizeof *res);
    res->status = "failed";
    clvox_mesh *mesh = job->preloaded ? job->mesh_ahead : NULL; /* ours from here on */
    clvox_status st;
    int rc;
    const char *saved_prefix = g_fail_prefix;
    if (s->batch) g_fail_prefix = job->source ? job->source : job->mesh;

    if (job->make_dirs && (rc = make_parent_dirs(job->output)) != EXIT_OK) goto done;
    if ((rc = check_output(job->output)) != EXIT_OK) goto done;
    clvox_format format = a->out.format ? a->out.format : clvox_format_from_path(job->output);
    if (!format) {
        rc = usage_error("cannot tell the output format of '%s' from its extension: use .exr, .npy, .nrrd, "
                         ".binvox or .vdb, or --format",
                         job->output);
        goto done;
    }
    struct stat in_sb, out_sb;
    if (stat(job->mesh, &in_sb) == 0 && stat(job->output, &out_sb) == 0 && in_sb.st_dev == out_sb.st_dev &&
        in_sb.st_ino == out_sb.st_ino) {
        rc = usage_error("the output '%s' is the input mesh", job->output);
        goto done;
    }

    if (job->preloaded) {
        if (!mesh) {
            rc = fail_status(job->mesh_ctx, job->mesh_status, ROLE_INPUT);
            goto done;
        }
        res->load_seconds = job->mesh_seconds;
    } else {
        double t0 = now_seconds();
        if ((st = clvox_mesh_load(s->host, job->mesh, &mesh)) != CLVOX_OK) {
            rc = fail_status(s->host, st, ROLE_INPUT);
            goto done;
        }
        res->load_seconds = now_seconds() - t0;
    }
    if (g_interrupted) { rc = fail_message(EXIT_CANCELLED, "cancelled"); goto done; }
    const clvox_mesh_report *report = clvox_mesh_get_report(mesh);
    res->report = *report;
    res->source.size = sizeof res->source;
    if (clvox_mesh_get_source_info(mesh, &res->source) != CLVOX_OK) res->source.reader[0] = 0;
    res->have_report = 1;

    if (s->have_like) {
        res->grid = s->like;
    } else {
        clvox_grid_options go = job->grid_by ? job->grid : a->grid;
        if (!(job->grid_by ? job->grid_by : a->grid_by)) go.resolution = DEFAULT_RESOLUTION;
        if (format == CLVOX_FORMAT_BINVOX && grid_allows_cube(&go)) go.cube = 1; /* binvox's own grid */
        if ((st = clvox_grid_compute(s->host, &go, report->bbox_min, report->bbox_max, &res->grid)) != CLVOX_OK) {
            rc = fail_status(s->host, st, ROLE_OTHER);
            goto done;
        }
    }
    res->have_grid = 1;

    if (!s->dev) { /* once per session: the kernel build is paid by the first mesh */
        /* The winding preparation (if these options use it) meanwhile, on
         * the core the set-up leaves idle (later meshes prepare beside their
         * partition, src/cast/cast.c); when no thread starts, the voxelization
         * prepares as usual and reports any error. */
        (void)clvox_mesh_prepare_winding(s->host, mesh, &a->vox);
        double t1 = now_seconds();
        clvox_context_options dco = CLVOX_CONTEXT_OPTIONS_INIT;
        dco.device = a->device;
        dco.float_kernels = a->float_kernels;
        if ((st = clvox_context_create(&dco, &s->dev)) != CLVOX_OK) {
            rc = fail_status(s->dev, st, ROLE_OTHER);
            clvox_context_destroy(s->dev);
            s->dev = NULL;
            res->fatal = 1; /* every further mesh would fail the same way */
            goto done;
        }
        s->setup_seconds = now_seconds() - t1;
        res->setup_seconds = s->setup_seconds;
    }
    if (g_interrupted) { rc = fail_message(EXIT_CANCELLED, "cancelled"); goto done; }

    progress_state prog;
    memset(&prog, 0, sizeof prog);
    prog.draw = !s->batch && !a->quiet && !a->no_progress && isatty(STDERR_FILENO);
    prog.start = now_seconds();
    prog.last_draw = prog.start - PROGRESS_INTERVAL_S;

    clvox_voxelize_options vo = a->vox;
    vo.palette = s->palette;
    vo.progress = on_progress;
    vo.progress_user = &prog;
    res->stats.size = sizeof res->stats;
    if (format == CLVOX_FORMAT_EXR && !a->out.flags) {
        st = clvox_voxelize_to_exr(s->dev, mesh, &res->grid, &vo, job->output, &res->stats);
    } else {
        clvox_output_options oo = a->out;
        oo.format = format;
        st = clvox_voxelize_to_file(s->dev, mesh, &res->grid, &vo, &oo, job->output, &res->stats);
    }
    progress_erase();
    { /* the library's warnings: devices left out or failed */
        const char *w = clvox_context_warnings(s->dev);
        while (w && *w) {
            const char *nl = strchr(w, '\n');
            int len = nl ? (int)(nl - w) : (int)strlen(w);
            record_warning(res, "%.*s", len, w);
            w += len + (nl != NULL);
        }
    }
    if (st != CLVOX_OK) {
        vox_print_warnings(s, job, res); /* before the error: they may explain it */
        res->warning_count = 0;
        rc = fail_status(s->dev, st, ROLE_OUTPUT);
        goto done;
    }
    res->stats.seconds[CLVOX_STAGE_LOAD] = res->load_seconds;
    res->have_stats = 1;
    res->output_size = res->stats.output_bytes;
    if (res->output_size == 0 && stat(job->output, &out_sb) == 0) res->output_size = (uint64_t)out_sb.st_size;

    /* Warnings come from the mesh report, whatever the method, one line each
     * (surface mode has no inside: open meshes and duplicates are fine). */
    const int solid = a->vox.mode != CLVOX_MODE_SURFACE;
    const int winding = res->stats.inside == CLVOX_INSIDE_WINDING || res->stats.inside == CLVOX_INSIDE_WINDING_ABS;
    if (solid && winding) {
        /* open and overlapping meshes are what the winding test is for; the
         * summary says what the preparation did */
    } else if (solid && !report->closed) {
        char rays[96] = "";
        if (res->stats.odd_parity_rays > 0)
            snprintf(rays, sizeof rays, "; %llu rays crossed it an odd number of times",
                     (unsigned long long)res->stats.odd_parity_rays);
        record_warning(res,
                       "the mesh is not closed (%llu boundary edges%s): inside and outside are not defined "
                       "everywhere and the result may be wrong",
                       (unsigned long long)report->boundary_edges, rays);
    } else if (solid && res->stats.odd_parity_rays > 0) {
        record_warning(res,
                       "%llu rays crossed the surface an odd number of times although the mesh is closed: the "
                       "result may be wrong",
                       (unsigned long long)res->stats.odd_parity_rays);
    }
    /* Vertices are 32-bit floats (relative to the first vertex for OFF and
     * OBJ, absolute for the float formats): say when their spacing is coarse
     * for the grid. */
    {
        const clvox_grid *grid = &res->grid;
        double far = 0, hmin = fmin(grid->voxel_size[0], fmin(grid->voxel_size[1], grid->voxel_size[2])), off[3];
        clvox_mesh_vertex_offset(mesh, off); /* vertices are stored relative to it */
        for (int k = 0; k < 3; k++)
            far = fmax(far, fmax(fabs(report->bbox_min[k] - off[k]), fabs(report->bbox_max[k] - off[k])));
        float f = (float)far;
        double ulp = (double)nextafterf(f, INFINITY) - (double)f;
        if (isfinite(ulp) && hmin > 0 && ulp > hmin / 64)
            record_warning(res,
                           "vertices are stored as 32-bit floats: near %.6g they lie on a %.3g spacing, %.0f %% of a "
                           "voxel, so the volume is only that precise (move the mesh near the origin for a finer "
                           "grid)",
                           far, ulp, 100.0 * ulp / hmin);
    }
    if (solid && !winding && report->duplicate_triangles > 0)
        record_warning(res,
                       "%llu triangles repeat the corners of another one (duplicated or coincident surfaces): the "
                       "parity rule cancels coincident copies, which is right where two solids touch face to face "
                       "(clvox mesh exports) but makes a doubled shell voxelize as empty",
                       (unsigned long long)report->duplicate_triangles);
    res->status = "ok";

done:
    res->rc = rc;
    if (rc != EXIT_OK) {
        snprintf(res->error, sizeof res->error, "%s", cli_last_error());
        res->status = rc == EXIT_CANCELLED ? "cancelled" : "failed";
        if (rc == EXIT_CANCELLED) res->fatal = 1;
    }
    g_fail_prefix = saved_prefix;
    clvox_mesh_destroy(mesh);
    res->wall_seconds = now_seconds() - wall_start;
    return rc;
}

void vox_print_warnings(const vox_session *s, const vox_job *job, const vox_result *res)
{
    for (int i = 0; i < res->warning_count; i++) {
        if (s->batch) warn("%s: %s", job->source ? job->source : job->mesh, res->warnings[i]);
        else warn("%s", res->warnings[i]);
    }
}

/* ---- --json ------------------------------------------------------------------------ */

static void json_channels(jbuf *b, const char *key, uint32_t mask)
{
    static const char *const names[] = {"occupancy", "coverage", "element", "score"};
    jb_arr_begin(b, key);
    for (int i = 0; i < 4; i++)
        if (mask & (1u << i)) jb_str(b, NULL, names[i]);
    jb_arr_end(b);
}

void vox_result_json(const vox_session *s, const vox_job *job, const vox_result *res, jbuf *b)
{
    const cli_args *a = s->a;
    const clvox_stats *st = &res->stats;
    const clvox_mesh_report *r = &res->report;
    jb_obj_begin(b, NULL);
    jb_str(b, "type", "mesh");
    if (job->n >= 0) jb_i64(b, "n", job->n);
    else jb_null(b, "n");
    jb_str(b, "status", res->status);
    jb_i64(b, "exit_code", res->rc);
    jb_str(b, "error", res->rc != EXIT_OK ? res->error : NULL);
    jb_path(b, "input", job->mesh);
    if (job->line) {
        jb_path(b, "manifest", job->source); /* "FILE:LINE" */
        jb_u64(b, "line", job->line);
    }
    jb_path(b, "output", job->output);
    if (res->have_stats) jb_u64(b, "output_size", res->output_size);
    else jb_null(b, "output_size");

    if (res->have_report) {
        jb_obj_begin(b, "mesh");
        jb_u64(b, "vertices", r->vertices);
        jb_u64(b, "triangles", r->triangles);
        jb_u64(b, "input_vertices", r->input_vertices);
        jb_u64(b, "input_faces", r->input_faces);
        jb_u64(b, "polygons_triangulated", r->polygons_triangulated);
        jb_u64(b, "dropped_faces", r->dropped_faces);
        jb_u64(b, "degenerate_triangles", r->degenerate_triangles);
        jb_u64(b, "nonmanifold_faces", r->nonmanifold_faces);
        jb_u64(b, "boundary_edges", r->boundary_edges);
        jb_u64(b, "duplicate_triangles", r->duplicate_triangles);
        jb_bool(b, "closed", r->closed);
        jb_num3(b, "bbox_min", r->bbox_min);
        jb_num3(b, "bbox_max", r->bbox_max);
        jb_num(b, "enclosed_volume", r->enclosed_volume);
        if (!strcmp(res->source.reader, "assimp")) { /* only for scenes: other records stay as they were */
            jb_obj_begin(b, "scene");
            jb_u64(b, "meshes", res->source.meshes);
            jb_u64(b, "placements", res->source.placements);
            jb_u64(b, "ignored_lines", res->source.ignored_lines);
            jb_u64(b, "ignored_points", res->source.ignored_points);
            if (res->source.unit_metres > 0) jb_num(b, "unit_metres", res->source.unit_metres);
            else jb_null(b, "unit_metres");
            jb_obj_end(b);
        }
        jb_obj_end(b);
    } else {
        jb_null(b, "mesh");
    }
    if (res->have_grid) {
        jb_obj_begin(b, "grid");
        jb_u32x3(b, "dims", res->grid.dims);
        jb_num3(b, "origin", res->grid.origin);
        jb_num3(b, "voxel_size", res->grid.voxel_size);
        jb_u64(b, "voxels", (uint64_t)res->grid.dims[0] * res->grid.dims[1] * res->grid.dims[2]);
        jb_path(b, "like", a->like);
        jb_obj_end(b);
    } else {
        jb_null(b, "grid");
    }

    static const char *const axes[] = {"x", "x", "y", "z"};
    int ax = (int)a->vox.ray_axis;
    jb_str(b, "mode", clvox_mode_name(a->vox.mode));
    jb_str(b, "method", a->vox.mode == CLVOX_MODE_SURFACE ? "surface"
                        : a->vox.method == CLVOX_METHOD_TETRA ? "tetra"
                                                               : "ray");
    jb_obj_begin(b, "parameters");
    jb_str(b, "axis", axes[ax >= 0 && ax <= 3 ? ax : 0]);
    jb_u64(b, "max_depth", a->vox.quadtree_max_depth);
    jb_u64(b, "leaf_size", a->vox.quadtree_leaf_size);
    jb_u64(b, "slab", a->vox.slab_depth);
    jb_num(b, "weld", a->vox.weld);
    jb_str(b, "compression", compression_name(effective_compression(a)));
    if (a->vox.method == CLVOX_METHOD_TETRA) {
        if (a->vox.tetra_origin == CLVOX_TETRA_ORIGIN_POINT) jb_num3(b, "tetra_origin", a->vox.tetra_point);
        else jb_str(b, "tetra_origin", a->vox.tetra_origin == CLVOX_TETRA_ORIGIN_BBOX_CENTER ? "bbox" : "centroid");
    }
    if (a->vox.oversample || s->palette) {
        uint32_t N = a->vox.oversample ? a->vox.oversample : 4;
        uint32_t M = a->vox.oversample_points ? a->vox.oversample_points : a->vox.oversample ? N : 16;
        jb_u64(b, "oversample", N);
        jb_u64(b, "oversample_points", M);
        jb_bool(b, "stochastic", a->vox.stochastic);
        jb_u64(b, "seed", a->vox.seed);
    }
    if (a->vox.threshold_set) jb_num(b, "threshold", a->vox.threshold);
    if (s->palette) {
        jb_str(b, "palette", clvox_palette_name(s->palette));
        jb_str(b, "metric", clvox_metric_name(a->vox.metric));
    }
    jb_obj_end(b);

    const clvox_device_info *dev = s->dev ? clvox_context_device(s->dev) : NULL;
    if (dev && res->have_stats) {
        jb_obj_begin(b, "device");
        jb_str(b, "name", dev->name);
        jb_str(b, "type", dev->type);
        jb_str(b, "platform", dev->platform);
        jb_str(b, "kernels", dev->kernels_float ? "float" : "double");
        jb_num(b, "fp64_slowdown", dev->fp64_slowdown);
        jb_obj_end(b);
        /* every device of the run, with its part */
        jb_arr_begin(b, "devices");
        for (uint32_t i = 0; i < st->device_count; i++) {
            const clvox_device_share *d = &st->devices[i];
            const clvox_device_info *di = clvox_context_device_at(s->dev, d->device);
            jb_obj_begin(b, NULL);
            jb_u64(b, "index", d->device);
            jb_str(b, "name", di ? di->name : "");
            jb_str(b, "type", di ? di->type : "");
            jb_str(b, "kernels", di && di->kernels_float ? "float" : "double");
            jb_u64(b, "slabs", d->slabs);
            jb_u64(b, "slices", d->slices);
            jb_num(b, "busy_s", d->busy_seconds);
            jb_u64(b, "discarded_slabs", d->discarded_slabs);
            jb_bool(b, "failed", d->failed);
            jb_bool(b, "left_out", d->left_out);
            jb_obj_end(b);
        }
        jb_arr_end(b);
        jb_num(b, "scheduling_efficiency", st->scheduling_efficiency);
    } else {
        jb_null(b, "device");
    }

    if (res->have_stats) {
        const int grey = (st->channels & CLVOX_CHANNEL_COVERAGE) != 0;
        json_channels(b, "channels", st->channels);
        jb_u64(b, "filled_voxels", s->palette ? st->palette_nonempty_voxels : st->filled_voxels);
        jb_u64(b, "total_voxels", st->total_voxels);
        jb_obj_begin(b, "volume");
        jb_num(b, "voxels", voxels_volume((double)st->filled_voxels, res->grid.voxel_size));
        if (grey) jb_num(b, "coverage", voxels_volume(st->coverage_sum, res->grid.voxel_size));
        if (s->palette) jb_num(b, "elements", voxels_volume(st->palette_volume, res->grid.voxel_size));
        jb_num(b, "mesh", r->enclosed_volume);
        jb_obj_end(b);
        jb_u64(b, "samples_per_voxel", st->samples_per_voxel);
        if (grey) jb_num(b, "coverage_sum", st->coverage_sum);
        else jb_null(b, "coverage_sum");
        if (s->palette) {
            jb_obj_begin(b, "palette");
            jb_str(b, "name", clvox_palette_name(s->palette));
            jb_u64(b, "elements", clvox_palette_count(s->palette));
            jb_str(b, "metric", clvox_metric_name(a->vox.metric));
            jb_u64(b, "early_voxels", st->palette_early_voxels);
            jb_u64(b, "shortcut_voxels", st->palette_shortcut_voxels);
            jb_u64(b, "scored_voxels", st->palette_scored_voxels);
            jb_u64(b, "nonempty_voxels", st->palette_nonempty_voxels);
            jb_num(b, "volume", st->palette_volume);
            jb_obj_end(b);
        } else {
            jb_null(b, "palette");
        }
        jb_obj_begin(b, "rays");
        jb_u64(b, "cast", st->rays);
        jb_u64(b, "odd_parity", st->odd_parity_rays);
        jb_u64(b, "overflow", st->overflow_rays);
        jb_u64(b, "max_crossings", st->max_crossings);
        jb_obj_end(b);
        jb_obj_begin(b, "quadtree");
        jb_u64(b, "depth", st->quadtree_depth);
        jb_u64(b, "leaves", st->quadtree_leaves);
        jb_u64(b, "refs", st->quadtree_refs);
        jb_obj_end(b);
        jb_u64(b, "slab_depth", st->slab_depth);
        if (a->vox.mode != CLVOX_MODE_SURFACE)
            jb_str(b, "inside", clvox_inside_name(st->inside));
        else
            jb_null(b, "inside");
        if (st->inside == CLVOX_INSIDE_WINDING || st->inside == CLVOX_INSIDE_WINDING_ABS) {
            const clvox_winding_report *w = &st->winding;
            jb_obj_begin(b, "winding");
            jb_u64(b, "merged_vertices", w->merged_vertices);
            jb_u64(b, "welded_vertices", w->welded_vertices);
            jb_u64(b, "dropped_triangles", w->dropped_triangles);
            jb_u64(b, "components", w->components);
            jb_u64(b, "closed_components", w->closed_components);
            jb_u64(b, "cavities", w->cavities);
            jb_u64(b, "flipped_triangles", w->flipped_triangles);
            jb_u64(b, "nonmanifold_edges", w->nonmanifold_edges);
            jb_u64(b, "nonorientable_components", w->nonorientable_components);
            jb_u64(b, "boundary_edges", w->boundary_edges);
            jb_u64(b, "holes", w->holes);
            jb_u64(b, "cap_triangles", w->cap_triangles);
            jb_u64(b, "exact_points", w->exact_points);
            jb_u64(b, "host_points", st->winding_host_points);
            jb_num(b, "seconds", w->seconds);
            jb_num(b, "exact_seconds", st->winding_exact_seconds);
            if (w->exact_points)
                jb_num(b, "seconds_per_exact_point", st->winding_exact_seconds / (double)w->exact_points);
            else
                jb_null(b, "seconds_per_exact_point");
            if (st->crack_pairs) { /* the certified crack weld (docs/design.md "Cracks") */
                jb_obj_begin(b, "crack_weld");
                jb_num(b, "distance", st->crack_weld_distance);
                jb_u64(b, "welded_vertices", st->crack_welded_vertices);
                jb_u64(b, "pairs", st->crack_pairs);
                jb_u64(b, "holes_left", st->crack_holes);
                jb_obj_end(b);
            } else {
                jb_null(b, "crack_weld");
            }
            jb_obj_end(b);
        } else {
            jb_null(b, "winding");
        }
    } else {
        static const char *const absent[] = {"channels", "filled_voxels", "total_voxels", "volume",
                                             "samples_per_voxel", "coverage_sum", "palette", "rays", "quadtree",
                                             "slab_depth", "inside", "winding"};
        for (size_t i = 0; i < sizeof absent / sizeof absent[0]; i++) jb_null(b, absent[i]);
    }
    jb_obj_begin(b, "seconds");
    jb_num(b, "load", res->load_seconds);
    jb_num(b, "setup", res->setup_seconds);
    jb_num(b, "partition", st->seconds[CLVOX_STAGE_PARTITION]);
    jb_num(b, "cast", st->seconds[CLVOX_STAGE_CAST]);
    jb_num(b, "classify", st->seconds[CLVOX_STAGE_CLASSIFY]);
    jb_num(b, "write", st->seconds[CLVOX_STAGE_WRITE]);
    jb_num(b, "total", st->seconds[CLVOX_STAGE_TOTAL]);
    jb_num(b, "wall", res->wall_seconds);
    jb_obj_end(b);
    jb_arr_begin(b, "warnings");
    for (int i = 0; i < res->warning_count; i++) jb_str(b, NULL, res->warnings[i]);
    jb_arr_end(b);
    jb_obj_end(b);
}
