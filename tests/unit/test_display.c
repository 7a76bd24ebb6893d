/* SPDX-License-Identifier: MIT */
/* Tests of the display side: swapchain image selection around held and on-screen images, the PNG and raw file
 * sinks (content written intact, a busy writer skips rather than blocks), and PNG round trips. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <cmocka.h>

#include "platform/plat_display.h"
#include "platform/plat_png.h"

static void pattern(warp_image_rgba8 *img, int seed)
{
    for (int y = 0; y < img->h; y++)
        for (int x = 0; x < img->w; x++)
            WARP_AT(img, x, y) = (warp_rgba8){(uint8_t)(x * 3 + seed), (uint8_t)(y * 5), (uint8_t)(x ^ y), 255};
}

static void test_swapchain_next(void **state)
{
    (void)state;
    plat_swapchain sc;
    assert_false(plat_swapchain_alloc(&sc, 1, 8, 8)); /* one image cannot be drawn while shown */
    assert_true(plat_swapchain_alloc(&sc, 3, 8, 8));
    sc.on_screen = 0;
    assert_int_equal(plat_swapchain_next(&sc, 0), 1);
    atomic_store(&sc.held[1], 1);
    assert_int_equal(plat_swapchain_next(&sc, 0), 2);
    atomic_store(&sc.held[2], 1);
    assert_int_equal(plat_swapchain_next(&sc, 0), -1); /* all busy: the compositor skips, never waits */
    atomic_store(&sc.held[1], 0);
    assert_int_equal(plat_swapchain_next(&sc, 0), 1);
    atomic_store(&sc.held[1], 0);
    atomic_store(&sc.held[2], 0);
    /* A pass started more than a period ahead: image 1 went up for the vsync at 100, image 0 is shown until then
     * and must not be drawn into before; afterwards it is free again. */
    plat_swapchain_presented(&sc, 1, 100);
    assert_int_equal(plat_swapchain_next(&sc, 50), 2);
    atomic_store(&sc.held[2], 1);
    assert_int_equal(plat_swapchain_next(&sc, 50), -1);
    assert_int_equal(plat_swapchain_next(&sc, 100), 0);
    plat_swapchain_free(&sc);
}

static void test_png_round_trip(void **state)
{
    (void)state;
    warp_image_rgba8 a, b;
    assert_true(warp_image_rgba8_alloc(&a, 37, 21));
    pattern(&a, 7);
    char err[256];
    assert_true(plat_png_write("build/test_display_rt.png", &a, false, err, sizeof err));
    assert_true(plat_png_read("build/test_display_rt.png", &b, err, sizeof err));
    assert_int_equal(b.w, 37);
    assert_int_equal(b.h, 21);
    for (int y = 0; y < 21; y++)
        for (int x = 0; x < 37; x++) assert_memory_equal(&WARP_AT(&a, x, y), &WARP_AT(&b, x, y), 4);
    warp_image_free(&b);
    /* errors name the file and the cause */
    assert_false(plat_png_read("build/no/such/file.png", &b, err, sizeof err));
    assert_non_null(strstr(err, "build/no/such/file.png"));
    warp_image_free(&a);
}

/* present() never waits for the file: the frame's path is a FIFO nobody reads yet, so the writer thread blocks
 * in its open (deterministically, not "most likely busy"); the presents after it return, the due one skipped and
 * counted. Then the test reads the FIFO and the image comes out whole. (This asserted present() took < 5 ms once,
 * which make check-cross's qemu-user did not always meet.) */
static void test_png_sink_writes_and_skips(void **state)
{
    (void)state;
    char err[256];
    mkdir("build", 0755);
    mkdir("build/test_display_png", 0755);
    const char *fifo = "build/test_display_png/frame_000004.png";
    unlink(fifo);
    assert_int_equal(mkfifo(fifo, 0644), 0);
    plat_display *d = plat_display_files_create("png", "build/test_display_png", 2, err, sizeof err);
    assert_non_null(d);
    plat_swapchain sc;
    assert_true(plat_swapchain_alloc(&sc, 3, 320, 200));
    pattern(&sc.img[0], 1);
    plat_display_present(d, &sc, 0, 0, 4); /* due: handed to the writer, which blocks opening the FIFO */
    plat_display_present(d, &sc, 0, 0, 5); /* not due (every 2nd) */
    plat_display_present(d, &sc, 0, 0, 6); /* due, but the writer is busy: skipped, not waited for */
    char line[400];
    d->describe(d, line, sizeof line);
    print_message("%s\n", line);
    assert_non_null(strstr(line, "1 skipped (writer busy)"));
    assert_int_equal(atomic_load(&sc.held[0]), 1); /* the writer still holds the image */
    /* now read what the writer writes, into a regular file */
    FILE *in = fopen(fifo, "rb");
    assert_non_null(in);
    FILE *out = fopen("build/test_display_png/frame_4_read.png", "wb");
    assert_non_null(out);
    char buf[4096];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, in)) > 0) assert_int_equal(fwrite(buf, 1, n, out), n);
    fclose(in);
    fclose(out);
    plat_display_flush(d);
    assert_int_equal(atomic_load(&sc.held[0]), 0); /* released after writing */
    warp_image_rgba8 back;
    assert_true(plat_png_read("build/test_display_png/frame_4_read.png", &back, err, sizeof err));
    for (int y = 0; y < 200; y += 7)
        for (int x = 0; x < 320; x += 5) assert_memory_equal(&WARP_AT(&back, x, y), &WARP_AT(&sc.img[0], x, y), 3);
    warp_image_free(&back);
    plat_display_destroy(d);
    plat_swapchain_free(&sc);
    unlink(fifo);
}

static void test_raw_sink(void **state)
{
    (void)state;
    char err[256];
    plat_display *d = plat_display_files_create("raw", "build/test_display_raw", 1, err, sizeof err);
    assert_non_null(d);
    plat_swapchain sc;
    assert_true(plat_swapchain_alloc(&sc, 2, 64, 32));
    for (int i = 0; i < 3; i++) {
        pattern(&sc.img[0], i);
        plat_display_present(d, &sc, 0, 0, (uint64_t)i);
        plat_display_flush(d); /* one at a time so none is skipped */
    }
    plat_display_destroy(d);
    struct stat st;
    assert_int_equal(stat("build/test_display_raw/frames.rgba", &st), 0);
    assert_int_equal(st.st_size, 3 * 64 * 32 * 4);
    /* bad sink settings are reported, not crashed on */
    assert_null(plat_display_files_create("jpeg", "build/x", 1, err, sizeof err));
    assert_non_null(strstr(err, "jpeg"));
    assert_null(plat_display_files_create("png", "/proc/forbidden/dir", 1, err, sizeof err));
    plat_swapchain_free(&sc);
}

static void test_png_u16_round_trip(void **state)
{
    (void)state;
    uint16_t px[37 * 5];
    for (int i = 0; i < 37 * 5; i++) px[i] = (uint16_t)(i * 353 + (i % 3) * 20000);
    char err[300];
    const char *path = "build/test_display_u16.png"; /* build/ exists in every build tree; build/tests not */
    assert_true(plat_png_write_u16(path, px, 37, 5, err, sizeof err));
    uint16_t *back = NULL;
    int w = 0, h = 0;
    assert_true(plat_png_read_u16(path, &back, &w, &h, err, sizeof err));
    assert_int_equal(w, 37);
    assert_int_equal(h, 5);
    assert_memory_equal(back, px, sizeof px); /* exact: depth and ids survive */
    free(back);
    /* an 8-bit PNG is refused with a message naming the file */
    warp_image_rgba8 img;
    assert_true(warp_image_rgba8_alloc(&img, 4, 4));
    assert_true(plat_png_write(path, &img, true, err, sizeof err));
    assert_false(plat_png_read_u16(path, &back, &w, &h, err, sizeof err));
    assert_non_null(strstr(err, "16-bit"));
    warp_image_free(&img);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_png_u16_round_trip),
        cmocka_unit_test(test_swapchain_next),
        cmocka_unit_test(test_png_round_trip),
        cmocka_unit_test(test_png_sink_writes_and_skips),
        cmocka_unit_test(test_raw_sink),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
