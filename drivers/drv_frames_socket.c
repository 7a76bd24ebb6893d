/* SPDX-License-Identifier: MIT */
/* drv_frames_socket: a drv_usb_transport over a listening Unix-domain stream socket, one host at a time; the
 * receive state machine, pose thread and statistics above it are the USB backend's, unchanged. */
#include "drivers/drv_frames_socket.h"

#include <errno.h>
#include <libgen.h>
#include <poll.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include "drivers/drv_link_throttle.h"
#include "platform/plat_clock.h"
#include "platform/plat_log.h"
#include "warp/warp_err.h"

#define BACKLOG 4              /* a host reconnecting while the old connection is being dropped */
#define FINISH_MS 100          /* the rest of a message the socket took only part of (the stream must stay whole) */
_Static_assert(DRV_FRAMES_SOCKET_PATH_MAX + 1 == sizeof(((struct sockaddr_un *)0)->sun_path), "sun_path size");

/* The reader (the frames thread, through read) alone accepts and drops hosts; the pose thread alone writes. */
typedef struct {
    drv_usb_transport base;
    char path[DRV_FRAMES_SOCKET_PATH_MAX + 1];
    dev_t dev;                 /* the socket file we made: removed at the end only if it is still ours */
    ino_t ino;
    int listen_fd;
    pthread_mutex_t lock;      /* conn_fd's changes against writes to it; the counters */
    int conn_fd;               /* the host's, -1 when none */
    pid_t conn_pid;
    uint64_t conns, conns_told; /* hosts accepted / as connections() last reported them */
    _Atomic uint64_t refused;
} sock_transport;

/* "pid 1234 (hmdwarp-feed)": the peer's process as the kernel saw it connect, for the log. */
static void peer_name(int fd, pid_t *pid, char *buf, size_t len)
{
    struct ucred cr;
    socklen_t sl = sizeof cr;
    *pid = 0;
    if (getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cr, &sl) != 0 || cr.pid <= 0) {
        snprintf(buf, len, "an unknown process");
        return;
    }
    *pid = cr.pid;
    char comm[64] = "", p[64];
    snprintf(p, sizeof p, "/proc/%d/comm", (int)cr.pid);
    FILE *f = fopen(p, "r");
    if (f) {
        if (fgets(comm, sizeof comm, f)) comm[strcspn(comm, "\n")] = 0;
        fclose(f);
    }
    snprintf(buf, len, "pid %d%s%s%s", (int)cr.pid, comm[0] ? " (" : "", comm, comm[0] ? ")" : "");
}

static void accept_host(sock_transport *t)
{
    int fd = accept4(t->listen_fd, NULL, NULL, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) return; /* the host gave up first, or EMFILE: it is asked again at the next poll */
    char who[96];
    pid_t pid;
    peer_name(fd, &pid, who, sizeof who);
    pthread_mutex_lock(&t->lock);
    bool busy = t->conn_fd >= 0;
    pid_t cur = t->conn_pid;
    if (!busy) {
        t->conn_fd = fd;
        t->conn_pid = pid;
        t->conns++;
    }
    pthread_mutex_unlock(&t->lock);
    if (busy) {
        close(fd); /* the host reads end of file at once */
        atomic_fetch_add(&t->refused, 1);
        plat_log(PLAT_LOG_WARNING, "socket frames: %s: refused a second host, %s (host pid %d is connected)", t->path,
                 who, (int)cur);
    } else {
        plat_log(PLAT_LOG_NOTICE, "socket frames: %s: host connected: %s", t->path, who);
    }
}

static void drop_host(sock_transport *t)
{
    pthread_mutex_lock(&t->lock);
    if (t->conn_fd >= 0) close(t->conn_fd);
    t->conn_fd = -1;
    t->conn_pid = 0;
    pthread_mutex_unlock(&t->lock);
}

/* The frames thread's: new hosts are accepted (or refused) here, between reads of the connected one's stream. The
 * connected host's bytes come first: a host that closed and at once reconnected has its end of file read (the old
 * connection dropped) before the new connection is looked at, so it is accepted rather than refused. */
static ssize_t sock_read(drv_usb_transport *bt, uint8_t *buf, size_t cap, int timeout_ms)
{
    sock_transport *t = (sock_transport *)bt;
    int conn = t->conn_fd; /* only this thread changes it */
    struct pollfd pfd[2] = {{t->listen_fd, POLLIN, 0}, {conn, POLLIN, 0}};
    int r = poll(pfd, conn >= 0 ? 2 : 1, plat_timeout_ms(timeout_ms));
    if (r < 0) return errno == EINTR ? 0 : -errno;
    if (r == 0) return 0;
    ssize_t rc = 0;
    if (conn >= 0 && (pfd[1].revents & (POLLIN | POLLHUP | POLLERR))) {
        ssize_t n = recv(conn, buf, cap, MSG_DONTWAIT);
        if (n > 0) return n; /* a waiting connection is taken at a later call: the listener stays readable */
        if (n == 0 || (errno != EAGAIN && errno != EINTR)) {
            int e = n == 0 ? ECONNRESET : errno; /* end of file: the host closed its end */
            plat_log(PLAT_LOG_NOTICE, "socket frames: %s: host pid %d went away (%s)", t->path, (int)t->conn_pid,
                     n == 0 ? "closed" : strerror(e));
            drop_host(t);
            rc = -e;
        }
    }
    if (pfd[0].revents & POLLIN) accept_host(t);
    return rc;
}

static ssize_t sock_write(drv_usb_transport *bt, const uint8_t *buf, size_t len, int timeout_ms)
{
    sock_transport *t = (sock_transport *)bt;
    ssize_t rc = 0;
    pthread_mutex_lock(&t->lock);
    if (t->conn_fd < 0 || t->conns != t->conns_told) goto out; /* a host not yet greeted gets nothing */
    struct pollfd pfd = {t->conn_fd, POLLOUT, 0};
    int r = poll(&pfd, 1, plat_timeout_ms(timeout_ms));
    if (r <= 0) {
        rc = r < 0 && errno != EINTR ? -errno : 0;
        goto out;
    }
    ssize_t n = send(t->conn_fd, buf, len, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n < 0) {
        rc = errno == EAGAIN ? 0 : -errno; /* a host that reads no poses: they are dropped, as on USB */
        goto out;
    }
    size_t done = (size_t)n;
    int64_t until = plat_now_ns() + FINISH_MS * PLAT_NS_PER_MS;
    while (done < len && plat_now_ns() < until) {
        pfd.revents = 0;
        if (poll(&pfd, 1, plat_timeout_ms(10)) <= 0) continue;
        n = send(t->conn_fd, buf + done, len - done, MSG_NOSIGNAL | MSG_DONTWAIT);
        if (n < 0 && errno != EAGAIN && errno != EINTR) break;
        if (n > 0) done += (size_t)n;
    }
    if (done < len) {
        /* Half a message would garble every later one: end the connection (the reader counts the disconnect). */
        shutdown(t->conn_fd, SHUT_RDWR);
        rc = -EPIPE;
        goto out;
    }
    rc = (ssize_t)len;
out:
    pthread_mutex_unlock(&t->lock);
    return rc;
}

static bool sock_connected(drv_usb_transport *bt)
{
    sock_transport *t = (sock_transport *)bt;
    pthread_mutex_lock(&t->lock);
    bool c = t->conn_fd >= 0;
    pthread_mutex_unlock(&t->lock);
    return c;
}

static uint64_t sock_connections(drv_usb_transport *bt)
{
    sock_transport *t = (sock_transport *)bt;
    pthread_mutex_lock(&t->lock);
    uint64_t n = t->conns_told = t->conns;
    pthread_mutex_unlock(&t->lock);
    return n;
}

static void sock_stats(drv_usb_transport *bt, drv_frames_usb_stats *st)
{
    sock_transport *t = (sock_transport *)bt;
    pthread_mutex_lock(&t->lock);
    st->connections = t->conns;
    pthread_mutex_unlock(&t->lock);
    st->refused = atomic_load(&t->refused);
}

static void sock_destroy(drv_usb_transport *bt)
{
    sock_transport *t = (sock_transport *)bt;
    drop_host(t);
    if (t->listen_fd >= 0) {
        close(t->listen_fd);
        struct stat sb;
        if (lstat(t->path, &sb) == 0 && sb.st_dev == t->dev && sb.st_ino == t->ino) unlink(t->path);
    }
    pthread_mutex_destroy(&t->lock);
    free(t);
}

/* A socket file at path: replaced when nothing listens there (a board that died), an error otherwise. */
static bool clear_path(const char *path, char *err, int errlen)
{
    struct stat sb;
    if (lstat(path, &sb) != 0) {
        if (errno == ENOENT) return true;
        return warp_err(err, errlen, "socket frames: %s: %s", path, strerror(errno));
    }
    if (!S_ISSOCK(sb.st_mode))
        return warp_err(err, errlen, "socket frames: %s exists and is %s, not a socket: remove it or choose another "
                                     "[frames] device", path,
                        S_ISREG(sb.st_mode) ? "a regular file" : S_ISDIR(sb.st_mode) ? "a directory"
                        : S_ISLNK(sb.st_mode) ? "a symbolic link" : "a special file");
    int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) return warp_err(err, errlen, "socket frames: socket: %s", strerror(errno));
    struct sockaddr_un a = {.sun_family = AF_UNIX};
    memcpy(a.sun_path, path, strlen(path) + 1);
    bool live = connect(fd, (struct sockaddr *)&a, sizeof a) == 0;
    close(fd);
    if (live)
        return warp_err(err, errlen, "socket frames: %s: another process is listening there (a second hmdwarpd?)",
                        path);
    if (unlink(path) != 0)
        return warp_err(err, errlen, "socket frames: %s: cannot remove the stale socket: %s", path, strerror(errno));
    return true;
}

/* The parent directory: made when it alone is missing (/run/hmdwarp on a PC); a deeper missing path is a typo. */
static bool make_parent(const char *path, char *err, int errlen)
{
    char d[DRV_FRAMES_SOCKET_PATH_MAX + 1];
    snprintf(d, sizeof d, "%s", path);
    const char *dir = dirname(d);
    struct stat sb;
    if (stat(dir, &sb) == 0) {
        if (S_ISDIR(sb.st_mode)) return true;
        return warp_err(err, errlen, "socket frames: %s: %s is not a directory", path, dir);
    }
    if (errno != ENOENT || mkdir(dir, 0755) != 0)
        return warp_err(err, errlen, "socket frames: %s: cannot make the directory %s: %s", path, dir,
                        strerror(errno));
    return true;
}

drv_frames *drv_frames_socket_create(const drv_frames_usb_params *p, const char *path, char *err, int errlen)
{
    if (!path || !path[0]) path = DRV_FRAMES_SOCKET_DEFAULT;
    size_t len = strlen(path);
    if (len > DRV_FRAMES_SOCKET_PATH_MAX) {
        warp_err(err, errlen, "socket frames: %s: %zu characters, a Unix socket path holds at most %d", path, len,
                 DRV_FRAMES_SOCKET_PATH_MAX);
        return NULL;
    }
    if (!make_parent(path, err, errlen) || !clear_path(path, err, errlen)) return NULL;
    sock_transport *t = calloc(1, sizeof *t);
    if (!t) {
        warp_err(err, errlen, "socket frames: out of memory");
        return NULL;
    }
    memcpy(t->path, path, len + 1);
    t->conn_fd = -1;
    t->listen_fd = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    pthread_mutex_init(&t->lock, NULL);
    atomic_init(&t->refused, 0);
    t->base.read = sock_read;
    t->base.write = sock_write;
    t->base.connected = sock_connected;
    t->base.connections = sock_connections;
    t->base.stats = sock_stats;
    t->base.destroy = sock_destroy;
    struct sockaddr_un a = {.sun_family = AF_UNIX};
    memcpy(a.sun_path, path, len + 1);
    struct stat sb;
    bool bound = t->listen_fd >= 0 && bind(t->listen_fd, (struct sockaddr *)&a, sizeof a) == 0;
    if (!bound || listen(t->listen_fd, BACKLOG) != 0 || lstat(path, &sb) != 0) {
        warp_err(err, errlen, "socket frames: cannot listen at %s: %s", path, strerror(errno));
        if (bound) unlink(path); /* only what bind made: a failed bind leaves someone else's file alone */
        if (t->listen_fd >= 0) close(t->listen_fd);
        t->listen_fd = -1;
        sock_destroy(&t->base);
        return NULL;
    }
    t->dev = sb.st_dev;
    t->ino = sb.st_ino;
    drv_usb_transport *link = drv_link_throttle(&t->base, p->link_mbps); /* [frames] link_mbps */
    if (!link) {
        warp_err(err, errlen, "socket frames: out of memory");
        return NULL;
    }
    return drv_frames_usb_create_on_transport(p, link, "socket", err, errlen);
}
