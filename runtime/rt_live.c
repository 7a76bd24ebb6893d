/* SPDX-License-Identifier: MIT */
/* rt_live: the live view of a running hmdwarpd, once a second from the helper thread: the --stats text in one of two
 * buffers (the abort handler writes the published one), the [telemetry] live_stats file and systemd's STATUS. */
#include "runtime/rt_live.h"

#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <systemd/sd-daemon.h>

#include "platform/plat_clock.h"
#include "platform/plat_log.h"
#include "warp/warp_err.h"

/* The key=value text of one live update: the --stats set is about 3 KB. */
#define LIVE_BUF_BYTES (32 * 1024)
#define LIVE_AUTO_DIR "/run/hmdwarp"

void rt_live_reset(rt_live *l)
{
    memset(l, 0, sizeof *l);
    atomic_store(&l->pub, -1);
}

bool rt_live_alloc(rt_live *l, const char *setting, char *err, int errlen)
{
    const char *want = setting;
    if (strcmp(want, "auto") == 0)
        want = access(LIVE_AUTO_DIR, W_OK) == 0 ? LIVE_AUTO_DIR "/stats" : "";
    if (want[0]) {
        /* fail now, not first a second into the run */
        char tmp[300];
        snprintf(tmp, sizeof tmp, "%s.tmp", want);
        int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
        if (fd < 0) return warp_err(err, errlen, "[telemetry] live_stats = %s: %s", want, strerror(errno));
        close(fd);
        unlink(tmp);
        snprintf(l->path, sizeof l->path, "%s", want);
    }
    for (int i = 0; i < 2; i++) l->buf[i] = malloc(LIVE_BUF_BYTES);
    l->m2p = calloc(1, sizeof *l->m2p);
    l->age = calloc(1, sizeof *l->age);
    if (!l->buf[0] || !l->buf[1] || !l->m2p || !l->age) return warp_err(err, errlen, "out of memory");
    return true;
}

/* The key=value text into the buffer not published, then published: the abort handler may read the other one
 * at any moment. fmemopen over the fixed buffer: nothing allocated per update but the FILE. */
static size_t render(rt_live *l, rt_live_text text, void *ctx, bool live)
{
    int pub = atomic_load(&l->pub);
    int next = pub == 0 ? 1 : 0;
    FILE *f = fmemopen(l->buf[next], LIVE_BUF_BYTES, "w");
    if (!f) return 0;
    text(ctx, f, live);
    long n = ftell(f);
    fclose(f);
    if (n <= 0) return 0;
    if (n >= LIVE_BUF_BYTES) n = LIVE_BUF_BYTES - 1;
    atomic_store(&l->len[next], (size_t)n);
    atomic_store(&l->pub, next);
    return (size_t)n;
}

/* Rewritten whole and renamed into place: a reader sees the last complete second or the one before, never half. */
static bool write_file(const rt_live *l, const char *text, size_t len)
{
    char tmp[300];
    snprintf(tmp, sizeof tmp, "%s.tmp", l->path);
    int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) return false;
    size_t off = 0;
    while (off < len) {
        ssize_t w = write(fd, text + off, len - off);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) break;
        off += (size_t)w;
    }
    bool ok = off == len && close(fd) == 0;
    if (off != len) close(fd);
    if (ok && rename(tmp, l->path) == 0) return true;
    unlink(tmp);
    return false;
}

void rt_live_update(rt_live *l, const rt_telemetry *t, rt_live_text text, void *ctx, bool notify)
{
    size_t len = render(l, text, ctx, true);
    if (l->path[0] && len) {
        int pub = atomic_load(&l->pub);
        bool ok = write_file(l, l->buf[pub], len);
        if (!ok && !l->write_failed)
            plat_log(PLAT_LOG_WARNING, "[telemetry] live_stats = %s: cannot write (%s); retrying each second",
                     l->path, strerror(errno));
        if (ok && l->write_failed) plat_log(PLAT_LOG_NOTICE, "[telemetry] live_stats = %s: written again", l->path);
        l->write_failed = !ok;
    }
    int64_t now = plat_now_ns();
    uint64_t v = t->vsyncs, fr = t->frames_received, by = t->frames_bytes;
    double dt = l->prev_ns ? (double)(now - l->prev_ns) * 1e-9 : 0;
    double m2p = rt_hist_pct_since(&t->m2p_ms, l->m2p, 99);
    double age = rt_hist_pct_since(&t->frame_age_ms, l->age, 50);
    if (notify && dt > 0)
        sd_notifyf(0,
                   "STATUS=%.1f vsyncs/s, %llu vsyncs, missed %llu (own %llu, woken late %llu, descheduled %llu, "
                   "no free image %llu); last second: m2p p99 %.1f ms, frame age p50 %.1f ms; link %.1f MB/s, "
                   "%.1f frames/s",
                   (double)(v - l->prev_vsyncs) / dt, (unsigned long long)v, (unsigned long long)t->missed,
                   (unsigned long long)t->missed_by[RT_MISS_OWN], (unsigned long long)t->missed_by[RT_MISS_LATE_WAKE],
                   (unsigned long long)t->missed_by[RT_MISS_DESCHEDULED],
                   (unsigned long long)t->missed_by[RT_MISS_NO_BUFFER], m2p, age,
                   (double)(by - l->prev_bytes) / dt / (1024 * 1024), (double)(fr - l->prev_frames) / dt);
    l->prev_ns = now;
    l->prev_vsyncs = v;
    l->prev_frames = fr;
    l->prev_bytes = by;
}

void rt_live_final(rt_live *l, rt_live_text text, void *ctx)
{
    size_t len = render(l, text, ctx, false);
    if (l->path[0] && len && !write_file(l, l->buf[atomic_load(&l->pub)], len))
        plat_log(PLAT_LOG_WARNING, "[telemetry] live_stats = %s: cannot write (%s)", l->path, strerror(errno));
}

bool rt_live_write_last(rt_live *l, int fd)
{
    int pub = atomic_load(&l->pub);
    if (pub < 0 || !l->buf[pub]) return false;
    size_t len = atomic_load(&l->len[pub]), off = 0;
    while (off < len) {
        ssize_t w = write(fd, l->buf[pub] + off, len - off);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) return false;
        off += (size_t)w;
    }
    return true;
}

void rt_live_free(rt_live *l)
{
    free(l->buf[0]);
    free(l->buf[1]);
    free(l->m2p);
    free(l->age);
    memset(l, 0, sizeof *l);
}
