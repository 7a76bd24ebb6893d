/* SPDX-License-Identifier: MIT */
/* plat_clock: the one time base of hmdwarp (CLOCK_MONOTONIC in int64 nanoseconds), absolute sleeps, and thread
 * set-up for the real-time path (SCHED_FIFO priority, CPU affinity, locked memory) where the system allows it. */
#include "platform/plat_clock.h"

#include <errno.h>
#include <limits.h>
#include <pthread.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>

/* Set once before any thread runs (the constructor below, or a test's main): plain reads after that. An integer
 * divisor keeps virtual time exact and monotonic, and N = 1 costs one compare on the vsync path. */
static int slowdown = 1;

#define SLOWDOWN_ENV "HMDWARP_TIME_SLOWDOWN"

__attribute__((constructor)) static void slowdown_from_env(void)
{
    const char *v = getenv(SLOWDOWN_ENV);
    if (!v || !*v) return;
    char *end;
    errno = 0;
    long n = strtol(v, &end, 10);
    if (errno || *end || n < 1 || n > PLAT_CLOCK_SLOWDOWN_MAX) {
        fprintf(stderr, "%s=%s: not a whole number from 1 to %d; running in real time\n", SLOWDOWN_ENV, v,
                PLAT_CLOCK_SLOWDOWN_MAX);
        return;
    }
    slowdown = (int)n;
}

int plat_clock_slowdown(void) { return slowdown; }

bool plat_clock_set_slowdown(int n)
{
    if (n < 1 || n > PLAT_CLOCK_SLOWDOWN_MAX) return false;
    char v[16];
    snprintf(v, sizeof v, "%d", n);
    if (setenv(SLOWDOWN_ENV, v, 1) != 0) return false;
    slowdown = n;
    return true;
}

void plat_cond_init_monotonic(pthread_cond_t *c)
{
    pthread_condattr_t ca;
    pthread_condattr_init(&ca);
    pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
    pthread_cond_init(c, &ca);
    pthread_condattr_destroy(&ca);
}

struct timespec plat_deadline_after_ms(int ms)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    int64_t ns = ts.tv_nsec + (int64_t)ms * PLAT_NS_PER_MS;
    ts.tv_sec += (time_t)(ns / PLAT_NS_PER_S);
    ts.tv_nsec = (long)(ns % PLAT_NS_PER_S);
    return ts;
}

int64_t plat_real_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * PLAT_NS_PER_S + ts.tv_nsec;
}

int64_t plat_now_ns(void)
{
    int64_t t = plat_real_now_ns();
    return slowdown == 1 ? t : t / slowdown;
}

int plat_timeout_ms(int ms)
{
    if (ms <= 0 || slowdown == 1) return ms;
    return ms > INT_MAX / slowdown ? INT_MAX : ms * slowdown;
}

void plat_sleep_until_ns(int64_t t_ns)
{
    if (slowdown != 1) t_ns = t_ns > INT64_MAX / slowdown ? INT64_MAX : t_ns * slowdown;
    struct timespec ts = {(time_t)(t_ns / PLAT_NS_PER_S), (long)(t_ns % PLAT_NS_PER_S)};
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR) {
    }
}

void plat_sleep_ns(int64_t ns)
{
    if (ns > 0) plat_sleep_until_ns(plat_now_ns() + ns);
}

int64_t plat_thread_cpu_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    int64_t t = (int64_t)ts.tv_sec * PLAT_NS_PER_S + ts.tv_nsec;
    return slowdown == 1 ? t : t / slowdown;
}

bool plat_thread_set_realtime(int prio)
{
    struct sched_param sp;
    memset(&sp, 0, sizeof sp);
    sp.sched_priority = prio;
    return pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp) == 0;
}

bool plat_thread_set_idle(void)
{
    struct sched_param sp;
    memset(&sp, 0, sizeof sp);
    return pthread_setschedparam(pthread_self(), SCHED_IDLE, &sp) == 0;
}

bool plat_lock_memory(void) { return mlockall(MCL_CURRENT | MCL_FUTURE) == 0; }

void plat_thread_set_name(const char *name)
{
    char n[16];
    strncpy(n, name, sizeof n - 1);
    n[sizeof n - 1] = 0;
    pthread_setname_np(pthread_self(), n);
}
