/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Helpers shared by the command-line files: the one-line error contract,
 * exit codes for library statuses, strict number and option parsing, the
 * early output check, stdout's end (cli_finish_stdout, for every command,
 * clvox batch included), and the sizes, volumes and lines the summaries print.
 * Output files and regular-file reads are the library's (clvox_output_file_*,
 * clvox_open_regular_read): the CLI keeps no copy of them.
 * Moved here from cli.c unchanged when `clvox preview` got its own file
 * (cli_preview.c), the summary helpers when cli.c was split by stage.
 */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include "cli_common.h"
#include "cli_vox.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* The progress line, if one is on screen, is erased before anything else
 * is written to stderr. */
int g_progress_line_len;

void progress_erase(void)
{
    if (g_progress_line_len > 0) {
        fprintf(stderr, "\r%*s\r", g_progress_line_len, "");
        fflush(stderr);
        g_progress_line_len = 0;
    }
}

/* Prints "clvox: error: <message>" as exactly one line (newlines in the
 * message, e.g. a kernel build log, become " | "; other control bytes "?")
 * and returns `code`. */
const char *g_fail_prefix;
static char g_last_error[1024];

const char *cli_last_error(void) { return g_last_error; }

int fail_message(int code, const char *message)
{
    /* A call that a SIGINT/SIGTERM/SIGHUP interrupted (EINTR) failed: that
     * is the cancellation the signal asked for, not an input or output error. */
    if (code != EXIT_OK && code != EXIT_CANCELLED && cli_interrupted() && message && strstr(message, strerror(EINTR))) {
        code = EXIT_CANCELLED;
        message = "cancelled";
    }
    progress_erase();
    fputs("clvox: error: ", stderr);
    if (g_fail_prefix && *g_fail_prefix) {
        for (const char *p = g_fail_prefix; *p; p++)
            fputc(((unsigned char)*p < 0x20 || *p == 0x7f) ? '?' : *p, stderr);
        fputs(": ", stderr);
    }
    size_t kept = 0;
    const char *s = message && *message ? message : "unknown error";
    size_t n = strlen(s);
    while (n > 0 && (s[n - 1] == '\n' || s[n - 1] == '\r' || s[n - 1] == ' ')) n--;
    int pending_break = 0;
    for (size_t i = 0; i < n; i++) {
        char c = s[i];
        if (c == '\n' || c == '\r') {
            pending_break = 1;
            continue;
        }
        if (pending_break) {
            fputs(" | ", stderr);
            if (kept + 3 < sizeof g_last_error) {
                memcpy(g_last_error + kept, " | ", 3);
                kept += 3;
            }
            pending_break = 0;
        }
        /* control bytes (from file names or file contents) would garble the line */
        char out = c == '\t' ? ' ' : ((unsigned char)c < 0x20 || c == 0x7f) ? '?' : c;
        fputc(out, stderr);
        if (kept + 1 < sizeof g_last_error) g_last_error[kept++] = out;
    }
    g_last_error[kept] = '\0';
    fputc('\n', stderr);
    return code;
}

int fail(int code, const char *fmt, ...)
{
    char buf[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    return fail_message(code, buf);
}

int exit_code_for(clvox_status st, role r)
{
    switch (st) {
    case CLVOX_OK: return EXIT_OK;
    case CLVOX_ERR_INVALID_ARGUMENT: return EXIT_USAGE;
    case CLVOX_ERR_IO: return r == ROLE_INPUT ? EXIT_INPUT : r == ROLE_OUTPUT ? EXIT_OUTPUT : EXIT_RUNTIME;
    case CLVOX_ERR_EXR: return r == ROLE_INPUT ? EXIT_INPUT : EXIT_RUNTIME;
    case CLVOX_ERR_MESH_FORMAT:
    case CLVOX_ERR_MESH_INVALID:
    case CLVOX_ERR_MESH_EMPTY:
    case CLVOX_ERR_PALETTE_FORMAT: return EXIT_INPUT;
    case CLVOX_ERR_GRID: return EXIT_GRID;
    case CLVOX_ERR_NO_DEVICE: return EXIT_NO_DEVICE;
    case CLVOX_ERR_CANCELLED: return EXIT_CANCELLED;
    case CLVOX_ERR_OUT_OF_MEMORY:
    case CLVOX_ERR_OPENCL:
    case CLVOX_ERR_KERNEL_BUILD:
    case CLVOX_ERR_INTERNAL:
    case CLVOX_STATUS_COUNT: break;
    }
    return EXIT_RUNTIME;
}

/* Reports a library failure: the context's message, else the status string. */
int fail_status(const clvox_context *ctx, clvox_status st, role r)
{
    const char *msg = ctx ? clvox_context_error(ctx) : "";
    if (st == CLVOX_ERR_CANCELLED) return fail_message(EXIT_CANCELLED, msg && *msg ? msg : "cancelled");
    return fail_message(exit_code_for(st, r), msg && *msg ? msg : clvox_status_string(st));
}

/* Returns NULL on success, else why `s` is not acceptable. */
const char *parse_u32(const char *s, uint32_t min, uint32_t *out, const char **end_out)
{
    if (!s || *s == '\0') return "empty value";
    if (*s == '-') return "must not be negative";
    if (*s < '0' || *s > '9') return "not a non-negative integer";
    errno = 0;
    char *end = NULL;
    unsigned long long v = strtoull(s, &end, 10);
    if (end == s) return "not a non-negative integer";
    if (end_out) *end_out = end;
    else if (*end != '\0') return "not a non-negative integer";
    if (errno == ERANGE || v > UINT32_MAX) return "too large";
    if (v < min) return min == 1 ? "must be at least 1" : "too small";
    *out = (uint32_t)v;
    return NULL;
}

int usage_error(const char *fmt, ...)
{
    char buf[768];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    return fail(EXIT_USAGE, "%s (see clvox --help)", buf);
}

/* Matches argv[*i] against a short and/or long option that takes a value;
 * accepts "-r 16", "-r16", "--opt 16" and "--opt=16". Returns 1 on a match
 * (*missing = 1 when the value is absent), 0 otherwise. */
int match_value(int argc, char **argv, int *i, const char *short_name, const char *long_name, const char **value,
                int *missing)
{
    const char *a = argv[*i];
    *missing = 0;
    if (short_name && strncmp(a, short_name, 2) == 0 && a[1] != '-') {
        if (a[2] != '\0') {
            *value = a + 2;
            return 1;
        }
    } else if (long_name) {
        size_t n = strlen(long_name);
        if (strncmp(a, long_name, n) != 0) return 0;
        if (a[n] == '=') {
            *value = a + n + 1;
            return 1;
        }
        if (a[n] != '\0') return 0; /* --padding is not --pad */
    } else {
        return 0;
    }
    if (*i + 1 >= argc) {
        *missing = 1;
        return 1;
    }
    *value = argv[++*i];
    return 1;
}

/* Fails early (creating nothing) when the output can not possibly be written. */
int check_output(const char *path)
{
    struct stat sb;
    if (stat(path, &sb) == 0 && S_ISDIR(sb.st_mode)) return fail(EXIT_OUTPUT, "cannot write '%s': it is a directory", path);
    if (lstat(path, &sb) == 0 && !S_ISREG(sb.st_mode)) {
        if (S_ISLNK(sb.st_mode))
            return fail(EXIT_OUTPUT, "cannot write '%s': it is a symbolic link (clvox replaces only regular files)",
                        path);
        return fail(EXIT_OUTPUT,
                    "cannot write '%s': it is not a regular file (a device, FIFO or socket; clvox replaces only "
                    "regular files)",
                    path);
    }
    size_t len = strlen(path);
    if (len > 0 && path[len - 1] == '/') return fail(EXIT_OUTPUT, "cannot write '%s': not a file name", path);

    char dir[4096];
    const char *slash = strrchr(path, '/');
    if (!slash) snprintf(dir, sizeof dir, ".");
    else if (slash == path) snprintf(dir, sizeof dir, "/");
    else if ((size_t)(slash - path) >= sizeof dir) return fail(EXIT_OUTPUT, "cannot write '%s': path too long", path);
    else snprintf(dir, sizeof dir, "%.*s", (int)(slash - path), path);

    if (stat(dir, &sb) != 0)
        return fail(EXIT_OUTPUT, "cannot write '%s': directory '%s': %s", path, dir, strerror(errno));
    if (!S_ISDIR(sb.st_mode)) return fail(EXIT_OUTPUT, "cannot write '%s': '%s' is not a directory", path, dir);
    if (access(dir, W_OK | X_OK) != 0)
        return fail(EXIT_OUTPUT, "cannot write '%s': directory '%s': %s", path, dir, strerror(errno));
    return EXIT_OK;
}

int make_parent_dirs(const char *path)
{
    const char *slash = strrchr(path, '/');
    if (!slash || slash == path) return EXIT_OK; /* the current directory, or / */
    size_t n = (size_t)(slash - path);
    char *dir = malloc(n + 1);
    if (!dir) return fail(EXIT_RUNTIME, "out of memory");
    memcpy(dir, path, n);
    dir[n] = '\0';
    int rc = EXIT_OK;
    for (size_t i = 1; i <= n && rc == EXIT_OK; i++) {
        if ((i < n && dir[i] != '/') || dir[i - 1] == '/') continue; /* inside a name, or "//" */
        char c = dir[i];
        dir[i] = '\0';
        struct stat sb;
        if (stat(dir, &sb) != 0) {
            if (errno != ENOENT)
                rc = fail(EXIT_OUTPUT, "cannot write '%s': directory '%s': %s", path, dir, strerror(errno));
            else if (mkdir(dir, 0777) != 0 && errno != EEXIST) /* EEXIST: made meanwhile (another shard) */
                rc = fail(EXIT_OUTPUT, "cannot write '%s': cannot create directory '%s': %s", path, dir,
                          strerror(errno));
            else if (stat(dir, &sb) != 0) /* a dangling symbolic link, say */
                rc = fail(EXIT_OUTPUT, "cannot write '%s': '%s' exists and is not a directory", path, dir);
        }
        if (rc == EXIT_OK && !S_ISDIR(sb.st_mode))
            rc = fail(EXIT_OUTPUT, "cannot write '%s': '%s' exists and is not a directory", path, dir);
        dir[i] = c;
    }
    free(dir);
    return rc;
}

int has_channel(const char *list, const char *name)
{
    size_t n = strlen(name);
    for (const char *p = list; p && *p;) {
        const char *comma = strchr(p, ',');
        size_t len = comma ? (size_t)(comma - p) : strlen(p);
        if (len == n && strncmp(p, name, n) == 0) return 1;
        p = comma ? comma + 1 : NULL;
    }
    return 0;
}

/* ---- stdout (every command ends with cli_finish_stdout) ---- */

/* fflush(stdout), keeping the first failure's errno (a later flush of an
 * emptied buffer succeeds and would lose it). */
static int g_stdout_errno;
void cli_flush_stdout(void)
{
    if (fflush(stdout) != 0 && !g_stdout_errno) g_stdout_errno = errno ? errno : EIO;
}

int cli_stdout_failed(void) { return g_stdout_errno != 0; }

int cli_finish_stdout(int rc, const char *written)
{
    cli_flush_stdout();
    if (!g_stdout_errno && !ferror(stdout)) return rc;
    if (rc != EXIT_OK) return rc;
    const char *why = g_stdout_errno ? strerror(g_stdout_errno) : "write error";
    if (written)
        return fail(EXIT_RUNTIME, "the volume was written to '%s', but the summary could not be written to stdout: %s",
                    written, why);
    return fail(EXIT_RUNTIME, "cannot write to stdout: %s", why);
}

/* ---- what the summaries print (clvox MESH, info, --list-devices) ---- */

void format_bytes(uint64_t bytes, char *buf, size_t size)
{
    static const char *const units[] = {"bytes", "KiB", "MiB", "GiB", "TiB"};
    if (bytes < 1024) {
        snprintf(buf, size, "%llu bytes", (unsigned long long)bytes);
        return;
    }
    double v = (double)bytes;
    int u = 0;
    while (v >= 1024.0 && u < 4) {
        v /= 1024.0;
        u++;
    }
    snprintf(buf, size, "%.2f %s", v, units[u]);
}

/* count voxels of size h[0] x h[1] x h[2]: 0 for no voxel even when the
 * voxel volume overflows (no 0 * inf = nan). */
double voxels_volume(double count, const double h[3])
{
    return count == 0 ? 0.0 : count * h[0] * h[1] * h[2];
}

/* A volume for the summary: %.*g, or words when it overflowed a double. */
void format_volume(double v, int digits, char *buf, size_t size)
{
    if (isfinite(v)) snprintf(buf, size, "%.*g", digits, v);
    else snprintf(buf, size, "%s", "(too large for a double)");
}

const char *path_basename(const char *path)
{
    const char *slash = strrchr(path, '/');
    return slash ? slash + 1 : path;
}

int is_readable_file(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0 && S_ISREG(sb.st_mode) && access(path, R_OK) == 0;
}

void print_grid_line(const uint32_t dims[3], const double origin[3], const double h[3])
{
    char size[96];
    if (h[0] == h[1] && h[1] == h[2]) snprintf(size, sizeof size, "voxel %.6g", h[0]);
    else snprintf(size, sizeof size, "voxel %.6g x %.6g x %.6g", h[0], h[1], h[2]);
    printf(LABEL "%u x %u x %u voxels, %s, origin (%.6g, %.6g, %.6g)\n", "grid", (unsigned)dims[0],
           (unsigned)dims[1], (unsigned)dims[2], size, origin[0], origin[1], origin[2]);
}

void print_filled_line(uint64_t filled, uint64_t total)
{
    double pct = total ? 100.0 * (double)filled / (double)total : 0.0;
    printf(LABEL "%llu of %llu voxels (%.2f %%)\n", "filled", (unsigned long long)filled,
           (unsigned long long)total, pct);
}
