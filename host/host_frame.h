/* SPDX-License-Identifier: MIT */
/* host_frame: libhmdwarp-host's frame checks and conversions: a caller's hmdwarp_host_frame (any colour and depth
 * format, strides, ray distances) into the drv_frame the framelink encoder takes, every refusal naming the field. */
#ifndef HOST_FRAME_H
#define HOST_FRAME_H

#include <stdbool.h>
#include <stdint.h>

#include "drivers/drv_framelink.h"
#include "host/hmdwarp-host.h"

/* The encoder's frame, its planes kept between frames of one size and layout (no allocation in the steady state). */
typedef struct {
    drv_frame f;
    int w[2], h[2];
    unsigned planes;
    int max_layers;
} host_frame_scratch;

/* What the checks need from the connection: the board's cameras when it sent them, the pose message echoed. */
typedef struct {
    const hmdwarp_host_cameras *cams;  /* NULL: none known */
    bool cams_from_board;              /* the cameras came from the board: its planes and limits apply */
    const drv_framelink_pose *echo;    /* the pose message of frame.pose_seq, NULL when pose_seq is 0 */
    int64_t echo_rx_ns;
    uint64_t seq;                      /* the frame counter to send */
} host_frame_ctx;

/* Fills s->f and *tx from in; returns HMDWARP_HOST_OK or an error (the message set through host_fail). */
int host_frame_build(host_frame_scratch *s, const hmdwarp_host_frame *in, const host_frame_ctx *ctx,
                     drv_framelink_tx *tx);
void host_frame_scratch_free(host_frame_scratch *s);

/* Converters between the API's plain types and the codec's, shared with the message side. */
warp_pose host_pose_to_warp(const hmdwarp_host_pose *p);
hmdwarp_host_pose host_pose_from_warp(warp_pose p);
warp_camera host_camera_to_warp(const hmdwarp_host_camera *c);
hmdwarp_host_camera host_camera_from_warp(const warp_camera *c);

/* The calling thread's error: sets the message (printf) and returns err, so a refusal reads
 * `return host_fail(HMDWARP_HOST_ERR_SIZE, "frame.eye[%d].color_stride: ...", e);` (defined in hmdwarp_host.c). */
int host_fail(int err, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

#endif
