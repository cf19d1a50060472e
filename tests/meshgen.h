/* SPDX-License-Identifier: Apache-2.0 */
/* Deterministic test meshes with exact answers (after lz4's datagen).
 * Generators return closed, consistently outward-oriented 2-manifolds with
 * shared vertices (CCW seen from outside). A zeroed tmesh is a valid empty
 * mesh; allocation failure aborts. Random meshes use splitmix64 and only
 * + - * / sqrt, so they are bit-identical on every IEEE machine. */
#ifndef CLVOX_MESHGEN_H
#define CLVOX_MESHGEN_H
#include <stddef.h>
#include <stdint.h>
#include "clvox.h"

typedef struct tmesh { float *xyz; size_t nv, cap_v; uint32_t *tri; size_t nt, cap_t; } tmesh;

void tmesh_free(tmesh *m);
uint32_t tmesh_add_vertex(tmesh *m, double x, double y, double z);
void tmesh_add_tri(tmesh *m, uint32_t a, uint32_t b, uint32_t c);
void tmesh_append(tmesh *dst, const tmesh *src); /* as a separate shell */
void tmesh_flip(tmesh *m);                       /* reverse orientation (cavities) */
void tmesh_translate(tmesh *m, double x, double y, double z);
double tmesh_volume(const tmesh *m); /* signed, divergence theorem, in double */
int tmesh_is_closed(const tmesh *m); /* each undirected edge used twice, opposite directions */
/* Writers return 0 on success. STL: 84 + 50 nt bytes; PLY: little endian,
 * float x y z, "list uchar int vertex_indices". */
int tmesh_write_off(const tmesh *m, const char *path);
int tmesh_write_obj(const tmesh *m, const char *path);
int tmesh_write_stl_binary(const tmesh *m, const char *path);
int tmesh_write_ply_binary(const tmesh *m, const char *path);

tmesh tmesh_box(double x0, double y0, double z0, double x1, double y1, double z1); /* 8 v, 12 t */
/* Faces split into n x n quads: 6n^2+2 vertices, 12n^2 triangles, lattice
 * coordinates lo + (hi-lo)*i/n (exactly lo and hi at the ends). */
tmesh tmesh_box_subdivided(double x0, double y0, double z0, double x1, double y1, double z1, unsigned n);
tmesh tmesh_tetra(const double a[3], const double b[3], const double c[3], const double d[3]); /* V > 0 */
tmesh tmesh_octahedron(double cx, double cy, double cz, double r); /* |x|+|y|+|z| <= r, V = 4r^3/3 */
/* UV sphere inscribed in radius r: n >= 2 latitude bands, 2n longitudes,
 * 2+2n(n-1) vertices, 4n(n-1) triangles; convex, its volume is exactly
 * tmesh_sphere_poly_volume (stacked frusta of regular 2n-gons). */
tmesh tmesh_sphere(double cx, double cy, double cz, double r, unsigned n);
double tmesh_sphere_volume(double r); /* 4/3 pi r^3 */
double tmesh_sphere_poly_volume(double r, unsigned n);
/* Around the z axis, R > r; nu segments around z, nv around the tube; vertices
 * on the surface, 2 nu nv triangles. Exact polyhedral volume (Pappus per
 * wedge): nu sin(2pi/nu) * nv/2 sin(2pi/nv) * R r^2. */
tmesh tmesh_torus(double cx, double cy, double cz, double R, double r, unsigned nu, unsigned nv);
double tmesh_torus_volume(double R, double r); /* 2 pi^2 R r^2 */
double tmesh_torus_poly_volume(double R, double r, unsigned nu, unsigned nv);
/* Outer sphere + inner one flipped (cavity). */
tmesh tmesh_hollow_sphere(double cx, double cy, double cz, double r_out, double r_in, unsigned n);

uint64_t tmesh_rng_next(uint64_t *state);  /* splitmix64; *state starts as the seed */
double tmesh_rng_uniform(uint64_t *state); /* [0,1), 53 bits */
/* `shells` disjoint star-shaped shells inside the open cube (0,1)^3, in general
 * position: each a subdivided cube (12n^2 triangles) projected radially with
 * a random radius per vertex, randomly rotated and offset. */
tmesh tmesh_random_closed(uint64_t seed, unsigned shells, unsigned n);
/* Two overlapping closed shells (self-intersecting, for parity rules), in
 * (0,1)^3, star-shaped around c1, c2 (written), |c1-c2| = 0.3, vertex radii in
 * [0.25,0.3]. For n >= 2 each holds the ball of radius 0.2 around its centre:
 * the midpoint is covered twice (even parity), c1 + (c1-c2)/2 once. */
tmesh tmesh_random_overlap(uint64_t seed, unsigned n, double c1[3], double c2[3]);

/* ---- broken meshes (winding-number tests, docs/design.md "Winding
 * numbers"): open, cracked, mis-oriented, overlapping, non-manifold. Not
 * closed or not consistently oriented on purpose; deterministic from the
 * seed; CCW seen from outside wherever an outside exists. ---- */
tmesh tmesh_copy(const tmesh *m);
/* Every triangle with its own three vertices (same coordinates). */
tmesh tmesh_soup(const tmesh *m);
/* Reverse triangle t only. */
void tmesh_flip_tri(tmesh *m, size_t t);
/* Undirected edges used once (boundary), by more than two triangles
 * (non-manifold), and directed edges used twice in the same direction
 * (orientation conflicts between two neighbours); by vertex index. */
void tmesh_edge_stats(const tmesh *m, uint64_t *boundary, uint64_t *nonmanifold, uint64_t *conflicts);
/* tmesh_box_subdivided(lo, hi, n) with `removed` (1..5) of its 6 faces left
 * out, which ones by the seed. Face f = 2*axis + (high side): triangles
 * [f*2n^2, (f+1)*2n^2) of the closed box. *mask (may be NULL) gets the
 * removed faces as bits. */
tmesh tmesh_open_box(uint64_t seed, const double lo[3], const double hi[3], unsigned n, unsigned removed,
                     unsigned *mask);
/* The upper half (z > cz) of tmesh_sphere(c, r, n), n even: open along the equator. */
tmesh tmesh_open_hemisphere(double cx, double cy, double cz, double r, unsigned n);
/* Cylinder along `axis` (0 x, 1 y, 2 z) from c[axis] to c[axis] + h, radius r
 * around c: seg segments, rows bands; caps: 1 closed (fans), 0 open tube. */
tmesh tmesh_cylinder(const double c[3], int axis, double r, double h, unsigned seg, unsigned rows, int caps);
/* tmesh_sphere with k distinct random triangles deleted (holes). */
tmesh tmesh_sphere_holes(uint64_t seed, double cx, double cy, double cz, double r, unsigned n, unsigned k);
/* tmesh_sphere with k distinct random triangles reversed (mis-oriented;
 * tmesh_sphere with the same arguments is the repaired mesh). */
tmesh tmesh_sphere_flipped(uint64_t seed, double cx, double cy, double cz, double r, unsigned n, unsigned k);
/* Box with each face's 4 corners its own vertices (2 triangles per face):
 * a soup of 6 quads. The first copy of each corner stays exact; every later
 * copy is moved by +-shift per axis with probability 1/2 (random signs), so
 * welding within > sqrt(3)*shift into the lowest-numbered vertex gives
 * exactly tmesh_box(lo, hi). */
tmesh tmesh_cracked_box(uint64_t seed, const double lo[3], const double hi[3], double shift);
/* CAD-like union in (0,1)^3: two boxes and two capped cylinders, each
 * closed and outward, every pair of parts that meets intersects (none lies
 * inside another); positions jittered by the seed (|jitter| <= 0.01). */
tmesh tmesh_cad_union(uint64_t seed);
/* Sphere + the same sphere moved by d along (1, 0.37, 0.21)/|.|: both closed, overlapping. */
tmesh tmesh_shifted_shells(double cx, double cy, double cz, double r, unsigned n, double d);
/* Moebius strip around the z axis: centre radius R, half width hw, nu
 * segments around (nu >= 3), nv across; non-orientable, open. */
tmesh tmesh_moebius(double cx, double cy, double cz, double R, double hw, unsigned nu, unsigned nv);
/* Three nested boxes around c (half sizes s[0] > s[1] > s[2] per axis, an
 * axis-dependent stretch): the outer one outward; the middle one inward
 * (a cavity) unless flags & 1 (then stored outward); the inner one outward
 * unless flags & 2 (then stored inward). flags = 0 is the repaired mesh. */
tmesh tmesh_nested_boxes(double cx, double cy, double cz, const double s[3], unsigned flags);
/* tmesh_sphere(c, r, n), n even, with a disk in the equator plane (z = cz)
 * sharing the equator vertices: 2n non-manifold edges (the equator, 3 triangles each). */
tmesh tmesh_sphere_membrane(double cx, double cy, double cz, double r, unsigned n);

/* Connected components of triangles across shared edges, vertices at
 * exactly equal positions merged first: label[t] in 0 .. count-1. */
size_t tmesh_components_of(const float *xyz, size_t nv, const uint32_t *tri, size_t nt, uint32_t *label);

/* The winding corpus (tests/test_winding.c, scripts/bench/bench_winding.sh), in
 * (0,1)^3: one of each generator above plus inverted, soup and cavity
 * cases. mesh is what the library gets; truth the mesh orientation repair
 * should arrive at, which the oracle evaluates (a copy of mesh when that is
 * consistently oriented already; nt == 0 when there is none: the Moebius
 * strip). Returns the count (at most max, else abort). */
typedef struct tmesh_case { const char *name; tmesh mesh, truth; } tmesh_case;
size_t tmesh_winding_corpus(tmesh_case *out, size_t max);
void tmesh_case_free(tmesh_case *c);

/* Voxel centres c with lo <= c < hi on every axis (design.md), evaluated as
 * the library does: corners rounded to float as in a tmesh, grid coordinate
 * (p - origin)/h - 0.5 in double rounded to float. For corners exact in grid
 * space this is exactly lo <= c < hi. */
uint64_t expected_box_voxels(const clvox_grid *g, const double lo[3], const double hi[3]);
/* Brute-force oracle: parity of the crossings of a ray from p towards +x with
 * a small generic tilt (majority of three tilts), in double. Independent, not
 * bit-exact; meaningless for p on or within ~1e-9 of the surface. */
int tmesh_point_inside(const tmesh *m, const double p[3]);
#endif
