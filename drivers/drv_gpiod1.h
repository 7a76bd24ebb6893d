/* SPDX-License-Identifier: MIT */
/* drv_gpiod1: the TE-line edge source on libgpiod 1.6 (the v1 GPIO character device API), behind drv_vsync_gpio's
 * drv_edge_source interface; all libgpiod use is in drv_gpiod1.c. */
#ifndef DRV_GPIOD1_H
#define DRV_GPIOD1_H

#include <stdbool.h>

#include "drivers/drv_vsync_gpio.h"

/* The line's edge events as requested by consumer "hmdwarp-vsync". NULL with a message in err (no such chip, no such
 * line, line busy and by whom, permission) when it cannot. */
drv_edge_source *drv_gpiod1_edges_open(const char *chip, int line, bool falling_edge, char *err, int errlen);

#endif
