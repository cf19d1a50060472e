/* SPDX-License-Identifier: Apache-2.0 */
/* Output formats (npy, NRRD, binvox, OpenVDB; docs/formats.md): each file
 * read back by an independent reader (NumPy, pynrrd, trimesh's binvox loader, pyopenvdb;
 * tests/formats_check.py, run with build/venv-formats/bin/python from
 * scripts/setup.sh) and compared voxel by voxel with
 * clvox_voxelize_to_buffers; bad requests (unknown extension, a channel the
 * format cannot hold, a non-cubic binvox grid, a FIFO target, a cancelled
 * run) fail with a message and leave nothing behind. */
#include "meshgen.h"
#include "spawn.h"
#include "test.h"
#include "core/internal.h"    /* clvox__outset_fail_at */
#include "io/output_set.h"  /* clvox__output_complete */

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define EXIT_INPUT_CODE 4
static char g_dir[2048], g_python[4096];
static int g_vdb; /* clvox was built with OpenVDB */

static const char *tmp(const char *name)
{
    static char buf[8][2400];
    static int k;
    char *b = buf[k++ & 7];
    snprintf(b, sizeof buf[0], "%s/%s", g_dir, name);
    return b;
}

static int entries(void) /* files in the scratch directory */
{
    DIR *d = opendir(g_dir);
    int n = 0;
    struct dirent *e;
    while (d && (e = readdir(d)))
        if (e->d_name[0] != '.') n++;
    if (d) closedir(d);
    return n;
}

static void clear_dir(void)
{
    DIR *d = opendir(g_dir);
    struct dirent *e;
    while (d && (e = readdir(d))) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0) continue;
        unlink(tmp(e->d_name));
    }
    if (d) closedir(d);
}

/* Is a file whose path contains `name` mapped into this process? */
static int maps_has(const char *name)
{
    FILE *f = fopen("/proc/self/maps", "r");
    char line[4096];
    int found = 0;
    while (f && fgets(line, sizeof line, f))
        if (strstr(line, name)) found = 1;
    if (f) fclose(f);
    return found;
}

static int write_raw(const char *path, const void *data, size_t bytes)
{
    FILE *f = fopen(path, "wb");
    if (!f) return 0;
    int ok = fwrite(data, 1, bytes, f) == bytes;
    return fclose(f) == 0 && ok;
}

/* Runs formats_check.py; 1 when it printed OK. */
static int check_py_arg(const char *fmt, const char *file, const char *ref, const char *dt, const clvox_grid *g,
                        const char *last)
{
    char a[7][64];
    snprintf(a[0], 64, "%u", g->dims[0]);
    snprintf(a[1], 64, "%u", g->dims[1]);
    snprintf(a[2], 64, "%u", g->dims[2]);
    for (int i = 0; i < 3; i++) snprintf(a[3 + i], 64, "%.17g", g->origin[i]);
    snprintf(a[6], 64, "%.17g", g->voxel_size[0]);
    const char *argv[] = {g_python, "tests/formats_check.py", fmt, file, ref, dt, a[0], a[1], a[2], a[3], a[4],
                          a[5], a[6], last, NULL};
    spawn_result r;
    spawn_run(&r, argv, 120);
    int ok = r.code == 0 && strstr(r.out, "OK") != NULL;
    if (!ok) fprintf(stderr, "formats_check %s %s: exit %d: %s%s\n", fmt, file, r.code, r.out, r.err);
    spawn_free(&r);
    return ok;
}

static int check_py(const char *fmt, const char *file, const char *ref, const char *dt, const clvox_grid *g,
                    int bits)
{
    return check_py_arg(fmt, file, ref, dt, g, bits ? "bits" : NULL);
}

static clvox_status to_file(clvox_context *ctx, clvox_mesh *m, const clvox_grid *g, const clvox_voxelize_options *vo,
                            uint32_t flags, clvox_compression c, const char *path)
{
    clvox_output_options oo = CLVOX_OUTPUT_OPTIONS_INIT;
    oo.flags = flags;
    oo.compression = c;
    return clvox_voxelize_to_file(ctx, m, g, vo, &oo, path, NULL);
}

/* ---- sets of files (npy, NRRD channels): replaced whole or not at all ---- */

static char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    char *b = NULL;
    size_t n = 0, cap = 0;
    for (;;) {
        if (n == cap) {
            char *nb = realloc(b, cap = cap ? 2 * cap : 4096);
            if (!nb) break;
            b = nb;
        }
        size_t got = fread(b + n, 1, cap - n, f);
        if (got == 0) break;
        n += got;
    }
    fclose(f);
    *len = n;
    return b;
}

static int same_file(const char *a, const char *b)
{
    size_t na = 0, nb = 0;
    char *x = slurp(a, &na), *y = slurp(b, &nb);
    int same = x && y && na == nb && memcmp(x, y, na) == 0;
    free(x);
    free(y);
    return same;
}

static int copy_file(const char *from, const char *to)
{
    size_t n = 0;
    char *b = slurp(from, &n);
    int ok = b && write_raw(to, b, n);
    free(b);
    return ok;
}

static int hidden_entries(void) /* .clvox-*.tmp left in the scratch directory */
{
    DIR *d = opendir(g_dir);
    int n = 0;
    struct dirent *e;
    while (d && (e = readdir(d)))
        if (strncmp(e->d_name, ".clvox-", 7) == 0) n++;
    if (d) closedir(d);
    return n;
}

typedef void (*before_finish_fn)(const char *path);

/* Writes occupancy + coverage (values from `seed`) to `path` through
 * clvox_volume_writer; `before` runs after the last slice, before the files are named. */
static clvox_status write_set(clvox_context *ctx, const char *path, const clvox_grid *g, int seed,
                              before_finish_fn before)
{
    clvox_volume_writer *w = NULL;
    clvox_status st = clvox_volume_writer_open(ctx, path, g, CLVOX_CHANNEL_OCCUPANCY | CLVOX_CHANNEL_COVERAGE,
                                               NULL, &w);
    if (st != CLVOX_OK) return st;
    const size_t plane = (size_t)g->dims[0] * g->dims[1];
    float v[64];
    for (uint32_t z = 0; z < g->dims[2] && st == CLVOX_OK; z++) {
        for (size_t i = 0; i < plane; i++) v[i] = (float)((i * 7 + z * 3 + (size_t)seed) % 5) / 4.0f;
        st = clvox_volume_writer_slice(w, CLVOX_CHANNEL_OCCUPANCY, z, v);
        if (st == CLVOX_OK) st = clvox_volume_writer_slice(w, CLVOX_CHANNEL_COVERAGE, z, v);
    }
    if (st != CLVOX_OK) {
        clvox_volume_writer_abort(w);
        return st;
    }
    if (before) before(path);
    return clvox_volume_writer_finish(w, NULL);
}

static void dir_at_coverage(const char *path) /* something appears at OUT.coverage.EXT mid-run */
{
    char p[2400];
    snprintf(p, sizeof p, "%s", path);
    char *dot = strrchr(p, '.'), ext[16];
    snprintf(ext, sizeof ext, "%s", dot);
    snprintf(dot, sizeof p - (size_t)(dot - p), ".coverage%s", ext);
    unlink(p);
    mkdir(p, 0777);
}

static void dir_at_json(const char *path)
{
    char p[2400];
    snprintf(p, sizeof p, "%s", path);
    strcpy(strrchr(p, '.'), ".json");
    unlink(p);
    mkdir(p, 0777);
}

static void test_output_sets(clvox_context *ctx)
{
    clear_dir();
    clvox_grid g = {{8, 4, 3}, {0.5, -1, 2}, {0.25, 0.25, 0.25}};
    static const char *const exts[2] = {"npy", "nrrd"};
    for (int e = 0; e < 2; e++) {
        const int npy = e == 0;
        char out[64], cov[64], json[64], a_main[64], a_cov[64], a_json[64], b[64], b_main[64], b_cov[64];
        snprintf(out, sizeof out, "s.%s", exts[e]);
        snprintf(cov, sizeof cov, "s.coverage.%s", exts[e]);
        snprintf(json, sizeof json, "s.json");
        snprintf(a_main, sizeof a_main, "a.%s", exts[e]);
        snprintf(a_cov, sizeof a_cov, "a.coverage.%s", exts[e]);
        snprintf(a_json, sizeof a_json, "a.json");
        snprintf(b, sizeof b, "b.%s", exts[e]);
        snprintf(b_main, sizeof b_main, "b.%s", exts[e]);
        snprintf(b_cov, sizeof b_cov, "b.coverage.%s", exts[e]);
        /* the old, complete set, and a copy of it */
        CHECK_OK(ctx, write_set(ctx, tmp(out), &g, 1, NULL));
        CHECK(copy_file(tmp(out), tmp(a_main)) && copy_file(tmp(cov), tmp(a_cov)));
        if (npy) CHECK(copy_file(tmp(json), tmp(a_json)));
        char why[1024] = "";
        CHECK_MSG(clvox__output_complete(tmp(out), why, sizeof why), "%s: %s", out, why);

        /* (1) a later member cannot be named (a directory appeared at
         * OUT.coverage.EXT, or at the marker OUT.json, mid-run): the run
         * fails and the old files are all still there, byte for byte */
        CHECK_STATUS(ctx, write_set(ctx, tmp(out), &g, 2, dir_at_coverage), CLVOX_ERR_IO);
        CHECK_MSG(strstr(clvox_context_error(ctx), "is a directory") != NULL, "%s", clvox_context_error(ctx));
        CHECK_MSG(same_file(tmp(out), tmp(a_main)), "%s: the old main file is gone or changed", out);
        if (npy) CHECK(same_file(tmp(json), tmp(a_json)));
        CHECK(rmdir(tmp(cov)) == 0 && copy_file(tmp(a_cov), tmp(cov)));
        if (npy) {
            CHECK_STATUS(ctx, write_set(ctx, tmp(out), &g, 2, dir_at_json), CLVOX_ERR_IO);
            CHECK_MSG(same_file(tmp(out), tmp(a_main)) && same_file(tmp(cov), tmp(a_cov)),
                      "%s: the old members are gone or changed", out);
            CHECK(rmdir(tmp(json)) == 0 && copy_file(tmp(a_json), tmp(json)));
        }
        /* a rename that fails midway (member 2, then the marker): the old
         * files the placed members replaced are renamed back */
        for (int k = 2; k <= (npy ? 3 : 2); k++) {
            clvox__outset_fail_at = k;
            CHECK_STATUS(ctx, write_set(ctx, tmp(out), &g, 2, NULL), CLVOX_ERR_IO);
            clvox__outset_fail_at = 0;
            CHECK_MSG(same_file(tmp(out), tmp(a_main)) && same_file(tmp(cov), tmp(a_cov)) &&
                          (!npy || same_file(tmp(json), tmp(a_json))),
                      "%s: rename %d failed: the old set was not put back", out, k);
            CHECK_MSG(hidden_entries() == 0, "%s: %d hidden files left", out, hidden_entries());
        }
        /* ... and where there was no old set, nothing is left */
        int before = entries();
        clvox__outset_fail_at = 2;
        CHECK_STATUS(ctx, write_set(ctx, tmp("new.npy"), &g, 2, NULL), CLVOX_ERR_IO);
        clvox__outset_fail_at = 0;
        CHECK_MSG(entries() == before && hidden_entries() == 0, "%d files, %d before", entries(), before);

        /* (2) a mixed set (a kill between two renames): the main file of
         * another run beside this set's marker and members is not trusted */
        CHECK_OK(ctx, write_set(ctx, tmp(b), &g, 3, NULL));
        CHECK(clvox__output_complete(tmp(b), NULL, 0));
        CHECK(copy_file(tmp(b_main), tmp(out)));
        why[0] = '\0';
        CHECK_MSG(!clvox__output_complete(tmp(out), why, sizeof why) && strstr(why, "mixed set"), "%s: %s", out, why);
        CHECK(copy_file(tmp(a_main), tmp(out)) && clvox__output_complete(tmp(out), NULL, 0));
        CHECK(copy_file(tmp(b_cov), tmp(cov)));
        CHECK_MSG(!clvox__output_complete(tmp(out), why, sizeof why) && strstr(why, "mixed set"), "%s: %s", out, why);
        CHECK(unlink(tmp(cov)) == 0);
        CHECK_MSG(!clvox__output_complete(tmp(out), why, sizeof why) && strstr(why, "missing"), "%s: %s", out, why);
        CHECK(copy_file(tmp(a_cov), tmp(cov)) && clvox__output_complete(tmp(out), NULL, 0));
        /* the same with named temporary files (no O_TMPFILE) */
        clvox__exr_no_tmpfile = 1;
        clvox__outset_fail_at = 2;
        CHECK_STATUS(ctx, write_set(ctx, tmp(out), &g, 2, NULL), CLVOX_ERR_IO);
        clvox__outset_fail_at = 0;
        CHECK(same_file(tmp(out), tmp(a_main)) && same_file(tmp(cov), tmp(a_cov)) && hidden_entries() == 0);
        CHECK_OK(ctx, write_set(ctx, tmp(out), &g, 2, NULL));
        clvox__exr_no_tmpfile = 0;
        CHECK(!same_file(tmp(out), tmp(a_main)) && clvox__output_complete(tmp(out), NULL, 0) && hidden_entries() == 0);
    }
    /* a sidecar without sizes and CRCs (earlier clvox): cannot be checked */
    const char *legacy = "{\"format\": \"npy\", \"dims\": [8, 4, 3], \"origin\": [0, 0, 0], \"voxel_size\": [1, 1, 1], "
                         "\"channels\": {\"occupancy\": {\"file\": \"s.npy\", \"dtype\": \"u1\", \"packed_bits\": false}}}\n";
    CHECK(write_raw(tmp("s.json"), legacy, strlen(legacy)));
    char why[1024] = "";
    CHECK_MSG(!clvox__output_complete(tmp("s.npy"), why, sizeof why) && strstr(why, "earlier clvox"), "%s", why);
    /* one file: complete when it is a regular file */
    CHECK(write_raw(tmp("one.exr"), "x", 1) && clvox__output_complete(tmp("one.exr"), NULL, 0));
    CHECK(mkdir(tmp("d.exr"), 0777) == 0 && !clvox__output_complete(tmp("d.exr"), NULL, 0));
    rmdir(tmp("d.exr"));
    clear_dir();
}

static int cancel_at_once(void *user, double f)
{
    (void)user, (void)f;
    return 0;
}

int main(void)
{
    snprintf(g_dir, sizeof g_dir, "%s/formats", test_tmpdir());
    mkdir(g_dir, 0777);
    clear_dir();
    if (access("build/venv-formats/bin/python", X_OK) == 0) snprintf(g_python, sizeof g_python, "build/venv-formats/bin/python");
    else snprintf(g_python, sizeof g_python, "python3");
    clvox_context *ctx = test_context();
    tmesh t = tmesh_torus(0.05, -0.02, 0.01, 0.7, 0.3, 48, 24);
    clvox_mesh *mesh = NULL;
    CHECK_OK(ctx, clvox_mesh_from_arrays(ctx, t.xyz, t.nv, t.tri, t.nt, &mesh));
    clvox_grid_options go = CLVOX_GRID_OPTIONS_INIT;
    go.resolution = 40;
    go.use_box = 1;
    for (int a = 0; a < 3; a++) go.box_min[a] = -1.2, go.box_max[a] = 1.2;
    clvox_grid g;
    CHECK_OK(ctx, clvox_grid_compute(ctx, &go, go.box_min, go.box_max, &g));
    const size_t n = (size_t)g.dims[0] * g.dims[1] * g.dims[2];
    uint8_t *occ = malloc(n);
    float *cov = malloc(n * sizeof *cov);
    clvox_voxelize_options vo = CLVOX_VOXELIZE_OPTIONS_INIT;
    vo.slab_depth = 7; /* several slabs, the last one short */
    CHECK_OK(ctx, clvox_voxelize_to_buffers(ctx, mesh, &g, &vo, occ, n, NULL, 0, NULL));
    CHECK(write_raw(tmp("ref.u8"), occ, n));
    size_t filled = 0;
    for (size_t i = 0; i < n; i++) filled += occ[i];
    CHECK(filled > n / 20 && filled < n / 2);

    /* occupancy in every format */
    CHECK_OK(ctx, to_file(ctx, mesh, &g, &vo, 0, 0, tmp("occ.npy")));
    CHECK(check_py("npy", tmp("occ.npy"), tmp("ref.u8"), "u8", &g, 0));
    CHECK_OK(ctx, to_file(ctx, mesh, &g, &vo, CLVOX_OUTPUT_PACK_BITS, 0, tmp("bits.npy")));
    CHECK(check_py("npy", tmp("bits.npy"), tmp("ref.u8"), "u8", &g, 1));
    CHECK_OK(ctx, to_file(ctx, mesh, &g, &vo, 0, 0, tmp("occ.nrrd")));
    CHECK(check_py("nrrd", tmp("occ.nrrd"), tmp("ref.u8"), "u8", &g, 0));
    CHECK_OK(ctx, to_file(ctx, mesh, &g, &vo, 0, CLVOX_COMPRESSION_NONE, tmp("raw.nrrd")));
    CHECK(check_py("nrrd", tmp("raw.nrrd"), tmp("ref.u8"), "u8", &g, 0));
    struct stat sg, sr;
    CHECK(stat(tmp("occ.nrrd"), &sg) == 0 && stat(tmp("raw.nrrd"), &sr) == 0 && sg.st_size < sr.st_size / 4);
    CHECK_OK(ctx, to_file(ctx, mesh, &g, &vo, 0, 0, tmp("occ.binvox")));
    CHECK(check_py("binvox", tmp("occ.binvox"), tmp("ref.u8"), "u8", &g, 0));

    /* coverage: float32 exact, float16 to HALF, NRRD float; two channels -> two files */
    clvox_voxelize_options cv = vo;
    cv.oversample = 2;
    CHECK_OK(ctx, clvox_voxelize_to_buffers(ctx, mesh, &g, &cv, NULL, 0, cov, n, NULL));
    CHECK(write_raw(tmp("ref.f32"), cov, n * sizeof *cov));
    CHECK_OK(ctx, to_file(ctx, mesh, &g, &cv, CLVOX_OUTPUT_FLOAT32, 0, tmp("cov32.npy")));
    CHECK(check_py("npy", tmp("cov32.npy"), tmp("ref.f32"), "f32", &g, 0));
    CHECK_OK(ctx, to_file(ctx, mesh, &g, &cv, 0, 0, tmp("cov16.npy")));
    CHECK(check_py("npy", tmp("cov16.npy"), tmp("ref.f32"), "f32", &g, 0));
    CHECK_OK(ctx, to_file(ctx, mesh, &g, &cv, 0, 0, tmp("cov.nrrd")));
    CHECK(check_py("nrrd", tmp("cov.nrrd"), tmp("ref.f32"), "f32", &g, 0));
    clvox_voxelize_options both = cv;
    both.channels = CLVOX_CHANNEL_OCCUPANCY | CLVOX_CHANNEL_COVERAGE;
    both.threshold_set = 1;
    both.threshold = 0.5;
    uint8_t *occ2 = malloc(n);
    CHECK_OK(ctx, clvox_voxelize_to_buffers(ctx, mesh, &g, &both, occ2, n, NULL, 0, NULL));
    CHECK(write_raw(tmp("ref2.u8"), occ2, n));
    CHECK_OK(ctx, to_file(ctx, mesh, &g, &both, CLVOX_OUTPUT_FLOAT32, 0, tmp("two.npy")));
    CHECK(check_py("npy", tmp("two.npy"), tmp("ref2.u8"), "u8", &g, 0));
    CHECK(check_py("npy", tmp("two.coverage.npy"), tmp("ref.f32"), "f32", &g, 0));
    CHECK(access(tmp("two.json"), F_OK) == 0);

    /* OpenVDB: a FLOAT grid "density" (occupancy, or coverage; both: also "occupancy"), read back with
     * pyopenvdb; without OpenVDB at build time, refused with one line before any work, nothing written.
     * The writer is a plugin (src/io/vdb_plugin.c): libopenvdb is not in the process before the first .vdb,
     * a plugin that is missing or not clvox's is refused with the reason, and one that the build made
     * (beside this program's directory) must load. */
    char plugin[4096] = "", lib[4096] = "";
    {
        char exe[4000];
        ssize_t len = readlink("/proc/self/exe", exe, sizeof exe - 1);
        CHECK(len > 0);
        exe[len > 0 ? len : 0] = 0;
        char *slash = strrchr(exe, '/');
        if (slash) *slash = 0; /* build/CONFIG/tests */
        snprintf(plugin, sizeof plugin, "%s/../libclvox-vdb.so", exe);
        snprintf(lib, sizeof lib, "%s/../libclvox.so", exe);
    }
    const int built_with_vdb = access(plugin, F_OK) == 0;
    CHECK_MSG(!maps_has("libopenvdb"), "libopenvdb is loaded before any .vdb was written");
    if (built_with_vdb) {
        setenv("CLVOX_VDB_PLUGIN", tmp("none.so"), 1);
        CHECK_STATUS(ctx, to_file(ctx, mesh, &g, &vo, 0, 0, tmp("p1.vdb")), CLVOX_ERR_INVALID_ARGUMENT);
        CHECK_MSG(strstr(clvox_context_error(ctx), "none.so: no such file") != NULL, "%s", clvox_context_error(ctx));
        setenv("CLVOX_VDB_PLUGIN", lib, 1); /* a shared object, not the plugin */
        CHECK_STATUS(ctx, to_file(ctx, mesh, &g, &vo, 0, 0, tmp("p2.vdb")), CLVOX_ERR_INVALID_ARGUMENT);
        CHECK_MSG(strstr(clvox_context_error(ctx), "is not the OpenVDB writer of this clvox") != NULL, "%s",
                  clvox_context_error(ctx));
        CHECK(write_raw(tmp("garbage.so"), "not an ELF file", 15));
        setenv("CLVOX_VDB_PLUGIN", tmp("garbage.so"), 1);
        CHECK_STATUS(ctx, to_file(ctx, mesh, &g, &vo, 0, 0, tmp("p3.vdb")), CLVOX_ERR_INVALID_ARGUMENT);
        CHECK_MSG(strstr(clvox_context_error(ctx), "cannot load") != NULL, "%s", clvox_context_error(ctx));
        unsetenv("CLVOX_VDB_PLUGIN");
        CHECK(access(tmp("p1.vdb"), F_OK) != 0 && access(tmp("p2.vdb"), F_OK) != 0 && access(tmp("p3.vdb"), F_OK) != 0);
        CHECK_MSG(!maps_has("libopenvdb"), "a refused plugin left libopenvdb loaded");
    }
    clvox_status vst = to_file(ctx, mesh, &g, &vo, 0, 0, tmp("occ.vdb"));
    CHECK_MSG(vst == CLVOX_OK || !built_with_vdb, "%s is there but .vdb failed: %s", plugin, clvox_context_error(ctx));
    CHECK(maps_has("libopenvdb") == (vst == CLVOX_OK));
    if (vst == CLVOX_OK) {
        g_vdb = 1;
        CHECK(check_py("vdb", tmp("occ.vdb"), tmp("ref.u8"), "u8", &g, 0));
        CHECK_OK(ctx, to_file(ctx, mesh, &g, &vo, 0, CLVOX_COMPRESSION_NONE, tmp("raw.vdb")));
        CHECK(check_py("vdb", tmp("raw.vdb"), tmp("ref.u8"), "u8", &g, 0));
        CHECK_OK(ctx, to_file(ctx, mesh, &g, &cv, 0, 0, tmp("cov.vdb")));
        CHECK(check_py("vdb", tmp("cov.vdb"), tmp("ref.f32"), "f32", &g, 0));
        CHECK_OK(ctx, to_file(ctx, mesh, &g, &both, 0, 0, tmp("two.vdb")));
        CHECK(check_py("vdb", tmp("two.vdb"), tmp("ref.f32"), "f32", &g, 0));
        CHECK(check_py_arg("vdb", tmp("two.vdb"), tmp("ref2.u8"), "u8", &g, "grid=occupancy"));
        CHECK_STATUS(ctx, to_file(ctx, mesh, &g, &vo, 0, CLVOX_COMPRESSION_PIZ, tmp("x.vdb")),
                     CLVOX_ERR_INVALID_ARGUMENT);
    } else {
        CHECK_STATUS(ctx, vst, CLVOX_ERR_INVALID_ARGUMENT);
        CHECK_MSG(strstr(clvox_context_error(ctx), "clvox was built without OpenVDB") != NULL, "%s",
                  clvox_context_error(ctx));
        fprintf(stderr, "test_formats: clvox built without OpenVDB: .vdb read-back skipped\n");
    }
    CHECK(access(tmp("occ.vdb"), F_OK) == (g_vdb ? 0 : -1));
    free(occ2);

    /* bad requests leave nothing */
    clear_dir();
    CHECK_STATUS(ctx, to_file(ctx, mesh, &g, &cv, 0, 0, tmp("cov.binvox")), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK(strstr(clvox_context_error(ctx), "binvox holds no coverage") != NULL);
    CHECK_STATUS(ctx, to_file(ctx, mesh, &g, &vo, 0, 0, tmp("x.vox")), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(ctx, to_file(ctx, mesh, &g, &vo, 0, CLVOX_COMPRESSION_PIZ, tmp("x.nrrd")), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(ctx, to_file(ctx, mesh, &g, &vo, CLVOX_OUTPUT_PACK_BITS, 0, tmp("x.nrrd")), CLVOX_ERR_INVALID_ARGUMENT);
    clvox_grid flat = g;
    flat.dims[2] = 20;
    CHECK_STATUS(ctx, to_file(ctx, mesh, &flat, &vo, 0, 0, tmp("flat.binvox")), CLVOX_ERR_GRID);
    CHECK(strstr(clvox_context_error(ctx), "cubic") != NULL);
    clvox_voxelize_options cancel = both;
    cancel.progress = cancel_at_once;
    CHECK_STATUS(ctx, to_file(ctx, mesh, &g, &cancel, 0, 0, tmp("c.npy")), CLVOX_ERR_CANCELLED);
    CHECK_STATUS(ctx, to_file(ctx, mesh, &g, &cancel, 0, 0, tmp("c.nrrd")), CLVOX_ERR_CANCELLED);
    cancel = vo;
    cancel.progress = cancel_at_once;
    CHECK_STATUS(ctx, to_file(ctx, mesh, &g, &cancel, 0, 0, tmp("c.binvox")), CLVOX_ERR_CANCELLED);
    CHECK_STATUS(ctx, to_file(ctx, mesh, &g, &cancel, 0, 0, tmp("c.vdb")), g_vdb ? CLVOX_ERR_CANCELLED : CLVOX_ERR_INVALID_ARGUMENT);
    if (g_vdb) {
        clvox_volume_writer *w = NULL;
        CHECK_STATUS(ctx, clvox_volume_writer_open(ctx, tmp("el.vdb"), &g, CLVOX_CHANNEL_ELEMENT, NULL, &w),
                     CLVOX_ERR_INVALID_ARGUMENT);
        CHECK(w == NULL && strstr(clvox_context_error(ctx), "vdb holds no element") != NULL);
        CHECK(mkfifo(tmp("fifo.vdb"), 0666) == 0);
        CHECK_STATUS(ctx, to_file(ctx, mesh, &g, &vo, 0, 0, tmp("fifo.vdb")), CLVOX_ERR_IO);
        unlink(tmp("fifo.vdb"));
        CHECK(mkdir(tmp("d.vdb"), 0777) == 0);
        CHECK_STATUS(ctx, to_file(ctx, mesh, &g, &vo, 0, 0, tmp("d.vdb")), CLVOX_ERR_IO);
        rmdir(tmp("d.vdb"));
    }
    CHECK_MSG(entries() == 0, "%d files left", entries());
    CHECK(mkfifo(tmp("fifo.npy"), 0666) == 0);
    CHECK_STATUS(ctx, to_file(ctx, mesh, &g, &vo, 0, 0, tmp("fifo.npy")), CLVOX_ERR_IO);
    CHECK(mkdir(tmp("d.nrrd"), 0777) == 0);
    CHECK_STATUS(ctx, to_file(ctx, mesh, &g, &vo, 0, 0, tmp("d.nrrd")), CLVOX_ERR_IO);
    struct stat sb;
    CHECK(lstat(tmp("fifo.npy"), &sb) == 0 && S_ISFIFO(sb.st_mode));
    CHECK(entries() == 2);
    unlink(tmp("fifo.npy"));
    rmdir(tmp("d.nrrd"));

    /* the CLI: one-line errors, non-zero exit, nothing left */
    const char *bin = getenv("CLVOX_BIN");
    CHECK(tmesh_write_off(&t, tmp("torus.off")) == 0);
    if (bin) {
        const char *a1[] = {bin, tmp("torus.off"), "-r", "16", "-o", tmp("out.vox"), "-q", NULL};
        spawn_result r;
        CHECK(spawn_run(&r, a1, 60) == 2 && strstr(r.err, "cannot tell the output format") && !strchr(strchr(r.err, '\n') + 1, '\n'));
        spawn_free(&r);
        const char *a2[] = {bin, tmp("torus.off"), "--dims", "16,16,8", "-o", tmp("out.binvox"), "-q", NULL};
        CHECK(spawn_run(&r, a2, 60) != 0 && strstr(r.err, "binvox needs a cubic grid"));
        spawn_free(&r);
        const char *a3[] = {bin, tmp("torus.off"), "-r", "16", "--format", "npy", "-o", tmp("out.dat"), "-q", NULL};
        CHECK(spawn_run(&r, a3, 60) == 0 && access(tmp("out.dat"), F_OK) == 0 && access(tmp("out.json"), F_OK) == 0);
        spawn_free(&r);
        unlink(tmp("out.dat"));
        unlink(tmp("out.json"));
        CHECK_MSG(entries() == 1, "%d files left", entries());
    }
    /* clvox convert: an EXR volume into every format, compared with the same reference */
    clear_dir();
    CHECK(write_raw(tmp("ref.u8"), occ, n));
    CHECK(write_raw(tmp("ref.f32"), cov, n * sizeof *cov));
    clvox_voxelize_options two = cv;
    two.channels = CLVOX_CHANNEL_OCCUPANCY | CLVOX_CHANNEL_COVERAGE;
    CHECK_OK(ctx, clvox_voxelize_to_exr(ctx, mesh, &g, &vo, tmp("in.exr"), NULL));
    CHECK_OK(ctx, clvox_voxelize_to_exr(ctx, mesh, &g, &two, tmp("in2.exr"), NULL));
    if (bin) {
        static const char *const outs[] = {"conv.npy", "conv.nrrd", "conv.binvox", "conv.exr"};
        for (int k = 0; k < 4; k++) {
            const char *a[] = {bin, "convert", tmp("in.exr"), tmp(outs[k]), NULL};
            spawn_result r;
            CHECK_MSG(spawn_run(&r, a, 60) == 0, "%s: %s", outs[k], r.err);
            spawn_free(&r);
        }
        CHECK(check_py("npy", tmp("conv.npy"), tmp("ref.u8"), "u8", &g, 0));
        CHECK(check_py("nrrd", tmp("conv.nrrd"), tmp("ref.u8"), "u8", &g, 0));
        CHECK(check_py("binvox", tmp("conv.binvox"), tmp("ref.u8"), "u8", &g, 0));
        {
            const char *a[] = {bin, "convert", tmp("in.exr"), tmp("conv.vdb"), NULL};
            spawn_result r;
            int code = spawn_run(&r, a, 60);
            if (g_vdb) {
                CHECK_MSG(code == 0, "conv.vdb: %s", r.err);
                CHECK(check_py("vdb", tmp("conv.vdb"), tmp("ref.u8"), "u8", &g, 0));
            } else {
                CHECK(code != 0 && strstr(r.err, "clvox was built without OpenVDB") && access(tmp("conv.vdb"), F_OK) != 0);
            }
            spawn_free(&r);
            const char *a2[] = {bin, "convert", tmp("in2.exr"), tmp("conv2.vdb"), NULL};
            code = spawn_run(&r, a2, 60);
            if (g_vdb) {
                CHECK_MSG(code == 0, "conv2.vdb: %s", r.err);
                /* the EXR holds coverage as HALF */
                CHECK(check_py_arg("vdb", tmp("conv2.vdb"), tmp("ref.f32"), "f32", &g, "half"));
            }
            spawn_free(&r);
        }
        uint8_t *back = malloc(n);
        clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
        CHECK_OK(ctx, clvox_volume_read(ctx, tmp("conv.exr"), &info, back, n));
        CHECK(memcmp(back, occ, n) == 0);
        free(back);
        const char *a2[] = {bin, "convert", tmp("in2.exr"), tmp("conv2.npy"), NULL};
        spawn_result r;
        CHECK(spawn_run(&r, a2, 60) == 0);
        spawn_free(&r);
        CHECK(check_py("npy", tmp("conv2.coverage.npy"), tmp("ref.f32"), "f32", &g, 0));
        /* bad requests: nothing left */
        int before = entries();
        const char *b1[] = {bin, "convert", tmp("in2.exr"), tmp("bad.binvox"), "--channel", "coverage", NULL};
        CHECK(spawn_run(&r, b1, 60) != 0 && strstr(r.err, "binvox holds no coverage"));
        spawn_free(&r);
        const char *b2[] = {bin, "convert", tmp("in2.exr"), tmp("bad.exr"), "--channel", "coverage", "--channel",
                            "occupancy", NULL};
        CHECK(spawn_run(&r, b2, 60) != 0 && strstr(r.err, "one channel at a time"));
        spawn_free(&r);
        const char *b3[] = {bin, "convert", tmp("in.exr"), tmp("bad.npy"), "--channel", "coverage", NULL};
        CHECK(spawn_run(&r, b3, 60) == EXIT_INPUT_CODE && strstr(r.err, "has no coverage channel"));
        spawn_free(&r);
        const char *b4[] = {bin, "convert", tmp("in.exr"), tmp("bad.vol"), NULL};
        CHECK(spawn_run(&r, b4, 60) == 2);
        spawn_free(&r);
        CHECK_MSG(entries() == before, "%d files, %d before", entries(), before);
    }
    test_output_sets(ctx);
    clvox_mesh_destroy(mesh);
    tmesh_free(&t);
    free(occ);
    free(cov);
    clvox_context_destroy(ctx);
    return test_report();
}
