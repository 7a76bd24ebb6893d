/* SPDX-License-Identifier: MIT */
/* The GLES renderer inside the runtime: how `renderer = auto|cpu|gles` decides (llvmpipe -> cpu, a hardware GPU ->
 * gles), the [render]/[display] keys, the KMS error without a DRM device, and a short GLES run on the simulated
 * board whose summary names the renderer, the reason and the per-pass GPU times. */
#include <setjmp.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "platform/plat_clock.h"
#include "platform/plat_gles.h"
#include "runtime/rt_app.h"
#include "runtime/rt_render_cpu.h"
#include "tests/support/test_run.h"
#include "tests/support/test_settings.h"
#include "tests/support/test_util.h"

static void test_choose(void **state)
{
    (void)state;
    char why[256];
    const char *llvm = "llvmpipe (LLVM 15.0.6, 256 bits)";
    assert_false(rt_render_choose("cpu", llvm, NULL, false, why, sizeof why));
    assert_string_equal(why, "renderer = cpu");
    /* auto: software rasterizer -> the CPU path, and the summary says why */
    assert_false(rt_render_choose("auto", llvm, NULL, false, why, sizeof why));
    assert_non_null(strstr(why, "software rasterizer (llvmpipe"));
    /* auto: a hardware GPU -> GLES */
    assert_true(rt_render_choose("auto", "V3D 4.2", NULL, false, why, sizeof why));
    assert_string_equal(why, "auto: EGL offers a hardware GPU");
    assert_true(rt_render_choose("auto", "Mali-G31 (Panfrost)", NULL, false, why, sizeof why));
    /* auto without EGL -> CPU, naming the EGL error */
    assert_false(rt_render_choose("auto", NULL, "EGL (surfaceless): no display", false, why, sizeof why));
    assert_non_null(strstr(why, "EGL (surfaceless): no display"));
    /* forced gles runs even on llvmpipe (make run RENDER=gles) */
    assert_true(rt_render_choose("gles", llvm, NULL, false, why, sizeof why));
    assert_non_null(strstr(why, "forced onto a software rasterizer"));
    assert_true(rt_render_choose("gles", "V3D 7.1", NULL, false, why, sizeof why));
    assert_string_equal(why, "renderer = gles");
    /* KMS output: the same choice, the CPU path showing through dumb buffers */
    assert_false(rt_render_choose("auto", llvm, NULL, true, why, sizeof why));
    assert_non_null(strstr(why, "KMS through dumb buffers"));
    assert_false(rt_render_choose("auto", NULL, "EGL (GBM): no display", true, why, sizeof why));
    assert_non_null(strstr(why, "KMS through dumb buffers"));
    assert_true(rt_render_choose("auto", "V3D 7.1", NULL, true, why, sizeof why));
    assert_false(rt_render_choose("cpu", "V3D 7.1", NULL, true, why, sizeof why));
    assert_true(rt_render_choose("gles", llvm, NULL, true, why, sizeof why));
}

static void test_config_keys(void **state)
{
    (void)state;
    rt_config c;
    rt_config_defaults(&c);
    assert_string_equal(c.renderer, "auto");
    assert_string_equal(c.output, "offscreen");
    assert_string_equal(c.kms_device, "/dev/dri/card0");
    rt_config_errors e = {0};
    assert_true(rt_config_set(&c, "render.renderer=gles", &e));
    assert_true(rt_config_set(&c, "render.renderer=cpu", &e));
    assert_false(rt_config_set(&c, "render.renderer=vulkan", &e));
    assert_true(e.count > 0);
    assert_non_null(strstr(e.msg[0], "renderer"));
    e.count = 0;
    assert_false(rt_config_set(&c, "display.output=hdmi", &e));
    e.count = 0;
    assert_true(rt_config_set(&c, "display.output=kms", &e));
    /* the CPU path drives KMS too (dumb buffers) */
    assert_true(rt_config_validate(&c, &e));
    assert_true(rt_config_set(&c, "render.renderer=auto", &e));
    assert_true(rt_config_validate(&c, &e));
    int w, h;
    double hz;
    assert_true(rt_config_parse_mode("auto", &w, &h, &hz) && w == 0 && h == 0 && hz == 0);
    assert_true(rt_config_parse_mode("2880x1600", &w, &h, &hz) && w == 2880 && h == 1600 && hz == 0);
    assert_true(rt_config_parse_mode("2880x1600@90", &w, &h, &hz) && w == 2880 && hz == 90);
    assert_false(rt_config_parse_mode("2880x1600@", &w, &h, &hz));
    assert_false(rt_config_parse_mode("2880x", &w, &h, &hz));
    assert_false(rt_config_parse_mode("wide", &w, &h, &hz));
    assert_false(rt_config_parse_mode("2880x1600@90Hz", &w, &h, &hz));
    assert_true(rt_config_set(&c, "display.kms_mode=big", &e));
    e.count = 0;
    assert_false(rt_config_validate(&c, &e));
    assert_non_null(strstr(e.msg[0], "kms_mode"));
}

static void small_config(rt_config *c, const char *renderer, const char *method)
{
    rt_config_defaults(c);
    const char *sets[] = {"display.width=192", "display.height=96", "eye.width=96", "eye.height=96",
                          "lens.scale=54", "lens.center=51 48", "sim.duration_s=0.4", "sim.eval_every_ms=0",
                          "render.rt_priority=0", "sim.scene=near", "sim.host_threads=1", "lens.mesh=16"};
    test_set_all(c, sets, sizeof sets / sizeof sets[0]);
    test_setf(c, "render.renderer=%s", renderer);
    test_setf(c, "warp.method=%s", method);
    test_validate(c);
}

static rt_app app;

static void test_kms_without_drm_device(void **state)
{
    (void)state;
    rt_config c;
    small_config(&c, "auto", "rotation");
    rt_config_errors e = {0};
    assert_true(rt_config_set(&c, "display.output=kms", &e));
    assert_true(rt_config_set(&c, "display.kms_device=/nonexistent/dri/card0", &e));
    char err[300];
    assert_false(rt_app_init(&app, &c, err, sizeof err));
    print_message("%s\n", err);
    assert_string_equal(err, "[display] output = kms: no DRM device: /nonexistent/dri/card0: No such file or directory");
    rt_app_free(&app);
    FILE *probe = fopen("/dev/dri/card0", "r");
    if (probe) {
        fclose(probe);
        return; /* a machine with a display controller: the default device exists */
    }
    assert_true(rt_config_set(&c, "display.kms_device=/dev/dri/card0", &e));
    assert_false(rt_app_init(&app, &c, err, sizeof err));
    assert_string_equal(err, "[display] output = kms: no DRM device: /dev/dri/card0: No such file or directory");
    rt_app_free(&app);
}

static char *stats_text(void)
{
    char *buf = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&buf, &len);
    assert_non_null(f);
    rt_app_stats_kv(&app, f);
    fclose(f);
    return buf;
}

static char *summary_text(void)
{
    char *buf = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&buf, &len);
    assert_non_null(f);
    rt_app_summary(&app, f);
    fclose(f);
    return buf;
}

/* GPU times of pass p so far. The watcher thread asks while the compositor thread adds to the histograms: an
 * atomic load, as the helper thread reads the other counters live (rt_telemetry.h). */
static uint64_t gles_count(const rt_app *a, int p)
{
    return atomic_load_explicit(&a->gl.ms[p].count, memory_order_relaxed);
}

/* At least the run's 0.4 s, and until every pass has a GPU time (under an emulator llvmpipe's first passes, its
 * shaders compiled, can take most of that). */
static bool llvmpipe_enough(const rt_app *a, double elapsed_s)
{
    return elapsed_s >= 0.4 &&
           atomic_load_explicit(&a->tel->method_count[RT_METHOD_RAYTRACE], memory_order_relaxed) > 0 &&
           gles_count(a, PLAT_GLES_RAYTRACE) > 0 && gles_count(a, PLAT_GLES_LENS) > 0 &&
           gles_count(a, PLAT_GLES_PYRAMID) > 0;
}

/* The simulated board on the GLES renderer with `method`, run until `enough` (60 s at most). */
static void gles_run_set(const char *method, const char *set, bool (*enough)(const rt_app *, double))
{
    rt_config c;
    small_config(&c, "gles", method);
    rt_config_errors e = {0};
    assert_true(rt_config_set(&c, "sim.duration_s=0", &e));
    if (set) assert_true(rt_config_set(&c, set, &e));
    char err[300];
    if (!rt_app_init(&app, &c, err, sizeof err)) fail_msg("init: %s", err);
    assert_true(app.gl.use);
    if (!test_run_until(&app, enough, 60)) print_message("%s: not enough drawn within 60 s\n", method);
}

static void gles_run(const char *method, bool (*enough)(const rt_app *, double)) { gles_run_set(method, NULL, enough); }

/* Pixels of the image on screen with some green: something was drawn, the image is not all black. */
static long lit_on_screen(void)
{
    int idx = app.sc.on_screen;
    assert_true(idx >= 0);
    long lit = 0;
    for (int y = 0; y < app.sc.img[idx].h; y++)
        for (int x = 0; x < app.sc.img[idx].w; x++) lit += WARP_AT(&app.sc.img[idx], x, y).g > 10;
    return lit;
}

static void test_gles_run_on_llvmpipe(void **state)
{
    (void)state;
    gles_run("raytrace", llvmpipe_enough);
    rt_telemetry *t = app.tel;
    print_message("vsyncs %llu, raytrace %llu, gles errors %llu\n", (unsigned long long)t->vsyncs,
                  (unsigned long long)t->method_count[RT_METHOD_RAYTRACE], (unsigned long long)app.gl.errors);
    assert_true(t->method_count[RT_METHOD_RAYTRACE] > 0);
    assert_int_equal(app.gl.errors, 0);
    assert_true(gles_count(&app, PLAT_GLES_RAYTRACE) > 0);
    assert_true(gles_count(&app, PLAT_GLES_LENS) > 0);
    assert_true(gles_count(&app, PLAT_GLES_PYRAMID) > 0); /* built for new frames */
    assert_true(lit_on_screen() > 192 * 96 / 2);
    char *kv = stats_text(), *sum = summary_text();
    assert_non_null(strstr(kv, "renderer=gles\n"));
    assert_non_null(strstr(kv, "gl_renderer=llvmpipe"));
    assert_non_null(strstr(kv, "renderer_reason=renderer = gles (forced onto a software rasterizer)\n"));
    assert_non_null(strstr(kv, "gles_raytrace_ms_p50="));
    assert_null(strstr(kv, "gles_raytrace_ms_p50=nan"));
    assert_non_null(strstr(sum, "renderer                   gles: llvmpipe"));
    assert_non_null(strstr(sum, "gles raytrace"));
    free(kv);
    free(sum);
    rt_app_free(&app);
}

/* At least the run's 0.4 s, and until the GPU drew raytrace_mesh and its lens pass has a time. */
static bool mesh_enough(const rt_app *a, double elapsed_s)
{
    return elapsed_s >= 0.4 &&
           atomic_load_explicit(&a->tel->method_count[RT_METHOD_RAYTRACE_MESH], memory_order_relaxed) > 0 &&
           gles_count(a, PLAT_GLES_LENS) > 0;
}

/* raytrace_mesh on the GLES renderer: its own pass (the CPU's vertex rays, the GPU's per-pixel rays in the marked
 * cells), not the per-pixel raytrace standing in nor rotation. */
static void test_gles_raytrace_mesh(void **state)
{
    (void)state;
    gles_run("raytrace_mesh", mesh_enough);
    rt_telemetry *t = app.tel;
    print_message("vsyncs %llu, raytrace_mesh %llu, raytrace %llu, rotation %llu, gles errors %llu\n",
                  (unsigned long long)t->vsyncs, (unsigned long long)t->method_count[RT_METHOD_RAYTRACE_MESH],
                  (unsigned long long)t->method_count[RT_METHOD_RAYTRACE],
                  (unsigned long long)t->method_count[RT_METHOD_ROTATION], (unsigned long long)app.gl.errors);
    assert_true(t->method_count[RT_METHOD_RAYTRACE_MESH] > 0);
    assert_int_equal(t->method_count[RT_METHOD_RAYTRACE], 0);
    assert_int_equal(app.gl.errors, 0);
    assert_true(gles_count(&app, PLAT_GLES_LENS) > 0);
    assert_int_equal(gles_count(&app, PLAT_GLES_RAYTRACE), 0); /* no eye-space pass */
    assert_non_null(rt_render_cpu_mesh_trace(app.render, 0));
    assert_true(lit_on_screen() > 192 * 96 / 2);
    rt_app_free(&app);
}

/* [warp] mesh_cells = false on the GLES renderer: raytrace_mesh's vertices through the plain lens pass, drawn as
 * raytrace_mesh (not fallen back to rotation) without a GL error. */
static void test_gles_raytrace_mesh_vertices_only(void **state)
{
    (void)state;
    gles_run_set("raytrace_mesh", "warp.mesh_cells=false", mesh_enough);
    rt_telemetry *t = app.tel;
    assert_false(rt_render_cpu_mesh_cells(app.render));
    assert_true(t->method_count[RT_METHOD_RAYTRACE_MESH] > 0);
    assert_int_equal(t->method_count[RT_METHOD_ROTATION], 0);
    assert_int_equal(app.gl.errors, 0);
    assert_true(lit_on_screen() > 192 * 96 / 2);
    rt_app_free(&app);
}

/* A GLES pass that llvmpipe draws for far longer than a period is the warp's own miss, not the scheduler's: the
 * compositor thread waits for the GPU without running, so its CPU time alone would blame the scheduler (make run
 * RENDER=gles once reported "descheduled 906, own 0"). Eye buffers of the sim board's size keep llvmpipe's pass at
 * ten periods or more however loaded the machine is. Only the vsyncs that had a host frame to warp are judged: before
 * the first frame a vsync costs a clear, and on a busy machine the simulated host's first frame can take most of a
 * short run (make test-busy: 55 vsyncs, 13 missed), so the run is repeated longer until 10 vsyncs had one. */
static void test_gles_misses_are_the_warps(void **state)
{
    (void)state;
    test_others others0 = test_others_mark();
    const rt_telemetry *t = NULL;
    uint64_t framed = 0;
    for (double secs = 0.6; secs < 5; secs *= 2) {
        if (t) rt_app_free(&app);
        rt_config c;
        rt_config_defaults(&c);
        const char *sets[] = {"render.renderer=gles", "warp.method=rotation", "sim.eval_every_ms=0",
                              "render.rt_priority=0", "sim.scene=room", "sim.host_threads=1"};
        test_set_all(&c, sets, sizeof sets / sizeof sets[0]);
        test_setf(&c, "sim.duration_s=%g", secs);
        test_validate(&c);
        char err[300];
        if (!rt_app_init(&app, &c, err, sizeof err)) fail_msg("init: %s", err);
        assert_true(app.gl.use && app.gl.software);
        others0 = test_others_mark();
        rt_app_run(&app);
        t = app.tel;
        framed = t->vsyncs - t->no_frame;
        print_message("%.1f s: vsyncs %llu (with a host frame %llu), missed %llu: own %llu, late wake %llu, "
                      "descheduled %llu\n", secs, (unsigned long long)t->vsyncs, (unsigned long long)framed,
                      (unsigned long long)t->missed, (unsigned long long)t->missed_by[RT_MISS_OWN],
                      (unsigned long long)t->missed_by[RT_MISS_LATE_WAKE],
                      (unsigned long long)t->missed_by[RT_MISS_DESCHEDULED]);
        if (framed >= 10) break;
    }
    if (framed < 10) fail_msg("only %llu vsyncs had a host frame in the longest run", (unsigned long long)framed);
    /* On virtual time (make check-cross: qemu-user at 20x) llvmpipe's pass is CPU time on the real clock, which
     * virtual time divides: whether it overruns the period is then the emulator's speed, not the runtime's (it
     * overran 113 of 113 vsyncs in one run, 3 of 55 in another). There the misses are counted and summed only. */
    const bool real_time = plat_clock_slowdown() == 1;
    if (real_time) assert_true(t->missed * 2 >= framed);
    uint64_t by = 0;
    for (int m = 0; m < RT_MISS_COUNT; m++) by += t->missed_by[m];
    assert_true(by == t->missed);
    /* Whose misses they are is judged only on a quiet machine: on a busy one llvmpipe's threads wait for a CPU,
     * and the runtime rightly counts that as the scheduler's (measured beside three other builds: own 8,
     * descheduled 31 of 39). Judged when other processes used under 15 % of the machine's CPU time during the run:
     * then 90 % of the misses are the pass's own, and the advice says the pass is too dear. */
    double others = test_others_share(others0);
    print_message("other processes used %.0f %% of the CPUs during the run\n", others * 100);
    if (real_time && others < 0.15) {
        assert_true(t->missed_by[RT_MISS_OWN] * 10 >= t->missed * 9);
        char *sum = summary_text();
        assert_non_null(strstr(sum, "misses, what to do         the GPU pass is too dear"));
        free(sum);
    } else {
        print_message("%s: the misses' causes are reported, not judged\n", real_time ? "busy machine" : "virtual time");
    }
    rt_app_free(&app);
}

static void test_auto_picks_cpu_on_llvmpipe(void **state)
{
    (void)state;
    rt_config c;
    small_config(&c, "auto", "rotation");
    rt_config_errors e = {0};
    assert_true(rt_config_set(&c, "sim.duration_s=0.1", &e));
    char err[300];
    if (!rt_app_init(&app, &c, err, sizeof err)) fail_msg("init: %s", err);
    assert_false(app.gl.use);
    assert_null(app.gl.egl); /* not kept open for nothing */
    rt_app_run(&app);
    char *kv = stats_text(), *sum = summary_text();
    assert_non_null(strstr(kv, "renderer=cpu\n"));
    assert_non_null(strstr(kv, "renderer_reason=auto: EGL offers only a software rasterizer (llvmpipe"));
    assert_null(strstr(kv, "gles_"));
    assert_non_null(strstr(sum, "renderer                   cpu ("));
    assert_non_null(strstr(sum, "renderer chosen            auto: EGL offers only a software rasterizer"));
    free(kv);
    free(sum);
    rt_app_free(&app);
}

int main(void)
{
    test_paced_by_sim(TEST_EMULATOR_SLOWDOWN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_choose),
        cmocka_unit_test(test_config_keys),
        cmocka_unit_test(test_kms_without_drm_device),
        cmocka_unit_test(test_gles_run_on_llvmpipe),
        cmocka_unit_test(test_gles_raytrace_mesh),
        cmocka_unit_test(test_gles_raytrace_mesh_vertices_only),
        cmocka_unit_test(test_gles_misses_are_the_warps),
        cmocka_unit_test(test_auto_picks_cpu_on_llvmpipe),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
