/* drv_vsync: the interface of vsync sources (simulated timer, GPIO TE line): the compositor asks when the next
 * vsync will be and schedules its warp just before it. */
#ifndef DRV_VSYNC_H
#define DRV_VSYNC_H

#include <stdint.h>

typedef struct drv_vsync drv_vsync;
struct drv_vsync {
    const char *name;
    /* Predicted time of the first vsync strictly after after_ns, and the current period estimate. Lock-free and
     * non-blocking: it reads the estimator that the source keeps up to date. */
    int64_t (*next)(drv_vsync *v, int64_t after_ns, int64_t *period_ns);
    void (*destroy)(drv_vsync *v);
};

static inline int64_t drv_vsync_next(drv_vsync *v, int64_t after_ns, int64_t *period_ns)
{
    return v->next(v, after_ns, period_ns);
}
static inline void drv_vsync_destroy(drv_vsync *v)
{
    if (v) v->destroy(v);
}

#endif
