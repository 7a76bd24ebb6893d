/* SPDX-License-Identifier: MIT */
/* plat_workers: the CPU backend's thread pool. The calling thread takes part in every job and claims tasks from a
 * shared counter, so the vsync thread never waits for a worker to start: at worst for one task it already claimed. */
#ifndef PLAT_WORKERS_H
#define PLAT_WORKERS_H

#include <stdbool.h>
#include <stdint.h>

typedef void (*plat_task_fn)(void *ctx, int task);

typedef struct plat_workers plat_workers;

/* Starts `extra` worker threads (0 = the caller works alone). realtime_prio > 0 asks for SCHED_FIFO (ignored when
 * not permitted). Returns NULL when threads cannot be created. */
plat_workers *plat_workers_create(int extra, int realtime_prio);
/* Runs fn(ctx, 0..ntasks-1) across the caller and the workers and returns when all tasks are done. Allocation-
 * and lock-free; one job at a time (call it from one thread). */
void plat_workers_run(plat_workers *w, int ntasks, plat_task_fn fn, void *ctx);
int plat_workers_threads(const plat_workers *w); /* caller included */
/* How long, in all, the caller has waited for a worker's task beyond twice its own tasks' length: time a worker
 * spent off its CPU, as far as the caller can tell (a miss's cause: the caller spins, and that is CPU time). */
int64_t plat_workers_stalled_ns(const plat_workers *w);
/* Tasks run by the extra threads since creation (shows whether they actually help). */
long plat_workers_helped(const plat_workers *w);
void plat_workers_destroy(plat_workers *w);

#endif
