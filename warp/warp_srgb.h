/* SPDX-License-Identifier: MIT */
/* warp_srgb: the sRGB transfer curve (IEC 61966-2-1) for blending in linear light, as renderers composite: 8-bit
 * codes to linear by a table, linear back to the nearest 8-bit code exactly, and the float curve for the simulator. */
#ifndef WARP_SRGB_H
#define WARP_SRGB_H

#include <stdint.h>

/* Linear value in [0, 1] of each 8-bit sRGB code. */
extern const float warp_srgb_to_linear_u8[256];
/* Linear value of each half-way point (k + 0.5) / 255 between codes k and k + 1: the encoder's decision points. */
extern const float warp_srgb_mid_linear[255];

/* The 8-bit sRGB code nearest to linear value v (clamped to [0, 1]): round(255 * encode(v)), found by a binary
 * search over the 255 linear values half-way between codes, so it rounds exactly as the curve does (a table indexed
 * by v would need about 2^20 entries to keep the dark end, where the curve is 12.92 steep, exact). */
static inline uint8_t warp_srgb_from_linear_u8(float v)
{
    int c = 0;
    for (int step = 128; step; step >>= 1)
        if (c + step <= 255 && v >= warp_srgb_mid_linear[c + step - 1]) c += step;
    return (uint8_t)c;
}

/* The curve itself in float, encoded [0, 1] <-> linear [0, 1] (outside: clamped). */
float warp_srgb_decode(float e);
float warp_srgb_encode(float v);

#endif
