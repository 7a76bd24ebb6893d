/* SPDX-License-Identifier: MIT */
/* test_scene: the fixture most warp tests share: a source render of a simulated scene with depth, the true view
 * at the target pose, and the source as a warp_view with its inverse depth. */
#ifndef TEST_SCENE_H
#define TEST_SCENE_H

#include "sim/sim_scene.h"
#include "warp/warp_view.h"

/* Renders `scene` at scene time 0 from eye pose a (colour + depth) into src and from b (colour) into truth, and
 * makes *v the source view (camera, pose a, colour, inverse depth in inv with its range). Fails the running test
 * when the scene does not exist or its depth converts with bad values. */
void test_render_pair(const char *scene, const warp_camera *cam, warp_pose a, warp_pose b, sim_buffers *src,
                      sim_buffers *truth, warp_image_f32 *inv, warp_view *v);

#endif
