/* SPDX-License-Identifier: MIT */
/* Unit tests for drv_frames_usb through its mock (socket pairs for the endpoints, a simulated host behind them):
 * frames arrive with the board's own poses echoed, faults are rejected by name and the stream resynchronises,
 * oversize frames are skipped unstored, stalls are ridden out, and a missing FunctionFS mount gives a clear error. */
#include <math.h>
#include <pthread.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cmocka.h>
#include <linux/usb/functionfs.h>

#include "drivers/drv_frames_usb.h"
#include "drivers/drv_frames_usb_mock.h"
#include "drivers/drv_framelink.h"
#include "platform/plat_clock.h"
#include "warp/warp_head.h"
#include "tests/support/test_util.h"

#define EYE_W 64
#define EYE_H 48

/* The board's tracker stand-in: a head turning at a known rate; remembers every target time asked for. */
typedef struct {
    pthread_mutex_t lock;
    int64_t targets[4096];
    int n;
} tracker;

static warp_pose head_at(int64_t t_ns)
{
    warp_head h = warp_head_default();
    double t = (double)(t_ns % (100 * PLAT_NS_PER_S)) * 1e-9;
    return warp_head_pose_from_orientation(&h, warp_quat_from_ypr(0.3 * sin(t), 0.1 * cos(t), 0));
}

static bool tracker_predict(void *ctx, int64_t t_ns, warp_pose *head)
{
    tracker *tr = ctx;
    pthread_mutex_lock(&tr->lock);
    if (tr->n < 4096) tr->targets[tr->n++] = t_ns;
    pthread_mutex_unlock(&tr->lock);
    *head = head_at(t_ns);
    return true;
}

static bool tracker_sent(tracker *tr, int64_t t_ns)
{
    pthread_mutex_lock(&tr->lock);
    bool found = false;
    for (int i = 0; i < tr->n && !found; i++) found = tr->targets[i] == t_ns;
    pthread_mutex_unlock(&tr->lock);
    return found;
}

typedef struct {
    tracker tr;
    drv_frames_sim_params host;
    drv_frames_usb_params p;
    drv_frames_usb_mock_params mp;
    drv_frames *fr;
    drv_frame f;
} rig;

static void rig_init(rig *r, const char *scene, unsigned planes)
{
    memset(r, 0, sizeof *r);
    pthread_mutex_init(&r->tr.lock, NULL);
    r->host.scene = sim_scene_find(scene);
    assert_non_null(r->host.scene);
    for (int e = 0; e < 2; e++) r->host.cam[e] = warp_camera_symmetric(EYE_W, EYE_H, 100, 90, 0.05, INFINITY);
    r->host.head = warp_head_default();
    r->host.rate_hz = 100;
    r->host.threads = 1;
    r->host.t0_ns = plat_now_ns();
    r->host.planes_wanted = planes;
    snprintf(r->p.ffs_dir, sizeof r->p.ffs_dir, "/nonexistent");
    r->p.max_frame_bytes = 8u << 20;
    r->p.eye_w = EYE_W;
    r->p.eye_h = EYE_H;
    r->p.planes = planes;
    r->p.poses.predict = tracker_predict;
    r->p.poses.ctx = &r->tr;
    r->p.pose_rate_hz = 500;
}

static void rig_start(rig *r)
{
    char err[200] = "";
    r->fr = drv_frames_usb_create_mock(&r->host, &r->p, &r->mp, err, sizeof err);
    if (!r->fr) print_error("%s\n", err);
    assert_non_null(r->fr);
    assert_int_equal(drv_frames_planes(r->fr), r->p.planes);
    assert_true(drv_frame_alloc(&r->f, EYE_W, EYE_H, r->p.planes, 4));
}

static void rig_stop(rig *r)
{
    drv_frames_destroy(r->fr);
    drv_frame_free(&r->f);
    pthread_mutex_destroy(&r->tr.lock);
}

static void test_end_to_end(void **state)
{
    (void)state;
    rig r;
    unsigned planes = DRV_PLANE_COLOR | DRV_PLANE_DEPTH | DRV_PLANE_IDS | DRV_PLANE_MOTION;
    rig_init(&r, "movers", planes);
    rig_start(&r);
    warp_head h = warp_head_default();
    int got = 0;
    uint64_t last_seq = 0;
    int64_t until = plat_now_ns() + 3 * PLAT_NS_PER_S;
    while (got < 6 && plat_now_ns() < until) {
        int rc = drv_frames_receive(r.fr, &r.f, 100);
        assert_true(rc >= 0);
        if (rc == 0) continue;
        got++;
        assert_int_equal(drv_frame_validate(&r.f), DRV_FRAME_OK);
        assert_int_equal(r.f.planes, planes); /* "movers" needs all four */
        assert_true(r.f.seq > last_seq);
        last_seq = r.f.seq;
        /* The frame was rendered at a pose the board sent, and says so. */
        assert_true(tracker_sent(&r.tr, r.f.pose_t_ns));
        warp_pose head = head_at(r.f.pose_t_ns);
        for (int e = 0; e < 2; e++) {
            warp_pose want = warp_head_eye_pose(&h, head, e);
            assert_memory_equal(&r.f.eye_pose[e], &want, sizeof want);
        }
        assert_true(r.f.n_objects > 0);
        assert_true(r.f.render_start_ns > 0 && r.f.render_start_ns <= r.f.received_ns);
    }
    assert_int_equal(got, 6);
    drv_frames_usb_stats st;
    drv_frames_usb_stats_get(r.fr, &st);
    assert_int_equal(st.frames, 6);
    assert_true(st.poses_sent > 0);
    assert_int_equal(st.skipped_bytes, 0);
    for (int e = 1; e < DRV_FRAME_ERR_COUNT; e++) assert_int_equal(st.rejected[e], 0);
    assert_true(st.lead_ms > 0);
    rig_stop(&r);
}

/* Receives until `frames` good frames; records accepted seqs and rejection codes. */
static void collect(rig *r, int frames, uint64_t *seqs, int *errs, int *n_err)
{
    int got = 0;
    *n_err = 0;
    int64_t until = plat_now_ns() + 4 * PLAT_NS_PER_S;
    while (got < frames && plat_now_ns() < until) {
        int rc = drv_frames_receive(r->fr, &r->f, 100);
        if (rc == 1) seqs[got++] = r->f.seq;
        if (rc < 0 && *n_err < 64) errs[(*n_err)++] = -rc;
    }
    assert_int_equal(got, frames);
}

/* Every n-th host frame is damaged; all others must arrive: a bad frame never costs its neighbour. */
static void check_faults(int corrupt_every, int truncate_every)
{
    rig r;
    rig_init(&r, "room", DRV_PLANE_COLOR);
    r.mp.corrupt_every = corrupt_every;
    r.mp.truncate_every = truncate_every;
    rig_start(&r);
    uint64_t seqs[12];
    int errs[64], n_err;
    collect(&r, 12, seqs, errs, &n_err);
    int every = corrupt_every ? corrupt_every : truncate_every;
    for (int i = 1; i < 12; i++) {
        assert_true(seqs[i] > seqs[i - 1]);
        for (uint64_t s = seqs[i - 1] + 1; s < seqs[i]; s++) assert_int_equal(s % (uint64_t)every, 0);
    }
    for (int i = 0; i < 12; i++) assert_int_not_equal(seqs[i] % (uint64_t)every, 0);
    assert_true(n_err >= 12 / every - 1);
    for (int i = 0; i < n_err; i++) assert_int_equal(errs[i], DRV_FRAME_ERR_CRC);
    drv_frames_usb_stats st;
    drv_frames_usb_stats_get(r.fr, &st);
    assert_int_equal(st.rejected[DRV_FRAME_ERR_CRC], (uint64_t)n_err);
    assert_int_equal(st.rejected[DRV_FRAME_ERR_BAD_MAGIC], 0);
    assert_non_null(strstr(st.last_error, "bad CRC"));
    rig_stop(&r);
}

static void test_corrupted_frames(void **state)
{
    (void)state;
    check_faults(3, 0);
}

static void test_truncated_frames(void **state)
{
    (void)state;
    check_faults(0, 3);
}

static void test_oversize_skipped(void **state)
{
    (void)state;
    rig r;
    rig_init(&r, "room", DRV_PLANE_COLOR);
    r.p.max_frame_bytes = 4096; /* a 64x48 colour frame is ~25 kB */
    rig_start(&r);
    int too_large = 0;
    int64_t until = plat_now_ns() + 3 * PLAT_NS_PER_S;
    while (too_large < 4 && plat_now_ns() < until) {
        int rc = drv_frames_receive(r.fr, &r.f, 100);
        assert_true(rc <= 0); /* never accepted */
        if (rc < 0) {
            assert_int_equal(-rc, DRV_FRAME_ERR_TOO_LARGE);
            too_large++;
        }
    }
    assert_int_equal(too_large, 4);
    drv_frames_usb_stats st;
    drv_frames_usb_stats_get(r.fr, &st);
    assert_int_equal(st.frames, 0);
    size_t frame = 2u * EYE_W * EYE_H * 4;
    /* Skipped by their declared size, not by searching for the next magic. */
    assert_true(st.discarded_bytes >= 3 * frame);
    assert_int_equal(st.skipped_bytes, 0);
    assert_non_null(strstr(st.last_error, "too large"));
    rig_stop(&r);
}

static void test_stall_mid_frame(void **state)
{
    (void)state;
    rig r;
    rig_init(&r, "room", DRV_PLANE_COLOR);
    r.mp.stall_at_s = 0.2;
    r.mp.stall_for_s = 0.5;
    rig_start(&r);
    int before = 0, after = 0, timeouts = 0;
    int64_t until = plat_now_ns() + 3 * PLAT_NS_PER_S;
    while (after < 3 && plat_now_ns() < until) {
        int rc = drv_frames_receive(r.fr, &r.f, 40);
        assert_true(rc >= 0); /* the half frame waits across timeouts, it is not rejected */
        if (rc == 0 && before > 0) timeouts++;
        if (rc == 1) {
            if (timeouts >= 5)
                after++;
            else
                before++;
        }
    }
    assert_true(before > 0);
    assert_true(timeouts >= 5); /* 0.5 s of silence seen in 40 ms slices, with generous slack */
    assert_int_equal(after, 3);
    rig_stop(&r);
}

static void test_missing_ffs(void **state)
{
    (void)state;
    rig r;
    rig_init(&r, "room", DRV_PLANE_COLOR);
    char err[300] = "";
    assert_null(drv_frames_usb_create(&r.p, err, sizeof err));
    assert_non_null(strstr(err, "/nonexistent"));
    assert_non_null(strstr(err, "No such file"));
    assert_non_null(strstr(err, "gadget.sh"));
    /* A directory that is not a FunctionFS mount. */
    char dir[48];
    assert_true(test_tmpdir_make(dir, sizeof dir, "test_frames_usb"));
    snprintf(r.p.ffs_dir, sizeof r.p.ffs_dir, "%s", dir);
    assert_null(drv_frames_usb_create(&r.p, err, sizeof err));
    assert_non_null(strstr(err, "ep0"));
    assert_true(test_tmpdir_remove(dir));
    /* The mock refuses a host whose cameras do not match the board's eyes. */
    r.host.cam[1].width = EYE_W * 2;
    assert_null(drv_frames_usb_create_mock(&r.host, &r.p, &r.mp, err, sizeof err));
    assert_non_null(strstr(err, "differs"));
    pthread_mutex_destroy(&r.tr.lock);
}

/* The receive state machine fed from memory a byte at a time (drv_frames_usb_create_fed): a good frame, one whose
 * garbage, one whose host times would overflow the render-start mapping (valid CRCs), one with a NaN object pose,
 * and a last good one. Each bad one is rejected by name and counted; the good ones arrive whole. */
static void test_fed_byte_by_byte(void **state)
{
    (void)state;
    enum { W = 8, H = 4 };
    drv_frame f, out;
    assert_true(drv_frame_alloc(&f, W, H, DRV_PLANE_COLOR, 0));
    assert_true(drv_frame_alloc(&out, W, H, DRV_PLANE_COLOR, 0));
    f.planes = DRV_PLANE_COLOR;
    f.n_objects = 1;
    f.object_pose[0] = (warp_pose){{1, 0, 0, 0}, {0, 0, -1}};
    for (int e = 0; e < 2; e++) {
        f.cam[e] = warp_camera_symmetric(W, H, 90, 60, 0.05, 100);
        f.eye_pose[e] = (warp_pose){{1, 0, 0, 0}, {0, 1.6, 0}};
    }
    static uint8_t stream[4 * 4096];
    size_t n = 0;
    drv_framelink_tx good = {1000, 50, 80, 90, 95, 0}, overflow = {(int64_t)1 << 62, 1, INT64_MAX, 0, 0, 0};
    f.seq = 1;
    n += drv_framelink_encode_ex(&f, &good, stream + n, sizeof stream - n);
    memcpy(stream + n, "junk", 4), n += 4;
    f.seq = 2;
    n += drv_framelink_encode_ex(&f, &overflow, stream + n, sizeof stream - n);
    f.seq = 3;
    f.object_pose[0].p.x = NAN;
    n += drv_framelink_encode_ex(&f, &good, stream + n, sizeof stream - n);
    f.seq = 4;
    f.object_pose[0].p.x = 0;
    n += drv_framelink_encode_ex(&f, &good, stream + n, sizeof stream - n);

    drv_frames_usb_params p = {.max_frame_bytes = 4096, .eye_w = W, .eye_h = H, .planes = DRV_PLANE_COLOR};
    char err[160];
    drv_frames *fr = drv_frames_usb_create_fed(&p, err, sizeof err);
    assert_non_null(fr);
    int results[16], nr = 0;
    uint64_t seqs[16];
    for (size_t i = 0; i < n;) {
        i += drv_frames_usb_feed(fr, stream + i, 1);
        int r;
        while ((r = drv_frames_receive(fr, &out, 0)) != 0 && nr < 16) seqs[nr] = out.seq, results[nr++] = r;
    }
    assert_int_equal(nr, 5);
    assert_int_equal(results[0], 1);
    assert_int_equal(seqs[0], 1);
    assert_int_equal(out.render_start_ns, 1030);
    assert_int_equal(results[1], -DRV_FRAME_ERR_BAD_MAGIC);  /* the junk */
    assert_int_equal(results[2], -DRV_FRAME_ERR_BAD_FORMAT); /* host times out of range */
    assert_int_equal(results[3], -DRV_FRAME_ERR_BAD_POSE);   /* NaN object position */
    assert_int_equal(results[4], 1);
    assert_int_equal(seqs[4], 4);
    drv_frames_usb_stats st;
    drv_frames_usb_stats_get(fr, &st);
    assert_int_equal(st.frames, 2);
    assert_int_equal(st.bytes, n);
    assert_int_equal(st.rejected[DRV_FRAME_ERR_BAD_FORMAT], 1);
    assert_int_equal(st.rejected[DRV_FRAME_ERR_BAD_POSE], 1);
    assert_non_null(strstr(st.last_error, "object 1 pose"));
    drv_frames_destroy(fr);
    drv_frame_free(&f);
    drv_frame_free(&out);
}

/* The gadget's ep0 accounting: a clean unplug/replug, and the same replug as a late-woken reader sees it once
 * f_fs.c has coalesced DISABLE/UNBIND/BIND away (a second ENABLE), both count one disconnect and a new host. */
static void test_ffs_events(void **state)
{
    (void)state;
    drv_frames_usb_stats st = {0};
    bool on = false;
    drv_frames_usb_ffs_event(FUNCTIONFS_BIND, &on, &st);
    drv_frames_usb_ffs_event(FUNCTIONFS_ENABLE, &on, &st);
    assert_true(on);
    assert_int_equal(st.connections, 1);
    assert_int_equal(st.disconnects, 0);
    drv_frames_usb_ffs_event(FUNCTIONFS_SUSPEND, &on, &st);
    drv_frames_usb_ffs_event(FUNCTIONFS_RESUME, &on, &st);
    assert_int_equal(st.connections, 1);
    drv_frames_usb_ffs_event(FUNCTIONFS_DISABLE, &on, &st);
    drv_frames_usb_ffs_event(FUNCTIONFS_UNBIND, &on, &st); /* already down: not a second disconnect */
    assert_false(on);
    assert_int_equal(st.disconnects, 1);
    assert_non_null(strstr(st.last_error, "disabled"));
    drv_frames_usb_ffs_event(FUNCTIONFS_BIND, &on, &st);
    drv_frames_usb_ffs_event(FUNCTIONFS_ENABLE, &on, &st);
    assert_int_equal(st.connections, 2);
    /* the coalesced replug: ENABLE while enabled */
    drv_frames_usb_ffs_event(FUNCTIONFS_ENABLE, &on, &st);
    assert_true(on);
    assert_int_equal(st.connections, 3);
    assert_int_equal(st.disconnects, 2);
    assert_non_null(strstr(st.last_error, "replug"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_end_to_end),
        cmocka_unit_test(test_corrupted_frames),
        cmocka_unit_test(test_truncated_frames),
        cmocka_unit_test(test_oversize_skipped),
        cmocka_unit_test(test_stall_mid_frame),
        cmocka_unit_test(test_missing_ffs),
        cmocka_unit_test(test_fed_byte_by_byte),
        cmocka_unit_test(test_ffs_events),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
