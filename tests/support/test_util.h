/* SPDX-License-Identifier: MIT */
/* test_util: small helpers shared by the test programs (temporary directories, deterministic random numbers, random
 * rotations). Header-only pieces are static inline so each test binary stays self-contained. */
#ifndef TEST_UTIL_H
#define TEST_UTIL_H

#include <dirent.h>
#include <errno.h>
#include <ftw.h>
#include <libgen.h>
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "platform/plat_clock.h"
#include "warp/warp_lens.h"
#include "warp/warp_math.h"
#include "warp/warp_rand.h"

/* Prefix for the programs a test starts: the runner the test itself runs under (TEST_RUNNER, e.g.
 * qemu-aarch64-static in make check-cross) plus a space, or "". A cross-built test cannot exec a cross-built
 * program without it. */
static inline const char *test_runner(void)
{
    static char buf[256];
    const char *r = getenv("TEST_RUNNER");
    snprintf(buf, sizeof buf, "%s%s", r ? r : "", r && *r ? " " : "");
    return buf;
}

/* The build directory of a test binary at BUILD/tests/KIND/NAME (argv0) into build, and BUILD/tests/SUB, created,
 * into tmp: where the tests that run the programs find them and write their files. False when either fails. */
static inline bool test_build_dirs(const char *argv0, char *build, size_t buildlen, char *tmp, size_t tmplen,
                                   const char *sub)
{
    char t[512];
    snprintf(t, sizeof t, "%s", argv0);
    char *b = realpath(dirname(dirname(dirname(t))), NULL);
    if (!b) return false;
    int n = snprintf(build, buildlen, "%s", b);
    free(b);
    if (n < 0 || (size_t)n >= buildlen) return false;
    n = snprintf(tmp, tmplen, "%s/tests/%s", build, sub);
    if (n < 0 || (size_t)n >= tmplen) return false;
    char cmd[600];
    snprintf(cmd, sizeof cmd, "mkdir -p '%s'", tmp);
    return system(cmd) == 0;
}

/* A new empty directory /tmp/NAME.XXXXXX into dir, for a test's files and sockets (whose paths hold 107 characters:
 * hence /tmp, not the build tree). False when it cannot be made. */
static inline bool test_tmpdir_make(char *dir, size_t len, const char *name)
{
    int n = snprintf(dir, len, "/tmp/%s.XXXXXX", name);
    return n > 0 && (size_t)n < len && mkdtemp(dir) != NULL;
}

static inline int test_tmpdir_remove_one(const char *path, const struct stat *sb, int flag, struct FTW *ftw)
{
    (void)sb, (void)flag, (void)ftw;
    return remove(path);
}

/* Removes dir and everything in it (links themselves, not what they point at). True when it is gone. */
static inline bool test_tmpdir_remove(const char *dir)
{
    return nftw(dir, test_tmpdir_remove_one, 16, FTW_DEPTH | FTW_PHYS) == 0 || errno == ENOENT;
}

/* The test program's own temporary directory as a cmocka group setup and teardown: test_tmp_setup makes
 * /tmp/PROGRAM.XXXXXX (test_tmpdir_make), test_tmp() names it, test_tmp_teardown removes it with all in it. */
#define TEST_TMP_LEN 64
static inline char *test_tmp(void)
{
    static char dir[TEST_TMP_LEN];
    return dir;
}
static inline int test_tmp_setup(void **state)
{
    (void)state;
    return test_tmpdir_make(test_tmp(), TEST_TMP_LEN, program_invocation_short_name) ? 0 : -1;
}
static inline int test_tmp_teardown(void **state)
{
    (void)state;
    return test_tmpdir_remove(test_tmp()) ? 0 : -1;
}

/* Runs the shell command cmd, its output (what cmd itself redirects) into out, NUL-terminated; *status gets its exit
 * status (-1 when a signal ended it). False when it could not be started. */
static inline bool test_capture(const char *cmd, char *out, size_t cap, int *status)
{
    FILE *p = popen(cmd, "r");
    if (!p) return false;
    size_t n = fread(out, 1, cap - 1, p);
    out[n] = 0;
    int st = pclose(p);
    *status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    return true;
}

/* Runs `program args` under test_runner() with stderr into stdout, its output into out (test_capture); returns its
 * exit status, -1 when it could not be started or a signal ended it. The tests of the tools run them through this. */
static inline int test_run_program(const char *program, const char *args, char *out, size_t cap)
{
    size_t n = strlen(program) + strlen(args) + 300;
    char *cmd = malloc(n);
    if (!cmd) return -1;
    snprintf(cmd, n, "%s%s %s 2>&1", test_runner(), program, args);
    int st = -1;
    if (!test_capture(cmd, out, cap, &st)) st = -1;
    free(cmd);
    return st;
}

/* The file at path into buf, NUL-terminated; its length, 0 when it cannot be read (a status file not written yet). */
static inline size_t test_slurp(const char *path, char *buf, size_t cap)
{
    FILE *f = fopen(path, "r");
    if (!f) return 0;
    size_t n = fread(buf, 1, cap - 1, f);
    buf[n] = 0;
    fclose(f);
    return n;
}

/* The value of "key=" at a line start in key=value text (the daemons' --live and --stats files), or -1. */
static inline double test_kv(const char *text, const char *key)
{
    char pat[80];
    snprintf(pat, sizeof pat, "\n%s=", key);
    size_t n = strlen(pat);
    if (strncmp(text, pat + 1, n - 1) == 0) return strtod(text + n - 1, NULL); /* the first line */
    const char *p = strstr(text, pat);
    return p ? strtod(p + n, NULL) : -1;
}

/* A test paced by the simulated board (its vsync, IMU, host and mocks keep real time) calls this first. Under an
 * emulator (TEST_RUNNER set: make check-cross), which runs far slower than the machine, it and the programs it
 * starts then run on virtual time `slowdown` times slower than real time (plat_clock.h), so the simulated devices
 * and the compositor keep the pace the test's logic assumes and it asserts the same things. HMDWARP_TIME_SLOWDOWN
 * in the environment chooses another factor (1: real time). */
#define TEST_EMULATOR_SLOWDOWN 20
static inline void test_paced_by_sim(int slowdown)
{
    const char *r = getenv("TEST_RUNNER");
    if (r && *r && !getenv("HMDWARP_TIME_SLOWDOWN")) plat_clock_set_slowdown(slowdown);
}

/* The reference headset's lens shape (barrel k1 0.22, k2 0.24, lateral CA red 0.996 / blue 1.008) centred at
 * (cx, cy) panel pixels with the given scale. */
static inline warp_lens test_reference_lens(double cx, double cy, double scale)
{
    warp_lens l = {.model = WARP_LENS_POLY}; /* the rest zero: the even polynomial */
    const double ca[3] = {0.996, 1.0, 1.008};
    for (int c = 0; c < 3; c++) {
        l.ch[c].k[0] = ca[c];
        l.ch[c].k[1] = 0.22 * ca[c];
        l.ch[c].k[2] = 0.24 * ca[c];
        l.ch[c].k[3] = 0;
    }
    l.center_x = cx;
    l.center_y = cy;
    l.scale = scale;
    return l;
}

/* Nanoseconds this process's threads have spent runnable but waiting for a CPU (the second field of each thread's
 * /proc/self/task/TID/schedstat: the kernel's run_delay). A check on how long something took on the CPU can add
 * the growth of this to its bound: time a busy machine kept the threads off their CPUs is not the code's. Returns
 * 0 where the kernel keeps no schedstats (the bound then stays as it was). */
static inline int64_t test_run_delay_ns(void)
{
    DIR *d = opendir("/proc/self/task");
    if (!d) return 0;
    int64_t sum = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.') continue;
        char path[300];
        snprintf(path, sizeof path, "/proc/self/task/%s/schedstat", e->d_name);
        FILE *f = fopen(path, "r");
        if (!f) continue;
        unsigned long long run, wait;
        if (fscanf(f, "%llu %llu", &run, &wait) == 2) sum += (int64_t)wait;
        fclose(f);
    }
    closedir(d);
    return sum;
}

/* How busy the rest of the machine was over a stretch: test_others_mark() before it, test_others_share() after:
 * the share of all CPUs' time (/proc/stat, steal included) that other processes used, 0 (quiet) to 1 (every CPU
 * busy with something else). A check of how a run split its time can be judged only when this is small. */
typedef struct { double busy_s, self_s, wall_s; } test_others;
static inline test_others test_others_mark(void)
{
    test_others m = {0, 0, 0};
    FILE *f = fopen("/proc/stat", "r");
    unsigned long long v[8] = {0};
    if (f) {
        if (fscanf(f, "cpu %llu %llu %llu %llu %llu %llu %llu %llu", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5], &v[6],
                   &v[7]) == 8) /* user nice system idle iowait irq softirq steal */
            m.busy_s = (double)(v[0] + v[1] + v[2] + v[5] + v[6] + v[7]) / (double)sysconf(_SC_CLK_TCK);
        fclose(f);
    }
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    m.self_s = (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    m.wall_s = (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
    return m;
}
static inline double test_others_share(test_others m0)
{
    test_others m = test_others_mark();
    double cpus = (double)sysconf(_SC_NPROCESSORS_ONLN), wall = m.wall_s - m0.wall_s;
    if (wall <= 0 || cpus < 1) return 0;
    double others = (m.busy_s - m0.busy_s) - (m.self_s - m0.self_s);
    return others < 0 ? 0 : others / (wall * cpus);
}

typedef struct { uint64_t s; } test_rng;

static inline test_rng test_rng_make(uint64_t seed)
{
    test_rng r = {seed * WARP_GOLDEN64 + 1};
    return r;
}
/* splitmix64: tiny, fixed-seed reproducible across platforms */
static inline uint64_t test_rng_next(test_rng *r)
{
    return warp_mix64(r->s += WARP_GOLDEN64);
}
static inline double test_rng_uniform(test_rng *r, double lo, double hi)
{
    return lo + (hi - lo) * warp_unit53(test_rng_next(r));
}
static inline warp_quat test_random_quat(test_rng *r)
{
    warp_quat q = {test_rng_uniform(r, -1, 1), test_rng_uniform(r, -1, 1), test_rng_uniform(r, -1, 1),
                   test_rng_uniform(r, -1, 1)};
    warp_quat o;
    warp_quat_normalize(q, &o);
    return o;
}

#endif
