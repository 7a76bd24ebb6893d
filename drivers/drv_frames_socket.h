/* SPDX-License-Identifier: MIT */
/* drv_frames_socket: host frames over a Unix-domain stream socket, so a PC runs the board with frames from any local
 * process: the USB backend's board side (drv_frames_usb.h) on a socket transport, the same bytes both ways. */
#ifndef DRV_FRAMES_SOCKET_H
#define DRV_FRAMES_SOCKET_H

#include "drivers/drv_frames_usb.h"

/* Where hmdwarpd listens when [frames] device is empty (the systemd unit's RuntimeDirectory). */
#define DRV_FRAMES_SOCKET_DEFAULT "/run/hmdwarp/frames.sock"
/* The longest path a Unix socket address holds (sun_path less its NUL). */
#define DRV_FRAMES_SOCKET_PATH_MAX 107

/* Listens at `path` (NULL or "": DRV_FRAMES_SOCKET_DEFAULT) for one host at a time: host -> board carries the
 * framelink stream of bulk OUT, board -> host the messages of bulk IN (camera "HWC1" on connecting and once a
 * second, poses "HWP1"), whole and back to back. A socket file left at path by a process that is gone is replaced;
 * any other file there, or a live listener, is an error. The parent directory is made when it alone is missing
 * (/run/hmdwarp without the systemd unit); the socket's permissions follow the umask. A second host is refused
 * (closed, logged, counted); a host going away is a disconnect (counted) and the next may connect. p->ffs_dir is
 * unused; drv_frames_usb_stats_get reads the statistics. NULL with a message in err naming path on failure. */
drv_frames *drv_frames_socket_create(const drv_frames_usb_params *p, const char *path, char *err, int errlen);

#endif
