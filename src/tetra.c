/* Placeholder until the tetra method lands (issue 3): reports clearly. */
#include "internal.h"

static clvox_status tetra_prepare(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                  const clvox_voxelize_options *opts, uint32_t slab_depth, clvox_stats *stats,
                                  clvox__method_state **out)
{
    (void)mesh; (void)grid; (void)opts; (void)slab_depth; (void)stats;
    *out = NULL;
    return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "method tetra is not available in this build");
}
static clvox_status tetra_slab(clvox__method_state *st, uint32_t z0, uint32_t nz, cl_mem out, clvox__slab_stats *ss)
{
    (void)st; (void)z0; (void)nz; (void)out; (void)ss;
    return CLVOX_ERR_INTERNAL;
}
static void tetra_release(clvox__method_state *st) { (void)st; }
static void tetra_describe(const clvox__method_state *st, char *buf, size_t size)
{
    (void)st;
    if (size) buf[0] = 0;
}
const clvox__method clvox__method_tetra = {"tetra", tetra_prepare, tetra_slab, tetra_release, tetra_describe};
