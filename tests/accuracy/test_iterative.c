/* SPDX-License-Identifier: MIT */
/* Accuracy of the iterative backward warp (001 §3) against the simulator's ground truth: near (translation and
 * disocclusion) and movers (object motion), its invariants, and the paper's claims about its knobs. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>
#include <cmocka.h>

#include "sim/sim_peel.h"
#include "sim/sim_scene.h"
#include "warp/warp_camera.h"
#include "warp/warp_iterative.h"
#include "warp/warp_metrics.h"
#include "warp/warp_reproject.h"
#include "warp/warp_view.h"
#include "tests/support/test_scene.h"

#define W 320
#define H 240
#define MAX_OBJ 16

typedef struct {
    warp_camera cam;
    test_pair p;           /* source render, truth render */
    sim_buffers bg;        /* background (peeled) layer of the source */
    warp_image_f32 inv_bg, inv_peel;
    warp_image_u8 excl;
    warp_iter_layer layer_bg, layer_peel;
    warp_pose obj_src[MAX_OBJ], obj_dst[MAX_OBJ];
    warp_iter_target tgt;
    warp_iter_ctx ctx;
} fx;

static fx F;
static const double D2R = WARP_PI / 180.0;

static int setup(void **state)
{
    (void)state;
    F.cam = (warp_camera){W, H, 1.0, 1.0, 0.75, 0.75, 0.05, INFINITY};
    unsigned all = SIM_PLANE_COLOR | SIM_PLANE_DEPTH | SIM_PLANE_IDS | SIM_PLANE_MOTION;
    if (!test_pair_alloc(&F.p, W, H, all) ||
        !sim_buffers_alloc(&F.bg, W, H, SIM_PLANE_COLOR | SIM_PLANE_DEPTH | SIM_PLANE_IDS, 1))
        return -1;
    if (!warp_image_f32_alloc(&F.inv_bg, W, H) || !warp_image_f32_alloc(&F.inv_peel, W, H) ||
        !warp_image_u8_alloc(&F.excl, W, H))
        return -1;
    if (!warp_iter_alloc(&F.ctx, W, H, W, H, 3)) return -1;
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    test_pair_free(&F.p);
    sim_buffers_free(&F.bg);
    warp_image_free(&F.inv_bg);
    warp_image_free(&F.inv_peel);
    warp_image_free(&F.excl);
    warp_iter_free(&F.ctx);
    return 0;
}

/* Source of `scene` at (pose a, time ta) with all its planes and its background layer (dense and peeled), truth
 * at (pose b, time tb). The target carries the objects' exact poses at tb. */
static void render_pair(const char *scene, warp_pose a, double ta, warp_pose b, double tb)
{
    const sim_scene *s = sim_scene_find(scene);
    assert_non_null(s);
    unsigned planes = sim_planes_for_effects(sim_scene_effects(s)) | SIM_PLANE_DEPTH | SIM_PLANE_IDS;
    sim_render(s, ta, a, &F.cam, planes, &F.p.a);
    sim_render(s, tb, b, &F.cam, SIM_PLANE_COLOR | SIM_PLANE_IDS, &F.p.b);
    int n = sim_scene_object_count(s);
    assert_true(n <= MAX_OBJ);
    for (int i = 0; i < n; i++) {
        F.obj_src[i] = sim_scene_object_pose(s, i + 1, ta);
        F.obj_dst[i] = sim_scene_object_pose(s, i + 1, tb);
    }
    F.p.v = (warp_view){.cam = F.cam, .pose = a, .color = &F.p.a.color, .inv_depth = &F.p.inv, .ids = &F.p.a.ids,
                      .motion = (planes & SIM_PLANE_MOTION) ? &F.p.a.motion : NULL, .n_objects = n,
                      .object_pose = F.obj_src, .time = ta};
    assert_int_equal(warp_inverse_depth_from(&F.cam, WARP_DEPTH_LINEAR, &F.p.a.depth, &F.p.inv, &F.p.v.inv_depth_min,
                                             &F.p.v.inv_depth_max),
                     0);
    F.tgt = (warp_iter_target){.cam = F.cam, .pose = b, .time = tb, .object_pose = F.obj_dst};
    /* the background layer: dense (the room everywhere) and peeled (only where the front layer hides it) */
    assert_true(sim_peel_render_rows(s, ta, a, &F.cam, SIM_PLANE_COLOR | SIM_PLANE_DEPTH | SIM_PLANE_IDS, &F.bg, 0, H));
    float mn, mx;
    assert_int_equal(warp_inverse_depth_from(&F.cam, WARP_DEPTH_LINEAR, &F.bg.depth, &F.inv_bg, &mn, &mx), 0);
    for (int y = 0; y < H; y++) memcpy(&WARP_AT(&F.inv_peel, 0, y), &WARP_AT(&F.inv_bg, 0, y), W * sizeof(float));
    long kept = warp_iter_peel_mask(&F.p.inv, &F.inv_peel, 1e-3f);
    assert_true(kept > 0 && kept < (long)W * H / 2);
    F.layer_bg = (warp_iter_layer){.color = &F.bg.color, .inv_depth = &F.inv_bg, .ids = &F.bg.ids};
    F.layer_peel = (warp_iter_layer){.color = &F.bg.color, .inv_depth = &F.inv_peel, .ids = &F.bg.ids};
}

static warp_iter_stats run(const warp_iter_params *p, const warp_iter_layer *extra, warp_image_rgba8 *out,
                           warp_image_u8 *mask)
{
    warp_iter_stats st;
    memset(&st, 0, sizeof st);
    const char *err = warp_iter_run(&F.ctx, &F.p.v, extra, extra ? 1 : 0, &F.tgt, p, out, mask, &st);
    if (err) print_message("warp_iter_run: %s\n", err);
    assert_null(err);
    return st;
}

static double pct(long a, long b) { return 100.0 * (double)a / (double)b; }

static void print_stats(const char *what, const warp_iter_stats *s, double psnr)
{
    print_message("%-28s %6.2f dB  conv %6.2f %%  holes %5ld  fringe %5ld  seeds/px %.2f  iters/seed %.2f  "
                  "area %.1f  dil %ld  approx %ld  layer1 %ld  cross %ld\n",
                  what, psnr, pct(s->converged, s->pixels), s->holes, s->fringe, (double)s->seeds / s->pixels,
                  (double)s->iterations / (double)s->seeds, s->bound_area / (double)s->pixels, s->dilated,
                  s->approximated, s->converged_layer[1], s->cross_layer);
}

/* Pixels that are fringe in either of two masks: scored away from fringes the way test_warp_accuracy does. */
static void union_fringe(const warp_image_u8 *a, const warp_image_u8 *b)
{
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            WARP_AT(&F.excl, x, y) = (uint8_t)((WARP_AT(a, x, y) | (b ? WARP_AT(b, x, y) : 0)) & WARP_MASK_FRINGE);
}

/* ---- invariants ---- */

static void test_identity_pose(void **state)
{
    (void)state;
    warp_pose a = test_eye_at(0.2, 0.1, 0, warp_v3(0.05, 1.55, 0.1));
    render_pair("near", a, 0.0, a, 0.0);
    warp_iter_params p = warp_iter_default_params();
    const warp_iter_bound bounds[] = {WARP_ITER_BOUND_GLOBAL, WARP_ITER_BOUND_TIGHT, WARP_ITER_BOUND_PCA};
    for (int i = 0; i < 3; i++) {
        p.bound = bounds[i];
        warp_iter_stats st = run(&p, NULL, &F.p.out, &F.p.mask);
        assert_true(isinf(warp_psnr(&F.p.out, &F.p.a.color, NULL, 0))); /* identity pose -> identity image */
        assert_int_equal(st.converged, (long)W * H);
        assert_int_equal(st.holes + st.fringe, 0);
        assert_int_equal(st.seeds, (long)W * H); /* a zero-width bound: the early exit takes one seed */
    }
}

static void test_pure_rotation_matches_reprojection(void **state)
{
    (void)state;
    warp_pose a = test_eye_at(0.2, 0.1, 0, warp_v3(0.05, 1.55, 0.1));
    warp_pose b = test_eye_at(0.2 + 4 * D2R, 0.1 - 2 * D2R, 1.5 * D2R, a.p);
    render_pair("near", a, 0.0, b, 0.0);
    warp_iter_params p = warp_iter_default_params();
    warp_iter_stats st = run(&p, NULL, &F.p.out, &F.p.mask);
    warp_mat3 hm = warp_reproject_homography(&F.p.v, &F.cam, b.q);
    warp_reproject_rows(&F.p.v, &hm, &F.p.out2, &F.p.mask2, 0, H);
    union_fringe(&F.p.mask, &F.p.mask2);
    double same = warp_psnr(&F.p.out, &F.p.out2, &F.excl, WARP_MASK_FRINGE);
    print_stats("pure rotation vs reproject", &st, same);
    assert_true(same > 40.0);
    assert_int_equal(st.holes, 0);
    /* the head turned left: the fringe is at the left edge, as the rotation warp's */
    long agree = 0, fr = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            bool f1 = WARP_AT(&F.p.mask, x, y) & WARP_MASK_FRINGE, f2 = WARP_AT(&F.p.mask2, x, y) & WARP_MASK_FRINGE;
            fr += f2;
            agree += f1 == f2;
        }
    assert_true(fr > 0);
    assert_true(agree > (long)W * H * 99 / 100);
}


/* ---- near: translation and disocclusion ---- */

static const warp_pose *near_a(void)
{
    static warp_pose a;
    a = test_eye_home();
    return &a;
}
/* a 4 cm sideways lean with a 1.5 degree turn, as test_warp_accuracy's raytrace case */
static warp_pose near_b(void) { return test_eye_at(1.5 * D2R, -3 * D2R, 0, warp_v3(0.04, 1.61, -0.01)); }

static double psnr_excl(const warp_image_rgba8 *out, const warp_image_u8 *mask, uint8_t excl)
{
    return warp_psnr(out, &F.p.b.color, mask, excl);
}

static void test_near_translation(void **state)
{
    (void)state;
    warp_pose a = *near_a(), b = near_b();
    render_pair("near", a, 0.0, b, 0.0);
    warp_iter_params p = warp_iter_default_params();
    warp_iter_stats st = run(&p, NULL, &F.p.out, &F.p.mask);
    double conv = warp_psnr(&F.p.out, &F.p.b.color, &F.p.mask, WARP_MASK_FRINGE | WARP_MASK_HOLE);
    double err = warp_error_pixel_percent(&F.p.out, &F.p.b.color, &F.p.mask, WARP_MASK_FRINGE | WARP_MASK_HOLE, 20);
    /* the rotation warp on the same pixels: what ignoring depth costs */
    warp_mat3 hm = warp_reproject_homography(&F.p.v, &F.cam, b.q);
    warp_reproject_rows(&F.p.v, &hm, &F.p.out2, &F.p.mask2, 0, H);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) WARP_AT(&F.excl, x, y) = WARP_AT(&F.p.mask, x, y) | WARP_AT(&F.p.mask2, x, y);
    double rot = psnr_excl(&F.p.out2, &F.excl, 0xff), it = psnr_excl(&F.p.out, &F.excl, 0xff);
    print_stats("near N8 T4 L1 pca", &st, conv);
    print_message("  converged px: %.2f %% error px; rotation warp there %.2f dB vs %.2f dB\n", err, rot, it);
    assert_true(conv > 32.0);
    assert_true(err < 3.0);
    assert_true(it > rot + 5.0);
    assert_true(pct(st.converged, st.pixels) > 90.0);
    /* the near objects against the far wall open disocclusions that a single layer cannot fill */
    assert_true(st.holes > st.pixels / 200 && st.holes < st.pixels * 6 / 100);
    /* a sign error in the translation (warping to the mirrored lean) must fail the threshold */
    warp_iter_target good = F.tgt;
    F.tgt.pose.p = warp_v3_sub(warp_v3_scale(a.p, 2.0), b.p);
    run(&p, NULL, &F.p.out2, &F.p.mask2);
    double wrong = warp_psnr(&F.p.out2, &F.p.b.color, &F.p.mask2, WARP_MASK_FRINGE | WARP_MASK_HOLE);
    print_message("  mirrored translation: %.2f dB\n", wrong);
    assert_true(wrong < 24.0);
    F.tgt = good;
}

/* 001 §3.4 / §4.2: multi-layer warping beats single-layer warping on disocclusions, and beats filling the single
 * layer's holes by dilation or by the approximate fallback. */
static void test_multilayer_beats_single_layer(void **state)
{
    (void)state;
    render_pair("near", *near_a(), 0.0, near_b(), 0.0);
    warp_iter_params p = warp_iter_default_params();
    warp_iter_stats s1 = run(&p, NULL, &F.p.out2, &F.p.mask2); /* keeps L = 1's holes in mask2 */
    double one = psnr_excl(&F.p.out2, &F.p.mask2, WARP_MASK_FRINGE);
    p.layers = 2;
    warp_iter_stats s2 = run(&p, &F.layer_bg, &F.p.out, &F.p.mask);
    double two = psnr_excl(&F.p.out, &F.p.mask, WARP_MASK_FRINGE);
    /* score on the disocclusions alone: the pixels the single layer left as holes */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            WARP_AT(&F.excl, x, y) = (uint8_t)((WARP_AT(&F.p.mask2, x, y) & WARP_MASK_HOLE) ? 0 : 1);
    double two_dis = psnr_excl(&F.p.out, &F.excl, 1);
    double two_dis_err = warp_error_pixel_percent(&F.p.out, &F.p.b.color, &F.excl, 1, 20);
    print_stats("near L=1", &s1, one);
    print_stats("near L=2 (background layer)", &s2, two);
    p.layers = 1;
    p.dilate = true;
    warp_iter_stats sd = run(&p, NULL, &F.p.out, &F.p.mask);
    double dil = psnr_excl(&F.p.out, &F.p.mask, WARP_MASK_FRINGE);
    double dil_dis = psnr_excl(&F.p.out, &F.excl, 1);
    double dil_dis_err = warp_error_pixel_percent(&F.p.out, &F.p.b.color, &F.excl, 1, 20);
    print_stats("near L=1 + dilation", &sd, dil);
    p.dilate = false;
    p.approximate = true;
    warp_iter_stats sa = run(&p, NULL, &F.p.out, &F.p.mask);
    double apx = psnr_excl(&F.p.out, &F.p.mask, WARP_MASK_FRINGE);
    double apx_dis = psnr_excl(&F.p.out, &F.excl, 1);
    print_stats("near L=1 + AWOC", &sa, apx);
    print_message("  on the L=1 holes: L=2 %.2f dB (%.1f %% error px), dilation %.2f dB (%.1f %%), AWOC %.2f dB\n",
                  two_dis, two_dis_err, dil_dis, dil_dis_err, apx_dis);
    assert_true(s2.holes * 10 < s1.holes);
    assert_true(s2.converged_layer[1] > 0);
    assert_true(two > one + 5.0);
    assert_true(two > dil + 2.0 && two > apx + 2.0);
    assert_true(two_dis > dil_dis + 2.0 && two_dis > apx_dis + 2.0);
    assert_true(two_dis_err < dil_dis_err);
}

/* A depth-peeled layer is empty wherever nothing is hidden: cross-layer seeding (001 Fig. 6) lets a search that
 * runs into its empty texels continue from the layer above instead of dying there. */
static void test_peeled_layer_cross_layer_seeding(void **state)
{
    (void)state;
    render_pair("near", *near_a(), 0.0, near_b(), 0.0);
    warp_iter_params p = warp_iter_default_params();
    warp_iter_stats s1 = run(&p, NULL, &F.p.out, &F.p.mask);
    p.layers = 2;
    warp_iter_stats sc = run(&p, &F.layer_peel, &F.p.out, &F.p.mask);
    double cross = psnr_excl(&F.p.out, &F.p.mask, WARP_MASK_FRINGE);
    p.cross_layer = false;
    warp_iter_stats sn = run(&p, &F.layer_peel, &F.p.out2, &F.p.mask2);
    double plain = psnr_excl(&F.p.out2, &F.p.mask2, WARP_MASK_FRINGE);
    print_stats("near L=2 peeled, cross-layer", &sc, cross);
    print_stats("near L=2 peeled, per layer", &sn, plain);
    assert_true(sc.cross_layer > 0 && sn.cross_layer == 0);
    assert_true(sc.holes * 10 < s1.holes && sn.holes * 10 < s1.holes);
    assert_true(sc.holes < sn.holes);
    assert_true(sc.seeds < sn.seeds); /* the fallback bound is tight where the peeled layer is empty */
}

/* 001 Table 2: the tight motion bound beats the global bound when N is small (same N and T). */
static void test_tight_bound_beats_global_at_small_n(void **state)
{
    (void)state;
    render_pair("near", *near_a(), 0.0, near_b(), 0.0);
    static const char *const names[] = {"global", "tight", "pca"};
    for (int n = 1; n <= 8; n *= 2) {
        double ps[3];
        long holes[3];
        for (int b = 0; b < 3; b++) {
            warp_iter_params p = warp_iter_default_params();
            p.seeds = n;
            p.iters = 3;
            p.bound = (warp_iter_bound)b;
            warp_iter_stats st = run(&p, NULL, &F.p.out, &F.p.mask);
            ps[b] = psnr_excl(&F.p.out, &F.p.mask, WARP_MASK_FRINGE);
            holes[b] = st.holes;
            char name[48];
            snprintf(name, sizeof name, "near N=%d T=3 %s", n, names[b]);
            print_stats(name, &st, ps[b]);
        }
        if (n <= 2) {
            for (int b = 1; b < 3; b++) {
                assert_true(holes[b] * 10 < holes[0] * 9); /* at least 10 % fewer non-convergent pixels */
                assert_true(ps[b] > ps[0] + 0.5);
            }
        }
    }
}

/* 001 Fig. 11: more fixed-point iterations converge more pixels. */
static void test_more_iterations_converge_more(void **state)
{
    (void)state;
    render_pair("near", *near_a(), 0.0, near_b(), 0.0);
    long prev = -1, first = 0;
    for (int t = 1; t <= 8; t *= 2) {
        warp_iter_params p = warp_iter_default_params();
        p.iters = t;
        warp_iter_stats st = run(&p, NULL, &F.p.out, &F.p.mask);
        char name[32];
        snprintf(name, sizeof name, "near T=%d", t);
        print_stats(name, &st, psnr_excl(&F.p.out, &F.p.mask, WARP_MASK_FRINGE));
        assert_true(st.converged > prev);
        assert_true(st.iterations <= (long)t * st.seeds);
        if (t == 1) first = st.converged;
        prev = st.converged;
    }
    assert_true(prev > first + (long)W * H / 4);
}

/* Holes closed from converged neighbours (001 Fig. 8) and the approximate fallback (001 §5, AWOC). */
static void test_dilation_and_approximate_fill(void **state)
{
    (void)state;
    render_pair("near", *near_a(), 0.0, near_b(), 0.0);
    warp_iter_params p = warp_iter_default_params();
    warp_iter_stats s0 = run(&p, NULL, &F.p.out2, &F.p.mask2);
    double none = psnr_excl(&F.p.out2, &F.p.mask2, WARP_MASK_FRINGE);
    p.dilate = true;
    warp_iter_stats sd = run(&p, NULL, &F.p.out, &F.p.mask);
    double dil = psnr_excl(&F.p.out, &F.p.mask, WARP_MASK_FRINGE);
    long filled = 0, open = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            uint8_t m = WARP_AT(&F.p.mask, x, y);
            filled += (m & (WARP_MASK_HOLE | WARP_MASK_FILLED)) == (WARP_MASK_HOLE | WARP_MASK_FILLED);
            open += m == WARP_MASK_HOLE;
            /* only holes are written by the fill; everything else is the plain warp's */
            if (!(WARP_AT(&F.p.mask2, x, y) & WARP_MASK_HOLE)) {
                warp_rgba8 c1 = WARP_AT(&F.p.out, x, y), c2 = WARP_AT(&F.p.out2, x, y);
                assert_true(c1.r == c2.r && c1.g == c2.g && c1.b == c2.b);
            }
        }
    print_stats("near dilation r=2", &sd, dil);
    assert_int_equal(sd.holes, s0.holes);
    assert_int_equal(filled, sd.dilated);
    assert_int_equal(open, sd.holes - sd.dilated);
    assert_true(sd.dilated > sd.holes / 2);
    assert_true(dil > none + 3.0);
    p.dilate = false;
    p.approximate = true;
    warp_iter_stats sa = run(&p, NULL, &F.p.out, &F.p.mask);
    assert_int_equal(sa.approximated, sa.holes); /* AWOC writes every non-convergent pixel */
    assert_true(psnr_excl(&F.p.out, &F.p.mask, WARP_MASK_FRINGE) > none + 3.0);
    p.dilate = true;
    warp_iter_stats sb = run(&p, NULL, &F.p.out, &F.p.mask);
    print_stats("near AWOC + dilation", &sb, psnr_excl(&F.p.out, &F.p.mask, WARP_MASK_FRINGE));
    assert_int_equal(sb.dilated + sb.approximated, sb.holes);
}

/* ---- large motion: the defaults must hold across the head motions the runtime meets ---- */

/* Renders "near" from a (source) and b (truth), runs the defaults on the pair and scores them on the pixels visible
 * in both views: those the rotation warp does not put in its fringe (independent of the warp under test, which may
 * fail to find even the fringe). valid: the share of them a search converged for inside the source, which must
 * exceed min_valid %; psnr: against the truth, holes left in, which must exceed min_psnr dB. */
static void large_motion(const char *what, warp_pose a, warp_pose b, double min_valid, double min_psnr)
{
    render_pair("near", a, 0.0, b, 0.0);
    warp_iter_params p = warp_iter_default_params();
    warp_iter_stats st = run(&p, NULL, &F.p.out, &F.p.mask);
    warp_mat3 hm = warp_reproject_homography(&F.p.v, &F.cam, F.tgt.pose.q);
    warp_reproject_rows(&F.p.v, &hm, &F.p.out2, &F.p.mask2, 0, H);
    long visible = 0, ok = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            if (WARP_AT(&F.p.mask2, x, y) & WARP_MASK_FRINGE) continue;
            visible++;
            ok += WARP_AT(&F.p.mask, x, y) == 0;
        }
    assert_true(visible > (long)W * H / 4);
    double valid = pct(ok, visible), psnr = psnr_excl(&F.p.out, &F.p.mask2, WARP_MASK_FRINGE);
    print_stats(what, &st, psnr);
    print_message("  %s: %.2f %% of the visible pixels valid, %.2f dB\n", what, valid, psnr);
    assert_true(valid > min_valid);
    assert_true(psnr > min_psnr);
}

/* A 12 degree turn with 4 degrees of pitch: the motion field varies by tens of pixels across the image, which the
 * plain fixed point q <- p - v(q) reduces by only |1 - dv/dq| per step. */
static void test_large_rotation(void **state)
{
    (void)state;
    warp_pose a = test_eye_at(0.1, -0.05, 0, warp_v3(0.05, 1.55, 0.1));
    large_motion("yaw 12 pitch 4", a, test_eye_at(0.1 + 12 * D2R, -0.05 + 4 * D2R, 0, a.p), 99.0, 32.0);
}

/* 20 cm of head translation with the near scene's objects 0.4-1.5 m away: up to ~50 px of parallax. */
static void test_large_translation(void **state)
{
    (void)state;
    /* what the near objects uncover stays holes in a single layer (~14 %: a background layer converges 98.6 %),
     * and they are black in the PSNR */
    large_motion("translate 20 cm", *near_a(), test_eye_home_moved(warp_v3(0.16, 0, -0.12)), 84.0, 14.8);
}

/* The adaptive budget: with the cap at 32 steps, seeds that converge run as long as they contract and the
 * non-convergent ones (across the disocclusions) stop after a few steps, so a large cap costs little. */
static void test_adaptive_budget(void **state)
{
    (void)state;
    render_pair("near", *near_a(), 0.0, test_eye_home_moved(warp_v3(0.16, 0, -0.12)), 0.0);
    warp_iter_params p = warp_iter_default_params();
    p.iters = 32;
    warp_iter_stats st = run(&p, NULL, &F.p.out, &F.p.mask);
    double per_seed = (double)st.iterations / (double)st.seeds;
    print_stats("translate 20 cm, T cap 32", &st, psnr_excl(&F.p.out, &F.p.mask, WARP_MASK_FRINGE));
    assert_true(pct(st.converged, st.pixels) > 84.0);
    assert_true(per_seed < 5.5);
    /* the same search with a small cap converges less: the budget is what it converged with */
    p.iters = 4;
    warp_iter_stats s4 = run(&p, NULL, &F.p.out, &F.p.mask);
    assert_true(s4.converged * 100 < st.converged * 95);
}

/* A 45 degree head turn (about a neck 10 cm behind the eyes): half the target is outside the source; where it is
 * inside, the rotation scales the image by up to 2x, where the plain fixed point does not converge at all. */
static void test_45_degree_turn(void **state)
{
    (void)state;
    const warp_vec3 neck = warp_v3(0, 1.5, 0.1);
    warp_pose a = test_eye_at(0, 0, 0, warp_v3(0, 1.6, 0));
    warp_pose b = test_eye_at(45 * D2R, 0, 0, a.p);
    b.p = warp_v3_add(neck, warp_quat_rotate(b.q, warp_v3_sub(a.p, neck)));
    /* the neck swings the eyes ~9 cm past objects 0.4 m away: their disocclusions stay holes (~6 %) */
    large_motion("yaw 45", a, b, 90.0, 19.0);
}

/* ---- movers: object motion ---- */

/* Scores the pixels of the translating sphere (id 7) and the slowly spinning box (id 8) in the truth, away from
 * fringes and holes. (The fast spinners' Lambert shading changes as they turn: no warp can follow that.) */
static double object_psnr(const warp_image_rgba8 *out, const warp_image_u8 *mask, double *err)
{
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int id = WARP_AT(&F.p.b.ids, x, y);
            bool o = id == 7 || id == 8;
            WARP_AT(&F.excl, x, y) = (uint8_t)((WARP_AT(mask, x, y) & (WARP_MASK_FRINGE | WARP_MASK_HOLE)) | (o ? 0 : 0x80));
        }
    *err = warp_error_pixel_percent(out, &F.p.b.color, &F.excl, 0xff, 20);
    return warp_psnr(out, &F.p.b.color, &F.excl, 0xff);
}

static void test_movers_object_motion(void **state)
{
    (void)state;
    /* t = 2 s: the sphere passes the middle of its swing at full speed (1.6 m/s); 0.1 s later it is ~7 px on */
    warp_pose a = test_eye_at(0, 0, 0, warp_v3(0, 1.6, 0)), b = test_eye_at(1 * D2R, 0, 0, warp_v3(0.02, 1.6, 0));
    render_pair("movers", a, 2.0, b, 2.1);
    warp_iter_params p = warp_iter_default_params();
    double e_exact, e_plane, e_static;
    warp_iter_stats se = run(&p, NULL, &F.p.out, &F.p.mask);
    double exact = object_psnr(&F.p.out, &F.p.mask, &e_exact);
    print_stats("movers exact poses, L=1", &se, exact);
    /* with the room behind the movers as a second layer, what they uncover is filled too */
    p.layers = 2;
    warp_iter_stats s2 = run(&p, &F.layer_bg, &F.p.out, &F.p.mask);
    double whole2 = psnr_excl(&F.p.out, &F.p.mask, WARP_MASK_FRINGE);
    print_stats("movers exact poses, L=2", &s2, whole2);
    p.layers = 1;
    F.tgt.object_pose = NULL; /* the screen-motion plane, extrapolated */
    warp_iter_stats sp = run(&p, NULL, &F.p.out, &F.p.mask);
    double plane = object_psnr(&F.p.out, &F.p.mask, &e_plane);
    print_stats("movers motion plane, L=1", &sp, plane);
    F.p.v.motion = NULL; /* no object motion at all: a broken warp's view */
    warp_iter_stats ss = run(&p, NULL, &F.p.out, &F.p.mask);
    double stat = object_psnr(&F.p.out, &F.p.mask, &e_static);
    double whole_static = psnr_excl(&F.p.out, &F.p.mask, WARP_MASK_FRINGE);
    print_stats("movers objects static, L=1", &ss, stat);
    print_message("  objects: exact %.2f dB / %.1f %% error px, plane %.2f / %.1f %%, static %.2f / %.1f %%; "
                  "whole image L=2 %.2f dB vs static %.2f dB\n",
                  exact, e_exact, plane, e_plane, stat, e_static, whole2, whole_static);
    assert_true(exact > 23.5 && plane > 23.5);
    assert_true(stat < 20.0);
    assert_true(e_exact < 8.0 && e_plane < 8.0 && e_static > 20.0);
    assert_true(se.holes > 0 && ss.holes == 0); /* moving objects uncover the room behind them */
    assert_true(s2.holes * 4 < se.holes);
    assert_true(whole2 > whole_static + 1.0);
}

/* ---- the min-max motion mipmap (001 §3.3) ---- */

/* A query must bound every motion a bilinear lookup in its rectangle can return: brute force on random rectangles
 * of the near scene's motion, in the PCA-rotated coordinates. */
static void test_mip_bound_is_conservative(void **state)
{
    (void)state;
    render_pair("near", *near_a(), 0.0, near_b(), 0.0);
    warp_iter_params p = warp_iter_default_params();
    assert_null(warp_iter_prepare(&F.ctx, &F.p.v, NULL, 0, &F.tgt, &p));
    const warp_motion_buffer *m = &F.ctx.motion[0];
    const warp_motion_mip *mip = &F.ctx.mip[0];
    assert_true(mip->theta != 0.0); /* a sideways lean: the principal axis is not the image axis */
    uint64_t seed = 12345;
    int tight = 0;
    for (int k = 0; k < 3000; k++) {
        double r[4];
        for (int i = 0; i < 4; i++) {
            seed = seed * 6364136223846793005ull + 1442695040888963407ull;
            r[i] = (double)(seed >> 40) / (double)(1ull << 24);
        }
        double sz = k % 3 == 0 ? 80 : (k % 3 == 1 ? 12 : 3);
        double x0 = r[0] * (W + 20) - 10, y0 = r[1] * (H + 20) - 10, x1 = x0 + r[2] * sz, y1 = y0 + r[3] * sz;
        warp_motion_box q = warp_motion_mip_query(mip, x0, y0, x1, y1);
        int ix0 = (int)floor(x0 - 0.5), iy0 = (int)floor(y0 - 0.5), ix1 = (int)floor(x1 - 0.5) + 1,
            iy1 = (int)floor(y1 - 0.5) + 1;
        ix0 = ix0 < 0 ? 0 : (ix0 > W - 1 ? W - 1 : ix0), ix1 = ix1 < 0 ? 0 : (ix1 > W - 1 ? W - 1 : ix1);
        iy0 = iy0 < 0 ? 0 : (iy0 > H - 1 ? H - 1 : iy0), iy1 = iy1 < 0 ? 0 : (iy1 > H - 1 ? H - 1 : iy1);
        warp_motion_box bf = {{INFINITY, INFINITY}, {-INFINITY, -INFINITY}};
        for (int y = iy0; y <= iy1; y++)
            for (int x = ix0; x <= ix1; x++) {
                const warp_motion_texel *t = &m->px[(size_t)y * W + (size_t)x];
                if (!(t->d >= 0)) continue;
                double a, b;
                warp_motion_rotate(mip->c, mip->s, t->x, t->y, &a, &b);
                assert_true(a >= q.lo[0] && a <= q.hi[0] && b >= q.lo[1] && b <= q.hi[1]);
                if (a < bf.lo[0]) bf.lo[0] = (float)a;
                if (a > bf.hi[0]) bf.hi[0] = (float)a;
                if (b < bf.lo[1]) bf.lo[1] = (float)b;
                if (b > bf.hi[1]) bf.hi[1] = (float)b;
            }
        /* and it is a real tightening: often much narrower than the global bound */
        warp_motion_box g = warp_motion_mip_global(mip);
        tight += (q.hi[0] - q.lo[0]) < 0.5f * (g.hi[0] - g.lo[0]);
    }
    assert_true(tight > 1000);
}

/* ---- bad input ---- */

static void test_bad_input_is_rejected(void **state)
{
    (void)state;
    render_pair("near", *near_a(), 0.0, near_b(), 0.0);
    warp_iter_params p = warp_iter_default_params();
    warp_iter_stats st = {0};
    p.layers = 2; /* no extra layer given */
    assert_non_null(warp_iter_run(&F.ctx, &F.p.v, NULL, 0, &F.tgt, &p, &F.p.out, &F.p.mask, &st));
    p.layers = 4; /* more than the context holds */
    assert_non_null(warp_iter_run(&F.ctx, &F.p.v, &F.layer_bg, 3, &F.tgt, &p, &F.p.out, &F.p.mask, &st));
    p = warp_iter_default_params();
    p.seeds = 0;
    assert_non_null(warp_iter_run(&F.ctx, &F.p.v, NULL, 0, &F.tgt, &p, &F.p.out, &F.p.mask, &st));
    p = warp_iter_default_params();
    p.tol = NAN;
    assert_non_null(warp_iter_run(&F.ctx, &F.p.v, NULL, 0, &F.tgt, &p, &F.p.out, &F.p.mask, &st));
    p = warp_iter_default_params();
    warp_view nodepth = F.p.v;
    nodepth.inv_depth = NULL;
    assert_non_null(warp_iter_run(&F.ctx, &nodepth, NULL, 0, &F.tgt, &p, &F.p.out, &F.p.mask, &st));
    warp_iter_target bad = F.tgt;
    bad.pose.p.x = NAN;
    assert_non_null(warp_iter_run(&F.ctx, &F.p.v, NULL, 0, &bad, &p, &F.p.out, &F.p.mask, &st));
    bad = F.tgt;
    bad.cam.width = W / 2;
    assert_non_null(warp_iter_run(&F.ctx, &F.p.v, NULL, 0, &bad, &p, &F.p.out, &F.p.mask, &st));
    assert_int_equal(st.pixels, 0); /* nothing ran */
    /* NaN depth texels are empty, not poison: the warp still runs and leaves no NaN position behind */
    WARP_AT(&F.p.inv, 10, 10) = NAN;
    assert_null(warp_iter_run(&F.ctx, &F.p.v, NULL, 0, &F.tgt, &p, &F.p.out, &F.p.mask, &st));
    assert_true(st.converged > st.pixels * 9 / 10);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_identity_pose),
        cmocka_unit_test(test_pure_rotation_matches_reprojection),
        cmocka_unit_test(test_near_translation),
        cmocka_unit_test(test_multilayer_beats_single_layer),
        cmocka_unit_test(test_peeled_layer_cross_layer_seeding),
        cmocka_unit_test(test_tight_bound_beats_global_at_small_n),
        cmocka_unit_test(test_more_iterations_converge_more),
        cmocka_unit_test(test_dilation_and_approximate_fill),
        cmocka_unit_test(test_large_rotation),
        cmocka_unit_test(test_large_translation),
        cmocka_unit_test(test_45_degree_turn),
        cmocka_unit_test(test_adaptive_budget),
        cmocka_unit_test(test_movers_object_motion),
        cmocka_unit_test(test_mip_bound_is_conservative),
        cmocka_unit_test(test_bad_input_is_rejected),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
