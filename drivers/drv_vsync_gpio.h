/* SPDX-License-Identifier: MIT */
/* drv_vsync_gpio: vsync sources for the real board: the panel's TE line on a GPIO (edges through libgpiod, a robust
 * estimator, a timer fallback when the edges stop). The free-running timer: drv_vsync_timer.h; the libgpiod 1.6 edge
 * source: drv_gpiod1.h; the mock: drv_vsync_gpio_mock.h. */
#ifndef DRV_VSYNC_GPIO_H
#define DRV_VSYNC_GPIO_H

#include <stdbool.h>
#include <stdint.h>

#include "drivers/drv_vsync.h"

/* ---- vsync backends ---- */

typedef struct {
    char chip[64];     /* "gpiochip0", "0" or "/dev/gpiochip0" (also a chip label) */
    int line;          /* line offset on that chip */
    double refresh_hz; /* nominal panel rate: the estimator starts from it and locks only within +-10 % */
    bool falling_edge; /* TE active low: vsync at the falling edge */
} drv_vsync_gpio_params;

/* Opens the TE line and starts the edge thread. NULL with a message in err (no such chip, no such line, line busy
 * and by whom, permission) when it cannot. */
drv_vsync *drv_vsync_gpio_create(const drv_vsync_gpio_params *p, char *err, int errlen);

/* ---- edge sources (what the GPIO backend reads; libgpiod v1 in drv_gpiod1.c, a v2 one may sit beside it) ---- */

typedef struct drv_edge_source drv_edge_source;
struct drv_edge_source {
    const char *name; /* for messages: "gpiochip0 line 17" */
    /* Waits up to timeout_ms for edges; stores up to max CLOCK_MONOTONIC edge times (oldest first). Returns how
     * many, 0 on timeout, or a negative errno (err, if not NULL, gets a message naming the line). */
    int (*wait)(drv_edge_source *s, int64_t *t_ns, int max, int timeout_ms, char *err, int errlen);
    void (*close)(drv_edge_source *s);
};

/* The GPIO vsync backend on any edge source (takes ownership of src, closing it on failure too). */
drv_vsync *drv_vsync_edges_create(drv_edge_source *src, double refresh_hz, const char *name);

/* Extra counters of an edge-driven backend, beyond drv_vsync_stats. */
typedef struct {
    uint64_t locks;        /* estimator locks: the first and each relock after a phase jump */
    uint64_t read_errors;  /* wait() errors */
    uint64_t bad_stamps;   /* edge times implausibly far from now (wrong clock), dropped */
    bool locked;
} drv_vsync_edges_stats;
/* v must come from drv_vsync_edges_create / _gpio_create / _gpio_create_mock. Safe from any thread. */
void drv_vsync_edges_stats_get(drv_vsync *v, drv_vsync_stats *st, drv_vsync_edges_stats *ex);

#endif
