/* SPDX-License-Identifier: MIT */
/* Unit tests for the lens models and formats (warp_lens_models) and the fit (warp_lensfit): each published parameter
 * set maps panel pixels to the same view angles as its source's formula, written out again here. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>
#include <cmocka.h>

#include "runtime/rt_config.h"
#include "tests/support/test_util.h"
#include "warp/warp_lens.h"
#include "warp/warp_lens_models.h"
#include "warp/warp_lensfit.h"

/* ---- OpenHMD, Rift CV1 ----
 * Constants from OpenHMD src/drv_oculus_rift/rift.c (REV_CV1): distortion a b c d, aberration, lens separation
 * 0.054 m. The CV1 reports its screen size and eye distance over USB (rift.c reads them); these are its nominal
 * 2160 x 1200 panel at 456 ppi and a 40 mm eye distance, lens centred vertically. */
static const warp_lens_openhmd_device cv1 = {
    .k = {0.098, 0.324, -0.241, 0.819},
    .aberration = {0.9952420, 1.0, 1.0008074},
    .hsize = 2160 / 456.0 * 0.0254,
    .vsize = 1200 / 456.0 * 0.0254,
    .hres = 2160,
    .vres = 1200,
    .lens_sep = 0.054,
    .lens_vpos = 1200 / 456.0 * 0.0254 / 2,
    .eye_to_screen = 0.04,
};

/* OpenHMD's shader (src/shaders/test1.frag) with the uniforms its examples set (examples/opengl/main.c), then the
 * left eye's frustum from rift.c: the view tangent channel c sees at left-viewport pixel (px, py). */
static void openhmd_reference(double px, double py, int c, double *tu, double *tv)
{
    const warp_lens_openhmd_device *d = &cv1;
    double vs[2] = {d->hsize / 2, d->vsize};              /* ViewportScale */
    double lc[2] = {vs[0] - d->lens_sep / 2, d->lens_vpos}; /* left LensCenter */
    double ws = fmax(lc[0], d->lens_sep / 2);             /* WarpScale */
    double out[2] = {px / (d->hres / 2.0), 1 - py / d->vres}; /* GL texture coordinates: t up */
    double r[2] = {(out[0] * vs[0] - lc[0]) / ws, (out[1] * vs[1] - lc[1]) / ws};
    double rm = hypot(r[0], r[1]);
    const double *k = d->k; /* HmdWarpParam = (a, b, c, d) */
    double s = k[3] + k[2] * rm + k[1] * rm * rm + k[0] * rm * rm * rm;
    double tc[2];
    for (int i = 0; i < 2; i++) tc[i] = (lc[i] + d->aberration[c] * r[i] * s * ws) / vs[i];
    double l = -(d->hsize / 2 - d->lens_sep / 2), rr = d->lens_sep / 2, b = -d->lens_vpos, t = d->vsize - d->lens_vpos;
    *tu = (l + tc[0] * (rr - l)) / d->eye_to_screen;
    *tv = (b + tc[1] * (t - b)) / d->eye_to_screen;
}

static warp_lens cv1_lens(void)
{
    warp_lens_panotools_params p;
    char err[200];
    assert_true(warp_lens_openhmd_params(&cv1, &p, err, sizeof err));
    return warp_lens_panotools(&p);
}

static void test_openhmd_cv1(void **state)
{
    (void)state;
    warp_lens l = cv1_lens();
    assert_null(warp_lens_check(&l, 1080, 1200, NULL, 0));
    assert_true(warp_lens_in_view(&l, 1, 0, 0)); /* only vive marks an end of view */
    /* known angles -> panel position by our inverse; OpenHMD's formula at that position sees the same angle */
    const double deg[] = {0, 5, 15, 30, 40}, az[] = {0, 0.7, 1.6, 3.0, 4.4};
    for (int c = 0; c < 3; c++)
        for (size_t i = 0; i < sizeof deg / sizeof *deg; i++)
            for (size_t j = 0; j < sizeof az / sizeof *az; j++) {
                double t = tan(deg[i] * WARP_PI / 180), u = t * cos(az[j]), v = t * sin(az[j]), x, y, ou, ov;
                assert_true(warp_lens_undistort(&l, c, u, v, &x, &y));
                openhmd_reference(x, y, c, &ou, &ov);
                assert_true(fabs(ou - u) < 1e-9 && fabs(ov - v) < 1e-9);
            }
    /* and every pixel of a grid: our forward map is OpenHMD's */
    for (int y = 0; y <= 1200; y += 100)
        for (int x = 0; x <= 1080; x += 90)
            for (int c = 0; c < 3; c++) {
                double u, v, ou, ov;
                warp_lens_distort(&l, c, x, y, &u, &v);
                openhmd_reference(x, y, c, &ou, &ov);
                assert_true(fabs(ou - u) < 1e-9 && fabs(ov - v) < 1e-9);
            }
    /* the lens axis sees straight ahead; blue's wider scale puts the same angle further out than red */
    double u, v, xr = 0, yr, xb = 0, yb;
    warp_lens_distort(&l, 1, l.center_x, l.center_y, &u, &v);
    assert_true(fabs(u) < 1e-12 && fabs(v) < 1e-12);
    assert_true(warp_lens_undistort(&l, 0, 0.5, 0, &xr, &yr) && warp_lens_undistort(&l, 2, 0.5, 0, &xb, &yb));
    assert_true(xb < xr); /* blue's aberration > red's: the same tangent needs a smaller radius */
}

/* ---- Monado, Vive ----
 * Left eye of the HTC Vive as Monado's libsurvive driver once hard-coded it (src/xrt/drivers/survive/
 * survive_driver.c, quirk_video_distortion_vive): aspect 0.9, grow_for_undistort 0.6, one centre, three
 * coefficients per channel. That table carried no intrinsics; these are a typical Vive eye's. */
static const warp_lens_vive_params vive = {
    .k = {{-0.02223805567703767, -0.04931309279533211, -0.07862881939243466, 0},
          {-0.188236068524731, -0.221086205321053, -0.2537849057915209, 0},
          {-0.07316590815739493, -0.02332400789561968, 0.02469959434698275, 0}},
    .center = {{0.08946027017045266, -0.009002181016260827},
               {0.08946027017045266, -0.009002181016260827},
               {0.08946027017045266, -0.009002181016260827}},
    .aspect_x_over_y = 0.8999999761581421,
    .intrinsics = {0.92, -0.06, 1.02, 0.01},
    .r2_cutoff = 1.11622154712677,
};

/* Monado's u_compute_distortion_vive, then the eye buffer's field from vive_config.c's _calculate_fov. */
static void vive_reference(double px, double py, int vw, int vh, int c, double *tu, double *tv)
{
    const double grow = 0.6000000238418579, a = vive.aspect_x_over_y, s = 1 + grow;
    double u = px / vw, v = py / vh;
    double fx = 0.5 / s, fy = 0.5 / s * a;
    double X = 2 * u - 1, Y = (2 * v - 1) / a;
    X -= vive.center[c][0];
    Y -= vive.center[c][1];
    double r2 = X * X + Y * Y;
    const double *k = vive.k[c];
    double d = 1 / (1 + r2 * (k[0] + r2 * (k[1] + r2 * k[2]))) + k[3];
    double tcx = 0.5 + (X * d + vive.center[c][0]) * fx, tcy = 0.5 + (Y * d + vive.center[c][1]) * fy;
    double ifx = vive.intrinsics[0] / s, icx = vive.intrinsics[1] / s, ify = vive.intrinsics[2] / s,
           icy = vive.intrinsics[3] / s;
    double focus_x = ifx * vw / 2, focus_y = ify * vh / 2;
    double center_x = (icx - 1) * -1 * vw / 2, center_y = (icy + 1) * vh / 2;
    /* angle_left = -atan(center_x / focus_x) at tc.x = 0, angle_up = atan(center_y / focus_y) at tc.y = 0 */
    *tu = (tcx * vw - center_x) / focus_x;
    *tv = (center_y - tcy * vh) / focus_y;
}

static void test_vive(void **state)
{
    (void)state;
    const int vw = 1080, vh = 1200;
    warp_lens l = warp_lens_vive(&vive, vw, vh);
    assert_null(warp_lens_check(&l, vw, vh, NULL, 0));
    for (int y = 0; y <= vh; y += 100)
        for (int x = 0; x <= vw; x += 90)
            for (int c = 0; c < 3; c++) {
                double u, v, ou, ov, bx, by;
                warp_lens_distort(&l, c, x, y, &u, &v);
                vive_reference(x, y, vw, vh, c, &ou, &ov);
                double X = 2.0 * x / vw - 1 - vive.center[c][0], Y = (2.0 * y / vh - 1) / vive.aspect_x_over_y -
                                                                     vive.center[c][1];
                bool in_view = X * X + Y * Y <= vive.r2_cutoff;
                assert_true(warp_lens_in_view(&l, c, x, y) == in_view);
                if (in_view) /* Monado's formula where the lens shows anything */
                    assert_true(fabs(ou - u) < 1e-9 && fabs(ov - v) < 1e-9);
                else
                    ou = u, ov = v;
                assert_true(warp_lens_undistort(&l, c, ou, ov, &bx, &by));
                assert_true(fabs(bx - x) < 1e-6 && fabs(by - y) < 1e-6);
            }
}

/* ---- Cardboard v1 ----
 * The Cardboard SDK's v1 viewer profile (sdk/qrcode/cardboard_v1/cardboard_v1.cc, decoded): screen to lens 0.042 m,
 * inter-lens 0.06 m, tray to lens 0.035 m, k1 0.441, k2 0.156, bottom alignment; on a 5.5" 1920 x 1080 phone. */
static const warp_lens_cardboard_params cardboard = {
    .k = {0.441, 0.156, 0, 0},
    .screen_to_lens = 0.042,
    .inter_lens = 0.06,
    .tray_to_lens = 0.035,
    .alignment = 0,
    .screen_w = 0.12096,
    .screen_h = 0.06804,
};

/* LensDistortion::DistortedUvForUndistortedUv's screen side (lens_distortion.cc) and Distort
 * (polynomial_radial_distortion.cc): the left eye's view tangent at whole-screen pixel (px, py). */
static void cardboard_reference(double px, double py, int panel_w, int panel_h, double *tu, double *tv)
{
    const warp_lens_cardboard_params *d = &cardboard;
    double sw = d->screen_w / d->screen_to_lens, sh = d->screen_h / d->screen_to_lens;
    double xoff = (d->screen_w - d->inter_lens) / 2 / d->screen_to_lens;
    double yoff = (d->tray_to_lens - 0.003) / d->screen_to_lens;
    double u = px / panel_w, v = 1 - py / panel_h; /* normalised screen coordinates, v up */
    double p[2] = {u * sw - xoff, v * sh - yoff};
    double r2 = p[0] * p[0] + p[1] * p[1], f = 1 + d->k[0] * r2 + d->k[1] * r2 * r2;
    *tu = p[0] * f;
    *tv = p[1] * f;
}

static void test_cardboard_v1(void **state)
{
    (void)state;
    const int pw = 1920, ph = 1080, vw = pw / 2;
    warp_lens l = warp_lens_cardboard(&cardboard, vw, ph);
    for (int y = 0; y <= ph; y += 90)
        for (int x = 0; x <= vw; x += 80) {
            double u, v, ou, ov;
            warp_lens_distort(&l, 1, x, y, &u, &v);
            cardboard_reference(x, y, pw, ph, &ou, &ov);
            assert_true(fabs(ou - u) < 1e-9 && fabs(ov - v) < 1e-9);
        }
    /* the right eye: mirrored about its viewport's centre line, so whole-screen pixel vw + x mirrors vw - x */
    warp_lens r = l;
    warp_lens_mirror(&r, vw);
    double u, v, ul, vl;
    warp_lens_distort(&r, 1, 100, 300, &u, &v);
    warp_lens_distort(&l, 1, vw - 100, 300, &ul, &vl);
    assert_true(fabs(u + ul) < 1e-12 && fabs(v - vl) < 1e-12);
}

/* ---- OpenCV ----
 * A calibration YAML's camera_matrix and distortion_coefficients, as cv::projectPoints applies them. */
static const warp_lens_opencv_params ocv = {700, 690, 545, 598, -0.21, 0.045, 0.0012, -0.0008, -0.004};

static void opencv_reference(double u, double v, double *x, double *y)
{
    double xp = u, yp = -v, r2 = xp * xp + yp * yp;
    double radial = 1 + ocv.k1 * r2 + ocv.k2 * r2 * r2 + ocv.k3 * r2 * r2 * r2;
    double xpp = xp * radial + 2 * ocv.p1 * xp * yp + ocv.p2 * (r2 + 2 * xp * xp);
    double ypp = yp * radial + ocv.p1 * (r2 + 2 * yp * yp) + 2 * ocv.p2 * xp * yp;
    *x = ocv.fx * xpp + ocv.cx;
    *y = ocv.fy * ypp + ocv.cy;
}

static void test_opencv(void **state)
{
    (void)state;
    warp_lens l = warp_lens_opencv(&ocv);
    assert_null(warp_lens_check(&l, 1080, 1200, NULL, 0));
    test_rng rng = test_rng_make(5);
    for (int i = 0; i < 500; i++) {
        double u = test_rng_uniform(&rng, -0.7, 0.7), v = test_rng_uniform(&rng, -0.7, 0.7), x, y, ox, oy, bu, bv;
        opencv_reference(u, v, &ox, &oy);
        assert_true(warp_lens_undistort(&l, i % 3, u, v, &x, &y));
        assert_true(fabs(x - ox) < 1e-9 && fabs(y - oy) < 1e-9);
        warp_lens_distort(&l, i % 3, ox, oy, &bu, &bv); /* the 2-D inverse, tangential terms included */
        assert_true(fabs(bu - u) < 1e-10 && fabs(bv - v) < 1e-10);
    }
    /* the fold: f(r) = r (1 + k1 r^2 + k2 r^4 + k3 r^6) stops rising at the tangent radius rf, which the panel shows
     * at radius f(rf) (in fx units): the monotonic radius is that panel-side one */
    double rf = 0;
    for (double r = 0; r < 5; r += 1e-5) {
        double d = 1 + 3 * ocv.k1 * r * r + 5 * ocv.k2 * pow(r, 4) + 7 * ocv.k3 * pow(r, 6);
        if (d <= 0) break;
        rf = r;
    }
    double want = rf * (1 + ocv.k1 * rf * rf + ocv.k2 * pow(rf, 4) + ocv.k3 * pow(rf, 6));
    assert_true(fabs(warp_lens_monotonic_radius(&l, 1) - want) < 1e-4);
}

/* Every model, both eyes: undistort inverts distort over the whole viewport and every channel. */
static void test_round_trips(void **state)
{
    (void)state;
    warp_lens lenses[5];
    int vw[5] = {1080, 1080, 1080, 960, 1080}, vh[5] = {1200, 1200, 1200, 1080, 1200};
    lenses[0] = test_reference_lens(540, 600, 560);
    lenses[1] = cv1_lens();
    lenses[2] = warp_lens_vive(&vive, 1080, 1200);
    lenses[3] = warp_lens_cardboard(&cardboard, 960, 1080);
    lenses[4] = warp_lens_opencv(&ocv);
    test_rng rng = test_rng_make(9);
    for (int m = 0; m < 5; m++)
        for (int eye = 0; eye < 2; eye++) {
            warp_lens l = lenses[m];
            if (eye) warp_lens_mirror(&l, vw[m]);
            assert_null(warp_lens_check(&l, vw[m], vh[m], NULL, 0));
            for (int i = 0; i < 600; i++) {
                double x = test_rng_uniform(&rng, 0, vw[m]), y = test_rng_uniform(&rng, 0, vh[m]), u, v, bx, by;
                int c = i % 3;
                warp_lens_distort(&l, c, x, y, &u, &v);
                assert_true(isfinite(u) && isfinite(v));
                assert_true(warp_lens_undistort(&l, c, u, v, &bx, &by));
                assert_true(fabs(bx - x) < 1e-6 && fabs(by - y) < 1e-6);
            }
        }
}

/* A lens folding inside the viewport is refused with the model named; far beyond the fold undistort says no. */
static void test_fold_refused(void **state)
{
    (void)state;
    warp_lens_panotools_params p = {.abcd = {{0, -0.6, 0, 1}, {0, -0.6, 0, 1}, {0, -0.6, 0, 1}},
                                    .aberration = {1, 1, 1}, .center_x = 540, .center_y = 600, .scale = 540,
                                    .tan_scale = 1};
    warp_lens l = warp_lens_panotools(&p);
    char buf[300];
    const char *why = warp_lens_check(&l, 1080, 1200, buf, sizeof buf);
    assert_non_null(why);
    assert_non_null(strstr(why, "panotools"));
    assert_non_null(strstr(why, "folds over"));
    double x, y;
    assert_false(warp_lens_undistort(&l, 1, 5, 0, &x, &y));
    /* f(r) = r - 0.6 r^3 peaks at r = sqrt(1 / 1.8) */
    assert_true(fabs(warp_lens_monotonic_radius(&l, 1) - sqrt(1 / 1.8)) < 1e-9);
}

/* A standard normal sample (Box-Muller). */
static double gauss(test_rng *rng)
{
    double a = test_rng_uniform(rng, 1e-300, 1), b = test_rng_uniform(rng, 0, 2 * WARP_PI);
    return sqrt(-2 * log(a)) * cos(b);
}

/* Synthetic correspondences from a known lens (its distort per channel, plus Gaussian noise of sigma tangent
 * units) over a grid of the viewport. */
static int synth(const warp_lens *l, int c, double sigma, warp_lensfit_point *pts, test_rng *rng)
{
    int n = 0;
    for (int y = 0; y <= 1200; y += 40)
        for (int x = 0; x <= 1080; x += 40) {
            double u, v;
            warp_lens_distort(l, c, x, y, &u, &v);
            pts[n++] = (warp_lensfit_point){x, y, u + sigma * gauss(rng), v + sigma * gauss(rng)};
        }
    return n;
}

/* The fit recovers a known lens of each linear model from noisy correspondences: coefficients within 2e-3 (noise
 * of 1e-4 tangent, about 0.06 panel pixels here), residual at the noise's size. */
static void test_fit_recovers(void **state)
{
    (void)state;
    static warp_lensfit_point pts[40 * 40];
    test_rng rng = test_rng_make(21);
    warp_lens poly = test_reference_lens(540, 600, 560), pano = cv1_lens();
    const double sigma = 1e-4;
    for (int c = 0; c < 3; c++) {
        warp_lensfit_result r;
        char err[200];
        int n = synth(&poly, c, sigma, pts, &rng);
        assert_true(warp_lensfit_radial(WARP_LENS_POLY, pts, n, 540, 600, 560, &r, err, sizeof err));
        for (int i = 0; i < 4; i++) assert_true(fabs(r.k[i] - poly.ch[c].k[i]) < 2e-3);
        assert_true(r.rms_px < 0.2 && r.max_px < 1 && r.unmapped == 0);
        print_message("poly %d: k %.5f %.5f %.5f %.5f, rms %.3f px, max %.3f px\n", c, r.k[0], r.k[1], r.k[2], r.k[3],
                      r.rms_px, r.max_px);
        /* panotools: the CV1's a b c d times its channel's aberration and tangent scale (one lens, F scaled) */
        n = synth(&pano, c, sigma, pts, &rng);
        assert_true(warp_lensfit_radial(WARP_LENS_PANOTOOLS, pts, n, pano.m[c].cx, pano.m[c].cy, pano.scale, &r, err,
                                        sizeof err));
        for (int i = 0; i < 4; i++) assert_true(fabs(r.k[i] - cv1.k[i] * pano.m[c].tsx) < 2e-3);
        assert_true(r.rms_px < 0.2 && r.max_px < 1 && r.unmapped == 0);
        print_message("panotools %d: k %.5f %.5f %.5f %.5f, rms %.3f px, max %.3f px\n", c, r.k[0], r.k[1], r.k[2],
                      r.k[3], r.rms_px, r.max_px);
    }
    /* noise-free: exact to rounding */
    warp_lensfit_result r;
    int n = synth(&poly, 1, 0, pts, &rng);
    assert_true(warp_lensfit_radial(WARP_LENS_POLY, pts, n, 540, 600, 560, &r, NULL, 0));
    for (int i = 0; i < 4; i++) assert_true(fabs(r.k[i] - poly.ch[1].k[i]) < 1e-9);
    assert_true(r.rms_px < 1e-6);
    /* too few points, or all at the centre: refused with a reason */
    char err[200];
    assert_false(warp_lensfit_radial(WARP_LENS_POLY, pts, 3, 540, 600, 560, &r, err, sizeof err));
    assert_non_null(strstr(err, "at least 4"));
    warp_lensfit_point same[6];
    for (int i = 0; i < 6; i++) same[i] = (warp_lensfit_point){540 + 100, 600, 0.2, 0};
    assert_false(warp_lensfit_radial(WARP_LENS_POLY, same, 6, 540, 600, 560, &r, err, sizeof err));
    assert_false(warp_lensfit_radial(WARP_LENS_VIVE, pts, n, 540, 600, 560, &r, err, sizeof err));
}

/* The centre too: from 25 pixels off, the fit finds the lens's centre and coefficients (noise-free: to 1e-3 px). */
static void test_fit_center(void **state)
{
    (void)state;
    static warp_lensfit_point pts[3][40 * 40];
    test_rng rng = test_rng_make(3);
    warp_lens poly = test_reference_lens(560, 600, 540);
    int n[3];
    for (int c = 0; c < 3; c++) n[c] = synth(&poly, c, 0, pts[c], &rng);
    const warp_lensfit_point *const cp[3] = {pts[0], pts[1], pts[2]};
    double cx = 540, cy = 620;
    warp_lensfit_result r[3];
    char err[200];
    assert_true(warp_lensfit_center(WARP_LENS_POLY, cp, n, &cx, &cy, 540, r, err, sizeof err));
    print_message("centre %.6f %.6f, green k %.6f %.6f %.6f %.6f, rms %.2g px\n", cx, cy, r[1].k[0], r[1].k[1],
                  r[1].k[2], r[1].k[3], r[1].rms_px);
    assert_true(fabs(cx - 560) < 1e-3 && fabs(cy - 600) < 1e-3);
    for (int c = 0; c < 3; c++) {
        for (int i = 0; i < 4; i++) assert_true(fabs(r[c].k[i] - poly.ch[c].k[i]) < 1e-5);
        assert_true(r[c].rms_px < 1e-3);
    }
    /* with noise (1e-4 tangent) the centre lands within a tenth of a pixel */
    for (int c = 0; c < 3; c++) n[c] = synth(&poly, c, 1e-4, pts[c], &rng);
    cx = 540, cy = 620;
    assert_true(warp_lensfit_center(WARP_LENS_POLY, cp, n, &cx, &cy, 540, r, err, sizeof err));
    assert_true(fabs(cx - 560) < 0.1 && fabs(cy - 600) < 0.1);
}

/* [lens] model and its keys: rt_config_lens builds the model (mirrored for the right eye); a lens that folds over
 * the viewport fails validation naming the model's own keys. */
static void test_config_models(void **state)
{
    (void)state;
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors err = {0};
    const char *set[] = {"display.width=2160", "display.height=1200", "lens.model=opencv",
                         "lens.opencv_camera=700 690 545 598", "lens.opencv_dist=-0.21 0.045 0.0012 -0.0008 -0.004"};
    for (size_t i = 0; i < sizeof set / sizeof *set; i++) assert_true(rt_config_set(&c, set[i], &err));
    assert_true(rt_config_validate(&c, &err));
    warp_lens l = rt_config_lens(&c, 0), r = rt_config_lens(&c, 1), want = warp_lens_opencv(&ocv);
    assert_int_equal(l.model, WARP_LENS_OPENCV);
    double u, v, uw, vw, ur, vr;
    warp_lens_distort(&l, 2, 200, 900, &u, &v);
    warp_lens_distort(&want, 2, 200, 900, &uw, &vw);
    warp_lens_distort(&r, 2, 1080 - 200, 900, &ur, &vr);
    assert_true(fabs(u - uw) < 1e-12 && fabs(v - vw) < 1e-12);
    assert_true(fabs(u + ur) < 1e-9 && fabs(v - vr) < 1e-9); /* the mirror image, tangential terms included */
    /* every model's defaults are a usable lens on the default panel */
    const char *const models[] = {"poly", "panotools", "vive", "cardboard", "opencv"};
    for (int m = 0; m < 5; m++) {
        rt_config d;
        rt_config_defaults(&d);
        char a[64];
        snprintf(a, sizeof a, "lens.model=%s", models[m]);
        rt_config_errors e = {0};
        assert_true(rt_config_set(&d, a, &e));
        bool ok = rt_config_validate(&d, &e);
        if (!ok) print_error("%s: %s\n", models[m], e.msg[0]);
        assert_true(ok);
    }
    /* a folding panotools lens names the panotools keys */
    rt_config_defaults(&c);
    err.count = 0;
    assert_true(rt_config_set(&c, "lens.model=panotools", &err));
    assert_true(rt_config_set(&c, "lens.pano_green=0 -0.6 0 1", &err));
    assert_false(rt_config_validate(&c, &err));
    assert_non_null(strstr(err.msg[0], "folds over"));
    assert_non_null(strstr(err.msg[0], "[lens] pano_green"));
    assert_non_null(strstr(err.msg[0], "[lens] model"));
    /* an unknown model is refused with the list */
    err.count = 0;
    assert_false(rt_config_set(&c, "lens.model=fisheye", &err));
    assert_non_null(strstr(err.msg[0], "opencv"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_openhmd_cv1), cmocka_unit_test(test_vive),         cmocka_unit_test(test_cardboard_v1),
        cmocka_unit_test(test_opencv),      cmocka_unit_test(test_round_trips),  cmocka_unit_test(test_fold_refused),
        cmocka_unit_test(test_fit_recovers), cmocka_unit_test(test_fit_center),  cmocka_unit_test(test_config_models),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
