/* SPDX-License-Identifier: MIT */
/* Unit tests for the V4L2 frame path: pixel conversions (75 % bars, round trips), the in-band layout (metadata
 * bit exact through YUYV, NV12, RGB and RGB->YUV->RGB; depth within quantisation; garbled bands rejected), and the
 * capture backend end to end over the mock device fed by the simulated host (formats, faults, reconnect). */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "drivers/drv_frames_v4l2_mock.h"
#include "drivers/drv_v4l2_output.h"
#include "drivers/drv_v4l2_convert.h"
#include "drivers/drv_v4l2_inband.h"
#include "platform/plat_clock.h"
#include "sim/sim_scene.h"
#include "tests/support/test_util.h"
#include "warp/warp_head.h"
#include "warp/warp_metrics.h"

static const uint32_t all_formats[] = {DRV_V4L2_YUYV, DRV_V4L2_NV12, DRV_V4L2_BGR32, DRV_V4L2_XBGR32, DRV_V4L2_RGB24};
#define NFORMATS (int)(sizeof all_formats / sizeof all_formats[0])

#define assert_near(v, ref, tol)                                                                                    \
    do {                                                                                                            \
        int v_ = (v), r_ = (ref);                                                                                   \
        if (abs(v_ - r_) > (tol)) fail_msg("%s = %d, want %d +- %d", #v, v_, r_, (tol));                           \
    } while (0)

static uint8_t *image_new(drv_v4l2_geom *g, uint32_t fourcc, int w, int h, int pad)
{
    assert_true(drv_v4l2_geom_init(g, fourcc, w, h, drv_v4l2_min_bytesperline(fourcc, w) + pad));
    assert_null(drv_v4l2_geom_check(g));
    uint8_t *p = malloc(g->size);
    assert_non_null(p);
    memset(p, 0x5a, g->size);
    return p;
}

/* ---- conversions ---- */

static void test_fourcc_and_geometry(void **state)
{
    (void)state;
    assert_int_equal(drv_v4l2_fourcc_parse("yuyv"), DRV_V4L2_YUYV);
    assert_int_equal(drv_v4l2_fourcc_parse("NV12"), DRV_V4L2_NV12);
    assert_int_equal(drv_v4l2_fourcc_parse("bgr32"), DRV_V4L2_BGR32);
    assert_int_equal(drv_v4l2_fourcc_parse("rgb24"), DRV_V4L2_RGB24);
    assert_int_equal(drv_v4l2_fourcc_parse("auto"), 0);
    assert_int_equal(drv_v4l2_fourcc_parse("mjpg"), 0);
    char buf[8];
    assert_string_equal(drv_v4l2_fourcc_str(DRV_V4L2_XBGR32, buf), "XR24");
    assert_false(drv_v4l2_fourcc_supported(DRV_V4L2_FOURCC('M', 'J', 'P', 'G')));
    drv_v4l2_geom g;
    assert_true(drv_v4l2_geom_init(&g, DRV_V4L2_NV12, 64, 32, 0));
    assert_int_equal(g.bytesperline, 64);
    assert_int_equal(g.size, 64 * 32 * 3 / 2);
    assert_true(drv_v4l2_geom_init(&g, DRV_V4L2_YUYV, 64, 32, 256));
    assert_int_equal(g.size, 256 * 32);
    assert_false(drv_v4l2_geom_init(&g, DRV_V4L2_RGB24, 64, 32, 100)); /* stride below 3 * 64 */
    assert_true(drv_v4l2_geom_init(&g, DRV_V4L2_NV12, 64, 31, 0));
    assert_non_null(drv_v4l2_geom_check(&g)); /* odd height */
    assert_true(drv_v4l2_geom_init(&g, DRV_V4L2_YUYV, 64, 32, 0));
    g.size--;
    assert_non_null(drv_v4l2_geom_check(&g));
}

/* 75 % colour bars (white, yellow, cyan, green, magenta, red, blue, black) and their Y'CbCr in BT.601 and BT.709
 * limited range (ITU-R BT.801 / SMPTE RP 219 tables). */
static const warp_rgba8 bars[8] = {{191, 191, 191, 255}, {191, 191, 0, 255}, {0, 191, 191, 255}, {0, 191, 0, 255},
                                   {191, 0, 191, 255},   {191, 0, 0, 255},   {0, 0, 191, 255},   {0, 0, 0, 255}};
static const int bars601[8][3] = {{180, 128, 128}, {162, 44, 142}, {131, 156, 44}, {112, 72, 58},
                                  {84, 184, 198},  {65, 100, 212}, {35, 212, 114}, {16, 128, 128}};
static const int bars709[8][3] = {{180, 128, 128}, {168, 44, 136}, {145, 147, 44}, {133, 63, 52},
                                  {63, 193, 204},  {51, 109, 212}, {28, 212, 120}, {16, 128, 128}};

static void check_bars(const drv_v4l2_colorspace *cs, const int ref[8][3])
{
    /* Each bar two pixels wide, so the 4:2:2 chroma of a pair is the bar's own. */
    warp_rgba8 src[16], back[16];
    for (int i = 0; i < 16; i++) src[i] = bars[i / 2];
    drv_v4l2_geom g;
    uint8_t *img = image_new(&g, DRV_V4L2_YUYV, 16, 2, 0);
    drv_v4l2_from_rgba(src, 16, 16, 1, cs, img, &g, 0, 0);
    for (int b = 0; b < 8; b++) {
        const uint8_t *p = img + 4 * b;
        assert_near(p[0], ref[b][0], 2);
        assert_near(p[2], ref[b][0], 2);
        assert_near(p[1], ref[b][1], 2);
        assert_near(p[3], ref[b][2], 2);
    }
    /* And the reference Y'CbCr back to the bars. */
    for (int b = 0; b < 8; b++) {
        uint8_t *p = img + g.bytesperline + 4 * b;
        p[0] = p[2] = (uint8_t)ref[b][0], p[1] = (uint8_t)ref[b][1], p[3] = (uint8_t)ref[b][2];
    }
    drv_v4l2_to_rgba(img, &g, cs, 0, 1, 16, 1, back, 16);
    for (int i = 0; i < 16; i++) {
        assert_near(back[i].r, src[i].r, 2);
        assert_near(back[i].g, src[i].g, 2);
        assert_near(back[i].b, src[i].b, 2);
        assert_int_equal(back[i].a, 255);
    }
    free(img);
}

static void test_bars(void **state)
{
    (void)state;
    drv_v4l2_colorspace cs601 = {DRV_V4L2_BT601, false}, cs709 = {DRV_V4L2_BT709, false};
    check_bars(&cs601, bars601);
    check_bars(&cs709, bars709);
    /* Full range (JFIF): 100 % red is Y 76, Cb 85, Cr 255; white 255/128/128. */
    drv_v4l2_colorspace full = {DRV_V4L2_BT601, true};
    warp_rgba8 px[2] = {{255, 0, 0, 255}, {255, 0, 0, 255}}, wh[2] = {{255, 255, 255, 255}, {255, 255, 255, 255}};
    drv_v4l2_geom g;
    uint8_t *img = image_new(&g, DRV_V4L2_YUYV, 2, 2, 0);
    drv_v4l2_from_rgba(px, 2, 2, 1, &full, img, &g, 0, 0);
    drv_v4l2_from_rgba(wh, 2, 2, 1, &full, img, &g, 0, 1);
    assert_in_range(img[0], 74, 78);
    assert_in_range(img[1], 83, 87);
    assert_in_range(img[3], 253, 255);
    assert_int_equal(img[g.bytesperline], 255);
    assert_in_range(img[g.bytesperline + 1], 127, 129);
    free(img);
}

/* An image of 2x2 blocks of one random colour each (so 4:2:0 chroma loses nothing). */
static void blocky_image(warp_image_rgba8 *im, int w, int h, uint64_t seed)
{
    assert_true(warp_image_rgba8_alloc(im, w, h));
    test_rng r = test_rng_make(seed);
    for (int y = 0; y < h; y += 2)
        for (int x = 0; x < w; x += 2) {
            uint64_t v = test_rng_next(&r);
            warp_rgba8 c = {(uint8_t)v, (uint8_t)(v >> 8), (uint8_t)(v >> 16), 255};
            WARP_AT(im, x, y) = WARP_AT(im, x + 1, y) = WARP_AT(im, x, y + 1) = WARP_AT(im, x + 1, y + 1) = c;
        }
}

static void test_round_trips(void **state)
{
    (void)state;
    const int w = 48, h = 20;
    warp_image_rgba8 src, back;
    blocky_image(&src, w, h, 7);
    assert_true(warp_image_rgba8_alloc(&back, w, h));
    const drv_v4l2_colorspace css[3] = {{DRV_V4L2_BT601, false}, {DRV_V4L2_BT709, false}, {DRV_V4L2_BT601, true}};
    for (int fi = 0; fi < NFORMATS; fi++)
        for (int ci = 0; ci < 3; ci++) {
            /* A sub-rectangle at an even offset of a larger padded buffer. */
            drv_v4l2_geom g;
            uint8_t *img = image_new(&g, all_formats[fi], w + 8, h + 6, 40);
            drv_v4l2_from_rgba(src.px, src.stride, w, h, &css[ci], img, &g, 4, 2);
            drv_v4l2_to_rgba(img, &g, &css[ci], 4, 2, w, h, back.px, back.stride);
            bool yuv = all_formats[fi] == DRV_V4L2_YUYV || all_formats[fi] == DRV_V4L2_NV12;
            /* Limited-range Y'CbCr has fewer codes than RGB: a round trip is within a few levels, saturated colours
             * (out of the Y'CbCr gamut corners) included. */
            int tol = yuv ? (css[ci].full_range ? 2 : 3) : 0;
            for (int y = 0; y < h; y++)
                for (int x = 0; x < w; x++) {
                    warp_rgba8 a = WARP_AT(&src, x, y), b = WARP_AT(&back, x, y);
                    if (abs(a.r - b.r) > tol || abs(a.g - b.g) > tol || abs(a.b - b.b) > tol)
                        fail_msg("format %d cs %d at (%d,%d): %d,%d,%d -> %d,%d,%d", fi, ci, x, y, a.r, a.g, a.b, b.r,
                                 b.g, b.b);
                }
            free(img);
        }
    warp_image_free(&src);
    warp_image_free(&back);
}

static void test_grey_levels(void **state)
{
    (void)state;
    uint8_t lv[16], out[16];
    for (int i = 0; i < 16; i++) lv[i] = (uint8_t)(i * 17);
    for (int fi = 0; fi < NFORMATS; fi++) {
        drv_v4l2_geom g;
        uint8_t *img = image_new(&g, all_formats[fi], 20, 4, 8);
        drv_v4l2_write_grey(img, &g, 2, 2, 16, lv);
        drv_v4l2_read_luma(img, &g, 2, 2, 16, out);
        assert_memory_equal(lv, out, 16);
        free(img);
    }
}

/* ---- in-band layout ---- */

#define EW 128
#define EH 64

static void frame_random(drv_frame *f, unsigned planes, uint64_t seed)
{
    assert_true(drv_frame_alloc(f, EW, EH, planes, 1));
    test_rng r = test_rng_make(seed);
    f->planes = planes;
    f->seq = test_rng_next(&r);
    f->pose_t_ns = (int64_t)(test_rng_next(&r) >> 2);
    f->render_start_ns = f->pose_t_ns - 12345678;
    f->scene_time = test_rng_uniform(&r, 0, 100);
    f->depth_encoding = WARP_DEPTH_LINEAR;
    for (int e = 0; e < 2; e++) {
        f->eye_pose[e].q = test_random_quat(&r);
        f->eye_pose[e].p = warp_v3(test_rng_uniform(&r, -2, 2), test_rng_uniform(&r, 0, 2), test_rng_uniform(&r, -2, 2));
        f->cam[e] = warp_camera_symmetric(EW, EH, 90 + e, 80, 0.05, INFINITY);
        f->cam[e].tan_left *= 1.1; /* asymmetric, like a real HMD frustum */
        warp_image_rgba8 c;
        blocky_image(&c, EW, EH, seed + 10 + (uint64_t)e);
        warp_image_rgba8_copy(&f->color[e], &c);
        warp_image_free(&c);
        if (planes & DRV_PLANE_DEPTH)
            for (int y = 0; y < EH; y++)
                for (int x = 0; x < EW; x++)
                    WARP_AT(&f->depth[e], x, y) = (x + y) % 17 == 0 ? INFINITY : (float)test_rng_uniform(&r, 0.05, 50);
    }
}

static void assert_meta_equal(const drv_frame *a, const drv_frame *b)
{
    assert_int_equal(a->seq, b->seq);
    assert_int_equal(a->pose_t_ns, b->pose_t_ns);
    assert_int_equal(a->render_start_ns, b->render_start_ns);
    assert_memory_equal(&a->scene_time, &b->scene_time, sizeof a->scene_time);
    for (int e = 0; e < 2; e++) {
        /* bit exact: the doubles travel as their IEEE bits */
        assert_memory_equal(&a->eye_pose[e], &b->eye_pose[e], sizeof a->eye_pose[e]);
        assert_memory_equal(&a->cam[e], &b->cam[e], sizeof a->cam[e]);
    }
}

static double psnr_eyes(const drv_frame *a, const drv_frame *b)
{
    double p0 = warp_psnr(&a->color[0], &b->color[0], NULL, 0), p1 = warp_psnr(&a->color[1], &b->color[1], NULL, 0);
    return p0 < p1 ? p0 : p1;
}

/* A random frame f with planes, an output frame for the same planes, and the video mode (w, h) their band and
 * rows need (with depth rows when planes has depth): what every pack/unpack round trip starts from. */
static void pack_fixture(drv_frame *f, drv_frame *out, unsigned planes, uint64_t seed, int *w, int *h)
{
    frame_random(f, planes, seed);
    assert_true(drv_frame_alloc(out, EW, EH, planes, 1));
    assert_true(drv_v4l2_layout(EW, EH, (planes & DRV_PLANE_DEPTH) != 0, w, h));
}

static void test_layout(void **state)
{
    (void)state;
    int w, h;
    assert_true(drv_v4l2_layout(EW, EH, false, &w, &h));
    assert_int_equal(w, 2 * EW);
    drv_v4l2_layout_info l;
    assert_true(drv_v4l2_layout_get(EW, EH, true, &l));
    assert_int_equal(l.band_rows % 2, 0);
    assert_true(l.band_rows / 2 * EW >= DRV_V4L2_META_BYTES * 8);          /* the band holds every bit */
    assert_true((l.band_rows / 2 - 1) * EW < DRV_V4L2_META_BYTES * 8);     /* and is no taller than needed */
    assert_int_equal(l.height, l.band_rows + 3 * EH);
    assert_int_equal(l.depth_y, l.band_rows + EH);
    assert_true(drv_v4l2_layout(960, 1080, false, &w, &h));
    assert_int_equal(w, 1920);
    assert_int_equal(h, 1080 + 6); /* 2080 bits / 960 per block row = 3 block rows */
    assert_false(drv_v4l2_layout(EW + 1, EH, false, &w, &h));
    assert_false(drv_v4l2_layout(32, EH, false, &w, &h));
    assert_false(drv_v4l2_layout(EW, EH - 1, false, &w, &h));
}

static void test_band_survives_formats(void **state)
{
    (void)state;
    drv_frame f, out;
    int w, h;
    pack_fixture(&f, &out, DRV_PLANE_COLOR, 1, &w, &h);
    for (int fi = 0; fi < NFORMATS; fi++) {
        drv_v4l2_geom g;
        /* a video mode larger than the layout: the layout sits top-left */
        uint8_t *img = image_new(&g, all_formats[fi], w + 16, h + 10, 64);
        drv_v4l2_colorspace cs = DRV_V4L2_CS_DEFAULT;
        assert_int_equal(drv_v4l2_pack(&f, false, &g, &cs, img), DRV_FRAME_OK);
        char why[160] = "";
        assert_int_equal(drv_v4l2_unpack(img, &g, &cs, &out, why, sizeof why), DRV_FRAME_OK);
        assert_meta_equal(&f, &out);
        assert_int_equal(out.planes, DRV_PLANE_COLOR);
        assert_int_equal(drv_frame_validate(&out), DRV_FRAME_OK);
        double p = psnr_eyes(&f, &out);
        if (all_formats[fi] == DRV_V4L2_YUYV || all_formats[fi] == DRV_V4L2_NV12)
            assert_true(p > 40);
        else
            assert_true(isinf(p));
        free(img);
    }
    drv_frame_free(&f);
    drv_frame_free(&out);
}

/* Board times outside [0, 2^62] and a non-finite scene time or position, sealed with a valid CRC by the encoder,
 * are refused by the decoder with a reason, the output frame untouched (issue #16: they reached the runtime). */
static void test_meta_values_checked(void **state)
{
    (void)state;
    drv_frame f, out;
    int w, h;
    pack_fixture(&f, &out, DRV_PLANE_COLOR, 3, &w, &h);
    drv_v4l2_geom g;
    uint8_t *img = image_new(&g, DRV_V4L2_YUYV, w, h, 0);
    drv_v4l2_colorspace cs = DRV_V4L2_CS_DEFAULT;
    const int64_t max = (int64_t)1 << 62;
    struct {
        int64_t pose_t, render_start;
        double scene_time, px;
        drv_frame_err want;
        const char *why;
    } cases[] = {
        {max, max, 1.0, 0, DRV_FRAME_OK, ""},
        {-1, 5, 1.0, 0, DRV_FRAME_ERR_BAD_FORMAT, "pose_t_ns -1"},
        {INT64_MIN, 5, 1.0, 0, DRV_FRAME_ERR_BAD_FORMAT, "outside [0, 2^62]"},
        {5, INT64_MAX, 1.0, 0, DRV_FRAME_ERR_BAD_FORMAT, "render_start_ns 9223372036854775807"},
        {5, 5, NAN, 0, DRV_FRAME_ERR_BAD_FORMAT, "scene_time"},
        {5, 5, 1.0, INFINITY, DRV_FRAME_ERR_BAD_POSE, "eye 0 pose"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        f.pose_t_ns = cases[i].pose_t, f.render_start_ns = cases[i].render_start;
        f.scene_time = cases[i].scene_time;
        warp_pose keep = f.eye_pose[0];
        f.eye_pose[0].p.x = cases[i].px;
        assert_int_equal(drv_v4l2_pack(&f, false, &g, &cs, img), DRV_FRAME_OK);
        f.eye_pose[0] = keep;
        out.seq = 0xDEAD;
        char why[160] = "";
        assert_int_equal(drv_v4l2_unpack(img, &g, &cs, &out, why, sizeof why), cases[i].want);
        assert_non_null(strstr(why, cases[i].why));
        if (cases[i].want) assert_int_equal(out.seq, 0xDEAD);
    }
    free(img);
    drv_frame_free(&f);
    drv_frame_free(&out);
}

/* Whole-image conversion, as a capture chain converting between RGB and YUV would do. */
static uint8_t *convert_image(const uint8_t *img, const drv_v4l2_geom *g, const drv_v4l2_colorspace *cs_in,
                              uint32_t fourcc, const drv_v4l2_colorspace *cs_out, drv_v4l2_geom *g2)
{
    warp_image_rgba8 tmp;
    assert_true(warp_image_rgba8_alloc(&tmp, g->width, g->height));
    drv_v4l2_to_rgba(img, g, cs_in, 0, 0, g->width, g->height, tmp.px, tmp.stride);
    uint8_t *o = image_new(g2, fourcc, g->width, g->height, 0);
    drv_v4l2_from_rgba(tmp.px, tmp.stride, g->width, g->height, cs_out, o, g2, 0, 0);
    warp_image_free(&tmp);
    return o;
}

static void test_band_survives_rgb_yuv_rgb(void **state)
{
    (void)state;
    drv_frame f, out;
    int w, h;
    pack_fixture(&f, &out, DRV_PLANE_COLOR, 2, &w, &h);
    drv_v4l2_colorspace lim601 = DRV_V4L2_CS_DEFAULT, full709 = {DRV_V4L2_BT709, true};
    drv_v4l2_geom g0, g1, g2;
    /* host writes BGR32, the link carries BT.709 full-range 4:2:0, the board captures RGB24 */
    uint8_t *a = image_new(&g0, DRV_V4L2_BGR32, w, h, 0);
    assert_int_equal(drv_v4l2_pack(&f, false, &g0, &lim601, a), DRV_FRAME_OK);
    uint8_t *b = convert_image(a, &g0, &lim601, DRV_V4L2_NV12, &full709, &g1);
    uint8_t *c = convert_image(b, &g1, &full709, DRV_V4L2_RGB24, &lim601, &g2);
    char why[160] = "";
    assert_int_equal(drv_v4l2_unpack(c, &g2, &lim601, &out, why, sizeof why), DRV_FRAME_OK);
    assert_meta_equal(&f, &out);
    assert_true(psnr_eyes(&f, &out) > 35);
    /* host writes YUYV (BT.601 limited), a bridge converts to limited-range RGB... read as RGB24 */
    free(a), free(b), free(c);
    a = image_new(&g0, DRV_V4L2_YUYV, w, h, 0);
    assert_int_equal(drv_v4l2_pack(&f, false, &g0, &lim601, a), DRV_FRAME_OK);
    b = convert_image(a, &g0, &lim601, DRV_V4L2_RGB24, &lim601, &g1);
    assert_int_equal(drv_v4l2_unpack(b, &g1, &lim601, &out, why, sizeof why), DRV_FRAME_OK);
    assert_meta_equal(&f, &out);
    /* ... and the band is also decoded from the YUYV the captured RGB would convert to with another matrix */
    c = convert_image(b, &g1, &lim601, DRV_V4L2_YUYV, &full709, &g2);
    assert_int_equal(drv_v4l2_unpack(c, &g2, &full709, &out, why, sizeof why), DRV_FRAME_OK);
    assert_meta_equal(&f, &out);
    free(a), free(b), free(c);
    drv_frame_free(&f);
    drv_frame_free(&out);
}

static void test_depth_packing(void **state)
{
    (void)state;
    drv_frame f, out;
    int w, h;
    pack_fixture(&f, &out, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, 3, &w, &h);
    for (int enc = 0; enc < 2; enc++)
        for (int fi = 0; fi < NFORMATS; fi++) {
            drv_frame *src = &f;
            if (enc == 1) {
                /* reversed-Z window depth d = near / z: arrives in the same encoding */
                f.depth_encoding = WARP_DEPTH_REVERSED;
                for (int e = 0; e < 2; e++)
                    for (int y = 0; y < EH; y++)
                        for (int x = 0; x < EW; x++) {
                            float *d = &WARP_AT(&f.depth[e], x, y);
                            if (*d > 1.0f || isinf(*d)) *d = (float)(isinf(*d) ? 0.0 : f.cam[e].near_z / *d);
                        }
            }
            drv_v4l2_geom g;
            uint8_t *img = image_new(&g, all_formats[fi], w, h, 0);
            drv_v4l2_colorspace cs = DRV_V4L2_CS_DEFAULT;
            assert_int_equal(drv_v4l2_pack(src, true, &g, &cs, img), DRV_FRAME_OK);
            assert_int_equal(drv_v4l2_unpack(img, &g, &cs, &out, NULL, 0), DRV_FRAME_OK);
            assert_int_equal(out.planes, DRV_PLANE_COLOR | DRV_PLANE_DEPTH);
            assert_int_equal(out.depth_encoding, f.depth_encoding);
            assert_meta_equal(&f, &out);
            for (int e = 0; e < 2; e++) {
                /* quantisation: inverse depth in steps of 1 / (65535 near), rounded */
                double step = 1.0 / (65535.0 * f.cam[e].near_z);
                for (int y = 0; y < EH; y++)
                    for (int x = 0; x < EW; x++) {
                        double a = warp_depth_to_inverse(&f.cam[e], f.depth_encoding, WARP_AT(&f.depth[e], x, y));
                        double b = warp_depth_to_inverse(&out.cam[e], out.depth_encoding, WARP_AT(&out.depth[e], x, y));
                        if (fabs(a - b) > 0.5 * step + 1e-6 * a)
                            fail_msg("fmt %d enc %d eye %d (%d,%d): 1/z %g -> %g", fi, enc, e, x, y, a, b);
                        if (a == 0) assert_true(b == 0);
                    }
            }
            free(img);
        }
    /* Frames without depth in a layout with depth rows: colour only. */
    drv_frame_free(&f);
    frame_random(&f, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, 4);
    f.planes = DRV_PLANE_COLOR;
    drv_v4l2_geom g;
    uint8_t *img = image_new(&g, DRV_V4L2_NV12, w, h, 0);
    drv_v4l2_colorspace cs = DRV_V4L2_CS_DEFAULT;
    assert_int_equal(drv_v4l2_pack(&f, true, &g, &cs, img), DRV_FRAME_OK);
    assert_int_equal(drv_v4l2_unpack(img, &g, &cs, &out, NULL, 0), DRV_FRAME_OK);
    assert_int_equal(out.planes, DRV_PLANE_COLOR);
    /* NaN and negative depth are the host's bug: refused. */
    f.planes = DRV_PLANE_COLOR | DRV_PLANE_DEPTH;
    f.depth_encoding = WARP_DEPTH_LINEAR;
    WARP_AT(&f.depth[1], 3, 3) = NAN;
    assert_int_equal(drv_v4l2_pack(&f, true, &g, &cs, img), DRV_FRAME_ERR_BAD_DEPTH);
    WARP_AT(&f.depth[1], 3, 3) = -1.0f;
    assert_int_equal(drv_v4l2_pack(&f, true, &g, &cs, img), DRV_FRAME_ERR_BAD_DEPTH);
    free(img);
    drv_frame_free(&f);
    drv_frame_free(&out);
}

static void flip_bit(uint8_t *img, const drv_v4l2_geom *g, int bit)
{
    int bx = bit % EW, by = bit / EW;
    uint8_t lv[2];
    drv_v4l2_read_luma(img, g, 2 * bx, 2 * by, 1, lv);
    lv[0] = lv[1] = lv[0] > 128 ? DRV_V4L2_LEVEL_BLACK : DRV_V4L2_LEVEL_WHITE;
    drv_v4l2_write_grey(img, g, 2 * bx, 2 * by, 2, lv);
    drv_v4l2_write_grey(img, g, 2 * bx, 2 * by + 1, 2, lv);
}

static void test_garbled_band(void **state)
{
    (void)state;
    drv_frame f, out;
    int w, h;
    pack_fixture(&f, &out, DRV_PLANE_COLOR, 5, &w, &h);
    drv_v4l2_colorspace cs = DRV_V4L2_CS_DEFAULT;
    drv_v4l2_geom g;
    uint8_t *img = image_new(&g, DRV_V4L2_YUYV, w, h, 0);
    uint8_t *copy = malloc(g.size);
    assert_int_equal(drv_v4l2_pack(&f, false, &g, &cs, img), DRV_FRAME_OK);
    memcpy(copy, img, g.size);
    char why[160];

    /* one payload bit anywhere -> CRC */
    int bits[] = {64 + 3, 8 * 100 + 5, DRV_V4L2_META_BYTES * 8 - 1};
    for (size_t i = 0; i < sizeof bits / sizeof bits[0]; i++) {
        memcpy(img, copy, g.size);
        flip_bit(img, &g, bits[i]);
        assert_int_equal(drv_v4l2_unpack(img, &g, &cs, &out, why, sizeof why), DRV_FRAME_ERR_CRC);
        assert_non_null(strstr(why, "CRC"));
    }
    /* magic bit -> BAD_MAGIC; blank or random pictures too */
    memcpy(img, copy, g.size);
    flip_bit(img, &g, 5);
    assert_int_equal(drv_v4l2_unpack(img, &g, &cs, &out, why, sizeof why), DRV_FRAME_ERR_BAD_MAGIC);
    memset(img, 0x10, g.size);
    assert_int_equal(drv_v4l2_unpack(img, &g, &cs, &out, NULL, 0), DRV_FRAME_ERR_BAD_MAGIC);
    test_rng r = test_rng_make(9);
    for (size_t i = 0; i < g.size; i++) img[i] = (uint8_t)test_rng_next(&r);
    assert_int_equal(drv_v4l2_unpack(img, &g, &cs, &out, NULL, 0), DRV_FRAME_ERR_BAD_MAGIC);
    /* a board configured for another eye height: BAD_SIZE naming both */
    memcpy(img, copy, g.size);
    drv_frame small;
    assert_true(drv_frame_alloc(&small, EW, EH - 2, DRV_PLANE_COLOR, 1));
    assert_int_equal(drv_v4l2_unpack(img, &g, &cs, &small, why, sizeof why), DRV_FRAME_ERR_BAD_SIZE);
    assert_non_null(strstr(why, "128x64"));
    drv_frame_free(&small);
    /* an image smaller than the layout, an unsupported fourcc */
    drv_v4l2_geom gs = g;
    gs.height = h - 2;
    assert_int_equal(drv_v4l2_unpack(img, &gs, &cs, &out, NULL, 0), DRV_FRAME_ERR_BAD_SIZE);
    assert_int_equal(drv_v4l2_pack(&f, false, &gs, &cs, img), DRV_FRAME_ERR_BAD_SIZE);
    drv_v4l2_geom gf = g;
    gf.fourcc = DRV_V4L2_FOURCC('M', 'J', 'P', 'G');
    assert_int_equal(drv_v4l2_unpack(img, &gf, &cs, &out, NULL, 0), DRV_FRAME_ERR_BAD_FORMAT);
    assert_int_equal(drv_v4l2_pack(&f, false, &gf, &cs, img), DRV_FRAME_ERR_BAD_FORMAT);
    /* a NaN pose sent by the host arrives intact, and is refused */
    f.eye_pose[1].p.y = NAN;
    assert_int_equal(drv_v4l2_pack(&f, false, &g, &cs, img), DRV_FRAME_OK);
    assert_int_equal(drv_v4l2_unpack(img, &g, &cs, &out, why, sizeof why), DRV_FRAME_ERR_BAD_POSE);
    f.eye_pose[1].p.y = 0;
    f.cam[0].near_z = -1;
    assert_int_equal(drv_v4l2_pack(&f, false, &g, &cs, img), DRV_FRAME_OK);
    assert_int_equal(drv_v4l2_unpack(img, &g, &cs, &out, why, sizeof why), DRV_FRAME_ERR_BAD_CAMERA);
    free(copy);
    free(img);
    drv_frame_free(&f);
    drv_frame_free(&out);
}

/* ---- the backend over the mock device ---- */

typedef struct { warp_head head; } pose_ctx;

static bool predict_fixed(void *ctx, int64_t t_ns, warp_pose *head)
{
    pose_ctx *p = ctx;
    (void)t_ns; /* a fixed head pose: the scene is static, so every frame is the same picture (PSNR deterministic) */
    *head = warp_head_pose_from_orientation(&p->head, warp_quat_from_ypr(0.3, 0.05, 0));
    return true;
}

static pose_ctx the_poses;

static drv_frames_sim_params host_params(void)
{
    drv_frames_sim_params sp;
    memset(&sp, 0, sizeof sp);
    sp.scene = sim_scene_find("near");
    assert_non_null(sp.scene);
    for (int e = 0; e < 2; e++) sp.cam[e] = warp_camera_symmetric(EW, EH, 90, 80, 0.05, INFINITY);
    the_poses.head = warp_head_default();
    sp.head = the_poses.head;
    sp.rate_hz = 200;
    sp.latency_ms = 0;
    sp.threads = 1;
    sp.t0_ns = plat_now_ns();
    sp.poses.predict = predict_fixed;
    sp.poses.ctx = &the_poses;
    sp.planes_wanted = DRV_PLANE_COLOR | DRV_PLANE_DEPTH;
    return sp;
}

static drv_frames_v4l2_params cap_params(const char *format, bool depth)
{
    drv_frames_v4l2_params p;
    memset(&p, 0, sizeof p);
    snprintf(p.format, sizeof p.format, "%s", format);
    p.eye_w = EW, p.eye_h = EH, p.depth = depth;
    return p;
}

/* Receives until a frame arrives (generous bound for a loaded machine); returns the last result. */
static int receive_one(drv_frames *fr, drv_frame *f)
{
    int rc = 0;
    for (int i = 0; i < 100 && rc == 0; i++) rc = drv_frames_receive(fr, f, 50);
    return rc;
}

static void check_against_render(const drv_frame *f, const sim_scene *scene, double min_psnr, bool depth)
{
    for (int e = 0; e < 2; e++) {
        sim_buffers b;
        assert_true(sim_buffers_alloc(&b, EW, EH, SIM_PLANE_COLOR | SIM_PLANE_DEPTH, 1));
        sim_render(scene, f->scene_time, f->eye_pose[e], &f->cam[e], SIM_PLANE_COLOR | SIM_PLANE_DEPTH, &b);
        double p = warp_psnr(&b.color, &f->color[e], NULL, 0);
        if (!(p > min_psnr)) fail_msg("eye %d: PSNR %.1f dB, want > %.1f", e, p, min_psnr);
        if (depth) {
            double step = 1.0 / (65535.0 * f->cam[e].near_z);
            for (int y = 0; y < EH; y++)
                for (int x = 0; x < EW; x++) {
                    double a = 1.0 / WARP_AT(&b.depth, x, y), c = 1.0 / WARP_AT(&f->depth[e], x, y);
                    if (fabs(a - c) > 0.5 * step + 1e-6) fail_msg("eye %d depth at (%d,%d): 1/z %g vs %g", e, x, y, a, c);
                }
        }
        sim_buffers_free(&b);
    }
}

/* The backend over the mock device, its host the simulator (host_params into *sp), and a frame allocated for the
 * planes the backend reports; mock_close frees both. */
static drv_frames *mock_open(drv_frames_sim_params *sp, const drv_frames_v4l2_params *p, drv_frame *f)
{
    *sp = host_params();
    char err[256] = "";
    drv_frames *fr = drv_frames_v4l2_create_mock(sp, p, err, sizeof err);
    if (!fr) fail_msg("%s", err);
    assert_true(drv_frame_alloc(f, EW, EH, drv_frames_planes(fr), 1));
    return fr;
}

static void mock_close(drv_frames *fr, drv_frame *f)
{
    drv_frame_free(f);
    drv_frames_destroy(fr);
}

static void test_mock_end_to_end_yuyv(void **state)
{
    (void)state;
    drv_frames_sim_params sp;
    drv_frames_v4l2_params p = cap_params("auto", false);
    drv_frame f;
    drv_frames *fr = mock_open(&sp, &p, &f);
    assert_int_equal(drv_frames_planes(fr), DRV_PLANE_COLOR);
    drv_frames_v4l2_stats st;
    drv_frames_v4l2_stats_get(fr, &st);
    assert_true(st.connected);
    assert_non_null(strstr(st.format, "YUYV")); /* auto prefers YUYV among RGB24, XBGR32, NV12, YUYV */
    uint64_t last_seq = 0;
    for (int i = 0; i < 3; i++) {
        int64_t before = plat_now_ns();
        assert_int_equal(receive_one(fr, &f), 1);
        assert_int_equal(drv_frame_validate(&f), DRV_FRAME_OK);
        assert_true(f.seq > last_seq);
        last_seq = f.seq;
        /* received_ns comes from the buffer's monotonic timestamp (microseconds): after the render began */
        assert_true(f.received_ns >= f.render_start_ns - 1000);
        assert_true(f.received_ns <= plat_now_ns());
        assert_true(f.received_ns >= before - 1000);
        check_against_render(&f, sp.scene, 35.0, false);
    }
    drv_frames_v4l2_stats_get(fr, &st);
    assert_int_equal(st.frames, 3);
    mock_close(fr, &f);
}

static void test_mock_formats_with_depth(void **state)
{
    (void)state;
    const char *fmts[] = {"nv12", "bgr32", "rgb24", "yuyv"};
    const char *want[] = {"NV12", "XR24", "RGB3", "YUYV"};
    for (int i = 0; i < 4; i++) {
        drv_frames_sim_params sp;
        drv_frames_v4l2_params p = cap_params(fmts[i], true);
        drv_frame f;
        drv_frames *fr = mock_open(&sp, &p, &f);
        drv_frames_v4l2_stats st;
        drv_frames_v4l2_stats_get(fr, &st);
        assert_non_null(strstr(st.format, want[i]));
        assert_int_equal(drv_frames_planes(fr), DRV_PLANE_COLOR | DRV_PLANE_DEPTH);
        assert_int_equal(receive_one(fr, &f), 1);
        assert_int_equal(drv_frame_validate(&f), DRV_FRAME_OK);
        assert_int_equal(f.planes, DRV_PLANE_COLOR | DRV_PLANE_DEPTH);
        check_against_render(&f, sp.scene, i == 0 ? 30.0 : i == 3 ? 35.0 : 99.0, true);
        mock_close(fr, &f);
    }
}

static void test_mock_faults_and_reconnect(void **state)
{
    (void)state;
    drv_frames_sim_params sp;
    drv_frames_v4l2_params p = cap_params("", false);
    snprintf(p.device, sizeof p.device, "/dev/video7");
    drv_frame f;
    drv_frames *fr = mock_open(&sp, &p, &f);
    drv_frames_v4l2_stats st;

    drv_frames_v4l2_mock_fault(fr, DRV_V4L2_FAULT_GARBLE);
    assert_int_equal(receive_one(fr, &f), -DRV_FRAME_ERR_CRC);
    drv_frames_v4l2_stats_get(fr, &st);
    assert_non_null(strstr(st.last_error, "/dev/video7"));
    assert_non_null(strstr(st.last_error, "CRC"));
    assert_int_equal(receive_one(fr, &f), 1); /* the next frame is fine */

    drv_frames_v4l2_mock_fault(fr, DRV_V4L2_FAULT_BLANK);
    assert_int_equal(receive_one(fr, &f), -DRV_FRAME_ERR_BAD_MAGIC);
    assert_int_equal(receive_one(fr, &f), 1);

    /* unplugged: the error, one failed reopen 500 ms later, then frames again after the next 500 ms */
    drv_frames_v4l2_mock_fault(fr, DRV_V4L2_FAULT_UNPLUG);
    int64_t t0 = plat_now_ns();
    assert_int_equal(receive_one(fr, &f), -DRV_FRAME_ERR_IO);
    drv_frames_v4l2_stats_get(fr, &st);
    assert_false(st.connected);
    assert_non_null(strstr(st.last_error, "/dev/video7"));
    assert_non_null(strstr(st.last_error, "VIDIOC_DQBUF"));
    assert_int_equal(receive_one(fr, &f), -DRV_FRAME_ERR_IO);
    int64_t t1 = plat_now_ns();
    assert_true(t1 - t0 >= 450 * PLAT_NS_PER_MS); /* a lower bound only: reopen is rate limited */
    drv_frames_v4l2_stats_get(fr, &st);
    assert_non_null(strstr(st.last_error, "cannot open"));
    assert_int_equal(receive_one(fr, &f), 1);
    assert_int_equal(drv_frame_validate(&f), DRV_FRAME_OK);
    drv_frames_v4l2_stats_get(fr, &st);
    assert_true(st.connected);
    assert_int_equal(st.reconnects, 1);
    assert_int_equal(st.io_errors, 2);
    assert_int_equal(st.rejected[DRV_FRAME_ERR_CRC], 1);
    assert_int_equal(st.rejected[DRV_FRAME_ERR_BAD_MAGIC], 1);
    mock_close(fr, &f);
}

/* [mock] corrupt_every: every third frame damaged, a garbled band and a blank picture in turn, each rejected by its
 * reason and counted; the frames between them arrive whole. */
static void test_mock_corrupt_every(void **state)
{
    (void)state;
    drv_frames_sim_params sp;
    drv_frames_v4l2_params p = cap_params("auto", false);
    drv_frame f;
    drv_frames *fr = mock_open(&sp, &p, &f);
    drv_frames_v4l2_mock_corrupt_every(fr, 3);
    for (int i = 1; i <= 12; i++) {
        int want = i % 3 ? 1 : (i / 3) % 2 ? -DRV_FRAME_ERR_CRC : -DRV_FRAME_ERR_BAD_MAGIC;
        int got = receive_one(fr, &f);
        if (got != want) fail_msg("frame %d: receive gave %d, want %d", i, got, want);
        if (got == 1) assert_int_equal(drv_frame_validate(&f), DRV_FRAME_OK);
    }
    drv_frames_v4l2_stats st;
    drv_frames_v4l2_stats_get(fr, &st);
    assert_int_equal(st.frames, 8);
    assert_int_equal(st.rejected[DRV_FRAME_ERR_CRC], 2);
    assert_int_equal(st.rejected[DRV_FRAME_ERR_BAD_MAGIC], 2);
    /* 0 turns it off */
    drv_frames_v4l2_mock_corrupt_every(fr, 0);
    for (int i = 0; i < 4; i++) assert_int_equal(receive_one(fr, &f), 1);
    mock_close(fr, &f);
}

static void test_missing_device_and_bad_params(void **state)
{
    (void)state;
    drv_frames_v4l2_params p = cap_params("auto", false);
    snprintf(p.device, sizeof p.device, "/dev/video-hmdwarp-missing");
    char err[256] = "";
    assert_null(drv_frames_v4l2_create(&p, err, sizeof err));
    assert_non_null(strstr(err, "/dev/video-hmdwarp-missing"));
    assert_non_null(strstr(err, "No such file"));
    err[0] = 0;
    assert_null(drv_v4l2_output_open("/dev/video-hmdwarp-missing", "yuyv", EW, EH, false, err, sizeof err));
    assert_non_null(strstr(err, "/dev/video-hmdwarp-missing"));
    /* not a V4L2 device at all */
    snprintf(p.device, sizeof p.device, "/dev/null");
    assert_null(drv_frames_v4l2_create(&p, err, sizeof err));
    assert_non_null(strstr(err, "/dev/null"));
    assert_non_null(strstr(err, "QUERYCAP"));
    /* bad format name and eye size */
    snprintf(p.format, sizeof p.format, "mjpeg");
    assert_null(drv_frames_v4l2_create(&p, err, sizeof err));
    assert_non_null(strstr(err, "mjpeg"));
    drv_frames_sim_params sp = host_params();
    drv_frames_v4l2_params q = cap_params("auto", false);
    q.eye_w = EW + 2;
    assert_null(drv_frames_v4l2_create_mock(&sp, &q, err, sizeof err));
    assert_non_null(strstr(err, "130x64"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fourcc_and_geometry),
        cmocka_unit_test(test_bars),
        cmocka_unit_test(test_meta_values_checked),
        cmocka_unit_test(test_round_trips),
        cmocka_unit_test(test_grey_levels),
        cmocka_unit_test(test_layout),
        cmocka_unit_test(test_band_survives_formats),
        cmocka_unit_test(test_band_survives_rgb_yuv_rgb),
        cmocka_unit_test(test_depth_packing),
        cmocka_unit_test(test_garbled_band),
        cmocka_unit_test(test_mock_end_to_end_yuyv),
        cmocka_unit_test(test_mock_formats_with_depth),
        cmocka_unit_test(test_mock_faults_and_reconnect),
        cmocka_unit_test(test_mock_corrupt_every),
        cmocka_unit_test(test_missing_device_and_bad_params),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
