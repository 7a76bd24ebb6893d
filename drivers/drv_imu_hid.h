/* SPDX-License-Identifier: MIT */
/* drv_imu_hid: IMU over USB HID (hidapi, hidraw backend): vendor IMU-bridge and Rift sensor reports decoded, device
 * time mapped to CLOCK_MONOTONIC, unplug/replug survived. Its mock transport: drv_imu_hid_mock.h. */
#ifndef DRV_IMU_HID_H
#define DRV_IMU_HID_H

#include <stdbool.h>
#include <stdint.h>

#include "drivers/drv_imu.h"

typedef struct {
    char device[128]; /* "/dev/hidrawN" or "VVVV:PPPP" (hex vendor:product, the first matching interface) */
    double rate_hz;   /* nominal sample rate (0: 1000); only used to notice a device that went silent */
} drv_imu_hid_params;

/* Opens the device; NULL with a message naming the device on failure. */
drv_imu *drv_imu_hid_create(const drv_imu_hid_params *p, char *err, int errlen);

/* The lowest layer, below decoding: what hidapi does for the real device. Every function gets the ctx given to
 * drv_imu_hid_create_with_transport. */
typedef struct {
    /* 0, or a negative errno with a message in err (-ENODEV: not there). */
    int (*open)(void *ctx, const char *device, char *err, int errlen);
    /* One input report (byte 0 = report id) into buf: its size, 0 after timeout_ms without one, or a negative errno
     * when the device failed or is gone (it is closed and reopened then). */
    int (*read)(void *ctx, uint8_t *buf, int len, int timeout_ms);
    void (*close)(void *ctx);
    void (*destroy)(void *ctx); /* optional: frees ctx with the IMU */
} drv_hid_transport;

/* An HID IMU on any transport (tests inject arbitrary bytes this way). Takes ownership of ctx (also on failure);
 * `device` names the device in messages and is what open() is given. */
drv_imu *drv_imu_hid_create_with_transport(const drv_hid_transport *t, void *ctx, const char *device, double rate_hz,
                                           char *err, int errlen);

/* Parses "VVVV:PPPP" (exactly four hex digits each). */
bool drv_hid_parse_vid_pid(const char *s, uint16_t *vid, uint16_t *pid);

/* How long a lost device waits between reopen attempts. */
#define DRV_IMU_HID_REOPEN_MS 250

#endif
