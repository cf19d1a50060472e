/* SPDX-License-Identifier: Apache-2.0 */
/* The kernel program's device binary, kept between processes.
 *
 * Why: building the program from source costs 0.09-0.11 s in every process
 * even when PoCL finds its compiled kernels in its own cache (PoCL runs
 * clang's preprocessor over the 100 KB of sources to compute its cache key
 * and reads the program's bitcode back); created from the binary that
 * clGetProgramInfo gave the last process, it takes 0.02 s. On small meshes
 * that was half of the whole run (bunny00 at 256^3: 0.23 -> 0.13 s).
 *
 * Where: $CLVOX_CACHE_DIR, else $XDG_CACHE_HOME/clvox, else
 * $HOME/.cache/clvox (made 0700 when missing); CLVOX_CACHE_DIR=off turns the
 * cache off. One file per (sources, build options, device, driver, clvox
 * version): the name is a hash of that identity, the file holds the identity
 * itself, the binary and a SHA-256 of everything before it, and anything that
 * does not match is a miss. A miss, an unreadable, corrupt or non-regular
 * file, a binary the driver refuses, a directory that cannot be written: the
 * program is built from source as before and the entry rewritten, and the
 * cache never makes a run fail. Files are written under a temporary name and
 * renamed, so concurrent processes see a whole file or none.
 *
 * A binary that passes every check and still crashes the driver (a forged
 * entry; a driver that cannot read its own output) cannot be caught inside
 * the process, so it is caught by the next one: before handing a cached
 * binary to the driver a process leaves a marker "<key>.try-<pid>-XXXXXX"
 * next to the entry and removes it once the program is built and its kernels
 * created. A marker whose process is gone means that process died there: the
 * entry is deleted and the program built from source. So a bad entry costs at
 * most one run, never every run; one that makes the driver hang costs the
 * runs started in the TRY_AGE after it, or until the hung run is killed
 * (docs/design.md "Kernel program cache").
 *
 * Housekeeping: at most KEEP binaries are kept (the newest by time of use);
 * temporary files of a killed store older than TMP_AGE, and markers of dead
 * processes whose entry is gone, are removed.
 */
#include "internal.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

extern const char *const clvox__kernel_sources[];
extern const unsigned clvox__kernel_source_count;

/* Format 2: SHA-256 instead of format 1's FNV-1a (format 1 files, named by
 * another hash, are never looked at, and pruned in time). */
#define MAGIC "clvox program binary 2\n"
#define SUFFIX ".clvoxbin"
#define TMP_PREFIX ".tmp-"
#define TRY_INFIX ".try-"
#define KEY_HEX 16                       /* the name: 16 hex digits of the identity's SHA-256 */
#define KEEP 8                           /* binaries kept in the directory */
#define TMP_AGE 3600                     /* s: a temporary file older than this is a killed store's */
#define TRY_AGE 60                       /* s: a load (0.02 s) this long in progress is stuck */
#define MAX_BINARY ((size_t)256 << 20)   /* larger: not cached */
#define MAX_IDENTITY 4096
#define SUM 32                           /* SHA-256 at the end of the file */

typedef struct cache_entry {
    char dir[3072], path[3200];
    char key[KEY_HEX + 1];
    char identity[MAX_IDENTITY];
} cache_entry;

static void hex(char *out, const unsigned char *b, size_t n)
{
    static const char digits[] = "0123456789abcdef";
    for (size_t i = 0; i < n; i++) out[2 * i] = digits[b[i] >> 4], out[2 * i + 1] = digits[b[i] & 15];
    out[2 * n] = 0;
}

/* The cache directory (made when missing); 0 when off or not usable. */
static int cache_dir(char *dir, size_t size)
{
    const char *env = clvox__setting_value(CLVOX__ENV_CACHE_DIR);
    int n;
    if (env && *env) {
        if (strcmp(env, "off") == 0 || strcmp(env, "0") == 0) return 0;
        n = snprintf(dir, size, "%s", env);
    } else if ((env = clvox__setting_value(CLVOX__ENV_XDG_CACHE_HOME)) && env[0] == '/') {
        n = snprintf(dir, size, "%s/clvox", env);
    } else if ((env = clvox__setting_value(CLVOX__ENV_HOME)) && env[0] == '/') {
        char base[3000];
        if (snprintf(base, sizeof base, "%s/.cache", env) >= (int)sizeof base) return 0;
        if (mkdir(base, 0700) != 0 && errno != EEXIST) return 0;
        n = snprintf(dir, size, "%s/clvox", base);
    } else {
        return 0;
    }
    if (n <= 0 || (size_t)n >= size) return 0;
    if (mkdir(dir, 0700) != 0 && errno != EEXIST) return 0;
    struct stat sb;
    return stat(dir, &sb) == 0 && S_ISDIR(sb.st_mode);
}

static void device_string(cl_device_id d, cl_device_info what, char *out, size_t size)
{
    out[0] = 0;
    if (clGetDeviceInfo(d, what, size - 1, out, NULL) != CL_SUCCESS) out[0] = 0;
    out[size - 1] = 0;
}

/* The identity of what would be built, and the file it is cached in. */
static int entry_for(clvox_context *ctx, const char *options, cache_entry *e)
{
    if (!cache_dir(e->dir, sizeof e->dir)) return 0;
    clvox__sha256_state s;
    clvox__sha256_init(&s);
    for (unsigned i = 0; i < clvox__kernel_source_count; i++) /* the NUL separates the files */
        clvox__sha256_update(&s, clvox__kernel_sources[i], strlen(clvox__kernel_sources[i]) + 1);
    unsigned char sum[32];
    char sources[65];
    clvox__sha256_final(&s, sum);
    hex(sources, sum, sizeof sum);
    char platform[512] = "", device[256] = "", vendor[256] = "", dversion[256] = "", driver[256] = "";
    if (clGetPlatformInfo(ctx->platform, CL_PLATFORM_VERSION, sizeof platform - 1, platform, NULL) != CL_SUCCESS)
        platform[0] = 0;
    device_string(ctx->device_id, CL_DEVICE_NAME, device, sizeof device);
    device_string(ctx->device_id, CL_DEVICE_VENDOR, vendor, sizeof vendor);
    device_string(ctx->device_id, CL_DEVICE_VERSION, dversion, sizeof dversion);
    device_string(ctx->device_id, CL_DRIVER_VERSION, driver, sizeof driver);
    int n = snprintf(e->identity, sizeof e->identity,
                     "clvox %s\nsources sha256 %s\noptions %s\nplatform %s\ndevice %s\nvendor %s\n"
                     "version %s\ndriver %s\npointer %zu\n",
                     CLVOX_VERSION_STRING, sources, options, platform, device, vendor, dversion, driver,
                     sizeof(void *));
    if (n <= 0 || (size_t)n >= sizeof e->identity) return 0;
    clvox__sha256(e->identity, (size_t)n, sum);
    hex(e->key, sum, KEY_HEX / 2);
    n = snprintf(e->path, sizeof e->path, "%s/%s" SUFFIX, e->dir, e->key);
    return n > 0 && (size_t)n < sizeof e->path;
}

/* File layout: MAGIC, identity length (8 bytes LE), identity, binary length
 * (8), binary, SHA-256 of all the bytes before it (32). */
static void put64(unsigned char *p, uint64_t v)
{
    for (int i = 0; i < 8; i++) p[i] = (unsigned char)(v >> (8 * i));
}
static uint64_t get64(const unsigned char *p)
{
    uint64_t v = 0;
    for (int i = 0; i < 8; i++) v |= (uint64_t)p[i] << (8 * i);
    return v;
}

int clvox__program_cache_parse(const unsigned char *file, size_t n, const char *identity, size_t *bin_off,
                               size_t *bin_len)
{
    const size_t m = sizeof MAGIC - 1, il = strlen(identity);
    if (n < m + 8 || memcmp(file, MAGIC, m) != 0 || get64(file + m) != il) return 0;
    if (n - m - 8 < il + 8 || memcmp(file + m + 8, identity, il) != 0) return 0;
    const size_t off = m + 8 + il + 8;
    const uint64_t len = get64(file + m + 8 + il);
    if (len == 0 || len > MAX_BINARY || n - off < SUM || len != n - off - SUM) return 0;
    unsigned char sum[SUM];
    clvox__sha256(file, n - SUM, sum);
    if (memcmp(sum, file + n - SUM, SUM) != 0) return 0;
    *bin_off = off;
    *bin_len = (size_t)len;
    return 1;
}

/* The file's bytes when it is a regular file, whole and for this identity;
 * *bin points into them. Opened without following a symbolic link and
 * without blocking (a FIFO at the name must not hang the run). */
static unsigned char *read_binary(const cache_entry *e, const unsigned char **bin, size_t *size)
{
    int fd = open(e->path, O_RDONLY | O_NONBLOCK | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) return NULL;
    struct stat sb;
    const size_t most = MAX_BINARY + sizeof MAGIC + MAX_IDENTITY + 16 + SUM;
    unsigned char *data = NULL;
    size_t n = 0, got = 0, off = 0;
    if (fstat(fd, &sb) == 0 && S_ISREG(sb.st_mode) && sb.st_size > 0 && (uint64_t)sb.st_size <= most &&
        (data = malloc(n = (size_t)sb.st_size)) != NULL) {
        while (got < n) {
            ssize_t r = read(fd, data + got, n - got);
            if (r < 0 && errno == EINTR) continue;
            if (r <= 0) break;
            got += (size_t)r;
        }
    }
    (void)close(fd);
    if (data && got == n && clvox__program_cache_parse(data, n, e->identity, &off, size)) {
        *bin = data + off;
        return data;
    }
    free(data);
    return NULL;
}

/* The pid in a marker's name "<key>.try-<pid>-XXXXXX"; 0 when not one. */
static long marker_pid(const char *name, char *key)
{
    const size_t il = strlen(TRY_INFIX);
    if (strlen(name) < KEY_HEX + il + 3 || memcmp(name + KEY_HEX, TRY_INFIX, il) != 0) return 0;
    char *end;
    errno = 0;
    long pid = strtol(name + KEY_HEX + il, &end, 10);
    if (errno || pid <= 0 || pid > INT_MAX || *end != '-' || end == name + KEY_HEX + il) return 0;
    memcpy(key, name, KEY_HEX);
    key[KEY_HEX] = 0;
    return pid;
}

static int process_gone(long pid) { return kill((pid_t)pid, 0) != 0 && errno == ESRCH; }

/* 1 when a was modified after b. */
static int newer(const struct stat *a, const struct stat *b)
{
    return a->st_mtim.tv_sec > b->st_mtim.tv_sec ||
           (a->st_mtim.tv_sec == b->st_mtim.tv_sec && a->st_mtim.tv_nsec > b->st_mtim.tv_nsec);
}

/* One pass over the directory. Removes the temporary files of stores
 * killed more than TMP_AGE ago (a younger one may be a store in progress)
 * and the markers of dead processes whose entry is gone. With `key`,
 * returns 1 when its entry must not be loaded: a marker for it left by a
 * dead process (that process died loading the entry: the entry is deleted,
 * then the marker), or one of a live process that has been loading the
 * same file for more than TRY_AGE (stuck in the driver: the entry is left
 * to the store that follows to replace). With `keep`: only the `keep` most
 * recently used binaries are kept. */
static int sweep(const char *dir, const char *key, size_t keep)
{
    DIR *d = opendir(dir);
    if (!d) return key != NULL; /* cannot check for markers: not safe to load */
    struct old {
        char name[256];
        time_t t;
    } list[4 * KEEP];
    size_t n = 0, total = 0;
    int unsafe = 0;
    const time_t now = time(NULL);
    struct dirent *de;
    while ((de = readdir(d)) != NULL) {
        const char *name = de->d_name;
        const size_t len = strlen(name), sl = strlen(SUFFIX);
        char path[3400], mkey[KEY_HEX + 1];
        struct stat sb;
        if (snprintf(path, sizeof path, "%s/%s", dir, name) >= (int)sizeof path || lstat(path, &sb) != 0)
            continue;
        long pid;
        if (strncmp(name, TMP_PREFIX, strlen(TMP_PREFIX)) == 0) {
            if (S_ISREG(sb.st_mode) && sb.st_mtime < now - TMP_AGE) (void)unlink(path);
        } else if ((pid = marker_pid(name, mkey)) != 0) {
            char entry[3400];
            struct stat es;
            if (!S_ISREG(sb.st_mode) || snprintf(entry, sizeof entry, "%s/%s" SUFFIX, dir, mkey) >= (int)sizeof entry)
                continue;
            const int have = lstat(entry, &es) == 0, gone_entry = !have && errno == ENOENT;
            const int ours = key && strcmp(mkey, key) == 0;
            if (process_gone(pid)) {
                if (ours) { /* that process died loading this entry */
                    unsafe = 1;
                    if (unlink(entry) == 0 || errno == ENOENT) (void)unlink(path);
                } else if (gone_entry) {
                    (void)unlink(path);
                }
            } else if (ours && have && sb.st_mtime < now - TRY_AGE && !newer(&es, &sb)) {
                unsafe = 1; /* a live process stuck loading this very file (written before its marker) */
            }
        } else if (keep && len > sl && len < sizeof list[0].name && strcmp(name + len - sl, SUFFIX) == 0) {
            total++;
            if (n < sizeof list / sizeof *list) {
                memcpy(list[n].name, name, len + 1);
                list[n++].t = sb.st_mtime;
            }
        }
    }
    closedir(d);
    /* the oldest first, while more than `keep` remain */
    while (keep && total > keep && n > 0) {
        size_t oldest = 0;
        for (size_t i = 1; i < n; i++)
            if (list[i].t < list[oldest].t) oldest = i;
        char path[3400];
        if (snprintf(path, sizeof path, "%s/%s", dir, list[oldest].name) < (int)sizeof path) (void)unlink(path);
        list[oldest] = list[--n];
        total--;
    }
    return unsafe;
}

/* Builds the program from the binary and creates its kernels (where a bad
 * binary that the driver does not refuse would crash it); NULL on an error. */
static cl_program load_binary(clvox_context *ctx, const char *options, const unsigned char *b, size_t size)
{
    cl_int err, status = CL_SUCCESS;
    cl_program program = clCreateProgramWithBinary(ctx->cl, 1, &ctx->device_id, &size, &b, &status, &err);
    if (err != CL_SUCCESS || status != CL_SUCCESS) {
        if (program) clReleaseProgram(program);
        return NULL;
    }
    cl_uint nk = 0;
    cl_kernel *k = NULL;
    int ok = clBuildProgram(program, 1, &ctx->device_id, options, NULL, NULL) == CL_SUCCESS &&
             clCreateKernelsInProgram(program, 0, NULL, &nk) == CL_SUCCESS && nk > 0 &&
             (k = calloc(nk, sizeof *k)) != NULL && clCreateKernelsInProgram(program, nk, k, NULL) == CL_SUCCESS;
    for (cl_uint i = 0; k && i < nk; i++)
        if (k[i]) clReleaseKernel(k[i]);
    free(k);
    if (!ok) {
        clReleaseProgram(program);
        return NULL;
    }
    return program;
}

cl_program clvox__program_cache_load(clvox_context *ctx, const char *options)
{
    cache_entry *e = malloc(sizeof *e);
    if (!e) return NULL;
    cl_program program = NULL;
    size_t size = 0;
    const unsigned char *b = NULL;
    unsigned char *file = NULL;
    char marker[3400];
    int fd = -1;
    if (entry_for(ctx, options, e) && !sweep(e->dir, e->key, 0) && (file = read_binary(e, &b, &size)) != NULL &&
        snprintf(marker, sizeof marker, "%s/%s" TRY_INFIX "%ld-XXXXXX", e->dir, e->key, (long)getpid()) <
            (int)sizeof marker &&
        (fd = mkstemp(marker)) >= 0) {
        /* the marker stays if the driver crashes on the binary (see the top) */
        program = load_binary(ctx, options, b, size);
        (void)close(fd);
        (void)unlink(marker);
        if (program) (void)utimensat(AT_FDCWD, e->path, NULL, AT_SYMLINK_NOFOLLOW); /* used: kept longest */
    }
    free(file);
    free(e);
    return program;
}

static int write_all(int fd, const void *data, size_t n)
{
    const unsigned char *p = data;
    while (n) {
        ssize_t w = write(fd, p, n);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) return 0;
        p += w, n -= (size_t)w;
    }
    return 1;
}

/* Writes e's file holding `bin` (under a temporary name, then renamed). */
static void store_bytes(cache_entry *e, const unsigned char *bin, size_t size)
{
    char tmp[3300];
    if (snprintf(tmp, sizeof tmp, "%s/" TMP_PREFIX "XXXXXX", e->dir) >= (int)sizeof tmp) return;
    int fd = mkstemp(tmp);
    if (fd < 0) return;
    unsigned char head[sizeof MAGIC - 1 + 8], len8[8], sum[SUM];
    const size_t il = strlen(e->identity);
    memcpy(head, MAGIC, sizeof MAGIC - 1);
    put64(head + sizeof MAGIC - 1, il);
    put64(len8, size);
    clvox__sha256_state s;
    clvox__sha256_init(&s);
    clvox__sha256_update(&s, head, sizeof head);
    clvox__sha256_update(&s, e->identity, il);
    clvox__sha256_update(&s, len8, 8);
    clvox__sha256_update(&s, bin, size);
    clvox__sha256_final(&s, sum);
    int ok = write_all(fd, head, sizeof head) && write_all(fd, e->identity, il) && write_all(fd, len8, 8) &&
             write_all(fd, bin, size) && write_all(fd, sum, SUM);
    ok = close(fd) == 0 && ok;
    /* rename replaces whatever has the entry's name (the name belongs to the
     * cache): a symbolic link there is replaced, never followed */
    if (!ok || rename(tmp, e->path) != 0) {
        (void)unlink(tmp);
        return;
    }
    (void)sweep(e->dir, NULL, KEEP);
}

void clvox__program_cache_store(clvox_context *ctx, cl_program program, const char *options)
{
    cache_entry *e = malloc(sizeof *e);
    unsigned char *bin = NULL;
    if (!e || !entry_for(ctx, options, e)) goto done;
    size_t size = 0;
    if (clGetProgramInfo(program, CL_PROGRAM_BINARY_SIZES, sizeof size, &size, NULL) != CL_SUCCESS || size == 0 ||
        size > MAX_BINARY || !(bin = malloc(size)))
        goto done;
    if (clGetProgramInfo(program, CL_PROGRAM_BINARIES, sizeof bin, &bin, NULL) != CL_SUCCESS) goto done;
    store_bytes(e, bin, size);
done:
    free(bin);
    free(e);
}

int clvox__cache_get(clvox_context *ctx, const char *what, void *out, size_t size)
{
    cache_entry *e = malloc(sizeof *e);
    int got = 0;
    size_t n = 0;
    const unsigned char *b = NULL;
    unsigned char *file = NULL;
    if (e && entry_for(ctx, what, e) && (file = read_binary(e, &b, &n)) != NULL && n == size) {
        memcpy(out, b, size);
        got = 1;
    }
    free(file);
    free(e);
    return got;
}

void clvox__cache_put(clvox_context *ctx, const char *what, const void *data, size_t size)
{
    cache_entry *e = malloc(sizeof *e);
    if (e && size > 0 && size <= MAX_BINARY && entry_for(ctx, what, e)) store_bytes(e, data, size);
    free(e);
}
