/* Tests of the display path's resampler and distortion mesh: SIMD and scalar kernels agree bit for bit, an identity
 * mesh reproduces the source, and the mesh stays close to the exact per-pixel warp+distortion. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdlib.h>
#include <cmocka.h>

#include "tests/support/test_util.h"
#include "warp/warp_camera.h"
#include "warp/warp_lens.h"
#include "warp/warp_mesh.h"
#include "warp/warp_resample.h"

static void random_image(warp_image_rgba8 *img, uint64_t seed, double noise)
{
    test_rng r = test_rng_make(seed);
    /* smooth content plus noise: exercises both interpolation and exact texel fetches */
    for (int y = 0; y < img->h; y++)
        for (int x = 0; x < img->w; x++) {
            double s = 127 + 100 * sin(x * 0.05) * cos(y * 0.07);
            double n1 = test_rng_uniform(&r, -noise, noise), n2 = test_rng_uniform(&r, -noise, noise);
            double b = 127 + 120 * sin(x * 0.031 + y * 0.043);
            WARP_AT(img, x, y) = (warp_rgba8){(uint8_t)(s + n1), (uint8_t)(255 - s + n2),
                                              (uint8_t)(noise > 0 ? test_rng_uniform(&r, 0, 255) : b), 255};
        }
}

static warp_lens realistic_lens(void)
{
    warp_lens l;
    const double ca[3] = {0.996, 1.0, 1.008};
    for (int c = 0; c < 3; c++) {
        l.ch[c].k[0] = ca[c];
        l.ch[c].k[1] = 0.22 * ca[c];
        l.ch[c].k[2] = 0.24 * ca[c];
        l.ch[c].k[3] = 0;
    }
    l.center_x = 200;
    l.center_y = 180;
    l.scale = 200;
    return l;
}

static void test_planar_deinterleave(void **state)
{
    (void)state;
    warp_image_rgba8 img;
    warp_planar3 p;
    assert_true(warp_image_rgba8_alloc(&img, 37, 11));
    assert_true(warp_planar3_alloc(&p, 37, 11));
    random_image(&img, 1, 20);
    warp_planar3_from_rgba_rows(&p, &img, 0, 11);
    for (int y = 0; y < 11; y++)
        for (int x = 0; x < 37; x++) {
            assert_int_equal(p.plane[0][y * p.stride + x], WARP_AT(&img, x, y).r);
            assert_int_equal(p.plane[2][y * p.stride + x], WARP_AT(&img, x, y).b);
        }
    warp_planar3_free(&p);
    warp_image_free(&img);
}

/* Source 400x360 seen through the realistic lens on a 400x360 viewport, rotated a little. */
typedef struct {
    warp_camera cam;
    warp_lens lens;
    warp_mesh mesh;
    warp_image_rgba8 src, out;
    warp_planar3 planar;
    warp_quat rot;
} fixture;

static void fixture_make(fixture *f, int n, bool identity, double noise)
{
    /* square pixels: the identity lens uses one pixel density for both axes */
    f->cam = (warp_camera){400, 360, 1.43, 1.43, 1.43 * 0.9, 1.43 * 0.9, 0.1, INFINITY};
    f->lens = identity ? warp_lens_identity(&f->cam) : realistic_lens();
    assert_true(warp_mesh_init(&f->mesh, n, &f->lens, 0, 0, 400, 360));
    assert_true(warp_image_rgba8_alloc(&f->src, 400, 360));
    assert_true(warp_image_rgba8_alloc(&f->out, 400, 360));
    assert_true(warp_planar3_alloc(&f->planar, 400, 360));
    random_image(&f->src, 7, noise);
    warp_planar3_from_rgba_rows(&f->planar, &f->src, 0, 360);
    f->rot = identity ? warp_quat_identity() : warp_quat_from_ypr(0.05, -0.03, 0.02);
    warp_mesh_update(&f->mesh, &f->cam, f->rot);
}

static void fixture_free(fixture *f)
{
    warp_mesh_free(&f->mesh);
    warp_image_free(&f->src);
    warp_image_free(&f->out);
    warp_planar3_free(&f->planar);
}

static void test_kernels_bit_identical(void **state)
{
    (void)state;
    fixture f;
    fixture_make(&f, 33, false, 20);
    warp_image_rgba8 a;
    assert_true(warp_image_rgba8_alloc(&a, 400, 360));
    warp_resample_force_scalar(true);
    warp_mesh_resample(&f.mesh, &f.planar, &a, 0, 0, 400, 360);
    warp_resample_force_scalar(false);
    /* odd tile boundaries exercise the SIMD tail handling */
    warp_mesh_resample(&f.mesh, &f.planar, &f.out, 0, 0, 203, 171);
    warp_mesh_resample(&f.mesh, &f.planar, &f.out, 203, 0, 400, 171);
    warp_mesh_resample(&f.mesh, &f.planar, &f.out, 0, 171, 400, 360);
    long diff = 0;
    for (int y = 0; y < 360; y++)
        for (int x = 0; x < 400; x++) {
            warp_rgba8 p = WARP_AT(&a, x, y), q = WARP_AT(&f.out, x, y);
            diff += p.r != q.r || p.g != q.g || p.b != q.b || p.a != q.a;
        }
    assert_int_equal(diff, 0);
    print_message("kernel in use: %s\n", warp_resample_kernel());
    warp_image_free(&a);
    fixture_free(&f);
}

static void test_identity_mesh_reproduces_source(void **state)
{
    (void)state;
    fixture f;
    fixture_make(&f, 17, true, 20);
    warp_mesh_resample(&f.mesh, &f.planar, &f.out, 0, 0, 400, 360);
    int maxd = 0;
    for (int y = 0; y < 360; y++)
        for (int x = 0; x < 400; x++) {
            warp_rgba8 p = WARP_AT(&f.src, x, y), q = WARP_AT(&f.out, x, y);
            int d = abs(p.r - q.r) + abs(p.g - q.g) + abs(p.b - q.b);
            if (d > maxd) maxd = d;
        }
    assert_int_equal(maxd, 0);
    fixture_free(&f);
}

/* Exact reference: per pixel and channel, lens then rotation then projection in double, float bilinear sample. */
static void exact_pixel(const fixture *f, int x, int y, int out[3])
{
    warp_mat3 k = warp_camera_K(&f->cam), r = warp_quat_to_mat3(f->rot), h = warp_mat3_mul(&k, &r);
    for (int c = 0; c < 3; c++) {
        double u, v;
        warp_lens_distort(&f->lens, c, x + 0.5, y + 0.5, &u, &v);
        warp_vec3 p = warp_mat3_apply(&h, warp_v3(u, v, -1));
        warp_rgba8 s = warp_sample_bilinear(&f->src, (float)(p.x / p.z), (float)(p.y / p.z));
        out[c] = c == 0 ? s.r : (c == 1 ? s.g : s.b);
    }
}

static void test_mesh_close_to_exact(void **state)
{
    (void)state;
    /* The piecewise-bilinear mesh approximates the exact mapping; a finer mesh must be closer. A smooth source
     * makes the colour error proportional to the position error. */
    double mean_err[2];
    int ns[2] = {9, 65};
    for (int t = 0; t < 2; t++) {
        fixture f;
        fixture_make(&f, ns[t], false, 0);
        warp_mesh_resample(&f.mesh, &f.planar, &f.out, 0, 0, 400, 360);
        double sum = 0;
        long cnt = 0;
        for (int y = 2; y < 358; y += 3)
            for (int x = 2; x < 398; x += 3) {
                int e[3];
                exact_pixel(&f, x, y, e);
                warp_rgba8 q = WARP_AT(&f.out, x, y);
                sum += abs(e[0] - q.r) + abs(e[1] - q.g) + abs(e[2] - q.b);
                cnt += 3;
            }
        mean_err[t] = sum / (double)cnt;
        fixture_free(&f);
    }
    print_message("mean |mesh - exact| per channel: n=9 %.3f, n=65 %.3f levels\n", mean_err[0], mean_err[1]);
    assert_true(mean_err[1] < 0.5);
    assert_true(mean_err[0] > mean_err[1]);
}

static void test_chromatic_aberration_separates_channels(void **state)
{
    (void)state;
    /* A grey source with a sharp vertical edge: through a lens with per-channel scale the edge lands at different
     * panel columns for red and blue, and only there do the channels disagree. */
    fixture f;
    fixture_make(&f, 65, false, 20);
    for (int y = 0; y < 360; y++)
        for (int x = 0; x < 400; x++) WARP_AT(&f.src, x, y) = x < 330 ? (warp_rgba8){40, 40, 40, 255} : (warp_rgba8){220, 220, 220, 255};
    warp_planar3_from_rgba_rows(&f.planar, &f.src, 0, 360);
    warp_mesh_update(&f.mesh, &f.cam, warp_quat_identity());
    warp_mesh_resample(&f.mesh, &f.planar, &f.out, 0, 0, 400, 360);
    int rb_diff = 0, rg_same_centre = 1;
    for (int x = 0; x < 400; x++) {
        warp_rgba8 p = WARP_AT(&f.out, x, 180);
        if (abs(p.r - p.b) > 30) rb_diff++;
    }
    for (int x = 150; x < 250; x++) {
        warp_rgba8 p = WARP_AT(&f.out, x, 180);
        if (p.r != p.g || p.g != p.b) rg_same_centre = 0;
    }
    assert_true(rb_diff >= 1);
    assert_true(rg_same_centre);
    fixture_free(&f);
}

static void test_mesh_behind_camera_is_fringe(void **state)
{
    (void)state;
    fixture f;
    fixture_make(&f, 17, false, 20);
    /* Turned all the way round: every vertex points behind the source camera. */
    warp_mesh_update(&f.mesh, &f.cam, warp_quat_from_ypr(WARP_PI, 0, 0));
    assert_int_equal(f.mesh.behind, 17 * 17 * 3);
    warp_mesh_resample(&f.mesh, &f.planar, &f.out, 0, 0, 400, 360);
    /* clamped to the source's top-left texel, never reading outside */
    warp_rgba8 p = WARP_AT(&f.out, 200, 180), s = WARP_AT(&f.src, 0, 0);
    assert_int_equal(p.r, s.r);
    assert_int_equal(p.g, s.g);
    fixture_free(&f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_planar_deinterleave),
        cmocka_unit_test(test_kernels_bit_identical),
        cmocka_unit_test(test_identity_mesh_reproduces_source),
        cmocka_unit_test(test_mesh_close_to_exact),
        cmocka_unit_test(test_chromatic_aberration_separates_channels),
        cmocka_unit_test(test_mesh_behind_camera_is_fringe),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
