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

static int setup(void **state)
{
    (void)state;
    F.cam = (warp_camera){W, H, 0.9, 0.9, 0.68, 0.68, 0.05, INFINITY};
    unsigned pl = SIM_PLANE_COLOR | SIM_PLANE_DEPTH;
    if (!sim_buffers_alloc(&F.src, W, H, pl, 1) || !sim_buffers_alloc(&F.truth, W, H, pl, 1)) return -1;
    if (!warp_image_f32_alloc(&F.inv, W, H) || !warp_image_rgba8_alloc(&F.warped, W, H) ||
        !warp_image_u8_alloc(&F.mask, W, H) || !warp_image_u8_alloc(&F.kind, W, H) ||
        !warp_image_rgba8_alloc(&F.out, W, H) || !warp_image_u8_alloc(&F.out_mask, W, H) ||
        !warp_image_u8_alloc(&F.score, W, H))
        return -1;
    if (!warp_holes_init(&F.ctx, W, H, 9)) return -1;
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    sim_buffers_free(&F.src);
    sim_buffers_free(&F.truth);
    warp_image_free(&F.inv);
    warp_image_free(&F.warped);
    warp_image_free(&F.mask);
    warp_image_free(&F.kind);
    warp_image_free(&F.out);
    warp_image_free(&F.out_mask);
    warp_image_free(&F.score);
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

static void check_claims(const score s[N_ALL], double lp_margin, double far_margin)
{
    /* 000 §5.2 / Table 2: the depth-aware low-pass fill beats stretching and rubber sheets */
    assert_true(s[I_LOWPASS].psnr > s[I_NEAREST].psnr + lp_margin);
    assert_true(s[I_LOWPASS].psnr > s[I_RUBBER].psnr + lp_margin);
    assert_true(s[I_LOWPASS].psnr > s[I_BACKGROUND].psnr);
    assert_true(s[I_LOWPASS].err < s[I_NEAREST].err && s[I_LOWPASS].err < s[I_RUBBER].err);
    /* 002 §3.3: the far side of the bidirectional scan beats the nearest-neighbour stretch */
    assert_true(s[I_FAR].psnr > s[I_NEAREST].psnr + far_margin);
    assert_true(s[I_FAR].err < s[I_NEAREST].err);
}

static void test_near_sideways(void **state)
{
    (void)state;
    make_holes("near", eye_at(0, -3 * D2R, warp_v3(0, 1.6, 0)), eye_at(1 * D2R, -3 * D2R, warp_v3(0.08, 1.62, 0)));
    assert_true(F.n_hidden > 1000);
    score s[N_ALL];
    score_all("near, 8 cm sideways", s);
    check_claims(s, 1.0, 1.0);
}

static void test_near_forward(void **state)
{
    (void)state;
    /* stepping towards the scene: a focus of expansion inside the image, epipolar lines radiate from it */
    make_holes("near", eye_at(0, -3 * D2R, warp_v3(0, 1.6, 0)), eye_at(0, -3 * D2R, warp_v3(0.03, 1.58, -0.15)));
    assert_false(F.epi.at_infinity);
    assert_true(F.epi.expansion);
    assert_true(F.epi.x > 0 && F.epi.x < W && F.epi.y > 0 && F.epi.y < H);
    assert_true(F.n_hidden > 300);
    score s[N_ALL];
    score_all("near, 15 cm forward", s);
    check_claims(s, 0.5, 0.5);
}

static void test_hairball(void **state)
{
    (void)state;
    make_holes("hairball", eye_at(0, 0, warp_v3(0, 1.6, 0)), eye_at(0, 0, warp_v3(0.06, 1.63, 0)));
    assert_true(F.n_hidden > 1000);
    score s[N_ALL];
    score_all("hairball, 6 cm", s);
    check_claims(s, 0.5, 0.5);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_near_sideways),
        cmocka_unit_test(test_near_forward),
        cmocka_unit_test(test_hairball),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
