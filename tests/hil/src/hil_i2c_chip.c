/* SPDX-License-Identifier: MIT */
/* hil_i2c_chip: plays an MPU-6050, MPU-9250 or ICM-42688-P on the kernel's i2c-stub (a plain register file behind a
 * real /dev/i2c-N): preloads identity and reset values, writes sim-trace samples into the data registers at the
 * ranges the driver configured, raises data-ready, and emulates the soft reset the stub cannot do by itself. */
#include <dirent.h>
#include <fcntl.h>
#include <i2c/smbus.h>
#include <linux/i2c-dev.h>
#include <linux/i2c.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stddef.h>
#include <sys/ioctl.h>

#include "drivers/drv_i2c_chip_emu.h"
#include "drivers/drv_i2c_chips.h"
#include "drivers/drv_imu_i2c.h"
#include "tests/hil/src/hil_common.h"

#define STUB_NAME "SMBus stub driver" /* i2c-stub's adapter name in /sys/class/i2c-dev/i2c-N/name */
#define MAX_RATE_HZ 1000.0            /* the driver polls at most at 1 kHz; faster ODRs are written at this rate */
#define BUS_GONE_NS (2 * PLAT_NS_PER_S) /* every transfer failing this long: the bus is gone, give up */

/* ---- register transport: what the feeder writes through ---- */

typedef struct hil_regs hil_regs;
struct hil_regs {
    const char *name; /* "/dev/i2c-3 addr 0x68", for messages */
    /* n = 1..32 consecutive registers from reg; 0 or a negative errno */
    int (*read)(hil_regs *r, uint8_t reg, uint8_t *buf, int n);
    int (*write)(hil_regs *r, uint8_t reg, const uint8_t *buf, int n);
};

/* i2c-dev with libi2c. Only SMBus byte-data and I2C-block transfers: i2c-stub keeps 16-bit words per register, so
 * a word write would not land in two consecutive byte registers. */
typedef struct {
    hil_regs r;
    int fd;
    char path[64];
    char name[96];
} dev_regs;

static int dev_read(hil_regs *r, uint8_t reg, uint8_t *buf, int n)
{
    dev_regs *d = (dev_regs *)r;
    if (n == 1) {
        int v = i2c_smbus_read_byte_data(d->fd, reg);
        if (v < 0) return v;
        buf[0] = (uint8_t)v;
        return 0;
    }
    int got = i2c_smbus_read_i2c_block_data(d->fd, reg, (uint8_t)n, buf);
    if (got < 0) return got;
    return got == n ? 0 : -EIO;
}

static int dev_write(hil_regs *r, uint8_t reg, const uint8_t *buf, int n)
{
    dev_regs *d = (dev_regs *)r;
    int rc = n == 1 ? i2c_smbus_write_byte_data(d->fd, reg, buf[0])
                    : i2c_smbus_write_i2c_block_data(d->fd, reg, (uint8_t)n, buf);
    return rc < 0 ? rc : 0;
}

/* --bus N, /dev/i2c-N or "stub" (the adapter i2c-stub registered, found by name in sysfs). */
static void resolve_bus(const char *arg, char *path, size_t len)
{
    if (strcmp(arg, "stub") == 0) {
        DIR *d = opendir("/sys/class/i2c-dev");
        struct dirent *e;
        bool found = false;
        while (d && !found && (e = readdir(d))) {
            if (strncmp(e->d_name, "i2c-", 4) != 0 || strlen(e->d_name) > 16) continue;
            char p[300], name[128] = "";
            snprintf(p, sizeof p, "/sys/class/i2c-dev/%s/name", e->d_name);
            FILE *f = fopen(p, "r");
            if (!f) continue;
            if (fgets(name, sizeof name, f)) name[strcspn(name, "\n")] = 0;
            fclose(f);
            if (strcmp(name, STUB_NAME) == 0) {
                snprintf(path, len, "/dev/%.16s", e->d_name);
                found = true;
            }
        }
        if (d) closedir(d);
        if (!found)
            hil_die(HIL_EXIT_FAIL,
                    "--bus stub: no I2C adapter named \"%s\" in /sys/class/i2c-dev (modprobe i2c-dev; modprobe "
                    "i2c-stub chip_addr=0x68)",
                    STUB_NAME);
        return;
    }
    char *end;
    long n = strtol(arg, &end, 10);
    if (end != arg && !*end && n >= 0 && n < 1000000)
        snprintf(path, len, "/dev/i2c-%ld", n);
    else
        snprintf(path, len, "%s", arg);
}

static void dev_open(dev_regs *d, const char *path, int addr, uint8_t probe_reg)
{
    memset(d, 0, sizeof *d);
    snprintf(d->path, sizeof d->path, "%s", path);
    snprintf(d->name, sizeof d->name, "%s addr 0x%02x", path, addr);
    d->r = (hil_regs){d->name, dev_read, dev_write};
    d->fd = open(path, O_RDWR | O_CLOEXEC);
    if (d->fd < 0) {
        int e = errno;
        if (e == ENOENT || e == ENODEV || e == ENXIO)
            hil_die(HIL_EXIT_FAIL, "%s: no such I2C bus (modprobe i2c-dev; modprobe i2c-stub chip_addr=0x%02x; "
                    "i2cdetect -l lists the buses)", path, addr);
        if (e == EACCES || e == EPERM) hil_die(HIL_EXIT_FAIL, "%s: permission denied (run as root)", path);
        hil_die(HIL_EXIT_FAIL, "%s: cannot open: %s", path, strerror(e));
    }
    unsigned long funcs = 0;
    if (ioctl(d->fd, I2C_FUNCS, &funcs) < 0)
        hil_die(HIL_EXIT_FAIL, "%s: not an I2C adapter (I2C_FUNCS: %s)", path, strerror(errno));
    const unsigned long need = I2C_FUNC_SMBUS_READ_BYTE_DATA | I2C_FUNC_SMBUS_WRITE_BYTE_DATA |
                               I2C_FUNC_SMBUS_READ_I2C_BLOCK | I2C_FUNC_SMBUS_WRITE_I2C_BLOCK;
    if ((funcs & need) != need)
        hil_die(HIL_EXIT_FAIL,
                "%s: adapter lacks SMBus byte-data / I2C-block reads and writes (funcs 0x%08lx); is it i2c-stub?",
                path, funcs);
    /* FORCE: claim the address even if a kernel driver sits on it (the feeder is the chip, not a client) */
    if (ioctl(d->fd, I2C_SLAVE_FORCE, (unsigned long)addr) < 0)
        hil_die(HIL_EXIT_FAIL, "%s addr 0x%02x: I2C_SLAVE_FORCE: %s", path, addr, strerror(errno));
    if (i2c_smbus_read_byte_data(d->fd, probe_reg) < 0) {
        int e = errno;
        if (e == ENXIO || e == EREMOTEIO || e == ENODEV || e == EIO)
            hil_die(HIL_EXIT_FAIL, "%s addr 0x%02x: no ACK (i2c-stub loaded with chip_addr=0x%02x?)", path, addr,
                    addr);
        hil_die(HIL_EXIT_FAIL, "%s addr 0x%02x: probe read failed: %s", path, addr, strerror(e));
    }
}

/* ---- in-process i2c-stub (self test, dry run): the same plain register file, seen by the feeder and by the
 * real chip driver (a drv_i2c_bus), with the stub's atomicity (one transfer at a time) ---- */

typedef struct {
    drv_i2c_bus bus; /* the driver's side: first member */
    hil_regs regs;   /* the feeder's side */
    pthread_mutex_t mu;
    uint8_t mem[256];
    uint64_t transfers;
} mem_stub;

static mem_stub *stub_of_regs(hil_regs *r) { return (mem_stub *)(void *)((char *)r - offsetof(mem_stub, regs)); }

/* One transfer: out != NULL reads into out, else writes in. */
static int stub_xfer(mem_stub *s, uint8_t reg, int n, uint8_t *out, const uint8_t *in)
{
    if (n < 1 || n > DRV_I2C_BLOCK_MAX) return -EINVAL;
    if (reg + n > 256) return -EIO; /* i2c-stub cuts the block at the end of the map: a short transfer */
    pthread_mutex_lock(&s->mu);
    s->transfers++;
    for (int i = 0; i < n; i++) {
        if (out)
            out[i] = s->mem[reg + i];
        else
            s->mem[reg + i] = in[i];
    }
    pthread_mutex_unlock(&s->mu);
    return 0;
}

static int stub_feeder_read(hil_regs *r, uint8_t reg, uint8_t *buf, int n)
{
    return stub_xfer(stub_of_regs(r), reg, n, buf, NULL);
}
static int stub_feeder_write(hil_regs *r, uint8_t reg, const uint8_t *buf, int n)
{
    return stub_xfer(stub_of_regs(r), reg, n, NULL, buf);
}
static int stub_bus_read(drv_i2c_bus *b, uint8_t reg, uint8_t *buf, int n)
{
    return stub_xfer((mem_stub *)b, reg, n, buf, NULL);
}
static int stub_bus_write(drv_i2c_bus *b, uint8_t reg, uint8_t val)
{
    return stub_xfer((mem_stub *)b, reg, 1, NULL, &val);
}
static void stub_bus_destroy(drv_i2c_bus *b) { (void)b; /* the stub outlives the driver */ }

static void stub_init(mem_stub *s)
{
    memset(s, 0, sizeof *s);
    pthread_mutex_init(&s->mu, NULL);
    s->bus = (drv_i2c_bus){"in-process i2c-stub addr 0x68", stub_bus_read, stub_bus_write, NULL, stub_bus_destroy};
    s->regs = (hil_regs){"in-process i2c-stub addr 0x68", stub_feeder_read, stub_feeder_write};
}

static uint8_t stub_peek(mem_stub *s, uint8_t reg)
{
    pthread_mutex_lock(&s->mu);
    uint8_t v = s->mem[reg];
    pthread_mutex_unlock(&s->mu);
    return v;
}

/* ---- the chip emulation ---- */

/* The register file itself (reset images, range decoding, the data block) is drivers/drv_i2c_chip_emu, the same as
 * the driver's mock bus; this program adds the transport: i2c-stub, which holds registers but does nothing. */

#define MPU_DATA_LO DRV_I2C_EMU_MPU_DATA_LO
#define MPU_DATA_HI DRV_I2C_EMU_MPU_DATA_HI
#define ICM_DATA_LO DRV_I2C_EMU_ICM_DATA_LO
#define ICM_DATA_HI DRV_I2C_EMU_ICM_DATA_HI

typedef struct {
    drv_i2c_chip_kind kind;
    const char *name, *model;
    hil_regs *regs;
    hil_imu_gen gen;      /* on a 1 us grid: sample index = us since t0, so any ODR takes its own samples */
    double fixed_rate_hz; /* 0: the ODR the driver configured */
    double temp_c;
    int64_t t0_ns;
    uint8_t def[256];     /* power-on / reset image */
    uint8_t img[256];     /* the configuration registers as read at the last update */
    int64_t last_look_ns; /* when the last read of the reset register that found no reset started */
    bool flag_up;         /* the data-ready flag we wrote is still set (i2c-stub never clears it on read) */
    bool bank_warned;
    atomic_bool hold;     /* frozen from outside (self test) */
    /* what the driver configured, from the registers at the last update */
    double rate_hz, gyro_fs_dps, accel_fs_g;
    bool awake;
    /* counters */
    uint64_t updates, resets, late_resets, idle_updates, frozen_updates, errors, consecutive_errors;
    int64_t last_ok_ns;
    char last_error[200];
    bool verbose;
    bool force_late; /* self test: take every reset as seen too late */
} chip_emu;

static bool is_mpu(const chip_emu *c) { return drv_i2c_emu_is_mpu(c->kind); }
static uint8_t reset_reg(const chip_emu *c) { return is_mpu(c) ? MPU_REG_PWR_MGMT_1 : ICM_REG_DEVICE_CONFIG; }
static uint8_t reset_bit(const chip_emu *c) { return is_mpu(c) ? MPU_PWR1_DEVICE_RESET : ICM_DEVICE_CONFIG_SOFT_RESET; }
static bool owned(const chip_emu *c, int r) /* registers only the chip itself changes: data, status, identity */
{
    if (r == MPU_REG_WHO_AM_I) return true; /* 0x75 on all three */
    return is_mpu(c) ? r >= MPU_DATA_LO && r <= MPU_DATA_HI : r >= ICM_DATA_LO && r <= ICM_DATA_HI;
}

static void note_err(chip_emu *c, int rc, const char *what, uint8_t reg)
{
    c->errors++;
    c->consecutive_errors++;
    snprintf(c->last_error, sizeof c->last_error, "%s: %s reg 0x%02x failed: %s", c->regs->name, what, reg,
             strerror(-rc));
    if (c->errors == 1 || c->errors % 1000 == 0)
        hil_msg("%s (%llu errors so far)", c->last_error, (unsigned long long)c->errors);
}

static int rd(chip_emu *c, uint8_t reg, uint8_t *buf, int n)
{
    int rc = c->regs->read(c->regs, reg, buf, n);
    if (rc < 0)
        note_err(c, rc, "read", reg);
    else
        c->consecutive_errors = 0;
    return rc;
}

static int wr(chip_emu *c, uint8_t reg, const uint8_t *buf, int n)
{
    int rc = c->regs->write(c->regs, reg, buf, n);
    if (rc < 0)
        note_err(c, rc, "write", reg);
    else
        c->consecutive_errors = 0;
    return rc;
}

/* Writes the registers lo..hi where want differs from cur, in runs of at most 32 bytes. */
static int write_diff(chip_emu *c, const uint8_t *cur, const uint8_t *want, int lo, int hi)
{
    for (int r = lo; r <= hi;) {
        if (cur && cur[r] == want[r]) {
            r++;
            continue;
        }
        int end = r;
        while (end + 1 <= hi && end + 1 - r < DRV_I2C_BLOCK_MAX && (!cur || cur[end + 1] != want[end + 1])) end++;
        int rc = wr(c, (uint8_t)r, &want[r], end - r + 1);
        if (rc < 0) return rc;
        r = end + 1;
    }
    return 0;
}

static void emu_defaults(chip_emu *c) { drv_i2c_emu_reset_image(c->kind, c->def); }

static void emu_init(chip_emu *c, drv_i2c_chip_kind kind, hil_regs *regs, const hil_trace_cfg *tc, double rate_hz,
                     double temp_c, int64_t t0_ns)
{
    memset(c, 0, sizeof *c);
    const drv_i2c_chip *chip = drv_i2c_chip_get(kind);
    c->kind = kind;
    c->name = chip->name;
    c->model = chip->model;
    c->regs = regs;
    c->fixed_rate_hz = rate_hz;
    c->temp_c = temp_c;
    c->t0_ns = t0_ns;
    hil_imu_gen_init(&c->gen, tc, 1e6);
    atomic_init(&c->hold, false);
    emu_defaults(c);
}

/* Power-on: the whole register file as after a reset. */
static int emu_preload(chip_emu *c)
{
    int rc = write_diff(c, NULL, c->def, 0, 255);
    if (rc == 0) memcpy(c->img, c->def, 256);
    c->last_look_ns = hil_now_ns();
    c->flag_up = false;
    return rc;
}

#define MAP_END 0x80 /* bank 0 of all three chips ends below 0x80 (WHO_AM_I 0x75, REG_BANK_SEL 0x76) */

/* The datasheets' wait after a reset before the chip may be configured (the driver waits exactly this). */
static int64_t reset_wait_ns(const chip_emu *c)
{
    return (is_mpu(c) ? MPU_RESET_MS : ICM_RESET_MS) * PLAT_NS_PER_MS;
}

/* The driver set the reset bit (seen by a read that ended at seen_ns). The real chip is back at its reset values
 * at once; the stub still holds everything, and the driver configures the chip again once the reset wait is over
 * (1 ms on the ICM-42688-P). If the reset happened less than half that wait ago (the previous look found none),
 * the driver has not written since: every register goes back to its reset value. If the feeder looked too late
 * (a descheduled VM), the driver may already have written its configuration, often the same values as before, so
 * the configuration is left alone and only the self-clearing bit, the data and the status are reset (counted in
 * late_resets). */
static int emu_reset(chip_emu *c, int64_t seen_ns)
{
    uint8_t cur[MAP_END], want[MAP_END];
    bool timely = seen_ns - c->last_look_ns < reset_wait_ns(c) / 2 && !c->force_late;
    for (int b = 0; b < MAP_END; b += DRV_I2C_BLOCK_MAX)
        if (rd(c, (uint8_t)b, &cur[b], DRV_I2C_BLOCK_MAX) < 0) return -1;
    uint8_t rr = reset_reg(c);
    for (int r = 0; r < MAP_END; r++) {
        if (r == rr)
            want[r] = (cur[r] & reset_bit(c)) ? c->def[r] : cur[r]; /* the bit clears itself */
        else
            want[r] = timely || owned(c, r) ? c->def[r] : cur[r];
    }
    int rc = write_diff(c, cur, want, 0, MAP_END - 1);
    memcpy(c->img, want, MAP_END);
    c->flag_up = false;
    c->resets++;
    if (!timely) {
        c->late_resets++;
        if (c->late_resets == 1 || c->verbose)
            hil_msg("%s: reset seen %.2f ms after the previous look (more than half the %.0f ms reset wait): the "
                    "configuration the driver may have rewritten is kept, only data and status reset",
                    c->regs->name, (double)(seen_ns - c->last_look_ns) * 1e-6, (double)reset_wait_ns(c) * 1e-6);
    } else if (c->verbose) {
        hil_msg("%s: soft reset emulated (#%llu)", c->regs->name, (unsigned long long)c->resets);
    }
    c->last_look_ns = hil_now_ns();
    return rc;
}

/* Reads the reset register; 1 when a reset was seen (and emulated), 0 none, -1 transfer error. */
static int emu_check_reset(chip_emu *c)
{
    uint8_t rr = reset_reg(c), v;
    int64_t t = hil_now_ns();
    if (rd(c, rr, &v, 1) < 0) return -1;
    if (v & reset_bit(c)) return emu_reset(c, hil_now_ns()) < 0 ? -1 : 1;
    c->img[rr] = v;
    c->last_look_ns = t;
    return 0;
}

/* Between data updates: only look for a reset (one 1-byte read). */
static int emu_watch(chip_emu *c) { return emu_check_reset(c) < 0 ? -1 : 0; }

/* Clears the data-ready flag we left up (no new data: asleep, sensors off, frozen). */
static void emu_lower_flag(chip_emu *c)
{
    if (!c->flag_up) return;
    uint8_t st = is_mpu(c) ? MPU_REG_INT_STATUS : ICM_REG_INT_STATUS, z = 0;
    if (wr(c, st, &z, 1) == 0) c->flag_up = false;
}

/* One ODR tick at time now: re-read the configuration, then (awake, not frozen) write the sample measured now into
 * the data registers and raise data-ready, in one block transfer so the driver never reads half a sample. */
static int emu_update(chip_emu *c, int64_t now, bool frozen)
{
    uint8_t *m = c->img;
    int rs = emu_check_reset(c);
    if (rs != 0) return rs < 0 ? -1 : 0;
    if (is_mpu(c)) {
        /* 0x19..0x38: SMPLRT_DIV, CONFIG, GYRO_CONFIG, ACCEL_CONFIG(2) .. INT_ENABLE; 0x6B..0x6C: PWR_MGMT_1/2 */
        if (rd(c, MPU_REG_SMPLRT_DIV, &m[MPU_REG_SMPLRT_DIV], 32) < 0) return -1;
        if (rd(c, MPU_REG_PWR_MGMT_1, &m[MPU_REG_PWR_MGMT_1], 2) < 0) return -1;
    } else {
        /* 0x4C..0x65: INTF_CONFIG0, PWR_MGMT0, GYRO/ACCEL_CONFIG0 .. INT_SOURCE0; 0x76 REG_BANK_SEL */
        if (rd(c, ICM_REG_INTF_CONFIG0, &m[ICM_REG_INTF_CONFIG0], 26) < 0) return -1;
        if (rd(c, ICM_REG_BANK_SEL, &m[ICM_REG_BANK_SEL], 1) < 0) return -1;
    }

    drv_i2c_emu_config cf = drv_i2c_emu_config_get(c->kind, m);
    c->rate_hz = cf.rate_hz;
    c->gyro_fs_dps = cf.gyro_fs_dps;
    c->accel_fs_g = cf.accel_fs_g;
    c->awake = cf.gyro_on || cf.accel_on;
    if (cf.bank != 0) {
        /* i2c-stub has one flat map: writes meant for banks 1-4 landed in bank 0's registers */
        if (!c->bank_warned)
            hil_msg("%s: driver selected register bank %d; banks 1-4 are not emulated (i2c-stub has one flat "
                    "map), data paused until bank 0 is selected again",
                    c->regs->name, cf.bank);
        c->bank_warned = true;
        c->idle_updates++;
        return 0;
    }
    if (frozen) {
        c->frozen_updates++;
        emu_lower_flag(c);
        return 0;
    }
    if (!c->awake) {
        c->idle_updates++;
        emu_lower_flag(c);
        return 0;
    }
    double gyro[3], accel[3];
    hil_imu_gen_sample(&c->gen, (uint64_t)((now - c->t0_ns) / 1000), gyro, accel);
    uint8_t blkw[DRV_I2C_EMU_DATA_MAX];
    int lo, n = drv_i2c_emu_data_range(c->kind, &lo);
    drv_i2c_emu_data_block(c->kind, m, gyro, accel, c->temp_c, blkw);
    /* i2c-stub never clears the flag on read: remember to lower it when no new data follows. The MPU raises
     * DATA_RDY_INT only when the interrupt is enabled; the ICM's RESET_DONE is gone (it clears on the first read). */
    c->flag_up = blkw[is_mpu(c) ? 0 : n - 1] != 0;
    if (wr(c, (uint8_t)lo, blkw, n) < 0) return -1;
    memcpy(&m[lo], blkw, (size_t)n);
    c->updates++;
    c->last_ok_ns = now;
    return 0;
}

/* ---- the feeder loop (the program's and the self test's) ---- */

typedef struct {
    int64_t t_end;                /* INT64_MAX: until stopped */
    int64_t freeze_at, freeze_to; /* data frozen in [freeze_at, freeze_to) */
    int64_t watch_ns;             /* reset watch between updates */
    atomic_bool *stop;            /* NULL: the signal flag */
} loop_cfg;

/* 0, or HIL_EXIT_FAIL when the bus stopped answering for good. */
static int emu_run(chip_emu *c, const loop_cfg *lc)
{
    int64_t now = hil_now_ns(), next_data = now, next_watch = now + lc->watch_ns;
    c->last_ok_ns = now;
    for (;;) {
        if (lc->stop ? atomic_load(lc->stop) : hil_stopped()) break;
        now = hil_now_ns();
        if (now >= lc->t_end) break;
        if (now >= next_data) {
            bool frozen = atomic_load(&c->hold) || (now >= lc->freeze_at && now < lc->freeze_to);
            emu_update(c, now, frozen);
            double rate = c->fixed_rate_hz > 0 ? c->fixed_rate_hz : fmin(c->rate_hz, MAX_RATE_HZ);
            int64_t period = (int64_t)llround(1e9 / (rate > 0 ? rate : 1000));
            next_data += period;
            if (next_data < now) next_data = now + period; /* fell behind (loaded VM): skip, do not burst */
            next_watch = now + lc->watch_ns;
        } else if (now >= next_watch) {
            emu_watch(c);
            next_watch = now + lc->watch_ns;
        }
        if (c->consecutive_errors > 0 && now - c->last_ok_ns > BUS_GONE_NS) {
            hil_msg("%s: every transfer failed for %.1f s, giving up (last: %s)", c->regs->name,
                    (double)BUS_GONE_NS * 1e-9, c->last_error);
            return HIL_EXIT_FAIL;
        }
        if (c->consecutive_errors == 0 && c->updates == 0) c->last_ok_ns = now;
        int64_t wake = next_data < next_watch ? next_data : next_watch;
        if (wake > lc->t_end) wake = lc->t_end;
        hil_sleep_until_ns(wake);
    }
    return 0;
}

/* ---- self test: the real chip driver against this emulation on an in-process stub ---- */

typedef struct {
    chip_emu *c;
    loop_cfg lc;
    atomic_bool stop;
} feeder_thread;

static void *feeder_main(void *arg)
{
    feeder_thread *f = arg;
    emu_run(f->c, &f->lc);
    return NULL;
}


/* Is v (what the driver decoded from a sample it read s seconds after t0) a value the trace took shortly before?
 * The feeder wrote the sample of its last update, a scheduling delay earlier at most: accept anything within
 * [s - 100 ms, s + 2 ms], plus 1.5 counts of quantisation. */
static bool in_envelope(const hil_imu_gen *g, double s, int axis, bool gyro_axis, double v, double lsb)
{
    double lo = INFINITY, hi = -INFINITY;
    for (double dt = -0.100; dt <= 0.002; dt += 0.0005) {
        double gy[3], ac[3];
        hil_imu_gen_sample(g, (uint64_t)fmax(0, (s + dt) * 1e6), gy, ac);
        double x = gyro_axis ? gy[axis] : ac[axis];
        lo = fmin(lo, x);
        hi = fmax(hi, x);
    }
    return v >= lo - 1.5 * lsb && v <= hi + 1.5 * lsb;
}

static int64_t default_watch_ns(drv_i2c_chip_kind kind)
{
    /* The driver waits 100 ms after an MPU reset but only 1 ms after an ICM-42688-P soft reset. */
    return kind == DRV_I2C_CHIP_ICM42688 ? 200 * 1000 : 2 * PLAT_NS_PER_MS;
}

#define CHECK(cond, ...)                                                                                           \
    do {                                                                                                           \
        if (!(cond)) {                                                                                             \
            printf("  FAIL: " __VA_ARGS__);                                                                        \
            printf("\n");                                                                                          \
            fails++;                                                                                               \
        }                                                                                                          \
    } while (0)

/* Checks one decoded sample against the trace; returns the number of axes out of the envelope. */
static int check_sample(const chip_emu *c, const drv_i2c_setup *su, const drv_imu_sample *smp, int64_t t0_ns,
                        bool print)
{
    const double deg2rad = 3.14159265358979323846 / 180.0;
    double glsb = deg2rad / su->gyro_lsb_per_dps, alsb = DRV_I2C_G / su->accel_lsb_per_g;
    double s = (double)(smp->t_ns - t0_ns) * 1e-9;
    int bad = 0;
    for (int i = 0; i < 3; i++) {
        bad += !in_envelope(&c->gen, s, i, true, smp->gyro[i], glsb);
        bad += !in_envelope(&c->gen, s, i, false, smp->accel[i], alsb);
    }
    if (bad && print) {
        double gy[3], ac[3];
        hil_imu_gen_sample(&c->gen, (uint64_t)fmax(0, s * 1e6), gy, ac);
        printf("  sample at %.4f s: gyro %+.4f %+.4f %+.4f accel %+.3f %+.3f %+.3f; trace there: gyro %+.4f %+.4f "
               "%+.4f accel %+.3f %+.3f %+.3f\n",
               s, smp->gyro[0], smp->gyro[1], smp->gyro[2], smp->accel[0], smp->accel[1], smp->accel[2], gy[0], gy[1],
               gy[2], ac[0], ac[1], ac[2]);
    }
    return bad;
}

/* The real driver (drv_imu_i2c_create_on_bus, chip = auto) on an in-process stub while this emulation runs in its
 * own thread, as hmdwarpd and the feeder run against i2c-stub in the VM. `late`: the feeder looks only every 5 ms
 * and takes every reset as seen after the driver's reset wait (a descheduled VM): the driver's configuration,
 * rewritten with the same values on re-initialisation, must survive. */
static int self_test_chip(drv_i2c_chip_kind kind, bool late, bool verbose)
{
    mem_stub st;
    stub_init(&st);
    hil_trace_cfg tc = hil_trace_defaults();
    tc.rest_s = 0;
    tc.gyro_noise = tc.accel_noise = 0;
    /* a large bias: a range the driver and the emulation disagree on shows as a gyro value off by 2x or more */
    tc.gyro_bias[0] = 0.5;
    tc.gyro_bias[1] = -0.3;
    tc.gyro_bias[2] = 0.2;
    chip_emu c;
    int64_t t0 = hil_now_ns();
    emu_init(&c, kind, &st.regs, &tc, late ? 100 : 0, 25.0, t0);
    c.verbose = verbose;
    c.force_late = late;
    int fails = 0;
    printf("%s: self test %s: the real driver on an in-process i2c-stub, the emulation in a thread%s\n", hil_prog,
           c.model, late ? " looking only every 5 ms (late for the 1 ms reset wait)" : "");
    CHECK(emu_preload(&c) == 0, "preload failed");
    feeder_thread f = {&c, {INT64_MAX, INT64_MAX, INT64_MAX, late ? 5 * PLAT_NS_PER_MS : default_watch_ns(kind), NULL},
                       false};
    f.lc.stop = &f.stop;
    pthread_t th;
    if (pthread_create(&th, NULL, feeder_main, &f) != 0) {
        printf("  FAIL: cannot start the feeder thread\n");
        return 1;
    }
    drv_imu_i2c_params p;
    memset(&p, 0, sizeof p);
    snprintf(p.bus, sizeof p.bus, "self-test");
    p.addr = 0x68;
    snprintf(p.chip, sizeof p.chip, "auto");
    p.rate_hz = 1000;
    p.gyro_dps = 500;
    p.accel_g = 4;
    char err[256] = "";
    int64_t t_create = hil_now_ns();
    drv_imu *imu = drv_imu_i2c_create_on_bus(&st.bus, &p, err, sizeof err);
    CHECK(imu, "the driver did not start: %s", err);
    if (imu) {
        const drv_i2c_chip *found = drv_imu_i2c_chip(imu);
        const drv_i2c_setup *su = drv_imu_i2c_setup(imu);
        CHECK(found && found->kind == kind, "auto identified %s", found ? found->model : "nothing");
        printf("  driver up after %.0f ms: %s, gyro +-%.0f deg/s, accel +-%.0f g, %.0f Hz; resets emulated: %llu\n",
               (double)(hil_now_ns() - t_create) * 1e-6, found ? found->model : "?", su->gyro_fs_dps, su->accel_fs_g,
               su->rate_hz, (unsigned long long)c.resets);
        CHECK(c.resets >= 1, "the driver's reset was not seen");
        if (is_mpu(&c))
            CHECK(stub_peek(&st, MPU_REG_PWR_MGMT_1) == MPU_PWR1_CLKSEL_PLL,
                  "PWR_MGMT_1 = 0x%02x after init (expected 0x01: reset bit cleared, awake, PLL)",
                  stub_peek(&st, MPU_REG_PWR_MGMT_1));
        else
            CHECK(stub_peek(&st, ICM_REG_DEVICE_CONFIG) == 0 &&
                      stub_peek(&st, ICM_REG_PWR_MGMT0) == (ICM_PWR_GYRO_LN | ICM_PWR_ACCEL_LN),
                  "DEVICE_CONFIG = 0x%02x, PWR_MGMT0 = 0x%02x after init (expected 0x00, 0x0f)",
                  stub_peek(&st, ICM_REG_DEVICE_CONFIG), stub_peek(&st, ICM_REG_PWR_MGMT0));

        /* samples at the ranges the driver configured */
        int got = 0, bad = 0;
        for (int64_t until = hil_now_ns() + 300 * PLAT_NS_PER_MS; hil_now_ns() < until;) {
            drv_imu_sample smp;
            if (drv_imu_read(imu, &smp, 1, 20) != 1) continue;
            got++;
            int b = check_sample(&c, su, &smp, t0, bad < 3);
            bad += b > 0;
        }
        printf("  %d samples in 300 ms, %d off the trace; emulation sees gyro +-%g deg/s, accel +-%g g\n", got, bad,
               c.gyro_fs_dps, c.accel_fs_g);
        CHECK(got >= 100, "only %d samples in 300 ms", got);
        CHECK(bad == 0, "%d samples do not match the trace", bad);
        CHECK(c.gyro_fs_dps == 500 && c.accel_fs_g == 4, "emulation read gyro +-%g, accel +-%g from the registers",
              c.gyro_fs_dps, c.accel_fs_g);

        /* freeze: no data-ready, the driver must call the chip lost, re-initialise it and recover */
        int64_t t_freeze = hil_now_ns(), lost_at = 0, back_at = 0;
        atomic_store(&c.hold, true);
        uint64_t resets_before = c.resets;
        while (hil_now_ns() < t_freeze + 3 * PLAT_NS_PER_S) {
            drv_imu_sample smp;
            int n = drv_imu_read(imu, &smp, 1, 20);
            int64_t now = hil_now_ns();
            if (n == -ENODEV && !lost_at) lost_at = now;
            if (lost_at && now > t_freeze + 400 * PLAT_NS_PER_MS) atomic_store(&c.hold, false);
            if (n == 1 && !atomic_load(&c.hold)) {
                back_at = now;
                bad = check_sample(&c, su, &smp, t0, true);
                CHECK(bad == 0, "first sample after recovery does not match the trace");
                break;
            }
        }
        atomic_store(&c.hold, false);
        int after = 0, bad_after = 0;
        for (int64_t until = hil_now_ns() + 100 * PLAT_NS_PER_MS; back_at && hil_now_ns() < until;) {
            drv_imu_sample smp;
            if (drv_imu_read(imu, &smp, 1, 20) != 1) continue;
            after++;
            bad_after += check_sample(&c, su, &smp, t0, bad_after < 3) > 0;
        }
        CHECK(!back_at || (after >= 20 && bad_after == 0), "after recovery: %d samples in 100 ms, %d off the trace",
              after, bad_after);
        CHECK(c.gyro_fs_dps == 500 && c.accel_fs_g == 4,
              "after recovery the registers say gyro +-%g, accel +-%g (expected 500, 4)", c.gyro_fs_dps, c.accel_fs_g);
        drv_imu_stats ds;
        drv_imu_stats_get(imu, &ds);
        printf("  freeze: lost after %.0f ms, back %.0f ms after the freeze ended; reconnects %llu, resets "
               "emulated %llu; driver says: %s\n",
               lost_at ? (double)(lost_at - t_freeze) * 1e-6 : -1.0,
               back_at ? (double)(back_at - t_freeze) * 1e-6 - 400 : -1.0, (unsigned long long)ds.reconnects,
               (unsigned long long)(c.resets - resets_before), ds.last_error);
        CHECK(lost_at, "the driver never reported the chip lost during the freeze");
        CHECK(!lost_at || lost_at - t_freeze >= 200 * PLAT_NS_PER_MS, "lost after only %.0f ms (expected >= 250)",
              (double)(lost_at - t_freeze) * 1e-6);
        CHECK(back_at, "the driver did not recover within 3 s");
        CHECK(ds.reconnects >= 1, "reconnects = %llu", (unsigned long long)ds.reconnects);
        CHECK(c.resets > resets_before, "the re-initialisation's reset was not seen");
        drv_imu_destroy(imu);
    }
    atomic_store(&f.stop, true);
    pthread_join(th, NULL);
    CHECK(c.errors == 0, "%llu feeder transfer errors (%s)", (unsigned long long)c.errors, c.last_error);
    if (late) CHECK(c.late_resets >= 1, "no reset was seen late (late_resets = 0): the late path went untested");
    printf("%s: self test %s%s: %s\n", hil_prog, c.model, late ? " (late feeder)" : "", fails ? "FAIL" : "PASS");
    pthread_mutex_destroy(&st.mu);
    return fails;
}

static int self_test(bool verbose)
{
    int fails = 0;
    for (int k = DRV_I2C_CHIP_MPU6050; k < DRV_I2C_CHIP_COUNT; k++)
        fails += self_test_chip((drv_i2c_chip_kind)k, false, verbose);
    fails += self_test_chip(DRV_I2C_CHIP_ICM42688, true, verbose);
    printf("%s: self test %s\n", hil_prog, fails ? "FAIL" : "PASS");
    return fails ? HIL_EXIT_FAIL : 0;
}

/* ---- --dry-run: the driver's init sequence replayed synchronously, then the first register updates ---- */

static int dry_run(drv_i2c_chip_kind kind, const hil_trace_cfg *tc, double rate_hz, double temp_c, int n)
{
    mem_stub st;
    stub_init(&st);
    chip_emu c;
    emu_init(&c, kind, &st.regs, tc, rate_hz, temp_c, 0);
    const drv_i2c_chip *chip = drv_i2c_chip_get(kind);
    int fails = 0;
    CHECK(emu_preload(&c) == 0, "preload failed");
    drv_i2c_request rq = {1000, 2000, 16};
    drv_i2c_setup su;
    char err[200];
    if (drv_i2c_chip_plan(chip, &rq, &su, err, sizeof err) < 0) hil_die(HIL_EXIT_FAIL, "plan: %s", err);
    printf("%s: dry run %s: WHO_AM_I (0x75) = 0x%02x; the driver's init for 1000 Hz, +-2000 deg/s, +-16 g:\n",
           hil_prog, chip->model, stub_peek(&st, MPU_REG_WHO_AM_I));
    for (int i = 0; i < su.n_steps; i++) {
        const drv_i2c_step *s = &su.steps[i];
        stub_bus_write(&st.bus, s->reg, s->val);
        uint64_t r0 = c.resets;
        emu_watch(&c);
        uint8_t back = stub_peek(&st, s->reg);
        bool reset = c.resets > r0;
        printf("  write %-16s (0x%02x) = 0x%02x  read back 0x%02x%s\n", s->what, s->reg, s->val, back,
               reset ? "  <- soft reset emulated: reset values restored, bit cleared" : "");
        CHECK(!s->verify || back == s->val, "%s reads back 0x%02x", s->what, back);
    }
    double period = c.fixed_rate_hz > 0 ? c.fixed_rate_hz : 0;
    const double deg2rad = 3.14159265358979323846 / 180.0;
    for (int k = 0; k < n; k++) {
        int64_t now = period > 0 ? (int64_t)llround(k * 1e9 / period)
                                 : (int64_t)llround(k * 1e9 / fmin(c.rate_hz > 0 ? c.rate_hz : 1000, MAX_RATE_HZ));
        emu_update(&c, now, false);
        bool joined = chip->status_reg + 1 == chip->data_reg;
        uint8_t buf[16], status;
        stub_bus_read(&st.bus, chip->status_reg, &status, 1);
        stub_bus_read(&st.bus, chip->data_reg, buf, chip->data_len);
        drv_i2c_sample smp;
        drv_i2c_chip_decode(chip, &su, buf, &smp);
        double gy[3], ac[3];
        hil_imu_gen_sample(&c.gen, (uint64_t)(now / 1000), gy, ac);
        double glsb = deg2rad / su.gyro_lsb_per_dps, alsb = DRV_I2C_G / su.accel_lsb_per_g, worst = 0;
        for (int i = 0; i < 3; i++)
            worst = fmax(worst, fmax(fabs(smp.gyro[i] - gy[i]) / glsb, fabs(smp.accel[i] - ac[i]) / alsb));
        bool ok = smp.valid && (status & chip->ready_mask) && worst <= 0.5001 && fabs(smp.temp_c - temp_c) < 0.01;
        fails += !ok;
        printf("update %d at t=%.6f s (%.0f Hz): INT_STATUS (0x%02x) = 0x%02x%s, 0x%02x..:", k, (double)now * 1e-9,
               c.rate_hz, chip->status_reg, status, joined ? " (same burst)" : "", chip->data_reg);
        for (int i = 0; i < chip->data_len; i++) printf(" %02x", buf[i]);
        printf("\n  driver decodes: gyro %+.5f %+.5f %+.5f rad/s accel %+.4f %+.4f %+.4f m/s^2 temp %.2f C\n"
               "  trace:          gyro %+.5f %+.5f %+.5f rad/s accel %+.4f %+.4f %+.4f m/s^2 (max error %.2f "
               "counts)%s\n",
               smp.gyro[0], smp.gyro[1], smp.gyro[2], smp.accel[0], smp.accel[1], smp.accel[2], smp.temp_c, gy[0],
               gy[1], gy[2], ac[0], ac[1], ac[2], worst, ok ? "" : "  <-- FAIL");
    }
    printf("%s: dry run %s\n", hil_prog, fails ? "FAIL" : "PASS");
    pthread_mutex_destroy(&st.mu);
    return fails ? HIL_EXIT_FAIL : 0;
}

/* ---- command line ---- */

static void usage(FILE *f)
{
    fprintf(f,
            "usage: %s --bus BUS [options]\n"
            "Plays an InvenSense MPU-6050 / MPU-9250 or TDK ICM-42688-P on the kernel's i2c-stub through i2c-dev:\n"
            "preloads WHO_AM_I and the reset values, then at every output-data-rate tick re-reads the configuration\n"
            "the driver wrote (ranges, rate, sleep, sensor modes), writes the sample of a sim trace into the data\n"
            "registers (big-endian, one SMBus I2C-block write together with the data-ready flag) and raises\n"
            "data-ready. The stub only stores bytes, so the soft reset (MPU PWR_MGMT_1 bit 7, ICM DEVICE_CONFIG\n"
            "bit 0) is emulated: reset values restored and the bit cleared. Prints \"%s: ready BUS addr ...\" when\n"
            "the chip is in place, and a key=value summary at exit (when it stops, data-ready is lowered).\n"
            "\n"
            "Device:\n"
            "  --bus BUS           N, /dev/i2c-N, or \"stub\" (the adapter named \"" STUB_NAME "\")\n"
            "  --addr A            7-bit address (default 0x68; i2c-stub must serve it: chip_addr=)\n"
            "  --chip NAME         mpu6050 | mpu9250 | icm42688 (default mpu6050)\n"
            "  --ready-file PATH   also write state=ready|done, bus=, addr=, chip=, pid= lines to PATH (atomic)\n"
            "Data:\n"
            "  --rate HZ|chip      data update rate (default chip: the ODR the driver configured, at most %.0f Hz)\n"
            "  --temp C            die temperature reported (default 25)\n"
            "  --watch-us US       how often to look for a reset between updates (default 2000 MPU, 200 ICM: the\n"
            "                      driver waits 100 ms resp. 1 ms after its reset)\n"
            "Run:\n"
            "  --duration S        stop after S seconds (default 60; 0: until SIGINT/SIGTERM)\n"
            "  --freeze-at S       S seconds after start, stop producing data (data-ready lowered, registers\n"
            "                      frozen; resets are still handled): the driver should call the chip lost\n"
            "  --freeze-for S      ... for S seconds (default 1), then resume: the driver should recover\n"
            "  --dry-run[=N]       no device: replay the driver's init sequence on an in-process stub, then print N\n"
            "                      updates (default 4) as the driver decodes them next to the trace; PASS or FAIL\n"
            "  --self-test         no device: run the real chip driver (drv_imu_i2c_create_on_bus) against this\n"
            "                      emulation in a thread for all three chips (init, ranges, samples, freeze and\n"
            "                      recovery; the ICM-42688-P once more with a late feeder); PASS or\n"
            "                      FAIL, about 5 s\n"
            "  -v, --verbose       log every emulated reset\n"
            "  -h, --help          this text\n",
            hil_prog, hil_prog, MAX_RATE_HZ);
    hil_trace_help(f);
    fprintf(f, "Exit status: 0 done, 1 device failure (or a failed check), 2 bad command line.\n");
}

enum {
    OPT_BUS = HIL_OPT_FIRST_FREE,
    OPT_ADDR,
    OPT_CHIP,
    OPT_READY_FILE,
    OPT_RATE,
    OPT_TEMP,
    OPT_WATCH_US,
    OPT_DURATION,
    OPT_FREEZE_AT,
    OPT_FREEZE_FOR,
    OPT_DRY_RUN,
    OPT_SELF_TEST,
};

typedef struct {
    const char *bus;
    int addr;
    drv_i2c_chip_kind kind;
    const char *ready_file;
    double rate_hz; /* 0: chip */
    double temp_c;
    int64_t watch_ns;
    double duration_s, freeze_at_s, freeze_for_s;
    int dry_run;
    bool self_test, verbose;
    hil_trace_cfg trace;
} opts;

static void parse_args(int argc, char **argv, opts *o)
{
    static const struct option lo[] = {
        {"bus", required_argument, NULL, OPT_BUS},
        {"addr", required_argument, NULL, OPT_ADDR},
        {"chip", required_argument, NULL, OPT_CHIP},
        {"ready-file", required_argument, NULL, OPT_READY_FILE},
        {"rate", required_argument, NULL, OPT_RATE},
        {"temp", required_argument, NULL, OPT_TEMP},
        {"watch-us", required_argument, NULL, OPT_WATCH_US},
        {"duration", required_argument, NULL, OPT_DURATION},
        {"freeze-at", required_argument, NULL, OPT_FREEZE_AT},
        {"freeze-for", required_argument, NULL, OPT_FREEZE_FOR},
        {"dry-run", optional_argument, NULL, OPT_DRY_RUN},
        {"self-test", no_argument, NULL, OPT_SELF_TEST},
        HIL_TRACE_LONGOPTS,
        HIL_LONGOPTS_END,
    };
    memset(o, 0, sizeof *o);
    o->addr = 0x68;
    o->kind = DRV_I2C_CHIP_MPU6050;
    o->temp_c = 25;
    o->duration_s = 60;
    o->freeze_for_s = 1;
    o->trace = hil_trace_defaults();
    int c;
    while ((c = hil_getopt(argc, argv, lo)) != -1) {
        if (hil_trace_option(c, optarg, &o->trace)) continue;
        switch (c) {
        case OPT_BUS: o->bus = optarg; break;
        case OPT_ADDR: o->addr = (int)hil_parse_int("--addr", optarg, 0x03, 0x77); break;
        case OPT_CHIP:
            if (!drv_i2c_chip_parse(optarg, &o->kind) || o->kind == DRV_I2C_CHIP_AUTO)
                hil_die(HIL_EXIT_USAGE, "--chip '%s': expected mpu6050, mpu9250 or icm42688", optarg);
            break;
        case OPT_READY_FILE: o->ready_file = optarg; break;
        case OPT_RATE: o->rate_hz = strcmp(optarg, "chip") == 0 ? 0 : hil_parse_double("--rate", optarg, 1, 4000); break;
        case OPT_TEMP: o->temp_c = hil_parse_double("--temp", optarg, -40, 85); break;
        case OPT_WATCH_US: o->watch_ns = hil_parse_int("--watch-us", optarg, 50, 1000000) * 1000; break;
        case OPT_DURATION: o->duration_s = hil_parse_double("--duration", optarg, 0, 1e6); break;
        case OPT_FREEZE_AT: o->freeze_at_s = hil_parse_double("--freeze-at", optarg, 0, 1e6); break;
        case OPT_FREEZE_FOR: o->freeze_for_s = hil_parse_double("--freeze-for", optarg, 0.001, 1e6); break;
        case OPT_DRY_RUN: o->dry_run = optarg ? (int)hil_parse_int("--dry-run", optarg, 1, 100000) : 4; break;
        case OPT_SELF_TEST: o->self_test = true; break;
        case 'v': o->verbose = true; break;
        default: hil_opt_other(c, argv, usage);
        }
    }
    hil_opt_no_operands(argc, argv);
    if (!o->bus && !o->dry_run && !o->self_test)
        hil_die(HIL_EXIT_USAGE, "--bus is required (N, /dev/i2c-N or stub; see --help)");
    if (!o->watch_ns) o->watch_ns = default_watch_ns(o->kind);
}

int main(int argc, char **argv)
{
    hil_init("hil_i2c_chip");
    opts o;
    parse_args(argc, argv, &o);
    if (o.self_test) return self_test(o.verbose);
    if (o.dry_run) {
        hil_imu_gen check;
        hil_imu_gen_init(&check, &o.trace, 1e6); /* the trace name is checked before anything is printed */
        return dry_run(o.kind, &o.trace, o.rate_hz, o.temp_c, o.dry_run);
    }

    hil_signals_install();
    char path[64];
    resolve_bus(o.bus, path, sizeof path);
    dev_regs d;
    dev_open(&d, path, o.addr, MPU_REG_WHO_AM_I);
    chip_emu c;
    int64_t t0 = hil_now_ns();
    emu_init(&c, o.kind, &d.r, &o.trace, o.rate_hz, o.temp_c, t0);
    c.verbose = o.verbose;
    if (emu_preload(&c) < 0) hil_die(HIL_EXIT_FAIL, "cannot preload the register file: %s", c.last_error);
    printf("%s: ready %s addr 0x%02x %s (%s, WHO_AM_I 0x%02x; rate %s, trace %s seed %llu)\n", hil_prog, path,
           o.addr, c.name, c.model, c.def[MPU_REG_WHO_AM_I], o.rate_hz > 0 ? "fixed" : "the chip's ODR",
           o.trace.trace, (unsigned long long)o.trace.seed);
    hil_status_write(o.ready_file, "state=ready\nbus=%s\naddr=0x%02x\nchip=%s\n", path, o.addr, c.name);
    loop_cfg lc = {o.duration_s > 0 ? t0 + (int64_t)(o.duration_s * 1e9) : INT64_MAX,
                   o.freeze_at_s > 0 ? t0 + (int64_t)(o.freeze_at_s * 1e9) : INT64_MAX,
                   o.freeze_at_s > 0 ? t0 + (int64_t)((o.freeze_at_s + o.freeze_for_s) * 1e9) : INT64_MAX, o.watch_ns,
                   NULL};
    int rc = emu_run(&c, &lc);
    emu_lower_flag(&c); /* a chip that stopped produces no more data */
    close(d.fd);
    printf("%s: summary run_s=%.3f updates=%llu resets=%llu idle_updates=%llu frozen_updates=%llu errors=%llu "
           "rate_hz=%g gyro_fs_dps=%g accel_fs_g=%g awake=%d stop=%s\n",
           hil_prog, (double)(hil_now_ns() - t0) * 1e-9, (unsigned long long)c.updates, (unsigned long long)c.resets,
           (unsigned long long)c.idle_updates, (unsigned long long)c.frozen_updates, (unsigned long long)c.errors,
           c.rate_hz, c.gyro_fs_dps, c.accel_fs_g, c.awake, hil_stopped() ? "signal" : rc ? "error" : "duration");
    if (c.errors) hil_msg("last error: %s", c.last_error);
    hil_status_write(o.ready_file, "state=done\nbus=%s\naddr=0x%02x\nchip=%s\n", path, o.addr, c.name);
    return rc;
}
