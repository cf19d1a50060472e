/* SPDX-License-Identifier: Apache-2.0 */
/*
 * subdivide — benchmark helper: makes large closed meshes from small ones.
 *
 *   subdivide IN.off K OUT.ply [--soup REL [SEED]]
 *
 * Reads an OFF mesh (polygons are fan-triangulated), applies K rounds of
 * 1->4 midpoint subdivision (each triangle is split at its edge midpoints;
 * a midpoint is shared by the two triangles of its edge, so a closed mesh
 * stays closed and the shape does not change) and writes a binary
 * little-endian PLY: "vertex" float x,y,z; "face" list uchar int
 * vertex_indices. Each round multiplies the triangle count by 4.
 *
 * --soup REL: then turns the mesh into a triangle soup, as an STL or a
 * mesh saved per face gives: every triangle gets three vertices of its own
 * (none shared), each coordinate moved by a uniform offset in
 * [-REL, REL] x the bounding box's largest side (in double, then rounded
 * to float), from a splitmix64 stream seeded by SEED (default 1), so the
 * same arguments give the same bytes. REL 0 gives the soup unjittered
 * (vertices at equal positions, which clvox's winding preparation merges).
 * scripts/bench/bench_winding_soup.sh uses it (issue 35).
 *
 * Built by `make bench-tools` (build/release/bench/subdivide), which the
 * scripts in scripts/bench/ run.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void die(const char *msg, const char *arg)
{
    fprintf(stderr, "subdivide: %s%s%s\n", msg, arg ? ": " : "", arg ? arg : "");
    exit(1);
}

static void *xrealloc(void *p, size_t n)
{
    void *q = realloc(p, n ? n : 1);
    if (!q) die("out of memory", NULL);
    return q;
}

/* Next whitespace-separated token of an OFF file, skipping # comments. */
static int next_token(FILE *f, char *buf, size_t cap)
{
    int c;
    size_t n = 0;
    for (;;) {
        c = getc(f);
        if (c == EOF) return 0;
        if (c == '#') {
            while (c != '\n' && c != EOF) c = getc(f);
            continue;
        }
        if (c != ' ' && c != '\t' && c != '\n' && c != '\r') break;
    }
    while (c != EOF && c != ' ' && c != '\t' && c != '\n' && c != '\r' && c != '#') {
        if (n + 1 < cap) buf[n++] = (char)c;
        c = getc(f);
    }
    if (c != EOF) ungetc(c, f); /* keep the line end for the caller */
    buf[n] = 0;
    return 1;
}

static long next_long(FILE *f, const char *what)
{
    char tok[64], *end;
    long v;
    if (!next_token(f, tok, sizeof tok)) die("unexpected end of file reading", what);
    v = strtol(tok, &end, 10);
    if (*end) die("bad integer for", what);
    return v;
}

typedef struct mesh {
    float *xyz;       /* 3 per vertex */
    uint32_t *tri;    /* 3 per triangle */
    size_t nv, nt;
} mesh;

static void read_off(const char *path, mesh *m)
{
    char tok[64], *end;
    long nv, nf, i, j;
    size_t cap = 0;
    FILE *f = fopen(path, "r");
    if (!f) die("cannot open", path);
    if (!next_token(f, tok, sizeof tok) || strcmp(tok, "OFF") != 0) die("not an OFF file", path);
    nv = next_long(f, "vertex count");
    nf = next_long(f, "face count");
    (void)next_long(f, "edge count");
    if (nv <= 0 || nf <= 0 || nv > 100000000L || nf > 100000000L) die("bad counts in", path);
    m->nv = (size_t)nv;
    m->xyz = xrealloc(NULL, (size_t)nv * 3 * sizeof(float));
    for (i = 0; i < nv * 3; i++) {
        if (!next_token(f, tok, sizeof tok)) die("truncated vertex list in", path);
        m->xyz[i] = strtof(tok, &end);
        if (*end) die("bad coordinate in", path);
    }
    m->nt = 0;
    m->tri = NULL;
    for (i = 0; i < nf; i++) {
        long n = next_long(f, "face size");
        long idx[3];
        if (n < 3 || n > 1000000L) die("bad face size in", path);
        for (j = 0; j < n; j++) {
            long v = next_long(f, "face index");
            if (v < 0 || v >= nv) die("face index out of range in", path);
            if (j < 2) {
                idx[j] = v;
                continue;
            }
            idx[2] = v; /* fan: (first, previous, current) */
            if (m->nt + 1 > cap) {
                cap = cap ? 2 * cap : (size_t)nf + 16;
                m->tri = xrealloc(m->tri, cap * 3 * sizeof(uint32_t));
            }
            m->tri[3 * m->nt + 0] = (uint32_t)idx[0];
            m->tri[3 * m->nt + 1] = (uint32_t)idx[1];
            m->tri[3 * m->nt + 2] = (uint32_t)idx[2];
            m->nt++;
            idx[1] = v;
        }
        /* rest of the line (colours) is ignored */
        {
            int c;
            while ((c = getc(f)) != '\n' && c != EOF) {
            }
        }
    }
    fclose(f);
}

/* Open-addressing map from an undirected edge to its midpoint vertex. */
typedef struct edge_map {
    uint64_t *keys; /* (min << 32 | max) + 1; 0 = empty */
    uint32_t *vals;
    size_t cap;
} edge_map;

static uint64_t hash64(uint64_t x)
{
    x ^= x >> 33;
    x *= 0xff51afd7ed558ccdULL;
    x ^= x >> 33;
    x *= 0xc4ceb9fe1a85ec53ULL;
    x ^= x >> 33;
    return x;
}

static uint32_t midpoint(edge_map *em, mesh *m, size_t *nv_cap, uint32_t a, uint32_t b)
{
    uint32_t lo = a < b ? a : b, hi = a < b ? b : a;
    uint64_t key = (((uint64_t)lo << 32) | hi) + 1;
    size_t i = (size_t)hash64(key) & (em->cap - 1);
    int k;
    while (em->keys[i]) {
        if (em->keys[i] == key) return em->vals[i];
        i = (i + 1) & (em->cap - 1);
    }
    if (m->nv + 1 > *nv_cap) {
        *nv_cap *= 2;
        m->xyz = xrealloc(m->xyz, *nv_cap * 3 * sizeof(float));
    }
    for (k = 0; k < 3; k++)
        m->xyz[3 * m->nv + k] = 0.5f * (m->xyz[3 * lo + k] + m->xyz[3 * hi + k]);
    em->keys[i] = key;
    em->vals[i] = (uint32_t)m->nv;
    return (uint32_t)m->nv++;
}

static void subdivide_once(mesh *m)
{
    edge_map em;
    size_t t, nv_cap = m->nv + 3 * m->nt / 2 + 16;
    uint32_t *out;
    if (m->nt > (size_t)UINT32_MAX / 16) die("mesh too large", NULL);
    em.cap = 1;
    while (em.cap < 3 * m->nt) em.cap <<= 1; /* load factor <= 1/2 for a closed mesh */
    em.keys = calloc(em.cap, sizeof(uint64_t));
    em.vals = malloc(em.cap * sizeof(uint32_t));
    out = malloc(m->nt * 4 * 3 * sizeof(uint32_t));
    if (!em.keys || !em.vals || !out) die("out of memory", NULL);
    m->xyz = xrealloc(m->xyz, nv_cap * 3 * sizeof(float));
    for (t = 0; t < m->nt; t++) {
        uint32_t a = m->tri[3 * t], b = m->tri[3 * t + 1], c = m->tri[3 * t + 2];
        uint32_t ab = midpoint(&em, m, &nv_cap, a, b);
        uint32_t bc = midpoint(&em, m, &nv_cap, b, c);
        uint32_t ca = midpoint(&em, m, &nv_cap, c, a);
        uint32_t *o = out + 12 * t;
        /* same orientation as the parent */
        o[0] = a;  o[1] = ab;  o[2] = ca;
        o[3] = ab; o[4] = b;   o[5] = bc;
        o[6] = ca; o[7] = bc;  o[8] = c;
        o[9] = ab; o[10] = bc; o[11] = ca;
    }
    free(em.keys);
    free(em.vals);
    free(m->tri);
    m->tri = out;
    m->nt *= 4;
}

static void put_le32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)v;
    p[1] = (unsigned char)(v >> 8);
    p[2] = (unsigned char)(v >> 16);
    p[3] = (unsigned char)(v >> 24);
}

static void write_ply(const char *path, const mesh *m)
{
    size_t i;
    char tmp[4096];
    FILE *f;
    if (snprintf(tmp, sizeof tmp, "%s.tmp", path) >= (int)sizeof tmp) die("path too long", path);
    f = fopen(tmp, "wb");
    if (!f) die("cannot write", tmp);
    fprintf(f,
            "ply\nformat binary_little_endian 1.0\ncomment made by clvox scripts/bench/subdivide.c\n"
            "element vertex %zu\nproperty float x\nproperty float y\nproperty float z\n"
            "element face %zu\nproperty list uchar int vertex_indices\nend_header\n",
            m->nv, m->nt);
    for (i = 0; i < m->nv; i++) {
        unsigned char rec[12];
        int k;
        for (k = 0; k < 3; k++) {
            uint32_t bits;
            memcpy(&bits, &m->xyz[3 * i + k], 4);
            put_le32(rec + 4 * k, bits);
        }
        fwrite(rec, 1, sizeof rec, f);
    }
    for (i = 0; i < m->nt; i++) {
        unsigned char rec[13];
        rec[0] = 3;
        put_le32(rec + 1, m->tri[3 * i]);
        put_le32(rec + 5, m->tri[3 * i + 1]);
        put_le32(rec + 9, m->tri[3 * i + 2]);
        fwrite(rec, 1, sizeof rec, f);
    }
    if (ferror(f) | fclose(f)) {
        remove(tmp);
        die("write failed", tmp);
    }
    if (rename(tmp, path) != 0) die("cannot rename to", path);
}

static uint64_t splitmix64(uint64_t *state)
{
    uint64_t z = (*state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

/* --soup: three vertices of its own per triangle, jittered (see the top). */
static void make_soup(mesh *m, double rel, uint64_t seed)
{
    double lo[3], hi[3], extent = 0;
    size_t i;
    int k;
    float *xyz;
    for (k = 0; k < 3; k++) lo[k] = hi[k] = m->xyz[k];
    for (i = 0; i < m->nv; i++)
        for (k = 0; k < 3; k++) {
            double v = m->xyz[3 * i + k];
            if (v < lo[k]) lo[k] = v;
            if (v > hi[k]) hi[k] = v;
        }
    for (k = 0; k < 3; k++)
        if (hi[k] - lo[k] > extent) extent = hi[k] - lo[k];
    if (m->nt > SIZE_MAX / 9 / sizeof(float) || m->nt * 3 > UINT32_MAX) die("mesh too large for a soup", NULL);
    xyz = xrealloc(NULL, m->nt * 9 * sizeof(float));
    for (i = 0; i < m->nt * 3; i++) {
        const float *v = m->xyz + 3 * (size_t)m->tri[i];
        for (k = 0; k < 3; k++) {
            double u = (double)(splitmix64(&seed) >> 11) * 0x1p-53; /* [0, 1) */
            xyz[3 * i + k] = (float)((double)v[k] + (2.0 * u - 1.0) * rel * extent);
        }
        m->tri[i] = (uint32_t)i;
    }
    free(m->xyz);
    m->xyz = xyz;
    m->nv = m->nt * 3;
}

int main(int argc, char **argv)
{
    mesh m;
    long k, r;
    char *end;
    double rel = -1;
    uint64_t seed = 1;
    if (argc < 4 || argc > 7 || (argc > 4 && strcmp(argv[4], "--soup") != 0) || argc == 5) {
        fprintf(stderr, "usage: subdivide IN.off K OUT.ply [--soup REL [SEED]]\n");
        return 2;
    }
    k = strtol(argv[2], &end, 10);
    if (*end || k < 0 || k > 8) die("K must be 0..8", argv[2]);
    if (argc > 5) {
        rel = strtod(argv[5], &end);
        if (*end || !(rel >= 0 && rel < 1)) die("REL must be in [0, 1)", argv[5]);
    }
    if (argc > 6) {
        seed = strtoull(argv[6], &end, 10);
        if (*end) die("bad SEED", argv[6]);
    }
    read_off(argv[1], &m);
    for (r = 0; r < k; r++) subdivide_once(&m);
    if (rel >= 0) make_soup(&m, rel, seed);
    write_ply(argv[3], &m);
    printf("%s: %zu vertices, %zu triangles\n", argv[3], m.nv, m.nt);
    free(m.xyz);
    free(m.tri);
    return 0;
}
