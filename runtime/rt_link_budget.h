/* SPDX-License-Identifier: MIT */
/* rt_link_budget: the configuration's link budget at start-up (hmdwarpd's log, --check-config): which link the
 * [frames] backend is, at what rate, and what the eyes, planes and host rate need on it (drv_link_budget). */
#ifndef RT_LINK_BUDGET_H
#define RT_LINK_BUDGET_H

#include <stdbool.h>
#include <stddef.h>

#include "runtime/rt_config.h"

/* The budget line for c (docs/link-budget.md): the usb backend's speed from sysfs (the host's once connected, the
 * UDC's maximum before), a mock or socket link's [frames] link_mbps, V4L2's in-band pixels; colour, depth and what
 * the warp method takes besides, at [sim] host_rate_hz, with the codecs this build decodes. False when nothing the
 * board announces fits (log it as a warning). The simulated host has no link: line "" and true. */
bool rt_link_budget_line(const rt_config *c, char *line, size_t len);

#endif
