#!/bin/sh
# 01-nominal: the full real-driver board. IMU over hidraw (hil_uhid_imu on uhid) at 1 kHz, host frames over USB
# (FunctionFS gadget on dummy_hcd, hmdwarp-feed as the host) at 30 Hz, TE edges from gpio-sim (hil_te) at 90 Hz.
# Asserts: TE edges reach hmdwarpd and it stays locked, one present per vsync and few late ones, the newest host
# frame shown (few dropped unseen), no rejects, IMU at rate without errors, motion-to-photon and frame age in
# bounds, and the run ends on time. Bounds are for a loaded 2-CPU TCG VM (see README "Timings").
# hil-timeout: 150
. /hil/scenarios/lib.sh
D=${HIL_NOMINAL_S:-10}

hil_uhid
hil_imu_start --duration $((D + 60)) --trace slow
hil_gpio_sim hil01 1
hil_te_start --rate 90 --duration $((D + 60))
hil_usb_udc
hil_gadget_start --config "$(hil_board hid-usb-gpio)" --duration "$D" --set "vsync.chip=$HIL_GPIO_CHIP"
hil_feed_usb --rate 30 --duration $((D + 5))
hil_hmdwarpd_wait $((D + 60))
kill "$HIL_FEED_PID" 2>/dev/null; wait "$HIL_FEED_PID" 2>/dev/null
tail -n 3 "$HIL_WORK/feed.log"
hil_gadget_stop
grep -v '^frames_rejected_\|^psnr\|^ssim' "$HIL_STATS"

hil_expect_backends hid/usb/gpio ||
    hil_miss "backends $(hil_stat imu_backend)/$(hil_stat frames_backend)/$(hil_stat vsync_backend), expected hid/usb/gpio"
hil_expect_run_time "$D" 15
# Vsync: the TE line drove the display (edges seen, locked at the end, ~90 Hz).
hil_expect_stat vsync_edges '>=' "$D * 90 * 0.5" "TE edges from gpio-sim"
hil_expect_stat vsync_on_timer '==' 0 "vsync on the TE line at the end"
hil_expect_stat vsync_period_ns '>=' 10500000 "TE period"
hil_expect_stat vsync_period_ns '<=' 11700000 "TE period"
# Presents: one per vsync, a bounded share late.
hil_expect_one_present_per_vsync
hil_expect_stat vsyncs '>=' "$D * 90 * 0.9" "vsyncs served"
hil_expect_on_time
# Frames: received over USB, none rejected, the newest one shown.
hil_expect_stat frames_received '>=' "$D * 2" "host frames over USB"
hil_expect_stat frames_rejected '==' 0 "rejected host frames"
hil_expect_stat frames_dropped '<=' "$(hil_stat frames_received) * 0.1 + 1" "frames dropped unseen (newest frame not used)"
# IMU: samples at (most of) 1 kHz, no bad reports, no reconnects.
hil_expect_stat imu_samples '>=' "$D * 1000 * ${HIL_IMU_RATE_MIN:-0.2}" "IMU samples over hidraw"
hil_expect_stat imu_bad_reports '==' 0 "bad HID reports"
hil_expect_stat imu_reconnects '==' 0 "IMU reconnects"
hil_expect_stat imu_lost '==' 0 "IMU lost"
# Latency: the prediction target is vsync + 5.5 ms, so motion-to-photon is at least ~5 ms when the warp runs
# before its vsync; a p50 near 0 means the vsyncs being served are already in the past.
hil_expect_stat m2p_ms_p50 '>=' 4 "motion-to-photon p50 (vsync served late?)"
hil_expect_stat m2p_ms_p99 '<=' 40 "motion-to-photon p99"
hil_expect_stat frame_age_ms_p50 '>' 0 "frame age p50"
hil_expect_stat frame_age_ms_p50 '<=' 500 "frame age p50"
hil_pass
