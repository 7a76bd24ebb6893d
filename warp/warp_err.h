/* SPDX-License-Identifier: MIT */
/* warp_err: the one way every layer reports an error to its caller: a message into the caller's buffer naming what
 * was wrong, printf-checked, cut to fit; the lowest layer's so drivers/, platform/, sim/, warp/ and tools/ share it.
 *
 * The convention: a function that can fail takes (char *err, int errlen) last and returns false / NULL / -1 (or its
 * module's error enum, e.g. drv_frame_err, drv_hid_err, which keep their codes and fill the text with warp_verr).
 * The message names the object and what was wrong ("HID IMU /dev/hidraw0: ..."); the caller adds context in front.
 * err may be NULL or errlen 0 when the caller wants no text. It only formats into the caller's buffer (vsnprintf: no
 * allocation, no lock, no I/O), so a failure on the vsync path (a page flip refused) may report through it too. */
#ifndef WARP_ERR_H
#define WARP_ERR_H

#include <stdarg.h>
#include <stdbool.h>

/* Formats into err[errlen] (truncated, always terminated when errlen > 0) and returns false, so a failure path
 * reads `return warp_err(err, errlen, "cannot open %s: %s", path, strerror(errno));`. errno is kept. */
bool warp_err(char *err, int errlen, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
bool warp_verr(char *err, int errlen, const char *fmt, va_list ap) __attribute__((format(printf, 3, 0)));

#endif
