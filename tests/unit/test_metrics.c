/* SPDX-License-Identifier: MIT */
/* Unit tests for warp_metrics: PSNR closed forms, SSIM against a brute-force double-precision reference,
 * CIE Lab reference colours, the 002 §4 error-pixel count, mask exclusion and the depth-edge band. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdlib.h>
#include <cmocka.h>

#include "tests/support/test_util.h"
#include "warp/warp_image.h"
#include "warp/warp_metrics.h"

static warp_rgba8 rgb(int r, int g, int b)
{
    warp_rgba8 c = {(uint8_t)r, (uint8_t)g, (uint8_t)b, 255};
    return c;
}

static int clamp255(double v)
{
    return v < 0 ? 0 : v > 255 ? 255 : (int)lround(v);
}

/* Random texture in [lo, hi] per channel, alpha random too (it must be ignored). */
static void fill_random(warp_image_rgba8 *img, test_rng *r, int lo, int hi)
{
    for (int y = 0; y < img->h; y++)
        for (int x = 0; x < img->w; x++) {
            /* one statement per draw: argument and initialiser order is unspecified in C */
            warp_rgba8 c;
            c.r = (uint8_t)test_rng_uniform(r, lo, hi + 1);
            c.g = (uint8_t)test_rng_uniform(r, lo, hi + 1);
            c.b = (uint8_t)test_rng_uniform(r, lo, hi + 1);
            c.a = (uint8_t)test_rng_uniform(r, 0, 256);
            WARP_AT(img, x, y) = c;
        }
}

/* Smooth texture: a sum of sinusoids, so SSIM sees structure rather than white noise. */
static void fill_textured(warp_image_rgba8 *img)
{
    for (int y = 0; y < img->h; y++)
        for (int x = 0; x < img->w; x++) {
            double t = 120 + 60 * sin(x * 0.21) * cos(y * 0.17) + 40 * sin((x + 2 * y) * 0.05);
            WARP_AT(img, x, y) = rgb(clamp255(t), clamp255(t * 0.8 + 20), clamp255(255 - t));
        }
}

static void add_noise(warp_image_rgba8 *dst, const warp_image_rgba8 *src, test_rng *r, double amp)
{
    for (int y = 0; y < src->h; y++)
        for (int x = 0; x < src->w; x++) {
            warp_rgba8 c = WARP_AT(src, x, y);
            int nr = clamp255(c.r + test_rng_uniform(r, -amp, amp));
            int ng = clamp255(c.g + test_rng_uniform(r, -amp, amp));
            int nb = clamp255(c.b + test_rng_uniform(r, -amp, amp));
            WARP_AT(dst, x, y) = rgb(nr, ng, nb);
        }
}

static double ref_luma(warp_rgba8 c)
{
    return 0.299f * (float)c.r + 0.587f * (float)c.g + 0.114f * (float)c.b;
}

/* Brute-force SSIM: full 11x11 window per pixel, clipped at the border and renormalised by its weight sum. */
static double ref_ssim(const warp_image_rgba8 *a, const warp_image_rgba8 *b, const warp_image_u8 *mask,
                       uint8_t exclude)
{
    const double c1 = (0.01 * 255) * (0.01 * 255), c2 = (0.03 * 255) * (0.03 * 255);
    double sum = 0;
    long n = 0;
    for (int y = 0; y < a->h; y++)
        for (int x = 0; x < a->w; x++) {
            if (mask && (WARP_AT(mask, x, y) & exclude)) continue;
            double W = 0, sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
            for (int j = -5; j <= 5; j++)
                for (int i = -5; i <= 5; i++) {
                    int xx = x + i, yy = y + j;
                    if (xx < 0 || yy < 0 || xx >= a->w || yy >= a->h) continue;
                    double wt = exp(-(i * i + j * j) / (2 * 1.5 * 1.5));
                    double la = ref_luma(WARP_AT(a, xx, yy)), lb = ref_luma(WARP_AT(b, xx, yy));
                    W += wt;
                    sx += wt * la;
                    sy += wt * lb;
                    sxx += wt * la * la;
                    syy += wt * lb * lb;
                    sxy += wt * la * lb;
                }
            double mx = sx / W, my = sy / W;
            double vx = sxx / W - mx * mx, vy = syy / W - my * my, cxy = sxy / W - mx * my;
            sum += (2 * mx * my + c1) * (2 * cxy + c2) / ((mx * mx + my * my + c1) * (vx + vy + c2));
            n++;
        }
    return n ? sum / n : NAN;
}

static void test_identical_images(void **state)
{
    (void)state;
    warp_image_rgba8 a, b;
    assert_true(warp_image_rgba8_alloc(&a, 61, 47) && warp_image_rgba8_alloc(&b, 61, 47));
    test_rng r = test_rng_make(21);
    fill_random(&a, &r, 0, 255);
    warp_image_rgba8_copy(&b, &a);
    /* alpha differs: it is not part of any metric */
    for (int x = 0; x < b.w; x++) WARP_AT(&b, x, 3).a ^= 0x55;
    assert_true(isinf(warp_psnr(&a, &b, NULL, 0)) && warp_psnr(&a, &b, NULL, 0) > 0);
    assert_true(fabs(warp_ssim(&a, &b, NULL, 0) - 1) < 1e-9);
    assert_true(warp_error_pixel_percent(&a, &b, NULL, 0, 20) == 0);
    /* flat images too (zero variance everywhere) */
    warp_image_rgba8_fill(&a, rgb(17, 200, 90));
    warp_image_rgba8_fill(&b, rgb(17, 200, 90));
    assert_true(fabs(warp_ssim(&a, &b, NULL, 0) - 1) < 1e-9);
    warp_image_free(&a);
    warp_image_free(&b);
}

static void test_psnr_uniform_offset(void **state)
{
    (void)state;
    warp_image_rgba8 a, b;
    assert_true(warp_image_rgba8_alloc(&a, 50, 30) && warp_image_rgba8_alloc(&b, 50, 30));
    test_rng r = test_rng_make(22);
    fill_random(&a, &r, 0, 240);
    for (int k = 1; k <= 15; k++) {
        for (int y = 0; y < a.h; y++)
            for (int x = 0; x < a.w; x++) {
                warp_rgba8 c = WARP_AT(&a, x, y);
                WARP_AT(&b, x, y) = rgb(c.r + k, c.g + k, c.b + k);
            }
        double expect = 10 * log10(255.0 * 255.0 / (k * k));
        assert_true(fabs(warp_psnr(&a, &b, NULL, 0) - expect) < 1e-12);
        assert_true(fabs(warp_psnr(&b, &a, NULL, 0) - expect) < 1e-12); /* symmetric */
    }
    /* one channel only: MSE is k^2 / 3 */
    for (int y = 0; y < a.h; y++)
        for (int x = 0; x < a.w; x++) {
            warp_rgba8 c = WARP_AT(&a, x, y);
            WARP_AT(&b, x, y) = rgb(c.r, c.g + 6, c.b);
        }
    assert_true(fabs(warp_psnr(&a, &b, NULL, 0) - 10 * log10(255.0 * 255.0 / 12.0)) < 1e-12);
    /* black vs white: 0 dB */
    warp_image_rgba8_fill(&a, rgb(0, 0, 0));
    warp_image_rgba8_fill(&b, rgb(255, 255, 255));
    assert_true(fabs(warp_psnr(&a, &b, NULL, 0)) < 1e-12);
    warp_image_free(&a);
    warp_image_free(&b);
}

static void test_ssim_matches_brute_force(void **state)
{
    (void)state;
    test_rng r = test_rng_make(23);
    /* sizes below, at and above the window, odd and even, so every border case occurs */
    const int sizes[][2] = {{37, 29}, {11, 11}, {5, 17}, {1, 1}, {64, 3}, {24, 40}};
    double worst = 0;
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        warp_image_rgba8 a, b;
        warp_image_u8 m;
        int w = sizes[s][0], h = sizes[s][1];
        assert_true(warp_image_rgba8_alloc(&a, w, h) && warp_image_rgba8_alloc(&b, w, h));
        assert_true(warp_image_u8_alloc(&m, w, h));
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) WARP_AT(&m, x, y) = (uint8_t)((x * 7 + y * 3) % 5 == 0 ? 1 : 2);
        for (int variant = 0; variant < 3; variant++) {
            if (variant == 0) { /* independent random images */
                fill_random(&a, &r, 0, 255);
                fill_random(&b, &r, 0, 255);
            } else if (variant == 1) { /* correlated: b is a noisy copy of a */
                fill_random(&a, &r, 0, 255);
                add_noise(&b, &a, &r, 30);
            } else { /* nearly flat and bright: the case where float variances would lose precision */
                fill_random(&a, &r, 250, 253);
                add_noise(&b, &a, &r, 1.5);
            }
            double got = warp_ssim(&a, &b, NULL, 0), ref = ref_ssim(&a, &b, NULL, 0);
            worst = fmax(worst, fabs(got - ref));
            assert_true(fabs(got - ref) < 1e-6);
            got = warp_ssim(&a, &b, &m, 1);
            ref = ref_ssim(&a, &b, &m, 1);
            if (isnan(ref)) {
                assert_true(isnan(got));
            } else {
                worst = fmax(worst, fabs(got - ref));
                assert_true(fabs(got - ref) < 1e-6);
            }
        }
        warp_image_free(&a);
        warp_image_free(&b);
        warp_image_free(&m);
    }
    print_message("SSIM vs brute force: max difference %.3g\n", worst);
    /* Double accumulation throughout: ~1e-13 here. The margin covers compilers that fuse the luma's float
     * multiply-adds differently in the library and in ref_luma (1 ulp of luma moves SSIM by < 1e-8). */
    assert_true(worst < 1e-9);
}

static void test_ssim_noise_and_offset(void **state)
{
    (void)state;
    warp_image_rgba8 a, b;
    assert_true(warp_image_rgba8_alloc(&a, 160, 120) && warp_image_rgba8_alloc(&b, 160, 120));
    fill_textured(&a);
    test_rng r = test_rng_make(24);
    add_noise(&b, &a, &r, 80);
    double s_noise = warp_ssim(&a, &b, NULL, 0);
    assert_true(s_noise < 0.9);
    /* a 1-level brightness offset barely changes structure */
    for (int y = 0; y < a.h; y++)
        for (int x = 0; x < a.w; x++) {
            warp_rgba8 c = WARP_AT(&a, x, y);
            WARP_AT(&b, x, y) = rgb(c.r < 255 ? c.r + 1 : c.r, c.g < 255 ? c.g + 1 : c.g, c.b < 255 ? c.b + 1 : c.b);
        }
    double s_off = warp_ssim(&a, &b, NULL, 0);
    assert_true(s_off > 0.99 && s_off < 1);
    /* symmetric in its arguments */
    assert_true(fabs(warp_ssim(&b, &a, NULL, 0) - s_off) < 1e-12);
    print_message("SSIM: strong noise %.4f, 1-level offset %.6f\n", s_noise, s_off);
    warp_image_free(&a);
    warp_image_free(&b);
}

static void test_lab_reference_colours(void **state)
{
    (void)state;
    double lab[3];
    warp_srgb_to_lab(rgb(255, 255, 255), lab);
    assert_true(fabs(lab[0] - 100) < 0.01 && fabs(lab[1]) < 0.01 && fabs(lab[2]) < 0.01);
    warp_srgb_to_lab(rgb(255, 0, 0), lab);
    assert_true(fabs(lab[0] - 53.24) < 0.05 && fabs(lab[1] - 80.09) < 0.05 && fabs(lab[2] - 67.20) < 0.05);
    warp_srgb_to_lab(rgb(0, 255, 0), lab); /* sRGB green: (87.73, -86.18, 83.18) */
    assert_true(fabs(lab[0] - 87.73) < 0.05 && fabs(lab[1] + 86.18) < 0.05 && fabs(lab[2] - 83.18) < 0.05);
    warp_srgb_to_lab(rgb(0, 0, 255), lab); /* sRGB blue: (32.30, 79.19, -107.86) */
    assert_true(fabs(lab[0] - 32.30) < 0.05 && fabs(lab[1] - 79.19) < 0.05 && fabs(lab[2] + 107.86) < 0.05);
    warp_srgb_to_lab(rgb(0, 0, 0), lab);
    assert_true(fabs(lab[0]) < 1e-12 && fabs(lab[1]) < 1e-12 && fabs(lab[2]) < 1e-12);
    /* greys are neutral, and the linear toe of the sRGB curve is continuous: L rises monotonically */
    double prev = -1;
    for (int v = 0; v < 256; v++) {
        warp_srgb_to_lab(rgb(v, v, v), lab);
        assert_true(fabs(lab[1]) < 1e-6 && fabs(lab[2]) < 1e-6);
        assert_true(lab[0] > prev);
        prev = lab[0];
    }
    warp_srgb_to_lab(rgb(119, 119, 119), lab); /* mid grey: L ~ 50 */
    assert_true(fabs(lab[0] - 50.0) < 0.5);
}

static double lab_distance(warp_rgba8 p, warp_rgba8 q)
{
    double a[3], b[3];
    warp_srgb_to_lab(p, a);
    warp_srgb_to_lab(q, b);
    return sqrt(pow(a[0] - b[0], 2) + pow(a[1] - b[1], 2) + pow(a[2] - b[2], 2));
}

static void test_error_pixel_percent(void **state)
{
    (void)state;
    warp_image_rgba8 a, b;
    assert_true(warp_image_rgba8_alloc(&a, 10, 10) && warp_image_rgba8_alloc(&b, 10, 10));
    warp_image_rgba8_fill(&a, rgb(128, 128, 128));
    warp_image_rgba8_fill(&b, rgb(128, 128, 128));
    /* 10 of 100 pixels turn red: Lab distance ~ 100 */
    for (int i = 0; i < 10; i++) WARP_AT(&b, (i * 3) % 10, i) = rgb(255, 0, 0);
    assert_true(warp_error_pixel_percent(&a, &b, NULL, 0, 20) == 10.0);
    /* small changes everywhere else stay below the threshold */
    for (int y = 0; y < 10; y++)
        for (int x = 0; x < 10; x++)
            if (WARP_AT(&b, x, y).g != 0) WARP_AT(&b, x, y) = rgb(131, 126, 129);
    assert_true(lab_distance(rgb(128, 128, 128), rgb(131, 126, 129)) < 5);
    assert_true(warp_error_pixel_percent(&a, &b, NULL, 0, 20) == 10.0);
    assert_true(warp_error_pixel_percent(&a, &b, NULL, 0, 0) == 100.0); /* every pixel differs a little */
    assert_true(warp_error_pixel_percent(&a, &b, NULL, 0, INFINITY) == 0.0);

    /* the threshold is a strict "exceeds": a change of distance d counts for threshold just below d only */
    warp_image_rgba8_fill(&b, rgb(128, 128, 128));
    WARP_AT(&b, 4, 4) = rgb(128, 128, 175);
    double d = lab_distance(rgb(128, 128, 128), rgb(128, 128, 175));
    assert_true(d > 15 && d < 60);
    assert_true(warp_error_pixel_percent(&a, &b, NULL, 0, d * (1 - 1e-9)) == 1.0);
    assert_true(warp_error_pixel_percent(&a, &b, NULL, 0, d * (1 + 1e-9)) == 0.0);
    assert_true(isnan(warp_error_pixel_percent(&a, &b, NULL, 0, NAN)));
    warp_image_free(&a);
    warp_image_free(&b);
}

static void test_mask_exclusion(void **state)
{
    (void)state;
    const int w = 48, h = 40;
    warp_image_rgba8 a, b;
    warp_image_u8 m;
    assert_true(warp_image_rgba8_alloc(&a, w, h) && warp_image_rgba8_alloc(&b, w, h));
    assert_true(warp_image_u8_alloc(&m, w, h));
    fill_textured(&a);
    warp_image_rgba8_copy(&b, &a);
    /* errors only in a left band flagged as fringe; a separate edge-flagged band is left intact */
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            if (x < 8) {
                WARP_AT(&m, x, y) = WARP_MASK_FRINGE;
                WARP_AT(&b, x, y) = rgb(255, 0, 255);
            } else if (x >= 40) {
                WARP_AT(&m, x, y) = WARP_MASK_EDGE;
            } else {
                WARP_AT(&m, x, y) = 0;
            }
        }
    /* unmasked: all metrics see the damage (8 of 48 columns) */
    assert_true(isfinite(warp_psnr(&a, &b, NULL, 0)));
    assert_true(fabs(warp_error_pixel_percent(&a, &b, NULL, 0, 20) - 100.0 * 8 / 48) < 1e-12);
    double s_all = warp_ssim(&a, &b, NULL, 0);
    assert_true(s_all < 0.9);
    /* excluding the fringe: PSNR infinite and no error pixels over the rest */
    assert_true(isinf(warp_psnr(&a, &b, &m, WARP_MASK_FRINGE)));
    assert_true(warp_error_pixel_percent(&a, &b, &m, WARP_MASK_FRINGE, 20) == 0);
    /* SSIM windows still straddle the band's edge, so it is not exactly 1; it matches the reference map mean */
    double s_ex = warp_ssim(&a, &b, &m, WARP_MASK_FRINGE);
    assert_true(s_ex > s_all && s_ex < 1);
    assert_true(fabs(s_ex - ref_ssim(&a, &b, &m, WARP_MASK_FRINGE)) < 1e-10);
    /* excluding the other bit only: the fringe still counts */
    assert_true(fabs(warp_error_pixel_percent(&a, &b, &m, WARP_MASK_EDGE, 20) - 100.0 * 8 / 40) < 1e-12);
    assert_true(fabs(warp_psnr(&a, &b, &m, WARP_MASK_EDGE) - warp_psnr(&a, &b, NULL, 0)) > 0.1);
    /* exclude = 0 means the mask is ignored */
    assert_true(warp_psnr(&a, &b, &m, 0) == warp_psnr(&a, &b, NULL, 0));
    assert_true(warp_ssim(&a, &b, &m, 0) == s_all);
    /* a mask that excludes everything leaves nothing to score */
    assert_true(isinf(warp_psnr(&a, &b, &m, WARP_MASK_FRINGE | WARP_MASK_EDGE))); /* the middle band still counts */
    warp_image_u8_fill(&m, WARP_MASK_FRINGE);
    assert_true(isnan(warp_psnr(&a, &b, &m, WARP_MASK_FRINGE)));
    assert_true(isnan(warp_ssim(&a, &b, &m, WARP_MASK_FRINGE)));
    assert_true(isnan(warp_error_pixel_percent(&a, &b, &m, WARP_MASK_FRINGE, 20)));
    warp_image_free(&m);
    warp_image_free(&a);
    warp_image_free(&b);
}

static void test_size_mismatch(void **state)
{
    (void)state;
    warp_image_rgba8 a, b;
    warp_image_u8 m;
    assert_true(warp_image_rgba8_alloc(&a, 20, 10) && warp_image_rgba8_alloc(&b, 10, 20));
    assert_true(warp_image_u8_alloc(&m, 5, 5));
    assert_true(isnan(warp_psnr(&a, &b, NULL, 0)));
    assert_true(isnan(warp_ssim(&a, &b, NULL, 0)));
    assert_true(isnan(warp_error_pixel_percent(&a, &b, NULL, 0, 20)));
    assert_true(isnan(warp_psnr(&a, &a, &m, 1)));
    assert_true(isnan(warp_ssim(&a, &a, &m, 1)));
    assert_true(isnan(warp_error_pixel_percent(&a, &a, &m, 1, 20)));
    warp_image_free(&a);
    warp_image_free(&b);
    warp_image_free(&m);
}

/* The depth-edge band (#21's accuracy where depth warps differ): against the definition, brute force, on a slanted
 * floor (1 % a pixel: no edge), a near square on it (a 50 % jump), a 5 % step (under the 10 % asked: none) and sky
 * (INFINITY) beside the floor (an edge) and beside sky (none). */
static int chebyshev(int x0, int y0, int x1, int y1)
{
    const int dx = abs(x0 - x1), dy = abs(y0 - y1);
    return dx > dy ? dx : dy;
}

static void test_depth_edge_band(void **state)
{
    (void)state;
    enum { W = 48, H = 32, R = 3 };
    warp_image_f32 z;
    warp_image_u8 band, small;
    assert_true(warp_image_f32_alloc(&z, W, H));
    assert_true(warp_image_u8_alloc(&band, W, H));
    assert_true(warp_image_u8_alloc(&small, W - 1, H));
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            float d = 2.0f * powf(1.01f, (float)x); /* slanted */
            if (x >= 8 && x < 16 && y >= 8 && y < 16) d *= 0.5f; /* the near square */
            if (x >= 24 && y >= 20) d *= 1.05f;                  /* a step under the threshold */
            if (x >= 40) d = INFINITY;                           /* sky */
            WARP_AT(&z, x, y) = d;
        }
    const long n = warp_depth_edge_band(&z, 0.1f, R, &band);
    long want = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            /* within R of the square's border pixels or of either side of the floor-sky boundary */
            bool in = false;
            for (int v = 0; v < H && !in; v++)
                for (int u = 0; u < W && !in; u++) {
                    const bool sq = u >= 8 && u < 16 && v >= 8 && v < 16;
                    const bool sq_border = sq && (u == 8 || u == 15 || v == 8 || v == 15);
                    const bool sq_ring = !sq && u >= 7 && u <= 16 && v >= 7 && v <= 16 &&
                                         !((u == 7 || u == 16) && (v == 7 || v == 16)); /* 4-neighbours only */
                    const bool sky = u == 39 || u == 40;
                    in = (sq_border || sq_ring || sky) && chebyshev(x, y, u, v) <= R;
                }
            want += in;
            assert_int_equal(WARP_AT(&band, x, y), in ? 0 : 1);
        }
    assert_int_equal(n, want);
    assert_true(n > 0 && n < W * H / 2);
    /* the 5 % step and the slant alone: far from the square and the sky, outside the band */
    assert_int_equal(WARP_AT(&band, 28, 20), 1);
    assert_int_equal(WARP_AT(&band, 30, 2), 1);
    assert_int_equal(warp_depth_edge_band(&z, 0.1f, R, &small), -1);
    warp_image_free(&z);
    warp_image_free(&band);
    warp_image_free(&small);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_identical_images),
        cmocka_unit_test(test_psnr_uniform_offset),
        cmocka_unit_test(test_ssim_matches_brute_force),
        cmocka_unit_test(test_ssim_noise_and_offset),
        cmocka_unit_test(test_lab_reference_colours),
        cmocka_unit_test(test_error_pixel_percent),
        cmocka_unit_test(test_mask_exclusion),
        cmocka_unit_test(test_size_mismatch),
        cmocka_unit_test(test_depth_edge_band),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
