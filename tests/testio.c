/* SPDX-License-Identifier: Apache-2.0 */
/* Files and text for the tests that run programs (testio.h). */
#ifndef _XOPEN_SOURCE
#define _XOPEN_SOURCE 700 /* realpath */
#endif
#include "testio.h"
#include "test.h"

#include <dirent.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

void path_join(char *dst, size_t size, const char *dir, const char *name)
{
    int n = snprintf(dst, size, "%s/%s", dir, name);
    if (n < 0 || (size_t)n >= size) {
        fprintf(stderr, "path too long: %s/%s\n", dir, name);
        abort();
    }
}

int write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "wb");
    if (!f) return 0;
    size_t n = strlen(text);
    int ok = fwrite(text, 1, n, f) == n;
    ok &= fclose(f) == 0;
    return ok;
}

char *read_stream(FILE *f)
{
    size_t cap = 4096, n = 0;
    char *buf = malloc(cap);
    if (!buf) abort();
    if (f) {
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

char *read_all(const char *path)
{
    FILE *f = fopen(path, "rb");
    char *buf = read_stream(f);
    if (f) fclose(f);
    return buf;
}

char *read_text(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    char *buf = read_stream(f);
    fclose(f);
    return buf;
}

int file_exists(const char *path)
{
    struct stat sb;
    return lstat(path, &sb) == 0;
}

long long file_size(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0 ? (long long)sb.st_size : -1;
}

void rm_tree(const char *path)
{
    struct stat sb;
    if (lstat(path, &sb) != 0) return;
    if (S_ISDIR(sb.st_mode)) {
        DIR *d = opendir(path);
        if (d) {
            struct dirent *e;
            while ((e = readdir(d)) != NULL) {
                if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0) continue;
                char sub[PATH_MAX];
                path_join(sub, sizeof sub, path, e->d_name);
                rm_tree(sub);
            }
            closedir(d);
        }
        rmdir(path);
    } else {
        unlink(path);
    }
}

int dir_count(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) return -1;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL)
        if (strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0) n++;
    closedir(d);
    return n;
}

int dir_is_empty(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) return 0;
    int empty = 1;
    struct dirent *e;
    while ((e = readdir(d)) != NULL)
        if (strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0) {
            fprintf(stderr, "left behind: %s/%s\n", dir, e->d_name);
            empty = 0;
        }
    closedir(d);
    return empty;
}

int absolute_path(const char *path, char *out, size_t size)
{
    char *p = realpath(path, NULL);
    if (!p) return 0;
    int ok = strlen(p) < size;
    if (ok) strcpy(out, p);
    free(p);
    return ok;
}

int test_cli_dirs(const char *bin, const char *name, char *bin_abs, char *dir, char *in, char *out, char *logs)
{
    if (!absolute_path(bin, bin_abs, PATH_MAX)) {
        fprintf(stderr, "FAIL: clvox binary '%s' not found (set CLVOX_BIN)\n", bin);
        test_failed++;
        return 0;
    }
    char tmp[PATH_MAX];
    if (!absolute_path(test_tmpdir(), tmp, sizeof tmp)) {
        fprintf(stderr, "FAIL: no test directory\n");
        test_failed++;
        return 0;
    }
    path_join(dir, PATH_MAX, tmp, name);
    rm_tree(dir);
    mkdir(dir, 0777);
    path_join(in, PATH_MAX, dir, "in");
    path_join(out, PATH_MAX, dir, "out");
    path_join(logs, PATH_MAX, dir, "logs");
    mkdir(in, 0777);
    mkdir(out, 0777);
    mkdir(logs, 0777);
    return 1;
}

int count_lines(const char *s)
{
    int n = 0;
    for (; s && *s; s++) n += *s == '\n';
    return n;
}

int lines_starting(const char *text, const char *prefix)
{
    int n = 0;
    size_t len = strlen(prefix);
    for (const char *l = text; l && *l;) {
        if (strncmp(l, prefix, len) == 0) n++;
        l = strchr(l, '\n');
        if (l) l++;
    }
    return n;
}
