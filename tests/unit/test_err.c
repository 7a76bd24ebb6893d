/* SPDX-License-Identifier: MIT */
/* warp_err, the one error-message helper every layer uses: returns false, fills the caller's buffer, cuts long
 * messages to fit, takes no buffer at all, and keeps errno for the caller. */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>
#include <cmocka.h>

#include "warp/warp_err.h"

static bool open_thing(const char *path, char *err, int errlen)
{
    errno = ENOENT;
    return warp_err(err, errlen, "cannot open %s: %s", path, strerror(errno));
}

static void test_formats_and_returns_false(void **state)
{
    (void)state;
    char err[64] = "stale";
    assert_false(open_thing("/dev/x", err, sizeof err));
    assert_string_equal(err, "cannot open /dev/x: No such file or directory");
    assert_int_equal(errno, ENOENT);
}

static void test_truncates(void **state)
{
    (void)state;
    char err[8];
    memset(err, 'x', sizeof err);
    assert_false(warp_err(err, sizeof err, "%s", "a message longer than the buffer"));
    assert_int_equal(strlen(err), sizeof err - 1);
    assert_string_equal(err, "a messa");
    char one[1] = {'x'};
    assert_false(warp_err(one, 1, "anything"));
    assert_int_equal(one[0], 0);
}

static void test_no_buffer(void **state)
{
    (void)state;
    char err[4] = "abc";
    assert_false(warp_err(NULL, 64, "nobody reads %d", 1));
    assert_false(warp_err(err, 0, "no room"));
    assert_string_equal(err, "abc"); /* errlen 0: untouched */
    assert_false(warp_err(err, -1, "no room"));
    assert_string_equal(err, "abc");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_formats_and_returns_false),
        cmocka_unit_test(test_truncates),
        cmocka_unit_test(test_no_buffer),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
