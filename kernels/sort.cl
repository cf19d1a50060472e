/* SPDX-License-Identifier: Apache-2.0 */
/* Stage cast: sort each ray's crossings by increasing u. Short lists (the
 * fast pass keeps at most `capacity`, 32 by default) are insertion-sorted in
 * private memory; long ones (overflow redo: up to CLVOX__MAX_CROSSINGS, e.g.
 * a surface duplicated many times) are heap-sorted in place, O(n log n)
 * whatever the order. With `signs` (winding runs) each crossing's sign
 * moves with it. */
#ifndef CLVOX_SORT_PRIVATE
#define CLVOX_SORT_PRIVATE 64
#endif

/* Sift h[i] down the max-heap h[0 .. n) (and its sign, if sg). */
static inline void clvox_sift_down(global clvox_real *h, global char *sg, uint i, uint n)
{
    clvox_real x = h[i];
    char xs = sg ? sg[i] : 0;
    for (;;) {
        uint c = 2u * i + 1u;
        if (c >= n) break;
        if (c + 1u < n && h[c + 1u] > h[c]) c++;
        if (!(h[c] > x)) break;
        h[i] = h[c];
        if (sg) sg[i] = sg[c];
        i = c;
    }
    h[i] = x;
    if (sg) sg[i] = xs;
}

/* Insertion sort of (crossing, sign) pairs in private memory. */
static inline void clvox_sort_signed(global clvox_real *h, global char *sg, uint n)
{
    clvox_real a[CLVOX_SORT_PRIVATE];
    char as[CLVOX_SORT_PRIVATE];
    for (uint i = 0; i < n; i++) {
        clvox_real x = h[i];
        char xs = sg[i];
        uint j = i;
        while (j > 0 && a[j - 1] > x) {
            a[j] = a[j - 1];
            as[j] = as[j - 1];
            j--;
        }
        a[j] = x;
        as[j] = xs;
    }
    for (uint i = 0; i < n; i++) {
        h[i] = a[i];
        sg[i] = as[i];
    }
}

static void clvox_sort_body(uint ray_count, uint capacity, global clvox_real *hits, global const uint *counts,
                            global char *signs)
{
    uint gid = get_global_id(0);
    if (gid >= ray_count) return;
    uint n = counts[gid];
    if (n > capacity) return; /* overflowed: redone by the host */
    global clvox_real *h = hits + (size_t)gid * capacity;
    global char *sg = signs ? signs + (size_t)gid * capacity : 0;
    if (sg && n <= CLVOX_SORT_PRIVATE) {
        clvox_sort_signed(h, sg, n);
    } else if (n <= CLVOX_SORT_PRIVATE) {
        clvox_real a[CLVOX_SORT_PRIVATE];
        for (uint i = 0; i < n; i++) {
            clvox_real x = h[i];
            uint j = i;
            while (j > 0 && a[j - 1] > x) { a[j] = a[j - 1]; j--; }
            a[j] = x;
        }
        for (uint i = 0; i < n; i++) h[i] = a[i];
    } else {
        for (uint i = n / 2u; i-- > 0;) clvox_sift_down(h, sg, i, n);
        for (uint end = n - 1u; end > 0; end--) {
            clvox_real t = h[0];
            h[0] = h[end];
            h[end] = t;
            if (sg) {
                char ts = sg[0];
                sg[0] = sg[end];
                sg[end] = ts;
            }
            clvox_sift_down(h, sg, 0, end);
        }
    }
}

/* The kernel: the body, then the launch's completion count (clvox_done,
 * prelude.cl). */
kernel void clvox_sort(uint ray_count, uint capacity, global clvox_real *hits, global const uint *counts,
                       global char *signs,
                       global uint *clvox_done, uint clvox_done_slot)
{
    clvox_sort_body(ray_count, capacity, hits, counts, signs);
    clvox_done_mark(clvox_done, clvox_done_slot);
}
