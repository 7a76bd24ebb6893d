/* SPDX-License-Identifier: MIT */
/* warp_stereo: the stereo warping strategies of 000 §6 (Fig. 10): cyclops warping (one centre view warped to both
 * eyes) and alternate-frame warping (one eye rendered per frame, the other warped from its previous render). */
#ifndef WARP_STEREO_H
#define WARP_STEREO_H

#include <stdbool.h>

#include "warp/warp_grid.h"
#include "warp/warp_math.h"
#include "warp/warp_view.h"

typedef enum { WARP_EYE_LEFT = 0, WARP_EYE_RIGHT = 1, WARP_EYE_CENTRE = 2 } warp_eye;

typedef enum {
    WARP_STEREO_CONVENTIONAL = 0, /* both eyes rendered every frame: the reference */
    WARP_STEREO_CYCLOPS = 1,      /* 000 Fig. 10a: the centre view rendered, warped to each eye (both up to date,
                                   * but every frame warps half the IPD: disocclusions at depth edges) */
    WARP_STEREO_ALTERNATE = 2,    /* 000 Fig. 10b: eyes rendered on alternate frames, the other eye warped from its
                                   * last render (short warps that vanish as the head stops; moving objects in the
                                   * warped eye lag one frame) */
} warp_stereo_strategy;

const char *warp_stereo_strategy_name(warp_stereo_strategy s);

/* Pose of an eye (world_from_eye) from the head pose (world_from_head, the point between the eyes): the eyes sit at
 * -ipd/2 (left) and +ipd/2 (right) along the head's +X, with the head's orientation. */
warp_pose warp_stereo_eye_pose(warp_pose head, double ipd_m, warp_eye e);

/* What one frame does under a strategy. */
typedef struct {
    int n_render;          /* views to render this frame: render[0 .. n_render) */
    warp_eye render[2];
    warp_eye source[2];    /* output eye (LEFT, RIGHT) is made from the latest render of this view ... */
    bool warp[2];          /* ... warped to the eye's current pose (false: shown as rendered) */
} warp_stereo_plan;

/* The plan of frame `frame` (0 = the first: alternate-frame warping renders both eyes once to start). Frames are
 * the host's render frames; the display-rate warps of the runtime come on top. */
warp_stereo_plan warp_stereo_schedule(warp_stereo_strategy s, long frame);

/* Renders per frame and eye warps per frame in steady state: the cost the strategy saves (000 §6.3). */
void warp_stereo_cost(warp_stereo_strategy s, int *renders, int *warps);

/* One output eye of a plan: warps `src` (the view the plan names) to eye pose `eye` with the adaptive grid (g
 * allocated for the source size). A view rendered at exactly that pose comes out unchanged (identity). */
const char *warp_stereo_eye(warp_grid *g, const warp_view *src, const warp_camera *dst_cam, warp_pose eye,
                            const warp_grid_params *p, warp_image_rgba8 *dst, warp_image_f32 *dst_inv,
                            warp_image_u8 *mask, warp_grid_stats *st);

#endif
