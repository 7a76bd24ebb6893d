/* SPDX-License-Identifier: MIT */
/* drv_frames_usb: host frames over USB, the board being a FunctionFS gadget (bulk OUT frames, bulk IN poses), and
 * a mock whose simulated host talks the same framelink byte streams through socket pairs instead of endpoints. */
#ifndef DRV_FRAMES_USB_H
#define DRV_FRAMES_USB_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "drivers/drv_frames.h"
#include "drivers/drv_sim.h"
#include "warp/warp_head.h"

typedef struct {
    char ffs_dir[128];        /* FunctionFS mount, e.g. /dev/ffs-hmdwarp */
    size_t max_frame_bytes;   /* frames declaring more are rejected (TOO_LARGE) unread; also the receive buffer */
    int eye_w, eye_h;         /* the board's eye size: frames of another size are rejected (BAD_SIZE) */
    unsigned planes;          /* DRV_PLANE_* the caller allocates (drv_frames_planes reports them) */
    drv_pose_source poses;    /* predictions sent to the host */
    double pose_rate_hz;      /* pose messages per second */
    warp_head head;           /* eye offsets (IPD) for the per-eye poses sent; all zero = warp_head_default() */
} drv_frames_usb_params;

/* The real gadget: writes the descriptors and strings to ffs_dir/ep0 (the gadget is bound afterwards, see
 * board/gadget.sh), then serves ep0 events, ep1 (frames) and ep2 (poses). NULL with a message in err on failure. */
drv_frames *drv_frames_usb_create(const drv_frames_usb_params *p, char *err, int errlen);

typedef struct {
    int corrupt_every, truncate_every; /* 0 = never: every n-th frame gets a payload byte flipped / is cut in half */
    double stall_at_s, stall_for_s;    /* the host stops mid-frame once, stall_at_s after creation */
} drv_frames_usb_mock_params;

/* The board side unchanged over socket pairs standing in for ep1/ep2; a mock-host thread renders `host`'s scene
 * at the poses received (its own poses source is replaced), encodes with the codec and applies the faults. */
drv_frames *drv_frames_usb_create_mock(const drv_frames_sim_params *host, const drv_frames_usb_params *p,
                                       const drv_frames_usb_mock_params *mp, char *err, int errlen);

/* The board side's receive state machine without a transport (tests, the fuzzer): bytes of the OUT stream are
 * given with drv_frames_usb_feed, and drv_frames_receive(fr, f, 0) parses what was fed exactly as the gadget does
 * (returning 0 once it needs more). No pose thread; p->poses may be empty. */
drv_frames *drv_frames_usb_create_fed(const drv_frames_usb_params *p, char *err, int errlen);
/* Appends up to n bytes to the stream; returns how many were taken: fewer once a whole frame (or a rejection) is
 * waiting to be received, or the buffer is full. */
size_t drv_frames_usb_feed(drv_frames *fr, const uint8_t *data, size_t n);

typedef struct {
    uint64_t frames;                            /* accepted */
    uint64_t bytes;                             /* read from the OUT stream */
    uint64_t rejected[DRV_FRAME_ERR_COUNT];     /* by reason */
    uint64_t skipped_bytes;                     /* dropped while looking for a frame magic */
    uint64_t discarded_bytes;                   /* oversize frames read into scratch and dropped */
    uint64_t poses_sent, poses_dropped;         /* pose messages written / not taken by the host in time */
    uint64_t disconnects;                       /* endpoint I/O failures and DISABLE/UNBIND events */
    bool connected;                             /* the host has configured the function (ENABLE) */
    double lead_ms;                             /* current pose lead: measured pose-to-frame latency */
    char last_error[160];
} drv_frames_usb_stats;

/* Statistics of a usb (or mock) frames source; safe from any thread. */
void drv_frames_usb_stats_get(drv_frames *fr, drv_frames_usb_stats *st);

#endif
