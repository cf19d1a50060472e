/* Stage cast: sort each ray's crossings by increasing u. Short lists (the
 * fast pass keeps at most `capacity`, 32 by default) are insertion-sorted in
 * private memory; long ones (overflow redo: up to CLVOX__MAX_CROSSINGS, e.g.
 * a surface duplicated many times) are heap-sorted in place, O(n log n)
 * whatever the order. */
#ifndef CLVOX_SORT_PRIVATE
#define CLVOX_SORT_PRIVATE 64
#endif

/* Sift h[i] down the max-heap h[0 .. n). */
inline void clvox_sift_down(global clvox_real *h, uint i, uint n)
{
    clvox_real x = h[i];
    for (;;) {
        uint c = 2u * i + 1u;
        if (c >= n) break;
        if (c + 1u < n && h[c + 1u] > h[c]) c++;
        if (!(h[c] > x)) break;
        h[i] = h[c];
        i = c;
    }
    h[i] = x;
}

kernel void clvox_sort(uint ray_count, uint capacity, global clvox_real *hits, global const uint *counts)
{
    uint gid = get_global_id(0);
    if (gid >= ray_count) return;
    uint n = counts[gid];
    if (n > capacity) return; /* overflowed: redone by the host */
    global clvox_real *h = hits + (size_t)gid * capacity;
    if (n <= CLVOX_SORT_PRIVATE) {
        clvox_real a[CLVOX_SORT_PRIVATE];
        for (uint i = 0; i < n; i++) {
            clvox_real x = h[i];
            uint j = i;
            while (j > 0 && a[j - 1] > x) { a[j] = a[j - 1]; j--; }
            a[j] = x;
        }
        for (uint i = 0; i < n; i++) h[i] = a[i];
    } else {
        for (uint i = n / 2u; i-- > 0;) clvox_sift_down(h, i, n);
        for (uint end = n - 1u; end > 0; end--) {
            clvox_real t = h[0];
            h[0] = h[end];
            h[end] = t;
            clvox_sift_down(h, 0, end);
        }
    }
}
