/* SPDX-License-Identifier: MIT */
/* warp_stereo: cyclops and alternate-frame warping schedules (000 §6, Fig. 10). */
#include "warp/warp_stereo.h"

const char *warp_stereo_strategy_name(warp_stereo_strategy s)
{
    switch (s) {
    case WARP_STEREO_CONVENTIONAL: return "conventional";
    case WARP_STEREO_CYCLOPS: return "cyclops";
    case WARP_STEREO_ALTERNATE: return "alternate-frame";
    }
    return "?";
}

warp_pose warp_stereo_eye_pose(warp_pose head, double ipd_m, warp_eye e)
{
    double off = e == WARP_EYE_LEFT ? -0.5 * ipd_m : e == WARP_EYE_RIGHT ? 0.5 * ipd_m : 0.0;
    warp_pose local = {warp_quat_identity(), warp_v3(off, 0, 0)};
    return warp_pose_mul(head, local);
}

warp_stereo_plan warp_stereo_schedule(warp_stereo_strategy s, long frame)
{
    warp_stereo_plan p = {0, {WARP_EYE_LEFT, WARP_EYE_RIGHT}, {WARP_EYE_LEFT, WARP_EYE_RIGHT}, {false, false}};
    switch (s) {
    case WARP_STEREO_CYCLOPS:
        p.n_render = 1;
        p.render[0] = WARP_EYE_CENTRE;
        p.source[0] = p.source[1] = WARP_EYE_CENTRE;
        p.warp[0] = p.warp[1] = true;
        break;
    case WARP_STEREO_ALTERNATE:
        if (frame <= 0) { /* nothing to warp from yet: start with both eyes */
            p.n_render = 2;
            break;
        }
        /* even frames render the left eye, odd frames the right one; the other eye reuses its last render */
        p.n_render = 1;
        warp_eye fresh = (frame & 1) ? WARP_EYE_RIGHT : WARP_EYE_LEFT;
        p.render[0] = fresh;
        p.warp[fresh == WARP_EYE_LEFT ? 1 : 0] = true;
        break;
    case WARP_STEREO_CONVENTIONAL:
    default:
        p.n_render = 2;
        break;
    }
    return p;
}

void warp_stereo_cost(warp_stereo_strategy s, int *renders, int *warps)
{
    warp_stereo_plan p = warp_stereo_schedule(s, 1);
    *renders = p.n_render;
    *warps = p.warp[0] + p.warp[1];
}

const char *warp_stereo_eye(warp_grid *g, const warp_view *src, const warp_camera *dst_cam, warp_pose eye,
                            const warp_grid_params *p, warp_image_rgba8 *dst, warp_image_f32 *dst_inv,
                            warp_image_u8 *mask, warp_grid_stats *st)
{
    return warp_grid_run(g, src, dst_cam, eye, p, dst, dst_inv, mask, st);
}
