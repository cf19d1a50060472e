/* SPDX-License-Identifier: Apache-2.0 */
/* Stage palette scoring (Cavagnino & Gribaudo), host side
 * (src/cast/palette_score.c): the palette on the device and
 * kernels/palette_score.cl's arguments over the column runs' samples. */
#ifndef CLVOX_PALETTE_SCORE_H
#define CLVOX_PALETTE_SCORE_H
#include "coverage.h"

typedef struct clvox__palette_score {
    uint32_t n_elements;
    cl_mem elements, cells, planes, masks, volume;
    cl_uint axis;                /* the ray axis as clvox_axis (1..3) */
    cl_uint metric, early_out, sc_lo, sc_hi;
    cl_uint use_masks;           /* uniform samples: score with the precomputed element masks */
    char name[64];
    cl_kernel k;
} clvox__palette_score;

/* After clvox__coverage_prepare (c: the samples). */
clvox_status clvox__palette_score_prepare(clvox_context *ctx, clvox__palette_score *p, const clvox_voxelize_options *o,
                                          const clvox__coverage *c, clvox_axis axis);
void clvox__palette_score_release(clvox__palette_score *p);
clvox_status clvox__palette_score_enqueue(clvox_context *ctx, const clvox__palette_score *p, const clvox__coverage *c,
                                          const clvox__winding_classify *w, const clvox__batch_mem *m, cl_uint n_cols,
                                          const clvox__slab_target *t, cl_event *ev);
/* Adds an item's 4 tallies (early, shortcut, scored, non-empty voxels) and
 * its element volume (2^-32 voxels) to the slab's. */
void clvox__palette_tally(clvox__slab_stats *ss, const uint32_t *p, uint64_t volume);
#endif
