/* SPDX-License-Identifier: Apache-2.0 */
/* The EXR writer's encoder threads and chunk writing: workers encode chunks
 * into a ring of slots, the calling thread writes them strictly in order;
 * the rows of a chunk that straddles two slabs are carried over. */
#include "io/exr_writer.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static exr_result_t write_chunk(clvox__exr_writer *w, exr_slot *s, int32_t c)
{
    return exr_write_tile_chunk(w->exr, 0, 0, c, 0, 0, s->out, s->out_bytes);
}

void *clvox__exrw_worker_main(void *arg)
{
    clvox__exr_writer *w = arg;
    pthread_mutex_lock(&w->mu);
    for (;;) {
        while (!w->quit &&
               !(w->job_next < w->job_end && w->slots[(unsigned)w->job_next % w->slot_count].state == SLOT_FREE))
            pthread_cond_wait(&w->work_cv, &w->mu);
        if (w->quit) break;
        int32_t c = w->job_next++;
        exr_slot *s = &w->slots[(unsigned)c % w->slot_count];
        s->state = SLOT_BUSY;
        s->chunk = c;
        w->busy++;
        pthread_mutex_unlock(&w->mu);
        exr_result_t rv = clvox__exrw_encode_chunk(w, s, c);
        pthread_mutex_lock(&w->mu);
        s->rv = rv;
        s->state = SLOT_DONE;
        w->busy--;
        pthread_cond_broadcast(&w->done_cv);
    }
    pthread_mutex_unlock(&w->mu);
    return NULL;
}

/* Encodes and writes chunks [first, end). */
static clvox_status run_chunks(clvox__exr_writer *w, int32_t first, int32_t end)
{
    char what[96];
    if (w->threads_started == 0) {
        exr_slot *s = &w->slots[0];
        for (int32_t c = first; c < end; c++) {
            exr_result_t rv = clvox__exrw_encode_chunk(w, s, c);
            if (rv != EXR_ERR_SUCCESS) {
                snprintf(what, sizeof what, "encoding chunk %d of", (int)c);
                return clvox__exrw_fail(w, rv, what);
            }
            rv = write_chunk(w, s, c);
            if (rv != EXR_ERR_SUCCESS) {
                snprintf(what, sizeof what, "writing chunk %d of", (int)c);
                return clvox__exrw_fail(w, rv, what);
            }
        }
        return CLVOX_OK;
    }

    clvox_status st = CLVOX_OK;
    pthread_mutex_lock(&w->mu);
    w->job_next = first;
    w->job_end = end;
    pthread_cond_broadcast(&w->work_cv);
    for (int32_t c = first; c < end; c++) {
        exr_slot *s = &w->slots[(unsigned)c % w->slot_count];
        while (!(s->state == SLOT_DONE && s->chunk == c)) pthread_cond_wait(&w->done_cv, &w->mu);
        pthread_mutex_unlock(&w->mu);
        exr_result_t rv = s->rv;
        if (rv != EXR_ERR_SUCCESS) {
            snprintf(what, sizeof what, "encoding chunk %d of", (int)c);
            st = clvox__exrw_fail(w, rv, what);
        } else {
            rv = write_chunk(w, s, c);
            if (rv != EXR_ERR_SUCCESS) {
                snprintf(what, sizeof what, "writing chunk %d of", (int)c);
                st = clvox__exrw_fail(w, rv, what);
            }
        }
        pthread_mutex_lock(&w->mu);
        s->state = SLOT_FREE;
        if (st != CLVOX_OK) {
            w->job_end = w->job_next; /* assign nothing more */
            break;
        }
        pthread_cond_broadcast(&w->work_cv);
    }
    /* Workers must be idle before the caller's slab goes away. */
    while (w->busy > 0) pthread_cond_wait(&w->done_cv, &w->mu);
    for (unsigned i = 0; i < w->slot_count; i++) w->slots[i].state = SLOT_FREE;
    w->job_next = w->job_end = 0;
    pthread_mutex_unlock(&w->mu);
    return st;
}

/* Appends image rows [row0, row0 + nrows) (one pointer per channel of
 * w->ch) to the file. */
clvox_status clvox__exrw_write_rows(clvox__exr_writer *w, uint64_t row0, uint64_t nrows, const uint8_t *const *data)
{
    const uint64_t T = (uint64_t)w->tile_h, H = (uint64_t)w->height;
    const uint64_t R0 = row0, R1 = row0 + nrows;
    int32_t first = (int32_t)(R0 / T);

    for (size_t t = 0; t < w->nch; t++) w->src[t] = data[t];
    w->src_row0 = R0;

    if (w->carry_rows > 0) { /* complete the chunk begun by the previous slab */
        uint64_t cstart = (uint64_t)first * T;
        uint64_t cend = cstart + T < H ? cstart + T : H;
        uint64_t take = cend - R0 < nrows ? cend - R0 : nrows;
        for (size_t t = 0; t < w->nch; t++) {
            size_t rb = source_row_bytes(w, t);
            memcpy(w->carry[t] + (size_t)w->carry_rows * rb, data[t], (size_t)take * rb);
        }
        w->carry_rows += (int32_t)take;
        if (cstart + (uint64_t)w->carry_rows < cend) return CLVOX_OK; /* still incomplete */
    }
    int32_t end = R1 == H ? w->chunk_count : (int32_t)(R1 / T);
    clvox_status st = run_chunks(w, first, end);
    if (st != CLVOX_OK) return st;
    w->carry_rows = 0;
    uint64_t tail0 = (uint64_t)end * T;
    if (tail0 < R1) { /* keep the start of the next chunk */
        for (size_t t = 0; t < w->nch; t++) {
            size_t rb = source_row_bytes(w, t);
            memcpy(w->carry[t], data[t] + (size_t)(tail0 - R0) * rb, (size_t)(R1 - tail0) * rb);
        }
        w->carry_rows = (int32_t)(R1 - tail0);
        w->carry_row0 = tail0;
    }
    return CLVOX_OK;
}

void clvox__exrw_stop_pool(clvox__exr_writer *w)
{
    if (!w->mu_ready) return;
    pthread_mutex_lock(&w->mu);
    w->quit = 1;
    pthread_cond_broadcast(&w->work_cv);
    pthread_mutex_unlock(&w->mu);
    for (unsigned i = 0; i < w->threads_started; i++) pthread_join(w->threads[i], NULL);
    w->threads_started = 0;
}

void clvox__exrw_release_slots(clvox__exr_writer *w)
{
    if (!w->slots) return;
    for (unsigned i = 0; i < w->slot_count; i++) {
        if (w->slots[i].initialized) exr_encoding_destroy(w->exr, &w->slots[i].pipe);
        free(w->slots[i].raw);
        free(w->slots[i].comp);
    }
    free(w->slots);
    w->slots = NULL;
}
