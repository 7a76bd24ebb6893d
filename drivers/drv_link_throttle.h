/* SPDX-License-Identifier: MIT */
/* drv_link_throttle: a drv_usb_transport in front of another whose reads carry at most [frames] link_mbps (a token
 * bucket on the board's clock), so the mock USB link and the socket link meet a real link's rate. */
#ifndef DRV_LINK_THROTTLE_H
#define DRV_LINK_THROTTLE_H

#include "drivers/drv_frames_usb.h"

/* t behind a read limit of mbps MB/s (10^6 bytes; drv_token_bucket_burst_for's burst), owned from here on (destroyed
 * on failure too); the writes (poses, small) and the rest pass through. mbps <= 0 returns t itself; NULL when out of
 * memory. The host side feels the limit as USB's does: its sends block once the socket's buffer is full. */
drv_usb_transport *drv_link_throttle(drv_usb_transport *t, double mbps);

#endif
