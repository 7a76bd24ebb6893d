/* SPDX-License-Identifier: MIT */
/* sim_scene: deterministic analytic scenes and their ground-truth renderer (colour, depth, object ids, motion
 * vectors, A-buffer layers), computing only the planes a scene's effects call for. */
#ifndef SIM_SCENE_H
#define SIM_SCENE_H

#include <stdbool.h>

#include "warp/warp_camera.h"
#include "warp/warp_image.h"
#include "warp/warp_math.h"

/* What a scene exercises. A warp or a host feed needs only the planes these imply (sim_planes_for_effects). */
enum {
    SIM_FX_HEAD_ROTATION = 1u << 0,
    SIM_FX_HEAD_TRANSLATION = 1u << 1,
    SIM_FX_OBJECT_MOTION = 1u << 2,
    SIM_FX_TRANSPARENCY = 1u << 3,
    SIM_FX_DISOCCLUSION = 1u << 4,
    SIM_FX_LENS = 1u << 5,
};

/* Image planes of a rendered view. */
enum {
    SIM_PLANE_COLOR = 1u << 0,
    SIM_PLANE_DEPTH = 1u << 1,  /* linear planar z (WARP_DEPTH_LINEAR), +INFINITY for sky */
    SIM_PLANE_IDS = 1u << 2,    /* u16 object id, 0 = sky / no object */
    SIM_PLANE_MOTION = 1u << 3, /* pixels per second of screen motion caused by object motion, camera held still */
    SIM_PLANE_LAYERS = 1u << 4, /* transparent fragments, nearest first */
};

/* rotation -> colour; translation or disocclusion -> + depth; object motion -> + depth, ids, motion;
 * transparency -> + depth, layers; lens -> nothing extra (the lens is applied on the display side). */
unsigned sim_planes_for_effects(unsigned effects);
/* "color,depth,ids" style list for logs; returns buf. */
const char *sim_planes_str(unsigned planes, char *buf, int buflen);
/* "rotation,translation" style list; returns buf. */
const char *sim_effects_str(unsigned effects, char *buf, int buflen);

typedef struct sim_scene sim_scene; /* opaque; scenes are static and immutable */

const sim_scene *sim_scene_find(const char *name);  /* NULL when unknown */
const char *const *sim_scene_names(void);           /* NULL-terminated list of all scene names */
const char *sim_scene_name(const sim_scene *s);
const char *sim_scene_description(const sim_scene *s);
unsigned sim_scene_effects(const sim_scene *s);
/* Objects are numbered 1..count (0 is the sky). Pose of object `id` at scene time t (world_from_object). */
int sim_scene_object_count(const sim_scene *s);
warp_pose sim_scene_object_pose(const sim_scene *s, int id, double t);
/* Smallest distance from the default eye position to any surface, metres (the d_min of 004 §3). */
double sim_scene_min_depth(const sim_scene *s);

typedef struct {
    warp_image_rgba8 color;   /* transparent fragments already blended over the opaque surface */
    warp_image_f32 depth;     /* nearest opaque surface */
    warp_image_u16 ids;
    warp_image_vec2f motion;
    warp_image_layers layers;
    unsigned planes;          /* the planes allocated */
} sim_buffers;

bool sim_buffers_alloc(sim_buffers *b, int w, int h, unsigned planes, int max_layers);
void sim_buffers_free(sim_buffers *b);

/* Renders rows [y0, y1) of the view of `s` at scene time t from eye pose (world_from_eye) through `cam` into
 * the planes `planes` (a subset of b->planes; others are left untouched). Deterministic: the same inputs give the
 * same bytes whatever the row split, so threads may render disjoint row ranges in parallel. */
void sim_render_rows(const sim_scene *s, double t, warp_pose eye, const warp_camera *cam, unsigned planes,
                     sim_buffers *b, int y0, int y1);
static inline void sim_render(const sim_scene *s, double t, warp_pose eye, const warp_camera *cam, unsigned planes,
                              sim_buffers *b)
{
    sim_render_rows(s, t, eye, cam, planes, b, 0, cam->height);
}

#endif
