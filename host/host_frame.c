/* SPDX-License-Identifier: MIT */
/* host_frame: checks a caller's frame field by field and converts it into the codec's drv_frame: colour to RGBA8,
 * ray distance to planar depth, 16-bit window depth to the wire's scale, strides to packed planes. */
#include "host/host_frame.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "warp/warp_camera.h"

static const char *const plane_names[5] = {"color", "depth", "ids", "motion", "layers"};

warp_pose host_pose_to_warp(const hmdwarp_host_pose *p)
{
    return (warp_pose){{p->orientation[0], p->orientation[1], p->orientation[2], p->orientation[3]},
                       {p->position[0], p->position[1], p->position[2]}};
}

hmdwarp_host_pose host_pose_from_warp(warp_pose p)
{
    return (hmdwarp_host_pose){{p.q.w, p.q.x, p.q.y, p.q.z}, {p.p.x, p.p.y, p.p.z}};
}

warp_camera host_camera_to_warp(const hmdwarp_host_camera *c)
{
    /* Sizes above WARP_MAX_SIDE become negative here only past INT_MAX; warp_camera_check refuses both. */
    return (warp_camera){(int)(c->width > WARP_MAX_SIDE ? WARP_MAX_SIDE + 1 : c->width),
                         (int)(c->height > WARP_MAX_SIDE ? WARP_MAX_SIDE + 1 : c->height),
                         c->tan_left, c->tan_right, c->tan_up, c->tan_down, c->near_z, c->far_z};
}

hmdwarp_host_camera host_camera_from_warp(const warp_camera *c)
{
    return (hmdwarp_host_camera){(uint32_t)c->width, (uint32_t)c->height, c->tan_left, c->tan_right, c->tan_up,
                                 c->tan_down, c->near_z, c->far_z};
}

void host_frame_scratch_free(host_frame_scratch *s)
{
    for (int e = 0; e < 2; e++) {
        warp_image_free(&s->f.color[e]);
        warp_image_free(&s->f.depth[e]);
        warp_image_free(&s->f.ids[e]);
        warp_image_free(&s->f.motion[e]);
        warp_image_layers_free(&s->f.layers[e]);
    }
    memset(s, 0, sizeof *s);
}

/* Allocates the planes for this frame's sizes and layout unless the last frame had the same. */
static int scratch_fit(host_frame_scratch *s, const int w[2], const int h[2], unsigned planes, int max_layers)
{
    if (s->planes == planes && s->max_layers == max_layers && memcmp(s->w, w, sizeof s->w) == 0 &&
        memcmp(s->h, h, sizeof s->h) == 0)
        return HMDWARP_HOST_OK;
    host_frame_scratch_free(s);
    for (int e = 0; e < 2; e++) {
        bool ok = warp_image_rgba8_alloc(&s->f.color[e], w[e], h[e]);
        if (planes & DRV_PLANE_DEPTH) ok = ok && warp_image_f32_alloc(&s->f.depth[e], w[e], h[e]);
        if (planes & DRV_PLANE_IDS) ok = ok && warp_image_u16_alloc(&s->f.ids[e], w[e], h[e]);
        if (planes & DRV_PLANE_MOTION) ok = ok && warp_image_vec2f_alloc(&s->f.motion[e], w[e], h[e]);
        if (planes & DRV_PLANE_LAYERS) ok = ok && warp_image_layers_alloc(&s->f.layers[e], w[e], h[e], max_layers);
        if (!ok) {
            host_frame_scratch_free(s);
            return host_fail(HMDWARP_HOST_ERR_NO_MEMORY, "frame: out of memory for %dx%d eye planes", w[e], h[e]);
        }
    }
    memcpy(s->w, w, sizeof s->w);
    memcpy(s->h, h, sizeof s->h);
    s->planes = planes;
    s->max_layers = max_layers;
    return HMDWARP_HOST_OK;
}

/* A pose as the board will accept it: finite, unit quaternion (normalised here: the board allows 1e-3). */
static int check_pose(const hmdwarp_host_pose *in, const char *what, int idx, warp_pose *out)
{
    for (int i = 0; i < 4; i++)
        if (!isfinite(in->orientation[i]))
            return host_fail(HMDWARP_HOST_ERR_NOT_FINITE, "%s[%d].orientation[%d]: not finite", what, idx, i);
    for (int i = 0; i < 3; i++)
        if (!isfinite(in->position[i]))
            return host_fail(HMDWARP_HOST_ERR_NOT_FINITE, "%s[%d].position[%d]: not finite", what, idx, i);
    warp_pose p = host_pose_to_warp(in);
    double n = warp_quat_norm(p.q);
    if (fabs(n - 1.0) > 1e-3)
        return host_fail(HMDWARP_HOST_ERR_ARG, "%s[%d].orientation: not a unit quaternion (norm %g)", what, idx, n);
    warp_quat_normalize(p.q, &p.q);
    *out = p;
    return HMDWARP_HOST_OK;
}

static int check_time(int64_t t, const char *field)
{
    if (t < 0 || t > DRV_FRAMELINK_TIME_MAX_NS)
        return host_fail(HMDWARP_HOST_ERR_ARG, "frame.%s: %lld ns is outside [0, 2^62]", field, (long long)t);
    return HMDWARP_HOST_OK;
}

/* Bytes a row of w pixels takes, and the stride to use (0: packed); SIZE when the caller's is too small. */
static int row_stride(size_t given, int w, size_t bpp, int e, const char *field, size_t *out)
{
    size_t row = (size_t)w * bpp;
    if (given && given < row)
        return host_fail(HMDWARP_HOST_ERR_SIZE, "frame.eye[%d].%s_stride: %zu bytes < width %d * %zu", e, field, given,
                         w, bpp);
    *out = given ? given : row;
    return HMDWARP_HOST_OK;
}

static size_t color_bpp(hmdwarp_host_color_format f) { return f == HMDWARP_HOST_COLOR_RGB8 ? 3 : 4; }
static size_t depth_bpp(hmdwarp_host_depth_format f)
{
    return f == HMDWARP_HOST_DEPTH_STANDARD_UNORM16 || f == HMDWARP_HOST_DEPTH_REVERSED_UNORM16 ? 2 : 4;
}

static int convert_color(const hmdwarp_host_frame *in, int e, warp_image_rgba8 *dst)
{
    size_t stride = 0;
    int rc = row_stride(in->eye[e].color_stride, dst->w, color_bpp(in->color_format), e, "color", &stride);
    if (rc) return rc;
    const uint8_t *base = in->eye[e].color;
    for (int y = 0; y < dst->h; y++) {
        const uint8_t *s = base + (size_t)y * stride;
        warp_rgba8 *d = &WARP_AT(dst, 0, y);
        switch (in->color_format) {
        case HMDWARP_HOST_COLOR_RGBA8: memcpy(d, s, (size_t)dst->w * 4); break;
        case HMDWARP_HOST_COLOR_BGRA8:
            for (int x = 0; x < dst->w; x++, s += 4) d[x] = (warp_rgba8){s[2], s[1], s[0], s[3]};
            break;
        case HMDWARP_HOST_COLOR_RGB8:
            for (int x = 0; x < dst->w; x++, s += 3) d[x] = (warp_rgba8){s[0], s[1], s[2], 255};
            break;
        case HMDWARP_HOST_COLOR_RGBX8:
            for (int x = 0; x < dst->w; x++, s += 4) d[x] = (warp_rgba8){s[0], s[1], s[2], 255};
            break;
        }
    }
    return HMDWARP_HOST_OK;
}

static int convert_depth(const hmdwarp_host_frame *in, int e, const warp_camera *cam, warp_image_f32 *dst)
{
    size_t stride = 0;
    int rc = row_stride(in->eye[e].depth_stride, dst->w, depth_bpp(in->depth_format), e, "depth", &stride);
    if (rc) return rc;
    const uint8_t *base = in->eye[e].depth;
    hmdwarp_host_depth_format fmt = in->depth_format;
    for (int y = 0; y < dst->h; y++) {
        const uint8_t *row = base + (size_t)y * stride;
        for (int x = 0; x < dst->w; x++) {
            float v;
            if (depth_bpp(fmt) == 2) {
                uint16_t u;
                memcpy(&u, row + (size_t)x * 2, 2);
                /* The wire's UNORM16 is round(d * 65535): d = u / 65535 comes back as u exactly (the error of the
                 * float quotient times 65535 stays far below 0.5). */
                WARP_AT(dst, x, y) = (float)(u / 65535.0);
                continue;
            }
            memcpy(&v, row + (size_t)x * 4, 4);
            if (isnan(v))
                return host_fail(HMDWARP_HOST_ERR_NOT_FINITE, "frame.eye[%d].depth: NaN at pixel (%d, %d)", e, x, y);
            if (fmt == HMDWARP_HOST_DEPTH_LINEAR_F32 || fmt == HMDWARP_HOST_DEPTH_RAY_F32) {
                if (!(v > 0))
                    return host_fail(HMDWARP_HOST_ERR_FORMAT,
                                     "frame.eye[%d].depth: %g at pixel (%d, %d) is not a distance in metres (> 0, "
                                     "+inf for sky)", e, (double)v, x, y);
                if (fmt == HMDWARP_HOST_DEPTH_RAY_F32 && isfinite(v)) {
                    /* Distance along the ray through the pixel centre -> planar z: r / |(u, v, 1)|. */
                    double u, t;
                    warp_camera_pixel_to_tan(cam, x + 0.5, y + 0.5, &u, &t);
                    v = (float)(v / sqrt(1.0 + u * u + t * t));
                }
            } else {
                if (isinf(v))
                    return host_fail(HMDWARP_HOST_ERR_NOT_FINITE, "frame.eye[%d].depth: infinite window depth at "
                                     "pixel (%d, %d)", e, x, y);
                if (v < 0 || v > 1)
                    return host_fail(HMDWARP_HOST_ERR_FORMAT, "frame.eye[%d].depth: window depth %g at pixel (%d, %d) "
                                     "is outside [0, 1] (wrong depth_format?)", e, (double)v, x, y);
            }
            WARP_AT(dst, x, y) = v;
        }
    }
    return HMDWARP_HOST_OK;
}

static int convert_ids(const hmdwarp_host_frame *in, int e, warp_image_u16 *dst)
{
    size_t stride = 0;
    int rc = row_stride(in->eye[e].ids_stride, dst->w, 2, e, "ids", &stride);
    if (rc) return rc;
    for (int y = 0; y < dst->h; y++)
        memcpy(&WARP_AT(dst, 0, y), (const uint8_t *)in->eye[e].ids + (size_t)y * stride, (size_t)dst->w * 2);
    return HMDWARP_HOST_OK;
}

static int convert_motion(const hmdwarp_host_frame *in, int e, warp_image_vec2f *dst)
{
    size_t stride = 0;
    int rc = row_stride(in->eye[e].motion_stride, dst->w, 8, e, "motion", &stride);
    if (rc) return rc;
    for (int y = 0; y < dst->h; y++) {
        const uint8_t *row = (const uint8_t *)in->eye[e].motion + (size_t)y * stride;
        for (int x = 0; x < dst->w; x++) {
            warp_vec2f m;
            memcpy(&m, row + (size_t)x * 8, 8);
            if (!isfinite(m.x) || !isfinite(m.y))
                return host_fail(HMDWARP_HOST_ERR_NOT_FINITE, "frame.eye[%d].motion: not finite at pixel (%d, %d)", e,
                                 x, y);
            WARP_AT(dst, x, y) = m;
        }
    }
    return HMDWARP_HOST_OK;
}

/* The deepest pixel's count and the sum of the counts; SIZE when the sum is not n_fragments. */
static int scan_layers(const hmdwarp_host_eye *eye, int e, int w, int h, int *deepest)
{
    size_t stride = 0, sum = 0;
    int rc = row_stride(eye->layer_count_stride, w, 1, e, "layer_count", &stride);
    if (rc) return rc;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            uint8_t c = eye->layer_count[(size_t)y * stride + (size_t)x];
            sum += c;
            if (c > *deepest) *deepest = c;
        }
    if (sum != eye->n_fragments)
        return host_fail(HMDWARP_HOST_ERR_SIZE, "frame.eye[%d].n_fragments: %zu, but layer_count adds up to %zu", e,
                         eye->n_fragments, sum);
    if (sum && !eye->fragments) return host_fail(HMDWARP_HOST_ERR_ARG, "frame.eye[%d].fragments: NULL", e);
    return HMDWARP_HOST_OK;
}

static int convert_layers(const hmdwarp_host_eye *eye, int e, warp_image_layers *dst)
{
    size_t stride = eye->layer_count_stride ? eye->layer_count_stride : (size_t)dst->w, k = 0;
    for (int y = 0; y < dst->h; y++)
        for (int x = 0; x < dst->w; x++) {
            size_t i = (size_t)y * (size_t)dst->w + (size_t)x;
            uint8_t c = eye->layer_count[(size_t)y * stride + (size_t)x];
            dst->count[i] = c;
            for (int j = 0; j < c; j++, k++) {
                const hmdwarp_host_fragment *s = &eye->fragments[k];
                if (!isfinite(s->z))
                    return host_fail(HMDWARP_HOST_ERR_NOT_FINITE, "frame.eye[%d].fragments[%zu].z: not finite", e, k);
                if (!(s->z > 0))
                    return host_fail(HMDWARP_HOST_ERR_FORMAT, "frame.eye[%d].fragments[%zu].z: %g is not a distance "
                                     "in metres (> 0)", e, k, (double)s->z);
                dst->frag[i * (size_t)dst->max_layers + (size_t)j] =
                    (warp_fragment){s->z, {s->rgba[0], s->rgba[1], s->rgba[2], s->rgba[3]}, s->id};
            }
        }
    return HMDWARP_HOST_OK;
}

static void plane_list(unsigned planes, char *buf, size_t len)
{
    buf[0] = 0;
    for (int i = 0; i < 5; i++)
        if (planes & (1u << i))
            snprintf(buf + strlen(buf), len - strlen(buf), "%s%s", buf[0] ? "," : "", plane_names[i]);
}

static int build_cameras(const hmdwarp_host_frame *in, const host_frame_ctx *ctx, warp_camera cam[2])
{
    for (int e = 0; e < 2; e++) {
        if (in->eye[e].camera.width) {
            cam[e] = host_camera_to_warp(&in->eye[e].camera);
            const char *why = warp_camera_check(&cam[e]);
            if (why) return host_fail(HMDWARP_HOST_ERR_ARG, "frame.eye[%d].camera: %s", e, why);
            if (ctx->cams && ctx->cams_from_board &&
                (in->eye[e].camera.width != ctx->cams->cam[e].width ||
                 in->eye[e].camera.height != ctx->cams->cam[e].height))
                return host_fail(HMDWARP_HOST_ERR_SIZE, "frame.eye[%d].camera: %ux%u, the board's eye is %ux%u", e,
                                 in->eye[e].camera.width, in->eye[e].camera.height, ctx->cams->cam[e].width,
                                 ctx->cams->cam[e].height);
        } else if (ctx->cams) {
            cam[e] = host_camera_to_warp(&ctx->cams->cam[e]);
        } else {
            return host_fail(HMDWARP_HOST_ERR_NO_CAMERAS, "frame.eye[%d].camera: not given, and the board has sent no "
                             "camera message (hmdwarp_host_wait_cameras, or hmdwarp_host_set_cameras)", e);
        }
    }
    bool window = in->depth_format >= HMDWARP_HOST_DEPTH_STANDARD_F32;
    if (window && (in->depth_near != 0 || in->depth_far != 0)) {
        if (!(in->depth_near > 0) || !isfinite(in->depth_near) || !(in->depth_far > in->depth_near))
            return host_fail(HMDWARP_HOST_ERR_ARG, "frame.depth_near/depth_far: %g / %g (want 0 < near < far, far may "
                             "be +inf)", in->depth_near, in->depth_far);
        /* The wire's camera carries the planes the window depth was written with: the board decodes with those. */
        for (int e = 0; e < 2; e++) cam[e].near_z = in->depth_near, cam[e].far_z = in->depth_far;
    }
    return HMDWARP_HOST_OK;
}

static int build_planes(const hmdwarp_host_frame *in, const host_frame_ctx *ctx, unsigned *planes)
{
    for (int e = 0; e < 2; e++)
        if (!in->eye[e].color) return host_fail(HMDWARP_HOST_ERR_ARG, "frame.eye[%d].color: NULL (colour is required)", e);
    *planes = DRV_PLANE_COLOR;
    if (in->depth_format != HMDWARP_HOST_DEPTH_NONE) *planes |= DRV_PLANE_DEPTH;
    const void *p[2][4];
    for (int e = 0; e < 2; e++) {
        p[e][0] = in->eye[e].depth, p[e][1] = in->eye[e].ids, p[e][2] = in->eye[e].motion;
        p[e][3] = in->eye[e].layer_count;
    }
    static const char *const field[4] = {"depth", "ids", "motion", "layer_count"};
    for (int i = 0; i < 4; i++) {
        if (!p[0][i] != !p[1][i])
            return host_fail(HMDWARP_HOST_ERR_ARG, "frame.eye[%d].%s: NULL while eye[%d].%s is given", p[0][i] ? 1 : 0,
                             field[i], p[0][i] ? 0 : 1, field[i]);
        if (i == 0) {
            if (!p[0][0] && in->depth_format != HMDWARP_HOST_DEPTH_NONE)
                return host_fail(HMDWARP_HOST_ERR_ARG, "frame.eye[0].depth: NULL, but depth_format is %d",
                                 in->depth_format);
            if (p[0][0] && in->depth_format == HMDWARP_HOST_DEPTH_NONE)
                return host_fail(HMDWARP_HOST_ERR_ARG, "frame.depth_format: NONE, but eye[].depth is given");
        } else if (p[0][i]) {
            *planes |= 1u << (i + 1);
        }
    }
    if (ctx->cams && ctx->cams_from_board && (*planes & ~ctx->cams->planes)) {
        char want[64], have[64];
        plane_list(*planes & ~ctx->cams->planes, want, sizeof want);
        plane_list(ctx->cams->planes, have, sizeof have);
        return host_fail(HMDWARP_HOST_ERR_FORMAT, "frame: the board does not accept the %s plane (its camera message "
                         "allows %s)", want, have);
    }
    return HMDWARP_HOST_OK;
}

int host_frame_build(host_frame_scratch *s, const hmdwarp_host_frame *in, const host_frame_ctx *ctx,
                     drv_framelink_tx *tx)
{
    if (!in) return host_fail(HMDWARP_HOST_ERR_ARG, "frame: NULL");
    if (in->color_format < HMDWARP_HOST_COLOR_RGBA8 || in->color_format > HMDWARP_HOST_COLOR_RGBX8)
        return host_fail(HMDWARP_HOST_ERR_FORMAT, "frame.color_format: %d is not a hmdwarp_host_color_format",
                         (int)in->color_format);
    if (in->depth_format < HMDWARP_HOST_DEPTH_NONE || in->depth_format > HMDWARP_HOST_DEPTH_REVERSED_UNORM16)
        return host_fail(HMDWARP_HOST_ERR_FORMAT, "frame.depth_format: %d is not a hmdwarp_host_depth_format",
                         (int)in->depth_format);
    bool window = in->depth_format >= HMDWARP_HOST_DEPTH_STANDARD_F32;
    if (in->depth_unorm16 && !window)
        return host_fail(HMDWARP_HOST_ERR_FORMAT, "frame.depth_unorm16: only window depth (standard or reversed) can "
                         "be sent as 16 bits");
    warp_camera cam[2];
    unsigned planes = 0;
    int rc = build_cameras(in, ctx, cam);
    if (!rc) rc = build_planes(in, ctx, &planes);
    if (rc) return rc;

    /* Poses and times: the echoed message's, or the caller's own. */
    warp_pose eye_pose[2];
    for (int e = 0; e < 2; e++) {
        const hmdwarp_host_pose *p = &in->eye[e].pose;
        bool given = p->orientation[0] != 0 || p->orientation[1] != 0 || p->orientation[2] != 0 ||
                     p->orientation[3] != 0;
        if (given) {
            rc = check_pose(p, "frame.eye", e, &eye_pose[e]);
            if (rc) return rc;
        } else if (ctx->echo) {
            eye_pose[e] = ctx->echo->eye[e];
        } else {
            return host_fail(HMDWARP_HOST_ERR_ARG, "frame.eye[%d].pose: not set (orientation all 0) and pose_seq is 0",
                             e);
        }
    }
    int64_t now = hmdwarp_host_now_ns();
    memset(tx, 0, sizeof *tx);
    int64_t pose_t = in->pose_target_ns;
    if (ctx->echo) {
        pose_t = ctx->echo->target_t_ns;
        tx->pose_sent_ns = ctx->echo->board_t_ns;
        tx->host_pose_rx_ns = ctx->echo_rx_ns;
    } else {
        tx->pose_sent_ns = in->pose_board_ns;
        tx->host_pose_rx_ns = in->pose_received_ns;
        if ((rc = check_time(in->pose_target_ns, "pose_target_ns")) || (rc = check_time(in->pose_board_ns, "pose_board_ns")) ||
            (rc = check_time(in->pose_received_ns, "pose_received_ns")))
            return rc;
    }
    if ((rc = check_time(in->render_start_ns, "render_start_ns")) || (rc = check_time(in->render_end_ns, "render_end_ns")))
        return rc;
    tx->host_render_start_ns = in->render_start_ns;
    tx->host_render_end_ns = in->render_end_ns ? in->render_end_ns : now;
    tx->host_send_ns = now;
    if (!isfinite(in->scene_time)) return host_fail(HMDWARP_HOST_ERR_NOT_FINITE, "frame.scene_time: not finite");
    if (in->n_objects > DRV_MAX_OBJECTS)
        return host_fail(HMDWARP_HOST_ERR_SIZE, "frame.n_objects: %u > %d", in->n_objects, DRV_MAX_OBJECTS);
    if (in->n_objects && !in->object_poses)
        return host_fail(HMDWARP_HOST_ERR_ARG, "frame.object_poses: NULL with n_objects %u", in->n_objects);
    warp_pose objects[DRV_MAX_OBJECTS];
    for (unsigned i = 0; i < in->n_objects; i++)
        if ((rc = check_pose(&in->object_poses[i], "frame.object_poses", (int)i, &objects[i]))) return rc;

    int w[2] = {cam[0].width, cam[1].width}, h[2] = {cam[0].height, cam[1].height}, deepest = 0;
    if (planes & DRV_PLANE_LAYERS)
        for (int e = 0; e < 2; e++)
            if ((rc = scan_layers(&in->eye[e], e, w[e], h[e], &deepest))) return rc;
    /* The allocation keeps the deepest count seen, so frames of varying depth complexity reuse it. */
    if (s->planes == planes && deepest < s->max_layers) deepest = s->max_layers;
    if ((rc = scratch_fit(s, w, h, planes, deepest > 0 ? deepest : 1))) return rc;

    drv_frame *f = &s->f;
    for (int e = 0; e < 2; e++) {
        if ((rc = convert_color(in, e, &f->color[e]))) return rc;
        if ((planes & DRV_PLANE_DEPTH) && (rc = convert_depth(in, e, &cam[e], &f->depth[e]))) return rc;
        if ((planes & DRV_PLANE_IDS) && (rc = convert_ids(in, e, &f->ids[e]))) return rc;
        if ((planes & DRV_PLANE_MOTION) && (rc = convert_motion(in, e, &f->motion[e]))) return rc;
        if ((planes & DRV_PLANE_LAYERS) && (rc = convert_layers(&in->eye[e], e, &f->layers[e]))) return rc;
        f->cam[e] = cam[e];
        f->eye_pose[e] = eye_pose[e];
    }
    f->seq = ctx->seq;
    f->pose_t_ns = pose_t;
    f->planes = planes;
    f->depth_encoding = in->depth_format == HMDWARP_HOST_DEPTH_STANDARD_F32 ||
                                in->depth_format == HMDWARP_HOST_DEPTH_STANDARD_UNORM16
                            ? WARP_DEPTH_STANDARD
                        : window ? WARP_DEPTH_REVERSED
                                 : WARP_DEPTH_LINEAR;
    f->n_objects = (int)in->n_objects;
    memcpy(f->object_pose, objects, sizeof(warp_pose) * in->n_objects);
    f->scene_time = in->scene_time;
    if (planes & DRV_PLANE_DEPTH)
        tx->depth_format = in->depth_unorm16 || depth_bpp(in->depth_format) == 2 ? DRV_FRAMELINK_FMT_UNORM16
                                                                                  : DRV_FRAMELINK_FMT_F32;
    return HMDWARP_HOST_OK;
}
