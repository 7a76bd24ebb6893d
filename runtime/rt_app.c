/* SPDX-License-Identifier: MIT */
/* rt_app: one hmdwarpd instance: devices chosen by board.ini, the IMU, frames, compositor and helper threads, and
 * the run summary. hmdwarpd_main parses arguments; tests drive an instance directly. */
#include "runtime/rt_app.h"

#include <ctype.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <systemd/sd-daemon.h>

#include "drivers/drv_sim.h"
#include "platform/plat_clock.h"
#include "platform/plat_log.h"
#include "platform/plat_version.h"
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

static bool fail(char *err, int errlen, const char *fmt, const char *a1, const char *a2)
{
    snprintf(err, (size_t)errlen, fmt, a1, a2);
    return false;
}

static void names_list(const char *const *names, char *buf, size_t len)
{
    buf[0] = 0;
    for (int i = 0; names[i]; i++) {
        strncat(buf, i ? ", " : "", len - strlen(buf) - 1);
        strncat(buf, names[i], len - strlen(buf) - 1);
    }
}

bool rt_render_choose(const char *setting, const char *gl_renderer, const char *egl_err, bool kms, char *why,
                      int whylen)
{
    size_t n = (size_t)whylen;
    if (strcmp(setting, "cpu") == 0) {
        snprintf(why, n, "renderer = cpu");
        return false;
    }
    if (strcmp(setting, "gles") == 0) {
        if (gl_renderer)
            snprintf(why, n, "renderer = gles%s", plat_egl_renderer_is_software(gl_renderer)
                                                      ? " (forced onto a software rasterizer)"
                                                      : "");
        else
            snprintf(why, n, "renderer = gles, but no EGL: %s", egl_err ? egl_err : "unknown error");
        return true;
    }
    /* with output = kms the CPU path shows through dumb buffers, so the choice is the same as offscreen */
    const char *via = kms ? "; KMS through dumb buffers" : "";
    if (!gl_renderer) {
        snprintf(why, n, "auto: no usable EGL / OpenGL ES 3 (%s)%s", egl_err ? egl_err : "unknown error", via);
        return false;
    }
    if (!plat_egl_renderer_is_software(gl_renderer)) {
        snprintf(why, n, "auto: EGL offers a hardware GPU");
        return true;
    }
    snprintf(why, n, "auto: EGL offers only a software rasterizer (%s); the CPU path is faster there and vsync "
                     "comes first%s",
             gl_renderer, via);
    return false;
}

/* The CPU path's KMS output: dumb buffers on the panel's connector (a->display; a->kms borrowed from it). */
static bool cpu_kms_init(rt_app *a, const plat_kms_params *kp, char *err, int errlen)
{
    char e[300];
    plat_kms *k = plat_kms_open(kp, e, sizeof e);
    if (!k) return fail(err, errlen, "[display] output = kms: %s%s", e, "");
    const plat_kms_choice *ch = plat_kms_chosen(k);
    if (ch->mode.hdisplay != a->cfg.panel_w || ch->mode.vdisplay != a->cfg.panel_h) {
        snprintf(e, sizeof e, "%dx%d, the panel is %dx%d", ch->mode.hdisplay, ch->mode.vdisplay, a->cfg.panel_w,
                 a->cfg.panel_h);
        plat_kms_close(k);
        return fail(err, errlen, "[display] output = kms: the mode is %s%s", e, "");
    }
    a->display = plat_display_kms(k, &a->sc, e, sizeof e);
    if (!a->display) return fail(err, errlen, "[display] output = kms: %s%s", e, "");
    a->kms = k;
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
        return fail(err, errlen, "[render] kernel = %s: this build or CPU cannot run it%s", rt_kernel_name(c->kernel),
                    "");
    plat_kms_params kp = {c->kms_device, c->kms_connector, 0, 0, 0, c->rt_priority};
    if (kms) {
        if (!rt_config_parse_mode(c->kms_mode, &kp.mode_w, &kp.mode_h, &kp.mode_hz))
            return fail(err, errlen, "[display] kms_mode = '%s': %s", c->kms_mode, "expected auto, WxH or WxH@Hz");
        if (kp.mode_w == 0) {
            kp.mode_w = c->panel_w;
            kp.mode_h = c->panel_h;
        }
    }
    if (strcmp(c->renderer, "cpu") != 0) {
        if (kms) {
            a->egl = plat_egl_open_kms(&kp, eerr, sizeof eerr);
            /* a missing device fails the same way on the CPU path: say so now, in the KMS terms */
            if (!a->egl && (forced || strncmp(eerr, "no DRM device", 13) == 0 || strncmp(eerr, "kms_device", 10) == 0))
                return fail(err, errlen, "[display] output = kms: %s%s", eerr, "");
            if (a->egl) {
                int mw, mh;
                plat_egl_kms_mode(a->egl, &mw, &mh, NULL, NULL);
                if (mw != c->panel_w || mh != c->panel_h) {
                    char m[64];
                    snprintf(m, sizeof m, "%dx%d, the panel is %dx%d", mw, mh, c->panel_w, c->panel_h);
                    return fail(err, errlen, "[display] output = kms: the mode is %s%s", m, "");
                }
            }
        } else {
            a->egl = plat_egl_open_offscreen(eerr, sizeof eerr);
        }
    }
    a->use_gles = rt_render_choose(c->renderer, a->egl ? plat_egl_renderer(a->egl) : NULL, eerr, kms, a->render_why,
                                   sizeof a->render_why);
    if (a->use_gles && !a->egl) return fail(err, errlen, "[render] renderer = gles: %s%s", eerr, "");
    a->gles_software = a->egl && plat_egl_renderer_is_software(plat_egl_renderer(a->egl));
    if (!a->use_gles) {
        /* closed before the CPU path opens the device: one master, one owner of the CRTC */
        plat_egl_close(a->egl);
        a->egl = NULL;
        return !kms || cpu_kms_init(a, &kp, err, errlen);
    }
    /* the GPU path runs transparency and object warps as its raytrace (no GLES pass for them yet) */
    a->gles_depth = c->method != RT_METHOD_NONE && c->method != RT_METHOD_ROTATION;
    plat_gles_params gp = {c->panel_w, c->panel_h, c->eye_w, c->eye_h, a->mesh[0].cols, a->mesh[0].rows,
                           a->gles_depth, kms, true, false};
    a->gles = plat_gles_create(a->egl, &gp, eerr, sizeof eerr);
    if (!a->gles) {
        if (forced) return fail(err, errlen, "[render] renderer = %s: %s", c->renderer, eerr);
        /* auto on a GPU whose driver cannot run our shaders: the CPU path still works, on KMS too */
        snprintf(a->render_why, sizeof a->render_why, "auto: the GPU (%.60s) cannot run the GLES renderer: %.140s",
                 plat_egl_renderer(a->egl), eerr);
        plat_egl_close(a->egl);
        a->egl = NULL;
        a->use_gles = false;
        return !kms || cpu_kms_init(a, &kp, err, errlen);
    }
    if (kms) a->kms = plat_egl_kms(a->egl);
    a->gles_ms = calloc(PLAT_GLES_PASSES, sizeof *a->gles_ms);
    if (!a->gles_ms) return fail(err, errlen, "%s%s", "out of memory", "");
    /* The compositor thread makes the context current for itself. */
    plat_egl_release(a->egl);
    return true;
}

static void stats_kv(rt_app *a, FILE *out, bool live);

#define CSV_HEADER "vsync,vsync_ns,frame_seq,method,warp_ms,missed,m2p_ms,frame_age_ms\n"
/* The key=value text of one live update: the --stats set is about 3 KB. */
#define LIVE_BUF_BYTES (32 * 1024)
#define LIVE_AUTO_DIR "/run/hmdwarp"

/* [telemetry] live_stats: auto means the runtime directory systemd makes (RuntimeDirectory=hmdwarp) when it is
 * there; a path named outright must be writable now, not first fail a second into the run. */
static bool live_init(rt_app *a, char *err, int errlen)
{
    const char *want = a->cfg.live_stats;
    if (strcmp(want, "auto") == 0)
        want = access(LIVE_AUTO_DIR, W_OK) == 0 ? LIVE_AUTO_DIR "/stats" : "";
    if (want[0]) {
        char tmp[300];
        snprintf(tmp, sizeof tmp, "%s.tmp", want);
        int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
        if (fd < 0) return fail(err, errlen, "[telemetry] live_stats = %s: %s", want, strerror(errno));
        close(fd);
        unlink(tmp);
        snprintf(a->live_path, sizeof a->live_path, "%s", want);
    }
    for (int i = 0; i < 2; i++) a->live_buf[i] = malloc(LIVE_BUF_BYTES);
    a->live_m2p = calloc(1, sizeof *a->live_m2p);
    a->live_age = calloc(1, sizeof *a->live_age);
    if (!a->live_buf[0] || !a->live_buf[1] || !a->live_m2p || !a->live_age)
        return fail(err, errlen, "%s%s", "out of memory", "");
    return true;
}

bool rt_app_init(rt_app *a, const rt_config *cfg, char *err, int errlen)
{
    memset(a, 0, sizeof *a);
    atomic_store(&a->live_pub, -1);
    a->cfg = *cfg;
    const rt_config *c = &a->cfg;
    char list[512];

    /* The simulated board's scene and motion, for the devices it plays (a sim backend or a mock device; the
     * accuracy evaluation needs a simulated head and host, so it implies them). A board whose devices are all real
     * never loads the simulator. */
    /* Virtual time (plat_clock.h) is the simulated board's: a kernel or a host stamps real devices' events in real
     * time, and mixing the two would make every stamp wrong. */
    const char *real = NULL;
    if (plat_clock_slowdown() > 1 && !rt_devices_on_virtual_time(c, &real))
        return fail(err, errlen, "HMDWARP_TIME_SLOWDOWN=%s: virtual time is for simulated and mock devices, but %s is "
                                 "a real one", getenv("HMDWARP_TIME_SLOWDOWN") ? getenv("HMDWARP_TIME_SLOWDOWN") : "?",
                    real);
    a->sim_loaded = rt_devices_simulated(c);
    if (a->sim_loaded) {
        a->scene = sim_scene_find(c->scene);
        if (!a->scene) {
            names_list(sim_scene_names(), list, sizeof list);
            return fail(err, errlen, "[sim] scene = '%s': unknown scene (available: %s)", c->scene, list);
        }
        if (!sim_trace_init(&a->trace, c->trace, c->seed)) {
            names_list(sim_trace_names(), list, sizeof list);
            return fail(err, errlen, "[sim] trace = '%s': unknown trace (available: %s)", c->trace, list);
        }
        a->trace.head.ipd = c->ipd;
    }

    a->head = warp_head_default();
    a->head.ipd = c->ipd;
    int vw = c->panel_w / 2;
    for (int e = 0; e < 2; e++) {
        a->eye_cam[e] = rt_config_eye_camera(c, e);
        a->lens[e] = rt_config_lens(c, e);
        if (!warp_mesh_init(&a->mesh[e], c->mesh_n, &a->lens[e], e * vw, 0, vw, c->panel_h))
            return fail(err, errlen, "%s%s: cannot allocate the distortion mesh", "[lens] mesh", "");
    }
    /* one shown, one waiting for its vsync, one being drawn; a fourth while a file sink still reads one, or while
     * a pass started by [render] stall_reserve_ms more than a period ahead keeps two out of reach */
    if (!plat_swapchain_init(&a->sc, c->stall_reserve_ms > 0 ? 4 : 3, c->panel_w, c->panel_h))
        return fail(err, errlen, "cannot allocate the swapchain (%s%s)", "[display] width/height", "");
    if (!render_init(a, err, errlen)) return false;
    a->workers = plat_workers_create(c->threads - 1, c->rt_priority);
    if (!a->workers) return fail(err, errlen, "cannot start %s%s", "compositor worker threads", "");
    a->rt_params = warp_raytrace_default_params();
    a->rt_params.max_steps = c->raytrace_steps;
    a->rt_params.edge_fill = (warp_edge_fill)c->edge_fill;
    a->rt_params.edge_jump = (float)c->edge_jump;
    const bool depth_warps = c->method != RT_METHOD_NONE && c->method != RT_METHOD_ROTATION;
    a->can_transparency = c->method == RT_METHOD_TRANSPARENCY || c->method == RT_METHOD_AUTO;
    a->can_objects = c->method == RT_METHOD_OBJECTS || c->method == RT_METHOD_AUTO;
    for (int e = 0; e < 2 && depth_warps; e++) {
        bool ok = warp_image_rgba8_alloc(&a->inter[e], c->eye_w, c->eye_h) &&
                  warp_planar3_alloc(&a->inter_planar[e], c->eye_w, c->eye_h) &&
                  warp_image_u8_alloc(&a->wmask[e], c->eye_w, c->eye_h);
        if (ok && a->can_transparency)
            ok = warp_grid_alloc(&a->grid[e], c->eye_w, c->eye_h, warp_grid_default_params().tile) &&
                 warp_minmax_alloc(&a->abuf[e], c->eye_w, c->eye_h) &&
                 warp_image_f32_alloc(&a->zb[e], c->eye_w, c->eye_h);
        if (ok && a->can_objects) {
            a->objs[e] = calloc(1, sizeof *a->objs[e]);
            ok = a->objs[e] && warp_fwd_scratch_alloc(&a->fwd[e], c->eye_w, c->eye_h, c->eye_w, c->eye_h) &&
                 warp_holes_init(&a->holes[e], c->eye_w, c->eye_h, 12);
        }
        if (!ok) return fail(err, errlen, "cannot allocate %s%s", "the depth warps' buffers", "");
    }
    rt_select_params selp = rt_select_default_params();
    selp.pixel_budget = c->pixel_budget;
    rt_select_init(&a->sel, &selp, &a->eye_cam[0]);

    a->fusion = calloc(1, sizeof *a->fusion);
    a->tel = rt_telemetry_create();
    if (!a->fusion || !a->tel) return fail(err, errlen, "%s%s", "out of memory", "");
    rt_fusion_params fp = rt_fusion_default_params();
    fp.lever_arm = a->head.neck_to_eye; /* the IMU sits between the eyes, on the neck model's lever arm */
    rt_fusion_init(a->fusion, &fp);

    /* Devices. Scene time 0 lies a little in the future, after the simulated headset's rest at boot, so every
     * thread is up and the tracker has learned the gyro bias when the head starts moving. */
    bool imu_simulated = strcmp(c->imu_backend, "sim") == 0 || strcmp(c->imu_device, "mock") == 0;
    a->t0_ns = plat_now_ns() + 50 * PLAT_NS_PER_MS + (imu_simulated ? (int64_t)(c->imu_rest_s * 1e9) : 0);
    if (c->duration_s > 0) a->t_end_ns = a->t0_ns + (int64_t)(c->duration_s * 1e9);
    drv_frames_sim_params sp;
    memset(&sp, 0, sizeof sp);
    sp.scene = a->scene;
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
    if (!rt_devices_open(a, &sp, err, errlen)) return false;
    if (!rt_config_parse_axes(c->imu_axes, a->imu_map, a->imu_sign))
        return fail(err, errlen, "[imu] axes = '%s': %s", c->imu_axes, "expected e.g. '-y +x +z'");
    a->imu_remap = strcmp(c->imu_backend, "sim") != 0 &&
                   !(a->imu_map[0] == 0 && a->imu_map[1] == 1 && a->imu_map[2] == 2 && a->imu_sign[0] > 0 &&
                     a->imu_sign[1] > 0 && a->imu_sign[2] > 0);
    if (!rt_frameq_init(&a->fq, c->eye_w, c->eye_h, drv_frames_planes(a->frames), 4))
        return fail(err, errlen, "cannot allocate %s%s", "the frame slots", "");

    if (a->display) {
        /* the CPU path's KMS output, opened with the renderer */
    } else if (strcmp(c->sink, "null") == 0) {
        a->display = plat_display_null();
    } else {
        char e2[300];
        a->display = plat_display_files(c->sink, c->sink_path, c->sink_every, e2, sizeof e2);
        if (!a->display) return fail(err, errlen, "[display] sink = %s: %s", c->sink, e2);
    }
    if (!a->display) return fail(err, errlen, "%s%s", "out of memory", "");

    if (!rt_ring_init(&a->eval_ring, sizeof(rt_eval_record), 64))
        return fail(err, errlen, "%s%s", "out of memory", "");
    if (c->csv[0]) {
        a->csv = fopen(c->csv, "w");
        if (!a->csv) return fail(err, errlen, "[telemetry] csv = %s: %s", c->csv, strerror(errno));
        a->csv_bytes = (uint64_t)fprintf(a->csv, "%s", CSV_HEADER);
        if (!rt_ring_init(&a->csv_ring, sizeof(rt_csv_row), 8192))
            return fail(err, errlen, "%s%s", "out of memory", "");
    }
    return live_init(a, err, errlen);
}

/* Board mounting: the IMU's axes into the head frame the tracker works in. */
static void remap_axes(const rt_app *a, drv_imu_sample *s)
{
    double g[3], ac[3];
    for (int i = 0; i < 3; i++) {
        g[i] = a->imu_sign[i] * s->gyro[a->imu_map[i]];
        ac[i] = a->imu_sign[i] * s->accel[a->imu_map[i]];
    }
    memcpy(s->gyro, g, sizeof g);
    memcpy(s->accel, ac, sizeof ac);
}

static void *imu_thread(void *arg)
{
    rt_app *a = arg;
    plat_thread_set_name("hmdwarp-imu");
    /* Just below the compositor: late IMU samples are late photons. */
    if (a->cfg.rt_priority > 1) plat_thread_set_realtime(a->cfg.rt_priority - 1);
    drv_imu_sample buf[64];
    bool lost = false;
    while (!atomic_load_explicit(&a->stop, memory_order_relaxed)) {
        int n = drv_imu_read(a->imu, buf, 64, 50);
        if (n < 0) {
            /* Device gone: the display holds the last orientation (RT_IMU_STALE_NS) while the backend retries;
             * read() itself paces the reopen attempts. */
            atomic_fetch_add(&a->tel->imu_read_errors, 1);
            if (!lost) {
                atomic_fetch_add(&a->tel->imu_lost, 1);
                drv_imu_stats ds;
                drv_imu_stats_get(a->imu, &ds);
                plat_log(PLAT_LOG_WARNING, "IMU %s lost (%s): holding the last orientation, retrying",
                        a->imu->name, ds.last_error[0] ? ds.last_error : strerror(-n));
                lost = true;
            }
            plat_sleep_ns(20 * PLAT_NS_PER_MS);
            continue;
        }
        if (lost && n > 0) {
            plat_log(PLAT_LOG_NOTICE, "IMU %s is back", a->imu->name);
            lost = false;
        }
        for (int i = 0; i < n; i++) {
            if (a->imu_remap) remap_axes(a, &buf[i]);
            rt_fusion_update(a->fusion, &buf[i]);
        }
        atomic_fetch_add_explicit(&a->tel->imu_samples, (uint64_t)n, memory_order_relaxed);
    }
    return NULL;
}

/* Everything derived from a frame is computed here, once per host frame, not once per vsync. */
static drv_frame_err prepare_frame(rt_frame *s)
{
    drv_frame_err e = drv_frame_validate(&s->f);
    if (e != DRV_FRAME_OK) return e;
    s->has_depth = (s->f.planes & DRV_PLANE_DEPTH) != 0;
    for (int eye = 0; eye < 2; eye++) {
        if (s->has_depth) {
            long bad = warp_inverse_depth_from(&s->f.cam[eye], s->f.depth_encoding, &s->f.depth[eye],
                                               &s->inv_depth[eye], &s->inv_min[eye], &s->inv_max[eye]);
            if (bad) return DRV_FRAME_ERR_BAD_DEPTH;
            warp_raytrace_blockmax(&s->inv_depth[eye], &s->blockmax[eye], RT_BLOCK);
        }
        warp_planar3_from_rgba_rows(&s->planar[eye], &s->f.color[eye], 0, s->f.color[eye].h);
        /* The host blended its transparent fragments into the colour; the transparency warp moves them on their
         * own, over the surface behind them: recover that once per frame, here, off the vsync path. */
        if ((s->f.planes & DRV_PLANE_LAYERS) && s->opaque[eye].px)
            warp_transparency_unblend(&s->f.color[eye], &s->f.layers[eye], &s->opaque[eye]);
    }
    return DRV_FRAME_OK;
}

/* What a frame's dense planes hold: about what the host link carried for it (the link's MB/s), less framing and
 * compression. The A-buffer's fragments are left out: counting them would walk every pixel's count again. */
static uint64_t frame_bytes(const drv_frame *f)
{
    uint64_t px = 0, b = 0;
    for (int e = 0; e < 2; e++) px += (uint64_t)f->color[e].w * (uint64_t)f->color[e].h;
    if (f->planes & DRV_PLANE_COLOR) b += px * 4;
    if (f->planes & DRV_PLANE_DEPTH) b += px * 4;
    if (f->planes & DRV_PLANE_IDS) b += px * 2;
    if (f->planes & DRV_PLANE_MOTION) b += px * 8;
    if (f->planes & DRV_PLANE_LAYERS) b += px; /* the per-pixel fragment counts */
    return b;
}

static void *frames_thread(void *arg)
{
    rt_app *a = arg;
    plat_thread_set_name("hmdwarp-frames");
    /* The log (this thread may do I/O; the vsync thread never does): each kind of rejection at once, then at most
     * one line a second; a host that goes quiet, and when it is back. */
    int64_t last_ok = plat_now_ns(), last_log = 0;
    bool quiet = false, seen_ok = false;
    uint64_t logged[DRV_FRAME_ERR_COUNT] = {0};
    while (!atomic_load_explicit(&a->stop, memory_order_relaxed)) {
        rt_frame *slot = rt_frameq_back(&a->fq);
        int rc = drv_frames_receive(a->frames, &slot->f, 50);
        int64_t now = plat_now_ns();
        if (rc == 0) {
            if (seen_ok && !quiet && now - last_ok > PLAT_NS_PER_S) {
                plat_log(PLAT_LOG_WARNING, "no host frame for %.1f s: warping the last good frame",
                        (double)(now - last_ok) * 1e-9);
                quiet = true;
            }
            continue;
        }
        drv_frame_err e = rc < 0 ? (drv_frame_err)(-rc) : prepare_frame(slot);
        if (e != DRV_FRAME_OK) {
            /* Rejected: counted, and the compositor keeps warping the last good frame. */
            if (e < 0 || e >= DRV_FRAME_ERR_COUNT) e = DRV_FRAME_ERR_IO;
            uint64_t n = atomic_fetch_add(&a->tel->frames_rejected[e], 1) + 1;
            if (!logged[e] || now - last_log > PLAT_NS_PER_S) {
                char why[200];
                drv_frames_last_error(a->frames, why, sizeof why);
                plat_log(PLAT_LOG_WARNING, "host frame rejected (%s, %llu so far)%s%s; the last good frame stays",
                        drv_frame_err_str(e), (unsigned long long)n, why[0] ? ": " : "", why);
                logged[e] = n;
                last_log = now;
            }
            continue;
        }
        if (quiet)
            plat_log(PLAT_LOG_NOTICE, "host frames are back after %.1f s", (double)(now - last_ok) * 1e-9);
        quiet = false;
        seen_ok = true;
        last_ok = now;
        /* A host that cannot place its render start on the board's clock sends 0. */
        if (slot->f.render_start_ns)
            rt_hist_add(&a->tel->host_render_ms, (double)(slot->f.received_ns - slot->f.render_start_ns) * 1e-6);
        /* Through a mock the simulated host's scene time is not on the wire: it is the pose time on the
         * simulated board's clock, which is what the accuracy evaluator re-renders. */
        if (a->has_truth && !a->sim_host) slot->f.scene_time = (double)(slot->f.pose_t_ns - a->t0_ns) * 1e-9;
        atomic_fetch_add(&a->tel->frames_received, 1);
        atomic_fetch_add_explicit(&a->tel->frames_bytes, frame_bytes(&slot->f), memory_order_relaxed);
        rt_frameq_publish(&a->fq);
    }
    return NULL;
}

/* [telemetry] csv_max_mb: the full file becomes FILE.1 (replacing the one before) and FILE starts again with its
 * header. freopen keeps the FILE pointer, which the compositor tests (a->csv) to decide whether to queue rows. */
static void rotate_csv(rt_app *a)
{
    const char *path = a->cfg.csv;
    char old[300];
    snprintf(old, sizeof old, "%s.1", path);
    fflush(a->csv);
    if (rename(path, old) != 0)
        plat_log(PLAT_LOG_WARNING, "[telemetry] csv = %s: cannot rotate to %s (%s): starting it again", path, old,
                 strerror(errno));
    if (!freopen(path, "w", a->csv)) {
        plat_log(PLAT_LOG_ERR, "[telemetry] csv = %s: cannot reopen (%s): no more CSV rows this run", path,
                 strerror(errno));
        a->csv_dead = true; /* freopen closed the stream */
        return;
    }
    a->csv_bytes = (uint64_t)fprintf(a->csv, "%s", CSV_HEADER);
}

static void drain_csv(rt_app *a)
{
    rt_csv_row r;
    const uint64_t max = (uint64_t)(a->cfg.csv_max_mb * 1024 * 1024);
    while (rt_ring_pop(&a->csv_ring, &r)) {
        if (a->csv_dead) continue;
        int n = fprintf(a->csv, "%llu,%lld,%llu,%s,%.3f,%d,%.3f,%.3f\n", (unsigned long long)r.vsync_no,
                        (long long)r.vsync_ns, (unsigned long long)r.frame_seq, rt_method_name((rt_method)r.method),
                        r.warp_ms, r.missed, r.m2p_ms, r.frame_age_ms);
        if (n > 0) a->csv_bytes += (uint64_t)n;
        if (max && a->csv_bytes >= max) rotate_csv(a);
    }
}

/* State the helper thread keeps from one live update to the next (rates are differences over the second). */
typedef struct {
    int64_t t_ns;
    uint64_t vsyncs, frames, bytes;
    bool write_failed; /* said once, not every second */
} live_prev;

/* The key=value text into the buffer not published, then published: the abort handler may read the other one
 * at any moment. fmemopen over the fixed buffer: nothing allocated per update but the FILE. */
static size_t live_render(rt_app *a, bool live)
{
    int pub = atomic_load(&a->live_pub);
    int next = pub == 0 ? 1 : 0;
    FILE *f = fmemopen(a->live_buf[next], LIVE_BUF_BYTES, "w");
    if (!f) return 0;
    stats_kv(a, f, live);
    long n = ftell(f);
    fclose(f);
    if (n <= 0) return 0;
    if (n >= LIVE_BUF_BYTES) n = LIVE_BUF_BYTES - 1;
    atomic_store(&a->live_len[next], (size_t)n);
    atomic_store(&a->live_pub, next);
    return (size_t)n;
}

/* Rewritten whole and renamed into place: a reader sees the last complete second or the one before, never half. */
static bool live_write_file(rt_app *a, const char *text, size_t len)
{
    char tmp[300];
    snprintf(tmp, sizeof tmp, "%s.tmp", a->live_path);
    int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) return false;
    size_t off = 0;
    while (off < len) {
        ssize_t w = write(fd, text + off, len - off);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) break;
        off += (size_t)w;
    }
    bool ok = off == len && close(fd) == 0;
    if (off != len) close(fd);
    if (ok && rename(tmp, a->live_path) == 0) return true;
    unlink(tmp);
    return false;
}

/* Once a second: the stats text (file and abort handler) and systemd's STATUS line. The STATUS percentiles are
 * over the last second; the file's, like --stats, over the whole run. */
static void live_update(rt_app *a, live_prev *p, bool notify)
{
    const rt_telemetry *t = a->tel;
    size_t len = live_render(a, true);
    if (a->live_path[0] && len) {
        int pub = atomic_load(&a->live_pub);
        bool ok = live_write_file(a, a->live_buf[pub], len);
        if (!ok && !p->write_failed)
            plat_log(PLAT_LOG_WARNING, "[telemetry] live_stats = %s: cannot write (%s); retrying each second",
                     a->live_path, strerror(errno));
        if (ok && p->write_failed) plat_log(PLAT_LOG_NOTICE, "[telemetry] live_stats = %s: written again", a->live_path);
        p->write_failed = !ok;
    }
    int64_t now = plat_now_ns();
    uint64_t v = t->vsyncs, fr = t->frames_received, by = t->frames_bytes;
    double dt = p->t_ns ? (double)(now - p->t_ns) * 1e-9 : 0;
    double m2p = rt_hist_pct_since(&t->m2p_ms, a->live_m2p, 99);
    double age = rt_hist_pct_since(&t->frame_age_ms, a->live_age, 50);
    if (notify && dt > 0)
        sd_notifyf(0,
                   "STATUS=%.1f vsyncs/s, %llu vsyncs, missed %llu (own %llu, woken late %llu, descheduled %llu, "
                   "no free image %llu); last second: m2p p99 %.1f ms, frame age p50 %.1f ms; link %.1f MB/s, "
                   "%.1f frames/s",
                   (double)(v - p->vsyncs) / dt, (unsigned long long)v, (unsigned long long)t->missed,
                   (unsigned long long)t->missed_by[RT_MISS_OWN], (unsigned long long)t->missed_by[RT_MISS_LATE_WAKE],
                   (unsigned long long)t->missed_by[RT_MISS_DESCHEDULED],
                   (unsigned long long)t->missed_by[RT_MISS_NO_BUFFER], m2p, age,
                   (double)(by - p->bytes) / dt / (1024 * 1024), (double)(fr - p->frames) / dt);
    p->t_ns = now;
    p->vsyncs = v;
    p->frames = fr;
    p->bytes = by;
}

bool rt_app_write_last_stats(rt_app *a, int fd)
{
    int pub = atomic_load(&a->live_pub);
    if (pub < 0 || !a->live_buf[pub]) return false;
    size_t len = atomic_load(&a->live_len[pub]), off = 0;
    while (off < len) {
        ssize_t w = write(fd, a->live_buf[pub] + off, len - off);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) return false;
        off += (size_t)w;
    }
    return true;
}

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
    live_prev lp = {0};
    live_update(a, &lp, false); /* marks and rates start now; the abort handler has something from the start */
    while (!atomic_load(&a->stop)) {
        if (a->csv) drain_csv(a);
        if (plat_now_ns() >= next_live) {
            live_update(a, &lp, notify);
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
    if (a->csv) drain_csv(a);
    return NULL;
}

/* The last word of the live file once every thread has stopped: what --stats says (running=0), so hmdwarp-top
 * shows the end. */
static void live_final(rt_app *a)
{
    size_t len = live_render(a, false);
    if (a->live_path[0] && len && !live_write_file(a, a->live_buf[atomic_load(&a->live_pub)], len))
        plat_log(PLAT_LOG_WARNING, "[telemetry] live_stats = %s: cannot write (%s)", a->live_path, strerror(errno));
}

void rt_app_request_stop(rt_app *a) { atomic_store(&a->stop, 1); }

void rt_app_run(rt_app *a)
{
    pthread_t eval_th;
    bool eval_up = a->has_truth && a->cfg.eval_every_ms > 0 && pthread_create(&eval_th, NULL, rt_eval_thread, a) == 0;
    a->run_start_ns = plat_now_ns();
    a->th_imu_up = pthread_create(&a->th_imu, NULL, imu_thread, a) == 0;
    a->th_frames_up = pthread_create(&a->th_frames, NULL, frames_thread, a) == 0;
    a->th_aux_up = pthread_create(&a->th_aux, NULL, aux_thread, a) == 0;
    plat_thread_set_name("hmdwarp-vsync");
    a->realtime = a->cfg.rt_priority > 0 && plat_thread_set_realtime(a->cfg.rt_priority);
    /* Everything is allocated by now; keep it resident so no page fault lands on the vsync path. */
    if (a->realtime) a->memory_locked = plat_lock_memory();
    rt_compositor_run(a);
    int64_t end = plat_now_ns(); /* stored once the helper thread, which reads it, has stopped */
    atomic_store(&a->stop, 1);
    if (a->th_imu_up) pthread_join(a->th_imu, NULL);
    if (a->th_frames_up) pthread_join(a->th_frames, NULL);
    if (a->th_aux_up) pthread_join(a->th_aux, NULL);
    if (eval_up) pthread_join(eval_th, NULL);
    a->run_end_ns = end;
    plat_display_flush(a->display);
    if (a->sim_host) {
        drv_frames_sim_stats st;
        drv_frames_sim_stats_get(a->frames, &st);
        a->sim_frames = st.frames;
        memcpy(a->sim_plane_renders, st.plane_renders, sizeof st.plane_renders);
    }
    live_final(a);
}

static void pct_line(FILE *out, const char *label, const rt_hist *h)
{
    if (!h->count)
        fprintf(out, "  %-26s -\n", label);
    else
        fprintf(out, "  %-26s p50 %6.2f ms   p99 %6.2f ms   max %6.2f ms   (%llu)\n", label, rt_hist_pct(h, 50),
                rt_hist_pct(h, 99), h->max, (unsigned long long)h->count);
}

void rt_app_summary(rt_app *a, FILE *out)
{
    const rt_config *c = &a->cfg;
    const rt_telemetry *t = a->tel;
    char buf[400];
    double secs = (double)t->vsyncs / c->refresh_hz;
    fprintf(out, "\nhmdwarpd %s summary — board '%s', scene '%s', head motion '%s', %.1f s\n", plat_version(),
            c->board_name, c->scene, c->trace, secs);
    if (a->use_gles)
        fprintf(out, "  renderer                   gles: %s (%s; %s), warp method %s\n", plat_egl_renderer(a->egl),
                plat_egl_version(a->egl), a->realtime ? "SCHED_FIFO" : "normal priority", rt_method_name(c->method));
    else
        fprintf(out, "  renderer                   cpu (%s kernel, %d threads, %s%s), warp method %s\n",
                warp_resample_kernel(), plat_workers_threads(a->workers),
                a->realtime           ? "SCHED_FIFO"
                : c->rt_priority == 0 ? "normal priority (rt_priority = 0)"
                                      : "normal priority (not permitted to use SCHED_FIFO)",
                a->realtime ? (a->memory_locked ? ", memory locked" : ", memory not locked") : "",
                rt_method_name(c->method));
    fprintf(out, "  renderer chosen            %s\n", a->render_why);
    fprintf(out, "  panel                      %dx%d at %.0f Hz, eye buffers %dx%d, lens mesh %dx%d\n", c->panel_w,
            c->panel_h, c->refresh_hz, c->eye_w, c->eye_h, c->mesh_n, c->mesh_n);
    fprintf(out, "display\n");
    fprintf(out, "  vsyncs                     %llu, missed %llu (%.2f %%)%s\n", (unsigned long long)t->vsyncs,
            (unsigned long long)t->missed, t->vsyncs ? 100.0 * (double)t->missed / (double)t->vsyncs : 0.0,
            t->no_buffer ? " (some with no free swapchain image)" : "");
    if (t->missed)
        fprintf(out, "  missed, why                own %llu (the warp outran its planned time), scheduler: woken late "
                     "%llu, descheduled %llu; no free image %llu\n",
                (unsigned long long)t->missed_by[RT_MISS_OWN], (unsigned long long)t->missed_by[RT_MISS_LATE_WAKE],
                (unsigned long long)t->missed_by[RT_MISS_DESCHEDULED], (unsigned long long)t->missed_by[RT_MISS_NO_BUFFER]);
    uint64_t missed_by[RT_MISS_COUNT];
    for (int m = 0; m < RT_MISS_COUNT; m++) missed_by[m] = t->missed_by[m];
    rt_miss_advice(missed_by, a->use_gles, a->gles_software, buf, sizeof buf);
    if (buf[0]) fprintf(out, "  misses, what to do         %s\n", buf);
    for (int m = 0; m < RT_METHOD_COUNT; m++)
        if (t->method_count[m]) {
            snprintf(buf, sizeof buf, "warp time (%s)", rt_method_name((rt_method)m));
            pct_line(out, buf, &t->warp_ms[m]);
        }
    if (a->use_gles) {
        fprintf(out, "  GPU time per pass          %s, depth pyramid on the %s%s\n", plat_gles_timing_method(a->gles),
                plat_gles_gpu_pyramid(a->gles) ? "GPU" : "CPU", a->gles_depth ? "" : " (not used)");
        for (int p = 0; p < PLAT_GLES_PASSES; p++)
            if (a->gles_ms[p].count) {
                snprintf(buf, sizeof buf, "  gles %s", plat_gles_pass_name((plat_gles_pass)p));
                pct_line(out, buf, &a->gles_ms[p]);
            }
        if (a->gles_errors)
            fprintf(out, "  GLES errors                %llu; last: %s\n", (unsigned long long)a->gles_errors,
                    a->gles_last_error);
    }
    if (a->kms) {
        plat_kms_stats ks;
        plat_kms_stats_get(a->kms, &ks);
        fprintf(out, "  KMS output                 %s %dx%d@%.0f, %s, %s: %llu page flips, %llu failed, %llu late%s%s\n",
                ks.connector, ks.w, ks.h, ks.hz, ks.api, ks.format, (unsigned long long)ks.flips,
                (unsigned long long)ks.failed, (unsigned long long)ks.late, ks.last_error[0] ? "; last: " : "",
                ks.last_error);
    }
    if (a->raytrace_fallbacks)
        fprintf(out, "  raytrace fallbacks         %llu vsyncs used rotation: the frame had no depth\n",
                (unsigned long long)a->raytrace_fallbacks);
    if (a->plane_fallbacks)
        fprintf(out, "  depth-warp fallbacks       %llu vsyncs used the raytrace: the frame lacked layers or ids\n",
                (unsigned long long)a->plane_fallbacks);
    if (c->method == RT_METHOD_AUTO) {
        fprintf(out, "  warp selection (auto)      budget %.2f px (004 eqs. 5-7 bound of ignoring translation); why:\n",
                c->pixel_budget);
        for (int w = 0; w < RT_WHY_COUNT; w++)
            if (t->select_why[w])
                fprintf(out, "    %-24s %llu vsyncs\n", rt_select_why_str((rt_select_why)w),
                        (unsigned long long)t->select_why[w]);
    }
    drv_vsync_stats vs;
    if (drv_vsync_stats_get(a->vsync, &vs))
        fprintf(out, "  vsync source               %s: edges %llu, spurious %llu, missed %llu, timer fallbacks %llu%s, "
                     "period %.3f ms, jitter %.0f us%s%s\n",
                a->vsync->name, (unsigned long long)vs.edges, (unsigned long long)vs.spurious,
                (unsigned long long)vs.missed, (unsigned long long)vs.fallbacks, vs.on_timer ? " (on timer now)" : "",
                (double)vs.period_ns * 1e-6, vs.jitter_us, vs.last_error[0] ? "; last: " : "", vs.last_error);
    pct_line(out, "motion-to-photon", &t->m2p_ms);
    if (c->stall_reserve_ms > 0)
        fprintf(out, "  stall reserve              %.1f ms of the motion-to-photon latency: passes start that much earlier "
                     "([render] stall_reserve_ms)%s\n",
                c->stall_reserve_ms, a->use_gles ? "; on the GLES path only what fits in a period" : "");
    pct_line(out, "frame age at photon time", &t->frame_age_ms);
    a->display->describe(a->display, buf, sizeof buf);
    fprintf(out, "  output                     %s\n", buf);
    fprintf(out, "host frames\n");
    uint64_t rejected = 0;
    for (int e = 1; e < DRV_FRAME_ERR_COUNT; e++) rejected += t->frames_rejected[e];
    fprintf(out, "  received                   %llu (%.1f Hz), shown %llu, dropped unseen %llu, rejected %llu\n",
            (unsigned long long)t->frames_received,
            secs + c->imu_rest_s > 0 ? (double)t->frames_received / (secs + c->imu_rest_s) : 0.0,
            (unsigned long long)t->new_frames_shown, (unsigned long long)t->frames_dropped,
            (unsigned long long)rejected);
    for (int e = 1; e < DRV_FRAME_ERR_COUNT; e++)
        if (t->frames_rejected[e])
            fprintf(out, "    rejected as %-13s %llu\n", drv_frame_err_str((drv_frame_err)e),
                    (unsigned long long)t->frames_rejected[e]);
    pct_line(out, "host render + transport", &t->host_render_ms);
    if (a->sim_host) {
        static const char *const plane_names[5] = {"color", "depth", "ids", "motion", "layers"};
        buf[0] = 0;
        for (int p = 0; p < 5; p++) {
            char one[48];
            snprintf(one, sizeof one, "%s%s %llu", p ? ", " : "", plane_names[p],
                     (unsigned long long)a->sim_plane_renders[p]);
            strncat(buf, one, sizeof buf - strlen(buf) - 1);
        }
        char fx[160];
        fprintf(out, "  planes rendered            %s (scene effects: %s)\n", buf,
                sim_effects_str(sim_scene_effects(a->scene), fx, sizeof fx));
    }
    fprintf(out, "tracking\n");
    fprintf(out, "  IMU samples                %llu (%.0f Hz, incl. the rest at boot), rejected %llu, read errors %llu\n",
            (unsigned long long)t->imu_samples,
            secs + c->imu_rest_s > 0 ? (double)t->imu_samples / (secs + c->imu_rest_s) : 0.0,
            (unsigned long long)(rt_fusion_rejected(a->fusion, RT_FUSION_BAD_VALUE) +
                                 rt_fusion_rejected(a->fusion, RT_FUSION_TIME_REPEAT) +
                                 rt_fusion_rejected(a->fusion, RT_FUSION_TIME_JUMP)),
            (unsigned long long)t->imu_read_errors);
    drv_imu_stats is;
    if (drv_imu_stats_get(a->imu, &is))
        fprintf(out, "  IMU device                 %s: %s, reports %llu, bad %llu, read errors %llu, reconnects %llu%s%s\n",
                a->imu->name, is.connected ? "connected" : "NOT connected", (unsigned long long)is.reports,
                (unsigned long long)is.bad_reports, (unsigned long long)is.read_errors,
                (unsigned long long)is.reconnects, is.last_error[0] ? "; last: " : "", is.last_error);
    if (t->imu_lost || t->imu_stale)
        fprintf(out, "  IMU lost                   %llu times; %llu vsyncs held the last orientation\n",
                (unsigned long long)t->imu_lost, (unsigned long long)t->imu_stale);
    rt_fusion_state st;
    if (a->has_truth && rt_fusion_latest(a->fusion, &st)) {
        double ts = (double)(st.t_ns - a->t0_ns) * 1e-9;
        warp_quat truth = sim_trace_orientation(&a->trace, ts);
        fprintf(out, "  orientation error at end   %.3f deg (gyro bias estimate %.4f %.4f %.4f rad/s)\n",
                warp_quat_angle_between(truth, st.q) * 180 / WARP_PI, st.bias.x, st.bias.y, st.bias.z);
    }
    if (a->has_truth && c->eval_every_ms > 0) {
        fprintf(out, "accuracy vs ground truth     left eye at photon time, before the lens; %d frames sampled\n",
                a->eval[RT_EVAL_NONE].n);
        const rt_eval_pose *pe = &a->eval_pose;
        if (pe->n)
            fprintf(out, "  pose error at photon time  mean %.3f deg / %.2f mm, max %.3f deg / %.2f mm "
                         "(prediction and tracking; no warp can fix it)\n",
                    pe->angle_sum / pe->n, pe->pos_sum / pe->n, pe->angle_max, pe->pos_max);
        fprintf(out, "  %-26s %9s %9s %8s %12s\n", "method", "PSNR dB", "min dB", "SSIM", "error px %");
        static const char *const names[RT_EVAL_METHODS] = {"no warp", "rotation (003 §3.4)", "raytrace (003 §3.5)",
                                                              "raytrace at mesh vertices"};
        for (int m = 0; m < RT_EVAL_METHODS; m++) {
            const rt_eval_acc *e = &a->eval[m];
            if (!e->n) continue;
            /* printf pads by bytes: widen by the UTF-8 continuation bytes (the "§") so the columns line up */
            int wide = 26;
            for (const char *p = names[m]; *p; p++) wide += ((unsigned char)*p & 0xc0) == 0x80;
            fprintf(out, "  %-*s %9.2f %9.2f %8.4f %12.3f\n", wide, names[m], e->psnr_sum / e->n, e->psnr_min,
                    e->ssim_sum / e->n, e->err_sum / e->n);
        }
    }
    if (a->csv) fprintf(out, "per-vsync CSV                %s\n", c->csv);
}

void rt_app_stats_kv(rt_app *a, FILE *out) { stats_kv(a, out, false); }

/* live: while the run goes on (the helper thread), leaving out what another thread accumulates unpublished until
 * the end (the accuracy evaluator's sums). */
static void stats_kv(rt_app *a, FILE *out, bool live)
{
    const rt_config *c = &a->cfg;
    const rt_telemetry *t = a->tel;
#define KV(k, fmt, v) fprintf(out, "%s=" fmt "\n", k, v)
#define KVU(k, v) KV(k, "%llu", (unsigned long long)(v))
    KV("version", "%s", plat_version());
    KV("running", "%d", live);
    {
        /* since the display started (after the simulated IMU's rest) until it stopped (not the accuracy
         * evaluation catching up afterwards): the span the vsync counts cover */
        int64_t since = a->run_start_ns ? (a->run_end_ns ? a->run_end_ns : plat_now_ns()) - a->t0_ns : 0;
        KV("run_s", "%.1f", since > 0 ? (double)since * 1e-9 : 0.0);
    }
    KV("board", "%s", c->board_name);
    KV("imu_backend", "%s", a->imu ? a->imu->name : "");
    KV("frames_backend", "%s", a->frames ? a->frames->name : "");
    KV("vsync_backend", "%s", a->vsync ? a->vsync->name : "");
    KV("renderer", "%s", a->use_gles ? "gles" : "cpu");
    KV("gl_renderer", "%s", a->use_gles ? plat_egl_renderer(a->egl) : "");
    KV("renderer_reason", "%s", a->render_why);
    KV("display_output", "%s", a->kms ? "kms" : "offscreen");
    {
        /* always present (zeros offscreen), so scripts need not test for the keys */
        plat_kms_stats ks = {.api = "", .format = ""};
        if (a->kms) plat_kms_stats_get(a->kms, &ks);
        KVU("kms_flips", ks.flips);
        KVU("kms_flips_failed", ks.failed);
        KVU("kms_flips_late", ks.late);
        KVU("kms_vblanks", ks.vblanks);
        KV("kms_api", "%s", ks.api);
        KV("kms_format", "%s", ks.format);
    }
    if (a->use_gles) {
        for (int p = 0; p < PLAT_GLES_PASSES; p++) {
            char k[64];
            snprintf(k, sizeof k, "gles_%s_ms_p50", plat_gles_pass_name((plat_gles_pass)p));
            KV(k, "%.3f", rt_hist_pct(&a->gles_ms[p], 50));
            snprintf(k, sizeof k, "gles_%s_ms_p99", plat_gles_pass_name((plat_gles_pass)p));
            KV(k, "%.3f", rt_hist_pct(&a->gles_ms[p], 99));
        }
        KVU("gles_errors", a->gles_errors);
    }
    KVU("vsyncs", t->vsyncs);
    KVU("missed", t->missed);
    for (int m = 0; m < RT_MISS_COUNT; m++) {
        char k[64];
        snprintf(k, sizeof k, "missed_%s", rt_miss_name((rt_miss)m));
        KVU(k, t->missed_by[m]);
    }
    KVU("no_frame", t->no_frame);
    KVU("no_buffer", t->no_buffer);
    for (int m = 0; m < RT_METHOD_COUNT; m++) {
        char k[64];
        snprintf(k, sizeof k, "method_%s", rt_method_name((rt_method)m));
        KVU(k, t->method_count[m]);
    }
    KV("warp_ms_p50", "%.3f", rt_hist_pct(&t->warp_ms[c->method], 50));
    KV("warp_ms_p99", "%.3f", rt_hist_pct(&t->warp_ms[c->method], 99));
    KV("stall_reserve_ms", "%.3f", c->stall_reserve_ms);
    KV("m2p_ms_p50", "%.3f", rt_hist_pct(&t->m2p_ms, 50));
    KV("m2p_ms_p99", "%.3f", rt_hist_pct(&t->m2p_ms, 99));
    KV("frame_age_ms_p50", "%.3f", rt_hist_pct(&t->frame_age_ms, 50));
    KV("frame_age_ms_max", "%.3f", rt_hist_pct(&t->frame_age_ms, 100));
    for (int w = 0; w < RT_WHY_COUNT; w++) {
        char k[64];
        snprintf(k, sizeof k, "select_%s", rt_select_why_key((rt_select_why)w));
        KVU(k, t->select_why[w]);
    }
    KVU("method_switches", t->method_switches);
    KVU("frames_received", t->frames_received);
    KVU("frames_bytes", t->frames_bytes);
    KVU("frames_shown", t->new_frames_shown);
    KVU("frames_dropped", t->frames_dropped);
    uint64_t rejected = 0;
    for (int e = 1; e < DRV_FRAME_ERR_COUNT; e++) {
        char k[64];
        snprintf(k, sizeof k, "frames_rejected_%s", drv_frame_err_str((drv_frame_err)e));
        for (char *p = k; *p; p++) /* "I/O error" -> i_o_error: shell-friendly keys */
            *p = isalnum((unsigned char)*p) ? (char)tolower((unsigned char)*p) : '_';
        KVU(k, t->frames_rejected[e]);
        rejected += t->frames_rejected[e];
    }
    KVU("frames_rejected", rejected);
    KVU("imu_samples", t->imu_samples);
    KVU("imu_read_errors", t->imu_read_errors);
    KVU("imu_lost", t->imu_lost);
    KVU("imu_stale_vsyncs", t->imu_stale);
    drv_imu_stats is;
    if (a->imu && drv_imu_stats_get(a->imu, &is)) {
        KVU("imu_reports", is.reports);
        KVU("imu_bad_reports", is.bad_reports);
        KVU("imu_reconnects", is.reconnects);
        KV("imu_connected", "%d", is.connected);
    }
    drv_vsync_stats vs;
    if (a->vsync && drv_vsync_stats_get(a->vsync, &vs)) {
        KVU("vsync_edges", vs.edges);
        KVU("vsync_spurious", vs.spurious);
        KVU("vsync_missed_edges", vs.missed);
        KVU("vsync_fallbacks", vs.fallbacks);
        KV("vsync_on_timer", "%d", vs.on_timer);
        KV("vsync_period_ns", "%lld", (long long)vs.period_ns);
        KV("vsync_jitter_us", "%.1f", vs.jitter_us);
    }
    rt_fusion_state st;
    if (rt_fusion_latest(a->fusion, &st)) {
        KV("orientation_w", "%.6f", st.q.w);
        KV("orientation_x", "%.6f", st.q.x);
        KV("orientation_y", "%.6f", st.q.y);
        KV("orientation_z", "%.6f", st.q.z);
        if (a->has_truth) {
            warp_quat truth = sim_trace_orientation(&a->trace, (double)(st.t_ns - a->t0_ns) * 1e-9);
            KV("orientation_error_deg", "%.4f", warp_quat_angle_between(truth, st.q) * 180 / WARP_PI);
        }
    }
    for (int m = 0; m < RT_EVAL_METHODS && !live; m++)
        if (a->eval[m].n) {
            char k[64];
            snprintf(k, sizeof k, "psnr_%s", rt_method_name(rt_eval_methods[m]));
            KV(k, "%.3f", a->eval[m].psnr_sum / a->eval[m].n);
            snprintf(k, sizeof k, "ssim_%s", rt_method_name(rt_eval_methods[m]));
            KV(k, "%.5f", a->eval[m].ssim_sum / a->eval[m].n);
        }
#undef KV
#undef KVU
}

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
    drv_imu_destroy(a->imu);
    drv_frames_destroy(a->frames);
    drv_vsync_destroy(a->vsync);
    plat_display_destroy(a->display);
    if (a->gles && plat_egl_make_current(a->egl)) plat_gles_destroy(a->gles);
    plat_egl_close(a->egl);
    free(a->gles_ms);
    if (a->workers) plat_workers_destroy(a->workers);
    for (int e = 0; e < 2; e++) {
        warp_mesh_free(&a->mesh[e]);
        warp_image_free(&a->inter[e]);
        warp_planar3_free(&a->inter_planar[e]);
        warp_image_free(&a->wmask[e]);
        warp_image_free(&a->zb[e]);
        if (a->grid[e].w) warp_grid_free(&a->grid[e]);
        warp_minmax_free(&a->abuf[e]);
        warp_fwd_scratch_free(&a->fwd[e]);
        if (a->objs[e]) warp_holes_free(&a->holes[e]);
        free(a->objs[e]);
    }
    plat_swapchain_free(&a->sc);
    rt_frameq_free(&a->fq);
    rt_ring_free(&a->eval_ring);
    rt_ring_free(&a->csv_ring);
    if (a->csv && !a->csv_dead) fclose(a->csv);
    free(a->live_buf[0]);
    free(a->live_buf[1]);
    free(a->live_m2p);
    free(a->live_age);
    free(a->fusion);
    rt_telemetry_destroy(a->tel);
    memset(a, 0, sizeof *a);
}
