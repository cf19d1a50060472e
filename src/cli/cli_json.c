/* SPDX-License-Identifier: Apache-2.0 */
/*
 * JSON records for --json and clvox info --json (cli_json.h). Strings: '"',
 * '\' and control bytes are escaped, valid UTF-8 is copied, bytes that are not
 * valid UTF-8 become U+FFFD; paths that are not valid UTF-8 also get a
 * "<key>_hex" member with their exact bytes. Numbers: integers as integers,
 * doubles as the shortest of %.15g/%.16g/%.17g that reads back exactly
 * (the C locale: the CLI never calls setlocale), non-finite ones as null.
 */
#include "cli_json.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void jb_init(jbuf *b)
{
    memset(b, 0, sizeof *b);
    b->first[0] = 1;
}

void jb_free(jbuf *b)
{
    free(b->s);
    memset(b, 0, sizeof *b);
}

static void put(jbuf *b, const char *s, size_t n)
{
    if (b->oom) return;
    if (b->len + n + 1 > b->cap) {
        size_t cap = b->cap ? b->cap : 1024;
        while (cap < b->len + n + 1) cap *= 2;
        char *g = realloc(b->s, cap);
        if (!g) {
            b->oom = 1;
            return;
        }
        b->s = g;
        b->cap = cap;
    }
    memcpy(b->s + b->len, s, n);
    b->len += n;
    b->s[b->len] = '\0';
}

static void puts_(jbuf *b, const char *s) { put(b, s, strlen(s)); }

/* Length of the valid UTF-8 sequence at s, or 0. */
static size_t utf8_len(const unsigned char *s)
{
    unsigned c = s[0];
    if (c < 0x80) return 1;
    size_t n;
    unsigned cp;
    if (c >= 0xC2 && c <= 0xDF) { n = 2; cp = c & 0x1F; }
    else if (c >= 0xE0 && c <= 0xEF) { n = 3; cp = c & 0x0F; }
    else if (c >= 0xF0 && c <= 0xF4) { n = 4; cp = c & 0x07; }
    else return 0;
    for (size_t i = 1; i < n; i++) {
        if ((s[i] & 0xC0) != 0x80) return 0;
        cp = (cp << 6) | (s[i] & 0x3F);
    }
    if ((n == 3 && cp < 0x800) || (n == 4 && (cp < 0x10000 || cp > 0x10FFFF))) return 0;
    if (cp >= 0xD800 && cp <= 0xDFFF) return 0;
    return n;
}

int json_valid_utf8(const char *str)
{
    const unsigned char *s = (const unsigned char *)str;
    while (*s) {
        size_t n = utf8_len(s);
        if (!n) return 0;
        s += n;
    }
    return 1;
}

static void put_string(jbuf *b, const char *str)
{
    const unsigned char *s = (const unsigned char *)str;
    put(b, "\"", 1);
    while (*s) {
        unsigned c = *s;
        char esc[8];
        if (c == '"') puts_(b, "\\\"");
        else if (c == '\\') puts_(b, "\\\\");
        else if (c == '\n') puts_(b, "\\n");
        else if (c == '\r') puts_(b, "\\r");
        else if (c == '\t') puts_(b, "\\t");
        else if (c < 0x20 || c == 0x7F) {
            snprintf(esc, sizeof esc, "\\u%04x", c);
            puts_(b, esc);
        } else if (c < 0x80) {
            put(b, (const char *)s, 1);
        } else {
            size_t n = utf8_len(s);
            if (n) {
                put(b, (const char *)s, n);
                s += n;
                continue;
            }
            puts_(b, "\\ufffd");
        }
        s++;
    }
    put(b, "\"", 1);
}

/* The comma and "key": before a member. */
static void member(jbuf *b, const char *key)
{
    int d = b->depth;
    if (!b->first[d]) put(b, ",", 1);
    b->first[d] = 0;
    if (key) {
        put_string(b, key);
        put(b, ":", 1);
    }
}

static void open_(jbuf *b, const char *key, const char *bracket)
{
    member(b, key);
    puts_(b, bracket);
    if (b->depth + 1 < JSON_MAX_DEPTH) b->depth++;
    else b->oom = 1;
    b->first[b->depth] = 1;
}

static void close_(jbuf *b, const char *bracket)
{
    puts_(b, bracket);
    if (b->depth > 0) b->depth--;
}

void jb_obj_begin(jbuf *b, const char *key) { open_(b, key, "{"); }
void jb_obj_end(jbuf *b) { close_(b, "}"); }
void jb_arr_begin(jbuf *b, const char *key) { open_(b, key, "["); }
void jb_arr_end(jbuf *b) { close_(b, "]"); }

void jb_str(jbuf *b, const char *key, const char *v)
{
    member(b, key);
    if (v) put_string(b, v);
    else puts_(b, "null");
}

void jb_path(jbuf *b, const char *key, const char *v)
{
    jb_str(b, key, v);
    if (!v || json_valid_utf8(v) || !key) return;
    char name[128];
    snprintf(name, sizeof name, "%s_hex", key);
    member(b, name);
    put(b, "\"", 1);
    for (const unsigned char *s = (const unsigned char *)v; *s; s++) {
        char hx[3];
        snprintf(hx, sizeof hx, "%02x", *s);
        put(b, hx, 2);
    }
    put(b, "\"", 1);
}

void jb_u64(jbuf *b, const char *key, uint64_t v)
{
    char t[32];
    snprintf(t, sizeof t, "%llu", (unsigned long long)v);
    member(b, key);
    puts_(b, t);
}

void jb_i64(jbuf *b, const char *key, int64_t v)
{
    char t[32];
    snprintf(t, sizeof t, "%lld", (long long)v);
    member(b, key);
    puts_(b, t);
}

void jb_num(jbuf *b, const char *key, double v)
{
    member(b, key);
    if (!isfinite(v)) {
        puts_(b, "null");
        return;
    }
    char t[40];
    for (int p = 15; p <= 17; p++) {
        snprintf(t, sizeof t, "%.*g", p, v);
        if (strtod(t, NULL) == v) break;
    }
    if (v == 0) snprintf(t, sizeof t, "0"); /* also -0 */
    puts_(b, t);
}

void jb_bool(jbuf *b, const char *key, int v)
{
    member(b, key);
    puts_(b, v ? "true" : "false");
}

void jb_null(jbuf *b, const char *key)
{
    member(b, key);
    puts_(b, "null");
}

void jb_num3(jbuf *b, const char *key, const double v[3])
{
    jb_arr_begin(b, key);
    for (int i = 0; i < 3; i++) jb_num(b, NULL, v[i]);
    jb_arr_end(b);
}

void jb_u32x3(jbuf *b, const char *key, const uint32_t v[3])
{
    jb_arr_begin(b, key);
    for (int i = 0; i < 3; i++) jb_u64(b, NULL, v[i]);
    jb_arr_end(b);
}

int jb_write_line(jbuf *b)
{
    if (b->oom || !b->s) return -1;
    put(b, "\n", 1);
    if (b->oom) return -1;
    return fwrite(b->s, 1, b->len, stdout) == b->len ? 0 : -1;
}
