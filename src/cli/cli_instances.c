/* SPDX-License-Identifier: Apache-2.0 */
/*
 * clvox instances VOLUME.exr -o OUT.csv [--render-map MAP] [--palette NAME|FILE]
 *
 * One CSV row per non-empty voxel (element != 0) of a palette volume: the
 * instances a renderer places to draw it (Cavagnino & Gribaudo, section 4;
 * scripts/tools/blender_instances.py builds a Blender scene from them). Columns:
 *
 *   i,j,k        the voxel
 *   x,y,z        world position of its centre, origin + (i + 0.5) * h per axis
 *   hx,hy,hz     voxel size
 *   element      element index in the palette, name, basic element name
 *   name,basic
 *   s00..s22     the signed permutation S, row by row, that maps the basic
 *                element onto this one: element = { S (p - 1/2) + 1/2 : p in
 *                basic } (clvox_palette_element_info.matrix)
 *   score        B_v in [0,1]
 *   object       the render object: the render map's choice for (element,
 *                score), or the basic element's name without a map
 *   frame        basic: the object is modelled as the basic element, so the
 *                instance's matrix is T(x,y,z) diag(hx,hy,hz) S; element: it
 *                is modelled as this element itself, T diag(h), no S
 *
 * Names are 1-63 of A-Z a-z 0-9 _ - . so no field needs quoting. Numbers are
 * the shortest decimal text that reads back to the same double (positions,
 * sizes) or float (score).
 *
 * Streaming: the element and score channels are read in step, one slice of
 * each at a time: two readers (clvox_volume_read_slices, each on its own
 * host-only context) run in two threads, the score reader one slice ahead at
 * most, so memory is O(slice) whatever Z is.
 *
 * The CSV is written like every clvox output (clvox_output_file_*): a
 * file without a name in the directory of OUT, synced, then named OUT; a
 * failure leaves nothing, and nothing but a regular file at OUT is replaced.
 */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include "cli_common.h"

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define CSV_HEADER "i,j,k,x,y,z,hx,hy,hz,element,name,basic,s00,s01,s02,s10,s11,s12,s20,s21,s22,score,object,frame\n"

static void print_instances_help(void)
{
    fputs(
"Usage: clvox instances VOLUME.exr -o OUT.csv [--render-map MAP]\n"
"                       [--palette NAME|FILE]\n"
"\n"
"Lists the instances that draw a palette volume (one written with --palette):\n"
"one CSV row per voxel whose element is not 0 (empty), with a header row:\n"
"  i,j,k       the voxel\n"
"  x,y,z       world position of its centre: origin + (i + 0.5) * h per axis\n"
"  hx,hy,hz    voxel size\n"
"  element,name,basic\n"
"              element index, its name and its basic element's name\n"
"  s00..s22    the signed permutation S (row by row) that maps the basic\n"
"              element onto this one: element = { S (p - 1/2) + 1/2 : p in\n"
"              basic } (clvox palette show prints it)\n"
"  score       the element's score B in [0, 1]\n"
"  object      the render object (see --render-map)\n"
"  frame       basic: the object is modelled as the basic element, the\n"
"              instance matrix is translate(x,y,z) scale(hx,hy,hz) S;\n"
"              element: modelled as this element, no S\n"
"Reads the element and score channels slice by slice (memory: a few slices).\n"
"Needs no OpenCL device. scripts/tools/blender_instances.py renders the CSV.\n"
"\n"
"Options:\n"
"  -o, --output OUT.csv     the table (required); written without a name in\n"
"                           the same directory and named OUT.csv on success;\n"
"                           never replaces anything but a regular file\n"
"  --render-map MAP         objects per element and score (docs/design.md\n"
"                           \"Render maps, instances and Blender\"; examples:\n"
"                           palettes/paper46.render, palettes/blocks.render).\n"
"                           Without it every element is drawn with one object\n"
"                           named after its basic element (frame basic)\n"
"  --palette NAME|FILE      the palette the volume was scored with: a built-in\n"
"                           name or a palette file (default: the one recorded\n"
"                           in the volume's header; when the header records one,\n"
"                           this must be the same palette)\n"
"  -h, --help               print this help and exit\n"
"\n"
"At the end one summary line: rows written and rows per object.\n"
"Exit codes: 0 ok, 2 usage error, 4 VOLUME missing, not a palette volume or\n"
"holding a value that is no element of the palette or a score outside [0, 1],\n"
"or a bad render map or palette (FILE:LINE: why), 5 OUT.csv can not be\n"
"written, 1 other failures. Errors are one line on stderr; a failed run leaves\n"
"no file.\n", stdout);
}

/* ---- the palette's elements, once ---------------------------------------------- */

typedef struct element_row {
    char name[64];
    char basic[64];
    int32_t s[3][3];
} element_row;

/* ---- two readers in step ------------------------------------------------------- */

typedef struct score_feed {
    pthread_mutex_t mu;
    pthread_cond_t cv;
    clvox_context *ctx;          /* the score reader's own */
    const char *path;
    clvox_volume_info info;
    float *slice;                /* X*Y scores of slice z, when full */
    size_t slice_len;
    uint32_t z;
    int full;                    /* a slice is waiting for the element reader */
    int done;                    /* the score reader returned */
    clvox_status status;         /* ... with this */
    int cancel;                  /* the element side stopped: return at once */
    int oom;
} score_feed;

static int on_score(void *user, uint32_t z, const float *values)
{
    score_feed *f = user;
    size_t n = (size_t)f->info.dims[0] * f->info.dims[1];
    pthread_mutex_lock(&f->mu);
    while (f->full && !f->cancel) pthread_cond_wait(&f->cv, &f->mu);
    int stop = f->cancel;
    if (!stop && !f->slice) {
        f->slice = malloc(n ? n * sizeof *f->slice : 1);
        f->slice_len = n;
        if (!f->slice) stop = f->oom = 1;
    }
    if (!stop) {
        memcpy(f->slice, values, n * sizeof *values);
        f->z = z;
        f->full = 1;
        pthread_cond_broadcast(&f->cv);
    }
    pthread_mutex_unlock(&f->mu);
    return stop;
}

static void *score_main(void *arg)
{
    score_feed *f = arg;
    f->info.size = sizeof f->info;
    clvox_status st = clvox_volume_read_slices(f->ctx, f->path, "score", &f->info, on_score, f);
    pthread_mutex_lock(&f->mu);
    f->done = 1;
    f->status = st;
    pthread_cond_broadcast(&f->cv);
    pthread_mutex_unlock(&f->mu);
    return NULL;
}

/* ---- the element side: rows ------------------------------------------------------ */

typedef struct job {
    const char *path, *output;
    const clvox_palette *palette;
    const char *palette_name;
    const clvox_render_map *map;
    const element_row *elements;
    size_t element_count;
    FILE *out;
    score_feed *feed;
    clvox_volume_info info;      /* the element reader's header */
    int started;
    uint64_t rows;
    uint64_t *per_object;
    int failed;                  /* why holds the message, code the exit code */
    int code;
    char why[1024];
} job;

static int job_fail(job *j, int code, const char *fmt, ...) CLI_PRINTF(3, 4);
static int job_fail(job *j, int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(j->why, sizeof j->why, fmt, ap);
    va_end(ap);
    j->failed = 1;
    j->code = code;
    return 1;
}

/* The shortest "%.Ng" text of v that reads back as the same double. */
static void fmt_double(char *buf, size_t size, double v)
{
    for (int p = 15; p <= 17; p++) {
        snprintf(buf, size, "%.*g", p, v);
        if (strtod(buf, NULL) == v) return;
    }
}

/* The same for a float. */
static void fmt_float(char *buf, size_t size, float v)
{
    for (int p = 6; p <= 9; p++) {
        snprintf(buf, size, "%.*g", p, (double)v);
        if (strtof(buf, NULL) == v) return;
    }
}

/* The header is in j->info before the first slice: checks it. */
static int job_start(job *j)
{
    const clvox_volume_info *in = &j->info;
    if (!has_channel(in->channels, "score"))
        return job_fail(j, EXIT_INPUT,
                        "'%s' has no score channel (has: %s): instances need the element and score channels of a "
                        "palette run",
                        j->path, in->channels);
    if (in->palette_hash && in->palette_hash != clvox_palette_hash(j->palette))
        return job_fail(j, EXIT_INPUT, "'%s' was scored with palette '%s' (%u elements), not with '%s' (%zu elements)",
                        j->path, in->palette, in->palette_count, j->palette_name, j->element_count);
    static const char header[] = CSV_HEADER;
    if (fputs(header, j->out) == EOF)
        return job_fail(j, EXIT_OUTPUT, "writing '%s' failed: %s", j->output, strerror(errno));
    j->started = 1;
    return 0;
}

static int write_slice(job *j, uint32_t z, const float *element, const float *score)
{
    const clvox_volume_info *in = &j->info;
    const uint32_t X = in->dims[0], Y = in->dims[1];
    char cx[40], cy[40], cz[40], hx[40], hy[40], hz[40], sc[40];
    fmt_double(hx, sizeof hx, in->voxel_size[0]);
    fmt_double(hy, sizeof hy, in->voxel_size[1]);
    fmt_double(hz, sizeof hz, in->voxel_size[2]);
    fmt_double(cz, sizeof cz, in->origin[2] + ((double)z + 0.5) * in->voxel_size[2]);
    for (uint32_t y = 0; y < Y; y++) {
        const float *er = element + (size_t)y * X, *sr = score + (size_t)y * X;
        int row_y = 0;
        for (uint32_t x = 0; x < X; x++) {
            float ev = er[x];
            if (ev == 0.0f) continue;
            if (!(ev >= 1.0f && (double)ev < (double)j->element_count && ev == floorf(ev)))
                return job_fail(j, EXIT_INPUT,
                                "'%s': voxel (%u,%u,%u) holds element %.9g, not an element of palette '%s' (0 to %zu)",
                                j->path, x, y, z, (double)ev, j->palette_name, j->element_count - 1);
            float s = sr[x];
            if (!(s >= 0.0f && s <= 1.0f))
                return job_fail(j, EXIT_INPUT, "'%s': voxel (%u,%u,%u) has score %.9g, outside [0, 1]", j->path, x, y,
                                z, (double)s);
            uint32_t e = (uint32_t)ev;
            clvox_render_frame frame = CLVOX_RENDER_FRAME_BASIC;
            uint32_t obj = clvox_render_map_choose(j->map, e, (double)s, &frame);
            const char *oname = clvox_render_map_object_name(j->map, obj);
            if (!oname) return job_fail(j, EXIT_RUNTIME, "internal error: no render object for element %u", e);
            if (!row_y) {
                fmt_double(cy, sizeof cy, in->origin[1] + ((double)y + 0.5) * in->voxel_size[1]);
                row_y = 1;
            }
            fmt_double(cx, sizeof cx, in->origin[0] + ((double)x + 0.5) * in->voxel_size[0]);
            fmt_float(sc, sizeof sc, s);
            const element_row *el = &j->elements[e];
            const int32_t(*m)[3] = el->s;
            if (fprintf(j->out, "%u,%u,%u,%s,%s,%s,%s,%s,%s,%u,%s,%s,%d,%d,%d,%d,%d,%d,%d,%d,%d,%s,%s,%s\n", x, y, z, cx,
                        cy, cz, hx, hy, hz, e, el->name, el->basic, (int)m[0][0], (int)m[0][1], (int)m[0][2],
                        (int)m[1][0], (int)m[1][1], (int)m[1][2], (int)m[2][0], (int)m[2][1], (int)m[2][2], sc, oname,
                        frame == CLVOX_RENDER_FRAME_ELEMENT ? "element" : "basic") < 0)
                return job_fail(j, EXIT_OUTPUT, "writing '%s' failed: %s", j->output, strerror(errno));
            j->rows++;
            j->per_object[obj]++;
        }
    }
    if (ferror(j->out)) return job_fail(j, EXIT_OUTPUT, "writing '%s' failed: %s", j->output, strerror(errno));
    return 0;
}

static int on_element(void *user, uint32_t z, const float *values)
{
    job *j = user;
    if (!j->started && job_start(j)) return 1;
    score_feed *f = j->feed;
    pthread_mutex_lock(&f->mu);
    while (!f->full && !f->done) pthread_cond_wait(&f->cv, &f->mu);
    int have = f->full;
    pthread_mutex_unlock(&f->mu);
    if (!have) return 1; /* the score reader stopped: its status says why */
    if (f->z != z || f->slice_len != (size_t)j->info.dims[0] * j->info.dims[1])
        return job_fail(j, EXIT_RUNTIME, "internal error: score slice %u next to element slice %u", f->z, z);
    int stop = write_slice(j, z, values, f->slice); /* the score reader waits while full */
    pthread_mutex_lock(&f->mu);
    f->full = 0;
    pthread_cond_broadcast(&f->cv);
    pthread_mutex_unlock(&f->mu);
    return stop;
}

/* ---- command ----------------------------------------------------------------------- */

#define INST_USAGE(...) fail(EXIT_USAGE, __VA_ARGS__)

static int is_builtin_palette(const char *name)
{
    for (size_t i = 0; clvox_palette_builtin_name(i); i++)
        if (strcmp(name, clvox_palette_builtin_name(i)) == 0) return 1;
    return 0;
}

static int same_file(const char *a, const char *b)
{
    struct stat sa, sb;
    return stat(a, &sa) == 0 && stat(b, &sb) == 0 && sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

static int load_palette(clvox_context *ctx, const char *volume, const char *given, clvox_palette **out)
{
    clvox_status st;
    if (!given) {
        st = clvox_volume_palette(ctx, volume, out);
        if (st != CLVOX_OK) return fail_status(ctx, st, ROLE_INPUT);
        return EXIT_OK;
    }
    if (is_builtin_palette(given)) st = clvox_palette_builtin(ctx, given, out);
    else {
        struct stat sb;
        if (stat(given, &sb) != 0)
            return INST_USAGE("instances: --palette '%s': not a built-in palette (binary, planar10, paper46, paper78) "
                              "and no such file",
                              given);
        st = clvox_palette_load(ctx, given, out);
    }
    return st == CLVOX_OK ? EXIT_OK : fail_status(ctx, st, ROLE_INPUT);
}

static int load_elements(clvox_context *ctx, const clvox_palette *p, element_row **out)
{
    size_t n = clvox_palette_count(p);
    element_row *rows = calloc(n ? n : 1, sizeof *rows);
    if (!rows) return fail(EXIT_RUNTIME, "out of memory");
    uint32_t *basic = malloc((n ? n : 1) * sizeof *basic);
    if (!basic) {
        free(rows);
        return fail(EXIT_RUNTIME, "out of memory");
    }
    for (size_t e = 0; e < n; e++) { /* once per element: a file palette's volume is sampled each call */
        clvox_palette_element_info info = CLVOX_PALETTE_ELEMENT_INFO_INIT;
        clvox_status st = clvox_palette_element_info_get(ctx, p, e, &info);
        if (st != CLVOX_OK) {
            free(basic);
            free(rows);
            return fail_status(ctx, st, ROLE_OTHER);
        }
        snprintf(rows[e].name, sizeof rows[e].name, "%s", info.name);
        memcpy(rows[e].s, info.matrix, sizeof rows[e].s);
        basic[e] = info.basic < n ? info.basic : (uint32_t)e;
    }
    for (size_t e = 0; e < n; e++) memcpy(rows[e].basic, rows[basic[e]].name, sizeof rows[e].basic);
    free(basic);
    *out = rows;
    return EXIT_OK;
}

/* Reads the volume and writes the rows to j->out; EXIT_OK or the reported failure. */
static int stream_rows(clvox_context *ctx, job *j)
{
    score_feed *f = j->feed;
    pthread_t thread;
    int err = pthread_create(&thread, NULL, score_main, f);
    if (err) return fail(EXIT_RUNTIME, "cannot start the score reader: %s", strerror(err));
    j->info.size = sizeof j->info;
    clvox_status st = clvox_volume_read_slices(ctx, j->path, "element", &j->info, on_element, j);
    pthread_mutex_lock(&f->mu);
    f->cancel = 1;
    pthread_cond_broadcast(&f->cv);
    pthread_mutex_unlock(&f->mu);
    pthread_join(thread, NULL);

    if (j->failed) return fail(j->code, "%s", j->why);
    if (st == CLVOX_ERR_EXR && j->info.dims[0] && !has_channel(j->info.channels, "element"))
        return fail(EXIT_INPUT, "'%s' has no element channel (has: %s): not a palette volume (voxelize with --palette)",
                    j->path, j->info.channels);
    if (st != CLVOX_OK && st != CLVOX_ERR_CANCELLED) return fail_status(ctx, st, ROLE_INPUT);
    if (f->oom) return fail(EXIT_RUNTIME, "out of memory for a slice of '%s'", j->path);
    if (f->status != CLVOX_OK && f->status != CLVOX_ERR_CANCELLED) return fail_status(f->ctx, f->status, ROLE_INPUT);
    if (st != CLVOX_OK) return fail(EXIT_RUNTIME, "internal error: the element reader stopped without a reason");
    if (!j->started) { /* no slice at all: cannot happen for a valid volume, but write the header */
        if (job_start(j)) return fail(j->code, "%s", j->why);
    }
    return EXIT_OK;
}

/* Writes the CSV to a file without a name and names it `output` once complete. */
static int write_csv(clvox_context *ctx, job *j)
{
    clvox_output_file *of = NULL;
    clvox_status st = clvox_output_file_create(ctx, j->output, &of);
    if (st != CLVOX_OK) return fail_status(ctx, st, ROLE_OUTPUT);
    int fd2 = dup(clvox_output_file_fd(of)); /* the stream's own descriptor: the file's stays open for the commit */
    FILE *f = fd2 >= 0 ? fdopen(fd2, "wb") : NULL;
    if (!f) {
        int e = errno;
        if (fd2 >= 0) close(fd2);
        clvox_output_file_discard(of);
        return fail(EXIT_RUNTIME, "cannot write '%s': %s", j->output, strerror(e));
    }
    setvbuf(f, NULL, _IOFBF, 1 << 18);
    j->out = f;
    int rc = stream_rows(ctx, j);
    if (rc == EXIT_OK && fflush(f) != 0) rc = fail(EXIT_OUTPUT, "writing '%s' failed: %s", j->output, strerror(errno));
    if (rc == EXIT_OK && fsync(fileno(f)) != 0) /* on disk before it gets its name */
        rc = fail(EXIT_OUTPUT, "writing '%s' failed: %s", j->output, strerror(errno));
    if (fclose(f) != 0 && rc == EXIT_OK) rc = fail(EXIT_OUTPUT, "writing '%s' failed: %s", j->output, strerror(errno));
    j->out = NULL;
    if (rc != EXIT_OK) {
        clvox_output_file_discard(of);
        return rc;
    }
    st = clvox_output_file_commit(of, NULL);
    return st == CLVOX_OK ? EXIT_OK : fail_status(ctx, st, ROLE_OUTPUT);
}

static void print_summary(const job *j, const char *map_path)
{
    const clvox_volume_info *in = &j->info;
    printf("wrote %s: %llu rows (non-empty voxels of %u x %u x %u), palette %s, render map %s; objects:", j->output,
           (unsigned long long)j->rows, in->dims[0], in->dims[1], in->dims[2], j->palette_name,
           map_path ? map_path : "none (basic element names)");
    int any = 0;
    size_t n = clvox_render_map_object_count(j->map);
    for (size_t o = 0; o < n; o++)
        if (j->per_object[o]) {
            printf("%s %s %llu", any ? "," : "", clvox_render_map_object_name(j->map, o),
                   (unsigned long long)j->per_object[o]);
            any = 1;
        }
    printf("%s\n", any ? "" : " none");
}

int cmd_instances(int argc, char **argv)
{
    const char *file = NULL, *output = NULL, *map_path = NULL, *palette_arg = NULL;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        const char *v = NULL;
        int missing = 0;
        if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
            print_instances_help();
            return EXIT_OK;
        }
        if (a[0] != '-' || a[1] == '\0') {
            if (file)
                return INST_USAGE("instances: more than one volume given: '%s' and '%s' (see clvox instances --help)",
                                  file, a);
            file = a;
        } else if (match_value(argc, argv, &i, "-o", "--output", &v, &missing)) {
            if (missing || !*v) return INST_USAGE("instances: -o needs a file name (see clvox instances --help)");
            output = v;
        } else if (match_value(argc, argv, &i, NULL, "--render-map", &v, &missing)) {
            if (missing || !*v) return INST_USAGE("instances: --render-map needs a file (see clvox instances --help)");
            map_path = v;
        } else if (match_value(argc, argv, &i, NULL, "--palette", &v, &missing)) {
            if (missing || !*v)
                return INST_USAGE("instances: --palette needs a name or a file (see clvox instances --help)");
            palette_arg = v;
        } else {
            return INST_USAGE("instances: unknown option '%s' (see clvox instances --help)", a);
        }
    }
    if (!file) return INST_USAGE("instances: missing VOLUME.exr (see clvox instances --help)");
    if (!output) return INST_USAGE("instances: missing -o OUT.csv (see clvox instances --help)");
    int rc = check_output(output);
    if (rc != EXIT_OK) return rc;
    if (same_file(output, file)) return INST_USAGE("instances: the output '%s' is the input volume", output);
    if (map_path && same_file(output, map_path)) return INST_USAGE("instances: the output '%s' is the render map", output);
    if (palette_arg && same_file(output, palette_arg))
        return INST_USAGE("instances: the output '%s' is the palette file", output);
    struct stat sb;
    if (stat(file, &sb) != 0) return fail(EXIT_INPUT, "cannot open '%s': %s", file, strerror(errno));

    clvox_context *ctx = NULL, *ctx2 = NULL;
    clvox_palette *palette = NULL;
    clvox_render_map *map = NULL;
    element_row *elements = NULL;
    uint64_t *per_object = NULL;
    score_feed feed;
    memset(&feed, 0, sizeof feed);
    int sync_made = 0;
    clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
    co.host_only = 1;
    clvox_status st = clvox_context_create(&co, &ctx);
    if (st == CLVOX_OK) {
        st = clvox_context_create(&co, &ctx2);
        if (st != CLVOX_OK) {
            rc = fail_status(ctx2, st, ROLE_OTHER);
            goto done;
        }
    } else {
        rc = fail_status(ctx, st, ROLE_OTHER);
        goto done;
    }
    if ((rc = load_palette(ctx, file, palette_arg, &palette)) != EXIT_OK) goto done;
    st = map_path ? clvox_render_map_load(ctx, map_path, palette, &map) : clvox_render_map_default(ctx, palette, &map);
    if (st != CLVOX_OK) {
        rc = st == CLVOX_ERR_IO ? fail(EXIT_INPUT, "%s", clvox_context_error(ctx)) : fail_status(ctx, st, ROLE_INPUT);
        goto done;
    }
    if ((rc = load_elements(ctx, palette, &elements)) != EXIT_OK) goto done;
    per_object = calloc(clvox_render_map_object_count(map) + 1, sizeof *per_object);
    if (!per_object) {
        rc = fail(EXIT_RUNTIME, "out of memory");
        goto done;
    }
    if (pthread_mutex_init(&feed.mu, NULL) != 0 || (pthread_cond_init(&feed.cv, NULL) != 0 &&
                                                    (pthread_mutex_destroy(&feed.mu), 1))) {
        rc = fail(EXIT_RUNTIME, "cannot create a mutex");
        goto done;
    }
    sync_made = 1;
    feed.ctx = ctx2;
    feed.path = file;

    job j;
    memset(&j, 0, sizeof j);
    j.path = file;
    j.output = output;
    j.palette = palette;
    j.palette_name = clvox_palette_name(palette);
    j.map = map;
    j.elements = elements;
    j.element_count = clvox_palette_count(palette);
    j.feed = &feed;
    j.per_object = per_object;
    rc = write_csv(ctx, &j);
    if (rc == EXIT_OK) print_summary(&j, map_path);

done:
    if (sync_made) {
        pthread_cond_destroy(&feed.cv);
        pthread_mutex_destroy(&feed.mu);
    }
    free(feed.slice);
    free(per_object);
    free(elements);
    clvox_render_map_destroy(map);
    clvox_palette_destroy(palette);
    clvox_context_destroy(ctx2);
    clvox_context_destroy(ctx);
    return rc;
}
