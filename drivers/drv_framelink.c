/* SPDX-License-Identifier: MIT */
/* drv_framelink: the frame wire protocol between host and board (one codec for both ends): frames host -> board,
 * pose messages board -> host. Little-endian, versioned, CRC32-checked; byte layout in docs/framelink.md. */
#include "drivers/drv_framelink.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>
#include <zlib.h>
#include <zstd.h>

#include "drivers/drv_codec.h"
#include "drivers/drv_codec_depth.h"
#include "drivers/drv_framelink_wire.h"

/* ---- little-endian primitives (explicit bytes: the wire layout never depends on the compiler's structs) ---- */

static void put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}
static void put_u32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++) p[i] = (uint8_t)(v >> (8 * i));
}
static void put_u64(uint8_t *p, uint64_t v)
{
    for (int i = 0; i < 8; i++) p[i] = (uint8_t)(v >> (8 * i));
}
static void put_f32(uint8_t *p, float f)
{
    uint32_t v;
    memcpy(&v, &f, 4);
    put_u32(p, v);
}
static void put_f64(uint8_t *p, double d)
{
    uint64_t v;
    memcpy(&v, &d, 8);
    put_u64(p, v);
}
static uint16_t get_u16(const uint8_t *p) { return (uint16_t)(p[0] | (p[1] << 8)); }
static uint32_t get_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}
static uint64_t get_u64(const uint8_t *p) { return (uint64_t)get_u32(p) | ((uint64_t)get_u32(p + 4) << 32); }
static float get_f32(const uint8_t *p)
{
    uint32_t v = get_u32(p);
    float f;
    memcpy(&f, &v, 4);
    return f;
}
static double get_f64(const uint8_t *p)
{
    uint64_t v = get_u64(p);
    double d;
    memcpy(&d, &v, 8);
    return d;
}

static uint32_t crc(const uint8_t *p, size_t n) { return (uint32_t)crc32_z(0, p, n); }

static void put_pose(uint8_t *p, warp_pose a)
{
    const double v[7] = {a.q.w, a.q.x, a.q.y, a.q.z, a.p.x, a.p.y, a.p.z};
    for (int i = 0; i < 7; i++) put_f64(p + 8 * i, v[i]);
}
static warp_pose get_pose(const uint8_t *p)
{
    warp_pose a;
    a.q.w = get_f64(p);
    a.q.x = get_f64(p + 8);
    a.q.y = get_f64(p + 16);
    a.q.z = get_f64(p + 24);
    a.p.x = get_f64(p + 32);
    a.p.y = get_f64(p + 40);
    a.p.z = get_f64(p + 48);
    return a;
}

static bool pose_ok(warp_pose a) { return warp_pose_isfinite(a) && fabs(warp_quat_norm(a.q) - 1.0) <= 1e-3; }
/* A camera on the wire (56 bytes): width, height u32, then the tangents, near and far (f64). */
static void put_camera(uint8_t *p, const warp_camera *c)
{
    put_u32(p, (uint32_t)c->width);
    put_u32(p + 4, (uint32_t)c->height);
    const double v[6] = {c->tan_left, c->tan_right, c->tan_up, c->tan_down, c->near_z, c->far_z};
    for (int i = 0; i < 6; i++) put_f64(p + 8 + 8 * i, v[i]);
}
/* The tangents, near and far of a wire camera (the size is read and checked by the caller). */
static void get_camera_frustum(const uint8_t *p, warp_camera *c)
{
    c->tan_left = get_f64(p + 8);
    c->tan_right = get_f64(p + 16);
    c->tan_up = get_f64(p + 24);
    c->tan_down = get_f64(p + 32);
    c->near_z = get_f64(p + 40);
    c->far_z = get_f64(p + 48);
}

static bool time_ok(int64_t t) { return t >= 0 && t <= DRV_FRAMELINK_TIME_MAX_NS; }

/* ---- frame layout ---- */

enum {
    OFF_MAGIC = 0, OFF_VERSION = 4, OFF_HEADER_SIZE = 6, OFF_TOTAL = 8, OFF_PLANES = 12, OFF_SEQ = 16,
    OFF_POSE_T = 24, OFF_POSE_SENT = 32, OFF_HOST_POSE_RX = 40, OFF_HOST_START = 48, OFF_HOST_END = 56,
    OFF_HOST_SEND = 64, OFF_DEPTH_ENC = 72, OFF_N_OBJECTS = 74, OFF_N_PLANES = 76, OFF_RESERVED = 78,
    OFF_SCENE_TIME = 80, OFF_EYES = 88, EYE_BYTES = 112, EYE_CAM = 56,
};
/* Plane descriptor: v1's reserved u32 at 12 carries v2's codec, flags, scale and slices bytes. */
enum { DESC_CODEC = 12, DESC_FLAGS = 13, DESC_SCALE = 14, DESC_SLICES = 15 };
/* depth_encoding travels as the warp_depth_encoding value itself; docs/framelink.md numbers it for hosts */
_Static_assert(WARP_DEPTH_LINEAR == 0 && WARP_DEPTH_STANDARD == 1 && WARP_DEPTH_REVERSED == 2,
               "framelink's depth_encoding values (docs/framelink.md) are warp_depth_encoding's");
#define MAX_DIM WARP_MAX_SIDE
#define FRAG_BYTES 10
#define MAX_DEPTH_SCALE 2

static size_t header_bytes(int n_objects, int n_planes)
{
    return DRV_FRAMELINK_FIXED_BYTES + (size_t)n_objects * DRV_FRAMELINK_OBJECT_BYTES +
           (size_t)n_planes * DRV_FRAMELINK_PLANE_DESC_BYTES + 4;
}
size_t drv_framelink_header_size(int n_objects, int n_planes) { return header_bytes(n_objects, n_planes); }

static int bytes_per_pixel(int format)
{
    switch (format) {
    case DRV_FRAMELINK_FMT_RGBA8: return 4;
    case DRV_FRAMELINK_FMT_F32: return 4;
    case DRV_FRAMELINK_FMT_UNORM16: return 2;
    case DRV_FRAMELINK_FMT_INV16: return 2;
    case DRV_FRAMELINK_FMT_U16: return 2;
    case DRV_FRAMELINK_FMT_VEC2F32: return 8;
    default: return 0;
    }
}
int drv_framelink_format_bpp(int format) { return bytes_per_pixel(format); }

/* Which formats each plane type (DRV_PLANE_* bit index) may use; INV16 is version 2's. */
static bool format_ok(int type, int format, int version)
{
    switch (type) {
    case 0: return format == DRV_FRAMELINK_FMT_RGBA8;
    case 1:
        return format == DRV_FRAMELINK_FMT_F32 || format == DRV_FRAMELINK_FMT_UNORM16 ||
               (version >= DRV_FRAMELINK_VERSION_2 && format == DRV_FRAMELINK_FMT_INV16);
    case 2: return format == DRV_FRAMELINK_FMT_U16;
    case 3: return format == DRV_FRAMELINK_FMT_VEC2F32;
    case 4: return format == DRV_FRAMELINK_FMT_FRAGMENTS;
    default: return false;
    }
}

/* Which codecs each plane type may be sent with (version 2). */
static bool codec_ok(int type, int codec)
{
    if (codec == DRV_CODEC_RAW) return true;
    if (type == 0) return codec == DRV_CODEC_JPEG || codec == DRV_CODEC_H264 || codec == DRV_CODEC_HEVC;
    return codec == DRV_CODEC_ZSTD;
}
static bool codec_video(int codec) { return codec == DRV_CODEC_H264 || codec == DRV_CODEC_HEVC; }

static int plane_format(int type, const drv_framelink_tx *tx)
{
    switch (type) {
    case 0: return DRV_FRAMELINK_FMT_RGBA8;
    case 1: return tx && tx->depth_format ? tx->depth_format : DRV_FRAMELINK_FMT_F32;
    case 2: return DRV_FRAMELINK_FMT_U16;
    case 3: return DRV_FRAMELINK_FMT_VEC2F32;
    default: return DRV_FRAMELINK_FMT_FRAGMENTS;
    }
}

/* Width and height of plane `type` of eye e as allocated in f (0 x 0 when not allocated). */
static void plane_dims(const drv_frame *f, int type, int e, int *w, int *h, bool *allocated)
{
    switch (type) {
    case 0: *w = f->color[e].w, *h = f->color[e].h, *allocated = f->color[e].px != NULL; break;
    case 1: *w = f->depth[e].w, *h = f->depth[e].h, *allocated = f->depth[e].px != NULL; break;
    case 2: *w = f->ids[e].w, *h = f->ids[e].h, *allocated = f->ids[e].px != NULL; break;
    case 3: *w = f->motion[e].w, *h = f->motion[e].h, *allocated = f->motion[e].px != NULL; break;
    default:
        *w = f->layers[e].w, *h = f->layers[e].h;
        *allocated = f->layers[e].count != NULL && f->layers[e].frag != NULL;
        break;
    }
}

static size_t layers_eye_bytes(const warp_image_layers *l)
{
    size_t n = (size_t)l->w * (size_t)l->h, frags = 0;
    for (size_t i = 0; i < n; i++) frags += l->count[i] < l->max_layers ? l->count[i] : (size_t)l->max_layers;
    return n + frags * FRAG_BYTES;
}

/* The most fragments any pixel of either eye sends (the layers descriptor's parameter). */
int drv_framelink_layers_deepest(const drv_frame *f)
{
    int m = 0;
    for (int e = 0; e < 2; e++) {
        const warp_image_layers *l = &f->layers[e];
        for (size_t i = 0, n = (size_t)l->w * (size_t)l->h; i < n; i++) {
            int c = l->count[i] < l->max_layers ? l->count[i] : l->max_layers;
            if (c > m) m = c;
        }
    }
    return m;
}

size_t drv_framelink_eye_bytes(const drv_frame *f, int type, int format, int e)
{
    if (type == 4) return layers_eye_bytes(&f->layers[e]);
    return (size_t)f->cam[e].width * (size_t)f->cam[e].height * (size_t)bytes_per_pixel(format);
}

/* Plane payload sizes of f (both eyes) as version 1 sends them, or false when f cannot be encoded. */
static bool plan(const drv_frame *f, const drv_framelink_tx *tx, size_t sizes[DRV_FRAMELINK_MAX_PLANES],
                 int *n_planes)
{
    if (!(f->planes & DRV_PLANE_COLOR) || (f->planes & ~0x1Fu)) return false;
    if (f->n_objects < 0 || f->n_objects > DRV_MAX_OBJECTS) return false;
    if ((unsigned)f->depth_encoding > WARP_DEPTH_REVERSED) return false;
    if (tx && tx->depth_format && tx->depth_format != DRV_FRAMELINK_FMT_F32) {
        if (tx->depth_format != DRV_FRAMELINK_FMT_UNORM16) return false;
        /* Metres do not fit a unit interval: unorm16 carries window depth only. */
        if ((f->planes & DRV_PLANE_DEPTH) && f->depth_encoding == WARP_DEPTH_LINEAR) return false;
    }
    *n_planes = 0;
    for (int t = 0; t < DRV_FRAMELINK_MAX_PLANES; t++) {
        sizes[t] = 0;
        if (!(f->planes & (1u << t))) continue;
        (*n_planes)++;
        for (int e = 0; e < 2; e++) {
            int w, h;
            bool allocated;
            plane_dims(f, t, e, &w, &h, &allocated);
            if (!allocated || w != f->cam[e].width || h != f->cam[e].height || w <= 0 || h <= 0 || w > MAX_DIM ||
                h > MAX_DIM)
                return false;
            sizes[t] += drv_framelink_eye_bytes(f, t, plane_format(t, tx), e);
        }
    }
    return true;
}

size_t drv_framelink_size_ex(const drv_frame *f, const drv_framelink_tx *tx)
{
    size_t sizes[DRV_FRAMELINK_MAX_PLANES];
    int n_planes;
    if (!plan(f, tx, sizes, &n_planes)) return 0;
    size_t total = header_bytes(f->n_objects, n_planes) + 4;
    for (int t = 0; t < DRV_FRAMELINK_MAX_PLANES; t++) total += sizes[t];
    return total > UINT32_MAX ? 0 : total;
}

size_t drv_framelink_size(const drv_frame *f) { return drv_framelink_size_ex(f, NULL); }

size_t drv_framelink_put_eye(const drv_frame *f, int t, int format, int e, uint8_t *p)
{
    uint8_t *start = p;
    int w = f->cam[e].width, h = f->cam[e].height;
    double near_z = f->cam[e].near_z;
    if (t == 0) { /* warp_rgba8 is r, g, b, a bytes: the wire's layout (asserted below), a row at a time */
        for (int y = 0; y < h; y++, p += (size_t)w * 4) memcpy(p, &WARP_AT(&f->color[e], 0, y), (size_t)w * 4);
        return (size_t)(p - start);
    }
    if (t == 1) { /* a loop per format: the per-pixel switch below cost more than the conversions */
        for (int y = 0; y < h; y++) {
            const float *d = &WARP_AT(&f->depth[e], 0, y);
            if (format == DRV_FRAMELINK_FMT_INV16)
                for (int x = 0; x < w; x++, p += 2) put_u16(p, drv_depth_to_inv16(d[x], near_z));
            else if (format == DRV_FRAMELINK_FMT_UNORM16) /* NaN (never valid depth) goes to far, as a cleared */
                for (int x = 0; x < w; x++, p += 2) put_u16(p, drv_depth_to_unorm16(d[x])); /* buffer holds */
            else
                for (int x = 0; x < w; x++, p += 4) put_f32(p, d[x]);
        }
        return (size_t)(p - start);
    }
    for (int y = 0; y < h && t != 4; y++) {
        for (int x = 0; x < w; x++) {
            switch (t) {
            case 2: put_u16(p, WARP_AT(&f->ids[e], x, y)); p += 2; break;
            case 3: {
                warp_vec2f m = WARP_AT(&f->motion[e], x, y);
                put_f32(p, m.x);
                put_f32(p + 4, m.y);
                p += 8;
                break;
            }
            default: break;
            }
        }
    }
    if (t == 4) {
        const warp_image_layers *l = &f->layers[e];
        size_t n = (size_t)w * (size_t)h;
        for (size_t i = 0; i < n; i++) *p++ = l->count[i] < l->max_layers ? l->count[i] : (uint8_t)l->max_layers;
        for (size_t i = 0; i < n; i++) {
            int c = l->count[i] < l->max_layers ? l->count[i] : l->max_layers;
            for (int k = 0; k < c; k++) {
                const warp_fragment *fr = &l->frag[i * (size_t)l->max_layers + (size_t)k];
                put_f32(p, fr->z);
                p[4] = fr->rgba.r, p[5] = fr->rgba.g, p[6] = fr->rgba.b, p[7] = fr->rgba.a;
                put_u16(p + 8, fr->id);
                p += FRAG_BYTES;
            }
        }
    }
    return (size_t)(p - start);
}

bool drv_framelink_finish(const drv_frame *f, const drv_framelink_tx *tx, int version, const drv_framelink_plane *pl,
                          int n_planes, uint8_t *buf, size_t total)
{
    size_t hdr = header_bytes(f->n_objects, n_planes);
    if (n_planes < 1 || n_planes > DRV_FRAMELINK_MAX_PLANES || total < hdr + 4 || total > UINT32_MAX) return false;
    memset(buf, 0, hdr);
    put_u32(buf + OFF_MAGIC, DRV_FRAMELINK_MAGIC);
    put_u16(buf + OFF_VERSION, (uint16_t)version);
    put_u16(buf + OFF_HEADER_SIZE, (uint16_t)hdr);
    put_u32(buf + OFF_TOTAL, (uint32_t)total);
    put_u32(buf + OFF_PLANES, f->planes);
    put_u64(buf + OFF_SEQ, f->seq);
    put_u64(buf + OFF_POSE_T, (uint64_t)f->pose_t_ns);
    if (tx) {
        put_u64(buf + OFF_POSE_SENT, (uint64_t)tx->pose_sent_ns);
        put_u64(buf + OFF_HOST_POSE_RX, (uint64_t)tx->host_pose_rx_ns);
        put_u64(buf + OFF_HOST_START, (uint64_t)tx->host_render_start_ns);
        put_u64(buf + OFF_HOST_END, (uint64_t)tx->host_render_end_ns);
        put_u64(buf + OFF_HOST_SEND, (uint64_t)tx->host_send_ns);
    }
    put_u16(buf + OFF_DEPTH_ENC, (uint16_t)f->depth_encoding);
    put_u16(buf + OFF_N_OBJECTS, (uint16_t)f->n_objects);
    put_u16(buf + OFF_N_PLANES, (uint16_t)n_planes);
    put_f64(buf + OFF_SCENE_TIME, f->scene_time);
    for (int e = 0; e < 2; e++) {
        uint8_t *p = buf + OFF_EYES + e * EYE_BYTES;
        put_pose(p, f->eye_pose[e]);
        put_camera(p + EYE_CAM, &f->cam[e]);
    }
    uint8_t *p = buf + DRV_FRAMELINK_FIXED_BYTES;
    for (int i = 0; i < f->n_objects; i++, p += DRV_FRAMELINK_OBJECT_BYTES) put_pose(p, f->object_pose[i]);
    for (int i = 0; i < n_planes; i++, p += DRV_FRAMELINK_PLANE_DESC_BYTES) {
        p[0] = (uint8_t)pl[i].type;
        p[1] = (uint8_t)pl[i].format;
        put_u16(p + 2, (uint16_t)pl[i].param);
        put_u32(p + 4, (uint32_t)pl[i].off);
        put_u32(p + 8, (uint32_t)pl[i].size);
        if (version >= DRV_FRAMELINK_VERSION_2) {
            p[DESC_CODEC] = (uint8_t)pl[i].codec;
            p[DESC_FLAGS] = (uint8_t)pl[i].flags;
            p[DESC_SCALE] = (uint8_t)pl[i].scale;
            p[DESC_SLICES] = (uint8_t)pl[i].slices;
        }
    }
    put_u32(buf + hdr - 4, crc(buf, hdr - 4));
    put_u32(buf + total - 4, crc(buf + hdr, total - hdr - 4));
    return true;
}

size_t drv_framelink_encode_ex(const drv_frame *f, const drv_framelink_tx *tx, uint8_t *buf, size_t cap)
{
    size_t sizes[DRV_FRAMELINK_MAX_PLANES];
    int n_planes;
    if (!plan(f, tx, sizes, &n_planes)) return 0;
    size_t hdr = header_bytes(f->n_objects, n_planes), total = drv_framelink_size_ex(f, tx);
    if (!total || total > cap) return 0;
    drv_framelink_plane pl[DRV_FRAMELINK_MAX_PLANES];
    int n = 0;
    size_t off = 0;
    uint8_t *p = buf + hdr;
    for (int t = 0; t < DRV_FRAMELINK_MAX_PLANES; t++) {
        if (!(f->planes & (1u << t))) continue;
        pl[n] = (drv_framelink_plane){.type = t, .format = plane_format(t, tx), .slices = 1, .off = off,
                                      .size = sizes[t]};
        pl[n].param = t == 4 ? (unsigned)drv_framelink_layers_deepest(f) : 0;
        for (int e = 0; e < 2; e++) p += drv_framelink_put_eye(f, t, pl[n].format, e, p);
        off += sizes[t];
        n++;
    }
    return drv_framelink_finish(f, tx, DRV_FRAMELINK_VERSION, pl, n, buf, total) ? total : 0;
}

size_t drv_framelink_encode(const drv_frame *f, uint8_t *buf, size_t cap)
{
    return drv_framelink_encode_ex(f, NULL, buf, cap);
}

/* ---- decoding ---- */

size_t drv_framelink_find_magic(const uint8_t *buf, size_t len)
{
    uint8_t m[4];
    put_u32(m, DRV_FRAMELINK_MAGIC);
    for (size_t i = 0; i < len; i++) {
        size_t n = len - i < 4 ? len - i : 4;
        if (memcmp(buf + i, m, n) == 0) return i;
    }
    return len;
}

/* The header checks shared by peek and decode. */
static drv_frame_err check_header(const uint8_t *buf, size_t len, size_t max_frame, size_t *need, char *detail,
                                  int dlen)
{
    uint8_t m[4];
    put_u32(m, DRV_FRAMELINK_MAGIC);
    size_t n = len < 4 ? len : 4;
    if (memcmp(buf, m, n) != 0) return drv_frame_fail(detail, dlen, DRV_FRAME_ERR_BAD_MAGIC,
                                                      "no frame magic at the start");
    *need = DRV_FRAMELINK_PREFIX_BYTES;
    if (len < 6) return drv_frame_fail(detail, dlen, DRV_FRAME_ERR_TRUNCATED, "%zu bytes: no version yet", len);
    unsigned version = get_u16(buf + OFF_VERSION);
    if (version < DRV_FRAMELINK_VERSION || version > DRV_FRAMELINK_VERSION_MAX)
        return drv_frame_fail(detail, dlen, DRV_FRAME_ERR_BAD_VERSION, "version %u (this build reads %d to %d)",
                              version, DRV_FRAMELINK_VERSION, DRV_FRAMELINK_VERSION_MAX);
    if (len < DRV_FRAMELINK_PREFIX_BYTES)
        return drv_frame_fail(detail, dlen, DRV_FRAME_ERR_TRUNCATED, "%zu bytes: header prefix incomplete", len);
    size_t hdr = get_u16(buf + OFF_HEADER_SIZE);
    if (hdr < header_bytes(0, 1) || hdr > DRV_FRAMELINK_MAX_HEADER)
        return drv_frame_fail(detail, dlen, DRV_FRAME_ERR_BAD_SIZE, "header size %zu outside [%zu, %d]", hdr,
                              header_bytes(0, 1), DRV_FRAMELINK_MAX_HEADER);
    *need = hdr;
    if (len < hdr) return drv_frame_fail(detail, dlen, DRV_FRAME_ERR_TRUNCATED, "%zu of %zu header bytes", len, hdr);
    uint32_t want = get_u32(buf + hdr - 4), got = crc(buf, hdr - 4);
    if (want != got)
        return drv_frame_fail(detail, dlen, DRV_FRAME_ERR_CRC, "header CRC 0x%08x, computed 0x%08x", want, got);
    size_t total = get_u32(buf + OFF_TOTAL);
    if (total < hdr + 4) return drv_frame_fail(detail, dlen, DRV_FRAME_ERR_BAD_SIZE, "total size %zu < header %zu",
                                               total, hdr);
    *need = total; /* also on TOO_LARGE: a stream receiver skips exactly this many bytes */
    if (max_frame && total > max_frame)
        return drv_frame_fail(detail, dlen, DRV_FRAME_ERR_TOO_LARGE, "frame of %zu bytes, limit %zu", total, max_frame);
    *need = total;
    return DRV_FRAME_OK;
}

drv_frame_err drv_framelink_peek(const uint8_t *buf, size_t len, size_t max_frame, size_t *total)
{
    size_t need = DRV_FRAMELINK_PREFIX_BYTES;
    drv_frame_err e = check_header(buf, len, max_frame, &need, NULL, 0);
    if (total) *total = need;
    return e;
}

/* Layers of one eye: counts within the allocation and the fragments adding up; returns the eye's bytes or 0. */
size_t drv_framelink_layers_check(const uint8_t *p, size_t avail, int w, int h, int max_layers, int *deepest)
{
    size_t n = (size_t)w * (size_t)h, frags = 0;
    if (avail < n) return 0;
    for (size_t i = 0; i < n; i++) {
        if (p[i] > max_layers) return 0;
        if (p[i] > *deepest) *deepest = p[i];
        frags += p[i];
    }
    size_t bytes = n + frags * FRAG_BYTES;
    return bytes <= avail ? bytes : 0;
}

_Static_assert(sizeof(warp_rgba8) == 4 && offsetof(warp_rgba8, r) == 0 && offsetof(warp_rgba8, a) == 3,
               "colour planes are copied to and from the wire a row at a time");

void drv_framelink_get_eye(drv_frame *out, int type, int format, int e, int w, int h, double near_z,
                           const uint8_t *p)
{
    if (type == 0) {
        for (int y = 0; y < h; y++, p += (size_t)w * 4) memcpy(&WARP_AT(&out->color[e], 0, y), p, (size_t)w * 4);
        return;
    }
    if (type == 1) { /* a loop per format, as drv_framelink_put_eye */
        for (int y = 0; y < h; y++) {
            float *d = &WARP_AT(&out->depth[e], 0, y);
            if (format == DRV_FRAMELINK_FMT_INV16)
                for (int x = 0; x < w; x++, p += 2) d[x] = drv_depth_from_inv16(get_u16(p), near_z);
            else if (format == DRV_FRAMELINK_FMT_UNORM16)
                for (int x = 0; x < w; x++, p += 2) d[x] = drv_depth_from_unorm16(get_u16(p));
            else
                for (int x = 0; x < w; x++, p += 4) d[x] = get_f32(p);
        }
        return;
    }
    for (int y = 0; y < h && type != 4; y++) {
        for (int x = 0; x < w; x++) {
            switch (type) {
            case 2: WARP_AT(&out->ids[e], x, y) = get_u16(p); p += 2; break;
            case 3:
                WARP_AT(&out->motion[e], x, y).x = get_f32(p);
                WARP_AT(&out->motion[e], x, y).y = get_f32(p + 4);
                p += 8;
                break;
            default: break;
            }
        }
    }
    if (type == 4) {
        warp_image_layers *l = &out->layers[e];
        size_t n = (size_t)w * (size_t)h;
        const uint8_t *fp = p + n;
        for (size_t i = 0; i < n; i++) {
            l->count[i] = p[i];
            for (int k = 0; k < p[i]; k++) {
                warp_fragment *fr = &l->frag[i * (size_t)l->max_layers + (size_t)k];
                fr->z = get_f32(fp);
                fr->rgba.r = fp[4], fr->rgba.g = fp[5], fr->rgba.b = fp[6], fr->rgba.a = fp[7];
                fr->id = get_u16(fp + 8);
                fp += FRAG_BYTES;
            }
        }
    }
}

/* Rows padded up to whole 16 x 16 blocks: libjpeg-turbo's worst case is under 6 bytes a padded pixel (tjBufSize:
 * 4:4:4 takes 6, 4:2:0 3, plus 2048), whatever the quality. */
static size_t pad16(int v) { return ((size_t)v + 15) / 16 * 16; }

size_t drv_framelink_chunk_bound(const drv_framelink_plane *p, int w, int h, int slice, int max_layers)
{
    int sw = p->scale ? drv_depth_scaled(w, p->scale) : w, sh = p->scale ? drv_depth_scaled(h, p->scale) : h;
    size_t raw = p->type == 4 ? (size_t)w * (size_t)h * (1 + (size_t)max_layers * FRAG_BYTES)
                              : (size_t)sw * (size_t)sh * (size_t)bytes_per_pixel(p->format);
    switch (p->codec) {
    case DRV_CODEC_ZSTD: return ZSTD_COMPRESSBOUND(raw) + 64; /* + room for the checksum, whatever the version */
    case DRV_CODEC_JPEG: {
        int y0, y1;
        drv_framelink_slice_rows(h, slice, p->slices, &y0, &y1);
        return pad16(w) * pad16(y1 - y0) * 6 + 2048;
    }
    /* One access unit: at most the RGBA picture it replaces plus the parameter sets (a key frame at the finest
     * quantiser stays below 12 bits a pixel). */
    case DRV_CODEC_H264:
    case DRV_CODEC_HEVC: return raw + 65536;
    default: return raw;
    }
}

/* Bytes of the plane a RAW descriptor must declare, fixed-size formats (the depth plane at its scale). */
static size_t raw_plane_bytes(const drv_framelink_plane *d, const int w[2], const int h[2])
{
    size_t s = 0;
    for (int e = 0; e < 2; e++)
        s += (size_t)drv_depth_scaled(w[e], d->scale) * (size_t)drv_depth_scaled(h[e], d->scale) *
             (size_t)bytes_per_pixel(d->format);
    return s;
}

/* Descriptor i's version 2 bytes: codec known and allowed for the type, flags, scale and slices in range. */
static drv_frame_err check_desc_v2(drv_framelink_plane *d, const uint8_t *dp, int i, const int h[2], bool hooked,
                                   char *detail, int dl)
{
    d->codec = dp[DESC_CODEC], d->flags = dp[DESC_FLAGS], d->scale = dp[DESC_SCALE], d->slices = dp[DESC_SLICES];
    if (d->codec >= DRV_CODEC_COUNT)
        return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "plane %d: unknown codec %d", i, d->codec);
    if (!codec_ok(d->type, d->codec))
        return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "plane type %d: codec %s not allowed for it",
                              d->type, drv_codec_name((drv_codec_id)d->codec));
    if (d->flags & ~DRV_FRAMELINK_DESC_KEY || (d->flags && !codec_video(d->codec)))
        return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "plane type %d: flags 0x%x", d->type, d->flags);
    if (d->scale > MAX_DEPTH_SCALE || (d->scale && d->type != 1))
        return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "plane type %d: scale %d (depth only, 0..%d)",
                              d->type, d->scale, MAX_DEPTH_SCALE);
    int max_slices = d->codec == DRV_CODEC_JPEG ? DRV_FRAMELINK_MAX_SLICES : 1;
    if (d->slices < 1 || d->slices > max_slices)
        return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "plane type %d: %d slices (codec %s: 1..%d)",
                              d->type, d->slices, drv_codec_name((drv_codec_id)d->codec), max_slices);
    if (d->slices > h[0] || d->slices > h[1])
        return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_SIZE, "plane type %d: %d slices of %d and %d rows",
                              d->type, d->slices, h[0], h[1]);
    if (d->param && !(d->type == 4 || (d->type == 0 && codec_video(d->codec))))
        return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "plane type %d: parameter %u set", d->type,
                              d->param);
    if (drv_framelink_plane_coded(d) && !hooked)
        return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT,
                              "plane type %d: codec %s scale %d needs a drv_framelink_dec (drv_framelink_codec.h)",
                              d->type, drv_codec_name((drv_codec_id)d->codec), d->scale);
    return DRV_FRAME_OK;
}

/* A coded plane's chunk table (2 * slices u32 lengths, then the chunks): every length non-zero and within the
 * plane's bound, adding up to the plane. Fills d->chunk. */
static drv_frame_err check_chunks(drv_framelink_plane *d, const uint8_t *p, const int w[2], const int h[2],
                                  const drv_frame *out, char *detail, int dl)
{
    size_t table = 4 * 2 * (size_t)d->slices, sum = 0;
    const uint8_t *c = p + table;
    for (int e = 0; e < 2; e++)
        for (int k = 0; k < d->slices; k++) {
            int i = e * d->slices + k;
            size_t n = get_u32(p + 4 * i);
            size_t bound = drv_framelink_chunk_bound(d, w[e], h[e], k, out->layers[e].max_layers);
            if (n == 0 || n > bound)
                return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_SIZE,
                                      "plane type %d eye %d chunk %d: %zu bytes, bound %zu", d->type, e, k, n, bound);
            sum += n;
            if (sum > d->size - table)
                return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_SIZE,
                                      "plane type %d: chunks add up to more than its %zu bytes", d->type,
                                      d->size - table);
            d->chunk[i] = c;
            d->chunk_len[i] = n;
            c += n;
        }
    if (sum != d->size - table)
        return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_SIZE, "plane type %d: chunks add up to %zu, plane has %zu",
                              d->type, sum, d->size - table);
    return DRV_FRAME_OK;
}

drv_frame_err drv_framelink_decode_hooked(const uint8_t *buf, size_t len, size_t max_frame, drv_frame *out,
                                          drv_framelink_rx *rx, char *detail, int dl, const drv_framelink_hook *hook)
{
    size_t need;
    drv_frame_err err = check_header(buf, len, max_frame, &need, detail, dl);
    if (err) return err;
    int version = get_u16(buf + OFF_VERSION);
    size_t hdr = get_u16(buf + OFF_HEADER_SIZE), total = get_u32(buf + OFF_TOTAL);
    unsigned planes = get_u32(buf + OFF_PLANES);
    int depth_enc = get_u16(buf + OFF_DEPTH_ENC), n_obj = get_u16(buf + OFF_N_OBJECTS);
    int n_planes = get_u16(buf + OFF_N_PLANES);
    if (n_obj > DRV_MAX_OBJECTS)
        return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_SIZE, "%d objects (at most %d)", n_obj, DRV_MAX_OBJECTS);
    if (n_planes < 1 || n_planes > DRV_FRAMELINK_MAX_PLANES)
        return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_SIZE, "%d planes", n_planes);
    if (hdr != header_bytes(n_obj, n_planes))
        return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_SIZE,
                              "header size %zu but %d objects and %d planes need %zu", hdr, n_obj, n_planes,
                              header_bytes(n_obj, n_planes));
    if (get_u16(buf + OFF_RESERVED))
        return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "reserved header field set (a newer sender?)");
    if (depth_enc > WARP_DEPTH_REVERSED)
        return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "unknown depth encoding %d", depth_enc);
    drv_framelink_layout lay;
    memset(&lay, 0, sizeof lay);
    lay.version = version, lay.n_planes = n_planes, lay.depth_encoding = (warp_depth_encoding)depth_enc;
    int *w = lay.w, *h = lay.h;
    for (int e = 0; e < 2; e++) {
        const uint8_t *p = buf + OFF_EYES + e * EYE_BYTES + EYE_CAM;
        uint32_t cw = get_u32(p), ch = get_u32(p + 4);
        if (cw == 0 || ch == 0 || cw > MAX_DIM || ch > MAX_DIM)
            return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_SIZE, "eye %d is %ux%u", e, cw, ch);
        w[e] = (int)cw, h[e] = (int)ch;
        lay.near_z[e] = get_f64(p + 40);
    }

    /* Plane descriptors: known types in ascending order, each once, formats and codecs the type allows, allocated
     * on this side at the cameras' sizes, packed back to back, each within its bound, adding up to the payload. */
    drv_framelink_plane *pd = lay.pl;
    unsigned seen = 0;
    bool coded = false;
    size_t payload = total - hdr - 4, off = 0;
    const uint8_t *dp = buf + DRV_FRAMELINK_FIXED_BYTES + (size_t)n_obj * DRV_FRAMELINK_OBJECT_BYTES;
    for (int i = 0; i < n_planes; i++, dp += DRV_FRAMELINK_PLANE_DESC_BYTES) {
        drv_framelink_plane *d = &pd[i];
        d->type = dp[0], d->format = dp[1], d->param = get_u16(dp + 2);
        d->off = get_u32(dp + 4), d->size = get_u32(dp + 8);
        d->slices = 1;
        if (d->type >= DRV_FRAMELINK_MAX_PLANES || (seen >> d->type))
            return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "plane %d: type %d out of order or unknown", i,
                                  d->type);
        seen |= 1u << d->type;
        if (!format_ok(d->type, d->format, version))
            return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "plane type %d: format %d not supported%s",
                                  d->type, d->format, version < 2 ? " in version 1" : "");
        if (d->type == 1 && d->format == DRV_FRAMELINK_FMT_UNORM16 && depth_enc == WARP_DEPTH_LINEAR)
            return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "unorm16 depth with linear encoding");
        if (d->type == 1 && d->format == DRV_FRAMELINK_FMT_INV16 && depth_enc != WARP_DEPTH_LINEAR)
            return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "inv16 depth needs the linear encoding");
        if (version < DRV_FRAMELINK_VERSION_2) {
            if (d->type != 4 && d->param)
                return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "plane type %d: parameter %u set",
                                      d->type, d->param);
            if (get_u32(dp + 12))
                return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT,
                                      "plane type %d: reserved field set (codec bytes in a version 1 frame)", d->type);
        } else {
            drv_frame_err de = check_desc_v2(d, dp, i, h, hook != NULL, detail, dl);
            if (de) return de;
        }
        for (int e = 0; e < 2; e++) {
            int aw, ah;
            bool allocated;
            plane_dims(out, d->type, e, &aw, &ah, &allocated);
            if (!allocated)
                return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "plane type %d sent but not allocated here",
                                      d->type);
            if (aw != w[e] || ah != h[e])
                return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_SIZE, "eye %d is %dx%d, allocated %dx%d", e, w[e],
                                      h[e], aw, ah);
        }
        if (d->off != off)
            return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_SIZE, "plane type %d at offset %zu, expected %zu",
                                  d->type, d->off, off);
        if (d->codec == DRV_CODEC_RAW && d->type != 4) {
            size_t want = raw_plane_bytes(d, w, h);
            if (d->size != want)
                return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_SIZE,
                                      "plane type %d: %zu bytes, %dx%d eyes need %zu", d->type, d->size, w[0], h[0],
                                      want);
        } else if (d->codec != DRV_CODEC_RAW) {
            /* A chunk table and a byte a chunk at least, the chunks' bounds at most. */
            size_t lo = 5 * 2 * (size_t)d->slices, hi = 4 * 2 * (size_t)d->slices;
            for (int e = 0; e < 2; e++)
                for (int k = 0; k < d->slices; k++)
                    hi += drv_framelink_chunk_bound(d, w[e], h[e], k, out->layers[e].max_layers);
            if (d->size < lo || d->size > hi)
                return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_SIZE,
                                      "plane type %d (%s): %zu bytes, outside [%zu, %zu]", d->type,
                                      drv_codec_name((drv_codec_id)d->codec), d->size, lo, hi);
        }
        if (d->size > payload - off)
            return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_SIZE, "plane type %d overruns the payload", d->type);
        off += d->size;
        coded = coded || drv_framelink_plane_coded(d);
    }
    if (seen != planes)
        return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "plane mask 0x%x but descriptors for 0x%x", planes,
                              seen);
    if (!(planes & DRV_PLANE_COLOR)) return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "no colour plane");
    if (off != payload)
        return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_SIZE, "planes add up to %zu bytes, payload is %zu", off,
                              payload);
    if (len < total) return drv_frame_fail(detail, dl, DRV_FRAME_ERR_TRUNCATED, "%zu of %zu bytes", len, total);
    uint32_t want = get_u32(buf + total - 4), got = crc(buf + hdr, payload);
    if (want != got) return drv_frame_fail(detail, dl, DRV_FRAME_ERR_CRC, "payload CRC 0x%08x, computed 0x%08x", want,
                                           got);
    /* Chunk tables, and RAW layers (variable length): checked in full before anything is written. */
    for (int i = 0; i < n_planes; i++) {
        const uint8_t *p = buf + hdr + pd[i].off;
        pd[i].data = p;
        if (pd[i].codec != DRV_CODEC_RAW) {
            err = check_chunks(&pd[i], p, w, h, out, detail, dl);
            if (err) return err;
            continue;
        }
        if (pd[i].type != 4) continue;
        size_t left = pd[i].size;
        int deepest = 0;
        for (int e = 0; e < 2; e++) {
            int ml = out->layers[e].max_layers;
            size_t b = drv_framelink_layers_check(p, left, w[e], h[e], ml, &deepest);
            if (!b)
                return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_SIZE,
                                      "eye %d layers: counts above the %d allocated or fragments overrun the plane", e,
                                      ml);
            p += b, left -= b;
        }
        if (left) return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_SIZE, "layers plane has %zu bytes left over",
                                        left);
        if (deepest != (int)pd[i].param)
            return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_SIZE, "layers descriptor says %u deep, counts reach %d",
                                  pd[i].param, deepest);
    }

    /* Times and poses: the host's values must be usable as they are, the warps and the runtime's time arithmetic
     * never check them again (DRV_FRAMELINK_TIME_MAX_NS). */
    static const struct {
        int off;
        const char *name;
    } times[] = {{OFF_POSE_T, "pose_t_ns"},           {OFF_POSE_SENT, "pose_sent_ns"},
                 {OFF_HOST_POSE_RX, "host_pose_rx_ns"}, {OFF_HOST_START, "host_render_start_ns"},
                 {OFF_HOST_END, "host_render_end_ns"},  {OFF_HOST_SEND, "host_send_ns"}};
    for (size_t i = 0; i < sizeof times / sizeof times[0]; i++) {
        int64_t t = (int64_t)get_u64(buf + times[i].off);
        if (!time_ok(t))
            return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "%s %lld outside [0, 2^62]", times[i].name,
                                  (long long)t);
    }
    if (!isfinite(get_f64(buf + OFF_SCENE_TIME)))
        return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "scene_time not finite");
    for (int e = 0; e < 2; e++)
        if (!pose_ok(get_pose(buf + OFF_EYES + e * EYE_BYTES)))
            return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_POSE, "eye %d pose not finite or not a unit quaternion",
                                  e);
    for (int i = 0; i < n_obj; i++)
        if (!pose_ok(get_pose(buf + DRV_FRAMELINK_FIXED_BYTES + (size_t)i * DRV_FRAMELINK_OBJECT_BYTES)))
            return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_POSE,
                                  "object %d pose not finite or not a unit quaternion", i + 1);

    /* All container checks passed: the RAW planes, then the codecs' (which may still fail: a corrupt stream; the
     * pixels are then partly written, never the frame's header fields). */
    for (int i = 0; i < n_planes; i++) {
        if (drv_framelink_plane_coded(&pd[i])) continue;
        const uint8_t *p = buf + hdr + pd[i].off;
        for (int e = 0; e < 2; e++) {
            drv_framelink_get_eye(out, pd[i].type, pd[i].format, e, w[e], h[e], lay.near_z[e], p);
            int deepest = 0;
            p += pd[i].type == 4
                     ? drv_framelink_layers_check(p, pd[i].size, w[e], h[e], out->layers[e].max_layers, &deepest)
                     : (size_t)w[e] * h[e] * (size_t)bytes_per_pixel(pd[i].format);
        }
    }
    if (coded) {
        err = hook->planes(hook->ctx, &lay, out, detail, dl);
        if (err) return err;
    }
    drv_framelink_tx tx;
    tx.pose_sent_ns = (int64_t)get_u64(buf + OFF_POSE_SENT);
    tx.host_pose_rx_ns = (int64_t)get_u64(buf + OFF_HOST_POSE_RX);
    tx.host_render_start_ns = (int64_t)get_u64(buf + OFF_HOST_START);
    tx.host_render_end_ns = (int64_t)get_u64(buf + OFF_HOST_END);
    tx.host_send_ns = (int64_t)get_u64(buf + OFF_HOST_SEND);
    tx.depth_format = DRV_FRAMELINK_FMT_F32;
    for (int i = 0; i < n_planes; i++)
        if (pd[i].type == 1) tx.depth_format = pd[i].format;
    out->seq = get_u64(buf + OFF_SEQ);
    out->pose_t_ns = (int64_t)get_u64(buf + OFF_POSE_T);
    /* The host's render start on the board clock: the board's send time of the pose plus the host's delay
     * between receiving it and starting (ignores the pose message's own transit, well under a millisecond). All
     * three are in [0, 2^62], so this cannot overflow; a result outside that range (a host clock that jumped)
     * means unknown, like a 0. */
    out->render_start_ns = tx.pose_sent_ns && tx.host_pose_rx_ns && tx.host_render_start_ns
                               ? tx.pose_sent_ns + (tx.host_render_start_ns - tx.host_pose_rx_ns)
                               : 0;
    if (!time_ok(out->render_start_ns)) out->render_start_ns = 0;
    out->planes = planes;
    out->depth_encoding = (warp_depth_encoding)depth_enc;
    out->scene_time = get_f64(buf + OFF_SCENE_TIME);
    for (int e = 0; e < 2; e++) {
        const uint8_t *p = buf + OFF_EYES + e * EYE_BYTES;
        out->eye_pose[e] = get_pose(p);
        warp_camera *c = &out->cam[e];
        c->width = w[e], c->height = h[e];
        get_camera_frustum(p + EYE_CAM, c);
    }
    out->n_objects = n_obj;
    for (int i = 0; i < n_obj; i++)
        out->object_pose[i] = get_pose(buf + DRV_FRAMELINK_FIXED_BYTES + (size_t)i * DRV_FRAMELINK_OBJECT_BYTES);
    if (rx) {
        rx->tx = tx;
        rx->total_bytes = total;
    }
    if (detail && dl > 0) detail[0] = 0;
    return DRV_FRAME_OK;
}

drv_frame_err drv_framelink_decode_ex(const uint8_t *buf, size_t len, size_t max_frame, drv_frame *out,
                                      drv_framelink_rx *rx, char *detail, int dl)
{
    return drv_framelink_decode_hooked(buf, len, max_frame, out, rx, detail, dl, NULL);
}

drv_frame_err drv_framelink_decode(const uint8_t *buf, size_t len, size_t max_frame, drv_frame *out)
{
    return drv_framelink_decode_ex(buf, len, max_frame, out, NULL, NULL, 0);
}

/* ---- board -> host messages ---- */

/* What every board message shares, checked in this order: magic, version, size, length, CRC (the last 4 bytes). */
static drv_frame_err msg_envelope(const uint8_t *buf, size_t len, uint32_t magic, uint16_t bytes, int max_version)
{
    if (len < 4) return DRV_FRAME_ERR_TRUNCATED;
    if (get_u32(buf) != magic) return DRV_FRAME_ERR_BAD_MAGIC;
    if (len < 8) return DRV_FRAME_ERR_TRUNCATED;
    if (get_u16(buf + 4) < DRV_FRAMELINK_VERSION || get_u16(buf + 4) > max_version) return DRV_FRAME_ERR_BAD_VERSION;
    if (get_u16(buf + 6) != bytes) return DRV_FRAME_ERR_BAD_SIZE;
    if (len < bytes) return DRV_FRAME_ERR_TRUNCATED;
    if (get_u32(buf + bytes - 4) != crc(buf, bytes - 4u)) return DRV_FRAME_ERR_CRC;
    return DRV_FRAME_OK;
}

/* ---- pose messages ---- */

size_t drv_framelink_pose_encode(const drv_framelink_pose *p, uint8_t *buf, size_t cap)
{
    if (cap < DRV_FRAMELINK_POSE_BYTES) return 0;
    memset(buf, 0, DRV_FRAMELINK_POSE_BYTES);
    put_u32(buf, DRV_FRAMELINK_POSE_MAGIC);
    put_u16(buf + 4, DRV_FRAMELINK_VERSION);
    put_u16(buf + 6, DRV_FRAMELINK_POSE_BYTES);
    put_u32(buf + 8, p->seq);
    put_u64(buf + 16, (uint64_t)p->board_t_ns);
    put_u64(buf + 24, (uint64_t)p->target_t_ns);
    put_u32(buf + 12, p->flags);
    put_pose(buf + 32, p->head);
    put_pose(buf + 88, p->eye[0]);
    put_pose(buf + 144, p->eye[1]);
    put_u32(buf + 200, crc(buf, 200));
    return DRV_FRAMELINK_POSE_BYTES;
}

drv_frame_err drv_framelink_pose_decode(const uint8_t *buf, size_t len, drv_framelink_pose *out)
{
    drv_frame_err env =
        msg_envelope(buf, len, DRV_FRAMELINK_POSE_MAGIC, DRV_FRAMELINK_POSE_BYTES, DRV_FRAMELINK_VERSION);
    if (env != DRV_FRAME_OK) return env;
    drv_framelink_pose p;
    p.seq = get_u32(buf + 8);
    p.flags = get_u32(buf + 12);
    p.board_t_ns = (int64_t)get_u64(buf + 16);
    p.target_t_ns = (int64_t)get_u64(buf + 24);
    p.head = get_pose(buf + 32);
    p.eye[0] = get_pose(buf + 88);
    p.eye[1] = get_pose(buf + 144);
    if (!pose_ok(p.head) || !pose_ok(p.eye[0]) || !pose_ok(p.eye[1])) return DRV_FRAME_ERR_BAD_POSE;
    if (!time_ok(p.board_t_ns) || !time_ok(p.target_t_ns)) return DRV_FRAME_ERR_BAD_POSE;
    *out = p;
    return DRV_FRAME_OK;
}

/* ---- camera messages ---- */

size_t drv_framelink_cams_encode(const drv_framelink_cams *c, uint8_t *buf, size_t cap)
{
    if (cap < DRV_FRAMELINK_CAMS_BYTES) return 0;
    memset(buf, 0, DRV_FRAMELINK_CAMS_BYTES);
    /* Version 1 unless the board decodes more than raw, so a version 1 host still reads a raw-only board. */
    unsigned codecs = c->codecs | DRV_CODEC_BIT(DRV_CODEC_RAW);
    bool v2 = codecs != DRV_CODEC_BIT(DRV_CODEC_RAW);
    put_u32(buf, DRV_FRAMELINK_CAMS_MAGIC);
    put_u16(buf + 4, v2 ? DRV_FRAMELINK_VERSION_2 : DRV_FRAMELINK_VERSION);
    put_u16(buf + 6, DRV_FRAMELINK_CAMS_BYTES);
    put_u32(buf + 8, c->seq);
    put_u32(buf + 16, c->planes);
    put_u32(buf + 20, (uint32_t)c->depth_encoding);
    put_u64(buf + 24, c->max_frame_bytes);
    put_f64(buf + 32, c->refresh_hz);
    put_f64(buf + 40, c->pose_rate_hz);
    put_camera(buf + 48, &c->cam[0]);
    put_camera(buf + 104, &c->cam[1]);
    if (v2) put_u32(buf + 160, codecs);
    put_u32(buf + 164, crc(buf, 164));
    return DRV_FRAMELINK_CAMS_BYTES;
}

drv_frame_err drv_framelink_cams_decode(const uint8_t *buf, size_t len, drv_framelink_cams *out)
{
    drv_frame_err env = msg_envelope(buf, len, DRV_FRAMELINK_CAMS_MAGIC, DRV_FRAMELINK_CAMS_BYTES,
                                     DRV_FRAMELINK_VERSION_2);
    if (env != DRV_FRAME_OK) return env;
    drv_framelink_cams c;
    memset(&c, 0, sizeof c);
    c.seq = get_u32(buf + 8);
    c.planes = get_u32(buf + 16);
    uint32_t enc = get_u32(buf + 20);
    c.max_frame_bytes = get_u64(buf + 24);
    c.refresh_hz = get_f64(buf + 32);
    c.pose_rate_hz = get_f64(buf + 40);
    /* Reserved fields are zero in version 1 (docs/framelink.md, Versioning); version 2's codecs always include raw,
     * and bits of codecs this build does not know are dropped (a host only picks what it knows). */
    if (get_u32(buf + 12) != 0) return DRV_FRAME_ERR_BAD_FORMAT;
    if (get_u16(buf + 4) == DRV_FRAMELINK_VERSION) {
        if (get_u32(buf + 160) != 0) return DRV_FRAME_ERR_BAD_FORMAT;
        c.codecs = DRV_CODEC_BIT(DRV_CODEC_RAW);
    } else {
        c.codecs = get_u32(buf + 160);
        if (!(c.codecs & DRV_CODEC_BIT(DRV_CODEC_RAW))) return DRV_FRAME_ERR_BAD_FORMAT;
        c.codecs &= DRV_CODEC_ALL;
    }
    if (!(c.planes & DRV_PLANE_COLOR) || (c.planes & ~(unsigned)(DRV_PLANE_COLOR | DRV_PLANE_DEPTH | DRV_PLANE_IDS |
                                                                 DRV_PLANE_MOTION | DRV_PLANE_LAYERS)))
        return DRV_FRAME_ERR_BAD_FORMAT;
    if (enc > WARP_DEPTH_REVERSED) return DRV_FRAME_ERR_BAD_FORMAT;
    c.depth_encoding = (warp_depth_encoding)enc;
    if (!isfinite(c.refresh_hz) || c.refresh_hz <= 0 || !isfinite(c.pose_rate_hz) || c.pose_rate_hz <= 0 ||
        c.max_frame_bytes == 0)
        return DRV_FRAME_ERR_BAD_SIZE;
    for (int e = 0; e < 2; e++) {
        const uint8_t *p = buf + 48 + 56 * e;
        uint32_t w = get_u32(p), h = get_u32(p + 4);
        if (w == 0 || h == 0 || w > MAX_DIM || h > MAX_DIM) return DRV_FRAME_ERR_BAD_CAMERA;
        c.cam[e].width = (int)w, c.cam[e].height = (int)h;
        get_camera_frustum(p, &c.cam[e]);
        if (warp_camera_check(&c.cam[e])) return DRV_FRAME_ERR_BAD_CAMERA;
    }
    *out = c;
    return DRV_FRAME_OK;
}

/* ---- visibility mask messages ---- */

/* A tangent beyond this is past 89.99 degrees: no camera a host renders reaches it. */
#define MASK_TAN_MAX 1e4f

size_t drv_framelink_mask_encode(const drv_framelink_mask *m, uint8_t *buf, size_t cap)
{
    for (int e = 0; e < 2; e++)
        if (m->n[e] < 0 || m->n[e] > DRV_FRAMELINK_MASK_MAX || (m->n[e] > 0 && m->n[e] < 3)) return 0;
    const size_t bytes = DRV_FRAMELINK_MASK_BYTES(m->n[0], m->n[1]);
    if (cap < bytes) return 0;
    memset(buf, 0, bytes);
    put_u32(buf, DRV_FRAMELINK_MASK_MAGIC);
    put_u16(buf + 4, DRV_FRAMELINK_VERSION);
    put_u16(buf + 6, (uint16_t)bytes);
    put_u32(buf + 8, m->seq);
    put_u16(buf + 16, (uint16_t)m->n[0]);
    put_u16(buf + 18, (uint16_t)m->n[1]);
    uint8_t *p = buf + 20;
    for (int e = 0; e < 2; e++)
        for (int i = 0; i < 2 * m->n[e]; i++, p += 4) put_f32(p, m->uv[e][i]);
    put_u32(buf + bytes - 4, crc(buf, bytes - 4u));
    return bytes;
}

drv_frame_err drv_framelink_mask_decode(const uint8_t *buf, size_t len, drv_framelink_mask *out)
{
    if (len < 4) return DRV_FRAME_ERR_TRUNCATED;
    if (get_u32(buf) != DRV_FRAMELINK_MASK_MAGIC) return DRV_FRAME_ERR_BAD_MAGIC;
    if (len < 20) return DRV_FRAME_ERR_TRUNCATED;
    if (get_u16(buf + 4) != DRV_FRAMELINK_VERSION) return DRV_FRAME_ERR_BAD_VERSION;
    const int n0 = get_u16(buf + 16), n1 = get_u16(buf + 18);
    /* the counts bound the size before anything is read past them: at most 24 + 8 * 2 * 65535 bytes */
    const size_t bytes = DRV_FRAMELINK_MASK_BYTES(n0, n1);
    if (get_u16(buf + 6) != bytes) return DRV_FRAME_ERR_BAD_SIZE;
    if (len < bytes) return DRV_FRAME_ERR_TRUNCATED;
    if (get_u32(buf + bytes - 4) != crc(buf, bytes - 4u)) return DRV_FRAME_ERR_CRC;
    if (get_u32(buf + 12) != 0) return DRV_FRAME_ERR_BAD_FORMAT;
    drv_framelink_mask m;
    memset(&m, 0, sizeof m);
    m.seq = get_u32(buf + 8);
    m.n[0] = n0;
    m.n[1] = n1;
    for (int e = 0; e < 2; e++)
        if (m.n[e] > DRV_FRAMELINK_MASK_MAX || (m.n[e] > 0 && m.n[e] < 3)) return DRV_FRAME_ERR_BAD_FORMAT;
    const uint8_t *p = buf + 20;
    for (int e = 0; e < 2; e++)
        for (int i = 0; i < 2 * m.n[e]; i++, p += 4) {
            float f = get_f32(p);
            if (!(f >= -MASK_TAN_MAX && f <= MASK_TAN_MAX)) return DRV_FRAME_ERR_BAD_CAMERA;
            m.uv[e][i] = f;
        }
    *out = m;
    return DRV_FRAME_OK;
}

uint32_t drv_framelink_msg_peek(const uint8_t *buf, size_t len, size_t *size)
{
    if (len < 12) return 0;
    uint32_t magic = get_u32(buf);
    if (magic != DRV_FRAMELINK_POSE_MAGIC && magic != DRV_FRAMELINK_CAMS_MAGIC && magic != DRV_FRAMELINK_MASK_MAGIC)
        return 0;
    if (size) *size = get_u16(buf + 6);
    return magic;
}
