/* SPDX-License-Identifier: MIT */
/* The depth warps on real photographs (issue 21): the Aloe pair of the Middlebury 2006 stereo set with its
 * ground-truth disparity, as Debian's opencv-doc ships it. The left photograph, with the depth its disparity gives,
 * is warped to the right camera by every depth warp and scored against the right photograph on the pixels both
 * cameras see, overall and in a 3 px band along the depth edges (where the warps differ most). */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>
#include <turbojpeg.h>

#include "platform/plat_png.h"
#include "tests/support/test_images.h"
#include "warp/warp_camera.h"
#include "warp/warp_forward.h"
#include "warp/warp_grid.h"
#include "warp/warp_holes.h"
#include "warp/warp_image.h"
#include "warp/warp_iterative.h"
#include "warp/warp_mesh.h"
#include "warp/warp_mesh_trace.h"
#include "warp/warp_metrics.h"
#include "warp/warp_raytrace.h"
#include "warp/warp_resample.h"
#include "warp/warp_splat.h"
#include "warp/warp_view.h"

#ifndef ALOE_DIR
#define ALOE_DIR "/usr/share/doc/opencv-doc/examples/data/"
#endif
#define ALOE_PKG "opencv-doc"

/* The photographs are 1282 x 1110 with disparities of 43-211 px; halved, the whole test takes about a second and
 * the disparities (22-105 px) are still larger than a head motion's. SCALE, MESH_CELL_PX and ALOE_DIR may be
 * given with -D to measure other cases (at full size: 5 s). */
#ifndef SCALE
#define SCALE 2
#endif
/* Both eyes' camera: only f * baseline matters (inverse depth = d / (f b)); 60 degrees and 10 cm put the depths
 * at 0.5-2.5 m, in the range the warps' defaults are tuned for. */
#define HFOV_DEG 60.0
#define BASELINE_M 0.1
/* A jump between neighbouring disparities larger than this fraction is a depth edge: the warps' own edge_jump on
 * inverse depth, which disparity is proportional to. */
#define EDGE_JUMP 0.1f
#define BAND_PX 3
/* The display mesh's cells: 24 px, as the default 64-vertex mesh on a 1440 x 1600 eye. */
#ifndef MESH_CELL_PX
#define MESH_CELL_PX 24
#endif

/* Left and right photographs and the ground truth at working size; the left view with its inverse depth. */
typedef struct {
    int w, h;
    warp_camera cam;
    warp_pose right_pose;
    warp_image_rgba8 left, right;
    warp_image_f32 disp;     /* left-view disparity in working pixels, 0 = unknown (GT's 0) */
    warp_image_f32 inv;      /* left-view inverse depth, unknowns filled from the farther neighbour in the row */
    warp_view v;
    warp_image_f32 disp_r;   /* right-view disparity from the GT forward map, 0 = nothing visible in both */
    warp_image_u8 valid;     /* right pixels visible in both views (1) */
    warp_image_u8 band;      /* ... of which within BAND_PX of a depth edge (1) */
    warp_image_rgba8 out;
    warp_image_u8 mask;
    warp_image_f32 zb;
} stereo_fx;

static stereo_fx S;
static const test_image images[] = {TEST_RGBA8(&S.left), TEST_RGBA8(&S.right), TEST_F32(&S.disp), TEST_F32(&S.inv),
                                    TEST_F32(&S.disp_r), TEST_U8(&S.valid),     TEST_U8(&S.band),  TEST_RGBA8(&S.out),
                                    TEST_U8(&S.mask),    TEST_F32(&S.zb)};
static bool have_data;

/* ---- reading and preparing the pair ---- */

static bool read_jpeg(const char *path, warp_image_rgba8 *img, char *err, size_t errlen)
{
    FILE *f = fopen(path, "rb");
    if (!f) return snprintf(err, errlen, "%s: cannot open", path), false;
    unsigned char *buf = NULL;
    long n = -1;
    if (fseek(f, 0, SEEK_END) == 0 && (n = ftell(f)) > 0 && fseek(f, 0, SEEK_SET) == 0 && (buf = malloc((size_t)n)) &&
        fread(buf, 1, (size_t)n, f) != (size_t)n)
        n = -1;
    fclose(f);
    bool ok = false;
    tjhandle tj = tjInitDecompress();
    int w, h, sub, cs;
    if (buf && n > 0 && tj && tjDecompressHeader3(tj, buf, (unsigned long)n, &w, &h, &sub, &cs) == 0 &&
        warp_image_rgba8_alloc(img, w, h))
        ok = tjDecompress2(tj, buf, (unsigned long)n, (unsigned char *)img->px, w, img->stride * 4, h, TJPF_RGBA, 0) ==
             0;
    if (!ok) snprintf(err, errlen, "%s: %s", path, tj ? tjGetErrorStr2(tj) : "cannot decode");
    if (tj) tjDestroy(tj);
    free(buf);
    return ok;
}

/* Box filter by SCALE (colour in 8-bit sRGB, as the photographs are). */
static void downscale_rgba(const warp_image_rgba8 *src, warp_image_rgba8 *dst)
{
    for (int y = 0; y < dst->h; y++)
        for (int x = 0; x < dst->w; x++) {
            int s[4] = {0, 0, 0, 0};
            for (int j = 0; j < SCALE; j++)
                for (int i = 0; i < SCALE; i++) {
                    warp_rgba8 c = WARP_AT(src, x * SCALE + i, y * SCALE + j);
                    s[0] += c.r, s[1] += c.g, s[2] += c.b;
                }
            int n = SCALE * SCALE;
            WARP_AT(dst, x, y) = (warp_rgba8){(uint8_t)((s[0] + n / 2) / n), (uint8_t)((s[1] + n / 2) / n),
                                              (uint8_t)((s[2] + n / 2) / n), 255};
        }
}

/* Disparity of a block: unknown when half of it is; the mean on one surface; across an edge the nearest (largest)
 * value, since the box-filtered colour there is mostly the foreground's silhouette. In working pixels. */
static void downscale_disparity(const warp_image_rgba8 *gt, warp_image_f32 *dst)
{
    for (int y = 0; y < dst->h; y++)
        for (int x = 0; x < dst->w; x++) {
            int n = 0, sum = 0, lo = 255, hi = 0;
            for (int j = 0; j < SCALE; j++)
                for (int i = 0; i < SCALE; i++) {
                    int d = WARP_AT(gt, x * SCALE + i, y * SCALE + j).r;
                    if (!d) continue;
                    n++, sum += d;
                    lo = d < lo ? d : lo, hi = d > hi ? d : hi;
                }
            float d = 0;
            if (2 * n >= SCALE * SCALE) d = (hi - lo) <= EDGE_JUMP * hi ? (float)sum / (float)n : (float)hi;
            WARP_AT(dst, x, y) = d / SCALE;
        }
}

/* Inverse depth of the left view: d / (f b); unknown disparities (occluded in the right view or not matched) take
 * the farther of the nearest known ones along the row: what an occlusion hides is background. */
static void inverse_depth_from_disparity(void)
{
    double fb = warp_camera_pixels_per_tan_x(&S.cam) * BASELINE_M;
    float lo = INFINITY, hi = 0;
    for (int y = 0; y < S.h; y++)
        for (int x = 0; x < S.w; x++) {
            float d = WARP_AT(&S.disp, x, y);
            if (d <= 0) {
                float l = 0, r = 0;
                for (int i = x - 1; i >= 0 && !l; i--) l = WARP_AT(&S.disp, i, y);
                for (int i = x + 1; i < S.w && !r; i++) r = WARP_AT(&S.disp, i, y);
                d = l && r ? fminf(l, r) : fmaxf(l, r);
            }
            assert_true(d > 0); /* no row of the Aloe GT is unknown throughout */
            float inv = (float)(d / fb);
            WARP_AT(&S.inv, x, y) = inv;
            lo = fminf(lo, inv), hi = fmaxf(hi, inv);
        }
    S.v = (warp_view){.cam = S.cam, .pose = {warp_quat_identity(), warp_v3(0, 0, 0)}, .color = &S.left,
                      .inv_depth = &S.inv, .inv_depth_min = lo, .inv_depth_max = hi};
}

/* The ground truth's own forward map into the right view: each left pixel with a known disparity moves to x - d;
 * neighbours on one surface (disparities within EDGE_JUMP) span the right pixels between them, the nearest surface
 * wins. Covered right pixels are visible in both views; the rest are disocclusions, unknown GT or the fringe. */
static void right_view_truth(void)
{
    for (int y = 0; y < S.h; y++) {
        float *dr = &WARP_AT(&S.disp_r, 0, y);
        for (int x = 0; x < S.w; x++) dr[x] = 0;
        for (int x = 0; x < S.w; x++) {
            float d0 = WARP_AT(&S.disp, x, y), d1 = x + 1 < S.w ? WARP_AT(&S.disp, x + 1, y) : 0;
            if (d0 <= 0) continue;
            double x0 = x + 0.5 - d0; /* continuous position of the pixel centre in the right view */
            bool span = d1 > 0 && fabsf(d1 - d0) <= EDGE_JUMP * fmaxf(d0, d1);
            double x1 = span ? x + 1.5 - d1 : x0;
            /* right pixel centres in [x0, x1), or the one x0 lands in for an isolated sample */
            int a = span ? (int)ceil(x0 - 0.5) : (int)floor(x0), b = span ? (int)ceil(x1 - 0.5) : a + 1;
            for (int i = a < 0 ? 0 : a; i < b && i < S.w; i++) {
                double t = span && x1 > x0 ? (i + 0.5 - x0) / (x1 - x0) : 0;
                float d = (float)(d0 + t * (d1 - d0));
                if (d > dr[i]) dr[i] = d;
            }
        }
    }
    for (int y = 0; y < S.h; y++)
        for (int x = 0; x < S.w; x++) WARP_AT(&S.valid, x, y) = WARP_AT(&S.disp_r, x, y) > 0;
    /* Depth edges: a jump to a neighbour, or a neighbour no left pixel reaches inside the image (a disocclusion). */
    for (int y = 0; y < S.h; y++)
        for (int x = 0; x < S.w; x++) WARP_AT(&S.band, x, y) = 0;
    for (int y = 1; y < S.h - 1; y++)
        for (int x = 1; x < S.w - 1; x++) {
            float d = WARP_AT(&S.disp_r, x, y);
            if (d <= 0) continue;
            const int nb[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
            bool edge = false;
            for (int k = 0; k < 4 && !edge; k++) {
                float e = WARP_AT(&S.disp_r, x + nb[k][0], y + nb[k][1]);
                /* a hole whose left pixels would come from beyond the left image's right border is the fringe */
                bool fringe = e <= 0 && x + nb[k][0] + d >= S.w - 1;
                edge = e > 0 ? fabsf(e - d) > EDGE_JUMP * fmaxf(e, d) : !fringe;
            }
            if (!edge) continue;
            for (int j = -BAND_PX; j <= BAND_PX; j++)
                for (int i = -BAND_PX; i <= BAND_PX; i++) {
                    int xx = x + i, yy = y + j;
                    if (xx >= 0 && yy >= 0 && xx < S.w && yy < S.h) WARP_AT(&S.band, xx, yy) = 1;
                }
        }
    for (int y = 0; y < S.h; y++)
        for (int x = 0; x < S.w; x++) WARP_AT(&S.band, x, y) &= WARP_AT(&S.valid, x, y);
}

static int setup(void **state)
{
    (void)state;
    warp_image_rgba8 l, r, gt;
    char err[512];
    have_data = read_jpeg(ALOE_DIR "aloeL.jpg", &l, err, sizeof err) &&
                read_jpeg(ALOE_DIR "aloeR.jpg", &r, err, sizeof err) &&
                plat_png_read(ALOE_DIR "aloeGT.png", &gt, err, (int)sizeof err);
    if (!have_data) {
        /* not a skip: make test installs the package (board/deps.sh), so a missing file is a broken setup */
        print_error("%s\nthe Aloe stereo pair comes with Debian's %s package: apt-get install %s (board/deps.sh)\n",
                    err, ALOE_PKG, ALOE_PKG);
        return 0;
    }
    if (l.w != r.w || l.h != r.h || l.w != gt.w || l.h != gt.h) return -1;
    S.w = l.w / SCALE, S.h = l.h / SCALE;
    double t = tan(HFOV_DEG / 2 * WARP_PI / 180), tv = t * S.h / S.w; /* square pixels */
    S.cam = (warp_camera){S.w, S.h, t, t, tv, tv, 0.05, INFINITY};
    S.right_pose = (warp_pose){warp_quat_identity(), warp_v3(BASELINE_M, 0, 0)};
    if (!test_images_alloc(images, TEST_IMAGES_N(images), S.w, S.h)) return -1;
    downscale_rgba(&l, &S.left);
    downscale_rgba(&r, &S.right);
    downscale_disparity(&gt, &S.disp);
    warp_image_free(&l);
    warp_image_free(&r);
    warp_image_free(&gt);
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    test_images_free(images, TEST_IMAGES_N(images));
    return 0;
}

/* PSNR of img against the right photograph on valid pixels (sel = S.valid) or the edge band (sel = S.band). */
static double score(const warp_image_rgba8 *img, const warp_image_u8 *sel)
{
    warp_image_u8 m;
    assert_true(warp_image_u8_alloc(&m, S.w, S.h));
    for (int y = 0; y < S.h; y++)
        for (int x = 0; x < S.w; x++) WARP_AT(&m, x, y) = WARP_AT(sel, x, y) ? 0 : 1;
    double p = warp_psnr(img, &S.right, &m, 1);
    warp_image_free(&m);
    return p;
}

/* ---- the warps: left view -> right camera, holes filled as a display path would ---- */

/* Forward warps leave disocclusions empty; the depth-aware low-pass fill (000 §5.2) closes them. */
static void fill_holes(const warp_image_f32 *inv_dst)
{
    warp_holes_ctx hc;
    assert_true(warp_holes_alloc(&hc, S.w, S.h, 12));
    warp_holes_params hp = warp_holes_default_params();
    hp.method = WARP_HOLES_LOWPASS;
    warp_epipole e = warp_epipole_from_poses(&S.cam, S.right_pose, S.v.pose);
    assert_null(warp_holes_fill(&hc, &S.out, &S.mask, inv_dst, &e, &hp, NULL));
    warp_holes_free(&hc);
}

static void run_raytrace(void)
{
    warp_raytrace_params p = warp_raytrace_default_params();
    warp_raytrace_setup s;
    assert_null(warp_raytrace_prepare(&s, &S.v, &S.cam, S.right_pose, &p));
    warp_raytrace_rows(&s, &S.out, &S.mask, 0, S.h, NULL);
}

static void run_grid(void)
{
    warp_grid g;
    assert_true(warp_grid_alloc(&g, S.w, S.h, 32));
    warp_grid_params p = warp_grid_default_params();
    assert_null(warp_grid_run(&g, &S.v, &S.cam, S.right_pose, &p, &S.out, &S.zb, &S.mask, NULL));
    warp_grid_free(&g);
}

/* The raytrace at the vertices of the eye's mesh, resampled between them; with `cells`, the display path's depth
 * warp as hmdwarpd runs it (raytrace_mesh): the cells a depth edge crosses then traced per pixel (warp_mesh_trace). */
static void mesh_raytrace(bool cells)
{
    warp_raytrace_params p = warp_raytrace_default_params();
    warp_raytrace_setup s;
    assert_null(warp_raytrace_prepare(&s, &S.v, &S.cam, S.right_pose, &p));
    warp_mesh m;
    warp_planar3 src;
    assert_true(warp_mesh_alloc_eye(&m, S.h / MESH_CELL_PX + 1, &S.cam));
    assert_true(warp_planar3_alloc(&src, S.w, S.h));
    warp_planar3_from_rgba_rows(&src, &S.left, 0, S.h);
    warp_mesh_trace t;
    assert_true(warp_mesh_trace_alloc(&t, &m));
    const warp_mesh_trace_params tp = warp_mesh_trace_default_params();
    const int marked = warp_mesh_raytrace_draw(&m, cells ? &t : NULL, &S.cam, &s, NULL, NULL, &tp, &src, &S.out);
    if (cells) print_message("mesh raytrace: %d of %d cells traced per pixel\n", marked, t.cells_x * t.cells_y);
    warp_mesh_trace_free(&t);
    memset(S.mask.px, 0, (size_t)S.mask.stride * (size_t)S.h);
    warp_mesh_free(&m);
    warp_planar3_free(&src);
}

static void run_mesh_vertices(void) { mesh_raytrace(false); }
static void run_mesh_raytrace(void) { mesh_raytrace(true); }

static void run_forward(void)
{
    warp_fwd_scratch sc;
    assert_true(warp_fwd_scratch_alloc(&sc, S.w, S.h, S.w, S.h));
    warp_forward_params p = warp_forward_default_params();
    assert_null(warp_forward_run(&S.v, &S.cam, S.right_pose, &p, &sc, &S.out, &S.mask, NULL));
    fill_holes(&(warp_image_f32){S.w, S.h, S.w, sc.zbuf});
    warp_fwd_scratch_free(&sc);
}

static void run_splat(warp_splat_kind kind)
{
    warp_fwd_scratch sc;
    assert_true(warp_fwd_scratch_alloc(&sc, S.w, S.h, S.w, S.h));
    warp_splat_params p = warp_splat_default_params(kind);
    assert_null(warp_splat_run(&S.v, &S.cam, S.right_pose, &p, &sc, &S.out, &S.mask, NULL));
    fill_holes(&(warp_image_f32){S.w, S.h, S.w, sc.zbuf});
    warp_fwd_scratch_free(&sc);
}
static void run_splat_point(void) { run_splat(WARP_SPLAT_POINT); }
static void run_splat_quad(void) { run_splat(WARP_SPLAT_QUAD); }
static void run_splat_mesh(void) { run_splat(WARP_SPLAT_MESH); }

/* The iterative warp's non-convergent pixels stay holes: they are scored as they are (transparent black), so its
 * defaults are judged on this motion (22-105 px of disparity: large, 001 §4) as the runtime would run them. */
static void run_iterative(void)
{
    warp_iter_ctx c;
    assert_true(warp_iter_alloc(&c, S.w, S.h, S.w, S.h, 1));
    warp_iter_params p = warp_iter_default_params();
    warp_iter_target t = {S.cam, S.right_pose, 0.0, NULL};
    assert_null(warp_iter_run(&c, &S.v, NULL, 0, &t, &p, &S.out, &S.mask, NULL));
    warp_iter_free(&c);
}

/* One line per warp: its bars in dB over the pixels both views see and in the 3 px band along depth edges, about
 * 1 dB under what each scores today (29.26/24.52 raytrace, 30.23/25.87 grid, 23.10/18.51 mesh raytrace, 30.29/26.02
 * forward, 29.47/25.58, 28.66/24.68 and 30.16/25.77 point, quad and mesh splats, 25.20/19.78 iterative), so a
 * regression fails and rounding does not. */
typedef struct {
    const char *name;
    void (*run)(void);
    double min_all, min_band;
} stereo_warp;

static const stereo_warp warps[] = {
    {"raytrace", run_raytrace, 28.0, 23.5},
    {"grid", run_grid, 29.0, 24.8},
    {"mesh vertices", run_mesh_vertices, 22.0, 17.5},
    /* the display path's depth warp (#21): at most 0.5 dB under the per-pixel raytrace, overall and at the edges
     * (the vertices alone trail it by 6 dB) */
    {"mesh raytrace", run_mesh_raytrace, 28.9, 24.25},
    {"forward", run_forward, 29.0, 25.0},
    {"splat point", run_splat_point, 28.5, 24.5},
    {"splat quad", run_splat_quad, 27.5, 23.5},
    {"splat mesh", run_splat_mesh, 29.0, 24.7},
    {"iterative", run_iterative, 24.0, 18.5},
};
#define N_WARPS (sizeof warps / sizeof warps[0])

static double psnr_all[N_WARPS], psnr_band[N_WARPS];

/* The GT warp's overall PSNR (set by test_ground_truth_encoding): the best a depth warp can be expected to do. */
static double gt_psnr = NAN;

/* ---- tests ---- */

/* The GT's encoding: 8-bit disparity in full-size pixels for the left view (0 = unknown), the right view's pixel
 * at x - d. Shown by the colour check: the left photograph moved by the GT disparity reproduces the right one
 * (backward, sampling the left image at x + d of the right view's forward-mapped disparity, bilinearly) far better
 * than with the disparity's sign flipped or scaled, or not moved at all. This is also the best any warp can do. */
static double gt_warp(float sign, float scale, const warp_image_u8 *sel)
{
    for (int y = 0; y < S.h; y++)
        for (int x = 0; x < S.w; x++) {
            float d = WARP_AT(&S.disp_r, x, y);
            WARP_AT(&S.out, x, y) = warp_sample_bilinear(&S.left, x + 0.5 + sign * scale * d, y + 0.5);
        }
    return score(&S.out, sel);
}

/* The view and the scoring masks, once (the tests may run alone). */
static void prepare(void)
{
    static bool done;
    if (!have_data) fail_msg("no Aloe stereo pair in " ALOE_DIR ": install Debian's " ALOE_PKG " (board/deps.sh)");
    if (done) return;
    inverse_depth_from_disparity();
    right_view_truth();
    gt_psnr = gt_warp(1, 1, &S.valid);
    done = true;
}

static size_t warp_index(const char *name)
{
    size_t k = 0;
    while (k < N_WARPS && strcmp(warps[k].name, name)) k++;
    assert_true(k < N_WARPS);
    return k;
}

static void test_ground_truth_encoding(void **state)
{
    (void)state;
    prepare();
    long nv = 0, nb = 0, unknown = 0;
    for (int y = 0; y < S.h; y++)
        for (int x = 0; x < S.w; x++) {
            nv += WARP_AT(&S.valid, x, y), nb += WARP_AT(&S.band, x, y);
            unknown += WARP_AT(&S.disp, x, y) <= 0;
        }
    double truth = gt_psnr, band = gt_warp(1, 1, &S.band);
    double flipped = gt_warp(-1, 1, &S.valid), half = gt_warp(1, 0.5f, &S.valid), twice = gt_warp(1, 2, &S.valid);
    double still = score(&S.left, &S.valid);
    print_message("Aloe %dx%d (1/%d): %ld px visible in both views (%.1f %%), %ld in the %d px edge band, %.1f %% "
                  "unknown GT; GT warp %.2f dB (band %.2f), sign flipped %.2f, half %.2f, twice %.2f, unmoved %.2f\n",
                  S.w, S.h, SCALE, nv, 100.0 * nv / ((double)S.w * S.h), nb, BAND_PX, 100.0 * unknown / ((double)S.w * S.h),
                  truth, band, flipped, half, twice, still);
    assert_true(nv > S.w * S.h * 3L / 4);
    assert_true(nb > nv / 20);
    assert_true(truth > 26.0);
    assert_true(truth > flipped + 8.0 && truth > half + 8.0 && truth > twice + 8.0 && truth > still + 8.0);
}

static void test_every_warp(void **state)
{
    (void)state;
    prepare();
    print_message("%-14s %8s %8s %8s\n", "warp", "all dB", "band dB", "holes");
    size_t best_all = 0, best_band = 0, grid = warp_index("grid"), rt = warp_index("raytrace");
    for (size_t k = 0; k < N_WARPS; k++) {
        memset(S.mask.px, 0, (size_t)S.mask.stride * (size_t)S.h);
        warps[k].run();
        psnr_all[k] = score(&S.out, &S.valid);
        psnr_band[k] = score(&S.out, &S.band);
        long holes = 0; /* left unfilled among the pixels scored */
        for (int y = 0; y < S.h; y++)
            for (int x = 0; x < S.w; x++)
                holes += WARP_AT(&S.valid, x, y) && (WARP_AT(&S.mask, x, y) & (WARP_MASK_HOLE | WARP_MASK_FILLED)) ==
                                                        WARP_MASK_HOLE;
        print_message("%-14s %8.2f %8.2f %8ld\n", warps[k].name, psnr_all[k], psnr_band[k], holes);
        if (psnr_all[k] > psnr_all[best_all]) best_all = k;
        if (psnr_band[k] > psnr_band[best_band]) best_band = k;
    }
    for (size_t k = 0; k < N_WARPS; k++) {
        if (!(isfinite(psnr_all[k]) && psnr_all[k] > warps[k].min_all && isfinite(psnr_band[k]) &&
              psnr_band[k] > warps[k].min_band))
            fail_msg("%s: %.2f dB overall (bar %.1f), %.2f dB in the edge band (bar %.1f)", warps[k].name, psnr_all[k],
                     warps[k].min_all, psnr_band[k], warps[k].min_band);
    }
    print_message("best overall %s (GT warp %.2f dB), best in the band %s; the raytrace trails the grid by %.2f dB "
                  "overall, %.2f in the band\n",
                  warps[best_all].name, gt_psnr, warps[best_band].name, psnr_all[grid] - psnr_all[rt],
                  psnr_band[grid] - psnr_band[rt]);
    /* The best warp reproduces the right photograph as well as the GT's own warp does (it scores 0.2 dB above it
     * today): the camera pair and the scoring are consistent with the data. */
    assert_true(isfinite(gt_psnr) && psnr_all[best_all] > gt_psnr - 0.5);
    /* 000's adaptive grid is the reference for the display path's depth warp (issue 21): within 0.5 dB of the best
     * warp at the depth edges (0.15 dB today, behind the forward warp). */
    assert_true(psnr_band[grid] > psnr_band[best_band] - 0.5);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ground_truth_encoding),
        cmocka_unit_test(test_every_warp),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
