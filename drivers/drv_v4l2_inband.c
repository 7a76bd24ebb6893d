/* SPDX-License-Identifier: MIT */
/* drv_v4l2_inband: the in-band layout of a host frame in one video frame (HDMI/CSI capture): a metadata band of
 * luma-only bit blocks, both eyes' colour side by side, optional 16-bit depth as luma byte pairs (docs/v4l2-inband.md). */
#include "drivers/drv_v4l2_inband.h"

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <zlib.h>

#include "warp/warp_err.h"

#define META_BITS (DRV_V4L2_META_BYTES * 8)
#define CHUNK 512 /* pixels per row piece handled on the stack (unpack never allocates) */
/* Block means are thresholded halfway between the levels: a block survives any error below ~100 levels. */
#define THRESHOLD ((DRV_V4L2_LEVEL_BLACK + DRV_V4L2_LEVEL_WHITE + 1) / 2)

bool drv_v4l2_layout_get(int eye_w, int eye_h, bool depth, drv_v4l2_layout_info *l)
{
    memset(l, 0, sizeof *l);
    if (eye_w < DRV_V4L2_MIN_EYE_W || eye_h < 2 || (eye_w & 1) || (eye_h & 1) || eye_w > 8192 || eye_h > 8192)
        return false;
    int bits_per_row = eye_w; /* 2*eye_w pixels / BLOCK */
    l->eye_w = eye_w, l->eye_h = eye_h, l->depth = depth;
    l->band_rows = DRV_V4L2_BLOCK * ((META_BITS + bits_per_row - 1) / bits_per_row);
    l->color_y = l->band_rows;
    l->depth_y = depth ? l->color_y + eye_h : -1;
    l->width = 2 * eye_w;
    l->height = l->color_y + eye_h * (depth ? 3 : 1);
    return true;
}

bool drv_v4l2_layout(int eye_w, int eye_h, bool depth, int *img_w, int *img_h)
{
    drv_v4l2_layout_info l;
    if (!drv_v4l2_layout_get(eye_w, eye_h, depth, &l)) return false;
    if (img_w) *img_w = l.width;
    if (img_h) *img_h = l.height;
    return true;
}

const drv_v4l2_mode drv_v4l2_common_modes[] = {
    {"720p", 1280, 720}, {"1080p", 1920, 1080}, {"1200p", 1920, 1200},
    {"1440p", 2560, 1440}, {"4K UHD", 3840, 2160}, {"DCI 4K", 4096, 2160},
};
const int drv_v4l2_common_mode_count = (int)(sizeof drv_v4l2_common_modes / sizeof drv_v4l2_common_modes[0]);

#define MAX_EYE_SIDE 8192 /* drv_v4l2_layout_get's limit (the band's u16 sizes and int pixel indices) */

static size_t frame_bytes(uint32_t fourcc, int w, int h)
{
    return drv_v4l2_image_size(fourcc, h, drv_v4l2_min_bytesperline(fourcc, w));
}

/* The tallest even eye of width w whose layout fits mode_h rows (0 if none). */
static int max_eye_h(int w, bool depth, int mode_h)
{
    drv_v4l2_layout_info l;
    if (!drv_v4l2_layout_get(w, 2, depth, &l)) return 0;
    int h = (mode_h - l.band_rows) / (depth ? 3 : 1);
    h = h > MAX_EYE_SIDE ? MAX_EYE_SIDE : h & ~1;
    return h >= 2 ? h : 0;
}

bool drv_v4l2_fit_check(int mode_w, int mode_h, uint32_t fourcc, int eye_w, int eye_h, unsigned planes,
                        drv_v4l2_fit *fit, char *why, int whylen)
{
    memset(fit, 0, sizeof *fit);
    const bool depth = (planes & DRV_PLANE_DEPTH) != 0;
    const char *what = depth ? "colour + depth" : "colour";
    char fc[8];
    if (!drv_v4l2_fourcc_supported(fourcc))
        return warp_err(why, whylen, "capture format %s is none of YUYV, NV12, BGR32/XBGR32, RGB24",
                        drv_v4l2_fourcc_str(fourcc, fc));
    if (mode_w <= 0 || mode_h <= 0 || mode_w > 1 << 16 || mode_h > 1 << 16)
        return warp_err(why, whylen, "capture mode %dx%d is no video mode", mode_w, mode_h);
    fit->have_bytes = frame_bytes(fourcc, mode_w, mode_h);
    int mw = mode_w / 2 > MAX_EYE_SIDE ? MAX_EYE_SIDE : (mode_w / 2) & ~1;
    fit->max_eye_w = mw >= DRV_V4L2_MIN_EYE_W ? mw : 0;
    drv_v4l2_layout_info l;
    bool has_layout = drv_v4l2_layout_get(eye_w, eye_h, depth, &l);
    int at_w = has_layout && eye_w < fit->max_eye_w ? eye_w : fit->max_eye_w;
    fit->max_eye_h = at_w ? max_eye_h(at_w, depth, mode_h) : 0;
    if (!(planes & DRV_PLANE_COLOR) || (planes & ~(unsigned)(DRV_PLANE_COLOR | DRV_PLANE_DEPTH)))
        return warp_err(why, whylen, "the V4L2 in-band layout carries colour and optionally depth only (planes 0x%x)",
                        planes);
    if (!has_layout)
        return warp_err(why, whylen,
                        "eyes %dx%d have no V4L2 in-band layout (even sizes, width %d..%d, height up to %d)", eye_w,
                        eye_h, DRV_V4L2_MIN_EYE_W, MAX_EYE_SIDE, MAX_EYE_SIDE);
    fit->need_w = l.width, fit->need_h = l.height;
    fit->need_bytes = frame_bytes(fourcc, l.width, l.height);
    fit->fits = l.width <= mode_w && l.height <= mode_h;
    if (fit->fits) return true;
    const double mib = 1024.0 * 1024.0;
    char holds[120];
    if (!fit->max_eye_h)
        snprintf(holds, sizeof holds, "it holds no eyes %s", depth ? "with depth" : "at all");
    else if (depth)
        snprintf(holds, sizeof holds, "it holds eyes up to %dx%d with depth, %dx%d colour only", at_w,
                 fit->max_eye_h, at_w, max_eye_h(at_w, false, mode_h));
    else
        snprintf(holds, sizeof holds, "it holds eyes up to %dx%d", at_w, fit->max_eye_h);
    return warp_err(why, whylen,
                    "eyes %dx%d (%s) need a %dx%d in-band frame (%.1f MiB of %s); the capture mode %dx%d %s has "
                    "%.1f MiB: %s", eye_w, eye_h, what, l.width, l.height, (double)fit->need_bytes / mib,
                    drv_v4l2_fourcc_str(fourcc, fc), mode_w, mode_h, fc, (double)fit->have_bytes / mib, holds);
}

/* ---- serialisation (little endian; doubles as their IEEE bits, so they arrive bit exact) ---- */

static void put16(uint8_t *p, uint32_t v) { p[0] = (uint8_t)v, p[1] = (uint8_t)(v >> 8); }
static void put32(uint8_t *p, uint32_t v) { put16(p, v), put16(p + 2, v >> 16); }
static void put64(uint8_t *p, uint64_t v) { put32(p, (uint32_t)v), put32(p + 4, (uint32_t)(v >> 32)); }
static void putd(uint8_t *p, double d)
{
    uint64_t v;
    memcpy(&v, &d, 8);
    put64(p, v);
}
static uint32_t get16(const uint8_t *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8; }
static uint32_t get32(const uint8_t *p) { return get16(p) | get16(p + 2) << 16; }
static uint64_t get64(const uint8_t *p) { return (uint64_t)get32(p) | (uint64_t)get32(p + 4) << 32; }
static double getd(const uint8_t *p)
{
    uint64_t v = get64(p);
    double d;
    memcpy(&d, &v, 8);
    return d;
}

/* Byte offsets. The preamble (magic, eye size) is the first 64 bits, which lie in the first block row for any
 * eye_w >= 64: a board configured for another eye size reads it and reports BAD_SIZE, not garbage. */
enum {
    O_MAGIC = 0, O_EYE_W = 4, O_EYE_H = 6, O_VERSION = 8, O_FLAGS = 10, O_DEPTH_ENC = 12, O_DEPTH_WIRE = 13,
    O_SEQ = 16, O_POSE_T = 24, O_RENDER_START = 32, O_SCENE_TIME = 40, O_EYE = 48, EYE_BYTES = 13 * 8,
    O_CRC = O_EYE + 2 * EYE_BYTES,
};
_Static_assert(O_CRC + 4 == DRV_V4L2_META_BYTES, "metadata layout");
_Static_assert(WARP_DEPTH_LINEAR == 0 && WARP_DEPTH_STANDARD == 1 && WARP_DEPTH_REVERSED == 2,
               "the band's depth encoding byte (docs/v4l2-inband.md) is warp_depth_encoding's value");
#define FLAG_DEPTH 1u

static void meta_serialise(const drv_v4l2_meta *m, uint8_t *b)
{
    memset(b, 0, DRV_V4L2_META_BYTES);
    put32(b + O_MAGIC, DRV_V4L2_MAGIC);
    put16(b + O_EYE_W, (uint32_t)m->eye_w);
    put16(b + O_EYE_H, (uint32_t)m->eye_h);
    put16(b + O_VERSION, (uint32_t)m->version);
    put16(b + O_FLAGS, m->depth ? FLAG_DEPTH : 0);
    b[O_DEPTH_ENC] = (uint8_t)m->depth_encoding;
    b[O_DEPTH_WIRE] = m->depth ? DRV_V4L2_DEPTH_WIRE_INV16 : 0;
    put64(b + O_SEQ, m->seq);
    put64(b + O_POSE_T, (uint64_t)m->pose_t_ns);
    put64(b + O_RENDER_START, (uint64_t)m->render_start_ns);
    putd(b + O_SCENE_TIME, m->scene_time);
    for (int e = 0; e < 2; e++) {
        uint8_t *p = b + O_EYE + e * EYE_BYTES;
        const warp_pose *q = &m->eye_pose[e];
        const warp_camera *c = &m->cam[e];
        const double v[13] = {q->q.w, q->q.x, q->q.y, q->q.z, q->p.x, q->p.y, q->p.z,
                              c->tan_left, c->tan_right, c->tan_up, c->tan_down, c->near_z, c->far_z};
        for (int i = 0; i < 13; i++) putd(p + 8 * i, v[i]);
    }
    put32(b + O_CRC, (uint32_t)crc32(0L, b, O_CRC));
}

/* ---- the band ---- */

static void write_band(uint8_t *img, const drv_v4l2_geom *g, const drv_v4l2_layout_info *l, const uint8_t *bytes)
{
    uint8_t lv[CHUNK];
    int bits_per_row = l->eye_w;
    for (int by = 0; by < l->band_rows / DRV_V4L2_BLOCK; by++) {
        for (int bx0 = 0; bx0 < bits_per_row; bx0 += CHUNK / DRV_V4L2_BLOCK) {
            int n = bits_per_row - bx0 < CHUNK / DRV_V4L2_BLOCK ? bits_per_row - bx0 : CHUNK / DRV_V4L2_BLOCK;
            for (int k = 0; k < n; k++) {
                int bit = by * bits_per_row + bx0 + k;
                /* bits MSB first within each byte, blocks left to right, top to bottom; padding is black */
                bool one = bit < META_BITS && ((bytes[bit >> 3] >> (7 - (bit & 7))) & 1);
                lv[2 * k] = lv[2 * k + 1] = one ? DRV_V4L2_LEVEL_WHITE : DRV_V4L2_LEVEL_BLACK;
            }
            for (int r = 0; r < DRV_V4L2_BLOCK; r++)
                drv_v4l2_write_grey(img, g, bx0 * DRV_V4L2_BLOCK, by * DRV_V4L2_BLOCK + r, n * DRV_V4L2_BLOCK, lv);
        }
    }
}

/* Decodes the first nbits bits of the band into bytes (which must hold nbits/8 bytes). */
static void read_band(const uint8_t *img, const drv_v4l2_geom *g, int eye_w, int nbits, uint8_t *bytes)
{
    uint8_t a[CHUNK], b[CHUNK];
    int bits_per_row = eye_w;
    memset(bytes, 0, (size_t)(nbits + 7) / 8);
    for (int bit0 = 0; bit0 < nbits;) {
        int by = bit0 / bits_per_row, bx0 = bit0 % bits_per_row;
        int n = bits_per_row - bx0;
        if (n > CHUNK / DRV_V4L2_BLOCK) n = CHUNK / DRV_V4L2_BLOCK;
        if (n > nbits - bit0) n = nbits - bit0;
        drv_v4l2_read_luma(img, g, bx0 * DRV_V4L2_BLOCK, by * DRV_V4L2_BLOCK, n * DRV_V4L2_BLOCK, a);
        drv_v4l2_read_luma(img, g, bx0 * DRV_V4L2_BLOCK, by * DRV_V4L2_BLOCK + 1, n * DRV_V4L2_BLOCK, b);
        for (int k = 0; k < n; k++) {
            int sum = a[2 * k] + a[2 * k + 1] + b[2 * k] + b[2 * k + 1];
            if (sum >= 4 * THRESHOLD) bytes[(bit0 + k) >> 3] |= (uint8_t)(0x80 >> ((bit0 + k) & 7));
        }
        bit0 += n;
    }
}

static const char *fourcc_name(uint32_t f, char *buf) { return drv_v4l2_fourcc_str(f, buf); }

/* Common geometry checks of pack and unpack. */
static drv_frame_err check_geom(const drv_v4l2_geom *g, const drv_v4l2_layout_info *l, char *why, int whylen)
{
    char fc[8];
    if (!drv_v4l2_fourcc_supported(g->fourcc))
        return drv_frame_fail(why, whylen, DRV_FRAME_ERR_BAD_FORMAT, "unsupported pixel format %s",
                              fourcc_name(g->fourcc, fc));
    const char *e = drv_v4l2_geom_check(g);
    if (e) return drv_frame_fail(why, whylen, DRV_FRAME_ERR_BAD_SIZE, "%s image %dx%d: %s", fourcc_name(g->fourcc, fc),
                                 g->width, g->height, e);
    if (g->width < l->width || g->height < l->height)
        return drv_frame_fail(why, whylen, DRV_FRAME_ERR_BAD_SIZE, "image %dx%d is smaller than the layout's %dx%d",
                              g->width, g->height, l->width, l->height);
    return DRV_FRAME_OK;
}

static void fill_black(uint8_t *img, const drv_v4l2_geom *g, int x0, int y0, int w, int h)
{
    uint8_t lv[CHUNK];
    memset(lv, DRV_V4L2_LEVEL_BLACK, sizeof lv);
    if (w <= 0 || h <= 0) return;
    for (int y = y0; y < y0 + h; y++)
        for (int x = x0; x < x0 + w; x += CHUNK) drv_v4l2_write_grey(img, g, x, y, x0 + w - x < CHUNK ? x0 + w - x : CHUNK, lv);
}

drv_frame_err drv_v4l2_pack(const drv_frame *f, bool depth, const drv_v4l2_geom *g, const drv_v4l2_colorspace *cs,
                            uint8_t *img)
{
    int ew = f->color[0].w, eh = f->color[0].h;
    drv_v4l2_layout_info l;
    if (!(f->planes & DRV_PLANE_COLOR) || !f->color[0].px || !f->color[1].px || f->color[1].w != ew ||
        f->color[1].h != eh || !drv_v4l2_layout_get(ew, eh, depth, &l))
        return DRV_FRAME_ERR_BAD_SIZE;
    drv_frame_err err = check_geom(g, &l, NULL, 0);
    if (err) return err;
    bool send_depth = depth && (f->planes & DRV_PLANE_DEPTH);
    if (send_depth)
        for (int e = 0; e < 2; e++)
            if (!f->depth[e].px || f->depth[e].w != ew || f->depth[e].h != eh) return DRV_FRAME_ERR_BAD_SIZE;

    /* Depth first: it is the only step that can reject the frame, and a rejected frame must leave no half-written
     * metadata that could pass for a valid band. */
    if (depth) {
        uint8_t hi[CHUNK], lo[CHUNK];
        for (int e = 0; e < 2; e++) {
            const warp_camera *c = &f->cam[e];
            for (int y = 0; y < eh; y++) {
                for (int x0 = 0; x0 < ew; x0 += CHUNK) {
                    int n = ew - x0 < CHUNK ? ew - x0 : CHUNK;
                    for (int k = 0; k < n; k++) {
                        uint32_t q = 0;
                        if (send_depth) {
                            double d = WARP_AT(&f->depth[e], x0 + k, y);
                            double inv = f->depth_encoding == WARP_DEPTH_LINEAR ? (d > 0 ? 1.0 / d : NAN)
                                                                                : warp_depth_to_inverse(c, f->depth_encoding, d);
                            if (!(inv >= 0)) return DRV_FRAME_ERR_BAD_DEPTH; /* NaN or behind the eye */
                            double w = inv * c->near_z;
                            q = w >= 1.0 ? 65535u : (uint32_t)lrint(w * 65535.0);
                        }
                        hi[k] = (uint8_t)(q >> 8), lo[k] = (uint8_t)q;
                    }
                    drv_v4l2_write_grey(img, g, e * ew + x0, l.depth_y + 2 * y, n, hi);
                    drv_v4l2_write_grey(img, g, e * ew + x0, l.depth_y + 2 * y + 1, n, lo);
                }
            }
        }
    }
    for (int e = 0; e < 2; e++)
        drv_v4l2_from_rgba(f->color[e].px, f->color[e].stride, ew, eh, cs, img, g, e * ew, l.color_y);

    drv_v4l2_meta m;
    memset(&m, 0, sizeof m);
    m.version = DRV_V4L2_VERSION;
    m.eye_w = ew, m.eye_h = eh;
    m.depth = send_depth;
    m.depth_encoding = f->depth_encoding;
    m.seq = f->seq;
    m.pose_t_ns = f->pose_t_ns;
    m.render_start_ns = f->render_start_ns;
    m.scene_time = f->scene_time;
    for (int e = 0; e < 2; e++) m.eye_pose[e] = f->eye_pose[e], m.cam[e] = f->cam[e];
    uint8_t bytes[DRV_V4L2_META_BYTES];
    meta_serialise(&m, bytes);
    write_band(img, g, &l, bytes);

    /* Whatever the video mode has beyond the layout. */
    fill_black(img, g, l.width, 0, g->width - l.width, l.height);
    fill_black(img, g, 0, l.height, g->width, g->height - l.height);
    return DRV_FRAME_OK;
}

#define TIME_MAX_NS ((int64_t)1 << 62)

static bool pose_ok(warp_pose p) { return warp_pose_isfinite(p) && fabs(warp_quat_norm(p.q) - 1.0) <= 1e-3; }

drv_frame_err drv_v4l2_read_meta(const uint8_t *img, const drv_v4l2_geom *g, int eye_w, drv_v4l2_meta *m,
                                 char *why, int whylen)
{
    char fc[8];
    memset(m, 0, sizeof *m);
    if (!drv_v4l2_fourcc_supported(g->fourcc))
        return drv_frame_fail(why, whylen, DRV_FRAME_ERR_BAD_FORMAT, "unsupported pixel format %s",
                              fourcc_name(g->fourcc, fc));
    const char *ge = drv_v4l2_geom_check(g);
    if (ge) return drv_frame_fail(why, whylen, DRV_FRAME_ERR_BAD_SIZE, "image %dx%d: %s", g->width, g->height, ge);
    drv_v4l2_layout_info l;
    if (!drv_v4l2_layout_get(eye_w, 2, false, &l) || g->width < l.width || g->height < l.band_rows)
        return drv_frame_fail(why, whylen, DRV_FRAME_ERR_BAD_SIZE, "image %dx%d cannot hold the band for eyes %d wide",
                              g->width, g->height, eye_w);
    uint8_t b[DRV_V4L2_META_BYTES];
    read_band(img, g, eye_w, 64, b); /* the preamble first: a blank or foreign picture is rejected cheaply */
    uint32_t magic = get32(b + O_MAGIC);
    if (magic != DRV_V4L2_MAGIC)
        return drv_frame_fail(why, whylen, DRV_FRAME_ERR_BAD_MAGIC, "no in-band metadata (magic 0x%08x, want 0x%08x)",
                              magic, DRV_V4L2_MAGIC);
    m->eye_w = (int)get16(b + O_EYE_W), m->eye_h = (int)get16(b + O_EYE_H);
    if (m->eye_w != eye_w)
        return drv_frame_fail(why, whylen, DRV_FRAME_ERR_BAD_SIZE, "host sends eyes %dx%d, board expects %d wide",
                              m->eye_w, m->eye_h, eye_w);
    read_band(img, g, eye_w, META_BITS, b);
    /* CRC before version: a flipped version bit is garbage, not a newer host (later versions keep the CRC of the
     * first 256 bytes at the same place, or change the magic). */
    uint32_t crc = (uint32_t)crc32(0L, b, O_CRC), want = get32(b + O_CRC);
    if (crc != want)
        return drv_frame_fail(why, whylen, DRV_FRAME_ERR_CRC, "metadata CRC 0x%08x, band says 0x%08x", crc, want);
    m->version = (int)get16(b + O_VERSION);
    if (m->version != DRV_V4L2_VERSION)
        return drv_frame_fail(why, whylen, DRV_FRAME_ERR_BAD_VERSION, "metadata version %d, want %d", m->version,
                              DRV_V4L2_VERSION);
    unsigned flags = get16(b + O_FLAGS);
    m->depth = flags & FLAG_DEPTH;
    m->depth_encoding = (warp_depth_encoding)b[O_DEPTH_ENC];
    if (b[O_DEPTH_ENC] > WARP_DEPTH_REVERSED || (m->depth && b[O_DEPTH_WIRE] != DRV_V4L2_DEPTH_WIRE_INV16))
        return drv_frame_fail(why, whylen, DRV_FRAME_ERR_BAD_FORMAT, "unknown depth encoding %u / wire format %u",
                              b[O_DEPTH_ENC], b[O_DEPTH_WIRE]);
    m->seq = get64(b + O_SEQ);
    m->pose_t_ns = (int64_t)get64(b + O_POSE_T);
    m->render_start_ns = (int64_t)get64(b + O_RENDER_START);
    m->scene_time = getd(b + O_SCENE_TIME);
    /* Board-clock times in [0, 2^62] (as framelink's DRV_FRAMELINK_TIME_MAX_NS): the runtime subtracts them from its
     * clock unchecked, which cannot overflow then. */
    if (m->pose_t_ns < 0 || m->pose_t_ns > TIME_MAX_NS || m->render_start_ns < 0 || m->render_start_ns > TIME_MAX_NS)
        return drv_frame_fail(why, whylen, DRV_FRAME_ERR_BAD_FORMAT,
                              "pose_t_ns %lld / render_start_ns %lld outside [0, 2^62]", (long long)m->pose_t_ns,
                              (long long)m->render_start_ns);
    if (!isfinite(m->scene_time)) return drv_frame_fail(why, whylen, DRV_FRAME_ERR_BAD_FORMAT, "scene_time not finite");
    for (int e = 0; e < 2; e++) {
        const uint8_t *p = b + O_EYE + e * EYE_BYTES;
        double v[13];
        for (int i = 0; i < 13; i++) v[i] = getd(p + 8 * i);
        m->eye_pose[e] = (warp_pose){{v[0], v[1], v[2], v[3]}, {v[4], v[5], v[6]}};
        m->cam[e] = (warp_camera){m->eye_w, m->eye_h, v[7], v[8], v[9], v[10], v[11], v[12]};
        if (!pose_ok(m->eye_pose[e]))
            return drv_frame_fail(why, whylen, DRV_FRAME_ERR_BAD_POSE,
                                  "eye %d pose not finite or not a unit quaternion", e);
        const char *ce = warp_camera_check(&m->cam[e]);
        if (ce) return drv_frame_fail(why, whylen, DRV_FRAME_ERR_BAD_CAMERA, "eye %d camera: %s", e, ce);
    }
    return DRV_FRAME_OK;
}

drv_frame_err drv_v4l2_unpack(const uint8_t *img, const drv_v4l2_geom *g, const drv_v4l2_colorspace *cs,
                              drv_frame *out, char *why, int whylen)
{
    int ew = out->color[0].w, eh = out->color[0].h;
    if (!out->color[0].px || !out->color[1].px || out->color[1].w != ew || out->color[1].h != eh)
        return drv_frame_fail(why, whylen, DRV_FRAME_ERR_BAD_SIZE, "output frame has no colour planes of one size");
    drv_v4l2_layout_info l;
    if (!drv_v4l2_layout_get(ew, eh, false, &l))
        return drv_frame_fail(why, whylen, DRV_FRAME_ERR_BAD_SIZE, "eye size %dx%d has no layout", ew, eh);
    drv_frame_err err = check_geom(g, &l, why, whylen);
    if (err) return err;
    drv_v4l2_meta m;
    err = drv_v4l2_read_meta(img, g, ew, &m, why, whylen);
    if (err) return err;
    if (m.eye_h != eh)
        return drv_frame_fail(why, whylen, DRV_FRAME_ERR_BAD_SIZE, "host sends eyes %dx%d, board expects %dx%d",
                              m.eye_w, m.eye_h, ew, eh);
    bool want_depth = m.depth && out->depth[0].px && out->depth[1].px;
    if (want_depth) {
        for (int e = 0; e < 2; e++)
            if (out->depth[e].w != ew || out->depth[e].h != eh)
                return drv_frame_fail(why, whylen, DRV_FRAME_ERR_BAD_SIZE, "output depth plane is not %dx%d", ew, eh);
        drv_v4l2_layout_get(ew, eh, true, &l);
        if (g->height < l.height)
            return drv_frame_fail(why, whylen, DRV_FRAME_ERR_BAD_SIZE,
                                  "image %dx%d too small for the depth rows (%dx%d)", g->width, g->height, l.width,
                                  l.height);
    }

    for (int e = 0; e < 2; e++)
        drv_v4l2_to_rgba(img, g, cs, e * ew, l.color_y, ew, eh, out->color[e].px, out->color[e].stride);
    if (want_depth) {
        uint8_t hi[CHUNK], lo[CHUNK];
        for (int e = 0; e < 2; e++) {
            const warp_camera *c = &m.cam[e];
            /* q = 65535 near / z: linear depth is one division; other encodings go through inverse depth. */
            double kz = 65535.0 * c->near_z, kinv = 1.0 / kz;
            for (int y = 0; y < eh; y++) {
                float *d = &WARP_AT(&out->depth[e], 0, y);
                for (int x0 = 0; x0 < ew; x0 += CHUNK) {
                    int n = ew - x0 < CHUNK ? ew - x0 : CHUNK;
                    drv_v4l2_read_luma(img, g, e * ew + x0, l.depth_y + 2 * y, n, hi);
                    drv_v4l2_read_luma(img, g, e * ew + x0, l.depth_y + 2 * y + 1, n, lo);
                    for (int k = 0; k < n; k++) {
                        unsigned q = (unsigned)hi[k] << 8 | lo[k];
                        if (m.depth_encoding == WARP_DEPTH_LINEAR)
                            d[x0 + k] = q ? (float)(kz / q) : INFINITY;
                        else
                            d[x0 + k] = (float)warp_depth_from_inverse(c, m.depth_encoding, q * kinv);
                    }
                }
            }
        }
    }
    out->planes = DRV_PLANE_COLOR | (want_depth ? DRV_PLANE_DEPTH : 0u);
    out->seq = m.seq;
    out->pose_t_ns = m.pose_t_ns;
    out->render_start_ns = m.render_start_ns;
    out->depth_encoding = m.depth_encoding;
    out->scene_time = m.scene_time;
    out->n_objects = 0;
    for (int e = 0; e < 2; e++) out->cam[e] = m.cam[e], out->eye_pose[e] = m.eye_pose[e];
    return DRV_FRAME_OK;
}
