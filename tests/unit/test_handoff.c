/* SPDX-License-Identifier: MIT */
/* Tests of the lock-free plumbing between threads: the frame triple buffer under a concurrent producer and consumer,
 * the SPSC record ring, and the compositor's worker pool (every task exactly once, job after job). */
#include <pthread.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stddef.h>
#include <string.h>
#include <cmocka.h>

#include "platform/plat_clock.h"
#include "platform/plat_workers.h"
#include "runtime/rt_frameq.h"
#include "runtime/rt_ring.h"
#include "tests/support/test_util.h"

#define W 64
#define H 16
#define FRAMES 20000

static rt_frameq q;
static _Atomic int producer_done;

/* Every pixel and the pose carry the frame's sequence number: a frame read while half written shows two. */
static void *producer(void *arg)
{
    (void)arg;
    for (uint64_t seq = 1; seq <= FRAMES; seq++) {
        rt_frame *s = rt_frameq_back(&q);
        s->f.seq = seq;
        s->f.pose_t_ns = (int64_t)seq * 7;
        for (int e = 0; e < 2; e++)
            for (int y = 0; y < H; y++)
                for (int x = 0; x < W; x++) {
                    uint8_t v = (uint8_t)(seq * 31 + (uint64_t)e);
                    WARP_AT(&s->f.color[e], x, y) = (warp_rgba8){v, (uint8_t)(seq >> 8), (uint8_t)seq, 255};
                }
        rt_frameq_publish(&q);
    }
    atomic_store(&producer_done, 1);
    return NULL;
}

static void test_frameq_concurrent(void **state)
{
    (void)state;
    assert_true(rt_frameq_alloc(&q, W, H, DRV_PLANE_COLOR, 1));
    bool is_new;
    assert_null(rt_frameq_latest(&q, &is_new));
    pthread_t th;
    atomic_store(&producer_done, 0);
    assert_int_equal(pthread_create(&th, NULL, producer, NULL), 0);
    uint64_t last = 0, seen = 0, torn = 0;
    for (;;) {
        bool done = atomic_load(&producer_done);
        const rt_frame *f = rt_frameq_latest(&q, &is_new);
        if (f) {
            uint64_t s = f->f.seq;
            assert_true(s >= last);               /* never goes back in time */
            if (is_new) assert_true(s > last);    /* "new" really is new */
            if (f->f.pose_t_ns != (int64_t)s * 7) torn++;
            for (int e = 0; e < 2; e++)
                for (int y = 0; y < H; y += 5)
                    for (int x = 0; x < W; x += 9) {
                        warp_rgba8 p = WARP_AT(&f->f.color[e], x, y);
                        if (p.r != (uint8_t)(s * 31 + (uint64_t)e) || p.g != (uint8_t)(s >> 8) || p.b != (uint8_t)s)
                            torn++;
                    }
            if (s != last) seen++;
            last = s;
        }
        if (done && last == FRAMES) break;
    }
    pthread_join(th, NULL);
    assert_int_equal(torn, 0);
    assert_int_equal(last, FRAMES); /* the newest frame always arrives */
    assert_true(seen > 1);
    rt_frameq_free(&q);
}

static void test_frameq_replaces_unconsumed(void **state)
{
    (void)state;
    assert_true(rt_frameq_alloc(&q, 8, 8, DRV_PLANE_COLOR, 1));
    rt_frameq_back(&q)->f.seq = 1;
    assert_false(rt_frameq_publish(&q));
    rt_frameq_back(&q)->f.seq = 2;
    assert_true(rt_frameq_publish(&q)); /* frame 1 was never taken */
    bool is_new;
    const rt_frame *f = rt_frameq_latest(&q, &is_new);
    assert_true(is_new);
    assert_int_equal(f->f.seq, 2);
    f = rt_frameq_latest(&q, &is_new);
    assert_false(is_new);
    assert_int_equal(f->f.seq, 2);
    rt_frameq_free(&q);
}

/* A host may count its frames from 0: that frame is shown like any other (the queue once took seq 0 for "no frame
 * yet" and showed nothing until frame 1). */
static void test_frameq_seq_zero_shown(void **state)
{
    (void)state;
    assert_true(rt_frameq_alloc(&q, 8, 8, DRV_PLANE_COLOR, 1));
    bool is_new = true;
    assert_null(rt_frameq_latest(&q, &is_new)); /* nothing published yet */
    assert_false(is_new);
    rt_frameq_back(&q)->f.seq = 0;
    WARP_AT(&rt_frameq_back(&q)->f.color[0], 3, 2) = (warp_rgba8){7, 8, 9, 255};
    assert_false(rt_frameq_publish(&q));
    const rt_frame *f = rt_frameq_latest(&q, &is_new);
    assert_non_null(f);
    assert_true(is_new);
    assert_int_equal(f->f.seq, 0);
    assert_int_equal(WARP_AT(&f->f.color[0], 3, 2).r, 7);
    f = rt_frameq_latest(&q, &is_new); /* still the current frame when nothing new came */
    assert_non_null(f);
    assert_false(is_new);
    assert_int_equal(f->f.seq, 0);
    rt_frameq_back(&q)->f.seq = 1;
    rt_frameq_publish(&q);
    f = rt_frameq_latest(&q, &is_new);
    assert_true(is_new);
    assert_int_equal(f->f.seq, 1);
    rt_frameq_free(&q);
}

static void test_ring(void **state)
{
    (void)state;
    rt_ring r;
    assert_false(rt_ring_alloc(&r, 8, 3)); /* not a power of two */
    assert_true(rt_ring_alloc(&r, sizeof(uint64_t), 4));
    uint64_t v;
    assert_false(rt_ring_pop(&r, &v));
    for (uint64_t i = 0; i < 4; i++) assert_true(rt_ring_push(&r, &i));
    uint64_t x = 99;
    assert_false(rt_ring_push(&r, &x)); /* full: dropped, counted, never waits */
    assert_int_equal(atomic_load(&r.dropped), 1);
    for (uint64_t i = 0; i < 4; i++) {
        assert_true(rt_ring_pop(&r, &v));
        assert_int_equal(v, i);
    }
    rt_ring_free(&r);
}

typedef struct {
    _Atomic int hits[257];
} count_ctx;

static void count_task(void *ctx, int task)
{
    count_ctx *c = ctx;
    atomic_fetch_add(&c->hits[task], 1);
}

static void test_workers_every_task_once(void **state)
{
    (void)state;
    plat_workers *w = plat_workers_create(2, 0);
    assert_non_null(w);
    assert_int_equal(plat_workers_threads(w), 3);
    for (int job = 0; job < 3000; job++) {
        count_ctx c;
        memset(&c, 0, sizeof c);
        int n = 1 + job % 257;
        plat_workers_run(w, n, count_task, &c);
        for (int i = 0; i < 257; i++) assert_int_equal(atomic_load(&c.hits[i]), i < n ? 1 : 0);
    }
    plat_workers_destroy(w);
    /* no extra threads: the caller does everything */
    w = plat_workers_create(0, 0);
    count_ctx c;
    memset(&c, 0, sizeof c);
    plat_workers_run(w, 10, count_task, &c);
    for (int i = 0; i < 10; i++) assert_int_equal(atomic_load(&c.hits[i]), 1);
    plat_workers_destroy(w);
}

/* Tasks of 0.2 ms of work; on a worker thread, the first one it takes is also put to sleep for 20 ms, as a worker
 * kept off its CPU mid-task would be. */
typedef struct {
    pthread_t caller;
    _Atomic int slept;
} stall_ctx;

static void busy_task(void *ctx, int task)
{
    (void)task;
    stall_ctx *c = ctx;
    int64_t end = plat_now_ns() + PLAT_NS_PER_MS / 5;
    while (plat_now_ns() < end) {
    }
    if (!pthread_equal(pthread_self(), c->caller) && atomic_exchange(&c->slept, 1) == 0) plat_sleep_ns(20 * PLAT_NS_PER_MS);
}

/* plat_workers_stalled_ns: waiting for a worker that was off its CPU counts, waiting for its last ordinary task
 * does not. */
static void test_workers_stalled_worker_counted(void **state)
{
    (void)state;
    plat_workers *w = plat_workers_create(1, 0);
    assert_non_null(w);
    stall_ctx c = {pthread_self(), 0};
    /* all tasks alike: at most about a task's wait a job, far from a stall, plus the time a busy machine kept the
     * threads waiting for a CPU (which is what the count is for: the time is not the caller's) */
    int64_t delay0 = test_run_delay_ns();
    for (int job = 0; job < 20; job++) {
        atomic_store(&c.slept, 1);
        plat_workers_run(w, 16, busy_task, &c);
    }
    int64_t delay = test_run_delay_ns() - delay0;
    print_message("stalled %.2f ms with %.2f ms waiting for a CPU\n", (double)plat_workers_stalled_ns(w) * 1e-6,
                  (double)delay * 1e-6);
    assert_true(plat_workers_stalled_ns(w) < 10 * PLAT_NS_PER_MS + delay);
    /* the worker sleeps in its first task (retried until the worker woke in time to take one) */
    int64_t before = plat_workers_stalled_ns(w), delay1 = test_run_delay_ns();
    atomic_store(&c.slept, 0);
    for (int tries = 0; tries < 50 && !atomic_load(&c.slept); tries++) plat_workers_run(w, 16, busy_task, &c);
    assert_true(atomic_load(&c.slept));
    int64_t stalled = plat_workers_stalled_ns(w) - before, waited = test_run_delay_ns() - delay1;
    print_message("stalled %.2f ms with %.2f ms waiting for a CPU\n", (double)stalled * 1e-6, (double)waited * 1e-6);
    /* about the worker's 20 ms less the caller's own ~3 ms of tasks; a caller kept off its CPU meanwhile waits
     * that much less (make test-busy: 9.5 ms), so its wait for a CPU is taken off the lower bound */
    assert_true(stalled > 10 * PLAT_NS_PER_MS - waited && stalled < 25 * PLAT_NS_PER_MS + waited);
    plat_workers_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_frameq_concurrent),
        cmocka_unit_test(test_frameq_replaces_unconsumed),
        cmocka_unit_test(test_frameq_seq_zero_shown),
        cmocka_unit_test(test_ring),
        cmocka_unit_test(test_workers_every_task_once),
        cmocka_unit_test(test_workers_stalled_worker_counted),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
