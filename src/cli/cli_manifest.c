/* SPDX-License-Identifier: Apache-2.0 */
/*
 * The batch manifest parser: one mesh per line, optionally followed by
 * -o OUT and one grid override (-r N, --dims X,Y,Z, --voxel-size S[,S,S]);
 * fields separated by spaces or tabs, "double quotes" around a field with
 * spaces (\" and \\ inside them); blank lines and lines whose first
 * non-blank byte is '#' are skipped. A quoted field is never a comment:
 * "#x.obj" is a mesh. Split from cli_batch.c so that it runs on a buffer
 * (tests/fuzz/fuzz_manifest.c).
 */
#include "cli_manifest.h"
#include "cli_vox.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The next field of a manifest line (in place), NULL at the end; why is
 * set (non-empty) on error. */
static char *next_field(char **cursor, char *why, size_t why_size)
{
    char *p = *cursor;
    while (*p == ' ' || *p == '\t') p++;
    if (*p == '\0') return NULL;
    char *start = p, *w = p;
    if (*p == '"') {
        p++;
        for (;;) {
            if (*p == '\0') {
                snprintf(why, why_size, "unterminated \"quote\"");
                return NULL;
            }
            if (*p == '"') { p++; break; }
            if (*p == '\\' && (p[1] == '"' || p[1] == '\\')) p++;
            *w++ = *p++;
        }
        if (*p != '\0' && *p != ' ' && *p != '\t') {
            snprintf(why, why_size, "text right after a closing quote");
            return NULL;
        }
        if (w == start) {
            snprintf(why, why_size, "empty \"\" field");
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

/* One line (NUL-terminated, no '\n'), modified in place: 0 blank or comment,
 * 1 an entry in *e, -1 malformed (why). */
static int parse_line(char *line, const clvox_grid_options *base, int like, manifest_entry *e, char *why,
                      size_t why_size)
{
    /* A comment is decided on the raw line: a quoted first field ("#x.obj")
     * is a mesh whatever it holds. */
    if (line[strspn(line, " \t")] == '#') return 0;
    char *cur = line;
    char *mesh = next_field(&cur, why, why_size);
    if (!mesh) return why[0] ? -1 : 0; /* blank */
    if (mesh[0] == '-') {
        snprintf(why, why_size, "the line must start with the mesh, not '%.200s' (write ./%.200s for a file of that name)",
                 mesh, mesh);
        return -1;
    }
    e->mesh = mesh;
    e->output = NULL;
    e->grid_by = 0;
    e->grid = *base;
    const char *grid_opt = NULL;
    for (;;) {
        char *opt = next_field(&cur, why, why_size);
        if (!opt) return why[0] ? -1 : 1;
        char *val = next_field(&cur, why, why_size);
        if (why[0]) return -1;
        if (!val) {
            snprintf(why, why_size, "%.40s needs a value", opt);
            return -1;
        }
        if (strcmp(opt, "-o") == 0 || strcmp(opt, "--output") == 0) {
            if (e->output) {
                snprintf(why, why_size, "-o given twice");
                return -1;
            }
            e->output = val;
        } else if (strcmp(opt, "-r") == 0 || strcmp(opt, "--resolution") == 0 || strcmp(opt, "--dims") == 0 ||
                   strcmp(opt, "--voxel-size") == 0) {
            if (like) {
                snprintf(why, why_size, "a grid override (-r, --dims, --voxel-size) can not be combined with --like");
                return -1;
            }
            if (grid_opt) {
                snprintf(why, why_size, "more than one of -r, --dims, --voxel-size");
                return -1;
            }
            grid_opt = opt;
            const char *w = grid_option_parse(opt, val, &e->grid, &e->grid_by);
            if (w) {
                snprintf(why, why_size, "%s", w);
                return -1;
            }
        } else {
            snprintf(why, why_size,
                     "unknown option '%.60s' (a line is MESH [-o OUT] [-r N | --dims X,Y,Z | --voxel-size S])", opt);
            return -1;
        }
    }
}

int manifest_parse(const char *text, size_t len, const clvox_grid_options *grid, int like, manifest_entry_fn fn,
                   void *user, unsigned *bad_line, char *why, size_t why_size)
{
    char *line = NULL;
    size_t cap = 0, at = 0;
    unsigned lineno = 0;
    int rc = 0;
    why[0] = '\0';
    *bad_line = 0;
    while (rc == 0 && at < len) {
        const char *nl = memchr(text + at, '\n', len - at);
        size_t n = nl ? (size_t)(nl - (text + at)) : len - at;
        if (lineno == UINT_MAX) {
            snprintf(why, why_size, "more than %u lines", UINT_MAX - 1);
            rc = -1;
            break;
        }
        lineno++;
        if (memchr(text + at, '\0', n)) {
            snprintf(why, why_size, "a NUL byte");
            rc = -1;
            break;
        }
        if (n + 1 > cap) {
            char *g = realloc(line, n + 1);
            if (!g) {
                snprintf(why, why_size, "out of memory");
                rc = -2;
                break;
            }
            line = g;
            cap = n + 1;
        }
        memcpy(line, text + at, n);
        while (n > 0 && line[n - 1] == '\r') n--;
        line[n] = '\0';
        at = nl ? (size_t)(nl - text) + 1 : len;
        manifest_entry e;
        int r = parse_line(line, grid, like, &e, why, why_size);
        if (r < 0) {
            rc = -1;
            break;
        }
        if (r > 0) {
            e.line = lineno;
            rc = fn(user, &e);
        }
    }
    if (rc == -1) *bad_line = lineno;
    free(line);
    return rc;
}
