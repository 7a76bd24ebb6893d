/* hmdwarp-warp's catalogue: every warp the tool (and the results table) can run, behind one signature, with its
 * knobs as name=value parameters and the planes it needs. */
#include "tools/common/cat_warps.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "warp/warp_holes.h"
#include "warp/warp_iterative.h"
#include "warp/warp_raytrace.h"
#include "warp/warp_reproject.h"

double cat_param(const char *params, const char *key, double def, bool *bad)
{
    if (!params) return def;
    size_t kl = strlen(key);
    for (const char *p = params; *p;) {
        const char *end = strchr(p, ',');
        size_t len = end ? (size_t)(end - p) : strlen(p);
        if (len > kl && strncmp(p, key, kl) == 0 && p[kl] == '=') {
            char buf[64];
            snprintf(buf, sizeof buf, "%.*s", (int)(len - kl - 1), p + kl + 1);
            char *e;
            double v = strtod(buf, &e);
            if (e == buf || *e) {
                if (bad) *bad = true;
                return def;
            }
            return v;
        }
        p += len + (end ? 1 : 0);
    }
    return def;
}

const char *cat_check_params(const char *params, const char *known)
{
    static char msg[200];
    if (!params) return NULL;
    for (const char *p = params; *p;) {
        const char *end = strchr(p, ',');
        size_t len = end ? (size_t)(end - p) : strlen(p);
        const char *eq = memchr(p, '=', len);
        size_t kl = eq ? (size_t)(eq - p) : len;
        bool ok = false;
        for (const char *k = known; *k;) {
            while (*k == ' ') k++;
            size_t n = strcspn(k, " ");
            if (n && n == kl && strncmp(k, p, kl) == 0) ok = true;
            k += n;
        }
        if (!ok || !eq) {
            snprintf(msg, sizeof msg, "parameter '%.*s': expected one of: %s (as key=value)", (int)len, p, known);
            return msg;
        }
        p += len + (end ? 1 : 0);
    }
    return NULL;
}

static void count_mask(const warp_image_u8 *mask, cat_stats *st)
{
    st->fringe = st->holes = 0;
    for (int y = 0; y < mask->h; y++)
        for (int x = 0; x < mask->w; x++) {
            uint8_t m = WARP_AT(mask, x, y);
            st->fringe += (m & WARP_MASK_FRINGE) != 0;
            st->holes += (m & WARP_MASK_HOLE) != 0;
        }
}

/* ---- 003: rotation reprojection and the height-map raytrace ---- */

static const char *run_none(const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose, double dst_time, const char *params,
                            warp_image_rgba8 *dst, warp_image_u8 *mask, cat_stats *st)
{
    (void)dst_pose;
    (void)dst_time;
    const char *why = cat_check_params(params, "");
    if (why) return why;
    /* The frame as rendered: what the wearer sees without any warp. */
    warp_mat3 h = warp_reproject_homography(src, dst_cam, src->pose.q);
    warp_reproject_rows(src, &h, dst, mask, 0, dst->h);
    st->primitives = st->samples = -1;
    count_mask(mask, st);
    return NULL;
}

static const char *run_rotation(const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose, double dst_time,
                                const char *params, warp_image_rgba8 *dst, warp_image_u8 *mask, cat_stats *st)
{
    (void)dst_time;
    const char *why = cat_check_params(params, "");
    if (why) return why;
    warp_mat3 h = warp_reproject_homography(src, dst_cam, dst_pose.q);
    warp_reproject_rows(src, &h, dst, mask, 0, dst->h);
    st->primitives = -1;
    st->samples = (long)dst->w * dst->h;
    count_mask(mask, st);
    return NULL;
}

static const char *run_raytrace(const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose, double dst_time,
                                const char *params, warp_image_rgba8 *dst, warp_image_u8 *mask, cat_stats *st)
{
    (void)dst_time;
    const char *why = cat_check_params(params, "steps refine fill edge_jump");
    if (why) return why;
    warp_raytrace_params p = warp_raytrace_default_params();
    bool bad = false;
    p.max_steps = (int)cat_param(params, "steps", p.max_steps, &bad);
    p.refine_iters = (int)cat_param(params, "refine", p.refine_iters, &bad);
    p.edge_fill = (warp_edge_fill)(int)cat_param(params, "fill", p.edge_fill, &bad);
    p.edge_jump = (float)cat_param(params, "edge_jump", p.edge_jump, &bad);
    if (bad) return "raytrace: a parameter value is not a number";
    if (p.edge_fill != WARP_EDGE_FILL_FAR && p.edge_fill != WARP_EDGE_FILL_LINEAR)
        return "raytrace: fill must be 0 (far side) or 1 (linear)";
    warp_raytrace_setup s;
    why = warp_raytrace_prepare(&s, src, dst_cam, dst_pose, &p);
    if (why) return why;
    warp_raytrace_stats rs = {0};
    warp_raytrace_rows(&s, dst, mask, 0, dst->h, &rs);
    st->primitives = -1;
    st->samples = rs.steps;
    count_mask(mask, st);
    snprintf(st->note, sizeof st->note, "%d steps max, %ld edge px", p.max_steps, rs.edge_pixels);
    return NULL;
}

/* ---- hole filling, for every warp that leaves holes (fill=K on its parameters) ---- */


/* fill = 0 none, 1 epipolar far (002 §3.3), 2 depth-aware low-pass (000 §5.2), 3 nearest stretch, 4 background
 * stretch, 5 rubber sheet. Needs the warped image's inverse depth (0 where unknown). */
static const char *fill_holes(int fill, const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose,
                              const warp_image_f32 *dst_inv, warp_image_rgba8 *dst, warp_image_u8 *mask, cat_stats *st)
{
    if (fill == 0) return NULL;
    static const warp_holes_method m[] = {0, WARP_HOLES_EPIPOLAR_FAR, WARP_HOLES_LOWPASS, WARP_HOLES_STRETCH_NEAREST,
                                          WARP_HOLES_STRETCH_BACKGROUND, WARP_HOLES_RUBBER_SHEET};
    if (fill < 0 || fill > 5) return "fill must be 0..5 (none epifar lowpass stretch background rubber)";
    warp_holes_ctx hc;
    if (!warp_holes_init(&hc, dst->w, dst->h, 12)) return "out of memory";
    warp_holes_params hp = warp_holes_default_params();
    hp.method = m[fill];
    warp_epipole e = warp_epipole_from_poses(dst_cam, dst_pose, src->pose);
    warp_holes_stats hs = {0};
    const char *why = warp_holes_fill(&hc, dst, mask, dst_inv, &e, &hp, &hs);
    warp_holes_free(&hc);
    if (why) return why;
    if (st->samples >= 0) st->samples += hs.search_steps;
    snprintf(st->note + strlen(st->note), sizeof st->note - strlen(st->note), "%sfilled %ld by %s",
             st->note[0] ? ", " : "", hs.filled, warp_holes_method_name(hp.method));
    return NULL;
}

/* ---- 001: iterative backward warp ---- */

static const char *run_iterative(const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose, double dst_time,
                                 const char *params, warp_image_rgba8 *dst, warp_image_u8 *mask, cat_stats *st)
{
    const char *why = cat_check_params(params, "seeds iters bound dilate awoc fill");
    if (why) return why;
    warp_iter_params p = warp_iter_default_params();
    bool bad = false;
    p.seeds = (int)cat_param(params, "seeds", p.seeds, &bad);
    p.iters = (int)cat_param(params, "iters", p.iters, &bad);
    p.bound = (warp_iter_bound)(int)cat_param(params, "bound", p.bound, &bad);
    p.dilate = cat_param(params, "dilate", p.dilate, &bad) != 0;
    p.approximate = cat_param(params, "awoc", p.approximate, &bad) != 0;
    int fill = (int)cat_param(params, "fill", 0, &bad);
    if (bad) return "iterative: a parameter value is not a number";
    if (p.bound < WARP_ITER_BOUND_GLOBAL || p.bound > WARP_ITER_BOUND_PCA) return "iterative: bound must be 0 (global), 1 (tight) or 2 (PCA)";
    warp_iter_ctx c;
    if (!warp_iter_alloc(&c, src->color->w, src->color->h, dst->w, dst->h, 1)) return "out of memory";
    warp_iter_target t = {*dst_cam, dst_pose, dst_time, NULL};
    warp_iter_stats is;
    memset(&is, 0, sizeof is);
    why = warp_iter_run(&c, src, NULL, 0, &t, &p, dst, mask, &is);
    if (!why) {
        st->primitives = -1;
        st->samples = is.seeds + is.iterations;
        snprintf(st->note, sizeof st->note, "N%d T%d %s, %.1f %% converged", p.seeds, p.iters,
                 p.bound == WARP_ITER_BOUND_GLOBAL ? "global" : p.bound == WARP_ITER_BOUND_TIGHT ? "tight" : "PCA",
                 is.pixels ? 100.0 * (double)is.converged / (double)is.pixels : 0.0);
        why = fill_holes(fill, src, dst_cam, dst_pose, &c.dst_depth, dst, mask, st);
        count_mask(mask, st);
    }
    warp_iter_free(&c);
    return why;
}

static const cat_warp w_none = {"none", "-", "the source frame as rendered (no warp)", 0, run_none};
static const cat_warp w_rotation = {"rotation", "003 §3.4", "rotation reprojection with clamped fringe fill", 0,
                                    run_rotation};
static const cat_warp w_raytrace = {"raytrace", "003 §3.5",
                                    "height-map raytrace; steps=512 refine=4 fill=0|1 (far|linear) edge_jump=0.1",
                                    CAT_NEEDS_DEPTH, run_raytrace};

static const cat_warp w_iterative = {"iterative", "001 §3",
                                     "backward warp by fixed-point iteration; seeds=8 iters=4 bound=0|1|2 "
                                     "(global|tight|PCA) dilate=0|1 awoc=0|1 fill=0..5",
                                     CAT_NEEDS_DEPTH, run_iterative};

static const cat_warp *const catalogue[] = {&w_none, &w_rotation, &w_raytrace, &w_iterative, NULL};

const cat_warp *const *cat_all(void) { return catalogue; }

const cat_warp *cat_find(const char *name)
{
    for (int i = 0; catalogue[i]; i++)
        if (strcmp(catalogue[i]->name, name) == 0) return catalogue[i];
    return NULL;
}
