/* SPDX-License-Identifier: MIT */
/* drv_codec_jpeg: framelink v2's JPEG colour codec (libturbojpeg), one band of rows of an eye image per JPEG, so a
 * frame's slices encode and decode in parallel; every size and length is checked before libturbojpeg sees it. */
#include "drivers/drv_codec_jpeg.h"

#include <limits.h>
#include <stdlib.h>
#include <turbojpeg.h>

#include "warp/warp_err.h"
#include "warp/warp_image.h"

struct drv_jpeg {
    tjhandle tj;
    bool encoder;
};

/* Decoding: a warning (corrupt or truncated entropy data, which libjpeg would paint over with grey) fails the call
 * (2.1 returns -1 for it anyway), and STOPONWARNING makes it stop there rather than decode the rest; LIMITSCANS
 * refuses progressive JPEGs with absurd scan counts, which otherwise take seconds per band (a cheap way for a bad
 * host to stall the frames thread). */
#define DEC_FLAGS (TJFLAG_STOPONWARNING | TJFLAG_LIMITSCANS)
/* Encoding into the caller's buffer only: libturbojpeg then assumes tjBufSize bytes, hence the cap check first. */
#define ENC_FLAGS TJFLAG_NOREALLOC

/* libturbojpeg takes lengths as unsigned long: the same width as size_t on every Linux ABI (LP64, ILP32). */
_Static_assert(sizeof(unsigned long) == sizeof(size_t), "unsigned long holds a size_t");

static const int tj_sub[] = {[DRV_JPEG_420] = TJSAMP_420, [DRV_JPEG_444] = TJSAMP_444};

static bool sub_ok(drv_jpeg_sub sub) { return sub == DRV_JPEG_420 || sub == DRV_JPEG_444; }
static bool side_ok(int n) { return n >= 1 && n <= WARP_MAX_SIDE; }

drv_jpeg *drv_jpeg_create(bool encoder, char *err, int errlen)
{
    drv_jpeg *j = calloc(1, sizeof *j);
    if (!j) {
        warp_err(err, errlen, "JPEG %s: out of memory", encoder ? "encoder" : "decoder");
        return NULL;
    }
    j->encoder = encoder;
    j->tj = encoder ? tjInitCompress() : tjInitDecompress();
    if (!j->tj) {
        /* tjGetErrorStr2(NULL) holds the reason a handle could not be made (thread-local in libturbojpeg). */
        warp_err(err, errlen, "JPEG %s: %s", encoder ? "encoder" : "decoder", tjGetErrorStr2(NULL));
        free(j);
        return NULL;
    }
    return j;
}

void drv_jpeg_destroy(drv_jpeg *j)
{
    if (!j) return;
    if (j->tj) tjDestroy(j->tj);
    free(j);
}

size_t drv_jpeg_bound(int w, int h, drv_jpeg_sub sub)
{
    if (!side_ok(w) || !side_ok(h) || !sub_ok(sub)) return 0;
    unsigned long n = tjBufSize(w, h, tj_sub[sub]);
    return n == (unsigned long)-1 ? 0 : (size_t)n;
}

size_t drv_jpeg_encode(drv_jpeg *j, const uint8_t *rgba, int w, int h, size_t stride, int quality, drv_jpeg_sub sub,
                       uint8_t *out, size_t cap, char *err, int errlen)
{
    if (!j || !j->encoder) return warp_err(err, errlen, "JPEG encode: not an encoder"), 0;
    if (!rgba || !out) return warp_err(err, errlen, "JPEG encode: no %s buffer", rgba ? "output" : "input"), 0;
    if (!side_ok(w) || !side_ok(h))
        return warp_err(err, errlen, "JPEG encode: size %dx%d outside 1..%d", w, h, WARP_MAX_SIDE), 0;
    if (stride < (size_t)w * 4 || stride > INT_MAX)
        return warp_err(err, errlen, "JPEG encode: stride %zu for %d RGBA pixels a row", stride, w), 0;
    if (quality < 1 || quality > 100)
        return warp_err(err, errlen, "JPEG encode: quality %d outside 1..100", quality), 0;
    if (!sub_ok(sub)) return warp_err(err, errlen, "JPEG encode: unknown subsampling %d", (int)sub), 0;
    size_t bound = drv_jpeg_bound(w, h, sub);
    if (cap < bound)
        return warp_err(err, errlen, "JPEG encode: %dx%d needs a %zu-byte buffer, given %zu", w, h, bound, cap), 0;
    unsigned char *dst = out;
    unsigned long len = (unsigned long)cap;
    /* RGBX: the fourth byte is ignored (JPEG has no alpha; the board decodes alpha 255). */
    if (tjCompress2(j->tj, rgba, w, (int)stride, h, TJPF_RGBX, &dst, &len, tj_sub[sub], quality, ENC_FLAGS) != 0)
        return warp_err(err, errlen, "JPEG encode %dx%d: %s", w, h, tjGetErrorStr2(j->tj)), 0;
    if (dst != out || len == 0 || len > cap) /* NOREALLOC promises neither; a library that broke it is not trusted */
        return warp_err(err, errlen, "JPEG encode %dx%d: libturbojpeg wrote outside the buffer", w, h), 0;
    return (size_t)len;
}

/* libturbojpeg 2.1's tjDecompressHeader3 returns from a refused header without aborting the libjpeg decompressor,
 * which then resumes that stream's parse on the next call (a good JPEG after a bad one was refused): a fresh handle
 * after such a failure. It allocates, on an error path of the frames thread only. */
static void reset_decoder(drv_jpeg *j)
{
    if (j->tj) tjDestroy(j->tj);
    j->tj = tjInitDecompress();
}

drv_frame_err drv_jpeg_decode(drv_jpeg *j, const uint8_t *jpeg, size_t len, uint8_t *rgba, int w, int h,
                              size_t stride, char *err, int errlen)
{
    if (!j || j->encoder) return drv_frame_fail(err, errlen, DRV_FRAME_ERR_BAD_FORMAT, "JPEG decode: not a decoder");
    if (!j->tj) {
        reset_decoder(j);
        if (!j->tj) return drv_frame_fail(err, errlen, DRV_FRAME_ERR_IO, "JPEG decoder: %s", tjGetErrorStr2(NULL));
    }
    if (!rgba || !side_ok(w) || !side_ok(h) || stride < (size_t)w * 4 || stride > INT_MAX)
        return drv_frame_fail(err, errlen, DRV_FRAME_ERR_BAD_SIZE, "JPEG decode: no room for %dx%d (stride %zu)", w,
                              h, stride);
    if (!jpeg || len == 0) return drv_frame_fail(err, errlen, DRV_FRAME_ERR_BAD_FORMAT, "JPEG decode: no data");
    int jw = 0, jh = 0, jsub, jcs; /* 2.1 returns 0 for a tables-only stream without setting them */
    /* The header alone first: a JPEG declaring another size is refused before a pixel is decoded (tjDecompress2
     * would otherwise scale it, or write a bigger picture than the caller's plane). */
    if (tjDecompressHeader3(j->tj, jpeg, (unsigned long)len, &jw, &jh, &jsub, &jcs) != 0) {
        drv_frame_err e = drv_frame_fail(err, errlen, DRV_FRAME_ERR_BAD_FORMAT, "JPEG header (%zu bytes): %s", len,
                                         tjGetErrorStr2(j->tj));
        reset_decoder(j);
        return e;
    }
    if (jw < 1 || jh < 1) /* a stream of tables only, or one cut before its frame header */
        return drv_frame_fail(err, errlen, DRV_FRAME_ERR_BAD_FORMAT, "JPEG (%zu bytes) declares no picture", len);
    if (jw != w || jh != h)
        return drv_frame_fail(err, errlen, DRV_FRAME_ERR_BAD_SIZE, "JPEG is %dx%d, the slice is %dx%d", jw, jh, w, h);
    /* RGBA: libturbojpeg writes 0xFF into the fourth byte when decompressing, so alpha needs no pass of its own. */
    if (tjDecompress2(j->tj, jpeg, (unsigned long)len, rgba, w, (int)stride, h, TJPF_RGBA, DEC_FLAGS) != 0)
        return drv_frame_fail(err, errlen, DRV_FRAME_ERR_BAD_FORMAT, "JPEG %dx%d (%zu bytes): %s%s", w, h, len,
                              tjGetErrorCode(j->tj) == TJERR_WARNING ? "corrupt data: " : "",
                              tjGetErrorStr2(j->tj));
    return DRV_FRAME_OK;
}
