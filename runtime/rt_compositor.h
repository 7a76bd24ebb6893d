/* SPDX-License-Identifier: MIT */
/* rt_compositor: the vsync-paced loop: just before each vsync it predicts the head pose at photon time, takes the
 * newest host frame, warps and distorts it into a free swapchain image and presents it. */
#ifndef RT_COMPOSITOR_H
#define RT_COMPOSITOR_H

#include "runtime/rt_app.h"

/* Runs on the calling thread (rt_app_run's) until a->stop is set or the configured duration has elapsed; reads the
 * parts rt_app_init opened and writes the telemetry. */
void rt_compositor_run(rt_app *a);

#endif
