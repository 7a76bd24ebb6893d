/* SPDX-License-Identifier: MIT */
/* Unit tests for warp_math and warp_camera: quaternion/matrix identities, round trips and conventions. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

#include "tests/support/test_util.h"
#include "warp/warp_camera.h"
#include "warp/warp_head.h"
#include "warp/warp_math.h"

static void test_quat_rotate_matches_matrix(void **state)
{
    (void)state;
    test_rng r = test_rng_make(1);
    for (int i = 0; i < 200; i++) {
        warp_quat q = test_random_quat(&r);
        warp_vec3 v = warp_v3(test_rng_uniform(&r, -3, 3), test_rng_uniform(&r, -3, 3), test_rng_uniform(&r, -3, 3));
        warp_mat3 m = warp_quat_to_mat3(q);
        warp_vec3 a = warp_quat_rotate(q, v), b = warp_mat3_apply(&m, v);
        assert_true(fabs(a.x - b.x) + fabs(a.y - b.y) + fabs(a.z - b.z) < 1e-12);
        /* rotation preserves length and the matrix is orthonormal with det +1 */
        assert_true(fabs(warp_v3_norm(a) - warp_v3_norm(v)) < 1e-12);
        assert_true(fabs(warp_mat3_det(&m) - 1.0) < 1e-12);
        /* matrix -> quaternion -> matrix round trip (q and -q are the same rotation) */
        warp_quat q2 = warp_mat3_to_quat(&m);
        assert_true(warp_quat_angle_between(q, q2) < 1e-9);
    }
}

static void test_quat_conventions(void **state)
{
    (void)state;
    /* positive yaw turns the view (-Z) towards -X (left); positive pitch towards +Y (up) */
    warp_vec3 fwd = warp_v3(0, 0, -1);
    warp_vec3 l = warp_quat_rotate(warp_quat_from_ypr(WARP_PI / 2, 0, 0), fwd);
    assert_true(fabs(l.x + 1) < 1e-12 && fabs(l.z) < 1e-12);
    warp_vec3 u = warp_quat_rotate(warp_quat_from_ypr(0, WARP_PI / 2, 0), fwd);
    assert_true(fabs(u.y - 1) < 1e-12 && fabs(u.z) < 1e-12);
    /* multiplication order: (a*b) applied to v == a(b(v)) */
    warp_quat a = warp_quat_from_ypr(0.3, 0, 0), b = warp_quat_from_ypr(0, 0.4, 0.1);
    warp_vec3 v = warp_v3(0.2, -0.5, 0.9);
    warp_vec3 x = warp_quat_rotate(warp_quat_mul(a, b), v), y = warp_quat_rotate(a, warp_quat_rotate(b, v));
    assert_true(fabs(x.x - y.x) + fabs(x.y - y.y) + fabs(x.z - y.z) < 1e-12);
}

static void test_quat_exp_log_slerp(void **state)
{
    (void)state;
    test_rng r = test_rng_make(2);
    for (int i = 0; i < 200; i++) {
        warp_quat q = test_random_quat(&r);
        warp_vec3 lg = warp_quat_log(q);
        assert_true(warp_v3_norm(lg) <= WARP_PI + 1e-12);
        assert_true(warp_quat_angle_between(warp_quat_exp(lg), q) < 1e-9);
        /* slerp endpoints, midpoint halves the angle, extrapolation continues at the same rate */
        warp_quat p = test_random_quat(&r);
        assert_true(warp_quat_angle_between(warp_quat_slerp(p, q, 0), p) < 1e-9);
        assert_true(warp_quat_angle_between(warp_quat_slerp(p, q, 1), q) < 1e-9);
        double ang = warp_quat_angle_between(p, q);
        if (ang < 1.0) {
            assert_true(fabs(warp_quat_angle_between(p, warp_quat_slerp(p, q, 0.5)) - ang / 2) < 1e-9);
            assert_true(fabs(warp_quat_angle_between(p, warp_quat_slerp(p, q, 2.0)) - ang * 2) < 1e-9);
        }
    }
    /* tiny rotations keep full relative precision (gyro integration at 1 kHz of slow motion) */
    warp_vec3 tiny = warp_v3(1e-9, -2e-9, 3e-9);
    warp_vec3 back = warp_quat_log(warp_quat_exp(tiny));
    assert_true(fabs(back.x - tiny.x) < 1e-20 && fabs(back.z - tiny.z) < 1e-20);
}

static void test_quat_normalize_rejects_bad(void **state)
{
    (void)state;
    warp_quat out;
    warp_quat nanq = {NAN, 0, 0, 0}, zero = {0, 0, 0, 0}, big = {2, 0, 0, 0};
    assert_false(warp_quat_normalize(nanq, &out));
    assert_true(out.w == 1 && out.x == 0);
    assert_false(warp_quat_normalize(zero, &out));
    assert_true(warp_quat_normalize(big, &out));
    assert_true(fabs(out.w - 1) < 1e-15);
}

static void test_pose_inverse_and_relative(void **state)
{
    (void)state;
    test_rng r = test_rng_make(3);
    for (int i = 0; i < 100; i++) {
        warp_pose a = {test_random_quat(&r), warp_v3(test_rng_uniform(&r, -5, 5), 1, test_rng_uniform(&r, -5, 5))};
        warp_pose b = {test_random_quat(&r), warp_v3(test_rng_uniform(&r, -5, 5), 2, 0.5)};
        warp_pose id = warp_pose_mul(a, warp_pose_inverse(a));
        assert_true(warp_quat_angle_between(id.q, warp_quat_identity()) < 1e-9 && warp_v3_norm(id.p) < 1e-12);
        /* a * relative(a, b) == b */
        warp_pose rb = warp_pose_mul(a, warp_pose_relative(a, b));
        assert_true(warp_quat_angle_between(rb.q, b.q) < 1e-9 && warp_v3_norm(warp_v3_sub(rb.p, b.p)) < 1e-12);
        /* pose as matrix agrees with pose_apply */
        warp_mat4 m = warp_pose_to_mat4(a);
        double in[4] = {0.3, -0.2, 0.7, 1}, out[4];
        warp_mat4_apply(&m, in, out);
        warp_vec3 e = warp_pose_apply(a, warp_v3(0.3, -0.2, 0.7));
        assert_true(fabs(out[0] - e.x) + fabs(out[1] - e.y) + fabs(out[2] - e.z) < 1e-12);
        warp_mat4 mi, prod;
        assert_true(warp_mat4_inverse(&m, &mi));
        prod = warp_mat4_mul(&m, &mi);
        for (int k = 0; k < 16; k++) assert_true(fabs(prod.m[k / 4][k % 4] - (k / 4 == k % 4)) < 1e-12);
    }
    /* relative pose of two poses 10 km from the origin stays exact to a micrometre */
    warp_pose far_a = {warp_quat_from_ypr(0.1, 0, 0), warp_v3(1e4, 0, 1e4)};
    warp_pose far_b = {warp_quat_from_ypr(0.1, 0, 0), warp_v3(1e4 + 0.001, 0, 1e4)};
    warp_pose rel = warp_pose_relative(far_a, far_b);
    assert_true(fabs(warp_v3_norm(rel.p) - 0.001) < 1e-9);
}

static void test_mat3_inverse(void **state)
{
    (void)state;
    warp_mat3 m = {{{2, 1, 0}, {0, 3, 1}, {1, 0, 4}}}, mi, p;
    assert_true(warp_mat3_inverse(&m, &mi));
    p = warp_mat3_mul(&m, &mi);
    for (int k = 0; k < 9; k++) assert_true(fabs(p.m[k / 3][k % 3] - (k / 3 == k % 3)) < 1e-14);
    warp_mat3 sing = {{{1, 2, 3}, {2, 4, 6}, {0, 0, 1}}};
    assert_false(warp_mat3_inverse(&sing, &mi));
}

static void test_camera_project_and_K(void **state)
{
    (void)state;
    warp_camera c = {640, 480, 1.2, 0.8, 0.7, 0.9, 0.1, INFINITY};
    assert_null(warp_camera_check(&c));
    warp_mat3 k = warp_camera_K(&c), ki = warp_camera_K_inverse(&c), p = warp_mat3_mul(&k, &ki);
    for (int i = 0; i < 9; i++) assert_true(fabs(p.m[i / 3][i % 3] - (i / 3 == i % 3)) < 1e-12);
    /* the optical axis lands where the tangents say: tl / (tl + tr) of the width */
    double x, y, iz;
    assert_true(warp_camera_project(&c, warp_v3(0, 0, -2), &x, &y, &iz));
    assert_true(fabs(x - 640 * 1.2 / 2.0) < 1e-9 && fabs(y - 480 * 0.7 / 1.6) < 1e-9 && fabs(iz - 0.5) < 1e-12);
    /* the frustum's corners are the image corners */
    assert_true(warp_camera_project(&c, warp_v3(-1.2, 0.7, -1), &x, &y, NULL));
    assert_true(fabs(x) < 1e-9 && fabs(y) < 1e-9);
    assert_true(warp_camera_project(&c, warp_v3(0.8, -0.9, -1), &x, &y, NULL));
    assert_true(fabs(x - 640) < 1e-9 && fabs(y - 480) < 1e-9);
    /* behind the camera is rejected */
    assert_false(warp_camera_project(&c, warp_v3(0, 0, 1), &x, &y, NULL));
    warp_camera bad = c;
    bad.near_z = 0;
    assert_non_null(warp_camera_check(&bad));
}

static void test_depth_encodings(void **state)
{
    (void)state;
    warp_camera fin = {16, 16, 1, 1, 1, 1, 0.1, 100};
    warp_camera inf = {16, 16, 1, 1, 1, 1, 0.1, INFINITY};
    const warp_camera *cams[2] = {&fin, &inf};
    for (int ci = 0; ci < 2; ci++) {
        const warp_camera *c = cams[ci];
        for (int e = 0; e < 3; e++) {
            for (double z = 0.1; z < 90; z *= 1.7) {
                double d = warp_depth_from_inverse(c, (warp_depth_encoding)e, 1.0 / z);
                double iz = warp_depth_to_inverse(c, (warp_depth_encoding)e, d);
                assert_true(fabs(iz * z - 1) < 1e-12);
            }
        }
        /* standard: near -> 0; reversed: near -> 1 */
        assert_true(fabs(warp_depth_from_inverse(c, WARP_DEPTH_STANDARD, 1 / 0.1)) < 1e-12);
        assert_true(fabs(warp_depth_from_inverse(c, WARP_DEPTH_REVERSED, 1 / 0.1) - 1) < 1e-12);
    }
    /* the GL projection puts near at NDC -1 and far at +1 */
    warp_mat4 p = warp_camera_gl_projection(&fin);
    double n[4] = {0, 0, -0.1, 1}, f[4] = {0, 0, -100, 1}, o[4];
    warp_mat4_apply(&p, n, o);
    assert_true(fabs(o[2] / o[3] + 1) < 1e-9);
    warp_mat4_apply(&p, f, o);
    assert_true(fabs(o[2] / o[3] - 1) < 1e-9);
    /* and a point at the frustum's right edge at x = +1 */
    double r[4] = {1.0 * 3, 0, -3, 1};
    warp_mat4_apply(&p, r, o);
    assert_true(fabs(o[0] / o[3] - 1) < 1e-12);
}

static void test_rotation_homography_matches_projection(void **state)
{
    (void)state;
    /* A point at infinity seen by two rotated cameras: H maps its target pixel onto its source pixel. */
    warp_camera src = warp_camera_symmetric(800, 600, 90, 75, 0.1, INFINITY);
    warp_camera dst = {700, 700, 0.9, 1.1, 1.0, 0.8, 0.1, INFINITY};
    warp_quat qs = warp_quat_from_ypr(0.2, -0.1, 0.05), qd = warp_quat_from_ypr(0.35, 0.05, -0.1);
    warp_quat src_from_dst = warp_quat_mul(warp_quat_conj(qs), qd);
    warp_mat3 h = warp_rotation_homography(&src, &dst, src_from_dst);
    warp_vec3 dirw = warp_v3(-0.3, 0.2, -1);
    double xs, ys, xd, yd;
    assert_true(warp_camera_project(&src, warp_quat_rotate(warp_quat_conj(qs), dirw), &xs, &ys, NULL));
    assert_true(warp_camera_project(&dst, warp_quat_rotate(warp_quat_conj(qd), dirw), &xd, &yd, NULL));
    warp_vec3 m = warp_mat3_apply(&h, warp_v3(xd, yd, 1));
    assert_true(fabs(m.x / m.z - xs) < 1e-9 && fabs(m.y / m.z - ys) < 1e-9);
}

static void test_head_model(void **state)
{
    (void)state;
    warp_head h = warp_head_default();
    warp_pose p0 = warp_head_pose_from_orientation(&h, warp_quat_identity());
    assert_true(fabs(p0.p.y - 1.6) < 1e-12 && fabs(p0.p.z) < 1e-12);
    /* turning the head moves the eyes: a 90 degree yaw swings them 8 cm forward-left around the neck */
    warp_pose p1 = warp_head_pose_from_orientation(&h, warp_quat_from_ypr(WARP_PI / 2, 0, 0));
    assert_true(fabs(p1.p.x - (-0.08)) < 1e-12 && fabs(p1.p.z - 0.08) < 1e-12);
    warp_pose l = warp_head_eye_pose(&h, p0, WARP_EYE_LEFT), r = warp_head_eye_pose(&h, p0, WARP_EYE_RIGHT);
    assert_true(fabs(r.p.x - l.p.x - 0.064) < 1e-12);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_quat_rotate_matches_matrix),
        cmocka_unit_test(test_quat_conventions),
        cmocka_unit_test(test_quat_exp_log_slerp),
        cmocka_unit_test(test_quat_normalize_rejects_bad),
        cmocka_unit_test(test_pose_inverse_and_relative),
        cmocka_unit_test(test_mat3_inverse),
        cmocka_unit_test(test_camera_project_and_K),
        cmocka_unit_test(test_depth_encodings),
        cmocka_unit_test(test_rotation_homography_matches_projection),
        cmocka_unit_test(test_head_model),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
