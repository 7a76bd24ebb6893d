/* SPDX-License-Identifier: MIT */
/* hmdwarp-feed: a host for hmdwarp boards on libhmdwarp-host: argument parsing and content sources (the simulated
 * scene, PNGs) rendered at the board's poses and submitted over USB, a socket or into a file (or a V4L2 output). */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "drivers/drv_framelink.h"
#include "drivers/drv_v4l2_output.h"
#include "host/hmdwarp-host.h"
#include "platform/plat_clock.h"
#include "platform/plat_png.h"
#include "platform/plat_version.h"
#include "platform/plat_workers.h"
#include "sim/sim_scene.h"
#include "warp/warp_head.h"

#include "feed_sequence.h"

#define DEFAULT_VID 0x1d6b /* Linux Foundation */
#define DEFAULT_PID 0x0104 /* multifunction composite gadget: what board/gadget.sh registers */
#define BAND 32

typedef struct {
    unsigned vid, pid;
    int interface;
    double wait_s;             /* how long to retry enumeration */
    const char *scene;
    const char *png;           /* printf pattern with one %d (frame index) or a plain file */
    const char *sequence, *seq_rate; /* --sequence DIR (feed_sequence.h), --sequence-rate own|board */
    bool loop;
    const char *out_path;      /* --file / --stdout ("-") */
    const char *socket_path;   /* --socket: hmdwarpd's [frames] backend = socket */
    const char *v4l2_dev;      /* --v4l2: a V4L2 output device (HDMI/CSI path to the board's capture) */
    const char *v4l2_format;
    bool v4l2_depth;
    bool synth_poses;          /* synthesise poses instead of reading the board's (implied by --file/--stdout) */
    int eye_w, eye_h;
    double fov[4], near_z;
    bool fov_set, near_set;    /* --fov / --near given: they override the board's camera message */
    unsigned planes;
    int depth_format;
    double rate_hz, duration_s, synth_rate_hz;
    long max_frames;
    long damage_every;
    int threads;
    bool verbose;
    hmdwarp_host_codec_options codec; /* --color-codec ... --depth-scale (framelink v2) */
    bool codec_set;
} feed_opts;

static atomic_bool g_stop;
static void on_signal(int sig)
{
    (void)sig;
    atomic_store(&g_stop, true);
}

static void usage(FILE *f)
{
    char scenes[256] = "";
    for (const char *const *n = sim_scene_names(); *n; n++)
        snprintf(scenes + strlen(scenes), sizeof scenes - strlen(scenes), "%s%s", scenes[0] ? " " : "", *n);
    fprintf(f,
            "Usage: hmdwarp-feed [options]\n"
            "Feeds host frames to an hmdwarp board over USB (the board runs as a FunctionFS gadget, see\n"
            "board/gadget.sh), a Unix socket or into a file: waits for the board's pose messages, renders each eye\n"
            "at the pose received, and sends framelink frames (docs/framelink.md) through libhmdwarp-host\n"
            "(docs/host-api.md).\n"
            "\n"
            "Device:\n"
            "  --device VID:PID    USB ids of the board, hex (default %04x:%04x)\n"
            "  --interface N       interface number of the hmdwarp function (default 0)\n"
            "  --wait S            keep retrying enumeration (or the socket) for S seconds (default 30)\n"
            "  --socket PATH       connect to hmdwarpd's socket backend at PATH instead of USB ([frames] backend =\n"
            "                      socket, device = PATH)\n"
            "Content:\n"
            "  --scene NAME        simulated scene to render (default room): %s\n"
            "  --png PATTERN       send PNG images instead (colour only); PATTERN may hold one %%d for the frame\n"
            "                      index, wrapping to 0 at the first missing file; both eyes get the same image\n"
            "  --sequence DIR      play a recorded sequence (docs/sequences.md): per-eye colour, depth, ids, motion\n"
            "                      and object poses with the poses they were rendered at; its size and cameras\n"
            "                      replace --eye/--fov/--near, --planes picks among its planes, --rate is not used\n"
            "  --sequence-rate R   own: at the manifest's times (the default); board: one frame per pose message\n"
            "  --loop              play the sequence again when it ends (default: once, then stop)\n"
            "  --eye WxH           eye size, must match the board's [eye] (default 720x800)\n"
            "  --fov L,R,U,D       left-eye half angles in degrees, mirrored for the right eye (default: the board's\n"
            "                      camera message, exactly; 52,48,52,52 without a board or when its eyes differ)\n"
            "  --near M            near plane in metres (default: the board's, else 0.05)\n"
            "  --planes LIST       planes to send when the scene needs them: color,depth,ids,motion,layers\n"
            "                      (default color,depth; the board must allocate them)\n"
            "  --depth f32|unorm16 depth plane format (unorm16 only with window-depth encodings; the simulator\n"
            "                      renders linear depth, so f32 there; default f32)\n"
            "  --threads N         render threads (default 2)\n"
            "Compression (framelink v2, docs/framelink.md; USB, socket and file output):\n"
            "  --color-codec C     raw, jpeg, h264, hevc or auto (what the board's camera message announces:\n"
            "                      JPEG when it decodes it); default auto\n"
            "  --quality N         JPEG quality 1..100 (default 75); video quantiser 1..51 (default 23)\n"
            "  --jpeg-sub 420|444  JPEG chroma subsampling (default 420)\n"
            "  --slices N          JPEG slices per eye 1..16, decoded in parallel on the board (default 4)\n"
            "  --video-kbps N      H.264/HEVC constant bit rate per eye in kbit/s (default 0: constant quality)\n"
            "  --depth-codec C     raw, zstd or auto (zstd when the board decodes it); default auto\n"
            "  --depth-format F    depth on the wire: f32, unorm16 (window depth), inv16 (linear depth as\n"
            "                      65535 * near / z) or auto (inv16/unorm16 with zstd); default auto\n"
            "  --depth-scale 0|1|2 send depth at 1/2^N resolution per axis (the board upsamples; default 0)\n"
            "  --other-codec C     ids, motion, layers: raw, zstd or auto; default auto\n"
            "Pacing:\n"
            "  --rate HZ           render at most this often (default 45)\n"
            "  --frames N          stop after N frames (default: run until interrupted)\n"
            "  --duration S        stop after S seconds\n"
            "Output (instead of USB, for tests and captures):\n"
            "  --file PATH         write the frame stream to PATH; poses are synthesised (a slow head turn)\n"
            "  --stdout            the same on standard output\n"
            "  --synth-rate HZ     pose rate synthesised in file mode (default 90)\n"
            "  --v4l2 DEV          write the frames to a V4L2 output device instead, in the in-band layout of\n"
            "                      docs/v4l2-inband.md (HDMI/CSI capture on the board; vivid's loop in tests); poses\n"
            "                      still come from the board over USB unless --synth-poses\n"
            "  --v4l2-format FMT   yuyv, nv12, bgr32 or rgb24 (default yuyv)\n"
            "  --v4l2-depth        pack the depth plane below the colour (board: [frames] depth = true)\n"
            "  --synth-poses       synthesise poses (a slow head turn) instead of reading the board's\n"
            "Faults (USB, socket and file output; hardware-in-the-loop tests):\n"
            "  --damage-every N    damage every Nth frame on the wire, in turn: one payload byte flipped (the\n"
            "                      board rejects it: crc), cut to half its bytes (truncated; the board resyncs on\n"
            "                      the next frame's magic), a version the board does not speak (bad version)\n"
            "Other:\n"
            "  -v, --verbose       per-frame lines\n"
            "  -h, --help          this text\n"
            "  --version           print the version and exit\n"
            "Prints throughput (MB/s, frames/s) and latency (board pose received -> frame sent, ms) every second.\n",
            DEFAULT_VID, DEFAULT_PID, scenes);
}

static unsigned parse_planes(const char *s)
{
    static const char *const names[] = {"color", "depth", "ids", "motion", "layers"};
    unsigned m = 0;
    char buf[128];
    snprintf(buf, sizeof buf, "%s", s);
    for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ",")) {
        int i;
        for (i = 0; i < 5 && strcmp(tok, names[i]) != 0; i++) {
        }
        if (i == 5) return 0;
        m |= 1u << i;
    }
    return m | DRV_PLANE_COLOR;
}

static bool parse_opts(int argc, char **argv, feed_opts *o)
{
    *o = (feed_opts){.v4l2_format = "yuyv", .vid = DEFAULT_VID, .pid = DEFAULT_PID, .wait_s = 30, .scene = "room", .eye_w = 720,
                     .eye_h = 800, .fov = {52, 48, 52, 52}, .near_z = 0.05,
                     .planes = DRV_PLANE_COLOR | DRV_PLANE_DEPTH, .rate_hz = 45, .synth_rate_hz = 90, .threads = 2,
                     .seq_rate = "own"};
    enum { O_DEVICE = 256, O_IFACE, O_WAIT, O_SCENE, O_PNG, O_EYE, O_FOV, O_NEAR, O_PLANES, O_DEPTH, O_THREADS,
           O_RATE, O_FRAMES, O_DURATION, O_FILE, O_STDOUT, O_SYNTH, O_V4L2, O_V4L2_FMT, O_V4L2_DEPTH, O_SYNTH_POSES,
           O_DAMAGE, O_SOCKET, O_SEQUENCE, O_SEQ_RATE, O_LOOP, O_COLOR_CODEC, O_QUALITY, O_JPEG_SUB, O_SLICES,
           O_VIDEO_KBPS, O_DEPTH_CODEC, O_DEPTH_FORMAT, O_DEPTH_SCALE, O_OTHER_CODEC };
    /* One entry a line: a new option is a line here and a case below. */
    static const struct option lo[] = {
        {"socket", 1, 0, O_SOCKET},
        {"device", 1, 0, O_DEVICE}, {"interface", 1, 0, O_IFACE}, {"wait", 1, 0, O_WAIT}, {"scene", 1, 0, O_SCENE},
        {"png", 1, 0, O_PNG}, {"sequence", 1, 0, O_SEQUENCE}, {"sequence-rate", 1, 0, O_SEQ_RATE},
        {"loop", 0, 0, O_LOOP}, {"eye", 1, 0, O_EYE}, {"fov", 1, 0, O_FOV}, {"near", 1, 0, O_NEAR},
        {"planes", 1, 0, O_PLANES}, {"depth", 1, 0, O_DEPTH}, {"threads", 1, 0, O_THREADS}, {"rate", 1, 0, O_RATE},
        {"frames", 1, 0, O_FRAMES}, {"duration", 1, 0, O_DURATION}, {"file", 1, 0, O_FILE},
        {"stdout", 0, 0, O_STDOUT}, {"synth-rate", 1, 0, O_SYNTH}, {"v4l2", 1, 0, O_V4L2},
        {"v4l2-format", 1, 0, O_V4L2_FMT}, {"v4l2-depth", 0, 0, O_V4L2_DEPTH}, {"synth-poses", 0, 0, O_SYNTH_POSES}, {"damage-every", 1, 0, O_DAMAGE}, {"verbose", 0, 0, 'v'}, {"help", 0, 0, 'h'},
        {"color-codec", 1, 0, O_COLOR_CODEC},
        {"quality", 1, 0, O_QUALITY},
        {"jpeg-sub", 1, 0, O_JPEG_SUB},
        {"slices", 1, 0, O_SLICES},
        {"video-kbps", 1, 0, O_VIDEO_KBPS},
        {"depth-codec", 1, 0, O_DEPTH_CODEC},
        {"depth-format", 1, 0, O_DEPTH_FORMAT},
        {"depth-scale", 1, 0, O_DEPTH_SCALE},
        {"other-codec", 1, 0, O_OTHER_CODEC},
        {"version", 0, 0, 'V'}, {0, 0, 0, 0}};
    int c;
    hmdwarp_host_codec_defaults(&o->codec); /* auto: what the board announces, as the library does */
    while ((c = getopt_long(argc, argv, "vh", lo, NULL)) != -1) {
        switch (c) {
        case O_DEVICE:
            if (sscanf(optarg, "%x:%x", &o->vid, &o->pid) != 2) return fprintf(stderr, "--device wants VID:PID\n"), false;
            break;
        case O_IFACE: o->interface = atoi(optarg); break;
        case O_WAIT: o->wait_s = atof(optarg); break;
        case O_SCENE: o->scene = optarg; break;
        case O_PNG: o->png = optarg; break;
        case O_SEQUENCE: o->sequence = optarg; break;
        case O_SEQ_RATE: o->seq_rate = optarg; break;
        case O_LOOP: o->loop = true; break;
        case O_EYE:
            if (sscanf(optarg, "%dx%d", &o->eye_w, &o->eye_h) != 2 || o->eye_w <= 0 || o->eye_h <= 0)
                return fprintf(stderr, "--eye wants WxH\n"), false;
            break;
        case O_FOV:
            if (sscanf(optarg, "%lf,%lf,%lf,%lf", &o->fov[0], &o->fov[1], &o->fov[2], &o->fov[3]) != 4)
                return fprintf(stderr, "--fov wants L,R,U,D\n"), false;
            o->fov_set = true;
            break;
        case O_NEAR:
            o->near_z = atof(optarg);
            o->near_set = true;
            break;
        case O_PLANES:
            o->planes = parse_planes(optarg);
            if (!o->planes) return fprintf(stderr, "--planes: unknown plane in '%s'\n", optarg), false;
            break;
        case O_DEPTH:
            if (strcmp(optarg, "f32") == 0)
                o->depth_format = DRV_FRAMELINK_FMT_F32;
            else if (strcmp(optarg, "unorm16") == 0)
                o->depth_format = DRV_FRAMELINK_FMT_UNORM16;
            else
                return fprintf(stderr, "--depth wants f32 or unorm16\n"), false;
            break;
        case O_THREADS: o->threads = atoi(optarg); break;
        case O_RATE: o->rate_hz = atof(optarg); break;
        case O_FRAMES: o->max_frames = atol(optarg); break;
        case O_DURATION: o->duration_s = atof(optarg); break;
        case O_FILE: o->out_path = optarg; break;
        case O_SOCKET: o->socket_path = optarg; break;
        case O_STDOUT: o->out_path = "-"; break;
        case O_SYNTH: o->synth_rate_hz = atof(optarg); break;
        case O_V4L2: o->v4l2_dev = optarg; break;
        case O_V4L2_FMT: o->v4l2_format = optarg; break;
        case O_V4L2_DEPTH: o->v4l2_depth = true; break;
        case O_SYNTH_POSES: o->synth_poses = true; break;
        case O_DAMAGE:
            o->damage_every = atol(optarg);
            if (o->damage_every < 1) return fprintf(stderr, "--damage-every wants a whole number >= 1\n"), false;
            break;
        case O_COLOR_CODEC:
        case O_DEPTH_CODEC:
        case O_OTHER_CODEC: {
            /* colour: raw jpeg h264 hevc; depth and other planes: raw zstd; auto for each */
            static const char *const names[] = {"raw", "zstd", "jpeg", "h264", "hevc"};
            const bool color = c == O_COLOR_CODEC;
            int v = strcmp(optarg, "auto") == 0 ? HMDWARP_HOST_CODEC_AUTO : -2;
            for (int i = 0; i < 5 && v == -2; i++)
                if (strcmp(optarg, names[i]) == 0 && (color ? i != 1 : i <= 1)) v = i;
            if (v == -2)
                return fprintf(stderr, "--%s wants %s or auto\n", color ? "color-codec" : c == O_DEPTH_CODEC
                                                                       ? "depth-codec" : "other-codec",
                               color ? "raw, jpeg, h264, hevc" : "raw, zstd"), false;
            *(color ? &o->codec.color : c == O_DEPTH_CODEC ? &o->codec.depth : &o->codec.other) = v;
            o->codec_set = true;
            break;
        }
        case O_QUALITY: o->codec.quality = atoi(optarg), o->codec_set = true; break;
        case O_JPEG_SUB: o->codec.jpeg_subsampling = atoi(optarg), o->codec_set = true; break;
        case O_SLICES: o->codec.slices = atoi(optarg), o->codec_set = true; break;
        case O_VIDEO_KBPS: o->codec.video_kbps = atoi(optarg), o->codec_set = true; break;
        case O_DEPTH_SCALE: o->codec.depth_scale = atoi(optarg), o->codec_set = true; break;
        case O_DEPTH_FORMAT: {
            static const char *const names[] = {"auto", "f32", "unorm16", "inv16"};
            int v = -1;
            for (int i = 0; i < 4; i++)
                if (strcmp(optarg, names[i]) == 0) v = i;
            if (v < 0) return fprintf(stderr, "--depth-format wants f32, unorm16, inv16 or auto\n"), false;
            o->codec.depth_format = v;
            o->codec_set = true;
            break;
        }
        case 'v': o->verbose = true; break;
        case 'h': usage(stdout); exit(0);
        case 'V': printf("hmdwarp-feed %s\n", plat_version()); exit(0);
        default: usage(stderr); return false;
        }
    }
    if (optind < argc) return fprintf(stderr, "unexpected argument '%s' (see --help)\n", argv[optind]), false;
    if (!(o->rate_hz > 0) || !(o->synth_rate_hz > 0) || o->threads < 1)
        return fprintf(stderr, "--rate, --synth-rate and --threads must be positive\n"), false;
    if (o->damage_every && o->v4l2_dev)
        return fprintf(stderr, "--damage-every damages framelink bytes: USB, socket or file output only, not --v4l2\n"),
               false;
    if (o->socket_path && o->out_path)
        return fprintf(stderr, "--socket and --file/--stdout are two outputs: choose one\n"), false;
    if (o->codec_set && o->v4l2_dev)
        return fprintf(stderr, "--color-codec ... --depth-scale compress framelink frames: USB, socket or file "
                               "output only, not --v4l2\n"), false;
    return true;
}

/* ---- poses: the board's (libhmdwarp-host), or synthesised (file output, --synth-poses) ---- */

/* A slow head turn on the pose clock of a board that sends synth_rate_hz messages: the pose of the newest tick. */
static hmdwarp_host_pose_msg synth_pose(int64_t t0, double rate_hz)
{
    static const warp_head *h;
    static warp_head head;
    if (!h) head = warp_head_default(), h = &head;
    int64_t now = plat_now_ns(), period = (int64_t)(1e9 / rate_hz);
    hmdwarp_host_pose_msg m = {.seq = (uint32_t)((now - t0) / period + 1)};
    m.board_time_ns = t0 + (int64_t)(m.seq - 1) * period;
    m.target_time_ns = m.board_time_ns + 20 * PLAT_NS_PER_MS;
    m.received_ns = now;
    double t = (double)(m.target_time_ns - t0) * 1e-9;
    warp_pose head_pose =
        warp_head_pose_from_orientation(h, warp_quat_from_ypr(0.5 * sin(0.5 * t), 0.1 * sin(0.3 * t), 0));
    for (int e = 0; e < 2; e++) {
        warp_pose p = warp_head_eye_pose(h, head_pose, e);
        m.eye[e] = (hmdwarp_host_pose){{p.q.w, p.q.x, p.q.y, p.q.z}, {p.p.x, p.p.y, p.p.z}};
    }
    return m;
}

static warp_pose pose_from_host(const hmdwarp_host_pose *p)
{
    return (warp_pose){{p->orientation[0], p->orientation[1], p->orientation[2], p->orientation[3]},
                       {p->position[0], p->position[1], p->position[2]}};
}

/* ---- the frame as libhmdwarp-host takes it: pointers into the rendered drv_frame ---- */

typedef struct {
    hmdwarp_host_frame fr;
    hmdwarp_host_frame all; /* every plane the scene renders: fr starts from it each frame (drop_unaccepted) */
    hmdwarp_host_fragment *frags[2]; /* the layers plane packed (the library wants the fragments back to back) */
    uint8_t *counts[2];
    hmdwarp_host_pose objects[DRV_MAX_OBJECTS];
} host_frame;

static bool host_frame_init(host_frame *hf, const drv_frame *f, unsigned planes)
{
    memset(hf, 0, sizeof *hf);
    hf->fr.color_format = HMDWARP_HOST_COLOR_RGBA8;
    /* The simulator renders linear depth; a sequence's depth may be window depth (its manifest's encoding). */
    hf->fr.depth_format = !(planes & DRV_PLANE_DEPTH)                     ? HMDWARP_HOST_DEPTH_NONE
                          : f->depth_encoding == WARP_DEPTH_STANDARD ? HMDWARP_HOST_DEPTH_STANDARD_F32
                          : f->depth_encoding == WARP_DEPTH_REVERSED ? HMDWARP_HOST_DEPTH_REVERSED_F32
                                                                     : HMDWARP_HOST_DEPTH_LINEAR_F32;
    for (int e = 0; e < 2; e++) {
        hmdwarp_host_eye *ey = &hf->fr.eye[e];
        const warp_camera *c = &f->cam[e];
        ey->camera = (hmdwarp_host_camera){(uint32_t)c->width, (uint32_t)c->height, c->tan_left, c->tan_right,
                                           c->tan_up, c->tan_down, c->near_z, c->far_z};
        ey->color = f->color[e].px, ey->color_stride = (size_t)f->color[e].stride * sizeof(warp_rgba8);
        if (planes & DRV_PLANE_DEPTH) ey->depth = f->depth[e].px, ey->depth_stride = (size_t)f->depth[e].stride * 4;
        if (planes & DRV_PLANE_IDS) ey->ids = f->ids[e].px, ey->ids_stride = (size_t)f->ids[e].stride * 2;
        if (planes & DRV_PLANE_MOTION)
            ey->motion = &f->motion[e].px[0].x, ey->motion_stride = (size_t)f->motion[e].stride * sizeof(warp_vec2f);
        if (planes & DRV_PLANE_LAYERS) {
            const warp_image_layers *l = &f->layers[e];
            hf->frags[e] = malloc((size_t)l->w * l->h * l->max_layers * sizeof(hmdwarp_host_fragment));
            hf->counts[e] = malloc((size_t)l->w * l->h);
            if (!hf->frags[e] || !hf->counts[e]) return false;
            ey->layer_count = hf->counts[e];
            ey->fragments = hf->frags[e];
        }
    }
    hf->fr.object_poses = hf->objects;
    hf->all = hf->fr;
    return true;
}

static void host_frame_free(host_frame *hf)
{
    for (int e = 0; e < 2; e++) free(hf->frags[e]), free(hf->counts[e]);
}

/* The per-frame fields: poses, times, objects, and the layers packed. */
static void host_frame_update(host_frame *hf, const drv_frame *f, const hmdwarp_host_pose_msg *pm, bool echo,
                              int64_t start, int64_t end)
{
    hmdwarp_host_frame *fr = &hf->fr;
    *fr = hf->all;
    fr->pose_seq = echo ? pm->seq : 0;
    fr->pose_target_ns = echo ? 0 : pm->target_time_ns;
    fr->pose_board_ns = echo ? 0 : pm->board_time_ns;
    fr->pose_received_ns = echo ? 0 : pm->received_ns;
    /* Not echoing: the poses the frame was rendered at (a synthesised pose's, or a sequence's own). */
    for (int e = 0; e < 2; e++) {
        warp_pose p = f->eye_pose[e];
        fr->eye[e].pose = echo ? (hmdwarp_host_pose){{0}, {0}}
                               : (hmdwarp_host_pose){{p.q.w, p.q.x, p.q.y, p.q.z}, {p.p.x, p.p.y, p.p.z}};
    }
    fr->render_start_ns = start;
    fr->render_end_ns = end;
    fr->scene_time = f->scene_time;
    fr->n_objects = (unsigned)f->n_objects;
    for (int i = 0; i < f->n_objects; i++) {
        warp_pose p = f->object_pose[i];
        hf->objects[i] = (hmdwarp_host_pose){{p.q.w, p.q.x, p.q.y, p.q.z}, {p.p.x, p.p.y, p.p.z}};
    }
    for (int e = 0; e < 2; e++) {
        if (!hf->frags[e]) continue;
        const warp_image_layers *l = &f->layers[e];
        size_t n = 0;
        for (size_t i = 0; i < (size_t)l->w * (size_t)l->h; i++) {
            int c = l->count[i] < l->max_layers ? l->count[i] : l->max_layers;
            hf->counts[e][i] = (uint8_t)c;
            for (int k = 0; k < c; k++, n++) {
                const warp_fragment *s = &l->frag[i * (size_t)l->max_layers + (size_t)k];
                hf->frags[e][n] = (hmdwarp_host_fragment){s->z, {s->rgba.r, s->rgba.g, s->rgba.b, s->rgba.a}, s->id};
            }
        }
        fr->eye[e].n_fragments = n;
    }
}

/* Leaves out the planes the board's camera message does not accept (it allocated none for them): the scene's other
 * planes still help its warps, where the library would refuse the whole frame. */
static void drop_unaccepted(hmdwarp_host *h, hmdwarp_host_frame *fr, bool *said)
{
    hmdwarp_host_cameras c;
    if (hmdwarp_host_get_cameras(h, &c) != 1) return;
    unsigned dropped = 0;
    for (int e = 0; e < 2; e++) {
        hmdwarp_host_eye *ey = &fr->eye[e];
        if (ey->depth && !(c.planes & HMDWARP_HOST_PLANE_DEPTH)) ey->depth = NULL, dropped |= HMDWARP_HOST_PLANE_DEPTH;
        if (ey->ids && !(c.planes & HMDWARP_HOST_PLANE_IDS)) ey->ids = NULL, dropped |= HMDWARP_HOST_PLANE_IDS;
        if (ey->motion && !(c.planes & HMDWARP_HOST_PLANE_MOTION))
            ey->motion = NULL, dropped |= HMDWARP_HOST_PLANE_MOTION;
        if (ey->layer_count && !(c.planes & HMDWARP_HOST_PLANE_LAYERS))
            ey->layer_count = NULL, ey->fragments = NULL, ey->n_fragments = 0, dropped |= HMDWARP_HOST_PLANE_LAYERS;
    }
    if (dropped & HMDWARP_HOST_PLANE_DEPTH) fr->depth_format = HMDWARP_HOST_DEPTH_NONE;
    if (dropped && !*said) {
        fprintf(stderr, "hmdwarp-feed: the board accepts planes 0x%x: not sending 0x%x\n", c.planes, dropped);
        *said = true;
    }
}

/* Renders exactly the field the board announces (its [eye] fov, from its lens when auto) unless --fov said
 * otherwise: the tangents and near plane of its camera message, when its eyes are the size allocated (--eye). The
 * hidden-area mask that follows it is reported; the scene renderer shades every pixel regardless. */
static void adopt_board_cameras(hmdwarp_host *h, const feed_opts *o, drv_frame *f, host_frame *hf)
{
    hmdwarp_host_cameras c;
    if (hmdwarp_host_wait_cameras(h, 2000, &c) != 1) {
        fprintf(stderr, "hmdwarp-feed: no camera message from the board: rendering --fov %g,%g,%g,%g\n", o->fov[0],
                o->fov[1], o->fov[2], o->fov[3]);
        return;
    }
    for (int e = 0; e < 2; e++)
        if ((int)c.cam[e].width != f->cam[e].width || (int)c.cam[e].height != f->cam[e].height) {
            fprintf(stderr, "hmdwarp-feed: the board's eyes are %ux%u, --eye %dx%d: rendering --fov\n", c.cam[e].width,
                    c.cam[e].height, f->cam[e].width, f->cam[e].height);
            return;
        }
    for (int e = 0; e < 2; e++) {
        warp_camera *w = &f->cam[e];
        w->tan_left = c.cam[e].tan_left, w->tan_right = c.cam[e].tan_right;
        w->tan_up = c.cam[e].tan_up, w->tan_down = c.cam[e].tan_down;
        if (!o->near_set) w->near_z = c.cam[e].near_z;
        hf->fr.eye[e].camera = (hmdwarp_host_camera){(uint32_t)w->width, (uint32_t)w->height, w->tan_left,
                                                     w->tan_right, w->tan_up, w->tan_down, w->near_z, w->far_z};
    }
    float uv[2 * HMDWARP_HOST_MASK_MAX];
    const double d = 180 / WARP_PI;
    /* the mask message comes right behind the camera message */
    for (int i = 0; i < 10 && hmdwarp_host_get_visibility_mask(h, 0, uv, 0) <= 0; i++) plat_sleep_ns(10 * PLAT_NS_PER_MS);
    fprintf(stderr, "hmdwarp-feed: rendering the board's field: left eye %.1f %.1f %.1f %.1f deg (left right up down); "
                    "visibility mask %d + %d vertices\n",
            atan(c.cam[0].tan_left) * d, atan(c.cam[0].tan_right) * d, atan(c.cam[0].tan_up) * d,
            atan(c.cam[0].tan_down) * d, hmdwarp_host_get_visibility_mask(h, 0, uv, HMDWARP_HOST_MASK_MAX),
            hmdwarp_host_get_visibility_mask(h, 1, uv, HMDWARP_HOST_MASK_MAX));
}

/* Opens the library's connection for the options: --file/--stdout, --socket, or the board over USB. */
static hmdwarp_host *open_link(const feed_opts *o)
{
    hmdwarp_host_options ho = {.wait_s = o->wait_s};
    if (o->out_path) {
        ho.transport = HMDWARP_HOST_TRANSPORT_FILE, ho.path = o->out_path;
    } else if (o->socket_path) {
        ho.transport = HMDWARP_HOST_TRANSPORT_SOCKET, ho.path = o->socket_path;
    } else {
        ho.transport = HMDWARP_HOST_TRANSPORT_USB, ho.vid = (uint16_t)o->vid, ho.pid = (uint16_t)o->pid;
        ho.interface = o->interface;
        fprintf(stderr, "hmdwarp-feed: waiting for %04x:%04x ...\n", o->vid, o->pid);
    }
    hmdwarp_host *h = hmdwarp_host_open_ex(&ho);
    if (!h) {
        fprintf(stderr, "hmdwarp-feed: %s\n", hmdwarp_host_last_error());
        return NULL;
    }
    if (!o->out_path)
        fprintf(stderr, "hmdwarp-feed: connected to %s\n", o->socket_path ? o->socket_path : "the board");
    if (o->codec_set && hmdwarp_host_set_codec(h, &o->codec) != HMDWARP_HOST_OK) {
        fprintf(stderr, "hmdwarp-feed: %s\n", hmdwarp_host_last_error());
        hmdwarp_host_close(h);
        return NULL;
    }
    return h;
}

/* ---- rendering ---- */

typedef struct {
    const sim_scene *scene;
    drv_frame *f;
    unsigned planes;
    double t;
    int h;
} render_job;

static void render_task(void *ctx, int task)
{
    render_job *j = ctx;
    int bands = (j->h + BAND - 1) / BAND, eye = task / bands, y0 = (task % bands) * BAND;
    int y1 = y0 + BAND < j->h ? y0 + BAND : j->h;
    sim_buffers b;
    memset(&b, 0, sizeof b);
    b.color = j->f->color[eye];
    b.depth = j->f->depth[eye];
    b.ids = j->f->ids[eye];
    b.motion = j->f->motion[eye];
    b.layers = j->f->layers[eye];
    b.planes = j->planes;
    sim_render_rows(j->scene, j->t, j->f->eye_pose[eye], &j->f->cam[eye], j->planes, &b, y0, y1);
}

static bool load_png(const char *pattern, long index, warp_image_rgba8 *img, char *err, int errlen)
{
    char path[512];
    if (strstr(pattern, "%d")) {
        snprintf(path, sizeof path, pattern, (int)index);
        FILE *f = fopen(path, "rb");
        if (!f && index > 0) snprintf(path, sizeof path, pattern, 0); /* wrap */
        if (f) fclose(f);
    } else {
        snprintf(path, sizeof path, "%s", pattern);
    }
    return plat_png_read(path, img, err, errlen);
}

int main(int argc, char **argv)
{
    feed_opts o;
    if (!parse_opts(argc, argv, &o)) return 2;
    signal(SIGINT, on_signal);
    signal(SIGTERM, on_signal);
    signal(SIGPIPE, SIG_IGN);

    const sim_scene *scene = NULL;
    unsigned planes = DRV_PLANE_COLOR;
    feed_sequence *seq = NULL;
    int max_layers = 4;
    char serr[600];
    if (o.sequence) {
        if (!(seq = feed_sequence_open(o.sequence, o.seq_rate, o.loop, serr, sizeof serr)))
            return fprintf(stderr, "hmdwarp-feed: --sequence: %s\n", serr), 2;
        feed_sequence_shape(seq, o.planes, &o.eye_w, &o.eye_h, &planes, &max_layers);
    } else if (!o.png) {
        scene = sim_scene_find(o.scene);
        if (!scene) return fprintf(stderr, "hmdwarp-feed: unknown scene '%s' (see --help)\n", o.scene), 2;
        planes = (sim_planes_for_effects(sim_scene_effects(scene)) & o.planes) | DRV_PLANE_COLOR;
    }
    if ((planes & DRV_PLANE_DEPTH) && o.depth_format == DRV_FRAMELINK_FMT_UNORM16)
        return fprintf(stderr, "hmdwarp-feed: these planes/depth format cannot be encoded (--depth unorm16 needs "
                               "window depth; the simulator renders linear depth)\n"), 2;
    drv_frame f;
    if (!drv_frame_alloc(&f, o.eye_w, o.eye_h, planes, max_layers))
        return fprintf(stderr, "hmdwarp-feed: out of memory\n"), 1;
    f.planes = planes;
    f.depth_encoding = WARP_DEPTH_LINEAR;
    for (int e = 0; e < 2; e++) {
        double l = tan(o.fov[0] * WARP_PI / 180), r = tan(o.fov[1] * WARP_PI / 180);
        warp_camera *c = &f.cam[e];
        c->width = o.eye_w, c->height = o.eye_h;
        c->tan_left = e == WARP_EYE_LEFT ? l : r; /* mirrored for the right eye, like the board's config */
        c->tan_right = e == WARP_EYE_LEFT ? r : l;
        c->tan_up = tan(o.fov[2] * WARP_PI / 180);
        c->tan_down = tan(o.fov[3] * WARP_PI / 180);
        c->near_z = o.near_z;
        c->far_z = INFINITY;
        const char *why = warp_camera_check(c);
        if (why) return fprintf(stderr, "hmdwarp-feed: camera: %s\n", why), 2;
    }
    if (scene) f.n_objects = sim_scene_object_count(scene) < DRV_MAX_OBJECTS ? sim_scene_object_count(scene)
                                                                             : DRV_MAX_OBJECTS;
    if (seq && !feed_sequence_prepare(seq, &f, serr, sizeof serr))
        return fprintf(stderr, "hmdwarp-feed: --sequence: %s\n", serr), 2;
    host_frame hf;
    plat_workers *workers = plat_workers_create(o.threads - 1, 0);
    if (!host_frame_init(&hf, &f, planes) || !workers) return fprintf(stderr, "hmdwarp-feed: out of memory\n"), 1;

    /* Frames go through libhmdwarp-host (USB, socket, file) or to a V4L2 output; poses come from the board over the
     * library's link (also when the pixels go out over V4L2) unless synthesised. */
    bool synth = o.synth_poses || o.out_path;
    drv_v4l2_output *vo = NULL;
    hmdwarp_host *h = NULL;
    if (o.v4l2_dev) {
        char err[300];
        vo = drv_v4l2_output_open(o.v4l2_dev, o.v4l2_format, o.eye_w, o.eye_h, o.v4l2_depth, err, sizeof err);
        if (!vo) return fprintf(stderr, "hmdwarp-feed: --v4l2 %s: %s\n", o.v4l2_dev, err), 1;
    }
    if ((!o.v4l2_dev || !synth) && !(h = open_link(&o))) return 1;
    if (h && !seq && !o.fov_set && !o.out_path) adopt_board_cameras(h, &o, &f, &hf);
    const char *sink_name = vo ? "v4l2" : o.out_path ? "file" : o.socket_path ? "socket" : "usb";
    uint8_t *buf = NULL; /* --damage-every: the encoded frame, damaged before it is sent */
    size_t cap = 0;

    int64_t t_start = plat_now_ns(), last_start = 0, period = seq ? 0 : (int64_t)(1e9 / o.rate_hz);
    int64_t scene_t0 = 0, report_at = t_start + PLAT_NS_PER_S;
    uint64_t frames = 0, win_frames = 0, win_bytes = 0, damaged = 0, damaged_kind[3] = {0}, synth_poses = 0;
    static const char *const damage_names[3] = {"crc", "truncated", "version"};
    double win_latency_ms = 0, win_render_ms = 0;
    bool said_gone = false, said_dropped = false;
    uint64_t bytes_before = 0;
    int rc = 0;
    while (!atomic_load(&g_stop)) {
        if (o.max_frames && (long)frames >= o.max_frames) break;
        if (o.duration_s > 0 && plat_now_ns() - t_start > (int64_t)(o.duration_s * 1e9)) break;
        if (last_start) plat_sleep_until_ns(last_start + period);
        hmdwarp_host_pose_msg pose;
        if (synth) {
            /* A pose newer than the last one used, as from a board: wait for the next tick when it is the same. */
            pose = synth_pose(t_start, o.synth_rate_hz);
            if (pose.seq <= synth_poses) {
                plat_sleep_until_ns(t_start + (int64_t)synth_poses * (int64_t)(1e9 / o.synth_rate_hz));
                pose = synth_pose(t_start, o.synth_rate_hz);
            }
            synth_poses = pose.seq;
        } else {
            int got = hmdwarp_host_wait_pose(h, 200, &pose);
            if (got == HMDWARP_HOST_ERR_NOT_CONNECTED) {
                /* The board went away: the library reconnects when it is back. */
                if (!said_gone) fprintf(stderr, "hmdwarp-feed: %s\n", hmdwarp_host_last_error()), said_gone = true;
                plat_sleep_ns(100 * PLAT_NS_PER_MS);
                continue;
            }
            if (got != 1) continue;
            if (said_gone) fprintf(stderr, "hmdwarp-feed: the board is back\n"), said_gone = false;
        }
        int64_t start = plat_now_ns();
        last_start = start;
        if (!scene_t0) scene_t0 = pose.target_time_ns;
        f.seq = frames + 1;
        f.pose_t_ns = pose.target_time_ns;
        f.scene_time = (double)(pose.target_time_ns - scene_t0) * 1e-9;
        f.eye_pose[0] = pose_from_host(&pose.eye[0]);
        f.eye_pose[1] = pose_from_host(&pose.eye[1]);
        if (seq) {
            /* The sequence's eye poses replace the board's: the frame goes with the poses it was rendered at. */
            int got = feed_sequence_next(seq, &f, serr, sizeof serr);
            if (got < 0) fprintf(stderr, "hmdwarp-feed: --sequence: %s\n", serr), rc = 1;
            if (got <= 0) break;
        } else if (scene) {
            for (int i = 0; i < f.n_objects; i++) f.object_pose[i] = sim_scene_object_pose(scene, i + 1, f.scene_time);
            render_job j = {scene, &f, planes, f.scene_time, o.eye_h};
            plat_workers_run(workers, 2 * ((o.eye_h + BAND - 1) / BAND), render_task, &j);
        } else {
            warp_image_rgba8 img;
            char err[300];
            if (!load_png(o.png, (long)frames, &img, err, sizeof err)) {
                fprintf(stderr, "hmdwarp-feed: %s\n", err);
                rc = 1;
                break;
            }
            if (img.w != o.eye_w || img.h != o.eye_h) {
                fprintf(stderr, "hmdwarp-feed: %s is %dx%d, the eyes are %dx%d (--eye)\n", o.png, img.w, img.h,
                        o.eye_w, o.eye_h);
                warp_image_free(&img);
                rc = 1;
                break;
            }
            warp_image_rgba8_copy(&f.color[0], &img);
            warp_image_rgba8_copy(&f.color[1], &img);
            warp_image_free(&img);
        }
        int64_t end = plat_now_ns();
        size_t n = 0;
        int err = 0;
        if (vo) {
            err = drv_v4l2_output_write(vo, &f);
            if (err) fprintf(stderr, "hmdwarp-feed: writing a frame to the V4L2 output: %s\n", strerror(-err));
        } else {
            host_frame_update(&hf, &f, &pose, !synth && !seq, start, end);
            drop_unaccepted(h, &hf.fr, &said_dropped);
            if (o.damage_every && (frames + 1) % (uint64_t)o.damage_every == 0) {
                int64_t len = hmdwarp_host_encode(h, &hf.fr, buf, cap);
                if (len > (int64_t)cap) {
                    free(buf);
                    cap = (size_t)len;
                    if (!(buf = malloc(cap))) return fprintf(stderr, "hmdwarp-feed: out of memory\n"), 1;
                    len = hmdwarp_host_encode(h, &hf.fr, buf, cap);
                }
                err = len < 0 ? (int)len : 0;
                if (!err) {
                    /* The kinds in turn; the header's size fields stay intact so the board's resync is tested. */
                    int kind = (int)(damaged % 3);
                    size_t hdr = (size_t)buf[6] | (size_t)buf[7] << 8, wire = (size_t)len;
                    n = (size_t)len;
                    if (kind == 0) buf[hdr + (n - hdr - 4) / 2] ^= 0x5a; /* payload byte: payload CRC */
                    else if (kind == 1) wire = n / 2;                    /* truncated */
                    else buf[4] ^= 0x02;                                 /* version 3: bad version */
                    damaged++;
                    damaged_kind[kind]++;
                    if (o.verbose)
                        fprintf(stderr, "frame %llu: damaged (%s)\n", (unsigned long long)f.seq, damage_names[kind]);
                    err = hmdwarp_host_send_raw(h, buf, wire);
                    bytes_before += err ? 0 : wire;
                }
            } else {
                err = hmdwarp_host_submit(h, &hf.fr);
                hmdwarp_host_stats st;
                hmdwarp_host_get_stats(h, &st);
                n = (size_t)(st.bytes_sent - bytes_before); /* this thread is the only sender */
                bytes_before = st.bytes_sent;
            }
            if (err == HMDWARP_HOST_ERR_DISCONNECTED || err == HMDWARP_HOST_ERR_NOT_CONNECTED) {
                /* A frame cut short: the board drops it; the next pose after the reconnect renders the next one. */
                if (!said_gone) fprintf(stderr, "hmdwarp-feed: %s\n", hmdwarp_host_last_error()), said_gone = true;
                continue;
            }
            if (err) fprintf(stderr, "hmdwarp-feed: frame %llu: %s\n", (unsigned long long)f.seq,
                             hmdwarp_host_last_error());
        }
        if (err) {
            rc = 1;
            break;
        }
        int64_t sent = plat_now_ns();
        frames++;
        win_frames++;
        win_bytes += n;
        win_latency_ms += (double)(sent - pose.received_ns) * 1e-6;
        win_render_ms += (double)(end - start) * 1e-6;
        if (o.verbose)
            fprintf(stderr, "frame %llu: %zu bytes, pose %u, render %.1f ms, pose->sent %.1f ms\n",
                    (unsigned long long)f.seq, n, pose.seq, (double)(end - start) * 1e-6,
                    (double)(sent - pose.received_ns) * 1e-6);
        if (sent >= report_at) {
            hmdwarp_host_stats st = {.poses_received = synth_poses};
            if (h && !synth) hmdwarp_host_get_stats(h, &st);
            double s = (double)(sent - report_at + PLAT_NS_PER_S) * 1e-9;
            fprintf(stderr, "%s: %.1f MB/s, %.1f frames/s, render %.1f ms, latency pose->sent %.1f ms, poses %llu "
                            "(%llu bad)",
                    sink_name, (double)win_bytes / s * 1e-6, (double)win_frames / s, win_render_ms / (double)win_frames,
                    win_latency_ms / (double)win_frames, (unsigned long long)st.poses_received,
                    (unsigned long long)st.messages_rejected);
            hmdwarp_host_codec_stats cs;
            if (h && hmdwarp_host_get_codec_stats(h, &cs) == HMDWARP_HOST_OK && cs.compressed_frames > 0 &&
                cs.wire_bytes_last > 0)
                fprintf(stderr, ", compressed %.1f:1, encode %.1f ms, key frames %llu", cs.plane_bytes_last /
                        cs.wire_bytes_last, cs.encode_ms_last, (unsigned long long)cs.key_frames);
            fputc('\n', stderr);
            report_at = sent + PLAT_NS_PER_S;
            win_frames = win_bytes = 0;
            win_latency_ms = win_render_ms = 0;
        }
    }
    hmdwarp_host_close(h);
    if (vo) drv_v4l2_output_close(vo);
    fprintf(stderr, "hmdwarp-feed: %llu frames sent\n", (unsigned long long)frames);
    if (o.damage_every)
        fprintf(stderr, "hmdwarp-feed: %llu damaged: %s %llu, %s %llu, %s %llu\n", (unsigned long long)damaged,
                damage_names[0], (unsigned long long)damaged_kind[0], damage_names[1],
                (unsigned long long)damaged_kind[1], damage_names[2], (unsigned long long)damaged_kind[2]);
    plat_workers_destroy(workers);
    host_frame_free(&hf);
    feed_sequence_close(seq);
    drv_frame_free(&f);
    free(buf);
    return rc;
}
