/* SPDX-License-Identifier: MIT */
/* rt_app: one hmdwarpd instance: devices chosen by board.ini, the IMU, frames, compositor and helper threads, and
 * the run summary. hmdwarpd_main parses arguments; tests drive an instance directly. */
#ifndef RT_APP_H
#define RT_APP_H

#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdio.h>

#include "drivers/drv_frames.h"
#include "drivers/drv_imu.h"
#include "drivers/drv_sim.h"
#include "drivers/drv_vsync.h"
#include "platform/plat_display.h"
#include "platform/plat_egl.h"
#include "platform/plat_gles.h"
#include "platform/plat_workers.h"
#include "runtime/rt_config.h"
#include "runtime/rt_frameq.h"
#include "runtime/rt_fusion.h"
#include "runtime/rt_ring.h"
#include "runtime/rt_telemetry.h"
#include "sim/sim_scene.h"
#include "sim/sim_trace.h"
#include "warp/warp_head.h"
#include "warp/warp_lens.h"
#include "warp/warp_mesh.h"
#include "warp/warp_forward.h"
#include "warp/warp_grid.h"
#include "warp/warp_holes.h"
#include "warp/warp_objects.h"
#include "warp/warp_raytrace.h"
#include "warp/warp_transparency.h"
#include "runtime/rt_select.h"

/* Older than this, the newest IMU state is not extrapolated: the device is gone or stalled (prediction off). */
#define RT_IMU_STALE_NS (150 * 1000000LL)

/* What the compositor hands the accuracy evaluator about one displayed frame (simulated board only). */
typedef struct {
    uint64_t vsync_no, frame_seq;
    double src_scene_time;     /* the scene time the host rendered */
    double photon_scene_time;  /* when the warped frame is seen */
    warp_pose src_eye;         /* left eye pose the frame was rendered with */
    warp_pose shown_eye;       /* left eye pose the compositor warped to (the prediction) */
    int method;
} rt_eval_record;

/* How far the pose the compositor warped to was from the true pose at photon time: the error no warp can fix. */
typedef struct {
    int n;
    double angle_sum, angle_max;  /* degrees */
    double pos_sum, pos_max;      /* millimetres */
} rt_eval_pose;

/* Accuracy of one method over the evaluated frames (left eye, before lens distortion, vs ground truth). */
typedef struct {
    int n;
    double psnr_sum, ssim_sum, err_sum; /* err: error-pixel % (002 §4) */
    double psnr_min;
} rt_eval_acc;

enum { RT_EVAL_NONE, RT_EVAL_ROTATION, RT_EVAL_RAYTRACE, RT_EVAL_RAYTRACE_MESH, RT_EVAL_METHODS };
/* The registry methods the evaluator scores, by RT_EVAL_* (their --stats keys are psnr_NAME, ssim_NAME). */
extern const rt_method rt_eval_methods[RT_EVAL_METHODS];

/* One CSV row per vsync, produced on the vsync path and written by the telemetry thread. */
typedef struct {
    uint64_t vsync_no, frame_seq;
    int64_t vsync_ns;
    float warp_ms, m2p_ms, frame_age_ms;
    int method;
    int missed;
} rt_csv_row;

typedef struct {
    rt_config cfg;
    int64_t t0_ns;         /* scene time origin (simulated board) */
    int64_t t_end_ns;      /* 0 = run until stopped */
    _Atomic int stop;

    /* devices */
    bool sim_host;         /* frames come straight from the simulated host (its render statistics are known) */
    bool has_truth;        /* the head motion and the scene are simulated: accuracy can be scored */
    bool imu_remap;        /* [imu] axes is not the identity */
    int imu_map[3], imu_sign[3];
    drv_imu *imu;
    drv_frames *frames;
    drv_vsync *vsync;
    plat_display *display;
    plat_kms *kms;         /* the KMS output (owned by display on the CPU path, by egl on GLES), NULL offscreen */

    /* tracking and frames */
    rt_fusion *fusion;
    rt_frameq fq;
    warp_head head;

    /* compositor */
    warp_camera eye_cam[2];
    warp_lens lens[2];
    warp_mesh mesh[2];
    plat_swapchain sc;
    plat_workers *workers;
    warp_raytrace_params rt_params;
    warp_image_rgba8 inter[2];  /* raytrace output in eye space, before the lens pass */
    warp_planar3 inter_planar[2];
    bool realtime;              /* compositor got SCHED_FIFO */
    bool memory_locked;         /* mlockall succeeded */
    uint64_t raytrace_fallbacks; /* raytrace requested but the frame had no depth */
    uint64_t plane_fallbacks;    /* transparency / objects requested but the frame lacked layers / ids */
    /* auto selection (rt_select) and the further depth warps, allocated when the method may use them */
    rt_select sel;
    bool can_transparency, can_objects;
    warp_grid grid[2];
    warp_minmax_tree abuf[2];
    const void *abuf_frame[2];     /* the frame slot and sequence the grid and tree were built from: they depend */
    uint64_t abuf_seq[2];          /* on the source only, so they are built once per host frame, not per vsync */
    warp_image_f32 zb[2];          /* warped opaque inverse depth (transparency) */
    warp_image_u8 wmask[2];        /* the depth warps' masks (holes, fringe) */
    warp_fwd_scratch fwd[2];
    warp_objects_setup *objs[2];
    warp_holes_ctx holes[2];
    warp_pose obj_prev[DRV_MAX_OBJECTS], obj_cur[DRV_MAX_OBJECTS], obj_at[DRV_MAX_OBJECTS];
    double obj_prev_t, obj_cur_t;  /* pose times of the two newest frames, seconds on the board clock */
    int obj_n;
    bool obj_two;                  /* two frames' object poses known: extrapolation possible */

    /* renderer ([render] renderer, rt_render_choose) */
    bool use_gles;
    bool gles_software; /* the GLES renderer is a software rasterizer: its GPU time is CPU time after the submit */
    char render_why[256];       /* why this renderer was chosen, for the summary */
    plat_egl *egl;              /* EGL display + context (GLES only) */
    plat_gles *gles;
    bool gles_depth;            /* the GLES resources include depth, pyramid and raytrace */
    const rt_frame *gles_frame; /* the frame whose planes are in the GLES textures */
    uint64_t gles_frame_seq;
    _Atomic uint64_t gles_errors; /* failed uploads, readbacks or page flips (read live: atomic) */
    char gles_last_error[200];
    rt_hist *gles_ms;           /* [PLAT_GLES_PASSES] GPU time per pass and vsync (compositor thread) */
    uint64_t gles_times_seq;
    double gles_gpu_ms;         /* newest complete frame's GPU time, all passes */
    int64_t gles_submit_ns;     /* when the last vsync's GL work was all submitted */

    /* telemetry */
    rt_telemetry *tel;
    rt_ring csv_ring;
    FILE *csv;
    uint64_t csv_bytes;        /* written to the current CSV file (helper thread), for [telemetry] csv_max_mb */
    bool csv_dead;             /* rotation could not reopen the CSV: rows are dropped, a->csv is closed */
    /* live telemetry, from the helper thread once a second: the key=value set of --stats in one of two buffers,
     * the other being rewritten; the abort handler writes the published one (rt_app_write_last_stats) */
    int64_t run_start_ns, run_end_ns; /* rt_app_run's start; the compositor's return (0 while running) */
    char live_path[256];       /* [telemetry] live_stats resolved ("" = off) */
    char *live_buf[2];
    _Atomic size_t live_len[2];
    _Atomic int live_pub;      /* the buffer complete and published, -1 none yet */
    rt_hist_mark *live_m2p, *live_age; /* the histograms' counts a second ago (STATUS's "last second") */

    /* simulated board */
    bool sim_loaded;           /* scene and trace loaded: some device is simulated (rt_devices_simulated) */
    const sim_scene *scene;    /* NULL unless sim_loaded */
    sim_trace trace;
    rt_ring eval_ring;
    rt_eval_acc eval[RT_EVAL_METHODS];
    rt_eval_pose eval_pose;
    int eval_done;
    uint64_t sim_plane_renders[5];
    uint64_t sim_frames;

    pthread_t th_imu, th_frames, th_aux;
    bool th_imu_up, th_frames_up, th_aux_up;
} rt_app;

/* Opens devices and allocates everything the run needs (nothing is allocated after this on the vsync path).
 * On failure returns false with a message naming the key or device in err. */
bool rt_app_init(rt_app *a, const rt_config *cfg, char *err, int errlen);
/* Starts the IMU, frames and helper threads, then runs the compositor on the calling thread until the configured
 * duration elapses or rt_app_request_stop() is called. */
void rt_app_run(rt_app *a);
void rt_app_request_stop(rt_app *a);
/* Prints the run summary (see README "Reading the summary"). */
void rt_app_summary(rt_app *a, FILE *out);
/* The summary as key=value lines, one per counter, for scripts (hardware-in-the-loop scenarios). */
void rt_app_stats_kv(rt_app *a, FILE *out);
/* Whether the run showed at least one host frame. False, with the reason in one line, when it presented no vsync,
 * received no host frame, or rejected every one it received: such a run fails (hmdwarpd exits 1). */
bool rt_app_showed_frames(const rt_app *a, char *why, int whylen);
/* Writes the key=value lines the helper thread last published (at most a second old) to fd with write(2);
 * async-signal-safe, for the abort handler. Returns false when none was published yet. */
bool rt_app_write_last_stats(rt_app *a, int fd);
void rt_app_free(rt_app *a);

/* Opens the IMU, frames and vsync backends board.ini names (rt_devices.c); sp describes the simulated host,
 * used by the sim backend and the mocks. Sets has_truth and sim_host. */
bool rt_devices_open(rt_app *a, const drv_frames_sim_params *sp, char *err, int errlen);
/* Whether the configuration has the simulator play a device (a sim backend or a mock device). */
bool rt_devices_simulated(const rt_config *c);
/* Whether every device follows plat_clock's virtual time (HMDWARP_TIME_SLOWDOWN); *real names the first that
 * does not. */
bool rt_devices_on_virtual_time(const rt_config *c, const char **real);

/* Decides the renderer from [render] renderer (`setting`: auto, cpu, gles), the GL_RENDERER string of the context
 * EGL gave (NULL when it gave none; egl_err then says why) and whether the output is KMS. Returns true for GLES
 * and writes the reason in one line to why. auto picks GLES on a hardware GPU and the CPU path when only a
 * software rasterizer (llvmpipe) or no EGL is there: there the CPU path is faster, and vsync comes first. With
 * KMS output the choice is the same (the CPU path shows through dumb buffers). A forced gles without EGL returns
 * true: the caller fails. */
bool rt_render_choose(const char *setting, const char *gl_renderer, const char *egl_err, bool kms, char *why,
                      int whylen);

/* The compositor loop (rt_compositor.c). */
void rt_compositor_run(rt_app *a);
/* The accuracy evaluator (rt_eval.c): processes records until stop is set and the ring is empty. */
void *rt_eval_thread(void *arg);

#endif
