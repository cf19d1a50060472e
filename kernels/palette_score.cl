/* SPDX-License-Identifier: Apache-2.0 */
/* Stage palette scoring: Monte Carlo palette voxelization (Cavagnino &
 * Gribaudo 3, 3.1), the cast's third consumer. One work-item per voxel
 * column: its R = N*N rays (sorted crossings from the cast, positions from
 * sampler.h as for coverage) and M points per voxel on each ray give the
 * voxel's S = R*M samples; o at a sample is the parity rule of classify and
 * coverage (inside when the number of crossings strictly beyond it is odd),
 * e_v is kernels/palette.h at the sample's position in the unit voxel.
 *
 * Score of element v: its equivalence count, the samples where e_v == o
 * (Nearest; the paper's NEX-OR counting); under Outer an element with a
 * sample where o = 1 and e_v = 0 scores -inf, under Inner one with o = 0 and
 * e_v = 1 does (Table 1). The voxel gets the element of the highest score,
 * the lowest index on ties; its score channel is count / S.
 *
 * The object's values at one voxel's samples are one bit mask O (sample
 * s = r*M + m is bit s % 32 of word s / 32). With uniform sampling every
 * voxel has the same sample positions, so the host computes each element's
 * mask E_v once (`masks`, words per element) and scoring an element is
 * S/32 XORs and popcounts: 78 elements at t = p = 16 are 624 word
 * operations (use_masks; uniform runs only). Stochastic samples move from
 * voxel to voxel, so e_v is
 * evaluated at every sample of every element still in the race (an element
 * leaves it at its first -inf sample, or under Nearest when its count plus
 * the samples left cannot reach the best count so far).
 *
 * Early-outs (3.1, unless early_out is 0): a run of voxels in which no ray
 * has a crossing and every ray is inside is full (score 1), every ray
 * outside empty (score 1) -- exactly what scoring would choose, as full and
 * empty are indices 1 and 0. A clean run whose rays disagree has the same O
 * in every voxel; with uniform sampling its voxels all get the first one's
 * result. The alpha/beta shortcut (Nearest, when sc_lo > 0 or sc_hi < S):
 * fewer than sc_lo samples inside -> empty, more than sc_hi -> full.
 *
 * Outputs per voxel (NULL planes are skipped): element index, score and
 * coverage as value_of_count[count] (HALF bits of count / S, or the count),
 * occupancy bit when the inside count >= occ_min (coverage's threshold).
 * Per column: sum of inside counts, occupied voxels, the voxels decided by
 * early-out / shortcut / scoring and the non-empty ones (pstats[4*gid +
 * 0..3]), and the sum of the chosen elements' volumes (col_volume, in units
 * of 2^-32 voxel: volume_fixed[e] = round(volume(e) * 2^32)). Columns with an
 * overflowed ray are skipped (the host redoes them). */
#define CLVOX_PALETTE_MAX_RAYS 256      /* CLVOX_MAX_OVERSAMPLE^2 */
#define CLVOX_PALETTE_MAX_WORDS 128     /* CLVOX_MAX_PALETTE_SAMPLES / 32 */
#define CLVOX_PALETTE_MAX_ELEMENTS 1024 /* palette.c MAX_ELEMENTS */
#define CLVOX_PALETTE_DEAD 0xFFFFu

/* Unit-voxel position of a sample along the ray (u) and across it (v, w),
 * as (x, y, z): the ray axis permutes them (x-rays: u,v,w = x,y,z; y-rays:
 * y,z,x; z-rays: z,x,y). */
static inline void clvox_unit_xyz(uint axis, float fu, float fv, float fw, float *x, float *y, float *z)
{
    if (axis == 1) {
        *x = fu, *y = fv, *z = fw;
    } else if (axis == 2) {
        *x = fw, *y = fu, *z = fv;
    } else {
        *x = fv, *y = fw, *z = fu;
    }
}

static void clvox_palette_score_body(global const clvox_column *cols, uint col_count, uint N, uint M,
                                     global const clvox_real *hits, global const uint *counts, uint capacity,
                                     uint u_begin, uint u_count, uint stochastic, uint seed_lo, uint seed_hi, uint axis,
                                     global const clvox_element *elements, global const clvox_cell *cells,
                                     global const clvox_halfspace *planes, uint n_elements, uint use_masks,
                                     global const uint *masks,
                                     uint metric, uint early_out, uint sc_lo, uint sc_hi,
                                     global const ushort *value_of_count, uint occ_min, uint X, uint W,
                                     uint vox_stride, uint out_stride, global ushort *element_out,
                                     global ushort *score_out, global ushort *coverage, global uint *occupancy,
                                     global const ulong *volume_fixed, global ulong *col_sum, global uint *col_filled,
                                     global uint *pstats, global ulong *col_volume,
                                     global const char *signs, global const clvox_ray *rays, uint abs_mode,
                                     global const clvox_real *h, global const clvox_cap_node *nodes, uint node_count,
                                     global const clvox_real *caps, global const float *gcaps,
                                     global uint *exact_points,
                                     global uint *unsure, global const uint *answers, uint n_answers)
{
    uint gid = get_global_id(0);
    if (!clvox_pass_column(&gid, &answers, n_answers)) return;
    const uint R = N * N, S = R * M, words = (S + 31u) / 32u;
    if (gid >= col_count || R > CLVOX_PALETTE_MAX_RAYS || words > CLVOX_PALETTE_MAX_WORDS ||
        n_elements > CLVOX_PALETTE_MAX_ELEMENTS || n_elements < 2)
        return;
    const size_t r0 = (size_t)gid * R;
    for (uint r = 0; r < R; r++)
        if (counts[r0 + r] > capacity) return; /* redone by the host */
    const clvox_column c = cols[gid];
    const uint row = c.out_base / W, x0 = (c.out_base % W) * 32u + c.bit;
    const size_t vbase = (size_t)row * X + x0, vstep = vox_stride ? vox_stride : 1u;
    global uint *o = occupancy ? occupancy + c.out_base : 0;
    const uint bit = 1u << (c.bit & 31u);

    uint k[CLVOX_PALETTE_MAX_RAYS];      /* per ray: crossings before the current voxel */
    int ks[CLVOX_PALETTE_MAX_RAYS];      /* winding: signed crossings beyond them */
    float fv[CLVOX_PALETTE_MAX_RAYS], fw[CLVOX_PALETTE_MAX_RAYS]; /* rays in the unit voxel */
    uint O[CLVOX_PALETTE_MAX_WORDS];
    ushort eq[CLVOX_PALETTE_MAX_ELEMENTS]; /* stochastic: running counts, DEAD = out */
    for (uint r = 0; r < R; r++) {
        uint a = r % N, b = r / N, bits[4] = {0, 0, 0, 0};
        if (stochastic) clvox_philox4x32_10(c.id, r, CLVOX_SAMPLER_RAY_WORD, 0, seed_lo, seed_hi, bits);
        fv[r] = clvox_stratum_float(a, N, (int)stochastic, bits[0]);
        fw[r] = clvox_stratum_float(b, N, (int)stochastic, bits[1]);
        k[r] = 0;
    }
    /* the ray axis: palette `axis` is 1..3 (x..z), the winding helpers take 0..2 */
    clvox_real g0[3], g1[3];
    const int col_near = signs ? clvox_column_winding_setup(signs, counts, rays, r0, R, capacity, ks, axis - 1u,
                                                            u_begin, u_count, h, nodes, node_count, g0, g1)
                               : 0;
    uint exact = 0;
    clvox_sample_cut sc;
    sc.n = 0;
    sc.fresh_exact = 0;
    ulong sum = 0;
    uint filled = 0, word = 0, n_early = 0, n_short = 0, n_scored = 0, nonempty = 0;
    ulong volume = 0;
    uint j = 0;
    while (j < u_count) {
        const uint u = u_begin + j;
        const clvox_real lo = (clvox_real)u - (clvox_real)0.5;
        const clvox_real hi = lo + (clvox_real)1;
        /* the first voxel (>= j) holding a crossing; rays inside until then */
        uint next, rays_in = clvox_column_step(hits, signs, counts, r0, R, capacity, k, ks, abs_mode, u_begin,
                                               u_count, j, lo, &next);
        int near = 0; /* voxel j's samples one by one (clvox_column_far_until) */
        if (col_near) {
            const uint e = clvox_column_far_until(j, next > j ? next : j + 1u, g0, g1, axis - 1u, u_begin, h, nodes,
                                                  node_count);
            near = e == j;
            if (near) next = j;
            else if (next > j) next = e;
        }
        uint end = j + 1, elem = 0, score = 0, cnt = 0;
        if (next > j && early_out && (rays_in == 0 || rays_in == R)) {
            end = next; /* wholly outside or inside: empty or full, score 1 */
            elem = rays_in ? 1u : 0u;
            cnt = rays_in ? S : 0u;
            score = S;
            n_early += end - j;
        } else {
            if (next > j && early_out && use_masks) end = next; /* same O, same masks: one result */
            /* O: the object at every sample of voxel j */
            for (uint w = 0; w < words; w++) O[w] = 0;
            for (uint r = 0; r < R; r++) {
                global const clvox_real *hr = hits + (r0 + r) * capacity;
                global const char *sg = signs ? signs + (r0 + r) * capacity : 0;
                const uint n = counts[r0 + r];
                uint kk = k[r];
                int K = sg ? ks[r] : 0;
                const int clean = !near && (kk == n || hr[kk] > hi);
                uint bits[4] = {0, 0, 0, 0};
                for (uint m = 0; m < M; m++) {
                    uint in;
                    if (clean) {
                        in = sg ? (uint)clvox_k_inside(K, abs_mode) : (n - kk) & 1u;
                    } else {
                        if (stochastic && (m & 3u) == 0)
                            clvox_philox4x32_10(c.id, r, u, m >> 2, seed_lo, seed_hi, bits);
                        const clvox_real p = clvox_sample_u(u, m, M, (int)stochastic, bits[m & 3u]);
                        if (sg) {
                            while (kk < n && hr[kk] <= p) K -= CLVOX_UNIT(sg[kk]), kk++;
                            if (near) {
                                /* a float build's unsure sample: the host decides (src/cast/unsure.c) */
                                const int w = clvox_sample_winding(K, abs_mode, axis - 1u, p, rays + r0 + r, h, nodes,
                                                                   node_count, caps, gcaps, &exact, &sc);
                                in = (uint)w & 1u;
                                if (w & CLVOX_UNSURE)
                                    in = clvox_unsure_sample(unsure, answers, n_answers, gid, j, K, (r << 8) | m, in);
                            } else {
                                in = (uint)clvox_k_inside(K, abs_mode);
                            }
                        } else {
                            while (kk < n && hr[kk] <= p) kk++;
                            in = (n - kk) & 1u;
                        }
                    }
                    const uint s = r * M + m;
                    O[s >> 5] |= in << (s & 31u);
                }
            }
            for (uint w = 0; w < words; w++) cnt += popcount(O[w]);
            if (metric == 0 && (cnt < sc_lo || cnt > sc_hi)) {
                elem = cnt < sc_lo ? 0u : 1u; /* alpha/beta shortcut */
                score = cnt < sc_lo ? S - cnt : cnt;
                n_short += end - j;
            } else if (use_masks) { /* uniform samples: the host's masks */
                int best = -1;
                for (uint e = 0; e < n_elements; e++) {
                    global const uint *E = masks + (size_t)e * words;
                    uint diff = 0, bad = 0;
                    for (uint w = 0; w < words; w++) {
                        diff += popcount(E[w] ^ O[w]);
                        bad |= metric == 1 ? (O[w] & ~E[w]) : metric == 2 ? (E[w] & ~O[w]) : 0u;
                    }
                    if (bad) continue;
                    if ((int)(S - diff) > best) best = (int)(S - diff), elem = e;
                }
                score = (uint)best; /* full (Outer) or empty (Inner) is never -inf */
                n_scored += end - j;
            } else {
                for (uint e = 0; e < n_elements; e++) eq[e] = 0;
                uint lead = 0; /* a lower bound of the best final count */
                for (uint r = 0; r < R; r++) {
                    uint bits[4] = {0, 0, 0, 0};
                    for (uint m = 0; m < M; m++) {
                        const uint s = r * M + m;
                        const uint in = (O[s >> 5] >> (s & 31u)) & 1u;
                        if (stochastic && (m & 3u) == 0) clvox_philox4x32_10(c.id, r, u, m >> 2, seed_lo, seed_hi, bits);
                        const float fu = clvox_stratum_float(m, M, (int)stochastic, bits[m & 3u]);
                        float px, py, pz;
                        clvox_unit_xyz(axis, fu, fv[r], fw[r], &px, &py, &pz);
                        for (uint e = 0; e < n_elements; e++) {
                            if (eq[e] == CLVOX_PALETTE_DEAD) continue;
                            const uint ev = (uint)clvox_element_contains(elements, cells, planes, e, px, py, pz);
                            if (ev == in) {
                                eq[e]++;
                            } else if ((metric == 1 && in) || (metric == 2 && ev)) {
                                eq[e] = CLVOX_PALETTE_DEAD;
                            }
                        }
                    }
                    if (metric == 0) { /* drop the elements that can no longer win */
                        const uint left = (R - 1u - r) * M;
                        for (uint e = 0; e < n_elements; e++)
                            if (eq[e] != CLVOX_PALETTE_DEAD && eq[e] > lead) lead = eq[e];
                        for (uint e = 0; e < n_elements; e++)
                            if (eq[e] != CLVOX_PALETTE_DEAD && (uint)eq[e] + left < lead) eq[e] = CLVOX_PALETTE_DEAD;
                    }
                }
                int best = -1;
                for (uint e = 0; e < n_elements; e++)
                    if (eq[e] != CLVOX_PALETTE_DEAD && (int)eq[e] > best) best = (int)eq[e], elem = e;
                score = (uint)best;
                n_scored += 1;
            }
        }
        const uint len = end - j;
        sum += (ulong)cnt * len;
        const int occ = cnt >= occ_min;
        const ushort vs = value_of_count[score], vc = value_of_count[cnt];
        for (uint i = j; i < end; i++) {
            const size_t at = vbase + (size_t)i * vstep;
            if (element_out) element_out[at] = (ushort)elem;
            if (score_out) score_out[at] = vs;
            if (coverage) coverage[at] = vc;
        }
        if (occ) filled += len;
        if (elem) nonempty += len;
        volume += volume_fixed[elem] * len;
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
    pstats[4 * gid + 0] = n_early;
    pstats[4 * gid + 1] = n_short;
    pstats[4 * gid + 2] = n_scored;
    pstats[4 * gid + 3] = nonempty;
    col_volume[gid] = volume;
    if (exact) atomic_add(exact_points, exact);
}

/* The kernel: the body, then the launch's completion count (clvox_done,
 * prelude.cl). */
kernel void clvox_palette_score(global const clvox_column *cols, uint col_count, uint N, uint M,
                                global const clvox_real *hits, global const uint *counts, uint capacity,
                                uint u_begin, uint u_count, uint stochastic, uint seed_lo, uint seed_hi, uint axis,
                                global const clvox_element *elements, global const clvox_cell *cells,
                                global const clvox_halfspace *planes, uint n_elements, uint use_masks,
                                global const uint *masks,
                                uint metric, uint early_out, uint sc_lo, uint sc_hi,
                                global const ushort *value_of_count, uint occ_min, uint X, uint W,
                                uint vox_stride, uint out_stride, global ushort *element_out,
                                global ushort *score_out, global ushort *coverage, global uint *occupancy,
                                global const ulong *volume_fixed, global ulong *col_sum, global uint *col_filled,
                                global uint *pstats, global ulong *col_volume,
                                global const char *signs, global const clvox_ray *rays, uint abs_mode,
                                global const clvox_real *h, global const clvox_cap_node *nodes, uint node_count,
                                global const clvox_real *caps, global const float *gcaps,
                                global uint *exact_points, global uint *unsure,
                                global const uint *answers, uint n_answers,
                                global uint *clvox_done, uint clvox_done_slot)
{
    clvox_palette_score_body(cols, col_count, N, M, hits, counts, capacity, u_begin, u_count, stochastic, seed_lo,
        seed_hi, axis, elements, cells, planes, n_elements, use_masks, masks, metric, early_out, sc_lo, sc_hi,
        value_of_count, occ_min, X, W, vox_stride, out_stride, element_out, score_out, coverage, occupancy,
        volume_fixed, col_sum, col_filled, pstats, col_volume, signs, rays, abs_mode, h, nodes, node_count, caps,
        gcaps, exact_points, unsure, answers, n_answers);
    clvox_done_mark(clvox_done, clvox_done_slot);
}
