/* SPDX-License-Identifier: MIT */
/* bench_rolling: what rolling-scan compensation buys on the simulated board's fast trace: the accuracy evaluator's
 * own scoring (rt_eval_score) against per-band truth, with the mesh warps per vertex row and without. */
#include "tools/hmdwarp-bench/bench_rolling.h"

#include <math.h>
#include <string.h>

#include "runtime/rt_config.h"
#include "sim/sim_scene.h"
#include "sim/sim_trace.h"
#include "warp/warp_raytrace.h"

/* What the simulated board does, as functions of time so that every run scores the same frames: frames are
 * rendered two 90 Hz frames before their mid-scan photon time (the sim host's usual age at 45 Hz), and the board
 * predicts from the true state 7.5 ms before it (an IMU sample 2 ms before the vsync, 5.5 ms to mid-scan) at
 * constant angular velocity, as rt_fusion_predict does. Only frames during a turn (> 100 deg/s) are scored: at
 * rest both warps are the same image. */
#define REFRESH_HZ 90.0
#define FRAME_AGE_S (2.0 / REFRESH_HZ)
#define SAMPLE_AGE_S 7.5e-3
#define TURN_DPS 100.0
#define TRACE_END_S 20.0

/* The left eye's pose at t as the board predicts it from the true state at t_sample. */
static warp_pose predict_eye(const sim_trace *tr, double t_sample, double t)
{
    const warp_vec3 w = sim_trace_angular_velocity(tr, t_sample);
    const warp_quat step = warp_quat_exp(warp_v3_scale(w, t - t_sample));
    warp_quat q;
    warp_quat_normalize(warp_quat_mul(sim_trace_orientation(tr, t_sample), step), &q);
    return warp_head_eye_pose(&tr->head, warp_head_pose_from_orientation(&tr->head, q), 0);
}

bool bench_rolling_measure(const bench_rolling_opts *o, bench_rolling_result *res)
{
    memset(res, 0, sizeof *res);
    rt_config c;
    rt_config_defaults(&c);
    c.eye_w = o->eye_w > 0 ? o->eye_w : 360;
    c.eye_h = o->eye_h > 0 ? o->eye_h : 400;
    c.panel_w = 2 * c.eye_w;
    c.panel_h = c.eye_h;
    /* the eye buffer is scored before the lens, so its field is fixed here (fov = auto would derive it from a lens
     * sized for the default panel, not this one) */
    const double fov[4] = {52, 48, 52, 52};
    for (int i = 0; i < 4; i++) c.fov_deg[i] = fov[i];
    c.refresh_hz = REFRESH_HZ;
    c.scanout = 1;
    c.scan_direction = WARP_SCAN_TOP_TO_BOTTOM;
    c.scan_ms = 0; /* auto: 90 % of the refresh */
    sim_trace tr;
    const sim_scene *scene = sim_scene_find("room");
    if (!scene || !sim_trace_init(&tr, "fast", c.seed)) {
        fprintf(stderr, "hmdwarp-bench: rolling: no room scene or fast trace\n");
        return false;
    }
    rt_eval_inputs in = {.scene = scene, .trace = &tr, .cam = rt_config_eye_camera(&c, WARP_EYE_LEFT),
                         .head = tr.head, .mesh_n = c.mesh_n, .rp = warp_raytrace_default_params(),
                         .tp = warp_mesh_trace_default_params(),
                         .scan = rt_config_scan(&c)};
    in.rp.max_steps = c.raytrace_steps;
    rt_eval_work w;
    if (!rt_eval_work_alloc(&w, &in)) {
        fprintf(stderr, "hmdwarp-bench: rolling: out of memory\n");
        return false;
    }
    const int frames = o->frames > 0 ? o->frames : BENCH_ROLLING_FRAMES;
    const double half = 0.5 * in.scan.scan_s;
    int n = 0;
    for (long k = 1; n < frames && k / REFRESH_HZ < TRACE_END_S; k++) {
        const double tp = (double)k / REFRESH_HZ; /* mid-scan photon time */
        const double speed = warp_v3_norm(sim_trace_angular_velocity(&tr, tp)) * 180 / WARP_PI;
        if (speed < TURN_DPS) continue;
        const double ts = tp - SAMPLE_AGE_S, tsrc = tp - FRAME_AGE_S;
        rt_eval_record r = {.vsync_no = (uint64_t)k, .frame_seq = (uint64_t)n, .src_scene_time = tsrc,
                            .photon_scene_time = tp};
        r.src_eye = warp_head_eye_pose(&tr.head, sim_trace_head_pose(&tr, tsrc), 0);
        r.shown_eye = r.shown_first = r.shown_last = predict_eye(&tr, ts, tp);
        rt_eval_score(&w, &in, &r, res->global, NULL);
        r.shown_first = predict_eye(&tr, ts, tp - half);
        r.shown_last = predict_eye(&tr, ts, tp + half);
        rt_eval_score(&w, &in, &r, res->rolling, NULL);
        res->speed_mean_dps += speed;
        n++;
    }
    rt_eval_work_free(&w);
    if (n) res->speed_mean_dps /= n;
    return n > 0;
}

static double mean(const rt_eval_acc *a, double sum) { return a->n ? sum / a->n : NAN; }

static void table(FILE *f, const bench_rolling_result *r, int eye_w, int eye_h)
{
    fprintf(f, "Rolling scanout on the `fast` trace (room scene, %dx%d left eye, top-to-bottom scan over 10 ms of a "
               "90 Hz refresh; %d frames during turns, mean %.0f deg/s), against per-band truth (%d bands):\n\n",
            eye_w, eye_h, r->global[RT_EVAL_NONE].n, r->speed_mean_dps, RT_EVAL_SCAN_BANDS);
    fprintf(f, "| method | PSNR global prediction, dB | PSNR rolling compensation, dB | gain, dB | error pixels "
               "global / rolling, %% |\n|---|---|---|---|---|\n");
    for (int m = 0; m < RT_EVAL_METHODS; m++) {
        const rt_eval_acc *g = &r->global[m], *o = &r->rolling[m];
        double pg = mean(g, g->psnr_sum), po = mean(o, o->psnr_sum);
        fprintf(f, "| %s | %.2f | %.2f | %+.2f | %.2f / %.2f |\n", rt_method_name(rt_eval_methods[m]), pg, po, po - pg,
                mean(g, g->err_sum), mean(o, o->err_sum));
    }
    fprintf(f, "\nrotation and raytrace_mesh warp each mesh vertex row at its own line's pose; raytrace (per pixel) "
               "keeps the mid-scan pose and none does not warp, so those rows are the same both ways.\n");
}

bool bench_rolling_run(const bench_rolling_opts *o)
{
    bench_rolling_result r;
    if (!bench_rolling_measure(o, &r)) return false;
    const int ew = o->eye_w > 0 ? o->eye_w : 360, eh = o->eye_h > 0 ? o->eye_h : 400;
    table(stdout, &r, ew, eh);
    if (o->out) {
        char path[600];
        snprintf(path, sizeof path, "%s/rolling.md", o->out);
        FILE *f = fopen(path, "w");
        if (!f) {
            fprintf(stderr, "hmdwarp-bench: cannot write %s\n", path);
            return false;
        }
        fprintf(f, "# Rolling-scan compensation (hmdwarp-bench --rolling-only)\n\n");
        table(f, &r, ew, eh);
        fclose(f);
    }
    return true;
}
