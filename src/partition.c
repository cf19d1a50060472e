/* Stage partition: quadtree over the projection of the triangles onto the
 * ray plane (Thon et al. 3.2). A node is split into 4 at its centre while it
 * holds more than `leaf_size` triangles and is shallower than `max_depth`.
 * A triangle goes to every child its projected bounding box touches
 * (closed intervals, slightly widened), so the leaf a ray lands in holds
 * every triangle the ray can cross.
 *
 * A split that does not separate the triangles is not made: when the four
 * children would hold 3 times the node's triangles or more (most of them
 * span both split lines: large or coincident triangles), a ray would still
 * test three quarters of them, and the references would multiply by up to 4
 * per level (a surface duplicated a million times asked for 32 GB). The
 * references are also capped (MAX_REFS) as a last guard; any leaf that holds
 * every triangle it touches is correct, so these rules change speed only. */
#include "internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct build {
    clvox_context *ctx;
    const float *box;      /* 4 floats per triangle: v0, w0, v1, w1 */
    uint32_t max_depth, leaf_size;
    clvox_qt_node *nodes;
    size_t node_count, node_cap;
    uint32_t *refs;
    size_t ref_count, ref_cap;
    uint32_t depth;
    size_t leaves;
} build;

/* At most this many references in all (4 bytes each): past it, nodes stay leaves. */
#define MAX_REFS ((size_t)1 << 28)

static int grow(void **p, size_t *cap, size_t need, size_t elem)
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

/* Leaves: default depth so that the smallest cell is about 2 columns wide,
 * capped at 12 (Thon's Table 3: gains stop around depth 10). */
uint32_t clvox__quadtree_auto_depth(uint32_t dim_v, uint32_t dim_w, size_t tri_count)
{
    uint32_t dim = dim_v > dim_w ? dim_v : dim_w;
    uint32_t d = 0;
    while (d < 12 && (dim >> (d + 1)) >= 2) d++;
    /* No point in more leaves than about 4 per triangle. */
    while (d > 0 && ((size_t)1 << (2 * d)) > 4 * tri_count + 4) d--;
    return d;
}

static clvox_status build_node(build *b, size_t node, const uint32_t *tris, size_t n, float v0, float w0,
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
        leaf = sum >= 3 * n || b->ref_count + sum > MAX_REFS;
    }
    if (leaf) {
        if (!grow((void **)&b->refs, &b->ref_cap, b->ref_count + n, sizeof *b->refs))
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
    if (!grow((void **)&b->nodes, &b->node_cap, b->node_count + 4, sizeof *b->nodes))
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
        st = build_node(b, first + q, sub, m, cv0, cw0, cv1, cw1, depth + 1);
    }
    free(sub);
    return st;
}

clvox_status clvox__quadtree_build(clvox_context *ctx, const float *soup, size_t tri_count, uint32_t dim_v,
                                   uint32_t dim_w, uint32_t max_depth, uint32_t leaf_size, clvox__quadtree *out)
{
    memset(out, 0, sizeof *out);
    if (tri_count > 0xFFFFFFF0u)
        return clvox__fail(ctx, CLVOX_ERR_MESH_INVALID, "more than 2^32 triangles");
    build b = {.ctx = ctx, .max_depth = max_depth ? max_depth : clvox__quadtree_auto_depth(dim_v, dim_w, tri_count),
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
    clvox_status st = build_node(&b, 0, root, n, v0, w0, v1, w1, 0);
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

void clvox__quadtree_free(clvox__quadtree *qt)
{
    if (!qt) return;
    free(qt->nodes);
    free(qt->refs);
    memset(qt, 0, sizeof *qt);
}
