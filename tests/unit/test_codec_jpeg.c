/* SPDX-License-Identifier: MIT */
/* drv_codec_jpeg, framelink v2's JPEG colour codec: round trips at 4:2:0 and 4:4:4 against measured PSNR bounds, odd
 * sizes, bands of rows by pointer and stride, and damaged input (wrong size, every truncation, bit flips) refused. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "drivers/drv_codec_jpeg.h"
#include "warp/warp_image.h"
#include "warp/warp_metrics.h"

static drv_jpeg *enc, *dec;

static int setup(void **state)
{
    (void)state;
    char err[256];
    enc = drv_jpeg_create(true, err, sizeof err);
    dec = drv_jpeg_create(false, err, sizeof err);
    return enc && dec ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    drv_jpeg_destroy(enc);
    drv_jpeg_destroy(dec);
    return 0;
}

/* A scene-like test picture: smooth gradients (where 4:2:0 and quantisation cost little), a hard-edged box and a
 * thin diagonal line in saturated colours (where they cost most), and alpha varying so its drop is seen. */
static void test_picture(warp_image_rgba8 *img, int w, int h)
{
    assert_true(warp_image_rgba8_alloc(img, w, h));
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            warp_rgba8 p = {(uint8_t)(40 + 160 * x / w), (uint8_t)(30 + 180 * y / h),
                            (uint8_t)(90 + 60 * (x + y) / (w + h)), (uint8_t)(x * 7 + y)};
            if (x > w / 4 && x < w / 2 && y > h / 3 && y < 2 * h / 3) p = (warp_rgba8){230, 20, 25, 1};
            if (abs(x - y) <= 1) p = (warp_rgba8){250, 250, 40, 2};
            WARP_AT(img, x, y) = p;
        }
}

static size_t stride_of(const warp_image_rgba8 *img) { return (size_t)img->stride * sizeof(warp_rgba8); }

/* Encodes img (all of it), checks the length against the bound, returns the JPEG (caller frees). */
static uint8_t *encode(const warp_image_rgba8 *img, int quality, drv_jpeg_sub sub, size_t *len)
{
    size_t cap = drv_jpeg_bound(img->w, img->h, sub);
    assert_true(cap > 0);
    uint8_t *out = malloc(cap);
    char err[256] = "";
    *len = drv_jpeg_encode(enc, (const uint8_t *)img->px, img->w, img->h, stride_of(img), quality, sub, out, cap, err,
                           sizeof err);
    if (*len == 0) fail_msg("encode %dx%d q%d: %s", img->w, img->h, quality, err);
    assert_true(*len <= cap);
    return out;
}

static double round_trip_psnr(const warp_image_rgba8 *img, int quality, drv_jpeg_sub sub, size_t *len)
{
    uint8_t *jpeg = encode(img, quality, sub, len);
    warp_image_rgba8 back;
    assert_true(warp_image_rgba8_alloc(&back, img->w, img->h));
    char err[256] = "";
    drv_frame_err e = drv_jpeg_decode(dec, jpeg, *len, (uint8_t *)back.px, back.w, back.h, stride_of(&back), err,
                                      sizeof err);
    if (e != DRV_FRAME_OK) fail_msg("decode %dx%d: %s", img->w, img->h, err);
    for (int y = 0; y < back.h; y++)
        for (int x = 0; x < back.w; x++) assert_int_equal(WARP_AT(&back, x, y).a, 255);
    double psnr = warp_psnr(img, &back, NULL, 0);
    warp_image_free(&back);
    free(jpeg);
    return psnr;
}

/* Bounds about 1.5 dB under what libjpeg-turbo 2.1 gives on this picture (measured in the comments), so a change of
 * flags, subsampling or colour handling that costs quality fails while small library changes do not. 4:2:0 stays
 * near 31 dB whatever the quality: the saturated one-pixel line loses its colour to the halved chroma, which is
 * what 4:4:4 is for. */
static void test_round_trip_quality(void **state)
{
    (void)state;
    static const struct {
        drv_jpeg_sub sub;
        int q;
        double min_db;
    } cases[] = {
        {DRV_JPEG_420, 50, 29.0}, /* 30.50 dB */ {DRV_JPEG_420, 75, 29.5}, /* 31.05 */
        {DRV_JPEG_420, 90, 29.9}, /* 31.39 */    {DRV_JPEG_420, 95, 30.0}, /* 31.47 */
        {DRV_JPEG_444, 50, 32.4}, /* 33.92 */    {DRV_JPEG_444, 75, 34.5}, /* 36.06 */
        {DRV_JPEG_444, 90, 39.5}, /* 40.96 */    {DRV_JPEG_444, 95, 43.7}, /* 45.20 */
    };
    warp_image_rgba8 img;
    test_picture(&img, 256, 192);
    size_t last_len[2] = {0, 0};
    double db420[4] = {0};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        size_t len;
        double db = round_trip_psnr(&img, cases[i].q, cases[i].sub, &len);
        printf("# %s q%d: %zu bytes, %.2f dB\n", cases[i].sub == DRV_JPEG_420 ? "4:2:0" : "4:4:4", cases[i].q, len,
               db);
        if (db < cases[i].min_db) fail_msg("q%d: %.2f dB < %.1f", cases[i].q, db, cases[i].min_db);
        assert_true(len > last_len[cases[i].sub]); /* quality costs bytes */
        last_len[cases[i].sub] = len;
        if (cases[i].sub == DRV_JPEG_420) db420[i] = db;
        else if (db <= db420[i - 4] + 2.0) /* the 4:2:0 case of the same quality, four rows up */
            fail_msg("4:4:4 q%d: %.2f dB, not 2 dB above 4:2:0's %.2f", cases[i].q, db, db420[i - 4]);
    }
    warp_image_free(&img);
}

/* Sizes that are no multiple of the 8x8 or 16x16 MCU: the padding is cropped back exactly. Tiny pictures are mostly
 * edge and line, so their bounds are low (measured in the comments); a shifted or transposed decode scores far less. */
static void test_odd_sizes(void **state)
{
    (void)state;
    static const struct {
        int w, h;
        double min_db[2]; /* 4:2:0, 4:4:4 */
    } cases[] = {
        {1, 1, {99, 99}},                                  /* identical: inf */
        {3, 5, {15.4, 27.6}}, {5, 3, {15.1, 29.0}}, /* 16.89, 29.10; 16.62, 30.56 */
        {17, 9, {19.2, 29.5}},                              /* 20.67, 30.97 */
        {719, 801, {34.9, 43.8}},                           /* 36.37, 45.35 */
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        for (int sub = DRV_JPEG_420; sub <= DRV_JPEG_444; sub++) {
            warp_image_rgba8 img;
            test_picture(&img, cases[i].w, cases[i].h);
            size_t len;
            double db = round_trip_psnr(&img, 90, (drv_jpeg_sub)sub, &len);
            if (db < cases[i].min_db[sub]) fail_msg("%dx%d sub %d: %.2f dB", img.w, img.h, sub, db);
            warp_image_free(&img);
        }
}

/* A slice as the framelink codec sends it: rows [y0, y1) of an eye image, encoded from a pointer into the image
 * with the image's stride and decoded into the same rows of another: nothing outside them (nor the row padding
 * beyond w pixels) is written. */
static void test_band_of_rows(void **state)
{
    (void)state;
    const int w = 100, h = 60, y0 = 21, y1 = 40, pad = 12;
    const size_t stride = (size_t)(w + pad) * 4;
    uint8_t *src = malloc(stride * h), *dst = malloc(stride * h);
    warp_image_rgba8 pic;
    test_picture(&pic, w, h);
    memset(src, 0x5a, stride * h);
    for (int y = 0; y < h; y++) memcpy(src + stride * y, &WARP_AT(&pic, 0, y), (size_t)w * 4);
    memset(dst, 0xa5, stride * h);
    for (int sub = DRV_JPEG_420; sub <= DRV_JPEG_444; sub++) {
        size_t cap = drv_jpeg_bound(w, y1 - y0, (drv_jpeg_sub)sub);
        uint8_t *jpeg = malloc(cap);
        char err[256] = "";
        size_t len = drv_jpeg_encode(enc, src + stride * y0, w, y1 - y0, stride, 95, (drv_jpeg_sub)sub, jpeg, cap, err,
                                     sizeof err);
        assert_true(len > 0);
        assert_int_equal(drv_jpeg_decode(dec, jpeg, len, dst + stride * y0, w, y1 - y0, stride, err, sizeof err),
                         DRV_FRAME_OK);
        for (int y = 0; y < h; y++)
            for (size_t b = 0; b < stride; b++) {
                bool inside = y >= y0 && y < y1 && b < (size_t)w * 4;
                if (!inside) assert_int_equal(dst[stride * y + b], 0xa5);
            }
        warp_image_rgba8 a = {w, y1 - y0, w + pad, (warp_rgba8 *)(src + stride * y0)};
        warp_image_rgba8 b = {w, y1 - y0, w + pad, (warp_rgba8 *)(dst + stride * y0)};
        double db = warp_psnr(&a, &b, NULL, 0);
        if (db < (sub == DRV_JPEG_420 ? 26.6 : 40.7)) fail_msg("band sub %d: %.2f dB", sub, db); /* 28.13, 42.22 */
        free(jpeg);
    }
    warp_image_free(&pic);
    free(src);
    free(dst);
}

/* A small JPEG for the damage tests (16x8 4:2:0: two MCUs). */
static uint8_t *small_jpeg(size_t *len)
{
    warp_image_rgba8 img;
    test_picture(&img, 16, 8);
    uint8_t *j = encode(&img, 80, DRV_JPEG_420, len);
    warp_image_free(&img);
    return j;
}

static void test_wrong_size(void **state)
{
    (void)state;
    size_t len;
    uint8_t *jpeg = small_jpeg(&len);
    uint8_t px[17 * 9 * 4];
    static const int sizes[][2] = {{16, 9}, {17, 8}, {15, 8}, {16, 7}, {8, 4}};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
        char err[256] = "";
        memset(px, 0x77, sizeof px);
        int w = sizes[i][0], h = sizes[i][1];
        assert_int_equal(drv_jpeg_decode(dec, jpeg, len, px, w, h, (size_t)w * 4, err, sizeof err),
                         DRV_FRAME_ERR_BAD_SIZE);
        char want[64];
        snprintf(want, sizeof want, "JPEG is 16x8, the slice is %dx%d", w, h);
        assert_string_equal(err, want);
        for (size_t b = 0; b < sizeof px; b++) assert_int_equal(px[b], 0x77); /* refused before any pixel */
    }
    free(jpeg);
}

/* Decodes jpeg[len] as 16x8 into a buffer with a guard after it; returns the result, fails on a guard write. */
static drv_frame_err decode_guarded(const uint8_t *jpeg, size_t len, char *err, int errlen)
{
    enum { N = 16 * 8 * 4, GUARD = 64 };
    uint8_t px[N + GUARD];
    memset(px + N, 0xee, GUARD);
    drv_frame_err e = drv_jpeg_decode(dec, jpeg, len, px, 16, 8, 16 * 4, err, errlen);
    for (int b = 0; b < GUARD; b++) assert_int_equal(px[N + b], 0xee);
    return e;
}

static void test_truncated(void **state)
{
    (void)state;
    size_t len;
    uint8_t *jpeg = small_jpeg(&len);
    char err[256];
    assert_int_equal(decode_guarded(jpeg, len, err, sizeof err), DRV_FRAME_OK);
    for (size_t cut = 0; cut < len; cut++) {
        /* An exact-size copy, so ASan (make asan) sees any read past the cut. */
        uint8_t *part = malloc(cut ? cut : 1);
        memcpy(part, jpeg, cut);
        err[0] = 0;
        drv_frame_err e = decode_guarded(part, cut, err, sizeof err);
        if (e != DRV_FRAME_ERR_BAD_FORMAT) fail_msg("cut at %zu of %zu: %s (%s)", cut, len, drv_frame_err_str(e), err);
        assert_true(err[0] != 0);
        free(part);
    }
    free(jpeg);
}

static uint32_t xorshift(uint32_t *s)
{
    *s ^= *s << 13;
    *s ^= *s >> 17;
    *s ^= *s << 5;
    return *s;
}

/* Random bit flips anywhere (fixed seed): never a crash or a write outside the plane; a flip in the header's size
 * is BAD_SIZE (never OK at another size). JPEG has no checksum of its own (framelink's CRC covers the frame), so a
 * flip in entropy data may still decode OK: only the share refused is bounded, from below. */
static void test_bit_flips(void **state)
{
    (void)state;
    size_t len;
    uint8_t *jpeg = small_jpeg(&len);
    uint8_t *bad = malloc(len);
    uint32_t seed = 0x19u;
    int ok = 0, refused = 0;
    for (int i = 0; i < 3000; i++) {
        memcpy(bad, jpeg, len);
        int flips = 1 + (int)(xorshift(&seed) % 3);
        for (int f = 0; f < flips; f++) {
            uint32_t bit = xorshift(&seed) % (uint32_t)(len * 8);
            bad[bit / 8] ^= (uint8_t)(1u << (bit % 8));
        }
        char err[256] = "";
        drv_frame_err e = decode_guarded(bad, len, err, sizeof err);
        if (e == DRV_FRAME_OK) ok++;
        else {
            assert_true(e == DRV_FRAME_ERR_BAD_FORMAT || e == DRV_FRAME_ERR_BAD_SIZE);
            assert_true(err[0] != 0);
            refused++;
        }
    }
    printf("# bit flips: %d decoded, %d refused\n", ok, refused);
    assert_true(refused > 1000); /* 1318 with libjpeg-turbo 2.1.5 */
    /* The frame header's height and width (SOF0: FF C0, length, precision, then height and width, big-endian). */
    size_t sof = 0;
    for (size_t i = 2; i + 8 < len; i++)
        if (jpeg[i] == 0xff && jpeg[i + 1] == 0xc0) {
            sof = i;
            break;
        }
    assert_true(sof > 0);
    for (size_t b = sof + 5; b < sof + 9; b++)
        for (int bit = 0; bit < 8; bit++) {
            memcpy(bad, jpeg, len);
            bad[b] ^= (uint8_t)(1u << bit);
            char err[256] = "";
            drv_frame_err e = decode_guarded(bad, len, err, sizeof err);
            /* Any changed size is another size; a zero one is no JPEG at all. */
            assert_true(e == DRV_FRAME_ERR_BAD_SIZE || e == DRV_FRAME_ERR_BAD_FORMAT);
        }
    free(bad);
    free(jpeg);
}

/* A buffer below the bound is refused before encoding and left untouched; the bound itself always suffices, even
 * for noise at quality 100 4:4:4 (JPEG's worst case). */
static void test_cap_and_bound(void **state)
{
    (void)state;
    assert_int_equal(drv_jpeg_bound(0, 8, DRV_JPEG_420), 0);
    assert_int_equal(drv_jpeg_bound(8, -1, DRV_JPEG_420), 0);
    assert_int_equal(drv_jpeg_bound(WARP_MAX_SIDE + 1, 8, DRV_JPEG_444), 0);
    assert_int_equal(drv_jpeg_bound(8, 8, (drv_jpeg_sub)7), 0);
    assert_true(drv_jpeg_bound(1, 1, DRV_JPEG_420) > 0);
    assert_true(drv_jpeg_bound(WARP_MAX_SIDE, WARP_MAX_SIDE, DRV_JPEG_444) > (size_t)WARP_MAX_SIDE * WARP_MAX_SIDE * 3);
    assert_true(drv_jpeg_bound(64, 64, DRV_JPEG_444) >= drv_jpeg_bound(64, 64, DRV_JPEG_420));

    const int w = 64, h = 48;
    uint8_t *rgba = malloc((size_t)w * h * 4);
    uint32_t seed = 7;
    for (size_t i = 0; i < (size_t)w * h * 4; i++) rgba[i] = (uint8_t)xorshift(&seed);
    size_t bound = drv_jpeg_bound(w, h, DRV_JPEG_444);
    uint8_t *out = malloc(bound + 16);
    char err[256] = "";
    memset(out, 0x3c, bound + 16);
    size_t stride = (size_t)w * 4;
    assert_int_equal(drv_jpeg_encode(enc, rgba, w, h, stride, 100, DRV_JPEG_444, out, bound - 1, err, sizeof err), 0);
    assert_non_null(strstr(err, "needs a"));
    for (size_t i = 0; i < bound + 16; i++) assert_int_equal(out[i], 0x3c);
    size_t len = drv_jpeg_encode(enc, rgba, w, h, stride, 100, DRV_JPEG_444, out, bound, err, sizeof err);
    assert_true(len > (size_t)w * h); /* noise does not compress */
    assert_true(len <= bound);
    for (size_t i = bound; i < bound + 16; i++) assert_int_equal(out[i], 0x3c);
    free(rgba);
    free(out);
}

/* Every argument a caller can get wrong: a clear error, no crash, nothing written. */
static void test_bad_arguments(void **state)
{
    (void)state;
    uint8_t px[16 * 8 * 4] = {0}, out[4096];
    size_t cap = sizeof out;
    char err[256];
#define ENC_FAILS(j, in, w, h, stride, q, sub, o, c, what)                                                             \
    do {                                                                                                               \
        err[0] = 0;                                                                                                    \
        assert_int_equal(drv_jpeg_encode(j, in, w, h, stride, q, sub, o, c, err, sizeof err), 0);                      \
        if (!strstr(err, what)) fail_msg("expected '%s' in '%s'", what, err);                                          \
    } while (0)
    ENC_FAILS(NULL, px, 16, 8, 64, 90, DRV_JPEG_420, out, cap, "not an encoder");
    ENC_FAILS(dec, px, 16, 8, 64, 90, DRV_JPEG_420, out, cap, "not an encoder");
    ENC_FAILS(enc, NULL, 16, 8, 64, 90, DRV_JPEG_420, out, cap, "no input");
    ENC_FAILS(enc, px, 16, 8, 64, 90, DRV_JPEG_420, NULL, cap, "no output");
    ENC_FAILS(enc, px, 0, 8, 64, 90, DRV_JPEG_420, out, cap, "size 0x8");
    ENC_FAILS(enc, px, 16, 8, 63, 90, DRV_JPEG_420, out, cap, "stride 63");
    ENC_FAILS(enc, px, 16, 8, 64, 0, DRV_JPEG_420, out, cap, "quality 0");
    ENC_FAILS(enc, px, 16, 8, 64, 101, DRV_JPEG_420, out, cap, "quality 101");
    ENC_FAILS(enc, px, 16, 8, 64, 90, (drv_jpeg_sub)3, out, cap, "subsampling 3");
    ENC_FAILS(enc, px, 16, 8, 64, 90, DRV_JPEG_420, out, 0, "needs a");
#undef ENC_FAILS
    size_t len = drv_jpeg_encode(enc, px, 16, 8, 64, 90, DRV_JPEG_420, out, cap, err, sizeof err);
    assert_true(len > 0);
    assert_int_equal(drv_jpeg_decode(NULL, out, len, px, 16, 8, 64, err, sizeof err), DRV_FRAME_ERR_BAD_FORMAT);
    assert_int_equal(drv_jpeg_decode(enc, out, len, px, 16, 8, 64, err, sizeof err), DRV_FRAME_ERR_BAD_FORMAT);
    assert_int_equal(drv_jpeg_decode(dec, NULL, len, px, 16, 8, 64, err, sizeof err), DRV_FRAME_ERR_BAD_FORMAT);
    assert_int_equal(drv_jpeg_decode(dec, out, 0, px, 16, 8, 64, err, sizeof err), DRV_FRAME_ERR_BAD_FORMAT);
    assert_string_equal(err, "JPEG decode: no data");
    assert_int_equal(drv_jpeg_decode(dec, out, len, NULL, 16, 8, 64, err, sizeof err), DRV_FRAME_ERR_BAD_SIZE);
    assert_int_equal(drv_jpeg_decode(dec, out, len, px, 16, 8, 60, err, sizeof err), DRV_FRAME_ERR_BAD_SIZE);
    assert_int_equal(drv_jpeg_decode(dec, out, len, px, 0, 8, 64, err, sizeof err), DRV_FRAME_ERR_BAD_SIZE);
    static const uint8_t not_jpeg[] = "\x89PNG\r\n\x1a\n not a JPEG at all";
    assert_int_equal(drv_jpeg_decode(dec, not_jpeg, sizeof not_jpeg, px, 16, 8, 64, err, sizeof err),
                     DRV_FRAME_ERR_BAD_FORMAT);
    assert_non_null(strstr(err, "JPEG header"));
    assert_int_equal(drv_jpeg_decode(dec, out, len, px, 16, 8, 64, err, sizeof err), DRV_FRAME_OK);
    drv_jpeg_destroy(NULL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip_quality), cmocka_unit_test(test_odd_sizes),
        cmocka_unit_test(test_band_of_rows),       cmocka_unit_test(test_wrong_size),
        cmocka_unit_test(test_truncated),          cmocka_unit_test(test_bit_flips),
        cmocka_unit_test(test_cap_and_bound),      cmocka_unit_test(test_bad_arguments),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
