/* SPDX-License-Identifier: MIT */
/* plat_workers: the CPU backend's thread pool. The calling thread takes part in every job and claims tasks from a
 * shared counter, so the vsync thread never waits for a worker to start: at worst for one task it already claimed. */
#include "platform/plat_workers.h"

#include <linux/futex.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>
#include <sys/syscall.h>
#include <unistd.h>

#include "platform/plat_clock.h"

#define MAX_EXTRA 16
#define CLOSED 0xffffffffu /* task index of a claim word whose job is being set up */

struct plat_workers {
    /* Job: generation in the high 32 bits, next unclaimed task in the low 32. A worker claims with a CAS that
     * also checks the generation, so a late worker can never run a task of a newer job with an older fn. */
    _Atomic uint64_t claim;
    _Atomic(plat_task_fn) fn;
    _Atomic(void *) ctx;
    _Atomic int ntasks;
    _Atomic int done;
    _Atomic uint32_t wake; /* futex word: bumped for every job and for shutdown */
    _Atomic int quit;
    _Atomic long helped;
    uint32_t gen;
    int64_t stalled_ns; /* plat_workers_stalled_ns; the caller's alone */
    int extra;
    int prio;
    pthread_t th[MAX_EXTRA];
};

static void futex_wait(_Atomic uint32_t *addr, uint32_t seen)
{
    syscall(SYS_futex, (uint32_t *)addr, FUTEX_WAIT_PRIVATE, seen, NULL, NULL, 0);
}

static void futex_wake_all(_Atomic uint32_t *addr)
{
    syscall(SYS_futex, (uint32_t *)addr, FUTEX_WAKE_PRIVATE, INT32_MAX, NULL, NULL, 0);
}

/* Claims and runs tasks of generation `gen` until none is left; returns how many it ran. */
static int drain(plat_workers *w, uint32_t gen)
{
    int ran = 0;
    for (;;) {
        uint64_t c = atomic_load_explicit(&w->claim, memory_order_acquire);
        if ((uint32_t)(c >> 32) != gen) return ran;
        /* acquire: seeing the next job's fn/ctx/ntasks means seeing the CLOSED claim word stored before them, so
         * the CAS below then fails (on aarch64 too, where relaxed stores may become visible out of order) */
        plat_task_fn fn = atomic_load_explicit(&w->fn, memory_order_acquire);
        void *ctx = atomic_load_explicit(&w->ctx, memory_order_acquire);
        int n = atomic_load_explicit(&w->ntasks, memory_order_acquire);
        uint32_t task = (uint32_t)c;
        if (task >= (uint32_t)n) return ran; /* all claimed, or CLOSED while the next job is set up */
        if (!atomic_compare_exchange_weak_explicit(&w->claim, &c, c + 1, memory_order_acq_rel, memory_order_acquire))
            continue;
        fn(ctx, (int)task);
        ran++;
        atomic_fetch_add_explicit(&w->done, 1, memory_order_release);
    }
}

static void *worker_main(void *arg)
{
    plat_workers *w = arg;
    plat_thread_set_name("hmdwarp-work");
    if (w->prio > 0) plat_thread_set_realtime(w->prio);
    uint32_t seen = atomic_load(&w->wake);
    for (;;) {
        /* quit is checked too: a pool destroyed before this thread first read `wake` bumped it already. */
        while (!atomic_load(&w->quit) && atomic_load_explicit(&w->wake, memory_order_acquire) == seen)
            futex_wait(&w->wake, seen);
        seen = atomic_load_explicit(&w->wake, memory_order_acquire);
        if (atomic_load(&w->quit)) return NULL;
        uint64_t c = atomic_load_explicit(&w->claim, memory_order_acquire);
        int ran = drain(w, (uint32_t)(c >> 32));
        if (ran) atomic_fetch_add_explicit(&w->helped, ran, memory_order_relaxed);
    }
}

plat_workers *plat_workers_create(int extra, int realtime_prio)
{
    if (extra < 0) extra = 0;
    if (extra > MAX_EXTRA) extra = MAX_EXTRA;
    plat_workers *w = calloc(1, sizeof *w);
    if (!w) return NULL;
    w->prio = realtime_prio;
    for (int i = 0; i < extra; i++) {
        if (pthread_create(&w->th[i], NULL, worker_main, w) != 0) {
            w->extra = i;
            plat_workers_destroy(w);
            return NULL;
        }
        w->extra = i + 1;
    }
    return w;
}

void plat_workers_run(plat_workers *w, int ntasks, plat_task_fn fn, void *ctx)
{
    if (ntasks <= 0) return;
    uint32_t gen = ++w->gen;
    /* Close the claim word first, under the new generation: a worker still in drain() for the previous job may
     * have read the old word, then this job's fn/ctx/ntasks; its CAS on the old word must fail now, or it would run
     * a task of this job that is claimed again below (twice), and count it in `done` (the caller would return
     * early). test_handoff's every-task-once test caught that under ASan. */
    atomic_store_explicit(&w->claim, (uint64_t)gen << 32 | CLOSED, memory_order_seq_cst);
    atomic_store_explicit(&w->fn, fn, memory_order_release);
    atomic_store_explicit(&w->ctx, ctx, memory_order_release);
    atomic_store_explicit(&w->ntasks, ntasks, memory_order_release);
    atomic_store_explicit(&w->done, 0, memory_order_relaxed);
    atomic_store_explicit(&w->claim, (uint64_t)gen << 32, memory_order_release);
    if (w->extra) {
        atomic_fetch_add_explicit(&w->wake, 1, memory_order_release);
        futex_wake_all(&w->wake);
    }
    const int64_t t0 = plat_now_ns();
    const int mine = drain(w, gen);
    /* Everything is claimed; wait only for tasks a worker is still finishing (bounded by one task). */
    if (atomic_load_explicit(&w->done, memory_order_acquire) >= ntasks) return;
    const int64_t t1 = plat_now_ns();
    while (atomic_load_explicit(&w->done, memory_order_acquire) < ntasks) {
#if defined(__x86_64__) || defined(__i386__)
        __builtin_ia32_pause();
#elif defined(__aarch64__)
        __asm__ volatile("yield");
#endif
    }
    /* Waiting longer than twice the caller's own tasks took on average means a worker was kept off its CPU mid-
     * task: the tasks of one job are alike (tiles, bands, eyes). With none of its own to compare, it cannot tell. */
    const int64_t waited = plat_now_ns() - t1, expected = mine ? 2 * (t1 - t0) / mine : waited;
    if (waited > expected) w->stalled_ns += waited - expected;
}

int64_t plat_workers_stalled_ns(const plat_workers *w) { return w->stalled_ns; }

int plat_workers_threads(const plat_workers *w) { return w->extra + 1; }

long plat_workers_helped(const plat_workers *w) { return atomic_load(&((plat_workers *)w)->helped); }

void plat_workers_destroy(plat_workers *w)
{
    if (!w) return;
    atomic_store(&w->quit, 1);
    atomic_fetch_add(&w->wake, 1);
    futex_wake_all(&w->wake);
    for (int i = 0; i < w->extra; i++) pthread_join(w->th[i], NULL);
    free(w);
}
