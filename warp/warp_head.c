/* SPDX-License-Identifier: MIT */
/* warp_head: the head as a rigid body carrying two eyes: neck model (head position from orientation) and eye
 * poses from the head pose and IPD. Shared by the tracker (prediction) and the simulator (ground truth). */
#include "warp/warp_head.h"

warp_head warp_head_default(void)
{
    warp_head h;
    h.ipd = 0.064;
    h.neck_to_eye = warp_v3(0.0, 0.075, -0.08);
    h.neck_pivot = warp_v3(0.0, 1.6 - 0.075, 0.08); /* eyes at (0, 1.6, 0) when looking straight ahead */
    return h;
}

warp_pose warp_head_pose_from_orientation(const warp_head *h, warp_quat q)
{
    warp_pose p;
    p.q = q;
    p.p = warp_v3_add(h->neck_pivot, warp_quat_rotate(q, h->neck_to_eye));
    return p;
}

warp_pose warp_head_eye_pose(const warp_head *h, warp_pose head, int eye)
{
    warp_pose off = warp_pose_identity();
    off.p.x = (eye == WARP_EYE_LEFT ? -0.5 : 0.5) * h->ipd;
    return warp_pose_mul(head, off);
}
