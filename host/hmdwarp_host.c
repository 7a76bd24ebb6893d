/* SPDX-License-Identifier: MIT */
/* hmdwarp_host: libhmdwarp-host's handle: the connection and its reader thread (pose and camera messages, reconnect
 * after the board went away), frame submission through host_frame and the framelink encoder, statistics. */
#include <errno.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "drivers/drv_codec.h"
#include "drivers/drv_framelink.h"
#include "drivers/drv_framelink_codec.h"
#include "host/hmdwarp-host.h"
#include "host/host_frame.h"
#include "host/host_link.h"
#include "platform/plat_clock.h"
#include "platform/plat_version.h"

#define API __attribute__((visibility("default")))

/* The camera message's plane bits reach the application unchanged (store_cams) and its frames' planes go to the board
 * as they are: the public header's HMDWARP_HOST_PLANE_* must be the wire's DRV_PLANE_* bits (the public header cannot
 * include the driver's). */
#define HOST_PLANES_ALL                                                                                                \
    (HMDWARP_HOST_PLANE_COLOR | HMDWARP_HOST_PLANE_DEPTH | HMDWARP_HOST_PLANE_IDS | HMDWARP_HOST_PLANE_MOTION |       \
     HMDWARP_HOST_PLANE_LAYERS)
_Static_assert((unsigned)HMDWARP_HOST_PLANE_COLOR == (unsigned)DRV_PLANE_COLOR &&
                   (unsigned)HMDWARP_HOST_PLANE_DEPTH == (unsigned)DRV_PLANE_DEPTH &&
                   (unsigned)HMDWARP_HOST_PLANE_IDS == (unsigned)DRV_PLANE_IDS &&
                   (unsigned)HMDWARP_HOST_PLANE_MOTION == (unsigned)DRV_PLANE_MOTION &&
                   (unsigned)HMDWARP_HOST_PLANE_LAYERS == (unsigned)DRV_PLANE_LAYERS,
               "HMDWARP_HOST_PLANE_* and DRV_PLANE_* must be the same bits");

/* Pose messages kept for hmdwarp_host_frame.pose_seq: 1024 at the board's 500 Hz is 2 s (200 KB), longer than any
 * render a board would still warp, even on a host loaded enough to stretch a render tenfold (64, 128 ms, refused a
 * loaded machine's first frames). */
#define POSE_RING 1024
/* Board messages are small (204 and 168 bytes); a declared size above this is garbage to resynchronise past. */
#define MSG_MAX 4096
#define READ_TIMEOUT_MS 100
#define RECONNECT_MS 200
#define DEFAULT_WAIT_S 5.0
/* The board asks for a key frame in every pose message for a while after it lost a video reference (until a frame
 * decodes again): one forced key frame answers a run of them, and another only after this long, when the first
 * could have arrived (so a lost key frame is answered again, a quarter-second request not with ten). */
#define KEY_HOLDOFF_NS 100000000
/* auto's choices: drv_framelink_codec.h's, measured by `make bench`'s link section (docs/host-api.md). */
#define AUTO_JPEG_QUALITY DRV_FRAMELINK_AUTO_JPEG_QUALITY
#define AUTO_JPEG_SLICES DRV_FRAMELINK_AUTO_JPEG_SLICES
#define AUTO_VIDEO_QUANTISER DRV_FRAMELINK_AUTO_VIDEO_QUANTISER

struct hmdwarp_host {
    hmdwarp_host_options opts;
    char *path;
    atomic_bool stop;
    bool messages; /* the transport carries board messages (a reader thread runs) */

    pthread_mutex_t send_lock; /* the link pointer, the encoder's scratch and buffer */
    host_link *link;
    host_frame_scratch scratch;
    uint8_t *buf;
    size_t cap;
    /* compression (send_lock): the options as set, and the encoder made for them and the eye size */
    bool codec_set;
    hmdwarp_host_codec_options codec;
    drv_framelink_enc *enc;
    drv_framelink_enc_params enc_p;
    int enc_w, enc_h;
    int64_t last_key_ns;
    bool last_raw;                        /* the frame last encoded into buf went out raw */
    const hmdwarp_host_frame *sized;      /* a compressed frame in buf only sized by encode (cap too small) */
    int64_t sized_len;

    pthread_mutex_t lock; /* everything below */
    pthread_cond_t cond;
    bool connected;
    drv_framelink_pose ring[POSE_RING];
    int64_t ring_rx[POSE_RING];
    uint64_t ring_gen[POSE_RING]; /* the connection each pose came over (gen, counted up at each reconnect) */
    uint64_t gen;
    uint64_t n_poses; /* stored so far: the newest is ring[(n_poses - 1) % POSE_RING] */
    bool fresh;       /* the newest pose has not been returned by wait/poll yet */
    hmdwarp_host_cameras cams;
    bool have_cams, cams_from_board;
    drv_framelink_mask mask; /* the visibility mask sent after the latest camera message (n 0: none) */
    hmdwarp_host_stats st;
    double send_ms_total;
    int64_t win_start_ns;
    uint64_t win_bytes;
    double win_rate;
    unsigned board_codecs;   /* DRV_CODEC_BIT()s the board's camera message announced; 0 unknown */
    bool want_key, want_key_run; /* a pose message asked for a key frame; the last one did */
    hmdwarp_host_codec_stats cst;
    double encode_ms_total;

    pthread_t reader;
    bool reader_up;
};

static _Thread_local char t_err[512];

int host_fail(int err, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(t_err, sizeof t_err, fmt, ap);
    va_end(ap);
    return err;
}

API unsigned hmdwarp_host_abi_version(void) { return HMDWARP_HOST_ABI_VERSION; }
API const char *hmdwarp_host_version(void) { return plat_version(); }
API const char *hmdwarp_host_last_error(void) { return t_err; }

API const char *hmdwarp_host_error_str(int err)
{
    switch (err) {
    case HMDWARP_HOST_OK: return "ok";
    case HMDWARP_HOST_ERR_ARG: return "bad argument";
    case HMDWARP_HOST_ERR_SIZE: return "bad size";
    case HMDWARP_HOST_ERR_NOT_FINITE: return "not finite";
    case HMDWARP_HOST_ERR_FORMAT: return "bad format";
    case HMDWARP_HOST_ERR_NO_CAMERAS: return "no cameras";
    case HMDWARP_HOST_ERR_NOT_CONNECTED: return "not connected";
    case HMDWARP_HOST_ERR_DISCONNECTED: return "disconnected";
    case HMDWARP_HOST_ERR_IO: return "i/o error";
    case HMDWARP_HOST_ERR_NO_MEMORY: return "out of memory";
    case HMDWARP_HOST_ERR_UNSUPPORTED: return "unsupported";
    }
    return "unknown error";
}

API int64_t hmdwarp_host_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

/* ---- board messages ---- */

static hmdwarp_host_pose_msg pose_msg(const drv_framelink_pose *p, int64_t rx)
{
    return (hmdwarp_host_pose_msg){p->seq, p->board_t_ns, p->target_t_ns, rx, host_pose_from_warp(p->head),
                                   {host_pose_from_warp(p->eye[0]), host_pose_from_warp(p->eye[1])}};
}

static void store_pose(hmdwarp_host *h, const drv_framelink_pose *p)
{
    int64_t rx = hmdwarp_host_now_ns();
    pthread_mutex_lock(&h->lock);
    h->ring[h->n_poses % POSE_RING] = *p;
    h->ring_rx[h->n_poses % POSE_RING] = rx;
    h->ring_gen[h->n_poses % POSE_RING] = h->gen;
    h->n_poses++;
    h->fresh = true;
    h->st.poses_received++;
    bool wk = (p->flags & DRV_FRAMELINK_POSE_WANT_KEY) != 0;
    if (wk) h->want_key = true;
    if (wk && !h->want_key_run) h->cst.key_requests++;
    h->want_key_run = wk;
    pthread_cond_broadcast(&h->cond);
    pthread_mutex_unlock(&h->lock);
}

static void store_cams(hmdwarp_host *h, const drv_framelink_cams *c)
{
    pthread_mutex_lock(&h->lock);
    h->cams = (hmdwarp_host_cameras){c->seq, c->planes, (hmdwarp_host_depth_encoding)c->depth_encoding,
                                     c->max_frame_bytes, c->refresh_hz, c->pose_rate_hz,
                                     {host_camera_from_warp(&c->cam[0]), host_camera_from_warp(&c->cam[1])}};
    h->have_cams = h->cams_from_board = true;
    /* the mask follows its camera message: until it comes (or when the board has none), no mask */
    h->mask.n[0] = h->mask.n[1] = 0;
    /* what the board decodes: a version 1 message (codecs 0) means raw only */
    h->board_codecs = c->codecs ? c->codecs : DRV_CODEC_BIT(DRV_CODEC_RAW);
    h->st.cameras_received++;
    pthread_cond_broadcast(&h->cond);
    pthread_mutex_unlock(&h->lock);
}

static void store_mask(hmdwarp_host *h, const drv_framelink_mask *m)
{
    pthread_mutex_lock(&h->lock);
    h->mask = *m;
    pthread_mutex_unlock(&h->lock);
}

static void count_rejected(hmdwarp_host *h)
{
    pthread_mutex_lock(&h->lock);
    h->st.messages_rejected++;
    pthread_mutex_unlock(&h->lock);
}

/* Takes the whole messages at the front of buf[0, len); returns the bytes used. Garbage is skipped a byte at a
 * time up to the next magic (one rejection per run of it). */
static size_t parse_messages(hmdwarp_host *h, const uint8_t *buf, size_t len, bool *skipping)
{
    size_t off = 0;
    while (len - off >= 12) {
        size_t size = 0;
        uint32_t magic = drv_framelink_msg_peek(buf + off, len - off, &size);
        if (!magic || size < 12 || size > MSG_MAX) {
            if (!*skipping) count_rejected(h);
            *skipping = true;
            off++;
            continue;
        }
        *skipping = false;
        if (len - off < size) break;
        if (magic == DRV_FRAMELINK_POSE_MAGIC) {
            drv_framelink_pose p;
            if (drv_framelink_pose_decode(buf + off, size, &p) == DRV_FRAME_OK)
                store_pose(h, &p);
            else
                count_rejected(h);
        } else if (magic == DRV_FRAMELINK_MASK_MAGIC) {
            drv_framelink_mask m;
            if (drv_framelink_mask_decode(buf + off, size, &m) == DRV_FRAME_OK)
                store_mask(h, &m);
            else
                count_rejected(h);
        } else {
            drv_framelink_cams c;
            if (drv_framelink_cams_decode(buf + off, size, &c) == DRV_FRAME_OK)
                store_cams(h, &c);
            else
                count_rejected(h);
        }
        off += size;
    }
    return off;
}

/* The board is gone: counted once, whoever notices first (the reader, or a submit whose write failed). */
static void mark_disconnected(hmdwarp_host *h)
{
    pthread_mutex_lock(&h->lock);
    if (h->connected) h->st.disconnects++;
    h->connected = false;
    pthread_cond_broadcast(&h->cond);
    pthread_mutex_unlock(&h->lock);
}

static bool is_connected(hmdwarp_host *h)
{
    pthread_mutex_lock(&h->lock);
    bool c = h->connected;
    pthread_mutex_unlock(&h->lock);
    return c;
}

static void sleep_ms(int ms)
{
    struct timespec ts = {0, (long)ms * 1000000L};
    while (nanosleep(&ts, &ts) != 0 && errno == EINTR) {
    }
}

/* Receives the board's messages; after a disconnect, closes the link (under send_lock, so no submit is using it)
 * and reconnects in the background: the caller's next submit or wait finds it back or reports NOT_CONNECTED. */
static void *reader_main(void *arg)
{
    hmdwarp_host *h = arg;
    uint8_t buf[3 * MSG_MAX];
    size_t have = 0;
    bool skipping = false;
    while (!atomic_load(&h->stop)) {
        if (!h->link) {
            sleep_ms(RECONNECT_MS);
            host_link *l = host_link_open(&h->opts, 0, &h->stop);
            if (!l) continue;
            pthread_mutex_lock(&h->send_lock);
            h->link = l;
            pthread_mutex_unlock(&h->send_lock);
            pthread_mutex_lock(&h->lock);
            h->connected = true;
            h->st.reconnects++;
            /* A restarted board counts its poses from the start again: a pose_seq from before must not match. */
            h->gen++;
            h->fresh = false;
            h->want_key = true; /* a restarted board's video decoder starts at a key frame: do not wait to be asked */
            pthread_cond_broadcast(&h->cond);
            pthread_mutex_unlock(&h->lock);
            have = 0;
            skipping = false;
            continue;
        }
        /* Only this thread replaces h->link, so reading it without send_lock is safe. */
        int n = host_link_read(h->link, buf + have, MSG_MAX, READ_TIMEOUT_MS);
        if (n < 0 || !is_connected(h)) {
            mark_disconnected(h);
            pthread_mutex_lock(&h->send_lock);
            host_link_close(h->link);
            h->link = NULL;
            pthread_mutex_unlock(&h->send_lock);
            continue;
        }
        have += (size_t)n;
        size_t used = parse_messages(h, buf, have, &skipping);
        memmove(buf, buf + used, have - used);
        have -= used;
        /* A declared size is at most MSG_MAX, so a message never needs more than that buffered; keep room for a
         * full read after it. */
        if (have > 2 * MSG_MAX) have = 0;
    }
    return NULL;
}

/* ---- open / close ---- */

API hmdwarp_host *hmdwarp_host_open_ex(const hmdwarp_host_options *opts)
{
    if (!opts) return host_fail(HMDWARP_HOST_ERR_ARG, "options: NULL"), NULL;
    hmdwarp_host *h = calloc(1, sizeof *h);
    if (!h) return host_fail(HMDWARP_HOST_ERR_NO_MEMORY, "out of memory"), NULL;
    h->opts = *opts;
    /* Negotiated from the start: auto sends what the board's camera message announces (raw until one came). */
    hmdwarp_host_codec_defaults(&h->codec);
    h->codec_set = true;
    if (opts->path && !(h->path = strdup(opts->path))) {
        free(h);
        return host_fail(HMDWARP_HOST_ERR_NO_MEMORY, "out of memory"), NULL;
    }
    h->opts.path = h->path;
    if (!(opts->wait_s >= 0)) {
        free(h->path);
        free(h);
        return host_fail(HMDWARP_HOST_ERR_ARG, "options.wait_s: %g (want >= 0)", opts->wait_s), NULL;
    }
    pthread_mutex_init(&h->send_lock, NULL);
    pthread_mutex_init(&h->lock, NULL);
    plat_cond_init_monotonic(&h->cond);
    h->link = host_link_open(&h->opts, opts->wait_s, &h->stop);
    if (!h->link) {
        hmdwarp_host_close(h);
        return NULL;
    }
    h->connected = true;
    h->messages = host_link_has_messages(h->link);
    if (h->messages) {
        int rc = pthread_create(&h->reader, NULL, reader_main, h);
        if (rc) {
            hmdwarp_host_close(h);
            return host_fail(HMDWARP_HOST_ERR_IO, "cannot start the reader thread: %s", strerror(rc)), NULL;
        }
        h->reader_up = true;
    }
    return h;
}

API hmdwarp_host *hmdwarp_host_open(const char *uri)
{
    if (!uri || !uri[0]) return host_fail(HMDWARP_HOST_ERR_ARG, "uri: empty"), NULL;
    hmdwarp_host_options o = {.wait_s = DEFAULT_WAIT_S};
    const char *colon = strchr(uri, ':');
    size_t scheme = colon ? (size_t)(colon - uri) : 0;
    if (strcmp(uri, "usb") == 0) {
        o.transport = HMDWARP_HOST_TRANSPORT_USB;
    } else if (scheme == 3 && strncmp(uri, "usb", 3) == 0) {
        unsigned vid, pid;
        char end;
        if (sscanf(colon + 1, "%x:%x%c", &vid, &pid, &end) != 2 || vid > 0xffff || pid > 0xffff)
            return host_fail(HMDWARP_HOST_ERR_ARG, "uri '%s': want usb:VID:PID (hex)", uri), NULL;
        o.transport = HMDWARP_HOST_TRANSPORT_USB;
        o.vid = (uint16_t)vid, o.pid = (uint16_t)pid;
    } else if (scheme == 6 && strncmp(uri, "socket", 6) == 0) {
        o.transport = HMDWARP_HOST_TRANSPORT_SOCKET;
        o.path = colon + 1;
    } else if (scheme == 4 && strncmp(uri, "file", 4) == 0) {
        o.transport = HMDWARP_HOST_TRANSPORT_FILE;
        o.path = colon + 1;
    } else if (strcmp(uri, "-") == 0 || !colon || (strchr(uri, '/') && strchr(uri, '/') < colon)) {
        o.transport = HMDWARP_HOST_TRANSPORT_FILE; /* a plain path */
        o.path = uri;
    } else {
        return host_fail(HMDWARP_HOST_ERR_ARG, "uri '%s': unknown transport '%.*s' (usb, socket, file)", uri,
                         (int)scheme, uri), NULL;
    }
    return hmdwarp_host_open_ex(&o);
}

API void hmdwarp_host_close(hmdwarp_host *h)
{
    if (!h) return;
    atomic_store(&h->stop, true);
    pthread_mutex_lock(&h->send_lock);
    if (h->link) host_link_shutdown(h->link);
    pthread_mutex_unlock(&h->send_lock);
    if (h->reader_up) pthread_join(h->reader, NULL);
    host_link_close(h->link);
    host_frame_scratch_free(&h->scratch);
    drv_framelink_enc_destroy(h->enc);
    free(h->buf);
    free(h->path);
    pthread_cond_destroy(&h->cond);
    pthread_mutex_destroy(&h->lock);
    pthread_mutex_destroy(&h->send_lock);
    free(h);
}

API int hmdwarp_host_connected(hmdwarp_host *h) { return h && is_connected(h) ? 1 : 0; }

/* ---- poses and cameras ---- */

/* One wait for the reader's signal (h->lock held); true when the caller's time is up: at once for a timeout of 0,
 * never for a negative one. While the board is away the wait goes on (the reader reconnects and signals), so a
 * caller's loop does not spin. */
static bool wait_signal(hmdwarp_host *h, int timeout_ms, const struct timespec *ts)
{
    if (timeout_ms < 0) {
        pthread_cond_wait(&h->cond, &h->lock);
        return false;
    }
    return timeout_ms == 0 || pthread_cond_timedwait(&h->cond, &h->lock, ts) == ETIMEDOUT;
}

API int hmdwarp_host_wait_pose(hmdwarp_host *h, int timeout_ms, hmdwarp_host_pose_msg *out)
{
    if (!h || !out) return host_fail(HMDWARP_HOST_ERR_ARG, "%s: NULL", !h ? "handle" : "out");
    if (!h->messages)
        return host_fail(HMDWARP_HOST_ERR_UNSUPPORTED, "wait_pose: a file transport receives no pose messages");
    struct timespec ts;
    if (timeout_ms > 0) ts = plat_deadline_after_ms(timeout_ms);
    int rc = 0;
    pthread_mutex_lock(&h->lock);
    for (;;) {
        if (h->fresh) {
            uint64_t i = (h->n_poses - 1) % POSE_RING;
            *out = pose_msg(&h->ring[i], h->ring_rx[i]);
            h->fresh = false;
            rc = 1;
            break;
        }
        /* it ends NOT_CONNECTED when the board stayed away for all of it */
        if (wait_signal(h, timeout_ms, &ts) && !h->fresh) {
            if (!h->connected)
                rc = host_fail(HMDWARP_HOST_ERR_NOT_CONNECTED, "wait_pose: not connected (the board went away; "
                               "reconnecting)");
            break;
        }
    }
    pthread_mutex_unlock(&h->lock);
    return rc;
}

API int hmdwarp_host_poll_pose(hmdwarp_host *h, hmdwarp_host_pose_msg *out)
{
    return hmdwarp_host_wait_pose(h, 0, out);
}

API int hmdwarp_host_get_cameras(hmdwarp_host *h, hmdwarp_host_cameras *out)
{
    if (!h || !out) return host_fail(HMDWARP_HOST_ERR_ARG, "%s: NULL", !h ? "handle" : "out");
    pthread_mutex_lock(&h->lock);
    int rc = h->have_cams;
    if (rc) *out = h->cams;
    pthread_mutex_unlock(&h->lock);
    return rc;
}

API int hmdwarp_host_get_visibility_mask(hmdwarp_host *h, int eye, float *uv, int max)
{
    if (!h) return host_fail(HMDWARP_HOST_ERR_ARG, "handle: NULL");
    if (eye < 0 || eye > 1) return host_fail(HMDWARP_HOST_ERR_ARG, "eye %d: 0 (left) or 1 (right)", eye);
    if (max < 0 || (max > 0 && !uv)) return host_fail(HMDWARP_HOST_ERR_ARG, "uv: NULL for %d vertices", max);
    pthread_mutex_lock(&h->lock);
    const int n = h->mask.n[eye];
    if (max > 0) memcpy(uv, h->mask.uv[eye], sizeof(float) * 2 * (size_t)(n < max ? n : max));
    pthread_mutex_unlock(&h->lock);
    return n;
}

API int hmdwarp_host_wait_cameras(hmdwarp_host *h, int timeout_ms, hmdwarp_host_cameras *out)
{
    if (!h || !out) return host_fail(HMDWARP_HOST_ERR_ARG, "%s: NULL", !h ? "handle" : "out");
    struct timespec ts;
    if (timeout_ms > 0) ts = plat_deadline_after_ms(timeout_ms);
    int rc = 0;
    pthread_mutex_lock(&h->lock);
    for (;;) {
        if (h->have_cams) {
            *out = h->cams;
            rc = 1;
            break;
        }
        if (!h->messages) break; /* nothing will arrive: set_cameras is the way */
        /* it ends NOT_CONNECTED when the board stayed away for all of it */
        if (wait_signal(h, timeout_ms, &ts) && !h->have_cams) {
            if (!h->connected)
                rc = host_fail(HMDWARP_HOST_ERR_NOT_CONNECTED, "wait_cameras: not connected (the board went away; "
                               "reconnecting)");
            break;
        }
    }
    pthread_mutex_unlock(&h->lock);
    return rc;
}

API int hmdwarp_host_set_cameras(hmdwarp_host *h, const hmdwarp_host_cameras *cams)
{
    if (!h || !cams) return host_fail(HMDWARP_HOST_ERR_ARG, "%s: NULL", !h ? "handle" : "cams");
    for (int e = 0; e < 2; e++) {
        warp_camera c = host_camera_to_warp(&cams->cam[e]);
        const char *why = warp_camera_check(&c);
        if (why) return host_fail(HMDWARP_HOST_ERR_ARG, "cams.cam[%d]: %s", e, why);
    }
    if (!(cams->planes & HMDWARP_HOST_PLANE_COLOR) || (cams->planes & ~(unsigned)HOST_PLANES_ALL))
        return host_fail(HMDWARP_HOST_ERR_ARG, "cams.planes: 0x%x (want COLOR and only HMDWARP_HOST_PLANE_* bits)",
                         cams->planes);
    pthread_mutex_lock(&h->lock);
    h->cams = *cams;
    h->have_cams = true;
    h->cams_from_board = false;
    pthread_cond_broadcast(&h->cond);
    pthread_mutex_unlock(&h->lock);
    return HMDWARP_HOST_OK;
}

/* ---- frames ---- */

/* ---- compression ---- */

static bool codec_in(int c, int lo, int hi) { return c == HMDWARP_HOST_CODEC_AUTO || (c >= lo && c <= hi); }

static int wire_depth_of(int fmt)
{
    return fmt == DRV_FRAMELINK_FMT_F32       ? HMDWARP_HOST_WIRE_DEPTH_F32
           : fmt == DRV_FRAMELINK_FMT_UNORM16 ? HMDWARP_HOST_WIRE_DEPTH_UNORM16
           : fmt == DRV_FRAMELINK_FMT_INV16   ? HMDWARP_HOST_WIRE_DEPTH_INV16
                                              : HMDWARP_HOST_WIRE_DEPTH_AUTO;
}

static bool enc_params_equal(const drv_framelink_enc_params *a, const drv_framelink_enc_params *b)
{
    return a->color == b->color && a->quality == b->quality && a->jpeg_sub == b->jpeg_sub &&
           a->slices == b->slices && a->video_kbps == b->video_kbps && a->refresh_frames == b->refresh_frames &&
           a->fps == b->fps && a->depth == b->depth && a->depth_format == b->depth_format &&
           a->depth_scale == b->depth_scale && a->other == b->other && a->zstd_level == b->zstd_level;
}

/* A codec chosen by hand must be one the board announced (when it said: board != 0). */
static int announced(const char *field, int c, unsigned board)
{
    if (!board || (board & DRV_CODEC_BIT(c))) return HMDWARP_HOST_OK;
    char names[64];
    return host_fail(HMDWARP_HOST_ERR_FORMAT, "codec.%s: %s: the board does not decode it (it announced: %s)", field,
                     drv_codec_name((drv_codec_id)c), drv_codec_names(board, " ", names, sizeof names));
}

/* The encoder's parameters for frame f: the options with auto resolved against the board's codecs (board 0:
 * unknown, so auto is raw) and the frame's depth encoding. */
static int resolve_codec(const hmdwarp_host_codec_options *o, const drv_frame *f, unsigned board, double hz,
                         drv_framelink_enc_params *p)
{
    unsigned avail = board ? board : DRV_CODEC_BIT(DRV_CODEC_RAW);
    bool zstd = avail & DRV_CODEC_BIT(DRV_CODEC_ZSTD);
    int rc;
    p->color = o->color != HMDWARP_HOST_CODEC_AUTO                 ? (drv_codec_id)o->color
               : avail & DRV_CODEC_BIT(DRV_CODEC_JPEG) ? DRV_CODEC_JPEG
                                                       : DRV_CODEC_RAW;
    if ((rc = announced("color", p->color, board))) return rc;
    bool video = p->color == DRV_CODEC_H264 || p->color == DRV_CODEC_HEVC;
    p->quality = o->quality ? o->quality : video ? AUTO_VIDEO_QUANTISER : AUTO_JPEG_QUALITY;
    p->jpeg_sub = o->jpeg_subsampling == 444 ? DRV_JPEG_444 : DRV_JPEG_420;
    p->slices = p->color != DRV_CODEC_JPEG ? 1 : o->slices ? o->slices : AUTO_JPEG_SLICES;
    p->video_kbps = o->video_kbps;
    p->refresh_frames = o->refresh_frames;
    if (hz > 0) p->fps = hz / 2; /* rate control's guess: hosts render at half the panel's refresh or faster */
    if (f->planes & DRV_PLANE_DEPTH) {
        p->depth = o->depth != HMDWARP_HOST_CODEC_AUTO ? (drv_codec_id)o->depth
                   : zstd                              ? DRV_CODEC_ZSTD
                                                       : DRV_CODEC_RAW;
        if ((rc = announced("depth", p->depth, board))) return rc;
        bool linear = f->depth_encoding == WARP_DEPTH_LINEAR;
        switch (o->depth_format) {
        case HMDWARP_HOST_WIRE_DEPTH_F32: p->depth_format = DRV_FRAMELINK_FMT_F32; break;
        case HMDWARP_HOST_WIRE_DEPTH_UNORM16: p->depth_format = DRV_FRAMELINK_FMT_UNORM16; break;
        case HMDWARP_HOST_WIRE_DEPTH_INV16: p->depth_format = DRV_FRAMELINK_FMT_INV16; break;
        default: /* 16 bits when compressing: INV16 for metres, UNORM16 for window depth; raw keeps the frame's */
            p->depth_format = p->depth == DRV_CODEC_ZSTD ? linear ? DRV_FRAMELINK_FMT_INV16 : DRV_FRAMELINK_FMT_UNORM16
                                                         : 0;
        }
        if (p->depth_format == DRV_FRAMELINK_FMT_UNORM16 && linear)
            return host_fail(HMDWARP_HOST_ERR_FORMAT, "codec.depth_format: UNORM16 holds window depth only, the "
                             "frame's is linear (INV16 is the 16-bit format for metres)");
        if (p->depth_format == DRV_FRAMELINK_FMT_INV16 && !linear)
            return host_fail(HMDWARP_HOST_ERR_FORMAT, "codec.depth_format: INV16 holds linear depth only, the frame's "
                             "is window depth (UNORM16 is its 16-bit format)");
        p->depth_scale = o->depth_scale;
    }
    if (f->planes & (DRV_PLANE_IDS | DRV_PLANE_MOTION | DRV_PLANE_LAYERS)) {
        p->other = o->other != HMDWARP_HOST_CODEC_AUTO ? (drv_codec_id)o->other
                   : zstd                              ? DRV_CODEC_ZSTD
                                                       : DRV_CODEC_RAW;
        if ((rc = announced("other", p->other, board))) return rc;
    }
    return HMDWARP_HOST_OK;
}

API void hmdwarp_host_codec_defaults(hmdwarp_host_codec_options *out)
{
    if (!out) return;
    *out = (hmdwarp_host_codec_options){.color = HMDWARP_HOST_CODEC_AUTO, .depth = HMDWARP_HOST_CODEC_AUTO,
                                        .other = HMDWARP_HOST_CODEC_AUTO};
}

API int hmdwarp_host_set_codec(hmdwarp_host *h, const hmdwarp_host_codec_options *o)
{
    if (!h) return host_fail(HMDWARP_HOST_ERR_ARG, "handle: NULL");
    if (o) {
        if (!codec_in(o->color, HMDWARP_HOST_CODEC_RAW, HMDWARP_HOST_CODEC_HEVC) ||
            o->color == HMDWARP_HOST_CODEC_ZSTD)
            return host_fail(HMDWARP_HOST_ERR_ARG, "codec.color: %d (want AUTO, RAW, JPEG, H264 or HEVC)", o->color);
        if (!codec_in(o->depth, HMDWARP_HOST_CODEC_RAW, HMDWARP_HOST_CODEC_ZSTD))
            return host_fail(HMDWARP_HOST_ERR_ARG, "codec.depth: %d (want AUTO, RAW or ZSTD)", o->depth);
        if (!codec_in(o->other, HMDWARP_HOST_CODEC_RAW, HMDWARP_HOST_CODEC_ZSTD))
            return host_fail(HMDWARP_HOST_ERR_ARG, "codec.other: %d (want AUTO, RAW or ZSTD)", o->other);
        bool video = o->color == HMDWARP_HOST_CODEC_H264 || o->color == HMDWARP_HOST_CODEC_HEVC;
        if (o->quality < 0 || o->quality > (video ? 51 : 100))
            return host_fail(HMDWARP_HOST_ERR_ARG, "codec.quality: %d (want 0 for the default, or 1..%d)", o->quality,
                             video ? 51 : 100);
        if (o->jpeg_subsampling != 0 && o->jpeg_subsampling != 420 && o->jpeg_subsampling != 444)
            return host_fail(HMDWARP_HOST_ERR_ARG, "codec.jpeg_subsampling: %d (want 420 or 444)", o->jpeg_subsampling);
        if (o->slices < 0 || o->slices > 16)
            return host_fail(HMDWARP_HOST_ERR_ARG, "codec.slices: %d (want 1..16, or 0 for 4)", o->slices);
        if (o->video_kbps < 0 || o->refresh_frames < 0)
            return host_fail(HMDWARP_HOST_ERR_ARG, "codec.%s: negative", o->video_kbps < 0 ? "video_kbps"
                                                                                          : "refresh_frames");
        if (o->depth_format < HMDWARP_HOST_WIRE_DEPTH_AUTO || o->depth_format > HMDWARP_HOST_WIRE_DEPTH_INV16)
            return host_fail(HMDWARP_HOST_ERR_ARG, "codec.depth_format: %d (want AUTO, F32, UNORM16 or INV16)",
                             o->depth_format);
        if (o->depth_scale < 0 || o->depth_scale > 2)
            return host_fail(HMDWARP_HOST_ERR_ARG, "codec.depth_scale: %d (want 0, 1 or 2)", o->depth_scale);
        const int picked[3] = {o->color, o->depth, o->other};
        const char *const names[3] = {"color", "depth", "other"};
        for (int i = 0; i < 3; i++)
            if (picked[i] != HMDWARP_HOST_CODEC_AUTO && !(drv_codec_encodable() & DRV_CODEC_BIT(picked[i])))
                return host_fail(HMDWARP_HOST_ERR_UNSUPPORTED, "codec.%s: %s: this library cannot encode it here",
                                 names[i], drv_codec_name((drv_codec_id)picked[i]));
    }
    pthread_mutex_lock(&h->send_lock);
    h->codec_set = o != NULL;
    if (o) h->codec = *o;
    pthread_mutex_unlock(&h->send_lock);
    return HMDWARP_HOST_OK;
}

API int hmdwarp_host_get_codec_stats(hmdwarp_host *h, hmdwarp_host_codec_stats *out)
{
    if (!h || !out) return host_fail(HMDWARP_HOST_ERR_ARG, "%s: NULL", !h ? "handle" : "out");
    pthread_mutex_lock(&h->lock);
    *out = h->cst;
    out->board_codecs = h->board_codecs;
    pthread_mutex_unlock(&h->lock);
    return HMDWARP_HOST_OK;
}

/* Checks and encodes into h->buf (send_lock held); returns the size or an error. */
static int64_t encode_locked(hmdwarp_host *h, const hmdwarp_host_frame *frame)
{
    hmdwarp_host_cameras cams;
    drv_framelink_pose echo;
    host_frame_ctx ctx = {0};
    pthread_mutex_lock(&h->lock);
    if (h->have_cams) {
        cams = h->cams;
        ctx.cams = &cams;
        ctx.cams_from_board = h->cams_from_board;
    }
    int rc = HMDWARP_HOST_OK;
    if (frame && frame->pose_seq) {
        uint64_t n = h->n_poses < POSE_RING ? h->n_poses : POSE_RING;
        bool stale = false;
        for (uint64_t k = 0; k < n && !ctx.echo && !stale; k++) {
            uint64_t i = (h->n_poses - 1 - k) % POSE_RING;
            if (h->ring[i].seq != frame->pose_seq) continue;
            stale = h->ring_gen[i] != h->gen;
            if (!stale) {
                echo = h->ring[i];
                ctx.echo = &echo;
                ctx.echo_rx_ns = h->ring_rx[i];
            }
        }
        if (stale)
            rc = host_fail(HMDWARP_HOST_ERR_DISCONNECTED, "frame.pose_seq: %u came before the board reconnected: "
                           "render for a new pose", frame->pose_seq);
        else if (!ctx.echo)
            rc = host_fail(HMDWARP_HOST_ERR_ARG, "frame.pose_seq: %u is not among the last %d pose messages received",
                           frame->pose_seq, POSE_RING);
    }
    ctx.seq = h->st.frames_sent + 1;
    unsigned board_codecs = h->board_codecs;
    bool want_key = h->want_key;
    h->want_key = false;
    pthread_mutex_unlock(&h->lock);
    drv_framelink_tx tx;
    if (!rc) rc = host_frame_build(&h->scratch, frame, &ctx, &tx);
    if (rc) return rc;
    const drv_frame *f = &h->scratch.f;
    size_t raw_size = drv_framelink_size_ex(f, &tx);
    if (!raw_size)
        return host_fail(HMDWARP_HOST_ERR_FORMAT, "frame: the planes and formats cannot be encoded together");
    drv_framelink_enc_params p = drv_framelink_enc_params_raw();
    if (h->codec_set && (rc = resolve_codec(&h->codec, f, ctx.cams_from_board ? board_codecs : 0,
                                            ctx.cams ? cams.refresh_hz : 0, &p)))
        return rc;
    bool raw = p.color == DRV_CODEC_RAW && p.depth == DRV_CODEC_RAW && p.other == DRV_CODEC_RAW &&
               p.depth_scale == 0 && p.depth_format == 0;
    int64_t now = hmdwarp_host_now_ns();
    /* a key frame for a run of requests, then none until it could have arrived (KEY_HOLDOFF_NS) */
    bool key = want_key && now - h->last_key_ns >= KEY_HOLDOFF_NS;
    if (key) h->last_key_ns = now;
    size_t size, bound = raw ? raw_size : 0;
    char why[200] = "";
    if (!raw) {
        if (!h->enc || f->color[0].w != h->enc_w || f->color[0].h != h->enc_h || !enc_params_equal(&p, &h->enc_p)) {
            drv_framelink_enc_destroy(h->enc);
            h->enc = drv_framelink_enc_create(&p, f->color[0].w, f->color[0].h, why, sizeof why);
            if (!h->enc) return host_fail(HMDWARP_HOST_ERR_FORMAT, "codec: %s", why);
            h->enc_p = p, h->enc_w = f->color[0].w, h->enc_h = f->color[0].h;
        }
        bound = drv_framelink_enc_bound(h->enc, f);
        if (!bound)
            return host_fail(HMDWARP_HOST_ERR_FORMAT, "frame: the planes and formats cannot be encoded with codecs "
                             "%s/%s/%s", drv_codec_name(p.color), drv_codec_name(p.depth), drv_codec_name(p.other));
    }
    /* a raw frame is checked against the board's limit before it is written; a compressed one once its size is
     * known (the bound only sizes the buffer) */
    if (raw && ctx.cams_from_board && raw_size > cams.max_frame_bytes)
        return host_fail(HMDWARP_HOST_ERR_SIZE, "frame: %zu bytes, over the board's max_frame_bytes %llu", raw_size,
                         (unsigned long long)cams.max_frame_bytes);
    if (bound > h->cap) {
        uint8_t *b = realloc(h->buf, bound);
        if (!b) return host_fail(HMDWARP_HOST_ERR_NO_MEMORY, "frame: out of memory for %zu bytes", bound);
        h->buf = b;
        h->cap = bound;
    }
    h->last_raw = raw;
    int64_t t0 = hmdwarp_host_now_ns();
    if (raw) {
        if (drv_framelink_encode_ex(f, &tx, h->buf, h->cap) != raw_size)
            return host_fail(HMDWARP_HOST_ERR_FORMAT, "frame: the encoder refused it");
        size = raw_size;
    } else {
        size = drv_framelink_enc_encode(h->enc, f, &tx, key, h->buf, h->cap, why, sizeof why);
        if (!size) return host_fail(HMDWARP_HOST_ERR_FORMAT, "frame: %s", why);
        if (ctx.cams_from_board && size > cams.max_frame_bytes)
            return host_fail(HMDWARP_HOST_ERR_SIZE, "frame: %zu bytes compressed, over the board's max_frame_bytes "
                             "%llu", size, (unsigned long long)cams.max_frame_bytes);
    }
    double ms = (double)(hmdwarp_host_now_ns() - t0) * 1e-6;
    pthread_mutex_lock(&h->lock);
    hmdwarp_host_codec_stats *cs = &h->cst;
    cs->color = (int)p.color, cs->depth = (int)p.depth, cs->other = (int)p.other;
    cs->depth_format = wire_depth_of(p.depth_format);
    cs->frames++;
    cs->compressed_frames += !raw && (p.color || p.depth || p.other);
    cs->key_frames += key && (p.color == DRV_CODEC_H264 || p.color == DRV_CODEC_HEVC);
    cs->plane_bytes += raw_size;
    cs->wire_bytes += size;
    cs->plane_bytes_last = (double)raw_size;
    cs->wire_bytes_last = (double)size;
    cs->encode_ms_last = ms;
    h->encode_ms_total += ms;
    cs->encode_ms_mean = h->encode_ms_total / (double)cs->frames;
    pthread_mutex_unlock(&h->lock);
    return (int64_t)size;
}

static void count_refused(hmdwarp_host *h)
{
    pthread_mutex_lock(&h->lock);
    h->st.frames_refused++;
    pthread_mutex_unlock(&h->lock);
}

/* Writes len bytes to the link (send_lock held) and counts them. */
static int send_locked(hmdwarp_host *h, const void *buf, size_t len)
{
    if (!h->link || (h->messages && !is_connected(h)))
        return host_fail(HMDWARP_HOST_ERR_NOT_CONNECTED, "submit: not connected (the board went away; reconnecting)");
    int64_t t0 = hmdwarp_host_now_ns();
    int rc = host_link_write(h->link, buf, len);
    int64_t t1 = hmdwarp_host_now_ns();
    if (rc == HMDWARP_HOST_ERR_DISCONNECTED && h->messages) {
        /* The reader closes the link and reconnects; shutting it down wakes the reader now. */
        mark_disconnected(h);
        host_link_shutdown(h->link);
    }
    pthread_mutex_lock(&h->lock);
    if (rc) {
        h->st.send_errors++;
    } else {
        double ms = (double)(t1 - t0) * 1e-6;
        h->st.frames_sent++;
        h->st.bytes_sent += len;
        h->st.send_ms_last = ms;
        h->send_ms_total += ms;
        h->st.send_ms_mean = h->send_ms_total / (double)h->st.frames_sent;
        if (!h->win_start_ns) h->win_start_ns = t0;
        h->win_bytes += len;
        if (t1 - h->win_start_ns >= 1000000000) {
            h->win_rate = (double)h->win_bytes / ((double)(t1 - h->win_start_ns) * 1e-9) * 1e-6;
            h->win_start_ns = t1;
            h->win_bytes = 0;
        }
    }
    pthread_mutex_unlock(&h->lock);
    return rc;
}

API int hmdwarp_host_submit(hmdwarp_host *h, const hmdwarp_host_frame *frame)
{
    if (!h) return host_fail(HMDWARP_HOST_ERR_ARG, "handle: NULL");
    pthread_mutex_lock(&h->send_lock);
    int rc;
    if (!h->link || (h->messages && !is_connected(h))) {
        rc = host_fail(HMDWARP_HOST_ERR_NOT_CONNECTED, "submit: not connected (the board went away; reconnecting)");
    } else {
        h->sized = NULL; /* buf is encoded again */
        int64_t n = encode_locked(h, frame);
        if (n < 0) {
            count_refused(h);
            rc = (int)n;
        } else {
            rc = send_locked(h, h->buf, (size_t)n);
        }
    }
    pthread_mutex_unlock(&h->send_lock);
    return rc;
}

API int64_t hmdwarp_host_encode(hmdwarp_host *h, const hmdwarp_host_frame *frame, void *buf, size_t cap)
{
    if (!h) return host_fail(HMDWARP_HOST_ERR_ARG, "handle: NULL");
    if (!buf && cap) return host_fail(HMDWARP_HOST_ERR_ARG, "buf: NULL with cap %zu", cap);
    pthread_mutex_lock(&h->send_lock);
    /* A compressed frame only sized (cap too small) stays in buf: the caller's next encode of the same frame gets
     * it as it was, so the size-then-fetch idiom advances a video stream by one frame, not two. */
    int64_t n = h->sized && h->sized == frame ? h->sized_len : encode_locked(h, frame);
    h->sized = NULL;
    if (n < 0) count_refused(h);
    if (n > 0 && (size_t)n <= cap) memcpy(buf, h->buf, (size_t)n);
    else if (n > 0 && !h->last_raw) h->sized = frame, h->sized_len = n;
    pthread_mutex_unlock(&h->send_lock);
    return n;
}

API int hmdwarp_host_send_raw(hmdwarp_host *h, const void *buf, size_t len)
{
    if (!h || (!buf && len)) return host_fail(HMDWARP_HOST_ERR_ARG, "%s: NULL", !h ? "handle" : "buf");
    pthread_mutex_lock(&h->send_lock);
    int rc = send_locked(h, buf, len);
    pthread_mutex_unlock(&h->send_lock);
    return rc;
}

API int hmdwarp_host_get_stats(hmdwarp_host *h, hmdwarp_host_stats *out)
{
    if (!h || !out) return host_fail(HMDWARP_HOST_ERR_ARG, "%s: NULL", !h ? "handle" : "out");
    int64_t now = hmdwarp_host_now_ns();
    pthread_mutex_lock(&h->lock);
    *out = h->st;
    /* The last full window's rate, or the current one's when it is the only one; 0 once sending stopped. */
    double cur = h->win_start_ns && now > h->win_start_ns
                     ? (double)h->win_bytes / ((double)(now - h->win_start_ns) * 1e-9) * 1e-6
                     : 0;
    out->mb_per_s = now - h->win_start_ns > 2000000000 ? 0 : h->win_rate > 0 ? h->win_rate : cur;
    out->connected = h->connected;
    pthread_mutex_unlock(&h->lock);
    return HMDWARP_HOST_OK;
}
