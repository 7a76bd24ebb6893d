/* SPDX-License-Identifier: MIT */
/* Unit tests for the vsync sources: the TE-edge estimator on synthetic edge sequences (jitter, missed and spurious
 * edges, off-nominal rate, phase jumps, next() semantics), the GPIO backend on its mock edge source in real time
 * (lock, timer fallback, relock), the free-running timer, and the errors of a missing GPIO chip. */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "drivers/drv_vsync.h"
#include "drivers/drv_vsync_est.h"
#include "drivers/drv_vsync_gpio_mock.h"
#include "drivers/drv_vsync_timer.h"
#include "platform/plat_clock.h"
#include "tests/support/test_util.h"

#define US 1000LL
#define MS 1000000LL

/* ---- synthetic TE line ---- */

typedef struct {
    double hz;            /* true panel rate */
    double jitter_us;     /* uniform +- */
    double miss_prob;
    double spurious_prob; /* per period, a glitch between 0.1 and 0.9 of the period */
    int64_t t0;
    uint64_t seed;
} gen_params;

typedef struct {
    gen_params p;
    double period;
    test_rng rng;
    int64_t k;          /* next vsync */
    int64_t pend[2];    /* events of the current period not yet handed out */
    bool pend_glitch[2];
    int64_t pend_k[2];
    int pend_n, pend_i;
    uint64_t dropped;   /* edges lost so far */
} gen;

static void gen_init(gen *g, const gen_params *p)
{
    memset(g, 0, sizeof *g);
    g->p = *p;
    g->period = 1e9 / p->hz;
    g->rng = test_rng_make(p->seed);
}

static int64_t truth(const gen *g, int64_t k) { return g->p.t0 + llround((double)k * g->period); }

/* The next event: its time, whether it is a glitch, and its vsync index. */
static int64_t gen_next(gen *g, bool *glitch, int64_t *k)
{
    while (g->pend_i == g->pend_n) {
        g->pend_n = g->pend_i = 0;
        double j = test_rng_uniform(&g->rng, -1, 1) * g->p.jitter_us * 1e3;
        bool lost = test_rng_uniform(&g->rng, 0, 1) < g->p.miss_prob;
        bool gl = test_rng_uniform(&g->rng, 0, 1) < g->p.spurious_prob;
        double where = test_rng_uniform(&g->rng, 0.1, 0.9);
        if (lost) {
            g->dropped++;
        } else {
            g->pend[g->pend_n] = truth(g, g->k) + llround(j);
            g->pend_glitch[g->pend_n] = false;
            g->pend_k[g->pend_n++] = g->k;
        }
        if (gl) {
            g->pend[g->pend_n] = truth(g, g->k) + llround(where * g->period);
            g->pend_glitch[g->pend_n] = true;
            g->pend_k[g->pend_n++] = g->k;
        }
        g->k++;
    }
    if (glitch) *glitch = g->pend_glitch[g->pend_i];
    if (k) *k = g->pend_k[g->pend_i];
    return g->pend[g->pend_i++];
}

/* Feeds events up to (not including) vsync k_end; returns how many edges it took to lock (-1: never). */
static int feed_until(drv_vsync_est *e, gen *g, int64_t k_end)
{
    int n = 0, locked_after = drv_vsync_est_locked(e) ? 0 : -1;
    while (g->k < k_end || g->pend_i < g->pend_n) {
        int64_t t = gen_next(g, NULL, NULL);
        n++;
        drv_vsync_est_edge(e, t);
        if (locked_after < 0 && drv_vsync_est_locked(e)) locked_after = n;
    }
    return locked_after;
}

/* Largest error of the predicted next vsync, asked from mid-period, for `ahead` vsyncs after vsync k. */
static double pred_err_us(const drv_vsync_est *e, const gen *g, int64_t k, int ahead)
{
    double worst = 0;
    for (int a = 1; a <= ahead; a++) {
        int64_t want = truth(g, k + a);
        int64_t after = want - llround(g->period / 2);
        int64_t got = drv_vsync_est_next(e, after, NULL);
        double err = fabs((double)(got - want)) / 1e3;
        if (err > worst) worst = err;
    }
    return worst;
}

static void test_est_clean(void **state)
{
    (void)state;
    gen g;
    gen_init(&g, &(gen_params){.hz = 90, .t0 = 1000 * MS, .seed = 1});
    drv_vsync_est e;
    drv_vsync_est_init(&e, 90);
    assert_false(drv_vsync_est_locked(&e));
    int locked_after = feed_until(&e, &g, 200);
    assert_true(locked_after > 0 && locked_after <= DRV_VSYNC_EST_ACQUIRE);
    int64_t period;
    drv_vsync_est_next(&e, g.p.t0, &period);
    assert_true(llabs(period - llround(1e9 / 90)) <= 1);
    assert_true(pred_err_us(&e, &g, 199, 100) < 1.0);
    const drv_vsync_est_counters *c = drv_vsync_est_counters_get(&e);
    assert_int_equal(c->edges, 200);
    assert_int_equal(c->accepted, 200);
    assert_int_equal(c->spurious, 0);
    assert_int_equal(c->missed, 0);
    assert_int_equal(c->locks, 1);
    assert_true(drv_vsync_est_jitter_us(&e) < 1.0);
}

static void test_est_jitter(void **state)
{
    (void)state;
    gen g;
    gen_init(&g, &(gen_params){.hz = 90, .jitter_us = 200, .t0 = 5 * MS, .seed = 2});
    drv_vsync_est e;
    drv_vsync_est_init(&e, 90);
    feed_until(&e, &g, 100);
    assert_true(drv_vsync_est_locked(&e));
    /* From then on, after every edge: the next 10 vsyncs within 100 us of truth despite +-200 us jitter. */
    double worst = 0;
    for (int64_t k = 100; k < 2000; k++) {
        feed_until(&e, &g, k + 1);
        double err = pred_err_us(&e, &g, k, 10);
        if (err > worst) worst = err;
    }
    assert_true(worst < 100.0);
    /* Uniform +-200 us has an RMS of 115 us. */
    double j = drv_vsync_est_jitter_us(&e);
    assert_true(j > 90 && j < 140);
    const drv_vsync_est_counters *c = drv_vsync_est_counters_get(&e);
    assert_int_equal(c->spurious, 0);
    assert_int_equal(c->missed, 0);
    assert_int_equal(c->locks, 1);
}

static void test_est_missed(void **state)
{
    (void)state;
    gen g;
    gen_init(&g, &(gen_params){.hz = 90, .jitter_us = 100, .miss_prob = 0.1, .t0 = 5 * MS, .seed = 3});
    drv_vsync_est e;
    drv_vsync_est_init(&e, 90);
    int64_t last_k = -1;
    uint64_t holes = 0, gaps = 0;
    double worst = 0;
    while (g.k < 3000) {
        int64_t k;
        int64_t t = gen_next(&g, NULL, &k);
        bool was_locked = drv_vsync_est_locked(&e);
        drv_vsync_edge_kind kind = drv_vsync_est_edge(&e, t);
        if (was_locked) {
            if (k > last_k + 1) {
                /* The edge after a hole says how many vsyncs it skipped. */
                assert_int_equal(kind, DRV_VSYNC_EDGE_AFTER_GAP);
                assert_int_equal(drv_vsync_est_last_gap(&e), k - last_k - 1);
                holes += (uint64_t)(k - last_k - 1);
                gaps++;
            } else {
                assert_int_equal(kind, DRV_VSYNC_EDGE_ACCEPTED);
            }
            double err = pred_err_us(&e, &g, k, 5);
            if (err > worst) worst = err;
        }
        last_k = k;
    }
    assert_true(gaps > 200);
    assert_true(worst < 100.0);
    /* Exactly the vsyncs without an edge since the lock are counted. */
    const drv_vsync_est_counters *c = drv_vsync_est_counters_get(&e);
    assert_int_equal(c->missed, holes);
    assert_true(holes > 250 && holes < 350);
    assert_int_equal(c->spurious, 0);
    assert_int_equal(c->locks, 1);
}

static void test_est_spurious(void **state)
{
    (void)state;
    gen g;
    gen_init(&g, &(gen_params){.hz = 90, .jitter_us = 100, .miss_prob = 0.05, .spurious_prob = 0.2, .t0 = 5 * MS,
                               .seed = 4});
    drv_vsync_est e;
    drv_vsync_est_init(&e, 90);
    feed_until(&e, &g, 60);
    assert_true(drv_vsync_est_locked(&e));
    uint64_t sp0 = drv_vsync_est_counters_get(&e)->spurious, glitches = 0;
    double worst = 0;
    while (g.k < 3000) {
        bool glitch;
        int64_t k;
        int64_t t = gen_next(&g, &glitch, &k);
        drv_vsync_edge_kind kind = drv_vsync_est_edge(&e, t);
        if (glitch) {
            assert_int_equal(kind, DRV_VSYNC_EDGE_SPURIOUS);
            glitches++;
        } else {
            assert_true(kind == DRV_VSYNC_EDGE_ACCEPTED || kind == DRV_VSYNC_EDGE_AFTER_GAP);
        }
        double err = pred_err_us(&e, &g, k, 5);
        if (err > worst) worst = err;
    }
    assert_true(glitches > 400);
    assert_int_equal(drv_vsync_est_counters_get(&e)->spurious - sp0, glitches);
    assert_true(worst < 100.0);
    assert_int_equal(drv_vsync_est_counters_get(&e)->locks, 1);

    /* A glitch just before a vsync, inside the gate, then the real edge: the one nearer the fit is kept. */
    int64_t k = g.k;
    int64_t want = truth(&g, k);
    drv_vsync_edge_kind kind = drv_vsync_est_edge(&e, want - 400 * US);
    assert_true(kind == DRV_VSYNC_EDGE_ACCEPTED || kind == DRV_VSYNC_EDGE_AFTER_GAP);
    assert_int_equal(drv_vsync_est_edge(&e, want + 10 * US), DRV_VSYNC_EDGE_SPURIOUS);
    assert_true(llabs(drv_vsync_est_next(&e, want - 5 * MS, NULL) - want) < 40 * US);
    assert_int_equal(drv_vsync_est_edge(&e, truth(&g, k + 1) - 30 * US), DRV_VSYNC_EDGE_ACCEPTED);
    assert_true(llabs(drv_vsync_est_next(&e, truth(&g, k + 1) + 5 * MS, NULL) - truth(&g, k + 2)) < 40 * US);
}

static void test_est_rate_error(void **state)
{
    (void)state;
    const double rates[] = {89.5, 90 * 1.005, 90 * 0.95};
    for (int i = 0; i < 3; i++) {
        gen g;
        gen_init(&g, &(gen_params){.hz = rates[i], .jitter_us = 100, .miss_prob = 0.05, .spurious_prob = 0.05,
                                   .t0 = 5 * MS, .seed = 5 + (uint64_t)i});
        drv_vsync_est e;
        drv_vsync_est_init(&e, 90);
        feed_until(&e, &g, 1000);
        assert_true(drv_vsync_est_locked(&e));
        int64_t period;
        drv_vsync_est_next(&e, 0, &period);
        /* Locked to the true period, not the nominal one (which is 62 us off at 89.5 Hz). */
        assert_true(fabs((double)period - 1e9 / rates[i]) < 2 * US);
        assert_true(pred_err_us(&e, &g, 999, 20) < 100.0);
    }
}

static void test_est_refuses_far_rate(void **state)
{
    (void)state;
    /* 80 Hz is 12.5 % off 90; 45 Hz edges fit every other 90 Hz vsync but are a different panel mode. */
    const double rates[] = {80, 45, 110};
    for (int i = 0; i < 3; i++) {
        gen g;
        gen_init(&g, &(gen_params){.hz = rates[i], .jitter_us = 50, .t0 = 5 * MS, .seed = 9});
        drv_vsync_est e;
        drv_vsync_est_init(&e, 90);
        assert_int_equal(feed_until(&e, &g, 500), -1);
        assert_false(drv_vsync_est_locked(&e));
        int64_t period = 0;
        assert_int_equal(drv_vsync_est_next(&e, 100 * MS, &period), 0);
        assert_int_equal(period, llround(1e9 / 90));
    }
    /* A nonsense nominal rate never locks either. */
    drv_vsync_est e;
    drv_vsync_est_init(&e, NAN);
    for (int i = 0; i < 100; i++) assert_int_equal(drv_vsync_est_edge(&e, i * 11 * MS), DRV_VSYNC_EDGE_ACQUIRING);
    assert_false(drv_vsync_est_locked(&e));
}

/* The panel changes mode: same rate, a new phase. */
static void phase_jump(double jump_frac, double jitter_us, int relock_within)
{
    gen g;
    gen_init(&g, &(gen_params){.hz = 90, .jitter_us = jitter_us, .miss_prob = 0.05, .t0 = 5 * MS, .seed = 11});
    drv_vsync_est e;
    drv_vsync_est_init(&e, 90);
    feed_until(&e, &g, 300);
    assert_true(drv_vsync_est_locked(&e));
    uint64_t locks0 = drv_vsync_est_counters_get(&e)->locks;
    gen h;
    gen_init(&h, &(gen_params){.hz = 90, .jitter_us = jitter_us, .miss_prob = 0.05,
                               .t0 = truth(&g, 300) + llround(jump_frac * g.period), .seed = 12});
    feed_until(&e, &h, relock_within);
    assert_true(drv_vsync_est_counters_get(&e)->locks > locks0);
    double worst = 0;
    for (int64_t k = relock_within; k < 500; k++) {
        feed_until(&e, &h, k + 1);
        double err = pred_err_us(&e, &h, k, 5);
        if (err > worst) worst = err;
        /* a fresh lock rests on few edges; the full window is as good as before the jump */
        if (k == relock_within + 30) {
            assert_true(worst < 250.0);
            worst = 0;
        }
    }
    assert_true(worst < 100.0);
}

static void test_est_phase_jump(void **state)
{
    (void)state;
    phase_jump(0.4, 200, 12); /* far outside the gate: re-acquired from the unexplained edges */
    phase_jump(-0.1, 100, 12);
    phase_jump(0.033, 50, 12); /* 370 us, inside the gate: the fit restarts once edges sit on one side */
}

static void test_est_next_semantics(void **state)
{
    (void)state;
    drv_vsync_model m = {1000 * MS, 1e9 / 90};
    int64_t period = 0;
    int64_t v1 = drv_vsync_model_next(&m, m.ref_ns, &period);
    assert_int_equal(period, 11111111);
    assert_int_equal(v1, m.ref_ns + 11111111); /* strictly after: a vsync at after_ns is not returned */
    assert_int_equal(drv_vsync_model_next(&m, v1 - 1, NULL), v1);
    assert_int_equal(drv_vsync_model_next(&m, m.ref_ns - 1, NULL), m.ref_ns);
    /* Far before and far after the reference, in both directions, each answer is the vsync just after. */
    int64_t afters[] = {-5 * PLAT_NS_PER_S, 0, 999 * MS, 3600 * PLAT_NS_PER_S, 3600 * PLAT_NS_PER_S + 5};
    for (int i = 0; i < 5; i++) {
        int64_t t = drv_vsync_model_next(&m, afters[i], NULL);
        assert_true(t > afters[i]);
        assert_true(t - afters[i] <= 11111112);
        double k = (double)(t - m.ref_ns) / m.period_ns;
        assert_true(fabs(k - round(k)) * m.period_ns <= 1.0);
    }
    /* Walking next(next(...)) steps exactly one period each time. */
    int64_t t = 0;
    for (int i = 0; i < 1000; i++) {
        int64_t u = drv_vsync_model_next(&m, t, NULL);
        if (i > 0) assert_true(llabs(u - t - 11111111) <= 1);
        t = u;
    }

    /* The estimator's next() agrees with its model; time going backwards is rejected and changes nothing. */
    gen g;
    gen_init(&g, &(gen_params){.hz = 90, .jitter_us = 50, .t0 = 5 * MS, .seed = 13});
    drv_vsync_est e;
    drv_vsync_est_init(&e, 90);
    feed_until(&e, &g, 100);
    drv_vsync_model em;
    assert_true(drv_vsync_est_model(&e, &em));
    int64_t p2;
    assert_int_equal(drv_vsync_est_next(&e, 700 * MS, &p2), drv_vsync_model_next(&em, 700 * MS, NULL));
    assert_int_equal(p2, llround(em.period_ns));
    uint64_t sp = drv_vsync_est_counters_get(&e)->spurious;
    assert_int_equal(drv_vsync_est_edge(&e, truth(&g, 50)), DRV_VSYNC_EDGE_SPURIOUS);
    assert_int_equal(drv_vsync_est_counters_get(&e)->spurious, sp + 1);
    drv_vsync_model em2;
    assert_true(drv_vsync_est_model(&e, &em2));
    assert_memory_equal(&em, &em2, sizeof em);
    assert_string_equal(drv_vsync_edge_kind_name(DRV_VSYNC_EDGE_AFTER_GAP), "after-gap");
}

/* ---- the GPIO backend on the mock edge source, in real time ---- */

static bool wait_for(drv_vsync *v, bool want_on_timer, int64_t deadline, drv_vsync_stats *st)
{
    drv_vsync_edges_stats ex;
    for (;;) {
        drv_vsync_edges_stats_get(v, st, &ex);
        /* Meanwhile next() always answers sensibly, however the edge thread is updating the estimate. */
        int64_t now = plat_now_ns(), per;
        int64_t nx = drv_vsync_next(v, now, &per);
        assert_true(nx > now && nx - now <= per + 1 && per > 0);
        if (ex.locked && st->on_timer == want_on_timer) return true;
        if (plat_now_ns() > deadline) return false;
        plat_sleep_ns(2 * MS);
    }
}

/* Error of next(after) against the nearest true vsync. */
static double mock_err_us(drv_vsync *v, int64_t t0, double period, int64_t after, int64_t *out)
{
    int64_t got = drv_vsync_next(v, after, NULL);
    *out = got;
    double k = round((double)(got - t0) / period);
    return fabs((double)got - ((double)t0 + k * period)) / 1e3;
}

static void test_gpio_mock_fallback(void **state)
{
    (void)state;
    const double hz = 90, rate_error = -0.005, period = 1e9 / (hz * (1 + rate_error));
    int64_t t0 = plat_now_ns() + 20 * MS;
    drv_vsync_mock_params mp = {.jitter_us = 100, .miss_prob = 0.02, .spurious_prob = 0.02, .stop_at_s = 0.3,
                                .stop_for_s = 0.4, .rate_error = rate_error, .seed = 7};
    drv_vsync *v = drv_vsync_gpio_create_mock(hz, t0, &mp);
    assert_non_null(v);
    drv_vsync_stats st;
    /* Before any edge: free-running at the nominal rate. */
    assert_true(drv_vsync_stats_get(v, &st));
    assert_true(st.on_timer);
    int64_t p0;
    int64_t n0 = drv_vsync_next(v, plat_now_ns(), &p0);
    assert_true(n0 > 0);
    assert_int_equal(p0, llround(1e9 / hz));

    /* Locks onto the edges, at the true (slow) rate. */
    assert_true(wait_for(v, false, t0 + 290 * MS, &st));
    assert_int_equal(st.fallbacks, 0);
    int64_t got, now = plat_now_ns();
    assert_true(mock_err_us(v, t0, period, now, &got) < 150.0);
    assert_true(got > now);
    int64_t per;
    drv_vsync_next(v, now, &per);
    assert_true(fabs((double)per - period) < 5 * US);

    /* Edges stop at t0 + 0.3 s: on the timer, once, and next() keeps advancing at the estimated period. */
    assert_true(wait_for(v, true, t0 + 650 * MS, &st));
    assert_int_equal(st.fallbacks, 1);
    now = plat_now_ns();
    int64_t a = drv_vsync_next(v, now, &per), b = drv_vsync_next(v, a, NULL), c = drv_vsync_next(v, b, NULL);
    assert_true(a > now && a - now <= per + 1);
    assert_true(llabs(b - a - per) <= 1 && llabs(c - b - per) <= 1);
    assert_true(fabs((double)per - period) < 5 * US);
    assert_true(mock_err_us(v, t0, period, now, &got) < 150.0); /* still on the panel's phase */
    assert_non_null(strstr(st.last_error, "stopped"));

    /* Edges resume at t0 + 0.7 s: back on them, no second fallback, the hole counted as missed vsyncs. */
    assert_true(wait_for(v, false, t0 + 1100 * MS, &st));
    assert_int_equal(st.fallbacks, 1);
    assert_true(st.missed >= 30);
    assert_true(st.edges > 25);
    assert_true(st.jitter_us > 30 && st.jitter_us < 100);
    now = plat_now_ns();
    assert_true(mock_err_us(v, t0, period, now, &got) < 150.0);

    /* destroy() does not wait out a long timeout. */
    int64_t d0 = plat_now_ns();
    drv_vsync_destroy(v);
    assert_true(plat_now_ns() - d0 < 200 * MS);
}

/* An edge source that fails once, then sends an edge on the wrong clock, then nothing. */
typedef struct {
    drv_edge_source base;
    int calls;
} bad_src;

static int bad_wait(drv_edge_source *s, int64_t *t, int max, int timeout_ms, char *err, int errlen)
{
    (void)max;
    bad_src *b = (bad_src *)s;
    switch (b->calls++) {
    case 0: snprintf(err, (size_t)errlen, "test source: line went away"); return -ENODEV;
    case 1: t[0] = plat_now_ns() + 1000 * PLAT_NS_PER_S; return 1;
    default: plat_sleep_ns(timeout_ms * MS); return 0;
    }
}

static void bad_close(drv_edge_source *s) { free(s); }

static void test_gpio_bad_source(void **state)
{
    (void)state;
    bad_src *b = calloc(1, sizeof *b);
    assert_non_null(b);
    b->base.name = "test source";
    b->base.wait = bad_wait;
    b->base.close = bad_close;
    drv_vsync *v = drv_vsync_edges_create(&b->base, 90, "gpio-test");
    assert_non_null(v);
    drv_vsync_stats st;
    drv_vsync_edges_stats ex;
    int64_t deadline = plat_now_ns() + 1000 * MS;
    do {
        plat_sleep_ns(2 * MS);
        drv_vsync_edges_stats_get(v, &st, &ex);
    } while ((ex.read_errors < 1 || ex.bad_stamps < 1) && plat_now_ns() < deadline);
    assert_int_equal(ex.read_errors, 1);
    assert_int_equal(ex.bad_stamps, 1);
    assert_false(ex.locked);
    assert_true(st.on_timer);
    assert_non_null(strstr(st.last_error, "not CLOCK_MONOTONIC"));
    /* Still a working (free-running) vsync source. */
    int64_t now = plat_now_ns(), per;
    int64_t n = drv_vsync_next(v, now, &per);
    assert_true(n > now && n - now <= per);
    drv_vsync_destroy(v);
    /* Not an edge backend: zeroed statistics. */
    drv_vsync *t = drv_vsync_timer_create(90);
    drv_vsync_edges_stats_get(t, &st, &ex);
    assert_int_equal(ex.read_errors, 0);
    drv_vsync_destroy(t);
}

static void test_timer(void **state)
{
    (void)state;
    int64_t before = plat_now_ns();
    drv_vsync *v = drv_vsync_timer_create(72);
    int64_t after = plat_now_ns();
    assert_non_null(v);
    assert_string_equal(v->name, "timer");
    int64_t per = 0;
    int64_t first = drv_vsync_next(v, before - 1, &per);
    assert_int_equal(per, llround(1e9 / 72));
    assert_true(first >= before && first <= after); /* vsync 0 at creation */
    int64_t t = first;
    for (int i = 0; i < 100; i++) {
        int64_t u = drv_vsync_next(v, t, NULL);
        assert_true(llabs(u - t - per) <= 1);
        t = u;
    }
    drv_vsync_stats st;
    assert_true(drv_vsync_stats_get(v, &st));
    assert_true(st.on_timer);
    assert_int_equal(st.period_ns, per);
    drv_vsync_destroy(v);
    assert_null(drv_vsync_timer_create(0));
    assert_null(drv_vsync_timer_create(NAN));
}

static void test_gpio_no_chip(void **state)
{
    (void)state;
    const char *chips[] = {"gpiochip99", "99", "/dev/gpiochip99"};
    for (int i = 0; i < 3; i++) {
        drv_vsync_gpio_params p = {.line = 3, .refresh_hz = 90};
        snprintf(p.chip, sizeof p.chip, "%s", chips[i]);
        char err[256] = "";
        assert_null(drv_vsync_gpio_create(&p, err, sizeof err));
        assert_non_null(strstr(err, "no such GPIO chip"));
        assert_non_null(strstr(err, chips[i]));
    }
    char err[256] = "";
    drv_vsync_gpio_params p = {.chip = "", .line = 3, .refresh_hz = 90};
    assert_null(drv_vsync_gpio_create(&p, err, sizeof err));
    assert_non_null(strstr(err, "no GPIO chip configured"));
    drv_vsync_gpio_params q = {.chip = "gpiochip0", .line = 3, .refresh_hz = 0};
    assert_null(drv_vsync_gpio_create(&q, err, sizeof err));
    assert_non_null(strstr(err, "refresh rate"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_est_clean),
        cmocka_unit_test(test_est_jitter),
        cmocka_unit_test(test_est_missed),
        cmocka_unit_test(test_est_spurious),
        cmocka_unit_test(test_est_rate_error),
        cmocka_unit_test(test_est_refuses_far_rate),
        cmocka_unit_test(test_est_phase_jump),
        cmocka_unit_test(test_est_next_semantics),
        cmocka_unit_test(test_gpio_mock_fallback),
        cmocka_unit_test(test_gpio_bad_source),
        cmocka_unit_test(test_timer),
        cmocka_unit_test(test_gpio_no_chip),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
