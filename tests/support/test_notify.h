/* SPDX-License-Identifier: MIT */
/* test_notify: a stand-in for systemd's NOTIFY_SOCKET for tests that run hmdwarpd as its unit would: a datagram
 * socket the daemon's sd_notify messages arrive on, read while the child runs (as systemd does). */
#ifndef TEST_NOTIFY_H
#define TEST_NOTIFY_H

#include <stdbool.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

typedef struct {
    int fd;
    char path[100]; /* a socket path must fit sun_path (108 bytes): short, unique per test process */
} test_notify;

/* Binds /tmp/hmdwarp-TAG-PID.sock, non-blocking; false (errno set) when it cannot. */
static inline bool test_notify_open(test_notify *n, const char *tag)
{
    snprintf(n->path, sizeof n->path, "/tmp/hmdwarp-%s-%d.sock", tag, (int)getpid());
    unlink(n->path);
    n->fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_NONBLOCK, 0);
    if (n->fd < 0) return false;
    struct sockaddr_un sa = {.sun_family = AF_UNIX};
    memcpy(sa.sun_path, n->path, strlen(n->path) + 1);
    return bind(n->fd, (struct sockaddr *)&sa, sizeof sa) == 0;
}

/* Hands each message (NUL-terminated) to on_msg until it returns true (it saw the last one: STOPPING=1) or
 * limit_ms of polling every 5 ms has passed: a datagram queue that nobody reads would block the sender. */
static inline void test_notify_read(test_notify *n, double limit_ms, bool (*on_msg)(const char *msg, void *ctx),
                                    void *ctx)
{
    char msg[1024];
    bool last = false;
    for (int waited = 0; !last && waited < limit_ms; waited += 5) {
        ssize_t len = recv(n->fd, msg, sizeof msg - 1, 0);
        if (len <= 0) {
            usleep(5000);
            continue;
        }
        msg[len] = 0;
        last = on_msg(msg, ctx);
    }
}

static inline void test_notify_close(test_notify *n)
{
    close(n->fd);
    unlink(n->path);
}

#endif
