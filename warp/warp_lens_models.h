/* SPDX-License-Identifier: MIT */
/* warp_lens_models: builds a warp_lens from the parameters each published lens format uses (OpenHMD's Panotools,
 * Monado's Vive/Index, Cardboard viewer profiles, OpenCV camera calibrations), in their own units. */
#ifndef WARP_LENS_MODELS_H
#define WARP_LENS_MODELS_H

#include <stdbool.h>

#include "warp/warp_lens.h"

/* Panotools as OpenHMD's universal distortion shader (OpenHMD src/shaders/test1.frag, examples/opengl/main.c):
 *   q = (panel - centre) / WarpScale,  r = |q|,  displaced = q (d + c r + b r^2 + a r^3) WarpScale,
 *   texture = (centre + aberration_c displaced) / viewport,
 * and the eye buffer is a frustum whose edges are the viewport's edges seen from eye_to_screen (rift.c), so the
 * view tangent is aberration_c * displaced / eye_to_screen. Here in pixels: scale = WarpScale in panel pixels,
 * tan_scale = WarpScale / eye_to_screen. */
typedef struct {
    double abcd[3][4];         /* per channel a b c d (OpenHMD uses one set for all three) */
    double aberration[3];      /* per-channel scale of the displaced radius, universal_aberration_k */
    double center_x, center_y; /* lens centre, viewport pixels from its top-left */
    double scale;              /* viewport pixels per unit of normalised radius (WarpScale) */
    double tan_scale;          /* view tangent per unit of displaced radius before aberration */
} warp_lens_panotools_params;

warp_lens warp_lens_panotools(const warp_lens_panotools_params *p);

/* OpenHMD's device properties (ohmd_device_getf), left eye; the viewport is half the panel. */
typedef struct {
    double k[4];          /* OHMD_UNIVERSAL_DISTORTION_K: a b c d */
    double aberration[3]; /* OHMD_UNIVERSAL_ABERRATION_K: r g b */
    double hsize, vsize;  /* OHMD_SCREEN_HORIZONTAL_SIZE / _VERTICAL_SIZE: the whole panel, metres */
    int hres, vres;       /* OHMD_SCREEN_HORIZONTAL_RESOLUTION / _VERTICAL_RESOLUTION: the whole panel, pixels */
    double lens_sep;      /* OHMD_LENS_HORIZONTAL_SEPARATION: lens centre to lens centre, metres */
    double lens_vpos;     /* OHMD_LENS_VERTICAL_POSITION: lens centre above the panel's bottom edge, metres */
    double eye_to_screen; /* the projection frustum's near distance (rift.c: eye_to_screen_distance), metres */
} warp_lens_openhmd_device;

/* OpenHMD's geometry in viewport pixels (WarpScale = the larger distance from the lens centre to a viewport side,
 * as OpenHMD's examples set it). Returns false with a message naming the bad value. */
bool warp_lens_openhmd_params(const warp_lens_openhmd_device *d, warp_lens_panotools_params *out, char *err,
                              int errlen);

/* Monado's u_vive model (src/xrt/auxiliary/util/u_distortion_mesh.c, u_compute_distortion_vive) with the eye
 * buffer's field from the config's intrinsics (src/xrt/drivers/vive/vive_config.c, _calculate_fov). For panel
 * coordinates u, v in [0, 1] of one eye (v down):
 *   X = 2u - 1 - cx_c,  Y = (2v - 1) / aspect - cy_c,  d = 1 / (1 + k1 r^2 + k2 r^4 + k3 r^6) + k4,
 *   tangent right = (X d + cx_c + icx) / ifx,   tangent up = (icy - aspect (Y d + cy_c)) / ify,
 * grow_for_undistort cancels between the texture coordinate and the field (both divide by 1 + grow). Valve's
 * undistort_r2_cutoff marks where the lens's view ends: past it (the panel's corners) F heads for its pole, so f
 * continues along its tangent line there, one to one and far outside any eye buffer. */
typedef struct {
    double k[3][4];          /* red, green, blue: k1 k2 k3 k4 (the JSON's distortion_red, distortion, distortion_blue
                                coeffs) */
    double center[3][2];     /* red, green, blue: center_x center_y */
    double aspect_x_over_y;  /* device.physical_aspect_x_over_y */
    double intrinsics[4];    /* fx cx fy cy: intrinsics[0][0], [0][2], [1][1], [1][2] of the eye */
    double r2_cutoff;        /* undistort_r2_cutoff: beyond r^2 = this, F's pole is out of the lens's view and f
                                continues along its tangent line (0: none) */
} warp_lens_vive_params;

warp_lens warp_lens_vive(const warp_lens_vive_params *p, int vw, int vh);

/* Cardboard's viewer profile (Cardboard SDK sdk/lens_distortion.cc, sdk/polynomial_radial_distortion.cc): a panel
 * point's distance from the lens axis divided by screen_to_lens is its screen tan-angle p; the view direction is
 * p (1 + k1 |p|^2 + k2 |p|^4). The left lens axis is (screen_w - inter_lens) / 2 from the panel's left edge; its
 * height above the bottom edge is tray_to_lens - 3 mm (bottom alignment), half the screen (centre) or the screen
 * height less that (top). No chromatic aberration: Cardboard corrects none. */
typedef struct {
    double k[4];            /* k1 k2 (k3 k4 for profiles with more; else 0) */
    double screen_to_lens;  /* metres */
    double inter_lens;      /* metres, lens axis to lens axis */
    double tray_to_lens;    /* metres */
    int alignment;          /* vertical_alignment: 0 bottom, 1 centre, 2 top */
    double screen_w, screen_h; /* the whole panel, metres */
} warp_lens_cardboard_params;

warp_lens warp_lens_cardboard(const warp_lens_cardboard_params *p, int vw, int vh);

/* OpenCV's camera model (cv::projectPoints) read as the display's: a view direction with tangents (u, v) (v up) is
 * x' = u, y' = -v; x'' = x' F + 2 p1 x' y' + p2 (r^2 + 2 x'^2), y'' = y' F + p1 (r^2 + 2 y'^2) + 2 p2 x' y',
 * F = 1 + k1 r^2 + k2 r^4 + k3 r^6; panel pixel = (fx x'' + cx, fy y'' + cy) in the eye's viewport. */
typedef struct {
    double fx, fy, cx, cy;      /* camera_matrix, viewport pixels */
    double k1, k2, p1, p2, k3;  /* distortion_coefficients in OpenCV's order */
} warp_lens_opencv_params;

warp_lens warp_lens_opencv(const warp_lens_opencv_params *p);

/* The right eye's lens from the left one: the viewport mirrored about its vertical centre line (vw wide). */
void warp_lens_mirror(warp_lens *lens, double vw);

#endif
