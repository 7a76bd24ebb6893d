/* SPDX-License-Identifier: MIT */
/* plat_clock: the one time base of hmdwarp (CLOCK_MONOTONIC in int64 nanoseconds), absolute sleeps, and thread
 * set-up for the real-time path (SCHED_FIFO priority, CPU affinity, locked memory) where the system allows it. */
#ifndef PLAT_CLOCK_H
#define PLAT_CLOCK_H

#include <pthread.h>
#include <stdbool.h>
#include <stdint.h>
#include <time.h>

#define PLAT_NS_PER_MS 1000000LL
#define PLAT_NS_PER_S 1000000000LL

/* Virtual time, for emulators: with a slow-down factor N > 1 the time every part of hmdwarp reads and sleeps on
 * (plat_now_ns, plat_sleep_*, plat_thread_cpu_ns, plat_timeout_ms) is CLOCK_MONOTONIC / N: the simulated board
 * (sim vsync, IMU, host, the mocks) and the compositor all run N times slower than real time, so a test under
 * qemu-user, 10-50x slower than the machine, keeps the pace its logic assumes. N comes from the environment
 * (HMDWARP_TIME_SLOWDOWN, read at start, so the programs a test starts follow it) or plat_clock_set_slowdown.
 * Only simulated and mocked devices follow it: a kernel's timestamps (GPIO edges, V4L2 buffers, KMS vblanks) are
 * real time, so hmdwarpd refuses a slow-down on a board with real devices. 1 (the default) is real time. */
#define PLAT_CLOCK_SLOWDOWN_MAX 1000
int plat_clock_slowdown(void);
/* Sets N (1..PLAT_CLOCK_SLOWDOWN_MAX) for this process and the programs it starts; call it before any thread or
 * device exists. False (nothing changed) when out of range. */
bool plat_clock_set_slowdown(int n);

int64_t plat_now_ns(void);
/* Sleeps until the absolute time t_ns (returns at once if it has passed). */
void plat_sleep_until_ns(int64_t t_ns);
void plat_sleep_ns(int64_t ns);
/* CPU time consumed by the calling thread, ns (for per-thread load figures). */
int64_t plat_thread_cpu_ns(void);
/* The real time a wait of `ms` takes (poll() and the like count real milliseconds); -1 stays -1. */
int plat_timeout_ms(int ms);
/* CLOCK_MONOTONIC whatever the slow-down: for caps that guard against hangs, which count real seconds. */
int64_t plat_real_now_ns(void);

/* Initialises c so that pthread_cond_timedwait's deadlines are CLOCK_MONOTONIC times (a wall-clock step does not
 * shorten or stretch a wait). */
void plat_cond_init_monotonic(pthread_cond_t *c);
/* The CLOCK_MONOTONIC time ms milliseconds from now (real time, whatever the slow-down): the deadline of a wait of ms
 * on such a condition variable. */
struct timespec plat_deadline_after_ms(int ms);

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
