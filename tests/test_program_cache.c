/* SPDX-License-Identifier: Apache-2.0 */
/* The kernel program's binary between processes (src/core/program_cache.c): a
 * context stores it, the next one is made from it and gives the same voxels;
 * a corrupt, truncated, foreign or refused file is a miss that is rebuilt
 * and rewritten; a binary that crashes the driver costs one run, not every
 * run (runs that may crash are this program started again as a child); a
 * FIFO or symbolic link at an entry's name is a miss, never read or followed;
 * a directory that cannot be used, or CLVOX_CACHE_DIR=off, only means no
 * cache; at most 8 binaries are kept, and a killed store's temporary file is
 * removed. Also: SHA-256 against FIPS 180-4's test vectors. */
#include "core/internal.h"
#include "meshgen.h"
#include "spawn.h"
#include "test.h"

#include <dirent.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>
#include <sys/wait.h>
#include <utime.h>

static char g_dir[2048];
static char g_self[4096]; /* this program, run as a child with the argument "child" */

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

/* The names in g_dir containing `part`. */
static int count_named(const char *part)
{
    DIR *d = opendir(g_dir);
    int n = 0;
    struct dirent *e;
    while (d && (e = readdir(d)))
        n += strstr(e->d_name, part) != NULL;
    if (d) closedir(d);
    return n;
}

static int set_age(const char *path, long seconds)
{
    struct utimbuf u = {.actime = time(NULL) - seconds, .modtime = time(NULL) - seconds};
    return utime(path, &u) == 0;
}

static int write_file(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (!f) return 0;
    int ok = fwrite(data, 1, n, f) == n;
    return fclose(f) == 0 && ok;
}

/* A cache entry as written on disk: magic line (23 bytes), identity length
 * (8, LE), identity, binary length (8), binary, checksum (the rest). */
typedef struct entry_bytes {
    unsigned char *data;
    size_t n, il, b0, bl;
} entry_bytes;

static int read_entry(const char *path, entry_bytes *e)
{
    memset(e, 0, sizeof *e);
    const long whole = file_size(path);
    FILE *f = whole > 0 ? fopen(path, "rb") : NULL;
    if (!f) return 0;
    e->n = (size_t)whole;
    e->data = malloc(e->n);
    int ok = e->data && fread(e->data, 1, e->n, f) == e->n;
    fclose(f);
    for (int k = 0; ok && k < 8; k++) e->il |= (size_t)e->data[23 + k] << (8 * k);
    ok = ok && e->n > 23 + 8 + e->il + 8;
    for (int k = 0; ok && k < 8; k++) e->bl |= (size_t)e->data[23 + 8 + e->il + k] << (8 * k);
    e->b0 = 23 + 8 + e->il + 8;
    return ok && e->bl > 64 && e->b0 + e->bl < e->n;
}

/* Writes at `path` the entry's identity and binary, the binary's 8 bytes at
 * `at` set to 0xff (at < 0: every byte garbage), in format 1 (FNV-1a of the
 * binary: what clvox checked before format 2) or 2 (SHA-256 of all before). */
static int forge(const entry_bytes *e, const char *path, int format, long at)
{
    const size_t sum = format == 1 ? 8 : 32, n = e->b0 + e->bl + sum;
    unsigned char *d = malloc(n);
    if (!d) return 0;
    memcpy(d, e->data, e->b0 + e->bl);
    memcpy(d, format == 1 ? "clvox program binary 1\n" : "clvox program binary 2\n", 23);
    for (size_t k = 0; k < e->bl; k++)
        if (at < 0) d[e->b0 + k] = (unsigned char)(k * 131u + 7u);
        else if (k >= (size_t)at && k < (size_t)at + 8) d[e->b0 + k] = 0xff;
    if (format == 1) {
        uint64_t h = 0xcbf29ce484222325ull;
        for (size_t k = 0; k < e->bl; k++) h = (h ^ d[e->b0 + k]) * 0x100000001b3ull;
        for (int k = 0; k < 8; k++) d[e->b0 + e->bl + k] = (unsigned char)(h >> (8 * k));
    } else {
        clvox__sha256(d, e->b0 + e->bl, d + e->b0 + e->bl);
    }
    int ok = write_file(path, d, n);
    free(d);
    return ok;
}

static uint64_t voxel_sum(const uint8_t *vox, size_t n) { return clvox__fnv1a(CLVOX__FNV_BASIS, vox, n); }

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

static const size_t g_n = 32 * 32 * 10; /* the torus's grid at -r 32: checked in main */
static tmesh torus(void) { return tmesh_torus(0.05, -0.02, 0.01, 0.7, 0.3, 48, 24); }

/* The child: voxelizes the torus, prints whether the program came from the
 * cache and the voxels' FNV-1a. */
static int child_main(void)
{
    tmesh t = torus();
    uint8_t *vox = calloc(g_n, 1);
    int cached = -1, ok = vox && voxelize(&t, vox, g_n, &cached);
    if (ok) printf("cached %d sum %016llx\n", cached, (unsigned long long)voxel_sum(vox, g_n));
    free(vox);
    tmesh_free(&t);
    return ok ? 0 : 1;
}

/* Runs the child (killed after 120 s: a hang is a failure, not a stuck
 * test). 1 when it exited 0 with voxels summing to `want`; *cached as it
 * said, *code its exit code (128 + signal when killed by one, -1 past the
 * limit). `quiet`: a failure is expected to be possible, not reported. */
static int run_child(uint64_t want, int *cached, int *code, int quiet)
{
    const char *argv[] = {g_self, "child", NULL};
    spawn_result r;
    *code = spawn_run(&r, argv, 120);
    unsigned long long sum = 0;
    *cached = -1;
    const int ok = *code == 0 && sscanf(r.out, "cached %d sum %llx", cached, &sum) == 2 && sum == want;
    if (!ok && !quiet) {
        const size_t el = strlen(r.err);
        fprintf(stderr, "child: exit %d, out '%s', err '%s'\n", *code, r.out, r.err + (el > 600 ? el - 600 : 0));
    }
    spawn_free(&r);
    return ok;
}

/* SHA-256 (src/core/sha256.c) against FIPS 180-4's examples and, for the padding
 * edges (55/56 and 119/120 bytes fit one or need two more blocks), against
 * Python's hashlib; fed whole and in uneven pieces. */
static void test_sha256(void)
{
    static const struct {
        const char *text;
        size_t repeat;
        const char *hex;
    } v[] = {
        {"", 0, "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"},
        {"abc", 0, "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"},
        {"abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq", 0,
         "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1"},
        {"a", 1000000, "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0"},
        {"a", 55, "9f4390f8d30c2dd92ec9f095b65e2b9ae9b0a925a5258e241c9f1e910f734318"},
        {"a", 56, "b35439a4ac6f0948b6d6f9e3c6af0f5f590ce20f1bde7090ef7970686ec6738a"},
        {"a", 63, "7d3e74a05d7db15bce4ad9ec0658ea98e3f06eeecf16b4c6fff2da457ddc2f34"},
        {"a", 64, "ffe054fe7ae0cb6dc65c3af9b61d5209f439851db43d0ba5997337df154668eb"},
        {"a", 65, "635361c48bb9eab14198e76ea8ab7f1a41685d6ad62aa9146d301d4f17eb0ae0"},
        {"a", 119, "31eba51c313a5c08226adf18d4a359cfdfd8d2e816b13f4af952f7ea6584dcfb"},
        {"a", 120, "2f3d335432c70b580af0e8e1b3674a7c020d683aa5f73aaaedfdc55af904c21c"},
    };
    for (size_t i = 0; i < sizeof v / sizeof *v; i++) {
        const size_t n = v[i].repeat ? v[i].repeat : strlen(v[i].text);
        char *msg = malloc(n + 1);
        if (!msg) continue;
        if (v[i].repeat) memset(msg, v[i].text[0], n);
        else memcpy(msg, v[i].text, n + 1);
        for (int pieces = 0; pieces < 2; pieces++) {
            unsigned char sum[32];
            if (!pieces) {
                clvox__sha256(msg, n, sum);
            } else { /* 1, 2, ... 70, 1, 2, ... bytes at a time */
                clvox__sha256_state st;
                clvox__sha256_init(&st);
                for (size_t at = 0, step = 1; at < n; at += step, step = step % 70 + 1)
                    clvox__sha256_update(&st, msg + at, step < n - at ? step : n - at);
                clvox__sha256_final(&st, sum);
            }
            char got[65];
            for (int k = 0; k < 32; k++) snprintf(got + 2 * k, 3, "%02x", sum[k]);
            CHECK_MSG(strcmp(got, v[i].hex) == 0, "sha256 of vector %zu (%s): %s", i, pieces ? "pieces" : "whole",
                      got);
        }
        free(msg);
    }
}

int main(int argc, char **argv)
{
    if (argc == 2 && strcmp(argv[1], "child") == 0) return child_main();
    test_sha256();
    ssize_t sl = readlink("/proc/self/exe", g_self, sizeof g_self - 1);
    CHECK(sl > 0);
    if (sl > 0) g_self[sl] = 0;
    test_embedded_sources();
    snprintf(g_dir, sizeof g_dir, "%s/program-cache", test_tmpdir());
    mkdir(g_dir, 0777);
    clear_dir();
    setenv("CLVOX_CACHE_DIR", g_dir, 1);
    tmesh t = torus();
    const size_t n = g_n;
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

    const uint64_t want = voxel_sum(ref, n);
    char key[64] = "";
    {
        const char *base = strrchr(bin, '/');
        snprintf(key, sizeof key, "%.16s", base ? base + 1 : bin);
    }
    entry_bytes eb;
    CHECK(read_entry(bin, &eb));
    CHECK(eb.b0 + eb.bl + 32 == eb.n); /* format 2: SHA-256 at the end */

    /* a well-formed file whose binary the driver refuses (garbage with a valid wrapper): the
     * identity and checksum are right, so only clCreateProgramWithBinary/clBuildProgram can say no */
    if (eb.data) {
        CHECK(forge(&eb, bin, 2, -1));
        CHECK(voxelize(&t, vox, n, &cached) && cached == 0 && memcmp(vox, ref, n) == 0);
        CHECK(voxelize(&t, vox, n, &cached) && cached == 1);
    }

    /* issue 32: a format-1 entry that passes format 1's checks (magic, identity, lengths,
     * FNV-1a) with the PoCL binary's count of root entries overwritten (pocl_binary.c asserts,
     * exit 134, on every run before the fix): a miss, rebuilt, the next run uses the new entry */
    int code = 0;
    if (eb.data) {
        CHECK(forge(&eb, bin, 1, 28));
        CHECK(run_child(want, &cached, &code, 0) && cached == 0);
        CHECK(voxelize(&t, vox, n, &cached) && cached == 1 && memcmp(vox, ref, n) == 0);
    }

    /* the same in format 2, SHA-256 and all (a forger who knows the format, or a driver that
     * cannot read its own binary): the run that hands it to the driver may die (it does on
     * PoCL 3.1), leaving its marker; the next run sees the marker of a dead process, deletes
     * the entry and builds from source; the one after uses the new entry */
    if (eb.data) {
        CHECK(forge(&eb, bin, 2, 28));
        const int first = run_child(want, &cached, &code, 1);
        CHECK_MSG(first ? cached == 1 : count_named(".try-") == 1, "first run: exit %d, cached %d, markers %d",
                  code, cached, count_named(".try-"));
        CHECK(run_child(want, &cached, &code, 0) && cached == (first ? 1 : 0));
        CHECK(count_named(".try-") == 0);
        CHECK(voxelize(&t, vox, n, &cached) && cached == 1 && memcmp(vox, ref, n) == 0);
    }

    /* a live process's marker made before the entry was last written, older than 60 s: that
     * process is stuck in the driver on this file (a hang), so it is not loaded (the forged
     * binary would kill the run if it were); the rebuilt entry is newer than the marker and used */
    if (eb.data) {
        CHECK(forge(&eb, bin, 2, 28));
        CHECK(set_age(bin, 3 * 3600));
        char marker[4300];
        snprintf(marker, sizeof marker, "%s/%s.try-%ld-AbCdEf", g_dir, key, (long)getpid());
        CHECK(write_file(marker, "", 0) && set_age(marker, 2 * 3600));
        CHECK(run_child(want, &cached, &code, 0) && cached == 0);
        CHECK(voxelize(&t, vox, n, &cached) && cached == 1 && memcmp(vox, ref, n) == 0);
        CHECK(file_size(marker) == 0); /* a live process's: kept */
        CHECK(unlink(marker) == 0);
    }

    /* issue 32: a FIFO at the entry's name (every run hung in open before the fix): a miss, the run
     * does not block (the child is killed after 120 s), and the store puts a regular file there */
    CHECK(unlink(bin) == 0 && mkfifo(bin, 0600) == 0);
    CHECK(run_child(want, &cached, &code, 0) && cached == 0);
    struct stat sb;
    CHECK(lstat(bin, &sb) == 0 && S_ISREG(sb.st_mode));
    CHECK(voxelize(&t, vox, n, &cached) && cached == 1);

    /* a symbolic link at the entry's name, to a good entry outside the directory: not followed
     * (a miss), the link replaced by a regular file, its target untouched */
    {
        char outside[4300];
        snprintf(outside, sizeof outside, "%s/../outside.clvoxbin", g_dir);
        CHECK(rename(bin, outside) == 0 && set_age(outside, 3600));
        const long before = file_size(outside);
        CHECK(symlink(outside, bin) == 0);
        CHECK(voxelize(&t, vox, n, &cached) && cached == 0 && memcmp(vox, ref, n) == 0);
        CHECK(lstat(bin, &sb) == 0 && S_ISREG(sb.st_mode));
        CHECK(stat(outside, &sb) == 0 && sb.st_mtime < time(NULL) - 1800 && file_size(outside) == before);
        CHECK(voxelize(&t, vox, n, &cached) && cached == 1);
        unlink(outside);
    }

    /* issue 32: a killed store's temporary file (1.2 MB each, never removed before the fix) is
     * removed once it is an hour old; a fresh one may be a store in progress and stays; a dead
     * process's marker for an entry that is gone is removed, a live one's stays */
    {
        char tmp_old[4300], tmp_new[4300], dead[4300], live[4300];
        snprintf(tmp_old, sizeof tmp_old, "%s/.tmp-Old123", g_dir);
        snprintf(tmp_new, sizeof tmp_new, "%s/.tmp-New123", g_dir);
        pid_t gone = fork(); /* a pid that is not running any more */
        if (gone == 0) _exit(0);
        CHECK(gone > 0 && waitpid(gone, NULL, 0) == gone);
        snprintf(dead, sizeof dead, "%s/0123456789abcdef.try-%ld-AbCdEf", g_dir, (long)gone);
        snprintf(live, sizeof live, "%s/0123456789abcdef.try-%ld-AbCdEf", g_dir, (long)getpid());
        CHECK(write_file(tmp_old, "x", 1) && set_age(tmp_old, 2 * 3600));
        CHECK(write_file(tmp_new, "x", 1));
        CHECK(write_file(dead, "", 0) && write_file(live, "", 0));
        CHECK(unlink(bin) == 0); /* a miss: the store prunes */
        CHECK(voxelize(&t, vox, n, &cached) && cached == 0);
        CHECK(file_size(tmp_old) == -1);
        CHECK(file_size(tmp_new) == 1);
        CHECK(file_size(dead) == -1);
        CHECK(file_size(live) == 0);
        CHECK(write_file(tmp_old, "x", 1) && set_age(tmp_old, 2 * 3600));
        CHECK(voxelize(&t, vox, n, &cached) && cached == 1); /* and a load */
        CHECK(file_size(tmp_old) == -1);
        unlink(tmp_new);
        unlink(live);
    }
    free(eb.data);

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
    CHECK(stat(path, &sb) == 0 && S_ISDIR(sb.st_mode) && (sb.st_mode & 0777) == 0700);

    free(ref);
    free(vox);
    tmesh_free(&t);
    return test_report();
}
