/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Reading back the volume formats clvox writes besides EXR (volume_source.h):
 *  - npy (write_npy.c): OUT.npy and OUT.<channel>.npy, with OUT.json beside
 *    them for the grid (a lone .npy without it is read as its one channel on
 *    a grid at origin 0 with voxel size 1); |u1 0/1, |u1 packed bits, <f2,
 *    <f4, <u2, <u4; format 1.0 to 3.0 headers, C order only.
 *  - NRRD (write_nrrd.c): attached (.nrrd) or detached (.nhdr + "data file"),
 *    raw or gzip, uint8/uint16/uint32/float; clvox's set line names the
 *    other channels' files. The corner origin comes from clvox_origin_corner
 *    when the header has it, else space origin - h/2.
 *  - binvox (write_binvox.c): cubic, occupancy, RLE.
 *  - OpenVDB: through the plugin (vdb_plugin.c), or a clear error without it.
 * The format is told by the first bytes, never the extension.
 *
 * Every parser is bounded by the file: header text is read up to 64 KiB,
 * every size is checked against the file's size before anything is
 * allocated (raw data must fill the file exactly; gzip data may claim at
 * most 1100 bytes per compressed byte, above deflate's 1032; binvox RLE at
 * most 255 voxels per 2 bytes), and all products are checked. npy and NRRD
 * stream one slice at a time (raw: pread; gzip: inflate); binvox stores x
 * slowest, so its z slices need the whole volume: it is decoded once into
 * bits (N^3/8 bytes, at most 16 bytes per byte of file).
 */
#include "io/output_set.h"
#include "io/volume_source.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#define HEAD_MAX (1u << 16)
#define GZIP_MAX_RATIO 1100u

enum { FMT_NPY = 1, FMT_NRRD, FMT_BINVOX, FMT_VDB };
enum { ST_U8, ST_BITS, ST_U16, ST_U32, ST_F16, ST_F32 }; /* samples as stored */

typedef struct vchan {
    char name[16];
    char *file;          /* the file holding the data */
    int stored;          /* ST_* */
    int gzip;
    uint64_t offset;     /* where the data starts */
    uint64_t data_bytes; /* raw: exactly; gzip: the compressed bytes */
} vchan;

struct clvox__vsrc {
    clvox_context *ctx;
    char *path;
    int format;
    uint32_t dims[3];
    size_t nch;
    vchan ch[4];
    uint8_t *bits;       /* binvox: the volume, bit (z*N + y)*N + x */
    void *vdb;           /* OpenVDB: the plugin's reader */
};

static const char *const channel_names[4] = {"coverage", "element", "occupancy", "score"}; /* as EXR lists them */

static int channel_index(const char *name)
{
    for (int i = 0; i < 4; i++)
        if (strcmp(name, channel_names[i]) == 0) return i;
    return -1;
}

/* ---- files ------------------------------------------------------------------------ */

static clvox_status open_file(clvox_context *ctx, const char *path, int *fd, uint64_t *size)
{
    const char *why = NULL;
    *fd = clvox_open_regular_read(path, &why);
    if (*fd < 0) return clvox__fail(ctx, CLVOX_ERR_IO, "cannot read '%s': %s", path, why ? why : "cannot open it");
    struct stat sb;
    if (fstat(*fd, &sb) != 0 || sb.st_size < 0) {
        int e = errno;
        close(*fd);
        *fd = -1;
        return clvox__fail(ctx, CLVOX_ERR_IO, "cannot read '%s': %s", path, strerror(e));
    }
    *size = (uint64_t)sb.st_size;
    return CLVOX_OK;
}

/* Reads exactly n bytes at off; a short read is a truncated file. */
static clvox_status read_at(clvox_context *ctx, int fd, const char *path, void *buf, size_t n, uint64_t off)
{
    uint8_t *p = buf;
    size_t done = 0;
    while (done < n) {
        size_t k = n - done > (1u << 30) ? (1u << 30) : n - done;
        ssize_t got = pread(fd, p + done, k, (off_t)(off + done));
        if (got < 0 && errno == EINTR) continue;
        if (got < 0) return clvox__fail(ctx, CLVOX_ERR_IO, "read from '%s' failed: %s", path, strerror(errno));
        if (got == 0) return clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' is truncated", path);
        done += (size_t)got;
    }
    return CLVOX_OK;
}

/* The first min(size, HEAD_MAX) bytes, NUL-terminated. */
static clvox_status read_head(clvox_context *ctx, int fd, const char *path, uint64_t size, char **out, size_t *len)
{
    size_t n = size < HEAD_MAX ? (size_t)size : HEAD_MAX;
    char *b = malloc(n + 1);
    if (!b) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    clvox_status st = read_at(ctx, fd, path, b, n, 0);
    if (st != CLVOX_OK) {
        free(b);
        return st;
    }
    b[n] = '\0';
    *out = b;
    *len = n;
    return CLVOX_OK;
}

/* `name` beside the file `path` (name as is when absolute). */
static char *beside(const char *path, const char *name)
{
    const char *slash = strrchr(path, '/');
    size_t dn = name[0] == '/' || !slash ? 0 : (size_t)(slash - path) + 1, nn = strlen(name);
    char *out = malloc(dn + nn + 1);
    if (!out) return NULL;
    memcpy(out, path, dn);
    memcpy(out + dn, name, nn + 1);
    return out;
}

static uint64_t stored_bytes(int stored, uint32_t X)
{
    switch (stored) {
    case ST_BITS: return ((uint64_t)X + 7) / 8;
    case ST_U8: return X;
    case ST_U16: case ST_F16: return (uint64_t)X * 2;
    default: return (uint64_t)X * 4;
    }
}

static clvox_status check_dims(clvox__vsrc *s, const char *path, const uint64_t d[3])
{
    for (int a = 0; a < 3; a++)
        if (d[a] == 0 || d[a] > CLVOX_MAX_AXIS)
            return clvox__fail(s->ctx, CLVOX_ERR_EXR, "'%s' is not a readable volume: size %llu along %c (1 to %u)",
                               path, (unsigned long long)d[a], "xyz"[a], CLVOX_MAX_AXIS);
    for (int a = 0; a < 3; a++) s->dims[a] = (uint32_t)d[a];
    return CLVOX_OK;
}

/* Adds a channel; its data (raw: exactly, gzip: bounded) must fit the file. */
static clvox_status add_channel(clvox__vsrc *s, const char *name, const char *file, int stored, int gzip,
                                uint64_t offset, uint64_t file_size)
{
    if (channel_index(name) < 0)
        return clvox__fail(s->ctx, CLVOX_ERR_EXR, "'%s': unknown channel \"%s\"", s->path, name);
    for (size_t i = 0; i < s->nch; i++)
        if (strcmp(s->ch[i].name, name) == 0)
            return clvox__fail(s->ctx, CLVOX_ERR_EXR, "'%s': channel \"%s\" twice", s->path, name);
    if (s->nch >= 4) return clvox__fail(s->ctx, CLVOX_ERR_EXR, "'%s': too many channels", s->path);
    const uint64_t row = stored_bytes(stored, s->dims[0]), rows = (uint64_t)s->dims[1] * s->dims[2];
    /* dims <= 2^16 each: row < 2^18, rows <= 2^32, the product < 2^50 */
    const uint64_t want = row * rows, have = file_size >= offset ? file_size - offset : 0;
    if (file_size < offset || (!gzip && have != want) || (gzip && want / GZIP_MAX_RATIO > have))
        return clvox__fail(s->ctx, CLVOX_ERR_EXR,
                           "'%s' is %s: %u x %u x %u voxels need %llu bytes of data, the file has %llu", file,
                           have < want ? "truncated" : "corrupt", s->dims[0], s->dims[1], s->dims[2],
                           (unsigned long long)want, (unsigned long long)have);
    vchan *c = &s->ch[s->nch];
    memset(c, 0, sizeof *c);
    snprintf(c->name, sizeof c->name, "%s", name);
    if (!(c->file = strdup(file))) return clvox__fail(s->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    c->stored = stored;
    c->gzip = gzip;
    c->offset = offset;
    c->data_bytes = have;
    s->nch++;
    return CLVOX_OK;
}

/* ---- npy ---------------------------------------------------------------------------- */

/* The value text after 'key': in an npy header dict, or NULL. */
static const char *dict_value(const char *dict, const char *key)
{
    char q[40];
    snprintf(q, sizeof q, "'%s'", key);
    const char *p = strstr(dict, q);
    if (!p) return NULL;
    p += strlen(q);
    while (*p == ' ') p++;
    if (*p != ':') return NULL;
    p++;
    while (*p == ' ') p++;
    return p;
}

typedef struct npy_head {
    int stored;        /* ST_U8 for u1 (packed bits are said by the sidecar) */
    uint64_t shape[3]; /* as written: (Z, Y, X or ceil(X/8)) */
    uint64_t data_at;
} npy_head;

static clvox_status npy_parse(clvox__vsrc *s, const char *path, int fd, uint64_t size, npy_head *h)
{
    clvox_context *ctx = s->ctx;
    uint8_t pre[12];
    if (size < 10) return clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' is truncated (an npy header needs 10 bytes)", path);
    clvox_status st = read_at(ctx, fd, path, pre, size < 12 ? 10 : 12, 0);
    if (st != CLVOX_OK) return st;
    if (memcmp(pre, "\x93NUMPY", 6) != 0) return clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' is not an npy file", path);
    uint64_t hl, at;
    if (pre[6] == 1) {
        hl = (uint64_t)pre[8] | (uint64_t)pre[9] << 8;
        at = 10;
    } else if ((pre[6] == 2 || pre[6] == 3) && size >= 12) {
        hl = (uint64_t)pre[8] | (uint64_t)pre[9] << 8 | (uint64_t)pre[10] << 16 | (uint64_t)pre[11] << 24;
        at = 12;
    } else {
        return clvox__fail(ctx, CLVOX_ERR_EXR, "'%s': npy format version %u.%u is not one clvox reads", path, pre[6],
                           pre[7]);
    }
    if (hl == 0 || hl > HEAD_MAX || hl > size - at)
        return clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' is corrupt or truncated: npy header of %llu bytes", path,
                           (unsigned long long)hl);
    char *dict = malloc((size_t)hl + 1);
    if (!dict) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    st = read_at(ctx, fd, path, dict, (size_t)hl, at);
    if (st != CLVOX_OK) {
        free(dict);
        return st;
    }
    dict[hl] = '\0';
    if (strlen(dict) != hl) st = clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' is corrupt: a NUL in its npy header", path);
    const char *d = st == CLVOX_OK ? dict_value(dict, "descr") : NULL, *f = dict_value(dict, "fortran_order"),
               *sh = dict_value(dict, "shape");
    if (st == CLVOX_OK && (!d || !f || !sh))
        st = clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' is corrupt: its npy header lacks descr, fortran_order or shape",
                         path);
    if (st == CLVOX_OK && strncmp(f, "False", 5) != 0)
        st = clvox__fail(ctx, CLVOX_ERR_EXR, "'%s': a Fortran-order array (clvox writes C order)", path);
    if (st == CLVOX_OK) {
        static const struct { const char *descr; int stored; } types[] = {
            {"'|u1'", ST_U8}, {"'<u1'", ST_U8}, {"'u1'", ST_U8}, {"'|b1'", ST_U8}, {"'<f2'", ST_F16},
            {"'<f4'", ST_F32}, {"'<u2'", ST_U16}, {"'<u4'", ST_U32}};
        h->stored = -1;
        for (size_t i = 0; i < sizeof types / sizeof *types; i++)
            if (strncmp(d, types[i].descr, strlen(types[i].descr)) == 0) h->stored = types[i].stored;
        if (h->stored < 0) {
            const char *e = strchr(d + 1, '\'');
            int n = *d == '\'' && e && e - d < 16 ? (int)(e - d - 1) : 0;
            st = clvox__fail(ctx, CLVOX_ERR_EXR,
                             "'%s': npy dtype '%.*s' is not one clvox reads (|u1, <u2, <u4, <f2, <f4)", path, n, d + 1);
        }
    }
    if (st == CLVOX_OK) {
        const char *p = sh;
        int n = 0, ok = *p++ == '(';
        while (ok) {
            while (*p == ' ') p++;
            if (*p == ')') break;
            if (n == 3 || *p < '0' || *p > '9') {
                ok = 0;
                break;
            }
            uint64_t v = 0;
            while (*p >= '0' && *p <= '9' && v <= CLVOX_MAX_AXIS) v = v * 10 + (uint64_t)(*p++ - '0');
            h->shape[n++] = v;
            while (*p == ' ') p++;
            if (*p == ',') p++;
            else if (*p != ')') ok = 0;
        }
        if (!ok || n != 3)
            st = clvox__fail(ctx, CLVOX_ERR_EXR, "'%s': the npy array is not 3-D (shape (Z, Y, X) expected)", path);
    }
    free(dict);
    h->data_at = at + hl;
    return st;
}

static clvox_status npy_open(clvox__vsrc *s, int fd, uint64_t size, clvox_volume_info *info)
{
    clvox_context *ctx = s->ctx;
    npy_head h;
    clvox_status st = npy_parse(s, s->path, fd, size, &h);
    if (st != CLVOX_OK) return st;
    char *json = clvox__replace_ext(s->path, ".json");
    if (!json) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    int jfd = -1;
    uint64_t jsize = 0;
    const char *why = NULL;
    jfd = clvox_open_regular_read(json, &why);
    if (jfd < 0 && errno != ENOENT) {
        st = clvox__fail(ctx, CLVOX_ERR_IO, "cannot read '%s' (the grid of '%s'): %s", json, s->path, why);
        free(json);
        return st;
    }
    if (jfd < 0) { /* a lone .npy: its one channel, by dtype, on a unit grid */
        free(json);
        uint64_t d[3] = {h.shape[2], h.shape[1], h.shape[0]};
        if ((st = check_dims(s, s->path, d)) != CLVOX_OK) return st;
        const char *name = h.stored == ST_U8 ? "occupancy" : (h.stored == ST_U16 || h.stored == ST_U32) ? "element"
                                                                                                      : "coverage";
        for (int a = 0; a < 3; a++) info->voxel_size[a] = 1.0;
        return add_channel(s, name, s->path, h.stored, 0, h.data_at, size);
    }
    char *text = NULL;
    size_t len = 0;
    struct stat sb;
    if (fstat(jfd, &sb) != 0) st = clvox__fail(ctx, CLVOX_ERR_IO, "cannot read '%s': %s", json, strerror(errno));
    else jsize = (uint64_t)sb.st_size;
    if (st == CLVOX_OK) st = read_head(ctx, jfd, json, jsize, &text, &len);
    close(jfd);
    clvox__npy_sidecar sc;
    memset(&sc, 0, sizeof sc);
    if (st == CLVOX_OK && (jsize > HEAD_MAX || !clvox__npy_sidecar_parse(text, len, &sc)))
        st = clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' (the grid of '%s') is not a clvox npy sidecar", json, s->path);
    free(text);
    uint64_t d[3];
    for (int a = 0; a < 3 && st == CLVOX_OK; a++) {
        if (sc.dims[a] < 1 || sc.dims[a] > CLVOX_MAX_AXIS || sc.dims[a] != floor(sc.dims[a]) ||
            (sc.have_voxel_size && !(sc.voxel_size[a] > 0)))
            st = clvox__fail(ctx, CLVOX_ERR_EXR, "'%s': bad dims or voxel_size", json);
        else d[a] = (uint64_t)sc.dims[a];
        info->origin[a] = sc.have_origin ? sc.origin[a] : 0.0;
        info->voxel_size[a] = sc.have_voxel_size ? sc.voxel_size[a] : 1.0;
    }
    if (st == CLVOX_OK) st = check_dims(s, json, d);
    if (st == CLVOX_OK) {
        snprintf(info->method, sizeof info->method, "%s", sc.method);
        snprintf(info->parameters, sizeof info->parameters, "%s", sc.parameters);
        snprintf(info->version, sizeof info->version, "%s", sc.version);
    }
    const char *base = strrchr(s->path, '/') ? strrchr(s->path, '/') + 1 : s->path;
    int listed = 0;
    for (size_t i = 0; st == CLVOX_OK && i < sc.nchannels; i++) {
        char *file = beside(json, sc.ch[i].file);
        if (!file) {
            st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
            break;
        }
        listed |= strcmp(sc.ch[i].file, base) == 0;
        int cfd = -1;
        uint64_t csize = 0;
        npy_head ch;
        st = open_file(ctx, file, &cfd, &csize);
        if (st == CLVOX_OK) st = npy_parse(s, file, cfd, csize, &ch);
        if (cfd >= 0) close(cfd);
        const int bits = sc.ch[i].packed_bits;
        const uint64_t last = bits ? ((uint64_t)s->dims[0] + 7) / 8 : s->dims[0];
        if (st == CLVOX_OK && (ch.shape[0] != s->dims[2] || ch.shape[1] != s->dims[1] || ch.shape[2] != last ||
                               (bits && ch.stored != ST_U8)))
            st = clvox__fail(ctx, CLVOX_ERR_EXR,
                             "'%s' does not match '%s': shape (%llu, %llu, %llu), the grid is %u x %u x %u%s", file,
                             json, (unsigned long long)ch.shape[0], (unsigned long long)ch.shape[1],
                             (unsigned long long)ch.shape[2], s->dims[0], s->dims[1], s->dims[2],
                             bits ? " as packed bits" : "");
        if (st == CLVOX_OK)
            st = add_channel(s, sc.ch[i].name, file, bits ? ST_BITS : ch.stored, 0, ch.data_at, csize);
        free(file);
    }
    if (st == CLVOX_OK && !listed)
        st = clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' does not list '%s' (they are not one set)", json, s->path);
    free(json);
    return st;
}

/* ---- NRRD ---------------------------------------------------------------------------- */

typedef struct nrrd_head {
    int stored, gzip, big, dimension;
    uint64_t sizes[3];
    int have_sizes, have_type, have_dir, have_spacings, have_sorigin, have_corner;
    double dir[3], sorigin[3], corner[3];
    char channel[16], method[32], version[32], set[512], datafile[1024];
    uint64_t data_at;
} nrrd_head;

/* n numbers from text: the digits-and-signs runs, everything else separating. */
static int numbers(const char *p, const char *end, double *v, int n)
{
    int k = 0;
    while (p < end) {
        if (strchr("+-0123456789.", *p)) {
            char num[48];
            size_t m = 0;
            while (p < end && strchr("+-0123456789.eE", *p) && m + 1 < sizeof num) num[m++] = *p++;
            num[m] = '\0';
            char *e;
            double x = strtod(num, &e);
            if (*e || !isfinite(x) || k == n) return -1;
            v[k++] = x;
        } else if (strchr(" \t(),", *p)) {
            p++;
        } else {
            return -1;
        }
    }
    return k;
}

static void copy_value(char *dst, size_t size, const char *v, size_t n)
{
    if (n >= size) n = size - 1;
    memcpy(dst, v, n);
    dst[n] = '\0';
}

static clvox_status nrrd_parse(clvox__vsrc *s, const char *path, int fd, uint64_t size, nrrd_head *h)
{
    clvox_context *ctx = s->ctx;
    memset(h, 0, sizeof *h);
    char *head = NULL;
    size_t len = 0;
    clvox_status st = read_head(ctx, fd, path, size, &head, &len);
    if (st != CLVOX_OK) return st;
    if (len < 9 || strncmp(head, "NRRD000", 7) != 0 || head[7] < '1' || head[7] > '5' ||
        (head[8] != '\n' && head[8] != '\r')) {
        free(head);
        return clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' is not an NRRD file (NRRD0001 to NRRD0005)", path);
    }
#define NRRD_BAD(...) do { st = clvox__fail(ctx, CLVOX_ERR_EXR, __VA_ARGS__); goto done; } while (0)
    const char *first_eol = memchr(head, '\n', len);
    if (!first_eol) NRRD_BAD("'%s' is truncated: its NRRD header has one line", path);
    const char *p = first_eol + 1, *end = head + len;
    int ended = 0;
    while (p < end) {
        const char *eol = memchr(p, '\n', (size_t)(end - p));
        if (!eol) {
            if (len < size) NRRD_BAD("'%s': NRRD header longer than %u bytes", path, HEAD_MAX);
            eol = end; /* a detached header may end without a newline */
        }
        const char *le = eol > p && eol[-1] == '\r' ? eol - 1 : eol;
        const char *line = p;
        p = eol < end ? eol + 1 : end;
        if (le == line) {
            ended = 1;
            break;
        }
        if (*line == '#') continue;
        if (memchr(line, '\0', (size_t)(le - line))) NRRD_BAD("'%s' is corrupt: a NUL in its NRRD header", path);
        const char *kv = NULL, *colon = NULL;
        for (const char *q = line; q + 1 < le; q++)
            if (q[0] == ':' && (q[1] == '=' || q[1] == ' ')) {
                colon = q;
                kv = q[1] == '=' ? q : NULL;
                break;
            }
        if (!colon) NRRD_BAD("'%s' is corrupt: NRRD header line without ': ' or ':='", path);
        const size_t kn = (size_t)(colon - line);
        const char *v = colon + 2;
        const size_t vn = (size_t)(le - v);
#define KEY(k) (kn == strlen(k) && strncmp(line, k, kn) == 0)
        if (kv) {
            if (KEY("clvox_channel")) copy_value(h->channel, sizeof h->channel, v, vn);
            else if (KEY("clvox_method")) copy_value(h->method, sizeof h->method, v, vn);
            else if (KEY("clvox_version")) copy_value(h->version, sizeof h->version, v, vn);
            else if (KEY("clvox_set")) {
                if (vn >= sizeof h->set) NRRD_BAD("'%s': clvox_set:= line too long", path);
                copy_value(h->set, sizeof h->set, v, vn);
            } else if (KEY("clvox_origin_corner")) {
                if (numbers(v, le, h->corner, 3) != 3) NRRD_BAD("'%s': bad clvox_origin_corner", path);
                h->have_corner = 1;
            }
            continue;
        }
        char val[128];
        copy_value(val, sizeof val, v, vn);
        if (KEY("type")) {
            static const struct { const char *n; int t; } types[] = {
                {"uint8", ST_U8}, {"uchar", ST_U8}, {"unsigned char", ST_U8}, {"uint8_t", ST_U8},
                {"uint16", ST_U16}, {"ushort", ST_U16}, {"unsigned short", ST_U16}, {"uint16_t", ST_U16},
                {"unsigned short int", ST_U16}, {"uint32", ST_U32}, {"uint", ST_U32}, {"unsigned int", ST_U32},
                {"uint32_t", ST_U32}, {"float", ST_F32}};
            h->have_type = 0;
            for (size_t i = 0; i < sizeof types / sizeof *types; i++)
                if (strcmp(val, types[i].n) == 0) h->stored = types[i].t, h->have_type = 1;
            if (!h->have_type) NRRD_BAD("'%s': NRRD type '%s' is not one clvox reads (uint8, uint16, uint32, float)",
                                        path, val);
        } else if (KEY("dimension")) {
            if (strcmp(val, "3") != 0) NRRD_BAD("'%s': NRRD dimension %s (clvox reads 3)", path, val);
            h->dimension = 3;
        } else if (KEY("sizes")) {
            double d[3];
            if (numbers(v, le, d, 3) != 3) NRRD_BAD("'%s': NRRD sizes must be 3 numbers", path);
            for (int a = 0; a < 3; a++) {
                if (!(d[a] >= 1 && d[a] <= CLVOX_MAX_AXIS) || d[a] != floor(d[a]))
                    NRRD_BAD("'%s': NRRD size %g along %c (1 to %u)", path, d[a], "xyz"[a], CLVOX_MAX_AXIS);
                h->sizes[a] = (uint64_t)d[a];
            }
            h->have_sizes = 1;
        } else if (KEY("encoding")) {
            if (strcmp(val, "raw") == 0) h->gzip = 0;
            else if (strcmp(val, "gzip") == 0 || strcmp(val, "gz") == 0) h->gzip = 1;
            else NRRD_BAD("'%s': NRRD encoding '%s' is not one clvox reads (raw, gzip)", path, val);
        } else if (KEY("endian")) {
            h->big = strcmp(val, "big") == 0;
        } else if (KEY("space directions")) {
            double m[9];
            if (numbers(v, le, m, 9) != 9 || m[1] != 0 || m[2] != 0 || m[3] != 0 || m[5] != 0 || m[6] != 0 ||
                m[7] != 0 || !(m[0] > 0) || !(m[4] > 0) || !(m[8] > 0))
                NRRD_BAD("'%s': NRRD space directions must be diagonal and positive (an axis-aligned grid)", path);
            h->dir[0] = m[0], h->dir[1] = m[4], h->dir[2] = m[8];
            h->have_dir = 1;
        } else if (KEY("spacings")) {
            double m[3];
            if (numbers(v, le, m, 3) != 3 || !(m[0] > 0) || !(m[1] > 0) || !(m[2] > 0))
                NRRD_BAD("'%s': bad NRRD spacings", path);
            if (!h->have_dir) memcpy(h->dir, m, sizeof m);
            h->have_spacings = 1;
        } else if (KEY("space origin")) {
            if (numbers(v, le, h->sorigin, 3) != 3) NRRD_BAD("'%s': bad NRRD space origin", path);
            h->have_sorigin = 1;
        } else if (KEY("data file") || KEY("datafile")) {
            if (vn >= sizeof h->datafile || strncmp(v, "LIST", 4) == 0 || memchr(v, '%', vn))
                NRRD_BAD("'%s': NRRD data file '%s' (clvox reads one data file)", path, val);
            copy_value(h->datafile, sizeof h->datafile, v, vn);
        } else if (KEY("byte skip") || KEY("line skip") || KEY("byteskip") || KEY("lineskip")) {
            if (strcmp(val, "0") != 0) NRRD_BAD("'%s': NRRD %.*s %s is not supported", path, (int)kn, line, val);
        }
#undef KEY
    }
    if (!h->have_type || h->dimension != 3 || !h->have_sizes)
        NRRD_BAD("'%s' is corrupt or truncated: its NRRD header lacks type, dimension or sizes", path);
    if (!ended && !h->datafile[0]) NRRD_BAD("'%s' is truncated: no data after its NRRD header", path);
    if (h->big && h->stored != ST_U8) NRRD_BAD("'%s': big-endian NRRD data is not supported", path);
    h->data_at = (uint64_t)(p - head);
done:
#undef NRRD_BAD
    free(head);
    return st;
}

/* Opens one NRRD member: header, channel, data (attached or detached). */
static clvox_status nrrd_member(clvox__vsrc *s, const char *path, const char *want_channel, nrrd_head *h)
{
    int fd = -1;
    uint64_t size = 0;
    clvox_status st = open_file(s->ctx, path, &fd, &size);
    if (st == CLVOX_OK) st = nrrd_parse(s, path, fd, size, h);
    if (fd >= 0) close(fd);
    if (st != CLVOX_OK) return st;
    if (s->nch == 0) {
        uint64_t d[3] = {h->sizes[0], h->sizes[1], h->sizes[2]};
        if ((st = check_dims(s, path, d)) != CLVOX_OK) return st;
    } else if (h->sizes[0] != s->dims[0] || h->sizes[1] != s->dims[1] || h->sizes[2] != s->dims[2]) {
        return clvox__fail(s->ctx, CLVOX_ERR_EXR, "'%s' does not match '%s': sizes %llu %llu %llu, not %u %u %u", path,
                           s->path, (unsigned long long)h->sizes[0], (unsigned long long)h->sizes[1],
                           (unsigned long long)h->sizes[2], s->dims[0], s->dims[1], s->dims[2]);
    }
    const char *name = h->channel[0] ? h->channel
                       : h->stored == ST_U8 ? "occupancy" : h->stored == ST_F32 ? "coverage" : "element";
    if (want_channel && strcmp(name, want_channel) != 0)
        return clvox__fail(s->ctx, CLVOX_ERR_EXR, "'%s' holds channel %s, its set says %s", path, name, want_channel);
    if (h->datafile[0]) {
        char *data = beside(path, h->datafile);
        if (!data) return clvox__fail(s->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
        st = open_file(s->ctx, data, &fd, &size);
        if (st == CLVOX_OK) close(fd);
        if (st == CLVOX_OK) st = add_channel(s, name, data, h->stored, h->gzip, 0, size);
        free(data);
        return st;
    }
    return add_channel(s, name, path, h->stored, h->gzip, h->data_at, size);
}

static clvox_status nrrd_open(clvox__vsrc *s, clvox_volume_info *info)
{
    nrrd_head h;
    clvox_status st = nrrd_member(s, s->path, NULL, &h);
    if (st != CLVOX_OK) return st;
    for (int a = 0; a < 3; a++) {
        info->voxel_size[a] = h.have_dir || h.have_spacings ? h.dir[a] : 1.0;
        info->origin[a] = h.have_corner ? h.corner[a] : h.have_sorigin ? h.sorigin[a] - 0.5 * info->voxel_size[a] : 0.0;
    }
    snprintf(info->method, sizeof info->method, "%s", h.method);
    snprintf(info->version, sizeof info->version, "%s", h.version);
    snprintf(info->compression, sizeof info->compression, "%s", h.gzip ? "gzip" : "none");
    /* the set: " <channel>:<bytes>:<crc32>" per other member */
    char set[sizeof h.set];
    memcpy(set, h.set, sizeof set);
    uint32_t mask = 0;
    const uint32_t bit[4] = {CLVOX_CHANNEL_COVERAGE, CLVOX_CHANNEL_ELEMENT, CLVOX_CHANNEL_OCCUPANCY,
                             CLVOX_CHANNEL_SCORE};
    char names[4][16];
    int n = 0;
    for (char *tok = strtok(set, " "); tok; tok = strtok(NULL, " ")) {
        char *c = strchr(tok, ':');
        if (c) *c = '\0';
        int k = channel_index(tok);
        if (k < 0 || n == 4) return clvox__fail(s->ctx, CLVOX_ERR_EXR, "'%s': malformed clvox_set:= line", s->path);
        snprintf(names[n++], sizeof names[0], "%s", tok);
        mask |= bit[k];
    }
    if (n == 0) return CLVOX_OK;
    mask |= bit[channel_index(s->ch[0].name)];
    for (int i = 0; i < n && st == CLVOX_OK; i++) {
        char *member = clvox__channel_path(s->path, bit[channel_index(names[i])], mask);
        if (!member) return clvox__fail(s->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
        nrrd_head mh;
        st = nrrd_member(s, member, names[i], &mh);
        free(member);
    }
    return st;
}

/* ---- binvox --------------------------------------------------------------------------- */

static clvox_status binvox_open(clvox__vsrc *s, int fd, uint64_t size, clvox_volume_info *info)
{
    clvox_context *ctx = s->ctx;
    char *head = NULL;
    size_t len = 0;
    clvox_status st = read_head(ctx, fd, s->path, size < 1024 ? size : 1024, &head, &len);
    if (st != CLVOX_OK) return st;
    uint64_t dim[3] = {0, 0, 0};
    double t[3] = {0, 0, 0}, scale = 1;
    int have_dim = 0, have_data = 0;
    size_t pos = 0;
    int first = 1;
    while (pos < len && !have_data) {
        const char *eol = memchr(head + pos, '\n', len - pos);
        if (!eol) break;
        char line[256];
        size_t n = (size_t)(eol - (head + pos));
        if (n >= sizeof line) break;
        memcpy(line, head + pos, n);
        line[n] = '\0';
        if (n && line[n - 1] == '\r') line[n - 1] = '\0';
        pos += n + 1;
        if (first) {
            first = 0;
            if (strcmp(line, "#binvox 1") != 0) break;
            continue;
        }
        unsigned long long a, b, c;
        int used = 0;
        if (strncmp(line, "dim ", 4) == 0) {
            if (sscanf(line, "dim %llu %llu %llu%n", &a, &b, &c, &used) != 3 || line[used]) break;
            dim[0] = a, dim[1] = b, dim[2] = c, have_dim = 1;
        } else if (strncmp(line, "translate ", 10) == 0) {
            if (numbers(line + 10, line + strlen(line), t, 3) != 3) break;
        } else if (strncmp(line, "scale ", 6) == 0) {
            if (numbers(line + 6, line + strlen(line), &scale, 1) != 1 || !(scale > 0)) break;
        } else if (strcmp(line, "data") == 0) {
            have_data = 1;
        } else {
            break;
        }
    }
    free(head);
    const uint64_t at = pos;
    if (first || !have_dim || !have_data)
        return clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' is corrupt or truncated: a bad binvox header", s->path);
    if (dim[0] != dim[1] || dim[0] != dim[2])
        return clvox__fail(ctx, CLVOX_ERR_EXR, "'%s': binvox dims %llu %llu %llu are not cubic", s->path,
                           (unsigned long long)dim[0], (unsigned long long)dim[1], (unsigned long long)dim[2]);
    if ((st = check_dims(s, s->path, dim)) != CLVOX_OK) return st;
    const uint64_t N = dim[0], total = N * N * N, data = size - at;
    if (data % 2 || total > (data / 2) * 255)
        return clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' is %s: %llu bytes of run-length data cannot hold %llu^3 voxels",
                           s->path, data % 2 ? "corrupt" : "truncated", (unsigned long long)data,
                           (unsigned long long)N);
    for (int a = 0; a < 3; a++) {
        info->origin[a] = t[a];
        info->voxel_size[a] = scale / (double)N;
    }
    snprintf(info->compression, sizeof info->compression, "rle");
    /* decode the runs: index x*N*N + z*N + y */
    if (total / 8 + 1 > SIZE_MAX || !(s->bits = calloc((size_t)(total / 8 + 1), 1)))
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for a binvox %llu^3 volume",
                           (unsigned long long)N);
    uint8_t buf[1 << 16];
    uint64_t i = 0, x = 0, y = 0, z = 0;
    for (uint64_t off = at; off < size && st == CLVOX_OK;) {
        size_t k = size - off < sizeof buf ? (size_t)(size - off) : sizeof buf;
        if ((st = read_at(ctx, fd, s->path, buf, k, off)) != CLVOX_OK) break;
        off += k;
        for (size_t j = 0; j + 1 < k; j += 2) {
            const unsigned v = buf[j], c = buf[j + 1];
            if (v > 1 || c == 0 || c > total - i) {
                st = clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' is corrupt: run (%u, %u) at voxel %llu of %llu", s->path,
                                 v, c, (unsigned long long)i, (unsigned long long)total);
                break;
            }
            for (unsigned r = 0; r < c; r++) {
                if (v) {
                    uint64_t b = (z * N + y) * N + x;
                    s->bits[b >> 3] |= (uint8_t)(1u << (b & 7));
                }
                if (++y == N) {
                    y = 0;
                    if (++z == N) z = 0, x++;
                }
            }
            i += c;
        }
    }
    if (st == CLVOX_OK && i != total)
        st = clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' is truncated: its runs cover %llu of %llu voxels", s->path,
                         (unsigned long long)i, (unsigned long long)total);
    if (st == CLVOX_OK) {
        memset(&s->ch[0], 0, sizeof s->ch[0]);
        snprintf(s->ch[0].name, sizeof s->ch[0].name, "occupancy");
        s->nch = 1;
    }
    return st;
}

/* ---- OpenVDB: through the plugin ----------------------------------------------------- */

static clvox_status vdb_open(clvox__vsrc *s, clvox_volume_info *info)
{
    clvox_status st = clvox__vdb_reader_open(s->ctx, s->path, info, &s->vdb);
    if (st != CLVOX_OK) return st;
    for (int a = 0; a < 3; a++) s->dims[a] = info->dims[a];
    for (int k = 0; k < 4; k++)
        if (clvox__vdb_reader_has(s->vdb, channel_names[k])) {
            snprintf(s->ch[s->nch].name, sizeof s->ch[0].name, "%s", channel_names[k]);
            s->nch++;
        }
    return CLVOX_OK;
}

/* ---- the source ------------------------------------------------------------------------ */

void clvox__vsrc_close(clvox__vsrc *s)
{
    if (!s) return;
    for (size_t i = 0; i < s->nch; i++) free(s->ch[i].file);
    if (s->vdb) clvox__vdb_reader_close(s->vdb);
    free(s->bits);
    free(s->path);
    free(s);
}

clvox_status clvox__vsrc_open(clvox_context *ctx, const char *path, clvox_volume_info *info, clvox__vsrc **out)
{
    *out = NULL;
    memset(info, 0, sizeof *info);
    info->size = sizeof *info;
    int fd = -1;
    uint64_t size = 0;
    clvox_status st = open_file(ctx, path, &fd, &size);
    if (st != CLVOX_OK) return st;
    uint8_t m[8] = {0};
    const size_t mn = size < sizeof m ? (size_t)size : sizeof m;
    st = read_at(ctx, fd, path, m, mn, 0);
    int format = 0;
    if (st == CLVOX_OK) {
        if (mn >= 4 && memcmp(m, "\x76\x2f\x31\x01", 4) == 0) format = -1; /* OpenEXR */
        else if (mn >= 6 && memcmp(m, "\x93NUMPY", 6) == 0) format = FMT_NPY;
        else if (mn >= 7 && memcmp(m, "NRRD000", 7) == 0) format = FMT_NRRD;
        else if (mn >= 7 && memcmp(m, "#binvox", 7) == 0) format = FMT_BINVOX;
        else if (mn >= 8 && memcmp(m, "\x20\x42\x44\x56\0\0\0\0", 8) == 0) format = FMT_VDB;
    }
    if (st != CLVOX_OK || format <= 0) {
        close(fd);
        if (st == CLVOX_OK && format == 0) {
            uint32_t magic = (uint32_t)m[0] | (uint32_t)m[1] << 8 | (uint32_t)m[2] << 16 | (uint32_t)m[3] << 24;
            /* a mesh given where a volume belongs: name the mix-up, not the magic number */
            if (clvox__is_mesh_path(path))
                return clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' is a mesh, not a volume (a file written by clvox)", path);
            st = clvox__fail(ctx, CLVOX_ERR_EXR,
                             "'%s' is not a volume clvox reads (OpenEXR, npy, NRRD, binvox, OpenVDB): %s 0x%08X",
                             path, size < 4 ? "too short, first bytes" : "magic", magic);
        }
        return st;
    }
    clvox__vsrc *s = calloc(1, sizeof *s);
    if (!s || !(s->path = strdup(path))) {
        close(fd);
        free(s);
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    }
    s->ctx = ctx;
    s->format = format;
    snprintf(info->compression, sizeof info->compression, "none");
    switch (format) {
    case FMT_NPY: st = npy_open(s, fd, size, info); break;
    case FMT_NRRD: st = nrrd_open(s, info); break;
    case FMT_BINVOX: st = binvox_open(s, fd, size, info); break;
    default: st = vdb_open(s, info); break;
    }
    close(fd);
    if (st == CLVOX_OK && s->nch == 0) st = clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' holds no clvox channel", path);
    if (st != CLVOX_OK) {
        clvox__vsrc_close(s);
        return st;
    }
    for (int a = 0; a < 3; a++) info->dims[a] = s->dims[a];
    for (int k = 0; k < 4; k++)
        if (clvox__vsrc_has(s, channel_names[k])) {
            size_t used = strlen(info->channels);
            snprintf(info->channels + used, sizeof info->channels - used, "%s%s", used ? "," : "", channel_names[k]);
        }
    *out = s;
    return CLVOX_OK;
}

int clvox__vsrc_has(const clvox__vsrc *s, const char *channel)
{
    for (size_t i = 0; s && i < s->nch; i++)
        if (strcmp(s->ch[i].name, channel) == 0) return 1;
    return 0;
}

static uint32_t le16(const uint8_t *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8; }
static uint32_t le32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* Converts one stored slice to band samples; returns the band's type. */
static int convert_slice(int stored, const uint8_t *in, uint32_t X, uint32_t Y, void *out)
{
    const size_t n = (size_t)X * Y, rb = (size_t)stored_bytes(stored, X);
    uint32_t *u = out;
    switch (stored) {
    case ST_U8:
        for (size_t i = 0; i < n; i++) u[i] = in[i];
        return CLVOX__SAMPLE_UINT;
    case ST_BITS:
        for (uint32_t y = 0; y < Y; y++)
            for (uint32_t x = 0; x < X; x++) u[(size_t)y * X + x] = (in[y * rb + x / 8] >> (x % 8)) & 1u;
        return CLVOX__SAMPLE_UINT;
    case ST_U16:
        for (size_t i = 0; i < n; i++) u[i] = le16(in + 2 * i);
        return CLVOX__SAMPLE_UINT;
    case ST_U32:
        for (size_t i = 0; i < n; i++) u[i] = le32(in + 4 * i);
        return CLVOX__SAMPLE_UINT;
    case ST_F16: {
        uint16_t *h = out;
        for (size_t i = 0; i < n; i++) h[i] = (uint16_t)le16(in + 2 * i);
        return CLVOX__SAMPLE_HALF;
    }
    default:
        for (size_t i = 0; i < n; i++) u[i] = le32(in + 4 * i); /* float bits */
        return CLVOX__SAMPLE_FLOAT;
    }
}

/* Gives zlib the next (at most 64 KiB) input of a gzip stream that ends at
 * `size`, read at *zoff into zin. */
static clvox_status gz_refill(clvox_context *ctx, int fd, const char *file, z_stream *zs, uint8_t *zin, uint64_t size,
                              uint64_t *zoff)
{
    const size_t k = size - *zoff < (1u << 16) ? (size_t)(size - *zoff) : (1u << 16);
    clvox_status st = read_at(ctx, fd, file, zin, k, *zoff);
    if (st != CLVOX_OK) return st;
    *zoff += k;
    zs->next_in = zin;
    zs->avail_in = (uInt)k;
    return CLVOX_OK;
}


static clvox_status read_raster(clvox__vsrc *s, const vchan *c, clvox__band_fn fn, void *user)
{
    clvox_context *ctx = s->ctx;
    const uint32_t X = s->dims[0], Y = s->dims[1], Z = s->dims[2];
    const size_t slice_bytes = (size_t)(stored_bytes(c->stored, X) * Y), n = (size_t)X * Y;
    uint8_t *raw = malloc(slice_bytes), *band = malloc(n * 4), *zin = c->gzip ? malloc(1u << 16) : NULL;
    int fd = -1;
    uint64_t size = 0;
    clvox_status st = CLVOX_OK;
    if (!raw || !band || (c->gzip && !zin))
        st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for a %u x %u slice of '%s'", X, Y, s->path);
    if (st == CLVOX_OK) st = open_file(ctx, c->file, &fd, &size);
    if (st == CLVOX_OK && size != c->offset + c->data_bytes)
        st = clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' changed while it was read", c->file);
    z_stream zs;
    int zready = 0;
    uint64_t zoff = c->offset;
    if (st == CLVOX_OK && c->gzip) {
        memset(&zs, 0, sizeof zs);
        if (inflateInit2(&zs, 15 + 32) != Z_OK) st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "zlib: out of memory");
        else zready = 1;
    }
    int zend = 0;
    for (uint32_t z = 0; z < Z && st == CLVOX_OK; z++) {
        if (!c->gzip) {
            st = read_at(ctx, fd, c->file, raw, slice_bytes, c->offset + (uint64_t)z * slice_bytes);
        } else {
            size_t got = 0;
            zs.avail_out = 0;
            while (st == CLVOX_OK && (got < slice_bytes || zs.avail_out > 0)) {
                if (zs.avail_out == 0) { /* a slice may pass 4 GiB: in pieces */
                    size_t k = slice_bytes - got > (1u << 30) ? (1u << 30) : slice_bytes - got;
                    zs.next_out = raw + got;
                    zs.avail_out = (uInt)k;
                    got += k;
                }
                if (zend) {
                    st = clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' is truncated: its gzip data ends at slice %u of %u",
                                     c->file, z, Z);
                    break;
                }
                if (zs.avail_in == 0) {
                    if (zoff >= size) {
                        st = clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' is truncated: its gzip data ends at slice %u of %u",
                                         c->file, z, Z);
                        break;
                    }
                    if ((st = gz_refill(ctx, fd, c->file, &zs, zin, size, &zoff)) != CLVOX_OK) break;
                }
                int zr = inflate(&zs, Z_NO_FLUSH);
                if (zr == Z_STREAM_END) zend = 1;
                else if (zr != Z_OK && zr != Z_BUF_ERROR)
                    st = clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' is corrupt: gzip data: %s", c->file,
                                     zs.msg ? zs.msg : "inflate failed");
            }
        }
        if (st != CLVOX_OK) break;
        int type = convert_slice(c->stored, raw, X, Y, band);
        st = fn(user, band, type, (uint64_t)z * Y, Y);
    }
    if (st == CLVOX_OK && c->gzip) {
        /* the whole stream, nothing after it */
        uint8_t extra;
        zs.next_out = &extra;
        zs.avail_out = 1;
        while (st == CLVOX_OK && !zend) {
            if (zs.avail_in == 0 && zoff < size && (st = gz_refill(ctx, fd, c->file, &zs, zin, size, &zoff)) != CLVOX_OK)
                break;
            int zr = inflate(&zs, Z_NO_FLUSH);
            if (zr == Z_STREAM_END) zend = 1;
            else if (zs.avail_out == 0 || (zr != Z_OK && zr != Z_BUF_ERROR) || (zs.avail_in == 0 && zoff >= size))
                st = clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' is corrupt: its gzip data %s", c->file,
                                 zs.avail_out == 0 ? "holds more than its NRRD sizes say" : "does not end");
        }
        if (st == CLVOX_OK && (zs.avail_in > 0 || zoff < size))
            st = clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' is corrupt: data after its gzip stream", c->file);
    }
    if (zready) inflateEnd(&zs);
    if (fd >= 0) close(fd);
    free(raw);
    free(band);
    free(zin);
    return st;
}

static clvox_status read_binvox(clvox__vsrc *s, clvox__band_fn fn, void *user)
{
    const uint64_t N = s->dims[0];
    uint32_t *band = malloc((size_t)(N * N) * sizeof *band);
    if (!band) return clvox__fail(s->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for a slice of '%s'", s->path);
    clvox_status st = CLVOX_OK;
    for (uint64_t z = 0; z < N && st == CLVOX_OK; z++) {
        for (uint64_t i = 0; i < N * N; i++) {
            uint64_t b = z * N * N + i;
            band[i] = (s->bits[b >> 3] >> (b & 7)) & 1u;
        }
        st = fn(user, (const uint8_t *)band, CLVOX__SAMPLE_UINT, z * N, N);
    }
    free(band);
    return st;
}

clvox_status clvox__vsrc_read(clvox__vsrc *s, const char *channel, clvox__band_fn fn, void *user)
{
    for (size_t i = 0; i < s->nch; i++) {
        if (strcmp(s->ch[i].name, channel) != 0) continue;
        if (s->format == FMT_BINVOX) return read_binvox(s, fn, user);
        if (s->format == FMT_VDB) return clvox__vdb_reader_read(s->vdb, channel, fn, user);
        return read_raster(s, &s->ch[i], fn, user);
    }
    return clvox__fail(s->ctx, CLVOX_ERR_EXR, "'%s' has no channel \"%s\"", s->path, channel);
}
