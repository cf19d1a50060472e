/* SPDX-License-Identifier: Apache-2.0 */
/* The EXR writer's state, shared by its files: write_exr.c (open, slabs,
 * finish; the file layout and the writing are described there),
 * exr_write_header.c (the header and its attributes), exr_write_encode.c
 * (packing and compressing one chunk) and exr_write_pool.c (the encoder
 * threads and the in-order chunk writing). Private to those four. */
#ifndef CLVOX_EXR_WRITER_H
#define CLVOX_EXR_WRITER_H

#include "core/internal.h"

#include <OpenEXR/openexr.h>

#include <pthread.h>

/* Largest uncompressed chunk: slices up to this size are one tile each. */
#ifndef CLVOX__EXR_CHUNK_BYTES
#define CLVOX__EXR_CHUNK_BYTES (8u << 20)
#endif
/* zlib level for ZIP / ZIPS (1: fastest; OpenEXR's default is zlib's 6). */
#ifndef CLVOX__EXR_ZIP_LEVEL
#define CLVOX__EXR_ZIP_LEVEL 1
#endif
#define CLVOX__EXR_MAX_THREADS 64u
#define CLVOX__EXR_MAX_CHANNELS 4

typedef struct exr_channel_def {
    const char *name;
    uint32_t mask;  /* CLVOX_CHANNEL_* */
    exr_pixel_type_t type;
    uint32_t bytes; /* per sample in the file */
    uint32_t src_bytes; /* per sample as the caller gives it (bytes < src_bytes never; bytes > src_bytes:
                           widened, a uint16 index stored as UINT) */
    int bits;       /* the caller gives bit rows (clvox__row_words words per row, bit 1 = 1.0), not samples */
    const void *(*plane)(const clvox__slab_planes *p); /* the caller's data for one slab */
} exr_channel_def;

enum { SLOT_FREE = 0, SLOT_BUSY, SLOT_DONE };

typedef struct exr_slot {
    int state;
    int initialized;            /* pipe went through exr_encoding_initialize */
    int32_t chunk;              /* tile row index being encoded */
    exr_result_t rv;
    exr_encode_pipeline_t pipe; /* owns the packed/compressed buffers */
    const void *out;            /* what to write: pipe.compressed_buffer or raw */
    uint64_t out_bytes;
    uint8_t *raw, *comp; /* packed samples, RLE output */
    size_t raw_size, comp_size;
} exr_slot;

struct clvox__exr_writer {
    clvox_context *ctx;
    exr_context_t exr;
    char *path;
    clvox__outfile of; /* the file being written (outfile.c) */
    uint32_t dims[3];
    int32_t height;       /* Y*Z image rows */
    int32_t tile_h;       /* rows per chunk */
    int32_t chunk_count;
    exr_compression_t compression;
    int little_endian;
    uint32_t channels;    /* CLVOX_CHANNEL_* mask */
    const exr_channel_def *ch[CLVOX__EXR_MAX_CHANNELS]; /* this file's channels, in file (name) order */
    size_t nch;
    uint32_t pixel_bytes; /* all channels' bytes per voxel in the file */
    uint64_t next_row;    /* image rows received so far */
    uint32_t next_z;      /* next slice expected */
    int failed;           /* a slab failed: only abort is possible */
    clvox_status fail_status;

    /* source of the current slab per channel of ch[] (read by workers) */
    const uint8_t *src[CLVOX__EXR_MAX_CHANNELS];
    uint64_t src_row0;
    /* rows of the chunk that straddles two slabs (row-chunks only) */
    uint8_t *carry[CLVOX__EXR_MAX_CHANNELS];
    uint64_t carry_row0; /* image row of carry[][0] */
    int32_t carry_rows;

    /* worker pool; slots[] also serves the single-threaded path */
    unsigned thread_count, threads_started;
    pthread_t *threads;
    exr_slot *slots;
    unsigned slot_count;
    pthread_mutex_t mu;
    pthread_cond_t work_cv, done_cv;
    int mu_ready;
    int quit;
    int32_t job_next, job_end;
    unsigned busy;

    /* errors from OpenEXRCore callbacks (any thread; guarded by mu) */
    char exr_msg[512];
    int io_errno;
};

/* Bytes of one image row of the writer's channel t as the caller gives it. */
static inline size_t source_row_bytes(const clvox__exr_writer *w, size_t t)
{
    if (w->ch[t]->bits) return (size_t)clvox__row_words(w->dims[0]) * 4;
    return (size_t)w->dims[0] * w->ch[t]->src_bytes;
}

/* A chunk of a single sample channel, stored as given, in that byte order
 * is the caller's data itself (see packed_chunk). */
static inline int chunk_is_source(const clvox__exr_writer *w, int native)
{
    return w->nch == 1 && !w->ch[0]->bits && w->ch[0]->bytes == w->ch[0]->src_bytes &&
           (w->ch[0]->bytes == 1 || native || w->little_endian);
}

/* "OpenEXR: <what>: <library message or default message for rv>" (write_exr.c) */
clvox_status clvox__exrw_fail(clvox__exr_writer *w, exr_result_t rv, const char *what);

/* exr_write_header.c */
exr_compression_t clvox__exrw_compression(clvox_compression c);
/* The header the writer would record for meta, checked before any file is
 * made: refused here rather than written broken. */
clvox_status clvox__exrw_check_meta(clvox_context *ctx, const char *path, const clvox__exr_meta *meta);
clvox_status clvox__exrw_define_header(clvox__exr_writer *w, const clvox_grid *grid, const clvox__exr_meta *meta,
                                       clvox_compression compression);

/* exr_write_encode.c: packs and compresses chunk c into slot s (no I/O). Any thread. */
exr_result_t clvox__exrw_encode_chunk(clvox__exr_writer *w, exr_slot *s, int32_t c);

/* exr_write_pool.c */
void *clvox__exrw_worker_main(void *arg);
/* Appends image rows [row0, row0 + nrows) (one pointer per channel of
 * w->ch) to the file. */
clvox_status clvox__exrw_write_rows(clvox__exr_writer *w, uint64_t row0, uint64_t nrows, const uint8_t *const *data);
void clvox__exrw_stop_pool(clvox__exr_writer *w);
void clvox__exrw_release_slots(clvox__exr_writer *w);

#endif /* CLVOX_EXR_WRITER_H */
