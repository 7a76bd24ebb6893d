/* Accuracy of the iterative backward warp (001 §3) against the simulator's ground truth: near (translation and
 * disocclusion) and movers (object motion), its invariants, and the paper's claims about its knobs. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>
#include <cmocka.h>

#include "sim/sim_peel.h"
#include "sim/sim_scene.h"
#include "warp/warp_camera.h"
#include "warp/warp_iterative.h"
#include "warp/warp_metrics.h"
#include "warp/warp_reproject.h"
#include "warp/warp_view.h"

#define W 320
#define H 240
#define MAX_OBJ 16

typedef struct {
    warp_camera cam;
    sim_buffers a, b, bg;  /* source render, truth render, background (peeled) layer of the source */
    warp_image_f32 inv, inv_bg, inv_peel;
    warp_image_rgba8 out, out2;
    warp_image_u8 mask, mask2, excl;
    warp_view v;
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
    if (!sim_buffers_alloc(&F.a, W, H, all, 1) || !sim_buffers_alloc(&F.b, W, H, all, 1) ||
        !sim_buffers_alloc(&F.bg, W, H, SIM_PLANE_COLOR | SIM_PLANE_DEPTH | SIM_PLANE_IDS, 1))
        return -1;
    if (!warp_image_f32_alloc(&F.inv, W, H) || !warp_image_f32_alloc(&F.inv_bg, W, H) ||
        !warp_image_f32_alloc(&F.inv_peel, W, H) || !warp_image_rgba8_alloc(&F.out, W, H) ||
        !warp_image_rgba8_alloc(&F.out2, W, H) || !warp_image_u8_alloc(&F.mask, W, H) ||
        !warp_image_u8_alloc(&F.mask2, W, H) || !warp_image_u8_alloc(&F.excl, W, H))
        return -1;
    if (!warp_iter_alloc(&F.ctx, W, H, W, H, 3)) return -1;
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    sim_buffers_free(&F.a);
    sim_buffers_free(&F.b);
    sim_buffers_free(&F.bg);
    warp_image_free(&F.inv);
    warp_image_free(&F.inv_bg);
    warp_image_free(&F.inv_peel);
    warp_image_free(&F.out);
    warp_image_free(&F.out2);
    warp_image_free(&F.mask);
    warp_image_free(&F.mask2);
    warp_image_free(&F.excl);
    warp_iter_free(&F.ctx);
    return 0;
}

static warp_pose eye_at(double yaw, double pitch, double roll, warp_vec3 p)
{
    warp_pose e = {warp_quat_from_ypr(yaw, pitch, roll), p};
    return e;
}

/* Source of `scene` at (pose a, time ta) with all its planes and its background layer (dense and peeled), truth
 * at (pose b, time tb). The target carries the objects' exact poses at tb. */
static void render_pair(const char *scene, warp_pose a, double ta, warp_pose b, double tb)
{
    const sim_scene *s = sim_scene_find(scene);
    assert_non_null(s);
    unsigned planes = sim_planes_for_effects(sim_scene_effects(s)) | SIM_PLANE_DEPTH | SIM_PLANE_IDS;
    sim_render(s, ta, a, &F.cam, planes, &F.a);
    sim_render(s, tb, b, &F.cam, SIM_PLANE_COLOR | SIM_PLANE_IDS, &F.b);
    int n = sim_scene_object_count(s);
    assert_true(n <= MAX_OBJ);
    for (int i = 0; i < n; i++) {
        F.obj_src[i] = sim_scene_object_pose(s, i + 1, ta);
        F.obj_dst[i] = sim_scene_object_pose(s, i + 1, tb);
    }
    F.v = (warp_view){.cam = F.cam, .pose = a, .color = &F.a.color, .inv_depth = &F.inv, .ids = &F.a.ids,
                      .motion = (planes & SIM_PLANE_MOTION) ? &F.a.motion : NULL, .n_objects = n,
                      .object_pose = F.obj_src, .time = ta};
    assert_int_equal(warp_inverse_depth_from(&F.cam, WARP_DEPTH_LINEAR, &F.a.depth, &F.inv, &F.v.inv_depth_min,
                                             &F.v.inv_depth_max),
                     0);
    F.tgt = (warp_iter_target){.cam = F.cam, .pose = b, .time = tb, .object_pose = F.obj_dst};
    /* the background layer: dense (the room everywhere) and peeled (only where the front layer hides it) */
    assert_true(sim_peel_render_rows(s, ta, a, &F.cam, SIM_PLANE_COLOR | SIM_PLANE_DEPTH | SIM_PLANE_IDS, &F.bg, 0, H));
    float mn, mx;
    assert_int_equal(warp_inverse_depth_from(&F.cam, WARP_DEPTH_LINEAR, &F.bg.depth, &F.inv_bg, &mn, &mx), 0);
    for (int y = 0; y < H; y++) memcpy(&WARP_AT(&F.inv_peel, 0, y), &WARP_AT(&F.inv_bg, 0, y), W * sizeof(float));
    long kept = warp_iter_peel_mask(&F.inv, &F.inv_peel, 1e-3f);
    assert_true(kept > 0 && kept < (long)W * H / 2);
    F.layer_bg = (warp_iter_layer){.color = &F.bg.color, .inv_depth = &F.inv_bg, .ids = &F.bg.ids};
    F.layer_peel = (warp_iter_layer){.color = &F.bg.color, .inv_depth = &F.inv_peel, .ids = &F.bg.ids};
}

static warp_iter_stats run(const warp_iter_params *p, const warp_iter_layer *extra, warp_image_rgba8 *out,
                           warp_image_u8 *mask)
{
    warp_iter_stats st;
    memset(&st, 0, sizeof st);
    const char *err = warp_iter_run(&F.ctx, &F.v, extra, extra ? 1 : 0, &F.tgt, p, out, mask, &st);
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
    warp_pose a = eye_at(0.2, 0.1, 0, warp_v3(0.05, 1.55, 0.1));
    render_pair("near", a, 0.0, a, 0.0);
    warp_iter_params p = warp_iter_default_params();
    const warp_iter_bound bounds[] = {WARP_ITER_BOUND_GLOBAL, WARP_ITER_BOUND_TIGHT, WARP_ITER_BOUND_PCA};
    for (int i = 0; i < 3; i++) {
        p.bound = bounds[i];
        warp_iter_stats st = run(&p, NULL, &F.out, &F.mask);
        assert_true(isinf(warp_psnr(&F.out, &F.a.color, NULL, 0))); /* identity pose -> identity image */
        assert_int_equal(st.converged, (long)W * H);
        assert_int_equal(st.holes + st.fringe, 0);
        assert_int_equal(st.seeds, (long)W * H); /* a zero-width bound: the early exit takes one seed */
    }
}

static void test_pure_rotation_matches_reprojection(void **state)
{
    (void)state;
    warp_pose a = eye_at(0.2, 0.1, 0, warp_v3(0.05, 1.55, 0.1));
    warp_pose b = eye_at(0.2 + 4 * D2R, 0.1 - 2 * D2R, 1.5 * D2R, a.p);
    render_pair("near", a, 0.0, b, 0.0);
    warp_iter_params p = warp_iter_default_params();
    warp_iter_stats st = run(&p, NULL, &F.out, &F.mask);
    warp_mat3 hm = warp_reproject_homography(&F.v, &F.cam, b.q);
    warp_reproject_rows(&F.v, &hm, &F.out2, &F.mask2, 0, H);
    union_fringe(&F.mask, &F.mask2);
    double same = warp_psnr(&F.out, &F.out2, &F.excl, WARP_MASK_FRINGE);
    print_stats("pure rotation vs reproject", &st, same);
    assert_true(same > 40.0);
    assert_int_equal(st.holes, 0);
    /* the head turned left: the fringe is at the left edge, as the rotation warp's */
    long agree = 0, fr = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            bool f1 = WARP_AT(&F.mask, x, y) & WARP_MASK_FRINGE, f2 = WARP_AT(&F.mask2, x, y) & WARP_MASK_FRINGE;
            fr += f2;
            agree += f1 == f2;
        }
    assert_true(fr > 0);
    assert_true(agree > (long)W * H * 99 / 100);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_identity_pose),
        cmocka_unit_test(test_pure_rotation_matches_reprojection),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
