/* SPDX-License-Identifier: MIT */
/* Tests of configuration loading: defaults and every shipped board.ini validate, errors name the line and key (in
 * line order, right past over-long lines), command-line overrides apply, cross-key validation catches a lens that
 * folds over and names where each key was set, frame and memory limits hold the configured frames, and a path
 * that is no board.ini (a device, a directory, a FIFO, a huge or binary file) is refused at once. */
#include <fcntl.h>
#include <ini.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <cmocka.h>

#include "runtime/rt_config.h"
#include "warp/warp_head.h"
#include "tests/support/test_util.h"

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

/* inih reads INI_MAX_LINE - 1 characters a line (199 in Debian's libinih): a line of exactly that many is read,
 * a longer one is an error on its own line, and every line after keeps its number. */
static void test_long_lines_keep_line_numbers(void **state)
{
    (void)state;
    const int max = INI_MAX_LINE - 1;
    char ini[4096];
    /* line 2: a comment of exactly max characters; line 4: max + 1; line 6: a bad value; line 7: a key */
    int n = snprintf(ini, sizeof ini, "[display]\n;");
    for (int i = 1; i < max; i++) ini[n++] = 'a';
    n += snprintf(ini + n, sizeof ini - (size_t)n, "\nrefresh_hz = 120\n;");
    for (int i = 1; i < max + 1; i++) ini[n++] = 'b';
    n += snprintf(ini + n, sizeof ini - (size_t)n, "\n[eye]\nwidth = wide\nheight = 400\n");
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors e = {0};
    assert_false(rt_config_load_string(&c, ini, "long.ini", &e));
    assert_int_equal(e.count, 2);
    char want[64];
    snprintf(want, sizeof want, "long.ini:4: longer than %d characters", max);
    assert_non_null(strstr(e.msg[0], want));
    assert_non_null(strstr(e.msg[1], "long.ini:6: [eye] width = 'wide'"));
    assert_true(c.refresh_hz == 120); /* the line after the longest allowed one was read as itself */
    assert_int_equal(c.eye_h, 400);
    /* the same with CRLF line ends and a line of exactly max characters that is a key */
    char ini2[1024];
    n = snprintf(ini2, sizeof ini2, "[board]\r\nname = ");
    while (n < max + (int)strlen("[board]\r\n")) ini2[n++] = 'x';
    n += snprintf(ini2 + n, sizeof ini2 - (size_t)n, "\r\nbogus\r\n");
    rt_config_errors e2 = {0};
    rt_config_defaults(&c);
    assert_false(rt_config_load_string(&c, ini2, "crlf.ini", &e2));
    assert_int_equal(e2.count, 2); /* the name is longer than [board] name holds; then the syntax error */
    assert_non_null(strstr(e2.msg[0], "crlf.ini:2: [board] name"));
    assert_non_null(strstr(e2.msg[1], "crlf.ini:3: syntax error"));
}

/* An unclosed '[section' is the one error reported: the keys after it would be checked against the section before
 * it and give errors that are not the problem. Errors come in line order, syntax errors included. */
static void test_unclosed_section_one_error(void **state)
{
    (void)state;
    const char *ini = "[display]\n"
                      "refresh_hz = 120\n"
                      "[lens\n"                  /* line 3 */
                      "mesh = 8\n"
                      "scale = 300\n"
                      "center = 1 2\n"
                      "[warp]\n"
                      "method = raytrace\n";
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors e = {0};
    assert_false(rt_config_load_string(&c, ini, "u.ini", &e));
    assert_int_equal(e.count, 1);
    assert_non_null(strstr(e.msg[0], "u.ini:3: '[lens': section header without ']'"));
    assert_int_equal(c.mesh_n, 64); /* not applied to [display] or anywhere */
    assert_int_equal(c.method, RT_METHOD_RAYTRACE); /* the next section is read again */

    const char *ini2 = "[display]\nrefresh_hz = x\nnot a key\n[eye]\nwidth = 0\nalso not a key\n";
    rt_config_errors e2 = {0};
    assert_false(rt_config_load_string(&c, ini2, "o.ini", &e2));
    assert_int_equal(e2.count, 4);
    assert_non_null(strstr(e2.msg[0], "o.ini:2:"));
    assert_non_null(strstr(e2.msg[1], "o.ini:3: syntax error"));
    assert_non_null(strstr(e2.msg[2], "o.ini:5:"));
    assert_non_null(strstr(e2.msg[3], "o.ini:6: syntax error"));
}

/* Errors about several keys name where each was set: a line of the file, a command-line override, or the
 * default. */
static void test_cross_key_errors_name_origins(void **state)
{
    (void)state;
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors e = {0};
    assert_true(rt_config_load_string(&c, "; panel\n[display]\nwidth = 2881\nrefresh_hz = 20\n", "p.ini", &e));
    assert_true(rt_config_set(&c, "render.threads=1", &e));
    assert_true(rt_config_set(&c, "sim.host_rate_hz=60", &e));
    assert_false(rt_config_validate(&c, &e));
    bool even = false, rate = false;
    for (int i = 0; i < e.count; i++) {
        if (strstr(e.msg[i], "must be even")) {
            even = true;
            assert_non_null(strstr(e.msg[i], "[display] width (p.ini:3)"));
        }
        if (strstr(e.msg[i], "host_rate_hz")) {
            rate = true;
            assert_non_null(strstr(e.msg[i], "[sim] host_rate_hz (command line, override 2)"));
            assert_non_null(strstr(e.msg[i], "[display] refresh_hz (p.ini:4)"));
        }
        /* the lens check involves the panel size too: it names where width came from */
        if (strstr(e.msg[i], "[lens]")) assert_non_null(strstr(e.msg[i], "[display] width (p.ini:3)"));
    }
    assert_true(even && rate);

    rt_config_defaults(&c);
    rt_config_errors e2 = {0};
    assert_true(rt_config_load_string(&c, "[lens]\nk_blue = 1 -0.5 0 0\n", "l.ini", &e2));
    assert_false(rt_config_validate(&c, &e2));
    assert_non_null(strstr(e2.msg[0], "[lens] k_blue (l.ini:2)"));
    assert_non_null(strstr(e2.msg[0], "[lens] scale (default)"));
    /* a refused value keeps the origin of the value that stays */
    rt_config_errors e3 = {0};
    assert_false(rt_config_set(&c, "lens.k_blue=nonsense", &e3));
    rt_config_errors e4 = {0};
    assert_false(rt_config_validate(&c, &e4));
    assert_non_null(strstr(e4.msg[0], "[lens] k_blue (l.ini:2)"));
}

/* A frame limit that cannot hold the configured frames, and a configuration that allocates more than
 * max_memory_mb, fail validation naming the keys (before: --check-config passed, then every frame was rejected or
 * gigabytes were locked for a board that showed nothing). */
static void test_frame_and_memory_limits(void **state)
{
    (void)state;
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors e = {0};
    assert_true(rt_config_set(&c, "frames.backend=usb", &e));
    assert_true(rt_config_set(&c, "frames.device=mock", &e));
    /* defaults: two 1440x1600 eyes of colour and depth, 8 bytes a pixel, within 64 MiB */
    assert_true(rt_config_frame_bytes(&c) > 2ull * 1440 * 1600 * 8);
    assert_true(rt_config_frame_bytes(&c) < 2ull * 1440 * 1600 * 8 + 8192);
    assert_true(rt_config_validate(&c, &e));
    assert_true(rt_config_set(&c, "frames.max_frame_mb=1", &e));
    assert_false(rt_config_validate(&c, &e));
    assert_int_equal(e.count, 1);
    assert_non_null(strstr(e.msg[0], "[frames] max_frame_mb = 1:"));
    assert_non_null(strstr(e.msg[0], "[frames] max_frame_mb (command line, override 3)"));
    assert_non_null(strstr(e.msg[0], "[eye] width (default)"));
    /* the limit matters only where frames arrive as framelink bytes */
    assert_true(rt_config_set(&c, "frames.backend=sim", &e));
    e.count = 0;
    assert_true(rt_config_validate(&c, &e));
    /* the object and transparency warps' planes make the frame larger */
    uint64_t plain = rt_config_frame_bytes(&c);
    assert_true(rt_config_set(&c, "warp.method=auto", &e));
    assert_true(rt_config_frame_bytes(&c) == plain + 2ull * 1440 * 1600 * 3);

    /* memory: the defaults fit; the 8192 x 8192 eye and a 4096 MiB frame limit do not */
    rt_config_defaults(&c);
    assert_true(rt_config_memory_bytes(&c) < 512ull << 20);
    assert_true(rt_config_set(&c, "eye.width=8192", &e));
    assert_true(rt_config_set(&c, "eye.height=8192", &e));
    e.count = 0;
    assert_false(rt_config_validate(&c, &e));
    assert_int_equal(e.count, 1);
    assert_non_null(strstr(e.msg[0], "[render] max_memory_mb = 2048"));
    assert_non_null(strstr(e.msg[0], "[eye] width (command line, override 1)"));
    /* allowed when the budget is raised on purpose */
    assert_true(rt_config_set(&c, "render.max_memory_mb=65536", &e));
    e.count = 0;
    assert_true(rt_config_validate(&c, &e));
    rt_config_defaults(&c);
    assert_true(rt_config_set(&c, "frames.backend=usb", &e));
    assert_true(rt_config_set(&c, "frames.device=/dev/ffs-hmdwarp", &e));
    assert_true(rt_config_set(&c, "frames.max_frame_mb=4096", &e));
    e.count = 0;
    assert_false(rt_config_validate(&c, &e));
    assert_non_null(strstr(e.msg[0], "[frames] max_frame_mb (command line, override 3)"));
    assert_true(rt_config_memory_bytes(&c) > 4096ull << 20);

    /* more than this machine has: a warning (the budget is the board's; this may be the host that builds it) */
    rt_config_defaults(&c);
    const char *huge[] = {"eye.width=8192", "eye.height=8192", "warp.method=auto", "render.max_memory_mb=1048576"};
    for (int i = 0; i < 4; i++) assert_true(rt_config_set(&c, huge[i], &e));
    e.count = 0;
    assert_true(rt_config_validate(&c, &e));
    rt_config_errors w = {0};
    rt_config_warnings(&c, &w);
    const uint64_t phys = (uint64_t)sysconf(_SC_PHYS_PAGES) * (uint64_t)sysconf(_SC_PAGESIZE);
    assert_int_equal(has_error(&w, "more than this machine's"), rt_config_memory_bytes(&c) > phys);
    rt_config_defaults(&c);
    rt_config_errors w2 = {0};
    rt_config_warnings(&c, &w2);
    assert_int_equal(w2.count, 0);

    /* [frames] link_mbps limits the mock usb and socket links only: on any other it is said to do nothing */
    const char *links[][2] = {{"frames.backend=socket", "frames.device="}, {"frames.backend=usb", "frames.device=mock"},
                              {"frames.backend=usb", "frames.device=/dev/ffs-hmdwarp"}, {"frames.backend=sim", ""}};
    for (int i = 0; i < 4; i++) {
        rt_config_defaults(&c);
        assert_true(rt_config_set(&c, "frames.link_mbps=40", &e));
        assert_true(rt_config_set(&c, links[i][0], &e));
        if (links[i][1][0]) assert_true(rt_config_set(&c, links[i][1], &e));
        rt_config_errors w3 = {0};
        rt_config_warnings(&c, &w3);
        assert_int_equal(has_error(&w3, "[frames] link_mbps (command line, override 1) = 40: ignored"), i >= 2);
    }
}

static const char *write_tmp(const char *name, const void *data, size_t len)
{
    static char path[128];
    snprintf(path, sizeof path, "%s/%s", test_tmp(), name);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, len, f), len);
    fclose(f);
    return path;
}

/* Only a regular text file of at most RT_CONFIG_MAX_FILE_KB is read: /dev/zero hung, a directory ran on the
 * defaults. Each is one error naming the path, and nothing of the config changes. */
static void test_paths_that_are_no_board_ini(void **state)
{
    (void)state;
    struct {
        const char *path, *want;
    } cases[] = {
        {"/dev/zero", "/dev/zero: not a regular file"},
        {"/dev/null", "/dev/null: not a regular file"},
        {test_tmp(), "a directory"},
        {"/nonexistent/board.ini", "cannot open config file"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        rt_config c;
        rt_config_defaults(&c);
        rt_config_errors e = {0};
        assert_false(rt_config_load(&c, cases[i].path, &e));
        assert_int_equal(e.count, 1);
        if (!strstr(e.msg[0], cases[i].want)) fail_msg("%s: '%s', want '%s'", cases[i].path, e.msg[0], cases[i].want);
    }
    /* a FIFO: no writer, and the open must not wait for one */
    char fifo[128];
    snprintf(fifo, sizeof fifo, "%s/fifo", test_tmp());
    assert_int_equal(mkfifo(fifo, 0600), 0);
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors e = {0};
    assert_false(rt_config_load(&c, fifo, &e));
    assert_non_null(strstr(e.msg[0], "not a regular file"));
    /* too large: one byte over the limit is refused, the limit itself is read */
    size_t big = (size_t)RT_CONFIG_MAX_FILE_KB * 1024;
    char *text = malloc(big + 1);
    assert_non_null(text);
    memset(text, '\n', big + 1);
    memcpy(text, "[display]\nrefresh_hz = 60\n", 26);
    rt_config_errors e2 = {0};
    assert_false(rt_config_load(&c, write_tmp("big.ini", text, big + 1), &e2));
    char want[64];
    snprintf(want, sizeof want, "larger than %d KB", RT_CONFIG_MAX_FILE_KB);
    assert_non_null(strstr(e2.msg[0], want));
    rt_config_errors e3 = {0};
    assert_true(rt_config_load(&c, write_tmp("limit.ini", text, big), &e3));
    assert_true(c.refresh_hz == 60);
    free(text);
    /* binary: a NUL byte, named by its line */
    rt_config_errors e4 = {0};
    assert_false(rt_config_load(&c, write_tmp("nul.ini", "[display]\nwidth = 2\0\n", 21), &e4));
    assert_non_null(strstr(e4.msg[0], "nul.ini:2: a NUL byte"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_defaults_valid),          cmocka_unit_test(test_sim_board_ini_valid),
        cmocka_unit_test(test_values_parsed),           cmocka_unit_test(test_errors_name_line_and_key),
        cmocka_unit_test(test_ranges_enforced),         cmocka_unit_test(test_folding_lens_rejected),
        cmocka_unit_test(test_eye_cameras_mirrored),   cmocka_unit_test(test_long_lines_keep_line_numbers),
        cmocka_unit_test(test_unclosed_section_one_error), cmocka_unit_test(test_cross_key_errors_name_origins),
        cmocka_unit_test(test_frame_and_memory_limits), cmocka_unit_test(test_paths_that_are_no_board_ini),
    };
    return cmocka_run_group_tests(tests, test_tmp_setup, test_tmp_teardown);
}
