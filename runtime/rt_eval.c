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

void *rt_eval_thread(void *arg)
{
    rt_eval *ev = arg;
    const rt_eval_inputs *in = &ev->in;
    plat_thread_set_name("hmdwarp-eval");
    plat_thread_set_idle();
    const warp_camera *cam = &in->cam;
    sim_buffers src, truth;
    warp_image_rgba8 out;
    warp_image_f32 inv;
    /* raytrace_mesh scored like the others, before the lens: a lens-free mesh over the eye buffer as dense as the
     * panel's (what hmdwarp-bench does too) */
    warp_mesh mesh;
    warp_planar3 planar;
    memset(&mesh, 0, sizeof mesh);
    memset(&planar, 0, sizeof planar);
    bool ok = sim_buffers_alloc(&src, cam->width, cam->height, SIM_PLANE_COLOR | SIM_PLANE_DEPTH, 1) &&
              sim_buffers_alloc(&truth, cam->width, cam->height, SIM_PLANE_COLOR, 1) &&
              warp_image_rgba8_alloc(&out, cam->width, cam->height) &&
              warp_image_f32_alloc(&inv, cam->width, cam->height) && warp_mesh_alloc_eye(&mesh, in->mesh_n, cam) &&
              warp_planar3_alloc(&planar, cam->width, cam->height);
    /* The display methods are scored here with the warp part of the CPU pass alone, on the left eye, in eye space
     * before the lens: the truth is an eye-space render, and scoring after the lens would measure the mesh's
     * resampling of the truth as well as the warp. The lens pass is the same for every method, so it adds nothing
     * to their comparison. What the warp part takes from the pass: the raytrace's knobs (the same setup as
     * rt_render_cpu's raytrace and raytrace_mesh), and for raytrace_mesh the mesh's vertex tracing and resampling
     * (through a lens-free mesh as dense as the lens mesh). The pass's rotation is the homography warp_reproject
     * applies here per pixel, there sampled at the lens mesh's vertices. */
    const warp_raytrace_params rp = in->rp;
    for (;;) {
        rt_eval_record r;
        if (!rt_ring_pop(&ev->ring, &r)) {
            if (atomic_load(in->stop)) break;
            plat_sleep_ns(5 * PLAT_NS_PER_MS);
            continue;
        }
        if (!ok) continue;
        /* The frame as the host rendered it, and what the eye really saw at photon time. */
        sim_render(in->scene, r.src_scene_time, r.src_eye, cam, SIM_PLANE_COLOR | SIM_PLANE_DEPTH, &src);
        warp_pose true_head = sim_trace_head_pose(in->trace, r.photon_scene_time);
        warp_pose true_eye = warp_head_eye_pose(&in->head, true_head, 0);
        sim_render(in->scene, r.photon_scene_time, true_eye, cam, SIM_PLANE_COLOR, &truth);
        rt_eval_pose *pe = &ev->pose;
        double ang = warp_quat_angle_between(true_eye.q, r.shown_eye.q) * 180 / WARP_PI;
        double mm = warp_v3_norm(warp_v3_sub(true_eye.p, r.shown_eye.p)) * 1000;
        pe->n++;
        pe->angle_sum += ang;
        pe->pos_sum += mm;
        if (ang > pe->angle_max) pe->angle_max = ang;
        if (mm > pe->pos_max) pe->pos_max = mm;

        warp_view v = {.cam = *cam, .pose = r.src_eye, .color = &src.color, .inv_depth = &inv};
        warp_inverse_depth_from(cam, WARP_DEPTH_LINEAR, &src.depth, &inv, &v.inv_depth_min, &v.inv_depth_max);

        score(&ev->acc[RT_EVAL_NONE], &src.color, &truth.color);
        warp_mat3 h = warp_reproject_homography(&v, cam, r.shown_eye.q);
        warp_reproject_rows(&v, &h, &out, NULL, 0, out.h);
        score(&ev->acc[RT_EVAL_ROTATION], &out, &truth.color);
        warp_raytrace_setup s;
        if (!warp_raytrace_prepare(&s, &v, cam, r.shown_eye, &rp)) {
            warp_raytrace_rows(&s, &out, NULL, 0, out.h, NULL);
            score(&ev->acc[RT_EVAL_RAYTRACE], &out, &truth.color);
            warp_planar3_from_rgba_rows(&planar, &src.color, 0, src.color.h);
            warp_mesh_update_raytrace(&mesh, cam, &s);
            warp_mesh_resample(&mesh, &planar, &out, 0, 0, out.w, out.h);
            score(&ev->acc[RT_EVAL_RAYTRACE_MESH], &out, &truth.color);
        }
        ev->done++;
    }
    sim_buffers_free(&src);
    sim_buffers_free(&truth);
    warp_image_free(&out);
    warp_image_free(&inv);
    warp_mesh_free(&mesh);
    warp_planar3_free(&planar);
    return NULL;
}
