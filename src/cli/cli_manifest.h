/* SPDX-License-Identifier: Apache-2.0 */
/* The `clvox batch --manifest` parser (cli_manifest.c), on a buffer: no
 * file, no batch, so that the fuzz target (tests/fuzz/fuzz_manifest.c) and
 * cli_batch.c share it. Syntax: docs/cli.md "Batch runs", clvox batch --help. */
#ifndef CLVOX_CLI_MANIFEST_H
#define CLVOX_CLI_MANIFEST_H

#include "clvox.h"

#include <stddef.h>

/* One mesh line. The strings live until the callback returns. */
typedef struct manifest_entry {
    const char *mesh;
    const char *output;        /* the line's -o, NULL when it has none */
    int grid_by;               /* GRID_BY_* of the line's override, 0 if none */
    clvox_grid_options grid;   /* the batch's grid with the override applied */
    unsigned line;             /* from 1 */
} manifest_entry;

/* Returns 0 to go on; a positive value stops the parse and is returned. */
typedef int (*manifest_entry_fn)(void *user, const manifest_entry *e);

/* Parses text[0..len): lines end at '\n' (a last line without one counts),
 * trailing '\r's are dropped. `grid` is the batch's grid (the base of a
 * line's override); `like`: --like was given (an override is refused).
 * Returns 0 when every line was good (fn called for each mesh line, in
 * order), -1 for a malformed line (*bad_line, and why: one line without
 * the file name), -2 out of memory, or the positive value fn returned. */
int manifest_parse(const char *text, size_t len, const clvox_grid_options *grid, int like, manifest_entry_fn fn,
                   void *user, unsigned *bad_line, char *why, size_t why_size);

#endif
