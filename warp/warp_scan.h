/* SPDX-License-Identifier: MIT */
/* warp_scan: when each panel pixel lights on a rolling-scan panel (which line first, how long the scan takes), and
 * the pose between the scan's first- and last-line predictions for any panel position (ILLIXR's start/end poses). */
#ifndef WARP_SCAN_H
#define WARP_SCAN_H

#include <stdbool.h>

#include "warp/warp_math.h"

typedef enum {
    WARP_SCAN_TOP_TO_BOTTOM,
    WARP_SCAN_BOTTOM_TO_TOP,
    WARP_SCAN_LEFT_TO_RIGHT, /* a portrait phone panel mounted sideways scans across the eyes */
    WARP_SCAN_RIGHT_TO_LEFT,
} warp_scan_dir;

/* How a panel lights its pixels. On a global panel (rolling false) every pixel lights at the mid-scan photon time
 * (hmdwarpd's [display] photon_offset_ms after the vsync edge); on a rolling panel the line at scan fraction f
 * (0 = the first line lit, 1 = the last) lights at mid-scan + (f - 1/2) * scan_s, so the mid-scan time is the one
 * global prediction already targets and a still head sees the same image either way. */
typedef struct {
    bool rolling;
    warp_scan_dir dir;
    double scan_s;          /* first line lit to last line lit, seconds */
    int panel_w, panel_h;   /* the panel, pixels (both eyes side by side) */
} warp_scan;

/* Scan fraction of the continuous panel position (x, y) (pixel centres at +0.5): the line through the first
 * pixel centre is 0, through the last 1, clamped in between; 0.5 everywhere on a global panel. */
double warp_scan_fraction(const warp_scan *s, double x, double y);
/* Seconds from the mid-scan photon time to when scan fraction f lights (0 on a global panel). */
double warp_scan_offset_s(const warp_scan *s, double f);
/* The orientation at scan fraction f between the first line's (f = 0) and the last line's (f = 1) predictions:
 * their slerp, exactly `first` at f <= 0 or when both are equal and exactly `last` at f >= 1. */
warp_quat warp_scan_slerp(warp_quat first, warp_quat last, double f);
/* The band of panel lines [0, bands) that scan fraction f falls in, and the fraction at band b's centre: what a
 * per-band ground truth renders (bands of equal scan time). */
int warp_scan_band(double f, int bands);
double warp_scan_band_fraction(int b, int bands);
/* NULL when s is usable, else what is wrong (a scan longer than period_s, the refresh, cannot be: the next
 * frame's scan would start before this one's ended). */
const char *warp_scan_check(const warp_scan *s, double period_s);

#endif
