/* SPDX-License-Identifier: Apache-2.0 */
/* JSON output for the command line (--json, clvox info --json): a record is
 * built in memory and written as one line, so records from parallel runs do
 * not interleave. Field names: docs/cli.md "Machine-readable results". */
#ifndef CLVOX_CLI_JSON_H
#define CLVOX_CLI_JSON_H

#include <stddef.h>
#include <stdint.h>

#define JSON_MAX_DEPTH 16

typedef struct jbuf {
    char *s;        /* NUL-terminated text so far */
    size_t len, cap;
    int oom;        /* an allocation failed: the record is incomplete */
    int depth;
    unsigned char first[JSON_MAX_DEPTH]; /* no member yet at this depth */
} jbuf;

void jb_init(jbuf *b);
void jb_free(jbuf *b);
/* key is NULL inside arrays and for the top-level value. */
void jb_obj_begin(jbuf *b, const char *key);
void jb_obj_end(jbuf *b);
void jb_arr_begin(jbuf *b, const char *key);
void jb_arr_end(jbuf *b);
/* A string (NULL writes null). Control bytes become \uXXXX escapes, '"' and
 * '\' are escaped, valid UTF-8 is copied, and every byte that is not part of
 * valid UTF-8 becomes U+FFFD (the output is always valid JSON and UTF-8). */
void jb_str(jbuf *b, const char *key, const char *v);
/* A path: as jb_str, plus "<key>_hex" (the bytes in lower-case hex) when the
 * path is not valid UTF-8, so that it can be recovered exactly. */
void jb_path(jbuf *b, const char *key, const char *v);
void jb_u64(jbuf *b, const char *key, uint64_t v);
void jb_i64(jbuf *b, const char *key, int64_t v);
/* The shortest %.{15,16,17}g that reads back to the same double; null when not finite. */
void jb_num(jbuf *b, const char *key, double v);
void jb_bool(jbuf *b, const char *key, int v);
void jb_null(jbuf *b, const char *key);
void jb_num3(jbuf *b, const char *key, const double v[3]);
void jb_u32x3(jbuf *b, const char *key, const uint32_t v[3]);
/* 1 when s is valid UTF-8 (no overlong forms, no surrogates, <= U+10FFFF). */
int json_valid_utf8(const char *s);
/* Writes the record and a newline to stdout (one fwrite); 0, or -1. */
int jb_write_line(jbuf *b);

#endif
