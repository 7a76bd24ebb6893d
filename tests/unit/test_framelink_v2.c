/* SPDX-License-Identifier: MIT */
/* Unit tests for framelink v2 (drv_framelink_codec, drv_codec_depth): round trips per codec and format, depth
 * quantisation and the edge-preserving upsample, every damage a compressed frame can carry, v1 still readable. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>
#include <zstd.h>
#include <cmocka.h>

#include "drivers/drv_codec_depth.h"
#include "drivers/drv_codec_video.h"
#include "drivers/drv_framelink_codec.h"
#include "tests/support/test_util.h"

#define W 21
#define H 13
#define MAX_LAYERS 3
#define ALL 0x1Fu
#define CAP (4u << 20)
#define DESC(i) (312 + 16 * (i)) /* descriptor i of a frame without objects */

static uint32_t get32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}
static void put32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++) p[i] = (uint8_t)(v >> (8 * i));
}
/* Both CRCs rewritten, so a mutation reaches the check behind them. */
static void repair(uint8_t *b)
{
    size_t hdr = (size_t)b[6] | (size_t)b[7] << 8, total = get32(b + 8);
    put32(b + hdr - 4, (uint32_t)crc32_z(0, b, hdr - 4));
    put32(b + total - 4, (uint32_t)crc32_z(0, b + hdr, total - hdr - 4));
}
static size_t hdr_of(const uint8_t *b) { return (size_t)b[6] | (size_t)b[7] << 8; }

/* Random content in every plane asked for; linear depth in metres with some sky. */
static void make_frame(drv_frame *f, int w, int h, unsigned planes, warp_depth_encoding enc, uint64_t seed)
{
    test_rng r = test_rng_make(seed);
    assert_true(drv_frame_alloc(f, w, h, planes, MAX_LAYERS));
    f->planes = planes;
    f->seq = 500 + seed;
    f->pose_t_ns = 1000000000LL + (int64_t)seed;
    f->depth_encoding = enc;
    for (int e = 0; e < 2; e++) {
        f->cam[e] = warp_camera_symmetric(w, h, 90, 80, 0.05, 100.0);
        f->eye_pose[e] = (warp_pose){{1, 0, 0, 0}, {e ? 0.032 : -0.032, 1.6, 0}};
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                uint64_t v = test_rng_next(&r);
                if (planes & DRV_PLANE_COLOR)
                    WARP_AT(&f->color[e], x, y) = (warp_rgba8){(uint8_t)v, (uint8_t)(v >> 8), (uint8_t)(v >> 16), 255};
                if (planes & DRV_PLANE_DEPTH)
                    WARP_AT(&f->depth[e], x, y) = enc == WARP_DEPTH_LINEAR
                                                      ? ((x + y) % 7 ? (float)test_rng_uniform(&r, 0.05, 80) : INFINITY)
                                                      : (float)test_rng_uniform(&r, 0, 1);
                if (planes & DRV_PLANE_IDS) WARP_AT(&f->ids[e], x, y) = (uint16_t)(v >> 40) % 5;
                if (planes & DRV_PLANE_MOTION)
                    WARP_AT(&f->motion[e], x, y) = (warp_vec2f){(float)x * 3.5f, -(float)(v >> 50)};
                if (planes & DRV_PLANE_LAYERS) {
                    warp_image_layers *l = &f->layers[e];
                    size_t i = (size_t)y * (size_t)w + (size_t)x;
                    l->count[i] = (uint8_t)((x + y + e) % (MAX_LAYERS + 1));
                    for (int k = 0; k < l->count[i]; k++)
                        l->frag[i * MAX_LAYERS + (size_t)k] =
                            (warp_fragment){.z = 1.0f + (float)k, .rgba = {(uint8_t)v, 1, 2, 128}, .id = (uint16_t)k};
                }
            }
    }
}

/* Encodes f with p into buf (asserting success); returns the length. */
static size_t encode(const drv_framelink_enc_params *p, const drv_frame *f, uint8_t *buf)
{
    char err[200] = "";
    drv_framelink_enc *e = drv_framelink_enc_create(p, f->cam[0].width, f->cam[0].height, err, sizeof err);
    if (!e) fail_msg("enc_create: %s", err);
    size_t bound = drv_framelink_enc_bound(e, f);
    assert_true(bound > 0);
    size_t n = drv_framelink_enc_encode(e, f, NULL, false, buf, CAP, err, sizeof err);
    if (!n) fail_msg("encode: %s", err);
    assert_true(n <= bound);
    drv_framelink_enc_destroy(e);
    return n;
}

static drv_framelink_dec *make_dec(int w, int h, int threads)
{
    char err[200] = "";
    drv_framelink_dec *d = drv_framelink_dec_create(w, h, ALL, MAX_LAYERS, threads, "", err, sizeof err);
    if (!d) fail_msg("dec_create: %s", err);
    return d;
}

static void assert_planes_equal(const drv_frame *a, const drv_frame *b, unsigned planes)
{
    for (int e = 0; e < 2; e++) {
        int w = a->cam[e].width, h = a->cam[e].height;
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                if (planes & DRV_PLANE_COLOR)
                    assert_memory_equal(&WARP_AT(&a->color[e], x, y), &WARP_AT(&b->color[e], x, y), 4);
                if (planes & DRV_PLANE_DEPTH)
                    assert_memory_equal(&WARP_AT(&a->depth[e], x, y), &WARP_AT(&b->depth[e], x, y), 4);
                if (planes & DRV_PLANE_IDS) assert_int_equal(WARP_AT(&a->ids[e], x, y), WARP_AT(&b->ids[e], x, y));
                if (planes & DRV_PLANE_MOTION)
                    assert_memory_equal(&WARP_AT(&a->motion[e], x, y), &WARP_AT(&b->motion[e], x, y), 8);
            }
        if (planes & DRV_PLANE_LAYERS)
            for (size_t i = 0; i < (size_t)w * (size_t)h; i++) {
                assert_int_equal(a->layers[e].count[i], b->layers[e].count[i]);
                for (int k = 0; k < a->layers[e].count[i]; k++) {
                    const warp_fragment *fa = &a->layers[e].frag[i * MAX_LAYERS + (size_t)k];
                    const warp_fragment *fb = &b->layers[e].frag[i * MAX_LAYERS + (size_t)k];
                    assert_true(fa->z == fb->z && fa->id == fb->id && !memcmp(&fa->rgba, &fb->rgba, 4));
                }
            }
    }
}

static drv_framelink_enc_params zstd_params(void)
{
    drv_framelink_enc_params p = drv_framelink_enc_params_raw();
    p.depth = DRV_CODEC_ZSTD, p.other = DRV_CODEC_ZSTD, p.zstd_level = 3;
    return p;
}

/* zstd is lossless: ids, motion, layers and F32 depth come back bit for bit, on one thread or three. */
static void test_zstd_lossless(void **state)
{
    (void)state;
    uint8_t *buf = malloc(CAP);
    for (int enc = 0; enc < 3; enc++)
        for (int threads = 1; threads <= 3; threads += 2) {
            drv_frame f, g;
            make_frame(&f, W, H, ALL, (warp_depth_encoding)enc, 7 + (uint64_t)enc);
            drv_framelink_enc_params p = zstd_params();
            size_t n = encode(&p, &f, buf);
            assert_int_equal(buf[4], 2); /* version 2 */
            assert_true(drv_frame_alloc(&g, W, H, ALL, MAX_LAYERS));
            drv_framelink_dec *d = make_dec(W, H, threads);
            char detail[200];
            drv_framelink_rx rx;
            assert_int_equal(drv_framelink_dec_decode(d, buf, n, 0, &g, &rx, detail, sizeof detail), DRV_FRAME_OK);
            assert_string_equal(detail, "");
            assert_int_equal(rx.total_bytes, n);
            assert_int_equal(g.seq, f.seq);
            assert_int_equal(g.planes, ALL);
            assert_planes_equal(&f, &g, ALL);
            assert_int_equal(drv_frame_validate(&g), DRV_FRAME_OK);
            drv_framelink_dec_stats st;
            drv_framelink_dec_stats_get(d, &st);
            assert_int_equal(st.frames, 1);
            assert_int_equal(st.compressed_frames, 1);
            assert_int_equal(st.codec_errors, 0);
            assert_int_equal(st.wire_bytes, n);
            assert_true(st.codecs_seen & DRV_CODEC_BIT(DRV_CODEC_ZSTD));
            assert_true(st.decode_ms_last >= 0);
            /* Without a decoder object a compressed frame is refused by name, the frame left alone. */
            g.seq = 1;
            assert_int_equal(drv_framelink_decode_ex(buf, n, 0, &g, NULL, detail, sizeof detail),
                             DRV_FRAME_ERR_BAD_FORMAT);
            assert_non_null(strstr(detail, "drv_framelink_dec"));
            assert_int_equal(g.seq, 1);
            drv_framelink_dec_destroy(d);
            drv_frame_free(&f);
            drv_frame_free(&g);
        }
    free(buf);
}

/* All raw: the encoder sends version 1, the very bytes of drv_framelink_encode_ex (F32 and UNORM16 depth). */
static void test_all_raw_is_v1(void **state)
{
    (void)state;
    uint8_t *a = malloc(CAP), *b = malloc(CAP);
    for (int unorm = 0; unorm < 2; unorm++) {
        drv_frame f;
        make_frame(&f, W, H, ALL, unorm ? WARP_DEPTH_REVERSED : WARP_DEPTH_LINEAR, 3);
        drv_framelink_enc_params p = drv_framelink_enc_params_raw();
        p.depth_format = unorm ? DRV_FRAMELINK_FMT_UNORM16 : 0;
        size_t n = encode(&p, &f, a);
        drv_framelink_tx tx = {.depth_format = p.depth_format};
        size_t m = drv_framelink_encode_ex(&f, &tx, b, CAP);
        assert_int_equal(n, m);
        assert_memory_equal(a, b, n);
        assert_int_equal(a[4], 1);
        /* and a v2 decoder reads version 1 */
        drv_frame g;
        assert_true(drv_frame_alloc(&g, W, H, ALL, MAX_LAYERS));
        drv_framelink_dec *d = make_dec(W, H, 2);
        assert_int_equal(drv_framelink_dec_decode(d, a, n, 0, &g, NULL, NULL, 0), DRV_FRAME_OK);
        if (!unorm) assert_planes_equal(&f, &g, ALL);
        drv_framelink_dec_stats st;
        drv_framelink_dec_stats_get(d, &st);
        assert_int_equal(st.compressed_frames, 0);
        assert_int_equal(st.codecs_seen, DRV_CODEC_BIT(DRV_CODEC_RAW));
        drv_framelink_dec_destroy(d);
        drv_frame_free(&g);
        drv_frame_free(&f);
    }
    free(a);
    free(b);
}

/* INV16: relative error at most z / (2 * 65535 * near) plus float rounding; sky stays sky; raw or zstd. */
static void test_inv16(void **state)
{
    (void)state;
    uint8_t *buf = malloc(CAP);
    for (int codec = 0; codec < 2; codec++) {
        drv_frame f, g;
        make_frame(&f, W, H, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, WARP_DEPTH_LINEAR, 11);
        drv_framelink_enc_params p = drv_framelink_enc_params_raw();
        p.depth_format = DRV_FRAMELINK_FMT_INV16, p.depth = codec ? DRV_CODEC_ZSTD : DRV_CODEC_RAW;
        size_t n = encode(&p, &f, buf);
        assert_int_equal(buf[4], 2);
        assert_int_equal(buf[DESC(1) + 1], DRV_FRAMELINK_FMT_INV16);
        assert_true(drv_frame_alloc(&g, W, H, ALL, MAX_LAYERS));
        drv_framelink_dec *d = make_dec(W, H, 2);
        /* raw INV16 is an all-raw v2 frame: drv_framelink_decode_ex reads it too */
        if (codec == 0) assert_int_equal(drv_framelink_decode_ex(buf, n, 0, &g, NULL, NULL, 0), DRV_FRAME_OK);
        assert_int_equal(drv_framelink_dec_decode(d, buf, n, 0, &g, NULL, NULL, 0), DRV_FRAME_OK);
        for (int e = 0; e < 2; e++)
            for (int y = 0; y < H; y++)
                for (int x = 0; x < W; x++) {
                    float z = WARP_AT(&f.depth[e], x, y), got = WARP_AT(&g.depth[e], x, y);
                    if (isinf(z)) {
                        assert_true(isinf(got));
                        continue;
                    }
                    double bound = z / (2.0 * 65535.0 * 0.05) + 1e-6;
                    assert_true(fabs(got - z) / z <= bound);
                }
        drv_framelink_dec_destroy(d);
        drv_frame_free(&f);
        drv_frame_free(&g);
    }
    /* the quantiser's ends */
    assert_int_equal(drv_depth_to_inv16(INFINITY, 0.1), 0);
    assert_int_equal(drv_depth_to_inv16(NAN, 0.1), 0);
    assert_int_equal(drv_depth_to_inv16(0.01f, 0.1), 65535);
    assert_int_equal(drv_depth_to_inv16(1e9f, 0.1), 1);
    assert_true(isinf(drv_depth_from_inv16(0, 0.1)));
    free(buf);
}

/* The quantiser rounds as lround (half away from zero) clamped to 1..65535, for any depth and near plane: the
 * inline one skips libm's call, and this holds it to the formula (exact halves included). */
static uint16_t inv16_by_lround(float z, double near_z)
{
    if (!(z < INFINITY)) return 0;
    if (z <= near_z) return 65535;
    long v = lround(65535.0 * near_z / z);
    return (uint16_t)(v < 1 ? 1 : v > 65535 ? 65535 : v);
}
static void test_inv16_rounding(void **state)
{
    (void)state;
    static const double nears[] = {0.05, 0.1, 0.3, 1.0, 1e-3, -0.5, 0.0, 1e30};
    long checked = 0;
    for (size_t k = 0; k < sizeof nears / sizeof nears[0]; k++) {
        const double nz = nears[k];
        /* a geometric sweep over 10 decades, and every code's exact half-way depth and its float neighbours */
        for (double z = 1e-4; z < 1e6; z *= 1.0001, checked++)
            assert_int_equal(drv_depth_to_inv16((float)z, nz), inv16_by_lround((float)z, nz));
        for (int c = 1; c < 65535 && nz > 0 && nz < 1e3; c++) {
            const float half = (float)(65535.0 * nz / (c + 0.5));
            const float zs[3] = {nextafterf(half, 0), half, nextafterf(half, INFINITY)};
            for (int i = 0; i < 3; i++, checked++)
                assert_int_equal(drv_depth_to_inv16(zs[i], nz), inv16_by_lround(zs[i], nz));
        }
    }
    /* (a near plane at or below 0, which cameras refuse, can make the quotient infinite, where lround's result is
     * the platform's: not compared) */
    const float odd[] = {NAN, INFINITY, -INFINITY, 0.0f, -0.0f, -1.0f, 1e-45f, 3.4e38f};
    for (size_t i = 0; i < sizeof odd / sizeof odd[0]; i++)
        for (size_t k = 0; k < sizeof nears / sizeof nears[0]; k++)
            if (nears[k] > 0)
            assert_int_equal(drv_depth_to_inv16(odd[i], nears[k]), inv16_by_lround(odd[i], nears[k]));
    assert_true(checked > 1000000);
}

/* The decoder's INV16 look-up (zstd, per eye and near plane) gives exactly drv_depth_from_inv16 of each code, at
 * full and reduced resolution, and follows a near plane that changes between frames. */
static void test_inv16_decoded_exactly(void **state)
{
    (void)state;
    uint8_t *buf = malloc(CAP);
    drv_frame f, g;
    make_frame(&f, W, H, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, WARP_DEPTH_LINEAR, 13);
    assert_true(drv_frame_alloc(&g, W, H, ALL, MAX_LAYERS));
    drv_framelink_dec *d = make_dec(W, H, 2);
    static const double nears[3] = {0.05, 0.2, 0.05};
    for (int fr = 0; fr < 3; fr++)
        for (int codec = 0; codec < 2; codec++) {
            for (int e = 0; e < 2; e++) f.cam[e].near_z = nears[fr] * (1 + e);
            drv_framelink_enc_params p = drv_framelink_enc_params_raw();
            p.depth_format = DRV_FRAMELINK_FMT_INV16, p.depth = codec ? DRV_CODEC_ZSTD : DRV_CODEC_RAW;
            size_t n = encode(&p, &f, buf);
            char detail[200];
            assert_int_equal(drv_framelink_dec_decode(d, buf, n, 0, &g, NULL, detail, sizeof detail), DRV_FRAME_OK);
            for (int e = 0; e < 2; e++)
                for (int y = 0; y < H; y++)
                    for (int x = 0; x < W; x++) {
                        const float want = drv_depth_from_inv16(
                            drv_depth_to_inv16(WARP_AT(&f.depth[e], x, y), f.cam[e].near_z), f.cam[e].near_z);
                        const float got = WARP_AT(&g.depth[e], x, y);
                        if (!(got == want || (isinf(got) && isinf(want))))
                            fail_msg("frame %d %s eye %d (%d,%d): %.9g, want %.9g", fr, codec ? "zstd" : "raw", e,
                                     x, y, got, want);
                    }
            /* at 1/2 resolution the samples the upsample starts from are the codes' values too: on a flat frame
             * each pixel is that value through inverse depth and back, as the upsample interpolates */
            p.depth_scale = 1;
            for (int e = 0; e < 2; e++)
                for (int y = 0; y < H; y++)
                    for (int x = 0; x < W; x++) WARP_AT(&f.depth[e], x, y) = 3.25f;
            n = encode(&p, &f, buf);
            assert_int_equal(drv_framelink_dec_decode(d, buf, n, 0, &g, NULL, detail, sizeof detail), DRV_FRAME_OK);
            for (int e = 0; e < 2; e++) {
                const float code = drv_depth_from_inv16(drv_depth_to_inv16(3.25f, f.cam[e].near_z), f.cam[e].near_z);
                const float want = (float)(1.0 / (double)(float)(1.0 / (double)code));
                for (int y = 0; y < H; y++)
                    for (int x = 0; x < W; x++) assert_true(WARP_AT(&g.depth[e], x, y) == want);
            }
            drv_frame_free(&f);
            make_frame(&f, W, H, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, WARP_DEPTH_LINEAR, 13 + fr);
        }
    drv_framelink_dec_destroy(d);
    drv_frame_free(&f);
    drv_frame_free(&g);
    free(buf);
}

/* A foreground surface (red, about 2 m, sloping) left of x = EDGE_X and a background wall (blue, 10 m) right of it,
 * sent at 1/2 and 1/4 resolution: every pixel gets one surface's depth (never one in between), its own surface's
 * by colour, and away from the edge the sloping surface is interpolated closely. */
#define UW 67
#define UH 45
#define EDGE_X 29
static float scene_z(int x, int y) { return x < EDGE_X ? 2.0f + 0.01f * (float)y + 0.004f * (float)x : 10.0f; }
static void test_upsample_edges(void **state)
{
    (void)state;
    uint8_t *buf = malloc(CAP);
    for (int scale = 1; scale <= 2; scale++)
        for (int codec = 0; codec < 2; codec++) {
            drv_frame f, g;
            make_frame(&f, UW, UH, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, WARP_DEPTH_LINEAR, 5);
            for (int e = 0; e < 2; e++)
                for (int y = 0; y < UH; y++)
                    for (int x = 0; x < UW; x++) {
                        WARP_AT(&f.depth[e], x, y) = scene_z(x, y);
                        WARP_AT(&f.color[e], x, y) = x < EDGE_X ? (warp_rgba8){200, 40, 30, 255}
                                                                : (warp_rgba8){20, 50, 220, 255};
                    }
            drv_framelink_enc_params p = drv_framelink_enc_params_raw();
            p.depth_format = DRV_FRAMELINK_FMT_INV16, p.depth_scale = scale;
            p.depth = codec ? DRV_CODEC_ZSTD : DRV_CODEC_RAW;
            size_t n = encode(&p, &f, buf);
            assert_int_equal(buf[DESC(1) + 14], scale);
            assert_true(drv_frame_alloc(&g, UW, UH, ALL, MAX_LAYERS));
            drv_framelink_dec *d = make_dec(UW, UH, 2);
            char detail[200];
            assert_int_equal(drv_framelink_dec_decode(d, buf, n, 0, &g, NULL, detail, sizeof detail), DRV_FRAME_OK);
            int wrong = 0, b = 1 << scale;
            double worst = 0;
            for (int e = 0; e < 2; e++)
                for (int y = 0; y < UH; y++)
                    for (int x = 0; x < UW; x++) {
                        float z = WARP_AT(&g.depth[e], x, y);
                        bool fg = z < 3.0f, bg = fabsf(z - 10.0f) < 0.01f;
                        if (!((fg && z > 1.99f) || bg))
                            fail_msg("scale %d (%d,%d): depth %g between surfaces", scale, x, y, z);
                        if (abs(x - EDGE_X) >= 2 * b) {
                            double rel = fabs(z - scene_z(x, y)) / scene_z(x, y);
                            if (rel > worst) worst = rel;
                        }
                        if (fg != (x < EDGE_X)) wrong++;
                    }
            /* smooth away from the edge: within the slope over a block (0.6 % a pixel here) and the quantisation */
            assert_true(worst < 0.01 * b);
            /* the colour guide puts every edge pixel on its own surface here (sharp colours, one edge) */
            printf("# scale %d %s: worst relative error %.4f away from the edge, %d pixels on the other surface\n",
                   scale, codec ? "zstd" : "raw", worst, wrong);
            assert_int_equal(wrong, 0);
            drv_framelink_dec_destroy(d);
            drv_frame_free(&f);
            drv_frame_free(&g);
        }
    free(buf);
}

/* The downsample keeps each block's nearest depth in every encoding (a thin object survives). */
static void test_downsample_nearest(void **state)
{
    (void)state;
    float src[4 * 4], lo[4];
    for (int enc = 0; enc < 3; enc++) {
        for (int i = 0; i < 16; i++) src[i] = enc == WARP_DEPTH_REVERSED ? 0.1f : 0.9f;
        float near = enc == WARP_DEPTH_REVERSED ? 0.7f : 0.3f;
        src[1 * 4 + 3] = near; /* one pixel of block (1, 0) */
        src[3 * 4 + 0] = NAN;  /* NaN is never nearest */
        drv_depth_downsample(src, 4, 4, 4, 1, (warp_depth_encoding)enc, lo);
        assert_true(lo[1] == near);
        assert_true(lo[0] == src[0] && lo[2] == src[0] && lo[3] == src[0]);
    }
}

/* Build a frame with colour raw, depth and ids zstd (ids the last plane, so its chunks can be replaced). */
static size_t damage_frame(uint8_t *buf, drv_frame *f)
{
    make_frame(f, W, H, DRV_PLANE_COLOR | DRV_PLANE_DEPTH | DRV_PLANE_IDS, WARP_DEPTH_LINEAR, 21);
    drv_framelink_enc_params p = zstd_params();
    return encode(&p, f, buf);
}

/* Replaces the ids plane's (descriptor 2, last) eye-0 chunk by c[len], fixing sizes and CRCs. */
static size_t replace_ids_chunk(uint8_t *buf, size_t n, const uint8_t *c, size_t len)
{
    size_t hdr = hdr_of(buf), off = get32(buf + DESC(2) + 4), size = get32(buf + DESC(2) + 8);
    uint8_t *pl = buf + hdr + off;
    size_t old0 = get32(pl), old1 = get32(pl + 4);
    uint8_t *eye1 = malloc(old1);
    memcpy(eye1, pl + 8 + old0, old1);
    put32(pl, (uint32_t)len);
    memcpy(pl + 8, c, len);
    memcpy(pl + 8 + len, eye1, old1);
    free(eye1);
    size_t nsize = 8 + len + old1, total = n - size + nsize;
    put32(buf + DESC(2) + 8, (uint32_t)nsize);
    put32(buf + 8, (uint32_t)total);
    repair(buf);
    return total;
}

static drv_frame_err try_decode(drv_framelink_dec *d, const uint8_t *b, size_t n, drv_frame *g, char *detail)
{
    g->seq = 42;
    drv_frame_err e = drv_framelink_dec_decode(d, b, n, 0, g, NULL, detail, 200);
    if (e) assert_int_equal(g->seq, 42); /* header fields untouched */
    return e;
}

static void test_damage(void **state)
{
    (void)state;
    uint8_t *buf = malloc(CAP), *b = malloc(CAP);
    drv_frame f, g;
    size_t n = damage_frame(buf, &f);
    assert_true(drv_frame_alloc(&g, W, H, ALL, MAX_LAYERS));
    drv_framelink_dec *d = make_dec(W, H, 2);
    char detail[200];
    size_t hdr = hdr_of(buf), ids = hdr + get32(buf + DESC(2) + 4);
    assert_int_equal(buf[DESC(2) + 12], DRV_CODEC_ZSTD);
    assert_int_equal(try_decode(d, buf, n, &g, detail), DRV_FRAME_OK);
#define RESET() memcpy(b, buf, n)
#define EXPECT(err, text)                                                                                          \
    do {                                                                                                            \
        repair(b);                                                                                                  \
        assert_int_equal(try_decode(d, b, n, &g, detail), err);                                                    \
        if (!strstr(detail, text)) fail_msg("detail '%s' lacks '%s'", detail, text);                               \
    } while (0)

    /* descriptor bytes */
    RESET(), b[DESC(1) + 12] = 9;
    EXPECT(DRV_FRAME_ERR_BAD_FORMAT, "unknown codec");
    RESET(), b[DESC(1) + 12] = DRV_CODEC_JPEG;
    EXPECT(DRV_FRAME_ERR_BAD_FORMAT, "not allowed");
    RESET(), b[DESC(0) + 12] = DRV_CODEC_ZSTD;
    EXPECT(DRV_FRAME_ERR_BAD_FORMAT, "not allowed");
    RESET(), b[DESC(1) + 14] = 3;
    EXPECT(DRV_FRAME_ERR_BAD_FORMAT, "scale 3");
    RESET(), b[DESC(2) + 14] = 1;
    EXPECT(DRV_FRAME_ERR_BAD_FORMAT, "depth only");
    RESET(), b[DESC(1) + 15] = 0;
    EXPECT(DRV_FRAME_ERR_BAD_FORMAT, "0 slices");
    RESET(), b[DESC(1) + 15] = 17;
    EXPECT(DRV_FRAME_ERR_BAD_FORMAT, "17 slices");
    RESET(), b[DESC(1) + 13] = 1; /* KEY on a zstd plane */
    EXPECT(DRV_FRAME_ERR_BAD_FORMAT, "flags");
    RESET(), b[DESC(2) + 2] = 1; /* param on ids */
    EXPECT(DRV_FRAME_ERR_BAD_FORMAT, "parameter");
    RESET(), b[DESC(1) + 1] = DRV_FRAMELINK_FMT_UNORM16; /* linear depth as unorm16 */
    EXPECT(DRV_FRAME_ERR_BAD_FORMAT, "unorm16");

    /* plane and chunk sizes */
    RESET(), put32(b + DESC(2) + 8, 4); /* less than its chunk table */
    EXPECT(DRV_FRAME_ERR_BAD_SIZE, "outside");
    RESET(), put32(b + DESC(2) + 8, 1u << 30);
    EXPECT(DRV_FRAME_ERR_BAD_SIZE, "outside");
    size_t bound = ZSTD_COMPRESSBOUND((size_t)W * H * 2) + 64;
    RESET(), put32(b + ids, (uint32_t)bound + 1);
    EXPECT(DRV_FRAME_ERR_BAD_SIZE, "bound");
    RESET(), put32(b + ids, 0);
    EXPECT(DRV_FRAME_ERR_BAD_SIZE, "bound");
    RESET(), put32(b + ids, get32(b + ids) - 1); /* sum one short */
    EXPECT(DRV_FRAME_ERR_BAD_SIZE, "add up");
    RESET(), put32(b + ids, get32(b + ids) + 1); /* sum one over */
    EXPECT(DRV_FRAME_ERR_BAD_SIZE, "add up");

    /* zstd frames: corrupt, not zstd, declaring more than the plane, truncated, without content size */
    drv_framelink_dec_stats st0, st1;
    drv_framelink_dec_stats_get(d, &st0);
    RESET(), b[ids + 8 + get32(b + ids) / 2] ^= 0x5a;
    EXPECT(DRV_FRAME_ERR_BAD_FORMAT, "zstd");
    RESET(), b[ids + 8] ^= 0xff;
    EXPECT(DRV_FRAME_ERR_BAD_FORMAT, "not a zstd frame");
    drv_framelink_dec_stats_get(d, &st1);
    assert_int_equal(st1.codec_errors, st0.codec_errors + 2);
    {
        size_t big = (size_t)W * H * 2 + 2;
        uint8_t *raw = calloc(1, big), *z = malloc(ZSTD_compressBound(big));
        size_t zn = ZSTD_compress(z, ZSTD_compressBound(big), raw, big, 1);
        memcpy(b, buf, n);
        size_t m = replace_ids_chunk(b, n, z, zn);
        assert_int_equal(try_decode(d, b, m, &g, detail), DRV_FRAME_ERR_BAD_SIZE);
        assert_non_null(strstr(detail, "declares"));
        /* the right size but cut short */
        zn = ZSTD_compress(z, ZSTD_compressBound(big), raw, big - 2, 1);
        memcpy(b, buf, n);
        m = replace_ids_chunk(b, n, z, zn - 3);
        assert_int_equal(try_decode(d, b, m, &g, detail), DRV_FRAME_ERR_BAD_FORMAT);
        assert_non_null(strstr(detail, "zstd"));
        /* a streamed frame: no content size */
        ZSTD_CCtx *cc = ZSTD_createCCtx();
        ZSTD_CCtx_setParameter(cc, ZSTD_c_contentSizeFlag, 0);
        ZSTD_outBuffer ob = {z, ZSTD_compressBound(big), 0};
        ZSTD_inBuffer ib = {raw, big - 2, 0};
        assert_false(ZSTD_isError(ZSTD_compressStream2(cc, &ob, &ib, ZSTD_e_end)));
        ZSTD_freeCCtx(cc);
        memcpy(b, buf, n);
        m = replace_ids_chunk(b, n, z, ob.pos);
        assert_int_equal(try_decode(d, b, m, &g, detail), DRV_FRAME_ERR_BAD_FORMAT);
        assert_non_null(strstr(detail, "content size"));
        free(raw);
        free(z);
    }
    /* truncated anywhere: never OK, never a crash */
    for (size_t cut = 0; cut < n; cut += 7) assert_int_not_equal(try_decode(d, buf, cut, &g, detail), DRV_FRAME_OK);
    /* a good frame still decodes after all that */
    assert_int_equal(try_decode(d, buf, n, &g, detail), DRV_FRAME_OK);
    drv_framelink_dec_destroy(d);

    /* version 1: codec bytes and INV16 are refused */
    drv_framelink_tx tx = {0};
    size_t v1 = drv_framelink_encode_ex(&f, &tx, b, CAP);
    assert_int_equal(b[4], 1);
    b[DESC(1) + 12] = DRV_CODEC_ZSTD;
    repair(b);
    assert_int_equal(drv_framelink_decode_ex(b, v1, 0, &g, NULL, detail, sizeof detail), DRV_FRAME_ERR_BAD_FORMAT);
    b[DESC(1) + 12] = 0, b[DESC(1) + 1] = DRV_FRAMELINK_FMT_INV16;
    repair(b);
    assert_int_equal(drv_framelink_decode_ex(b, v1, 0, &g, NULL, detail, sizeof detail), DRV_FRAME_ERR_BAD_FORMAT);
    b[DESC(1) + 1] = DRV_FRAMELINK_FMT_F32, b[4] = 3;
    repair(b);
    assert_int_equal(drv_framelink_decode_ex(b, v1, 0, &g, NULL, detail, sizeof detail), DRV_FRAME_ERR_BAD_VERSION);
    drv_frame_free(&f);
    drv_frame_free(&g);
    free(buf);
    free(b);
}

/* Encoder parameters are checked by name. */
static void test_params(void **state)
{
    (void)state;
    char err[200];
    drv_framelink_enc_params p = drv_framelink_enc_params_raw();
    assert_true(drv_framelink_enc_params_check(&p, err, sizeof err));
    p.depth = DRV_CODEC_JPEG;
    assert_false(drv_framelink_enc_params_check(&p, err, sizeof err));
    assert_non_null(strstr(err, "depth codec"));
    p = drv_framelink_enc_params_raw(), p.depth_scale = 3;
    assert_false(drv_framelink_enc_params_check(&p, err, sizeof err));
    p = drv_framelink_enc_params_raw(), p.color = DRV_CODEC_JPEG, p.slices = 17;
    assert_false(drv_framelink_enc_params_check(&p, err, sizeof err));
    p = drv_framelink_enc_params_raw(), p.zstd_level = 0;
    assert_false(drv_framelink_enc_params_check(&p, err, sizeof err));
    /* INV16 of window depth is refused per frame */
    drv_frame f;
    make_frame(&f, W, H, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, WARP_DEPTH_STANDARD, 1);
    p = drv_framelink_enc_params_raw(), p.depth_format = DRV_FRAMELINK_FMT_INV16;
    drv_framelink_enc *e = drv_framelink_enc_create(&p, W, H, err, sizeof err);
    assert_non_null(e);
    uint8_t *buf = malloc(CAP);
    assert_int_equal(drv_framelink_enc_encode(e, &f, NULL, false, buf, CAP, err, sizeof err), 0);
    assert_non_null(strstr(err, "INV16"));
    /* too small a buffer */
    p.depth_format = 0, p.depth = DRV_CODEC_ZSTD;
    drv_framelink_enc_destroy(e);
    e = drv_framelink_enc_create(&p, W, H, err, sizeof err);
    assert_int_equal(drv_framelink_enc_encode(e, &f, NULL, false, buf, 400, err, sizeof err), 0);
    assert_non_null(strstr(err, "buffer"));
    drv_framelink_enc_destroy(e);
    drv_frame_free(&f);
    free(buf);
}

/* Camera message v2: codecs travel; a raw-only board still sends version 1; v1 reads as raw only. */
static void test_cams_codecs(void **state)
{
    (void)state;
    drv_framelink_cams c = {.seq = 3, .planes = DRV_PLANE_COLOR | DRV_PLANE_DEPTH, .max_frame_bytes = 1 << 20,
                            .refresh_hz = 90, .pose_rate_hz = 500};
    c.cam[0] = c.cam[1] = warp_camera_symmetric(64, 48, 90, 80, 0.05, 100);
    uint8_t b[DRV_FRAMELINK_CAMS_BYTES];
    drv_framelink_cams out;
    c.codecs = DRV_CODEC_BIT(DRV_CODEC_RAW) | DRV_CODEC_BIT(DRV_CODEC_ZSTD) | DRV_CODEC_BIT(DRV_CODEC_HEVC);
    assert_int_equal(drv_framelink_cams_encode(&c, b, sizeof b), DRV_FRAMELINK_CAMS_BYTES);
    assert_int_equal(b[4], 2);
    assert_int_equal(drv_framelink_cams_decode(b, sizeof b, &out), DRV_FRAME_OK);
    assert_int_equal(out.codecs, c.codecs);
    c.codecs = 0;
    drv_framelink_cams_encode(&c, b, sizeof b);
    assert_int_equal(b[4], 1);
    assert_int_equal(get32(b + 160), 0);
    assert_int_equal(drv_framelink_cams_decode(b, sizeof b, &out), DRV_FRAME_OK);
    assert_int_equal(out.codecs, DRV_CODEC_BIT(DRV_CODEC_RAW));
    /* v2 without raw: refused; unknown codec bits: dropped */
    c.codecs = DRV_CODEC_BIT(DRV_CODEC_ZSTD);
    drv_framelink_cams_encode(&c, b, sizeof b);
    put32(b + 160, DRV_CODEC_BIT(DRV_CODEC_ZSTD));
    put32(b + 164, (uint32_t)crc32_z(0, b, 164));
    assert_int_equal(drv_framelink_cams_decode(b, sizeof b, &out), DRV_FRAME_ERR_BAD_FORMAT);
    put32(b + 160, 0x81u | DRV_CODEC_BIT(DRV_CODEC_ZSTD));
    put32(b + 164, (uint32_t)crc32_z(0, b, 164));
    assert_int_equal(drv_framelink_cams_decode(b, sizeof b, &out), DRV_FRAME_OK);
    assert_int_equal(out.codecs, DRV_CODEC_BIT(DRV_CODEC_RAW) | DRV_CODEC_BIT(DRV_CODEC_ZSTD));
    /* a version 1 message with the codecs field set is refused as before */
    b[4] = 1;
    put32(b + 164, (uint32_t)crc32_z(0, b, 164));
    assert_int_equal(drv_framelink_cams_decode(b, sizeof b, &out), DRV_FRAME_ERR_BAD_FORMAT);
}

/* A smooth picture (codecs are judged on what they are for, not on noise). */
static void smooth_colour(drv_frame *f, int t)
{
    for (int e = 0; e < 2; e++)
        for (int y = 0; y < f->cam[e].height; y++)
            for (int x = 0; x < f->cam[e].width; x++)
                WARP_AT(&f->color[e], x, y) =
                    (warp_rgba8){(uint8_t)(x * 3 + t), (uint8_t)(y * 4 + e * 20), (uint8_t)((x + y) * 2), 255};
}
static double psnr(const drv_frame *a, const drv_frame *b)
{
    double se = 0;
    size_t n = 0;
    for (int e = 0; e < 2; e++)
        for (int y = 0; y < a->cam[e].height; y++)
            for (int x = 0; x < a->cam[e].width; x++, n += 3) {
                warp_rgba8 p = WARP_AT(&a->color[e], x, y), q = WARP_AT(&b->color[e], x, y);
                se += (p.r - q.r) * (p.r - q.r) + (p.g - q.g) * (p.g - q.g) + (p.b - q.b) * (p.b - q.b);
                assert_int_equal(q.a, 255);
            }
    return se ? 10 * log10(255.0 * 255.0 * (double)n / se) : 99;
}

/* JPEG slices: once drv_codec_jpeg.c is libturbojpeg's (the placeholder's drv_jpeg_create returns NULL). */
static void test_jpeg(void **state)
{
    (void)state;
    drv_jpeg *probe = drv_jpeg_create(true, NULL, 0);
    if (!probe) {
        printf("# jpeg: skipped, drv_jpeg_create returned NULL (the JPEG placeholder is in place)\n");
        skip();
        return;
    }
    drv_jpeg_destroy(probe);
    uint8_t *buf = malloc(CAP);
    for (int slices = 1; slices <= 4; slices += 3)
        for (int sub = 0; sub < 2; sub++) {
            drv_frame f, g;
            make_frame(&f, 64, 48, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, WARP_DEPTH_LINEAR, 2);
            smooth_colour(&f, 0);
            drv_framelink_enc_params p = zstd_params();
            p.color = DRV_CODEC_JPEG, p.quality = 90, p.slices = slices, p.jpeg_sub = (drv_jpeg_sub)sub;
            size_t n = encode(&p, &f, buf);
            assert_int_equal(buf[DESC(0) + 12], DRV_CODEC_JPEG);
            assert_int_equal(buf[DESC(0) + 15], slices);
            assert_true(drv_frame_alloc(&g, 64, 48, ALL, MAX_LAYERS));
            drv_framelink_dec *d = make_dec(64, 48, 2);
            char detail[200];
            assert_int_equal(drv_framelink_dec_decode(d, buf, n, 0, &g, NULL, detail, sizeof detail), DRV_FRAME_OK);
            assert_true(psnr(&f, &g) > 35);
            /* a corrupt JPEG (CRCs repaired) is refused for its reason and counted */
            size_t hdr = hdr_of(buf), c0 = hdr + get32(buf + DESC(0) + 4) + 8u * (size_t)slices;
            memset(buf + c0 + 2, 0x00, 40);
            repair(buf);
            assert_int_not_equal(drv_framelink_dec_decode(d, buf, n, 0, &g, NULL, detail, sizeof detail), DRV_FRAME_OK);
            drv_framelink_dec_stats st;
            drv_framelink_dec_stats_get(d, &st);
            assert_int_equal(st.codec_errors, 1);
            drv_framelink_dec_destroy(d);
            drv_frame_free(&f);
            drv_frame_free(&g);
        }
    free(buf);
}

/* Video: the stream counter in param, KEY, a gap -> want_key and frames dropped until a key frame. Once
 * drv_codec_video.c is libavcodec's (the placeholder can encode nothing). */
static void test_video(void **state)
{
    (void)state;
    for (int c = DRV_CODEC_H264; c <= DRV_CODEC_HEVC; c++) {
        if (!drv_video_can_encode((drv_codec_id)c) || !drv_video_can_decode((drv_codec_id)c)) {
            printf("# %s: skipped, this build cannot encode and decode it (the video placeholder?)\n",
                   drv_codec_name((drv_codec_id)c));
            continue;
        }
        enum { VW = 64, VH = 48, FRAMES = 8 };
        drv_framelink_enc_params p = drv_framelink_enc_params_raw();
        p.color = (drv_codec_id)c, p.quality = 20, p.fps = 45;
        char err[200] = "", detail[200];
        drv_framelink_enc *e = drv_framelink_enc_create(&p, VW, VH, err, sizeof err);
        if (!e) fail_msg("%s", err);
        drv_framelink_dec *d = make_dec(VW, VH, 2);
        static uint8_t *buf[FRAMES];
        size_t n[FRAMES];
        drv_frame f, g;
        make_frame(&f, VW, VH, DRV_PLANE_COLOR, WARP_DEPTH_LINEAR, 1);
        assert_true(drv_frame_alloc(&g, VW, VH, ALL, MAX_LAYERS));
        for (int i = 0; i < FRAMES; i++) {
            smooth_colour(&f, i);
            buf[i] = malloc(CAP);
            n[i] = drv_framelink_enc_encode(e, &f, NULL, i == 5, buf[i], CAP, err, sizeof err);
            if (!n[i]) fail_msg("%s", err);
            assert_int_equal(buf[i][DESC(0) + 2], i); /* the counter */
        }
        assert_true(buf[0][DESC(0) + 13] & 1); /* the first is a key frame */
        assert_true(buf[5][DESC(0) + 13] & 1); /* asked for */
        assert_int_equal(drv_framelink_dec_decode(d, buf[0], n[0], 0, &g, NULL, detail, sizeof detail), DRV_FRAME_OK);
        assert_int_equal(drv_framelink_dec_decode(d, buf[1], n[1], 0, &g, NULL, detail, sizeof detail), DRV_FRAME_OK);
        smooth_colour(&f, 1);
        assert_true(psnr(&f, &g) > 30);
        assert_false(drv_framelink_dec_take_want_key(d));
        /* frame 2 lost: 3 and 4 are dropped, a key frame asked for (once), 5 (key) decodes */
        assert_int_equal(drv_framelink_dec_decode(d, buf[3], n[3], 0, &g, NULL, detail, sizeof detail),
                         DRV_FRAME_ERR_BAD_FORMAT);
        assert_non_null(strstr(detail, "missing"));
        assert_true(drv_framelink_dec_take_want_key(d));
        assert_false(drv_framelink_dec_take_want_key(d));
        assert_int_equal(drv_framelink_dec_decode(d, buf[4], n[4], 0, &g, NULL, detail, sizeof detail),
                         DRV_FRAME_ERR_BAD_FORMAT);
        assert_non_null(strstr(detail, "key frame"));
        assert_int_equal(drv_framelink_dec_decode(d, buf[5], n[5], 0, &g, NULL, detail, sizeof detail), DRV_FRAME_OK);
        assert_int_equal(drv_framelink_dec_decode(d, buf[6], n[6], 0, &g, NULL, detail, sizeof detail), DRV_FRAME_OK);
        drv_framelink_dec_stats st;
        drv_framelink_dec_stats_get(d, &st);
        assert_int_equal(st.frames, 4);
        assert_int_equal(st.codec_errors, 2);
        assert_int_equal(st.key_requests, 1);
        assert_true(st.video_decoder[0]);
        for (int i = 0; i < FRAMES; i++) free(buf[i]);
        drv_framelink_enc_destroy(e);
        drv_framelink_dec_destroy(d);
        drv_frame_free(&f);
        drv_frame_free(&g);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_zstd_lossless),   cmocka_unit_test(test_all_raw_is_v1),
        cmocka_unit_test(test_inv16),           cmocka_unit_test(test_upsample_edges),
        cmocka_unit_test(test_inv16_rounding),  cmocka_unit_test(test_inv16_decoded_exactly),
        cmocka_unit_test(test_downsample_nearest), cmocka_unit_test(test_damage),
        cmocka_unit_test(test_params),          cmocka_unit_test(test_cams_codecs),
        cmocka_unit_test(test_jpeg),            cmocka_unit_test(test_video),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
