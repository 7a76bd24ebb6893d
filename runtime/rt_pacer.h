/* SPDX-License-Identifier: MIT */
/* rt_pacer: when the compositor wakes for which vsync (lead = warp estimate + late wake-ups + margin + stall reserve),
 * what each warp costs, and whether and why a vsync was missed: a pure state machine over times passed in. */
#ifndef RT_PACER_H
#define RT_PACER_H

#include <stdbool.h>
#include <stdint.h>

#include "runtime/rt_config.h"
#include "runtime/rt_telemetry.h"

/* The shape follows Monado's u_pacing_compositor: predict, mark points, info on the vsync that happened. The
 * pacer reads no clock and asks no vsync source: the compositor passes in what they said, so a test drives it with
 * made-up times and asserts exact nanoseconds. */
typedef struct rt_pacer rt_pacer;

typedef struct {
    int64_t margin_ns;  /* kept between the estimated end of a pass and its vsync */
    int64_t reserve_ns; /* [render] stall_reserve_ms: started that much earlier still (clamped to period - margin) */
} rt_pacer_params;

/* The default margin: half a millisecond. */
#define RT_PACER_MARGIN_NS 500000LL
/* The estimator's window, in vsyncs: the longest pass and the latest wake-up among the last this many. */
#define RT_PACER_WINDOW 128

/* The plan for the next vsync. */
typedef struct {
    uint64_t vsync_no;    /* counts the vsyncs since the start, skipped ones included */
    int64_t vsync_ns;     /* the vsync targeted */
    int64_t wake_ns;      /* when to wake for it: vsync_ns - lead_ns */
    int64_t lead_ns;      /* warp estimate + late wake-up estimate + margin + reserve (one period at most on GLES) */
    int64_t time_left_ns; /* what a warp may cost (rt_select): a period less the margin and the late estimate */
    int64_t period_ns;
} rt_pacer_frame;

/* The points of one pass the pacer is told about (Monado's mark_point). WOKE, SUBMITTED and DONE feed the
 * estimates; FRAME_TAKEN and PRESENTED are kept for a present-to-display model a display with timing would add. */
typedef enum {
    RT_PACER_WOKE,        /* the compositor thread is running again */
    RT_PACER_FRAME_TAKEN, /* the newest host frame taken */
    RT_PACER_SUBMITTED,   /* GLES: the draw calls submitted (the GPU may still run) */
    RT_PACER_DONE,        /* the pass's CPU side finished */
    RT_PACER_PRESENTED,   /* the image handed to the display */
    RT_PACER_POINT_COUNT
} rt_pacer_point;

/* What the compositor measured about the pass that the pacer cannot know. */
typedef struct {
    int64_t work_ns; /* the pass's own work (CPU time less waits for stalled workers; + GPU: rt_miss_gles_work) */
    int64_t gpu_ns;  /* GLES: the GPU time after submission the estimate adds; < 0 on the CPU path */
    bool buffer;     /* a swapchain image was free (otherwise the previous one is shown again: a miss) */
    bool shown;      /* a host frame was warped into it: its cost counts for `method` */
    rt_method method;
} rt_pacer_work;

/* The vsync that happened. */
typedef struct {
    bool missed;
    rt_miss cause;   /* meaningful when missed; also the cause skipped vsyncs take (rt_pacer_advance) */
    int64_t dur_ns;  /* what the estimator took for the pass (woke -> done, or -> submitted + GPU on GLES) */
    int64_t late_ns; /* woken this much after the planned start */
} rt_pacer_info;

/* NULL when out of memory. Made with the run's other parts (rt_app_init): the vsync loop allocates nothing. */
rt_pacer *rt_pacer_create(const rt_pacer_params *p);
/* Frees and clears *p (NULL is fine). */
void rt_pacer_destroy(rt_pacer **p);
/* Starts (or starts again) from the first vsync, at t_vs and period_ns long, with no estimate yet. one_period: plan
 * within one period (a KMS page flip cannot queue behind one pending: the GLES path); known only when the loop
 * starts, since the compositor thread may fail to make the GLES context current and fall back to the CPU path. */
void rt_pacer_start(rt_pacer *p, int64_t t_vs, int64_t period_ns, bool one_period);

/* The plan for the vsync now targeted. */
void rt_pacer_predict(const rt_pacer *p, rt_pacer_frame *out);
void rt_pacer_mark_point(rt_pacer *p, rt_pacer_point point, int64_t when_ns);
/* After RT_PACER_DONE: whether the vsync was made and why not; feeds the estimators. */
void rt_pacer_info_vsync(rt_pacer *p, const rt_pacer_work *w, rt_pacer_info *out);
/* The cost estimator (rt_select's input): per method what it has been costing, ns; 0 = not known. */
const double *rt_pacer_costs(const rt_pacer *p);

/* Moving on: the time after which to ask the vsync source for the next vsync (half a period after the one served:
 * an estimated phase may move it a few µs later, and asking for "after it" would return it again). */
int64_t rt_pacer_next_after(const rt_pacer *p);
/* The vsync source's answer `next_vs` (its period `period_ns`) at `now_ns`. False when it can still be made: it
 * becomes the target. True when the pass overran it: *ask_after is the time from which to ask for the first vsync
 * that can still be made (rt_pacer_skip_to). The test leaves the reserve out: it is there to be used up. */
bool rt_pacer_advance(rt_pacer *p, int64_t next_vs, int64_t period_ns, int64_t now_ns, int64_t *ask_after);
/* After an overrun: the source's answer for the time rt_pacer_advance gave. Returns how many vsyncs were skipped
 * (missed, with the cause of the pass that overran); the later vsync becomes the target. */
uint64_t rt_pacer_skip_to(rt_pacer *p, int64_t later_vs, int64_t period_ns);

#endif
