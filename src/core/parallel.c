/* SPDX-License-Identifier: Apache-2.0 */
/* Host threads (parallel.h): a fork/join of n parts, one pthread each. */
#include "parallel.h"

#include "environment.h"

#include <pthread.h>
#include <stdlib.h>
#include <unistd.h>

int clvox__host_threads(void)
{
    int v = clvox__hooks()->host_threads;
    if (v >= 1) return v > CLVOX__MAX_HOST_THREADS ? CLVOX__MAX_HOST_THREADS : v;
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    if (n < 1) n = 1;
    return n > 8 ? 8 : (int)n;
}

void clvox__part_range(size_t count, int i, int n, size_t *begin, size_t *end)
{
    /* count * i / n without overflow for any size_t count and n <= 16 */
    size_t q = count / (size_t)n, r = count % (size_t)n;
    *begin = q * (size_t)i + (r * (size_t)i) / (size_t)n;
    *end = q * (size_t)(i + 1) + (r * (size_t)(i + 1)) / (size_t)n;
}

typedef struct part {
    void (*fn)(void *, int, int);
    void *arg;
    int i, n;
} part;

static void *part_main(void *p)
{
    part *w = p;
    w->fn(w->arg, w->i, w->n);
    return NULL;
}

void clvox__parallel(int n, void (*fn)(void *arg, int i, int n), void *arg)
{
    if (n > CLVOX__MAX_HOST_THREADS) n = CLVOX__MAX_HOST_THREADS;
    if (n <= 1) {
        fn(arg, 0, 1);
        return;
    }
    pthread_t th[CLVOX__MAX_HOST_THREADS];
    part w[CLVOX__MAX_HOST_THREADS];
    int started[CLVOX__MAX_HOST_THREADS] = {0};
    for (int i = 1; i < n; i++) {
        w[i] = (part){fn, arg, i, n};
        started[i] = pthread_create(&th[i], NULL, part_main, &w[i]) == 0;
    }
    fn(arg, 0, n);
    for (int i = 1; i < n; i++) {
        if (started[i]) pthread_join(th[i], NULL);
        else fn(arg, i, n);
    }
}
