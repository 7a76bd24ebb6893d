/* SPDX-License-Identifier: MIT */
/* drv_vsync_kms: vsync from the display controller itself: the DRM device's vblank times, fed to the same robust
 * estimator as TE-line edges (drv_vsync_edges_create), for boards without a TE line. */
#include "drivers/drv_vsync_kms.h"

#include <stdio.h>
#include <stdlib.h>

#include "warp/warp_err.h"

typedef struct {
    drv_edge_source base;
    plat_kms *k;
    char name[64];
} kms_edges;

static int kms_wait(drv_edge_source *s, int64_t *t_ns, int max, int timeout_ms, char *err, int errlen)
{
    return plat_kms_wait_vblanks(((kms_edges *)s)->k, t_ns, max, timeout_ms, err, errlen);
}

static void kms_close(drv_edge_source *s)
{
    kms_edges *e = (kms_edges *)s;
    plat_kms_stop_vblanks(e->k);
    free(e);
}

drv_edge_source *drv_kms_vblank_edges_open(plat_kms *k, char *err, int errlen)
{
    if (!k) {
        warp_err(err, errlen, "no KMS output to take vblanks from (needs [display] output = kms)");
        return NULL;
    }
    kms_edges *e = calloc(1, sizeof *e);
    if (!e) {
        warp_err(err, errlen, "out of memory");
        return NULL;
    }
    e->k = k;
    snprintf(e->name, sizeof e->name, "%.31s vblanks", plat_kms_chosen(k)->conn_name);
    e->base.name = e->name;
    e->base.wait = kms_wait;
    e->base.close = kms_close;
    return &e->base;
}

drv_vsync *drv_vsync_kms_create(plat_kms *k, double refresh_hz, char *err, int errlen)
{
    drv_edge_source *src = drv_kms_vblank_edges_open(k, err, errlen);
    if (!src) return NULL;
    drv_vsync *v = drv_vsync_edges_create(src, refresh_hz, "kms");
    if (!v) warp_err(err, errlen, "cannot start the vsync thread");
    return v;
}
