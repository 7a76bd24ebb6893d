/* SPDX-License-Identifier: MIT */
/* drv_vsync_gpio_mock: the GPIO vsync backend on a simulated panel's TE line (drv_te_schedule's pulses in real time)
 * instead of libgpiod's edge events: estimator, thread and fallback are the real code. */
#ifndef DRV_VSYNC_GPIO_MOCK_H
#define DRV_VSYNC_GPIO_MOCK_H

#include <stdint.h>

#include "drivers/drv_vsync_gpio.h"

typedef struct {
    double jitter_us;     /* each edge uniformly within +-jitter_us of its vsync */
    double miss_prob;     /* each edge lost with this probability */
    double spurious_prob; /* per period, probability of one glitch at a random time between two vsyncs */
    double stop_at_s, stop_for_s; /* no edges in [t0 + stop_at_s, t0 + stop_at_s + stop_for_s) (stop_for_s 0: never) */
    double rate_error;    /* true panel rate = refresh_hz * (1 + rate_error), e.g. -0.005 = 0.5 % slow */
    uint64_t seed;
} drv_vsync_mock_params;

/* The GPIO backend with only the libgpiod edge source replaced: edges come in real time (vsync k at
 * t0_ns + k / true rate, plus the faults of mp; NULL mp: clean). Estimator, thread and fallback are the real code. */
drv_vsync *drv_vsync_gpio_create_mock(double refresh_hz, int64_t t0_ns, const drv_vsync_mock_params *mp);

#endif
