/* SPDX-License-Identifier: MIT */
/* A board whose devices are all real never loads the simulator: the rpi5 board's configuration (its panel made
 * offscreen and its devices pointed at paths that do not exist) starts without looking up a scene or a trace and
 * without the simulated board's part (rt_simboard), and fails on its first device; the same board with one mock
 * device does load them. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>
#include <cmocka.h>

#include "runtime/rt_app.h"
#include "runtime/rt_simboard.h"

static rt_app app;

/* board/rpi5/board.ini, small and offscreen, its devices missing, and a scene and trace no simulator knows: a
 * board that loaded the simulator would stop at them. */
static void rpi5_config(rt_config *c, const char *imu_device)
{
    rt_config_defaults(c);
    rt_config_errors e = {0};
    if (!rt_config_load(c, "board/rpi5/board.ini", &e)) fail_msg("board/rpi5/board.ini: %s", e.msg[0]);
    char imu[160];
    snprintf(imu, sizeof imu, "imu.device=%s", imu_device);
    const char *sets[] = {"display.output=offscreen", "render.renderer=cpu", "render.rt_priority=0",
                          "render.threads=1", "display.width=640", "display.height=360", "eye.width=320",
                          "eye.height=360", "lens.scale=180", "lens.center=170 180", imu,
                          "frames.device=/nonexistent/ffs-hmdwarp", "vsync.chip=/nonexistent/gpiochip9"};
    for (size_t i = 0; i < sizeof sets / sizeof sets[0]; i++)
        if (!rt_config_set(c, sets[i], &e)) fail_msg("%s: %s", sets[i], e.msg[0]);
    snprintf(c->scene, sizeof c->scene, "no-such-scene");
    snprintf(c->trace, sizeof c->trace, "no-such-trace");
}

static void test_which_configs_simulate(void **state)
{
    (void)state;
    rt_config c;
    rpi5_config(&c, "/nonexistent/i2c-1");
    assert_false(rt_devices_simulated(&c));
    rt_config s = c;
    snprintf(s.imu_device, sizeof s.imu_device, "mock");
    assert_true(rt_devices_simulated(&s));
    s = c;
    snprintf(s.frames_device, sizeof s.frames_device, "mock");
    assert_true(rt_devices_simulated(&s));
    s = c;
    snprintf(s.vsync_chip, sizeof s.vsync_chip, "mock");
    assert_true(rt_devices_simulated(&s));
    s = c;
    snprintf(s.vsync_backend, sizeof s.vsync_backend, "sim");
    assert_true(rt_devices_simulated(&s));
    rt_config_defaults(&s); /* the simulated board */
    assert_true(rt_devices_simulated(&s));
}

static void test_real_board_skips_the_simulator(void **state)
{
    (void)state;
    rt_config c;
    rpi5_config(&c, "/nonexistent/i2c-1");
    char err[400] = "";
    assert_false(rt_app_init(&app, &c, err, sizeof err));
    print_message("%s\n", err);
    assert_non_null(strstr(err, "[imu]"));
    assert_non_null(strstr(err, "/nonexistent/i2c-1"));
    assert_null(strstr(err, "[sim]"));
    assert_null(app.sim);
    rt_app_free(&app);
}

static void test_mock_device_loads_the_simulator(void **state)
{
    (void)state;
    rt_config c;
    rpi5_config(&c, "mock");
    char err[400] = "";
    assert_false(rt_app_init(&app, &c, err, sizeof err));
    print_message("%s\n", err);
    assert_non_null(strstr(err, "[sim] scene = 'no-such-scene'"));
    assert_null(app.sim); /* its creation failed */
    rt_app_free(&app);
}

/* With a scene and trace the simulator knows, the mock IMU's board holds the simulated part, and the run stops at
 * the first real device (the GPIO chip that does not exist), past the IMU the simulator plays. */
static void test_mock_device_holds_the_simulated_board(void **state)
{
    (void)state;
    rt_config c;
    rpi5_config(&c, "mock");
    snprintf(c.scene, sizeof c.scene, "room");
    snprintf(c.trace, sizeof c.trace, "slow");
    char err[400] = "";
    assert_false(rt_app_init(&app, &c, err, sizeof err));
    print_message("%s\n", err);
    assert_non_null(strstr(err, "[vsync]"));
    assert_non_null(strstr(err, "/nonexistent/gpiochip9"));
    assert_non_null(app.sim);
    assert_non_null(rt_simboard_scene(app.sim));
    rt_app_free(&app);
    assert_null(app.sim);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_which_configs_simulate),
        cmocka_unit_test(test_real_board_skips_the_simulator),
        cmocka_unit_test(test_mock_device_loads_the_simulator),
        cmocka_unit_test(test_mock_device_holds_the_simulated_board),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
