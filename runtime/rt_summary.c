/* SPDX-License-Identifier: MIT */
/* rt_summary: a run's counters as one table (key, summary line, where each goes, how to read it), from which both
 * the human summary (README "Reading the summary") and the key=value --stats / live stats print. */
#include "runtime/rt_summary.h"

#include <ctype.h>
#include <math.h>
#include <string.h>

#include "drivers/drv_codec.h"
#include "drivers/drv_frames.h"
#include "platform/plat_gles.h"
#include "platform/plat_version.h"
#include "runtime/rt_select.h"
#include "warp/warp_math.h"

/* Row ids: the table below is in this order (checked at the end of the file). */
enum {
    R_VERSION, R_RUNNING, R_RUN_S, R_BOARD, R_IMU_BACKEND, R_FRAMES_BACKEND, R_VSYNC_BACKEND, R_RENDERER,
    R_GL_RENDERER, R_RENDERER_REASON, R_DISPLAY_OUTPUT, R_KMS_FLIPS, R_KMS_FAILED, R_KMS_LATE, R_KMS_VBLANKS,
    R_KMS_API, R_KMS_FORMAT, R_GLES_P50, R_GLES_P99, R_GLES_ERRORS, R_VSYNCS, R_MISSED, R_MISSED_BY, R_NO_FRAME,
    R_NO_BUFFER, R_METHOD, R_WARP_P50, R_WARP_P99, R_STALL, R_M2P_P50, R_M2P_P99, R_AGE_P50, R_AGE_MAX, R_OUTSIDE_P50, R_OUTSIDE_P99,
    R_OUTSIDE_PX, R_VISIBLE_PX, R_SELECT,
    R_SWITCHES, R_RECEIVED, R_BYTES, R_SHOWN, R_DROPPED, R_REJECTED_BY, R_REJECTED, R_PREPARE_P50, R_PREPARE_P99,
    R_LINK_CONNECTED,
    R_LINK_CONNECTIONS, R_LINK_REFUSED, R_LINK_DISCONNECTS, R_LINK_POSES, R_LINK_POSES_DROPPED, R_LINK_CAMS, R_LINK_MASKS,
    R_LINK_USB_SPEED,
    R_LINK_DECODE_P50, R_LINK_DECODE_P99, R_LINK_COMPRESSED, R_LINK_CODEC_ERRORS, R_LINK_KEY_REQUESTS,
    R_LINK_WIRE_MB_S, R_LINK_COMPRESSION, R_LINK_VIDEO_DECODER, R_IMU_SAMPLES,
    R_IMU_READ_ERRORS, R_IMU_LOST, R_IMU_STALE, R_IMU_REPORTS, R_IMU_BAD, R_IMU_RECONNECTS, R_IMU_CONNECTED,
    R_VS_EDGES, R_VS_SPURIOUS, R_VS_MISSED, R_VS_FALLBACKS, R_VS_ON_TIMER, R_VS_PERIOD, R_VS_JITTER, R_ORIENT_W,
    R_ORIENT_X, R_ORIENT_Y, R_ORIENT_Z, R_ORIENT_ERR, R_PSNR, R_SSIM,
    /* the summary's own: histograms it prints whole, and what only a reader needs */
    R_PANEL, R_ADVICE, R_WARP_MS, R_GLES_TIMING, R_GLES_MS, R_RT_FALLBACKS, R_PLANE_FALLBACKS, R_M2P, R_AGE,
    R_OUTPUT, R_HOST_RENDER, R_LINK_DECODE_MS, R_PREPARE_MS, R_PLANES, R_IMU_REJECTED, R_EVAL_N, R_POSE_ERR, R_CSV, R_COUNT
};

#define B RT_SUM_BOTH
#define K RT_SUM_STATS
#define S RT_SUM_SUMMARY
const rt_summary_row rt_summary_table[] = {
    [R_VERSION] = {"version", "summary", B, 's', 0, false},
    [R_RUNNING] = {"running", NULL, K, 'd', 0, false},
    [R_RUN_S] = {"run_s", NULL, K, 'f', 1, false}, /* the summary's span is vsyncs / refresh rate */
    [R_BOARD] = {"board", "summary", B, 's', 0, false},
    [R_IMU_BACKEND] = {"imu_backend", "IMU device", B, 's', 0, false},
    [R_FRAMES_BACKEND] = {"frames_backend", NULL, K, 's', 0, false},
    [R_VSYNC_BACKEND] = {"vsync_backend", "vsync source", B, 's', 0, false},
    [R_RENDERER] = {"renderer", "renderer", B, 's', 0, false},
    [R_GL_RENDERER] = {"gl_renderer", "renderer", B, 's', 0, false},
    [R_RENDERER_REASON] = {"renderer_reason", "renderer chosen", B, 's', 0, false},
    [R_DISPLAY_OUTPUT] = {"display_output", NULL, K, 's', 0, false}, /* the summary describes the output instead */
    [R_KMS_FLIPS] = {"kms_flips", "KMS output", B, 'u', 0, false},
    [R_KMS_FAILED] = {"kms_flips_failed", "KMS output", B, 'u', 0, false},
    [R_KMS_LATE] = {"kms_flips_late", "KMS output", B, 'u', 0, false},
    [R_KMS_VBLANKS] = {"kms_vblanks", NULL, K, 'u', 0, false},
    [R_KMS_API] = {"kms_api", "KMS output", B, 's', 0, false},
    [R_KMS_FORMAT] = {"kms_format", "KMS output", B, 's', 0, false},
    [R_GLES_P50] = {"gles_%s_ms_p50", "gles", B, 'f', 3, true},
    [R_GLES_P99] = {"gles_%s_ms_p99", "gles", B, 'f', 3, false},
    [R_GLES_ERRORS] = {"gles_errors", "GLES errors", B, 'u', 0, false},
    [R_VSYNCS] = {"vsyncs", "vsyncs", B, 'u', 0, false},
    [R_MISSED] = {"missed", "vsyncs", B, 'u', 0, false},
    [R_MISSED_BY] = {"missed_%s", "missed, why", B, 'u', 0, false},
    [R_NO_FRAME] = {"no_frame", NULL, K, 'u', 0, false},
    [R_NO_BUFFER] = {"no_buffer", "vsyncs", B, 'u', 0, false}, /* shown as a remark, not a number */
    [R_METHOD] = {"method_%s", "warp time", B, 'u', 0, false},
    [R_WARP_P50] = {"warp_ms_p50", "warp time", B, 'f', 3, false},
    [R_WARP_P99] = {"warp_ms_p99", "warp time", B, 'f', 3, false},
    [R_STALL] = {"stall_reserve_ms", "stall reserve", B, 'f', 3, false},
    [R_M2P_P50] = {"m2p_ms_p50", "motion-to-photon", B, 'f', 3, false},
    [R_M2P_P99] = {"m2p_ms_p99", "motion-to-photon", B, 'f', 3, false},
    [R_AGE_P50] = {"frame_age_ms_p50", "frame age at photon time", B, 'f', 3, false},
    [R_AGE_MAX] = {"frame_age_ms_max", "frame age at photon time", B, 'f', 3, false},
    [R_OUTSIDE_P50] = {"outside_source_pct_p50", "outside the source", B, 'f', 2, false},
    [R_OUTSIDE_P99] = {"outside_source_pct_p99", "outside the source", B, 'f', 2, false},
    [R_OUTSIDE_PX] = {"outside_source_px", "outside the source", B, 'u', 0, false},
    [R_VISIBLE_PX] = {"visible_px", "outside the source", B, 'u', 0, false},
    [R_SELECT] = {"select_%s", "warp selection (auto)", B, 'u', 0, false},
    [R_SWITCHES] = {"method_switches", NULL, K, 'u', 0, false},
    [R_RECEIVED] = {"frames_received", "received", B, 'u', 0, false},
    [R_BYTES] = {"frames_bytes", NULL, K, 'u', 0, false},
    [R_SHOWN] = {"frames_shown", "received", B, 'u', 0, false},
    [R_DROPPED] = {"frames_dropped", "received", B, 'u', 0, false},
    [R_REJECTED_BY] = {"frames_rejected_%s", "rejected as", B, 'u', 0, false},
    [R_REJECTED] = {"frames_rejected", "received", B, 'u', 0, false},
    [R_PREPARE_P50] = {"frames_prepare_ms_p50", "frame prepare", B, 'f', 3, false},
    [R_PREPARE_P99] = {"frames_prepare_ms_p99", "frame prepare", B, 'f', 3, false},
    [R_LINK_CONNECTED] = {"frames_link_connected", "host link", B, 'd', 0, false},
    [R_LINK_CONNECTIONS] = {"frames_link_connections", "host link", B, 'u', 0, false},
    [R_LINK_REFUSED] = {"frames_link_refused", "host link", B, 'u', 0, false},
    [R_LINK_DISCONNECTS] = {"frames_link_disconnects", "host link", B, 'u', 0, false},
    [R_LINK_POSES] = {"frames_link_poses_sent", "host link", B, 'u', 0, false},
    [R_LINK_POSES_DROPPED] = {"frames_link_poses_dropped", "host link", B, 'u', 0, false},
    [R_LINK_CAMS] = {"frames_link_cams_sent", "host link", B, 'u', 0, false},
    [R_LINK_MASKS] = {"frames_link_masks_sent", "host link", B, 'u', 0, false},
    [R_LINK_USB_SPEED] = {"frames_link_usb_speed", "host link", B, 's', 0, false},
    [R_LINK_DECODE_P50] = {"frames_link_decode_ms_p50", "link decode", B, 'f', 3, false},
    [R_LINK_DECODE_P99] = {"frames_link_decode_ms_p99", "link decode", B, 'f', 3, false},
    [R_LINK_COMPRESSED] = {"frames_link_compressed_frames", "link codecs", B, 'u', 0, false},
    [R_LINK_CODEC_ERRORS] = {"frames_link_codec_errors", "link codecs", B, 'u', 0, false},
    [R_LINK_KEY_REQUESTS] = {"frames_link_key_requests", "link codecs", B, 'u', 0, false},
    [R_LINK_WIRE_MB_S] = {"frames_link_wire_mb_s", "link codecs", B, 'f', 2, false},
    [R_LINK_COMPRESSION] = {"frames_link_compression", "link codecs", B, 'f', 2, false},
    [R_LINK_VIDEO_DECODER] = {"frames_link_video_decoder", "link codecs", B, 's', 0, false},
    [R_IMU_SAMPLES] = {"imu_samples", "IMU samples", B, 'u', 0, false},
    [R_IMU_READ_ERRORS] = {"imu_read_errors", "IMU samples", B, 'u', 0, false},
    [R_IMU_LOST] = {"imu_lost", "IMU lost", B, 'u', 0, false},
    [R_IMU_STALE] = {"imu_stale_vsyncs", "IMU lost", B, 'u', 0, false},
    [R_IMU_REPORTS] = {"imu_reports", "IMU device", B, 'u', 0, false},
    [R_IMU_BAD] = {"imu_bad_reports", "IMU device", B, 'u', 0, false},
    [R_IMU_RECONNECTS] = {"imu_reconnects", "IMU device", B, 'u', 0, false},
    [R_IMU_CONNECTED] = {"imu_connected", "IMU device", B, 'd', 0, false},
    [R_VS_EDGES] = {"vsync_edges", "vsync source", B, 'u', 0, false},
    [R_VS_SPURIOUS] = {"vsync_spurious", "vsync source", B, 'u', 0, false},
    [R_VS_MISSED] = {"vsync_missed_edges", "vsync source", B, 'u', 0, false},
    [R_VS_FALLBACKS] = {"vsync_fallbacks", "vsync source", B, 'u', 0, false},
    [R_VS_ON_TIMER] = {"vsync_on_timer", "vsync source", B, 'd', 0, false},
    [R_VS_PERIOD] = {"vsync_period_ns", "vsync source", B, 'l', 0, false},
    [R_VS_JITTER] = {"vsync_jitter_us", "vsync source", B, 'f', 1, false},
    [R_ORIENT_W] = {"orientation_w", NULL, K, 'f', 6, false},
    [R_ORIENT_X] = {"orientation_x", NULL, K, 'f', 6, false},
    [R_ORIENT_Y] = {"orientation_y", NULL, K, 'f', 6, false},
    [R_ORIENT_Z] = {"orientation_z", NULL, K, 'f', 6, false},
    [R_ORIENT_ERR] = {"orientation_error_deg", "orientation error at end", B, 'f', 4, false},
    [R_PSNR] = {"psnr_%s", "PSNR dB", B, 'f', 3, true},
    [R_SSIM] = {"ssim_%s", "SSIM", B, 'f', 5, false},
    [R_PANEL] = {NULL, "panel", S, 'x', 0, false},
    [R_ADVICE] = {NULL, "misses, what to do", S, 'x', 0, false},
    [R_WARP_MS] = {NULL, "warp time", S, 'h', 0, false},
    [R_GLES_TIMING] = {NULL, "GPU time per pass", S, 's', 0, false},
    [R_GLES_MS] = {NULL, "gles", S, 'h', 0, false},
    [R_RT_FALLBACKS] = {NULL, "raytrace fallbacks", S, 'u', 0, false},
    [R_PLANE_FALLBACKS] = {NULL, "depth-warp fallbacks", S, 'u', 0, false},
    [R_M2P] = {NULL, "motion-to-photon", S, 'h', 0, false},
    [R_AGE] = {NULL, "frame age at photon time", S, 'h', 0, false},
    [R_OUTPUT] = {NULL, "output", S, 's', 0, false},
    [R_HOST_RENDER] = {NULL, "host render + transport", S, 'h', 0, false},
    [R_LINK_DECODE_MS] = {NULL, "link decode", S, 'h', 0, false},
    [R_PREPARE_MS] = {NULL, "frame prepare", S, 'h', 0, false},
    [R_PLANES] = {NULL, "planes rendered", S, 'u', 0, false},
    [R_IMU_REJECTED] = {NULL, "IMU samples", S, 'u', 0, false},
    [R_EVAL_N] = {NULL, "accuracy vs ground truth", S, 'd', 0, false},
    [R_POSE_ERR] = {NULL, "pose error at photon time", S, 'x', 0, false},
    [R_CSV] = {NULL, "per-vsync CSV", S, 's', 0, false},
};
#undef B
#undef K
#undef S
const int rt_summary_table_len = (int)(sizeof rt_summary_table / sizeof rt_summary_table[0]);
_Static_assert(sizeof rt_summary_table / sizeof rt_summary_table[0] == R_COUNT, "a row id without its row");

static const char *const plane_names[5] = {"color", "depth", "ids", "motion", "layers"};
static const char *const eval_names[RT_EVAL_METHODS] = {"no warp", "rotation (003 §3.4)", "raytrace (003 §3.5)",
                                                        "raytrace at mesh vertices"};

int rt_summary_members(const rt_summary_src *s, int r)
{
    switch (r) {
    case R_GLES_P50:
    case R_GLES_P99:
    case R_GLES_MS: return s->gles ? PLAT_GLES_PASSES : 0;
    case R_GLES_ERRORS:
    case R_GLES_TIMING: return s->gles;
    case R_MISSED_BY: return RT_MISS_COUNT;
    case R_METHOD:
    case R_WARP_MS: return RT_METHOD_COUNT;
    case R_SELECT: return RT_WHY_COUNT;
    case R_REJECTED_BY: return DRV_FRAME_ERR_COUNT - 1; /* member i is reason i + 1: 0 is "ok" */
    case R_LINK_CONNECTED:
    case R_LINK_CONNECTIONS:
    case R_LINK_REFUSED:
    case R_LINK_DISCONNECTS:
    case R_LINK_POSES:
    case R_LINK_POSES_DROPPED:
    case R_LINK_CAMS:
    case R_LINK_MASKS:
    case R_LINK_DECODE_P50:
    case R_LINK_DECODE_P99:
    case R_LINK_COMPRESSED:
    case R_LINK_CODEC_ERRORS:
    case R_LINK_KEY_REQUESTS:
    case R_LINK_WIRE_MB_S:
    case R_LINK_COMPRESSION:
    case R_LINK_VIDEO_DECODER:
    case R_LINK_DECODE_MS: return s->has_link_stats;
    case R_LINK_USB_SPEED: return s->has_link_stats && s->link.usb_speed[0]; /* the USB gadget's only */
    case R_IMU_REPORTS:
    case R_IMU_BAD:
    case R_IMU_RECONNECTS:
    case R_IMU_CONNECTED: return s->has_imu_stats;
    case R_VS_EDGES:
    case R_VS_SPURIOUS:
    case R_VS_MISSED:
    case R_VS_FALLBACKS:
    case R_VS_ON_TIMER:
    case R_VS_PERIOD:
    case R_VS_JITTER: return s->has_vsync_stats;
    case R_ORIENT_W:
    case R_ORIENT_X:
    case R_ORIENT_Y:
    case R_ORIENT_Z: return s->has_orientation;
    case R_ORIENT_ERR: return s->has_orientation && s->has_truth;
    /* the evaluator's sums are its own until it has stopped: never printed live */
    case R_PSNR:
    case R_SSIM: return s->live || !s->eval ? 0 : RT_EVAL_METHODS;
    case R_PLANES: return s->sim_host && s->sim_plane_renders ? 5 : 0;
    case R_EVAL_N:
    case R_POSE_ERR: return s->accuracy;
    case R_CSV: return s->csv != NULL;
    default: return 1;
    }
}

const char *rt_summary_member_key(int r, int i)
{
    switch (r) {
    case R_GLES_P50:
    case R_GLES_P99:
    case R_GLES_MS: return plat_gles_pass_name((plat_gles_pass)i);
    case R_MISSED_BY: return rt_miss_name((rt_miss)i);
    case R_METHOD:
    case R_WARP_MS: return rt_method_name((rt_method)i);
    case R_SELECT: return rt_select_why_key((rt_select_why)i);
    case R_REJECTED_BY: return drv_frame_err_str((drv_frame_err)(i + 1));
    case R_PSNR:
    case R_SSIM: return rt_method_name(rt_eval_methods[i]);
    case R_PLANES: return plane_names[i];
    default: return NULL;
    }
}

const char *rt_summary_member_label(int r, int i)
{
    switch (r) {
    case R_SELECT: return rt_select_why_str((rt_select_why)i);
    case R_PSNR:
    case R_SSIM: return eval_names[i];
    case R_REJECTED_BY:
    case R_WARP_MS:
    case R_GLES_MS: return rt_summary_member_key(r, i);
    default: return NULL;
    }
}

typedef struct {
    bool absent; /* this member has nothing to say in this run (a method the evaluator did not score) */
    unsigned long long u;
    long long l;
    double f;
    const char *s;
    const rt_hist *h;
} val;

/* The configured method's warp time; under auto, every method's together (auto has no histogram of its own: it
 * is RT_METHOD_COUNT, one past the array). */
static double warp_pct(const rt_telemetry *t, rt_method m, double p)
{
    return m == RT_METHOD_AUTO ? rt_hist_pct_of(t->warp_ms, RT_METHOD_COUNT, p) : rt_hist_pct(&t->warp_ms[m], p);
}

static val value(const rt_summary_src *s, int r, int i)
{
    const rt_config *c = s->cfg;
    const rt_telemetry *t = s->tel;
    val v = {0};
    switch (r) {
    case R_VERSION: v.s = plat_version(); break;
    case R_RUNNING: v.u = s->live; break;
    case R_RUN_S: v.f = s->run_s; break;
    case R_BOARD: v.s = c->board_name; break;
    case R_IMU_BACKEND: v.s = s->imu_name; break;
    case R_FRAMES_BACKEND: v.s = s->frames_name; break;
    case R_VSYNC_BACKEND: v.s = s->vsync_name; break;
    case R_RENDERER: v.s = s->gles ? "gles" : "cpu"; break;
    case R_GL_RENDERER: v.s = s->gles ? s->gl_renderer : ""; break;
    case R_RENDERER_REASON: v.s = s->render_why; break;
    case R_DISPLAY_OUTPUT: v.s = s->kms ? "kms" : "offscreen"; break;
    case R_KMS_FLIPS: v.u = s->kms_stats.flips; break;
    case R_KMS_FAILED: v.u = s->kms_stats.failed; break;
    case R_KMS_LATE: v.u = s->kms_stats.late; break;
    case R_KMS_VBLANKS: v.u = s->kms_stats.vblanks; break;
    case R_KMS_API: v.s = s->kms_stats.api ? s->kms_stats.api : ""; break;
    case R_KMS_FORMAT: v.s = s->kms_stats.format ? s->kms_stats.format : ""; break;
    case R_GLES_P50: v.f = rt_hist_pct(&s->gles_ms[i], 50); break;
    case R_GLES_P99: v.f = rt_hist_pct(&s->gles_ms[i], 99); break;
    case R_GLES_ERRORS: v.u = s->gles_errors; break;
    case R_VSYNCS: v.u = t->vsyncs; break;
    case R_MISSED: v.u = t->missed; break;
    case R_MISSED_BY: v.u = t->missed_by[i]; break;
    case R_NO_FRAME: v.u = t->no_frame; break;
    case R_NO_BUFFER: v.u = t->no_buffer; break;
    case R_METHOD: v.u = t->method_count[i]; break;
    case R_WARP_P50: v.f = warp_pct(t, c->method, 50); break;
    case R_WARP_P99: v.f = warp_pct(t, c->method, 99); break;
    case R_STALL: v.f = c->stall_reserve_ms; break;
    case R_M2P_P50: v.f = rt_hist_pct(&t->m2p_ms, 50); break;
    case R_M2P_P99: v.f = rt_hist_pct(&t->m2p_ms, 99); break;
    case R_AGE_P50: v.f = rt_hist_pct(&t->frame_age_ms, 50); break;
    case R_AGE_MAX: v.f = rt_hist_pct(&t->frame_age_ms, 100); break;
    /* the lower edge of the percentile's 0.01 % bin, so that frames with nothing outside read 0 */
    case R_OUTSIDE_P50: v.f = t->outside_pct.count ? fmax(0, rt_hist_pct(&t->outside_pct, 50) - 0.005) : 0; break;
    case R_OUTSIDE_P99: v.f = t->outside_pct.count ? fmax(0, rt_hist_pct(&t->outside_pct, 99) - 0.005) : 0; break;
    case R_OUTSIDE_PX: v.u = t->outside_px; break;
    case R_VISIBLE_PX: v.u = t->visible_px; break;
    case R_SELECT: v.u = t->select_why[i]; break;
    case R_SWITCHES: v.u = t->method_switches; break;
    case R_RECEIVED: v.u = t->frames_received; break;
    case R_BYTES: v.u = t->frames_bytes; break;
    case R_SHOWN: v.u = t->new_frames_shown; break;
    case R_DROPPED: v.u = t->frames_dropped; break;
    case R_REJECTED_BY: v.u = t->frames_rejected[i + 1]; break;
    case R_REJECTED:
        for (int e = 1; e < DRV_FRAME_ERR_COUNT; e++) v.u += t->frames_rejected[e];
        break;
    case R_PREPARE_P50: v.f = rt_hist_pct(&t->prepare_ms, 50); break;
    case R_PREPARE_P99: v.f = rt_hist_pct(&t->prepare_ms, 99); break;
    case R_LINK_CONNECTED: v.u = s->link.connected; break;
    case R_LINK_CONNECTIONS: v.u = s->link.connections; break;
    case R_LINK_REFUSED: v.u = s->link.refused; break;
    case R_LINK_DISCONNECTS: v.u = s->link.disconnects; break;
    case R_LINK_POSES: v.u = s->link.poses_sent; break;
    case R_LINK_POSES_DROPPED: v.u = s->link.poses_dropped; break;
    case R_LINK_CAMS: v.u = s->link.cams_sent; break;
    case R_LINK_MASKS: v.u = s->link.masks_sent; break;
    case R_LINK_DECODE_P50: v.f = rt_hist_pct(&t->decode_ms, 50); break;
    case R_LINK_DECODE_P99: v.f = rt_hist_pct(&t->decode_ms, 99); break;
    case R_LINK_COMPRESSED: v.u = s->link.dec.compressed_frames; break;
    case R_LINK_CODEC_ERRORS: v.u = s->link.dec.codec_errors; break;
    case R_LINK_KEY_REQUESTS: v.u = s->link.dec.key_requests; break;
    /* the accepted frames' bytes on the wire over the run (what the codecs left of plane_bytes) */
    case R_LINK_WIRE_MB_S: v.f = s->run_s > 0 ? (double)s->link.dec.wire_bytes / s->run_s * 1e-6 : 0; break;
    /* decoded plane bytes per wire byte: 1 for raw frames, 0 before any frame */
    case R_LINK_COMPRESSION:
        v.f = s->link.dec.wire_bytes ? (double)s->link.dec.plane_bytes / (double)s->link.dec.wire_bytes : 0;
        break;
    case R_LINK_VIDEO_DECODER: v.s = s->link.dec.video_decoder; break;
    case R_LINK_DECODE_MS: v.h = &t->decode_ms; break;
    case R_LINK_USB_SPEED: v.s = s->link.usb_speed; break;
    case R_IMU_SAMPLES: v.u = t->imu_samples; break;
    case R_IMU_READ_ERRORS: v.u = t->imu_read_errors; break;
    case R_IMU_LOST: v.u = t->imu_lost; break;
    case R_IMU_STALE: v.u = t->imu_stale; break;
    case R_IMU_REPORTS: v.u = s->imu.reports; break;
    case R_IMU_BAD: v.u = s->imu.bad_reports; break;
    case R_IMU_RECONNECTS: v.u = s->imu.reconnects; break;
    case R_IMU_CONNECTED: v.u = s->imu.connected; break;
    case R_VS_EDGES: v.u = s->vsync.edges; break;
    case R_VS_SPURIOUS: v.u = s->vsync.spurious; break;
    case R_VS_MISSED: v.u = s->vsync.missed; break;
    case R_VS_FALLBACKS: v.u = s->vsync.fallbacks; break;
    case R_VS_ON_TIMER: v.u = s->vsync.on_timer; break;
    case R_VS_PERIOD: v.l = s->vsync.period_ns; break;
    case R_VS_JITTER: v.f = s->vsync.jitter_us; break;
    case R_ORIENT_W: v.f = s->orientation.q.w; break;
    case R_ORIENT_X: v.f = s->orientation.q.x; break;
    case R_ORIENT_Y: v.f = s->orientation.q.y; break;
    case R_ORIENT_Z: v.f = s->orientation.q.z; break;
    case R_ORIENT_ERR: v.f = s->orientation_error_deg; break;
    case R_PSNR:
        v.absent = s->eval[i].n == 0;
        v.f = v.absent ? 0 : s->eval[i].psnr_sum / s->eval[i].n;
        break;
    case R_SSIM:
        v.absent = s->eval[i].n == 0;
        v.f = v.absent ? 0 : s->eval[i].ssim_sum / s->eval[i].n;
        break;
    case R_WARP_MS: v.h = &t->warp_ms[i]; break;
    case R_GLES_TIMING: v.s = s->gles_timing; break;
    case R_GLES_MS: v.h = &s->gles_ms[i]; break;
    case R_RT_FALLBACKS: v.u = s->raytrace_fallbacks; break;
    case R_PLANE_FALLBACKS: v.u = s->plane_fallbacks; break;
    case R_M2P: v.h = &t->m2p_ms; break;
    case R_AGE: v.h = &t->frame_age_ms; break;
    case R_OUTPUT: v.s = s->output ? s->output : ""; break;
    case R_HOST_RENDER: v.h = &t->host_render_ms; break;
    case R_PREPARE_MS: v.h = &t->prepare_ms; break;
    case R_PLANES: v.u = s->sim_plane_renders[i]; break;
    case R_IMU_REJECTED: v.u = s->imu_rejected; break;
    case R_EVAL_N: v.u = (unsigned)s->eval[RT_EVAL_NONE].n; break;
    case R_CSV: v.s = s->csv; break;
    default: v.absent = true; break;
    }
    if (!v.s && (rt_summary_table[r].kind == 's')) v.s = "";
    return v;
}

/* ---- --stats ---- */

static void kv_one(const rt_summary_src *s, FILE *out, int r, int i, int n)
{
    const rt_summary_row *row = &rt_summary_table[r];
    val v = value(s, r, i);
    if (v.absent) return;
    char k[96];
    const char *m = rt_summary_member_key(r, i);
    if (m && n > 0) {
        snprintf(k, sizeof k, row->key, m);
        for (char *p = k; *p; p++) /* "I/O error" -> i_o_error: shell-friendly keys */
            *p = isalnum((unsigned char)*p) ? (char)tolower((unsigned char)*p) : '_';
    } else {
        snprintf(k, sizeof k, "%s", row->key);
    }
    switch (row->kind) {
    case 'u': fprintf(out, "%s=%llu\n", k, v.u); break;
    case 'd': fprintf(out, "%s=%d\n", k, (int)v.u); break;
    case 'l': fprintf(out, "%s=%lld\n", k, v.l); break;
    case 'f': fprintf(out, "%s=%.*f\n", k, row->prec, v.f); break;
    case 's': fprintf(out, "%s=%s\n", k, v.s); break;
    default: break;
    }
}

void rt_summary_kv(const rt_summary_src *s, FILE *out)
{
    for (int r = 0; r < rt_summary_table_len; r++) {
        if (!rt_summary_table[r].key) continue;
        /* a run of rows printed member by member: gles_upload_ms_p50, gles_upload_ms_p99, gles_pyramid_ms_p50 ... */
        int last = r;
        while (rt_summary_table[last].with_next) last++;
        int n = rt_summary_members(s, r);
        for (int i = 0; i < n; i++)
            for (int q = r; q <= last; q++) kv_one(s, out, q, i, rt_summary_member_key(q, i) ? n : 0);
        r = last;
    }
}

/* ---- the summary ---- */

static void pct_line(FILE *out, const char *label, const rt_hist *h)
{
    if (!h->count)
        fprintf(out, "  %-26s -\n", label);
    else
        fprintf(out, "  %-26s p50 %6.2f ms   p99 %6.2f ms   max %6.2f ms   (%llu)\n", label, rt_hist_pct(h, 50),
                rt_hist_pct(h, 99), h->max, (unsigned long long)h->count);
}

/* A line's label, as the table has it, padded to the value column. */
static const char *L(int r) { return rt_summary_table[r].label; }

void rt_summary_print(const rt_summary_src *s, FILE *out)
{
    const rt_config *c = s->cfg;
#define U(r) value(s, r, 0).u
#define UI(r, i) value(s, r, i).u
#define STR(r) value(s, r, 0).s
    char buf[400];
    const double secs = (double)U(R_VSYNCS) / c->refresh_hz;
    const double up_s = secs + c->imu_rest_s; /* the rates count the simulated IMU's rest at boot */
    fprintf(out, "\nhmdwarpd %s %s — board '%s', scene '%s', head motion '%s', %.1f s\n", STR(R_VERSION),
            L(R_VERSION), STR(R_BOARD), c->scene, c->trace, secs);
    if (s->gles)
        fprintf(out, "  %-26s gles: %s (%s; %s), warp method %s\n", L(R_RENDERER), STR(R_GL_RENDERER),
                s->gl_version, s->realtime ? "SCHED_FIFO" : "normal priority", rt_method_name(c->method));
    else {
        const bool why = s->cpu_kernel_why && *s->cpu_kernel_why; /* kernel = auto measured the kernels */
        fprintf(out, "  %-26s cpu (%s kernel%s%s%s %d threads, %s%s), warp method %s\n", L(R_RENDERER), s->cpu_kernel,
                why ? ", " : "", why ? s->cpu_kernel_why : "", why ? ";" : ",", s->threads,
                s->realtime           ? "SCHED_FIFO"
                : c->rt_priority == 0 ? "normal priority (rt_priority = 0)"
                                      : "normal priority (not permitted to use SCHED_FIFO)",
                s->realtime ? (s->memory_locked ? ", memory locked" : ", memory not locked") : "",
                rt_method_name(c->method));
    }
    fprintf(out, "  %-26s %s\n", L(R_RENDERER_REASON), STR(R_RENDERER_REASON));
    const warp_scan scan = rt_config_scan(c);
    static const char *const scan_dirs[] = {"top to bottom", "bottom to top", "left to right", "right to left"};
    char scan_txt[96] = "";
    if (scan.rolling && scan.dir >= 0 && scan.dir <= WARP_SCAN_RIGHT_TO_LEFT)
        snprintf(scan_txt, sizeof scan_txt, ", rolling scan %s over %.1f ms", scan_dirs[scan.dir], scan.scan_s * 1e3);
    fprintf(out, "  %-26s %dx%d at %.0f Hz, eye buffers %dx%d, lens mesh %dx%d%s\n", L(R_PANEL), c->panel_w,
            c->panel_h, c->refresh_hz, c->eye_w, c->eye_h, c->mesh_n, c->mesh_n, scan_txt);

    fprintf(out, "display\n");
    const uint64_t vsyncs = U(R_VSYNCS), missed = U(R_MISSED);
    fprintf(out, "  %-26s %llu, missed %llu (%.2f %%)%s\n", L(R_VSYNCS), (unsigned long long)vsyncs,
            (unsigned long long)missed, vsyncs ? 100.0 * (double)missed / (double)vsyncs : 0.0,
            U(R_NO_BUFFER) ? " (some with no free swapchain image)" : "");
    uint64_t missed_by[RT_MISS_COUNT];
    for (int m = 0; m < RT_MISS_COUNT; m++) missed_by[m] = UI(R_MISSED_BY, m);
    if (missed)
        fprintf(out, "  %-26s own %llu (the warp outran its planned time), scheduler: woken late %llu, descheduled "
                     "%llu; no free image %llu\n",
                L(R_MISSED_BY), (unsigned long long)missed_by[RT_MISS_OWN],
                (unsigned long long)missed_by[RT_MISS_LATE_WAKE], (unsigned long long)missed_by[RT_MISS_DESCHEDULED],
                (unsigned long long)missed_by[RT_MISS_NO_BUFFER]);
    rt_miss_advice(missed_by, s->gles, s->gles_software, buf, sizeof buf);
    if (buf[0]) fprintf(out, "  %-26s %s\n", L(R_ADVICE), buf);
    for (int m = 0; m < rt_summary_members(s, R_METHOD); m++)
        if (UI(R_METHOD, m)) {
            snprintf(buf, sizeof buf, "%s (%s)", L(R_WARP_MS), rt_summary_member_label(R_WARP_MS, m));
            pct_line(out, buf, value(s, R_WARP_MS, m).h);
        }
    if (s->gles) {
        fprintf(out, "  %-26s %s, depth pyramid on the %s%s\n", L(R_GLES_TIMING), STR(R_GLES_TIMING),
                s->gles_gpu_pyramid ? "GPU" : "CPU", s->gles_depth ? "" : " (not used)");
        for (int p = 0; p < rt_summary_members(s, R_GLES_MS); p++) {
            const rt_hist *h = value(s, R_GLES_MS, p).h;
            if (!h->count) continue;
            snprintf(buf, sizeof buf, "  %s %s", L(R_GLES_MS), rt_summary_member_label(R_GLES_MS, p));
            pct_line(out, buf, h);
        }
        if (U(R_GLES_ERRORS))
            fprintf(out, "  %-26s %llu; last: %s\n", L(R_GLES_ERRORS), U(R_GLES_ERRORS), s->gles_last_error);
    }
    if (s->kms) {
        const plat_kms_stats *ks = &s->kms_stats;
        fprintf(out, "  %-26s %s %dx%d@%.0f, %s, %s: %llu page flips, %llu failed, %llu late%s%s\n", L(R_KMS_FLIPS),
                ks->connector, ks->w, ks->h, ks->hz, STR(R_KMS_API), STR(R_KMS_FORMAT), U(R_KMS_FLIPS),
                U(R_KMS_FAILED), U(R_KMS_LATE), ks->last_error[0] ? "; last: " : "", ks->last_error);
    }
    if (U(R_RT_FALLBACKS))
        fprintf(out, "  %-26s %llu vsyncs used rotation: the frame had no depth\n", L(R_RT_FALLBACKS),
                U(R_RT_FALLBACKS));
    if (U(R_PLANE_FALLBACKS))
        fprintf(out, "  %-26s %llu vsyncs used the raytrace: the frame lacked layers or ids\n", L(R_PLANE_FALLBACKS),
                U(R_PLANE_FALLBACKS));
    if (c->method == RT_METHOD_AUTO) {
        fprintf(out, "  %-26s budget %.2f px (004 eqs. 5-7 bound of ignoring translation); why:\n", L(R_SELECT),
                c->pixel_budget);
        for (int w = 0; w < rt_summary_members(s, R_SELECT); w++)
            if (UI(R_SELECT, w))
                fprintf(out, "    %-24s %llu vsyncs\n", rt_summary_member_label(R_SELECT, w), UI(R_SELECT, w));
    }
    if (s->has_vsync_stats) {
        const drv_vsync_stats *vs = &s->vsync;
        fprintf(out, "  %-26s %s: edges %llu, spurious %llu, missed %llu, timer fallbacks %llu%s, period %.3f ms, "
                     "jitter %.0f us%s%s\n",
                L(R_VS_EDGES), STR(R_VSYNC_BACKEND), U(R_VS_EDGES), U(R_VS_SPURIOUS), U(R_VS_MISSED),
                U(R_VS_FALLBACKS), U(R_VS_ON_TIMER) ? " (on timer now)" : "", (double)value(s, R_VS_PERIOD, 0).l * 1e-6,
                value(s, R_VS_JITTER, 0).f, vs->last_error[0] ? "; last: " : "", vs->last_error);
    }
    pct_line(out, L(R_M2P), value(s, R_M2P, 0).h);
    if (value(s, R_STALL, 0).f > 0)
        fprintf(out, "  %-26s %.1f ms of the motion-to-photon latency: passes start that much earlier ([render] "
                     "stall_reserve_ms)%s\n",
                L(R_STALL), value(s, R_STALL, 0).f, s->gles ? "; on the GLES path only what fits in a period" : "");
    pct_line(out, L(R_AGE), value(s, R_AGE, 0).h);
    if (!U(R_VISIBLE_PX))
        fprintf(out, "  %-26s -\n", L(R_OUTSIDE_P50));
    else
        fprintf(out, "  %-26s p50 %.2f %%   p99 %.2f %% of the visible panel pixels per frame; %.3f %% over the run "
                     "(%llu of %llu)\n",
                L(R_OUTSIDE_P50), value(s, R_OUTSIDE_P50, 0).f, value(s, R_OUTSIDE_P99, 0).f,
                100.0 * (double)U(R_OUTSIDE_PX) / (double)U(R_VISIBLE_PX), (unsigned long long)U(R_OUTSIDE_PX),
                (unsigned long long)U(R_VISIBLE_PX));
    fprintf(out, "  %-26s %s\n", L(R_OUTPUT), STR(R_OUTPUT));

    fprintf(out, "host frames\n");
    const uint64_t received = U(R_RECEIVED);
    fprintf(out, "  %-26s %llu (%.1f Hz), shown %llu, dropped unseen %llu, rejected %llu\n", L(R_RECEIVED),
            (unsigned long long)received, up_s > 0 ? (double)received / up_s : 0.0, U(R_SHOWN), U(R_DROPPED),
            U(R_REJECTED));
    for (int e = 0; e < rt_summary_members(s, R_REJECTED_BY); e++)
        if (UI(R_REJECTED_BY, e))
            fprintf(out, "    %s %-13s %llu\n", L(R_REJECTED_BY), rt_summary_member_label(R_REJECTED_BY, e),
                    UI(R_REJECTED_BY, e));
    if (s->has_link_stats)
        fprintf(out, "  %-26s %s%s%s, hosts %llu (refused %llu), disconnects %llu; poses sent %llu, dropped "
                     "%llu; camera messages %llu, visibility masks %llu%s%s\n", L(R_LINK_CONNECTED),
                U(R_LINK_CONNECTED) ? "connected" : "NOT connected", s->link.usb_speed[0] ? " at usb " : "",
                s->link.usb_speed, U(R_LINK_CONNECTIONS), U(R_LINK_REFUSED), U(R_LINK_DISCONNECTS), U(R_LINK_POSES),
                U(R_LINK_POSES_DROPPED), U(R_LINK_CAMS), U(R_LINK_MASKS), s->link.last_error[0] ? "; last: " : "",
                s->link.last_error);
    if (s->has_link_stats) {
        char names[64];
        drv_codec_names(s->link.codecs, " ", names, sizeof names);
        fprintf(out, "  %-26s announced %s; %llu frames compressed, %.2f MB/s on the wire (%.1f:1), codec errors "
                     "%llu, key frames asked %llu%s%s\n",
                L(R_LINK_COMPRESSED), names[0] ? names : "-", U(R_LINK_COMPRESSED), value(s, R_LINK_WIRE_MB_S, 0).f,
                value(s, R_LINK_COMPRESSION, 0).f, U(R_LINK_CODEC_ERRORS), U(R_LINK_KEY_REQUESTS),
                STR(R_LINK_VIDEO_DECODER)[0] ? "; video decoder " : "", STR(R_LINK_VIDEO_DECODER));
        pct_line(out, L(R_LINK_DECODE_MS), value(s, R_LINK_DECODE_MS, 0).h);
    }
    pct_line(out, L(R_HOST_RENDER), value(s, R_HOST_RENDER, 0).h);
    pct_line(out, L(R_PREPARE_MS), value(s, R_PREPARE_MS, 0).h);
    if (rt_summary_members(s, R_PLANES)) {
        buf[0] = 0;
        for (int p = 0; p < rt_summary_members(s, R_PLANES); p++) {
            char one[48];
            snprintf(one, sizeof one, "%s%s %llu", p ? ", " : "", rt_summary_member_key(R_PLANES, p),
                     UI(R_PLANES, p));
            strncat(buf, one, sizeof buf - strlen(buf) - 1);
        }
        fprintf(out, "  %-26s %s (scene effects: %s)\n", L(R_PLANES), buf, s->scene_effects ? s->scene_effects : "");
    }

    fprintf(out, "tracking\n");
    const uint64_t samples = U(R_IMU_SAMPLES);
    fprintf(out, "  %-26s %llu (%.0f Hz, incl. the rest at boot), rejected %llu, read errors %llu\n", L(R_IMU_SAMPLES),
            (unsigned long long)samples, up_s > 0 ? (double)samples / up_s : 0.0, U(R_IMU_REJECTED),
            U(R_IMU_READ_ERRORS));
    if (s->has_imu_stats)
        fprintf(out, "  %-26s %s: %s, reports %llu, bad %llu, read errors %llu, reconnects %llu%s%s\n",
                L(R_IMU_REPORTS), STR(R_IMU_BACKEND), U(R_IMU_CONNECTED) ? "connected" : "NOT connected",
                U(R_IMU_REPORTS), U(R_IMU_BAD), (unsigned long long)s->imu.read_errors, U(R_IMU_RECONNECTS),
                s->imu.last_error[0] ? "; last: " : "", s->imu.last_error);
    if (U(R_IMU_LOST) || U(R_IMU_STALE))
        fprintf(out, "  %-26s %llu times; %llu vsyncs held the last orientation\n", L(R_IMU_LOST), U(R_IMU_LOST),
                U(R_IMU_STALE));
    if (rt_summary_members(s, R_ORIENT_ERR)) {
        const warp_vec3 b = s->orientation.bias;
        fprintf(out, "  %-26s %.3f deg (gyro bias estimate %.4f %.4f %.4f rad/s)\n", L(R_ORIENT_ERR),
                value(s, R_ORIENT_ERR, 0).f, b.x, b.y, b.z);
    }
    if (rt_summary_members(s, R_EVAL_N)) {
        fprintf(out, "%-28s left eye at photon time, before the lens%s; %d frames sampled\n", L(R_EVAL_N),
                scan.rolling ? " (rolling panel: the truth per band at each band's photon time)" : "",
                (int)U(R_EVAL_N));
        const rt_eval_pose *pe = s->eval_pose;
        if (pe && pe->n)
            fprintf(out, "  %-26s mean %.3f deg / %.2f mm, max %.3f deg / %.2f mm (prediction and tracking; no warp "
                         "can fix it)\n",
                    L(R_POSE_ERR), pe->angle_sum / pe->n, pe->pos_sum / pe->n, pe->angle_max, pe->pos_max);
        fprintf(out, "  %-26s %9s %9s %8s %12s\n", "method", L(R_PSNR), "min dB", L(R_SSIM), "error px %");
        for (int m = 0; m < RT_EVAL_METHODS; m++) {
            const rt_eval_acc *e = &s->eval[m];
            if (!e->n) continue;
            const char *name = rt_summary_member_label(R_PSNR, m);
            /* printf pads by bytes: widen by the UTF-8 continuation bytes (the "§") so the columns line up */
            int wide = 26;
            for (const char *p = name; *p; p++) wide += ((unsigned char)*p & 0xc0) == 0x80;
            fprintf(out, "  %-*s %9.2f %9.2f %8.4f %12.3f\n", wide, name, e->psnr_sum / e->n, e->psnr_min,
                    e->ssim_sum / e->n, e->err_sum / e->n);
        }
    }
    if (rt_summary_members(s, R_CSV)) fprintf(out, "%-28s %s\n", L(R_CSV), STR(R_CSV));
#undef U
#undef UI
#undef STR
}
