/* SPDX-License-Identifier: Apache-2.0 */
/* Deterministic test meshes; see meshgen.h. */
#include "meshgen.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846
static void *grow(void *p, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap) return p;
    size_t c = *cap ? *cap : 64;
    while (c < need) c *= 2;
    if (!(p = realloc(p, c * elem))) { fprintf(stderr, "meshgen: out of memory\n"); abort(); }
    *cap = c;
    return p;
}
void tmesh_free(tmesh *m)
{
    if (!m) return;
    free(m->xyz); free(m->tri);
    memset(m, 0, sizeof *m);
}
uint32_t tmesh_add_vertex(tmesh *m, double x, double y, double z)
{
    m->xyz = grow(m->xyz, &m->cap_v, m->nv + 1, 3 * sizeof(float));
    float *v = m->xyz + 3 * m->nv;
    v[0] = (float)x; v[1] = (float)y; v[2] = (float)z;
    return (uint32_t)m->nv++;
}
void tmesh_add_tri(tmesh *m, uint32_t a, uint32_t b, uint32_t c)
{
    m->tri = grow(m->tri, &m->cap_t, m->nt + 1, 3 * sizeof(uint32_t));
    uint32_t *t = m->tri + 3 * m->nt++;
    t[0] = a; t[1] = b; t[2] = c;
}
static void add_quad(tmesh *m, uint32_t a, uint32_t b, uint32_t c, uint32_t d)
{
    tmesh_add_tri(m, a, b, c); tmesh_add_tri(m, a, c, d);
}
void tmesh_append(tmesh *dst, const tmesh *src)
{
    uint32_t off = (uint32_t)dst->nv;
    for (size_t i = 0; i < src->nv; i++)
        tmesh_add_vertex(dst, src->xyz[3 * i], src->xyz[3 * i + 1], src->xyz[3 * i + 2]);
    for (const uint32_t *t = src->tri; t < src->tri + 3 * src->nt; t += 3)
        tmesh_add_tri(dst, t[0] + off, t[1] + off, t[2] + off);
}
void tmesh_flip(tmesh *m)
{
    for (uint32_t *t = m->tri; t < m->tri + 3 * m->nt; t += 3) { uint32_t s = t[1]; t[1] = t[2]; t[2] = s; }
}
void tmesh_translate(tmesh *m, double x, double y, double z)
{
    for (float *v = m->xyz; v < m->xyz + 3 * m->nv; v += 3) {
        v[0] = (float)(v[0] + x); v[1] = (float)(v[1] + y); v[2] = (float)(v[2] + z);
    }
}
static void vget(const tmesh *m, size_t i, double *o) { for (int k = 0; k < 3; k++) o[k] = m->xyz[3 * i + k]; }
static void tri_get(const tmesh *m, size_t t, double v[3][3])
{
    for (int k = 0; k < 3; k++) vget(m, m->tri[3 * t + k], v[k]);
}
static void sub3(const double *a, const double *b, double *o) { for (int k = 0; k < 3; k++) o[k] = a[k]-b[k]; }
static double dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static void cross3(const double a[3], const double b[3], double o[3])
{
    o[0] = a[1] * b[2] - a[2] * b[1]; o[1] = a[2] * b[0] - a[0] * b[2]; o[2] = a[0] * b[1] - a[1] * b[0];
}
double tmesh_volume(const tmesh *m)
{
    if (!m->nt) return 0.0;
    double o[3], v[3][3], n[3], sum = 0.0;
    vget(m, m->tri[0], o); /* reference point: less cancellation far from 0 */
    for (size_t i = 0; i < m->nt; i++) {
        tri_get(m, i, v);
        for (int k = 0; k < 3; k++) sub3(v[k], o, v[k]);
        cross3(v[1], v[2], n);
        sum += dot3(v[0], n);
    }
    return sum / 6.0;
}
static int cmp_u64(const void *a, const void *b)
{
    return (*(const uint64_t *)a > *(const uint64_t *)b) - (*(const uint64_t *)a < *(const uint64_t *)b);
}
int tmesh_is_closed(const tmesh *m)
{
    size_t ne = 3 * m->nt;
    uint64_t *e = malloc((ne ? ne : 1) * sizeof *e);
    int ok = m->nt > 0;
    if (!e) abort();
    for (size_t i = 0; i < ne; i++) {
        uint32_t a = m->tri[i], b = m->tri[i - i % 3 + (i + 1) % 3];
        if (a == b || a >= m->nv) ok = 0;
        e[i] = (uint64_t)a << 32 | b;
    }
    qsort(e, ne, sizeof *e, cmp_u64);
    for (size_t i = 0; ok && i < ne; i++) {
        uint64_t r = e[i] << 32 | e[i] >> 32;
        if ((i + 1 < ne && e[i + 1] == e[i]) || !bsearch(&r, e, ne, sizeof *e, cmp_u64))
            ok = 0; /* a directed edge used twice, or without its opposite */
    }
    free(e);
    return ok;
}

/* ---- writers ---- */
static int finish(FILE *f, int ok) { return fclose(f) == 0 && ok ? 0 : -1; }
static int write_text(const tmesh *m, const char *path, int off)
{
    FILE *f = fopen(path, "w");
    if (!f) return -1;
    int ok = !off || fprintf(f, "OFF\n%zu %zu 0\n", m->nv, m->nt) > 0;
    for (const float *v = m->xyz; ok && v < m->xyz + 3 * m->nv; v += 3)
        ok = fprintf(f, "%s%.9g %.9g %.9g\n", off ? "" : "v ", v[0], v[1], v[2]) > 0;
    for (const uint32_t *t = m->tri; ok && t < m->tri + 3 * m->nt; t += 3) /* OBJ: 1-based */
        ok = fprintf(f, "%s %lu %lu %lu\n", off ? "3" : "f", (unsigned long)t[0] + !off,
                     (unsigned long)t[1] + !off, (unsigned long)t[2] + !off) > 0;
    return finish(f, ok);
}
int tmesh_write_off(const tmesh *m, const char *path) { return write_text(m, path, 1); }
int tmesh_write_obj(const tmesh *m, const char *path) { return write_text(m, path, 0); }
static void put_u32(unsigned char *b, uint32_t v)
{
    for (int k = 0; k < 4; k++) b[k] = (unsigned char)(v >> 8 * k);
}
static void put_f32(unsigned char *p, float f) { uint32_t u; memcpy(&u, &f, 4); put_u32(p, u); }
int tmesh_write_stl_binary(const tmesh *m, const char *path)
{
    FILE *f = fopen(path, "wb");
    if (!f) return -1;
    unsigned char head[84] = "clvox meshgen binary STL", rec[50] = {0};
    put_u32(head + 80, (uint32_t)m->nt);
    int ok = fwrite(head, 1, 84, f) == 84;
    for (size_t i = 0; ok && i < m->nt; i++) {
        double v[3][3], e1[3], e2[3], n[3];
        tri_get(m, i, v);
        sub3(v[1], v[0], e1); sub3(v[2], v[0], e2); cross3(e1, e2, n);
        double len = sqrt(dot3(n, n));
        for (int k = 0; k < 3; k++) {
            put_f32(rec + 4 * k, len > 0 ? (float)(n[k] / len) : 0.0f);
            for (int j = 0; j < 3; j++) put_f32(rec + 12 + 12 * k + 4 * j, (float)v[k][j]);
        }
        ok = fwrite(rec, 1, 50, f) == 50;
    }
    return finish(f, ok);
}
int tmesh_write_ply_binary(const tmesh *m, const char *path)
{
    FILE *f = fopen(path, "wb");
    if (!f) return -1;
    int ok = fprintf(f, "ply\nformat binary_little_endian 1.0\ncomment clvox meshgen\n"
                        "element vertex %zu\nproperty float x\nproperty float y\nproperty float z\n"
                        "element face %zu\nproperty list uchar int vertex_indices\nend_header\n",
                     m->nv, m->nt) > 0;
    unsigned char rec[13];
    for (size_t i = 0; ok && i < m->nv; i++) {
        for (int k = 0; k < 3; k++) put_f32(rec + 4 * k, m->xyz[3 * i + k]);
        ok = fwrite(rec, 1, 12, f) == 12;
    }
    rec[0] = 3;
    for (size_t i = 0; ok && i < m->nt; i++) {
        for (int k = 0; k < 3; k++) put_u32(rec + 1 + 4 * k, m->tri[3 * i + k]);
        ok = fwrite(rec, 1, 13, f) == 13;
    }
    return finish(f, ok);
}

/* ---- exact solids ---- */
static double lerp_n(double lo, double hi, unsigned i, unsigned n)
{
    return i == 0 ? lo : i == n ? hi : lo + (hi - lo) * i / n;
}
tmesh tmesh_box_subdivided(double x0, double y0, double z0, double x1, double y1, double z1, unsigned n)
{
    tmesh m = {0};
    if (n < 1) n = 1;
    size_t s = n + 1;
    uint32_t *id = malloc(s * s * s * sizeof *id); /* lattice point -> vertex */
    if (!id) abort();
    memset(id, 0xff, s * s * s * sizeof *id);
    for (unsigned a = 0; a < 3; a++)
        for (unsigned side = 0; side < 2; side++)
            for (unsigned p = 0; p < n; p++)
                for (unsigned q = 0; q < n; q++) {
                    uint32_t v[4];
                    for (int c = 0; c < 4; c++) {
                        unsigned g[3];
                        g[a] = side * n; g[(a + 1) % 3] = p + (c == 1 || c == 2); g[(a + 2) % 3] = q + c / 2;
                        uint32_t *slot = &id[(g[0] * s + g[1]) * s + g[2]];
                        if (*slot == UINT32_MAX)
                            *slot = tmesh_add_vertex(&m, lerp_n(x0, x1, g[0], n), lerp_n(y0, y1, g[1], n),
                                                     lerp_n(z0, z1, g[2], n));
                        v[c] = *slot;
                    }
                    /* p, q step along e_{a+1}, e_{a+2}: v0..v3 is CCW around +e_a */
                    if (side) add_quad(&m, v[0], v[1], v[2], v[3]);
                    else add_quad(&m, v[0], v[3], v[2], v[1]);
                }
    free(id);
    return m;
}
tmesh tmesh_box(double x0, double y0, double z0, double x1, double y1, double z1)
{
    return tmesh_box_subdivided(x0, y0, z0, x1, y1, z1, 1);
}
tmesh tmesh_tetra(const double a[3], const double b[3], const double c[3], const double d[3])
{
    tmesh m = {0};
    double e1[3], e2[3], e3[3], n[3];
    sub3(b, a, e1); sub3(c, a, e2); sub3(d, a, e3); cross3(e1, e2, n);
    const double *p[4] = {a, b, c, d};
    if (dot3(n, e3) < 0) { p[1] = c; p[2] = b; }
    for (int i = 0; i < 4; i++) tmesh_add_vertex(&m, p[i][0], p[i][1], p[i][2]);
    tmesh_add_tri(&m, 0, 2, 1); tmesh_add_tri(&m, 0, 1, 3);
    tmesh_add_tri(&m, 0, 3, 2); tmesh_add_tri(&m, 1, 2, 3);
    return m;
}
tmesh tmesh_octahedron(double cx, double cy, double cz, double r)
{
    tmesh m = {0};
    for (int a = 0; a < 6; a++) { /* 0:+x 1:-x 2:+y 3:-y 4:+z 5:-z */
        double p[3] = {cx, cy, cz};
        p[a / 2] += a & 1 ? -r : r;
        tmesh_add_vertex(&m, p[0], p[1], p[2]);
    }
    for (uint32_t o = 0; o < 8; o++) {
        uint32_t x = o & 1, y = 2 + (o >> 1 & 1), z = 4 + (o >> 2 & 1);
        if ((x + y + z) & 1) tmesh_add_tri(&m, x, z, y); /* odd number of negative axes */
        else tmesh_add_tri(&m, x, y, z);
    }
    return m;
}
tmesh tmesh_sphere(double cx, double cy, double cz, double r, unsigned n)
{
    tmesh m = {0};
    if (n < 2) n = 2;
    unsigned seg = 2 * n;
    tmesh_add_vertex(&m, cx, cy, cz + r);
    for (unsigned j = 1; j < n; j++)
        for (unsigned i = 0; i < seg; i++) {
            double th = PI * j / n, ph = 2 * PI * i / seg;
            tmesh_add_vertex(&m, cx + r * sin(th) * cos(ph), cy + r * sin(th) * sin(ph), cz + r * cos(th));
        }
    uint32_t south = tmesh_add_vertex(&m, cx, cy, cz - r);
#define RING(j, i) ((uint32_t)(1 + ((j) - 1) * seg + (i) % seg))
    for (unsigned i = 0; i < seg; i++) {
        tmesh_add_tri(&m, 0, RING(1, i), RING(1, i + 1));
        for (unsigned j = 1; j + 1 < n; j++)
            add_quad(&m, RING(j, i), RING(j + 1, i), RING(j + 1, i + 1), RING(j, i + 1));
        tmesh_add_tri(&m, south, RING(n - 1, i + 1), RING(n - 1, i));
    }
#undef RING
    return m;
}
double tmesh_sphere_volume(double r) { return 4.0 / 3.0 * PI * r * r * r; }
double tmesh_sphere_poly_volume(double r, unsigned n)
{
    if (n < 2) n = 2;
    double sum = 0, k = n * sin(PI / n); /* area of a regular 2n-gon = k rho^2 */
    for (unsigned j = 0; j < n; j++) {  /* frustum of band j */
        double r0 = r * sin(PI * j / n), r1 = r * sin(PI * (j + 1) / n);
        double h = r * (cos(PI * j / n) - cos(PI * (j + 1) / n));
        sum += h / 3 * k * (r0 * r0 + r1 * r1 + r0 * r1);
    }
    return sum;
}
tmesh tmesh_torus(double cx, double cy, double cz, double R, double r, unsigned nu, unsigned nv)
{
    tmesh m = {0};
    nu = nu < 3 ? 3 : nu; nv = nv < 3 ? 3 : nv;
    for (unsigned i = 0; i < nu; i++)
        for (unsigned j = 0; j < nv; j++) {
            double u = 2 * PI * i / nu, v = 2 * PI * j / nv, rho = R + r * cos(v);
            tmesh_add_vertex(&m, cx + rho * cos(u), cy + rho * sin(u), cz + r * sin(v));
        }
#define TV(i, j) ((uint32_t)(((i) % nu) * nv + (j) % nv))
    for (unsigned i = 0; i < nu; i++)
        for (unsigned j = 0; j < nv; j++)
            add_quad(&m, TV(i, j), TV(i + 1, j), TV(i + 1, j + 1), TV(i, j + 1));
#undef TV
    return m;
}
double tmesh_torus_volume(double R, double r) { return 2 * PI * PI * R * r * r; }
double tmesh_torus_poly_volume(double R, double r, unsigned nu, unsigned nv)
{
    return nu * sin(2 * PI / nu) * 0.5 * nv * sin(2 * PI / nv) * R * r * r;
}
tmesh tmesh_hollow_sphere(double cx, double cy, double cz, double r_out, double r_in, unsigned n)
{
    tmesh m = tmesh_sphere(cx, cy, cz, r_out, n), in = tmesh_sphere(cx, cy, cz, r_in, n);
    tmesh_flip(&in);
    tmesh_append(&m, &in);
    tmesh_free(&in);
    return m;
}

/* ---- random meshes ---- */
uint64_t tmesh_rng_next(uint64_t *state)
{
    uint64_t z = (*state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}
double tmesh_rng_uniform(uint64_t *state) { return (double)(tmesh_rng_next(state) >> 11) * 0x1p-53; }
static double urange(uint64_t *s, double lo, double hi) { return lo + (hi - lo) * tmesh_rng_uniform(s); }
/* Uniform point of the unit ball, norm^2 >= min2 (rejection): *n2 = norm^2. */
static void in_ball(uint64_t *s, double *v, int dim, double min2, double *n2)
{
    do {
        *n2 = 0;
        for (int k = 0; k < dim; k++) { v[k] = urange(s, -1, 1); *n2 += v[k] * v[k]; }
    } while (*n2 > 1 || *n2 < min2);
}

/* Star-shaped shell around c: radially projected subdivided cube, vertex radii
 * in [rmin,rmax], random rotation (uniform quaternion, sqrt only, no trig). */
static void add_star_shell(tmesh *dst, uint64_t *s, const double c[3], double rmin, double rmax, unsigned n)
{
    tmesh sh = tmesh_box_subdivided(-1, -1, -1, 1, 1, 1, n);
    double q[4], qq;
    in_ball(s, q, 4, 1e-3, &qq);
    double w = q[0], x = q[1], y = q[2], z = q[3], k = 2 / qq;
    double rot[3][3] = {{1 - k * (y * y + z * z), k * (x * y - w * z), k * (x * z + w * y)},
                        {k * (x * y + w * z), 1 - k * (x * x + z * z), k * (y * z - w * x)},
                        {k * (x * z - w * y), k * (y * z + w * x), 1 - k * (x * x + y * y)}};
    for (size_t i = 0; i < sh.nv; i++) {
        double v[3];
        vget(&sh, i, v);
        double f = urange(s, rmin, rmax) / sqrt(dot3(v, v));
        for (int a = 0; a < 3; a++) sh.xyz[3 * i + a] = (float)(c[a] + f * dot3(rot[a], v));
    }
    tmesh_append(dst, &sh);
    tmesh_free(&sh);
}
tmesh tmesh_random_closed(uint64_t seed, unsigned shells, unsigned n)
{
    tmesh m = {0};
    uint64_t s = seed;
    unsigned k = 1;
    if (shells < 1) shells = 1;
    while (k * k * k < shells) k++;
    double cell = 1.0 / k; /* radius <= 0.40 cell, jitter <= 0.08 cell: stays in its cell */
    for (unsigned i = 0; i < shells; i++) {
        double c[3] = {(i % k + 0.5) * cell, (i / k % k + 0.5) * cell, (i / (k * k) + 0.5) * cell};
        for (int a = 0; a < 3; a++) c[a] += urange(&s, -0.08, 0.08) * cell;
        add_star_shell(&m, &s, c, 0.25 * cell, 0.40 * cell, n);
    }
    return m;
}
tmesh tmesh_random_overlap(uint64_t seed, unsigned n, double c1[3], double c2[3])
{
    tmesh m = {0};
    uint64_t s = seed;
    double d[3], dd;
    in_ball(&s, d, 3, 1e-2, &dd);
    for (int a = 0; a < 3; a++) {
        c1[a] = 0.5 + urange(&s, -0.02, 0.02) - 0.15 * d[a] / sqrt(dd);
        c2[a] = c1[a] + 0.3 * d[a] / sqrt(dd);
    }
    add_star_shell(&m, &s, c1, 0.25, 0.3, n);
    add_star_shell(&m, &s, c2, 0.25, 0.3, n);
    return m;
}

/* ---- broken meshes ---- */
tmesh tmesh_copy(const tmesh *m)
{
    tmesh c = {0};
    tmesh_append(&c, m);
    return c;
}
tmesh tmesh_soup(const tmesh *m)
{
    tmesh s = {0};
    for (size_t t = 0; t < m->nt; t++) {
        uint32_t v[3];
        for (int k = 0; k < 3; k++) {
            const float *p = m->xyz + 3 * (size_t)m->tri[3 * t + k];
            v[k] = tmesh_add_vertex(&s, p[0], p[1], p[2]);
        }
        tmesh_add_tri(&s, v[0], v[1], v[2]);
    }
    return s;
}
void tmesh_flip_tri(tmesh *m, size_t t)
{
    uint32_t *p = m->tri + 3 * t, s = p[1];
    p[1] = p[2];
    p[2] = s;
}
void tmesh_edge_stats(const tmesh *m, uint64_t *boundary, uint64_t *nonmanifold, uint64_t *conflicts)
{
    size_t ne = 3 * m->nt;
    uint64_t *e = malloc((ne ? ne : 1) * sizeof *e), *u = malloc((ne ? ne : 1) * sizeof *u);
    if (!e || !u) abort();
    for (size_t i = 0; i < ne; i++) {
        uint32_t a = m->tri[i], b = m->tri[i - i % 3 + (i + 1) % 3];
        e[i] = (uint64_t)a << 32 | b;
        u[i] = a < b ? e[i] : (uint64_t)b << 32 | a;
    }
    qsort(e, ne, sizeof *e, cmp_u64);
    qsort(u, ne, sizeof *u, cmp_u64);
    *boundary = *nonmanifold = *conflicts = 0;
    for (size_t i = 1; i < ne; i++) *conflicts += e[i] == e[i - 1];
    for (size_t i = 0; i < ne;) {
        size_t j = i;
        while (j < ne && u[j] == u[i]) j++;
        *boundary += j - i == 1;
        *nonmanifold += j - i > 2;
        i = j;
    }
    free(e);
    free(u);
}
/* k distinct triangle indices below nt (partial Fisher-Yates), in order of drawing. */
static size_t *pick_distinct(uint64_t *s, size_t nt, size_t k)
{
    size_t *idx = malloc((nt ? nt : 1) * sizeof *idx);
    if (!idx) abort();
    for (size_t i = 0; i < nt; i++) idx[i] = i;
    for (size_t i = 0; i < k && i < nt; i++) {
        size_t j = i + (size_t)(tmesh_rng_next(s) % (nt - i)), t = idx[i];
        idx[i] = idx[j];
        idx[j] = t;
    }
    return idx;
}
/* The triangles of m for which keep[t] is set (all vertices kept). */
static tmesh filter_tris(const tmesh *m, const unsigned char *keep)
{
    tmesh o = {0};
    for (size_t i = 0; i < m->nv; i++) tmesh_add_vertex(&o, m->xyz[3 * i], m->xyz[3 * i + 1], m->xyz[3 * i + 2]);
    for (size_t t = 0; t < m->nt; t++)
        if (keep[t]) tmesh_add_tri(&o, m->tri[3 * t], m->tri[3 * t + 1], m->tri[3 * t + 2]);
    return o;
}
tmesh tmesh_open_box(uint64_t seed, const double lo[3], const double hi[3], unsigned n, unsigned removed,
                     unsigned *mask)
{
    if (n < 1) n = 1;
    if (removed < 1) removed = 1;
    if (removed > 5) removed = 5;
    tmesh box = tmesh_box_subdivided(lo[0], lo[1], lo[2], hi[0], hi[1], hi[2], n);
    uint64_t s = seed;
    size_t *faces = pick_distinct(&s, 6, removed);
    unsigned bits = 0;
    for (unsigned i = 0; i < removed; i++) bits |= 1u << faces[i];
    free(faces);
    unsigned char *keep = malloc(box.nt);
    if (!keep) abort();
    for (size_t t = 0; t < box.nt; t++) keep[t] = !(bits >> (t / (2 * (size_t)n * n)) & 1);
    tmesh o = filter_tris(&box, keep);
    free(keep);
    tmesh_free(&box);
    if (mask) *mask = bits;
    return o;
}
tmesh tmesh_open_hemisphere(double cx, double cy, double cz, double r, unsigned n)
{
    if (n < 2) n = 2;
    n += n & 1;
    tmesh sp = tmesh_sphere(cx, cy, cz, r, n);
    unsigned char *keep = malloc(sp.nt);
    if (!keep) abort();
    for (size_t t = 0; t < sp.nt; t++) {
        double z = 0;
        for (int k = 0; k < 3; k++) z += sp.xyz[3 * (size_t)sp.tri[3 * t + k] + 2];
        keep[t] = z / 3 > cz;
    }
    tmesh o = filter_tris(&sp, keep);
    free(keep);
    tmesh_free(&sp);
    return o;
}
/* Adds a vertex given in the cylinder's local frame (u, v across, t along axis). */
static uint32_t add_local(tmesh *m, const double c[3], int axis, double u, double v, double t)
{
    double p[3];
    p[axis] = c[axis] + t;
    p[(axis + 1) % 3] = c[(axis + 1) % 3] + u; /* cyclic: keeps the orientation */
    p[(axis + 2) % 3] = c[(axis + 2) % 3] + v;
    return tmesh_add_vertex(m, p[0], p[1], p[2]);
}
tmesh tmesh_cylinder(const double c[3], int axis, double r, double h, unsigned seg, unsigned rows, int caps)
{
    tmesh m = {0};
    if (seg < 3) seg = 3;
    if (rows < 1) rows = 1;
    for (unsigned j = 0; j <= rows; j++)
        for (unsigned i = 0; i < seg; i++) {
            double ph = 2 * PI * i / seg;
            add_local(&m, c, axis, r * cos(ph), r * sin(ph), lerp_n(0, h, j, rows));
        }
#define CV(j, i) ((uint32_t)((j) * seg + (i) % seg))
    for (unsigned j = 0; j < rows; j++)
        for (unsigned i = 0; i < seg; i++) add_quad(&m, CV(j, i), CV(j, i + 1), CV(j + 1, i + 1), CV(j + 1, i));
    if (caps) {
        uint32_t bot = add_local(&m, c, axis, 0, 0, 0), top = add_local(&m, c, axis, 0, 0, h);
        for (unsigned i = 0; i < seg; i++) {
            tmesh_add_tri(&m, bot, CV(0, i + 1), CV(0, i));
            tmesh_add_tri(&m, top, CV(rows, i), CV(rows, i + 1));
        }
    }
#undef CV
    return m;
}
tmesh tmesh_sphere_holes(uint64_t seed, double cx, double cy, double cz, double r, unsigned n, unsigned k)
{
    tmesh sp = tmesh_sphere(cx, cy, cz, r, n);
    uint64_t s = seed;
    size_t *idx = pick_distinct(&s, sp.nt, k);
    unsigned char *keep = malloc(sp.nt);
    if (!keep) abort();
    memset(keep, 1, sp.nt);
    for (size_t i = 0; i < k && i < sp.nt; i++) keep[idx[i]] = 0;
    tmesh o = filter_tris(&sp, keep);
    free(keep);
    free(idx);
    tmesh_free(&sp);
    return o;
}
tmesh tmesh_sphere_flipped(uint64_t seed, double cx, double cy, double cz, double r, unsigned n, unsigned k)
{
    tmesh sp = tmesh_sphere(cx, cy, cz, r, n);
    uint64_t s = seed;
    size_t *idx = pick_distinct(&s, sp.nt, k);
    for (size_t i = 0; i < k && i < sp.nt; i++) tmesh_flip_tri(&sp, idx[i]);
    free(idx);
    return sp;
}
tmesh tmesh_cracked_box(uint64_t seed, const double lo[3], const double hi[3], double shift)
{
    tmesh box = tmesh_box(lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]), o = {0};
    uint64_t s = seed;
    int seen[8] = {0};
    for (size_t t = 0; t < box.nt; t += 2) { /* one face: triangles t, t + 1 = quad a b c, a c d */
        const uint32_t *q = box.tri + 3 * t;
        uint32_t corner[4] = {q[0], q[1], q[2], q[5]}, v[4];
        for (int k = 0; k < 4; k++) {
            const float *p = box.xyz + 3 * (size_t)corner[k];
            double x[3] = {p[0], p[1], p[2]};
            if (seen[corner[k]]++ && (tmesh_rng_next(&s) >> 63))
                for (int a = 0; a < 3; a++) x[a] += (tmesh_rng_next(&s) >> 63) ? shift : -shift;
            v[k] = tmesh_add_vertex(&o, x[0], x[1], x[2]);
        }
        add_quad(&o, v[0], v[1], v[2], v[3]);
    }
    tmesh_free(&box);
    return o;
}
tmesh tmesh_cad_union(uint64_t seed)
{
    uint64_t s = seed;
    double j[12];
    for (int i = 0; i < 12; i++) j[i] = urange(&s, -0.01, 0.01);
    tmesh m = tmesh_box(0.12 + j[0], 0.21 + j[1], 0.17 + j[2], 0.61 + j[3], 0.58 + j[4], 0.49 + j[5]);
    tmesh b = tmesh_box(0.41 + j[6], 0.33 + j[7], 0.29 + j[8], 0.87 + j[9], 0.79 + j[10], 0.83 + j[11]);
    double cz[3] = {0.30 + j[1], 0.62 + j[2], 0.13 + j[3]}, cx[3] = {0.09 + j[4], 0.42 + j[5], 0.62 + j[6]};
    tmesh c1 = tmesh_cylinder(cz, 2, 0.17, 0.58, 40, 3, 1); /* along z, meets the first box */
    tmesh c2 = tmesh_cylinder(cx, 0, 0.14, 0.84, 36, 5, 1); /* along x, through both boxes */
    tmesh_append(&m, &b);
    tmesh_append(&m, &c1);
    tmesh_append(&m, &c2);
    tmesh_free(&b);
    tmesh_free(&c1);
    tmesh_free(&c2);
    return m;
}
tmesh tmesh_shifted_shells(double cx, double cy, double cz, double r, unsigned n, double d)
{
    double u[3] = {1, 0.37, 0.21}, l = sqrt(dot3(u, u));
    tmesh m = tmesh_sphere(cx, cy, cz, r, n), b = tmesh_sphere(cx + d * u[0] / l, cy + d * u[1] / l, cz + d * u[2] / l, r, n);
    tmesh_append(&m, &b);
    tmesh_free(&b);
    return m;
}
tmesh tmesh_moebius(double cx, double cy, double cz, double R, double hw, unsigned nu, unsigned nv)
{
    tmesh m = {0};
    if (nu < 3) nu = 3;
    if (nv < 1) nv = 1;
    for (unsigned i = 0; i < nu; i++)
        for (unsigned k = 0; k <= nv; k++) {
            double u = 2 * PI * i / nu, v = lerp_n(-hw, hw, k, nv), rho = R + v * cos(u / 2);
            tmesh_add_vertex(&m, cx + rho * cos(u), cy + rho * sin(u), cz + v * sin(u / 2));
        }
    /* (nu, k) is (0, nv - k): the half twist */
#define MV(i, k) ((uint32_t)((i) < nu ? (i) * (nv + 1) + (k) : nv - (k)))
    for (unsigned i = 0; i < nu; i++)
        for (unsigned k = 0; k < nv; k++) add_quad(&m, MV(i, k), MV(i + 1, k), MV(i + 1, k + 1), MV(i, k + 1));
#undef MV
    return m;
}
tmesh tmesh_nested_boxes(double cx, double cy, double cz, const double s[3], unsigned flags)
{
    static const double stretch[3] = {1.0, 0.83, 0.71};
    tmesh m = {0};
    for (int b = 0; b < 3; b++) {
        double e[3];
        for (int a = 0; a < 3; a++) e[a] = s[b] * stretch[a];
        tmesh one = tmesh_box(cx - e[0], cy - e[1], cz - e[2], cx + e[0], cy + e[1], cz + e[2]);
        if ((b == 1 && !(flags & 1)) || (b == 2 && (flags & 2))) tmesh_flip(&one);
        tmesh_append(&m, &one);
        tmesh_free(&one);
    }
    return m;
}
tmesh tmesh_sphere_membrane(double cx, double cy, double cz, double r, unsigned n)
{
    if (n < 2) n = 2;
    n += n & 1;
    tmesh m = tmesh_sphere(cx, cy, cz, r, n);
    unsigned seg = 2 * n;
    uint32_t eq = 1 + (n / 2 - 1) * seg; /* first vertex of the equator ring (tmesh_sphere's RING) */
    uint32_t centre = tmesh_add_vertex(&m, cx, cy, cz), inner = (uint32_t)m.nv;
    for (unsigned i = 0; i < seg; i++) {
        double ph = 2 * PI * i / seg;
        tmesh_add_vertex(&m, cx + 0.5 * r * cos(ph), cy + 0.5 * r * sin(ph), cz);
    }
    for (unsigned i = 0; i < seg; i++) {
        uint32_t i1 = (i + 1) % seg;
        tmesh_add_tri(&m, centre, inner + i, inner + i1); /* +z */
        add_quad(&m, inner + i, eq + i, eq + i1, inner + i1);
    }
    return m;
}

/* ---- the winding corpus ---- */
static const tmesh none;
static void add_case(tmesh_case *out, size_t max, size_t *n, const char *name, tmesh mesh, int truth_is_mesh,
                     tmesh truth)
{
    if (*n == max) abort();
    tmesh_case *c = &out[(*n)++];
    c->name = name;
    c->mesh = mesh;
    c->truth = truth_is_mesh ? tmesh_copy(&mesh) : truth;
}
void tmesh_case_free(tmesh_case *c)
{
    tmesh_free(&c->mesh);
    tmesh_free(&c->truth);
}
size_t tmesh_winding_corpus(tmesh_case *out, size_t max)
{
    size_t n = 0;
    double lo[3] = {0.13, 0.17, 0.11}, hi[3] = {0.86, 0.79, 0.91};
    add_case(out, max, &n, "open box (1 face)", tmesh_open_box(1, lo, hi, 3, 1, NULL), 1, none);
    add_case(out, max, &n, "open box (2 faces)", tmesh_open_box(4, lo, hi, 2, 2, NULL), 1, none);
    add_case(out, max, &n, "open box (3 faces)", tmesh_open_box(2, lo, hi, 2, 3, NULL), 1, none);
    add_case(out, max, &n, "open hemisphere", tmesh_open_hemisphere(0.51, 0.49, 0.47, 0.4, 16), 1, none);
    double cc[3] = {0.5, 0.48, 0.12};
    add_case(out, max, &n, "cylinder without caps", tmesh_cylinder(cc, 2, 0.35, 0.75, 32, 4, 0), 1, none);
    add_case(out, max, &n, "sphere with holes", tmesh_sphere_holes(3, 0.5, 0.49, 0.52, 0.4, 16, 12), 1, none);
    add_case(out, max, &n, "sphere, 20 faces flipped", tmesh_sphere_flipped(5, 0.5, 0.49, 0.52, 0.4, 16, 20), 0,
             tmesh_sphere(0.5, 0.49, 0.52, 0.4, 16));
    tmesh inv = tmesh_sphere(0.49, 0.52, 0.5, 0.41, 16);
    tmesh_flip(&inv);
    add_case(out, max, &n, "inverted sphere", inv, 0, tmesh_sphere(0.49, 0.52, 0.5, 0.41, 16));
    add_case(out, max, &n, "cracked box", tmesh_cracked_box(7, lo, hi, 1e-5), 1, none);
    add_case(out, max, &n, "cad union", tmesh_cad_union(11), 1, none);
    add_case(out, max, &n, "shifted shells", tmesh_shifted_shells(0.45, 0.47, 0.49, 0.3, 16, 0.12), 1, none);
    tmesh sp = tmesh_sphere(0.5, 0.49, 0.52, 0.4, 12);
    add_case(out, max, &n, "triangle soup", tmesh_soup(&sp), 1, none);
    tmesh_free(&sp);
    add_case(out, max, &n, "moebius strip", tmesh_moebius(0.5, 0.5, 0.5, 0.3, 0.12, 64, 4), 0, none);
    double s[3] = {0.41, 0.27, 0.13};
    add_case(out, max, &n, "nested boxes", tmesh_nested_boxes(0.5, 0.5, 0.5, s, 0), 1, none);
    add_case(out, max, &n, "nested boxes, middle outwards", tmesh_nested_boxes(0.5, 0.5, 0.5, s, 1), 0,
             tmesh_nested_boxes(0.5, 0.5, 0.5, s, 0));
    add_case(out, max, &n, "nested boxes, inner inwards", tmesh_nested_boxes(0.5, 0.5, 0.5, s, 3), 0,
             tmesh_nested_boxes(0.5, 0.5, 0.5, s, 0));
    add_case(out, max, &n, "sphere with membrane", tmesh_sphere_membrane(0.5, 0.49, 0.52, 0.4, 16), 1, none);
    tmesh hs = tmesh_sphere(0.49, 0.5, 0.51, 0.42, 14), hin = tmesh_sphere(0.49, 0.5, 0.51, 0.23, 14);
    tmesh_append(&hs, &hin); /* inner shell stored outwards */
    tmesh_free(&hin);
    add_case(out, max, &n, "hollow sphere, inner outwards", hs, 0, tmesh_hollow_sphere(0.49, 0.5, 0.51, 0.42, 0.23, 14));
    return n;
}

size_t tmesh_components_of(const float *xyz, size_t nv, const uint32_t *tri, size_t nt, uint32_t *label)
{
    uint32_t *parent = malloc((nv ? nv : 1) * sizeof *parent), *rep = malloc((nv ? nv : 1) * sizeof *rep);
    if (!parent || !rep) abort();
    for (size_t i = 0; i < nv; i++) parent[i] = (uint32_t)i;
    /* exact merge: open addressing on the coordinates' bits */
    size_t hn = 1;
    while (hn < 2 * nv) hn <<= 1;
    uint32_t *head = malloc(hn * sizeof *head);
    if (!head) abort();
    memset(head, 0xff, hn * sizeof *head);
    for (size_t i = 0; i < nv; i++) {
        uint32_t b[3];
        memcpy(b, xyz + 3 * i, sizeof b);
        size_t h = ((b[0] * 73856093u) ^ (b[1] * 19349663u) ^ (b[2] * 83492791u)) & (hn - 1);
        while (head[h] != UINT32_MAX && memcmp(xyz + 3 * (size_t)head[h], xyz + 3 * i, 3 * sizeof(float)) != 0)
            h = (h + 1) & (hn - 1);
        if (head[h] == UINT32_MAX) head[h] = (uint32_t)i;
        rep[i] = head[h];
    }
    free(head);
#define FIND(x) do { while (parent[x] != x) x = parent[x] = parent[parent[x]]; } while (0)
    for (size_t t = 0; t < nt; t++) {
        uint32_t a = rep[tri[3 * t]];
        FIND(a);
        for (int k = 1; k < 3; k++) {
            uint32_t b = rep[tri[3 * t + k]];
            FIND(b);
            if (a != b) parent[b] = a;
        }
    }
    size_t n = 0;
    uint32_t *id = malloc((nv ? nv : 1) * sizeof *id);
    if (!id) abort();
    memset(id, 0xff, (nv ? nv : 1) * sizeof *id);
    for (size_t t = 0; t < nt; t++) {
        uint32_t a = rep[tri[3 * t]];
        FIND(a);
        if (id[a] == UINT32_MAX) id[a] = (uint32_t)n++;
        label[t] = id[a];
    }
#undef FIND
    free(id);
    free(parent);
    free(rep);
    return n;
}

/* ---- oracles ---- */
uint64_t expected_box_voxels(const clvox_grid *g, const double lo[3], const double hi[3])
{
    uint64_t count = 1;
    for (int a = 0; a < 3; a++) {
        double h = g->voxel_size[a], d = g->dims[a];
        double glo = (float)(((double)(float)lo[a] - g->origin[a]) / h - 0.5);
        double ghi = (float)(((double)(float)hi[a] - g->origin[a]) / h - 0.5);
        double i0 = fmin(fmax(ceil(glo), 0), d), i1 = fmin(fmax(ceil(ghi), 0), d); /* i0 <= i < i1 */
        count *= i1 > i0 ? (uint64_t)(i1 - i0) : 0;
    }
    return count;
}
static int ray_parity(const tmesh *m, const double p[3], const double d[3])
{
    int odd = 0;
    for (size_t i = 0; i < m->nt; i++) { /* Moller-Trumbore */
        double v[3][3], e1[3], e2[3], pv[3], tv[3], qv[3];
        tri_get(m, i, v);
        sub3(v[1], v[0], e1); sub3(v[2], v[0], e2); cross3(d, e2, pv);
        double det = dot3(e1, pv);
        if (det == 0) continue;
        sub3(p, v[0], tv);
        double u = dot3(tv, pv) / det;
        if (u < 0 || u > 1) continue;
        cross3(tv, e1, qv);
        double w = dot3(d, qv) / det;
        if (w < 0 || u + w > 1) continue;
        odd ^= dot3(e2, qv) / det > 0;
    }
    return odd;
}
int tmesh_point_inside(const tmesh *m, const double p[3])
{
    static const double dir[3][3] = {
        {1, 0.0123456789, 0.00731059}, {1, -0.0089123457, 0.0161803399}, {1, 0.0141421356, -0.0113137085}};
    return ray_parity(m, p, dir[0]) + ray_parity(m, p, dir[1]) + ray_parity(m, p, dir[2]) >= 2;
}
