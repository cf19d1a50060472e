/* SPDX-License-Identifier: Apache-2.0 */
/* The certified crack weld (src/winding/crack_weld.c, issue 35).
 *
 * 1. The weld pairs' bound, on the device: trees of pairs (T, T' = T moved
 *    by up to delta: each corner at random, the whole triangle along its
 *    normal or in its plane, or collapsed), every node seen from points
 *    outside its box and off its slab at many distances. The node's exact
 *    value (its caps rev T and T', kernels/winding_inside.h) must equal the
 *    brute-force sum of Omega(T') - Omega(T) over its pairs (ref_solid_angle),
 *    its estimate must be 0 and its bound at least that value. The worst
 *    ratio value / bound is printed, and must be above 0.1: a bound made
 *    10 times too small would fail.
 * 2. Whole runs, weld on and off (the CLVOX_CRACK_WELD switch): the same
 *    voxels on jittered soups of a sphere and a torus (and one with faces
 *    removed: still open after welding), for w > 1/2, |w| > 1/2 and
 *    coverage; the weld used exactly when it should be (not with an
 *    explicit weld, not on a closed mesh, not on a soup facing inwards).
 * Voxel-for-voxel agreement with the exact winding number of soups is
 * test_winding_soups'. */
#include "core/environment.h" /* src/: the switches (internal) */
#include "meshgen.h"
#include "reference.h"
#include "test.h"
#include "winding/winding.h" /* src/: the cap tree (internal) */

#include <math.h>
#include <string.h>

static clvox_context *ctx;
#define PI 3.14159265358979323846

/* ---- 1. the pairs' bound -------------------------------------------------- */

static void put_pair(float *out, size_t *n, const double t[9], const double w[9])
{
    for (int k = 0; k < 9; k++) out[18 * *n + k] = (float)t[k], out[18 * *n + 9 + k] = (float)w[k];
    (*n)++;
}

/* Pairs of kind `kind` with displacement delta (grid space). */
static size_t make_pairs(int kind, double delta, float *out, size_t max, uint64_t *s)
{
    size_t n = 0;
    if (kind == 0) { /* a flat strip of a grid, moved along its normal: the leaves' slabs are thin */
        for (int i = 0; i < 12 && n + 2 <= max; i++)
            for (int j = 0; j < 2 && n + 2 <= max; j++) {
                const double x = 4 + 1.5 * i, y = 6 + 1.5 * j, z = 9;
                const double a[9] = {x, y, z, x + 1.5, y, z, x + 1.5, y + 1.5, z};
                const double b[9] = {x, y, z, x + 1.5, y + 1.5, z, x, y + 1.5, z};
                double wa[9], wb[9];
                for (int k = 0; k < 9; k++) wa[k] = a[k] + (k % 3 == 2 ? delta : 0), wb[k] = b[k] + (k % 3 == 2 ? delta : 0);
                put_pair(out, &n, a, wa);
                put_pair(out, &n, b, wb);
            }
        return n;
    }
    for (int t = 0; t < 48 && n < max; t++) {
        double c[3], v[9], w[9];
        for (int k = 0; k < 3; k++) c[k] = 20 * tmesh_rng_uniform(s);
        for (int k = 0; k < 9; k++) v[k] = c[k % 3] + 3 * (tmesh_rng_uniform(s) - 0.5);
        if (kind == 1) { /* each corner at random within delta */
            for (int k = 0; k < 3; k++) {
                double u[3], l;
                do {
                    l = 0;
                    for (int a = 0; a < 3; a++) u[a] = 2 * tmesh_rng_uniform(s) - 1, l += u[a] * u[a];
                } while (l > 1 || l < 1e-4);
                for (int a = 0; a < 3; a++) w[3 * k + a] = v[3 * k + a] + delta * u[a] / sqrt(l);
            }
        } else { /* kind 2: along the normal; 3: in the plane, along an edge; 4: collapsed (c onto b) */
            double e1[3], e2[3], nrm[3], l = 0, m = 0;
            for (int a = 0; a < 3; a++) e1[a] = v[3 + a] - v[a], e2[a] = v[6 + a] - v[a];
            nrm[0] = e1[1] * e2[2] - e1[2] * e2[1], nrm[1] = e1[2] * e2[0] - e1[0] * e2[2],
            nrm[2] = e1[0] * e2[1] - e1[1] * e2[0];
            for (int a = 0; a < 3; a++) l += nrm[a] * nrm[a], m += e1[a] * e1[a];
            for (int k = 0; k < 9; k++) {
                const int a = k % 3;
                w[k] = v[k] + (kind == 2 ? delta * nrm[a] / sqrt(l) : kind == 3 ? delta * e1[a] / sqrt(m) : 0);
            }
            if (kind == 4) { /* c moves onto b, b and a stay: a collapse by up to the edge's length */
                for (int a = 0; a < 3; a++) w[6 + a] = v[3 + a];
            }
        }
        put_pair(out, &n, v, w);
    }
    return n;
}

/* Omega(T') - Omega(T) / 4pi, brute force. */
static double pair_value(const float *pr, const double p[3], const double h[3])
{
    double w = 0;
    for (int t = 0; t < 2; t++) {
        double A[3], B[3], C[3];
        for (int a = 0; a < 3; a++) {
            A[a] = (double)pr[9 * t + a] * h[a] - p[a];
            B[a] = (double)pr[9 * t + 3 + a] * h[a] - p[a];
            C[a] = (double)pr[9 * t + 6 + a] * h[a] - p[a];
        }
        const double om = ref_solid_angle(A, B, C) / (4 * PI);
        w += t ? om : -om;
    }
    return w;
}

static void test_pair_bounds(void)
{
    if (ctx->real_size != 8) {
        printf("pair bounds: skipped (the device has no double)\n");
        return;
    }
    static const char *const kinds[] = {"flat strip", "corners at random", "along the normal", "in the plane",
                                        "collapsed"};
    static const double deltas[] = {1e-5, 1e-3, 0.05};
    static const double ratio[] = {0.02, 0.05, 0.1, 0.2, 0.4, 0.7, 1, 1.5, 2, 3, 5, 10, 30};
    const size_t nr = sizeof ratio / sizeof ratio[0], dirs = 4;
    const double h[3] = {0.9, 1.1, 1.3};
    cl_kernel k = NULL;
    CHECK_OK(ctx, clvox__kernel(ctx, "clvox_winding_probe", &k));
    if (!k) return;
    uint64_t seed = 0x9a125eed;
    double worst_all = 0;
    for (int kind = 0; kind < 5; kind++)
        for (size_t di = 0; di < sizeof deltas / sizeof deltas[0]; di++) {
            if (kind == 4 && di > 0) continue; /* a collapse does not scale with delta */
            float pairs[18 * 64];
            const size_t np = make_pairs(kind, deltas[di], pairs, 64, &seed);
            clvox_grid grid;
            memset(&grid, 0, sizeof grid);
            for (int a = 0; a < 3; a++) grid.voxel_size[a] = h[a];
            clvox__caps caps;
            CHECK_OK(ctx, clvox__caps_upload_pairs(ctx, NULL, 0, pairs, np, clvox__axes_for(CLVOX_AXIS_X), &grid, &caps));
            const size_t nn = caps.node_count, npts = nn * (nr * dirs + nr);
            clvox_cap_node *nodes = malloc(nn * sizeof *nodes);
            double *tris = malloc(np * 18 * sizeof *tris), *pts = malloc(npts * 3 * sizeof *pts),
                   *res = malloc(npts * 12 * sizeof *res);
            cl_uint *node_of = malloc(npts * sizeof *node_of);
            CHECK(nodes && tris && pts && res && node_of);
            cl_int e = clEnqueueReadBuffer(ctx->queue, caps.nodes, CL_TRUE, 0, nn * sizeof *nodes, nodes, 0, NULL, NULL);
            e |= clEnqueueReadBuffer(ctx->queue, caps.tris, CL_TRUE, 0, np * 18 * sizeof *tris, tris, 0, NULL, NULL);
            CHECK(e == CL_SUCCESS);
            CHECK_MSG(nodes[0].radius >= CLVOX_PAIR_RADIUS, "%s: the root is not a pair node", kinds[kind]);
            size_t at = 0;
            for (size_t j = 0; j < nn; j++) {
                const clvox_cap_node *nd = &nodes[j];
                double c[3], half = 0;
                for (int a = 0; a < 3; a++) c[a] = 0.5 * (nd->lo[a] + nd->hi[a]), half += 0.25 * (nd->hi[a] - nd->lo[a]) * (nd->hi[a] - nd->lo[a]);
                half = sqrt(half);
                const double size = 2 * half > 0.5 ? 2 * half : 0.5;
                /* outside the box's sphere, at t x its diameter */
                for (size_t i = 0; i < nr; i++)
                    for (size_t r = 0; r < dirs; r++, at++) {
                        double u[3], l;
                        do {
                            l = 0;
                            for (int a = 0; a < 3; a++) u[a] = 2 * tmesh_rng_uniform(&seed) - 1, l += u[a] * u[a];
                        } while (l > 1 || l < 1e-4);
                        for (int a = 0; a < 3; a++) pts[3 * at + a] = c[a] + (half + ratio[i] * size) * u[a] / sqrt(l);
                        node_of[at] = (cl_uint)j;
                    }
                /* off the slab, over the middle of the node's first pair */
                for (size_t i = 0; i < nr; i++, at++) {
                    const double *t = tris + 9 * nd->tri_first + 0; /* rev T */
                    for (int a = 0; a < 3; a++)
                        pts[3 * at + a] = (t[a] + t[3 + a] + t[6 + a]) / 3 +
                                          (nd->normal4pi[a] != 0 ? nd->normal4pi[a] : (a == 2)) * ratio[i] * 0.5;
                    node_of[at] = (cl_uint)j;
                }
            }
            cl_int ce = CL_SUCCESS;
            cl_mem bn = clCreateBuffer(ctx->cl, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, npts * sizeof *node_of, node_of, &ce);
            cl_mem bp = clCreateBuffer(ctx->cl, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, npts * 3 * sizeof *pts, pts, &ce);
            cl_mem bo = clCreateBuffer(ctx->cl, CL_MEM_WRITE_ONLY, npts * 12 * sizeof *res, NULL, &ce);
            cl_uint cnt = (cl_uint)npts;
            e = clSetKernelArg(k, 0, sizeof(cl_mem), &caps.nodes);
            e |= clSetKernelArg(k, 1, sizeof(cl_mem), &caps.tris);
            e |= clSetKernelArg(k, 2, sizeof(cl_mem), &bn);
            e |= clSetKernelArg(k, 3, sizeof(cl_mem), &bp);
            e |= clSetKernelArg(k, 4, sizeof(cl_uint), &cnt);
            e |= clSetKernelArg(k, 5, sizeof(cl_mem), &bo);
            size_t global = npts;
            e |= clEnqueueNDRangeKernel(ctx->queue, k, 1, NULL, &global, NULL, 0, NULL, NULL);
            e |= clEnqueueReadBuffer(ctx->queue, bo, CL_TRUE, 0, npts * 12 * sizeof *res, res, 0, NULL, NULL);
            CHECK(ce == CL_SUCCESS && e == CL_SUCCESS);
            size_t bad = 0, inexact = 0, nonzero = 0, tested = 0;
            double worst = 0;
            for (size_t i = 0; i < npts; i++) {
                const clvox_cap_node *nd = &nodes[node_of[i]];
                const double *p = pts + 3 * i, *o = res + 12 * i;
                /* the pairs' value from the input floats (tris holds rev T, T' in scaled space) */
                double w = 0;
                for (uint32_t t = nd->tri_first; t < nd->tri_first + nd->tri_count; t++) {
                    double A[3], B[3], C[3];
                    for (int a = 0; a < 3; a++) {
                        A[a] = tris[9 * t + a] - p[a];
                        B[a] = tris[9 * t + 3 + a] - p[a];
                        C[a] = tris[9 * t + 6 + a] - p[a];
                    }
                    w -= ref_solid_angle(A, B, C) / (4 * PI); /* w = K - w_caps: the caps' value, negated */
                }
                if (o[0] != 0) nonzero++;
                if (!(fabs(o[6] + w) <= 1e-12)) inexact++;
                if (!(fabs(w) <= o[1] + 1e-13)) {
                    if (bad++ < 5)
                        fprintf(stderr, "  %s delta %g node %u: value %.17g, bound %.3g\n", kinds[kind], deltas[di],
                                node_of[i], w, o[1]);
                }
                if (o[1] < 0.5) {
                    tested++;
                    if (fabs(w) / o[1] > worst) worst = fabs(w) / o[1];
                }
            }
            /* the value from the pairs as given equals the tree's (rev T, T') */
            {
                double p0[3] = {-3, 2, 40}, w0 = 0, wt = 0;
                double sc[3]; /* the kernels' scale (clvox__winding_scale) */
                clvox__winding_scale(&grid, sc);
                for (size_t q = 0; q < np; q++) w0 += pair_value(pairs + 18 * q, p0, sc);
                for (size_t t = 0; t < 2 * np; t++) {
                    double A[3], B[3], C[3];
                    for (int a = 0; a < 3; a++) {
                        A[a] = tris[9 * t + a] - p0[a];
                        B[a] = tris[9 * t + 3 + a] - p0[a];
                        C[a] = tris[9 * t + 6 + a] - p0[a];
                    }
                    wt -= ref_solid_angle(A, B, C) / (4 * PI);
                }
                CHECK_MSG(fabs(w0 + wt) <= 1e-12 * (1 + fabs(w0)) || (kind == 4 && fabs(w0 + wt) <= 1e-9),
                          "%s: the tree's caps hold %.17g, the pairs %.17g", kinds[kind], -wt, w0);
            }
            CHECK_MSG(bad == 0, "%s delta %g: %zu of %zu values above their bound", kinds[kind], deltas[di], bad, npts);
            CHECK_MSG(inexact == 0, "%s delta %g: %zu exact node values differ from the brute-force sum", kinds[kind],
                      deltas[di], inexact);
            CHECK_MSG(nonzero == 0, "%s delta %g: %zu pair estimates not 0", kinds[kind], deltas[di], nonzero);
            printf("pair bounds %-18s delta %-6g %2zu pairs, %3zu nodes, %5zu points (%5zu with bound < 1/2): "
                   "|value| / bound at most %.3f\n",
                   kinds[kind], deltas[di], np, nn, npts, tested, worst);
            if (worst > worst_all) worst_all = worst;
            clReleaseMemObject(bn);
            clReleaseMemObject(bp);
            clReleaseMemObject(bo);
            clvox__caps_release(&caps);
            free(nodes);
            free(tris);
            free(pts);
            free(res);
            free(node_of);
        }
    CHECK_MSG(worst_all > 0.1, "the pairs' bound is more than 10 times loose everywhere (worst ratio %.3f)", worst_all);
    printf("pair bounds: worst |value| / bound %.3f (a bound 10 times smaller fails)\n", worst_all);
    clReleaseKernel(k);
}

/* ---- 2. whole runs, weld on and off --------------------------------------- */

/* The triangles of t as a soup (3 vertices each), jittered by rel x extent
 * (seeded), without every `drop`-th triangle (0: none). */
static clvox_mesh *soup_of(const tmesh *t, double rel, unsigned drop, int flip, uint64_t seed)
{
    float *xyz = malloc(t->nt * 9 * sizeof *xyz);
    uint32_t *tri = malloc(t->nt * 3 * sizeof *tri);
    CHECK(xyz && tri);
    double lo = INFINITY, hi = -INFINITY;
    for (size_t i = 0; i < t->nv * 3; i++) lo = fmin(lo, t->xyz[i]), hi = fmax(hi, t->xyz[i]);
    size_t n = 0;
    for (size_t f = 0; f < t->nt; f++) {
        if (drop && f % drop == drop / 2) continue;
        for (int c = 0; c < 3; c++) {
            const uint32_t v = t->tri[3 * f + (flip && c ? 3 - c : c)];
            for (int a = 0; a < 3; a++)
                xyz[9 * n + 3 * c + a] = (float)(t->xyz[3 * v + a] + (2 * tmesh_rng_uniform(&seed) - 1) * rel * (hi - lo));
            tri[3 * n + c] = (uint32_t)(3 * n + c);
        }
        n++;
    }
    clvox_mesh *m = NULL;
    CHECK_OK(ctx, clvox_mesh_from_arrays(ctx, xyz, 3 * n, tri, n, &m));
    free(xyz);
    free(tri);
    return m;
}

static uint8_t *run(const clvox_mesh *m, const clvox_grid *g, const clvox_voxelize_options *o, int weld_off,
                    clvox_stats *s)
{
    clvox__test_hooks h = *clvox__hooks(), saved = h;
    h.no_crack_weld = weld_off;
    clvox__set_test_hooks(&h);
    const size_t n = (size_t)g->dims[0] * g->dims[1] * g->dims[2];
    uint8_t *v = calloc(n, 1);
    CHECK(v != NULL);
    *s = (clvox_stats)CLVOX_STATS_INIT;
    CHECK_OK(ctx, clvox_voxelize_to_memory(ctx, m, g, o, v, n, s));
    clvox__set_test_hooks(&saved);
    return v;
}

static void same_both_ways(const char *what, const clvox_mesh *m, uint32_t N, const clvox_voxelize_options *o,
                           int expect_weld)
{
    clvox_grid g = test_padded_grid(ctx, clvox_mesh_get_report(m), N);
    const size_t n = (size_t)g.dims[0] * g.dims[1] * g.dims[2];
    clvox_stats on, off;
    uint8_t *a = run(m, &g, o, 0, &on), *b = run(m, &g, o, 1, &off);
    size_t diff = 0, filled = 0;
    for (size_t i = 0; i < n; i++) diff += a[i] != b[i], filled += a[i] != 0;
    printf("crack weld %-34s %ux%ux%u: %zu filled, %zu differ; on: %llu pairs, %llu welded, %llu of %llu holes left, "
           "%llu exact points; off: %llu exact points\n",
           what, g.dims[0], g.dims[1], g.dims[2], filled, diff, (unsigned long long)on.crack_pairs,
           (unsigned long long)on.crack_welded_vertices, (unsigned long long)on.crack_holes,
           (unsigned long long)on.winding.holes, (unsigned long long)on.winding.exact_points,
           (unsigned long long)off.winding.exact_points);
    CHECK_MSG(diff == 0, "%s: %zu voxels differ with the crack weld", what, diff);
    CHECK_MSG((on.crack_pairs > 0) == expect_weld, "%s: the crack weld was %sused", what, expect_weld ? "not " : "");
    CHECK_MSG(off.crack_pairs == 0, "%s: the crack weld was used when switched off", what);
    CHECK_MSG(!expect_weld || on.crack_weld_distance > 0, "%s: no weld distance reported", what);
    CHECK_MSG(on.winding.holes == off.winding.holes && on.winding.cap_triangles == off.winding.cap_triangles,
              "%s: the report is not the mesh's as given", what);
    free(a);
    free(b);
}

static void test_runs(void)
{
    tmesh sphere = tmesh_sphere(0, 0, 0, 10, 24), torus = tmesh_torus(1, 2, 3, 9, 3.5, 40, 20);
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    clvox_mesh *m;

    m = soup_of(&sphere, 1e-6, 0, 0, 1);
    same_both_ways("sphere soup, jitter 1e-6", m, 40, &o, 1);
    o.ray_axis = CLVOX_AXIS_Y;
    same_both_ways("sphere soup, jitter 1e-6, rays along y", m, 40, &o, 1);
    o.ray_axis = CLVOX_AXIS_Z; /* the z classify ORs bits across words */
    same_both_ways("sphere soup, jitter 1e-6, rays along z", m, 40, &o, 1);
    o.ray_axis = CLVOX_AXIS_X;
    o.inside = CLVOX_INSIDE_WINDING_ABS;
    same_both_ways("sphere soup, jitter 1e-6, |w|", m, 40, &o, 1);
    o = (clvox_voxelize_options)CLVOX_VOXELIZE_OPTIONS_INIT;
    o.oversample = 2;
    o.threshold_set = 1;
    same_both_ways("sphere soup, jitter 1e-6, coverage 2", m, 24, &o, 1);
    o = (clvox_voxelize_options)CLVOX_VOXELIZE_OPTIONS_INIT;
    o.weld = 1e-3; /* an explicit weld keeps its meaning: no crack weld */
    same_both_ways("sphere soup, --weld 1e-3", m, 24, &o, 0);
    o = (clvox_voxelize_options)CLVOX_VOXELIZE_OPTIONS_INIT;
    clvox_mesh_destroy(m);

    m = soup_of(&torus, 1e-5, 0, 0, 2);
    same_both_ways("torus soup, jitter 1e-5", m, 48, &o, 1);
    clvox_mesh_destroy(m);
    m = soup_of(&torus, 1e-6, 7, 0, 3);
    same_both_ways("torus soup, jitter 1e-6, 1/7 removed", m, 40, &o, 1);
    clvox_mesh_destroy(m);
    m = soup_of(&torus, 1e-6, 0, 1, 4); /* every triangle reversed: welded, it is turned outwards */
    same_both_ways("torus soup facing inwards", m, 32, &o, 0);
    clvox_mesh_destroy(m);
    m = NULL;
    CHECK_OK(ctx, clvox_mesh_from_arrays(ctx, torus.xyz, torus.nv, torus.tri, torus.nt, &m));
    same_both_ways("torus, closed", m, 32, &o, 0);
    clvox_mesh_destroy(m);
    tmesh_free(&sphere);
    tmesh_free(&torus);
}

int main(void)
{
    ctx = test_context();
    test_pair_bounds();
    test_runs();
    clvox_context_destroy(ctx);
    return test_report();
}
