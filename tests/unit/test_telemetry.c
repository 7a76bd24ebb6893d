/* SPDX-License-Identifier: MIT */
/* rt_telemetry: the latency histograms' percentiles and the attribution of missed vsyncs to hmdwarpd's own work
 * or to the system (late wake-up, descheduled, no free image), which HIL and soak runs assert on. */
#include <pthread.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <math.h>
#include <string.h>

#include "runtime/rt_telemetry.h"

#define MS 1000000LL

static void test_hist_percentiles(void **state)
{
    (void)state;
    rt_telemetry *t = rt_telemetry_create();
    assert_non_null(t);
    assert_true(isnan(rt_hist_pct(&t->m2p_ms, 50)));
    for (int i = 1; i <= 100; i++) rt_hist_add(&t->m2p_ms, (double)i); /* 1..100 ms */
    assert_true(fabs(rt_hist_pct(&t->m2p_ms, 50) - 50.0) < 0.02);
    assert_true(fabs(rt_hist_pct(&t->m2p_ms, 99) - 99.0) < 0.02);
    rt_hist_add(&t->m2p_ms, 1000.0); /* past the last bin: counted as overflow, max kept */
    assert_true(rt_hist_pct(&t->m2p_ms, 100) >= 250.0);
    assert_true(t->m2p_ms.max == 1000.0);
    rt_telemetry_destroy(t);
}

/* A pass planned 4 ms ahead of its vsync (wake at 6 ms, vsync at 10 ms). */
static void test_miss_causes(void **state)
{
    (void)state;
    const int64_t wake = 6 * MS, vs = 10 * MS;
    /* its own CPU work alone is longer than the 4 ms it planned: hmdwarpd's doing, however it was scheduled */
    assert_int_equal(rt_miss_classify(wake, wake, vs, 5 * MS, true), RT_MISS_OWN);
    assert_int_equal(rt_miss_classify(wake, wake + 3 * MS, vs, 4 * MS + 1, true), RT_MISS_OWN);
    /* 2 ms of work woken 2.5 ms late: woken on time it would have made it */
    assert_int_equal(rt_miss_classify(wake, wake + 5 * MS / 2, vs, 2 * MS, true), RT_MISS_LATE_WAKE);
    /* woken on time, 2 ms of work, yet late: it was off the CPU in between */
    assert_int_equal(rt_miss_classify(wake, wake, vs, 2 * MS, true), RT_MISS_DESCHEDULED);
    assert_int_equal(rt_miss_classify(wake, wake + 1 * MS, vs, 2 * MS, true), RT_MISS_DESCHEDULED);
    /* no image to draw into: the display's */
    assert_int_equal(rt_miss_classify(wake, wake, vs, 5 * MS, false), RT_MISS_NO_BUFFER);
    for (int m = 0; m < RT_MISS_COUNT; m++) assert_true(strcmp(rt_miss_name((rt_miss)m), "?") != 0);
    assert_string_equal(rt_miss_name(RT_MISS_COUNT), "?");
}

/* GLES: the compositor thread waits for the GPU without running, so its CPU time alone would put a pass whose GPU
 * work outran the plan on the scheduler (make run RENDER=gles on llvmpipe once showed 906 of 906 so). */
static void test_miss_gles(void **state)
{
    (void)state;
    const int64_t wake = 6 * MS, vs = 10 * MS;
    /* 1 ms of submission, 157 ms of llvmpipe drawing: the warp's own miss, not the scheduler's */
    assert_int_equal(rt_miss_classify(wake, wake, vs, 1 * MS, true), RT_MISS_DESCHEDULED);
    assert_int_equal(rt_miss_classify(wake, wake, vs, rt_miss_gles_work(1 * MS, 157 * MS, true), true), RT_MISS_OWN);
    assert_int_equal(rt_miss_classify(wake, wake, vs, rt_miss_gles_work(1 * MS, 157 * MS, false), true), RT_MISS_OWN);
    /* a software rasterizer draws after the submission: 2 + 3 ms outrun a 4 ms plan */
    assert_int_equal(rt_miss_gles_work(2 * MS, 3 * MS, true), 5 * MS);
    assert_int_equal(rt_miss_classify(wake, wake, vs, rt_miss_gles_work(2 * MS, 3 * MS, true), true), RT_MISS_OWN);
    /* a hardware GPU runs beside the submitting thread: the longer one is what the pass needed, and 3 ms fit */
    assert_int_equal(rt_miss_gles_work(2 * MS, 3 * MS, false), 3 * MS);
    assert_int_equal(rt_miss_classify(wake, wake, vs, rt_miss_gles_work(2 * MS, 3 * MS, false), true),
                     RT_MISS_DESCHEDULED);
    assert_int_equal(rt_miss_gles_work(2 * MS, -1, false), 2 * MS); /* no GPU time measured yet */
}

/* The summary's advice names what to change for the cause of most misses, and stays quiet about a stray one. */
static void test_miss_advice(void **state)
{
    (void)state;
    char buf[400];
    uint64_t by[RT_MISS_COUNT] = {0};
    by[RT_MISS_DESCHEDULED] = 2;
    rt_miss_advice(by, false, false, buf, sizeof buf);
    assert_string_equal(buf, "");
    by[RT_MISS_OWN] = 906;
    rt_miss_advice(by, true, true, buf, sizeof buf);
    assert_non_null(strstr(buf, "renderer = cpu"));
    rt_miss_advice(by, false, false, buf, sizeof buf);
    assert_non_null(strstr(buf, "cheaper [warp] method"));
    assert_null(strstr(buf, "renderer"));
    by[RT_MISS_DESCHEDULED] = 1000;
    rt_miss_advice(by, true, true, buf, sizeof buf);
    assert_non_null(strstr(buf, "scheduler"));
    memset(by, 0, sizeof by);
    by[RT_MISS_NO_BUFFER] = 10;
    rt_miss_advice(by, false, false, buf, sizeof buf);
    assert_non_null(strstr(buf, "swapchain"));
}

/* A board stopped while it waited for a host that sent nothing exits 0 (systemctl stop before the PC is plugged
 * in is no failure); one whose frames were all rejected, or that presented nothing, has failed. */
static void test_waiting_for_host(void **state)
{
    (void)state;
    rt_telemetry *t = rt_telemetry_create();
    assert_non_null(t);
    assert_false(rt_telemetry_waiting_for_host(t)); /* no vsync presented */
    t->vsyncs = 90;
    assert_true(rt_telemetry_waiting_for_host(t));
    t->frames_rejected[DRV_FRAME_ERR_COUNT - 1] = 1;
    assert_false(rt_telemetry_waiting_for_host(t));
    t->frames_rejected[DRV_FRAME_ERR_COUNT - 1] = 0;
    t->frames_received = 1;
    assert_false(rt_telemetry_waiting_for_host(t));
    rt_telemetry_destroy(t);
}

/* The counters the helper thread reads while the compositor writes them (watchdog: vsyncs; live stats and STATUS=:
 * the rest) must be atomic: a plain uint64_t read there is a data race (it once was: tel->vsyncs). _Generic on a
 * pointer, since lvalue conversion would drop the _Atomic of the field itself. */
#define IS_ATOMIC_U64(field) _Generic(&(field), _Atomic uint64_t *: 1, default: 0)
#define IS_ATOMIC_U32(field) _Generic(&(field), _Atomic uint32_t *: 1, default: 0)

static void test_counters_atomic(void **state)
{
    (void)state;
    rt_telemetry *t = rt_telemetry_create();
    assert_non_null(t);
    assert_true(IS_ATOMIC_U64(t->vsyncs));
    assert_true(IS_ATOMIC_U64(t->missed));
    assert_true(IS_ATOMIC_U64(t->missed_by[0]));
    assert_true(IS_ATOMIC_U64(t->no_frame));
    assert_true(IS_ATOMIC_U64(t->new_frames_shown));
    assert_true(IS_ATOMIC_U64(t->frames_dropped));
    assert_true(IS_ATOMIC_U64(t->frames_received));
    assert_true(IS_ATOMIC_U64(t->frames_bytes));
    assert_true(IS_ATOMIC_U64(t->imu_samples));
    assert_true(IS_ATOMIC_U64(t->m2p_ms.count));
    assert_true(IS_ATOMIC_U32(t->m2p_ms.bin[0]));
    rt_telemetry_destroy(t);
}

#define WRITES 200000

static void *vsync_writer(void *arg)
{
    rt_telemetry *t = arg;
    for (int i = 0; i < WRITES; i++) t->vsyncs++;
    return NULL;
}

/* The watchdog's read beside the compositor's writes, as aux_thread does it: every value it sees is one the writer
 * wrote (never torn, never going back), and the last is the writer's count. (Under -fsanitize=thread a plain field
 * is reported here.) */
static void test_vsyncs_read_while_written(void **state)
{
    (void)state;
    rt_telemetry *t = rt_telemetry_create();
    assert_non_null(t);
    pthread_t th;
    assert_int_equal(pthread_create(&th, NULL, vsync_writer, t), 0);
    uint64_t last = 0;
    for (;;) {
        uint64_t v = t->vsyncs;
        assert_true(v >= last && v <= WRITES);
        last = v;
        if (v == WRITES) break;
    }
    pthread_join(th, NULL);
    assert_int_equal(t->vsyncs, WRITES);
    rt_telemetry_destroy(t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_hist_percentiles),
        cmocka_unit_test(test_miss_causes),
        cmocka_unit_test(test_miss_gles),
        cmocka_unit_test(test_miss_advice),
        cmocka_unit_test(test_waiting_for_host),
        cmocka_unit_test(test_counters_atomic),
        cmocka_unit_test(test_vsyncs_read_while_written),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
