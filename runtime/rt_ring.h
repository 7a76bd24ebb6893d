/* SPDX-License-Identifier: MIT */
/* rt_ring: a single-producer single-consumer ring of fixed-size records, so the vsync thread can hand records
 * (CSV rows, accuracy samples) to slower threads without locks, allocation or waiting: when full, it drops. */
#ifndef RT_RING_H
#define RT_RING_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef struct {
    size_t rec_size, cap; /* cap is a power of two */
    unsigned char *buf;
    _Atomic uint64_t head, tail; /* head: next write (producer), tail: next read (consumer) */
    _Atomic uint64_t dropped;
} rt_ring;

bool rt_ring_alloc(rt_ring *r, size_t rec_size, size_t cap_pow2);
void rt_ring_free(rt_ring *r);
/* Producer: copies rec in; false (and counts a drop) when full. */
bool rt_ring_push(rt_ring *r, const void *rec);
/* Consumer: copies the oldest record out; false when empty. */
bool rt_ring_pop(rt_ring *r, void *rec);

#endif
