/* SPDX-License-Identifier: MIT */
/* warp_raytrace: the height-map raytrace warp of 003 §3.5: every target pixel casts a ray through the source
 * frame's depth treated as a continuous height map; edge fills of 003 §4.4 and a sub-pixel refinement of the hit. */
#ifndef WARP_RAYTRACE_H
#define WARP_RAYTRACE_H

#include "warp/warp_camera.h"
#include "warp/warp_image.h"
#include "warp/warp_view.h"

typedef enum {
    WARP_EDGE_FILL_FAR = 0,    /* fill a disocclusion gap with the farther side of the edge (003 §4.4, first) */
    WARP_EDGE_FILL_LINEAR = 1, /* interpolate linearly between the near and the far side (003 §4.4, second) */
} warp_edge_fill;

typedef struct {
    int max_steps;      /* step budget per ray; the search takes one step per source pixel (003 eq. 10) up to it */
    int refine_iters;   /* regula-falsi iterations after the bracketing step: makes the hit sub-pixel accurate;
                         * 0 = the plain linear search of 003 eq. 10 (hit at the first sample behind) */
    warp_edge_fill edge_fill;
    float edge_jump;    /* relative inverse-depth jump between the texels of a cell that counts as an occlusion
                         * edge: the height map has a vertical wall there and the edge fills decide */
} warp_raytrace_params;

/* max_steps 512, refine_iters 4, far-side fill, edge_jump 0.1. */
warp_raytrace_params warp_raytrace_default_params(void);

typedef struct {
    long rays;          /* target pixels traced */
    long steps;         /* depth samples taken in the linear searches (n_d of 003 eq. 11, summed) */
    long edge_pixels;   /* pixels filled across a depth edge */
    long fringe_pixels; /* pixels whose ray left the source image */
    long samples;       /* depth samples actually taken by the searches (fewer than steps with a block-max grid) */
} warp_raytrace_stats;

/* Everything that is constant over one warp of one eye. */
typedef struct {
    const warp_view *src;
    warp_raytrace_params p;
    warp_mat3 h;        /* target pixel -> source homogeneous position of the ray's point at infinity */
    double ax, ay, aw;  /* source homogeneous position of the target eye (K_src * origin) */
    int dst_w, dst_h;
    const warp_image_f32 *blockmax; /* optional (warp_raytrace_use_blockmax): skip steps that cannot hit */
    int block;
} warp_raytrace_setup;

/* Prepares a warp of src (which must carry inverse depth) to the eye pose dst_pose (world_from_eye) seen through
 * dst_cam. Returns NULL when usable, else a static string naming what is missing. */
const char *warp_raytrace_prepare(warp_raytrace_setup *s, const warp_view *src, const warp_camera *dst_cam,
                                  warp_pose dst_pose, const warp_raytrace_params *p);

/* The largest inverse depth of every block x block texels of inv, into bmax ((w + block - 1) / block wide, as
 * many rows). Once per host frame: with it, the search skips runs of steps whose region holds nothing as near
 * as the ray (the spirit of 000 §5.3's min-max trees); the result is bit-identical to the plain search. */
void warp_raytrace_blockmax(const warp_image_f32 *inv, warp_image_f32 *bmax, int block);
/* Lets s use bmax (built from s's source inverse depth with the same block); NULL = the plain linear search. */
void warp_raytrace_use_blockmax(warp_raytrace_setup *s, const warp_image_f32 *bmax, int block);

/* Writes rows [y0, y1) of dst; fills mask with WARP_MASK_FRINGE / WARP_MASK_EDGE (may be NULL); adds to *st
 * (may be NULL). Rows are independent, so threads may split them. */
void warp_raytrace_rows(const warp_raytrace_setup *s, warp_image_rgba8 *dst, warp_image_u8 *mask, int y0, int y1,
                        warp_raytrace_stats *st);

/* Traces one ray, through the continuous target position (tx, ty) (pixel (x, y) of warp_raytrace_rows is the ray
 * through (x + 0.5, y + 0.5)), with the same search, refinement, edge fill and fringe rules. Writes the source
 * position whose bilinear sample is the ray's colour: the hit; at a depth edge the centre of the texel the ray
 * sees (the near side's or the far side's); the far texel's centre for an edge under the far-side fill; for a ray that leaves the source, the position the fringe fill samples (possibly outside the
 * image: samplers clamp it to the border). Returns 0, WARP_MASK_EDGE or WARP_MASK_FRINGE (what rows writes into
 * the mask); adds to *st (may be NULL). For meshes that trace only at their vertices (warp_mesh_update_raytrace). */
int warp_raytrace_point(const warp_raytrace_setup *s, double tx, double ty, double *sx, double *sy,
                        warp_raytrace_stats *st);

/* warp_raytrace_point, and the inverse depth of the ray's hit into *d (may be NULL): where its search stopped, before
 * the edge rules move the position to a texel (at an edge: where the ray met the wall; for a ray that leaves the
 * source: the depth its fringe fill samples at, 0 beyond 90 degrees). */
int warp_raytrace_point_depth(const warp_raytrace_setup *s, double tx, double ty, double *sx, double *sy, double *d,
                              warp_raytrace_stats *st);

enum {
    WARP_GUESS_BEHIND = -1, /* the ray is behind the height map already at the first guess's near end */
    WARP_GUESS_MISSED = -2, /* it meets nothing at any guess (or cannot be searched there) */
};

/* warp_raytrace_point_depth's ray through (tx, ty) without its linear search over the whole depth range: its hit
 * sought only at the inverse depths cand[0..n_cand) (nearest first) at which the caller expects it to meet a surface
 * (where its neighbours' rays met theirs, interpolated to this ray; 000 §3-4's reasoning on a grid's vertices), each
 * within margin_px source pixels of parallax. First each guess at its word, one surface read: where the height map
 * is smooth there, one Newton step on it gives the hit if the ray meets it within half a pixel (and to 1/32 pixel);
 * a guess it passes clearly in front of is skipped. Otherwise the full search's own steps in each guess's margin,
 * and a crossing between two guesses (in front of the nearer surface, behind the farther one's near end: at a
 * disocclusion the near side's wall) halved down to one step; then the full search's refinement and edge rules
 * (003 §3.5, §4.4), so that such a hit lands bit for bit where warp_raytrace_point_depth puts it when it is the
 * ray's first. That it is (nothing nearer than the first guess, no thin object between two) is the caller's to know.
 * Returns the flag (0 or WARP_MASK_EDGE) and writes the source position as warp_raytrace_point does and the hit's
 * inverse depth into *d (may be NULL); or WARP_GUESS_BEHIND or WARP_GUESS_MISSED, writing nothing (MISSED also for
 * a ray of no parallax, beyond 90 degrees, or whose guess reaches the search's near end, where the full search's
 * own rules hold). Adds the depth samples taken (surface reads and steps, not the refinement's) to *samples (may be
 * NULL). */
int warp_raytrace_point_guess(const warp_raytrace_setup *s, double tx, double ty, const double *cand, int n_cand,
                              double margin_px, double *sx, double *sy, double *d, int *samples);

#endif
