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
 * itself, the binary's size and a checksum, and anything that does not match
 * is a miss. A miss, an unreadable or corrupt file, a binary the driver
 * refuses, a directory that cannot be written: the program is built from
 * source as before, and the cache never makes a run fail. Files are written
 * under a temporary name and renamed, so concurrent processes see a whole
 * file or none. At most KEEP binaries are kept (the newest by time of use).
 */
#include "internal.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

extern const char *const clvox__kernel_sources[];
extern const unsigned clvox__kernel_source_count;

#define MAGIC "clvox program binary 1\n"
#define SUFFIX ".clvoxbin"
#define KEEP 8                           /* binaries kept in the directory */
#define MAX_BINARY ((size_t)256 << 20)   /* larger: not cached */
#define MAX_IDENTITY 4096

typedef struct cache_entry {
    char dir[3072], path[3200];
    char identity[MAX_IDENTITY];
} cache_entry;

/* A second hash of the sources, independent of FNV: 64-bit multiply-mix. */
static uint64_t mix64(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; i++) {
        h = (h + p[i] + 1) * 0x9e3779b97f4a7c15ull;
        h ^= h >> 29;
    }
    return h;
}

/* The cache directory (made when missing); 0 when off or not usable. */
static int cache_dir(char *dir, size_t size)
{
    const char *env = getenv("CLVOX_CACHE_DIR");
    int n;
    if (env && *env) {
        if (strcmp(env, "off") == 0 || strcmp(env, "0") == 0) return 0;
        n = snprintf(dir, size, "%s", env);
    } else if ((env = getenv("XDG_CACHE_HOME")) && env[0] == '/') {
        n = snprintf(dir, size, "%s/clvox", env);
    } else if ((env = getenv("HOME")) && env[0] == '/') {
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
    uint64_t h1 = CLVOX__FNV_BASIS, h2 = 0;
    for (unsigned i = 0; i < clvox__kernel_source_count; i++) {
        size_t len = strlen(clvox__kernel_sources[i]);
        h1 = clvox__fnv1a(h1, clvox__kernel_sources[i], len + 1); /* the NUL separates the files */
        h2 = mix64(h2, clvox__kernel_sources[i], len + 1);
    }
    char platform[512] = "", device[256] = "", vendor[256] = "", dversion[256] = "", driver[256] = "";
    if (clGetPlatformInfo(ctx->platform, CL_PLATFORM_VERSION, sizeof platform - 1, platform, NULL) != CL_SUCCESS)
        platform[0] = 0;
    device_string(ctx->device_id, CL_DEVICE_NAME, device, sizeof device);
    device_string(ctx->device_id, CL_DEVICE_VENDOR, vendor, sizeof vendor);
    device_string(ctx->device_id, CL_DEVICE_VERSION, dversion, sizeof dversion);
    device_string(ctx->device_id, CL_DRIVER_VERSION, driver, sizeof driver);
    int n = snprintf(e->identity, sizeof e->identity,
                     "clvox %s\nsources %016llx%016llx\noptions %s\nplatform %s\ndevice %s\nvendor %s\n"
                     "version %s\ndriver %s\npointer %zu\n",
                     CLVOX_VERSION_STRING, (unsigned long long)h1, (unsigned long long)h2, options, platform, device,
                     vendor, dversion, driver, sizeof(void *));
    if (n <= 0 || (size_t)n >= sizeof e->identity) return 0;
    uint64_t key = clvox__fnv1a(CLVOX__FNV_BASIS, e->identity, (size_t)n);
    n = snprintf(e->path, sizeof e->path, "%s/%016llx" SUFFIX, e->dir, (unsigned long long)key);
    return n > 0 && (size_t)n < sizeof e->path;
}

/* File layout: MAGIC, identity length (8 bytes LE), identity, binary length
 * (8), binary, FNV-1a of the binary (8). */
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
    if (len == 0 || len > MAX_BINARY || n - off < 8 || len != n - off - 8) return 0;
    if (get64(file + n - 8) != clvox__fnv1a(CLVOX__FNV_BASIS, file + off, (size_t)len)) return 0;
    *bin_off = off;
    *bin_len = (size_t)len;
    return 1;
}

/* The file's bytes when it is whole and for this identity; *bin points into them. */
static unsigned char *read_binary(const cache_entry *e, const unsigned char **bin, size_t *size)
{
    FILE *f = fopen(e->path, "rb");
    if (!f) return NULL;
    unsigned char *data = NULL;
    long n = fseek(f, 0, SEEK_END) == 0 ? ftell(f) : -1;
    const size_t most = MAX_BINARY + sizeof MAGIC + MAX_IDENTITY + 32;
    size_t off = 0;
    if (n > 0 && (size_t)n <= most && fseek(f, 0, SEEK_SET) == 0 && (data = malloc((size_t)n)) != NULL &&
        fread(data, 1, (size_t)n, f) == (size_t)n && clvox__program_cache_parse(data, (size_t)n, e->identity, &off, size)) {
        fclose(f);
        *bin = data + off;
        return data;
    }
    free(data);
    fclose(f);
    return NULL;
}

cl_program clvox__program_cache_load(clvox_context *ctx, const char *options)
{
    cache_entry *e = malloc(sizeof *e);
    if (!e) return NULL;
    cl_program program = NULL;
    size_t size = 0;
    const unsigned char *b = NULL;
    unsigned char *file = entry_for(ctx, options, e) ? read_binary(e, &b, &size) : NULL;
    if (file) {
        cl_int err, status = CL_SUCCESS;
        program = clCreateProgramWithBinary(ctx->cl, 1, &ctx->device_id, &size, &b, &status, &err);
        if (err != CL_SUCCESS || status != CL_SUCCESS) {
            if (program) clReleaseProgram(program);
            program = NULL;
        } else if (clBuildProgram(program, 1, &ctx->device_id, options, NULL, NULL) != CL_SUCCESS) {
            clReleaseProgram(program);
            program = NULL;
        } else {
            (void)utimensat(AT_FDCWD, e->path, NULL, 0); /* used: kept longest by prune() */
        }
    }
    free(file);
    free(e);
    return program;
}

/* Keeps the KEEP most recently used binaries of the directory. */
static void prune(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) return;
    struct old {
        char name[256];
        time_t t;
    } list[4 * KEEP];
    size_t n = 0, total = 0;
    struct dirent *de;
    while ((de = readdir(d)) != NULL) {
        size_t len = strlen(de->d_name);
        if (len <= strlen(SUFFIX) || len >= sizeof list[0].name ||
            strcmp(de->d_name + len - strlen(SUFFIX), SUFFIX) != 0)
            continue;
        char path[3400];
        struct stat sb;
        if (snprintf(path, sizeof path, "%s/%s", dir, de->d_name) >= (int)sizeof path || stat(path, &sb) != 0)
            continue;
        total++;
        if (n < sizeof list / sizeof *list) {
            memcpy(list[n].name, de->d_name, len + 1);
            list[n++].t = sb.st_mtime;
        }
    }
    closedir(d);
    /* the oldest first, while more than KEEP remain */
    while (total > KEEP && n > 0) {
        size_t oldest = 0;
        for (size_t i = 1; i < n; i++)
            if (list[i].t < list[oldest].t) oldest = i;
        char path[3400];
        if (snprintf(path, sizeof path, "%s/%s", dir, list[oldest].name) < (int)sizeof path) (void)unlink(path);
        list[oldest] = list[--n];
        total--;
    }
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
    char tmp[3300];
    if (snprintf(tmp, sizeof tmp, "%s/.tmp-XXXXXX", e->dir) >= (int)sizeof tmp) goto done;
    int fd = mkstemp(tmp);
    if (fd < 0) goto done;
    unsigned char head[sizeof MAGIC - 1 + 8], len8[8], sum8[8];
    const size_t il = strlen(e->identity);
    memcpy(head, MAGIC, sizeof MAGIC - 1);
    put64(head + sizeof MAGIC - 1, il);
    put64(len8, size);
    put64(sum8, clvox__fnv1a(CLVOX__FNV_BASIS, bin, size));
    int ok = write_all(fd, head, sizeof head) && write_all(fd, e->identity, il) && write_all(fd, len8, 8) &&
             write_all(fd, bin, size) && write_all(fd, sum8, 8);
    ok = close(fd) == 0 && ok;
    if (!ok || rename(tmp, e->path) != 0) {
        (void)unlink(tmp);
        goto done;
    }
    prune(e->dir);
done:
    free(bin);
    free(e);
}
