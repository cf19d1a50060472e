/* SPDX-License-Identifier: Apache-2.0 */
/* Stage cast: crossings of each ray with the triangles of its leaf.
 * Keeps at most `capacity` crossings per ray but counts all of them, so the
 * host can redo the rays that overflowed with a larger buffer. With `signs`
 * (winding runs) each crossing also gets its orientation: +1 when the
 * triangle faces +u (its corners run counter-clockwise in the (v,w) plane),
 * -1 otherwise; doubled on caps (triangles from surface_count on), whose
 * crossings leave the winding number continuous.
 * Triangles are indexed: tris holds 3 vertex indices per triangle into
 * verts (grid space, u,v,w per vertex), the floats a soup would repeat at
 * every corner (src/grid/grid.c), so the crossings are the soup's bit for bit. */

#if !defined(CLVOX_FP64)
/* Devices without fp64: the crossings exactly as double finds them, in
 * float. Which triangles a ray crosses: the edge signs are exact
 * (clvox_e2_sign of (a - p) x (b - p), kernels/overlap.h; the tie rule's
 * a.w - b.w and b.v - a.v are exact float differences), as they are in
 * double. Where it crosses: the consumers that count crossings beyond
 * integer centres (classify, winding) only read ceil(u_hit), and
 * ceil(u_hit) = the smallest integer i with u <= i; "u <= i" is the exact
 * sign of the triangle's plane function at (i, pv, pw) (clvox_o3_sign)
 * times the crossing's orientation, so the float estimate's ceil is
 * checked against it at the integers around it and the estimate moved (by
 * at most its own error) to give that ceil. Double's u_hit is exact to
 * about 1e-16 relative and its ceil the same wherever u is not within that
 * of an integer (and on integers, where double is exact for dyadic
 * inputs). Coordinates must lie in overlap.h's float range (0 or 2^-24 ..
 * 2^36 in magnitude; the host checks the vertices, src/cast/cast.c). */
static inline int clvox_edge_sign_x(float pv, float pw, float av, float aw, float bv, float bw)
{
    const int s = clvox_e2_sign(pv, pw, av, aw, pv, pw, bv, bw);
    if (s) return s;
    if (aw != bw) return aw > bw ? 1 : -1; /* dw = Aw - Bw = a.w - b.w */
    if (bv != av) return bv > av ? 1 : -1; /* dv = Bv - Av = b.v - a.v */
    return 0;
}

/* "u <= i" for the crossing of orientation s of the triangle v (a, b, c)
 * with the ray at (pv, pw): f(q) = n . (q - a), n = (b - a) x (c - a), is
 * n.u (i - u) at q = (i, pv, pw), and n.u has the sign s. */
static inline int clvox_hit_at_or_below(const float *v, float i, float pv, float pw, int s)
{
    return s * clvox_o3_sign(v, i, pv, pw) >= 0;
}

static inline int clvox_ray_crosses_x(global const float *a, global const float *b, global const float *c, float pv,
                                      float pw, float *u_hit)
{
    const int sab = clvox_edge_sign_x(pv, pw, a[1], a[2], b[1], b[2]);
    const int sbc = clvox_edge_sign_x(pv, pw, b[1], b[2], c[1], c[2]);
    const int sca = clvox_edge_sign_x(pv, pw, c[1], c[2], a[1], a[2]);
    if (sab == 0 || sab != sbc || sab != sca) return 0;
    /* the estimate, as in double (weights rounded) */
    const float Av = a[1] - pv, Aw = a[2] - pw, Bv = b[1] - pv, Bw = b[2] - pw, Cv = c[1] - pv, Cw = c[2] - pw;
    const float eab = Av * Bw - Aw * Bv, ebc = Bv * Cw - Bw * Cv, eca = Cv * Aw - Cw * Av;
    const float ua = a[0];
    float h = ua + (eca * (b[0] - ua) + eab * (c[0] - ua)) / (eab + ebc + eca);
    /* u lies in the triangle's u-range: the integers to search are those
     * between ceil(umin) and ceil(umax), clipped to +-2^22 (far past any
     * grid: a crossing beyond is on the same side of every centre) */
    const float umin = fmin(fmin(a[0], b[0]), c[0]), umax = fmax(fmax(a[0], b[0]), c[0]);
    const float lo = fmax(ceil(umin), -0x1p22f), hi = fmin(ceil(umax), 0x1p22f);
    const float v[9] = {a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]};
    float i = fmin(fmax(ceil(h), lo), hi); /* NaN -> lo */
    while (i < hi && !clvox_hit_at_or_below(v, i, pv, pw, sab)) i += 1.0f;
    while (i > lo && clvox_hit_at_or_below(v, i - 1.0f, pv, pw, sab)) i -= 1.0f;
    /* ceil(h) == i: h in (i - 1, i] */
    *u_hit = fmin(fmax(h, nextafter(i - 1.0f, i)), i);
    return sab;
}
#endif

static void clvox_intersect_body(global const clvox_ray *rays, uint ray_count,
                                 global const uint *leaf_of_ray, global const clvox_qt_node *nodes,
                                 global const uint *refs, global const float *verts, global const uint *tris,
                                 uint capacity, global clvox_real *hits, global uint *counts, global char *signs,
                                 uint surface_count)
{
    uint gid = get_global_id(0);
    if (gid >= ray_count) return;
    float pv = rays[gid].v, pw = rays[gid].w;
    clvox_qt_node leaf = nodes[leaf_of_ray[gid]];
    global clvox_real *out = hits + (size_t)gid * capacity;
    uint n = 0;
    for (uint k = 0; k < leaf.count; k++) {
        uint t = refs[leaf.first + k];
        clvox_real u;
        global const uint *k3 = tris + (size_t)t * 3;
#if defined(CLVOX_FP64)
        const int s = clvox_ray_crosses(verts + (size_t)k3[0] * 3, verts + (size_t)k3[1] * 3, verts + (size_t)k3[2] * 3,
                                        pv, pw, &u);
#else
        const int s = clvox_ray_crosses_x(verts + (size_t)k3[0] * 3, verts + (size_t)k3[1] * 3,
                                          verts + (size_t)k3[2] * 3, pv, pw, &u);
#endif
        if (s) {
            if (n < capacity) {
                out[n] = u;
                if (signs) signs[(size_t)gid * capacity + n] = (char)(t < surface_count ? s : 2 * s);
            }
            n++;
        }
    }
    counts[gid] = n;
}

/* The kernel: the body, then the launch's completion count (clvox_done,
 * prelude.cl). */
kernel void clvox_intersect(global const clvox_ray *rays, uint ray_count,
                            global const uint *leaf_of_ray, global const clvox_qt_node *nodes,
                            global const uint *refs, global const float *verts, global const uint *tris,
                            uint capacity, global clvox_real *hits, global uint *counts, global char *signs,
                            uint surface_count,
                            global uint *clvox_done, uint clvox_done_slot)
{
    clvox_intersect_body(rays, ray_count, leaf_of_ray, nodes, refs, verts, tris, capacity, hits, counts, signs,
        surface_count);
    clvox_done_mark(clvox_done, clvox_done_slot);
}
