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
inline void clvox_row_bits(global uint *o, uint *word, uint j, uint end, int set)
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
 * each ray's crossings below lo (k[r]: crossings before the voxel), sets
 * *next to the first voxel (>= j) that holds a crossing of any ray, and
 * returns how many rays are inside over [j, *next) (odd crossings beyond). */
inline uint clvox_column_step(global const clvox_real *hits, global const uint *counts, size_t r0, uint R,
                              uint capacity, uint *k, uint u_begin, uint u_count, uint j, clvox_real lo, uint *next)
{
    uint nx = u_count, inside = 0;
    for (uint r = 0; r < R; r++) {
        global const clvox_real *h = hits + (r0 + r) * capacity;
        const uint n = counts[r0 + r];
        uint kk = k[r];
        while (kk < n && h[kk] < lo) kk++;
        k[r] = kk;
        if (kk < n) {
            /* first voxel whose [u-1/2, u+1/2] holds h: ceil(h - 1/2) */
            clvox_real e = ceil(h[kk] - (clvox_real)0.5) - (clvox_real)u_begin;
            uint ev = e <= (clvox_real)j ? j : (e >= (clvox_real)u_count ? u_count : (uint)e);
            nx = min(nx, ev);
        }
        inside += (n - kk) & 1u;
    }
    *next = nx;
    return inside;
}

kernel void clvox_coverage(global const clvox_column *cols, uint col_count, uint R, uint M,
                           global const clvox_real *hits, global const uint *counts, uint capacity,
                           uint u_begin, uint u_count, uint stochastic, uint seed_lo, uint seed_hi,
                           global const ushort *value_of_count, uint occ_min,
                           uint X, uint W, uint vox_stride, uint out_stride,
                           global ushort *coverage, global uint *occupancy,
                           global ulong *col_sum, global uint *col_filled)
{
    uint gid = get_global_id(0);
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
    for (uint r = 0; r < R; r++) k[r] = 0;
    ulong sum = 0;
    uint filled = 0, word = 0;
    uint j = 0;
    while (j < u_count) {
        const clvox_real lo = (clvox_real)(u_begin + j) - (clvox_real)0.5;
        const clvox_real hi = lo + (clvox_real)1;
        uint next, rays_in = clvox_column_step(hits, counts, r0, R, capacity, k, u_begin, u_count, j, lo, &next);
        uint clean = rays_in * M; /* the points of the clean rays that are inside */
        uint end = next > j ? next : j + 1; /* voxels [j, end) get one value */
        uint cnt = clean;
        if (next == j) { /* voxel j holds a crossing: look at the points of those rays */
            cnt = 0;
            const uint u = u_begin + j;
            for (uint r = 0; r < R; r++) {
                global const clvox_real *h = hits + (r0 + r) * capacity;
                const uint n = counts[r0 + r];
                uint kk = k[r];
                if (kk == n || h[kk] > hi) {
                    cnt += ((n - kk) & 1u) ? M : 0u;
                    continue;
                }
                uint bits[4] = {0, 0, 0, 0};
                for (uint m = 0; m < M; m++) {
                    if (stochastic && (m & 3u) == 0)
                        clvox_philox4x32_10(c.id, r, u, m >> 2, seed_lo, seed_hi, bits);
                    clvox_real p = lo + clvox_stratum(m, M, (int)stochastic, bits[m & 3u]);
                    while (kk < n && h[kk] <= p) kk++;
                    cnt += (n - kk) & 1u;
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
}
