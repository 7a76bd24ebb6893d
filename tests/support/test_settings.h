/* SPDX-License-Identifier: MIT */
/* test_settings: the key=value settings a test runs hmdwarpd's configuration with, each required to apply and the
 * result to validate: one set of helpers instead of a loop per test program; a failure names what was refused. */
#ifndef TEST_SETTINGS_H
#define TEST_SETTINGS_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <cmocka.h>

#include "runtime/rt_config.h"

/* Applies sets[0..n) to c, on top of what it holds. */
static inline void test_set_all(rt_config *c, const char *const *sets, size_t n)
{
    rt_config_errors e = {0};
    for (size_t i = 0; i < n; i++)
        if (!rt_config_set(c, sets[i], &e)) fail_msg("%s: %s", sets[i], e.msg[0]);
}

/* One setting built from a format ("warp.method=%s"). */
static inline void test_setf(rt_config *c, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static inline void test_setf(rt_config *c, const char *fmt, ...)
{
    char kv[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(kv, sizeof kv, fmt, ap);
    va_end(ap);
    const char *sets[] = {kv};
    test_set_all(c, sets, 1);
}

static inline void test_validate(const rt_config *c)
{
    rt_config_errors e = {0};
    if (!rt_config_validate(c, &e)) fail_msg("config: %s", e.msg[0]);
}

#endif
