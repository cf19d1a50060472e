/* SPDX-License-Identifier: Apache-2.0 */
/* Files and text for the tests that run programs and look at what they
 * leave (test_batch, test_cli, test_blender, test_instances): one copy of
 * each helper (testio.c). */
#ifndef CLVOX_TEST_IO_H
#define CLVOX_TEST_IO_H
#include <stddef.h>
#include <stdio.h>

/* dir/name into dst; aborts when it does not fit (a test setup error). */
void path_join(char *dst, size_t size, const char *dir, const char *name);
/* 1 when the whole text was written to path (created or truncated). */
int write_text(const char *path, const char *text);
/* The rest of f, NUL-terminated (malloc'ed; "" when f is NULL). Aborts when
 * memory runs out. */
char *read_stream(FILE *f);
/* The whole file, NUL-terminated (malloc'ed); "" when it cannot be opened. */
char *read_all(const char *path);
/* The whole file, NUL-terminated (malloc'ed); NULL when it cannot be opened. */
char *read_text(const char *path);
/* Whether path exists (a dangling link counts: lstat). */
int file_exists(const char *path);
/* Its size in bytes, -1 when it cannot be stat'ed. */
long long file_size(const char *path);
/* Removes path and, when it is a directory, all below it. */
void rm_tree(const char *path);
/* Entries of dir besides . and ..; -1 when it cannot be opened. */
int dir_count(const char *dir);
/* 1 when dir can be opened and is empty; else 0, each entry left reported
 * on stderr. */
int dir_is_empty(const char *dir);
/* path resolved (realpath) into out; 0 when it does not exist or does not
 * fit. */
int absolute_path(const char *path, char *out, size_t size);
/* The setup of a test that runs the clvox binary: bin_abs = bin's absolute
 * path; dir = <test directory>/<name>, made afresh, with in/, out/ and
 * logs/ in it (each PATH_MAX bytes). 0, a failure counted and reported,
 * when the binary or the test directory is missing. */
int test_cli_dirs(const char *bin, const char *name, char *bin_abs, char *dir, char *in, char *out, char *logs);
/* Lines of s (its '\n'); 0 for NULL. */
int count_lines(const char *s);
/* Lines of text that start with prefix. */
int lines_starting(const char *text, const char *prefix);
#endif
