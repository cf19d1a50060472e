/* SPDX-License-Identifier: Apache-2.0 */
/* The block lattice of the winding classify, host side
 * (kernels/winding_lattice.h): per slab, the blocks' bounds, and the near
 * caps of the blocks split near the rims with their sums at the blocks'
 * corners (clvox_winding_blocks), then the caps' solid angle at the lattice
 * points next to a usable or split block (clvox_winding_lattice), before
 * the slab's rays are classified. */
#include "winding_classify.h"
#include "core/environment.h"
#include "core/launch.h"

#include <string.h>

#define LATTICE_PLANES 32u     /* lattice points along the grid's largest side, about: S from it */
#define LATTICE_MIN_SIDE 192u  /* the grid's largest side from which the lattice is used */
#define LATTICE_BYTES ((uint64_t)64 << 20) /* a slab's points or blocks at most */

clvox_status clvox__winding_lattice_prepare(clvox_context *ctx, const clvox_grid *grid, int binary,
                                            clvox__winding_classify *w)
{
    double s[3];
    w->lattice_on = 0;
    /* Weld pairs have their own classify (no caps' solid angle to
     * interpolate); on voxels that are not cubes the points' scaled
     * coordinates are rounded, which the blocks' bounds do not take in. */
    const int hook = clvox__hooks()->lattice;
    if (!binary || w->caps.node_count == 0 || w->crack_pairs || !clvox__winding_scale(grid, s) || hook < 0)
        return CLVOX_OK;
    uint32_t m = grid->dims[0] > grid->dims[1] ? grid->dims[0] : grid->dims[1];
    if (grid->dims[2] > m) m = grid->dims[2];
    /* On smaller grids the voxels it decides were cheap along the rays
     * anyway and it cost more than it saved (2 cores, 128^3: 0-25 % slower
     * on elephant-with-holes, b9_mesh, nefertiti; 192^3: 5-15 % faster) */
    if (m < LATTICE_MIN_SIDE && hook == 0) return CLVOX_OK;
    uint32_t S = hook > 0 ? 4 : 8;
    while (S < 1024u && m / S > LATTICE_PLANES) S *= 2;
    w->lat[4] = S;
    clvox_status st = clvox__kernel(ctx, "clvox_winding_blocks", &w->k_blocks);
    if (st == CLVOX_OK) st = clvox__kernel(ctx, "clvox_winding_lattice", &w->k_lattice);
    if (st == CLVOX_OK) w->lattice_on = 1;
    return st;
}

/* Points 0, S, 2S .. covering [0, n - 1]. */
static uint32_t lattice_count(uint32_t n, uint32_t S) { return n < 2 ? 1u : (n - 1 + S - 1) / S + 1; }

/* A buffer of at least `bytes` in *m (grown, not shrunk). */
static clvox_status room(clvox_context *ctx, cl_mem *m, size_t bytes, const char *what)
{
    if (*m && clvox__mem_bytes(*m) >= bytes) return CLVOX_OK;
    clvox__release_mem(m);
    clvox_status st = CLVOX_OK;
    *m = clvox__buffer(ctx, CL_MEM_READ_WRITE, bytes, NULL, &st, what);
    return st;
}

clvox_status clvox__winding_lattice_slab(clvox_context *ctx, const clvox_grid *grid, clvox__winding_classify *w,
                                         uint32_t z0, uint32_t nz)
{
    w->lat[0] = 0;
    if (!w->lattice_on || nz == 0) return CLVOX_OK;
    const uint32_t S = w->lat[4];
    const uint32_t nx = lattice_count(grid->dims[0], S), ny = lattice_count(grid->dims[1], S);
    /* the planes around the slab's, and one more on either side where the
     * grid's lattice has it: a voxel on a lattice plane then finds the same
     * block whatever the slabs (clvox_lattice_inside takes the block above
     * it where there is one), so that the slabs' partition changes
     * nothing, not even which voxels are evaluated */
    const uint32_t nzg = lattice_count(grid->dims[2], S);
    uint32_t zl0 = z0 / S, zl1 = (z0 + nz - 1 + S - 1) / S + 1;
    if (zl0 > 0) zl0--;
    if (zl1 > nzg - 1) zl1 = nzg - 1;
    const uint32_t nzl = zl1 - zl0 + 1;
    if (nx < 2 || ny < 2 || nzl < 2) return CLVOX_OK;
    const uint64_t points = (uint64_t)nx * ny * nzl, blocks = (uint64_t)(nx - 1) * (ny - 1) * (nzl - 1);
    const uint64_t pb = points * 2 * ctx->real_size, bb = blocks * CLVOX_BLOCK_WORDS * ctx->real_size;
    /* an aid, not a need: none where it would take much memory (a 2048^3
     * grid's slab of 64 planes at S = 64: 0.6 MB) */
    uint64_t max = clvox__device_max_alloc(ctx) / 4;
    if (max > LATTICE_BYTES) max = LATTICE_BYTES;
    if (points > UINT32_MAX / 2 || pb > max || bb > max) return CLVOX_OK;
    const uint64_t sb = blocks * CLVOX_SPLIT_WORDS * ctx->real_size;
    const uint64_t nb = blocks * (CLVOX_NEAR_MAX + 1) * sizeof(cl_uint);
    if (sb > max || nb > max) return CLVOX_OK;
    clvox_status st = room(ctx, &w->lat_blocks, (size_t)bb, "winding lattice blocks");
    if (st == CLVOX_OK) st = room(ctx, &w->lat_points, (size_t)pb, "winding lattice points");
    if (st == CLVOX_OK) st = room(ctx, &w->lat_split, (size_t)sb, "winding lattice split blocks");
    if (st == CLVOX_OK) st = room(ctx, &w->lat_near, (size_t)nb, "winding lattice near caps");
    if (st != CLVOX_OK) return st;
    cl_uint axis = w->axis;
    cl_uint a = 0;
    cl_int err = 0;
    cl_kernel kb = w->k_blocks, kl = w->k_lattice;
    const cl_uint dims[5] = {nx, ny, nzl, zl0, S};
    err |= clSetKernelArg(kb, a++, sizeof(cl_mem), &w->caps.nodes);
    err |= clSetKernelArg(kb, a++, sizeof(cl_uint), &w->caps.node_count);
    err |= clSetKernelArg(kb, a++, sizeof(cl_mem), &w->caps.tris);
    err |= clSetKernelArg(kb, a++, sizeof(cl_mem), &w->caps.h);
    err |= clSetKernelArg(kb, a++, sizeof(cl_mem), &w->rims.nodes);
    err |= clSetKernelArg(kb, a++, sizeof(cl_uint), &w->rims.node_count);
    err |= clSetKernelArg(kb, a++, sizeof(cl_mem), &w->rims.tris);
    for (int i = 0; i < 5; i++) err |= clSetKernelArg(kb, a++, sizeof(cl_uint), &dims[i]);
    err |= clSetKernelArg(kb, a++, sizeof(cl_mem), &w->lat_blocks);
    err |= clSetKernelArg(kb, a++, sizeof(cl_mem), &w->caps.grid);
    err |= clSetKernelArg(kb, a++, sizeof(cl_uint), &axis);
    err |= clSetKernelArg(kb, a++, sizeof(cl_mem), &w->lat_split);
    err |= clSetKernelArg(kb, a++, sizeof(cl_mem), &w->lat_near);
    a = 0;
    err |= clSetKernelArg(kl, a++, sizeof(cl_mem), &w->caps.nodes);
    err |= clSetKernelArg(kl, a++, sizeof(cl_mem), &w->caps.tris);
    err |= clSetKernelArg(kl, a++, sizeof(cl_mem), &w->caps.grid);
    err |= clSetKernelArg(kl, a++, sizeof(cl_mem), &w->caps.h);
    err |= clSetKernelArg(kl, a++, sizeof(cl_uint), &axis);
    err |= clSetKernelArg(kl, a++, sizeof(cl_mem), &w->lat_blocks);
    for (int i = 0; i < 5; i++) err |= clSetKernelArg(kl, a++, sizeof(cl_uint), &dims[i]);
    err |= clSetKernelArg(kl, a++, sizeof(cl_mem), &w->lat_points);
    err |= clSetKernelArg(kl, a++, sizeof(cl_mem), &w->lat_split);
    if (err != CL_SUCCESS) return clvox__cl_fail(ctx, CL_INVALID_KERNEL_ARGS, "clSetKernelArg(winding lattice)");
    clvox__launch_begin(ctx);
    st = clvox__launch(ctx, kb, "clvox_winding_blocks", 0, (size_t)blocks, 16, NULL);
    if (st == CLVOX_OK) st = clvox__launch(ctx, kl, "clvox_winding_lattice", 0, (size_t)points, 16, NULL);
    if (st == CLVOX_OK) st = clvox__launch_check(ctx);
    if (st != CLVOX_OK) return st;
    memcpy(w->lat, dims, 4 * sizeof *dims);
    return CLVOX_OK;
}
