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
                                      float pw, int exact_hits, float *u_hit)
{
    const int sab = clvox_edge_sign_x(pv, pw, a[1], a[2], b[1], b[2]);
    const int sbc = clvox_edge_sign_x(pv, pw, b[1], b[2], c[1], c[2]);
    const int sca = clvox_edge_sign_x(pv, pw, c[1], c[2], a[1], a[2]);
    if (sab == 0 || sab != sbc || sab != sca) return 0;
    /* the estimate, as in double (weights rounded) */
    const float Av = a[1] - pv, Aw = a[2] - pw, Bv = b[1] - pv, Bw = b[2] - pw, Cv = c[1] - pv, Cw = c[2] - pw;
    const float eab = Av * Bw - Aw * Bv, ebc = Bv * Cw - Bw * Cv, eca = Cv * Aw - Cw * Av;
    const float ua = a[0], db = b[0] - ua, dc = c[0] - ua;
    const float S = eab + ebc + eca, N = eca * db + eab * dc, q = N / S;
    float h = ua + q;
    if (exact_hits) { /* every float compared exactly, integers among them */
        *u_hit = h;
        return sab;
    }
    /* u lies in the triangle's u-range: the integers to search are those
     * between ceil(umin) and ceil(umax), clipped to +-2^22 (far past any
     * grid: a crossing beyond is on the same side of every centre) */
    const float umin = fmin(fmin(a[0], b[0]), c[0]), umax = fmax(fmax(a[0], b[0]), c[0]);
    const float lo = fmax(ceil(umin), -0x1p22f), hi = fmin(ceil(umax), 0x1p22f);
    /* Most crossings lie well inside (i - 1, i]: where h's error bound
     * keeps it there, ceil(h) is u's, the search's answer, and h the
     * u_hit it returns. The bound: each e, from rounded differences, lies
     * within 3.0001 u of its permanent (Shewchuk's ccwerrboundA; 2^-146
     * more for products near underflow); S = their sum within ES; N = eca
     * db + eab dc (db, dc rounded differences) within EN; q = N / S within
     * (EN + |q| ES) / (|S| - ES) + u |q| where |S| > 2 ES; h = ua + q
     * within that + u |h|, and 2 u |h| more for h -+ Eh's own rounding.
     * The bound's own arithmetic (a dozen roundings) is inside the factors
     * 1.0001. Elsewhere the search below. */
    {
        const float U = 0x1p-24f, TINY = 0x1p-146f;
        const float e_ab = 3.0001f * U * (fabs(Av * Bw) + fabs(Aw * Bv)) + TINY;
        const float e_bc = 3.0001f * U * (fabs(Bv * Cw) + fabs(Bw * Cv)) + TINY;
        const float e_ca = 3.0001f * U * (fabs(Cv * Aw) + fabs(Cw * Av)) + TINY;
        const float ES = (e_ab + e_bc + e_ca + 2.0001f * U * (fabs(eab) + fabs(ebc) + fabs(eca))) * 1.0001f + TINY;
        const float EN = ((e_ca + 2.0001f * U * fabs(eca)) * fabs(db) + (e_ab + 2.0001f * U * fabs(eab)) * fabs(dc) +
                          U * fabs(N)) * 1.0001f + TINY;
        const float Eh = ((EN + fabs(q) * ES) / (fabs(S) - ES) + U * fabs(q) + 3 * U * fabs(h)) * 1.0001f;
        const float ch = ceil(h);
        if (fabs(S) > 2 * ES && Eh < 0.25f && ceil(h - Eh) == ch && ceil(h + Eh) == ch && ch >= lo && ch <= hi) {
            *u_hit = h;
            return sab;
        }
    }
    const float v[9] = {a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]};
    float i = fmin(fmax(ceil(h), lo), hi); /* NaN -> lo */
    while (i < hi && !clvox_hit_at_or_below(v, i, pv, pw, sab)) i += 1.0f;
    while (i > lo && clvox_hit_at_or_below(v, i - 1.0f, pv, pw, sab)) i -= 1.0f;
    /* ceil(h) == i: h in (i - 1, i] */
    *u_hit = fmin(fmax(h, nextafter(i - 1.0f, i)), i);
    return sab;
}
#endif

/* Crossings for the column consumers (coverage), which compare them with
 * sample points that are floats (sampler.h clvox_sample_u), not only
 * integers: the crossing is stored as RU(u), the smallest float f >= u of
 * the set S = {0} and 2^-24 <= |f| <= 2^22, so that "f > p" is exactly
 * "u > p" for every p in S (u > p: f >= u > p; u <= p: f <= p), and
 * ceil(f) = ceil(u). "u <= f" is the exact sign of the triangle's plane
 * function at (f, pv, pw) (clvox_hit_at_or_below), monotone in f: from
 * the estimate, a galloping search then bisection over S in order (keys:
 * the floats' bit patterns, counted from 2^-24). In double the estimate is
 * within a fraction of a float's spacing, and the filter of overlap.h
 * decides the two signs at once but at ties; in float a few steps each
 * way. Both builds get the same float. */
#define CLVOX_HIT_MIN_BITS 0x33800000 /* as_int(0x1p-24f) */
static inline long clvox_hit_key(float f) /* f in S */
{
    if (f == 0.0f) return 0;
    const long k = (long)as_int(fabs(f)) - CLVOX_HIT_MIN_BITS + 1;
    return f > 0.0f ? k : -k;
}
static inline float clvox_hit_of_key(long k)
{
    if (k == 0) return 0.0f;
    const float f = as_float((int)((k > 0 ? k : -k) - 1 + CLVOX_HIT_MIN_BITS));
    return k > 0 ? f : -f;
}
/* The key of a float f clamped into S's range: below it (down) or above. */
static inline long clvox_hit_key_near(float f, int up)
{
    f = fmin(fmax(f, -0x1p22f), 0x1p22f);
    if (fabs(f) < 0x1p-24f) return f == 0.0f ? 0 : (f > 0.0f ? (up ? 1 : 0) : (up ? 0 : -1));
    return clvox_hit_key(f);
}
static inline int clvox_hit_below_pre(const clvox_ovr *v, const clvox_ovr *m, const clvox_ovr *pm, long k, float pv,
                                      float pw, int s)
{
    return s * clvox_o3_sign_pre(v, m, pm, clvox_hit_of_key(k), pv, pw) >= 0;
}
static inline float clvox_hit_round_up(global const float *a, global const float *b, global const float *c, float pv,
                                       float pw, int s, clvox_real est)
{
    const clvox_ovr v[9] = {a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]};
    clvox_ovr m[3], pm[3];
    clvox_o3_setup(v, m, pm);
    const long klo = clvox_hit_key_near(fmin(fmin(a[0], b[0]), c[0]), 0);
    const long khi = clvox_hit_key_near(fmax(fmax(a[0], b[0]), c[0]), 1);
    long k = clvox_hit_key_near((float)est, 1); /* NaN: fmin/fmax give the bound */
    k = k < klo ? klo : (k > khi ? khi : k);
    /* invariant: "u <= key b" holds (b = khi if never seen), "u <= key a"
     * does not (a = klo - 1 if never seen) */
    long lo, hi, step = 1;
    if (clvox_hit_below_pre(v, m, pm, k, pv, pw, s)) {
        hi = k;
        lo = k - 1;
        while (lo >= klo && clvox_hit_below_pre(v, m, pm, lo, pv, pw, s)) {
            hi = lo;
            step *= 2;
            lo = hi - step;
        }
        if (lo < klo) lo = klo - 1;
    } else {
        lo = k;
        hi = k + 1;
        while (hi <= khi && !clvox_hit_below_pre(v, m, pm, hi, pv, pw, s)) {
            lo = hi;
            step *= 2;
            hi = lo + step;
        }
        if (hi > khi) hi = khi;
    }
    while (hi - lo > 1) {
        const long mid = lo + (hi - lo) / 2;
        if (clvox_hit_below_pre(v, m, pm, mid, pv, pw, s)) hi = mid;
        else lo = mid;
    }
    return clvox_hit_of_key(hi);
}

static void clvox_intersect_body(global const clvox_ray *rays, uint ray_count,
                                 global const uint *leaf_of_ray, global const clvox_qt_node *nodes,
                                 global const uint *refs, global const float *verts, global const uint *tris,
                                 uint capacity, global clvox_real *hits, global uint *counts, global char *signs,
                                 uint surface_count, uint exact_hits)
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
                                          verts + (size_t)k3[2] * 3, pv, pw, (int)exact_hits, &u);
#endif
        if (s && exact_hits)
            u = clvox_hit_round_up(verts + (size_t)k3[0] * 3, verts + (size_t)k3[1] * 3, verts + (size_t)k3[2] * 3, pv,
                                   pw, s, u);
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
                            uint surface_count, uint exact_hits,
                            global uint *clvox_done, uint clvox_done_slot)
{
    clvox_intersect_body(rays, ray_count, leaf_of_ray, nodes, refs, verts, tris, capacity, hits, counts, signs,
        surface_count, exact_hits);
    clvox_done_mark(clvox_done, clvox_done_slot);
}
