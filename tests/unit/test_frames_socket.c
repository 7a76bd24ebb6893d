/* SPDX-License-Identifier: MIT */
/* Unit tests for drv_frames_socket with this test as the host on the socket: the camera message first, then poses;
 * frames arrive byte-identical; garbage and cut frames are rejected and counted, the next frame accepted; a host that
 * leaves is a counted disconnect and the next one is greeted again; a second host is refused; the socket path's
 * cases (stale socket, another file, a live listener, too long, a missing parent) give a board or a clear error. */
#include <errno.h>
#include <math.h>
#include <poll.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>
#include <cmocka.h>

#include "drivers/drv_framelink.h"
#include "drivers/drv_frames_socket.h"
#include "platform/plat_clock.h"
#include "warp/warp_head.h"
#include "tests/support/test_host_link.h"
#include "tests/support/test_util.h"

#define W 32
#define H 24
#define PLANES (DRV_PLANE_COLOR | DRV_PLANE_DEPTH)
#define WAIT_S 10 /* the longest any step may take on a loaded machine: a hang guard, never a measurement */

static char path[100];

static bool predict(void *ctx, int64_t t_ns, warp_pose *head)
{
    (void)ctx;
    warp_head h = warp_head_default();
    double t = (double)(t_ns % (100 * PLAT_NS_PER_S)) * 1e-9;
    *head = warp_head_pose_from_orientation(&h, warp_quat_from_ypr(0.2 * sin(t), 0, 0));
    return true;
}

static drv_frames_usb_params params(void)
{
    drv_frames_usb_params p;
    memset(&p, 0, sizeof p);
    p.max_frame_bytes = 1u << 20;
    p.eye_w = W;
    p.eye_h = H;
    p.planes = PLANES;
    p.poses.predict = predict;
    p.pose_rate_hz = 200;
    for (int e = 0; e < 2; e++) p.cam[e] = warp_camera_symmetric(W, H, 100, 90, 0.05, INFINITY);
    p.cam[1].tan_left = 1.1; /* the eyes differ: each must arrive as given */
    p.refresh_hz = 90;
    p.depth_encoding = WARP_DEPTH_LINEAR;
    return p;
}

/* The board under test and the frame it receives into. */
typedef struct {
    drv_frames *fr;
    drv_frame f;
} board;

static void board_start(board *b)
{
    drv_frames_usb_params p = params();
    char err[300] = "";
    b->fr = drv_frames_socket_create(&p, path, err, sizeof err);
    if (!b->fr) print_error("%s\n", err);
    assert_non_null(b->fr);
    assert_true(drv_frame_alloc(&b->f, W, H, PLANES, 0));
}

static void board_stop(board *b)
{
    drv_frames_destroy(b->fr);
    drv_frame_free(&b->f);
    struct stat sb;
    assert_int_equal(lstat(path, &sb), -1); /* the board removed its socket */
}

static drv_frames_usb_stats stats(board *b)
{
    drv_frames_usb_stats st;
    drv_frames_usb_stats_get(b->fr, &st);
    return st;
}

/* The board's frames thread stand-in: one receive step (which also accepts hosts). */
static int pump(board *b, int timeout_ms) { return drv_frames_receive(b->fr, &b->f, timeout_ms); }

/* Receives until a frame or a rejection (1 or -err); 0 only after WAIT_S. */
static int pump_until_result(board *b)
{
    int64_t until = plat_now_ns() + WAIT_S * PLAT_NS_PER_S;
    int rc = 0;
    while (rc == 0 && plat_now_ns() < until) rc = pump(b, 20);
    return rc;
}

typedef test_host_link host;

/* the board listens already: one try */
static void host_connect(host *h) { assert_true(test_host_link_connect(h, path, 1)); }

static void host_close(host *h)
{
    close(h->fd);
    h->fd = -1;
}

/* The next whole board -> host message into msg (its magic returned), pumping the board meanwhile; 0 when the board
 * closed the connection, -1 when nothing came in WAIT_S. */
static int64_t host_next(host *h, board *b, uint8_t *msg, size_t cap)
{
    int64_t until = plat_now_ns() + WAIT_S * PLAT_NS_PER_S;
    while (plat_now_ns() < until) {
        size_t size = 0;
        uint32_t magic = drv_framelink_msg_peek(h->buf, h->have, &size);
        if (h->have >= 12) assert_true(magic != 0); /* whole messages back to back: never out of step */
        if (magic && h->have >= size) {
            assert_true(size <= cap);
            memcpy(msg, h->buf, size);
            memmove(h->buf, h->buf + size, h->have - size);
            h->have -= size;
            return magic;
        }
        assert_int_equal(pump(b, 5), 0); /* no frame is in flight while the host listens */
        struct pollfd pfd = {h->fd, POLLIN, 0};
        if (poll(&pfd, 1, 5) <= 0) continue;
        ssize_t n = recv(h->fd, h->buf + h->have, sizeof h->buf - h->have, MSG_DONTWAIT);
        if (n == 0) return 0;
        if (n > 0) h->have += (size_t)n;
    }
    return -1;
}

static void host_send(host *h, const uint8_t *data, size_t len)
{
    while (len > 0) {
        ssize_t n = send(h->fd, data, len, MSG_NOSIGNAL);
        assert_true(n > 0);
        data += n;
        len -= (size_t)n;
    }
}

/* A frame as a host renders it for pose message m: a pattern of seq in colour and depth, at m's eye poses. */
static size_t make_frame(drv_frame *f, uint64_t seq, const drv_framelink_pose *m, uint8_t *out, size_t cap)
{
    drv_frames_usb_params p = params();
    f->seq = seq;
    f->planes = PLANES;
    f->depth_encoding = WARP_DEPTH_LINEAR;
    f->pose_t_ns = m->target_t_ns;
    for (int e = 0; e < 2; e++) {
        f->cam[e] = p.cam[e];
        f->eye_pose[e] = m->eye[e];
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                f->color[e].px[y * f->color[e].stride + x] =
                    (warp_rgba8){(uint8_t)(x * 7 + seq), (uint8_t)(y * 5 + e), (uint8_t)(seq * 3), 255};
                f->depth[e].px[y * f->depth[e].stride + x] = 0.5f + 0.01f * (float)(x + y) + (float)seq;
            }
    }
    drv_framelink_tx tx = {.pose_sent_ns = m->board_t_ns, .host_pose_rx_ns = 1, .host_render_start_ns = 2,
                           .host_render_end_ns = 3, .host_send_ns = 4};
    size_t n = drv_framelink_encode_ex(f, &tx, out, cap);
    assert_true(n > 0);
    return n;
}

static void assert_same_planes(const drv_frame *got, const drv_frame *sent)
{
    assert_int_equal(got->seq, sent->seq);
    assert_int_equal(got->pose_t_ns, sent->pose_t_ns);
    for (int e = 0; e < 2; e++)
        for (int y = 0; y < H; y++) {
            assert_memory_equal(got->color[e].px + y * got->color[e].stride,
                                sent->color[e].px + y * sent->color[e].stride, W * sizeof(warp_rgba8));
            assert_memory_equal(got->depth[e].px + y * got->depth[e].stride,
                                sent->depth[e].px + y * sent->depth[e].stride, W * sizeof(float));
        }
}

/* Connects and reads the greeting: the camera message first, then a pose (into *m). */
static void host_greeted(host *h, board *b, drv_framelink_cams *c, drv_framelink_pose *m)
{
    host_connect(h);
    uint8_t msg[512];
    assert_int_equal(host_next(h, b, msg, sizeof msg), DRV_FRAMELINK_CAMS_MAGIC);
    assert_int_equal(drv_framelink_cams_decode(msg, DRV_FRAMELINK_CAMS_BYTES, c), DRV_FRAME_OK);
    int64_t magic;
    while ((magic = host_next(h, b, msg, sizeof msg)) == DRV_FRAMELINK_CAMS_MAGIC) {
    }
    assert_int_equal(magic, DRV_FRAMELINK_POSE_MAGIC);
    assert_int_equal(drv_framelink_pose_decode(msg, DRV_FRAMELINK_POSE_BYTES, m), DRV_FRAME_OK);
}

/* A test's board and its greeted host (cameras c, newest pose m), with a frame to render into. */
typedef struct {
    board b;
    host h;
    drv_framelink_cams c;
    drv_framelink_pose m;
    drv_frame sent;
} rig;

static uint8_t wire[1 << 16]; /* the frame last sent, whole (static: too large for the stack) */

static void rig_start(rig *r)
{
    board_start(&r->b);
    host_greeted(&r->h, &r->b, &r->c, &r->m);
    assert_true(drv_frame_alloc(&r->sent, W, H, PLANES, 0));
}

/* Ends a rig whose host may already be closed (host_close leaves fd -1, which close ignores). */
static void rig_stop(rig *r)
{
    host_close(&r->h);
    drv_frame_free(&r->sent);
    board_stop(&r->b);
}

/* Renders frame seq at the newest pose into wire and sends it; the board receives it whole. Returns its bytes. */
static size_t rig_send_frame(rig *r, uint64_t seq)
{
    size_t n = make_frame(&r->sent, seq, &r->m, wire, sizeof wire);
    host_send(&r->h, wire, n);
    assert_int_equal(pump_until_result(&r->b), 1);
    assert_same_planes(&r->b.f, &r->sent);
    return n;
}

static void test_cameras_poses_frames(void **state)
{
    (void)state;
    rig r;
    rig_start(&r);
    drv_frames_usb_params p = params();
    assert_int_equal(r.c.seq, 1);
    assert_int_equal(r.c.planes, PLANES);
    assert_int_equal(r.c.depth_encoding, WARP_DEPTH_LINEAR);
    assert_int_equal(r.c.max_frame_bytes, p.max_frame_bytes);
    assert_true(r.c.refresh_hz == 90 && r.c.pose_rate_hz == 200);
    for (int e = 0; e < 2; e++) {
        assert_int_equal(r.c.cam[e].width, W);
        assert_int_equal(r.c.cam[e].height, H);
        assert_true(r.c.cam[e].tan_left == p.cam[e].tan_left && r.c.cam[e].tan_up == p.cam[e].tan_up);
        assert_true(r.c.cam[e].near_z == p.cam[e].near_z && isinf(r.c.cam[e].far_z));
    }
    /* Poses follow, and the cameras again a second later (a host that missed them learns them). */
    uint8_t msg[512];
    int poses = 1, cams = 1;
    uint32_t last_seq = r.m.seq;
    while (cams < 2) {
        int64_t magic = host_next(&r.h, &r.b, msg, sizeof msg);
        assert_true(magic == DRV_FRAMELINK_POSE_MAGIC || magic == DRV_FRAMELINK_CAMS_MAGIC);
        if (magic == DRV_FRAMELINK_CAMS_MAGIC) {
            assert_int_equal(drv_framelink_cams_decode(msg, DRV_FRAMELINK_CAMS_BYTES, &r.c), DRV_FRAME_OK);
            assert_int_equal(r.c.seq, ++cams);
            continue;
        }
        assert_int_equal(drv_framelink_pose_decode(msg, DRV_FRAMELINK_POSE_BYTES, &r.m), DRV_FRAME_OK);
        assert_true(r.m.seq > last_seq);
        last_seq = r.m.seq;
        poses++;
    }
    assert_true(poses > 2);
    /* Frames rendered at the newest pose arrive whole, plane bytes identical. */
    size_t total = 0;
    for (uint64_t seq = 1; seq <= 3; seq++) {
        total += rig_send_frame(&r, seq);
        assert_int_equal(drv_frame_validate(&r.b.f), DRV_FRAME_OK);
        assert_memory_equal(&r.b.f.eye_pose[1], &r.m.eye[1], sizeof r.m.eye[1]);
    }
    drv_frames_usb_stats st = stats(&r.b);
    assert_int_equal(st.frames, 3);
    assert_int_equal(st.bytes, total);
    assert_true(st.connected);
    assert_int_equal(st.connections, 1);
    assert_int_equal(st.disconnects, 0);
    assert_int_equal(st.refused, 0);
    assert_true(st.cams_sent >= 2 && st.poses_sent >= (uint64_t)poses);
    for (int e = 1; e < DRV_FRAME_ERR_COUNT; e++) assert_int_equal(st.rejected[e], 0);
    rig_stop(&r);
}

static void test_garbage_and_cut_frames(void **state)
{
    (void)state;
    rig r;
    rig_start(&r);
    static uint8_t a[1 << 16], cut[1 << 16];
    /* a good frame, garbage, a frame cut short by the next one, which must still arrive */
    rig_send_frame(&r, 1);
    host_send(&r.h, (const uint8_t *)"this is not a frame", 19);
    assert_int_equal(pump_until_result(&r.b), -DRV_FRAME_ERR_BAD_MAGIC);
    size_t n = make_frame(&r.sent, 2, &r.m, cut, sizeof cut);
    host_send(&r.h, cut, n / 2);
    n = make_frame(&r.sent, 3, &r.m, a, sizeof a);
    host_send(&r.h, a, n);
    assert_int_equal(pump_until_result(&r.b), -DRV_FRAME_ERR_CRC);
    assert_int_equal(pump_until_result(&r.b), 1);
    assert_same_planes(&r.b.f, &r.sent);
    drv_frames_usb_stats st = stats(&r.b);
    assert_int_equal(st.frames, 2);
    assert_int_equal(st.rejected[DRV_FRAME_ERR_BAD_MAGIC], 1);
    assert_int_equal(st.rejected[DRV_FRAME_ERR_CRC], 1);
    assert_true(st.skipped_bytes >= 19);
    assert_non_null(strstr(st.last_error, "socket frames: frame rejected"));
    rig_stop(&r);
}

/* A host leaves mid-frame: a counted disconnect, the partial frame dropped; the next host is greeted afresh. */
static void test_reconnect(void **state)
{
    (void)state;
    rig r;
    rig_start(&r);
    size_t n = rig_send_frame(&r, 1);
    host_send(&r.h, wire, n / 2);
    host_close(&r.h);
    int64_t until = plat_now_ns() + WAIT_S * PLAT_NS_PER_S;
    while (stats(&r.b).disconnects == 0 && plat_now_ns() < until) assert_int_equal(pump(&r.b, 20), 0);
    drv_frames_usb_stats st = stats(&r.b);
    assert_int_equal(st.disconnects, 1);
    assert_false(st.connected);
    assert_non_null(strstr(st.last_error, "partial frame dropped"));
    uint32_t first_cams = r.c.seq;
    host_greeted(&r.h, &r.b, &r.c, &r.m);
    assert_true(r.c.seq > first_cams);
    rig_send_frame(&r, 2);
    st = stats(&r.b);
    assert_int_equal(st.frames, 2);
    assert_int_equal(st.connections, 2);
    assert_int_equal(st.disconnects, 1);
    assert_true(st.connected);
    for (int e = 1; e < DRV_FRAME_ERR_COUNT; e++) assert_int_equal(st.rejected[e], 0);
    rig_stop(&r);
}

/* A host that closes and reconnects at once (a restarted renderer): both are waiting when the board next reads,
 * and the new connection is accepted, not refused as a second host. */
static void test_reconnect_at_once(void **state)
{
    (void)state;
    rig r;
    rig_start(&r);
    host_close(&r.h);
    host_greeted(&r.h, &r.b, &r.c, &r.m);
    drv_frames_usb_stats st = stats(&r.b);
    assert_int_equal(st.connections, 2);
    assert_int_equal(st.disconnects, 1);
    assert_int_equal(st.refused, 0);
    rig_stop(&r);
}

static void test_second_host_refused(void **state)
{
    (void)state;
    rig r;
    rig_start(&r);
    host h2;
    host_connect(&h2);
    uint8_t msg[512];
    assert_int_equal(host_next(&h2, &r.b, msg, sizeof msg), 0); /* closed, told nothing */
    drv_frames_usb_stats st = stats(&r.b);
    assert_int_equal(st.refused, 1);
    assert_int_equal(st.connections, 1);
    assert_int_equal(st.disconnects, 0);
    host_close(&h2);
    /* the first host carries on */
    rig_send_frame(&r, 1);
    rig_stop(&r);
}

static void test_socket_path(void **state)
{
    (void)state;
    drv_frames_usb_params p = params();
    char err[300] = "";
    /* a socket file nobody listens at (a board that died): replaced */
    int s = socket(AF_UNIX, SOCK_STREAM, 0);
    struct sockaddr_un a = {.sun_family = AF_UNIX};
    snprintf(a.sun_path, sizeof a.sun_path, "%s", path);
    assert_int_equal(bind(s, (struct sockaddr *)&a, sizeof a), 0);
    close(s);
    rig r;
    rig_start(&r);
    host_close(&r.h);
    /* ... but not while a board listens there */
    assert_null(drv_frames_socket_create(&p, path, err, sizeof err));
    assert_non_null(strstr(err, path));
    assert_non_null(strstr(err, "another process is listening"));
    rig_stop(&r); /* the host is closed already */
    /* a regular file at the path: an error naming it, the file left alone */
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fclose(f);
    assert_null(drv_frames_socket_create(&p, path, err, sizeof err));
    assert_non_null(strstr(err, path));
    assert_non_null(strstr(err, "regular file, not a socket"));
    struct stat sb;
    assert_int_equal(lstat(path, &sb), 0);
    assert_true(S_ISREG(sb.st_mode));
    unlink(path);
    /* longer than a socket address holds */
    char longp[200];
    snprintf(longp, sizeof longp, "%s/%0120d", test_tmp(), 7);
    assert_null(drv_frames_socket_create(&p, longp, err, sizeof err));
    assert_non_null(strstr(err, "at most 107"));
    /* a missing parent is made (as /run/hmdwarp), a missing grandparent is not */
    char sub[160];
    snprintf(sub, sizeof sub, "%s/run/frames.sock", test_tmp());
    drv_frames *fr = drv_frames_socket_create(&p, sub, err, sizeof err);
    assert_non_null(fr);
    drv_frames_destroy(fr);
    snprintf(sub, sizeof sub, "%s/no/such/frames.sock", test_tmp());
    assert_null(drv_frames_socket_create(&p, sub, err, sizeof err));
    assert_non_null(strstr(err, "cannot make the directory"));
    /* cameras that do not match the eyes are refused before anything listens */
    p.cam[1].width = W * 2;
    assert_null(drv_frames_socket_create(&p, path, err, sizeof err));
    assert_non_null(strstr(err, "bad parameters"));
    assert_int_equal(lstat(path, &sb), -1);
}

static int setup(void **state)
{
    if (test_tmp_setup(state)) return -1;
    snprintf(path, sizeof path, "%s/frames.sock", test_tmp());
    return 0;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cameras_poses_frames), cmocka_unit_test(test_garbage_and_cut_frames),
        cmocka_unit_test(test_reconnect),            cmocka_unit_test(test_reconnect_at_once),
        cmocka_unit_test(test_second_host_refused),
        cmocka_unit_test(test_socket_path),
    };
    return cmocka_run_group_tests(tests, setup, test_tmp_teardown);
}
