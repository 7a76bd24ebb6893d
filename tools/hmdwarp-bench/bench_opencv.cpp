/* SPDX-License-Identifier: MIT */
// The bench's peer: OpenCV's cv::remap doing the display path's per-channel distortion resampling (three 8-bit
// single-channel remaps through fixed-point maps), behind a C interface since OpenCV 4 has no C API.
#include "bench_opencv.h"

#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

struct bench_cv {
    int w, h, src_w, src_h;
    cv::Mat m1[3], m2[3];
};

extern "C" bench_cv *bench_cv_create(int w, int h, const float *const mapx[3], const float *const mapy[3], int src_w,
                                     int src_h)
{
    bench_cv *b = new bench_cv;
    b->w = w;
    b->h = h;
    b->src_w = src_w;
    b->src_h = src_h;
    for (int c = 0; c < 3; c++) {
        cv::Mat fx(h, w, CV_32FC1, const_cast<float *>(mapx[c])), fy(h, w, CV_32FC1, const_cast<float *>(mapy[c]));
        cv::convertMaps(fx, fy, b->m1[c], b->m2[c], CV_16SC2, false);
    }
    return b;
}

extern "C" void bench_cv_remap(bench_cv *b, const uint8_t *const src[3], int src_stride, uint8_t *const dst[3],
                               int dst_stride)
{
    for (int c = 0; c < 3; c++) {
        cv::Mat s(b->src_h, b->src_w, CV_8UC1, const_cast<uint8_t *>(src[c]), (size_t)src_stride);
        cv::Mat d(b->h, b->w, CV_8UC1, dst[c], (size_t)dst_stride);
        cv::remap(s, d, b->m1[c], b->m2[c], cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    }
}

extern "C" void bench_cv_set_threads(int n) { cv::setNumThreads(n); }

extern "C" const char *bench_cv_version(void) { return CV_VERSION; }

extern "C" void bench_cv_destroy(bench_cv *b) { delete b; }
