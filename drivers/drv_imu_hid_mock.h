/* SPDX-License-Identifier: MIT */
/* drv_imu_hid_mock: a mocked HID IMU for the simulated board and tests: the real decoding, time mapping and
 * reconnects of drv_imu_hid over a transport that encodes another drv_imu's samples as vendor reports. */
#ifndef DRV_IMU_HID_MOCK_H
#define DRV_IMU_HID_MOCK_H

#include "drivers/drv_imu_hid.h"

typedef struct {
    uint32_t counter_start;     /* device µs counter at the source's first sample, e.g. near 2^32 to force roll-over;
                                 * it restarts there after a replug, as a power-cycled device's would */
    int samples_per_report;     /* 1..4 (0: 1) */
    double unplug_at_s;         /* seconds after creation the device vanishes (0: never) */
    double unplug_for_s;        /* ... and for how long (0: never unplugged) */
    int corrupt_every;          /* every Nth report garbled (bit flip, truncation, wrong id, wrong version in turn);
                                 * 0: never */
} drv_imu_hid_mock_params;

/* Takes ownership of `source` (also on failure): its samples are encoded into vendor reports stamped with a mock
 * device clock, then decoded and time-mapped by the same code as real reports. NULL on bad parameters. */
drv_imu *drv_imu_hid_create_mock(drv_imu *source, const drv_imu_hid_mock_params *mp);

#endif
