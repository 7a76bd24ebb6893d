/* SPDX-License-Identifier: MIT */
/* rt_summary: a run's counters as one table (key, summary line, where each goes, how to read it), from which both
 * the human summary (README "Reading the summary") and the key=value --stats / live stats print. */
#ifndef RT_SUMMARY_H
#define RT_SUMMARY_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "drivers/drv_frames_usb.h"
#include "drivers/drv_imu.h"
#include "drivers/drv_vsync.h"
#include "platform/plat_kms.h"
#include "runtime/rt_config.h"
#include "runtime/rt_eval.h"
#include "runtime/rt_fusion.h"
#include "runtime/rt_telemetry.h"

/* What the table reads: the run's parts as plain values and pointers, filled by rt_app (rt_app_summary_src) or
 * by a test. The devices' stats are copies taken when it is filled; the counters are read as they are printed. */
typedef struct {
    const rt_config *cfg;
    const rt_telemetry *tel;
    bool live;                 /* the run goes on: leave out what the evaluator publishes only at its end */
    double run_s;              /* since the display started (after the simulated IMU's rest) until it stopped */
    /* renderer */
    bool gles, gles_software, gles_depth, gles_gpu_pyramid;
    bool realtime, memory_locked;
    const char *gl_renderer, *gl_version, *gles_timing; /* "" on the CPU path */
    const char *render_why;
    const char *cpu_kernel;
    const char *cpu_kernel_why; /* "" or NULL unless [render] kernel = auto measured it (rt_kernel) */
    int threads;
    const rt_hist *gles_ms;    /* [PLAT_GLES_PASSES], NULL on the CPU path */
    uint64_t gles_errors;
    const char *gles_last_error;
    uint64_t raytrace_fallbacks, plane_fallbacks;
    /* devices */
    const char *imu_name, *frames_name, *vsync_name; /* "" when not open */
    bool has_imu_stats, has_vsync_stats, kms;
    bool has_link_stats;       /* the frames come over a framelink link (usb, its mock, socket) */
    drv_frames_usb_stats link;
    drv_imu_stats imu;
    drv_vsync_stats vsync;
    plat_kms_stats kms_stats;  /* zeros, api and format "", offscreen */
    const char *output;        /* the display's description (summary only) */
    /* tracking */
    uint64_t imu_rejected;     /* samples the tracker refused (bad values, repeated or jumping times) */
    bool has_orientation;
    rt_fusion_state orientation;
    bool has_truth;            /* orientation_error_deg is known */
    double orientation_error_deg;
    /* simulated board */
    bool sim_host;
    const uint64_t *sim_plane_renders; /* [5]: colour, depth, ids, motion, layers */
    const char *scene_effects;
    bool accuracy;             /* the evaluator ran ([sim] eval_every_ms with ground truth) */
    const rt_eval_acc *eval;   /* [RT_EVAL_METHODS] */
    const rt_eval_pose *eval_pose;
    const char *csv;           /* the per-vsync CSV's path, NULL when none is written */
} rt_summary_src;

/* Where a counter is printed. Both is the rule; the others are deliberate (a table column, so a test can tell a
 * counter someone forgot in one output from one meant for one only). */
typedef enum { RT_SUM_BOTH, RT_SUM_STATS, RT_SUM_SUMMARY } rt_summary_where;

/* One counter, or a family of them (one per method, miss cause, rejection reason ...). */
typedef struct {
    const char *key;    /* --stats key; a family's holds %s for the member (NULL: summary only) */
    const char *label;  /* text the summary line showing it starts with (NULL: --stats only) */
    rt_summary_where where;
    char kind;          /* u %llu, d %d, l %lld, f %.*f, s %s; summary only: h histogram, x text the line composes */
    int prec;           /* digits after the point for kind f */
    bool with_next;     /* --stats: a family printed member by member together with the next row's */
} rt_summary_row;

extern const rt_summary_row rt_summary_table[];
extern const int rt_summary_table_len;
/* A family row's members and their names: in the key, and (where the summary names them) on its lines. Returns
 * how many members row r has for src (0: absent in this run, 1: a single counter). */
int rt_summary_members(const rt_summary_src *s, int r);
const char *rt_summary_member_key(int r, int i);   /* NULL for a single counter */
const char *rt_summary_member_label(int r, int i); /* NULL when the summary does not name members */

/* The human summary (README "Reading the summary"). */
void rt_summary_print(const rt_summary_src *s, FILE *out);
/* The key=value lines, one per counter, in the table's order. */
void rt_summary_kv(const rt_summary_src *s, FILE *out);

#endif
