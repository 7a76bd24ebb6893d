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

#include "drivers/drv_framelink.h"
#include "host/hmdwarp-host.h"
#include "host/host_frame.h"
#include "host/host_link.h"
#include "platform/plat_version.h"

#define API __attribute__((visibility("default")))

/* Pose messages kept for hmdwarp_host_frame.pose_seq: 1024 at the board's 500 Hz is 2 s (200 KB), longer than any
 * render a board would still warp, even on a host loaded enough to stretch a render tenfold (64, 128 ms, refused a
 * loaded machine's first frames). */
#define POSE_RING 1024
/* Board messages are small (204 and 168 bytes); a declared size above this is garbage to resynchronise past. */
#define MSG_MAX 4096
#define READ_TIMEOUT_MS 100
#define RECONNECT_MS 200
#define DEFAULT_WAIT_S 5.0

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
    hmdwarp_host_stats st;
    double send_ms_total;
    int64_t win_start_ns;
    uint64_t win_bytes;
    double win_rate;

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
    h->st.cameras_received++;
    pthread_cond_broadcast(&h->cond);
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
    pthread_condattr_t ca;
    pthread_condattr_init(&ca);
    pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
    pthread_cond_init(&h->cond, &ca);
    pthread_condattr_destroy(&ca);
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
    free(h->buf);
    free(h->path);
    pthread_cond_destroy(&h->cond);
    pthread_mutex_destroy(&h->lock);
    pthread_mutex_destroy(&h->send_lock);
    free(h);
}

API int hmdwarp_host_connected(hmdwarp_host *h) { return h && is_connected(h) ? 1 : 0; }

/* ---- poses and cameras ---- */

static void deadline(struct timespec *ts, int timeout_ms)
{
    clock_gettime(CLOCK_MONOTONIC, ts);
    ts->tv_sec += timeout_ms / 1000;
    ts->tv_nsec += (long)(timeout_ms % 1000) * 1000000L;
    if (ts->tv_nsec >= 1000000000L) ts->tv_sec++, ts->tv_nsec -= 1000000000L;
}

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
    if (timeout_ms > 0) deadline(&ts, timeout_ms);
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

API int hmdwarp_host_wait_cameras(hmdwarp_host *h, int timeout_ms, hmdwarp_host_cameras *out)
{
    if (!h || !out) return host_fail(HMDWARP_HOST_ERR_ARG, "%s: NULL", !h ? "handle" : "out");
    struct timespec ts;
    if (timeout_ms > 0) deadline(&ts, timeout_ms);
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
    if (!(cams->planes & HMDWARP_HOST_PLANE_COLOR) || (cams->planes & ~0x1fu))
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
    pthread_mutex_unlock(&h->lock);
    drv_framelink_tx tx;
    if (!rc) rc = host_frame_build(&h->scratch, frame, &ctx, &tx);
    if (rc) return rc;
    size_t size = drv_framelink_size_ex(&h->scratch.f, &tx);
    if (!size) return host_fail(HMDWARP_HOST_ERR_FORMAT, "frame: the planes and formats cannot be encoded together");
    if (ctx.cams_from_board && size > cams.max_frame_bytes)
        return host_fail(HMDWARP_HOST_ERR_SIZE, "frame: %zu bytes, over the board's max_frame_bytes %llu", size,
                         (unsigned long long)cams.max_frame_bytes);
    if (size > h->cap) {
        uint8_t *b = realloc(h->buf, size);
        if (!b) return host_fail(HMDWARP_HOST_ERR_NO_MEMORY, "frame: out of memory for %zu bytes", size);
        h->buf = b;
        h->cap = size;
    }
    if (drv_framelink_encode_ex(&h->scratch.f, &tx, h->buf, h->cap) != size)
        return host_fail(HMDWARP_HOST_ERR_FORMAT, "frame: the encoder refused it");
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
    int64_t n = encode_locked(h, frame);
    if (n < 0) count_refused(h);
    if (n > 0 && (size_t)n <= cap) memcpy(buf, h->buf, (size_t)n);
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
