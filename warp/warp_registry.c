/* SPDX-License-Identifier: MIT */
/* warp_registry: the one list of warps: per method its name, paper, the planes it needs, its cheaper fallback, its
 * cost rank and its knobs. The runtime, its config, the selector, hmdwarp-warp's catalogue and the bench read it. */
#include "warp/warp_registry.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Knob shorthands: integral (I) or real (R), name, range, default, help. */
#define I(n, lo, hi, d, h) {n, lo, hi, d, true, h}
#define R(n, lo, hi, d, h) {n, lo, hi, d, false, h}
#define FILL I("fill", 0, 5, 0, "holes: 0 none, 1 epipolar far, 2 low-pass, 3 nearest, 4 background, 5 rubber sheet")
/* The adaptive grid's knobs (000 §4.1), shared by grid and transparency. */
#define GRID_KNOBS                                                                                                     \
    I("strategy", 0, 3, 3, "0 Didyk, 1 cross, 2 partial cross, 3 irregular"), I("tile", 2, 64, 32, "a power of two"),          \
        R("max_error", 0, 1, 0.02, NULL), I("filter", 0, 2, 0, "0 adaptive, 1 linear, 2 nearest"), FILL

/* Indexed by warp_method; the defaults are the warp modules' *_default_params() (tests/unit/test_registry.c). */
static const warp_method_info methods[WARP_METHOD_COUNT] = {
    [WARP_METHOD_NONE] = {"none", "-", "the frame as rendered, through the lens only", 0, WARP_METHOD_NONE, 0, true,
                          WARP_METHOD_NONE, 0, {{0}}},
    [WARP_METHOD_ROTATION] = {"rotation", "003 §3.4", "rotation reprojection with clamped fringe fill", 0,
                              WARP_METHOD_ROTATION, 1, true, WARP_METHOD_ROTATION, 0, {{0}}},
    /* Short of time the per-pixel raytrace steps down to the mesh raytrace: as accurate (it traces per pixel where
     * depth is discontinuous) at a fraction of the cost. */
    [WARP_METHOD_RAYTRACE] = {"raytrace", "003 §3.5", "height-map raytrace of every eye-buffer pixel",
                              WARP_NEEDS_DEPTH, WARP_METHOD_RAYTRACE_MESH, 3, true, WARP_METHOD_RAYTRACE, 5,
                              {I("steps", 1, 100000, 512, "ray steps at most"), I("refine", 0, 64, 4, NULL),
                               I("fill", 0, 1, 0, "disocclusions: 0 far side, 1 linear (003 §4.4)"),
                               R("edge_jump", 0, 1, 0.1, NULL),
                               I("skip", 0, 1, 1, "1 the skipping grid, 0 linear search")}},
    [WARP_METHOD_TRANSPARENCY] = {"transparency", "000 §5.3",
                                  "adaptive grid for the opaque surface + A-buffer ray casting",
                                  WARP_NEEDS_DEPTH | WARP_NEEDS_LAYERS, WARP_METHOD_RAYTRACE, 4, true,
                                  WARP_METHOD_RAYTRACE, 7,
                                  {R("opacity", 0, 1, 0.99, NULL), R("thickness", 0, 10, 0.02, NULL), GRID_KNOBS}},
    [WARP_METHOD_OBJECTS] = {"objects", "002 §3.2", "per-object forward warp, objects at their target-time poses",
                             WARP_NEEDS_DEPTH | WARP_NEEDS_IDS, WARP_METHOD_RAYTRACE, 4, true, WARP_METHOD_RAYTRACE,
                             3,
                             {I("kind", 0, 2, 2, "0 point, 1 quad, 2 mesh splats"),
                              I("fill", 0, 5, 2, "holes, as the other warps' fill"),
                              I("static", 0, 1, 0, "1 objects where the source saw them")}},
    [WARP_METHOD_RAYTRACE_MESH] = {"raytrace_mesh", "003 §3.5, 000 §3",
                                   "the raytrace at the lens mesh's vertices, per pixel in its cells with depth edges",
                                   WARP_NEEDS_DEPTH, WARP_METHOD_ROTATION, 2, true, WARP_METHOD_RAYTRACE_MESH, 2,
                                   {I("mesh", 2, 1024, 64, "vertices per side ([lens] mesh)"),
                                    I("cells", 0, 1, 1, "1 per pixel in its cells with depth edges, 0 its vertices "
                                                        "alone ([warp] mesh_cells)")}},
    [WARP_METHOD_ITERATIVE] = {"iterative", "001 §3", "backward warp by fixed-point iteration", WARP_NEEDS_DEPTH,
                               WARP_METHOD_ROTATION, 5, false, WARP_METHOD_COUNT, 6,
                               {I("seeds", 1, 64, 8, NULL), I("iters", 1, 64, 32, "steps per seed at most"),
                                I("bound", 0, 2, 2, "0 global, 1 tight, 2 PCA"), I("dilate", 0, 1, 0, NULL),
                                I("awoc", 0, 1, 0, NULL), FILL}},
    [WARP_METHOD_GRID] = {"grid", "000 §4.1", "adaptive grid warp", WARP_NEEDS_DEPTH, WARP_METHOD_ROTATION, 5, false,
                          WARP_METHOD_COUNT, 5, {GRID_KNOBS}},
    [WARP_METHOD_FORWARD] = {"forward", "004 §4", "McMillan forward warp, 1-pixel points", WARP_NEEDS_DEPTH,
                             WARP_METHOD_ROTATION, 5, false, WARP_METHOD_COUNT, 3,
                             {I("vis", 0, 2, 2, "0 z-buffer, 1 4 sheets, 2 8 sheets"),
                              I("twopass", 0, 1, 0, "1 two-pass binned (004 §5)"), FILL}},
    [WARP_METHOD_SPLAT] = {"splat", "002 §3.3", "forward warp with reconstruction", WARP_NEEDS_DEPTH,
                           WARP_METHOD_ROTATION, 5, false, WARP_METHOD_COUNT, 3,
                           {I("kind", 0, 2, 2, "0 point, 1 quad, 2 mesh"), I("vis", 0, 2, 0, "as forward's vis"),
                            FILL}},
};
#undef I
#undef R
#undef FILL
#undef GRID_KNOBS

/* The names in the table and in the X-list (what config tables use) are one list. */
#define CHECK_NAME_(id, name) _Static_assert(sizeof name > 1, "method " #id " needs a name");
WARP_RUNTIME_METHODS(CHECK_NAME_)
WARP_OFFLINE_METHODS(CHECK_NAME_)
#undef CHECK_NAME_
_Static_assert(WARP_METHOD_COUNT == sizeof methods / sizeof methods[0], "one registry entry per method");

const warp_method_info *warp_method_get(warp_method m)
{
    return m >= 0 && m < WARP_METHOD_COUNT ? &methods[m] : NULL;
}

const char *warp_method_name(warp_method m) { return m >= 0 && m < WARP_METHOD_COUNT ? methods[m].name : "?"; }

int warp_method_find(const char *name)
{
    for (int m = 0; name && m < WARP_METHOD_COUNT; m++)
        if (strcmp(methods[m].name, name) == 0) return m;
    return -1;
}

warp_method warp_method_usable(warp_method m, unsigned have, unsigned *missing)
{
    unsigned lacked = 0;
    /* at most COUNT steps: a ladder with a cycle (which test_registry rules out) still ends */
    for (int i = 0; i < WARP_METHOD_COUNT && m >= 0 && m < WARP_METHOD_COUNT; i++) {
        unsigned lack = methods[m].needs & ~have;
        if (!lack) break;
        lacked |= lack;
        m = methods[m].fallback;
    }
    if (missing) *missing |= lacked;
    return m;
}

const warp_knob *warp_method_knob(warp_method m, const char *name)
{
    const warp_method_info *w = warp_method_get(m);
    for (int k = 0; w && k < w->n_knobs; k++)
        if (strcmp(w->knobs[k].name, name) == 0) return &w->knobs[k];
    return NULL;
}

const char *warp_method_knobs_str(warp_method m, char *buf, size_t len)
{
    const warp_method_info *w = warp_method_get(m);
    if (!len) return buf;
    buf[0] = 0;
    for (int k = 0; w && k < w->n_knobs; k++) {
        const warp_knob *kn = &w->knobs[k];
        size_t at = strlen(buf);
        snprintf(buf + at, len - at, "%s%s=%g (%g..%g%s%s)", k ? " " : "", kn->name, kn->def, kn->min, kn->max,
                 kn->help ? ": " : "", kn->help ? kn->help : "");
    }
    return buf;
}

const char *warp_method_check_params(warp_method m, const char *params, char *buf, size_t len)
{
    const warp_method_info *w = warp_method_get(m);
    if (!w) {
        snprintf(buf, len, "no warp method %d", (int)m);
        return buf;
    }
    for (const char *p = params; p && *p;) {
        const char *end = strchr(p, ',');
        size_t n = end ? (size_t)(end - p) : strlen(p);
        const char *eq = memchr(p, '=', n);
        size_t kl = eq ? (size_t)(eq - p) : n;
        char key[32], val[64];
        snprintf(key, sizeof key, "%.*s", (int)(kl < sizeof key ? kl : sizeof key - 1), p);
        const warp_knob *kn = kl < sizeof key ? warp_method_knob(m, key) : NULL;
        if (!kn || !eq) {
            char names[200] = "";
            for (int k = 0; k < w->n_knobs; k++)
                snprintf(names + strlen(names), sizeof names - strlen(names), "%s%s", k ? " " : "", w->knobs[k].name);
            if (w->n_knobs)
                snprintf(buf, len, "parameter '%.*s': expected one of: %s (as key=value)", (int)n, p, names);
            else
                snprintf(buf, len, "parameter '%.*s': this warp takes no parameters", (int)n, p);
            return buf;
        }
        size_t vl = n - kl - 1;
        snprintf(val, sizeof val, "%.*s", (int)(vl < sizeof val ? vl : sizeof val - 1), eq + 1);
        char *e;
        double v = strtod(val, &e);
        if (vl == 0 || vl >= sizeof val || *e || !isfinite(v) || v < kn->min || v > kn->max ||
            (kn->integral && v != floor(v))) {
            snprintf(buf, len, "%s=%.*s: expected %s %g..%g%s%s", key, (int)vl, eq + 1,
                     kn->integral ? "a whole number" : "a number", kn->min, kn->max, kn->help ? " (" : "",
                     kn->help ? kn->help : "");
            if (kn->help) snprintf(buf + strlen(buf), len - strlen(buf), ")");
            return buf;
        }
        p += n + (end ? 1 : 0);
    }
    return NULL;
}
