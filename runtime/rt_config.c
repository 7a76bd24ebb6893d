/* SPDX-License-Identifier: MIT */
/* rt_config: hmdwarpd's settings: defaults, board.ini parsing (inih) with errors naming line and key, command-line
 * overrides (section.key=value) and validation. One table defines every key, its range and its help text. */
#include "runtime/rt_config.h"

#include <errno.h>
#include <fcntl.h>
#include <ini.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "drivers/drv_codec.h"
#include "drivers/drv_framelink.h"
#include "drivers/drv_frames_socket.h"
#include "drivers/drv_frames_usb.h"
#include "warp/warp_err.h"
#include "warp/warp_fov.h"
#include "drivers/drv_v4l2_inband.h"
#include "runtime/rt_calib.h"
#include "warp/warp_head.h"
#include "warp/warp_lens_models.h"
#include "warp/warp_registry.h"

/* [warp] method: the registry's runtime methods, then auto (RT_METHOD_AUTO, rt_select's choice per vsync). */
static const char *const method_names[] = {WARP_RUNTIME_METHOD_NAMES "auto", NULL};
static const char *const edge_fill_names[] = {"far", "linear", NULL};
static const char *const sink_names[] = {"null", "png", "raw", NULL};
static const char *const renderer_names[] = {"auto", "cpu", "gles", NULL};
/* in warp_resample_kernel_id order: the index is the id */
static const char *const kernel_names[] = {"auto", "scalar", "vector", "avx2", "avx512", NULL};
static const char *const output_names[] = {"offscreen", "kms", NULL};
static const char *const imu_names[] = {"sim", "hid", "i2c", NULL};
static const char *const frames_names[] = {"sim", "usb", "v4l2", "socket", NULL};
static const char *const vsync_names[] = {"sim", "gpio", "timer", "kms", NULL};
static const char *const chip_names[] = {"auto", "mpu6050", "mpu9250", "icm42688", NULL};
static const char *const v4l2_format_names[] = {"auto", "yuyv", "nv12", "bgr32", "rgb24", NULL};
static const char *const bool_names[] = {"false", "true", NULL};
static const char *const edge_names[] = {"rising", "falling", NULL};
static const char *const arch_names[] = {"any", "aarch64", "x86_64", "arm", NULL};
/* K_DOUBLE and K_DLIST keys whose `names` is auto_names also take the word auto, stored as NAN (every element). */
static const char *const auto_names[] = {"auto", NULL};
/* [lens] model, in warp_lens_model order */
static const char *const lens_model_names[] = {"poly", "panotools", "vive", "cardboard", "opencv", NULL};
static const char *const alignment_names[] = {"bottom", "center", "top", NULL};
/* [display] scanout and scan_direction: indexes are warp_scan's (rolling = true, warp_scan_dir) */
static const char *const scanout_names[] = {"global", "rolling", NULL};
static const char *const scan_direction_names[] = {"top_to_bottom", "bottom_to_top", "left_to_right", "right_to_left",
                                                   NULL};

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
/* A mock device's fault window, two keys: NAME_at_s, when it starts (run time; 0 = never), and NAME_for_s. */
#define MOCK_WINDOW(name, starts, lasts)                                                                               \
    {"mock", #name "_at_s", K_DOUBLE, F(mock_##name##_at_s), 0, 0, 1e6, NULL,                                          \
     starts " at this run time (0 = never)"},                                                                          \
    {"mock", #name "_for_s", K_DOUBLE, F(mock_##name##_for_s), 0, 0, 1e6, NULL, lasts}

static const keydef keys[] = {
    {"board", "name", K_STR, F(board_name), S(board_name), 0, 0, NULL, "board name shown in the summary"},
    {"board", "arch", K_CHOICE, F(board_arch), S(board_arch), 0, 0, arch_names,
     "the board's CPU architecture (any, aarch64, x86_64, arm): board/flash.sh refuses a tree built for another"},
    {"board", "calibration", K_STR, F(calibration), S(calibration), 0, 0, NULL,
     "calibration file read after board.ini ([lens] and [imu] mount, axes, gyro_bias, accel_bias, gravity; "
     "--set still overrides it; hmdwarpd --calibrate-imu writes it); empty = none. A missing default file is "
     "fine, a missing named one an error (--calibration PATH names one)"},
    {"display", "width", K_INT, F(panel_w), 0, 16, WARP_MAX_SIDE, NULL,
     "panel width in pixels (both eyes side by side)"},
    {"display", "height", K_INT, F(panel_h), 0, 16, WARP_MAX_SIDE, NULL, "panel height in pixels"},
    {"display", "refresh_hz", K_DOUBLE, F(refresh_hz), 0, 10, 500, NULL, "panel refresh rate"},
    {"display", "photon_offset_ms", K_DOUBLE, F(photon_offset_ms), 0, 0, 100, NULL,
     "time from the vsync edge to when the photons are seen (prediction target); on a rolling panel when the "
     "middle of the scan is seen"},
    /* scanout (#20): how the panel lights its lines */
    {"display", "scanout", K_ENUM, F(scanout), 0, 0, 0, scanout_names,
     "global (every pixel lit at once, at photon_offset_ms) or rolling (lines lit one after another over scan_ms "
     "centred on photon_offset_ms: the warp then predicts the pose per mesh row at each row's photon time)"},
    {"display", "scan_direction", K_ENUM, F(scan_direction), 0, 0, 0, scan_direction_names,
     "scanout = rolling: which panel line lights first: top_to_bottom, bottom_to_top, left_to_right or "
     "right_to_left (a portrait panel mounted sideways scans across the eyes)"},
    {"display", "scan_ms", K_DOUBLE, F(scan_ms), 0, 0, 1000, NULL,
     "scanout = rolling: first line lit to last line lit, at most a refresh period; 0 = auto: 90 % of the refresh "
     "period (a panel lights each line as its data arrives, and the data fills the frame but for the vertical "
     "blanking, a few to 10 % of the lines)"},
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
     "CPU resampling kernel: auto (the fastest this CPU runs, timed at start-up), scalar, vector, avx2 or avx512 "
     "(x86 only); all give the same image bit for bit, they differ in speed (an emulator may run the plain ones "
     "faster)"},
    {"render", "rt_priority", K_INT, F(rt_priority), 0, 0, 99, NULL,
     "SCHED_FIFO priority for the compositor when permitted (0 = normal scheduling)"},
    {"render", "max_memory_mb", K_DOUBLE, F(max_memory_mb), 0, 16, 1048576, NULL,
     "memory the configuration may allocate at start, MiB (swapchain, frame slots, the warps' buffers, the frame "
     "backend's buffers; an estimate of the large ones): a board.ini whose eye or panel size or max_frame_mb needs "
     "more fails --check-config instead of locking the board's memory; raise it on a board with more to spare"},
    {"render", "stall_reserve_ms", K_DOUBLE, F(stall_reserve_ms), 0, 0, 100, NULL,
     "extra time each pass starts ahead of its vsync, beyond its longest recent warp, so that the scheduler keeping "
     "the compositor off the CPU that long (a VM, a shared desktop) costs no vsync; at most a period; adds as "
     "much motion-to-photon latency (0 on a board whose compositor has its cores; the GLES path takes at most "
     "what fits in one period)"},
    {"eye", "width", K_INT, F(eye_w), 0, 16, 8192, NULL, "host eye buffer width"},
    {"eye", "height", K_INT, F(eye_h), 0, 16, 8192, NULL, "host eye buffer height"},
    {"eye", "fov", K_DLIST, F(fov_deg), 4, 1, 89, auto_names,
     "auto (what the eye's visible panel pixels see through the lens in any colour channel, plus guard_deg on each "
     "side; --check-config prints it), or the left eye's half-angles in degrees: left right up down (the right eye "
     "is mirrored)"},
    {"eye", "guard_deg", K_DOUBLE, F(guard_deg), 0, 0, 45, auto_names,
     "fov = auto: degrees added on each side of the lens's field so a rotation warp finds rendered pixels during "
     "head turns (003 4.3); auto: 100 deg/s of head speed over two panel periods plus photon_offset_ms"},
    {"eye", "near", K_DOUBLE, F(near_z), 0, 0.001, 10, NULL, "near plane in metres"},
    {"eye", "ipd", K_DOUBLE, F(ipd), 0, 0.04, 0.09, NULL, "interpupillary distance in metres"},
    {"lens", "mesh", K_INT, F(mesh_n), 0, 2, 1024, NULL, "distortion mesh vertices per side (N x N)"},
    /* h-lens: the lens models (docs/lens.md); center and scale serve poly and panotools */
    {"lens", "model", K_ENUM, F(lens_model), 0, 0, 0, lens_model_names,
     "lens model: poly (k_red/k_green/k_blue), panotools (OpenHMD: pano_*, aberration, pano_tan_scale), vive "
     "(Monado/SteamVR: vive_*), cardboard (viewer profile: cardboard_*) or opencv (camera YAML: opencv_*); "
     "hmdwarp-lens import writes any of them"},
    {"lens", "k_red", K_DLIST, F(k[0]), WARP_LENS_TERMS, -100, 100, NULL,
     "poly: red radial scale polynomial k0 k1 k2 k3: s(r^2) = k0 + k1 r^2 + k2 r^4 + k3 r^6 (the defaults are "
     "the Oculus Rift DK1's DistortionK 1 0.22 0.24 0 from the Oculus SDK 0.2 HMDInfo, times 0.996 for red and "
     "1.008 for blue; that SDK's DK1 ChromaAbCorrection has 0.996 and 1.014)"},
    {"lens", "k_green", K_DLIST, F(k[1]), WARP_LENS_TERMS, -100, 100, NULL, "green polynomial"},
    {"lens", "k_blue", K_DLIST, F(k[2]), WARP_LENS_TERMS, -100, 100, NULL, "blue polynomial"},
    {"lens", "scale", K_DOUBLE, F(lens_scale), 0, 1, 100000, NULL, "panel pixels per unit of normalised radius"},
    {"lens", "center", K_DLIST, F(lens_center), 2, -100000, 100000, NULL,
     "left eye's lens centre x y in pixels within its half of the panel (mirrored for the right eye)"},
    {"lens", "visible_radius", K_DOUBLE, F(visible_radius), 0, 0.01, 100, auto_names,
     "radius of the disc of the panel seen through the lens, in the lens's normalised units (scale pixels); "
     "pixels outside it are black and left unrendered (the hidden-area mask); auto: the largest disc around the "
     "lens centre inside the eye's half of the panel"},
    {"lens", "pano_red", K_DLIST, F(pano[0]), 4, -100, 100, NULL,
     "panotools: red a b c d, F(r) = d + c r + b r^2 + a r^3 of the radius r in units of scale (OpenHMD's "
     "universal_distortion_k)"},
    {"lens", "pano_green", K_DLIST, F(pano[1]), 4, -100, 100, NULL, "panotools: green a b c d"},
    {"lens", "pano_blue", K_DLIST, F(pano[2]), 4, -100, 100, NULL, "panotools: blue a b c d"},
    {"lens", "aberration", K_DLIST, F(pano_aberration), 3, 0.5, 2, NULL,
     "panotools: red green blue scale of the displaced radius (OpenHMD's universal_aberration_k)"},
    {"lens", "pano_tan_scale", K_DOUBLE, F(pano_tan_scale), 0, 0.01, 100, NULL,
     "panotools: view tangent per unit of displaced radius (OpenHMD: WarpScale / eye-to-screen distance)"},
    {"lens", "vive_red", K_DLIST, F(vive_k[0]), 4, -100, 100, NULL,
     "vive: red k1 k2 k3 k4, F = 1 / (1 + k1 r^2 + k2 r^4 + k3 r^6) + k4 (the config JSON's distortion_red "
     "coeffs)"},
    {"lens", "vive_green", K_DLIST, F(vive_k[1]), 4, -100, 100, NULL, "vive: green k1 k2 k3 k4 (distortion)"},
    {"lens", "vive_blue", K_DLIST, F(vive_k[2]), 4, -100, 100, NULL, "vive: blue k1 k2 k3 k4 (distortion_blue)"},
    {"lens", "vive_center_red", K_DLIST, F(vive_center[0]), 2, -10, 10, NULL,
     "vive: red centre_x centre_y in the JSON's units (2 = the viewport's width; y divided by the aspect)"},
    {"lens", "vive_center_green", K_DLIST, F(vive_center[1]), 2, -10, 10, NULL, "vive: green centre_x centre_y"},
    {"lens", "vive_center_blue", K_DLIST, F(vive_center[2]), 2, -10, 10, NULL, "vive: blue centre_x centre_y"},
    {"lens", "vive_aspect", K_DOUBLE, F(vive_aspect), 0, 0.1, 10, NULL,
     "vive: physical_aspect_x_over_y of one eye's viewport"},
    {"lens", "vive_intrinsics", K_DLIST, F(vive_intrinsics), 4, -100, 100, NULL,
     "vive: the left eye's intrinsics fx cx fy cy (matrix entries [0][0] [0][2] [1][1] [1][2])"},
    {"lens", "vive_r2_cutoff", K_DOUBLE, F(vive_r2_cutoff), 0, 0, 100, NULL,
     "vive: undistort_r2_cutoff, where the lens's view ends (beyond it the model continues along its tangent line; "
     "0 = none)"},
    {"lens", "cardboard_k", K_DLIST, F(cardboard_k), 2, -100, 100, NULL,
     "cardboard: k1 k2 of the viewer profile, F = 1 + k1 r^2 + k2 r^4 of the screen tan-angle r"},
    {"lens", "cardboard_distances", K_DLIST, F(cardboard_distances), 3, 0.001, 1, NULL,
     "cardboard: screen_to_lens inter_lens tray_to_lens distances, metres"},
    {"lens", "cardboard_alignment", K_ENUM, F(cardboard_alignment), 0, 0, 0, alignment_names,
     "cardboard: vertical_alignment (bottom, center, top): where tray_to_lens is measured from"},
    {"lens", "cardboard_screen", K_DLIST, F(cardboard_screen), 2, 0.001, 10, NULL,
     "cardboard: the whole panel's width and height, metres"},
    {"lens", "opencv_camera", K_DLIST, F(opencv_camera), 4, -100000, 100000, NULL,
     "opencv: the left eye's camera_matrix fx fy cx cy, viewport pixels (view tangent -> panel pixel)"},
    {"lens", "opencv_dist", K_DLIST, F(opencv_dist), 5, -100, 100, NULL,
     "opencv: distortion_coefficients k1 k2 p1 p2 k3"},
    /* the methods themselves are listed from the registry (method_help) */
    {"warp", "method", K_ENUM, F(method), 0, 0, 0, method_names,
     "or auto (per vsync, the cheapest warp whose predicted error stays under pixel_budget; short of time, a warp "
     "steps down its fallback:"},
    {"warp", "pixel_budget", K_DOUBLE, F(pixel_budget), 0, 0.01, 100, NULL,
     "auto: largest on-screen error in eye-buffer pixels accepted from a cheaper warp (004 eqs. 5-7 bound)"},
    {"warp", "raytrace_steps", K_INT, F(raytrace_steps), 0, 1, 100000, NULL, "raytrace step budget per ray"},
    {"warp", "edge_fill", K_ENUM, F(edge_fill), 0, 0, 0, edge_fill_names,
     "raytrace disocclusion fill: far (far side) or linear (003 §4.4)"},
    {"warp", "edge_jump", K_DOUBLE, F(edge_jump), 0, 0.001, 10, NULL,
     "relative inverse-depth jump per step that counts as an occlusion edge"},
    {"warp", "mesh_cells", K_ENUM, F(mesh_cells), 0, 0, 0, bool_names,
     "raytrace_mesh: per-pixel rays in the lens mesh cells with a depth discontinuity (true), or its vertices alone "
     "(false: a CPU board's choice, a fraction of the cost, less accurate at depth edges; make bench times and "
     "scores both)"},
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
     "mounting: the head's x y z axes as signed IMU axes, e.g. '-y +x +z' (head x = IMU -y); [imu] mount "
     "takes any rotation"},
    {"imu", "mount", K_STR, F(imu_mount), S(imu_mount), 0, 0, NULL,
     "mounting as any rotation (empty = [imu] axes; set, it wins over axes): signed axes '-y +x +z', "
     "'quat W X Y Z' (the IMU's orientation in the head frame) or 'rpy ROLL PITCH YAW' (degrees, as mounted on the "
     "visor: yaw about head +y, then pitch about the turned x, then roll about the turned z); calibration"},
    {"imu", "gyro_bias", K_DLIST, F(imu_gyro_bias), 3, -1, 1, NULL,
     "gyro bias x y z in the IMU's own axes, rad/s, subtracted before fusion (hmdwarpd --calibrate-imu "
     "measures it); calibration"},
    {"imu", "accel_bias", K_DLIST, F(imu_accel_bias), 3, -5, 5, NULL,
     "accelerometer bias x y z in the IMU's own axes, m/s^2, subtracted before fusion; calibration"},
    {"imu", "gravity", K_DOUBLE, F(imu_gravity), 0, 5, 15, NULL,
     "what the accelerometer reads at rest (m/s^2, after accel_bias): samples are scaled by 9.81 / gravity "
     "(hmdwarpd --calibrate-imu measures it); calibration"},
    {"imu", "rate_hz", K_DOUBLE, F(imu_rate_hz), 0, 10, 10000, NULL, "IMU sample rate"},
    {"frames", "backend", K_CHOICE, F(frames_backend), S(frames_backend), 0, 0, frames_names,
     "host frame source: sim (simulated host), usb (FunctionFS gadget), v4l2 (HDMI/CSI capture) or socket (a "
     "local process through a Unix socket, the USB wire format; docs/framelink.md)"},
    {"frames", "device", K_STR, F(frames_device), S(frames_device), 0, 0, NULL,
     "usb: FunctionFS mount directory; v4l2: capture device; socket: the path to listen at (empty: "
     DRV_FRAMES_SOCKET_DEFAULT "); mock (usb, v4l2): the simulated host over the real wire format"},
    {"frames", "format", K_CHOICE, F(v4l2_format), S(v4l2_format), 0, 0, v4l2_format_names,
     "v4l2: capture pixel format (auto picks one the device offers)"},
    {"frames", "depth", K_ENUM, F(frames_depth), 0, 0, 0, bool_names,
     "v4l2: the host packs a depth plane beside the colour"},
    {"frames", "max_frame_mb", K_DOUBLE, F(max_frame_mb), 0, 0.01, 4096, NULL,
     "largest host frame accepted, MiB (larger ones are rejected unread)"},
    {"frames", "pose_rate_hz", K_DOUBLE, F(pose_rate_hz), 0, 1, 2000, NULL,
     "usb, socket: how often the board sends its predicted head pose to the host"},
    {"frames", "codecs", K_STR, F(frames_codecs), S(frames_codecs), 0, 0, NULL,
     "usb, socket: the codecs the board tells hosts it decodes (framelink v2; docs/framelink.md): auto (every one "
     "this build decodes; raw alone on a socket or mock link without link_mbps, where compressing saves nothing) or a "
     "list of "
     "raw, zstd, jpeg, h264, hevc; raw (v1 frames) is always accepted"},
    {"frames", "decode_threads", K_INT, F(decode_threads), 0, 1, DRV_FRAMES_USB_DECODE_THREADS_MAX, NULL,
     "usb, socket: threads a frame's compressed planes decode on (eyes and JPEG slices in parallel)"},
    {"frames", "video_decoder", K_CHOICE, F(video_decoder), S(video_decoder), 0, 0, drv_frames_usb_video_decoders,
     "usb, socket: H.264/HEVC colour decoder: software (libavcodec) or v4l2m2m (the board's hardware decoder)"},
    {"frames", "link_mbps", K_DOUBLE, F(link_mbps), 0, 0, 100000, NULL,
     "mock usb and socket links: the most they carry, MB/s (10^6 bytes), as a real link would (USB 2.0 ~40, USB 3 "
     "~400; docs/link-budget.md); 0 = unlimited"},
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
     "mock devices: garble every Nth HID report / host frame (USB: a flipped byte; V4L2: a damaged band or a "
     "picture without it, in turn) (0 = never)"},
    {"mock", "truncate_every", K_INT, F(mock_truncate_every), 0, 0, 1000000, NULL,
     "mock host link: cut every Nth frame short (0 = never)"},
    MOCK_WINDOW(imu_unplug, "mock HID IMU: unplug", "... and replug after"),
    MOCK_WINDOW(host_stall, "mock host link: the host stops sending", "... for this long"),
    {"mock", "vsync_jitter_us", K_DOUBLE, F(mock_vsync_jitter_us), 0, 0, 10000, NULL, "mock TE edges: jitter"},
    MOCK_WINDOW(edges_stop, "mock TE edges: stop", "... for this long"),
    {"telemetry", "csv", K_STR, F(csv), S(csv), 0, 0, NULL, "write one CSV row per vsync to this file"},
    {"telemetry", "stats", K_STR, F(stats), S(stats), 0, 0, NULL,
     "write the run summary as key=value lines to this file at exit (for scripts)"},
    {"telemetry", "live_stats", K_STR, F(live_stats), S(live_stats), 0, 0, NULL,
     "rewrite those key=value lines to this file every second while running, for hmdwarp-top (empty = off; auto = "
     "/run/hmdwarp/stats when that directory is writable)"},
    {"telemetry", "csv_max_mb", K_DOUBLE, F(csv_max_mb), 0, 0, 1e6, NULL,
     "rotate the per-vsync CSV at this size: the full one becomes FILE.1 (0 = never)"},
};
#undef MOCK_WINDOW
#define NKEYS (int)(sizeof keys / sizeof keys[0])
_Static_assert(NKEYS <= RT_CONFIG_MAX_KEYS, "rt_config's origin table is smaller than the key table");

void rt_config_defaults(rt_config *c)
{
    memset(c, 0, sizeof *c);
    snprintf(c->board_name, sizeof c->board_name, "unnamed");
    snprintf(c->board_arch, sizeof c->board_arch, "any");
    c->panel_w = 2880;
    c->panel_h = 1600;
    c->refresh_hz = 90;
    c->photon_offset_ms = 5.5;
    c->scanout = 0;        /* global: what every board did before scanout was a key */
    c->scan_direction = 0; /* top_to_bottom */
    c->scan_ms = 0;        /* auto (rt_config_scan) */
    snprintf(c->sink, sizeof c->sink, "null");
    c->sink_every = 90;
    snprintf(c->sink_path, sizeof c->sink_path, "build/frames");
    snprintf(c->output, sizeof c->output, "offscreen");
    snprintf(c->kms_device, sizeof c->kms_device, "/dev/dri/card0");
    snprintf(c->kms_connector, sizeof c->kms_connector, "auto");
    snprintf(c->kms_mode, sizeof c->kms_mode, "auto");
    snprintf(c->renderer, sizeof c->renderer, "auto");
    snprintf(c->live_stats, sizeof c->live_stats, "auto");
    c->csv_max_mb = 64; /* 16 MB an hour at 90 Hz: four hours in CSV, four in CSV.1 */
    c->kernel = 0; /* auto */
    c->threads = 2;
    c->rt_priority = 10;
    c->max_memory_mb = 2048; /* half of a 4 GB board: the OS, the page cache and the USB gadget need the rest */
    c->eye_w = 1440;
    c->eye_h = 1600;
    for (int i = 0; i < 4; i++) c->fov_deg[i] = NAN; /* auto: from the lens (warp_fov) */
    c->guard_deg = NAN;
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
    c->visible_radius = NAN;
    c->lens_model = WARP_LENS_POLY;
    for (int ch = 0; ch < 3; ch++) {
        c->pano[ch][3] = 1; /* a b c d = 0 0 0 1: no distortion */
        c->pano_aberration[ch] = 1;
        c->vive_intrinsics[0] = c->vive_intrinsics[2] = 1;
    }
    c->pano_tan_scale = 1;
    c->vive_aspect = 0.9; /* Monado's default (vive_init_defaults) */
    c->cardboard_distances[0] = 0.042; /* Cardboard v1's profile (sdk/qrcode/cardboard_v1) */
    c->cardboard_distances[1] = 0.06;
    c->cardboard_distances[2] = 0.035;
    c->cardboard_k[0] = 0.441;
    c->cardboard_k[1] = 0.156;
    c->cardboard_screen[0] = 0.12096; /* a 5.5" 16:9 phone */
    c->cardboard_screen[1] = 0.06804;
    c->opencv_camera[0] = c->opencv_camera[1] = 720;
    c->opencv_camera[2] = 760;
    c->opencv_camera[3] = 800;
    c->method = RT_METHOD_ROTATION;
    c->pixel_budget = 0.5;
    c->raytrace_steps = 512;
    c->edge_fill = 0;
    c->edge_jump = 0.1;
    c->mesh_cells = 1;
    snprintf(c->imu_backend, sizeof c->imu_backend, "sim");
    snprintf(c->frames_backend, sizeof c->frames_backend, "sim");
    snprintf(c->vsync_backend, sizeof c->vsync_backend, "sim");
    c->imu_address = 0x68;
    snprintf(c->imu_chip, sizeof c->imu_chip, "auto");
    c->imu_gyro_dps = 2000;
    c->imu_accel_g = 16;
    snprintf(c->imu_axes, sizeof c->imu_axes, "+x +y +z");
    snprintf(c->calibration, sizeof c->calibration, "%s", RT_CONFIG_CALIBRATION_DEFAULT);
    c->imu_gravity = 9.81;
    snprintf(c->v4l2_format, sizeof c->v4l2_format, "auto");
    c->max_frame_mb = 64;
    c->pose_rate_hz = 500;
    snprintf(c->frames_codecs, sizeof c->frames_codecs, "auto");
    c->decode_threads = 2;
    snprintf(c->video_decoder, sizeof c->video_decoder, "software");
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

void rt_config_join_names(const char *const *names, char *buf, size_t len)
{
    buf[0] = 0;
    for (int i = 0; names[i]; i++) {
        strncat(buf, i ? ", " : "", len - strlen(buf) - 1);
        strncat(buf, names[i], len - strlen(buf) - 1);
    }
}

static bool set_value(rt_config *c, const keydef *k, const char *section, const char *key, const char *value,
                      const char *where, rt_config_errors *err);

/* Sets one key; `where` is "file:line" or "command line" for messages, `origin` goes to c->origin (see there). */
static bool set_key(rt_config *c, const char *section, const char *key, const char *value, const char *where,
                    int origin, rt_config_errors *err)
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
    /* Recorded now and put back if the value is refused: a refused value leaves the key as it was. */
    const int idx = (int)(k - keys);
    const int32_t old_origin = c->origin[idx];
    c->origin[idx] = origin;
    if (!set_value(c, k, section, key, value, where, err)) {
        c->origin[idx] = old_origin;
        return false;
    }
    return true;
}

static bool set_value(rt_config *c, const keydef *k, const char *section, const char *key, const char *value,
                      const char *where, rt_config_errors *err)
{
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
        if (k->names == auto_names && strcmp(value, "auto") == 0) {
            *(double *)base = NAN;
            return true;
        }
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
            rt_config_join_names(k->names, names, sizeof names);
            add_error(err, "%s: [%s] %s = '%s': not available in this build (expected one of: %s)", where, section,
                      key, value, names);
        }
        return false;
    case K_DLIST: {
        double v[8];
        int n = 0;
        if (k->names == auto_names && strcmp(value, "auto") == 0) {
            for (int i = 0; i < k->n; i++) ((double *)base)[i] = NAN;
            return true;
        }
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
            add_error(err, "%s: [%s] %s = '%s': expected %s%d numbers from %g to %g", where, section, key, value,
                      k->names == auto_names ? "auto or " : "", k->n, k->lo, k->hi);
            return false;
        }
        memcpy(base, v, sizeof(double) * (size_t)n);
        return true;
    }
    }
    return false;
}

/* inih (Debian's libinih) reads at most INI_MAX_LINE - 1 characters a line and carries the rest over as a line of
 * its own, which shifted every later line number. So the file is read here, whole, and inih is handed one line per
 * reader call: a line too long for it, or one inih would call a syntax error, is reported here with its own
 * number, in line order, and inih gets an empty line in its place. */
typedef struct {
    rt_config *c;
    rt_config_errors *err;
    const char *name;
    const char *text;
    int line;
    bool after_key;     /* the last line inih parsed was a key: an indented line continues its value */
    bool bad_section;   /* inside an unclosed '[section': its keys would land in the section before it */
    bool ok;
    bool calib;         /* a calibration file: only calibration keys, origins from RT_CONFIG_ORIGIN_CALIB */
} parse_ctx;

/* What a calibration file may hold: every [lens] key (whatever the lens models add) and these of [imu]. */
static const char *const calib_imu_keys[] = {"mount", "axes", "gyro_bias", "accel_bias", "gravity", NULL};

static bool is_calibration_key(const char *section, const char *key)
{
    if (strcmp(section, "lens") == 0) return true;
    if (strcmp(section, "imu") != 0) return false;
    for (int i = 0; calib_imu_keys[i]; i++)
        if (strcmp(calib_imu_keys[i], key) == 0) return true;
    return false;
}

/* inih's scan for a delimiter that stops at an inline comment (';' after whitespace). */
static const char *find_chars_or_comment(const char *s, const char *chars)
{
    bool was_space = false;
    while (*s && !strchr(chars, *s) && !(was_space && *s == ';')) {
        was_space = *s == ' ' || *s == '\t' || *s == '\r' || *s == '\f' || *s == '\v';
        s++;
    }
    return s;
}

/* Classifies the line as inih will (ini.c, ini_parse_stream); false when inih would call it a syntax error,
 * after recording the error. Continuation lines and keys are inih's to handle. */
static bool check_line(parse_ctx *p, const char *line)
{
    const char *s = line;
    if (p->line == 1 && (unsigned char)s[0] == 0xEF && (unsigned char)s[1] == 0xBB && (unsigned char)s[2] == 0xBF)
        s += 3;
    const char *start = s;
    while (*start == ' ' || *start == '\t' || *start == '\r') start++;
    if (!*start || *start == ';' || *start == '#') return true;
    if (p->after_key && start > s) return true; /* INI_ALLOW_MULTILINE: the value goes on */
    if (*start == '[') {
        const char *end = find_chars_or_comment(start + 1, "]");
        if (*end == ']') {
            p->bad_section = false;
            p->after_key = false;
            return true;
        }
        int n = (int)strcspn(start, " \t;");
        add_error(p->err, "%s:%d: '%.*s': section header without ']' (the keys after it, up to the next section, "
                          "are not read)", p->name, p->line, n > 40 ? 40 : n, start);
        p->bad_section = true;
        p->after_key = false;
        return false;
    }
    const char *end = find_chars_or_comment(start, "=:");
    if (*end == '=' || *end == ':') {
        p->after_key = true;
        return true;
    }
    add_error(p->err, "%s:%d: syntax error (expected '[section]' or 'key = value')", p->name, p->line);
    return false;
}

static char *reader(char *str, int num, void *stream)
{
    parse_ctx *p = stream;
    if (!*p->text) return NULL;
    const char *nl = strchr(p->text, '\n');
    size_t len = nl ? (size_t)(nl - p->text) : strlen(p->text);
    const char *next = nl ? nl + 1 : p->text + len;
    if (len && p->text[len - 1] == '\r') len--;
    p->line++;
    str[0] = 0;
    if (len > (size_t)num - 1) {
        /* what a line holds is unknown past inih's buffer: the section it may open is too */
        add_error(p->err, "%s:%d: longer than %d characters (inih's limit): not read", p->name, p->line, num - 1);
        p->ok = false;
    } else {
        memcpy(str, p->text, len);
        str[len] = 0;
        if (!check_line(p, str)) {
            p->ok = false;
            str[0] = 0;
        }
    }
    p->text = next;
    return str;
}

static int handler(void *user, const char *section, const char *name, const char *value)
{
    parse_ctx *p = user;
    if (p->bad_section) return 1; /* reported once, at the unclosed header */
    char where[300];
    snprintf(where, sizeof where, "%s:%d", p->name, p->line);
    if (p->calib && !is_calibration_key(section, name)) {
        /* board.ini's business: a calibration file that could set it would hide what the board runs */
        add_error(p->err, "%s: [%s] %s: not a calibration key (a calibration file holds [lens] and [imu] mount, "
                          "axes, gyro_bias, accel_bias, gravity; the rest belongs in board.ini)", where, section, name);
        p->ok = false;
        return 1;
    }
    if (!set_key(p->c, section, name, value, where, p->calib ? RT_CONFIG_ORIGIN_CALIB + p->line : p->line, p->err))
        p->ok = false;
    return 1; /* keep going: report every problem of the file at once */
}

static bool parse(rt_config *c, const char *text, const char *name, bool calib, rt_config_errors *err)
{
    parse_ctx p = {c, err, name, text, 0, false, false, true, calib};
    if (calib)
        snprintf(c->calib_file, sizeof c->calib_file, "%s", name);
    else
        snprintf(c->origin_file, sizeof c->origin_file, "%s", name);
    int r = ini_parse_stream(reader, &p, handler, &p);
    if (r > 0) { /* a case check_line does not know: still reported, with inih's line number */
        add_error(err, "%s:%d: syntax error (expected '[section]' or 'key = value')", name, r);
        p.ok = false;
    } else if (r < 0) {
        add_error(err, "%s: cannot be parsed (inih error %d)", name, r);
        p.ok = false;
    }
    return p.ok;
}

static bool load_file(rt_config *c, const char *path, bool calib, rt_config_errors *err)
{
    /* O_NONBLOCK: a FIFO given as the config must not hang the open; nothing but a regular file is read. */
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        add_error(err, "%s: cannot open config file: %s", path, strerror(errno));
        return false;
    }
    struct stat st;
    const off_t limit = (off_t)RT_CONFIG_MAX_FILE_KB * 1024;
    if (fstat(fd, &st) != 0) {
        add_error(err, "%s: cannot stat config file: %s", path, strerror(errno));
        close(fd);
        return false;
    }
    if (S_ISDIR(st.st_mode) || !S_ISREG(st.st_mode)) {
        add_error(err, "%s: %s, not a board.ini file", path,
                  S_ISDIR(st.st_mode) ? "a directory" : "not a regular file");
        close(fd);
        return false;
    }
    if (st.st_size > limit) {
        add_error(err, "%s: larger than %d KB, not a board.ini file", path, RT_CONFIG_MAX_FILE_KB);
        close(fd);
        return false;
    }
    /* Read at most limit + 1 bytes whatever fstat said: the file may grow while it is read. */
    char *text = malloc((size_t)limit + 2);
    size_t n = 0;
    bool read_ok = text != NULL;
    while (read_ok && n <= (size_t)limit) {
        ssize_t r = read(fd, text + n, (size_t)limit + 1 - n);
        if (r < 0 && errno == EINTR) continue;
        if (r < 0) {
            add_error(err, "%s: cannot read config file: %s", path, strerror(errno));
            read_ok = false;
        }
        if (r <= 0) break;
        n += (size_t)r;
    }
    close(fd);
    if (!text) add_error(err, "%s: out of memory", path);
    if (!read_ok) {
        free(text);
        return false;
    }
    if (n > (size_t)limit) {
        add_error(err, "%s: larger than %d KB, not a board.ini file", path, RT_CONFIG_MAX_FILE_KB);
        free(text);
        return false;
    }
    text[n] = 0;
    const char *nul = memchr(text, 0, n);
    if (nul) {
        int line = 1;
        for (const char *q = text; q < nul; q++) line += *q == '\n';
        add_error(err, "%s:%d: a NUL byte: not a text file", path, line);
        free(text);
        return false;
    }
    bool ok = parse(c, text, path, calib, err);
    free(text);
    return ok;
}

bool rt_config_load(rt_config *c, const char *path, rt_config_errors *err) { return load_file(c, path, false, err); }

bool rt_config_load_calibration(rt_config *c, const char *path, rt_config_errors *err)
{
    return load_file(c, path, true, err);
}

bool rt_config_load_string(rt_config *c, const char *text, const char *name, rt_config_errors *err)
{
    return parse(c, text, name, false, err);
}

bool rt_config_set(rt_config *c, const char *assignment, rt_config_errors *err)
{
    const char *dot = strchr(assignment, '.'), *eq = strchr(assignment, '=');
    if (!dot || !eq || dot > eq) {
        add_error(err, "command line: '%s': expected section.key=value", assignment);
        return false;
    }
    c->overrides++; /* counted whether or not it applies, so the numbers follow the command line */
    char section[64], key[64];
    snprintf(section, sizeof section, "%.*s", (int)(dot - assignment), assignment);
    snprintf(key, sizeof key, "%.*s", (int)(eq - dot - 1), dot + 1);
    return set_key(c, section, key, eq + 1, "command line", -c->overrides, err);
}

bool rt_config_fov_auto(const rt_config *c) { return isnan(c->fov_deg[0]); }

double rt_config_guard_deg(const rt_config *c)
{
    if (isfinite(c->guard_deg)) return c->guard_deg;
    /* A frame is shown for up to two periods of a half-rate host (45 Hz on a 90 Hz panel), its photons photon_offset
     * later: the age a rotation warp reaches over when the pose prediction misses a turn entirely. */
    const double age_s = 2.0 / c->refresh_hz + c->photon_offset_ms * 1e-3;
    return warp_fov_default_guard_deg(RT_GUARD_HEAD_DEG_S, age_s);
}

double rt_config_visible_radius(const rt_config *c, int eye)
{
    warp_lens lens = rt_config_lens(c, eye);
    return warp_fov_visible_radius(&lens, c->visible_radius, c->panel_w / 2, c->panel_h);
}

const char *rt_config_eye_camera_check(const rt_config *c, int eye, warp_camera *out, char *buf, int buflen)
{
    warp_camera cam;
    cam.width = c->eye_w;
    cam.height = c->eye_h;
    cam.near_z = c->near_z;
    cam.far_z = INFINITY;
    if (rt_config_fov_auto(c)) {
        warp_lens lens = rt_config_lens(c, eye);
        double t[4] = {1, 1, 1, 1};
        const char *why = warp_fov_tangents(&lens, rt_config_visible_radius(c, eye), c->panel_w / 2, c->panel_h,
                                            rt_config_guard_deg(c), t, buf, buflen);
        if (why) return why;
        cam.tan_left = t[0];
        cam.tan_right = t[1];
        cam.tan_up = t[2];
        cam.tan_down = t[3];
    } else {
        double l = tan(c->fov_deg[0] * WARP_PI / 180), r = tan(c->fov_deg[1] * WARP_PI / 180);
        /* Mirror for the right eye: its temporal side is on the right. */
        cam.tan_left = eye == WARP_EYE_LEFT ? l : r;
        cam.tan_right = eye == WARP_EYE_LEFT ? r : l;
        cam.tan_up = tan(c->fov_deg[2] * WARP_PI / 180);
        cam.tan_down = tan(c->fov_deg[3] * WARP_PI / 180);
    }
    *out = cam;
    return NULL;
}

void rt_config_fov_line(const rt_config *c, char *buf, int len)
{
    size_t n = (size_t)len, at = 0;
    buf[0] = 0;
    at += (size_t)snprintf(buf, n, "field of view (half-angles left right up down, deg):");
    for (int e = 0; e < 2 && at < n; e++) {
        warp_camera cam = rt_config_eye_camera(c, e);
        at += (size_t)snprintf(buf + at, n - at, " %s eye %.1f %.1f %.1f %.1f%s", e ? "right" : "left",
                               atan(cam.tan_left) * 180 / WARP_PI, atan(cam.tan_right) * 180 / WARP_PI,
                               atan(cam.tan_up) * 180 / WARP_PI, atan(cam.tan_down) * 180 / WARP_PI, e ? "" : ";");
    }
    if (at >= n) return;
    if (!rt_config_fov_auto(c)) {
        snprintf(buf + at, n - at, " ([eye] fov as configured)");
        return;
    }
    const int vw = c->panel_w / 2;
    warp_lens lens = rt_config_lens(c, WARP_EYE_LEFT);
    const double r = rt_config_visible_radius(c, WARP_EYE_LEFT);
    int32_t *span = malloc(sizeof *span * 2 * (size_t)c->panel_h);
    const double shown = span ? (double)warp_fov_spans(&lens, r, vw, c->panel_h, span) / ((double)vw * c->panel_h) : NAN;
    free(span);
    snprintf(buf + at, n - at, " (auto: the lens's visible disc, radius %.3f, shows %.1f %% of each eye's panel pixels; "
             "guard band %.2f deg)", r, 100 * shown, rt_config_guard_deg(c));
}

warp_camera rt_config_eye_camera(const rt_config *c, int eye)
{
    warp_camera cam;
    char buf[200];
    if (rt_config_eye_camera_check(c, eye, &cam, buf, sizeof buf)) {
        /* rt_config_validate reports why; a caller that skipped it gets a camera warp_camera_check refuses */
        cam.width = c->eye_w;
        cam.height = c->eye_h;
        cam.tan_left = cam.tan_right = cam.tan_up = cam.tan_down = NAN;
        cam.near_z = c->near_z;
        cam.far_z = INFINITY;
    }
    return cam;
}

warp_lens rt_config_lens(const rt_config *c, int eye)
{
    warp_lens lens = {.model = WARP_LENS_POLY};
    int vw = c->panel_w / 2, vh = c->panel_h;
    switch (c->lens_model) {
    case WARP_LENS_PANOTOOLS: {
        warp_lens_panotools_params p = {.center_x = c->lens_center[0], .center_y = c->lens_center[1],
                                        .scale = c->lens_scale, .tan_scale = c->pano_tan_scale};
        memcpy(p.abcd, c->pano, sizeof p.abcd);
        memcpy(p.aberration, c->pano_aberration, sizeof p.aberration);
        lens = warp_lens_panotools(&p);
        break;
    }
    case WARP_LENS_VIVE: {
        warp_lens_vive_params p = {.aspect_x_over_y = c->vive_aspect, .r2_cutoff = c->vive_r2_cutoff};
        memcpy(p.k, c->vive_k, sizeof p.k);
        memcpy(p.center, c->vive_center, sizeof p.center);
        memcpy(p.intrinsics, c->vive_intrinsics, sizeof p.intrinsics);
        lens = warp_lens_vive(&p, vw, vh);
        break;
    }
    case WARP_LENS_CARDBOARD: {
        warp_lens_cardboard_params p = {.k = {c->cardboard_k[0], c->cardboard_k[1], 0, 0},
                                        .screen_to_lens = c->cardboard_distances[0],
                                        .inter_lens = c->cardboard_distances[1],
                                        .tray_to_lens = c->cardboard_distances[2],
                                        .alignment = c->cardboard_alignment,
                                        .screen_w = c->cardboard_screen[0],
                                        .screen_h = c->cardboard_screen[1]};
        lens = warp_lens_cardboard(&p, vw, vh);
        break;
    }
    case WARP_LENS_OPENCV: {
        const double *m = c->opencv_camera, *d = c->opencv_dist;
        warp_lens_opencv_params p = {m[0], m[1], m[2], m[3], d[0], d[1], d[2], d[3], d[4]};
        lens = warp_lens_opencv(&p);
        break;
    }
    default:
        for (int ch = 0; ch < 3; ch++)
            for (int i = 0; i < WARP_LENS_TERMS; i++) lens.ch[ch].k[i] = c->k[ch][i];
        lens.center_x = c->lens_center[0];
        lens.center_y = c->lens_center[1];
        lens.scale = c->lens_scale;
        break;
    }
    if (eye != WARP_EYE_LEFT) warp_lens_mirror(&lens, c->panel_w / 2.0);
    return lens;
}

/* The keys that set the configured model's lens (for the cross-key check's message). */
static const char *lens_model_keys(const rt_config *c)
{
    switch (c->lens_model) {
    case WARP_LENS_PANOTOOLS:
        return "lens.model lens.pano_red lens.pano_green lens.pano_blue lens.aberration lens.pano_tan_scale lens.scale "
               "lens.center display.width display.height";
    case WARP_LENS_VIVE:
        return "lens.model lens.vive_red lens.vive_green lens.vive_blue lens.vive_center_red lens.vive_center_green "
               "lens.vive_center_blue lens.vive_aspect lens.vive_intrinsics lens.vive_r2_cutoff display.width "
               "display.height";
    case WARP_LENS_CARDBOARD:
        return "lens.model lens.cardboard_k lens.cardboard_distances lens.cardboard_alignment lens.cardboard_screen "
               "display.width display.height";
    case WARP_LENS_OPENCV:
        return "lens.model lens.opencv_camera lens.opencv_dist display.width display.height";
    default:
        return "lens.center lens.scale lens.k_red lens.k_green lens.k_blue display.width display.height";
    }
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

/* Index in keys[] of "section.key" given as the first n characters of s, or -1. */
static int key_index(const char *s, size_t n)
{
    const char *dot = memchr(s, '.', n);
    if (!dot) return -1;
    size_t ls = (size_t)(dot - s), lk = n - ls - 1;
    for (int i = 0; i < NKEYS; i++)
        if (strlen(keys[i].section) == ls && !strncmp(keys[i].section, s, ls) && strlen(keys[i].key) == lk &&
            !strncmp(keys[i].key, dot + 1, lk))
            return i;
    return -1;
}

/* "[sec] key (file:line)" for each "sec.key" of the space-separated list: where each key of a cross-key error was
 * set (or that it was left at its default). */
static const char *keys_at(const rt_config *c, const char *list, char *buf, size_t len)
{
    buf[0] = 0;
    while (*list) {
        size_t n = strcspn(list, " ");
        int idx = key_index(list, n);
        char one[300];
        if (idx < 0)
            snprintf(one, sizeof one, "%.*s", (int)n, list); /* a typo in this file; shows in the message */
        else if (c->origin[idx] > RT_CONFIG_ORIGIN_CALIB)
            snprintf(one, sizeof one, "[%s] %s (%s:%d)", keys[idx].section, keys[idx].key, c->calib_file,
                     (int)(c->origin[idx] - RT_CONFIG_ORIGIN_CALIB));
        else if (c->origin[idx] > 0)
            snprintf(one, sizeof one, "[%s] %s (%s:%d)", keys[idx].section, keys[idx].key, c->origin_file,
                     (int)c->origin[idx]);
        else if (c->origin[idx] < 0)
            snprintf(one, sizeof one, "[%s] %s (command line, override %d)", keys[idx].section, keys[idx].key,
                     (int)-c->origin[idx]);
        else
            snprintf(one, sizeof one, "[%s] %s (default)", keys[idx].section, keys[idx].key);
        snprintf(buf + strlen(buf), len - strlen(buf), "%s%s", buf[0] ? ", " : "", one);
        list += n;
        while (*list == ' ') list++;
    }
    return buf;
}

/* The planes the runtime asks a host for (rt_app_init's planes_wanted): colour and depth, and what the registry
 * says the configured warp needs besides (ids for the object warp, layers for the transparency warp); auto may
 * choose any of them. */
static bool method_needs(const rt_config *c, unsigned plane)
{
    return c->method == RT_METHOD_AUTO || (warp_method_get(rt_method_warp(c->method))->needs & plane);
}
static bool wants_ids(const rt_config *c) { return method_needs(c, WARP_NEEDS_IDS); }
/* The backends that receive framelink streams into a max_frame_mb buffer (the USB board side, on either link). */
static bool framelink_backend(const rt_config *c)
{
    return strcmp(c->frames_backend, "usb") == 0 || strcmp(c->frames_backend, "socket") == 0;
}
static bool wants_layers(const rt_config *c) { return method_needs(c, WARP_NEEDS_LAYERS); }

uint64_t rt_config_frame_bytes(const rt_config *c)
{
    /* per pixel: RGBA8 colour, float32 depth, u16 ids, the layers' per-pixel count (no fragments: the least) */
    const uint64_t px = 2 * (uint64_t)c->eye_w * (uint64_t)c->eye_h;
    const uint64_t per_px = 4 + 4 + (wants_ids(c) ? 2 : 0) + (wants_layers(c) ? 1 : 0);
    return DRV_FRAMELINK_MAX_HEADER + 4 + px * per_px;
}

uint64_t rt_config_memory_bytes(const rt_config *c)
{
    /* Bytes per eye-buffer pixel and eye of each allocation (rt_app_init, rt_frameq_alloc, drv_frame_alloc). */
    enum { COLOR = 4, DEPTH = 4, IDS = 2, LAYERS = 1 + 4 * 12, PLANAR = 6, INV_DEPTH = 4, OPAQUE = 4 };
    const bool ids = wants_ids(c), layers = wants_layers(c);
    const uint64_t eye_px = (uint64_t)c->eye_w * (uint64_t)c->eye_h, eyes = 2;
    const uint64_t frame = eyes * eye_px * (COLOR + DEPTH + (ids ? IDS : 0) + (layers ? LAYERS : 0));
    uint64_t total = 0;
    /* swapchain: three panel images, four with a stall reserve */
    total += (c->stall_reserve_ms > 0 ? 4 : 3) * (uint64_t)c->panel_w * (uint64_t)c->panel_h * 4;
    /* the frame queue's three slots: the frame and what is derived from it once per host frame */
    total += 3 * (frame + eyes * eye_px * (PLANAR + INV_DEPTH + (layers ? OPAQUE : 0)));
    /* the depth warps' eye-sized buffers (intermediate image, its planar copy, masks; transparency's depth and
     * min/max tree; the forward warp's scratch and hole filling for objects) */
    if (method_needs(c, WARP_NEEDS_DEPTH))
        total += eyes * eye_px * (4 + PLANAR + 1 + (layers ? 4 + 8 : 0) + (ids ? 24 + 11 : 0));
    /* the frame backend: a simulated host renders into frames of its own; the USB (or socket) receiver holds
     * max_frame_mb (and its mock an encoded frame); V4L2 maps four capture buffers of about 4 bytes a pixel */
    const bool sim_host = strcmp(c->frames_backend, "sim") == 0 || strcmp(c->frames_device, "mock") == 0;
    if (sim_host) total += 2 * frame;
    if (framelink_backend(c)) {
        total += (uint64_t)(c->max_frame_mb * 1024 * 1024);
        if (strcmp(c->frames_device, "mock") == 0) total += rt_config_frame_bytes(c);
    } else if (strcmp(c->frames_backend, "v4l2") == 0) {
        total += 4 * eyes * eye_px * 4 * (c->frames_depth ? 2 : 1);
    }
    /* the lens meshes: a few dozen bytes a vertex */
    total += eyes * (uint64_t)(c->mesh_n + 1) * (uint64_t)(c->mesh_n + 1) * 64;
    return total;
}

bool rt_config_parse_codecs(const char *s, unsigned *mask, char *err, int errlen)
{
    unsigned m = DRV_CODEC_BIT(DRV_CODEC_RAW);
    const char *p = s;
    bool any = false;
    char all[64]; /* the codecs' names, for a message */
    while (*p) {
        while (*p == ' ' || *p == '\t' || *p == ',') p++;
        size_t n = strcspn(p, " \t,");
        if (!n) break;
        char name[16];
        snprintf(name, sizeof name, "%.*s", (int)(n < sizeof name - 1 ? n : sizeof name - 1), p);
        drv_codec_id id;
        if (n == 4 && strncmp(p, "auto", 4) == 0) {
            m |= drv_codec_decodable();
        } else if (n >= sizeof name || !drv_codec_parse(name, &id)) {
            return warp_err(err, errlen, "'%.*s' is not a codec (%s or auto)", (int)n, p,
                            drv_codec_names(DRV_CODEC_ALL, ", ", all, sizeof all));
        } else if (!(drv_codec_decodable() & DRV_CODEC_BIT(id))) {
            return warp_err(err, errlen, "%s: this build cannot decode it", name);
        } else {
            m |= DRV_CODEC_BIT(id);
        }
        any = true;
        p += n;
    }
    if (!any)
        return warp_err(err, errlen, "empty (auto, or a list of %s)",
                        drv_codec_names(DRV_CODEC_ALL, ", ", all, sizeof all));
    *mask = m;
    return true;
}

bool rt_config_frames_codecs(const rt_config *c, unsigned *mask, char *err, int errlen)
{
    if (!rt_config_parse_codecs(c->frames_codecs, mask, err, errlen)) return false;
    bool unlimited = (strcmp(c->frames_backend, "socket") == 0 ||
                      (strcmp(c->frames_backend, "usb") == 0 && strcmp(c->frames_device, "mock") == 0)) &&
                     !(c->link_mbps > 0);
    if (strcmp(c->frames_codecs, "auto") == 0 && unlimited) *mask = DRV_CODEC_BIT(DRV_CODEC_RAW);
    return true;
}
static unsigned v4l2_planes(const rt_config *c) { return DRV_PLANE_COLOR | (c->frames_depth ? DRV_PLANE_DEPTH : 0u); }

/* [eye] fov, guard_deg and [lens] visible_radius (h-fov's block): each eye's camera, from the lens when auto. */
static void check_fov(const rt_config *c, rt_config_errors *err)
{
    char at[1200], buf[200], which[600], region[400];
    /* an automatic field follows from the lens: the configured model's own keys set it */
    if (rt_config_fov_auto(c))
        snprintf(which, sizeof which, "eye.fov eye.guard_deg eye.near eye.width eye.height lens.visible_radius %s",
                 lens_model_keys(c));
    else
        snprintf(which, sizeof which, "eye.fov eye.near eye.width eye.height");
    snprintf(region, sizeof region, "%s lens.visible_radius eye.fov", lens_model_keys(c));
    if (rt_config_fov_auto(c) && !(rt_config_visible_radius(c, WARP_EYE_LEFT) > 0)) {
        add_error(err, "[lens]: the lens centre lies outside the eye's half of the panel, or no channel is monotonic "
                       "there: no visible region for fov = auto; set by %s",
                  keys_at(c, region, at, sizeof at));
        return;
    }
    for (int e = 0; e < 2; e++) {
        warp_camera cam;
        const char *why = rt_config_eye_camera_check(c, e, &cam, buf, sizeof buf);
        if (!why) why = warp_camera_check(&cam);
        if (why) {
            add_error(err, "%s eye's camera: %s; set by %s", e ? "right" : "left", why, keys_at(c, which, at, sizeof at));
            return;
        }
    }
}

/* [imu] mount (rt_calib.h): set, it wins over [imu] axes, so a calibration file's mount beats board.ini's axes. */
static void check_calibration(const rt_config *c, rt_config_errors *err)
{
    char at[600], why[200];
    double m[3][3];
    if (c->imu_mount[0] && !rt_calib_parse_mount(c->imu_mount, m, why, sizeof why))
        add_error(err, "%s = '%s': %s", keys_at(c, "imu.mount", at, sizeof at), c->imu_mount, why);
}

/* Rolling scanout: the scan fits in a refresh period (the next frame's scan would start before this one's ended). */
static void check_scan(const rt_config *c, rt_config_errors *err)
{
    char at[300];
    const warp_scan s = rt_config_scan(c);
    const char *why = warp_scan_check(&s, 1.0 / c->refresh_hz);
    if (why)
        add_error(err, "[display] scan_ms = %g: %s (%.3f ms at %g Hz); %s", c->scan_ms, why, 1000.0 / c->refresh_hz,
                  c->refresh_hz, keys_at(c, "display.scan_ms display.refresh_hz display.scanout", at, sizeof at));
}

warp_scan rt_config_scan(const rt_config *c)
{
    const double period_ms = 1000.0 / c->refresh_hz;
    warp_scan s = {c->scanout == 1, (warp_scan_dir)c->scan_direction,
                   (c->scan_ms > 0 ? c->scan_ms : RT_SCAN_AUTO_SHARE * period_ms) * 1e-3, c->panel_w, c->panel_h};
    return s;
}

bool rt_config_validate(const rt_config *c, rt_config_errors *err)
{
    int before = err ? err->count : 0;
    char at[1200];
    if (c->panel_w % 2)
        add_error(err, "%s = %d: must be even (two eyes side by side)", keys_at(c, "display.width", at, sizeof at),
                  c->panel_w);
    char buf[400];
    check_fov(c, err);
    warp_lens lens = rt_config_lens(c, WARP_EYE_LEFT);
    const char *lw = warp_lens_check(&lens, c->panel_w / 2, c->panel_h, buf, sizeof buf);
    if (lw)
        add_error(err, "[lens]: %s; set by %s", lw,
                  keys_at(c, lens_model_keys(c), at, sizeof at));
    check_scan(c, err);
    int map[3], sign[3];
    if (!rt_config_parse_axes(c->imu_axes, map, sign))
        add_error(err, "%s = '%s': expected three signed axes using each of x, y, z once, e.g. '-y +x +z'",
                  keys_at(c, "imu.axes", at, sizeof at), c->imu_axes);
    check_calibration(c, err);
    if (strcmp(c->imu_backend, "sim") != 0 && !c->imu_device[0])
        add_error(err, "[imu] device: required for backend = %s (a device path%s, or mock); %s", c->imu_backend,
                  strcmp(c->imu_backend, "hid") == 0 ? " or VVVV:PPPP" : "",
                  keys_at(c, "imu.backend imu.device", at, sizeof at));
    const bool on_socket = strcmp(c->frames_backend, "socket") == 0;
    if (on_socket && strcmp(c->frames_device, "mock") == 0)
        add_error(err, "[frames] device = mock: the socket backend has no mock host (any process is its host; "
                       "backend = usb with device = mock runs the simulated host over the wire format); %s",
                  keys_at(c, "frames.backend frames.device", at, sizeof at));
    if (on_socket && strlen(c->frames_device) > DRV_FRAMES_SOCKET_PATH_MAX)
        add_error(err, "[frames] device = %s: %zu characters, a Unix socket path holds at most %d; %s",
                  c->frames_device, strlen(c->frames_device), DRV_FRAMES_SOCKET_PATH_MAX,
                  keys_at(c, "frames.device", at, sizeof at));
    if (strcmp(c->frames_backend, "sim") != 0 && !on_socket && !c->frames_device[0])
        add_error(err, "[frames] device: required for backend = %s (%s, or mock); %s", c->frames_backend,
                  strcmp(c->frames_backend, "usb") == 0 ? "the FunctionFS mount directory" : "a /dev/videoN path",
                  keys_at(c, "frames.backend frames.device", at, sizeof at));
    unsigned codecs;
    char cwhy[160];
    if (!rt_config_parse_codecs(c->frames_codecs, &codecs, cwhy, sizeof cwhy))
        add_error(err, "%s = '%s': %s", keys_at(c, "frames.codecs", at, sizeof at), c->frames_codecs, cwhy);
    /* V4L2 in band: the capture mode is the incoming signal's, known only at start-up (drv_frames_v4l2 checks it
     * there); an eye size without any layout is known now. */
    drv_v4l2_fit fit;
    if (strcmp(c->frames_backend, "v4l2") == 0 &&
        !drv_v4l2_fit_check(1 << 16, 1 << 16, DRV_V4L2_YUYV, c->eye_w, c->eye_h, v4l2_planes(c), &fit, buf, sizeof buf))
        add_error(err, "[frames] backend = v4l2: %s; %s", buf, keys_at(c, "eye.width eye.height", at, sizeof at));
    const bool kms = strcmp(c->output, "kms") == 0;
    if (strcmp(c->vsync_backend, "kms") == 0 && !kms)
        add_error(err, "[vsync] backend = kms: needs [display] output = kms (the vblanks come from the KMS output; "
                       "output is %s); %s", c->output, keys_at(c, "vsync.backend display.output", at, sizeof at));
    if (kms && strcmp(c->sink, "null") != 0)
        add_error(err, "[display] sink = %s: output = kms shows the images on the panel; sinks take them only with "
                       "output = offscreen; %s", c->sink, keys_at(c, "display.sink display.output", at, sizeof at));
    int mw, mh;
    double mhz;
    if (!rt_config_parse_mode(c->kms_mode, &mw, &mh, &mhz))
        add_error(err, "%s = '%s': expected auto, WxH or WxH@Hz (e.g. 2880x1600@90)",
                  keys_at(c, "display.kms_mode", at, sizeof at), c->kms_mode);
    if (c->host_rate_hz > c->refresh_hz * 2)
        add_error(err, "[sim] host_rate_hz = %g: more than twice the display rate (%g Hz) makes no sense; %s",
                  c->host_rate_hz, c->refresh_hz, keys_at(c, "sim.host_rate_hz display.refresh_hz", at, sizeof at));
    /* A limit that cannot hold the frames this configuration asks for rejects every one of them: the board would
     * run and show nothing. */
    const double mib = 1024.0 * 1024.0;
    const uint64_t frame = rt_config_frame_bytes(c);
    if (framelink_backend(c) && (double)frame > c->max_frame_mb * mib) {
        const char *planes = wants_layers(c) ? "colour, depth, ids, layers"
                             : wants_ids(c)  ? "colour, depth, ids"
                                             : "colour, depth";
        add_error(err, "[frames] max_frame_mb = %g: a host frame of two %dx%d eyes (%s) takes %.1f MiB, more than "
                       "the limit, so every frame would be rejected; %s", c->max_frame_mb, c->eye_w, c->eye_h, planes,
                  (double)frame / mib,
                  keys_at(c, "frames.max_frame_mb eye.width eye.height warp.method", at, sizeof at));
    }
    const uint64_t mem = rt_config_memory_bytes(c);
    if ((double)mem > c->max_memory_mb * mib)
        add_error(err, "[render] max_memory_mb = %g: this configuration allocates about %.0f MiB at start "
                       "(swapchain, frame slots, warp buffers%s); %s", c->max_memory_mb, (double)mem / mib,
                  framelink_backend(c) ? ", the host link's receive buffer" : "",
                  keys_at(c, framelink_backend(c)
                                 ? "render.max_memory_mb eye.width eye.height display.width display.height warp.method "
                                   "frames.max_frame_mb"
                                 : "render.max_memory_mb eye.width eye.height display.width display.height warp.method",
                          at, sizeof at));
    return (err ? err->count : 0) == before;
}

void rt_config_warnings(const rt_config *c, rt_config_errors *warn)
{
    /* A real board: named (the built-in default is "unnamed"), or with a device that is neither simulated nor
     * mocked. Such a board that displays nowhere is almost certainly a mistake in its board.ini. */
    bool named = c->board_name[0] && strcmp(c->board_name, "sim") != 0 && strcmp(c->board_name, "unnamed") != 0;
    bool real_imu = strcmp(c->imu_backend, "sim") != 0 && strcmp(c->imu_device, "mock") != 0;
    /* (the socket backend's host is a process on the same machine: a PC, not a board) */
    bool real_frames = strcmp(c->frames_backend, "sim") != 0 && strcmp(c->frames_backend, "socket") != 0 &&
                       strcmp(c->frames_device, "mock") != 0;
    bool real_vsync = strcmp(c->vsync_backend, "kms") == 0 ||
                      (strcmp(c->vsync_backend, "gpio") == 0 && strcmp(c->vsync_chip, "mock") != 0);
    if ((named || real_imu || real_frames || real_vsync) && strcmp(c->output, "offscreen") == 0 &&
        strcmp(c->sink, "null") == 0)
        add_error(warn, "board '%s' displays nowhere: [display] output = offscreen and sink = null (set output = kms "
                        "to show the panel)", c->board_name);
    /* A V4L2 in-band layout larger than every common capture mode (docs/v4l2-inband.md) needs a capture device
     * with an unusual mode; the start-up check is the final word (the mock delivers the layout's own size). */
    if (strcmp(c->frames_backend, "v4l2") == 0 && strcmp(c->frames_device, "mock") != 0) {
        const drv_v4l2_mode *big = &drv_v4l2_common_modes[drv_v4l2_common_mode_count - 1];
        drv_v4l2_fit fit;
        bool any = false;
        for (int i = 0; i < drv_v4l2_common_mode_count; i++)
            any = any || drv_v4l2_fit_check(drv_v4l2_common_modes[i].w, drv_v4l2_common_modes[i].h, DRV_V4L2_YUYV,
                                            c->eye_w, c->eye_h, v4l2_planes(c), &fit, NULL, 0);
        if (!any && fit.need_w > 0)
            add_error(warn, "[frames] backend = v4l2: eyes %dx%d (%s) need a %dx%d in-band frame, larger than every "
                            "common capture mode up to %s %dx%d (docs/v4l2-inband.md); the capture device must "
                            "deliver at least that", c->eye_w, c->eye_h, c->frames_depth ? "colour + depth" : "colour",
                      fit.need_w, fit.need_h, big->name, big->w, big->h);
    }
    /* max_memory_mb is the board's budget; this machine may have less (a warning only: a board's configuration is
     * also checked on the host that builds it) */
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    const uint64_t mem = rt_config_memory_bytes(c);
    if (pages > 0 && page > 0 && mem > (uint64_t)pages * (uint64_t)page)
        add_error(warn, "this configuration allocates about %.0f MiB at start, more than this machine's %.0f MiB",
                  (double)mem / (1024.0 * 1024.0), (double)pages * (double)page / (1024.0 * 1024.0));
    /* only the links that stand in for one are limited: a real link runs at its own rate */
    const bool limitable = strcmp(c->frames_backend, "socket") == 0 ||
                           (strcmp(c->frames_backend, "usb") == 0 && strcmp(c->frames_device, "mock") == 0);
    char at[300];
    if (c->link_mbps > 0 && !limitable)
        add_error(warn, "%s = %g: ignored for backend = %s%s (only the mock usb and the socket links are limited)",
                  keys_at(c, "frames.link_mbps", at, sizeof at), c->link_mbps, c->frames_backend,
                  strcmp(c->frames_backend, "usb") == 0 ? ", a real link at its bus's rate" : "");
}

static void format_value(const rt_config *c, const keydef *k, char *buf, size_t len)
{
    const char *base = (const char *)c + k->off;
    switch (k->type) {
    case K_INT: snprintf(buf, len, "%d", *(const int *)base); break;
    case K_DOUBLE:
        if (k->names == auto_names && isnan(*(const double *)base))
            snprintf(buf, len, "auto");
        else
            snprintf(buf, len, "%g", *(const double *)base);
        break;
    case K_U64: snprintf(buf, len, "%llu", (unsigned long long)*(const uint64_t *)base); break;
    case K_STR:
    case K_CHOICE: snprintf(buf, len, "%s", base); break;
    case K_ENUM: snprintf(buf, len, "%s", k->names[*(const int *)base]); break;
    case K_DLIST: {
        buf[0] = 0;
        if (k->names == auto_names && isnan(*(const double *)base)) {
            snprintf(buf, len, "auto");
            break;
        }
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
        if (keys[i].names == method_names) {
            /* [warp] method: the registry's runtime methods, each with its paper and what it does */
            fprintf(out, "    %-17s ", keys[i].key);
            for (int m = 0; m < RT_METHOD_COUNT; m++) {
                const warp_method_info *w = warp_method_get((warp_method)m);
                const bool cited = strcmp(w->cite, "-") != 0;
                fprintf(out, "%s (%s%s%s), ", w->name, cited ? w->cite : "", cited ? ": " : "", w->summary);
            }
            fprintf(out, "%s", keys[i].help);
            const char *sep = " ";
            for (int m = 0; m < RT_METHOD_COUNT; m++) {
                const warp_method_info *w = warp_method_get((warp_method)m);
                if (w->fallback == (warp_method)m) continue;
                fprintf(out, "%s%s to %s", sep, w->name, warp_method_name(w->fallback));
                sep = ", ";
            }
            fprintf(out, "; the GLES renderer traces per pixel) (default: %s)\n", v[0] ? v : "empty");
            continue;
        }
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
