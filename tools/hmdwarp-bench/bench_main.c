/* SPDX-License-Identifier: MIT */
/* hmdwarp-bench: what accuracy costs in time. Times hmdwarpd's own display path (its CPU render pass: rotation +
 * lens + chromatic aberration, both eyes) against a memcpy of the frame and OpenCV's cv::remap measured interleaved
 * in the same run, sweeps every warp of the catalogue x its knobs x scenes x motion magnitudes against ground
 * truth, and soaks hmdwarpd at 90 Hz. Writes a CSV, a Markdown table and gnuplot plots. */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sched.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "bench_display.h"
#include "bench_link.h"
#include "bench_opencv.h"
#include "bench_samples.h"
#include "platform/plat_clock.h"
#include "platform/plat_egl.h"
#include "platform/plat_gles.h"
#include "platform/plat_version.h"
#include "platform/plat_workers.h"
#include "runtime/rt_config.h"
#include "runtime/rt_kernel.h"
#include "runtime/rt_render_cpu.h"
#include "sim/sim_scene.h"
#include "tools/common/cat_warps.h"
#include "tools/hmdwarp-bench/bench_rolling.h"
#include "warp/warp_metrics.h"
#include "warp/warp_mesh.h"
#include "warp/warp_mesh_trace.h"
#include "warp/warp_raytrace.h"
#include "warp/warp_resample.h"

#define MAX_REPS BENCH_MAX_SAMPLES

typedef struct {
    bool quick;
    int eye_w, eye_h; /* --eye: 0 = the reference (or quick) size */
    const char *out;
    const char *hmdwarpd;
    double soak_s;
    int reps;
    int threads;
    bool link_only; /* --link-only: the link section alone */
    bool rolling_only; /* --rolling-only: the rolling-scan section alone */
} opts;

/* ---- scenes and ground truth ---- */

typedef struct {
    const sim_scene *scene;
    warp_camera cam;
    sim_buffers src, truth;
    warp_image_f32 inv;
    warp_image_u8 band; /* 0 within 3 px of the truth's depth edges (warp_depth_edge_band), 1 elsewhere */
    warp_view v;
    warp_pose a, b;
    double t0, t1;
    warp_pose objs[64];
} frame_case;

static const unsigned ALL_PLANES =
    SIM_PLANE_COLOR | SIM_PLANE_DEPTH | SIM_PLANE_IDS | SIM_PLANE_MOTION | SIM_PLANE_LAYERS;

static bool case_alloc(frame_case *fc, const warp_camera *cam)
{
    memset(fc, 0, sizeof *fc);
    fc->cam = *cam;
    return sim_buffers_alloc(&fc->src, cam->width, cam->height, ALL_PLANES, 8) &&
           sim_buffers_alloc(&fc->truth, cam->width, cam->height, SIM_PLANE_COLOR | SIM_PLANE_DEPTH, 1) &&
           warp_image_f32_alloc(&fc->inv, cam->width, cam->height) &&
           warp_image_u8_alloc(&fc->band, cam->width, cam->height);
}

/* Renders the source at the left eye's rest pose and the truth after a head motion of `deg` yaw and `cm`
 * sideways (the motion a host frame's age has to bridge), `dt` of scene time later. */
static void case_render(frame_case *fc, const sim_scene *sc, double deg, double cm, double dt)
{
    fc->scene = sc;
    fc->a = (warp_pose){warp_quat_from_ypr(0.1, 0.02, 0), warp_v3(-0.032, 1.6, 0)};
    warp_pose d = {warp_quat_from_ypr(deg * WARP_PI / 180, 0, 0), warp_v3(cm * 0.01, 0, 0)};
    fc->b = warp_pose_mul(fc->a, d);
    fc->t0 = 1.0;
    fc->t1 = 1.0 + dt;
    sim_render(sc, fc->t0, fc->a, &fc->cam, ALL_PLANES, &fc->src);
    sim_render(sc, fc->t1, fc->b, &fc->cam, SIM_PLANE_COLOR | SIM_PLANE_DEPTH, &fc->truth);
    /* #21's depth-edge band, as tests/accuracy scores it: within 3 px of a relative depth jump over 10 % (a scene
     * without an edge leaves it empty: its band PSNR is NAN, which no target row counts) */
    warp_depth_edge_band(&fc->truth.depth, 0.1f, 3, &fc->band);
    int n = sim_scene_object_count(sc) < 64 ? sim_scene_object_count(sc) : 64;
    for (int i = 0; i < n; i++) fc->objs[i] = sim_scene_object_pose(sc, i + 1, fc->t0);
    fc->v = (warp_view){.cam = fc->cam, .pose = fc->a, .color = &fc->src.color, .inv_depth = &fc->inv,
                        .ids = &fc->src.ids, .motion = &fc->src.motion, .layers = &fc->src.layers, .n_objects = n,
                        .object_pose = fc->objs, .time = fc->t0};
    warp_inverse_depth_from(&fc->cam, WARP_DEPTH_LINEAR, &fc->src.depth, &fc->inv, &fc->v.inv_depth_min,
                            &fc->v.inv_depth_max);
}

static void case_free(frame_case *fc)
{
    sim_buffers_free(&fc->src);
    sim_buffers_free(&fc->truth);
    warp_image_free(&fc->inv);
    warp_image_free(&fc->band);
}

/* ---- knobs swept per warp (a warp not listed runs once with its defaults) ---- */

typedef struct {
    const char *warp;
    const char *params[6];
} knob_set;

static const knob_set knobs[] = {
    {"raytrace", {"steps=16", "steps=64", "steps=512", "steps=512,refine=0", NULL, NULL}},
    {"raytrace_mesh", {"mesh=64", "mesh=128", "mesh=64,cells=0", NULL, NULL, NULL}},
    {"iterative", {"seeds=1,bound=0", "seeds=1,bound=1", "seeds=4,bound=1", "seeds=8,bound=2,fill=2",
                   "seeds=8,iters=8,bound=2,dilate=1,awoc=1", NULL}},
    {"grid", {"strategy=0", "strategy=1", "strategy=2", "strategy=3", "strategy=3,fill=2", NULL}},
};

static int knob_list(const char *warp, const char *out[8])
{
    for (size_t i = 0; i < sizeof knobs / sizeof knobs[0]; i++)
        if (strcmp(knobs[i].warp, warp) == 0) {
            int n = 0;
            while (n < 6 && knobs[i].params[n]) {
                out[n] = knobs[i].params[n];
                n++;
            }
            return n;
        }
    out[0] = NULL;
    return 1;
}

/* ---- the display path: hmdwarpd's CPU pass (bench_display) ---- */

/* The two eyes' cases as the host frame the pass warps (colour and depth, prepared as hmdwarpd does). */
static bool load_frame(bench_display *d, frame_case fc[2], uint64_t seq)
{
    const warp_camera cam[2] = {fc[0].cam, fc[1].cam};
    const warp_pose pose[2] = {fc[0].a, fc[1].a};
    const warp_image_rgba8 *const color[2] = {&fc[0].src.color, &fc[1].src.color};
    const warp_image_f32 *const depth[2] = {&fc[0].src.depth, &fc[1].src.depth};
    char err[200];
    if (bench_display_set_frame(d, cam, pose, color, depth, seq, err, sizeof err)) return true;
    fprintf(stderr, "hmdwarp-bench: the host frame: %s\n", err);
    return false;
}

/* One vsync of the pass, in ms. A pass that ran another method than asked (its fallback) would time the wrong
 * path: that stops the bench. */
static double timed(bench_display *d, int which, const warp_pose eyes[2], rt_method m)
{
    int64_t t = plat_now_ns();
    rt_method ran = bench_display_run(d, which, eyes, m);
    double ms = (double)(plat_now_ns() - t) * 1e-6;
    if (ran != m) {
        fprintf(stderr, "hmdwarp-bench: the display path ran %s instead of %s\n", rt_method_name(ran),
                rt_method_name(m));
        exit(1);
    }
    return ms;
}

/* ---- output ---- */

typedef struct {
    char scene[16], warp[24], params[48];
    double motion_deg, motion_cm;
    double med_ms, p99_ms;
    double psnr, ssim, err;
    double band_psnr; /* over the depth-edge band (NAN: the scene has no depth edge) */
    long primitives, samples;
    bool pareto;
} sweep_row;

#define MAX_ROWS 2048

static bool run_gnuplot(const char *dir, const char *script)
{
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "cd '%s' && gnuplot '%s' 2>&1", dir, script);
    int rc = system(cmd);
    return rc == 0;
}

/* One soak of hmdwarpd on the simulated board (its board.ini plus `extra` settings), summary in OUT/NAME.txt and its
 * --stats in OUT/NAME.kv; vsyncs < 0 when it did not run. */
typedef struct {
    long vsyncs, missed, own, late, desched;
    double m2p_p50, reserve_ms;
} soak_result;

/* A stolen CPU, reproducibly: a child at SCHED_FIFO 90 on CPU 0 that every 0.5-0.9 s spins for stall_ms, as a
 * hypervisor or an interrupt storm takes the CPU away from whatever runs there. 0 when not permitted. */
static pid_t start_stalls(double stall_ms)
{
    pid_t pid = fork();
    if (pid != 0) return pid < 0 ? 0 : pid;
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(0, &set);
    struct sched_param sp = {.sched_priority = 90};
    if (sched_setaffinity(0, sizeof set, &set) != 0 || sched_setscheduler(0, SCHED_FIFO, &sp) != 0) _exit(1);
    uint32_t seed = 1; /* no rand(): the child of a threaded process keeps to plain code and system calls */
    for (;;) {
        seed = seed * 1664525u + 1013904223u;
        plat_sleep_ns((int64_t)((500 + (seed >> 8) % 400) * 1e6));
        int64_t end = plat_now_ns() + (int64_t)(stall_ms * 1e6);
        while (plat_now_ns() < end) {
        }
    }
}

static soak_result soak(const char *hmdwarpd, const opts *o, const char *name, const char *extra, double seconds,
                        double stall_ms)
{
    soak_result r = {-1, -1, -1, -1, -1, NAN, NAN};
    pid_t stalls = 0;
    if (stall_ms > 0) {
        stalls = start_stalls(stall_ms);
        usleep(100000);
        int st;
        if (!stalls || waitpid(stalls, &st, WNOHANG) != 0) {
            printf("soak: %s skipped: SCHED_FIFO on CPU 0 not permitted for the stall injector\n", name);
            return r;
        }
    }
    char cmd[4096], stats[700];
    snprintf(stats, sizeof stats, "%s/%s.kv", o->out, name);
    snprintf(cmd, sizeof cmd, "%s --config board/sim/board.ini --duration %g --set warp.method=rotation "
             "--set sim.eval_every_ms=0 %s --stats %s > %s/%s.txt 2>&1", hmdwarpd, seconds, extra, stats, o->out, name);
    printf("soak: %s%s\n", cmd, stalls ? " (with stalls injected)" : "");
    fflush(stdout);
    int rc = system(cmd);
    if (stalls) {
        kill(stalls, SIGKILL);
        waitpid(stalls, NULL, 0);
    }
    if (rc != 0) return r;
    FILE *f = fopen(stats, "r");
    char line[256];
    while (f && fgets(line, sizeof line, f)) {
        if (!strncmp(line, "vsyncs=", 7)) r.vsyncs = atol(line + 7);
        if (!strncmp(line, "missed=", 7)) r.missed = atol(line + 7);
        if (!strncmp(line, "missed_own=", 11)) r.own = atol(line + 11);
        if (!strncmp(line, "missed_late_wake=", 17)) r.late = atol(line + 17);
        if (!strncmp(line, "missed_descheduled=", 19)) r.desched = atol(line + 19);
        if (!strncmp(line, "m2p_ms_p50=", 11)) r.m2p_p50 = atof(line + 11);
        if (!strncmp(line, "stall_reserve_ms=", 17)) r.reserve_ms = atof(line + 17);
    }
    if (f) fclose(f);
    printf("soak: %ld vsyncs, %ld missed (target 0): own %ld, woken late %ld, descheduled %ld; motion-to-photon p50 "
           "%.2f ms, stall reserve %.1f ms\n", r.vsyncs, r.missed, r.own, r.late, r.desched, r.m2p_p50, r.reserve_ms);
    return r;
}

static void usage(FILE *f)
{
    fprintf(f, "Usage: hmdwarp-bench [options]\n"
               "Measures what accuracy costs in time on this machine and writes a CSV, a Markdown table and plots.\n"
               "  --quick          smaller eyes (720x800), fewer repetitions, a 5 s soak: a smoke run for CI\n"
               "  --eye WxH        eye size instead (panel 2W x H, lens scaled alike), e.g. a tiny one to check that\n"
               "                   a cross build runs under qemu-user (make check-cross): function, not timing\n"
               "  --out DIR        where results go (default docs/bench)\n"
               "  --reps N         repetitions of each display-path timing (default 60, quick 15)\n"
               "  --threads N      compositor threads (default 2)\n"
               "  --soak S         seconds of hmdwarpd at 90 Hz on the simulated board (default 60, quick 5; 0 = skip)\n"
               "  --hmdwarpd PATH  the hmdwarpd to soak (default: next to this program)\n"
               "  --link-only      only the link section: every framelink codec and quality step (link.md, link.csv)\n"
               "  --rolling-only   only the rolling-scan section: compensation against global prediction on the fast\n"
               "                   trace, against per-band truth (rolling.md; deterministic, about a minute)\n"
               "  -h, --help       this text\n"
               "  --version        print the version and exit\n"
               "Times are wall-clock on a noisy machine: the ratios to memcpy and OpenCV, measured interleaved in the\n"
               "same run, are what carries over; absolute times do not.\n");
}

int main(int argc, char **argv)
{
    opts o = {.out = "docs/bench", .soak_s = -1, .reps = 0, .threads = 2};
    static const struct option lo[] = {{"quick", 0, 0, 'q'}, {"out", 1, 0, 'o'},      {"reps", 1, 0, 'r'},
                                       {"soak", 1, 0, 's'},  {"hmdwarpd", 1, 0, 'd'}, {"threads", 1, 0, 't'},
                                       {"eye", 1, 0, 'e'},   {"help", 0, 0, 'h'},  {"version", 0, 0, 'V'},
                                       {"link-only", 0, 0, 'L'}, {"rolling-only", 0, 0, 'R'}, {0, 0, 0, 0}};
    int c;
    while ((c = getopt_long(argc, argv, "h", lo, NULL)) != -1) {
        switch (c) {
        case 'q': o.quick = true; break;
        case 'e':
            if (sscanf(optarg, "%dx%d", &o.eye_w, &o.eye_h) != 2 || o.eye_w < 16 || o.eye_h < 16 || o.eye_w > 8192 ||
                o.eye_h > 8192) {
                fprintf(stderr, "hmdwarp-bench: --eye '%s': expected WxH, 16..8192 each\n", optarg);
                return 2;
            }
            break;
        case 'o': o.out = optarg; break;
        case 'r': o.reps = atoi(optarg); break;
        case 's': o.soak_s = atof(optarg); break;
        case 'd': o.hmdwarpd = optarg; break;
        case 't': o.threads = atoi(optarg); break;
        case 'L': o.link_only = true; break;
        case 'R': o.rolling_only = true; break;
        case 'h': usage(stdout); return 0;
        case 'V': printf("hmdwarp-bench %s\n", plat_version()); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (o.reps <= 0) o.reps = o.quick ? 15 : 60;
    if (o.reps > MAX_REPS) o.reps = MAX_REPS;
    if (o.soak_s < 0) o.soak_s = o.quick ? 5 : 60;
    if (o.threads < 1) o.threads = 1;
    char hmdwarpd[600];
    if (o.hmdwarpd)
        snprintf(hmdwarpd, sizeof hmdwarpd, "%s", o.hmdwarpd);
    else {
        snprintf(hmdwarpd, sizeof hmdwarpd, "%s", argv[0]);
        char *slash = strrchr(hmdwarpd, '/');
        snprintf(slash ? slash + 1 : hmdwarpd, sizeof hmdwarpd - (size_t)(slash ? slash + 1 - hmdwarpd : 0),
                 "hmdwarpd");
    }
    if (mkdir(o.out, 0755) != 0 && errno != EEXIST) {
        fprintf(stderr, "hmdwarp-bench: cannot create %s: %s\n", o.out, strerror(errno));
        return 1;
    }

    /* The reference panel: 1440x1600 per eye (quick: half in each direction), the default lens with CA. The
     * display path is hmdwarpd's own CPU pass, on 2 threads and on 1. */
    rt_config cfg;
    bench_config(&cfg, o.quick, o.eye_w, o.eye_h);
    bench_display D;
    memset(&D, 0, sizeof D);
    int vw = cfg.panel_w / 2;
    warp_camera cam[2];
    warp_lens lens[2];
    for (int e = 0; e < 2; e++) {
        cam[e] = rt_config_eye_camera(&cfg, e);
        lens[e] = rt_config_lens(&cfg, e);
    }
    /* The link section: rpi5's eyes (the reference panel's), colour + depth at 45 Hz, decoded on the board's two
     * decode threads. */
    bench_link_opts lo_link = {.quick = o.quick, .reference = !o.quick && !o.eye_w, .cam = {cam[0], cam[1]},
                               .decode_threads = 2, .out = o.out};
    if (o.link_only) return bench_link_run(&lo_link) ? 0 : 1;
    const bench_rolling_opts ro = {.out = o.out};
    if (o.rolling_only) return bench_rolling_run(&ro) ? 0 : 1;
    plat_workers *workers = plat_workers_create(o.threads - 1, 0), *workers1 = plat_workers_create(0, 0);
    char err[300] = "out of memory";
    frame_case fc[2];
    bool ok = workers && workers1 && bench_display_init(&D, &cfg, workers, workers1, err, sizeof err) &&
              case_alloc(&fc[0], &cam[0]) && case_alloc(&fc[1], &cam[1]);
    if (!ok) {
        fprintf(stderr, "hmdwarp-bench: %s\n", err);
        return 1;
    }
    rt_kernel_choice kc; /* the kernel hmdwarpd's [render] kernel = auto would measure and run */
    if (rt_kernel_measure(&cfg, D.pass[0], &kc, err, sizeof err) && warp_resample_set_auto(kc.picked))
        printf("auto kernel: %s, %s\n", warp_resample_kernel_name(kc.picked), kc.why);
    printf("hmdwarp-bench: panel %dx%d (eyes %dx%d), lens mesh %d, %d threads, %d reps, kernel %s\n", cfg.panel_w,
           cfg.panel_h, cfg.eye_w, cfg.eye_h, cfg.mesh_n, o.threads, o.reps, warp_resample_kernel());
    fflush(stdout);

    /* Both eyes' host frames of the translation scene, 5 deg and 5 cm away from the displayed pose. */
    const sim_scene *near = sim_scene_find("near");
    uint64_t seq = 0;
    for (int e = 0; e < 2; e++) case_render(&fc[e], near, 5, 5, 0);
    if (!load_frame(&D, fc, ++seq)) return 1;
    warp_quat rot[2];
    warp_pose eyes[2];
    for (int e = 0; e < 2; e++) {
        rot[e] = warp_quat_mul(warp_quat_conj(fc[e].a.q), fc[e].b.q);
        eyes[e] = fc[e].b;
    }

    /* OpenCV gets the exact per-pixel, per-channel positions the mesh approximates, for both eyes. */
    const size_t npx = (size_t)vw * (size_t)cfg.panel_h;
    float *maps[2][6];
    bench_cv *cv[2];
    uint8_t *cv_src[2][3], *cv_dst[2][3];
    for (int e = 0; e < 2; e++) {
        warp_mat3 k = warp_camera_K(&cam[e]), r = warp_quat_to_mat3(rot[e]);
        warp_mat3 h = warp_mat3_mul(&k, &r);
        for (int i = 0; i < 6; i++) maps[e][i] = malloc(sizeof(float) * npx);
        for (int ch = 0; ch < 3; ch++) {
            cv_src[e][ch] = malloc((size_t)cfg.eye_w * (size_t)cfg.eye_h);
            cv_dst[e][ch] = malloc(npx);
            for (int y = 0; y < cfg.eye_h; y++)
                for (int x = 0; x < cfg.eye_w; x++) {
                    warp_rgba8 p = WARP_AT(&fc[e].src.color, x, y);
                    cv_src[e][ch][(size_t)y * cfg.eye_w + x] = ch == 0 ? p.r : ch == 1 ? p.g : p.b;
                }
            for (int y = 0; y < cfg.panel_h; y++)
                for (int x = 0; x < vw; x++) {
                    double u, v;
                    warp_lens_distort(&lens[e], ch, x + 0.5, y + 0.5, &u, &v);
                    double sx = h.m[0][0] * u + h.m[0][1] * v - h.m[0][2];
                    double sy = h.m[1][0] * u + h.m[1][1] * v - h.m[1][2];
                    double sw = h.m[2][0] * u + h.m[2][1] * v - h.m[2][2];
                    bool front = sw > 1e-6;
                    maps[e][ch][(size_t)y * vw + x] = front ? (float)(sx / sw - 0.5) : -1e4f;
                    maps[e][3 + ch][(size_t)y * vw + x] = front ? (float)(sy / sw - 0.5) : -1e4f;
                }
        }
        const float *mx[3] = {maps[e][0], maps[e][1], maps[e][2]}, *my[3] = {maps[e][3], maps[e][4], maps[e][5]};
        cv[e] = bench_cv_create(vw, cfg.panel_h, mx, my, cfg.eye_w, cfg.eye_h);
    }
    /* ---- 1. the display path, interleaved rounds ---- */
    bench_samples t_memcpy = {0}, t_ours = {0}, t_ours1 = {0}, t_cv = {0}, t_cv1 = {0}, t_ray = {0}, r_cv = {0},
            r_ray = {0}, t_raymesh = {0}, r_raymesh = {0}, t_meshvert = {0}, r_meshvert = {0};
    bench_samples t_kern[4];
    memset(t_kern, 0, sizeof t_kern);
    static const warp_resample_kernel_id kern[4] = {WARP_RESAMPLE_SCALAR, WARP_RESAMPLE_VECTOR, WARP_RESAMPLE_AVX2,
                                                    WARP_RESAMPLE_AVX512};
    static const char *const kern_name[4] = {"scalar", "vector", "avx2", "avx512"};
    warp_image_rgba8 copy;
    warp_image_rgba8_alloc(&copy, cfg.panel_w, cfg.panel_h);
    const size_t frame_bytes = (size_t)D.panel.stride * (size_t)cfg.panel_h * sizeof(warp_rgba8);
    for (int r = -2; r < o.reps; r++) { /* two warm-up rounds */
        int64_t t;
        t = plat_now_ns();
        memcpy(copy.px, D.panel.px, frame_bytes);
        double ms_memcpy = (double)(plat_now_ns() - t) * 1e-6;
        bench_cv_set_threads(o.threads);
        t = plat_now_ns();
        for (int e = 0; e < 2; e++) bench_cv_remap(cv[e], (const uint8_t *const *)cv_src[e], cfg.eye_w, cv_dst[e], vw);
        double ms_cv = (double)(plat_now_ns() - t) * 1e-6;
        t = plat_now_ns();
        double ms_ours = timed(&D, 0, eyes, RT_METHOD_ROTATION);
        bench_cv_set_threads(1);
        t = plat_now_ns();
        for (int e = 0; e < 2; e++) bench_cv_remap(cv[e], (const uint8_t *const *)cv_src[e], cfg.eye_w, cv_dst[e], vw);
        double ms_cv1 = (double)(plat_now_ns() - t) * 1e-6;
        double ms_ours1 = timed(&D, 1, eyes, RT_METHOD_ROTATION);
        /* the per-pixel raytrace takes some 80 display paths: every fourth round (and the first warm-up) keeps the
         * bench to minutes and still gives its ratio a median of 15 in a full run (60 rounds) */
        const bool ray_round = r < 0 ? r == -2 : r % 4 == 0;
        double ms_ray = 0;
        if (ray_round) ms_ray = timed(&D, 0, eyes, RT_METHOD_RAYTRACE);
        /* its vertices alone: what is left of the 2x when no cell is traced per pixel */
        rt_render_cpu_mesh_vertices_only(D.pass[0], true);
        double ms_meshvert = timed(&D, 0, eyes, RT_METHOD_RAYTRACE_MESH);
        rt_render_cpu_mesh_vertices_only(D.pass[0], false);
        double ms_raymesh = timed(&D, 0, eyes, RT_METHOD_RAYTRACE_MESH);
        if (r < 0) continue;
        bench_add(&t_memcpy, ms_memcpy);
        bench_add(&t_cv, ms_cv);
        bench_add(&t_ours, ms_ours);
        bench_add(&t_cv1, ms_cv1);
        bench_add(&t_ours1, ms_ours1);
        bench_add(&r_cv, ms_ours / ms_cv);
        if (ray_round) {
            bench_add(&t_ray, ms_ray);
            bench_add(&r_ray, ms_ray / ms_ours);
        }
        bench_add(&t_raymesh, ms_raymesh);
        bench_add(&r_raymesh, ms_raymesh / ms_ours);
        bench_add(&t_meshvert, ms_meshvert);
        bench_add(&r_meshvert, ms_meshvert / ms_ours);
        if (r % 4 == 0)
            for (int k = 0; k < 4; k++) {
                if (!warp_resample_force_kernel(kern[k])) continue;
                bench_add(&t_kern[k], timed(&D, 0, eyes, RT_METHOD_ROTATION));
                warp_resample_force_kernel(WARP_RESAMPLE_AUTO);
            }
    }
    bench_cv_set_threads(o.threads);
    /* the share of lens mesh cells raytrace_mesh traced per pixel (its depth discontinuities), both eyes */
    int traced_cells = 0, all_cells = 0;
    for (int e = 0; e < 2; e++) {
        const warp_mesh_trace *mt = rt_render_cpu_mesh_trace(D.pass[0], e);
        if (!mt) continue;
        traced_cells += mt->marked;
        all_cells += mt->cells_x * mt->cells_y;
    }
    const double traced_pct = all_cells ? 100.0 * traced_cells / all_cells : 0;
    double cv_speedup = 1.0 / bench_pct(&r_cv, 50), ray_ratio = bench_pct(&r_ray, 50), raymesh_ratio = bench_pct(&r_raymesh, 50),
           meshvert_ratio = bench_pct(&r_meshvert, 50);
    printf("display path: ours %.2f ms, OpenCV %.2f ms (%s), memcpy %.2f ms: %.2fx faster than OpenCV (target 3x); "
           "raytrace at 5 cm %.2f ms = %.2fx rotation (target <= 2x); raytrace_mesh %.2f ms = %.2fx (%.1f %% of "
           "its cells traced per pixel; its vertices alone %.2fx)\n",
           bench_pct(&t_ours, 50), bench_pct(&t_cv, 50), bench_cv_version(), bench_pct(&t_memcpy, 50), cv_speedup, bench_pct(&t_ray, 50),
           ray_ratio, bench_pct(&t_raymesh, 50), raymesh_ratio, traced_pct, meshvert_ratio);
    fflush(stdout);

    /* ---- 2. raytrace cost vs head translation (003 eq. 11: steps grow with the screen-space parallax) ---- */
    const double motions_cm[] = {0, 1, 2, 5, 10};
    const int n_motion = o.quick ? 3 : 5;
    double ray_ms[5], ray_steps[5], rot_ms[5], ray_psnr[5], rot_psnr[5], mesh_ms[5], mesh_psnr[5], mesh_vs_ray[5];
    warp_image_rgba8 eye_out, eye_out2;
    warp_image_u8 eye_mask;
    warp_image_rgba8_alloc(&eye_out, cfg.eye_w, cfg.eye_h);
    warp_image_rgba8_alloc(&eye_out2, cfg.eye_w, cfg.eye_h);
    warp_image_u8_alloc(&eye_mask, cfg.eye_w, cfg.eye_h);
    /* the mesh raytrace's accuracy before the lens: a lens-free mesh over the eye buffer, as dense as the panel's,
     * resampling the left eye's source */
    warp_mesh eye_mesh;
    warp_planar3 planar0;
    memset(&eye_mesh, 0, sizeof eye_mesh);
    memset(&planar0, 0, sizeof planar0);
    warp_mesh_trace eye_trace;
    memset(&eye_trace, 0, sizeof eye_trace);
    if (!warp_mesh_alloc_eye(&eye_mesh, cfg.mesh_n, &cam[0]) || !warp_mesh_trace_alloc(&eye_trace, &eye_mesh) ||
        !warp_planar3_alloc(&planar0, cfg.eye_w, cfg.eye_h)) {
        fprintf(stderr, "hmdwarp-bench: out of memory\n");
        return 1;
    }
    for (int m = 0; m < n_motion; m++) {
        for (int e = 0; e < 2; e++) {
            case_render(&fc[e], near, 2, motions_cm[m], 0);
            eyes[e] = fc[e].b;
        }
        if (!load_frame(&D, fc, ++seq)) return 1;
        bench_samples sr = {0}, so = {0}, sm = {0};
        for (int r = 0; r < (o.quick ? 3 : 7); r++) {
            bench_add(&sr, timed(&D, 0, eyes, RT_METHOD_RAYTRACE));
            bench_add(&so, timed(&D, 0, eyes, RT_METHOD_ROTATION));
            bench_add(&sm, timed(&D, 0, eyes, RT_METHOD_RAYTRACE_MESH));
        }
        ray_ms[m] = bench_pct(&sr, 50);
        rot_ms[m] = bench_pct(&so, 50);
        mesh_ms[m] = bench_pct(&sm, 50);
        /* accuracy before the lens, left eye */
        warp_raytrace_setup rts0;
        warp_raytrace_stats st = {0};
        warp_raytrace_prepare(&rts0, &fc[0].v, &cam[0], fc[0].b, rt_render_cpu_raytrace_params(D.pass[0]));
        warp_raytrace_rows(&rts0, &eye_out, &eye_mask, 0, cfg.eye_h, &st);
        ray_steps[m] = (double)st.steps / (double)st.rays;
        ray_psnr[m] = warp_psnr(&eye_out, &fc[0].truth.color, NULL, 0);
        warp_planar3_from_rgba_rows(&planar0, &fc[0].src.color, 0, cfg.eye_h);
        warp_mesh_raytrace_draw(&eye_mesh, &eye_trace, &cam[0], &rts0, NULL, NULL,
                                rt_render_cpu_mesh_trace_params(D.pass[0]), &planar0, &eye_out2);
        mesh_psnr[m] = warp_psnr(&eye_out2, &fc[0].truth.color, NULL, 0);
        mesh_vs_ray[m] = warp_psnr(&eye_out2, &eye_out, NULL, 0);
        cat_stats cs;
        memset(&cs, 0, sizeof cs);
        cat_find("rotation")->run(&fc[0].v, &fc[0].cam, fc[0].b, fc[0].t1, NULL, &eye_out, &eye_mask, &cs);
        rot_psnr[m] = warp_psnr(&eye_out, &fc[0].truth.color, NULL, 0);
        printf("  translation %4.1f cm: raytrace %.2f ms (%.1f steps/ray, %.2f dB), rotation %.2f ms (%.2f dB), mesh "
               "raytrace %.2f ms (%.2f dB; %.2f dB from the per-pixel one)\n",
               motions_cm[m], ray_ms[m], ray_steps[m], ray_psnr[m], rot_ms[m], rot_psnr[m], mesh_ms[m], mesh_psnr[m],
               mesh_vs_ray[m]);
        fflush(stdout);
    }

    /* ---- GPU: every GLES pass at this panel size, where EGL is there (on llvmpipe too: the numbers say why
     * render = auto picks the CPU path on a software rasterizer) ---- */
    plat_gles_times gpu, gpu_traced;
    memset(&gpu, 0, sizeof gpu);
    memset(&gpu_traced, 0, sizeof gpu_traced);
    bool have_traced = false;
    int gl_cells = 0;
    char gl_renderer[160] = "", gl_timing[80] = "", gl_err[300] = "";
    bool have_gpu = false;
    {
        plat_egl *egl = plat_egl_open_offscreen(gl_err, sizeof gl_err);
        if (egl && plat_egl_make_current(egl)) {
            const warp_mesh *meshes[2] = {rt_render_cpu_mesh(D.pass[0], 0), rt_render_cpu_mesh(D.pass[0], 1)};
            plat_gles_params gp = {cfg.panel_w, cfg.panel_h, cfg.eye_w, cfg.eye_h, meshes[0]->cols, meshes[0]->rows,
                                   true, false, true, false};
            plat_gles *g = plat_gles_create(egl, &gp, gl_err, sizeof gl_err);
            if (g) {
                warp_raytrace_setup gl_rts[2];
                for (int e = 0; e < 2; e++) {
                    case_render(&fc[e], near, 5, 5, 0);
                    warp_raytrace_prepare(&gl_rts[e], &fc[e].v, &cam[e], fc[e].b,
                                          rt_render_cpu_raytrace_params(D.pass[0]));
                }
                const warp_raytrace_setup *rts[2] = {&gl_rts[0], &gl_rts[1]};
                /* each eye's own render: the raytrace and the marks are eye e's, so is what they read */
                const warp_image_rgba8 *gl_color[2] = {&fc[0].src.color, &fc[1].src.color};
                const warp_image_f32 *gl_inv[2] = {&fc[0].inv, &fc[1].inv};
                have_gpu = plat_gles_bench(g, gl_color, gl_inv, rts, meshes, o.quick ? 3 : 10, &gpu);
                /* raytrace_mesh: the CPU's vertex rays and marks, then the traced lens pass alone */
                warp_mesh_trace tr[2];
                memset(tr, 0, sizeof tr);
                if (have_gpu && warp_mesh_trace_alloc(&tr[0], meshes[0]) && warp_mesh_trace_alloc(&tr[1], meshes[1])) {
                    for (int e = 0; e < 2; e++)
                        gl_cells += warp_mesh_raytrace_vertices(rt_render_cpu_mesh(D.pass[0], e), &tr[e], &cam[e],
                                                                    &gl_rts[e], NULL, NULL,
                                                                    rt_render_cpu_mesh_trace_params(D.pass[0]));
                    const warp_mesh_trace *tp[2] = {&tr[0], &tr[1]};
                    const warp_camera *cp[2] = {&cam[0], &cam[1]};
                    have_traced = plat_gles_bench_traced(g, gl_color, gl_inv, rts, meshes, tp, cp,
                                                         o.quick ? 3 : 10, &gpu_traced);
                }
                for (int e = 0; e < 2; e++) warp_mesh_trace_free(&tr[e]);
                snprintf(gl_renderer, sizeof gl_renderer, "%s", plat_egl_renderer(egl));
                snprintf(gl_timing, sizeof gl_timing, "%s", plat_gles_timing_method(g));
                plat_gles_destroy(g);
            }
            plat_egl_release(egl);
        }
        plat_egl_close(egl);
        if (have_gpu) {
            printf("GLES (%s, %s):", gl_renderer, gl_timing);
            for (int p = 0; p < PLAT_GLES_PASSES; p++)
                if (gpu.valid[p]) printf(" %s %.2f ms", plat_gles_pass_name((plat_gles_pass)p), gpu.ms[p]);
            printf("\n");
            if (have_traced)
                printf("GLES raytrace_mesh (%d cells traced per pixel): lens %.2f ms, no raytrace pass\n", gl_cells,
                       gpu_traced.ms[PLAT_GLES_LENS]);
        } else {
            printf("GLES: not measured (%s)\n", gl_err[0] ? gl_err : "no EGL");
        }
        fflush(stdout);
    }

    /* ---- 3. every warp x knobs x scene x motion, one eye, against ground truth ---- */
    static sweep_row rows[MAX_ROWS];
    int nrows = 0;
    static const char *const scenes[] = {"room", "near", "hairball", "glass", "movers", "outdoor"};
    const double mdeg[2] = {2, 8}, mcm[2] = {1, 5};
    for (size_t s = 0; s < sizeof scenes / sizeof scenes[0]; s++) {
        const sim_scene *sc = sim_scene_find(scenes[s]);
        if (!sc) continue;
        for (int m = 0; m < 2; m++) {
            if (o.quick && m == 0) continue;
            case_render(&fc[0], sc, mdeg[m], mcm[m], sim_scene_object_count(sc) ? 0.033 : 0);
            for (const cat_warp *const *wp = cat_all(); *wp; wp++) {
                const char *params[8];
                int nk = knob_list((*wp)->name, params);
                for (int k = 0; k < nk && nrows < MAX_ROWS; k++) {
                    sweep_row *row = &rows[nrows];
                    memset(row, 0, sizeof *row);
                    bench_samples ts = {0};
                    cat_stats cs;
                    const char *why = NULL;
                    /* three runs for a median, but one is enough for the slow reference warps (the bench must
                     * finish in minutes, and their cost is far from the display-path decisions) */
                    for (int r = 0; r < (o.quick ? 1 : 3) && !why && (r == 0 || ts.v[0] < 150); r++) {
                        memset(&cs, 0, sizeof cs);
                        warp_image_u8_fill(&eye_mask, 0);
                        int64_t t = plat_now_ns();
                        why = (*wp)->run(&fc[0].v, &fc[0].cam, fc[0].b, fc[0].t1, params[k], &eye_out, &eye_mask,
                                         &cs);
                        bench_add(&ts, (double)(plat_now_ns() - t) * 1e-6);
                    }
                    if (why) continue;
                    snprintf(row->scene, sizeof row->scene, "%s", scenes[s]);
                    snprintf(row->warp, sizeof row->warp, "%s", (*wp)->name);
                    snprintf(row->params, sizeof row->params, "%s", params[k] ? params[k] : "defaults");
                    row->motion_deg = mdeg[m];
                    row->motion_cm = mcm[m];
                    row->med_ms = bench_pct(&ts, 50);
                    row->p99_ms = bench_pct(&ts, 99);
                    row->psnr = warp_psnr(&eye_out, &fc[0].truth.color, NULL, 0);
                    row->band_psnr = warp_psnr(&eye_out, &fc[0].truth.color, &fc[0].band, 1);
                    row->ssim = warp_ssim(&eye_out, &fc[0].truth.color, NULL, 0);
                    row->err = warp_error_pixel_percent(&eye_out, &fc[0].truth.color, NULL, 0, 20);
                    row->primitives = cs.primitives;
                    row->samples = cs.samples;
                    nrows++;
                }
            }
        }
        printf("  swept %s\n", scenes[s]);
        fflush(stdout);
    }
    /* Pareto front per scene and motion: no other configuration is both faster and more accurate. */
    for (int i = 0; i < nrows; i++) {
        rows[i].pareto = true;
        for (int j = 0; j < nrows && rows[i].pareto; j++)
            if (j != i && !strcmp(rows[i].scene, rows[j].scene) && rows[i].motion_cm == rows[j].motion_cm &&
                rows[j].med_ms <= rows[i].med_ms && rows[j].psnr >= rows[i].psnr &&
                (rows[j].med_ms < rows[i].med_ms || rows[j].psnr > rows[i].psnr))
                rows[i].pareto = false;
    }

    /* ---- 4. soak: hmdwarpd on the simulated board at 90 Hz with the rotation warp: as the board is configured
     * (with its stall reserve), and (full run) without the reserve, to show what robustness costs in latency ---- */
    soak_result soaks[4];
    int n_soaks = 0;
    const double stall_ms = 8, stall_s = 20;
    if (o.soak_s > 0) {
        soaks[n_soaks++] = soak(hmdwarpd, &o, "soak", "", o.soak_s, 0);
        if (!o.quick) {
            soaks[n_soaks++] = soak(hmdwarpd, &o, "soak_no_reserve", "--set render.stall_reserve_ms=0", o.soak_s, 0);
            soaks[n_soaks++] = soak(hmdwarpd, &o, "soak_stalls", "", stall_s, stall_ms);
            soaks[n_soaks++] = soak(hmdwarpd, &o, "soak_stalls_no_reserve", "--set render.stall_reserve_ms=0", stall_s,
                                    stall_ms);
        }
    }

    /* ---- output: CSV, Markdown, plots ---- */
    char path[700];
    snprintf(path, sizeof path, "%s/bench.csv", o.out);
    FILE *csv = fopen(path, "w");
    snprintf(path, sizeof path, "%s/bench.md", o.out);
    FILE *md = fopen(path, "w");
    if (!csv || !md) {
        fprintf(stderr, "hmdwarp-bench: cannot write into %s\n", o.out);
        return 1;
    }
    fprintf(csv, "section,scene,warp,params,motion_deg,motion_cm,median_ms,p99_ms,psnr_db,ssim,error_px_pct,"
                 "primitives,samples,pareto,band_psnr_db\n");
    struct {
        const char *name;
        bench_samples *s;
    } disp[] = {{"memcpy of the output frame", &t_memcpy},
                {"ours: rotation+lens+CA, both eyes, 2 threads", &t_ours},
                {"ours: the same, 1 thread", &t_ours1},
                {"OpenCV cv::remap x3 channels, both eyes, 2 threads", &t_cv},
                {"OpenCV cv::remap, 1 thread", &t_cv1},
                {"ours: raytrace at 5 cm + lens pass, 2 threads", &t_ray},
                {"ours: raytrace_mesh at 5 cm (vertices, per pixel at depth edges), both eyes, 2 threads",
                 &t_raymesh},
                {"ours: raytrace_mesh at 5 cm, its vertices alone ([warp] mesh_cells = false: no marks, no per-pixel "
                 "rays), both eyes, 2 threads",
                 &t_meshvert}};
    for (size_t i = 0; i < sizeof disp / sizeof disp[0]; i++)
        fprintf(csv, "display,near,%s,,5,5,%.4f,%.4f,,,,,,\n", disp[i].name, bench_pct(disp[i].s, 50), bench_pct(disp[i].s, 99));
    for (int k = 0; k < 4; k++)
        if (t_kern[k].n)
            fprintf(csv, "display,near,kernel %s 2 threads,,5,5,%.4f,%.4f,,,,,,\n", kern_name[k], bench_pct(&t_kern[k], 50),
                    bench_pct(&t_kern[k], 99));
    for (int m = 0; m < n_motion; m++)
        fprintf(csv, "motion,near,raytrace+lens,,2,%g,%.4f,,%.3f,,,,%.2f,\n", motions_cm[m], ray_ms[m], ray_psnr[m],
                ray_steps[m]);
    for (int m = 0; m < n_motion; m++)
        fprintf(csv, "motion,near,mesh raytrace,,2,%g,%.4f,,%.3f,,,,,\n", motions_cm[m], mesh_ms[m], mesh_psnr[m]);
    for (int p = 0; have_gpu && p < PLAT_GLES_PASSES; p++)
        if (gpu.valid[p])
            fprintf(csv, "gpu,near,gles %s,,5,5,%.4f,,,,,,,\n", plat_gles_pass_name((plat_gles_pass)p), gpu.ms[p]);
    for (int i = 0; i < nrows; i++)
        fprintf(csv, "sweep,%s,%s,%s,%g,%g,%.4f,%.4f,%.3f,%.5f,%.3f,%ld,%ld,%d,%.3f\n", rows[i].scene, rows[i].warp,
                rows[i].params, rows[i].motion_deg, rows[i].motion_cm, rows[i].med_ms, rows[i].p99_ms, rows[i].psnr,
                rows[i].ssim, rows[i].err, rows[i].primitives, rows[i].samples, rows[i].pareto, rows[i].band_psnr);
    fclose(csv);

    fprintf(md, "# What accuracy costs in time\n\n"
                "`make bench%s` on this machine (%d threads, %s kernel, OpenCV %s); panel %dx%d, eyes %dx%d, lens "
                "mesh %d. Times are wall-clock medians and p99 of %d interleaved rounds (the per-pixel raytrace in "
                "every fourth); the ratios are the "
                "medians of per-round ratios, which hold on a noisy machine where absolute times do not.\n\n",
            o.quick ? " BENCH_ARGS=--quick" : "", o.threads, warp_resample_kernel(), bench_cv_version(), cfg.panel_w,
            cfg.panel_h, cfg.eye_w, cfg.eye_h, cfg.mesh_n, o.reps);
    fprintf(md, "## Targets\n\n| target | measured | verdict |\n|---|---|---|\n");
    /* #21 raised the bar from 3x to 5x (the kernel picked by measurement, the mask filled four pixels a store) */
    fprintf(md, "| display path at least 5x faster than OpenCV cv::remap doing the same per-channel resampling | "
                "%.2fx | %s |\n", cv_speedup, cv_speedup >= 5 ? "met" : "NOT met");
    fprintf(md, "| raytrace at 5 cm head translation at most 2x the display path | %.2fx | %s |\n", ray_ratio,
            ray_ratio <= 2 ? "met" : "NOT met");
    const int m5 = n_motion - 1 < 3 ? n_motion - 1 : 3; /* 5 cm (quick: the largest measured) */
    fprintf(md, "| depth warp (raytrace_mesh) vs rotation display path: <= 2x (rays at the lens mesh's vertices, per "
                "pixel in the %.1f %% of its cells with a depth discontinuity; %.2f dB from the per-pixel raytrace at "
                "%g cm, see below; its vertices alone, without marks or per-pixel rays: %.2fx) | %.2fx | %s |\n",
            traced_pct, mesh_vs_ray[m5], motions_cm[m5], meshvert_ratio, raymesh_ratio,
            raymesh_ratio <= 2 ? "met" : "NOT met");
    /* raytrace_mesh (its defaults) against the better of the per-pixel raytrace and the adaptive grid on every
     * scene at the larger motion of section 3, the worst scene's shortfall: against their defaults (the warps as
     * configured), and against any of their knobs (the grid's low-pass hole fill, 000 §5.2, is a fill the
     * raytrace's far-side edge fill does not match) */
    double gap_def = -INFINITY, gap_any = -INFINITY, gap_band = -INFINITY;
    char scene_def[32] = "-", scene_any[32] = "-", scene_band[32] = "-";
    for (size_t sc = 0; sc < sizeof scenes / sizeof scenes[0]; sc++) {
        double mesh = NAN, mesh_band = NAN, best_def = -INFINITY, best_any = -INFINITY, best_band = -INFINITY;
        for (int i = 0; i < nrows; i++) {
            if (strcmp(rows[i].scene, scenes[sc]) || rows[i].motion_cm != mcm[1]) continue;
            if (!strcmp(rows[i].warp, "raytrace_mesh") && !strcmp(rows[i].params, "mesh=64")) {
                mesh = rows[i].psnr;
                mesh_band = rows[i].band_psnr;
            }
            const bool ray = !strcmp(rows[i].warp, "raytrace"), grid = !strcmp(rows[i].warp, "grid");
            if (!ray && !grid) continue;
            if (rows[i].psnr > best_any) best_any = rows[i].psnr;
            if ((ray && !strcmp(rows[i].params, "steps=512")) || (grid && !strcmp(rows[i].params, "strategy=3"))) {
                if (rows[i].psnr > best_def) best_def = rows[i].psnr;
                /* the band's best may be the other warp (NAN, no band: never above) */
                if (rows[i].band_psnr > best_band) best_band = rows[i].band_psnr;
            }
        }
        if (isnan(mesh)) continue;
        if (isfinite(best_def) && best_def - mesh > gap_def) {
            gap_def = best_def - mesh;
            snprintf(scene_def, sizeof scene_def, "%s", scenes[sc]);
        }
        if (isfinite(best_any) && best_any - mesh > gap_any) {
            gap_any = best_any - mesh;
            snprintf(scene_any, sizeof scene_any, "%s", scenes[sc]);
        }
        if (isfinite(best_band) && !isnan(mesh_band) && best_band - mesh_band > gap_band) {
            gap_band = best_band - mesh_band;
            snprintf(scene_band, sizeof scene_band, "%s", scenes[sc]);
        }
    }
    if (isfinite(gap_def))
        fprintf(md, "| raytrace_mesh within 0.3 dB of best reference at %g cm (the per-pixel raytrace or the adaptive "
                    "grid at their defaults, whichever is better, on every scene of the sweep below; worst: %s. "
                    "Against their best knobs: %.2f dB below on %s, where the grid's low-pass hole fill wins) | "
                    "%.2f dB below | %s |\n",
                mcm[1], scene_def, gap_any, scene_any, gap_def, gap_def <= 0.3 ? "met" : "NOT met");
    if (isfinite(gap_band))
        fprintf(md, "| raytrace_mesh within 1 dB of best reference at %g cm in the depth-edge band (the pixels within 3 "
                    "px of a depth edge of the truth, the sweep's band dB column; the same references, per scene the "
                    "better in the band; worst: %s) | %.2f dB %s | %s |\n",
                mcm[1], scene_band, fabs(gap_band), gap_band >= 0 ? "below" : "above", gap_band <= 1 ? "met" : "NOT met");
    static const char *soak_what[] = {
        "zero missed vsyncs in %g s at 90 Hz, rotation warp, simulated board",
        "for comparison: the same without the stall reserve",
        "the same with %.0f ms stalls injected on one core every 0.5-0.9 s (%g s)",
        "the same with stalls injected, without the stall reserve",
    };
    for (int k = 0; k < n_soaks; k++) {
        const soak_result *r = &soaks[k];
        if (r->vsyncs < 0) continue;
        char what[200];
        if (k == 0) snprintf(what, sizeof what, soak_what[0], o.soak_s);
        else if (k == 2) snprintf(what, sizeof what, soak_what[2], stall_ms, stall_s);
        else snprintf(what, sizeof what, "%s", soak_what[k]);
        fprintf(md, "| %s | %ld of %ld missed (hmdwarpd's own %ld; the scheduler's: woken late %ld, descheduled %ld); "
                    "motion-to-photon p50 %.1f ms with a %.1f ms stall reserve | %s |\n",
                what, r->missed, r->vsyncs, r->own, r->late, r->desched, r->m2p_p50, r->reserve_ms,
                k == 0 ? (r->missed == 0 ? "met" : "NOT met") : "-");
    }
    fprintf(md, "\n## Display path, both eyes\n\n| what | median ms | p99 ms | x memcpy |\n|---|---:|---:|---:|\n");
    for (size_t i = 0; i < sizeof disp / sizeof disp[0]; i++)
        fprintf(md, "| %s | %.2f | %.2f | %.1f |\n", disp[i].name, bench_pct(disp[i].s, 50), bench_pct(disp[i].s, 99),
                bench_pct(disp[i].s, 50) / bench_pct(&t_memcpy, 50));
    for (int k = 0; k < 4; k++)
        if (t_kern[k].n)
            fprintf(md, "| ours, %s kernel, 2 threads | %.2f | %.2f | %.1f |\n", kern_name[k], bench_pct(&t_kern[k], 50),
                    bench_pct(&t_kern[k], 99), bench_pct(&t_kern[k], 50) / bench_pct(&t_memcpy, 50));
    if (have_gpu) {
        fprintf(md, "\n## GPU passes (GLES 3, %s; %s)\n\n| pass | ms per vsync | CPU path equivalent |\n|---|---:|---|\n",
                gl_renderer, gl_timing);
        for (int p = 0; p < PLAT_GLES_PASSES; p++)
            if (gpu.valid[p])
                fprintf(md, "| %s | %.2f | %s |\n", plat_gles_pass_name((plat_gles_pass)p), gpu.ms[p],
                        p == PLAT_GLES_LENS ? "display path above" : p == PLAT_GLES_RAYTRACE ? "raytrace row above" : "-");
        if (have_traced && gpu_traced.valid[PLAT_GLES_LENS])
            fprintf(md, "| lens, traced (raytrace_mesh: per-pixel rays in its %d marked cells, no raytrace pass) | %.2f | "
                        "raytrace_mesh row above |\n",
                    gl_cells, gpu_traced.ms[PLAT_GLES_LENS]);
        fprintf(md, "\nOn a software rasterizer (llvmpipe) these are CPU times too, which is why `render = auto` "
                    "picks the CPU path there.\n");
    } else {
        fprintf(md, "\n## GPU passes\n\nNot measured: %s.\n", gl_err[0] ? gl_err : "no EGL display");
    }
    fprintf(md, "\n## Raytrace cost vs head translation (scene near, 2 deg yaw)\n\n"
                "003 eq. 11: the linear search takes a step per source pixel of parallax, so its cost grows with "
                "translation. ![time vs motion](time_vs_motion.png)\n\n"
                "The mesh raytrace (`method = raytrace_mesh`) traces the lens mesh's vertices (%d x %d per eye, 3 "
                "channels) and interpolates in between, except in the cells with a depth discontinuity, which it "
                "traces per pixel: its PSNR is scored the same way, before the lens through a lens-free mesh as "
                "dense, and against the per-pixel raytrace's image (the last column).\n\n"
                "| translation cm | raytrace+lens ms | steps/ray | raytrace PSNR dB | rotation ms | rotation PSNR dB "
                "| mesh raytrace ms | mesh raytrace PSNR dB | mesh vs per-pixel dB |\n"
                "|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
            rt_render_cpu_mesh(D.pass[0], 0)->cols, rt_render_cpu_mesh(D.pass[0], 0)->rows);
    for (int m = 0; m < n_motion; m++)
        fprintf(md, "| %g | %.2f | %.1f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f |\n", motions_cm[m], ray_ms[m],
                ray_steps[m], ray_psnr[m], rot_ms[m], rot_psnr[m], mesh_ms[m], mesh_psnr[m], mesh_vs_ray[m]);
    fprintf(md, "\n## Every warp against ground truth (one eye, before the lens, single thread)\n\n"
                "Pareto = no other configuration of the same scene and motion is both faster and more accurate. "
                "band dB = PSNR over the pixels within 3 px of a depth edge of the truth (a depth jump over 10 %% "
                "between neighbours: silhouettes and the disocclusions beside them), where depth warps differ most. "
                "raytrace_mesh traces the vertices of a lens-free mesh over the eye buffer (`mesh=N` per "
                "side, [lens] mesh's %d by default) and resamples in between, per pixel in the cells with a depth "
                "discontinuity (`cells=0`: its vertices alone, [warp] mesh_cells = false); its time includes the "
                "per-host-frame "
                "preparation (planar source, skipping grid), as the per-pixel raytrace's includes its skipping grid, "
                "and, like every catalogue warp's, the allocation of its scratch (here the mesh and the planar "
                "source).\n",
            cfg.mesh_n);
    for (size_t s = 0; s < sizeof scenes / sizeof scenes[0]; s++) {
        fprintf(md, "\n### %s ![quality vs time](quality_vs_time_%s.png)\n\n"
                    "| warp | knobs | motion | median ms | p99 ms | PSNR dB | band dB | SSIM | error px %% | primitives | "
                    "samples | Pareto |\n"
                    "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|:-:|\n",
                scenes[s], scenes[s]);
        for (int i = 0; i < nrows; i++)
            if (!strcmp(rows[i].scene, scenes[s])) {
                char pr[24] = "-", sa[24] = "-";
                if (rows[i].primitives >= 0) snprintf(pr, sizeof pr, "%ld", rows[i].primitives);
                if (rows[i].samples >= 0) snprintf(sa, sizeof sa, "%ld", rows[i].samples);
                fprintf(md, "| %s | %s | %g deg, %g cm | %.2f | %.2f | %.2f | %.2f | %.4f | %.3f | %s | %s | %s |\n",
                        rows[i].warp, rows[i].params, rows[i].motion_deg, rows[i].motion_cm, rows[i].med_ms,
                        rows[i].p99_ms, rows[i].psnr, rows[i].band_psnr, rows[i].ssim, rows[i].err, pr, sa,
                        rows[i].pareto ? "yes" : "");
            }
    }
    fclose(md);

    /* gnuplot: data files, then one script for all plots */
    snprintf(path, sizeof path, "%s/time_vs_motion.dat", o.out);
    FILE *f = fopen(path, "w");
    for (int m = 0; f && m < n_motion; m++)
        fprintf(f, "%g %.4f %.4f %.3f %.4f\n", motions_cm[m], ray_ms[m], rot_ms[m], ray_steps[m], mesh_ms[m]);
    if (f) fclose(f);
    snprintf(path, sizeof path, "%s/plots.gp", o.out);
    FILE *gp = fopen(path, "w");
    if (gp) {
        fprintf(gp, "set terminal pngcairo size 800,520\nset grid\nset key top left\n"
                    "set output 'time_vs_motion.png'\nset title 'Raytrace cost grows with head translation (003 eq. 11)'\n"
                    "set xlabel 'head translation, cm'\nset ylabel 'ms per frame, both eyes'\n"
                    "plot 'time_vs_motion.dat' u 1:2 w lp lw 2 t 'raytrace + lens', '' u 1:3 w lp lw 2 t 'rotation + lens', "
                    "'' u 1:5 w lp lw 2 t 'raytrace at the mesh vertices'\n");
        for (size_t s = 0; s < sizeof scenes / sizeof scenes[0]; s++) {
            snprintf(path, sizeof path, "%s/sweep_%s.dat", o.out, scenes[s]);
            FILE *d = fopen(path, "w");
            if (!d) continue;
            /* all points, then the front (sorted by time) after two blank lines: gnuplot "index" 0 and 1 */
            for (int i = 0; i < nrows; i++)
                if (!strcmp(rows[i].scene, scenes[s]) && rows[i].motion_cm == mcm[1])
                    fprintf(d, "%.4f %.3f \"%s %s\"\n", rows[i].med_ms, rows[i].psnr, rows[i].warp, rows[i].params);
            fprintf(d, "\n\n");
            int idx[MAX_ROWS], n = 0;
            for (int i = 0; i < nrows; i++)
                if (!strcmp(rows[i].scene, scenes[s]) && rows[i].motion_cm == mcm[1] && rows[i].pareto) idx[n++] = i;
            for (int a = 1; a < n; a++)
                for (int b = a; b > 0 && rows[idx[b]].med_ms < rows[idx[b - 1]].med_ms; b--) {
                    int t = idx[b];
                    idx[b] = idx[b - 1];
                    idx[b - 1] = t;
                }
            for (int i = 0; i < n; i++) fprintf(d, "%.4f %.3f\n", rows[idx[i]].med_ms, rows[idx[i]].psnr);
            fclose(d);
            fprintf(gp, "set output 'quality_vs_time_%s.png'\nset title 'Scene %s, %g deg + %g cm: quality vs time'\n"
                        "set xlabel 'ms per frame, one eye, single thread (log)'\nset ylabel 'PSNR vs ground truth, dB'\n"
                        "set logscale x\n"
                        "plot 'sweep_%s.dat' index 0 u 1:2 w p pt 7 ps 1.3 t 'configurations', "
                        "'' index 0 u 1:2:3 w labels offset 0,1 font ',7' notitle, "
                        "'' index 1 u 1:2 w lp lw 2 lc rgb 'red' t 'Pareto front'\nunset logscale x\n",
                    scenes[s], scenes[s], mdeg[1], mcm[1], scenes[s]);
        }
        fclose(gp);
        if (!run_gnuplot(o.out, "plots.gp")) fprintf(stderr, "hmdwarp-bench: gnuplot failed (plots missing)\n");
    }
    printf("results: %s/bench.md, %s/bench.csv, plots %s/*.png\n", o.out, o.out, o.out);
    fflush(stdout);
    /* ---- 5. the link: every framelink codec and quality step (bench_link.c) ---- */
    if (!bench_link_run(&lo_link)) return 1;
    /* ---- 6. rolling scanout: what compensation buys (bench_rolling.c) ---- */
    if (!bench_rolling_run(&ro)) return 1;

    for (int e = 0; e < 2; e++) {
        bench_cv_destroy(cv[e]);
        for (int i = 0; i < 6; i++) free(maps[e][i]);
        for (int ch = 0; ch < 3; ch++) {
            free(cv_src[e][ch]);
            free(cv_dst[e][ch]);
        }
        case_free(&fc[e]);
    }
    bench_display_free(&D);
    warp_planar3_free(&planar0);
    warp_image_free(&copy);
    warp_image_free(&eye_out);
    warp_image_free(&eye_out2);
    warp_image_free(&eye_mask);
    warp_mesh_free(&eye_mesh);
    warp_mesh_trace_free(&eye_trace);
    plat_workers_destroy(workers);
    plat_workers_destroy(workers1);
    return 0;
}
