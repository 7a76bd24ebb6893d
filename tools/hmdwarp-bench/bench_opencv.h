/* SPDX-License-Identifier: MIT */
/* The bench's peer: OpenCV's cv::remap doing the display path's per-channel distortion resampling (three 8-bit
 * single-channel remaps through fixed-point maps), behind a C interface since OpenCV 4 has no C API. */
#ifndef BENCH_OPENCV_H
#define BENCH_OPENCV_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct bench_cv bench_cv;

/* Maps: for output pixel (x, y) of channel c, the source position in OpenCV's convention (pixel centres at
 * integers), mapx[c][y * w + x], mapy[c][...]. Converted once to OpenCV's fast fixed-point form (CV_16SC2 +
 * CV_16UC1, 1/32 pixel), as a real user would. Source planes are src_w x src_h 8-bit, `src_stride` bytes apart. */
bench_cv *bench_cv_create(int w, int h, const float *const mapx[3], const float *const mapy[3], int src_w, int src_h);
/* One frame: dst plane c (w x h, dst_stride) = remap(src plane c), bilinear, replicated border (the 003 §4.3 fill). */
void bench_cv_remap(bench_cv *cv, const uint8_t *const src[3], int src_stride, uint8_t *const dst[3], int dst_stride);
void bench_cv_set_threads(int n);
const char *bench_cv_version(void);
void bench_cv_destroy(bench_cv *cv);

#ifdef __cplusplus
}
#endif

#endif
