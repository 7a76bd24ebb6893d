/* SPDX-License-Identifier: MIT */
/* test_images: the plain images of a test fixture allocated and freed from one list, so that its setup and teardown
 * name each image once and cannot drift apart. */
#ifndef TEST_IMAGES_H
#define TEST_IMAGES_H

#include <stdbool.h>
#include <stddef.h>

#include "warp/warp_image.h"

typedef enum { TEST_IMG_RGBA8, TEST_IMG_F32, TEST_IMG_U8 } test_image_kind;

typedef struct {
    test_image_kind kind;
    void *img; /* a warp_image_rgba8, _f32 or _u8, as kind says */
} test_image;

#define TEST_RGBA8(p) {TEST_IMG_RGBA8, (warp_image_rgba8 *)(p)}
#define TEST_F32(p) {TEST_IMG_F32, (warp_image_f32 *)(p)}
#define TEST_U8(p) {TEST_IMG_U8, (warp_image_u8 *)(p)}
#define TEST_IMAGES_N(list) (sizeof(list) / sizeof(list)[0])

/* Allocates every image of the list at w x h; false when one fails (free the list: freeing a null image is fine). */
static inline bool test_images_alloc(const test_image *list, size_t n, int w, int h)
{
    for (size_t i = 0; i < n; i++) {
        bool ok = list[i].kind == TEST_IMG_RGBA8 ? warp_image_rgba8_alloc(list[i].img, w, h)
                  : list[i].kind == TEST_IMG_F32 ? warp_image_f32_alloc(list[i].img, w, h)
                                                 : warp_image_u8_alloc(list[i].img, w, h);
        if (!ok) return false;
    }
    return true;
}

static inline void test_images_free(const test_image *list, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        if (list[i].kind == TEST_IMG_RGBA8)
            warp_image_free((warp_image_rgba8 *)list[i].img);
        else if (list[i].kind == TEST_IMG_F32)
            warp_image_free((warp_image_f32 *)list[i].img);
        else
            warp_image_free((warp_image_u8 *)list[i].img);
    }
}

#endif
