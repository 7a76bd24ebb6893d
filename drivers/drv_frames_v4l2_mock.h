/* SPDX-License-Identifier: MIT */
/* drv_frames_v4l2_mock: the V4L2 capture backend over a mock capture device (open/ioctl/mmap/poll answered in
 * memory) whose frames come from a simulated host, with unplug and damaged-frame faults for tests. */
#ifndef DRV_FRAMES_V4L2_MOCK_H
#define DRV_FRAMES_V4L2_MOCK_H

#include "drivers/drv_frames_v4l2.h"
#include "drivers/drv_sim.h"

/* The same backend over a mock device (replacing only open/ioctl/mmap/poll) whose frames come from a simulated
 * host packed in the chosen format (auto picks YUYV: the mock offers RGB24, XBGR32, NV12 and YUYV). */
drv_frames *drv_frames_v4l2_create_mock(const drv_frames_sim_params *host, const drv_frames_v4l2_params *p,
                                        char *err, int errlen);

/* Mock faults for tests (no effect on a real device). */
typedef enum {
    DRV_V4L2_FAULT_UNPLUG = 1, /* the next poll reports POLLERR, DQBUF fails with ENODEV, the next open fails */
    DRV_V4L2_FAULT_GARBLE = 2, /* the next frame's band has one bit flipped (CRC error) */
    DRV_V4L2_FAULT_BLANK = 3,  /* the next frame is a plain picture without band (BAD_MAGIC) */
} drv_v4l2_fault;
void drv_frames_v4l2_mock_fault(drv_frames *fr, drv_v4l2_fault fault);
/* [mock] corrupt_every: from now on every nth frame arrives damaged, in turn GARBLE and BLANK (0 = never). */
void drv_frames_v4l2_mock_corrupt_every(drv_frames *fr, int n);

#endif
