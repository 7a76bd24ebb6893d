/* SPDX-License-Identifier: MIT */
/* drv_token_bucket: a byte-rate limit (token bucket) on an injected clock, so the mock USB link and the socket link
 * carry no more than a real link would ([frames] link_mbps); pure arithmetic, no clock or sleep of its own. */
#ifndef DRV_TOKEN_BUCKET_H
#define DRV_TOKEN_BUCKET_H

#include <stddef.h>
#include <stdint.h>

/* Tokens are bytes; they accrue at rate_bps up to burst. A take may overdraw the bucket: the debt is paid back by
 * waiting, so a link read in large pieces still averages the rate exactly. */
typedef struct {
    double rate_bps; /* bytes per second; > 0 */
    double burst;    /* bytes the bucket holds when the link was idle */
    double tokens;   /* may be negative: bytes taken ahead of the rate */
    int64_t t_ns;    /* when tokens was last brought up to date */
} drv_token_bucket;

/* A full bucket at now_ns. rate_bps <= 0 is not a bucket: callers leave the link unlimited instead. */
void drv_token_bucket_init(drv_token_bucket *b, double rate_bps, double burst, int64_t now_ns);
/* When (ns, on the same clock) the bucket holds at least one token again: now_ns or earlier when it does now. */
int64_t drv_token_bucket_ready_ns(const drv_token_bucket *b, int64_t now_ns);
/* Takes n bytes at now_ns (the caller moved them) and returns when the next byte may move (as _ready_ns). */
int64_t drv_token_bucket_take(drv_token_bucket *b, size_t n, int64_t now_ns);
/* The burst a link of rate_bps gets: DRV_TOKEN_BUCKET_BURST_MS of traffic, at least DRV_TOKEN_BUCKET_MIN_BURST. */
double drv_token_bucket_burst_for(double rate_bps);
#define DRV_TOKEN_BUCKET_BURST_MS 2.0     /* a USB host controller's queue of bulk transfers, about */
#define DRV_TOKEN_BUCKET_MIN_BURST 16384  /* one read's worth at the lowest rates, so reads are not cut to crumbs */

#endif
