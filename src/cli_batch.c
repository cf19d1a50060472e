/*
 * clvox batch: many meshes in one process, with one host context, one
 * OpenCL context and one kernel build (vox_session, cli_run.c), each mesh run by
 * vox_run as `clvox MESH` runs it.
 *
 *   meshes   MESH arguments, then --dir DIR (its mesh files, sorted by name),
 *            then --manifest FILE (one mesh per line, optional overrides);
 *            n = the position in that list, from 0
 *   outputs  -o TEMPLATE with {stem} {name} {dir} {n} (default {stem}.exr),
 *            or a manifest line's own -o; two meshes may not share one
 *   shards   --shard I/N runs the meshes with n % N == I
 *   results  a progress line per mesh on stderr, a JSON record per mesh on
 *            stdout with --json, a final summary; a failed mesh is recorded
 *            and the batch goes on (--no-keep-going stops it); the exit
 *            status is that of the first failed mesh, 130 when cancelled
 */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include "cli_common.h"
#include "cli_json.h"
#include "cli_vox.h"

#include <dirent.h>
#include <errno.h>
#include <inttypes.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define DEFAULT_TEMPLATE "{stem}.exr"

typedef struct batch_opts {
    const char *dir, *manifest;
    int skip_existing, keep_going;
    uint32_t shard_i, shard_n;
} batch_opts;

typedef struct batch_item {
    char *mesh;
    char *output;             /* expanded, or the manifest line's -o */
    int grid_by;
    clvox_grid_options grid;
    unsigned line;            /* manifest line, 0 if none */
    char *source;             /* "MANIFEST:LINE" or NULL */
} batch_item;

typedef struct batch_list {
    batch_item *items;
    size_t count, cap;
} batch_list;

static void print_batch_help(void)
{
    fputs(
"Usage: clvox batch [MESH...] [--dir DIR] [--manifest FILE] [options]\n"
"\n"
"Voxelizes many meshes in one process: one OpenCL context and one kernel\n"
"build for all of them. Every option of `clvox MESH` applies to every mesh\n"
"(grid, mode, method, oversampling, palette, compression, device, --like,\n"
"--json, -q); -o is a template. With -r, --dims or --voxel-size each mesh\n"
"gets its own box; add --box (or --like) for one frame shared by all.\n"
"\n"
"Meshes, in this order (n = the position in the list, from 0):\n"
"  MESH...                  mesh files\n"
"  --dir DIR                the mesh files in DIR (.obj .off .ply .stl .om, any\n"
"                           case; not recursive), sorted by name\n"
"  --manifest FILE          one mesh per line, optionally followed by overrides\n"
"                           for that mesh: -o OUT, and one of -r N, --dims X,Y,Z,\n"
"                           --voxel-size S[,S,S]. Fields are separated by spaces\n"
"                           or tabs; \"double quotes\" hold a field with spaces (\\\"\n"
"                           and \\\\ inside them); blank lines and lines starting\n"
"                           with # are skipped. Paths are relative to the current\n"
"                           directory. A malformed line stops the batch before\n"
"                           it starts (FILE:LINE: why, exit 2)\n"
"\n"
"Outputs:\n"
"  -o, --output TEMPLATE    output name of each mesh (default {stem}.exr):\n"
"                           {stem} the mesh file name without its extension,\n"
"                           {name} with it, {dir} the mesh's directory (. if\n"
"                           none), {n} its position in the list, {{ and }} braces.\n"
"                           Two meshes with the same output are refused before\n"
"                           the batch starts (use {dir} or {n})\n"
"  --skip-existing          do not voxelize a mesh whose output exists (outputs\n"
"                           are only ever named when complete, so an interrupted\n"
"                           batch resumes where it stopped)\n"
"\n"
"Runs:\n"
"  --shard I/N              only the meshes with n % N == I (0 <= I < N): N\n"
"                           processes or machines share a list without talking\n"
"  --keep-going             a failed mesh is recorded and the batch goes on (the\n"
"                           default)\n"
"  --no-keep-going          stop at the first failed mesh\n"
"  --json                   one JSON object per mesh on stdout (as for one mesh,\n"
"                           plus \"n\"; skipped meshes have status \"skipped\"), then\n"
"                           one {\"type\":\"batch\",...} object with the counts\n"
"  -q, --quiet              no progress lines and no summary\n"
"\n"
"A progress line per mesh goes to stderr (\"clvox: [k/K] ok|failed|skipped\n"
"...\"), errors and warnings as for one mesh, prefixed by the mesh (or\n"
"FILE:LINE for a manifest line). The summary (meshes ok, failed, skipped, not\n"
"run; meshes per second) goes to stdout, or is the last JSON object.\n"
"No OpenCL device or a kernel that does not build stops the batch. Ctrl-C\n"
"(SIGINT, SIGTERM, SIGHUP) stops it after cancelling the current mesh; no\n"
"partial file is left.\n"
"\n"
"Exit status: 0 when no mesh failed, 130 when cancelled, else the exit code of\n"
"the first failed mesh (clvox --help: 4 bad mesh, 5 output, 6 grid, ...);\n"
"2 for bad arguments, a bad manifest line, a bad template or shard.\n", stdout);
}

/* ---- arguments ---- */

static int parse_shard(const char *v, batch_opts *o)
{
    const char *end = NULL;
    const char *why = parse_u32(v, 0, &o->shard_i, &end);
    if (!why && *end != '/') why = "expected I/N";
    if (!why) why = parse_u32(end + 1, 1, &o->shard_n, NULL);
    if (!why && o->shard_i >= o->shard_n) why = "I must be less than N";
    if (why) {
        usage_error("batch: --shard '%s': %s (expected I/N, 0 <= I < N)", v, why);
        return -1;
    }
    return 1;
}

static int batch_extra(void *user, int argc, char **argv, int *i)
{
    batch_opts *o = user;
    const char *arg = argv[*i], *v = NULL;
    int missing = 0;
    if (strcmp(arg, "--skip-existing") == 0) return o->skip_existing = 1;
    if (strcmp(arg, "--keep-going") == 0) return o->keep_going = 1;
    if (strcmp(arg, "--no-keep-going") == 0) {
        o->keep_going = 0;
        return 1;
    }
    const char *names[] = {"--dir", "--manifest", "--shard"};
    for (int k = 0; k < 3; k++) {
        if (!match_value(argc, argv, i, NULL, names[k], &v, &missing)) continue;
        if (missing) {
            usage_error("option %s needs a value", names[k]);
            return -1;
        }
        if (k < 2 && *v == '\0') {
            usage_error("batch: %s: empty name", names[k]);
            return -1;
        }
        if (k == 0) {
            if (o->dir) return usage_error("batch: --dir given twice"), -1;
            o->dir = v;
        } else if (k == 1) {
            if (o->manifest) return usage_error("batch: --manifest given twice"), -1;
            o->manifest = v;
        } else {
            return parse_shard(v, o);
        }
        return 1;
    }
    return 0;
}

/* ---- the list ---- */

static char *dup_str(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = malloc(n);
    if (d) memcpy(d, s, n);
    return d;
}

static batch_item *list_add(batch_list *l, const char *mesh)
{
    if (l->count == l->cap) {
        size_t cap = l->cap ? 2 * l->cap : 64;
        batch_item *g = realloc(l->items, cap * sizeof *g);
        if (!g) return NULL;
        l->items = g;
        l->cap = cap;
    }
    batch_item *it = &l->items[l->count];
    memset(it, 0, sizeof *it);
    if (!(it->mesh = dup_str(mesh))) return NULL;
    l->count++;
    return it;
}

static void list_free(batch_list *l)
{
    for (size_t i = 0; i < l->count; i++) {
        free(l->items[i].mesh);
        free(l->items[i].output);
        free(l->items[i].source);
    }
    free(l->items);
    memset(l, 0, sizeof *l);
}

static int is_mesh_name(const char *name)
{
    static const char *const exts[] = {"obj", "off", "ply", "stl", "om"};
    const char *dot = strrchr(name, '.');
    if (!dot || dot == name) return 0;
    for (size_t i = 0; i < sizeof exts / sizeof exts[0]; i++) {
        size_t n = strlen(exts[i]);
        if (strlen(dot + 1) != n) continue;
        size_t k = 0;
        while (k < n && (dot[1 + k] | 0x20) == exts[i][k]) k++;
        if (k == n) return 1;
    }
    return 0;
}

static int cmp_str(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

static int add_dir(batch_list *l, const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) return fail(EXIT_INPUT, "batch: --dir '%s': %s", dir, strerror(errno));
    char **names = NULL;
    size_t n = 0, cap = 0;
    int rc = EXIT_OK;
    struct dirent *e;
    size_t dl = strlen(dir);
    while ((e = readdir(d)) != NULL) {
        if (!is_mesh_name(e->d_name)) continue;
        size_t len = dl + 1 + strlen(e->d_name) + 1;
        char *p = malloc(len);
        if (!p) { rc = fail(EXIT_RUNTIME, "out of memory"); break; }
        snprintf(p, len, "%s%s%s", dir, dl && dir[dl - 1] == '/' ? "" : "/", e->d_name);
        struct stat sb;
        if (stat(p, &sb) != 0 || !S_ISREG(sb.st_mode)) {
            free(p);
            continue;
        }
        if (n == cap) {
            char **g = realloc(names, (cap = cap ? 2 * cap : 64) * sizeof *g);
            if (!g) { free(p); rc = fail(EXIT_RUNTIME, "out of memory"); break; }
            names = g;
        }
        names[n++] = p;
    }
    closedir(d);
    if (rc == EXIT_OK && n) qsort(names, n, sizeof *names, cmp_str);
    for (size_t i = 0; i < n; i++) {
        if (rc == EXIT_OK && !list_add(l, names[i])) rc = fail(EXIT_RUNTIME, "out of memory");
        free(names[i]);
    }
    free(names);
    return rc;
}

/* The next field of a manifest line (in place), NULL at the end; *why on error. */
static char *next_field(char **cursor, const char **why)
{
    char *p = *cursor;
    while (*p == ' ' || *p == '\t') p++;
    if (*p == '\0') return NULL;
    char *start = p, *w = p;
    if (*p == '"') {
        p++;
        for (;;) {
            if (*p == '\0') {
                *why = "unterminated \"quote\"";
                return NULL;
            }
            if (*p == '"') { p++; break; }
            if (*p == '\\' && (p[1] == '"' || p[1] == '\\')) p++;
            *w++ = *p++;
        }
        if (*p != '\0' && *p != ' ' && *p != '\t') {
            *why = "text right after a closing quote";
            return NULL;
        }
        if (w == start) {
            *why = "empty \"\" field";
            return NULL;
        }
    } else {
        while (*p && *p != ' ' && *p != '\t') *w++ = *p++;
    }
    if (*p) p++;
    *w = '\0';
    *cursor = p;
    return start;
}

static int add_manifest(batch_list *l, const char *path, const cli_args *a)
{
    const char *open_why = NULL;
    int fd = cli_open_regular_read(path, &open_why);
    if (fd < 0) return fail(EXIT_INPUT, "batch: --manifest '%s': %s", path, open_why);
    FILE *f = fdopen(fd, "rb");
    if (!f) {
        int e = errno;
        close(fd);
        return fail(EXIT_RUNTIME, "batch: --manifest '%s': %s", path, strerror(e));
    }
    char *line = NULL;
    size_t cap = 0;
    ssize_t len;
    unsigned lineno = 0;
    int rc = EXIT_OK;
    while (rc == EXIT_OK && (len = getline(&line, &cap, f)) >= 0) {
        lineno++;
        if (memchr(line, '\0', (size_t)len)) {
            rc = fail(EXIT_USAGE, "%s:%u: a NUL byte", path, lineno);
            break;
        }
        while (len > 0 && (line[len - 1] == '\n' || line[len - 1] == '\r')) line[--len] = '\0';
        char *cur = line;
        const char *why = NULL;
        char *mesh = next_field(&cur, &why);
        if (!mesh && !why) continue; /* blank */
        if (mesh && mesh[0] == '#' && line[strspn(line, " \t")] == '#') continue; /* comment */
        if (mesh && mesh[0] == '-') {
            rc = fail(EXIT_USAGE, "%s:%u: the line must start with the mesh, not '%s' (write ./%s for a file of that name)",
                      path, lineno, mesh, mesh);
            break;
        }
        char *out = NULL;
        int grid_by = 0;
        clvox_grid_options grid = a->grid;
        const char *grid_opt = NULL;
        while (!why) {
            char *opt = next_field(&cur, &why);
            if (!opt) break;
            char *val = next_field(&cur, &why);
            if (why) break;
            if (!val) {
                static char m[96];
                snprintf(m, sizeof m, "%.40s needs a value", opt);
                why = m;
                break;
            }
            if (strcmp(opt, "-o") == 0 || strcmp(opt, "--output") == 0) {
                if (out) { why = "-o given twice"; break; }
                out = val;
            } else if (strcmp(opt, "-r") == 0 || strcmp(opt, "--resolution") == 0 || strcmp(opt, "--dims") == 0 ||
                       strcmp(opt, "--voxel-size") == 0) {
                if (a->like) { why = "a grid override (-r, --dims, --voxel-size) can not be combined with --like"; break; }
                if (grid_opt) { why = "more than one of -r, --dims, --voxel-size"; break; }
                grid_opt = opt;
                why = grid_option_parse(opt, val, &grid, &grid_by);
            } else {
                static char m[160];
                snprintf(m, sizeof m, "unknown option '%.60s' (a line is MESH [-o OUT] [-r N | --dims X,Y,Z | "
                                      "--voxel-size S])", opt);
                why = m;
            }
        }
        if (why) {
            rc = fail(EXIT_USAGE, "%s:%u: %s", path, lineno, why);
            break;
        }
        batch_item *it = list_add(l, mesh);
        char src[64];
        if (it) {
            it->line = lineno;
            it->grid_by = grid_by;
            it->grid = grid;
            size_t sl = strlen(path) + sizeof src;
            it->source = malloc(sl);
            if (it->source) snprintf(it->source, sl, "%s:%u", path, lineno);
            if (out) it->output = dup_str(out);
        }
        if (!it || !it->source || (out && !it->output)) rc = fail(EXIT_RUNTIME, "out of memory");
    }
    if (rc == EXIT_OK && ferror(f)) rc = fail(EXIT_INPUT, "batch: --manifest '%s': cannot read: %s", path, strerror(errno));
    free(line);
    fclose(f);
    return rc;
}

/* ---- output names ---- */

typedef struct sbuf {
    char *s;
    size_t len, cap;
} sbuf;

static int sb_put(sbuf *b, const char *s, size_t n)
{
    if (b->len + n + 1 > b->cap) {
        size_t cap = b->cap ? b->cap : 128;
        while (cap < b->len + n + 1) cap *= 2;
        char *g = realloc(b->s, cap);
        if (!g) return -1;
        b->s = g;
        b->cap = cap;
    }
    memcpy(b->s + b->len, s, n);
    b->len += n;
    b->s[b->len] = '\0';
    return 0;
}

/* The output name of `mesh` (malloc'ed) from the template, or NULL with *why
 * (NULL: out of memory). */
static char *expand_template(const char *tpl, const char *mesh, uint64_t n, const char **why)
{
    sbuf b = {NULL, 0, 0};
    *why = NULL;
    const char *slash = strrchr(mesh, '/');
    const char *name = slash ? slash + 1 : mesh;
    const char *dot = strrchr(name, '.');
    size_t stem_len = dot && dot != name ? (size_t)(dot - name) : strlen(name);
    int err = 0;
    for (const char *p = tpl; *p && !err && !*why;) {
        if (p[0] == '{' && p[1] == '{') { err = sb_put(&b, "{", 1); p += 2; continue; }
        if (p[0] == '}' && p[1] == '}') { err = sb_put(&b, "}", 1); p += 2; continue; }
        if (*p == '}') { *why = "a single '}' (write }} for a brace)"; break; }
        if (*p != '{') {
            size_t k = strcspn(p, "{}");
            err = sb_put(&b, p, k);
            p += k;
            continue;
        }
        const char *close = strchr(p, '}');
        size_t fl = close ? (size_t)(close - p - 1) : 0;
        if (close && fl == 4 && strncmp(p + 1, "stem", 4) == 0) err = sb_put(&b, name, stem_len);
        else if (close && fl == 4 && strncmp(p + 1, "name", 4) == 0) err = sb_put(&b, name, strlen(name));
        else if (close && fl == 3 && strncmp(p + 1, "dir", 3) == 0) {
            if (!slash) err = sb_put(&b, ".", 1);
            else if (slash == mesh) err = sb_put(&b, "/", 1);
            else err = sb_put(&b, mesh, (size_t)(slash - mesh));
        } else if (close && fl == 1 && p[1] == 'n') {
            char num[24];
            snprintf(num, sizeof num, "%" PRIu64, n);
            err = sb_put(&b, num, strlen(num));
        } else {
            *why = "unknown field (expected {stem}, {name}, {dir}, {n}, or {{ and }} for braces)";
            break;
        }
        p = close + 1;
    }
    if (!*why && !err && b.len == 0) *why = "the name is empty";
    if (*why || err) {
        free(b.s);
        return NULL;
    }
    return b.s;
}

static int cmp_item_output(const void *a, const void *b)
{
    const batch_item *x = *(batch_item *const *)a, *y = *(batch_item *const *)b;
    return strcmp(x->output, y->output);
}

/* ---- the run ---- */

typedef struct batch_counts {
    size_t ok, failed, skipped, run;
} batch_counts;

/* The next mesh, loaded while this one is voxelized: a batch of small
 * meshes leaves most of a second core idle (loading, writing and the device
 * waits run on one), and a mesh's load was a third of its time
 * (docs/benchmarks.md "Batch: the next mesh loaded ahead"). The thread loads
 * it with a host context of its own (its messages) and starts its winding
 * preparation (clvox_mesh_prepare_winding); vox_run takes the mesh.
 * Meshes over PREFETCH_MAX_BYTES are not loaded ahead, so that two big
 * meshes are never held at once. */
#define PREFETCH_MAX_BYTES (64ull << 20)

typedef struct prefetch {
    pthread_t thread;
    int running;                       /* a thread to join */
    size_t k;                          /* the selected item it loads */
    const char *path;
    const clvox_voxelize_options *vox;
    clvox_context *ctx;                /* host-only, this thread's */
    clvox_mesh *mesh;
    clvox_status st;
    double seconds;
} prefetch;

static void *prefetch_main(void *arg)
{
    prefetch *p = arg;
    double t0 = cli_now();
    p->st = clvox_mesh_load(p->ctx, p->path, &p->mesh);
    p->seconds = cli_now() - t0;
    if (p->st == CLVOX_OK) (void)clvox_mesh_prepare_winding(p->ctx, p->mesh, p->vox); /* errors: the cast's */
    return NULL;
}

/* Waits for the thread; the mesh (or the failed load) stays in p. */
static void prefetch_join(prefetch *p)
{
    if (!p->running) return;
    pthread_join(p->thread, NULL);
    p->running = 0;
}

static int would_skip(const batch_opts *o, const batch_item *it)
{
    struct stat sb;
    return o->skip_existing && lstat(it->output, &sb) == 0 && S_ISREG(sb.st_mode);
}

/* Starts loading the first item after k that will run (not skipped), if it
 * is a regular file of at most PREFETCH_MAX_BYTES. */
static void prefetch_start(prefetch *p, const batch_opts *o, batch_item **sel, size_t K, size_t k)
{
    if (!p->ctx || p->running || p->mesh) return;
    size_t j = k + 1;
    while (j < K && would_skip(o, sel[j])) j++;
    struct stat sb;
    if (j >= K || stat(sel[j]->mesh, &sb) != 0 || !S_ISREG(sb.st_mode) || (uint64_t)sb.st_size > PREFETCH_MAX_BYTES)
        return;
    p->k = j;
    p->path = sel[j]->mesh;
    p->st = CLVOX_OK;
    p->seconds = 0;
    if (pthread_create(&p->thread, NULL, prefetch_main, p) == 0) p->running = 1;
}

static void progress_line(const cli_args *a, size_t k, size_t K, const batch_item *it, const vox_result *res)
{
    if (a->quiet) return;
    char what[48];
    if (res->rc != 0 && strcmp(res->status, "failed") == 0) snprintf(what, sizeof what, "failed (exit %d)", res->rc);
    else snprintf(what, sizeof what, "%s", res->status);
    fprintf(stderr, "clvox: [%zu/%zu] %s %.3f s  %s -> %s\n", k, K, what, res->wall_seconds, it->mesh, it->output);
}

int cmd_batch(int argc, char **argv)
{
    batch_opts o;
    memset(&o, 0, sizeof o);
    o.keep_going = 1;
    o.shard_n = 1;
    cli_args a;
    batch_list list = {NULL, 0, 0};
    batch_item **sel = NULL;
    vox_result *res = NULL;
    vox_session s;
    memset(&s, 0, sizeof s);
    prefetch pf;
    memset(&pf, 0, sizeof pf);
    int rc = parse_args(argc, argv, 0, 1, batch_extra, &o, &a);
    if (rc != EXIT_OK) goto done;
    if (a.help) {
        print_batch_help();
        rc = cli_finish_stdout(EXIT_OK, NULL);
        goto done;
    }
    if (a.version || a.list_devices) {
        rc = usage_error("batch: %s is not a batch option", a.version ? "--version" : "--list-devices");
        goto done;
    }
    const char *tpl = a.output ? a.output : DEFAULT_TEMPLATE;
    const char *why = NULL;
    char *probe = expand_template(tpl, "dir/mesh.obj", 0, &why);
    free(probe);
    if (why) { rc = usage_error("batch: -o '%s': %s", tpl, why); goto done; }

    for (size_t i = 0; i < a.mesh_count; i++)
        if (!list_add(&list, a.meshes[i])) { rc = fail(EXIT_RUNTIME, "out of memory"); goto done; }
    if (o.dir && (rc = add_dir(&list, o.dir)) != EXIT_OK) goto done;
    if (o.manifest && (rc = add_manifest(&list, o.manifest, &a)) != EXIT_OK) goto done;
    if (list.count == 0) {
        rc = o.dir || o.manifest ? fail(EXIT_INPUT, "batch: no meshes found (%s%s%s)", o.dir ? "--dir " : "",
                                        o.dir ? o.dir : "", o.manifest ? " --manifest, empty" : "")
                                 : usage_error("batch: no meshes (give MESH arguments, --dir DIR or --manifest FILE)");
        goto done;
    }

    /* this shard's meshes, their outputs, no two the same */
    size_t K = 0;
    if (!(sel = malloc(list.count * sizeof *sel))) { rc = fail(EXIT_RUNTIME, "out of memory"); goto done; }
    for (size_t n = 0; n < list.count; n++) {
        if (n % o.shard_n != o.shard_i) continue;
        batch_item *it = &list.items[n];
        if (!it->output) {
            it->output = expand_template(tpl, it->mesh, n, &why);
            if (!it->output) {
                rc = why ? fail(EXIT_USAGE, "batch: -o '%s' for '%s': %s", tpl, it->mesh, why)
                         : fail(EXIT_RUNTIME, "out of memory");
                goto done;
            }
        }
        sel[K++] = it;
    }
    if (K > 1) {
        batch_item **sorted = malloc(K * sizeof *sorted);
        if (!sorted) { rc = fail(EXIT_RUNTIME, "out of memory"); goto done; }
        memcpy(sorted, sel, K * sizeof *sorted);
        qsort(sorted, K, sizeof *sorted, cmp_item_output);
        for (size_t k = 1; k < K && rc == EXIT_OK; k++)
            if (strcmp(sorted[k - 1]->output, sorted[k]->output) == 0)
                rc = usage_error("batch: '%s' and '%s' would both be written to '%s' (put {dir} or {n} in -o)",
                                 sorted[k - 1]->mesh, sorted[k]->mesh, sorted[k]->output);
        free(sorted);
        if (rc != EXIT_OK) goto done;
    }

    if ((rc = vox_session_open(&s, &a)) != EXIT_OK) goto done;
    s.batch = 1;
    if (!(res = malloc(sizeof *res))) { rc = fail(EXIT_RUNTIME, "out of memory"); goto done; }

    double start = cli_now();
    batch_counts c = {0, 0, 0, 0};
    int first_failure = EXIT_OK, cancelled = 0;
    if (K > 1) {
        clvox_context_options ho = CLVOX_CONTEXT_OPTIONS_INIT;
        ho.host_only = 1;
        if (clvox_context_create(&ho, &pf.ctx) != CLVOX_OK) { /* no loading ahead, nothing else lost */
            clvox_context_destroy(pf.ctx);
            pf.ctx = NULL;
        }
        pf.vox = &a.vox;
    }
    for (size_t k = 0; k < K; k++) {
        batch_item *it = sel[k];
        if (cli_interrupted()) { cancelled = 1; break; }
        vox_job job = {it->mesh, it->output, it->grid_by, it->grid, (int64_t)(it - list.items), it->source, it->line,
                       0, NULL, CLVOX_OK, NULL, 0};
        if (pf.ctx && (pf.running || pf.mesh) && pf.k == k) { /* this mesh was loaded ahead */
            prefetch_join(&pf);
            job.preloaded = 1;
            job.mesh_ahead = pf.mesh;
            job.mesh_status = pf.st;
            job.mesh_ctx = pf.ctx;
            job.mesh_seconds = pf.seconds;
            pf.mesh = NULL;
        }
        struct stat sb;
        if (o.skip_existing && lstat(it->output, &sb) == 0 && S_ISREG(sb.st_mode)) {
            clvox_mesh_destroy(job.mesh_ahead); /* its output appeared meanwhile */
            memset(res, 0, sizeof *res);
            res->status = "skipped";
            res->output_size = (uint64_t)sb.st_size;
            c.skipped++;
        } else {
            c.run++;
            /* the next load ahead, beside this run -- after it where this
             * run reports a failed load ahead (its message is in pf.ctx) */
            const int failed_ahead = job.preloaded && !job.mesh_ahead;
            if (!failed_ahead) prefetch_start(&pf, &o, sel, K, k);
            int r = vox_run(&s, &job, res);
            if (failed_ahead) prefetch_start(&pf, &o, sel, K, k);
            if (r == EXIT_OK) {
                c.ok++;
            } else if (r == EXIT_CANCELLED) {
                cancelled = 1;
            } else {
                c.failed++;
                if (first_failure == EXIT_OK) first_failure = r;
            }
        }
        progress_line(&a, k + 1, K, it, res);
        if (a.json) {
            jbuf b;
            jb_init(&b);
            vox_result_json(&s, &job, res, &b);
            if (jb_write_line(&b) != 0 && b.oom) fail(EXIT_RUNTIME, "out of memory for a JSON record");
            jb_free(&b);
            cli_flush_stdout();
        }
        vox_print_warnings(&s, &job, res);
        if (cancelled || res->fatal) break;
        if (res->rc != EXIT_OK && !o.keep_going) break;
    }
    prefetch_join(&pf); /* a batch cut short: the mesh loaded ahead is not run */
    clvox_mesh_destroy(pf.mesh);
    pf.mesh = NULL;
    double seconds = cli_now() - start;
    size_t not_run = K - c.ok - c.failed - c.skipped;
    double rate = seconds > 0 ? (double)c.ok / seconds : 0;
    rc = cancelled ? EXIT_CANCELLED : first_failure;
    if (a.json) {
        jbuf b;
        jb_init(&b);
        jb_obj_begin(&b, NULL);
        jb_str(&b, "type", "batch");
        jb_u64(&b, "meshes", K);
        jb_u64(&b, "listed", list.count);
        jb_u64(&b, "ok", c.ok);
        jb_u64(&b, "failed", c.failed);
        jb_u64(&b, "skipped", c.skipped);
        jb_u64(&b, "not_run", not_run);
        jb_bool(&b, "cancelled", cancelled);
        jb_arr_begin(&b, "shard");
        jb_u64(&b, NULL, o.shard_i);
        jb_u64(&b, NULL, o.shard_n);
        jb_arr_end(&b);
        jb_num(&b, "seconds", seconds);
        jb_num(&b, "setup_seconds", s.setup_seconds);
        jb_num(&b, "meshes_per_second", rate);
        jb_i64(&b, "exit_code", rc);
        jb_obj_end(&b);
        if (jb_write_line(&b) != 0 && b.oom) fail(EXIT_RUNTIME, "out of memory for a JSON record");
        jb_free(&b);
    } else if (!a.quiet) {
        printf("batch        %zu meshes: %zu ok, %zu failed, %zu skipped, %zu not run%s\n", K, c.ok, c.failed,
               c.skipped, not_run, cancelled ? " (cancelled)" : "");
        if (o.shard_n > 1) printf("shard        %u/%u of %zu meshes listed\n", o.shard_i, o.shard_n, list.count);
        printf("time         %.3f s, %.2f meshes per second (device setup %.3f s, once)\n", seconds, rate,
               s.setup_seconds);
    }
    rc = cli_finish_stdout(rc, NULL);

done:
    prefetch_join(&pf);
    clvox_mesh_destroy(pf.mesh);
    clvox_context_destroy(pf.ctx);
    vox_session_close(&s);
    free(res);
    free(sel);
    list_free(&list);
    free(a.meshes);
    return rc;
}
