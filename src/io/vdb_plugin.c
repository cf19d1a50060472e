/* SPDX-License-Identifier: Apache-2.0 */
/* The .vdb format's ops in the library: they load the OpenVDB writer
 * (write_vdb.cpp, built as the plugin libclvox-vdb.so) on the first .vdb and
 * forward to it. Why a plugin: linked into the library, libopenvdb and what
 * it pulls in (TBB, Boost, log4cplus, blosc) were loaded and relocated at
 * the start of every run, .vdb or not: 27 MB of resident memory (a tenth of
 * a 3.3 M-triangle run at 512^3) and 40 ms (`clvox --version`: 34 MB and
 * 0.04 s with it, 5 MB and 0.00 s without).
 *
 * Where the plugin is looked for, first match wins:
 *   $CLVOX_VDB_PLUGIN                 that file only (tests, packagers)
 *   beside the code that holds this file (libclvox.so, or the program that
 *   links libclvox.a; the program's own path comes from /proc/self/exe):
 *     DIR/, DIR/../, DIR/clvox/, DIR/../lib/clvox/
 *                                     build tree (build/CONFIG/ and its
 *                                     tests/), `make install` (bin/ and lib/)
 *   CLVOX_VDB_PLUGIN_DIR              the build directory (the Makefile's),
 *                                     for programs elsewhere that link that
 *                                     build's libclvox.a (the Python module)
 * The plugin is loaded once per process and never unloaded (OpenVDB keeps
 * global state and threads). It links no clvox code: what it needs from the
 * library comes in a table of functions (clvox__vdb_host), and it refuses a
 * table from another version or layout (CLVOX__VDB_ABI). */
#define _GNU_SOURCE /* dladdr */
#include "core/internal.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#ifdef CLVOX_HAVE_OPENVDB
#include <dlfcn.h>
#include <pthread.h>
#include <unistd.h>

#ifndef CLVOX_VDB_PLUGIN_DIR
#define CLVOX_VDB_PLUGIN_DIR ""
#endif

static pthread_mutex_t g_lock = PTHREAD_MUTEX_INITIALIZER;
static const clvox__fmt_ops *g_ops;   /* the plugin's, once loaded */
static const clvox__vdb_reader_ops *g_reader; /* its reader (NULL: a plugin without one) */
static char g_error[PATH_MAX + 512]; /* why the last attempt failed */

static const clvox__vdb_host g_host = {clvox__fail, clvox__outfile_create, clvox__outfile_write,
                                       clvox__outfile_finish, clvox__outfile_discard};

/* Tries one file: 1 when it is a matching plugin (g_ops set), else 0 with
 * the reason in g_error when the file exists (a missing file says nothing:
 * the next place is tried). */
static int try_plugin(const char *path)
{
    char file[PATH_MAX];
    if (!realpath(path, file)) return 0; /* "lib/clvox/x.so", not "bin/../lib/clvox/x.so" */
    struct stat sb; /* dlopen would block on a FIFO */
    if (stat(file, &sb) != 0 || !S_ISREG(sb.st_mode)) {
        snprintf(g_error, sizeof g_error, "cannot load %s (%s)", file,
                 S_ISDIR(sb.st_mode) ? strerror(EISDIR) : "not a regular file");
        return 0;
    }
    void *h = dlopen(file, RTLD_NOW | RTLD_LOCAL);
    if (!h) {
        const char *e = dlerror();
        snprintf(g_error, sizeof g_error, "cannot load %s (%s)", file, e ? e : "dlopen failed");
        return 0;
    }
    clvox__vdb_plugin_fn entry;
    void *sym = dlsym(h, CLVOX__VDB_PLUGIN_ENTRY);
    memcpy(&entry, &sym, sizeof entry); /* object to function pointer (POSIX) */
    const clvox__fmt_ops *ops = entry ? entry(&g_host, CLVOX__VDB_ABI, CLVOX_VERSION_STRING) : NULL;
    if (!ops) {
        snprintf(g_error, sizeof g_error, "%s is not the OpenVDB writer of this clvox (%s)", file,
                 entry ? "another version or build" : "no " CLVOX__VDB_PLUGIN_ENTRY);
        dlclose(h);
        return 0;
    }
    g_ops = ops; /* kept loaded for the process */
    clvox__vdb_reader_fn reader_entry;
    void *rsym = dlsym(h, CLVOX__VDB_READER_ENTRY);
    memcpy(&reader_entry, &rsym, sizeof reader_entry);
    g_reader = reader_entry ? reader_entry(&g_host, CLVOX__VDB_READER_ABI, CLVOX_VERSION_STRING) : NULL;
    return 1;
}

/* Tries NAME in dir (a directory or a file's path whose directory is meant:
 * `is_file`) followed by each of the suffixes. */
static int try_beside(const char *path, int is_file)
{
    static const char *const sub[] = {"", "/..", "/clvox", "/../lib/clvox"};
    char dir[PATH_MAX], file[PATH_MAX + 64];
    if (snprintf(dir, sizeof dir, "%s", path) >= (int)sizeof dir) return 0;
    if (is_file) {
        char *slash = strrchr(dir, '/');
        if (!slash) return 0;
        *slash = 0;
    }
    for (size_t i = 0; i < sizeof sub / sizeof *sub; i++) {
        if (snprintf(file, sizeof file, "%s%s/" CLVOX__VDB_PLUGIN_NAME, dir, sub[i]) >= (int)sizeof file) continue;
        if (try_plugin(file)) return 1;
    }
    return 0;
}

static void load_locked(void)
{
    g_error[0] = 0;
    const char *env = clvox__setting_value(CLVOX__ENV_VDB_PLUGIN);
    if (env && *env) {
        if (!try_plugin(env) && !g_error[0]) snprintf(g_error, sizeof g_error, "CLVOX_VDB_PLUGIN=%s: no such file", env);
        return;
    }
    /* Beside the code: an absolute module path (libclvox.so), else the program. */
    Dl_info info;
    char real[PATH_MAX];
    if (dladdr((void *)&g_host, &info) && info.dli_fname && info.dli_fname[0] == '/' &&
        realpath(info.dli_fname, real) && try_beside(real, 1))
        return;
    ssize_t n = readlink("/proc/self/exe", real, sizeof real - 1);
    if (n > 0) {
        real[n] = 0;
        if (try_beside(real, 1)) return;
    }
    if (CLVOX_VDB_PLUGIN_DIR[0] && try_beside(CLVOX_VDB_PLUGIN_DIR, 0)) return;
    if (!g_error[0])
        snprintf(g_error, sizeof g_error,
                 CLVOX__VDB_PLUGIN_NAME " was not found beside clvox (nor in lib/clvox/ there) or in %s "
                                        "(CLVOX_VDB_PLUGIN names it)",
                 CLVOX_VDB_PLUGIN_DIR[0] ? CLVOX_VDB_PLUGIN_DIR : "the build directory");
}

clvox_status clvox__vdb_load(clvox_context *ctx, const char *path)
{
    pthread_mutex_lock(&g_lock);
    if (!g_ops) load_locked(); /* a failed load is tried again next time */
    const int ok = g_ops != NULL;
    char why[sizeof g_error];
    memcpy(why, g_error, sizeof why);
    pthread_mutex_unlock(&g_lock);
    if (ok) return CLVOX_OK;
    return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "cannot write '%s': OpenVDB writer: %s", path, why);
}

static const clvox__fmt_ops *ops_loaded(void)
{
    pthread_mutex_lock(&g_lock);
    const clvox__fmt_ops *ops = g_ops;
    pthread_mutex_unlock(&g_lock);
    return ops;
}

static clvox_status vdb_open(clvox_context *ctx, const clvox__fmt_info *info, void **state)
{
    *state = NULL;
    clvox_status st = clvox__vdb_load(ctx, info->path);
    if (st != CLVOX_OK) return st;
    return ops_loaded()->open(ctx, info, state);
}
/* write, finish and abort come after a successful open: the plugin is loaded. */
static clvox_status vdb_write(void *state, const clvox__fmt_slab *s) { return ops_loaded()->write(state, s); }
static clvox_status vdb_finish(void *state, uint64_t *bytes) { return ops_loaded()->finish(state, bytes); }
static void vdb_abort(void *state)
{
    if (state) ops_loaded()->abort(state);
}

/* Reading: the same plugin, loaded the same way. */
clvox_status clvox__vdb_reader_open(clvox_context *ctx, const char *path, clvox_volume_info *info, void **state)
{
    *state = NULL;
    pthread_mutex_lock(&g_lock);
    if (!g_ops) load_locked();
    const clvox__vdb_reader_ops *r = g_reader;
    const int loaded = g_ops != NULL;
    char why[sizeof g_error];
    memcpy(why, g_error, sizeof why);
    pthread_mutex_unlock(&g_lock);
    if (!loaded)
        return clvox__fail(ctx, CLVOX_ERR_EXR, "cannot read '%s' (an OpenVDB file): OpenVDB plugin: %s", path, why);
    if (!r)
        return clvox__fail(ctx, CLVOX_ERR_EXR, "cannot read '%s' (an OpenVDB file): the OpenVDB plugin has no reader",
                           path);
    return r->open(ctx, path, info, state);
}
/* The rest come after a successful open: the reader is loaded. */
static const clvox__vdb_reader_ops *reader_loaded(void)
{
    pthread_mutex_lock(&g_lock);
    const clvox__vdb_reader_ops *r = g_reader;
    pthread_mutex_unlock(&g_lock);
    return r;
}
int clvox__vdb_reader_has(void *state, const char *channel) { return reader_loaded()->has(state, channel); }
clvox_status clvox__vdb_reader_read(void *state, const char *channel, clvox__vdb_band_fn fn, void *user)
{
    return reader_loaded()->read(state, channel, fn, user);
}
void clvox__vdb_reader_close(void *state)
{
    if (state) reader_loaded()->close(state);
}

#else /* !CLVOX_HAVE_OPENVDB */

clvox_status clvox__vdb_reader_open(clvox_context *ctx, const char *path, clvox_volume_info *info, void **state)
{
    (void)info;
    *state = NULL;
    return clvox__fail(ctx, CLVOX_ERR_EXR, "cannot read '%s' (an OpenVDB file): clvox was built without OpenVDB", path);
}
int clvox__vdb_reader_has(void *state, const char *channel)
{
    (void)state, (void)channel;
    return 0;
}
clvox_status clvox__vdb_reader_read(void *state, const char *channel, clvox__vdb_band_fn fn, void *user)
{
    (void)state, (void)channel, (void)fn, (void)user;
    return CLVOX_ERR_INTERNAL;
}
void clvox__vdb_reader_close(void *state) { (void)state; }

clvox_status clvox__vdb_load(clvox_context *ctx, const char *path)
{
    return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "cannot write '%s': clvox was built without OpenVDB", path);
}
static clvox_status vdb_open(clvox_context *ctx, const clvox__fmt_info *info, void **state)
{
    *state = NULL;
    return clvox__vdb_load(ctx, info->path);
}
static clvox_status vdb_write(void *state, const clvox__fmt_slab *s)
{
    (void)state, (void)s;
    return CLVOX_ERR_INTERNAL;
}
static clvox_status vdb_finish(void *state, uint64_t *bytes)
{
    (void)state;
    if (bytes) *bytes = 0;
    return CLVOX_ERR_INTERNAL;
}
static void vdb_abort(void *state) { (void)state; }

#endif

const clvox__fmt_ops clvox__fmt_vdb = {
    "vdb", CLVOX_CHANNEL_OCCUPANCY | CLVOX_CHANNEL_COVERAGE, 1, 0, vdb_open, vdb_write, vdb_finish, vdb_abort};
