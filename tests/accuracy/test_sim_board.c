/* SPDX-License-Identifier: MIT */
/* End-to-end runs of hmdwarpd's runtime on the simulated board (IMU, host and vsync simulated in-process):
 * frames flow, tracking follows the true head, only the planes a scene needs are rendered, warps are chosen as
 * configured. Short runs with small panels; assertions are about behaviour, not speed. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "runtime/rt_app.h"
#include "runtime/rt_simboard.h"
#include "tests/support/test_run.h"
#include "tests/support/test_settings.h"
#include "tests/support/test_util.h"
#include "warp/warp_resample.h"

/* A split of time (whose misses, how much earlier a pass starts) is judged only while other processes used less
 * than this share of the CPUs: on a busy machine the scheduler's share is real and is the scheduler's. */
#define QUIET_OTHERS 0.15

static void small_config(rt_config *c, const char *scene, const char *method)
{
    rt_config_defaults(c);
    const char *sets[] = {"display.width=640", "display.height=360", "eye.width=320", "eye.height=360",
                          "lens.scale=180", "lens.center=170 180", "sim.duration_s=1.5", "sim.eval_every_ms=300",
                          "render.rt_priority=0", "sim.trace=fast"};
    test_set_all(c, sets, sizeof sets / sizeof sets[0]);
    test_setf(c, "sim.scene=%s", scene);
    test_setf(c, "warp.method=%s", method);
    test_validate(c);
}

static rt_app app;

static void run(const rt_config *c)
{
    char err[300];
    if (!rt_app_init(&app, c, err, sizeof err)) fail_msg("init: %s", err);
    rt_app_run(&app);
}

static void test_rotation_only_scene(void **state)
{
    (void)state;
    rt_config c;
    small_config(&c, "room", "rotation");
    /* a fixed 1.5 s, not until it has its data: the evaluator scores every record after the stop (each a
     * ground-truth render), and a longer run on a busy machine left minutes of that backlog. So the counts are
     * floors every path clears on any load ("carries data"), and the vsyncs are bounded by the run's length. */
    test_others others0 = test_others_mark();
    run(&c);
    double others = test_others_share(others0);
    rt_telemetry *t = app.tel;
    print_message("vsyncs %llu missed %llu frames %llu imu %llu eval %d\n", (unsigned long long)t->vsyncs,
                  (unsigned long long)t->missed, (unsigned long long)t->frames_received,
                  (unsigned long long)t->imu_samples, rt_simboard_eval(app.sim)->acc[RT_EVAL_NONE].n);
    assert_true(t->vsyncs >= 120 && t->vsyncs <= test_run_max_vsyncs(&app, 90)); /* 1.5 s at 90 Hz, skipped ones too */
    assert_true(t->frames_received >= 2);                                          /* 10 quiet */
    assert_true(t->imu_samples >= 100);                                            /* 1300 quiet */
    assert_true(t->method_count[RT_METHOD_ROTATION] >= 10);                        /* 100 quiet */
    /* a rotation-only scene never pays for depth */
    assert_int_equal(rt_simboard_plane_renders(app.sim)[1], 0);
    assert_true(rt_simboard_plane_renders(app.sim)[0] == rt_simboard_host_frames(app.sim));
    /* the tracker follows the true head (biased, noisy gyro) */
    rt_fusion_state st;
    assert_true(rt_fusion_latest(app.fusion, &st));
    warp_quat truth = sim_trace_orientation(rt_simboard_trace(app.sim), (double)(st.t_ns - app.t0_ns) * 1e-9);
    assert_true(warp_quat_angle_between(truth, st.q) < 2.0 * WARP_PI / 180);
    /* latencies are measured and plausible: IMU sample to photon within a frame or so (on a busy machine within a
     * second: a pass kept off its CPU shows an older sample) */
    print_message("m2p p50 %.2f ms, other processes used %.0f %% of the CPUs\n", rt_hist_pct(&t->m2p_ms, 50), others * 100);
    assert_true(rt_hist_pct(&t->m2p_ms, 50) > 0 && rt_hist_pct(&t->m2p_ms, 50) < (others < QUIET_OTHERS ? 30 : 1000));
    assert_true(rt_simboard_eval(app.sim)->acc[RT_EVAL_NONE].n >= 1);
    rt_app_free(&app);
}

/* A warp that cannot fit the period (full-size eyes, one thread, 500 Hz): the misses are hmdwarpd's own, and the
 * causes account for every miss. */
static void test_misses_attributed(void **state)
{
    (void)state;
    rt_config c;
    rt_config_defaults(&c);
    const char *sets[] = {"display.refresh_hz=500", "render.threads=1", "render.rt_priority=0", "sim.duration_s=0.5",
                          "sim.scene=room", "warp.method=rotation"};
    test_set_all(&c, sets, sizeof sets / sizeof sets[0]);
    test_validate(&c);
    test_others others0 = test_others_mark();
    run(&c);
    rt_telemetry *t = app.tel;
    uint64_t sum = 0;
    for (int m = 0; m < RT_MISS_COUNT; m++) sum += t->missed_by[m];
    print_message("vsyncs %llu missed %llu own %llu\n", (unsigned long long)t->vsyncs, (unsigned long long)t->missed,
                  (unsigned long long)t->missed_by[RT_MISS_OWN]);
    assert_true(t->missed * 2 > t->vsyncs);
    assert_true(sum == t->missed);
    /* 90 % its own on a quiet machine; on a busy one the scheduler's share is real (judged as a majority there) */
    double others = test_others_share(others0);
    print_message("other processes used %.0f %% of the CPUs\n", others * 100);
    if (others < QUIET_OTHERS) assert_true(t->missed_by[RT_MISS_OWN] * 10 >= t->missed * 9);
    else assert_true(t->missed_by[RT_MISS_OWN] * 2 >= t->missed);
    rt_app_free(&app);
}

/* [render] stall_reserve_ms: each pass starts that much earlier (more than a period ahead here), so motion-to-photon
 * grows by about as much; the swapchain has the fourth image that needs, and the passes still find a free one. */
static void test_stall_reserve_starts_passes_earlier(void **state)
{
    (void)state;
    double m2p[2];
    test_others others0 = test_others_mark();
    for (int k = 0; k < 2; k++) {
        rt_config c;
        small_config(&c, "room", "rotation");
        rt_config_errors e = {0};
        assert_true(rt_config_set(&c, k ? "render.stall_reserve_ms=8" : "render.stall_reserve_ms=0", &e));
        /* no accuracy evaluation: this test scores none, and on a busy machine the evaluator's backlog kept the run
         * scoring for minutes after the display stopped */
        assert_true(rt_config_set(&c, "sim.eval_every_ms=0", &e));
        run(&c);
        rt_telemetry *t = app.tel;
        m2p[k] = rt_hist_pct(&t->m2p_ms, 50);
        print_message("reserve %d ms: m2p p50 %.2f ms, vsyncs %llu, missed %llu, no image %llu\n", k ? 8 : 0, m2p[k],
                      (unsigned long long)t->vsyncs, (unsigned long long)t->missed,
                      (unsigned long long)t->no_buffer);
        assert_int_equal(app.sc.count, k ? 4 : 3);
        assert_int_equal(t->no_buffer, 0);
        /* the passes warped (not a count of a quiet machine's ~135: an ASan build beside other work skipped 86 of
         * 136 vsyncs as overruns) */
        assert_true(t->method_count[RT_METHOD_ROTATION] >= 20);
        rt_app_free(&app);
    }
    /* 8 ms earlier starts show as 6-10 ms more motion-to-photon; judged on a quiet machine (a busy one moves the
     * medians by the time passes wait for a CPU), reported otherwise */
    double others = test_others_share(others0);
    print_message("m2p p50 grew %.2f ms; other processes used %.0f %% of the CPUs\n", m2p[1] - m2p[0], others * 100);
    if (others < QUIET_OTHERS) assert_true(m2p[1] - m2p[0] > 6 && m2p[1] - m2p[0] < 10);
}

/* [render] kernel picks the resampling kernel for the run; auto gives the choice back to the CPU check. */
static void test_kernel_choice(void **state)
{
    (void)state;
    rt_config c;
    small_config(&c, "room", "rotation");
    rt_config_errors e = {0};
    char err[300];
    assert_true(rt_config_set(&c, "render.kernel=scalar", &e));
    if (!rt_app_init(&app, &c, err, sizeof err)) fail_msg("init: %s", err);
    assert_string_equal(warp_resample_kernel(), "scalar");
    rt_app_free(&app);
    assert_true(rt_config_set(&c, "render.kernel=auto", &e));
    if (!rt_app_init(&app, &c, err, sizeof err)) fail_msg("init: %s", err);
    assert_string_not_equal(warp_resample_kernel(), "scalar");
    rt_app_free(&app);
}

static void test_depth_scene_raytrace(void **state)
{
    (void)state;
    rt_config c;
    small_config(&c, "near", "raytrace");
    run(&c);
    rt_telemetry *t = app.tel;
    assert_true(rt_simboard_plane_renders(app.sim)[1] > 0); /* translation scene: the host sends depth */
    assert_true(t->method_count[RT_METHOD_RAYTRACE] > 0);
    assert_int_equal(rt_render_cpu_stats_get(app.render).raytrace_fallbacks, 0);
    const uint64_t *planes = rt_simboard_plane_renders(app.sim);
    assert_int_equal(planes[2] + planes[3] + planes[4], 0);
    rt_app_free(&app);
}

/* [warp] method = raytrace_mesh: the raytrace traced at the lens mesh's vertices runs, with no fallback, and the
 * summary names it. */
static void test_depth_scene_raytrace_mesh(void **state)
{
    (void)state;
    rt_config c;
    small_config(&c, "near", "raytrace_mesh");
    rt_config_errors e = {0};
    assert_true(rt_config_set(&c, "sim.trace=translate", &e));
    assert_int_equal(c.method, RT_METHOD_RAYTRACE_MESH);
    run(&c);
    rt_telemetry *t = app.tel;
    assert_true(rt_simboard_plane_renders(app.sim)[1] > 0);
    assert_true(t->method_count[RT_METHOD_RAYTRACE_MESH] > 0);
    assert_int_equal(t->method_count[RT_METHOD_ROTATION] + t->method_count[RT_METHOD_RAYTRACE], 0);
    assert_int_equal(rt_render_cpu_stats_get(app.render).raytrace_fallbacks, 0);
    assert_int_equal(rt_render_cpu_stats_get(app.render).plane_fallbacks, 0);
    char *text = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&text, &len);
    assert_non_null(f);
    rt_app_summary(&app, f);
    fclose(f);
    assert_non_null(strstr(text, "warp method raytrace_mesh"));
    assert_non_null(strstr(text, "warp time (raytrace_mesh)"));
    assert_non_null(strstr(text, "raytrace at mesh vertices"));
    free(text);
    /* Against ground truth the mesh raytrace is scored on the same frames as the others: it corrects what the
     * unwarped frame gets wrong about as well as the per-pixel raytrace does (the latency's few millimetres of
     * translation separate the warps by tenths of a dB here, too little to rank them). */
    const rt_eval_acc *acc = rt_simboard_eval(app.sim)->acc;
    const rt_eval_acc *none = &acc[RT_EVAL_NONE], *rot = &acc[RT_EVAL_ROTATION], *ray = &acc[RT_EVAL_RAYTRACE],
                      *mesh = &acc[RT_EVAL_RAYTRACE_MESH];
    assert_true(mesh->n >= 2 && mesh->n == none->n && mesh->n == ray->n);
    const double p_none = none->psnr_sum / none->n, p_rot = rot->psnr_sum / rot->n, p_ray = ray->psnr_sum / ray->n,
                 p_mesh = mesh->psnr_sum / mesh->n;
    print_message("PSNR vs truth over %d frames: no warp %.2f dB, rotation %.2f dB, raytrace %.2f dB, mesh raytrace "
                  "%.2f dB\n", mesh->n, p_none, p_rot, p_ray, p_mesh);
    assert_true(p_mesh > p_none + 3);
    assert_true(fabs(p_mesh - p_ray) < 1);
    /* The last vsync's mesh holds traced positions, not the lens-only ones the per-pixel path leaves there (the
     * head moved between the frame and the vsync, so they differ). */
    warp_mesh *m = rt_render_cpu_mesh(app.render, 0);
    size_t n = (size_t)m->rows * (size_t)m->cols * 3;
    warp_vec2f *traced = malloc(n * sizeof *traced);
    assert_non_null(traced);
    memcpy(traced, m->src, n * sizeof *traced);
    warp_mesh_update(m, &app.eye_cam[0], warp_quat_identity());
    double most = 0;
    for (size_t k = 0; k < n; k++) {
        double d = fabs(traced[k].x - m->src[k].x) + fabs(traced[k].y - m->src[k].y);
        most = d > most ? d : most;
    }
    free(traced);
    print_message("mesh raytrace: last vsync's vertices up to %.2f px from the lens-only mesh\n", most);
    assert_true(most > 0.5);
    rt_app_free(&app);
}

static void test_raytrace_without_depth_falls_back(void **state)
{
    (void)state;
    rt_config c;
    small_config(&c, "room", "raytrace");
    run(&c);
    assert_true(rt_render_cpu_stats_get(app.render).raytrace_fallbacks > 0);
    assert_int_equal(app.tel->method_count[RT_METHOD_RAYTRACE], 0);
    assert_true(app.tel->method_count[RT_METHOD_ROTATION] > 0);
    rt_app_free(&app);
}

/* ---- auto selection (rt_select in the compositor) ---- */

static void auto_config(rt_config *c, const char *scene)
{
    small_config(c, scene, "auto");
    /* a slower panel, so the depth warps fit the frame time on this 2-core machine: the choice is what is tested */
    const char *sets[] = {"display.refresh_hz=30", "sim.host_rate_hz=15", "sim.trace=translate",
                          "sim.eval_every_ms=0", "display.width=320", "display.height=180", "eye.width=160",
                          "eye.height=180", "lens.scale=90", "lens.center=85 90"};
    test_set_all(c, sets, sizeof sets / sizeof sets[0]);
    test_validate(c);
}

static void test_auto_rotation_only_scene_never_pays_for_depth(void **state)
{
    (void)state;
    rt_config c;
    auto_config(&c, "room");
    run(&c);
    rt_telemetry *t = app.tel;
    for (int m = RT_METHOD_RAYTRACE; m < RT_METHOD_COUNT; m++) assert_int_equal(t->method_count[m], 0);
    const uint64_t *planes = rt_simboard_plane_renders(app.sim);
    assert_int_equal(planes[1] + planes[2] + planes[4], 0);
    assert_true(t->select_why[RT_WHY_ROTATION_ONLY] > 0);
    assert_int_equal(t->select_why[RT_WHY_PARALLAX], 0);
    rt_app_free(&app);
}

static void test_auto_translation_escalates_and_is_stable(void **state)
{
    (void)state;
    rt_config c;
    auto_config(&c, "near");
    run(&c);
    rt_telemetry *t = app.tel;
    print_message("near: rotation %llu raytrace %llu mesh %llu, why parallax %llu small %llu held %llu time %llu, switches %llu\n",
                  (unsigned long long)t->method_count[RT_METHOD_ROTATION],
                  (unsigned long long)t->method_count[RT_METHOD_RAYTRACE],
                  (unsigned long long)t->method_count[RT_METHOD_RAYTRACE_MESH],
                  (unsigned long long)t->select_why[RT_WHY_PARALLAX],
                  (unsigned long long)t->select_why[RT_WHY_PARALLAX_SMALL],
                  (unsigned long long)t->select_why[RT_WHY_HELD], (unsigned long long)t->select_why[RT_WHY_TIME_BUDGET],
                  (unsigned long long)t->method_switches);
    /* the near object and the head's translation call for the depth warp, and a depth warp runs: the per-pixel
     * raytrace, or its mesh-vertex version when the machine is too busy for the per-pixel one */
    assert_true(t->select_why[RT_WHY_PARALLAX] + t->select_why[RT_WHY_HELD] > 0);
    assert_true(t->method_count[RT_METHOD_RAYTRACE] + t->method_count[RT_METHOD_RAYTRACE_MESH] >
                t->method_count[RT_METHOD_ROTATION]);
    /* steady motion: no flicker between warps (the first escalation, perhaps a time-budget step or two) */
    assert_true(t->method_switches <= 6);
    rt_app_free(&app);
}

static void test_auto_transparency_scene_uses_its_warp(void **state)
{
    (void)state;
    rt_config c;
    auto_config(&c, "glass");
    run(&c);
    rt_telemetry *t = app.tel;
    assert_true(rt_simboard_plane_renders(app.sim)[4] > 0); /* the host sends layers for this scene */
    assert_true(t->select_why[RT_WHY_TRANSPARENCY] > 0);
    assert_true(t->method_count[RT_METHOD_TRANSPARENCY] > 0);
    rt_app_free(&app);
}

static void test_auto_moving_objects_use_object_warp(void **state)
{
    (void)state;
    rt_config c;
    auto_config(&c, "movers");
    run(&c);
    rt_telemetry *t = app.tel;
    assert_true(rt_simboard_plane_renders(app.sim)[2] > 0); /* ids */
    assert_true(t->select_why[RT_WHY_OBJECT_MOTION] > 0);
    assert_true(t->method_count[RT_METHOD_OBJECTS] > 0);
    rt_app_free(&app);
}

int main(void)
{
    /* its 90 Hz CPU passes on 320x360 eyes took 19 ms of virtual time at 20x under qemu-user on a loaded 2-core
     * machine (the vector kernel on TCG): most vsyncs missed, too few passes shown for the stall reserve's check */
    test_paced_by_sim(60);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rotation_only_scene),
        cmocka_unit_test(test_misses_attributed),
        cmocka_unit_test(test_kernel_choice),
        cmocka_unit_test(test_stall_reserve_starts_passes_earlier),
        cmocka_unit_test(test_depth_scene_raytrace),
        cmocka_unit_test(test_depth_scene_raytrace_mesh),
        cmocka_unit_test(test_raytrace_without_depth_falls_back),
        cmocka_unit_test(test_auto_rotation_only_scene_never_pays_for_depth),
        cmocka_unit_test(test_auto_translation_escalates_and_is_stable),
        cmocka_unit_test(test_auto_transparency_scene_uses_its_warp),
        cmocka_unit_test(test_auto_moving_objects_use_object_warp),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
