/* SPDX-License-Identifier: MIT */
/* What rolling-scan compensation buys, judged as hmdwarp-bench --rolling-only judges it (bench_rolling, the
 * evaluator's own scoring against per-band truth) on a fixed number of frames of the fast trace, on small eyes;
 * and hmdwarpd's runtime on a rolling panel of the simulated board, end to end. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

#include "runtime/rt_app.h"
#include "runtime/rt_simboard.h"
#include "tests/support/test_run.h"
#include "tests/support/test_settings.h"
#include "tools/hmdwarp-bench/bench_rolling.h"

/* Compensation must gain at least this much mean PSNR on the mesh warps (the reference size gains 2.6-2.8 dB). */
#define MIN_GAIN_DB 1.0

static double psnr(const rt_eval_acc *a) { return a->n ? a->psnr_sum / a->n : NAN; }

static void test_fast_trace(void **state)
{
    (void)state;
    const bench_rolling_opts o = {.frames = 12, .eye_w = 192, .eye_h = 216};
    bench_rolling_result r;
    assert_true(bench_rolling_measure(&o, &r));
    for (int m = 0; m < RT_EVAL_METHODS; m++) {
        assert_int_equal(r.global[m].n, 12);
        assert_int_equal(r.rolling[m].n, 12);
        print_message("%-14s global %.2f dB, rolling %.2f dB\n", rt_method_name(rt_eval_methods[m]),
                      psnr(&r.global[m]), psnr(&r.rolling[m]));
    }
    assert_true(r.speed_mean_dps > 100);
    assert_true(psnr(&r.rolling[RT_EVAL_ROTATION]) > psnr(&r.global[RT_EVAL_ROTATION]) + MIN_GAIN_DB);
    assert_true(psnr(&r.rolling[RT_EVAL_RAYTRACE_MESH]) > psnr(&r.global[RT_EVAL_RAYTRACE_MESH]) + MIN_GAIN_DB);
    /* the per-pixel raytrace keeps the mid-scan pose, and no warp is no warp: the same both ways */
    assert_true(psnr(&r.rolling[RT_EVAL_RAYTRACE]) == psnr(&r.global[RT_EVAL_RAYTRACE]));
    assert_true(psnr(&r.rolling[RT_EVAL_NONE]) == psnr(&r.global[RT_EVAL_NONE]));
}

static bool enough(const rt_app *a, double elapsed_s)
{
    return elapsed_s > 1.2 && a->tel->method_count[RT_METHOD_RAYTRACE_MESH] >= 20;
}

/* The compositor predicts the scan's first and last line, the CPU pass warps per vertex row, the evaluator
 * scores against per-band truth: a short run on small eyes shows frames and scores them. */
static void test_runtime(void **state)
{
    (void)state;
    static rt_app app;
    rt_config c;
    rt_config_defaults(&c);
    const char *sets[] = {"display.width=320", "display.height=180", "eye.width=160", "eye.height=180",
                          "lens.scale=90", "lens.center=85 90", "sim.duration_s=0", "sim.eval_every_ms=200",
                          "render.rt_priority=0", "render.renderer=cpu", "sim.trace=fast", "sim.scene=near",
                          "warp.method=raytrace_mesh", "display.scanout=rolling"};
    test_set_all(&c, sets, sizeof sets / sizeof sets[0]);
    test_validate(&c);
    char err[300];
    if (!rt_app_init(&app, &c, err, sizeof err)) fail_msg("init: %s", err);
    assert_true(test_run_until(&app, enough, 60));
    const rt_eval *ev = rt_simboard_eval(app.sim);
    print_message("vsyncs %llu, evaluated %d, raytrace_mesh %.2f dB\n", (unsigned long long)app.tel->vsyncs,
                  ev->acc[RT_EVAL_RAYTRACE_MESH].n, psnr(&ev->acc[RT_EVAL_RAYTRACE_MESH]));
    assert_true(ev->acc[RT_EVAL_RAYTRACE_MESH].n >= 1);
    assert_true(psnr(&ev->acc[RT_EVAL_RAYTRACE_MESH]) > 15);
    rt_app_free(&app);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_fast_trace), cmocka_unit_test(test_runtime)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
