/* SPDX-License-Identifier: Apache-2.0 */
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

/* ---- generalized winding numbers (Jacobson et al. 2013; docs/design.md
 * "Winding numbers") ----
 * w(p) = (1/4pi) * sum over triangles of the signed solid angle (van
 * Oosterom-Strackee, double), triangles as given: counter-clockwise seen from
 * outside = +1 inside a closed shell, -1 inside an inverted one; any soup,
 * open, overlapping or not. Meaningless on the surface. */
double ref_winding_number(const float *xyz, size_t nv, const uint32_t *tri, size_t nt, const double p[3]);
/* The same with double vertices (3 per vertex). */
double ref_winding_number_d(const double *xyz, size_t nv, const uint32_t *tri, size_t nt, const double p[3]);
/* Signed solid angle of triangle (a, b, c) seen from the origin (a, b, c are
 * the corners minus p; c may be a unit direction: a corner at infinity). */
double ref_solid_angle(const double a[3], const double b[3], const double c[3]);
/* An independent second formula for the same number: the signed crossings
 * of the +x ray from p (+1 where the ray leaves through a face whose normal
 * has positive x) plus (1/4pi) * sum over the boundary chain (directed edges
 * a->b with non-zero net multiplicity by vertex index, counted with it) of
 * the solid angle of the half-infinite strip a, b, infinity towards -x.
 * Plain double crossing test (no tie rule): p must be in general position. */
double ref_winding_number_rays(const double *xyz, size_t nv, const uint32_t *tri, size_t nt, const double p[3]);

/* The inside rules: w > 1/2 + 2^-30 (WINDING), |w| > 1/2 + 2^-30 (ABS). */
#define REF_WINDING_EPS 0x1p-30
int ref_winding_inside(double w, int abs_rule);

/* The space the library's winding test lives in, for voxel-exact
 * comparisons: the library rounds every vertex once to float in grid space,
 * g = (float)((x - origin)/h - 0.5) per axis (clvox__grid_space_soup), and
 * works on those floats. Solid angles are not invariant under anisotropic
 * scaling, so the oracle evaluates the SAME float grid-space vertices scaled
 * back per axis to an isotropic space: q = (double)g * h (exact in double),
 * where voxel centre (i, j, k) is (i*h0, j*h1, k*h2) and a sample at grid
 * position s is s*h. Returns nv*3 doubles (malloc). */
double *ref_winding_space(const float *xyz, size_t nv, const clvox_grid *g);

/* Brute force, every voxel centre against every triangle (O(voxels x
 * triangles)) in ref_winding_space: out[X*Y*Z] (x fastest) = inside by the
 * rule; w (may be NULL) receives each centre's w. */
void ref_winding_voxelize(const float *xyz, size_t nv, const uint32_t *tri, size_t nt, const clvox_grid *g,
                          int abs_rule, uint8_t *out, double *w);
/* Grey levels with the winding rule: the samples of ref_coverage (the same
 * positions: rays rounded to float, points in double; sampler.h), each
 * inside when its w is; counts[X*Y*Z]. Returns the number of samples with
 * |w - 1/2| < near (ties whose side the device may legitimately differ on). */
uint64_t ref_winding_coverage(const float *xyz, size_t nv, const uint32_t *tri, size_t nt, const clvox_grid *g,
                              clvox_axis axis, uint32_t N, uint32_t M, int stochastic, uint64_t seed, int abs_rule,
                              double near, uint32_t *counts);
/* The same voxels by the second formula (ref_winding_number_rays) in the
 * same space, fast enough for 128^3: per column the exact crossings of the
 * +x ray with the library's tie rule (grid space, as ref_voxelize; signed by
 * the normal's x), per centre the strips of the boundary chain, after
 * merging vertices at exactly equal positions (coincident opposite edges
 * cancel exactly). O(columns x triangles + voxels x boundary edges).
 * Returns the number of boundary edges used. */
size_t ref_winding_voxelize_rays(const float *xyz, size_t nv, const uint32_t *tri, size_t nt, const clvox_grid *g,
                                 int abs_rule, uint8_t *out, double *w);
