/* SPDX-License-Identifier: MIT */
/* drv_vsync_timer: a free-running CLOCK_MONOTONIC vsync source at the configured rate, vsync 0 at creation: for a
 * board whose panel has no TE line wired (the compositor then drifts against the panel's own timing). */
#include "drivers/drv_vsync_timer.h"

#include <math.h>
#include <stdlib.h>

#include "drivers/drv_vsync_est.h"
#include "platform/plat_clock.h"

typedef struct {
    drv_vsync base;
    drv_vsync_model m;
} vsync_timer;

static int64_t timer_next(drv_vsync *v, int64_t after_ns, int64_t *period_ns)
{
    vsync_timer *s = (vsync_timer *)v;
    /* Before creation the first vsync is the creation time itself, as with the simulated source. */
    if (after_ns < s->m.ref_ns) {
        if (period_ns) *period_ns = llround(s->m.period_ns);
        return s->m.ref_ns;
    }
    return drv_vsync_model_next(&s->m, after_ns, period_ns);
}

static void timer_stats(drv_vsync *v, drv_vsync_stats *out)
{
    vsync_timer *s = (vsync_timer *)v;
    out->on_timer = true;
    out->period_ns = llround(s->m.period_ns);
}

static void timer_destroy(drv_vsync *v) { free(v); }

drv_vsync *drv_vsync_timer_create(double refresh_hz)
{
    if (!(refresh_hz >= 1 && refresh_hz <= 10000)) return NULL;
    vsync_timer *s = calloc(1, sizeof *s);
    if (!s) return NULL;
    s->base.name = "timer";
    s->base.next = timer_next;
    s->base.stats = timer_stats;
    s->base.destroy = timer_destroy;
    s->m.ref_ns = plat_now_ns();
    s->m.period_ns = 1e9 / refresh_hz;
    return &s->base;
}
