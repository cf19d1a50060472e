/* SPDX-License-Identifier: Apache-2.0 */
/* Running another program from a test: fork + execvp, standard input from
 * /dev/null, standard output and error captured, a time limit. Used by the
 * tests that drive the clvox binary or Blender (test_instances, test_blender). */
#ifndef CLVOX_TEST_SPAWN_H
#define CLVOX_TEST_SPAWN_H
#include <stddef.h>

typedef struct spawn_result {
    int code;  /* exit status; 128 + signal when killed by one; -1 past the time limit or not started */
    char *out; /* captured standard output, NUL-terminated, never NULL after spawn_run */
    char *err; /* captured standard error */
} spawn_result;

/* Runs argv[0] (a path, or a name looked up on PATH) with argv (NULL-
 * terminated) for at most timeout_s seconds (then SIGKILL). Returns r->code. */
int spawn_run(spawn_result *r, const char *const *argv, double timeout_s);
void spawn_free(spawn_result *r);
/* 1 when `name` is an executable file in a directory of PATH; its path in buf. */
int spawn_which(const char *name, char *buf, size_t size);
#endif
