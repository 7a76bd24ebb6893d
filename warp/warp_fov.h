/* SPDX-License-Identifier: MIT */
/* warp_fov: the field each eye sees through its lens: the panel's visible region (the hidden-area mask), the eye
 * camera's tangents that cover it in every colour channel plus a guard band, and the share sampling outside the source. */
#ifndef WARP_FOV_H
#define WARP_FOV_H

#include <stdbool.h>
#include <stdint.h>

#include "warp/warp_lens.h"
#include "warp/warp_mesh.h"

/* The visible region of one eye's viewport (vp_w x vp_h pixels, as warp_lens_distort takes them): the pixels whose
 * centre lies within the visible radius of the lens centre (lens->center_x/y, in lens->scale units). A round lens
 * shows a disc of the panel; beyond its rim the panel is seen through the lens barrel or not at all, and the
 * distortion's extrapolation there reaches tangents of 3 and more, which no eye buffer should pay for (docs/lens.md,
 * "Visible region"). Only warp_lens_* calls and the centre and scale are used, so every lens model works. */

/* Largest mask line loop a board announces per eye (docs/framelink.md, Visibility mask message). */
#define WARP_FOV_MASK_MAX 64
/* Vertices of the line loop hmdwarpd announces (a 408-byte message): 1/cos(pi/24) = 1.0086 outward covers the chords. */
#define WARP_FOV_MASK_VERTICES 24

/* The visible radius in the lens's normalised units: radius_cfg when finite and > 0, else (NAN: auto) the distance
 * from the lens centre to the nearest viewport edge (the largest disc the eye's half of the panel holds); never
 * beyond 0.999 of the smallest monotonic radius of the three channels (past the fold the lens shows nothing an
 * inverse could place), and with auto never past where the lens's own view ends (warp_lens_in_view: a Vive-class
 * lens's cutoff). 0 when the lens centre lies outside the viewport or the lens is unusable. */
double warp_fov_visible_radius(const warp_lens *lens, double radius_cfg, int vp_w, int vp_h);

/* Whether pixel (x, y)'s centre lies within `radius` (normalised) of the lens centre and inside the viewport. */
bool warp_fov_pixel_visible(const warp_lens *lens, double radius, int vp_w, int vp_h, int x, int y);

/* The visible pixels of each viewport row: span[2 y] .. span[2 y + 1] - 1 (an empty row has both equal). The disc
 * meets a row in one run, so one span per row is exact. Returns the number of visible pixels. */
int64_t warp_fov_spans(const warp_lens *lens, double radius, int vp_w, int vp_h, int32_t *span);

/* The eye camera's half-field tangents tan[0..3] = left, right, up, down (positive when the field reaches past the
 * axis that way; warp_camera's tan_left ... tan_down) that the visible pixels' centres see, the union over the
 * three channels, each widened by guard_deg (atan(t) + guard). The distortion is a local diffeomorphism inside the
 * monotonic radius, so interior pixels map inside: the extremes lie on the region's border, and only border pixels
 * are evaluated. Returns NULL, or a message (in buf) when the region is empty or a widened half-angle reaches 89 deg. */
const char *warp_fov_tangents(const warp_lens *lens, double radius, int vp_w, int vp_h, double guard_deg,
                              double tangent[4], char *buf, int buflen);

/* The visible region's border as a counter-clockwise line loop of n (3..WARP_FOV_MASK_MAX) tangent-space vertices
 * (u, v), uv[2 k], uv[2 k + 1], in the manner of OpenXR's XR_KHR_visibility_mask: per direction from the lens centre
 * the farthest tangent any channel sees there, widened by guard_deg and by 1/cos(pi/n) so the chords between vertices
 * stay outside the curve. A host need not shade outside it. Returns n, or 0 (no mask: shade everything) when the
 * lens centre lies outside the viewport or the radius is 0. */
int warp_fov_mask_loop(const warp_lens *lens, double radius, int vp_w, int vp_h, double guard_deg, int n, float *uv);

/* The guard band's default in degrees: the rotation an expected head speed of deg_per_s makes over the frame age
 * (frame_age_s), the reach a rotation warp needs beyond the rendered field (003 §4.3). */
double warp_fov_default_guard_deg(double deg_per_s, double frame_age_s);

/* Per mesh vertex, how many visible pixels it stands for (those whose centre is nearest to it), so the share of
 * visible pixels sampling outside the source is read off the vertices' source positions each vsync at the cost of
 * one pass over the mesh. Start-up only (allocates). */
typedef struct {
    int32_t *weight; /* [rows * cols] */
    int n;           /* rows * cols of the mesh it was made for */
    int64_t visible; /* sum of the weights: the visible pixels */
} warp_fov_weights;

bool warp_fov_weights_alloc(warp_fov_weights *w, const warp_mesh *m, const int32_t *span);
void warp_fov_weights_free(warp_fov_weights *w);

/* Visible pixels (weighted as above) whose vertex's source position, in any channel, lies outside the source image
 * [0, src_w] x [0, src_h] for the mesh's current warp. Allocation-free: safe on the vsync path. */
int64_t warp_fov_outside(const warp_fov_weights *w, const warp_mesh *m, int src_w, int src_h);

/* The same count pixel by pixel: every visible pixel's sample position, interpolated from the mesh as the resampler
 * does (warp_mesh.h), checked against [0, src_w] x [0, src_h] in every channel. Exact, but a pass over the viewport:
 * for tests and tools, not the vsync path. */
int64_t warp_fov_outside_exact(const warp_mesh *m, int src_w, int src_h);

#endif
