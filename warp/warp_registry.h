/* SPDX-License-Identifier: MIT */
/* warp_registry: the one list of warps: per method its name, paper, the planes it needs, its cheaper fallback, its
 * cost rank and its knobs. The runtime, its config, the selector, hmdwarp-warp's catalogue and the bench read it. */
#ifndef WARP_REGISTRY_H
#define WARP_REGISTRY_H

#include <stdbool.h>
#include <stddef.h>

/* Adding a warp: its module (warp/warp_NAME.[ch]), one line in the X-list below and one entry in warp_registry.c's
 * table (the GPU renderer's stand-in for it is a column there); then its entry points where it runs:
 * tools/common/cat_warps.c's runs[] (hmdwarp-warp, the bench) and, for a runtime method, runtime/rt_render_cpu.c's
 * passes[]. Both are indexed by the registry's ids and checked to cover every method.
 *
 * X(ID, "name"): the methods the runtime can run, in the order of [warp] method's values (config files and --stats
 * use the names, so neither order nor names may change; a new one goes at the end). */
#define WARP_RUNTIME_METHODS(X)                                                                                        \
    X(NONE, "none") X(ROTATION, "rotation") X(RAYTRACE, "raytrace") X(TRANSPARENCY, "transparency")                   \
        X(OBJECTS, "objects") X(RAYTRACE_MESH, "raytrace_mesh")
/* The reference warps only hmdwarp-warp and the bench run (too slow or too general for a vsync). */
#define WARP_OFFLINE_METHODS(X) X(ITERATIVE, "iterative") X(GRID, "grid") X(FORWARD, "forward") X(SPLAT, "splat")

#define WARP_METHOD_ENUM_(id, name) WARP_METHOD_##id,
typedef enum {
    WARP_RUNTIME_METHODS(WARP_METHOD_ENUM_)
    WARP_METHOD_RUNTIME_COUNT,
    WARP_METHOD_OFFLINE_FIRST_ = WARP_METHOD_RUNTIME_COUNT - 1,
    WARP_OFFLINE_METHODS(WARP_METHOD_ENUM_)
    WARP_METHOD_COUNT
} warp_method;
#undef WARP_METHOD_ENUM_

/* The names as a string-literal list, for tables that need them at compile time (config enums): "none", ... */
#define WARP_METHOD_NAME_(id, name) name,
#define WARP_RUNTIME_METHOD_NAMES WARP_RUNTIME_METHODS(WARP_METHOD_NAME_)

/* Planes a warp needs from the host frame besides colour; the same bits as DRV_PLANE_* (asserted in runtime/). */
enum {
    WARP_NEEDS_DEPTH = 1u << 1,
    WARP_NEEDS_IDS = 1u << 2,
    WARP_NEEDS_MOTION = 1u << 3,
    WARP_NEEDS_LAYERS = 1u << 4,
};

/* One knob of a warp, as hmdwarp-warp's name=value parameters: integral knobs take whole numbers only. */
typedef struct {
    const char *name;
    double min, max, def;
    bool integral;
    const char *help; /* what the values mean, e.g. "0 far side, 1 linear"; NULL when the name says it */
} warp_knob;

enum { WARP_MAX_KNOBS = 8 };

typedef struct {
    const char *name;
    const char *cite;     /* paper and section, e.g. "003 §3.5"; "-" for none */
    const char *summary;  /* one line: what it does */
    unsigned needs;       /* WARP_NEEDS_* */
    /* The next cheaper method, taken when a needed plane is missing or the method does not fit the time left; a
     * method that is its own fallback ends the ladder (none, rotation). */
    warp_method fallback;
    int cost_rank;        /* larger = dearer and more capable; the selector escalates at once, de-escalates slowly */
    bool runtime;         /* hmdwarpd can run it ([warp] method) */
    /* What the GLES renderer (platform/plat_gles) draws for it: itself where it has a GPU pass, else the GPU pass
     * that stands in (the GPU's per-pixel raytrace serves the A-buffer and the object warps). WARP_METHOD_COUNT (no
     * method) for the offline warps, which hmdwarpd never runs. */
    warp_method gpu;
    int n_knobs;
    warp_knob knobs[WARP_MAX_KNOBS];
} warp_method_info;

/* The entry for m, or NULL when m is no method. */
const warp_method_info *warp_method_get(warp_method m);
/* "?" for no method. */
const char *warp_method_name(warp_method m);
/* The method called name, or -1. */
int warp_method_find(const char *name);

/* The first method on m's fallback ladder (m included) whose planes are all in `have` (WARP_NEEDS_* bits); the
 * planes found missing on the way are ORed into *missing (may be NULL). Allocation-free: the vsync path calls it. */
warp_method warp_method_usable(warp_method m, unsigned have, unsigned *missing);

/* The knob called name of method m, or NULL. */
const warp_knob *warp_method_knob(warp_method m, const char *name);
/* Checks "k=v,k=v" parameters against m's knobs (names, numbers, ranges, whole numbers). NULL when fine, else a
 * message naming the parameter and what it accepts, in buf (the caller names the method). */
const char *warp_method_check_params(warp_method m, const char *params, char *buf, size_t len);
/* The knobs as one line: "steps=512 (1..100000) refine=4 (0..64) ..." into buf; returns buf. */
const char *warp_method_knobs_str(warp_method m, char *buf, size_t len);

#endif
