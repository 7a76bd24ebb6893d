/* SPDX-License-Identifier: MIT */
/* framelink v2 end to end: libhmdwarp-host compresses (hmdwarp_host_set_codec) and the board's socket backend
 * decodes and counts (compressed frames, wire and plane bytes, decode time); a corrupt JPEG is rejected for its
 * reason and counted while the last good frame stays; a lost video reference makes the board ask for a key frame
 * (WANT_KEY in its pose messages) and the host send one; [frames] codecs is parsed naming what is wrong. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>
#include <cmocka.h>

#include "drivers/drv_codec.h"
#include "drivers/drv_codec_video.h"
#include "drivers/drv_framelink.h"
#include "drivers/drv_framelink_codec.h"
#include "drivers/drv_frames_socket.h"
#include "host/hmdwarp-host.h"
#include "platform/plat_clock.h"
#include "runtime/rt_config.h"
#include "warp/warp_head.h"
#include "tests/support/test_util.h"

#define W 64
#define H 48
#define PLANES (DRV_PLANE_COLOR | DRV_PLANE_DEPTH)
#define NEAR_Z 0.05
#define WAIT_S 20 /* a hang guard only (a loaded machine): every wait ends on a count */

static char path[100], uri[120];

static bool predict(void *ctx, int64_t t_ns, warp_pose *head)
{
    (void)ctx, (void)t_ns;
    warp_head h = warp_head_default();
    *head = warp_head_pose_from_orientation(&h, warp_quat_identity());
    return true;
}

/* The board: the socket backend (the USB board side's receive machine) and the frame it receives into. */
typedef struct {
    drv_frames *fr;
    drv_frame f;
    hmdwarp_host *h;
} rig;

static drv_frames_usb_stats stats(rig *rg)
{
    drv_frames_usb_stats st;
    drv_frames_usb_stats_get(rg->fr, &st);
    return st;
}

/* Receives until a frame or a rejection (1 or -err); 0 only after WAIT_S. */
static int pump_until_result(rig *rg)
{
    int64_t until = plat_now_ns() + WAIT_S * PLAT_NS_PER_S;
    int rc = 0;
    while (rc == 0 && plat_now_ns() < until) rc = drv_frames_receive(rg->fr, &rg->f, 20);
    return rc;
}

/* The board side's parameters: W x H eyes of PLANES, poses from predict (no cameras, no decoder settings). */
static drv_frames_usb_params board_params(void)
{
    drv_frames_usb_params p;
    memset(&p, 0, sizeof p);
    p.max_frame_bytes = 1u << 20;
    p.eye_w = W, p.eye_h = H;
    p.planes = PLANES;
    p.poses.predict = predict;
    p.pose_rate_hz = 200;
    return p;
}

static void rig_start(rig *rg)
{
    drv_frames_usb_params p = board_params();
    for (int e = 0; e < 2; e++) p.cam[e] = warp_camera_symmetric(W, H, 100, 90, NEAR_Z, INFINITY);
    p.refresh_hz = 90;
    p.depth_encoding = WARP_DEPTH_LINEAR;
    p.decode_threads = 2;
    char err[300] = "";
    rg->fr = drv_frames_socket_create(&p, path, err, sizeof err);
    if (!rg->fr) print_error("%s\n", err);
    assert_non_null(rg->fr);
    assert_true(drv_frame_alloc(&rg->f, W, H, PLANES, 0));
    /* the host connects (the listen backlog takes it); the board accepts it while receiving and greets it */
    rg->h = hmdwarp_host_open(uri);
    if (!rg->h) print_error("%s\n", hmdwarp_host_last_error());
    assert_non_null(rg->h);
    hmdwarp_host_cameras c;
    int64_t until = plat_now_ns() + WAIT_S * PLAT_NS_PER_S;
    while (hmdwarp_host_get_cameras(rg->h, &c) != 1 && plat_now_ns() < until)
        assert_int_equal(drv_frames_receive(rg->fr, &rg->f, 20), 0);
    assert_int_equal(hmdwarp_host_get_cameras(rg->h, &c), 1);
}

static void rig_stop(rig *rg)
{
    hmdwarp_host_close(rg->h);
    if (rg->fr) drv_frames_destroy(rg->fr);
    drv_frame_free(&rg->f);
    memset(rg, 0, sizeof *rg);
}

/* Each test's rig: stopped by the teardown too, so a failed assertion leaves no board listening for the next. */
static rig r;
static int rig_teardown(void **state)
{
    (void)state;
    rig_stop(&r);
    return 0;
}

/* A smooth picture (JPEG keeps it within a few levels) and depth from 0.5 to about 3.3 m, shifted by k. */
static uint8_t color[2][H][W][4];
static float depth[2][H][W];

static hmdwarp_host_frame make_frame(int k)
{
    hmdwarp_host_frame fr;
    memset(&fr, 0, sizeof fr);
    fr.color_format = HMDWARP_HOST_COLOR_RGBA8;
    fr.depth_format = HMDWARP_HOST_DEPTH_LINEAR_F32;
    for (int e = 0; e < 2; e++) {
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                color[e][y][x][0] = (uint8_t)(x * 3 + k);
                color[e][y][x][1] = (uint8_t)(y * 4 + e * 20);
                color[e][y][x][2] = (uint8_t)(128 + k);
                color[e][y][x][3] = 255;
                depth[e][y][x] = 0.5f + 0.03f * (float)(x + y) + 0.01f * (float)k;
            }
        fr.eye[e].color = color[e];
        fr.eye[e].depth = depth[e];
        fr.eye[e].pose.orientation[0] = 1;
    }
    return fr;
}

/* The frame received is the one sent: colour within JPEG's error, depth within INV16's steps. */
static void assert_close(const drv_frame *f, int k)
{
    (void)make_frame(k);
    double diff = 0, worst_z = 0;
    for (int e = 0; e < 2; e++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                warp_rgba8 p = f->color[e].px[y * f->color[e].stride + x];
                diff += fabs((double)p.r - color[e][y][x][0]) + fabs((double)p.g - color[e][y][x][1]) +
                        fabs((double)p.b - color[e][y][x][2]);
                assert_int_equal(p.a, 255);
                double z = f->depth[e].px[y * f->depth[e].stride + x], want = depth[e][y][x];
                worst_z = fmax(worst_z, fabs(z - want) / want);
            }
    diff /= 2.0 * W * H * 3;
    if (diff > 4 || worst_z > 2e-3) fail_msg("colour off by %.2f levels on average, depth by %.2g relative", diff,
                                             worst_z);
}

/* Whether this build's framelink encoder takes the parameters (false, printing why, while the v2 codecs are not
 * built): the compressed tests need them. */
static bool codec_built(const drv_framelink_enc_params *p)
{
    char why[200];
    if (drv_framelink_enc_params_check(p, why, sizeof why)) return true;
    print_message("skipped: the framelink encoder refuses these codecs here: %s\n", why);
    return false;
}

static void test_compressed_frames_counted(void **state)
{
    (void)state;
    drv_framelink_enc_params p = drv_framelink_enc_params_raw();
    p.color = DRV_CODEC_JPEG, p.slices = 2, p.depth = DRV_CODEC_ZSTD, p.depth_format = DRV_FRAMELINK_FMT_INV16;
    if (!codec_built(&p)) skip();
    rig_start(&r);
    hmdwarp_host_codec_options o;
    hmdwarp_host_codec_defaults(&o);
    o.color = HMDWARP_HOST_CODEC_JPEG, o.quality = 90, o.slices = 2;
    o.depth = HMDWARP_HOST_CODEC_ZSTD, o.depth_format = HMDWARP_HOST_WIRE_DEPTH_INV16;
    assert_int_equal(hmdwarp_host_set_codec(r.h, &o), HMDWARP_HOST_OK);
    enum { N = 4 };
    for (int k = 0; k < N; k++) {
        hmdwarp_host_frame fr = make_frame(k);
        if (hmdwarp_host_submit(r.h, &fr) != HMDWARP_HOST_OK) fail_msg("submit: %s", hmdwarp_host_last_error());
        assert_int_equal(pump_until_result(&r), 1);
        assert_close(&r.f, k);
    }
    drv_frames_usb_stats st = stats(&r);
    assert_int_equal(st.frames, N);
    assert_int_equal(st.dec.compressed_frames, N);
    assert_int_equal(st.dec.codec_errors, 0);
    assert_true(st.dec.codecs_seen & DRV_CODEC_BIT(DRV_CODEC_JPEG));
    assert_true(st.dec.codecs_seen & DRV_CODEC_BIT(DRV_CODEC_ZSTD));
    /* what came on the wire is what the host sent, and less than the planes it decoded to */
    hmdwarp_host_codec_stats cs;
    assert_int_equal(hmdwarp_host_get_codec_stats(r.h, &cs), HMDWARP_HOST_OK);
    assert_int_equal(cs.frames, N);
    assert_int_equal(cs.compressed_frames, N);
    assert_int_equal(cs.color, HMDWARP_HOST_CODEC_JPEG);
    assert_int_equal(cs.depth, HMDWARP_HOST_CODEC_ZSTD);
    assert_int_equal(st.dec.wire_bytes, cs.wire_bytes);
    assert_true(st.dec.wire_bytes < st.dec.plane_bytes);
    assert_true(cs.wire_bytes < cs.plane_bytes);
    assert_true(st.dec.decode_ms_last > 0 && cs.encode_ms_last > 0);
    assert_true(drv_frames_usb_decode_ms(r.fr) > 0);
    rig_stop(&r);
}

/* A handle starts on auto: with no set_codec its frames use what the board announced (JPEG colour, zstd depth). */
static void test_auto_is_negotiated(void **state)
{
    (void)state;
    rig_start(&r);
    hmdwarp_host_frame fr = make_frame(1);
    assert_int_equal(hmdwarp_host_submit(r.h, &fr), HMDWARP_HOST_OK);
    assert_int_equal(pump_until_result(&r), 1);
    assert_close(&r.f, 1);
    drv_frames_usb_stats st = stats(&r);
    assert_int_equal(st.frames, 1);
    assert_int_equal(st.dec.compressed_frames, 1);
    assert_true(st.dec.codecs_seen & DRV_CODEC_BIT(DRV_CODEC_JPEG));
    assert_true(st.dec.codecs_seen & DRV_CODEC_BIT(DRV_CODEC_ZSTD));
    rig_stop(&r);
}

/* Raw frames (set_codec(NULL)) are version 1 and go through the same decoder uncompressed. */
static void test_raw_frames_through_the_decoder(void **state)
{
    (void)state;
    rig_start(&r);
    hmdwarp_host_frame fr = make_frame(1);
    assert_int_equal(hmdwarp_host_set_codec(r.h, NULL), HMDWARP_HOST_OK);
    assert_int_equal(hmdwarp_host_submit(r.h, &fr), HMDWARP_HOST_OK);
    assert_int_equal(pump_until_result(&r), 1);
    assert_int_equal(hmdwarp_host_submit(r.h, &fr), HMDWARP_HOST_OK);
    assert_int_equal(pump_until_result(&r), 1);
    for (int e = 0; e < 2; e++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                assert_memory_equal(&r.f.color[e].px[y * r.f.color[e].stride + x], color[e][y][x], 4);
                assert_true(r.f.depth[e].px[y * r.f.depth[e].stride + x] == depth[e][y][x]);
            }
    drv_frames_usb_stats st = stats(&r);
    assert_int_equal(st.frames, 2);
    assert_int_equal(st.dec.compressed_frames, 0);
    assert_int_equal(st.dec.codec_errors, 0);
    /* raw: nothing saved, the wire carries the pixels and the headers */
    assert_true(st.dec.wire_bytes >= st.dec.plane_bytes && st.dec.wire_bytes - st.dec.plane_bytes < 2 * 1024);
    assert_true(st.codecs & DRV_CODEC_BIT(DRV_CODEC_RAW));
    hmdwarp_host_codec_stats cs;
    assert_int_equal(hmdwarp_host_get_codec_stats(r.h, &cs), HMDWARP_HOST_OK);
    assert_int_equal(cs.frames, 2);
    assert_int_equal(cs.compressed_frames, 0);
    assert_int_equal(cs.color, HMDWARP_HOST_CODEC_RAW);
    assert_int_equal(cs.wire_bytes, st.dec.wire_bytes);
    rig_stop(&r);
}

static uint32_t get_u32(const uint8_t *p) { return p[0] | p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24; }
static void put_u32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++) p[i] = (uint8_t)(v >> (8 * i));
}

static uint8_t wire[1 << 20];

static void test_corrupt_jpeg_rejected_last_frame_stays(void **state)
{
    (void)state;
    drv_framelink_enc_params p = drv_framelink_enc_params_raw();
    p.color = DRV_CODEC_JPEG;
    if (!codec_built(&p)) skip();
    rig_start(&r);
    hmdwarp_host_codec_options o;
    hmdwarp_host_codec_defaults(&o);
    o.color = HMDWARP_HOST_CODEC_JPEG, o.slices = 1, o.depth = o.other = HMDWARP_HOST_CODEC_RAW;
    assert_int_equal(hmdwarp_host_set_codec(r.h, &o), HMDWARP_HOST_OK);
    hmdwarp_host_frame good = make_frame(2);
    assert_int_equal(hmdwarp_host_submit(r.h, &good), HMDWARP_HOST_OK);
    assert_int_equal(pump_until_result(&r), 1);
    uint64_t kept_seq = r.f.seq;

    /* The next frame's first JPEG loses its start-of-image marker; the CRCs are made right again, so only the
     * JPEG decoder can tell. The colour plane comes first: its chunk table (2 lengths), then eye 0's JPEG. */
    hmdwarp_host_frame bad = make_frame(9);
    int64_t n = hmdwarp_host_encode(r.h, &bad, wire, sizeof wire);
    assert_true(n > 0);
    size_t hdr = (size_t)wire[6] | (size_t)wire[7] << 8;
    size_t n_planes = (size_t)wire[76] | (size_t)wire[77] << 8;
    const uint8_t *desc = wire + hdr - 4 - n_planes * DRV_FRAMELINK_PLANE_DESC_BYTES;
    assert_int_equal(desc[0], 0);                /* colour */
    assert_int_equal(desc[12], DRV_CODEC_JPEG);  /* its codec byte */
    uint8_t *jpeg = wire + hdr + get_u32(desc + 4) + 8;
    assert_true(jpeg[0] == 0xff && jpeg[1] == 0xd8);
    jpeg[0] = jpeg[1] = 0;
    put_u32(wire + n - 4, (uint32_t)crc32_z(0, wire + hdr, (size_t)n - hdr - 4));
    assert_int_equal(hmdwarp_host_send_raw(r.h, wire, (size_t)n), HMDWARP_HOST_OK);
    int rc = pump_until_result(&r);
    assert_true(rc < 0);
    assert_true(-rc == DRV_FRAME_ERR_BAD_FORMAT || -rc == DRV_FRAME_ERR_BAD_SIZE);
    drv_frames_usb_stats st = stats(&r);
    assert_int_equal(st.dec.codec_errors, 1);
    assert_int_equal(st.rejected[-rc], 1);
    assert_int_equal(st.frames, 1);
    /* a rejected frame is never handed on as one: its header fields stay the last good frame's (the runtime
     * decodes into a back slot it does not publish, so the display keeps warping the last good frame) */
    assert_int_equal(r.f.seq, kept_seq);
    char why[200];
    drv_frames_last_error(r.fr, why, sizeof why);
    assert_non_null(strstr(why, "rejected"));
    /* and the next good frame is taken */
    assert_int_equal(hmdwarp_host_submit(r.h, &good), HMDWARP_HOST_OK);
    assert_int_equal(pump_until_result(&r), 1);
    rig_stop(&r);
}

static void test_lost_reference_asks_for_a_key_frame(void **state)
{
    (void)state;
    if (!drv_video_can_encode(DRV_CODEC_H264) || !drv_video_can_decode(DRV_CODEC_H264)) {
        print_message("skipped: this machine's libavcodec cannot %s H.264\n",
                      drv_video_can_encode(DRV_CODEC_H264) ? "decode" : "encode");
        skip();
    }
    drv_framelink_enc_params p = drv_framelink_enc_params_raw();
    p.color = DRV_CODEC_H264, p.quality = 23;
    if (!codec_built(&p)) skip();
    rig_start(&r);
    hmdwarp_host_codec_options o;
    hmdwarp_host_codec_defaults(&o);
    o.color = HMDWARP_HOST_CODEC_H264, o.depth = o.other = HMDWARP_HOST_CODEC_RAW;
    assert_int_equal(hmdwarp_host_set_codec(r.h, &o), HMDWARP_HOST_OK);
    hmdwarp_host_frame fr = make_frame(0);
    assert_int_equal(hmdwarp_host_submit(r.h, &fr), HMDWARP_HOST_OK); /* the stream's key frame */
    assert_int_equal(pump_until_result(&r), 1);
    /* a frame of the stream is lost on the way: the next one refers to it */
    assert_true(hmdwarp_host_encode(r.h, &fr, wire, sizeof wire) > 0);
    assert_int_equal(hmdwarp_host_submit(r.h, &fr), HMDWARP_HOST_OK);
    assert_true(pump_until_result(&r) < 0);
    drv_frames_usb_stats st = stats(&r);
    assert_int_equal(st.dec.codec_errors, 1);
    assert_true(st.dec.key_requests >= 1);
    /* the pose thread's next messages carry WANT_KEY; the host's reader sees them */
    hmdwarp_host_codec_stats cs = {0};
    int64_t until = plat_now_ns() + WAIT_S * PLAT_NS_PER_S;
    while (cs.key_requests == 0 && plat_now_ns() < until) {
        assert_int_equal(drv_frames_receive(r.fr, &r.f, 10), 0);
        hmdwarp_host_get_codec_stats(r.h, &cs);
    }
    assert_true(cs.key_requests >= 1);
    /* so the next frame is a key frame, which decodes */
    assert_int_equal(hmdwarp_host_submit(r.h, &fr), HMDWARP_HOST_OK);
    assert_int_equal(pump_until_result(&r), 1);
    assert_int_equal(hmdwarp_host_get_codec_stats(r.h, &cs), HMDWARP_HOST_OK);
    assert_true(cs.key_frames >= 1);
    st = stats(&r);
    assert_int_equal(st.frames, 2);
    rig_stop(&r);
}

/* The codec names and the first codec lacking, as the config's, the host library's and the summary's messages and
 * the encoder's and the board's checks take them: id order, the separator given, cut to the buffer. */
static void test_codec_names(void **state)
{
    (void)state;
    const unsigned raw = DRV_CODEC_BIT(DRV_CODEC_RAW), zstd = DRV_CODEC_BIT(DRV_CODEC_ZSTD);
    const unsigned jpeg = DRV_CODEC_BIT(DRV_CODEC_JPEG), hevc = DRV_CODEC_BIT(DRV_CODEC_HEVC);
    char b[64];
    assert_string_equal(drv_codec_names(DRV_CODEC_ALL, ", ", b, sizeof b), "raw, zstd, jpeg, h264, hevc");
    assert_string_equal(drv_codec_names(hevc | jpeg | raw | 0x100u, " ", b, sizeof b), "raw jpeg hevc");
    assert_string_equal(drv_codec_names(0, " ", b, sizeof b), "");
    char small[8];
    assert_string_equal(drv_codec_names(DRV_CODEC_ALL, " ", small, sizeof small), "raw zst");
    assert_int_equal(drv_codec_missing(DRV_CODEC_ALL, raw | zstd), DRV_CODEC_JPEG);
    assert_int_equal(drv_codec_missing(hevc | raw, raw | zstd), DRV_CODEC_HEVC);
    assert_int_equal(drv_codec_missing(jpeg | raw, DRV_CODEC_ALL), DRV_CODEC_COUNT);
    assert_int_equal(drv_codec_missing(raw | 0x100u, raw), DRV_CODEC_COUNT); /* no codec's bit: none lacking */
}

/* decode_threads and video_decoder: a board config takes exactly what the USB board side does (its one rule), and
 * the board side refuses the rest itself when made without a config (tests, the fuzzer). */
static void test_decoder_settings(void **state)
{
    (void)state;
    drv_frames_usb_params p = board_params();
    char err[300] = "", ini[160];
    p.decode_threads = DRV_FRAMES_USB_DECODE_THREADS_MAX + 1;
    assert_null(drv_frames_usb_create_fed(&p, err, sizeof err));
    assert_non_null(strstr(err, "decode_threads"));
    p.decode_threads = 0;
    p.video_decoder = "vaapi";
    assert_null(drv_frames_usb_create_fed(&p, err, sizeof err));
    assert_non_null(strstr(err, "'vaapi'"));
    rt_config cfg;
    rt_config_defaults(&cfg);
    rt_config_errors cerr = {0};
    snprintf(ini, sizeof ini, "[frames]\ndecode_threads = %d\n", DRV_FRAMES_USB_DECODE_THREADS_MAX + 1);
    assert_false(rt_config_load_string(&cfg, ini, "t.ini", &cerr));
    for (int v = 0; drv_frames_usb_video_decoders[v]; v++) {
        rt_config_defaults(&cfg);
        cerr.count = 0;
        snprintf(ini, sizeof ini, "[frames]\nvideo_decoder = %s\ndecode_threads = %d\n",
                 drv_frames_usb_video_decoders[v], DRV_FRAMES_USB_DECODE_THREADS_MAX);
        assert_true(rt_config_load_string(&cfg, ini, "t.ini", &cerr));
        p.video_decoder = cfg.video_decoder;
        p.decode_threads = cfg.decode_threads;
        drv_frames *fr = drv_frames_usb_create_fed(&p, err, sizeof err);
        if (!fr) fail_msg("video_decoder %s: %s", cfg.video_decoder, err);
        drv_frames_destroy(fr);
    }
}

static void test_config_codecs(void **state)
{
    (void)state;
    unsigned m = 0;
    char why[200];
    assert_true(rt_config_parse_codecs("auto", &m, why, sizeof why));
    assert_int_equal(m, drv_codec_decodable());
    assert_true(rt_config_parse_codecs("raw", &m, why, sizeof why));
    assert_int_equal(m, DRV_CODEC_BIT(DRV_CODEC_RAW));
    assert_true(rt_config_parse_codecs("zstd, jpeg", &m, why, sizeof why));
    assert_int_equal(m, DRV_CODEC_BIT(DRV_CODEC_RAW) | DRV_CODEC_BIT(DRV_CODEC_ZSTD) | DRV_CODEC_BIT(DRV_CODEC_JPEG));
    assert_false(rt_config_parse_codecs("jpeg,vp9", &m, why, sizeof why));
    assert_non_null(strstr(why, "'vp9'"));
    assert_false(rt_config_parse_codecs("", &m, why, sizeof why));
    for (int c = 0; c < DRV_CODEC_COUNT; c++)
        if (!(drv_codec_decodable() & DRV_CODEC_BIT(c))) {
            assert_false(rt_config_parse_codecs(drv_codec_name((drv_codec_id)c), &m, why, sizeof why));
            assert_non_null(strstr(why, drv_codec_name((drv_codec_id)c)));
        }
    /* and in a board.ini, with the line */
    rt_config cfg;
    rt_config_defaults(&cfg);
    rt_config_errors err = {0};
    assert_true(rt_config_load_string(&cfg, "[frames]\ncodecs = raw, mpeg2\ndecode_threads = 4\n", "t.ini", &err));
    assert_int_equal(cfg.decode_threads, 4);
    assert_false(rt_config_validate(&cfg, &err));
    assert_non_null(strstr(err.msg[0], "mpeg2"));
    assert_non_null(strstr(err.msg[0], "[frames] codecs (t.ini:2)"));
    rt_config_defaults(&cfg);
    err.count = 0;
    assert_false(rt_config_load_string(&cfg, "[frames]\ndecode_threads = 9\nvideo_decoder = vaapi\n", "t.ini", &err));
    assert_int_equal(err.count, 2);
    /* what the board announces: auto is every decodable codec on USB and on a socket limited by link_mbps, raw
     * alone on an unlimited socket; a list is taken as written on any link */
    rt_config_defaults(&cfg);
    snprintf(cfg.frames_backend, sizeof cfg.frames_backend, "usb");
    assert_true(rt_config_frames_codecs(&cfg, &m, why, sizeof why));
    assert_int_equal(m, drv_codec_decodable());
    snprintf(cfg.frames_backend, sizeof cfg.frames_backend, "socket");
    assert_true(rt_config_frames_codecs(&cfg, &m, why, sizeof why));
    assert_int_equal(m, DRV_CODEC_BIT(DRV_CODEC_RAW));
    cfg.link_mbps = 35;
    assert_true(rt_config_frames_codecs(&cfg, &m, why, sizeof why));
    assert_int_equal(m, drv_codec_decodable());
    snprintf(cfg.frames_backend, sizeof cfg.frames_backend, "usb");
    snprintf(cfg.frames_device, sizeof cfg.frames_device, "mock");
    assert_true(rt_config_frames_codecs(&cfg, &m, why, sizeof why));
    assert_int_equal(m, drv_codec_decodable());
    cfg.link_mbps = 0;
    assert_true(rt_config_frames_codecs(&cfg, &m, why, sizeof why));
    assert_int_equal(m, DRV_CODEC_BIT(DRV_CODEC_RAW));
    cfg.link_mbps = 0;
    snprintf(cfg.frames_codecs, sizeof cfg.frames_codecs, "jpeg");
    assert_true(rt_config_frames_codecs(&cfg, &m, why, sizeof why));
    assert_int_equal(m, DRV_CODEC_BIT(DRV_CODEC_RAW) | DRV_CODEC_BIT(DRV_CODEC_JPEG));
}

static int setup(void **state)
{
    if (test_tmp_setup(state)) return -1;
    snprintf(path, sizeof path, "%s/frames.sock", test_tmp());
    snprintf(uri, sizeof uri, "socket:%s", path);
    return 0;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_auto_is_negotiated, rig_teardown),
        cmocka_unit_test_teardown(test_raw_frames_through_the_decoder, rig_teardown),
        cmocka_unit_test_teardown(test_compressed_frames_counted, rig_teardown),
        cmocka_unit_test_teardown(test_corrupt_jpeg_rejected_last_frame_stays, rig_teardown),
        cmocka_unit_test_teardown(test_lost_reference_asks_for_a_key_frame, rig_teardown),
        cmocka_unit_test(test_config_codecs),
        cmocka_unit_test(test_codec_names),
        cmocka_unit_test(test_decoder_settings),
    };
    return cmocka_run_group_tests(tests, setup, test_tmp_teardown);
}
