/* SPDX-License-Identifier: Apache-2.0 */
/* Native binary STL reader.
 *
 * OpenMesh 9.0's binary STL reader (what clvox used before) merges a corner
 * into an earlier vertex when a std::map with a tolerant comparison (CmpVec,
 * eps = FLT_MIN: |a - b| <= FLT_MIN per coordinate) finds one, adds vertices
 * in first-seen order and drops a facet whose three corners do not map to
 * three different vertices. For coordinates that are 0 or of magnitude
 * >= 2^-100, that comparison is exact equality with -0 == +0 (two different
 * such floats differ by at least 2^-123 > FLT_MIN, and b - FLT_MIN rounds to
 * b), so a hash on the bit patterns (-0 folded into +0) gives the same
 * vertices, in the same order, and the same triangles. A file with a tiny
 * non-zero coordinate (|x| < 2^-100) returns 1 and is read by OpenMesh. The
 * stored vertex is the first corner seen, as in OpenMesh (-0 stays -0).
 *
 * Memory: the mapped file, the vertex array (capacity 3 per facet, shrunk at
 * the end; untouched pages are never resident), the index array (3 per
 * facet, becomes the triangle array in place) and a hash table of 4-byte
 * vertex ids, at most half full. */
#include "mesh_internal.h"

#include <stdlib.h>
#include <string.h>

static uint32_t le32u(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static uint32_t key_bits(uint32_t u) { return (u & 0x7fffffffu) ? u : 0; } /* -0 -> +0 */

static uint64_t hash_key(uint32_t a, uint32_t b, uint32_t c)
{
    uint64_t h = (uint64_t)a * 0x9E3779B97F4A7C15ull ^ ((uint64_t)b * 0xC2B2AE3D27D4EB4Full + (uint64_t)c);
    h ^= (uint64_t)c * 0x165667B19E3779F9ull;
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
    return h;
}

/* |x| < 2^-100 and x != 0: OpenMesh's tolerance could merge it with a neighbour. */
static int tiny(uint32_t u)
{
    uint32_t m = u & 0x7fffffffu;
    return m && m < 0x0d800000u; /* 2^-100 = exponent field 27 */
}

int clvox__stl_read_binary(const unsigned char *p, size_t n, clvox__raw_mesh *raw)
{
    memset(raw, 0, sizeof *raw);
    if (n < 84) return 1;
    uint64_t count = le32u(p + 80);
    if (84 + 50 * count != n) return 1;
    size_t corners = (size_t)count * 3;
    float *xyz = malloc((corners ? corners : 1) * 3 * sizeof *xyz);
    uint32_t *idx = malloc((corners ? corners : 1) * sizeof *idx);
    size_t ts = 1024;
    while (ts < count) ts <<= 1; /* about 2 slots per expected vertex (V ~ T/2 for closed meshes) */
    uint32_t *slot = calloc(ts, sizeof *slot);
    if (!xyz || !idx || !slot) goto oom;
    size_t nv = 0, ni = 0, mask = ts - 1;
    enum { BLOCK = 32 }; /* facets whose slots are prefetched together */
    uint32_t key[BLOCK * 3][3], raw_bits[BLOCK * 3][3];
    uint64_t hash[BLOCK * 3];
    for (uint64_t t0 = 0; t0 < count; t0 += BLOCK) {
        size_t nb = count - t0 < BLOCK ? (size_t)(count - t0) : BLOCK;
        for (size_t j = 0; j < 3 * nb; j++) {
            const unsigned char *r = p + 84 + 50 * (t0 + j / 3) + 12 + 12 * (j % 3);
            for (int a = 0; a < 3; a++) {
                uint32_t u = le32u(r + 4 * a);
                if (tiny(u)) goto fallback;
                raw_bits[j][a] = u;
                key[j][a] = key_bits(u);
            }
            hash[j] = hash_key(key[j][0], key[j][1], key[j][2]);
#if defined(__GNUC__)
            __builtin_prefetch(&slot[(size_t)hash[j] & mask]);
#endif
        }
        for (size_t f = 0; f < nb; f++) {
            uint32_t h3[3];
            for (int c = 0; c < 3; c++) {
                size_t j = 3 * f + (size_t)c;
                const uint32_t *k = key[j];
                size_t i = (size_t)hash[j] & mask;
                for (;; i = (i + 1) & mask) {
                    uint32_t s = slot[i];
                    if (!s) break;
                    uint32_t q[3];
                    memcpy(q, xyz + 3 * (size_t)(s - 1), sizeof q);
                    if (key_bits(q[0]) == k[0] && key_bits(q[1]) == k[1] && key_bits(q[2]) == k[2]) break;
                }
                if (slot[i]) {
                    h3[c] = slot[i] - 1;
                    continue;
                }
                if (nv >= UINT32_MAX - 1) goto oom;
                memcpy(xyz + 3 * nv, raw_bits[j], sizeof raw_bits[j]);
                h3[c] = (uint32_t)nv;
                slot[i] = (uint32_t)++nv;
                if (2 * nv > ts) { /* grow: keep the table at most half full */
                    size_t nts = ts * 2;
                    uint32_t *ns = calloc(nts, sizeof *ns);
                    if (!ns) goto oom;
                    size_t nmask = nts - 1;
                    for (size_t v = 0; v < nv; v++) {
                        uint32_t q[3];
                        memcpy(q, xyz + 3 * v, sizeof q);
                        size_t m = (size_t)hash_key(key_bits(q[0]), key_bits(q[1]), key_bits(q[2])) & nmask;
                        while (ns[m]) m = (m + 1) & nmask;
                        ns[m] = (uint32_t)(v + 1);
                    }
                    free(slot);
                    slot = ns;
                    ts = nts;
                    mask = nmask;
                }
            }
            if (h3[0] != h3[1] && h3[0] != h3[2] && h3[1] != h3[2]) {
                idx[ni++] = h3[0];
                idx[ni++] = h3[1];
                idx[ni++] = h3[2];
            }
        }
    }
    free(slot);
    float *shr = realloc(xyz, (nv ? nv : 1) * 3 * sizeof *shr);
    if (shr) xyz = shr;
    raw->xyz = xyz;
    raw->vertex_count = nv;
    raw->face_indices = idx;
    raw->face_count = ni / 3;
    raw->index_count = ni;
    raw->face_sizes = NULL; /* all triangles */
    return 0;
fallback:
    free(slot);
    free(xyz);
    free(idx);
    return 1;
oom:
    free(slot);
    free(xyz);
    free(idx);
    return -2;
}
