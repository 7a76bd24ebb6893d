/* SPDX-License-Identifier: MIT */
/* Unit tests for drv_framelink: bit-exact round trips of every plane combination, each rejection with its named
 * error, header peeking on partial streams, fixed-seed corruption fuzzing, and the board -> host pose and camera messages. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>
#include <cmocka.h>

#include "drivers/drv_framelink.h"
#include "tests/support/test_util.h"

#define W 13
#define H 7
#define MAX_LAYERS 3
#define ALL 0x1Fu
#define OFF_W_EYE1 (88 + 112 + 56) /* eye 1 camera width in the fixed header */

static float rand_f32(test_rng *r, float lo, float hi) { return (float)test_rng_uniform(r, lo, hi); }

static warp_pose rand_pose(test_rng *r)
{
    warp_pose p = {test_random_quat(r), warp_v3(test_rng_uniform(r, -2, 2), test_rng_uniform(r, -2, 2),
                                                test_rng_uniform(r, -2, 2))};
    return p;
}

/* A frame of random content with the given planes; depth in [0,1] for window encodings, metres (and sky) for
 * linear. */
static void make_frame(drv_frame *f, unsigned planes, warp_depth_encoding enc, int n_obj, uint64_t seed)
{
    test_rng r = test_rng_make(seed);
    assert_true(drv_frame_alloc(f, W, H, planes, MAX_LAYERS));
    f->planes = planes;
    f->seq = 1000 + seed;
    f->pose_t_ns = 123456789012345 + (int64_t)seed;
    f->depth_encoding = enc;
    f->scene_time = 1.25;
    f->n_objects = n_obj;
    for (int i = 0; i < n_obj; i++) f->object_pose[i] = rand_pose(&r);
    for (int e = 0; e < 2; e++) {
        f->cam[e] = warp_camera_symmetric(W, H, 90 + e, 80, 0.05, e ? INFINITY : 100.0);
        f->eye_pose[e] = rand_pose(&r);
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                if (planes & DRV_PLANE_COLOR) {
                    uint64_t v = test_rng_next(&r);
                    WARP_AT(&f->color[e], x, y) = (warp_rgba8){(uint8_t)v, (uint8_t)(v >> 8), (uint8_t)(v >> 16),
                                                               (uint8_t)(v >> 24)};
                }
                if (planes & DRV_PLANE_DEPTH)
                    WARP_AT(&f->depth[e], x, y) = enc == WARP_DEPTH_LINEAR
                                                      ? ((x + y) % 5 ? rand_f32(&r, 0.05f, 50.0f) : INFINITY)
                                                      : rand_f32(&r, 0.0f, 1.0f);
                if (planes & DRV_PLANE_IDS) WARP_AT(&f->ids[e], x, y) = (uint16_t)test_rng_next(&r);
                if (planes & DRV_PLANE_MOTION)
                    WARP_AT(&f->motion[e], x, y) = (warp_vec2f){rand_f32(&r, -500, 500), rand_f32(&r, -500, 500)};
            }
        if (planes & DRV_PLANE_LAYERS) {
            warp_image_layers *l = &f->layers[e];
            for (int i = 0; i < W * H; i++) {
                l->count[i] = (uint8_t)(test_rng_next(&r) % (MAX_LAYERS + 1));
                for (int k = 0; k < l->count[i]; k++) {
                    warp_fragment *fr = &l->frag[i * MAX_LAYERS + k];
                    uint64_t v = test_rng_next(&r);
                    fr->z = rand_f32(&r, 0.1f, 10.0f);
                    fr->rgba = (warp_rgba8){(uint8_t)v, (uint8_t)(v >> 8), (uint8_t)(v >> 16), (uint8_t)(v >> 24)};
                    fr->id = (uint16_t)(v >> 32);
                }
            }
        }
    }
}

static uint8_t *encode_new(const drv_frame *f, const drv_framelink_tx *tx, size_t *n)
{
    *n = drv_framelink_size_ex(f, tx);
    assert_true(*n > 0);
    uint8_t *buf = malloc(*n);
    assert_non_null(buf);
    assert_int_equal(drv_framelink_encode_ex(f, tx, buf, *n), *n);
    return buf;
}

static bool same_f32(float a, float b) { return memcmp(&a, &b, sizeof a) == 0; }

static void assert_same_pose(warp_pose a, warp_pose b)
{
    assert_memory_equal(&a, &b, sizeof a);
}

/* b decoded from a: everything equal, depth within unorm16 quantisation when quantised. */
static void assert_frames_equal(const drv_frame *a, const drv_frame *b, bool unorm16)
{
    assert_int_equal(a->planes, b->planes);
    assert_int_equal(a->seq, b->seq);
    assert_int_equal(a->pose_t_ns, b->pose_t_ns);
    assert_int_equal(a->depth_encoding, b->depth_encoding);
    assert_int_equal(a->n_objects, b->n_objects);
    assert_true(a->scene_time == b->scene_time);
    for (int i = 0; i < a->n_objects; i++) assert_same_pose(a->object_pose[i], b->object_pose[i]);
    for (int e = 0; e < 2; e++) {
        assert_same_pose(a->eye_pose[e], b->eye_pose[e]);
        assert_memory_equal(&a->cam[e], &b->cam[e], sizeof a->cam[e]);
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                if (a->planes & DRV_PLANE_COLOR)
                    assert_memory_equal(&WARP_AT(&a->color[e], x, y), &WARP_AT(&b->color[e], x, y), 4);
                if (a->planes & DRV_PLANE_DEPTH) {
                    float da = WARP_AT(&a->depth[e], x, y), db = WARP_AT(&b->depth[e], x, y);
                    if (unorm16)
                        assert_true(fabsf(da - db) <= 0.5f / 65535.0f + 1e-7f);
                    else
                        assert_true(same_f32(da, db));
                }
                if (a->planes & DRV_PLANE_IDS) assert_int_equal(WARP_AT(&a->ids[e], x, y), WARP_AT(&b->ids[e], x, y));
                if (a->planes & DRV_PLANE_MOTION) {
                    assert_true(same_f32(WARP_AT(&a->motion[e], x, y).x, WARP_AT(&b->motion[e], x, y).x));
                    assert_true(same_f32(WARP_AT(&a->motion[e], x, y).y, WARP_AT(&b->motion[e], x, y).y));
                }
            }
        if (a->planes & DRV_PLANE_LAYERS) {
            for (int i = 0; i < W * H; i++) {
                assert_int_equal(a->layers[e].count[i], b->layers[e].count[i]);
                for (int k = 0; k < a->layers[e].count[i]; k++) {
                    const warp_fragment *fa = &a->layers[e].frag[i * MAX_LAYERS + k];
                    const warp_fragment *fb = &b->layers[e].frag[i * MAX_LAYERS + k];
                    assert_true(same_f32(fa->z, fb->z));
                    assert_memory_equal(&fa->rgba, &fb->rgba, 4);
                    assert_int_equal(fa->id, fb->id);
                }
            }
        }
    }
}

static void test_round_trip_all_planes(void **state)
{
    (void)state;
    int combos = 0;
    for (unsigned planes = 1; planes <= ALL; planes++) {
        if (!(planes & DRV_PLANE_COLOR)) continue;
        for (int enc = 0; enc < 3; enc++) {
            drv_frame a, b;
            make_frame(&a, planes, (warp_depth_encoding)enc, (int)planes % 4, planes * 7 + (unsigned)enc);
            drv_framelink_tx tx = {.pose_sent_ns = 5000, .host_pose_rx_ns = 900, .host_render_start_ns = 1000,
                                   .host_render_end_ns = 1500, .host_send_ns = 1600};
            size_t n;
            uint8_t *buf = encode_new(&a, &tx, &n);
            size_t total = 0;
            assert_int_equal(drv_framelink_peek(buf, n, n, &total), DRV_FRAME_OK);
            assert_int_equal(total, n);
            assert_true(drv_frame_alloc(&b, W, H, ALL, MAX_LAYERS));
            drv_framelink_rx rx;
            char detail[160];
            assert_int_equal(drv_framelink_decode_ex(buf, n, n, &b, &rx, detail, sizeof detail), DRV_FRAME_OK);
            assert_frames_equal(&a, &b, false);
            assert_int_equal(drv_frame_validate(&b), DRV_FRAME_OK);
            assert_int_equal(rx.total_bytes, n);
            assert_int_equal(rx.tx.host_render_end_ns, 1500);
            assert_int_equal(rx.tx.host_send_ns, 1600);
            /* Host render start on the board clock: pose sent at 5000, host started 100 ns after receiving it. */
            assert_int_equal(b.render_start_ns, 5100);
            free(buf);
            drv_frame_free(&a);
            drv_frame_free(&b);
            combos++;
        }
    }
    assert_int_equal(combos, 16 * 3);
}

static void test_round_trip_unorm16(void **state)
{
    (void)state;
    for (int enc = WARP_DEPTH_STANDARD; enc <= WARP_DEPTH_REVERSED; enc++) {
        drv_frame a, b;
        make_frame(&a, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, (warp_depth_encoding)enc, 0, 77);
        drv_framelink_tx tx = {.depth_format = DRV_FRAMELINK_FMT_UNORM16};
        size_t n;
        uint8_t *buf = encode_new(&a, &tx, &n);
        /* Half the depth bytes of f32. */
        assert_int_equal(n + 2 * W * H * 2, drv_framelink_size(&a));
        assert_true(drv_frame_alloc(&b, W, H, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, 0));
        drv_framelink_rx rx;
        assert_int_equal(drv_framelink_decode_ex(buf, n, 0, &b, &rx, NULL, 0), DRV_FRAME_OK);
        assert_int_equal(rx.tx.depth_format, DRV_FRAMELINK_FMT_UNORM16);
        assert_frames_equal(&a, &b, true);
        assert_int_equal(b.render_start_ns, 0); /* no host timing sent */
        free(buf);
        drv_frame_free(&a);
        drv_frame_free(&b);
    }
    /* Metres do not fit unorm16. */
    drv_frame a;
    make_frame(&a, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, WARP_DEPTH_LINEAR, 0, 78);
    drv_framelink_tx tx = {.depth_format = DRV_FRAMELINK_FMT_UNORM16};
    assert_int_equal(drv_framelink_size_ex(&a, &tx), 0);
    uint8_t small[16];
    assert_int_equal(drv_framelink_encode_ex(&a, &tx, small, sizeof small), 0);
    drv_frame_free(&a);
}

static void test_encode_refuses(void **state)
{
    (void)state;
    drv_frame a;
    make_frame(&a, DRV_PLANE_COLOR, WARP_DEPTH_LINEAR, 0, 3);
    size_t n = drv_framelink_size(&a);
    uint8_t *buf = malloc(n);
    assert_int_equal(drv_framelink_encode(&a, buf, n - 1), 0); /* too small a buffer */
    a.planes = DRV_PLANE_COLOR | DRV_PLANE_DEPTH;               /* claims a plane it has not allocated */
    assert_int_equal(drv_framelink_size(&a), 0);
    a.planes = DRV_PLANE_COLOR;
    a.cam[1].width = W + 1; /* camera does not match the plane */
    assert_int_equal(drv_framelink_size(&a), 0);
    a.cam[1].width = W;
    a.n_objects = DRV_MAX_OBJECTS + 1;
    assert_int_equal(drv_framelink_size(&a), 0);
    free(buf);
    drv_frame_free(&a);
}

/* A valid frame with every plane, plus a receiving frame. */
typedef struct {
    drv_frame src, dst;
    uint8_t *buf;
    size_t n;
} fixture;

static void fixture_make(fixture *fx, unsigned planes)
{
    make_frame(&fx->src, planes, WARP_DEPTH_LINEAR, 5, 42);
    fx->buf = encode_new(&fx->src, NULL, &fx->n);
    assert_true(drv_frame_alloc(&fx->dst, W, H, ALL, MAX_LAYERS));
    fx->dst.seq = 0xDEAD;
}

static void fixture_free(fixture *fx)
{
    free(fx->buf);
    drv_frame_free(&fx->src);
    drv_frame_free(&fx->dst);
}

static drv_frame_err decode_copy(const fixture *fx, const uint8_t *buf, size_t len, size_t max)
{
    drv_frame_err e = drv_framelink_decode((const uint8_t *)buf, len, max, (drv_frame *)&fx->dst);
    return e;
}

static uint32_t le32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}
static void set_le32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++) p[i] = (uint8_t)(v >> (8 * i));
}
static size_t header_size(const uint8_t *b) { return (size_t)(b[6] | (b[7] << 8)); }
/* Re-seals the header after an edit, so the checks behind the CRC get exercised. */
static void reseal_header(uint8_t *b)
{
    size_t h = header_size(b);
    set_le32(b + h - 4, (uint32_t)crc32(0, b, (uInt)(h - 4)));
}

static void test_truncated_everywhere(void **state)
{
    (void)state;
    fixture fx;
    fixture_make(&fx, ALL);
    for (size_t len = 0; len < fx.n; len++) {
        uint8_t *copy = malloc(len ? len : 1); /* exact-size copy: ASan sees any read past the end */
        memcpy(copy, fx.buf, len);
        assert_int_equal(decode_copy(&fx, copy, len, 0), DRV_FRAME_ERR_TRUNCATED);
        free(copy);
    }
    assert_int_equal(fx.dst.seq, 0xDEAD); /* never written */
    assert_int_equal(decode_copy(&fx, fx.buf, fx.n, 0), DRV_FRAME_OK);
    fixture_free(&fx);
}

static void test_peek_progressive(void **state)
{
    (void)state;
    fixture fx;
    fixture_make(&fx, DRV_PLANE_COLOR | DRV_PLANE_DEPTH);
    size_t need = 0, hdr = header_size(fx.buf);
    assert_int_equal(drv_framelink_peek(fx.buf, 0, 0, &need), DRV_FRAME_ERR_TRUNCATED);
    assert_int_equal(need, DRV_FRAMELINK_PREFIX_BYTES);
    assert_int_equal(drv_framelink_peek(fx.buf, 3, 0, &need), DRV_FRAME_ERR_TRUNCATED);
    assert_int_equal(drv_framelink_peek(fx.buf, DRV_FRAMELINK_PREFIX_BYTES, 0, &need), DRV_FRAME_ERR_TRUNCATED);
    assert_int_equal(need, hdr);
    assert_int_equal(drv_framelink_peek(fx.buf, hdr - 1, 0, &need), DRV_FRAME_ERR_TRUNCATED);
    assert_int_equal(drv_framelink_peek(fx.buf, hdr, 0, &need), DRV_FRAME_OK);
    assert_int_equal(need, fx.n);
    /* The whole frame is not needed to refuse an oversize one. */
    assert_int_equal(drv_framelink_peek(fx.buf, hdr, fx.n - 1, &need), DRV_FRAME_ERR_TOO_LARGE);
    assert_int_equal(need, fx.n); /* the declared size, to skip it */
    assert_int_equal(drv_framelink_peek(fx.buf, hdr, fx.n, &need), DRV_FRAME_OK);
    uint8_t junk[4] = {'H', 'W', 'X', '1'};
    assert_int_equal(drv_framelink_peek(junk, 4, 0, &need), DRV_FRAME_ERR_BAD_MAGIC);
    assert_int_equal(drv_framelink_peek(junk, 2, 0, &need), DRV_FRAME_ERR_TRUNCATED); /* "HW" may still be one */
    fixture_free(&fx);
}

static void test_rejections(void **state)
{
    (void)state;
    fixture fx;
    fixture_make(&fx, ALL);
    uint8_t *b = malloc(fx.n);
    size_t hdr = header_size(fx.buf);
    char detail[200];
#define RESET() memcpy(b, fx.buf, fx.n)

    RESET();
    assert_int_equal(decode_copy(&fx, b, fx.n, fx.n - 1), DRV_FRAME_ERR_TOO_LARGE);
    RESET();
    b[0] ^= 1;
    assert_int_equal(decode_copy(&fx, b, fx.n, 0), DRV_FRAME_ERR_BAD_MAGIC);
    RESET();
    b[4] = 3; /* version 3 (this build reads 1 and 2): refused before the CRC is even looked at */
    assert_int_equal(decode_copy(&fx, b, fx.n, 0), DRV_FRAME_ERR_BAD_VERSION);
    RESET();
    b[20] ^= 0x10; /* seq: header CRC */
    assert_int_equal(drv_framelink_decode_ex(b, fx.n, 0, &fx.dst, NULL, detail, sizeof detail), DRV_FRAME_ERR_CRC);
    assert_non_null(strstr(detail, "header CRC"));
    RESET();
    b[hdr + 100] ^= 0x01; /* a colour byte: payload CRC */
    assert_int_equal(drv_framelink_decode_ex(b, fx.n, 0, &fx.dst, NULL, detail, sizeof detail), DRV_FRAME_ERR_CRC);
    assert_non_null(strstr(detail, "payload CRC"));
    RESET();
    b[fx.n - 1] ^= 0x80; /* the payload CRC itself */
    assert_int_equal(decode_copy(&fx, b, fx.n, 0), DRV_FRAME_ERR_CRC);
    RESET();
    set_le32(b + 8, (uint32_t)fx.n + 8); /* total size grown, header resealed: planes no longer add up */
    reseal_header(b);
    assert_int_equal(decode_copy(&fx, b, fx.n, 0), DRV_FRAME_ERR_BAD_SIZE);
    RESET();
    b[6] = 0x10, b[7] = 0; /* header size below the minimum */
    assert_int_equal(decode_copy(&fx, b, fx.n, 0), DRV_FRAME_ERR_BAD_SIZE);
    /* Plane descriptor edits: first descriptor (colour) after the objects. */
    size_t d0 = DRV_FRAMELINK_FIXED_BYTES + 5 * DRV_FRAMELINK_OBJECT_BYTES;
    RESET();
    b[d0 + 1] = DRV_FRAMELINK_FMT_F32; /* colour as float */
    reseal_header(b);
    assert_int_equal(decode_copy(&fx, b, fx.n, 0), DRV_FRAME_ERR_BAD_FORMAT);
    RESET();
    b[d0 + 16 + 1] = 99; /* unknown depth format */
    reseal_header(b);
    assert_int_equal(decode_copy(&fx, b, fx.n, 0), DRV_FRAME_ERR_BAD_FORMAT);
    RESET();
    set_le32(b + d0 + 8, le32(b + d0 + 8) - 4); /* colour plane 4 bytes short */
    reseal_header(b);
    assert_int_equal(decode_copy(&fx, b, fx.n, 0), DRV_FRAME_ERR_BAD_SIZE);
    RESET();
    b[72] = 7; /* depth encoding */
    reseal_header(b);
    assert_int_equal(decode_copy(&fx, b, fx.n, 0), DRV_FRAME_ERR_BAD_FORMAT);
    RESET();
    b[74] = DRV_MAX_OBJECTS + 1; /* object count */
    reseal_header(b);
    assert_int_equal(decode_copy(&fx, b, fx.n, 0), DRV_FRAME_ERR_BAD_SIZE);
    RESET();
    set_le32(b + OFF_W_EYE1, W + 2); /* eye 1 wider than the planes it sends */
    reseal_header(b);
    assert_int_equal(decode_copy(&fx, b, fx.n, 0), DRV_FRAME_ERR_BAD_SIZE);
    assert_int_equal(fx.dst.seq, 0xDEAD);

    /* Dims not matching the receiver's allocation, and a plane the receiver has not allocated. */
    drv_frame other;
    assert_true(drv_frame_alloc(&other, W + 1, H, ALL, MAX_LAYERS));
    assert_int_equal(drv_framelink_decode_ex(fx.buf, fx.n, 0, &other, NULL, detail, sizeof detail),
                     DRV_FRAME_ERR_BAD_SIZE);
    assert_non_null(strstr(detail, "allocated"));
    drv_frame_free(&other);
    assert_true(drv_frame_alloc(&other, W, H, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, 0));
    assert_int_equal(drv_framelink_decode(fx.buf, fx.n, 0, &other), DRV_FRAME_ERR_BAD_FORMAT);
    drv_frame_free(&other);
    /* Fewer layers allocated than the sender used. */
    assert_true(drv_frame_alloc(&other, W, H, ALL, 1));
    assert_int_equal(drv_framelink_decode(fx.buf, fx.n, 0, &other), DRV_FRAME_ERR_BAD_SIZE);
    drv_frame_free(&other);
    free(b);
    fixture_free(&fx);
}

/* Host times are checked before any arithmetic (issue #16: pose_sent_ns + (host_render_start_ns - host_pose_rx_ns)
 * overflowed with valid CRCs), and NaN/infinite eye or object poses are refused at the decoder, frame untouched. */
static void test_times_and_poses(void **state)
{
    (void)state;
    drv_frame src, dst;
    make_frame(&src, DRV_PLANE_COLOR, WARP_DEPTH_LINEAR, 2, 5);
    assert_true(drv_frame_alloc(&dst, W, H, ALL, MAX_LAYERS));
    char detail[200];
    size_t n;
    const int64_t max = DRV_FRAMELINK_TIME_MAX_NS;
    struct {
        drv_framelink_tx tx;
        int64_t pose_t;
        drv_frame_err want;
        int64_t render_start; /* when accepted */
    } cases[] = {
        {{1000, 50, 80, 90, 95, 0}, 7, DRV_FRAME_OK, 1030},
        {{max, 1, max, 0, 0, 0}, max, DRV_FRAME_OK, 0}, /* in range but mapped past 2^62: unknown */
        {{1, max, 0, 0, 0, 0}, 7, DRV_FRAME_OK, 0},     /* a zero: unknown */
        {{1LL << 62, 1, INT64_MAX, 0, 0, 0}, 7, DRV_FRAME_ERR_BAD_FORMAT, 0},
        {{1, 1, INT64_MIN, 0, 0, 0}, 7, DRV_FRAME_ERR_BAD_FORMAT, 0},
        {{-5, 1, 2, 0, 0, 0}, 7, DRV_FRAME_ERR_BAD_FORMAT, 0},
        {{1, 1, 2, 3, -1, 0}, 7, DRV_FRAME_ERR_BAD_FORMAT, 0},
        {{1, 1, 2, 3, 4, 0}, -1, DRV_FRAME_ERR_BAD_FORMAT, 0},
        {{1, 1, 2, 3, 4, 0}, max + 1, DRV_FRAME_ERR_BAD_FORMAT, 0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        src.pose_t_ns = cases[i].pose_t;
        uint8_t *b = encode_new(&src, &cases[i].tx, &n);
        dst.seq = 0xDEAD;
        assert_int_equal(drv_framelink_decode_ex(b, n, 0, &dst, NULL, detail, sizeof detail), cases[i].want);
        if (cases[i].want == DRV_FRAME_OK) {
            assert_int_equal(dst.render_start_ns, cases[i].render_start);
        } else {
            assert_int_equal(dst.seq, 0xDEAD);
            assert_non_null(strstr(detail, "outside [0, 2^62]"));
        }
        free(b);
    }
    src.pose_t_ns = 7;
    const double bad[] = {NAN, INFINITY, -INFINITY};
    for (int k = 0; k < 3; k++) {
        for (int which = 0; which < 3; which++) { /* eye 0 position, eye 1 orientation, object 2 position */
            drv_frame f = src;
            if (which == 0) f.eye_pose[0].p.y = bad[k];
            if (which == 1) f.eye_pose[1].q.x = bad[k];
            if (which == 2) f.object_pose[1].p.z = bad[k];
            uint8_t *b = encode_new(&f, NULL, &n);
            dst.seq = 0xDEAD;
            assert_int_equal(drv_framelink_decode_ex(b, n, 0, &dst, NULL, detail, sizeof detail),
                             DRV_FRAME_ERR_BAD_POSE);
            assert_non_null(strstr(detail, which == 2 ? "object 2 pose" : "pose not finite"));
            assert_int_equal(dst.seq, 0xDEAD);
            free(b);
        }
    }
    /* The pose message's times too. */
    drv_framelink_pose p = {.seq = 1, .board_t_ns = -1, .target_t_ns = 5, .head = {{1, 0, 0, 0}, {0, 0, 0}}};
    p.eye[0] = p.eye[1] = p.head;
    uint8_t m[DRV_FRAMELINK_POSE_BYTES];
    drv_framelink_pose q;
    drv_framelink_pose_encode(&p, m, sizeof m);
    assert_int_equal(drv_framelink_pose_decode(m, sizeof m, &q), DRV_FRAME_ERR_BAD_POSE);
    p.board_t_ns = 5, p.target_t_ns = INT64_MAX;
    drv_framelink_pose_encode(&p, m, sizeof m);
    assert_int_equal(drv_framelink_pose_decode(m, sizeof m, &q), DRV_FRAME_ERR_BAD_POSE);
    p.target_t_ns = max;
    drv_framelink_pose_encode(&p, m, sizeof m);
    assert_int_equal(drv_framelink_pose_decode(m, sizeof m, &q), DRV_FRAME_OK);
    drv_frame_free(&src);
    drv_frame_free(&dst);
}

/* Thousands of corruptions of valid frames: none crashes (ASan build), none is accepted. */
static void test_fuzz(void **state)
{
    (void)state;
    const unsigned combos[] = {DRV_PLANE_COLOR, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, ALL};
    test_rng r = test_rng_make(2024);
    int rejected[DRV_FRAME_ERR_COUNT] = {0}, tries = 0;
    for (int c = 0; c < 3; c++) {
        fixture fx;
        fixture_make(&fx, combos[c]);
        size_t hdr = header_size(fx.buf);
        uint8_t *b = malloc(fx.n);
        for (int i = 0; i < 2500; i++) {
            memcpy(b, fx.buf, fx.n);
            size_t len = fx.n;
            int kind = (int)(test_rng_next(&r) % 5);
            if (kind == 0) { /* 1-3 bit flips anywhere (CRC32 catches all of them) */
                int flips = 1 + (int)(test_rng_next(&r) % 3);
                for (int k = 0; k < flips; k++) {
                    size_t at = test_rng_next(&r) % fx.n;
                    b[at] ^= (uint8_t)(1u << (test_rng_next(&r) % 8));
                }
            } else if (kind == 1) { /* truncation */
                len = test_rng_next(&r) % fx.n;
            } else if (kind == 2) { /* a length or count field edited, header resealed */
                static const size_t fields[] = {6, 8, 74, 76};
                size_t at = fields[test_rng_next(&r) % 4];
                b[at] = (uint8_t)test_rng_next(&r);
                if (test_rng_next(&r) & 1) b[at + 1] = (uint8_t)test_rng_next(&r);
                if (header_size(b) <= DRV_FRAMELINK_MAX_HEADER && header_size(b) >= 8 && header_size(b) <= fx.n)
                    reseal_header(b);
            } else if (kind == 3) { /* a descriptor byte edited, header resealed */
                size_t n_planes = (size_t)(b[76] | (b[77] << 8));
                size_t d0 = hdr - 4 - n_planes * DRV_FRAMELINK_PLANE_DESC_BYTES;
                b[d0 + test_rng_next(&r) % (n_planes * DRV_FRAMELINK_PLANE_DESC_BYTES)] = (uint8_t)test_rng_next(&r);
                reseal_header(b);
            } else { /* a burst of random bytes */
                size_t at = test_rng_next(&r) % fx.n, k = 1 + test_rng_next(&r) % 16;
                for (size_t j = 0; j < k && at + j < fx.n; j++) b[at + j] = (uint8_t)test_rng_next(&r);
            }
            if (len == fx.n && memcmp(b, fx.buf, fx.n) == 0) continue; /* mutation undid itself */
            drv_frame_err e = drv_framelink_decode(b, len, 0, &fx.dst);
            size_t need;
            drv_framelink_peek(b, len, 0, &need);
            if (e == DRV_FRAME_OK) {
                for (size_t j = 0; j < fx.n; j++)
                    if (b[j] != fx.buf[j]) print_error("accepted: kind %d, byte %zu changed (header %zu)\n", kind, j, hdr);
            }
            assert_int_not_equal(e, DRV_FRAME_OK);
            assert_true(e > 0 && e < DRV_FRAME_ERR_COUNT);
            rejected[e]++;
            tries++;
        }
        assert_int_equal(fx.dst.seq, 0xDEAD);
        free(b);
        fixture_free(&fx);
    }
    assert_true(tries > 7000);
    /* Every defence was reached. */
    assert_true(rejected[DRV_FRAME_ERR_TRUNCATED] > 0);
    assert_true(rejected[DRV_FRAME_ERR_CRC] > 0);
    assert_true(rejected[DRV_FRAME_ERR_BAD_SIZE] > 0);
    assert_true(rejected[DRV_FRAME_ERR_BAD_FORMAT] > 0);
}

static void test_find_magic(void **state)
{
    (void)state;
    fixture fx;
    fixture_make(&fx, DRV_PLANE_COLOR);
    uint8_t *s = malloc(fx.n + 37);
    for (int i = 0; i < 37; i++) s[i] = (uint8_t)(i * 7 + 1);
    memcpy(s + 37, fx.buf, fx.n);
    assert_int_equal(drv_framelink_find_magic(s, fx.n + 37), 37);
    assert_int_equal(drv_framelink_find_magic(s, 37), 37);
    assert_int_equal(drv_framelink_find_magic(s, 39), 37); /* "HW" at the end may start a frame */
    assert_int_equal(drv_framelink_decode(s + 37, fx.n, 0, &fx.dst), DRV_FRAME_OK);
    free(s);
    fixture_free(&fx);
}

static drv_frame_err pose_decode(const uint8_t *b, size_t n)
{
    drv_framelink_pose p;
    return drv_framelink_pose_decode(b, n, &p);
}
static drv_frame_err cams_decode(const uint8_t *b, size_t n)
{
    drv_framelink_cams c;
    return drv_framelink_cams_decode(b, n, &c);
}

/* What every board -> host message of n bytes must refuse: any shorter length, another magic, version or size, and
 * any single flipped bit after the size field (the CRC). */
static void check_envelope(const uint8_t *buf, size_t n, drv_frame_err (*decode)(const uint8_t *, size_t))
{
    uint8_t b[256];
    assert_true(n <= sizeof b);
    assert_int_equal(decode(buf, n), DRV_FRAME_OK);
    for (size_t len = 0; len < n; len++) assert_int_equal(decode(buf, len), DRV_FRAME_ERR_TRUNCATED);
    const struct { int off, x; drv_frame_err want; } env[] = {
        {1, 1, DRV_FRAME_ERR_BAD_MAGIC}, {4, 8, DRV_FRAME_ERR_BAD_VERSION}, {6, 100, DRV_FRAME_ERR_BAD_SIZE}};
    for (size_t i = 0; i < 3; i++) {
        memcpy(b, buf, n);
        b[env[i].off] ^= (uint8_t)env[i].x;
        assert_int_equal(decode(b, n), env[i].want);
    }
    for (size_t i = 8; i < n; i++) {
        memcpy(b, buf, n);
        b[i] ^= (uint8_t)(1u << (i % 8));
        assert_int_equal(decode(b, n), DRV_FRAME_ERR_CRC);
    }
}

static void test_pose_message(void **state)
{
    (void)state;
    test_rng r = test_rng_make(9);
    drv_framelink_pose p = {.seq = 77, .board_t_ns = 111222333444, .target_t_ns = 111242333444};
    p.head = rand_pose(&r);
    p.eye[0] = rand_pose(&r);
    p.eye[1] = rand_pose(&r);
    uint8_t buf[DRV_FRAMELINK_POSE_BYTES], b[DRV_FRAMELINK_POSE_BYTES];
    assert_int_equal(drv_framelink_pose_encode(&p, buf, sizeof buf - 1), 0);
    assert_int_equal(drv_framelink_pose_encode(&p, buf, sizeof buf), DRV_FRAMELINK_POSE_BYTES);
    drv_framelink_pose q;
    assert_int_equal(drv_framelink_pose_decode(buf, sizeof buf, &q), DRV_FRAME_OK);
    assert_int_equal(q.seq, 77);
    assert_int_equal(q.board_t_ns, p.board_t_ns);
    assert_int_equal(q.target_t_ns, p.target_t_ns);
    assert_same_pose(q.head, p.head);
    assert_same_pose(q.eye[0], p.eye[0]);
    assert_same_pose(q.eye[1], p.eye[1]);

    check_envelope(buf, sizeof buf, pose_decode);
    /* A sender's NaN or non-unit quaternion, with a correct CRC, is still refused. */
    p.head.q.w = NAN;
    drv_framelink_pose_encode(&p, b, sizeof b);
    assert_int_equal(drv_framelink_pose_decode(b, sizeof b, &q), DRV_FRAME_ERR_BAD_POSE);
    p.head.q = (warp_quat){2, 0, 0, 0};
    drv_framelink_pose_encode(&p, b, sizeof b);
    assert_int_equal(drv_framelink_pose_decode(b, sizeof b, &q), DRV_FRAME_ERR_BAD_POSE);
    assert_int_equal(q.seq, 77); /* untouched by the failures */
}

/* Re-encodes with a correct CRC (so a field check, not the CRC, must catch what was changed). */
static void recrc_cams(uint8_t *b) { set_le32(b + 164, (uint32_t)crc32_z(0, b, 164)); }

static void test_cams_message(void **state)
{
    (void)state;
    drv_framelink_cams c = {.seq = 5, .planes = DRV_PLANE_COLOR | DRV_PLANE_DEPTH,
                            .depth_encoding = WARP_DEPTH_REVERSED, .max_frame_bytes = 64u << 20,
                            .refresh_hz = 90, .pose_rate_hz = 180};
    c.cam[0] = warp_camera_symmetric(720, 800, 100, 104, 0.05, INFINITY);
    c.cam[1] = warp_camera_symmetric(720, 800, 96, 104, 0.05, 100);
    c.cam[1].tan_left = 1.1; /* asymmetric */
    uint8_t buf[DRV_FRAMELINK_CAMS_BYTES], b[DRV_FRAMELINK_CAMS_BYTES];
    assert_int_equal(drv_framelink_cams_encode(&c, buf, sizeof buf - 1), 0);
    assert_int_equal(drv_framelink_cams_encode(&c, buf, sizeof buf), DRV_FRAMELINK_CAMS_BYTES);
    drv_framelink_cams q;
    assert_int_equal(drv_framelink_cams_decode(buf, sizeof buf, &q), DRV_FRAME_OK);
    assert_int_equal(q.seq, 5);
    assert_int_equal(q.planes, c.planes);
    assert_int_equal(q.depth_encoding, WARP_DEPTH_REVERSED);
    assert_true(q.max_frame_bytes == c.max_frame_bytes);
    assert_true(q.refresh_hz == 90 && q.pose_rate_hz == 180);
    for (int e = 0; e < 2; e++) assert_memory_equal(&q.cam[e], &c.cam[e], sizeof c.cam[e]);
    assert_true(isinf(q.cam[0].far_z));

    /* Told apart from a pose message by its magic and size. */
    size_t size = 0;
    assert_int_equal(drv_framelink_msg_peek(buf, sizeof buf, &size), DRV_FRAMELINK_CAMS_MAGIC);
    assert_int_equal(size, DRV_FRAMELINK_CAMS_BYTES);
    assert_int_equal(drv_framelink_msg_peek(buf, 11, &size), 0);
    drv_framelink_pose p = {.seq = 1, .board_t_ns = 1, .target_t_ns = 2};
    p.head.q = p.eye[0].q = p.eye[1].q = (warp_quat){1, 0, 0, 0};
    uint8_t pm[DRV_FRAMELINK_POSE_BYTES];
    drv_framelink_pose_encode(&p, pm, sizeof pm);
    assert_int_equal(drv_framelink_msg_peek(pm, sizeof pm, &size), DRV_FRAMELINK_POSE_MAGIC);
    assert_int_equal(size, DRV_FRAMELINK_POSE_BYTES);
    assert_int_equal(drv_framelink_cams_decode(pm, sizeof pm, &q), DRV_FRAME_ERR_BAD_MAGIC);
    memcpy(b, buf, sizeof b);
    b[2] ^= 1;
    assert_int_equal(drv_framelink_msg_peek(b, sizeof b, &size), 0);

    check_envelope(buf, sizeof buf, cams_decode);
    /* Fields a board could get wrong, each behind a correct CRC. */
    const struct { int off, byte; drv_frame_err want; } bad[] = {
        {12, 1, DRV_FRAME_ERR_BAD_FORMAT},  /* flags reserved */
        {160, 1, DRV_FRAME_ERR_BAD_FORMAT}, /* reserved */
        {16, 0x02, DRV_FRAME_ERR_BAD_FORMAT}, /* planes without colour */
        {17, 0x01, DRV_FRAME_ERR_BAD_FORMAT}, /* an unknown plane bit */
        {20, 7, DRV_FRAME_ERR_BAD_FORMAT},  /* depth encoding */
        {48, 0, DRV_FRAME_ERR_BAD_CAMERA},  /* width 0 (low byte; 720 = 0x2d0) */
        {106, 1, DRV_FRAME_ERR_BAD_CAMERA}, /* eye 1 width > WARP_MAX_SIDE */
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        memcpy(b, buf, sizeof b);
        b[bad[i].off] = (uint8_t)bad[i].byte;
        if (bad[i].off == 48) b[49] = 0;
        recrc_cams(b);
        assert_int_equal(drv_framelink_cams_decode(b, sizeof b, &q), bad[i].want);
    }
    c.refresh_hz = NAN;
    drv_framelink_cams_encode(&c, b, sizeof b);
    assert_int_equal(drv_framelink_cams_decode(b, sizeof b, &q), DRV_FRAME_ERR_BAD_SIZE);
    c.refresh_hz = 90;
    c.max_frame_bytes = 0;
    drv_framelink_cams_encode(&c, b, sizeof b);
    assert_int_equal(drv_framelink_cams_decode(b, sizeof b, &q), DRV_FRAME_ERR_BAD_SIZE);
    c.max_frame_bytes = 1;
    c.cam[1].tan_up = -2; /* an inverted frustum */
    drv_framelink_cams_encode(&c, b, sizeof b);
    assert_int_equal(drv_framelink_cams_decode(b, sizeof b, &q), DRV_FRAME_ERR_BAD_CAMERA);
    assert_int_equal(q.seq, 5); /* untouched by the failures */
}

static drv_frame_err mask_decode(const uint8_t *b, size_t n)
{
    drv_framelink_mask m;
    return drv_framelink_mask_decode(b, n, &m);
}

/* The visibility mask message: round trip with exact floats, told apart by peek, every damaged form refused. */
static void test_mask_message(void **state)
{
    (void)state;
    drv_framelink_mask m = {.seq = 9, .n = {24, 3}};
    for (int k = 0; k < 24; k++) {
        m.uv[0][2 * k] = (float)(1.5 * cos(k * 2 * WARP_PI / 24));
        m.uv[0][2 * k + 1] = (float)(1.4 * sin(k * 2 * WARP_PI / 24));
    }
    const float tri[6] = {-1, -1, 1, -1, 0, 1.25f};
    memcpy(m.uv[1], tri, sizeof tri);
    const size_t n = DRV_FRAMELINK_MASK_BYTES(24, 3);
    assert_int_equal(n, 24 + 8 * 27);
    uint8_t buf[DRV_FRAMELINK_MASK_BYTES(DRV_FRAMELINK_MASK_MAX, DRV_FRAMELINK_MASK_MAX)], b[sizeof buf];
    assert_int_equal(drv_framelink_mask_encode(&m, buf, n - 1), 0);
    assert_int_equal(drv_framelink_mask_encode(&m, buf, sizeof buf), n);
    drv_framelink_mask q;
    memset(&q, 0, sizeof q);
    assert_int_equal(drv_framelink_mask_decode(buf, n, &q), DRV_FRAME_OK);
    assert_int_equal(q.seq, 9);
    assert_int_equal(q.n[0], 24);
    assert_int_equal(q.n[1], 3);
    assert_memory_equal(q.uv[0], m.uv[0], sizeof(float) * 48);
    assert_memory_equal(q.uv[1], tri, sizeof tri);
    size_t size = 0;
    assert_int_equal(drv_framelink_msg_peek(buf, n, &size), DRV_FRAMELINK_MASK_MAGIC);
    assert_int_equal(size, n);
    for (size_t len = 0; len < n; len++) assert_int_equal(mask_decode(buf, len), DRV_FRAME_ERR_TRUNCATED);
    /* counts the encoder refuses */
    drv_framelink_mask bad = m;
    bad.n[1] = 2;
    assert_int_equal(drv_framelink_mask_encode(&bad, b, sizeof b), 0);
    bad.n[1] = DRV_FRAMELINK_MASK_MAX + 1;
    assert_int_equal(drv_framelink_mask_encode(&bad, b, sizeof b), 0);
    /* no mask for one eye is fine */
    bad.n[1] = 0;
    size_t n0 = drv_framelink_mask_encode(&bad, b, sizeof b);
    assert_int_equal(n0, DRV_FRAMELINK_MASK_BYTES(24, 0));
    assert_int_equal(drv_framelink_mask_decode(b, n0, &q), DRV_FRAME_OK);
    assert_int_equal(q.n[1], 0);
    /* damage: magic, version, size, a payload bit (CRC), then fields behind a correct CRC */
    const struct { int off, x; drv_frame_err want; } env[] = {{1, 1, DRV_FRAME_ERR_BAD_MAGIC},
                                                             {4, 8, DRV_FRAME_ERR_BAD_VERSION},
                                                             {6, 1, DRV_FRAME_ERR_BAD_SIZE},
                                                             {40, 0x10, DRV_FRAME_ERR_CRC}};
    for (size_t i = 0; i < sizeof env / sizeof env[0]; i++) {
        memcpy(b, buf, n);
        b[env[i].off] ^= (uint8_t)env[i].x;
        assert_int_equal(mask_decode(b, n), env[i].want);
    }
    memcpy(b, buf, n);
    b[12] = 1; /* flags */
    set_le32(b + n - 4, (uint32_t)crc32_z(0, b, n - 4));
    assert_int_equal(mask_decode(b, n), DRV_FRAME_ERR_BAD_FORMAT);
    memcpy(b, buf, n);
    set_le32(b + 20, 0x7fc00000u); /* a NaN vertex */
    set_le32(b + n - 4, (uint32_t)crc32_z(0, b, n - 4));
    assert_int_equal(mask_decode(b, n), DRV_FRAME_ERR_BAD_CAMERA);
    memcpy(b, buf, n);
    set_le32(b + 20, 0x4f000000u); /* 2^31: past any tangent */
    set_le32(b + n - 4, (uint32_t)crc32_z(0, b, n - 4));
    assert_int_equal(mask_decode(b, n), DRV_FRAME_ERR_BAD_CAMERA);
    /* counts of 1 or 2 vertices, or above the maximum, with a matching size and CRC */
    const int counts[][2] = {{1, 0}, {0, 2}, {DRV_FRAMELINK_MASK_MAX + 1, 0}};
    for (size_t i = 0; i < 3; i++) {
        size_t nb = DRV_FRAMELINK_MASK_BYTES(counts[i][0], counts[i][1]);
        uint8_t *d = calloc(1, nb);
        memcpy(d, buf, 16);
        d[6] = (uint8_t)nb, d[7] = (uint8_t)(nb >> 8);
        d[16] = (uint8_t)counts[i][0], d[18] = (uint8_t)counts[i][1];
        set_le32(d + nb - 4, (uint32_t)crc32_z(0, d, nb - 4));
        assert_int_equal(mask_decode(d, nb), DRV_FRAME_ERR_BAD_FORMAT);
        free(d);
    }
    /* a declared size that the counts cannot have: 65535 vertices would not fit the u16 size */
    memcpy(b, buf, n);
    b[16] = 0xff, b[17] = 0xff;
    assert_int_equal(mask_decode(b, n), DRV_FRAME_ERR_BAD_SIZE);
    assert_int_equal(q.seq, 9); /* untouched by the failures */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip_all_planes),
        cmocka_unit_test(test_round_trip_unorm16),
        cmocka_unit_test(test_encode_refuses),
        cmocka_unit_test(test_truncated_everywhere),
        cmocka_unit_test(test_peek_progressive),
        cmocka_unit_test(test_rejections),
        cmocka_unit_test(test_times_and_poses),
        cmocka_unit_test(test_fuzz),
        cmocka_unit_test(test_find_magic),
        cmocka_unit_test(test_pose_message),
        cmocka_unit_test(test_cams_message),
        cmocka_unit_test(test_mask_message),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
