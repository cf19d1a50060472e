/* SPDX-License-Identifier: Apache-2.0 */
/* The body of the libFuzzer targets of the readers of clvox's other volume
 * formats (src/io/read_volume.c): fuzz_read_npy, fuzz_read_nrrd,
 * fuzz_read_binvox. An input is one or more files joined by FUZZ_READ_SEP;
 * the k-th is written under the k-th name of the target's list (the main
 * file first, then its sidecar, set members or detached data) in a
 * directory of the process's own, and each of the target's entry files is
 * read as fuzz_volume_read reads an EXR: the header and count, the
 * occupancy of a small volume, every channel's slices. Every input must
 * give a volume or a status with a message; never a crash, a hang, an
 * out-of-bounds access or an allocation beyond what the files describe.
 * Seeds: tests/fuzz/make_read_seeds.sh (files written by clvox). */
#ifndef CLVOX_FUZZ_READ_H
#define CLVOX_FUZZ_READ_H

#include "clvox.h"

#include <dirent.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define FUZZ_READ_SEP "\n==CLVOX-FUZZ-NEXT-FILE==\n"

static clvox_context *fuzz_read_ctx;
static char fuzz_read_dir[64];

/* Removes the process's directory (atexit). */
static void fuzz_read_cleanup(void)
{
    DIR *d = opendir(fuzz_read_dir);
    struct dirent *e;
    char fpath[400];
    while (d && (e = readdir(d))) {
        if (e->d_name[0] == '.') continue;
        snprintf(fpath, sizeof fpath, "%s/%s", fuzz_read_dir, e->d_name);
        unlink(fpath);
    }
    if (d) closedir(d);
    rmdir(fuzz_read_dir);
    clvox_context_destroy(fuzz_read_ctx);
    fuzz_read_ctx = NULL;
}

static int fuzz_read_slice(void *user, uint32_t z, const float *values)
{
    (void)z;
    *(double *)user += values[0];
    return 0;
}

static void fuzz_read_one(const char *file)
{
    clvox_context *c = fuzz_read_ctx;
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    clvox_status st = clvox_volume_read(c, file, &info, NULL, 0);
    if (st != CLVOX_OK && !clvox_context_error(c)[0]) abort(); /* every failure says why */
    if (st == CLVOX_OK) {
        uint64_t n = (uint64_t)info.dims[0] * info.dims[1] * info.dims[2];
        if (n <= (1u << 20)) {
            uint8_t *occ = malloc((size_t)n);
            if (occ) {
                clvox_volume_info again = CLVOX_VOLUME_INFO_INIT;
                st = clvox_volume_read(c, file, &again, occ, (size_t)n);
                if (st == CLVOX_OK && again.filled_voxels != info.filled_voxels) abort(); /* deterministic */
                free(occ);
            }
        }
    }
    double sum = 0;
    static const char *const channels[] = {"coverage", "occupancy", "element", "score"};
    for (size_t i = 0; i < sizeof channels / sizeof channels[0]; i++) {
        st = clvox_volume_read_slices(c, file, channels[i], NULL, fuzz_read_slice, &sum);
        if (st != CLVOX_OK && !clvox_context_error(c)[0]) abort();
    }
}

/* names: the files the parts become (n of them); entries: the files read. */
static int fuzz_read_run(const uint8_t *data, size_t size, const char *const *names, size_t n,
                         const char *const *entries, size_t ne)
{
    if (!fuzz_read_ctx) {
        clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
        o.host_only = 1;
        if (clvox_context_create(&o, &fuzz_read_ctx) != CLVOX_OK) abort();
        snprintf(fuzz_read_dir, sizeof fuzz_read_dir, "/dev/shm/clvox-fuzz-read-%ld", (long)getpid());
        mkdir(fuzz_read_dir, 0700);
        atexit(fuzz_read_cleanup);
    }
    char fpath[160];
    const size_t sl = strlen(FUZZ_READ_SEP);
    const uint8_t *p = data, *end = data + size;
    for (size_t k = 0; k < n; k++) {
        snprintf(fpath, sizeof fpath, "%s/%s", fuzz_read_dir, names[k]);
        unlink(fpath);
        if (!p) continue; /* fewer parts than names: the rest are absent */
        const uint8_t *q = p;
        while (q + sl <= end && memcmp(q, FUZZ_READ_SEP, sl) != 0) q++;
        const uint8_t *part_end = q + sl <= end ? q : end;
        FILE *f = fopen(fpath, "wb");
        if (!f) abort();
        if (part_end > p && fwrite(p, 1, (size_t)(part_end - p), f) != (size_t)(part_end - p)) abort();
        if (fclose(f) != 0) abort();
        p = part_end < end ? part_end + sl : NULL;
    }
    for (size_t k = 0; k < ne; k++) {
        snprintf(fpath, sizeof fpath, "%s/%s", fuzz_read_dir, entries[k]);
        fuzz_read_one(fpath);
    }
    return 0;
}

#endif
