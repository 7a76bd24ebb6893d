/* SPDX-License-Identifier: MIT */
/* warp_holes: filling the holes (WARP_MASK_HOLE) a forward or iterative warp leaves: the bidirectional epipolar
 * far-pixel search (002 §3.3), the depth-aware low-pass pyramid (000 §5.2), and stretch / rubber-sheet baselines. */
#ifndef WARP_HOLES_H
#define WARP_HOLES_H

#include <stdbool.h>
#include <stdint.h>

#include "warp/warp_camera.h"
#include "warp/warp_image.h"
#include "warp/warp_math.h"

/* The epipole of the target image: where the source camera centre projects (004 §3, the output-image epipole).
 * Under head translation every pixel moves along the line through it, nearer pixels more than farther ones, so a
 * disocclusion hole opens on the line with the occluder on one side and the uncovered background on the other.
 *  - finite (at_infinity false): (x, y) in target pixels (may lie far outside the image); `expansion` true when
 *    near pixels move away from it (a focus of expansion: the target eye moved towards the scene), false when they
 *    move towards it (a focus of contraction: the eye moved back);
 *  - at_infinity (translation parallel to the image plane): the lines are parallel and (x, y) is the direction in
 *    which near pixels move; `expansion` is ignored. (0, 0) means no translation: the searches then run along rows. */
typedef struct {
    double x, y;
    bool at_infinity;
    bool expansion;
} warp_epipole;

/* The epipole of a target eye at dst_pose (world_from_eye, camera dst_cam) for a source rendered at src_pose. */
warp_epipole warp_epipole_from_poses(const warp_camera *dst_cam, warp_pose dst_pose, warp_pose src_pose);
/* Unit direction (*dx, *dy) in which near pixels move relative to far ones at target position (x, y) (pixel centres
 * at +0.5); the uncovered background of a hole lies the other way. Returns false where it is undefined (no
 * translation, or (x, y) on a finite epipole); (*dx, *dy) is then (1, 0). */
bool warp_epipole_direction(const warp_epipole *e, double x, double y, double *dx, double *dy);

typedef enum {
    /* 002 §3.3: scan the epipolar line both ways from the hole to the nearest valid pixel on each side and copy the
     * farther (background) one; the same surface on both sides (depths within depth_tolerance) -> the nearer one. */
    WARP_HOLES_EPIPOLAR_FAR = 0,
    /* 000 §5.2: a depth-aware low-pass pyramid (pull: each level averages the valid pixels of a kernel that are not
     * nearer than the kernel's mean depth, so foreground dissolves; push: a hole reads the level its distance to the
     * background border calls for, that border searched along the epipolar line with doubling steps). */
    WARP_HOLES_LOWPASS = 1,
    /* Baselines. Stretch: copy the nearest valid pixel along the epipolar line, whichever side (nearest-neighbour
     * stretch, 000 §2.2), or always the background side given by the epipole's type (Mark's one-sided scan, cited
     * in 002 §3.3). Rubber sheet: interpolate linearly between the bounding valid pixels along the row and along the
     * column, the shorter span weighted more (the "rubber sheets" of 000 §2.2, joining foreground to background). */
    WARP_HOLES_STRETCH_NEAREST = 2,
    WARP_HOLES_STRETCH_BACKGROUND = 3,
    WARP_HOLES_RUBBER_SHEET = 4,
} warp_holes_method;

typedef struct {
    warp_holes_method method;
    int max_search;        /* pixels scanned along a line each way before giving up on that side (then fallback) */
    float depth_tolerance; /* relative inverse-depth difference below which two pixels count as one surface */
    int max_levels;        /* low-pass: pyramid levels including the full-resolution one (<= the ctx's) */
    int kernel;            /* low-pass pull kernel: 2 = 2x2 box, 4 = 4x4 binomial [1 3 3 1]^2 */
    int level_bias;        /* low-pass: added to the level the border distance calls for (more = blurrier; the
                            * level is at least 1) */
    bool depth_aware;      /* low-pass: the depth tests of 000 §5.2 (false = a plain push-pull, for comparison) */
    warp_rgba8 empty;      /* written where no valid pixel exists at all (an image that is all hole) */
} warp_holes_params;

/* Epipolar far search, max_search 1024, depth_tolerance 0.05, 9 levels, 4x4 kernel, bias -1, depth aware, black. */
warp_holes_params warp_holes_default_params(void);

typedef struct {
    long holes;          /* hole pixels met in the rows filled */
    long filled;         /* of those, pixels written (every hole is: == holes) */
    long search_steps;   /* pixels probed by the line searches */
    long fallbacks;      /* holes whose epipolar search found nothing either way (filled from rows/columns) */
    long bad_depth;      /* valid pixels with NaN/Inf/negative inverse depth, taken as sky (counted in prepare) */
    int levels;          /* pyramid levels built (low-pass; 1 otherwise) */
} warp_holes_stats;

/* One pyramid cell: colour (0..255, straight alpha), coverage weight, inverse depth. */
typedef struct { float c[4]; float wt, inv; } warp_holes_cell;

/* Scratch for one image size, allocated once (warp_holes_alloc), reused every frame. */
typedef struct {
    int w, h, max_levels;
    int levels;                  /* built by the last prepare */
    int lw[16], lh[16];          /* level sizes */
    warp_holes_cell *lvl[16];    /* level 0 = the warped image itself; [1..] only for the low-pass method */
    warp_rgba8 *c0;              /* valid colours of level 0, copied exactly (w * h) */
    /* Nearest valid pixel at or before / after each pixel on its row (x) and column (y), -1 = none (w * h each);
     * and per row the nearest row holding any valid pixel: O(1) rubber sheets and fallbacks. */
    int16_t *row_prev, *row_next, *col_prev, *col_next, *near_row;
    warp_holes_params p;         /* of the last prepare */
    double ex, ey, ew;           /* homogeneous epipole (see warp_epipole_direction) */
} warp_holes_ctx;

/* Allocates scratch for w x h images (at most 32767 each way) with up to max_levels pyramid levels (1..16).
 * False on bad size / no memory (the ctx is then zeroed; warp_holes_free is safe on it). */
bool warp_holes_alloc(warp_holes_ctx *c, int w, int h, int max_levels);
void warp_holes_free(warp_holes_ctx *c);

/* Takes a snapshot of the valid pixels (mask without WARP_MASK_HOLE) of dst, their warped inverse depth
 * (1/z, 0 = sky; only read at valid pixels; may be NULL for the methods that do not need depth: stretch and rubber
 * sheet), and builds the pyramid for the low-pass method. Whole image, not row-split. Returns NULL when usable,
 * else a static string naming what is wrong (sizes, missing depth, bad params); nothing is then written.
 * Adds bad_depth and levels to *st (may be NULL). */
const char *warp_holes_prepare(warp_holes_ctx *c, const warp_image_rgba8 *dst, const warp_image_u8 *mask,
                               const warp_image_f32 *inv_depth, const warp_epipole *e, const warp_holes_params *p,
                               warp_holes_stats *st);
/* Fills the hole pixels of rows [y0, y1) of dst and sets WARP_MASK_FILLED on them (HOLE stays set); valid pixels
 * are not touched. Reads only the snapshot, so threads may split the rows; does nothing before a successful
 * prepare. Adds to *st (may be NULL). */
void warp_holes_fill_rows(const warp_holes_ctx *c, warp_image_rgba8 *dst, warp_image_u8 *mask, int y0, int y1,
                          warp_holes_stats *st);
/* prepare + all rows: the one-call entry point. *st (may be NULL) is zeroed first. */
const char *warp_holes_fill(warp_holes_ctx *c, warp_image_rgba8 *dst, warp_image_u8 *mask,
                            const warp_image_f32 *inv_depth, const warp_epipole *e, const warp_holes_params *p,
                            warp_holes_stats *st);

const char *warp_holes_method_name(warp_holes_method m);

#endif
