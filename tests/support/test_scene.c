/* SPDX-License-Identifier: MIT */
/* test_scene: the fixture most warp tests share: a source render of a simulated scene with depth, the true view
 * at the target pose, and the source as a warp_view with its inverse depth. */
#include "tests/support/test_scene.h"

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

void test_render_pair(const char *scene, const warp_camera *cam, warp_pose a, warp_pose b, sim_buffers *src,
                      sim_buffers *truth, warp_image_f32 *inv, warp_view *v)
{
    const sim_scene *s = sim_scene_find(scene);
    assert_non_null(s);
    sim_render(s, 0.0, a, cam, SIM_PLANE_COLOR | SIM_PLANE_DEPTH, src);
    sim_render(s, 0.0, b, cam, SIM_PLANE_COLOR, truth);
    *v = (warp_view){.cam = *cam, .pose = a, .color = &src->color, .inv_depth = inv};
    assert_int_equal(warp_inverse_depth_from(cam, WARP_DEPTH_LINEAR, &src->depth, inv, &v->inv_depth_min,
                                             &v->inv_depth_max),
                     0);
}
