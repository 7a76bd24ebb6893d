/* SPDX-License-Identifier: MIT */
/* drv_token_bucket: the token bucket's arithmetic (accrue, take with debt, when ready) on times the caller gives.
 * See drv_token_bucket.h. */
#include "drivers/drv_token_bucket.h"

#include <math.h>

void drv_token_bucket_init(drv_token_bucket *b, double rate_bps, double burst, int64_t now_ns)
{
    b->rate_bps = rate_bps;
    b->burst = burst > 1 ? burst : 1;
    b->tokens = b->burst;
    b->t_ns = now_ns;
}

/* Brings tokens up to now; a clock that went backwards (it should not) accrues nothing. */
static void accrue(drv_token_bucket *b, int64_t now_ns)
{
    if (now_ns <= b->t_ns) return;
    b->tokens += (double)(now_ns - b->t_ns) * 1e-9 * b->rate_bps;
    if (b->tokens > b->burst) b->tokens = b->burst;
    b->t_ns = now_ns;
}

int64_t drv_token_bucket_ready_ns(const drv_token_bucket *b, int64_t now_ns)
{
    /* one token: the debt plus the byte the next read needs */
    double need = 1.0 - b->tokens;
    int64_t t = b->t_ns > now_ns ? b->t_ns : now_ns;
    if (need <= 0) return now_ns;
    int64_t ready = b->t_ns + (int64_t)ceil(need / b->rate_bps * 1e9);
    return ready > t ? ready : t;
}

int64_t drv_token_bucket_take(drv_token_bucket *b, size_t n, int64_t now_ns)
{
    accrue(b, now_ns);
    b->tokens -= (double)n;
    return drv_token_bucket_ready_ns(b, now_ns);
}

double drv_token_bucket_burst_for(double rate_bps)
{
    double burst = rate_bps * DRV_TOKEN_BUCKET_BURST_MS * 1e-3;
    return burst > DRV_TOKEN_BUCKET_MIN_BURST ? burst : DRV_TOKEN_BUCKET_MIN_BURST;
}
