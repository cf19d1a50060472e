/* SPDX-License-Identifier: Apache-2.0 */
#include "test.h"
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>

int test_passed, test_failed;

int test_report(void)
{
    printf("%d passed, %d failed\n", test_passed, test_failed);
    return test_failed ? 1 : 0;
}

clvox_context *test_context(void)
{
    clvox_context *ctx = NULL;
    clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
    clvox_status st = clvox_context_create(&o, &ctx);
    if (st != CLVOX_OK) {
        fprintf(stderr, "cannot create an OpenCL context: %s: %s\n", clvox_status_string(st),
                clvox_context_error(ctx));
        clvox_context_destroy(ctx);
        printf("0 passed, 1 failed\n");
        exit(1);
    }
    return ctx;
}

const char *test_tmpdir(void)
{
    const char *d = getenv("CLVOX_TEST_TMP");
    if (!d || !*d) d = "build/test-tmp";
    mkdir("build", 0777);
    mkdir(d, 0777);
    return d;
}

clvox_grid test_grid(const double lo[3], const double hi[3], uint32_t nx, uint32_t ny, uint32_t nz)
{
    clvox_grid g;
    uint32_t n[3] = {nx, ny, nz};
    for (int a = 0; a < 3; a++) {
        g.dims[a] = n[a];
        g.origin[a] = lo[a];
        g.voxel_size[a] = (hi[a] - lo[a]) / n[a];
    }
    return g;
}

clvox_grid test_padded_grid(clvox_context *ctx, const clvox_mesh_report *r, uint32_t n)
{
    clvox_grid_options go = CLVOX_GRID_OPTIONS_INIT;
    go.resolution = n;
    go.padding = 1;
    clvox_grid g;
    memset(&g, 0, sizeof g);
    CHECK_OK(ctx, clvox_grid_compute(ctx, &go, r->bbox_min, r->bbox_max, &g));
    return g;
}

clvox_grid test_reference_grid(const clvox_mesh *m, const clvox_grid *g)
{
    double off[3];
    clvox_mesh_vertex_offset(m, off);
    clvox_grid r = *g;
    for (int a = 0; a < 3; a++) r.origin[a] = g->origin[a] - off[a];
    return r;
}

double test_cpu_seconds(void)
{
    struct rusage u;
    if (getrusage(RUSAGE_SELF, &u) != 0) return 0.0;
    return (double)u.ru_utime.tv_sec + 1e-6 * (double)u.ru_utime.tv_usec + (double)u.ru_stime.tv_sec +
           1e-6 * (double)u.ru_stime.tv_usec;
}
