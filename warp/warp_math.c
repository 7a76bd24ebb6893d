/* SPDX-License-Identifier: MIT */
/* warp_math: vectors, quaternions, rigid poses and small matrices in double precision.
 * Poses stay in double so that head positions far from the origin and long integrations keep sub-pixel accuracy. */
#include "warp/warp_math.h"

#include <math.h>
#include <string.h>

double warp_v3_norm(warp_vec3 a) { return sqrt(warp_v3_dot(a, a)); }

bool warp_v3_isfinite(warp_vec3 a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }

warp_quat warp_quat_mul(warp_quat a, warp_quat b)
{
    warp_quat r;
    r.w = a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z;
    r.x = a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y;
    r.y = a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x;
    r.z = a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w;
    return r;
}

double warp_quat_norm(warp_quat q) { return sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z); }

bool warp_quat_isfinite(warp_quat q) { return isfinite(q.w) && isfinite(q.x) && isfinite(q.y) && isfinite(q.z); }

bool warp_quat_normalize(warp_quat q, warp_quat *out)
{
    double n = warp_quat_norm(q);
    if (!isfinite(n) || n < 1e-12) {
        *out = warp_quat_identity();
        return false;
    }
    out->w = q.w / n;
    out->x = q.x / n;
    out->y = q.y / n;
    out->z = q.z / n;
    return true;
}

warp_vec3 warp_quat_rotate(warp_quat q, warp_vec3 v)
{
    /* v' = v + 2w (u x v) + 2 u x (u x v), u = vector part: cheaper than two quaternion products. */
    warp_vec3 u = warp_v3(q.x, q.y, q.z);
    warp_vec3 t = warp_v3_scale(warp_v3_cross(u, v), 2.0);
    return warp_v3_add(warp_v3_add(v, warp_v3_scale(t, q.w)), warp_v3_cross(u, t));
}

warp_quat warp_quat_from_axis_angle(warp_vec3 axis, double angle)
{
    double n = warp_v3_norm(axis);
    if (!(n > 0.0)) return warp_quat_identity();
    return warp_quat_exp(warp_v3_scale(axis, angle / n));
}

warp_quat warp_quat_exp(warp_vec3 r)
{
    double theta = warp_v3_norm(r);
    double half = 0.5 * theta;
    /* sin(half)/theta, by series below 1e-4 rad so tiny gyro steps keep full relative precision. */
    double k = theta < 1e-4 ? 0.5 - theta * theta / 48.0 : sin(half) / theta;
    warp_quat q = {cos(half), r.x * k, r.y * k, r.z * k};
    return q;
}

warp_vec3 warp_quat_log(warp_quat q)
{
    if (q.w < 0) { /* same rotation, shorter way round */
        q.w = -q.w; q.x = -q.x; q.y = -q.y; q.z = -q.z;
    }
    double s = sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
    /* atan2 keeps precision both near 0 and near pi, where acos(w) would not. */
    double theta = 2.0 * atan2(s, q.w);
    double k = s < 1e-9 ? 2.0 / (q.w > 0 ? q.w : 1.0) : theta / s;
    return warp_v3(q.x * k, q.y * k, q.z * k);
}

warp_quat warp_quat_from_ypr(double yaw, double pitch, double roll)
{
    warp_quat qy = warp_quat_from_axis_angle(warp_v3(0, 1, 0), yaw);
    warp_quat qp = warp_quat_from_axis_angle(warp_v3(1, 0, 0), pitch);
    warp_quat qr = warp_quat_from_axis_angle(warp_v3(0, 0, 1), roll);
    return warp_quat_mul(qy, warp_quat_mul(qp, qr));
}

warp_quat warp_quat_slerp(warp_quat a, warp_quat b, double t)
{
    /* a * exp(t * log(a^-1 b)) handles extrapolation (t > 1) and near-identical inputs uniformly. */
    warp_quat d = warp_quat_mul(warp_quat_conj(a), b);
    warp_vec3 r = warp_quat_log(d);
    warp_quat out;
    warp_quat_normalize(warp_quat_mul(a, warp_quat_exp(warp_v3_scale(r, t))), &out);
    return out;
}

double warp_quat_angle_between(warp_quat a, warp_quat b)
{
    return warp_v3_norm(warp_quat_log(warp_quat_mul(warp_quat_conj(a), b)));
}

warp_mat3 warp_quat_to_mat3(warp_quat q)
{
    double w = q.w, x = q.x, y = q.y, z = q.z;
    warp_mat3 m = {{
        {1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
        {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
        {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)},
    }};
    return m;
}

warp_quat warp_mat3_to_quat(const warp_mat3 *mm)
{
    /* Shepperd's method: pick the largest diagonal term to divide by, for stability at 180 degrees. */
    const double (*m)[3] = mm->m;
    double tr = m[0][0] + m[1][1] + m[2][2];
    warp_quat q;
    if (tr > 0) {
        double s = sqrt(tr + 1.0) * 2;
        q.w = 0.25 * s;
        q.x = (m[2][1] - m[1][2]) / s;
        q.y = (m[0][2] - m[2][0]) / s;
        q.z = (m[1][0] - m[0][1]) / s;
    } else if (m[0][0] > m[1][1] && m[0][0] > m[2][2]) {
        double s = sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]) * 2;
        q.w = (m[2][1] - m[1][2]) / s;
        q.x = 0.25 * s;
        q.y = (m[0][1] + m[1][0]) / s;
        q.z = (m[0][2] + m[2][0]) / s;
    } else if (m[1][1] > m[2][2]) {
        double s = sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]) * 2;
        q.w = (m[0][2] - m[2][0]) / s;
        q.x = (m[0][1] + m[1][0]) / s;
        q.y = 0.25 * s;
        q.z = (m[1][2] + m[2][1]) / s;
    } else {
        double s = sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]) * 2;
        q.w = (m[1][0] - m[0][1]) / s;
        q.x = (m[0][2] + m[2][0]) / s;
        q.y = (m[1][2] + m[2][1]) / s;
        q.z = 0.25 * s;
    }
    warp_quat out;
    warp_quat_normalize(q, &out);
    return out;
}

warp_pose warp_pose_mul(warp_pose a, warp_pose b)
{
    warp_pose r;
    r.q = warp_quat_mul(a.q, b.q);
    r.p = warp_v3_add(warp_quat_rotate(a.q, b.p), a.p);
    return r;
}

warp_pose warp_pose_inverse(warp_pose a)
{
    warp_pose r;
    r.q = warp_quat_conj(a.q);
    r.p = warp_v3_scale(warp_quat_rotate(r.q, a.p), -1.0);
    return r;
}

warp_vec3 warp_pose_apply(warp_pose a, warp_vec3 v) { return warp_v3_add(warp_quat_rotate(a.q, v), a.p); }

warp_pose warp_pose_relative(warp_pose a, warp_pose b)
{
    /* Subtract positions before rotating so that two poses 10 km from the origin lose no precision. */
    warp_quat ai = warp_quat_conj(a.q);
    warp_pose r;
    r.q = warp_quat_mul(ai, b.q);
    r.p = warp_quat_rotate(ai, warp_v3_sub(b.p, a.p));
    return r;
}

warp_mat4 warp_pose_to_mat4(warp_pose a)
{
    warp_mat3 r = warp_quat_to_mat3(a.q);
    warp_mat4 m = warp_mat4_identity();
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) m.m[i][j] = r.m[i][j];
    m.m[0][3] = a.p.x;
    m.m[1][3] = a.p.y;
    m.m[2][3] = a.p.z;
    return m;
}

bool warp_pose_isfinite(warp_pose a) { return warp_quat_isfinite(a.q) && warp_v3_isfinite(a.p); }

/* One static message per role and fault, so the check formats nothing (warps report static strings). */
enum { POSE_BAD_POSITION, POSE_BAD_ORIENT, POSE_ZERO_QUAT, POSE_NOT_UNIT, POSE_FAULTS };
#define POSE_MSGS_(who)                                                                                                \
    {who " pose: position is not finite", who " pose: orientation is not finite",                                   \
     who " pose: orientation quaternion is zero",                                                                   \
     who " pose: orientation is not a unit quaternion (|q| off 1 by more than 1e-3)"}
static const char *const pose_msg[][POSE_FAULTS] = {
    [WARP_POSE_SOURCE] = POSE_MSGS_("source"),
    [WARP_POSE_TARGET] = POSE_MSGS_("target"),
    [WARP_POSE_SOURCE_OBJECT] = POSE_MSGS_("source object"),
    [WARP_POSE_TARGET_OBJECT] = POSE_MSGS_("target object"),
};
#undef POSE_MSGS_

static const char *const *pose_msgs(warp_pose_role role)
{
    return pose_msg[role <= WARP_POSE_TARGET_OBJECT ? role : WARP_POSE_TARGET];
}

const char *warp_orientation_check(warp_quat q, warp_pose_role role)
{
    const char *const *m = pose_msgs(role);
    if (!warp_quat_isfinite(q)) return m[POSE_BAD_ORIENT];
    if (q.w == 0 && q.x == 0 && q.y == 0 && q.z == 0) return m[POSE_ZERO_QUAT];
    if (!(fabs(warp_quat_norm(q) - 1.0) <= WARP_POSE_UNIT_TOL)) return m[POSE_NOT_UNIT];
    return NULL;
}

const char *warp_pose_check(warp_pose p, warp_pose_role role)
{
    if (!warp_v3_isfinite(p.p)) return pose_msgs(role)[POSE_BAD_POSITION];
    return warp_orientation_check(p.q, role);
}

const char *warp_object_poses_check(const warp_pose *src, const warp_pose *dst, int n)
{
    for (int i = 0; i < n; i++) {
        const char *bad = src ? warp_pose_check(src[i], WARP_POSE_SOURCE_OBJECT) : NULL;
        if (!bad && dst) bad = warp_pose_check(dst[i], WARP_POSE_TARGET_OBJECT);
        if (bad) return bad;
    }
    return NULL;
}

warp_mat3 warp_mat3_identity(void)
{
    warp_mat3 m = {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
    return m;
}

warp_mat3 warp_mat3_mul(const warp_mat3 *a, const warp_mat3 *b)
{
    warp_mat3 r;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            r.m[i][j] = a->m[i][0] * b->m[0][j] + a->m[i][1] * b->m[1][j] + a->m[i][2] * b->m[2][j];
    return r;
}

warp_vec3 warp_mat3_apply(const warp_mat3 *a, warp_vec3 v)
{
    return warp_v3(a->m[0][0] * v.x + a->m[0][1] * v.y + a->m[0][2] * v.z,
                   a->m[1][0] * v.x + a->m[1][1] * v.y + a->m[1][2] * v.z,
                   a->m[2][0] * v.x + a->m[2][1] * v.y + a->m[2][2] * v.z);
}

double warp_mat3_det(const warp_mat3 *a)
{
    const double (*m)[3] = a->m;
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

bool warp_mat3_inverse(const warp_mat3 *a, warp_mat3 *out)
{
    const double (*m)[3] = a->m;
    double det = warp_mat3_det(a);
    double scale = 0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) scale = fmax(scale, fabs(m[i][j]));
    if (!isfinite(det) || scale == 0 || fabs(det) <= 1e-300 * scale * scale * scale) return false;
    double id = 1.0 / det;
    out->m[0][0] = (m[1][1] * m[2][2] - m[1][2] * m[2][1]) * id;
    out->m[0][1] = (m[0][2] * m[2][1] - m[0][1] * m[2][2]) * id;
    out->m[0][2] = (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * id;
    out->m[1][0] = (m[1][2] * m[2][0] - m[1][0] * m[2][2]) * id;
    out->m[1][1] = (m[0][0] * m[2][2] - m[0][2] * m[2][0]) * id;
    out->m[1][2] = (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * id;
    out->m[2][0] = (m[1][0] * m[2][1] - m[1][1] * m[2][0]) * id;
    out->m[2][1] = (m[0][1] * m[2][0] - m[0][0] * m[2][1]) * id;
    out->m[2][2] = (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * id;
    return true;
}

warp_mat3 warp_mat3_transpose(const warp_mat3 *a)
{
    warp_mat3 r;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) r.m[i][j] = a->m[j][i];
    return r;
}

warp_mat4 warp_mat4_identity(void)
{
    warp_mat4 m;
    memset(&m, 0, sizeof m);
    for (int i = 0; i < 4; i++) m.m[i][i] = 1;
    return m;
}

warp_mat4 warp_mat4_mul(const warp_mat4 *a, const warp_mat4 *b)
{
    warp_mat4 r;
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            double s = 0;
            for (int k = 0; k < 4; k++) s += a->m[i][k] * b->m[k][j];
            r.m[i][j] = s;
        }
    return r;
}

void warp_mat4_apply(const warp_mat4 *a, const double in[4], double out[4])
{
    for (int i = 0; i < 4; i++)
        out[i] = a->m[i][0] * in[0] + a->m[i][1] * in[1] + a->m[i][2] * in[2] + a->m[i][3] * in[3];
}

bool warp_mat4_inverse(const warp_mat4 *a, warp_mat4 *out)
{
    /* Gauss-Jordan with partial pivoting: 4x4 projection matrices are badly scaled (near/far), cofactors are not. */
    double m[4][8];
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            m[i][j] = a->m[i][j];
            m[i][j + 4] = (i == j);
        }
    for (int c = 0; c < 4; c++) {
        int piv = c;
        for (int r = c + 1; r < 4; r++)
            if (fabs(m[r][c]) > fabs(m[piv][c])) piv = r;
        if (!(fabs(m[piv][c]) > 1e-300)) return false;
        if (piv != c)
            for (int j = 0; j < 8; j++) {
                double t = m[c][j];
                m[c][j] = m[piv][j];
                m[piv][j] = t;
            }
        double inv = 1.0 / m[c][c];
        for (int j = 0; j < 8; j++) m[c][j] *= inv;
        for (int r = 0; r < 4; r++) {
            if (r == c || m[r][c] == 0) continue;
            double f = m[r][c];
            for (int j = 0; j < 8; j++) m[r][j] -= f * m[c][j];
        }
    }
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            out->m[i][j] = m[i][j + 4];
            if (!isfinite(out->m[i][j])) return false;
        }
    return true;
}
