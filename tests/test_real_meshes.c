/* SPDX-License-Identifier: Apache-2.0 */
/* Real meshes from Debian's libcgal-demo (fetched by scripts/fetch_meshes.sh
 * into data/meshes/): the OpenCL result equals the CPU reference bit for
 * bit, and closed meshes give the same occupancy along x, y and z. */
#include "reference.h"
#include "test.h"

#include <math.h>
#include <string.h>
#include <unistd.h>

static clvox_context *ctx;

static size_t nvox(const clvox_grid *g) { return (size_t)g->dims[0] * g->dims[1] * g->dims[2]; }

static void check_mesh(const char *name, uint32_t n, int closed_expected)
{
    char path[256];
    snprintf(path, sizeof path, "data/meshes/%s", name);
    if (access(path, R_OK) != 0) {
        fprintf(stderr, "missing %s (run scripts/fetch_meshes.sh): counted as a failure\n", path);
        CHECK(access(path, R_OK) == 0);
        return;
    }
    clvox_mesh *m = NULL;
    CHECK_OK(ctx, clvox_mesh_load(ctx, path, &m));
    if (!m) return;
    const clvox_mesh_report *r = clvox_mesh_get_report(m);
    CHECK_MSG(r->closed == closed_expected, "%s: closed=%d, expected %d (%llu boundary edges)", name, r->closed,
              closed_expected, (unsigned long long)r->boundary_edges);
    clvox_grid g = test_padded_grid(ctx, r, n);
    size_t nv, nt;
    const float *xyz = clvox_mesh_vertices(m, &nv);
    const uint32_t *tri = clvox_mesh_triangles(m, &nt);
    clvox_grid gref = test_reference_grid(m, &g);
    uint8_t *ref = malloc(nvox(&g)), *dev[3];
    for (int a = 0; a < 3; a++) {
        clvox_axis axis = (clvox_axis)(CLVOX_AXIS_X + a);
        dev[a] = calloc(nvox(&g), 1);
        clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
        o.ray_axis = axis;
        o.inside = CLVOX_INSIDE_PARITY; /* the reference is parity (self-intersecting meshes differ) */
        clvox_stats s = CLVOX_STATS_INIT;
        CHECK_OK(ctx, clvox_voxelize_to_memory(ctx, m, &g, &o, dev[a], nvox(&g), &s));
        uint64_t odd = ref_voxelize(xyz, nv, tri, nt, &gref, axis, ref);
        size_t diff = 0;
        for (size_t i = 0; i < nvox(&g); i++) diff += dev[a][i] != ref[i];
        CHECK_MSG(diff == 0, "%s at %u axis %c: %zu voxels differ from the CPU reference", name, n, "xyz"[a], diff);
        CHECK_MSG(s.odd_parity_rays == odd, "%s: %llu odd rays, reference %llu", name,
                  (unsigned long long)s.odd_parity_rays, (unsigned long long)odd);
        if (closed_expected) CHECK_MSG(odd == 0, "%s is closed but has %llu odd-parity rays", name, (unsigned long long)odd);
    }
    if (closed_expected) {
        size_t dxy = 0, dxz = 0;
        for (size_t i = 0; i < nvox(&g); i++) dxy += dev[0][i] != dev[1][i], dxz += dev[0][i] != dev[2][i];
        CHECK_MSG(dxy == 0 && dxz == 0, "%s: x/y rays differ on %zu voxels, x/z on %zu", name, dxy, dxz);
    }
    for (int a = 0; a < 3; a++) free(dev[a]);
    free(ref);
    clvox_mesh_destroy(m);
}

/* Grey levels on a real mesh: the device equals the CPU reference (stochastic,
 * every point against every crossing), and the estimated volume converges to
 * the enclosed volume as K grows. */
static void check_coverage(const char *name, uint32_t n)
{
    char path[256];
    snprintf(path, sizeof path, "data/meshes/%s", name);
    clvox_mesh *m = NULL;
    if (access(path, R_OK) != 0 || clvox_mesh_load(ctx, path, &m) != CLVOX_OK) {
        CHECK_MSG(0, "cannot load %s", path);
        return;
    }
    const clvox_mesh_report *r = clvox_mesh_get_report(m);
    clvox_grid g = test_padded_grid(ctx, r, n);
    size_t nv, nt;
    const float *xyz = clvox_mesh_vertices(m, &nv);
    const uint32_t *tri = clvox_mesh_triangles(m, &nt);
    float *cov = malloc(nvox(&g) * sizeof *cov);
    uint32_t *ref = malloc(nvox(&g) * sizeof *ref);
    clvox_voxelize_options o = CLVOX_VOXELIZE_OPTIONS_INIT;
    o.oversample = 2;
    o.oversample_points = 3;
    o.stochastic = 1;
    o.seed = 99;
    o.inside = CLVOX_INSIDE_PARITY;
    CHECK_OK(ctx, clvox_voxelize_to_buffers(ctx, m, &g, &o, NULL, 0, cov, nvox(&g), NULL));
    clvox_grid gref = test_reference_grid(m, &g);
    ref_coverage(xyz, nv, tri, nt, &gref, CLVOX_AXIS_X, 2, 3, 1, 99, ref);
    size_t diff = 0;
    for (size_t i = 0; i < nvox(&g); i++) diff += cov[i] != (float)ref[i] / 12.0f;
    CHECK_MSG(diff == 0, "%s at %u: %zu coverage values differ from the CPU reference", name, n, diff);
    const double vv = g.voxel_size[0] * g.voxel_size[1] * g.voxel_size[2];
    double err[4];
    for (int k = 0; k < 4; k++) {
        clvox_voxelize_options u = CLVOX_VOXELIZE_OPTIONS_INIT;
        u.oversample = 1u << k;
        clvox_stats s = CLVOX_STATS_INIT;
        CHECK_OK(ctx, clvox_voxelize_to_buffers(ctx, m, &g, &u, NULL, 0, cov, nvox(&g), &s));
        err[k] = fabs(s.coverage_sum * vv - r->enclosed_volume) / r->enclosed_volume;
        printf("%s at %u, K=%u: relative volume error %.2e\n", name, n, 1u << k, err[k]);
    }
    CHECK_MSG(err[3] < err[0] && err[3] < 2e-3, "%s: volume errors %.2e (K=1) .. %.2e (K=8)", name, err[0], err[3]);
    free(cov);
    free(ref);
    clvox_mesh_destroy(m);
}

int main(void)
{
    if (getenv("CLVOX_QUICK")) {
        printf("quick run: real meshes skipped\n0 passed, 0 failed\n");
        return 0;
    }
    ctx = test_context();
    check_mesh("cow.off", 96, 1);
    check_mesh("bunny00.off", 64, 1);
    check_mesh("armadillo.off", 64, 1);
    check_mesh("knot1.off", 64, 1);
    check_mesh("ChineseDragon-10kv.off", 48, 0); /* has boundary edges on purpose */
    check_coverage("cow.off", 32);
    check_coverage("armadillo.off", 24);
    clvox_context_destroy(ctx);
    return test_report();
}
