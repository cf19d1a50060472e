/* Slow, obviously correct CPU reference of the ray method: every triangle is
 * tested against every voxel column, with the arithmetic of docs/design.md
 * ("The exact crossing test"), so the OpenCL result must match bit for bit. */
#ifndef CLVOX_REFERENCE_H
#define CLVOX_REFERENCE_H
#include <stddef.h>
#include <stdint.h>
#include "clvox.h"

/* out: X*Y*Z bytes (x fastest), 0/1. axis: CLVOX_AXIS_X/Y/Z (DEFAULT = X).
 * Returns the number of columns with an odd number of crossings. */
uint64_t ref_voxelize(const float *xyz, size_t nv, const uint32_t *tri, size_t nt, const clvox_grid *g,
                      clvox_axis axis, uint8_t *out);
/* Grey levels (sampler.h): counts[X*Y*Z] receives the number of each
 * voxel's N*N*M points that are inside (every point tested against every
 * crossing of its ray: no per-span shortcut). */
void ref_coverage(const float *xyz, size_t nv, const uint32_t *tri, size_t nt, const clvox_grid *g,
                  clvox_axis axis, uint32_t N, uint32_t M, int stochastic, uint64_t seed, uint32_t *counts);
/* Palette scoring (Cavagnino & Gribaudo, Table 1) of the same samples:
 * every element tested at every sample (no early-out, no masks, no pruning),
 * argmax with ties to the lowest index. element[X*Y*Z]; equal (may be NULL)
 * the winner's equivalence count, inside (may be NULL) the samples inside. */
void ref_palette(const float *xyz, size_t nv, const uint32_t *tri, size_t nt, const clvox_grid *g, clvox_axis axis,
                 uint32_t N, uint32_t M, int stochastic, uint64_t seed, const clvox_palette *pal, clvox_metric metric,
                 uint16_t *element, uint32_t *equal, uint32_t *inside);
/* Samples where `element` (X*Y*Z) breaks the metric: Outer, an object
 * sample outside the voxel's element; Inner, an empty one inside it. */
uint64_t ref_palette_violations(const float *xyz, size_t nv, const uint32_t *tri, size_t nt, const clvox_grid *g,
                                clvox_axis axis, uint32_t N, uint32_t M, int stochastic, uint64_t seed,
                                const clvox_palette *pal, clvox_metric metric, const uint16_t *element);
#endif
