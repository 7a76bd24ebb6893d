/* SPDX-License-Identifier: MIT */
/* Accuracy of the A-buffer transparency warp (000 §4.2, §5.3) against the simulator's ground truth on the glass
 * scene, compared with warping pre-blended colour (000 Fig. 7c, 7d); invariants and the ray caster's knobs. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdlib.h>
#include <cmocka.h>

#include "sim/sim_scene.h"
#include "tests/support/test_images.h"
#include "warp/warp_camera.h"
#include "warp/warp_grid.h"
#include "warp/warp_metrics.h"
#include "warp/warp_reproject.h"
#include "warp/warp_srgb.h"
#include "warp/warp_transparency.h"
#include "warp/warp_view.h"
#include "tests/support/test_scene.h"

#define W 320
#define H 240
#define MAXL 4

typedef struct {
    warp_camera cam;
    sim_buffers glass, room, truth;
    warp_image_f32 inv, front, zb;
    warp_image_rgba8 out, out2, unbl;
    warp_image_u8 mask, mask2;
    warp_grid g;
    warp_minmax_tree t;
    warp_view v;        /* the hybrid warp's input: opaque colour + depth + layers */
} fx;

static fx F;
static const test_image images[] = {TEST_F32(&F.inv),    TEST_F32(&F.front),   TEST_F32(&F.zb),
                                    TEST_RGBA8(&F.out),  TEST_RGBA8(&F.out2),  TEST_RGBA8(&F.unbl),
                                    TEST_U8(&F.mask),    TEST_U8(&F.mask2)};

static int setup(void **state)
{
    (void)state;
    F.cam = test_camera(W, H);
    unsigned all = SIM_PLANE_COLOR | SIM_PLANE_DEPTH | SIM_PLANE_LAYERS;
    if (!sim_buffers_alloc(&F.glass, W, H, all, MAXL) || !sim_buffers_alloc(&F.room, W, H, all, MAXL) ||
        !sim_buffers_alloc(&F.truth, W, H, all, MAXL))
        return -1;
    if (!test_images_alloc(images, TEST_IMAGES_N(images), W, H)) return -1;
    if (!warp_grid_alloc(&F.g, W, H, 32) || !warp_minmax_alloc(&F.t, W, H)) return -1;
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    sim_buffers_free(&F.glass);
    sim_buffers_free(&F.room);
    sim_buffers_free(&F.truth);
    test_images_free(images, TEST_IMAGES_N(images));
    warp_grid_free(&F.g);
    warp_minmax_free(&F.t);
    return 0;
}

static const double D2R = WARP_PI / 180.0;

/* Source: the glass scene's A-buffer and opaque depth; its opaque G-buffer colour is the room's (the glass scene is
 * the room plus panes, and the room renders identically in both). Truth: the glass scene at pose b. */
static void render_pair(warp_pose a, warp_pose b)
{
    const sim_scene *glass = sim_scene_find("glass"), *room = sim_scene_find("room");
    assert_non_null(glass);
    assert_non_null(room);
    sim_render(glass, 0.0, a, &F.cam, SIM_PLANE_COLOR | SIM_PLANE_DEPTH | SIM_PLANE_LAYERS, &F.glass);
    sim_render(room, 0.0, a, &F.cam, SIM_PLANE_COLOR | SIM_PLANE_DEPTH, &F.room);
    sim_render(glass, 0.0, b, &F.cam, SIM_PLANE_COLOR, &F.truth);
    float mn, mx;
    assert_int_equal(warp_inverse_depth_from(&F.cam, WARP_DEPTH_LINEAR, &F.glass.depth, &F.inv, &mn, &mx), 0);
    F.v = (warp_view){.cam = F.cam, .pose = a, .color = &F.room.color, .inv_depth = &F.inv,
                      .inv_depth_min = mn, .inv_depth_max = mx, .layers = &F.glass.layers};
}

static void hybrid(warp_pose to, const warp_transparency_params *p, warp_image_rgba8 *out,
                   warp_transparency_stats *st)
{
    warp_grid_params gp = warp_grid_default_params();
    assert_null(warp_transparency_run(&F.g, &F.t, &F.v, &F.cam, to, &gp, p, out, &F.zb, &F.mask, NULL, st));
}

/* Grid warp of the pre-blended colour with opaque depth (Fig. 7c) or with the front fragment's depth (Fig. 7d). */
static void preblended(warp_pose to, bool front_depth, warp_image_rgba8 *out)
{
    warp_view v = F.v;
    v.color = &F.glass.color;
    v.layers = NULL;
    if (front_depth) {
        warp_transparency_front_depth(&F.inv, &F.glass.layers, &F.front);
        v.inv_depth = &F.front;
    }
    warp_grid_params gp = warp_grid_default_params();
    assert_null(warp_grid_run(&F.g, &v, &F.cam, to, &gp, out, &F.zb, &F.mask2, NULL));
}

static long pane_pixels(void)
{
    long n = 0;
    for (int i = 0; i < W * H; i++) n += F.glass.layers.count[i] > 0;
    return n;
}

static void test_scene_setup(void **state)
{
    (void)state;
    warp_pose a = test_eye_at(0, 0, 0, warp_v3(0, 1.6, 0));
    render_pair(a, a);
    long frags = 0, multi = 0;
    for (int i = 0; i < W * H; i++) {
        frags += F.glass.layers.count[i];
        multi += F.glass.layers.count[i] > 1;
    }
    long bad = warp_minmax_build(&F.t, &F.glass.layers);
    print_message("glass: %ld pane pixels, %ld fragments, %ld pixels with 2+ layers, tree %d levels\n", pane_pixels(),
                  frags, multi, F.t.levels);
    assert_int_equal(bad, 0);
    assert_int_equal(F.t.fragments, frags);
    assert_true(pane_pixels() > W * H / 10 && multi > 1000);
    /* the opaque planes of glass and room agree, so the room's colour is the glass scene's G-buffer */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) assert_true(WARP_AT(&F.glass.depth, x, y) == WARP_AT(&F.room.depth, x, y));
    /* unblending the final colour recovers the G-buffer up to 8-bit rounding */
    long lost = warp_transparency_unblend(&F.glass.color, &F.glass.layers, &F.unbl);
    double q = warp_psnr(&F.unbl, &F.room.color, NULL, 0);
    print_message("unblended colour vs opaque colour: %.2f dB (%ld unrecoverable)\n", q, lost);
    assert_int_equal(lost, 0);
    assert_true(q > 40.0);
    /* root of the min-max tree: the panes are 1.3-2.7 m away (inverse depth ~0.35..0.8) */
    int top = F.t.levels - 1;
    assert_true(F.t.mn[F.t.off[top]] > 0.3f && F.t.mx[F.t.off[top]] < 0.85f);
}

static void test_identity_and_pure_rotation(void **state)
{
    (void)state;
    warp_pose a = test_eye_at(0.1, -0.05, 0, warp_v3(0.05, 1.6, 0.1));
    render_pair(a, a);
    warp_transparency_params p = warp_transparency_default_params();
    warp_transparency_stats st = {0};
    hybrid(a, &p, &F.out, &st);
    double q = warp_psnr(&F.out, &F.glass.color, NULL, 0);
    print_message("identity: hybrid vs source %.2f dB; %ld rays, %ld hit, %.2f nodes per ray\n", q, st.rays,
                  st.rays_hit, (double)st.nodes / (double)st.rays);
    assert_true(q > 45.0); /* 8-bit fragments vs the renderer's float blend: rounding only */
    assert_int_equal(st.rays_hit, pane_pixels());
    /* pure rotation: the same as rotating the final image */
    warp_pose b = test_eye_at(0.14, -0.02, 0.02, a.p);
    render_pair(a, b);
    hybrid(b, &p, &F.out, NULL);
    warp_mat3 hm = warp_reproject_homography(&F.v, &F.cam, b.q);
    warp_view fin = F.v;
    fin.color = &F.glass.color;
    warp_reproject_rows(&fin, &hm, &F.out2, &F.mask2, 0, H);
    for (int i = 0; i < W * H; i++) F.mask.px[i] |= F.mask2.px[i];
    double same = warp_psnr(&F.out, &F.out2, &F.mask, 0xff);
    print_message("pure rotation: hybrid vs rotation reprojection of the final image %.2f dB\n", same);
    assert_true(same > 33.0); /* nearest-sampled fragments vs bilinear: resampling only */
}

/* The runtime's path (rt_frameq, hmdwarp-warp): the host sends only the final image and its layers; the opaque colour
 * is un-blended from it, warped, and the layers composited back over it. At the identity that must give the input
 * back. The simulator blends in linear light as renderers do (issue #21: 49.3 dB and 5,175 clamped pixels on Cycles
 * renders when the warp blended the sRGB codes). */
static void test_unblend_identity_round_trip(void **state)
{
    (void)state;
    warp_pose a = test_eye_at(0.1, -0.05, 0, warp_v3(0.05, 1.6, 0.1));
    render_pair(a, a);
    long lost = warp_transparency_unblend(&F.glass.color, &F.glass.layers, &F.unbl);
    warp_view v = F.v;
    v.color = &F.unbl;
    warp_transparency_params p = warp_transparency_default_params();
    warp_grid_params gp = warp_grid_default_params();
    assert_null(warp_transparency_run(&F.g, &F.t, &v, &F.cam, a, &gp, &p, &F.out, &F.zb, &F.mask, NULL, NULL));
    double q = warp_psnr(&F.out, &F.glass.color, NULL, 0);
    int worst = 0;
    long off = 0; /* pixels more than one code off: where the un-blend had to clamp, or blended differently */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            warp_rgba8 o = WARP_AT(&F.out, x, y), i = WARP_AT(&F.glass.color, x, y);
            int e = abs(o.r - i.r);
            if (abs(o.g - i.g) > e) e = abs(o.g - i.g);
            if (abs(o.b - i.b) > e) e = abs(o.b - i.b);
            if (e > worst) worst = e;
            off += e > 1;
        }
    print_message("un-blend, identity warp, composite: %.2f dB against the input, worst %d codes, %ld px more than 1 "
                  "code off, %ld unrecoverable (%ld pane pixels)\n", q, worst, off, lost, pane_pixels());
    assert_int_equal(lost, 0);
    assert_true(q > 60.0);
    assert_true(worst <= 1);
    assert_int_equal(off, 0);
}

/* The transfer tables against the curve: every code decodes and encodes back to itself, and the encoder rounds as
 * round(255 * encode(v)) does over a fine sweep of linear values. */
static void test_srgb_tables(void **state)
{
    (void)state;
    for (int c = 0; c < 256; c++) {
        assert_true(fabsf(warp_srgb_to_linear_u8[c] - warp_srgb_decode(c / 255.0f)) < 2e-6f);
        assert_int_equal(warp_srgb_from_linear_u8(warp_srgb_to_linear_u8[c]), c);
    }
    long differ = 0;
    for (int i = 0; i <= 1 << 20; i++) {
        float v = (float)i / (float)(1 << 20);
        int want = (int)(warp_srgb_encode(v) * 255.0f + 0.5f);
        differ += abs(warp_srgb_from_linear_u8(v) - want) > 0;
        assert_true(abs(warp_srgb_from_linear_u8(v) - want) <= 1); /* float rounding at the half-way points only */
    }
    print_message("sRGB encoder vs the float curve: %ld of %d linear values round to the neighbouring code\n",
                  differ, (1 << 20) + 1);
    assert_true(differ < 64);
    assert_int_equal(warp_srgb_from_linear_u8(-1.0f), 0);
    assert_int_equal(warp_srgb_from_linear_u8(2.0f), 255);
    assert_int_equal(warp_srgb_from_linear_u8(NAN), 0);
}

static void test_abuffer_beats_preblended(void **state)
{
    (void)state;
    warp_pose a = test_eye_at(0, -2 * D2R, 0, warp_v3(0, 1.6, 0));
    warp_pose b = test_eye_at(1.0 * D2R, -2 * D2R, 0, warp_v3(0.04, 1.62, -0.02)); /* 4 cm lean */
    render_pair(a, b);
    warp_transparency_params p = warp_transparency_default_params();
    warp_transparency_stats st = {0};
    hybrid(b, &p, &F.out, &st);
    double ab = warp_psnr(&F.out, &F.truth.color, NULL, 0), abs_ = warp_ssim(&F.out, &F.truth.color, NULL, 0);
    double abe = warp_error_pixel_percent(&F.out, &F.truth.color, NULL, 0, 20);
    preblended(b, false, &F.out2);
    double c = warp_psnr(&F.out2, &F.truth.color, NULL, 0), cs = warp_ssim(&F.out2, &F.truth.color, NULL, 0);
    double ce = warp_error_pixel_percent(&F.out2, &F.truth.color, NULL, 0, 20);
    preblended(b, true, &F.out2);
    double d = warp_psnr(&F.out2, &F.truth.color, NULL, 0), ds = warp_ssim(&F.out2, &F.truth.color, NULL, 0);
    double de = warp_error_pixel_percent(&F.out2, &F.truth.color, NULL, 0, 20);
    print_message("glass, 4 cm: A-buffer %.2f dB SSIM %.4f %.2f %%; pre-blended, opaque depth (7c) %.2f dB SSIM %.4f "
                  "%.2f %%; pre-blended, front depth (7d) %.2f dB SSIM %.4f %.2f %%\n",
                  ab, abs_, abe, c, cs, ce, d, ds, de);
    print_message("  %ld rays, %ld hit, %.2f nodes, %.2f leaves, %.2f fragment tests per ray, %ld early exits\n",
                  st.rays, st.rays_hit, (double)st.nodes / (double)st.rays, (double)st.leaves / (double)st.rays,
                  (double)st.fragment_tests / (double)st.rays, st.early_exits);
    assert_true(ab > c + 1.0 && ab > d + 1.0);
    assert_true(abs_ > cs && abs_ > ds);
    assert_true(ab > 30.0);
}

static void test_knobs(void **state)
{
    (void)state;
    warp_pose a = test_eye_at(0, -2 * D2R, 0, warp_v3(0, 1.6, 0));
    warp_pose b = test_eye_at(1.0 * D2R, -2 * D2R, 0, warp_v3(0.04, 1.62, -0.02));
    render_pair(a, b);
    warp_transparency_params p = warp_transparency_default_params();
    warp_transparency_stats stf = {0};
    hybrid(b, &p, &F.out, &stf);
    double full = warp_psnr(&F.out, &F.truth.color, NULL, 0);
    /* no extrusion: rays pass between the fragments of neighbouring pixels (micro holes, §5.3) */
    p.thickness = 0;
    warp_transparency_stats st0 = {0};
    hybrid(b, &p, &F.out2, &st0);
    double thin = warp_psnr(&F.out2, &F.truth.color, NULL, 0);
    /* a low opacity threshold stops after the first pane */
    p = warp_transparency_default_params();
    p.opacity_threshold = 0.3f;
    warp_transparency_stats st1 = {0};
    hybrid(b, &p, &F.out2, &st1);
    double early = warp_psnr(&F.out2, &F.truth.color, NULL, 0);
    print_message("thickness 0: %.2f dB (%ld hit rays), opacity 0.3: %.2f dB (%ld early exits); full %.2f dB (%ld hit "
                  "rays)\n", thin, st0.rays_hit, early, st1.early_exits, full, stf.rays_hit);
    /* Our leaf boxes are whole pixel squares at one depth, so zero thickness loses only the rays that cross a
     * slanted pane between two pixel depths: few, but never none. */
    assert_true(st0.rays_hit < stf.rays_hit && full >= thin);
    assert_true(full > early + 1.0);
    assert_true(st1.early_exits > 1000);
}

static void test_bad_input(void **state)
{
    (void)state;
    warp_pose a = test_eye_at(0, 0, 0, warp_v3(0, 1.6, 0));
    warp_pose b = test_eye_at(0, 0, 0, warp_v3(0.03, 1.6, 0));
    render_pair(a, b);
    warp_transparency_params p = warp_transparency_default_params();
    warp_transparency_setup s;
    warp_view nolayers = F.v;
    nolayers.layers = NULL;
    assert_non_null(warp_transparency_prepare(&s, &nolayers, &F.t, &F.cam, b, &p));
    p.thickness = NAN;
    assert_non_null(warp_transparency_prepare(&s, &F.v, &F.t, &F.cam, b, &p));
    p = warp_transparency_default_params();
    /* corrupt fragments (NaN, negative, infinite z) are counted by the tree build and skipped by the rays */
    int hit = 0;
    for (int i = 0; i < W * H && hit < 3; i++)
        if (F.glass.layers.count[i] > 0) F.glass.layers.frag[(size_t)i * MAXL].z = hit == 0 ? NAN : hit == 1 ? -1.0f : INFINITY, hit++;
    assert_int_equal(warp_minmax_build(&F.t, &F.glass.layers), 3);
    warp_transparency_stats st = {0};
    hybrid(b, &p, &F.out, &st);
    double q = warp_psnr(&F.out, &F.truth.color, NULL, 0);
    print_message("3 corrupt fragments: %.2f dB, %ld rays hit\n", q, st.rays_hit);
    assert_true(q > 30.0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_scene_setup),
        cmocka_unit_test(test_identity_and_pure_rotation),
        cmocka_unit_test(test_unblend_identity_round_trip),
        cmocka_unit_test(test_srgb_tables),
        cmocka_unit_test(test_abuffer_beats_preblended),
        cmocka_unit_test(test_knobs),
        cmocka_unit_test(test_bad_input),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
