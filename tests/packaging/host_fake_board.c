/* SPDX-License-Identifier: MIT */
/* host_fake_board: a board's side of the socket frame link for the installed-library test (test_host_install.sh):
 * sends the camera message and pose messages, decodes and checks the frames a host sends, saves the last colour. */
#include <math.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#include "drivers/drv_framelink.h"

/* Pose messages every 5 ms while frames are awaited (a fast board: the host never waits long). */
#define POSE_PERIOD_MS 5

static int fail(const char *msg)
{
    fprintf(stderr, "host_fake_board: %s\n", msg);
    return 1;
}

int main(int argc, char **argv)
{
    if (argc != 6)
        return fprintf(stderr, "usage: host_fake_board SOCKET W H FRAMES OUT.rgba\n"), 2;
    int w = atoi(argv[2]), h = atoi(argv[3]), want = atoi(argv[4]);
    int lfd = socket(AF_UNIX, SOCK_STREAM, 0);
    struct sockaddr_un sa = {.sun_family = AF_UNIX};
    if (strlen(argv[1]) >= sizeof sa.sun_path) return fail("socket path too long");
    strcpy(sa.sun_path, argv[1]);
    unlink(argv[1]);
    if (bind(lfd, (struct sockaddr *)&sa, sizeof sa) || listen(lfd, 1)) return fail("bind/listen failed");
    printf("listening\n");
    fflush(stdout);
    int fd = accept(lfd, NULL, NULL);
    if (fd < 0) return fail("accept failed");
    drv_framelink_cams c = {.seq = 1, .planes = DRV_PLANE_COLOR | DRV_PLANE_DEPTH, .max_frame_bytes = 64u << 20,
                            .refresh_hz = 90, .pose_rate_hz = 1000.0 / POSE_PERIOD_MS};
    c.cam[0] = c.cam[1] = warp_camera_symmetric(w, h, 90, 90, 0.05, INFINITY);
    uint8_t msg[DRV_FRAMELINK_POSE_BYTES];
    drv_framelink_cams_encode(&c, msg, sizeof msg);
    if (send(fd, msg, DRV_FRAMELINK_CAMS_BYTES, MSG_NOSIGNAL) != DRV_FRAMELINK_CAMS_BYTES) return fail("send cams");
    drv_frame f;
    if (!drv_frame_alloc(&f, w, h, c.planes, 1)) return fail("out of memory");
    size_t cap = 64u << 20, have = 0;
    uint8_t *buf = malloc(cap);
    uint32_t seq = 0;
    int got = 0;
    while (got < want) {
        drv_framelink_pose p = {.seq = ++seq, .board_t_ns = 1000000000LL + seq * 5000000LL};
        p.target_t_ns = p.board_t_ns + 20000000;
        p.head = p.eye[0] = p.eye[1] = (warp_pose){warp_quat_from_ypr(0.01 * seq, 0, 0), warp_v3(0, 1.6, 0)};
        drv_framelink_pose_encode(&p, msg, sizeof msg);
        if (send(fd, msg, sizeof msg, MSG_NOSIGNAL) != (ssize_t)sizeof msg) return fail("the host went away");
        struct pollfd pfd = {.fd = fd, .events = POLLIN};
        while (got < want && poll(&pfd, 1, POSE_PERIOD_MS) > 0) {
            ssize_t n = recv(fd, buf + have, cap - have, 0);
            if (n <= 0) return fail("the host closed the connection before the frames arrived");
            have += (size_t)n;
            size_t total;
            drv_frame_err e;
            while ((e = drv_framelink_peek(buf, have, cap, &total)) == DRV_FRAME_OK && have >= total) {
                char why[200] = "";
                e = drv_framelink_decode_ex(buf, total, cap, &f, NULL, why, sizeof why);
                if (e == DRV_FRAME_OK) e = drv_frame_validate(&f);
                if (e != DRV_FRAME_OK) return fprintf(stderr, "host_fake_board: frame rejected: %s %s\n",
                                                      drv_frame_err_str(e), why), 1;
                got++;
                memmove(buf, buf + total, have - total);
                have -= total;
            }
            if (e != DRV_FRAME_OK && e != DRV_FRAME_ERR_TRUNCATED)
                return fprintf(stderr, "host_fake_board: stream: %s\n", drv_frame_err_str(e)), 1;
        }
    }
    FILE *out = fopen(argv[5], "wb");
    for (int y = 0; y < h && out; y++) fwrite(&WARP_AT(&f.color[0], 0, y), 4, (size_t)w, out);
    if (!out || fclose(out)) return fail("cannot write the colour");
    printf("received %d frames, %dx%d, planes 0x%x, depth(0,0) %g, last seq %llu\n", got, w, h, f.planes,
           (double)WARP_AT(&f.depth[0], 0, 0), (unsigned long long)f.seq);
    close(fd);
    close(lfd);
    unlink(argv[1]);
    drv_frame_free(&f);
    free(buf);
    return 0;
}
