/* SPDX-License-Identifier: MIT */
/* drv_vsync_timer: a free-running CLOCK_MONOTONIC vsync source at the configured rate, for a board whose panel has
 * no TE line wired (the compositor then drifts against the panel's own timing). */
#ifndef DRV_VSYNC_TIMER_H
#define DRV_VSYNC_TIMER_H

#include "drivers/drv_vsync.h"

/* Vsync 0 at creation; NULL for a rate outside 1..10000 Hz (or not a number), or out of memory. */
drv_vsync *drv_vsync_timer_create(double refresh_hz);

#endif
