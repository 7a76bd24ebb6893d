/* SPDX-License-Identifier: MIT */
/* warp_files: hmdwarp-warp's input and output files other than PNG: the view file, PFM float images and the layers
 * (A-buffer) file, each checked against what the file holds before anything it declares is allocated. */
#ifndef HMDWARP_WARP_FILES_H
#define HMDWARP_WARP_FILES_H

#include <stdbool.h>
#include <stdio.h>

#include "warp/warp_camera.h"
#include "warp/warp_image.h"
#include "warp/warp_math.h"

/* The view file (docs/hmdwarp-warp.md): the camera and the source and target poses. */
typedef struct {
    warp_camera cam;
    warp_pose src, dst;
} warpfile_view;

/* False with a message naming the file (and line) on any problem: unknown key, unreadable values, a pose that is
 * not finite, a camera warp_camera_check() refuses. */
bool warpfile_load_view(const char *path, warpfile_view *vf, char *err, int errlen);
void warpfile_pose_line(FILE *f, const char *key, warp_pose p);

/* PFM ("Pf" grey, "PF" RGB; rows bottom to top) into a newly allocated top-to-bottom float array (free() it); NULL
 * with a message when the header is bad or the file holds fewer values than it declares. */
float *warpfile_read_pfm(const char *path, int *w, int *h, int *channels, char *err, int errlen);
bool warpfile_write_pfm(const char *path, const float *px, int w, int h, int channels);

/* Layers file ("HWLAYER1", u32 w, h, max_layers, per pixel a u8 count and its fragments) of cam's size into *l
 * (allocated here; warp_image_layers_free() it). On failure nothing stays allocated. */
bool warpfile_read_layers(const char *path, const warp_camera *cam, warp_image_layers *l, char *err, int errlen);
bool warpfile_write_layers(const char *path, const warp_image_layers *l);

#endif
