#!/bin/sh
# SPDX-License-Identifier: MIT
# 01-nominal: the full real-driver board. IMU over hidraw (hil_uhid_imu on uhid) at 1 kHz, host frames over USB
# (FunctionFS gadget on dummy_hcd, hmdwarp-feed as the host) at 30 Hz, TE edges from gpio-sim (hil_te) at 90 Hz.
# Asserts: TE edges reach hmdwarpd and it stays locked, one present per vsync and few late ones, the newest host
# frame shown (few dropped unseen), no rejects, IMU at rate without errors, motion-to-photon and frame age in
# bounds, and the run ends on time. Checks hold on any load (every device path carries data, counts and
# causes add up, no crash); rates, misses and latency are timing targets, reported (README "What the scenarios
# judge"). Then, with the head still, the panel image shown through the real drivers equals the in-process
# simulated board's, byte for byte. Last, the USB link compressed (JPEG colour, zstd depth): received, all
# compressed, none rejected.
# hil-timeout: 420
. /hil/scenarios/lib.sh
D=${HIL_NOMINAL_S:-10}

hil_uhid
# the devices play until hil-run's cleanup stops them
hil_imu_start --duration 900 --trace slow
hil_gpio_sim hil01 1
hil_te_start --rate 90 --duration 900
hil_usb_udc
# D seconds and on until every device path has carried its share of data (a starved VM takes longer)
hil_gadget_start --config "$(hil_board hid-usb-gpio)" --duration 0 --set "vsync.chip=$HIL_GPIO_CHIP"
hil_feed_usb --rate 30
hil_run_until "$D" 150 frames_received 20 imu_samples 1000 vsync_edges 100 vsyncs 100
kill "$HIL_FEED_PID" 2>/dev/null; wait "$HIL_FEED_PID" 2>/dev/null
tail -n 3 "$HIL_WORK/feed.log"
hil_gadget_stop
grep -v '^frames_rejected_\|^psnr\|^ssim' "$HIL_STATS"

hil_expect_backends hid/usb/gpio ||
    hil_miss "backends $(hil_stat imu_backend)/$(hil_stat frames_backend)/$(hil_stat vsync_backend), expected hid/usb/gpio"
# Vsync: the TE line drove the display (edges seen, locked at the end, ~90 Hz: the estimator's period within
# 15 % on any load, within 5 % a target).
RUN_S=$(hil_stat run_s)
hil_expect_stat vsync_edges '>=' 100 "TE edges from gpio-sim"
hil_target vsync_edges '>=' "$RUN_S * 90 * 0.5" "TE edge rate"
hil_expect_locked "vsync on the TE line"
hil_expect_stat vsync_period_ns '>=' 9500000 "TE period"
hil_expect_stat vsync_period_ns '<=' 12800000 "TE period"
hil_target vsync_period_ns '>=' 10500000 "TE period"
hil_target vsync_period_ns '<=' 11700000 "TE period"
# Presents: one per vsync, a bounded share late.
hil_expect_one_present_per_vsync
hil_expect_stat vsyncs '>=' 100 "vsyncs served"
hil_target vsyncs '>=' "$RUN_S * 90 * 0.9" "vsync rate"
hil_expect_on_time
# Frames: received over USB, none rejected, the newest one shown.
hil_expect_stat frames_received '>=' 20 "host frames over USB"
hil_target frames_received '>=' "$RUN_S * 2" "host frame rate"
hil_expect_stat frames_rejected '==' 0 "rejected host frames"
hil_expect_stat frames_shown '>=' 1 "host frames shown"
hil_expect_usb_speed
hil_target frames_dropped '<=' "$(hil_stat frames_received) * 0.1 + 1" "frames dropped unseen (newest frame not used)"
# IMU: samples over hidraw (at most of 1 kHz: a target), no bad reports, no reconnects.
hil_expect_stat imu_samples '>=' 1000 "IMU samples over hidraw"
hil_target imu_samples '>=' "$RUN_S * 1000 * ${HIL_IMU_RATE_MIN:-0.2}" "IMU sample rate"
hil_expect_stat imu_bad_reports '==' 0 "bad HID reports"
hil_expect_stat imu_reconnects '==' 0 "IMU reconnects"
hil_expect_stat imu_lost '==' 0 "IMU lost"
# Latency (targets): the prediction target is vsync + 5.5 ms, so motion-to-photon is at least ~5 ms when the warp
# runs before its vsync; a p50 near 0 means the vsyncs being served are already in the past.
hil_target m2p_ms_p50 '>=' 4 "motion-to-photon p50 (vsync served late?)"
hil_target m2p_ms_p99 '<=' 40 "motion-to-photon p99"
hil_expect_stat m2p_ms_p50 '>' 0 "motion-to-photon measured"
hil_expect_stat frame_age_ms_p50 '>' 0 "frame age p50"
# The age is mostly the host's: hmdwarp-feed shares the VM's two CPUs with everything at normal priority, and in a
# slow stretch (a busy host machine: 7.5 frames/s once in CI) its pose reader falls behind and renders for poses up
# to a second old; beyond 1.5 s the pose loop itself is broken.
hil_target frame_age_ms_p50 '<=' 1500 "frame age p50"

# Same inputs, same picture. With the head still (no IMU noise or bias), the real-driver board and the simulated
# board in-process warp the same scene rendered at the same eye poses, so their panel images must agree byte for
# byte: nothing on the real path (hidraw reports, FunctionFS and framelink, TE edges) changes what is shown.
hil_log "--- same inputs: real drivers vs in-process"
kill "$HIL_IMU_PID" 2>/dev/null; wait "$HIL_IMU_PID" 2>/dev/null
hil_imu_start --duration 900 --trace still --gyro-noise 0 --gyro-bias 0,0,0 --accel-noise 0
mkdir -p "$HIL_WORK/real" "$HIL_WORK/inproc"
# Each run lasts until it has shown 20 host frames and then 100 more vsyncs (two more raw images), however slowly.
same_inputs_wait() {
    hil_live_wait 120 frames_shown 20
    hil_live_wait 60 vsyncs "$(( $(hil_live_now vsyncs) + 100 ))"
    hil_hmdwarpd_stop 30
}
hil_gadget_start --config "$(hil_board hid-usb-gpio)" --duration 0 --set "vsync.chip=$HIL_GPIO_CHIP" \
    --set sim.trace=still --set display.sink=raw --set display.sink_every=45 --set "display.sink_path=$HIL_WORK/real" \
    --set "telemetry.live_stats=$HIL_LIVE"
# raw frames: the comparison is byte for byte with the in-process board's (the feed's auto would send JPEG on USB)
hil_feed_usb --rate 30 --color-codec raw --depth-codec raw --other-codec raw
same_inputs_wait
kill "$HIL_FEED_PID" 2>/dev/null; wait "$HIL_FEED_PID" 2>/dev/null
hil_gadget_stop
hil_expect_stat frames_shown '>=' 20 "same inputs: host frames shown by the real-driver board"
hil_log "same inputs: real-driver orientation $(hil_stat orientation_w) $(hil_stat orientation_x) $(hil_stat orientation_y) $(hil_stat orientation_z)"
hil_hmdwarpd --config "$(hil_board hid-usb-gpio)" --duration 0 --set imu.backend=sim --set frames.backend=sim \
    --set vsync.backend=sim --set sim.trace=still --set sim.gyro_noise=0 --set "sim.gyro_bias=0 0 0" \
    --set sim.accel_noise=0 --set display.sink=raw --set display.sink_every=45 --set "display.sink_path=$HIL_WORK/inproc" \
    --set "telemetry.live_stats=$HIL_LIVE"
same_inputs_wait
# the last panel image of each run (the raw sink appends RGBA8 images of the panel's size)
pw=128; ph=64; [ "${HIL_PANEL:-small}" = small ] || { pw=640; ph=360; }
cmp=$(hil_imgcmp "$HIL_WORK/real/frames.rgba" "$HIL_WORK/inproc/frames.rgba" "$pw" "$ph" 2>&1)
hil_log "same inputs: $cmp"
psnr=$(echo "$cmp" | sed -n 's/^psnr=\([^ ]*\) .*/\1/p')
hil_note same_inputs_psnr "${psnr:-missing}"
case "$psnr" in
    inf) ;;
    "") hil_miss "same inputs: no comparison ($cmp)" ;;
    *) hil_cmp "$psnr" '>=' "${HIL_SAME_PSNR_MIN:-45}" || hil_miss "same inputs: real-driver vs in-process panel $cmp (expected >= ${HIL_SAME_PSNR_MIN:-45} dB)" ;;
esac

# Compressed (framelink v2): the same USB link with the feed's codecs on auto, as libhmdwarp-host starts: the board
# (codecs = auto) announces what it decodes in its camera message, the host picks JPEG colour and zstd depth from
# it, and the board decodes on its frames thread. Frames arrive, all compressed, none rejected, and are shown.
hil_log "--- compressed: codecs negotiated (auto: JPEG colour, zstd depth) over FunctionFS"
hil_gadget_start --config "$(hil_board hid-usb-gpio)" --duration 0 --set "vsync.chip=$HIL_GPIO_CHIP"
hil_feed_usb --rate 30
hil_run_until "$D" 150 frames_received 20 frames_link_compressed_frames 20
kill "$HIL_FEED_PID" 2>/dev/null; wait "$HIL_FEED_PID" 2>/dev/null
tail -n 3 "$HIL_WORK/feed.log"
hil_gadget_stop
grep '^frames_\|^psnr' "$HIL_STATS"
hil_expect_stat frames_received '>=' 20 "compressed: host frames over USB"
hil_expect_stat frames_link_compressed_frames '>=' 20 "compressed: frames that came compressed"
hil_expect_stat frames_link_compressed_frames '>=' "$(hil_stat frames_received)" "compressed: every frame"
hil_expect_stat frames_rejected '==' 0 "compressed: rejected host frames"
hil_expect_stat frames_link_codec_errors '==' 0 "compressed: codec errors"
hil_expect_stat frames_shown '>=' 1 "compressed: host frames shown"
hil_expect_stat frames_link_compression '>' 1 "compressed: plane bytes per wire byte"
# The hidden-area mask (issue #20) crosses the real FunctionFS link behind the camera message, and the host library
# hands it to the feed, which says how many vertices per eye it received.
hil_expect_stat frames_link_masks_sent '>=' 1 "visibility mask messages sent"
grep -q "visibility mask [1-9][0-9]* + [1-9][0-9]* vertices" "$HIL_WORK/feed.log" ||
    hil_miss "the feed received no visibility mask: $(grep 'visibility mask' "$HIL_WORK/feed.log")"
hil_note compressed_decode_ms_p50 "$(hil_stat frames_link_decode_ms_p50)"
hil_pass
