/* SPDX-License-Identifier: MIT */
/* drv_frames_usb: host frames over USB, the board being a FunctionFS gadget (bulk OUT frames, bulk IN poses); the
 * board side runs on any drv_usb_transport (the mock's socket pairs are in drv_frames_usb_mock.c). */
#include "drivers/drv_frames_usb.h"

#include <endian.h>
#include <errno.h>
#include <fcntl.h>
#include <linux/aio_abi.h>
#include <linux/usb/functionfs.h>
#include <math.h>
#include <poll.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/eventfd.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

#include "drivers/drv_codec.h"
#include "drivers/drv_framelink.h"
#include "drivers/drv_framelink_codec.h"
#include "drivers/drv_usb_speed.h"
#include "platform/plat_clock.h"
#include "platform/plat_log.h"
#include "warp/warp_err.h"
#include "warp/warp_head.h"

#define CHUNK (256 * 1024)        /* bytes per receive step: a multiple of every bulk max packet size */
#define FFS_READ (64 * 1024)      /* bytes per FunctionFS read request (the kernel allocates it contiguously) */
/* The IN endpoint's one write buffer holds the largest message the board sends: a pose, the camera message or a
 * full visibility mask (the mask is five times a pose; a buffer sized for poses dropped every mask unsent). */
#define FFS_WRITE_MAX                                                                                                  \
    (DRV_FRAMELINK_MASK_BYTES(DRV_FRAMELINK_MASK_MAX, DRV_FRAMELINK_MASK_MAX) > DRV_FRAMELINK_POSE_BYTES               \
         ? DRV_FRAMELINK_MASK_BYTES(DRV_FRAMELINK_MASK_MAX, DRV_FRAMELINK_MASK_MAX)                                    \
         : DRV_FRAMELINK_POSE_BYTES)
_Static_assert(FFS_WRITE_MAX >= DRV_FRAMELINK_CAMS_BYTES, "the camera message fits the IN buffer");
#define LEAD_START_MS 20.0
#define LEAD_MIN_MS 2.0
#define LEAD_MAX_MS 200.0
#define DECODE_THREADS_DEFAULT 2
#define MAX_LAYERS_DEFAULT 4 /* what rt_app allocates its frame slots with */
/* A video stream that lost a reference asks for a key frame in the pose messages of the next quarter second (at
 * least 8): several, since a pose message the host did not take in time is dropped, and not forever, since a host
 * that ignores the flag must not keep it on. The request ends early once a frame decodes again: the decoder drops
 * every frame of the stream until its key frame, so an accepted frame means the key frame came. */
#define WANT_KEY_S 0.25
#define WANT_KEY_MIN_POSES 8

/* ---- the board side (the same on every transport) ---- */

/* software: libavcodec's own decoders (NULL to drv_framelink_dec_create); v4l2m2m: the board's hardware one. */
const char *const drv_frames_usb_video_decoders[] = {"software", "v4l2m2m", NULL};

typedef struct {
    drv_frames base;
    drv_frames_usb_params p;
    drv_usb_transport *t;
    uint8_t *buf;              /* receive buffer: one frame plus one read */
    size_t cap, have;
    uint8_t *scratch;          /* oversize frames are read here and dropped */
    size_t discard_left;
    bool resyncing;            /* garbage after a reported rejection is skipped silently */
    drv_frame_err first_err;

    pthread_t pose_th;
    bool pose_up;
    atomic_bool stop;
    _Atomic int64_t lead_ns;
    pthread_mutex_t lock;      /* stats */
    drv_frames_usb_stats st;
    uint32_t pose_seq, cams_seq;
    bool send_cams;            /* the params name the cameras: hosts get the camera message */
    drv_framelink_dec *dec;    /* v1 and v2 frames, compressed planes decoded on its threads */
    double decode_ms;          /* the last frame returned (receiving thread only) */
    atomic_int want_key_poses; /* pose messages still to carry DRV_FRAMELINK_POSE_WANT_KEY */
} usb_frames;

static void note(usb_frames *u, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void note(usb_frames *u, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    drv_frames_vnote(&u->lock, u->st.last_error, (int)sizeof u->st.last_error, fmt, ap);
    va_end(ap);
}

static void drop(usb_frames *u, size_t n)
{
    if (n >= u->have) {
        u->have = 0;
        return;
    }
    memmove(u->buf, u->buf + n, u->have - n);
    u->have -= n;
}

/* A rejected frame: counted, named in last_error; the stream resynchronises from the frame's second byte on. */
static int reject(usb_frames *u, drv_frame_err e, size_t skip, bool resync, const char *detail)
{
    pthread_mutex_lock(&u->lock);
    u->st.rejected[e]++;
    snprintf(u->st.last_error, sizeof u->st.last_error, "%s frames: frame rejected: %s%s%s", u->base.name,
             drv_frame_err_str(e), detail && detail[0] ? ": " : "", detail ? detail : "");
    pthread_mutex_unlock(&u->lock);
    drop(u, skip);
    u->resyncing = resync;
    return -(int)e;
}

static void link_lost(usb_frames *u, ssize_t rc)
{
    pthread_mutex_lock(&u->lock);
    u->st.disconnects++;
    snprintf(u->st.last_error, sizeof u->st.last_error, "%s frames: frame stream (OUT): %s (partial frame dropped)",
             u->base.name, strerror((int)-rc));
    pthread_mutex_unlock(&u->lock);
    u->have = 0;
    u->discard_left = 0;
    u->resyncing = false;
    plat_sleep_ns(10 * PLAT_NS_PER_MS); /* a persistent failure must not spin */
}

/* The receive state machine, apart from the transport: what is buffered is parsed by stream_parse, the next read
 * goes where stream_space says, and stream_got accounts for it. usb_receive drives it from the endpoint, and
 * drv_frames_usb_feed from memory (tests, the fuzzer), so both run the same code. */

/* After each decode: the decoder's counters into the stats, and a key frame request into the pose messages. */
static void decoded(usb_frames *u, drv_frame_err e)
{
    drv_framelink_dec_stats ds;
    drv_framelink_dec_stats_get(u->dec, &ds);
    if (drv_framelink_dec_take_want_key(u->dec)) {
        int n = (int)(u->p.pose_rate_hz * WANT_KEY_S);
        atomic_store(&u->want_key_poses, n < WANT_KEY_MIN_POSES ? WANT_KEY_MIN_POSES : n);
    } else if (e == DRV_FRAME_OK) {
        atomic_store(&u->want_key_poses, 0);
    }
    u->decode_ms = ds.decode_ms_last;
    pthread_mutex_lock(&u->lock);
    u->st.dec = ds;
    pthread_mutex_unlock(&u->lock);
}

/* 1 when a frame was stored in *f, -drv_frame_err when one was rejected, 0 when more bytes are needed. */
static int stream_parse(usb_frames *u, drv_frame *f)
{
    if (u->discard_left != 0 || u->have == 0) return 0;
    size_t k = drv_framelink_find_magic(u->buf, u->have);
    if (k > 0) {
        pthread_mutex_lock(&u->lock);
        u->st.skipped_bytes += k;
        pthread_mutex_unlock(&u->lock);
        drop(u, k);
        if (!u->resyncing) return reject(u, DRV_FRAME_ERR_BAD_MAGIC, 0, true, "garbage between frames");
    }
    size_t total = 0;
    drv_frame_err e = drv_framelink_peek(u->buf, u->have, u->p.max_frame_bytes, &total);
    if (e == DRV_FRAME_ERR_TOO_LARGE) {
        /* A sound header for a frame too big to keep: skip exactly its bytes, never storing them. */
        size_t in_buf = u->have < total ? u->have : total;
        u->discard_left = total - in_buf;
        pthread_mutex_lock(&u->lock);
        u->st.discarded_bytes += in_buf;
        pthread_mutex_unlock(&u->lock);
        char d[80];
        snprintf(d, sizeof d, "%zu bytes, limit %zu", total, u->p.max_frame_bytes);
        return reject(u, e, in_buf, false, d);
    }
    if (e == DRV_FRAME_OK && u->have >= total) {
        char detail[160];
        drv_framelink_rx rx;
        e = drv_framelink_dec_decode(u->dec, u->buf, total, u->p.max_frame_bytes, f, &rx, detail, sizeof detail);
        decoded(u, e);
        if (e != DRV_FRAME_OK) return reject(u, e, 1, true, detail);
        f->received_ns = plat_now_ns();
        drop(u, total);
        u->resyncing = false;
        e = drv_frame_validate(f);
        if (e != DRV_FRAME_OK) return reject(u, e, 0, false, "content invalid");
        if (rx.tx.pose_sent_ns > 0 && f->received_ns > rx.tx.pose_sent_ns) {
            /* The lead the next poses are predicted with: how long the host took to answer one. */
            double ms = (double)(f->received_ns - rx.tx.pose_sent_ns) * 1e-6;
            double lead = (double)atomic_load(&u->lead_ns) * 1e-6;
            lead = 0.9 * lead + 0.1 * (ms < LEAD_MIN_MS ? LEAD_MIN_MS : ms > LEAD_MAX_MS ? LEAD_MAX_MS : ms);
            atomic_store(&u->lead_ns, (int64_t)(lead * 1e6));
        }
        pthread_mutex_lock(&u->lock);
        u->st.frames++;
        pthread_mutex_unlock(&u->lock);
        return 1;
    }
    if (e != DRV_FRAME_OK && e != DRV_FRAME_ERR_TRUNCATED) return reject(u, e, 1, true, "bad header");
    return 0;
}

/* Where the next bytes of the stream go (*dst) and how many fit. */
static size_t stream_space(usb_frames *u, uint8_t **dst)
{
    if (u->discard_left) {
        *dst = u->scratch;
        return u->discard_left < CHUNK ? u->discard_left : CHUNK;
    }
    if (u->have == u->cap) drop(u, 1); /* cannot happen (frames fit the buffer); never stall on a full buffer */
    *dst = u->buf + u->have;
    return u->cap - u->have < CHUNK ? u->cap - u->have : CHUNK;
}

/* n bytes arrived where stream_space said. */
static void stream_got(usb_frames *u, size_t n)
{
    pthread_mutex_lock(&u->lock);
    u->st.bytes += (uint64_t)n;
    if (u->discard_left) u->st.discarded_bytes += (uint64_t)n;
    pthread_mutex_unlock(&u->lock);
    if (u->discard_left)
        u->discard_left -= n;
    else
        u->have += n;
}

static int usb_receive(drv_frames *fr, drv_frame *f, int timeout_ms)
{
    usb_frames *u = (usb_frames *)fr;
    int64_t deadline = plat_now_ns() + (int64_t)timeout_ms * PLAT_NS_PER_MS;
    for (;;) {
        int r = stream_parse(u, f);
        if (r != 0) return r;
        int64_t left = deadline - plat_now_ns();
        if (left <= 0) return 0;
        uint8_t *dst;
        size_t want = stream_space(u, &dst);
        ssize_t n = u->t->read(u->t, dst, want, (int)((left + PLAT_NS_PER_MS - 1) / PLAT_NS_PER_MS));
        if (n < 0) {
            link_lost(u, n);
            continue; /* the transport waits for the link up to the deadline */
        }
        if (n > 0) stream_got(u, (size_t)n);
    }
}

static void usb_last_error(drv_frames *fr, char *buf, int len);

static unsigned usb_planes(drv_frames *fr) { return ((usb_frames *)fr)->p.planes; }

/* One message to the host on the IN endpoint: counted as sent (or as dropped, where the caller counts those), a
 * failed link named in last_error. What every board-to-host message does, so the counters cannot drift apart. */
static bool send_msg(usb_frames *u, const uint8_t *msg, size_t n, int timeout_ms, uint64_t *sent, uint64_t *dropped,
                     const char *what)
{
    ssize_t rc = u->t->write(u->t, msg, n, timeout_ms);
    pthread_mutex_lock(&u->lock);
    if (rc == (ssize_t)n)
        (*sent)++;
    else if (dropped)
        (*dropped)++;
    if (rc < 0)
        snprintf(u->st.last_error, sizeof u->st.last_error, "%s frames: %s (IN): %s", u->base.name, what,
                 strerror((int)-rc));
    pthread_mutex_unlock(&u->lock);
    return rc == (ssize_t)n;
}

/* The camera message (HWC1): what this board wants rendered, so a host need not be told by hand. */
static bool send_cams(usb_frames *u, int timeout_ms)
{
    drv_framelink_cams c = {.seq = ++u->cams_seq, .planes = u->p.planes, .depth_encoding = u->p.depth_encoding,
                            .max_frame_bytes = u->p.max_frame_bytes, .refresh_hz = u->p.refresh_hz,
                            .pose_rate_hz = u->p.pose_rate_hz, .cam = {u->p.cam[0], u->p.cam[1]},
                            .codecs = u->p.codecs};
    uint8_t msg[DRV_FRAMELINK_CAMS_BYTES];
    drv_framelink_cams_encode(&c, msg, sizeof msg);
    return send_msg(u, msg, sizeof msg, timeout_ms, &u->st.cams_sent, NULL, "camera message");
}

/* The visibility mask (HWV1) that follows each camera message (a host clears the mask it had when a camera message
 * comes). Sent on its own and retried before later poses, so a mask that does not go out never holds back the
 * greeting or a pose. Masks once never crossed real USB because the IN endpoint's write buffer was sized for poses
 * and refused the longer mask (FFS_WRITE_MAX now holds a full one), not because of when the host reads. */
static bool send_mask(usb_frames *u, int timeout_ms)
{
    drv_framelink_mask m = u->p.mask;
    m.seq = u->cams_seq;
    uint8_t mb[DRV_FRAMELINK_MASK_BYTES(DRV_FRAMELINK_MASK_MAX, DRV_FRAMELINK_MASK_MAX)];
    size_t n = drv_framelink_mask_encode(&m, mb, sizeof mb);
    if (!n) return true; /* counts out of range: rt_devices never sets such */
    return send_msg(u, mb, n, timeout_ms, &u->st.masks_sent, NULL, "visibility mask message");
}

static void *pose_thread(void *arg)
{
    usb_frames *u = arg;
    plat_thread_set_name("hmdwarp-poses");
    warp_head head = u->p.head.ipd > 0 ? u->p.head : warp_head_default();
    int64_t period = (int64_t)(1e9 / u->p.pose_rate_hz), next = plat_now_ns(), next_cams = 0;
    int timeout_ms = (int)(period / PLAT_NS_PER_MS) + 1;
    uint64_t greeted = 0; /* the hosts greeted with the camera message so far */
    bool mask_due = false; /* the visibility mask has not followed the latest camera message yet */
    bool was_up = false;
    while (!atomic_load(&u->stop)) {
        next += period;
        int64_t now = plat_now_ns();
        if (next < now) next = now; /* fell behind (host stalled a write): no burst to catch up */
        plat_sleep_until_ns(next);
        if (atomic_load(&u->stop)) break;
        if (!u->t->connected(u->t)) {
            was_up = false;
            continue;
        }
        /* A new host hears the cameras first, before any pose; every host again once a second. A greeting that did
         * not go out (USB: the host enabled the function but is not reading yet) is sent again before the next
         * pose, so no pose overtakes it: a host renders its first frame knowing the cameras and the codecs. */
        uint64_t hosts = u->t->connections ? u->t->connections(u->t) : greeted + !was_up;
        if (u->send_cams && (hosts != greeted || plat_now_ns() >= next_cams)) {
            if (send_cams(u, timeout_ms)) {
                next_cams = plat_now_ns() + PLAT_NS_PER_S;
                mask_due = u->p.mask.n[0] || u->p.mask.n[1];
            } else if (hosts != greeted) {
                continue; /* not greeted: was_up and greeted stay, so the next period greets again */
            }
        }
        if (mask_due && send_mask(u, timeout_ms)) mask_due = false;
        was_up = true;
        greeted = hosts;
        drv_framelink_pose m = {.flags = 0};
        m.board_t_ns = plat_now_ns();
        m.target_t_ns = m.board_t_ns + atomic_load(&u->lead_ns);
        if (!u->p.poses.predict(u->p.poses.ctx, m.target_t_ns, &m.head)) continue;
        /* (the frames thread may set a new count meanwhile: then this one is not spent) */
        int want_key = atomic_load(&u->want_key_poses);
        if (want_key > 0) {
            m.flags |= DRV_FRAMELINK_POSE_WANT_KEY;
            atomic_compare_exchange_strong(&u->want_key_poses, &want_key, want_key - 1);
        }
        m.seq = ++u->pose_seq;
        for (int e = 0; e < 2; e++) m.eye[e] = warp_head_eye_pose(&head, m.head, e);
        uint8_t msg[DRV_FRAMELINK_POSE_BYTES];
        drv_framelink_pose_encode(&m, msg, sizeof msg);
        send_msg(u, msg, sizeof msg, timeout_ms, &u->st.poses_sent, &u->st.poses_dropped, "pose messages");
    }
    return NULL;
}

static void usb_destroy(drv_frames *fr)
{
    usb_frames *u = (usb_frames *)fr;
    atomic_store(&u->stop, true);
    if (u->pose_up) pthread_join(u->pose_th, NULL);
    if (u->t) u->t->destroy(u->t);
    pthread_mutex_destroy(&u->lock);
    drv_framelink_dec_destroy(u->dec);
    free(u->buf);
    free(u->scratch);
    free(u);
}

static usb_frames *board_new(const drv_frames_usb_params *p, char *err, int errlen)
{
    if (!p->poses.predict || !(p->pose_rate_hz > 0) || p->eye_w <= 0 || p->eye_h <= 0 ||
        !(p->planes & DRV_PLANE_COLOR) || p->max_frame_bytes < 1024) {
        warp_err(err, errlen, "usb frames: bad parameters (need a pose source, pose_rate_hz > 0, eye size, colour, "
                              "max_frame_bytes >= 1024)");
        return NULL;
    }
    /* Cameras are optional (tests of the receive path leave them out), but when given they must describe the
     * frames accepted: a host renders what the camera message says. */
    bool cams = p->cam[0].width > 0;
    for (int e = 0; e < 2 && cams; e++)
        if (warp_camera_check(&p->cam[e]) || p->cam[e].width != p->eye_w || p->cam[e].height != p->eye_h ||
            !(p->refresh_hz > 0)) {
            warp_err(err, errlen, "usb frames: bad parameters (eye %d camera: %s, %dx%d for %dx%d eyes, refresh %g Hz)",
                     e, warp_camera_check(&p->cam[e]) ? warp_camera_check(&p->cam[e]) : "valid", p->cam[e].width,
                     p->cam[e].height, p->eye_w, p->eye_h, p->refresh_hz);
            return NULL;
        }
    unsigned decodable = drv_codec_decodable();
    if (p->codecs & ~decodable) {
        drv_codec_id lack = drv_codec_missing(p->codecs, decodable);
        if (lack != DRV_CODEC_COUNT)
            warp_err(err, errlen, "usb frames: codec %s: not decodable in this build", drv_codec_name(lack));
        else
            warp_err(err, errlen, "usb frames: codecs 0x%x: unknown codec bits", p->codecs);
        return NULL;
    }
    if (p->decode_threads < 0 || p->decode_threads > DRV_FRAMES_USB_DECODE_THREADS_MAX || p->max_layers < 0) {
        warp_err(err, errlen, "usb frames: bad parameters (decode_threads %d: want 1..%d; max_layers %d)",
                 p->decode_threads, DRV_FRAMES_USB_DECODE_THREADS_MAX, p->max_layers);
        return NULL;
    }
    const char *vdec = p->video_decoder && p->video_decoder[0] ? p->video_decoder : "software";
    int v = 0;
    while (drv_frames_usb_video_decoders[v] && strcmp(vdec, drv_frames_usb_video_decoders[v]) != 0) v++;
    if (!drv_frames_usb_video_decoders[v]) {
        warp_err(err, errlen, "usb frames: video decoder '%s': want software or v4l2m2m", vdec);
        return NULL;
    }
    char e[200] = "";
    drv_framelink_dec *dec = drv_framelink_dec_create(
        p->eye_w, p->eye_h, p->planes, p->max_layers ? p->max_layers : MAX_LAYERS_DEFAULT,
        p->decode_threads ? p->decode_threads : DECODE_THREADS_DEFAULT,
        strcmp(vdec, "software") == 0 ? NULL : vdec, e, sizeof e);
    if (!dec) {
        warp_err(err, errlen, "usb frames: framelink decoder: %s", e[0] ? e : "cannot create");
        return NULL;
    }
    usb_frames *u = calloc(1, sizeof *u);
    if (!u) {
        drv_framelink_dec_destroy(dec);
        return NULL;
    }
    u->p = *p;
    u->p.codecs = p->codecs ? p->codecs : decodable;
    u->p.codecs |= DRV_CODEC_BIT(DRV_CODEC_RAW); /* v1 frames are always read */
    u->dec = dec;
    u->st.codecs = u->p.codecs;
    u->send_cams = cams;
    u->cap = p->max_frame_bytes + CHUNK;
    u->buf = malloc(u->cap);
    u->scratch = malloc(CHUNK);
    if (!u->buf || !u->scratch) {
        drv_framelink_dec_destroy(u->dec);
        free(u->buf);
        free(u->scratch);
        warp_err(err, errlen, "usb frames: cannot allocate a %zu byte receive buffer", u->cap);
        free(u);
        return NULL;
    }
    pthread_mutex_init(&u->lock, NULL);
    atomic_init(&u->lead_ns, (int64_t)(LEAD_START_MS * 1e6));
    atomic_init(&u->stop, false);
    atomic_init(&u->want_key_poses, 0);
    u->base.receive = usb_receive;
    u->base.planes = usb_planes;
    u->base.destroy = usb_destroy;
    u->base.last_error = usb_last_error;
    return u;
}

static bool board_start(usb_frames *u, char *err, int errlen)
{
    u->pose_up = pthread_create(&u->pose_th, NULL, pose_thread, u) == 0;
    if (!u->pose_up) return warp_err(err, errlen, "usb frames: cannot start the pose thread");
    return true;
}

void drv_frames_usb_stats_get(drv_frames *fr, drv_frames_usb_stats *st)
{
    usb_frames *u = (usb_frames *)fr;
    pthread_mutex_lock(&u->lock);
    *st = u->st;
    pthread_mutex_unlock(&u->lock);
    st->connected = u->t->connected(u->t);
    if (u->t->stats) u->t->stats(u->t, st);
    st->lead_ms = (double)atomic_load(&u->lead_ns) * 1e-6;
}

double drv_frames_usb_decode_ms(drv_frames *fr) { return ((usb_frames *)fr)->decode_ms; }

static void usb_last_error(drv_frames *fr, char *buf, int len)
{
    usb_frames *u = (usb_frames *)fr;
    pthread_mutex_lock(&u->lock);
    snprintf(buf, (size_t)len, "%s", u->st.last_error);
    pthread_mutex_unlock(&u->lock);
}

drv_frames *drv_frames_usb_create_on_transport(const drv_frames_usb_params *p, drv_usb_transport *t,
                                               const char *name, char *err, int errlen)
{
    usb_frames *u = board_new(p, err, errlen);
    if (!u) {
        t->destroy(t);
        return NULL;
    }
    u->base.name = name;
    u->t = t;
    if (!board_start(u, err, errlen)) {
        usb_destroy(&u->base);
        return NULL;
    }
    return &u->base;
}

/* ---- fed from memory: the receive state machine alone ---- */

/* No link: the bytes come from drv_frames_usb_feed, so a read only waits out its timeout. */
static ssize_t fed_read(drv_usb_transport *t, uint8_t *buf, size_t cap, int timeout_ms)
{
    (void)t, (void)buf, (void)cap;
    if (timeout_ms > 0) plat_sleep_ns((int64_t)timeout_ms * PLAT_NS_PER_MS);
    return 0;
}
static ssize_t fed_write(drv_usb_transport *t, const uint8_t *buf, size_t len, int timeout_ms)
{
    (void)t, (void)buf, (void)timeout_ms;
    return (ssize_t)len;
}
static bool fed_connected(drv_usb_transport *t) { return (void)t, true; }
static void fed_destroy(drv_usb_transport *t) { free(t); }
static bool no_poses(void *ctx, int64_t t_ns, warp_pose *head) { return (void)ctx, (void)t_ns, (void)head, false; }

drv_frames *drv_frames_usb_create_fed(const drv_frames_usb_params *p, char *err, int errlen)
{
    drv_frames_usb_params q = *p;
    if (!q.poses.predict) q.poses.predict = no_poses; /* no pose thread runs: nothing is asked */
    if (!(q.pose_rate_hz > 0)) q.pose_rate_hz = 1;
    usb_frames *u = board_new(&q, err, errlen);
    if (!u) return NULL;
    u->t = calloc(1, sizeof *u->t);
    if (!u->t) {
        usb_destroy(&u->base);
        warp_err(err, errlen, "usb frames: out of memory");
        return NULL;
    }
    *u->t = (drv_usb_transport){
        .read = fed_read, .write = fed_write, .connected = fed_connected, .destroy = fed_destroy};
    u->base.name = "usb (fed)";
    return &u->base;
}

size_t drv_frames_usb_feed(drv_frames *fr, const uint8_t *data, size_t n)
{
    usb_frames *u = (usb_frames *)fr;
    size_t taken = 0;
    while (taken < n) {
        /* Never past a complete frame: the caller receives it first (a full buffer would drop bytes). */
        if (!u->discard_left && u->have >= DRV_FRAMELINK_PREFIX_BYTES) {
            size_t total = 0;
            if (drv_framelink_peek(u->buf, u->have, u->p.max_frame_bytes, &total) != DRV_FRAME_ERR_TRUNCATED &&
                u->have >= total)
                break;
        }
        if (u->have == u->cap) break;
        uint8_t *dst;
        size_t want = stream_space(u, &dst), k = n - taken < want ? n - taken : want;
        memcpy(dst, data + taken, k);
        stream_got(u, k);
        taken += k;
    }
    return taken;
}

/* ---- FunctionFS transport ---- */

/* Linux native AIO: FunctionFS endpoint files have no poll(), so timeouts and a clean shutdown need
 * asynchronous reads and writes completed through an eventfd (as the kernel's ffs-aio example does). */
static long aio_setup(unsigned n, aio_context_t *ctx) { return syscall(__NR_io_setup, n, ctx); }
static long aio_destroy(aio_context_t ctx) { return syscall(__NR_io_destroy, ctx); }
static long aio_submit(aio_context_t ctx, long n, struct iocb **io) { return syscall(__NR_io_submit, ctx, n, io); }
static long aio_cancel(aio_context_t ctx, struct iocb *io, struct io_event *ev)
{
    return syscall(__NR_io_cancel, ctx, io, ev);
}
static long aio_getevents(aio_context_t ctx, long min, long max, struct io_event *ev, struct timespec *ts)
{
    return syscall(__NR_io_getevents, ctx, min, max, ev, ts);
}

typedef struct {
    aio_context_t ctx;
    int fd, efd;
    struct iocb cb;
    bool pending;
    uint8_t *buf;          /* the I/O's own buffer: it outlives a timed-out call */
    size_t len, off;       /* completed bytes not yet handed out (reads) */
} aio_ep;

static bool aio_ep_init(aio_ep *a, int fd, size_t bufsize)
{
    memset(a, 0, sizeof *a);
    a->fd = fd;
    a->efd = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
    a->buf = malloc(bufsize);
    if (a->efd < 0 || !a->buf || aio_setup(2, &a->ctx) < 0) return false;
    return true;
}

/* Waits up to timeout_ms for the pending I/O: its result, or -EINPROGRESS. */
static long aio_ep_wait(aio_ep *a, int timeout_ms)
{
    struct pollfd pfd = {a->efd, POLLIN, 0};
    if (poll(&pfd, 1, timeout_ms) <= 0) return -EINPROGRESS;
    uint64_t v;
    if (read(a->efd, &v, sizeof v) < 0) return -EINPROGRESS;
    struct io_event ev;
    struct timespec zero = {0, 0};
    if (aio_getevents(a->ctx, 1, 1, &ev, &zero) != 1) return -EINPROGRESS;
    a->pending = false;
    return (long)ev.res;
}

static void aio_ep_cancel(aio_ep *a)
{
    if (!a->pending) return;
    struct io_event ev;
    aio_cancel(a->ctx, &a->cb, &ev);
    /* Cancelled or not, the request completes: wait for it so the buffer is free again. */
    for (int i = 0; i < 20 && a->pending; i++) aio_ep_wait(a, 50);
}

static bool aio_ep_submit(aio_ep *a, unsigned opcode, size_t len)
{
    memset(&a->cb, 0, sizeof a->cb);
    a->cb.aio_fildes = (uint32_t)a->fd;
    a->cb.aio_lio_opcode = (uint16_t)opcode;
    a->cb.aio_buf = (uint64_t)(uintptr_t)a->buf;
    a->cb.aio_nbytes = len;
    a->cb.aio_flags = IOCB_FLAG_RESFD;
    a->cb.aio_resfd = (uint32_t)a->efd;
    struct iocb *list[1] = {&a->cb};
    if (aio_submit(a->ctx, 1, list) != 1) return false;
    a->pending = true;
    return true;
}

static void aio_ep_free(aio_ep *a)
{
    aio_ep_cancel(a);
    if (a->ctx) aio_destroy(a->ctx);
    if (a->efd >= 0) close(a->efd);
    if (a->fd >= 0) close(a->fd);
    free(a->buf);
}

typedef struct {
    drv_usb_transport base;
    int ep0;
    aio_ep out, in;
    pthread_t ep0_th;
    bool ep0_up;
    atomic_bool stop;
    pthread_mutex_t lock;
    pthread_cond_t cond;
    bool enabled;
    usb_frames *owner;
} ffs_transport;

static bool ffs_wait_enabled(ffs_transport *t, int timeout_ms)
{
    pthread_mutex_lock(&t->lock);
    if (!t->enabled && timeout_ms > 0) {
        struct timespec ts = plat_deadline_after_ms(timeout_ms);
        while (!t->enabled && pthread_cond_timedwait(&t->cond, &t->lock, &ts) == 0) {
        }
    }
    bool en = t->enabled;
    pthread_mutex_unlock(&t->lock);
    return en;
}

static ssize_t ffs_read(drv_usb_transport *bt, uint8_t *buf, size_t cap, int timeout_ms)
{
    ffs_transport *t = (ffs_transport *)bt;
    aio_ep *a = &t->out;
    if (a->off < a->len) { /* the rest of a completed read that did not fit last time */
        size_t n = a->len - a->off < cap ? a->len - a->off : cap;
        memcpy(buf, a->buf + a->off, n);
        a->off += n;
        return (ssize_t)n;
    }
    if (!a->pending) {
        if (!ffs_wait_enabled(t, timeout_ms)) return 0;
        if (!aio_ep_submit(a, IOCB_CMD_PREAD, FFS_READ)) return -errno;
    }
    long r = aio_ep_wait(a, timeout_ms);
    if (r == -EINPROGRESS) return 0;
    if (r < 0) return r;
    a->len = (size_t)r;
    a->off = 0;
    size_t n = a->len < cap ? a->len : cap;
    memcpy(buf, a->buf, n);
    a->off = n;
    return (ssize_t)n;
}

static ssize_t ffs_write(drv_usb_transport *bt, const uint8_t *buf, size_t len, int timeout_ms)
{
    ffs_transport *t = (ffs_transport *)bt;
    aio_ep *a = &t->in;
    if (a->pending && aio_ep_wait(a, 0) == -EINPROGRESS) aio_ep_cancel(a); /* a fresher pose replaces it */
    if (a->pending) return 0;
    if (!ffs_wait_enabled(t, 0)) return 0;
    if (len > FFS_WRITE_MAX) return -EMSGSIZE; /* a message this driver never builds: said, not retried silently */
    memcpy(a->buf, buf, len);
    if (!aio_ep_submit(a, IOCB_CMD_PWRITE, len)) return -errno;
    long r = aio_ep_wait(a, timeout_ms);
    if (r == -EINPROGRESS) return 0; /* stays queued until the host reads or the next pose replaces it */
    return r;
}

static bool ffs_connected(drv_usb_transport *bt) { return ffs_wait_enabled((ffs_transport *)bt, 0); }

/* On ENABLE (the host configured us), the speed the host negotiated: in the stats and the log, with a warning when
 * it is below what the UDC can do (a USB 2 port or cable in front of a USB 3 controller). */
static void ffs_note_speed(ffs_transport *t)
{
    char udc[64];
    if (!drv_usb_udc_of("", t->owner->p.ffs_dir, udc, sizeof udc)) return;
    drv_usb_speed cur = drv_usb_udc_speed("", udc, false), max = drv_usb_udc_speed("", udc, true);
    pthread_mutex_lock(&t->owner->lock);
    snprintf(t->owner->st.usb_speed, sizeof t->owner->st.usb_speed, "%s", drv_usb_speed_name(cur));
    pthread_mutex_unlock(&t->owner->lock);
    if (cur != DRV_USB_SPEED_UNKNOWN && cur < max)
        plat_log(PLAT_LOG_WARNING, "usb frames: host connected at %s (~%g MB/s) on %s, which does %s: a USB %s port "
                 "or cable on the way?", drv_usb_speed_name(cur), drv_usb_speed_mbps(cur), udc,
                 drv_usb_speed_name(max), cur <= DRV_USB_SPEED_HIGH ? "2" : "3 Gen 1");
    else
        plat_log(PLAT_LOG_NOTICE, "usb frames: host connected at %s (~%g MB/s) on %s", drv_usb_speed_name(cur),
                 drv_usb_speed_mbps(cur), udc);
}

void drv_frames_usb_ffs_event(int type, bool *enabled, drv_frames_usb_stats *st)
{
    switch (type) {
    case FUNCTIONFS_ENABLE:
        if (*enabled) { /* the replug's DISABLE/UNBIND were coalesced away (see the header) */
            st->disconnects++;
            snprintf(st->last_error, sizeof st->last_error, "usb frames: host re-enabled the function (a replug)");
        }
        st->connections++; /* a host configured the function: counted as socket hosts are */
        *enabled = true;
        break;
    case FUNCTIONFS_DISABLE:
    case FUNCTIONFS_UNBIND:
        if (*enabled) {
            st->disconnects++;
            snprintf(st->last_error, sizeof st->last_error, "usb frames: host %s",
                     type == FUNCTIONFS_DISABLE ? "disabled the function" : "unbound");
        }
        *enabled = false;
        break;
    default: /* BIND, SETUP, SUSPEND, RESUME: no change of host */
        break;
    }
}

static void *ep0_thread(void *arg)
{
    ffs_transport *t = arg;
    plat_thread_set_name("hmdwarp-ep0");
    while (!atomic_load(&t->stop)) {
        struct pollfd pfd = {t->ep0, POLLIN, 0};
        if (poll(&pfd, 1, 100) <= 0) continue;
        struct usb_functionfs_event ev[4];
        ssize_t n = read(t->ep0, ev, sizeof ev);
        if (n < 0) {
            if (errno == EINTR || errno == EAGAIN) continue;
            note(t->owner, "usb frames: ep0: %s", strerror(errno));
            plat_sleep_ns(100 * PLAT_NS_PER_MS);
            continue;
        }
        for (size_t i = 0; i < (size_t)n / sizeof ev[0]; i++) {
            switch (ev[i].type) {
            case FUNCTIONFS_ENABLE:
            case FUNCTIONFS_DISABLE:
            case FUNCTIONFS_UNBIND:
                pthread_mutex_lock(&t->lock);
                pthread_mutex_lock(&t->owner->lock);
                drv_frames_usb_ffs_event(ev[i].type, &t->enabled, &t->owner->st);
                pthread_mutex_unlock(&t->owner->lock);
                if (t->enabled) pthread_cond_broadcast(&t->cond);
                pthread_mutex_unlock(&t->lock);
                if (ev[i].type == FUNCTIONFS_ENABLE) ffs_note_speed(t);
                break;
            case FUNCTIONFS_SETUP:
                /* No vendor control requests: stall the data phase in its direction. */
                if (ev[i].u.setup.bRequestType & USB_DIR_IN) {
                    if (write(t->ep0, NULL, 0) < 0) {
                    }
                } else if (read(t->ep0, NULL, 0) < 0) {
                }
                break;
            default: /* BIND, SUSPEND, RESUME: nothing to do */
                break;
            }
        }
    }
    return NULL;
}

static void ffs_destroy(drv_usb_transport *bt)
{
    ffs_transport *t = (ffs_transport *)bt;
    atomic_store(&t->stop, true);
    if (t->ep0_up) pthread_join(t->ep0_th, NULL);
    aio_ep_free(&t->out);
    aio_ep_free(&t->in);
    if (t->ep0 >= 0) close(t->ep0);
    pthread_cond_destroy(&t->cond);
    pthread_mutex_destroy(&t->lock);
    free(t);
}

/* Descriptors: one vendor interface, bulk OUT ep1 (frames) and bulk IN ep2 (poses), at full, high and super speed.
 * FunctionFS has no SuperSpeedPlus set of its own: it offers the super-speed one at SuperSpeedPlus too (f_fs.c's
 * _ffs_func_bind, as in Debian 12's 6.1), so a USB 3.1/3.2 controller runs Gen 2 with these. On a USB 3 controller
 * the composite layer writes the device's bcdUSB (3.2 at super speed, 2.1 below) whatever gadget.sh put in configfs. */
struct ffs_ep_pair {
    struct usb_interface_descriptor intf;
    struct usb_endpoint_descriptor_no_audio out, in;
} __attribute__((packed));

/* Super speed adds a companion after each endpoint. */
struct ffs_ss_set {
    struct usb_interface_descriptor intf;
    struct usb_endpoint_descriptor_no_audio out;
    struct usb_ss_ep_comp_descriptor out_comp;
    struct usb_endpoint_descriptor_no_audio in;
    struct usb_ss_ep_comp_descriptor in_comp;
} __attribute__((packed));

#define FFS_SS_MAXPACKET 1024 /* the only bulk max packet size USB 3 allows */
#define FFS_SS_OUT_BURST 15   /* frames: 16 packets a burst (the most), so the host streams without a handshake
                               * every packet; what USB 3 controllers need to pass ~400 MB/s */
#define FFS_SS_IN_BURST 0     /* poses: one packet holds a pose message */

static struct ffs_ep_pair ep_pair(uint16_t maxpacket)
{
    struct ffs_ep_pair d;
    memset(&d, 0, sizeof d);
    d.intf.bLength = sizeof d.intf;
    d.intf.bDescriptorType = USB_DT_INTERFACE;
    d.intf.bNumEndpoints = 2;
    d.intf.bInterfaceClass = USB_CLASS_VENDOR_SPEC;
    d.intf.iInterface = 1;
    d.out.bLength = sizeof d.out;
    d.out.bDescriptorType = USB_DT_ENDPOINT;
    d.out.bEndpointAddress = 1 | USB_DIR_OUT;
    d.out.bmAttributes = USB_ENDPOINT_XFER_BULK;
    d.out.wMaxPacketSize = htole16(maxpacket);
    d.in = d.out;
    d.in.bEndpointAddress = 2 | USB_DIR_IN;
    return d;
}

static struct ffs_ss_set ss_set(void)
{
    struct ffs_ep_pair p = ep_pair(FFS_SS_MAXPACKET);
    struct ffs_ss_set d;
    memset(&d, 0, sizeof d);
    d.intf = p.intf;
    d.out = p.out;
    d.in = p.in;
    d.out_comp.bLength = d.in_comp.bLength = USB_DT_SS_EP_COMP_SIZE;
    d.out_comp.bDescriptorType = d.in_comp.bDescriptorType = USB_DT_SS_ENDPOINT_COMP;
    d.out_comp.bMaxBurst = FFS_SS_OUT_BURST;
    d.in_comp.bMaxBurst = FFS_SS_IN_BURST;
    return d;
}
_Static_assert(sizeof(struct usb_ss_ep_comp_descriptor) == USB_DT_SS_EP_COMP_SIZE, "companion descriptor size");

static bool ffs_write_descriptors(int ep0, char *err, int errlen, const char *dir)
{
    struct {
        struct usb_functionfs_descs_head_v2 head;
        __le32 fs_count, hs_count, ss_count;
        struct ffs_ep_pair fs, hs;
        struct ffs_ss_set ss;
    } __attribute__((packed)) desc;
    desc.head.magic = htole32(FUNCTIONFS_DESCRIPTORS_MAGIC_V2);
    desc.head.length = htole32(sizeof desc);
    desc.head.flags = htole32(FUNCTIONFS_HAS_FS_DESC | FUNCTIONFS_HAS_HS_DESC | FUNCTIONFS_HAS_SS_DESC);
    desc.fs_count = htole32(3);
    desc.hs_count = htole32(3);
    desc.ss_count = htole32(5);
    desc.fs = ep_pair(64);
    desc.hs = ep_pair(512);
    desc.ss = ss_set();
    if (write(ep0, &desc, sizeof desc) != (ssize_t)sizeof desc)
        return warp_err(err, errlen, "usb frames: %s/ep0: writing the descriptors: %s", dir, strerror(errno));
    static const char name[] = "hmdwarp frames";
    struct {
        struct usb_functionfs_strings_head head;
        __le16 lang;
        char str[sizeof name];
    } __attribute__((packed)) strs;
    strs.head.magic = htole32(FUNCTIONFS_STRINGS_MAGIC);
    strs.head.length = htole32(sizeof strs);
    strs.head.str_count = htole32(1);
    strs.head.lang_count = htole32(1);
    strs.lang = htole16(0x0409);
    memcpy(strs.str, name, sizeof name);
    if (write(ep0, &strs, sizeof strs) != (ssize_t)sizeof strs)
        return warp_err(err, errlen, "usb frames: %s/ep0: writing the strings: %s", dir, strerror(errno));
    return true;
}

drv_frames *drv_frames_usb_create(const drv_frames_usb_params *p, char *err, int errlen)
{
    struct stat sb;
    if (stat(p->ffs_dir, &sb) != 0 || !S_ISDIR(sb.st_mode)) {
        warp_err(err, errlen,
                 "usb frames: FunctionFS directory %s: %s (mount it first: board/gadget.sh start)", p->ffs_dir,
                 stat(p->ffs_dir, &sb) != 0 ? strerror(errno) : "not a directory");
        return NULL;
    }
    usb_frames *u = board_new(p, err, errlen);
    if (!u) return NULL;
    u->base.name = "usb";
    ffs_transport *t = calloc(1, sizeof *t);
    if (!t) {
        usb_destroy(&u->base);
        return NULL;
    }
    t->ep0 = -1;
    t->out.fd = t->in.fd = t->out.efd = t->in.efd = -1;
    t->owner = u;
    pthread_mutex_init(&t->lock, NULL);
    plat_cond_init_monotonic(&t->cond);
    t->base.read = ffs_read;
    t->base.write = ffs_write;
    t->base.connected = ffs_connected;
    t->base.destroy = ffs_destroy;
    u->t = &t->base;
    char path[200];
    snprintf(path, sizeof path, "%s/ep0", p->ffs_dir);
    t->ep0 = open(path, O_RDWR | O_CLOEXEC);
    if (t->ep0 < 0) {
        warp_err(err, errlen, "usb frames: cannot open %s: %s (is FunctionFS mounted there?)", path, strerror(errno));
        goto fail;
    }
    if (!ffs_write_descriptors(t->ep0, err, errlen, p->ffs_dir)) goto fail;
    /* ep1/ep2 exist once the descriptors are written. */
    snprintf(path, sizeof path, "%s/ep1", p->ffs_dir);
    int out_fd = open(path, O_RDWR | O_CLOEXEC);
    snprintf(path, sizeof path, "%s/ep2", p->ffs_dir);
    int in_fd = open(path, O_RDWR | O_CLOEXEC);
    bool ok_out = aio_ep_init(&t->out, out_fd, FFS_READ), ok_in = aio_ep_init(&t->in, in_fd, FFS_WRITE_MAX);
    if (out_fd < 0 || in_fd < 0 || !ok_out || !ok_in) {
        warp_err(err, errlen, "usb frames: %s: cannot open ep1/ep2 for asynchronous I/O: %s", p->ffs_dir,
                 strerror(errno));
        goto fail;
    }
    /* before the ep0 thread, which sets it when a host enables the function */
    snprintf(u->st.usb_speed, sizeof u->st.usb_speed, "%s", drv_usb_speed_name(DRV_USB_SPEED_UNKNOWN));
    t->ep0_up = pthread_create(&t->ep0_th, NULL, ep0_thread, t) == 0;
    if (!t->ep0_up) {
        warp_err(err, errlen, "usb frames: cannot start the ep0 thread");
        goto fail;
    }
    if (!board_start(u, err, errlen)) goto fail;
    char udc[64];
    if (drv_usb_udc_of("", p->ffs_dir, udc, sizeof udc))
        plat_log(PLAT_LOG_NOTICE, "usb frames: descriptors written to %s (full, high and super speed); UDC %s does %s",
                 p->ffs_dir, udc, drv_usb_speed_name(drv_usb_udc_speed("", udc, true)));
    return &u->base;
fail:
    usb_destroy(&u->base);
    return NULL;
}
