/* SPDX-License-Identifier: Apache-2.0 */
/* libFuzzer target: the `clvox batch --manifest` parser (manifest_parse,
 * src/cli/cli_manifest.c) on arbitrary bytes. Every input must give either
 * mesh entries or one malformed line (its number within the input, a
 * one-line reason); never a crash, an out-of-bounds access or unbounded
 * work. Entries must be well formed (a mesh that is not empty and does not
 * start with '-', an output that is not empty, one grid kind, increasing
 * line numbers), a line whose first field is quoted must be a mesh line,
 * and entries must survive a round trip: written back with every field
 * quoted (what a script writing a manifest does, "#x.obj" included), they
 * must parse to the same entries. With --like, the first line with a grid
 * override must be the one refused.
 * Build and run: make fuzz-run FUZZ_SECONDS=60 FUZZ_ONLY=manifest */
#include "cli/cli_manifest.h"
#include "cli/cli_vox.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* cli_common.c asks whether a signal stopped the run (src/cli/cli_run.c); the
 * parser alone installs no handlers. */
int cli_interrupted(void) { return 0; }

typedef struct manifest_got {
    manifest_entry *e; /* strings copied */
    size_t n, cap;
    int bad;           /* an entry broke a property */
} manifest_got;

static char *manifest_dup(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = malloc(n);
    if (!d) abort();
    memcpy(d, s, n);
    return d;
}

static int manifest_collect(void *user, const manifest_entry *e)
{
    manifest_got *g = user;
    if (!e->mesh[0] || e->mesh[0] == '-' || (e->output && !e->output[0])) g->bad = 1;
    if (e->grid_by != 0 && e->grid_by != GRID_BY_RESOLUTION && e->grid_by != GRID_BY_DIMS &&
        e->grid_by != GRID_BY_VOXEL_SIZE)
        g->bad = 1;
    if (e->line == 0 || (g->n && e->line <= g->e[g->n - 1].line)) g->bad = 1;
    if (g->n == g->cap) {
        g->cap = g->cap ? 2 * g->cap : 16;
        g->e = realloc(g->e, g->cap * sizeof *g->e);
        if (!g->e) abort();
    }
    manifest_entry *c = &g->e[g->n++];
    *c = *e;
    c->mesh = manifest_dup(e->mesh);
    c->output = e->output ? manifest_dup(e->output) : NULL;
    return 0;
}

static void manifest_got_free(manifest_got *g)
{
    for (size_t i = 0; i < g->n; i++) {
        free((char *)g->e[i].mesh);
        free((char *)g->e[i].output);
    }
    free(g->e);
    memset(g, 0, sizeof *g);
}

static void manifest_put(char **s, size_t *len, size_t *cap, const char *t, size_t n)
{
    if (*len + n + 1 > *cap) {
        while (*len + n + 1 > *cap) *cap = *cap ? 2 * *cap : 256;
        *s = realloc(*s, *cap);
        if (!*s) abort();
    }
    memcpy(*s + *len, t, n);
    *len += n;
    (*s)[*len] = '\0';
}

static void manifest_put_quoted(char **s, size_t *len, size_t *cap, const char *f)
{
    manifest_put(s, len, cap, "\"", 1);
    for (; *f; f++) {
        if (*f == '"' || *f == '\\') manifest_put(s, len, cap, "\\", 1);
        manifest_put(s, len, cap, f, 1);
    }
    manifest_put(s, len, cap, "\"", 1);
}

static int manifest_same_entry(const manifest_entry *x, const manifest_entry *y)
{
    if (strcmp(x->mesh, y->mesh) != 0 || !x->output != !y->output) return 0;
    if (x->output && strcmp(x->output, y->output) != 0) return 0;
    if (x->grid_by != y->grid_by || x->grid.resolution != y->grid.resolution) return 0;
    for (int i = 0; i < 3; i++)
        if (x->grid.dims[i] != y->grid.dims[i] || x->grid.voxel_size[i] != y->grid.voxel_size[i]) return 0;
    return 1;
}

/* 0 ok; -1 a malformed line; -2 out of memory: checks what any result must hold. */
static int manifest_run(const char *text, size_t len, const clvox_grid_options *base, int like, manifest_got *g,
                        unsigned *bad_line)
{
    char why[400];
    int rc = manifest_parse(text, len, base, like, manifest_collect, g, bad_line, why, sizeof why);
    if (rc != 0 && rc != -1 && rc != -2) abort();
    if (g->bad) abort();
    if (rc == -1) {
        size_t lines = 1;
        for (size_t i = 0; i + 1 < len; i++) lines += text[i] == '\n';
        if (*bad_line == 0 || *bad_line > lines || !why[0] || strchr(why, '\n')) abort();
        if (g->n && g->e[g->n - 1].line >= *bad_line) abort();
    }
    return rc;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    clvox_grid_options base = CLVOX_GRID_OPTIONS_INIT;
    base.resolution = 7;
    const char *text = (const char *)data;
    manifest_got g = {NULL, 0, 0, 0}, h = {NULL, 0, 0, 0};
    unsigned bad = 0, bad2 = 0;
    int rc = manifest_run(text, size, &base, 0, &g, &bad);
    if (rc == 0) {
        /* a line whose first field is quoted is a mesh line, never a
         * comment or blank ("#x.obj" quoted is a mesh) */
        size_t next = 0;
        unsigned line = 1;
        for (size_t at = 0; at < size; line++) {
            const char *nl = memchr(text + at, '\n', size - at);
            size_t b = at;
            while (b < size && (text[b] == ' ' || text[b] == '\t')) b++;
            if (b < size && text[b] == '"') {
                while (next < g.n && g.e[next].line < line) next++;
                if (next == g.n || g.e[next].line != line) abort();
            }
            at = nl ? (size_t)(nl - text) + 1 : size;
        }
        /* the round trip: every field quoted, one entry a line */
        char *s = NULL;
        size_t len = 0, cap = 0;
        for (size_t i = 0; i < g.n; i++) {
            const manifest_entry *e = &g.e[i];
            char num[160];
            manifest_put_quoted(&s, &len, &cap, e->mesh);
            if (e->output) {
                manifest_put(&s, &len, &cap, " -o ", 4);
                manifest_put_quoted(&s, &len, &cap, e->output);
            }
            if (e->grid_by == GRID_BY_RESOLUTION)
                snprintf(num, sizeof num, "\t-r %u", e->grid.resolution);
            else if (e->grid_by == GRID_BY_DIMS)
                snprintf(num, sizeof num, " --dims %u,%u,%u", e->grid.dims[0], e->grid.dims[1], e->grid.dims[2]);
            else if (e->grid_by == GRID_BY_VOXEL_SIZE)
                snprintf(num, sizeof num, " --voxel-size %.17g,%.17g,%.17g", e->grid.voxel_size[0],
                         e->grid.voxel_size[1], e->grid.voxel_size[2]);
            else
                num[0] = '\0';
            manifest_put(&s, &len, &cap, num, strlen(num));
            manifest_put(&s, &len, &cap, "\n", 1);
        }
        if (manifest_run(s ? s : "", len, &base, 0, &h, &bad2) != 0 || h.n != g.n) abort();
        for (size_t i = 0; i < g.n; i++)
            if (!manifest_same_entry(&g.e[i], &h.e[i]) || h.e[i].line != i + 1) abort();
        free(s);
        manifest_got_free(&h);
        /* --like: the first override is refused, on its line */
        size_t first = 0;
        while (first < g.n && g.e[first].grid_by == 0) first++;
        int r2 = manifest_run(text, size, &base, 1, &h, &bad2);
        if (first == g.n ? r2 != 0 || h.n != g.n : r2 != -1 || bad2 != g.e[first].line || h.n != first) abort();
    }
    manifest_got_free(&g);
    manifest_got_free(&h);
    return 0;
}
