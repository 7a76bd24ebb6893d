/* SPDX-License-Identifier: MIT */
/* What rolling-scan compensation buys, judged as hmdwarp-bench --rolling-only judges it (bench_rolling, the
 * evaluator's own scoring against per-band truth) on a fixed number of frames of the fast trace, on small eyes. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

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

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_fast_trace)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
