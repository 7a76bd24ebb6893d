/* SPDX-License-Identifier: MIT */
/* drv_link_budget: the link budget's arithmetic (bytes per pixel per plane and codec, times eyes and host rate,
 * against the link's rate) and its one-line report. See drv_link_budget.h and docs/link-budget.md. */
#include "drivers/drv_link_budget.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "drivers/drv_frames.h"

#define MB 1e6
#define SMALLEST_DEPTH_SCALE 2 /* framelink v2's depth scale byte: 0, 1 or 2 (1/4 a side) */

/* Bytes per eye pixel. Raw: framelink v1's formats (RGBA8, float depth, u16 ids, two float motion components, the
 * layers' u8 count with no fragments: the least). Coded, as `make bench`'s link section measured them on the
 * simulator's scenes at 1440x1600 (docs/bench/link.md, bytes/px): JPEG q75 4:2:0 (libhmdwarp-host's auto) 0.083,
 * H.264 and HEVC at quantiser 20 0.020 and 0.011 (frames between key frames), zstd over byte-shuffled INV16 depth
 * at full resolution (auto) 0.043; ids, motion and layers are estimates (ids and layers mostly runs, motion two
 * floats that vary smoothly). */
static const struct {
    unsigned plane;
    double raw, zstd;
} planes[] = {
    {DRV_PLANE_COLOR, 4, -1}, {DRV_PLANE_DEPTH, 4, 0.043}, {DRV_PLANE_IDS, 2, 0.05},
    {DRV_PLANE_MOTION, 8, 2.0}, {DRV_PLANE_LAYERS, 1, 0.1},
};
static const char *const plane_names[] = {"colour", "depth", "ids", "motion", "layers"};
static const double colour_coded[DRV_CODEC_COUNT] = {[DRV_CODEC_JPEG] = 0.083, [DRV_CODEC_H264] = 0.020,
                                                     [DRV_CODEC_HEVC] = 0.011};
static const drv_codec_id colour_codecs[DRV_LINK_BUDGET_COLOUR_CODECS] = {DRV_CODEC_JPEG, DRV_CODEC_H264,
                                                                          DRV_CODEC_HEVC};

double drv_link_budget_bytes_per_px(unsigned plane, drv_codec_id codec, int scale)
{
    if (scale < 0 || scale > SMALLEST_DEPTH_SCALE || (scale && plane != DRV_PLANE_DEPTH)) return -1;
    for (size_t i = 0; i < sizeof planes / sizeof planes[0]; i++) {
        if (planes[i].plane != plane) continue;
        double b = codec == DRV_CODEC_RAW    ? planes[i].raw
                   : codec == DRV_CODEC_ZSTD ? planes[i].zstd
                   : plane == DRV_PLANE_COLOR && (unsigned)codec < DRV_CODEC_COUNT && colour_coded[codec] > 0
                       ? colour_coded[codec]
                       : -1;
        return b < 0 ? -1 : b / (double)(1 << (2 * scale)); /* 1/2^scale a side: 1/4^scale of the pixels */
    }
    return -1;
}

static double link_rate(const drv_link_budget_in *in)
{
    if (in->kind != DRV_LINK_USB) return in->link_mbps > 0 ? in->link_mbps : 0;
    return drv_usb_speed_mbps(in->usb_speed != DRV_USB_SPEED_UNKNOWN ? in->usb_speed : DRV_USB_SPEED_HIGH);
}

void drv_link_budget_compute(const drv_link_budget_in *in, drv_link_budget *out)
{
    memset(out, 0, sizeof *out);
    const double px_s = 2.0 * in->eye_w * in->eye_h * in->host_hz; /* eye pixels a second, both eyes */
    out->link_mbps = link_rate(in);
    /* v4l2 carries pixels, not framelink: no codecs there; a v1 board (RAW alone) has neither codecs nor scale */
    const bool v2 = in->kind != DRV_LINK_V4L2 && (in->codecs & ~DRV_CODEC_BIT(DRV_CODEC_RAW)) != 0;
    const bool zstd = v2 && (in->codecs & DRV_CODEC_BIT(DRV_CODEC_ZSTD));
    double raw = 0, rest = 0; /* rest: the planes other than colour, coded */
    for (size_t i = 0; i < sizeof planes / sizeof planes[0]; i++) {
        unsigned p = planes[i].plane;
        if (!(in->planes & p)) continue;
        raw += planes[i].raw;
        if (p != DRV_PLANE_COLOR)
            rest += drv_link_budget_bytes_per_px(p, zstd ? DRV_CODEC_ZSTD : DRV_CODEC_RAW,
                                                 0); /* depth at full resolution, as auto sends it */
    }
    out->raw_mbps = raw * px_s / MB;
    out->raw_fits = out->link_mbps <= 0 || out->raw_mbps <= out->link_mbps;
    if (!v2) return;
    const double colour = in->planes & DRV_PLANE_COLOR ? 1 : 0;
    for (int k = 0; k < DRV_LINK_BUDGET_COLOUR_CODECS; k++)
        if (in->codecs & DRV_CODEC_BIT(colour_codecs[k])) out->colour[out->n_coded++] = colour_codecs[k];
    if (out->n_coded == 0) out->colour[out->n_coded++] = DRV_CODEC_RAW; /* zstd alone: colour stays raw */
    for (int k = 0; k < out->n_coded; k++) {
        double bpp = colour * drv_link_budget_bytes_per_px(DRV_PLANE_COLOR, out->colour[k], 0) + rest;
        out->coded_mbps[k] = bpp * px_s / MB;
        if (out->link_mbps <= 0 || out->coded_mbps[k] <= out->link_mbps) out->coded_fits = true;
    }
}

/* "1.66 GB/s", "155 MB/s", "3.5 MB/s" */
static void rate_str(double mbps, char *buf, size_t len)
{
    if (mbps >= 1000) snprintf(buf, len, "%.2f GB/s", mbps / 1000);
    else if (mbps >= 10) snprintf(buf, len, "%.0f MB/s", mbps);
    else snprintf(buf, len, "%.1f MB/s", mbps);
}

/* Appends to buf (always terminated). */
static void add(char *buf, size_t len, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void add(char *buf, size_t len, const char *fmt, ...)
{
    size_t n = strlen(buf);
    if (n + 1 >= len) return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf + n, len - n, fmt, ap);
    va_end(ap);
}

bool drv_link_budget_line(const drv_link_budget_in *in, char *buf, size_t len)
{
    drv_link_budget b;
    drv_link_budget_compute(in, &b);
    char r[32];
    if (!len) return b.raw_fits || b.coded_fits;
    buf[0] = 0;
    rate_str(b.link_mbps, r, sizeof r);
    switch (in->kind) {
    case DRV_LINK_USB:
        if (in->usb_speed == DRV_USB_SPEED_UNKNOWN)
            add(buf, len, "link: usb, speed not known (no UDC found): high-speed ~%s assumed", r);
        else
            add(buf, len, "link: usb %s%s ~%s", in->usb_negotiated ? "" : "up to ", drv_usb_speed_name(in->usb_speed),
                r);
        if (in->udc && in->udc[0])
            add(buf, len, " (%s%s)", in->udc, in->usb_negotiated ? "" : ", until a host connects");
        break;
    case DRV_LINK_MOCK:
    case DRV_LINK_SOCKET:
        add(buf, len, "link: %s", in->kind == DRV_LINK_MOCK ? "usb mock" : "socket");
        if (b.link_mbps > 0) add(buf, len, " limited to %s ([frames] link_mbps)", r);
        else add(buf, len, ", unlimited");
        break;
    case DRV_LINK_V4L2:
        add(buf, len, "link: v4l2 capture, raw pixels in-band");
        if (b.link_mbps > 0) add(buf, len, ", its mode ~%s", r);
        else add(buf, len, " (its mode decides: docs/v4l2-inband.md)");
        break;
    }
    add(buf, len, "; ");
    int n = 0;
    for (size_t i = 0; i < sizeof planes / sizeof planes[0]; i++)
        if (in->planes & planes[i].plane) add(buf, len, "%s%s", n++ ? "+" : "", plane_names[i]);
    rate_str(b.raw_mbps, r, sizeof r);
    add(buf, len, " %dx%dx2 @%g Hz: raw needs %s", in->eye_w, in->eye_h, in->host_hz, r);
    if (b.link_mbps > 0) add(buf, len, ", %s", b.raw_fits ? "fits" : "does not fit");
    if (b.n_coded > 0) {
        const bool zstd = (in->codecs & DRV_CODEC_BIT(DRV_CODEC_ZSTD)) != 0;
        add(buf, len, "; coded (%s):", zstd ? "depth and other planes zstd" : "other planes raw");
        for (int k = 0; k < b.n_coded; k++) {
            rate_str(b.coded_mbps[k], r, sizeof r);
            add(buf, len, "%s %s ~%s%s", k ? "," : "", drv_codec_name(b.colour[k]), r,
                b.link_mbps <= 0 ? "" : b.coded_mbps[k] <= b.link_mbps ? " fits" : " does not fit");
        }
    } else if (in->kind != DRV_LINK_V4L2) {
        add(buf, len, "; the board announces raw only");
    }
    const bool fits = b.raw_fits || b.coded_fits;
    if (!fits) add(buf, len, " - nothing announced fits: a smaller [eye], a slower host or a faster link");
    return fits;
}
