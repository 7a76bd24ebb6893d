/* SPDX-License-Identifier: MIT */
/* drv_vsync_gpio_mock: a drv_edge_source (the seam libgpiod fills on a board) that sleeps until drv_te_schedule's
 * next pulse or glitch and reports its time, as the TE interrupt's timestamp would. */
#include "drivers/drv_vsync_gpio_mock.h"

#include <math.h>
#include <stdlib.h>

#include "drivers/drv_te_schedule.h"
#include "platform/plat_clock.h"

typedef struct {
    drv_edge_source base;
    drv_te_schedule s;
    int64_t t0;
    int64_t k; /* next vsync to generate */
    int64_t pend[2];
    int pend_n, pend_head;
} mock_src;

/* Generates vsync periods until one has an event: the edge (unless lost), then perhaps a glitch between it and the
 * next vsync. The stop window swallows everything. */
static void mock_fill(mock_src *m)
{
    while (m->pend_n == 0) {
        int64_t slot = drv_te_schedule_slot(&m->s, m->k);
        if (slot >= m->s.stop_at_ns && slot < m->s.stop_to_ns) {
            m->k = (int64_t)ceil((double)m->s.stop_to_ns / m->s.period_ns); /* skip a long dropout at once */
            continue;
        }
        m->pend_head = 0;
        int64_t at;
        if (drv_te_schedule_pulse(&m->s, m->k, &at)) m->pend[m->pend_n++] = m->t0 + at;
        if (drv_te_schedule_glitch(&m->s, m->k, &at)) m->pend[m->pend_n++] = m->t0 + at;
        m->k++;
    }
}

static int mock_wait(drv_edge_source *src, int64_t *t_ns, int max, int timeout_ms, char *err, int errlen)
{
    (void)err;
    (void)errlen;
    mock_src *m = (mock_src *)src;
    int64_t deadline = plat_now_ns() + (int64_t)timeout_ms * PLAT_NS_PER_MS;
    mock_fill(m);
    int64_t due = m->pend[m->pend_head];
    if (due > deadline) {
        plat_sleep_until_ns(deadline);
        return 0;
    }
    plat_sleep_until_ns(due); /* as the TE interrupt would wake us; the time is the edge's, like the IRQ stamp */
    int64_t now = plat_now_ns();
    int n = 0;
    while (n < max) {
        mock_fill(m);
        if (m->pend[m->pend_head] > now) break;
        t_ns[n++] = m->pend[m->pend_head++];
        m->pend_n--;
    }
    return n;
}

static void mock_close(drv_edge_source *src) { free(src); }

drv_vsync *drv_vsync_gpio_create_mock(double refresh_hz, int64_t t0_ns, const drv_vsync_mock_params *mp)
{
    drv_vsync_mock_params clean = {0};
    if (!mp) mp = &clean;
    double true_hz = refresh_hz * (1 + mp->rate_error);
    if (!(true_hz > 1)) return NULL;
    mock_src *m = calloc(1, sizeof *m);
    if (!m) return NULL;
    m->base.name = "mock TE line";
    m->base.wait = mock_wait;
    m->base.close = mock_close;
    m->s = drv_te_schedule_clean(1e9 / true_hz, mp->seed);
    m->s.jitter_ns = mp->jitter_us * 1e3;
    m->s.miss_prob = mp->miss_prob;
    m->s.spurious_prob = mp->spurious_prob;
    if (mp->stop_for_s > 0) {
        m->s.stop_at_ns = llround(mp->stop_at_s * 1e9);
        m->s.stop_to_ns = llround((mp->stop_at_s + mp->stop_for_s) * 1e9);
    }
    m->t0 = t0_ns;
    /* The panel is already running: edges from now on, not only from t0 (vsync k is at t0 + k periods). */
    m->k = (int64_t)ceil((double)(plat_now_ns() - t0_ns) / m->s.period_ns);
    return drv_vsync_edges_create(&m->base, refresh_hz, "gpio-mock");
}
