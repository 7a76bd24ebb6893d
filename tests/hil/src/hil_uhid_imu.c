/* SPDX-License-Identifier: MIT */
/* hil_uhid_imu: plays an hmdwarp USB HID IMU bridge through the kernel's uhid driver: a real HID device whose
 * /dev/hidrawN hmdwarpd's HID backend reads with hidapi, streaming vendor reports (docs/hid-report.md) of sim-trace
 * samples in real time, with unplug/replug and corrupted reports on request. */
#include <fcntl.h>
#include <dirent.h>
#include <linux/uhid.h>
#include <poll.h>
#include <sys/stat.h>

#include "drivers/drv_hid_report.h"
#include "tests/hil/src/hil_common.h"

#define DEFAULT_VID 0x1209 /* pid.codes: open-source hardware ids */
#define DEFAULT_PID 0x0001 /* pid.codes test PID */
#define DEFAULT_NAME "hmdwarp IMU bridge"
#define DEFAULT_COUNTER_START (4294967296ULL - 3000000ULL) /* the device counter wraps 3 s after plug-in */
#define OTHER_REPORT_ID 0x32 /* a second vendor input report, so a "wrong id" report reaches hidraw */
#define LATE_SKIP_NS (100 * PLAT_NS_PER_MS) /* further behind than this: drop samples like a device nobody polled */

/* Vendor page 0xFF00, application collection with two numbered 63-byte input reports: 0x31 (ours) and 0x32 (some
 * other vendor report the host must skip). hidraw prefixes the report id, so reads are 64 bytes. */
static const uint8_t report_descriptor[] = {
    0x06, 0x00, 0xFF, /* Usage Page (Vendor Defined 0xFF00) */
    0x09, 0x01,       /* Usage (0x01) */
    0xA1, 0x01,       /* Collection (Application) */
    0x85, DRV_HID_VENDOR_REPORT_ID, /* Report ID (0x31) */
    0x09, 0x02,       /*   Usage (0x02) */
    0x15, 0x00,       /*   Logical Minimum (0) */
    0x26, 0xFF, 0x00, /*   Logical Maximum (255) */
    0x75, 0x08,       /*   Report Size (8) */
    0x95, DRV_HID_VENDOR_REPORT_SIZE - 1, /* Report Count (63) */
    0x81, 0x02,       /*   Input (Data, Variable, Absolute) */
    0x85, OTHER_REPORT_ID, /* Report ID (0x32) */
    0x09, 0x03,       /*   Usage (0x03) */
    0x95, DRV_HID_VENDOR_REPORT_SIZE - 1, /* Report Count (63) */
    0x81, 0x02,       /*   Input (Data, Variable, Absolute) */
    0xC0,             /* End Collection */
};

typedef struct {
    const char *uhid_path;
    unsigned vid, pid;
    const char *name;
    char uniq[64];
    double rate_hz;
    int per_report;
    uint32_t counter_start;
    int gyro_dps, accel_g;
    double duration_s;
    double unplug_at_s, unplug_for_s;
    int corrupt_every;
    const char *ready_file;
    double ready_timeout_s;
    int dry_run; /* reports to print; 0: run for real */
    bool verbose;
    hil_trace_cfg trace;
} opts;

/* ---- the report stream (pure: what the bridge's firmware would put on the wire) ---- */

typedef struct {
    const hil_imu_gen *gen;
    int per_report;
    uint32_t counter_start;
    int gyro_code, accel_code;
    int corrupt_every;
    int64_t period_ns;
    uint64_t reports; /* made since start (corruption counts across replugs) */
} stream;

static int64_t sample_time_ns(const stream *s, uint64_t i) { return (int64_t)i * s->period_ns; }

enum { CORRUPT_NONE = 0, CORRUPT_BITFLIP, CORRUPT_TRUNCATE, CORRUPT_WRONG_ID, CORRUPT_VERSION };
static const char *const corrupt_names[] = {"none", "bit flip", "truncated", "wrong report id", "unknown version"};

/* Report with samples i0 .. i0+n-1; plug_index is the first sample after the device (re)started, where its µs
 * counter read counter_start and its sequence number 0. Returns the size to send (64, less when truncated), or -1
 * when the encoder refused (NaN). *kind says how it was damaged. */
static int make_report(stream *s, uint64_t i0, uint64_t plug_index, uint8_t out[DRV_HID_VENDOR_REPORT_SIZE],
                       int *kind)
{
    drv_hid_vendor_in in;
    memset(&in, 0, sizeof in);
    in.n = s->per_report;
    in.seq = (uint16_t)(i0 - plug_index);
    /* latched when the sample was measured: µs since plug-in, wrapping at 2^32 like a free-running counter */
    int64_t since_plug_ns = sample_time_ns(s, i0) - sample_time_ns(s, plug_index);
    in.t_us = s->counter_start + (uint32_t)(uint64_t)(since_plug_ns / 1000);
    int64_t iv = (s->period_ns + 500) / 1000;
    in.interval_us = (uint16_t)(iv < 1 ? 1 : iv > 65535 ? 65535 : iv);
    in.gyro_code = s->gyro_code;
    in.accel_code = s->accel_code;
    for (int k = 0; k < in.n; k++) hil_imu_gen_sample(s->gen, i0 + (uint64_t)k, in.gyro[k], in.accel[k]);
    *kind = CORRUPT_NONE;
    int size = drv_hid_encode_vendor(&in, out);
    if (size < 0) return -1;
    s->reports++;
    if (s->corrupt_every > 0 && s->reports % (uint64_t)s->corrupt_every == 0) {
        /* the same rotation as the driver's mock: each kind of damage the decoder must catch */
        switch ((s->reports / (uint64_t)s->corrupt_every) % 4) {
        case 0: out[12 + (int)(s->reports % 48)] ^= 0x10; *kind = CORRUPT_BITFLIP; break;
        case 1: size = 40; *kind = CORRUPT_TRUNCATE; break;
        case 2: out[0] = OTHER_REPORT_ID; *kind = CORRUPT_WRONG_ID; break;
        case 3: out[1] = DRV_HID_VENDOR_VERSION + 1; *kind = CORRUPT_VERSION; break;
        }
    }
    return size;
}

static int range_code(int full_scale, int base, int codes)
{
    for (int c = 0; c < codes; c++)
        if (base << c == full_scale) return c;
    return -1;
}

/* ---- --dry-run: the first reports, decoded again and compared with the trace ---- */

static int dry_run(const opts *o, stream *s)
{
    printf("%s: dry run: %d reports at %g Hz, %d sample(s)/report, gyro +-%d deg/s, accel +-%d g, counter from "
           "0x%08x\n",
           hil_prog, o->dry_run, o->rate_hz, o->per_report, o->gyro_dps, o->accel_g, (unsigned)o->counter_start);
    int bad = 0;
    for (int r = 0; r < o->dry_run; r++) {
        uint64_t i0 = (uint64_t)r * (uint64_t)o->per_report;
        uint8_t rep[DRV_HID_VENDOR_REPORT_SIZE];
        int kind;
        int size = make_report(s, i0, 0, rep, &kind);
        int64_t due = sample_time_ns(s, i0 + (uint64_t)o->per_report - 1);
        printf("report %d: sent at t=%.6f s, %d bytes%s%s:", r, (double)due * 1e-9, size,
               kind ? ", damaged: " : "", kind ? corrupt_names[kind] : "");
        for (int b = 0; b < size; b++) printf("%s%02x", b % 16 ? " " : "\n  ", rep[b]);
        printf("\n");
        drv_hid_imu_report d;
        char msg[128] = "";
        drv_hid_err e = drv_hid_decode(rep, size, &d, msg, sizeof msg);
        if (kind) {
            printf("  decoder: %s (%s)%s\n", drv_hid_err_str(e), msg, e == DRV_HID_OK ? "  <-- FAIL: accepted" : "");
            bad += e == DRV_HID_OK;
            continue;
        }
        if (e != DRV_HID_OK) {
            printf("  decoder: %s (%s)  <-- FAIL\n", drv_hid_err_str(e), msg);
            bad++;
            continue;
        }
        for (int k = 0; k < d.n; k++) {
            double g[3], a[3];
            hil_imu_gen_sample(s->gen, i0 + (uint64_t)k, g, a);
            uint32_t t_expect = o->counter_start + (uint32_t)(uint64_t)(sample_time_ns(s, i0 + (uint64_t)k) / 1000);
            double worst = 0; /* in counts */
            for (int c = 0; c < 3; c++) {
                double eg = fabs(d.gyro[k][c] - g[c]) / d.gyro_lsb, ea = fabs(d.accel[k][c] - a[c]) / d.accel_lsb;
                worst = fmax(worst, fmax(eg, ea));
            }
            bool ok = worst <= 0.5001 && d.t_us[k] == t_expect && d.seq == (uint16_t)i0;
            bad += !ok;
            printf("  seq %u t_us 0x%08x  gyro %+.5f %+.5f %+.5f rad/s  accel %+.4f %+.4f %+.4f m/s^2  "
                   "(trace: %+.5f %+.5f %+.5f | %+.4f %+.4f %+.4f; max error %.2f counts)%s\n",
                   (unsigned)(d.seq + k), (unsigned)d.t_us[k], d.gyro[k][0], d.gyro[k][1], d.gyro[k][2],
                   d.accel[k][0], d.accel[k][1], d.accel[k][2], g[0], g[1], g[2], a[0], a[1], a[2], worst,
                   ok ? "" : "  <-- FAIL");
        }
    }
    printf("%s: dry run %s\n", hil_prog, bad ? "FAIL" : "PASS");
    return bad ? HIL_EXIT_FAIL : 0;
}

/* ---- the uhid device ---- */

typedef struct {
    const opts *o;
    int fd;
    bool created, started;
    int opens;      /* hidraw opens minus closes (UHID_OPEN/CLOSE) */
    char hidraw[64];
    /* counters */
    uint64_t ev_open, ev_close, ev_start, ev_stop, ev_output, get_reports, set_reports, write_errors;
} uhid_dev;

static int uhid_write_ev(uhid_dev *u, const struct uhid_event *ev)
{
    ssize_t n = write(u->fd, ev, sizeof *ev);
    if (n == (ssize_t)sizeof *ev) return 0;
    int e = n < 0 ? errno : EIO;
    u->write_errors++;
    return -e;
}

static void uhid_open(uhid_dev *u)
{
    u->fd = open(u->o->uhid_path, O_RDWR | O_CLOEXEC | O_NONBLOCK);
    if (u->fd >= 0) return;
    int e = errno;
    if (e == ENOENT || e == ENODEV || e == ENXIO)
        hil_die(HIL_EXIT_FAIL, "%s: no such device (uhid not loaded? `modprobe uhid`; devtmpfs on /dev?)",
                u->o->uhid_path);
    if (e == EACCES || e == EPERM) hil_die(HIL_EXIT_FAIL, "%s: permission denied (run as root)", u->o->uhid_path);
    hil_die(HIL_EXIT_FAIL, "%s: cannot open: %s", u->o->uhid_path, strerror(e));
}

static int uhid_create(uhid_dev *u)
{
    struct uhid_event ev;
    memset(&ev, 0, sizeof ev);
    ev.type = UHID_CREATE2;
    snprintf((char *)ev.u.create2.name, sizeof ev.u.create2.name, "%s", u->o->name);
    snprintf((char *)ev.u.create2.phys, sizeof ev.u.create2.phys, "hmdwarp-hil/uhid");
    snprintf((char *)ev.u.create2.uniq, sizeof ev.u.create2.uniq, "%s", u->o->uniq);
    ev.u.create2.rd_size = sizeof report_descriptor;
    ev.u.create2.bus = BUS_USB;
    ev.u.create2.vendor = u->o->vid;
    ev.u.create2.product = u->o->pid;
    ev.u.create2.version = 0x0100;
    memcpy(ev.u.create2.rd_data, report_descriptor, sizeof report_descriptor);
    int rc = uhid_write_ev(u, &ev);
    if (rc < 0) {
        hil_msg("%s: UHID_CREATE2 %04x:%04x failed: %s", u->o->uhid_path, u->o->vid, u->o->pid, strerror(-rc));
        return rc;
    }
    u->created = true;
    u->started = false;
    u->hidraw[0] = 0;
    return 0;
}

static void uhid_destroy(uhid_dev *u)
{
    if (!u->created) return;
    struct uhid_event ev;
    memset(&ev, 0, sizeof ev);
    ev.type = UHID_DESTROY;
    int rc = uhid_write_ev(u, &ev);
    if (rc < 0) hil_msg("%s: UHID_DESTROY failed: %s", u->o->uhid_path, strerror(-rc));
    u->created = false;
    u->started = false;
    u->opens = 0;
}

/* Handles every pending kernel event; requests are answered at once (the kernel waits for the reply). */
static void uhid_events(uhid_dev *u)
{
    for (;;) {
        struct uhid_event ev;
        ssize_t n = read(u->fd, &ev, sizeof ev);
        if (n < 0) {
            if (errno != EAGAIN && errno != EINTR) hil_msg("%s: read: %s", u->o->uhid_path, strerror(errno));
            return;
        }
        if (n < (ssize_t)sizeof ev.type) return;
        struct uhid_event reply;
        memset(&reply, 0, sizeof reply);
        switch (ev.type) {
        case UHID_START:
            u->started = true;
            u->ev_start++;
            if (u->o->verbose) hil_msg("UHID_START (flags 0x%llx)", (unsigned long long)ev.u.start.dev_flags);
            break;
        case UHID_STOP:
            u->started = false;
            u->ev_stop++;
            if (u->o->verbose) hil_msg("UHID_STOP");
            break;
        case UHID_OPEN:
            u->opens++;
            u->ev_open++;
            if (u->o->verbose) hil_msg("UHID_OPEN (hidraw opened)");
            break;
        case UHID_CLOSE:
            if (u->opens > 0) u->opens--;
            u->ev_close++;
            if (u->o->verbose) hil_msg("UHID_CLOSE");
            break;
        case UHID_OUTPUT:
            u->ev_output++;
            if (u->o->verbose) hil_msg("UHID_OUTPUT %u bytes (ignored)", (unsigned)ev.u.output.size);
            break;
        case UHID_GET_REPORT:
            /* The bridge has no feature reports: say so instead of letting the caller time out. */
            u->get_reports++;
            reply.type = UHID_GET_REPORT_REPLY;
            reply.u.get_report_reply.id = ev.u.get_report.id;
            reply.u.get_report_reply.err = EIO;
            reply.u.get_report_reply.size = 0;
            uhid_write_ev(u, &reply);
            if (u->o->verbose) hil_msg("UHID_GET_REPORT 0x%02x: answered EIO", ev.u.get_report.rnum);
            break;
        case UHID_SET_REPORT:
            u->set_reports++;
            reply.type = UHID_SET_REPORT_REPLY;
            reply.u.set_report_reply.id = ev.u.set_report.id;
            reply.u.set_report_reply.err = EIO;
            uhid_write_ev(u, &reply);
            if (u->o->verbose) hil_msg("UHID_SET_REPORT 0x%02x: answered EIO", ev.u.set_report.rnum);
            break;
        default:
            if (u->o->verbose) hil_msg("uhid event %u ignored", (unsigned)ev.type);
            break;
        }
    }
}

/* The hidraw node of our device: /sys/class/hidraw/hidrawN/device is the HID device, whose uevent carries the uniq
 * string we created it with (the only thing that tells two bridges with the same ids apart). */
static bool find_hidraw(const uhid_dev *u, char *out, size_t len)
{
    DIR *d = opendir("/sys/class/hidraw");
    if (!d) return false;
    char want[96];
    snprintf(want, sizeof want, "HID_UNIQ=%s\n", u->o->uniq);
    bool found = false;
    struct dirent *e;
    while (!found && (e = readdir(d))) {
        if (strncmp(e->d_name, "hidraw", 6) != 0 || strlen(e->d_name) > 32) continue;
        char path[512], buf[1024];
        snprintf(path, sizeof path, "/sys/class/hidraw/%s/device/uevent", e->d_name);
        FILE *f = fopen(path, "r");
        if (!f) continue;
        size_t n = fread(buf, 1, sizeof buf - 1, f);
        fclose(f);
        buf[n] = 0;
        if (strstr(buf, want)) {
            snprintf(out, len, "/dev/%.32s", e->d_name);
            found = true;
        }
    }
    closedir(d);
    return found;
}

/* After UHID_CREATE2: waits for UHID_START and the /dev/hidrawN node (devtmpfs creates it; no udevd needed). */
static bool wait_ready(uhid_dev *u, double timeout_s)
{
    int64_t until = hil_now_ns() + (int64_t)(timeout_s * 1e9);
    bool node_known = false;
    while (!hil_stopped()) {
        uhid_events(u);
        if (u->started && !node_known) node_known = find_hidraw(u, u->hidraw, sizeof u->hidraw);
        if (node_known && access(u->hidraw, F_OK) == 0) return true;
        if (hil_now_ns() > until) {
            if (!u->started)
                hil_msg("%s: %04x:%04x created but never started (UHID_START) within %.1f s (hid-generic not "
                        "bound?)",
                        u->o->uhid_path, u->o->vid, u->o->pid, timeout_s);
            else if (!node_known)
                hil_msg("%04x:%04x \"%s\": no hidraw device in /sys/class/hidraw within %.1f s (CONFIG_HIDRAW?)",
                        u->o->vid, u->o->pid, u->o->name, timeout_s);
            else
                hil_msg("%s: node did not appear within %.1f s (devtmpfs mounted on /dev?)", u->hidraw, timeout_s);
            return false;
        }
        struct pollfd p = {u->fd, POLLIN, 0};
        poll(&p, 1, 5);
    }
    return false;
}

/* ---- the run ---- */

static void usage(FILE *f)
{
    fprintf(f,
            "usage: %s [options]\n"
            "Creates a USB HID IMU bridge through /dev/uhid (a real HID device: /dev/hidrawN appears) and streams\n"
            "hmdwarp vendor IMU reports (report id 0x31, 64 bytes, docs/hid-report.md) with the samples of a sim\n"
            "trace, paced in real time on CLOCK_MONOTONIC. Prints \"%s: ready /dev/hidrawN\" once the node exists,\n"
            "\"unplugged\" / \"ready /dev/hidrawN\" around a simulated unplug, and a key=value summary at exit.\n"
            "\n"
            "Device:\n"
            "  --uhid PATH         uhid control node (default /dev/uhid)\n"
            "  --vid HEX           USB vendor id (default %04x)\n"
            "  --pid HEX           USB product id (default %04x)\n"
            "  --name STR          HID device name (default \"%s\")\n"
            "  --uniq STR          HID uniq string (serial) used to find our hidraw node (default hil-PID)\n"
            "  --ready-file PATH   also write state=ready|unplugged|done, hidraw=, pid= lines to PATH (atomic)\n"
            "  --ready-timeout S   how long to wait for the hidraw node after each create (default 5)\n"
            "Reports:\n"
            "  --rate HZ           IMU sample rate (default 1000)\n"
            "  --samples-per-report N  1..4 samples per report (default 1); reports go out at rate/N\n"
            "  --counter-start U32 device us counter at plug-in (default %llu: wraps 3 s later); it restarts\n"
            "                      there after a replug, as a power-cycled bridge's would\n"
            "  --gyro-range DPS    declared gyro full scale: 125 250 500 1000 2000 4000 (default 2000)\n"
            "  --accel-range G     declared accel full scale: 2 4 8 16 32 (default 8)\n"
            "Run:\n"
            "  --duration S        stop after S seconds (default 60; 0: until SIGINT/SIGTERM)\n"
            "  --unplug-at S       S seconds after start, destroy the device (UHID_DESTROY: hidraw node vanishes)\n"
            "  --unplug-for S      ... and create it again after S seconds (default 1; new node, counter and seq\n"
            "                      restart)\n"
            "  --corrupt-every N   damage every Nth report, in turn: bit flip (crc), truncated to 40 bytes, report\n"
            "                      id 0x32, unknown version (default 0: never)\n"
            "  --dry-run[=N]       no device: print the first N reports (default 6) in hex, decode them with the\n"
            "                      real decoder and compare with the trace; prints PASS or FAIL\n"
            "  -v, --verbose       log every uhid event\n"
            "  -h, --help          this text\n",
            hil_prog, hil_prog, DEFAULT_VID, DEFAULT_PID, DEFAULT_NAME, (unsigned long long)DEFAULT_COUNTER_START);
    hil_trace_help(f);
    fprintf(f, "Exit status: 0 done, 1 device failure, 2 bad command line.\n");
}

enum {
    OPT_UHID = HIL_OPT_FIRST_FREE,
    OPT_VID,
    OPT_PID,
    OPT_NAME,
    OPT_UNIQ,
    OPT_READY_FILE,
    OPT_READY_TIMEOUT,
    OPT_RATE,
    OPT_PER_REPORT,
    OPT_COUNTER_START,
    OPT_GYRO_RANGE,
    OPT_ACCEL_RANGE,
    OPT_DURATION,
    OPT_UNPLUG_AT,
    OPT_UNPLUG_FOR,
    OPT_CORRUPT_EVERY,
    OPT_DRY_RUN,
};

static void parse_args(int argc, char **argv, opts *o)
{
    static const struct option lo[] = {
        {"uhid", required_argument, NULL, OPT_UHID},
        {"vid", required_argument, NULL, OPT_VID},
        {"pid", required_argument, NULL, OPT_PID},
        {"name", required_argument, NULL, OPT_NAME},
        {"uniq", required_argument, NULL, OPT_UNIQ},
        {"ready-file", required_argument, NULL, OPT_READY_FILE},
        {"ready-timeout", required_argument, NULL, OPT_READY_TIMEOUT},
        {"rate", required_argument, NULL, OPT_RATE},
        {"samples-per-report", required_argument, NULL, OPT_PER_REPORT},
        {"counter-start", required_argument, NULL, OPT_COUNTER_START},
        {"gyro-range", required_argument, NULL, OPT_GYRO_RANGE},
        {"accel-range", required_argument, NULL, OPT_ACCEL_RANGE},
        {"duration", required_argument, NULL, OPT_DURATION},
        {"unplug-at", required_argument, NULL, OPT_UNPLUG_AT},
        {"unplug-for", required_argument, NULL, OPT_UNPLUG_FOR},
        {"corrupt-every", required_argument, NULL, OPT_CORRUPT_EVERY},
        {"dry-run", optional_argument, NULL, OPT_DRY_RUN},
        HIL_TRACE_LONGOPTS,
        HIL_LONGOPTS_END,
    };
    memset(o, 0, sizeof *o);
    o->uhid_path = "/dev/uhid";
    o->vid = DEFAULT_VID;
    o->pid = DEFAULT_PID;
    o->name = DEFAULT_NAME;
    snprintf(o->uniq, sizeof o->uniq, "hil-%ld", (long)getpid());
    o->ready_timeout_s = 5;
    o->rate_hz = 1000;
    o->per_report = 1;
    o->counter_start = (uint32_t)DEFAULT_COUNTER_START;
    o->gyro_dps = 2000;
    o->accel_g = 8;
    o->duration_s = 60;
    o->unplug_for_s = 1;
    o->trace = hil_trace_defaults();
    int c;
    while ((c = hil_getopt(argc, argv, lo)) != -1) {
        if (hil_trace_option(c, optarg, &o->trace)) continue;
        switch (c) {
        case OPT_UHID: o->uhid_path = optarg; break;
        case OPT_VID: o->vid = hil_parse_hex16("--vid", optarg); break;
        case OPT_PID: o->pid = hil_parse_hex16("--pid", optarg); break;
        case OPT_NAME:
            if (strlen(optarg) >= 128) hil_die(HIL_EXIT_USAGE, "--name: longer than 127 bytes");
            o->name = optarg;
            break;
        case OPT_UNIQ:
            if (!optarg[0] || strlen(optarg) >= sizeof o->uniq)
                hil_die(HIL_EXIT_USAGE, "--uniq '%s': expected 1 to %d characters", optarg, (int)sizeof o->uniq - 1);
            snprintf(o->uniq, sizeof o->uniq, "%s", optarg);
            break;
        case OPT_READY_FILE: o->ready_file = optarg; break;
        case OPT_READY_TIMEOUT: o->ready_timeout_s = hil_parse_double("--ready-timeout", optarg, 0.1, 600); break;
        case OPT_RATE: o->rate_hz = hil_parse_double("--rate", optarg, 1, 8000); break;
        case OPT_PER_REPORT:
            o->per_report = (int)hil_parse_int("--samples-per-report", optarg, 1, DRV_HID_VENDOR_MAX_SAMPLES);
            break;
        case OPT_COUNTER_START:
            o->counter_start = (uint32_t)hil_parse_int("--counter-start", optarg, 0, UINT32_MAX);
            break;
        case OPT_GYRO_RANGE:
            o->gyro_dps = (int)hil_parse_int("--gyro-range", optarg, 125, 4000);
            if (range_code(o->gyro_dps, 125, DRV_HID_VENDOR_GYRO_CODES) < 0)
                hil_die(HIL_EXIT_USAGE, "--gyro-range %s: expected 125, 250, 500, 1000, 2000 or 4000", optarg);
            break;
        case OPT_ACCEL_RANGE:
            o->accel_g = (int)hil_parse_int("--accel-range", optarg, 2, 32);
            if (range_code(o->accel_g, 2, DRV_HID_VENDOR_ACCEL_CODES) < 0)
                hil_die(HIL_EXIT_USAGE, "--accel-range %s: expected 2, 4, 8, 16 or 32", optarg);
            break;
        case OPT_DURATION: o->duration_s = hil_parse_double("--duration", optarg, 0, 1e6); break;
        case OPT_UNPLUG_AT: o->unplug_at_s = hil_parse_double("--unplug-at", optarg, 0, 1e6); break;
        case OPT_UNPLUG_FOR: o->unplug_for_s = hil_parse_double("--unplug-for", optarg, 0.01, 1e6); break;
        case OPT_CORRUPT_EVERY: o->corrupt_every = (int)hil_parse_int("--corrupt-every", optarg, 0, 1000000); break;
        case OPT_DRY_RUN: o->dry_run = optarg ? (int)hil_parse_int("--dry-run", optarg, 1, 100000) : 6; break;
        case 'v': o->verbose = true; break;
        default: hil_opt_other(c, argv, usage);
        }
    }
    hil_opt_no_operands(argc, argv);
}

int main(int argc, char **argv)
{
    hil_init("hil_uhid_imu");
    opts o;
    parse_args(argc, argv, &o);
    hil_imu_gen gen;
    hil_imu_gen_init(&gen, &o.trace, o.rate_hz);
    stream s = {&gen, o.per_report, o.counter_start, range_code(o.gyro_dps, 125, DRV_HID_VENDOR_GYRO_CODES),
                range_code(o.accel_g, 2, DRV_HID_VENDOR_ACCEL_CODES), o.corrupt_every,
                (int64_t)llround(1e9 / o.rate_hz), 0};
    if (o.dry_run) return dry_run(&o, &s);

    hil_signals_install();
    uhid_dev u;
    memset(&u, 0, sizeof u);
    u.o = &o;
    uhid_open(&u);
    if (uhid_create(&u) < 0) return HIL_EXIT_FAIL;
    if (!wait_ready(&u, o.ready_timeout_s)) {
        uhid_destroy(&u);
        close(u.fd);
        return hil_stopped() ? 0 : HIL_EXIT_FAIL;
    }
    const int64_t t_base = hil_now_ns(); /* sample 0 is measured now; trace time -rest */
    const int64_t t_end = o.duration_s > 0 ? t_base + (int64_t)(o.duration_s * 1e9) : INT64_MAX;
    const int64_t unplug_at = o.unplug_at_s > 0 ? t_base + (int64_t)(o.unplug_at_s * 1e9) : INT64_MAX;
    printf("%s: ready %s (%04x:%04x \"%s\" uniq %s; %g Hz, %d sample(s)/report, gyro +-%d deg/s, accel +-%d g, "
           "trace %s seed %llu, counter 0x%08x)\n",
           hil_prog, u.hidraw, o.vid, o.pid, o.name, o.uniq, o.rate_hz, o.per_report, o.gyro_dps, o.accel_g,
           o.trace.trace, (unsigned long long)o.trace.seed, (unsigned)o.counter_start);
    hil_status_write(o.ready_file, "state=ready\nhidraw=%s\n", u.hidraw);

    uint64_t next = 0, plug_index = 0; /* next sample to send; first sample since the last plug-in */
    uint64_t samples = 0, sent = 0, dropped_stopped = 0, skipped = 0, corrupted = 0, unplugs = 0, replugs = 0;
    int64_t max_late_ns = 0;
    int rc = 0;
    bool unplug_done = false;
    while (!hil_stopped()) {
        int64_t now = hil_now_ns();
        if (now >= t_end) break;
        if (!unplug_done && now >= unplug_at) {
            unplug_done = true;
            uhid_destroy(&u);
            unplugs++;
            printf("%s: unplugged %s for %.3f s\n", hil_prog, u.hidraw, o.unplug_for_s);
            hil_status_write(o.ready_file, "state=unplugged\nhidraw=\n");
            int64_t back = unplug_at + (int64_t)(o.unplug_for_s * 1e9);
            while (!hil_stopped() && hil_now_ns() < back && hil_now_ns() < t_end) {
                uhid_events(&u);
                int64_t step = hil_now_ns() + 10 * PLAT_NS_PER_MS;
                hil_sleep_until_ns(step < back ? step : back);
            }
            if (hil_stopped() || hil_now_ns() >= t_end) break;
            if (uhid_create(&u) < 0 || !wait_ready(&u, o.ready_timeout_s)) {
                rc = hil_stopped() ? 0 : HIL_EXIT_FAIL;
                break;
            }
            replugs++;
            /* The head moved on meanwhile; the bridge restarts its counter and sequence at the first new sample. */
            now = hil_now_ns();
            uint64_t i = (uint64_t)((now - t_base) / s.period_ns) + 1;
            i = (i + (uint64_t)o.per_report - 1) / (uint64_t)o.per_report * (uint64_t)o.per_report;
            skipped += i - next;
            next = plug_index = i;
            printf("%s: ready %s (replugged)\n", hil_prog, u.hidraw);
            hil_status_write(o.ready_file, "state=ready\nhidraw=%s\n", u.hidraw);
            continue;
        }
        uint64_t last = next + (uint64_t)o.per_report - 1;
        int64_t due = t_base + sample_time_ns(&s, last);
        if (due > now) {
            int64_t wake = due < unplug_at ? due : unplug_at;
            if (wake > t_end) wake = t_end;
            uhid_events(&u);
            hil_sleep_until_ns(wake);
            continue;
        }
        if (now - due > LATE_SKIP_NS) {
            /* Stalled (a loaded VM): a device nobody polled loses those samples; seq shows the gap. */
            uint64_t i = (uint64_t)((now - t_base) / s.period_ns);
            i = i / (uint64_t)o.per_report * (uint64_t)o.per_report;
            if (i > next) {
                skipped += i - next;
                next = i;
                continue;
            }
        }
        if (now - due > max_late_ns) max_late_ns = now - due;
        uint8_t rep[DRV_HID_VENDOR_REPORT_SIZE];
        int kind;
        int size = make_report(&s, next, plug_index, rep, &kind);
        next += (uint64_t)o.per_report;
        samples += (uint64_t)o.per_report;
        if (size < 0) continue;
        uhid_events(&u);
        if (!u.started) {
            dropped_stopped++;
            continue;
        }
        struct uhid_event ev;
        memset(&ev, 0, sizeof ev);
        ev.type = UHID_INPUT2;
        ev.u.input2.size = (uint16_t)size;
        memcpy(ev.u.input2.data, rep, (size_t)size);
        int wr = uhid_write_ev(&u, &ev);
        if (wr < 0) {
            if (u.write_errors == 1 || u.write_errors % 1000 == 0)
                hil_msg("%s: UHID_INPUT2 to %s failed (%llu so far): %s", o.uhid_path, u.hidraw,
                        (unsigned long long)u.write_errors, strerror(-wr));
            continue;
        }
        sent++;
        corrupted += kind != CORRUPT_NONE;
    }
    uhid_destroy(&u);
    close(u.fd);
    double run_s = (double)(hil_now_ns() - t_base) * 1e-9;
    printf("%s: summary run_s=%.3f samples=%llu reports_sent=%llu corrupted=%llu dropped_not_started=%llu "
           "skipped_samples=%llu unplugs=%llu replugs=%llu hidraw_opens=%llu hidraw_closes=%llu get_report=%llu "
           "set_report=%llu write_errors=%llu max_late_us=%.0f stop=%s\n",
           hil_prog, run_s, (unsigned long long)samples, (unsigned long long)sent, (unsigned long long)corrupted,
           (unsigned long long)dropped_stopped, (unsigned long long)skipped, (unsigned long long)unplugs,
           (unsigned long long)replugs, (unsigned long long)u.ev_open, (unsigned long long)u.ev_close,
           (unsigned long long)u.get_reports, (unsigned long long)u.set_reports,
           (unsigned long long)u.write_errors, (double)max_late_ns * 1e-3,
           hil_stopped() ? "signal" : rc ? "error" : "duration");
    hil_status_write(o.ready_file, "state=done\nhidraw=\nreports_sent=%llu\n", (unsigned long long)sent);
    return rc;
}
