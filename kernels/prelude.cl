/* SPDX-License-Identifier: Apache-2.0 */
/* Shared helpers of all clvox kernels. Prepended to every stage file.
 * No contraction: a*b - c*d must round exactly as the CPU reference does.
 * (Embedded as C string literals by scripts/embed_kernels.sh: a backslash
 * like this one, \, or "quotes" must come through as written;
 * tests/test_program_cache.c compares every embedded source with its file.) */
#pragma OPENCL FP_CONTRACT OFF

/* Crossings are computed in double where the device has it: a crossing a
 * millionth of a voxel from a centre must still land on the right side of
 * it, so that the ray and tetra methods agree bit for bit. Without fp64 the
 * same code runs in float (consistent, but only float-accurate). Kernels
 * test CLVOX_FP64, not cl_khr_fp64. */
#if defined(cl_khr_fp64) && !defined(CLVOX_NO_FP64) /* CLVOX_NO_FP64: float on any device (src/core/context.c) */
#define CLVOX_FP64 1
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double clvox_real;
#else
typedef float clvox_real;
#endif

/* Sign of the edge function of directed edge (a,b) for a ray at p, given
 * A = a - p and B = b - p in the ray plane (.x = v, .y = w).
 * E(b,a) == -E(a,b) exactly (same products), so an edge shared by two
 * triangles is judged the same way from both. E == 0 (p on the edge's line)
 * is broken by a symbolic perturbation p + eps*(1, eps'): the sign of the
 * derivative of E in that direction. 0 only for a degenerate edge. */
static inline int clvox_edge_sign(clvox_real Av, clvox_real Aw, clvox_real Bv, clvox_real Bw, clvox_real *e_out)
{
    clvox_real e = Av * Bw - Aw * Bv;
    *e_out = e;
    if (e != 0) return e > 0 ? 1 : -1;
    clvox_real dw = Aw - Bw;
    if (dw != 0) return dw > 0 ? 1 : -1;
    clvox_real dv = Bv - Av;
    if (dv != 0) return dv > 0 ? 1 : -1;
    return 0;
}

/* Does the ray at (pv,pw) along +u cross the triangle with corners a, b, c
 * (3 floats each, u,v,w, grid space)? If so *u_hit is where, and the
 * result is the crossing's orientation: +1 when the corners run
 * counter-clockwise in the (v,w) plane (the face's normal points to +u),
 * -1 clockwise; 0: no crossing. Both windings count. */
static inline int clvox_ray_crosses(global const float *a, global const float *b, global const float *c, float fpv,
                                    float fpw, clvox_real *u_hit)
{
    clvox_real pv = fpv, pw = fpw;
    clvox_real Av = (clvox_real)a[1] - pv, Aw = (clvox_real)a[2] - pw;
    clvox_real Bv = (clvox_real)b[1] - pv, Bw = (clvox_real)b[2] - pw;
    clvox_real Cv = (clvox_real)c[1] - pv, Cw = (clvox_real)c[2] - pw;
    clvox_real eab, ebc, eca;
    int sab = clvox_edge_sign(Av, Aw, Bv, Bw, &eab);
    int sbc = clvox_edge_sign(Bv, Bw, Cv, Cw, &ebc);
    int sca = clvox_edge_sign(Cv, Cw, Av, Aw, &eca);
    if (sab == 0 || sab != sbc || sab != sca) return 0;
    /* Barycentric interpolation anchored at a: a face of constant u gives
     * exactly that u. The weights share one sign, so den != 0. */
    clvox_real ua = a[0];
    clvox_real num = eca * ((clvox_real)b[0] - ua) + eab * ((clvox_real)c[0] - ua);
    clvox_real den = eab + ebc + eca;
    *u_hit = ua + num / den;
    return sab;
}

/* The contraction self-test (src/core/device_checks.c): a*b - c*d for
 * (a, b, c, d) = in[4i .. 4i+3], as the predicates compute it (through
 * clvox_edge_sign, under this file's FP_CONTRACT OFF), and in float. */
kernel void clvox_contraction_probe(global const clvox_real *in, global clvox_real *out, global const float *fin,
                                    global float *fout)
{
    const size_t i = get_global_id(0);
    clvox_real e;
    (void)clvox_edge_sign(in[4 * i], in[4 * i + 2], in[4 * i + 3], in[4 * i + 1], &e); /* Av Bw - Aw Bv */
    out[i] = e;
    fout[i] = fin[4 * i] * fin[4 * i + 1] - fin[4 * i + 2] * fin[4 * i + 3];
}

/* Lets the host learn which precision the compiler picked. */
kernel void clvox_real_size(global uint *out) { out[0] = (uint)sizeof(clvox_real); }

/* Completion count of a launch (src/core/launch.c): each kernel ends by
 * calling this in every work-item, and the last work-item of each
 * work-group adds one to done[slot] once it has run. The host compares the
 * count with the launch's number of work-groups, so that a kernel that the
 * runtime stopped (Oclgrind does, with no error to the host) fails the run
 * instead of leaving voxels unset. One atomic per work-group. */
static void clvox_done_mark(global uint *done, uint slot)
{
    if (get_local_id(0) == get_local_size(0) - 1) atomic_inc(done + slot);
#if defined(CLVOX_TEST_BROKEN_KERNEL)
    /* Never in clvox's builds: tests/test_oclgrind.sh passes it through
     * oclgrind --build-options to check that a broken kernel fails the test
     * (1: a write one past the buffer, 2: a data race). */
    if (CLVOX_TEST_BROKEN_KERNEL == 1 && get_global_id(0) == get_global_offset(0)) done[CLVOX_LAUNCH_SLOTS] = slot;
    if (CLVOX_TEST_BROKEN_KERNEL == 2) done[CLVOX_LAUNCH_SLOTS - 1] = get_global_id(0);
#endif
}
