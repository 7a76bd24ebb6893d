/* SPDX-License-Identifier: MIT */
/* sim_internal: the object model shared by the scene definitions (sim_scene.c) and the ray caster (sim_render.c).
 * Not a public interface: only sim/ includes it. */
#ifndef SIM_INTERNAL_H
#define SIM_INTERNAL_H

#include <stdint.h>

#include "sim/sim_scene.h"
#include "warp/warp_math.h"

/* Primitive shapes, all in their object frame (the pose maps object -> world). */
typedef enum {
    SIM_PRIM_ROOM,     /* inside of the box |x|<=sx, |y|<=sy, |z|<=sz: the viewer stands in it, sees the far walls */
    SIM_PRIM_BOX,      /* solid box |x|<=sx, |y|<=sy, |z|<=sz */
    SIM_PRIM_SPHERE,   /* radius sx about the origin */
    SIM_PRIM_CYLINDER, /* radius sx about the Y axis, |y|<=sy, capped */
    SIM_PRIM_RECT,     /* z = 0, |x|<=sx, |y|<=sy, two-sided; sx = INFINITY makes an unbounded plane */
} sim_prim_type;

/* Texture recipes (view-independent, band-limited: see sim_render.c). */
typedef enum {
    SIM_TEX_ROOM,   /* per-wall colours, tiles, stripes and gradients */
    SIM_TEX_SOLID,  /* 3D checkers and stripes in object space: spheres and boxes */
    SIM_TEX_GROUND, /* large-scale outdoor ground */
    SIM_TEX_PLAIN,  /* base colour and a soft stripe along the axis: hairball strands */
    SIM_TEX_PANE,   /* tinted glass with a smooth gradient */
} sim_tex_type;

typedef struct {
    uint8_t prim, tex;
    float alpha;        /* 1 = opaque; < 1: semi-transparent pane (A-buffer fragment, 000 §4.2) */
    float size[3];      /* see sim_prim_type */
    float rgb[3];       /* base albedo (or pane tint) */
    double pos[3];      /* position at t = 0, metres */
    double ypr_deg[3];  /* orientation at t = 0 (warp_quat_from_ypr) */
    double vel[3];      /* constant velocity, m/s */
    double amp[3];      /* periodic displacement amp * sin(2 pi freq t + phase), metres */
    double freq_hz, phase;
    double spin_dps[3]; /* constant world angular velocity, deg/s: q(t) = exp(spin t) q0 */
} sim_object;

/* Number of objects and object `k` (0-based; its id is k + 1). */
int sim_scene_nobjects(const sim_scene *s);
void sim_scene_object(const sim_scene *s, int k, sim_object *out);
bool sim_scene_has_sky(const sim_scene *s);

/* Pose and its time derivative: world linear velocity of the object origin and world angular velocity. */
warp_pose sim_object_pose(const sim_object *o, double t);
void sim_object_velocity(const sim_object *o, double t, warp_vec3 *lin, warp_vec3 *ang);
bool sim_object_moves(const sim_object *o);

#endif
