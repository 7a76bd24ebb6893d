/* SPDX-License-Identifier: MIT */
/* rt_eval: the accuracy evaluator's part of a run (simulated board only): the records the compositor hands it, its
 * scores per method, and the idle-priority thread that re-renders the truth and scores them. */
#ifndef RT_EVAL_H
#define RT_EVAL_H

#include <stdatomic.h>
#include <stdint.h>

#include "runtime/rt_config.h"
#include "runtime/rt_ring.h"
#include "sim/sim_trace.h"
#include "warp/warp_camera.h"
#include "warp/warp_head.h"
#include "warp/warp_math.h"
#include "sim/sim_scene.h"
#include "warp/warp_mesh.h"
#include "warp/warp_mesh_trace.h"
#include "warp/warp_raytrace.h"
#include "warp/warp_resample.h"
#include "warp/warp_scan.h"

typedef struct sim_scene sim_scene;

/* What the compositor hands the accuracy evaluator about one displayed frame (simulated board only). */
typedef struct {
    uint64_t vsync_no, frame_seq;
    double src_scene_time;     /* the scene time the host rendered */
    double photon_scene_time;  /* when the warped frame is seen */
    warp_pose src_eye;         /* left eye pose the frame was rendered with */
    warp_pose shown_eye;       /* left eye pose the compositor warped to (the prediction) */
    int method;
    /* rolling scanout: the left eye poses the compositor predicted for the scan's first and last line (the mesh
     * warps slerp between them); shown_eye twice when it did not compensate */
    warp_pose shown_first, shown_last;
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

/* What the evaluator re-renders and how it warps, set before its thread starts and only read by it. */
typedef struct {
    const sim_scene *scene;
    const sim_trace *trace;     /* the true head motion */
    warp_camera cam;            /* the left eye's */
    warp_head head;
    int mesh_n;                 /* [lens] mesh: raytrace_mesh's vertex grid */
    warp_raytrace_params rp;    /* the CPU pass's raytrace knobs (rt_render_cpu_raytrace_params) */
    warp_mesh_trace_params tp;  /* and its raytrace_mesh's (rt_render_cpu_mesh_trace_params) */
    warp_scan scan;             /* the panel's scanout (rt_config_scan): rolling renders the truth per band */
    _Atomic int *stop;          /* the run's: the thread returns once it is set and the ring is empty */
} rt_eval_inputs;

/* The evaluator's state: the compositor pushes records into ring (never blocking: a full ring drops the sample);
 * the thread alone writes the scores, read once it has stopped (the summary) or by tests. */
typedef struct {
    rt_ring ring;
    rt_eval_inputs in;
    rt_eval_acc acc[RT_EVAL_METHODS];
    rt_eval_pose pose;
    int done; /* records scored */
} rt_eval;

/* The accuracy evaluator: processes records until in.stop is set and the ring is empty. arg: the rt_eval. */
void *rt_eval_thread(void *arg);

/* Bands of the per-band truth on a rolling panel: each rendered at its own photon time and stitched. 16 bands of
 * a 11 ms scan are 0.7 ms apart, 0.2 deg at 300 deg/s: well under what separates compensated from not. */
#define RT_EVAL_SCAN_BANDS 16

/* One evaluation's buffers (the thread's, and hmdwarp-bench's rolling section, which scores records it makes). */
typedef struct {
    sim_buffers src, truth, band;
    warp_image_rgba8 out;
    warp_image_f32 inv;
    warp_mesh mesh;
    warp_mesh_trace mtrace; /* raytrace_mesh's cells traced per pixel, as the CPU pass's */
    warp_planar3 planar;
} rt_eval_work;

/* Allocates w for in's camera and mesh size; false on out of memory (w is then freed). */
bool rt_eval_work_alloc(rt_eval_work *w, const rt_eval_inputs *in);
void rt_eval_work_free(rt_eval_work *w);
/* The truth a left eye sees when the panel's mid-scan photon time is photon_scene_time, into w->truth.color: one
 * render at the true pose then (global scanout), or on a rolling panel RT_EVAL_SCAN_BANDS bands along the scan
 * direction, each rendered at its own photon time with the true pose then (the eye buffer standing for the left
 * eye's viewport, the lens left out as in every score here). */
void rt_eval_truth(rt_eval_work *w, const rt_eval_inputs *in, double photon_scene_time);
/* Scores record r into acc (and its pose error into pose, when not NULL): the truth, then no warp, rotation,
 * raytrace and raytrace_mesh. On a rolling panel rotation and raytrace_mesh run as the display's lens mesh does
 * (per vertex from r's first- to last-line pose, through an eye mesh of in.mesh_n), raytrace at r's mid-scan pose. */
void rt_eval_score(rt_eval_work *w, const rt_eval_inputs *in, const rt_eval_record *r, rt_eval_acc acc[RT_EVAL_METHODS],
                   rt_eval_pose *pose);

#endif
