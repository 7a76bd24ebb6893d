/* SPDX-License-Identifier: MIT */
/* The KMS output's pure parts and rules: the R/B-swapping copy into XRGB8888 (and the plain one into XBGR8888), the
 * late-flip rule on vblank sequences, the config rules of output = kms and vsync backend = kms, the --check-config
 * warning for a real board that displays nowhere, and the errors without a DRM device. The device itself: the vkms
 * HIL scenario. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>
#include <cmocka.h>

#include "drivers/drv_vsync_kms.h"
#include "platform/plat_kms.h"
#include "runtime/rt_config.h"

static bool has_msg(const rt_config_errors *e, const char *needle)
{
    for (int i = 0; i < e->count && i < 16; i++)
        if (strstr(e->msg[i], needle)) return true;
    return false;
}

/* 3x2 pixels inside rows of 5 (stride), into a buffer of 16-byte rows: 12 bytes of pixels and 4 of padding. */
static void test_copy(void **state)
{
    (void)state;
    warp_rgba8 px[10];
    for (int i = 0; i < 10; i++) px[i] = (warp_rgba8){(uint8_t)(10 * i + 1), (uint8_t)(10 * i + 2), (uint8_t)(10 * i + 3), 7};
    warp_image_rgba8 img = {3, 2, 5, px};
    uint8_t buf[32];
    memset(buf, 0xEE, sizeof buf);
    plat_kms_copy_to_xrgb(buf, 16, &img);
    for (int y = 0; y < 2; y++) {
        for (int x = 0; x < 3; x++) {
            const warp_rgba8 s = px[y * 5 + x];
            const uint8_t *d = buf + y * 16 + 4 * x;
            /* XRGB8888 is a little-endian word: bytes B, G, R, X (X opaque whatever alpha was) */
            assert_int_equal(d[0], s.b);
            assert_int_equal(d[1], s.g);
            assert_int_equal(d[2], s.r);
            assert_int_equal(d[3], 0xff);
        }
        for (int i = 12; i < 16; i++) assert_int_equal(buf[y * 16 + i], 0xEE); /* padding untouched */
    }
    memset(buf, 0xEE, sizeof buf);
    plat_kms_copy_to_xbgr(buf, 16, &img);
    for (int y = 0; y < 2; y++) {
        assert_memory_equal(buf + y * 16, &px[y * 5], 12); /* XBGR8888 is RGBA8 byte for byte */
        for (int i = 12; i < 16; i++) assert_int_equal(buf[y * 16 + i], 0xEE);
    }
}

/* Feeds completion sequences through the rule as the event thread does and counts late flips. */
static int count_late(const uint32_t *seq, int n)
{
    bool have = false;
    uint32_t prev = 0;
    int late = 0;
    for (int i = 0; i < n; i++) {
        late += plat_kms_flip_is_late(have, prev, seq[i]);
        have = true;
        prev = seq[i];
    }
    return late;
}

static void test_late_flips(void **state)
{
    (void)state;
    assert_false(plat_kms_flip_is_late(false, 0, 100)); /* the first flip after the modeset has no predecessor */
    assert_false(plat_kms_flip_is_late(true, 100, 101));
    assert_true(plat_kms_flip_is_late(true, 100, 102)); /* vblank 101 showed the previous frame again */
    assert_true(plat_kms_flip_is_late(true, 100, 110));
    assert_false(plat_kms_flip_is_late(true, 0xffffffffu, 0)); /* across the counter's wrap */
    assert_true(plat_kms_flip_is_late(true, 0xfffffffeu, 0));
    const uint32_t every[] = {50, 51, 52, 53, 54};
    assert_int_equal(count_late(every, 5), 0);
    const uint32_t gaps[] = {50, 51, 53, 54, 57, 58}; /* two repeats: 52, and 55-56 */
    assert_int_equal(count_late(gaps, 6), 2);
}

static void test_config_rules(void **state)
{
    (void)state;
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors e = {0};
    /* the CPU path drives KMS now */
    assert_true(rt_config_set(&c, "display.output=kms", &e));
    assert_true(rt_config_set(&c, "render.renderer=cpu", &e));
    assert_true(rt_config_validate(&c, &e));
    assert_true(rt_config_set(&c, "vsync.backend=kms", &e));
    assert_true(rt_config_validate(&c, &e));
    assert_true(rt_config_set(&c, "render.renderer=gles", &e));
    assert_true(rt_config_validate(&c, &e));
    assert_int_equal(e.count, 0);
    /* vblank pacing needs the KMS output */
    assert_true(rt_config_set(&c, "display.output=offscreen", &e));
    assert_false(rt_config_validate(&c, &e));
    assert_true(has_msg(&e, "[vsync] backend = kms: needs [display] output = kms"));
    /* a sink with output = kms would get images nobody drew (GLES) or take them from the panel */
    e.count = 0;
    assert_true(rt_config_set(&c, "display.output=kms", &e));
    assert_true(rt_config_set(&c, "display.sink=png", &e));
    assert_false(rt_config_validate(&c, &e));
    assert_true(has_msg(&e, "[display] sink = png"));
    e.count = 0;
    assert_false(rt_config_set(&c, "vsync.backend=drm", &e));
}

static void test_displays_nowhere_warning(void **state)
{
    (void)state;
    rt_config c;
    rt_config_errors w = {0};
    /* the simulated board and the built-in defaults display nowhere on purpose */
    rt_config_defaults(&c);
    rt_config_warnings(&c, &w);
    assert_int_equal(w.count, 0);
    rt_config_errors e = {0};
    assert_true(rt_config_load(&c, "board/sim/board.ini", &e));
    rt_config_warnings(&c, &w);
    assert_int_equal(w.count, 0);
    /* a named board, offscreen with the null sink */
    rt_config_defaults(&c);
    assert_true(rt_config_set(&c, "board.name=myboard", &e));
    rt_config_warnings(&c, &w);
    assert_int_equal(w.count, 1);
    assert_true(has_msg(&w, "board 'myboard' displays nowhere"));
    /* ... not when it shows the panel, or writes its frames somewhere */
    w.count = 0;
    assert_true(rt_config_set(&c, "display.output=kms", &e));
    rt_config_warnings(&c, &w);
    assert_int_equal(w.count, 0);
    assert_true(rt_config_set(&c, "display.output=offscreen", &e));
    assert_true(rt_config_set(&c, "display.sink=raw", &e));
    rt_config_warnings(&c, &w);
    assert_int_equal(w.count, 0);
    /* unnamed, but with a real device */
    rt_config_defaults(&c);
    assert_true(rt_config_set(&c, "imu.backend=i2c", &e));
    assert_true(rt_config_set(&c, "imu.device=/dev/i2c-1", &e));
    rt_config_warnings(&c, &w);
    assert_int_equal(w.count, 1);
    /* mocks are not real devices */
    w.count = 0;
    assert_true(rt_config_set(&c, "imu.device=mock", &e));
    rt_config_warnings(&c, &w);
    assert_int_equal(w.count, 0);
    assert_int_equal(e.count, 0);
}

/* Every shipped real board shows its picture somewhere. */
static void test_boards_display(void **state)
{
    (void)state;
    const char *boards[] = {"board/rpi5/board.ini", "board/generic-aarch64/board.ini"};
    for (size_t i = 0; i < sizeof boards / sizeof boards[0]; i++) {
        rt_config c;
        rt_config_defaults(&c);
        rt_config_errors e = {0}, w = {0};
        assert_true(rt_config_load(&c, boards[i], &e));
        assert_true(rt_config_validate(&c, &e));
        rt_config_warnings(&c, &w);
        if (w.count) fail_msg("%s: %s", boards[i], w.msg[0]);
        assert_string_equal(c.output, "kms");
    }
}

static void test_no_device(void **state)
{
    (void)state;
    char err[300];
    plat_kms_params p = {"/nonexistent/dri/card0", "auto", 0, 0, 0, 0};
    assert_null(plat_kms_open(&p, err, sizeof err));
    assert_string_equal(err, "no DRM device: /nonexistent/dri/card0: No such file or directory");
    FILE *probe = fopen("/dev/dri/card0", "r");
    if (!probe) {
        p.device = "auto";
        assert_null(plat_kms_open(&p, err, sizeof err));
        assert_non_null(strstr(err, "kms_device = auto: no /dev/dri/cardN with a connected connector"));
    } else {
        fclose(probe);
    }
    /* the vblank source without a KMS output */
    assert_null(drv_kms_vblank_edges_open(NULL, err, sizeof err));
    assert_non_null(strstr(err, "output = kms"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_copy),           cmocka_unit_test(test_late_flips),
        cmocka_unit_test(test_config_rules),   cmocka_unit_test(test_displays_nowhere_warning),
        cmocka_unit_test(test_boards_display), cmocka_unit_test(test_no_device),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
