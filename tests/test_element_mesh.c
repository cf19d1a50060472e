/* SPDX-License-Identifier: Apache-2.0 */
/* Past 800 lines on purpose: one test program for element geometry and its PLY
 * export, sharing the palette fixtures. */
/* Element geometry (src/palette/element_mesh.c) and the PLY export of palette
 * volumes (src/palette/element_ply.c).
 *
 * Geometry, for every element of binary, planar10, paper46, paper78,
 * palettes/blocks.txt and a test palette of tilted, overlapping, redundant
 * and empty cells: every piece closed and consistently oriented (each
 * directed edge has its reverse in the piece, as often), its triangles using
 * only its own vertices, all vertices in [0,1]^3, positive piece volumes
 * adding up to the element's volume (exact volumes to 1e-9; sampled ones
 * within the error bound of the 64^3 estimate, sqrt(3) * surface area / 64),
 * and the pieces disjoint and covering the element: on a 16^3 offset lattice
 * (points within 1e-7 of a plane of the element skipped: none for the
 * built-ins and blocks.txt), every piece's winding number is 0 or 1, and the
 * point is in exactly one piece when clvox_palette_contains says it is in
 * the element, else in none.
 */
#include "test.h"
#include "core/internal.h"
#include "palette/element_mesh.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

static clvox_context *ctx;

/* ---- geometry ---- */

static const char test_palette_text[] =
    "element tilt\n  cell\n    0.3 0.7 -0.2 0.45\nend\n"
    "element gem\n  cell\n    1 1 1 2.2\n    -1 1 0 0.6\n    1 -1 0.5 0.7\n    0 0 -1 -0.1\n    -2 -1 -1 -0.9\nend\n"
    "element overlap\n  cell\n    1 0.2 0 0.7\n    0 1 -0.1 0.8\n  cell\n    -1 0.3 0 -0.3\n    0 -1 0.2 -0.2\nend\n"
    "element not_overlap\n  cell\n    1 0.2 0 0.7\n    0 1 -0.1 0.8\n  cell\n    -1 0.3 0 -0.3\n    0 -1 0.2 -0.2\n"
    "  complement\nend\n"
    "element redundant\n  cell\n    1 0 0 2\n    1 1 0 2\n    -1 0 0 1\n    0.4 0 1 0.9\nend\n"
    "element sliver\n  cell\n    1 0 0 0.001\nend\n"
    "element three\n  cell\n    1 0 0 0.6\n  cell\n    0 1 0 0.6\n  cell\n    0 0 1 0.6\nend\n"
    "element halves\n  cell\n    1 0 0 0.5\n    0 1 0 0.25\n  cell\n    -1 0 0 -0.5\n    0 1 0 0.25\nend\n"
    "element outside_and_in\n  cell\n    1 0 0 -0.5\n  cell\n    0 1 0 0.3\nend\n"
    "element not_two\n  cell\n    1 0 0 -0.5\n  cell\n    0 1 0 0.3\n  cell\n    0 0 1 0.25\n  complement\nend\n"
    "element nested\n  cell\n    1 0 0 0.8\n  cell\n    1 0 0 0.3\n    0 1 0 0.3\n  cell\n    1 1 1 2.5\nend\n"
    "element skew\n  cell\n    1 2 0 1.5\n    0 -1 1 0.25\n  symmetry\nend\n";

/* The element's planes, for the on-plane test. */
static void element_planes(const clvox_palette *p, size_t e, const clvox_halfspace **hs, size_t *n)
{
    const clvox_element *els;
    const clvox_cell *cells;
    const clvox_halfspace *planes;
    size_t ne, nc, np;
    clvox__palette_arrays(p, &els, &ne, &cells, &nc, &planes, &np);
    const clvox_element *el = &els[e];
    if (el->cell_count == 0) {
        *hs = planes;
        *n = 0;
        return;
    }
    const clvox_cell *c0 = &cells[el->first_cell], *cl = &cells[el->first_cell + el->cell_count - 1];
    *hs = planes + c0->first_plane; /* an element's planes are consecutive */
    *n = cl->first_plane + cl->plane_count - c0->first_plane;
}

static double solid_angle(const double *p, const double *A, const double *B, const double *C)
{
    double a[3], b[3], c[3];
    for (int k = 0; k < 3; k++) a[k] = A[k] - p[k], b[k] = B[k] - p[k], c[k] = C[k] - p[k];
    double la = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    double lb = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    double lc = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    double det = a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2]) + a[2] * (b[0] * c[1] - b[1] * c[0]);
    double ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2], ac = a[0] * c[0] + a[1] * c[1] + a[2] * c[2],
           bc = b[0] * c[0] + b[1] * c[1] + b[2] * c[2];
    return 2.0 * atan2(det, la * lb * lc + ab * lc + ac * lb + bc * la);
}

static double tri_area(const double *a, const double *b, const double *c)
{
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    double x = u[1] * v[2] - u[2] * v[1], y = u[2] * v[0] - u[0] * v[2], z = u[0] * v[1] - u[1] * v[0];
    return 0.5 * sqrt(x * x + y * y + z * z);
}

static double tri_volume(const double *a, const double *b, const double *c)
{
    return (a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2]) + a[2] * (b[0] * c[1] - b[1] * c[0])) /
           6.0;
}

/* Every directed edge of triangles [t0, t1) has its reverse as often (O(n^2)). */
static int piece_closed(const clvox__element_mesh *m, size_t t0, size_t t1)
{
    for (size_t t = t0; t < t1; t++)
        for (int k = 0; k < 3; k++) {
            uint32_t a = m->tris[3 * t + k], b = m->tris[3 * t + (k + 1) % 3];
            size_t fwd = 0, rev = 0;
            for (size_t u = t0; u < t1; u++)
                for (int q = 0; q < 3; q++) {
                    uint32_t c = m->tris[3 * u + q], d = m->tris[3 * u + (q + 1) % 3];
                    fwd += c == a && d == b;
                    rev += c == b && d == a;
                }
            if (fwd != rev || a == b) return 0;
        }
    return 1;
}

#define LAT 16u

static float lat(uint32_t i, int axis)
{
    static const int off[3] = {33, 35, 41};
    return (float)((double)(i * 64u + (uint32_t)off[axis]) / (64.0 * LAT));
}

typedef struct geo_stats {
    size_t elements, pieces, triangles, skipped_points, bad_points, bad_winding;
    double worst_volume_error;
} geo_stats;

static void check_element(const clvox_palette *p, size_t e, geo_stats *gs)
{
    clvox_palette_element_info info = CLVOX_PALETTE_ELEMENT_INFO_INIT;
    CHECK_OK(ctx, clvox_palette_element_info_get(ctx, p, e, &info));
    clvox__element_mesh m;
    clvox_status st = clvox__element_mesh_build(ctx, p, e, &m);
    CHECK_MSG(st == CLVOX_OK, "%s element %zu %s: %s", clvox_palette_name(p), e, info.name, clvox_context_error(ctx));
    if (st != CLVOX_OK) return;
    gs->elements++;
    gs->pieces += m.piece_count;
    gs->triangles += m.triangle_count;
    CHECK(m.piece_vertex[0] == 0 && m.piece_triangle[0] == 0);
    CHECK(m.piece_vertex[m.piece_count] == m.vertex_count && m.piece_triangle[m.piece_count] == m.triangle_count);
    int inside_cube = 1, own_vertices = 1, closed = 1, positive = 1;
    for (size_t v = 0; v < 3 * m.vertex_count; v++) inside_cube &= m.xyz[v] >= 0.0 && m.xyz[v] <= 1.0;
    double total = 0, area = 0;
    for (size_t q = 0; q < m.piece_count; q++) {
        size_t v0 = m.piece_vertex[q], v1 = m.piece_vertex[q + 1], t0 = m.piece_triangle[q], t1 = m.piece_triangle[q + 1];
        for (size_t t = 3 * t0; t < 3 * t1; t++) own_vertices &= m.tris[t] >= v0 && m.tris[t] < v1;
        if (!own_vertices) break;
        closed &= piece_closed(&m, t0, t1) && t1 - t0 >= 4;
        double vol = 0;
        for (size_t t = t0; t < t1; t++) {
            const double *a = &m.xyz[3 * m.tris[3 * t]], *b = &m.xyz[3 * m.tris[3 * t + 1]], *c = &m.xyz[3 * m.tris[3 * t + 2]];
            vol += tri_volume(a, b, c);
            area += tri_area(a, b, c);
        }
        positive &= vol > 0;
        total += vol;
    }
    CHECK_MSG(inside_cube, "%s %s: a vertex outside [0,1]^3", clvox_palette_name(p), info.name);
    CHECK_MSG(own_vertices, "%s %s: a piece uses another piece's vertex", clvox_palette_name(p), info.name);
    if (!own_vertices) goto done;
    CHECK_MSG(closed, "%s %s: a piece is not closed and consistently oriented", clvox_palette_name(p), info.name);
    CHECK_MSG(positive, "%s %s: a piece has no positive volume (inward?)", clvox_palette_name(p), info.name);
    CHECK_MSG(fabs(total - m.volume) < 1e-12, "%s %s: volume %.17g vs reported %.17g", clvox_palette_name(p), info.name,
              total, m.volume);
    double err = fabs(total - info.volume), tol = info.volume_exact ? 1e-9 : sqrt(3.0) * area / 64.0 + 1e-12;
    if (err > gs->worst_volume_error) gs->worst_volume_error = err;
    CHECK_MSG(err <= tol, "%s %s: mesh volume %.12f, element volume %.12f (%s), tolerance %.3g", clvox_palette_name(p),
              info.name, total, info.volume, info.volume_exact ? "exact" : "sampled", tol);
    if (info.volume_exact && e < 2) CHECK(m.piece_count == e); /* empty: nothing; full: the cube */

    const clvox_halfspace *hs;
    size_t nh;
    element_planes(p, e, &hs, &nh);
    size_t bad = 0, badw = 0;
    for (uint32_t k = 0; k < LAT; k++)
        for (uint32_t j = 0; j < LAT; j++)
            for (uint32_t i = 0; i < LAT; i++) {
                float fx = lat(i, 0), fy = lat(j, 1), fz = lat(k, 2);
                double pt[3] = {fx, fy, fz};
                int near = 0;
                for (size_t h = 0; h < nh && !near; h++) {
                    double s = (double)hs[h].a * pt[0] + (double)hs[h].b * pt[1] + (double)hs[h].c * pt[2] - hs[h].d;
                    double n = sqrt((double)hs[h].a * hs[h].a + (double)hs[h].b * hs[h].b + (double)hs[h].c * hs[h].c);
                    near = fabs(s) <= 1e-7 * n;
                }
                if (near) {
                    gs->skipped_points++;
                    continue;
                }
                int in_pieces = 0;
                for (size_t q = 0; q < m.piece_count; q++) {
                    double w = 0;
                    for (size_t t = m.piece_triangle[q]; t < m.piece_triangle[q + 1]; t++)
                        w += solid_angle(pt, &m.xyz[3 * m.tris[3 * t]], &m.xyz[3 * m.tris[3 * t + 1]],
                                         &m.xyz[3 * m.tris[3 * t + 2]]);
                    w /= 4.0 * 3.14159265358979323846;
                    if (fabs(w - 1.0) < 1e-6) in_pieces++;
                    else if (fabs(w) >= 1e-6) badw++;
                }
                int want = clvox_palette_contains(p, e, fx, fy, fz);
                if (in_pieces != want) bad++;
            }
    gs->bad_points += bad;
    gs->bad_winding += badw;
    CHECK_MSG(bad == 0, "%s %s: %zu lattice points in the wrong number of pieces", clvox_palette_name(p), info.name, bad);
    CHECK_MSG(badw == 0, "%s %s: %zu winding numbers neither 0 nor 1", clvox_palette_name(p), info.name, badw);
done:
    clvox__element_mesh_free(&m);
}

static void check_palette(clvox_palette *p, int expect_no_skips)
{
    if (!p) return;
    geo_stats gs;
    memset(&gs, 0, sizeof gs);
    for (size_t e = 0; e < clvox_palette_count(p); e++) check_element(p, e, &gs);
    CHECK(gs.elements == clvox_palette_count(p));
    if (expect_no_skips) CHECK_MSG(gs.skipped_points == 0, "%s: %zu lattice points on planes", clvox_palette_name(p), gs.skipped_points);
    printf("geometry %-10s %4zu elements, %5zu pieces, %6zu triangles, worst volume error %.2g, %zu lattice points "
           "on planes skipped\n",
           clvox_palette_name(p), gs.elements, gs.pieces, gs.triangles, gs.worst_volume_error, gs.skipped_points);
    clvox_palette_destroy(p);
}

static clvox_palette *builtin(const char *name)
{
    clvox_palette *p = NULL;
    CHECK_OK(ctx, clvox_palette_builtin(ctx, name, &p));
    return p;
}

/* Exact counts of a few meshes: the shapes are what they should be. */
static void check_counts(void)
{
    clvox_palette *p = builtin("paper78");
    if (!p) return;
    static const struct {
        const char *name;
        size_t pieces, vertices, triangles;
    } want[] = {
        {"full", 1, 8, 12},  {"wedge", 1, 6, 8},           {"corner", 1, 4, 4},         {"column", 1, 8, 12},
        {"roof", 1, 6, 8},   {"not_column", 2, 16, 24},    {"not_corner", 1, 7, 10},  {"not_roof", 2, 12, 16},
    };
    for (size_t w = 0; w < sizeof want / sizeof want[0]; w++) {
        size_t e = 0;
        clvox_palette_element_info info = CLVOX_PALETTE_ELEMENT_INFO_INIT;
        for (; e < clvox_palette_count(p); e++)
            if (clvox_palette_element_info_get(ctx, p, e, &info) == CLVOX_OK && strcmp(info.name, want[w].name) == 0) break;
        CHECK_MSG(e < clvox_palette_count(p), "paper78 has no %s", want[w].name);
        clvox__element_mesh m;
        if (e == clvox_palette_count(p) || clvox__element_mesh_build(ctx, p, e, &m) != CLVOX_OK) continue;
        CHECK_MSG(m.piece_count == want[w].pieces && m.vertex_count == want[w].vertices &&
                      m.triangle_count == want[w].triangles,
                  "%s: %zu pieces, %zu vertices, %zu triangles; expected %zu, %zu, %zu", want[w].name, m.piece_count,
                  m.vertex_count, m.triangle_count, want[w].pieces, want[w].vertices, want[w].triangles);
        clvox__element_mesh_free(&m);
    }
    /* bad arguments */
    clvox__element_mesh m;
    CHECK_STATUS(ctx, clvox__element_mesh_build(ctx, p, clvox_palette_count(p), &m), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK(m.xyz == NULL && m.piece_count == 0);
    CHECK_STATUS(ctx, clvox__element_mesh_build(ctx, NULL, 0, &m), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(ctx, clvox__element_mesh_build(ctx, p, 0, NULL), CLVOX_ERR_INVALID_ARGUMENT);
    clvox__element_mesh_free(NULL);
    clvox_palette_destroy(p);
}

static void test_geometry(void)
{
    check_counts();
    static const char *const names[] = {"binary", "planar10", "paper46", "paper78"};
    for (size_t i = 0; i < 4; i++) check_palette(builtin(names[i]), 1);
    clvox_palette *p = NULL;
    CHECK_OK(ctx, clvox_palette_load(ctx, "palettes/blocks.txt", &p));
    CHECK(p && clvox_palette_count(p) == 12);
    check_palette(p, 1);
    p = NULL;
    CHECK_OK(ctx, clvox_palette_parse(ctx, "tilted.txt", test_palette_text, strlen(test_palette_text), &p));
    CHECK(p && clvox_palette_count(p) > 14);
    check_palette(p, 0);
    /* many overlapping cells of random planes (a fixed LCG): hundreds of pieces */
    static const struct {
        unsigned cells, planes, complement;
    } shape[] = {{16, 4, 0}, {8, 8, 0}, {16, 4, 1}, {6, 10, 1}};
    char *text = malloc(1 << 16);
    size_t n = 0;
    uint32_t seed = 12345;
#define RND() ((seed = seed * 1664525u + 1013904223u) >> 8) / 16777216.0 /* [0, 1) */
    for (size_t e = 0; e < sizeof shape / sizeof shape[0] && text; e++) {
        n += (size_t)snprintf(text + n, (1 << 16) - n, "element random%zu\n", e);
        for (unsigned c = 0; c < shape[e].cells; c++) {
            double centre[3] = {0.2 + 0.6 * RND(), 0.2 + 0.6 * RND(), 0.2 + 0.6 * RND()};
            n += (size_t)snprintf(text + n, (1 << 16) - n, "  cell\n");
            for (unsigned k = 0; k < shape[e].planes; k++) {
                double a[3] = {RND() - 0.5, RND() - 0.5, RND() - 0.5};
                double d = a[0] * centre[0] + a[1] * centre[1] + a[2] * centre[2] + 0.1 * RND() + 0.02;
                n += (size_t)snprintf(text + n, (1 << 16) - n, "    %.5f %.5f %.5f %.5f\n", a[0], a[1], a[2], d);
            }
        }
        n += (size_t)snprintf(text + n, (1 << 16) - n, "%send\n", shape[e].complement ? "  complement\n" : "");
    }
#undef RND
    p = NULL;
    CHECK(text && n < (1 << 16));
    if (text) CHECK_OK(ctx, clvox_palette_parse(ctx, "random.txt", text, n, &p));
    CHECK(p && clvox_palette_count(p) == 6);
    check_palette(p, 0);
    free(text);
}


/* ---- PLY export ---- */

typedef struct file_sink {
    int fd;
    int fail_after; /* > 0: the n-th write fails with ENOSPC */
    int writes;
} file_sink;

static int sink_write_at(void *user, uint64_t offset, const void *data, size_t size)
{
    file_sink *s = user;
    if (s->fail_after && ++s->writes >= s->fail_after) return ENOSPC;
    const char *p = data;
    while (size) {
        ssize_t n = pwrite(s->fd, p, size, (off_t)offset);
        if (n < 0) {
            if (errno == EINTR) continue;
            return errno;
        }
        p += n;
        size -= (size_t)n;
        offset += (uint64_t)n;
    }
    return 0;
}

/* A test volume: element (i * 7 + j * 3 + k * 5) % count, every 4th voxel empty. */
static float test_element(uint32_t i, uint32_t j, uint32_t k, size_t count)
{
    uint32_t n = i * 7u + j * 3u + k * 5u;
    return n % 4u == 3u ? 0.0f : (float)(n % count);
}

typedef struct volume {
    uint32_t dims[3];
    double origin[3], h[3];
} volume;

static float *test_slice(const volume *v, uint32_t k, size_t count)
{
    float *s = malloc((size_t)v->dims[0] * v->dims[1] * sizeof *s);
    for (uint32_t j = 0; j < v->dims[1]; j++)
        for (uint32_t i = 0; i < v->dims[0]; i++) s[(size_t)j * v->dims[0] + i] = test_element(i, j, k, count);
    return s;
}

/* Exports the test volume to path; 0 on success. */
static clvox_status export_volume(const clvox_palette *p, const volume *v, int ascii, const char *path,
                                  clvox__ply_totals *t)
{
    clvox__ply_export *x = NULL;
    clvox_status st = clvox__ply_export_create(ctx, p, v->dims, v->origin, v->h, ascii, &x);
    for (uint32_t k = 0; k < v->dims[2] && st == CLVOX_OK; k++) {
        float *s = test_slice(v, v->dims[2] - 1 - k, clvox_palette_count(p)); /* any order */
        st = clvox__ply_export_count(x, v->dims[2] - 1 - k, s);
        free(s);
    }
    if (st == CLVOX_OK) st = clvox__ply_export_totals(x, t);
    file_sink sink = {open(path, O_WRONLY | O_CREAT | O_TRUNC, 0644), 0, 0};
    if (sink.fd < 0) st = CLVOX_ERR_IO;
    if (st == CLVOX_OK) st = clvox__ply_export_begin(x, sink_write_at, &sink);
    for (uint32_t k = 0; k < v->dims[2] && st == CLVOX_OK; k++) {
        float *s = test_slice(v, k, clvox_palette_count(p));
        st = clvox__ply_export_slice(x, k, s);
        free(s);
    }
    if (st == CLVOX_OK) st = clvox__ply_export_finish(x);
    if (sink.fd >= 0) close(sink.fd);
    clvox__ply_export_destroy(x);
    return st;
}

static long file_size(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0 ? (long)sb.st_size : -1;
}

static void test_export_file(clvox_palette *p, const volume *v)
{
    char bin[4096], asc[4096];
    snprintf(bin, sizeof bin, "%s/element_mesh_%s.ply", test_tmpdir(), clvox_palette_name(p));
    snprintf(asc, sizeof asc, "%s/element_mesh_%s_ascii.ply", test_tmpdir(), clvox_palette_name(p));
    clvox__ply_totals tb, ta;
    CHECK_OK(ctx, export_volume(p, v, 0, bin, &tb));
    CHECK_OK(ctx, export_volume(p, v, 1, asc, &ta));
    CHECK((long)tb.bytes == file_size(bin) && (long)ta.bytes == file_size(asc));
    CHECK(tb.voxels == ta.voxels && tb.vertices == ta.vertices && tb.triangles == ta.triangles);

    /* expected totals, vertices and volume from the element meshes */
    size_t count = clvox_palette_count(p);
    clvox__element_mesh *m = calloc(count, sizeof *m);
    for (size_t e = 0; e < count; e++) CHECK_OK(ctx, clvox__element_mesh_build(ctx, p, e, &m[e]));
    uint64_t voxels = 0, nv = 0, nt = 0;
    double expect_volume = 0;
    for (uint32_t k = 0; k < v->dims[2]; k++)
        for (uint32_t j = 0; j < v->dims[1]; j++)
            for (uint32_t i = 0; i < v->dims[0]; i++) {
                size_t e = (size_t)test_element(i, j, k, count);
                voxels += e != 0;
                nv += m[e].vertex_count;
                nt += m[e].triangle_count;
                expect_volume += m[e].volume * v->h[0] * v->h[1] * v->h[2];
            }
    CHECK(tb.voxels == voxels && tb.vertices == nv && tb.triangles == nt);
    CHECK(tb.bytes == tb.header_bytes + 12 * nv + 13 * nt && ta.bytes == ta.header_bytes + 48 * nv + 35 * nt);

    FILE *f = fopen(bin, "rb");
    char head[1024] = {0};
    if (f) {
        CHECK(fread(head, 1, sizeof head - 1, f) > 0);
        fclose(f);
    }
    CHECK(strncmp(head, "ply\nformat binary_little_endian 1.0\ncomment clvox ", 50) == 0);
    char want[128];
    snprintf(want, sizeof want, "element vertex %llu\n", (unsigned long long)nv);
    CHECK(strstr(head, want) != NULL);

    clvox_mesh *mb = NULL, *ma = NULL;
    CHECK_OK(ctx, clvox_mesh_load(ctx, bin, &mb));
    CHECK_OK(ctx, clvox_mesh_load(ctx, asc, &ma));
    if (mb && ma) {
        const clvox_mesh_report *r = clvox_mesh_get_report(mb);
        CHECK(r->vertices == nv && r->triangles == nt && r->dropped_faces == 0);
        CHECK_MSG(r->boundary_edges == 0 && r->closed && r->nonmanifold_faces == 0,
                  "%llu boundary edges, %llu non-manifold", (unsigned long long)r->boundary_edges,
                  (unsigned long long)r->nonmanifold_faces);
        CHECK_MSG(fabs(r->enclosed_volume - expect_volume) <= 1e-5 * expect_volume, "enclosed %.9g, expected %.9g",
                  r->enclosed_volume, expect_volume);
        int in_box = 1;
        for (int a = 0; a < 3; a++) {
            double lo = v->origin[a], hi = v->origin[a] + v->dims[a] * v->h[a], slack = 1e-6 * (fabs(lo) + fabs(hi));
            in_box &= r->bbox_min[a] >= lo - slack && r->bbox_max[a] <= hi + slack;
        }
        CHECK(in_box);
        printf("export %-8s %llu voxels, %llu vertices, %llu triangles, %llu + %llu bytes; mesh report: %llu "
               "boundary edges, %llu duplicate triangles, closed %d\n",
               clvox_palette_name(p), (unsigned long long)voxels, (unsigned long long)nv, (unsigned long long)nt,
               (unsigned long long)tb.bytes, (unsigned long long)ta.bytes, (unsigned long long)r->boundary_edges,
               (unsigned long long)r->duplicate_triangles, r->closed);
        /* ASCII and binary hold the same floats and indices */
        size_t na, nb, ta_n, tb_n;
        const float *xa = clvox_mesh_vertices(ma, &na), *xb = clvox_mesh_vertices(mb, &nb);
        const uint32_t *ia = clvox_mesh_triangles(ma, &ta_n), *ib = clvox_mesh_triangles(mb, &tb_n);
        CHECK(na == nb && ta_n == tb_n && memcmp(xa, xb, 3 * na * sizeof *xa) == 0 &&
              memcmp(ia, ib, 3 * ta_n * sizeof *ia) == 0);
        /* every vertex is origin + (cell + u) * h, rounded once; triangles in mesh order */
        size_t vi = 0, ti = 0;
        int exact = 1, order = 1;
        for (uint32_t k = 0; k < v->dims[2]; k++)
            for (uint32_t j = 0; j < v->dims[1]; j++)
                for (uint32_t i = 0; i < v->dims[0]; i++) {
                    const clvox__element_mesh *em = &m[(size_t)test_element(i, j, k, count)];
                    double cell[3] = {i, j, k};
                    for (size_t q = 0; q < em->triangle_count && ti < tb_n; q++, ti++)
                        for (int c = 0; c < 3; c++) order &= ib[3 * ti + c] == vi + em->tris[3 * q + c];
                    for (size_t q = 0; q < em->vertex_count && vi < nb; q++, vi++)
                        for (int a = 0; a < 3; a++)
                            exact &= xb[3 * vi + a] == (float)(v->origin[a] + (cell[a] + em->xyz[3 * q + a]) * v->h[a]);
                }
        CHECK(exact && order && vi == nb && ti == tb_n);
    }
    clvox_mesh_destroy(mb);
    clvox_mesh_destroy(ma);
    for (size_t e = 0; e < count; e++) clvox__element_mesh_free(&m[e]);
    free(m);
}

static void test_export_errors(clvox_palette *p)
{
    volume v = {{3, 2, 2}, {0, 0, 0}, {1, 1, 1}};
    clvox__ply_export *x = NULL;
    double bad_h[3] = {1, 0, 1}, huge[3] = {1e39, 0, 0}, one[3] = {1, 1, 1};
    uint32_t zero_dims[3] = {3, 0, 2};
    CHECK_STATUS(ctx, clvox__ply_export_create(ctx, p, v.dims, v.origin, bad_h, 0, &x), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK(x == NULL);
    CHECK_STATUS(ctx, clvox__ply_export_create(ctx, p, v.dims, huge, one, 0, &x), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(ctx, clvox__ply_export_create(ctx, p, zero_dims, v.origin, one, 0, &x), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(ctx, clvox__ply_export_create(ctx, NULL, v.dims, v.origin, one, 0, &x), CLVOX_ERR_INVALID_ARGUMENT);
    clvox__ply_export_destroy(NULL);

    /* values that are not element indices */
    const float bad[] = {(float)clvox_palette_count(p), 1.5f, -1.0f, NAN, INFINITY, 1e30f};
    for (size_t b = 0; b < sizeof bad / sizeof bad[0]; b++) {
        CHECK_OK(ctx, clvox__ply_export_create(ctx, p, v.dims, v.origin, v.h, 0, &x));
        float s[6] = {0, 1, 2, 3, 4, 5};
        s[4] = bad[b];
        CHECK_STATUS(ctx, clvox__ply_export_count(x, 0, s), CLVOX_ERR_EXR);
        CHECK_MSG(strstr(clvox_context_error(ctx), "voxel (1, 1, 0) has element") != NULL, "%s", clvox_context_error(ctx));
        clvox__ply_export_destroy(x);
        x = NULL;
    }

    /* pass order: totals need every slice, slices once and in order */
    float a[6] = {0, 1, 2, 3, 4, 5}, more[6] = {6, 1, 2, 3, 4, 5}, fewer[6] = {0, 0, 2, 3, 4, 5};
    clvox__ply_totals t;
    char path[4096];
    snprintf(path, sizeof path, "%s/element_mesh_errors.ply", test_tmpdir());
    file_sink sink = {open(path, O_WRONLY | O_CREAT | O_TRUNC, 0644), 0, 0};
    CHECK(sink.fd >= 0);
    CHECK_OK(ctx, clvox__ply_export_create(ctx, p, v.dims, v.origin, v.h, 0, &x));
    CHECK_OK(ctx, clvox__ply_export_count(x, 1, a));
    CHECK_STATUS(ctx, clvox__ply_export_count(x, 1, a), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(ctx, clvox__ply_export_count(x, 2, a), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(ctx, clvox__ply_export_totals(x, &t), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(ctx, clvox__ply_export_slice(x, 0, a), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_OK(ctx, clvox__ply_export_count(x, 0, a));
    CHECK_OK(ctx, clvox__ply_export_totals(x, &t));
    CHECK(t.voxels == 10);
    CHECK_OK(ctx, clvox__ply_export_begin(x, sink_write_at, &sink));
    CHECK_STATUS(ctx, clvox__ply_export_count(x, 0, a), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(ctx, clvox__ply_export_slice(x, 1, a), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(ctx, clvox__ply_export_finish(x), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_OK(ctx, clvox__ply_export_slice(x, 0, a));
    CHECK_STATUS(ctx, clvox__ply_export_slice(x, 1, more), CLVOX_ERR_IO); /* the volume changed */
    CHECK(strstr(clvox_context_error(ctx), "changed") != NULL);
    clvox__ply_export_destroy(x);

    CHECK_OK(ctx, clvox__ply_export_create(ctx, p, v.dims, v.origin, v.h, 0, &x));
    CHECK_OK(ctx, clvox__ply_export_count(x, 0, a));
    CHECK_OK(ctx, clvox__ply_export_count(x, 1, a));
    CHECK_OK(ctx, clvox__ply_export_begin(x, sink_write_at, &sink));
    CHECK_OK(ctx, clvox__ply_export_slice(x, 0, a));
    CHECK_OK(ctx, clvox__ply_export_slice(x, 1, fewer));
    CHECK_STATUS(ctx, clvox__ply_export_finish(x), CLVOX_ERR_IO);
    clvox__ply_export_destroy(x);

    /* a failing write (the header, then a buffer flush) */
    for (int n = 1; n <= 2; n++) {
        CHECK_OK(ctx, clvox__ply_export_create(ctx, p, v.dims, v.origin, v.h, 0, &x));
        CHECK_OK(ctx, clvox__ply_export_count(x, 0, a));
        CHECK_OK(ctx, clvox__ply_export_count(x, 1, a));
        sink.fail_after = n;
        sink.writes = 0;
        clvox_status st = clvox__ply_export_begin(x, sink_write_at, &sink);
        if (st == CLVOX_OK) st = clvox__ply_export_slice(x, 0, a);
        if (st == CLVOX_OK) st = clvox__ply_export_slice(x, 1, a);
        if (st == CLVOX_OK) st = clvox__ply_export_finish(x);
        CHECK_MSG(st == CLVOX_ERR_IO && strstr(clvox_context_error(ctx), strerror(ENOSPC)), "write %d: %s", n,
                  clvox_context_error(ctx));
        clvox__ply_export_destroy(x);
    }
    sink.fail_after = 0;

    /* an empty volume: a valid PLY with no vertices and no faces */
    float empty[6] = {0};
    CHECK_OK(ctx, clvox__ply_export_create(ctx, p, v.dims, v.origin, v.h, 1, &x));
    CHECK_OK(ctx, clvox__ply_export_count(x, 0, empty));
    CHECK_OK(ctx, clvox__ply_export_count(x, 1, empty));
    CHECK_OK(ctx, clvox__ply_export_totals(x, &t));
    CHECK(t.voxels == 0 && t.vertices == 0 && t.triangles == 0 && t.bytes == t.header_bytes);
    CHECK(ftruncate(sink.fd, 0) == 0);
    CHECK_OK(ctx, clvox__ply_export_begin(x, sink_write_at, &sink));
    CHECK_OK(ctx, clvox__ply_export_slice(x, 0, empty));
    CHECK_OK(ctx, clvox__ply_export_slice(x, 1, empty));
    CHECK_OK(ctx, clvox__ply_export_finish(x));
    clvox__ply_export_destroy(x);
    close(sink.fd);
    CHECK(file_size(path) == (long)t.header_bytes);
}

static void test_export(void)
{
    clvox_palette *p = builtin("paper78");
    volume v = {{5, 4, 3}, {-1.5, 0.25, 2.0}, {0.5, 0.25, 1.0}};
    if (p) test_export_file(p, &v);
    if (p) test_export_errors(p);
    clvox_palette_destroy(p);
    p = NULL;
    CHECK_OK(ctx, clvox_palette_load(ctx, "palettes/blocks.txt", &p));
    volume w = {{6, 5, 4}, {10.0, -3.0, 0.1}, {0.3, 0.7, 0.2}}; /* not dyadic: rounding only */
    if (p) test_export_file(p, &w);
    clvox_palette_destroy(p);
}

/* ---- the export voxelized again ---- */

/* Element membership of p moved by an infinitesimal step that is largest
 * along axis ord[0], then ord[1], then ord[2] (p + e1 u0 + e2 u1 + e3 u2,
 * e1 >> e2 >> e3 > 0): the classification the ray method's tie rules give a
 * point on a face, for rays along ord[0] (docs/design.md "Inside test").
 * Exact for the dyadic points and planes used here. */
static int perturbed_contains(const clvox_palette *p, size_t e, const double pt[3], const int ord[3])
{
    const clvox_element *els;
    const clvox_cell *cells;
    const clvox_halfspace *planes;
    size_t ne, nc, np;
    clvox__palette_arrays(p, &els, &ne, &cells, &nc, &planes, &np);
    const clvox_element *el = &els[e];
    int in = 0;
    for (uint32_t c = 0; c < el->cell_count && !in; c++) {
        const clvox_cell *cell = &cells[el->first_cell + c];
        int all = 1;
        for (uint32_t k = 0; k < cell->plane_count && all; k++) {
            const clvox_halfspace *h = &planes[cell->first_plane + k];
            double a[3] = {h->a, h->b, h->c};
            double s = a[0] * pt[0] + a[1] * pt[1] + a[2] * pt[2] - h->d;
            if (s == 0) s = a[ord[0]] != 0 ? a[ord[0]] : a[ord[1]] != 0 ? a[ord[1]] : a[ord[2]];
            all = s < 0;
        }
        in = all;
    }
    return el->complement ? !in : in;
}

static int on_plane(const clvox_palette *p, size_t e, const double pt[3])
{
    const clvox_halfspace *hs;
    size_t nh;
    element_planes(p, e, &hs, &nh);
    for (size_t h = 0; h < nh; h++)
        if ((double)hs[h].a * pt[0] + (double)hs[h].b * pt[1] + (double)hs[h].c * pt[2] == (double)hs[h].d) return 1;
    return 0;
}

#define FINE 4u

/* Voxelizes the PLY at `ply` (the export of volume v with elements el) with
 * the binary ray method on the grid FINE times finer (same box): each
 * sub-voxel centre ((a + 1/2) / FINE per axis in its voxel) must be inside
 * exactly where the voxel's element holds it. Centres on a plane of the
 * element (x + y = 1 meets (a + 1/2)/4 + (b + 1/2)/4 for a + b = 3; no fine
 * factor avoids it, the lattice is symmetric about 1/2) are counted apart
 * and, when exact_ties (a dyadic grid: every coordinate exact in float),
 * compared with the tie rule (the point moved by +e along the ray axis,
 * then less along the other two in cyclic order; the tetra method moves it
 * along x, then y, then z). Off the planes, for integer coefficients and d
 * in halves (built-ins, blocks.txt), a.p - d is a non-zero multiple of 1/8,
 * far above float rounding. Rays along x, y and z, and the tetra method. */
static void check_revoxelized(clvox_context *dev, const clvox_palette *p, const volume *v, const float *el,
                              const char *ply, int exact_ties)
{
    uint32_t X = v->dims[0], Y = v->dims[1];
    clvox_mesh *mesh = NULL;
    CHECK_OK(dev, clvox_mesh_load(dev, ply, &mesh));
    if (!mesh) return;
    const clvox_mesh_report *r = clvox_mesh_get_report(mesh);
    CHECK(r->boundary_edges == 0 && r->closed && r->nonmanifold_faces == 0);
    clvox_grid_options go = CLVOX_GRID_OPTIONS_INIT;
    go.use_box = 1;
    for (int a = 0; a < 3; a++) {
        go.dims[a] = v->dims[a] * FINE;
        go.box_min[a] = v->origin[a];
        go.box_max[a] = v->origin[a] + v->dims[a] * v->h[a];
    }
    clvox_grid g;
    CHECK_OK(dev, clvox_grid_compute(dev, &go, go.box_min, go.box_max, &g));
    int aligned = 1;
    for (int a = 0; a < 3; a++)
        aligned &= g.dims[a] == v->dims[a] * FINE && g.origin[a] == v->origin[a] &&
                   fabs(g.voxel_size[a] - v->h[a] / FINE) <= 1e-15 * v->h[a];
    CHECK(aligned);
    size_t nfine = (size_t)g.dims[0] * g.dims[1] * g.dims[2];
    uint8_t *occ = malloc(nfine);
    /* x rays: (x, y, z); y: (y, z, x); z: (z, x, y); tetra: (x, y, z) */
    static const int orders[4][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 1, 2}};
    static const clvox_axis axes[4] = {CLVOX_AXIS_X, CLVOX_AXIS_Y, CLVOX_AXIS_Z, CLVOX_AXIS_DEFAULT};
    static const char *const what[4] = {"x rays", "y rays", "z rays", "tetra"};
    for (int ax = 0; ax < 4 && occ && aligned; ax++) {
        clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
        o.ray_axis = axes[ax];
        if (ax == 3) o.method = CLVOX_METHOD_TETRA;
        clvox_stats stats = CLVOX_STATS_INIT;
        memset(occ, 0, nfine);
        CHECK_OK(dev, clvox_voxelize_to_memory(dev, mesh, &g, &o, occ, nfine, &stats));
        CHECK(ax == 3 || stats.odd_parity_rays == 0);
        size_t off_plane = 0, off_bad = 0, on = 0, on_bad = 0, inside = 0;
        for (uint32_t K = 0; K < g.dims[2]; K++)
            for (uint32_t J = 0; J < g.dims[1]; J++)
                for (uint32_t I = 0; I < g.dims[0]; I++) {
                    size_t e = (size_t)el[((size_t)(K / FINE) * Y + J / FINE) * X + I / FINE];
                    double pt[3] = {(I % FINE + 0.5) / FINE, (J % FINE + 0.5) / FINE, (K % FINE + 0.5) / FINE};
                    int got = occ[((size_t)K * g.dims[1] + J) * g.dims[0] + I];
                    inside += (size_t)got;
                    if (on_plane(p, e, pt)) {
                        on++;
                        on_bad += got != perturbed_contains(p, e, pt, orders[ax]);
                    } else {
                        off_plane++;
                        off_bad += got != clvox_palette_contains(p, e, (float)pt[0], (float)pt[1], (float)pt[2]);
                    }
                }
        CHECK_MSG(off_bad == 0, "%s, %s: %zu of %zu sub-voxel centres off the planes differ", clvox_palette_name(p),
                  what[ax], off_bad, off_plane);
        if (exact_ties)
            CHECK_MSG(on_bad == 0, "%s, %s: %zu of %zu sub-voxel centres on element planes differ from the tie rule",
                      clvox_palette_name(p), what[ax], on_bad, on);
        if (ax == 0)
            printf("revoxelized %-8s at %ux: %zu sub-voxel centres, %zu inside; %zu off the planes (%zu differ), %zu on an "
                   "element plane (%zu differ from the tie rule%s)\n",
                   clvox_palette_name(p), FINE, nfine, inside, off_plane, off_bad, on, on_bad,
                   exact_ties ? "" : ", not checked");
    }
    free(occ);
    clvox_mesh_destroy(mesh);
}

/* A volume holding every element of p, exported and voxelized again. */
static void test_revoxelize(clvox_context *dev, clvox_palette *p)
{
    size_t count = clvox_palette_count(p);
    volume v = {{8, 5, 4}, {-2.0, 0.25, 8.0}, {1.0, 0.5, 2.0}}; /* dyadic: every coordinate exact in float */
    uint32_t X = v.dims[0], Y = v.dims[1], Z = v.dims[2];
    size_t nvox = (size_t)X * Y * Z;
    float *el = malloc(nvox * sizeof *el);
    unsigned char *seen = calloc(count, 1);
    for (size_t n = 0; n < nvox; n++) {
        el[n] = n % 7 == 6 ? 0.0f : (float)((n * 37 + 3) % count);
        seen[(size_t)el[n]] = 1;
    }
    size_t missing = 0;
    for (size_t e = 0; e < count; e++) missing += !seen[e];
    CHECK_MSG(missing == 0, "%s: %zu elements not in the test volume", clvox_palette_name(p), missing);

    char path[4096];
    snprintf(path, sizeof path, "%s/element_mesh_revox_%s.ply", test_tmpdir(), clvox_palette_name(p));
    clvox__ply_export *x = NULL;
    clvox__ply_totals t;
    clvox_status st = clvox__ply_export_create(ctx, p, v.dims, v.origin, v.h, 0, &x);
    for (uint32_t k = 0; k < Z && st == CLVOX_OK; k++) st = clvox__ply_export_count(x, k, el + (size_t)k * X * Y);
    if (st == CLVOX_OK) st = clvox__ply_export_totals(x, &t);
    file_sink sink = {open(path, O_WRONLY | O_CREAT | O_TRUNC, 0644), 0, 0};
    if (st == CLVOX_OK) st = sink.fd >= 0 ? clvox__ply_export_begin(x, sink_write_at, &sink) : CLVOX_ERR_IO;
    for (uint32_t k = 0; k < Z && st == CLVOX_OK; k++) st = clvox__ply_export_slice(x, k, el + (size_t)k * X * Y);
    if (st == CLVOX_OK) st = clvox__ply_export_finish(x);
    CHECK_OK(ctx, st);
    if (sink.fd >= 0) close(sink.fd);
    clvox__ply_export_destroy(x);
    if (st == CLVOX_OK) check_revoxelized(dev, p, &v, el, path, 1);
    free(el);
    free(seen);
}

static void test_cli(clvox_context *dev); /* below */

static void test_revoxelize_all(void)
{
    clvox_context *dev = NULL;
    clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
    CHECK_OK(dev, clvox_context_create(&o, &dev));
    if (dev && clvox_context_device(dev)) {
        static const char *const names[] = {"planar10", "paper78"};
        for (size_t i = 0; i < 2; i++) {
            clvox_palette *p = builtin(names[i]);
            if (p) test_revoxelize(dev, p);
            clvox_palette_destroy(p);
        }
        clvox_palette *p = NULL;
        CHECK_OK(ctx, clvox_palette_load(ctx, "palettes/blocks.txt", &p));
        if (p) test_revoxelize(dev, p);
        clvox_palette_destroy(p);
        test_cli(dev);
    }
    clvox_context_destroy(dev);
}

/* ---- clvox mesh, end to end ---- */

typedef struct cli_run {
    int code;        /* exit status, -1 when it did not exit */
    char out[4096];  /* stdout (truncated) */
    char err[4096];  /* stderr (truncated) */
} cli_run;

/* dst = dir/name; aborts when it does not fit. */
static void join(char *dst, size_t size, const char *dir, const char *name)
{
    int n = snprintf(dst, size, "%s/%s", dir, name);
    if (n < 0 || (size_t)n >= size) {
        fprintf(stderr, "path too long: %s/%s\n", dir, name);
        abort();
    }
}

static void read_text(const char *path, char *buf, size_t size)
{
    buf[0] = '\0';
    FILE *f = fopen(path, "rb");
    if (!f) return;
    size_t n = fread(buf, 1, size - 1, f);
    buf[n] = '\0';
    fclose(f);
}

/* Runs $CLVOX_BIN (default build/release/clvox) with args (NULL-terminated), no shell. */
static void run_clvox(cli_run *r, const char *const *args)
{
    const char *bin = getenv("CLVOX_BIN");
    if (!bin || !*bin) bin = "build/release/clvox";
    const char *argv[32];
    size_t n = 0;
    argv[n++] = bin;
    for (size_t i = 0; args[i] && n < 31; i++) argv[n++] = args[i];
    argv[n] = NULL;
    char out_path[4096], err_path[4096];
    snprintf(out_path, sizeof out_path, "%s/element_mesh_cli.out", test_tmpdir());
    snprintf(err_path, sizeof err_path, "%s/element_mesh_cli.err", test_tmpdir());
    fflush(stdout);
    fflush(stderr);
    r->code = -1;
    pid_t pid = fork();
    if (pid == 0) {
        int o = open(out_path, O_WRONLY | O_CREAT | O_TRUNC, 0644), e = open(err_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (o < 0 || e < 0 || dup2(o, 1) < 0 || dup2(e, 2) < 0) _exit(126);
        execv(bin, (char *const *)argv);
        _exit(127);
    }
    int status = 0;
    if (pid > 0 && waitpid(pid, &status, 0) == pid && WIFEXITED(status)) r->code = WEXITSTATUS(status);
    read_text(out_path, r->out, sizeof r->out);
    read_text(err_path, r->err, sizeof r->err);
}

static int one_line(const char *s)
{
    size_t n = strlen(s);
    return n > 0 && s[n - 1] == '\n' && memchr(s, '\n', n - 1) == NULL;
}

/* Names in dir other than those listed (NULL-terminated): leftovers. */
static size_t other_entries(const char *dir, const char *const *keep)
{
    DIR *d = opendir(dir);
    if (!d) return 0;
    size_t n = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
        int kept = 0;
        for (size_t i = 0; keep[i]; i++) kept |= strcmp(e->d_name, keep[i]) == 0;
        if (!kept) {
            fprintf(stderr, "leftover: %s/%s\n", dir, e->d_name);
            n++;
        }
    }
    closedir(d);
    return n;
}

typedef struct element_volume {
    volume v;
    float *el;
    size_t n, filled;
} element_volume;

static int grab_slice(void *user, uint32_t z, const float *values)
{
    element_volume *ev = user;
    size_t s = (size_t)ev->v.dims[0] * ev->v.dims[1];
    memcpy(ev->el + (size_t)z * s, values, s * sizeof *values);
    for (size_t i = 0; i < s; i++) ev->filled += values[i] != 0.0f;
    return 0;
}

/* One palette run of the bundled mesh on a dyadic grid, then clvox mesh. */
static void e2e_palette(clvox_context *dev, const char *dir, const char *palette_arg)
{
    char vol[4096], ply[4096], asc[4096];
    join(vol, sizeof vol, dir, "vol.exr");
    join(ply, sizeof ply, dir, "vol.ply");
    join(asc, sizeof asc, dir, "vol_ascii.ply");
    cli_run r;
    run_clvox(&r, (const char *const[]){"tests/data/default.obj", "--box", "-2,-2,-1,2,2,1", "--dims", "16,16,8",
                                         "--palette", palette_arg, "-q", "-o", vol, NULL});
    CHECK_MSG(r.code == 0, "palette run: exit %d: %s", r.code, r.err);
    run_clvox(&r, (const char *const[]){"mesh", vol, "-o", ply, NULL});
    CHECK_MSG(r.code == 0 && one_line(r.out) && r.err[0] == '\0', "clvox mesh: exit %d: %s%s", r.code, r.out, r.err);
    printf("clvox mesh (%s): %s", palette_arg, r.out);
    run_clvox(&r, (const char *const[]){"mesh", "--ascii", vol, "--output", asc, NULL});
    CHECK_MSG(r.code == 0 && strstr(r.out, "(ascii)") != NULL, "clvox mesh --ascii: exit %d: %s%s", r.code, r.out, r.err);

    element_volume ev;
    memset(&ev, 0, sizeof ev);
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    clvox_palette *p = NULL;
    CHECK_OK(ctx, clvox_volume_palette(ctx, vol, &p));
    CHECK_OK(ctx, clvox_volume_read(ctx, vol, &info, NULL, 0));
    for (int a = 0; a < 3; a++) {
        ev.v.dims[a] = info.dims[a];
        ev.v.origin[a] = info.origin[a];
        ev.v.h[a] = info.voxel_size[a];
    }
    ev.n = (size_t)info.dims[0] * info.dims[1] * info.dims[2];
    ev.el = calloc(ev.n, sizeof *ev.el);
    CHECK(info.dims[0] == 16 && info.dims[1] == 16 && info.dims[2] == 8 && info.voxel_size[0] == 0.25);
    CHECK_OK(ctx, clvox_volume_read_slices(ctx, vol, "element", NULL, grab_slice, &ev));
    char want[128];
    snprintf(want, sizeof want, ": %zu voxels of 16 x 16 x 8 (palette %s, ", ev.filled, p ? clvox_palette_name(p) : "?");
    CHECK_MSG(strstr(r.out, want) != NULL, "summary '%s' lacks '%s'", r.out, want);
    CHECK(ev.filled > 0);
    if (p) check_revoxelized(dev, p, &ev.v, ev.el, ply, 1);

    clvox_mesh *mb = NULL, *ma = NULL;
    CHECK_OK(ctx, clvox_mesh_load(ctx, ply, &mb));
    CHECK_OK(ctx, clvox_mesh_load(ctx, asc, &ma));
    if (mb && ma) {
        size_t nb, na, tb, ta;
        const float *xb = clvox_mesh_vertices(mb, &nb), *xa = clvox_mesh_vertices(ma, &na);
        const uint32_t *ib = clvox_mesh_triangles(mb, &tb), *ia = clvox_mesh_triangles(ma, &ta);
        CHECK(nb == na && tb == ta && !memcmp(xb, xa, 3 * nb * sizeof *xb) && !memcmp(ib, ia, 3 * tb * sizeof *ib));
    }
    clvox_mesh_destroy(mb);
    clvox_mesh_destroy(ma);
    clvox_palette_destroy(p);
    free(ev.el);
}

static void test_cli(clvox_context *dev)
{
    char dir[4096], out[4096], vol[4096], plain[4096], link_path[4096], target[4096], fifo[4096];
    snprintf(dir, sizeof dir, "%s/element_mesh_cli", test_tmpdir());
    mkdir(dir, 0777);
    join(vol, sizeof vol, dir, "vol.exr");
    join(plain, sizeof plain, dir, "plain.exr");
    join(out, sizeof out, dir, "out");
    mkdir(out, 0777);
    e2e_palette(dev, dir, "paper78");
    e2e_palette(dev, dir, "palettes/blocks.txt");

    /* failures: one line on stderr, the documented exit code, nothing left in out/ */
    cli_run r;
    char bad_out[4096], missing_dir[4096], missing_vol[4096];
    join(bad_out, sizeof bad_out, out, "x.ply");
    join(missing_dir, sizeof missing_dir, dir, "no/such/dir/x.ply");
    join(missing_vol, sizeof missing_vol, dir, "missing.exr");
    run_clvox(&r, (const char *const[]){"tests/data/default.obj", "-r", "12", "-q", "-o", plain, NULL});
    CHECK(r.code == 0);
    run_clvox(&r, (const char *const[]){"mesh", plain, "-o", bad_out, NULL});
    /* not a palette volume: its voxel faces (tests/test_volume_mesh.c) */
    CHECK_MSG(r.code == 0 && strstr(r.out, "voxel faces of occupancy"), "%d %s", r.code, r.err);
    unlink(bad_out);
    run_clvox(&r, (const char *const[]){"mesh", missing_vol, "-o", bad_out, NULL});
    CHECK_MSG(r.code == 4 && one_line(r.err), "%d %s", r.code, r.err);
    run_clvox(&r, (const char *const[]){"mesh", vol, "-o", missing_dir, NULL});
    CHECK_MSG(r.code == 5 && one_line(r.err), "%d %s", r.code, r.err);
    run_clvox(&r, (const char *const[]){"mesh", vol, "-o", out, NULL});
    CHECK_MSG(r.code == 5 && one_line(r.err) && strstr(r.err, "directory"), "%d %s", r.code, r.err);
    run_clvox(&r, (const char *const[]){"mesh", vol, "-o", vol, NULL});
    CHECK_MSG(r.code == 2 && one_line(r.err) && strstr(r.err, "input"), "%d %s", r.code, r.err);
    run_clvox(&r, (const char *const[]){"mesh", vol, NULL});
    CHECK_MSG(r.code == 2 && one_line(r.err) && strstr(r.err, "-o"), "%d %s", r.code, r.err);
    run_clvox(&r, (const char *const[]){"mesh", "-o", bad_out, NULL});
    CHECK_MSG(r.code == 2 && one_line(r.err), "%d %s", r.code, r.err);
    run_clvox(&r, (const char *const[]){"mesh", vol, vol, "-o", bad_out, NULL});
    CHECK_MSG(r.code == 2 && one_line(r.err), "%d %s", r.code, r.err);
    run_clvox(&r, (const char *const[]){"mesh", vol, "-o", bad_out, "--binary", NULL});
    CHECK_MSG(r.code == 2 && one_line(r.err) && strstr(r.err, "--binary"), "%d %s", r.code, r.err);
    run_clvox(&r, (const char *const[]){"mesh", "--help", NULL});
    CHECK(r.code == 0 && strstr(r.out, "Usage: clvox mesh VOLUME -o OUT.{ply,obj,stl}"));
    /* not a regular file at OUT: refused and left alone */
    join(target, sizeof target, out, "target.txt");
    join(link_path, sizeof link_path, out, "link.ply");
    join(fifo, sizeof fifo, out, "fifo.ply");
    FILE *f = fopen(target, "w");
    if (f) {
        fputs("keep\n", f);
        fclose(f);
    }
    unlink(link_path);
    CHECK(symlink("target.txt", link_path) == 0);
    run_clvox(&r, (const char *const[]){"mesh", vol, "-o", link_path, NULL});
    CHECK_MSG(r.code == 5 && one_line(r.err) && strstr(r.err, "symbolic link"), "%d %s", r.code, r.err);
    char kept[16];
    read_text(target, kept, sizeof kept);
    CHECK(strcmp(kept, "keep\n") == 0);
    unlink(fifo);
    CHECK(mkfifo(fifo, 0644) == 0);
    run_clvox(&r, (const char *const[]){"mesh", vol, "-o", fifo, NULL});
    CHECK_MSG(r.code == 5 && one_line(r.err), "%d %s", r.code, r.err);
    CHECK(other_entries(out, (const char *const[]){"target.txt", "link.ply", "fifo.ply", NULL}) == 0);
    /* an existing regular file is replaced (the output needs a mesh
     * extension: .ply, .obj or .stl) */
    run_clvox(&r, (const char *const[]){"mesh", vol, "-o", target, NULL});
    CHECK_MSG(r.code == 2 && strstr(r.err, "unknown mesh extension"), "%d %s", r.code, r.err);
    char replaced[4096];
    join(replaced, sizeof replaced, out, "replaced.ply");
    f = fopen(replaced, "w");
    if (f) {
        fputs("keep\n", f);
        fclose(f);
    }
    run_clvox(&r, (const char *const[]){"mesh", vol, "-o", replaced, NULL});
    CHECK(r.code == 0);
    read_text(replaced, kept, sizeof kept);
    CHECK(strncmp(kept, "ply\n", 4) == 0);
    unlink(replaced);
    CHECK(other_entries(out, (const char *const[]){"target.txt", "link.ply", "fifo.ply", NULL}) == 0);
    unlink(fifo);
    unlink(link_path);
}

int main(void)
{
    clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
    o.host_only = 1;
    if (clvox_context_create(&o, &ctx) != CLVOX_OK) {
        printf("0 passed, 1 failed\n");
        return 1;
    }
    test_geometry();
    test_export();
    test_revoxelize_all();
    clvox_context_destroy(ctx);
    return test_report();
}
