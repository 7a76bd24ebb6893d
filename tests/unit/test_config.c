/* SPDX-License-Identifier: MIT */
/* Tests of configuration loading: defaults and every shipped board.ini validate, errors name the line and key,
 * command-line overrides apply, and cross-key validation catches a lens that folds over. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>
#include <cmocka.h>

#include "runtime/rt_config.h"
#include "warp/warp_head.h"

static bool has_error(const rt_config_errors *e, const char *needle)
{
    for (int i = 0; i < e->count && i < 16; i++)
        if (strstr(e->msg[i], needle)) return true;
    return false;
}

static void test_defaults_valid(void **state)
{
    (void)state;
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors e = {0};
    assert_true(rt_config_validate(&c, &e));
    assert_int_equal(e.count, 0);
}

static void test_sim_board_ini_valid(void **state)
{
    (void)state;
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors e = {0};
    assert_true(rt_config_load(&c, "board/sim/board.ini", &e));
    assert_true(rt_config_validate(&c, &e));
    assert_string_equal(c.board_name, "sim");
}

static void test_values_parsed(void **state)
{
    (void)state;
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors e = {0};
    const char *ini = "; comment\n[display]\nrefresh_hz = 120\n[lens]\nk_red = 1 0.1 0.2 0.3\n[warp]\nmethod = raytrace\n"
                      "[sim]\nseed = 42\nscene = near\n";
    assert_true(rt_config_load_string(&c, ini, "t.ini", &e));
    assert_true(c.refresh_hz == 120);
    assert_true(c.k[0][3] == 0.3);
    assert_int_equal(c.method, RT_METHOD_RAYTRACE);
    assert_int_equal(c.seed, 42);
    assert_string_equal(c.scene, "near");
}

static void test_errors_name_line_and_key(void **state)
{
    (void)state;
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors e = {0};
    const char *ini = "[display]\n"
                      "refresh_hz = fast\n"        /* line 2: not a number */
                      "colour = blue\n"            /* line 3: unknown key */
                      "[nonsense]\n"
                      "x = 1\n"                    /* line 5: unknown section */
                      "[lens]\n"
                      "k_red = 1 2\n"              /* line 7: too few numbers */
                      "this line is broken\n"      /* line 8: syntax */
                      "[warp]\n"
                      "method = teleport\n";       /* line 10: not a choice */
    assert_false(rt_config_load_string(&c, ini, "bad.ini", &e));
    assert_true(has_error(&e, "bad.ini:2: [display] refresh_hz = 'fast'"));
    assert_true(has_error(&e, "bad.ini:3: unknown key 'colour' in [display]"));
    assert_true(has_error(&e, "bad.ini:5: unknown section [nonsense]"));
    assert_true(has_error(&e, "bad.ini:7: [lens] k_red"));
    assert_true(has_error(&e, "bad.ini:8: syntax error"));
    assert_true(has_error(&e, "bad.ini:10: [warp] method = 'teleport'"));
    /* bad values leave the defaults in place */
    assert_true(c.refresh_hz == 90);
}

static void test_ranges_enforced(void **state)
{
    (void)state;
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors e = {0};
    assert_false(rt_config_set(&c, "display.refresh_hz=0", &e));
    assert_false(rt_config_set(&c, "render.threads=2.5", &e));
    assert_false(rt_config_set(&c, "eye.ipd=nan", &e));
    assert_false(rt_config_set(&c, "display.width", &e));
    assert_true(has_error(&e, "expected section.key=value"));
    assert_true(rt_config_set(&c, "render.threads=1", &e));
    assert_int_equal(c.threads, 1);
    assert_false(rt_config_set(&c, "render.kernel=avx3", &e));
    assert_true(has_error(&e, "[render] kernel = 'avx3'"));
    assert_true(rt_config_set(&c, "render.kernel=scalar", &e));
    assert_string_equal(rt_kernel_name(c.kernel), "scalar");
}

static void test_folding_lens_rejected(void **state)
{
    (void)state;
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors e = {0};
    assert_true(rt_config_set(&c, "lens.k_blue=1 -0.5 0 0", &e));
    assert_false(rt_config_validate(&c, &e));
    assert_true(has_error(&e, "[lens]"));
    assert_true(has_error(&e, "blue"));
}

static void test_eye_cameras_mirrored(void **state)
{
    (void)state;
    rt_config c;
    rt_config_defaults(&c);
    warp_camera l = rt_config_eye_camera(&c, WARP_EYE_LEFT), r = rt_config_eye_camera(&c, WARP_EYE_RIGHT);
    assert_true(l.tan_left == r.tan_right && l.tan_right == r.tan_left);
    warp_lens ll = rt_config_lens(&c, WARP_EYE_LEFT), lr = rt_config_lens(&c, WARP_EYE_RIGHT);
    assert_true(ll.center_x + lr.center_x == c.panel_w / 2.0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_defaults_valid),          cmocka_unit_test(test_sim_board_ini_valid),
        cmocka_unit_test(test_values_parsed),           cmocka_unit_test(test_errors_name_line_and_key),
        cmocka_unit_test(test_ranges_enforced),         cmocka_unit_test(test_folding_lens_rejected),
        cmocka_unit_test(test_eye_cameras_mirrored),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
