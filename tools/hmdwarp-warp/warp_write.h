/* SPDX-License-Identifier: MIT */
/* warp_write: hmdwarp-warp's files written from the simulator: one frame's inputs (--write-inputs, also a one-frame
 * sequence) and a multi-frame sequence (--write-sequence) that hmdwarp-feed --sequence plays. */
#ifndef HMDWARP_WARP_WRITE_H
#define HMDWARP_WARP_WRITE_H

#include <stdbool.h>

#include "sim/sim_scene.h"
#include "tools/common/warp_files.h"

/* DIR/color.png, depth.pfm, ids.png, motion.pfm, layers.bin, objects.txt (object poses at the source and target
 * times), view.txt, truth.png and manifest.txt (a one-frame, one-eye sequence at scene time t) from the rendered
 * source sb (all planes) and truth tb. False with the message. */
bool warp_write_inputs(const char *dir, const warpfile_view *vf, const sim_buffers *sb, const sim_buffers *tb,
                       double t, int n_objects, const warp_pose *obj_src, const warp_pose *obj_dst, char *err,
                       int errlen);

/* A stereo sequence of n frames of scene sc at rate_hz into DIR: the head moves from the view's source pose to its
 * target pose (the view poses are head poses, eyes IPD apart through warp_head_default()), scene time from t0 on;
 * per frame and eye colour, depth, ids and motion (and layers when the scene has transparency), per frame the
 * object poses; manifest.txt names them. False with the message. */
bool warp_write_sequence(const char *dir, const sim_scene *sc, const warpfile_view *vf, int n, double rate_hz,
                         double t0, char *err, int errlen);

#endif
