/* SPDX-License-Identifier: Apache-2.0 */
/* Running another program from a test: fork + execvp, standard input from
 * /dev/null, standard output and error captured, a time limit. Used by the
 * tests that drive the clvox binary or Blender (test_batch, test_cli,
 * test_instances, test_blender). */
#ifndef CLVOX_TEST_SPAWN_H
#define CLVOX_TEST_SPAWN_H
#include <stddef.h>
#include <sys/types.h>

typedef struct spawn_result {
    int code;  /* exit status; 128 + signal when killed by one; -1 past the time limit or not started */
    char *out; /* captured standard output, NUL-terminated, never NULL after spawn_run */
    char *err; /* captured standard error */
} spawn_result;

/* Runs argv[0] (a path, or a name looked up on PATH) with argv (NULL-
 * terminated) for at most timeout_s seconds (then SIGKILL). Returns r->code. */
int spawn_run(spawn_result *r, const char *const *argv, double timeout_s);
void spawn_free(spawn_result *r);

/* How spawn_run_to runs a program. Zero is the default of every field but
 * timeout_s (and signal_count, when signal_after is set). */
typedef struct spawn_opts {
    const char *cwd;          /* the child's working directory (NULL: ours) */
    const char *const *env;   /* the child's environment (NULL: ours, and argv[0] looked up on PATH) */
    const char *stdout_file;  /* when set, the child's stdout (an existing file, e.g. /dev/full) */
    int ignore_sighup;        /* the child starts with SIGHUP ignored (as under nohup) */
    long fsize_limit;         /* > 0: RLIMIT_FSIZE, SIGXFSZ ignored (a write past it fails with EFBIG) */
    double timeout_s;         /* then SIGKILL, code -1 */
    /* signal_after > 0: `signal` (0: SIGINT) sent signal_count times,
     * signal_gap seconds apart, the first once signal_after and signal_gap
     * seconds have passed and signal_ready (NULL: no condition) says 1 */
    double signal_after, signal_gap;
    int signal, signal_count;
    int (*signal_ready)(pid_t pid, void *arg);
    void *signal_arg;
    int signals_sent; /* set: how many were sent */
} spawn_opts;

/* Runs argv[0] with argv, stdin from /dev/null, stdout and stderr into
 * out_path and err_path (created or truncated), SIGINT, SIGTERM and SIGHUP
 * at their default dispositions whatever this process inherited (clvox
 * keeps a signal ignored that it inherited ignored); r->out and r->err get
 * the files' contents ("" when missing). Returns r->code. */
int spawn_run_to(spawn_result *r, const char *const *argv, const char *out_path, const char *err_path,
                 spawn_opts *o);

/* prog followed by args (NULL-terminated): a malloc'ed argv (strings
 * borrowed) for spawn_run_to. */
const char **spawn_argv(const char *prog, const char *const *args);
/* Where run number id keeps its output: logs/runNNN.out and .err (each
 * PATH_MAX bytes). */
void spawn_log_paths(const char *logs, unsigned id, char *out_path, char *err_path);

/* Seconds on the monotonic clock. */
double now_s(void);
/* 1 when `name` is an executable file in a directory of PATH; its path in buf. */
int spawn_which(const char *name, char *buf, size_t size);
#endif
