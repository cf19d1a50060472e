/* Stage cast: sort each ray's crossings by increasing u (insertion sort:
 * lists are short; the few long ones come from the overflow pass). */

#ifndef CLVOX_SORT_PRIVATE
#define CLVOX_SORT_PRIVATE 64
#endif

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
        for (uint i = 1; i < n; i++) {
            clvox_real x = h[i];
            uint j = i;
            while (j > 0 && h[j - 1] > x) { h[j] = h[j - 1]; j--; }
            h[j] = x;
        }
    }
}
