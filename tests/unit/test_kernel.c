/* SPDX-License-Identifier: MIT */
/* Tests of [render] kernel = auto's measurement (rt_kernel): every kernel this CPU runs is timed or cut off as
 * clearly slower, the choice is warp_resample_kernel_pick's on those times, it is one this CPU runs, the why names
 * it, and measuring leaves the kernel in use alone. Which kernel wins is the machine's business: not asserted. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>
#include <cmocka.h>

#include "platform/plat_workers.h"
#include "runtime/rt_config.h"
#include "runtime/rt_kernel.h"
#include "runtime/rt_render_cpu.h"
#include "warp/warp_resample.h"

/* The default panel and lens scaled to a small eye, as hmdwarp-bench --eye does: the test stays cheap. */
static void small_config(rt_config *c)
{
    rt_config ref;
    rt_config_defaults(c);
    rt_config_defaults(&ref);
    const double s = 240.0 / ref.eye_w;
    c->panel_w = 480, c->panel_h = (int)(ref.panel_h * s), c->eye_w = 240, c->eye_h = (int)(ref.eye_h * s);
    c->lens_scale = ref.lens_scale * s;
    c->lens_center[0] = ref.lens_center[0] * s, c->lens_center[1] = ref.lens_center[1] * s;
}

static void test_measure_picks_a_measured_usable_kernel(void **state)
{
    (void)state;
    rt_config c;
    small_config(&c);
    assert_true(warp_resample_force_kernel(WARP_RESAMPLE_VECTOR));
    rt_kernel_choice kc;
    char err[200] = "";
    /* timed on the render pass's own lens mesh, as hmdwarpd does */
    plat_workers *w = plat_workers_create(0, 0);
    assert_non_null(w);
    const rt_render_cpu_params p = rt_render_cpu_params_from_config(&c);
    rt_render_cpu *pass = rt_render_cpu_create(&p, w, err, sizeof err);
    assert_non_null(pass);
    assert_true(rt_kernel_measure(&c, pass, &kc, err, sizeof err));
    rt_render_cpu_destroy(&pass);
    plat_workers_destroy(w);
    /* measuring forces each kernel in turn; afterwards the caller's kernel runs again */
    assert_string_equal(warp_resample_kernel(), "vector");
    assert_true(warp_resample_force_kernel(WARP_RESAMPLE_AUTO));

    int measured = 0;
    for (int k = 0; k < WARP_RESAMPLE_KERNELS; k++) {
        assert_int_equal(kc.usable[k], k != WARP_RESAMPLE_AUTO && warp_resample_kernel_available(k));
        if (!kc.usable[k]) assert_true(kc.ms[k] == 0);
        measured += kc.ms[k] > 0;
    }
    assert_true(measured >= 1);
    assert_true(kc.usable[kc.picked]);
    assert_true(kc.ms[kc.picked] > 0);
    assert_int_equal(kc.picked, warp_resample_kernel_pick(kc.ms, kc.usable));
    /* the why: the pick's time, then every other kernel's (or that it was cut off) */
    print_message("picked %s: %s\n", warp_resample_kernel_name(kc.picked), kc.why);
    assert_non_null(strstr(kc.why, "measured "));
    for (int k = WARP_RESAMPLE_SCALAR; k < WARP_RESAMPLE_KERNELS; k++)
        if (kc.usable[k] && k != (int)kc.picked)
            assert_non_null(strstr(kc.why, warp_resample_kernel_name((warp_resample_kernel_id)k)));
    /* the pick is no slower than any measured kernel by more than the tie margin */
    for (int k = WARP_RESAMPLE_SCALAR; k < WARP_RESAMPLE_KERNELS; k++)
        if (kc.ms[k] > 0) assert_true(kc.ms[kc.picked] <= kc.ms[k] * (1 + WARP_RESAMPLE_PICK_TIE) + 1e-12);

    assert_true(warp_resample_set_auto(kc.picked));
    assert_string_equal(warp_resample_kernel(), warp_resample_kernel_name(kc.picked));
    assert_true(warp_resample_set_auto(WARP_RESAMPLE_AUTO));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_measure_picks_a_measured_usable_kernel),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
