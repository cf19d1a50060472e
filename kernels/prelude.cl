/* Shared helpers of all clvox kernels. Prepended to every stage file.
 * No contraction: a*b - c*d must round exactly as the CPU reference does. */
#pragma OPENCL FP_CONTRACT OFF

/* Sign of the edge function of directed edge (a,b) for a ray at p, given
 * A = a - p and B = b - p in the ray plane (.x = v, .y = w).
 * E(b,a) == -E(a,b) exactly (same products), so an edge shared by two
 * triangles is judged the same way from both. E == 0 (p on the edge's line)
 * is broken by a symbolic perturbation p + eps*(1, eps'): the sign of the
 * derivative of E in that direction. 0 only for a degenerate edge. */
inline int clvox_edge_sign(float Av, float Aw, float Bv, float Bw, float *e_out)
{
    float e = Av * Bw - Aw * Bv;
    *e_out = e;
    if (e != 0.0f) return e > 0.0f ? 1 : -1;
    float dw = Aw - Bw;
    if (dw != 0.0f) return dw > 0.0f ? 1 : -1;
    float dv = Bv - Av;
    if (dv != 0.0f) return dv > 0.0f ? 1 : -1;
    return 0;
}

/* Does the ray at (pv,pw) along +u cross triangle t (9 floats, u,v,w per
 * corner, grid space)? If so *u_hit is where. Both windings count. */
inline int clvox_ray_crosses(global const float *t, float pv, float pw, float *u_hit)
{
    float Av = t[1] - pv, Aw = t[2] - pw;
    float Bv = t[4] - pv, Bw = t[5] - pw;
    float Cv = t[7] - pv, Cw = t[8] - pw;
    float eab, ebc, eca;
    int sab = clvox_edge_sign(Av, Aw, Bv, Bw, &eab);
    int sbc = clvox_edge_sign(Bv, Bw, Cv, Cw, &ebc);
    int sca = clvox_edge_sign(Cv, Cw, Av, Aw, &eca);
    if (sab == 0 || sab != sbc || sab != sca) return 0;
    /* Barycentric interpolation anchored at a: a face of constant u gives
     * exactly that u. The weights share one sign, so den != 0. */
    float num = eca * (t[3] - t[0]) + eab * (t[6] - t[0]);
    float den = eab + ebc + eca;
    *u_hit = t[0] + num / den;
    return 1;
}
