/* SPDX-License-Identifier: MIT */
/* sim_scene: the catalogue of analytic test scenes (what is where, how it moves), image-plane bookkeeping and
 * the scene queries (object poses, minimum depth). The ray caster itself is in sim_render.c. */
#include "sim/sim_scene.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "sim/sim_internal.h"
#include "warp/warp_rand.h"

#define NELEM(a) ((int)(sizeof(a) / sizeof((a)[0])))

/* ---- planes and effects ---- */

unsigned sim_planes_for_effects(unsigned fx)
{
    /* Colour is always needed: it is what gets displayed. Depth for anything that parallax moves (translation,
     * disocclusion), ids + motion for per-object warps (002 §3), layers for the A-buffer (000 §4.2). */
    unsigned p = SIM_PLANE_COLOR;
    if (fx & (SIM_FX_HEAD_TRANSLATION | SIM_FX_DISOCCLUSION)) p |= SIM_PLANE_DEPTH;
    if (fx & SIM_FX_OBJECT_MOTION) p |= SIM_PLANE_DEPTH | SIM_PLANE_IDS | SIM_PLANE_MOTION;
    if (fx & SIM_FX_TRANSPARENCY) p |= SIM_PLANE_DEPTH | SIM_PLANE_LAYERS;
    return p;
}

static const char *bits_str(unsigned bits, const char *const *names, int n, char *buf, int buflen)
{
    if (!buf || buflen <= 0) return buf;
    buf[0] = '\0';
    size_t used = 0, cap = (size_t)buflen;
    for (int i = 0; i < n; i++) {
        if (!(bits & (1u << i))) continue;
        int k = snprintf(buf + used, cap - used, "%s%s", used ? "," : "", names[i]);
        if (k < 0 || (size_t)k >= cap - used) break; /* truncated: keep what fits */
        used += (size_t)k;
    }
    if (used == 0) snprintf(buf, cap, "none");
    return buf;
}

const char *sim_planes_str(unsigned planes, char *buf, int buflen)
{
    static const char *const names[] = {"color", "depth", "ids", "motion", "layers"};
    return bits_str(planes, names, NELEM(names), buf, buflen);
}

const char *sim_effects_str(unsigned effects, char *buf, int buflen)
{
    static const char *const names[] = {"rotation", "translation", "object_motion", "transparency", "disocclusion",
                                        "lens"};
    return bits_str(effects, names, NELEM(names), buf, buflen);
}

/* ---- object tables ----
 * Every indoor scene starts with the same room (ids 1..ROOM_N), so its static geometry renders identically in all
 * of them and the tests can compare a scene against "room" (e.g. glass panes blended over the room's pixels). */

#define OBJ(prim_, tex_, sx, sy, sz, r, g, b, px, py, pz, yaw, pitch, roll) \
    {.prim = (prim_), .tex = (tex_), .alpha = 1.0f, .size = {sx, sy, sz}, .rgb = {r, g, b}, \
     .pos = {px, py, pz}, .ypr_deg = {yaw, pitch, roll}}

/* Room: 6 m wide, 3 m high, 8 m deep; the default eye (0, 1.6, 0) is 6 m from the front wall and 2 m from the
 * back wall. The furniture stays >= 2 m from the eye so that this scene is about rotation, not parallax. */
static const sim_object room_objs[] = {
    OBJ(SIM_PRIM_ROOM, SIM_TEX_ROOM, 3.0f, 1.5f, 4.0f, 0.80f, 0.76f, 0.68f, 0.0, 1.5, -2.0, 0, 0, 0),
    OBJ(SIM_PRIM_BOX, SIM_TEX_SOLID, 0.5f, 0.5f, 0.5f, 0.90f, 0.55f, 0.20f, -1.5, 0.5, -4.0, 25, 0, 0),
    OBJ(SIM_PRIM_SPHERE, SIM_TEX_SOLID, 0.55f, 0, 0, 0.20f, 0.70f, 0.70f, 1.5, 1.1, -4.5, 0, 0, 0),
    OBJ(SIM_PRIM_BOX, SIM_TEX_SOLID, 0.35f, 0.35f, 0.5f, 0.60f, 0.35f, 0.75f, 1.6, 0.35, -2.6, -15, 0, 0),
    OBJ(SIM_PRIM_SPHERE, SIM_TEX_SOLID, 0.35f, 0, 0, 0.90f, 0.85f, 0.30f, -2.0, 2.2, -3.2, 0, 0, 0),
    OBJ(SIM_PRIM_BOX, SIM_TEX_SOLID, 0.4f, 0.4f, 0.4f, 0.35f, 0.55f, 0.90f, 2.2, 0.4, 1.4, 10, 0, 0),
};

/* Near: objects 0.4-1.5 m from the eyes: strong parallax and disocclusions against the far wall. */
static const sim_object near_objs[] = {
    OBJ(SIM_PRIM_BOX, SIM_TEX_SOLID, 0.12f, 0.12f, 0.12f, 0.85f, 0.25f, 0.25f, 0.30, 1.35, -0.70, 30, 10, 0),
    OBJ(SIM_PRIM_SPHERE, SIM_TEX_SOLID, 0.12f, 0, 0, 0.30f, 0.80f, 0.35f, -0.28, 1.75, -0.55, 0, 0, 0),
    OBJ(SIM_PRIM_SPHERE, SIM_TEX_SOLID, 0.05f, 0, 0, 0.95f, 0.95f, 0.90f, 0.10, 1.45, -0.45, 0, 0, 0),
    OBJ(SIM_PRIM_CYLINDER, SIM_TEX_SOLID, 0.09f, 1.5f, 0, 0.70f, 0.70f, 0.75f, 0.55, 1.5, -1.2, 0, 0, 0),
    OBJ(SIM_PRIM_BOX, SIM_TEX_SOLID, 0.30f, 0.04f, 0.25f, 0.55f, 0.40f, 0.25f, -0.55, 0.75, -1.0, 15, 0, 0),
};

/* Glass: overlapping tinted panes 1.3-2.7 m away; up to three fragments per pixel in the middle of the view. */
#define PANE(sx, sy, r, g, b, a, px, py, pz, yaw, pitch) \
    {.prim = SIM_PRIM_RECT, .tex = SIM_TEX_PANE, .alpha = (a), .size = {sx, sy, 0}, .rgb = {r, g, b}, \
     .pos = {px, py, pz}, .ypr_deg = {yaw, pitch, 0}}
static const sim_object glass_objs[] = {
    PANE(0.45f, 0.35f, 0.95f, 0.25f, 0.20f, 0.40f, -0.35, 1.55, -1.3, 10, 0),
    PANE(0.60f, 0.45f, 0.20f, 0.85f, 0.30f, 0.50f, 0.20, 1.65, -2.0, -25, 0),
    PANE(0.70f, 0.50f, 0.25f, 0.35f, 0.95f, 0.35f, 0.00, 1.40, -2.7, 5, 15),
};

/* Movers: periodic translation (peaks 1.3-1.6 m/s) and 90 deg/s spins, 2.5-4 m away so they stay in view. The
 * sphere only translates (its image moves rigidly: a clean target for motion-vector checks), the boxes translate
 * and spin, the propeller only spins. */
static const sim_object mover_objs[] = {
    {.prim = SIM_PRIM_SPHERE, .tex = SIM_TEX_SOLID, .alpha = 1, .size = {0.3f, 0, 0}, .rgb = {0.95f, 0.45f, 0.60f},
     .pos = {0, 1.3, -3.5}, .amp = {1.0, 0, 0}, .freq_hz = 0.25},
    {.prim = SIM_PRIM_BOX, .tex = SIM_TEX_SOLID, .alpha = 1, .size = {0.25f, 0.25f, 0.25f},
     .rgb = {0.40f, 0.85f, 0.45f}, .pos = {-1.0, 1.6, -3.0}, .amp = {0, 0, 0.6}, .freq_hz = 0.4, .phase = 1.0,
     .spin_dps = {27.0, 84.0, 18.0}},
    {.prim = SIM_PRIM_BOX, .tex = SIM_TEX_SOLID, .alpha = 1, .size = {0.2f, 0.35f, 0.2f},
     .rgb = {0.95f, 0.80f, 0.35f}, .pos = {1.4, 1.8, -3.8}, .amp = {0, 0.4, 0}, .freq_hz = 0.5, .phase = 2.0,
     .spin_dps = {90, 0, 0}},
    {.prim = SIM_PRIM_BOX, .tex = SIM_TEX_SOLID, .alpha = 1, .size = {0.6f, 0.06f, 0.02f},
     .rgb = {0.85f, 0.30f, 0.25f}, .pos = {0.6, 2.3, -3.3}, .spin_dps = {0, 0, 90}},
};

/* Outdoor: ground to the horizon, landmarks 10-80 m away, the textured sky at infinity all around. */
static const sim_object outdoor_objs[] = {
    OBJ(SIM_PRIM_RECT, SIM_TEX_GROUND, INFINITY, INFINITY, 0, 0.45f, 0.62f, 0.30f, 0, 0, 0, 0, -90, 0),
    OBJ(SIM_PRIM_BOX, SIM_TEX_SOLID, 2, 2, 2, 0.75f, 0.40f, 0.30f, -8, 2, -25, 30, 0, 0),
    OBJ(SIM_PRIM_SPHERE, SIM_TEX_SOLID, 5, 0, 0, 0.85f, 0.85f, 0.80f, 12, 5, -40, 0, 0, 0),
    OBJ(SIM_PRIM_CYLINDER, SIM_TEX_SOLID, 3, 15, 0, 0.60f, 0.60f, 0.65f, -30, 15, -70, 0, 0, 0),
    OBJ(SIM_PRIM_BOX, SIM_TEX_SOLID, 3, 1.5f, 1.5f, 0.50f, 0.45f, 0.70f, 25, 1.5, 15, -20, 0, 0),
    OBJ(SIM_PRIM_SPHERE, SIM_TEX_SOLID, 1, 0, 0, 0.90f, 0.60f, 0.25f, -20, 1, 8, 0, 0, 0),
};

/* Hairball strands: generated from a hash of the strand index (no tables to keep in sync, no mutable state). */
enum { HAIRBALL_N = 300 };

static double hash_uniform(uint64_t key, int k) /* [0, 1) */
{
    return warp_unit53(warp_mix64(key * WARP_GOLDEN64 + (uint64_t)k * 0xD1B54A32D192ED03ull + 0x632BE59BD9B4E019ull));
}

static void hairball_strand(int k, sim_object *o)
{
    uint64_t key = (uint64_t)k + 1;
    memset(o, 0, sizeof *o);
    o->prim = SIM_PRIM_CYLINDER;
    o->tex = SIM_TEX_PLAIN;
    o->alpha = 1.0f;
    /* centre uniform in a ball of radius 0.28 m around (0, 1.6, -1.5) (rejection-free: cube-root radius) */
    double cz = 2 * hash_uniform(key, 0) - 1, ca = 2 * WARP_PI * hash_uniform(key, 1);
    double rr = 0.28 * cbrt(hash_uniform(key, 2)), sz = sqrt(1 - cz * cz);
    o->pos[0] = rr * sz * cos(ca);
    o->pos[1] = 1.6 + rr * sz * sin(ca);
    o->pos[2] = -1.5 + rr * cz;
    /* axis uniform on the sphere: roll tilts Y by acos(uniform), yaw spins it about the vertical */
    o->ypr_deg[0] = 360.0 * hash_uniform(key, 3);
    o->ypr_deg[2] = acos(2 * hash_uniform(key, 4) - 1) * 180.0 / WARP_PI;
    o->size[0] = (float)(0.01 + 0.01 * hash_uniform(key, 5));
    o->size[1] = (float)(0.07 + 0.10 * hash_uniform(key, 6));
    /* varied saturated hues so neighbouring strands differ */
    double h = hash_uniform(key, 7) * 6.0;
    for (int c = 0; c < 3; c++) {
        double x = fabs(fmod(h + 2.0 * c, 6.0) - 3.0) - 1.0; /* hue wheel */
        x = x < 0 ? 0 : (x > 1 ? 1 : x);
        o->rgb[c] = (float)(0.25 + 0.7 * x);
    }
}

/* ---- scenes ---- */

struct sim_scene {
    const char *name, *description;
    unsigned effects;
    const sim_object *part[2];
    int npart[2];
    int ngen;
    void (*gen)(int k, sim_object *o);
    bool sky;
};

#define FX_RT (SIM_FX_HEAD_ROTATION | SIM_FX_HEAD_TRANSLATION)
static const sim_scene scenes[] = {
    {"room", "textured room 6 x 3 x 8 m with a few boxes and spheres >= 2 m away", SIM_FX_HEAD_ROTATION | SIM_FX_LENS,
     {room_objs, NULL}, {NELEM(room_objs), 0}, 0, NULL, false},
    {"near", "the room plus boxes, spheres and a pillar 0.4-1.5 m from the eyes",
     FX_RT | SIM_FX_DISOCCLUSION | SIM_FX_LENS, {room_objs, near_objs}, {NELEM(room_objs), NELEM(near_objs)}, 0,
     NULL, false},
    {"hairball", "ball of 300 thin strands 1.5 m ahead in front of the room", FX_RT | SIM_FX_DISOCCLUSION,
     {room_objs, NULL}, {NELEM(room_objs), 0}, HAIRBALL_N, hairball_strand, false},
    {"glass", "the room with three overlapping tinted panes 1.3-2.7 m away", FX_RT | SIM_FX_TRANSPARENCY,
     {room_objs, glass_objs}, {NELEM(room_objs), NELEM(glass_objs)}, 0, NULL, false},
    {"movers", "the room with a translating sphere, translating and spinning boxes and a propeller", FX_RT | SIM_FX_OBJECT_MOTION,
     {room_objs, mover_objs}, {NELEM(room_objs), NELEM(mover_objs)}, 0, NULL, false},
    {"outdoor", "ground to the horizon, distant landmarks and a textured sky at infinity", FX_RT,
     {outdoor_objs, NULL}, {NELEM(outdoor_objs), 0}, 0, NULL, true},
};

static const char *const scene_names[] = {"room", "near", "hairball", "glass", "movers", "outdoor", NULL};

const sim_scene *sim_scene_find(const char *name)
{
    if (!name) return NULL;
    for (int i = 0; i < NELEM(scenes); i++)
        if (strcmp(scenes[i].name, name) == 0) return &scenes[i];
    return NULL;
}

const char *const *sim_scene_names(void) { return scene_names; }
const char *sim_scene_name(const sim_scene *s) { return s->name; }
const char *sim_scene_description(const sim_scene *s) { return s->description; }
unsigned sim_scene_effects(const sim_scene *s) { return s->effects; }
bool sim_scene_has_sky(const sim_scene *s) { return s->sky; }

int sim_scene_nobjects(const sim_scene *s) { return s->npart[0] + s->npart[1] + s->ngen; }
int sim_scene_object_count(const sim_scene *s) { return sim_scene_nobjects(s); }

void sim_scene_object(const sim_scene *s, int k, sim_object *out)
{
    for (int i = 0; i < 2; i++) {
        if (k < s->npart[i]) {
            *out = s->part[i][k];
            return;
        }
        k -= s->npart[i];
    }
    if (k < s->ngen) {
        s->gen(k, out);
        return;
    }
    memset(out, 0, sizeof *out);
}

/* ---- motion ---- */

static double deg(double d) { return d * (WARP_PI / 180.0); }

bool sim_object_moves(const sim_object *o)
{
    for (int i = 0; i < 3; i++)
        if (o->vel[i] != 0 || (o->amp[i] != 0 && o->freq_hz != 0) || o->spin_dps[i] != 0) return true;
    return false;
}

warp_pose sim_object_pose(const sim_object *o, double t)
{
    warp_pose p;
    double s = sin(2 * WARP_PI * o->freq_hz * t + o->phase);
    warp_quat q0 = warp_quat_from_ypr(deg(o->ypr_deg[0]), deg(o->ypr_deg[1]), deg(o->ypr_deg[2]));
    warp_vec3 spin = warp_v3(deg(o->spin_dps[0]) * t, deg(o->spin_dps[1]) * t, deg(o->spin_dps[2]) * t);
    p.q = warp_quat_mul(warp_quat_exp(spin), q0);
    p.p = warp_v3(o->pos[0] + o->vel[0] * t + o->amp[0] * s, o->pos[1] + o->vel[1] * t + o->amp[1] * s,
                  o->pos[2] + o->vel[2] * t + o->amp[2] * s);
    return p;
}

void sim_object_velocity(const sim_object *o, double t, warp_vec3 *lin, warp_vec3 *ang)
{
    double w = 2 * WARP_PI * o->freq_hz, c = w * cos(w * t + o->phase);
    *lin = warp_v3(o->vel[0] + o->amp[0] * c, o->vel[1] + o->amp[1] * c, o->vel[2] + o->amp[2] * c);
    *ang = warp_v3(deg(o->spin_dps[0]), deg(o->spin_dps[1]), deg(o->spin_dps[2]));
}

warp_pose sim_scene_object_pose(const sim_scene *s, int id, double t)
{
    if (!s || id < 1 || id > sim_scene_nobjects(s)) return warp_pose_identity();
    sim_object o;
    sim_scene_object(s, id - 1, &o);
    return sim_object_pose(&o, t);
}

/* ---- minimum depth ---- */

/* Distance from a point to a primitive; e is in the object frame. */
static double prim_distance(const sim_object *o, warp_vec3 e)
{
    double sx = o->size[0], sy = o->size[1], sz = o->size[2];
    switch (o->prim) {
    case SIM_PRIM_ROOM: { /* from inside: the nearest wall */
        double d = fmin(fmin(sx - fabs(e.x), sy - fabs(e.y)), sz - fabs(e.z));
        return fabs(d);
    }
    case SIM_PRIM_BOX: {
        double dx = fmax(fabs(e.x) - sx, 0), dy = fmax(fabs(e.y) - sy, 0), dz = fmax(fabs(e.z) - sz, 0);
        return sqrt(dx * dx + dy * dy + dz * dz);
    }
    case SIM_PRIM_SPHERE: return fmax(warp_v3_norm(e) - sx, 0);
    case SIM_PRIM_CYLINDER: {
        double radial = fmax(hypot(e.x, e.z) - sx, 0), axial = fmax(fabs(e.y) - sy, 0);
        return hypot(radial, axial);
    }
    case SIM_PRIM_RECT: {
        double dx = isinf(sx) ? 0 : fmax(fabs(e.x) - sx, 0), dy = isinf(sy) ? 0 : fmax(fabs(e.y) - sy, 0);
        return sqrt(dx * dx + dy * dy + e.z * e.z);
    }
    }
    return INFINITY;
}

double sim_scene_min_depth(const sim_scene *s)
{
    /* The d_min of 004 §3 bounds how far pixels move under translation: exact per primitive for static objects;
     * moving ones are sampled over 20 s (their motion is periodic with periods of a few seconds). */
    const warp_vec3 eye = warp_v3(0, 1.6, 0);
    double best = INFINITY;
    int n = sim_scene_nobjects(s);
    for (int k = 0; k < n; k++) {
        sim_object o;
        sim_scene_object(s, k, &o);
        int samples = sim_object_moves(&o) ? 2001 : 1;
        for (int i = 0; i < samples; i++) {
            warp_pose p = sim_object_pose(&o, i * 0.01);
            warp_vec3 e = warp_quat_rotate(warp_quat_conj(p.q), warp_v3_sub(eye, p.p));
            best = fmin(best, prim_distance(&o, e));
        }
    }
    return best;
}

/* ---- buffers ---- */

bool sim_buffers_alloc(sim_buffers *b, int w, int h, unsigned planes, int max_layers)
{
    memset(b, 0, sizeof *b);
    bool ok = true;
    if (planes & SIM_PLANE_COLOR) ok = ok && warp_image_rgba8_alloc(&b->color, w, h);
    if (planes & SIM_PLANE_DEPTH) ok = ok && warp_image_f32_alloc(&b->depth, w, h);
    if (planes & SIM_PLANE_IDS) ok = ok && warp_image_u16_alloc(&b->ids, w, h);
    if (planes & SIM_PLANE_MOTION) ok = ok && warp_image_vec2f_alloc(&b->motion, w, h);
    if (planes & SIM_PLANE_LAYERS) ok = ok && warp_image_layers_alloc(&b->layers, w, h, max_layers);
    if (!ok) {
        sim_buffers_free(b);
        return false;
    }
    b->planes = planes & (SIM_PLANE_COLOR | SIM_PLANE_DEPTH | SIM_PLANE_IDS | SIM_PLANE_MOTION | SIM_PLANE_LAYERS);
    return true;
}

void sim_buffers_free(sim_buffers *b)
{
    warp_image_free(&b->color);
    warp_image_free(&b->depth);
    warp_image_free(&b->ids);
    warp_image_free(&b->motion);
    warp_image_layers_free(&b->layers);
    memset(b, 0, sizeof *b);
}
