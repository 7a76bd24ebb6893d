/* SPDX-License-Identifier: MIT */
/* rt_devices: the devices of a run as one part: the IMU, host-frame and vsync backends board.ini names (real or
 * mock), the display output and the IMU's mounting, opened with one clear error; and the threads that read them. */
#include <stdio.h>
#include <string.h>

#include "drivers/drv_frames_socket.h"
#include "drivers/drv_frames_usb.h"
#include "drivers/drv_frames_usb_mock.h"
#include "drivers/drv_frames_v4l2_mock.h"
#include "drivers/drv_imu_hid_mock.h"
#include "drivers/drv_imu_i2c_mock.h"
#include "drivers/drv_sim.h"
#include "drivers/drv_vsync_gpio_mock.h"
#include "drivers/drv_vsync_kms.h"
#include "drivers/drv_vsync_timer.h"
#include "platform/plat_clock.h"
#include "platform/plat_log.h"
#include "runtime/rt_devices.h"
#include "warp/warp_err.h"
#include "warp/warp_fov.h"

static bool is_mock(const char *dev) { return strcmp(dev, "mock") == 0; }

/* Run time (from scene time 0) in the mocks' fault schedules, which count from their own start. */
static double since_start(const drv_frames_sim_params *sp, double run_s)
{
    return run_s > 0 ? run_s + (double)(sp->t0_ns - plat_now_ns()) * 1e-9 : 0;
}

static drv_imu *sim_imu(const rt_config *c, const sim_trace *trace, const drv_frames_sim_params *sp)
{
    sim_imu_params ip = sim_imu_default_params();
    ip.rate_hz = c->imu_rate_hz;
    ip.gyro_noise = c->gyro_noise;
    ip.gyro_bias = warp_v3(c->gyro_bias[0], c->gyro_bias[1], c->gyro_bias[2]);
    ip.accel_noise = c->accel_noise;
    ip.seed = c->seed;
    ip.t_start = -c->imu_rest_s;
    return drv_imu_sim_create(trace, &ip, sp->t0_ns);
}

static bool open_imu(rt_devices *d, const rt_config *c, const sim_trace *trace, const drv_frames_sim_params *sp,
                     char *err, int errlen)
{
    char e[256] = "";
    bool mock = is_mock(c->imu_device);
    if (strcmp(c->imu_backend, "sim") == 0) {
        d->imu = sim_imu(c, trace, sp);
    } else if (strcmp(c->imu_backend, "hid") == 0) {
        if (mock) {
            drv_imu_hid_mock_params mp;
            memset(&mp, 0, sizeof mp);
            mp.counter_start = 0xFFFFFFFFu - 3000000u; /* rolls over 3 s in */
            mp.samples_per_report = 2;
            mp.unplug_at_s = since_start(sp, c->mock_imu_unplug_at_s);
            mp.unplug_for_s = c->mock_imu_unplug_for_s;
            mp.corrupt_every = c->mock_corrupt_every;
            drv_imu *src = sim_imu(c, trace, sp);
            d->imu = src ? drv_imu_hid_create_mock(src, &mp) : NULL;
        } else {
            drv_imu_hid_params p;
            memset(&p, 0, sizeof p);
            snprintf(p.device, sizeof p.device, "%s", c->imu_device);
            p.rate_hz = c->imu_rate_hz;
            d->imu = drv_imu_hid_create(&p, e, sizeof e);
        }
    } else if (strcmp(c->imu_backend, "i2c") == 0) {
        drv_imu_i2c_params p;
        memset(&p, 0, sizeof p);
        snprintf(p.bus, sizeof p.bus, "%s", c->imu_device);
        p.addr = c->imu_address;
        snprintf(p.chip, sizeof p.chip, "%s", c->imu_chip);
        p.rate_hz = c->imu_rate_hz;
        p.gyro_dps = c->imu_gyro_dps;
        p.accel_g = c->imu_accel_g;
        if (mock) {
            if (strcmp(p.chip, "auto") == 0) snprintf(p.chip, sizeof p.chip, "icm42688");
            drv_imu *src = sim_imu(c, trace, sp);
            d->imu = src ? drv_imu_i2c_create_mock(src, &p, e, sizeof e) : NULL;
        } else {
            d->imu = drv_imu_i2c_create(&p, e, sizeof e);
        }
    }
    if (!d->imu) {
        return warp_err(err, errlen, "[imu] backend = %s, device = %s: %s", c->imu_backend,
                        c->imu_device[0] ? c->imu_device : "(none)", e[0] ? e : "cannot open");
    }
    return true;
}

static bool open_vsync(rt_devices *d, const rt_config *c, const drv_frames_sim_params *sp, char *err, int errlen)
{
    char e[256] = "";
    if (strcmp(c->vsync_backend, "sim") == 0) {
        d->vsync = drv_vsync_sim_create(c->refresh_hz, sp->t0_ns);
    } else if (strcmp(c->vsync_backend, "timer") == 0) {
        d->vsync = drv_vsync_timer_create(c->refresh_hz);
    } else if (strcmp(c->vsync_backend, "kms") == 0) {
        /* the KMS output is open by now (rt_app's render_init); its event thread hands over the vblank times */
        d->vsync = drv_vsync_kms_create(d->kms, c->refresh_hz, e, sizeof e);
        if (!d->vsync) return warp_err(err, errlen, "[vsync] backend = kms: %s", e[0] ? e : "cannot start");
    } else if (is_mock(c->vsync_chip)) {
        drv_vsync_mock_params mp;
        memset(&mp, 0, sizeof mp);
        mp.jitter_us = c->mock_vsync_jitter_us;
        mp.stop_at_s = c->mock_edges_stop_at_s; /* the mock counts from t0 already */
        mp.stop_for_s = c->mock_edges_stop_for_s;
        mp.seed = c->seed;
        d->vsync = drv_vsync_gpio_create_mock(c->refresh_hz, sp->t0_ns, &mp);
    } else {
        drv_vsync_gpio_params p;
        memset(&p, 0, sizeof p);
        snprintf(p.chip, sizeof p.chip, "%s", c->vsync_chip);
        p.line = c->vsync_line;
        p.refresh_hz = c->refresh_hz;
        p.falling_edge = c->vsync_falling != 0;
        d->vsync = drv_vsync_gpio_create(&p, e, sizeof e);
    }
    if (!d->vsync) {
        return warp_err(err, errlen, "[vsync] backend = %s, chip = %s, line = %d: %s", c->vsync_backend,
                        c->vsync_chip, c->vsync_line, e[0] ? e : "cannot open");
    }
    return true;
}

static bool open_frames(rt_devices *d, const rt_config *c, const drv_frames_sim_params *sp, char *err, int errlen)
{
    char e[256] = "";
    bool mock = is_mock(c->frames_device);
    size_t max_bytes = (size_t)(c->max_frame_mb * 1024 * 1024);
    if (strcmp(c->frames_backend, "sim") == 0) {
        d->frames = drv_frames_sim_create(sp);
        d->sim_host = true;
    } else if (strcmp(c->frames_backend, "usb") == 0 || strcmp(c->frames_backend, "socket") == 0) {
        drv_frames_usb_params p;
        memset(&p, 0, sizeof p);
        snprintf(p.ffs_dir, sizeof p.ffs_dir, "%s", c->frames_device);
        p.max_frame_bytes = max_bytes;
        p.eye_w = c->eye_w;
        p.eye_h = c->eye_h;
        p.planes = sp->planes_wanted;
        p.poses = sp->poses;
        p.pose_rate_hz = c->pose_rate_hz;
        p.link_mbps = c->link_mbps;
        p.head = sp->head;
        /* what the camera message asks hosts to render: the board's eyes, refresh, and linear depth (the warps'
         * own encoding: nothing to convert) */
        p.cam[0] = sp->cam[0];
        p.cam[1] = sp->cam[1];
        p.refresh_hz = c->refresh_hz;
        p.depth_encoding = WARP_DEPTH_LINEAR;
        /* the hidden-area mask after each camera message: what the lens shows, guard band included (warp_fov) */
        for (int eye = 0; eye < 2; eye++) {
            warp_lens lens = rt_config_lens(c, eye);
            p.mask.n[eye] = warp_fov_mask_loop(&lens, rt_config_visible_radius(c, eye), c->panel_w / 2, c->panel_h,
                                               rt_config_guard_deg(c), WARP_FOV_MASK_VERTICES, p.mask.uv[eye]);
        }
        /* framelink v2: what hosts are told the board decodes, and the decoder's threads (validated already) */
        if (!rt_config_frames_codecs(c, &p.codecs, e, sizeof e))
            return warp_err(err, errlen, "[frames] codecs = '%s': %s", c->frames_codecs, e);
        p.decode_threads = c->decode_threads;
        p.video_decoder = c->video_decoder;
        if (strcmp(c->frames_backend, "socket") == 0) {
            d->frames = drv_frames_socket_create(&p, c->frames_device, e, sizeof e);
        } else if (mock) {
            drv_frames_usb_mock_params mp;
            memset(&mp, 0, sizeof mp);
            mp.corrupt_every = c->mock_corrupt_every;
            mp.truncate_every = c->mock_truncate_every;
            mp.stall_at_s = since_start(sp, c->mock_host_stall_at_s);
            mp.stall_for_s = c->mock_host_stall_for_s;
            d->frames = drv_frames_usb_create_mock(sp, &p, &mp, e, sizeof e);
        } else {
            d->frames = drv_frames_usb_create(&p, e, sizeof e);
        }
        d->framelink = d->frames != NULL;
    } else if (strcmp(c->frames_backend, "v4l2") == 0) {
        drv_frames_v4l2_params p;
        memset(&p, 0, sizeof p);
        snprintf(p.device, sizeof p.device, "%s", c->frames_device);
        snprintf(p.format, sizeof p.format, "%s", c->v4l2_format);
        p.eye_w = c->eye_w;
        p.eye_h = c->eye_h;
        p.depth = c->frames_depth != 0;
        d->frames = mock ? drv_frames_v4l2_create_mock(sp, &p, e, sizeof e) : drv_frames_v4l2_create(&p, e, sizeof e);
        if (d->frames && mock) drv_frames_v4l2_mock_corrupt_every(d->frames, c->mock_corrupt_every);
    }
    if (!d->frames) {
        return warp_err(err, errlen, "[frames] backend = %s, device = %s: %s", c->frames_backend,
                        c->frames_device[0]                          ? c->frames_device
                        : strcmp(c->frames_backend, "socket") == 0 ? DRV_FRAMES_SOCKET_DEFAULT
                                                                     : "(none)",
                        e[0] ? e : "cannot open");
    }
    return true;
}

bool rt_devices_simulated(const rt_config *c)
{
    return strcmp(c->imu_backend, "sim") == 0 || is_mock(c->imu_device) || strcmp(c->frames_backend, "sim") == 0 ||
           is_mock(c->frames_device) || strcmp(c->vsync_backend, "sim") == 0 ||
           (strcmp(c->vsync_backend, "gpio") == 0 && is_mock(c->vsync_chip));
}

bool rt_devices_on_virtual_time(const rt_config *c, const char **real)
{
    /* the timer vsync reads plat_clock; the rest stamp in the kernel or on a host, in real time (a KMS display
     * only shows: its vblank stamps matter as [vsync] kms) */
    *real = !(strcmp(c->imu_backend, "sim") == 0 || is_mock(c->imu_device))           ? "[imu]"
            : !(strcmp(c->frames_backend, "sim") == 0 || is_mock(c->frames_device))   ? "[frames]"
            : strcmp(c->vsync_backend, "kms") == 0 ||
                      (strcmp(c->vsync_backend, "gpio") == 0 && !is_mock(c->vsync_chip)) ? "[vsync]"
                                                                                      : NULL;
    return *real == NULL;
}

bool rt_devices_open(rt_devices *d, const rt_config *c, const sim_trace *trace, const drv_frames_sim_params *sp,
                     char *err, int errlen)
{
    /* Ground truth exists when both the head and the host are simulated, directly or behind a mock. */
    bool imu_sim = strcmp(c->imu_backend, "sim") == 0 || is_mock(c->imu_device);
    bool host_sim = strcmp(c->frames_backend, "sim") == 0 || is_mock(c->frames_device);
    d->has_truth = imu_sim && host_sim;
    return open_imu(d, c, trace, sp, err, errlen) && open_vsync(d, c, sp, err, errlen) &&
           open_frames(d, c, sp, err, errlen);
}

bool rt_devices_mount(rt_devices *d, const rt_config *c, char *err, int errlen)
{
    if (!rt_calib_imu_from_config(c, strcmp(c->imu_backend, "sim") != 0, &d->imu_cal, err, errlen)) return false;
    d->imu_remap = !d->imu_cal.identity;
    return true;
}

bool rt_devices_open_imu(rt_devices *d, const rt_config *c, const sim_trace *trace, int64_t t0_ns, char *err,
                         int errlen)
{
    drv_frames_sim_params sp;
    memset(&sp, 0, sizeof sp);
    sp.t0_ns = t0_ns; /* all a simulated or mock IMU reads of it */
    return open_imu(d, c, trace, &sp, err, errlen);
}

void rt_devices_remap(const rt_devices *d, drv_imu_sample *s) { rt_calib_imu_apply(&d->imu_cal, s); }

void rt_devices_close(rt_devices *d)
{
    drv_imu_destroy(d->imu);
    drv_frames_destroy(d->frames);
    drv_vsync_destroy(d->vsync);
    plat_display_destroy(d->display);
    d->imu = NULL;
    d->frames = NULL;
    d->vsync = NULL;
    d->display = NULL;
    d->kms = NULL;
}

void *rt_devices_imu_thread(void *arg)
{
    rt_devices_feed *a = arg;
    plat_thread_set_name("hmdwarp-imu");
    /* Just below the compositor: late IMU samples are late photons. */
    if (a->rt_priority > 1) plat_thread_set_realtime(a->rt_priority - 1);
    drv_imu_sample buf[64];
    bool lost = false;
    while (!atomic_load_explicit(a->stop, memory_order_relaxed)) {
        int n = drv_imu_read(a->dev->imu, buf, 64, 50);
        if (n < 0) {
            /* Device gone: the display holds the last orientation (RT_IMU_STALE_NS) while the backend retries;
             * read() itself paces the reopen attempts. */
            atomic_fetch_add(&a->tel->imu_read_errors, 1);
            if (!lost) {
                atomic_fetch_add(&a->tel->imu_lost, 1);
                drv_imu_stats ds;
                drv_imu_stats_get(a->dev->imu, &ds);
                plat_log(PLAT_LOG_WARNING, "IMU %s lost (%s): holding the last orientation, retrying",
                        a->dev->imu->name, ds.last_error[0] ? ds.last_error : strerror(-n));
                lost = true;
            }
            plat_sleep_ns(20 * PLAT_NS_PER_MS);
            continue;
        }
        if (lost && n > 0) {
            plat_log(PLAT_LOG_NOTICE, "IMU %s is back", a->dev->imu->name);
            lost = false;
        }
        for (int i = 0; i < n; i++) {
            if (a->dev->imu_remap) rt_devices_remap(a->dev, &buf[i]);
            rt_fusion_update(a->fusion, &buf[i]);
        }
        atomic_fetch_add_explicit(&a->tel->imu_samples, (uint64_t)n, memory_order_relaxed);
    }
    return NULL;
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

void *rt_devices_frames_thread(void *arg)
{
    rt_devices_feed *a = arg;
    plat_thread_set_name("hmdwarp-frames");
    /* The log (this thread may do I/O; the vsync thread never does): each kind of rejection at once, then at most
     * one line a second; a host that goes quiet, and when it is back. */
    int64_t last_ok = plat_now_ns(), last_log = 0;
    bool quiet = false, seen_ok = false;
    uint64_t logged[DRV_FRAME_ERR_COUNT] = {0};
    while (!atomic_load_explicit(a->stop, memory_order_relaxed)) {
        rt_frame *slot = rt_frameq_back(a->fq);
        int rc = drv_frames_receive(a->dev->frames, &slot->f, 50);
        int64_t now = plat_now_ns();
        if (rc == 0) {
            if (seen_ok && !quiet && now - last_ok > PLAT_NS_PER_S) {
                plat_log(PLAT_LOG_WARNING, "no host frame for %.1f s: warping the last good frame",
                        (double)(now - last_ok) * 1e-9);
                quiet = true;
            }
            continue;
        }
        drv_frame_err e = rc < 0 ? (drv_frame_err)(-rc) : a->prepare(slot, a->prepare_workers);
        if (rc > 0) rt_hist_add(&a->tel->prepare_ms, (double)(plat_now_ns() - now) * 1e-6);
        if (e != DRV_FRAME_OK) {
            /* Rejected: counted, and the compositor keeps warping the last good frame. */
            if (e < 0 || e >= DRV_FRAME_ERR_COUNT) e = DRV_FRAME_ERR_IO;
            uint64_t n = atomic_fetch_add(&a->tel->frames_rejected[e], 1) + 1;
            if (!logged[e] || now - last_log > PLAT_NS_PER_S) {
                char why[200];
                drv_frames_last_error(a->dev->frames, why, sizeof why);
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
        if (a->dev->has_truth && !a->dev->sim_host)
            slot->f.scene_time = (double)(slot->f.pose_t_ns - a->t0_ns) * 1e-9;
        /* measured on this thread by the decoder: the vsync path never decodes */
        if (a->dev->framelink) rt_hist_add(&a->tel->decode_ms, drv_frames_usb_decode_ms(a->dev->frames));
        atomic_fetch_add(&a->tel->frames_received, 1);
        atomic_fetch_add_explicit(&a->tel->frames_bytes, frame_bytes(&slot->f), memory_order_relaxed);
        rt_frameq_publish(a->fq);
    }
    return NULL;
}
