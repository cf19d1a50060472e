/* SPDX-License-Identifier: Apache-2.0 */
/* Is an output complete? The check behind batch --skip-existing and --like
 * on a .npy. A set of files (npy: OUT.npy, OUT.<channel>.npy and OUT.json;
 * NRRD with several channels: OUT.nrrd and OUT.<channel>.nrrd) is named file
 * by file, its marker last (write_raster.c, outfile.c): the marker (OUT.json,
 * else the main OUT.nrrd's "clvox_set:=" header line) records the size and
 * CRC-32 of the other members. A run killed between two renames, or one whose
 * old files could not be put back, leaves members that disagree with the
 * marker: such a set is reported, never trusted. Reads every member whole
 * (the CRC): about the cost of copying the output once. */
#include "output_set.h"

#include "core/internal.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <zlib.h>

#define MARKER_MAX (1u << 16) /* the marker's text: a few hundred bytes */

static int say(char *why, size_t size, const char *fmt, const char *a, const char *b)
{
    if (why && size) snprintf(why, size, fmt, a, b ? b : "");
    return 0;
}

/* 1 when `path` is a regular file of `bytes` bytes whose CRC-32 is `crc`. */
static int member_agrees(const char *path, const char *marker, uint64_t bytes, uint32_t crc, char *why,
                         size_t size)
{
    struct stat sb;
    if (lstat(path, &sb) != 0) return say(why, size, "'%s' is missing (the set of '%s' is incomplete)", path, marker);
    if (!S_ISREG(sb.st_mode)) return say(why, size, "'%s' is not a regular file (in the set of '%s')", path, marker);
    if ((uint64_t)sb.st_size != bytes)
        return say(why, size, "'%s' does not match '%s' (its size differs: a mixed set, as a failed or killed run "
                              "leaves)", path, marker);
    FILE *f = fopen(path, "rb");
    if (!f) {
        char e[128];
        snprintf(e, sizeof e, "%s", strerror(errno));
        return say(why, size, "cannot read '%s': %s", path, e);
    }
    static const size_t chunk = 1u << 20;
    unsigned char *buf = malloc(chunk);
    uLong c = crc32(0L, Z_NULL, 0);
    uint64_t total = 0;
    size_t got;
    while (buf && (got = fread(buf, 1, chunk, f)) > 0) {
        c = crc32(c, buf, (uInt)got);
        total += got;
    }
    int no_memory = !buf, bad = no_memory || ferror(f);
    free(buf);
    fclose(f);
    if (bad) return say(why, size, "cannot read '%s'%s", path, no_memory ? ": out of memory" : "");
    if (total != bytes || (uint32_t)c != crc)
        return say(why, size, "'%s' does not match '%s' (its CRC-32 differs: a mixed set, as a failed or killed run "
                              "leaves)", path, marker);
    return 1;
}

/* The first `max` bytes of a file, NUL-terminated; NULL with `why` set. */
static char *read_head(const char *path, size_t max, size_t *len, int *whole, char *why, size_t size)
{
    struct stat sb;
    if (lstat(path, &sb) != 0) {
        say(why, size, "'%s' %s", path, errno == ENOENT ? "does not exist" : strerror(errno));
        return NULL;
    }
    if (!S_ISREG(sb.st_mode)) {
        say(why, size, "'%s' is not a regular file", path, NULL);
        return NULL;
    }
    FILE *f = fopen(path, "rb");
    char *b = f ? malloc(max + 1) : NULL;
    size_t n = b ? fread(b, 1, max, f) : 0;
    if (!b || ferror(f)) {
        say(why, size, "cannot read '%s'%s", path, f ? "" : ": cannot open it");
        free(b);
        if (f) fclose(f);
        return NULL;
    }
    *whole = n < max || fgetc(f) == EOF;
    fclose(f);
    b[n] = '\0';
    *len = n;
    return b;
}

/* ---- npy: OUT.json ---- */

typedef struct jr {
    const char *p, *end;
    int depth;
} jr;

static void ws(jr *r)
{
    while (r->p < r->end && (*r->p == ' ' || *r->p == '\t' || *r->p == '\n' || *r->p == '\r')) r->p++;
}

static int lit(jr *r, char c)
{
    ws(r);
    if (r->p >= r->end || *r->p != c) return 0;
    r->p++;
    return 1;
}

/* A JSON string, decoded into buf (\uXXXX only below 0x80, as clvox writes);
 * one longer than buf fails, or with `truncate` is cut to fit. */
static int str_ex(jr *r, char *buf, size_t size, int truncate)
{
    if (!lit(r, '"')) return 0;
    size_t k = 0;
    while (r->p < r->end && *r->p != '"') {
        char c = *r->p++;
        if ((unsigned char)c < 0x20) return 0;
        if (c == '\\') {
            if (r->p >= r->end) return 0;
            char e = *r->p++;
            const char *from = "\"\\/bfnrt", *to = "\"\\/\b\f\n\r\t";
            const char *at = strchr(from, e);
            if (e == 'u') {
                unsigned v = 0;
                for (int i = 0; i < 4; i++) {
                    if (r->p >= r->end) return 0;
                    char h = *r->p++;
                    v = v * 16 + (unsigned)(h >= '0' && h <= '9' ? h - '0' : h >= 'a' && h <= 'f' ? h - 'a' + 10
                                                              : h >= 'A' && h <= 'F' ? h - 'A' + 10 : 99);
                    if (v > 0xFFFF) return 0;
                }
                if (v == 0 || v >= 0x80) return 0;
                c = (char)v;
            } else if (e && at) {
                c = to[at - from];
            } else {
                return 0;
            }
        }
        if (buf) {
            if (k + 1 >= size && !truncate) return 0;
            if (k + 1 < size) buf[k++] = c;
        }
    }
    if (r->p >= r->end) return 0;
    r->p++;
    if (buf) buf[k] = '\0';
    return 1;
}

static int str(jr *r, char *buf, size_t size) { return str_ex(r, buf, size, 0); }

static int skip(jr *r)
{
    ws(r);
    if (r->p >= r->end || ++r->depth > 16) return 0;
    char c = *r->p;
    int ok = 1;
    if (c == '"') {
        ok = str(r, NULL, 0);
    } else if (c == '{' || c == '[') {
        char close = c == '{' ? '}' : ']';
        r->p++;
        if (!lit(r, close)) {
            do {
                if (c == '{' && (!str(r, NULL, 0) || !lit(r, ':'))) return 0;
                if (!skip(r)) return 0;
            } while (lit(r, ','));
            ok = lit(r, close);
        }
    } else {
        const char *s = r->p;
        while (r->p < r->end && strchr("+-0123456789.eEtrufalsn", *r->p)) r->p++;
        ok = r->p > s;
    }
    r->depth--;
    return ok;
}

typedef struct npy_member {
    char file[256];
    uint64_t bytes;
    uint32_t crc;
    int have_file, have_bytes, have_crc;
} npy_member;

static int member(jr *r, npy_member *m)
{
    memset(m, 0, sizeof *m);
    if (!lit(r, '{')) return 0;
    if (lit(r, '}')) return 1;
    do {
        char key[32];
        if (!str(r, key, sizeof key) || !lit(r, ':')) return 0;
        if (strcmp(key, "file") == 0) {
            if (!str(r, m->file, sizeof m->file)) return 0;
            m->have_file = 1;
        } else if (strcmp(key, "bytes") == 0) {
            ws(r);
            char num[24];
            size_t k = 0;
            while (r->p < r->end && *r->p >= '0' && *r->p <= '9' && k + 1 < sizeof num) num[k++] = *r->p++;
            num[k] = '\0';
            if (k == 0 || k > 19) return 0;
            m->bytes = strtoull(num, NULL, 10);
            m->have_bytes = 1;
        } else if (strcmp(key, "crc32") == 0) {
            char hex[16], *e;
            if (!str(r, hex, sizeof hex) || strlen(hex) != 8) return 0;
            m->crc = (uint32_t)strtoul(hex, &e, 16);
            if (*e) return 0;
            m->have_crc = 1;
        } else if (!skip(r)) {
            return 0;
        }
    } while (lit(r, ','));
    return lit(r, '}');
}

int clvox__npy_set_complete(const char *json, const char *member_path, char *why, size_t size)
{
    size_t len = 0;
    int whole = 0;
    char *text = read_head(json, MARKER_MAX, &len, &whole, why, size);
    if (!text) return 0;
    const char *slash = strrchr(json, '/');
    size_t dn = slash ? (size_t)(slash - json) + 1 : 0; /* the members lie beside the marker */
    const char *want = member_path ? (strrchr(member_path, '/') ? strrchr(member_path, '/') + 1 : member_path) : NULL;
    jr r = {text, text + len, 0};
    int ok = whole && lit(&r, '{'), npy = 0, found = 0, listed = 0;
    int result = 1;
    if (ok && !lit(&r, '}')) {
        do {
            char key[32];
            if (!(ok = str(&r, key, sizeof key) && lit(&r, ':'))) break;
            if (strcmp(key, "format") == 0) {
                char f[16];
                if (!(ok = str(&r, f, sizeof f))) break;
                npy = strcmp(f, "npy") == 0;
            } else if (strcmp(key, "channels") == 0) {
                if (!(ok = lit(&r, '{'))) break;
                if (lit(&r, '}')) continue;
                do {
                    npy_member m;
                    if (!(ok = str(&r, key, sizeof key) && lit(&r, ':') && member(&r, &m) && m.have_file)) break;
                    listed++;
                    if (want && strcmp(m.file, want) == 0) found = 1;
                    if (!result) continue; /* the first disagreement is the one said */
                    if (!m.have_bytes || !m.have_crc) {
                        result = say(why, size, "'%s' records no size and CRC-32 of its files (written by an "
                                                "earlier clvox): its set cannot be checked", json, NULL);
                        continue;
                    }
                    if (strchr(m.file, '/') || strlen(m.file) + dn >= 4096) {
                        ok = 0;
                        break;
                    }
                    char path[4096];
                    snprintf(path, sizeof path, "%.*s%s", (int)dn, json, m.file);
                    result = member_agrees(path, json, m.bytes, m.crc, why, size);
                } while (lit(&r, ','));
                if (ok) ok = lit(&r, '}');
            } else {
                ok = skip(&r);
            }
        } while (ok && lit(&r, ','));
        if (ok) ok = lit(&r, '}');
    }
    free(text);
    if (!ok || !npy || listed == 0)
        return say(why, size, "'%s' is not a clvox .npy sidecar (malformed, truncated or not \"format\": \"npy\")",
                   json, NULL);
    if (!result) return 0;
    if (want && !found) return say(why, size, "'%s' does not list '%s' (they are not one set)", json, member_path);
    return 1;
}

/* ---- NRRD: OUT.nrrd's "clvox_set:=" line ---- */

static uint32_t channel_of(const char *name, size_t n)
{
    static const uint32_t all[4] = {CLVOX_CHANNEL_OCCUPANCY, CLVOX_CHANNEL_COVERAGE, CLVOX_CHANNEL_ELEMENT,
                                    CLVOX_CHANNEL_SCORE};
    for (int i = 0; i < 4; i++)
        if (strlen(clvox__channel_name(all[i])) == n && strncmp(name, clvox__channel_name(all[i]), n) == 0)
            return all[i];
    return 0;
}

/* The value of header line "key:=" (up to its end), or NULL. */
static const char *field(const char *head, const char *key, size_t *n)
{
    size_t k = strlen(key);
    for (const char *p = head; p && *p;) {
        if (*p == '\n' || (*p == '\r' && p[1] == '\n')) return NULL; /* the blank line ends the header */
        const char *eol = strchr(p, '\n');
        if (strncmp(p, key, k) == 0) {
            *n = eol ? (size_t)(eol - p - k) : strlen(p + k);
            if (*n && p[k + *n - 1] == '\r') (*n)--;
            return p + k;
        }
        p = eol ? eol + 1 : NULL;
    }
    return NULL;
}

static int nrrd_complete(const char *path, char *why, size_t size)
{
    size_t len = 0;
    int whole = 0;
    char *head = read_head(path, MARKER_MAX, &len, &whole, why, size);
    if (!head) return 0;
    size_t n = 0, cn = 0;
    const char *set = field(head, "clvox_set:=", &n), *ch = field(head, "clvox_channel:=", &cn);
    if (!set) { /* one channel (or not clvox's): a file on its own */
        free(head);
        return 1;
    }
    uint32_t main_channel = ch ? channel_of(ch, cn) : 0, mask = main_channel;
    uint32_t chans[4];
    uint64_t bytes[4];
    uint32_t crcs[4];
    size_t k = 0;
    int ok = main_channel != 0;
    for (const char *p = set, *end = set + n; ok && p < end;) {
        while (p < end && *p == ' ') p++;
        if (p >= end) break;
        const char *c1 = memchr(p, ':', (size_t)(end - p));
        uint32_t c = c1 ? channel_of(p, (size_t)(c1 - p)) : 0;
        char tail[40];
        size_t tl = c1 ? (size_t)(end - c1) : 0;
        const char *sp = c1 ? memchr(c1, ' ', tl) : NULL;
        if (sp) tl = (size_t)(sp - c1);
        unsigned long long b;
        unsigned x;
        int used = 0;
        ok = c && !(mask & c) && k < 4 && tl < sizeof tail;
        if (ok) {
            memcpy(tail, c1, tl);
            tail[tl] = '\0';
            ok = sscanf(tail, ":%20llu:%8x%n", &b, &x, &used) == 2 && (size_t)used == tl;
        }
        if (ok) {
            mask |= c;
            chans[k] = c, bytes[k] = b, crcs[k] = x, k++;
            p = c1 + tl;
        }
    }
    free(head);
    if (!ok || k == 0) return say(why, size, "'%s': malformed clvox_set:= line", path, NULL);
    for (size_t i = 0; i < k; i++) {
        char *member_path = clvox__channel_path(path, chans[i], mask);
        if (!member_path) return say(why, size, "out of memory", NULL, NULL);
        int agrees = member_agrees(member_path, path, bytes[i], crcs[i], why, size);
        free(member_path);
        if (!agrees) return 0;
    }
    return 1;
}

int clvox__output_complete(const char *path, char *why, size_t size)
{
    struct stat sb;
    if (lstat(path, &sb) != 0) return say(why, size, "'%s' does not exist", path, NULL);
    if (!S_ISREG(sb.st_mode)) return say(why, size, "'%s' is not a regular file", path, NULL);
    switch (clvox_format_from_path(path)) {
    case CLVOX_FORMAT_NPY: {
        char *json = clvox__replace_ext(path, ".json");
        if (!json) return say(why, size, "out of memory", NULL, NULL);
        int ok = clvox__npy_set_complete(json, path, why, size);
        free(json);
        return ok;
    }
    case CLVOX_FORMAT_NRRD: return nrrd_complete(path, why, size);
    default: return 1; /* one file, named only when complete */
    }
}

/* ---- npy: OUT.json for the reader (read_volume.c) ---- */

/* A JSON number into *v (finite). */
static int number(jr *r, double *v)
{
    ws(r);
    char num[48];
    size_t k = 0;
    while (r->p < r->end && strchr("+-0123456789.eE", *r->p) && k + 1 < sizeof num) num[k++] = *r->p++;
    num[k] = '\0';
    char *e;
    *v = k ? strtod(num, &e) : 0;
    return k && *e == '\0' && isfinite(*v);
}

static int triple(jr *r, double v[3])
{
    if (!lit(r, '[')) return 0;
    for (int i = 0; i < 3; i++)
        if ((i && !lit(r, ',')) || !number(r, &v[i])) return 0;
    return lit(r, ']');
}

static int sidecar_channel(jr *r, clvox__npy_sidecar *s)
{
    if (s->nchannels >= 4) return 0;
    size_t i = s->nchannels;
    if (!str(r, s->ch[i].name, sizeof s->ch[i].name) || !lit(r, ':') || !lit(r, '{')) return 0;
    int have_file = 0;
    if (!lit(r, '}')) {
        do {
            char key[32];
            if (!str(r, key, sizeof key) || !lit(r, ':')) return 0;
            if (strcmp(key, "file") == 0) {
                if (!str(r, s->ch[i].file, sizeof s->ch[i].file)) return 0;
                have_file = 1;
            } else if (strcmp(key, "dtype") == 0) {
                if (!str(r, s->ch[i].dtype, sizeof s->ch[i].dtype)) return 0;
            } else if (strcmp(key, "packed_bits") == 0) {
                ws(r);
                if (r->end - r->p >= 4 && memcmp(r->p, "true", 4) == 0) s->ch[i].packed_bits = 1, r->p += 4;
                else if (r->end - r->p >= 5 && memcmp(r->p, "false", 5) == 0) r->p += 5;
                else return 0;
            } else if (!skip(r)) {
                return 0;
            }
        } while (lit(r, ','));
        if (!lit(r, '}')) return 0;
    }
    if (!have_file || !s->ch[i].file[0] || strchr(s->ch[i].file, '/')) return 0;
    s->nchannels++;
    return 1;
}

int clvox__npy_sidecar_parse(const char *text, size_t len, clvox__npy_sidecar *s)
{
    memset(s, 0, sizeof *s);
    jr r = {text, text + len, 0};
    int npy = 0;
    if (!lit(&r, '{')) return 0;
    if (lit(&r, '}')) return 0;
    do {
        char key[32];
        if (!str(&r, key, sizeof key) || !lit(&r, ':')) return 0;
        int ok = 1;
        if (strcmp(key, "format") == 0) {
            char f[16];
            ok = str(&r, f, sizeof f);
            npy = ok && strcmp(f, "npy") == 0;
        } else if (strcmp(key, "clvox_version") == 0) {
            ok = str_ex(&r, s->version, sizeof s->version, 1);
        } else if (strcmp(key, "method") == 0) {
            ok = str_ex(&r, s->method, sizeof s->method, 1);
        } else if (strcmp(key, "parameters") == 0) { /* cut as the EXR reader cuts it */
            ok = str_ex(&r, s->parameters, sizeof s->parameters, 1);
        } else if (strcmp(key, "dims") == 0) {
            ok = s->have_dims = triple(&r, s->dims);
        } else if (strcmp(key, "origin") == 0) {
            ok = s->have_origin = triple(&r, s->origin);
        } else if (strcmp(key, "voxel_size") == 0) {
            ok = s->have_voxel_size = triple(&r, s->voxel_size);
        } else if (strcmp(key, "channels") == 0) {
            ok = lit(&r, '{');
            if (ok && !lit(&r, '}')) {
                do ok = sidecar_channel(&r, s);
                while (ok && lit(&r, ','));
                ok = ok && lit(&r, '}');
            }
        } else {
            ok = skip(&r);
        }
        if (!ok) return 0;
    } while (lit(&r, ','));
    if (!lit(&r, '}')) return 0;
    ws(&r);
    return npy && r.p == r.end && s->have_dims && s->nchannels > 0;
}
