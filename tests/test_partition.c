/* SPDX-License-Identifier: Apache-2.0 */
/* The partition on several host threads (src/grid/grid.c, src/grid/partition.c): the
 * grid-space soup and the quadtree at 1, 2, 3 and 4 threads are the same,
 * built from the soup or from the indexed triangles (grid-space vertices and
 * the mesh's index array, the cast's input),
 * float for float and node for node (same nodes, same references in the
 * same order), as the one-thread build before threads came in (its code is
 * kept below as the reference), on generated meshes and the CGAL meshes, at
 * several grids, ray axes, depths and leaf sizes. */
#include "test.h"
#include "core/environment.h"
#include "meshgen.h"
#include "core/internal.h"

#include <dirent.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static clvox_context *tctx;
static int compared;

/* ---- the one-thread build as it was (reference) ---- */

typedef struct old_build {
    clvox_context *ctx;
    const float *box;      /* 4 floats per triangle: v0, w0, v1, w1 */
    uint32_t max_depth, leaf_size;
    clvox_qt_node *nodes;
    size_t node_count, node_cap;
    uint32_t *refs;
    size_t ref_count, ref_cap;
    uint32_t depth;
    size_t leaves;
} old_build;

/* At most this many references in all (4 bytes each): past it, nodes stay leaves. */
#define OLD_MAX_REFS ((size_t)1 << 28)

static int old_grow(void **p, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap) return 1;
    size_t n = *cap ? *cap : 1024;
    while (n < need) n *= 2;
    void *q = realloc(*p, n * elem);
    if (!q) return 0;
    *p = q;
    *cap = n;
    return 1;
}

static clvox_status old_build_node(old_build *b, size_t node, const uint32_t *tris, size_t n, float v0, float w0,
                               float v1, float w1, uint32_t depth)
{
    if (depth > b->depth) b->depth = depth;
    float sv = 0.5f * (v0 + v1), sw = 0.5f * (w0 + w1);
    int leaf = n <= b->leaf_size || depth >= b->max_depth;
    if (!leaf) { /* does a split separate the triangles? (children's sizes, one pass) */
        size_t sum = 0;
        for (size_t i = 0; i < n; i++) {
            const float *bb = b->box + (size_t)tris[i] * 4;
            unsigned cv = (bb[0] <= sv) + (bb[2] >= sv), cw = (bb[1] <= sw) + (bb[3] >= sw);
            sum += cv * cw; /* quadrants touched: 1, 2 or 4 */
        }
        leaf = sum >= 3 * n || b->ref_count + sum > OLD_MAX_REFS;
    }
    if (leaf) {
        if (!old_grow((void **)&b->refs, &b->ref_cap, b->ref_count + n, sizeof *b->refs))
            return clvox__fail(b->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory building the quadtree");
        b->nodes[node].first = (uint32_t)b->ref_count;
        b->nodes[node].count = (uint32_t)n;
        b->nodes[node].split_v = b->nodes[node].split_w = 0;
        if (n) memcpy(b->refs + b->ref_count, tris, n * sizeof *tris);
        b->ref_count += n;
        b->leaves++;
        if (b->ref_count > 0xFFFFFFF0u)
            return clvox__fail(b->ctx, CLVOX_ERR_OUT_OF_MEMORY, "quadtree holds more than 2^32 references");
        return CLVOX_OK;
    }
    if (!old_grow((void **)&b->nodes, &b->node_cap, b->node_count + 4, sizeof *b->nodes))
        return clvox__fail(b->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory building the quadtree");
    size_t first = b->node_count;
    b->node_count += 4;
    b->nodes[node].split_v = sv;
    b->nodes[node].split_w = sw;
    b->nodes[node].first = (uint32_t)first;
    b->nodes[node].count = CLVOX_QT_INTERNAL;

    uint32_t *sub = malloc((n ? n : 1) * sizeof *sub);
    if (!sub) return clvox__fail(b->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory building the quadtree");
    clvox_status st = CLVOX_OK;
    for (int q = 0; q < 4 && st == CLVOX_OK; q++) {
        /* Child q: v in [v0,sv] or [sv,v1], w likewise (closed). */
        float cv0 = (q & 1) ? sv : v0, cv1 = (q & 1) ? v1 : sv;
        float cw0 = (q & 2) ? sw : w0, cw1 = (q & 2) ? w1 : sw;
        size_t m = 0;
        for (size_t i = 0; i < n; i++) {
            const float *bb = b->box + (size_t)tris[i] * 4;
            if (bb[0] <= cv1 && bb[2] >= cv0 && bb[1] <= cw1 && bb[3] >= cw0) sub[m++] = tris[i];
        }
        st = old_build_node(b, first + q, sub, m, cv0, cw0, cv1, cw1, depth + 1);
    }
    free(sub);
    return st;
}

static clvox_status old_quadtree_build(clvox_context *ctx, const float *soup, size_t tri_count, uint32_t dim_v,
                                   uint32_t dim_w, uint32_t max_depth, uint32_t leaf_size, clvox__quadtree *out)
{
    memset(out, 0, sizeof *out);
    if (tri_count > 0xFFFFFFF0u)
        return clvox__fail(ctx, CLVOX_ERR_MESH_INVALID, "more than 2^32 triangles");
    old_build b = {.ctx = ctx, .max_depth = max_depth ? max_depth : clvox__quadtree_auto_depth(dim_v, dim_w, tri_count),
               .leaf_size = leaf_size ? leaf_size : 8};
    if (b.max_depth > 16) b.max_depth = 16;
    float v0 = -0.5f, w0 = -0.5f, v1 = (float)dim_v - 0.5f, w1 = (float)dim_w - 0.5f;
    float *box = malloc((tri_count ? tri_count : 1) * 4 * sizeof *box);
    uint32_t *root = malloc((tri_count ? tri_count : 1) * sizeof *root);
    b.nodes = malloc(1024 * sizeof *b.nodes);
    b.node_cap = 1024;
    if (!box || !root || !b.nodes) {
        free(box);
        free(root);
        free(b.nodes);
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory building the quadtree");
    }
    b.box = box;
    size_t n = 0;
    for (size_t t = 0; t < tri_count; t++) {
        const float *p = soup + t * 9;
        float lv = fminf(p[1], fminf(p[4], p[7])), hv = fmaxf(p[1], fmaxf(p[4], p[7]));
        float lw = fminf(p[2], fminf(p[5], p[8])), hw = fmaxf(p[2], fmaxf(p[5], p[8]));
        /* Widen by a few ulps of the coordinates: the crossing test works on
         * rounded differences, so be conservative. */
        float ev = 1e-5f * (1.0f + fmaxf(fabsf(lv), fabsf(hv)));
        float ew = 1e-5f * (1.0f + fmaxf(fabsf(lw), fabsf(hw)));
        box[t * 4 + 0] = lv - ev;
        box[t * 4 + 1] = lw - ew;
        box[t * 4 + 2] = hv + ev;
        box[t * 4 + 3] = hw + ew;
        if (box[t * 4 + 0] <= v1 && box[t * 4 + 2] >= v0 && box[t * 4 + 1] <= w1 && box[t * 4 + 3] >= w0)
            root[n++] = (uint32_t)t;
    }
    b.node_count = 1;
    clvox_status st = old_build_node(&b, 0, root, n, v0, w0, v1, w1, 0);
    free(box);
    free(root);
    if (st != CLVOX_OK) {
        free(b.nodes);
        free(b.refs);
        return st;
    }
    if (!b.refs) { /* no triangle over the plane: keep one valid element */
        b.refs = calloc(1, sizeof *b.refs);
        if (!b.refs) {
            free(b.nodes);
            return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory building the quadtree");
        }
    }
    out->nodes = b.nodes;
    out->node_count = b.node_count;
    out->refs = b.refs;
    out->ref_count = b.ref_count;
    out->depth = b.depth;
    out->leaf_count = b.leaves;
    return CLVOX_OK;
}


/* ---- comparisons ---- */

static int same_tree(const clvox__quadtree *a, const clvox__quadtree *b)
{
    return a->node_count == b->node_count && a->ref_count == b->ref_count && a->depth == b->depth &&
           a->leaf_count == b->leaf_count && !memcmp(a->nodes, b->nodes, a->node_count * sizeof *a->nodes) &&
           !memcmp(a->refs, b->refs, (a->ref_count ? a->ref_count : 1) * sizeof *a->refs);
}

static void compare_mesh(const char *what, const clvox_mesh *m, uint32_t resolution, clvox_axis axis,
                         uint32_t max_depth, uint32_t leaf_size)
{
    const clvox_mesh_report *r = clvox_mesh_get_report(m);
    clvox_grid_options go = CLVOX_GRID_OPTIONS_INIT;
    go.resolution = resolution;
    clvox_grid g;
    if (clvox_grid_compute(tctx, &go, r->bbox_min, r->bbox_max, &g) != CLVOX_OK) return; /* flat meshes */
    clvox__axes ax = clvox__axes_for(axis);
    uint32_t dv = g.dims[ax.perm[1]], dw = g.dims[ax.perm[2]];
    size_t nt = m->triangle_count;
    float *soup1 = NULL;
    CHECK_OK(tctx, clvox__grid_space_soup_threads(tctx, m, &g, ax, 1, &soup1));
    if (!soup1) return;
    clvox__quadtree ref;
    CHECK_OK(tctx, old_quadtree_build(tctx, soup1, nt, dv, dw, max_depth, leaf_size, &ref));
    for (int threads = 1; threads <= 4; threads++) {
        float *soup = NULL;
        CHECK_OK(tctx, clvox__grid_space_soup_threads(tctx, m, &g, ax, threads, &soup));
        CHECK_MSG(soup && !memcmp(soup, soup1, nt * 9 * sizeof *soup), "%s: soup differs at %d threads", what,
                  threads);
        /* the soup's vertices alone: every soup corner is its vertex's floats */
        float *gv = NULL;
        CHECK_OK(tctx, clvox__grid_space_vertices(tctx, m, &g, ax, threads, &gv));
        int corners_ok = gv != NULL;
        for (size_t t = 0; corners_ok && t < nt; t++)
            for (int c = 0; c < 3; c++)
                if (memcmp(soup1 + t * 9 + c * 3, gv + (size_t)m->tris[t * 3 + c] * 3, 3 * sizeof *gv)) corners_ok = 0;
        CHECK_MSG(corners_ok, "%s: grid-space vertices differ from the soup's corners at %d threads", what, threads);
        /* the tree from the soup and from the indexed triangles */
        for (int indexed = 0; indexed <= 1 && gv; indexed++) {
            clvox__quadtree qt;
            CHECK_OK(tctx, clvox__quadtree_build_threads(tctx, indexed ? gv : soup1, indexed ? m->tris : NULL, nt, dv,
                                                         dw, max_depth, leaf_size, threads, &qt));
            CHECK_MSG(same_tree(&qt, &ref),
                      "%s (%u, axis %d, depth %u, leaf %u), %d threads, %s: %zu/%zu nodes %zu/%zu refs depth %u/%u "
                      "leaves %zu/%zu", what, resolution, (int)axis, max_depth, leaf_size, threads,
                      indexed ? "indexed" : "soup", qt.node_count, ref.node_count, qt.ref_count, ref.ref_count,
                      qt.depth, ref.depth, qt.leaf_count, ref.leaf_count);
            clvox__quadtree_free(&qt);
        }
        free(gv);
        free(soup);
    }
    clvox__quadtree_free(&ref);
    free(soup1);
    compared++;
}

static void compare_tmesh(const char *what, const tmesh *t, uint32_t resolution)
{
    clvox_mesh *m = NULL;
    CHECK_OK(tctx, clvox_mesh_from_arrays(tctx, t->xyz, t->nv, t->tri, t->nt, &m));
    if (!m) return;
    compare_mesh(what, m, resolution, CLVOX_AXIS_X, 0, 0);
    compare_mesh(what, m, resolution, CLVOX_AXIS_Z, 0, 0);
    compare_mesh(what, m, resolution, CLVOX_AXIS_Y, 12, 2);
    compare_mesh(what, m, resolution, CLVOX_AXIS_X, 3, 0);
    clvox_mesh_destroy(m);
}

static void generated(void)
{
    tmesh rnd = tmesh_random_closed(5, 4, 40); /* 76800 triangles */
    compare_tmesh("random shells", &rnd, 256);
    compare_tmesh("random shells", &rnd, 37);
    /* Large triangles over everything and copies of one surface (splits that
     * do not separate: leaves high up, next to deep subtrees). */
    tmesh mix = tmesh_random_closed(9, 2, 50);
    tmesh big = tmesh_box(-0.5, -0.5, -0.5, 1.5, 1.5, 1.5);
    tmesh_append(&mix, &big);
    tmesh sph = tmesh_sphere(0.5, 0.5, 0.5, 0.2, 40);
    for (int k = 0; k < 6; k++) tmesh_append(&mix, &sph);
    compare_tmesh("shells, a big box and a sphere 6 times", &mix, 200);
    /* Enough triangles for the memory-lean paths (partition.c LEAN_ITEMS,
     * 2^16 in this test: the root's children made one at a time and shrunk
     * as they go). */
    tmesh many = tmesh_random_closed(11, 3, 90); /* 291600 triangles */
    compare_tmesh("291600 triangles in 3 shells", &many, 512);
    tmesh_free(&many);
    tmesh small = tmesh_box(0, 0, 0, 1, 2, 3);
    compare_tmesh("box", &small, 64);
    tmesh_free(&rnd);
    tmesh_free(&mix);
    tmesh_free(&big);
    tmesh_free(&sph);
    tmesh_free(&small);
}

static void real_meshes(void)
{
    DIR *d = opendir("data/meshes");
    if (!d) {
        printf("SKIP data/meshes: not present\n");
        return;
    }
    int quick = getenv("CLVOX_QUICK") != NULL;
    struct dirent *e;
    char path[1400];
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.' || (quick && strstr(e->d_name, "_s"))) continue;
        snprintf(path, sizeof path, "data/meshes/%s", e->d_name);
        clvox_mesh *m = NULL;
        if (clvox_mesh_load(tctx, path, &m) != CLVOX_OK) continue;
        int big = m->triangle_count > 20000;
        compare_mesh(path, m, big ? 512 : 128, CLVOX_AXIS_X, 0, 0);
        if (big && !strstr(e->d_name, "_s3")) compare_mesh(path, m, 300, CLVOX_AXIS_Z, 0, 0);
        clvox_mesh_destroy(m);
    }
    closedir(d);
}

int main(void)
{
    /* The memory-lean paths of the quadtree build start at 2^16 triangles
     * here (the default is 2^20), so that the generated meshes reach them;
     * every other test runs the default, and the tree is the same. */
    clvox__test_hooks hooks = *clvox__hooks();
    if (!hooks.partition_lean_bits) hooks.partition_lean_bits = 16;
    clvox__set_test_hooks(&hooks);
    clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
    o.host_only = 1;
    CHECK_OK(NULL, clvox_context_create(&o, &tctx));
    if (!tctx) return test_report();
    generated();
    real_meshes();
    printf("%d cases compared\n", compared);
    CHECK(compared >= 16);
    clvox_context_destroy(tctx);
    return test_report();
}
