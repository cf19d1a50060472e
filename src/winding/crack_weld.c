/* SPDX-License-Identifier: Apache-2.0 */
/* The certified crack weld: the winding number of a cracked mesh or a
 * triangle soup, exactly as given, at the speed of the welded mesh.
 *
 * A soup (no shared vertices, each corner a little off its neighbours': an
 * STL, a mesh saved per face) has a hole around every triangle. Its caps
 * nearly cancel, but every bound adds their sizes, so every centre near the
 * surface had to be evaluated against thousands of caps (issue 35: 13.8 s
 * at 64^3 for a 52 k-triangle soup). Welded, the same surface is closed or
 * nearly, and fast. The voxels must still be the soup's.
 *
 * Let S be the surface as the unwelded preparation orients it and S' the
 * welded one: each triangle T of S has a copy T' whose corners are the
 * welded representatives (T' may collapse). Then, exactly,
 *   w_S(p) = w_S'(p) + sum_T (Omega(T, p) - Omega(T', p)) / 4pi
 *          = K'(p) - w_caps'(p) - sum_T (Omega(T', p) + Omega(rev T, p)) / 4pi,
 * K' and caps' those of the welded preparation. So the cast runs over S' and
 * its caps, and the cap tree gets, beside the caps of S', each pair {rev T,
 * T'} as two more cap triangles (a pair whose T' has T's positions adds 0
 * and is left out). Nothing else changes: the kernels' w = K - w_caps is
 * the soup's w at every point, ties included (the caps' tie rule is the
 * cast's).
 *
 * What makes it fast is the pairs' bound. Move T's corners v_i linearly to
 * v'_i, |v'_i - v_i| <= delta. While p is outside the box of T and T' (which
 * holds every intermediate triangle), Omega changes by the flux of x/|x|^3
 * through the ribbon its edges sweep: |dOmega/dt| <= (perimeter at t) delta
 * / D^2, D the distance from p to the box, the perimeter at most per(T) + 6
 * delta. So
 *   |Omega(T) - Omega(T')| / 4pi <= (per(T) + 6 delta) delta / (4pi D^2),
 * small where the weld moved little, and it is the bound the cap tree
 * stores for pair nodes (kernels/winding_bounds.h "weld pairs"): most
 * centres are decided from K', and only those within about sqrt(per
 * delta) of a pair are evaluated exactly, against a few pairs.
 *
 * Orientation. The two preparations may orient a triangle differently
 * (the soup's small patches of exactly merged vertices get a sign of their
 * own; an inward-facing mesh is turned outwards once welded): then T' is
 * T reversed and moved, and its term is split as
 *   Omega(T') - Omega(T) = 2 Omega(T') + (Omega(rev T') - Omega(T)),
 * a pair {rev T, rev T'} (T and rev T' alike again: small) and T' twice as
 * an ordinary cap (bounded by its area, as holes are).
 *
 * The weld is tried only by default (no --weld) and only where the
 * unwelded preparation left many boundary edges; it is used only when its
 * caps, those of the reversed triangles included, are at most half the
 * unwelded caps. */
#include "crack_weld.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

double clvox__crack_weld_distance(const double h[3])
{
    double m = h[0];
    if (h[1] < m) m = h[1];
    if (h[2] < m) m = h[2];
    return 0.01 * m;
}

void clvox__crack_weld_free(clvox__crack_weld *cw)
{
    if (!cw) return;
    const double seconds = cw->seconds;
    clvox__winding_mesh_free(&cw->welded);
    free(cw->pairs);
    free(cw->extra);
    memset(cw, 0, sizeof *cw);
    cw->seconds = seconds;
}

static int same_pos(const float *xyz, uint32_t a, uint32_t b)
{
    const float *p = xyz + 3 * (size_t)a, *q = xyz + 3 * (size_t)b;
    return p[0] == q[0] && p[1] == q[1] && p[2] == q[2];
}

/* Worth a second preparation: a soup has three boundary edges a triangle;
 * a mesh with a few holes has far fewer than one in 16. */
static int worth_trying(const clvox_mesh *mesh, const clvox__winding_mesh *soup)
{
    return soup->cap_count > 0 && soup->report.boundary_edges >= 64 &&
           soup->report.boundary_edges * 16 >= (uint64_t)mesh->triangle_count;
}

clvox_status clvox__crack_weld_try(clvox_context *ctx, const clvox_mesh *mesh, const clvox__winding_mesh *soup,
                                   double distance, clvox__crack_weld *cw)
{
    memset(cw, 0, sizeof *cw);
    cw->distance = distance;
    if (clvox__hooks()->no_crack_weld || !(distance > 0) || !isfinite(distance) || !worth_trying(mesh, soup) ||
        !soup->tris)
        return CLVOX_OK;
    /* its messages to a scratch context: a weld that fails is not an error */
    clvox_context *side = malloc(sizeof *side);
    if (!side) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    *side = *ctx;
    clvox_status st = clvox__winding_prepare_flags(side, mesh, distance, CLVOX__PREP_KEEP_REP, &cw->welded);
    if (st == CLVOX_ERR_OUT_OF_MEMORY) {
        clvox__crack_weld_free(cw);
        st = clvox__fail(ctx, st, "%s", side->error);
        free(side);
        return st;
    }
    free(side);
    cw->seconds = cw->welded.report.seconds; /* spent whether it is used or not */
    if (st != CLVOX_OK || cw->welded.cap_count * 2 > soup->cap_count || !cw->welded.rep) {
        clvox__crack_weld_free(cw);
        return CLVOX_OK;
    }
    const float *xyz = mesh->xyz;
    const uint32_t *rep = cw->welded.rep;
    size_t nt = mesh->triangle_count, is = 0, iw = 0, np = 0, ne = 0;
    cw->pairs = malloc((nt ? nt : 1) * 6 * sizeof *cw->pairs);
    cw->extra = malloc((nt ? nt : 1) * 3 * sizeof *cw->extra);
    if (!cw->pairs || !cw->extra) {
        clvox__crack_weld_free(cw);
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for %zu weld pairs", nt);
    }
    int ok = 1;
    /* both preparations list the input triangles they keep in input order,
     * reversed (corners 1 and 2 swapped) where they flip them */
    for (size_t t = 0; t < nt && ok; t++) {
        const uint32_t *in = mesh->tris + 3 * t;
        const int kept_s = !same_pos(xyz, in[0], in[1]) && !same_pos(xyz, in[1], in[2]) &&
                           !same_pos(xyz, in[0], in[2]);
        const uint32_t ra = rep[in[0]], rb = rep[in[1]], rc = rep[in[2]];
        const int kept_w = ra != rb && rb != rc && ra != rc;
        if (!kept_s) {
            if (kept_w) ok = 0; /* the weld only merges more */
            continue;
        }
        if (is >= soup->triangle_count) {
            ok = 0;
            break;
        }
        const uint32_t *s = soup->tris + 3 * is++;
        if (!same_pos(xyz, s[0], in[0])) {
            ok = 0;
            break;
        }
        const int flip_s = !same_pos(xyz, s[1], in[1]);
        if (kept_w) {
            if (iw >= cw->welded.triangle_count) {
                ok = 0;
                break;
            }
            const uint32_t *w = cw->welded.tris + 3 * iw++;
            const int flip_w = w[1] != rb;
            if (w[0] != ra) {
                ok = 0;
                break;
            }
            if (flip_w != flip_s) { /* the pair below is against rev T'; 2 T' more as caps */
                if (ne + 2 > nt) {
                    ok = 0;
                    break;
                }
                for (int k = 0; k < 2; k++, ne++) memcpy(cw->extra + 3 * ne, w, 3 * sizeof *w);
            }
        }
        uint32_t *pr = cw->pairs + 6 * np;
        pr[0] = s[0];
        pr[1] = s[1];
        pr[2] = s[2];
        pr[3] = ra;
        pr[4] = flip_s ? rc : rb;
        pr[5] = flip_s ? rb : rc;
        if (same_pos(xyz, pr[0], pr[3]) && same_pos(xyz, pr[1], pr[4]) && same_pos(xyz, pr[2], pr[5]))
            continue; /* adds exactly 0 */
        np++;
    }
    if (!ok || is != soup->triangle_count || iw != cw->welded.triangle_count || np == 0 ||
        (cw->welded.cap_count + ne) * 2 > soup->cap_count) {
        clvox__crack_weld_free(cw);
        return CLVOX_OK;
    }
    uint32_t *shrunk = realloc(cw->pairs, np * 6 * sizeof *shrunk);
    if (shrunk) cw->pairs = shrunk;
    cw->pair_count = np;
    cw->extra_count = ne;
    cw->used = 1;
    free(cw->welded.rep);
    cw->welded.rep = NULL;
    return CLVOX_OK;
}
