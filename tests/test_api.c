/* SPDX-License-Identifier: Apache-2.0 */
/* The library and the command line, told apart (issue 33):
 *  - libclvox.so exports the functions clvox.h marks CLVOX_API and nothing
 *    else: every dynamic symbol it defines is a clvox_ name declared in the
 *    header (no clvox__ internal, no C++ or helper symbol), and every
 *    declared function is there;
 *  - every file of src/cli includes only the public header, its own
 *    headers (src/cli/cli_*.h) and system headers;
 *  - output structs that may grow check their .size and write no more;
 *  - the entry points the command line uses instead of internals work.
 * Runs from the repository root (tests/run_tests.sh does); the library is
 * the one beside this program's directory (build/CONFIG/libclvox.so). */
#include "test.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* ---- names ---------------------------------------------------------------------- */

typedef struct names {
    char **v;
    size_t n, cap;
} names;

static void names_add(names *s, const char *name, size_t len)
{
    if (s->n == s->cap) {
        s->cap = s->cap ? 2 * s->cap : 64;
        s->v = realloc(s->v, s->cap * sizeof *s->v);
        if (!s->v) abort();
    }
    s->v[s->n] = malloc(len + 1);
    if (!s->v[s->n]) abort();
    memcpy(s->v[s->n], name, len);
    s->v[s->n][len] = '\0';
    s->n++;
}

static int names_has(const names *s, const char *name)
{
    for (size_t i = 0; i < s->n; i++)
        if (strcmp(s->v[i], name) == 0) return 1;
    return 0;
}

static void names_free(names *s)
{
    for (size_t i = 0; i < s->n; i++) free(s->v[i]);
    free(s->v);
    memset(s, 0, sizeof *s);
}

/* The functions clvox.h declares CLVOX_API: the name before the first '('
 * of each declaration that begins with the macro. */
static void declared_functions(const char *header, names *out)
{
    FILE *f = fopen(header, "r");
    CHECK_MSG(f != NULL, "cannot open %s: %s", header, strerror(errno));
    if (!f) return;
    char line[1024];
    while (fgets(line, sizeof line, f)) {
        if (strncmp(line, "CLVOX_API ", 10) != 0) continue;
        const char *paren = strchr(line, '(');
        CHECK_MSG(paren != NULL, "%s: a CLVOX_API line without '(': %s", header, line);
        if (!paren) continue;
        const char *end = paren;
        const char *start = end;
        while (start > line && (start[-1] == '_' || (start[-1] >= 'a' && start[-1] <= 'z') ||
                                (start[-1] >= 'A' && start[-1] <= 'Z') || (start[-1] >= '0' && start[-1] <= '9')))
            start--;
        names_add(out, start, (size_t)(end - start));
    }
    fclose(f);
}

/* Whether the header marks every function it declares: a line that starts
 * a declaration (a return type at column 0, a name, a '(') without the
 * macro would be hidden from the shared library. */
static void every_declaration_marked(const char *header)
{
    FILE *f = fopen(header, "r");
    if (!f) return;
    char line[1024];
    unsigned no = 0, unmarked = 0;
    static const char *const types[] = {"const ", "void ", "clvox_status ", "clvox_format ", "int ", "uint32_t ",
                                        "uint64_t ", "size_t ", "unsigned ", "double "};
    while (fgets(line, sizeof line, f)) {
        no++;
        for (size_t t = 0; t < sizeof types / sizeof types[0]; t++) {
            if (strncmp(line, types[t], strlen(types[t])) == 0 && strchr(line, '(') && !strstr(line, "typedef")) {
                unmarked++;
                CHECK_MSG(0, "%s:%u: a declaration without CLVOX_API: %s", header, no, line);
                break;
            }
        }
    }
    fclose(f);
    CHECK_MSG(unmarked == 0, "%u declarations of %s are not exported", unmarked, header);
}

/* The library beside this program's directory: build/CONFIG/libclvox.so. */
static void library_path(char *buf, size_t size)
{
    char exe[PATH_MAX];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n <= 0) {
        snprintf(buf, size, "build/release/libclvox.so");
        return;
    }
    exe[n] = '\0';
    char *slash = strrchr(exe, '/'); /* .../build/CONFIG/tests/test_api */
    if (slash) *slash = '\0';
    slash = strrchr(exe, '/');
    if (slash) *slash = '\0';
    snprintf(buf, size, "%s/libclvox.so", exe);
}

static void test_exports(void)
{
    char lib[PATH_MAX + 32];
    library_path(lib, sizeof lib);
    struct stat sb;
    CHECK_MSG(stat(lib, &sb) == 0, "no shared library at %s", lib);
    names declared = {0};
    declared_functions("include/clvox.h", &declared);
    CHECK_MSG(declared.n >= 60, "only %zu CLVOX_API declarations found in include/clvox.h", declared.n);
    every_declaration_marked("include/clvox.h");

    /* nm -D --defined-only: "ADDRESS TYPE NAME" per symbol the library
     * defines in its dynamic symbol table, which is what a program linking
     * it can bind to. */
    char cmd[PATH_MAX + 128];
    snprintf(cmd, sizeof cmd, "nm -D --defined-only '%s' 2>&1", lib);
    FILE *p = popen(cmd, "r");
    CHECK_MSG(p != NULL, "cannot run %s", cmd);
    if (!p) {
        names_free(&declared);
        return;
    }
    names exported = {0};
    char line[2048];
    unsigned bad = 0;
    while (fgets(line, sizeof line, p)) {
        line[strcspn(line, "\n")] = '\0';
        const char *name = strrchr(line, ' ');
        name = name ? name + 1 : line;
        char type = 0;
        const char *sp = strchr(line, ' ');
        if (sp && sp[1] && sp[2] == ' ') type = sp[1];
        /* Only clvox_ names that clvox.h declares; no clvox__ internal, no
         * C++ symbol of the OpenMesh reader, no helper. (GNU ld puts no
         * _init/_fini/_edata/... into .dynsym of a -shared link by
         * default; were one to appear, this test names it.) */
        int ok = strncmp(name, "clvox_", 6) == 0 && strncmp(name, "clvox__", 7) != 0 && names_has(&declared, name);
        if (!ok) {
            bad++;
            if (bad <= 20) CHECK_MSG(0, "libclvox.so exports '%s' (%c), not a public clvox.h function", name, type);
        }
        names_add(&exported, name, strlen(name));
    }
    int rc = pclose(p);
    CHECK_MSG(rc == 0, "nm -D failed (%d) on %s", rc, lib);
    CHECK_MSG(bad == 0, "libclvox.so exports %u names that are not public API", bad);
    CHECK_MSG(exported.n >= declared.n, "libclvox.so exports %zu names, clvox.h declares %zu", exported.n, declared.n);
    for (size_t i = 0; i < declared.n; i++)
        CHECK_MSG(names_has(&exported, declared.v[i]), "clvox.h declares %s, libclvox.so does not export it",
                  declared.v[i]);
    names_free(&exported);
    names_free(&declared);
}

/* ---- the command line's includes ---------------------------------------------- */

/* One #include line of a CLI file: the public header, a CLI header that is
 * in src/cli, or a system header that is not one of the library's (a
 * <core/internal.h> through some -I would be). */
static int cli_include_ok(const char *file, unsigned no, const char *line)
{
    const char *p = line;
    while (*p == ' ' || *p == '\t') p++;
    if (*p != '#') return 1;
    p++;
    while (*p == ' ' || *p == '\t') p++;
    if (strncmp(p, "include", 7) != 0) return 1;
    p += 7;
    while (*p == ' ' || *p == '\t') p++;
    char close = *p == '"' ? '"' : *p == '<' ? '>' : 0;
    if (!close) {
        CHECK_MSG(0, "%s:%u: an #include this test cannot read: %s", file, no, line);
        return 0;
    }
    const char *name = p + 1;
    const char *end = strchr(name, close);
    if (!end) return 0;
    char inc[512];
    snprintf(inc, sizeof inc, "%.*s", (int)(end - name), name);
    if (strcmp(inc, "clvox.h") == 0) return 1;
    if (strchr(inc, '/') || strstr(inc, "..")) { /* "core/internal.h", <io/output_set.h>, "../x.h" */
        char in_src[600];
        snprintf(in_src, sizeof in_src, "src/%s", inc);
        struct stat sb;
        if (close == '"' || stat(in_src, &sb) == 0 || strstr(inc, "..")) {
            CHECK_MSG(0, "%s:%u: includes \"%s\", not the public header or its own", file, no, inc);
            return 0;
        }
        return 1; /* <sys/stat.h> and the like */
    }
    if (close == '"') {
        char own[600];
        snprintf(own, sizeof own, "src/cli/%s", inc);
        struct stat sb;
        if (strncmp(inc, "cli_", 4) == 0 && stat(own, &sb) == 0) return 1;
        CHECK_MSG(0, "%s:%u: includes \"%s\", which is not in src/cli", file, no, inc);
        return 0;
    }
    /* <name.h>: a system header, unless the library has one of that name */
    static const char *const dirs[] = {"src", "src/core", "src/mesh", "src/grid", "src/cast", "src/winding",
                                       "src/raster", "src/palette", "src/io", "kernels"};
    for (size_t d = 0; d < sizeof dirs / sizeof dirs[0]; d++) {
        char lib_header[600];
        snprintf(lib_header, sizeof lib_header, "%s/%s", dirs[d], inc);
        struct stat sb;
        if (stat(lib_header, &sb) == 0) {
            CHECK_MSG(0, "%s:%u: includes <%s>, the library's %s", file, no, inc, lib_header);
            return 0;
        }
    }
    return 1;
}

static void test_cli_includes(void)
{
    DIR *d = opendir("src/cli");
    CHECK_MSG(d != NULL, "cannot open src/cli: %s (run from the repository root)", strerror(errno));
    if (!d) return;
    unsigned files = 0, includes = 0, bad = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        size_t n = strlen(e->d_name);
        if (n < 3 || !(strcmp(e->d_name + n - 2, ".c") == 0 || strcmp(e->d_name + n - 2, ".h") == 0)) continue;
        char path[600];
        snprintf(path, sizeof path, "src/cli/%s", e->d_name);
        FILE *f = fopen(path, "r");
        CHECK_MSG(f != NULL, "cannot open %s", path);
        if (!f) continue;
        files++;
        char line[1024];
        unsigned no = 0;
        while (fgets(line, sizeof line, f)) {
            no++;
            if (strstr(line, "include")) {
                if (strstr(line, "#") && strstr(line, "include")) includes++;
                if (!cli_include_ok(path, no, line)) bad++;
            }
            /* and no internal name: the CLI calls the library only through clvox.h */
            const char *u = strstr(line, "clvox__");
            if (u && !strstr(line, "* ") && !strstr(line, "//")) {
                bad++;
                CHECK_MSG(0, "%s:%u: uses a library internal: %s", path, no, line);
            }
        }
        fclose(f);
    }
    closedir(d);
    CHECK_MSG(files >= 10 && includes >= files, "only %u files and %u includes seen in src/cli", files, includes);
    CHECK_MSG(bad == 0, "%u includes or names of src/cli reach into the library", bad);
}

/* ---- output structs that may grow ------------------------------------------------ */

/* A caller's struct in a buffer with a canary after it: the library must
 * write neither past .size nor anything when .size is refused. */
#define CANARY 0xA5
static int canary_intact(const unsigned char *b, size_t from, size_t to)
{
    for (size_t i = from; i < to; i++)
        if (b[i] != CANARY) return 0;
    return 1;
}

static void test_output_struct_sizes(clvox_context *ctx)
{
    const char *tmp = test_tmpdir();
    clvox_palette *pal = NULL;
    CHECK_OK(ctx, clvox_palette_builtin(ctx, "planar10", &pal));
    if (!pal) return;

    unsigned char buf[sizeof(clvox_palette_element_info) + 64];
    clvox_palette_element_info *info = (clvox_palette_element_info *)(void *)buf;
    size_t sizes[] = {0, 4, sizeof(size_t), sizeof *info + 8};
    for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
        memset(buf, CANARY, sizeof buf);
        info->size = sizes[k];
        CHECK_STATUS(ctx, clvox_palette_element_info_get(ctx, pal, 2, info), CLVOX_ERR_INVALID_ARGUMENT);
        CHECK_MSG(canary_intact(buf, sizeof(size_t), sizeof buf), "element info with .size %zu was written",
                  sizes[k]);
        CHECK_MSG(strstr(clvox_context_error(ctx), "clvox_palette_element_info.size") != NULL, "message: %s",
                  clvox_context_error(ctx));
    }
    memset(buf, CANARY, sizeof buf);
    info->size = sizeof *info;
    CHECK_OK(ctx, clvox_palette_element_info_get(ctx, pal, 2, info));
    CHECK(info->size == sizeof *info);
    CHECK(info->name[0] != '\0' && info->volume > 0.0 && info->volume < 1.0);
    CHECK_MSG(canary_intact(buf, sizeof *info, sizeof buf), "element info written past its size");

    /* a volume to read back */
    char path[1024];
    snprintf(path, sizeof path, "%s/api_volume.exr", tmp);
    clvox_grid g = {{4, 3, 2}, {0, 0, 0}, {1, 1, 1}};
    clvox_output_options oo = CLVOX_OUTPUT_OPTIONS_INIT;
    clvox_volume_writer *w = NULL;
    CHECK_OK(ctx, clvox_volume_writer_open(ctx, path, &g, CLVOX_CHANNEL_OCCUPANCY, &oo, &w));
    float slice[12];
    for (int i = 0; i < 12; i++) slice[i] = (float)(i % 2);
    for (uint32_t z = 0; z < 2 && w; z++) CHECK_OK(ctx, clvox_volume_writer_slice(w, CLVOX_CHANNEL_OCCUPANCY, z, slice));
    if (w) CHECK_OK(ctx, clvox_volume_writer_finish(w, NULL));

    unsigned char vb[sizeof(clvox_volume_info) + 64];
    clvox_volume_info *vi = (clvox_volume_info *)(void *)vb;
    memset(vb, CANARY, sizeof vb);
    vi->size = 0; /* a caller that forgot: refused, not half-filled */
    CHECK_STATUS(ctx, clvox_volume_read(ctx, path, vi, NULL, 0), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK(canary_intact(vb, sizeof(size_t), sizeof vb));
    vi->size = sizeof *vi + 1;
    CHECK_STATUS(ctx, clvox_volume_read(ctx, path, vi, NULL, 0), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK(canary_intact(vb, sizeof(size_t), sizeof vb));
    vi->size = sizeof *vi;
    CHECK_OK(ctx, clvox_volume_read(ctx, path, vi, NULL, 0));
    CHECK(vi->size == sizeof *vi && vi->dims[0] == 4 && vi->dims[1] == 3 && vi->dims[2] == 2);
    CHECK_MSG(vi->filled_voxels == 12, "filled %llu", (unsigned long long)vi->filled_voxels);
    CHECK_MSG(canary_intact(vb, sizeof *vi, sizeof vb), "volume info written past its size");
    clvox_volume_info plain = CLVOX_VOLUME_INFO_INIT;
    CHECK_OK(ctx, clvox_volume_read(ctx, path, &plain, NULL, 0));
    CHECK(plain.size == sizeof plain && plain.filled_voxels == 12);
    CHECK_OK(ctx, clvox_volume_read(ctx, path, NULL, NULL, 0)); /* NULL: nothing to size */

    /* devices: out[0].size is checked before any OpenCL call */
    clvox_device_info devs[2];
    memset(devs, CANARY, sizeof devs);
    devs[0].size = 3;
    size_t count = 0;
    CHECK(clvox_list_devices(devs, 2, &count) == CLVOX_ERR_INVALID_ARGUMENT);
    CHECK(canary_intact((const unsigned char *)devs, sizeof(size_t), sizeof devs));

    /* stats: refused before any work (a host-only context is enough to see it) */
    clvox_stats st;
    memset(&st, CANARY, sizeof st);
    st.size = 1;
    clvox_mesh *m = NULL;
    const float v[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    const uint32_t t[] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
    CHECK_OK(ctx, clvox_mesh_from_arrays(ctx, v, 4, t, 4, &m));
    uint8_t occ[24];
    CHECK_STATUS(ctx, clvox_voxelize_to_memory(ctx, m, &g, NULL, occ, sizeof occ, &st), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_MSG(strstr(clvox_context_error(ctx), "clvox_stats.size") != NULL, "message: %s", clvox_context_error(ctx));
    CHECK(canary_intact((const unsigned char *)&st, sizeof(size_t), sizeof st));
    clvox_mesh_destroy(m);

    /* the PLY export's totals */
    clvox_palette *binary = NULL;
    CHECK_OK(ctx, clvox_palette_builtin(ctx, "binary", &binary));
    clvox_ply_export *x = NULL;
    const uint32_t dims[3] = {1, 1, 1};
    const double origin[3] = {0, 0, 0}, h[3] = {1, 1, 1};
    CHECK_OK(ctx, clvox_ply_export_create(ctx, binary, dims, origin, h, 0, &x));
    const float full = 1.0f;
    if (x) CHECK_OK(ctx, clvox_ply_export_count(x, 0, &full));
    clvox_ply_totals tot;
    memset(&tot, 0, sizeof tot);
    if (x) CHECK_STATUS(ctx, clvox_ply_export_totals(x, &tot), CLVOX_ERR_INVALID_ARGUMENT);
    clvox_ply_totals tot2 = CLVOX_PLY_TOTALS_INIT;
    if (x) CHECK_OK(ctx, clvox_ply_export_totals(x, &tot2));
    CHECK_MSG(tot2.voxels == 1 && tot2.triangles == 12 && tot2.bytes > tot2.header_bytes,
              "totals: %llu voxels, %llu triangles", (unsigned long long)tot2.voxels,
              (unsigned long long)tot2.triangles);
    clvox_ply_export_destroy(x);
    clvox_palette_destroy(binary);
    clvox_palette_destroy(pal);
    unlink(path);
}

/* ---- the entry points the command line uses ---------------------------------- */

static void test_output_file(clvox_context *ctx)
{
    const char *tmp = test_tmpdir();
    char path[1024], dir[1024], fifo[1024];
    snprintf(path, sizeof path, "%s/api_out.txt", tmp);
    snprintf(dir, sizeof dir, "%s/api_dir", tmp);
    snprintf(fifo, sizeof fifo, "%s/api_fifo", tmp);
    unlink(path);
    mkdir(dir, 0777);

    clvox_output_file *of = NULL;
    CHECK_OK(ctx, clvox_output_file_create(ctx, path, &of));
    int fd = clvox_output_file_fd(of);
    CHECK(fd >= 0);
    CHECK(write(fd, "hello\n", 6) == 6);
    CHECK_MSG(access(path, F_OK) != 0, "the file has its name before the commit");
    uint64_t bytes = 0;
    CHECK_OK(ctx, clvox_output_file_commit(of, &bytes));
    CHECK(bytes == 6);
    struct stat sb;
    CHECK(stat(path, &sb) == 0 && S_ISREG(sb.st_mode) && sb.st_size == 6);

    /* discarded: the old file stays as it was */
    CHECK_OK(ctx, clvox_output_file_create(ctx, path, &of));
    CHECK(write(clvox_output_file_fd(of), "x", 1) == 1);
    clvox_output_file_discard(of);
    CHECK(stat(path, &sb) == 0 && sb.st_size == 6);
    clvox_output_file_discard(NULL);

    /* empty: refused, nothing replaced */
    CHECK_OK(ctx, clvox_output_file_create(ctx, path, &of));
    CHECK_STATUS(ctx, clvox_output_file_commit(of, NULL), CLVOX_ERR_IO);
    CHECK(stat(path, &sb) == 0 && sb.st_size == 6);

    /* not a regular file at the path */
    of = (clvox_output_file *)&of;
    CHECK_STATUS(ctx, clvox_output_file_create(ctx, dir, &of), CLVOX_ERR_IO);
    CHECK(of == NULL);
    CHECK_MSG(strstr(clvox_context_error(ctx), "directory") != NULL, "message: %s", clvox_context_error(ctx));

    /* reading: a regular file, never a directory or a FIFO */
    const char *why = NULL;
    int rfd = clvox_open_regular_read(path, &why);
    CHECK(rfd >= 0);
    if (rfd >= 0) close(rfd);
    CHECK(clvox_open_regular_read(dir, &why) == -1 && why && strcmp(why, strerror(EISDIR)) == 0);
    unlink(fifo);
    if (mkfifo(fifo, 0666) == 0) {
        why = NULL;
        CHECK(clvox_open_regular_read(fifo, &why) == -1 && why && strstr(why, "not a regular file"));
        unlink(fifo);
    }
    snprintf(fifo, sizeof fifo, "%s/api_missing", tmp);
    CHECK(clvox_open_regular_read(fifo, &why) == -1 && why && strcmp(why, strerror(ENOENT)) == 0);

    /* --skip-existing: a plain .exr is complete when it is a regular file */
    char why_buf[512] = "";
    CHECK(clvox_output_complete(path, why_buf, sizeof why_buf) == 1);
    CHECK(clvox_output_complete(fifo, why_buf, sizeof why_buf) == 0 && strstr(why_buf, "does not exist"));
    CHECK(clvox_output_complete(dir, why_buf, sizeof why_buf) == 0 && strstr(why_buf, "not a regular file"));
    CHECK(clvox_npy_set_complete(fifo, NULL, why_buf, sizeof why_buf) == 0 && why_buf[0]);
    unlink(path);
    rmdir(dir);
}

static void test_grid_like(clvox_context *ctx)
{
    static const char nrrd[] = "NRRD0004\n"
                               "type: uint8\n"
                               "dimension: 3\n"
                               "space: left-posterior-superior\n"
                               "sizes: 4 5 6\n"
                               "space directions: (0.5,0,0) (0,0.5,0) (0,0,2)\n"
                               "space origin: (1.25,0.25,1)\n"
                               "encoding: raw\n"
                               "\n";
    clvox_grid g;
    char note[256] = "x";
    CHECK_OK(ctx, clvox_grid_from_nrrd_header(ctx, "api.nrrd", nrrd, sizeof nrrd - 1, &g, note, sizeof note));
    CHECK(g.dims[0] == 4 && g.dims[1] == 5 && g.dims[2] == 6);
    CHECK(g.voxel_size[0] == 0.5 && g.voxel_size[2] == 2.0);
    CHECK_MSG(g.origin[0] == 1.0 && g.origin[1] == 0.0 && g.origin[2] == 0.0, "origin %g %g %g", g.origin[0],
              g.origin[1], g.origin[2]); /* the centre of voxel 0 minus h/2 */
    CHECK(note[0] == '\0');
    CHECK_STATUS(ctx, clvox_grid_from_nrrd_header(ctx, "bad.nrrd", "NRRD", 4, &g, NULL, 0), CLVOX_ERR_GRID);
    CHECK_MSG(strstr(clvox_context_error(ctx), "bad.nrrd") != NULL, "message: %s", clvox_context_error(ctx));
    CHECK_STATUS(ctx, clvox_grid_from_nrrd_header(ctx, "x", NULL, 0, &g, NULL, 0), CLVOX_ERR_INVALID_ARGUMENT);

    static const char json[] = "{\"format\": \"npy\", \"dims\": [2, 3, 4], \"origin\": [0, 1, 2], "
                               "\"voxel_size\": [0.5, 0.5, 0.25]}";
    CHECK_OK(ctx, clvox_grid_from_npy_sidecar(ctx, "api.json", json, sizeof json - 1, &g));
    CHECK(g.dims[0] == 2 && g.dims[1] == 3 && g.dims[2] == 4 && g.origin[1] == 1.0 && g.voxel_size[2] == 0.25);
    CHECK_STATUS(ctx, clvox_grid_from_npy_sidecar(ctx, "bad.json", "{}", 2, &g), CLVOX_ERR_GRID);
}

/* The library reads the environment only in src/core/environment.c (the
 * test hooks and the user's settings); the CLI may read it anywhere. */
static void test_getenv_in_one_place(void)
{
    FILE *f = popen("grep -rln --include='*.c' --include='*.cpp' --include='*.h' 'getenv *(' src", "r");
    CHECK_MSG(f != NULL, "cannot run grep: %s", strerror(errno));
    if (!f) return;
    char line[PATH_MAX];
    unsigned seen = 0, bad = 0;
    while (fgets(line, sizeof line, f)) {
        line[strcspn(line, "\n")] = 0;
        if (strcmp(line, "src/core/environment.c") == 0) {
            seen++;
            continue;
        }
        if (strncmp(line, "src/cli/", 8) == 0) continue;
        bad++;
        CHECK_MSG(0, "%s reads the environment (only src/core/environment.c may)", line);
    }
    pclose(f);
    CHECK_MSG(seen == 1, "src/core/environment.c not found by the scan (run from the repository root)");
    CHECK(bad == 0);
}

int main(void)
{
    test_exports();
    test_cli_includes();
    test_getenv_in_one_place();
    clvox_context *ctx = NULL;
    clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
    co.host_only = 1;
    CHECK_OK(ctx, clvox_context_create(&co, &ctx));
    if (ctx) {
        test_output_struct_sizes(ctx);
        test_output_file(ctx);
        test_grid_like(ctx);
    }
    clvox_context_destroy(ctx);
    return test_report();
}
