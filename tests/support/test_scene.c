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

bool test_pair_alloc(test_pair *p, int w, int h, unsigned planes)
{
    return sim_buffers_alloc(&p->a, w, h, planes, 1) && sim_buffers_alloc(&p->b, w, h, planes, 1) &&
           warp_image_f32_alloc(&p->inv, w, h) && warp_image_rgba8_alloc(&p->out, w, h) &&
           warp_image_rgba8_alloc(&p->out2, w, h) && warp_image_u8_alloc(&p->mask, w, h) &&
           warp_image_u8_alloc(&p->mask2, w, h);
}

void test_pair_free(test_pair *p)
{
    sim_buffers_free(&p->a);
    sim_buffers_free(&p->b);
    warp_image_free(&p->inv);
    warp_image_free(&p->out);
    warp_image_free(&p->out2);
    warp_image_free(&p->mask);
    warp_image_free(&p->mask2);
}

void test_pair_render(test_pair *p, const char *scene, const warp_camera *cam, warp_pose a, warp_pose b)
{
    test_render_pair(scene, cam, a, b, &p->a, &p->b, &p->inv, &p->v);
}
