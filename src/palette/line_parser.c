/* SPDX-License-Identifier: Apache-2.0 */
/* The line syntax of palette files and render maps (line_parser.h). */
#include "palette/line_parser.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_FIELDS 8

static int blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

clvox_status clvox__line_fail(const clvox__line_parser *lp, const char *fmt, ...)
{
    char why[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(why, sizeof why, fmt, ap);
    va_end(ap);
    return clvox__fail(lp->ctx, CLVOX_ERR_PALETTE_FORMAT, "%.3000s:%u: %s", lp->source, lp->line, why);
}

/* Splits line (comment removed) into at most max fields, in place (no
 * strtok: its hidden state is shared between threads). -1: too many. */
static int split_fields(char *line, char **field, int max)
{
    int n = 0;
    for (char *p = line;;) {
        while (blank(*p)) p++;
        if (!*p) return n;
        if (n == max) return -1;
        field[n++] = p;
        while (*p && !blank(*p)) p++;
        if (*p) *p++ = '\0';
    }
}

clvox_status clvox__parse_lines(clvox__line_parser *lp, const char *what, const char *text, size_t size,
                                int max_fields, clvox__line_fn fn, void *user)
{
    if (max_fields < 1 || max_fields > MAX_FIELDS)
        return clvox__fail(lp->ctx, CLVOX_ERR_INTERNAL, "%s: %d fields per line", what, max_fields);
    char *buf = malloc(size + 1);
    if (!buf) return clvox__fail(lp->ctx, CLVOX_ERR_OUT_OF_MEMORY, "%s: out of memory", what);
    clvox_status st = CLVOX_OK;
    for (size_t pos = 0; st == CLVOX_OK && pos < size;) {
        size_t end = pos;
        while (end < size && text[end] != '\n') end++;
        lp->line++;
        size_t len = end - pos;
        memcpy(buf, text + pos, len);
        buf[len] = '\0';
        if (memchr(buf, '\0', len)) st = clvox__line_fail(lp, "NUL byte (not a text file)");
        if (st == CLVOX_OK) {
            char *hash = strchr(buf, '#');
            if (hash) *hash = '\0';
            char *field[MAX_FIELDS];
            int n = split_fields(buf, field, max_fields);
            if (n < 0) st = clvox__line_fail(lp, "too many fields");
            else if (n > 0) st = fn(user, field, n);
        }
        pos = end + 1;
    }
    free(buf);
    return st;
}

int clvox__line_valid_name(const char *s, size_t max)
{
    size_t n = strlen(s);
    if (n == 0 || n > max) return 0;
    for (size_t i = 0; i < n; i++) {
        char c = s[i];
        if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-' ||
              c == '.'))
            return 0;
    }
    return 1;
}
