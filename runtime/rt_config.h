/* SPDX-License-Identifier: MIT */
/* rt_config: hmdwarpd's settings: defaults, board.ini parsing (inih) with errors naming line and key, command-line
 * overrides (section.key=value) and validation. One table defines every key, its range and its help text. */
#ifndef RT_CONFIG_H
#define RT_CONFIG_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "warp/warp_camera.h"
#include "warp/warp_lens.h"
#include "warp/warp_registry.h"
#include "warp/warp_scan.h"

/* The warps the compositor runs; AUTO is not a warp but [warp] method = auto: rt_select picks one per vsync. */
typedef enum {
    RT_METHOD_NONE = 0,
    RT_METHOD_ROTATION = 1,
    RT_METHOD_RAYTRACE = 2,
    RT_METHOD_TRANSPARENCY = 3, /* opaque surface by the adaptive grid + A-buffer ray casting (000 §5.3) */
    RT_METHOD_OBJECTS = 4,      /* per-object forward warp with extrapolated object poses (002 §3.2) */
    RT_METHOD_RAYTRACE_MESH = 5, /* the raytrace at the lens mesh's vertices (warp_mesh_update_raytrace), per pixel
                                  * in the cells with a depth discontinuity (warp_mesh_trace): one resampling pass
                                  * from the host frame */
    RT_METHOD_COUNT,
    RT_METHOD_AUTO = RT_METHOD_COUNT
} rt_method;
const char *rt_method_name(rt_method m);
/* The registry's entry for a warp the compositor runs: use this, never a cast. RT_METHOD_AUTO is no warp, and its
 * value is the registry's first reference warp (iterative, which no pass runs): it reads as rotation here, what a
 * vsync shows when nothing was chosen. */
static inline warp_method rt_method_warp(rt_method m)
{
    return m >= 0 && m < RT_METHOD_COUNT ? (warp_method)m : WARP_METHOD_ROTATION;
}
/* [render] kernel's value names, in warp_resample_kernel_id order ("auto", "scalar", ...). */
const char *rt_kernel_name(int k);
/* The NULL-terminated names as "a, b, c" into buf (cut to len), for the messages that list what a setting takes. */
void rt_config_join_names(const char *const *names, char *buf, size_t len);

/* Room in rt_config's origin table (the key table holds fewer; rt_config.c checks at compile time). */
#define RT_CONFIG_MAX_KEYS 128
/* A board.ini is a few KB; anything this large is not one (a device node, a log file given by mistake). */
#define RT_CONFIG_MAX_FILE_KB 256
/* rt_config.origin of a key set by the calibration file's line L: RT_CONFIG_ORIGIN_CALIB + L (no file of
 * RT_CONFIG_MAX_FILE_KB has this many lines). */
#define RT_CONFIG_ORIGIN_CALIB (1 << 24)
/* [board] calibration's default: the state directory systemd's StateDirectory=hmdwarp gives the service. */
#define RT_CONFIG_CALIBRATION_DEFAULT "/var/lib/hmdwarp/calibration.ini"

typedef struct {
    char board_name[64];
    char board_arch[16];        /* any | aarch64 | x86_64 | arm: what board/flash.sh expects of a tree's binaries */
    char calibration[256];      /* the calibration file read after board.ini ("" = none; rt_calib.h) */
    /* [display] */
    int panel_w, panel_h;       /* whole panel; the left eye gets the left half, the right eye the right half */
    double refresh_hz;
    double photon_offset_ms;    /* vsync edge -> photons (e.g. half a frame for mid-scanout) */
    int scanout;                /* 0 global, 1 rolling (rt_config_scan) */
    int scan_direction;         /* a warp_scan_dir */
    double scan_ms;             /* rolling: first to last line lit; 0 = auto (RT_SCAN_AUTO_SHARE of a refresh) */
    char sink[16];              /* null | png | raw */
    int sink_every;
    char sink_path[256];
    char output[16];            /* offscreen | kms */
    char kms_device[128];       /* DRM card node */
    char kms_connector[32];     /* auto | HDMI-A-1 | DSI-1 | ... */
    char kms_mode[32];          /* auto (= panel size) | WxH | WxH@Hz */
    /* [render] */
    char renderer[16];          /* auto | cpu | gles */
    int threads;                /* compositor threads, caller included */
    int kernel;                 /* CPU resampling kernel, a warp_resample_kernel_id (auto, scalar, vector, ...) */
    int rt_priority;            /* SCHED_FIFO priority of the compositor when permitted; 0 = normal */
    double max_memory_mb;       /* budget for what the configuration allocates (rt_config_memory_bytes) */
    double stall_reserve_ms;    /* extra lead before each vsync for the scheduler's stalls (rt_pacer.c) */
    /* [eye]: the host's eye buffers (left eye; the right eye is its mirror image) */
    int eye_w, eye_h;
    double fov_deg[4];          /* left, right, up, down half-angles in degrees; NAN: auto (from the lens, warp_fov) */
    double guard_deg;           /* guard band added to each side of an auto FOV; NAN: auto (rt_config_guard_deg) */
    double near_z;
    double ipd;
    /* [lens] */
    int mesh_n;
    double k[3][WARP_LENS_TERMS];
    double lens_scale;          /* panel pixels per unit of normalised radius */
    double lens_center[2];      /* left eye, pixels within its half of the panel; mirrored for the right eye */
    double visible_radius;      /* the lens's visible disc, normalised radius; NAN: auto (warp_fov_visible_radius) */
    int lens_model;             /* warp_lens_model; the keys below belong to one model each (docs/lens.md) */
    double pano[3][4];          /* panotools: a b c d per channel */
    double pano_aberration[3];
    double pano_tan_scale;
    double vive_k[3][4];        /* vive: k1 k2 k3 k4 per channel */
    double vive_center[3][2];
    double vive_aspect;
    double vive_intrinsics[4];  /* fx cx fy cy */
    double vive_r2_cutoff;
    double cardboard_k[2];
    double cardboard_distances[3]; /* screen-to-lens, inter-lens, tray-to-lens, metres */
    int cardboard_alignment;    /* 0 bottom, 1 center, 2 top */
    double cardboard_screen[2]; /* the whole panel, metres */
    double opencv_camera[4];    /* fx fy cx cy, viewport pixels */
    double opencv_dist[5];      /* k1 k2 p1 p2 k3 */
    /* [warp] */
    rt_method method;
    double pixel_budget;        /* auto: largest predicted error accepted from a cheaper warp, eye-buffer pixels */
    int raytrace_steps;
    int edge_fill;              /* warp_edge_fill */
    double edge_jump;
    int mesh_cells;             /* raytrace_mesh: 1 per-pixel rays in its cells with a depth discontinuity, 0 not */
    /* [imu] [frames] [vsync] backends and their devices; device "mock" puts the simulated board's device behind
     * the real backend's decoding (HID reports, I2C register maps, GPIO edges, framelink, V4L2 layout) */
    char imu_backend[16], frames_backend[16], vsync_backend[16];
    char imu_device[128];       /* hid: /dev/hidrawN or VVVV:PPPP; i2c: /dev/i2c-N; or mock */
    int imu_address;            /* i2c */
    char imu_chip[16];          /* i2c: auto | mpu6050 | mpu9250 | icm42688 */
    int imu_gyro_dps, imu_accel_g;
    char imu_axes[32];          /* mounting: head x y z as signed IMU axes, e.g. "-y +x +z" */
    /* IMU calibration (rt_calib.h): the mounting as any rotation ("" = imu_axes), biases in the IMU's own frame */
    char imu_mount[96];
    double imu_gyro_bias[3];    /* rad/s, subtracted from every gyro sample */
    double imu_accel_bias[3];   /* m/s^2, subtracted from every accelerometer sample */
    double imu_gravity;         /* what the accelerometer reads at rest (after accel_bias): samples scaled to 9.81 */
    char frames_device[128];    /* usb: FunctionFS mount; v4l2: /dev/videoN; or mock */
    char v4l2_format[16];       /* auto | yuyv | nv12 | bgr32 | rgb24 */
    int frames_depth;           /* v4l2: a depth plane is packed beside the colour */
    double max_frame_mb;
    double pose_rate_hz;        /* board -> host pose messages */
    char frames_codecs[64];     /* usb, socket: codecs announced to hosts: auto, or a list of raw zstd jpeg h264 hevc */
    int decode_threads;         /* usb, socket: threads a frame's compressed planes decode on */
    char video_decoder[16];     /* software | v4l2m2m */
    double link_mbps;           /* mock usb and socket links: a token-bucket limit in MB/s (10^6 B/s), 0 = none */
    char vsync_chip[64];        /* gpio: gpiochipN, N, /dev/gpiochipN, or mock */
    int vsync_line;
    int vsync_falling;          /* edge: 0 rising, 1 falling */
    /* [mock] fault injection into mock devices (hardware-in-the-loop style runs) */
    int mock_corrupt_every, mock_truncate_every;
    double mock_imu_unplug_at_s, mock_imu_unplug_for_s;
    double mock_host_stall_at_s, mock_host_stall_for_s;
    double mock_vsync_jitter_us, mock_edges_stop_at_s, mock_edges_stop_for_s;
    /* [sim] */
    char scene[32], trace[32];
    double duration_s;
    uint64_t seed;
    double host_rate_hz;
    double host_latency_ms;     /* transport latency added after the simulated render */
    int host_threads;           /* threads the simulated host renders with */
    double imu_rate_hz;
    double imu_rest_s;          /* the simulated headset lies still this long before the motion starts */
    double gyro_noise, gyro_bias[3], accel_noise;
    double eval_every_ms;       /* accuracy sample period; 0 = off */
    /* [telemetry] */
    char csv[256];
    char stats[256];            /* key=value summary written at exit (tests, hardware-in-the-loop scenarios) */
    /* Where each key was set, so that errors about several keys can name the line of each: indexed like the key
     * table; 0 = default, > 0 = line in origin_file (or, from RT_CONFIG_ORIGIN_CALIB up, line - that in
     * calib_file), < 0 = the -Nth command-line override. */
    int32_t origin[RT_CONFIG_MAX_KEYS];
    int overrides;              /* command-line overrides applied so far */
    char origin_file[256];
    char calib_file[256];       /* the calibration file read (rt_config_load_calibration), "" = none */
    char live_stats[256];       /* the same key=value set, rewritten each second while running ("" = off, auto) */
    double csv_max_mb;          /* the per-vsync CSV moves to CSV.1 at this size (0 = never) */
} rt_config;

void rt_config_defaults(rt_config *c);

/* Error list filled by parsing and validation. */
typedef struct {
    int count;
    char msg[16][512];
} rt_config_errors;

/* Parses a board.ini file. Every problem (unknown section or key, bad value, syntax, a line longer than inih
 * reads) is recorded with its line number, in line order; returns true when there were none. A path that is not a
 * regular file, or a file over RT_CONFIG_MAX_FILE_KB, is refused before anything is parsed. */
bool rt_config_load(rt_config *c, const char *path, rt_config_errors *err);
/* Parses a calibration file (board.ini's syntax; rt_calib.h): only [lens] and [imu]'s calibration keys (mount,
 * axes, gyro_bias, accel_bias, gravity) are allowed, every other one is an error naming path:line. Records path
 * in c->calib_file; errors about its keys name it. Same refusals as rt_config_load. */
bool rt_config_load_calibration(rt_config *c, const char *path, rt_config_errors *err);
/* Parses INI text (tests, embedded defaults); `name` is used in messages. */
bool rt_config_load_string(rt_config *c, const char *text, const char *name, rt_config_errors *err);
/* Applies one "section.key=value" override from the command line. */
bool rt_config_set(rt_config *c, const char *assignment, rt_config_errors *err);
/* Cross-key checks (camera, lens folding over the viewport, sizes, memory); each message names where every key it
 * involves was set. */
bool rt_config_validate(const rt_config *c, rt_config_errors *err);

/* Wire size of the smallest host frame the configured eye size and planes make (colour, depth as float32, ids and
 * layers when the warp method uses them): what [frames] max_frame_mb must hold on the usb and socket backends. */
uint64_t rt_config_frame_bytes(const rt_config *c);
/* Estimate of the memory the configuration allocates at start (swapchain, frame slots, the warps' eye-sized
 * buffers, the frame backend's buffers): the large allocations only, checked against [render] max_memory_mb. */
uint64_t rt_config_memory_bytes(const rt_config *c);

/* Warnings that do not stop a run (--check-config prints them as `warning:` lines): a real board (named, or with
 * a real device backend) that displays nowhere (output = offscreen, sink = null); a configuration whose memory
 * estimate exceeds this machine's physical memory (sysconf). */
void rt_config_warnings(const rt_config *c, rt_config_errors *warn);

/* Parses a [display] kms_mode: "auto" gives 0 x 0 at 0 Hz, "WxH" any refresh (hz 0), "WxH@Hz". */
bool rt_config_parse_mode(const char *s, int *w, int *h, double *hz);
/* [frames] codecs as DRV_CODEC_BIT()s (auto: every codec this build decodes; RAW always); false with the first
 * unknown or undecodable name in err. */
bool rt_config_parse_codecs(const char *s, unsigned *mask, char *err, int errlen);
/* What this board announces to hosts: [frames] codecs, where auto on an unlimited local link (the socket or the mock
 * USB link with link_mbps 0) is raw alone: there compressing costs host and board time and saves nothing. */
bool rt_config_frames_codecs(const rt_config *c, unsigned *mask, char *err, int errlen);

/* Parses a mounting string ("-y +x +z": head axis i = sign[i] * IMU axis map[i]). */
bool rt_config_parse_axes(const char *s, int map[3], int sign[3]);

/* Derived objects. eye = WARP_EYE_LEFT / WARP_EYE_RIGHT. */
warp_camera rt_config_eye_camera(const rt_config *c, int eye);
warp_lens rt_config_lens(const rt_config *c, int eye);
/* The FOV from the lens ([eye] fov = auto, the default; warp/warp_fov.h): with auto, rt_config_eye_camera's tangents
 * are those the eye's visible panel pixels see in any channel, plus the guard band on each side. */
bool rt_config_fov_auto(const rt_config *c);
/* [eye] guard_deg, or its default: the head's expected speed RT_GUARD_HEAD_DEG_S over the frame age the board
 * expects, two panel periods plus photon_offset_ms (003 §4.3; README, "Field of view"). */
#define RT_GUARD_HEAD_DEG_S 100.0
double rt_config_guard_deg(const rt_config *c);
/* [lens] visible_radius for the eye's viewport (auto resolved), normalised lens units; 0 when none. */
double rt_config_visible_radius(const rt_config *c, int eye);
/* One line on the eyes' fields for --check-config and the start-up log: the half-angles per eye, and with auto the
 * visible radius, the guard band and the share of the panel the lens shows. */
void rt_config_fov_line(const rt_config *c, char *buf, int len);
/* The eye's camera with its tangents as computed, or NULL; else a message in buf naming what is wrong. */
const char *rt_config_eye_camera_check(const rt_config *c, int eye, warp_camera *cam, char *buf, int buflen);
/* [display] scanout, scan_direction, scan_ms (auto resolved) over the whole panel. */
#define RT_SCAN_AUTO_SHARE 0.9
warp_scan rt_config_scan(const rt_config *c);

/* Writes every key with its default and meaning (for --help and the README). */
void rt_config_print_keys(FILE *out);
/* Writes the effective configuration as INI. */
void rt_config_print(const rt_config *c, FILE *out);

#endif
