/* SPDX-License-Identifier: MIT */
/* drv_vsync: the interface of vsync sources (simulated timer, GPIO TE line): the compositor asks when the next
 * vsync will be and schedules its warp just before it. */
#ifndef DRV_VSYNC_H
#define DRV_VSYNC_H

#include <stdbool.h>
#include <stdint.h>

/* What an edge-driven source has seen (optional; the simulated timer has none). */
typedef struct {
    uint64_t edges;          /* edges received */
    uint64_t spurious;       /* edges rejected as glitches (far from any predicted vsync) */
    uint64_t missed;         /* predicted vsyncs with no edge */
    uint64_t fallbacks;      /* times the edges stopped and the source fell back to its timer */
    bool on_timer;           /* currently free-running on the configured refresh rate */
    int64_t period_ns;       /* current period estimate */
    double jitter_us;        /* RMS edge-time residual against the estimate */
    char last_error[160];
} drv_vsync_stats;

typedef struct drv_vsync drv_vsync;
struct drv_vsync {
    const char *name;
    /* Predicted time of the first vsync strictly after after_ns, and the current period estimate. Lock-free and
     * non-blocking: it reads the estimator that the source keeps up to date. */
    int64_t (*next)(drv_vsync *v, int64_t after_ns, int64_t *period_ns);
    /* Optional (NULL: no statistics). Safe from any thread. */
    void (*stats)(drv_vsync *v, drv_vsync_stats *out);
    void (*destroy)(drv_vsync *v);
};

static inline int64_t drv_vsync_next(drv_vsync *v, int64_t after_ns, int64_t *period_ns)
{
    return v->next(v, after_ns, period_ns);
}
static inline bool drv_vsync_stats_get(drv_vsync *v, drv_vsync_stats *out)
{
    *out = (drv_vsync_stats){0};
    if (!v->stats) return false;
    v->stats(v, out);
    return true;
}
static inline void drv_vsync_destroy(drv_vsync *v)
{
    if (v) v->destroy(v);
}

#endif
