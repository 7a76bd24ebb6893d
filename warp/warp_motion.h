/* SPDX-License-Identifier: MIT */
/* warp_motion: the motion buffer of 001 §3.1 (where each source pixel lands in the target view, from its depth, the
 * camera motion and per-object motion) and the min-max motion mipmap of 001 §3.3 that bounds the iterative search. */
#ifndef WARP_MOTION_H
#define WARP_MOTION_H

#include <stdbool.h>

#include "warp/warp_camera.h"
#include "warp/warp_image.h"
#include "warp/warp_math.h"
#include "warp/warp_view.h"

/* One source pixel of one depth layer: its screen motion v = q^ - q into the target view in target pixels (source
 * and target cameras may differ; v is measured in the common pixel grid), and its inverse depth in the target view.
 * d < 0 marks an empty texel: the layer has no surface there (depth peeling), or the point is behind the target. */
typedef struct { float x, y, d; } warp_motion_texel;

typedef struct {
    int w, h;               /* source image size; rows are w texels apart */
    warp_motion_texel *px;
} warp_motion_buffer;

bool warp_motion_alloc(warp_motion_buffer *m, int w, int h);
void warp_motion_free(warp_motion_buffer *m);

/* Where the source's pixels go: the relative camera motion and, for pixels with an object id, the object's motion
 * between the source time and the target time (001 §3.1: "combining camera and object motion"). */
typedef struct {
    warp_camera src_cam, dst_cam;
    warp_pose src_pose, dst_pose;     /* world_from_eye */
    double dt;                        /* target time - source time, seconds */
    /* Object motion, first match wins: exact per-object poses at the target time (world_from_object, [id - 1],
     * 002 §3.2 per-object matrices; needs the view's object_pose too), else the view's screen-motion plane
     * extrapolated over dt at constant inverse depth (first order), else none (the scene is taken as static). */
    int n_objects;
    const warp_pose *src_object_pose; /* [id - 1] at the source time */
    const warp_pose *dst_object_pose; /* [id - 1] at the target time */
} warp_motion_setup;

/* Fills rows [y0, y1) of m from one depth layer: inv_depth (1/z, 0 = sky, < 0 = empty), optional ids and motion
 * (screen motion from object motion, pixels per second). Rows are independent (threads may split them). */
void warp_motion_compute_rows(warp_motion_buffer *m, const warp_motion_setup *s, const warp_image_f32 *inv_depth,
                              const warp_image_u16 *ids, const warp_image_vec2f *motion, int y0, int y1);

/* Principal axes of the motion vectors (001 §3.3, oriented bounds): samples about `samples` valid texels on a
 * regular grid and returns the rotation angle theta of the first principal axis; rotate v by -theta
 * (warp_motion_rotate) to express it in principal coordinates. 0 when fewer than two texels are valid. */
double warp_motion_pca(const warp_motion_buffer *m, int samples);

/* Coordinates (a, b) of v along the axes at angle theta: a = c x + s y, b = -s x + c y. */
static inline void warp_motion_rotate(double c, double s, double x, double y, double *a, double *b)
{
    *a = c * x + s * y;
    *b = -s * x + c * y;
}

/* A motion bound in (possibly rotated) motion coordinates: lo <= (a, b) <= hi. Empty when lo > hi. */
typedef struct { float lo[2], hi[2]; } warp_motion_box;

static inline bool warp_motion_box_valid(const warp_motion_box *b) { return b->lo[0] <= b->hi[0] && b->lo[1] <= b->hi[1]; }

/* Min-max mipmap of the motion (001 §3.3, after [Williams 1983]): level 0 holds each texel's motion (rotated by
 * the PCA angle), level i the bound over 2^i x 2^i texels; the last level (1 x 1) is the global bound. */
#define WARP_MOTION_MAX_LEVELS 16
typedef struct {
    int levels;
    int w[WARP_MOTION_MAX_LEVELS], h[WARP_MOTION_MAX_LEVELS];
    warp_motion_box *lvl[WARP_MOTION_MAX_LEVELS];
    double theta, c, s;  /* the rotation the bounds are expressed in (0 for axis-aligned bounds) */
    void *mem;
} warp_motion_mip;

bool warp_motion_mip_alloc(warp_motion_mip *mip, int w, int h);
void warp_motion_mip_free(warp_motion_mip *mip);
/* Builds every level from m (same size as the mip), with the bounds taken along the axes at angle theta.
 * Texels empty in m take the first non-empty texel of fallback[0..n_fallback): the layers above a deeper layer,
 * nearest first, which is what the cross-layer seeding of 001 Fig. 6 reads there, so the bound covers exactly
 * the motions the search can see. */
void warp_motion_mip_build(warp_motion_mip *mip, const warp_motion_buffer *m, const warp_motion_buffer *const *fallback,
                           int n_fallback, double theta);

static inline warp_motion_box warp_motion_mip_global(const warp_motion_mip *mip) { return mip->lvl[mip->levels - 1][0]; }

/* Bound of the motions a bilinear lookup anywhere in the image-space rectangle [x0, x1] x [y0, y1] can return:
 * the four corner texels at the level where the rectangle's texel footprint spans at most two texels per axis
 * (001 Fig. 5, local_motion_bound). The rectangle is clamped to the image; empty result when nothing valid. */
warp_motion_box warp_motion_mip_query(const warp_motion_mip *mip, double x0, double y0, double x1, double y1);

#endif
