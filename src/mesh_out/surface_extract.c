/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Surfaces of a volume, streamed slice by slice (docs/design.md "Meshes from
 * volumes").
 *
 * Voxel faces: a square for every face between a voxel with value > iso
 * (inside) and one without (outside; outside the grid counts as outside),
 * oriented away from the inside voxel, two triangles. Vertices sit on the
 * voxel corners and are shared by the faces that meet there, split where
 * the inside voxels touch only along an edge or at a corner: around each
 * lattice edge the faces are paired so that each inside voxel's faces go
 * round it (inside voxels are 6-connected, as in the classic voxel surface
 * definitions), and a corner gets one vertex per ring of faces around it
 * (a table over the 256 configurations of its 8 voxels). The result is a
 * closed, oriented 2-manifold whose every edge is used by exactly two
 * triangles in opposite directions; where voxels touch only along an edge
 * or corner the two sheets have distinct vertices at the same position.
 *
 * Marching cubes: the cubes between the voxel centres, values outside the
 * grid 0, a vertex on each cube edge whose ends are on either side of iso
 * (inside: value > iso), at the linear interpolation, kept 1/256 of an edge
 * from either end so no triangle collapses. The ambiguous faces (inside
 * corners diagonal) are always separated, a rule of the face's four values
 * alone, so the two cubes sharing a face agree and the surface is closed;
 * each cube's polygons are the loops of its faces' segments, fanned.
 *
 * Memory: two slices of values and two planes of vertex numbers.
 */
#include "mesh_out/surface_extract.h"

#include "core/internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define MC_MAX_TRI 10
#define NONE UINT32_MAX

struct clvox__surface {
    clvox_context *ctx;
    int smooth;
    uint32_t X, Y, Z;
    double origin[3], h[3];
    float iso;
    clvox__surface_sink sink;
    uint32_t next_z;
    int finished, failed;
    uint64_t nv, nt, inside;
    double vsum, vol6; /* vol6: 6 x signed volume, lattice units */
    uint64_t plane_start[2];
    /* voxel faces */
    uint8_t sheet_count[256];
    int8_t sheet_of[256][24]; /* [config][voxel * 3 + axis] */
    uint8_t *occ[2];          /* X*Y: slice below, slice above the current plane */
    uint8_t *cfg[2];          /* (X+1)*(Y+1): planes K-1, K */
    uint32_t *base[2];        /* first vertex of each corner, from plane_start */
    uint32_t *mx[2], *my[2];  /* x / y edges of planes K-1, K: first of their two midpoints, or NONE */
    /* marching cubes */
    uint8_t mc_count[256];
    int8_t mc_tri[256][MC_MAX_TRI * 3];
    float *val[2];            /* (X+2)*(Y+2), zero border: centre planes k, k+1 */
    uint32_t *xe[2], *ye[2], *ze;
};

/* ---- tables ---------------------------------------------------------------- */

static int uf_find(int *p, int x)
{
    while (p[x] != x) x = p[x] = p[p[x]];
    return x;
}

/* The rings of faces around a corner, for every configuration of its 8
 * voxels (voxel v = bx | by<<1 | bz<<2 is (I-1+bx, J-1+by, K-1+bz)). Face
 * (v, d): v inside, v ^ (1<<d) outside. Around the corner's edge along e the
 * face continues, across the third axis f, into v's own face (v, f) when
 * v ^ f is outside (it goes round v), else into v^f's face (v^f, d) when
 * v^f^d is outside (flat), else into (v^f^d, f) (a concave corner). */
static void build_sheets(uint8_t count[256], int8_t sheet[256][24])
{
    for (int c = 0; c < 256; c++) {
        int parent[24];
        for (int i = 0; i < 24; i++) parent[i] = i;
#define IN(v) (((c) >> (v)) & 1)
        for (int v = 0; v < 8; v++)
            for (int d = 0; d < 3; d++) {
                if (!IN(v) || IN(v ^ (1 << d))) continue;
                for (int e = 0; e < 3; e++) {
                    if (e == d) continue;
                    int f = 3 - d - e;
                    int vf = v ^ (1 << f), vfd = vf ^ (1 << d);
                    int other = !IN(vf) ? v * 3 + f : !IN(vfd) ? vf * 3 + d : vfd * 3 + f;
                    int a = uf_find(parent, v * 3 + d), b = uf_find(parent, other);
                    if (a != b) parent[a] = b;
                }
            }
        int label[24], n = 0;
        for (int i = 0; i < 24; i++) label[i] = -1;
        for (int i = 0; i < 24; i++) {
            sheet[c][i] = -1;
            int v = i / 3, d = i % 3;
            if (!IN(v) || IN(v ^ (1 << d))) continue;
            int r = uf_find(parent, i);
            if (label[r] < 0) label[r] = n++;
            sheet[c][i] = (int8_t)label[r];
        }
#undef IN
        count[c] = (uint8_t)n;
    }
}

/* Cube edge number of corners c1, c2 (one bit apart): axis * 4 + the other
 * two corner bits, lower axis first. */
static int cube_edge(int c1, int c2)
{
    int a = (c1 ^ c2) == 1 ? 0 : (c1 ^ c2) == 2 ? 1 : 2;
    int lo = c1 & c2, idx = 0, j = 0;
    for (int b = 0; b < 3; b++)
        if (b != a) idx |= ((lo >> b) & 1) << j++;
    return a * 4 + idx;
}

/* Marching-cubes triangles of every configuration: on each cube face
 * (corners counter-clockwise seen from outside the cube) a segment runs from
 * the crossing where the walk leaves the inside to the one where it enters
 * it (each inside corner on its own when the face is ambiguous); the
 * segments close into loops round the inside part of the cube's surface,
 * each fanned into triangles turned so that they face away from the inside. */
static void build_mc(uint8_t count[256], int8_t tri[256][MC_MAX_TRI * 3])
{
    for (int c = 0; c < 256; c++) {
        int next[12];
        for (int i = 0; i < 12; i++) next[i] = -1;
#define IN(v) (((c) >> (v)) & 1)
        for (int a = 0; a < 3; a++)
            for (int s = 0; s < 2; s++) {
                int u = (a + 1) % 3, w = (a + 2) % 3;
                static const int ccw[2][4][2] = {{{0, 0}, {0, 1}, {1, 1}, {1, 0}}, {{0, 0}, {1, 0}, {1, 1}, {0, 1}}};
                int q[4];
                for (int i = 0; i < 4; i++) q[i] = s << a | ccw[s][i][0] << u | ccw[s][i][1] << w;
                int ambiguous = IN(q[0]) == IN(q[2]) && IN(q[1]) == IN(q[3]) && IN(q[0]) != IN(q[1]);
                if (ambiguous) {
                    for (int i = 0; i < 4; i++)
                        if (IN(q[i])) next[cube_edge(q[i], q[(i + 1) & 3])] = cube_edge(q[(i + 3) & 3], q[i]);
                } else {
                    int exit_e = -1, entry_e = -1;
                    for (int i = 0; i < 4; i++) {
                        int p0 = q[i], p1 = q[(i + 1) & 3];
                        if (IN(p0) && !IN(p1)) exit_e = cube_edge(p0, p1);
                        if (!IN(p0) && IN(p1)) entry_e = cube_edge(p0, p1);
                    }
                    if (exit_e >= 0) next[exit_e] = entry_e;
                }
            }
#undef IN
        int seen[12] = {0}, n = 0;
        for (int e = 0; e < 12; e++) {
            if (next[e] < 0 || seen[e]) continue;
            int loop[12], m = 0;
            for (int x = e; !seen[x]; x = next[x]) {
                seen[x] = 1;
                loop[m++] = x;
            }
            for (int i = 1; i + 1 < m; i++) {
                tri[c][3 * n] = (int8_t)loop[0];
                tri[c][3 * n + 1] = (int8_t)loop[i + 1];
                tri[c][3 * n + 2] = (int8_t)loop[i];
                n++;
            }
        }
        count[c] = (uint8_t)n;
    }
}

/* ---- common ---------------------------------------------------------------- */

static clvox_status sink_failed(clvox__surface *s, int err)
{
    s->failed = 1;
    return clvox__fail(s->ctx, CLVOX_ERR_IO, "writing the mesh failed: %s", strerror(err));
}

static clvox_status put_vertex(clvox__surface *s, const double lat[3])
{
    if (s->sink.vertex) {
        double w[3];
        for (int a = 0; a < 3; a++) w[a] = s->origin[a] + lat[a] * s->h[a];
        int err = s->sink.vertex(s->sink.user, w);
        if (err) return sink_failed(s, err);
    }
    s->nv++;
    return CLVOX_OK;
}

static clvox_status put_triangle(clvox__surface *s, uint64_t a, uint64_t b, uint64_t c, const double *pa,
                                 const double *pb, const double *pc)
{
    s->vol6 += pa[0] * (pb[1] * pc[2] - pb[2] * pc[1]) - pa[1] * (pb[0] * pc[2] - pb[2] * pc[0]) +
               pa[2] * (pb[0] * pc[1] - pb[1] * pc[0]);
    s->nt++;
    if (!s->sink.triangle) return CLVOX_OK;
    uint64_t v[3] = {a, b, c};
    double w[9];
    const double *p[3] = {pa, pb, pc};
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++) w[3 * i + k] = s->origin[k] + p[i][k] * s->h[k];
    int err = s->sink.triangle(s->sink.user, v, w);
    return err ? sink_failed(s, err) : CLVOX_OK;
}

/* ---- voxel faces ----------------------------------------------------------- */

static inline int occ_at(const clvox__surface *s, const uint8_t *slice, int64_t i, int64_t j)
{
    return i >= 0 && j >= 0 && i < s->X && j < s->Y && slice[(size_t)j * s->X + (size_t)i];
}

/* The vertices of plane K (between slices K-1 = occ[0] and K = occ[1]) into
 * cfg[1] / base[1]. */
static clvox_status faces_plane(clvox__surface *s, uint32_t K)
{
    const size_t W = (size_t)s->X + 1;
    s->plane_start[1] = s->nv;
    for (uint32_t J = 0; J <= s->Y; J++)
        for (uint32_t I = 0; I <= s->X; I++) {
            int c = 0;
            for (int v = 0; v < 8; v++)
                if (occ_at(s, s->occ[v >> 2], (int64_t)I - 1 + (v & 1), (int64_t)J - 1 + ((v >> 1) & 1))) c |= 1 << v;
            size_t p = I + J * W;
            s->cfg[1][p] = (uint8_t)c;
            s->base[1][p] = (uint32_t)(s->nv - s->plane_start[1]);
            double lat[3] = {I, J, K};
            for (int n = 0; n < s->sheet_count[c]; n++) {
                clvox_status st = put_vertex(s, lat);
                if (st != CLVOX_OK) return st;
            }
        }
    /* the diagonal edges of the plane: two midpoints each, [0] for the
     * inside voxel below the plane, [1] for the one above */
    for (int a = 0; a < 2; a++) {
        uint32_t ni = a == 0 ? s->X : s->X + 1, nj = a == 0 ? s->Y + 1 : s->Y;
        uint32_t *m = a == 0 ? s->mx[1] : s->my[1];
        for (uint32_t J = 0; J < nj; J++)
            for (uint32_t I = 0; I < ni; I++) {
                int b[4]; /* [across + 2 * above] */
                for (int q = 0; q < 4; q++) {
                    int64_t i = (int64_t)I - (a == 1 ? 1 - (q & 1) : 0), j = (int64_t)J - (a == 0 ? 1 - (q & 1) : 0);
                    b[q] = occ_at(s, s->occ[q >> 1], i, j);
                }
                size_t p = I + (size_t)J * ni;
                m[p] = NONE;
                if (b[0] != b[3] || b[1] != b[2] || b[0] == b[1]) continue;
                m[p] = (uint32_t)(s->nv - s->plane_start[1]);
                double lat[3] = {I + (a == 0 ? 0.5 : 0.0), J + (a == 1 ? 0.5 : 0.0), K};
                for (int n = 0; n < 2; n++) {
                    clvox_status st = put_vertex(s, lat);
                    if (st != CLVOX_OK) return st;
                }
            }
    }
    return CLVOX_OK;
}

/* The face of voxel vox on side `side` (0: -, 1: +) of axis d; planes K-1
 * and K (tables 0 and 1) hold its corners. A side on a lattice edge where
 * two inside voxels touch diagonally gets that voxel's own midpoint vertex
 * (vmid: the voxel's vertical edges, made on first use, NONE until then),
 * so that the two pairs of faces round the edge never share an edge of the
 * mesh; such a face is fanned from its first midpoint. */
static clvox_status faces_quad(clvox__surface *s, const int64_t vox[3], int d, int side, uint32_t K, uint64_t vmid[4])
{
    static const int order[2][4][2] = {{{0, 0}, {0, 1}, {1, 1}, {1, 0}}, {{0, 0}, {1, 0}, {1, 1}, {0, 1}}};
    const size_t W = (size_t)s->X + 1;
    int u = (d + 1) % 3, w = (d + 2) % 3;
    uint64_t id[4];
    int64_t P[4][3];
    for (int i = 0; i < 4; i++) {
        P[i][d] = vox[d] + side;
        P[i][u] = vox[u] + order[side][i][0];
        P[i][w] = vox[w] + order[side][i][1];
        int v = 0;
        for (int a = 0; a < 3; a++) v |= (int)(vox[a] - (P[i][a] - 1)) << a;
        int t = (int)(P[i][2] - ((int64_t)K - 1));
        size_t p = (size_t)P[i][0] + (size_t)P[i][1] * W;
        int sh = s->sheet_of[s->cfg[t][p]][v * 3 + d];
        if (sh < 0) return clvox__fail(s->ctx, CLVOX_ERR_INTERNAL, "voxel faces: a face without its corner");
        id[i] = s->plane_start[t] + s->base[t][p] + (uint64_t)sh;
    }
    uint64_t pid[8];
    double pos[8][3];
    int n = 0, first_mid = -1;
    for (int i = 0; i < 4; i++) {
        const int64_t *A = P[i], *B = P[(i + 1) & 3];
        pid[n] = id[i];
        for (int a = 0; a < 3; a++) pos[n][a] = (double)A[a];
        n++;
        int axis = A[0] != B[0] ? 0 : A[1] != B[1] ? 1 : 2;
        int64_t lo[3] = {A[0] < B[0] ? A[0] : B[0], A[1] < B[1] ? A[1] : B[1], A[2] < B[2] ? A[2] : B[2]};
        uint64_t mid = UINT64_MAX;
        if (axis == 2) { /* a vertical edge of slice vox[2] */
            int b[4];
            for (int q = 0; q < 4; q++)
                b[q] = occ_at(s, s->occ[0], lo[0] - 1 + (q & 1), lo[1] - 1 + (q >> 1));
            if (b[0] == b[3] && b[1] == b[2] && b[0] != b[1]) {
                int c = (int)(lo[0] - vox[0]) + 2 * (int)(lo[1] - vox[1]);
                if (vmid[c] == UINT64_MAX) {
                    double lat[3] = {(double)lo[0], (double)lo[1], (double)lo[2] + 0.5};
                    vmid[c] = s->nv;
                    clvox_status st = put_vertex(s, lat);
                    if (st != CLVOX_OK) return st;
                }
                mid = vmid[c];
            }
        } else {
            int t = (int)(lo[2] - ((int64_t)K - 1));
            const uint32_t *m = axis == 0 ? s->mx[t] : s->my[t];
            size_t p = axis == 0 ? (size_t)lo[0] + (size_t)lo[1] * s->X : (size_t)lo[0] + (size_t)lo[1] * W;
            if (m[p] != NONE) mid = s->plane_start[t] + m[p] + (vox[2] == lo[2] ? 1 : 0);
        }
        if (mid != UINT64_MAX) {
            if (first_mid < 0) first_mid = n;
            pid[n] = mid;
            for (int a = 0; a < 3; a++) pos[n][a] = (A[a] + B[a]) * 0.5;
            n++;
        }
    }
    if (first_mid < 0) {
        clvox_status st = put_triangle(s, pid[0], pid[1], pid[2], pos[0], pos[1], pos[2]);
        if (st == CLVOX_OK) st = put_triangle(s, pid[0], pid[2], pid[3], pos[0], pos[2], pos[3]);
        return st;
    }
    for (int k = 1; k + 1 < n; k++) {
        int a = first_mid, b = (first_mid + k) % n, c = (first_mid + k + 1) % n;
        clvox_status st = put_triangle(s, pid[a], pid[b], pid[c], pos[a], pos[b], pos[c]);
        if (st != CLVOX_OK) return st;
    }
    return CLVOX_OK;
}

/* Plane K: its vertices, its z faces, then the x and y faces of slice K-1. */
static clvox_status faces_step(clvox__surface *s, uint32_t K)
{
    clvox_status st = faces_plane(s, K);
    for (uint32_t j = 0; j < s->Y && st == CLVOX_OK; j++)
        for (uint32_t i = 0; i < s->X && st == CLVOX_OK; i++) {
            int below = occ_at(s, s->occ[0], i, j), above = occ_at(s, s->occ[1], i, j);
            if (below == above) continue;
            int64_t vox[3] = {i, j, below ? (int64_t)K - 1 : K};
            uint64_t vmid[4] = {UINT64_MAX, UINT64_MAX, UINT64_MAX, UINT64_MAX};
            st = faces_quad(s, vox, 2, below, K, vmid);
        }
    if (K > 0)
        for (uint32_t j = 0; j < s->Y && st == CLVOX_OK; j++)
            for (uint32_t i = 0; i < s->X && st == CLVOX_OK; i++) {
                if (!occ_at(s, s->occ[0], i, j)) continue;
                int64_t vox[3] = {i, j, (int64_t)K - 1};
                uint64_t vmid[4] = {UINT64_MAX, UINT64_MAX, UINT64_MAX, UINT64_MAX};
                for (int d = 0; d < 2 && st == CLVOX_OK; d++)
                    for (int side = 0; side < 2 && st == CLVOX_OK; side++) {
                        int64_t ni = (int64_t)i + (d == 0 ? 2 * side - 1 : 0);
                        int64_t nj = (int64_t)j + (d == 1 ? 2 * side - 1 : 0);
                        if (!occ_at(s, s->occ[0], ni, nj)) st = faces_quad(s, vox, d, side, K, vmid);
                    }
            }
    uint8_t *o = s->occ[0];
    s->occ[0] = s->occ[1];
    s->occ[1] = o;
    uint8_t *c = s->cfg[0];
    s->cfg[0] = s->cfg[1];
    s->cfg[1] = c;
    uint32_t *b = s->base[0];
    s->base[0] = s->base[1];
    s->base[1] = b;
    b = s->mx[0];
    s->mx[0] = s->mx[1];
    s->mx[1] = b;
    b = s->my[0];
    s->my[0] = s->my[1];
    s->my[1] = b;
    s->plane_start[0] = s->plane_start[1];
    return st;
}

/* ---- marching cubes -------------------------------------------------------- */

/* The crossing on the edge from lattice point p (value va) one step along
 * axis a (value vb); lattice units. */
static void mc_point(const double p[3], int a, float va, float vb, float iso, double out[3])
{
    double t = ((double)iso - va) / ((double)vb - va);
    if (!(t >= 1.0 / 256)) t = 1.0 / 256;
    if (t > 1 - 1.0 / 256) t = 1 - 1.0 / 256;
    out[0] = p[0];
    out[1] = p[1];
    out[2] = p[2];
    out[a] += t;
}

/* Lattice position of padded sample (ci, cj) of centre plane k. */
static void mc_sample(uint64_t ci, uint64_t cj, int64_t k, double p[3])
{
    p[0] = (double)ci - 0.5;
    p[1] = (double)cj - 0.5;
    p[2] = (double)k + 0.5;
}

/* The layer of cubes between centre planes k (val[0]) and k+1 (val[1]). */
static clvox_status mc_layer(clvox__surface *s, int64_t k)
{
    const size_t W = (size_t)s->X + 2, H = (size_t)s->Y + 2, XW = (size_t)s->X + 1;
    const float iso = s->iso;
    const float *v0 = s->val[0], *v1 = s->val[1];
    clvox_status st = CLVOX_OK;
    s->plane_start[1] = s->nv;
    double p[3], q[3];
    /* x and y edges of plane k+1, then the z edges of the layer */
    for (size_t cj = 0; cj < H && st == CLVOX_OK; cj++)
        for (size_t ci = 0; ci + 1 < W && st == CLVOX_OK; ci++) {
            float a = v1[ci + cj * W], b = v1[ci + 1 + cj * W];
            if ((a > iso) == (b > iso)) continue;
            s->xe[1][ci + cj * XW] = (uint32_t)(s->nv - s->plane_start[1]);
            mc_sample(ci, cj, k + 1, p);
            mc_point(p, 0, a, b, iso, q);
            st = put_vertex(s, q);
        }
    for (size_t cj = 0; cj + 1 < H && st == CLVOX_OK; cj++)
        for (size_t ci = 0; ci < W && st == CLVOX_OK; ci++) {
            float a = v1[ci + cj * W], b = v1[ci + (cj + 1) * W];
            if ((a > iso) == (b > iso)) continue;
            s->ye[1][ci + cj * W] = (uint32_t)(s->nv - s->plane_start[1]);
            mc_sample(ci, cj, k + 1, p);
            mc_point(p, 1, a, b, iso, q);
            st = put_vertex(s, q);
        }
    for (size_t cj = 0; cj < H && st == CLVOX_OK; cj++)
        for (size_t ci = 0; ci < W && st == CLVOX_OK; ci++) {
            float a = v0[ci + cj * W], b = v1[ci + cj * W];
            if ((a > iso) == (b > iso)) continue;
            s->ze[ci + cj * W] = (uint32_t)(s->nv - s->plane_start[1]);
            mc_sample(ci, cj, k, p);
            mc_point(p, 2, a, b, iso, q);
            st = put_vertex(s, q);
        }
    /* the cubes */
    for (size_t cj = 0; cj + 1 < H && st == CLVOX_OK; cj++)
        for (size_t ci = 0; ci + 1 < W && st == CLVOX_OK; ci++) {
            float cv[8];
            int c = 0;
            for (int v = 0; v < 8; v++) {
                const float *pl = (v & 4) ? v1 : v0;
                cv[v] = pl[ci + (v & 1) + (cj + ((v >> 1) & 1)) * W];
                if (cv[v] > iso) c |= 1 << v;
            }
            if (c == 0 || c == 255) continue;
            for (int t = 0; t < s->mc_count[c] && st == CLVOX_OK; t++) {
                uint64_t id[3];
                double pos[3][3];
                for (int n = 0; n < 3; n++) {
                    int e = s->mc_tri[c][3 * t + n], a = e / 4, idx = e % 4;
                    /* the edge's low corner */
                    int lo = a == 0 ? (idx & 1) << 1 | (idx >> 1) << 2
                           : a == 1 ? (idx & 1) | (idx >> 1) << 2
                                    : (idx & 1) | (idx >> 1) << 1;
                    size_t x = ci + (lo & 1), y = cj + ((lo >> 1) & 1);
                    int z = (lo >> 2) & 1;
                    if (a == 0) id[n] = s->plane_start[z] + s->xe[z][x + y * XW];
                    else if (a == 1) id[n] = s->plane_start[z] + s->ye[z][x + y * W];
                    else id[n] = s->plane_start[1] + s->ze[x + y * W];
                    mc_sample(x, y, k + z, p);
                    mc_point(p, a, cv[lo], cv[lo | 1 << a], iso, pos[n]);
                }
                st = put_triangle(s, id[0], id[1], id[2], pos[0], pos[1], pos[2]);
            }
        }
    float *f = s->val[0];
    s->val[0] = s->val[1];
    s->val[1] = f;
    uint32_t *e = s->xe[0];
    s->xe[0] = s->xe[1];
    s->xe[1] = e;
    e = s->ye[0];
    s->ye[0] = s->ye[1];
    s->ye[1] = e;
    s->plane_start[0] = s->plane_start[1];
    return st;
}

/* ---- API ------------------------------------------------------------------- */

clvox_status clvox__surface_create(clvox_context *ctx, int smooth, const uint32_t dims[3], const double origin[3],
                                   const double voxel_size[3], float iso, const clvox__surface_sink *sink,
                                   clvox__surface **out)
{
    if (!ctx) return CLVOX_ERR_INVALID_ARGUMENT;
    if (!out || !dims || !origin || !voxel_size)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "surface: NULL argument");
    *out = NULL;
    for (int a = 0; a < 3; a++) {
        if (!dims[a] || dims[a] > (1u << 20))
            return clvox__fail(ctx, CLVOX_ERR_GRID, "surface: bad grid %u x %u x %u", dims[0], dims[1], dims[2]);
        if (!isfinite(origin[a]) || !isfinite(voxel_size[a]) || !(voxel_size[a] > 0))
            return clvox__fail(ctx, CLVOX_ERR_GRID, "surface: bad origin or voxel size");
    }
    if (!isfinite(iso)) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "surface: iso value is not finite");
    /* vertex numbers within one plane (or layer) are 32-bit */
    uint64_t plane = ((uint64_t)dims[0] + 2) * ((uint64_t)dims[1] + 2);
    if (plane * 4 >= UINT32_MAX)
        return clvox__fail(ctx, CLVOX_ERR_GRID, "surface: slices of %u x %u voxels are too large for a mesh", dims[0],
                           dims[1]);
    clvox__surface *s = calloc(1, sizeof *s);
    if (!s) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    s->ctx = ctx;
    s->smooth = smooth;
    s->X = dims[0];
    s->Y = dims[1];
    s->Z = dims[2];
    memcpy(s->origin, origin, sizeof s->origin);
    memcpy(s->h, voxel_size, sizeof s->h);
    s->iso = iso;
    if (sink) s->sink = *sink;
    int ok = 1;
    size_t n = (size_t)plane;
    if (smooth) {
        build_mc(s->mc_count, s->mc_tri);
        for (int i = 0; i < 2; i++) {
            ok = ok && (s->val[i] = calloc(n, sizeof(float))) && (s->xe[i] = calloc(n, sizeof(uint32_t))) &&
                 (s->ye[i] = calloc(n, sizeof(uint32_t)));
        }
        ok = ok && (s->ze = calloc(n, sizeof(uint32_t)));
    } else {
        build_sheets(s->sheet_count, s->sheet_of);
        size_t xy = (size_t)s->X * s->Y;
        for (int i = 0; i < 2; i++)
            ok = ok && (s->occ[i] = calloc(xy, 1)) && (s->cfg[i] = calloc(n, 1)) &&
                 (s->base[i] = calloc(n, sizeof(uint32_t))) && (s->mx[i] = calloc(n, sizeof(uint32_t))) &&
                 (s->my[i] = calloc(n, sizeof(uint32_t)));
    }
    if (!ok) {
        clvox__surface_destroy(s);
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for the surface of %u x %u slices", dims[0],
                           dims[1]);
    }
    *out = s;
    return CLVOX_OK;
}

void clvox__surface_destroy(clvox__surface *s)
{
    if (!s) return;
    for (int i = 0; i < 2; i++) {
        free(s->occ[i]);
        free(s->cfg[i]);
        free(s->base[i]);
        free(s->mx[i]);
        free(s->my[i]);
        free(s->val[i]);
        free(s->xe[i]);
        free(s->ye[i]);
    }
    free(s->ze);
    free(s);
}

clvox_status clvox__surface_slice(clvox__surface *s, uint32_t z, const float *values)
{
    if (!s) return CLVOX_ERR_INVALID_ARGUMENT;
    if (s->failed || s->finished || !values || z != s->next_z || z >= s->Z)
        return clvox__fail(s->ctx, CLVOX_ERR_INVALID_ARGUMENT, "surface: slice %u out of order (expected %u of %u)", z,
                           s->next_z, s->Z);
    s->next_z++;
    const size_t X = s->X, Y = s->Y;
    for (size_t j = 0; j < Y; j++)
        for (size_t i = 0; i < X; i++) {
            float v = values[i + j * X];
            if (isfinite(v)) s->vsum += v;
            if (v > s->iso) s->inside++;
        }
    clvox_status st;
    if (s->smooth) {
        const size_t W = X + 2;
        float *pl = s->val[1];
        for (size_t j = 0; j < Y; j++)
            for (size_t i = 0; i < X; i++) {
                float v = values[i + j * X];
                pl[i + 1 + (j + 1) * W] = isfinite(v) ? v : 0.0f;
            }
        st = mc_layer(s, (int64_t)z - 1);
    } else {
        for (size_t q = 0; q < X * Y; q++) s->occ[1][q] = values[q] > s->iso;
        st = faces_step(s, z);
    }
    if (st != CLVOX_OK) s->failed = 1;
    return st;
}

clvox_status clvox__surface_finish(clvox__surface *s)
{
    if (!s) return CLVOX_ERR_INVALID_ARGUMENT;
    if (s->failed || s->finished || s->next_z != s->Z)
        return clvox__fail(s->ctx, CLVOX_ERR_INVALID_ARGUMENT, "surface: finished after %u of %u slices", s->next_z,
                           s->Z);
    s->finished = 1;
    clvox_status st;
    if (s->smooth) {
        memset(s->val[1], 0, ((size_t)s->X + 2) * ((size_t)s->Y + 2) * sizeof(float));
        st = mc_layer(s, (int64_t)s->Z - 1);
    } else {
        memset(s->occ[1], 0, (size_t)s->X * s->Y);
        st = faces_step(s, s->Z);
    }
    if (st != CLVOX_OK) s->failed = 1;
    return st;
}

void clvox__surface_get_counts(const clvox__surface *s, clvox__surface_counts *c)
{
    memset(c, 0, sizeof *c);
    if (!s) return;
    c->vertices = s->nv;
    c->triangles = s->nt;
    c->inside_voxels = s->inside;
    c->value_sum = s->vsum;
    c->enclosed_volume = s->vol6 / 6.0 * s->h[0] * s->h[1] * s->h[2];
}
