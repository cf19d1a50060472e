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
#endif
