/* SPDX-License-Identifier: MIT */
/* drv_framelink_codec: framelink v2's frame encoder (host) and decoder (board), a codec per plane: zstd (shuffled)
 * for depth, ids, motion and layers, JPEG slices and H.264/HEVC for colour, chunks coded in parallel (plat_workers). */
#include "drivers/drv_framelink_codec.h"

#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <zstd.h>

#include "drivers/drv_codec_depth.h"
#include "drivers/drv_codec_video.h"
#include "drivers/drv_framelink_wire.h"
#include "platform/plat_clock.h"
#include "platform/plat_workers.h"
#include "warp/warp_err.h"

/* Tasks of one frame: every colour chunk (2 eyes x 16 slices at most) and an eye of each other plane. */
#define MAX_TASKS (DRV_FRAMELINK_MAX_CHUNKS + 2 * 4)
#define MAX_THREADS 16
#define WHY_LEN 160
/* While a video stream waits for its key frame, the request is raised again every this many dropped frames (the
 * pose message carrying it may have been lost; the frames already in flight are not worth a key frame each). */
#define WANT_KEY_REPEAT 8

/* Scratch index of plane type t (1..4: depth, ids, motion, layers) and eye e. */
static int slot(int t, int e) { return (t - 1) * 2 + e; }

/* zstd input of 16- and 32-bit planes is byte-shuffled (every element's byte 0, then every byte 1, ...): the high
 * bytes of depth, ids and motion repeat and compress far better apart from the noisy low ones. */
static int shuffle_size(int format)
{
    switch (format) {
    case DRV_FRAMELINK_FMT_F32:
    case DRV_FRAMELINK_FMT_VEC2F32: return 4;
    case DRV_FRAMELINK_FMT_UNORM16:
    case DRV_FRAMELINK_FMT_INV16:
    case DRV_FRAMELINK_FMT_U16: return 2;
    default: return 1;
    }
}
/* Byte planes: element byte b of element i at b * n + i. A loop per element size, so the compiler sees constant
 * strides (the generic double loop cost more than zstd itself on a full-resolution depth plane). */
static void shuffle(const uint8_t *in, uint8_t *out, size_t bytes, int es)
{
    size_t n = bytes / (size_t)es;
    if (es == 2)
        for (size_t i = 0; i < n; i++) out[i] = in[2 * i], out[n + i] = in[2 * i + 1];
    else
        for (size_t i = 0; i < n; i++)
            for (int b = 0; b < es; b++) out[(size_t)b * n + i] = in[i * (size_t)es + (size_t)b];
}
static void unshuffle(const uint8_t *in, uint8_t *out, size_t bytes, int es)
{
    size_t n = bytes / (size_t)es;
    if (es == 2)
        for (size_t i = 0; i < n; i++) out[2 * i] = in[i], out[2 * i + 1] = in[n + i];
    else
        for (size_t i = 0; i < n; i++)
            for (int b = 0; b < es; b++) out[i * (size_t)es + (size_t)b] = in[(size_t)b * n + i];
}

static int video_index(int codec) { return codec == DRV_CODEC_HEVC; }
static bool is_video(int codec) { return codec == DRV_CODEC_H264 || codec == DRV_CODEC_HEVC; }

/* Low-resolution depth in a 16/32-bit wire format <-> floats (INV16 with the eye's near plane). */
static void depth_to_wire(const float *lo, size_t n, int format, double near_z, uint8_t *p)
{
    for (size_t i = 0; i < n; i++) {
        if (format == DRV_FRAMELINK_FMT_F32) {
            uint32_t v;
            memcpy(&v, &lo[i], 4);
            for (int b = 0; b < 4; b++) p[4 * i + (size_t)b] = (uint8_t)(v >> (8 * b));
        } else {
            uint16_t v = format == DRV_FRAMELINK_FMT_INV16 ? drv_depth_to_inv16(lo[i], near_z)
                                                            : drv_depth_to_unorm16(lo[i]);
            p[2 * i] = (uint8_t)v, p[2 * i + 1] = (uint8_t)(v >> 8);
        }
    }
}
/* Reduced F32 or UNORM16 depth from the wire (INV16 goes through the decoder's table: inv16_run). */
static void depth_from_wire(const uint8_t *p, size_t n, int format, float *lo)
{
    for (size_t i = 0; i < n; i++) {
        if (format == DRV_FRAMELINK_FMT_F32) {
            uint32_t v = (uint32_t)p[4 * i] | (uint32_t)p[4 * i + 1] << 8 | (uint32_t)p[4 * i + 2] << 16 |
                         (uint32_t)p[4 * i + 3] << 24;
            memcpy(&lo[i], &v, 4);
        } else {
            lo[i] = drv_depth_from_unorm16((uint16_t)(p[2 * i] | p[2 * i + 1] << 8));
        }
    }
}
/* n INV16 codes, low bytes at lo[k * step] and high bytes at hi[k * step], through table (drv_depth_from_inv16 of
 * every code for one near plane) into out. */
static void inv16_run(const float *table, const uint8_t *lo, const uint8_t *hi, size_t step, size_t n, float *out)
{
    for (size_t k = 0; k < n; k++) out[k] = table[lo[k * step] | hi[k * step] << 8];
}

/* ---- parameters ---- */

drv_framelink_enc_params drv_framelink_enc_params_raw(void)
{
    return (drv_framelink_enc_params){.color = DRV_CODEC_RAW, .quality = 85, .slices = 1, .depth = DRV_CODEC_RAW,
                                      .other = DRV_CODEC_RAW, .zstd_level = 1, .fps = 45};
}

drv_framelink_enc_params drv_framelink_enc_params_auto(unsigned codecs, warp_depth_encoding enc)
{
    drv_framelink_enc_params p = drv_framelink_enc_params_raw();
    if (codecs & DRV_CODEC_BIT(DRV_CODEC_JPEG)) {
        p.color = DRV_CODEC_JPEG;
        p.quality = DRV_FRAMELINK_AUTO_JPEG_QUALITY;
        p.jpeg_sub = DRV_JPEG_420;
        p.slices = DRV_FRAMELINK_AUTO_JPEG_SLICES;
    }
    if (codecs & DRV_CODEC_BIT(DRV_CODEC_ZSTD)) {
        p.depth = p.other = DRV_CODEC_ZSTD;
        p.depth_format = enc == WARP_DEPTH_LINEAR ? DRV_FRAMELINK_FMT_INV16 : DRV_FRAMELINK_FMT_UNORM16;
    }
    return p;
}

bool drv_framelink_enc_params_check(const drv_framelink_enc_params *p, char *err, int errlen)
{
    if (p->color != DRV_CODEC_RAW && p->color != DRV_CODEC_JPEG && !is_video(p->color))
        return warp_err(err, errlen, "colour codec %s: not raw, jpeg, h264 or hevc", drv_codec_name(p->color));
    if (p->depth != DRV_CODEC_RAW && p->depth != DRV_CODEC_ZSTD)
        return warp_err(err, errlen, "depth codec %s: not raw or zstd", drv_codec_name(p->depth));
    if (p->other != DRV_CODEC_RAW && p->other != DRV_CODEC_ZSTD)
        return warp_err(err, errlen, "ids/motion/layers codec %s: not raw or zstd", drv_codec_name(p->other));
    if (p->color == DRV_CODEC_JPEG) {
        if (p->quality < 1 || p->quality > 100) return warp_err(err, errlen, "JPEG quality %d: not 1..100", p->quality);
        if (p->slices < 1 || p->slices > DRV_FRAMELINK_MAX_SLICES)
            return warp_err(err, errlen, "JPEG slices %d: not 1..%d", p->slices, DRV_FRAMELINK_MAX_SLICES);
        if (p->jpeg_sub != DRV_JPEG_420 && p->jpeg_sub != DRV_JPEG_444)
            return warp_err(err, errlen, "JPEG subsampling %d: not 4:2:0 or 4:4:4", (int)p->jpeg_sub);
    }
    if (is_video(p->color)) {
        if (p->video_kbps < 0) return warp_err(err, errlen, "video rate %d kbit/s: negative", p->video_kbps);
        if (p->video_kbps == 0 && (p->quality < 1 || p->quality > 51))
            return warp_err(err, errlen, "video quality %d: not 1..51", p->quality);
        if (p->refresh_frames < 0) return warp_err(err, errlen, "refresh_frames %d: negative", p->refresh_frames);
        if (!(p->fps > 0 && p->fps < 10000)) return warp_err(err, errlen, "fps %g: not positive", p->fps);
    }
    if (p->depth_format != 0 && p->depth_format != DRV_FRAMELINK_FMT_F32 &&
        p->depth_format != DRV_FRAMELINK_FMT_UNORM16 && p->depth_format != DRV_FRAMELINK_FMT_INV16)
        return warp_err(err, errlen, "depth format %d: not one of F32, UNORM16, INV16", p->depth_format);
    if (p->depth_scale < 0 || p->depth_scale > 2)
        return warp_err(err, errlen, "depth scale %d: not 0, 1 or 2", p->depth_scale);
    if (p->zstd_level < 1 || p->zstd_level > 19)
        return warp_err(err, errlen, "zstd level %d: not 1..19", p->zstd_level);
    return true;
}

/* What one plane of a frame is sent as. */
static drv_framelink_plane plane_choice(const drv_framelink_enc_params *p, int t)
{
    drv_framelink_plane pl = {.type = t, .slices = 1};
    switch (t) {
    case 0:
        pl.format = DRV_FRAMELINK_FMT_RGBA8, pl.codec = p->color;
        if (p->color == DRV_CODEC_JPEG) pl.slices = p->slices;
        break;
    case 1:
        pl.format = p->depth_format ? p->depth_format : DRV_FRAMELINK_FMT_F32;
        pl.codec = p->depth, pl.scale = p->depth_scale;
        break;
    case 2: pl.format = DRV_FRAMELINK_FMT_U16, pl.codec = p->other; break;
    case 3: pl.format = DRV_FRAMELINK_FMT_VEC2F32, pl.codec = p->other; break;
    default: pl.format = DRV_FRAMELINK_FMT_FRAGMENTS, pl.codec = p->other; break;
    }
    return pl;
}

/* ---- encoder ---- */

typedef struct {
    int plane, eye, slice; /* plane: index into the frame's planes */
    uint8_t *out;
    size_t cap, len;
    bool is_key;
    char why[WHY_LEN];
} enc_task;

struct drv_framelink_enc {
    drv_framelink_enc_params p;
    int w, h;
    plat_workers *workers;
    ZSTD_CCtx *zc[8];
    uint8_t *raw[8], *shuf[8];
    size_t raw_cap[8], shuf_cap[8];
    float *lo[2];
    drv_jpeg *jpeg[DRV_FRAMELINK_MAX_CHUNKS];
    drv_video_enc *video[2];
    unsigned counter;  /* video frames sent (the descriptor's param, mod 65536) */
    bool need_key;     /* first video frame, or one after a failed encode */
    /* the frame being encoded */
    const drv_frame *f;
    drv_framelink_plane pl[DRV_FRAMELINK_MAX_PLANES];
    int n_planes;
    bool force_key;
    enc_task task[MAX_TASKS];
    int n_tasks;
};

static int online_cpus(void)
{
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n < 1 ? 1 : n > MAX_THREADS ? MAX_THREADS : (int)n;
}

drv_framelink_enc *drv_framelink_enc_create(const drv_framelink_enc_params *p, int w, int h, char *err, int errlen)
{
    if (!drv_framelink_enc_params_check(p, err, errlen)) return NULL;
    if (w < 1 || h < 1 || w > WARP_MAX_SIDE || h > WARP_MAX_SIDE)
        return warp_err(err, errlen, "eye %dx%d: outside 1..%d", w, h, WARP_MAX_SIDE), NULL;
    unsigned need = DRV_CODEC_BIT(p->color) | DRV_CODEC_BIT(p->depth) | DRV_CODEC_BIT(p->other);
    drv_codec_id lack = drv_codec_missing(need, drv_codec_encodable());
    if (lack != DRV_CODEC_COUNT)
        return warp_err(err, errlen, "codec %s: this build cannot encode it", drv_codec_name(lack)), NULL;
    drv_framelink_enc *e = calloc(1, sizeof *e);
    if (!e) return warp_err(err, errlen, "out of memory"), NULL;
    e->p = *p, e->w = w, e->h = h, e->need_key = true;
    /* Host side: as many threads as the chunks can use, up to the CPUs (none for raw frames). */
    int chunks = (p->color == DRV_CODEC_RAW ? 0 : 2 * (p->color == DRV_CODEC_JPEG ? p->slices : 1)) +
                 (p->depth != DRV_CODEC_RAW || p->depth_scale ? 2 : 0) + (p->other != DRV_CODEC_RAW ? 6 : 0);
    int threads = online_cpus() < chunks ? online_cpus() : chunks;
    if (threads > 1 && !(e->workers = plat_workers_create(threads - 1, 0))) {
        warp_err(err, errlen, "cannot start %d encode threads", threads - 1);
        goto fail;
    }
    if (p->depth == DRV_CODEC_ZSTD || p->other == DRV_CODEC_ZSTD)
        for (int i = 0; i < 8; i++)
            /* The content size in the frame header (the board checks it against the plane before decompressing)
             * and a checksum (a corrupt frame is refused for its reason instead of decoding to noise). */
            if (!(e->zc[i] = ZSTD_createCCtx()) ||
                ZSTD_isError(ZSTD_CCtx_setParameter(e->zc[i], ZSTD_c_compressionLevel, p->zstd_level)) ||
                ZSTD_isError(ZSTD_CCtx_setParameter(e->zc[i], ZSTD_c_checksumFlag, 1)) ||
                ZSTD_isError(ZSTD_CCtx_setParameter(e->zc[i], ZSTD_c_contentSizeFlag, 1))) {
                warp_err(err, errlen, "zstd: cannot create a compression context");
                goto fail;
            }
    if (p->depth_scale)
        for (int i = 0; i < 2; i++)
            if (!(e->lo[i] = malloc(sizeof(float) * (size_t)drv_depth_scaled(w, p->depth_scale) *
                                    (size_t)drv_depth_scaled(h, p->depth_scale)))) {
                warp_err(err, errlen, "out of memory");
                goto fail;
            }
    if (p->color == DRV_CODEC_JPEG)
        for (int i = 0; i < 2 * p->slices; i++)
            if (!(e->jpeg[i] = drv_jpeg_create(true, err, errlen))) goto fail;
    if (is_video(p->color))
        for (int i = 0; i < 2; i++) {
            drv_video_params vp = {.codec = p->color, .w = w, .h = h, .fps = p->fps, .bitrate_kbps = p->video_kbps,
                                   .quality = p->quality, .refresh_frames = p->refresh_frames, .gop = 0};
            if (!(e->video[i] = drv_video_enc_create(&vp, err, errlen))) goto fail;
        }
    return e;
fail:
    drv_framelink_enc_destroy(e);
    return NULL;
}

void drv_framelink_enc_destroy(drv_framelink_enc *e)
{
    if (!e) return;
    if (e->workers) plat_workers_destroy(e->workers);
    for (int i = 0; i < 8; i++) {
        ZSTD_freeCCtx(e->zc[i]);
        free(e->raw[i]);
        free(e->shuf[i]);
    }
    for (int i = 0; i < 2; i++) {
        free(e->lo[i]);
        drv_video_enc_destroy(e->video[i]);
    }
    for (int i = 0; i < DRV_FRAMELINK_MAX_CHUNKS; i++) drv_jpeg_destroy(e->jpeg[i]);
    for (int i = 0; i < MAX_TASKS; i++) free(e->task[i].out);
    free(e);
}

/* The planes f is sent with under e's parameters; false (reason in err) when it cannot be. */
static bool enc_plan(drv_framelink_enc *e, const drv_frame *f, char *err, int errlen)
{
    drv_framelink_tx f32 = {.depth_format = DRV_FRAMELINK_FMT_F32};
    if (!drv_framelink_size_ex(f, &f32))
        return warp_err(err, errlen, "frame cannot be encoded (planes, objects, depth encoding or plane sizes)");
    for (int i = 0; i < 2; i++)
        if (f->cam[i].width > e->w || f->cam[i].height > e->h)
            return warp_err(err, errlen, "eye %d is %dx%d, the encoder was made for %dx%d", i, f->cam[i].width,
                            f->cam[i].height, e->w, e->h);
    e->n_planes = 0;
    for (int t = 0; t < DRV_FRAMELINK_MAX_PLANES; t++) {
        if (!(f->planes & (1u << t))) continue;
        drv_framelink_plane pl = plane_choice(&e->p, t);
        if (t == 1 && pl.format == DRV_FRAMELINK_FMT_INV16 && f->depth_encoding != WARP_DEPTH_LINEAR)
            return warp_err(err, errlen, "INV16 depth needs linear depth (metres); this frame's is window depth");
        if (t == 1 && pl.format == DRV_FRAMELINK_FMT_UNORM16 && f->depth_encoding == WARP_DEPTH_LINEAR)
            return warp_err(err, errlen, "UNORM16 depth needs window depth; this frame's is linear (use INV16)");
        if (t == 0 && pl.codec == DRV_CODEC_JPEG && (pl.slices > f->cam[0].height || pl.slices > f->cam[1].height))
            return warp_err(err, errlen, "%d JPEG slices for eyes of %d and %d rows", pl.slices, f->cam[0].height,
                            f->cam[1].height);
        if (t == 4) pl.param = (unsigned)drv_framelink_layers_deepest(f);
        e->pl[e->n_planes++] = pl;
    }
    return true;
}

static size_t coded_bound(const drv_framelink_plane *pl, const drv_frame *f, int eye, int slice)
{
    return drv_framelink_chunk_bound(pl, f->cam[eye].width, f->cam[eye].height, slice, f->layers[eye].max_layers);
}

size_t drv_framelink_enc_bound(const drv_framelink_enc *e, const drv_frame *f)
{
    drv_framelink_enc tmp = *e; /* enc_plan writes only the plan */
    if (!enc_plan(&tmp, f, NULL, 0)) return 0;
    size_t total = drv_framelink_header_size(f->n_objects, tmp.n_planes) + 4;
    for (int i = 0; i < tmp.n_planes; i++) {
        const drv_framelink_plane *pl = &tmp.pl[i];
        for (int eye = 0; eye < 2; eye++) {
            if (pl->codec == DRV_CODEC_RAW && !pl->scale) {
                total += drv_framelink_eye_bytes(f, pl->type, pl->format, eye);
                continue;
            }
            if (pl->codec == DRV_CODEC_RAW) {
                total += (size_t)drv_depth_scaled(f->cam[eye].width, pl->scale) *
                         (size_t)drv_depth_scaled(f->cam[eye].height, pl->scale) *
                         (size_t)drv_framelink_format_bpp(pl->format);
                continue;
            }
            total += 4 * (size_t)pl->slices;
            for (int k = 0; k < pl->slices; k++) total += coded_bound(pl, f, eye, k);
        }
    }
    return total > UINT32_MAX ? 0 : total;
}

/* An eye of a plane other than colour in its wire bytes (depth downsampled and quantised) into e->raw[s]. */
static size_t enc_wire_eye(drv_framelink_enc *e, const drv_framelink_plane *pl, int eye)
{
    const drv_frame *f = e->f;
    int s = slot(pl->type, eye);
    if (pl->type == 1 && pl->scale) {
        const warp_image_f32 *d = &f->depth[eye];
        int lw = drv_depth_scaled(d->w, pl->scale), lh = drv_depth_scaled(d->h, pl->scale);
        drv_depth_downsample(d->px, d->w, d->h, (size_t)d->stride, pl->scale, f->depth_encoding, e->lo[eye]);
        depth_to_wire(e->lo[eye], (size_t)lw * (size_t)lh, pl->format, f->cam[eye].near_z, e->raw[s]);
        return (size_t)lw * (size_t)lh * (size_t)drv_framelink_format_bpp(pl->format);
    }
    return drv_framelink_put_eye(f, pl->type, pl->format, eye, e->raw[s]);
}

static void enc_run(void *ctx, int i)
{
    drv_framelink_enc *e = ctx;
    enc_task *t = &e->task[i];
    const drv_framelink_plane *pl = &e->pl[t->plane];
    const drv_frame *f = e->f;
    t->len = 0;
    t->why[0] = 0;
    if (pl->type == 0) {
        const warp_image_rgba8 *c = &f->color[t->eye];
        size_t stride = (size_t)c->stride * 4;
        if (pl->codec == DRV_CODEC_JPEG) {
            int y0, y1;
            drv_framelink_slice_rows(c->h, t->slice, pl->slices, &y0, &y1);
            t->len = drv_jpeg_encode(e->jpeg[t->eye * pl->slices + t->slice],
                                     (const uint8_t *)c->px + stride * (size_t)y0, c->w, y1 - y0, stride,
                                     e->p.quality, e->p.jpeg_sub, t->out, t->cap, t->why, WHY_LEN);
        } else {
            t->len = drv_video_encode(e->video[t->eye], (const uint8_t *)c->px, stride, e->force_key, t->out, t->cap,
                                      &t->is_key, t->why, WHY_LEN);
        }
        return;
    }
    size_t n = enc_wire_eye(e, pl, t->eye);
    int s = slot(pl->type, t->eye);
    if (pl->codec == DRV_CODEC_RAW) {
        memcpy(t->out, e->raw[s], n);
        t->len = n;
        return;
    }
    const uint8_t *src = e->raw[s];
    int es = shuffle_size(pl->format);
    if (es > 1) {
        shuffle(e->raw[s], e->shuf[s], n, es);
        src = e->shuf[s];
    }
    size_t r = ZSTD_compress2(e->zc[s], t->out, t->cap, src, n);
    if (ZSTD_isError(r)) {
        snprintf(t->why, WHY_LEN, "zstd: %s", ZSTD_getErrorName(r));
        return;
    }
    t->len = r;
}

/* Grows *p to at least n bytes (host side: encoding may allocate). */
static bool grow(uint8_t **p, size_t *cap, size_t n)
{
    if (*cap >= n) return true;
    uint8_t *q = realloc(*p, n);
    if (!q) return false;
    *p = q, *cap = n;
    return true;
}

size_t drv_framelink_enc_encode(drv_framelink_enc *e, const drv_frame *f, const drv_framelink_tx *tx, bool want_key,
                                uint8_t *buf, size_t cap, char *err, int errlen)
{
    if (!enc_plan(e, f, err, errlen)) return 0;
    bool v1 = true;
    for (int i = 0; i < e->n_planes; i++)
        v1 = v1 && !drv_framelink_plane_coded(&e->pl[i]) && e->pl[i].format != DRV_FRAMELINK_FMT_INV16;
    drv_framelink_tx t = tx ? *tx : (drv_framelink_tx){0};
    if (v1) {
        /* Everything raw: version 1, byte for byte what a version 1 sender writes. */
        t.depth_format = e->p.depth_format;
        size_t n = drv_framelink_encode_ex(f, &t, buf, cap);
        if (!n) warp_err(err, errlen, "frame of %zu bytes does not fit the buffer of %zu", drv_framelink_size_ex(f, &t),
                         cap);
        return n;
    }
    /* One task per chunk; the plain RAW planes are copied straight into buf afterwards. */
    e->f = f;
    e->force_key = want_key || e->need_key;
    e->n_tasks = 0;
    for (int i = 0; i < e->n_planes; i++) {
        const drv_framelink_plane *pl = &e->pl[i];
        if (!drv_framelink_plane_coded(pl)) continue;
        for (int eye = 0; eye < 2; eye++) {
            if (pl->type != 0) {
                int s = slot(pl->type, eye);
                size_t n = drv_framelink_eye_bytes(f, pl->type, pl->format, eye);
                if (!grow(&e->raw[s], &e->raw_cap[s], n) || !grow(&e->shuf[s], &e->shuf_cap[s], n))
                    return warp_err(err, errlen, "out of memory"), 0;
            }
            for (int k = 0; k < pl->slices; k++) {
                enc_task *tk = &e->task[e->n_tasks++];
                tk->plane = i, tk->eye = eye, tk->slice = k;
                size_t b = pl->codec == DRV_CODEC_RAW ? drv_framelink_eye_bytes(f, pl->type, pl->format, eye)
                                                      : coded_bound(pl, f, eye, k);
                if (!grow(&tk->out, &tk->cap, b)) return warp_err(err, errlen, "out of memory"), 0;
            }
        }
    }
    if (e->workers)
        plat_workers_run(e->workers, e->n_tasks, enc_run, e);
    else
        for (int i = 0; i < e->n_tasks; i++) enc_run(e, i);
    bool keys = true, video = false;
    for (int i = 0; i < e->n_tasks; i++) {
        enc_task *tk = &e->task[i];
        if (!tk->len) {
            if (is_video(e->pl[tk->plane].codec)) e->need_key = true; /* the eyes' streams may now disagree */
            return warp_err(err, errlen, "plane type %d eye %d chunk %d: %s", e->pl[tk->plane].type, tk->eye,
                            tk->slice, tk->why[0] ? tk->why : "encoder failed"),
                   0;
        }
        if (is_video(e->pl[tk->plane].codec)) video = true, keys = keys && tk->is_key;
    }
    /* Sizes, then the frame: header, each plane (RAW eyes, or chunk table and chunks), CRCs. */
    size_t hdr = drv_framelink_header_size(f->n_objects, e->n_planes), off = 0;
    int ti = 0;
    for (int i = 0; i < e->n_planes; i++) {
        drv_framelink_plane *pl = &e->pl[i];
        pl->off = off, pl->size = 0, pl->flags = 0;
        if (!drv_framelink_plane_coded(pl)) {
            for (int eye = 0; eye < 2; eye++) pl->size += drv_framelink_eye_bytes(f, pl->type, pl->format, eye);
        } else {
            pl->size = pl->codec == DRV_CODEC_RAW ? 0 : 4 * 2 * (size_t)pl->slices;
            for (int k = 0; k < 2 * pl->slices; k++) pl->size += e->task[ti++].len;
        }
        if (is_video(pl->codec)) {
            pl->param = e->counter & 0xffffu;
            if (keys) pl->flags = DRV_FRAMELINK_DESC_KEY;
        }
        off += pl->size;
    }
    size_t total = hdr + off + 4;
    if (total > cap || total > UINT32_MAX)
        return warp_err(err, errlen, "frame of %zu bytes does not fit the buffer of %zu", total, cap), 0;
    uint8_t *p = buf + hdr;
    ti = 0;
    for (int i = 0; i < e->n_planes; i++) {
        const drv_framelink_plane *pl = &e->pl[i];
        if (!drv_framelink_plane_coded(pl)) {
            for (int eye = 0; eye < 2; eye++) p += drv_framelink_put_eye(f, pl->type, pl->format, eye, p);
            continue;
        }
        int first = ti;
        if (pl->codec != DRV_CODEC_RAW)
            for (int k = 0; k < 2 * pl->slices; k++, p += 4) {
                uint32_t n = (uint32_t)e->task[first + k].len;
                for (int b = 0; b < 4; b++) p[b] = (uint8_t)(n >> (8 * b));
            }
        for (int k = 0; k < 2 * pl->slices; k++, ti++) {
            memcpy(p, e->task[ti].out, e->task[ti].len);
            p += e->task[ti].len;
        }
    }
    if (!drv_framelink_finish(f, &t, DRV_FRAMELINK_VERSION_2, e->pl, e->n_planes, buf, total))
        return warp_err(err, errlen, "frame header cannot be written"), 0;
    if (video) e->counter++, e->need_key = false;
    return total;
}

/* ---- decoder ---- */

typedef struct {
    int plane, eye, slice;
    drv_frame_err err;
    int deepest; /* layers: the deepest pixel decompressed */
    char why[WHY_LEN];
} dec_task;

struct drv_framelink_dec {
    int w, h, threads, max_layers;
    unsigned planes;
    plat_workers *workers;
    ZSTD_DCtx *zd[8];
    uint8_t *zbuf[8], *ubuf[8];
    size_t zcap[8];
    float *lo[2];
    void *upscratch[2];
    float *inv16[2];        /* drv_depth_from_inv16 of every code for the eye's near plane inv16_near[e] (NaN: none */
    double inv16_near[2];   /* yet): a look-up where each pixel cost a double division */
    drv_jpeg *jpeg[DRV_FRAMELINK_MAX_CHUNKS];
    drv_video_dec *video[2][2]; /* [H264, HEVC][eye] */
    /* the video colour stream (frames thread only) */
    bool vseen, dropping;
    unsigned vnext;
    int vcodec, dropped;
    atomic_bool want_key; /* read by the pose thread */
    /* the frame being decoded */
    const drv_framelink_layout *lay;
    drv_frame *out;
    dec_task task[MAX_TASKS]; /* phase 1: chunks */
    dec_task conv[MAX_TASKS]; /* phase 2: eyes of planes other than colour */
    dec_task band[2 * MAX_THREADS]; /* phase 3: bands of rows of reduced depth (slice: the band) */
    int n_tasks, n_conv, n_band;
    bool hook_failed;
    unsigned frame_codecs;
    uint64_t key_requests;
    char video_name[32];
    pthread_mutex_t lock; /* st, for readers on other threads */
    drv_framelink_dec_stats st;
};

drv_framelink_dec *drv_framelink_dec_create(int w, int h, unsigned planes, int max_layers, int threads,
                                            const char *video_hw, char *err, int errlen)
{
    if (w < 1 || h < 1 || w > WARP_MAX_SIDE || h > WARP_MAX_SIDE)
        return warp_err(err, errlen, "eye %dx%d: outside 1..%d", w, h, WARP_MAX_SIDE), NULL;
    if (!(planes & DRV_PLANE_COLOR) || (planes & ~0x1Fu))
        return warp_err(err, errlen, "planes 0x%x: colour missing or unknown bits", planes), NULL;
    if (threads < 1 || threads > MAX_THREADS)
        return warp_err(err, errlen, "decode threads %d: not 1..%d", threads, MAX_THREADS), NULL;
    if ((planes & DRV_PLANE_LAYERS) && (max_layers < 1 || max_layers > 255))
        return warp_err(err, errlen, "max_layers %d: not 1..255", max_layers), NULL;
    drv_framelink_dec *d = calloc(1, sizeof *d);
    if (!d) return warp_err(err, errlen, "out of memory"), NULL;
    pthread_mutex_init(&d->lock, NULL);
    atomic_init(&d->want_key, false);
    d->w = w, d->h = h, d->threads = threads, d->planes = planes, d->max_layers = max_layers;
    size_t px = (size_t)w * (size_t)h;
    if (threads > 1 && !(d->workers = plat_workers_create(threads - 1, 0))) {
        warp_err(err, errlen, "cannot start %d decode threads", threads - 1);
        goto fail;
    }
    /* Every lossless plane the board accepts: a context and room for an eye at the widest format. */
    static const size_t bpp[5] = {0, 4, 2, 8, 0};
    for (int t = 1; t < 5; t++) {
        if (!(planes & (1u << t))) continue;
        size_t n = t == 4 ? px * (1 + (size_t)max_layers * 10) : px * bpp[t];
        for (int e = 0; e < 2; e++) {
            int s = slot(t, e);
            d->zd[s] = ZSTD_createDCtx();
            d->zbuf[s] = malloc(n);
            d->ubuf[s] = t == 4 ? NULL : malloc(n); /* layers are not shuffled */
            d->zcap[s] = n;
            if (!d->zd[s] || !d->zbuf[s] || (t != 4 && !d->ubuf[s])) {
                warp_err(err, errlen, "out of memory (zstd scratch)");
                goto fail;
            }
        }
    }
    d->inv16_near[0] = d->inv16_near[1] = NAN;
    int lw = drv_depth_scaled(w, 1), lh = drv_depth_scaled(h, 1); /* scale 1 is the largest reduced one */
    if (planes & DRV_PLANE_DEPTH)
        for (int e = 0; e < 2; e++)
            if (!(d->lo[e] = malloc(sizeof(float) * (size_t)lw * (size_t)lh)) ||
                !(d->upscratch[e] = malloc(drv_depth_upsample_scratch(lw, lh))) ||
                !(d->inv16[e] = malloc(sizeof(float) * 65536))) {
                warp_err(err, errlen, "out of memory");
                goto fail;
            }
    /* JPEG and video are optional here: a codec this machine lacks is refused per frame (and not announced). */
    for (int i = 0; i < DRV_FRAMELINK_MAX_CHUNKS; i++)
        if (!(d->jpeg[i] = drv_jpeg_create(false, NULL, 0))) break;
    for (int c = 0; c < 2; c++) {
        drv_codec_id codec = c ? DRV_CODEC_HEVC : DRV_CODEC_H264;
        if (!drv_video_can_decode(codec)) continue;
        for (int e = 0; e < 2; e++) {
            char why[WHY_LEN] = "";
            d->video[c][e] = drv_video_dec_create(codec, w, h, video_hw, why, sizeof why);
        }
        if (!d->video[c][0] || !d->video[c][1]) {
            drv_video_dec_destroy(d->video[c][0]), drv_video_dec_destroy(d->video[c][1]);
            d->video[c][0] = d->video[c][1] = NULL;
        }
    }
    return d;
fail:
    drv_framelink_dec_destroy(d);
    return NULL;
}

void drv_framelink_dec_destroy(drv_framelink_dec *d)
{
    if (!d) return;
    if (d->workers) plat_workers_destroy(d->workers);
    for (int i = 0; i < 8; i++) {
        ZSTD_freeDCtx(d->zd[i]);
        free(d->zbuf[i]);
        free(d->ubuf[i]);
    }
    for (int e = 0; e < 2; e++) free(d->lo[e]), free(d->upscratch[e]), free(d->inv16[e]);
    for (int i = 0; i < DRV_FRAMELINK_MAX_CHUNKS; i++) drv_jpeg_destroy(d->jpeg[i]);
    for (int c = 0; c < 2; c++)
        for (int e = 0; e < 2; e++) drv_video_dec_destroy(d->video[c][e]);
    pthread_mutex_destroy(&d->lock);
    free(d);
}

/* Bytes eye e of plane pl decompresses to (fixed formats; layers: at most). */
static size_t wire_eye_bytes(const drv_framelink_plane *pl, int w, int h, int max_layers)
{
    if (pl->type == 4) return (size_t)w * (size_t)h * (1 + (size_t)max_layers * 10);
    return (size_t)drv_depth_scaled(w, pl->scale) * (size_t)drv_depth_scaled(h, pl->scale) *
           (size_t)drv_framelink_format_bpp(pl->format);
}

static drv_frame_err task_fail(dec_task *t, drv_frame_err e, const char *fmt, const char *a)
{
    snprintf(t->why, WHY_LEN, fmt, a);
    return t->err = e;
}

/* Phase 1: one chunk: a JPEG slice or a video access unit straight into the colour plane, or a zstd frame into
 * the eye's scratch (checked against the plane before it is decompressed). */
static void dec_chunk(void *ctx, int i)
{
    drv_framelink_dec *d = ctx;
    dec_task *t = &d->task[i];
    const drv_framelink_plane *pl = &d->lay->pl[t->plane];
    int e = t->eye, w = d->lay->w[e], h = d->lay->h[e];
    int c = e * pl->slices + t->slice;
    const uint8_t *src = pl->chunk[c];
    size_t len = pl->chunk_len[c];
    t->err = DRV_FRAME_OK;
    t->why[0] = 0;
    if (pl->type == 0) {
        warp_image_rgba8 *img = &d->out->color[e];
        size_t stride = (size_t)img->stride * 4;
        if (pl->codec == DRV_CODEC_JPEG) {
            int y0, y1;
            drv_framelink_slice_rows(h, t->slice, pl->slices, &y0, &y1);
            t->err = drv_jpeg_decode(d->jpeg[c], src, len, (uint8_t *)img->px + stride * (size_t)y0, w, y1 - y0,
                                     stride, t->why, WHY_LEN);
        } else {
            t->err = drv_video_decode(d->video[video_index(pl->codec)][e], src, len, (uint8_t *)img->px, stride,
                                      t->why, WHY_LEN);
        }
        return;
    }
    int s = slot(pl->type, e);
    size_t want = wire_eye_bytes(pl, w, h, pl->type == 4 ? d->out->layers[e].max_layers : 0);
    unsigned long long declared = ZSTD_getFrameContentSize(src, len);
    if (declared == ZSTD_CONTENTSIZE_ERROR) {
        task_fail(t, DRV_FRAME_ERR_BAD_FORMAT, "%s", "not a zstd frame");
        return;
    }
    if (declared == ZSTD_CONTENTSIZE_UNKNOWN) {
        task_fail(t, DRV_FRAME_ERR_BAD_FORMAT, "%s", "zstd frame without its content size");
        return;
    }
    if (pl->type == 4 ? declared > want || declared > d->zcap[s] : declared != want) {
        snprintf(t->why, WHY_LEN, "zstd frame declares %llu bytes, the eye's plane %s %zu", declared,
                 pl->type == 4 ? "holds at most" : "is", want);
        t->err = DRV_FRAME_ERR_BAD_SIZE;
        return;
    }
    size_t fsize = ZSTD_findFrameCompressedSize(src, len);
    if (ZSTD_isError(fsize) || fsize != len) {
        task_fail(t, DRV_FRAME_ERR_BAD_FORMAT, "zstd frame: %s",
                  ZSTD_isError(fsize) ? ZSTD_getErrorName(fsize) : "bytes after its end");
        return;
    }
    size_t r = ZSTD_decompressDCtx(d->zd[s], d->zbuf[s], (size_t)declared, src, len);
    if (ZSTD_isError(r) || r != declared) {
        task_fail(t, DRV_FRAME_ERR_BAD_FORMAT, "zstd: %s", ZSTD_isError(r) ? ZSTD_getErrorName(r) : "short frame");
        return;
    }
    if (pl->type == 4) {
        t->deepest = 0;
        size_t b = drv_framelink_layers_check(d->zbuf[s], r, w, h, d->out->layers[e].max_layers, &t->deepest);
        if (b != r) {
            snprintf(t->why, WHY_LEN, "eye %d layers: counts above the %d allocated or fragments not adding up", e,
                     d->out->layers[e].max_layers);
            t->err = DRV_FRAME_ERR_BAD_SIZE;
        }
    }
}

/* Phase 2: an eye of a plane other than colour from its wire bytes into the frame (depth upsampled, guided by the
 * eye's decoded colour). */
static void dec_convert(void *ctx, int i)
{
    drv_framelink_dec *d = ctx;
    dec_task *t = &d->conv[i];
    const drv_framelink_plane *pl = &d->lay->pl[t->plane];
    int e = t->eye, w = d->lay->w[e], h = d->lay->h[e], s = slot(pl->type, e);
    double near_z = d->lay->near_z[e];
    const bool inv16 = pl->type == 1 && pl->format == DRV_FRAMELINK_FMT_INV16;
    const uint8_t *p;
    if (pl->codec == DRV_CODEC_ZSTD) {
        size_t n = pl->type == 4 ? 0 : wire_eye_bytes(pl, w, h, 0);
        int es = shuffle_size(pl->format);
        p = d->zbuf[s];
        if (es > 1 && !inv16) { /* INV16 is read from its two byte planes below, without the copy */
            unshuffle(d->zbuf[s], d->ubuf[s], n, es);
            p = d->ubuf[s];
        }
    } else {
        /* RAW at a reduced scale: eye 1 follows eye 0 in the plane */
        p = pl->data + (e ? wire_eye_bytes(pl, d->lay->w[0], d->lay->h[0], 0) : 0);
    }
    const int lw = drv_depth_scaled(w, pl->scale), lh = drv_depth_scaled(h, pl->scale);
    if (inv16) {
        /* Every code through the eye's table of drv_depth_from_inv16 (auto's depth: a double division per pixel
         * cost more than zstd); zstd's bytes as its two byte planes, raw ones interleaved. */
        if (!(d->inv16_near[e] == near_z)) {
            for (int v = 0; v < 65536; v++) d->inv16[e][v] = drv_depth_from_inv16((uint16_t)v, near_z);
            d->inv16_near[e] = near_z;
        }
        const size_t n = (size_t)lw * (size_t)lh, step = pl->codec == DRV_CODEC_ZSTD ? 1 : 2;
        const uint8_t *hi = pl->codec == DRV_CODEC_ZSTD ? p + n : p + 1;
        if (!pl->scale) {
            for (int y = 0; y < h; y++)
                inv16_run(d->inv16[e], p + (size_t)y * (size_t)w * step, hi + (size_t)y * (size_t)w * step, step,
                          (size_t)w, &WARP_AT(&d->out->depth[e], 0, y));
            return;
        }
        inv16_run(d->inv16[e], p, hi, step, n, d->lo[e]);
    } else if (pl->type != 1 || !pl->scale) {
        drv_framelink_get_eye(d->out, pl->type, pl->format, e, w, h, near_z, p);
        return;
    } else {
        depth_from_wire(p, (size_t)lw * (size_t)lh, pl->format, d->lo[e]);
    }
    drv_depth_upsample_prepare(d->lo[e], lw, lh, d->lay->depth_encoding, d->upscratch[e]);
}

/* Phase 3: a band of rows of a reduced depth plane upsampled (the bands of both eyes spread over every thread). */
static void dec_upsample(void *ctx, int i)
{
    drv_framelink_dec *d = ctx;
    const dec_task *t = &d->band[i];
    const drv_framelink_plane *pl = &d->lay->pl[t->plane];
    int e = t->eye, w = d->lay->w[e], h = d->lay->h[e], y0, y1;
    drv_framelink_slice_rows(h, t->slice, d->threads, &y0, &y1);
    warp_image_f32 *dst = &d->out->depth[e];
    drv_depth_upsample_rows(d->lo[e], drv_depth_scaled(w, pl->scale), drv_depth_scaled(h, pl->scale), pl->scale,
                            d->lay->depth_encoding, &d->out->color[e], dst->px, w, h, (size_t)dst->stride, y0, y1,
                            d->upscratch[e]);
}

static void raise_want_key(drv_framelink_dec *d)
{
    atomic_store(&d->want_key, true);
    d->key_requests++;
    d->dropped = 0;
}

/* The video colour stream's continuity before its chunks are decoded: a gap in the counter (a frame lost on the way)
 * or a new stream needs a key frame; until one arrives frames are dropped and a key frame is asked for. */
static drv_frame_err video_gate(drv_framelink_dec *d, const drv_framelink_plane *pl, char *detail, int dl)
{
    int vi = video_index(pl->codec);
    if (!d->video[vi][0])
        return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "no %s decoder on this board",
                              drv_codec_name((drv_codec_id)pl->codec));
    bool key = pl->flags & DRV_FRAMELINK_DESC_KEY;
    bool gap = !d->vseen || pl->param != d->vnext || pl->codec != d->vcodec;
    unsigned expected = d->vnext;
    d->vseen = true, d->vnext = (pl->param + 1) & 0xffffu, d->vcodec = pl->codec;
    if (!key && (gap || d->dropping)) {
        if (!d->dropping || ++d->dropped >= WANT_KEY_REPEAT) raise_want_key(d);
        d->dropping = true;
        if (gap)
            return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT,
                                  "%s frame %u, expected %u: a reference is missing, dropped until a key frame",
                                  drv_codec_name((drv_codec_id)pl->codec), pl->param, expected);
        return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "%s frame %u dropped: waiting for a key frame",
                              drv_codec_name((drv_codec_id)pl->codec), pl->param);
    }
    if (key && (gap || d->dropping))
        for (int e = 0; e < 2; e++) drv_video_dec_reset(d->video[vi][e]);
    if (!d->video_name[0]) snprintf(d->video_name, sizeof d->video_name, "%s", drv_video_dec_name(d->video[vi][0]));
    return DRV_FRAME_OK;
}

static void run_tasks(drv_framelink_dec *d, plat_task_fn fn, int n)
{
    if (d->workers && n > 1)
        plat_workers_run(d->workers, n, fn, d);
    else
        for (int i = 0; i < n; i++) fn(d, i);
}

static drv_frame_err dec_planes(void *ctx, const drv_framelink_layout *lay, drv_frame *out, char *detail, int dl)
{
    drv_framelink_dec *d = ctx;
    d->hook_failed = true; /* until it returns OK: every failure below is the codecs' */
    d->lay = lay, d->out = out;
    for (int e = 0; e < 2; e++)
        if (lay->w[e] > d->w || lay->h[e] > d->h)
            return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_SIZE, "eye %d is %dx%d, the decoder was made for %dx%d",
                                  e, lay->w[e], lay->h[e], d->w, d->h);
    const drv_framelink_plane *video = NULL;
    d->n_tasks = d->n_conv = d->n_band = 0;
    for (int i = 0; i < lay->n_planes; i++) {
        const drv_framelink_plane *pl = &lay->pl[i];
        d->frame_codecs |= DRV_CODEC_BIT(pl->codec);
        if (!drv_framelink_plane_coded(pl)) continue;
        if (pl->type != 0 && !d->zd[slot(pl->type, 0)])
            return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "plane type %d: no scratch for it", pl->type);
        if (pl->codec == DRV_CODEC_JPEG && !d->jpeg[DRV_FRAMELINK_MAX_CHUNKS - 1])
            return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_FORMAT, "no JPEG decoder on this board");
        if (is_video(pl->codec)) video = pl;
        for (int e = 0; e < 2; e++) {
            if (pl->codec != DRV_CODEC_RAW)
                for (int k = 0; k < pl->slices; k++)
                    d->task[d->n_tasks++] = (dec_task){.plane = i, .eye = e, .slice = k};
            if (pl->type != 0) d->conv[d->n_conv++] = (dec_task){.plane = i, .eye = e};
            for (int k = 0; pl->type == 1 && pl->scale && k < d->threads; k++)
                d->band[d->n_band++] = (dec_task){.plane = i, .eye = e, .slice = k};
        }
    }
    if (video) {
        drv_frame_err ve = video_gate(d, video, detail, dl);
        if (ve) return ve;
    }
    /* Phase 1: every chunk (colour straight into the frame, zstd into scratch), in parallel. */
    run_tasks(d, dec_chunk, d->n_tasks);
    for (int i = 0; i < d->n_tasks; i++) {
        const dec_task *t = &d->task[i];
        const drv_framelink_plane *pl = &lay->pl[t->plane];
        if (!t->err) continue;
        if (is_video(pl->codec)) {
            d->dropping = true;
            raise_want_key(d);
        }
        return drv_frame_fail(detail, dl, t->err, "plane type %d (%s) eye %d chunk %d: %s", pl->type,
                              drv_codec_name((drv_codec_id)pl->codec), t->eye, t->slice, t->why);
    }
    if (video) d->dropping = false;
    /* Layers sent with zstd: the descriptor's depth against both eyes' counts. */
    for (int i = 0; i < lay->n_planes; i++) {
        const drv_framelink_plane *pl = &lay->pl[i];
        if (pl->type != 4 || pl->codec != DRV_CODEC_ZSTD) continue;
        int deepest = 0;
        for (int k = 0; k < d->n_tasks; k++)
            if (d->task[k].plane == i && d->task[k].deepest > deepest) deepest = d->task[k].deepest;
        if (deepest != (int)pl->param)
            return drv_frame_fail(detail, dl, DRV_FRAME_ERR_BAD_SIZE, "layers descriptor says %u deep, counts reach %d",
                                  pl->param, deepest);
    }
    /* Phase 2: every eye of every coded plane but colour into the frame (depth guided by the decoded colour). */
    run_tasks(d, dec_convert, d->n_conv);
    run_tasks(d, dec_upsample, d->n_band);
    d->hook_failed = false;
    return DRV_FRAME_OK;
}

drv_frame_err drv_framelink_dec_decode(drv_framelink_dec *d, const uint8_t *buf, size_t len, size_t max_frame,
                                       drv_frame *out, drv_framelink_rx *rx, char *detail, int detail_len)
{
    int64_t t0 = plat_now_ns();
    drv_framelink_hook hook = {dec_planes, d};
    d->hook_failed = false;
    d->frame_codecs = 0;
    drv_framelink_rx r;
    drv_frame_err e = drv_framelink_decode_hooked(buf, len, max_frame, out, &r, detail, detail_len, &hook);
    double ms = (double)(plat_now_ns() - t0) * 1e-6;
    pthread_mutex_lock(&d->lock);
    d->st.key_requests = d->key_requests;
    if (d->video_name[0] && !d->st.video_decoder[0])
        snprintf(d->st.video_decoder, sizeof d->st.video_decoder, "%s", d->video_name);
    if (e == DRV_FRAME_OK) {
        /* no coded plane: the hook was not called, every plane was RAW */
        unsigned codecs = d->frame_codecs ? d->frame_codecs : DRV_CODEC_BIT(DRV_CODEC_RAW);
        d->st.frames++;
        if (codecs & ~DRV_CODEC_BIT(DRV_CODEC_RAW)) d->st.compressed_frames++;
        d->st.codecs_seen |= codecs;
        d->st.wire_bytes += r.total_bytes;
        for (int i = 0; i < 2; i++) {
            size_t px = (size_t)out->cam[i].width * (size_t)out->cam[i].height;
            /* what the planes hold in memory (layers: their counts) */
            d->st.plane_bytes += px * (4 + (out->planes & DRV_PLANE_DEPTH ? 4 : 0) +
                                       (out->planes & DRV_PLANE_IDS ? 2 : 0) +
                                       (out->planes & DRV_PLANE_MOTION ? 8 : 0) +
                                       (out->planes & DRV_PLANE_LAYERS ? 1 : 0));
        }
        d->st.decode_ms_last = ms;
        if (rx) *rx = r;
    } else if (d->hook_failed) {
        d->st.codec_errors++;
    }
    pthread_mutex_unlock(&d->lock);
    return e;
}

bool drv_framelink_dec_take_want_key(drv_framelink_dec *d) { return atomic_exchange(&d->want_key, false); }

void drv_framelink_dec_stats_get(const drv_framelink_dec *d, drv_framelink_dec_stats *st)
{
    pthread_mutex_lock((pthread_mutex_t *)&d->lock);
    *st = d->st;
    pthread_mutex_unlock((pthread_mutex_t *)&d->lock);
}
