/* SPDX-License-Identifier: Apache-2.0 */
/* Replays every fuzz seed corpus (tests/fuzz/seeds_<name>/) and every input a
 * fuzzer or an issue once found (tests/fuzz/regress_<name>/) through the fuzz
 * targets' own checks, without libFuzzer: the mesh targets' property check
 * (fuzz/fuzz_mesh.h), the EXR reader target, the palette parser target and
 * the render map parser target, the --like header target, the program
 * cache file target, the batch manifest target, the npy, NRRD and binvox
 * reader targets,
 * compiled here a second time with gcc. Each input runs in a child process with a time limit, so a crash,
 * an abort inside OpenMesh, a hang or (under CONFIG=sanitize) a sanitizer
 * report fails that input alone. Runs from the repository root (run_tests.sh). */
#include "test.h"

#include <dirent.h>
#include <signal.h>
#include <stdint.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "fuzz/fuzz_mesh.h"
#include "fuzz/fuzz_volume_read.c" /* LLVMFuzzerTestOneInput of fuzz_volume_read */
#define LLVMFuzzerTestOneInput fuzz_palette_one_input
#include "fuzz/fuzz_palette.c" /* the palette target, renamed */
#undef LLVMFuzzerTestOneInput
#define LLVMFuzzerTestOneInput fuzz_render_map_one_input
#include "fuzz/fuzz_render_map.c" /* the render map target, renamed */
#undef LLVMFuzzerTestOneInput
#define LLVMFuzzerTestOneInput fuzz_like_header_one_input
#include "fuzz/fuzz_like_header.c" /* the --like header target, renamed */
#undef LLVMFuzzerTestOneInput
#define LLVMFuzzerTestOneInput fuzz_program_cache_one_input
#include "fuzz/fuzz_program_cache.c" /* the program cache file target, renamed */
#undef LLVMFuzzerTestOneInput
#define LLVMFuzzerTestOneInput fuzz_manifest_one_input
#include "fuzz/fuzz_manifest.c" /* the batch manifest target, renamed (links src/cli/cli_manifest.c: Makefile) */
#undef LLVMFuzzerTestOneInput
#define LLVMFuzzerTestOneInput fuzz_mesh_assimp_one_input
#include "fuzz/fuzz_mesh_assimp.c" /* the Assimp target (first byte: the extension), renamed */
#undef LLVMFuzzerTestOneInput
#define LLVMFuzzerTestOneInput fuzz_read_npy_one_input
#include "fuzz/fuzz_read_npy.c" /* the npy, NRRD and binvox reader targets, renamed (fuzz/fuzz_read.h) */
#undef LLVMFuzzerTestOneInput
#define LLVMFuzzerTestOneInput fuzz_read_nrrd_one_input
#include "fuzz/fuzz_read_nrrd.c"
#undef LLVMFuzzerTestOneInput
#define LLVMFuzzerTestOneInput fuzz_read_binvox_one_input
#include "fuzz/fuzz_read_binvox.c"
#undef LLVMFuzzerTestOneInput

typedef struct target {
    const char *name; /* fuzz_<name>.c, seeds_<name>/, regress_<name>/ */
    const char *ext;  /* mesh extension; NULL: a target with its own entry point */
    int (*one)(const uint8_t *, size_t); /* that entry point */
    int needs_shm;    /* writes its input to /dev/shm */
} target;

static const target targets[] = {
    {"volume_read", NULL, LLVMFuzzerTestOneInput, 1}, {"palette", NULL, fuzz_palette_one_input, 0},
    {"render_map", NULL, fuzz_render_map_one_input, 0}, {"like_header", NULL, fuzz_like_header_one_input, 0},
    {"program_cache", NULL, fuzz_program_cache_one_input, 0}, {"manifest", NULL, fuzz_manifest_one_input, 0},
    {"read_npy", NULL, fuzz_read_npy_one_input, 1}, {"read_nrrd", NULL, fuzz_read_nrrd_one_input, 1},
    {"read_binvox", NULL, fuzz_read_binvox_one_input, 1},
    {"mesh_obj", "obj", NULL, 0}, {"mesh_off", "off", NULL, 0}, {"mesh_ply", "ply", NULL, 0},
    {"mesh_stl", "stl", NULL, 0}, {"mesh_om", "om", NULL, 0},
    {"mesh_assimp", NULL, fuzz_mesh_assimp_one_input, 0},
};

static unsigned char *read_all(const char *p, size_t *n)
{
    FILE *f = fopen(p, "rb");
    if (!f) return NULL;
    size_t cap = 4096, len = 0;
    unsigned char *b = malloc(cap);
    for (size_t got; b && (got = fread(b + len, 1, cap - len, f)) > 0;) {
        len += got;
        if (len == cap) {
            unsigned char *g = realloc(b, cap *= 2);
            if (!g) free(b);
            b = g;
        }
    }
    fclose(f);
    *n = len;
    return b;
}

/* The input being replayed: a global, so LeakSanitizer in the child sees it
 * as reachable. */
static unsigned char *g_input;

/* One input in a child: 0 when it passed, else why not (in `why`). */
static int replay(const target *t, const unsigned char *data, size_t n, char *why, size_t why_size)
{
    fflush(NULL);
    pid_t pid = fork();
    if (pid < 0) {
        snprintf(why, why_size, "fork failed");
        return 1;
    }
    if (pid == 0) {
        alarm(30); /* a hang: SIGALRM */
        if (t->ext) {
            const char *w = fuzz_mesh_check(t->ext, data, n);
            if (w) {
                fprintf(stderr, "  property: %s\n", w);
                exit(1);
            }
        } else {
            t->one(data, n);
        }
        clvox_context_destroy(fuzz_mesh_ctx);
        clvox_context_destroy(palette_ctx);
        for (int i = 0; i < 2; i++) clvox_palette_destroy(render_map_palettes[i]);
        clvox_context_destroy(render_map_ctx);
        exit(0); /* exit, not _exit: LeakSanitizer checks the child */
    }
    int status = 0;
    while (waitpid(pid, &status, 0) < 0) {
    }
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return 0;
    /* A child that died inside the loader left its input file behind. */
    char left[96];
    snprintf(left, sizeof left, "/dev/shm/clvox-fuzz-%ld.%s", (long)pid, t->ext ? t->ext : "exr");
    unlink(left);
    snprintf(left, sizeof left, "/tmp/clvox-fuzz-%ld.%s", (long)pid, t->ext ? t->ext : "exr");
    unlink(left);
    if (WIFSIGNALED(status))
        snprintf(why, why_size, "killed by signal %d%s", WTERMSIG(status),
                 WTERMSIG(status) == SIGALRM ? " (hang: over 30 s)" : "");
    else
        snprintf(why, why_size, "exit %d", WEXITSTATUS(status));
    return 1;
}

/* Replays the files of dir; returns how many there were. */
static int replay_dir(const target *t, const char *kind)
{
    char dir[256];
    snprintf(dir, sizeof dir, "tests/fuzz/%s_%s", kind, t->name);
    struct dirent **list = NULL;
    int count = scandir(dir, &list, NULL, alphasort), files = 0;
    for (int i = 0; i < count; i++) {
        if (list[i]->d_name[0] != '.') {
            char p[600], why[128];
            snprintf(p, sizeof p, "%s/%s", dir, list[i]->d_name);
            size_t n = 0;
            g_input = read_all(p, &n);
            CHECK_MSG(g_input != NULL, "cannot read %s", p);
            if (g_input) {
                int bad = replay(t, g_input, n, why, sizeof why);
                CHECK_MSG(!bad, "%s: %s", p, why);
                files++;
            }
            free(g_input);
            g_input = NULL;
        }
        free(list[i]);
    }
    free(list);
    return files;
}

int main(void)
{
    int shm = access("/dev/shm", W_OK) == 0;
    for (size_t i = 0; i < sizeof targets / sizeof targets[0]; i++) {
        const target *t = &targets[i];
        if (t->needs_shm && !shm) {
            printf("%s: skipped (/dev/shm is not writable)\n", t->name);
            continue;
        }
        int seeds = replay_dir(t, "seeds");
        int found = replay_dir(t, "regress");
        CHECK_MSG(seeds > 0, "%s: no seeds in tests/fuzz/seeds_%s (run from the repository root)", t->name, t->name);
        printf("%s: %d seeds, %d regression inputs\n", t->name, seeds, found);
    }
    return test_report();
}
