/* SPDX-License-Identifier: MIT */
/* rt_devices: opens the IMU, host-frame and vsync backends board.ini names, real or mock, with one clear error
 * naming the key and the device when one cannot be opened. */
#include <stdio.h>
#include <string.h>

#include "drivers/drv_frames_usb_mock.h"
#include "drivers/drv_frames_v4l2_mock.h"
#include "drivers/drv_imu_hid_mock.h"
#include "drivers/drv_imu_i2c_mock.h"
#include "drivers/drv_sim.h"
#include "drivers/drv_vsync_gpio_mock.h"
#include "drivers/drv_vsync_kms.h"
#include "platform/plat_clock.h"
#include "runtime/rt_app.h"

static bool is_mock(const char *dev) { return strcmp(dev, "mock") == 0; }

/* Run time (from scene time 0) in the mocks' fault schedules, which count from their own start. */
static double since_start(const rt_app *a, double run_s)
{
    return run_s > 0 ? run_s + (double)(a->t0_ns - plat_now_ns()) * 1e-9 : 0;
}

static drv_imu *sim_imu(rt_app *a)
{
    const rt_config *c = &a->cfg;
    sim_imu_params ip = sim_imu_default_params();
    ip.rate_hz = c->imu_rate_hz;
    ip.gyro_noise = c->gyro_noise;
    ip.gyro_bias = warp_v3(c->gyro_bias[0], c->gyro_bias[1], c->gyro_bias[2]);
    ip.accel_noise = c->accel_noise;
    ip.seed = c->seed;
    ip.t_start = -c->imu_rest_s;
    return drv_imu_sim_create(&a->trace, &ip, a->t0_ns);
}

static bool open_imu(rt_app *a, char *err, int errlen)
{
    const rt_config *c = &a->cfg;
    char e[256] = "";
    bool mock = is_mock(c->imu_device);
    if (strcmp(c->imu_backend, "sim") == 0) {
        a->imu = sim_imu(a);
    } else if (strcmp(c->imu_backend, "hid") == 0) {
        if (mock) {
            drv_imu_hid_mock_params mp;
            memset(&mp, 0, sizeof mp);
            mp.counter_start = 0xFFFFFFFFu - 3000000u; /* rolls over 3 s in */
            mp.samples_per_report = 2;
            mp.unplug_at_s = since_start(a, c->mock_imu_unplug_at_s);
            mp.unplug_for_s = c->mock_imu_unplug_for_s;
            mp.corrupt_every = c->mock_corrupt_every;
            drv_imu *src = sim_imu(a);
            a->imu = src ? drv_imu_hid_create_mock(src, &mp) : NULL;
        } else {
            drv_imu_hid_params p;
            memset(&p, 0, sizeof p);
            snprintf(p.device, sizeof p.device, "%s", c->imu_device);
            p.rate_hz = c->imu_rate_hz;
            a->imu = drv_imu_hid_create(&p, e, sizeof e);
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
            drv_imu *src = sim_imu(a);
            a->imu = src ? drv_imu_i2c_create_mock(src, &p, e, sizeof e) : NULL;
        } else {
            a->imu = drv_imu_i2c_create(&p, e, sizeof e);
        }
    }
    if (!a->imu) {
        snprintf(err, (size_t)errlen, "[imu] backend = %s, device = %s: %s", c->imu_backend,
                 c->imu_device[0] ? c->imu_device : "(none)", e[0] ? e : "cannot open");
        return false;
    }
    return true;
}

static bool open_vsync(rt_app *a, char *err, int errlen)
{
    const rt_config *c = &a->cfg;
    char e[256] = "";
    if (strcmp(c->vsync_backend, "sim") == 0) {
        a->vsync = drv_vsync_sim_create(c->refresh_hz, a->t0_ns);
    } else if (strcmp(c->vsync_backend, "timer") == 0) {
        a->vsync = drv_vsync_timer_create(c->refresh_hz);
    } else if (strcmp(c->vsync_backend, "kms") == 0) {
        /* the KMS output is open by now (rt_app's render_init); its event thread hands over the vblank times */
        a->vsync = drv_vsync_kms_create(a->kms, c->refresh_hz, e, sizeof e);
        if (!a->vsync) {
            snprintf(err, (size_t)errlen, "[vsync] backend = kms: %s", e[0] ? e : "cannot start");
            return false;
        }
    } else if (is_mock(c->vsync_chip)) {
        drv_vsync_mock_params mp;
        memset(&mp, 0, sizeof mp);
        mp.jitter_us = c->mock_vsync_jitter_us;
        mp.stop_at_s = c->mock_edges_stop_at_s; /* the mock counts from t0 already */
        mp.stop_for_s = c->mock_edges_stop_for_s;
        mp.seed = c->seed;
        a->vsync = drv_vsync_gpio_create_mock(c->refresh_hz, a->t0_ns, &mp);
    } else {
        drv_vsync_gpio_params p;
        memset(&p, 0, sizeof p);
        snprintf(p.chip, sizeof p.chip, "%s", c->vsync_chip);
        p.line = c->vsync_line;
        p.refresh_hz = c->refresh_hz;
        p.falling_edge = c->vsync_falling != 0;
        a->vsync = drv_vsync_gpio_create(&p, e, sizeof e);
    }
    if (!a->vsync) {
        snprintf(err, (size_t)errlen, "[vsync] backend = %s, chip = %s, line = %d: %s", c->vsync_backend,
                 c->vsync_chip, c->vsync_line, e[0] ? e : "cannot open");
        return false;
    }
    return true;
}

static bool open_frames(rt_app *a, const drv_frames_sim_params *sp, char *err, int errlen)
{
    const rt_config *c = &a->cfg;
    char e[256] = "";
    bool mock = is_mock(c->frames_device);
    size_t max_bytes = (size_t)(c->max_frame_mb * 1024 * 1024);
    if (strcmp(c->frames_backend, "sim") == 0) {
        a->frames = drv_frames_sim_create(sp);
        a->sim_host = true;
    } else if (strcmp(c->frames_backend, "usb") == 0) {
        drv_frames_usb_params p;
        memset(&p, 0, sizeof p);
        snprintf(p.ffs_dir, sizeof p.ffs_dir, "%s", c->frames_device);
        p.max_frame_bytes = max_bytes;
        p.eye_w = c->eye_w;
        p.eye_h = c->eye_h;
        p.planes = sp->planes_wanted;
        p.poses = sp->poses;
        p.pose_rate_hz = c->pose_rate_hz;
        p.head = a->head;
        if (mock) {
            drv_frames_usb_mock_params mp;
            memset(&mp, 0, sizeof mp);
            mp.corrupt_every = c->mock_corrupt_every;
            mp.truncate_every = c->mock_truncate_every;
            mp.stall_at_s = since_start(a, c->mock_host_stall_at_s);
            mp.stall_for_s = c->mock_host_stall_for_s;
            a->frames = drv_frames_usb_create_mock(sp, &p, &mp, e, sizeof e);
        } else {
            a->frames = drv_frames_usb_create(&p, e, sizeof e);
        }
    } else if (strcmp(c->frames_backend, "v4l2") == 0) {
        drv_frames_v4l2_params p;
        memset(&p, 0, sizeof p);
        snprintf(p.device, sizeof p.device, "%s", c->frames_device);
        snprintf(p.format, sizeof p.format, "%s", c->v4l2_format);
        p.eye_w = c->eye_w;
        p.eye_h = c->eye_h;
        p.depth = c->frames_depth != 0;
        a->frames = mock ? drv_frames_v4l2_create_mock(sp, &p, e, sizeof e) : drv_frames_v4l2_create(&p, e, sizeof e);
        if (a->frames && mock) drv_frames_v4l2_mock_corrupt_every(a->frames, c->mock_corrupt_every);
    }
    if (!a->frames) {
        snprintf(err, (size_t)errlen, "[frames] backend = %s, device = %s: %s", c->frames_backend,
                 c->frames_device[0] ? c->frames_device : "(none)", e[0] ? e : "cannot open");
        return false;
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

bool rt_devices_open(rt_app *a, const drv_frames_sim_params *sp, char *err, int errlen)
{
    const rt_config *c = &a->cfg;
    /* Ground truth exists when both the head and the host are simulated, directly or behind a mock. */
    bool imu_sim = strcmp(c->imu_backend, "sim") == 0 || is_mock(c->imu_device);
    bool host_sim = strcmp(c->frames_backend, "sim") == 0 || is_mock(c->frames_device);
    a->has_truth = imu_sim && host_sim;
    return open_imu(a, err, errlen) && open_vsync(a, err, errlen) && open_frames(a, sp, err, errlen);
}
