/* SPDX-License-Identifier: MIT */
/* rt_ring: a single-producer single-consumer ring of fixed-size records, so the vsync thread can hand records
 * (CSV rows, accuracy samples) to slower threads without locks, allocation or waiting: when full, it drops. */
#include "runtime/rt_ring.h"

#include <stdlib.h>
#include <string.h>

bool rt_ring_alloc(rt_ring *r, size_t rec_size, size_t cap_pow2)
{
    memset(r, 0, sizeof *r);
    if (!rec_size || !cap_pow2 || (cap_pow2 & (cap_pow2 - 1))) return false;
    r->buf = calloc(cap_pow2, rec_size);
    if (!r->buf) return false;
    r->rec_size = rec_size;
    r->cap = cap_pow2;
    return true;
}

void rt_ring_free(rt_ring *r)
{
    free(r->buf);
    r->buf = NULL;
}

bool rt_ring_push(rt_ring *r, const void *rec)
{
    uint64_t h = atomic_load_explicit(&r->head, memory_order_relaxed);
    uint64_t t = atomic_load_explicit(&r->tail, memory_order_acquire);
    if (h - t >= r->cap) {
        atomic_fetch_add_explicit(&r->dropped, 1, memory_order_relaxed);
        return false;
    }
    memcpy(r->buf + (h & (r->cap - 1)) * r->rec_size, rec, r->rec_size);
    atomic_store_explicit(&r->head, h + 1, memory_order_release);
    return true;
}

bool rt_ring_pop(rt_ring *r, void *rec)
{
    uint64_t t = atomic_load_explicit(&r->tail, memory_order_relaxed);
    uint64_t h = atomic_load_explicit(&r->head, memory_order_acquire);
    if (t == h) return false;
    memcpy(rec, r->buf + (t & (r->cap - 1)) * r->rec_size, r->rec_size);
    atomic_store_explicit(&r->tail, t + 1, memory_order_release);
    return true;
}
