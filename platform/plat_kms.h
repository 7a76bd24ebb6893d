/* SPDX-License-Identifier: MIT */
/* plat_kms: DRM/KMS output for both renderers: the connector/mode/CRTC choice, atomic (or legacy) page flips, one
 * event thread that reads the DRM fd, and the CPU path's display on dumb buffers. */
#ifndef PLAT_KMS_H
#define PLAT_KMS_H

#include <stdbool.h>
#include <stdint.h>
#include <xf86drmMode.h>

#include "platform/plat_display.h"

/* Where KMS output goes. Strings are copied. */
typedef struct {
    const char *device;    /* DRM card node, e.g. /dev/dri/card0 */
    const char *connector; /* "auto" (first connected) or a name like HDMI-A-1, DSI-1, eDP-1 */
    int mode_w, mode_h;    /* 0 = the connector's preferred mode */
    double mode_hz;        /* 0 = any refresh of that size */
    /* SCHED_FIFO priority of the compositor (0 = normal scheduling): the KMS threads are on the display path, so
     * the event thread runs one above it (it only stamps and re-arms, like an interrupt handler) and the CPU
     * display's copy-and-commit thread at it; a normal-priority thread starves behind a busy compositor. */
    int rt_priority;
} plat_kms_params;

/* What plat_kms_pick chose. */
typedef struct {
    uint32_t conn_id, crtc_id;
    int crtc_index; /* in drmModeGetResources' CRTC list: vblank requests and plane masks use it */
    drmModeModeInfo mode;
    char conn_name[32];
} plat_kms_choice;

/* Finds the connector (the named one, or the first connected for "auto"), its mode and a CRTC for it. False with
 * a message naming the device and listing its connectors in err. */
bool plat_kms_pick(int fd, const plat_kms_params *p, plat_kms_choice *out, char *err, int errlen);

/* ---- a KMS output: device, CRTC, flips, events ---- */

typedef struct plat_kms plat_kms;

/* Opens the device, picks connector/mode/CRTC, turns on atomic modesetting (with universal planes) when the
 * driver offers it, finds the CRTC's primary plane and starts the event thread. Nothing is shown before the
 * first plat_kms_commit(). NULL with a message in err ("no DRM device: /dev/dri/card0: No such file or
 * directory", "... no connected connector (connectors: ...)"). */
plat_kms *plat_kms_open(const plat_kms_params *p, char *err, int errlen);
/* Waits for a pending flip (briefly), stops the event thread, gives the saved CRTC back, closes the device. */
void plat_kms_close(plat_kms *k);

int plat_kms_fd(const plat_kms *k);
const char *plat_kms_device(const plat_kms *k); /* the card node (the one found for kms_device = auto) */
const plat_kms_choice *plat_kms_chosen(const plat_kms *k);
bool plat_kms_atomic(const plat_kms *k);
/* Whether the primary plane scans out `fourcc` (legacy drivers without plane lists: XRGB8888 only). */
bool plat_kms_plane_has_format(const plat_kms *k, uint32_t fourcc);
/* The format the owner scans out (named in the summary and --stats). */
void plat_kms_set_format(plat_kms *k, uint32_t fourcc);

/* Shows framebuffer fb: the first call sets the mode (atomic: a blocking ALLOW_MODESET commit with MODE_ID,
 * ACTIVE and the connector's CRTC_ID; legacy: drmModeSetCrtc), later ones queue a page flip at the next vblank
 * (atomic NONBLOCK | PAGE_FLIP_EVENT; legacy drmModePageFlip) whose completion the event thread reports. Never
 * waits. False when the commit failed: counted, and err names why (EBUSY, not DRM master, ...). */
bool plat_kms_commit(plat_kms *k, uint32_t fb, char *err, int errlen);
/* Whether a flip is queued and its completion event has not arrived yet. */
bool plat_kms_flip_pending(const plat_kms *k);
/* Flips completed so far (completion events, plus the modeset): what changes when the pending flip is done. */
uint64_t plat_kms_flips_completed(const plat_kms *k);
/* Waits up to timeout_ms for the event thread to report something (a flip completion, or plat_kms_kick). False on
 * timeout. For the one thread that commits. */
bool plat_kms_wait(plat_kms *k, int timeout_ms);
/* Wakes plat_kms_wait (never blocks: a semaphore post; callable on the vsync path). */
void plat_kms_kick(plat_kms *k);
/* Waits up to timeout_ms for the pending flip to complete; on timeout the flip is counted as failed and
 * forgotten, so the output keeps going. */
bool plat_kms_wait_flip(plat_kms *k, int timeout_ms);

/* Vblank times for a vsync source: from the first call on, the event thread requests an event for every vblank of
 * the CRTC (drmWaitVBlank, once the CRTC is lit) and queues their CLOCK_MONOTONIC times. Waits up to timeout_ms,
 * stores up to max times (oldest first); returns how many, 0 on timeout, or a negative errno with err. */
int plat_kms_wait_vblanks(plat_kms *k, int64_t *t_ns, int max, int timeout_ms, char *err, int errlen);
/* Stops requesting vblank events (the vsync source is gone). */
void plat_kms_stop_vblanks(plat_kms *k);

typedef struct {
    uint64_t flips;       /* commits that succeeded, the modeset included */
    uint64_t failed;      /* commits refused, and flips whose completion never came */
    uint64_t late;        /* flips completed more than one vblank after the previous one: a frame shown twice */
    uint64_t vblanks;     /* vblank times handed to the vsync source */
    const char *api;      /* "atomic" or "legacy" */
    const char *format;   /* "XBGR8888", "XRGB8888" */
    char connector[32];
    int w, h;
    double hz;
    char last_error[160];
} plat_kms_stats;
/* Safe from any thread (counters read racily, the error under a lock off the vsync path). */
void plat_kms_stats_get(plat_kms *k, plat_kms_stats *st);
/* "XRGB8888" for DRM_FORMAT_XRGB8888, ... */
const char *plat_kms_format_name(uint32_t fourcc);

/* ---- pure helpers (unit-tested) ---- */

/* Whether a flip that completed at vblank `seq` came late: more than one vblank after the previous flip's
 * (prev_valid false for the first one). Sequences are the kernel's 32-bit counters and may wrap. */
bool plat_kms_flip_is_late(bool prev_valid, uint32_t prev_seq, uint32_t seq);
/* Copies an RGBA8 image into an XRGB8888 buffer (little-endian words: bytes B, G, R, X) of `pitch` bytes per row:
 * the R/B swap drivers without XBGR8888 (vkms) need. */
void plat_kms_copy_to_xrgb(uint8_t *dst, int pitch, const warp_image_rgba8 *src);
/* Copies an RGBA8 image as it is into an XBGR8888 buffer (the same byte order). */
void plat_kms_copy_to_xbgr(uint8_t *dst, int pitch, const warp_image_rgba8 *src);

/* ---- the CPU path's display ---- */

/* Shows presented swapchain images on k through dumb buffers (DRM_IOCTL_MODE_CREATE_DUMB, MAP_DUMB, mmap,
 * drmModeAddFB2). XBGR8888 when the primary plane offers it: the swapchain's images then live in the mapped
 * buffers (sc's pixels are swapped in, and back at destroy) and are flipped to without a copy; else XRGB8888,
 * converted into buffers of the display's own by its thread. present() only hands the index to that thread
 * (held[] set until the image is no longer read). Takes ownership of k (closed on failure too). NULL with err. */
plat_display *plat_display_kms_create(plat_kms *k, plat_swapchain *sc, char *err, int errlen);

#endif
