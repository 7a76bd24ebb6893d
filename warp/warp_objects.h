/* SPDX-License-Identifier: MIT */
/* warp_objects: per-object forward warping (002 §3.2): every pixel's object id selects one combined transform
 * (source object pose -> target object pose, composed with the camera change), and object poses are extrapolated
 * from the two latest frames (slerp on rotation, linear on position) when no newer pose is known. */
#ifndef WARP_OBJECTS_H
#define WARP_OBJECTS_H

#include "warp/warp_forward.h"
#include "warp/warp_splat.h"

/* Linear prediction of an object pose (002 §3.2): the pose at time t from the poses p0 at t0 and p1 at t1
 * (t1 != t0; t > t1 extrapolates): rotation by quaternion slerp with parameter (t - t0) / (t1 - t0), position
 * linearly. Exact for constant linear and angular velocity. Returns p1 when the times are unusable. */
warp_pose warp_object_pose_extrapolate(warp_pose p0, double t0, warp_pose p1, double t1, double t);

/* The combined transform of 002 §3.2 for one object, as a rigid pose from source eye to target eye:
 * dst_eye_from_src_eye = dst_eye^-1 * obj_dst * obj_src^-1 * src_eye (all world_from_x). */
warp_pose warp_object_eye_transform(warp_pose src_eye, warp_pose dst_eye, warp_pose obj_src, warp_pose obj_dst);

#define WARP_OBJECTS_MAX 4096

typedef struct {
    warp_fwd_setup fwd;
    warp_fwd_xform xf[WARP_OBJECTS_MAX]; /* [id]; id 0 (static scene, sky) moves with the camera only */
    int n_moved;                         /* objects whose target pose differs from their source pose */
} warp_objects_setup;

/* Prepares a per-object warp of src (colour, inverse depth, ids, object_pose, n_objects) to the eye pose dst_pose
 * seen through dst_cam, with the objects at dst_object_pose ([id - 1], world_from_object at the target time, e.g.
 * from warp_object_pose_extrapolate); dst_object_pose NULL keeps every object where the source saw it (the
 * whole-frame warp). Returns NULL when usable, else what is missing. */
const char *warp_objects_prepare(warp_objects_setup *s, const warp_view *src, const warp_camera *dst_cam,
                                 warp_pose dst_pose, const warp_pose *dst_object_pose);

typedef struct {
    warp_splat_stats splat;  /* samples, holes, primitives, ...; fwd.bad_ids counts ids beyond n_objects */
    int objects;             /* transforms built (n_objects + 1) */
    int moved;               /* of those, objects that moved between source and target */
} warp_objects_stats;

/* The entry point: per-object forward warp with reconstruction p (the z-buffer is always used: every object has
 * its own epipole, so no single occlusion-compatible order exists). s is caller memory (it is large: the
 * transform table). st may be NULL. */
const char *warp_objects_run(warp_objects_setup *s, const warp_view *src, const warp_camera *dst_cam,
                             warp_pose dst_pose, const warp_pose *dst_object_pose, const warp_splat_params *p,
                             warp_fwd_scratch *sc, warp_image_rgba8 *dst, warp_image_u8 *mask,
                             warp_objects_stats *st);

#endif
