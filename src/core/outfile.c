/* SPDX-License-Identifier: Apache-2.0 */
/* Output files named only when complete, shared by every volume writer
 * (write_exr.c, write_npy.c, write_nrrd.c, write_binvox.c):
 *  - Linux: open(dir, O_TMPFILE), a file without a name: no exit, crash or
 *    kill -9 can leave it behind. clvox__outfile_finish, once the writer has
 *    checked its data, syncs it and links it to `path` (linkat through
 *    /proc/self/fd) when nothing is there, else to a short unique name in the
 *    directory that is renamed over `path` at once.
 *  - Where the file system has no O_TMPFILE (EOPNOTSUPP, EISDIR, EINVAL) or
 *    /proc is missing: a named temporary ".clvox-<pid>-<n>.tmp" (O_EXCL; short,
 *    so every valid output name works), renamed to `path` by finish and
 *    unlinked on every other exit; only a kill -9 can leave it.
 * Only regular files are replaced: anything else at `path` (directory,
 * symbolic link, device node, FIFO, socket) is refused at create and again
 * just before the rename; a symbolic link is neither replaced nor written
 * through. A set of files (npy, NRRD channels) is named by
 * clvox__outfile_finish_set, below: whole or not at all. */
#if defined(__linux__) && !defined(_GNU_SOURCE)
#define _GNU_SOURCE /* O_TMPFILE, AT_EMPTY_PATH */
#endif
#include "internal.h"
#include "io/output_set.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

int clvox__exr_no_tmpfile;
int clvox__outset_fail_at;

clvox_status clvox__outfile_check_target(clvox_context *ctx, const char *path)
{
    struct stat sb;
    if (lstat(path, &sb) != 0 || S_ISREG(sb.st_mode)) return CLVOX_OK; /* missing: the create tells */
    if (S_ISDIR(sb.st_mode)) return clvox__fail(ctx, CLVOX_ERR_IO, "cannot write '%s': it is a directory", path);
    if (S_ISLNK(sb.st_mode))
        return clvox__fail(ctx, CLVOX_ERR_IO,
                           "cannot write '%s': it is a symbolic link (clvox replaces only regular files)", path);
    return clvox__fail(ctx, CLVOX_ERR_IO,
                       "cannot write '%s': it is not a regular file (a device, FIFO or socket; clvox replaces only "
                       "regular files)",
                       path);
}

/* "<dir>/.clvox-<pid>-<n>.tmp": at most 30 bytes past the directory. */
static int temp_name(char *buf, size_t size, const char *dir)
{
    static unsigned counter;
    unsigned k = __atomic_fetch_add(&counter, 1u, __ATOMIC_RELAXED);
    int n = snprintf(buf, size, "%s/.clvox-%ld-%u.tmp", dir, (long)getpid(), k);
    return n > 0 && (size_t)n < size;
}

clvox_status clvox__outfile_create(clvox__outfile *f, clvox_context *ctx, const char *path)
{
    memset(f, 0, sizeof *f);
    f->ctx = ctx;
    f->fd = -1;
    clvox_status st = clvox__outfile_check_target(ctx, path);
    if (st != CLVOX_OK) return st;
    f->path = strdup(path);
    if (!f->path) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    const char *slash = strrchr(path, '/');
    size_t dn = !slash ? 1 : slash == path ? 1 : (size_t)(slash - path);
    f->dir = malloc(dn + 1);
    if (!f->dir) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    memcpy(f->dir, !slash ? "." : path, dn);
    f->dir[dn] = '\0';
#ifdef O_TMPFILE
    if (!clvox__exr_no_tmpfile) {
        int fd = open(f->dir, O_TMPFILE | O_WRONLY | O_CLOEXEC, 0666);
        if (fd >= 0) {
            char proc[64];
            snprintf(proc, sizeof proc, "/proc/self/fd/%d", fd);
            if (access(proc, F_OK) == 0) { /* it can be given a name at the end */
                f->fd = fd;
                f->unnamed = 1;
                return CLVOX_OK;
            }
            close(fd);
        } else if (errno != EOPNOTSUPP && errno != EISDIR && errno != EINVAL) {
            return clvox__fail(ctx, CLVOX_ERR_IO, "cannot create output file '%s': %s", path, strerror(errno));
        }
    }
#endif
    size_t n = dn + 64;
    f->tmp = malloc(n);
    if (!f->tmp) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    for (int attempt = 0; attempt < 100; attempt++) {
        if (!temp_name(f->tmp, n, f->dir)) break;
        f->fd = open(f->tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (f->fd >= 0) return CLVOX_OK;
        if (errno != EEXIST) {
            int e = errno;
            free(f->tmp);
            f->tmp = NULL; /* nothing to unlink */
            return clvox__fail(ctx, CLVOX_ERR_IO, "cannot create output file '%s': %s", path, strerror(e));
        }
    }
    free(f->tmp);
    f->tmp = NULL;
    return clvox__fail(ctx, CLVOX_ERR_IO, "cannot create a temporary file next to '%s'", path);
}

clvox_status clvox__outfile_write(clvox__outfile *f, const void *data, size_t size)
{
    const uint8_t *p = data;
    while (size > 0) {
        size_t n = size > (1u << 30) ? (1u << 30) : size;
        ssize_t got = write(f->fd, p, n);
        if (got < 0 && errno == EINTR) continue;
        if (got <= 0)
            return clvox__fail(f->ctx, CLVOX_ERR_IO, "writing '%s' failed: %s", f->path,
                               got < 0 ? strerror(errno) : "nothing written");
        p += got;
        size -= (size_t)got;
        f->written += (uint64_t)got;
    }
    return CLVOX_OK;
}

clvox_status clvox__outfile_pwrite(clvox__outfile *f, const void *data, size_t size, uint64_t offset)
{
    const uint8_t *p = data;
    while (size > 0) {
        size_t n = size > (1u << 30) ? (1u << 30) : size;
        ssize_t got = pwrite(f->fd, p, n, (off_t)offset);
        if (got < 0 && errno == EINTR) continue;
        if (got <= 0)
            return clvox__fail(f->ctx, CLVOX_ERR_IO, "writing '%s' failed: %s", f->path,
                               got < 0 ? strerror(errno) : "nothing written");
        p += got;
        size -= (size_t)got;
        offset += (uint64_t)got;
    }
    return CLVOX_OK;
}

#ifdef O_TMPFILE
/* Gives the unnamed file fd the name `name` (fails with EEXIST if taken). */
static int link_unnamed(int fd, const char *name)
{
    char proc[64];
    snprintf(proc, sizeof proc, "/proc/self/fd/%d", fd);
    if (linkat(AT_FDCWD, proc, AT_FDCWD, name, AT_SYMLINK_FOLLOW) == 0) return 0;
    if (errno != ENOENT) return -1;
    return linkat(fd, "", AT_FDCWD, name, AT_EMPTY_PATH); /* no /proc: needs CAP_DAC_READ_SEARCH */
}
#endif

/* Puts the complete, synced file at f->path. On success nothing is left to unlink. */
static clvox_status commit(clvox__outfile *f)
{
    clvox_status st = clvox__outfile_check_target(f->ctx, f->path); /* again: something may have appeared */
    if (st != CLVOX_OK) return st;
#ifdef O_TMPFILE
    if (f->unnamed) {
        if (link_unnamed(f->fd, f->path) == 0) return CLVOX_OK; /* nothing was there */
        if (errno != EEXIST)
            return clvox__fail(f->ctx, CLVOX_ERR_IO, "cannot create '%s': %s", f->path, strerror(errno));
        /* replace the existing file: a unique name, renamed over it at once */
        size_t n = strlen(f->dir) + 64;
        f->tmp = malloc(n);
        if (!f->tmp) return clvox__fail(f->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
        int linked = 0;
        for (int attempt = 0; attempt < 100 && !linked; attempt++) {
            if (!temp_name(f->tmp, n, f->dir)) break;
            if (link_unnamed(f->fd, f->tmp) == 0) linked = 1;
            else if (errno != EEXIST) break;
        }
        if (!linked) {
            int e = errno;
            free(f->tmp);
            f->tmp = NULL;
            return clvox__fail(f->ctx, CLVOX_ERR_IO, "cannot replace '%s': %s", f->path, strerror(e));
        }
    }
#endif
    if (rename(f->tmp, f->path) != 0)
        return clvox__fail(f->ctx, CLVOX_ERR_IO, "cannot replace '%s': %s", f->path, strerror(errno));
    free(f->tmp);
    f->tmp = NULL; /* renamed: nothing to unlink */
    return CLVOX_OK;
}

clvox_status clvox__outfile_finish(clvox__outfile *f, uint64_t *bytes)
{
    if (bytes) *bytes = 0;
    clvox_context *ctx = f->ctx;
    clvox_status st;
    struct stat sb;
    if (fstat(f->fd, &sb) != 0 || sb.st_size <= 0) {
        st = clvox__fail(ctx, CLVOX_ERR_IO, "writing '%s' failed: the file being written is empty", f->path);
        clvox__outfile_discard(f);
        return st;
    }
    /* On disk before it gets its name: a crash never leaves a partial file at `path`. */
    if (fdatasync(f->fd) != 0) {
        st = clvox__fail(ctx, CLVOX_ERR_IO, "writing '%s' failed: %s", f->path, strerror(errno));
        clvox__outfile_discard(f);
        return st;
    }
    if (!f->unnamed) { /* named: closed before the rename (an unnamed file is linked through its fd) */
        int fd = f->fd;
        f->fd = -1;
        if (close(fd) != 0) {
            st = clvox__fail(ctx, CLVOX_ERR_IO, "writing '%s' failed: %s", f->path, strerror(errno));
            clvox__outfile_discard(f);
            return st;
        }
    }
    st = commit(f);
    if (st != CLVOX_OK) {
        clvox__outfile_discard(f);
        return st;
    }
    if (f->fd >= 0) {
        int fd = f->fd;
        f->fd = -1;
        close(fd); /* synced and named: nothing is lost if close reports an error now */
    }
    if (bytes) *bytes = (uint64_t)sb.st_size;
    clvox__outfile_discard(f); /* frees the names; nothing left to remove */
    return CLVOX_OK;
}

void clvox__outfile_discard(clvox__outfile *f)
{
    if (!f || !f->ctx) return; /* never created, or already discarded */
    if (f->fd >= 0) close(f->fd);
    f->fd = -1;
    if (f->tmp) unlink(f->tmp);
    free(f->tmp);
    free(f->dir);
    free(f->path);
    f->tmp = f->dir = f->path = NULL;
    f->ctx = NULL;
}

/* ---- sets of files (write_raster.c: npy and NRRD channels with their marker) ----
 *
 * A set replaces the files of the previous set as a whole or not at all:
 *  1. every member is complete, non-empty and synced, and every name is free
 *     or a regular file, before any name is touched;
 *  2. each member gets a hidden name in its directory (.clvox-<pid>-<n>.tmp);
 *  3. the members are renamed into place in order, the marker last; before a
 *     member replaces an old file, the old file gets a second hidden name
 *     (a hard link), so that a failure at member k renames the old files of
 *     members 0..k-1 back; a member that replaced nothing is unlinked only
 *     while it is still this run's file (same device and inode). Where the
 *     file system has no hard links, an old file cannot be restored: the new
 *     member stays, and the old marker, not renamed, no longer agrees with it
 *     (output_set.c says so to every reader).
 * Nothing that this run did not create is ever unlinked. A kill in step 3 can
 * leave hidden .clvox-*.tmp files and a mixed set whose marker disagrees. */

typedef struct set_entry {
    dev_t dev;
    ino_t ino;
    char *backup; /* hidden second name of the old file, or NULL */
    int had_old;  /* something (a regular file) was replaced */
} set_entry;

/* Gives the complete, synced file a hidden name (f->tmp) in its directory. */
static clvox_status stage(clvox__outfile *f)
{
#ifdef O_TMPFILE
    if (f->unnamed) {
        size_t n = strlen(f->dir) + 64;
        f->tmp = malloc(n);
        if (!f->tmp) return clvox__fail(f->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
        for (int attempt = 0; attempt < 100; attempt++) {
            if (!temp_name(f->tmp, n, f->dir)) break;
            if (link_unnamed(f->fd, f->tmp) == 0) return CLVOX_OK;
            if (errno != EEXIST) break;
        }
        int e = errno;
        free(f->tmp);
        f->tmp = NULL;
        return clvox__fail(f->ctx, CLVOX_ERR_IO, "cannot name '%s': %s", f->path, strerror(e));
    }
#endif
    int fd = f->fd; /* named already: closed before the rename */
    f->fd = -1;
    if (close(fd) != 0) return clvox__fail(f->ctx, CLVOX_ERR_IO, "writing '%s' failed: %s", f->path, strerror(errno));
    return CLVOX_OK;
}

/* A hidden second name for the old file at `path` (NULL: none could be made). */
static char *backup_of(const clvox__outfile *f)
{
    size_t n = strlen(f->dir) + 64;
    char *b = malloc(n);
    if (!b) return NULL;
    for (int attempt = 0; attempt < 100; attempt++) {
        if (!temp_name(b, n, f->dir)) break;
        if (link(f->path, b) == 0) return b;
        if (errno != EEXIST) break;
    }
    free(b);
    return NULL;
}

clvox_status clvox__outfile_finish_set(clvox__outfile *const *files, size_t n)
{
    if (n == 0) return CLVOX_OK;
    clvox_context *ctx = files[0]->ctx;
    clvox_status st = CLVOX_OK;
    set_entry *e = calloc(n, sizeof *e);
    if (!e) st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    /* 1. complete and synced; every name free or a regular file */
    for (size_t i = 0; i < n && st == CLVOX_OK; i++) {
        clvox__outfile *f = files[i];
        struct stat sb;
        if (fstat(f->fd, &sb) != 0 || sb.st_size <= 0)
            st = clvox__fail(ctx, CLVOX_ERR_IO, "writing '%s' failed: the file being written is empty", f->path);
        else if (fdatasync(f->fd) != 0)
            st = clvox__fail(ctx, CLVOX_ERR_IO, "writing '%s' failed: %s", f->path, strerror(errno));
        else
            e[i].dev = sb.st_dev, e[i].ino = sb.st_ino;
    }
    for (size_t i = 0; i < n && st == CLVOX_OK; i++) st = clvox__outfile_check_target(ctx, files[i]->path);
    /* 2. hidden names */
    for (size_t i = 0; i < n && st == CLVOX_OK; i++) st = stage(files[i]);
    /* 3. into place, the marker last */
    size_t placed = 0;
    for (; placed < n && st == CLVOX_OK; placed++) {
        clvox__outfile *f = files[placed];
        set_entry *s = &e[placed];
        st = clvox__outfile_check_target(ctx, f->path); /* again: something may have appeared */
        if (st != CLVOX_OK) break;
        struct stat sb;
        s->had_old = lstat(f->path, &sb) == 0;
        if (s->had_old) s->backup = backup_of(f);
        int failed = clvox__outset_fail_at == (int)placed + 1 ? (errno = EIO, 1) : rename(f->tmp, f->path) != 0;
        if (failed) {
            st = clvox__fail(ctx, CLVOX_ERR_IO, "cannot replace '%s': %s", f->path, strerror(errno));
            if (s->backup) unlink(s->backup); /* a second name of the old file, which is still in place */
            free(s->backup);
            s->backup = NULL;
            break;
        }
        free(f->tmp);
        f->tmp = NULL; /* renamed: nothing to unlink */
    }
    if (st != CLVOX_OK) { /* put back what the placed members replaced */
        const char *kept = NULL;
        while (placed-- > 0) {
            clvox__outfile *f = files[placed];
            set_entry *s = &e[placed];
            struct stat sb;
            if (s->backup) {
                if (rename(s->backup, f->path) == 0) {
                    free(s->backup);
                    s->backup = NULL;
                } else if (!kept) {
                    kept = s->backup; /* the old file's only name now: kept, and said */
                }
            } else if (!s->had_old && lstat(f->path, &sb) == 0 && sb.st_dev == s->dev && sb.st_ino == s->ino) {
                unlink(f->path); /* this run's file at a name that was free */
            }
        }
        if (kept) {
            const char *msg = clvox_context_error(ctx);
            char first[512];
            snprintf(first, sizeof first, "%s", msg ? msg : "");
            clvox__fail(ctx, st, "%s (the old file is kept as '%s')", first, kept);
        }
    }
    for (size_t i = 0; e && i < n; i++) {
        if (st == CLVOX_OK && e[i].backup) unlink(e[i].backup); /* the old file's second name */
        free(e[i].backup);
    }
    free(e);
    for (size_t i = 0; i < n; i++) clvox__outfile_discard(files[i]); /* closes; unlinks hidden names not placed */
    return st;
}

/* ---- the public names (clvox.h): a caller's own files, and --skip-existing ---- */

struct clvox_output_file {
    clvox__outfile f;
};

clvox_status clvox_output_file_create(clvox_context *ctx, const char *path, clvox_output_file **out)
{
    if (!out) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_output_file_create: out is NULL");
    *out = NULL;
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT; /* the file's messages go to it */
    if (!path || !*path) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_output_file_create: no path");
    clvox_output_file *x = calloc(1, sizeof *x);
    if (!x) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    clvox_status st = clvox__outfile_create(&x->f, ctx, path);
    if (st != CLVOX_OK) {
        clvox__outfile_discard(&x->f);
        free(x);
        return st;
    }
    *out = x;
    return CLVOX_OK;
}

int clvox_output_file_fd(const clvox_output_file *file) { return file ? file->f.fd : -1; }

clvox_status clvox_output_file_commit(clvox_output_file *file, uint64_t *bytes)
{
    if (bytes) *bytes = 0;
    if (!file) return CLVOX_ERR_INVALID_ARGUMENT;
    clvox_status st = clvox__outfile_finish(&file->f, bytes); /* discards it on failure */
    free(file);
    return st;
}

void clvox_output_file_discard(clvox_output_file *file)
{
    if (!file) return;
    clvox__outfile_discard(&file->f);
    free(file);
}

int clvox_output_complete(const char *path, char *why, size_t why_size)
{
    if (!path || !*path) {
        if (why && why_size) snprintf(why, why_size, "no path");
        return 0;
    }
    return clvox__output_complete(path, why, why_size);
}

int clvox_npy_set_complete(const char *json, const char *member, char *why, size_t why_size)
{
    if (!json || !*json) {
        if (why && why_size) snprintf(why, why_size, "no path");
        return 0;
    }
    return clvox__npy_set_complete(json, member, why, why_size);
}
