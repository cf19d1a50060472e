/* SPDX-License-Identifier: Apache-2.0 */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif
#include "spawn.h"
#include "testio.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

static char *slurp(FILE *f)
{
    if (f) rewind(f);
    return read_stream(f);
}

double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Waits for the child pid, polling every 5 ms: its exit status (128 +
 * signal when killed by one), -1 past timeout_s (then SIGKILL) or when it
 * cannot be waited for. o (may be NULL) says which signals to send on the
 * way and gets how many were. */
static int wait_child(pid_t pid, const char *const *argv, double timeout_s, spawn_opts *o)
{
    double start = now_s(), sent_at = 0;
    int sent = 0, status = 0, code = -1;
    for (;;) {
        pid_t w = waitpid(pid, &status, WNOHANG);
        if (w == pid) {
            if (WIFEXITED(status)) code = WEXITSTATUS(status);
            else if (WIFSIGNALED(status)) code = 128 + WTERMSIG(status);
            break;
        }
        if (w < 0 && errno != EINTR) break;
        double t = now_s() - start;
        if (o && o->signal_after > 0 && sent < o->signal_count && t >= o->signal_after && t >= sent_at + o->signal_gap &&
            (sent || !o->signal_ready || o->signal_ready(pid, o->signal_arg))) {
            kill(pid, o->signal ? o->signal : SIGINT);
            sent++;
            sent_at = t;
        }
        if (t > timeout_s) {
            kill(pid, SIGKILL);
            waitpid(pid, &status, 0);
            fprintf(stderr, "TIMEOUT after %.0f s: %s %s\n", timeout_s, argv[0], argv[1] ? argv[1] : "");
            code = -1;
            break;
        }
        struct timespec ts = {0, 5 * 1000 * 1000};
        nanosleep(&ts, NULL);
    }
    if (o) o->signals_sent = sent;
    return code;
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
        r->code = wait_child(pid, argv, timeout_s, NULL);
    } else {
        fprintf(stderr, "cannot start %s: %s\n", argv[0], strerror(errno));
    }
    r->out = slurp(out);
    r->err = slurp(err);
    if (out) fclose(out);
    if (err) fclose(err);
    return r->code;
}

int spawn_run_to(spawn_result *r, const char *const *argv, const char *out_path, const char *err_path,
                 spawn_opts *o)
{
    r->code = -1;
    o->signals_sent = 0;
    fflush(stdout);
    fflush(stderr);
    pid_t pid = fork();
    if (pid == 0) {
        /* child: only async-signal-safe calls */
        if (o->cwd && chdir(o->cwd) != 0) _exit(126);
        int in = open("/dev/null", O_RDONLY);
        int out = o->stdout_file ? open(o->stdout_file, O_WRONLY) : open(out_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        int e = open(err_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (in < 0 || out < 0 || e < 0) _exit(126);
        if (dup2(in, 0) < 0 || dup2(out, 1) < 0 || dup2(e, 2) < 0) _exit(126);
        /* default dispositions, whatever this test inherited (a background
         * job of a script starts with SIGINT ignored, and clvox keeps a
         * signal ignored that it inherited ignored) */
        struct sigaction ign, dfl;
        memset(&ign, 0, sizeof ign);
        ign.sa_handler = SIG_IGN;
        memset(&dfl, 0, sizeof dfl);
        dfl.sa_handler = SIG_DFL;
        if (sigaction(SIGINT, &dfl, NULL) != 0 || sigaction(SIGTERM, &dfl, NULL) != 0 ||
            sigaction(SIGHUP, o->ignore_sighup ? &ign : &dfl, NULL) != 0)
            _exit(126);
        if (o->fsize_limit > 0) {
            struct rlimit rl = {(rlim_t)o->fsize_limit, (rlim_t)o->fsize_limit};
            if (sigaction(SIGXFSZ, &ign, NULL) != 0 || setrlimit(RLIMIT_FSIZE, &rl) != 0) _exit(126);
        }
        if (o->env) execve(argv[0], (char *const *)argv, (char *const *)o->env);
        else execvp(argv[0], (char *const *)argv);
        _exit(127);
    }
    if (pid > 0) r->code = wait_child(pid, argv, o->timeout_s, o);
    else fprintf(stderr, "fork failed: %s\n", strerror(errno));
    r->out = read_all(out_path);
    r->err = read_all(err_path);
    return r->code;
}

const char **spawn_argv(const char *prog, const char *const *args)
{
    size_t na = 0;
    while (args[na]) na++;
    const char **argv = malloc((na + 2) * sizeof *argv);
    if (!argv) abort();
    argv[0] = prog;
    for (size_t i = 0; i < na; i++) argv[i + 1] = args[i];
    argv[na + 1] = NULL;
    return argv;
}

void spawn_log_paths(const char *logs, unsigned id, char *out_path, char *err_path)
{
    char name[32];
    snprintf(name, sizeof name, "run%03u.out", id);
    path_join(out_path, PATH_MAX, logs, name);
    snprintf(name, sizeof name, "run%03u.err", id);
    path_join(err_path, PATH_MAX, logs, name);
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
