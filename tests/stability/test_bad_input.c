/* SPDX-License-Identifier: MIT */
/* Bad poses and depth into every warp (issue #21): a NaN or infinite position or orientation, a zero or non-unit
 * quaternion, as the source's pose, the target's or an object's, into rotation, raytrace, grid, stereo,
 * transparency, iterative, forward, splat and per-object warps: each refuses with a message naming the pose and
 * what is wrong, and nothing crashes (ASan/UBSan in `make asan`). Depth nearer than the near plane is taken as the
 * near plane, not as sky. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "warp/warp_camera.h"
#include "warp/warp_forward.h"
#include "warp/warp_grid.h"
#include "warp/warp_iterative.h"
#include "warp/warp_objects.h"
#include "warp/warp_raytrace.h"
#include "warp/warp_reproject.h"
#include "warp/warp_splat.h"
#include "warp/warp_stereo.h"
#include "warp/warp_transparency.h"
#include "warp/warp_view.h"

#define W 64
#define H 48

static warp_camera cam(void) { return (warp_camera){W, H, 1.0, 1.0, 0.75, 0.75, 0.05, INFINITY}; }

/* ---- every warp on a small synthetic view (colour, depth, ids, one object, an empty A-buffer) ---- */

typedef struct {
    warp_image_rgba8 color, out;
    warp_image_f32 inv, zb;
    warp_image_u16 ids;
    warp_image_u8 mask;
    warp_image_layers layers;
    warp_grid g;
    warp_minmax_tree t;
    warp_iter_ctx it;
    warp_fwd_scratch sc;
    warp_objects_setup *os;
    warp_pose obj_src[1], obj_dst[1];
    warp_view v;
} fx;

static fx F;

static int setup(void **state)
{
    (void)state;
    if (!warp_image_rgba8_alloc(&F.color, W, H) || !warp_image_rgba8_alloc(&F.out, W, H) ||
        !warp_image_f32_alloc(&F.inv, W, H) || !warp_image_f32_alloc(&F.zb, W, H) ||
        !warp_image_u16_alloc(&F.ids, W, H) || !warp_image_u8_alloc(&F.mask, W, H) ||
        !warp_image_layers_alloc(&F.layers, W, H, 2) || !warp_grid_alloc(&F.g, W, H, warp_grid_default_params().tile) ||
        !warp_minmax_alloc(&F.t, W, H) || !warp_iter_alloc(&F.it, W, H, W, H, 1) ||
        !warp_fwd_scratch_alloc(&F.sc, W, H, W, H) || !(F.os = calloc(1, sizeof *F.os)))
        return -1;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            WARP_AT(&F.color, x, y) = (warp_rgba8){(uint8_t)(x * 4), (uint8_t)(y * 5), 90, 255};
            WARP_AT(&F.inv, x, y) = x < W / 2 ? 0.5f : 1.0f; /* a depth edge, 2 m and 1 m */
            WARP_AT(&F.ids, x, y) = x > W / 2 && y > H / 2;  /* object 1 in one corner */
        }
    F.obj_src[0] = F.obj_dst[0] = warp_pose_identity();
    F.v = (warp_view){.cam = cam(), .pose = warp_pose_identity(), .color = &F.color, .inv_depth = &F.inv,
                      .inv_depth_min = 0.5f, .inv_depth_max = 1.0f, .ids = &F.ids, .layers = &F.layers,
                      .n_objects = 1, .object_pose = F.obj_src};
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    warp_image_free(&F.color);
    warp_image_free(&F.out);
    warp_image_free(&F.inv);
    warp_image_free(&F.zb);
    warp_image_free(&F.ids);
    warp_image_free(&F.mask);
    warp_image_layers_free(&F.layers);
    warp_grid_free(&F.g);
    warp_minmax_free(&F.t);
    warp_iter_free(&F.it);
    warp_fwd_scratch_free(&F.sc);
    free(F.os);
    return 0;
}

enum { RUN_ROTATION, RUN_RAYTRACE, RUN_GRID, RUN_STEREO, RUN_TRANSPARENCY, RUN_ITERATIVE, RUN_FORWARD, RUN_SPLAT,
       RUN_OBJECTS, RUN_COUNT };
static const char *const run_name[RUN_COUNT] = {"rotation", "raytrace", "grid",    "stereo", "transparency",
                                                "iterative", "forward", "splat", "objects"};

/* Runs warp `w` of F.v to dst; NULL or its error. A warp that accepts must also finish without a crash. */
static const char *run(int w, warp_pose dst, const warp_pose *dst_objects)
{
    const warp_camera c = cam();
    warp_grid_params gp = warp_grid_default_params();
    warp_splat_params sp = warp_splat_default_params(WARP_SPLAT_POINT);
    warp_image_u8_fill(&F.mask, 0);
    const char *why = NULL;
    switch (w) {
    case RUN_ROTATION: {
        warp_mat3 h;
        if (!(why = warp_reproject_prepare(&h, &F.v, &c, dst.q))) warp_reproject_rows(&F.v, &h, &F.out, &F.mask, 0, H);
        break;
    }
    case RUN_RAYTRACE: {
        warp_raytrace_params p = warp_raytrace_default_params();
        warp_raytrace_setup s;
        if (!(why = warp_raytrace_prepare(&s, &F.v, &c, dst, &p))) warp_raytrace_rows(&s, &F.out, &F.mask, 0, H, NULL);
        break;
    }
    case RUN_GRID: why = warp_grid_run(&F.g, &F.v, &c, dst, &gp, &F.out, &F.zb, &F.mask, NULL); break;
    case RUN_STEREO: why = warp_stereo_eye(&F.g, &F.v, &c, dst, &gp, &F.out, &F.zb, &F.mask, NULL); break;
    case RUN_TRANSPARENCY: {
        warp_transparency_params p = warp_transparency_default_params();
        why = warp_transparency_run(&F.g, &F.t, &F.v, &c, dst, &gp, &p, &F.out, &F.zb, &F.mask, NULL, NULL);
        /* the runtime's own split (rt_render_cpu): the prepare alone checks too */
        warp_transparency_setup s;
        const char *why2 = warp_transparency_prepare(&s, &F.v, &F.t, &c, dst, &p);
        if ((why == NULL) != (why2 == NULL)) fail_msg("transparency run '%s', prepare '%s'", why, why2);
        break;
    }
    case RUN_ITERATIVE: {
        warp_iter_params p = warp_iter_default_params();
        warp_iter_target t = {.cam = c, .pose = dst, .time = 0, .object_pose = dst_objects};
        why = warp_iter_run(&F.it, &F.v, NULL, 0, &t, &p, &F.out, &F.mask, NULL);
        break;
    }
    case RUN_FORWARD: {
        warp_forward_params p = warp_forward_default_params();
        why = warp_forward_run(&F.v, &c, dst, &p, &F.sc, &F.out, &F.mask, NULL);
        break;
    }
    case RUN_SPLAT: why = warp_splat_run(&F.v, &c, dst, &sp, &F.sc, &F.out, &F.mask, NULL); break;
    case RUN_OBJECTS:
        why = warp_objects_run(F.os, &F.v, &c, dst, dst_objects, &sp, &F.sc, &F.out, &F.mask, NULL);
        break;
    }
    return why;
}

typedef struct {
    const char *what;
    warp_pose p;
    const char *want; /* the problem the message must name */
} bad_pose;

static void bad_poses(bad_pose *b)
{
    warp_pose id = warp_pose_identity();
    b[0] = (bad_pose){"NaN position", id, "position is not finite"};
    b[0].p.p.x = NAN;
    b[1] = (bad_pose){"infinite position", id, "position is not finite"};
    b[1].p.p.z = -INFINITY;
    b[2] = (bad_pose){"NaN orientation", id, "orientation is not finite"};
    b[2].p.q.y = NAN;
    b[3] = (bad_pose){"infinite orientation", id, "orientation is not finite"};
    b[3].p.q.w = INFINITY;
    b[4] = (bad_pose){"zero quaternion", id, "orientation quaternion is zero"};
    b[4].p.q = (warp_quat){0, 0, 0, 0};
    b[5] = (bad_pose){"quaternion of length 2", id, "not a unit quaternion"};
    b[5].p.q = (warp_quat){2, 0, 0, 0};
}

/* Rotation uses the target's orientation only: a bad target position is not its business. */
static bool uses_target_position(int w) { return w != RUN_ROTATION; }

/* 1 (and a line on what happened) unless the warp refused with a message naming `who` and the problem. */
static int not_refused(int w, const char *why, const char *who, const bad_pose *b)
{
    if (why && strncmp(why, who, strlen(who)) == 0 && strstr(why, b->want)) return 0;
    if (!why) print_message("  %s warp accepted a %s %s\n", run_name[w], who, b->what);
    else print_message("  %s warp, %s %s: '%s' (want '%s pose: %s')\n", run_name[w], who, b->what, why, who, b->want);
    return 1;
}

static void test_bad_poses_into_every_warp(void **state)
{
    (void)state;
    bad_pose b[6];
    bad_poses(b);
    const warp_pose good = {warp_quat_from_ypr(0.02, 0.01, 0), {0.01, 0, 0}};
    int cases = 0, missed = 0;
    for (int w = 0; w < RUN_COUNT; w++) {
        /* the good case first: every warp runs on this input, so a refusal below is the pose's doing */
        F.v.pose = warp_pose_identity();
        const char *why = run(w, good, F.obj_dst);
        if (why) fail_msg("%s warp refused a good pose: %s", run_name[w], why);
        for (int i = 0; i < 6; i++) {
            if (uses_target_position(w) || i >= 2) {
                missed += not_refused(w, run(w, b[i].p, F.obj_dst), "target", &b[i]);
                cases++;
            }
            F.v.pose = b[i].p;
            missed += not_refused(w, run(w, good, F.obj_dst), "source", &b[i]);
            cases++;
            F.v.pose = warp_pose_identity();
        }
    }
    print_message("%d of %d bad source and target poses into %d warps not refused as named\n", missed, cases,
                  RUN_COUNT);
    assert_int_equal(missed, 0);
}

static void test_bad_object_poses(void **state)
{
    (void)state;
    bad_pose b[6];
    bad_poses(b);
    const warp_pose good = {warp_quat_from_ypr(0.02, 0, 0), {0.01, 0, 0}};
    const int uses_objects[] = {RUN_ITERATIVE, RUN_OBJECTS};
    int missed = 0;
    F.v.pose = warp_pose_identity();
    for (int k = 0; k < 2; k++) {
        int w = uses_objects[k];
        for (int i = 0; i < 6; i++) {
            missed += not_refused(w, run(w, good, &b[i].p), "target object", &b[i]);
            F.obj_src[0] = b[i].p;
            missed += not_refused(w, run(w, good, F.obj_dst), "source object", &b[i]);
            F.obj_src[0] = warp_pose_identity();
        }
        assert_null(run(w, good, F.obj_dst));
    }
    print_message("%d of 24 bad object poses into the iterative and per-object warps not refused as named\n", missed);
    assert_int_equal(missed, 0);
}

/* ---- depth nearer than near ---- */

/* A linear depth plane of sky with a square 2 cm away (the near plane is 5 cm): a renderer's rounding or a
 * different near plane puts depth inside near, and that surface is the nearest thing in view, not sky. Taken as
 * near, a 2 cm step to the right moves it 13 px left (0.02 / 0.05 tangent units at 32 px per unit); taken as sky,
 * it would not move at all. */
static void test_depth_nearer_than_near_is_near(void **state)
{
    (void)state;
    const warp_camera c = cam();
    warp_image_f32 depth;
    assert_true(warp_image_f32_alloc(&depth, W, H));
    const int x0 = 24, x1 = 40, y0 = 16, y1 = 32;
    const warp_rgba8 red = {220, 30, 30, 255}, blue = {40, 60, 200, 255};
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            bool in = x >= x0 && x < x1 && y >= y0 && y < y1;
            WARP_AT(&depth, x, y) = in ? 0.02f : INFINITY;
            WARP_AT(&F.color, x, y) = in ? red : blue;
        }
    float lo, hi;
    long bad = warp_inverse_depth_from(&c, WARP_DEPTH_LINEAR, &depth, &F.inv, &lo, &hi);
    print_message("depth 2 cm with near at 5 cm: inverse depth %g (near's %g), %ld values refused\n",
                  WARP_AT(&F.inv, 30, 20), 1 / c.near_z, bad);
    assert_int_equal(bad, 0);
    assert_true(fabs(WARP_AT(&F.inv, 30, 20) - 1 / c.near_z) < 1e-4 && hi == WARP_AT(&F.inv, 30, 20));
    warp_view v = {.cam = c, .pose = warp_pose_identity(), .color = &F.color, .inv_depth = &F.inv,
                   .inv_depth_min = lo, .inv_depth_max = hi};
    warp_pose to = warp_pose_identity();
    to.p.x = 0.02;
    warp_raytrace_params p = warp_raytrace_default_params();
    warp_raytrace_setup s;
    assert_null(warp_raytrace_prepare(&s, &v, &c, to, &p));
    warp_raytrace_rows(&s, &F.out, &F.mask, 0, H, NULL);
    /* the square moved left by 0.02 / 0.05 tangent units: its new place, most of it outside the old one, shows
     * the near surface (the disocclusion it left is the edge fill's business, not judged here) */
    const int shift = (int)lround(to.p.x / c.near_z * warp_camera_pixels_per_tan_x(&c));
    long near_px = 0;
    for (int x = x0 - shift + 1; x < x1 - shift - 1; x++) near_px += WARP_AT(&F.out, x, 24).r > 150;
    print_message("%.0f cm step: %ld of %d px show the near surface where it moved (%d px left)\n", to.p.x * 100,
                  near_px, x1 - x0 - 2, shift);
    assert_true(shift > 10);
    assert_int_equal(near_px, x1 - x0 - 2);
    warp_image_free(&depth);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bad_poses_into_every_warp),
        cmocka_unit_test(test_bad_object_poses),
        cmocka_unit_test(test_depth_nearer_than_near_is_near),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
