/* SPDX-License-Identifier: Apache-2.0 */
/* Past 800 lines on purpose: the batch loop and its look-ahead loader share
 * one queue and its lock; sources, templates and the manifest parser already
 * live apart (cli_manifest.c). */
/*
 * clvox batch: many meshes in one process, with one host context, one
 * OpenCL context and one kernel build (vox_session, cli_run.c), each mesh run by
 * vox_run as `clvox MESH` runs it.
 *
 *   meshes   MESH arguments, then --dir DIR (its mesh files, sorted by name),
 *            then --manifest FILE (one mesh per line, optional overrides);
 *            n = the position in that list, from 0
 *   outputs  -o TEMPLATE with {stem} {name} {dir} {n} (default {stem}.exr),
 *            or a manifest line's own -o; no two meshes may write one file,
 *            however its path is spelled (check_outputs)
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
#include "cli_manifest.h"
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
    int own_output;           /* output from the manifest line, not the template */
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
"  --dir DIR                the mesh files in DIR (.obj .off .ply .stl .om .glb\n"
"                           .gltf .3mf .fbx .dae .3ds, any case; not\n"
"                           recursive), sorted by name\n"
"  --manifest FILE          one mesh per line, optionally followed by overrides\n"
"                           for that mesh: -o OUT, and one of -r N, --dims X,Y,Z,\n"
"                           --voxel-size S[,S,S]. Fields are separated by spaces\n"
"                           or tabs; \"double quotes\" hold a field with spaces (\\\"\n"
"                           and \\\\ inside them); blank lines and lines starting\n"
"                           with # are skipped (a quoted \"#x.obj\" is a mesh).\n"
"                           Paths are relative to the current directory. A\n"
"                           malformed line stops the batch before it starts\n"
"                           (FILE:LINE: why, exit 2)\n"
"\n"
"Outputs:\n"
"  -o, --output TEMPLATE    output name of each mesh (default {stem}.exr):\n"
"                           {stem} the mesh file name without its extension,\n"
"                           {name} with it, {dir} the mesh's directory (. if\n"
"                           none), {n} its position in the list, {{ and }} braces.\n"
"                           Two meshes writing one file are refused before the\n"
"                           batch starts, in every shard (use {dir} or {n}):\n"
"                           paths are compared as files (out/./x.exr,\n"
"                           a/../out/x.exr and a link to out/ are out/x.exr),\n"
"                           with the files an output writes beside it (OUT.json,\n"
"                           OUT.<channel>.npy).\n", stdout);
    fputs(
"                           Missing folders in an output's path are created\n"
"                           (as mkdir -p) before its mesh runs; a component that\n"
"                           exists and is not a folder fails that mesh (exit 5);\n"
"                           nothing is removed or replaced. A .binvox output gets\n"
"                           binvox's cube (--cube, clvox --help) unless --box,\n"
"                           --like or non-cubic --dims/--voxel-size say otherwise\n"
"  --skip-existing          do not voxelize a mesh whose output exists (outputs\n"
"                           are only ever named when complete, so an interrupted\n"
"                           batch resumes where it stopped); a set of files\n"
"                           (npy, NRRD channels) counts only when its marker\n"
"                           (OUT.json, OUT.nrrd) agrees with every file in it\n"
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
    static const char *const exts[] = {"obj", "off", "ply", "stl", "om", "glb", "gltf", "3mf", "fbx", "dae", "3ds"};
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

/* A manifest line's mesh into the list (manifest_parse's callback). */
typedef struct manifest_sink {
    batch_list *list;
    const char *path;
} manifest_sink;

static int manifest_add(void *user, const manifest_entry *e)
{
    manifest_sink *m = user;
    batch_item *it = list_add(m->list, e->mesh);
    if (!it) return 1;
    it->line = e->line;
    it->grid_by = e->grid_by;
    it->grid = e->grid;
    size_t sl = strlen(m->path) + 16;
    if (!(it->source = malloc(sl))) return 1;
    snprintf(it->source, sl, "%s:%u", m->path, e->line);
    if (e->output && !(it->output = dup_str(e->output))) return 1;
    it->own_output = e->output != NULL;
    return 0;
}

static int add_manifest(batch_list *l, const char *path, const cli_args *a)
{
    const char *open_why = NULL;
    int fd = clvox_open_regular_read(path, &open_why);
    if (fd < 0) return fail(EXIT_INPUT, "batch: --manifest '%s': %s", path, open_why);
    FILE *f = fdopen(fd, "rb");
    if (!f) {
        int e = errno;
        close(fd);
        return fail(EXIT_RUNTIME, "batch: --manifest '%s': %s", path, strerror(e));
    }
    char *text = NULL;
    size_t len = 0, cap = 0;
    int rc = EXIT_OK;
    for (;;) {
        if (cap - len < 65536) {
            size_t ncap = cap ? 2 * cap : 65536;
            char *g = ncap > cap ? realloc(text, ncap) : NULL;
            if (!g) { rc = fail(EXIT_RUNTIME, "batch: --manifest '%s': out of memory", path); break; }
            text = g;
            cap = ncap;
        }
        size_t got = fread(text + len, 1, cap - len, f);
        len += got;
        if (got == 0) {
            if (ferror(f)) rc = fail(EXIT_INPUT, "batch: --manifest '%s': %s", path, strerror(errno));
            break;
        }
    }
    fclose(f);
    if (rc == EXIT_OK) {
        manifest_sink m = {l, path};
        unsigned bad = 0;
        char why[400];
        int r = manifest_parse(text, len, &a->grid, a->like != NULL, manifest_add, &m, &bad, why, sizeof why);
        if (r == -1) rc = fail(EXIT_USAGE, "%s:%u: %s", path, bad, why);
        else if (r != 0) rc = fail(EXIT_RUNTIME, "out of memory");
    }
    free(text);
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

/* ---- one file, many spellings ---- */

/* A file as the system finds it: the (st_dev, st_ino) of the deepest
 * directory on its path that exists (its own directory, when that exists)
 * and the rest of the path below that directory (the missing directories,
 * without "." and empty components, then the file's name). out/x.exr,
 * out/./x.exr, out//x.exr, a/../out/x.exr and link-to-out/x.exr are one
 * file; outputs are compared so, not as strings. */
typedef struct file_id {
    uint64_t dev, ino; /* 0, 0: not even the top directory could be read */
    char *rest;
    char *path;        /* the file as spelled: an output, or a file written beside it */
    size_t item;       /* list index */
} file_id;

/* The last directory resolved (consecutive outputs mostly share one). */
typedef struct dir_id {
    char *dir;         /* as spelled; NULL: none yet */
    uint64_t dev, ino;
    char *missing;     /* "" or "a/b/": the part that does not exist */
} dir_id;

/* "comp/rest" (malloc'ed), NULL when out of memory. */
static char *prepend_dir(const char *comp, size_t n, const char *rest)
{
    size_t rl = strlen(rest);
    char *s = malloc(n + 1 + rl + 1);
    if (!s) return NULL;
    memcpy(s, comp, n);
    s[n] = '/';
    memcpy(s + n + 1, rest, rl + 1);
    return s;
}

/* d for directory `dir`: 0, or -1 when out of memory. */
static int resolve_dir(dir_id *d, const char *dir)
{
    if (d->dir && strcmp(d->dir, dir) == 0) return 0;
    free(d->dir);
    free(d->missing);
    d->dir = dup_str(dir);
    d->missing = dup_str("");
    char *buf = dup_str(dir);
    int rc = d->dir && d->missing && buf ? 0 : -1;
    while (rc == 0) {
        struct stat sb;
        if (stat(buf, &sb) == 0) {
            d->dev = (uint64_t)sb.st_dev;
            d->ino = (uint64_t)sb.st_ino;
            break;
        }
        size_t n = strlen(buf);
        while (n > 1 && buf[n - 1] == '/') n--;
        buf[n] = '\0';
        char *slash = strrchr(buf, '/');
        if ((!slash && strcmp(buf, ".") == 0) || (slash == buf && n == 1)) { /* "." or "/" unreadable */
            char *m = prepend_dir(dir, strlen(dir), "");
            if (!m) { rc = -1; break; }
            free(d->missing);
            d->missing = m;
            d->dev = d->ino = 0;
            break;
        }
        const char *comp = slash ? slash + 1 : buf;
        if (strcmp(comp, ".") != 0) {
            char *m = prepend_dir(comp, strlen(comp), d->missing);
            if (!m) { rc = -1; break; }
            free(d->missing);
            d->missing = m;
        }
        if (!slash) strcpy(buf, ".");
        else if (slash == buf) buf[1] = '\0';
        else *slash = '\0';
    }
    free(buf);
    if (rc != 0) { /* nothing half-made stays cached */
        free(d->dir);
        d->dir = NULL;
    }
    return rc;
}

/* The identity of file `path` of item `item` into *f: 0, or -1 when out of
 * memory. */
static int identify(dir_id *d, const char *path, size_t item, file_id *f)
{
    const char *slash = strrchr(path, '/');
    const char *name = slash ? slash + 1 : path;
    char *dir = slash == path ? dup_str("/") : slash ? malloc((size_t)(slash - path) + 1) : dup_str(".");
    if (!dir) return -1;
    if (slash && slash != path) {
        memcpy(dir, path, (size_t)(slash - path));
        dir[slash - path] = '\0';
    }
    int rc = resolve_dir(d, dir);
    free(dir);
    if (rc != 0) return -1;
    size_t ml = strlen(d->missing), nl = strlen(name);
    f->dev = d->dev;
    f->ino = d->ino;
    f->item = item;
    f->path = dup_str(path);
    f->rest = malloc(ml + nl + 1);
    if (!f->path || !f->rest) {
        free(f->path);
        free(f->rest);
        return -1;
    }
    memcpy(f->rest, d->missing, ml);
    memcpy(f->rest + ml, name, nl + 1);
    return 0;
}

/* The files output `out` writes: itself; for .npy and .nrrd also those of
 * its other channels, OUT.<channel>.npy, and for .npy the sidecar OUT.json
 * (the library's names: output.c clvox__channel_path, write_npy.c). Every
 * channel a run could produce counts, whatever this run's options. Up to 5
 * into m (malloc'ed, member 0 = out); the count, or -1 out of memory. */
static int output_members(const char *out, clvox_format format, char *m[5])
{
    if (format == CLVOX_FORMAT_AUTO) format = clvox_format_from_path(out);
    int k = 0;
    if (!(m[k++] = dup_str(out))) return -1;
    if (format != CLVOX_FORMAT_NPY && format != CLVOX_FORMAT_NRRD) return k;
    /* the extension's dot, as output.c's ext_at finds it */
    const char *slash = strrchr(out, '/'), *dot = strrchr(out, '.');
    size_t n = strlen(out), e = n;
    if (dot && !(slash && dot < slash) && dot != out && !(slash && dot == slash + 1)) e = (size_t)(dot - out);
    static const char *const insert[4] = {".coverage", ".element", ".score", ".json"};
    for (int i = 0; i < 4; i++) {
        int sidecar = i == 3;
        if (sidecar && format != CLVOX_FORMAT_NPY) break;
        size_t il = strlen(insert[i]), tail = sidecar ? 0 : n - e;
        char *p = malloc(e + il + tail + 1);
        if (!p) {
            while (k > 0) free(m[--k]);
            return -1;
        }
        memcpy(p, out, e);
        memcpy(p + e, insert[i], il);
        memcpy(p + e + il, out + e, tail);
        p[e + il + tail] = '\0';
        m[k++] = p;
    }
    return k;
}

static int same_file(const file_id *x, const file_id *y)
{
    return x->dev == y->dev && x->ino == y->ino && strcmp(x->rest, y->rest) == 0;
}

static int cmp_file_id(const void *a, const void *b)
{
    const file_id *x = a, *y = b;
    if (x->dev != y->dev) return x->dev < y->dev ? -1 : 1;
    if (x->ino != y->ino) return x->ino < y->ino ? -1 : 1;
    int c = strcmp(x->rest, y->rest);
    if (c) return c;
    return x->item < y->item ? -1 : x->item > y->item;
}

/* "'MESH'" or "'MESH' (FILE:LINE)" */
static void describe_mesh(const batch_item *it, char *buf, size_t size)
{
    if (it->source) snprintf(buf, size, "'%s' (%s)", it->mesh, it->source);
    else snprintf(buf, size, "'%s'", it->mesh);
}

/* "'OUT'" or "'FILE' (written with 'OUT')" */
static void describe_file(const file_id *f, const batch_item *it, char *buf, size_t size)
{
    if (strcmp(f->path, it->output) == 0) snprintf(buf, size, "'%s'", f->path);
    else snprintf(buf, size, "'%s' (written with '%s')", f->path, it->output);
}

/* Refuses a list where two meshes would write one file: the same output,
 * spelled alike or not, or a file one writes beside its output (a .npy's
 * sidecar, another channel's file). All listed meshes are compared, not
 * only this shard's: shards run at once. EXIT_OK or the reported error. */
static int check_outputs(const batch_list *l, clvox_format format)
{
    file_id *ids = NULL;
    size_t count = 0, cap = 0;
    dir_id d;
    memset(&d, 0, sizeof d);
    int rc = EXIT_OK;
    for (size_t i = 0; i < l->count && rc == EXIT_OK; i++) {
        char *m[5];
        int k = output_members(l->items[i].output, format, m);
        if (k < 0) { rc = fail(EXIT_RUNTIME, "out of memory"); break; }
        if (count + (size_t)k > cap) {
            size_t nc = cap ? 2 * cap : 256;
            file_id *g = realloc(ids, nc * sizeof *g);
            if (!g) rc = fail(EXIT_RUNTIME, "out of memory");
            else ids = g, cap = nc;
        }
        for (int j = 0; j < k; j++) {
            if (rc == EXIT_OK && identify(&d, m[j], i, &ids[count]) == 0) count++;
            else if (rc == EXIT_OK) rc = fail(EXIT_RUNTIME, "out of memory");
            free(m[j]);
        }
    }
    free(d.dir);
    free(d.missing);
    if (rc == EXIT_OK && count > 1) {
        qsort(ids, count, sizeof *ids, cmp_file_id);
        /* runs of one file, their meshes in list order; reported: the
         * clash whose later mesh comes first in the list */
        size_t best_a = 0, best_b = 0, found = 0;
        for (size_t r = 0, e; r < count; r = e) {
            for (e = r + 1; e < count && same_file(&ids[r], &ids[e]); e++) {
            }
            size_t j = r + 1;
            while (j < e && ids[j].item == ids[r].item) j++;
            if (j < e && (!found || ids[j].item < ids[best_b].item)) best_a = r, best_b = j, found = 1;
        }
        if (found) {
            const batch_item *x = &l->items[ids[best_a].item], *y = &l->items[ids[best_b].item];
            char mx[600], my[600], fx[1200], fy[1200];
            describe_mesh(x, mx, sizeof mx);
            describe_mesh(y, my, sizeof my);
            const char *hint = x->own_output || y->own_output ? "" : " (put {dir} or {n} in -o)";
            if (strcmp(ids[best_a].path, ids[best_b].path) == 0 && strcmp(ids[best_a].path, x->output) == 0 &&
                strcmp(ids[best_b].path, y->output) == 0) {
                rc = usage_error("batch: %s and %s would both be written to '%s'%s", mx, my, x->output, hint);
            } else {
                describe_file(&ids[best_a], x, fx, sizeof fx);
                describe_file(&ids[best_b], y, fy, sizeof fy);
                rc = usage_error("batch: %s and %s would both be written to one file: %s and %s are the same file%s",
                                 mx, my, fx, fy, hint);
            }
        }
    }
    for (size_t i = 0; i < count; i++) {
        free(ids[i].rest);
        free(ids[i].path);
    }
    free(ids);
    return rc;
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

/* --skip-existing: the output is there and whole (a set of files only when
 * its marker agrees with every member, clvox_output_complete); else it is redone. */
static int would_skip(const batch_opts *o, const batch_item *it)
{
    return o->skip_existing && clvox_output_complete(it->output, NULL, 0);
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

    /* every mesh's output, no two writing one file (all shards' meshes:
     * shards run at once), then this shard's meshes */
    for (size_t n = 0; n < list.count; n++) {
        batch_item *it = &list.items[n];
        if (it->output) continue;
        it->output = expand_template(tpl, it->mesh, n, &why);
        if (!it->output) {
            rc = why ? fail(EXIT_USAGE, "batch: -o '%s' for '%s': %s", tpl, it->mesh, why)
                     : fail(EXIT_RUNTIME, "out of memory");
            goto done;
        }
    }
    if ((rc = check_outputs(&list, a.out.format)) != EXIT_OK) goto done;
    size_t K = 0;
    if (!(sel = malloc(list.count * sizeof *sel))) { rc = fail(EXIT_RUNTIME, "out of memory"); goto done; }
    for (size_t n = 0; n < list.count; n++)
        if (n % o.shard_n == o.shard_i) sel[K++] = &list.items[n];

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
                       0, NULL, CLVOX_OK, NULL, 0, 1};
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
        char incomplete[1024] = "";
        int whole = o.skip_existing && clvox_output_complete(it->output, incomplete, sizeof incomplete);
        if (o.skip_existing && !whole && !a.quiet && lstat(it->output, &sb) == 0)
            fprintf(stderr, "clvox: warning: %s; voxelizing it again\n", incomplete); /* a set left mixed */
        if (whole && lstat(it->output, &sb) == 0) {
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
