/* SPDX-License-Identifier: MIT */
/* Unit tests for warp_lens: identity lens vs the camera, distort/undistort round trips, chromatic aberration,
 * the monotonic (fold-over) radius against analytic roots, and warp_lens_check's verdicts. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>
#include <cmocka.h>

#include "tests/support/test_util.h"
#include "warp/warp_camera.h"
#include "warp/warp_lens.h"

/* A realistic HMD lens: 1440x1600 viewport, barrel-correcting polynomial, blue spread 0.8 % wider than red. */
static warp_lens realistic_lens(void)
{
    warp_lens l = {.ch = {{{0.996, 0.22, 0.24, 0.0}}, {{1.0, 0.22, 0.24, 0.0}}, {{1.008, 0.22, 0.24, 0.0}}},
                   .center_x = 720, .center_y = 800, .scale = 720};
    return l;
}

static warp_lens uniform_lens(double k0, double k1, double k2, double k3)
{
    warp_lens l = {.model = WARP_LENS_POLY};
    for (int c = 0; c < 3; c++) {
        l.ch[c].k[0] = k0;
        l.ch[c].k[1] = k1;
        l.ch[c].k[2] = k2;
        l.ch[c].k[3] = k3;
    }
    l.center_x = 720;
    l.center_y = 800;
    l.scale = 720;
    return l;
}

static void test_identity_matches_camera(void **state)
{
    (void)state;
    /* asymmetric frustum with square pixels: 1000 / 2.0 == 800 / 1.6 == 500 pixels per tangent */
    warp_camera cam = {1000, 800, 1.2, 0.8, 0.7, 0.9, 0.1, INFINITY};
    warp_lens l = warp_lens_identity(&cam);
    assert_null(warp_lens_check(&l, cam.width, cam.height, NULL, 0));
    for (int c = 0; c < 3; c++)
        assert_true(l.ch[c].k[0] == 1 && l.ch[c].k[1] == 0 && l.ch[c].k[2] == 0 && l.ch[c].k[3] == 0);
    assert_true(fabs(l.center_x - 600) < 1e-12 && fabs(l.center_y - 350) < 1e-12 && l.scale == 500);
    test_rng r = test_rng_make(11);
    for (int i = 0; i < 2000; i++) {
        double x = test_rng_uniform(&r, 0, cam.width), y = test_rng_uniform(&r, 0, cam.height);
        double ue, ve, xe, ye;
        warp_camera_pixel_to_tan(&cam, x, y, &ue, &ve);
        for (int c = 0; c < 3; c++) {
            double u, v, xb, yb;
            warp_lens_distort(&l, c, x, y, &u, &v);
            assert_true(fabs(u - ue) < 1e-13 && fabs(v - ve) < 1e-13);
            /* and the inverse is the camera's tan -> pixel */
            assert_true(warp_lens_undistort(&l, c, ue, ve, &xb, &yb));
            warp_camera_tan_to_pixel(&cam, ue, ve, &xe, &ye);
            assert_true(fabs(xb - xe) < 1e-10 && fabs(yb - ye) < 1e-10);
        }
    }
    /* the optical axis maps to the centre exactly */
    double x0, y0;
    assert_true(warp_lens_undistort(&l, 1, 0, 0, &x0, &y0));
    assert_true(x0 == l.center_x && y0 == l.center_y);
}

static void test_round_trips_realistic(void **state)
{
    (void)state;
    warp_lens l = realistic_lens();
    assert_true(isinf(warp_lens_monotonic_radius(&l, 0)) && isinf(warp_lens_monotonic_radius(&l, 2)));
    double max_px = 0, max_rel = 0;
    /* pixel -> tangent -> pixel over a dense grid including the viewport's edges and corners */
    for (int c = 0; c < 3; c++) {
        for (double y = 0; y <= 1600; y += 2.5) {
            for (double x = 0; x <= 1440; x += 2.5) {
                double u, v, xb = -1, yb = -1;
                warp_lens_distort(&l, c, x, y, &u, &v);
                assert_true(warp_lens_undistort(&l, c, u, v, &xb, &yb));
                max_px = fmax(max_px, fmax(fabs(xb - x), fabs(yb - y)));
            }
        }
    }
    /* tangent -> pixel -> tangent for random directions out to the corner's field of view */
    double u_corner, v_corner;
    warp_lens_distort(&l, 1, 0, 0, &u_corner, &v_corner);
    double tmax = hypot(u_corner, v_corner);
    test_rng r = test_rng_make(12);
    for (int i = 0; i < 100000; i++) {
        int c = i % 3;
        double ang = test_rng_uniform(&r, 0, 2 * WARP_PI), rad = tmax * sqrt(test_rng_uniform(&r, 0, 1));
        double u = rad * cos(ang), v = rad * sin(ang), x, y, ub, vb;
        assert_true(warp_lens_undistort(&l, c, u, v, &x, &y));
        warp_lens_distort(&l, c, x, y, &ub, &vb);
        max_rel = fmax(max_rel, hypot(ub - u, vb - v) / fmax(rad, 1e-300));
    }
    print_message("lens round trip: max pixel error %.3g px, max tangent relative error %.3g\n", max_px, max_rel);
    assert_true(max_px < 1e-11); /* far inside the 1e-4 px budget */
    assert_true(max_rel < 1e-13);
}

static void test_chromatic_aberration(void **state)
{
    (void)state;
    warp_lens l = realistic_lens();
    const double pts[][2] = {{720, 800}, {721, 800}, {900, 600}, {0, 0}, {1440, 1600}, {100, 1500}};
    for (size_t i = 0; i < sizeof pts / sizeof pts[0]; i++) {
        double x = pts[i][0], y = pts[i][1];
        double q2 = (pow(x - 720, 2) + pow(800 - y, 2)) / (720.0 * 720.0);
        double sg = 1.0 + 0.22 * q2 + 0.24 * q2 * q2;
        double t[3][2];
        for (int c = 0; c < 3; c++) warp_lens_distort(&l, c, x, y, &t[c][0], &t[c][1]);
        /* each channel's tangent is green's scaled by s_c / s_green: the k0 offsets -0.004 and +0.008 */
        for (int j = 0; j < 2; j++) {
            assert_true(fabs(t[0][j] - t[1][j] * (sg - 0.004) / sg) < 1e-14);
            assert_true(fabs(t[2][j] - t[1][j] * (sg + 0.008) / sg) < 1e-14);
        }
        if (x != 720 || y != 800) {
            /* blue is seen farther out than green, red nearer */
            assert_true(hypot(t[2][0], t[2][1]) > hypot(t[1][0], t[1][1]));
            assert_true(hypot(t[0][0], t[0][1]) < hypot(t[1][0], t[1][1]));
        }
    }
    /* so to show one direction in all colours, red must be drawn farther from the centre than green, blue nearer */
    double xr, yr, xg, yg, xbl, ybl;
    assert_true(warp_lens_undistort(&l, 0, 0.5, -0.3, &xr, &yr));
    assert_true(warp_lens_undistort(&l, 1, 0.5, -0.3, &xg, &yg));
    assert_true(warp_lens_undistort(&l, 2, 0.5, -0.3, &xbl, &ybl));
    assert_true(xr > xg && xg > xbl && yr > yg && yg > ybl);
}

static void test_monotonic_radius_analytic(void **state)
{
    (void)state;
    /* g(x) = 1 - 1.5 x -> x = 2/3 */
    warp_lens l = uniform_lens(1, -0.5, 0, 0);
    for (int c = 0; c < 3; c++) assert_true(fabs(warp_lens_monotonic_radius(&l, c) - sqrt(2.0 / 3.0)) < 1e-14);
    /* g(x) = 1 - 1.5 x^2 -> x = sqrt(2/3) */
    l = uniform_lens(1, 0, -0.3, 0);
    assert_true(fabs(warp_lens_monotonic_radius(&l, 1) - sqrt(sqrt(2.0 / 3.0))) < 1e-14);
    /* g(x) = 1 - 7 x^3 -> x = 7^(-1/3) */
    l = uniform_lens(1, 0, 0, -1);
    assert_true(fabs(warp_lens_monotonic_radius(&l, 1) - sqrt(cbrt(1.0 / 7.0))) < 1e-14);
    /* g(x) = (1 - 2x)(1 - x/2)(1 + x/3): three real roots, smallest positive 0.5 */
    l = uniform_lens(1, (-2.5 + 1.0 / 3.0) / 3.0, (1.0 - 5.0 / 6.0) / 5.0, (1.0 / 3.0) / 7.0);
    assert_true(fabs(warp_lens_monotonic_radius(&l, 1) - sqrt(0.5)) < 1e-14);
    /* g(x) = 1 - x + x^2/2 dips but stays positive: monotonic everywhere */
    l = uniform_lens(1, -1.0 / 3.0, 1.0 / 10.0, 0);
    assert_true(isinf(warp_lens_monotonic_radius(&l, 1)));
    /* g(x) = (1 - x)^2 touches zero at x = 1 (a double root) */
    l = uniform_lens(1, -2.0 / 3.0, 1.0 / 5.0, 0);
    assert_true(fabs(warp_lens_monotonic_radius(&l, 1) - 1.0) < 1e-7);
    /* no distortion, and k0 <= 0 (folded at the centre) */
    l = uniform_lens(2, 0, 0, 0);
    assert_true(isinf(warp_lens_monotonic_radius(&l, 0)));
    l = uniform_lens(0, 1, 0, 0);
    assert_true(warp_lens_monotonic_radius(&l, 0) == 0);
    l = uniform_lens(-1, 1, 0, 0);
    assert_true(warp_lens_monotonic_radius(&l, 0) == 0);
}

static void test_monotonic_radius_random(void **state)
{
    (void)state;
    /* Random cubics against a fine scan of g: the first sample where g <= 0 brackets the returned root, and
     * r s(r^2) rises up to it. */
    test_rng r = test_rng_make(13);
    for (int i = 0; i < 3000; i++) {
        warp_lens l = uniform_lens(test_rng_uniform(&r, 0.5, 1.5), test_rng_uniform(&r, -1, 1),
                                   test_rng_uniform(&r, -1, 1), test_rng_uniform(&r, -1, 1));
        const double *k = l.ch[1].k;
        double rm = warp_lens_monotonic_radius(&l, 1);
        const double step = 1e-3, xlim = 50;
        double first = INFINITY;
        for (double x = step; x <= xlim; x += step) {
            if (k[0] + 3 * k[1] * x + 5 * k[2] * x * x + 7 * k[3] * x * x * x <= 0) {
                first = x;
                break;
            }
        }
        if (k[3] < 0 || isfinite(first)) assert_true(isfinite(rm)); /* g ends negative, or was seen <= 0 */
        if (isinf(rm)) continue;
        double xm = rm * rm;
        assert_true(xm <= first * (1 + 1e-12));
        double gm = k[0] + 3 * k[1] * xm + 5 * k[2] * xm * xm + 7 * k[3] * xm * xm * xm;
        double gscale = fabs(k[0]) + fabs(3 * k[1] * xm) + fabs(5 * k[2] * xm * xm) + fabs(7 * k[3] * xm * xm * xm);
        assert_true(fabs(gm) < 1e-12 * gscale);
        /* g > 0 strictly before the root, so r s(r^2) rises all the way to it */
        for (int j = 0; j < 1000; j++) {
            double x = xm * j / 1000.0 * 0.9999;
            assert_true(k[0] + 3 * k[1] * x + 5 * k[2] * x * x + 7 * k[3] * x * x * x > 0);
        }
    }
}

static void test_undistort_beyond_fold(void **state)
{
    (void)state;
    warp_lens l = uniform_lens(1, -0.5, 0, 0);
    double rm = sqrt(2.0 / 3.0), fm = rm * (1 - 0.5 * rm * rm); /* the largest tangent radius the lens reaches */
    double x = 12345, y = -678;
    for (int c = 0; c < 3; c++) {
        assert_false(warp_lens_undistort(&l, c, fm * 1.001, 0, &x, &y));
        assert_false(warp_lens_undistort(&l, c, 0.6 * cos(1.0), 0.6 * sin(1.0), &x, &y));
        assert_false(warp_lens_undistort(&l, c, NAN, 0.1, &x, &y));
        assert_false(warp_lens_undistort(&l, c, 0.1, INFINITY, &x, &y));
        assert_true(x == 12345 && y == -678);
    }
    /* inside the fold the inverse lands on the rising branch and round trips */
    for (double f = 0.05; f < 0.9999; f += 0.05) {
        double t = fm * f, u, v;
        assert_true(warp_lens_undistort(&l, 1, t * 0.6, -t * 0.8, &x, &y));
        double rad = hypot(x - 720, y - 800) / 720;
        assert_true(rad < rm);
        warp_lens_distort(&l, 1, x, y, &u, &v);
        assert_true(fabs(u - t * 0.6) < 1e-14 && fabs(v + t * 0.8) < 1e-14);
    }
    /* right at the fold: still a (single) solution, at the monotonic radius */
    assert_true(warp_lens_undistort(&l, 1, fm, 0, &x, &y));
    assert_true(fabs((x - 720) / 720 - rm) < 1e-6 && fabs(y - 800) < 1e-9);
    /* a lens folded at its centre has no inverse at all */
    warp_lens bad = uniform_lens(0, 1, 0, 0);
    x = 1;
    assert_false(warp_lens_undistort(&bad, 0, 0.1, 0.1, &x, &y));
    assert_true(x == 1);
}

static void test_check(void **state)
{
    (void)state;
    char buf[256];
    warp_lens l = realistic_lens();
    assert_null(warp_lens_check(&l, 1440, 1600, buf, sizeof buf));

    /* folding lens: corner radius hypot(720, 800) / 720 = 1.49 beyond the fold at 0.816 */
    warp_lens f = uniform_lens(1, -0.5, 0, 0);
    const char *m = warp_lens_check(&f, 1440, 1600, buf, sizeof buf);
    assert_non_null(m);
    print_message("folding lens: %s\n", m);
    assert_non_null(strstr(m, "red channel folds over at radius 0.816"));
    assert_non_null(strstr(m, "1.49"));
    /* ... yet fine for a small viewport that stays inside the fold */
    f.center_x = f.center_y = 50;
    assert_null(warp_lens_check(&f, 100, 100, buf, sizeof buf));
    /* only blue folds: the message names blue */
    warp_lens b = realistic_lens();
    b.ch[2].k[1] = -0.5;
    b.ch[2].k[2] = 0;
    m = warp_lens_check(&b, 1440, 1600, buf, sizeof buf);
    assert_non_null(m);
    assert_non_null(strstr(m, "blue"));

    warp_lens n = realistic_lens();
    n.ch[1].k[2] = NAN;
    m = warp_lens_check(&n, 1440, 1600, buf, sizeof buf);
    assert_non_null(m);
    assert_non_null(strstr(m, "green"));
    n = realistic_lens();
    n.ch[0].k[3] = INFINITY;
    assert_non_null(warp_lens_check(&n, 1440, 1600, buf, sizeof buf));
    n = realistic_lens();
    n.center_x = NAN;
    assert_non_null(warp_lens_check(&n, 1440, 1600, buf, sizeof buf));

    warp_lens s = realistic_lens();
    s.scale = 0;
    m = warp_lens_check(&s, 1440, 1600, buf, sizeof buf);
    assert_non_null(m);
    assert_non_null(strstr(m, "scale"));
    s.scale = -720;
    assert_non_null(warp_lens_check(&s, 1440, 1600, buf, sizeof buf));

    warp_lens z = realistic_lens();
    z.ch[0].k[0] = 0;
    assert_non_null(warp_lens_check(&z, 1440, 1600, buf, sizeof buf));
    assert_non_null(warp_lens_check(&l, 0, 1600, buf, sizeof buf));

    /* a tiny or missing buffer still reports failure, truncated safely */
    char tiny[8];
    memset(tiny, 'x', sizeof tiny);
    f.center_x = 720;
    f.center_y = 800;
    m = warp_lens_check(&f, 1440, 1600, tiny, sizeof tiny);
    assert_non_null(m);
    assert_true(strlen(m) == sizeof tiny - 1);
    assert_non_null(warp_lens_check(&f, 1440, 1600, NULL, 0));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_identity_matches_camera),
        cmocka_unit_test(test_round_trips_realistic),
        cmocka_unit_test(test_chromatic_aberration),
        cmocka_unit_test(test_monotonic_radius_analytic),
        cmocka_unit_test(test_monotonic_radius_random),
        cmocka_unit_test(test_undistort_beyond_fold),
        cmocka_unit_test(test_check),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
