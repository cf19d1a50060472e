/* SPDX-License-Identifier: Apache-2.0 */
/* Several devices, one volume, in order (schedule.h).
 *
 * Slabs are independent and every device computes a slab to the same bits
 * (the tie rules, the keyed sampler), so the run is a queue of slabs:
 *  - each device has a host thread that takes packets of consecutive slabs,
 *    sized as EngineCL's HGuided does: its share of what is left, weighted
 *    by its measured throughput, halved (K = 2) so packets shrink towards
 *    the end; a device not yet measured takes one slab;
 *  - a device's slab is read back into the reorder buffer's slot slab %
 *    window, and the calling thread hands the slots to the sink in
 *    increasing z; a device may start slab i only when i < written +
 *    window, so the buffer never holds more than `window` slabs whatever
 *    the slices or the imbalance, and the slab the writer waits for can
 *    always be started (no deadlock);
 *  - a device with nothing left to take re-computes the lowest slab still
 *    running on another device when it expects to finish it sooner (first
 *    result wins; the other device's method is stopped at its next poll);
 *  - a device computes up to `group` consecutive slabs of its packet in one
 *    method call (its launch unit, sized to the device by voxelize.c), all
 *    below written + window, then reads each slab of the group back into
 *    its own slot: a group is won, lost, failed or re-issued as a whole
 *    (a straggler's copy computes the same range), so every slab of it is
 *    delivered once and its statistics, kept on its first slab, once;
 *  - a device whose throughput is under 1/20 of the others' together takes
 *    no more packets (its share would be under 5 %, while its last slab
 *    could hold the writer up);
 *  - a device that fails is dropped: its unfinished slabs go back to the
 *    queue, one warning names it; when every device has failed, the run
 *    fails.
 * One mutex guards it all: it is taken a few times per slab. */
#include "schedule.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define NONE UINT32_MAX
#define PACKET_K 2.0      /* HGuided's divisor: a device takes 1/K of its share of what is left */
#define SLOW_FRACTION 20.0 /* left out below 1/SLOW_FRACTION of the others' throughput */
#define WINDOW_BYTES (256ull << 20)

typedef enum slab_state { SLAB_TODO, SLAB_ASSIGNED, SLAB_RUNNING, SLAB_COPYING, SLAB_DONE, SLAB_WRITTEN } slab_state;

typedef struct slab_info {
    uint8_t state;
    uint8_t owner;     /* ASSIGNED: whose packet; COPYING/DONE: whose result */
    uint32_t runners;  /* devices computing it (bit per device) */
    uint32_t gbeg, gend; /* RUNNING: the group it is computed in, [gbeg, gend) */
    double started;    /* when its first runner started it */
    clvox__slab_stats ss;
} slab_info;

typedef struct clvox__sched {
    const clvox__sched_job *job;
    pthread_mutex_t mu;
    pthread_cond_t cv;
    slab_info *slab;
    uint32_t nslabs, next_fresh, written;
    int redo;          /* some slab below next_fresh is TODO again */
    int stop;          /* the run is over (done, failed or cancelled) */
    uint32_t alive;
    clvox_status status;      /* of the first failure that ends the run */
    char first_error[1024];   /* the first device failure's message */
    clvox_status first_device_st;
    /* The caller's progress callback runs on the writer's thread only: a
     * device polling between its batches asks the writer (poll_pending)
     * and waits for the answer, unless the writer is busy writing, so that
     * a cancel is seen at the same batch boundary as with one thread. */
    int writing, poll_pending;
    double last_progress, reported;
    void **slot[4];           /* reorder buffer: window slots per plane */
    /* One device whose memory is the host's (a CPU device), one slab per
     * call: its planes are the slots themselves (CL_MEM_USE_HOST_PTR
     * buffers over them, wrap[p][w]), mapped for the writer once computed
     * and unmapped by the device's thread before it computes into the
     * slot again, so no slab is copied (2 cores, bunny00 512^3
     * --oversample 4: the copy of 32 MB a slab cost 8-10 %). */
    cl_mem *wrap[4];
    uint8_t *mapped;          /* per slot: mapped for the writer */
    uint32_t held, peak;      /* slabs in the buffer (copying or done, not written) */
} clvox__sched;

uint32_t clvox__sched_window(uint32_t ndev, uint32_t group, uint64_t slab_bytes)
{
    if (group < 1) group = 1;
    if (ndev <= 1) {
        uint32_t w = 2 * group;
        while (w > 2 && (uint64_t)w * slab_bytes > WINDOW_BYTES) w--;
        return w;
    }
    uint32_t w = ndev * (2 * group > 4 ? 2 * group : 4);
    while (w > ndev + 1 && (uint64_t)w * slab_bytes > WINDOW_BYTES) w--;
    return w;
}

static uint32_t slab_z0(const clvox__sched *s, uint32_t i) { return i * s->job->depth; }
static uint32_t slab_nz(const clvox__sched *s, uint32_t i)
{
    uint32_t z0 = slab_z0(s, i), Z = s->job->Z;
    return Z - z0 < s->job->depth ? Z - z0 : s->job->depth;
}

/* Slices of slabs [i, e). */
static uint32_t range_slices(const clvox__sched *s, uint32_t i, uint32_t e)
{
    uint32_t z1 = e * s->job->depth;
    return (z1 < s->job->Z ? z1 : s->job->Z) - slab_z0(s, i);
}

static double throughput(const clvox__sched_device *d)
{
    return d->slabs_won && d->busy_won > 0 ? (double)d->slices_won / d->busy_won : 0.0;
}

int clvox__sched_poll(void *user, double slab_fraction)
{
    clvox__sched_device *d = user;
    clvox__sched *s = d->sched;
    if (!s) return 1;
    pthread_mutex_lock(&s->mu);
    d->fraction = slab_fraction;
    int go = !s->stop && d->current != NONE && s->slab[d->current].state <= SLAB_RUNNING;
    if (go && s->job->progress && !s->writing && !s->poll_pending && clvox__now() - s->last_progress >= 0.1) {
        s->poll_pending = 1;
        pthread_cond_broadcast(&s->cv);
        while (s->poll_pending && !s->stop) pthread_cond_wait(&s->cv, &s->mu);
        go = !s->stop && s->slab[d->current].state <= SLAB_RUNNING;
    }
    pthread_mutex_unlock(&s->mu);
    return go;
}

/* Puts back what device d held: its packet's slabs and the group it ran
 * (every slab of it that no other device computes). */
static void release_slabs(clvox__sched *s, clvox__sched_device *d)
{
    for (uint32_t k = d->pk_next; k < d->pk_end; k++)
        if (s->slab[k].state == SLAB_ASSIGNED && s->slab[k].owner == d->index) s->slab[k].state = SLAB_TODO, s->redo = 1;
    d->pk_next = d->pk_end = 0;
    if (d->current == NONE) return;
    for (uint32_t k = d->current; k < d->current_end; k++) {
        slab_info *si = &s->slab[k];
        si->runners &= ~(1u << d->index);
        if (si->state == SLAB_COPYING && si->owner == d->index) si->state = SLAB_RUNNING, s->held--;
        if (si->state == SLAB_RUNNING && !si->runners) si->state = SLAB_TODO, s->redo = 1;
    }
}

/* HGuided: d's share of the slabs left, weighted by throughput, over K. */
static uint32_t packet_size(const clvox__sched *s, const clvox__sched_device *d)
{
    const clvox__sched_job *job = s->job;
    double mine = throughput(d);
    if (mine <= 0) return d->group; /* not measured yet: one call */
    double sum = 0;
    for (uint32_t e = 0; e < job->ndev; e++) {
        const clvox__sched_device *o = &job->dev[e];
        if (!o->ms || o->dead || o->left_out) continue;
        double t = throughput(o);
        sum += t > 0 ? t : mine;
    }
    double left = (double)(s->nslabs - s->next_fresh);
    double size = left * mine / (PACKET_K * (sum > 0 ? sum : mine));
    uint32_t cap = job->window / (s->alive ? s->alive : 1);
    if (cap < d->group) cap = d->group;
    uint32_t n = size < d->group ? d->group : size > cap ? cap : (uint32_t)size;
    return n;
}

/* Whether d is too slow to pay: its throughput under 1/SLOW_FRACTION of
 * the other live devices' together (all of them measured). */
static int too_slow(const clvox__sched *s, const clvox__sched_device *d)
{
    double mine = throughput(d), others = 0;
    if (mine <= 0) return 0;
    for (uint32_t e = 0; e < s->job->ndev; e++) {
        const clvox__sched_device *o = &s->job->dev[e];
        if (o == d || !o->ms || o->dead || o->left_out) continue;
        double t = throughput(o);
        if (t <= 0) return 0;
        others += t;
    }
    return others > 0 && mine * SLOW_FRACTION < others;
}

/* Whether a device other than d can still take work. */
static int others_alive(const clvox__sched *s, const clvox__sched_device *d)
{
    for (uint32_t e = 0; e < s->job->ndev; e++) {
        const clvox__sched_device *o = &s->job->dev[e];
        if (o != d && o->ms && !o->dead && !o->left_out) return 1;
    }
    return 0;
}

/* The lowest running group d should also compute (the same range, which
 * its planes hold): one other device runs it and d, at its own measured
 * throughput, would finish it sooner than that device will (estimated from
 * the fraction it has polled, else from its throughput). *gend: its end. */
static uint32_t straggler(const clvox__sched *s, const clvox__sched_device *d, double now, uint32_t *gend)
{
    const double rate = throughput(d);
    if (rate <= 0) return NONE;
    uint32_t end = s->written + s->job->window;
    if (end > s->nslabs) end = s->nslabs;
    for (uint32_t k = s->written; k < end; k++) {
        const slab_info *si = &s->slab[k];
        if (si->state != SLAB_RUNNING || si->gbeg != k || si->gend - k > d->group ||
            (si->runners & (1u << d->index)) || (si->runners & (si->runners - 1)))
            continue;
        uint32_t e = 0;
        while (!(si->runners & (1u << e))) e++;
        const clvox__sched_device *o = &s->job->dev[e];
        const double slices = range_slices(s, k, si->gend), mine = slices / rate, theirs = throughput(o);
        double elapsed = now - si->started, left;
        if (o->current == k && o->fraction > 0.01)
            left = elapsed * (1.0 - o->fraction) / o->fraction;
        else if (theirs > 0)
            left = slices / theirs - elapsed;
        else
            left = elapsed; /* unmeasured: assume as long again */
        if (mine < left) {
            *gend = si->gend;
            return k;
        }
    }
    return NONE;
}

/* The next group for d, [return, *gend), claimed; NONE when d is to stop.
 * Lock held. */
static uint32_t pick(clvox__sched *s, clvox__sched_device *d, uint32_t *gend)
{
    for (;;) {
        if (s->stop || d->dead) return NONE;
        uint32_t i = NONE, e = NONE;
        while (d->pk_next < d->pk_end) {
            const slab_info *si = &s->slab[d->pk_next];
            if (si->state == SLAB_ASSIGNED && si->owner == d->index) {
                i = d->pk_next;
                break;
            }
            d->pk_next++;
        }
        if (i == NONE && !d->left_out && too_slow(s, d)) {
            d->left_out = 1;
            s->alive--;
            release_slabs(s, d);
            pthread_cond_broadcast(&s->cv);
        }
        if (d->left_out && !others_alive(s, d)) { /* the others failed: back to work */
            d->left_out = 0;
            s->alive++;
        }
        if (i != NONE && i >= s->written + s->job->window && s->redo && !d->left_out) {
            /* its packet waits for room, while a slab to redo (a failed
             * device's, maybe the one the writer waits for) cannot: the
             * packet goes back and the lowest slab to redo comes first */
            for (uint32_t k = d->pk_next; k < d->pk_end; k++)
                if (s->slab[k].state == SLAB_ASSIGNED && s->slab[k].owner == d->index) s->slab[k].state = SLAB_TODO;
            d->pk_next = d->pk_end = 0;
            i = NONE;
        }
        if (i == NONE && !d->left_out && s->redo) {
            s->redo = 0;
            uint32_t n = 0;
            for (uint32_t k = s->written; k < s->next_fresh; k++)
                if (s->slab[k].state == SLAB_TODO) {
                    if (i == NONE) i = k;
                    if (k == i + n && n < d->group) n++; /* a packet of up to one group */
                    else s->redo = 1;                    /* more for the others */
                }
            if (i != NONE) {
                for (uint32_t k = i; k < i + n; k++)
                    s->slab[k].state = SLAB_ASSIGNED, s->slab[k].owner = (uint8_t)d->index;
                d->pk_next = i;
                d->pk_end = i + n;
            }
        }
        if (i == NONE && !d->left_out && s->next_fresh < s->nslabs) {
            uint32_t n = packet_size(s, d);
            if (n > s->nslabs - s->next_fresh) n = s->nslabs - s->next_fresh;
            d->pk_next = s->next_fresh;
            d->pk_end = s->next_fresh + n;
            for (uint32_t k = d->pk_next; k < d->pk_end; k++)
                s->slab[k].state = SLAB_ASSIGNED, s->slab[k].owner = (uint8_t)d->index;
            s->next_fresh += n;
            i = d->pk_next;
        }
        if (i == NONE && !d->left_out) i = straggler(s, d, clvox__now(), &e);
        if (i == NONE) {
            if (s->written == s->nslabs) return NONE;
            int open = 0;
            for (uint32_t k = s->written; k < s->nslabs && !open; k++) open = s->slab[k].state < SLAB_DONE;
            if (!open) return NONE;
            /* something may still fail or straggle: look again soon */
            struct timespec ts;
            clock_gettime(CLOCK_REALTIME, &ts);
            ts.tv_nsec += 50 * 1000 * 1000;
            if (ts.tv_nsec >= 1000000000L) ts.tv_sec++, ts.tv_nsec -= 1000000000L;
            pthread_cond_timedwait(&s->cv, &s->mu, &ts);
            continue;
        }
        if (i >= s->written + s->job->window) { /* the writer is behind: wait for room */
            pthread_cond_wait(&s->cv, &s->mu);
            continue;
        }
        if (e == NONE) { /* from its packet: up to a group of it, within the window */
            uint32_t lim = s->written + s->job->window;
            if (lim > d->pk_end) lim = d->pk_end;
            if (lim - i > d->group) lim = i + d->group;
            e = i + 1;
            while (e < lim && s->slab[e].state == SLAB_ASSIGNED && s->slab[e].owner == d->index) e++;
            d->pk_next = e;
        }
        const double now = clvox__now();
        for (uint32_t k = i; k < e; k++) {
            slab_info *si = &s->slab[k];
            if (si->state == SLAB_ASSIGNED || si->state == SLAB_TODO) {
                si->state = SLAB_RUNNING;
                si->started = now;
                si->gbeg = i;
                si->gend = e;
            }
            si->runners |= 1u << d->index;
        }
        *gend = e;
        return i;
    }
}

/* A device failed at group d->current (lock held): drop it, put its slabs
 * back, end the run if it was the last. */
static void device_failed(clvox__sched *s, clvox__sched_device *d, clvox_status st)
{
    const clvox__sched_job *job = s->job;
    uint32_t z = d->current != NONE ? slab_z0(s, d->current) : 0;
    d->dead = 1;
    s->alive--;
    release_slabs(s, d);
    d->current = NONE;
    if (s->first_device_st == CLVOX_OK) {
        s->first_device_st = st;
        snprintf(s->first_error, sizeof s->first_error, "device %u '%.128s': %.800s", d->ctx->position, d->ctx->device.name,
                 d->ctx->error);
    }
    int any = 0; /* a left-out device comes back (pick) */
    for (uint32_t e = 0; e < job->ndev; e++) any |= job->dev[e].ms && !job->dev[e].dead;
    if (any)
        clvox__warn(job->ctx, "device %u '%s' failed at slice %u (%s); its slabs were redone on the other devices",
                    d->ctx->position, d->ctx->device.name, z, d->ctx->error);
    else if (!s->stop) {
        s->stop = 1;
        s->status = st;
        if (job->ndev > 1) clvox__fail(job->ctx, st, "every device failed; %s", s->first_error);
        else if (d->ctx != job->ctx) clvox__fail(job->ctx, st, "%s", d->ctx->error);
    }
    pthread_cond_broadcast(&s->cv);
}

/* Reads slabs [i, e) from d's planes into their reorder buffer slots
 * (zero copy: maps slab i's slot, which d computed into). */
static clvox_status read_back(clvox__sched *s, clvox__sched_device *d, uint32_t i, uint32_t e)
{
    const clvox__sched_job *job = s->job;
    cl_int err = CL_SUCCESS;
    if (s->mapped) {
        const uint32_t w = i % job->window;
        for (int p = 0; p < 4 && err == CL_SUCCESS; p++) {
            if (!job->plane_slice[p]) continue;
            void *q = clEnqueueMapBuffer(d->ctx->queue, s->wrap[p][w], CL_TRUE, CL_MAP_READ, 0,
                                         (size_t)(job->depth * job->plane_slice[p]), 0, NULL, NULL, &err);
            if (err == CL_SUCCESS && q != s->slot[p][w]) { /* USE_HOST_PTR maps to host_ptr (OpenCL 1.2 5.4.2) */
                clEnqueueUnmapMemObject(d->ctx->queue, s->wrap[p][w], q, 0, NULL, NULL);
                return clvox__fail(d->ctx, CLVOX_ERR_OPENCL, "the device mapped a host buffer elsewhere");
            }
        }
        s->mapped[w] = 1; /* unmapped below on error paths too: see unmap_slot */
        if (err != CL_SUCCESS) return clvox__cl_fail(d->ctx, err, "mapping the slab for the writer");
        return CLVOX_OK;
    }
    for (uint32_t k = i; k < e && err == CL_SUCCESS; k++)
        for (int p = 0; p < 4 && err == CL_SUCCESS; p++) {
            if (!job->plane_slice[p]) continue;
            const size_t off = (size_t)(k - i) * job->depth * job->plane_slice[p];
            err = clEnqueueReadBuffer(d->ctx->queue, d->plane[p], CL_FALSE, off,
                                      (size_t)(slab_nz(s, k) * job->plane_slice[p]), s->slot[p][k % job->window], 0,
                                      NULL, NULL);
        }
    cl_int fin = clFinish(d->ctx->queue); /* the reads land before the slots are handed on */
    if (err == CL_SUCCESS) err = fin;
    if (err != CL_SUCCESS) return clvox__cl_fail(d->ctx, err, "reading the slab back");
    return CLVOX_OK;
}

/* Zero copy: gives slot w back to d's device (the writer is done with it). */
static clvox_status unmap_slot(clvox__sched *s, clvox__sched_device *d, uint32_t w)
{
    const clvox__sched_job *job = s->job;
    if (!s->mapped || !s->mapped[w]) return CLVOX_OK;
    cl_int err = CL_SUCCESS;
    for (int p = 0; p < 4; p++)
        if (job->plane_slice[p]) {
            cl_int e2 = clEnqueueUnmapMemObject(d->ctx->queue, s->wrap[p][w], s->slot[p][w], 0, NULL, NULL);
            if (err == CL_SUCCESS) err = e2;
        }
    s->mapped[w] = 0;
    if (err != CL_SUCCESS) return clvox__cl_fail(d->ctx, err, "unmapping a written slab");
    return CLVOX_OK;
}

static void *device_main(void *arg)
{
    clvox__sched_device *d = arg;
    clvox__sched *s = d->sched;
    const clvox__sched_job *job = s->job;
    const clvox__slab_out out = {d->plane[0], d->plane[1], d->plane[2], d->plane[3]};
    pthread_mutex_lock(&s->mu);
    for (;;) {
        uint32_t e = NONE, i = pick(s, d, &e);
        if (i == NONE) break;
        d->current = i;
        d->current_end = e;
        d->fraction = 0;
        int fail_now = 0; /* the hook's N-th slab is in this group */
        for (uint32_t k = i; k < e; k++) fail_now |= clvox__hook_fails_device(d->ctx->position, ++d->slabs_started);
        const uint32_t nth = d->slabs_started;
        pthread_mutex_unlock(&s->mu);

        double t0 = clvox__now();
        clvox__slab_stats ss;
        memset(&ss, 0, sizeof ss);
        uint32_t z0 = slab_z0(s, i), nz = range_slices(s, i, e);
        clvox_status st = CLVOX_OK;
        clvox__slab_out here = out;
        if (s->mapped) { /* zero copy: compute into slab i's slot, which the writer has given back */
            const uint32_t w = i % job->window;
            st = unmap_slot(s, d, w);
            here = (clvox__slab_out){s->wrap[0] ? s->wrap[0][w] : NULL, s->wrap[1] ? s->wrap[1][w] : NULL,
                                     s->wrap[2] ? s->wrap[2][w] : NULL, s->wrap[3] ? s->wrap[3][w] : NULL};
        }
        if (st != CLVOX_OK)
            ;
        else if (fail_now)
            st = clvox__fail(d->ctx, CLVOX_ERR_OPENCL, "CLVOX_TEST_FAIL_DEVICE=%u:%u: a simulated OpenCL error",
                             d->ctx->position, nth);
        else
            st = job->m->slab(d->ms, z0, nz, &here, &ss);
        if (st == CLVOX_OK && job->m2) {
            ss.filled = 0; /* the surface pass counts the union */
            st = job->m2->slab(d->ms2, z0, nz, &here, &ss);
        }
        /* The group is won whole or not at all: a copy elsewhere computes
         * the same range and claims it under the same lock. */
        pthread_mutex_lock(&s->mu);
        int won = st == CLVOX_OK && !s->stop;
        for (uint32_t k = i; k < e && won; k++) won = s->slab[k].state <= SLAB_RUNNING;
        if (won) {
            for (uint32_t k = i; k < e; k++) {
                s->slab[k].state = SLAB_COPYING;
                s->slab[k].owner = (uint8_t)d->index;
            }
            s->held += e - i;
            if (s->held > s->peak) s->peak = s->held;
        }
        pthread_mutex_unlock(&s->mu);
        if (won) st = read_back(s, d, i, e);
        if (st != CLVOX_OK || !won) clFinish(d->ctx->queue); /* a stopped method may leave commands queued */
        double busy = clvox__now() - t0;

        pthread_mutex_lock(&s->mu);
        d->busy_all += busy;
        if (st == CLVOX_OK && won) {
            for (uint32_t k = i; k < e; k++) {
                slab_info *si = &s->slab[k];
                si->state = SLAB_DONE;
                si->runners &= ~(1u << d->index);
                if (k == i) si->ss = ss; /* the group's statistics, once */
                else memset(&si->ss, 0, sizeof si->ss);
            }
            d->slabs_won += e - i;
            d->slices_won += nz;
            d->busy_won += busy;
        } else if (st == CLVOX_OK || (st == CLVOX_ERR_CANCELLED && (s->stop || s->slab[i].state > SLAB_RUNNING))) {
            /* lost the race, or the run stops: a slab nobody else computes
             * goes back (none does while copies share whole ranges) */
            for (uint32_t k = i; k < e; k++) {
                slab_info *si = &s->slab[k];
                si->runners &= ~(1u << d->index);
                if (si->state == SLAB_RUNNING && !si->runners) si->state = SLAB_TODO, s->redo = 1;
            }
            if (!s->stop) d->slabs_lost += e - i;
        } else {
            device_failed(s, d, st);
            break;
        }
        d->current = NONE;
        pthread_cond_broadcast(&s->cv);
    }
    d->current = NONE;
    pthread_cond_broadcast(&s->cv);
    pthread_mutex_unlock(&s->mu);
    return NULL;
}

static void add_slab_stats(clvox_stats *stats, const clvox__slab_stats *ss)
{
    stats->seconds[CLVOX_STAGE_CAST] += ss->cast_seconds;
    stats->seconds[CLVOX_STAGE_CLASSIFY] += ss->classify_seconds;
    stats->filled_voxels += ss->filled;
    stats->rays += ss->rays;
    stats->odd_parity_rays += ss->odd_parity_rays;
    stats->overflow_rays += ss->overflow_rays;
    stats->coverage_sum += (double)ss->coverage_count;
    stats->palette_early_voxels += ss->palette_early;
    stats->palette_shortcut_voxels += ss->palette_shortcut;
    stats->palette_scored_voxels += ss->palette_scored;
    stats->palette_nonempty_voxels += ss->palette_nonempty;
    stats->palette_volume += ss->palette_volume;
    stats->winding.exact_points += ss->exact_points;
    stats->winding_exact_seconds += ss->exact_seconds;
    stats->winding_host_points += ss->host_points;
    if (ss->max_crossings > stats->max_crossings) stats->max_crossings = ss->max_crossings;
}

/* Progress as one device would report it: the slabs written and the
 * polled fraction of the one the writer waits for (furthest copy). Never
 * more than the next slab's end, so the calls after each slab written keep
 * it increasing. */
static double progress_of(const clvox__sched *s)
{
    double running = 0;
    for (uint32_t e = 0; e < s->job->ndev; e++) {
        const clvox__sched_device *d = &s->job->dev[e];
        if (d->current == s->written && d->fraction > running && d->fraction < 1.0) running = d->fraction;
    }
    return ((double)s->written + running) / s->nslabs;
}

/* Zero copy off: the slot buffers released (after their last unmap). */
static void release_wraps(clvox__sched *s)
{
    for (int p = 0; p < 4; p++) {
        if (!s->wrap[p]) continue;
        for (uint32_t w = 0; w < s->job->window; w++) clvox__release_mem(&s->wrap[p][w]);
        free(s->wrap[p]);
        s->wrap[p] = NULL;
    }
    free(s->mapped);
    s->mapped = NULL;
}

clvox_status clvox__sched_run(const clvox__sched_job *job, clvox_stats *stats)
{
    clvox_context *ctx = job->ctx;
    clvox__sched s;
    memset(&s, 0, sizeof s);
    s.job = job;
    s.nslabs = (job->Z + job->depth - 1) / job->depth;
    s.status = CLVOX_OK;
    s.slab = calloc(s.nslabs, sizeof *s.slab);
    if (!s.slab) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    clvox_status st = CLVOX_OK;
    const clvox__sched_device *d0 = &job->dev[0];
    cl_bool unified = CL_FALSE;
    if (job->ndev == 1 && d0->ms && d0->group == 1 && !clvox__hooks()->copy_slabs)
        clGetDeviceInfo(d0->ctx->device_id, CL_DEVICE_HOST_UNIFIED_MEMORY, sizeof unified, &unified, NULL);
    for (int p = 0; p < 4 && st == CLVOX_OK; p++) {
        if (!job->plane_slice[p]) continue;
        s.slot[p] = calloc(job->window, sizeof *s.slot[p]);
        if (!s.slot[p]) st = CLVOX_ERR_OUT_OF_MEMORY;
        const size_t bytes = (size_t)(job->depth * job->plane_slice[p]);
        for (uint32_t w = 0; w < job->window && st == CLVOX_OK; w++)
            if (!(s.slot[p][w] = unified ? aligned_alloc(4096, (bytes + 4095) / 4096 * 4096) : malloc(bytes)))
                st = CLVOX_ERR_OUT_OF_MEMORY;
    }
    if (st != CLVOX_OK) st = clvox__fail(ctx, st, "out of memory for the reorder buffer (%u slabs)", job->window);
    if (st == CLVOX_OK && unified) { /* zero copy where the buffers can be made; else the copies */
        int ok = (s.mapped = calloc(job->window, 1)) != NULL;
        for (int p = 0; p < 4 && ok; p++) {
            if (!job->plane_slice[p]) continue;
            ok = (s.wrap[p] = calloc(job->window, sizeof *s.wrap[p])) != NULL;
            for (uint32_t w = 0; w < job->window && ok; w++) {
                cl_int err = CL_SUCCESS;
                s.wrap[p][w] = clCreateBuffer(d0->ctx->cl, CL_MEM_READ_WRITE | CL_MEM_USE_HOST_PTR,
                                              (size_t)(job->depth * job->plane_slice[p]), s.slot[p][w], &err);
                ok = err == CL_SUCCESS && s.wrap[p][w];
            }
        }
        if (!ok) release_wraps(&s);
    }
    pthread_mutex_init(&s.mu, NULL);
    pthread_cond_init(&s.cv, NULL);

    double t_start = clvox__now();
    for (uint32_t e = 0; e < job->ndev && st == CLVOX_OK; e++) {
        clvox__sched_device *d = &job->dev[e];
        d->sched = &s;
        d->index = e;
        d->current = NONE;
        if (!d->ms) continue;
        s.alive++;
    }
    pthread_mutex_lock(&s.mu);
    for (uint32_t e = 0; e < job->ndev && st == CLVOX_OK; e++) {
        clvox__sched_device *d = &job->dev[e];
        if (!d->ms) continue;
        d->started = pthread_create(&d->thread, NULL, device_main, d) == 0;
        if (!d->started) {
            snprintf(d->ctx->error, sizeof d->ctx->error, "cannot start its host thread");
            device_failed(&s, d, CLVOX_ERR_OUT_OF_MEMORY);
        }
    }
    /* The writer: this thread. */
    s.last_progress = -1e300; /* the first poll inside a slab is passed on */
    while (st == CLVOX_OK && !s.stop && s.written < s.nslabs) {
        uint32_t i = s.written;
        if (s.poll_pending) { /* a device asks between its batches */
            double f = progress_of(&s);
            int go = 1;
            if (f > s.reported) { /* the caller sees the fraction increase */
                pthread_mutex_unlock(&s.mu);
                go = job->progress(job->progress_user, f);
                pthread_mutex_lock(&s.mu);
                s.reported = f;
            }
            s.last_progress = clvox__now();
            s.poll_pending = 0;
            if (!go) {
                st = clvox__fail(ctx, CLVOX_ERR_CANCELLED, "cancelled after %u of %u slabs", s.written, s.nslabs);
                s.stop = 1;
            }
            pthread_cond_broadcast(&s.cv);
            continue;
        }
        if (s.slab[i].state == SLAB_DONE) {
            s.writing = 1;
            pthread_mutex_unlock(&s.mu);
            uint32_t slot = i % job->window;
            clvox__slab_planes hp = {s.slot[0] ? s.slot[0][slot] : NULL, s.slot[1] ? s.slot[1][slot] : NULL,
                                     s.slot[2] ? s.slot[2][slot] : NULL, s.slot[3] ? s.slot[3][slot] : NULL};
            double t0 = clvox__now();
            clvox_status sst = job->sink(job->sink_user, slab_z0(&s, i), slab_nz(&s, i), &hp);
            stats->seconds[CLVOX_STAGE_WRITE] += clvox__now() - t0;
            add_slab_stats(stats, &s.slab[i].ss); /* DONE: no device writes it any more */
            int go = 1;
            if (sst == CLVOX_OK && job->progress) go = job->progress(job->progress_user, (double)(i + 1) / s.nslabs);
            s.reported = (double)(i + 1) / s.nslabs; /* only this thread writes it */
            pthread_mutex_lock(&s.mu);
            s.writing = 0;
            if (job->progress) s.last_progress = clvox__now();
            s.slab[i].state = SLAB_WRITTEN;
            s.held--;
            s.written++;
            if (sst != CLVOX_OK) st = sst;
            else if (!go)
                st = clvox__fail(ctx, CLVOX_ERR_CANCELLED, "cancelled after %u of %u slabs", s.written, s.nslabs);
            if (st != CLVOX_OK) s.stop = 1;
            pthread_cond_broadcast(&s.cv);
            continue;
        }
        pthread_cond_wait(&s.cv, &s.mu);
    }
    if (st == CLVOX_OK && s.stop && s.written < s.nslabs) st = s.status != CLVOX_OK ? s.status : CLVOX_ERR_INTERNAL;
    s.stop = 1;
    pthread_cond_broadcast(&s.cv);
    pthread_mutex_unlock(&s.mu);
    for (uint32_t e = 0; e < job->ndev; e++)
        if (job->dev[e].started) pthread_join(job->dev[e].thread, NULL);
    double wall = clvox__now() - t_start;

    /* What each device did; the efficiency of the whole. */
    double sum_rate = 0;
    uint64_t slices = 0;
    stats->device_count = job->ndev < CLVOX_MAX_DEVICES ? job->ndev : CLVOX_MAX_DEVICES;
    for (uint32_t e = 0; e < stats->device_count; e++) {
        const clvox__sched_device *d = &job->dev[e];
        clvox_device_share *sh = &stats->devices[e];
        sh->device = e;
        sh->slabs = d->slabs_won;
        sh->slices = d->slices_won;
        sh->busy_seconds = d->busy_all;
        sh->discarded_slabs = d->slabs_lost;
        sh->failed = d->dead;
        sh->left_out = d->left_out || !d->ms;
        sum_rate += throughput(d);
        slices += d->slices_won;
    }
    stats->scheduling_efficiency = sum_rate > 0 && wall > 0 ? (double)slices / (sum_rate * wall) : 0.0;
    if (stats->scheduling_efficiency > 1.0) stats->scheduling_efficiency = 1.0;
    stats->reorder_slabs = job->window;
    stats->reorder_peak = s.peak;
    for (int p = 0; p < 4; p++) stats->reorder_bytes += (uint64_t)job->window * job->depth * job->plane_slice[p];

    if (s.mapped) { /* the device threads have ended: give the slots back, then the buffers */
        for (uint32_t w = 0; w < job->window; w++) unmap_slot(&s, &job->dev[0], w);
        clFinish(job->dev[0].ctx->queue);
        release_wraps(&s);
    }
    for (int p = 0; p < 4; p++) {
        if (!s.slot[p]) continue;
        for (uint32_t w = 0; w < job->window; w++) free(s.slot[p][w]);
        free(s.slot[p]);
    }
    for (uint32_t e = 0; e < job->ndev; e++) job->dev[e].sched = NULL;
    free(s.slab);
    pthread_cond_destroy(&s.cv);
    pthread_mutex_destroy(&s.mu);
    return st;
}
