/* SPDX-License-Identifier: MIT */
/* drv_imu_i2c: the drv_imu backend for IMUs on an I2C bus (Linux i2c-dev + libi2c SMBus), polled at the sample rate;
 * its mock bus (the chip's register file emulated) is in drv_imu_i2c_mock.c. */
#include "drivers/drv_imu_i2c.h"

#include <errno.h>
#include <fcntl.h>
#include <i2c/smbus.h>
#include <linux/i2c-dev.h>
#include <linux/i2c.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include "platform/plat_clock.h"
#include "warp/warp_err.h"

#define RETRY_NS (250 * PLAT_NS_PER_MS)   /* re-initialise a lost chip at most this often */
#define NO_DATA_NS (250 * PLAT_NS_PER_MS) /* no data-ready for this long while the bus works: chip reset/asleep */
#define FAILS_LOST 3                      /* consecutive failed transfers that mean the chip is gone */

/* ==== the real bus: /dev/i2c-N ==== */

typedef struct {
    drv_i2c_bus bus;
    int fd;
    char path[128];
    int addr;
    bool rdwr_read, rdwr_write; /* plain I2C messages instead of SMBus (adapter lacks the SMBus commands) */
    char name[160];
} i2c_dev;

static int dev_rdwr(i2c_dev *d, struct i2c_msg *msgs, int n)
{
    struct i2c_rdwr_ioctl_data x = {msgs, (__u32)n};
    return ioctl(d->fd, I2C_RDWR, &x) < 0 ? -errno : 0;
}

static int dev_read_block(drv_i2c_bus *b, uint8_t reg, uint8_t *buf, int n)
{
    i2c_dev *d = (i2c_dev *)b;
    if (d->fd < 0) return -EBADF;
    if (n < 1 || n > DRV_I2C_BLOCK_MAX) return -EINVAL;
    if (d->rdwr_read) {
        /* register address write, repeated start, read: what the SMBus I2C-block read does on the wire */
        struct i2c_msg m[2] = {{(__u16)d->addr, 0, 1, &reg}, {(__u16)d->addr, I2C_M_RD, (__u16)n, buf}};
        return dev_rdwr(d, m, 2);
    }
    int rc = i2c_smbus_read_i2c_block_data(d->fd, reg, (__u8)n, buf);
    if (rc < 0) return rc;
    return rc == n ? 0 : -EIO; /* short read */
}

static int dev_write_byte(drv_i2c_bus *b, uint8_t reg, uint8_t val)
{
    i2c_dev *d = (i2c_dev *)b;
    if (d->fd < 0) return -EBADF;
    if (d->rdwr_write) {
        uint8_t msg[2] = {reg, val};
        struct i2c_msg m = {(__u16)d->addr, 0, 2, msg};
        return dev_rdwr(d, &m, 1);
    }
    int rc = i2c_smbus_write_byte_data(d->fd, reg, val);
    return rc < 0 ? rc : 0;
}

static int dev_connect(i2c_dev *d, char *err, int errlen)
{
    d->fd = open(d->path, O_RDWR | O_CLOEXEC);
    if (d->fd < 0) {
        int e = errno;
        if (e == ENOENT || e == ENODEV || e == ENXIO)
            warp_err(err, errlen, "%s: no such bus (i2c-dev loaded? `modprobe i2c-dev`, `ls /dev/i2c-*`)", d->path);
        else if (e == EACCES || e == EPERM)
            warp_err(err, errlen, "%s: permission denied (add the user to group i2c or use a udev rule)", d->path);
        else
            warp_err(err, errlen, "%s: cannot open: %s", d->path, strerror(e));
        return -e;
    }
    unsigned long funcs = 0;
    if (ioctl(d->fd, I2C_FUNCS, &funcs) < 0) {
        int e = errno;
        warp_err(err, errlen, "%s: not an I2C adapter (I2C_FUNCS: %s)", d->path, strerror(e));
        close(d->fd);
        d->fd = -1;
        return -e;
    }
    /* SMBus first: the i2c-stub test device and many SMBus-only controllers support nothing else. */
    bool smb_read = funcs & I2C_FUNC_SMBUS_READ_I2C_BLOCK, smb_write = funcs & I2C_FUNC_SMBUS_WRITE_BYTE_DATA;
    bool plain = funcs & I2C_FUNC_I2C;
    if ((!smb_read || !smb_write) && !plain) {
        warp_err(err, errlen,
                 "%s: adapter supports neither SMBus I2C-block reads + byte writes nor plain I2C (funcs 0x%08lx)",
                 d->path, funcs);
        close(d->fd);
        d->fd = -1;
        return -EOPNOTSUPP;
    }
    d->rdwr_read = !smb_read;
    d->rdwr_write = !smb_write;
    if (ioctl(d->fd, I2C_SLAVE, (unsigned long)d->addr) < 0) {
        int e = errno;
        if (e == EBUSY)
            warp_err(err, errlen, "%s addr 0x%02x: address in use by a kernel driver (unbind it first)", d->path,
                     d->addr);
        else
            warp_err(err, errlen, "%s addr 0x%02x: I2C_SLAVE: %s", d->path, d->addr, strerror(e));
        close(d->fd);
        d->fd = -1;
        return -e;
    }
    return 0;
}

static int dev_reopen(drv_i2c_bus *b)
{
    i2c_dev *d = (i2c_dev *)b;
    if (d->fd >= 0) close(d->fd);
    d->fd = -1;
    char e[8];
    return dev_connect(d, e, sizeof e);
}

static void dev_destroy(drv_i2c_bus *b)
{
    i2c_dev *d = (i2c_dev *)b;
    if (d->fd >= 0) close(d->fd);
    free(d);
}

drv_i2c_bus *drv_i2c_dev_create(const char *path, int addr, char *err, int errlen)
{
    i2c_dev *d = calloc(1, sizeof *d);
    if (!d) {
        warp_err(err, errlen, "%s: out of memory", path);
        return NULL;
    }
    snprintf(d->path, sizeof d->path, "%s", path);
    d->addr = addr;
    d->fd = -1;
    snprintf(d->name, sizeof d->name, "%s addr 0x%02x", path, addr);
    d->bus = (drv_i2c_bus){d->name, dev_read_block, dev_write_byte, dev_reopen, dev_destroy};
    if (dev_connect(d, err, errlen) < 0) {
        free(d);
        return NULL;
    }
    return &d->bus;
}

/* ==== the backend ==== */

typedef struct {
    drv_imu base;
    char name[176];
    drv_i2c_bus *bus;
    const drv_i2c_chip *chip;
    drv_i2c_setup setup;
    int64_t period_ns, poll_ns;
    int64_t next_due;      /* next time to look for a sample */
    int64_t last_ready_ns; /* last time the chip had new data */
    bool online;
    int fails;             /* consecutive failed transfers */
    /* (re-)initialisation, stepped so read() never blocks past its timeout */
    bool initialising;
    int init_pos;
    int64_t init_resume_ns;
    int64_t last_attempt_ns;
    pthread_mutex_t mu; /* guards st (stats() may run on another thread) */
    drv_imu_stats st;
} imu_i2c;

static void note_error(imu_i2c *s, bool transport, const char *msg)
{
    pthread_mutex_lock(&s->mu);
    if (transport)
        s->st.read_errors++;
    else
        s->st.bad_reports++;
    snprintf(s->st.last_error, sizeof s->st.last_error, "%s", msg);
    pthread_mutex_unlock(&s->mu);
}

static void go_offline(imu_i2c *s, int64_t now)
{
    s->online = false;
    s->initialising = false;
    s->last_attempt_ns = now;
    pthread_mutex_lock(&s->mu);
    s->st.connected = false;
    pthread_mutex_unlock(&s->mu);
}

/* Runs init steps from init_pos; waits of a step beyond `deadline` are resumed by the next call.
 * 1 done, 0 still waiting, < 0 error. */
static int init_continue(imu_i2c *s, int64_t deadline, char *err, int errlen)
{
    for (;;) {
        int64_t now = plat_now_ns();
        if (now < s->init_resume_ns) {
            if (s->init_resume_ns > deadline) {
                plat_sleep_until_ns(deadline);
                return 0;
            }
            plat_sleep_until_ns(s->init_resume_ns);
        }
        if (s->init_pos >= s->setup.n_steps) return 1;
        const drv_i2c_step *st = &s->setup.steps[s->init_pos];
        int rc = drv_i2c_chip_step(s->bus, st, err, errlen);
        if (rc < 0) return rc;
        s->init_pos++;
        s->init_resume_ns = plat_now_ns() + (int64_t)st->delay_ms * PLAT_NS_PER_MS;
    }
}

static void init_begin(imu_i2c *s)
{
    s->initialising = true;
    s->init_pos = 0;
    s->init_resume_ns = 0;
}

static void came_online(imu_i2c *s)
{
    int64_t now = plat_now_ns();
    s->online = true;
    s->initialising = false;
    s->fails = 0;
    s->next_due = now;
    s->last_ready_ns = now;
    pthread_mutex_lock(&s->mu);
    s->st.connected = true;
    pthread_mutex_unlock(&s->mu);
}

/* Offline: re-identify and re-initialise at most every RETRY_NS. 0 when back online, else -ENODEV. */
static int recover(imu_i2c *s, int64_t deadline)
{
    char e[160];
    if (!s->initialising) {
        int64_t at = s->last_attempt_ns + RETRY_NS;
        if (plat_now_ns() < at) {
            plat_sleep_until_ns(at < deadline ? at : deadline);
            if (plat_now_ns() < at) return -ENODEV;
        }
        s->last_attempt_ns = plat_now_ns();
        int rc = s->bus->reopen ? s->bus->reopen(s->bus) : 0;
        if (rc < 0) {
            snprintf(e, sizeof e, "%s: cannot reopen the bus: %s", s->bus->name, strerror(-rc));
            note_error(s, true, e);
            return -ENODEV;
        }
        /* Same chip as before (a different one on the same address is an error, not a silent switch). */
        if (drv_i2c_chip_identify(s->bus, s->chip, NULL, e, sizeof e) < 0) {
            note_error(s, true, e);
            return -ENODEV;
        }
        init_begin(s);
    }
    int rc = init_continue(s, deadline, e, sizeof e);
    if (rc < 0) {
        note_error(s, true, e);
        s->initialising = false;
        s->last_attempt_ns = plat_now_ns();
        return -ENODEV;
    }
    if (rc == 0) return -ENODEV;
    came_online(s);
    pthread_mutex_lock(&s->mu);
    s->st.reconnects++;
    pthread_mutex_unlock(&s->mu);
    return 0;
}

static int imu_i2c_read(drv_imu *imu, drv_imu_sample *out, int max, int timeout_ms)
{
    imu_i2c *s = (imu_i2c *)imu;
    if (max <= 0) return 0;
    int64_t deadline = plat_now_ns() + (int64_t)(timeout_ms > 0 ? timeout_ms : 0) * PLAT_NS_PER_MS;
    if (!s->online && recover(s, deadline) < 0) return -ENODEV;
    bool joined = s->chip->status_reg + 1 == s->chip->data_reg;
    char e[160];
    for (;;) {
        int64_t now = plat_now_ns();
        if (now < s->next_due) {
            if (s->next_due > deadline) {
                plat_sleep_until_ns(deadline);
                return 0;
            }
            plat_sleep_until_ns(s->next_due);
        }
        bool ready = true;
        drv_i2c_sample smp;
        int64_t t0 = 0, t1 = 0;
        int rc = joined ? 0 : drv_i2c_chip_data_ready(s->bus, s->chip, &ready, e, sizeof e);
        if (rc == 0 && ready) rc = drv_i2c_chip_read(s->bus, s->chip, &s->setup, &smp, &ready, &t0, &t1, e, sizeof e);
        now = plat_now_ns();
        if (rc < 0) {
            note_error(s, true, e);
            if (++s->fails >= FAILS_LOST) {
                go_offline(s, now);
                return -ENODEV;
            }
            s->next_due = now + s->period_ns / 4;
            continue;
        }
        s->fails = 0;
        if (ready && !smp.valid) {
            snprintf(e, sizeof e, "%s: %s data registers hold the invalid marker -32768 (sensors not running)",
                     s->bus->name, s->chip->model);
            note_error(s, false, e);
            ready = false;
        }
        if (!ready) {
            if (now - s->last_ready_ns > NO_DATA_NS) {
                snprintf(e, sizeof e, "%s: %s reported no new data for %d ms (reset or asleep?); re-initialising",
                         s->bus->name, s->chip->model, (int)(NO_DATA_NS / PLAT_NS_PER_MS));
                note_error(s, false, e);
                go_offline(s, now);
                return -ENODEV;
            }
            s->next_due = now + s->poll_ns;
            continue;
        }
        /* The chip sampled shortly before the transfer; its middle is the best single estimate we have. */
        out[0].t_ns = t0 + (t1 - t0) / 2;
        for (int i = 0; i < 3; i++) {
            out[0].gyro[i] = smp.gyro[i];
            out[0].accel[i] = smp.accel[i];
        }
        s->last_ready_ns = now;
        s->next_due = out[0].t_ns + s->period_ns;
        pthread_mutex_lock(&s->mu);
        s->st.reports++;
        pthread_mutex_unlock(&s->mu);
        return 1;
    }
}

static void imu_i2c_stats(drv_imu *imu, drv_imu_stats *out)
{
    imu_i2c *s = (imu_i2c *)imu;
    pthread_mutex_lock(&s->mu);
    *out = s->st;
    pthread_mutex_unlock(&s->mu);
}

static void imu_i2c_destroy(drv_imu *imu)
{
    imu_i2c *s = (imu_i2c *)imu;
    drv_i2c_bus_destroy(s->bus);
    pthread_mutex_destroy(&s->mu);
    free(s);
}

static bool params_ok(const drv_imu_i2c_params *p, drv_i2c_chip_kind *kind, char *err, int errlen)
{
    if (!p) {
        warp_err(err, errlen, "i2c imu: no parameters");
        return false;
    }
    if (p->addr < 0x03 || p->addr > 0x77) {
        warp_err(err, errlen, "%s addr 0x%02x: not a 7-bit I2C device address (0x03..0x77; MPU/ICM: 0x68 or 0x69)",
                 p->bus, p->addr);
        return false;
    }
    if (!drv_i2c_chip_parse(p->chip, kind)) {
        warp_err(err, errlen, "%s addr 0x%02x: chip '%s' unknown (auto, mpu6050, mpu9250, icm42688)", p->bus, p->addr,
                 p->chip);
        return false;
    }
    return true;
}

static drv_imu *create_on_bus(drv_i2c_bus *bus, const drv_imu_i2c_params *p, char *err, int errlen)
{
    drv_i2c_chip_kind kind;
    if (!params_ok(p, &kind, err, errlen)) {
        drv_i2c_bus_destroy(bus);
        return NULL;
    }
    imu_i2c *s = calloc(1, sizeof *s);
    if (!s) {
        warp_err(err, errlen, "%s: out of memory", bus->name);
        drv_i2c_bus_destroy(bus);
        return NULL;
    }
    pthread_mutex_init(&s->mu, NULL);
    s->bus = bus;
    drv_i2c_request rq = {p->rate_hz, p->gyro_dps, p->accel_g};
    char e[200];
    if (drv_i2c_chip_identify(bus, drv_i2c_chip_get(kind), &s->chip, err, errlen) < 0) goto fail;
    if (drv_i2c_chip_plan(s->chip, &rq, &s->setup, e, sizeof e) < 0) {
        warp_err(err, errlen, "%s: %s", bus->name, e);
        goto fail;
    }
    init_begin(s);
    if (init_continue(s, INT64_MAX, err, errlen) < 0) goto fail;
    s->period_ns = (int64_t)llround(1e9 / s->setup.rate_hz);
    s->poll_ns = s->period_ns / 10 > 50000 ? s->period_ns / 10 : 50000;
    snprintf(s->name, sizeof s->name, "i2c %s %s", s->chip->name, bus->name);
    s->base.name = s->name;
    s->base.read = imu_i2c_read;
    s->base.stats = imu_i2c_stats;
    s->base.destroy = imu_i2c_destroy;
    came_online(s);
    return &s->base;
fail:
    imu_i2c_destroy(&s->base);
    return NULL;
}

drv_imu *drv_imu_i2c_create_on_bus(drv_i2c_bus *bus, const drv_imu_i2c_params *p, char *err, int errlen)
{
    if (!bus) {
        warp_err(err, errlen, "i2c imu: no bus");
        return NULL;
    }
    return create_on_bus(bus, p, err, errlen);
}

drv_imu *drv_imu_i2c_create(const drv_imu_i2c_params *p, char *err, int errlen)
{
    drv_i2c_chip_kind kind;
    if (!params_ok(p, &kind, err, errlen)) return NULL;
    drv_i2c_bus *bus = drv_i2c_dev_create(p->bus, p->addr, err, errlen);
    if (!bus) return NULL;
    return create_on_bus(bus, p, err, errlen);
}

static imu_i2c *as_i2c(drv_imu *imu)
{
    return imu && imu->read == imu_i2c_read ? (imu_i2c *)imu : NULL;
}

const drv_i2c_chip *drv_imu_i2c_chip(drv_imu *imu)
{
    imu_i2c *s = as_i2c(imu);
    return s ? s->chip : NULL;
}

const drv_i2c_setup *drv_imu_i2c_setup(drv_imu *imu)
{
    imu_i2c *s = as_i2c(imu);
    return s ? &s->setup : NULL;
}

drv_i2c_bus *drv_imu_i2c_bus(drv_imu *imu)
{
    imu_i2c *s = as_i2c(imu);
    return s ? s->bus : NULL;
}
