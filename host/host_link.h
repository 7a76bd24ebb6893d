/* SPDX-License-Identifier: MIT */
/* host_link: libhmdwarp-host's transports behind one seam: the board's USB gadget (libusb bulk OUT / IN), a Unix
 * socket hmdwarpd listens on, or a file; byte streams out, board messages in. */
#ifndef HOST_LINK_H
#define HOST_LINK_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "host/hmdwarp-host.h"

typedef struct host_link host_link;

/* Connects (retrying until wait_s has passed; never when *stop turns true). NULL with the reason through host_fail. */
host_link *host_link_open(const hmdwarp_host_options *o, double wait_s, const atomic_bool *stop);
/* Writes all of buf: 0, HMDWARP_HOST_ERR_DISCONNECTED (the board went away) or HMDWARP_HOST_ERR_IO. */
int host_link_write(host_link *l, const void *buf, size_t len);
/* Reads what the board sent into buf (USB: one transfer, one message; socket: whatever arrived): the byte count,
 * 0 on timeout, or HMDWARP_HOST_ERR_DISCONNECTED. Only the reader thread calls it. */
int host_link_read(host_link *l, uint8_t *buf, size_t cap, int timeout_ms);
/* Whether the board sends anything back (USB, socket) or not (file). */
bool host_link_has_messages(const host_link *l);
/* Makes blocked reads and writes return (socket: shutdown); the link must still be closed. */
void host_link_shutdown(host_link *l);
void host_link_close(host_link *l);

#endif
