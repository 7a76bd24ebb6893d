/* SPDX-License-Identifier: MIT */
/* hmdwarp-warp's catalogue: every warp of the registry (warp/warp_registry.h) behind one signature; names, papers,
 * planes and knobs come from the registry, only the entry points are here. */
#ifndef TOOLS_CAT_WARPS_H
#define TOOLS_CAT_WARPS_H

#include <stdbool.h>

#include "warp/warp_camera.h"
#include "warp/warp_image.h"
#include "warp/warp_registry.h"
#include "warp/warp_view.h"

/* Planes a warp needs from the source view (the registry's bits). */
enum {
    CAT_NEEDS_DEPTH = WARP_NEEDS_DEPTH,
    CAT_NEEDS_IDS = WARP_NEEDS_IDS,
    CAT_NEEDS_MOTION = WARP_NEEDS_MOTION,
    CAT_NEEDS_LAYERS = WARP_NEEDS_LAYERS
};

/* What a run reports besides the image: primitives (grid cells, splats, triangles) or samples (ray steps, seeds x
 * iterations), and pixels the warp itself flagged. */
typedef struct {
    long primitives;     /* -1 when the warp has none */
    long samples;        /* -1 when not counted */
    long fringe, holes;  /* pixels flagged WARP_MASK_FRINGE / WARP_MASK_HOLE in the mask */
    char note[160];      /* anything else worth a column, e.g. "4 sheets" */
} cat_stats;

typedef struct {
    warp_method id;
    /* copies of the registry's, for the callers' convenience */
    const char *name;
    const char *cite;     /* paper and section, e.g. "003 §3.5" */
    const char *help;     /* one line: the summary and the parameters it takes, with ranges and defaults */
    unsigned needs;
    /* Warps src to the eye pose dst_pose seen through dst_cam at scene time dst_time (object motion) into dst (+ mask,
     * cleared by the caller). params:
     * "k=v,k=v" (NULL = defaults). Returns NULL, or a message naming what is wrong (bad parameter, missing plane). */
    const char *(*run)(const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose, double dst_time,
                       const char *params, warp_image_rgba8 *dst, warp_image_u8 *mask, cat_stats *st);
} cat_warp;

const cat_warp *cat_find(const char *name);
/* NULL-terminated, one entry per registry method in registry order. */
const cat_warp *const *cat_all(void);

/* Parameter helper: the value of key in "k=v,k=v" as a number (def when absent); *bad set when present but not a
 * number. */
double cat_param(const char *params, const char *key, double def, bool *bad);
/* The parameters checked against method m's registry knobs (names, numbers, ranges): NULL or a message. */
const char *cat_check_params(warp_method m, const char *params);

/* Object poses at the target time ([id - 1], world_from_object) for the per-object warp; NULL = unknown (the objects
 * stay where the source saw them). The tool and the table set it from the simulator. */
void cat_set_target_objects(const warp_pose *poses);

#endif
