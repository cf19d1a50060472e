/* The kernel program's binary between processes (src/program_cache.c): a
 * context stores it, the next one is made from it and gives the same voxels;
 * a corrupt, truncated, foreign or refused file is a miss that is rebuilt
 * and rewritten; a directory that cannot be used, or CLVOX_CACHE_DIR=off,
 * only means no cache; at most 8 binaries are kept. */
#include "internal.h"
#include "meshgen.h"
#include "test.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>
#include <utime.h>

static char g_dir[2048];

/* The .clvoxbin files in g_dir; the path of the last one in `one`. */
static int binaries(char *one, size_t size)
{
    DIR *d = opendir(g_dir);
    int n = 0;
    struct dirent *e;
    while (d && (e = readdir(d))) {
        size_t len = strlen(e->d_name);
        if (len > 9 && strcmp(e->d_name + len - 9, ".clvoxbin") == 0) {
            n++;
            if (one) snprintf(one, size, "%s/%s", g_dir, e->d_name);
        }
    }
    if (d) closedir(d);
    return n;
}

static void clear_dir_at(const char *dir)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    char p[8192];
    while (d && (e = readdir(d))) {
        if (e->d_name[0] == '.' && (e->d_name[1] == 0 || (e->d_name[1] == '.' && e->d_name[2] == 0))) continue;
        snprintf(p, sizeof p, "%s/%s", dir, e->d_name);
        unlink(p);
    }
    if (d) closedir(d);
}

static void clear_dir(void) { clear_dir_at(g_dir); }

static long file_size(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0 ? (long)sb.st_size : -1;
}

/* Flips one byte at `at` (from the end when negative). */
static int flip_byte(const char *path, long at)
{
    FILE *f = fopen(path, "r+b");
    if (!f) return 0;
    if (at < 0) at += file_size(path);
    int ok = fseek(f, at, SEEK_SET) == 0;
    int c = ok ? fgetc(f) : EOF;
    ok = ok && c != EOF && fseek(f, at, SEEK_SET) == 0 && fputc(c ^ 0x5a, f) != EOF;
    return fclose(f) == 0 && ok;
}

/* A context, its voxels of the mesh, and whether its program came from the cache. */
static int voxelize(const tmesh *t, uint8_t *vox, size_t n, int *cached)
{
    clvox_context *ctx = NULL;
    clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
    clvox_status st = clvox_context_create(&o, &ctx);
    CHECK_MSG(st == CLVOX_OK, "context: %s", clvox_context_error(ctx));
    int ok = st == CLVOX_OK;
    clvox_mesh *mesh = NULL;
    if (ok) {
        *cached = ctx->program_cached;
        ok = clvox_mesh_from_arrays(ctx, t->xyz, t->nv, t->tri, t->nt, &mesh) == CLVOX_OK;
        clvox_grid_options go = CLVOX_GRID_OPTIONS_INIT;
        go.resolution = 32;
        clvox_grid g;
        const clvox_mesh_report *r = ok ? clvox_mesh_get_report(mesh) : NULL;
        ok = ok && clvox_grid_compute(ctx, &go, r->bbox_min, r->bbox_max, &g) == CLVOX_OK;
        clvox_voxelize_options vo = CLVOX_VOXELIZE_OPTIONS_INIT;
        ok = ok && (size_t)g.dims[0] * g.dims[1] * g.dims[2] == n &&
             clvox_voxelize_to_buffers(ctx, mesh, &g, &vo, vox, n, NULL, 0, NULL) == CLVOX_OK;
        CHECK_MSG(ok, "voxelize: %s", clvox_context_error(ctx));
    }
    clvox_mesh_destroy(mesh);
    clvox_context_destroy(ctx);
    return ok;
}

/* The library's embedded kernel sources are the files in kernels/ byte for
 * byte (scripts/embed_kernels.sh escapes backslashes and quotes: prelude.cl
 * has both). */
static void test_embedded_sources(void)
{
    int backslash = 0;
    for (unsigned i = 0; i < clvox__kernel_source_count; i++) {
        char path[512];
        snprintf(path, sizeof path, "kernels/%s", clvox__kernel_names[i]);
        FILE *f = fopen(path, "rb");
        CHECK_MSG(f != NULL, "%s: cannot open (run from the repository root)", path);
        if (!f) continue;
        const char *src = clvox__kernel_sources[i];
        size_t n = strlen(src), at = 0, same = 1;
        int c;
        while ((c = fgetc(f)) != EOF) {
            if (at >= n || (unsigned char)src[at] != (unsigned)c) same = 0;
            backslash |= c == '\\';
            at++;
        }
        fclose(f);
        CHECK_MSG(same && at == n, "%s: the embedded source differs from the file", path);
    }
    CHECK_MSG(backslash, "no kernel file has a backslash: the escaping goes unchecked");
}

int main(void)
{
    test_embedded_sources();
    snprintf(g_dir, sizeof g_dir, "%s/program-cache", test_tmpdir());
    mkdir(g_dir, 0777);
    clear_dir();
    setenv("CLVOX_CACHE_DIR", g_dir, 1);
    tmesh t = tmesh_torus(0.05, -0.02, 0.01, 0.7, 0.3, 48, 24);
    const size_t n = 32 * 32 * 10; /* the torus's grid at -r 32: checked below */
    uint8_t *ref = calloc(n, 1), *vox = calloc(n, 1);
    int cached = -1;

    /* a miss stores the binary; the next context is made from it, same voxels */
    CHECK(voxelize(&t, ref, n, &cached) && cached == 0);
    size_t filled = 0;
    for (size_t i = 0; i < n; i++) filled += ref[i];
    CHECK(filled > n / 20 && filled < n);
    char bin[4096] = "";
    CHECK(binaries(bin, sizeof bin) == 1);
    const long whole = file_size(bin);
    CHECK(whole > 1000);
    for (int k = 0; k < 2; k++) {
        memset(vox, 7, n);
        CHECK(voxelize(&t, vox, n, &cached) && cached == 1);
        CHECK(memcmp(vox, ref, n) == 0);
    }
    CHECK(binaries(NULL, 0) == 1);

    /* a flipped byte in the binary (checksum), in the identity, in the magic; a truncated file; an
     * empty one: each a miss that is rebuilt, gives the same voxels and rewrites the file whole */
    static const long at[] = {-100, 40, 2};
    for (size_t i = 0; i < sizeof at / sizeof *at; i++) {
        CHECK(flip_byte(bin, at[i]));
        memset(vox, 7, n);
        CHECK_MSG(voxelize(&t, vox, n, &cached) && cached == 0, "flip at %ld: cached %d", at[i], cached);
        CHECK(memcmp(vox, ref, n) == 0);
        CHECK(file_size(bin) == whole);
        CHECK(voxelize(&t, vox, n, &cached) && cached == 1);
    }
    CHECK(truncate(bin, whole / 2) == 0);
    CHECK(voxelize(&t, vox, n, &cached) && cached == 0 && memcmp(vox, ref, n) == 0);
    CHECK(file_size(bin) == whole);
    CHECK(truncate(bin, 0) == 0);
    CHECK(voxelize(&t, vox, n, &cached) && cached == 0 && memcmp(vox, ref, n) == 0);
    CHECK(voxelize(&t, vox, n, &cached) && cached == 1);

    /* a well-formed file whose binary the driver refuses (garbage with a valid wrapper): the
     * identity and checksum are right, so only clCreateProgramWithBinary/clBuildProgram can say no */
    {
        FILE *f = fopen(bin, "rb");
        unsigned char *data = malloc((size_t)whole);
        CHECK(f && fread(data, 1, (size_t)whole, f) == (size_t)whole);
        if (f) fclose(f);
        /* layout: magic (23) + 8 + identity + 8 + binary + 8 */
        uint64_t il = 0, bl = 0;
        for (int k = 0; k < 8; k++) il |= (uint64_t)data[23 + k] << (8 * k);
        const size_t b0 = 23 + 8 + (size_t)il + 8;
        for (int k = 0; k < 8; k++) bl |= (uint64_t)data[23 + 8 + il + k] << (8 * k);
        CHECK(b0 + bl + 8 == (size_t)whole);
        if (b0 + bl + 8 == (size_t)whole) {
            for (size_t k = 0; k < bl; k++) data[b0 + k] = (unsigned char)(k * 131u + 7u);
            uint64_t h = 0xcbf29ce484222325ull;
            for (size_t k = 0; k < bl; k++) h = (h ^ data[b0 + k]) * 0x100000001b3ull;
            for (int k = 0; k < 8; k++) data[b0 + bl + k] = (unsigned char)(h >> (8 * k));
            f = fopen(bin, "wb");
            CHECK(f && fwrite(data, 1, (size_t)whole, f) == (size_t)whole);
            if (f) CHECK(fclose(f) == 0);
            CHECK(voxelize(&t, vox, n, &cached) && cached == 0 && memcmp(vox, ref, n) == 0);
            CHECK(voxelize(&t, vox, n, &cached) && cached == 1);
        }
        free(data);
    }

    /* at most 8 binaries: 10 old ones from other builds, ours (just written) kept */
    char path[4200];
    for (int k = 0; k < 10; k++) {
        snprintf(path, sizeof path, "%s/%016x.clvoxbin", g_dir, k);
        FILE *f = fopen(path, "wb");
        CHECK(f && fputs("old", f) >= 0);
        if (f) fclose(f);
        struct utimbuf u = {.actime = time(NULL) - 86400 * (k + 1), .modtime = time(NULL) - 86400 * (k + 1)};
        CHECK(utime(path, &u) == 0);
    }
    CHECK(binaries(NULL, 0) == 11);
    CHECK(unlink(bin) == 0); /* a miss, so that the store prunes */
    CHECK(voxelize(&t, vox, n, &cached) && cached == 0);
    CHECK(binaries(NULL, 0) == 8);
    CHECK(file_size(bin) == whole);
    snprintf(path, sizeof path, "%s/%016x.clvoxbin", g_dir, 0); /* the newest old one stays */
    CHECK(file_size(path) == 3);
    snprintf(path, sizeof path, "%s/%016x.clvoxbin", g_dir, 9); /* the oldest goes */
    CHECK(file_size(path) == -1);

    /* off, or a directory that cannot be used: no cache, the context still works */
    clear_dir();
    setenv("CLVOX_CACHE_DIR", "off", 1);
    CHECK(voxelize(&t, vox, n, &cached) && cached == 0 && memcmp(vox, ref, n) == 0);
    CHECK(binaries(NULL, 0) == 0);
    snprintf(path, sizeof path, "%s/a-file", g_dir);
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (f) fclose(f);
    setenv("CLVOX_CACHE_DIR", path, 1); /* a regular file */
    CHECK(voxelize(&t, vox, n, &cached) && cached == 0 && memcmp(vox, ref, n) == 0);
    setenv("CLVOX_CACHE_DIR", "/proc/clvox-no-such-dir", 1);
    CHECK(voxelize(&t, vox, n, &cached) && cached == 0 && memcmp(vox, ref, n) == 0);
    /* HOME-based default when CLVOX_CACHE_DIR is unset: HOME/.cache/clvox */
    unsetenv("CLVOX_CACHE_DIR");
    unsetenv("XDG_CACHE_HOME");
    char home[3200], cwd[1024] = ""; /* HOME counts only when absolute (the test's dir may be relative) */
    if (g_dir[0] != '/' && !getcwd(cwd, sizeof cwd)) cwd[0] = 0;
    snprintf(home, sizeof home, "%s%s%s/home", cwd, cwd[0] ? "/" : "", g_dir);
    mkdir(home, 0777);
    setenv("HOME", home, 1);
    snprintf(path, sizeof path, "%s/.cache/clvox", home);
    clear_dir_at(path); /* an earlier run's binary there */
    CHECK(voxelize(&t, vox, n, &cached) && cached == 0);
    CHECK(voxelize(&t, vox, n, &cached) && cached == 1 && memcmp(vox, ref, n) == 0);
    snprintf(path, sizeof path, "%s/.cache/clvox", home);
    struct stat sb;
    CHECK(stat(path, &sb) == 0 && S_ISDIR(sb.st_mode) && (sb.st_mode & 0777) == 0700);

    free(ref);
    free(vox);
    tmesh_free(&t);
    return test_report();
}
