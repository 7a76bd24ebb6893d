/* SPDX-License-Identifier: MIT */
/* bench_rolling: what rolling-scan compensation buys on the simulated board's fast trace: the accuracy evaluator's
 * own scoring (rt_eval_score) against per-band truth, with the mesh warps per vertex row and without. */
#ifndef BENCH_ROLLING_H
#define BENCH_ROLLING_H

#include <stdbool.h>
#include <stdio.h>

#include "runtime/rt_eval.h"

typedef struct {
    const char *out;  /* directory for rolling.md; NULL: stdout only */
    int frames;       /* evaluated frames (0: BENCH_ROLLING_FRAMES) */
    int eye_w, eye_h; /* 0: 360 x 400, half the simulated board's eye */
} bench_rolling_opts;

#define BENCH_ROLLING_FRAMES 32

/* Scores per method, RT_EVAL_* order, on the same frames: global prediction on the rolling panel, and rolling
 * compensation. */
typedef struct {
    rt_eval_acc global[RT_EVAL_METHODS], rolling[RT_EVAL_METHODS];
    double speed_mean_dps; /* mean true head speed over the evaluated frames, deg/s */
} bench_rolling_result;

/* Runs the comparison (deterministic: the trace, the scene and the prediction are functions of time) on a panel
 * scanning top to bottom over 90 % of a 90 Hz refresh. False with the reason on stderr. */
bool bench_rolling_measure(const bench_rolling_opts *o, bench_rolling_result *res);
/* Measures, prints the table to stdout and (o->out) writes rolling.md. */
bool bench_rolling_run(const bench_rolling_opts *o);

#endif
