/* SPDX-License-Identifier: MIT */
/* drv_vsync_kms: vsync from the display controller itself: the DRM device's vblank times, fed to the same robust
 * estimator as TE-line edges (drv_vsync_edges_create), for boards without a TE line. */
#ifndef DRV_VSYNC_KMS_H
#define DRV_VSYNC_KMS_H

#include "drivers/drv_vsync_gpio.h"
#include "platform/plat_kms.h"

/* An edge source whose edges are k's vblank times (plat_kms_wait_vblanks: the KMS event thread reads the events;
 * this source only takes their times). k is borrowed: it must outlive the source. */
drv_edge_source *drv_kms_vblank_edges_open(plat_kms *k, char *err, int errlen);

/* The vsync backend `kms`: k's vblanks through the edge estimator (timer fallback until the CRTC is lit). */
drv_vsync *drv_vsync_kms_create(plat_kms *k, double refresh_hz, char *err, int errlen);

#endif
