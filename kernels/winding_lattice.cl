/* SPDX-License-Identifier: Apache-2.0 */
/* Stage classify, winding numbers: the lattice of one slab
 * (kernels/winding_lattice.h), built before its rays are classified
 * (src/cast/winding_lattice.c): first the blocks, then the lattice points
 * that a usable block needs. */

/* Block i of the lattice (nx by ny by nz points from plane z0), out[5i ..]
 * (CLVOX_BLOCK_WORDS): M2 along x, y and z over it (INFINITY where a rim
 * may touch it), the caps' bound over it where that decides every voxel
 * by K alone (else INFINITY), and 1 where its points interpolate (no cap
 * near, the interpolation's error at its centre under CLVOX_BLOCK_USABLE),
 * CLVOX_BLOCK_SPLIT where it is split in near and far caps (its near caps'
 * sums at its corners and the far caps' M2 in split, its near leaves in
 * near; axis: the classify's ray axis, for the tie rule), else 0. The
 * rays' segments take M2 from the blocks too (kernels/winding.cl), caps or
 * not. */
kernel void clvox_winding_blocks(global const clvox_cap_node *nodes, uint node_count, global const clvox_real *caps,
                                 global const clvox_real *h, global const clvox_cap_node *rims, uint rim_count,
                                 global const clvox_real *edges, uint nx, uint ny, uint nz, uint z0, uint S,
                                 global clvox_real *out, global const float *gcaps, uint axis,
                                 global clvox_real *split, global uint *near, global uint *clvox_done,
                                 uint clvox_done_slot)
{
    const uint i = get_global_id(0), bx = nx - 1u, by = ny - 1u;
    if (i < bx * by * (nz - 1u)) {
        const uint g[3] = {i % bx, (i / bx) % by, i / (bx * by) + z0};
        clvox_real q0[3], q1[3], m2[3], e = 0;
        for (uint a = 0; a < 3u; a++) {
            q0[a] = (clvox_real)(g[a] * S) * h[a];
            q1[a] = (clvox_real)((g[a] + 1u) * S) * h[a];
        }
        global clvox_real *o = out + (size_t)i * CLVOX_BLOCK_WORDS;
        const clvox_real far =
            node_count ? clvox_caps_box_bound(nodes, q0, q1, CLVOX_BLOCK_FAR_BUDGET, CLVOX_CAPS_FAR_LIMIT) : 0;
        const int alone = far < CLVOX_CAPS_FAR_LIMIT;
        m2[0] = m2[1] = m2[2] = (clvox_real)INFINITY;
        /* sum of M2 at which the centre's error is CLVOX_BLOCK_ENOUGH (cubic voxels: h[a] the same) */
        const clvox_real hw0 = (clvox_real)S * h[0] * (clvox_real)0.5;
        if (!alone)
            clvox_rim_box_m2(rims, rim_count, edges, q0, q1, (clvox_real)CLVOX_BLOCK_ENOUGH * 2 / (hw0 * hw0), m2);
        for (uint a = 0; a < 3u; a++) {
            o[a] = m2[a];
            const clvox_real hw = (clvox_real)S * h[a] * (clvox_real)0.5;
            e += m2[a] * hw * hw * (clvox_real)0.5; /* the interpolation's error at the centre */
        }
        o[3] = alone ? far : (clvox_real)INFINITY;
        o[4] = !alone && e < (clvox_real)CLVOX_BLOCK_USABLE &&
                       !clvox_caps_touch(nodes, caps, q0, q1, h[0] * (clvox_real)1e-3)
                   ? 1
                   : 0;
        /* a block near the rims: split in near and far caps where the far
         * part's interpolation error is small enough (winding_lattice.h) */
        global uint *list = near + (size_t)i * (CLVOX_NEAR_MAX + 1u);
        list[0] = 0;
        clvox_real mf = 0;
        const clvox_real R = (clvox_real)(CLVOX_NEAR_BLOCKS * S) * h[0];
        if (!alone && o[4] == 0 && node_count && e >= (clvox_real)CLVOX_BLOCK_USABLE &&
            clvox_caps_split(nodes, q0, q1, R, list, &mf)) {
            const clvox_real ef = 3 * mf * hw0 * hw0 * (clvox_real)0.5; /* cubic voxels: hw0 on every axis */
            if (ef < (clvox_real)CLVOX_BLOCK_USABLE) {
                /* the near caps' sum at the block's corners: the far part
                 * there is the lattice point's w_caps less it */
                global clvox_real *sw = split + (size_t)i * CLVOX_SPLIT_WORDS;
                for (uint q = 0; q < 8u; q++) {
                    const clvox_real gq[3] = {(clvox_real)((g[0] + (q & 1u)) * S),
                                              (clvox_real)((g[1] + ((q >> 1) & 1u)) * S),
                                              (clvox_real)((g[2] + (q >> 2)) * S)};
                    clvox_real err = 0;
                    sw[2u * q] = clvox_near_sum(nodes, caps, gcaps, list, gq, h, axis | CLVOX_AXIS_FLAGS(h[3]), &err);
                    sw[2u * q + 1u] = err;
                }
                sw[16] = mf;
                o[4] = CLVOX_BLOCK_SPLIT;
            } else {
                list[0] = 0;
            }
        }
    }
    clvox_done_mark(clvox_done, clvox_done_slot);
}

/* Lattice point i: w_caps's interval (clvox_caps_interval) into out[2i ..]
 * where a block next to it interpolates or is split (blocks,
 * clvox_winding_blocks; a split block's far part at its corners is this
 * less its near caps there, split), else NAN. axis: the classify's ray
 * axis (its tie rule). */
kernel void clvox_winding_lattice(global const clvox_cap_node *nodes, global const clvox_real *caps,
                                  global const float *gcaps, global const clvox_real *h, uint axis,
                                  global const clvox_real *blocks, uint nx, uint ny, uint nz, uint z0, uint S,
                                  global clvox_real *out, global const clvox_real *split, global uint *clvox_done,
                                  uint clvox_done_slot)
{
    const uint i = get_global_id(0);
    if (i < nx * ny * nz) {
        const uint p[3] = {i % nx, (i / nx) % ny, i / (nx * ny)};
        const uint n[3] = {nx, ny, nz};
        /* the width aimed at: CLVOX_LATTICE_EPS, or half the smallest
         * interpolation error (at the centre) of the usable blocks next to
         * it where that is larger (a narrower value would not narrow the
         * voxels' intervals much) */
        clvox_real want = (clvox_real)INFINITY;
        for (uint q = 0; q < 8u; q++) {
            uint b[3], ok = 1;
            for (uint a = 0; a < 3u; a++) {
                const uint d = (q >> a) & 1u;
                ok &= p[a] >= d && p[a] - d + 1u < n[a];
                b[a] = p[a] - d;
            }
            if (!ok) continue;
            const size_t bi = (size_t)(b[2] * (ny - 1u) + b[1]) * (nx - 1u) + b[0];
            global const clvox_real *bw = blocks + bi * CLVOX_BLOCK_WORDS;
            if (bw[4] == 0) continue;
            clvox_real e = 0;
            for (uint a = 0; a < 3u; a++) {
                const clvox_real hw = (clvox_real)S * h[a] * (clvox_real)0.5;
                /* a split block: its far caps' M2 (cubic voxels) */
                e += (bw[4] == 1 ? bw[a] : split[bi * CLVOX_SPLIT_WORDS + 16u]) * hw * hw * (clvox_real)0.5;
            }
            want = fmin(want, fmax((clvox_real)CLVOX_LATTICE_EPS, e * (clvox_real)0.5));
        }
        clvox_real lo = (clvox_real)NAN, hi = (clvox_real)NAN;
        if (isfinite(want)) {
            const clvox_real g[3] = {(clvox_real)(p[0] * S), (clvox_real)(p[1] * S),
                                     (clvox_real)((p[2] + z0) * S)};
            clvox_caps_interval(nodes, caps, gcaps, g, g[0] * h[0], g[1] * h[1], g[2] * h[2],
                                axis | CLVOX_AXIS_FLAGS(h[3]), want, &lo, &hi);
        }
        out[2 * (size_t)i] = lo;
        out[2 * (size_t)i + 1] = hi;
    }
    clvox_done_mark(clvox_done, clvox_done_slot);
}

/* For tests/test_winding.c only: the lattice's answer for grid points
 * g[3i ..] (x, y, z) with K = 0, so that [lo, hi] holds -w_caps: out[5i ..]
 * = lo, hi, how (1 interpolated, 2 the caps' bound alone, 0 none), the
 * block's M2 along x and its word 4 (1, CLVOX_BLOCK_SPLIT or 0). */
kernel void clvox_lattice_probe(global const clvox_real *h, global const clvox_real *points,
                                global const clvox_real *blocks, uint nx, uint ny, uint nz, uint z0, uint S,
                                global const clvox_real *split, global const uint *near,
                                global const clvox_cap_node *nodes, global const clvox_real *caps,
                                global const float *gcaps, uint axis, global const clvox_real *g, uint count,
                                global clvox_real *out)
{
    const uint i = get_global_id(0);
    if (i >= count) return;
    const clvox_lattice lt = {points, blocks, nx, ny, nz, z0, S, split, near, nodes, caps, gcaps,
                              axis | CLVOX_AXIS_FLAGS(h[3])};
    const clvox_real p[3] = {g[3 * i], g[3 * i + 1], g[3 * i + 2]};
    clvox_real lo = (clvox_real)NAN, hi = (clvox_real)NAN;
    clvox_lattice_inside(&lt, h, p, 0, 0u, &lo, &hi);
    global clvox_real *o = out + 5 * (size_t)i;
    o[0] = lo;
    o[1] = hi;
    int usable;
    const clvox_real m2 = clvox_lattice_segment_m2(&lt, 0u, p, 1u, &usable);
    o[2] = !(lo <= hi) ? 0 : (usable ? 1 : 2);
    o[3] = m2;
    uint c[3], k[3];
    global const clvox_real *bw = clvox_lattice_block(&lt, p, c, k);
    o[4] = bw ? bw[4] : 0;
}
