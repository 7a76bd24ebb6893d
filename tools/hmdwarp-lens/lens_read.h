/* SPDX-License-Identifier: MIT */
/* hmdwarp-lens's readers of the files a user downloads or measures (a Monado/SteamVR config JSON, an OpenCV
 * calibration YAML, a correspondence CSV): each to the numbers import or fit writes, or a message saying why not. */
#ifndef HMDWARP_LENS_READ_H
#define HMDWARP_LENS_READ_H

#include <stdbool.h>
#include <stddef.h>

#include "warp/warp_lens_models.h"
#include "warp/warp_lensfit.h"

#define LENS_READ_MAX_POINTS 1000000 /* a photographed grid has thousands; this bounds the memory */

/* Each reader returns 0, or the tool's exit status (2 refused, 1 out of memory) with err saying why: the file, and
 * the line or key where one is known. Files are read whole up to 16 MiB (configs and calibrations are a few kB). */

/* The left eye of a Monado/SteamVR HMD config (tracking_to_eye_transform[0], device.physical_aspect_x_over_y):
 * every number finite, aspect > 0 (default 0.9), intrinsics' fx and fy non-zero, r2_cutoff >= 0. A missing red or
 * blue channel is the green one's copy, with missing[c] set. */
int lens_read_vive(const char *path, warp_lens_vive_params *p, bool missing[3], char *err, size_t errlen);

/* An OpenCV calibration: camera_matrix (fx, fy > 0) and distortion_coefficients (4, 5, 8, 12 or 14 numbers, none
 * non-zero beyond k3), every number finite; when image_width and image_height are given the camera matrix is scaled
 * from that image to a vw x vh viewport and *scaled set. */
int lens_read_opencv(const char *path, double vw, double vh, warp_lens_opencv_params *p, bool *scaled, char *err,
                     size_t errlen);

/* Correspondence rows channel,panel_x,panel_y,u,v (a header, blank and # lines skipped) appended to pts[c] (malloc'd,
 * the caller frees them, also on failure), n[c] counting them: four finite numbers each, at most
 * LENS_READ_MAX_POINTS in all. */
int lens_read_csv(const char *path, warp_lensfit_point *pts[3], int n[3], char *err, size_t errlen);

#endif
