/* SPDX-License-Identifier: MIT */
/* Unit tests for warp_fov and [eye] fov = auto: the visible region, the auto FOV covering it on the sim and rpi5
 * boards (no visible pixel samples outside the source at rest, counted pixel by pixel), the hidden-area mask exactly
 * black, the guard band against the fast trace (modelled, and hmdwarpd's summary counts), the mask's line loop, and
 * config parsing of the new keys. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>
#include <unistd.h>

#include "runtime/rt_config.h"
#include "sim/sim_trace.h"
#include "tests/support/test_util.h"
#include "warp/warp_fov.h"
#include "warp/warp_lens_models.h"
#include "warp/warp_math.h"
#include "warp/warp_resample.h"

static void load_board(rt_config *c, const char *path)
{
    rt_config_defaults(c);
    rt_config_errors err = {0};
    assert_true(rt_config_load(c, path, &err));
    assert_true(rt_config_validate(c, &err));
    assert_int_equal(err.count, 0);
}

/* One eye's mesh with its mask, as rt_render_cpu builds it. */
typedef struct {
    warp_lens lens;
    warp_camera cam;
    warp_mesh mesh;
    int32_t *span;
    int64_t visible;
    int vw, h;
} eye_setup;

static void eye_alloc(eye_setup *s, const rt_config *c, int eye)
{
    s->lens = rt_config_lens(c, eye);
    s->cam = rt_config_eye_camera(c, eye);
    s->vw = c->panel_w / 2;
    s->h = c->panel_h;
    assert_null(warp_camera_check(&s->cam));
    assert_true(warp_mesh_alloc(&s->mesh, c->mesh_n, &s->lens, eye * s->vw, 0, s->vw, s->h));
    s->span = malloc(sizeof *s->span * 2 * (size_t)s->h);
    assert_non_null(s->span);
    s->visible = warp_fov_spans(&s->lens, rt_config_visible_radius(c, eye), s->vw, s->h, s->span);
    s->mesh.visible = s->span;
}

static void eye_free(eye_setup *s)
{
    warp_mesh_free(&s->mesh);
    free(s->span);
}

/* With the defaults of a board, no visible pixel samples outside the eye buffer at rest; without the mask (every
 * panel pixel) many would: the test can fail. */
static void at_rest(const char *board)
{
    rt_config c;
    load_board(&c, board);
    assert_true(rt_config_fov_auto(&c));
    for (int e = 0; e < 2; e++) {
        eye_setup s;
        eye_alloc(&s, &c, e);
        assert_true(s.visible > (int64_t)s.vw * s.h / 2);
        assert_true(s.visible < (int64_t)s.vw * s.h);
        warp_mesh_update(&s.mesh, &s.cam, warp_quat_identity());
        assert_int_equal(warp_fov_outside_exact(&s.mesh, s.cam.width, s.cam.height), 0);
        warp_fov_weights w;
        assert_true(warp_fov_weights_alloc(&w, &s.mesh, s.span));
        assert_int_equal(w.visible, s.visible);
        assert_int_equal(warp_fov_outside(&w, &s.mesh, s.cam.width, s.cam.height), 0);
        s.mesh.visible = NULL;
        assert_true(warp_fov_outside_exact(&s.mesh, s.cam.width, s.cam.height) > (int64_t)s.vw * s.h / 10);
        warp_fov_weights_free(&w);
        eye_free(&s);
    }
}

static void test_sim_board_at_rest(void **state)
{
    (void)state;
    at_rest("board/sim/board.ini");
}

static void test_rpi5_board_at_rest(void **state)
{
    (void)state;
    at_rest("board/rpi5/board.ini");
}

/* The old hand-typed FOV (52 48 52 52) against the same lens: the panel corners see tangents of about 3, far
 * outside the eye buffer's 1.28; with the mask but that FOV, the visible disc's rim still overreaches it. */
static void test_fixed_fov_overreaches(void **state)
{
    (void)state;
    rt_config c;
    load_board(&c, "board/sim/board.ini");
    rt_config_errors err = {0};
    assert_true(rt_config_set(&c, "eye.fov=52 48 52 52", &err));
    assert_false(rt_config_fov_auto(&c));
    eye_setup s;
    eye_alloc(&s, &c, 0);
    warp_mesh_update(&s.mesh, &s.cam, warp_quat_identity());
    assert_true(warp_fov_outside_exact(&s.mesh, s.cam.width, s.cam.height) > 0);
    eye_free(&s);
}

/* Masked pixels are exactly opaque black, whatever the source; visible ones are sampled. */
static void test_mask_black(void **state)
{
    (void)state;
    rt_config c;
    load_board(&c, "board/sim/board.ini");
    eye_setup s;
    eye_alloc(&s, &c, 1);
    warp_image_rgba8 src, panel;
    warp_planar3 planar;
    assert_true(warp_image_rgba8_alloc(&src, c.eye_w, c.eye_h));
    assert_true(warp_planar3_alloc(&planar, c.eye_w, c.eye_h));
    assert_true(warp_image_rgba8_alloc(&panel, c.panel_w, c.panel_h));
    for (int y = 0; y < c.eye_h; y++)
        for (int x = 0; x < c.eye_w; x++) WARP_AT(&src, x, y) = (warp_rgba8){200, 150, 100, 255};
    for (int y = 0; y < c.panel_h; y++)
        for (int x = 0; x < c.panel_w; x++) WARP_AT(&panel, x, y) = (warp_rgba8){1, 2, 3, 4};
    warp_planar3_from_rgba_rows(&planar, &src, 0, c.eye_h);
    /* a turn that leaves part of the disc outside the source: its smear stays inside the disc */
    warp_mesh_update(&s.mesh, &s.cam, warp_quat_from_axis_angle((warp_vec3){0, 1, 0}, 0.3));
    warp_mesh_resample(&s.mesh, &planar, &panel, 0, 0, s.vw, s.h);
    int64_t black = 0, lit = 0;
    for (int y = 0; y < s.h; y++)
        for (int x = 0; x < s.vw; x++) {
            warp_rgba8 p = WARP_AT(&panel, s.vw + x, y);
            bool vis = x >= s.span[2 * y] && x < s.span[2 * y + 1];
            assert_int_equal(vis, warp_fov_pixel_visible(&s.lens, rt_config_visible_radius(&c, 1), s.vw, s.h, x, y));
            if (vis) {
                assert_int_equal(p.r, 200);
                assert_int_equal(p.b, 100);
                lit++;
            } else {
                assert_int_equal(p.r, 0);
                assert_int_equal(p.g, 0);
                assert_int_equal(p.b, 0);
                assert_int_equal(p.a, 255);
                black++;
            }
        }
    assert_int_equal(lit, s.visible);
    assert_true(black > 0);
    /* the left half was not touched */
    assert_int_equal(WARP_AT(&panel, 0, 0).a, 4);
    warp_image_free(&src);
    warp_image_free(&panel);
    warp_planar3_free(&planar);
    eye_free(&s);
}

/* The guard band against the `fast` trace (bursts to 300 deg/s) with the simulated host's timing (45 Hz frames
 * rendered at the pose predicted for their arrival, 4 ms transport, shown until the next one arrives, photons
 * photon_offset_ms after each 90 Hz vsync): over 10 s, fewer than 1 % of the visible pixels sample outside the
 * source with the default guard band, but more than that without one. Deterministic: no clock, no threads. */
static double fast_trace_share(const rt_config *c, double *p99)
{
    sim_trace tr;
    assert_true(sim_trace_init(&tr, "fast", (uint64_t)c->seed));
    eye_setup s;
    eye_alloc(&s, c, 0);
    warp_fov_weights w;
    assert_true(warp_fov_weights_alloc(&w, &s.mesh, s.span));
    const double host_period = 1.0 / c->host_rate_hz, render = 0.008, latency = c->host_latency_ms * 1e-3;
    const double vs_period = 1.0 / c->refresh_hz, photon = c->photon_offset_ms * 1e-3;
    enum { N = 900 };
    static double share[N];
    int64_t out = 0, vis = 0;
    for (int k = 0; k < N; k++) {
        const double t_vs = k * vs_period, t_photon = t_vs + photon;
        /* the newest frame that arrived before the vsync: asked for at `start`, rendered at the pose predicted
         * (constant angular velocity from the truth at start) for its arrival */
        const double start = floor((t_vs - render - latency) / host_period) * host_period;
        const double target = start + render + latency;
        warp_vec3 wv = sim_trace_angular_velocity(&tr, start);
        warp_quat q_frame = warp_quat_mul(sim_trace_orientation(&tr, start),
                                          warp_quat_exp(warp_v3_scale(wv, target - start)));
        warp_quat src_from_dst = warp_quat_mul(warp_quat_conj(q_frame), sim_trace_orientation(&tr, t_photon));
        warp_mesh_update(&s.mesh, &s.cam, src_from_dst);
        int64_t o = warp_fov_outside(&w, &s.mesh, s.cam.width, s.cam.height);
        share[k] = (double)o / (double)w.visible;
        out += o;
        vis += w.visible;
    }
    /* p99 by sorting (insertion: small N) */
    for (int i = 1; i < N; i++)
        for (int j = i; j > 0 && share[j - 1] > share[j]; j--) {
            double t = share[j];
            share[j] = share[j - 1];
            share[j - 1] = t;
        }
    *p99 = share[N * 99 / 100];
    warp_fov_weights_free(&w);
    eye_free(&s);
    return (double)out / (double)vis;
}

static void test_fast_trace_guard(void **state)
{
    (void)state;
    rt_config c;
    load_board(&c, "board/sim/board.ini");
    double p99, share = fast_trace_share(&c, &p99);
    if ((getenv("TEST_FOV_VERBOSE") || getenv("TEST_FOV_SWEEP"))) printf("# guard %.2f deg: %.3f %% over the run, p99 %.2f %%\n",
                                          rt_config_guard_deg(&c), 100 * share, 100 * p99);
    assert_true(share < 0.01);
    rt_config_errors err = {0};
    assert_true(rt_config_set(&c, "eye.guard_deg=0", &err));
    double p99_0, share0 = fast_trace_share(&c, &p99_0);
    if ((getenv("TEST_FOV_VERBOSE") || getenv("TEST_FOV_SWEEP"))) printf("# guard 0: %.3f %% over the run, p99 %.2f %%\n", 100 * share0, 100 * p99_0);
    assert_true(share0 > share);
    for (int g = 1; getenv("TEST_FOV_SWEEP") && g <= 8; g++) {
        char set[64];
        snprintf(set, sizeof set, "eye.guard_deg=%d", g);
        assert_true(rt_config_set(&c, set, &err));
        double p, sh = fast_trace_share(&c, &p);
        printf("# guard %d: %.3f %% over the run, p99 %.2f %%\n", g, 100 * sh, 100 * p);
    }
}

/* The auto FOV: the union over the channels of the visible border, plus the guard; the right eye mirrors the left
 * on a mirrored lens; config text round-trips auto. */
static void test_auto_fov_config(void **state)
{
    (void)state;
    rt_config c;
    load_board(&c, "board/sim/board.ini");
    warp_camera l = rt_config_eye_camera(&c, 0), r = rt_config_eye_camera(&c, 1);
    assert_float_equal(l.tan_left, r.tan_right, 1e-9);
    assert_float_equal(l.tan_up, r.tan_up, 1e-9);
    /* the disc touches the viewport's nearest edge: 340 px of 360 px/unit on the sim board */
    assert_float_equal(rt_config_visible_radius(&c, 0), 340.0 / 360.0, 1e-12);
    /* guard widening: atan(t) grows by exactly the guard */
    rt_config z = c;
    rt_config_errors err = {0};
    assert_true(rt_config_set(&z, "eye.guard_deg=0", &err));
    warp_camera l0 = rt_config_eye_camera(&z, 0);
    assert_float_equal(atan(l.tan_left) - atan(l0.tan_left), rt_config_guard_deg(&c) * WARP_PI / 180, 1e-9);
    /* the blue channel reaches furthest: the FOV at guard 0 equals blue's tangent at the disc's leftmost pixel */
    double u, v;
    warp_lens lens = rt_config_lens(&c, 0);
    int y = (int)floor(lens.center_y);
    int32_t *span = malloc(sizeof *span * 2 * (size_t)c.panel_h);
    warp_fov_spans(&lens, rt_config_visible_radius(&c, 0), c.panel_w / 2, c.panel_h, span);
    warp_lens_distort(&lens, 2, span[2 * y] + 0.5, y + 0.5, &u, &v);
    free(span);
    assert_true(l0.tan_left >= -u - 1e-12);
    assert_float_equal(l0.tan_left, -u, 0.01);
    /* keys: auto parses and prints, numbers still work, bad words are refused with the key named */
    char text[4096];
    FILE *f = fmemopen(text, sizeof text, "w");
    rt_config_print(&c, f);
    fclose(f);
    assert_non_null(strstr(text, "fov = auto\n"));
    assert_non_null(strstr(text, "guard_deg = auto\n"));
    assert_non_null(strstr(text, "visible_radius = auto\n"));
    assert_false(rt_config_set(&z, "eye.fov=wide", &err));
    assert_non_null(strstr(err.msg[err.count - 1], "auto or 4 numbers"));
    assert_false(rt_config_set(&z, "eye.guard_deg=-1", &err));
    assert_true(rt_config_set(&z, "lens.visible_radius=0.5", &err));
    assert_float_equal(rt_config_visible_radius(&z, 0), 0.5, 1e-12);
    /* a lens centre off the viewport: no visible region, a clear error naming the keys */
    rt_config bad = c;
    rt_config_errors e2 = {0};
    assert_true(rt_config_set(&bad, "lens.center=-10 400", &e2));
    assert_false(rt_config_validate(&bad, &e2));
    if (!strstr(e2.msg[0], "[lens] center (command line")) fail_msg("%s", e2.msg[0]);
    char line[400];
    rt_config_fov_line(&c, line, sizeof line);
    assert_non_null(strstr(line, "left eye"));
    assert_non_null(strstr(line, "guard band"));
}

/* The line loop: n vertices around the axis, counter-clockwise, each beyond what the border pixels see. */
static void test_mask_loop(void **state)
{
    (void)state;
    rt_config c;
    load_board(&c, "board/sim/board.ini");
    warp_lens lens = rt_config_lens(&c, 0);
    double r = rt_config_visible_radius(&c, 0);
    float uv[2 * WARP_FOV_MASK_MAX];
    assert_int_equal(warp_fov_mask_loop(&lens, r, c.panel_w / 2, c.panel_h, 0, 32, uv), 32);
    double area = 0;
    for (int k = 0; k < 32; k++) {
        int n = (k + 1) % 32;
        area += (double)uv[2 * k] * uv[2 * n + 1] - (double)uv[2 * n] * uv[2 * k + 1];
    }
    assert_true(area > 0);
    /* the leftmost visible pixel of the centre row sees inside the loop's leftmost vertex (k = 16: phi = pi) */
    warp_camera cam0 = rt_config_eye_camera(&c, 0);
    assert_true(-uv[2 * 16] > 0);
    assert_true(-uv[2 * 16] <= cam0.tan_left * 1.01);
    assert_int_equal(warp_fov_mask_loop(&lens, 0, c.panel_w / 2, c.panel_h, 0, 32, uv), 0);
    assert_int_equal(warp_fov_mask_loop(&lens, r, c.panel_w / 2, c.panel_h, 0, 2, uv), 0);
    warp_lens off = lens;
    off.center_x = -5;
    assert_int_equal(warp_fov_mask_loop(&off, r, c.panel_w / 2, c.panel_h, 0, 32, uv), 0);
}

static char build[256], tmp[300];

/* hmdwarpd on the simulated board (half size), `trace` for `secs` seconds on virtual time 6x slower than real (the
 * simulated host keeps its 45 Hz on a loaded machine, so frames have their nominal age: counts, not clock, are
 * judged), its --stats into text. */
static void run_sim(const char *trace, double secs, char *text, size_t cap)
{
    char stats[400], cmd[2048], out[8192];
    snprintf(stats, sizeof stats, "%s/%s.stats", tmp, trace);
    unlink(stats);
    snprintf(cmd, sizeof cmd,
             "HMDWARP_TIME_SLOWDOWN=${HMDWARP_TIME_SLOWDOWN:-6} %s%s/hmdwarpd --config board/sim/board.ini "
             "--set sim.trace=%s --set sim.duration_s=%g --set sim.imu_rest_s=0.3 --set sim.eval_every_ms=0 "
             "--set render.rt_priority=0 --set display.width=720 --set display.height=400 --set eye.width=360 "
             "--set eye.height=400 --set lens.scale=180 --set 'lens.center=190 200' --stats %s 2>&1",
             test_runner(), build, trace, secs, stats);
    int st = -1;
    assert_true(test_capture(cmd, out, sizeof out, &st));
    if (st != 0) fail_msg("%s\n%s", cmd, out);
    assert_true(test_slurp(stats, text, cap) > 0);
    if (getenv("TEST_FOV_VERBOSE")) printf("%s", out);
}

/* The summary's counts: at rest nothing visible samples outside the source; on the fast trace with the default
 * guard band fewer than 1 % of the visible pixels do over the run. */
/* A Vive-class lens ends its view at undistort_r2_cutoff: the auto disc stops there, so no pixel it shows lies
 * beyond it in any channel, while without the cutoff the disc is the eye's half's own. */
static void test_vive_cutoff_bounds_disc(void **state)
{
    (void)state;
    const int vw = 1080, vh = 1200;
    warp_lens_vive_params p = {
        .k = {{-0.022, -0.049, -0.079, 0}, {-0.188, -0.221, -0.254, 0}, {-0.073, -0.023, 0.025, 0}},
        .center = {{0.089, -0.009}, {0.089, -0.009}, {0.089, -0.009}},
        .aspect_x_over_y = 0.9,
        .intrinsics = {0.92, -0.06, 1.02, 0.01},
        .r2_cutoff = 0,
    };
    warp_lens open = warp_lens_vive(&p, vw, vh);
    const double r_open = warp_fov_visible_radius(&open, NAN, vw, vh);
    p.r2_cutoff = 0.5;
    warp_lens cut = warp_lens_vive(&p, vw, vh);
    const double r_cut = warp_fov_visible_radius(&cut, NAN, vw, vh);
    print_message("vive disc: %.4f without the cutoff, %.4f with r2_cutoff 0.5\n", r_open, r_cut);
    assert_true(r_cut > 0 && r_cut < r_open);
    static int32_t span[2 * 1200];
    int64_t shown = warp_fov_spans(&cut, r_cut, vw, vh, span), checked = 0;
    for (int y = 0; y < vh; y++)
        for (int x = span[2 * y]; x < span[2 * y + 1]; x++, checked++)
            for (int c = 0; c < 3; c++) assert_true(warp_lens_in_view(&cut, c, x + 0.5, y + 0.5));
    assert_true(shown > 0 && checked == shown);
    /* a configured radius is the user's: kept as given */
    assert_float_equal(warp_fov_visible_radius(&cut, 0.3, vw, vh), 0.3, 1e-12);
}

static void test_hmdwarpd_outside_share(void **state)
{
    (void)state;
    /* the head turns while a frame ages: paced by the simulated board, so under make check-cross's emulator on
     * its virtual time (at run_sim's 6x qemu-user's frames aged past the guard band: 8.7 % outside; 0.37 % at 20x) */
    test_paced_by_sim(TEST_EMULATOR_SLOWDOWN);
    static char text[65536];
    run_sim("still", 1.0, text, sizeof text);
    assert_true(test_kv(text, "visible_px") > 0);
    assert_true(test_kv(text, "outside_source_px") == 0);
    assert_true(test_kv(text, "outside_source_pct_p99") == 0);
    run_sim("fast", 3.0, text, sizeof text);
    double vis = test_kv(text, "visible_px"), out = test_kv(text, "outside_source_px");
    print_message("fast trace: %.3f %% of the visible pixels outside the source (p99 of frames %.2f %%)\n",
                  100 * out / vis, test_kv(text, "outside_source_pct_p99"));
    assert_true(vis > 0 && out >= 0);
    assert_true(out < 0.01 * vis);
}

int main(int argc, char **argv)
{
    (void)argc;
    if (!test_build_dirs(argv[0], build, sizeof build, tmp, sizeof tmp, "fov")) return 1;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sim_board_at_rest), cmocka_unit_test(test_rpi5_board_at_rest),
        cmocka_unit_test(test_fixed_fov_overreaches), cmocka_unit_test(test_mask_black),
        cmocka_unit_test(test_fast_trace_guard), cmocka_unit_test(test_auto_fov_config),
        cmocka_unit_test(test_mask_loop), cmocka_unit_test(test_vive_cutoff_bounds_disc),
        cmocka_unit_test(test_hmdwarpd_outside_share),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
