/* SPDX-License-Identifier: MIT */
/* Hole fillers (warp_holes) against the simulator's ground truth: realistic disocclusion holes are cut out of a
 * truth render of the target view (target pixels whose 3D point the source view does not see: hidden behind a nearer
 * surface, or outside its frustum), filled, and scored on the hole pixels only. Checks 000 §5.2's claim (the
 * depth-aware low-pass fill beats stretching and rubber sheets) and 002 §3.3's (the far side of the epipolar scan
 * beats the nearest), plus the invariants: every hole filled, nothing else touched, no holes -> no change. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "platform/plat_png.h"
#include "sim/sim_scene.h"
#include "tests/support/test_images.h"
#include "warp/warp_camera.h"
#include "warp/warp_holes.h"
#include "warp/warp_metrics.h"
#include "warp/warp_view.h"

#define W 320
#define H 240

enum { KIND_HIDDEN = 1, KIND_OUTSIDE = 2 };
static const warp_rgba8 SENTINEL = {255, 0, 255, 255};

typedef struct {
    warp_camera cam;
    sim_buffers src, truth;
    warp_image_f32 inv;        /* warped (here: true) inverse depth of the target, garbage at holes */
    warp_image_rgba8 warped;   /* truth with the holes knocked out */
    warp_image_u8 mask;        /* WARP_MASK_HOLE at holes */
    warp_image_u8 kind;        /* KIND_* per hole pixel, 0 elsewhere */
    warp_image_rgba8 out;
    warp_image_u8 out_mask, score;
    warp_holes_ctx ctx;
    warp_epipole epi;
    long n_hidden, n_outside;
} fx;

static fx F;
static const test_image images[] = {TEST_F32(&F.inv), TEST_RGBA8(&F.warped),  TEST_U8(&F.mask), TEST_U8(&F.kind),
                                    TEST_RGBA8(&F.out), TEST_U8(&F.out_mask), TEST_U8(&F.score)};

static int setup(void **state)
{
    (void)state;
    F.cam = (warp_camera){W, H, 0.9, 0.9, 0.68, 0.68, 0.05, INFINITY};
    unsigned pl = SIM_PLANE_COLOR | SIM_PLANE_DEPTH;
    if (!sim_buffers_alloc(&F.src, W, H, pl, 1) || !sim_buffers_alloc(&F.truth, W, H, pl, 1)) return -1;
    if (!test_images_alloc(images, TEST_IMAGES_N(images), W, H)) return -1;
    if (!warp_holes_alloc(&F.ctx, W, H, 9)) return -1;
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    sim_buffers_free(&F.src);
    sim_buffers_free(&F.truth);
    test_images_free(images, TEST_IMAGES_N(images));
    warp_holes_free(&F.ctx);
    return 0;
}

static const double D2R = WARP_PI / 180.0;

static warp_pose eye_at(double yaw, double pitch, warp_vec3 p)
{
    warp_pose e = {warp_quat_from_ypr(yaw, pitch, 0), p};
    return e;
}

/* Renders the truth at target pose b and the source's depth at a, and cuts out what a forward warp of the source
 * could not have supplied: a target pixel is a hole when its surface point, seen from a, lies outside the source
 * image or behind the source's surface there (a disocclusion). */
static void make_holes(const char *scene, warp_pose a, warp_pose b)
{
    const sim_scene *s = sim_scene_find(scene);
    assert_non_null(s);
    sim_render(s, 0.0, a, &F.cam, SIM_PLANE_DEPTH, &F.src);
    sim_render(s, 0.0, b, &F.cam, SIM_PLANE_COLOR | SIM_PLANE_DEPTH, &F.truth);
    float mn, mx;
    assert_int_equal(warp_inverse_depth_from(&F.cam, WARP_DEPTH_LINEAR, &F.truth.depth, &F.inv, &mn, &mx), 0);
    warp_pose src_from_dst = warp_pose_relative(a, b);
    F.n_hidden = F.n_outside = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double u, v, xs, ys, inv_s;
            warp_camera_pixel_to_tan(&F.cam, x + 0.5, y + 0.5, &u, &v);
            double z = WARP_AT(&F.truth.depth, x, y);
            if (!isfinite(z)) z = 1e9; /* sky: a direction */
            warp_vec3 p = warp_pose_apply(src_from_dst, warp_v3(u * z, v * z, -z));
            uint8_t k = 0;
            if (!warp_camera_project(&F.cam, p, &xs, &ys, &inv_s) || xs < 0 || ys < 0 || xs >= W || ys >= H) {
                k = KIND_OUTSIDE;
            } else {
                double zs = WARP_AT(&F.src.depth, (int)xs, (int)ys);
                double src_inv = isfinite(zs) ? 1.0 / zs : 0.0;
                if (src_inv > inv_s * 1.03 + 1e-4) k = KIND_HIDDEN; /* the source sees something nearer there */
            }
            WARP_AT(&F.kind, x, y) = k;
            WARP_AT(&F.mask, x, y) = k ? WARP_MASK_HOLE : 0;
            WARP_AT(&F.warped, x, y) = k ? SENTINEL : WARP_AT(&F.truth.color, x, y);
            if (k) WARP_AT(&F.inv, x, y) = 50.0f; /* what a warp leaves there is not depth: must not be read */
            F.n_hidden += k == KIND_HIDDEN;
            F.n_outside += k == KIND_OUTSIDE;
        }
    F.epi = warp_epipole_from_poses(&F.cam, b, a);
}

typedef struct {
    double psnr, ssim, err;
    warp_holes_stats st;
} score;

/* Fills a copy of the warped image with params p, checks the invariants, scores the pixels of kind `kinds`. */
static score fill_and_score(const warp_holes_params *p, uint8_t kinds)
{
    score r;
    warp_image_rgba8_copy(&F.out, &F.warped);
    memcpy(F.out_mask.px, F.mask.px, (size_t)F.mask.stride * H);
    const char *err = warp_holes_fill(&F.ctx, &F.out, &F.out_mask, &F.inv, &F.epi, p, &r.st);
    assert_null(err);
    long holes = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            uint8_t k = WARP_AT(&F.kind, x, y);
            warp_rgba8 o = WARP_AT(&F.out, x, y), w = WARP_AT(&F.warped, x, y);
            if (k) {
                holes++;
                assert_int_equal(WARP_AT(&F.out_mask, x, y), WARP_MASK_HOLE | WARP_MASK_FILLED);
            } else { /* valid pixels: bit exact, mask untouched */
                assert_int_equal(WARP_AT(&F.out_mask, x, y), 0);
                assert_memory_equal(&o, &w, sizeof o);
            }
            WARP_AT(&F.score, x, y) = (k & kinds) ? 0 : 1;
        }
    assert_int_equal(r.st.holes, holes);
    assert_int_equal(r.st.filled, holes);
    r.psnr = warp_psnr(&F.out, &F.truth.color, &F.score, 1);
    r.ssim = warp_ssim(&F.out, &F.truth.color, &F.score, 1);
    r.err = warp_error_pixel_percent(&F.out, &F.truth.color, &F.score, 1, 20);
    return r;
}

static warp_holes_params params(warp_holes_method m)
{
    warp_holes_params p = warp_holes_default_params();
    p.method = m;
    return p;
}

static const warp_holes_method ALL[] = {WARP_HOLES_EPIPOLAR_FAR, WARP_HOLES_LOWPASS, WARP_HOLES_STRETCH_NEAREST,
                                        WARP_HOLES_STRETCH_BACKGROUND, WARP_HOLES_RUBBER_SHEET};
#define N_ALL ((int)(sizeof ALL / sizeof ALL[0]))

/* TEST_HOLES_DUMP=DIR writes the images of each case as PNGs into DIR (for looking at, not checked). */
static void dump(const char *label, const char *what, const warp_image_rgba8 *img)
{
    const char *dir = getenv("TEST_HOLES_DUMP");
    if (!dir) return;
    char path[512];
    snprintf(path, sizeof path, "%s/%s-%s.png", dir, label, what);
    for (char *c = path + strlen(dir) + 1; *c; c++)
        if (*c == ' ' || *c == ',') *c = '_';
    plat_png_write(path, img, true, NULL, 0);
}

/* Scores every method on the disocclusions of the current case; prints a results line per method. */
static void score_all(const char *label, score out[N_ALL])
{
    print_message("%s: %ld disoccluded + %ld outside hole pixels; epipole %s (%.1f, %.1f)%s\n", label, F.n_hidden,
                  F.n_outside, F.epi.at_infinity ? "direction" : (F.epi.expansion ? "expansion" : "contraction"),
                  F.epi.x, F.epi.y, "");
    dump(label, "truth", &F.truth.color);
    dump(label, "holes", &F.warped);
    for (int i = 0; i < N_ALL; i++) {
        warp_holes_params p = params(ALL[i]);
        out[i] = fill_and_score(&p, KIND_HIDDEN);
        dump(label, warp_holes_method_name(ALL[i]), &F.out);
        print_message("  %-18s disocclusions: PSNR %6.2f dB  SSIM %.4f  error px %5.1f %%  (%ld steps, %ld "
                      "fallbacks, %d levels)\n",
                      warp_holes_method_name(ALL[i]), out[i].psnr, out[i].ssim, out[i].err, out[i].st.search_steps,
                      out[i].st.fallbacks, out[i].st.levels);
    }
}

enum { I_FAR, I_LOWPASS, I_NEAREST, I_BACKGROUND, I_RUBBER };

/* Margins in dB: low-pass over nearest stretch and rubber sheet, epipolar far over nearest stretch, low-pass over
 * the background-side stretch (the strongest baseline: it already knows where the background is). */
static void check_claims(const score s[N_ALL], double lp_margin, double far_margin, double bg_margin)
{
    /* 000 §5.2 / Table 2: the depth-aware low-pass fill beats stretching and rubber sheets */
    assert_true(s[I_LOWPASS].psnr > s[I_NEAREST].psnr + lp_margin);
    assert_true(s[I_LOWPASS].psnr > s[I_RUBBER].psnr + lp_margin);
    assert_true(s[I_LOWPASS].psnr > s[I_BACKGROUND].psnr + bg_margin);
    assert_true(s[I_LOWPASS].ssim > s[I_NEAREST].ssim && s[I_LOWPASS].ssim > s[I_RUBBER].ssim);
    assert_true(s[I_LOWPASS].err < s[I_NEAREST].err && s[I_LOWPASS].err < s[I_RUBBER].err);
    /* 002 §3.3: the far side of the bidirectional scan beats the nearest-neighbour stretch */
    assert_true(s[I_FAR].psnr > s[I_NEAREST].psnr + far_margin);
    assert_true(s[I_FAR].err < s[I_NEAREST].err);
}

static void flip_epipole(void)
{
    if (F.epi.at_infinity) {
        F.epi.x = -F.epi.x, F.epi.y = -F.epi.y;
    } else {
        F.epi.expansion = !F.epi.expansion;
    }
}

static void test_near_sideways(void **state)
{
    (void)state;
    make_holes("near", eye_at(0, -3 * D2R, warp_v3(0, 1.6, 0)), eye_at(1 * D2R, -3 * D2R, warp_v3(0.08, 1.62, 0)));
    assert_true(F.n_hidden > 3000);
    score s[N_ALL];
    score_all("near, 8 cm sideways", s);
    check_claims(s, 3.0, 3.0, 1.0);

    /* Broken on purpose: the depth tests of 000 §5.2 are what make the low-pass fill work (a plain push-pull
     * averages the occluder into the hole). */
    warp_holes_params p = params(WARP_HOLES_LOWPASS);
    p.depth_aware = false;
    score plain = fill_and_score(&p, KIND_HIDDEN);
    print_message("  lowpass without the depth tests: %.2f dB, %.1f %% error px\n", plain.psnr, plain.err);
    assert_true(s[I_LOWPASS].psnr > plain.psnr + 2.0);
    assert_true(s[I_LOWPASS].err < plain.err / 2);

    /* A wrong epipole (contraction taken for expansion) wrecks the one-sided scan, which trusts it to point to the
     * background, but not the bidirectional one, which decides by depth (002 §3.3: why it scans both ways). */
    flip_epipole();
    p = params(WARP_HOLES_STRETCH_BACKGROUND);
    score wrong_bg = fill_and_score(&p, KIND_HIDDEN);
    p = params(WARP_HOLES_EPIPOLAR_FAR);
    score wrong_far = fill_and_score(&p, KIND_HIDDEN);
    print_message("  flipped epipole: stretch-background %.2f dB, epipolar-far %.2f dB\n", wrong_bg.psnr,
                  wrong_far.psnr);
    assert_true(wrong_bg.psnr < s[I_BACKGROUND].psnr - 5.0);
    assert_true(fabs(wrong_far.psnr - s[I_FAR].psnr) < 0.5);
}

static void test_near_forward(void **state)
{
    (void)state;
    /* stepping towards the scene: a focus of expansion inside the image, epipolar lines radiate from it */
    make_holes("near", eye_at(0, -3 * D2R, warp_v3(0, 1.6, 0)), eye_at(0, -3 * D2R, warp_v3(0.03, 1.58, -0.15)));
    assert_false(F.epi.at_infinity);
    assert_true(F.epi.expansion);
    assert_true(F.epi.x > 0 && F.epi.x < W && F.epi.y > 0 && F.epi.y < H);
    assert_true(F.n_hidden > 2000);
    score s[N_ALL];
    score_all("near, 15 cm forward", s);
    check_claims(s, 1.5, 2.0, 1.0);
}

static void test_hairball(void **state)
{
    (void)state;
    /* 0.9 m from the ball of strands: many small disocclusions between thin occluders at many depths */
    make_holes("hairball", eye_at(0, 0, warp_v3(0, 1.6, -0.6)), eye_at(0, 0, warp_v3(0.06, 1.63, -0.6)));
    assert_true(F.n_hidden > 2000);
    score s[N_ALL];
    score_all("hairball, 6 cm", s);
    check_claims(s, 1.0, 1.5, 0.5);
}

/* No holes: nothing changes, whatever the method; other mask bits are kept and do not count as holes. */
static void test_no_holes_unchanged(void **state)
{
    (void)state;
    make_holes("near", eye_at(0, 0, warp_v3(0, 1.6, 0)), eye_at(0, 0, warp_v3(0.05, 1.6, 0)));
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) WARP_AT(&F.mask, x, y) = (uint8_t)((x + y) % 3 == 0 ? WARP_MASK_EDGE : 0);
    warp_image_rgba8_copy(&F.warped, &F.truth.color);
    for (int i = 0; i < N_ALL; i++) {
        warp_holes_params p = params(ALL[i]);
        warp_image_rgba8_copy(&F.out, &F.warped);
        memcpy(F.out_mask.px, F.mask.px, (size_t)F.mask.stride * H);
        warp_holes_stats st;
        assert_null(warp_holes_fill(&F.ctx, &F.out, &F.out_mask, &F.inv, &F.epi, &p, &st));
        assert_int_equal(st.holes, 0);
        assert_int_equal(st.filled, 0);
        assert_memory_equal(F.out.px, F.warped.px, (size_t)F.out.stride * H * sizeof *F.out.px);
        assert_memory_equal(F.out_mask.px, F.mask.px, (size_t)F.mask.stride * H);
    }
}

/* Rows split in any order give the same bytes as one call (threads may split them). */
static void test_row_split(void **state)
{
    (void)state;
    make_holes("near", eye_at(0, -3 * D2R, warp_v3(0, 1.6, 0)), eye_at(1 * D2R, -3 * D2R, warp_v3(0.08, 1.62, 0)));
    warp_image_rgba8 whole;
    warp_image_u8 whole_mask;
    assert_true(warp_image_rgba8_alloc(&whole, W, H) && warp_image_u8_alloc(&whole_mask, W, H));
    static const int cuts[] = {H, 201, 200, 131, 77, 76, 3, 0};
    for (int i = 0; i < N_ALL; i++) {
        warp_holes_params p = params(ALL[i]);
        warp_image_rgba8_copy(&whole, &F.warped);
        memcpy(whole_mask.px, F.mask.px, (size_t)F.mask.stride * H);
        assert_null(warp_holes_fill(&F.ctx, &whole, &whole_mask, &F.inv, &F.epi, &p, NULL));
        warp_image_rgba8_copy(&F.out, &F.warped);
        memcpy(F.out_mask.px, F.mask.px, (size_t)F.mask.stride * H);
        warp_holes_stats st = {0};
        assert_null(warp_holes_prepare(&F.ctx, &F.out, &F.out_mask, &F.inv, &F.epi, &p, &st));
        for (int k = 0; cuts[k + 1] || k == 0 || cuts[k] != 0; k++) { /* bottom chunk first */
            warp_holes_fill_rows(&F.ctx, &F.out, &F.out_mask, cuts[k + 1], cuts[k], &st);
            if (cuts[k + 1] == 0) break;
        }
        assert_int_equal(st.holes, F.n_hidden + F.n_outside);
        assert_memory_equal(F.out.px, whole.px, (size_t)F.out.stride * H * sizeof *F.out.px);
        assert_memory_equal(F.out_mask.px, whole_mask.px, (size_t)F.mask.stride * H);
    }
    warp_image_free(&whole);
    warp_image_free(&whole_mask);
}

/* An image that is all hole still comes back filled (with `empty`), and a lone valid pixel fills everything. */
static void test_all_hole_and_single_pixel(void **state)
{
    (void)state;
    for (int i = 0; i < N_ALL; i++) {
        warp_holes_params p = params(ALL[i]);
        p.empty = (warp_rgba8){1, 2, 3, 255};
        warp_image_rgba8_fill(&F.out, SENTINEL);
        warp_image_u8_fill(&F.out_mask, WARP_MASK_HOLE);
        warp_holes_stats st;
        assert_null(warp_holes_fill(&F.ctx, &F.out, &F.out_mask, &F.inv, &F.epi, &p, &st));
        assert_int_equal(st.filled, (long)W * H);
        assert_int_equal(st.fallbacks, (long)W * H);
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                warp_rgba8 c = WARP_AT(&F.out, x, y);
                assert_true(c.r == 1 && c.g == 2 && c.b == 3);
                assert_int_equal(WARP_AT(&F.out_mask, x, y), WARP_MASK_HOLE | WARP_MASK_FILLED);
            }
        /* one valid pixel, off every row and column of most holes: all take its colour */
        warp_image_rgba8_fill(&F.out, SENTINEL);
        warp_image_u8_fill(&F.out_mask, WARP_MASK_HOLE);
        WARP_AT(&F.out, 100, 50) = (warp_rgba8){10, 200, 30, 255};
        WARP_AT(&F.out_mask, 100, 50) = 0;
        WARP_AT(&F.inv, 100, 50) = 0.5f;
        assert_null(warp_holes_fill(&F.ctx, &F.out, &F.out_mask, &F.inv, &F.epi, &p, &st));
        assert_int_equal(st.filled, (long)W * H - 1);
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                warp_rgba8 c = WARP_AT(&F.out, x, y);
                assert_true(c.r == 10 && c.g == 200 && c.b == 30);
            }
    }
}

static void test_bad_input(void **state)
{
    (void)state;
    make_holes("near", eye_at(0, -3 * D2R, warp_v3(0, 1.6, 0)), eye_at(1 * D2R, -3 * D2R, warp_v3(0.08, 1.62, 0)));
    warp_holes_params p = params(WARP_HOLES_EPIPOLAR_FAR);
    warp_image_rgba8_copy(&F.out, &F.warped);
    memcpy(F.out_mask.px, F.mask.px, (size_t)F.mask.stride * H);
    warp_holes_stats st;
    /* errors name the problem and write nothing */
    assert_non_null(warp_holes_fill(&F.ctx, &F.out, &F.out_mask, NULL, &F.epi, &p, &st));
    warp_image_rgba8 small = F.out;
    small.w = W - 1;
    const char *e = warp_holes_fill(&F.ctx, &small, &F.out_mask, &F.inv, &F.epi, &p, &st);
    assert_non_null(e);
    assert_non_null(strstr(e, "size"));
    p.method = WARP_HOLES_LOWPASS;
    p.kernel = 3;
    assert_non_null(warp_holes_fill(&F.ctx, &F.out, &F.out_mask, &F.inv, &F.epi, &p, &st));
    p.kernel = 4;
    p.max_levels = 12; /* more than the scratch has */
    assert_non_null(warp_holes_fill(&F.ctx, &F.out, &F.out_mask, &F.inv, &F.epi, &p, &st));
    p.max_levels = 9;
    p.level_bias = 1000;
    assert_non_null(warp_holes_fill(&F.ctx, &F.out, &F.out_mask, &F.inv, &F.epi, &p, &st));
    p.level_bias = 0;
    p.method = (warp_holes_method)42;
    assert_non_null(warp_holes_fill(&F.ctx, &F.out, &F.out_mask, &F.inv, &F.epi, &p, &st));
    warp_epipole nan_e = F.epi;
    nan_e.x = NAN;
    p = params(WARP_HOLES_EPIPOLAR_FAR);
    assert_non_null(warp_holes_fill(&F.ctx, &F.out, &F.out_mask, &F.inv, &nan_e, &p, &st));
    assert_memory_equal(F.out.px, F.warped.px, (size_t)F.out.stride * H * sizeof *F.out.px);
    /* a huge search budget is only bounded by the image */
    p.max_search = 0x7fffffff;
    assert_null(warp_holes_fill(&F.ctx, &F.out, &F.out_mask, &F.inv, &F.epi, &p, &st));
    assert_int_equal(st.filled, F.n_hidden + F.n_outside);
    warp_image_rgba8_copy(&F.out, &F.warped);
    memcpy(F.out_mask.px, F.mask.px, (size_t)F.mask.stride * H);
    /* depth is optional for the methods that do not use it */
    p.method = WARP_HOLES_RUBBER_SHEET;
    assert_null(warp_holes_fill(&F.ctx, &F.out, &F.out_mask, NULL, &F.epi, &p, &st));
    assert_int_equal(st.filled, F.n_hidden + F.n_outside);
    /* bad depth at valid pixels is counted and taken as sky, not propagated */
    WARP_AT(&F.inv, 3, 3) = NAN;
    WARP_AT(&F.inv, 4, 3) = -1.0f;
    WARP_AT(&F.inv, 5, 3) = INFINITY;
    for (int x = 3; x <= 5; x++) WARP_AT(&F.mask, x, 3) = 0;
    p = params(WARP_HOLES_LOWPASS);
    warp_image_rgba8_copy(&F.out, &F.warped);
    memcpy(F.out_mask.px, F.mask.px, (size_t)F.mask.stride * H);
    assert_null(warp_holes_fill(&F.ctx, &F.out, &F.out_mask, &F.inv, &F.epi, &p, &st));
    assert_int_equal(st.bad_depth, 3);
    assert_int_equal(st.filled, F.n_hidden + F.n_outside - (WARP_AT(&F.kind, 3, 3) != 0) -
                                    (WARP_AT(&F.kind, 4, 3) != 0) - (WARP_AT(&F.kind, 5, 3) != 0));
}

/* The epipole and the direction of motion agree with the 3D warp itself: a near and a far point on one source ray
 * land on the target's epipolar line, the near one displaced the way warp_epipole_direction says. */
static void test_epipole_geometry(void **state)
{
    (void)state;
    warp_pose a = eye_at(0.1, -0.05, warp_v3(0.2, 1.5, 0.1));
    const warp_vec3 moves[] = {warp_v3(0.1, 0, 0), warp_v3(0, 0.05, -0.2), warp_v3(0.02, -0.03, 0.2),
                               warp_v3(-0.07, 0.04, 0.01)};
    for (int m = 0; m < 8; m++) { /* pure translations, then the same with a head turn */
        warp_pose b = {a.q, warp_v3_add(a.p, warp_quat_rotate(a.q, moves[m % 4]))};
        if (m >= 4) b.q = warp_quat_from_ypr(0.13, -0.02, 0.01);
        warp_epipole e = warp_epipole_from_poses(&F.cam, b, a);
        warp_pose dst_from_src = warp_pose_relative(b, a);
        int ok = 0;
        for (int k = 0; k < 20; k++) {
            double u = -0.6 + 0.06 * k, v = 0.4 - 0.04 * k, xn, yn, xf, yf, iz;
            assert_true(warp_camera_project(&F.cam, warp_pose_apply(dst_from_src, warp_v3(u * 8, v * 8, -8)), &xf,
                                            &yf, &iz));
            assert_true(warp_camera_project(&F.cam, warp_pose_apply(dst_from_src, warp_v3(u * .6, v * .6, -.6)),
                                            &xn, &yn, &iz));
            double dx, dy, mx = xn - xf, my = yn - yf, n = hypot(mx, my);
            assert_true(warp_epipole_direction(&e, xf, yf, &dx, &dy));
            assert_true(n > 0.5);
            assert_true((mx * dx + my * dy) / n > 0.999); /* along the line, the right way */
            ok++;
        }
        assert_int_equal(ok, 20);
        if (m == 0) assert_true(e.at_infinity || fabs(e.x) > 1e4); /* sideways: parallel lines */
        if (m == 1) assert_true(!e.at_infinity && e.expansion);     /* forward: focus of expansion */
        if (m == 2) assert_true(!e.at_infinity && !e.expansion);    /* backward: focus of contraction */
    }
    warp_epipole none = warp_epipole_from_poses(&F.cam, a, a); /* no translation: rows */
    double dx, dy;
    assert_false(warp_epipole_direction(&none, 10, 10, &dx, &dy));
    assert_true(dx == 1 && dy == 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_near_sideways),
        cmocka_unit_test(test_near_forward),
        cmocka_unit_test(test_hairball),
        cmocka_unit_test(test_no_holes_unchanged),
        cmocka_unit_test(test_row_split),
        cmocka_unit_test(test_all_hole_and_single_pixel),
        cmocka_unit_test(test_bad_input),
        cmocka_unit_test(test_epipole_geometry),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
