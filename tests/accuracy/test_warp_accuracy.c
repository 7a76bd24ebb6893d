/* SPDX-License-Identifier: MIT */
/* Accuracy of the warps against the simulator's ground truth: rotation reprojection under pure rotation (003 §3.4),
 * the raytrace warp under head translation (003 §3.5), their invariants, and the knobs that trade accuracy. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>
#include <cmocka.h>

#include "tests/support/test_scene.h"

#include "sim/sim_scene.h"
#include "warp/warp_camera.h"
#include "warp/warp_metrics.h"
#include "warp/warp_raytrace.h"
#include "warp/warp_reproject.h"
#include "warp/warp_view.h"

#define W 480
#define H 400

typedef struct {
    warp_camera cam;
    test_pair p;
} fx;

static fx F;

static int setup(void **state)
{
    (void)state;
    F.cam = (warp_camera){W, H, 1.0, 1.0, 0.85, 0.82, 0.05, INFINITY};
    return test_pair_alloc(&F.p, W, H, SIM_PLANE_COLOR | SIM_PLANE_DEPTH) ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    test_pair_free(&F.p);
    return 0;
}

/* Renders the source at pose a (with depth) and the truth at pose b. */
static void render_pair(const char *scene, warp_pose a, warp_pose b)
{
    test_pair_render(&F.p, scene, &F.cam, a, b);
}

static void reproject(warp_pose to, warp_image_rgba8 *out, warp_image_u8 *mask)
{
    warp_mat3 h = warp_reproject_homography(&F.p.v, &F.cam, to.q);
    warp_reproject_rows(&F.p.v, &h, out, mask, 0, H);
}

static void raytrace(warp_pose to, const warp_raytrace_params *p, warp_image_rgba8 *out, warp_image_u8 *mask,
                     warp_raytrace_stats *st)
{
    warp_raytrace_setup s;
    assert_null(warp_raytrace_prepare(&s, &F.p.v, &F.cam, to, p));
    warp_raytrace_rows(&s, out, mask, 0, H, st);
}

static const double D2R = WARP_PI / 180.0;

static void test_rotation_matches_truth(void **state)
{
    (void)state;
    warp_vec3 eye = warp_v3(0, 1.6, 0);
    warp_pose a = test_eye_at(5 * D2R, 2 * D2R, 0, eye);
    warp_pose b = test_eye_at(11 * D2R, -1 * D2R, 2 * D2R, eye); /* 6 deg left, 3 down, 2 roll: a fast head turn */
    render_pair("room", a, b);
    reproject(b, &F.p.out, &F.p.mask);
    double warped = warp_psnr(&F.p.out, &F.p.b.color, &F.p.mask, WARP_MASK_FRINGE);
    double unwarped = warp_psnr(&F.p.a.color, &F.p.b.color, NULL, 0);
    double ssim = warp_ssim(&F.p.out, &F.p.b.color, &F.p.mask, WARP_MASK_FRINGE);
    print_message("room, 7 deg turn: rotation warp %.2f dB (SSIM %.4f) away from fringes, unwarped %.2f dB\n", warped,
                  ssim, unwarped);
    assert_true(warped > 33.0);
    assert_true(ssim > 0.95);
    assert_true(unwarped < 20.0);
    /* The head turned left: new content enters at the left edge, so the fringe is there and not at the right. */
    long left = 0, right = 0;
    for (int y = 0; y < H; y++) {
        left += WARP_AT(&F.p.mask, 2, y) & WARP_MASK_FRINGE;
        right += WARP_AT(&F.p.mask, W - 3, y) & WARP_MASK_FRINGE;
    }
    assert_true(left > H / 2 && right == 0);
}

static void test_rotation_sign_error_fails(void **state)
{
    (void)state;
    /* The threshold above must catch a matrix-order or sign mistake: warping with the inverse rotation. */
    warp_vec3 eye = warp_v3(0, 1.6, 0);
    warp_pose a = test_eye_at(5 * D2R, 2 * D2R, 0, eye);
    warp_pose b = test_eye_at(11 * D2R, -1 * D2R, 2 * D2R, eye);
    render_pair("room", a, b);
    warp_quat wrong = warp_quat_mul(a.q, warp_quat_mul(warp_quat_conj(b.q), a.q)); /* rotated the other way */
    warp_pose bw = {wrong, eye};
    reproject(bw, &F.p.out, &F.p.mask);
    double p = warp_psnr(&F.p.out, &F.p.b.color, &F.p.mask, WARP_MASK_FRINGE);
    print_message("inverse rotation: %.2f dB\n", p);
    assert_true(p < 22.0);
}

static void test_raytrace_beats_rotation_under_translation(void **state)
{
    (void)state;
    warp_pose a = test_eye_home();
    warp_pose b = test_eye_at(1.5 * D2R, -3 * D2R, 0, warp_v3(0.04, 1.61, -0.01)); /* 4 cm sideways lean */
    render_pair("near", a, b);
    warp_raytrace_params p = warp_raytrace_default_params();
    warp_raytrace_stats st = {0};
    raytrace(b, &p, &F.p.out, &F.p.mask, &st);
    reproject(b, &F.p.out2, &F.p.mask2);
    /* Score both away from the fringe and the disocclusion fills, where neither has data. */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) WARP_AT(&F.p.mask, x, y) |= WARP_AT(&F.p.mask2, x, y);
    double rt = warp_psnr(&F.p.out, &F.p.b.color, &F.p.mask, 0xff), rot = warp_psnr(&F.p.out2, &F.p.b.color, &F.p.mask, 0xff);
    double rte = warp_error_pixel_percent(&F.p.out, &F.p.b.color, &F.p.mask, 0xff, 20);
    double rote = warp_error_pixel_percent(&F.p.out2, &F.p.b.color, &F.p.mask, 0xff, 20);
    print_message("near, 4 cm: raytrace %.2f dB / %.2f %% error px, rotation %.2f dB / %.2f %%; %.1f steps per ray, "
                  "%ld edge px\n",
                  rt, rte, rot, rote, (double)st.steps / (double)st.rays, st.edge_pixels);
    assert_true(rt > 28.0);
    assert_true(rt > rot + 4.0);
    assert_true(rte < rote / 2);
    assert_true(st.edge_pixels > 0); /* near objects against the far wall open disocclusions */
}

static void test_raytrace_identity_and_pure_rotation(void **state)
{
    (void)state;
    warp_pose a = test_eye_at(0.2, 0.1, 0, warp_v3(0.3, 1.5, 0.2));
    render_pair("near", a, a);
    warp_raytrace_params p = warp_raytrace_default_params();
    raytrace(a, &p, &F.p.out, &F.p.mask, NULL);
    assert_true(isinf(warp_psnr(&F.p.out, &F.p.a.color, NULL, 0))); /* identity pose -> identity image */
    /* pure rotation: the raytrace reduces to the rotation reprojection */
    warp_pose b = test_eye_at(0.26, 0.07, 0.03, a.p);
    raytrace(b, &p, &F.p.out, &F.p.mask, NULL);
    reproject(b, &F.p.out2, &F.p.mask2);
    double same = warp_psnr(&F.p.out, &F.p.out2, NULL, 0);
    print_message("pure rotation: raytrace vs reprojection %.2f dB\n", same);
    assert_true(same > 45.0);
}

static void test_raytrace_refinement_and_budget(void **state)
{
    (void)state;
    warp_pose a = test_eye_home();
    warp_pose b = test_eye_home_moved(warp_v3(0.05, 0, 0));
    render_pair("near", a, b);
    warp_raytrace_params p = warp_raytrace_default_params();
    raytrace(b, &p, &F.p.out, &F.p.mask, NULL);
    double full = warp_psnr(&F.p.out, &F.p.b.color, &F.p.mask, 0xff);
    p.refine_iters = 0;
    raytrace(b, &p, &F.p.out2, &F.p.mask2, NULL);
    double coarse = warp_psnr(&F.p.out2, &F.p.b.color, &F.p.mask, 0xff);
    p.refine_iters = 4;
    p.max_steps = 3;
    warp_raytrace_stats st = {0};
    raytrace(b, &p, &F.p.out2, &F.p.mask2, &st);
    double budget = warp_psnr(&F.p.out2, &F.p.b.color, &F.p.mask, 0xff);
    print_message("refined %.2f dB, unrefined %.2f dB, 3-step budget %.2f dB\n", full, coarse, budget);
    assert_true(full > coarse + 1.0); /* the sub-pixel hit matters */
    assert_true(full > budget + 1.0); /* skipping samples misses thin near surfaces */
    assert_true(st.steps <= 3 * st.rays);
}

static void test_raytrace_edge_fills(void **state)
{
    (void)state;
    warp_pose a = test_eye_home();
    warp_pose b = test_eye_home_moved(warp_v3(0.06, 0, 0));
    render_pair("near", a, b);
    warp_raytrace_params p = warp_raytrace_default_params();
    p.edge_fill = WARP_EDGE_FILL_FAR;
    raytrace(b, &p, &F.p.out, &F.p.mask, NULL);
    p.edge_fill = WARP_EDGE_FILL_LINEAR;
    raytrace(b, &p, &F.p.out2, &F.p.mask2, NULL);
    long edges = 0, differ = 0, differ_outside = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            assert_int_equal(WARP_AT(&F.p.mask, x, y), WARP_AT(&F.p.mask2, x, y)); /* the fill does not move edges */
            bool e = WARP_AT(&F.p.mask, x, y) & WARP_MASK_EDGE;
            warp_rgba8 p1 = WARP_AT(&F.p.out, x, y), p2 = WARP_AT(&F.p.out2, x, y);
            bool d = p1.r != p2.r || p1.g != p2.g || p1.b != p2.b;
            edges += e;
            differ += d && e;
            differ_outside += d && !e;
        }
    print_message("%ld edge pixels, %ld filled differently\n", edges, differ);
    assert_true(edges > 100);
    assert_true(differ > edges / 4);
    assert_int_equal(differ_outside, 0);
}

static void test_reversed_z_input(void **state)
{
    (void)state;
    /* A host that sends reversed-Z window depth gets the same warp as one that sends linear depth. */
    warp_pose a = test_eye_at(0, 0, 0, warp_v3(0, 1.6, 0));
    warp_pose b = test_eye_at(0.02, 0, 0, warp_v3(0.03, 1.6, 0));
    render_pair("near", a, b);
    warp_raytrace_params p = warp_raytrace_default_params();
    raytrace(b, &p, &F.p.out, NULL, NULL);
    warp_image_f32 rz;
    assert_true(warp_image_f32_alloc(&rz, W, H));
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double z = WARP_AT(&F.p.a.depth, x, y);
            WARP_AT(&rz, x, y) = (float)warp_depth_from_inverse(&F.cam, WARP_DEPTH_REVERSED, 1.0 / z);
        }
    assert_int_equal(warp_inverse_depth_from(&F.cam, WARP_DEPTH_REVERSED, &rz, &F.p.inv, &F.p.v.inv_depth_min,
                                             &F.p.v.inv_depth_max),
                     0);
    raytrace(b, &p, &F.p.out2, NULL, NULL);
    double same = warp_psnr(&F.p.out, &F.p.out2, NULL, 0);
    print_message("reversed-Z vs linear depth input: %.2f dB\n", same);
    assert_true(same > 45.0);
    /* bad depth values are counted, not propagated */
    WARP_AT(&rz, 5, 5) = NAN;
    WARP_AT(&rz, 6, 5) = -0.5f;
    assert_int_equal(warp_inverse_depth_from(&F.cam, WARP_DEPTH_REVERSED, &rz, &F.p.inv, &F.p.v.inv_depth_min,
                                             &F.p.v.inv_depth_max),
                     2);
    assert_true(WARP_AT(&F.p.inv, 5, 5) == 0.0f);
    warp_image_free(&rz);
}

static void test_raytrace_blockmax_skipping_is_exact(void **state)
{
    (void)state;
    /* The block-max grid only skips steps that cannot hit: the image and mask are bit-identical to the plain
     * linear search, with far fewer depth samples (a broken bound would change pixels or skip nothing). */
    warp_image_f32 bmax;
    assert_true(warp_image_f32_alloc(&bmax, (W + 7) / 8, (H + 7) / 8));
    const warp_pose a = test_eye_at(0, 0, 0, warp_v3(0, 1.6, 0));
    const warp_pose tos[3] = {test_eye_at(0.03, 0, 0, warp_v3(0.05, 1.6, 0)), test_eye_at(-0.02, 0.01, 0, warp_v3(-0.03, 1.62, -0.04)),
                              test_eye_at(0, 0, 0, warp_v3(0, 1.6, -0.08))};
    const char *scenes[2] = {"near", "hairball"};
    for (int sc = 0; sc < 2; sc++)
        for (int t = 0; t < 3; t++) {
            render_pair(scenes[sc], a, tos[t]);
            warp_raytrace_blockmax(&F.p.inv, &bmax, 8);
            warp_raytrace_params p = warp_raytrace_default_params();
            warp_raytrace_setup s;
            assert_null(warp_raytrace_prepare(&s, &F.p.v, &F.cam, tos[t], &p));
            warp_raytrace_stats plain = {0}, fast = {0};
            warp_raytrace_rows(&s, &F.p.out, &F.p.mask, 0, H, &plain);
            warp_raytrace_use_blockmax(&s, &bmax, 8);
            warp_raytrace_rows(&s, &F.p.out2, &F.p.mask2, 0, H, &fast);
            for (int y = 0; y < H; y++) {
                assert_memory_equal(&WARP_AT(&F.p.out, 0, y), &WARP_AT(&F.p.out2, 0, y), sizeof(warp_rgba8) * W);
                assert_memory_equal(&WARP_AT(&F.p.mask, 0, y), &WARP_AT(&F.p.mask2, 0, y), W);
            }
            assert_int_equal(plain.steps, fast.steps); /* the search is the same; it samples less */
            print_message("%s pose %d: %ld steps, samples %ld -> %ld\n", scenes[sc], t, plain.steps, plain.samples,
                          fast.samples);
            assert_true(fast.samples < plain.samples);
        }
    /* the translation case with most steps saves the most */
    warp_image_free(&bmax);
}

/* Bit 0 clear: pixels within 3 px of a depth edge of the truth (a relative depth jump over 0.1 between neighbours,
 * warp_depth_edge_band, as `make bench` scores its band), where a depth warp's silhouettes and disocclusion fills
 * show. */
static void depth_edge_band(const char *scene, warp_pose b, warp_image_u8 *band)
{
    sim_buffers t;
    memset(&t, 0, sizeof t);
    assert_true(sim_buffers_alloc(&t, W, H, SIM_PLANE_DEPTH, 0));
    sim_render(sim_scene_find(scene), 0.0, b, &F.cam, SIM_PLANE_DEPTH, &t);
    assert_true(warp_depth_edge_band(&t.depth, 0.1f, 3, band) > 0);
    sim_buffers_free(&t);
}

static void test_raytrace_depth_edge_band(void **state)
{
    (void)state;
    /* 5 cm sideways: near objects against the room open disocclusions. Before the edge decision moved from the two
     * search samples around the hit to texels (and the height map got vertical walls at depth edges), neighbouring
     * rays flipped between near and far (comb-like streaks) and grazing rays slid off silhouettes: 21.09 / 21.09 /
     * 25.10 dB in the band (near, hairball, room); then 22.66 / 22.50 / 27.68; 22.94 / 22.73 / 28.03 in
     * warp_depth_edge_band's band (both pixels of an edge's pair at its centre, where this test took one). */
    static const char *const scenes[] = {"near", "hairball", "room"};
    static const double floor_db[] = {22.2, 22.0, 27.0};
    warp_pose a = test_eye_home();
    warp_pose b = test_eye_at(1.5 * D2R, -3 * D2R, 0, warp_v3(0.05, 1.61, -0.01));
    for (int i = 0; i < 3; i++) {
        render_pair(scenes[i], a, b);
        warp_raytrace_params p = warp_raytrace_default_params();
        raytrace(b, &p, &F.p.out, &F.p.mask, NULL);
        depth_edge_band(scenes[i], b, &F.p.mask2);
        long n = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                /* the fringe has no data for any warp */
                WARP_AT(&F.p.mask2, x, y) |= (uint8_t)(WARP_AT(&F.p.mask, x, y) & WARP_MASK_FRINGE ? 1 : 0);
                n += !(WARP_AT(&F.p.mask2, x, y) & 1);
            }
        double band = warp_psnr(&F.p.out, &F.p.b.color, &F.p.mask2, 1);
        print_message("%-8s 5 cm: raytrace %.2f dB in the 3 px depth-edge band (%ld px)\n", scenes[i], band, n);
        assert_true(n > 3000);
        assert_true(band > floor_db[i]);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rotation_matches_truth),
        cmocka_unit_test(test_rotation_sign_error_fails),
        cmocka_unit_test(test_raytrace_beats_rotation_under_translation),
        cmocka_unit_test(test_raytrace_identity_and_pure_rotation),
        cmocka_unit_test(test_raytrace_refinement_and_budget),
        cmocka_unit_test(test_raytrace_edge_fills),
        cmocka_unit_test(test_raytrace_depth_edge_band),
        cmocka_unit_test(test_reversed_z_input),
        cmocka_unit_test(test_raytrace_blockmax_skipping_is_exact),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
