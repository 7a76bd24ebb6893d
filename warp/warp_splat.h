/* SPDX-License-Identifier: MIT */
/* warp_splat: reconstruction of forward-warped samples (002 §3.3): square point splats sized from the warp's
 * Jacobian, quadrilateral splats (the Jacobian image of the pixel) and a mesh of the source pixels that is not
 * connected across depth discontinuities or object borders. Runs on the samples warp_forward maps. */
#ifndef WARP_SPLAT_H
#define WARP_SPLAT_H

#include "warp/warp_forward.h"

typedef enum {
    WARP_SPLAT_POINT = 0, /* S x S square, S = ceil(max(|J11| + |J12|, |J21| + |J22|)) clamped (002 §3.3); where
                           * splats of one surface overlap the nearest sample wins, and the rounded-up part beyond
                           * the true footprint only fills what no footprint covers */
    WARP_SPLAT_QUAD = 1,  /* the parallelogram J * [-1/2, 1/2]^2 around the warped centre */
    WARP_SPLAT_MESH = 2,  /* two triangles per 2x2 block of source pixels, colour and depth interpolated; samples
                           * at a cut also draw their pixel's footprint over what lies behind them */
} warp_splat_kind;

typedef struct {
    warp_splat_kind kind;
    warp_fwd_visibility vis; /* z-buffer, or the painter's algorithm in the 4- or 8-sheet order */
    int min_size, max_size;  /* point splat side limits in pixels (min_size > 1 forces wide splats) */
    float max_extent;        /* quads: largest side of the splat's box; mesh: of a triangle's box (pixels) */
    float edge_jump;         /* relative inverse-depth jump between neighbours that is a depth edge: the mesh
                              * breaks there and the Jacobian uses one-sided slopes */
} warp_splat_params;

/* kind as given, z-buffer, sizes 1..4, extent 8, edge_jump 0.1. */
warp_splat_params warp_splat_default_params(warp_splat_kind kind);
/* NULL when p is usable (a known kind, 1 <= min_size <= max_size, max_extent >= 1), else what is wrong. */
const char *warp_splat_check_params(const warp_splat_params *p);

typedef struct {
    warp_forward_stats fwd;  /* samples, holes, depth rejects, ... (writes = fragments written) */
    long primitives;         /* splats or triangles drawn; the mesh adds samples cut off from every triangle,
                              * drawn as points where nothing else landed */
    long fragments;          /* pixel coverage tests passed (before the depth test) */
    long culled;             /* triangles not drawn: across a depth edge or object border, degenerate, too big;
                              * quads collapsed to a point */
} warp_splat_stats;

/* Draws the samples in sc (mapped by warp_forward_map_rows with the Jacobian for points and quads) in the order of
 * sc->order into dst, after warp_forward_clear. The per-object warp uses this with its own setup. */
void warp_splat_draw(const warp_fwd_setup *s, warp_fwd_scratch *sc, const warp_splat_params *p,
                     warp_image_rgba8 *dst, warp_splat_stats *st);

/* The entry point: forward-warp src to dst_pose seen through dst_cam and reconstruct with p; holes (pixels no
 * splat or triangle covered) are flagged WARP_MASK_HOLE as in warp_forward_run. st may be NULL. */
const char *warp_splat_run(const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose,
                           const warp_splat_params *p, warp_fwd_scratch *sc, warp_image_rgba8 *dst,
                           warp_image_u8 *mask, warp_splat_stats *st);

#endif
