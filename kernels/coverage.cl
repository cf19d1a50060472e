/* SPDX-License-Identifier: Apache-2.0 */
/* Stage coverage: oversampled grey-level counting (Thon et al. 3.3.4), a
 * consumer of the cast like classify. One work-item per voxel column: its
 * R = N*N rays (sorted crossings from the cast) and M points per voxel on
 * each ray; the voxel's count is the number of its R*M points inside, a
 * point u being inside when the number of crossings strictly beyond it
 * (h > u) is odd -- the rule of classify, so N = M = 1 uniform gives the
 * binary volume exactly.
 *
 * Count per span, not per point: a voxel whose interval [u-1/2, u+1/2] holds
 * no crossing of a ray gets M or 0 from that ray at once; only rays with a
 * crossing in the voxel look at their points. A run of voxels clean for all
 * R rays is filled in one go, so the cost is O(R) per run and per voxel that
 * holds a crossing, plus one store per voxel.
 *
 * Outputs, per voxel: value_of_count[count] into `coverage` (a table: HALF
 * bits of count/(R*M) for the file, or the count itself for callers that
 * want exact fractions) unless coverage is 0; the occupancy bit count >=
 * occ_min unless occupancy is 0 (rows written whole for x-rays, atomic_or
 * for the others as in classify). Per column: the sum of counts and the
 * number of voxels with count >= occ_min (whether or not bits are written). Columns with an overflowed ray are skipped
 * (the host redoes them with a larger buffer). */
#ifndef CLVOX_COVERAGE_MAX_RAYS
#define CLVOX_COVERAGE_MAX_RAYS 256 /* CLVOX_MAX_OVERSAMPLE^2: per-ray state is private */
#endif

/* Appends bits [j, end) = `set` to a row written whole, word by word
 * (see classify.cl). */
static inline void clvox_row_bits(global uint *o, uint *word, uint j, uint end, int set)
{
    const uint fill = set ? 0xFFFFFFFFu : 0u;
    if (j & 31u) {
        uint b = j & 31u, take = min(32u - b, end - j);
        *word |= fill & (((1u << take) - 1u) << b); /* take < 32 */
        j += take;
        if ((j & 31u) == 0) o[(j >> 5) - 1] = *word;
    }
    for (; j + 32u <= end; j += 32u) o[j >> 5] = fill;
    if (j < end) *word = fill & ((1u << (end - j)) - 1u);
}

/* One step along a column of R rays (coverage and palette scoring): passes
 * each ray's crossings below lo (k[r]: crossings before the voxel; with
 * signs, ks[r]: the signed crossings beyond them), sets *next to the first
 * voxel (>= j) that holds a crossing of any ray, and returns how many rays
 * are inside over [j, *next): odd crossings beyond (parity), or
 * clvox_k_inside (winding, away from the caps). */
static inline uint clvox_column_step(global const clvox_real *hits, global const char *signs, global const uint *counts,
                                     size_t r0, uint R, uint capacity, uint *k, int *ks, uint abs_mode, uint u_begin,
                                     uint u_count, uint j, clvox_real lo, uint *next)
{
    uint nx = u_count, inside = 0;
    for (uint r = 0; r < R; r++) {
        global const clvox_real *h = hits + (r0 + r) * capacity;
        const uint n = counts[r0 + r];
        uint kk = k[r];
        if (signs) {
            global const char *sg = signs + (r0 + r) * capacity;
            while (kk < n && h[kk] < lo) ks[r] -= CLVOX_UNIT(sg[kk]), kk++;
        } else {
            while (kk < n && h[kk] < lo) kk++;
        }
        k[r] = kk;
        if (kk < n) {
            /* first voxel whose [u-1/2, u+1/2] holds h: ceil(h - 1/2) */
            clvox_real e = ceil(h[kk] - (clvox_real)0.5) - (clvox_real)u_begin;
            uint ev = e <= (clvox_real)j ? j : (e >= (clvox_real)u_count ? u_count : (uint)e);
            nx = min(nx, ev);
        }
        inside += signs ? (uint)clvox_k_inside(ks[r], abs_mode) : (n - kk) & 1u;
    }
    *next = nx;
    return inside;
}

/* Winding runs of the column consumers: each ray's signed crossings in
 * ks[r] (all of them: beyond the column's start), and whether the column
 * comes near a cap (then every sample is tested on its own,
 * clvox_winding_inside; else clvox_k_inside as for whole runs). */
static inline int clvox_column_winding_setup(global const char *signs, global const uint *counts,
                                             global const clvox_ray *rays, size_t r0, uint R, uint capacity, int *ks,
                                             uint axis, uint u_begin, uint u_count, global const clvox_real *h,
                                             global const clvox_cap_node *nodes, uint node_count, clvox_real *g0,
                                             clvox_real *g1)
{
    g0[0] = (clvox_real)u_begin - (clvox_real)0.5;
    g1[0] = (clvox_real)(u_begin + u_count) - (clvox_real)0.5;
    g0[1] = g0[2] = g1[1] = g1[2] = 0;
    for (uint r = 0; r < R; r++) {
        global const char *sg = signs + (r0 + r) * capacity;
        int K = 0;
        for (uint q = 0; q < counts[r0 + r]; q++) K += CLVOX_UNIT(sg[q]);
        ks[r] = K;
        const clvox_real v = rays[r0 + r].v, w = rays[r0 + r].w;
        if (r == 0 || v < g0[1]) g0[1] = v;
        if (r == 0 || v > g1[1]) g1[1] = v;
        if (r == 0 || w < g0[2]) g0[2] = w;
        if (r == 0 || w > g1[2]) g1[2] = w;
    }
    if (node_count == 0) return 0;
    clvox_real q0[3], q1[3];
    clvox_cap_box(axis, g0, g1, h, q0, q1);
    return !clvox_caps_far(nodes, node_count, q0, q1, 16u);
}

/* In a column near a cap (g0, g1: its rays' box in grid space, u along
 * the column): the end e of a stretch [j, e), e <= next, whose samples
 * the caps' bounds leave to K (clvox_caps_far over its box): j when voxel
 * j alone is not such a stretch (its samples are evaluated one by one),
 * else the longest of [j, next), halved while it is not. Most voxels of a
 * column that comes near a cap are far from it (a soup's weld pairs lie
 * along the whole surface: every column crossing it is near). */
static inline uint clvox_column_far_until(uint j, uint next, const clvox_real *g0, const clvox_real *g1, uint axis,
                                          uint u_begin, global const clvox_real *h,
                                          global const clvox_cap_node *nodes, uint node_count)
{
    clvox_real a0[3] = {(clvox_real)(u_begin + j) - (clvox_real)0.5, g0[1], g0[2]}, a1[3] = {0, g1[1], g1[2]};
    clvox_real q0[3], q1[3];
    uint e = j + 1u;
    for (int first = 1;; first = 0) {
        a1[0] = (clvox_real)(u_begin + e) - (clvox_real)0.5;
        clvox_cap_box(axis, a0, a1, h, q0, q1);
        const int far = clvox_caps_far(nodes, node_count, q0, q1, CLVOX_COLUMN_BUDGET);
        if (first) {
            if (!far) return j;
            if (next <= j + 1u) return j + 1u;
            e = next;
            continue;
        }
        if (far) return e;
        e = j + 1u + (e - j - 1u) / 2u; /* [j, j + 1) is far: halving ends there */
        if (e == j + 1u) return e;
    }
}

/* The sample at u on ray r of a column near a cap: K at u (signed
 * crossings beyond it, from ks and the crossings kk.. passed), then the
 * caps, from the cut of the column's last sample (clvox_winding_inside_cut:
 * the samples of a column are each other's neighbours). */
typedef struct clvox_sample_cut {
    uint cut[CLVOX_CUT_MAX], n, fresh_exact;
} clvox_sample_cut;

static inline int clvox_sample_winding(int K, uint abs_mode, uint axis, clvox_real u, global const clvox_ray *ray,
                                       global const clvox_real *h, global const clvox_cap_node *nodes, uint node_count,
                                       global const clvox_real *caps, global const float *gcaps, uint *exact,
                                       clvox_sample_cut *sc)
{
    clvox_real x, y, z, lo, hi, g[3];
    clvox_scaled_xyz(axis, u, (clvox_real)ray->v, (clvox_real)ray->w, h, &x, &y, &z);
    /* the exact signs on the grid's floats (the samples are floats,
     * clvox_sample_u); the float build's unsure answers (CLVOX_UNSURE) go
     * to the host (clvox_unsure_sample) */
    clvox_grid_xyz(axis, u, (clvox_real)ray->v, (clvox_real)ray->w, g);
    return clvox_winding_inside_cut(K, abs_mode, nodes, node_count, caps, gcaps, g, x, y, z,
                                    axis | CLVOX_AXIS_FLAGS(h[3]), 0u, exact, &lo, &hi, sc->cut, &sc->n,
                                    &sc->fresh_exact);
}

static void clvox_coverage_body(global const clvox_column *cols, uint col_count, uint R, uint M,
                                global const clvox_real *hits, global const uint *counts, uint capacity,
                                uint u_begin, uint u_count, uint stochastic, uint seed_lo, uint seed_hi,
                                global const ushort *value_of_count, uint occ_min,
                                uint X, uint W, uint vox_stride, uint out_stride,
                                global ushort *coverage, global uint *occupancy,
                                global ulong *col_sum, global uint *col_filled,
                                global const char *signs, global const clvox_ray *rays, uint abs_mode, uint axis,
                                global const clvox_real *h, global const clvox_cap_node *nodes, uint node_count,
                                global const clvox_real *caps, global const float *gcaps,
                                global uint *exact_points, global uint *unsure,
                                global const uint *answers, uint n_answers)
{
    uint gid = get_global_id(0);
    if (!clvox_pass_column(&gid, &answers, n_answers)) return;
    if (gid >= col_count || R > CLVOX_COVERAGE_MAX_RAYS) return;
    const size_t r0 = (size_t)gid * R;
    for (uint r = 0; r < R; r++)
        if (counts[r0 + r] > capacity) return; /* redone by the host */
    const clvox_column c = cols[gid];
    /* where voxel j of this column goes: coverage[vbase + j*vstep], bit
     * `bit` of occupancy[c.out_base + j*out_stride] (out_stride 0: one row) */
    const uint row = c.out_base / W, x0 = (c.out_base % W) * 32u + c.bit;
    const size_t vbase = (size_t)row * X + x0, vstep = vox_stride ? vox_stride : 1u;
    global uint *o = occupancy ? occupancy + c.out_base : 0;
    const uint bit = 1u << (c.bit & 31u);

    uint k[CLVOX_COVERAGE_MAX_RAYS]; /* per ray: crossings before the current voxel */
    int ks[CLVOX_COVERAGE_MAX_RAYS];  /* winding: signed crossings beyond them */
    for (uint r = 0; r < R; r++) k[r] = 0;
    clvox_real g0[3], g1[3];
    const int col_near = signs ? clvox_column_winding_setup(signs, counts, rays, r0, R, capacity, ks, axis,
                                                            u_begin, u_count, h, nodes, node_count, g0, g1)
                               : 0;
    uint exact = 0;
    clvox_sample_cut sc;
    sc.n = 0;
    sc.fresh_exact = 0;
    ulong sum = 0;
    uint filled = 0, word = 0;
    uint j = 0;
    while (j < u_count) {
        const clvox_real lo = (clvox_real)(u_begin + j) - (clvox_real)0.5;
        const clvox_real hi = lo + (clvox_real)1;
        uint next, rays_in = clvox_column_step(hits, signs, counts, r0, R, capacity, k, ks, abs_mode, u_begin,
                                               u_count, j, lo, &next);
        int near = 0; /* voxel j's samples one by one */
        if (col_near) {
            const uint e = clvox_column_far_until(j, next > j ? next : j + 1u, g0, g1, axis, u_begin, h, nodes,
                                                  node_count);
            near = e == j;
            if (near) next = j;
            else if (next > j) next = e;
        }
        uint clean = rays_in * M; /* the points of the clean rays that are inside */
        uint end = next > j ? next : j + 1; /* voxels [j, end) get one value */
        uint cnt = clean;
        if (next == j) { /* voxel j holds a crossing: look at the points of those rays */
            cnt = 0;
            const uint u = u_begin + j;
            /* uniform points are the same on every ray: made once */
            float pu[16];
            const int same_points = !stochastic && M <= 16u;
            for (uint m = 0; same_points && m < M; m++) pu[m] = clvox_sample_u(u, m, M, 0, 0u);
            for (uint r = 0; r < R; r++) {
                global const clvox_real *hr = hits + (r0 + r) * capacity;
                global const char *sg = signs ? signs + (r0 + r) * capacity : 0;
                const uint n = counts[r0 + r];
                uint kk = k[r];
                int K = sg ? ks[r] : 0;
                if (!near && (kk == n || hr[kk] > hi)) {
                    cnt += (sg ? clvox_k_inside(K, abs_mode) : (n - kk) & 1u) ? M : 0u;
                    continue;
                }
                uint bits[4] = {0, 0, 0, 0};
                for (uint m = 0; m < M; m++) {
                    if (stochastic && (m & 3u) == 0)
                        clvox_philox4x32_10(c.id, r, u, m >> 2, seed_lo, seed_hi, bits);
                    const clvox_real p = same_points ? pu[m] : clvox_sample_u(u, m, M, (int)stochastic, bits[m & 3u]);
                    if (sg) {
                        while (kk < n && hr[kk] <= p) K -= CLVOX_UNIT(sg[kk]), kk++;
                        if (!near) {
                            cnt += (uint)clvox_k_inside(K, abs_mode);
                            continue;
                        }
                        const int in = clvox_sample_winding(K, abs_mode, axis, p, rays + r0 + r, h, nodes,
                                                            node_count, caps, gcaps, &exact, &sc);
                        cnt += in & CLVOX_UNSURE
                                   ? clvox_unsure_sample(unsure, answers, n_answers, gid, j, K, (r << 8) | m,
                                                         (uint)in & 1u)
                                   : (uint)in;
                    } else {
                        while (kk < n && hr[kk] <= p) kk++;
                        cnt += (n - kk) & 1u;
                    }
                }
            }
        }
        const uint len = end - j;
        sum += (ulong)cnt * len;
        const int occ = cnt >= occ_min;
        if (coverage) {
            const ushort v = value_of_count[cnt];
            for (uint i = j; i < end; i++) coverage[vbase + (size_t)i * vstep] = v;
        }
        if (occ) filled += len;
        if (o) {
            if (out_stride == 0) {
                clvox_row_bits(o, &word, j, end, occ);
            } else if (occ) {
                for (uint i = j; i < end; i++) atomic_or(o + (size_t)i * out_stride, bit);
            }
        }
        j = end;
    }
    if (o && out_stride == 0 && (j & 31u)) o[j >> 5] = word;
    col_sum[gid] = sum;
    col_filled[gid] = filled;
    if (exact) atomic_add(exact_points, exact);
}

/* The kernel: the body, then the launch's completion count (clvox_done,
 * prelude.cl). */
kernel void clvox_coverage(global const clvox_column *cols, uint col_count, uint R, uint M,
                           global const clvox_real *hits, global const uint *counts, uint capacity,
                           uint u_begin, uint u_count, uint stochastic, uint seed_lo, uint seed_hi,
                           global const ushort *value_of_count, uint occ_min,
                           uint X, uint W, uint vox_stride, uint out_stride,
                           global ushort *coverage, global uint *occupancy,
                           global ulong *col_sum, global uint *col_filled,
                           global const char *signs, global const clvox_ray *rays, uint abs_mode, uint axis,
                           global const clvox_real *h, global const clvox_cap_node *nodes, uint node_count,
                           global const clvox_real *caps, global const float *gcaps,
                           global uint *exact_points, global uint *unsure,
                           global const uint *answers, uint n_answers,
                           global uint *clvox_done, uint clvox_done_slot)
{
    clvox_coverage_body(cols, col_count, R, M, hits, counts, capacity, u_begin, u_count, stochastic, seed_lo, seed_hi,
        value_of_count, occ_min, X, W, vox_stride, out_stride, coverage, occupancy, col_sum, col_filled, signs, rays,
        abs_mode, axis, h, nodes, node_count, caps, gcaps, exact_points, unsure, answers, n_answers);
    clvox_done_mark(clvox_done, clvox_done_slot);
}

#ifdef CLVOX_FP64
/* The ray positions of a batch of columns (src/cast/cast.c ray_slab), one
 * work-item per ray: ray r of column i at rays[i * R + r], R = N * N, made
 * by sampler.h's clvox_column_ray in double as the host makes them, so the
 * same floats bit for bit (a float build would round the strata otherwise:
 * there the host makes the rays and this kernel does not exist). The
 * column's id is w * dim_v + v. */
kernel void clvox_column_rays(global const clvox_column *cols, uint n_cols, uint N, uint dim_v, uint stochastic,
                              uint seed_lo, uint seed_hi, global clvox_ray *rays,
                              global uint *clvox_done, uint clvox_done_slot)
{
    const uint R = N * N;
    const size_t g = get_global_id(0);
    if (g < (size_t)n_cols * R) {
        const uint i = (uint)(g / R), r = (uint)(g % R), id = cols[i].id;
        float pv, pw;
        clvox_column_ray(id % dim_v, id / dim_v, id, r, N, (int)stochastic, seed_lo, seed_hi, &pv, &pw);
        clvox_ray ray;
        ray.v = pv;
        ray.w = pw;
        ray.out_base = 0u;
        ray.bit = 0u;
        rays[g] = ray;
    }
    clvox_done_mark(clvox_done, clvox_done_slot);
}
#endif
