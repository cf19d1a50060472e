/* Winding numbers, host side (docs/design.md "Winding numbers"): the soup
 * the cast runs over -- the prepared surface followed by its caps -- and the
 * cap tree the consumers refine near the caps (kernels/winding.h). */
#include "winding.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define CAP_LEAF 4 /* cap triangles per leaf */

clvox_status clvox__winding_soup(clvox_context *ctx, const clvox_mesh *mesh, const clvox_grid *grid,
                                 clvox__axes axes, const clvox__winding_mesh *wm, float **out_soup,
                                 size_t *out_count)
{
    *out_soup = NULL;
    *out_count = 0;
    size_t nt = wm->triangle_count + wm->cap_count;
    if (nt > SIZE_MAX / (9 * sizeof(float)) || wm->apex_count > (SIZE_MAX / 12) - mesh->vertex_count)
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "mesh too large");
    /* A view of the mesh with the apexes after its vertices and the caps
     * after its triangles, so that clvox__grid_space_soup transforms every
     * vertex exactly as for parity (caps share the boundary's floats). */
    clvox_mesh view = *mesh;
    uint32_t *tris = malloc((nt ? nt : 1) * 3 * sizeof *tris);
    float *xyz = NULL;
    if (tris && wm->apex_count) {
        xyz = malloc((mesh->vertex_count + wm->apex_count) * 3 * sizeof *xyz);
        if (xyz) {
            memcpy(xyz, mesh->xyz, mesh->vertex_count * 3 * sizeof *xyz);
            memcpy(xyz + mesh->vertex_count * 3, wm->apex, wm->apex_count * 3 * sizeof *xyz);
        }
    }
    if (!tris || (wm->apex_count && !xyz)) {
        free(tris);
        free(xyz);
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu triangles and caps", nt);
    }
    memcpy(tris, wm->tris, wm->triangle_count * 3 * sizeof *tris);
    if (wm->cap_count) memcpy(tris + wm->triangle_count * 3, wm->caps, wm->cap_count * 3 * sizeof *tris);
    view.tris = tris;
    view.triangle_count = nt;
    if (xyz) {
        view.xyz = xyz;
        view.vertex_count = mesh->vertex_count + wm->apex_count;
    }
    clvox_status st = clvox__grid_space_soup(ctx, &view, grid, axes, out_soup);
    free(tris);
    free(xyz);
    if (st == CLVOX_OK) *out_count = nt;
    return st;
}

typedef struct cap_key {
    double key;
    uint32_t index;
} cap_key;

static int cmp_cap_key(const void *pa, const void *pb)
{
    const cap_key *a = pa, *b = pb;
    if (a->key != b->key) return a->key < b->key ? -1 : 1;
    return a->index < b->index ? -1 : a->index > b->index;
}

static float round_down(double x)
{
    float f = (float)x;
    return (double)f > x ? nextafterf(f, -INFINITY) : f;
}

static float round_up(double x)
{
    float f = (float)x;
    return (double)f < x ? nextafterf(f, INFINITY) : f;
}

void clvox__caps_release(clvox__caps *c)
{
    clvox__release_mem(&c->nodes);
    clvox__release_mem(&c->tris);
    clvox__release_mem(&c->h);
    c->node_count = 0;
    c->cap_count = 0;
}

clvox_status clvox__caps_upload(clvox_context *ctx, const float *cap_soup, size_t n, clvox__axes axes,
                                const clvox_grid *grid, clvox__caps *out)
{
    memset(out, 0, sizeof *out);
    clvox_status st = CLVOX_OK;
    double h3[3] = {grid->voxel_size[0], grid->voxel_size[1], grid->voxel_size[2]};
    /* h is needed even without caps (the kernels take it) */
    size_t rs = ctx->real_size;
    {
        unsigned char hb[24];
        for (int a = 0; a < 3; a++) {
            if (rs == 8) memcpy(hb + 8 * a, &h3[a], 8);
            else {
                float f = (float)h3[a];
                memcpy(hb + 4 * a, &f, 4);
            }
        }
        out->h = clvox__buffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, 3 * rs, hb, &st, "voxel size");
    }
    if (st != CLVOX_OK || n == 0) {
        if (st == CLVOX_OK) { /* bind something: the kernels read no node when node_count is 0 */
            clvox_cap_node dummy;
            memset(&dummy, 0, sizeof dummy);
            out->nodes = clvox__buffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof dummy, &dummy, &st,
                                       "cap tree");
            if (st == CLVOX_OK) out->tris = clvox__buffer(ctx, CL_MEM_READ_ONLY, 9 * rs, NULL, &st, "caps");
        }
        if (st != CLVOX_OK) clvox__caps_release(out);
        return st;
    }
    if (n > UINT32_MAX / 2) return clvox__fail(ctx, CLVOX_ERR_MESH_INVALID, "%zu cap triangles: too many", n);

    /* Scaled x, y, z (grid coordinates times h): solid angles of the world. */
    double *q = malloc(n * 9 * sizeof *q);
    cap_key *keys = malloc(n * sizeof *keys);
    uint32_t *order = malloc(n * sizeof *order);
    clvox_cap_node *nodes = malloc(2 * n * sizeof *nodes);
    uint32_t *stack = malloc(2 * n * sizeof *stack);
    void *tris = malloc(n * 9 * rs);
    if (!q || !keys || !order || !nodes || !stack || !tris) {
        st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu cap triangles", n);
        goto done;
    }
    for (size_t t = 0; t < n; t++) {
        for (int c = 0; c < 3; c++)
            for (int k = 0; k < 3; k++) {
                int a = axes.perm[k];
                q[t * 9 + c * 3 + a] = (double)cap_soup[t * 9 + c * 3 + k] * h3[a];
            }
        order[t] = (uint32_t)t;
    }
    /* Top-down median split on the longest axis of the centroids' box. */
    size_t node_count = 1, sp = 0;
    nodes[0].tri_first = 0;
    nodes[0].tri_count = (uint32_t)n;
    stack[sp++] = 0;
    while (sp) {
        clvox_cap_node *nd = &nodes[stack[--sp]];
        uint32_t first = nd->tri_first, count = nd->tri_count;
        double lo[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, hi[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
        double clo[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, chi[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
        double area = 0.0;
        for (uint32_t i = first; i < first + count; i++) {
            const double *p = q + (size_t)order[i] * 9;
            for (int a = 0; a < 3; a++) {
                for (int c = 0; c < 3; c++) {
                    if (p[c * 3 + a] < lo[a]) lo[a] = p[c * 3 + a];
                    if (p[c * 3 + a] > hi[a]) hi[a] = p[c * 3 + a];
                }
                double m = (p[a] + p[3 + a] + p[6 + a]) / 3.0;
                if (m < clo[a]) clo[a] = m;
                if (m > chi[a]) chi[a] = m;
            }
            double e1[3], e2[3];
            for (int a = 0; a < 3; a++) e1[a] = p[3 + a] - p[a], e2[a] = p[6 + a] - p[a];
            double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2],
                   cz = e1[0] * e2[1] - e1[1] * e2[0];
            area += 0.5 * sqrt(cx * cx + cy * cy + cz * cz);
        }
        for (int a = 0; a < 3; a++) {
            nd->lo[a] = round_down(lo[a]);
            nd->hi[a] = round_up(hi[a]);
        }
        nd->area4pi = round_up(area / (4.0 * 3.14159265358979323846) * (1.0 + 1e-9));
        nd->half_count = round_up(0.5 * count);
        nd->child = 0;
        nd->pad = 0;
        if (count <= CAP_LEAF) continue;
        int axis = 0;
        for (int a = 1; a < 3; a++)
            if (chi[a] - clo[a] > chi[axis] - clo[axis]) axis = a;
        for (uint32_t i = 0; i < count; i++) {
            const double *p = q + (size_t)order[first + i] * 9;
            keys[i].key = p[axis] + p[3 + axis] + p[6 + axis];
            keys[i].index = order[first + i];
        }
        qsort(keys, count, sizeof *keys, cmp_cap_key);
        for (uint32_t i = 0; i < count; i++) order[first + i] = keys[i].index;
        uint32_t half = count / 2;
        uint32_t c = (uint32_t)node_count;
        node_count += 2;
        nd->child = c;
        nodes[c].tri_first = first;
        nodes[c].tri_count = half;
        nodes[c + 1].tri_first = first + half;
        nodes[c + 1].tri_count = count - half;
        stack[sp++] = c;
        stack[sp++] = c + 1;
    }
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 9; k++) {
            double v = q[(size_t)order[i] * 9 + k];
            if (rs == 8) ((double *)tris)[i * 9 + k] = v;
            else ((float *)tris)[i * 9 + k] = (float)v;
        }
    out->nodes = clvox__buffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, node_count * sizeof *nodes, nodes, &st,
                               "cap tree");
    if (st == CLVOX_OK)
        out->tris = clvox__buffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, n * 9 * rs, tris, &st, "caps");
    out->node_count = (cl_uint)node_count;
    out->cap_count = n;
done:
    free(q);
    free(keys);
    free(order);
    free(nodes);
    free(stack);
    free(tris);
    if (st != CLVOX_OK) clvox__caps_release(out);
    return st;
}
