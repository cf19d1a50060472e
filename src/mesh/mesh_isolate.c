/* SPDX-License-Identifier: Apache-2.0 */
/* Assimp in a child process (every Assimp read): fork, the child
 * parses the bytes mesh_load.c already read (clvox__assimp_read) and writes
 * the flattened mesh into a pipe, the parent reads it back. A parser that
 * crashes, aborts or runs out of its memory or CPU limit takes only the
 * child with it: the parent reports one line (and clvox batch goes on).
 * Debian's libassimp is built with its assertions on: the fuzzer
 * (fuzz_mesh_assimp) found an abort() in the 3MF reader within seconds
 * (D3MFOpcPackage.cpp:170, a package without a root model), so no Assimp
 * read runs in the caller's process.
 *
 * The child's limits: address space 2 GiB + 64 x the file (not under
 * AddressSanitizer, whose shadow memory needs far more), CPU time 60 s +
 * 1 s per MB. Under AddressSanitizer the child also gives crashes back to
 * their signals and dies by SIGABRT on a sanitizer report, so the parent
 * tells a crash as it does in other builds. It touches nothing of the parent's OpenCL state and leaves by
 * _exit (no atexit handlers, no stdio flush of the parent's buffers).
 *
 * What comes back through the pipe: a header (status, message, counts,
 * offset, source info), then xyz, triangle indices and per-triangle source
 * mesh, each exactly as long as the header says; a short read is "the
 * reader crashed". */
#include "mesh_internal.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#if defined(__SANITIZE_ADDRESS__)
#define CLVOX__ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define CLVOX__ASAN 1
#endif
#endif
#ifdef CLVOX__ASAN
#include <sanitizer/common_interface_defs.h>

/* A sanitizer's report ends in exit status 1 (its report went to /dev/null
 * with the child's stderr): the child dies by SIGABRT instead, so that the
 * parent says "crashed", as it does for the same input in other builds. */
static void sanitizer_died(void)
{
    signal(SIGABRT, SIG_DFL);
    raise(SIGABRT);
}
#endif

typedef struct {
    int32_t rc;
    char err[512];
    uint64_t vertex_count, face_count;
    double offset[3];
    clvox_mesh_source_info source;
} isolate_header;

static int write_all(int fd, const void *p, size_t n)
{
    const char *c = p;
    while (n) {
        ssize_t w = write(fd, c, n > (1u << 20) ? (1u << 20) : n);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) return -1;
        c += w;
        n -= (size_t)w;
    }
    return 0;
}

static int read_all(int fd, void *p, size_t n)
{
    char *c = p;
    while (n) {
        ssize_t r = read(fd, c, n > (1u << 20) ? (1u << 20) : n);
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) return -1;
        c += r;
        n -= (size_t)r;
    }
    return 0;
}

static void child(int fd, const char *path, const char *ext, const unsigned char *data, size_t n)
{
#ifndef CLVOX__ASAN
    struct rlimit as;
    uint64_t lim = (2ull << 30) + 64ull * n;
    as.rlim_cur = as.rlim_max = (rlim_t)lim;
    setrlimit(RLIMIT_AS, &as);
#else
    /* AddressSanitizer's handlers turn a crash into exit status 1: a crash
     * kills the child by its signal here too (test_assimp's crash hook) */
    signal(SIGSEGV, SIG_DFL);
    signal(SIGBUS, SIG_DFL);
    signal(SIGFPE, SIG_DFL);
    signal(SIGILL, SIG_DFL);
    __sanitizer_set_death_callback(sanitizer_died);
#endif
    struct rlimit cpu;
    cpu.rlim_cur = cpu.rlim_max = (rlim_t)(60 + n / 1000000);
    setrlimit(RLIMIT_CPU, &cpu);
    signal(SIGPIPE, SIG_DFL);
    /* Assimp's assertions print before they abort: the library prints nothing */
    int null = open("/dev/null", O_WRONLY);
    if (null >= 0) {
        dup2(null, STDOUT_FILENO);
        dup2(null, STDERR_FILENO);
        if (null > STDERR_FILENO) close(null);
    }

    isolate_header h;
    memset(&h, 0, sizeof h);
    clvox__raw_mesh raw;
    h.rc = clvox__assimp_read(path, ext, data, n, &raw, h.err, sizeof h.err);
    if (h.rc == 0) {
        h.vertex_count = raw.vertex_count;
        h.face_count = raw.face_count;
        memcpy(h.offset, raw.offset, sizeof h.offset);
        h.source = raw.source;
    }
    int bad = write_all(fd, &h, sizeof h);
    if (!bad && h.rc == 0)
        bad = write_all(fd, raw.xyz, 3 * raw.vertex_count * sizeof(float)) ||
              write_all(fd, raw.face_indices, 3 * raw.face_count * sizeof(uint32_t)) ||
              write_all(fd, raw.face_source, raw.face_count * sizeof(uint32_t));
    _exit(bad ? 3 : 0);
}

static void describe_death(int status, char *err, size_t err_size)
{
    if (WIFSIGNALED(status)) {
        int sig = WTERMSIG(status);
        snprintf(err, err_size, "the reader crashed (signal %d: %s)%s", sig, strsignal(sig),
                 sig == SIGXCPU ? ", over its CPU time limit" : "");
    } else if (WIFEXITED(status) && WEXITSTATUS(status) != 0) {
        snprintf(err, err_size, "the reader process failed (exit status %d; out of memory?)", WEXITSTATUS(status));
    } else {
        snprintf(err, err_size, "the reader process ended without a result");
    }
}

int clvox__assimp_read_isolated(const char *path, const char *ext, const unsigned char *data, size_t n,
                                clvox__raw_mesh *out, char *err, size_t err_size)
{
    memset(out, 0, sizeof *out);
    int fds[2];
    if (pipe(fds) != 0) {
        snprintf(err, err_size, "cannot create a pipe for the reader process: %s", strerror(errno));
        return -1;
    }
    pid_t pid = fork();
    if (pid < 0) {
        int e = errno;
        close(fds[0]);
        close(fds[1]);
        snprintf(err, err_size, "cannot start the reader process: %s", strerror(e));
        return -1;
    }
    if (pid == 0) {
        close(fds[0]);
        child(fds[1], path, ext, data, n); /* does not return */
    }
    close(fds[1]);

    isolate_header h;
    int rc = -1, got = read_all(fds[0], &h, sizeof h) == 0;
    if (got && h.rc == 0) {
        /* The child's own bound (mesh_assimp.cpp) holds; these only keep a
         * broken message from asking for absurd allocations. */
        if (h.vertex_count > UINT32_MAX || h.face_count > UINT32_MAX / 3) {
            got = 0;
        } else {
            size_t nv = (size_t)h.vertex_count, nf = (size_t)h.face_count;
            out->xyz = malloc((nv ? nv : 1) * 3 * sizeof(float));
            out->face_indices = malloc((nf ? nf : 1) * 3 * sizeof(uint32_t));
            out->face_source = malloc((nf ? nf : 1) * sizeof(uint32_t));
            if (!out->xyz || !out->face_indices || !out->face_source) {
                clvox__raw_mesh_free(out);
                snprintf(err, err_size, "out of memory for %zu vertices and %zu triangles", nv, nf);
                rc = -2;
                got = 0;
            } else if (read_all(fds[0], out->xyz, 3 * nv * sizeof(float)) ||
                       read_all(fds[0], out->face_indices, 3 * nf * sizeof(uint32_t)) ||
                       read_all(fds[0], out->face_source, nf * sizeof(uint32_t))) {
                clvox__raw_mesh_free(out);
                got = 0;
            } else {
                out->vertex_count = nv;
                out->face_count = nf;
                out->index_count = 3 * nf;
                memcpy(out->offset, h.offset, sizeof h.offset);
                out->source = h.source;
                out->source.size = sizeof out->source;
                out->source.reader[sizeof out->source.reader - 1] = 0;
                rc = 0;
            }
        }
    }
    close(fds[0]);
    int status = 0;
    if (!got || rc != 0) kill(pid, SIGKILL); /* nothing more wanted from it */
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    if (rc == 0) {
        if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return 0;
        clvox__raw_mesh_free(out);
        describe_death(status, err, err_size);
        return -1;
    }
    if (rc == -2) return -2;
    if (got) { /* the child's own failure, with its message */
        h.err[sizeof h.err - 1] = 0;
        snprintf(err, err_size, "%s", h.err);
        return h.rc == -2 ? -2 : -1;
    }
    describe_death(status, err, err_size);
    return -1;
}
