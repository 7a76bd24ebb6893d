/* SPDX-License-Identifier: MIT */
/* rt_select: which warp each vsync runs: the cheapest one whose predicted error stays under a pixel budget, given
 * the head motion the frame must bridge, the nearest depth in it (004 eqs. 5-7), its planes and the time left. */
#ifndef RT_SELECT_H
#define RT_SELECT_H

#include <stdbool.h>
#include <stdint.h>

#include "runtime/rt_config.h"
#include "warp/warp_camera.h"

/* Why the selector chose what it chose (counted in telemetry). */
typedef enum {
    RT_WHY_CONFIGURED = 0,   /* [warp] method names one warp: no selection */
    RT_WHY_NO_FRAME,         /* nothing to warp yet */
    RT_WHY_ROTATION_ONLY,    /* the frame has no depth (a rotation-only scene): rotation is all there is */
    RT_WHY_PARALLAX_SMALL,   /* translation x nearest depth predicts less than the budget: rotation suffices */
    RT_WHY_PARALLAX,         /* ignoring the translation would cost more than the budget: a depth warp */
    RT_WHY_TRANSPARENCY,     /* the frame carries transparent layers and the head translates: their own warp */
    RT_WHY_OBJECT_MOTION,    /* moving objects: a warp that moves them */
    RT_WHY_HELD,             /* would de-escalate, but held for stability (hysteresis) */
    RT_WHY_TIME_BUDGET,      /* the preferred warp does not fit before the vsync: degraded to a cheaper one */
    RT_WHY_COUNT
} rt_select_why;
const char *rt_select_why_str(rt_select_why w);

typedef struct {
    double pixel_budget; /* px: the largest error, predicted on the panel's eye buffer, accepted from a cheaper warp */
    double hysteresis;   /* de-escalate only when the prediction falls below budget * (1 - hysteresis) ... */
    int hold_vsyncs;     /* ... for this many vsyncs in a row */
} rt_select_params;

/* What one vsync knows. */
typedef struct {
    bool have_frame;
    bool has_depth;
    float inv_depth_max;      /* nearest surface in the frame, 1/m (0 = all sky) */
    bool has_layers;          /* transparent fragments present */
    bool objects_moving;      /* object ids and matrices present and some object moved between the last two frames */
    double translation_m;     /* head (eye) translation between the frame's pose and the target pose */
    double time_left_ns;      /* until the warp must be done */
    double cost_ns[RT_METHOD_COUNT]; /* expected time per method (the compositor's running estimates; 0 = unknown) */
} rt_select_input;

/* The selector's state: the method in use and how long a cheaper one has been good enough. */
typedef struct {
    rt_select_params p;
    warp_camera cam;          /* the eye buffer the error is predicted in */
    rt_method current;
    int calm;                 /* vsyncs in a row the prediction stayed below the de-escalation threshold */
    double last_px;           /* the last prediction, px */
} rt_select;

rt_select_params rt_select_default_params(void); /* budget 0.5 px, hysteresis 0.3, hold 45 vsyncs */
void rt_select_init(rt_select *s, const rt_select_params *p, const warp_camera *cam);

/* The worst-case on-screen error, in pixels of cam, of ignoring a head translation of translation_m for surfaces
 * no nearer than 1/inv_depth_max: 004 eqs. 5-7, p = a_max * asin(T / d_min), with a_max the largest pixels per
 * radian anywhere in the image (at its corners). */
double rt_select_parallax_px(const warp_camera *cam, double translation_m, double inv_depth_max);

/* Chooses this vsync's method; `configured` is [warp] method (RT_METHOD_AUTO selects). Allocation-free, O(1):
 * called on the vsync path. *why gets the reason. */
rt_method rt_select_choose(rt_select *s, rt_method configured, const rt_select_input *in, rt_select_why *why);

#endif
