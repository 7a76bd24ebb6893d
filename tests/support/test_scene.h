/* SPDX-License-Identifier: MIT */
/* test_scene: the fixture most warp tests share: a source render of a simulated scene with depth, the true view
 * at the target pose, and the source as a warp_view with its inverse depth. */
#ifndef TEST_SCENE_H
#define TEST_SCENE_H

#include <math.h>
#include <stdbool.h>

#include "sim/sim_scene.h"
#include "warp/warp_view.h"

/* Renders `scene` at scene time 0 from eye pose a (colour + depth) into src and from b (colour) into truth, and
 * makes *v the source view (camera, pose a, colour, inverse depth in inv with its range). Fails the running test
 * when the scene does not exist or its depth converts with bad values. */
void test_render_pair(const char *scene, const warp_camera *cam, warp_pose a, warp_pose b, sim_buffers *src,
                      sim_buffers *truth, warp_image_f32 *inv, warp_view *v);

/* The eye pose at yaw, pitch, roll (radians) and position p. */
static inline warp_pose test_eye_at(double yaw, double pitch, double roll, warp_vec3 p)
{
    return (warp_pose){warp_quat_from_ypr(yaw, pitch, roll), p};
}

/* The eye camera the grid, stereo and transparency tests render with: view tangents 1.0 left and right, 0.8 up,
 * 0.7 down, near plane 5 cm, no far plane. */
static inline warp_camera test_camera(int w, int h) { return (warp_camera){w, h, 1.0, 1.0, 0.8, 0.7, 0.05, INFINITY}; }

/* The source eye most warp tests render from: standing (1.6 m), level, looking 3 degrees down. */
static inline warp_pose test_eye_home(void) { return test_eye_at(0, -3 * (WARP_PI / 180.0), 0, warp_v3(0, 1.6, 0)); }

/* test_eye_home moved by d without turning: the pure-translation targets. */
static inline warp_pose test_eye_home_moved(warp_vec3 d)
{
    warp_pose e = test_eye_home();
    e.p = warp_v3_add(e.p, d);
    return e;
}

/* The images a source-vs-truth warp test works on: the two renders, the source's inverse depth and view, two
 * outputs and two masks, all W x H. */
typedef struct {
    sim_buffers a, b; /* source render (colour + depth) and truth render */
    warp_image_f32 inv;
    warp_image_rgba8 out, out2;
    warp_image_u8 mask, mask2;
    warp_view v;
} test_pair;

/* Allocates every image of p at w x h, the renders with `planes` (SIM_PLANE_*; colour and depth at least); false
 * (p partly allocated: test_pair_free it) when memory runs out. */
bool test_pair_alloc(test_pair *p, int w, int h, unsigned planes);
void test_pair_free(test_pair *p);
/* test_render_pair into p's source, truth, inverse depth and view. */
void test_pair_render(test_pair *p, const char *scene, const warp_camera *cam, warp_pose a, warp_pose b);

#endif
