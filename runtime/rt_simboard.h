/* SPDX-License-Identifier: MIT */
/* rt_simboard: the simulated board as one part: the scene, the true head motion, the simulated host's render
 * counters and the accuracy evaluator. A run creates it only when some device is simulated; real boards never do. */
#ifndef RT_SIMBOARD_H
#define RT_SIMBOARD_H

#include <stdbool.h>
#include <stdint.h>

#include "runtime/rt_config.h"
#include "runtime/rt_devices.h"
#include "runtime/rt_eval.h"
#include "sim/sim_trace.h"

typedef struct rt_simboard rt_simboard;

/* Looks up [sim] scene and trace (the head model's ipd from [head]); call it only when rt_devices_simulated(c).
 * NULL with the [sim] key and the known names in err for an unknown scene or trace, or when out of memory. */
rt_simboard *rt_simboard_create(const rt_config *c, char *err, int errlen);
/* Frees the part (after rt_simboard_eval_join) and clears *sb; NULL and *sb == NULL are fine. */
void rt_simboard_destroy(rt_simboard **sb);

const sim_scene *rt_simboard_scene(const rt_simboard *sb);
const sim_trace *rt_simboard_trace(const rt_simboard *sb);
/* Scene time 0 on the board clock: the display's start (rt_app's t0_ns), set before any device thread runs. */
void rt_simboard_set_origin(rt_simboard *sb, int64_t t0_ns);
/* How far orientation q, the tracker's at board time t_ns, is from the true head's then, in degrees. */
double rt_simboard_orientation_error_deg(const rt_simboard *sb, int64_t t_ns, warp_quat q);
/* The scene's effects as text ("translation, objects"), in buf. */
const char *rt_simboard_scene_effects(const rt_simboard *sb, char *buf, int buflen);

/* The simulated host's counters, copied from d's frames backend once its thread has stopped (only when
 * d->sim_host: a mock link's host keeps none); zeros until then. */
void rt_simboard_collect_host(rt_simboard *sb, const rt_devices *d);
const uint64_t *rt_simboard_plane_renders(const rt_simboard *sb); /* [5]: colour, depth, ids, motion, layers */
uint64_t rt_simboard_host_frames(const rt_simboard *sb);

/* The accuracy evaluator (rt_eval.h): its ring, allocated at create, takes the compositor's records; start runs its
 * idle-priority thread on in (scene and trace are filled in here); join waits for it once in->stop is set. */
rt_eval *rt_simboard_eval(rt_simboard *sb);
bool rt_simboard_eval_start(rt_simboard *sb, const rt_eval_inputs *in);
void rt_simboard_eval_join(rt_simboard *sb);

#endif
