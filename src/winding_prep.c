/* TEMPORARY stand-in for the winding preparation (being written on branch
 * winding-prep): no merging or orientation repair; the boundary chain is
 * capped by one fan from the mean of its vertices. */
#include "internal.h"

#include <stdlib.h>
#include <string.h>

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

void clvox__winding_mesh_free(clvox__winding_mesh *w)
{
    free(w->tris);
    free(w->caps);
    free(w->apex);
    memset(w, 0, sizeof *w);
}

clvox_status clvox__winding_prepare(clvox_context *ctx, const clvox_mesh *mesh, double weld, clvox__winding_mesh *out)
{
    (void)weld;
    double t0 = clvox__now();
    memset(out, 0, sizeof *out);
    size_t nt = mesh->triangle_count;
    out->tris = malloc(nt * 3 * sizeof *out->tris);
    uint64_t *e = malloc(nt * 3 * sizeof *e);
    if (!out->tris || !e) {
        free(e);
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    }
    memcpy(out->tris, mesh->tris, nt * 3 * sizeof *out->tris);
    out->triangle_count = nt;
    for (size_t i = 0; i < 3 * nt; i++) {
        uint32_t a = mesh->tris[i], b = mesh->tris[i % 3 == 2 ? i - 2 : i + 1];
        e[i] = (uint64_t)a << 32 | b;
    }
    qsort(e, 3 * nt, sizeof *e, cmp_u64);
    /* net multiplicity per undirected edge: count a->b minus b->a */
    size_t nb = 0, cap = 0;
    uint32_t *caps = NULL;
    double sum[3] = {0, 0, 0};
    for (size_t i = 0; i < 3 * nt;) {
        size_t j = i;
        while (j < 3 * nt && e[j] == e[i]) j++;
        uint32_t a = (uint32_t)(e[i] >> 32), b = (uint32_t)e[i];
        long m = (long)(j - i);
        uint64_t rev = (uint64_t)b << 32 | a;
        uint64_t *lo = e, *hi = e + 3 * nt; /* binary search for the reverse */
        while (lo < hi) {
            uint64_t *mid = lo + (hi - lo) / 2;
            if (*mid < rev) lo = mid + 1;
            else hi = mid;
        }
        long r = 0;
        while (lo < e + 3 * nt && *lo == rev) lo++, r++;
        if (a < b || r == 0) {
            long net = a < b ? m - r : m; /* each undirected edge once */
            if (a > b && r) net = 0;
            for (long k = 0; k < (net < 0 ? -net : net); k++) {
                if (nb + 1 > cap) {
                    cap = cap * 2 + 16;
                    caps = realloc(caps, cap * 3 * sizeof *caps);
                    if (!caps) {
                        free(e);
                        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
                    }
                }
                uint32_t p = net > 0 ? a : b, q = net > 0 ? b : a; /* boundary edge p->q */
                caps[nb * 3] = q;
                caps[nb * 3 + 1] = p;
                caps[nb * 3 + 2] = (uint32_t)mesh->vertex_count;
                for (int c = 0; c < 3; c++) sum[c] += mesh->xyz[3 * (size_t)p + c];
                nb++;
            }
        }
        i = j;
    }
    free(e);
    out->caps = caps;
    out->cap_count = nb;
    if (nb) {
        out->apex = malloc(3 * sizeof *out->apex);
        if (!out->apex) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
        for (int c = 0; c < 3; c++) out->apex[c] = (float)(sum[c] / (double)nb + 0.0123456789 * (c + 1));
        out->apex_count = 1;
    }
    out->report.boundary_edges = nb;
    out->report.cap_triangles = nb;
    out->report.holes = nb ? 1 : 0;
    out->report.seconds = clvox__now() - t0;
    return CLVOX_OK;
}
