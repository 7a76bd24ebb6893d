/* SPDX-License-Identifier: MIT */
/* rt_app: one hmdwarpd instance: devices chosen by board.ini, the IMU, frames, compositor and helper threads, and
 * the run summary. hmdwarpd_main parses arguments; tests drive an instance directly. */
#include "runtime/rt_app.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <systemd/sd-daemon.h>

#include "platform/plat_clock.h"
#include "platform/plat_egl.h"
#include "platform/plat_gles.h"
#include "platform/plat_kms.h"
#include "platform/plat_log.h"
#include "platform/plat_version.h"
#include "platform/plat_workers.h"
#include "runtime/rt_compositor.h"
#include "runtime/rt_csv.h"
#include "runtime/rt_gles.h"
#include "runtime/rt_kernel.h"
#include "runtime/rt_live.h"
#include "runtime/rt_pacer.h"
#include "runtime/rt_simboard.h"
#include "runtime/rt_summary.h"
#include "warp/warp_err.h"
#include "warp/warp_resample.h"

static bool predict_for_host(void *ctx, int64_t t_ns, warp_pose *head)
{
    rt_app *a = ctx;
    warp_quat q;
    rt_fusion_state st;
    if (!rt_fusion_latest(a->fusion, &st)) return false;
    /* As on the display path: hold the last orientation while the IMU is gone rather than extrapolate. */
    if (t_ns - st.t_ns > RT_IMU_STALE_NS)
        q = st.q;
    else if (!rt_fusion_at(a->fusion, t_ns, &q))
        return false;
    *head = warp_head_pose_from_orientation(&a->head, q);
    return true;
}

/* The CPU path's KMS output: dumb buffers on the panel's connector (a->dev.display; a->dev.kms borrowed from it). */
static bool cpu_kms_init(rt_app *a, const plat_kms_params *kp, char *err, int errlen)
{
    char e[300];
    plat_kms *k = plat_kms_open(kp, e, sizeof e);
    if (!k) return warp_err(err, errlen, "[display] output = kms: %s", e);
    const plat_kms_choice *ch = plat_kms_chosen(k);
    if (ch->mode.hdisplay != a->cfg.panel_w || ch->mode.vdisplay != a->cfg.panel_h) {
        snprintf(e, sizeof e, "%dx%d, the panel is %dx%d", ch->mode.hdisplay, ch->mode.vdisplay, a->cfg.panel_w,
                 a->cfg.panel_h);
        plat_kms_close(k);
        return warp_err(err, errlen, "[display] output = kms: the mode is %s", e);
    }
    a->dev.display = plat_display_kms_create(k, &a->sc, e, sizeof e);
    if (!a->dev.display) return warp_err(err, errlen, "[display] output = kms: %s", e);
    a->dev.kms = k;
    return true;
}

/* Opens EGL and the GLES renderer when [render] renderer and [display] output call for them, and the KMS output. */
static bool render_init(rt_app *a, char *err, int errlen)
{
    const rt_config *c = &a->cfg;
    const bool kms = strcmp(c->output, "kms") == 0;
    const bool forced = strcmp(c->renderer, "gles") == 0;
    char eerr[300] = "";
    if (!warp_resample_force_kernel((warp_resample_kernel_id)c->kernel))
        return warp_err(err, errlen, "[render] kernel = %s: this build or CPU cannot run it",
                        rt_kernel_name(c->kernel));
    if (c->kernel == WARP_RESAMPLE_AUTO) {
        /* the fastest by measurement, not the widest the CPU flags allow (on a Zen 5 AVX2 beat AVX-512); GLES
         * runs may fall back to the CPU pass, so they choose too; the summary says which and why */
        rt_kernel_choice kc;
        if (!rt_kernel_measure(c, a->render, &kc, err, errlen)) return false;
        warp_resample_set_auto(kc.picked);
        snprintf(a->kernel_why, sizeof a->kernel_why, "%s", kc.why);
    }
    plat_kms_params kp = {c->kms_device, c->kms_connector, 0, 0, 0, c->rt_priority};
    if (kms) {
        if (!rt_config_parse_mode(c->kms_mode, &kp.mode_w, &kp.mode_h, &kp.mode_hz))
            return warp_err(err, errlen, "[display] kms_mode = '%s': expected auto, WxH or WxH@Hz", c->kms_mode);
        if (kp.mode_w == 0) {
            kp.mode_w = c->panel_w;
            kp.mode_h = c->panel_h;
        }
    }
    if (strcmp(c->renderer, "cpu") != 0) {
        if (kms) {
            a->gl.egl = plat_egl_open_kms(&kp, eerr, sizeof eerr);
            /* a missing device fails the same way on the CPU path: say so now, in the KMS terms */
            if (!a->gl.egl &&
                (forced || strncmp(eerr, "no DRM device", 13) == 0 || strncmp(eerr, "kms_device", 10) == 0))
                return warp_err(err, errlen, "[display] output = kms: %s", eerr);
            if (a->gl.egl) {
                int mw, mh;
                plat_egl_kms_mode(a->gl.egl, &mw, &mh, NULL, NULL);
                if (mw != c->panel_w || mh != c->panel_h) {
                    char m[64];
                    snprintf(m, sizeof m, "%dx%d, the panel is %dx%d", mw, mh, c->panel_w, c->panel_h);
                    return warp_err(err, errlen, "[display] output = kms: the mode is %s", m);
                }
            }
        } else {
            a->gl.egl = plat_egl_open_offscreen(eerr, sizeof eerr);
        }
    }
    a->gl.use = rt_render_choose(c->renderer, a->gl.egl ? plat_egl_renderer(a->gl.egl) : NULL, eerr, kms, a->render_why,
                                   sizeof a->render_why);
    if (a->gl.use && !a->gl.egl) return warp_err(err, errlen, "[render] renderer = gles: %s", eerr);
    a->gl.software = a->gl.egl && plat_egl_renderer_is_software(plat_egl_renderer(a->gl.egl));
    if (!a->gl.use) {
        /* closed before the CPU path opens the device: one master, one owner of the CRTC */
        plat_egl_close(a->gl.egl);
        a->gl.egl = NULL;
        return !kms || cpu_kms_init(a, &kp, err, errlen);
    }
    /* the GPU path runs transparency and object warps as its raytrace (no GLES pass for them yet) */
    a->gl.depth = c->method != RT_METHOD_NONE && c->method != RT_METHOD_ROTATION;
    const warp_mesh *mesh = rt_render_cpu_mesh(a->render, 0);
    plat_gles_params gp = {c->panel_w, c->panel_h, c->eye_w, c->eye_h, mesh->cols, mesh->rows,
                           a->gl.depth, kms, true, false};
    a->gl.renderer = plat_gles_create(a->gl.egl, &gp, eerr, sizeof eerr);
    if (!a->gl.renderer) {
        if (forced) return warp_err(err, errlen, "[render] renderer = %s: %s", c->renderer, eerr);
        /* auto on a GPU whose driver cannot run our shaders: the CPU path still works, on KMS too */
        snprintf(a->render_why, sizeof a->render_why, "auto: the GPU (%.60s) cannot run the GLES renderer: %.140s",
                 plat_egl_renderer(a->gl.egl), eerr);
        plat_egl_close(a->gl.egl);
        a->gl.egl = NULL;
        a->gl.use = false;
        return !kms || cpu_kms_init(a, &kp, err, errlen);
    }
    if (kms) a->dev.kms = plat_egl_kms(a->gl.egl);
    a->gl.ms = calloc(PLAT_GLES_PASSES, sizeof *a->gl.ms);
    if (!a->gl.ms) return warp_err(err, errlen, "out of memory");
    /* The compositor thread makes the context current for itself. */
    plat_egl_release(a->gl.egl);
    return true;
}

static void stats_kv(rt_app *a, FILE *out, bool live);

bool rt_app_init(rt_app *a, const rt_config *cfg, char *err, int errlen)
{
    memset(a, 0, sizeof *a);
    rt_live_reset(&a->live);
    a->cfg = *cfg;
    const rt_config *c = &a->cfg;

    /* The simulated board's scene and motion, for the devices it plays (a sim backend or a mock device; the
     * accuracy evaluation needs a simulated head and host, so it implies them). A board whose devices are all real
     * never loads the simulator. */
    /* Virtual time (plat_clock.h) is the simulated board's: a kernel or a host stamps real devices' events in real
     * time, and mixing the two would make every stamp wrong. */
    const char *real = NULL;
    if (plat_clock_slowdown() > 1 && !rt_devices_on_virtual_time(c, &real))
        return warp_err(err, errlen,
                        "HMDWARP_TIME_SLOWDOWN=%s: virtual time is for simulated and mock devices, but %s is a real one",
                        getenv("HMDWARP_TIME_SLOWDOWN") ? getenv("HMDWARP_TIME_SLOWDOWN") : "?", real);
    if (rt_devices_simulated(c) && !(a->sim = rt_simboard_create(c, err, errlen))) return false;

    a->head = warp_head_default();
    a->head.ipd = c->ipd;
    for (int e = 0; e < 2; e++) a->eye_cam[e] = rt_config_eye_camera(c, e);
    /* one shown, one waiting for its vsync, one being drawn; a fourth while a file sink still reads one, or while
     * a pass started by [render] stall_reserve_ms more than a period ahead keeps two out of reach */
    if (!plat_swapchain_alloc(&a->sc, c->stall_reserve_ms > 0 ? 4 : 3, c->panel_w, c->panel_h))
        return warp_err(err, errlen, "cannot allocate the swapchain ([display] width/height)");
    a->workers = plat_workers_create(c->threads - 1, c->rt_priority);
    if (!a->workers) return warp_err(err, errlen, "cannot start compositor worker threads");
    /* the CPU pass before the renderer: its lens meshes are the GLES path's too */
    rt_render_cpu_params rp = rt_render_cpu_params_from_config(c);
    a->render = rt_render_cpu_create(&rp, a->workers, err, errlen);
    if (!a->render) return false;
    if (!render_init(a, err, errlen)) return false;
    a->can_transparency = rp.transparency;
    a->can_objects = rp.objects;
    rt_select_params selp = rt_select_default_params();
    selp.pixel_budget = c->pixel_budget;
    rt_select_init(&a->sel, &selp, &a->eye_cam[0]);

    a->fusion = calloc(1, sizeof *a->fusion);
    a->tel = rt_telemetry_create();
    rt_pacer_params pp = {RT_PACER_MARGIN_NS, (int64_t)(c->stall_reserve_ms * 1e6)};
    a->pacer = rt_pacer_create(&pp);
    if (!a->fusion || !a->tel || !a->pacer) return warp_err(err, errlen, "out of memory");
    rt_fusion_params fp = rt_fusion_default_params();
    fp.lever_arm = a->head.neck_to_eye; /* the IMU sits between the eyes, on the neck model's lever arm */
    rt_fusion_init(a->fusion, &fp);

    /* Devices. Scene time 0 lies a little in the future, after the simulated headset's rest at boot, so every
     * thread is up and the tracker has learned the gyro bias when the head starts moving. */
    bool imu_simulated = strcmp(c->imu_backend, "sim") == 0 || strcmp(c->imu_device, "mock") == 0;
    a->t0_ns = plat_now_ns() + 50 * PLAT_NS_PER_MS + (imu_simulated ? (int64_t)(c->imu_rest_s * 1e9) : 0);
    if (c->duration_s > 0) a->t_end_ns = a->t0_ns + (int64_t)(c->duration_s * 1e9);
    if (a->sim) rt_simboard_set_origin(a->sim, a->t0_ns);
    drv_frames_sim_params sp;
    memset(&sp, 0, sizeof sp);
    sp.scene = a->sim ? rt_simboard_scene(a->sim) : NULL;
    sp.cam[0] = a->eye_cam[0];
    sp.cam[1] = a->eye_cam[1];
    sp.head = a->head;
    sp.rate_hz = c->host_rate_hz;
    sp.latency_ms = c->host_latency_ms;
    sp.threads = c->host_threads;
    sp.t0_ns = a->t0_ns;
    sp.poses.predict = predict_for_host;
    sp.poses.ctx = a;
    /* The warps of this build use colour and depth; ids, motion and layers would be rendered for nothing. */
    sp.planes_wanted = DRV_PLANE_COLOR | DRV_PLANE_DEPTH | (a->can_objects ? DRV_PLANE_IDS : 0) |
                       (a->can_transparency ? DRV_PLANE_LAYERS : 0);
    const sim_trace *trace = a->sim ? rt_simboard_trace(a->sim) : NULL; /* read only for simulated devices */
    if (!rt_devices_open(&a->dev, c, trace, &sp, err, errlen) || !rt_devices_mount(&a->dev, c, err, errlen))
        return false;
    if (!rt_frameq_alloc(&a->fq, c->eye_w, c->eye_h, drv_frames_planes(a->dev.frames), 4))
        return warp_err(err, errlen, "cannot allocate the frame slots");
    /* The frames thread prepares each eye of a host frame on its own thread, as many as decode a frame's planes
     * ([frames] decode_threads): at normal priority, below the compositor's. */
    if (c->decode_threads > 1 && !(a->prepare_workers = plat_workers_create(1, 0)))
        return warp_err(err, errlen, "cannot start the frames thread's worker");

    if (a->dev.display) {
        /* the CPU path's KMS output, opened with the renderer */
    } else if (strcmp(c->sink, "null") == 0) {
        a->dev.display = plat_display_null_create();
    } else {
        char e2[300];
        a->dev.display = plat_display_files_create(c->sink, c->sink_path, c->sink_every, e2, sizeof e2);
        if (!a->dev.display) return warp_err(err, errlen, "[display] sink = %s: %s", c->sink, e2);
    }
    if (!a->dev.display) return warp_err(err, errlen, "out of memory");

    return rt_csv_open(&a->csv, c->csv, c->csv_max_mb, err, errlen) &&
           rt_live_alloc(&a->live, c->live_stats, err, errlen);
}

/* The live view's text: the key=value set of --stats (rt_live.h). */
static void live_text(void *ctx, FILE *out, bool live) { stats_kv(ctx, out, live); }

bool rt_app_write_last_stats(rt_app *a, int fd) { return rt_live_write_last(&a->live, fd); }

static void *aux_thread(void *arg)
{
    rt_app *a = arg;
    plat_thread_set_name("hmdwarp-aux");
    /* CSV rows are written here, away from the vsync path; then accuracy evaluation once the run is over if the
     * idle-priority evaluator could not keep up. Under systemd (Type=notify, WatchdogSec) the watchdog is fed
     * from here too, but only while the vsync loop advances: a compositor that stops presenting gets restarted. */
    uint64_t usec = 0, last_vsyncs = UINT64_MAX;
    bool watchdog = sd_watchdog_enabled(0, &usec) > 0 && usec > 0;
    /* STATUS= only under systemd (sd_notify is a no-op elsewhere, but formatting it need not run) */
    bool notify = getenv("NOTIFY_SOCKET") != NULL;
    int64_t next_ping = plat_now_ns(), next_live = plat_now_ns() + PLAT_NS_PER_S;
    /* marks and rates start now; the abort handler has something from the start */
    rt_live_update(&a->live, a->tel, live_text, a, false);
    while (!atomic_load(&a->stop)) {
        rt_csv_drain(&a->csv);
        if (plat_now_ns() >= next_live) {
            rt_live_update(&a->live, a->tel, live_text, a, notify);
            next_live += PLAT_NS_PER_S;
            if (next_live < plat_now_ns()) next_live = plat_now_ns() + PLAT_NS_PER_S; /* after a stall: no burst */
        }
        if (watchdog && plat_now_ns() >= next_ping) {
            uint64_t v = a->tel->vsyncs;
            if (v != last_vsyncs) sd_notify(0, "WATCHDOG=1");
            last_vsyncs = v;
            next_ping = plat_now_ns() + (int64_t)usec * 1000 / 2;
        }
        plat_sleep_ns(20 * PLAT_NS_PER_MS);
    }
    rt_csv_drain(&a->csv);
    return NULL;
}

void rt_app_request_stop(rt_app *a) { atomic_store(&a->stop, 1); }

void rt_app_run(rt_app *a)
{
    if (a->sim && a->dev.has_truth && a->cfg.eval_every_ms > 0) {
        rt_eval_inputs in = {.cam = a->eye_cam[0], .head = a->head, .mesh_n = a->cfg.mesh_n,
                             .rp = *rt_render_cpu_raytrace_params(a->render),
                             .tp = *rt_render_cpu_mesh_trace_params(a->render), .scan = rt_config_scan(&a->cfg),
                             .stop = &a->stop};
        rt_simboard_eval_start(a->sim, &in);
    }
    a->run_start_ns = plat_now_ns();
    a->feed = (rt_devices_feed){&a->dev, a->fusion, &a->fq, a->tel, &a->stop, a->cfg.rt_priority, a->t0_ns,
                                rt_frame_prepare_on, a->prepare_workers};
    a->th_imu_up = pthread_create(&a->th_imu, NULL, rt_devices_imu_thread, &a->feed) == 0;
    a->th_frames_up = pthread_create(&a->th_frames, NULL, rt_devices_frames_thread, &a->feed) == 0;
    a->th_aux_up = pthread_create(&a->th_aux, NULL, aux_thread, a) == 0;
    plat_thread_set_name("hmdwarp-vsync");
    /* relaxed: the helper thread reads them only to print them */
    bool rt = a->cfg.rt_priority > 0 && plat_thread_set_realtime(a->cfg.rt_priority);
    atomic_store_explicit(&a->realtime, rt, memory_order_relaxed);
    /* Everything is allocated by now; keep it resident so no page fault lands on the vsync path. */
    if (rt) atomic_store_explicit(&a->memory_locked, plat_lock_memory(), memory_order_relaxed);
    rt_compositor_run(a);
    int64_t end = plat_now_ns(); /* stored once the helper thread, which reads it, has stopped */
    atomic_store(&a->stop, 1);
    if (a->th_imu_up) pthread_join(a->th_imu, NULL);
    if (a->th_frames_up) pthread_join(a->th_frames, NULL);
    if (a->th_aux_up) pthread_join(a->th_aux, NULL);
    rt_simboard_eval_join(a->sim);
    a->run_end_ns = end;
    plat_display_flush(a->dev.display);
    if (a->sim) rt_simboard_collect_host(a->sim, &a->dev);
    /* the live file's last word once every thread has stopped: what --stats says, so hmdwarp-top shows the end */
    rt_live_final(&a->live, live_text, a);
}

/* The run's parts as the summary table reads them (rt_summary.h). live: while the run goes on (the helper thread),
 * leaving out what another thread accumulates unpublished until the end (the accuracy evaluator's sums). */
/* The texts summary_src composes, held by its caller for as long as the table prints from it. */
typedef struct {
    char output[400]; /* the display's description (the summary's alone) */
    char fx[160];     /* the scene's effects */
    char why[320];    /* why this renderer, with the compositor's fallback if it fell back */
} summary_text;

static void summary_src(rt_app *a, rt_summary_src *s, bool live, bool with_output, summary_text *t)
{
    const rt_config *c = &a->cfg;
    memset(s, 0, sizeof *s);
    s->cfg = c;
    s->tel = a->tel;
    s->live = live;
    /* since the display started (after the simulated IMU's rest) until it stopped (not the accuracy evaluation
     * catching up afterwards): the span the vsync counts cover */
    int64_t since = a->run_start_ns ? (a->run_end_ns ? a->run_end_ns : plat_now_ns()) - a->t0_ns : 0;
    s->run_s = since > 0 ? (double)since * 1e-9 : 0.0;
    s->gles = atomic_load_explicit(&a->gl.use, memory_order_relaxed);
    s->gles_software = a->gl.software;
    s->gles_depth = a->gl.depth;
    s->realtime = atomic_load_explicit(&a->realtime, memory_order_relaxed);
    s->memory_locked = atomic_load_explicit(&a->memory_locked, memory_order_relaxed);
    s->gl_renderer = s->gles ? plat_egl_renderer(a->gl.egl) : "";
    s->gl_version = s->gles ? plat_egl_version(a->gl.egl) : "";
    s->gles_timing = a->gl.renderer ? plat_gles_timing_method(a->gl.renderer) : "";
    s->gles_gpu_pyramid = a->gl.renderer && plat_gles_gpu_pyramid(a->gl.renderer);
    /* render_why is rt_app_init's; the compositor's fallback is a flag, not an append the helper could read
     * half-written */
    snprintf(t->why, sizeof t->why, "%s%s", a->render_why,
             atomic_load_explicit(&a->gl.fell_back, memory_order_relaxed)
                 ? "; the EGL context could not be made current: fell back to cpu"
                 : "");
    s->render_why = t->why;
    s->cpu_kernel = warp_resample_kernel();
    s->cpu_kernel_why = a->kernel_why;
    s->threads = a->workers ? plat_workers_threads(a->workers) : 0;
    s->gles_ms = a->gl.ms;
    s->gles_errors = a->gl.errors;
    s->gles_last_error = a->gl.last_error;
    rt_render_cpu_stats rs = a->render ? rt_render_cpu_stats_get(a->render) : (rt_render_cpu_stats){0};
    s->raytrace_fallbacks = rs.raytrace_fallbacks;
    s->plane_fallbacks = rs.plane_fallbacks;
    const rt_devices *d = &a->dev;
    s->imu_name = d->imu ? d->imu->name : "";
    s->frames_name = d->frames ? d->frames->name : "";
    s->vsync_name = d->vsync ? d->vsync->name : "";
    s->has_imu_stats = d->imu && drv_imu_stats_get(d->imu, &s->imu);
    s->has_vsync_stats = d->vsync && drv_vsync_stats_get(d->vsync, &s->vsync);
    /* the usb backend (or its mock) and the socket backend are one board side: its link statistics */
    s->has_link_stats =
        d->frames && (strcmp(c->frames_backend, "usb") == 0 || strcmp(c->frames_backend, "socket") == 0);
    if (s->has_link_stats) drv_frames_usb_stats_get(d->frames, &s->link);
    s->kms = d->kms != NULL;
    s->kms_stats.api = "";
    s->kms_stats.format = "";
    if (d->kms) plat_kms_stats_get(d->kms, &s->kms_stats);
    if (with_output) { /* the summary's alone: --stats names the output in display_output */
        t->output[0] = 0;
        if (d->display) d->display->describe(d->display, t->output, (int)sizeof t->output);
    }
    s->output = with_output ? t->output : NULL;
    s->imu_rejected = rt_fusion_rejected(a->fusion, RT_FUSION_BAD_VALUE) +
                      rt_fusion_rejected(a->fusion, RT_FUSION_TIME_REPEAT) +
                      rt_fusion_rejected(a->fusion, RT_FUSION_TIME_JUMP);
    s->has_orientation = rt_fusion_latest(a->fusion, &s->orientation);
    s->has_truth = d->has_truth;
    if (s->has_orientation && d->has_truth && a->sim)
        s->orientation_error_deg = rt_simboard_orientation_error_deg(a->sim, s->orientation.t_ns, s->orientation.q);
    /* a board without the simulated one prints the same keys, its evaluator's scores empty */
    static const rt_eval no_eval;
    const rt_eval *ev = a->sim ? rt_simboard_eval(a->sim) : &no_eval;
    s->sim_host = d->sim_host;
    s->sim_plane_renders = a->sim ? rt_simboard_plane_renders(a->sim) : NULL;
    s->scene_effects = d->sim_host && a->sim ? rt_simboard_scene_effects(a->sim, t->fx, (int)sizeof t->fx) : "";
    s->accuracy = d->has_truth && c->eval_every_ms > 0;
    s->eval = ev->acc;
    s->eval_pose = &ev->pose;
    s->csv = a->csv.f ? c->csv : NULL;
}

static void stats_kv(rt_app *a, FILE *out, bool live)
{
    rt_summary_src s;
    summary_text t;
    summary_src(a, &s, live, false, &t);
    rt_summary_kv(&s, out);
}

void rt_app_summary(rt_app *a, FILE *out)
{
    rt_summary_src s;
    summary_text t;
    summary_src(a, &s, false, true, &t);
    rt_summary_print(&s, out);
}

void rt_app_stats_kv(rt_app *a, FILE *out) { stats_kv(a, out, false); }

bool rt_app_showed_frames(const rt_app *a, char *why, int whylen)
{
    const rt_telemetry *t = a->tel;
    uint64_t rejected = 0;
    int most = 0;
    for (int e = 1; e < DRV_FRAME_ERR_COUNT; e++) {
        rejected += t->frames_rejected[e];
        if (t->frames_rejected[e] > t->frames_rejected[most]) most = e;
    }
    why[0] = 0;
    if (t->vsyncs == 0)
        snprintf(why, (size_t)whylen, "no vsync was presented (the configuration is more than this machine can "
                                      "warp at %.0f Hz, or the vsync source gave nothing)", a->cfg.refresh_hz);
    else if (t->new_frames_shown > 0)
        return true;
    else if (rejected && !t->frames_received)
        snprintf(why, (size_t)whylen, "every host frame was rejected (%llu, most as %s)",
                 (unsigned long long)rejected, drv_frame_err_str((drv_frame_err)most));
    else if (!t->frames_received)
        snprintf(why, (size_t)whylen, "no host frame arrived in %llu vsyncs", (unsigned long long)t->vsyncs);
    else
        snprintf(why, (size_t)whylen, "%llu host frames arrived, none was shown",
                 (unsigned long long)t->frames_received);
    return false;
}

void rt_app_free(rt_app *a)
{
    rt_devices_close(&a->dev);
    rt_gles_free(&a->gl);
    rt_render_cpu_destroy(&a->render); /* before the workers it borrows */
    rt_pacer_destroy(&a->pacer);
    if (a->workers) plat_workers_destroy(a->workers);
    if (a->prepare_workers) plat_workers_destroy(a->prepare_workers);
    plat_swapchain_free(&a->sc);
    rt_frameq_free(&a->fq);
    rt_simboard_destroy(&a->sim);
    rt_csv_close(&a->csv);
    rt_live_free(&a->live);
    free(a->fusion);
    rt_telemetry_destroy(a->tel);
    memset(a, 0, sizeof *a);
}
