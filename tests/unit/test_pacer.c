/* SPDX-License-Identifier: MIT */
/* rt_pacer driven by a fake clock and a fake 100 Hz vsync source: the lead it converges to, a work spike's one
 * miss and the estimator's answer, late wake-ups, the stall reserve, overrun skipping, the cost estimator. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <string.h>

#include "runtime/rt_pacer.h"

#define MS 1000000LL
#define US 1000LL
#define PERIOD (10 * MS)
#define MARGIN RT_PACER_MARGIN_NS

/* The fake clock: time moves only when the pacer's user sleeps or works. */
typedef struct {
    int64_t now;
} fake_clock;

static void fake_sleep_until(fake_clock *c, int64_t t)
{
    if (t > c->now) c->now = t;
}

/* The fake vsync source: a vsync every PERIOD from 0 on; the first one after `after`. */
static int64_t fake_vsync_next(int64_t after) { return (after / PERIOD + 1) * PERIOD; }

typedef struct {
    int64_t late, dur, work; /* woken this much after the planned wake-up, took dur of which work was its own */
    bool no_buffer;
    rt_method method;
} pass_spec;

/* One compositor pass as rt_compositor_run makes it, on the fake clock. *skipped: the vsyncs it overran. */
static rt_pacer_info run_pass(rt_pacer *p, fake_clock *c, pass_spec s, uint64_t *skipped)
{
    rt_pacer_frame f;
    rt_pacer_predict(p, &f);
    fake_sleep_until(c, f.wake_ns);
    c->now += s.late;
    rt_pacer_mark_point(p, RT_PACER_WOKE, c->now);
    c->now += s.dur;
    rt_pacer_mark_point(p, RT_PACER_DONE, c->now);
    rt_pacer_work w = {s.work, -1, !s.no_buffer, !s.no_buffer, s.method};
    rt_pacer_info info;
    rt_pacer_info_vsync(p, &w, &info);
    int64_t ask = 0;
    uint64_t sk = 0;
    if (rt_pacer_advance(p, fake_vsync_next(rt_pacer_next_after(p)), PERIOD, c->now, &ask))
        sk = rt_pacer_skip_to(p, fake_vsync_next(ask), PERIOD);
    if (skipped) *skipped = sk;
    return info;
}

static pass_spec steady(int64_t dur) { return (pass_spec){0, dur, dur, false, RT_METHOD_ROTATION}; }

static rt_pacer *new_pacer(fake_clock *c, int64_t reserve, bool one_period)
{
    rt_pacer_params pp = {MARGIN, reserve};
    c->now = 100 * PERIOD - 20 * MS;
    rt_pacer *p = rt_pacer_create(&pp);
    assert_non_null(p);
    rt_pacer_start(p, 100 * PERIOD, PERIOD, one_period);
    return p;
}

static int64_t lead(const rt_pacer *p)
{
    rt_pacer_frame f;
    rt_pacer_predict(p, &f);
    assert_int_equal(f.wake_ns, f.vsync_ns - f.lead_ns);
    return f.lead_ns;
}

/* Passes of 2 ms: the first window (128 vsyncs) plans for a whole period, then the lead is the longest pass plus
 * a quarter, plus the margin: 2.5 + 0.5 ms. */
static void test_steady_state_lead(void **state)
{
    (void)state;
    fake_clock c;
    rt_pacer *p = new_pacer(&c, 0, false);
    assert_int_equal(lead(p), PERIOD);
    for (int i = 0; i < RT_PACER_WINDOW; i++) {
        assert_int_equal(lead(p), PERIOD);
        uint64_t sk;
        rt_pacer_info in = run_pass(p, &c, steady(2 * MS), &sk);
        assert_false(in.missed);
        assert_int_equal(in.dur_ns, 2 * MS);
        assert_int_equal(in.late_ns, 0);
        assert_int_equal(sk, 0);
    }
    assert_int_equal(lead(p), 3 * MS);
    rt_pacer_frame f;
    rt_pacer_predict(p, &f);
    assert_int_equal(f.vsync_no, RT_PACER_WINDOW);
    assert_int_equal(f.vsync_ns, (100 + RT_PACER_WINDOW) * PERIOD);
    assert_int_equal(f.wake_ns, f.vsync_ns - 3 * MS);
    assert_int_equal(f.time_left_ns, PERIOD - MARGIN);
    for (int i = 0; i < 50; i++) assert_false(run_pass(p, &c, steady(2 * MS), NULL).missed);
    assert_int_equal(lead(p), 3 * MS);
    rt_pacer_destroy(&p);
    assert_null(p);
    rt_pacer_destroy(&p); /* a cleared pointer is fine */
}

static rt_pacer *converged(fake_clock *c, int64_t reserve, bool one_period)
{
    rt_pacer *p = new_pacer(c, reserve, one_period);
    for (int i = 0; i < RT_PACER_WINDOW; i++) run_pass(p, c, steady(2 * MS), NULL);
    return p;
}

/* rt_app_init makes the pacer, the vsync loop starts it: a start forgets the last run (lead, vsync count, costs)
 * and plans from the new first vsync, within one period when asked (a stall reserve beyond it is cut). */
static void test_start_again(void **state)
{
    (void)state;
    fake_clock c;
    rt_pacer *p = converged(&c, 0, false);
    run_pass(p, &c, (pass_spec){0, 4 * MS, 4 * MS, false, RT_METHOD_NONE}, NULL);
    assert_int_equal(lead(p), 5 * MS + MARGIN);
    rt_pacer_start(p, 500 * PERIOD, PERIOD, true);
    rt_pacer_frame f;
    rt_pacer_predict(p, &f);
    assert_int_equal(f.vsync_no, 0);
    assert_int_equal(f.vsync_ns, 500 * PERIOD);
    assert_int_equal(f.lead_ns, PERIOD);
    for (int m = 0; m < RT_METHOD_COUNT; m++) assert_true(rt_pacer_costs(p)[m] == 0);
    rt_pacer_destroy(&p);
    /* a reserve of a whole period on the one-period (GLES) plan: the lead stays a period */
    p = converged(&c, PERIOD, true);
    assert_int_equal(lead(p), PERIOD);
    rt_pacer_start(p, 600 * PERIOD, PERIOD, false);
    assert_int_equal(lead(p), PERIOD + (PERIOD - MARGIN)); /* a cold window plus the reserve, cut to period - margin */
    rt_pacer_destroy(&p);
}

/* One 4 ms pass against a 3 ms lead: exactly one miss, the pass's own; the lead grows to 4 * 1.25 + 0.5 ms at once
 * and stays for a window, then comes back. */
static void test_spike_one_own_miss(void **state)
{
    (void)state;
    fake_clock c;
    rt_pacer *p = converged(&c, 0, false);
    rt_pacer_info in = run_pass(p, &c, steady(4 * MS), NULL);
    assert_true(in.missed);
    assert_int_equal(in.cause, RT_MISS_OWN);
    assert_int_equal(lead(p), 5 * MS + MARGIN);
    int misses = 0;
    for (int i = 0; i < RT_PACER_WINDOW - 1; i++) {
        misses += run_pass(p, &c, steady(2 * MS), NULL).missed;
        assert_int_equal(lead(p), 5 * MS + MARGIN);
    }
    misses += run_pass(p, &c, steady(2 * MS), NULL).missed;
    assert_int_equal(misses, 0);
    assert_int_equal(lead(p), 3 * MS);
    rt_pacer_destroy(&p);
}

/* The miss causes: woken too late for the work to fit; kept off the CPU though woken in time; no free image. */
static void test_miss_causes(void **state)
{
    (void)state;
    fake_clock c;
    rt_pacer *p = converged(&c, 0, false);
    /* planned 3 ms, woken 2.5 ms late, 1 ms of work: late wake-up; the late estimate takes it (a quarter period) */
    rt_pacer_info in = run_pass(p, &c, (pass_spec){2500 * US, 1 * MS, 1 * MS, false, RT_METHOD_ROTATION}, NULL);
    assert_true(in.missed);
    assert_int_equal(in.cause, RT_MISS_LATE_WAKE);
    assert_int_equal(in.late_ns, 2500 * US);
    assert_int_equal(lead(p), 2500 * US + 2500 * US + MARGIN);
    rt_pacer_frame f;
    rt_pacer_predict(p, &f);
    assert_int_equal(f.time_left_ns, PERIOD - MARGIN - 2500 * US);
    rt_pacer_destroy(&p);

    /* woken in time, 1 ms of its own work in 3.5 ms: descheduled */
    p = converged(&c, 0, false);
    in = run_pass(p, &c, (pass_spec){0, 3500 * US, 1 * MS, false, RT_METHOD_ROTATION}, NULL);
    assert_true(in.missed);
    assert_int_equal(in.cause, RT_MISS_DESCHEDULED);
    assert_int_equal(in.late_ns, 0);
    /* a late wake-up far beyond a quarter period counts as a quarter period only */
    in = run_pass(p, &c, (pass_spec){9 * MS, 1 * MS, 1 * MS, false, RT_METHOD_ROTATION}, NULL);
    assert_true(in.missed);
    assert_int_equal(in.cause, RT_MISS_LATE_WAKE);
    assert_int_equal(in.late_ns, 9 * MS);
    rt_pacer_predict(p, &f);
    assert_int_equal(f.time_left_ns, PERIOD - MARGIN - PERIOD / 4);
    rt_pacer_destroy(&p);

    /* done in time, but every image still being read: a miss, and not the pass's */
    p = converged(&c, 0, false);
    in = run_pass(p, &c, (pass_spec){0, 1 * MS, 1 * MS, true, RT_METHOD_ROTATION}, NULL);
    assert_true(in.missed);
    assert_int_equal(in.cause, RT_MISS_NO_BUFFER);
    rt_pacer_destroy(&p);
}

/* The stall reserve: a fixed extra lead, at most a period less the margin, none when negative; the GLES path plans
 * within a period whatever the reserve. A pass started late because the previous one ran into its wake-up time is
 * not a late wake-up. */
static void test_stall_reserve(void **state)
{
    (void)state;
    fake_clock c;
    rt_pacer *p = converged(&c, 8 * MS, false);
    assert_int_equal(lead(p), 3 * MS + 8 * MS);
    assert_false(run_pass(p, &c, steady(2 * MS), NULL).missed);
    rt_pacer_destroy(&p);

    p = converged(&c, 20 * MS, false);
    assert_int_equal(lead(p), 3 * MS + PERIOD - MARGIN);
    rt_pacer_destroy(&p);
    p = converged(&c, -5 * MS, false);
    assert_int_equal(lead(p), 3 * MS);
    rt_pacer_destroy(&p);
    p = converged(&c, 0, false);
    assert_int_equal(lead(p), 3 * MS);
    rt_pacer_destroy(&p);
    /* GLES: 3 + 8 ms capped to the period; without a reserve the same as the CPU path */
    p = converged(&c, 8 * MS, true);
    assert_int_equal(lead(p), PERIOD);
    rt_pacer_destroy(&p);
    p = converged(&c, 0, true);
    assert_int_equal(lead(p), 3 * MS);
    rt_pacer_destroy(&p);

    /* a 10.5 ms pass that still made its vsync (woken 11 ms ahead): the lead becomes 9.5 + 0.5 + 8 = 18 ms, so the
     * next wake-up is due before this pass ended; starting when it ended is on plan, not late */
    p = converged(&c, 8 * MS, false);
    rt_pacer_info in = run_pass(p, &c, steady(10500 * US), NULL);
    assert_false(in.missed);
    assert_int_equal(lead(p), PERIOD - MARGIN + MARGIN + 8 * MS);
    in = run_pass(p, &c, steady(2 * MS), NULL);
    assert_false(in.missed);
    assert_int_equal(in.late_ns, 0);
    assert_int_equal(lead(p), PERIOD - MARGIN + MARGIN + 8 * MS);
    rt_pacer_destroy(&p);
}

/* A 25 ms pass for a vsync at T, woken at T - 3 ms, ends at T + 22 ms: the vsyncs at T + 10 and T + 20 passed
 * meanwhile, and T + 30 cannot be made with 9.5 ms planned for the next pass: three skipped, T + 40 targeted. */
static void test_overrun_skipping(void **state)
{
    (void)state;
    fake_clock c;
    rt_pacer *p = converged(&c, 0, false);
    rt_pacer_frame f;
    rt_pacer_predict(p, &f);
    const int64_t t = f.vsync_ns;
    const uint64_t no = f.vsync_no;
    uint64_t sk = 0;
    rt_pacer_info in = run_pass(p, &c, steady(25 * MS), &sk);
    assert_true(in.missed);
    assert_int_equal(in.cause, RT_MISS_OWN);
    assert_int_equal(sk, 3);
    rt_pacer_predict(p, &f);
    assert_int_equal(f.vsync_ns, t + 40 * MS);
    assert_int_equal(f.vsync_no, no + 4);
    assert_int_equal(f.lead_ns, PERIOD);
    /* and the next pass makes it */
    in = run_pass(p, &c, steady(2 * MS), &sk);
    assert_false(in.missed);
    assert_int_equal(sk, 0);
    rt_pacer_destroy(&p);

    /* a pass that ends exactly at its vsync made it; a nanosecond later it did not */
    p = converged(&c, 0, false);
    in = run_pass(p, &c, steady(3 * MS), &sk);
    assert_false(in.missed);
    assert_int_equal(sk, 0);
    rt_pacer_destroy(&p);
    p = converged(&c, 0, false);
    in = run_pass(p, &c, steady(3 * MS + 1), &sk);
    assert_true(in.missed);
    assert_int_equal(in.cause, RT_MISS_OWN);
    assert_int_equal(sk, 0);
    rt_pacer_destroy(&p);
}

/* What each method costs: up at once, down by an eighth of the difference, decaying by 1/512 when not run, and
 * not at all once over two periods (never retried). */
static void test_cost_estimator(void **state)
{
    (void)state;
    fake_clock c;
    rt_pacer *p = new_pacer(&c, 0, false);
    const double *cost = rt_pacer_costs(p);
    for (int m = 0; m < RT_METHOD_COUNT; m++) assert_true(cost[m] == 0);
    run_pass(p, &c, (pass_spec){0, 4 * MS, 4 * MS, false, RT_METHOD_ROTATION}, NULL);
    assert_true(cost[RT_METHOD_ROTATION] == 4e6);
    run_pass(p, &c, (pass_spec){0, 2 * MS, 2 * MS, false, RT_METHOD_ROTATION}, NULL);
    assert_true(cost[RT_METHOD_ROTATION] == 3.75e6);
    run_pass(p, &c, (pass_spec){0, 1 * MS, 1 * MS, false, RT_METHOD_NONE}, NULL);
    assert_true(cost[RT_METHOD_NONE] == 1e6);
    assert_true(cost[RT_METHOD_ROTATION] == 3.75e6 - 3.75e6 / 512);
    run_pass(p, &c, (pass_spec){0, 2 * MS, 2 * MS, false, RT_METHOD_ROTATION}, NULL);
    assert_true(cost[RT_METHOD_NONE] == 1e6 - 1e6 / 512);
    /* a pass of 25 ms (over two periods): its cost stays while other methods run */
    run_pass(p, &c, (pass_spec){0, 25 * MS, 25 * MS, false, RT_METHOD_NONE}, NULL);
    assert_true(cost[RT_METHOD_NONE] == 25e6);
    run_pass(p, &c, steady(2 * MS), NULL);
    assert_true(cost[RT_METHOD_NONE] == 25e6);
    /* a pass that showed no frame (no free image) costs nothing */
    double before = cost[RT_METHOD_ROTATION];
    run_pass(p, &c, (pass_spec){0, 9 * MS, 9 * MS, true, RT_METHOD_ROTATION}, NULL);
    assert_true(cost[RT_METHOD_ROTATION] == before);
    rt_pacer_destroy(&p);
}

/* GLES: the estimate takes submission plus the GPU's time when that ends later than the CPU side. */
static void test_gles_gpu_time(void **state)
{
    (void)state;
    fake_clock c;
    rt_pacer *p = converged(&c, 0, true);
    rt_pacer_frame f;
    rt_pacer_predict(p, &f);
    fake_sleep_until(&c, f.wake_ns);
    rt_pacer_mark_point(p, RT_PACER_WOKE, c.now);
    rt_pacer_mark_point(p, RT_PACER_SUBMITTED, c.now + 1 * MS);
    rt_pacer_mark_point(p, RT_PACER_DONE, c.now + 2 * MS);
    rt_pacer_work w = {4 * MS, 3 * MS, true, true, RT_METHOD_NONE};
    rt_pacer_info in;
    rt_pacer_info_vsync(p, &w, &in);
    assert_int_equal(in.dur_ns, 4 * MS);
    assert_false(in.missed);
    assert_int_equal(f.lead_ns, 3 * MS);
    assert_int_equal(lead(p), 5 * MS + MARGIN);
    assert_true(rt_pacer_costs(p)[RT_METHOD_NONE] == 4e6);
    rt_pacer_destroy(&p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_steady_state_lead), cmocka_unit_test(test_spike_one_own_miss),
        cmocka_unit_test(test_miss_causes),       cmocka_unit_test(test_stall_reserve),
        cmocka_unit_test(test_overrun_skipping),  cmocka_unit_test(test_cost_estimator),
        cmocka_unit_test(test_gles_gpu_time),       cmocka_unit_test(test_start_again),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
