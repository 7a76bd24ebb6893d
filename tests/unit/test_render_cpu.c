/* SPDX-License-Identifier: MIT */
/* The CPU render pass: hmdwarp-bench's display path gives the daemon's bytes for the same host frame and poses
 * (the pass rt_app_init builds against the one the bench builds), it draws a picture, and frames lacking a plane
 * fall down the registry's ladder and are counted; raytrace_mesh's vertices alone change only its marked cells. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "runtime/rt_app.h"
#include "sim/sim_scene.h"
#include "tests/support/test_settings.h"
#include "tools/hmdwarp-bench/bench_display.h"

static rt_app app;

/* The bench's panel at a test's size (96x96 eyes, the reference lens scaled to them), on the simulated board with
 * the CPU renderer: what `hmdwarp-bench --eye 96x96` and hmdwarpd with this panel both run. */
static void config(rt_config *c)
{
    bench_config(c, false, 96, 96);
    const char *sets[] = {"render.renderer=cpu", "render.rt_priority=0", "render.threads=2",
                          "display.output=offscreen"};
    test_set_all(c, sets, sizeof sets / sizeof sets[0]);
}

/* The host frame: scene `near` from a head pose, both eyes, colour and depth; eyes: where the display warps to (3
 * degrees of yaw and 2 cm sideways on). */
static void host_frame(bench_display *d, const rt_config *c, warp_pose eyes[2])
{
    const sim_scene *sc = sim_scene_find("near");
    assert_non_null(sc);
    warp_head h = warp_head_default();
    h.ipd = c->ipd;
    warp_pose head = warp_head_pose_from_orientation(&h, warp_quat_from_ypr(0.1, 0.02, 0));
    warp_pose moved = warp_pose_mul(head, (warp_pose){warp_quat_from_ypr(3 * WARP_PI / 180, 0, 0), warp_v3(0.02, 0, 0)});
    warp_camera cam[2];
    warp_pose pose[2];
    sim_buffers b[2];
    for (int e = 0; e < 2; e++) {
        cam[e] = rt_config_eye_camera(c, e);
        pose[e] = warp_head_eye_pose(&h, head, e);
        eyes[e] = warp_head_eye_pose(&h, moved, e);
        assert_true(sim_buffers_alloc(&b[e], cam[e].width, cam[e].height, SIM_PLANE_COLOR | SIM_PLANE_DEPTH, 1));
        sim_render(sc, 1.0, pose[e], &cam[e], SIM_PLANE_COLOR | SIM_PLANE_DEPTH, &b[e]);
    }
    const warp_image_rgba8 *const color[2] = {&b[0].color, &b[1].color};
    const warp_image_f32 *const depth[2] = {&b[0].depth, &b[1].depth};
    char err[200];
    if (!bench_display_set_frame(d, cam, pose, color, depth, 7, err, sizeof err)) fail_msg("%s", err);
    for (int e = 0; e < 2; e++) sim_buffers_free(&b[e]);
}

/* The bench's display path on two threads (its workers returned, for the caller to destroy) with the host frame
 * and the eye poses it warps to. */
static plat_workers *bench_two_threads(rt_config *c, bench_display *d, warp_pose eyes[2])
{
    config(c);
    plat_workers *w = plat_workers_create(1, 0);
    assert_non_null(w);
    char err[400] = "";
    if (!bench_display_init(d, c, w, NULL, err, sizeof err)) fail_msg("bench_display_init: %s", err);
    host_frame(d, c, eyes);
    return w;
}

static bool same_image(const warp_image_rgba8 *a, const warp_image_rgba8 *b)
{
    if (a->w != b->w || a->h != b->h) return false;
    for (int y = 0; y < a->h; y++)
        if (memcmp(&WARP_AT(a, 0, y), &WARP_AT(b, 0, y), sizeof(warp_rgba8) * (size_t)a->w)) return false;
    return true;
}

static long lit_pixels(const warp_image_rgba8 *img)
{
    long n = 0;
    for (int y = 0; y < img->h; y++)
        for (int x = 0; x < img->w; x++) {
            warp_rgba8 p = WARP_AT(img, x, y);
            n += p.r || p.g || p.b;
        }
    return n;
}

static void clear(warp_image_rgba8 *img)
{
    for (int y = 0; y < img->h; y++) memset(&WARP_AT(img, 0, y), 0, sizeof(warp_rgba8) * (size_t)img->w);
}

static void test_bench_shows_what_the_daemon_shows(void **state)
{
    (void)state;
    rt_config c;
    config(&c);
    char err[400] = "";
    if (!rt_app_init(&app, &c, err, sizeof err)) fail_msg("rt_app_init: %s", err);
    /* two threads, as the daemon's, and the bench's one-thread pass: the split into tasks must not show (the
     * raytrace's bands once read their neighbours' rows before those were traced) */
    plat_workers *w = plat_workers_create(1, 0), *w1 = plat_workers_create(0, 0);
    assert_non_null(w);
    assert_non_null(w1);
    bench_display d;
    if (!bench_display_init(&d, &c, w, w1, err, sizeof err)) fail_msg("bench_display_init: %s", err);
    warp_pose eyes[2];
    host_frame(&d, &c, eyes);
    warp_image_rgba8 daemon, none;
    assert_true(warp_image_rgba8_alloc(&daemon, c.panel_w, c.panel_h));
    assert_true(warp_image_rgba8_alloc(&none, c.panel_w, c.panel_h));

    static const rt_method methods[] = {RT_METHOD_NONE, RT_METHOD_ROTATION, RT_METHOD_RAYTRACE,
                                        RT_METHOD_RAYTRACE_MESH};
    for (size_t i = 0; i < sizeof methods / sizeof methods[0]; i++) {
        rt_method m = methods[i];
        clear(&d.panel);
        clear(&daemon);
        assert_int_equal(bench_display_run(&d, 0, eyes, m), m);
        assert_int_equal(rt_render_cpu_frame(app.render, &d.frame, eyes, m, NULL, &daemon), m);
        long lit = lit_pixels(&daemon);
        print_message("%s: %ld of %d pixels lit\n", rt_method_name(m), lit, c.panel_w * c.panel_h);
        /* a picture: most of the panel inside the lens' field lit */
        assert_true(lit > c.panel_w * c.panel_h / 4);
        if (!same_image(&d.panel, &daemon)) fail_msg("%s: the bench's panel differs from the daemon's", rt_method_name(m));
        clear(&d.panel);
        assert_int_equal(bench_display_run(&d, 1, eyes, m), m);
        if (!same_image(&d.panel, &daemon)) fail_msg("%s: one thread draws other bytes than two", rt_method_name(m));
        if (m == RT_METHOD_NONE) {
            for (int y = 0; y < none.h; y++) memcpy(&WARP_AT(&none, 0, y), &WARP_AT(&daemon, 0, y), sizeof(warp_rgba8) * (size_t)none.w);
        } else {
            /* the eye poses were used: every warp moves the picture away from the unwarped one */
            assert_false(same_image(&none, &daemon));
        }
    }

    /* The comparison can fail: a pass built from another lens (1 % wider) draws other bytes. */
    rt_render_cpu_params p = rt_render_cpu_params_from_config(&c);
    for (int e = 0; e < 2; e++) p.lens[e].scale *= 1.01;
    rt_render_cpu *other = rt_render_cpu_create(&p, w, err, sizeof err);
    assert_non_null(other);
    assert_int_equal(rt_render_cpu_frame(other, &d.frame, eyes, RT_METHOD_ROTATION, NULL, &daemon),
                     RT_METHOD_ROTATION);
    assert_int_equal(bench_display_run(&d, 0, eyes, RT_METHOD_ROTATION), RT_METHOD_ROTATION);
    assert_false(same_image(&d.panel, &daemon));
    rt_render_cpu_destroy(&other);
    assert_null(other);

    warp_image_free(&daemon);
    warp_image_free(&none);
    bench_display_free(&d);
    plat_workers_destroy(w);
    plat_workers_destroy(w1);
    rt_app_free(&app);
}

static void test_frame_lacking_planes_falls_back(void **state)
{
    (void)state;
    rt_config c;
    config(&c);
    plat_workers *w = plat_workers_create(0, 0);
    assert_non_null(w);
    bench_display d;
    char err[200];
    if (!bench_display_init(&d, &c, w, NULL, err, sizeof err)) fail_msg("%s", err);
    warp_pose eyes[2];
    host_frame(&d, &c, eyes);
    warp_image_rgba8 rot;
    assert_true(warp_image_rgba8_alloc(&rot, c.panel_w, c.panel_h));
    assert_int_equal(bench_display_run(&d, 0, eyes, RT_METHOD_ROTATION), RT_METHOD_ROTATION);
    for (int y = 0; y < rot.h; y++) memcpy(&WARP_AT(&rot, 0, y), &WARP_AT(&d.panel, 0, y), sizeof(warp_rgba8) * (size_t)rot.w);
    rt_render_cpu_stats st = rt_render_cpu_stats_get(d.pass[0]);
    assert_int_equal(st.raytrace_fallbacks, 0);
    assert_int_equal(st.plane_fallbacks, 0);

    /* The same frame without its depth (a host that sends colour only): both raytraces become the rotation, and
     * draw its very picture, each counted. */
    d.frame.f.planes = DRV_PLANE_COLOR;
    assert_int_equal(rt_frame_prepare(&d.frame), DRV_FRAME_OK);
    assert_false(d.frame.has_depth);
    clear(&d.panel);
    assert_int_equal(bench_display_run(&d, 0, eyes, RT_METHOD_RAYTRACE), RT_METHOD_ROTATION);
    assert_true(same_image(&d.panel, &rot));
    assert_int_equal(bench_display_run(&d, 0, eyes, RT_METHOD_RAYTRACE_MESH), RT_METHOD_ROTATION);
    st = rt_render_cpu_stats_get(d.pass[0]);
    assert_int_equal(st.raytrace_fallbacks, 2);
    assert_int_equal(st.plane_fallbacks, 0);

    /* With depth but no layers or ids (and a pass not built for those warps): the raytrace, counted as a plane
     * fallback. */
    d.frame.f.planes = DRV_PLANE_COLOR | DRV_PLANE_DEPTH;
    assert_int_equal(rt_frame_prepare(&d.frame), DRV_FRAME_OK);
    assert_int_equal(bench_display_run(&d, 0, eyes, RT_METHOD_TRANSPARENCY), RT_METHOD_RAYTRACE);
    assert_int_equal(bench_display_run(&d, 0, eyes, RT_METHOD_OBJECTS), RT_METHOD_RAYTRACE);
    st = rt_render_cpu_stats_get(d.pass[0]);
    assert_int_equal(st.raytrace_fallbacks, 2);
    assert_int_equal(st.plane_fallbacks, 2);

    warp_image_free(&rot);
    bench_display_free(&d);
    plat_workers_destroy(w);
}

/* A pass that cannot be built says what was wrong, and the pass without eye buffers (rotation only) never runs a depth warp
 * into them. */
static void test_bad_params(void **state)
{
    (void)state;
    rt_config c;
    config(&c);
    plat_workers *w = plat_workers_create(0, 0);
    assert_non_null(w);
    char err[200] = "";
    rt_render_cpu_params p = rt_render_cpu_params_from_config(&c);
    p.mesh_n = 0;
    assert_null(rt_render_cpu_create(&p, w, err, sizeof err));
    print_message("%s\n", err);
    assert_non_null(strstr(err, "[lens] mesh = 0"));
    p = rt_render_cpu_params_from_config(&c);
    p.eye_h = 0;
    assert_null(rt_render_cpu_create(&p, w, err, sizeof err));
    print_message("%s\n", err);
    assert_non_null(strstr(err, "96x0 eyes"));

    c.method = RT_METHOD_ROTATION;
    p = rt_render_cpu_params_from_config(&c);
    assert_false(p.depth_warps);
    rt_render_cpu *r = rt_render_cpu_create(&p, w, err, sizeof err);
    assert_non_null(r);
    bench_display d;
    if (!bench_display_init(&d, &c, w, NULL, err, sizeof err)) fail_msg("%s", err);
    warp_pose eyes[2];
    host_frame(&d, &c, eyes);
    assert_int_equal(rt_render_cpu_frame(r, &d.frame, eyes, RT_METHOD_RAYTRACE, NULL, &d.panel), RT_METHOD_ROTATION);
    assert_int_equal(rt_render_cpu_stats_get(r).raytrace_fallbacks, 1);
    rt_render_cpu_destroy(&r);
    rt_render_cpu_destroy(&r); /* cleared: a second destroy is harmless */
    bench_display_free(&d);
    plat_workers_destroy(w);
}

/* Rolling scanout (#20): with the first and last line's poses equal to the mid-scan ones the pass draws the global
 * pass's bytes; apart, the mesh warps (rotation, raytrace_mesh) move and the per-pixel raytrace keeps the mid-scan
 * pose; a global panel ignores them. */
static void test_rolling_scan(void **state)
{
    (void)state;
    rt_config c;
    bench_display d;
    warp_pose eyes[2], first[2], last[2];
    plat_workers *w = bench_two_threads(&c, &d, eyes);
    char err[400] = "";
    /* a turn: 1.5 degrees of yaw either side of mid-scan */
    for (int e = 0; e < 2; e++) {
        first[e] = last[e] = eyes[e];
        first[e].q = warp_quat_mul(eyes[e].q, warp_quat_from_ypr(-1.5 * WARP_PI / 180, 0, 0));
        last[e].q = warp_quat_mul(eyes[e].q, warp_quat_from_ypr(1.5 * WARP_PI / 180, 0, 0));
    }
    rt_render_cpu_params p = rt_render_cpu_params_from_config(&c);
    assert_false(p.scan.rolling); /* the default */
    rt_render_cpu *global = rt_render_cpu_create(&p, w, err, sizeof err);
    p.scan = (warp_scan){true, WARP_SCAN_TOP_TO_BOTTOM, 0.01, c.panel_w, c.panel_h};
    rt_render_cpu *rolling = rt_render_cpu_create(&p, w, err, sizeof err);
    assert_non_null(global);
    assert_non_null(rolling);
    warp_image_rgba8 g, r;
    assert_true(warp_image_rgba8_alloc(&g, c.panel_w, c.panel_h));
    assert_true(warp_image_rgba8_alloc(&r, c.panel_w, c.panel_h));
    static const rt_method methods[] = {RT_METHOD_ROTATION, RT_METHOD_RAYTRACE, RT_METHOD_RAYTRACE_MESH};
    for (size_t i = 0; i < sizeof methods / sizeof methods[0]; i++) {
        rt_method m = methods[i];
        assert_int_equal(rt_render_cpu_frame(global, &d.frame, eyes, m, NULL, &g), m);
        assert_int_equal(rt_render_cpu_frame_scan(rolling, &d.frame, eyes, eyes, eyes, m, NULL, &r), m);
        if (!same_image(&g, &r)) fail_msg("%s: a still head on a rolling panel differs from global", rt_method_name(m));
        assert_int_equal(rt_render_cpu_frame_scan(global, &d.frame, eyes, first, last, m, NULL, &r), m);
        if (!same_image(&g, &r)) fail_msg("%s: a global panel used the scan's poses", rt_method_name(m));
        assert_int_equal(rt_render_cpu_frame_scan(rolling, &d.frame, eyes, first, last, m, NULL, &r), m);
        if (m == RT_METHOD_ROTATION) /* what the GLES renderer draws through: the CPU pass's very mesh */
            for (int e = 0; e < 2; e++) {
                warp_mesh *cpu = rt_render_cpu_mesh(rolling, e);
                const size_t n = (size_t)cpu->rows * (size_t)cpu->cols * 3;
                warp_vec2f *was = malloc(n * sizeof *was);
                assert_non_null(was);
                memcpy(was, cpu->src, n * sizeof *was);
                /* a global update in between, so the call below must redo the rolling one to match */
                rt_render_cpu_mesh_for(rolling, &d.frame, e, m, eyes[e], NULL, NULL);
                assert_true(memcmp(was, cpu->src, n * sizeof *was) != 0);
                assert_ptr_equal(rt_render_cpu_mesh_for(rolling, &d.frame, e, m, eyes[e], first, last), cpu);
                assert_memory_equal(was, cpu->src, n * sizeof *was);
                free(was);
            }
        if (m == RT_METHOD_RAYTRACE) {
            if (!same_image(&g, &r)) fail_msg("raytrace: the per-pixel raytrace left the mid-scan pose");
        } else if (same_image(&g, &r)) {
            fail_msg("%s: the scan's poses were not used", rt_method_name(m));
        }
    }
    warp_image_free(&g);
    warp_image_free(&r);
    rt_render_cpu_destroy(&global);
    rt_render_cpu_destroy(&rolling);
    bench_display_free(&d);
    plat_workers_destroy(w);
}

/* raytrace_mesh with its vertices alone (what `make bench` times beside it, so that the per-pixel cells' cost shows):
 * the panel differs from the full warp's in the marked cells only, the marks stay, and switched back the full warp's
 * bytes return. [warp] mesh_cells = false (a CPU board's choice) makes a pass that draws those very bytes. */
static void test_mesh_vertices_only(void **state)
{
    (void)state;
    rt_config c;
    bench_display d;
    warp_pose eyes[2];
    plat_workers *w = bench_two_threads(&c, &d, eyes);
    warp_image_rgba8 full;
    assert_true(warp_image_rgba8_alloc(&full, c.panel_w, c.panel_h));
    const rt_method m = RT_METHOD_RAYTRACE_MESH;
    assert_int_equal(bench_display_run(&d, 0, eyes, m), m);
    for (int y = 0; y < full.h; y++)
        memcpy(&WARP_AT(&full, 0, y), &WARP_AT(&d.panel, 0, y), sizeof(warp_rgba8) * (size_t)full.w);
    int marked[2];
    for (int e = 0; e < 2; e++) marked[e] = rt_render_cpu_mesh_trace(d.pass[0], e)->marked;
    assert_true(marked[0] + marked[1] > 0);

    rt_render_cpu_mesh_vertices_only(d.pass[0], true);
    assert_int_equal(bench_display_run(&d, 0, eyes, m), m);
    long differ = 0;
    for (int e = 0; e < 2; e++) {
        const warp_mesh *me = rt_render_cpu_mesh(d.pass[0], e);
        const warp_mesh_trace *t = rt_render_cpu_mesh_trace(d.pass[0], e);
        assert_int_equal(t->marked, marked[e]);
        for (int y = 0; y < me->vp_h; y++)
            for (int x = 0; x < me->vp_w; x++) {
                const warp_rgba8 a = WARP_AT(&full, me->vp_x + x, me->vp_y + y),
                                 b = WARP_AT(&d.panel, me->vp_x + x, me->vp_y + y);
                if (!memcmp(&a, &b, sizeof a)) continue;
                differ++;
                /* the cell the resampler puts (x, y) in (warp_mesh.h: rows in bands, columns cell_w wide) */
                int j = (int)(((double)y + 0.5) * (me->rows - 1) / me->vp_h);
                j = j < me->rows - 2 ? j : me->rows - 2;
                if (!t->cell[(size_t)j * t->cells_x + x / me->cell_w])
                    fail_msg("eye %d pixel (%d, %d) changed outside the marked cells", e, x, y);
            }
    }
    print_message("vertices alone: %ld pixels differ, all in the %d marked cells\n", differ, marked[0] + marked[1]);
    assert_true(differ > 0);

    /* the same from the config: mesh_cells is on by default, and off it draws the vertices alone */
    assert_true(rt_render_cpu_params_from_config(&c).mesh_cells);
    assert_false(rt_render_cpu_mesh_cells(d.pass[0]));
    rt_config_errors ce;
    rt_config off = c;
    assert_false(rt_config_set(&off, "warp.mesh_cells=no", &ce));
    assert_true(rt_config_set(&off, "warp.mesh_cells=false", &ce));
    const rt_render_cpu_params po = rt_render_cpu_params_from_config(&off);
    assert_false(po.mesh_cells);
    char err[400] = "";
    rt_render_cpu *vo = rt_render_cpu_create(&po, w, err, sizeof err);
    if (!vo) fail_msg("rt_render_cpu_create: %s", err);
    assert_false(rt_render_cpu_mesh_cells(vo));
    warp_image_rgba8 img;
    assert_true(warp_image_rgba8_alloc(&img, c.panel_w, c.panel_h));
    assert_int_equal(rt_render_cpu_frame(vo, &d.frame, eyes, m, NULL, &img), m);
    assert_true(same_image(&img, &d.panel));
    warp_image_free(&img);
    rt_render_cpu_destroy(&vo);

    rt_render_cpu_mesh_vertices_only(d.pass[0], false);
    assert_true(rt_render_cpu_mesh_cells(d.pass[0]));
    assert_int_equal(bench_display_run(&d, 0, eyes, m), m);
    assert_true(same_image(&d.panel, &full));
    warp_image_free(&full);
    bench_display_free(&d);
    plat_workers_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bench_shows_what_the_daemon_shows),
        cmocka_unit_test(test_frame_lacking_planes_falls_back),
        cmocka_unit_test(test_bad_params),
        cmocka_unit_test(test_rolling_scan),
        cmocka_unit_test(test_mesh_vertices_only),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
