/* SPDX-License-Identifier: MIT */
/* Numerical stability of the hard cases: depth at near, far and infinity, reversed-Z, points behind either camera,
 * w near 0, the epipole inside the image and on a pixel centre, zero translation, 180-degree and view-axis
 * rotations, quaternions near +-1 and unnormalised, gyro at 0 and 2000 deg/s, IMU time jumps, camera positions 10 km
 * from the origin, lenses whose inverse has no solution, 16-bit depth, NaN/Inf in every input; plus randomized
 * round-trip properties with fixed seeds. Each case asserts finite output, bounded error against a double-precision
 * reference, and no crash (ASan/UBSan in `make asan`). Run alone with `make stability`. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "drivers/drv_frames.h"
#include "runtime/rt_config.h"
#include "runtime/rt_fusion.h"
#include "sim/sim_scene.h"
#include "tests/support/test_scene.h"
#include "tests/support/test_util.h"
#include "warp/warp_camera.h"
#include "warp/warp_lens.h"
#include "warp/warp_mesh.h"
#include "warp/warp_metrics.h"
#include "warp/warp_raytrace.h"
#include "warp/warp_reproject.h"
#include "warp/warp_view.h"

#define W 160
#define H 120
#define DEG (WARP_PI / 180.0)
#define MS 1000000LL

static warp_camera cam(void) { return (warp_camera){W, H, 1.0, 1.0, 0.75, 0.75, 0.05, INFINITY}; }

static bool image_finite_and_written(const warp_image_rgba8 *img)
{
    /* RGBA8 cannot hold NaN; "finite" for an image means every pixel was written (alpha 255, not the sentinel) */
    for (int y = 0; y < img->h; y++)
        for (int x = 0; x < img->w; x++)
            if (WARP_AT(img, x, y).a != 255) return false;
    return true;
}

/* ---- fixture: a source render with depth and its truth ---- */

typedef struct {
    warp_camera c;
    test_pair p; /* src = p.a, truth = p.b */
} fx;

static void fx_init(fx *f)
{
    memset(f, 0, sizeof *f);
    f->c = cam();
    assert_true(test_pair_alloc(&f->p, W, H, SIM_PLANE_COLOR | SIM_PLANE_DEPTH));
}

static void fx_free(fx *f) { test_pair_free(&f->p); }

static void fx_render(fx *f, const char *scene, warp_pose a, warp_pose b)
{
    test_pair_render(&f->p, scene, &f->c, a, b);
}

static void raytrace(fx *f, warp_pose to, warp_image_rgba8 *out)
{
    warp_raytrace_params p = warp_raytrace_default_params();
    warp_raytrace_setup s;
    assert_null(warp_raytrace_prepare(&s, &f->p.v, &f->c, to, &p));
    warp_image_rgba8_fill(out, (warp_rgba8){0, 0, 0, 0});
    warp_raytrace_rows(&s, out, &f->p.mask, 0, H, NULL);
}

static void reproject(fx *f, warp_quat to, warp_image_rgba8 *out)
{
    warp_mat3 h = warp_reproject_homography(&f->p.v, &f->c, to);
    warp_image_rgba8_fill(out, (warp_rgba8){0, 0, 0, 0});
    warp_reproject_rows(&f->p.v, &h, out, &f->p.mask, 0, H);
}

/* ---- depth encodings at the limits ---- */

static void test_depth_limits_all_encodings(void **state)
{
    (void)state;
    /* near plane, far plane, sky, and values just around them, in every encoding, against the double formula */
    warp_camera c = cam();
    for (int finite_far = 0; finite_far < 2; finite_far++) {
        c.far_z = finite_far ? 1000.0 : INFINITY;
        const double zs[] = {c.near_z, c.near_z * (1 + 1e-7), 0.5, 10, 999.9, finite_far ? 1000.0 : 1e12, INFINITY};
        warp_image_f32 d, inv;
        assert_true(warp_image_f32_alloc(&d, 7, 1) && warp_image_f32_alloc(&inv, 7, 1));
        for (int enc = 0; enc < 3; enc++) {
            for (int i = 0; i < 7; i++) {
                double z = zs[i], v;
                /* with a finite far plane, window depth cannot say "beyond far": sky is stored as the far plane */
                if (enc != WARP_DEPTH_LINEAR && finite_far && isinf(z)) z = c.far_z;
                if (enc == WARP_DEPTH_LINEAR) v = z;
                else {
                    /* window depth of z: standard d = f(z - n) / (z (f - n)), infinite far: 1 - n/z; reversed 1 - d */
                    double dstd = isinf(c.far_z) ? 1 - c.near_z / z : c.far_z * (z - c.near_z) / (z * (c.far_z - c.near_z));
                    v = enc == WARP_DEPTH_STANDARD ? dstd : 1 - dstd;
                }
                WARP_AT(&d, i, 0) = (float)v;
            }
            float lo, hi;
            long bad = warp_inverse_depth_from(&c, (warp_depth_encoding)enc, &d, &inv, &lo, &hi);
            if (bad) fail_msg("enc %d far %g: %ld values refused", enc, c.far_z, bad);
            for (int i = 0; i < 7; i++) {
                float iz = WARP_AT(&inv, i, 0);
                assert_true(isfinite(iz) && iz >= 0);
                double zi = (enc != WARP_DEPTH_LINEAR && finite_far && isinf(zs[i])) ? c.far_z : zs[i];
                double want = isinf(zi) ? 0 : 1 / zi;
                /* float window depth near d = 1 loses digits (standard encoding): far values are bounded by what
                 * float32 d can resolve, i.e. |d 1/z| <= 2^-24 / near */
                double tol = enc == WARP_DEPTH_LINEAR ? 1e-6 * want + 1e-12 : 2e-7 / c.near_z * 4 + 1e-6 * want;
                if (fabs(iz - want) > tol)
                    fail_msg("enc %d far %g z %g: 1/z %g, want %g (tol %g)", enc, c.far_z, zs[i], iz, want, tol);
            }
            assert_true(lo >= 0 && hi <= 1 / c.near_z * 1.0001);
        }
        warp_image_free(&d);
        warp_image_free(&inv);
    }
}

static void test_depth_nan_inf_negative_counted(void **state)
{
    (void)state;
    warp_camera c = cam();
    warp_image_f32 d, inv;
    assert_true(warp_image_f32_alloc(&d, 6, 1) && warp_image_f32_alloc(&inv, 6, 1));
    const float vals[6] = {NAN, -1.0f, -INFINITY, 0.01f /* nearer than near */, 1.0f, INFINITY};
    for (int i = 0; i < 6; i++) WARP_AT(&d, i, 0) = vals[i];
    float lo, hi;
    long bad = warp_inverse_depth_from(&c, WARP_DEPTH_LINEAR, &d, &inv, &lo, &hi);
    assert_int_equal(bad, 3); /* nearer than near is not bad: it is taken as near (issue #21) */
    for (int i = 0; i < 6; i++) assert_true(isfinite(WARP_AT(&inv, i, 0)));
    assert_true(fabsf(WARP_AT(&inv, 3, 0) - (float)(1 / c.near_z)) < 1e-4f);
    assert_true(fabs(WARP_AT(&inv, 4, 0) - 1.0f) < 1e-7);
    assert_true(WARP_AT(&inv, 5, 0) == 0);
    /* window encodings: values outside [0, 1] are bad too */
    WARP_AT(&d, 0, 0) = 1.5f;
    WARP_AT(&d, 1, 0) = -0.2f;
    bad = warp_inverse_depth_from(&c, WARP_DEPTH_REVERSED, &d, &inv, &lo, &hi);
    assert_true(bad >= 2);
    for (int i = 0; i < 6; i++) assert_true(isfinite(WARP_AT(&inv, i, 0)));
    warp_image_free(&d);
    warp_image_free(&inv);
}

static void test_sky_only_frame(void **state)
{
    (void)state;
    /* a frame that is all sky (inverse depth 0 everywhere): raytrace degenerates to rotation reprojection */
    fx f;
    fx_init(&f);
    warp_pose a = {warp_quat_from_ypr(0.2, 0.1, 0), warp_v3(0, 1.6, 0)};
    fx_render(&f, "room", a, a);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) WARP_AT(&f.p.inv, x, y) = 0;
    f.p.v.inv_depth_min = f.p.v.inv_depth_max = 0;
    warp_pose b = {warp_quat_from_ypr(0.25, 0.1, 0.05), warp_v3(0.05, 1.6, -0.03)};
    raytrace(&f, b, &f.p.out);
    reproject(&f, b.q, &f.p.out2);
    assert_true(image_finite_and_written(&f.p.out));
    double p = warp_psnr(&f.p.out, &f.p.out2, NULL, 0);
    if (p < 45) fail_msg("sky-only raytrace vs rotation: %.2f dB", p);
    fx_free(&f);
}

/* ---- geometry at the edges ---- */

static void test_points_behind_cameras_and_w_near_zero(void **state)
{
    (void)state;
    fx f;
    fx_init(&f);
    warp_pose a = {warp_quat_identity(), warp_v3(0, 1.6, 0)};
    fx_render(&f, "near", a, a);
    /* target turned 90 degrees (w = 0 exactly on a column), 135 and 180 degrees: everything is fringe or seen,
     * nothing unwritten, and no pixel samples outside the source (ASan) */
    const double yaws[] = {90, 90 + 1e-9, 135, 180, -179.999};
    for (size_t i = 0; i < sizeof yaws / sizeof yaws[0]; i++) {
        warp_pose b = {warp_quat_from_ypr(yaws[i] * DEG, 0, 0), warp_v3(0.02, 1.6, 0)};
        reproject(&f, b.q, &f.p.out);
        assert_true(image_finite_and_written(&f.p.out));
        raytrace(&f, b, &f.p.out);
        assert_true(image_finite_and_written(&f.p.out));
        long fringe = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) fringe += (WARP_AT(&f.p.mask, x, y) & WARP_MASK_FRINGE) != 0;
        if (yaws[i] >= 135 || yaws[i] < -170) assert_int_equal(fringe, (long)W * H); /* the source saw none of it */
    }
    /* the camera's own projection of points behind it */
    double x, y, iz;
    assert_false(warp_camera_project(&f.c, warp_v3(0, 0, 1), &x, &y, &iz));
    assert_false(warp_camera_project(&f.c, warp_v3(1, 1, 0), &x, &y, &iz));
    assert_true(warp_camera_project(&f.c, warp_v3(0, 0, -1e-300), &x, &y, &iz) ? isfinite(x) && isfinite(y) : true);
    fx_free(&f);
}

static void test_epipole_inside_image_and_on_pixel_centre(void **state)
{
    (void)state;
    /* moving straight forward puts the epipole in the image; with a symmetric camera it lands on the image
     * centre, which for an even size is a pixel corner, so shift the principal point by half a pixel to put it
     * exactly on a pixel centre too */
    for (int centred = 0; centred < 2; centred++) {
        fx f;
        fx_init(&f);
        if (centred) {
            double px = 1.0 / (W / (f.c.tan_left + f.c.tan_right));
            f.c.tan_left += px / 2;
            f.c.tan_right -= px / 2;
        }
        warp_pose a = {warp_quat_identity(), warp_v3(0, 1.6, 0)};
        warp_pose b = {warp_quat_identity(), warp_v3(0, 1.6, -0.06)}; /* 6 cm forward */
        fx_render(&f, "near", a, b);
        raytrace(&f, b, &f.p.out);
        assert_true(image_finite_and_written(&f.p.out));
        reproject(&f, b.q, &f.p.out2);
        double pr = warp_psnr(&f.p.out, &f.p.b.color, NULL, 0), pn = warp_psnr(&f.p.out2, &f.p.b.color, NULL, 0);
        print_message("epipole %s: raytrace %.2f dB, rotation-only %.2f dB\n", centred ? "on a pixel centre" : "at a corner",
                      pr, pn);
        assert_true(pr > pn + 2); /* bounded error: the depth warp still does its job around the epipole */
        /* the pixel at the epipole itself does not move: it must equal the source there */
        int ex = W / 2, ey = H / 2;
        if (centred) {
            warp_rgba8 o = WARP_AT(&f.p.out, ex, ey), s = WARP_AT(&f.p.a.color, ex, ey);
            assert_true(abs(o.r - s.r) + abs(o.g - s.g) + abs(o.b - s.b) <= 6);
        }
        fx_free(&f);
    }
}

static void test_zero_translation_matches_rotation(void **state)
{
    (void)state;
    /* the epipole is undefined with no translation: the raytrace must reduce to rotation reprojection */
    fx f;
    fx_init(&f);
    warp_pose a = {warp_quat_from_ypr(0.1, 0.05, 0), warp_v3(0.1, 1.6, 0.2)};
    warp_pose b = {warp_quat_from_ypr(0.16, 0.02, 0.03), a.p};
    fx_render(&f, "near", a, b);
    raytrace(&f, b, &f.p.out);
    reproject(&f, b.q, &f.p.out2);
    assert_true(image_finite_and_written(&f.p.out));
    assert_true(warp_psnr(&f.p.out, &f.p.out2, &f.p.mask, WARP_MASK_FRINGE) > 40);
    fx_free(&f);
}

static void test_view_axis_and_half_turn_rotations(void **state)
{
    (void)state;
    /* rotations about the view axis, including 180 degrees: the reprojection equals the analytic pixel rotation */
    fx f;
    fx_init(&f);
    warp_pose a = {warp_quat_identity(), warp_v3(0, 1.6, 0)};
    const double rolls[] = {1e-9, 1, 45, 90, 179.9999, 180};
    for (size_t i = 0; i < sizeof rolls / sizeof rolls[0]; i++) {
        warp_pose b = {warp_quat_from_ypr(0, 0, rolls[i] * DEG), a.p};
        fx_render(&f, "room", a, b);
        reproject(&f, b.q, &f.p.out);
        assert_true(image_finite_and_written(&f.p.out));
        double p = warp_psnr(&f.p.out, &f.p.b.color, &f.p.mask, WARP_MASK_FRINGE);
        if (p < 28) fail_msg("roll %g: %.2f dB", rolls[i], p);
    }
    /* 180 degree quaternions are +-(0, axis): the homography must not depend on the sign */
    warp_quat q = warp_quat_from_axis_angle(warp_v3(0, 0, 1), WARP_PI), nq = {-q.w, -q.x, -q.y, -q.z};
    warp_mat3 h1 = warp_reproject_homography(&f.p.v, &f.c, q), h2 = warp_reproject_homography(&f.p.v, &f.c, nq);
    for (int r = 0; r < 3; r++)
        for (int cidx = 0; cidx < 3; cidx++) assert_true(fabs(h1.m[r][cidx] - h2.m[r][cidx]) < 1e-9);
    fx_free(&f);
}

/* ---- quaternions ---- */

static void test_quaternions_near_identity_and_unnormalised(void **state)
{
    (void)state;
    /* q and -q (w near +-1), tiny angles, and slerp between antipodal representations */
    warp_quat a = warp_quat_from_axis_angle(warp_v3(0.3, 1, 0.2), 1e-9), na = {-a.w, -a.x, -a.y, -a.z};
    assert_true(warp_quat_angle_between(a, na) < 1e-7);
    warp_quat s = warp_quat_slerp(a, na, 0.5);
    assert_true(fabs(warp_quat_norm(s) - 1) < 1e-12 && warp_quat_angle_between(s, a) < 1e-7);
    warp_vec3 l = warp_quat_log(warp_quat_identity());
    assert_true(l.x == 0 && l.y == 0 && l.z == 0);
    warp_quat e = warp_quat_exp(warp_v3(1e-300, 0, 0));
    assert_true(warp_quat_isfinite(e) && fabs(warp_quat_norm(e) - 1) < 1e-15);
    /* unnormalised input is normalised or refused, never propagated as NaN */
    warp_quat out;
    const warp_quat in[] = {{2, 0, 0, 0}, {1e-200, 1e-200, 0, 0}, {1e200, 1e200, 0, 0}, {0, 0, 0, 0}, {NAN, 0, 0, 1},
                            {INFINITY, 0, 0, 0}};
    /* a norm of 1e-200 is "too small to trust" and 1e200 overflows the norm: both refused like zero (documented),
     * with identity written, so a caller that ignores the result still gets a rotation */
    const bool ok[] = {true, false, false, false, false, false};
    for (size_t i = 0; i < sizeof in / sizeof in[0]; i++) {
        bool r = warp_quat_normalize(in[i], &out);
        if (r != ok[i]) fail_msg("normalize case %zu: %d", i, r);
        assert_true(warp_quat_isfinite(out) && fabs(warp_quat_norm(out) - 1) < 1e-12);
    }
    /* a frame whose pose quaternion is off unit length is rejected, not warped */
    drv_frame fr;
    assert_true(drv_frame_alloc(&fr, 16, 16, DRV_PLANE_COLOR, 1));
    fr.planes = DRV_PLANE_COLOR;
    for (int ei = 0; ei < 2; ei++) {
        fr.cam[ei] = (warp_camera){16, 16, 1, 1, 1, 1, 0.05, INFINITY};
        fr.eye_pose[ei] = warp_pose_identity();
    }
    assert_int_equal(drv_frame_validate(&fr), DRV_FRAME_OK);
    fr.eye_pose[1].q = (warp_quat){1.01, 0, 0, 0};
    assert_int_equal(drv_frame_validate(&fr), DRV_FRAME_ERR_BAD_POSE);
    fr.eye_pose[1].q = (warp_quat){NAN, 0, 0, 0};
    assert_int_equal(drv_frame_validate(&fr), DRV_FRAME_ERR_BAD_POSE);
    fr.eye_pose[1] = warp_pose_identity();
    fr.eye_pose[0].p.y = INFINITY;
    assert_int_equal(drv_frame_validate(&fr), DRV_FRAME_ERR_BAD_POSE);
    drv_frame_free(&fr);
}

/* ---- tracking ---- */

static drv_imu_sample imu_at(int64_t t, warp_vec3 w, warp_quat q)
{
    /* upright gravity seen in the head frame */
    warp_vec3 g = warp_quat_rotate(warp_quat_conj(q), warp_v3(0, 9.81, 0));
    drv_imu_sample s = {.t_ns = t, .gyro = {w.x, w.y, w.z}, .accel = {g.x, g.y, g.z}};
    return s;
}

static void test_gyro_extremes(void **state)
{
    (void)state;
    /* 0 and 2000 deg/s about a tilted axis for 1 s at 1 kHz: integration matches the analytic rotation */
    const double rates[] = {0, 2000 * DEG};
    for (int k = 0; k < 2; k++) {
        rt_fusion *f = calloc(1, sizeof *f);
        rt_fusion_params p = rt_fusion_default_params();
        p.tilt_gain = 0; /* pure integration: what the gyro alone must get right */
        p.bias_gain = 0;
        rt_fusion_init(f, &p);
        warp_vec3 axis = warp_v3(0.2, 1, 0.1);
        axis = warp_v3_scale(axis, 1 / warp_v3_norm(axis));
        warp_vec3 w = warp_v3_scale(axis, rates[k]);
        int64_t t0 = 1000 * 1000 * MS;
        warp_quat q = warp_quat_identity();
        for (int i = 0; i <= 1000; i++) {
            warp_quat truth = warp_quat_exp(warp_v3_scale(w, i * 1e-3));
            drv_imu_sample s = imu_at(t0 + i * MS, w, truth);
            rt_fusion_result r = rt_fusion_update(f, &s);
            assert_true(r == RT_FUSION_OK);
            q = truth;
        }
        rt_fusion_state st;
        assert_true(rt_fusion_latest(f, &st));
        assert_true(warp_quat_isfinite(st.q) && fabs(warp_quat_norm(st.q) - 1) < 1e-12);
        double err = warp_quat_angle_between(st.q, q) / DEG;
        print_message("gyro %.0f deg/s for 1 s: error %.2e deg\n", rates[k] / DEG, err);
        /* the first sample sets tilt from gravity with yaw 0; about a vertical-ish axis the yaw is then relative */
        assert_true(err < (k ? 0.5 : 1e-6));
        /* prediction from 2000 deg/s stays finite and is clamped */
        warp_quat pq = rt_fusion_predict(f, &st, st.t_ns + 1000 * MS);
        assert_true(warp_quat_isfinite(pq));
        free(f);
    }
}

static void test_imu_time_jumps_and_repeats(void **state)
{
    (void)state;
    rt_fusion *f = calloc(1, sizeof *f);
    rt_fusion_params p = rt_fusion_default_params();
    rt_fusion_init(f, &p);
    int64_t t = 5000 * MS;
    warp_quat q = warp_quat_identity();
    warp_vec3 w0 = {0, 0, 0};
    drv_imu_sample s = imu_at(t, w0, q);
    assert_int_equal(rt_fusion_update(f, &s), RT_FUSION_OK);
    /* forward, repeated, backwards, 10 s gap, normal, and a gap of centuries */
    const int64_t jumps[] = {MS, 0, -MS, 10 * 1000 * MS, MS, INT64_MAX / 4};
    for (size_t i = 0; i < sizeof jumps / sizeof jumps[0]; i++) {
        t += jumps[i];
        s = imu_at(t, w0, q);
        rt_fusion_update(f, &s);
        rt_fusion_state st;
        assert_true(rt_fusion_latest(f, &st));
        assert_true(warp_quat_isfinite(st.q) && fabs(warp_quat_norm(st.q) - 1) < 1e-12);
        warp_quat at;
        assert_true(rt_fusion_at(f, t - 3 * MS, &at) && warp_quat_isfinite(at));
    }
    assert_true(rt_fusion_rejected(f, RT_FUSION_TIME_REPEAT) >= 2);
    assert_true(rt_fusion_rejected(f, RT_FUSION_TIME_JUMP) >= 2);
    free(f);
}

/* ---- far from the origin ---- */

static void test_ten_km_from_origin(void **state)
{
    (void)state;
    /* the same relative head motion at the origin and 10 km away warps to the same image: positions are double
     * and the warps subtract poses before going to float */
    fx f;
    fx_init(&f);
    warp_pose a = {warp_quat_from_ypr(0.2, 0, 0), warp_v3(0, 1.6, 0)};
    warp_pose b = {warp_quat_from_ypr(0.23, 0.01, 0), warp_v3(0.03, 1.61, -0.01)};
    fx_render(&f, "near", a, b);
    raytrace(&f, b, &f.p.out);
    const warp_vec3 far = {10000.0, 3.0, -10000.0};
    f.p.v.pose.p = warp_v3_add(a.p, far);
    warp_pose b2 = b;
    b2.p = warp_v3_add(b.p, far);
    raytrace(&f, b2, &f.p.out2);
    long diff = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            warp_rgba8 p = WARP_AT(&f.p.out, x, y), q = WARP_AT(&f.p.out2, x, y);
            diff += abs(p.r - q.r) + abs(p.g - q.g) + abs(p.b - q.b) > 3;
        }
    assert_true(diff <= W * H / 1000); /* at most 0.1 % of pixels differ visibly */
    fx_free(&f);
}

/* ---- lenses ---- */

static void test_extreme_lens_rejected_clearly(void **state)
{
    (void)state;
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors e = {0};
    /* a barrel so strong that r s(r^2) folds back inside the panel: no inverse there */
    assert_true(rt_config_set(&c, "lens.k_green=1 -2 0 0", &e));
    assert_false(rt_config_validate(&c, &e));
    assert_non_null(strstr(e.msg[0], "[lens]"));
    warp_lens l = rt_config_lens(&c, 0);
    double x, y;
    /* a direction the lens never produces: refused, not NaN */
    assert_false(warp_lens_undistort(&l, 1, 50.0, 50.0, &x, &y));
    double u, v;
    warp_lens_distort(&l, 1, 1e9, -1e9, &u, &v);
    assert_true(isfinite(u) && isfinite(v));
    /* NaN coefficients are refused by the config parser */
    rt_config_errors e2 = {0};
    assert_false(rt_config_set(&c, "lens.k_red=nan 0 0 0", &e2));
    /* a mesh built on such a lens stays finite (vertices beyond the fold go to the border) */
    warp_mesh m;
    assert_true(warp_mesh_alloc(&m, 9, &l, 0, 0, 200, 200));
    warp_camera cc = cam();
    warp_mesh_update(&m, &cc, warp_quat_identity());
    for (int i = 0; i < m.rows * m.cols * 3; i++) assert_true(isfinite(m.src[i].x) && isfinite(m.src[i].y));
    warp_mesh_free(&m);
}

/* ---- 16-bit depth ---- */

static void test_unorm16_depth_quantisation(void **state)
{
    (void)state;
    /* the depth plane as a 16-bit reversed-Z buffer (what a host may send to save bandwidth): the raytrace error
     * grows by a bounded amount only */
    fx f;
    fx_init(&f);
    warp_pose a = {warp_quat_identity(), warp_v3(0, 1.6, 0)};
    warp_pose b = {warp_quat_from_ypr(0.02, 0, 0), warp_v3(0.04, 1.6, 0)};
    fx_render(&f, "near", a, b);
    raytrace(&f, b, &f.p.out);
    double p_float = warp_psnr(&f.p.out, &f.p.b.color, NULL, 0);
    warp_image_f32 d16;
    assert_true(warp_image_f32_alloc(&d16, W, H));
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double z = WARP_AT(&f.p.a.depth, x, y);
            double d = isinf(z) ? 0 : f.c.near_z / z; /* reversed-Z, infinite far */
            WARP_AT(&d16, x, y) = (float)(round(d * 65535) / 65535);
        }
    assert_int_equal(warp_inverse_depth_from(&f.c, WARP_DEPTH_REVERSED, &d16, &f.p.inv, &f.p.v.inv_depth_min,
                                             &f.p.v.inv_depth_max),
                     0);
    raytrace(&f, b, &f.p.out2);
    double p_16 = warp_psnr(&f.p.out2, &f.p.b.color, NULL, 0);
    print_message("raytrace vs truth: float depth %.2f dB, 16-bit reversed-Z %.2f dB\n", p_float, p_16);
    assert_true(image_finite_and_written(&f.p.out2));
    assert_true(p_16 > p_float - 1.0);
    warp_image_free(&d16);
    fx_free(&f);
}

/* ---- randomized round trips ---- */

static void test_random_round_trips(void **state)
{
    (void)state;
    /* warp(A->B) then warp(B->A) returns the source where both views see the scene: rotation reprojection for
     * random rotations, and the raytrace for random small translations (fixed seeds) */
    fx f;
    fx_init(&f);
    test_rng r = test_rng_make(77);
    warp_image_rgba8 back;
    warp_image_u8 mask2;
    assert_true(warp_image_rgba8_alloc(&back, W, H) && warp_image_u8_alloc(&mask2, W, H));
    for (int it = 0; it < 12; it++) {
        warp_pose a = {warp_quat_from_ypr(test_rng_uniform(&r, -3, 3), test_rng_uniform(&r, -0.4, 0.4),
                                          test_rng_uniform(&r, -0.3, 0.3)),
                       warp_v3(test_rng_uniform(&r, -0.5, 0.5), 1.6, test_rng_uniform(&r, -0.5, 0.5))};
        warp_pose b = {warp_quat_mul(a.q, warp_quat_from_ypr(test_rng_uniform(&r, -0.1, 0.1),
                                                             test_rng_uniform(&r, -0.1, 0.1),
                                                             test_rng_uniform(&r, -0.1, 0.1))),
                       a.p};
        fx_render(&f, "room", a, b);
        reproject(&f, b.q, &f.p.out);
        /* warp the result back: treat it as a frame rendered at b */
        warp_view vb = {.cam = f.c, .pose = b, .color = &f.p.out};
        warp_mat3 h = warp_reproject_homography(&vb, &f.c, a.q);
        warp_reproject_rows(&vb, &h, &back, &mask2, 0, H);
        /* compare where neither pass was fringe: mark pixels whose forward sample was fringe too */
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                /* the back pass samples the forward image near (x, y) mapped to b: approximate its fringe by the
                 * back mask and a border margin */
                if (x < 3 || y < 3 || x >= W - 3 || y >= H - 3) WARP_AT(&mask2, x, y) |= WARP_MASK_FRINGE;
            }
        long n_valid = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) n_valid += !(WARP_AT(&mask2, x, y) & WARP_MASK_FRINGE);
        /* forward fringe pixels map into the back image's interior; restrict to a centre window both surely see */
        warp_image_u8 centre;
        assert_true(warp_image_u8_alloc(&centre, W, H));
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++)
                WARP_AT(&centre, x, y) =
                    (x > W / 4 && x < 3 * W / 4 && y > H / 4 && y < 3 * H / 4) ? 0 : WARP_MASK_FRINGE;
        double p = warp_psnr(&back, &f.p.a.color, &centre, WARP_MASK_FRINGE);
        warp_image_free(&centre);
        if (p < 26) fail_msg("rotation round trip %d: %.2f dB", it, p);
        assert_true(n_valid > 0);
    }
    /* raytrace: A->B then B->A with the true depth at B */
    for (int it = 0; it < 6; it++) {
        warp_pose a = {warp_quat_from_ypr(test_rng_uniform(&r, -0.3, 0.3), 0, 0), warp_v3(0, 1.6, 0)};
        warp_pose b = {warp_quat_mul(a.q, warp_quat_from_ypr(test_rng_uniform(&r, -0.03, 0.03), 0, 0)),
                       warp_v3(test_rng_uniform(&r, -0.03, 0.03), 1.6 + test_rng_uniform(&r, -0.02, 0.02),
                               test_rng_uniform(&r, -0.03, 0.03))};
        fx_render(&f, "near", a, b);
        warp_image_rgba8 src_copy;
        assert_true(warp_image_rgba8_alloc(&src_copy, W, H));
        warp_image_rgba8_copy(&src_copy, &f.p.a.color);
        raytrace(&f, b, &f.p.out); /* A -> B */
        /* B -> A: the truth render at B gives the depth of B */
        const sim_scene *s = sim_scene_find("near");
        sim_render(s, 0, b, &f.c, SIM_PLANE_COLOR | SIM_PLANE_DEPTH, &f.p.a);
        warp_image_rgba8_copy(&f.p.a.color, &f.p.out); /* but the colour of the warped image */
        f.p.v.pose = b;
        warp_inverse_depth_from(&f.c, WARP_DEPTH_LINEAR, &f.p.a.depth, &f.p.inv, &f.p.v.inv_depth_min,
                                &f.p.v.inv_depth_max);
        raytrace(&f, a, &back);
        double p = warp_psnr(&back, &src_copy, &f.p.mask, WARP_MASK_FRINGE | WARP_MASK_EDGE);
        if (p < 24) fail_msg("raytrace round trip %d: %.2f dB", it, p);
        warp_image_free(&src_copy);
    }
    warp_image_free(&back);
    warp_image_free(&mask2);
    fx_free(&f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_depth_limits_all_encodings),
        cmocka_unit_test(test_depth_nan_inf_negative_counted),
        cmocka_unit_test(test_sky_only_frame),
        cmocka_unit_test(test_points_behind_cameras_and_w_near_zero),
        cmocka_unit_test(test_epipole_inside_image_and_on_pixel_centre),
        cmocka_unit_test(test_zero_translation_matches_rotation),
        cmocka_unit_test(test_view_axis_and_half_turn_rotations),
        cmocka_unit_test(test_quaternions_near_identity_and_unnormalised),
        cmocka_unit_test(test_gyro_extremes),
        cmocka_unit_test(test_imu_time_jumps_and_repeats),
        cmocka_unit_test(test_ten_km_from_origin),
        cmocka_unit_test(test_extreme_lens_rejected_clearly),
        cmocka_unit_test(test_unorm16_depth_quantisation),
        cmocka_unit_test(test_random_round_trips),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
