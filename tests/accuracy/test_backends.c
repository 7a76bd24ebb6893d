/* SPDX-License-Identifier: MIT */
/* hmdwarpd with every device backend behind its mock: the simulated board's IMU, host and panel go through the
 * real HID report decoding, I2C register maps, GPIO edge handling, framelink parsing and V4L2 layout, and the
 * display keeps going through faults. Also: a wrong device gives one startup error naming the key and device. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>
#include <cmocka.h>

#include "runtime/rt_app.h"
#include "runtime/rt_simboard.h"
#include "tests/support/test_run.h"
#include "tests/support/test_settings.h"
#include "tests/support/test_util.h"

static void config(rt_config *c, const char *const *extra, size_t n_extra)
{
    rt_config_defaults(c);
    const char *sets[] = {"display.width=640", "display.height=360", "eye.width=320", "eye.height=360",
                          "lens.scale=180", "lens.center=170 180", "sim.duration_s=0", "sim.eval_every_ms=0",
                          "render.rt_priority=0", "sim.trace=slow", "sim.scene=near", "warp.method=rotation"};
    test_set_all(c, sets, sizeof sets / sizeof sets[0]);
    test_set_all(c, extra, n_extra);
    test_validate(c);
}

static rt_app app;
/* Whether app holds a running board: a failed assert returns from the test without its rt_app_free, and the next
 * test's rt_app_init over a live app would crash the whole binary; the teardown frees what is left. */
static bool app_live;

static bool app_init(const rt_config *c, char *err, int errlen)
{
    app_live = rt_app_init(&app, c, err, errlen);
    return app_live;
}

static void app_free(void)
{
    if (app_live) rt_app_free(&app);
    app_live = false;
}

static int teardown(void **state)
{
    (void)state;
    app_free();
    return 0;
}

/* The runs last until they have their data (support/test_run.h), at least 1.5 s (the fault timeline's end), at
 * most 60 s: a loaded machine serves fewer vsyncs a second, and what must hold is judged on counts. */
#define RUN_MIN_S 1.5
#define RUN_CAP_S 60.0
#define PANEL_HZ 90.0

static bool nominal_enough(const rt_app *a, double elapsed_s)
{
    const rt_telemetry *t = a->tel;
    return elapsed_s >= RUN_MIN_S && t->vsyncs >= 120 && t->frames_received >= 8 && t->imu_samples >= 1000 &&
           t->method_count[RT_METHOD_ROTATION] > 100;
}

static void run(const char *const *extra, size_t n)
{
    rt_config c;
    config(&c, extra, n);
    char err[400];
    if (!app_init(&c, err, sizeof err)) fail_msg("init: %s", err);
    bool enough = test_run_until(&app, nominal_enough, RUN_CAP_S);
    rt_app_summary(&app, stdout);
    if (!enough) fail_msg("no nominal run's counts within %.0f s", RUN_CAP_S);
}

/* At most one vsync per panel refresh, however long the run took. */
static void assert_vsyncs_paced(void)
{
    print_message("vsyncs %llu in %.2f s\n", (unsigned long long)app.tel->vsyncs,
                  (double)(app.run_end_ns - app.t0_ns) * 1e-9);
    assert_true((double)app.tel->vsyncs <= test_run_max_vsyncs(&app, PANEL_HZ));
}

static uint64_t rejected(void)
{
    uint64_t r = 0;
    for (int e = 1; e < DRV_FRAME_ERR_COUNT; e++) r += app.tel->frames_rejected[e];
    return r;
}

/* The run served the display and the tracker followed the true head through the mocked devices. */
static void assert_nominal(void)
{
    rt_telemetry *t = app.tel;
    assert_true(t->vsyncs >= 120);
    assert_vsyncs_paced();
    assert_true(t->frames_received >= 8);
    assert_true(t->imu_samples >= 1000);
    assert_true(t->method_count[RT_METHOD_ROTATION] > 100);
    assert_true(drv_frames_planes(app.dev.frames) & DRV_PLANE_DEPTH); /* the translation scene's depth crosses the link */
    rt_fusion_state st;
    assert_true(rt_fusion_latest(app.fusion, &st));
    warp_quat truth = sim_trace_orientation(rt_simboard_trace(app.sim), (double)(st.t_ns - app.t0_ns) * 1e-9);
    assert_true(warp_quat_angle_between(truth, st.q) < 2.0 * WARP_PI / 180);
}

#define RUN(...)                                                                                                      \
    do {                                                                                                              \
        const char *const sets_[] = {__VA_ARGS__};                                                                   \
        run(sets_, sizeof sets_ / sizeof sets_[0]);                                                                   \
    } while (0)

static void test_hid_usb_gpio(void **state)
{
    (void)state;
    RUN("imu.backend=hid", "imu.device=mock", "frames.backend=usb", "frames.device=mock", "vsync.backend=gpio",
        "vsync.chip=mock", "mock.vsync_jitter_us=150");
    assert_nominal();
    assert_int_equal(rejected(), 0);
    drv_imu_stats is;
    assert_true(drv_imu_stats_get(app.dev.imu, &is));
    assert_true(is.reports > 500 && is.bad_reports == 0 && is.connected);
    drv_vsync_stats vs;
    assert_true(drv_vsync_stats_get(app.dev.vsync, &vs));
    assert_true(vs.edges >= 120 && !vs.on_timer);
    app_free();
}

static void test_i2c_v4l2_timer(void **state)
{
    (void)state;
    RUN("imu.backend=i2c", "imu.device=mock", "imu.chip=mpu6050", "frames.backend=v4l2", "frames.device=mock",
        "frames.format=yuyv", "frames.depth=true", "vsync.backend=timer");
    assert_nominal();
    assert_int_equal(rejected(), 0);
    app_free();
}

static void test_faults_keep_the_display_going(void **state)
{
    (void)state;
    /* The IMU is unplugged for 0.3 s, TE edges stop for 0.3 s, the host stalls for 0.4 s, every 5th frame is
     * garbled and every 7th cut short: every vsync is still served, bad frames are rejected by reason, the IMU
     * comes back. */
    RUN("imu.backend=hid", "imu.device=mock", "frames.backend=usb", "frames.device=mock", "vsync.backend=gpio",
        "vsync.chip=mock", "mock.corrupt_every=5", "mock.truncate_every=7", "mock.imu_unplug_at_s=0.4",
        "mock.imu_unplug_for_s=0.3", "mock.edges_stop_at_s=0.5", "mock.edges_stop_for_s=0.3",
        "mock.host_stall_at_s=0.6", "mock.host_stall_for_s=0.4");
    rt_telemetry *t = app.tel;
    assert_true(t->vsyncs >= 120);
    assert_vsyncs_paced();
    assert_true(t->frames_received >= 4);
    assert_true(rejected() >= 2);
    /* while the host stalled the last good frame kept being warped, further and further from its pose */
    assert_true(rt_hist_pct(&t->frame_age_ms, 100) > 300);
    assert_int_equal(t->imu_lost, 1);
    assert_true(t->imu_stale > 0); /* the display held the last orientation meanwhile */
    drv_imu_stats is;
    assert_true(drv_imu_stats_get(app.dev.imu, &is));
    assert_true(is.reconnects == 1 && is.connected);
    drv_vsync_stats vs;
    assert_true(drv_vsync_stats_get(app.dev.vsync, &vs));
    assert_true(vs.fallbacks >= 1 && !vs.on_timer);
    app_free();
}

/* 0.4 s's worth of data, however long it takes */
static bool combination_enough(const rt_app *a, double elapsed_s)
{
    const rt_telemetry *t = a->tel;
    return elapsed_s >= 0.4 && t->vsyncs >= 30 && t->frames_received >= 2 && t->imu_samples >= 300 &&
           t->method_count[RT_METHOD_ROTATION] >= 20;
}

static void test_every_combination(void **state)
{
    (void)state;
    /* 3 IMUs x 3 frame sources x 3 vsync sources, short runs: every pairing starts, serves vsyncs, delivers
     * frames and samples, and rejects nothing on a clean link. */
    const char *imu[3][3] = {{"imu.backend=sim", "imu.device=", "imu.chip=auto"},
                             {"imu.backend=hid", "imu.device=mock", "imu.chip=auto"},
                             {"imu.backend=i2c", "imu.device=mock", "imu.chip=icm42688"}};
    const char *frames[3][2] = {{"frames.backend=sim", "frames.device="},
                                {"frames.backend=usb", "frames.device=mock"},
                                {"frames.backend=v4l2", "frames.device=mock"}};
    const char *vsync[3][2] = {{"vsync.backend=sim", "vsync.chip=gpiochip0"},
                               {"vsync.backend=gpio", "vsync.chip=mock"},
                               {"vsync.backend=timer", "vsync.chip=gpiochip0"}};
    for (int i = 0; i < 3; i++)
        for (int f = 0; f < 3; f++)
            for (int v = 0; v < 3; v++) {
                const char *sets[] = {imu[i][0],    imu[i][1],    imu[i][2],         frames[f][0],
                                      frames[f][1], vsync[v][0],  vsync[v][1],       "sim.duration_s=0",
                                      "sim.imu_rest_s=0.2", "sim.scene=room"};
                rt_config c;
                config(&c, sets, sizeof sets / sizeof sets[0]);
                char err[400];
                if (!app_init(&c, err, sizeof err)) fail_msg("%s %s %s: %s", imu[i][0], frames[f][0], vsync[v][0], err);
                bool enough = test_run_until(&app, combination_enough, RUN_CAP_S);
                rt_telemetry *t = app.tel;
                print_message("%-16s %-19s %-18s vsyncs %3llu frames %3llu imu %4llu\n", imu[i][0], frames[f][0],
                              vsync[v][0], (unsigned long long)t->vsyncs, (unsigned long long)t->frames_received,
                              (unsigned long long)t->imu_samples);
                assert_true(enough);
                assert_true(t->vsyncs >= 30);
                assert_vsyncs_paced();
                assert_true(t->frames_received >= 2);
                assert_true(t->imu_samples >= 300);
                assert_true(t->method_count[RT_METHOD_ROTATION] >= 20);
                assert_int_equal(rejected(), 0);
                app_free();
            }
}

/* A device that is not there: init fails with one message naming the key and the device. */
static void expect_open_error(const char *const *sets, size_t n, const char *key, const char *device)
{
    rt_config c;
    config(&c, sets, n);
    char err[400] = "";
    assert_false(rt_app_init(&app, &c, err, sizeof err));
    print_message("%s\n", err);
    assert_non_null(strstr(err, key));
    assert_non_null(strstr(err, device));
    rt_app_free(&app);
}

static void test_missing_devices_named(void **state)
{
    (void)state;
    /* real devices only open here, paced by nothing: real time (a slow-down would be refused before they open) */
    int slowdown = plat_clock_slowdown();
    assert_true(plat_clock_set_slowdown(1));
    const char *hid[] = {"imu.backend=hid", "imu.device=/dev/hidraw97"};
    expect_open_error(hid, 2, "[imu]", "/dev/hidraw97");
    const char *i2c[] = {"imu.backend=i2c", "imu.device=/dev/i2c-97"};
    expect_open_error(i2c, 2, "[imu]", "/dev/i2c-97");
    const char *gpio[] = {"vsync.backend=gpio", "vsync.chip=gpiochip97"};
    expect_open_error(gpio, 2, "[vsync]", "gpiochip97");
    const char *usb[] = {"frames.backend=usb", "frames.device=/nonexistent/ffs"};
    expect_open_error(usb, 2, "[frames]", "/nonexistent/ffs");
    const char *v4l2[] = {"frames.backend=v4l2", "frames.device=/dev/video97"};
    expect_open_error(v4l2, 2, "[frames]", "/dev/video97");
    assert_true(plat_clock_set_slowdown(slowdown));
}

int main(void)
{
    test_paced_by_sim(TEST_EMULATOR_SLOWDOWN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_hid_usb_gpio, teardown),
        cmocka_unit_test_teardown(test_i2c_v4l2_timer, teardown),
        cmocka_unit_test_teardown(test_faults_keep_the_display_going, teardown),
        cmocka_unit_test_teardown(test_every_combination, teardown),
        cmocka_unit_test_teardown(test_missing_devices_named, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
