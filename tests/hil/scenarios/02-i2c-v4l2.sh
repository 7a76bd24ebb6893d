#!/bin/sh
# SPDX-License-Identifier: MIT
# 02-i2c-v4l2: the I2C/V4L2 board. IMU on i2c-stub (hil_i2c_chip plays an MPU-6050, then an ICM-42688-P register
# map; hmdwarpd identifies each by WHO_AM_I), host frames through vivid's HDMI loop (hmdwarp-feed --v4l2 writes
# the in-band layout to the output node, hmdwarpd captures), TE edges from gpio-sim at 90 Hz.
# Asserts per chip: the chip identified, IMU samples at rate without read errors, frames captured and none
# rejected, vsync on the TE line, one present per vsync; rates and latency are timing targets (reported).
# hil-timeout: 420
. /hil/scenarios/lib.sh
D=${HIL_NOMINAL_S:-10}

hil_gpio_sim hil02 1
hil_te_start --rate 90 --duration 900
hil_vivid
hil_vivid_loop YUYV

run_chip() {
    chip=$1
    hil_log "--- $chip"
    bus=$(hil_i2c_stub 0x68)
    hil_device hil_i2c_chip --bus "$bus" --chip "$chip" --ready-file "$HIL_WORK/i2c.ready" --duration 900 --trace slow \
        >"$HIL_WORK/i2c-$chip.log" 2>&1 &
    ipid=$!
    hil_wait_until 10 grep -q '^state=ready' "$HIL_WORK/i2c.ready" 2>/dev/null ||
        { cat "$HIL_WORK/i2c-$chip.log"; hil_fail "hil_i2c_chip $chip: not ready on $bus"; }
    hmdwarp-feed --v4l2 "$HIL_VID_OUT" --v4l2-format yuyv --synth-poses --eye "$HIL_EYE" --rate 30 \
        --duration 900 >"$HIL_WORK/feed-$chip.log" 2>&1 &
    fpid=$!
    sleep 1
    # D seconds and on until every device path has carried its share of data (a starved VM takes longer)
    hil_hmdwarpd --config "$(hil_board i2c-v4l2-gpio)" --duration 0 --set "imu.device=$bus" --set imu.chip=auto \
        --set "frames.device=$HIL_VID_CAP" --set "vsync.chip=$HIL_GPIO_CHIP"
    hil_run_until "$D" 150 frames_received 20 imu_samples 1000 vsync_edges 100 vsyncs 100
    kill "$fpid" "$ipid" 2>/dev/null; wait "$fpid" "$ipid" 2>/dev/null
    tail -n 3 "$HIL_WORK/feed-$chip.log"; tail -n 3 "$HIL_WORK/i2c-$chip.log"
    cp "$HIL_STATS" "$HIL_WORK/stats-$chip.txt"
    rm -f "$HIL_WORK/i2c.ready"
    hil_rmmod i2c_stub

    hil_expect_backends i2c/v4l2/gpio ||
        hil_miss "$chip: backends $(hil_stat imu_backend)/$(hil_stat frames_backend)/$(hil_stat vsync_backend)"
    want=$chip; [ "$chip" = icm42688 ] && want='icm-?42688'; [ "$chip" = mpu6050 ] && want='mpu-?6050'
    grep -qiE "$want" "$HIL_HMD_LOG" || hil_miss "$chip: hmdwarpd's log does not name the chip it identified"
    RUN_S=$(hil_stat run_s)
    hil_expect_stat imu_samples '>=' 1000 "$chip: IMU samples over i2c-dev"
    hil_target imu_samples '>=' "$RUN_S * 1000 * ${HIL_IMU_RATE_MIN:-0.2}" "$chip: IMU sample rate"
    hil_expect_stat imu_read_errors '<=' 2 "$chip: I2C read errors"
    hil_expect_stat imu_lost '==' 0 "$chip: IMU lost"
    hil_expect_stat frames_received '>=' 20 "$chip: frames captured from vivid"
    hil_target frames_received '>=' "$RUN_S * 2" "$chip: frame rate from vivid"
    hil_expect_stat frames_rejected '==' 0 "$chip: rejected frames (the loop is byte-exact)"
    hil_expect_stat vsync_edges '>=' 100 "$chip: TE edges"
    hil_target vsync_edges '>=' "$RUN_S * 90 * 0.5" "$chip: TE edge rate"
    hil_expect_locked "$chip: vsync on the TE line"
    hil_expect_one_present_per_vsync
    hil_expect_on_time "$chip"
    hil_expect_stat m2p_ms_p50 '>' 0 "$chip: motion-to-photon measured"
    hil_target m2p_ms_p50 '>=' 4 "$chip: motion-to-photon p50 (vsync served late?)"
    hil_target m2p_ms_p99 '<=' 40 "$chip: motion-to-photon p99"
}
run_chip mpu6050
run_chip icm42688
hil_pass
