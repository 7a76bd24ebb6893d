/* SPDX-License-Identifier: MIT */
/* hmdwarp-lens import and fit end to end: each format's section, loaded back as board.ini, builds the same lens as
 * the model built from the source's parameters directly; the fit recovers a known lens from a CSV; malformed JSON,
 * YAML and CSV are refused with a message naming what was wrong (file, line, key), never a crash. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "runtime/rt_config.h"
#include "tests/support/test_util.h"
#include "warp/warp_lens_models.h"

static char tool[256], dir[256];
static const char board[] = "[display]\nwidth = 2160\nheight = 1200\n[eye]\nwidth = 1080\nheight = 1200\n";

static int run(const char *args, char *out, size_t cap) { return test_run_program(tool, args, out, cap); }

static const char *path_of(const char *name)
{
    static char p[4][400];
    static int i;
    i = (i + 1) % 4;
    snprintf(p[i], sizeof p[i], "%s/%s", dir, name);
    return p[i];
}

static void write_file(const char *name, const char *text)
{
    FILE *f = fopen(path_of(name), "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

/* The tool's section (in out, after any residual lines) loaded over the test board. */
static warp_lens lens_of(const char *out, rt_config *c)
{
    const char *sec = strstr(out, "[lens]");
    assert_non_null(sec);
    static char text[8000];
    snprintf(text, sizeof text, "%s%s", board, sec);
    rt_config_defaults(c);
    rt_config_errors err = {0};
    bool ok = rt_config_load_string(c, text, "section", &err);
    if (!ok) print_error("%s\n", err.msg[0]);
    assert_true(ok);
    assert_true(rt_config_validate(c, &err));
    return rt_config_lens(c, 0);
}

/* `import --config board.ini OPT NAME` of text written to DIR/NAME: the section it prints, loaded over the board. */
static warp_lens import_file(const char *name, const char *text, const char *opt, rt_config *c)
{
    char out[8000], args[1000];
    write_file(name, text);
    snprintf(args, sizeof args, "import --config %s %s %s", path_of("board.ini"), opt, path_of(name));
    assert_int_equal(run(args, out, sizeof out), 0);
    return lens_of(out, c);
}

static void same_lens(const warp_lens *a, const warp_lens *b, int vw, int vh)
{
    for (int y = 0; y <= vh; y += vh / 6)
        for (int x = 0; x <= vw; x += vw / 6)
            for (int c = 0; c < 3; c++) {
                double ua, va, ub, vb;
                warp_lens_distort(a, c, x, y, &ua, &va);
                warp_lens_distort(b, c, x, y, &ub, &vb);
                assert_true(fabs(ua - ub) < 1e-9 && fabs(va - vb) < 1e-9);
            }
}

static void test_import_openhmd(void **state)
{
    (void)state;
    char out[8000];
    write_file("board.ini", board);
    char args[1000];
    snprintf(args, sizeof args,
             "import --config %s --openhmd 0.098,0.324,-0.241,0.819 --aberration 0.9952420,1.0,1.0008074 "
             "--screen 0.12032,0.06684 --lens-sep 0.054 --eye-to-screen 0.04",
             path_of("board.ini"));
    assert_int_equal(run(args, out, sizeof out), 0);
    rt_config c;
    warp_lens got = lens_of(out, &c);
    assert_int_equal(got.model, WARP_LENS_PANOTOOLS);
    warp_lens_openhmd_device d = {.k = {0.098, 0.324, -0.241, 0.819}, .aberration = {0.9952420, 1.0, 1.0008074},
                                  .hsize = 0.12032, .vsize = 0.06684, .hres = 2160, .vres = 1200, .lens_sep = 0.054,
                                  .lens_vpos = 0.06684 / 2, .eye_to_screen = 0.04};
    warp_lens_panotools_params p;
    assert_true(warp_lens_openhmd_params(&d, &p, NULL, 0));
    warp_lens want = warp_lens_panotools(&p);
    same_lens(&got, &want, 1080, 1200);
    /* the right eye is the mirror image */
    warp_lens right = rt_config_lens(&c, 1);
    double ul, vl, ur, vr;
    warp_lens_distort(&got, 0, 100, 200, &ul, &vl);
    warp_lens_distort(&right, 0, 980, 200, &ur, &vr);
    assert_true(fabs(ul + ur) < 1e-12 && fabs(vl - vr) < 1e-12);
    /* a missing geometry option is named */
    assert_int_equal(run("import --openhmd 0.1,0.3,-0.2,0.8 --screen 0.12,0.07", out, sizeof out), 2);
    assert_non_null(strstr(out, "--lens-sep"));
    assert_int_equal(run("import --openhmd 0.1,0.3 --screen 0.12,0.07 --lens-sep 0.05 --eye-to-screen 0.04", out,
                         sizeof out),
                     2);
    assert_non_null(strstr(out, "--openhmd"));
}

static const char vive_json[] =
    "{\"device\": {\"physical_aspect_x_over_y\": 0.9},\n"
    " \"tracking_to_eye_transform\": [{\n"
    "  \"distortion\": {\"center_x\": 0.0894, \"center_y\": -0.009, \"coeffs\": [-0.188, -0.221, -0.254]},\n"
    "  \"distortion_red\": {\"center_x\": 0.0890, \"center_y\": -0.009, \"coeffs\": [-0.022, -0.049, -0.079]},\n"
    "  \"distortion_blue\": {\"center_x\": 0.0898, \"center_y\": -0.009, \"coeffs\": [-0.073, -0.023, 0.025]},\n"
    "  \"grow_for_undistort\": 0.6, \"undistort_r2_cutoff\": 1.116,\n"
    "  \"intrinsics\": [[0.92, 0.0, -0.06], [0.0, 1.02, 0.01], [0.0, 0.0, -1.0]]\n"
    " }, {}]}\n";

static void test_import_vive(void **state)
{
    (void)state;
    rt_config c;
    warp_lens got = import_file("vive.json", vive_json, "--vive", &c);
    warp_lens_vive_params p = {.k = {{-0.022, -0.049, -0.079, 0}, {-0.188, -0.221, -0.254, 0}, {-0.073, -0.023, 0.025, 0}},
                               .center = {{0.0890, -0.009}, {0.0894, -0.009}, {0.0898, -0.009}},
                               .aspect_x_over_y = 0.9, .intrinsics = {0.92, -0.06, 1.02, 0.01}, .r2_cutoff = 1.116};
    warp_lens want = warp_lens_vive(&p, 1080, 1200);
    same_lens(&got, &want, 1080, 1200);
}

static const char opencv_yaml[] = "%YAML:1.0\n"
                                  "---\n"
                                  "image_width: 540\n"
                                  "image_height: 600\n"
                                  "camera_matrix: !!opencv-matrix\n"
                                  "   rows: 3\n"
                                  "   cols: 3\n"
                                  "   dt: d\n"
                                  "   data: [ 350., 0., 272.5, 0., 345., 299., 0., 0., 1. ]\n"
                                  "distortion_coefficients: !!opencv-matrix\n"
                                  "   rows: 5\n"
                                  "   cols: 1\n"
                                  "   dt: d\n"
                                  "   data: [ -0.21, 0.045, 0.0012, -0.0008, -0.004 ]\n";

static void test_import_opencv_and_cardboard(void **state)
{
    (void)state;
    rt_config c;
    warp_lens got = import_file("cam.yaml", opencv_yaml, "--opencv", &c);
    char out[8000], args[1000];
    /* the 540 x 600 calibration image scaled to the 1080 x 1200 viewport */
    warp_lens_opencv_params p = {700, 690, 545, 598, -0.21, 0.045, 0.0012, -0.0008, -0.004};
    warp_lens want = warp_lens_opencv(&p);
    same_lens(&got, &want, 1080, 1200);
    /* the same numbers written longer than 60 characters (the limit the reader once had) */
    static char longer[2000];
    const char *at = strstr(opencv_yaml, "350.");
    const int head = (int)(at - opencv_yaml);
    snprintf(longer, sizeof longer, "%.*s350.%070d%s", head, opencv_yaml, 0, at + strlen("350."));
    got = import_file("long.yaml", longer, "--opencv", &c);
    same_lens(&got, &want, 1080, 1200);

    snprintf(args, sizeof args,
             "import --config %s --cardboard 0.441,0.156 --screen 0.12096,0.06804 --screen-to-lens 0.042 "
             "--inter-lens 0.06 --tray-to-lens 0.035",
             path_of("board.ini"));
    assert_int_equal(run(args, out, sizeof out), 0);
    got = lens_of(out, &c);
    warp_lens_cardboard_params cp = {.k = {0.441, 0.156, 0, 0}, .screen_to_lens = 0.042, .inter_lens = 0.06,
                                     .tray_to_lens = 0.035, .screen_w = 0.12096, .screen_h = 0.06804};
    want = warp_lens_cardboard(&cp, 1080, 1200);
    same_lens(&got, &want, 1080, 1200);
}

/* Malformed inputs: exit 2 and a message naming the file and what was wrong. */
static void test_import_malformed(void **state)
{
    (void)state;
    const struct {
        const char *name, *text, *opt, *expect;
    } cases[] = {
        {"trunc.json", "{\"tracking_to_eye_transform\": [{\"distortion\": {\"coeffs\": [0.1, ", "--vive",
         "not JSON"},
        {"noeyes.json", "{\"device\": {}}", "--vive", "tracking_to_eye_transform: missing"},
        {"coeffs.json", "{\"tracking_to_eye_transform\": [{\"distortion\": {\"center_x\": 0, \"center_y\": 0, "
                        "\"coeffs\": \"x\"}}]}",
         "--vive", "distortion.coeffs: expected an array of 3 or 4 numbers"},
        {"intr.json", "{\"tracking_to_eye_transform\": [{\"distortion\": {\"center_x\": 0, \"center_y\": 0, "
                      "\"coeffs\": [0, 0, 0]}, \"intrinsics\": [[1, 0]]}]}",
         "--vive", "intrinsics: expected a 3 x 3 array"},
        {"bad.yaml", "%YAML:1.0\ncamera_matrix: !!opencv-matrix\n  data: [1, 2\n  rows: 3\n", "--opencv", "not YAML"},
        {"nocam.yaml", "%YAML:1.0\ndistortion_coefficients: !!opencv-matrix\n  data: [0, 0, 0, 0, 0]\n", "--opencv",
         "camera_matrix: missing"},
        {"word.yaml", "camera_matrix:\n  data: [700, 0, 540, 0, 700, x, 0, 0, 1]\n"
                      "distortion_coefficients:\n  data: [0, 0, 0, 0, 0]\n",
         "--opencv", ":2: camera_matrix.data[5]: not a number"},
        {"rational.yaml", "camera_matrix:\n  data: [700, 0, 540, 0, 700, 600, 0, 0, 1]\n"
                          "distortion_coefficients:\n  data: [0, 0, 0, 0, 0, 0.5, 0, 0]\n",
         "--opencv", "only k1 k2 p1 p2 k3"},
        {"empty.yaml", "", "--opencv", "expected a mapping"},
    };
    char out[8000], args[1000];
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        write_file(cases[i].name, cases[i].text);
        snprintf(args, sizeof args, "import --config %s %s %s", path_of("board.ini"), cases[i].opt,
                 path_of(cases[i].name));
        int st = run(args, out, sizeof out);
        if (st != 2 || !strstr(out, cases[i].expect) || !strstr(out, cases[i].name))
            print_error("%s: status %d, output: %s\n", cases[i].name, st, out);
        assert_int_equal(st, 2);
        assert_non_null(strstr(out, cases[i].expect));
        assert_non_null(strstr(out, cases[i].name));
    }
    snprintf(args, sizeof args, "import --vive %s/nonexistent.json", dir);
    assert_int_equal(run(args, out, sizeof out), 2);
    assert_non_null(strstr(out, "cannot read"));
}

/* fit: a CSV from a known lens (the board's centre and scale, noise-free) gives back its coefficients. */
static void test_fit(void **state)
{
    (void)state;
    static char csv[400000];
    warp_lens l = test_reference_lens(560, 600, 540);
    const char *const name[3] = {"red", "green", "blue"};
    size_t n = (size_t)snprintf(csv, sizeof csv, "channel,panel_x,panel_y,u,v\n# a comment\n");
    for (int y = 0; y <= 1200; y += 60)
        for (int x = 0; x <= 1080; x += 60)
            for (int c = 0; c < 3; c++) {
                double u, v;
                warp_lens_distort(&l, c, x + 0.5, y + 0.5, &u, &v);
                n += (size_t)snprintf(csv + n, sizeof csv - n, "%s,%.1f,%.1f,%.17g,%.17g\n", name[c], x + 0.5, y + 0.5,
                                      u, v);
            }
    write_file("corr.csv", csv);
    char fitboard[300];
    snprintf(fitboard, sizeof fitboard, "%s[lens]\ncenter = 560 600\nscale = 540\n", board);
    write_file("fitboard.ini", fitboard);
    char out[8000], args[1000];
    snprintf(args, sizeof args, "fit %s --config %s --model poly", path_of("corr.csv"), path_of("fitboard.ini"));
    assert_int_equal(run(args, out, sizeof out), 0);
    assert_non_null(strstr(out, "green: 399 points, residual RMS 0.000 px"));
    rt_config c;
    warp_lens got = lens_of(out, &c);
    for (int ch = 0; ch < 3; ch++)
        for (int i = 0; i < 4; i++) assert_true(fabs(got.ch[ch].k[i] - l.ch[ch].k[i]) < 1e-8);
    /* panotools: the same even lens approximated by odd and even terms (0.76 px RMS here) */
    snprintf(args, sizeof args, "fit %s --config %s --model panotools --out %s", path_of("corr.csv"),
             path_of("fitboard.ini"), path_of("pano.ini"));
    assert_int_equal(run(args, out, sizeof out), 0);
    const char *p = strstr(out, "green: 399 points, residual RMS ");
    assert_non_null(p);
    assert_true(atof(p + strlen("green: 399 points, residual RMS ")) < 1.5);
    /* --out into a board's calibration file: its [lens] keys are set, its IMU calibration and comments kept */
    write_file("cal.ini", "; this unit's calibration\n[imu]\ngyro_bias = 0.01 -0.002 0.003\n[lens]\nk_red = 9 9 9 9\n");
    snprintf(args, sizeof args, "fit %s --config %s --model poly --out %s", path_of("corr.csv"),
             path_of("fitboard.ini"), path_of("cal.ini"));
    assert_int_equal(run(args, out, sizeof out), 0);
    static char cal[8000];
    assert_true(test_slurp(path_of("cal.ini"), cal, sizeof cal));
    assert_non_null(strstr(cal, "; this unit's calibration\n[imu]\ngyro_bias = 0.01 -0.002 0.003\n"));
    assert_null(strstr(cal, "9 9 9 9"));
    got = lens_of(cal, &c);
    for (int ch = 0; ch < 3; ch++)
        for (int i = 0; i < 4; i++) assert_true(fabs(got.ch[ch].k[i] - l.ch[ch].k[i]) < 1e-8);
    /* --fit-center: from a centre 20 pixels off, the lens's own */
    snprintf(fitboard, sizeof fitboard, "%s[lens]\ncenter = 545 615\nscale = 540\n", board);
    write_file("offboard.ini", fitboard);
    snprintf(args, sizeof args, "fit %s --config %s --fit-center", path_of("corr.csv"), path_of("offboard.ini"));
    assert_int_equal(run(args, out, sizeof out), 0);
    got = lens_of(out, &c);
    assert_true(fabs(c.lens_center[0] - 560) < 1e-3 && fabs(c.lens_center[1] - 600) < 1e-3);
    for (int ch = 0; ch < 3; ch++)
        for (int i = 0; i < 4; i++) assert_true(fabs(got.ch[ch].k[i] - l.ch[ch].k[i]) < 1e-5);
    /* a bad row names file:line; a channel without rows is named */
    write_file("badrow.csv", "channel,panel_x,panel_y,u,v\nred,1,2,0.1,0.2\ngreen,1,2,zero,0.2\n");
    snprintf(args, sizeof args, "fit %s --config %s", path_of("badrow.csv"), path_of("fitboard.ini"));
    assert_int_equal(run(args, out, sizeof out), 2);
    assert_non_null(strstr(out, "badrow.csv:3: expected channel,panel_x,panel_y,u,v"));
    /* a channel name longer than the reader's buffer is refused, not cut to "red" plus spaces and taken */
    write_file("longch.csv", "channel,panel_x,panel_y,u,v\nred            junk,1,2,0.1,0.2\n");
    snprintf(args, sizeof args, "fit %s --config %s", path_of("longch.csv"), path_of("fitboard.ini"));
    assert_int_equal(run(args, out, sizeof out), 2);
    assert_non_null(strstr(out, "longch.csv:2: expected channel,panel_x,panel_y,u,v"));
    write_file("nogreen.csv", "red,1,2,0.1,0.2\nblue,1,2,0.1,0.2\n");
    snprintf(args, sizeof args, "fit %s --config %s", path_of("nogreen.csv"), path_of("fitboard.ini"));
    assert_int_equal(run(args, out, sizeof out), 2);
    assert_non_null(strstr(out, "no rows for green"));
    snprintf(args, sizeof args, "fit %s --model vive", path_of("corr.csv"));
    assert_int_equal(run(args, out, sizeof out), 2);
}

int main(int argc, char **argv)
{
    (void)argc;
    char build[200];
    if (!test_build_dirs(argv[0], build, sizeof build, dir, sizeof dir, "lens-tool")) return 1;
    snprintf(tool, sizeof tool, "%s/hmdwarp-lens", build);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_import_openhmd), cmocka_unit_test(test_import_vive),
        cmocka_unit_test(test_import_opencv_and_cardboard), cmocka_unit_test(test_import_malformed),
        cmocka_unit_test(test_fit),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
