/* SPDX-License-Identifier: MIT */
/* warp_files: the tools' frame files (hmdwarp-warp's inputs, hmdwarp-feed's sequences): the view file, depth, ids,
 * motion, PFM, layers and object-pose files, each checked against what the file holds before anything is allocated. */
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

/* Depth of cam's size (docs/hmdwarp-warp.md): .pfm (1 channel), .png (16 bit grey) or anything else as raw float32
 * (little endian, rows top to bottom), into *depth (allocated here) in encoding enc: linear values are multiplied
 * by scale (to metres) and, when ray, turned from distance along the pixel's ray into planar z; 16-bit PNG window
 * depth is divided by 65535. Ray distance only with linear depth. On failure nothing stays allocated. */
bool warpfile_load_depth(const char *path, const warp_camera *cam, warp_depth_encoding enc, bool ray, double scale,
                         warp_image_f32 *depth, char *err, int errlen);
/* "linear", "standard", "reversed" / "planar", "ray": false for any other word. */
bool warpfile_depth_encoding(const char *name, warp_depth_encoding *enc);
bool warpfile_depth_kind(const char *name, bool *ray);
/* Object ids (16-bit grey PNG, 0 = static scene) and screen motion (3-channel PFM, pixels per second: x, y, unused)
 * of cam's size into *ids / *motion (allocated here); on failure nothing stays allocated. */
bool warpfile_load_ids(const char *path, const warp_camera *cam, warp_image_u16 *ids, char *err, int errlen);
bool warpfile_load_motion(const char *path, const warp_camera *cam, warp_image_vec2f *motion, char *err, int errlen);
bool warpfile_write_motion(const char *path, const warp_image_vec2f *motion);

/* The object-pose file (docs/hmdwarp-warp.md): per object its id (1..WARPFILE_MAX_OBJECTS) and world_from_object
 * at the source (render) time and, optionally, at the target time. Ids not listed hold still at the identity. */
#define WARPFILE_MAX_OBJECTS 64
typedef struct {
    int n;                                  /* highest id listed: poses [0, n) are meaningful */
    bool has_target;                        /* some line gave a target pose (the others hold still) */
    warp_pose src[WARPFILE_MAX_OBJECTS];    /* [id - 1] */
    warp_pose dst[WARPFILE_MAX_OBJECTS];
} warpfile_objects;
/* False with a message naming the file, line and field: bad id, repeated id, unreadable or non-finite numbers, a
 * quaternion that is not unit length within 1e-3. */
bool warpfile_load_objects(const char *path, warpfile_objects *o, char *err, int errlen);
/* dst may be NULL (source poses only). */
bool warpfile_write_objects(const char *path, int n, const warp_pose *src, const warp_pose *dst);

/* A pose from 7 numbers "qw qx qy qz x y z"; the quaternion is normalised. NULL when read, else a static message
 * naming what is wrong: fewer numbers, the first one that is not finite ("x is not finite"), a zero quaternion, or a
 * quaternion whose length is off 1 by more than tol (tol < 0: any non-zero length). *used: characters read. */
const char *warpfile_parse_pose(const char *s, double tol, warp_pose *p, int *used);

#endif
