/* SPDX-License-Identifier: MIT */
/* rt_compositor: the vsync-paced loop: just before each vsync it predicts the head pose at photon time, takes the
 * newest host frame, warps and distorts it into a free swapchain image and presents it. No allocation, no I/O, no
 * locks on this path. */
#include "runtime/rt_compositor.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "platform/plat_clock.h"
#include "platform/plat_egl.h"
#include "platform/plat_gles.h"
#include "platform/plat_log.h"
#include "platform/plat_workers.h"
#include "runtime/rt_render_cpu.h"
#include "runtime/rt_simboard.h"
#include "warp/warp_objects.h"
#include "runtime/rt_pacer.h"
#include "warp/warp_raytrace.h"
#include "warp/warp_registry.h"

/* The CPU pass on the GPU: the frame's planes go to textures once per host frame, then the same warps as the CPU
 * path (same mesh, same raytrace setup) draw the panel, which is read back into `out` (offscreen) or page-flipped
 * onto the panel (KMS). */
static rt_method compose_gles(rt_app *a, const rt_frame *frame, const warp_pose eyes[2], const warp_pose *first,
                              const warp_pose *last, rt_method method, warp_image_rgba8 *out)
{
    plat_gles *g = a->gl.renderer;
    char err[200];
    /* the GPU's stand-in for the method (the registry's gpu column; the CPU passes are rt_render_cpu's); its
     * methods need depth at most: the other planes are not asked for */
    method = rt_render_cpu_usable(a->render, frame, (rt_method)warp_method_get(rt_method_warp(method))->gpu, 0);
    if (frame != a->gl.frame || frame->f.seq != a->gl.frame_seq) {
        bool ok = true;
        for (int e = 0; e < 2; e++)
            ok &= plat_gles_upload(g, e, &frame->f.color[e],
                                   a->gl.depth && frame->has_depth ? &frame->inv_depth[e] : NULL);
        if (!ok) {
            a->gl.errors++;
            snprintf(a->gl.last_error, sizeof a->gl.last_error, "frame %llu: texture upload failed",
                     (unsigned long long)frame->f.seq);
        }
        a->gl.frame = frame;
        a->gl.frame_seq = frame->f.seq;
    }
    bool drawn = false;
    if (method == RT_METHOD_RAYTRACE_MESH && a->gl.depth) {
        /* the vertices' rays and the cells' marks on the CPU, as the CPU pass makes them; the marked cells' per-pixel
         * rays on the GPU (rolling panels: both at the first and the last line's pose, interpolated per vertex and
         * per pixel at its line's scan fraction) */
        const warp_raytrace_setup *rts[2], *rts_last[2];
        const warp_scan *scan = NULL;
        if (rt_render_cpu_mesh_traced(a->render, frame, eyes, first, last, rts, rts_last, &scan)) {
            const bool cells = rt_render_cpu_mesh_cells(a->render);
            for (int e = 0; e < 2; e++) {
                if (cells)
                    plat_gles_lens_traced(g, e, rt_render_cpu_mesh(a->render, e),
                                          rt_render_cpu_mesh_trace(a->render, e), &frame->f.cam[e], rts[e],
                                          rts_last[e], scan);
                else /* [warp] mesh_cells = false: the vertices alone, through the plain lens pass */
                    plat_gles_lens(g, e, rt_render_cpu_mesh(a->render, e), false);
            }
            drawn = true;
        }
    }
    if (method == RT_METHOD_RAYTRACE && a->gl.depth) {
        bool ok = true;
        warp_view views[2]; /* the raytrace setups point at these */
        warp_raytrace_setup rts[2];
        const warp_raytrace_params *rp = rt_render_cpu_raytrace_params(a->render);
        for (int e = 0; e < 2 && ok; e++) {
            views[e] = rt_frame_view(frame, e);
            ok = warp_raytrace_prepare(&rts[e], &views[e], &frame->f.cam[e], eyes[e], rp) == NULL;
        }
        if (ok) {
            for (int e = 0; e < 2; e++) {
                warp_mesh *mesh = rt_render_cpu_mesh(a->render, e);
                plat_gles_raytrace(g, e, &rts[e]);
                warp_mesh_update(mesh, &frame->f.cam[e], warp_quat_identity());
                plat_gles_lens(g, e, mesh, true);
            }
            drawn = true;
        }
    }
    if (!drawn) {
        if (method == RT_METHOD_RAYTRACE || method == RT_METHOD_RAYTRACE_MESH) method = RT_METHOD_ROTATION;
        /* rolling scanout: per vertex between the first and last line's poses, as the CPU pass does (the GPU's
         * raytrace above is per pixel: it keeps the mid-scan pose) */
        for (int e = 0; e < 2; e++)
            plat_gles_lens(g, e, rt_render_cpu_mesh_for(a->render, frame, e, method, eyes[e], first, last), false);
    }
    a->gl.submit_ns = plat_now_ns();
    bool ok = plat_egl_is_kms(a->gl.egl) ? plat_egl_present(a->gl.egl, err, sizeof err)
                                      : plat_gles_read(g, out, err, sizeof err);
    if (!ok) {
        a->gl.errors++;
        snprintf(a->gl.last_error, sizeof a->gl.last_error, "%s", err);
    }
    plat_gles_end_frame(g);
    return method;
}

/* Per-pass GPU times of the newest frame whose timings are complete, into telemetry. */
static void gles_times(rt_app *a)
{
    plat_gles_times gt;
    if (!plat_gles_times_latest(a->gl.renderer, &gt) || gt.seq == a->gl.times_seq) return;
    a->gl.times_seq = gt.seq;
    double total = 0;
    for (int p = 0; p < PLAT_GLES_PASSES; p++)
        if (gt.valid[p]) {
            rt_hist_add(&a->gl.ms[p], gt.ms[p]);
            total += gt.ms[p];
        }
    a->gl.gpu_ms = total;
}

/* Keeps the object poses of the two newest frames (002 §3.2: extrapolation needs two) and whether any object
 * moved between them. */
static bool track_objects(rt_app *a, const rt_frame *fr)
{
    int n = fr->f.n_objects < DRV_MAX_OBJECTS ? fr->f.n_objects : DRV_MAX_OBJECTS;
    if (!(fr->f.planes & DRV_PLANE_IDS) || n <= 0) {
        a->obj_two = false;
        a->obj_n = 0;
        return false;
    }
    bool had = a->obj_n == n;
    memcpy(a->obj_prev, a->obj_cur, sizeof(warp_pose) * (size_t)n);
    a->obj_prev_t = a->obj_cur_t;
    memcpy(a->obj_cur, fr->f.object_pose, sizeof(warp_pose) * (size_t)n);
    a->obj_cur_t = (double)fr->f.pose_t_ns * 1e-9;
    a->obj_n = n;
    a->obj_two = had && a->obj_cur_t > a->obj_prev_t;
    bool moving = false;
    for (int i = 0; a->obj_two && i < n && !moving; i++)
        moving = warp_v3_norm(warp_v3_sub(a->obj_cur[i].p, a->obj_prev[i].p)) > 1e-4 ||
                 warp_quat_angle_between(a->obj_cur[i].q, a->obj_prev[i].q) > 1e-3;
    return moving;
}

static void clear_image(warp_image_rgba8 *img)
{
    for (int y = 0; y < img->h; y++) memset(&WARP_AT(img, 0, y), 0, sizeof(warp_rgba8) * (size_t)img->w);
}

void rt_compositor_run(rt_app *a)
{
    rt_telemetry *tel = a->tel;
    const rt_config *c = &a->cfg;
    const int64_t photon_ns = (int64_t)(c->photon_offset_ms * 1e6);
    /* rolling scanout: the first and the last line light this long before and after the mid-scan photon time */
    const warp_scan scan = rt_config_scan(c);
    const int64_t first_ns = (int64_t)llround(warp_scan_offset_s(&scan, 0) * 1e9);
    const int64_t last_ns = (int64_t)llround(warp_scan_offset_s(&scan, 1) * 1e9);
    const int64_t eval_every = (int64_t)(c->eval_every_ms * 1e6);
    /* the simulated board's evaluator, when it scores this run: the records go into its ring */
    rt_eval *eval = a->sim && a->dev.has_truth && eval_every > 0 ? rt_simboard_eval(a->sim) : NULL;
    int64_t next_eval = a->t0_ns + eval_every;
    rt_method prev_used = RT_METHOD_COUNT;
    bool objects_moving = false;
    uint64_t last_seq = 0;
    bool have_seq = false; /* a host may count from 0: seq 0 is a frame, not "none yet" */
    bool gles = atomic_load_explicit(&a->gl.use, memory_order_relaxed);
    if (gles && !plat_egl_make_current(a->gl.egl)) {
        plat_log(PLAT_LOG_WARNING, "cannot make the EGL context current on the compositor thread: using the CPU "
                                   "path");
        /* flags, not an append to render_why: the helper thread may be formatting it for the live stats */
        atomic_store_explicit(&a->gl.fell_back, true, memory_order_relaxed);
        atomic_store_explicit(&a->gl.use, false, memory_order_relaxed);
        gles = false;
    }
    /* The display starts at scene time 0 (after the simulated headset's rest at boot), whatever the vsync source. */
    int64_t first = plat_now_ns() + 2 * PLAT_NS_PER_MS;
    if (first < a->t0_ns - 1) first = a->t0_ns - 1;
    int64_t period = 0;
    int64_t t_first = drv_vsync_next(a->dev.vsync, first, &period);
    /* Wake-up, lead, stall reserve, the cost estimator and overrun skipping: rt_pacer (made by rt_app_init). */
    rt_pacer *pacer = a->pacer;
    rt_pacer_start(pacer, t_first, period, gles);

    while (!atomic_load_explicit(&a->stop, memory_order_relaxed)) {
        rt_pacer_frame pf;
        rt_pacer_predict(pacer, &pf);
        const int64_t t_vs = pf.vsync_ns;
        const uint64_t vsync_no = pf.vsync_no;
        if (a->t_end_ns && t_vs > a->t_end_ns) break;
        plat_sleep_until_ns(pf.wake_ns);
        int64_t t_start = plat_now_ns();
        rt_pacer_mark_point(pacer, RT_PACER_WOKE, t_start);
        int64_t cpu_start = plat_thread_cpu_ns(), stalled_start = plat_workers_stalled_ns(a->workers);

        bool is_new = false;
        const rt_frame *frame = rt_frameq_latest(&a->fq, &is_new);
        rt_pacer_mark_point(pacer, RT_PACER_FRAME_TAKEN, plat_now_ns());
        if (is_new) {
            if (have_seq && frame->f.seq > last_seq + 1) tel->frames_dropped += frame->f.seq - last_seq - 1;
            last_seq = frame->f.seq;
            have_seq = true;
            tel->new_frames_shown++;
            if (a->can_objects) objects_moving = track_objects(a, frame);
        }

        int idx = plat_swapchain_next(&a->sc, t_start);
        int64_t t_photon = t_vs + photon_ns;
        rt_fusion_state st;
        bool tracked = rt_fusion_latest(a->fusion, &st);
        /* With no IMU sample for a while (unplugged, bus error) extrapolating the last angular velocity would
         * spin the view: hold the last orientation instead until samples return. */
        bool stale = tracked && t_photon - st.t_ns > RT_IMU_STALE_NS;
        tel->imu_stale += stale;
        warp_quat q = !tracked ? warp_quat_identity() : stale ? st.q : rt_fusion_predict(a->fusion, &st, t_photon);
        warp_pose head = warp_head_pose_from_orientation(&a->head, q);
        warp_pose eyes[2] = {warp_head_eye_pose(&a->head, head, 0), warp_head_eye_pose(&a->head, head, 1)};
        /* rolling: two more predictions, for the scan's first and last line; the warp slerps between them per mesh
         * row (ILLIXR's start and end poses). A held (stale) or absent orientation is the same for every line. */
        const bool rolling = scan.rolling && tracked && !stale;
        warp_pose scan_first[2], scan_last[2];
        if (rolling) {
            const warp_quat q0 = rt_fusion_predict(a->fusion, &st, t_photon + first_ns);
            const warp_quat q1 = rt_fusion_predict(a->fusion, &st, t_photon + last_ns);
            const warp_pose h0 = warp_head_pose_from_orientation(&a->head, q0);
            const warp_pose h1 = warp_head_pose_from_orientation(&a->head, q1);
            for (int e = 0; e < 2; e++) {
                scan_first[e] = warp_head_eye_pose(&a->head, h0, e);
                scan_last[e] = warp_head_eye_pose(&a->head, h1, e);
            }
        }

        rt_method want = c->method;
        if (want == RT_METHOD_AUTO) {
            rt_select_input in;
            memset(&in, 0, sizeof in);
            in.have_frame = frame != NULL;
            if (frame) {
                in.has_depth = frame->has_depth;
                in.inv_depth_max = frame->inv_max[0] > frame->inv_max[1] ? frame->inv_max[0] : frame->inv_max[1];
                in.has_layers = a->can_transparency && (frame->f.planes & DRV_PLANE_LAYERS);
                in.objects_moving = a->can_objects && objects_moving && a->obj_two;
                for (int e = 0; e < 2; e++) {
                    double t = warp_v3_norm(warp_v3_sub(eyes[e].p, frame->f.eye_pose[e].p));
                    if (t > in.translation_m) in.translation_m = t;
                }
            }
            in.time_left_ns = (double)pf.time_left_ns; /* a frame's worth, not what is left now (rt_pacer.h) */
            memcpy(in.cost_ns, rt_pacer_costs(pacer), sizeof in.cost_ns);
            rt_select_why why;
            want = rt_select_choose(&a->sel, RT_METHOD_AUTO, &in, &why);
            tel->select_why[why]++;
        }
        if (want == RT_METHOD_OBJECTS && a->obj_two) {
            double tp = (double)t_photon * 1e-9;
            for (int i = 0; i < a->obj_n; i++)
                a->obj_at[i] = warp_object_pose_extrapolate(a->obj_prev[i], a->obj_prev_t, a->obj_cur[i], a->obj_cur_t, tp);
        }
        rt_method used = want;
        if (idx < 0) {
            tel->no_buffer++; /* every image is still being read: show the previous one again */
        } else if (!frame) {
            tel->no_frame++;
            clear_image(&a->sc.img[idx]);
            if (gles && plat_egl_is_kms(a->gl.egl)) {
                char err[200];
                plat_gles_clear(a->gl.renderer);
                if (!plat_egl_present(a->gl.egl, err, sizeof err)) a->gl.errors++;
            }
        } else if (gles) {
            used = compose_gles(a, frame, eyes, rolling ? scan_first : NULL, rolling ? scan_last : NULL, want,
                                &a->sc.img[idx]);
        } else {
            used = rt_render_cpu_frame_scan(a->render, frame, eyes, rolling ? scan_first : NULL,
                                            rolling ? scan_last : NULL, want, a->obj_two ? a->obj_at : NULL,
                                            &a->sc.img[idx]);
        }
        if (used == RT_METHOD_AUTO) used = RT_METHOD_ROTATION; /* no frame: nothing was warped */
        int64_t t_done = plat_now_ns();
        rt_pacer_mark_point(pacer, RT_PACER_DONE, t_done);
        rt_pacer_work pw = {0, -1, idx >= 0, frame && idx >= 0, used};
        if (gles) {
            gles_times(a);
            if (frame && idx >= 0) {
                rt_pacer_mark_point(pacer, RT_PACER_SUBMITTED, a->gl.submit_ns);
                pw.gpu_ns = (int64_t)(a->gl.gpu_ms * 1e6);
            }
        }
        /* the compositor spins while it waits for a worker's last task: CPU time, but not its own work when the
         * worker was off its CPU meanwhile */
        int64_t work = plat_thread_cpu_ns() - cpu_start - (plat_workers_stalled_ns(a->workers) - stalled_start);
        /* on GLES the thread waits for the GPU without running: its time is the pass's own work all the same (a
         * 157 ms llvmpipe pass once counted as 906 misses of the scheduler's) */
        if (gles && frame && idx >= 0) {
            /* before the first timer query has come back, the wait from submission to done is the GPU's (a fence
             * wait: the readback, or the flip of the previous frame) */
            int64_t gpu = a->gl.gpu_ms > 0 ? (int64_t)(a->gl.gpu_ms * 1e6) : t_done - a->gl.submit_ns;
            work = rt_miss_gles_work(work, gpu, a->gl.software);
        }
        pw.work_ns = work;
        rt_pacer_info pi;
        rt_pacer_info_vsync(pacer, &pw, &pi);
        const bool missed = pi.missed;
        const rt_miss cause = pi.cause;
        const int64_t dur = pi.dur_ns;
        if (idx >= 0) {
            plat_display_present(a->dev.display, &a->sc, idx, t_vs, vsync_no);
            plat_swapchain_presented(&a->sc, idx, t_vs);
            rt_pacer_mark_point(pacer, RT_PACER_PRESENTED, plat_now_ns());
        }

        tel->vsyncs++;
        tel->missed += missed;
        tel->missed_by[cause] += missed;
        double warp_ms = (double)dur * 1e-6;
        if (frame && idx >= 0) {
            tel->method_count[used]++;
            rt_hist_add(&tel->warp_ms[used], warp_ms);
        }
        rt_hist_add(&tel->late_ms, (double)(t_done - t_vs) * 1e-6 + 50.0);
        double m2p = tracked ? (double)(t_photon - st.t_ns) * 1e-6 : NAN;
        double age = frame ? (double)(t_photon - frame->f.pose_t_ns) * 1e-6 : NAN;
        if (tracked) rt_hist_add(&tel->m2p_ms, m2p);
        if (frame) rt_hist_add(&tel->frame_age_ms, age);
        if (frame && idx >= 0) {
            /* the share of the visible panel that sampled outside the host frame (the fringe, 003 §4.3): read off
             * the mesh each pass just drew through; the eye-space warps' mesh maps their own output (share 0) */
            int64_t outside = 0, visible = 0;
            for (int e = 0; e < 2; e++) {
                outside += rt_render_cpu_outside(a->render, e, frame->f.cam[e].width, frame->f.cam[e].height);
                visible += rt_render_cpu_visible(a->render, e);
            }
            if (visible > 0) {
                rt_hist_add(&tel->outside_pct, 100.0 * (double)outside / (double)visible);
                tel->outside_px += (uint64_t)outside;
                tel->visible_px += (uint64_t)visible;
            }
        }
        if (a->csv.f) {
            rt_csv_row row = {vsync_no, frame ? frame->f.seq : 0, t_vs, (float)warp_ms, (float)m2p, (float)age,
                              (int)used, missed};
            rt_ring_push(&a->csv.ring, &row);
        }
        if (eval && frame && t_vs >= next_eval) {
            rt_eval_record r = {vsync_no, frame->f.seq, frame->f.scene_time,
                                (double)(t_photon - a->t0_ns) * 1e-9, frame->f.eye_pose[0], eyes[0], (int)used,
                                rolling ? scan_first[0] : eyes[0], rolling ? scan_last[0] : eyes[0]};
            rt_ring_push(&eval->ring, &r);
            next_eval += eval_every;
        }

        if (frame && idx >= 0) {
            if (prev_used != RT_METHOD_COUNT && used != prev_used) tel->method_switches++;
            prev_used = used;
        }

        int64_t ask_after, period_ns = pf.period_ns;
        int64_t next = drv_vsync_next(a->dev.vsync, rt_pacer_next_after(pacer), &period_ns);
        if (rt_pacer_advance(pacer, next, period_ns, plat_now_ns(), &ask_after)) {
            int64_t later = drv_vsync_next(a->dev.vsync, ask_after, &period_ns);
            uint64_t skipped = rt_pacer_skip_to(pacer, later, period_ns);
            tel->vsyncs += skipped;
            tel->missed += skipped;
            /* skipped vsyncs take the overrunning pass's cause; a pass that made its vsync yet leaves no time for the
             * next one has cause OWN: the plan's doing */
            tel->missed_by[cause] += skipped;
        }
    }
    if (gles) plat_egl_release(a->gl.egl);
}
