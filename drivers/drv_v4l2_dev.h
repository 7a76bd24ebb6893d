/* SPDX-License-Identifier: MIT */
/* drv_v4l2_dev: the V4L2 node operations the board's capture and the host tool's output writer share: a struct of
 * device operations (the real ones, or a mock's), format choice and setting, MMAP buffers and queueing. */
#ifndef DRV_V4L2_DEV_H
#define DRV_V4L2_DEV_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

#include "drivers/drv_v4l2_convert.h"

/* The lowest layer, what the backend does to a V4L2 node: every function gets the ctx given below. */
typedef struct {
    int (*open)(void *ctx, const char *path, int flags);
    int (*close)(void *ctx, int fd);
    int (*ioctl)(void *ctx, int fd, unsigned long req, void *arg); /* 0, or -1 with errno */
    void *(*mmap)(void *ctx, size_t len, int fd, off_t off);         /* MAP_FAILED with errno on failure */
    int (*munmap)(void *ctx, void *p, size_t len);
    int (*poll)(void *ctx, int fd, short events, int timeout_ms, short *revents); /* as poll(2) for one fd */
    void (*destroy)(void *ctx); /* optional: frees ctx with the source */
} drv_v4l2_dev_ops;

#define DRV_V4L2_NBUF 4 /* buffers the capture requests */

/* open(2), close(2), ioctl(2) (EINTR retried), mmap(2) shared read/write, munmap(2), poll(2). */
extern const drv_v4l2_dev_ops drv_v4l2_real_ops;

/* Format parameter (auto|yuyv|nv12|bgr32|rgb24) -> fourcc (0 = auto); false for an unknown name. */
bool drv_v4l2_parse_format(const char *s, uint32_t *f);
/* Picks the pixel format: want (0 = auto) among what ENUM_FMT lists for buffer type `type` (YUV first, then RGB);
 * BGR32 and XBGR32 satisfy each other. The list offered goes into `offered`. Returns 0 when nothing fits. */
uint32_t drv_v4l2_choose_format(const drv_v4l2_dev_ops *ops, void *ctx, int fd, uint32_t type, uint32_t want,
                                char *offered, int offeredlen);
/* S_FMT for w x h in `fourcc` (BT.601 limited range asked for); checks what the driver made of it: the same format,
 * progressive, at least w x h. Fills the geometry and the Y'CbCr encoding reported. False with a message naming
 * `dev` in err; g is filled (g->width > 0) when the mode is only too small. */
bool drv_v4l2_set_format(const drv_v4l2_dev_ops *ops, void *ctx, int fd, const char *dev, uint32_t type,
                         uint32_t fourcc, int w, int h, drv_v4l2_geom *g, drv_v4l2_colorspace *cs, char *err,
                         int errlen);

typedef struct {
    void *p;
    size_t len;
} drv_v4l2_mapped;

/* REQBUFS + QUERYBUF + mmap of DRV_V4L2_NBUF buffers of at least `need` bytes into b. Returns how many were mapped
 * (0 on failure, err set). */
int drv_v4l2_map_buffers(const drv_v4l2_dev_ops *ops, void *ctx, int fd, const char *dev, uint32_t type, size_t need,
                         drv_v4l2_mapped *b, char *err, int errlen);
void drv_v4l2_unmap_buffers(const drv_v4l2_dev_ops *ops, void *ctx, drv_v4l2_mapped *b, int n);
/* QBUF of MMAP buffer `index` with bytesused; 0, or -1 with errno. */
int drv_v4l2_queue_buffer(const drv_v4l2_dev_ops *ops, void *ctx, int fd, uint32_t type, int index,
                          uint32_t bytesused);

#endif
