/* SPDX-License-Identifier: Apache-2.0 */
/* The line syntax palette files (palette.c) and render maps (render_map.c)
 * share: one directive per line, '#' starts a comment, fields separated by
 * blanks, every malformed line CLVOX_ERR_PALETTE_FORMAT "SOURCE:LINE: why".
 * One copy, so the two formats cannot drift apart (they were two). */
#ifndef CLVOX_LINE_PARSER_H
#define CLVOX_LINE_PARSER_H

#include "core/internal.h"

typedef struct clvox__line_parser {
    clvox_context *ctx;
    const char *source; /* named in messages */
    unsigned line;      /* the line being parsed, from 1 (0 before the first) */
} clvox__line_parser;

/* One line's fields (at least one), NUL-terminated in place. */
typedef clvox_status (*clvox__line_fn)(void *user, char **fields, int count);

/* Calls fn for each line of text[0, size) that holds a field, with lp->line
 * its number; stops at the first status other than CLVOX_OK. A NUL byte
 * fails ("not a text file"), so does a line of more than max_fields fields
 * (at most 8). `what` names the format in the out-of-memory message. */
clvox_status clvox__parse_lines(clvox__line_parser *lp, const char *what, const char *text, size_t size,
                                int max_fields, clvox__line_fn fn, void *user);

/* CLVOX_ERR_PALETTE_FORMAT "SOURCE:LINE: why" at lp->line. */
clvox_status clvox__line_fail(const clvox__line_parser *lp, const char *fmt, ...) CLVOX__PRINTF(2, 3);

/* 1 for a name of 1 to max characters of A-Z a-z 0-9 _ - . */
int clvox__line_valid_name(const char *s, size_t max);

#endif /* CLVOX_LINE_PARSER_H */
