/* SPDX-License-Identifier: MIT */
/* test_host_link: the host's end of the board's frames socket for the tests that play the host, and the reading
 * of a recorded framelink stream. Include after <cmocka.h>: the stream helper asserts with it. */
#ifndef TEST_HOST_LINK_H
#define TEST_HOST_LINK_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include "drivers/drv_framelink.h"

/* The test's host: its end of the socket and the board -> host stream read so far. */
typedef struct {
    int fd;
    uint8_t buf[8192];
    size_t have;
} test_host_link;

/* Connects h to the socket at path, up to `tries` times 10 ms apart (a daemon that is still starting listens
 * late); false when no try succeeded. */
static inline bool test_host_link_connect(test_host_link *h, const char *path, int tries)
{
    memset(h, 0, sizeof *h);
    struct sockaddr_un a = {.sun_family = AF_UNIX};
    snprintf(a.sun_path, sizeof a.sun_path, "%s", path);
    for (int i = 0; i < tries; i++) {
        if (i) usleep(10000);
        h->fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
        if (h->fd >= 0 && connect(h->fd, (struct sockaddr *)&a, sizeof a) == 0) return true;
        close(h->fd);
    }
    h->fd = -1;
    return false;
}

/* The frame at *at of a framelink stream (frames back to back, none over max bytes) into f, which must arrive
 * whole and valid; moves *at past it. */
static inline void test_stream_next(const uint8_t *buf, size_t len, size_t *at, size_t max, drv_frame *f)
{
    size_t total;
    assert_int_equal(drv_framelink_peek(buf + *at, len - *at, max, &total), DRV_FRAME_OK);
    assert_int_equal(drv_framelink_decode(buf + *at, total, max, f), DRV_FRAME_OK);
    assert_int_equal(drv_frame_validate(f), DRV_FRAME_OK);
    *at += total;
}

#endif
