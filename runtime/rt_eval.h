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
#include "warp/warp_raytrace.h"

typedef struct sim_scene sim_scene;

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

/* What the evaluator re-renders and how it warps, set before its thread starts and only read by it. */
typedef struct {
    const sim_scene *scene;
    const sim_trace *trace;     /* the true head motion */
    warp_camera cam;            /* the left eye's */
    warp_head head;
    int mesh_n;                 /* [lens] mesh: raytrace_mesh's vertex grid */
    warp_raytrace_params rp;    /* the CPU pass's raytrace knobs (rt_render_cpu_raytrace_params) */
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

#endif
