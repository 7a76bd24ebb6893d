/* SPDX-License-Identifier: MIT */
/* warp_rand: counter-based randomness shared by every layer (sampling jitter, simulated traces and scenes, TE
 * pulse schedules, tests): splitmix64, so any draw is a pure function of its key and evaluation order never matters. */
#ifndef WARP_RAND_H
#define WARP_RAND_H

#include <stdint.h>

/* The golden-ratio increment of splitmix64's state (Steele, Lea, Flood 2014, "Fast splittable pseudorandom number
 * generators"). */
#define WARP_GOLDEN64 0x9E3779B97F4A7C15ull

/* splitmix64's output function alone (Stafford's "Mix13" finaliser): a bijection that spreads every input bit. */
static inline uint64_t warp_mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* One splitmix64 step from state z: the value drawn for key z. */
static inline uint64_t warp_splitmix64(uint64_t z) { return warp_mix64(z + WARP_GOLDEN64); }

/* A 64-bit draw as a double in [0, 1) from its top 53 bits (every value exactly representable). */
static inline double warp_unit53(uint64_t z) { return (double)(z >> 11) * 0x1.0p-53; }

#endif
