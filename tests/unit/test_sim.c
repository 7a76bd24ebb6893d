/* SPDX-License-Identifier: MIT */
/* Unit tests for sim_scene: the scene catalogue, and the renderer's planes against analytic ground truth
 * (planar depth, ids, motion vectors, A-buffer layers, direction-only sky), row-split determinism and untouched planes. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "sim/sim_scene.h"
#include "tests/support/test_util.h"
#include "warp/warp_camera.h"
#include "warp/warp_math.h"
#include "warp/warp_srgb.h"

#define DEG (WARP_PI / 180.0)
#define ALL_PLANES (SIM_PLANE_COLOR | SIM_PLANE_DEPTH | SIM_PLANE_IDS | SIM_PLANE_MOTION | SIM_PLANE_LAYERS)

static warp_camera cam_make(int w, int h) { return warp_camera_symmetric(w, h, 90, 96, 0.05, INFINITY); }

static warp_pose eye_at(double x, double y, double z, double yaw_deg, double pitch_deg, double roll_deg)
{
    warp_pose e = {warp_quat_from_ypr(yaw_deg * DEG, pitch_deg * DEG, roll_deg * DEG), warp_v3(x, y, z)};
    return e;
}

static const sim_scene *scene(const char *name)
{
    const sim_scene *s = sim_scene_find(name);
    assert_non_null(s);
    return s;
}

static void render_new(sim_buffers *b, const sim_scene *s, double t, warp_pose eye, const warp_camera *c,
                       unsigned planes, int max_layers)
{
    assert_true(sim_buffers_alloc(b, c->width, c->height, planes, max_layers));
    sim_render(s, t, eye, c, planes, b);
}

/* Pixel coordinates (continuous) and planar depth of a world point; false when behind the eye. */
static bool project(const warp_camera *c, warp_pose eye, warp_vec3 pw, double *x, double *y, double *z)
{
    warp_vec3 pc = warp_pose_apply(warp_pose_inverse(eye), pw);
    double iz;
    if (!warp_camera_project(c, pc, x, y, &iz)) return false;
    if (z) *z = 1.0 / iz;
    return true;
}

/* World ray (origin at the eye) through the centre of pixel (x, y): direction with camera-space z = -1, so that
 * the ray parameter is the planar depth. */
static warp_vec3 pixel_dir(const warp_camera *c, warp_pose eye, int x, int y)
{
    double u, v;
    warp_camera_pixel_to_tan(c, x + 0.5, y + 0.5, &u, &v);
    return warp_quat_rotate(eye.q, warp_v3(u, v, -1));
}

static void test_planes_for_effects(void **state)
{
    (void)state;
    const unsigned C = SIM_PLANE_COLOR, D = SIM_PLANE_DEPTH, I = SIM_PLANE_IDS, M = SIM_PLANE_MOTION,
                   L = SIM_PLANE_LAYERS;
    assert_int_equal(sim_planes_for_effects(SIM_FX_HEAD_ROTATION), C);
    assert_int_equal(sim_planes_for_effects(SIM_FX_HEAD_TRANSLATION), C | D);
    assert_int_equal(sim_planes_for_effects(SIM_FX_DISOCCLUSION), C | D);
    assert_int_equal(sim_planes_for_effects(SIM_FX_OBJECT_MOTION), C | D | I | M);
    assert_int_equal(sim_planes_for_effects(SIM_FX_TRANSPARENCY), C | D | L);
    assert_int_equal(sim_planes_for_effects(SIM_FX_LENS), C);
    assert_int_equal(sim_planes_for_effects(SIM_FX_HEAD_ROTATION | SIM_FX_LENS), C);
    assert_int_equal(sim_planes_for_effects(0x3f), C | D | I | M | L);

    char buf[128];
    assert_string_equal(sim_planes_str(C | D | I, buf, sizeof buf), "color,depth,ids");
    assert_string_equal(sim_planes_str(M | L, buf, sizeof buf), "motion,layers");
    assert_string_equal(sim_effects_str(SIM_FX_HEAD_ROTATION | SIM_FX_HEAD_TRANSLATION, buf, sizeof buf),
                        "rotation,translation");
    assert_string_equal(sim_effects_str(SIM_FX_OBJECT_MOTION | SIM_FX_TRANSPARENCY | SIM_FX_DISOCCLUSION | SIM_FX_LENS,
                                        buf, sizeof buf),
                        "object_motion,transparency,disocclusion,lens");
    /* a short buffer truncates cleanly */
    char small[8];
    sim_planes_str(C | D | I, small, sizeof small);
    assert_true(strlen(small) < sizeof small);
}

static void test_scene_catalogue(void **state)
{
    (void)state;
    const unsigned R = SIM_FX_HEAD_ROTATION, T = SIM_FX_HEAD_TRANSLATION, O = SIM_FX_OBJECT_MOTION,
                   TR = SIM_FX_TRANSPARENCY, D = SIM_FX_DISOCCLUSION, L = SIM_FX_LENS;
    static const char *const names[] = {"room", "near", "hairball", "glass", "movers", "outdoor"};
    const unsigned fx[] = {R | L, R | T | D | L, R | T | D, R | T | TR, R | T | O, R | T};
    const char *const *list = sim_scene_names();
    int n = 0;
    while (list[n]) n++;
    assert_int_equal(n, 6);
    for (int i = 0; i < 6; i++) {
        const sim_scene *s = scene(names[i]);
        assert_string_equal(sim_scene_name(s), names[i]);
        assert_int_equal(sim_scene_effects(s), fx[i]);
        assert_true(strlen(sim_scene_description(s)) > 10);
        assert_true(sim_scene_object_count(s) >= 4);
        bool listed = false;
        for (int k = 0; k < n; k++) listed |= strcmp(list[k], names[i]) == 0;
        assert_true(listed);
    }
    assert_null(sim_scene_find("kitchen"));
    assert_null(sim_scene_find(NULL));
    assert_true(sim_scene_object_count(scene("hairball")) >= 200);

    /* the indoor scenes share the room's objects (same ids, same poses) */
    const sim_scene *room = scene("room");
    int nroom = sim_scene_object_count(room);
    for (int i = 1; i < 5; i++) {
        const sim_scene *s = scene(names[i]);
        assert_true(sim_scene_object_count(s) > nroom);
        for (int id = 1; id <= nroom; id++) {
            warp_pose a = sim_scene_object_pose(room, id, 1.0), b = sim_scene_object_pose(s, id, 1.0);
            assert_true(warp_v3_norm(warp_v3_sub(a.p, b.p)) == 0.0 && warp_quat_angle_between(a.q, b.q) == 0.0);
        }
    }
    /* unknown ids give the identity */
    warp_pose p = sim_scene_object_pose(room, 0, 0.0), q = sim_scene_object_pose(room, nroom + 1, 0.0);
    assert_true(p.q.w == 1 && warp_v3_norm(p.p) == 0 && q.q.w == 1 && warp_v3_norm(q.p) == 0);

    /* d_min: the room's ceiling is 1.4 m above the eyes; "near" has objects 0.4-0.5 m away; outdoors the ground */
    assert_true(fabs(sim_scene_min_depth(room) - 1.4) < 1e-9);
    double dn = sim_scene_min_depth(scene("near"));
    assert_true(dn >= 0.4 && dn < 0.5);
    assert_true(fabs(sim_scene_min_depth(scene("outdoor")) - 1.6) < 1e-9);
    double dh = sim_scene_min_depth(scene("hairball")), dg = sim_scene_min_depth(scene("glass"));
    assert_true(dh > 0.9 && dh < 1.4 && dg > 1.0 && dg < 1.4);
}

static void test_object_motion_model(void **state)
{
    (void)state;
    const sim_scene *s = scene("movers");
    int n = sim_scene_object_count(s), nroom = sim_scene_object_count(scene("room")), spinning = 0, moving = 0;
    for (int id = 1; id <= n; id++) {
        warp_pose p0 = sim_scene_object_pose(s, id, 0.0);
        double vmax = 0, wmax = 0, wmin = 1e9, excursion = 0;
        const double h = 0.01;
        for (int k = 0; k < 800; k++) {
            double t = k * h;
            warp_pose a = sim_scene_object_pose(s, id, t), b = sim_scene_object_pose(s, id, t + h);
            vmax = fmax(vmax, warp_v3_norm(warp_v3_sub(b.p, a.p)) / h);
            double w = warp_quat_angle_between(a.q, b.q) / h;
            wmax = fmax(wmax, w), wmin = fmin(wmin, w);
            excursion = fmax(excursion, warp_v3_norm(warp_v3_sub(a.p, p0.p)));
        }
        if (id <= nroom) {
            assert_true(vmax == 0.0 && wmax == 0.0); /* the room and its furniture are static */
            continue;
        }
        if (vmax > 0) {
            moving++;
            assert_true(vmax > 0.5 && vmax < 2.0); /* brisk but trackable translation */
            assert_true(excursion < 2.1);          /* periodic: stays in view */
        }
        if (wmax > 0) {
            spinning++;
            assert_true(fabs(wmax / DEG - 90) < 5 && fabs(wmin / DEG - 90) < 5);
        }
    }
    assert_true(moving >= 2 && spinning >= 2);
}

static void test_depth_matches_geometry(void **state)
{
    (void)state;
    const sim_scene *room = scene("room");
    warp_camera c = cam_make(160, 180);
    warp_pose eye = eye_at(0, 1.6, 0, 0, 0, 0);
    sim_buffers b;
    render_new(&b, room, 0, eye, &c, SIM_PLANE_DEPTH | SIM_PLANE_IDS, 1);
    /* straight ahead: the far wall 6 m away, fronto-parallel, so planar z is 6 at every pixel that sees it */
    for (int y = 82; y < 98; y++)
        for (int x = 65; x < 95; x++) {
            assert_true(fabs(WARP_AT(&b.depth, x, y) - 6.0) < 6e-4);
            assert_int_equal(WARP_AT(&b.ids, x, y), 1);
        }
    /* top row: the ceiling 1.4 m above the eye, planar z = 1.4 / v (not the distance along the ray) */
    for (int x = 10; x < 150; x += 7) {
        double u, v;
        warp_camera_pixel_to_tan(&c, x + 0.5, 0.5, &u, &v);
        assert_true(fabs(WARP_AT(&b.depth, x, 0) - 1.4 / v) < 1e-4 * (1.4 / v));
    }
    /* left edge: the left wall 3 m away, planar z = 3 / -u */
    for (int y = 85; y < 95; y++) {
        double u, v;
        warp_camera_pixel_to_tan(&c, 0.5, y + 0.5, &u, &v);
        assert_true(fabs(WARP_AT(&b.depth, 0, y) - 3.0 / -u) < 1e-4 * (3.0 / -u));
    }
    sim_buffers_free(&b);

    /* a sphere seen from a displaced, rotated eye: every pixel with its id has the analytic planar depth */
    eye = eye_at(0.3, 1.5, -0.5, 15, -5, 3);
    render_new(&b, room, 0, eye, &c, SIM_PLANE_DEPTH | SIM_PLANE_IDS, 1);
    warp_vec3 centre = sim_scene_object_pose(room, 3, 0).p;
    const double r = 0.55;
    int checked = 0;
    for (int y = 0; y < c.height; y++)
        for (int x = 0; x < c.width; x++) {
            warp_vec3 d = pixel_dir(&c, eye, x, y), oc = warp_v3_sub(eye.p, centre);
            double A = warp_v3_dot(d, d), B = warp_v3_dot(oc, d), C = warp_v3_dot(oc, oc) - r * r;
            double disc = B * B - A * C;
            bool hit = disc > 1e-3 * B * B; /* clear of the silhouette */
            if (!hit) continue;
            double t = (-B - sqrt(disc)) / A;
            if (WARP_AT(&b.ids, x, y) != 3) { /* something nearer in front of it */
                assert_true(WARP_AT(&b.depth, x, y) < t);
                continue;
            }
            assert_true(fabs(WARP_AT(&b.depth, x, y) - t) < 1e-4 * t);
            checked++;
        }
    assert_true(checked > 100);
    sim_buffers_free(&b);
}

static int id_at(const sim_buffers *b, const warp_camera *c, warp_pose eye, warp_vec3 pw)
{
    double x, y;
    assert_true(project(c, eye, pw, &x, &y, NULL));
    assert_true(x >= 0 && y >= 0 && x < c->width && y < c->height);
    return WARP_AT(&b->ids, (int)x, (int)y);
}

static void test_ids_of_known_objects(void **state)
{
    (void)state;
    warp_camera c = cam_make(200, 220);
    warp_pose eye = eye_at(0, 1.6, 0, 0, 0, 0);
    sim_buffers b;
    const sim_scene *room = scene("room");
    render_new(&b, room, 0, eye, &c, SIM_PLANE_IDS | SIM_PLANE_DEPTH, 1);
    for (int id = 2; id <= 5; id++) assert_int_equal(id_at(&b, &c, eye, sim_scene_object_pose(room, id, 0).p), id);
    sim_buffers_free(&b);

    const sim_scene *near = scene("near");
    render_new(&b, near, 0, eye, &c, SIM_PLANE_IDS | SIM_PLANE_DEPTH, 1);
    for (int id = 7; id <= 9; id++) assert_int_equal(id_at(&b, &c, eye, sim_scene_object_pose(near, id, 0).p), id);
    assert_int_equal(id_at(&b, &c, eye, sim_scene_object_pose(near, 11, 0).p), 11);
    /* the pillar, above the objects in front of it */
    warp_vec3 top = warp_v3_add(sim_scene_object_pose(near, 10, 0).p, warp_v3(0, 0.9, 0));
    assert_int_equal(id_at(&b, &c, eye, top), 10);
    /* behind the near box the far wall continues: a strong depth edge */
    double x, y;
    assert_true(project(&c, eye, sim_scene_object_pose(near, 7, 0).p, &x, &y, NULL));
    float zin = WARP_AT(&b.depth, (int)x, (int)y);
    assert_true(zin < 0.8f);
    sim_buffers_free(&b);

    const sim_scene *hair = scene("hairball");
    render_new(&b, hair, 0, eye, &c, SIM_PLANE_IDS | SIM_PLANE_DEPTH, 1);
    /* the ball is dense: strands cover its centre, and many different strands are visible */
    assert_true(id_at(&b, &c, eye, warp_v3(0, 1.6, -1.5)) > 6);
    static unsigned char seen[4096];
    memset(seen, 0, sizeof seen);
    int distinct = 0;
    for (int yy = 0; yy < c.height; yy++)
        for (int xx = 0; xx < c.width; xx++) {
            int id = WARP_AT(&b.ids, xx, yy);
            if (id > 6 && id < 4096 && !seen[id]) seen[id] = 1, distinct++;
        }
    assert_true(distinct > 100);
    sim_buffers_free(&b);

    /* outdoors, straight up is sky: id 0, infinite depth */
    render_new(&b, scene("outdoor"), 0, eye_at(0, 1.6, 0, 0, 80, 0), &c, SIM_PLANE_IDS | SIM_PLANE_DEPTH, 1);
    assert_int_equal(WARP_AT(&b.ids, 100, 110), 0);
    assert_true(isinf(WARP_AT(&b.depth, 100, 110)) && WARP_AT(&b.depth, 100, 110) > 0);
    sim_buffers_free(&b);
}

static void test_room_is_enclosed(void **state)
{
    (void)state;
    warp_camera c = cam_make(64, 72);
    static const double ypr[][3] = {{0, 0, 0}, {90, 0, 0}, {180, 10, 0}, {-90, 0, 20}, {30, 70, 0}, {-20, -70, 0}};
    static const char *const names[] = {"room", "near", "hairball", "glass", "movers"};
    for (int s = 0; s < 5; s++)
        for (int i = 0; i < 6; i++) {
            sim_buffers b;
            render_new(&b, scene(names[s]), 0.4, eye_at(0.1, 1.55, 0.05, ypr[i][0], ypr[i][1], ypr[i][2]), &c,
                       SIM_PLANE_IDS | SIM_PLANE_DEPTH | SIM_PLANE_COLOR, 1);
            for (int y = 0; y < c.height; y++)
                for (int x = 0; x < c.width; x++) {
                    assert_true(WARP_AT(&b.ids, x, y) != 0);
                    float z = WARP_AT(&b.depth, x, y);
                    assert_true(z > 0.05f && z < 12.0f);
                    warp_rgba8 px = WARP_AT(&b.color, x, y);
                    assert_true(px.a == 255 && px.r + px.g + px.b > 60); /* lit, textured surfaces everywhere */
                }
            sim_buffers_free(&b);
        }
}

static bool planes_equal(const sim_buffers *a, const sim_buffers *b, unsigned planes, int w, int h)
{
    for (int y = 0; y < h; y++) {
        if ((planes & SIM_PLANE_COLOR) && memcmp(&WARP_AT(&a->color, 0, y), &WARP_AT(&b->color, 0, y), (size_t)w * 4))
            return false;
        if ((planes & SIM_PLANE_DEPTH) && memcmp(&WARP_AT(&a->depth, 0, y), &WARP_AT(&b->depth, 0, y), (size_t)w * 4))
            return false;
        if ((planes & SIM_PLANE_IDS) && memcmp(&WARP_AT(&a->ids, 0, y), &WARP_AT(&b->ids, 0, y), (size_t)w * 2))
            return false;
        if ((planes & SIM_PLANE_MOTION) &&
            memcmp(&WARP_AT(&a->motion, 0, y), &WARP_AT(&b->motion, 0, y), (size_t)w * sizeof(warp_vec2f)))
            return false;
    }
    if (planes & SIM_PLANE_LAYERS) {
        int ml = a->layers.max_layers;
        for (int i = 0; i < w * h; i++) {
            if (a->layers.count[i] != b->layers.count[i]) return false;
            if (memcmp(&a->layers.frag[(size_t)i * ml], &b->layers.frag[(size_t)i * ml],
                       a->layers.count[i] * sizeof(warp_fragment)))
                return false;
        }
    }
    return true;
}

static void test_row_split_is_deterministic(void **state)
{
    (void)state;
    /* odd sizes: partial tiles and partial 4-pixel groups at the right and bottom edges */
    warp_camera c = cam_make(101, 90);
    static const char *const names[] = {"glass", "movers", "hairball", "outdoor", "near"};
    static const int cuts[][2] = {{33, 34}, {0, 7}, {34, 90}, {7, 33}}; /* out of order, one single row */
    for (int s = 0; s < 5; s++) {
        const sim_scene *sc = scene(names[s]);
        warp_pose eye = eye_at(0.05, 1.62, -0.1, 8, -4, 1);
        sim_buffers a, b, d;
        render_new(&a, sc, 0.73, eye, &c, ALL_PLANES, 3);
        render_new(&d, sc, 0.73, eye, &c, ALL_PLANES, 3);
        assert_true(planes_equal(&a, &d, ALL_PLANES, c.width, c.height)); /* same inputs, same bytes */
        assert_true(sim_buffers_alloc(&b, c.width, c.height, ALL_PLANES, 3));
        for (int k = 0; k < 4; k++) sim_render_rows(sc, 0.73, eye, &c, ALL_PLANES, &b, cuts[k][0], cuts[k][1]);
        assert_true(planes_equal(&a, &b, ALL_PLANES, c.width, c.height));
        sim_buffers_free(&a);
        sim_buffers_free(&b);
        sim_buffers_free(&d);
    }
}

static void fill_sentinel(sim_buffers *b)
{
    if (b->color.px) memset(b->color.px, 0x5a, (size_t)b->color.stride * b->color.h * 4);
    if (b->depth.px) memset(b->depth.px, 0x5a, (size_t)b->depth.stride * b->depth.h * 4);
    if (b->ids.px) memset(b->ids.px, 0x5a, (size_t)b->ids.stride * b->ids.h * 2);
    if (b->motion.px) memset(b->motion.px, 0x5a, (size_t)b->motion.stride * b->motion.h * sizeof(warp_vec2f));
    if (b->layers.count) {
        memset(b->layers.count, 0x5a, (size_t)b->layers.w * b->layers.h);
        memset(b->layers.frag, 0x5a, (size_t)b->layers.w * b->layers.h * b->layers.max_layers * sizeof(warp_fragment));
    }
}

static bool all_bytes(const void *p, size_t n, unsigned char v)
{
    const unsigned char *c = p;
    for (size_t i = 0; i < n; i++)
        if (c[i] != v) return false;
    return true;
}

static void test_unrequested_planes_untouched(void **state)
{
    (void)state;
    warp_camera c = cam_make(48, 40);
    const sim_scene *s = scene("glass");
    warp_pose eye = eye_at(0, 1.6, 0, 0, 0, 0);
    sim_buffers b;
    assert_true(sim_buffers_alloc(&b, c.width, c.height, ALL_PLANES, 2));
    assert_int_equal(b.planes, ALL_PLANES);
    size_t n = (size_t)c.width * c.height;

    fill_sentinel(&b);
    sim_render(s, 0, eye, &c, SIM_PLANE_COLOR, &b);
    assert_true(all_bytes(b.depth.px, (size_t)b.depth.stride * c.height * 4, 0x5a));
    assert_true(all_bytes(b.ids.px, (size_t)b.ids.stride * c.height * 2, 0x5a));
    assert_true(all_bytes(b.motion.px, (size_t)b.motion.stride * c.height * sizeof(warp_vec2f), 0x5a));
    assert_true(all_bytes(b.layers.count, n, 0x5a));
    assert_true(all_bytes(b.layers.frag, n * 2 * sizeof(warp_fragment), 0x5a));
    assert_false(all_bytes(b.color.px, n * 4, 0x5a));

    fill_sentinel(&b);
    sim_render(s, 0, eye, &c, SIM_PLANE_DEPTH | SIM_PLANE_LAYERS, &b);
    assert_true(all_bytes(b.color.px, (size_t)b.color.stride * c.height * 4, 0x5a));
    assert_true(all_bytes(b.ids.px, (size_t)b.ids.stride * c.height * 2, 0x5a));
    assert_true(all_bytes(b.motion.px, (size_t)b.motion.stride * c.height * sizeof(warp_vec2f), 0x5a));
    assert_false(all_bytes(b.layers.count, n, 0x5a));

    /* rows outside the range are not written */
    fill_sentinel(&b);
    sim_render_rows(s, 0, eye, &c, SIM_PLANE_COLOR | SIM_PLANE_IDS, &b, 10, 20);
    for (int y = 0; y < c.height; y++) {
        bool inside = y >= 10 && y < 20;
        assert_true(all_bytes(&WARP_AT(&b.color, 0, y), (size_t)c.width * 4, 0x5a) != inside);
        assert_true(all_bytes(&WARP_AT(&b.ids, 0, y), (size_t)c.width * 2, 0x5a) != inside);
    }
    sim_buffers_free(&b);

    /* planes asked for but not allocated are skipped, not written through NULL */
    sim_buffers d;
    assert_true(sim_buffers_alloc(&d, c.width, c.height, SIM_PLANE_DEPTH, 1));
    assert_null(d.color.px);
    sim_render(s, 0, eye, &c, ALL_PLANES, &d);
    assert_true(fabs(WARP_AT(&d.depth, 24, 20) - 6.0) < 1e-3); /* the pane 1.3 m ahead is not in the depth: the wall is */
    sim_buffers_free(&d);
}

static void test_motion_vectors(void **state)
{
    (void)state;
    const sim_scene *s = scene("movers");
    int nroom = sim_scene_object_count(scene("room")), n = sim_scene_object_count(s);
    warp_camera c = cam_make(160, 180);
    warp_pose eye = eye_at(0.1, 1.6, 0.2, 4, 3, 0);
    const double t = 0.3, h = 1e-4;
    sim_buffers b;
    render_new(&b, s, t, eye, &c, SIM_PLANE_MOTION | SIM_PLANE_IDS | SIM_PLANE_DEPTH, 1);
    /* per pixel: carry the visible surface point with its object's pose from t to t + h and reproject */
    int moving = 0;
    double fastest = 0;
    for (int y = 0; y < c.height; y++)
        for (int x = 0; x < c.width; x++) {
            int id = WARP_AT(&b.ids, x, y);
            warp_vec2f m = WARP_AT(&b.motion, x, y);
            if (id <= nroom) {
                assert_true(m.x == 0.0f && m.y == 0.0f); /* static: no motion */
                continue;
            }
            assert_true(id <= n);
            warp_vec3 pw = warp_v3_add(eye.p, warp_v3_scale(pixel_dir(&c, eye, x, y), WARP_AT(&b.depth, x, y)));
            warp_vec3 po = warp_pose_apply(warp_pose_inverse(sim_scene_object_pose(s, id, t)), pw);
            warp_vec3 p1 = warp_pose_apply(sim_scene_object_pose(s, id, t + h), po);
            double x1, y1;
            assert_true(project(&c, eye, p1, &x1, &y1, NULL));
            double ex = (x1 - (x + 0.5)) / h, ey = (y1 - (y + 0.5)) / h;
            double err = hypot(m.x - ex, m.y - ey), mag = hypot(ex, ey);
            assert_true(err < 0.01 * mag + 0.05);
            fastest = fmax(fastest, mag);
            moving++;
        }
    assert_true(moving > 500 && fastest > 30.0);
    sim_buffers_free(&b);

    /* between two renders: moving render(t0) by its motion vectors registers it onto render(t1). The sphere only
     * translates (its shading stays put on its surface), so the best scale of the vectors must be 1 within a few
     * percent. The interval is centred on its peak speed, where the velocity is nearly constant. */
    warp_camera z = warp_camera_symmetric(320, 360, 70, 76, 0.05, INFINITY);
    const int sphere = nroom + 1;
    const double dt = 0.1, t0 = 2.0 - dt / 2;
    warp_pose ez = eye_at(0, 1.6, 0, 0, -4, 0);
    sim_buffers b0, b1;
    render_new(&b0, s, t0, ez, &z, SIM_PLANE_COLOR | SIM_PLANE_MOTION | SIM_PLANE_IDS, 1);
    render_new(&b1, s, t0 + dt, ez, &z, SIM_PLANE_COLOR | SIM_PLANE_IDS, 1);
    double best_err = 1e30, best_scale = 0, err_at_1 = 0, err_off = 0;
    for (int si = -20; si <= 20; si++) {
        double scale = 1.0 + 0.005 * si, se = 0;
        long cnt = 0;
        for (int y = 0; y < z.height; y++)
            for (int x = 0; x < z.width; x++) {
                if (WARP_AT(&b0.ids, x, y) != sphere) continue;
                warp_vec2f m = WARP_AT(&b0.motion, x, y);
                double qx = x + 0.5 + scale * m.x * dt, qy = y + 0.5 + scale * m.y * dt;
                int ix = (int)floor(qx), iy = (int)floor(qy);
                bool inside = ix >= 2 && iy >= 2 && ix < z.width - 2 && iy < z.height - 2;
                for (int dy = -2; inside && dy <= 2; dy++)
                    for (int dx = -2; inside && dx <= 2; dx++) inside = WARP_AT(&b1.ids, ix + dx, iy + dy) == sphere;
                if (!inside) continue;
                warp_rgba8 p0 = WARP_AT(&b0.color, x, y), p1 = warp_sample_bilinear(&b1.color, (float)qx, (float)qy);
                se += (p0.r - p1.r) * (p0.r - p1.r) + (p0.g - p1.g) * (p0.g - p1.g) + (p0.b - p1.b) * (p0.b - p1.b);
                cnt++;
            }
        assert_true(cnt > 500);
        double e = se / cnt;
        if (e < best_err) best_err = e, best_scale = scale;
        if (si == 0) err_at_1 = e;
        if (si == 20) err_off = e;
    }
    assert_true(fabs(best_scale - 1.0) <= 0.03);
    assert_true(err_off > 2.0 * err_at_1); /* the texture is detailed enough to tell a 10 % error */
    /* and the image really moved: the sphere runs at ~1.6 m/s across the view */
    double mx = 0;
    for (int y = 0; y < z.height; y++)
        for (int x = 0; x < z.width; x++)
            if (WARP_AT(&b0.ids, x, y) == sphere) mx = fmax(mx, fabs(WARP_AT(&b0.motion, x, y).x));
    assert_true(mx * dt > 5.0);
    sim_buffers_free(&b0);
    sim_buffers_free(&b1);
}

static void test_layers_and_blend(void **state)
{
    (void)state;
    const sim_scene *glass = scene("glass");
    int nroom = sim_scene_object_count(scene("room"));
    warp_camera c = cam_make(160, 180);
    warp_pose eye = eye_at(0, 1.6, 0, 0, 0, 0);
    sim_buffers g4, g2, room;
    render_new(&g4, glass, 0, eye, &c, SIM_PLANE_COLOR | SIM_PLANE_DEPTH | SIM_PLANE_LAYERS, 4);
    render_new(&g2, glass, 0, eye, &c, SIM_PLANE_COLOR | SIM_PLANE_LAYERS, 2);
    render_new(&room, scene("room"), 0, eye, &c, SIM_PLANE_COLOR | SIM_PLANE_DEPTH, 1);
    int hist[5] = {0};
    for (int y = 0; y < c.height; y++)
        for (int x = 0; x < c.width; x++) {
            size_t i = (size_t)y * c.width + x;
            int n4 = g4.layers.count[i], n2 = g2.layers.count[i];
            assert_true(n4 <= 4 && n2 <= 2 && n2 == (n4 < 2 ? n4 : 2));
            hist[n4]++;
            const warp_fragment *f = &g4.layers.frag[i * 4];
            for (int k = 0; k < n4; k++) {
                assert_true(f[k].id > nroom && f[k].id <= nroom + 3);
                assert_true(f[k].z < WARP_AT(&g4.depth, x, y)); /* in front of the opaque surface */
                if (k) assert_true(f[k].z > f[k - 1].z);        /* nearest first */
                assert_true(f[k].rgba.a >= 76 && f[k].rgba.a <= 153); /* alpha 0.3-0.6 */
            }
            /* truncation keeps the nearest ones, the colour still blends all of them */
            assert_memory_equal(f, &g2.layers.frag[i * 2], (size_t)n2 * sizeof(warp_fragment));
            assert_memory_equal(&WARP_AT(&g4.color, x, y), &WARP_AT(&g2.color, x, y), 4);
            /* depth and opaque colour are the room's: the panes are blended "over" it, back to front, in linear
             * light (issue #21: as renderers blend, and as warp_transparency un-blends) */
            assert_true(WARP_AT(&g4.depth, x, y) == WARP_AT(&room.depth, x, y));
            warp_rgba8 o = WARP_AT(&room.color, x, y), got = WARP_AT(&g4.color, x, y);
            const float *lin = warp_srgb_to_linear_u8;
            double cc[3] = {lin[o.r], lin[o.g], lin[o.b]};
            for (int k = n4 - 1; k >= 0; k--) {
                double a = f[k].rgba.a / 255.0, fc[3] = {lin[f[k].rgba.r], lin[f[k].rgba.g], lin[f[k].rgba.b]};
                for (int ch = 0; ch < 3; ch++) cc[ch] = a * fc[ch] + (1 - a) * cc[ch];
            }
            for (int ch = 0; ch < 3; ch++) cc[ch] = 255.0 * warp_srgb_encode((float)cc[ch]);
            assert_true(fabs(cc[0] - got.r) <= 2.0 && fabs(cc[1] - got.g) <= 2.0 && fabs(cc[2] - got.b) <= 2.0);
            if (n4 == 0) assert_memory_equal(&o, &got, 4);
        }
    assert_true(hist[1] > 500 && hist[2] > 500 && hist[3] > 100); /* overlapping panes: up to three deep */
    sim_buffers_free(&g4);
    sim_buffers_free(&g2);
    sim_buffers_free(&room);
}

static void test_sky_depends_on_direction_only(void **state)
{
    (void)state;
    const sim_scene *s = scene("outdoor");
    warp_camera c = cam_make(96, 108);
    sim_buffers a, b, r;
    render_new(&a, s, 0, eye_at(0, 1.6, 0, 20, 35, 0), &c, SIM_PLANE_COLOR | SIM_PLANE_IDS, 1);
    render_new(&b, s, 0, eye_at(1, 1.6, 0, 20, 35, 0), &c, SIM_PLANE_COLOR | SIM_PLANE_IDS, 1);
    render_new(&r, s, 0, eye_at(0, 1.6, 0, 25, 35, 0), &c, SIM_PLANE_COLOR | SIM_PLANE_IDS, 1);
    int sky = 0, moved = 0;
    double sum = 0, sum2 = 0;
    for (int y = 0; y < c.height; y++)
        for (int x = 0; x < c.width; x++) {
            if (WARP_AT(&a.ids, x, y) || WARP_AT(&b.ids, x, y)) continue;
            warp_rgba8 pa = WARP_AT(&a.color, x, y), pb = WARP_AT(&b.color, x, y), pr = WARP_AT(&r.color, x, y);
            assert_memory_equal(&pa, &pb, 4); /* 1 m apart, the same direction: the same sky */
            sky++;
            sum += pa.b, sum2 += (double)pa.b * pa.b;
            moved += abs(pa.r - pr.r) + abs(pa.g - pr.g) + abs(pa.b - pr.b) > 6;
        }
    assert_true(sky > c.width * c.height / 2);
    double mean = sum / sky, sd = sqrt(sum2 / sky - mean * mean);
    assert_true(sd > 6.0);            /* visible detail (gridlines, clouds), not a flat colour */
    assert_true(moved > sky / 10);    /* fixed to the world, not to the screen */
    sim_buffers_free(&a);
    sim_buffers_free(&b);
    sim_buffers_free(&r);
}

/* PSNR of a rotation-only reprojection (003 §3.4) of render a, bilinear, against render b. */
static double rotation_warp_psnr(const sim_scene *s, const warp_camera *c, warp_pose e0, warp_quat dq)
{
    sim_buffers a, b;
    warp_pose e1 = e0;
    e1.q = warp_quat_mul(e0.q, dq);
    render_new(&a, s, 0, e0, c, SIM_PLANE_COLOR, 1);
    render_new(&b, s, 0, e1, c, SIM_PLANE_COLOR, 1);
    warp_mat3 hm = warp_rotation_homography(c, c, dq);
    double se = 0;
    long n = 0;
    for (int y = 0; y < c->height; y++)
        for (int x = 0; x < c->width; x++) {
            double p[3] = {x + 0.5, y + 0.5, 1}, q[3];
            for (int i = 0; i < 3; i++) q[i] = hm.m[i][0] * p[0] + hm.m[i][1] * p[1] + hm.m[i][2] * p[2];
            double sx = q[0] / q[2], sy = q[1] / q[2];
            if (sx < 1 || sy < 1 || sx > c->width - 1 || sy > c->height - 1) continue;
            warp_rgba8 w = warp_sample_bilinear(&a.color, (float)sx, (float)sy), g = WARP_AT(&b.color, x, y);
            se += (w.r - g.r) * (w.r - g.r) + (w.g - g.g) * (w.g - g.g) + (w.b - g.b) * (w.b - g.b);
            n += 3;
        }
    sim_buffers_free(&a);
    sim_buffers_free(&b);
    assert_true(n > (long)c->width * c->height);
    return 10 * log10(255.0 * 255.0 / (se / (double)n));
}

static void test_rotation_warp_quality(void **state)
{
    (void)state;
    /* the textures are band-limited to the pixel footprint, so resampling a render matches a render from the
     * resampled pose; a correct rotation warp of "room" must stay well above 30 dB */
    warp_camera c = cam_make(320, 360);
    warp_pose e = eye_at(0, 1.6, 0, 0, 0, 0);
    double p1 = rotation_warp_psnr(scene("room"), &c, e, warp_quat_from_ypr(2.3 * DEG, 1.1 * DEG, 0));
    double p2 = rotation_warp_psnr(scene("room"), &c, e, warp_quat_from_ypr(-4.0 * DEG, -2.5 * DEG, 1.5 * DEG));
    double p3 = rotation_warp_psnr(scene("outdoor"), &c, eye_at(0, 1.6, 0, 0, 10, 0), warp_quat_from_ypr(3 * DEG, 1 * DEG, 0));
    assert_true(p1 > 35.0 && p2 > 35.0 && p3 > 33.0);
    /* and a wrong warp shows: a 0.5 degree misregistration costs well over 8 dB */
    sim_buffers a, b;
    render_new(&a, scene("room"), 0, e, &c, SIM_PLANE_COLOR, 1);
    render_new(&b, scene("room"), 0, eye_at(0, 1.6, 0, 0.5, 0, 0), &c, SIM_PLANE_COLOR, 1);
    double se = 0;
    for (int y = 0; y < c.height; y++)
        for (int x = 0; x < c.width; x++) {
            warp_rgba8 p = WARP_AT(&a.color, x, y), q = WARP_AT(&b.color, x, y);
            se += (p.r - q.r) * (p.r - q.r) + (p.g - q.g) * (p.g - q.g) + (p.b - q.b) * (p.b - q.b);
        }
    double pw = 10 * log10(255.0 * 255.0 / (se / (3.0 * c.width * c.height)));
    assert_true(pw < p1 - 8.0);
    sim_buffers_free(&a);
    sim_buffers_free(&b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_planes_for_effects),
        cmocka_unit_test(test_scene_catalogue),
        cmocka_unit_test(test_object_motion_model),
        cmocka_unit_test(test_depth_matches_geometry),
        cmocka_unit_test(test_ids_of_known_objects),
        cmocka_unit_test(test_room_is_enclosed),
        cmocka_unit_test(test_row_split_is_deterministic),
        cmocka_unit_test(test_unrequested_planes_untouched),
        cmocka_unit_test(test_motion_vectors),
        cmocka_unit_test(test_layers_and_blend),
        cmocka_unit_test(test_sky_depends_on_direction_only),
        cmocka_unit_test(test_rotation_warp_quality),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
