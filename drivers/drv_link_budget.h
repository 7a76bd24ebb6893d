/* SPDX-License-Identifier: MIT */
/* drv_link_budget: what a board's eye size, planes and host rate need on its link, raw and with the codecs it
 * announces, against what that link carries (USB speed, socket/mock limit, V4L2 mode): the one start-up line. */
#ifndef DRV_LINK_BUDGET_H
#define DRV_LINK_BUDGET_H

#include <stdbool.h>
#include <stddef.h>

#include "drivers/drv_codec.h"
#include "drivers/drv_usb_speed.h"

typedef enum {
    DRV_LINK_USB,    /* FunctionFS gadget: usb_speed */
    DRV_LINK_MOCK,   /* the mock USB link: link_mbps */
    DRV_LINK_SOCKET, /* a Unix socket: link_mbps */
    DRV_LINK_V4L2,   /* HDMI/CSI capture: raw pixels in-band; link_mbps = the capture mode's bytes a second, if known */
} drv_link_kind;

typedef struct {
    drv_link_kind kind;
    drv_usb_speed usb_speed;  /* usb: UNKNOWN assumes high speed (the common device port, the Pi 5's) */
    bool usb_negotiated;      /* usb: usb_speed is the host's; false: the UDC's maximum (no host yet) */
    const char *udc;          /* usb: the controller's name for the line, or NULL */
    double link_mbps;         /* mock, socket: [frames] link_mbps (0 = unlimited); v4l2: mode MB/s (0 = unknown) */
    int eye_w, eye_h;
    unsigned planes;          /* DRV_PLANE_* the board takes from the host */
    double host_hz;           /* host frames a second the budget is for */
    unsigned codecs;          /* DRV_CODEC_BIT()s the board announces; RAW alone = a v1 board */
} drv_link_budget_in;

/* The colour codecs a row is computed for, in this order. */
#define DRV_LINK_BUDGET_COLOUR_CODECS 3

typedef struct {
    double link_mbps;          /* what the link carries, MB/s (10^6 B/s); 0 = unlimited or unknown */
    double raw_mbps;           /* every plane raw, as framelink v1 sends it */
    /* per announced colour codec (JPEG, H.264, HEVC; RAW when none is announced): colour with it, the other planes
     * zstd when announced, depth INV16 at full resolution (what libhmdwarp-host's auto sends) */
    int n_coded;
    drv_codec_id colour[DRV_LINK_BUDGET_COLOUR_CODECS];
    double coded_mbps[DRV_LINK_BUDGET_COLOUR_CODECS];
    bool raw_fits, coded_fits; /* coded_fits: at least one coded row fits */
} drv_link_budget;

/* Estimated bytes per eye pixel of a plane (DRV_PLANE_*) sent with codec (RAW or ZSTD for every plane, JPEG, H264 or
 * HEVC for colour) at the scale given (depth: 1/2^scale a side); -1 for a pair that does not exist. Estimates until
 * `make bench` measures them (docs/link-budget.md says where each comes from). */
double drv_link_budget_bytes_per_px(unsigned plane, drv_codec_id codec, int scale);

void drv_link_budget_compute(const drv_link_budget_in *in, drv_link_budget *out);

/* The start-up line, e.g. "link: usb high-speed ~40 MB/s; colour+depth 1440x1600x2 @45 Hz: raw needs 1.66 GB/s,
 * does not fit; coded (depth and other planes zstd): jpeg ~26 MB/s fits, hevc ~5.6 MB/s fits". Returns false
 * when nothing the board announces fits (log it as a warning); true also when the link's rate is not known. */
bool drv_link_budget_line(const drv_link_budget_in *in, char *buf, size_t len);

#endif
