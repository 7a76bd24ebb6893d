/* SPDX-License-Identifier: MIT */
/* hmdwarp-warp's catalogue: every warp the tool (and the results table) can run, behind one signature, with its
 * knobs as name=value parameters and the planes it needs. */
#ifndef TOOLS_CAT_WARPS_H
#define TOOLS_CAT_WARPS_H

#include <stdbool.h>

#include "warp/warp_camera.h"
#include "warp/warp_image.h"
#include "warp/warp_view.h"

/* Planes a warp needs from the source view. */
enum { CAT_NEEDS_DEPTH = 1, CAT_NEEDS_IDS = 2, CAT_NEEDS_MOTION = 4, CAT_NEEDS_LAYERS = 8 };

/* What a run reports besides the image: primitives (grid cells, splats, triangles) or samples (ray steps, seeds x
 * iterations), and pixels the warp itself flagged. */
typedef struct {
    long primitives;     /* -1 when the warp has none */
    long samples;        /* -1 when not counted */
    long fringe, holes;  /* pixels flagged WARP_MASK_FRINGE / WARP_MASK_HOLE in the mask */
    char note[160];      /* anything else worth a column, e.g. "4 sheets" */
} cat_stats;

typedef struct {
    const char *name;
    const char *cite;     /* paper and section, e.g. "003 §3.5" */
    const char *help;     /* one line, with the parameters it takes */
    unsigned needs;
    /* Warps src to the eye pose dst_pose seen through dst_cam at scene time dst_time (object motion) into dst (+ mask,
     * cleared by the caller). params:
     * "k=v,k=v" (NULL = defaults). Returns NULL, or a message naming what is wrong (bad parameter, missing plane). */
    const char *(*run)(const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose, double dst_time,
                       const char *params, warp_image_rgba8 *dst, warp_image_u8 *mask, cat_stats *st);
} cat_warp;

const cat_warp *cat_find(const char *name);
/* NULL-terminated. */
const cat_warp *const *cat_all(void);

/* Parameter helper: the value of key in "k=v,k=v" as a number (def when absent); *bad set when present but not a
 * number. Keys not in `known` (space-separated) make cat_check_params return a message. */
double cat_param(const char *params, const char *key, double def, bool *bad);
const char *cat_check_params(const char *params, const char *known);

/* Object poses at the target time ([id - 1], world_from_object) for the per-object warp; NULL = unknown (the objects
 * stay where the source saw them). The tool and the table set it from the simulator. */
void cat_set_target_objects(const warp_pose *poses);

#endif
