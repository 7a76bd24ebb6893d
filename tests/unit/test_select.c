/* SPDX-License-Identifier: MIT */
/* rt_select: the per-vsync warp choice. A rotation-only frame never gets a depth warp; a translation with a near
 * object escalates; the 004 bound matches its closed form; steady motion near the threshold does not flicker;
 * a short time budget degrades to rotation without forgetting the preference; transparency and object motion are
 * named as the reason. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

#include "runtime/rt_select.h"

static warp_camera cam(void) { return (warp_camera){720, 800, 1.28, 1.11, 1.28, 1.28, 0.05, INFINITY}; }

static rt_select_input frame(double t_m, double nearest_m)
{
    rt_select_input in = {0};
    in.have_frame = true;
    in.has_depth = true;
    in.inv_depth_max = nearest_m > 0 ? (float)(1 / nearest_m) : 0;
    in.translation_m = t_m;
    in.time_left_ns = 8e6;
    return in;
}

/* A selector with the default parameters over cam(): where every choice test starts. */
typedef struct {
    rt_select s;
    rt_select_params p;
    warp_camera c;
} selector;

static void selector_init(selector *x)
{
    x->p = rt_select_default_params();
    x->c = cam();
    rt_select_init(&x->s, &x->p, &x->c);
}

/* One choice with configured on in: asserts the method chosen and the reason given. */
static void expect_choice(rt_select *s, rt_method configured, const rt_select_input *in, rt_method want,
                          rt_select_why want_why)
{
    rt_select_why why;
    assert_int_equal(rt_select_choose(s, configured, in, &why), want);
    assert_int_equal(why, want_why);
}

static void test_bound_matches_004(void **state)
{
    (void)state;
    /* symmetric camera: eq. 7 in its own form */
    double vfov = 90 * WARP_PI / 180, V = 800, A = 720.0 / 800.0;
    warp_camera c = {720, 800, A * tan(vfov / 2), A * tan(vfov / 2), tan(vfov / 2), tan(vfov / 2), 0.05, INFINITY};
    double a_max = V / 2 / tan(vfov / 2) * ((A * A + 1) * (1 - cos(vfov)) / (1 + cos(vfov)) + 1);
    double T = 0.02, d = 0.5;
    double p = rt_select_parallax_px(&c, T, 1 / d);
    assert_true(fabs(p - a_max * asin(T / d)) < 1e-9 * p);
    /* no translation, or all sky: no parallax */
    assert_true(rt_select_parallax_px(&c, 0, 2) == 0);
    assert_true(rt_select_parallax_px(&c, 0.05, 0) == 0);
    /* T beyond d_min has no bound: a large finite number, never NaN */
    assert_true(isfinite(rt_select_parallax_px(&c, 10, 10)));
}

static void test_rotation_only_never_depth(void **state)
{
    (void)state;
    selector x;
    selector_init(&x);
    for (int i = 0; i < 500; i++) {
        rt_select_input in = frame(0.1 * (i % 7), 0.3); /* big translations ... */
        in.has_depth = false;                           /* ... but the frame has no depth */
        expect_choice(&x.s, RT_METHOD_AUTO, &in, RT_METHOD_ROTATION, RT_WHY_ROTATION_ONLY);
    }
    /* a configured method is used as is */
    rt_select_input in = frame(0.05, 0.3);
    expect_choice(&x.s, RT_METHOD_NONE, &in, RT_METHOD_NONE, RT_WHY_CONFIGURED);
}

static void test_translation_near_object_escalates(void **state)
{
    (void)state;
    selector x;
    selector_init(&x);
    rt_select_why why;
    /* far scene, 1 cm: under budget */
    rt_select_input in = frame(0.001, 50);
    expect_choice(&x.s, RT_METHOD_AUTO, &in, RT_METHOD_ROTATION, RT_WHY_PARALLAX_SMALL);
    /* 1 cm with something 40 cm away: several pixels of parallax -> the display path's depth warp */
    in = frame(0.01, 0.4);
    expect_choice(&x.s, RT_METHOD_AUTO, &in, RT_METHOD_RAYTRACE_MESH, RT_WHY_PARALLAX);
    assert_true(x.s.last_px > 5);
    /* transparency and object motion are named */
    in.has_layers = true;
    rt_select_choose(&x.s, RT_METHOD_AUTO, &in, &why);
    assert_int_equal(why, RT_WHY_TRANSPARENCY);
    in.has_layers = false;
    in.objects_moving = true;
    rt_select_choose(&x.s, RT_METHOD_AUTO, &in, &why);
    assert_int_equal(why, RT_WHY_OBJECT_MOTION);
}

static void test_stable_near_threshold(void **state)
{
    (void)state;
    /* steady motion whose prediction wobbles around the budget: at most one switch up, none back */
    selector x;
    selector_init(&x);
    double t_at_budget = 0;
    for (double t = 0; t < 0.01; t += 1e-6)
        if (rt_select_parallax_px(&x.c, t, 1 / 2.0) > x.p.pixel_budget) {
            t_at_budget = t;
            break;
        }
    assert_true(t_at_budget > 0);
    rt_method prev = RT_METHOD_ROTATION;
    int switches = 0;
    rt_select_why why;
    for (int i = 0; i < 2000; i++) {
        rt_select_input in = frame(t_at_budget * (1 + 0.05 * sin(i * 0.7)), 2.0);
        rt_method m = rt_select_choose(&x.s, RT_METHOD_AUTO, &in, &why);
        switches += m != prev;
        prev = m;
    }
    assert_true(switches <= 1);
    /* once the head is still for long enough, it comes back down */
    for (int i = 0; i < x.p.hold_vsyncs + 1; i++) {
        rt_select_input in = frame(0, 2.0);
        prev = rt_select_choose(&x.s, RT_METHOD_AUTO, &in, &why);
    }
    assert_int_equal(prev, RT_METHOD_ROTATION);
}

static void test_time_budget_degrades(void **state)
{
    (void)state;
    selector x;
    selector_init(&x);
    rt_select_why why;
    rt_select_input in = frame(0.02, 0.4);
    in.cost_ns[RT_METHOD_ROTATION] = 2e6;
    in.cost_ns[RT_METHOD_RAYTRACE] = 20e6; /* the per-pixel raytrace is not what auto wants for parallax */
    in.cost_ns[RT_METHOD_RAYTRACE_MESH] = 3e6; /* fits */
    expect_choice(&x.s, RT_METHOD_AUTO, &in, RT_METHOD_RAYTRACE_MESH, RT_WHY_PARALLAX);
    in.cost_ns[RT_METHOD_RAYTRACE_MESH] = 9e6; /* does not fit in 8 ms: rotation */
    expect_choice(&x.s, RT_METHOD_AUTO, &in, RT_METHOD_ROTATION, RT_WHY_TIME_BUDGET);
    /* the objects warp steps down through the same ladder: raytrace does not fit, raytrace_mesh does */
    in.objects_moving = true;
    in.cost_ns[RT_METHOD_OBJECTS] = 30e6;
    in.cost_ns[RT_METHOD_RAYTRACE_MESH] = 3e6;
    expect_choice(&x.s, RT_METHOD_AUTO, &in, RT_METHOD_RAYTRACE_MESH, RT_WHY_TIME_BUDGET);
    in.cost_ns[RT_METHOD_RAYTRACE] = 5e6; /* fits: one rung down only */
    assert_int_equal(rt_select_choose(&x.s, RT_METHOD_AUTO, &in, &why), RT_METHOD_RAYTRACE);
    in.cost_ns[RT_METHOD_OBJECTS] = 6e6; /* fits again: back to the preferred warp at once */
    assert_int_equal(rt_select_choose(&x.s, RT_METHOD_AUTO, &in, &why), RT_METHOD_OBJECTS);
}

/* The reasons' --stats keys (select_KEY) are an interface: exactly these, one per reason, and a summary text each. */
static void test_reason_keys(void **state)
{
    (void)state;
    static const char *const keys[RT_WHY_COUNT] = {"configured", "no_frame",      "rotation_only",
                                                   "parallax_small", "parallax", "transparency",
                                                   "object_motion", "held",      "time_budget"};
    for (int w = 0; w < RT_WHY_COUNT; w++) {
        assert_string_equal(rt_select_why_key((rt_select_why)w), keys[w]);
        assert_string_not_equal(rt_select_why_str((rt_select_why)w), "?");
    }
    assert_string_equal(rt_select_why_key(RT_WHY_COUNT), "?");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bound_matches_004),
        cmocka_unit_test(test_rotation_only_never_depth),
        cmocka_unit_test(test_translation_near_object_escalates),
        cmocka_unit_test(test_stable_near_threshold),
        cmocka_unit_test(test_time_budget_degrades),
        cmocka_unit_test(test_reason_keys),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
