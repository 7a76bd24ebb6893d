/* SPDX-License-Identifier: MIT */
/* drv_codec_video, H.264 and HEVC per eye through libavcodec: round trips at three sizes judged by PSNR, key frames
 * forced and recovered from, a missing reference refused, damaged access units survived, sizes checked, intra
 * refresh, and nothing written past the caller's image. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cmocka.h>

#include "drivers/drv_codec_video.h"

/* Quality 23, ultrafast, measured worst frame of ten (H.264 / HEVC): 720x800 39.2 / 39.1 dB; 161x97 32.3 / 32.9;
 * 64x48 33.0 / 33.5 (small images are mostly edges and texture). The bounds leave about 3 dB. */
#define MIN_PSNR_DB 35.0
#define MIN_PSNR_SMALL_DB 29.0

typedef struct {
    int w, h;
    size_t stride;
    uint8_t *src, *dst;
    uint8_t *au;
    size_t cap;
    drv_video_enc *e; /* of the rig's size (rig_open) */
    drv_video_dec *d;
} rig;

static void rig_init(rig *r, int w, int h)
{
    r->w = w, r->h = h;
    r->e = NULL, r->d = NULL;
    r->stride = (size_t)w * 4 + 12; /* not tight: strides are honoured */
    r->src = calloc(r->stride * (size_t)h, 1);
    r->dst = calloc(r->stride * (size_t)h, 1);
    r->cap = (size_t)w * h * 4 + 65536;
    r->au = malloc(r->cap);
    assert_non_null(r->src);
    assert_non_null(r->dst);
    assert_non_null(r->au);
}

static void rig_free(rig *r)
{
    drv_video_dec_destroy(r->d);
    drv_video_enc_destroy(r->e);
    free(r->src), free(r->dst), free(r->au);
}

/* A smooth scene with a bright square moving 3 px a frame and a fine pattern: motion, edges and texture. */
static void draw(rig *r, int t)
{
    for (int y = 0; y < r->h; y++)
        for (int x = 0; x < r->w; x++) {
            uint8_t *p = r->src + (size_t)y * r->stride + (size_t)x * 4;
            double u = (double)x / r->w, v = (double)y / r->h;
            p[0] = (uint8_t)(128 + 100 * sin(6.0 * u + 0.2 * t));
            p[1] = (uint8_t)(128 + 100 * cos(5.0 * v - 0.1 * t));
            p[2] = (uint8_t)(128 + 60 * sin(3.0 * (u + v)) + 12 * (((x / 8) + (y / 8)) & 1));
            p[3] = 255;
            int sx = (r->w / 4 + 3 * t) % r->w, sy = r->h / 3, side = r->w / 8 + 2;
            if (x >= sx && x < sx + side && y >= sy && y < sy + side) p[0] = p[1] = p[2] = 240;
        }
}

/* PSNR of dst against src over RGB; dst's alpha must be 255. */
static double psnr(const rig *r)
{
    double se = 0;
    for (int y = 0; y < r->h; y++)
        for (int x = 0; x < r->w; x++) {
            const uint8_t *a = r->src + (size_t)y * r->stride + (size_t)x * 4;
            const uint8_t *b = r->dst + (size_t)y * r->stride + (size_t)x * 4;
            assert_int_equal(b[3], 255);
            for (int c = 0; c < 3; c++) se += (double)(a[c] - b[c]) * (a[c] - b[c]);
        }
    double mse = se / (3.0 * r->w * r->h);
    return mse <= 0 ? 99.0 : 10.0 * log10(255.0 * 255.0 / mse);
}

static drv_video_params params(drv_codec_id c, int w, int h)
{
    return (drv_video_params){.codec = c, .w = w, .h = h, .fps = 45, .quality = 23};
}

/* A rig of p's size with an encoder of p and a decoder of p's codec for dw x dh eyes (hw as drv_video_dec_create's). */
static void rig_open(rig *r, const drv_video_params *p, int dw, int dh, const char *hw)
{
    rig_init(r, p->w, p->h);
    char err[256] = "";
    r->e = drv_video_enc_create(p, err, sizeof err);
    if (!r->e) fail_msg("encoder: %s", err);
    r->d = drv_video_dec_create(p->codec, dw, dh, hw, err, sizeof err);
    if (!r->d) fail_msg("decoder: %s", err);
}

/* Whether this machine has codec c both ways; a skip says why. */
static bool have(drv_codec_id c)
{
    if (drv_video_can_encode(c) && drv_video_can_decode(c)) return true;
    printf("# SKIP %s: this libavcodec lacks its %s\n", drv_codec_name(c),
           drv_video_can_encode(c) ? "decoder" : "encoder (libx264 / libx265)");
    return false;
}

/* Encodes draw(t) into r->au; returns its length. */
static size_t enc(rig *r, int t, bool force, bool *key)
{
    char err[256] = "";
    draw(r, t);
    size_t n = drv_video_encode(r->e, r->src, r->stride, force, r->au, r->cap, key, err, sizeof err);
    if (!n) fail_msg("encode frame %d: %s", t, err);
    return n;
}

static drv_frame_err dec(rig *r, size_t n, char *err, int errlen)
{
    return drv_video_decode(r->d, r->au, n, r->dst, r->stride, err, errlen);
}

/* Encodes draw(t) (a key frame when forced) and decodes it, which must succeed (else fails naming what); the PSNR
 * of the picture decoded. *n, *key: the access unit's length and whether it is a key frame. */
static double through(rig *r, int t, bool force, size_t *n, bool *key, const char *what)
{
    char err[256] = "";
    *n = enc(r, t, force, key);
    if (dec(r, *n, err, sizeof err) != DRV_FRAME_OK) fail_msg("%s frame %d: %s", what, t, err);
    return psnr(r);
}

static void roundtrip(drv_codec_id c, int w, int h, double min_db)
{
    rig r;
    drv_video_params p = params(c, w, h);
    rig_open(&r, &p, w, h, NULL);
    assert_string_equal(drv_video_dec_name(r.d), "software");
    char what[64];
    snprintf(what, sizeof what, "%s %dx%d", drv_codec_name(c), w, h);
    double worst = 99;
    for (int t = 0; t < 10; t++) {
        bool key = true;
        size_t n;
        double db = through(&r, t, false, &n, &key, what);
        assert_int_equal(key, t == 0); /* gop 0: only the first */
        if (db < worst) worst = db;
        if (getenv("VIDEO_TEST_VERBOSE")) printf("#   frame %d: %zu bytes %.1f dB\n", t, n, db);
        if (db < min_db) fail_msg("%s %dx%d frame %d: %.1f dB", drv_codec_name(c), w, h, t, db);
    }
    printf("# %s %dx%d: worst %.1f dB\n", drv_codec_name(c), w, h, worst);
    rig_free(&r);
}

static void test_roundtrip(void **state)
{
    drv_codec_id c = (drv_codec_id)(intptr_t)*state;
    if (!have(c)) skip();
    roundtrip(c, 64, 48, MIN_PSNR_SMALL_DB);
    roundtrip(c, 720, 800, MIN_PSNR_DB);
    roundtrip(c, 161, 97, MIN_PSNR_SMALL_DB); /* odd both ways: padded to even and cropped back */
}

/* A frame lost mid-stream: the next P-frame (libavcodec conceals it, 23 dB for H.264 and 12 dB for HEVC here) is
 * refused; a P-frame after a reset is refused; a forced key frame is an IDR, flagged, and a reset decoder resumes
 * from it. */
static void test_keys_and_loss(void **state)
{
    drv_codec_id c = (drv_codec_id)(intptr_t)*state;
    if (!have(c)) skip();
    rig r;
    drv_video_params p = params(c, 96, 64);
    rig_open(&r, &p, 96, 64, "");
    char err[256] = "";
    bool key;
    size_t n;
    for (int t = 0; t < 3; t++) through(&r, t, false, &n, &key, "before the loss");
    /* frame 3 lost on the link; frame 4 refers to it */
    enc(&r, 3, false, &key);
    n = enc(&r, 4, false, &key);
    err[0] = 0;
    assert_int_equal(dec(&r, n, err, sizeof err), DRV_FRAME_ERR_BAD_FORMAT);
    assert_non_null(strstr(err, "concealed"));
    printf("# %s: P-frame after a lost one: %s\n", drv_codec_name(c), err);
    /* the caller resets and waits for a key: a P-frame first is refused */
    drv_video_dec_reset(r.d);
    n = enc(&r, 5, false, &key);
    assert_false(key);
    err[0] = 0;
    assert_int_equal(dec(&r, n, err, sizeof err), DRV_FRAME_ERR_BAD_FORMAT);
    assert_true(err[0] != 0);
    printf("# %s: P-frame after reset: %s\n", drv_codec_name(c), err);
    /* the board asked; the host forces a key frame; the stream is whole again from it */
    drv_video_dec_reset(r.d);
    for (int t = 6; t < 10; t++) {
        assert_true(through(&r, t, t == 6, &n, &key, "from the forced key") > MIN_PSNR_SMALL_DB);
        assert_int_equal(key, t == 6);
    }
    rig_free(&r);
}

/* Truncated and bit-flipped access units (fixed seed) are refused or decoded, never crash, print nothing, and the
 * stream recovers at the next key frame after a reset. */
static void test_damage(void **state)
{
    drv_codec_id c = (drv_codec_id)(intptr_t)*state;
    if (!have(c)) skip();
    rig r;
    drv_video_params p = params(c, 64, 48);
    p.gop = 4;
    rig_open(&r, &p, 64, 48, NULL);
    char err[256];
    uint8_t *bad = malloc(r.cap);
    assert_non_null(bad);
    unsigned seed = 19;
    int refused = 0, tries = 0;
    /* libav's own complaints must not reach stderr (a host's bad stream would fill the board's journal) */
    fflush(stderr);
    int saved_stderr = dup(2);
    FILE *cap = tmpfile();
    assert_true(saved_stderr >= 0 && cap);
    dup2(fileno(cap), 2);
    for (int t = 0; t < 24; t++) {
        bool key;
        size_t n = enc(&r, t, false, &key);
        assert_int_equal(key, t % 4 == 0);
        memcpy(bad, r.au, n);
        size_t m = n;
        if (t % 2)
            m = n / 2 + (size_t)(rand_r(&seed) % (unsigned)(n / 2)); /* truncated */
        for (int k = 0; k < 1 + t % 5; k++) bad[rand_r(&seed) % n] ^= (uint8_t)(1u << (rand_r(&seed) % 8));
        drv_frame_err fe = drv_video_decode(r.d, bad, m, r.dst, r.stride, err, sizeof err);
        tries++;
        if (fe != DRV_FRAME_OK) {
            assert_int_equal(fe, DRV_FRAME_ERR_BAD_FORMAT);
            refused++;
        }
    }
    fflush(stderr);
    dup2(saved_stderr, 2);
    close(saved_stderr);
    fseek(cap, 0, SEEK_END);
    long said = ftell(cap);
    fclose(cap);
    assert_int_equal(said, 0);
    printf("# %s: %d of %d damaged access units refused\n", drv_codec_name(c), refused, tries);
    assert_true(refused > 0);
    /* garbage that is no stream at all, and nothing */
    for (size_t i = 0; i < 4096; i++) bad[i] = (uint8_t)rand_r(&seed);
    assert_int_not_equal(drv_video_decode(r.d, bad, 4096, r.dst, r.stride, err, sizeof err), DRV_FRAME_OK);
    assert_int_equal(drv_video_decode(r.d, bad, 0, r.dst, r.stride, err, sizeof err), DRV_FRAME_ERR_TRUNCATED);
    drv_video_dec_reset(r.d);
    bool key;
    size_t n;
    assert_true(through(&r, 24, false, &n, &key, "key after the damage") > MIN_PSNR_SMALL_DB);
    assert_true(key);
    free(bad);
    rig_free(&r);
}

/* A stream of another size is BAD_SIZE; so is a stride narrower than the eye. */
static void test_wrong_size(void **state)
{
    drv_codec_id c = (drv_codec_id)(intptr_t)*state;
    if (!have(c)) skip();
    rig r;
    drv_video_params p = params(c, 80, 64);
    rig_open(&r, &p, 64, 48, NULL);
    char err[256] = "";
    bool key;
    size_t n = enc(&r, 0, false, &key);
    assert_int_equal(dec(&r, n, err, sizeof err), DRV_FRAME_ERR_BAD_SIZE);
    assert_non_null(strstr(err, "80x64"));
    drv_video_dec *d2 = drv_video_dec_create(c, 80, 64, NULL, err, sizeof err);
    assert_non_null(d2);
    assert_int_equal(drv_video_decode(d2, r.au, n, r.dst, 80 * 4 - 4, err, sizeof err), DRV_FRAME_ERR_BAD_SIZE);
    assert_int_equal(drv_video_decode(d2, r.au, n, r.dst, r.stride, err, sizeof err), DRV_FRAME_OK);
    /* an encoder refuses a stride narrower than its eye, and an output that cannot hold the access unit */
    assert_int_equal(drv_video_encode(r.e, r.src, 80 * 4 - 4, false, r.au, r.cap, &key, err, sizeof err), 0);
    assert_non_null(strstr(err, "stride"));
    assert_int_equal(drv_video_encode(r.e, r.src, r.stride, true, r.au, 16, &key, err, sizeof err), 0);
    assert_non_null(strstr(err, "room"));
    drv_video_dec_destroy(d2);
    rig_free(&r);
}

/* Intra refresh: a key frame first, then none, and no frame much bigger than the rest (the refresh is spread); a
 * forced key frame still works. */
static void test_intra_refresh(void **state)
{
    drv_codec_id c = (drv_codec_id)(intptr_t)*state;
    if (!have(c)) skip();
    rig r;
    drv_video_params p = params(c, 640, 320); /* x265 at smaller sizes (5 CTU columns) spends a big frame per period */
    p.refresh_frames = 8;
    rig_open(&r, &p, p.w, p.h, NULL);
    size_t first = 0, most = 0, least = SIZE_MAX;
    for (int t = 0; t < 24; t++) {
        bool key;
        size_t n;
        double db = through(&r, t, false, &n, &key, "intra refresh");
        assert_int_equal(key, t == 0);
        if (t == 0)
            first = n;
        else {
            if (n > most) most = n;
            if (n < least) least = n;
        }
        if (getenv("VIDEO_TEST_VERBOSE")) printf("#   refresh frame %d: %zu bytes %.1f dB\n", t, n, db);
        assert_true(db > MIN_PSNR_DB);
    }
    printf("# %s intra refresh: first %zu bytes, then %zu..%zu\n", drv_codec_name(c), first, least, most);
    assert_true(most < first); /* no second full key frame */
    assert_true(most < 4 * least);
    /* the board lost a reference: a forced key frame is an IDR here too, and a reset decoder resumes from it */
    drv_video_dec_reset(r.d);
    bool key;
    size_t n;
    assert_true(through(&r, 24, true, &n, &key, "forced key") > MIN_PSNR_DB);
    assert_true(key);
    through(&r, 25, false, &n, &key, "after the forced key");
    assert_false(key);
    rig_free(&r);
}

/* Parameters out of range are refused with the field named; v4l2m2m falls back to software with a note where the
 * board has no such device. */
static void test_params_and_hw(void **state)
{
    drv_codec_id c = (drv_codec_id)(intptr_t)*state;
    if (!have(c)) skip();
    char err[256];
    drv_video_params p = params(c, 64, 48);
    p.quality = 0;
    assert_null(drv_video_enc_create(&p, err, sizeof err));
    assert_non_null(strstr(err, "quality"));
    p = params(c, 1, 48);
    assert_null(drv_video_enc_create(&p, err, sizeof err));
    assert_non_null(strstr(err, "size"));
    p = params(c, 64, 48);
    p.fps = 0;
    assert_null(drv_video_enc_create(&p, err, sizeof err));
    assert_non_null(strstr(err, "fps"));
    p = params(DRV_CODEC_JPEG, 64, 48);
    assert_null(drv_video_enc_create(&p, err, sizeof err));
    assert_null(drv_video_dec_create(c, 64, 48, "cuda", err, sizeof err));
    assert_non_null(strstr(err, "cuda"));
    assert_null(drv_video_dec_create(DRV_CODEC_RAW, 64, 48, NULL, err, sizeof err));
    err[0] = 0;
    drv_video_dec *d = drv_video_dec_create(c, 64, 48, "v4l2m2m", err, sizeof err);
    assert_non_null(d);
    if (strcmp(drv_video_dec_name(d), "software") == 0) {
        assert_non_null(strstr(err, "using software"));
        printf("# %s\n", err);
    }
    drv_video_dec_destroy(d);
    /* CBR: a bit rate instead of a quality, access units near the budget of one frame */
    rig r;
    rig_init(&r, 320, 240);
    p = params(c, r.w, r.h);
    p.quality = 0;
    p.bitrate_kbps = 2000;
    if (!(r.e = drv_video_enc_create(&p, err, sizeof err))) fail_msg("%s", err);
    size_t total = 0;
    bool key;
    for (int t = 0; t < 20; t++) total += t ? enc(&r, t, false, &key) : (enc(&r, t, false, &key), 0);
    double per_frame = 2000e3 / 8 / p.fps;
    printf("# %s CBR 2000 kb/s: %.0f bytes a frame after the first (budget %.0f)\n", drv_codec_name(c), total / 19.0,
           per_frame);
    assert_true(total / 19.0 < 2.0 * per_frame);
    rig_free(&r);
    assert_false(drv_video_can_encode(DRV_CODEC_JPEG));
    assert_false(drv_video_can_decode(DRV_CODEC_RAW));
}

/* Decoding into an image with no slack (stride 4w, nothing after the last row) writes nothing past it and alpha 255
 * everywhere, at widths libswscale's fast path handles and at ones it does not (it overruns at 40, 44; alpha 0 at
 * the row ends of 36, 37, 52). */
static void test_no_overrun(void **state)
{
    drv_codec_id c = (drv_codec_id)(intptr_t)*state;
    if (!have(c)) skip();
    static const int widths[] = {32, 36, 37, 40, 44, 52, 64};
    enum { H = 18, CANARY = 256 };
    for (size_t i = 0; i < sizeof widths / sizeof widths[0]; i++) {
        int w = widths[i];
        rig r;
        drv_video_params p = params(c, w, H);
        rig_open(&r, &p, w, H, NULL);
        char err[256] = "";
        bool key;
        size_t n = enc(&r, 0, false, &key);
        size_t img = (size_t)w * 4 * H;
        uint8_t *tight = malloc(img + CANARY);
        assert_non_null(tight);
        memset(tight, 0, img);
        memset(tight + img, 0xA5, CANARY);
        if (drv_video_decode(r.d, r.au, n, tight, (size_t)w * 4, err, sizeof err) != DRV_FRAME_OK) fail_msg("%s", err);
        for (size_t k = 0; k < CANARY; k++)
            if (tight[img + k] != 0xA5) fail_msg("width %d: byte %zu past the image written", w, k);
        for (size_t k = 3; k < img; k += 4)
            if (tight[k] != 255) fail_msg("width %d: alpha %u at pixel %zu", w, tight[k], k / 4);
        free(tight);
        rig_free(&r);
    }
}

/* Each test once per codec, named so (TAP lines tell H.264 from HEVC). */
#define PER_CODEC(fn)                                                                                               \
    {#fn " h264", fn, NULL, NULL, (void *)(intptr_t)DRV_CODEC_H264},                                                \
        {#fn " hevc", fn, NULL, NULL, (void *)(intptr_t)DRV_CODEC_HEVC}

int main(void)
{
    const struct CMUnitTest tests[] = {
        PER_CODEC(test_roundtrip),     PER_CODEC(test_keys_and_loss), PER_CODEC(test_damage),
        PER_CODEC(test_wrong_size),    PER_CODEC(test_intra_refresh), PER_CODEC(test_params_and_hw),
        PER_CODEC(test_no_overrun),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
