/* SPDX-License-Identifier: MIT */
/* fake_board: a stand-in board for the host examples' tests: listens on a Unix socket (the socket link), sends the
 * camera and pose messages, decodes each frame with the framelink codec and prints checksums of every plane. */
#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>
#include <zlib.h>

#include "drivers/drv_framelink.h"
#include "drivers/drv_frames.h"

/* Pose messages every 5 ms (200 Hz), predicted 20 ms ahead: as a board's pose thread would, slower. */
#define POSE_PERIOD_NS 5000000
#define POSE_LEAD_NS 20000000
#define MAX_FRAME (64u << 20)
#define PLANES (DRV_PLANE_COLOR | DRV_PLANE_DEPTH | DRV_PLANE_IDS | DRV_PLANE_MOTION)

static atomic_bool stop;
static int conn = -1;

static int64_t now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

static bool send_all(const uint8_t *b, size_t n)
{
    while (n) {
        ssize_t w = send(conn, b, n, MSG_NOSIGNAL);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) return false;
        b += w, n -= (size_t)w;
    }
    return true;
}

/* The eye poses of pose message seq: a slow yaw, so consecutive frames differ and an echo of the wrong pose
 * shows in the checksum line. */
static void pose_of(uint32_t seq, drv_framelink_pose *p)
{
    double yaw = 0.002 * seq;
    warp_pose head = {{cos(yaw / 2), 0, sin(yaw / 2), 0}, {0, 1.6, 0}};
    p->seq = seq;
    p->board_t_ns = now_ns();
    p->target_t_ns = p->board_t_ns + POSE_LEAD_NS;
    p->head = head;
    for (int e = 0; e < 2; e++) {
        warp_pose off = warp_pose_identity();
        off.p.x = e ? 0.032 : -0.032;
        p->eye[e] = warp_pose_mul(head, off);
    }
}

static void *pose_thread(void *arg)
{
    (void)arg;
    uint8_t msg[DRV_FRAMELINK_POSE_BYTES];
    for (uint32_t seq = 1; !atomic_load(&stop); seq++) {
        drv_framelink_pose p;
        pose_of(seq, &p);
        drv_framelink_pose_encode(&p, msg, sizeof msg);
        if (!send_all(msg, sizeof msg)) break;
        nanosleep(&(struct timespec){0, POSE_PERIOD_NS}, NULL);
    }
    return NULL;
}

static bool read_full(uint8_t *b, size_t n)
{
    while (n) {
        ssize_t r = recv(conn, b, n, 0);
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) return false;
        b += r, n -= (size_t)r;
    }
    return true;
}

static unsigned long crc_rows(const void *px, int w, int h, int stride, size_t elem)
{
    uLong c = crc32(0, NULL, 0);
    for (int y = 0; y < h; y++) c = crc32(c, (const Bytef *)px + (size_t)y * (size_t)stride * elem, (uInt)(w * elem));
    return c;
}

static void print_frame(const drv_frame *f, const drv_framelink_rx *rx)
{
    printf("frame seq=%llu planes=%u enc=%d pose_t=%lld pose_sent=%lld start=%lld end=%lld objects=%d bytes=%zu",
           (unsigned long long)f->seq, f->planes, (int)f->depth_encoding, (long long)f->pose_t_ns,
           (long long)rx->tx.pose_sent_ns, (long long)rx->tx.host_render_start_ns,
           (long long)rx->tx.host_render_end_ns, f->n_objects, rx->total_bytes);
    for (int e = 0; e < 2; e++) {
        const warp_pose *p = &f->eye_pose[e];
        printf(" | eye%d %dx%d pose=%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g color=%08lx", e, f->cam[e].width,
               f->cam[e].height, p->q.w, p->q.x, p->q.y, p->q.z, p->p.x, p->p.y, p->p.z,
               crc_rows(f->color[e].px, f->color[e].w, f->color[e].h, f->color[e].stride, 4));
        if (f->planes & DRV_PLANE_DEPTH)
            printf(" depth=%08lx", crc_rows(f->depth[e].px, f->depth[e].w, f->depth[e].h, f->depth[e].stride, 4));
        if (f->planes & DRV_PLANE_IDS)
            printf(" ids=%08lx", crc_rows(f->ids[e].px, f->ids[e].w, f->ids[e].h, f->ids[e].stride, 2));
        if (f->planes & DRV_PLANE_MOTION)
            printf(" motion=%08lx", crc_rows(f->motion[e].px, f->motion[e].w, f->motion[e].h, f->motion[e].stride, 8));
    }
    for (int i = 0; i < f->n_objects; i++)
        printf(" | obj%d %.9g,%.9g", i + 1, f->object_pose[i].q.w, f->object_pose[i].p.x);
    printf("\n");
    fflush(stdout);
}

int main(int argc, char **argv)
{
    int w = 0, h = 0;
    long frames = argc > 3 ? atol(argv[3]) : 0;
    if (argc < 4 || sscanf(argv[2], "%dx%d", &w, &h) != 2 || w < 1 || h < 1 || frames < 1) {
        fprintf(stderr, "usage: fake_board SOCKET WxH FRAMES: serves one host, prints a line per frame, exits\n");
        return 2;
    }
    struct sockaddr_un a = {.sun_family = AF_UNIX};
    snprintf(a.sun_path, sizeof a.sun_path, "%s", argv[1]);
    int ls = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    unlink(argv[1]);
    if (ls < 0 || bind(ls, (struct sockaddr *)&a, sizeof a) < 0 || listen(ls, 1) < 0) {
        fprintf(stderr, "fake_board: %s: %s\n", argv[1], strerror(errno));
        return 1;
    }
    printf("listening %s\n", argv[1]);
    fflush(stdout);
    conn = accept(ls, NULL, NULL);
    if (conn < 0) return 1;

    drv_framelink_cams cams = {.seq = 1, .planes = PLANES, .depth_encoding = WARP_DEPTH_LINEAR,
                               .max_frame_bytes = MAX_FRAME, .refresh_hz = 90, .pose_rate_hz = 1e9 / POSE_PERIOD_NS};
    cams.cam[0] = cams.cam[1] = warp_camera_symmetric(w, h, 90, 2 * atan((double)h / w) * 180 / M_PI, 0.05, INFINITY);
    uint8_t cmsg[DRV_FRAMELINK_CAMS_BYTES];
    drv_framelink_cams_encode(&cams, cmsg, sizeof cmsg);
    if (!send_all(cmsg, sizeof cmsg)) return 1;
    /* and its visibility mask: a square for the left eye, none for the right */
    drv_framelink_mask mask = {.seq = 1, .n = {4, 0}, .uv = {{0.5f, 0, 0, 0.25f, -0.5f, 0, 0, -0.25f}}};
    uint8_t mmsg[DRV_FRAMELINK_MASK_BYTES(4, 0)];
    drv_framelink_mask_encode(&mask, mmsg, sizeof mmsg);
    if (!send_all(mmsg, sizeof mmsg)) return 1;
    pthread_t pt;
    pthread_create(&pt, NULL, pose_thread, NULL);

    drv_frame f;
    uint8_t *buf = malloc(MAX_FRAME);
    if (!buf || !drv_frame_alloc(&f, w, h, PLANES, 0)) return 1;
    long got = 0;
    int rc = 0;
    while (got < frames) {
        size_t have = 0, need = DRV_FRAMELINK_PREFIX_BYTES, total = 0;
        drv_frame_err e;
        while ((e = drv_framelink_peek(buf, have, MAX_FRAME, &total)) == DRV_FRAME_ERR_TRUNCATED) {
            need = total;
            if (!read_full(buf + have, need - have)) goto eof;
            have = need;
        }
        if (e != DRV_FRAME_OK) {
            printf("reject %s (header)\n", drv_frame_err_str(e));
            rc = 1;
            break;
        }
        if (!read_full(buf + have, total - have)) goto eof;
        drv_framelink_rx rx;
        char detail[256] = "";
        e = drv_framelink_decode_ex(buf, total, MAX_FRAME, &f, &rx, detail, sizeof detail);
        if (e == DRV_FRAME_OK) {
            print_frame(&f, &rx);
        } else {
            printf("reject %s %s\n", drv_frame_err_str(e), detail);
            fflush(stdout);
        }
        got++;
    }
    goto done;
eof:
    printf("eof after %ld frames\n", got);
done:
    atomic_store(&stop, true);
    shutdown(conn, SHUT_RDWR);
    pthread_join(pt, NULL);
    close(conn);
    close(ls);
    unlink(argv[1]);
    drv_frame_free(&f);
    free(buf);
    return rc;
}
