/* SPDX-License-Identifier: MIT */
/* hmdwarp-feed: the host side of the USB frame link: reads the board's pose messages, renders the simulated scene
 * (or loads PNGs) at each pose, encodes frames with the framelink codec and sends them to the board (or a file). */
#include <errno.h>
#include <getopt.h>
#include <libusb.h>
#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "drivers/drv_framelink.h"
#include "drivers/drv_v4l2_output.h"
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
    const char *v4l2_dev;      /* --v4l2: a V4L2 output device (HDMI/CSI path to the board's capture) */
    const char *v4l2_format;
    bool v4l2_depth;
    bool synth_poses;          /* synthesise poses instead of reading the board's (implied by --file/--stdout) */
    int eye_w, eye_h;
    double fov[4], near_z;
    unsigned planes;
    int depth_format;
    double rate_hz, duration_s, synth_rate_hz;
    long max_frames;
    long damage_every;
    int threads;
    bool verbose;
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
            "board/gadget.sh) or into a file: waits for the board's pose messages on bulk IN, renders each eye at the\n"
            "pose received, and writes framelink frames (docs/framelink.md) to bulk OUT.\n"
            "\n"
            "Device:\n"
            "  --device VID:PID    USB ids of the board, hex (default %04x:%04x)\n"
            "  --interface N       interface number of the hmdwarp function (default 0)\n"
            "  --wait S            keep retrying enumeration for S seconds (no hotplug without udevd; default 30)\n"
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
            "  --fov L,R,U,D       left-eye half angles in degrees, mirrored for the right eye (default 52,48,52,52)\n"
            "  --near M            near plane in metres (default 0.05)\n"
            "  --planes LIST       planes to send when the scene needs them: color,depth,ids,motion,layers\n"
            "                      (default color,depth; the board must allocate them)\n"
            "  --depth f32|unorm16 depth plane format (unorm16 only with window-depth encodings; the simulator\n"
            "                      renders linear depth, so f32 there; default f32)\n"
            "  --threads N         render threads (default 2)\n"
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
            "Faults (USB and file output; hardware-in-the-loop tests):\n"
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
           O_RATE, O_FRAMES, O_DURATION, O_FILE, O_STDOUT, O_SYNTH, O_V4L2, O_V4L2_FMT, O_V4L2_DEPTH, O_SYNTH_POSES, O_DAMAGE,
           O_SEQUENCE, O_SEQ_RATE, O_LOOP };
    static const struct option lo[] = {
        {"device", 1, 0, O_DEVICE}, {"interface", 1, 0, O_IFACE}, {"wait", 1, 0, O_WAIT}, {"scene", 1, 0, O_SCENE},
        {"png", 1, 0, O_PNG}, {"sequence", 1, 0, O_SEQUENCE}, {"sequence-rate", 1, 0, O_SEQ_RATE},
        {"loop", 0, 0, O_LOOP}, {"eye", 1, 0, O_EYE}, {"fov", 1, 0, O_FOV}, {"near", 1, 0, O_NEAR},
        {"planes", 1, 0, O_PLANES}, {"depth", 1, 0, O_DEPTH}, {"threads", 1, 0, O_THREADS}, {"rate", 1, 0, O_RATE},
        {"frames", 1, 0, O_FRAMES}, {"duration", 1, 0, O_DURATION}, {"file", 1, 0, O_FILE},
        {"stdout", 0, 0, O_STDOUT}, {"synth-rate", 1, 0, O_SYNTH}, {"v4l2", 1, 0, O_V4L2},
        {"v4l2-format", 1, 0, O_V4L2_FMT}, {"v4l2-depth", 0, 0, O_V4L2_DEPTH}, {"synth-poses", 0, 0, O_SYNTH_POSES}, {"damage-every", 1, 0, O_DAMAGE}, {"verbose", 0, 0, 'v'}, {"help", 0, 0, 'h'},
        {"version", 0, 0, 'V'}, {0, 0, 0, 0}};
    int c;
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
            break;
        case O_NEAR: o->near_z = atof(optarg); break;
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
        return fprintf(stderr, "--damage-every damages framelink bytes: USB or file output only, not --v4l2\n"), false;
    return true;
}

/* ---- pose input: the board over bulk IN, or synthesised for file output ---- */

typedef struct {
    pthread_mutex_t lock;
    pthread_cond_t cond;
    drv_framelink_pose latest;
    int64_t latest_rx_ns;
    uint64_t received, bad;
    bool fresh;
    /* USB */
    libusb_device_handle *dev;
    unsigned char ep_in, ep_out;
    /* synthetic */
    double synth_rate_hz;
    pthread_t th;
    bool th_up;
} pose_input;

static void pose_store(pose_input *pi, const drv_framelink_pose *p)
{
    pthread_mutex_lock(&pi->lock);
    pi->latest = *p;
    pi->latest_rx_ns = plat_now_ns();
    pi->fresh = true;
    pi->received++;
    pthread_cond_signal(&pi->cond);
    pthread_mutex_unlock(&pi->lock);
}

static void *usb_pose_thread(void *arg)
{
    pose_input *pi = arg;
    unsigned char buf[512];
    while (!atomic_load(&g_stop)) {
        int n = 0;
        int rc = libusb_bulk_transfer(pi->dev, pi->ep_in, buf, sizeof buf, &n, 100);
        if (rc == LIBUSB_ERROR_TIMEOUT) continue;
        if (rc != 0) {
            fprintf(stderr, "hmdwarp-feed: reading poses: %s\n", libusb_strerror(rc));
            atomic_store(&g_stop, true);
            break;
        }
        drv_framelink_pose p;
        drv_frame_err e = drv_framelink_pose_decode(buf, (size_t)n, &p);
        if (e == DRV_FRAME_OK) {
            pose_store(pi, &p);
        } else {
            pthread_mutex_lock(&pi->lock);
            pi->bad++;
            pthread_mutex_unlock(&pi->lock);
            fprintf(stderr, "hmdwarp-feed: pose message rejected: %s (%d bytes)\n", drv_frame_err_str(e), n);
        }
    }
    return NULL;
}

/* File mode: a slow head turn, encoded and decoded through the codec like the board's messages. */
static void *synth_pose_thread(void *arg)
{
    pose_input *pi = arg;
    warp_head h = warp_head_default();
    int64_t t0 = plat_now_ns(), next = t0, period = (int64_t)(1e9 / pi->synth_rate_hz);
    uint32_t seq = 0;
    while (!atomic_load(&g_stop)) {
        plat_sleep_until_ns(next += period);
        drv_framelink_pose p = {.seq = ++seq, .board_t_ns = plat_now_ns()};
        p.target_t_ns = p.board_t_ns + 20 * PLAT_NS_PER_MS;
        double t = (double)(p.target_t_ns - t0) * 1e-9;
        p.head = warp_head_pose_from_orientation(&h, warp_quat_from_ypr(0.5 * sin(0.5 * t), 0.1 * sin(0.3 * t), 0));
        for (int e = 0; e < 2; e++) p.eye[e] = warp_head_eye_pose(&h, p.head, e);
        uint8_t msg[DRV_FRAMELINK_POSE_BYTES];
        drv_framelink_pose_encode(&p, msg, sizeof msg);
        drv_framelink_pose q;
        if (drv_framelink_pose_decode(msg, sizeof msg, &q) == DRV_FRAME_OK) pose_store(pi, &q);
    }
    return NULL;
}

/* Waits up to timeout_ms for a pose newer than the last one taken. */
static bool pose_take(pose_input *pi, int timeout_ms, drv_framelink_pose *p, int64_t *rx_ns)
{
    pthread_mutex_lock(&pi->lock);
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    ts.tv_nsec += (long)timeout_ms * 1000000L;
    ts.tv_sec += ts.tv_nsec / 1000000000L;
    ts.tv_nsec %= 1000000000L;
    while (!pi->fresh && !atomic_load(&g_stop))
        if (pthread_cond_timedwait(&pi->cond, &pi->lock, &ts) != 0) break;
    bool ok = pi->fresh;
    if (ok) {
        *p = pi->latest;
        *rx_ns = pi->latest_rx_ns;
        pi->fresh = false;
    }
    pthread_mutex_unlock(&pi->lock);
    return ok;
}

/* ---- frame output: USB bulk OUT, a file, or a V4L2 output device ---- */

typedef struct feed_sink feed_sink;
struct feed_sink {
    const char *name;
    /* buf/len: the framelink encoding of f (NULL/0 for sinks that do not want it) */
    bool (*write)(feed_sink *s, const drv_frame *f, const uint8_t *buf, size_t len);
    void (*close)(feed_sink *s);
    void *ctx;
    bool wants_bytes;
};

static bool v4l2_sink_write(feed_sink *s, const drv_frame *f, const uint8_t *buf, size_t len)
{
    (void)buf;
    (void)len;
    int rc = drv_v4l2_output_write(s->ctx, f);
    if (rc) fprintf(stderr, "hmdwarp-feed: writing a frame to the V4L2 output: %s\n", strerror(-rc));
    return rc == 0;
}
static void v4l2_sink_close(feed_sink *s) { drv_v4l2_output_close(s->ctx); }

static bool usb_sink_write(feed_sink *s, const drv_frame *f, const uint8_t *buf, size_t len)
{
    (void)f;
    pose_input *pi = s->ctx;
    while (len > 0 && !atomic_load(&g_stop)) {
        int n = 0, chunk = len > (1u << 24) ? 1 << 24 : (int)len;
        int rc = libusb_bulk_transfer(pi->dev, pi->ep_out, (unsigned char *)buf, chunk, &n, 2000);
        if (rc != 0 && rc != LIBUSB_ERROR_TIMEOUT) {
            fprintf(stderr, "hmdwarp-feed: writing a frame: %s\n", libusb_strerror(rc));
            return false;
        }
        buf += n;
        len -= (size_t)n;
    }
    return len == 0;
}
static void usb_sink_close(feed_sink *s) { (void)s; }

static bool file_sink_write(feed_sink *s, const drv_frame *f, const uint8_t *buf, size_t len)
{
    (void)f;
    if (fwrite(buf, 1, len, s->ctx) != len) {
        fprintf(stderr, "hmdwarp-feed: writing the stream: %s\n", strerror(errno));
        return false;
    }
    return fflush(s->ctx) == 0;
}
static void file_sink_close(feed_sink *s)
{
    if (s->ctx != stdout) fclose(s->ctx);
}

/* Opens the board by VID:PID, retrying: without udevd there is no hotplug, so poll enumeration. */
static bool usb_open(const feed_opts *o, pose_input *pi)
{
    int rc = libusb_init(NULL);
    if (rc != 0) return fprintf(stderr, "hmdwarp-feed: libusb_init: %s\n", libusb_strerror(rc)), false;
    int64_t until = plat_now_ns() + (int64_t)(o->wait_s * 1e9);
    bool said = false;
    while (!(pi->dev = libusb_open_device_with_vid_pid(NULL, (uint16_t)o->vid, (uint16_t)o->pid))) {
        if (atomic_load(&g_stop) || plat_now_ns() > until) {
            fprintf(stderr, "hmdwarp-feed: no USB device %04x:%04x after %.0f s (is the board's gadget bound? "
                            "permissions on /dev/bus/usb?)\n", o->vid, o->pid, o->wait_s);
            return false;
        }
        if (!said) fprintf(stderr, "hmdwarp-feed: waiting for %04x:%04x ...\n", o->vid, o->pid), said = true;
        plat_sleep_ns(500 * PLAT_NS_PER_MS);
        /* Without udevd libusb gets no hotplug events and keeps its first device list: a new context rescans. */
        libusb_exit(NULL);
        rc = libusb_init(NULL);
        if (rc != 0) return fprintf(stderr, "hmdwarp-feed: libusb_init: %s\n", libusb_strerror(rc)), false;
    }
    libusb_set_auto_detach_kernel_driver(pi->dev, 1);
    rc = libusb_claim_interface(pi->dev, o->interface);
    if (rc != 0)
        return fprintf(stderr, "hmdwarp-feed: claiming interface %d: %s\n", o->interface, libusb_strerror(rc)), false;
    /* The endpoints from the descriptors rather than assumed numbers. */
    struct libusb_config_descriptor *cfg;
    rc = libusb_get_active_config_descriptor(libusb_get_device(pi->dev), &cfg);
    if (rc != 0) return fprintf(stderr, "hmdwarp-feed: config descriptor: %s\n", libusb_strerror(rc)), false;
    for (int i = 0; i < cfg->bNumInterfaces; i++) {
        const struct libusb_interface_descriptor *id = &cfg->interface[i].altsetting[0];
        if (id->bInterfaceNumber != o->interface) continue;
        for (int e = 0; e < id->bNumEndpoints; e++) {
            const struct libusb_endpoint_descriptor *ep = &id->endpoint[e];
            if ((ep->bmAttributes & 3) != LIBUSB_TRANSFER_TYPE_BULK) continue;
            if (ep->bEndpointAddress & LIBUSB_ENDPOINT_IN)
                pi->ep_in = ep->bEndpointAddress;
            else
                pi->ep_out = ep->bEndpointAddress;
        }
    }
    libusb_free_config_descriptor(cfg);
    if (!pi->ep_in || !pi->ep_out)
        return fprintf(stderr, "hmdwarp-feed: interface %d has no bulk IN + OUT pair\n", o->interface), false;
    fprintf(stderr, "hmdwarp-feed: board %04x:%04x, bulk OUT 0x%02x, bulk IN 0x%02x\n", o->vid, o->pid, pi->ep_out,
            pi->ep_in);
    return true;
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
    drv_framelink_tx tx = {.depth_format = o.depth_format};
    if (scene) f.n_objects = sim_scene_object_count(scene) < DRV_MAX_OBJECTS ? sim_scene_object_count(scene)
                                                                             : DRV_MAX_OBJECTS;
    if (seq && !feed_sequence_prepare(seq, &f, serr, sizeof serr))
        return fprintf(stderr, "hmdwarp-feed: --sequence: %s\n", serr), 2;
    size_t cap = drv_framelink_size_ex(&f, &tx);
    if (!cap) return fprintf(stderr, "hmdwarp-feed: these planes/depth format cannot be encoded\n"), 2;
    if (planes & DRV_PLANE_LAYERS) cap += (size_t)2 * o.eye_w * o.eye_h * 4 * 10;
    uint8_t *buf = malloc(cap);
    plat_workers *workers = plat_workers_create(o.threads - 1, 0);
    if (!buf || !workers) return fprintf(stderr, "hmdwarp-feed: out of memory\n"), 1;

    pose_input pi;
    memset(&pi, 0, sizeof pi);
    pthread_mutex_init(&pi.lock, NULL);
    pthread_cond_init(&pi.cond, NULL);
    pi.synth_rate_hz = o.synth_rate_hz;
    feed_sink sink;
    if (o.out_path) {
        FILE *fp = strcmp(o.out_path, "-") == 0 ? stdout : fopen(o.out_path, "wb");
        if (!fp) return fprintf(stderr, "hmdwarp-feed: %s: %s\n", o.out_path, strerror(errno)), 1;
        sink = (feed_sink){"file", file_sink_write, file_sink_close, fp, true};
        pi.th_up = pthread_create(&pi.th, NULL, synth_pose_thread, &pi) == 0;
    } else {
        if (o.v4l2_dev) {
            char err[300];
            drv_v4l2_output *vo =
                drv_v4l2_output_open(o.v4l2_dev, o.v4l2_format, o.eye_w, o.eye_h, o.v4l2_depth, err, sizeof err);
            if (!vo) return fprintf(stderr, "hmdwarp-feed: --v4l2 %s: %s\n", o.v4l2_dev, err), 1;
            sink = (feed_sink){"v4l2", v4l2_sink_write, v4l2_sink_close, vo, false};
        }
        /* Poses come from the board over USB (also when the pixels go out over V4L2), unless synthesised. */
        if (o.synth_poses) {
            pi.th_up = pthread_create(&pi.th, NULL, synth_pose_thread, &pi) == 0;
        } else {
            if (!usb_open(&o, &pi)) return 1;
            pi.th_up = pthread_create(&pi.th, NULL, usb_pose_thread, &pi) == 0;
        }
        if (!o.v4l2_dev) sink = (feed_sink){"usb", usb_sink_write, usb_sink_close, &pi, true};
    }
    if (!pi.th_up) return fprintf(stderr, "hmdwarp-feed: cannot start the pose thread\n"), 1;

    int64_t t_start = plat_now_ns(), last_start = 0, period = seq ? 0 : (int64_t)(1e9 / o.rate_hz);
    int64_t scene_t0 = 0, report_at = t_start + PLAT_NS_PER_S;
    uint64_t frames = 0, win_frames = 0, win_bytes = 0, damaged = 0, damaged_kind[3] = {0};
    static const char *const damage_names[3] = {"crc", "truncated", "version"};
    double win_latency_ms = 0, win_render_ms = 0;
    int rc = 0;
    while (!atomic_load(&g_stop)) {
        if (o.max_frames && (long)frames >= o.max_frames) break;
        if (o.duration_s > 0 && plat_now_ns() - t_start > (int64_t)(o.duration_s * 1e9)) break;
        if (last_start) plat_sleep_until_ns(last_start + period);
        drv_framelink_pose pose;
        int64_t pose_rx;
        if (!pose_take(&pi, 200, &pose, &pose_rx)) continue;
        int64_t start = plat_now_ns();
        last_start = start;
        if (!scene_t0) scene_t0 = pose.target_t_ns;
        f.seq = frames + 1;
        f.pose_t_ns = pose.target_t_ns; /* echoed: the board needs no clock sync */
        f.scene_time = (double)(pose.target_t_ns - scene_t0) * 1e-9;
        f.eye_pose[0] = pose.eye[0];
        f.eye_pose[1] = pose.eye[1];
        if (seq) {
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
        tx.pose_sent_ns = pose.board_t_ns;
        tx.host_pose_rx_ns = pose_rx;
        tx.host_render_start_ns = start;
        tx.host_render_end_ns = plat_now_ns();
        tx.host_send_ns = plat_now_ns();
        size_t n = sink.wants_bytes ? drv_framelink_encode_ex(&f, &tx, buf, cap) : 1;
        if (!n) {
            fprintf(stderr, "hmdwarp-feed: frame %llu cannot be encoded\n", (unsigned long long)f.seq);
            rc = 1;
            break;
        }
        size_t wire = n;
        if (o.damage_every && (frames + 1) % (uint64_t)o.damage_every == 0) {
            /* The kinds in turn; the header's size fields stay intact so the board's resync is what is tested. */
            int kind = (int)(damaged % 3);
            size_t hdr = (size_t)buf[6] | (size_t)buf[7] << 8;
            if (kind == 0) buf[hdr + (n - hdr - 4) / 2] ^= 0x5a; /* payload byte: payload CRC */
            else if (kind == 1) wire = n / 2;                    /* truncated */
            else buf[4] ^= 0x02;                                 /* version 3: bad version */
            damaged++;
            damaged_kind[kind]++;
            if (o.verbose) fprintf(stderr, "frame %llu: damaged (%s)\n", (unsigned long long)f.seq, damage_names[kind]);
        }
        if (!sink.write(&sink, &f, sink.wants_bytes ? buf : NULL, sink.wants_bytes ? wire : 0)) {
            rc = 1;
            break;
        }
        int64_t sent = plat_now_ns();
        frames++;
        win_frames++;
        win_bytes += n;
        win_latency_ms += (double)(sent - pose_rx) * 1e-6;
        win_render_ms += (double)(tx.host_render_end_ns - start) * 1e-6;
        if (o.verbose)
            fprintf(stderr, "frame %llu: %zu bytes, pose %u, render %.1f ms, pose->sent %.1f ms\n",
                    (unsigned long long)f.seq, n, pose.seq, (double)(tx.host_render_end_ns - start) * 1e-6,
                    (double)(sent - pose_rx) * 1e-6);
        if (sent >= report_at) {
            double s = (double)(sent - report_at + PLAT_NS_PER_S) * 1e-9;
            fprintf(stderr, "%s: %.1f MB/s, %.1f frames/s, render %.1f ms, latency pose->sent %.1f ms, poses %llu "
                            "(%llu bad)\n",
                    sink.name, (double)win_bytes / s * 1e-6, (double)win_frames / s, win_render_ms / (double)win_frames,
                    win_latency_ms / (double)win_frames, (unsigned long long)pi.received, (unsigned long long)pi.bad);
            report_at = sent + PLAT_NS_PER_S;
            win_frames = win_bytes = 0;
            win_latency_ms = win_render_ms = 0;
        }
    }
    atomic_store(&g_stop, true);
    pthread_join(pi.th, NULL);
    sink.close(&sink);
    if (pi.dev) {
        libusb_release_interface(pi.dev, o.interface);
        libusb_close(pi.dev);
        libusb_exit(NULL);
    }
    fprintf(stderr, "hmdwarp-feed: %llu frames sent\n", (unsigned long long)frames);
    if (o.damage_every)
        fprintf(stderr, "hmdwarp-feed: %llu damaged: %s %llu, %s %llu, %s %llu\n", (unsigned long long)damaged,
                damage_names[0], (unsigned long long)damaged_kind[0], damage_names[1],
                (unsigned long long)damaged_kind[1], damage_names[2], (unsigned long long)damaged_kind[2]);
    plat_workers_destroy(workers);
    feed_sequence_close(seq);
    drv_frame_free(&f);
    free(buf);
    return rc;
}
