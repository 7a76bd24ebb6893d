/* SPDX-License-Identifier: MIT */
/* rt_eval: accuracy of the simulated board against ground truth. For sampled vsyncs it re-renders the host's frame
 * (the simulator is deterministic), renders the truth at the true photon-time pose and scores no warp, rotation
 * reprojection, raytrace and the raytrace at mesh vertices. Runs at idle priority, off the vsync path. */
#include <math.h>
#include <string.h>

#include "platform/plat_clock.h"
#include "runtime/rt_eval.h"
#include "sim/sim_scene.h"
#include "warp/warp_mesh.h"
#include "warp/warp_metrics.h"
#include "warp/warp_raytrace.h"
#include "warp/warp_reproject.h"
#include "warp/warp_resample.h"
#include "warp/warp_view.h"

const rt_method rt_eval_methods[RT_EVAL_METHODS] = {
    [RT_EVAL_NONE] = RT_METHOD_NONE,
    [RT_EVAL_ROTATION] = RT_METHOD_ROTATION,
    [RT_EVAL_RAYTRACE] = RT_METHOD_RAYTRACE,
    [RT_EVAL_RAYTRACE_MESH] = RT_METHOD_RAYTRACE_MESH,
};

static void score(rt_eval_acc *acc, const warp_image_rgba8 *img, const warp_image_rgba8 *truth)
{
    double p = warp_psnr(img, truth, NULL, 0);
    if (isinf(p)) p = 99.0; /* identical: cap so averages stay finite */
    double s = warp_ssim(img, truth, NULL, 0);
    double e = warp_error_pixel_percent(img, truth, NULL, 0, 20.0);
    if (!(p == p) || !(s == s) || !(e == e)) return;
    if (acc->n == 0 || p < acc->psnr_min) acc->psnr_min = p;
    acc->n++;
    acc->psnr_sum += p;
    acc->ssim_sum += s;
    acc->err_sum += e;
}

bool rt_eval_work_alloc(rt_eval_work *w, const rt_eval_inputs *in)
{
    const warp_camera *cam = &in->cam;
    memset(w, 0, sizeof *w);
    /* raytrace_mesh scored like the others, before the lens: a lens-free mesh over the eye buffer as dense as the
     * panel's (what hmdwarp-bench does too) */
    bool ok = sim_buffers_alloc(&w->src, cam->width, cam->height, SIM_PLANE_COLOR | SIM_PLANE_DEPTH, 1) &&
              sim_buffers_alloc(&w->truth, cam->width, cam->height, SIM_PLANE_COLOR, 1) &&
              warp_image_rgba8_alloc(&w->out, cam->width, cam->height) &&
              warp_image_f32_alloc(&w->inv, cam->width, cam->height) &&
              warp_mesh_alloc_eye(&w->mesh, in->mesh_n, cam) && warp_mesh_trace_alloc(&w->mtrace, &w->mesh) &&
              warp_planar3_alloc(&w->planar, cam->width, cam->height);
    /* a horizontal scan's bands are columns: each band is rendered whole and its columns copied */
    if (ok && in->scan.rolling && (in->scan.dir == WARP_SCAN_LEFT_TO_RIGHT || in->scan.dir == WARP_SCAN_RIGHT_TO_LEFT))
        ok = sim_buffers_alloc(&w->band, cam->width, cam->height, SIM_PLANE_COLOR, 1);
    if (!ok) rt_eval_work_free(w);
    return ok;
}

void rt_eval_work_free(rt_eval_work *w)
{
    sim_buffers_free(&w->src);
    sim_buffers_free(&w->truth);
    sim_buffers_free(&w->band);
    warp_image_free(&w->out);
    warp_image_free(&w->inv);
    warp_mesh_free(&w->mesh);
    warp_mesh_trace_free(&w->mtrace);
    warp_planar3_free(&w->planar);
    memset(w, 0, sizeof *w);
}

/* The panel's scan over the left eye buffer standing for the left eye's viewport (the left half of a panel two eye
 * buffers wide): eye pixel (x, y) lights at the scan fraction of the viewport position it stands for. */
static warp_scan eye_scan(const rt_eval_inputs *in)
{
    warp_scan s = in->scan;
    s.panel_w = 2 * in->cam.width;
    s.panel_h = in->cam.height;
    return s;
}

static warp_pose true_eye_at(const rt_eval_inputs *in, double t)
{
    return warp_head_eye_pose(&in->head, sim_trace_head_pose(in->trace, t), 0);
}

/* The truth's band of eye-buffer line l (a row, or a column for a horizontal scan). */
static int line_band(const warp_scan *s, bool by_row, int l)
{
    const double f = by_row ? warp_scan_fraction(s, 0.5, l + 0.5) : warp_scan_fraction(s, l + 0.5, 0.5);
    return warp_scan_band(f, RT_EVAL_SCAN_BANDS);
}

void rt_eval_truth(rt_eval_work *w, const rt_eval_inputs *in, double photon_scene_time)
{
    const warp_camera *cam = &in->cam;
    if (!in->scan.rolling) {
        sim_render(in->scene, photon_scene_time, true_eye_at(in, photon_scene_time), cam, SIM_PLANE_COLOR, &w->truth);
        return;
    }
    const warp_scan s = eye_scan(in);
    const bool by_row = s.dir == WARP_SCAN_TOP_TO_BOTTOM || s.dir == WARP_SCAN_BOTTOM_TO_TOP;
    const int n = by_row ? cam->height : cam->width;
    /* runs of lines in one band (a band's lines are contiguous whichever way the scan runs) */
    for (int l0 = 0; l0 < n;) {
        const int b = line_band(&s, by_row, l0);
        int l1 = l0 + 1;
        while (l1 < n && line_band(&s, by_row, l1) == b) l1++;
        const double t = photon_scene_time + warp_scan_offset_s(&s, warp_scan_band_fraction(b, RT_EVAL_SCAN_BANDS));
        const warp_pose eye = true_eye_at(in, t);
        if (by_row) {
            sim_render_rows(in->scene, t, eye, cam, SIM_PLANE_COLOR, &w->truth, l0, l1);
        } else {
            sim_render(in->scene, t, eye, cam, SIM_PLANE_COLOR, &w->band);
            for (int y = 0; y < cam->height; y++)
                memcpy(&WARP_AT(&w->truth.color, l0, y), &WARP_AT(&w->band.color, l0, y),
                       sizeof(warp_rgba8) * (size_t)(l1 - l0));
        }
        l0 = l1;
    }
}

void rt_eval_score(rt_eval_work *w, const rt_eval_inputs *in, const rt_eval_record *r, rt_eval_acc acc[RT_EVAL_METHODS],
                   rt_eval_pose *pe)
{
    const warp_camera *cam = &in->cam;
    /* The frame as the host rendered it, and what the eye really saw at photon time. */
    sim_render(in->scene, r->src_scene_time, r->src_eye, cam, SIM_PLANE_COLOR | SIM_PLANE_DEPTH, &w->src);
    rt_eval_truth(w, in, r->photon_scene_time);
    if (pe) {
        warp_pose true_eye = true_eye_at(in, r->photon_scene_time);
        double ang = warp_quat_angle_between(true_eye.q, r->shown_eye.q) * 180 / WARP_PI;
        double mm = warp_v3_norm(warp_v3_sub(true_eye.p, r->shown_eye.p)) * 1000;
        pe->n++;
        pe->angle_sum += ang;
        pe->pos_sum += mm;
        if (ang > pe->angle_max) pe->angle_max = ang;
        if (mm > pe->pos_max) pe->pos_max = mm;
    }

    warp_image_rgba8 *out = &w->out;
    const warp_image_rgba8 *truth = &w->truth.color;
    warp_view v = {.cam = *cam, .pose = r->src_eye, .color = &w->src.color, .inv_depth = &w->inv};
    warp_inverse_depth_from(cam, WARP_DEPTH_LINEAR, &w->src.depth, &w->inv, &v.inv_depth_min, &v.inv_depth_max);

    score(&acc[RT_EVAL_NONE], &w->src.color, truth);
    const warp_scan s = eye_scan(in);
    warp_planar3_from_rgba_rows(&w->planar, &w->src.color, 0, w->src.color.h);
    if (s.rolling) {
        /* as the display's lens mesh: per vertex between the first and the last line's pose */
        const warp_quat src_q = warp_quat_conj(r->src_eye.q);
        warp_mesh_update_rolling(&w->mesh, cam, warp_quat_mul(src_q, r->shown_first.q),
                                 warp_quat_mul(src_q, r->shown_last.q), &s);
        warp_mesh_resample(&w->mesh, &w->planar, out, 0, 0, out->w, out->h);
    } else {
        warp_mat3 h = warp_reproject_homography(&v, cam, r->shown_eye.q);
        warp_reproject_rows(&v, &h, out, NULL, 0, out->h);
    }
    score(&acc[RT_EVAL_ROTATION], out, truth);
    warp_raytrace_setup rs, rs_last;
    if (!warp_raytrace_prepare(&rs, &v, cam, r->shown_eye, &in->rp)) {
        warp_raytrace_rows(&rs, out, NULL, 0, out->h, NULL);
        score(&acc[RT_EVAL_RAYTRACE], out, truth);
        if (!s.rolling)
            warp_mesh_raytrace_draw(&w->mesh, &w->mtrace, cam, &rs, NULL, NULL, &in->tp, &w->planar, out);
        else if (!warp_raytrace_prepare(&rs, &v, cam, r->shown_first, &in->rp) &&
                 !warp_raytrace_prepare(&rs_last, &v, cam, r->shown_last, &in->rp))
            warp_mesh_raytrace_draw(&w->mesh, &w->mtrace, cam, &rs, &rs_last, &s, &in->tp, &w->planar, out);
        else /* no setup for the scan's ends: the rotation's mesh, as the pass falls back to */
            warp_mesh_resample(&w->mesh, &w->planar, out, 0, 0, out->w, out->h);
        score(&acc[RT_EVAL_RAYTRACE_MESH], out, truth);
    }
}

void *rt_eval_thread(void *arg)
{
    rt_eval *ev = arg;
    const rt_eval_inputs *in = &ev->in;
    plat_thread_set_name("hmdwarp-eval");
    plat_thread_set_idle();
    rt_eval_work w;
    const bool ok = rt_eval_work_alloc(&w, in);
    /* The display methods are scored here with the warp part of the CPU pass alone, on the left eye, in eye space
     * before the lens: the truth is an eye-space render, and scoring after the lens would measure the mesh's
     * resampling of the truth as well as the warp. The lens pass is the same for every method, so it adds nothing
     * to their comparison. What the warp part takes from the pass: the raytrace's knobs (the same setup as
     * rt_render_cpu's raytrace and raytrace_mesh), and for raytrace_mesh the mesh's vertex tracing and resampling
     * (through a lens-free mesh as dense as the lens mesh). The pass's rotation is the homography warp_reproject
     * applies here per pixel, there sampled at the lens mesh's vertices (on a rolling panel, the mesh itself). */
    for (;;) {
        rt_eval_record r;
        if (!rt_ring_pop(&ev->ring, &r)) {
            if (atomic_load(in->stop)) break;
            plat_sleep_ns(5 * PLAT_NS_PER_MS);
            continue;
        }
        if (!ok) continue;
        rt_eval_score(&w, in, &r, ev->acc, &ev->pose);
        ev->done++;
    }
    if (ok) rt_eval_work_free(&w);
    return NULL;
}
