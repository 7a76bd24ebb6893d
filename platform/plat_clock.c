/* SPDX-License-Identifier: MIT */
/* plat_clock: the one time base of hmdwarp (CLOCK_MONOTONIC in int64 nanoseconds), absolute sleeps, and thread
 * set-up for the real-time path (SCHED_FIFO priority, CPU affinity, locked memory) where the system allows it. */
#include "platform/plat_clock.h"

#include <errno.h>
#include <pthread.h>
#include <sched.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>

int64_t plat_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * PLAT_NS_PER_S + ts.tv_nsec;
}

void plat_sleep_until_ns(int64_t t_ns)
{
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
    return (int64_t)ts.tv_sec * PLAT_NS_PER_S + ts.tv_nsec;
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
