/* SPDX-License-Identifier: MIT */
/* warp_head: the head as a rigid body carrying two eyes: neck model (head position from orientation) and eye
 * poses from the head pose and IPD. Shared by the tracker (prediction) and the simulator (ground truth). */
#ifndef WARP_HEAD_H
#define WARP_HEAD_H

#include "warp/warp_math.h"

enum { WARP_EYE_LEFT = 0, WARP_EYE_RIGHT = 1 };

typedef struct {
    double ipd;             /* metres between the eyes */
    warp_vec3 neck_to_eye;  /* head-frame offset from the neck pivot to the midpoint between the eyes */
    warp_vec3 neck_pivot;   /* world position of the neck pivot */
} warp_head;

/* Typical adult values (Cardboard-like neck model): IPD 64 mm, eyes 7.5 cm above and 8 cm in front of the pivot. */
warp_head warp_head_default(void);

/* Head pose (world_from_head, origin between the eyes) from an orientation through the neck model. */
warp_pose warp_head_pose_from_orientation(const warp_head *h, warp_quat q);

/* Eye pose (world_from_eye) from the head pose: eyes sit at -+ipd/2 along the head's +X axis, parallel to it. */
warp_pose warp_head_eye_pose(const warp_head *h, warp_pose head, int eye);

#endif
