/* SPDX-License-Identifier: MIT */
/* GLES renderer vs the CPU reference on Mesa llvmpipe (surfaceless EGL): the lens pass with rotation, the raytrace
 * with its pyramid skipping and edge fills, their masks, the pyramid itself, the pass timing, and the KMS error. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "platform/plat_egl.h"
#include "platform/plat_gles.h"
#include "sim/sim_scene.h"
#include "warp/warp_fov.h"
#include "warp/warp_mesh_trace.h"
#include "warp/warp_metrics.h"
#include "warp/warp_raytrace.h"
#include "warp/warp_resample.h"
#include "warp/warp_scan.h"
#include "tests/support/test_scene.h"

#define W 192
#define H 160
#define MESH_N 17

static const double D2R = WARP_PI / 180.0;

typedef struct {
    plat_egl *egl;
    plat_gles *g, *g_cpu_pyr;
    warp_camera cam;
    warp_lens lens;
    warp_mesh mesh[2];
    sim_buffers src, dst;
    warp_image_f32 inv;
    warp_view view;
    warp_planar3 planar;
    warp_image_rgba8 panel_cpu, panel_gpu, rt_cpu, rt_gpu, rt_gpu2;
    warp_image_u8 mask_cpu, mask_gpu, mask_gpu2;
} fx;

static fx F;

static int setup(void **state)
{
    (void)state;
    char err[300];
    F.egl = plat_egl_open_offscreen(err, sizeof err);
    if (!F.egl) {
        print_error("no EGL/GLES 3 here: %s\n", err);
        return -1;
    }
    F.cam = (warp_camera){W, H, tan(52 * D2R), tan(48 * D2R), tan(52 * D2R), tan(52 * D2R), 0.05, INFINITY};
    /* the simulated board's lens (board/sim/board.ini) at this size */
    static const double k[3][4] = {{0.996, 0.21912, 0.23904, 0}, {1.0, 0.22, 0.24, 0}, {1.008, 0.22176, 0.24192, 0}};
    for (int c = 0; c < 3; c++)
        for (int i = 0; i < 4; i++) F.lens.ch[c].k[i] = k[c][i];
    F.lens.center_x = W * 380.0 / 720.0;
    F.lens.center_y = H / 2.0;
    F.lens.scale = W / 2.0;
    char buf[200];
    if (warp_lens_check(&F.lens, W, H, buf, sizeof buf)) return -1;
    for (int e = 0; e < 2; e++)
        if (!warp_mesh_alloc(&F.mesh[e], MESH_N, &F.lens, e * W, 0, W, H)) return -1;
    plat_gles_params p = {2 * W, H, W, H, F.mesh[0].cols, F.mesh[0].rows, true, false, true, false};
    F.g = plat_gles_create(F.egl, &p, err, sizeof err);
    if (!F.g) {
        print_error("%s\n", err);
        return -1;
    }
    p.cpu_pyramid = true;
    p.timing = false;
    F.g_cpu_pyr = plat_gles_create(F.egl, &p, err, sizeof err);
    if (!F.g_cpu_pyr) return -1;
    unsigned planes = SIM_PLANE_COLOR | SIM_PLANE_DEPTH;
    if (!sim_buffers_alloc(&F.src, W, H, planes, 1) || !sim_buffers_alloc(&F.dst, W, H, planes, 1) ||
        !warp_image_f32_alloc(&F.inv, W, H) || !warp_planar3_alloc(&F.planar, W, H) ||
        !warp_image_rgba8_alloc(&F.panel_cpu, 2 * W, H) || !warp_image_rgba8_alloc(&F.panel_gpu, 2 * W, H) ||
        !warp_image_rgba8_alloc(&F.rt_cpu, W, H) || !warp_image_rgba8_alloc(&F.rt_gpu, W, H) ||
        !warp_image_rgba8_alloc(&F.rt_gpu2, W, H) || !warp_image_u8_alloc(&F.mask_cpu, W, H) ||
        !warp_image_u8_alloc(&F.mask_gpu, W, H) || !warp_image_u8_alloc(&F.mask_gpu2, W, H))
        return -1;
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    plat_gles_destroy(F.g);
    plat_gles_destroy(F.g_cpu_pyr);
    plat_egl_close(F.egl);
    for (int e = 0; e < 2; e++) warp_mesh_free(&F.mesh[e]);
    sim_buffers_free(&F.src);
    sim_buffers_free(&F.dst);
    warp_image_free(&F.inv);
    warp_planar3_free(&F.planar);
    warp_image_free(&F.panel_cpu);
    warp_image_free(&F.panel_gpu);
    warp_image_free(&F.rt_cpu);
    warp_image_free(&F.rt_gpu);
    warp_image_free(&F.rt_gpu2);
    warp_image_free(&F.mask_cpu);
    warp_image_free(&F.mask_gpu);
    warp_image_free(&F.mask_gpu2);
    return 0;
}

/* Renders the source view (colour and inverse depth) and uploads it as both eyes' frame. */
static void source(const char *scene, warp_pose at)
{
    const sim_scene *s = sim_scene_find(scene);
    assert_non_null(s);
    sim_render(s, 0.0, at, &F.cam, SIM_PLANE_COLOR | SIM_PLANE_DEPTH, &F.src);
    F.view = (warp_view){.cam = F.cam, .pose = at, .color = &F.src.color, .inv_depth = &F.inv};
    assert_int_equal(warp_inverse_depth_from(&F.cam, WARP_DEPTH_LINEAR, &F.src.depth, &F.inv,
                                             &F.view.inv_depth_min, &F.view.inv_depth_max),
                     0);
    warp_planar3_from_rgba_rows(&F.planar, &F.src.color, 0, H);
    for (int e = 0; e < 2; e++) {
        assert_true(plat_gles_upload(F.g, e, &F.src.color, &F.inv));
        assert_true(plat_gles_upload(F.g_cpu_pyr, e, &F.src.color, &F.inv));
    }
}

/* Every pixel flagged `flag` in a has a pixel flagged so in b within one pixel. Returns the pixels that do not. */
static long mask_unmatched(const warp_image_u8 *a, const warp_image_u8 *b, uint8_t flag)
{
    long bad = 0;
    for (int y = 0; y < a->h; y++)
        for (int x = 0; x < a->w; x++) {
            if (!(WARP_AT(a, x, y) & flag)) continue;
            bool found = false;
            for (int dy = -1; dy <= 1 && !found; dy++)
                for (int dx = -1; dx <= 1 && !found; dx++) {
                    int xx = x + dx, yy = y + dy;
                    if (xx >= 0 && yy >= 0 && xx < a->w && yy < a->h && (WARP_AT(b, xx, yy) & flag)) found = true;
                }
            bad += !found;
        }
    return bad;
}

static long mask_count(const warp_image_u8 *m, uint8_t flag)
{
    long n = 0;
    for (int y = 0; y < m->h; y++)
        for (int x = 0; x < m->w; x++) n += (WARP_AT(m, x, y) & flag) != 0;
    return n;
}

static void test_egl_llvmpipe_detected(void **state)
{
    (void)state;
    const char *r = plat_egl_renderer(F.egl);
    print_message("GL_RENDERER %s, %s, timing by %s, pyramid on the %s\n", r, plat_egl_version(F.egl),
                  plat_gles_timing_method(F.g), plat_gles_gpu_pyramid(F.g) ? "GPU" : "CPU");
    assert_non_null(strstr(plat_egl_version(F.egl), "OpenGL ES 3"));
    /* This CI machine has only Mesa's software rasterizer: `render = auto` must see it as such. */
    assert_non_null(strstr(r, "llvmpipe"));
    assert_true(plat_egl_renderer_is_software(r));
    assert_false(plat_egl_renderer_is_software("V3D 4.2"));
    assert_false(plat_egl_renderer_is_software("Mali-G52 (Panfrost)"));
    assert_true(plat_egl_renderer_is_software("softpipe"));
    assert_true(plat_egl_renderer_is_software(NULL));
    assert_true(plat_egl_has_extension(F.egl, "GL_EXT_color_buffer_float"));
    assert_false(plat_egl_has_extension(F.egl, "GL_EXT_color_buffer")); /* whole words only */
    assert_false(plat_egl_is_kms(F.egl));
}

/* CPU reference of the lens pass of both eyes through the rotation src_from_dst. */
static void cpu_lens(warp_quat src_from_dst, const warp_planar3 *src)
{
    warp_image_rgba8_fill(&F.panel_cpu, (warp_rgba8){0, 0, 0, 255});
    for (int e = 0; e < 2; e++) {
        warp_mesh_update(&F.mesh[e], &F.cam, src_from_dst);
        warp_mesh_resample(&F.mesh[e], src, &F.panel_cpu, 0, 0, W, H);
    }
}

static void gpu_lens(plat_gles *g, bool from_raytrace)
{
    char err[200];
    for (int e = 0; e < 2; e++) plat_gles_lens(g, e, &F.mesh[e], from_raytrace);
    assert_true(plat_gles_read(g, &F.panel_gpu, err, sizeof err));
    plat_gles_end_frame(g);
}

static void test_rotation_parity(void **state)
{
    (void)state;
    static const char *const scenes[] = {"room", "near", "hairball", "outdoor"};
    warp_vec3 eye = warp_v3(0, 1.6, 0);
    for (size_t i = 0; i < sizeof scenes / sizeof scenes[0]; i++) {
        warp_pose a = test_eye_at(5 * D2R, 2 * D2R, 0, eye);
        source(scenes[i], a);
        /* none, a small and a fast turn (with fringes on the left) */
        const double turns[3][3] = {{0, 0, 0}, {1.5, -0.5, 0.3}, {11, -1, 2}};
        for (int t = 0; t < 3; t++) {
            warp_pose b = test_eye_at(turns[t][0] * D2R, turns[t][1] * D2R, turns[t][2] * D2R, eye);
            warp_quat q = warp_quat_mul(warp_quat_conj(a.q), b.q);
            cpu_lens(q, &F.planar); /* also leaves the mesh updated for the GPU */
            gpu_lens(F.g, false);
            double p = warp_psnr(&F.panel_gpu, &F.panel_cpu, NULL, 0);
            if (t == 2) print_message("rotation, %-8s %4.1f deg turn: GLES vs CPU %.2f dB\n", scenes[i], 11.2, p);
            assert_true(p >= 45.0);
        }
    }
    /* The threshold catches a wrong mesh interpolation: the GPU image with the other eye's mesh is far off. */
    warp_quat q = warp_quat_identity();
    cpu_lens(q, &F.planar);
    warp_mesh_update(&F.mesh[1], &F.cam, warp_quat_from_ypr(0.5 * D2R, 0, 0));
    gpu_lens(F.g, false);
    double p = warp_psnr(&F.panel_gpu, &F.panel_cpu, NULL, 0);
    print_message("half a degree off in one eye: %.2f dB\n", p);
    assert_true(p < 40.0);
}

/* The hidden-area mask (warp_fov): both paths paint the same pixels opaque black, exactly, and sample the rest. */
static void test_mask_parity(void **state)
{
    (void)state;
    int32_t span[2][2 * H];
    for (int e = 0; e < 2; e++) {
        /* eye 1 a smaller disc than eye 0: each eye's own mask reaches the GPU */
        assert_true(warp_fov_spans(&F.lens, e ? 0.7 : 0.9, W, H, span[e]) > 0);
        F.mesh[e].visible = span[e];
    }
    warp_pose a = test_eye_at(5 * D2R, 2 * D2R, 0, warp_v3(0, 1.6, 0));
    source("room", a);
    cpu_lens(warp_quat_from_ypr(3 * D2R, 0, 0), &F.planar);
    gpu_lens(F.g, false);
    long black = 0;
    for (int e = 0; e < 2; e++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                warp_rgba8 c = WARP_AT(&F.panel_cpu, e * W + x, y), g = WARP_AT(&F.panel_gpu, e * W + x, y);
                if (x >= span[e][2 * y] && x < span[e][2 * y + 1]) continue;
                black++;
                assert_int_equal(c.r | c.g | c.b, 0);
                assert_int_equal(g.r | g.g | g.b, 0);
                assert_int_equal(g.a, 255);
            }
    assert_true(black > W * H / 4);
    double p = warp_psnr(&F.panel_gpu, &F.panel_cpu, NULL, 0);
    print_message("masked rotation: GLES vs CPU %.2f dB, %ld masked pixels\n", p, black);
    assert_true(p >= 45.0);
    for (int e = 0; e < 2; e++) F.mesh[e].visible = NULL;
}

/* Raytraces source -> `to` on the CPU (reference, with mask) and on the GPU (both pyramid builds). */
static void raytrace_both(warp_pose to, const warp_raytrace_params *rp, double *psnr, long *unmatched, long *flagged)
{
    warp_raytrace_setup s;
    assert_null(warp_raytrace_prepare(&s, &F.view, &F.cam, to, rp));
    warp_raytrace_rows(&s, &F.rt_cpu, &F.mask_cpu, 0, H, NULL);
    plat_gles_raytrace(F.g, 0, &s);
    assert_true(plat_gles_read_raytrace(F.g, 0, &F.rt_gpu, &F.mask_gpu));
    plat_gles_raytrace(F.g_cpu_pyr, 0, &s);
    assert_true(plat_gles_read_raytrace(F.g_cpu_pyr, 0, &F.rt_gpu2, &F.mask_gpu2));
    /* the pyramid's origin does not change a single pixel */
    assert_true(isinf(warp_psnr(&F.rt_gpu, &F.rt_gpu2, NULL, 0)));
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) assert_int_equal(WARP_AT(&F.mask_gpu, x, y), WARP_AT(&F.mask_gpu2, x, y));
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) WARP_AT(&F.rt_cpu, x, y).a = 255;
    *psnr = warp_psnr(&F.rt_gpu, &F.rt_cpu, NULL, 0);
    *unmatched = 0;
    *flagged = 0;
    for (int f = WARP_MASK_FRINGE; f <= WARP_MASK_EDGE; f <<= 1) {
        *unmatched += mask_unmatched(&F.mask_cpu, &F.mask_gpu, (uint8_t)f) +
                      mask_unmatched(&F.mask_gpu, &F.mask_cpu, (uint8_t)f);
        *flagged += mask_count(&F.mask_cpu, (uint8_t)f);
    }
}

static void test_raytrace_parity(void **state)
{
    (void)state;
    static const char *const scenes[] = {"near", "room", "hairball", "outdoor"};
    warp_raytrace_params rp = warp_raytrace_default_params();
    for (size_t i = 0; i < sizeof scenes / sizeof scenes[0]; i++) {
        warp_pose a = test_eye_home();
        source(scenes[i], a);
        const warp_pose to[3] = {
            test_eye_at(1.5 * D2R, -3 * D2R, 0, warp_v3(0.04, 1.61, -0.01)), /* 4 cm lean */
            test_eye_at(-4 * D2R, -1 * D2R, 1 * D2R, warp_v3(-0.02, 1.58, 0.03)),
            test_eye_home(), /* identity */
        };
        for (int t = 0; t < 3; t++) {
            double p;
            long unmatched, flagged;
            raytrace_both(to[t], &rp, &p, &unmatched, &flagged);
            print_message("raytrace, %-8s pose %d: GLES vs CPU %.2f dB; masks: %ld flagged, %ld not matched "
                          "within 1 px\n",
                          scenes[i], t, p, flagged, unmatched);
            assert_true(p >= 45.0);
            assert_int_equal(unmatched, 0);
        }
    }
    /* The edge fills and the fringe are exercised: the lean opens disocclusions in "near". */
    warp_pose a = test_eye_home();
    source("near", a);
    double p;
    long unmatched, flagged;
    raytrace_both(test_eye_at(1.5 * D2R, -3 * D2R, 0, warp_v3(0.04, 1.61, -0.01)), &rp, &p, &unmatched, &flagged);
    assert_true(mask_count(&F.mask_gpu, WARP_MASK_EDGE) > 0);
    assert_true(mask_count(&F.mask_gpu, WARP_MASK_FRINGE) > 0);
    /* linear fill, no refinement and a small step budget follow the CPU as well */
    rp.edge_fill = WARP_EDGE_FILL_LINEAR;
    rp.refine_iters = 0;
    raytrace_both(test_eye_at(1.5 * D2R, -3 * D2R, 0, warp_v3(0.04, 1.61, -0.01)), &rp, &p, &unmatched, &flagged);
    print_message("raytrace, linear fill, unrefined: %.2f dB, %ld unmatched\n", p, unmatched);
    assert_true(p >= 45.0);
    assert_int_equal(unmatched, 0);
    rp = warp_raytrace_default_params();
    rp.max_steps = 8;
    raytrace_both(test_eye_at(1.5 * D2R, -3 * D2R, 0, warp_v3(0.04, 1.61, -0.01)), &rp, &p, &unmatched, &flagged);
    print_message("raytrace, 8-step budget: %.2f dB, %ld unmatched\n", p, unmatched);
    assert_true(p >= 45.0);
    assert_int_equal(unmatched, 0);
}

static void test_pyramid_skips_empty_space(void **state)
{
    (void)state;
    /* A lean in the room: rays cross long stretches of open space before reaching the walls. */
    warp_pose a = test_eye_home();
    source("room", a);
    warp_raytrace_params rp = warp_raytrace_default_params();
    warp_raytrace_setup s;
    assert_null(warp_raytrace_prepare(&s, &F.view, &F.cam, test_eye_at(2 * D2R, -3 * D2R, 0, warp_v3(0.25, 1.62, -0.3)), &rp));
    warp_raytrace_stats st = {0};
    warp_raytrace_rows(&s, &F.rt_cpu, NULL, 0, H, &st);
    plat_gles_count_samples(F.g, true);
    plat_gles_raytrace(F.g, 0, &s);
    assert_true(plat_gles_read_raytrace(F.g, 0, &F.rt_gpu, NULL));
    plat_gles_count_samples(F.g, false);
    double gpu = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) gpu += WARP_AT(&F.rt_gpu, x, y).r + 256.0 * WARP_AT(&F.rt_gpu, x, y).g;
    double cpu = (double)st.steps / (double)st.rays;
    gpu /= (double)W * H;
    print_message("depth samples per ray: CPU linear search %.2f steps, GLES with the pyramid %.2f samples\n", cpu,
                  gpu);
    assert_true(cpu > 4.0);
    assert_true(gpu < cpu / 2);
}

static void test_raytrace_then_lens_parity(void **state)
{
    (void)state;
    warp_pose a = test_eye_home();
    warp_pose b = test_eye_at(2 * D2R, -2 * D2R, 0, warp_v3(0.03, 1.6, 0));
    source("near", a);
    warp_raytrace_params rp = warp_raytrace_default_params();
    warp_raytrace_setup s;
    assert_null(warp_raytrace_prepare(&s, &F.view, &F.cam, b, &rp));
    /* the compositor's CPU path: raytrace, deinterleave, lens with identity rotation */
    warp_raytrace_rows(&s, &F.rt_cpu, NULL, 0, H, NULL);
    warp_planar3 inter;
    assert_true(warp_planar3_alloc(&inter, W, H));
    warp_planar3_from_rgba_rows(&inter, &F.rt_cpu, 0, H);
    cpu_lens(warp_quat_identity(), &inter);
    warp_planar3_free(&inter);
    for (int e = 0; e < 2; e++) plat_gles_raytrace(F.g, e, &s);
    gpu_lens(F.g, true);
    double p = warp_psnr(&F.panel_gpu, &F.panel_cpu, NULL, 0);
    print_message("raytrace + lens: GLES vs CPU %.2f dB\n", p);
    assert_true(p >= 45.0);
}

/* The eye-buffer position of channel c's lens direction at viewport column x of cell (i, j), ty down the cell. */
static void eye_pos(const warp_mesh *m, int c, int i, int j, double ty, int x, double *px, double *py)
{
    const warp_vec2f *v00 = &m->tan[((size_t)j * m->cols + i) * 3 + c], *v10 = v00 + 3,
                     *v01 = v00 + (size_t)m->cols * 3, *v11 = v01 + 3;
    const double tx = (x + 0.5 - (double)i * m->cell_w) / m->cell_w;
    const double u = (1 - ty) * ((1 - tx) * v00->x + tx * v10->x) + ty * ((1 - tx) * v01->x + tx * v11->x);
    const double w = (1 - ty) * ((1 - tx) * v00->y + tx * v10->y) + ty * ((1 - tx) * v01->y + tx * v11->y);
    warp_camera_tan_to_pixel(&F.cam, u, w, px, py);
}

/* Channel c of viewport pixel (x, y) (row fraction ty across band j, column cell i) of mesh m by its own full ray
 * on the CPU (warp_raytrace_point): what the traced lens pass computes in a marked cell. Under s alone (last NULL),
 * or on a rolling panel as warp_mesh_trace_rect traces it: under s (the first line's setup) and last, the source
 * positions interpolated at the pixel's scan fraction. */
static int full_ray(const warp_mesh *m, const warp_raytrace_setup *s, const warp_raytrace_setup *last,
                    const warp_scan *scan, int c, int i, int j, double ty, int x, int y)
{
    double px, py, sx, sy;
    eye_pos(m, c, i, j, ty, x, &px, &py);
    warp_raytrace_point(s, px, py, &sx, &sy, NULL);
    if (last) {
        double lx, ly;
        warp_raytrace_point(last, px, py, &lx, &ly, NULL);
        const double f = warp_scan_fraction(scan, m->vp_x + x + 0.5, m->vp_y + y + 0.5);
        sx += (lx - sx) * f, sy += (ly - sy) * f;
    }
    const warp_rgba8 v = warp_sample_bilinear(&F.src.color, (float)sx, (float)sy);
    return c == 0 ? v.r : (c == 1 ? v.g : v.b);
}

/* The cell (i, j) of viewport pixel (x, y) of mesh m as the lens pass finds it, and ty, y's fraction down band j;
 * whether t marks that cell (its pixels traced per pixel). */
static bool marked_cell(const warp_mesh *m, const warp_mesh_trace *t, int x, int y, int *i, int *j, double *ty)
{
    const double b = (y + 0.5) * (m->rows - 1) / m->vp_h;
    *j = (int)b < m->rows - 2 ? (int)b : m->rows - 2;
    *i = x / m->cell_w < t->cells_x ? x / m->cell_w : t->cells_x - 1;
    *ty = b - *j;
    return t->cell[*j * t->cells_x + *i] != 0;
}

/* The display path's depth warp in one GLES pass (plat_gles_lens_traced) against the CPU's (warp_mesh_raytrace_draw):
 * the same vertices and marks; outside the marked cells exactly the lens pass, inside them per-pixel rays, which
 * put the depth edges where the per-pixel raytrace puts them. */
static void test_lens_traced_parity(void **state)
{
    (void)state;
    warp_mesh_trace t[2];
    for (int e = 0; e < 2; e++) assert_true(warp_mesh_trace_alloc(&t[e], &F.mesh[e]));
    const warp_mesh_trace_params mp = warp_mesh_trace_default_params();
    warp_raytrace_params rp = warp_raytrace_default_params();
    warp_image_rgba8 lens_only, two_pass;
    assert_true(warp_image_rgba8_alloc(&lens_only, 2 * W, H) && warp_image_rgba8_alloc(&two_pass, 2 * W, H));
    char err[200];
    static const char *const scenes[] = {"near", "hairball", "room"};
    for (size_t sc = 0; sc < sizeof scenes / sizeof scenes[0]; sc++) {
        source(scenes[sc], test_eye_home());
        const warp_pose to = test_eye_at(1.5 * D2R, -3 * D2R, 0, warp_v3(0.04, 1.61, -0.01));
        warp_raytrace_setup s;
        assert_null(warp_raytrace_prepare(&s, &F.view, &F.cam, to, &rp));
        /* the two-pass GLES raytrace (every eye-buffer pixel, then the lens): the per-pixel reference */
        for (int e = 0; e < 2; e++) {
            warp_mesh_update(&F.mesh[e], &F.cam, warp_quat_identity());
            plat_gles_raytrace(F.g, e, &s);
        }
        gpu_lens(F.g, true);
        memcpy(two_pass.px, F.panel_gpu.px, sizeof(warp_rgba8) * 2 * W * H);
        /* the CPU's display path; it leaves the meshes traced and their cells marked */
        warp_image_rgba8_fill(&F.panel_cpu, (warp_rgba8){0, 0, 0, 255});
        int marked = 0;
        for (int e = 0; e < 2; e++)
            marked += warp_mesh_raytrace_draw(&F.mesh[e], &t[e], &F.cam, &s, NULL, NULL, &mp, &F.planar,
                                              &F.panel_cpu);
        /* the same meshes through the plain lens pass, and through the traced one */
        gpu_lens(F.g, false);
        memcpy(lens_only.px, F.panel_gpu.px, sizeof(warp_rgba8) * 2 * W * H);
        for (int e = 0; e < 2; e++) plat_gles_lens_traced(F.g, e, &F.mesh[e], &t[e], &F.cam, &s, NULL, NULL);
        assert_true(plat_gles_read(F.g, &F.panel_gpu, err, sizeof err));
        plat_gles_end_frame(F.g);
        long in_cells = 0, differs_outside = 0;
        double se_traced = 0, se_lens = 0, se_rays = 0;
        for (int e = 0; e < 2; e++) {
            const warp_mesh *m = &F.mesh[e];
            for (int y = 0; y < H; y++) {
                for (int x = 0; x < W; x++) {
                    int i, j;
                    double ty;
                    warp_rgba8 g = WARP_AT(&F.panel_gpu, e * W + x, y), l = WARP_AT(&lens_only, e * W + x, y),
                               r = WARP_AT(&two_pass, e * W + x, y);
                    if (!marked_cell(m, &t[e], x, y, &i, &j, &ty)) {
                        differs_outside += memcmp(&g, &l, sizeof g) != 0;
                        continue;
                    }
                    const int gc[3] = {g.r, g.g, g.b};
                    for (int c = 0; c < 3; c++) {
                        const int d = gc[c] - full_ray(m, &s, NULL, NULL, c, i, j, ty, x, y);
                        se_rays += d * d;
                    }
                    in_cells++;
                    const int dg[3] = {g.r - r.r, g.g - r.g, g.b - r.b}, dl[3] = {l.r - r.r, l.g - r.g, l.b - r.b};
                    for (int c = 0; c < 3; c++) {
                        se_traced += dg[c] * dg[c];
                        se_lens += dl[c] * dl[c];
                    }
                }
            }
        }
        const double n = 3.0 * (double)in_cells;
        const double p_traced = 10 * log10(255.0 * 255.0 * n / (se_traced + 1e-9));
        const double p_lens = 10 * log10(255.0 * 255.0 * n / (se_lens + 1e-9));
        const double p_rays = 10 * log10(255.0 * 255.0 * n / (se_rays + 1e-9));
        const double p_cpu = warp_psnr(&F.panel_gpu, &F.panel_cpu, NULL, 0);
        print_message("traced lens, %-8s %d cells marked (%ld px): in them vs the CPU's full rays %.2f dB, vs the "
                      "two-pass raytrace %.2f dB (the vertices alone %.2f dB); whole panel vs the CPU's display path "
                      "%.2f dB\n",
                      scenes[sc], marked, in_cells, p_rays, p_traced, p_lens, p_cpu);
        assert_true(marked > 0);
        assert_int_equal(differs_outside, 0); /* outside the marks, exactly the lens pass */
        /* near's edges are a few pixels of parallax apart at this lean: the vertices alone smear them */
        if (sc == 0) assert_true(p_traced > p_lens + 3.0);
        /* every channel's own full ray, as the CPU traces it */
        assert_true(p_rays >= 50.0);
        /* The CPU's display path saves rays: a 4-pixel lattice with guided searches between (which can miss
         * hairball's thinnest strands), and red and blue on green's surface unless it sees a reason not to
         * (warp_mesh_trace.c); beside edges it differs, elsewhere it is the same lens pass. */
        assert_true(p_cpu >= 38.0);
    }
    /* no marks: exactly the lens pass */
    for (int e = 0; e < 2; e++) memset(t[e].cell, 0, (size_t)t[e].cells_x * (size_t)t[e].cells_y);
    gpu_lens(F.g, false);
    memcpy(lens_only.px, F.panel_gpu.px, sizeof(warp_rgba8) * 2 * W * H);
    for (int e = 0; e < 2; e++) {
        warp_raytrace_setup s;
        assert_null(warp_raytrace_prepare(&s, &F.view, &F.cam, test_eye_home(), &rp));
        plat_gles_lens_traced(F.g, e, &F.mesh[e], &t[e], &F.cam, &s, NULL, NULL);
    }
    assert_true(plat_gles_read(F.g, &F.panel_gpu, err, sizeof err));
    plat_gles_end_frame(F.g);
    assert_memory_equal(F.panel_gpu.px, lens_only.px, sizeof(warp_rgba8) * 2 * W * H);
    for (int e = 0; e < 2; e++) warp_mesh_trace_free(&t[e]);
    warp_image_free(&lens_only);
    warp_image_free(&two_pass);
}

/* On a rolling panel the vertices are warped at their own line's pose; the traced lens pass traces its marked
 * cells' pixels at theirs too (the first and the last line's setups interpolated, as the CPU does), not at the
 * mid-scan pose, which leaves the first and last lines' traced pixels a scan's motion away from their cells'
 * vertices. */
static void test_lens_traced_rolling(void **state)
{
    (void)state;
    warp_mesh_trace t[2];
    for (int e = 0; e < 2; e++) assert_true(warp_mesh_trace_alloc(&t[e], &F.mesh[e]));
    const warp_mesh_trace_params mp = warp_mesh_trace_default_params();
    warp_raytrace_params rp = warp_raytrace_default_params();
    char err[200];
    const warp_scan scans[] = {{true, WARP_SCAN_TOP_TO_BOTTOM, 0.01, 2 * W, H},
                               {true, WARP_SCAN_RIGHT_TO_LEFT, 0.01, 2 * W, H}};
    source("near", test_eye_home());
    /* a fast turn with a lean: the last line is lit 4 degrees of yaw and 2 cm after the first */
    const warp_pose first = test_eye_at(-0.5 * D2R, -3 * D2R, 0, warp_v3(0.03, 1.61, -0.01));
    const warp_pose mid = test_eye_at(1.5 * D2R, -3 * D2R, 0, warp_v3(0.04, 1.61, -0.01));
    const warp_pose last = test_eye_at(3.5 * D2R, -3 * D2R, 0, warp_v3(0.05, 1.61, -0.01));
    warp_raytrace_setup sf, sm, sl;
    assert_null(warp_raytrace_prepare(&sf, &F.view, &F.cam, first, &rp));
    assert_null(warp_raytrace_prepare(&sm, &F.view, &F.cam, mid, &rp));
    assert_null(warp_raytrace_prepare(&sl, &F.view, &F.cam, last, &rp));
    for (size_t k = 0; k < sizeof scans / sizeof scans[0]; k++) {
        const warp_scan *scan = &scans[k];
        /* the vertices at their lines' poses and the marks, as the CPU's display path makes them */
        int marked = 0;
        for (int e = 0; e < 2; e++)
            marked += warp_mesh_raytrace_vertices(&F.mesh[e], &t[e], &F.cam, &sf, &sl, scan, &mp);
        /* per line (the fix) and at the mid-scan pose (before it), from the same vertices and marks */
        double p_rays[2];
        for (int way = 0; way < 2; way++) {
            for (int e = 0; e < 2; e++) {
                if (way == 0) plat_gles_lens_traced(F.g, e, &F.mesh[e], &t[e], &F.cam, &sf, &sl, scan);
                else plat_gles_lens_traced(F.g, e, &F.mesh[e], &t[e], &F.cam, &sm, NULL, NULL);
            }
            assert_true(plat_gles_read(F.g, &F.panel_gpu, err, sizeof err));
            plat_gles_end_frame(F.g);
            long in_cells = 0;
            double se = 0;
            for (int e = 0; e < 2; e++) {
                const warp_mesh *m = &F.mesh[e];
                for (int y = 0; y < H; y++) {
                    for (int x = 0; x < W; x++) {
                        int i, j;
                        double ty;
                        if (!marked_cell(m, &t[e], x, y, &i, &j, &ty)) continue;
                        warp_rgba8 g = WARP_AT(&F.panel_gpu, e * W + x, y);
                        const int gc[3] = {g.r, g.g, g.b};
                        for (int c = 0; c < 3; c++) {
                            const int d = gc[c] - full_ray(m, &sf, &sl, scan, c, i, j, ty, x, y);
                            se += d * d;
                        }
                        in_cells++;
                    }
                }
            }
            p_rays[way] = 10 * log10(255.0 * 255.0 * 3.0 * (double)in_cells / (se + 1e-9));
        }
        print_message("traced lens, rolling scan %d: %d cells marked: in them vs the CPU's full rays per line "
                      "%.2f dB (at the mid-scan pose %.2f dB)\n",
                      (int)scan->dir, marked, p_rays[0], p_rays[1]);
        assert_true(marked > 0);
        assert_true(p_rays[0] >= 45.0);
        assert_true(p_rays[0] > p_rays[1] + 6.0);
    }
    for (int e = 0; e < 2; e++) warp_mesh_trace_free(&t[e]);
}

/* The traced lens pass re-sends its vertices' eye-buffer positions only when they change (the lens or the frame's
 * camera): a frame with another camera is traced at that camera's positions, and the first camera's come back
 * with it, byte for byte. */
static void test_lens_traced_follows_camera(void **state)
{
    (void)state;
    warp_mesh_trace t[2];
    for (int e = 0; e < 2; e++) assert_true(warp_mesh_trace_alloc(&t[e], &F.mesh[e]));
    const warp_mesh_trace_params mp = warp_mesh_trace_default_params();
    warp_raytrace_params rp = warp_raytrace_default_params();
    char err[200];
    source("near", test_eye_home());
    warp_raytrace_setup s;
    assert_null(warp_raytrace_prepare(&s, &F.view, &F.cam,
                                      test_eye_at(1.5 * D2R, -3 * D2R, 0, warp_v3(0.04, 1.61, -0.01)), &rp));
    int marked = 0;
    for (int e = 0; e < 2; e++)
        marked += warp_mesh_raytrace_draw(&F.mesh[e], &t[e], &F.cam, &s, NULL, NULL, &mp, &F.planar, &F.panel_cpu);
    assert_true(marked > 0);
    warp_camera wide = F.cam; /* 10 % wider: every vertex's position in the eye buffer moves */
    wide.tan_left *= 1.1, wide.tan_right *= 1.1;
    const warp_camera *cams[3] = {&F.cam, &wide, &F.cam};
    warp_image_rgba8 drawn[3];
    for (int k = 0; k < 3; k++) {
        assert_true(warp_image_rgba8_alloc(&drawn[k], 2 * W, H));
        for (int e = 0; e < 2; e++) plat_gles_lens_traced(F.g, e, &F.mesh[e], &t[e], cams[k], &s, NULL, NULL);
        assert_true(plat_gles_read(F.g, &drawn[k], err, sizeof err));
        plat_gles_end_frame(F.g);
    }
    long moved = 0, outside = 0;
    for (int e = 0; e < 2; e++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                int i, j;
                double ty;
                const bool in = marked_cell(&F.mesh[e], &t[e], x, y, &i, &j, &ty);
                const bool d = memcmp(&WARP_AT(&drawn[0], e * W + x, y), &WARP_AT(&drawn[1], e * W + x, y),
                                      sizeof(warp_rgba8)) != 0;
                moved += in && d, outside += !in && d;
            }
    print_message("traced lens, another camera: %ld pixels of the marked cells moved, %ld outside them\n", moved,
                  outside);
    assert_true(moved > marked); /* more than a pixel a cell: the positions were re-sent */
    assert_int_equal(outside, 0); /* the lens pass's own positions are the mesh's, not the camera's */
    assert_memory_equal(drawn[0].px, drawn[2].px, sizeof(warp_rgba8) * 2 * W * H);
    for (int k = 0; k < 3; k++) warp_image_free(&drawn[k]);
    for (int e = 0; e < 2; e++) warp_mesh_trace_free(&t[e]);
}

static void test_pyramid_matches_cpu(void **state)
{
    (void)state;
    source("near", test_eye_at(0.3, -0.1, 0, warp_v3(0.1, 1.5, 0.2)));
    int levels = plat_gles_pyramid_levels(W, H);
    assert_int_equal(levels, 9); /* 192x160 -> 96x80 -> ... -> 2x2 (... 1x1 at level 8) */
    warp_image_f32 gpu, cpu;
    assert_true(warp_image_f32_alloc(&gpu, W, H) && warp_image_f32_alloc(&cpu, W, H));
    float *scratch = malloc(sizeof(float) * W * H);
    assert_non_null(scratch);
    for (int l = 0; l < levels; l++) {
        int lw, lh;
        plat_gles_pyramid_level_size(W, H, l, &lw, &lh);
        assert_true(plat_gles_read_pyramid(F.g, 0, l, &gpu));
        plat_gles_pyramid_cpu(&F.inv, l, &cpu, scratch);
        for (int y = 0; y < lh; y++)
            for (int x = 0; x < lw; x++) assert_true(WARP_AT(&gpu, x, y) == WARP_AT(&cpu, x, y));
    }
    /* the top level is the largest inverse depth of the whole image, as the CPU's range says */
    assert_true(WARP_AT(&cpu, 0, 0) == F.view.inv_depth_max);
    /* a level bounds every bilinear sample in its cells */
    plat_gles_pyramid_cpu(&F.inv, 3, &cpu, scratch);
    for (int i = 0; i < 2000; i++) {
        float x = (float)(i * 7919 % (W * 16)) / 16.0f, y = (float)(i * 104729 % (H * 16)) / 16.0f;
        int cx = (int)floorf(x - 0.5f), cy = (int)floorf(y - 0.5f);
        cx = cx < 0 ? 0 : cx > W - 1 ? W - 1 : cx;
        cy = cy < 0 ? 0 : cy > H - 1 ? H - 1 : cy;
        assert_true(warp_sample_f32(&F.inv, x, y) <= WARP_AT(&cpu, cx >> 3, cy >> 3));
    }
    free(scratch);
    warp_image_free(&gpu);
    warp_image_free(&cpu);
}

static void test_pass_timing(void **state)
{
    (void)state;
    source("room", test_eye_at(0, 0, 0, warp_v3(0, 1.6, 0)));
    warp_raytrace_params rp = warp_raytrace_default_params();
    warp_raytrace_setup s;
    assert_null(warp_raytrace_prepare(&s, &F.view, &F.cam, test_eye_at(0.01, 0, 0, warp_v3(0.01, 1.6, 0)), &rp));
    plat_gles_times t;
    uint64_t seq = 0;
    for (int f = 0; f < 6; f++) {
        for (int e = 0; e < 2; e++) {
            warp_mesh_update(&F.mesh[e], &F.cam, warp_quat_identity());
            plat_gles_raytrace(F.g, e, &s);
        }
        gpu_lens(F.g, true);
        if (plat_gles_times_latest(F.g, &t)) {
            assert_true(t.seq >= seq); /* a new result or the same one again, never an older */
            seq = t.seq;
        }
    }
    /* the readback waited for the GPU, so the queries of earlier frames are done */
    assert_true(plat_gles_times_latest(F.g, &t));
    assert_true(t.valid[PLAT_GLES_RAYTRACE] && t.valid[PLAT_GLES_LENS] && t.valid[PLAT_GLES_READBACK]);
    assert_false(t.valid[PLAT_GLES_PYRAMID]); /* no new frame in those vsyncs */
    print_message("pass times (%s):", plat_gles_timing_method(F.g));
    for (int p = 0; p < PLAT_GLES_PASSES; p++)
        if (t.valid[p]) print_message(" %s %.3f ms", plat_gles_pass_name((plat_gles_pass)p), t.ms[p]);
    print_message("\n");
    assert_true(t.ms[PLAT_GLES_RAYTRACE] > 0 && t.ms[PLAT_GLES_RAYTRACE] < 10000);
    assert_true(t.ms[PLAT_GLES_LENS] > 0);
    /* with timing off there is nothing */
    assert_false(plat_gles_times_latest(F.g_cpu_pyr, &t));
    assert_string_equal(plat_gles_timing_method(F.g_cpu_pyr), "off");
}

static void test_bench(void **state)
{
    (void)state;
    source("near", test_eye_at(0, 0, 0, warp_v3(0, 1.6, 0)));
    warp_raytrace_params rp = warp_raytrace_default_params();
    warp_raytrace_setup s;
    assert_null(warp_raytrace_prepare(&s, &F.view, &F.cam, test_eye_at(0.02, 0, 0, warp_v3(0.02, 1.6, 0)), &rp));
    const warp_raytrace_setup *rt[2] = {&s, &s};
    const warp_mesh *m[2] = {&F.mesh[0], &F.mesh[1]};
    const warp_image_rgba8 *color[2] = {&F.src.color, &F.src.color};
    const warp_image_f32 *inv[2] = {&F.inv, &F.inv};
    plat_gles_times t;
    assert_true(plat_gles_bench(F.g, color, inv, rt, m, 3, &t));
    print_message("bench %dx%d per eye:", W, H);
    for (int p = 0; p < PLAT_GLES_PASSES; p++) {
        assert_true(t.valid[p]);
        assert_true(t.ms[p] >= 0 && t.ms[p] < 10000);
        print_message(" %s %.3f ms", plat_gles_pass_name((plat_gles_pass)p), t.ms[p]);
    }
    print_message("\n");
    assert_true(t.ms[PLAT_GLES_RAYTRACE] > 0);
    /* an untimed renderer cannot bench */
    assert_false(plat_gles_bench(F.g_cpu_pyr, color, inv, rt, m, 3, &t));
}

static void test_kms_without_drm_device(void **state)
{
    (void)state;
    char err[300];
    plat_egl_kms_params kp = {"/dev/dri/card0", "auto", 0, 0, 0, 0};
    FILE *probe = fopen("/dev/dri/card0", "r");
    if (!probe) {
        assert_null(plat_egl_open_kms(&kp, err, sizeof err));
        print_message("%s\n", err);
        assert_string_equal(err, "no DRM device: /dev/dri/card0: No such file or directory");
    } else {
        fclose(probe);
    }
    kp.device = "/nonexistent/dri/card7";
    assert_null(plat_egl_open_kms(&kp, err, sizeof err));
    assert_string_equal(err, "no DRM device: /nonexistent/dri/card7: No such file or directory");
    /* a file that is not a DRM device: opened, but it has no KMS resources */
    kp.device = "/dev/null";
    assert_null(plat_egl_open_kms(&kp, err, sizeof err));
    print_message("%s\n", err);
    assert_non_null(strstr(err, "DRM device /dev/null: no KMS resources"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_egl_llvmpipe_detected),
        cmocka_unit_test(test_rotation_parity),
        cmocka_unit_test(test_mask_parity),
        cmocka_unit_test(test_raytrace_parity),
        cmocka_unit_test(test_pyramid_skips_empty_space),
        cmocka_unit_test(test_raytrace_then_lens_parity),
        cmocka_unit_test(test_lens_traced_parity),
        cmocka_unit_test(test_lens_traced_rolling),
        cmocka_unit_test(test_lens_traced_follows_camera),
        cmocka_unit_test(test_pyramid_matches_cpu),
        cmocka_unit_test(test_pass_timing),
        cmocka_unit_test(test_bench),
        cmocka_unit_test(test_kms_without_drm_device),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
