/* SPDX-License-Identifier: MIT */
/* Accuracy of the forward 3D warp (004) and its splat reconstructions (002 §3.3) against the simulator's ground
 * truth, and their invariants: identity, pure rotation, occlusion-compatible orders vs the z-buffer, two-pass ==
 * single pass, the pixel-movement bound p. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "tests/support/test_scene.h"

#include "sim/sim_scene.h"
#include "tests/support/test_util.h"
#include "warp/warp_camera.h"
#include "warp/warp_forward.h"
#include "warp/warp_holes.h"
#include "warp/warp_metrics.h"
#include "warp/warp_reproject.h"
#include "warp/warp_splat.h"
#include "warp/warp_view.h"

#define W 320
#define H 240

typedef struct {
    warp_camera cam;
    test_pair p;
    warp_image_rgba8 col;
    warp_image_u8 both;
    warp_fwd_scratch sc;
    float zref[W * H];
} fx;

static fx F;
static const double D2R = WARP_PI / 180.0;

static int setup(void **state)
{
    (void)state;
    F.cam = warp_camera_symmetric(W, H, 90.0, 2 * atan(0.75) / D2R, 0.05, INFINITY); /* square pixels */
    if (!test_pair_alloc(&F.p, W, H, SIM_PLANE_COLOR | SIM_PLANE_DEPTH) || !warp_image_rgba8_alloc(&F.col, W, H) ||
        !warp_image_u8_alloc(&F.both, W, H) || !warp_fwd_scratch_alloc(&F.sc, W, H, W, H))
        return -1;
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    test_pair_free(&F.p);
    warp_image_free(&F.col);
    warp_image_free(&F.both);
    warp_fwd_scratch_free(&F.sc);
    return 0;
}

/* Source render at a (with depth), truth at b. */
static void render_pair(const char *scene, warp_pose a, warp_pose b)
{
    test_pair_render(&F.p, scene, &F.cam, a, b);
}

static void fwd(warp_pose to, warp_fwd_visibility vis, bool two_pass, warp_image_rgba8 *out, warp_image_u8 *mask,
                warp_forward_stats *st)
{
    warp_forward_params p = warp_forward_default_params();
    p.vis = vis;
    p.two_pass = two_pass;
    assert_null(warp_forward_run(&F.p.v, &F.cam, to, &p, &F.sc, out, mask, st));
}

static void splat(warp_pose to, warp_splat_kind kind, warp_fwd_visibility vis, int size, warp_image_rgba8 *out,
                  warp_image_u8 *mask, warp_splat_stats *st)
{
    warp_splat_params p = warp_splat_default_params(kind);
    p.vis = vis;
    if (size > 0) p.min_size = p.max_size = size;
    assert_null(warp_splat_run(&F.p.v, &F.cam, to, &p, &F.sc, out, mask, st));
}

static void reproject(warp_pose to, warp_image_rgba8 *out, warp_image_u8 *mask)
{
    warp_mat3 h = warp_reproject_homography(&F.p.v, &F.cam, to.q);
    warp_reproject_rows(&F.p.v, &h, out, mask, 0, H);
}

static bool same_image(const warp_image_rgba8 *a, const warp_image_rgba8 *b)
{
    for (int y = 0; y < H; y++)
        if (memcmp(&WARP_AT(a, 0, y), &WARP_AT(b, 0, y), W * sizeof(warp_rgba8)) != 0) return false;
    return true;
}

static void or_masks(warp_image_u8 *dst, const warp_image_u8 *a, const warp_image_u8 *b)
{
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) WARP_AT(dst, x, y) = WARP_AT(a, x, y) | WARP_AT(b, x, y);
}

/* ---- geometry ---- */

static void test_warp_equation_and_epipole(void **state)
{
    (void)state;
    /* A world point seen from two eyes: the warp equation must move its source projection onto its target one. */
    test_rng r = test_rng_make(6);
    for (int i = 0; i < 200; i++) {
        warp_pose a = {test_random_quat(&r), warp_v3(test_rng_uniform(&r, -1, 1), 1.6, test_rng_uniform(&r, -1, 1))};
        warp_pose b = {warp_quat_mul(a.q, warp_quat_from_ypr(test_rng_uniform(&r, -0.2, 0.2),
                                                             test_rng_uniform(&r, -0.2, 0.2), 0)),
                       warp_v3_add(a.p, warp_v3(test_rng_uniform(&r, -0.1, 0.1), 0, test_rng_uniform(&r, -0.1, 0.1)))};
        warp_vec3 pe = warp_v3(test_rng_uniform(&r, -0.5, 0.5), test_rng_uniform(&r, -0.4, 0.4),
                               -test_rng_uniform(&r, 0.5, 5));
        warp_vec3 pw = warp_pose_apply(a, pe), pb = warp_pose_apply(warp_pose_inverse(b), pw);
        double x1, y1, d1, x2, y2, d2, wx, wy, wd;
        assert_true(warp_camera_project(&F.cam, pe, &x1, &y1, &d1));
        if (!warp_camera_project(&F.cam, pb, &x2, &y2, &d2)) continue;
        warp_fwd_xform xf = warp_fwd_xform_make(&F.cam, &F.cam, warp_pose_relative(b, a));
        assert_true(warp_fwd_xform_apply(&xf, x1, y1, d1, &wx, &wy, &wd));
        assert_true(fabs(wx - x2) < 1e-6 && fabs(wy - y2) < 1e-6 && fabs(wd - d2) < 1e-9);
    }
    /* Epipole: the target eye's centre in the source image, positive when it is in front of the source eye. */
    warp_vec3 ahead = warp_v3(0.05, 0.02, -0.1);
    warp_fwd_epipole e = warp_fwd_epipole_make(&F.cam, ahead);
    double ex, ey;
    assert_true(warp_camera_project(&F.cam, ahead, &ex, &ey, NULL));
    assert_true(e.defined && e.positive && fabs(e.x - ex) < 1e-9 && fabs(e.y - ey) < 1e-9);
    e = warp_fwd_epipole_make(&F.cam, warp_v3_scale(ahead, -1));
    assert_true(e.defined && !e.positive && fabs(e.x - ex) < 1e-9 && fabs(e.y - ey) < 1e-9); /* same point, away */
    e = warp_fwd_epipole_make(&F.cam, warp_v3(0, 0, 0));
    assert_false(e.defined); /* pure rotation */
    e = warp_fwd_epipole_make(&F.cam, warp_v3(0.1, 0, 0));
    assert_true(e.defined && e.x > 1e6); /* sideways: at infinity to the right */
}

static void check_permutation(const int32_t *order)
{
    static unsigned char seen[W * H];
    memset(seen, 0, sizeof seen);
    for (int i = 0; i < W * H; i++) {
        assert_true(order[i] >= 0 && order[i] < W * H);
        assert_int_equal(seen[order[i]], 0);
        seen[order[i]] = 1;
    }
}

static void test_traversal_orders(void **state)
{
    (void)state;
    warp_pose a = test_eye_at(0, 0, 0, warp_v3(0, 1.6, 0));
    render_pair("room", a, a);
    struct {
        warp_vec3 d;
        int s4, s8;
    } cases[] = {
        {{0.02, 0.01, -0.1}, 4, 8}, /* epipole inside, positive */
        {{0.02, 0.01, 0.1}, 4, 8},  /* inside, negative */
        {{0.2, 0.0, -0.01}, 2, 2},  /* right of the image, in its vertical middle: all |dx| >= |dy| */
        {{0.2, 0.2, -0.01}, 1, 2},  /* beyond a corner: one quadrant, the diagonal crosses it */
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        warp_pose b = a;
        b.p = warp_v3_add(a.p, cases[c].d);
        warp_forward_params p = warp_forward_default_params();
        warp_fwd_setup s;
        assert_null(warp_forward_prepare(&s, &F.p.v, &F.cam, b, &p));
        assert_int_equal(warp_forward_order(&s, WARP_FWD_SHEETS4, &F.sc), cases[c].s4);
        check_permutation(F.sc.order);
        assert_int_equal(warp_forward_order(&s, WARP_FWD_SHEETS8, &F.sc), cases[c].s8);
        check_permutation(F.sc.order);
        /* Back to front along the epipolar line through the epipole's row: a positive epipole is warped last, so
         * pixels farther from it come first; a negative one the other way round. */
        int row = (int)floor(s.ep.y), cx = (int)floor(s.ep.x);
        if (row < 0 || row >= H || cx < 0 || cx >= W) continue;
        static int pos[W * H];
        for (int i = 0; i < W * H; i++) pos[F.sc.order[i]] = i;
        int near = row * W + cx + 1, far = row * W + cx + 60;
        assert_true(s.ep.positive ? pos[far] < pos[near] : pos[far] > pos[near]);
    }
}

/* ---- invariants ---- */

static void test_identity_is_exact(void **state)
{
    (void)state;
    warp_pose a = test_eye_at(0.3, -0.1, 0.05, warp_v3(0.2, 1.5, -0.3));
    render_pair("near", a, a);
    warp_forward_stats st;
    const warp_fwd_visibility modes[] = {WARP_FWD_ZBUFFER, WARP_FWD_SHEETS4, WARP_FWD_SHEETS8};
    for (int m = 0; m < 3; m++)
        for (int tp = 0; tp < 2; tp++) {
            fwd(a, modes[m], tp, &F.p.out, &F.p.mask, &st);
            assert_true(same_image(&F.p.out, &F.p.a.color));
            assert_int_equal(st.holes, 0);
            assert_int_equal(st.samples, W * H);
        }
    for (int k = 0; k < 3; k++) {
        warp_splat_stats ss;
        splat(a, (warp_splat_kind)k, WARP_FWD_ZBUFFER, 0, &F.p.out, &F.p.mask, &ss);
        assert_true(same_image(&F.p.out, &F.p.a.color));
        assert_int_equal(ss.fwd.holes, 0);
    }
}

static void test_pure_rotation_matches_reprojection(void **state)
{
    (void)state;
    warp_pose a = test_eye_at(0.2, 0.05, 0, warp_v3(0.1, 1.6, 0.1));
    warp_pose b = test_eye_at(0.26, 0.02, 0.03, a.p);
    render_pair("near", a, b);
    /* The mapped positions are exactly the inverse of the rotation homography (depth drops out). */
    warp_forward_params p = warp_forward_default_params();
    warp_fwd_setup s;
    assert_null(warp_forward_prepare(&s, &F.p.v, &F.cam, b, &p));
    assert_false(s.ep.defined);
    warp_forward_map_rows(&s, &F.sc, false, 0, H, NULL);
    warp_mat3 h = warp_reproject_homography(&F.p.v, &F.cam, b.q);
    double worst = 0;
    for (int k = 0; k < W * H; k += 7) {
        if (!(F.sc.x2[k] == F.sc.x2[k])) continue;
        warp_vec3 q = warp_mat3_apply(&h, warp_v3(F.sc.x2[k], F.sc.y2[k], 1));
        worst = fmax(worst, hypot(q.x / q.z - (k % W + 0.5), q.y / q.z - (k / W + 0.5)));
    }
    assert_true(worst < 2e-3);
    /* Images agree up to resampling: the mesh interpolates linearly, as the reprojection's bilinear filter. */
    warp_splat_stats ss;
    splat(b, WARP_SPLAT_MESH, WARP_FWD_ZBUFFER, 0, &F.p.out, &F.p.mask, &ss);
    reproject(b, &F.p.out2, &F.p.mask2);
    or_masks(&F.both, &F.p.mask, &F.p.mask2);
    double mesh = warp_psnr(&F.p.out, &F.p.out2, &F.both, 0xff);
    fwd(b, WARP_FWD_SHEETS8, false, &F.p.out, &F.p.mask, NULL);
    or_masks(&F.both, &F.p.mask, &F.p.mask2);
    double pts = warp_psnr(&F.p.out, &F.p.out2, &F.both, 0xff);
    print_message("pure rotation vs reprojection: mesh %.2f dB, forward footprints %.2f dB\n", mesh, pts);
    assert_true(mesh > 38.0);
    assert_true(pts > 60.0); /* resampled through J^-1: the reprojection's own bilinear samples */
}

/* ---- against ground truth ---- */

static void test_translation_vs_truth(void **state)
{
    (void)state;
    warp_pose a = test_eye_home();
    warp_pose b = test_eye_at(1.5 * D2R, -3 * D2R, 0, warp_v3(0.04, 1.61, -0.01)); /* 4 cm sideways lean */
    render_pair("near", a, b);
    warp_forward_stats st;
    fwd(b, WARP_FWD_SHEETS8, false, &F.p.out, &F.p.mask, &st);
    reproject(b, &F.p.out2, &F.p.mask2);
    or_masks(&F.both, &F.p.mask, &F.p.mask2);
    double f = warp_psnr(&F.p.out, &F.p.b.color, &F.both, 0xff), r = warp_psnr(&F.p.out2, &F.p.b.color, &F.both, 0xff);
    double fe = warp_error_pixel_percent(&F.p.out, &F.p.b.color, &F.both, 0xff, 20);
    double re = warp_error_pixel_percent(&F.p.out2, &F.p.b.color, &F.both, 0xff, 20);
    long interior_holes = st.holes - st.fringe;
    print_message("near, 4 cm: forward %.2f dB / %.2f %% error px, rotation %.2f dB / %.2f %%; %ld holes (%ld fringe), "
                  "%ld writes, %d sheets\n",
                  f, fe, r, re, st.holes, st.fringe, st.writes, st.sheets);
    assert_true(f > 28.0);
    assert_true(f > r + 4.0);
    assert_true(fe < re / 2);
    assert_true(interior_holes > 50);        /* disocclusions behind the near objects */
    assert_true(interior_holes < W * H / 10); /* ... but no wholesale loss */
    /* Translating the wrong way must fail the threshold. */
    warp_pose wrong = b;
    wrong.p = warp_v3_sub(a.p, warp_v3_sub(b.p, a.p));
    fwd(wrong, WARP_FWD_SHEETS8, false, &F.p.out, &F.p.mask, &st);
    or_masks(&F.both, &F.p.mask, &F.p.mask2);
    double fw = warp_psnr(&F.p.out, &F.p.b.color, &F.both, 0xff);
    print_message("translation sign flipped: %.2f dB\n", fw);
    assert_true(fw < 24.0);
}

static void test_splats_vs_truth(void **state)
{
    (void)state;
    /* Stepping 8 cm forward magnifies the near objects: 1-pixel points crack, Jacobian-sized splats and the mesh
     * close the cracks and keep only the disocclusions. */
    warp_pose a = test_eye_home();
    warp_pose b = test_eye_at(0, -3 * D2R, 0, warp_v3(0.02, 1.6, -0.08));
    render_pair("near", a, b);
    warp_forward_stats pst;
    warp_forward_params pp = warp_forward_default_params();
    pp.vis = WARP_FWD_ZBUFFER;
    pp.footprint = false;
    assert_null(warp_forward_run(&F.p.v, &F.cam, b, &pp, &F.sc, &F.p.out2, &F.p.mask2, &pst));
    double pts = warp_psnr(&F.p.out2, &F.p.b.color, &F.p.mask2, 0xff);
    const char *names[] = {"point splat", "quad splat", "mesh"};
    long holes[3];
    double psnr[3];
    for (int k = 0; k < 3; k++) {
        warp_splat_stats st;
        splat(b, (warp_splat_kind)k, WARP_FWD_ZBUFFER, 0, &F.p.out, &F.p.mask, &st);
        holes[k] = st.fwd.holes - st.fwd.fringe;
        psnr[k] = warp_psnr(&F.p.out, &F.p.b.color, &F.p.mask, 0xff);
        double err = warp_error_pixel_percent(&F.p.out, &F.p.b.color, &F.p.mask, 0xff, 20);
        print_message("%-11s %.2f dB, %.2f %% error px, %ld interior holes, %ld primitives, %ld fragments, "
                      "%ld culled\n",
                      names[k], psnr[k], err, holes[k], st.primitives, st.fragments, st.culled);
        assert_true(psnr[k] > 26.0);
        assert_true(st.primitives > W * H / 2);
        if (k == WARP_SPLAT_MESH) assert_true(st.culled > 100); /* the mesh breaks at the depth edges */
    }
    long pholes = pst.holes - pst.fringe;
    print_message("1-px points  %.2f dB, %ld interior holes\n", pts, pholes);
    for (int k = 0; k < 3; k++) assert_true(holes[k] * 3 < pholes);
    assert_true(psnr[WARP_SPLAT_MESH] > psnr[WARP_SPLAT_POINT]);
}


/* ---- cracks (issue 21) ---- */

/* Forward holes filled by the depth-aware low-pass pyramid (000 §5.2), as a display path would fill them. */
static void fill_lowpass(warp_pose to, warp_image_rgba8 *img, warp_image_u8 *mask)
{
    warp_holes_ctx hc;
    assert_true(warp_holes_alloc(&hc, W, H, 12));
    warp_holes_params hp = warp_holes_default_params();
    hp.method = WARP_HOLES_LOWPASS;
    warp_epipole e = warp_epipole_from_poses(&F.cam, to, F.p.v.pose);
    warp_image_f32 zb = {W, H, W, F.sc.zbuf};
    assert_null(warp_holes_fill(&hc, img, mask, &zb, &e, &hp, NULL));
    warp_holes_free(&hc);
}

static void test_no_cracks_under_rotation(void **state)
{
    (void)state;
    /* A rotation stretches the image by up to (1 + tan^2) at the edges, so 1-pixel points left every stretched row
     * and column a crack (3.5 % of the pixels at 3 deg of yaw, 10 % at 12), and the hole fill blurred them: 3.4-4
     * dB under the backward rotation warp. Footprints tile the stretch; resampled through J^-1 a pure rotation
     * gives the backward warp's image. Small translations far from the objects open (almost) no disocclusions, so
     * they must not crack either. Scored after the low-pass fill where the backward warp is valid: cracks count. */
    struct {
        const char *scene;
        double yaw, pitch, roll; /* degrees */
        warp_vec3 move;          /* metres */
    } cases[] = {
        {"near", 3, 0, 0, {0, 0, 0}},    {"near", 12, 0, 0, {0, 0, 0}},    {"room", 12, 4, 3, {0, 0, 0}},
        {"room", 3, 0, 0, {0.02, 0, 0}}, {"room", 0, 0, 0, {0, 0, -0.05}},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        warp_pose a = test_eye_home();
        warp_pose b = test_eye_at(cases[i].yaw * D2R, (cases[i].pitch - 3) * D2R, cases[i].roll * D2R,
                                  warp_v3_add(a.p, cases[i].move));
        render_pair(cases[i].scene, a, b);
        warp_forward_stats st;
        fwd(b, WARP_FWD_SHEETS8, false, &F.p.out, &F.p.mask, &st);
        double cracks = 100.0 * (double)(st.holes - st.fringe) / (W * H);
        reproject(b, &F.p.out2, &F.p.mask2);
        fill_lowpass(b, &F.p.out, &F.p.mask);
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++)
                WARP_AT(&F.both, x, y) =
                    (uint8_t)(WARP_AT(&F.p.mask2, x, y) | (WARP_AT(&F.p.mask, x, y) & WARP_MASK_FRINGE));
        double f = warp_psnr(&F.p.out, &F.p.b.color, &F.both, 0xff);
        double r = warp_psnr(&F.p.out2, &F.p.b.color, &F.both, 0xff);
        bool rotation = warp_v3_norm(cases[i].move) == 0;
        print_message("%s, yaw %.0f pitch %.0f roll %.0f deg, %.0f cm: %.3f %% interior holes, forward %.2f dB, "
                      "backward rotation %.2f dB\n",
                      cases[i].scene, cases[i].yaw, cases[i].pitch, cases[i].roll, 100 * warp_v3_norm(cases[i].move),
                      cracks, f, r);
        assert_true(cracks < 0.1);
        if (rotation)
            assert_true(f > r - 1.0);
        else
            assert_true(f > 35.0); /* the backward rotation warp misses the parallax: 30 and 26 dB here */
    }
}

/* ---- splat centring (issue 21) ---- */

/* A fronto-parallel plane 1.5 m away whose colour names the source pixel (r, b: x; g: y), seen from the origin. */
static void id_plane(void)
{
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            WARP_AT(&F.p.inv, x, y) = 1 / 1.5f;
            WARP_AT(&F.col, x, y) = (warp_rgba8){(uint8_t)(x & 255), (uint8_t)y, (uint8_t)(x >> 8), 255};
        }
    F.p.v = (warp_view){.cam = F.cam, .pose = warp_pose_identity(), .color = &F.col, .inv_depth = &F.p.inv,
                        .inv_depth_min = 1 / 1.5f, .inv_depth_max = 1 / 1.5f};
}

/* Mean over the shown samples of (centroid of the pixels showing a sample - its warped position), in x and y, and
 * the share of target pixels written. */
static void splat_displacement(const warp_image_rgba8 *img, double *mx, double *my, double *coverage)
{
    static double sx[W * H], sy[W * H];
    static int cnt[W * H];
    memset(cnt, 0, sizeof cnt);
    memset(sx, 0, sizeof sx);
    memset(sy, 0, sizeof sy);
    long shown = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            warp_rgba8 c = WARP_AT(img, x, y);
            if (c.a == 0) continue; /* a hole */
            int k = c.g * W + (c.r | c.b << 8);
            sx[k] += x + 0.5;
            sy[k] += y + 0.5;
            cnt[k]++;
            shown++;
        }
    double ax = 0, ay = 0;
    long n = 0;
    for (int k = 0; k < W * H; k++) {
        if (!cnt[k]) continue;
        ax += sx[k] / cnt[k] - F.sc.x2[k];
        ay += sy[k] / cnt[k] - F.sc.y2[k];
        n++;
    }
    *mx = n ? ax / n : NAN;
    *my = n ? ay / n : NAN;
    *coverage = (double)shown / (W * H);
}

static void test_point_splats_centred(void **state)
{
    (void)state;
    /* Point splat sides are rounded up (002 §3.3), so a slight magnification makes nearly every splat 2x2 and they
     * overlap; when the later splat won every overlap, the image moved by half a pixel against the drawing order
     * (up and left in raster order). Each pixel must show its nearest sample: on a plane whose colours name the
     * source pixels, the shown pixels' centroid must sit on the sample's warped position, on average. */
    struct {
        const char *what;
        double yaw;     /* degrees */
        warp_vec3 move; /* metres */
    } cases[] = {
        {"4 cm closer", 0, {0, 0, -0.04}},
        {"3 deg yaw", 3, {0, 0, 0}},
        {"2 cm closer, 1 cm left", 0, {-0.01, 0.003, -0.02}},
        {"3 cm back", 0, {0, 0, 0.03}},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        for (int vis = WARP_FWD_ZBUFFER; vis <= WARP_FWD_SHEETS8; vis += WARP_FWD_SHEETS8) {
            id_plane();
            warp_pose b = test_eye_at(cases[i].yaw * D2R, 0, 0, cases[i].move);
            splat(b, WARP_SPLAT_POINT, (warp_fwd_visibility)vis, 0, &F.p.out, &F.p.mask, NULL);
            double dx, dy, cov;
            splat_displacement(&F.p.out, &dx, &dy, &cov);
            print_message("point splats, %s, %s: mean displacement (%+.3f, %+.3f) px, %.1f %% of pixels shown\n",
                          cases[i].what, vis ? "8 sheets" : "z-buffer", dx, dy, 100 * cov);
            assert_true(fabs(dx) < 0.1 && fabs(dy) < 0.1);
            assert_true(cov > 0.9);
        }
    /* Against the truth on rendered scenes (2 deg yaw, 2 cm sideways, 4 cm closer): displaced, point splats were
     * 5 dB under quad splats here; centred, 2-3 dB; with the rounded-up part only padding, 0.5-1.6 dB. */
    const char *scenes[] = {"room", "near"};
    const double floor_db[] = {33.0, 31.0};
    for (int sc = 0; sc < 2; sc++) {
        warp_pose a = test_eye_home();
        warp_pose b = test_eye_at(2 * D2R, -3 * D2R, 0, warp_v3(0.02, 1.6, -0.04));
        render_pair(scenes[sc], a, b);
        double ps[2];
        for (int k = 0; k < 2; k++) {
            splat(b, (warp_splat_kind)k, WARP_FWD_ZBUFFER, 0, &F.p.out, &F.p.mask, NULL);
            ps[k] = warp_psnr(&F.p.out, &F.p.b.color, &F.p.mask, 0xff);
        }
        print_message("%s: point splats %.2f dB, quad splats %.2f dB\n", scenes[sc], ps[0], ps[1]);
        assert_true(ps[0] > floor_db[sc]);
    }
}

/* ---- occlusion-compatible orders ---- */

/* Pixels whose visible sample is much farther than the z-buffer's: visibility errors. */
static long visibility_errors(const float *zref, const float *z)
{
    long n = 0;
    for (int i = 0; i < W * H; i++) n += zref[i] >= 0 && z[i] < 0.5f * zref[i];
    return n;
}

static void test_sheets8_fixes_sheets4_errors(void **state)
{
    (void)state;
    /* 004 §4.3: a raster sheet errs where its minor direction runs along the epipolar lines, i.e. along the row
     * of the epipole. Built case: a far wall with a two-pixel-high near wire on that row, the eye stepping back
     * (negative epipole: the wire shrinks towards it), drawn with 3x3 splats: in 4 sheets the wall samples of the
     * next row are drawn after the wire samples they cover; 8 sheets walk that region by columns. */
    warp_camera cam = F.cam;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            bool wire = (y == H / 2 - 1 || y == H / 2) && abs(x - W / 2) >= 40;
            WARP_AT(&F.p.inv, x, y) = wire ? 1 / 0.35f : 1 / 3.0f;
            int k = y * W + x;
            WARP_AT(&F.col, x, y) = wire ? (warp_rgba8){250, 40, 40, 255}
                                         : (warp_rgba8){(uint8_t)(k * 37), 120, (uint8_t)(k * 13 >> 5), 255};
        }
    F.p.v = (warp_view){.cam = cam, .pose = warp_pose_identity(), .color = &F.col, .inv_depth = &F.p.inv,
                      .inv_depth_min = 1 / 3.0f, .inv_depth_max = 1 / 0.35f};
    warp_pose b = warp_pose_identity();
    b.p = warp_v3(0, 0, 0.3);
    splat(b, WARP_SPLAT_POINT, WARP_FWD_ZBUFFER, 3, &F.p.out, NULL, NULL);
    memcpy(F.zref, F.sc.zbuf, sizeof F.zref);
    warp_splat_stats s4, s8;
    splat(b, WARP_SPLAT_POINT, WARP_FWD_SHEETS4, 3, &F.p.out2, NULL, &s4);
    long e4 = visibility_errors(F.zref, F.sc.zbuf);
    splat(b, WARP_SPLAT_POINT, WARP_FWD_SHEETS8, 3, &F.p.out2, NULL, &s8);
    long e8 = visibility_errors(F.zref, F.sc.zbuf);
    print_message("wire on the epipole's row: visibility errors 4 sheets %ld, 8 sheets %ld (%d / %d sheets)\n", e4,
                  e8, s4.fwd.sheets, s8.fwd.sheets);
    assert_int_equal(s4.fwd.sheets, 4);
    assert_int_equal(s8.fwd.sheets, 8);
    assert_true(e4 > 100);
    assert_int_equal(e8, 0);

    /* On a real scene with footprints, 8 sheets resolve visibility as the z-buffer does. */
    warp_pose a = test_eye_home();
    warp_pose c = test_eye_at(2 * D2R, -3 * D2R, 0, warp_v3(-0.05, 1.62, 0.04));
    render_pair("near", a, c);
    fwd(c, WARP_FWD_ZBUFFER, false, &F.p.out, NULL, NULL);
    memcpy(F.zref, F.sc.zbuf, sizeof F.zref);
    warp_forward_stats st;
    fwd(c, WARP_FWD_SHEETS8, false, &F.p.out2, NULL, &st);
    long en = visibility_errors(F.zref, F.sc.zbuf);
    print_message("near, forward: 8-sheet visibility errors %ld of %ld writes\n", en, st.writes);
    assert_true(en <= 5);
}

static void test_two_pass_equals_single_pass(void **state)
{
    (void)state;
    warp_pose a = test_eye_home();
    warp_pose b = test_eye_at(4 * D2R, -1 * D2R, 2 * D2R, warp_v3(0.05, 1.58, -0.04));
    render_pair("near", a, b);
    warp_forward_stats s1, s2;
    fwd(b, WARP_FWD_SHEETS8, false, &F.p.out, &F.p.mask, &s1);
    fwd(b, WARP_FWD_SHEETS8, true, &F.p.out2, &F.p.mask2, &s2);
    print_message("two-pass: %d bins, %ld seam pixels decided by order, %ld vs %ld writes\n", s2.bins,
                  s2.seam_resolves, s2.writes, s1.writes);
    assert_true(same_image(&F.p.out, &F.p.out2));
    for (int y = 0; y < H; y++) assert_memory_equal(&WARP_AT(&F.p.mask, 0, y), &WARP_AT(&F.p.mask2, 0, y), W);
    assert_int_equal(s2.bins, (W + 15) / 16);
    assert_true(s2.seam_resolves > 0);
    assert_true(s2.writes <= s1.writes);
}

/* ---- pixel-movement bound ---- */

static void test_pixel_bound(void **state)
{
    (void)state;
    /* eq. 7 tends to V / v for a narrow FOV, and the camera form equals the paper's for a symmetric camera. */
    double v = 0.01, p = warp_fwd_pixel_bound(480, 4.0 / 3.0, v, 0.01, 1.0);
    assert_true(fabs(p / (480 / v * asin(0.01)) - 1) < 1e-4);
    double pc = warp_fwd_pixel_bound_camera(&F.cam, 0.05, 0.5);
    double pp = warp_fwd_pixel_bound(H, (double)W / H, 2 * atan(0.75), 0.05, 0.5);
    assert_true(fabs(pc - pp) < 1e-9 * pp);
    assert_true(isinf(warp_fwd_pixel_bound(H, 1.33, 1.0, 1.0, 0.5)));
    assert_true(isnan(warp_fwd_pixel_bound(H, 1.33, 1.0, -1.0, 0.5)));

    /* Measured movement from the projective position never exceeds p, over random poses within T_max. */
    warp_pose a = test_eye_home();
    render_pair("near", a, a);
    double d_min = INFINITY;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double u, vv, z = 1.0 / WARP_AT(&F.p.inv, x, y);
            warp_camera_pixel_to_tan(&F.cam, x + 0.5, y + 0.5, &u, &vv);
            d_min = fmin(d_min, z * sqrt(1 + u * u + vv * vv));
        }
    const double t_max = 0.08;
    double bound = warp_fwd_pixel_bound_camera(&F.cam, t_max, d_min), worst = 0;
    test_rng r = test_rng_make(44);
    for (int i = 0; i < 40; i++) {
        warp_vec3 dir = warp_v3(test_rng_uniform(&r, -1, 1), test_rng_uniform(&r, -1, 1), test_rng_uniform(&r, -1, 1));
        double n = warp_v3_norm(dir);
        warp_pose b = {warp_quat_mul(a.q, warp_quat_from_ypr(test_rng_uniform(&r, -0.2, 0.2),
                                                             test_rng_uniform(&r, -0.2, 0.2),
                                                             test_rng_uniform(&r, -0.2, 0.2))),
                       warp_v3_add(a.p, warp_v3_scale(dir, t_max * test_rng_uniform(&r, 0.5, 1.0) / n))};
        warp_forward_params p0 = warp_forward_default_params();
        warp_fwd_setup s;
        assert_null(warp_forward_prepare(&s, &F.p.v, &F.cam, b, &p0));
        warp_forward_map_rows(&s, &F.sc, false, 0, H, NULL);
        for (int k = 0; k < W * H; k++) {
            double x2 = F.sc.x2[k], y2 = F.sc.y2[k], xi, yi, di;
            if (!(x2 >= 0 && x2 <= W && y2 >= 0 && y2 <= H)) continue;
            if (!warp_fwd_xform_apply(&s.cam_xf, k % W + 0.5, k / W + 0.5, 0, &xi, &yi, &di)) continue;
            if (!(xi >= 0 && xi <= W && yi >= 0 && yi <= H)) continue;
            worst = fmax(worst, hypot(x2 - xi, y2 - yi));
        }
    }
    print_message("d_min %.3f m, T_max %.2f m: bound p = %.1f px, largest measured movement %.1f px\n", d_min, t_max,
                  bound, worst);
    assert_true(worst <= bound);
    assert_true(worst > 0.25 * bound); /* and it is not vacuous */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_warp_equation_and_epipole),
        cmocka_unit_test(test_traversal_orders),
        cmocka_unit_test(test_identity_is_exact),
        cmocka_unit_test(test_pure_rotation_matches_reprojection),
        cmocka_unit_test(test_translation_vs_truth),
        cmocka_unit_test(test_splats_vs_truth),
        cmocka_unit_test(test_no_cracks_under_rotation),
        cmocka_unit_test(test_point_splats_centred),
        cmocka_unit_test(test_sheets8_fixes_sheets4_errors),
        cmocka_unit_test(test_two_pass_equals_single_pass),
        cmocka_unit_test(test_pixel_bound),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
