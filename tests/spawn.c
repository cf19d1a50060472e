/* SPDX-License-Identifier: Apache-2.0 */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif
#include "spawn.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

static char *slurp(FILE *f)
{
    size_t cap = 4096, n = 0;
    char *buf = malloc(cap);
    if (!buf) abort();
    if (f) {
        rewind(f);
        size_t got;
        while ((got = fread(buf + n, 1, cap - n - 1, f)) > 0) {
            n += got;
            if (cap - n - 1 == 0) {
                char *g = realloc(buf, cap *= 2);
                if (!g) abort();
                buf = g;
            }
        }
    }
    buf[n] = '\0';
    return buf;
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int spawn_run(spawn_result *r, const char *const *argv, double timeout_s)
{
    r->code = -1;
    r->out = r->err = NULL;
    FILE *out = tmpfile(), *err = tmpfile();
    fflush(NULL);
    pid_t pid = out && err ? fork() : -1;
    if (pid == 0) {
        int in = open("/dev/null", O_RDONLY);
        if (in < 0 || dup2(in, 0) < 0 || dup2(fileno(out), 1) < 0 || dup2(fileno(err), 2) < 0) _exit(126);
        execvp(argv[0], (char *const *)argv);
        _exit(127);
    }
    if (pid > 0) {
        double start = now_s();
        for (;;) {
            int status = 0;
            pid_t w = waitpid(pid, &status, WNOHANG);
            if (w == pid) {
                if (WIFEXITED(status)) r->code = WEXITSTATUS(status);
                else if (WIFSIGNALED(status)) r->code = 128 + WTERMSIG(status);
                break;
            }
            if (w < 0 && errno != EINTR) break;
            if (now_s() - start > timeout_s) {
                kill(pid, SIGKILL);
                waitpid(pid, &status, 0);
                fprintf(stderr, "TIMEOUT after %.0f s: %s\n", timeout_s, argv[0]);
                r->code = -1;
                break;
            }
            struct timespec ts = {0, 5 * 1000 * 1000};
            nanosleep(&ts, NULL);
        }
    } else {
        fprintf(stderr, "cannot start %s: %s\n", argv[0], strerror(errno));
    }
    r->out = slurp(out);
    r->err = slurp(err);
    if (out) fclose(out);
    if (err) fclose(err);
    return r->code;
}

void spawn_free(spawn_result *r)
{
    free(r->out);
    free(r->err);
    r->out = r->err = NULL;
}

int spawn_which(const char *name, char *buf, size_t size)
{
    const char *path = getenv("PATH");
    if (!path || strchr(name, '/')) return 0;
    for (const char *p = path; *p;) {
        const char *colon = strchr(p, ':');
        size_t len = colon ? (size_t)(colon - p) : strlen(p);
        int n = snprintf(buf, size, "%.*s/%s", (int)(len ? len : 1), len ? p : ".", name);
        if (n > 0 && (size_t)n < size && access(buf, X_OK) == 0) return 1;
        if (!colon) break;
        p = colon + 1;
    }
    return 0;
}
