/* SPDX-License-Identifier: MIT */
/* warp_err: the one way every layer reports an error to its caller: a message into the caller's buffer naming what
 * was wrong, printf-checked, cut to fit (the convention is in warp_err.h). */
#include "warp/warp_err.h"

#include <errno.h>
#include <stdio.h>

bool warp_verr(char *err, int errlen, const char *fmt, va_list ap)
{
    if (!err || errlen <= 0) return false;
    int saved = errno; /* callers format strerror(errno) and may look at errno again afterwards */
    if (vsnprintf(err, (size_t)errlen, fmt, ap) < 0) err[0] = 0;
    errno = saved;
    return false;
}

bool warp_err(char *err, int errlen, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    warp_verr(err, errlen, fmt, ap);
    va_end(ap);
    return false;
}
