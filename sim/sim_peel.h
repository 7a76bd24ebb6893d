/* SPDX-License-Identifier: MIT */
/* sim_peel: a hidden depth layer for the multi-layer warps (001 §3.4): an indoor scene's static room rendered
 * without the objects in front of it, the background layer 001 §4.1 peels "without foreground objects". */
#ifndef SIM_PEEL_H
#define SIM_PEEL_H

#include <stdbool.h>

#include "sim/sim_scene.h"

/* The scene holding only s's background: "room" when s is built on the room (its first objects are the room's,
 * with the same ids), else NULL. "room" itself has no background layer of its own (NULL). */
const sim_scene *sim_peel_background(const sim_scene *s);

/* Renders rows [y0, y1) of s's background layer into b (planes as sim_render_rows). Colour and depth match s's
 * render wherever s shows the room; where a foreground object hides it, they show what lies behind. Returns false
 * (rendering nothing) when s has no background layer. Pass the layer's depth through warp_iter_peel_mask to keep
 * only what the front layer hides (a depth-peeled layer with empty texels elsewhere). */
bool sim_peel_render_rows(const sim_scene *s, double t, warp_pose eye, const warp_camera *cam, unsigned planes,
                          sim_buffers *b, int y0, int y1);

#endif
