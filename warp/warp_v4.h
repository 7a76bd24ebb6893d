/* SPDX-License-Identifier: MIT */
/* warp_v4: four-lane vectors in GCC/clang vector extensions (SSE2 on x86-64, NEON on aarch64, at 16 bytes; wider
 * ones are split into scalars where the target lacks them) for the whole-frame loops, and their lane select. */
#ifndef WARP_V4_H
#define WARP_V4_H

#include <stdint.h>

/* Element-wise IEEE operations round like their scalar counterparts; a comparison gives -1 in the lanes where it
 * holds, 0 elsewhere. */
typedef float warp_v4f __attribute__((vector_size(16)));
typedef int32_t warp_v4i __attribute__((vector_size(16)));
typedef uint32_t warp_v4u __attribute__((vector_size(16)));
typedef double warp_v4d __attribute__((vector_size(32)));
typedef uint16_t warp_v4h __attribute__((vector_size(8)));

/* m ? a : b per lane (C has no vector ?:), m a comparison's result. */
static inline warp_v4f warp_v4f_select(warp_v4i m, warp_v4f a, warp_v4f b)
{
    return (warp_v4f)(((warp_v4i)a & m) | ((warp_v4i)b & ~m));
}

#endif
