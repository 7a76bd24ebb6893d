/* SPDX-License-Identifier: MIT */
/* warp_lens_models: builds a warp_lens from the parameters each published lens format uses (OpenHMD's Panotools,
 * Monado's Vive/Index, Cardboard viewer profiles, OpenCV camera calibrations), in their own units. */
#include "warp/warp_lens_models.h"

#include <math.h>
#include <string.h>

#include "warp/warp_err.h"

/* center_x/y and scale keep the green channel's values: the generic fields code reads (a lens's centre). */
static warp_lens finish(warp_lens l)
{
    l.center_x = l.m[1].cx;
    l.center_y = l.m[1].cy;
    for (int c = 0; c < 3; c++) l.ch[c].k[0] = 1; /* the poly fields stay a harmless identity */
    warp_lens_prepare(&l);
    return l;
}

warp_lens warp_lens_panotools(const warp_lens_panotools_params *p)
{
    warp_lens l = {.model = WARP_LENS_PANOTOOLS};
    l.scale = l.scale_y = p->scale;
    for (int c = 0; c < 3; c++) {
        memcpy(l.m[c].k, p->abcd[c], sizeof l.m[c].k);
        l.m[c].cx = p->center_x;
        l.m[c].cy = p->center_y;
        l.m[c].tsx = l.m[c].tsy = p->aberration[c] * p->tan_scale;
    }
    return finish(l);
}

bool warp_lens_openhmd_params(const warp_lens_openhmd_device *d, warp_lens_panotools_params *out, char *err,
                              int errlen)
{
    const double pos[5] = {d->hsize, d->vsize, d->lens_sep, d->eye_to_screen, d->lens_vpos};
    const char *const name[5] = {"screen width", "screen height", "lens separation", "eye to screen distance",
                                 "lens vertical position"};
    for (int i = 0; i < 5; i++)
        if (!isfinite(pos[i]) || !(pos[i] > 0) || pos[i] > 10) {
            warp_err(err, errlen, "OpenHMD %s %g m: must be positive and under 10 m", name[i], pos[i]);
            return false;
        }
    if (d->hres < 2 || d->vres < 1 || d->hres % 2) {
        warp_err(err, errlen, "OpenHMD resolution %dx%d: the whole panel, an even width", d->hres, d->vres);
        return false;
    }
    for (int i = 0; i < 4; i++)
        if (!isfinite(d->k[i])) {
            warp_err(err, errlen, "OpenHMD distortion coefficient %c = %g: not finite", 'a' + i, d->k[i]);
            return false;
        }
    for (int c = 0; c < 3; c++)
        if (!isfinite(d->aberration[c]) || !(d->aberration[c] > 0)) {
            warp_err(err, errlen, "OpenHMD aberration %g: must be positive", d->aberration[c]);
            return false;
        }
    double vw_m = d->hsize / 2, px_per_m = d->hres / d->hsize; /* square pixels: OpenHMD's r is in metres */
    double lc_x = vw_m - d->lens_sep / 2;                       /* left eye: the lens sits towards the nose */
    double warp_scale = fmax(lc_x, d->lens_sep / 2);
    for (int c = 0; c < 3; c++) {
        memcpy(out->abcd[c], d->k, sizeof out->abcd[c]);
        out->aberration[c] = d->aberration[c];
    }
    out->center_x = lc_x * px_per_m;
    out->center_y = d->vres - d->lens_vpos * (d->vres / d->vsize); /* OpenHMD's y is up from the bottom edge */
    out->scale = warp_scale * px_per_m;
    out->tan_scale = warp_scale / d->eye_to_screen;
    return true;
}

warp_lens warp_lens_vive(const warp_lens_vive_params *p, int vw, int vh)
{
    warp_lens l = {.model = WARP_LENS_VIVE};
    double a = p->aspect_x_over_y, ifx = p->intrinsics[0], icx = p->intrinsics[1], ify = p->intrinsics[2],
           icy = p->intrinsics[3];
    /* X = (x - cx) / scale with scale = vw / 2; Y (down) = (y - cy) / scale_y with scale_y = vh a / 2 */
    l.scale = vw / 2.0;
    l.scale_y = vh * a / 2.0;
    l.rcut = p->r2_cutoff > 0 ? sqrt(p->r2_cutoff) : 0;
    for (int c = 0; c < 3; c++) {
        memcpy(l.m[c].k, p->k[c], sizeof l.m[c].k);
        l.m[c].cx = vw / 2.0 * (1 + p->center[c][0]);
        l.m[c].cy = vh / 2.0 * (1 + a * p->center[c][1]);
        l.m[c].tsx = 1 / ifx;
        l.m[c].tbx = (p->center[c][0] + icx) / ifx;
        l.m[c].tsy = a / ify; /* q.y is up (-Y): tangent up = (icy - a cy_c + a q.y d) / ify */
        l.m[c].tby = (icy - a * p->center[c][1]) / ify;
    }
    return finish(l);
}

warp_lens warp_lens_cardboard(const warp_lens_cardboard_params *p, int vw, int vh)
{
    warp_lens l = {.model = WARP_LENS_CARDBOARD};
    double ppm_x = 2.0 * vw / p->screen_w, ppm_y = vh / p->screen_h;
    double bottom = p->alignment == 0   ? p->tray_to_lens - 0.003 /* kDefaultBorderSizeMeters */
                    : p->alignment == 2 ? p->screen_h - p->tray_to_lens - 0.003
                                        : p->screen_h / 2;
    l.scale = p->screen_to_lens * ppm_x;
    l.scale_y = p->screen_to_lens * ppm_y;
    for (int c = 0; c < 3; c++) {
        memcpy(l.m[c].k, p->k, sizeof l.m[c].k);
        l.m[c].cx = (p->screen_w - p->inter_lens) / 2 * ppm_x;
        l.m[c].cy = vh - bottom * ppm_y;
        l.m[c].tsx = l.m[c].tsy = 1;
    }
    return finish(l);
}

warp_lens warp_lens_opencv(const warp_lens_opencv_params *p)
{
    warp_lens l = {.model = WARP_LENS_OPENCV};
    l.scale = p->fx;
    l.scale_y = p->fy;
    l.p1 = p->p1;
    l.p2 = p->p2;
    for (int c = 0; c < 3; c++) {
        l.m[c].k[0] = p->k1;
        l.m[c].k[1] = p->k2;
        l.m[c].k[2] = p->k3;
        l.m[c].cx = p->cx;
        l.m[c].cy = p->cy;
        l.m[c].tsx = l.m[c].tsy = 1;
    }
    return finish(l);
}

void warp_lens_mirror(warp_lens *l, double vw)
{
    l->center_x = vw - l->center_x;
    if (l->model == WARP_LENS_POLY) return;
    for (int c = 0; c < 3; c++) {
        l->m[c].cx = vw - l->m[c].cx;
        l->m[c].tbx = -l->m[c].tbx; /* a mirrored pixel sees the mirrored direction */
    }
    l->p2 = -l->p2; /* opencv: p2's term in x'' is even in x', p1's odd */
}
