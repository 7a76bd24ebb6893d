/* SPDX-License-Identifier: MIT */
/* warp_registry: every entry is consistent (unique names, ladders ending at rotation or none without cycles, knob
 * defaults in range and equal to the modules' own), and [warp] method, --help-config and the catalogue behind
 * hmdwarp-warp --list offer exactly the registry's methods, raytrace_mesh included. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>
#include <libgen.h>

#include "drivers/drv_frames.h"
#include "runtime/rt_config.h"
#include "tools/common/cat_warps.h"
#include "warp/warp_raytrace.h"
#include "warp/warp_registry.h"
#include "tests/support/test_scene.h"
#include "tests/support/test_util.h"

static void entries_consistent(void **state)
{
    (void)state;
    for (int m = 0; m < WARP_METHOD_COUNT; m++) {
        const warp_method_info *w = warp_method_get((warp_method)m);
        assert_non_null(w);
        assert_non_null(w->name);
        assert_non_null(w->cite);
        assert_non_null(w->summary);
        assert_int_equal(warp_method_find(w->name), m); /* unique: the first with that name is this one */
        assert_int_equal(w->runtime, m < WARP_METHOD_RUNTIME_COUNT);
        /* the ladder: each rung cheaper, a runtime method falls to runtime methods only, and it ends (a method
         * that is its own fallback) at rotation or none within COUNT steps */
        warp_method at = (warp_method)m;
        int steps = 0;
        while (warp_method_get(at)->fallback != at && steps <= WARP_METHOD_COUNT) {
            warp_method next = warp_method_get(at)->fallback;
            assert_non_null(warp_method_get(next));
            assert_true(warp_method_get(next)->cost_rank < warp_method_get(at)->cost_rank);
            if (w->runtime) assert_true(warp_method_get(next)->runtime);
            at = next;
            steps++;
        }
        assert_true(steps < WARP_METHOD_COUNT);
        assert_true(at == WARP_METHOD_ROTATION || at == WARP_METHOD_NONE);
        assert_int_equal(warp_method_get(at)->needs, 0); /* the end of a ladder runs on colour alone */
        for (int k = 0; k < w->n_knobs; k++) {
            const warp_knob *kn = &w->knobs[k];
            assert_true(kn->min <= kn->def && kn->def <= kn->max);
            assert_ptr_equal(warp_method_knob((warp_method)m, kn->name), kn); /* knob names unique */
        }
        /* needs only what a frame can carry */
        assert_int_equal(w->needs & ~(unsigned)(DRV_PLANE_DEPTH | DRV_PLANE_IDS | DRV_PLANE_MOTION | DRV_PLANE_LAYERS),
                         0);
    }
    assert_null(warp_method_get(WARP_METHOD_COUNT));
    assert_int_equal(warp_method_find("auto"), -1);
    assert_string_equal(warp_method_name(WARP_METHOD_COUNT), "?");
    /* the modules' own defaults */
    warp_raytrace_params rp = warp_raytrace_default_params();
    assert_int_equal(warp_method_knob(WARP_METHOD_RAYTRACE, "steps")->def, rp.max_steps);
    assert_int_equal(warp_method_knob(WARP_METHOD_RAYTRACE, "refine")->def, rp.refine_iters);
    assert_float_equal(warp_method_knob(WARP_METHOD_RAYTRACE, "edge_jump")->def, rp.edge_jump, 1e-6);
}

/* The planes each method needs are what the compositor checks: a frame lacking one walks the ladder to the warp
 * the compositor ran before the registry (transparency/objects -> raytrace; no depth -> rotation). */
static void ladders_match_compositor(void **state)
{
    (void)state;
    const unsigned all = DRV_PLANE_DEPTH | DRV_PLANE_IDS | DRV_PLANE_LAYERS | DRV_PLANE_MOTION;
    unsigned miss = 0;
    assert_int_equal(warp_method_usable(WARP_METHOD_TRANSPARENCY, all, &miss), WARP_METHOD_TRANSPARENCY);
    assert_int_equal(miss, 0);
    assert_int_equal(warp_method_usable(WARP_METHOD_TRANSPARENCY, all & ~DRV_PLANE_LAYERS, &miss),
                     WARP_METHOD_RAYTRACE);
    assert_int_equal(miss, DRV_PLANE_LAYERS);
    miss = 0;
    assert_int_equal(warp_method_usable(WARP_METHOD_OBJECTS, all & ~DRV_PLANE_IDS, &miss), WARP_METHOD_RAYTRACE);
    assert_int_equal(miss, DRV_PLANE_IDS);
    for (int m = 0; m < WARP_METHOD_RUNTIME_COUNT; m++) {
        miss = 0;
        warp_method u = warp_method_usable((warp_method)m, DRV_PLANE_COLOR, &miss);
        assert_int_equal(u, m == WARP_METHOD_NONE ? WARP_METHOD_NONE : WARP_METHOD_ROTATION);
        assert_int_equal(miss & ~warp_method_get((warp_method)m)->needs, 0);
    }
    assert_int_equal(warp_method_usable(WARP_METHOD_RAYTRACE_MESH, DRV_PLANE_DEPTH, NULL), WARP_METHOD_RAYTRACE_MESH);
}

/* The GPU column: every runtime method has a stand-in that the GLES renderer draws (compose_gles draws none,
 * rotation and raytrace: the methods that are their own stand-in), needing no plane the method itself does not;
 * the transparency and object warps and the mesh raytrace are the GPU's raytrace, as before the column. */
static void gpu_column_covers_runtime(void **state)
{
    (void)state;
    for (int m = 0; m < WARP_METHOD_COUNT; m++) {
        const warp_method_info *w = warp_method_get((warp_method)m);
        if (!w->runtime) {
            assert_int_equal(w->gpu, WARP_METHOD_COUNT);
            continue;
        }
        const warp_method_info *g = warp_method_get(w->gpu);
        assert_non_null(g);
        assert_true(g->runtime);
        assert_int_equal(g->gpu, w->gpu); /* a stand-in has a GPU pass of its own */
        assert_int_equal(g->needs & ~w->needs, 0);
        bool own = w->gpu == (warp_method)m;
        assert_int_equal(own, m == WARP_METHOD_NONE || m == WARP_METHOD_ROTATION || m == WARP_METHOD_RAYTRACE ||
                                  m == WARP_METHOD_RAYTRACE_MESH);
    }
    assert_int_equal(warp_method_get(WARP_METHOD_TRANSPARENCY)->gpu, WARP_METHOD_RAYTRACE);
    assert_int_equal(warp_method_get(WARP_METHOD_OBJECTS)->gpu, WARP_METHOD_RAYTRACE);
    assert_int_equal(warp_method_get(WARP_METHOD_RAYTRACE_MESH)->gpu, WARP_METHOD_RAYTRACE_MESH);
}

/* [warp] method takes exactly the runtime methods (by the registry's names, stored as its index) and auto. */
static void config_lists_registry(void **state)
{
    (void)state;
    for (int m = 0; m < WARP_METHOD_COUNT; m++) {
        rt_config c;
        rt_config_defaults(&c);
        rt_config_errors e;
        memset(&e, 0, sizeof e);
        char set[64];
        snprintf(set, sizeof set, "warp.method=%s", warp_method_name((warp_method)m));
        bool ok = rt_config_set(&c, set, &e);
        assert_int_equal(ok, m < WARP_METHOD_RUNTIME_COUNT);
        if (ok) {
            assert_int_equal(c.method, m);
            assert_string_equal(rt_method_name(c.method), warp_method_name((warp_method)m));
        }
    }
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors e;
    memset(&e, 0, sizeof e);
    assert_true(rt_config_set(&c, "warp.method=auto", &e));
    assert_int_equal(c.method, RT_METHOD_AUTO);
    /* auto's value is a reference warp's in the registry (iterative): the one conversion never hands it on */
    assert_int_equal(rt_method_warp(RT_METHOD_AUTO), WARP_METHOD_ROTATION);
    for (int m = 0; m < RT_METHOD_COUNT; m++) assert_int_equal(rt_method_warp((rt_method)m), m);

    /* --help-config's method line names every runtime method, and no reference-only one */
    char *buf = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&buf, &len);
    rt_config_print_keys(f);
    fclose(f);
    char *line = strstr(buf, "    method ");
    assert_non_null(line);
    char *end = strchr(line, '\n');
    *end = 0;
    for (int m = 0; m < WARP_METHOD_COUNT; m++) {
        char want[40];
        snprintf(want, sizeof want, " %s (", warp_method_name((warp_method)m));
        assert_int_equal(strstr(line, want) != NULL, m < WARP_METHOD_RUNTIME_COUNT);
    }
    free(buf);
}

/* The catalogue (hmdwarp-warp --list, the bench) lists every registry method once, in registry order, with the
 * registry's paper and planes, and range-checks parameters by the registry's knobs. */
static void catalogue_lists_registry(void **state)
{
    (void)state;
    const cat_warp *const *all = cat_all();
    int n = 0;
    for (; all[n]; n++) {
        const warp_method_info *w = warp_method_get((warp_method)n);
        assert_int_equal(all[n]->id, n);
        assert_string_equal(all[n]->name, w->name);
        assert_string_equal(all[n]->cite, w->cite);
        assert_int_equal(all[n]->needs, w->needs);
        assert_non_null(all[n]->run);
        assert_ptr_equal(cat_find(w->name), all[n]);
    }
    assert_int_equal(n, WARP_METHOD_COUNT);
    assert_non_null(cat_find("raytrace_mesh"));
    assert_null(cat_check_params(WARP_METHOD_RAYTRACE, "steps=16,refine=0"));
    assert_non_null(strstr(cat_check_params(WARP_METHOD_RAYTRACE, "steps=0"), "steps=0"));
    assert_non_null(strstr(cat_check_params(WARP_METHOD_RAYTRACE, "steps=1.5"), "whole number"));
    assert_non_null(strstr(cat_check_params(WARP_METHOD_ROTATION, "steps=16"), "'steps=16'"));
    assert_non_null(cat_check_params(WARP_METHOD_GRID, "tile="));
}

/* Every knob's registry range is what the warp itself accepts: run each colour+depth method with each knob at its
 * minimum and at its maximum (the others at their defaults) on a small pair; none may refuse the value (the
 * iterative warp's `iters` once reached down to 0, which the warp rejects as "iteration count T must be 1..256"). */
static void knob_ranges_accepted(void **state)
{
    (void)state;
    enum { W = 24, H = 16 };
    const warp_camera cam = {W, H, 1.0, 1.0, 0.8, 0.7, 0.05, INFINITY};
    test_pair tp;
    assert_true(test_pair_alloc(&tp, W, H, SIM_PLANE_COLOR | SIM_PLANE_DEPTH));
    const warp_pose a = test_eye_at(0, 0, 0, (warp_vec3){0, 0, 0});
    const warp_pose b = test_eye_at(0.05, 0.02, 0, (warp_vec3){0.02, 0, 0});
    test_pair_render(&tp, "near", &cam, a, b);
    int runs = 0;
    for (int m = 0; m < WARP_METHOD_COUNT; m++) {
        const warp_method_info *w = warp_method_get((warp_method)m);
        if (w->needs & ~(unsigned)WARP_NEEDS_DEPTH) continue; /* ids, motion, layers: not in this pair */
        for (int k = 0; k < w->n_knobs; k++) {
            for (int end = 0; end < 2; end++) {
                char params[80];
                snprintf(params, sizeof params, "%s=%g", w->knobs[k].name, end ? w->knobs[k].max : w->knobs[k].min);
                cat_stats st;
                const char *err = cat_all()[m]->run(&tp.v, &cam, b, 0.0, params, &tp.out, &tp.mask, &st);
                if (err) fail_msg("%s %s: %s", w->name, params, err);
                runs++;
            }
        }
    }
    assert_true(runs >= 20);
    test_pair_free(&tp);
}

static char tool[600]; /* build/hmdwarp-warp, beside this test's build/tests/unit/ */

/* hmdwarp-warp --list prints one line per registry method, in registry order, with its paper and planes. */
static void warp_tool_lists_registry(void **state)
{
    (void)state;
    char cmd[1000];
    /* under make check-cross the tool is a board binary: run it the way this test runs (TEST_RUNNER) */
    snprintf(cmd, sizeof cmd, "%s%s --list", test_runner(), tool);
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    char line[2048];
    int n = 0;
    while (fgets(line, sizeof line, p)) {
        assert_true(n < WARP_METHOD_COUNT);
        const warp_method_info *w = warp_method_get((warp_method)n);
        char want[100];
        snprintf(want, sizeof want, "  %-16s %-10s %s", w->name, w->cite, w->summary);
        assert_memory_equal(line, want, strlen(want));
        assert_int_equal(strstr(line, "[needs depth") != NULL, (w->needs & WARP_NEEDS_DEPTH) != 0);
        n++;
    }
    assert_int_equal(pclose(p), 0);
    assert_int_equal(n, WARP_METHOD_COUNT);
}

int main(int argc, char **argv)
{
    (void)argc;
    char tmp[512];
    snprintf(tmp, sizeof tmp, "%s", argv[0]);
    snprintf(tool, sizeof tool, "%s/hmdwarp-warp", dirname(dirname(dirname(tmp))));
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(entries_consistent),
        cmocka_unit_test(ladders_match_compositor),
        cmocka_unit_test(gpu_column_covers_runtime),
        cmocka_unit_test(config_lists_registry),
        cmocka_unit_test(catalogue_lists_registry),
        cmocka_unit_test(knob_ranges_accepted),
        cmocka_unit_test(warp_tool_lists_registry),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
