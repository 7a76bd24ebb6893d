/* SPDX-License-Identifier: MIT */
/* rt_pacer: when the compositor wakes for which vsync (lead = warp estimate + late wake-ups + margin + stall reserve),
 * what each warp costs, and whether and why a vsync was missed: a pure state machine over times passed in. */
#include "runtime/rt_pacer.h"

#include <stdlib.h>
#include <string.h>

struct rt_pacer {
    rt_pacer_params p;
    int64_t reserve_ns; /* p.reserve_ns clamped to the period */
    bool one_period;
    int64_t t_vs, period;
    uint64_t vsync_no;
    /* When to wake: the vsync minus the longest warp and the latest wake-up among the last WINDOW vsyncs, plus a
     * margin. A running maximum rather than an average: a miss costs a whole repeated frame, waking a little early
     * costs only that much latency (Monado's pacing likewise backs off at once and creeps back). */
    int64_t durs[RT_PACER_WINDOW], lates[RT_PACER_WINDOW];
    int64_t warp_est, late_est;
    int64_t prev_done;
    int64_t at[RT_PACER_POINT_COUNT];
    /* auto: what each method has been costing (rises at once, decays slowly; an estimate not refreshed decays too,
     * by 1/512 per vsync, so a warp once a little too slow is tried again after some seconds; one that took more
     * than two periods is not retried: every retry would cost its length in missed vsyncs) */
    double cost_ns[RT_METHOD_COUNT];
    /* set by rt_pacer_advance when the pass overran: the vsync that could not be made */
    int64_t pending_next;
};

rt_pacer *rt_pacer_create(const rt_pacer_params *params)
{
    rt_pacer *p = calloc(1, sizeof *p);
    if (!p) return NULL;
    p->p = *params;
    return p;
}

void rt_pacer_start(rt_pacer *p, int64_t t_vs, int64_t period_ns, bool one_period)
{
    const rt_pacer_params params = p->p;
    memset(p, 0, sizeof *p);
    p->p = params;
    p->one_period = one_period;
    p->t_vs = t_vs;
    p->period = period_ns;
    /* The first WINDOW vsyncs plan for a whole period: the first warps run with cold caches and TLBs and on pages
     * touched for the first time, and a half-period guess missed them (a 60 s soak lost its first vsyncs so).
     * Waking early costs a few ms of latency for the first second or so, nothing else. */
    for (int i = 0; i < RT_PACER_WINDOW; i++) p->durs[i] = period_ns - p->p.margin_ns;
    p->warp_est = period_ns - p->p.margin_ns;
    /* The stall reserve lets a pass start up to a period before the previous vsync: the warp for vsync N may run
     * while N-1's image waits and N-2's is still shown (the swapchain keeps both out of reach). */
    p->reserve_ns = p->p.reserve_ns;
    if (p->reserve_ns > period_ns - p->p.margin_ns) p->reserve_ns = period_ns - p->p.margin_ns;
    if (p->reserve_ns < 0) p->reserve_ns = 0;
}

void rt_pacer_destroy(rt_pacer **p)
{
    if (!p) return;
    free(*p);
    *p = NULL;
}

static int64_t lead_of(const rt_pacer *p)
{
    int64_t lead = p->warp_est + p->late_est + p->p.margin_ns + p->reserve_ns;
    /* A KMS page flip cannot be queued behind one still pending: the GLES path plans within one period. */
    if (p->one_period && lead > p->period) lead = p->period;
    return lead;
}

void rt_pacer_predict(const rt_pacer *p, rt_pacer_frame *out)
{
    out->vsync_no = p->vsync_no;
    out->vsync_ns = p->t_vs;
    out->lead_ns = lead_of(p);
    out->wake_ns = p->t_vs - out->lead_ns;
    /* What a warp may take is a frame, not what is left now: the wake-up time follows the warps actually run
     * (warp_est), so after choosing a dearer warp the compositor wakes earlier from the next vsync on. */
    out->time_left_ns = p->period - p->p.margin_ns - p->late_est;
    out->period_ns = p->period;
}

void rt_pacer_mark_point(rt_pacer *p, rt_pacer_point point, int64_t when_ns)
{
    if ((unsigned)point < RT_PACER_POINT_COUNT) p->at[point] = when_ns;
}

const double *rt_pacer_costs(const rt_pacer *p) { return p->cost_ns; }

/* The method's cost rises at once to a dearer pass and creeps down to a cheaper one; the others decay. */
static void update_costs(rt_pacer *p, rt_method used, int64_t dur)
{
    double d = (double)dur;
    for (int m = 0; m < RT_METHOD_COUNT; m++)
        if (m == (int)used)
            p->cost_ns[m] = d > p->cost_ns[m] ? d : p->cost_ns[m] + (d - p->cost_ns[m]) / 8;
        else if (p->cost_ns[m] < 2 * p->period)
            p->cost_ns[m] -= p->cost_ns[m] / 512;
}

static void update_estimates(rt_pacer *p)
{
    p->warp_est = p->late_est = 0;
    for (int i = 0; i < RT_PACER_WINDOW; i++) {
        if (p->durs[i] > p->warp_est) p->warp_est = p->durs[i];
        if (p->lates[i] > p->late_est) p->late_est = p->lates[i];
    }
    /* The longest of 128 warps is no bound on the next: keep a quarter of it in hand (the misses left in 60 s soaks
     * were passes 10-25 % over the window's maximum; a quarter costs about a millisecond of latency). */
    p->warp_est += p->warp_est / 4;
    /* Plan within one period. A scheduler that wakes us later than a quarter period (a loaded VM) is noise no
     * wake-up time can absorb; and neither estimate may go negative, or the compositor would pick a vsync that has
     * already passed and serve it again. */
    if (p->late_est > p->period / 4) p->late_est = p->period / 4;
    if (p->warp_est + p->late_est > p->period - p->p.margin_ns) p->warp_est = p->period - p->p.margin_ns - p->late_est;
    if (p->warp_est < 0) p->warp_est = 0;
}

void rt_pacer_info_vsync(rt_pacer *p, const rt_pacer_work *w, rt_pacer_info *out)
{
    int64_t wake = p->t_vs - lead_of(p);
    int64_t t_start = p->at[RT_PACER_WOKE], t_done = p->at[RT_PACER_DONE];
    int64_t dur = t_done - t_start;
    /* The GPU may still be drawing when the CPU is done (KMS: no readback waits for it): the estimate takes
     * submission plus the GPU time the timer queries measured, whichever is longer. */
    if (w->gpu_ns >= 0 && p->at[RT_PACER_SUBMITTED] - t_start + w->gpu_ns > dur)
        dur = p->at[RT_PACER_SUBMITTED] - t_start + w->gpu_ns;
    out->missed = t_done > p->t_vs || !w->buffer;
    out->cause = out->missed ? rt_miss_classify(wake, t_start, p->t_vs, w->work_ns, w->buffer) : RT_MISS_OWN;
    out->dur_ns = dur;

    if (w->shown) update_costs(p, w->method, dur);
    p->durs[p->vsync_no % RT_PACER_WINDOW] = dur;
    /* woken late; not a start delayed by the previous pass, which a lead beyond a period can make */
    int64_t planned_start = wake > p->prev_done ? wake : p->prev_done;
    out->late_ns = t_start > planned_start ? t_start - planned_start : 0;
    p->lates[p->vsync_no % RT_PACER_WINDOW] = out->late_ns;
    p->prev_done = t_done;
    update_estimates(p);
}

int64_t rt_pacer_next_after(const rt_pacer *p) { return p->t_vs + p->period / 2; }

bool rt_pacer_advance(rt_pacer *p, int64_t next_vs, int64_t period_ns, int64_t now_ns, int64_t *ask_after)
{
    p->vsync_no++;
    p->period = period_ns;
    if (next_vs - p->warp_est - p->late_est - p->p.margin_ns >= now_ns) {
        p->t_vs = next_vs;
        return false;
    }
    /* Overran a whole period: the vsyncs in between are not served. Ask for the first vsync we can still make, and
     * never one at or before the vsync just served. */
    int64_t after = now_ns + p->warp_est + p->p.margin_ns;
    if (after < p->t_vs + period_ns / 2) after = p->t_vs + period_ns / 2;
    p->pending_next = next_vs;
    *ask_after = after;
    return true;
}

uint64_t rt_pacer_skip_to(rt_pacer *p, int64_t later_vs, int64_t period_ns)
{
    int64_t next = p->pending_next;
    p->period = period_ns;
    if (later_vs < next) later_vs = next;
    uint64_t skipped = period_ns > 0 ? (uint64_t)((later_vs - next + period_ns / 2) / period_ns) : 0;
    p->vsync_no += skipped;
    p->t_vs = later_vs;
    return skipped;
}
