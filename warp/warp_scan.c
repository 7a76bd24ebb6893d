/* SPDX-License-Identifier: MIT */
/* warp_scan: when each panel pixel lights on a rolling-scan panel (which line first, how long the scan takes), and
 * the pose between the scan's first- and last-line predictions for any panel position (ILLIXR's start/end poses). */
#include "warp/warp_scan.h"

#include <math.h>
#include <stddef.h>

static double clamp01(double f) { return f > 0 ? (f < 1 ? f : 1) : 0; }

/* Position along the scan axis of n lines: line k's centre (k + 0.5) is fraction k / (n - 1). */
static double along(double pos, int n) { return n > 1 ? clamp01((pos - 0.5) / (n - 1)) : 0.5; }

double warp_scan_fraction(const warp_scan *s, double x, double y)
{
    if (!s->rolling) return 0.5;
    switch (s->dir) {
    case WARP_SCAN_TOP_TO_BOTTOM: return along(y, s->panel_h);
    case WARP_SCAN_BOTTOM_TO_TOP: return 1.0 - along(y, s->panel_h);
    case WARP_SCAN_LEFT_TO_RIGHT: return along(x, s->panel_w);
    case WARP_SCAN_RIGHT_TO_LEFT: return 1.0 - along(x, s->panel_w);
    }
    return 0.5;
}

double warp_scan_offset_s(const warp_scan *s, double f) { return s->rolling ? (f - 0.5) * s->scan_s : 0.0; }

static bool quat_same(warp_quat a, warp_quat b) { return a.w == b.w && a.x == b.x && a.y == b.y && a.z == b.z; }

warp_quat warp_scan_slerp(warp_quat first, warp_quat last, double f)
{
    /* exact endpoints: a still head on a rolling panel must warp bit for bit as on a global one, and slerp's
     * renormalisation would move the last bits */
    if (f <= 0 || quat_same(first, last)) return first;
    if (f >= 1) return last;
    return warp_quat_slerp(first, last, f);
}

int warp_scan_band(double f, int bands)
{
    int b = (int)floor(clamp01(f) * bands);
    return b < bands ? b : bands - 1;
}

double warp_scan_band_fraction(int b, int bands) { return (b + 0.5) / bands; }

const char *warp_scan_check(const warp_scan *s, double period_s)
{
    if (!s->rolling) return NULL;
    if (s->dir < WARP_SCAN_TOP_TO_BOTTOM || s->dir > WARP_SCAN_RIGHT_TO_LEFT) return "unknown scan direction";
    if (!(s->scan_s >= 0) || !isfinite(s->scan_s)) return "scan duration must be a finite time of at least 0";
    if (s->scan_s > period_s * (1 + 1e-9)) return "scan duration longer than the refresh period";
    if (s->panel_w < 1 || s->panel_h < 1) return "panel size must be positive";
    return NULL;
}
