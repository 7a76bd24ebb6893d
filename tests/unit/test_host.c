/* SPDX-License-Identifier: MIT */
/* Unit tests for libhmdwarp-host against a fake board (a listening Unix socket here that sends HWC1/HWP1 and decodes
 * what arrives with drv_framelink_decode): conversions byte-exact, each bad input refused naming its field, a board
 * that disconnects mid-frame and comes back, the file transport and the uri forms. */
#include <errno.h>
#include <math.h>
#include <poll.h>
#include <pthread.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>
#include <cmocka.h>

#include "drivers/drv_framelink.h"
#include "host/hmdwarp-host.h"
#include "tests/support/test_util.h"

#define W 13
#define H 7
#define MAX_LAYERS 3

typedef struct {
    char dir[48], path[80];
    int listen_fd, fd; /* the board's end */
    hmdwarp_host *h;
    drv_framelink_cams cams;
} board;

static void sleep_ms(int ms)
{
    struct timespec ts = {ms / 1000, (long)(ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
}

static void board_send(board *b, const uint8_t *buf, size_t len)
{
    assert_int_equal(send(b->fd, buf, len, MSG_NOSIGNAL), (ssize_t)len);
}

static void board_send_cams(board *b)
{
    uint8_t m[DRV_FRAMELINK_CAMS_BYTES];
    assert_int_equal(drv_framelink_cams_encode(&b->cams, m, sizeof m), sizeof m);
    board_send(b, m, sizeof m);
}

/* Sends the cameras again numbered seq and waits (2 s at most) until the host has them. */
static void board_send_cams_as(board *b, uint32_t seq)
{
    b->cams.seq = seq;
    board_send_cams(b);
    hmdwarp_host_cameras c = {0};
    for (int k = 0; k < 200 && c.seq != seq; k++) hmdwarp_host_get_cameras(b->h, &c), sleep_ms(10);
}

static drv_framelink_pose test_pose(uint32_t seq)
{
    drv_framelink_pose p = {.seq = seq, .board_t_ns = 1000000000LL * seq, .target_t_ns = 1000000000LL * seq + 20000000};
    p.head = (warp_pose){warp_quat_from_ypr(0.1 * seq, 0.05, 0), warp_v3(0, 1.6, 0)};
    p.eye[0] = (warp_pose){p.head.q, warp_v3(-0.032, 1.6, 0)};
    p.eye[1] = (warp_pose){p.head.q, warp_v3(0.032, 1.6, 0)};
    return p;
}

static void board_send_pose(board *b, uint32_t seq)
{
    drv_framelink_pose p = test_pose(seq);
    uint8_t m[DRV_FRAMELINK_POSE_BYTES];
    assert_int_equal(drv_framelink_pose_encode(&p, m, sizeof m), sizeof m);
    board_send(b, m, sizeof m);
}

/* Reads one whole frame from the host (its header says how long) into a fresh buffer. */
static uint8_t *board_read_frame(board *b, size_t *len)
{
    uint8_t *buf = malloc(DRV_FRAMELINK_PREFIX_BYTES);
    size_t have = 0, need = DRV_FRAMELINK_PREFIX_BYTES, total = 0;
    for (;;) {
        while (have < need) {
            ssize_t n = recv(b->fd, buf + have, need - have, 0);
            assert_true(n > 0);
            have += (size_t)n;
        }
        drv_frame_err e = drv_framelink_peek(buf, have, 0, &total);
        if (e == DRV_FRAME_OK && have >= total) break;
        assert_true(e == DRV_FRAME_OK || e == DRV_FRAME_ERR_TRUNCATED);
        need = e == DRV_FRAME_OK ? total : total > have ? total : have + 1;
        buf = realloc(buf, need);
    }
    *len = total;
    return buf;
}

/* Decodes the next frame the board receives into f (allocated for planes). */
static void board_decode(board *b, drv_frame *f, unsigned planes, drv_framelink_rx *rx)
{
    size_t len;
    uint8_t *buf = board_read_frame(b, &len);
    assert_true(drv_frame_alloc(f, W, H, planes, MAX_LAYERS));
    char why[200] = "";
    drv_frame_err e = drv_framelink_decode_ex(buf, len, 0, f, rx, why, sizeof why);
    if (e != DRV_FRAME_OK) fail_msg("decode: %s: %s", drv_frame_err_str(e), why);
    assert_int_equal(drv_frame_validate(f), DRV_FRAME_OK);
    free(buf);
}

/* No bytes waiting on the board's end (a refused frame sent nothing). */
static void assert_board_idle(board *b)
{
    struct pollfd p = {.fd = b->fd, .events = POLLIN};
    assert_int_equal(poll(&p, 1, 50), 0);
}

/* The board's listening socket (hmdwarpd's socket backend: a connect succeeds once it listens). */
static void board_listen(board *b)
{
    b->listen_fd = socket(AF_UNIX, SOCK_STREAM, 0);
    struct sockaddr_un sa = {.sun_family = AF_UNIX};
    snprintf(sa.sun_path, sizeof sa.sun_path, "%s", b->path);
    assert_int_equal(bind(b->listen_fd, (struct sockaddr *)&sa, sizeof sa), 0);
    assert_int_equal(listen(b->listen_fd, 4), 0);
}

static int setup(void **state)
{
    board *b = calloc(1, sizeof *b);
    assert_true(test_tmpdir_make(b->dir, sizeof b->dir, "test_host"));
    snprintf(b->path, sizeof b->path, "%s/frames.sock", b->dir);
    board_listen(b);
    b->cams = (drv_framelink_cams){.seq = 1, .planes = 0x1f, .depth_encoding = WARP_DEPTH_REVERSED,
                                   .max_frame_bytes = 1u << 20, .refresh_hz = 90, .pose_rate_hz = 500};
    b->cams.cam[0] = warp_camera_symmetric(W, H, 100, 90, 0.05, INFINITY);
    b->cams.cam[1] = warp_camera_symmetric(W, H, 96, 90, 0.05, 100);
    b->cams.cam[1].tan_left = 1.1;
    char uri[200];
    snprintf(uri, sizeof uri, "socket:%s", b->path);
    b->h = hmdwarp_host_open(uri);
    if (!b->h) fail_msg("open: %s", hmdwarp_host_last_error());
    b->fd = accept(b->listen_fd, NULL, NULL);
    assert_true(b->fd >= 0);
    *state = b;
    return 0;
}

static int teardown(void **state)
{
    board *b = *state;
    hmdwarp_host_close(b->h);
    if (b->fd >= 0) close(b->fd);
    close(b->listen_fd);
    test_tmpdir_remove(b->dir);
    free(b);
    return 0;
}

/* The cameras and a pose arrive; the pose is echoed: */
static void connect_and_pose(board *b, uint32_t seq, hmdwarp_host_pose_msg *pm)
{
    board_send_cams(b);
    board_send_pose(b, seq);
    hmdwarp_host_cameras c;
    assert_int_equal(hmdwarp_host_wait_cameras(b->h, 5000, &c), 1);
    assert_int_equal(hmdwarp_host_wait_pose(b->h, 5000, pm), 1);
    assert_int_equal(pm->seq, seq);
}

static uint8_t px(int e, int x, int y, int c) { return (uint8_t)(e * 101 + x * 7 + y * 13 + c * 31); }

static void test_messages(void **state)
{
    board *b = *state;
    assert_int_equal(hmdwarp_host_abi_version(), HMDWARP_HOST_ABI_VERSION);
    assert_true(strlen(hmdwarp_host_version()) > 0);
    hmdwarp_host_cameras c;
    assert_int_equal(hmdwarp_host_get_cameras(b->h, &c), 0);
    hmdwarp_host_pose_msg pm;
    assert_int_equal(hmdwarp_host_poll_pose(b->h, &pm), 0);
    /* Messages split across writes and back to back, with garbage in between: the reader resynchronises. */
    uint8_t m[DRV_FRAMELINK_CAMS_BYTES + 7];
    assert_int_equal(drv_framelink_cams_encode(&b->cams, m + 7, DRV_FRAMELINK_CAMS_BYTES), DRV_FRAMELINK_CAMS_BYTES);
    memcpy(m, "garbage", 7);
    board_send(b, m, 50);
    sleep_ms(20);
    board_send(b, m + 50, sizeof m - 50);
    board_send_pose(b, 7);
    board_send_pose(b, 8);
    assert_int_equal(hmdwarp_host_wait_cameras(b->h, 5000, &c), 1);
    assert_int_equal(c.planes, 0x1f);
    assert_int_equal(c.depth_encoding, HMDWARP_HOST_ENCODING_REVERSED);
    assert_int_equal(c.max_frame_bytes, 1u << 20);
    assert_true(c.refresh_hz == 90 && c.pose_rate_hz == 500);
    assert_int_equal(c.cam[1].width, W);
    assert_true(c.cam[1].tan_left == 1.1 && c.cam[1].far_z == 100 && isinf(c.cam[0].far_z));
    /* The newest pose, once: the next wait times out. */
    int got = 0;
    for (int i = 0; i < 100 && pm.seq != 8; i++) got = hmdwarp_host_wait_pose(b->h, 100, &pm);
    assert_int_equal(got, 1);
    assert_int_equal(pm.seq, 8);
    assert_int_equal(hmdwarp_host_wait_pose(b->h, 10, &pm), 0);
    drv_framelink_pose p = test_pose(8);
    assert_true(pm.target_time_ns == p.target_t_ns && pm.board_time_ns == p.board_t_ns);
    assert_true(pm.eye[1].position[0] == 0.032 && pm.eye[0].orientation[0] == p.head.q.w);
    assert_true(pm.received_ns > 0);
    hmdwarp_host_stats st;
    assert_int_equal(hmdwarp_host_get_stats(b->h, &st), 0);
    assert_int_equal(st.poses_received, 2);
    assert_int_equal(st.cameras_received, 1);
    assert_int_equal(st.messages_rejected, 1); /* the garbage run, once */
    assert_int_equal(st.connected, 1);
}

/* The visibility mask: none before it comes, then each eye's loop exactly; a new camera message clears it until its
 * mask follows; a damaged mask is rejected and counted; bad arguments are refused. */
static void test_visibility_mask(void **state)
{
    board *b = *state;
    float uv[2 * HMDWARP_HOST_MASK_MAX];
    assert_int_equal(hmdwarp_host_get_visibility_mask(b->h, 0, uv, HMDWARP_HOST_MASK_MAX), 0);
    drv_framelink_mask m = {.seq = 1, .n = {4, 0}};
    const float sq[8] = {1.25f, 0, 0, 1.5f, -1.25f, 0, 0, -1.5f};
    memcpy(m.uv[0], sq, sizeof sq);
    uint8_t mb[DRV_FRAMELINK_MASK_BYTES(4, 0)];
    assert_int_equal(drv_framelink_mask_encode(&m, mb, sizeof mb), sizeof mb);
    hmdwarp_host_pose_msg pm;
    board_send_cams(b);
    board_send(b, mb, sizeof mb);
    board_send_pose(b, 3);
    assert_int_equal(hmdwarp_host_wait_pose(b->h, 5000, &pm), 1); /* messages are read in order: the mask is in */
    assert_int_equal(hmdwarp_host_get_visibility_mask(b->h, 0, uv, HMDWARP_HOST_MASK_MAX), 4);
    assert_memory_equal(uv, sq, sizeof sq);
    assert_int_equal(hmdwarp_host_get_visibility_mask(b->h, 1, uv, HMDWARP_HOST_MASK_MAX), 0);
    float two[4] = {9, 9, 9, 9};
    assert_int_equal(hmdwarp_host_get_visibility_mask(b->h, 0, two, 1), 4); /* n, with only max copied */
    assert_true(two[0] == 1.25f && two[1] == 0 && two[2] == 9);
    assert_int_equal(hmdwarp_host_get_visibility_mask(b->h, 0, NULL, 0), 4);
    assert_int_equal(hmdwarp_host_get_visibility_mask(b->h, 2, uv, 4), HMDWARP_HOST_ERR_ARG);
    assert_int_equal(hmdwarp_host_get_visibility_mask(b->h, 0, NULL, 4), HMDWARP_HOST_ERR_ARG);
    assert_int_equal(hmdwarp_host_get_visibility_mask(NULL, 0, uv, 4), HMDWARP_HOST_ERR_ARG);
    /* a camera message without its mask (a board without one): no mask */
    board_send_cams(b);
    board_send_pose(b, 4);
    assert_int_equal(hmdwarp_host_wait_pose(b->h, 5000, &pm), 1);
    assert_int_equal(hmdwarp_host_get_visibility_mask(b->h, 0, uv, HMDWARP_HOST_MASK_MAX), 0);
    /* a damaged mask: rejected, counted */
    hmdwarp_host_stats st0, st;
    assert_int_equal(hmdwarp_host_get_stats(b->h, &st0), 0);
    mb[25] ^= 0x40;
    board_send(b, mb, sizeof mb);
    board_send_pose(b, 5);
    assert_int_equal(hmdwarp_host_wait_pose(b->h, 5000, &pm), 1);
    assert_int_equal(hmdwarp_host_get_visibility_mask(b->h, 0, uv, HMDWARP_HOST_MASK_MAX), 0);
    assert_int_equal(hmdwarp_host_get_stats(b->h, &st), 0);
    assert_int_equal(st.messages_rejected, st0.messages_rejected + 1);
}

/* Garbage between messages, a message with a bad CRC and one with a size field beyond any message: each rejected
 * and counted, the good messages around them all received, the reader never stuck. */
static void test_garbage(void **state)
{
    board *b = *state;
    test_rng r = test_rng_make(42);
    uint8_t junk[4096];
    int sent = 0;
    for (int round = 0; round < 8; round++) {
        for (size_t i = 0; i < sizeof junk; i++) junk[i] = (uint8_t)test_rng_next(&r); /* fixed seed: no magic in it */
        board_send(b, junk, sizeof junk);
        board_send_pose(b, (uint32_t)(100 + round));
        sent++;
        hmdwarp_host_pose_msg pm;
        assert_int_equal(hmdwarp_host_wait_pose(b->h, 5000, &pm), 1);
        assert_int_equal(pm.seq, 100 + round);
    }
    drv_framelink_pose p = test_pose(200);
    uint8_t m[DRV_FRAMELINK_POSE_BYTES];
    drv_framelink_pose_encode(&p, m, sizeof m);
    m[40] ^= 1; /* the CRC no longer holds */
    board_send(b, m, sizeof m);
    drv_framelink_pose_encode(&p, m, sizeof m);
    m[6] = 0xff, m[7] = 0x7f; /* declares 32 KiB: not a message */
    board_send(b, m, sizeof m);
    board_send_pose(b, 201);
    hmdwarp_host_pose_msg pm;
    assert_int_equal(hmdwarp_host_wait_pose(b->h, 5000, &pm), 1);
    assert_int_equal(pm.seq, 201);
    hmdwarp_host_stats st;
    hmdwarp_host_get_stats(b->h, &st);
    assert_int_equal(st.poses_received, sent + 1);
    assert_true(st.messages_rejected >= 10); /* eight runs of junk, the CRC, the size */
    assert_int_equal(st.connected, 1);
}

/* Every plane in every input format; what the board decodes is the expected bytes exactly. */
static void test_conversions(void **state)
{
    board *b = *state;
    hmdwarp_host_pose_msg pm;
    connect_and_pose(b, 3, &pm);
    enum { CS = 4 * W + 12 }; /* padded strides */
    static uint8_t bgra[2][H][CS], rgb[2][H][3 * W + 1];
    static uint16_t ids[2][H][W + 3], d16[2][H][W];
    static float ray[2][H][W], motion[2][H][2 * W];
    static uint8_t count[2][H][W];
    static hmdwarp_host_fragment frags[2][W * H * 2];
    size_t nfr[2] = {0, 0};
    for (int e = 0; e < 2; e++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                for (int c = 0; c < 4; c++) bgra[e][y][4 * x + c] = px(e, x, y, c);
                for (int c = 0; c < 3; c++) rgb[e][y][3 * x + c] = px(e, x, y, c);
                ids[e][y][x] = (uint16_t)((x + y + e) % 3);
                ray[e][y][x] = x == 0 && y == 0 ? INFINITY : 1.0f + 0.25f * (float)(x + y);
                d16[e][y][x] = (uint16_t)(x * 5000 + y * 97 + e);
                motion[e][y][2 * x] = (float)x - 3.5f, motion[e][y][2 * x + 1] = (float)y * 0.5f;
                count[e][y][x] = (uint8_t)((x + y) % 3);
                for (int k = 0; k < count[e][y][x]; k++)
                    frags[e][nfr[e]++] = (hmdwarp_host_fragment){0.5f + (float)k, {px(e, x, y, 0), 1, 2, 128},
                                                                 (uint16_t)(k + 1)};
            }
    hmdwarp_host_pose objs[2] = {{{1, 0, 0, 0}, {1, 2, 3}}, {{0, 1, 0, 0}, {-1, 0, 0}}};
    hmdwarp_host_frame fr = {.color_format = HMDWARP_HOST_COLOR_BGRA8, .depth_format = HMDWARP_HOST_DEPTH_RAY_F32,
                             .pose_seq = pm.seq, .render_start_ns = 5, .render_end_ns = 9, .n_objects = 2,
                             .object_poses = objs};
    for (int e = 0; e < 2; e++)
        fr.eye[e] = (hmdwarp_host_eye){.color = bgra[e], .color_stride = CS, .depth = ray[e], .ids = &ids[e][0][0],
                                       .ids_stride = sizeof ids[e][0], .motion = &motion[e][0][0],
                                       .layer_count = &count[e][0][0], .fragments = frags[e], .n_fragments = nfr[e]};
    if (hmdwarp_host_submit(b->h, &fr)) fail_msg("submit: %s", hmdwarp_host_last_error());
    drv_frame f;
    drv_framelink_rx rx;
    board_decode(b, &f, 0x1f, &rx);
    drv_framelink_pose p = test_pose(3);
    assert_int_equal(f.planes, 0x1f);
    assert_int_equal(f.depth_encoding, WARP_DEPTH_LINEAR);
    assert_true(f.pose_t_ns == p.target_t_ns && rx.tx.pose_sent_ns == p.board_t_ns);
    assert_true(rx.tx.host_pose_rx_ns == pm.received_ns && rx.tx.host_render_start_ns == 5 &&
                rx.tx.host_render_end_ns == 9);
    assert_true(f.eye_pose[1].p.x == p.eye[1].p.x && f.eye_pose[0].q.y == p.eye[0].q.y);
    assert_int_equal(f.n_objects, 2);
    assert_true(f.object_pose[0].p.z == 3 && f.object_pose[1].q.x == 1);
    for (int e = 0; e < 2; e++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                warp_rgba8 c = WARP_AT(&f.color[e], x, y);
                assert_true(c.r == px(e, x, y, 2) && c.g == px(e, x, y, 1) && c.b == px(e, x, y, 0) &&
                            c.a == px(e, x, y, 3));
                double u, v;
                warp_camera_pixel_to_tan(&b->cams.cam[e], x + 0.5, y + 0.5, &u, &v);
                float want = isinf(ray[e][y][x]) ? INFINITY : (float)(ray[e][y][x] / sqrt(1 + u * u + v * v));
                assert_true(WARP_AT(&f.depth[e], x, y) == want);
                assert_int_equal(WARP_AT(&f.ids[e], x, y), ids[e][y][x]);
                assert_true(WARP_AT(&f.motion[e], x, y).x == motion[e][y][2 * x] &&
                            WARP_AT(&f.motion[e], x, y).y == motion[e][y][2 * x + 1]);
                assert_int_equal(f.layers[e].count[y * W + x], count[e][y][x]);
            }
    assert_true(f.layers[1].frag[(1 * W + 1) * MAX_LAYERS + 1].z == 1.5f);
    assert_int_equal(f.layers[1].frag[(1 * W + 1) * MAX_LAYERS + 1].id, 2);
    drv_frame_free(&f);

    /* RGB8 (opaque) and 16-bit reversed window depth, explicit eye poses and times, near/far of the projection. */
    hmdwarp_host_frame g = {.color_format = HMDWARP_HOST_COLOR_RGB8,
                            .depth_format = HMDWARP_HOST_DEPTH_REVERSED_UNORM16, .depth_near = 0.1,
                            .depth_far = 50, .pose_target_ns = 77, .pose_board_ns = 66, .pose_received_ns = 55};
    for (int e = 0; e < 2; e++)
        g.eye[e] = (hmdwarp_host_eye){.color = rgb[e], .color_stride = sizeof rgb[e][0], .depth = d16[e],
                                      .pose = {{0, 0, 1, 0}, {e, 0, 0}}};
    if (hmdwarp_host_submit(b->h, &g)) fail_msg("submit: %s", hmdwarp_host_last_error());
    size_t len;
    uint8_t *raw = board_read_frame(b, &len);
    assert_true(drv_frame_alloc(&f, W, H, 0x1f, MAX_LAYERS));
    assert_int_equal(drv_framelink_decode_ex(raw, len, 0, &f, &rx, NULL, 0), DRV_FRAME_OK);
    assert_int_equal(rx.tx.depth_format, DRV_FRAMELINK_FMT_UNORM16);
    assert_int_equal(f.depth_encoding, WARP_DEPTH_REVERSED);
    assert_true(f.cam[0].near_z == 0.1 && f.cam[1].far_z == 50 && f.cam[1].tan_left == 1.1);
    assert_true(f.pose_t_ns == 77 && rx.tx.pose_sent_ns == 66 && rx.tx.host_pose_rx_ns == 55);
    assert_true(f.eye_pose[1].p.x == 1 && f.eye_pose[0].q.y == 1);
    /* The depth plane's bytes on the wire are the caller's u16 values: colour (4 B/px) comes first. */
    size_t hdr = (size_t)raw[6] | (size_t)raw[7] << 8, depth_off = hdr + 2 * W * H * 4;
    assert_memory_equal(raw + depth_off, d16[0], sizeof d16[0]);
    assert_memory_equal(raw + depth_off + sizeof d16[0], d16[1], sizeof d16[1]);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            warp_rgba8 c = WARP_AT(&f.color[1], x, y);
            assert_true(c.r == px(1, x, y, 0) && c.g == px(1, x, y, 1) && c.b == px(1, x, y, 2) && c.a == 255);
        }
    free(raw);
    drv_frame_free(&f);
    hmdwarp_host_stats st;
    hmdwarp_host_get_stats(b->h, &st);
    assert_int_equal(st.frames_sent, 2);
    assert_true(st.bytes_sent > 2 * 2 * W * H * 4 && st.send_ms_mean >= 0);
}

typedef struct {
    const char *why;
    int err;
    const char *field;
} refusal;

/* Each bad input is refused with its code and the field named; nothing reaches the board; a good frame then does. */
static void test_refusals(void **state)
{
    board *b = *state;
    b->cams.planes = DRV_PLANE_COLOR | DRV_PLANE_DEPTH;
    b->cams.max_frame_bytes = 4000;
    hmdwarp_host_pose_msg pm;
    connect_and_pose(b, 11, &pm);
    static uint8_t rgba[2][H][W * 4];
    static float depth[2][H][W];
    static uint16_t ids[2][H][W];
    for (int e = 0; e < 2; e++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) depth[e][y][x] = 0.5f;
    hmdwarp_host_frame good = {.color_format = HMDWARP_HOST_COLOR_RGBA8,
                               .depth_format = HMDWARP_HOST_DEPTH_STANDARD_F32, .pose_seq = pm.seq};
    for (int e = 0; e < 2; e++) good.eye[e] = (hmdwarp_host_eye){.color = rgba[e], .depth = depth[e]};
    hmdwarp_host_pose objs[1] = {{{1, 0, 0, 0}, {0, NAN, 0}}};
    for (int i = 0;; i++) {
        hmdwarp_host_frame f = good;
        refusal r;
        switch (i) {
        case 0: f.eye[1].pose.orientation[0] = NAN, r = (refusal){"NaN pose", -3, "frame.eye[1].orientation[0]"}; break;
        case 1: f.eye[0].pose.orientation[0] = 2, r = (refusal){"non-unit", -1, "frame.eye[0].orientation"}; break;
        case 2: f.eye[0].color_stride = 4 * W - 1, r = (refusal){"stride", -2, "frame.eye[0].color_stride"}; break;
        case 3:
            f.eye[1].camera = (hmdwarp_host_camera){W + 1, H, 1, 1, 1, 1, 0.05, INFINITY};
            r = (refusal){"camera size", -2, "frame.eye[1].camera"};
            break;
        case 4: depth[1][2][3] = NAN, r = (refusal){"NaN depth", -3, "frame.eye[1].depth"}; break;
        case 5: depth[0][2][3] = 1.5f, r = (refusal){"window depth > 1", -4, "frame.eye[0].depth"}; break;
        case 6:
            f.eye[0].ids = &ids[0][0][0], f.eye[1].ids = &ids[1][0][0];
            r = (refusal){"plane not accepted", -4, "ids plane"};
            break;
        case 7: f.pose_seq = 999, r = (refusal){"unknown pose_seq", -1, "frame.pose_seq"}; break;
        case 8: f.eye[1].depth = NULL, r = (refusal){"one eye's depth", -1, "frame.eye[1].depth"}; break;
        case 9: f.color_format = 9, r = (refusal){"colour format", -4, "frame.color_format"}; break;
        case 10:
            f.n_objects = 1, f.object_poses = objs;
            r = (refusal){"NaN object", -3, "frame.object_poses[0]"};
            break;
        case 11: f.depth_format = HMDWARP_HOST_DEPTH_LINEAR_F32, r = (refusal){"negative?", -4, "frame.eye[0].depth"};
            depth[0][0][0] = -1;
            break;
        case 12: f.render_start_ns = -5, r = (refusal){"time", -1, "frame.render_start_ns"}; break;
        case 13: f.depth_unorm16 = 1, f.depth_format = HMDWARP_HOST_DEPTH_RAY_F32,
                 r = (refusal){"16-bit linear", -4, "frame.depth_unorm16"};
            break;
        case 14: f.eye[0].color = NULL, r = (refusal){"no colour", -1, "frame.eye[0].color"}; break;
        case 15:
            b->cams.max_frame_bytes = 1000;
            board_send_cams_as(b, 2);
            r = (refusal){"over max_frame_bytes", -2, "max_frame_bytes"};
            break;
        default: r.why = NULL;
        }
        if (!r.why) break;
        int rc = hmdwarp_host_submit(b->h, &f);
        if (rc != r.err || !strstr(hmdwarp_host_last_error(), r.field))
            fail_msg("%s: got %d '%s', want %d naming %s", r.why, rc, hmdwarp_host_last_error(), r.err, r.field);
        for (int e = 0; e < 2; e++)
            for (int y = 0; y < H; y++)
                for (int x = 0; x < W; x++) depth[e][y][x] = 0.5f;
    }
    assert_board_idle(b);
    hmdwarp_host_stats st;
    hmdwarp_host_get_stats(b->h, &st);
    assert_int_equal(st.frames_refused, 16);
    assert_int_equal(st.frames_sent, 0);
    b->cams.max_frame_bytes = 1u << 20;
    board_send_cams_as(b, 3);
    if (hmdwarp_host_submit(b->h, &good)) fail_msg("submit: %s", hmdwarp_host_last_error());
    drv_frame f;
    board_decode(b, &f, 0x1f, NULL);
    assert_int_equal(f.seq, 1);
    assert_true(WARP_AT(&f.depth[1], 3, 2) == 0.5f);
    drv_frame_free(&f);
}

/* The board reads part of a large frame and goes away. */
static void *board_cut(void *arg)
{
    board *b = arg;
    uint8_t buf[1000];
    size_t got = 0;
    while (got < sizeof buf) {
        ssize_t n = recv(b->fd, buf + got, sizeof buf - got, 0);
        if (n <= 0) break;
        got += (size_t)n;
    }
    /* Gone altogether (hmdwarpd stopped): nothing to reconnect to until the test brings it back. */
    close(b->fd);
    close(b->listen_fd);
    unlink(b->path);
    b->fd = -1;
    return NULL;
}

/* The board comes back a little later, while the host waits for a pose. */
static void *board_return(void *arg)
{
    board *b = arg;
    sleep_ms(50);
    board_listen(b);
    b->fd = accept(b->listen_fd, NULL, NULL);
    assert_true(b->fd >= 0);
    board_send_cams(b);
    board_send_pose(b, 2);
    return NULL;
}

static void test_disconnect(void **state)
{
    board *b = *state;
    enum { BW = 512, BH = 512 };
    b->cams.cam[0] = warp_camera_symmetric(BW, BH, 100, 100, 0.05, INFINITY);
    b->cams.cam[1] = b->cams.cam[0];
    b->cams.max_frame_bytes = 64u << 20;
    hmdwarp_host_pose_msg pm;
    connect_and_pose(b, 1, &pm);
    uint8_t *rgba = calloc(BW * BH, 4);
    hmdwarp_host_frame fr = {.color_format = HMDWARP_HOST_COLOR_RGBX8, .pose_seq = pm.seq};
    fr.eye[0].color = fr.eye[1].color = rgba;
    pthread_t th;
    pthread_create(&th, NULL, board_cut, b);
    int rc = hmdwarp_host_submit(b->h, &fr);
    pthread_join(th, NULL);
    if (rc != HMDWARP_HOST_ERR_DISCONNECTED) fail_msg("mid-frame: %d %s", rc, hmdwarp_host_last_error());
    assert_non_null(strstr(hmdwarp_host_last_error(), "socket"));
    /* Until the board is back: not connected, for submits and waits alike. */
    assert_int_equal(hmdwarp_host_submit(b->h, &fr), HMDWARP_HOST_ERR_NOT_CONNECTED);
    assert_int_equal(hmdwarp_host_wait_pose(b->h, 100, &pm), HMDWARP_HOST_ERR_NOT_CONNECTED);
    assert_int_equal(hmdwarp_host_connected(b->h), 0);
    /* The board comes back during a wait: the reader reconnects on its own and the wait gets the new pose. */
    pthread_create(&th, NULL, board_return, b);
    int got = hmdwarp_host_wait_pose(b->h, 20000, &pm);
    pthread_join(th, NULL);
    if (got != 1) fail_msg("wait across the reconnect: %d %s", got, hmdwarp_host_last_error());
    assert_int_equal(pm.seq, 2);
    assert_int_equal(hmdwarp_host_connected(b->h), 1);
    /* A pose from before the reconnect is not echoed (a restarted board's seq numbers start again). */
    fr.pose_seq = 1;
    assert_int_equal(hmdwarp_host_submit(b->h, &fr), HMDWARP_HOST_ERR_DISCONNECTED);
    assert_non_null(strstr(hmdwarp_host_last_error(), "frame.pose_seq: 1 came before the board reconnected"));
    fr.pose_seq = pm.seq;
    /* A small frame: the board reads it here after the submit returned. */
    b->cams.cam[0] = b->cams.cam[1] = warp_camera_symmetric(W, H, 100, 100, 0.05, INFINITY);
    board_send_cams_as(b, 9);
    if (hmdwarp_host_submit(b->h, &fr)) fail_msg("after reconnect: %s", hmdwarp_host_last_error());
    drv_frame f;
    board_decode(b, &f, 0x1f, NULL);
    assert_true(WARP_AT(&f.color[0], 0, 0).a == 255);
    drv_frame_free(&f);
    hmdwarp_host_stats st;
    hmdwarp_host_get_stats(b->h, &st);
    assert_int_equal(st.disconnects, 1);
    assert_int_equal(st.reconnects, 1);
    assert_int_equal(st.send_errors, 1);
    free(rgba);
}

/* file: and the uri forms; no cameras until set; no poses from a file. */
static void test_file_and_uris(void **state)
{
    (void)state;
    assert_null(hmdwarp_host_open("tcp:localhost:5"));
    assert_non_null(strstr(hmdwarp_host_last_error(), "unknown transport 'tcp'"));
    assert_null(hmdwarp_host_open("usb:12"));
    assert_non_null(strstr(hmdwarp_host_last_error(), "usb:VID:PID"));
    hmdwarp_host_options o = {.transport = HMDWARP_HOST_TRANSPORT_SOCKET, .path = "/nonexistent/x.sock"};
    assert_null(hmdwarp_host_open_ex(&o));
    assert_non_null(strstr(hmdwarp_host_last_error(), "/nonexistent/x.sock"));
    char path[] = "/tmp/test_host_file.XXXXXX";
    int fd = mkstemp(path);
    close(fd);
    char uri[64];
    snprintf(uri, sizeof uri, "file:%s", path);
    hmdwarp_host *h = hmdwarp_host_open(uri);
    assert_non_null(h);
    hmdwarp_host_pose_msg pm;
    assert_int_equal(hmdwarp_host_wait_pose(h, 10, &pm), HMDWARP_HOST_ERR_UNSUPPORTED);
    static uint8_t rgba[W * H * 4];
    hmdwarp_host_frame fr = {.color_format = HMDWARP_HOST_COLOR_RGBA8};
    for (int e = 0; e < 2; e++) fr.eye[e] = (hmdwarp_host_eye){.color = rgba, .pose = {{1, 0, 0, 0}, {0, 0, 0}}};
    assert_int_equal(hmdwarp_host_submit(h, &fr), HMDWARP_HOST_ERR_NO_CAMERAS);
    hmdwarp_host_cameras c = {.planes = HMDWARP_HOST_PLANE_COLOR};
    c.cam[0] = c.cam[1] = (hmdwarp_host_camera){W, H, 1, 1, 1, 1, 0.05, INFINITY};
    c.cam[1].tan_up = -1;
    assert_int_equal(hmdwarp_host_set_cameras(h, &c), HMDWARP_HOST_ERR_ARG);
    assert_non_null(strstr(hmdwarp_host_last_error(), "cams.cam[1]"));
    c.cam[1].tan_up = 1;
    assert_int_equal(hmdwarp_host_set_cameras(h, &c), 0);
    assert_int_equal(hmdwarp_host_submit(h, &fr), 0);
    int64_t n = hmdwarp_host_encode(h, &fr, NULL, 0);
    assert_true(n > W * H * 8);
    hmdwarp_host_close(h);
    FILE *fp = fopen(path, "rb");
    uint8_t *buf = malloc((size_t)n + 1);
    assert_int_equal(fread(buf, 1, (size_t)n + 1, fp), (size_t)n);
    fclose(fp);
    unlink(path);
    drv_frame f;
    assert_true(drv_frame_alloc(&f, W, H, DRV_PLANE_COLOR, 1));
    assert_int_equal(drv_framelink_decode(buf, (size_t)n, 0, &f), DRV_FRAME_OK);
    assert_int_equal(f.seq, 1);
    drv_frame_free(&f);
    free(buf);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_messages, setup, teardown),
        cmocka_unit_test_setup_teardown(test_visibility_mask, setup, teardown),
        cmocka_unit_test_setup_teardown(test_garbage, setup, teardown),
        cmocka_unit_test_setup_teardown(test_conversions, setup, teardown),
        cmocka_unit_test_setup_teardown(test_refusals, setup, teardown),
        cmocka_unit_test_setup_teardown(test_disconnect, setup, teardown),
        cmocka_unit_test(test_file_and_uris),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
