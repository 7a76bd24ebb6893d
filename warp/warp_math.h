/* SPDX-License-Identifier: MIT */
/* warp_math: vectors, quaternions, rigid poses and small matrices in double precision.
 * Poses stay in double so that head positions far from the origin and long integrations keep sub-pixel accuracy. */
#ifndef WARP_MATH_H
#define WARP_MATH_H

#include <stdbool.h>

#define WARP_PI 3.14159265358979323846

/* Conventions used everywhere in hmdwarp (OpenGL style, right-handed):
 *  - camera/eye space: +X right, +Y up, the eye looks down -Z;
 *  - world space: +Y up (gravity is -Y);
 *  - a warp_pose is world_from_local: x_world = q * x_local + p;
 *  - matrices are row-major and act on column vectors (y = M x). */

typedef struct { double x, y, z; } warp_vec3;
typedef struct { double w, x, y, z; } warp_quat;
typedef struct { warp_quat q; warp_vec3 p; } warp_pose;
typedef struct { double m[3][3]; } warp_mat3;
typedef struct { double m[4][4]; } warp_mat4;

/* qsort's order on doubles, ascending: the medians and percentiles of timings (the kernel pick, the bench). */
static inline int warp_cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* vectors */
static inline warp_vec3 warp_v3(double x, double y, double z) { warp_vec3 v = {x, y, z}; return v; }
static inline warp_vec3 warp_v3_add(warp_vec3 a, warp_vec3 b) { return warp_v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline warp_vec3 warp_v3_sub(warp_vec3 a, warp_vec3 b) { return warp_v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline warp_vec3 warp_v3_scale(warp_vec3 a, double s) { return warp_v3(a.x * s, a.y * s, a.z * s); }
static inline double warp_v3_dot(warp_vec3 a, warp_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline warp_vec3 warp_v3_cross(warp_vec3 a, warp_vec3 b)
{
    return warp_v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
double warp_v3_norm(warp_vec3 a);
bool warp_v3_isfinite(warp_vec3 a);

/* quaternions (unit quaternions represent rotations; w is the scalar part) */
static inline warp_quat warp_quat_identity(void) { warp_quat q = {1, 0, 0, 0}; return q; }
warp_quat warp_quat_mul(warp_quat a, warp_quat b);
static inline warp_quat warp_quat_conj(warp_quat q) { warp_quat r = {q.w, -q.x, -q.y, -q.z}; return r; }
double warp_quat_norm(warp_quat q);
bool warp_quat_isfinite(warp_quat q);
/* Normalizes q into *out. Returns false (and leaves *out as identity) for NaN/Inf or a norm too small to trust,
 * so callers can reject bad input instead of propagating NaN. */
bool warp_quat_normalize(warp_quat q, warp_quat *out);
warp_vec3 warp_quat_rotate(warp_quat q, warp_vec3 v);
warp_quat warp_quat_from_axis_angle(warp_vec3 axis, double angle_rad);
/* Rotation vector (axis * angle) <-> quaternion; exact near zero angle (series), used for gyro integration. */
warp_quat warp_quat_exp(warp_vec3 rotvec);
warp_vec3 warp_quat_log(warp_quat q);
/* q = Ry(yaw) * Rx(pitch) * Rz(roll), radians: positive yaw turns left, positive pitch looks up,
 * roll is about the view axis. */
warp_quat warp_quat_from_ypr(double yaw, double pitch, double roll);
/* Shortest-path spherical interpolation; t outside [0,1] extrapolates (used for pose prediction, 002 §3.2). */
warp_quat warp_quat_slerp(warp_quat a, warp_quat b, double t);
/* Angle in radians of the rotation between a and b, in [0, pi]. */
double warp_quat_angle_between(warp_quat a, warp_quat b);
warp_mat3 warp_quat_to_mat3(warp_quat q);
warp_quat warp_mat3_to_quat(const warp_mat3 *m);

/* rigid poses */
static inline warp_pose warp_pose_identity(void)
{
    warp_pose p = {{1, 0, 0, 0}, {0, 0, 0}};
    return p;
}
warp_pose warp_pose_mul(warp_pose a, warp_pose b);      /* a * b: apply b, then a */
warp_pose warp_pose_inverse(warp_pose a);
warp_vec3 warp_pose_apply(warp_pose a, warp_vec3 v);    /* q v + p */
/* Pose of `b` expressed in the frame of `a`: inverse(a) * b. */
warp_pose warp_pose_relative(warp_pose a, warp_pose b);
warp_mat4 warp_pose_to_mat4(warp_pose a);
bool warp_pose_isfinite(warp_pose a);

/* The one check every warp makes of the poses it is given (a NaN would otherwise reach ray arithmetic and index
 * images at (int)NaN, and a non-unit quaternion would scale the scene: warp_quat_rotate assumes |q| = 1). Returns
 * NULL when usable, else a static message naming the pose and what is wrong with it: "target pose: position is not
 * finite", "... orientation is not finite", "... orientation quaternion is zero", "... orientation is not a unit
 * quaternion". Unit within WARP_POSE_UNIT_TOL, as drv_frame_validate accepts a host's poses. */
#define WARP_POSE_UNIT_TOL 1e-3
typedef enum {
    WARP_POSE_SOURCE,        /* the view's pose (world_from_eye at render time) */
    WARP_POSE_TARGET,        /* the eye pose warped to */
    WARP_POSE_SOURCE_OBJECT, /* an object's pose at render time */
    WARP_POSE_TARGET_OBJECT, /* an object's pose at the target time */
} warp_pose_role;
const char *warp_pose_check(warp_pose p, warp_pose_role role);
/* The orientation alone, for warps that use nothing else of a pose (rotation reprojection). */
const char *warp_orientation_check(warp_quat q, warp_pose_role role);
/* n object poses at render time (src) and at the target time (dst), either may be NULL: the first bad one. */
const char *warp_object_poses_check(const warp_pose *src, const warp_pose *dst, int n);
/* Source, then target: what a warp's entry calls, `const char *bad = warp_poses_check(src->pose, dst_pose);`. */
static inline const char *warp_poses_check(warp_pose src, warp_pose dst)
{
    const char *bad = warp_pose_check(src, WARP_POSE_SOURCE);
    return bad ? bad : warp_pose_check(dst, WARP_POSE_TARGET);
}

/* 3x3 and 4x4 matrices */
warp_mat3 warp_mat3_identity(void);
warp_mat3 warp_mat3_mul(const warp_mat3 *a, const warp_mat3 *b);
warp_vec3 warp_mat3_apply(const warp_mat3 *a, warp_vec3 v);
double warp_mat3_det(const warp_mat3 *a);
/* Returns false when the matrix is singular (|det| below 1e-300 relative scale) or not finite. */
bool warp_mat3_inverse(const warp_mat3 *a, warp_mat3 *out);
warp_mat3 warp_mat3_transpose(const warp_mat3 *a);

warp_mat4 warp_mat4_identity(void);
warp_mat4 warp_mat4_mul(const warp_mat4 *a, const warp_mat4 *b);
/* Applies to (x,y,z,w) given as an array of 4. */
void warp_mat4_apply(const warp_mat4 *a, const double in[4], double out[4]);
bool warp_mat4_inverse(const warp_mat4 *a, warp_mat4 *out);

#endif
