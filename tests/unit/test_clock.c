/* SPDX-License-Identifier: MIT */
/* plat_clock's virtual time: with a slow-down N, now, sleeps, CPU time and poll timeouts are CLOCK_MONOTONIC's / N
 * (exactly and monotonically), N is refused outside 1..1000, and the programs a test starts inherit it. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>

#include "platform/plat_clock.h"

static void test_real_time_by_default(void **state)
{
    (void)state;
    if (getenv("HMDWARP_TIME_SLOWDOWN")) skip(); /* a run that chose one */
    assert_int_equal(plat_clock_slowdown(), 1);
    int64_t r0 = plat_real_now_ns(), v = plat_now_ns(), r1 = plat_real_now_ns();
    assert_true(r0 <= v && v <= r1);
    assert_int_equal(plat_timeout_ms(20), 20);
}

static void test_slowdown(void **state)
{
    (void)state;
    assert_false(plat_clock_set_slowdown(0));
    assert_false(plat_clock_set_slowdown(PLAT_CLOCK_SLOWDOWN_MAX + 1));
    assert_true(plat_clock_set_slowdown(4));
    assert_int_equal(plat_clock_slowdown(), 4);
    assert_string_equal(getenv("HMDWARP_TIME_SLOWDOWN"), "4"); /* what a started program reads */
    int64_t r0 = plat_real_now_ns(), v = plat_now_ns(), r1 = plat_real_now_ns();
    assert_true(r0 / 4 <= v && v <= r1 / 4);
    /* a virtual millisecond's sleep lasts four real ones: woken no earlier than 4 x the virtual deadline */
    int64_t due = plat_now_ns() + 1000000;
    plat_sleep_until_ns(due);
    assert_true(plat_real_now_ns() >= due * 4);
    assert_true(plat_now_ns() >= due);
    assert_int_equal(plat_timeout_ms(20), 80);
    assert_int_equal(plat_timeout_ms(0), 0);
    assert_int_equal(plat_timeout_ms(-1), -1);
    assert_int_equal(plat_timeout_ms(INT_MAX / 2), INT_MAX);
    /* CPU time runs slower too: spin until a virtual millisecond of it has passed, then compare with the real one */
    int64_t c0 = plat_thread_cpu_ns();
    while (plat_thread_cpu_ns() - c0 < 1000000) {
    }
    assert_true(plat_clock_set_slowdown(1));
    assert_int_equal(plat_clock_slowdown(), 1);
    assert_true(plat_thread_cpu_ns() >= 4 * (c0 + 1000000) - 4);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_real_time_by_default),
        cmocka_unit_test(test_slowdown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
