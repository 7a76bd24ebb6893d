/* SPDX-License-Identifier: MIT */
/* Unit tests for rolling scanout: band times and fractions per scan direction, the slerp's exact endpoints, the
 * [display] scan keys, the lens mesh per vertex row (still head = the global mesh bit for bit), per-band truth. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "runtime/rt_config.h"
#include "runtime/rt_eval.h"
#include "sim/sim_scene.h"
#include "sim/sim_trace.h"
#include "tests/support/test_settings.h"
#include "warp/warp_mesh.h"
#include "warp/warp_scan.h"

static warp_scan scan_of(warp_scan_dir dir)
{
    warp_scan s = {true, dir, 0.010, 1440, 800};
    return s;
}

static bool quat_bits_equal(warp_quat a, warp_quat b) { return memcmp(&a, &b, sizeof a) == 0; }

static void test_fractions_and_times(void **state)
{
    (void)state;
    warp_scan s = scan_of(WARP_SCAN_TOP_TO_BOTTOM);
    /* the first line's centre is 0, the last's 1, the middle 0.5, anything beyond clamped; x does not matter */
    assert_true(warp_scan_fraction(&s, 3.5, 0.5) == 0.0);
    assert_true(warp_scan_fraction(&s, 1000, 799.5) == 1.0);
    assert_float_equal(warp_scan_fraction(&s, 0, 400.0), 0.5, 1e-12);
    assert_true(warp_scan_fraction(&s, 0, -20) == 0.0 && warp_scan_fraction(&s, 0, 900) == 1.0);
    /* the first line lights half a scan before mid-scan, the last half a scan after */
    assert_float_equal(warp_scan_offset_s(&s, 0), -0.005, 1e-15);
    assert_float_equal(warp_scan_offset_s(&s, 1), 0.005, 1e-15);
    assert_float_equal(warp_scan_offset_s(&s, 0.5), 0, 1e-15);
    /* line 200 of 800 lights (199.5 / 799 - 1/2) * 10 ms from mid-scan */
    assert_float_equal(warp_scan_offset_s(&s, warp_scan_fraction(&s, 0, 200.5)), (200.0 / 799 - 0.5) * 0.010, 1e-15);
    /* the other directions */
    s = scan_of(WARP_SCAN_BOTTOM_TO_TOP);
    assert_true(warp_scan_fraction(&s, 0, 799.5) == 0.0 && warp_scan_fraction(&s, 0, 0.5) == 1.0);
    s = scan_of(WARP_SCAN_LEFT_TO_RIGHT);
    assert_true(warp_scan_fraction(&s, 0.5, 700) == 0.0 && warp_scan_fraction(&s, 1439.5, 0) == 1.0);
    assert_float_equal(warp_scan_fraction(&s, 720, 3), 0.5, 1e-12); /* the eyes' seam is mid-scan */
    s = scan_of(WARP_SCAN_RIGHT_TO_LEFT);
    assert_true(warp_scan_fraction(&s, 1439.5, 0) == 0.0 && warp_scan_fraction(&s, 0.5, 0) == 1.0);
    /* a global panel: every pixel at mid-scan, no offset */
    s.rolling = false;
    assert_true(warp_scan_fraction(&s, 0.5, 0.5) == 0.5 && warp_scan_offset_s(&s, 0) == 0);
    /* bands of equal scan time, and their centres */
    assert_int_equal(warp_scan_band(0, 16), 0);
    assert_int_equal(warp_scan_band(1, 16), 15);
    assert_int_equal(warp_scan_band(0.0626, 16), 1);
    assert_float_equal(warp_scan_band_fraction(0, 16), 1.0 / 32, 1e-15);
    assert_float_equal(warp_scan_band_fraction(15, 16), 31.0 / 32, 1e-15);
}

static void test_slerp_endpoints(void **state)
{
    (void)state;
    warp_quat a = warp_quat_from_axis_angle(warp_v3(0.2, 1, 0.1), 0.3);
    warp_quat b = warp_quat_from_axis_angle(warp_v3(0.1, 0.9, -0.3), 0.45);
    assert_true(quat_bits_equal(warp_scan_slerp(a, b, 0), a));
    assert_true(quat_bits_equal(warp_scan_slerp(a, b, 1), b));
    assert_true(quat_bits_equal(warp_scan_slerp(a, b, -0.5), a));
    assert_true(quat_bits_equal(warp_scan_slerp(a, a, 0.37), a));
    warp_quat m = warp_scan_slerp(a, b, 0.25);
    assert_float_equal(warp_quat_angle_between(a, m), 0.25 * warp_quat_angle_between(a, b), 1e-12);
    assert_float_equal(warp_quat_angle_between(m, b), 0.75 * warp_quat_angle_between(a, b), 1e-12);
}

static void test_config_keys(void **state)
{
    (void)state;
    rt_config c;
    rt_config_defaults(&c);
    warp_scan s = rt_config_scan(&c);
    assert_false(s.rolling); /* global by default: every existing board unchanged */
    const char *sets[] = {"display.scanout=rolling", "display.scan_direction=left_to_right", "display.refresh_hz=60"};
    test_set_all(&c, sets, 3);
    test_validate(&c);
    s = rt_config_scan(&c);
    assert_true(s.rolling && s.dir == WARP_SCAN_LEFT_TO_RIGHT);
    assert_float_equal(s.scan_s, 0.9 / 60, 1e-12); /* auto */
    assert_int_equal(s.panel_w, c.panel_w);
    test_setf(&c, "display.scan_ms=12.5");
    test_validate(&c);
    assert_float_equal(rt_config_scan(&c).scan_s, 0.0125, 1e-12);
    /* longer than a refresh: refused, naming the key */
    test_setf(&c, "display.scan_ms=17");
    rt_config_errors e = {0};
    assert_false(rt_config_validate(&c, &e));
    assert_non_null(strstr(e.msg[0], "scan_ms"));
    assert_non_null(strstr(e.msg[0], "refresh"));
    /* a direction that does not exist */
    e.count = 0;
    assert_false(rt_config_set(&c, "display.scan_direction=diagonal", &e));
    assert_non_null(strstr(e.msg[0], "scan_direction"));
}

/* A small eye and lens, and a frame rendered a little to the side. */
static warp_camera small_cam(void)
{
    rt_config c;
    rt_config_defaults(&c);
    c.eye_w = 96;
    c.eye_h = 108;
    return rt_config_eye_camera(&c, WARP_EYE_LEFT);
}

static bool meshes_equal(const warp_mesh *a, const warp_mesh *b)
{
    size_t n = (size_t)a->rows * (size_t)a->cols * 3;
    size_t lines = (size_t)(a->rows - 1) * 2 * WARP_MESH_LINE_VALUES * (size_t)a->line_stride;
    return a->behind == b->behind && memcmp(a->src, b->src, n * sizeof *a->src) == 0 &&
           memcmp(a->lines, b->lines, lines * sizeof *a->lines) == 0;
}

/* Vertex row j (or column i) of a against b's. */
static bool row_equal(const warp_mesh *a, const warp_mesh *b, int j)
{
    return memcmp(a->src + (size_t)j * a->cols * 3, b->src + (size_t)j * b->cols * 3,
                  (size_t)a->cols * 3 * sizeof *a->src) == 0;
}
static bool col_equal(const warp_mesh *a, const warp_mesh *b, int i)
{
    for (int j = 0; j < a->rows; j++)
        if (memcmp(a->src + ((size_t)j * a->cols + i) * 3, b->src + ((size_t)j * b->cols + i) * 3, 3 * sizeof *a->src))
            return false;
    return true;
}

static void test_mesh_rotation(void **state)
{
    (void)state;
    warp_camera cam = small_cam();
    warp_lens lens = warp_lens_identity(&cam);
    warp_mesh g, r;
    /* the left eye's viewport of a 192 x 108 panel */
    assert_true(warp_mesh_alloc(&g, 12, &lens, 0, 0, cam.width, cam.height));
    assert_true(warp_mesh_alloc(&r, 12, &lens, 0, 0, cam.width, cam.height));
    warp_quat q0 = warp_quat_from_axis_angle(warp_v3(0, 1, 0), 0.05);
    warp_quat q1 = warp_quat_from_axis_angle(warp_v3(0.3, 1, 0), 0.09);
    for (int d = WARP_SCAN_TOP_TO_BOTTOM; d <= WARP_SCAN_RIGHT_TO_LEFT; d++) {
        warp_scan s = {true, (warp_scan_dir)d, 0.01, 2 * cam.width, cam.height};
        /* a still head: the global mesh, bit for bit */
        warp_mesh_update(&g, &cam, q0);
        warp_mesh_update_rolling(&r, &cam, q0, q0, &s);
        assert_true(meshes_equal(&g, &r));
        /* a turning one: the first lit vertex line is the first pose's, the last lit the last pose's */
        warp_mesh_update_rolling(&r, &cam, q0, q1, &s);
        assert_false(meshes_equal(&g, &r));
        warp_mesh_update(&g, &cam, q0);
        const int top = 0, bottom = r.rows - 1, left = 0;
        switch ((warp_scan_dir)d) {
        case WARP_SCAN_TOP_TO_BOTTOM: assert_true(row_equal(&r, &g, top)); break;
        case WARP_SCAN_BOTTOM_TO_TOP: assert_true(row_equal(&r, &g, bottom)); break;
        case WARP_SCAN_LEFT_TO_RIGHT: assert_true(col_equal(&r, &g, left)); break;
        case WARP_SCAN_RIGHT_TO_LEFT: assert_false(col_equal(&r, &g, left)); break; /* the left eye lights last */
        }
        warp_mesh_update(&g, &cam, q1);
        switch ((warp_scan_dir)d) {
        case WARP_SCAN_TOP_TO_BOTTOM: assert_true(row_equal(&r, &g, bottom)); break;
        case WARP_SCAN_BOTTOM_TO_TOP: assert_true(row_equal(&r, &g, top)); break;
        /* left to right, the left eye lights in the panel's first half: never the last pose exactly; right to
         * left, its left edge is the panel's last line */
        case WARP_SCAN_LEFT_TO_RIGHT: assert_false(col_equal(&r, &g, r.cols - 1)); break;
        case WARP_SCAN_RIGHT_TO_LEFT: assert_true(col_equal(&r, &g, left)); break;
        }
    }
    warp_mesh_free(&g);
    warp_mesh_free(&r);
}

/* The per-band truth and the raytrace mesh need a scene: the room, static, on a small eye. */
static void test_raytrace_mesh_and_truth(void **state)
{
    (void)state;
    warp_camera cam = small_cam();
    sim_trace still, fast;
    assert_true(sim_trace_init(&still, "still", 1) && sim_trace_init(&fast, "fast", 1));
    rt_eval_inputs in = {.scene = sim_scene_find("room"), .trace = &still, .cam = cam, .head = still.head,
                         .mesh_n = 12, .rp = warp_raytrace_default_params(), .tp = warp_mesh_trace_default_params(),
                         .scan = {true, WARP_SCAN_TOP_TO_BOTTOM, 0.01, 2 * cam.width, cam.height}};
    assert_non_null(in.scene);
    rt_eval_work w;
    assert_true(rt_eval_work_alloc(&w, &in));
    size_t bytes = (size_t)w.truth.color.stride * (size_t)cam.height * sizeof(warp_rgba8);
    warp_rgba8 *global = malloc(bytes);
    assert_non_null(global);
    /* a still head on a static scene: per-band truth = the one render, for every scan direction */
    rt_eval_inputs gin = in;
    gin.scan.rolling = false;
    rt_eval_truth(&w, &gin, 0.8);
    memcpy(global, w.truth.color.px, bytes);
    for (int d = WARP_SCAN_TOP_TO_BOTTOM; d <= WARP_SCAN_RIGHT_TO_LEFT; d++) {
        rt_eval_inputs din = in;
        din.scan.dir = (warp_scan_dir)d;
        rt_eval_work wd;
        assert_true(rt_eval_work_alloc(&wd, &din));
        rt_eval_truth(&wd, &din, 0.8);
        assert_memory_equal(wd.truth.color.px, global, bytes);
        rt_eval_work_free(&wd);
    }
    /* mid-turn it is not (the bands see different poses): the comparison can fail */
    in.trace = gin.trace = &fast;
    double t = 0;
    for (double u = 0.4; u < 2 && t == 0; u += 0.005)
        if (warp_v3_norm(sim_trace_angular_velocity(&fast, u)) > 200 * WARP_PI / 180) t = u;
    assert_true(t > 0);
    rt_eval_truth(&w, &gin, t);
    memcpy(global, w.truth.color.px, bytes);
    rt_eval_truth(&w, &in, t);
    assert_true(memcmp(w.truth.color.px, global, bytes) != 0);

    /* the raytrace mesh: setups for one pose give the global mesh bit for bit; for two, the first and last rows
     * are theirs */
    sim_render(in.scene, t - 0.02, warp_head_eye_pose(&fast.head, sim_trace_head_pose(&fast, t - 0.02), 0), &cam,
               SIM_PLANE_COLOR | SIM_PLANE_DEPTH, &w.src);
    warp_view v = {.cam = cam, .pose = warp_head_eye_pose(&fast.head, sim_trace_head_pose(&fast, t - 0.02), 0),
                   .color = &w.src.color, .inv_depth = &w.inv};
    warp_inverse_depth_from(&cam, WARP_DEPTH_LINEAR, &w.src.depth, &w.inv, &v.inv_depth_min, &v.inv_depth_max);
    warp_pose p0 = warp_head_eye_pose(&fast.head, sim_trace_head_pose(&fast, t - 0.005), 0);
    warp_pose p1 = warp_head_eye_pose(&fast.head, sim_trace_head_pose(&fast, t + 0.005), 0);
    warp_raytrace_setup s0, s0b, s1;
    assert_null(warp_raytrace_prepare(&s0, &v, &cam, p0, &in.rp));
    assert_null(warp_raytrace_prepare(&s0b, &v, &cam, p0, &in.rp));
    assert_null(warp_raytrace_prepare(&s1, &v, &cam, p1, &in.rp));
    warp_mesh g;
    assert_true(warp_mesh_alloc_eye(&g, 12, &cam));
    warp_mesh_update_raytrace(&g, &cam, &s0);
    warp_mesh_update_raytrace_rolling(&w.mesh, &cam, &s0, &s0b, &in.scan);
    assert_true(meshes_equal(&g, &w.mesh));
    warp_mesh_update_raytrace_rolling(&w.mesh, &cam, &s0, &s1, &in.scan);
    assert_false(meshes_equal(&g, &w.mesh));
    assert_true(row_equal(&w.mesh, &g, 0));
    warp_mesh_update_raytrace(&g, &cam, &s1);
    assert_true(row_equal(&w.mesh, &g, g.rows - 1));
    warp_mesh_free(&g);
    free(global);
    rt_eval_work_free(&w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fractions_and_times), cmocka_unit_test(test_slerp_endpoints),
        cmocka_unit_test(test_config_keys),         cmocka_unit_test(test_mesh_rotation),
        cmocka_unit_test(test_raytrace_mesh_and_truth),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
