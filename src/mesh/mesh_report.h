/* SPDX-License-Identifier: Apache-2.0 */
/* What the two implementations of the mesh report (mesh_report.c: the
 * default, on the host threads; mesh_report_serial.c: one thread) share:
 * the hashes and the duplicate key of a triangle, inline since they run per
 * vertex or per triangle. Internal. */
#ifndef CLVOX_MESH_REPORT_H
#define CLVOX_MESH_REPORT_H
#include "mesh_internal.h"

#include <string.h>

/* 64-bit finaliser (MurmurHash3 fmix64): the slot comes from the low bits,
 * a 32-bit tag from the high bits. */
static inline uint64_t mix64(uint64_t h)
{
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ull;
    h ^= h >> 33;
    return h;
}

static inline uint64_t hash3(uint32_t a, uint32_t b, uint32_t c)
{
    return mix64(((uint64_t)a << 32 | b) * 0x9e3779b97f4a7c15ull ^ (uint64_t)c * 0xbf58476d1ce4e5b9ull);
}

static inline uint32_t float_key(float f)
{
    uint32_t u;
    if (f == 0.0f) f = 0.0f; /* -0 and +0 are the same position */
    memcpy(&u, &f, sizeof u);
    return u;
}

/* Lexicographic order of two vertex positions (as float_key triples). */
static inline int pos_less(const uint32_t *a, const uint32_t *b)
{
    if (a[0] != b[0]) return a[0] < b[0];
    if (a[1] != b[1]) return a[1] < b[1];
    return a[2] < b[2];
}

/* The corner positions of triangle t, sorted: the duplicate key. */
static inline void sorted_corners(const float *xyz, const uint32_t *tris, size_t t, uint32_t k[3][3])
{
    for (int c = 0; c < 3; c++)
        for (int a = 0; a < 3; a++) k[c][a] = float_key(xyz[3 * (size_t)tris[3 * t + c] + a]);
    uint32_t s[3];
#define SWAP_IF(i, j) \
    if (pos_less(k[j], k[i])) memcpy(s, k[i], sizeof s), memcpy(k[i], k[j], sizeof s), memcpy(k[j], s, sizeof s)
    SWAP_IF(0, 1);
    SWAP_IF(1, 2);
    SWAP_IF(0, 1);
#undef SWAP_IF
}

/* The one-thread implementation (mesh_report_serial.c): the report's box,
 * degenerate triangles, enclosed volume (*vol6: the signed sum), boundary
 * edges, non-manifold and duplicate triangles. Returns -1 when memory runs
 * out. */
int clvox__mesh_analyze_serial(const float *xyz, size_t nv, const uint32_t *tris, size_t nt, clvox_mesh_report *r,
                               double *vol6);
#endif
