/* SPDX-License-Identifier: MIT */
/* drv_frames_usb_mock: the USB frames backend's board side over socket pairs standing in for ep1/ep2, with a
 * simulated host behind them that answers the board's pose messages with framelink frames, faults on request. */
#ifndef DRV_FRAMES_USB_MOCK_H
#define DRV_FRAMES_USB_MOCK_H

#include "drivers/drv_frames_usb.h"
#include "drivers/drv_sim.h"

typedef struct {
    int corrupt_every, truncate_every; /* 0 = never: every n-th frame gets a payload byte flipped / is cut in half */
    double stall_at_s, stall_for_s;    /* the host stops mid-frame once, stall_at_s after creation */
} drv_frames_usb_mock_params;

/* The board side unchanged over socket pairs standing in for ep1/ep2; a mock-host thread renders `host`'s scene
 * at the poses received (its own poses source is replaced), encodes with the codec and applies the faults. */
drv_frames *drv_frames_usb_create_mock(const drv_frames_sim_params *host, const drv_frames_usb_params *p,
                                       const drv_frames_usb_mock_params *mp, char *err, int errlen);

#endif
