/* SPDX-License-Identifier: MIT */
/* host_link: the transports of libhmdwarp-host: libusb bulk transfers to the board's gadget (enumeration polled:
 * hot-plug without udevd), a Unix-domain stream socket (hmdwarpd's socket backend), or a plain file / stdout. */
#include "host/host_link.h"

#include <errno.h>
#include <fcntl.h>
#include <libusb.h>
#include <poll.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#include "host/host_frame.h"

#define USB_DEFAULT_VID 0x1d6b /* Linux Foundation */
#define USB_DEFAULT_PID 0x0104 /* multifunction composite gadget: what board/gadget.sh registers */
/* One bulk OUT transfer at most (libusb's int length; usbfs splits it further). */
#define USB_CHUNK (1 << 24)
/* A stalled board is given this long per chunk before the write counts as failed. */
#define USB_WRITE_TIMEOUT_MS 2000
/* How often a board that is not there is looked for again. */
#define RETRY_MS 200

struct host_link {
    hmdwarp_host_transport kind;
    int fd;
    bool own_fd;
    libusb_context *usb;
    libusb_device_handle *dev;
    int interface;
    unsigned char ep_in, ep_out;
};

static void sleep_ms(int ms)
{
    struct timespec ts = {ms / 1000, (long)(ms % 1000) * 1000000L};
    while (nanosleep(&ts, &ts) != 0 && errno == EINTR) {
    }
}

static bool usb_find_endpoints(host_link *l)
{
    struct libusb_config_descriptor *cfg;
    if (libusb_get_active_config_descriptor(libusb_get_device(l->dev), &cfg) != 0) return false;
    /* The endpoints from the descriptors rather than assumed numbers. */
    for (int i = 0; i < cfg->bNumInterfaces; i++) {
        const struct libusb_interface_descriptor *id = &cfg->interface[i].altsetting[0];
        if (id->bInterfaceNumber != l->interface) continue;
        for (int e = 0; e < id->bNumEndpoints; e++) {
            const struct libusb_endpoint_descriptor *ep = &id->endpoint[e];
            if ((ep->bmAttributes & 3) != LIBUSB_TRANSFER_TYPE_BULK) continue;
            if (ep->bEndpointAddress & LIBUSB_ENDPOINT_IN)
                l->ep_in = ep->bEndpointAddress;
            else
                l->ep_out = ep->bEndpointAddress;
        }
    }
    libusb_free_config_descriptor(cfg);
    return l->ep_in && l->ep_out;
}

static void usb_release(host_link *l)
{
    if (l->dev) {
        libusb_release_interface(l->dev, l->interface);
        libusb_close(l->dev);
    }
    if (l->usb) libusb_exit(l->usb);
    l->dev = NULL;
    l->usb = NULL;
}

static bool usb_open(host_link *l, const hmdwarp_host_options *o, double wait_s, const atomic_bool *stop)
{
    unsigned vid = o->vid ? o->vid : USB_DEFAULT_VID, pid = o->pid ? o->pid : USB_DEFAULT_PID;
    l->interface = o->interface;
    struct timespec t0;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (;;) {
        /* Without udevd libusb gets no hot-plug events and keeps its first device list: a new context rescans. */
        int rc = libusb_init(&l->usb);
        if (rc != 0) {
            l->usb = NULL;
            return host_fail(HMDWARP_HOST_ERR_IO, "usb: libusb_init: %s", libusb_strerror(rc)), false;
        }
        l->dev = libusb_open_device_with_vid_pid(l->usb, (uint16_t)vid, (uint16_t)pid);
        if (l->dev) break;
        libusb_exit(l->usb);
        l->usb = NULL;
        struct timespec t;
        clock_gettime(CLOCK_MONOTONIC, &t);
        double waited = (double)(t.tv_sec - t0.tv_sec) + (double)(t.tv_nsec - t0.tv_nsec) * 1e-9;
        if ((stop && atomic_load(stop)) || waited >= wait_s)
            return host_fail(HMDWARP_HOST_ERR_IO, "usb: no USB device %04x:%04x after %.0f s (is the board's gadget "
                             "bound? permissions on /dev/bus/usb?)", vid, pid, wait_s), false;
        sleep_ms(RETRY_MS);
    }
    libusb_set_auto_detach_kernel_driver(l->dev, 1);
    int rc = libusb_claim_interface(l->dev, l->interface);
    if (rc != 0) {
        host_fail(HMDWARP_HOST_ERR_IO, "usb %04x:%04x: claiming interface %d: %s", vid, pid, l->interface,
                  libusb_strerror(rc));
        usb_release(l);
        return false;
    }
    if (!usb_find_endpoints(l)) {
        host_fail(HMDWARP_HOST_ERR_IO, "usb %04x:%04x: interface %d has no bulk IN + OUT pair", vid, pid, l->interface);
        usb_release(l);
        return false;
    }
    return true;
}

static bool socket_open(host_link *l, const char *path, double wait_s, const atomic_bool *stop)
{
    struct sockaddr_un sa = {.sun_family = AF_UNIX};
    if (!path || !path[0] || strlen(path) >= sizeof sa.sun_path)
        return host_fail(HMDWARP_HOST_ERR_ARG, "socket: path '%s' is empty or longer than %zu bytes", path ? path : "",
                         sizeof sa.sun_path - 1), false;
    memcpy(sa.sun_path, path, strlen(path) + 1);
    int tries = wait_s > 0 ? (int)(wait_s * 1000 / RETRY_MS) + 1 : 1;
    for (int i = 0;; i++) {
        int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
        if (fd < 0) return host_fail(HMDWARP_HOST_ERR_IO, "socket: %s", strerror(errno)), false;
        if (connect(fd, (struct sockaddr *)&sa, sizeof sa) == 0) {
            l->fd = fd;
            l->own_fd = true;
            return true;
        }
        int err = errno;
        close(fd);
        if (i + 1 >= tries || (stop && atomic_load(stop)))
            return host_fail(HMDWARP_HOST_ERR_IO, "socket:%s: connect: %s (is hmdwarpd running with [frames] backend "
                             "= socket?)", path, strerror(err)), false;
        sleep_ms(RETRY_MS);
    }
}

host_link *host_link_open(const hmdwarp_host_options *o, double wait_s, const atomic_bool *stop)
{
    host_link *l = calloc(1, sizeof *l);
    if (!l) return host_fail(HMDWARP_HOST_ERR_NO_MEMORY, "out of memory"), NULL;
    l->kind = o->transport;
    l->fd = -1;
    bool ok = false;
    switch (o->transport) {
    case HMDWARP_HOST_TRANSPORT_USB: ok = usb_open(l, o, wait_s, stop); break;
    case HMDWARP_HOST_TRANSPORT_SOCKET: ok = socket_open(l, o->path, wait_s, stop); break;
    case HMDWARP_HOST_TRANSPORT_FILE:
        if (!o->path || !o->path[0]) {
            host_fail(HMDWARP_HOST_ERR_ARG, "file: no path");
        } else if (strcmp(o->path, "-") == 0) {
            l->fd = STDOUT_FILENO;
            ok = true;
        } else {
            l->fd = open(o->path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
            l->own_fd = ok = l->fd >= 0;
            if (!ok) host_fail(HMDWARP_HOST_ERR_IO, "file:%s: %s", o->path, strerror(errno));
        }
        break;
    default: host_fail(HMDWARP_HOST_ERR_ARG, "options.transport: %d is not a hmdwarp_host_transport", (int)o->transport);
    }
    if (!ok) {
        free(l);
        return NULL;
    }
    return l;
}

bool host_link_has_messages(const host_link *l) { return l->kind != HMDWARP_HOST_TRANSPORT_FILE; }

int host_link_write(host_link *l, const void *buf, size_t len)
{
    const uint8_t *p = buf;
    if (l->kind == HMDWARP_HOST_TRANSPORT_USB) {
        while (len > 0) {
            int n = 0, chunk = len > USB_CHUNK ? USB_CHUNK : (int)len;
            int rc = libusb_bulk_transfer(l->dev, l->ep_out, (unsigned char *)p, chunk, &n, USB_WRITE_TIMEOUT_MS);
            if (rc == LIBUSB_ERROR_TIMEOUT && n > 0) rc = 0; /* progress: keep going */
            if (rc != 0)
                return host_fail(rc == LIBUSB_ERROR_NO_DEVICE || rc == LIBUSB_ERROR_IO || rc == LIBUSB_ERROR_PIPE ||
                                         rc == LIBUSB_ERROR_TIMEOUT
                                     ? HMDWARP_HOST_ERR_DISCONNECTED
                                     : HMDWARP_HOST_ERR_IO,
                                 "usb: bulk OUT after %zu bytes of the frame: %s", (size_t)(p - (const uint8_t *)buf),
                                 libusb_strerror(rc));
            p += n;
            len -= (size_t)n;
        }
        return HMDWARP_HOST_OK;
    }
    while (len > 0) {
        /* MSG_NOSIGNAL: a board that went away is an error code, not SIGPIPE in the caller's process. */
        ssize_t n = l->kind == HMDWARP_HOST_TRANSPORT_SOCKET ? send(l->fd, p, len, MSG_NOSIGNAL) : write(l->fd, p, len);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            int err = n < 0 ? errno : EPIPE;
            bool gone = l->kind == HMDWARP_HOST_TRANSPORT_SOCKET;
            return host_fail(gone ? HMDWARP_HOST_ERR_DISCONNECTED : HMDWARP_HOST_ERR_IO, "%s: write after %zu bytes "
                             "of the frame: %s", gone ? "socket" : "file", (size_t)(p - (const uint8_t *)buf),
                             strerror(err));
        }
        p += n;
        len -= (size_t)n;
    }
    return HMDWARP_HOST_OK;
}

int host_link_read(host_link *l, uint8_t *buf, size_t cap, int timeout_ms)
{
    if (l->kind == HMDWARP_HOST_TRANSPORT_USB) {
        int n = 0;
        int rc = libusb_bulk_transfer(l->dev, l->ep_in, buf, (int)cap, &n, (unsigned)timeout_ms);
        if (rc == LIBUSB_ERROR_TIMEOUT) return n;
        if (rc != 0)
            return host_fail(HMDWARP_HOST_ERR_DISCONNECTED, "usb: bulk IN: %s", libusb_strerror(rc));
        return n;
    }
    if (l->kind != HMDWARP_HOST_TRANSPORT_SOCKET) return 0;
    struct pollfd pfd = {.fd = l->fd, .events = POLLIN};
    int rc = poll(&pfd, 1, timeout_ms);
    if (rc == 0 || (rc < 0 && errno == EINTR)) return 0;
    ssize_t n = rc < 0 ? -1 : recv(l->fd, buf, cap, 0);
    if (n < 0 && (errno == EINTR || errno == EAGAIN)) return 0;
    if (n <= 0)
        return host_fail(HMDWARP_HOST_ERR_DISCONNECTED, "socket: %s", n == 0 ? "the board closed the connection"
                                                                            : strerror(errno));
    return (int)n;
}

void host_link_shutdown(host_link *l)
{
    if (l->kind == HMDWARP_HOST_TRANSPORT_SOCKET && l->fd >= 0) shutdown(l->fd, SHUT_RDWR);
}

void host_link_close(host_link *l)
{
    if (!l) return;
    if (l->kind == HMDWARP_HOST_TRANSPORT_USB) usb_release(l);
    if (l->own_fd && l->fd >= 0) close(l->fd);
    free(l);
}
