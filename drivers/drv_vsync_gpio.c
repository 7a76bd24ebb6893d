/* SPDX-License-Identifier: MIT */
/* drv_vsync_gpio: the vsync backend on the panel's TE line: a thread waits for edges and feeds the estimator; next()
 * reads the published estimate without locks. When edges stop for more than 3.5 periods the source free-runs on the
 * estimate (or the nominal rate) and relocks as soon as edges return. The mock edge source: drv_vsync_gpio_mock.c. */
#include "drivers/drv_vsync_gpio.h"

#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "drivers/drv_gpiod1.h"
#include "drivers/drv_vsync_est.h"
#include "platform/plat_clock.h"
#include "warp/warp_err.h"

#define BATCH 16          /* edges per wait (the v1 kernel FIFO's size) */
#define FALLBACK_PERIODS 3.5
#define MAX_WAIT_MS 20    /* the thread checks for destroy() at least this often */
#define NO_LOCK_WARN_NS (1 * PLAT_NS_PER_S)

/* The published model as a "latch" (two copies and a sequence counter, like the kernel's seqcount_latch): the
 * writer updates one copy while readers use the other, so a reader never waits for the writer and retries only
 * when a whole update completed during its read. */
typedef struct {
    _Atomic int64_t ref_ns;
    _Atomic uint64_t period_bits; /* double */
} pub_slot;

typedef struct {
    drv_vsync base;
    drv_edge_source *src;
    double nominal_ns;
    int64_t created_ns;

    atomic_uint seq;
    pub_slot slot[2];

    pthread_t thread;
    atomic_bool stop;

    /* edge thread only */
    drv_vsync_est est;
    bool on_timer, warned_no_lock;
    int64_t timer_since_ns;
    drv_vsync_model published;

    pthread_mutex_t mu; /* guards st and ex (statistics, off the vsync path) */
    drv_vsync_stats st;
    drv_vsync_edges_stats ex;
} vsync_edges;

static void slot_write(pub_slot *s, const drv_vsync_model *m)
{
    uint64_t bits;
    memcpy(&bits, &m->period_ns, sizeof bits);
    atomic_store_explicit(&s->ref_ns, m->ref_ns, memory_order_relaxed);
    atomic_store_explicit(&s->period_bits, bits, memory_order_relaxed);
}

static void publish(vsync_edges *s, const drv_vsync_model *m)
{
    /* Each switch is a release (the copy readers move to is complete) followed by a release fence (a reader that
     * sees the copy being overwritten also sees the switch, and retries). */
    unsigned q = atomic_load_explicit(&s->seq, memory_order_relaxed);
    atomic_store_explicit(&s->seq, q + 1, memory_order_release); /* readers move to copy (q + 1) & 1 */
    atomic_thread_fence(memory_order_release);
    slot_write(&s->slot[q & 1], m);
    atomic_store_explicit(&s->seq, q + 2, memory_order_release); /* readers back to copy q & 1 */
    atomic_thread_fence(memory_order_release);
    slot_write(&s->slot[(q + 1) & 1], m);
    s->published = *m;
}

static drv_vsync_model read_model(vsync_edges *s)
{
    drv_vsync_model m;
    unsigned q;
    do {
        q = atomic_load_explicit(&s->seq, memory_order_acquire);
        const pub_slot *sl = &s->slot[q & 1];
        m.ref_ns = atomic_load_explicit(&sl->ref_ns, memory_order_relaxed);
        uint64_t bits = atomic_load_explicit(&sl->period_bits, memory_order_relaxed);
        memcpy(&m.period_ns, &bits, sizeof bits);
        atomic_thread_fence(memory_order_acquire);
    } while (atomic_load_explicit(&s->seq, memory_order_relaxed) != q);
    return m;
}

static int64_t edges_next(drv_vsync *v, int64_t after_ns, int64_t *period_ns)
{
    drv_vsync_model m = read_model((vsync_edges *)v);
    return drv_vsync_model_next(&m, after_ns, period_ns);
}

static void edges_stats(drv_vsync *v, drv_vsync_stats *out)
{
    vsync_edges *s = (vsync_edges *)v;
    pthread_mutex_lock(&s->mu);
    *out = s->st;
    pthread_mutex_unlock(&s->mu);
}

void drv_vsync_edges_stats_get(drv_vsync *v, drv_vsync_stats *st, drv_vsync_edges_stats *ex)
{
    if (st) *st = (drv_vsync_stats){0};
    if (ex) *ex = (drv_vsync_edges_stats){0};
    if (!v || v->next != edges_next) return;
    vsync_edges *s = (vsync_edges *)v;
    pthread_mutex_lock(&s->mu);
    if (st) *st = s->st;
    if (ex) *ex = s->ex;
    pthread_mutex_unlock(&s->mu);
}

static void set_error(vsync_edges *s, const char *msg)
{
    snprintf(s->st.last_error, sizeof s->st.last_error, "%s", msg);
}

/* After each wait: timer fallback when the edges stopped, back to the edges when they return, and the model that
 * next() should use. */
static void update(vsync_edges *s, int64_t now, const char *fault, uint64_t bad, bool read_error)
{
    drv_vsync_est *e = &s->est;
    bool locked = drv_vsync_est_locked(e);
    char msg[160] = "";
    /* On the timer before the first lock (not a fallback), when the edges stop, or if the lock is lost. */
    bool stopped = locked && (double)(now - e->last_accept_ns) > FALLBACK_PERIODS * e->model.period_ns;
    if (!s->on_timer && (stopped || !locked)) {
        s->on_timer = true;
        s->timer_since_ns = now;
        snprintf(msg, sizeof msg, "vsync %s: %s; free-running at %.3f Hz", s->src->name,
                 stopped ? "edges stopped" : "lock lost", 1e9 / s->published.period_ns);
        pthread_mutex_lock(&s->mu);
        s->st.fallbacks++;
        pthread_mutex_unlock(&s->mu);
    } else if (s->on_timer && locked && !stopped && e->last_accept_ns > s->timer_since_ns) {
        s->on_timer = false;
    }
    if (!locked && !s->warned_no_lock && now - s->created_ns > NO_LOCK_WARN_NS) {
        s->warned_no_lock = true;
        snprintf(msg, sizeof msg, "vsync %s: no lock after %llu edges; free-running at %.3f Hz", s->src->name,
                 (unsigned long long)drv_vsync_est_counters_get(e)->edges, 1e9 / s->published.period_ns);
    }

    /* Free-running continues on the last estimate (the nominal rate from creation until the first lock). */
    drv_vsync_model m = s->published;
    if (drv_vsync_est_model(e, &m) && (m.ref_ns != s->published.ref_ns || m.period_ns != s->published.period_ns))
        publish(s, &m);

    const drv_vsync_est_counters *c = drv_vsync_est_counters_get(e);
    pthread_mutex_lock(&s->mu);
    s->st.edges = c->edges + s->ex.bad_stamps + bad;
    s->st.spurious = c->spurious;
    s->st.missed = c->missed;
    s->st.on_timer = s->on_timer;
    s->st.period_ns = llround(m.period_ns);
    s->st.jitter_us = drv_vsync_est_jitter_us(e);
    s->ex.locks = c->locks;
    s->ex.bad_stamps += bad;
    s->ex.read_errors += read_error;
    s->ex.locked = locked;
    if (fault && fault[0]) set_error(s, fault);
    if (msg[0]) set_error(s, msg);
    pthread_mutex_unlock(&s->mu);
}

static void *edges_thread(void *arg)
{
    vsync_edges *s = arg;
    plat_thread_set_name("hmdwarp-te");
    int64_t t[BATCH];
    char err[160], fault[160];
    while (!atomic_load_explicit(&s->stop, memory_order_relaxed)) {
        /* About one period, so a stop is noticed within FALLBACK_PERIODS and destroy() within MAX_WAIT_MS. */
        double p = drv_vsync_est_locked(&s->est) ? s->est.model.period_ns : s->nominal_ns;
        int timeout_ms = (int)ceil(p / 1e6);
        if (timeout_ms > MAX_WAIT_MS) timeout_ms = MAX_WAIT_MS;
        if (timeout_ms < 1) timeout_ms = 1;
        err[0] = fault[0] = 0;
        int n = s->src->wait(s->src, t, BATCH, timeout_ms, err, sizeof err);
        int64_t now = plat_now_ns();
        uint64_t bad = 0;
        if (n < 0) {
            snprintf(fault, sizeof fault, "%s", err[0] ? err : "vsync: edge source failed");
            update(s, now, fault, 0, true);
            plat_sleep_ns((int64_t)timeout_ms * PLAT_NS_PER_MS); /* a dead line fails at once: do not spin */
            continue;
        }
        for (int i = 0; i < n; i++) {
            /* An edge time far from now is on another clock (or garbage); it would wreck the fit. */
            if (t[i] > now + 50 * PLAT_NS_PER_MS || t[i] < now - 10 * PLAT_NS_PER_S) {
                bad++;
                snprintf(fault, sizeof fault, "vsync %s: edge time %.3f s from now is not CLOCK_MONOTONIC; dropped",
                         s->src->name, (double)(t[i] - now) * 1e-9);
                continue;
            }
            drv_vsync_est_edge(&s->est, t[i]);
        }
        update(s, now, fault, bad, false);
    }
    return NULL;
}

static void edges_destroy(drv_vsync *v)
{
    vsync_edges *s = (vsync_edges *)v;
    atomic_store(&s->stop, true);
    pthread_join(s->thread, NULL);
    s->src->close(s->src);
    pthread_mutex_destroy(&s->mu);
    free(s);
}

drv_vsync *drv_vsync_edges_create(drv_edge_source *src, double refresh_hz, const char *name)
{
    if (!src) return NULL;
    if (!(refresh_hz >= 10 && refresh_hz <= 1000)) {
        src->close(src);
        return NULL;
    }
    vsync_edges *s = calloc(1, sizeof *s);
    if (!s) {
        src->close(src);
        return NULL;
    }
    s->base.name = name;
    s->base.next = edges_next;
    s->base.stats = edges_stats;
    s->base.destroy = edges_destroy;
    s->src = src;
    s->nominal_ns = 1e9 / refresh_hz;
    s->created_ns = plat_now_ns();
    drv_vsync_est_init(&s->est, refresh_hz);
    s->on_timer = true; /* until the first lock */
    s->timer_since_ns = s->created_ns;
    s->st.on_timer = true;
    s->st.period_ns = llround(s->nominal_ns);
    atomic_init(&s->seq, 0);
    atomic_init(&s->stop, false);
    drv_vsync_model m = {s->created_ns, s->nominal_ns};
    slot_write(&s->slot[0], &m);
    slot_write(&s->slot[1], &m);
    s->published = m;
    pthread_mutex_init(&s->mu, NULL);
    if (pthread_create(&s->thread, NULL, edges_thread, s) != 0) {
        pthread_mutex_destroy(&s->mu);
        src->close(src);
        free(s);
        return NULL;
    }
    return &s->base;
}

drv_vsync *drv_vsync_gpio_create(const drv_vsync_gpio_params *p, char *err, int errlen)
{
    if (!(p->refresh_hz >= 10 && p->refresh_hz <= 1000)) {
        warp_err(err, errlen, "vsync gpio: refresh rate %g Hz out of range (10..1000)", p->refresh_hz);
        return NULL;
    }
    char chip[sizeof p->chip + 1];
    memcpy(chip, p->chip, sizeof p->chip);
    chip[sizeof p->chip] = 0;
    drv_edge_source *src = drv_gpiod1_edges_open(chip, p->line, p->falling_edge, err, errlen);
    if (!src) return NULL;
    drv_vsync *v = drv_vsync_edges_create(src, p->refresh_hz, "gpio");
    if (!v) warp_err(err, errlen, "vsync gpio: cannot start the edge thread (out of memory or threads)");
    return v;
}
