/* SPDX-License-Identifier: Apache-2.0 */
/* Winding numbers (winding_angles.h): the inside test of a point, the cap
 * tree refined best-first (bounds of winding_bounds.h, exact solid angles of
 * winding_angles.h) until the answer is certain. */

/* A cut of the cap tree kept from one point to the next along a ray
 * (clvox_winding_inside_m): node ids, CLVOX_CUT_EXACT on those evaluated
 * exactly. Any cut (frontier + exact nodes covering every leaf once) is a
 * valid start; a neighbour's saves most of the descent. */
#define CLVOX_CUT_MAX 384 /* above the frontier's CLVOX_CAP_STACK: a cut holds it and the exact nodes */
#define CLVOX_CUT_EXACT 0x80000000u

/* Multiplies the node's caps into a. */
static inline void clvox_cap_node_angles(global const clvox_cap_node *nd, global const clvox_real *caps,
                                         global const float *gcaps, const clvox_real *g, clvox_real px, clvox_real py,
                                         clvox_real pz, uint axis, clvox_angles *a)
{
    const uint first = nd->tri_first, count = nd->tri_count;
    if (nd->block) { /* a leaf (at most 4 caps) */
        clvox_cap_block4(caps + nd->block, caps + (size_t)first * 9u, gcaps + (size_t)first * 9u, g, count, px, py,
                         pz, axis, a);
        return;
    }
    for (uint t = 0; t < count; t += 4u)
        clvox_cap_angles4(caps + (size_t)(first + t) * 9u, gcaps + (size_t)(first + t) * 9u, g, min(count - t, 4u),
                          px, py, pz, axis, a);
}

/* The node's caps' solid angles / 4pi at p, exactly; adds the value's
 * error bound to *err (clvox_angles_value). */
static inline clvox_real clvox_cap_node_exact(global const clvox_cap_node *nd, global const clvox_real *caps,
                                              global const float *gcaps, const clvox_real *g, clvox_real px,
                                              clvox_real py, clvox_real pz, uint axis, clvox_real *err)
{
    clvox_angles a;
    clvox_angles_init(&a);
    clvox_cap_node_angles(nd, caps, gcaps, g, px, py, pz, axis, &a);
    return clvox_angles_value(&a, err);
}

/* The inside test at p (scaled grid space, x, y, z; g: its grid
 * coordinates, gcaps the caps', for CLVOX_EXACT_SIGNS) given K there:
 * best-first refinement of the cap tree, each frontier node an estimate
 * and an error bound, until [K - S - sum est -+ sum err] lies on one side
 * of the threshold (S: the caps evaluated exactly). Adds 1 to *exact when
 * cap solid angles had to be evaluated; [*wlo, *whi] holds w. With `tight`
 * the refinement goes on past the decision (at most `tight` steps) until
 * the error bound is at most CLVOX_TIGHT_F of w's distance from the
 * threshold, so that the caller can reuse the interval nearby. cut (may be
 * 0): in, a cut to start from (*cut_n entries; 0: the root); out, this
 * point's (*cut_n = 0 when it does not fit). */
static inline int clvox_winding_inside_m(int K, uint abs_mode, global const clvox_cap_node *nodes, uint node_count,
                                         global const clvox_real *caps, global const float *gcaps, const clvox_real *g,
                                         clvox_real px, clvox_real py, clvox_real pz, uint axis, uint tight,
                                         uint *exact, clvox_real *wlo, clvox_real *whi, uint *cut, uint *cut_n)
{
    const clvox_real thr = (clvox_real)0.5 + (clvox_real)CLVOX_WINDING_TIE;
    *wlo = *whi = (clvox_real)K;
    if (node_count == 0) return abs_mode ? K != 0 : K >= 1;
    const int pairs = CLVOX_PAIR_TREE(nodes, node_count); /* the slab bounds only where there are pairs */
    const clvox_real dp = clvox_point_rounding(px, py, pz, axis);
    uint stack[CLVOX_CAP_STACK];
    clvox_real se[CLVOX_CAP_STACK], sb[CLVOX_CAP_STACK];
    uint ex[CLVOX_CUT_MAX];
    uint sp = 0, nex = 0;
    clvox_real S = 0;
    clvox_real serr = 0; /* S's error bound (clvox_angles_value, and in float its sums) */
    int evaluated = 0, answer = -1, lost = 0; /* lost: the exact nodes do not fit ex */
    if (cut && *cut_n) {
        clvox_angles all; /* the cut's exact nodes: one product, one atan2 */
        clvox_angles_init(&all);
        for (uint i = 0; i < *cut_n; i++) {
            const uint nd = cut[i] & ~CLVOX_CUT_EXACT;
            if (cut[i] & CLVOX_CUT_EXACT) {
                clvox_cap_node_angles(nodes + nd, caps, gcaps, g, px, py, pz, axis, &all);
                ex[nex++] = nd;
                evaluated = 1;
            } else {
                stack[sp++] = nd;
            }
        }
        uint i = 0; /* the frontier's estimates, four or two at a time */
        for (; i + 3u < sp; i += 4u)
            clvox_cap_estimate4(nodes + stack[i], nodes + stack[i + 1u], nodes + stack[i + 2u], nodes + stack[i + 3u],
                                px, py, pz, dp, pairs, se + i, sb + i);
        for (; i + 1u < sp; i += 2u)
            clvox_cap_estimate2(nodes + stack[i], nodes + stack[i + 1u], px, py, pz, dp, pairs, se + i, sb + i);
        if (i < sp) clvox_cap_estimate(nodes + stack[i], px, py, pz, dp, pairs, &se[i], &sb[i]);
        S = clvox_angles_value(&all, &serr);
    } else {
        stack[sp] = 0;
        clvox_cap_estimate(nodes, px, py, pz, dp, pairs, &se[sp], &sb[sp]);
        sp++;
    }
    uint extra = 0;
    /* Running sums of the frontier's bounds and estimates pick the steps
     * at which to look: only where they decide (or once decided, in the
     * tight phase) are the sums taken afresh, in frontier order, and it is
     * those that decide and bound w. The running ones drift by their
     * subtractions, which can only cost a step or a fresh sum, never the
     * rigour of the answer. */
    clvox_real Br = 0, Er = 0;
    for (uint i = 0; i < sp; i++) {
        Br += sb[i];
        Er += se[i];
    }
    for (;;) {
        uint best = 0;
        clvox_real bv = sb[0]; /* the first largest bound (sp == 0: unused) */
        for (uint i = 1; i < sp; i++) {
            const int gt = sb[i] > bv;
            best = gt ? i : best;
            bv = gt ? sb[i] : bv;
        }
        /* the sums' own rounding, and S's (clvox_angles_value) */
        const clvox_real slack = (clvox_real)1e-12 + serr;
        const clvox_real wr = (clvox_real)K - S - Er, Bq = Br * (clvox_real)CLVOX_SUM_ROUND + slack;
        /* decided: the tight phase ends after `tight` steps, or where the
         * bound is within CLVOX_TIGHT_F of w's distance from the threshold */
        int last = 0, look;
        if (answer >= 0) {
            last = extra++ >= tight;
            const clvox_real dr = abs_mode ? fmin(fabs(wr - thr), fabs(wr + thr)) : fabs(wr - thr);
            look = sp == 0 || last || Bq <= (clvox_real)CLVOX_TIGHT_F * dr;
        } else {
            look = sp == 0 || clvox_interval_inside(wr - Bq, wr + Bq, abs_mode) >= 0;
        }
        if (look) {
            clvox_real B = 0, E = 0, EA = 0;
            for (uint i = 0; i < sp; i++) {
                B += sb[i];
                E += se[i];
#if !defined(CLVOX_FP64)
                EA += fabs(se[i]);
#endif
            }
            Br = B;
            Er = E;
            B = B * (clvox_real)CLVOX_SUM_ROUND + slack;
            const clvox_real w = (clvox_real)K - S - E;
#if !defined(CLVOX_FP64)
            /* float: the estimates' sum (sp terms) and K - S - E rounded */
            B += (clvox_real)1.01f * CLVOX_REAL_U *
                 ((clvox_real)(sp + 2u) * EA + 2 * (fabs((clvox_real)K) + fabs(S) + fabs(E)));
#else
            (void)EA;
#endif
            if (answer < 0) {
                answer = clvox_interval_inside(w - B, w + B, abs_mode);
                if (answer >= 0) last = extra++ >= tight;
            }
            const clvox_real dist = abs_mode ? fmin(fabs(w - thr), fabs(w + thr)) : fabs(w - thr);
            int stop = sp == 0 || (answer >= 0 && (last || B <= (clvox_real)CLVOX_TIGHT_F * dist));
#if !defined(CLVOX_FP64)
            /* float: where the part of B that refining cannot shrink (S's
             * error, the sums' rounding) dominates, refining is wasted: a
             * decided point stops tightening, an undecided one whose
             * interval would straddle the threshold even with the frontier's
             * bounds gone goes to the host now (either only changes how
             * much work is done, never a voxel: the host decides exactly) */
            {
                const clvox_real refinable = Br * (clvox_real)CLVOX_SUM_ROUND, fixed = B - refinable;
                if (answer >= 0 && refinable <= fixed) stop = 1;
                if (answer < 0 && dist + refinable <= fixed) stop = 1;
            }
#endif
            if (stop) {
                if (evaluated) (*exact)++;
                *wlo = w - B;
                *whi = w + B; /* w lies in [w - B, w + B] */
                if (cut) {
                    if (lost || sp + nex > CLVOX_CUT_MAX) {
                        *cut_n = 0;
                    } else {
                        for (uint i = 0; i < sp; i++) cut[i] = stack[i];
                        for (uint i = 0; i < nex; i++) cut[sp + i] = ex[i] | CLVOX_CUT_EXACT;
                        *cut_n = sp + nex;
                    }
                }
                if (answer >= 0) return answer;
                const int guess = abs_mode ? (w > thr || w < -thr) : w > thr;
#if defined(CLVOX_FP64)
                return guess;
#else
                return guess | CLVOX_UNSURE; /* decided by the host (src/cast/unsure.c) */
#endif
            }
        }
        Br -= sb[best];
        Er -= se[best];
        const uint nd = stack[best];
        stack[best] = stack[sp - 1u];
        sb[best] = sb[sp - 1u];
        se[best] = se[sp - 1u];
        sp--;
        const uint child = nodes[nd].child;
        if (child == 0 || sp + 2u > CLVOX_CAP_STACK) { /* evaluate the node's caps exactly */
            S += clvox_cap_node_exact(nodes + nd, caps, gcaps, g, px, py, pz, axis, &serr);
#if !defined(CLVOX_FP64)
            serr += CLVOX_REAL_U * fabs(S); /* the sum's rounding */
#endif
            evaluated = 1;
            if (nex < CLVOX_CUT_MAX) ex[nex++] = nd;
            else lost = 1;
        } else {
            stack[sp] = child;
            stack[sp + 1u] = child + 1u;
            clvox_cap_estimate2(nodes + child, nodes + child + 1u, px, py, pz, dp, pairs, se + sp, sb + sp);
            Br += sb[sp] + sb[sp + 1u];
            Er += se[sp] + se[sp + 1u];
            sp += 2u;
        }
    }
}

/* clvox_winding_inside_m started from the cut of the last evaluation
 * nearby (any cut is a valid start; a neighbour's saves most of the
 * descent), which is dropped once it has grown much past a fresh start's
 * (a cut only refines): *fresh_exact holds the exact nodes of the last
 * fresh start. */
static inline int clvox_winding_inside_cut(int K, uint abs_mode, global const clvox_cap_node *nodes, uint node_count,
                                           global const clvox_real *caps, global const float *gcaps,
                                           const clvox_real *g, clvox_real px, clvox_real py, clvox_real pz, uint axis,
                                           uint tight, uint *exact, clvox_real *lo, clvox_real *hi, uint *cut,
                                           uint *cut_n, uint *fresh_exact)
{
    const int fresh = *cut_n == 0;
    const int inside = clvox_winding_inside_m(K, abs_mode, nodes, node_count, caps, gcaps, g, px, py, pz, axis,
                                              tight, exact, lo, hi, cut, cut_n);
    uint cut_exact = 0;
    for (uint i = 0; i < *cut_n; i++) cut_exact += (cut[i] & CLVOX_CUT_EXACT) != 0;
    if (fresh) *fresh_exact = cut_exact;
    else if (cut_exact > *fresh_exact + *fresh_exact / 2u + 2u) *cut_n = 0;
    return inside;
}

/* A point the float build could not certify (CLVOX_UNSURE), appended to
 * the list the host reads after the batch (unsure[0]: entries wanted,
 * unsure[1]: room; the entries from unsure[2], CLVOX_UNSURE_WORDS words
 * each): binary runs (kernels/winding.cl) ray gid, voxel j of the slab's
 * stretch, K there, 0; the column runs (coverage.cl, palette_score.cl)
 * column gid, voxel j, K, ray r << 8 | point m. Decided by
 * src/cast/unsure.c. */
#define CLVOX_UNSURE_WORDS 4u
static inline void clvox_unsure_push(global uint *unsure, uint gid, uint j, uint a, uint b)
{
    const uint i = atomic_inc(unsure);
    if (i < unsure[1]) {
        global uint *e = unsure + 2 + (size_t)i * CLVOX_UNSURE_WORDS;
        e[0] = gid;
        e[1] = j;
        e[2] = a;
        e[3] = b;
    }
}

/* A column run's second pass (src/cast/unsure.c): the host's answer for
 * sample (ray r, point m: rm = r << 8 | m) of voxel j of column gid, which
 * the first pass left unsure. answers[3i ..] = (column, voxel, rm | inside
 * << 31), sorted by those three. 2: not there (on the first pass, none). */
static inline uint clvox_unsure_answer(global const uint *answers, uint n, uint gid, uint j, uint rm)
{
    uint lo = 0, hi = n;
    while (lo < hi) {
        const uint mid = lo + (hi - lo) / 2u;
        global const uint *a = answers + 3u * mid;
        const uint key = a[2] & 0x7FFFFFFFu;
        const int less = a[0] < gid || (a[0] == gid && (a[1] < j || (a[1] == j && key < rm)));
        if (less) lo = mid + 1u;
        else hi = mid;
    }
    if (lo < n && answers[3u * lo] == gid && answers[3u * lo + 1u] == j && (answers[3u * lo + 2u] & 0x7FFFFFFFu) == rm)
        return answers[3u * lo + 2u] >> 31;
    return 2u;
}

/* A column run's second pass runs only the columns that have answers
 * (src/cast/unsure.c resolve_columns): then answers[0] is their count n,
 * answers[1 .. n] the columns, ascending, and the answers proper follow.
 * Work-item *gid takes the *gid-th of them; 0: none left for it. On the
 * first pass (n_answers 0) every work-item is its own column. */
static inline int clvox_pass_column(uint *gid, global const uint **answers, uint n_answers)
{
    if (!n_answers) return 1;
    const uint n = (*answers)[0];
    if (*gid >= n) return 0;
    *gid = (*answers)[1u + *gid];
    *answers += 1u + n;
    return 1;
}

/* The inside test of a column run's unsure sample: the host's answer where
 * there is one, else the sample goes to the host's list (and `guess`
 * stands until the second pass). */
static inline uint clvox_unsure_sample(global uint *unsure, global const uint *answers, uint n_answers, uint gid,
                                       uint j, int K, uint rm, uint guess)
{
    const uint a = n_answers ? clvox_unsure_answer(answers, n_answers, gid, j, rm) : 2u;
    if (a < 2u) return a;
    clvox_unsure_push(unsure, gid, j, (uint)K, rm);
    return guess;
}
