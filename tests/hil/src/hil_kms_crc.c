/* SPDX-License-Identifier: MIT */
/* hil_kms_crc: the CRC vkms reports for a picture, computed from the panel image (hmdwarpd's raw sink), so a HIL
 * scenario can check that what reached vkms's CRTC is byte for byte the image hmdwarpd rendered offscreen.
 *
 * vkms (Linux 6.1, drivers/gpu/drm/vkms/vkms_composer.c) composes each CRTC row into struct pixel_argb_u16
 * {u16 a, r, g, b} (8 bytes a pixel, little-endian here; a = 0xffff for XRGB8888, each 8-bit channel * 257) and
 * chains crc = crc32_le(crc, row, width * 8) over all rows from crc = 0. Linux's crc32_le is the reflected CRC-32
 * without zlib's pre- and post-inversion, so crc32_le(c, buf) = ~zlib_crc32(~c, buf), and rows chain through it.
 * Alpha is ignored: vkms's primary plane is XRGB8888 (or XRGB16161616, RGB565: not modelled here).
 *
 * It also shows an image on a KMS card by itself (a dumb buffer and one legacy modeset, no hmdwarpd), so 00-devices
 * can check this model against vkms directly, and makes a test pattern for that. */
#include <errno.h>
#include <fcntl.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>
#include <drm_fourcc.h>
#include <xf86drm.h>
#include <xf86drmMode.h>
#include <zlib.h>

#define MAX_SIDE 8192 /* vkms's XRES_MAX / YRES_MAX */

/* vkms's CRC of one w x h RGBA8 image (rgba: w * h * 4 bytes, rows packed). */
static uint32_t vkms_crc(const uint8_t *rgba, int w, int h, uint8_t *row)
{
    uint32_t crc = 0;
    for (int y = 0; y < h; y++) {
        const uint8_t *p = rgba + (size_t)y * w * 4;
        for (int x = 0; x < w; x++) {
            uint16_t v[4] = {0xffff, (uint16_t)(p[4 * x] * 257), (uint16_t)(p[4 * x + 1] * 257),
                             (uint16_t)(p[4 * x + 2] * 257)};
            for (int c = 0; c < 4; c++) { /* little-endian u16s, as the kernel's struct on x86 */
                row[8 * x + 2 * c] = (uint8_t)(v[c] & 0xff);
                row[8 * x + 2 * c + 1] = (uint8_t)(v[c] >> 8);
            }
        }
        crc = ~(uint32_t)crc32(~crc & 0xffffffffu, row, (uInt)w * 8);
    }
    return crc;
}

/* Reads the whole raw stream (whole images only; a trailing partial one is ignored). */
static uint8_t *read_stream(const char *path, int w, int h, long *n_images)
{
    FILE *f = fopen(path, "rb");
    if (!f) return fprintf(stderr, "hil_kms_crc: %s: %s\n", path, strerror(errno)), NULL;
    long isz = (long)w * h * 4;
    if (fseek(f, 0, SEEK_END) != 0 || ftell(f) < isz) {
        fprintf(stderr, "hil_kms_crc: %s holds no complete %dx%d RGBA8 image\n", path, w, h);
        fclose(f);
        return NULL;
    }
    *n_images = ftell(f) / isz;
    rewind(f);
    uint8_t *buf = malloc((size_t)(*n_images * isz));
    if (!buf || fread(buf, (size_t)isz, (size_t)*n_images, f) != (size_t)*n_images) {
        fprintf(stderr, "hil_kms_crc: %s: %s\n", path, buf ? "short read" : "out of memory");
        free(buf);
        buf = NULL;
    }
    fclose(f);
    return buf;
}

/* A picture in which every channel takes many values and differs from the others (an R/B swap, a wrong channel
 * order or a dropped row changes the CRC), opaque. */
static void pattern(uint8_t *rgba, int w, int h)
{
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            uint8_t *p = rgba + ((size_t)y * w + x) * 4;
            p[0] = (uint8_t)(x * 255 / (w > 1 ? w - 1 : 1));
            p[1] = (uint8_t)(y * 255 / (h > 1 ? h - 1 : 1));
            p[2] = (uint8_t)((x ^ y) * 7);
            p[3] = 255;
        }
}

/* Shows rgba on the first connected connector of card in its w x h mode (XRGB8888 dumb buffer, legacy SetCrtc),
 * holds it for secs seconds (the caller reads the CRCs meanwhile). A test program that exits right after: on any
 * failure it leaves the clean-up to the kernel, which frees the FB, buffer and mapping with the file. */
static int show(const char *card, const uint8_t *rgba, int w, int h, int secs)
{
    int fd = open(card, O_RDWR | O_CLOEXEC);
    if (fd < 0) return fprintf(stderr, "hil_kms_crc: %s: %s\n", card, strerror(errno)), 1;
    drmModeRes *res = drmModeGetResources(fd);
    if (!res) return fprintf(stderr, "hil_kms_crc: %s: not a KMS device\n", card), 1;
    drmModeConnector *conn = NULL;
    drmModeModeInfo *mode = NULL;
    for (int i = 0; i < res->count_connectors && !mode; i++) {
        conn = drmModeGetConnector(fd, res->connectors[i]);
        if (conn && conn->connection == DRM_MODE_CONNECTED)
            for (int m = 0; m < conn->count_modes && !mode; m++)
                if (conn->modes[m].hdisplay == w && conn->modes[m].vdisplay == h) mode = &conn->modes[m];
        if (!mode && conn) drmModeFreeConnector(conn);
    }
    if (!mode) return fprintf(stderr, "hil_kms_crc: %s: no connected connector with a %dx%d mode\n", card, w, h), 1;
    struct drm_mode_create_dumb cd = {.width = (uint32_t)w, .height = (uint32_t)h, .bpp = 32};
    if (drmIoctl(fd, DRM_IOCTL_MODE_CREATE_DUMB, &cd) != 0)
        return fprintf(stderr, "hil_kms_crc: create dumb %dx%d: %s\n", w, h, strerror(errno)), 1;
    struct drm_mode_map_dumb md = {.handle = cd.handle};
    if (drmIoctl(fd, DRM_IOCTL_MODE_MAP_DUMB, &md) != 0)
        return fprintf(stderr, "hil_kms_crc: map dumb: %s\n", strerror(errno)), 1;
    uint8_t *px = mmap(NULL, cd.size, PROT_READ | PROT_WRITE, MAP_SHARED, fd, (off_t)md.offset);
    if (px == MAP_FAILED) return fprintf(stderr, "hil_kms_crc: mmap dumb: %s\n", strerror(errno)), 1;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) { /* XRGB8888: B, G, R, X in memory */
            const uint8_t *s = rgba + ((size_t)y * w + x) * 4;
            uint8_t *d = px + (size_t)y * cd.pitch + (size_t)x * 4;
            d[0] = s[2], d[1] = s[1], d[2] = s[0], d[3] = 0;
        }
    uint32_t handles[4] = {cd.handle}, pitches[4] = {cd.pitch}, offsets[4] = {0}, fb = 0;
    if (drmModeAddFB2(fd, (uint32_t)w, (uint32_t)h, DRM_FORMAT_XRGB8888, handles, pitches, offsets, &fb, 0) != 0)
        return fprintf(stderr, "hil_kms_crc: AddFB2 XRGB8888: %s\n", strerror(errno)), 1;
    uint32_t crtc = 0;
    drmModeEncoder *enc = conn->count_encoders > 0 ? drmModeGetEncoder(fd, conn->encoders[0]) : NULL;
    for (int i = 0; enc && i < res->count_crtcs && !crtc; i++)
        if (enc->possible_crtcs & (1u << i)) crtc = res->crtcs[i];
    if (!crtc) return fprintf(stderr, "hil_kms_crc: no CRTC for connector %u\n", conn->connector_id), 1;
    if (drmModeSetCrtc(fd, crtc, fb, 0, 0, &conn->connector_id, 1, mode) != 0)
        return fprintf(stderr, "hil_kms_crc: SetCrtc %dx%d: %s\n", w, h, strerror(errno)), 1;
    printf("shown=%dx%d fb=%u crtc=%u\n", w, h, fb, crtc);
    fflush(stdout);
    sleep((unsigned)secs);
    return 0;
}

static int usage(void)
{
    fprintf(stderr,
            "usage: hil_kms_crc crc RAW W H [--all]       vkms's CRC of the last W x H RGBA8 image of a raw stream\n"
            "                                             (--all: of every image, one a line), as 0xXXXXXXXX\n"
            "       hil_kms_crc pattern W H >FILE         write a W x H RGBA8 test pattern\n"
            "       hil_kms_crc show CARD RAW W H SECS    show the last image of RAW on CARD's W x H mode for SECS s\n");
    return 2;
}

static int parse_size(const char *ws, const char *hs, int *w, int *h)
{
    char *e1, *e2;
    long lw = strtol(ws, &e1, 10), lh = strtol(hs, &e2, 10);
    if (*e1 || *e2 || lw < 1 || lh < 1 || lw > MAX_SIDE || lh > MAX_SIDE) {
        fprintf(stderr, "hil_kms_crc: bad size '%s' x '%s' (1..%d each)\n", ws, hs, MAX_SIDE);
        return 0;
    }
    *w = (int)lw, *h = (int)lh;
    return 1;
}

int main(int argc, char **argv)
{
    int w, h;
    if (argc >= 5 && strcmp(argv[1], "crc") == 0) {
        int all = argc == 6 && strcmp(argv[5], "--all") == 0;
        if (argc != 5 && !all) return usage();
        if (!parse_size(argv[3], argv[4], &w, &h)) return 2;
        long n;
        uint8_t *img = read_stream(argv[2], w, h, &n);
        uint8_t *row = malloc((size_t)w * 8);
        if (!img || !row) return free(img), free(row), 1;
        for (long i = all ? 0 : n - 1; i < n; i++) printf("0x%08x\n", vkms_crc(img + i * (size_t)w * h * 4, w, h, row));
        free(img);
        free(row);
        return 0;
    }
    if (argc == 4 && strcmp(argv[1], "pattern") == 0) {
        if (!parse_size(argv[2], argv[3], &w, &h)) return 2;
        uint8_t *img = malloc((size_t)w * h * 4);
        if (!img) return 1;
        pattern(img, w, h);
        int ok = fwrite(img, (size_t)w * 4, (size_t)h, stdout) == (size_t)h;
        free(img);
        return ok ? 0 : 1;
    }
    if (argc == 7 && strcmp(argv[1], "show") == 0) {
        if (!parse_size(argv[4], argv[5], &w, &h)) return 2;
        int secs = atoi(argv[6]);
        if (secs < 1 || secs > 3600) return fprintf(stderr, "hil_kms_crc: bad duration '%s' s\n", argv[6]), 2;
        long n;
        uint8_t *img = read_stream(argv[3], w, h, &n);
        if (!img) return 1;
        int rc = show(argv[2], img + (n - 1) * (size_t)w * h * 4, w, h, secs);
        free(img);
        return rc;
    }
    return usage();
}
