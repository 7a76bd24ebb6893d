/* SPDX-License-Identifier: MIT */
/* drv_frames_usb_mock: a drv_usb_transport (the seam FunctionFS fills on a board) made of socket pairs, and a
 * simulated host thread on their far side rendering at the poses the board sends, with payload, cut and stall
 * faults. */
#include "drivers/drv_frames_usb_mock.h"

#include <errno.h>
#include <poll.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "drivers/drv_framelink.h"
#include "drivers/drv_framelink_codec.h"
#include "drivers/drv_link_throttle.h"
#include "platform/plat_clock.h"
#include "warp/warp_err.h"

/* The transport and the host behind it, in one: the board's ends of the socket pairs and the host thread's. */
struct mock_host {
    drv_usb_transport base; /* the board's side of the socket pairs */
    int board_out_fd, board_in_fd;
    drv_frames_sim_params hp;
    drv_frames_usb_mock_params mp;
    drv_frames *sim;
    drv_frame frame;
    int out_fd, in_fd; /* host side */
    pthread_t th;
    bool up;
    atomic_bool stop;
    bool have_pose, stalled;
    drv_framelink_pose latest, used;
    int64_t latest_rx_ns, used_rx_ns;
    int64_t t_created;
    uint8_t *buf;
    size_t cap;
    unsigned board_codecs;   /* what the board's camera message announced (0: none yet) */
    drv_framelink_enc *enc;  /* auto's encoder for them (NULL: raw, v1 frames) */
    unsigned enc_codecs;
};

/* ---- the board's side: socket pairs for the endpoints ---- */

static ssize_t sock_read(drv_usb_transport *bt, uint8_t *buf, size_t cap, int timeout_ms)
{
    struct mock_host *t = (struct mock_host *)bt;
    struct pollfd pfd = {t->board_out_fd, POLLIN, 0};
    int r = poll(&pfd, 1, plat_timeout_ms(timeout_ms)); /* the mock host runs on virtual time (plat_clock.h) */
    if (r < 0) return errno == EINTR ? 0 : -errno;
    if (r == 0) return 0;
    ssize_t n = read(t->board_out_fd, buf, cap);
    if (n == 0) return -ESHUTDOWN; /* the mock host went away */
    if (n < 0) return errno == EINTR || errno == EAGAIN ? 0 : -errno;
    return n;
}

static ssize_t sock_write(drv_usb_transport *bt, const uint8_t *buf, size_t len, int timeout_ms)
{
    struct mock_host *t = (struct mock_host *)bt;
    struct pollfd pfd = {t->board_in_fd, POLLOUT, 0};
    int r = poll(&pfd, 1, plat_timeout_ms(timeout_ms));
    if (r <= 0) return r < 0 && errno != EINTR ? -errno : 0;
    ssize_t n = send(t->board_in_fd, buf, len, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n < 0) return errno == EAGAIN ? 0 : -errno;
    return n;
}

static bool sock_connected(drv_usb_transport *bt)
{
    (void)bt;
    return true;
}

/* ---- the simulated host ---- */


/* The simulated host's pose source: the newest pose message from the board. */
static bool mock_predict(void *ctx, int64_t t_ns, warp_pose *head)
{
    (void)t_ns;
    struct mock_host *m = ctx;
    if (!m->have_pose) return false;
    *head = m->latest.head;
    m->used = m->latest;
    m->used_rx_ns = m->latest_rx_ns;
    return true;
}

static void mock_drain_poses(struct mock_host *m)
{
    uint8_t msg[512];
    ssize_t n;
    while ((n = recv(m->in_fd, msg, sizeof msg, MSG_DONTWAIT)) > 0) {
        /* The camera message repeats what the simulated host was created with, but for the codecs: it encodes as
         * libhmdwarp-host's auto does with what the board announces. */
        uint32_t kind = drv_framelink_msg_peek(msg, (size_t)n, NULL);
        drv_framelink_cams c;
        if (kind == DRV_FRAMELINK_CAMS_MAGIC && drv_framelink_cams_decode(msg, (size_t)n, &c) == DRV_FRAME_OK)
            m->board_codecs = c.codecs;
        if (kind != DRV_FRAMELINK_POSE_MAGIC) continue;
        drv_framelink_pose p;
        if (drv_framelink_pose_decode(msg, (size_t)n, &p) == DRV_FRAME_OK) {
            m->latest = p;
            m->latest_rx_ns = plat_now_ns();
            m->have_pose = true;
        }
    }
}

/* Writes buf completely unless stopping; false when the board went away or we stop. */
static bool mock_write_all(struct mock_host *m, const uint8_t *buf, size_t len)
{
    while (len > 0 && !atomic_load(&m->stop)) {
        struct pollfd pfd = {m->out_fd, POLLOUT, 0};
        if (poll(&pfd, 1, 20) <= 0) continue;
        ssize_t n = send(m->out_fd, buf, len, MSG_NOSIGNAL | MSG_DONTWAIT);
        if (n < 0) {
            if (errno == EAGAIN || errno == EINTR) continue;
            return false;
        }
        buf += n;
        len -= (size_t)n;
    }
    return len == 0;
}

/* The frame as a host on auto sends it: v1 while the board announces raw alone, else through auto's encoder (made
 * again when the announcement changes; the buffer grows to its bound here, on the host's thread). */
static size_t mock_encode(struct mock_host *m, const drv_framelink_tx *tx)
{
    unsigned codecs = m->board_codecs & ~DRV_CODEC_BIT(DRV_CODEC_RAW);
    if (!codecs) return drv_framelink_encode_ex(&m->frame, tx, m->buf, m->cap);
    char why[160];
    if (!m->enc || m->enc_codecs != codecs) {
        drv_framelink_enc_destroy(m->enc);
        drv_framelink_enc_params p = drv_framelink_enc_params_auto(codecs, m->frame.depth_encoding);
        m->enc = drv_framelink_enc_create(&p, m->frame.cam[0].width, m->frame.cam[0].height, why, sizeof why);
        m->enc_codecs = codecs;
        if (!m->enc) return drv_framelink_encode_ex(&m->frame, tx, m->buf, m->cap);
        size_t bound = drv_framelink_enc_bound(m->enc, &m->frame);
        uint8_t *b = bound > m->cap ? realloc(m->buf, bound) : m->buf;
        if (!b) return 0;
        m->buf = b;
        m->cap = bound > m->cap ? bound : m->cap;
    }
    return drv_framelink_enc_encode(m->enc, &m->frame, tx, false, m->buf, m->cap, why, sizeof why);
}

static void *mock_thread(void *arg)
{
    struct mock_host *m = arg;
    plat_thread_set_name("hmdwarp-mockhost");
    uint64_t k = 0;
    while (!atomic_load(&m->stop)) {
        mock_drain_poses(m);
        int64_t start = plat_now_ns();
        int rc = drv_frames_receive(m->sim, &m->frame, 20);
        if (rc != 1) continue;
        /* Echo the board's pose: its target time (pose_t_ns) and send time, as a real host does. */
        m->frame.pose_t_ns = m->used.target_t_ns;
        drv_framelink_tx tx = {.pose_sent_ns = m->used.board_t_ns, .host_pose_rx_ns = m->used_rx_ns,
                               .host_render_start_ns = start, .host_render_end_ns = plat_now_ns()};
        tx.host_send_ns = plat_now_ns();
        size_t n = mock_encode(m, &tx);
        if (!n) continue;
        k++;
        size_t len = n;
        if (m->mp.corrupt_every > 0 && k % (uint64_t)m->mp.corrupt_every == 0) m->buf[n - n / 3] ^= 0x5A;
        if (m->mp.truncate_every > 0 && k % (uint64_t)m->mp.truncate_every == 0) len = n / 2;
        double since = (double)(plat_now_ns() - m->t_created) * 1e-9;
        if (!m->stalled && m->mp.stall_for_s > 0 && since >= m->mp.stall_at_s) {
            /* Stop mid-frame, as a host whose renderer hangs would. */
            m->stalled = true;
            if (!mock_write_all(m, m->buf, len / 2)) break;
            int64_t until = plat_now_ns() + (int64_t)(m->mp.stall_for_s * 1e9);
            while (!atomic_load(&m->stop) && plat_now_ns() < until) plat_sleep_ns(10 * PLAT_NS_PER_MS);
            if (!mock_write_all(m, m->buf + len / 2, len - len / 2)) break;
            continue;
        }
        if (!mock_write_all(m, m->buf, len)) break;
    }
    return NULL;
}

/* After the board's pose thread stopped: the host thread first, then both sides of the socket pairs. */
static void mock_destroy(drv_usb_transport *bt)
{
    struct mock_host *m = (struct mock_host *)bt;
    atomic_store(&m->stop, true);
    if (m->up) pthread_join(m->th, NULL);
    drv_frames_destroy(m->sim);
    drv_frame_free(&m->frame);
    drv_framelink_enc_destroy(m->enc);
    if (m->out_fd >= 0) close(m->out_fd);
    if (m->in_fd >= 0) close(m->in_fd);
    if (m->board_out_fd >= 0) close(m->board_out_fd);
    if (m->board_in_fd >= 0) close(m->board_in_fd);
    free(m->buf);
    free(m);
}

drv_frames *drv_frames_usb_create_mock(const drv_frames_sim_params *host, const drv_frames_usb_params *p,
                                       const drv_frames_usb_mock_params *mp, char *err, int errlen)
{
    for (int e = 0; e < 2; e++)
        if (host->cam[e].width != p->eye_w || host->cam[e].height != p->eye_h) {
            if (err && errlen > 0)
                warp_err(err, errlen, "usb mock: host camera %dx%d differs from the board's eye %dx%d",
                         host->cam[e].width, host->cam[e].height, p->eye_w, p->eye_h);
            return NULL;
        }
    struct mock_host *m = calloc(1, sizeof *m);
    if (!m) {
        warp_err(err, errlen, "usb mock: out of memory");
        return NULL;
    }
    m->out_fd = m->in_fd = m->board_out_fd = m->board_in_fd = -1;
    m->base.read = sock_read;
    m->base.write = sock_write;
    m->base.connected = sock_connected;
    m->base.destroy = mock_destroy;
    atomic_init(&m->stop, false);
    /* OUT: a byte stream, as bulk OUT reads are; IN: one message per packet, as bulk IN transfers are. */
    int outp[2] = {-1, -1}, inp[2] = {-1, -1};
    if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, outp) ||
        socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, inp)) {
        warp_err(err, errlen, "usb mock: socketpair: %s", strerror(errno));
        if (outp[0] >= 0) close(outp[0]), close(outp[1]);
        free(m);
        return NULL;
    }
    m->board_out_fd = outp[0], m->out_fd = outp[1];
    m->board_in_fd = inp[0], m->in_fd = inp[1];
    /* The board side first (it checks the parameters); its pose thread's first messages wait in the socket. */
    drv_usb_transport *link = drv_link_throttle(&m->base, p->link_mbps); /* [frames] link_mbps */
    if (!link) {
        warp_err(err, errlen, "usb mock: out of memory");
        return NULL;
    }
    drv_frames *fr = drv_frames_usb_create_on_transport(p, link, "usb-mock", err, errlen);
    if (!fr) return NULL;
    const char *why = "out of memory";
    m->mp = mp ? *mp : (drv_frames_usb_mock_params){0};
    m->hp = *host;
    m->hp.poses.predict = mock_predict;
    m->hp.poses.ctx = m;
    m->hp.planes_wanted &= p->planes;
    m->sim = drv_frames_sim_create(&m->hp);
    if (!m->sim) {
        why = "cannot create the simulated host";
        goto fail;
    }
    if (!drv_frame_alloc(&m->frame, p->eye_w, p->eye_h, drv_frames_planes(m->sim), 4)) goto fail;
    m->frame.planes = drv_frames_planes(m->sim);
    for (int e = 0; e < 2; e++) m->frame.cam[e] = host->cam[e];
    m->frame.n_objects = DRV_MAX_OBJECTS; /* size the buffer for the largest header */
    m->cap = drv_framelink_size(&m->frame);
    m->frame.n_objects = 0;
    if (m->frame.planes & DRV_PLANE_LAYERS) m->cap += (size_t)2 * p->eye_w * p->eye_h * 4 * 10;
    m->buf = malloc(m->cap);
    if (!m->buf) goto fail;
    m->t_created = plat_now_ns();
    m->up = pthread_create(&m->th, NULL, mock_thread, m) == 0;
    if (!m->up) {
        why = "cannot start the host thread";
        goto fail;
    }
    return fr;
fail:
    warp_err(err, errlen, "usb mock: %s", why);
    drv_frames_destroy(fr); /* destroys m with the transport */
    return NULL;
}
