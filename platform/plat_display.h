/* SPDX-License-Identifier: MIT */
/* plat_display: where composited panel images go: a swapchain of panel-sized buffers and display sinks (null,
 * PNG snapshots, raw stream; KMS on a board). Presenting never blocks and never does I/O on the vsync path. */
#ifndef PLAT_DISPLAY_H
#define PLAT_DISPLAY_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#include "warp/warp_image.h"

#define PLAT_SWAPCHAIN_MAX 4

typedef struct {
    int count;
    warp_image_rgba8 img[PLAT_SWAPCHAIN_MAX];
    /* Set by a display that keeps reading an image after present() returned (a file writer, a pending page
     * flip); cleared by it when done. The compositor never draws into a held image. */
    _Atomic int held[PLAT_SWAPCHAIN_MAX];
    int on_screen; /* index presented last, shown from its vsync on; -1 before the first present */
    /* The image presented before it, still shown until on_screen's vsync: a compositor that starts a pass more
     * than a period ahead (plat_swapchain_presented) must not draw into it yet. */
    int prev;
    int64_t prev_until_ns;
} plat_swapchain;

bool plat_swapchain_alloc(plat_swapchain *sc, int count, int w, int h);
/* An image that is neither on screen, nor still shown at now_ns, nor held, or -1 when every image is busy (the
 * compositor then skips). */
int plat_swapchain_next(plat_swapchain *sc, int64_t now_ns);
/* Records that image `index` was presented for the vsync at vsync_ns. */
void plat_swapchain_presented(plat_swapchain *sc, int index, int64_t vsync_ns);
void plat_swapchain_free(plat_swapchain *sc);

typedef struct plat_display plat_display;
struct plat_display {
    const char *name;
    /* Queues image `index` for the vsync at vsync_ns. Called on the vsync path: must not block or do I/O. */
    void (*present)(plat_display *d, plat_swapchain *sc, int index, int64_t vsync_ns, uint64_t vsync_no);
    /* Waits until images handed over so far are written (not on the vsync path; NULL = nothing pending). */
    void (*flush)(plat_display *d);
    /* One line for the run summary (what was written where, what was skipped). */
    void (*describe)(plat_display *d, char *buf, int len);
    /* Waits for pending writes, then frees. */
    void (*destroy)(plat_display *d);
};

static inline void plat_display_present(plat_display *d, plat_swapchain *sc, int index, int64_t vsync_ns,
                                        uint64_t vsync_no)
{
    d->present(d, sc, index, vsync_ns, vsync_no);
}
static inline void plat_display_flush(plat_display *d)
{
    if (d && d->flush) d->flush(d);
}
static inline void plat_display_destroy(plat_display *d)
{
    if (d) d->destroy(d);
}

/* Discards frames (the default on the simulated board: the summary reports what would have been shown). */
plat_display *plat_display_null_create(void);
/* Writes every `every`-th presented image from a writer thread into dir: kind "png" -> dir/frame_NNNNNN.png,
 * kind "raw" -> one growing dir/frames.rgba stream (RGBA8, size printed in the summary). A snapshot due while the
 * writer is still busy is skipped and counted, never waited for. NULL with a message in err on failure. */
plat_display *plat_display_files_create(const char *kind, const char *dir, int every, char *err, int errlen);

#endif
