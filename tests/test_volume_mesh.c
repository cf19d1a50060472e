/* SPDX-License-Identifier: Apache-2.0 */
/* Meshes from volumes (src/mesh_out, clvox_volume_to_mesh, clvox mesh).
 *
 * Voxel faces: for volumes written here (voxels touching only along edges
 * and at corners, a random half-filled one, an empty one, a full one,
 * anisotropic voxels off the origin) and for armadillo, bunny, cow and open
 * meshes voxelized at 64^3: the mesh is closed (every directed edge once,
 * with its reverse), each vertex's triangles form one ring (a 2-manifold),
 * its signed volume is the voxel count x voxel volume, and voxelized again
 * on the same grid (ray method, parity, and winding but on the random
 * volumes) it gives back exactly the volume; through PLY (binary and
 * ASCII), OBJ and STL.
 * Marching cubes: closed and a 2-manifold on random values (every
 * ambiguous configuration), on a volume filling its grid, on coverage
 * volumes; the enclosed volume of a coverage volume within 2 % of its
 * coverage sum (times the voxel volume).
 * The CLI: bad input is one line and a non-zero exit, no file left; the
 * peak RSS of clvox mesh on a 512^3 volume stays far below the dense volume.
 */
#define _GNU_SOURCE
#include "test.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

static clvox_context *ctx;

/* ---- reading the meshes we write (PLY binary/ascii as clvox writes it) ---- */

typedef struct tmesh {
    double *v;   /* 3 per vertex */
    uint32_t *t; /* 3 per triangle */
    size_t nv, nt;
} tmesh;

static void tmesh_free(tmesh *m)
{
    free(m->v);
    free(m->t);
    memset(m, 0, sizeof *m);
}

static int read_ply(const char *path, tmesh *m)
{
    memset(m, 0, sizeof *m);
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    char line[256];
    int ascii = -1;
    unsigned long long nv = 0, nt = 0;
    while (fgets(line, sizeof line, f)) {
        if (strncmp(line, "format ascii", 12) == 0) ascii = 1;
        if (strncmp(line, "format binary_little_endian", 27) == 0) ascii = 0;
        sscanf(line, "element vertex %llu", &nv);
        sscanf(line, "element face %llu", &nt);
        if (strcmp(line, "end_header\n") == 0) break;
    }
    int ok = ascii >= 0;
    m->nv = nv;
    m->nt = nt;
    m->v = malloc((nv + 1) * 3 * sizeof *m->v);
    m->t = malloc((nt + 1) * 3 * sizeof *m->t);
    ok = ok && m->v && m->t;
    for (size_t i = 0; ok && i < nv; i++) {
        float x[3];
        if (ascii) ok = fscanf(f, "%f %f %f", &x[0], &x[1], &x[2]) == 3;
        else ok = fread(x, 4, 3, f) == 3;
        for (int a = 0; a < 3; a++) m->v[3 * i + a] = x[a];
    }
    for (size_t i = 0; ok && i < nt; i++) {
        unsigned n = 0;
        int32_t idx[3];
        if (ascii) ok = fscanf(f, "%u %d %d %d", &n, &idx[0], &idx[1], &idx[2]) == 4;
        else {
            unsigned char c;
            ok = fread(&c, 1, 1, f) == 1 && fread(idx, 4, 3, f) == 3;
            n = c;
        }
        ok = ok && n == 3;
        for (int a = 0; ok && a < 3; a++) {
            ok = idx[a] >= 0 && (size_t)idx[a] < nv;
            m->t[3 * i + a] = (uint32_t)idx[a];
        }
    }
    if (ok && !ascii) ok = fgetc(f) == EOF; /* nothing after the faces */
    fclose(f);
    if (!ok) tmesh_free(m);
    return ok;
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* Every directed edge once, its reverse present; and each vertex's
 * triangles one ring (the opposite edges (b, c) chain into one cycle). */
static int closed_manifold(const tmesh *m, char *why, size_t why_size)
{
    why[0] = '\0';
    size_t ne = 3 * m->nt;
    uint64_t *e = malloc((ne + 1) * sizeof *e), *c = malloc((ne + 1) * sizeof *c);
    int ok = e && c;
    for (size_t i = 0; ok && i < m->nt; i++)
        for (int k = 0; k < 3; k++) {
            uint64_t a = m->t[3 * i + k], b = m->t[3 * i + (k + 1) % 3], d = m->t[3 * i + (k + 2) % 3];
            if (a == b) {
                snprintf(why, why_size, "degenerate triangle %zu", i);
                ok = 0;
            }
            e[3 * i + k] = a << 32 | b;
            /* corner at a: its ring edge b -> d, keyed by a then b */
            c[3 * i + k] = a << 32 | b;
            (void)d;
        }
    if (ok) qsort(e, ne, sizeof *e, cmp_u64);
    for (size_t i = 0; ok && i < ne; i++) {
        if (i + 1 < ne && e[i] == e[i + 1]) {
            snprintf(why, why_size, "edge %llu -> %llu used twice the same way", (unsigned long long)(e[i] >> 32),
                     (unsigned long long)(e[i] & 0xffffffffu));
            ok = 0;
        }
        uint64_t r = (e[i] & 0xffffffffu) << 32 | e[i] >> 32;
        if (ok && !bsearch(&r, e, ne, sizeof *e, cmp_u64)) {
            snprintf(why, why_size, "edge %llu -> %llu has no reverse", (unsigned long long)(e[i] >> 32),
                     (unsigned long long)(e[i] & 0xffffffffu));
            ok = 0;
        }
    }
    /* rings: around vertex a, corner (a, b, d) links b -> d */
    if (ok) {
        typedef struct corner { uint32_t a, b, d; } corner;
        corner *cs = malloc((ne + 1) * sizeof *cs);
        ok = cs != NULL;
        for (size_t i = 0; ok && i < m->nt; i++)
            for (int k = 0; k < 3; k++)
                cs[3 * i + k] = (corner){m->t[3 * i + k], m->t[3 * i + (k + 1) % 3], m->t[3 * i + (k + 2) % 3]};
        for (size_t i = 0; ok && i < ne; i++) c[i] = (uint64_t)cs[i].a << 32 | i; /* sort corners by vertex */
        if (ok) qsort(c, ne, sizeof *c, cmp_u64);
        for (size_t g = 0; ok && g < ne;) {
            size_t h = g;
            while (h < ne && c[h] >> 32 == c[g] >> 32) h++;
            /* follow b -> d from the group's first corner */
            const corner *first = &cs[c[g] & 0xffffffffu];
            uint32_t at = first->d;
            size_t steps = 1;
            while (at != first->b && steps <= h - g) {
                size_t k = g;
                while (k < h && cs[c[k] & 0xffffffffu].b != at) k++;
                if (k == h) break;
                at = cs[c[k] & 0xffffffffu].d;
                steps++;
            }
            if (at != first->b || steps != h - g) {
                snprintf(why, why_size, "vertex %u: its %zu triangles are not one ring", first->a, h - g);
                ok = 0;
            }
            g = h;
        }
        free(cs);
    }
    free(e);
    free(c);
    return ok;
}

static double signed_volume(const tmesh *m)
{
    double s = 0;
    const double *o = m->nv ? m->v : (const double[3]){0, 0, 0};
    for (size_t i = 0; i < m->nt; i++) {
        double p[3][3];
        for (int k = 0; k < 3; k++)
            for (int a = 0; a < 3; a++) p[k][a] = m->v[3 * m->t[3 * i + k] + a] - o[a];
        s += p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1]) - p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0]) +
             p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0]);
    }
    return s / 6;
}

/* ---- volumes ---- */

static void path_in_tmp(char *buf, size_t size, const char *name)
{
    snprintf(buf, size, "%s/volmesh_%s", test_tmpdir(), name);
}

/* Writes X*Y*Z values as one channel (CLVOX_CHANNEL_*) of an EXR volume. */
static int write_volume(const char *path, const clvox_grid *g, uint32_t channel, const float *values)
{
    clvox_volume_writer *w = NULL;
    clvox_status st = clvox_volume_writer_open(ctx, path, g, channel, NULL, &w);
    size_t slice = (size_t)g->dims[0] * g->dims[1];
    for (uint32_t z = 0; st == CLVOX_OK && z < g->dims[2]; z++)
        st = clvox_volume_writer_slice(w, channel, z, values + z * slice);
    if (st == CLVOX_OK) st = clvox_volume_writer_finish(w, NULL);
    else clvox_volume_writer_abort(w);
    if (st != CLVOX_OK) fprintf(stderr, "write_volume %s: %s\n", path, clvox_context_error(ctx));
    return st == CLVOX_OK;
}

/* The volume's occupancy (value > 0.5 of its first channel) and grid. */
static uint8_t *read_occupancy(const char *path, clvox_grid *g)
{
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    if (clvox_volume_read(ctx, path, &info, NULL, 0) != CLVOX_OK) return NULL;
    size_t n = (size_t)info.dims[0] * info.dims[1] * info.dims[2];
    uint8_t *occ = malloc(n + 1);
    if (occ && clvox_volume_read(ctx, path, &info, occ, n) != CLVOX_OK) {
        free(occ);
        return NULL;
    }
    memcpy(g->dims, info.dims, sizeof g->dims);
    memcpy(g->origin, info.origin, sizeof g->origin);
    memcpy(g->voxel_size, info.voxel_size, sizeof g->voxel_size);
    return occ;
}

/* The mesh voxelized on grid g (ray method, inside test `inside`) equals occ. */
static void check_revoxelized(const char *mesh_path, const clvox_grid *g, const uint8_t *occ, clvox_inside inside,
                              const char *what)
{
    size_t n = (size_t)g->dims[0] * g->dims[1] * g->dims[2];
    clvox_mesh *m = NULL;
    clvox_status st = clvox_mesh_load(ctx, mesh_path, &m);
    CHECK_MSG(st == CLVOX_OK, "%s: load %s: %s", what, mesh_path, clvox_context_error(ctx));
    if (st != CLVOX_OK) return;
    uint8_t *back = malloc(n);
    clvox_voxelize_options vo = CLVOX_VOXELIZE_OPTIONS_INIT;
    vo.inside = inside;
    st = clvox_voxelize_to_memory(ctx, m, g, &vo, back, n, NULL);
    CHECK_MSG(st == CLVOX_OK, "%s: voxelize: %s", what, clvox_context_error(ctx));
    size_t diff = 0, first = n;
    for (size_t i = 0; st == CLVOX_OK && i < n; i++)
        if (!back[i] != !occ[i]) {
            if (!diff) first = i;
            diff++;
        }
    CHECK_MSG(st == CLVOX_OK && diff == 0, "%s (%s): %zu voxels differ from the volume, the first %zu", what,
              clvox_inside_name(inside), diff, first);
    free(back);
    clvox_mesh_destroy(m);
}

/* Voxel faces of `volume` into mesh (.ply): closed, ring-manifold, volume
 * = count x voxel volume, and back to the same voxels. */
static void check_faces(const char *volume, const char *what, int ascii, int winding)
{
    clvox_grid g;
    uint8_t *occ = read_occupancy(volume, &g);
    CHECK_MSG(occ != NULL, "%s: read %s", what, volume);
    if (!occ) return;
    size_t n = (size_t)g.dims[0] * g.dims[1] * g.dims[2], count = 0;
    for (size_t i = 0; i < n; i++) count += occ[i] != 0;
    char ply[4096];
    path_in_tmp(ply, sizeof ply, ascii ? "faces_ascii.ply" : "faces.ply");
    clvox_surface_options so = CLVOX_SURFACE_OPTIONS_INIT;
    so.kind = CLVOX_SURFACE_FACES;
    so.ascii = ascii;
    clvox_surface_totals t = CLVOX_SURFACE_TOTALS_INIT;
    CHECK_OK(ctx, clvox_volume_to_mesh(ctx, volume, ply, &so, &t));
    double hv = g.voxel_size[0] * g.voxel_size[1] * g.voxel_size[2];
    CHECK_MSG(t.inside_voxels == count, "%s: %llu inside voxels, %zu in the volume", what,
              (unsigned long long)t.inside_voxels, count);
    CHECK_MSG(fabs(t.enclosed_volume - count * hv) <= 1e-9 * (count * hv + hv), "%s: enclosed %.12g, voxels %.12g",
              what, t.enclosed_volume, count * hv);
    tmesh m;
    int ok = read_ply(ply, &m);
    CHECK_MSG(ok, "%s: %s is not the PLY it should be", what, ply);
    if (ok) {
        char why[256];
        CHECK_MSG(m.nv == t.vertices && m.nt == t.triangles, "%s: counts", what);
        CHECK_MSG(closed_manifold(&m, why, sizeof why), "%s: not a closed 2-manifold: %s", what, why);
        double vol = signed_volume(&m);
        CHECK_MSG(fabs(vol - count * hv) <= 1e-5 * (count * hv) + 1e-12, "%s: signed volume %.9g, voxels %.9g", what,
                  vol, count * hv);
        tmesh_free(&m);
    }
    if (count) {
        if (winding) check_revoxelized(ply, &g, occ, CLVOX_INSIDE_WINDING, what);
        check_revoxelized(ply, &g, occ, CLVOX_INSIDE_PARITY, what);
    } else {
        CHECK_MSG(t.triangles == 0 && t.vertices == 0, "%s: an empty volume has an empty mesh", what);
    }
    free(occ);
}

static uint32_t rng_state = 12345;
static uint32_t rnd(void)
{
    rng_state = rng_state * 1664525u + 1013904223u;
    return rng_state >> 8;
}

static void synthetic_faces(void)
{
    char path[4096];
    /* edges and corners: (1,1,1)-(2,2,1) share an edge, (3,3,2) a corner with
     * (2,2,1); a 2x2x2 checkerboard; an L with a voxel on its inner edge */
    {
        clvox_grid g = {{7, 6, 5}, {-1.5, 2.0, 0.25}, {0.5, 0.25, 0.75}};
        float *v = calloc(7 * 6 * 5, sizeof *v);
#define V(i, j, k) v[(i) + 7 * ((j) + 6 * (k))]
        V(1, 1, 1) = V(2, 2, 1) = V(3, 3, 2) = 1;
        V(4, 0, 0) = V(5, 1, 0) = V(4, 1, 1) = V(5, 0, 1) = 1;
        V(0, 4, 3) = V(1, 4, 3) = V(0, 5, 3) = V(1, 5, 4) = V(0, 4, 4) = 1;
        V(6, 5, 4) = V(5, 4, 3) = 1;
#undef V
        path_in_tmp(path, sizeof path, "touching.exr");
        CHECK(write_volume(path, &g, CLVOX_CHANNEL_OCCUPANCY, v));
        check_faces(path, "edge/corner contacts", 0, 1);
        check_faces(path, "edge/corner contacts, ascii", 1, 1);
        free(v);
    }
    /* random half-filled: every kind of corner */
    for (int pass = 0; pass < 2; pass++) {
        clvox_grid g = {{12, 11, 10}, {0, 0, 0}, {1, 1, 1}};
        size_t n = 12 * 11 * 10;
        float *v = malloc(n * sizeof *v);
        for (size_t i = 0; i < n; i++) v[i] = (rnd() % 100) < (pass ? 70u : 40u);
        path_in_tmp(path, sizeof path, "random.exr");
        CHECK(write_volume(path, &g, CLVOX_CHANNEL_OCCUPANCY, v));
        /* parity only: the winding preparation merges vertices at equal
         * positions, sees the split edges as non-manifold and re-orients
         * patches of so tangled a surface (docs/design.md "Meshes from volumes") */
        check_faces(path, pass ? "random 70 %" : "random 40 %", 0, 0);
        free(v);
    }
    /* empty, full */
    {
        clvox_grid g = {{4, 5, 6}, {1, 2, 3}, {0.125, 0.125, 0.125}};
        float v[4 * 5 * 6];
        memset(v, 0, sizeof v);
        path_in_tmp(path, sizeof path, "empty.exr");
        CHECK(write_volume(path, &g, CLVOX_CHANNEL_OCCUPANCY, v));
        check_faces(path, "empty", 0, 1);
        for (size_t i = 0; i < 4 * 5 * 6; i++) v[i] = 1;
        path_in_tmp(path, sizeof path, "full.exr");
        CHECK(write_volume(path, &g, CLVOX_CHANNEL_OCCUPANCY, v));
        check_faces(path, "full", 0, 1);
    }
}

/* Marching cubes of `volume`: closed, ring-manifold; its enclosed volume
 * within rel of the value sum (< 0: not checked). */
static void check_smooth(const char *volume, const char *channel, double rel, const char *what)
{
    char ply[4096];
    path_in_tmp(ply, sizeof ply, "smooth.ply");
    clvox_surface_options so = CLVOX_SURFACE_OPTIONS_INIT;
    so.kind = CLVOX_SURFACE_SMOOTH;
    so.channel = channel;
    clvox_surface_totals t = CLVOX_SURFACE_TOTALS_INIT;
    CHECK_OK(ctx, clvox_volume_to_mesh(ctx, volume, ply, &so, &t));
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    CHECK_OK(ctx, clvox_volume_read(ctx, volume, &info, NULL, 0));
    double hv = info.voxel_size[0] * info.voxel_size[1] * info.voxel_size[2];
    tmesh m;
    int ok = read_ply(ply, &m);
    CHECK_MSG(ok, "%s: %s unreadable", what, ply);
    if (!ok) return;
    char why[256];
    CHECK_MSG(closed_manifold(&m, why, sizeof why), "%s: marching cubes not a closed 2-manifold: %s", what, why);
    double vol = signed_volume(&m);
    CHECK_MSG(vol > 0, "%s: marching cubes inward (volume %g)", what, vol);
    if (rel >= 0) {
        double want = t.value_sum * hv;
        printf("  %s: marching cubes %.6g, value sum %.6g (%+.3f %%)\n", what, vol, want, 100 * (vol / want - 1));
        CHECK_MSG(fabs(vol - want) <= rel * want, "%s: marching cubes enclose %.6g, the values sum to %.6g", what,
                  vol, want);
    }
    tmesh_free(&m);
}

static void synthetic_smooth(void)
{
    char path[4096];
    clvox_grid g = {{9, 8, 7}, {0, 0, 0}, {1, 1, 1}};
    size_t n = 9 * 8 * 7;
    float *v = malloc(n * sizeof *v);
    for (int pass = 0; pass < 3; pass++) {
        /* random values (all 256 cube configurations many times), exact 0.5s
         * among them; then the grid full (it touches the boundary) */
        for (size_t i = 0; i < n; i++) v[i] = pass == 2 ? 1.0f : (float)(rnd() % 9) / 8;
        path_in_tmp(path, sizeof path, "smooth_random.exr");
        CHECK(write_volume(path, &g, CLVOX_CHANNEL_COVERAGE, v));
        check_smooth(path, NULL, -1, pass == 2 ? "full coverage" : "random coverage");
    }
    /* a ball of radius 9.3 voxels, coverage from 8^3 points per voxel */
    clvox_grid b = {{24, 24, 24}, {-12, -12, -12}, {1, 1, 1}};
    float *c = malloc(24 * 24 * 24 * sizeof *c);
    for (int k = 0; k < 24; k++)
        for (int j = 0; j < 24; j++)
            for (int i = 0; i < 24; i++) {
                int in = 0;
                for (int s = 0; s < 512; s++) {
                    double x = i - 12 + (s % 8 + 0.5) / 8, y = j - 12 + (s / 8 % 8 + 0.5) / 8, z = k - 12 + (s / 64 + 0.5) / 8;
                    in += x * x + y * y + z * z < 9.3 * 9.3;
                }
                c[i + 24 * (j + 24 * k)] = in / 512.0f;
            }
    path_in_tmp(path, sizeof path, "ball.exr");
    CHECK(write_volume(path, &b, CLVOX_CHANNEL_COVERAGE, c));
    check_smooth(path, NULL, 0.02, "ball r 9.3");
    free(c);
    free(v);
}

/* ---- real meshes ---- */

static void real_meshes(void)
{
    static const char *const names[] = {"armadillo.off", "bunny00.off", "cow.off", "open_cube.off",
                                        "elephant-with-holes.off", "hole.off"};
    for (size_t i = 0; i < sizeof names / sizeof *names; i++) {
        char mesh[4096], exr[4096], cov[4096];
        snprintf(mesh, sizeof mesh, "data/meshes/%s", names[i]);
        if (access(mesh, R_OK) != 0) {
            printf("SKIP %s: not there (scripts/fetch_meshes.sh fetches it)\n", mesh);
            continue;
        }
        clvox_mesh *m = NULL;
        CHECK_OK(ctx, clvox_mesh_load(ctx, mesh, &m));
        if (!m) continue;
        clvox_grid g;
        clvox_grid_options go = CLVOX_GRID_OPTIONS_INIT;
        go.resolution = 64;
        const clvox_mesh_report *r = clvox_mesh_get_report(m);
        CHECK_OK(ctx, clvox_grid_compute(ctx, &go, r->bbox_min, r->bbox_max, &g));
        path_in_tmp(exr, sizeof exr, "real.exr");
        CHECK_OK(ctx, clvox_voxelize_to_file(ctx, m, &g, NULL, NULL, exr, NULL));
        check_faces(exr, names[i], 0, 1);
        if (i < 3) { /* coverage: marching cubes against the coverage sum */
            clvox_voxelize_options vo = CLVOX_VOXELIZE_OPTIONS_INIT;
            vo.oversample = 4;
            path_in_tmp(cov, sizeof cov, "real_cov.exr");
            CHECK_OK(ctx, clvox_voxelize_to_file(ctx, m, &g, &vo, NULL, cov, NULL));
            check_smooth(cov, NULL, 0.02, names[i]);
            check_smooth(exr, NULL, -1, names[i]); /* --smooth of occupancy */
        }
        clvox_mesh_destroy(m);
    }
}

/* ---- the CLI ---- */

typedef struct run {
    int code;
    long maxrss_kb;
    char out[4096], err[4096];
} run;

static void slurp(const char *path, char *buf, size_t size)
{
    buf[0] = '\0';
    FILE *f = fopen(path, "r");
    if (!f) return;
    size_t n = fread(buf, 1, size - 1, f);
    buf[n] = '\0';
    fclose(f);
}

static void run_clvox(run *r, const char *const *args)
{
    const char *bin = getenv("CLVOX_BIN");
    if (!bin || !*bin) bin = "build/release/clvox";
    const char *argv[32];
    size_t n = 0;
    argv[n++] = bin;
    for (size_t i = 0; args[i] && n < 31; i++) argv[n++] = args[i];
    argv[n] = NULL;
    char op[4096], ep[4096];
    path_in_tmp(op, sizeof op, "cli.out");
    path_in_tmp(ep, sizeof ep, "cli.err");
    fflush(stdout);
    fflush(stderr);
    r->code = -1;
    r->maxrss_kb = 0;
    pid_t pid = fork();
    if (pid == 0) {
        int o = open(op, O_WRONLY | O_CREAT | O_TRUNC, 0644), e = open(ep, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (o < 0 || e < 0 || dup2(o, 1) < 0 || dup2(e, 2) < 0) _exit(126);
        execv(bin, (char *const *)argv);
        _exit(127);
    }
    int status = 0;
    struct rusage ru;
    memset(&ru, 0, sizeof ru);
    if (pid > 0 && wait4(pid, &status, 0, &ru) == pid && WIFEXITED(status)) r->code = WEXITSTATUS(status);
    r->maxrss_kb = ru.ru_maxrss;
    slurp(op, r->out, sizeof r->out);
    slurp(ep, r->err, sizeof r->err);
}

static int one_line(const char *s)
{
    const char *nl = strchr(s, '\n');
    return *s && nl && nl[1] == '\0';
}

static void cli_bad(const char *const *args, int code, const char *out, const char *what)
{
    run r;
    run_clvox(&r, args);
    CHECK_MSG(r.code == code && one_line(r.err) && strstr(r.err, "clvox: error:"),
              "%s: exit %d (want %d), stderr: %s", what, r.code, code, r.err);
    if (out) CHECK_MSG(access(out, F_OK) != 0, "%s: %s left behind", what, out);
}

static void cli(void)
{
    char exr[4096], txt[4096], out[4096], obj[4096], stl[4096], cov[4096];
    path_in_tmp(exr, sizeof exr, "cli.exr");
    path_in_tmp(cov, sizeof cov, "cli_cov.exr");
    /* a voxel sphere touching a corner voxel, as occupancy; the same as coverage */
    clvox_grid g = {{10, 9, 8}, {-2, -1, 0.5}, {0.5, 0.5, 0.5}};
    float v[10 * 9 * 8];
    for (int k = 0; k < 8; k++)
        for (int j = 0; j < 9; j++)
            for (int i = 0; i < 10; i++)
                v[i + 10 * (j + 9 * k)] = (i - 4.5) * (i - 4.5) + (j - 4) * (j - 4) + (k - 3.5) * (k - 3.5) < 9 ||
                                          (i == 8 && j == 8 && k == 7);
    CHECK(write_volume(exr, &g, CLVOX_CHANNEL_OCCUPANCY, v));
    CHECK(write_volume(cov, &g, CLVOX_CHANNEL_COVERAGE, v));
    clvox_grid gr;
    uint8_t *occ = read_occupancy(exr, &gr);
    path_in_tmp(obj, sizeof obj, "cli.obj");
    path_in_tmp(stl, sizeof stl, "cli.stl");
    path_in_tmp(out, sizeof out, "cli.ply");
    const char *const outs[] = {obj, stl, out};
    for (int i = 0; i < 3; i++) {
        unlink(outs[i]);
        run r;
        run_clvox(&r, (const char *const[]){"mesh", exr, "-o", outs[i], NULL});
        CHECK_MSG(r.code == 0 && strstr(r.out, "voxel faces of occupancy"), "clvox mesh -o %s: exit %d: %s%s", outs[i],
                  r.code, r.out, r.err);
        if (occ && r.code == 0) check_revoxelized(outs[i], &gr, occ, CLVOX_INSIDE_WINDING, outs[i]);
    }
    {
        run r;
        run_clvox(&r, (const char *const[]){"mesh", stl, "-o", out, "--ascii", NULL});
        CHECK_MSG(r.code != 0, "a mesh is not a volume");
        run_clvox(&r, (const char *const[]){"mesh", exr, "-o", stl, "--ascii", NULL});
        CHECK_MSG(r.code == 0, "ascii stl: %s", r.err);
        if (occ && r.code == 0) check_revoxelized(stl, &gr, occ, CLVOX_INSIDE_WINDING, "ascii stl");
        run_clvox(&r, (const char *const[]){"mesh", cov, "-o", out, NULL});
        CHECK_MSG(r.code == 0 && strstr(r.out, "marching cubes of coverage"), "coverage: %s%s", r.out, r.err);
        run_clvox(&r, (const char *const[]){"mesh", cov, "-o", out, "--faces", NULL});
        CHECK_MSG(r.code == 0 && strstr(r.out, "voxel faces of coverage"), "coverage --faces: %s%s", r.out, r.err);
        if (occ && r.code == 0) check_revoxelized(out, &gr, occ, CLVOX_INSIDE_WINDING, "coverage --faces");
        run_clvox(&r, (const char *const[]){"mesh", "--help", NULL});
        CHECK(r.code == 0 && strstr(r.out, "--smooth") && strstr(r.out, ".stl"));
    }
    free(occ);
    /* bad input: one line, non-zero, no file */
    path_in_tmp(out, sizeof out, "bad.ply");
    unlink(out);
    path_in_tmp(txt, sizeof txt, "not_a_volume.exr");
    FILE *f = fopen(txt, "w");
    if (f) {
        fputs("hello\n", f);
        fclose(f);
    }
    char missing[4096], nodir[4096];
    path_in_tmp(missing, sizeof missing, "missing.exr");
    path_in_tmp(nodir, sizeof nodir, "no/such/dir/x.ply");
    cli_bad((const char *const[]){"mesh", missing, "-o", out, NULL}, 4, out, "missing volume");
    cli_bad((const char *const[]){"mesh", txt, "-o", out, NULL}, 4, out, "not a volume");
    cli_bad((const char *const[]){"mesh", txt, "-o", out, "--smooth", NULL}, 4, out, "not a volume, --smooth");
    cli_bad((const char *const[]){"mesh", exr, "-o", out, "--channel", "nope", NULL}, 4, out, "no such channel");
    cli_bad((const char *const[]){"mesh", exr, "-o", "x.off", NULL}, 2, "x.off", "unknown extension");
    cli_bad((const char *const[]){"mesh", exr, "-o", out, "--faces", "--smooth", NULL}, 2, out, "faces and smooth");
    cli_bad((const char *const[]){"mesh", exr, "-o", out, "--iso", "abc", NULL}, 2, out, "bad iso");
    cli_bad((const char *const[]){"mesh", exr, "-o", nodir, NULL}, 5, nodir, "no output directory");
    cli_bad((const char *const[]){"mesh", exr, NULL}, 2, NULL, "no output");
    /* a truncated volume: fails in the first read, no file */
    char cut[4096];
    path_in_tmp(cut, sizeof cut, "cut.exr");
    FILE *a = fopen(exr, "rb"), *b = fopen(cut, "wb");
    if (a && b) {
        char buf[400];
        size_t n = fread(buf, 1, sizeof buf, a);
        fwrite(buf, 1, n, b);
    }
    if (a) fclose(a);
    if (b) fclose(b);
    cli_bad((const char *const[]){"mesh", cut, "-o", out, NULL}, 4, out, "truncated volume");
    cli_bad((const char *const[]){"mesh", cut, "-o", obj, "--smooth", NULL}, 4, NULL, "truncated volume, obj");
}

/* Peak RSS of clvox mesh on a 512^3 volume (a ball), against the dense
 * volume (512^3 bytes as occupancy, 4x that as the floats the reader gives). */
static void bounded_memory(void)
{
    const uint32_t N = 512;
    char exr[4096], ply[4096];
    path_in_tmp(exr, sizeof exr, "big.exr");
    path_in_tmp(ply, sizeof ply, "big.ply");
    clvox_grid g = {{N, N, N}, {0, 0, 0}, {1, 1, 1}};
    clvox_volume_writer *w = NULL;
    clvox_status st = clvox_volume_writer_open(ctx, exr, &g, CLVOX_CHANNEL_OCCUPANCY, NULL, &w);
    float *s = malloc((size_t)N * N * sizeof *s);
    uint64_t count = 0;
    for (uint32_t z = 0; st == CLVOX_OK && z < N; z++) {
        for (uint32_t j = 0; j < N; j++)
            for (uint32_t i = 0; i < N; i++) {
                double x = i + 0.5 - N / 2.0, y = j + 0.5 - N / 2.0, zz = z + 0.5 - N / 2.0;
                s[i + (size_t)N * j] = x * x + y * y + zz * zz < 0.45 * 0.45 * N * N;
                count += s[i + (size_t)N * j] != 0;
            }
        st = clvox_volume_writer_slice(w, CLVOX_CHANNEL_OCCUPANCY, z, s);
    }
    free(s);
    if (st == CLVOX_OK) st = clvox_volume_writer_finish(w, NULL);
    else clvox_volume_writer_abort(w);
    CHECK_OK(ctx, st);
    if (st != CLVOX_OK) return;
    const double dense_mb = (double)N * N * N / (1 << 20);
    for (int smooth = 0; smooth < 2; smooth++) {
        run r;
        run_clvox(&r, (const char *const[]){"mesh", exr, "-o", ply, smooth ? "--smooth" : "--faces", NULL});
        CHECK_MSG(r.code == 0, "512^3: exit %d: %s", r.code, r.err);
        printf("  512^3 %s: peak RSS %.1f MiB (dense occupancy %.0f MiB, as floats %.0f MiB): %s", smooth ? "smooth" : "faces",
               r.maxrss_kb / 1024.0, dense_mb, 4 * dense_mb, r.out);
#ifndef __SANITIZE_ADDRESS__ /* ASan's shadow memory and quarantine are no measure of ours */
        CHECK_MSG(r.maxrss_kb > 0 && r.maxrss_kb / 1024.0 < dense_mb / 4, "512^3 %s: peak RSS %ld KiB",
                  smooth ? "smooth" : "faces", r.maxrss_kb);
#endif
        if (!smooth) {
            tmesh m;
            int ok = read_ply(ply, &m);
            CHECK(ok);
            if (ok) {
                char why[256];
                CHECK_MSG(closed_manifold(&m, why, sizeof why), "512^3: %s", why);
                CHECK(fabs(signed_volume(&m) - (double)count) <= 1e-6 * count);
                tmesh_free(&m);
            }
        }
    }
    unlink(exr);
    unlink(ply);
}

int main(void)
{
    ctx = test_context();
    synthetic_faces();
    synthetic_smooth();
    real_meshes();
    cli();
    bounded_memory();
    clvox_context_destroy(ctx);
    return test_report();
}
