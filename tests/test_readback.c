/* SPDX-License-Identifier: Apache-2.0 */
/* clvox reads every format it writes (issue 36; src/io/read_volume.c): one
 * torus voxelized by the clvox binary into EXR and into npy (its variants),
 * NRRD (raw, gzip, a detached .nhdr), binvox and OpenVDB, for every mode each
 * format holds (occupancy, coverage, both, a palette run's element and
 * score). Each file read back through the library (clvox_volume_read,
 * clvox_volume_read_slices: what clvox info, preview, convert and
 * clvox.read use) must give the EXR's grid, filled count and voxels: exactly,
 * or, for float32 coverage/score (npy --npy-float32, NRRD, OpenVDB hold
 * count/samples exactly, the EXR its HALF rounding), equal once rounded to
 * HALF. The CLI: `clvox info` prints the EXR's counts; `clvox convert FILE
 * out.exr` gives the byte-identical EXR of converting the run's EXR where
 * the format keeps method and parameters (npy, OpenVDB), else the same
 * voxels; `clvox preview` the same picture. Files told by magic bytes under
 * other names; truncated and corrupt files: one line, exit 4. */
#include "meshgen.h"
#include "spawn.h"
#include "test.h"
#include "testio.h"
#include "core/internal.h" /* clvox__half_from_unit */

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static char g_dir[2048];
static const char *g_bin;
static clvox_context *g_ctx;

static const char *tmp(const char *name)
{
    static char buf[8][2400];
    static int k;
    char *b = buf[k++ & 7];
    snprintf(b, sizeof buf[0], "%s/%s", g_dir, name);
    return b;
}

/* Runs clvox with up to 16 args; returns the exit code, stderr into err (may be NULL). */
static int run(char **err, const char *a0, ...)
{
    const char *argv[24] = {g_bin};
    size_t n = 1;
    va_list ap;
    va_start(ap, a0);
    for (const char *a = a0; a && n + 1 < sizeof argv / sizeof *argv; a = va_arg(ap, const char *)) argv[n++] = a;
    va_end(ap);
    argv[n] = NULL;
    spawn_result r;
    int code = spawn_run(&r, argv, 120);
    if (err) *err = strdup(r.err);
    else if (code != 0) fprintf(stderr, "  clvox %s ...: exit %d: %s", a0, code, r.err);
    spawn_free(&r);
    return code;
}

static int slice_to_dense(void *user, uint32_t z, const float *values)
{
    float **d = user;
    const size_t n = (size_t)(uintptr_t)d[1];
    memcpy(d[0] + z * n, values, n * sizeof *values);
    return 0;
}

/* A channel as floats (malloc'ed), NULL when it cannot be read. */
static float *read_channel(const char *path, const char *channel, clvox_volume_info *info)
{
    clvox_volume_info h = CLVOX_VOLUME_INFO_INIT;
    if (clvox_volume_read(g_ctx, path, &h, NULL, 0) != CLVOX_OK) {
        fprintf(stderr, "  %s: %s\n", path, clvox_context_error(g_ctx));
        return NULL;
    }
    if (info) *info = h;
    const size_t plane = (size_t)h.dims[0] * h.dims[1], n = plane * h.dims[2];
    float *v = calloc(n, sizeof *v);
    float *d[2] = {v, (float *)(uintptr_t)plane};
    if (clvox_volume_read_slices(g_ctx, path, channel, NULL, slice_to_dense, d) != CLVOX_OK) {
        fprintf(stderr, "  %s %s: %s\n", path, channel, clvox_context_error(g_ctx));
        free(v);
        return NULL;
    }
    return v;
}

static int has_channel(const char *list, const char *name)
{
    size_t k = strlen(name);
    for (const char *p = list; (p = strstr(p, name)); p += k)
        if ((p == list || p[-1] == ',') && (p[k] == ',' || !p[k])) return 1;
    return 0;
}

/* 1 when the channel of `file` equals the EXR's: exactly, or (float32 ones)
 * after rounding to HALF. */
static int same_voxels(const char *file, const char *exr, const char *channel, int float32)
{
    clvox_volume_info a, b;
    float *x = read_channel(file, channel, &a), *y = read_channel(exr, channel, &b);
    int ok = x && y && memcmp(a.dims, b.dims, sizeof a.dims) == 0;
    const size_t n = (size_t)b.dims[0] * b.dims[1] * b.dims[2];
    size_t bad = 0, first = 0;
    for (size_t i = 0; ok && i < n; i++) {
        int eq = float32 ? clvox__half_from_unit(x[i]) == clvox__half_from_unit(y[i]) : x[i] == y[i];
        if (!eq && !bad++) first = i;
    }
    if (bad) fprintf(stderr, "  %s %s: %zu voxels differ, first %zu: %g vs %g\n", file, channel, bad, first,
                     (double)x[first], (double)y[first]);
    free(x);
    free(y);
    return ok && !bad;
}

/* The grid, filled count and channels of `file` against the EXR's. */
static void check_header(const char *file, const char *exr, const char *channels, int same_method, double tol)
{
    clvox_volume_info a = CLVOX_VOLUME_INFO_INIT, b = CLVOX_VOLUME_INFO_INIT;
    CHECK_OK(g_ctx, clvox_volume_read(g_ctx, file, &a, NULL, 0));
    CHECK_OK(g_ctx, clvox_volume_read(g_ctx, exr, &b, NULL, 0));
    CHECK_MSG(memcmp(a.dims, b.dims, sizeof a.dims) == 0, "%s: dims %u %u %u", file, a.dims[0], a.dims[1], a.dims[2]);
    for (int k = 0; k < 3; k++) {
        CHECK_MSG(fabs(a.origin[k] - b.origin[k]) <= tol * fabs(b.origin[k]), "%s: origin[%d] %.17g vs %.17g", file, k,
                  a.origin[k], b.origin[k]);
        CHECK_MSG(fabs(a.voxel_size[k] - b.voxel_size[k]) <= tol * b.voxel_size[k], "%s: voxel_size[%d] %.17g vs %.17g",
                  file, k, a.voxel_size[k], b.voxel_size[k]);
    }
    CHECK_MSG(a.filled_voxels == b.filled_voxels, "%s: filled %llu vs %llu", file,
              (unsigned long long)a.filled_voxels, (unsigned long long)b.filled_voxels);
    CHECK_MSG(strcmp(a.channels, channels) == 0, "%s: channels '%s', expected '%s'", file, a.channels, channels);
    if (same_method) {
        CHECK_MSG(strcmp(a.method, b.method) == 0, "%s: method '%s' vs '%s'", file, a.method, b.method);
        if (same_method > 1)
            CHECK_MSG(strcmp(a.parameters, b.parameters) == 0, "%s: parameters differ", file);
    }
}

static int same_files(const char *p, const char *q)
{
    long long n = file_size(p);
    if (n <= 0 || n != file_size(q)) return 0;
    FILE *f = fopen(p, "rb"), *g = fopen(q, "rb");
    int same = f && g;
    for (int c; same && (c = fgetc(f)) != EOF;) same = c == fgetc(g);
    if (f) fclose(f);
    if (g) fclose(g);
    return same;
}

/* `clvox info FILE` prints the EXR's "filled" line; `clvox convert FILE
 * x.exr` gives the EXR's main channel (byte-identical when `bytes`). */
static void check_cli(const char *file, const char *exr, const char *main_channel, int bytes, int float32)
{
    char *err = NULL;
    const char *info_args[] = {g_bin, "info", file, NULL}, *ref_args[] = {g_bin, "info", exr, NULL};
    spawn_result r, q;
    spawn_run(&r, info_args, 120);
    spawn_run(&q, ref_args, 120);
    const char *f1 = strstr(r.out, "\nfilled"), *f2 = strstr(q.out, "\nfilled");
    CHECK_MSG(r.code == 0 && f1 && f2 && strncmp(f1, f2, (size_t)(strchr(f2 + 1, '\n') - f2)) == 0,
              "clvox info %s: exit %d: %s%s", file, r.code, r.out, r.err);
    spawn_free(&r);
    spawn_free(&q);
    unlink(tmp("conv.exr"));
    unlink(tmp("ref.exr"));
    CHECK(run(NULL, "convert", file, tmp("conv.exr"), NULL) == 0);
    CHECK(run(NULL, "convert", exr, tmp("ref.exr"), NULL) == 0);
    if (bytes) CHECK_MSG(same_files(tmp("conv.exr"), tmp("ref.exr")), "convert %s -> exr: not byte-identical", file);
    CHECK_MSG(same_voxels(tmp("conv.exr"), tmp("ref.exr"), main_channel, float32), "convert %s -> exr", file);
    free(err);
}

typedef struct mode {
    const char *name;
    const char *args[6];
    const char *channels; /* as the EXR lists them */
} mode;

/* The voxelization of `m` into `out` (extra options after). */
static int voxelize(const mode *m, const char *out, const char *x1, const char *x2)
{
    const char *argv[24] = {g_bin, tmp("torus.off"), "-r", "20", "--box", "-1.2,-1.2,-1.2,1.2,1.2,1.2", "-q"};
    size_t n = 7;
    for (int i = 0; m->args[i]; i++) argv[n++] = m->args[i];
    if (x1) argv[n++] = x1;
    if (x2) argv[n++] = x2;
    argv[n++] = "-o";
    argv[n++] = out;
    argv[n] = NULL;
    spawn_result r;
    int code = spawn_run(&r, argv, 300);
    if (code != 0) fprintf(stderr, "  voxelize %s -> %s: %s", m->name, out, r.err);
    spawn_free(&r);
    return code == 0;
}

/* A corrupt file: `clvox info` fails with exit 4 and one line on stderr. */
static void expect_bad(const char *file, const char *what)
{
    char *err = NULL;
    int code = run(&err, "info", file, NULL);
    const char *nl = err ? strchr(err, '\n') : NULL;
    CHECK_MSG(code == 4 && err && err[0] && nl && !nl[1], "%s: clvox info %s: exit %d, stderr '%s'", what, file, code,
              err ? err : "");
    if (err && err[0] && code == 4) { /* the library says why too */
        clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
        clvox_status st = clvox_volume_read(g_ctx, file, &info, NULL, 0);
        CHECK_MSG(st != CLVOX_OK && clvox_context_error(g_ctx)[0], "%s: read gave %s", what, clvox_status_string(st));
    }
    free(err);
}

static int copy_file(const char *from, const char *to, long long keep, long long flip_at)
{
    FILE *f = fopen(from, "rb"), *g = fopen(to, "wb");
    int ok = f && g;
    long long i = 0;
    for (int c; ok && (c = fgetc(f)) != EOF && (keep < 0 || i < keep); i++) ok = fputc(i == flip_at ? c ^ 0x5A : c, g) != EOF;
    if (f) fclose(f);
    if (g && fclose(g) != 0) ok = 0;
    return ok;
}

int main(void)
{
    g_bin = getenv("CLVOX_BIN");
    if (!g_bin) {
        fprintf(stderr, "test_readback needs CLVOX_BIN (the clvox binary)\n");
        return 1;
    }
    snprintf(g_dir, sizeof g_dir, "%s/readback", test_tmpdir());
    rm_tree(g_dir);
    mkdir(g_dir, 0777);
    g_ctx = test_context();
    tmesh t = tmesh_torus(0.05, -0.02, 0.01, 0.7, 0.3, 48, 24);
    CHECK(tmesh_write_off(&t, tmp("torus.off")) == 0);
    /* is .vdb written here (a build with OpenVDB)? */
    tmesh_free(&t);
    const mode modes[] = {
        {"occupancy", {NULL}, "occupancy"},
        {"coverage", {"--oversample", "2", NULL}, "coverage"},
        {"both", {"--oversample", "2", "--channels", "occupancy,coverage", NULL}, "coverage,occupancy"},
        {"palette", {"--palette", "planar10", NULL}, NULL},
    };
    const mode *occ_mode = &modes[0];
    const int vdb = voxelize(occ_mode, tmp("probe.vdb"), NULL, NULL);
    if (!vdb) printf("note: no .vdb here (clvox built without OpenVDB): the .vdb cases are left out\n");

    for (size_t mi = 0; mi < sizeof modes / sizeof *modes; mi++) {
        const mode *m = &modes[mi];
        char exr[2400];
        snprintf(exr, sizeof exr, "%s", tmp("ref_run.exr"));
        unlink(exr);
        CHECK(voxelize(m, exr, NULL, NULL));
        clvox_volume_info ref = CLVOX_VOLUME_INFO_INIT;
        CHECK_OK(g_ctx, clvox_volume_read(g_ctx, exr, &ref, NULL, 0));
        if (m->channels) CHECK_MSG(strcmp(ref.channels, m->channels) == 0, "%s: EXR channels %s", m->name, ref.channels);
        printf("mode %s: channels %s, %llu filled\n", m->name, ref.channels, (unsigned long long)ref.filled_voxels);
        const char *main_channel = has_channel(ref.channels, "occupancy") ? "occupancy"
                                   : has_channel(ref.channels, "element") ? "element" : "coverage";
        static const char *const all[4] = {"coverage", "element", "occupancy", "score"};
        /* npy: default, and each storage flag */
        static const char *const npy_flags[] = {NULL, "--npy-bits", "--npy-float32", "--npy-uint32"};
        for (size_t f = 0; f < 4; f++) {
            const char *out = tmp("run.npy");
            CHECK(voxelize(m, out, npy_flags[f], NULL));
            const int f32 = f == 2;
            check_header(out, exr, ref.channels, 2, 0);
            for (int c = 0; c < 4; c++)
                if (has_channel(ref.channels, all[c]))
                    CHECK_MSG(same_voxels(out, exr, all[c], f32 && c != 1 && c != 2), "%s npy %s %s", m->name,
                              npy_flags[f] ? npy_flags[f] : "", all[c]);
            check_cli(out, exr, main_channel, !f32 || strcmp(main_channel, "coverage") != 0, f32);
        }
        if (strcmp(m->name, "occupancy") == 0) {
            /* formats told by their magic under other names */
            CHECK(voxelize(m, tmp("one.nrrd"), NULL, NULL));
            CHECK(copy_file(tmp("one.nrrd"), tmp("nrrd.dat"), -1, -1));
            check_header(tmp("nrrd.dat"), exr, ref.channels, 1, 0);
            CHECK(copy_file(exr, tmp("exr.npy"), -1, -1));
            check_header(tmp("exr.npy"), exr, ref.channels, 2, 0);
            /* a lone .npy (no sidecar): its channel by dtype, on a unit grid */
            CHECK(copy_file(tmp("run.npy"), tmp("lone.npy"), -1, -1));
            clvox_volume_info lone = CLVOX_VOLUME_INFO_INIT;
            CHECK_OK(g_ctx, clvox_volume_read(g_ctx, tmp("lone.npy"), &lone, NULL, 0));
            CHECK(memcmp(lone.dims, ref.dims, sizeof lone.dims) == 0 && lone.filled_voxels == ref.filled_voxels &&
                  strcmp(lone.channels, "occupancy") == 0 && lone.voxel_size[0] == 1.0 && lone.origin[0] == 0.0);
        }
        /* NRRD raw and gzip (float32 coverage and score), one file per channel */
        static const char *const nrrd_comp[] = {"none", "zip"};
        for (int k = 0; k < 2; k++) {
            const char *out = tmp("run.nrrd");
            CHECK(voxelize(m, out, "--compression", nrrd_comp[k]));
            check_header(out, exr, ref.channels, 1, 0);
            for (int c = 0; c < 4; c++)
                if (has_channel(ref.channels, all[c]))
                    CHECK_MSG(same_voxels(out, exr, all[c], c == 0 || c == 3), "%s nrrd %s %s", m->name,
                              nrrd_comp[k], all[c]);
            check_cli(out, exr, main_channel, 0, 1);
        }
        /* a detached header over the raw NRRD's data (main channel only) */
        CHECK(voxelize(m, tmp("raw.nrrd"), "--compression", "none"));
        char *text = read_all(tmp("raw.nrrd"));
        char *blank = strstr(text, "\n\n");
        CHECK(blank != NULL);
        if (blank) {
            const long long hl = blank + 2 - text, total = file_size(tmp("raw.nrrd"));
            FILE *in = fopen(tmp("raw.nrrd"), "rb"), *o = fopen(tmp("data.raw"), "wb");
            for (long long i = 0; in && o && i < total; i++) {
                int c = fgetc(in);
                if (i >= hl) fputc(c, o);
            }
            if (in) fclose(in);
            if (o) fclose(o);
            char *set = strstr(text, "clvox_set:=");
            if (set) *set = '\0'; /* the other members are not beside the .nhdr */
            else blank[1] = '\0';
            char *nhdr = malloc(strlen(text) + 64);
            snprintf(nhdr, strlen(text) + 64, "%sdata file: data.raw\n", text);
            CHECK(write_text(tmp("run.nhdr"), nhdr));
            free(nhdr);
            CHECK_MSG(same_voxels(tmp("run.nhdr"), exr, main_channel, strcmp(main_channel, "coverage") == 0),
                      "%s nhdr", m->name);
            /* a detached header whose data is missing: one line */
            CHECK(unlink(tmp("data.raw")) == 0);
            expect_bad(tmp("run.nhdr"), "nhdr without its data");
        }
        free(text);
        /* binvox: occupancy only */
        if (strcmp(m->name, "occupancy") == 0) {
            const char *out = tmp("run.binvox");
            CHECK(voxelize(m, out, NULL, NULL));
            check_header(out, exr, "occupancy", 0, 1e-14);
            CHECK(same_voxels(out, exr, "occupancy", 0));
            check_cli(out, exr, "occupancy", 0, 0);
        }
        /* OpenVDB: occupancy and coverage */
        if (vdb && strcmp(m->name, "palette") != 0) {
            const char *out = tmp("run.vdb");
            CHECK(voxelize(m, out, NULL, NULL));
            check_header(out, exr, ref.channels, 2, 0);
            for (int c = 0; c < 4; c++)
                if (has_channel(ref.channels, all[c]))
                    CHECK_MSG(same_voxels(out, exr, all[c], c == 0), "%s vdb %s", m->name, all[c]);
            check_cli(out, exr, main_channel, strcmp(main_channel, "coverage") != 0, 1);
        }
        /* clvox preview draws the same picture from the npy as from the EXR */
        if (strcmp(m->name, "coverage") == 0 || strcmp(m->name, "occupancy") == 0) {
            CHECK(voxelize(m, tmp("run.npy"), NULL, NULL));
            CHECK(run(NULL, "preview", tmp("run.npy"), "-o", tmp("npy.png"), NULL) == 0);
            CHECK(run(NULL, "preview", exr, "-o", tmp("exr.png"), NULL) == 0);
            CHECK_MSG(same_files(tmp("npy.png"), tmp("exr.png")), "%s: preview of the npy differs", m->name);
        }
    }

    /* truncated and corrupt files: one line, exit 4, never a crash */
    CHECK(voxelize(occ_mode, tmp("c.npy"), NULL, NULL));
    CHECK(voxelize(occ_mode, tmp("c.nrrd"), "--compression", "none"));
    CHECK(voxelize(occ_mode, tmp("z.nrrd"), "--compression", "zip"));
    CHECK(voxelize(occ_mode, tmp("c.binvox"), NULL, NULL));
    const long long npy_n = file_size(tmp("c.npy")), nrrd_n = file_size(tmp("c.nrrd")), z_n = file_size(tmp("z.nrrd")),
                    bv_n = file_size(tmp("c.binvox"));
    char *head = read_all(tmp("c.nrrd"));
    const long long sizes_at = strstr(head, "sizes: ") ? strstr(head, "sizes: ") - head + 7 : 7;
    free(head);
    struct { const char *from, *to; long long keep, flip; const char *what; } bad[] = {
        {"c.npy", "t.npy", npy_n - 1, -1, "npy short by a byte"},
        {"c.npy", "h.npy", 40, -1, "npy cut in its header"},
        {"c.npy", "f.npy", -1, 20, "npy header corrupt"},
        {"c.nrrd", "t.nrrd", nrrd_n - 100, -1, "raw NRRD truncated"},
        {"c.nrrd", "h.nrrd", 30, -1, "NRRD cut in its header"},
        {"c.nrrd", "f.nrrd", -1, sizes_at, "NRRD sizes corrupt"},
        {"c.nrrd", "m.nrrd", -1, 5, "NRRD magic corrupt"},
        {"z.nrrd", "tz.nrrd", z_n - 20, -1, "gzip NRRD truncated"},
        {"z.nrrd", "fz.nrrd", -1, z_n - 40, "gzip NRRD corrupt"},
        {"c.binvox", "t.binvox", bv_n - 2, -1, "binvox truncated"},
        {"c.binvox", "f.binvox", -1, bv_n - 2, "binvox value corrupt"},
        {"c.binvox", "h.binvox", 12, -1, "binvox cut in its header"},
        {"probe.vdb", "t.vdb", 200, -1, "OpenVDB truncated"},
    };
    char *err = NULL;
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        if (!vdb && strstr(bad[i].from, ".vdb")) continue;
        CHECK(copy_file(tmp(bad[i].from), tmp(bad[i].to), bad[i].keep, bad[i].flip));
        /* npy sidecars: t.json etc. name the member file */
        if (strstr(bad[i].to, ".npy")) {
            char *json = read_all(tmp("c.json"));
            char *at = strstr(json, "\"c.npy\"");
            if (at) at[1] = bad[i].to[0];
            char name[16];
            snprintf(name, sizeof name, "%c.json", bad[i].to[0]);
            CHECK(write_text(tmp(name), json));
            free(json);
        }
        expect_bad(tmp(bad[i].to), bad[i].what);
    }
    if (vdb) { /* a .vdb without the plugin: one line that says so */
        setenv("CLVOX_VDB_PLUGIN", tmp("no-such-plugin.so"), 1);
        err = NULL;
        CHECK(run(&err, "info", tmp("probe.vdb"), NULL) == 4 && strstr(err, "OpenVDB plugin") &&
              strchr(err, '\n') && !strchr(err, '\n')[1]);
        free(err);
        unsetenv("CLVOX_VDB_PLUGIN");
    }
    /* a sidecar cut short; one that lists another file; an unknown magic */
    char *json = read_all(tmp("c.json"));
    json[strlen(json) / 2] = '\0';
    CHECK(write_text(tmp("c.json"), json));
    free(json);
    expect_bad(tmp("c.npy"), "npy sidecar cut short");
    CHECK(write_text(tmp("junk.npy"), "this is not a volume\n"));
    expect_bad(tmp("junk.npy"), "text named .npy");
    err = NULL;
    CHECK(run(&err, "info", tmp("junk.npy"), NULL) == 4 && strstr(err, "not a volume clvox reads"));
    free(err);
    rm_tree(g_dir);
    clvox_context_destroy(g_ctx);
    return test_report();
}
