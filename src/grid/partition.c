/* SPDX-License-Identifier: Apache-2.0 */
/* Stage partition: quadtree over the projection of the triangles onto the
 * ray plane (Thon et al. 3.2). A node is split into 4 at its centre while it
 * holds more than `leaf_size` triangles and is shallower than `max_depth`.
 * A triangle goes to every child its projected bounding box touches
 * (closed intervals, slightly widened), so the leaf a ray lands in holds
 * every triangle the ray can cross.
 *
 * A split that does not separate the triangles is not made: when the four
 * children would hold 3 times the node's triangles or more (most of them
 * span both split lines: large or coincident triangles), a ray would still
 * test three quarters of them, and the references would multiply by up to 4
 * per level (a surface duplicated a million times asked for 32 GB). The
 * references are also capped (MAX_REFS) as a last guard; any leaf that holds
 * every triangle it touches is correct, so these rules change speed only.
 *
 * Layout (what the cast kernels read): nodes in the order of a depth-first
 * build, the 4 children of a node allocated together when it is split, then
 * built one after the other; leaf references in the order the leaves are
 * made, each leaf's triangles in increasing index.
 *
 * On several host threads (parallel.h) the top SKELETON_DEPTH levels are
 * built first, the subtrees below them become tasks built independently
 * into arrays of their own, and one walk over the skeleton then lays
 * everything out exactly as the one-thread build would: the same nodes and
 * the same references in the same order. A node's decisions depend only on
 * its triangles and bounds, except for the MAX_REFS guard, which depends on
 * the references made before it; so when the result comes near that guard
 * the tree is built again on one thread. tests/test_partition.c compares
 * the two at 1 to 4 threads.
 *
 * Memory. The triangles come indexed (grid-space vertices and the mesh's
 * own index array) or as a soup. No list of all of them is made: a pass
 * over the triangles counts the root's children and marks, per triangle,
 * which ones it goes to; each child's list is then streamed out on its own,
 * just before it is built. Large nodes make their children's lists one at
 * a time, shrinking their own list as they go (LEAN_ITEMS), and the
 * skeleton runs its tasks as soon as their lists add up (PENDING_ITEMS).
 * armadillo_s3 (3.3 M triangles) at 512^3: the build's peak is about
 * 50 MB on 1 thread, 55-60 MB on 2 above what it starts with, its 21 MB of
 * references included; making all four children of every node at once and
 * all the skeleton's tasks before running them, it was 78 and 105 MB. */
#include "core/internal.h"
#include "core/parallel.h"

#include <math.h>
#include <stdatomic.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <stdlib.h>
#include <string.h>

/* At most this many references in all (4 bytes each): past it, nodes stay leaves. */
#define MAX_REFS ((size_t)1 << 28)
/* More references than a 32-bit index reaches: an error. */
#define MAX_TOTAL_REFS 0xFFFFFFF0u
/* Levels built before the tasks (up to 4^3 = 64 subtrees to share out). */
#define SKELETON_DEPTH 3
/* Fewer triangles than this: one thread. */
#define MIN_PARALLEL_TRIANGLES 20000
/* A node holding this many triangles or more makes its children's lists
 * one at a time instead of all four in one pass, and its own list shrinks
 * to what the children not made yet need: less memory held at once (the
 * lists of the top levels are tens of MB), one more pass over the list per
 * child. */
#define LEAN_ITEMS ((size_t)1 << lean_bits())
/* The skeleton runs its tasks when their lists hold this many triangles. */
#define PENDING_ITEMS ((size_t)1 << (lean_bits() + 1))
/* 2^20: at 2^16 / 2^17 the peak was the same to a few MB on a 3.3 M-triangle
 * mesh (the lists are then a few MB), but the two host threads overlapped
 * less (partition 0.23 -> 0.29 s). CLVOX_PARTITION_LEAN_BITS (10..24)
 * overrides it, so that tests reach these paths with small meshes; the
 * tree is the same at any value. */
static unsigned lean_bits(void)
{
    unsigned bits = clvox__hooks()->partition_lean_bits;
    return bits ? bits : 20;
}
/* In the skeleton: a node whose subtree is task `first`. */
#define NODE_TASK 0xFFFFFFFEu

/* A triangle in a node's list: its widened (v,w) box and its index. Lists
 * carry the boxes so that every pass over a node streams through memory. */
typedef struct item {
    float v0, w0, v1, w1;
    uint32_t id;
} item;

/* Does the item's box meet the closed box [v0, v1] x [w0, w1]? */
static inline int item_meets(const item *it, float v0, float w0, float v1, float w1)
{
    return it->v0 <= v1 && it->v1 >= v0 && it->w0 <= w1 && it->w1 >= w0;
}

/* The lowest set bit of m (m != 0). */
static inline unsigned lowest_bit(unsigned m)
{
#if defined(__GNUC__)
    return (unsigned)__builtin_ctz(m);
#else
    unsigned k = 0;
    while (!(m >> k & 1u)) k++;
    return k;
#endif
}

/* The children of a node that an item of the node's list goes to: bit q
 * (q & 1: the high half in v, q & 2: in w). Every list holds only items
 * that meet its node's closed box, so child q's box test (item_meets)
 * reduces to the two split lines: the same answer, without its four loads
 * and branches per child. */
static inline unsigned item_quadrants(const item *it, float sv, float sw)
{
    unsigned lv = it->v0 <= sv, hv = it->v1 >= sv, lw = it->w0 <= sw, hw = it->w1 >= sw;
    return (lv & lw) | (hv & lw) << 1 | (lv & hw) << 2 | (hv & hw) << 3;
}

typedef struct task {
    item *list; /* owned */
    size_t n;
    float v0, w0, v1, w1;
    uint32_t depth;
    /* its subtree: nodes[0] is the task's node, refs from 0 */
    clvox_qt_node *nodes;
    size_t node_count;
    uint32_t *refs;
    size_t ref_count;
    uint32_t max_depth_reached;
    size_t leaves;
    int rc; /* build_node's */
} task;

typedef struct build {
    uint32_t max_depth, leaf_size;
    uint32_t defer_depth;  /* nodes at this depth become tasks; 0: never */
    clvox_qt_node *nodes;
    size_t node_count, node_cap;
    uint32_t *refs;
    size_t ref_count, ref_cap;
    uint32_t depth;
    size_t leaves;
    task *tasks;
    size_t task_count, task_cap;
    size_t tasks_done;    /* tasks [0, tasks_done) have run */
    size_t pending_items; /* in the lists of the tasks not run yet */
    int threads;          /* for the tasks */
} build;

static void run_pending_tasks(build *b);
static void release_free_memory(void);

static int grow(void **p, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap) return 1;
    size_t n = *cap ? *cap : 1024;
    while (n < need) n *= 2;
    void *q = realloc(*p, n * elem);
    if (!q) return 0;
    *p = q;
    *cap = n;
    return 1;
}

/* Leaves: default depth so that the smallest cell is about 2 columns wide,
 * capped at 12 (Thon's Table 3: gains stop around depth 10). */
uint32_t clvox__quadtree_auto_depth(uint32_t dim_v, uint32_t dim_w, size_t tri_count)
{
    uint32_t dim = dim_v > dim_w ? dim_v : dim_w;
    uint32_t d = 0;
    while (d < 12 && (dim >> (d + 1)) >= 2) d++;
    /* No point in more leaves than about 4 per triangle. */
    while (d > 0 && ((size_t)1 << (2 * d)) > 4 * tri_count + 4) d--;
    return d;
}

/* list (n items, owned: freed here, NULL when n == 0) is the node's
 * triangles in increasing index. Returns 1, 0 when memory runs out, -1
 * past MAX_TOTAL_REFS. */
static int build_node(build *b, size_t node, item *list, size_t n, float v0, float w0, float v1, float w1,
                      uint32_t depth)
{
    if (b->defer_depth && depth == b->defer_depth) {
        if (!grow((void **)&b->tasks, &b->task_cap, b->task_count + 1, sizeof *b->tasks)) {
            free(list);
            return 0;
        }
        task *t = &b->tasks[b->task_count];
        memset(t, 0, sizeof *t);
        t->list = list;
        t->n = n;
        t->v0 = v0, t->w0 = w0, t->v1 = v1, t->w1 = w1;
        t->depth = depth;
        b->nodes[node].first = (uint32_t)b->task_count++;
        b->nodes[node].count = NODE_TASK;
        b->nodes[node].split_v = b->nodes[node].split_w = 0;
        /* run the tasks when their lists add up: they are not all held at once */
        b->pending_items += n;
        if (b->pending_items >= PENDING_ITEMS) run_pending_tasks(b);
        return 1;
    }
    if (depth > b->depth) b->depth = depth;
    float sv = 0.5f * (v0 + v1), sw = 0.5f * (w0 + w1);
    int leaf = n <= b->leaf_size || depth >= b->max_depth;
    /* Child q: v in [v0,sv] or [sv,v1], w likewise (closed). */
    float cv0[4], cv1[4], cw0[4], cw1[4];
    for (int q = 0; q < 4; q++) {
        cv0[q] = (q & 1) ? sv : v0, cv1[q] = (q & 1) ? v1 : sv;
        cw0[q] = (q & 2) ? sw : w0, cw1[q] = (q & 2) ? w1 : sw;
    }
    size_t count[4] = {0, 0, 0, 0};
    if (!leaf) { /* does a split separate the triangles? (children's sizes, one pass) */
        size_t c0 = 0, c1 = 0, c2 = 0, c3 = 0; /* in registers: count[] in memory was a chain of stores */
        for (size_t i = 0; i < n; i++) {
            const unsigned m = item_quadrants(&list[i], sv, sw);
            c0 += m & 1u, c1 += m >> 1 & 1u, c2 += m >> 2 & 1u, c3 += m >> 3;
        }
        count[0] = c0, count[1] = c1, count[2] = c2, count[3] = c3;
        const size_t sum = count[0] + count[1] + count[2] + count[3]; /* quadrants touched: 1, 2 or 4 each */
        leaf = sum >= 3 * n || b->ref_count + sum > MAX_REFS;
    }
    if (leaf) {
        if (!grow((void **)&b->refs, &b->ref_cap, b->ref_count + n, sizeof *b->refs)) {
            free(list);
            return 0;
        }
        b->nodes[node].first = (uint32_t)b->ref_count;
        b->nodes[node].count = (uint32_t)n;
        b->nodes[node].split_v = b->nodes[node].split_w = 0;
        for (size_t i = 0; i < n; i++) b->refs[b->ref_count + i] = list[i].id;
        free(list);
        b->ref_count += n;
        b->leaves++;
        return b->ref_count <= MAX_TOTAL_REFS ? 1 : -1;
    }
    /* An internal node: its four children are nodes first .. first + 3. */
    if (!grow((void **)&b->nodes, &b->node_cap, b->node_count + 4, sizeof *b->nodes)) {
        free(list);
        return 0;
    }
    const size_t first = b->node_count;
    b->node_count += 4;
    b->nodes[node].split_v = sv;
    b->nodes[node].split_w = sw;
    b->nodes[node].first = (uint32_t)first;
    b->nodes[node].count = CLVOX_QT_INTERNAL;
    if (n >= LEAN_ITEMS) { /* one child's list at a time (same lists, same order) */
        /* The same pass keeps in the list only what the later children
         * need, and the list shrinks before child q is built. */
        int ok = 1;
        for (int q = 0; q < 4 && ok == 1; q++) {
            item *sub = count[q] ? malloc((count[q] + 1) * sizeof *sub) : NULL; /* + 1: the branch-free copy below */
            if (count[q] && !sub) {
                ok = 0;
                break;
            }
            item scratch; /* an empty child's writes (its bit is never set) */
            item *o = sub ? sub : &scratch;
            size_t keep = 0;
            for (size_t i = 0; i < n; i++) { /* written always, kept when wanted: no branch to mispredict */
                const item it = list[i];
                const unsigned m = item_quadrants(&it, sv, sw);
                *o = it;
                o += m >> q & 1u;
                list[keep] = it;         /* keep <= i */
                keep += m >> (q + 1) != 0; /* a later child needs it */
            }
            n = keep;
            if (!n) {
                free(list);
                list = NULL;
            } else {
                item *smaller = realloc(list, n * sizeof *list);
                if (smaller) list = smaller;
            }
            ok = build_node(b, first + q, sub, count[q], cv0[q], cw0[q], cv1[q], cw1[q], depth + 1);
        }
        free(list);
        return ok;
    }
    item *sub[4] = {NULL, NULL, NULL, NULL};
    int ok = 1;
    for (int q = 0; q < 4 && ok; q++)
        if (count[q] && !(sub[q] = malloc(count[q] * sizeof *sub[q]))) ok = 0;
    if (!ok) {
        for (int q = 0; q < 4; q++) free(sub[q]);
        free(list);
        return 0;
    }
    /* The four lists in one pass, each in the node's order. An item goes
     * to the children of its set bits (at least one: it meets the node),
     * lowest first; the loop runs again only for items that straddle a
     * split line, so its branch is mostly predicted (testing the four
     * children in turn mispredicted about one in two). */
    item *out[4] = {sub[0], sub[1], sub[2], sub[3]};
    for (size_t i = 0; i < n; i++) {
        const item it = list[i];
        unsigned m = item_quadrants(&it, sv, sw);
        do {
            *out[lowest_bit(m)]++ = it;
            m &= m - 1u;
        } while (m);
    }
    free(list);
    int q = 0;
    for (; q < 4 && ok == 1; q++) ok = build_node(b, first + q, sub[q], count[q], cv0[q], cw0[q], cv1[q], cw1[q], depth + 1);
    for (; q < 4; q++) free(sub[q]); /* after a failure */
    return ok;
}

/* ---- boxes of the triangles (parallel parts) --------------------------------------- */

struct boxes;

/* The root: its list (R->list), or when the root is split (R->list NULL),
 * its four children's sizes; each child's list is made when it is built, by
 * streaming over the triangles (stream_child), so that no list of all the
 * triangles is ever held. Owned. */
typedef struct root {
    item *list;
    size_t n;
    item *sub[4];
    size_t count[4];
    float v0, w0, v1, w1;
    struct boxes *B; /* the pass that streams the children, on `threads` */
    int threads;
} root;

static void root_free(root *R)
{
    free(R->list);
    for (int q = 0; q < 4; q++) free(R->sub[q]);
    memset(R, 0, sizeof *R);
}

typedef struct boxes {
    const float *verts;   /* grid-space vertices, or a soup when tris is NULL */
    const uint32_t *tris;
    size_t tri_count;
    float v0, w0, v1, w1;
    int pass; /* 1: count; 2: write the root's list or child only_q's */
    int only_q;
    /* per triangle, from pass 1: the root's children it goes to (bit q),
     * 0 when it misses the plane; NULL: pass 2 tests again */
    unsigned char *mask;
    uint32_t leaf_size, max_depth;
    /* per part: triangles over the plane, the split test's sum, each child's count */
    size_t part_n[CLVOX__MAX_HOST_THREADS], part_sum[CLVOX__MAX_HOST_THREADS];
    size_t part_count[CLVOX__MAX_HOST_THREADS][4];
    root *R;
} boxes;

/* Triangles ahead whose corners are fetched early (indexed: 3 gathers each). */
#define PREFETCH 16

static void prefetch_tri(const boxes *B, size_t t)
{
#if defined(__GNUC__)
    if (!B->tris) return;
    const uint32_t *k = B->tris + t * 3;
    __builtin_prefetch(B->verts + (size_t)k[0] * 3);
    __builtin_prefetch(B->verts + (size_t)k[1] * 3);
    __builtin_prefetch(B->verts + (size_t)k[2] * 3);
#else
    (void)B, (void)t;
#endif
}

static item box_of(const boxes *B, size_t t)
{
    const float *a, *b, *c; /* corners, u,v,w each */
    if (B->tris) {
        const uint32_t *k = B->tris + t * 3;
        a = B->verts + (size_t)k[0] * 3, b = B->verts + (size_t)k[1] * 3, c = B->verts + (size_t)k[2] * 3;
    } else {
        a = B->verts + t * 9, b = a + 3, c = a + 6;
    }
    /* Coordinates are finite: the same values as fminf/fmaxf (a zero's sign
     * does not survive the widening below). */
    float lv = a[1] < b[1] ? a[1] : b[1], hv = a[1] > b[1] ? a[1] : b[1];
    float lw = a[2] < b[2] ? a[2] : b[2], hw = a[2] > b[2] ? a[2] : b[2];
    lv = c[1] < lv ? c[1] : lv, hv = c[1] > hv ? c[1] : hv;
    lw = c[2] < lw ? c[2] : lw, hw = c[2] > hw ? c[2] : hw;
    /* Widen by a few ulps of the coordinates: the crossing test works on
     * rounded differences, so be conservative. */
    float av = fabsf(lv) > fabsf(hv) ? fabsf(lv) : fabsf(hv);
    float aw = fabsf(lw) > fabsf(hw) ? fabsf(lw) : fabsf(hw);
    float ev = 1e-5f * (1.0f + av), ew = 1e-5f * (1.0f + aw);
    item it = {lv - ev, lw - ew, hv + ev, hw + ew, (uint32_t)t};
    return it;
}

/* The root streamed from the triangles in parts: pass 1 counts (the root's
 * split test and its children's sizes), pass 2 writes, each part at its
 * offset, so the lists are in triangle order as one pass would make them. */
static void boxes_part(void *arg, int i, int n)
{
    boxes *B = arg;
    size_t t0, t1;
    clvox__part_range(B->tri_count, i, n, &t0, &t1);
    float sv = 0.5f * (B->v0 + B->v1), sw = 0.5f * (B->w0 + B->w1);
    if (B->pass == 1) {
        size_t k = 0, sum = 0, count[4] = {0, 0, 0, 0};
        for (size_t t = t0; t < t1; t++) {
            if (t + PREFETCH < t1) prefetch_tri(B, t + PREFETCH);
            item it = box_of(B, t);
            if (!item_meets(&it, B->v0, B->w0, B->v1, B->w1)) {
                if (B->mask) B->mask[t] = 0;
                continue;
            }
            k++;
            const unsigned bits = item_quadrants(&it, sv, sw); /* it meets the root */
            for (int q = 0; q < 4; q++) count[q] += bits >> q & 1u;
            sum += (bits & 1u) + (bits >> 1 & 1u) + (bits >> 2 & 1u) + (bits >> 3); /* quadrants touched */
            if (B->mask) B->mask[t] = (unsigned char)(bits | 16u); /* 16: over the plane */
        }
        B->part_n[i] = k, B->part_sum[i] = sum;
        for (int q = 0; q < 4; q++) B->part_count[i][q] = count[q];
        return;
    }
    root *R = B->R;
    size_t at = 0, sat[4] = {0, 0, 0, 0};
    for (int j = 0; j < i; j++) {
        at += B->part_n[j];
        for (int q = 0; q < 4; q++) sat[q] += B->part_count[j][q];
    }
    const int q = B->only_q;
    const unsigned want = R->list ? 16u : 1u << q;
    for (size_t t = t0; t < t1; t++) {
        if (B->mask) { /* pass 1 decided: only the triangles that go there */
            if (!(B->mask[t] & want)) continue;
            item it = box_of(B, t);
            if (R->list) R->list[at++] = it;
            else R->sub[q][sat[q]++] = it;
            continue;
        }
        if (t + PREFETCH < t1) prefetch_tri(B, t + PREFETCH);
        item it = box_of(B, t);
        if (!item_meets(&it, B->v0, B->w0, B->v1, B->w1)) continue;
        if (R->list) {
            R->list[at++] = it;
            continue;
        }
        if (item_quadrants(&it, sv, sw) >> q & 1u) R->sub[q][sat[q]++] = it;
    }
}

/* Fills *R from the triangles (a split root: the children's sizes only).
 * Returns 0 when memory runs out. */
static int make_root(boxes *B, int threads, root *R)
{
    memset(R, 0, sizeof *R);
    R->v0 = B->v0, R->w0 = B->w0, R->v1 = B->v1, R->w1 = B->w1;
    R->B = B;
    R->threads = threads;
    B->R = R;
    B->pass = 1;
    clvox__parallel(threads, boxes_part, B);
    size_t n = 0, sum = 0;
    for (int i = 0; i < threads; i++) {
        n += B->part_n[i], sum += B->part_sum[i];
        for (int q = 0; q < 4; q++) R->count[q] += B->part_count[i][q];
    }
    R->n = n;
    /* build_node's test at the root (no references made yet) */
    int leaf = n <= B->leaf_size || B->max_depth == 0 || sum >= 3 * n || sum > MAX_REFS;
    if (leaf) {
        if (n && !(R->list = malloc(n * sizeof *R->list))) return 0;
        for (int q = 0; q < 4; q++) R->count[q] = 0;
        if (!n) return 1;
    } else {
        return 1; /* the children are streamed one by one (stream_child) */
    }
    B->pass = 2;
    B->only_q = -1;
    clvox__parallel(threads, boxes_part, B);
    return 1;
}

/* Child q of a split root: its list, streamed from the triangles. 0: out of memory. */
static int stream_child(root *R, int q)
{
    if (!R->count[q]) return 1;
    if (!(R->sub[q] = malloc(R->count[q] * sizeof *R->sub[q]))) return 0;
    R->B->pass = 2;
    R->B->only_q = q;
    clvox__parallel(R->threads, boxes_part, R->B);
    return 1;
}

/* Hands the memory freed by the lists back to the system, once the build
 * is done.
 * glibc keeps freed blocks below its adaptive mmap threshold, which the
 * first freed list of tens of MB raises, so without this they stay
 * resident under everything allocated later. Not done during the build:
 * trimming after each of the root's children and after children of 2^18
 * triangles lowered armadillo_s3's peak (512^3, 1 / 2 threads) from
 * 244 / 252 to 235 / 245 MB but cost the build 0.08 s there and 0.5 s on
 * 13.3 M triangles (page faults on the memory handed back). Elsewhere:
 * nothing. */
static void release_free_memory(void)
{
#if defined(__GLIBC__)
    malloc_trim(0);
#endif
}

/* ---- tasks and the final layout ---------------------------------------------------- */

typedef struct tasks_run {
    const build *proto;
    task *tasks;
    size_t count;
    atomic_size_t next;
} tasks_run;

static void run_tasks(void *arg, int i, int n)
{
    (void)i, (void)n;
    tasks_run *R = arg;
    for (;;) {
        size_t k = atomic_fetch_add(&R->next, 1);
        if (k >= R->count) return;
        task *t = &R->tasks[k];
        build b = {.max_depth = R->proto->max_depth, .leaf_size = R->proto->leaf_size};
        b.nodes = malloc(64 * sizeof *b.nodes);
        b.node_cap = 64;
        b.node_count = 1;
        b.depth = t->depth;
        item *list = t->list;
        t->list = NULL;
        if (b.nodes) t->rc = build_node(&b, 0, list, t->n, t->v0, t->w0, t->v1, t->w1, t->depth);
        else free(list), t->rc = 0;
        t->nodes = b.nodes;
        t->node_count = b.node_count;
        t->refs = b.refs;
        t->ref_count = b.ref_count;
        t->max_depth_reached = b.depth;
        t->leaves = b.leaves;
    }
}

/* Runs the tasks made since the last call, on b->threads threads. */
static void run_pending_tasks(build *b)
{
    size_t k = b->task_count - b->tasks_done;
    if (!k) return;
    tasks_run R = {.proto = b, .tasks = b->tasks + b->tasks_done, .count = k};
    atomic_init(&R.next, 0);
    clvox__parallel(b->threads < (int)k ? b->threads : (int)k, run_tasks, &R);
    b->tasks_done = b->task_count;
    b->pending_items = 0;
}

/* Lays out skeleton node s at index g of out, as the one-thread build would. */
static void assemble(const build *sk, size_t s, build *out, size_t g)
{
    const clvox_qt_node *sn = &sk->nodes[s];
    if (sn->count == NODE_TASK) {
        const task *t = &sk->tasks[sn->first];
        size_t nbase = out->node_count, rbase = out->ref_count;
        for (size_t k = 0; k < t->node_count; k++) {
            clvox_qt_node v = t->nodes[k];
            if (v.count == CLVOX_QT_INTERNAL) v.first = (uint32_t)(nbase + v.first - 1); /* local 1.. follow nbase */
            else v.first = (uint32_t)(rbase + v.first);
            out->nodes[k ? nbase + k - 1 : g] = v;
        }
        out->node_count += t->node_count - 1;
        if (t->ref_count) memcpy(out->refs + rbase, t->refs, t->ref_count * sizeof *t->refs);
        out->ref_count += t->ref_count;
        return;
    }
    if (sn->count != CLVOX_QT_INTERNAL) {
        clvox_qt_node v = *sn;
        v.first = (uint32_t)out->ref_count;
        out->nodes[g] = v;
        if (sn->count) memcpy(out->refs + out->ref_count, sk->refs + sn->first, sn->count * sizeof *sk->refs);
        out->ref_count += sn->count;
        return;
    }
    size_t first = out->node_count;
    out->node_count += 4;
    out->nodes[g] = *sn;
    out->nodes[g].first = (uint32_t)first;
    for (int q = 0; q < 4; q++) assemble(sk, sn->first + q, out, first + q);
}

static void free_tasks(build *b)
{
    for (size_t k = 0; k < b->task_count; k++) {
        free(b->tasks[k].list);
        free(b->tasks[k].nodes);
        free(b->tasks[k].refs);
    }
    free(b->tasks);
    b->tasks = NULL;
    b->task_count = b->task_cap = 0;
}

/* The tree over root[0..n) (owned) on `threads` threads; 1: no tasks.
 * Returns as build_node; *near_cap when the references came close enough to
 * MAX_REFS that the guard might have acted differently (the caller then
 * builds on one thread). */
/* Node 0 from R, as build_node would make it. */
static int build_root(build *b, root *R)
{
    if (R->list || R->n == 0) /* a leaf */
        return build_node(b, 0, R->list, R->n, R->v0, R->w0, R->v1, R->w1, 0);
    float sv = 0.5f * (R->v0 + R->v1), sw = 0.5f * (R->w0 + R->w1);
    b->nodes[0].split_v = sv;
    b->nodes[0].split_w = sw;
    b->nodes[0].first = 1;
    b->nodes[0].count = CLVOX_QT_INTERNAL;
    b->node_count = 5;
    int ok = 1;
    for (int q = 0; q < 4 && ok == 1; q++) {
        float cv0 = (q & 1) ? sv : R->v0, cv1 = (q & 1) ? R->v1 : sv;
        float cw0 = (q & 2) ? sw : R->w0, cw1 = (q & 2) ? R->w1 : sw;
        if (!stream_child(R, q)) {
            ok = 0;
            break;
        }
        ok = build_node(b, 1 + (size_t)q, R->sub[q], R->count[q], cv0, cw0, cv1, cw1, 1);
        R->sub[q] = NULL;
        /* the skeleton: this child's subtrees now, so that their lists
         * are not all held at once */
        if (ok == 1) run_pending_tasks(b);
    }
    return ok;
}

static int build_tree(build *b, root *rt, int threads, int *near_cap)
{
    *near_cap = 0;
    size_t n = rt->n;
    b->nodes = malloc(1024 * sizeof *b->nodes);
    b->node_cap = 1024;
    b->node_count = 1;
    if (!b->nodes) {
        root_free(rt);
        return 0;
    }
    if (threads <= 1) {
        /* The references in one reservation (about 1.6 per triangle on
         * real meshes; grown past it as before): doubling from small
         * leaves a trail of freed copies the allocator keeps. Pages not
         * written cost nothing. */
        size_t cap = n <= (SIZE_MAX / sizeof *b->refs - 1024) / 2 ? 2 * n + 1024 : 0;
        if (cap && (b->refs = malloc(cap * sizeof *b->refs)) != NULL) b->ref_cap = cap;
        return build_root(b, rt);
    }

    build sk = *b; /* the skeleton: its own nodes and refs */
    sk.defer_depth = SKELETON_DEPTH;
    b->nodes = NULL;
    b->node_cap = b->node_count = 0;
    sk.threads = threads;
    int ok = build_root(&sk, rt);
    if (ok == 1) run_pending_tasks(&sk);
    size_t nodes = sk.node_count, refs = sk.ref_count, leaves = sk.leaves;
    uint32_t depth = sk.depth;
    for (size_t k = 0; ok == 1 && k < sk.task_count; k++) {
        const task *t = &sk.tasks[k];
        if (t->rc != 1) ok = t->rc;
        nodes += t->node_count - 1;
        refs += t->ref_count;
        leaves += t->leaves;
        if (t->max_depth_reached > depth) depth = t->max_depth_reached;
    }
    if (ok == 1 && refs > MAX_TOTAL_REFS) ok = -1;
    if (ok == 1 && refs + 4 * n > MAX_REFS) *near_cap = 1;
    if (ok == 1 && !*near_cap) {
        b->nodes = malloc(nodes * sizeof *b->nodes);
        b->refs = malloc((refs ? refs : 1) * sizeof *b->refs);
        ok = b->nodes && b->refs;
        if (ok) {
            b->node_cap = nodes;
            b->ref_cap = refs;
            b->node_count = 1;
            b->ref_count = 0;
            assemble(&sk, 0, b, 0);
            b->leaves = leaves;
            b->depth = depth;
        }
    }
    free_tasks(&sk);
    free(sk.nodes);
    free(sk.refs);
    return ok;
}

clvox_status clvox__quadtree_build_threads(clvox_context *ctx, const float *verts, const uint32_t *tris,
                                           size_t tri_count, uint32_t dim_v, uint32_t dim_w, uint32_t max_depth,
                                           uint32_t leaf_size, int threads, clvox__quadtree *out)
{
    memset(out, 0, sizeof *out);
    if (tri_count > 0xFFFFFFF0u)
        return clvox__fail(ctx, CLVOX_ERR_MESH_INVALID, "more than 2^32 triangles");
    if (threads <= 0) threads = clvox__host_threads();
    if (threads > CLVOX__MAX_HOST_THREADS) threads = CLVOX__MAX_HOST_THREADS;
    if (tri_count < MIN_PARALLEL_TRIANGLES) threads = 1;
    build b = {.max_depth = max_depth ? max_depth : clvox__quadtree_auto_depth(dim_v, dim_w, tri_count),
               .leaf_size = leaf_size ? leaf_size : 8};
    if (b.max_depth > 16) b.max_depth = 16;
    boxes B = {.verts = verts, .tris = tris, .tri_count = tri_count, .v0 = -0.5f, .w0 = -0.5f, .v1 = (float)dim_v - 0.5f,
               .w1 = (float)dim_w - 0.5f};
    B.leaf_size = b.leaf_size, B.max_depth = b.max_depth;
    B.mask = malloc(tri_count ? tri_count : 1); /* 1 byte a triangle; without it, slower */
    int near_cap = 0, ok = 0;
    for (int attempt = 0; attempt < 2; attempt++) {
        root R;
        if (!make_root(&B, threads, &R)) break;
        ok = build_tree(&b, &R, threads, &near_cap);
        if (ok != 1 || !near_cap) break;
        /* Near MAX_REFS: the guard depends on the order; build on one thread. */
        free(b.nodes);
        free(b.refs);
        build one = {.max_depth = b.max_depth, .leaf_size = b.leaf_size};
        b = one;
        threads = 1;
    }
    free(B.mask);
    release_free_memory();
    if (ok != 1) {
        free(b.nodes);
        free(b.refs);
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY,
                           ok ? "quadtree holds more than 2^32 references" : "out of memory building the quadtree");
    }
    if (!b.refs) { /* no triangle over the plane: keep one valid element */
        b.refs = calloc(1, sizeof *b.refs);
        if (!b.refs) {
            free(b.nodes);
            return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory building the quadtree");
        }
    }
    out->nodes = b.nodes;
    out->node_count = b.node_count;
    out->refs = b.refs;
    out->ref_count = b.ref_count;
    out->depth = b.depth;
    out->leaf_count = b.leaves;
    return CLVOX_OK;
}

clvox_status clvox__quadtree_build(clvox_context *ctx, const float *verts, const uint32_t *tris, size_t tri_count,
                                   uint32_t dim_v, uint32_t dim_w, uint32_t max_depth, uint32_t leaf_size,
                                   clvox__quadtree *out)
{
    return clvox__quadtree_build_threads(ctx, verts, tris, tri_count, dim_v, dim_w, max_depth, leaf_size, 0, out);
}

void clvox__quadtree_free(clvox__quadtree *qt)
{
    if (!qt) return;
    free(qt->nodes);
    free(qt->refs);
    memset(qt, 0, sizeof *qt);
}
