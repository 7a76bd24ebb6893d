/* rt_config: hmdwarpd's settings: defaults, board.ini parsing (inih) with errors naming line and key, command-line
 * overrides (section.key=value) and validation. One table defines every key, its range and its help text. */
#include "runtime/rt_config.h"

#include <ini.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "warp/warp_head.h"

static const char *const method_names[] = {"none",    "rotation",      "raytrace", "transparency",
                                           "objects", "raytrace_mesh", "auto",     NULL};
static const char *const edge_fill_names[] = {"far", "linear", NULL};
static const char *const sink_names[] = {"null", "png", "raw", NULL};
static const char *const renderer_names[] = {"auto", "cpu", "gles", NULL};
/* in warp_resample_kernel_id order: the index is the id */
static const char *const kernel_names[] = {"auto", "scalar", "vector", "avx2", "avx512", NULL};
static const char *const output_names[] = {"offscreen", "kms", NULL};
static const char *const imu_names[] = {"sim", "hid", "i2c", NULL};
static const char *const frames_names[] = {"sim", "usb", "v4l2", NULL};
static const char *const vsync_names[] = {"sim", "gpio", "timer", "kms", NULL};
static const char *const chip_names[] = {"auto", "mpu6050", "mpu9250", "icm42688", NULL};
static const char *const v4l2_format_names[] = {"auto", "yuyv", "nv12", "bgr32", "rgb24", NULL};
static const char *const bool_names[] = {"false", "true", NULL};
static const char *const edge_names[] = {"rising", "falling", NULL};
static const char *const arch_names[] = {"any", "aarch64", "x86_64", "arm", NULL};

const char *rt_kernel_name(int k)
{
    return k >= 0 && k < (int)(sizeof kernel_names / sizeof *kernel_names) - 1 ? kernel_names[k] : "?";
}

const char *rt_method_name(rt_method m) { return m >= 0 && m <= RT_METHOD_AUTO ? method_names[m] : "?"; }

typedef enum { K_INT, K_DOUBLE, K_U64, K_STR, K_CHOICE, K_ENUM, K_DLIST } ktype;

typedef struct {
    const char *section, *key;
    ktype type;
    size_t off;
    int n;                      /* string buffer size, or list length */
    double lo, hi;
    const char *const *names;   /* K_CHOICE (stored as string) and K_ENUM (stored as int index) */
    const char *help;
} keydef;

#define F(field) offsetof(rt_config, field)
#define S(field) (int)sizeof(((rt_config *)0)->field)

static const keydef keys[] = {
    {"board", "name", K_STR, F(board_name), S(board_name), 0, 0, NULL, "board name shown in the summary"},
    {"board", "arch", K_CHOICE, F(board_arch), S(board_arch), 0, 0, arch_names,
     "the board's CPU architecture (any, aarch64, x86_64, arm): board/flash.sh refuses a tree built for another"},
    {"display", "width", K_INT, F(panel_w), 0, 16, 16384, NULL, "panel width in pixels (both eyes side by side)"},
    {"display", "height", K_INT, F(panel_h), 0, 16, 16384, NULL, "panel height in pixels"},
    {"display", "refresh_hz", K_DOUBLE, F(refresh_hz), 0, 10, 500, NULL, "panel refresh rate"},
    {"display", "photon_offset_ms", K_DOUBLE, F(photon_offset_ms), 0, 0, 100, NULL,
     "time from the vsync edge to when the photons are seen (prediction target)"},
    {"display", "sink", K_CHOICE, F(sink), S(sink), 0, 0, sink_names,
     "where panel images go: null, png (snapshots) or raw (RGBA8 stream)"},
    {"display", "sink_every", K_INT, F(sink_every), 0, 1, 1000000, NULL, "write every Nth vsync (png/raw sinks)"},
    {"display", "sink_path", K_STR, F(sink_path), S(sink_path), 0, 0, NULL, "directory for png/raw sink output"},
    {"display", "output", K_CHOICE, F(output), S(output), 0, 0, output_names,
     "offscreen (images go to the sink) or kms (the panel through DRM/KMS page flips: GBM buffers on the GLES "
     "renderer, dumb buffers on the CPU path)"},
    {"display", "kms_device", K_STR, F(kms_device), S(kms_device), 0, 0, NULL,
     "DRM card node for output = kms, or auto (the first /dev/dri/cardN with a connected connector)"},
    {"display", "kms_connector", K_STR, F(kms_connector), S(kms_connector), 0, 0, NULL,
     "connector for output = kms: auto (first connected) or a name like HDMI-A-1, DSI-1"},
    {"display", "kms_mode", K_STR, F(kms_mode), S(kms_mode), 0, 0, NULL,
     "mode for output = kms: auto (the panel's width x height) or WxH or WxH@Hz; it must match the panel"},
    {"render", "renderer", K_CHOICE, F(renderer), S(renderer), 0, 0, renderer_names,
     "warp backend: gles (EGL + OpenGL ES 3), cpu, or auto (gles on a hardware GPU, cpu when EGL offers only a "
     "software rasterizer such as llvmpipe or nothing)"},
    {"render", "threads", K_INT, F(threads), 0, 1, 16, NULL, "compositor threads (the vsync thread included)"},
    {"render", "kernel", K_ENUM, F(kernel), 0, 0, 0, kernel_names,
     "CPU resampling kernel: auto (the widest this CPU runs), scalar, vector, avx2 or avx512 (x86 only); all give "
     "the same image bit for bit, they differ in speed (an emulator may run the plain ones faster)"},
    {"render", "rt_priority", K_INT, F(rt_priority), 0, 0, 99, NULL,
     "SCHED_FIFO priority for the compositor when permitted (0 = normal scheduling)"},
    {"render", "stall_reserve_ms", K_DOUBLE, F(stall_reserve_ms), 0, 0, 100, NULL,
     "extra time each pass starts ahead of its vsync, beyond its longest recent warp, so that the scheduler keeping "
     "the compositor off the CPU that long (a VM, a shared desktop) costs no vsync; at most a period; adds as "
     "much motion-to-photon latency (0 on a board whose compositor has its cores; the GLES path takes at most "
     "what fits in one period)"},
    {"eye", "width", K_INT, F(eye_w), 0, 16, 8192, NULL, "host eye buffer width"},
    {"eye", "height", K_INT, F(eye_h), 0, 16, 8192, NULL, "host eye buffer height"},
    {"eye", "fov", K_DLIST, F(fov_deg), 4, 1, 89, NULL,
     "left eye's half-angles in degrees: left right up down (the right eye is mirrored)"},
    {"eye", "near", K_DOUBLE, F(near_z), 0, 0.001, 10, NULL, "near plane in metres"},
    {"eye", "ipd", K_DOUBLE, F(ipd), 0, 0.04, 0.09, NULL, "interpupillary distance in metres"},
    {"lens", "mesh", K_INT, F(mesh_n), 0, 2, 1024, NULL, "distortion mesh vertices per side (N x N)"},
    {"lens", "k_red", K_DLIST, F(k[0]), WARP_LENS_TERMS, -100, 100, NULL,
     "red radial scale polynomial k0 k1 k2 k3: s(r^2) = k0 + k1 r^2 + k2 r^4 + k3 r^6"},
    {"lens", "k_green", K_DLIST, F(k[1]), WARP_LENS_TERMS, -100, 100, NULL, "green polynomial"},
    {"lens", "k_blue", K_DLIST, F(k[2]), WARP_LENS_TERMS, -100, 100, NULL, "blue polynomial"},
    {"lens", "scale", K_DOUBLE, F(lens_scale), 0, 1, 100000, NULL, "panel pixels per unit of normalised radius"},
    {"lens", "center", K_DLIST, F(lens_center), 2, -100000, 100000, NULL,
     "left eye's lens centre x y in pixels within its half of the panel (mirrored for the right eye)"},
    {"warp", "method", K_ENUM, F(method), 0, 0, 0, method_names,
     "none (lens only), rotation (003 §3.4), raytrace (003 §3.5, every eye-buffer pixel, then the lens pass), "
     "raytrace_mesh (the raytrace at the lens mesh's vertices only, one pass from the host frame: near the display "
     "path's cost, parallax smeared across depth edges within a mesh cell; the GLES renderer traces per pixel), "
     "transparency (000 §5.3), objects (002 §3.2) or auto (per vsync, the cheapest warp whose predicted error "
     "stays under pixel_budget; short of time, raytrace steps down to raytrace_mesh, then rotation)"},
    {"warp", "pixel_budget", K_DOUBLE, F(pixel_budget), 0, 0.01, 100, NULL,
     "auto: largest on-screen error in eye-buffer pixels accepted from a cheaper warp (004 eqs. 5-7 bound)"},
    {"warp", "raytrace_steps", K_INT, F(raytrace_steps), 0, 1, 100000, NULL, "raytrace step budget per ray"},
    {"warp", "edge_fill", K_ENUM, F(edge_fill), 0, 0, 0, edge_fill_names,
     "raytrace disocclusion fill: far (far side) or linear (003 §4.4)"},
    {"warp", "edge_jump", K_DOUBLE, F(edge_jump), 0, 0.001, 10, NULL,
     "relative inverse-depth jump per step that counts as an occlusion edge"},
    {"imu", "backend", K_CHOICE, F(imu_backend), S(imu_backend), 0, 0, imu_names,
     "IMU source: sim (simulated board), hid (USB HID, hidraw) or i2c (i2c-dev)"},
    {"imu", "device", K_STR, F(imu_device), S(imu_device), 0, 0, NULL,
     "hid: /dev/hidrawN or VVVV:PPPP (hex vendor:product); i2c: /dev/i2c-N; mock: the simulated IMU behind the "
     "real decoder"},
    {"imu", "address", K_INT, F(imu_address), 0, 0x03, 0x77, NULL, "i2c: 7-bit device address (e.g. 0x68)"},
    {"imu", "chip", K_CHOICE, F(imu_chip), S(imu_chip), 0, 0, chip_names,
     "i2c: register map: auto (probe WHO_AM_I), mpu6050, mpu9250 or icm42688"},
    {"imu", "gyro_dps", K_INT, F(imu_gyro_dps), 0, 125, 4000, NULL, "i2c: gyro full scale, degrees/s"},
    {"imu", "accel_g", K_INT, F(imu_accel_g), 0, 2, 32, NULL, "i2c: accelerometer full scale, g"},
    {"imu", "axes", K_STR, F(imu_axes), S(imu_axes), 0, 0, NULL,
     "mounting: the head's x y z axes as signed IMU axes, e.g. '-y +x +z' (head x = IMU -y)"},
    {"imu", "rate_hz", K_DOUBLE, F(imu_rate_hz), 0, 10, 10000, NULL, "IMU sample rate"},
    {"frames", "backend", K_CHOICE, F(frames_backend), S(frames_backend), 0, 0, frames_names,
     "host frame source: sim (simulated host), usb (FunctionFS gadget) or v4l2 (HDMI/CSI capture)"},
    {"frames", "device", K_STR, F(frames_device), S(frames_device), 0, 0, NULL,
     "usb: FunctionFS mount directory; v4l2: capture device; mock: the simulated host over the real wire format"},
    {"frames", "format", K_CHOICE, F(v4l2_format), S(v4l2_format), 0, 0, v4l2_format_names,
     "v4l2: capture pixel format (auto picks one the device offers)"},
    {"frames", "depth", K_ENUM, F(frames_depth), 0, 0, 0, bool_names,
     "v4l2: the host packs a depth plane beside the colour"},
    {"frames", "max_frame_mb", K_DOUBLE, F(max_frame_mb), 0, 0.01, 4096, NULL,
     "largest host frame accepted, MiB (larger ones are rejected unread)"},
    {"frames", "pose_rate_hz", K_DOUBLE, F(pose_rate_hz), 0, 1, 2000, NULL,
     "usb: how often the board sends its predicted head pose to the host"},
    {"vsync", "backend", K_CHOICE, F(vsync_backend), S(vsync_backend), 0, 0, vsync_names,
     "vsync source: sim (simulated panel), gpio (panel TE line via libgpiod), timer (free running) or kms (the "
     "display controller's vblank times; needs output = kms)"},
    {"vsync", "chip", K_STR, F(vsync_chip), S(vsync_chip), 0, 0, NULL,
     "gpio: gpiochipN, N or /dev/gpiochipN; mock: simulated TE edges through the real edge handling"},
    {"vsync", "line", K_INT, F(vsync_line), 0, 0, 1023, NULL, "gpio: line offset of the TE signal on the chip"},
    {"vsync", "edge", K_ENUM, F(vsync_falling), 0, 0, 0, edge_names, "gpio: which TE edge marks the vsync"},
    {"sim", "scene", K_STR, F(scene), S(scene), 0, 0, NULL, "simulated scene (see --list)"},
    {"sim", "trace", K_STR, F(trace), S(trace), 0, 0, NULL, "simulated head motion (see --list)"},
    {"sim", "duration_s", K_DOUBLE, F(duration_s), 0, 0, 1e6, NULL, "run time in seconds (0 = until SIGINT)"},
    {"sim", "seed", K_U64, F(seed), 0, 0, 0, NULL, "seed for noise and trace variations"},
    {"sim", "host_rate_hz", K_DOUBLE, F(host_rate_hz), 0, 1, 500, NULL, "simulated host render rate (at most)"},
    {"sim", "host_latency_ms", K_DOUBLE, F(host_latency_ms), 0, 0, 1000, NULL,
     "simulated transport latency after each host render"},
    {"sim", "host_threads", K_INT, F(host_threads), 0, 1, 16, NULL, "threads the simulated host renders with"},
    {"sim", "imu_rest_s", K_DOUBLE, F(imu_rest_s), 0, 0, 60, NULL,
     "seconds the simulated headset lies still before the head motion starts (the tracker learns gyro bias)"},
    {"sim", "gyro_noise", K_DOUBLE, F(gyro_noise), 0, 0, 10, NULL, "simulated gyro noise, rad/s rms"},
    {"sim", "gyro_bias", K_DLIST, F(gyro_bias), 3, -10, 10, NULL, "simulated gyro bias x y z, rad/s"},
    {"sim", "accel_noise", K_DOUBLE, F(accel_noise), 0, 0, 100, NULL, "simulated accelerometer noise, m/s^2 rms"},
    {"sim", "eval_every_ms", K_DOUBLE, F(eval_every_ms), 0, 0, 1e6, NULL,
     "compare a displayed frame with ground truth this often (0 = off)"},
    {"mock", "corrupt_every", K_INT, F(mock_corrupt_every), 0, 0, 1000000, NULL,
     "mock devices: garble every Nth HID report / host frame (0 = never)"},
    {"mock", "truncate_every", K_INT, F(mock_truncate_every), 0, 0, 1000000, NULL,
     "mock host link: cut every Nth frame short (0 = never)"},
    {"mock", "imu_unplug_at_s", K_DOUBLE, F(mock_imu_unplug_at_s), 0, 0, 1e6, NULL,
     "mock HID IMU: unplug at this run time (0 = never)"},
    {"mock", "imu_unplug_for_s", K_DOUBLE, F(mock_imu_unplug_for_s), 0, 0, 1e6, NULL, "... and replug after"},
    {"mock", "host_stall_at_s", K_DOUBLE, F(mock_host_stall_at_s), 0, 0, 1e6, NULL,
     "mock host link: the host stops sending at this run time (0 = never)"},
    {"mock", "host_stall_for_s", K_DOUBLE, F(mock_host_stall_for_s), 0, 0, 1e6, NULL, "... for this long"},
    {"mock", "vsync_jitter_us", K_DOUBLE, F(mock_vsync_jitter_us), 0, 0, 10000, NULL, "mock TE edges: jitter"},
    {"mock", "edges_stop_at_s", K_DOUBLE, F(mock_edges_stop_at_s), 0, 0, 1e6, NULL,
     "mock TE edges: stop at this run time (0 = never)"},
    {"mock", "edges_stop_for_s", K_DOUBLE, F(mock_edges_stop_for_s), 0, 0, 1e6, NULL, "... for this long"},
    {"telemetry", "csv", K_STR, F(csv), S(csv), 0, 0, NULL, "write one CSV row per vsync to this file"},
    {"telemetry", "stats", K_STR, F(stats), S(stats), 0, 0, NULL,
     "write the run summary as key=value lines to this file at exit (for scripts)"},
};
#define NKEYS (int)(sizeof keys / sizeof keys[0])

void rt_config_defaults(rt_config *c)
{
    memset(c, 0, sizeof *c);
    snprintf(c->board_name, sizeof c->board_name, "unnamed");
    snprintf(c->board_arch, sizeof c->board_arch, "any");
    c->panel_w = 2880;
    c->panel_h = 1600;
    c->refresh_hz = 90;
    c->photon_offset_ms = 5.5;
    snprintf(c->sink, sizeof c->sink, "null");
    c->sink_every = 90;
    snprintf(c->sink_path, sizeof c->sink_path, "build/frames");
    snprintf(c->output, sizeof c->output, "offscreen");
    snprintf(c->kms_device, sizeof c->kms_device, "/dev/dri/card0");
    snprintf(c->kms_connector, sizeof c->kms_connector, "auto");
    snprintf(c->kms_mode, sizeof c->kms_mode, "auto");
    snprintf(c->renderer, sizeof c->renderer, "auto");
    c->kernel = 0; /* auto */
    c->threads = 2;
    c->rt_priority = 10;
    c->eye_w = 1440;
    c->eye_h = 1600;
    c->fov_deg[0] = 52; c->fov_deg[1] = 48; c->fov_deg[2] = 52; c->fov_deg[3] = 52;
    c->near_z = 0.05;
    c->ipd = 0.064;
    c->mesh_n = 64;
    const double base[WARP_LENS_TERMS] = {1.0, 0.22, 0.24, 0.0};
    const double ca[3] = {0.996, 1.0, 1.008}; /* lateral chromatic aberration: per-channel radial scale */
    for (int ch = 0; ch < 3; ch++)
        for (int i = 0; i < WARP_LENS_TERMS; i++) c->k[ch][i] = base[i] * ca[ch];
    c->lens_scale = 720;
    c->lens_center[0] = 760; /* slightly towards the nose: lens axes sit closer together than the panel halves */
    c->lens_center[1] = 800;
    c->method = RT_METHOD_ROTATION;
    c->pixel_budget = 0.5;
    c->raytrace_steps = 512;
    c->edge_fill = 0;
    c->edge_jump = 0.1;
    snprintf(c->imu_backend, sizeof c->imu_backend, "sim");
    snprintf(c->frames_backend, sizeof c->frames_backend, "sim");
    snprintf(c->vsync_backend, sizeof c->vsync_backend, "sim");
    c->imu_address = 0x68;
    snprintf(c->imu_chip, sizeof c->imu_chip, "auto");
    c->imu_gyro_dps = 2000;
    c->imu_accel_g = 16;
    snprintf(c->imu_axes, sizeof c->imu_axes, "+x +y +z");
    snprintf(c->v4l2_format, sizeof c->v4l2_format, "auto");
    c->max_frame_mb = 64;
    c->pose_rate_hz = 500;
    snprintf(c->vsync_chip, sizeof c->vsync_chip, "gpiochip0");
    snprintf(c->scene, sizeof c->scene, "room");
    snprintf(c->trace, sizeof c->trace, "fast");
    c->duration_s = 10;
    c->seed = 1;
    c->host_rate_hz = 45;
    c->host_latency_ms = 4;
    c->host_threads = 1;
    c->imu_rate_hz = 1000;
    c->imu_rest_s = 1.0;
    c->gyro_noise = 0.005;
    c->gyro_bias[0] = 0.01; c->gyro_bias[1] = -0.007; c->gyro_bias[2] = 0.004;
    c->accel_noise = 0.05;
    c->eval_every_ms = 500;
}

static void add_error(rt_config_errors *e, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void add_error(rt_config_errors *e, const char *fmt, ...)
{
    if (!e) return;
    if (e->count >= (int)(sizeof e->msg / sizeof e->msg[0])) {
        e->count++;
        return;
    }
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(e->msg[e->count], sizeof e->msg[0], fmt, ap);
    va_end(ap);
    e->count++;
}

static bool parse_double(const char *s, double *out)
{
    char *end;
    double v = strtod(s, &end);
    while (*end == ' ' || *end == '\t') end++;
    if (end == s || *end || !isfinite(v)) return false;
    *out = v;
    return true;
}

static void list_names(const char *const *names, char *buf, size_t len)
{
    buf[0] = 0;
    for (int i = 0; names[i]; i++) {
        strncat(buf, i ? ", " : "", len - strlen(buf) - 1);
        strncat(buf, names[i], len - strlen(buf) - 1);
    }
}

/* Sets one key; `where` is "file:line" or "command line" for messages. */
static bool set_key(rt_config *c, const char *section, const char *key, const char *value, const char *where,
                    rt_config_errors *err)
{
    const keydef *k = NULL;
    bool section_known = false;
    for (int i = 0; i < NKEYS; i++) {
        if (strcmp(keys[i].section, section) != 0) continue;
        section_known = true;
        if (strcmp(keys[i].key, key) == 0) {
            k = &keys[i];
            break;
        }
    }
    if (!section_known) {
        add_error(err, "%s: unknown section [%s]", where, section);
        return false;
    }
    if (!k) {
        add_error(err, "%s: unknown key '%s' in [%s]", where, key, section);
        return false;
    }
    char *base = (char *)c + k->off;
    switch (k->type) {
    case K_INT: {
        double v;
        if (!parse_double(value, &v) || v != floor(v) || v < k->lo || v > k->hi) {
            add_error(err, "%s: [%s] %s = '%s': expected a whole number from %g to %g", where, section, key, value,
                      k->lo, k->hi);
            return false;
        }
        *(int *)base = (int)v;
        return true;
    }
    case K_DOUBLE: {
        double v;
        if (!parse_double(value, &v) || v < k->lo || v > k->hi) {
            add_error(err, "%s: [%s] %s = '%s': expected a number from %g to %g", where, section, key, value, k->lo,
                      k->hi);
            return false;
        }
        *(double *)base = v;
        return true;
    }
    case K_U64: {
        char *end;
        unsigned long long v = strtoull(value, &end, 0);
        if (end == value || *end || value[0] == '-') {
            add_error(err, "%s: [%s] %s = '%s': expected a non-negative integer", where, section, key, value);
            return false;
        }
        *(uint64_t *)base = v;
        return true;
    }
    case K_STR:
        if (strlen(value) >= (size_t)k->n) {
            add_error(err, "%s: [%s] %s: value longer than %d characters", where, section, key, k->n - 1);
            return false;
        }
        snprintf(base, (size_t)k->n, "%s", value);
        return true;
    case K_CHOICE:
    case K_ENUM:
        for (int i = 0; k->names[i]; i++)
            if (strcmp(k->names[i], value) == 0) {
                if (k->type == K_ENUM)
                    *(int *)base = i;
                else
                    snprintf(base, (size_t)k->n, "%s", value);
                return true;
            }
        {
            char names[200];
            list_names(k->names, names, sizeof names);
            add_error(err, "%s: [%s] %s = '%s': not available in this build (expected one of: %s)", where, section,
                      key, value, names);
        }
        return false;
    case K_DLIST: {
        double v[8];
        int n = 0;
        const char *p = value;
        char *end;
        while (*p && n < 8) {
            while (*p == ' ' || *p == '\t' || *p == ',') p++;
            if (!*p) break;
            v[n] = strtod(p, &end);
            if (end == p || !isfinite(v[n])) {
                n = -1;
                break;
            }
            n++;
            p = end;
        }
        bool ok = n == k->n;
        for (int i = 0; ok && i < n; i++) ok = v[i] >= k->lo && v[i] <= k->hi;
        if (!ok) {
            add_error(err, "%s: [%s] %s = '%s': expected %d numbers from %g to %g", where, section, key, value, k->n,
                      k->lo, k->hi);
            return false;
        }
        memcpy(base, v, sizeof(double) * (size_t)n);
        return true;
    }
    }
    return false;
}

/* inih hands lines over through a reader; counting them there gives every handler call its line number. */
typedef struct {
    rt_config *c;
    rt_config_errors *err;
    const char *name;
    int line;
    FILE *f;
    const char *text;
    bool ok;
} parse_ctx;

static char *reader(char *str, int num, void *stream)
{
    parse_ctx *p = stream;
    if (p->f) {
        if (!fgets(str, num, p->f)) return NULL;
    } else {
        if (!*p->text) return NULL;
        int i = 0;
        while (i < num - 1 && p->text[i] && p->text[i] != '\n') {
            str[i] = p->text[i];
            i++;
        }
        if (p->text[i] == '\n' && i < num - 1) str[i++] = '\n';
        str[i] = 0;
        p->text += i;
    }
    p->line++;
    return str;
}

static int handler(void *user, const char *section, const char *name, const char *value)
{
    parse_ctx *p = user;
    char where[300];
    snprintf(where, sizeof where, "%s:%d", p->name, p->line);
    if (!set_key(p->c, section, name, value, where, p->err)) p->ok = false;
    return 1; /* keep going: report every problem of the file at once */
}

static bool parse(parse_ctx *p)
{
    p->ok = true;
    int r = ini_parse_stream(reader, p, handler, p);
    if (r > 0) {
        add_error(p->err, "%s:%d: syntax error (expected '[section]' or 'key = value')", p->name, r);
        p->ok = false;
    }
    return p->ok;
}

bool rt_config_load(rt_config *c, const char *path, rt_config_errors *err)
{
    parse_ctx p = {c, err, path, 0, fopen(path, "r"), NULL, true};
    if (!p.f) {
        add_error(err, "%s: cannot open config file", path);
        return false;
    }
    bool ok = parse(&p);
    fclose(p.f);
    return ok;
}

bool rt_config_load_string(rt_config *c, const char *text, const char *name, rt_config_errors *err)
{
    parse_ctx p = {c, err, name, 0, NULL, text, true};
    return parse(&p);
}

bool rt_config_set(rt_config *c, const char *assignment, rt_config_errors *err)
{
    const char *dot = strchr(assignment, '.'), *eq = strchr(assignment, '=');
    if (!dot || !eq || dot > eq) {
        add_error(err, "command line: '%s': expected section.key=value", assignment);
        return false;
    }
    char section[64], key[64];
    snprintf(section, sizeof section, "%.*s", (int)(dot - assignment), assignment);
    snprintf(key, sizeof key, "%.*s", (int)(eq - dot - 1), dot + 1);
    return set_key(c, section, key, eq + 1, "command line", err);
}

warp_camera rt_config_eye_camera(const rt_config *c, int eye)
{
    warp_camera cam;
    double l = tan(c->fov_deg[0] * WARP_PI / 180), r = tan(c->fov_deg[1] * WARP_PI / 180);
    cam.width = c->eye_w;
    cam.height = c->eye_h;
    /* Mirror for the right eye: its temporal side is on the right. */
    cam.tan_left = eye == WARP_EYE_LEFT ? l : r;
    cam.tan_right = eye == WARP_EYE_LEFT ? r : l;
    cam.tan_up = tan(c->fov_deg[2] * WARP_PI / 180);
    cam.tan_down = tan(c->fov_deg[3] * WARP_PI / 180);
    cam.near_z = c->near_z;
    cam.far_z = INFINITY;
    return cam;
}

warp_lens rt_config_lens(const rt_config *c, int eye)
{
    warp_lens lens;
    for (int ch = 0; ch < 3; ch++)
        for (int i = 0; i < WARP_LENS_TERMS; i++) lens.ch[ch].k[i] = c->k[ch][i];
    double vw = c->panel_w / 2.0;
    lens.center_x = eye == WARP_EYE_LEFT ? c->lens_center[0] : vw - c->lens_center[0];
    lens.center_y = c->lens_center[1];
    lens.scale = c->lens_scale;
    return lens;
}

bool rt_config_parse_mode(const char *s, int *w, int *h, double *hz)
{
    *w = *h = 0;
    *hz = 0;
    if (strcmp(s, "auto") == 0) return true;
    char tail[8] = "";
    int n = sscanf(s, "%dx%d@%lf%7s", w, h, hz, tail);
    if (n == 2 && !strchr(s, '@')) return *w > 0 && *h > 0;
    return n == 3 && *w > 0 && *h > 0 && *hz > 0;
}

bool rt_config_parse_axes(const char *s, int map[3], int sign[3])
{
    int n = 0, used = 0;
    for (const char *p = s; *p && n <= 3;) {
        while (*p == ' ' || *p == '\t' || *p == ',') p++;
        if (!*p) break;
        int sg = 1;
        if (*p == '+' || *p == '-') sg = *p++ == '-' ? -1 : 1;
        if (*p < 'x' || *p > 'z' || n == 3) return false;
        int axis = *p++ - 'x';
        if (used & (1 << axis)) return false;
        used |= 1 << axis;
        map[n] = axis;
        sign[n] = sg;
        n++;
    }
    return n == 3;
}

bool rt_config_validate(const rt_config *c, rt_config_errors *err)
{
    int before = err ? err->count : 0;
    if (c->panel_w % 2) add_error(err, "[display] width = %d: must be even (two eyes side by side)", c->panel_w);
    warp_camera cam = rt_config_eye_camera(c, WARP_EYE_LEFT);
    const char *why = warp_camera_check(&cam);
    if (why) add_error(err, "[eye]: %s", why);
    char buf[200];
    warp_lens lens = rt_config_lens(c, WARP_EYE_LEFT);
    const char *lw = warp_lens_check(&lens, c->panel_w / 2, c->panel_h, buf, sizeof buf);
    if (lw) add_error(err, "[lens]: %s", lw);
    int map[3], sign[3];
    if (!rt_config_parse_axes(c->imu_axes, map, sign))
        add_error(err, "[imu] axes = '%s': expected three signed axes using each of x, y, z once, e.g. '-y +x +z'",
                  c->imu_axes);
    if (strcmp(c->imu_backend, "sim") != 0 && !c->imu_device[0])
        add_error(err, "[imu] device: required for backend = %s (a device path%s, or mock)", c->imu_backend,
                  strcmp(c->imu_backend, "hid") == 0 ? " or VVVV:PPPP" : "");
    if (strcmp(c->frames_backend, "sim") != 0 && !c->frames_device[0])
        add_error(err, "[frames] device: required for backend = %s (%s, or mock)", c->frames_backend,
                  strcmp(c->frames_backend, "usb") == 0 ? "the FunctionFS mount directory" : "a /dev/videoN path");
    const bool kms = strcmp(c->output, "kms") == 0;
    if (strcmp(c->vsync_backend, "kms") == 0 && !kms)
        add_error(err, "[vsync] backend = kms: needs [display] output = kms (the vblanks come from the KMS output; "
                       "output is %s)", c->output);
    if (kms && strcmp(c->sink, "null") != 0)
        add_error(err, "[display] sink = %s: output = kms shows the images on the panel; sinks take them only with "
                       "output = offscreen", c->sink);
    int mw, mh;
    double mhz;
    if (!rt_config_parse_mode(c->kms_mode, &mw, &mh, &mhz))
        add_error(err, "[display] kms_mode = '%s': expected auto, WxH or WxH@Hz (e.g. 2880x1600@90)", c->kms_mode);
    if (c->host_rate_hz > c->refresh_hz * 2)
        add_error(err, "[sim] host_rate_hz = %g: more than twice the display rate makes no sense", c->host_rate_hz);
    return (err ? err->count : 0) == before;
}

void rt_config_warnings(const rt_config *c, rt_config_errors *warn)
{
    /* A real board: named (the built-in default is "unnamed"), or with a device that is neither simulated nor
     * mocked. Such a board that displays nowhere is almost certainly a mistake in its board.ini. */
    bool named = c->board_name[0] && strcmp(c->board_name, "sim") != 0 && strcmp(c->board_name, "unnamed") != 0;
    bool real_imu = strcmp(c->imu_backend, "sim") != 0 && strcmp(c->imu_device, "mock") != 0;
    bool real_frames = strcmp(c->frames_backend, "sim") != 0 && strcmp(c->frames_device, "mock") != 0;
    bool real_vsync = strcmp(c->vsync_backend, "kms") == 0 ||
                      (strcmp(c->vsync_backend, "gpio") == 0 && strcmp(c->vsync_chip, "mock") != 0);
    if ((named || real_imu || real_frames || real_vsync) && strcmp(c->output, "offscreen") == 0 &&
        strcmp(c->sink, "null") == 0)
        add_error(warn, "board '%s' displays nowhere: [display] output = offscreen and sink = null (set output = kms "
                        "to show the panel)", c->board_name);
}

static void format_value(const rt_config *c, const keydef *k, char *buf, size_t len)
{
    const char *base = (const char *)c + k->off;
    switch (k->type) {
    case K_INT: snprintf(buf, len, "%d", *(const int *)base); break;
    case K_DOUBLE: snprintf(buf, len, "%g", *(const double *)base); break;
    case K_U64: snprintf(buf, len, "%llu", (unsigned long long)*(const uint64_t *)base); break;
    case K_STR:
    case K_CHOICE: snprintf(buf, len, "%s", base); break;
    case K_ENUM: snprintf(buf, len, "%s", k->names[*(const int *)base]); break;
    case K_DLIST: {
        buf[0] = 0;
        for (int i = 0; i < k->n; i++) {
            char one[32];
            snprintf(one, sizeof one, "%s%g", i ? " " : "", ((const double *)base)[i]);
            strncat(buf, one, len - strlen(buf) - 1);
        }
        break;
    }
    }
}

void rt_config_print_keys(FILE *out)
{
    rt_config d;
    rt_config_defaults(&d);
    const char *sec = "";
    for (int i = 0; i < NKEYS; i++) {
        if (strcmp(sec, keys[i].section) != 0) {
            sec = keys[i].section;
            fprintf(out, "  [%s]\n", sec);
        }
        char v[128];
        format_value(&d, &keys[i], v, sizeof v);
        fprintf(out, "    %-17s %s (default: %s)\n", keys[i].key, keys[i].help, v[0] ? v : "empty");
    }
}

void rt_config_print(const rt_config *c, FILE *out)
{
    const char *sec = "";
    for (int i = 0; i < NKEYS; i++) {
        if (strcmp(sec, keys[i].section) != 0) {
            sec = keys[i].section;
            fprintf(out, "%s[%s]\n", i ? "\n" : "", sec);
        }
        char v[128];
        format_value(c, &keys[i], v, sizeof v);
        fprintf(out, "%s = %s\n", keys[i].key, v);
    }
}
