/* SPDX-License-Identifier: MIT */
/* drv_vsync_est: estimates the panel's vsync period and phase from TE-line edge timestamps, robust to jitter, missed
 * and spurious edges and a panel slightly off its nominal rate. Pure and deterministic: no OS calls, no allocation.
 *
 * Locked, it keeps a least-squares line through the last accepted edges (time against vsync index): the slope is
 * the true period, whatever the nominal rate says, and missed edges simply leave holes in the index. A new edge is
 * assigned to the nearest predicted vsync and accepted only within a gate around it; anything else is a glitch.
 * Unlocked (at start, or when the panel's phase jumped and edges keep falling outside the gate), it searches the
 * recent unexplained edges for the period near nominal and the phase that explain most of them. */
#include "drivers/drv_vsync_est.h"

#include <math.h>
#include <string.h>

#define MIN_GATE_NS 500e3 /* TE edges jitter by IRQ latency; below this gate real panels lose edges */
#define ACQ_GATE_NS 1e6   /* acquisition: an edge explains a candidate when this close to one of its vsyncs */
#define MAX_GATE_FRAC 0.35

void drv_vsync_est_init(drv_vsync_est *e, double nominal_hz)
{
    memset(e, 0, sizeof *e);
    /* A nonsensical rate leaves the estimator unable to lock rather than locking onto anything. */
    e->nominal_ns = (nominal_hz > 1.0 && nominal_hz < 10000.0) ? 1e9 / nominal_hz : 0.0;
    e->last_edge_ns = INT64_MIN;
    e->last_accept_ns = INT64_MIN;
}

bool drv_vsync_est_locked(const drv_vsync_est *e) { return e->locked; }
int drv_vsync_est_last_gap(const drv_vsync_est *e) { return e->last_gap; }
double drv_vsync_est_jitter_us(const drv_vsync_est *e) { return e->locked ? e->rms_ns * 1e-3 : 0.0; }
const drv_vsync_est_counters *drv_vsync_est_counters_get(const drv_vsync_est *e) { return &e->c; }

const char *drv_vsync_edge_kind_name(drv_vsync_edge_kind k)
{
    switch (k) {
    case DRV_VSYNC_EDGE_ACCEPTED: return "accepted";
    case DRV_VSYNC_EDGE_AFTER_GAP: return "after-gap";
    case DRV_VSYNC_EDGE_SPURIOUS: return "spurious";
    case DRV_VSYNC_EDGE_ACQUIRING: return "acquiring";
    case DRV_VSYNC_EDGE_LOCKED: return "locked";
    }
    return "?";
}

int64_t drv_vsync_model_next(const drv_vsync_model *m, int64_t after_ns, int64_t *period_ns)
{
    if (period_ns) *period_ns = llround(m->period_ns);
    if (!(m->period_ns > 0)) return 0;
    double x = (double)(after_ns - m->ref_ns) / m->period_ns;
    int64_t k = (int64_t)floor(x) + 1;
    int64_t t = m->ref_ns + llround((double)k * m->period_ns);
    /* Rounding can put the candidate one vsync off either way; settle on the first strictly after. */
    while (t <= after_ns) t = m->ref_ns + llround((double)++k * m->period_ns);
    for (;;) {
        int64_t prev = m->ref_ns + llround((double)(k - 1) * m->period_ns);
        if (prev <= after_ns) break;
        k--;
        t = prev;
    }
    return t;
}

int64_t drv_vsync_est_next(const drv_vsync_est *e, int64_t after_ns, int64_t *period_ns)
{
    if (!e->locked) {
        if (period_ns) *period_ns = llround(e->nominal_ns);
        return 0;
    }
    return drv_vsync_model_next(&e->model, after_ns, period_ns);
}

bool drv_vsync_est_model(const drv_vsync_est *e, drv_vsync_model *m)
{
    if (!e->locked) return false;
    *m = e->model;
    return true;
}

static bool period_plausible(const drv_vsync_est *e, double p)
{
    return fabs(p - e->nominal_ns) <= DRV_VSYNC_EST_MAX_DEV * e->nominal_ns;
}

static int win_idx(const drv_vsync_est *e, int i) /* i = 0 oldest .. win_n-1 newest */
{
    return (e->win_head - e->win_n + i + 2 * DRV_VSYNC_EST_WINDOW) % DRV_VSYNC_EST_WINDOW;
}

static void win_push(drv_vsync_est *e, int64_t k, int64_t t)
{
    e->win_k[e->win_head] = k;
    e->win_t[e->win_head] = t;
    e->win_head = (e->win_head + 1) % DRV_VSYNC_EST_WINDOW;
    if (e->win_n < DRV_VSYNC_EST_WINDOW) e->win_n++;
}

/* Least-squares line through the window, relative to its newest point so the sums stay small. With one point the
 * period stays what it was (nominal at first). */
static void refit(drv_vsync_est *e, double period_if_single)
{
    int newest = win_idx(e, e->win_n - 1);
    int64_t ka = e->win_k[newest], ta = e->win_t[newest];
    double n = e->win_n, sx = 0, sy = 0;
    for (int i = 0; i < e->win_n; i++) {
        int j = win_idx(e, i);
        sx += (double)(e->win_k[j] - ka);
        sy += (double)(e->win_t[j] - ta);
    }
    double xm = sx / n, ym = sy / n, sxx = 0, sxy = 0;
    for (int i = 0; i < e->win_n; i++) {
        int j = win_idx(e, i);
        double dx = (double)(e->win_k[j] - ka) - xm, dy = (double)(e->win_t[j] - ta) - ym;
        sxx += dx * dx;
        sxy += dx * dy;
    }
    double b = sxx > 0 ? sxy / sxx : period_if_single;
    double a = ym - b * xm; /* fitted time of the newest point, relative to it */
    double ssr = 0;
    for (int i = 0; i < e->win_n; i++) {
        int j = win_idx(e, i);
        double r = (double)(e->win_t[j] - ta) - (a + b * (double)(e->win_k[j] - ka));
        ssr += r * r;
    }
    e->rms_ns = e->win_n > 2 ? sqrt(ssr / (n - 2)) : 0.0;
    e->slope_se_ns = sxx > 0 ? e->rms_ns / sqrt(sxx) : 0.0;
    e->base_k = ka;
    e->model.ref_ns = ta + llround(a);
    e->model.period_ns = b;
}

/* Searches the unexplained edges for the period (within +-10 % of nominal) and phase that explain most of them:
 * every pair of edges and every whole number of periods between them is a candidate. Locks when enough edges,
 * most of those seen and most of the vsyncs they span, agree. */
static bool acquire(drv_vsync_est *e)
{
    const int64_t *raw = e->raw;
    int m = e->raw_n, best_inl = 0;
    double best_cost = INFINITY, best_p = 0;
    int64_t best_t = 0;
    for (int i = 0; i < m; i++) {
        for (int j = i + 1; j < m; j++) {
            double d = (double)(raw[j] - raw[i]);
            int64_t nlo = (int64_t)ceil(d / (e->nominal_ns * (1 + DRV_VSYNC_EST_MAX_DEV)));
            int64_t nhi = (int64_t)floor(d / (e->nominal_ns * (1 - DRV_VSYNC_EST_MAX_DEV)));
            if (nlo < 1) nlo = 1;
            for (int64_t n = nlo; n <= nhi && n <= 4 * DRV_VSYNC_EST_RAW; n++) {
                double p = d / (double)n, cost = 0;
                int inl = 0;
                int64_t last_slot = INT64_MIN;
                for (int q = 0; q < m; q++) {
                    double y = (double)(raw[q] - raw[i]);
                    int64_t s = llround(y / p);
                    double r = fabs(y - (double)s * p);
                    if (r < ACQ_GATE_NS && s != last_slot) {
                        inl++;
                        cost += r;
                        last_slot = s;
                    }
                }
                if (inl > best_inl || (inl == best_inl && cost < best_cost)) {
                    best_inl = inl;
                    best_cost = cost;
                    best_p = p;
                    best_t = raw[i];
                }
            }
        }
    }
    if (best_inl < DRV_VSYNC_EST_ACQUIRE || best_inl * 10 < m * 6) return false;

    /* The candidate's edges, the closest one per vsync, as the new fit window. */
    int64_t ks[DRV_VSYNC_EST_RAW], ts[DRV_VSYNC_EST_RAW];
    double rs[DRV_VSYNC_EST_RAW];
    int n = 0;
    for (int q = 0; q < m; q++) {
        double y = (double)(raw[q] - best_t);
        int64_t s = llround(y / best_p);
        double r = fabs(y - (double)s * best_p);
        if (r >= ACQ_GATE_NS) continue;
        if (n > 0 && ks[n - 1] == s) {
            if (r < rs[n - 1]) ts[n - 1] = raw[q], rs[n - 1] = r;
            continue;
        }
        ks[n] = s, ts[n] = raw[q], rs[n] = r;
        n++;
    }
    /* Edges at every other vsync of a candidate are a panel at half the rate, not a lossy line at this one. */
    if (n < DRV_VSYNC_EST_ACQUIRE || (double)n < 0.6 * (double)(ks[n - 1] - ks[0] + 1)) return false;

    drv_vsync_est trial = *e;
    trial.win_n = trial.win_head = 0;
    for (int q = 0; q < n; q++) win_push(&trial, ks[q], ts[q]);
    refit(&trial, best_p);
    if (!period_plausible(&trial, trial.model.period_ns)) return false;
    *e = trial;
    e->locked = true;
    e->last_acc_k = e->base_k;
    e->held_n = 0;
    e->last_accept_ns = ts[n - 1];
    e->last_gap = 0;
    e->c.locks++;
    e->c.accepted += (uint64_t)n;
    e->raw_n = 0;
    return true;
}

static void hold(drv_vsync_est *e, int64_t k, int64_t t, int sign)
{
    e->held_k[e->held_n] = k;
    e->held_t[e->held_n++] = t;
    e->held_sign = sign;
}

static void flush_held(drv_vsync_est *e)
{
    for (int i = 0; i < e->held_n; i++) win_push(e, e->held_k[i], e->held_t[i]);
    e->held_n = 0;
}

static void raw_push(drv_vsync_est *e, int64_t t)
{
    if (e->raw_n == DRV_VSYNC_EST_RAW) {
        memmove(e->raw, e->raw + 1, sizeof e->raw[0] * (DRV_VSYNC_EST_RAW - 1));
        e->raw_n--;
    }
    e->raw[e->raw_n++] = t;
}

/* Unexplained edge: keep it for acquisition and try to (re)lock on what has accumulated. The edges a lock takes in
 * were counted as spurious while locked to the old phase; take them back. */
static drv_vsync_edge_kind unexplained(drv_vsync_est *e, int64_t t)
{
    bool was_locked = e->locked;
    raw_push(e, t);
    if (was_locked) e->c.spurious++;
    if (e->raw_n >= DRV_VSYNC_EST_ACQUIRE) {
        uint64_t before = e->c.accepted, seen = (uint64_t)e->raw_n;
        if (acquire(e)) {
            uint64_t took = e->c.accepted - before;
            if (was_locked)
                e->c.spurious -= took <= e->c.spurious ? took : e->c.spurious;
            else
                e->c.spurious += seen - took; /* the edges the first lock could not explain */
            return DRV_VSYNC_EDGE_LOCKED;
        }
    }
    return was_locked ? DRV_VSYNC_EDGE_SPURIOUS : DRV_VSYNC_EDGE_ACQUIRING;
}

drv_vsync_edge_kind drv_vsync_est_edge(drv_vsync_est *e, int64_t t)
{
    e->c.edges++;
    if (e->nominal_ns <= 0) return DRV_VSYNC_EDGE_ACQUIRING;
    if (e->last_edge_ns != INT64_MIN && t <= e->last_edge_ns) {
        /* Time going backwards is a broken source, not a vsync; it must not disturb the fit. */
        e->c.spurious++;
        return DRV_VSYNC_EDGE_SPURIOUS;
    }
    e->last_edge_ns = t;
    if (!e->locked) return unexplained(e, t);

    const drv_vsync_model *m = &e->model;
    double y = (double)(t - m->ref_ns);
    int64_t n = llround(y / m->period_ns), k = e->base_k + n;
    double r = y - (double)n * m->period_ns;
    /* The gate widens with the period's uncertainty over the vsyncs since the newest fitted edge. */
    double gate = fmax(5 * e->rms_ns, MIN_GATE_NS) + 4 * e->slope_se_ns * fabs((double)n);
    if (gate > MAX_GATE_FRAC * m->period_ns) gate = MAX_GATE_FRAC * m->period_ns;

    if (k <= e->last_acc_k) {
        /* A second edge on the newest accepted vsync: one of them is a glitch; keep the one nearer the fit. */
        if (k == e->last_acc_k && fabs(r) < gate) {
            int64_t *tp = e->held_n ? &e->held_t[e->held_n - 1] : &e->win_t[win_idx(e, e->win_n - 1)];
            double r_old = (double)(*tp - m->ref_ns) - (double)n * m->period_ns;
            if (fabs(r) < fabs(r_old)) {
                *tp = t;
                e->last_accept_ns = t;
                /* Back on the fit: what was held was not a phase shift. */
                if (e->held_n && !(fabs(r) > fmax(0.5 * gate, 3 * e->rms_ns))) flush_held(e);
                if (!e->held_n) refit(e, m->period_ns);
            }
            e->c.spurious++;
            return DRV_VSYNC_EDGE_SPURIOUS;
        }
        return unexplained(e, t);
    }
    if (!(fabs(r) < gate)) return unexplained(e, t);

    int64_t gap = k - e->last_acc_k - 1;
    e->raw_n = 0;
    e->last_accept_ns = t;
    e->last_acc_k = k;
    e->last_gap = (int)(gap < 1000000000 ? gap : 1000000000);
    e->c.accepted++;
    e->c.missed += (uint64_t)gap;
    drv_vsync_edge_kind kind = gap > 0 ? DRV_VSYNC_EDGE_AFTER_GAP : DRV_VSYNC_EDGE_ACCEPTED;

    /* A phase shift smaller than the gate: edges land far off the fit, all on one side. They stay out of the fit
     * until DRV_VSYNC_EST_RUN of them in a row prove the shift (the fit restarts from them) or one edge back on
     * the fit shows they were only jitter (they join the fit). */
    int sign = r > 0 ? 1 : -1;
    bool off = fabs(r) > fmax(0.5 * gate, 3 * e->rms_ns);
    if (off && (e->held_n == 0 || sign == e->held_sign)) {
        hold(e, k, t, sign);
        if (e->held_n < DRV_VSYNC_EST_RUN) return kind;
        e->win_n = e->win_head = 0; /* proven: the fit restarts from the held edges */
        flush_held(e);
        e->c.locks++;
    } else {
        flush_held(e); /* they were jitter after all; older than this edge, so they go in first */
        if (off)
            hold(e, k, t, sign); /* the other side: may start a run of its own */
        else
            win_push(e, k, t);
    }
    refit(e, m->period_ns);
    if (!period_plausible(e, e->model.period_ns)) {
        /* Cannot happen with gated edges; if it does, start over rather than predict from a wild period. */
        e->locked = false;
        e->win_n = e->win_head = e->held_n = 0;
        return DRV_VSYNC_EDGE_SPURIOUS;
    }
    return kind;
}
