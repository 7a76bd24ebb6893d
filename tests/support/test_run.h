/* SPDX-License-Identifier: MIT */
/* test_run: runs an rt_app until it has the data a test needs (counts of vsyncs, frames, samples), not for a fixed
 * time: a busy machine does less in a second, never less in all. The wall-clock cap only guards against hangs. */
#ifndef TEST_RUN_H
#define TEST_RUN_H

#include <pthread.h>
#include <stdbool.h>

#include "platform/plat_clock.h"
#include "runtime/rt_app.h"

/* True once the run has what the test needs; `elapsed_s` is the time since the app's t0 (a fault timeline's
 * origin), so a condition may also ask for the whole timeline to have played. */
typedef bool (*test_run_enough)(const rt_app *a, double elapsed_s);

typedef struct {
    rt_app *a;
    test_run_enough enough;
    double cap_s;
    bool reached;
} test_run_watch;

static inline void *test_run_watcher(void *arg)
{
    test_run_watch *w = arg;
    while (!atomic_load(&w->a->stop)) {
        double el = (double)(plat_now_ns() - w->a->t0_ns) * 1e-9;
        if (w->enough(w->a, el)) w->reached = true;
        if (w->reached || el > w->cap_s) {
            rt_app_request_stop(w->a);
            break;
        }
        plat_sleep_ns(2 * PLAT_NS_PER_MS);
    }
    return NULL;
}

/* Runs an app initialised with sim.duration_s = 0 (until stopped) until enough() holds or cap_s seconds have
 * passed. Returns whether enough() held: a test asserts it, so a run that never gets its data fails by name. */
static inline bool test_run_until(rt_app *a, test_run_enough enough, double cap_s)
{
    test_run_watch w = {a, enough, cap_s, false};
    pthread_t th;
    bool up = pthread_create(&th, NULL, test_run_watcher, &w) == 0;
    if (!up) return false;
    rt_app_run(a);
    pthread_join(th, NULL);
    return w.reached;
}

/* The most vsyncs a panel at hz can have had in the run: however loaded the machine, never more than one per
 * refresh period (plus one at each end and one for the vsync clock's phase against t0; a quiet run measures
 * 38 in 0.41 s at 90 Hz). */
static inline double test_run_max_vsyncs(const rt_app *a, double hz)
{
    return (double)(a->run_end_ns - a->t0_ns) * 1e-9 * hz + 3;
}

#endif
