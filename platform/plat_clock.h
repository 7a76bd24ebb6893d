/* SPDX-License-Identifier: MIT */
/* plat_clock: the one time base of hmdwarp (CLOCK_MONOTONIC in int64 nanoseconds), absolute sleeps, and thread
 * set-up for the real-time path (SCHED_FIFO priority, CPU affinity, locked memory) where the system allows it. */
#ifndef PLAT_CLOCK_H
#define PLAT_CLOCK_H

#include <stdbool.h>
#include <stdint.h>

#define PLAT_NS_PER_MS 1000000LL
#define PLAT_NS_PER_S 1000000000LL

int64_t plat_now_ns(void);
/* Sleeps until the absolute CLOCK_MONOTONIC time t_ns (returns at once if it has passed). */
void plat_sleep_until_ns(int64_t t_ns);
void plat_sleep_ns(int64_t ns);
/* CPU time consumed by the calling thread, ns (for per-thread load figures). */
int64_t plat_thread_cpu_ns(void);

/* Gives the calling thread SCHED_FIFO priority `prio` (1..99). False when not permitted (not root, no
 * CAP_SYS_NICE, no RLIMIT_RTPRIO): the caller reports it and runs at normal priority. */
bool plat_thread_set_realtime(int prio);
/* Lowest scheduling class (SCHED_IDLE): for work that must never take CPU from the display path. */
bool plat_thread_set_idle(void);
/* Locks current and future pages in RAM (mlockall) so the vsync path never waits on a page fault. False when not
 * permitted (RLIMIT_MEMLOCK): the caller reports it. */
bool plat_lock_memory(void);
/* Names the calling thread (shows in top -H and in debuggers). */
void plat_thread_set_name(const char *name);

#endif
