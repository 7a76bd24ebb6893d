/* SPDX-License-Identifier: MIT */
/* LeakSanitizer's built-in suppressions for every test binary (make asan): leaks inside libraries we link but do
 * not own, each named with why, so make asan still fails on ours. Unused outside ASan builds. */

const char *__lsan_default_suppressions(void);

/* libx265 3.5 (Debian 12) keeps x265_malloc'd blocks past x265_encoder_close (FrameFilter::init and the encoder's
 * frame pools: ~1 KB an encoder, more once it has encoded), whatever the parameters: drv_codec_video's HEVC encoder
 * frees everything libavcodec hands back. */
const char *__lsan_default_suppressions(void) { return "leak:libx265.so\n"; }
