/* SPDX-License-Identifier: MIT */
/* Tests of the display path's resampler and distortion mesh: every kernel agrees bit for bit with the scalar
 * reference for any tiling, an identity mesh reproduces the source, and the mesh stays close to the exact warp. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "tests/support/test_util.h"
#include "warp/warp_camera.h"
#include "warp/warp_lens.h"
#include "warp/warp_mesh.h"
#include "warp/warp_resample.h"

static const warp_resample_kernel_id all_kernels[] = {WARP_RESAMPLE_SCALAR, WARP_RESAMPLE_VECTOR, WARP_RESAMPLE_AVX2,
                                                      WARP_RESAMPLE_AVX512};
#define KERNELS (int)(sizeof all_kernels / sizeof all_kernels[0])

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

static warp_lens realistic_lens(void) { return test_reference_lens(200, 180, 200); }

static bool same_pixel(warp_rgba8 p, warp_rgba8 q) { return p.r == q.r && p.g == q.g && p.b == q.b && p.a == q.a; }

static void test_planar_deinterleave(void **state)
{
    (void)state;
    warp_image_rgba8 img;
    warp_planar3 p;
    assert_true(warp_image_rgba8_alloc(&img, 37, 11));
    assert_true(warp_planar3_alloc(&p, 37, 11));
    random_image(&img, 1, 20);
    warp_planar3_from_rgba_rows(&p, &img, 0, 11);
    /* each element pairs a pixel with the one below it (the last row with itself) */
    for (int y = 0; y < 11; y++)
        for (int x = 0; x < 37; x++) {
            int yb = y + 1 < 11 ? y + 1 : y;
            assert_int_equal(p.plane[0][y * p.stride + x], WARP_AT(&img, x, y).r | WARP_AT(&img, x, yb).r << 8);
            assert_int_equal(p.plane[1][y * p.stride + x], WARP_AT(&img, x, y).g | WARP_AT(&img, x, yb).g << 8);
            assert_int_equal(p.plane[2][y * p.stride + x], WARP_AT(&img, x, y).b | WARP_AT(&img, x, yb).b << 8);
        }
    /* and the element right of the last column repeats it */
    for (int y = 0; y < 11; y++)
        for (int c = 0; c < 3; c++) assert_int_equal(p.plane[c][y * p.stride + 37], p.plane[c][y * p.stride + 36]);
    warp_planar3_free(&p);
    warp_image_free(&img);
}

static void test_mesh_layout(void **state)
{
    (void)state;
    /* columns a multiple of 8 pixels apart, the nearest such spacing to n spread evenly; rows as asked */
    const struct {
        int n, w, h, cell_w;
    } cases[] = {{64, 720, 800, 8},  {64, 1440, 1600, 24}, {65, 400, 360, 8}, {9, 400, 360, 48},
                 {2, 403, 297, 400}, {17, 401, 100, 24},   {3, 5, 7, 8},      {1024, 720, 800, 8}};
    const warp_lens lens = realistic_lens();
    for (size_t t = 0; t < sizeof cases / sizeof cases[0]; t++) {
        warp_mesh m;
        assert_true(warp_mesh_alloc(&m, cases[t].n, &lens, 3, 5, cases[t].w, cases[t].h));
        assert_int_equal(m.cell_w, cases[t].cell_w);
        assert_int_equal(m.rows, cases[t].n);
        assert_int_equal(m.cols, (cases[t].w + m.cell_w - 1) / m.cell_w + 1);
        assert_true((m.cols - 1) * m.cell_w >= cases[t].w);
        assert_true((m.cols - 2) * m.cell_w < cases[t].w);
        /* vertices sit exactly on pixel positions: the lens is evaluated there */
        for (int j = 0; j < m.rows; j += m.rows - 1)
            for (int i = 0; i < m.cols; i += m.cols - 1) {
                double u, v;
                warp_lens_distort(&lens, 2, (double)i * m.cell_w, (double)j * cases[t].h / (m.rows - 1), &u, &v);
                assert_true(m.tan[((size_t)j * m.cols + i) * 3 + 2].x == (float)u);
                assert_true(m.tan[((size_t)j * m.cols + i) * 3 + 2].y == (float)v);
            }
        warp_mesh_free(&m);
    }
    warp_mesh m;
    assert_false(warp_mesh_alloc(&m, 1, &lens, 0, 0, 100, 100));
    assert_false(warp_mesh_alloc(&m, 1025, &lens, 0, 0, 100, 100));
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
    assert_true(warp_mesh_alloc(&f->mesh, n, &f->lens, 0, 0, 400, 360));
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

/* Resamples the viewport cut into random rectangles (odd sizes and starts, so SIMD groups are split anywhere). */
static void resample_random_tiles(const warp_mesh *m, const warp_planar3 *src, warp_image_rgba8 *dst, test_rng *r)
{
    for (int y0 = 0; y0 < m->vp_h;) {
        int y1 = y0 + 1 + (int)test_rng_uniform(r, 0, 40);
        y1 = y1 < m->vp_h ? y1 : m->vp_h;
        for (int x0 = 0; x0 < m->vp_w;) {
            int x1 = x0 + 1 + (int)test_rng_uniform(r, 0, 150);
            x1 = x1 < m->vp_w ? x1 : m->vp_w;
            warp_mesh_resample(m, src, dst, x0, y0, x1, y1);
            x0 = x1;
        }
        y0 = y1;
    }
}

static void test_kernels_bit_identical(void **state)
{
    (void)state;
    /* Every kernel, tiled at random, against the scalar reference over the whole viewport in one call: random
     * content, small to large meshes, viewports and sources of odd sizes, warps from gentle to steep (the AVX-512
     * kernel's window and gather paths) and past the source's border, the viewport inside a larger panel. */
    const struct {
        int n, vw, vh, sw, sh;
        double yaw, pitch, roll;
    } cases[] = {
        {33, 400, 360, 400, 360, 0.05, -0.03, 0.02}, {65, 403, 297, 517, 389, 0.3, -0.2, 0.1},
        {2, 203, 171, 300, 200, 0.0, 0.0, 0.0},      {5, 160, 120, 90, 70, -0.4, 0.3, 0.9},
        {200, 331, 250, 331, 250, 0.1, 0.05, -0.3},  {17, 96, 400, 640, 480, 1.4, 0.2, 0.0},
    };
    const warp_lens lens = realistic_lens();
    const warp_rgba8 sentinel = {1, 2, 3, 4};
    int compared = 0;
    for (size_t t = 0; t < sizeof cases / sizeof cases[0]; t++) {
        const int vx = 7, vy = 3, pw = cases[t].vw + 19, ph = cases[t].vh + 5;
        warp_camera cam = {cases[t].sw, cases[t].sh, 1.2, 1.1, 1.0, 1.05, 0.1, INFINITY};
        warp_mesh m;
        warp_image_rgba8 src, ref, out;
        warp_planar3 planar;
        assert_true(warp_mesh_alloc(&m, cases[t].n, &lens, vx, vy, cases[t].vw, cases[t].vh));
        assert_true(warp_image_rgba8_alloc(&src, cases[t].sw, cases[t].sh));
        assert_true(warp_image_rgba8_alloc(&ref, pw, ph));
        assert_true(warp_image_rgba8_alloc(&out, pw, ph));
        assert_true(warp_planar3_alloc(&planar, cases[t].sw, cases[t].sh));
        random_image(&src, 100 + t, 60);
        warp_planar3_from_rgba_rows(&planar, &src, 0, cases[t].sh);
        warp_mesh_update(&m, &cam, warp_quat_from_ypr(cases[t].yaw, cases[t].pitch, cases[t].roll));
        warp_image_rgba8_fill(&ref, sentinel);
        assert_true(warp_resample_force_kernel(WARP_RESAMPLE_SCALAR));
        warp_mesh_resample(&m, &planar, &ref, 0, 0, cases[t].vw, cases[t].vh);
        test_rng r = test_rng_make(7 + t);
        for (int k = 0; k < KERNELS; k++) {
            if (!warp_resample_force_kernel(all_kernels[k])) continue;
            warp_image_rgba8_fill(&out, sentinel);
            resample_random_tiles(&m, &planar, &out, &r);
            long diff = 0;
            for (int y = 0; y < ph; y++)
                for (int x = 0; x < pw; x++) {
                    bool inside = x >= vx && x < vx + cases[t].vw && y >= vy && y < vy + cases[t].vh;
                    diff += !same_pixel(WARP_AT(&out, x, y), WARP_AT(&ref, x, y));
                    /* only the viewport is written */
                    diff += !inside && !same_pixel(WARP_AT(&out, x, y), sentinel);
                }
            if (diff) print_message("case %zu: kernel %s differs in %ld pixels\n", t, warp_resample_kernel(), diff);
            assert_int_equal(diff, 0);
            compared++;
        }
        warp_mesh_free(&m);
        warp_image_free(&src);
        warp_image_free(&ref);
        warp_image_free(&out);
        warp_planar3_free(&planar);
    }
    warp_resample_force_kernel(WARP_RESAMPLE_AUTO);
    print_message("kernel in use: %s; %d kernel runs compared\n", warp_resample_kernel(), compared);
}

static void test_identity_mesh_reproduces_source(void **state)
{
    (void)state;
    fixture f;
    fixture_make(&f, 17, true, 20);
    for (int k = 0; k < KERNELS; k++) {
        if (!warp_resample_force_kernel(all_kernels[k])) continue;
        warp_image_rgba8_fill(&f.out, (warp_rgba8){0, 0, 0, 0});
        warp_mesh_resample(&f.mesh, &f.planar, &f.out, 0, 0, 400, 360);
        int maxd = 0;
        for (int y = 0; y < 360; y++)
            for (int x = 0; x < 400; x++) {
                warp_rgba8 p = WARP_AT(&f.src, x, y), q = WARP_AT(&f.out, x, y);
                int d = abs(p.r - q.r) + abs(p.g - q.g) + abs(p.b - q.b);
                if (d > maxd) maxd = d;
            }
        assert_int_equal(maxd, 0);
    }
    warp_resample_force_kernel(WARP_RESAMPLE_AUTO);
    fixture_free(&f);
}

static void test_half_pixel_shift_averages(void **state)
{
    (void)state;
    /* Moving the identity lens's centre by half a pixel samples exactly between two source pixels: the 6-bit
     * weights are 32/32 and the result is their average rounded half up, in every kernel. */
    for (int axis = 0; axis < 2; axis++) {
        fixture f;
        fixture_make(&f, 17, true, 60);
        if (axis == 0)
            f.lens.center_x += 0.5;
        else
            f.lens.center_y += 0.5;
        warp_mesh_free(&f.mesh);
        assert_true(warp_mesh_alloc(&f.mesh, 17, &f.lens, 0, 0, 400, 360));
        warp_mesh_update(&f.mesh, &f.cam, warp_quat_identity());
        for (int k = 0; k < KERNELS; k++) {
            if (!warp_resample_force_kernel(all_kernels[k])) continue;
            warp_mesh_resample(&f.mesh, &f.planar, &f.out, 0, 0, 400, 360);
            long bad = 0;
            for (int y = 1; y < 360; y++)
                for (int x = 1; x < 400; x++) {
                    warp_rgba8 a = WARP_AT(&f.src, x, y), b = axis == 0 ? WARP_AT(&f.src, x - 1, y) : WARP_AT(&f.src, x, y - 1);
                    warp_rgba8 q = WARP_AT(&f.out, x, y);
                    bad += q.r != (a.r + b.r + 1) >> 1 || q.g != (a.g + b.g + 1) >> 1 || q.b != (a.b + b.b + 1) >> 1;
                }
            assert_int_equal(bad, 0);
        }
        warp_resample_force_kernel(WARP_RESAMPLE_AUTO);
        fixture_free(&f);
    }
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
     * makes the colour error proportional to the position error. (n = 65 over 400 pixels gives 8-pixel columns,
     * a little coarser than 400 / 64; the 1/64-pixel positions add at most 1/128 pixel.) */
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
    assert_int_equal(f.mesh.behind, f.mesh.rows * f.mesh.cols * 3);
    for (int k = 0; k < KERNELS; k++) {
        if (!warp_resample_force_kernel(all_kernels[k])) continue;
        warp_mesh_resample(&f.mesh, &f.planar, &f.out, 0, 0, 400, 360);
        /* clamped to the source's top-left texel, never reading outside */
        warp_rgba8 p = WARP_AT(&f.out, 200, 180), s = WARP_AT(&f.src, 0, 0);
        assert_int_equal(p.r, s.r);
        assert_int_equal(p.g, s.g);
    }
    /* Turned 80 degrees: part of the mesh behind, part in front, cells in between interpolating across the far
     * positions; all kernels must still agree and stay inside the source (ASan checks the latter). */
    warp_mesh_update(&f.mesh, &f.cam, warp_quat_from_ypr(1.4, 0.3, 0));
    assert_true(f.mesh.behind > 0 && f.mesh.behind < f.mesh.rows * f.mesh.cols * 3);
    warp_image_rgba8 ref;
    assert_true(warp_image_rgba8_alloc(&ref, 400, 360));
    assert_true(warp_resample_force_kernel(WARP_RESAMPLE_SCALAR));
    warp_mesh_resample(&f.mesh, &f.planar, &ref, 0, 0, 400, 360);
    for (int k = 0; k < KERNELS; k++) {
        if (!warp_resample_force_kernel(all_kernels[k])) continue;
        warp_mesh_resample(&f.mesh, &f.planar, &f.out, 0, 0, 400, 360);
        assert_memory_equal(f.out.px, ref.px, sizeof(warp_rgba8) * 400 * 360);
    }
    warp_resample_force_kernel(WARP_RESAMPLE_AUTO);
    warp_image_free(&ref);
    fixture_free(&f);
}

static void test_kernel_selection(void **state)
{
    (void)state;
    /* SCALAR and VECTOR run everywhere; forcing an unavailable kernel changes nothing */
    assert_true(warp_resample_kernel_available(WARP_RESAMPLE_SCALAR));
    assert_true(warp_resample_kernel_available(WARP_RESAMPLE_VECTOR));
    warp_resample_force_scalar(true);
    assert_string_equal(warp_resample_kernel(), "scalar");
    assert_true(warp_resample_force_kernel(WARP_RESAMPLE_VECTOR));
    assert_string_equal(warp_resample_kernel(), "vector");
    if (!warp_resample_kernel_available(WARP_RESAMPLE_AVX512)) {
        assert_false(warp_resample_force_kernel(WARP_RESAMPLE_AVX512));
        assert_string_equal(warp_resample_kernel(), "vector");
    }
    warp_resample_force_scalar(false);
    assert_true(warp_resample_force_kernel(WARP_RESAMPLE_AUTO));
}

static void test_kernel_pick_by_measurement(void **state)
{
    (void)state;
    const bool all[WARP_RESAMPLE_KERNELS] = {false, true, true, true, true};
    /* the Zen 5: AVX-512 (6.12 ms) was slower than AVX2 (5.83 ms), and the widest-first rule ran it */
    double ms[WARP_RESAMPLE_KERNELS] = {0, 18.1, 11.0, 5.83, 6.12};
    assert_int_equal(warp_resample_kernel_pick(ms, all), WARP_RESAMPLE_AVX2);
    ms[WARP_RESAMPLE_AVX512] = 5.0;
    assert_int_equal(warp_resample_kernel_pick(ms, all), WARP_RESAMPLE_AVX512);
    /* under an emulator the plain kernels can win */
    const double emu[WARP_RESAMPLE_KERNELS] = {0, 40, 55, 90, 300};
    assert_int_equal(warp_resample_kernel_pick(emu, all), WARP_RESAMPLE_SCALAR);
    /* ties, exact or within the margin, go to the narrower kernel, whichever of them measured faster */
    const double tie[WARP_RESAMPLE_KERNELS] = {0, 30, 10, 5.0, 5.0};
    assert_int_equal(warp_resample_kernel_pick(tie, all), WARP_RESAMPLE_AVX2);
    const double near[WARP_RESAMPLE_KERNELS] = {0, 30, 10, 5.0 * (1 + WARP_RESAMPLE_PICK_TIE / 2), 5.0};
    assert_int_equal(warp_resample_kernel_pick(near, all), WARP_RESAMPLE_AVX2);
    const double clear[WARP_RESAMPLE_KERNELS] = {0, 30, 10, 5.0 * (1 + 2 * WARP_RESAMPLE_PICK_TIE), 5.0};
    assert_int_equal(warp_resample_kernel_pick(clear, all), WARP_RESAMPLE_AVX512);
    /* a kernel this CPU cannot run is never picked, however fast its (bogus) time; nor one not measured (0, NaN,
     * negative) */
    const bool no_avx512[WARP_RESAMPLE_KERNELS] = {false, true, true, true, false};
    const double fast512[WARP_RESAMPLE_KERNELS] = {0, 30, 10, 5.0, 0.1};
    assert_int_equal(warp_resample_kernel_pick(fast512, no_avx512), WARP_RESAMPLE_AVX2);
    const bool plain[WARP_RESAMPLE_KERNELS] = {false, true, true, false, false};
    assert_int_equal(warp_resample_kernel_pick(fast512, plain), WARP_RESAMPLE_VECTOR);
    const double unmeasured[WARP_RESAMPLE_KERNELS] = {0, 30, NAN, 0, -1};
    assert_int_equal(warp_resample_kernel_pick(unmeasured, all), WARP_RESAMPLE_SCALAR);
    /* AUTO's own entry is no kernel */
    const double auto_fast[WARP_RESAMPLE_KERNELS] = {0.01, 30, 10, 0, 0};
    const bool with_auto[WARP_RESAMPLE_KERNELS] = {true, true, true, false, false};
    assert_int_equal(warp_resample_kernel_pick(auto_fast, with_auto), WARP_RESAMPLE_VECTOR);
    /* nothing measured: the widest this CPU runs, which it can run */
    const double none[WARP_RESAMPLE_KERNELS] = {0};
    const warp_resample_kernel_id w = warp_resample_kernel_pick(none, all);
    assert_int_equal(w, warp_resample_kernel_widest());
    assert_true(warp_resample_kernel_available(w));

    /* AUTO runs the choice until it is set back; forcing still wins over it */
    assert_true(warp_resample_set_auto(WARP_RESAMPLE_VECTOR));
    assert_string_equal(warp_resample_kernel(), "vector");
    assert_true(warp_resample_force_kernel(WARP_RESAMPLE_SCALAR));
    assert_string_equal(warp_resample_kernel(), "scalar");
    assert_true(warp_resample_force_kernel(WARP_RESAMPLE_AUTO));
    assert_string_equal(warp_resample_kernel(), "vector");
    if (!warp_resample_kernel_available(WARP_RESAMPLE_AVX512))
        assert_false(warp_resample_set_auto(WARP_RESAMPLE_AVX512));
    assert_true(warp_resample_set_auto(WARP_RESAMPLE_AUTO));
    assert_string_equal(warp_resample_kernel(), warp_resample_kernel_name(warp_resample_kernel_widest()));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_planar_deinterleave),
        cmocka_unit_test(test_mesh_layout),
        cmocka_unit_test(test_kernels_bit_identical),
        cmocka_unit_test(test_identity_mesh_reproduces_source),
        cmocka_unit_test(test_half_pixel_shift_averages),
        cmocka_unit_test(test_mesh_close_to_exact),
        cmocka_unit_test(test_chromatic_aberration_separates_channels),
        cmocka_unit_test(test_mesh_behind_camera_is_fringe),
        cmocka_unit_test(test_kernel_selection),
        cmocka_unit_test(test_kernel_pick_by_measurement),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
