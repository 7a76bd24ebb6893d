/* SPDX-License-Identifier: MIT */
/* warp_transparency: warping of transparent A-buffer fragments by ray casting (000 §4.2, §5.3): a min-max quadtree
 * over fragment depths, stackless traversal, extruded fragment boxes, front-to-back compositing over the opaque warp. */
#ifndef WARP_TRANSPARENCY_H
#define WARP_TRANSPARENCY_H

#include <stdbool.h>

#include "warp/warp_camera.h"
#include "warp/warp_grid.h"
#include "warp/warp_image.h"
#include "warp/warp_math.h"
#include "warp/warp_view.h"

/* Min-max quadtree (000 §4.2) as a pyramid: level 0 is per pixel, level k nodes cover 2^k x 2^k pixels; values are
 * the min and max inverse depth (1/z) of the transparent fragments below (+INF / -INF when there are none). */
#define WARP_MINMAX_MAX_LEVELS 17
typedef struct {
    int w, h, levels;
    int lw[WARP_MINMAX_MAX_LEVELS], lh[WARP_MINMAX_MAX_LEVELS];
    long off[WARP_MINMAX_MAX_LEVELS];
    float *mn, *mx;
    long fragments; /* fragments in the last build */
} warp_minmax_tree;

bool warp_minmax_alloc(warp_minmax_tree *t, int w, int h);
void warp_minmax_free(warp_minmax_tree *t);
/* Bottom-up reduction over the fragments of `layers` (same size as the tree). Fragments with z not finite or
 * not positive are skipped and counted: the return value is their number. */
long warp_minmax_build(warp_minmax_tree *t, const warp_image_layers *layers);

typedef struct {
    float opacity_threshold; /* stop gathering once the accumulated opacity reaches this (000 §5.3) */
    float thickness;         /* fragments are extruded to boxes of +-thickness relative inverse depth (§5.3) */
    int max_steps;           /* node visits per ray, a guard against pathological rays */
} warp_transparency_params;

/* opacity 0.99, thickness 0.02, 4096 steps */
warp_transparency_params warp_transparency_default_params(void);

typedef struct {
    long rays;          /* rays cast (target pixels whose ray met the tree's depth range inside the image) */
    long rays_hit;      /* rays that composited at least one fragment */
    long nodes;         /* quadtree nodes visited (all levels) */
    long leaves;        /* leaf (pixel) visits with fragment tests */
    long fragment_tests;
    long fragments;     /* fragments composited */
    long early_exits;   /* rays stopped by the opacity threshold */
} warp_transparency_stats;

typedef struct {
    const warp_view *src;
    const warp_minmax_tree *tree;
    warp_transparency_params p;
    warp_mat3 rot;      /* source_from_target rotation */
    warp_vec3 ka;       /* K_src * (target eye position in the source eye frame) */
    warp_mat3 k;        /* K_src */
    warp_camera dst_cam;
} warp_transparency_setup;

/* Prepares the ray casting of src->layers (through `tree`, built from them) to the eye pose dst_pose seen through
 * dst_cam. Returns NULL or what is wrong. */
const char *warp_transparency_prepare(warp_transparency_setup *s, const warp_view *src, const warp_minmax_tree *tree,
                                      const warp_camera *dst_cam, warp_pose dst_pose, const warp_transparency_params *p);

/* Rows [y0, y1): every target pixel's ray gathers the fragments in front of the warped opaque surface (opaque_inv:
 * target 1/z of the opaque warp, <= 0 for none/sky) and composites them front to back over dst, which holds the
 * warped opaque colour on entry. */
void warp_transparency_rows(const warp_transparency_setup *s, const warp_image_f32 *opaque_inv, warp_image_rgba8 *dst,
                            int y0, int y1, warp_transparency_stats *st);

/* Entry point for tools, the hybrid warp of 000 §5: src->color is the opaque G-buffer colour, src->inv_depth its
 * depth, src->layers the A-buffer. Warps the opaque pixels with the adaptive grid (g allocated for the source size),
 * then ray casts the fragments. dst_inv receives the opaque z-buffer. */
const char *warp_transparency_run(warp_grid *g, warp_minmax_tree *t, const warp_view *src, const warp_camera *dst_cam,
                                  warp_pose dst_pose, const warp_grid_params *gp, const warp_transparency_params *p,
                                  warp_image_rgba8 *dst, warp_image_f32 *dst_inv, warp_image_u8 *mask,
                                  warp_grid_stats *gst, warp_transparency_stats *st);

/* Baselines of 000 Fig. 7 and helpers. */
/* Inverse depth with the nearest transparent fragment written over the opaque depth (Fig. 7d). */
void warp_transparency_front_depth(const warp_image_f32 *opaque_inv, const warp_image_layers *layers,
                                   warp_image_f32 *out);
/* Recovers the opaque colour from a colour plane with the fragments already blended over it (what a host that
 * sends only the final image provides): inverts "over" front to back. Pixels behind near-opaque fragments cannot be
 * recovered (their colour is kept); returns how many there were. */
long warp_transparency_unblend(const warp_image_rgba8 *blended, const warp_image_layers *layers,
                               warp_image_rgba8 *opaque);

#endif
