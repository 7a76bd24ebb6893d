/* SPDX-License-Identifier: MIT */
/* warp_view: a rendered eye image together with the pose and camera it was rendered with: the input of every
 * warp. Depth is held as inverse depth (1/z, 0 = infinity), which is affine in screen space along any ray. */
#ifndef WARP_VIEW_H
#define WARP_VIEW_H

#include "warp/warp_camera.h"
#include "warp/warp_image.h"
#include "warp/warp_math.h"

typedef struct {
    warp_camera cam;
    warp_pose pose;                  /* world_from_eye at render time */
    const warp_image_rgba8 *color;
    const warp_image_f32 *inv_depth; /* 1/z in 1/m per pixel, 0 = sky; NULL when the frame has no depth plane */
    float inv_depth_min, inv_depth_max; /* range over the image: the raytrace's search bounds */
    /* Optional planes, NULL when the frame has none (a scene sends only what its effects need). */
    const warp_image_u16 *ids;       /* object id per pixel, 0 = static scene (002 §3.2) */
    const warp_image_vec2f *motion;  /* screen motion from object motion, pixels per second, camera held still */
    const warp_image_layers *layers; /* transparent fragments per pixel, nearest first (000 §4.2) */
    int n_objects;
    const warp_pose *object_pose;    /* [id - 1]: world_from_object at render time */
    double time;                     /* scene time the view shows, seconds (object-motion extrapolation) */
} warp_view;

/* Converts a depth plane in encoding `enc` into inverse depth and reports its range. Depth nearer than the near
 * plane is taken as the near plane. Values that are NaN, zero or negative (linear), or outside [0, 1] (window depth)
 * are written as 0 (sky) and counted: the return value is the number of such bad values, so the caller can reject
 * the frame (a frame with bad depth is not warped). */
long warp_inverse_depth_from(const warp_camera *cam, warp_depth_encoding enc, const warp_image_f32 *depth,
                             warp_image_f32 *inv, float *inv_min, float *inv_max);

#endif
