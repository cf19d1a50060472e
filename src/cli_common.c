/*
 * Helpers shared by the command-line files: the one-line error contract,
 * exit codes for library statuses, strict number and option parsing, the
 * early output check. Moved here from cli.c unchanged when `clvox preview`
 * got its own file (cli_preview.c).
 */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include "cli_common.h"

#include <errno.h>
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
int fail_message(int code, const char *message)
{
    progress_erase();
    fputs("clvox: error: ", stderr);
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
            pending_break = 0;
        }
        /* control bytes (from file names or file contents) would garble the line */
        fputc(c == '\t' ? ' ' : ((unsigned char)c < 0x20 || c == 0x7f) ? '?' : c, stderr);
    }
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
    case CLVOX_ERR_MESH_EMPTY: return EXIT_INPUT;
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
