/* SPDX-License-Identifier: Apache-2.0 */
/* Stage cast: the ray method's state and batches (src/cast/cast.c), shared
 * with the host's part of a float device's winding runs (unsure.c). Private
 * to those two files. */
#ifndef CLVOX_CAST_STATE_H
#define CLVOX_CAST_STATE_H

#include "classify.h"
#include "core/launch.h"
#include "palette_score.h"

#define UNSURE_ROOM 4096u       /* a float device's unsure points a batch lists before a rerun (unsure.c) */
#define UNSURE_WORDS 4u         /* words an entry (kernels/winding_inside.h CLVOX_UNSURE_WORDS) */

/* One batch's device buffers and host arrays, and what is in flight of it
 * (ray_slab keeps two, alternating, where the device holds them: batch
 * k + 1 runs while the host tallies batch k and makes batch k + 2). */
typedef struct batch_set {
    clvox__batch_mem mem;
    clvox_ray *rays;             /* max_rays; NULL on column runs whose rays the device makes */
    clvox_column *cols;          /* coverage: max_items */
    uint32_t *counts;            /* max_rays */
    uint32_t *filled;            /* max_items */
    uint64_t *sums;              /* column runs: max_items */
    uint32_t *pstats;            /* palette: 4 per item (early, shortcut, scored, non-empty voxels) */
    uint64_t *pvolume;           /* palette: per item, element volumes in 2^-32 voxels */
    cl_uint exact;               /* winding: the batch's exact points (read back; not on the stack) */
    cl_uint *unsure;             /* winding on a float device: the unsure list read back (unsure.c) */
    cl_uint unsure_head[2];      /* what the list starts from: 0 entries, its room */
    const clvox_ray *cast_rays;  /* the rays batch_enqueue uploaded (NULL: z rays already on the device) */
    const clvox_column *cast_cols; /* coverage: the columns it uploaded (NULL: as cast_rays) */
    cl_uint n_cols;              /* coverage: columns enqueued */
    uint32_t z0;                 /* ray_slab: the slab's first slice */
    cl_uint n_rays;              /* rays enqueued */
    clvox__slab_target t;        /* where its voxels went */
    cl_event ev[5];              /* profiling: lookup, intersect, sort, consumer, column rays */
    clvox__launch_ticket ticket; /* the batch's completion counts, read last: its read event ends the batch */
    int queued;                  /* 1: enqueued, not yet waited for */
    size_t c0, k;                /* ray_slab: the batch's first item in the slab, its items */
} batch_set;

struct clvox__method_state {
    clvox_context *ctx;
    clvox_grid grid;
    clvox_axis axis;       /* X, Y or Z (resolved) */
    clvox__axes axes;
    uint32_t dim_u, dim_v, dim_w;
    clvox__quadtree qt;
    cl_mem verts, tris, nodes, refs; /* the triangles, indexed; the quadtree (read-only device copies) */
    float *verts_host;           /* grid-space vertices (owned) */
    size_t float_outside;        /* clvox__float_outside over them (float kernels decide exactly without it) */
    float float_coord;
    uint32_t *tris_owned;        /* the index array when it is not the mesh's own (winding) */
    cl_kernel k_lookup, k_intersect, k_sort, k_classify; /* k_classify: binary runs, parity or winding */
    cl_kernel k_set_bits;        /* binary winding runs on a float device: the host's answers (unsure.c) */
    int winding;                 /* 1: signed crossings and the winding inside test */
    clvox__winding_classify wind; /* its caps and rims (zero on parity runs: the column consumers take them too) */
    uint32_t leaf_size;
    uint64_t leaf_max;           /* most triangles in one quadtree leaf */
    batch_set set[2];            /* the fast pass's batches: set[0], and set[1] where sets == 2 */
    int sets;                    /* 2: batches in flight two at a time (fit_batches); 1: one at a time */
    size_t batch_items;          /* items per fast-pass batch (work-bounded) */
    int timed;                   /* caps: batches sized by their time (ray_slab) */
    size_t batch_now;            /* items in the next batch: batch_items, or fewer where timed */
    int (*poll)(void *, double); /* clvox__run.poll */
    void *poll_user;
    uint64_t max_alloc;          /* the device's largest buffer */
    uint64_t redo_room;          /* device bytes left for redo_overflow's batches (fit_batches) */
    uint64_t held_bytes;         /* device bytes held besides them: the mesh, the slab planes, the fast pass */
    /* z rays: every slab's rays are the same X*Y columns, only the slices
     * they classify differ. When one batch holds them all, the first slab
     * cast leaves their sorted crossings in set[0] and the next slabs run
     * only the consumer (at 1024^3, 64 slabs cast once instead of 64 times). */
    int z_cast;                  /* 1: set[0].mem holds the crossings of every z column */
    uint32_t *z_counts;          /* their crossing counts (the first pass's), X*Y*R */
    /* coverage and palette (column runs) */
    int coverage;                /* 1: a column run (the coverage or the palette consumer) */
    clvox__coverage cov;         /* the samples (both consumers) */
    uint32_t channels;
    int palette;                 /* 1: the palette consumer */
    clvox__palette_score pal;
};

/* Column i of the slab that starts at z0: its ray-plane position (v, w) and
 * where its voxels go (out_base, bit; see clvox_ray). */
void clvox__slab_column(const clvox__method_state *s, uint32_t z0, size_t i, uint32_t *v, uint32_t *w,
                        clvox_u32 *out_base, clvox_u32 *bit);
/* The points batch b's consumer left unsure (a float device's winding
 * runs, b->unsure), decided on the host and written behind the batch
 * (unsure.c). */
clvox_status clvox__resolve_unsure(clvox__method_state *s, batch_set *b, clvox__slab_stats *ss);

#endif
