/* SPDX-License-Identifier: MIT */
/* warp_objects: per-object forward warping (002 §3.2): every pixel's object id selects one combined transform
 * (source object pose -> target object pose, composed with the camera change), and object poses are extrapolated
 * from the two latest frames (slerp on rotation, linear on position) when no newer pose is known. */
#include "warp/warp_objects.h"

#include <math.h>
#include <string.h>

warp_pose warp_object_pose_extrapolate(warp_pose p0, double t0, warp_pose p1, double t1, double t)
{
    double dt = t1 - t0;
    if (!(fabs(dt) > 1e-12) || !isfinite(t) || !warp_pose_isfinite(p0) || !warp_pose_isfinite(p1)) return p1;
    double s = (t - t0) / dt;
    warp_pose out;
    out.q = warp_quat_slerp(p0.q, p1.q, s);
    out.p = warp_v3_add(p0.p, warp_v3_scale(warp_v3_sub(p1.p, p0.p), s));
    return out;
}

warp_pose warp_object_eye_transform(warp_pose src_eye, warp_pose dst_eye, warp_pose obj_src, warp_pose obj_dst)
{
    /* 002 §3.2: S_wld->cam * S_obj->wld * C_wld->obj * C_cam->wld (the projections live in the xform). The object
     * step obj_dst * obj_src^-1 is formed first: for a static object it is exactly the identity. */
    warp_pose move = warp_pose_mul(obj_dst, warp_pose_inverse(obj_src));
    warp_pose t = warp_pose_mul(move, src_eye);
    return warp_pose_relative(dst_eye, t);
}

const char *warp_objects_prepare(warp_objects_setup *s, const warp_view *src, const warp_camera *dst_cam,
                                 warp_pose dst_pose, const warp_pose *dst_object_pose)
{
    warp_forward_params fp = warp_forward_default_params();
    fp.vis = WARP_FWD_ZBUFFER;
    const char *err = warp_forward_prepare(&s->fwd, src, dst_cam, dst_pose, &fp);
    if (err) return err;
    if (!src->ids) return "per-object warp needs an id plane";
    if (src->n_objects < 0 || src->n_objects >= WARP_OBJECTS_MAX) return "object count out of range";
    if (src->n_objects > 0 && !src->object_pose) return "per-object warp needs the source object poses";
    s->xf[0] = s->fwd.cam_xf;
    s->n_moved = 0;
    for (int id = 1; id <= src->n_objects; id++) {
        warp_pose os = src->object_pose[id - 1], od = dst_object_pose ? dst_object_pose[id - 1] : os;
        if ((err = warp_object_poses_check(&os, &od, 1))) return err;
        warp_pose m = warp_object_eye_transform(src->pose, dst_pose, os, od);
        s->xf[id] = warp_fwd_xform_make(&src->cam, dst_cam, m);
        s->n_moved += od.p.x != os.p.x || od.p.y != os.p.y || od.p.z != os.p.z || od.q.w != os.q.w ||
                      od.q.x != os.q.x || od.q.y != os.q.y || od.q.z != os.q.z;
    }
    s->fwd.obj_xf = s->xf;
    s->fwd.n_obj_xf = src->n_objects + 1;
    return NULL;
}

const char *warp_objects_run(warp_objects_setup *s, const warp_view *src, const warp_camera *dst_cam,
                             warp_pose dst_pose, const warp_pose *dst_object_pose, const warp_splat_params *p,
                             warp_fwd_scratch *sc, warp_image_rgba8 *dst, warp_image_u8 *mask,
                             warp_objects_stats *st)
{
    const char *err = warp_splat_check_params(p);
    if (err) return err;
    err = warp_objects_prepare(s, src, dst_cam, dst_pose, dst_object_pose);
    if (err) return err;
    err = warp_fwd_check_sizes(src, dst_cam, sc, dst, mask);
    if (err) return err;
    s->fwd.p.edge_jump = p->edge_jump;
    warp_splat_params zp = *p;
    zp.vis = WARP_FWD_ZBUFFER;
    warp_objects_stats local;
    memset(&local, 0, sizeof local);
    warp_forward_map_rows(&s->fwd, sc, p->kind != WARP_SPLAT_MESH, 0, src->color->h, &local.splat.fwd);
    local.splat.fwd.sheets = warp_forward_order(&s->fwd, WARP_FWD_ZBUFFER, sc);
    warp_forward_clear(sc);
    warp_splat_draw(&s->fwd, sc, &zp, dst, &local.splat);
    warp_forward_finish_rows(&s->fwd, sc, dst, mask, 0, dst->h, &local.splat.fwd);
    local.objects = src->n_objects + 1;
    local.moved = s->n_moved;
    if (st) *st = local;
    return NULL;
}
