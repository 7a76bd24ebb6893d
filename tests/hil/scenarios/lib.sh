# SPDX-License-Identifier: MIT
# lib.sh: helpers for HIL scenarios (sourced inside the test VM: . /hil/scenarios/lib.sh).
# Kernel mock devices (modules, i2c-stub, gpio-sim, vivid, the FunctionFS gadget), hmdwarpd runs, stats checks.
# A scenario ends with hil_pass; hil_fail REASON (or any failed hil_expect*) ends it with that reason.

HIL_NAME=${HIL_NAME:-adhoc}
HIL_REASON=${HIL_REASON:-/tmp/hil/$HIL_NAME.reason}
HIL_BOARDS=${HIL_BOARDS:-/hil/boards}
HIL_WORK=/tmp/hil/$HIL_NAME.d
mkdir -p "$HIL_WORK" "$(dirname "$HIL_REASON")"
CFS=/sys/kernel/config
FFS_DIR=/dev/ffs-hmdwarp

hil_log() { echo "[$HIL_NAME $(cut -d' ' -f1 /proc/uptime)] $*"; }

# hil_fail REASON: record the reason (hil-run prints it on the scenario's line) and end the scenario.
hil_fail() {
    echo "$*" >>"$HIL_REASON"
    hil_log "FAIL: $*"
    hil_on_fail 2>/dev/null
    exit 1
}
# Scenarios may redefine this to dump extra state (logs) on failure.
hil_on_fail() { :; }

# hil_miss REASON: record a failed check and carry on (the remaining checks still report); hil_pass then fails.
hil_miss() {
    echo "$*" >>"$HIL_REASON"
    hil_log "CHECK FAILED: $*"
}

hil_pass() {
    if [ -s "$HIL_REASON" ]; then hil_on_fail 2>/dev/null; exit 1; fi
    echo "hil-ok: $HIL_NAME"
    exit 0
}

# hil_note KEY VALUE: keep a measured value in the log in a fixed form (README "timings").
hil_note() { echo "hil-note: $HIL_NAME: $1=$2"; }

# Timing targets. A check that depends on how much CPU the VM gets (rates per wall second, misses, latency,
# recovery in wall seconds) is a target, not a pass/fail check: a busy host (a build beside `make test`) takes the
# vCPUs away, and the guest, which counts that time as its own, cannot tell. hil_target records every target with
# its measured value in /tmp/hil/NAME.targets ("met" or "missed" lines) and a hil-target: line in the log; hil-run
# prints the missed ones after the scenario's line and a total at the end, and the scenario still passes.
# HIL_STRICT=1 (a quiet host measuring the targets) turns a missed target into a failed check.
HIL_TARGETS=${HIL_TARGETS:-/tmp/hil/$HIL_NAME.targets}
# hil_target_cmp VALUE OP BOUND NAME WHY: a target on a value measured by the scenario.
hil_target_cmp() {
    if hil_cmp "$1" "$2" "$3"; then
        echo "met $4=$1 ($2 $3)" >>"$HIL_TARGETS"; return 0
    fi
    echo "missed $4=${1:-missing} ($2 $3): $5" >>"$HIL_TARGETS"
    echo "hil-target: $HIL_NAME: $5: $4=${1:-missing}, target $2 $3"
    [ "${HIL_STRICT:-0}" = 1 ] && hil_miss "$5 (HIL_STRICT=1): $4=${1:-missing}, target $2 $3"
    return 1
}
# hil_target KEY OP VALUE WHY: hil_expect_stat's form, as a target.
hil_target() {
    v=$(hil_stat "$1")
    hil_note "$1" "${v:-missing}"
    hil_target_cmp "$v" "$2" "$3" "$1" "${4:-target}"
}

# hil_expect DESCRIPTION COMMAND...: fail with DESCRIPTION unless COMMAND succeeds.
hil_expect() {
    d=$1; shift
    "$@" || hil_fail "$d"
}

# Floating-point comparison: hil_cmp A OP B with OP one of < <= > >= == !=.
hil_cmp() { awk -v a="$1" -v b="$3" -v op="$2" 'function ev(x,  n, t, i, r) {
        # a tiny evaluator for "N", "N * M", "N * M + K" (bounds written in terms of measured values)
        n = split(x, t, " "); r = t[1] + 0
        for (i = 2; i < n; i += 2) { if (t[i] == "*") r *= t[i+1]; else if (t[i] == "+") r += t[i+1]; else if (t[i] == "-") r -= t[i+1]; else if (t[i] == "/") r /= t[i+1] }
        return r }
    BEGIN {
    if (a == "" || b == "" || a == "nan" || b == "nan") exit 1
    a = ev(a); b = ev(b)
    if (op == "<") exit !(a < b); if (op == "<=") exit !(a <= b); if (op == ">") exit !(a > b)
    if (op == ">=") exit !(a >= b); if (op == "==") exit !(a == b); if (op == "!=") exit !(a != b); exit 1 }'; }

# --- modules ---------------------------------------------------------------------------------------------------

# hil_modprobe NAME [PARAM=VALUE...]: load a module with parameters; fails the scenario with dmesg's tail.
hil_modprobe() {
    if ! out=$(modprobe "$@" 2>&1); then
        dmesg | tail -n 15
        hil_fail "modprobe $*: $out"
    fi
}
# hil_rmmod NAME...: unload modules that are loaded (ignores ones that are not).
hil_rmmod() {
    for m in "$@"; do
        m=$(echo "$m" | tr - _)
        grep -q "^$m " /proc/modules && rmmod "$m" 2>/dev/null
    done
    return 0
}

# hil_wait_for PATH [TIMEOUT_S]: wait until PATH exists (devtmpfs nodes appear asynchronously).
hil_wait_for() {
    i=0; lim=$(( ${2:-10} * 10 ))
    while [ ! -e "$1" ]; do
        i=$((i + 1)); [ "$i" -le "$lim" ] || return 1
        sleep 0.1
    done
}
# hil_wait_until TIMEOUT_S COMMAND...: poll COMMAND every 0.1 s until it succeeds.
hil_wait_until() {
    lim=$(( $1 * 10 )); shift; i=0
    until "$@"; do
        i=$((i + 1)); [ "$i" -le "$lim" ] || return 1
        sleep 0.1
    done
}

# hil_device PROGRAM ARGS...: run a device stand-in (hil_uhid_imu, hil_i2c_chip, hil_te) at SCHED_FIFO 40. They
# play hardware, which neither delays the board nor is delayed by it. At normal priority the VM's scheduler holds
# the IMU's reports back behind the host feeder's rendering (motion-to-photon grows by tens of ms); above
# hmdwarpd's threads (50, 49) they take the CPU from its compositor (the I2C chip's 1 kHz register traffic costs
# a TCG guest several syscalls a tick). Just below them, they run whenever hmdwarpd's real-time threads sleep.
# Called in the background (hil_device PROG ... &): exec, so that $! is the program's own pid (a scenario that
# kills $! must reach the program, not a subshell that leaves it running).
hil_device() { exec chrt -f 40 "$@"; }

# hil_uhid: uhid plus hid-generic, which binds the created devices (no udevd here to load it from the modalias).
hil_uhid() {
    hil_modprobe uhid
    hil_modprobe hid-generic
    hil_wait_for /dev/uhid 5 || hil_fail "uhid: no /dev/uhid"
}

# hil_imu_start ARGS...: hil_uhid_imu in the background (HIL_IMU_PID); waits for its hidraw node (HIL_HIDRAW).
hil_imu_start() {
    rm -f "$HIL_WORK/imu.ready"
    hil_device hil_uhid_imu --ready-file "$HIL_WORK/imu.ready" "$@" >"$HIL_WORK/imu.log" 2>&1 &
    HIL_IMU_PID=$!
    hil_wait_until 15 grep -q '^state=ready' "$HIL_WORK/imu.ready" 2>/dev/null ||
        { cat "$HIL_WORK/imu.log"; hil_fail "hil_uhid_imu: no hidraw device ($(tail -n 1 "$HIL_WORK/imu.log"))"; }
    HIL_HIDRAW=$(sed -n 's/^hidraw=//p' "$HIL_WORK/imu.ready")
    hil_log "imu: uhid device at $HIL_HIDRAW"
}

# hil_te_start ARGS...: hil_te playing 90 Hz TE pulses on the gpio-sim line HIL_GPIO_CHIP/0 (HIL_TE_PID).
hil_te_start() {
    rm -f "$HIL_WORK/te.ready"
    # above everything of hmdwarpd's (a panel's TE is hardware, which the board cannot delay; two writes a period,
    # unlike the IMU stand-ins' 1 kHz traffic): at hil_device's 40 a busy host's VM woke it more than 5 ms late
    # for 85 % of its pulses (hmdwarpd's real-time threads first), at 70 for 48 %
    chrt -f 70 hil_te --chip "$HIL_GPIO_CHIP" --line 0 --ready-file "$HIL_WORK/te.ready" "$@" >"$HIL_WORK/te.log" 2>&1 &
    HIL_TE_PID=$!
    # (state=running once a second after that, with its counts)
    hil_wait_until 10 grep -qE '^state=(ready|running)' "$HIL_WORK/te.ready" 2>/dev/null ||
        { cat "$HIL_WORK/te.log"; hil_fail "hil_te: line $HIL_GPIO_CHIP/0 not ready ($(tail -n 1 "$HIL_WORK/te.log"))"; }
}

# --- I2C: i2c-stub ---------------------------------------------------------------------------------------------

# hil_i2c_stub [ADDR]: load i2c-dev and i2c-stub with a chip at ADDR (default 0x68); prints /dev/i2c-N.
hil_i2c_stub() {
    hil_modprobe i2c-dev
    hil_modprobe i2c-stub "chip_addr=${1:-0x68}"
    for d in /sys/bus/i2c/devices/i2c-*; do
        if [ "$(cat "$d/name" 2>/dev/null)" = "SMBus stub driver" ]; then
            n=${d##*/i2c-}
            hil_wait_for "/dev/i2c-$n" 5 || hil_fail "i2c-stub bus i2c-$n has no /dev/i2c-$n"
            echo "/dev/i2c-$n"; return 0
        fi
    done
    hil_fail "i2c-stub loaded but no 'SMBus stub driver' bus in /sys/bus/i2c/devices"
}

# --- GPIO: gpio-sim --------------------------------------------------------------------------------------------

# hil_gpio_sim NAME [NUM_LINES]: create a live gpio-sim chip through configfs. Sets HIL_GPIO_CHIP (gpiochipN)
# and HIL_GPIO_DEV (platform device name); hil_gpio_pull LINE prints that line's sysfs `pull` path.
hil_gpio_sim() {
    grep -q '^gpio_sim ' /proc/modules || hil_modprobe gpio-sim
    g=$CFS/gpio-sim/$1
    [ -d "$CFS/gpio-sim" ] || hil_fail "gpio-sim loaded but $CFS/gpio-sim missing (configfs mounted?)"
    mkdir "$g" "$g/bank0" || hil_fail "cannot create gpio-sim chip $1 in configfs"
    echo "${2:-1}" >"$g/bank0/num_lines"
    echo 1 >"$g/live" || hil_fail "gpio-sim chip $1 did not go live (dmesg: $(dmesg | tail -n 2 | tr '\n' ' '))"
    HIL_GPIO_CHIP=$(cat "$g/bank0/chip_name")
    HIL_GPIO_DEV=$(cat "$g/dev_name")
    [ -n "$HIL_GPIO_CHIP" ] || hil_fail "gpio-sim chip $1 has no chip_name"
    hil_wait_for "/dev/$HIL_GPIO_CHIP" 5 || hil_fail "no /dev/$HIL_GPIO_CHIP for gpio-sim chip $1"
}
hil_gpio_pull() { echo "/sys/devices/platform/$HIL_GPIO_DEV/$HIL_GPIO_CHIP/sim_gpio${1:-0}/pull"; }
hil_gpio_sim_remove() {
    g=$CFS/gpio-sim/$1
    [ -d "$g" ] || return 0
    echo 0 >"$g/live" 2>/dev/null
    rmdir "$g/bank0" "$g" 2>/dev/null
    return 0
}

# --- V4L2: vivid loop ------------------------------------------------------------------------------------------

# hil_vivid: load vivid with one capture and one output node; sets HIL_VID_CAP and HIL_VID_OUT (/dev/videoN).
hil_vivid() {
    grep -q '^vivid ' /proc/modules || hil_modprobe vivid n_devs=1 node_types=0x101
    HIL_VID_CAP=; HIL_VID_OUT=
    for d in /sys/class/video4linux/video*; do
        case "$(cat "$d/name")" in
            *vid-cap*) HIL_VID_CAP=/dev/${d##*/} ;;
            *vid-out*) HIL_VID_OUT=/dev/${d##*/} ;;
        esac
    done
    [ -n "$HIL_VID_CAP" ] && [ -n "$HIL_VID_OUT" ] || hil_fail "vivid: no vid-cap/vid-out nodes ($(ls /sys/class/video4linux | tr '\n' ' '))"
    hil_wait_for "$HIL_VID_CAP" 5 && hil_wait_for "$HIL_VID_OUT" 5 || hil_fail "vivid nodes missing in /dev"
}
# hil_vivid_loop [FOURCC]: both sides on HDMI with the same DV timings (640x480p59.94, vivid's first preset, which
# the in-band layout of 320x360 eyes fits: 640x374) and the same format, OSD off, loop on: what is written to the
# output comes back on the capture byte for byte. Sets HIL_VID_W and HIL_VID_H.
hil_vivid_loop() {
    fcc=${1:-YUYV}
    v4l2-ctl -d "$HIL_VID_CAP" -i 3 >/dev/null || hil_fail "vivid: cannot select capture input 3 (HDMI)"
    v4l2-ctl -d "$HIL_VID_OUT" -o 1 >/dev/null || hil_fail "vivid: cannot select output 1 (HDMI)"
    for d in "$HIL_VID_CAP" "$HIL_VID_OUT"; do
        v4l2-ctl -d "$d" --set-dv-bt-timings index=0 >/dev/null || hil_fail "vivid: $d rejects DV timings preset 0"
    done
    HIL_VID_W=640; HIL_VID_H=480
    v4l2-ctl -d "$HIL_VID_OUT" --set-fmt-video-out="width=640,height=480,pixelformat=$fcc" >/dev/null || hil_fail "vivid: output format"
    v4l2-ctl -d "$HIL_VID_CAP" --set-fmt-video="width=640,height=480,pixelformat=$fcc" >/dev/null || hil_fail "vivid: capture format"
    v4l2-ctl -d "$HIL_VID_CAP" --set-ctrl=osd_text_mode=2 >/dev/null || hil_fail "vivid: cannot set OSD Text Mode = None"
    v4l2-ctl -d "$HIL_VID_CAP" --set-ctrl=loop_video=1 >/dev/null || hil_fail "vivid: cannot turn Loop Video on"
}

# --- KMS: vkms -------------------------------------------------------------------------------------------------

# hil_vkms: load vkms (out-of-tree, kmod/) without fbdev emulation, so the CRTC stays off until a KMS client
# commits and no fbcon cursor blinks into the CRCs between runs. Sets HIL_DRI_CARD (/dev/dri/cardN), HIL_DRI_DEBUG
# (its debugfs folder: crtc-0/crc/{control,data}) and HIL_DRI_CONN (the connector's sysfs folder: status, modes).
hil_vkms() {
    if ! grep -q '^drm_kms_helper ' /proc/modules; then
        hil_modprobe drm_kms_helper fbdev_emulation=0
    else
        echo N >/sys/module/drm_kms_helper/parameters/fbdev_emulation
    fi
    grep -q '^vkms ' /proc/modules || hil_modprobe vkms
    HIL_DRI_CARD=; HIL_DRI_CONN=
    for d in /sys/class/drm/card[0-9]*; do
        case "$d" in *-*) continue ;; esac        # connectors are card0-Virtual-1, ...
        # vkms registers a bare platform device named vkms (no driver binds it)
        [ "$(basename "$(readlink -f "$d/device")")" = vkms ] || continue
        HIL_DRI_CARD=/dev/dri/${d##*/}
        HIL_DRI_DEBUG=/sys/kernel/debug/dri/${d##*/card}
        HIL_DRI_CONN=$(ls -d "$d"-Virtual-* 2>/dev/null | head -n 1)
    done
    [ -n "$HIL_DRI_CARD" ] || hil_fail "vkms loaded but no card in /sys/class/drm ($(ls /sys/class/drm | tr '\n' ' '))"
    hil_wait_for "$HIL_DRI_CARD" 5 || hil_fail "vkms: no $HIL_DRI_CARD node"
    [ -n "$HIL_DRI_CONN" ] || hil_fail "vkms: no Virtual connector under /sys/class/drm"
    # Nothing has probed the connector yet (no fbdev, no client): status "unknown", no modes until a detect.
    echo detect >"$HIL_DRI_CONN/status"
}
# hil_vkms_crc_on / hil_vkms_crc_off: capture CRCs of what the CRTC shows. With the "auto" source in crc/control,
# vkms composes the planes at every vblank and CRCs the result for as long as crc/data is open (opening it starts
# capture, closing it stops it): a background reader keeps it open, and hil_vkms_crc_off leaves the lines
# "0xFRAME 0xCRC" in $HIL_WORK/crc.txt. Start it after the client's modeset (the DRM CRC ABI: a modeset may reset
# capture). Each read of crc/data returns one line plus its C string's NUL, which busybox's text tools would
# take for the line's end: crc.raw keeps them, crc.txt not.
# The reader's pid is kept in a file for hil_cleanup: a read blocked in crc/data (the CRTC off, no more entries)
# holds debugfs's removal, so rmmod vkms would hang until it is gone.
HIL_CRC_PIDFILE=/tmp/hil/crc-reader.pid
hil_vkms_crc_on() {
    c=$HIL_DRI_DEBUG/crtc-0/crc
    [ -e "$c/control" ] || hil_fail "vkms: no $c/control (debugfs mounted?)"
    echo auto >"$c/control" || hil_fail "vkms: CRC source auto refused"
    rm -f "$HIL_WORK/crc.txt"
    cat "$c/data" >"$HIL_WORK/crc.raw" 2>"$HIL_WORK/crc.err" &
    echo $! >"$HIL_CRC_PIDFILE"
}
# hil_vkms_crc_count: CRC lines captured so far; hil_vkms_crc_has N: at least N (for hil_wait_until).
hil_vkms_crc_count() { tr -d '\000' <"$HIL_WORK/crc.raw" 2>/dev/null | grep -c '^0x'; }
hil_vkms_crc_has() { [ "$(hil_vkms_crc_count)" -ge "$1" ]; }
hil_vkms_crc_off() {
    [ -s "$HIL_CRC_PIDFILE" ] || return 0
    pid=$(cat "$HIL_CRC_PIDFILE"); rm -f "$HIL_CRC_PIDFILE"
    kill "$pid" 2>/dev/null; wait "$pid" 2>/dev/null
    tr -d '\000' <"$HIL_WORK/crc.raw" | grep '^0x' >"$HIL_WORK/crc.txt"
}

# hil_vkms_vblank_stress N W H: N cycles of vkms's vblank turned on from one vCPU and off from the other, the
# reproducer of the deadlock kmod/patch.sh fixes (tests/hil/README.md, "The hang"): with a pattern shown (the
# CRTC on in its W x H mode, no client holding vblank references) and drm.vblankoffdelay=1, opening crc/data
# takes a vblank reference (the timer starts on this vCPU), the reader moves to the other vCPU and closes it (the
# reference dropped, vblank off a tick later there, from drm's vblank_disable_fn). Unpatched vkms hung the VM
# within 250 cycles (2 runs of 2); patched, a disable that meets the callback is logged and counted
# (vkms_vblank_disable_races). ~5 cycles a second.
hil_vkms_vblank_stress() {
    c=$HIL_DRI_DEBUG/crtc-0/crc
    hil_kms_crc pattern "$2" "$3" >"$HIL_WORK/stress.rgba" || hil_fail "hil_kms_crc pattern failed"
    hil_kms_crc show "$HIL_DRI_CARD" "$HIL_WORK/stress.rgba" "$2" "$3" 3600 >"$HIL_WORK/stress-show.log" 2>&1 &
    spid=$!
    hil_wait_until 10 grep -q '^shown=' "$HIL_WORK/stress-show.log" || hil_fail "vkms stress: no mode set"
    od=$(cat /sys/module/drm/parameters/vblankoffdelay)
    echo 1 >/sys/module/drm/parameters/vblankoffdelay
    echo auto >"$c/control" || hil_fail "vkms: CRC source auto refused"
    i=0
    while [ "$i" -lt "$1" ]; do
        # a varying hold, so the disable falls at every phase of the vblank period
        taskset -c $((i % 2)) sh -c "exec 3<$c/data; taskset -p -c $(((i + 1) % 2)) \$\$ >/dev/null; sleep 0.0$((i % 10)); exec 3<&-" 2>/dev/null
        i=$((i + 1))
    done
    echo "$od" >/sys/module/drm/parameters/vblankoffdelay
    kill "$spid" 2>/dev/null; wait "$spid" 2>/dev/null
    hil_note vkms_stress_cycles "$i"
}

# --- USB: dummy_hcd + FunctionFS gadget ------------------------------------------------------------------------

# hil_usb_udc: load dummy_hcd (one UDC, dummy_udc.0) and usbfs-visible host side, at HIL_USB_SPEED: super-speed
# by default (is_super_speed=1: a USB 3 root hub beside the USB 2 one, so the gadget's SuperSpeed descriptors are
# the ones used), high-speed as before with HIL_USB_SPEED=high-speed. hil_expect_usb_speed checks what the board saw.
HIL_USB_SPEED=${HIL_USB_SPEED:-super-speed}
hil_usb_udc() {
    if [ "$HIL_USB_SPEED" = super-speed ]; then hil_modprobe dummy_hcd is_super_speed=1
    else hil_modprobe dummy_hcd; fi
    hil_modprobe libcomposite
    hil_modprobe usb_f_fs
    hil_wait_for /sys/class/udc/dummy_udc.0 5 || hil_fail "dummy_hcd loaded but no dummy_udc.0"
}
# hil_gadget_start HMDWARPD_ARGS...: board/gadget.sh builds the configfs gadget and mounts FunctionFS; hmdwarpd
# (run by us, so its exit status is ours: HIL_HMD_PID) writes the descriptors; gadget.sh then binds dummy_udc.0.
hil_gadget_start() {
    gadget.sh --udc dummy_udc.0 --no-daemon --wait 60 --ffs-dir "$FFS_DIR" start >"$HIL_WORK/gadget.log" 2>&1 &
    gpid=$!
    hil_wait_for "$FFS_DIR/ep0" 20 || { cat "$HIL_WORK/gadget.log"; hil_fail "gadget.sh: no FunctionFS ep0 in $FFS_DIR"; }
    hil_hmdwarpd "$@" --set frames.backend=usb --set "frames.device=$FFS_DIR"
    if ! wait "$gpid"; then
        cat "$HIL_WORK/gadget.log"; tail -n 20 "$HIL_HMD_LOG" | sed 's/^/  hmdwarpd| /'
        hil_fail "gadget.sh start failed: $(tail -n 1 "$HIL_WORK/gadget.log")"
    fi
    hil_log "$(tail -n 1 "$HIL_WORK/gadget.log")"
}
# hil_feed_usb ARGS...: hmdwarp-feed over USB (HIL_FEED_PID), started once the host side has enumerated the
# gadget: hmdwarp-feed calls libusb_init once and then retries libusb_open_device_with_vid_pid, and without udevd
# libusb gets no hotplug events, so a device that enumerates after its libusb_init is never seen. It runs until the
# scenario kills it: no --duration, which a starved VM's waits could outlast (make test-busy once ran 03's 200 s
# feed out before its USB replug, which then saw no frames come again).
hil_feed_usb() {
    hil_wait_until 20 sh -c 'grep -qx 0104 /sys/bus/usb/devices/*/idProduct 2>/dev/null' ||
        hil_fail "dummy_hcd host side never enumerated the gadget (no 1d6b:0104 in /sys/bus/usb/devices)"
    hmdwarp-feed --eye "$HIL_EYE" --wait 30 "$@" >"$HIL_WORK/feed.log" 2>&1 &
    HIL_FEED_PID=$!
}
# hil_feed_state: "running" or "ended" (hmdwarp-feed, for a miss's message: a feed that ended sends nothing more).
hil_feed_state() {
    if kill -0 "$HIL_FEED_PID" 2>/dev/null; then echo running; else echo ended; fi
}
# hil_expect_usb_speed: the board's stats name the speed dummy_hcd was loaded for (the speed the host negotiated,
# read from the UDC's current_speed when the host enabled the function).
hil_expect_usb_speed() {
    v=$(hil_stat frames_link_usb_speed)
    hil_note frames_link_usb_speed "${v:-missing}"
    [ "$v" = "$HIL_USB_SPEED" ] || hil_miss "stats: frames_link_usb_speed=${v:-missing}, expected $HIL_USB_SPEED"
}
hil_gadget_stop() { gadget.sh --ffs-dir "$FFS_DIR" stop >>"$HIL_WORK/gadget.log" 2>&1; }

# --- hmdwarpd --------------------------------------------------------------------------------------------------

# hil_hmdwarpd ARGS...: start hmdwarpd in the background with --stats $HIL_STATS and its log in $HIL_HMD_LOG.
HIL_STATS=$HIL_WORK/stats.txt
HIL_LIVE=$HIL_WORK/live.txt   # the live stats (telemetry.live_stats), rewritten each second: hil_live_wait
HIL_CSV=$HIL_WORK/vsync.csv   # one row per vsync (telemetry.csv): recovery times are measured from it
HIL_HMD_LOG=$HIL_WORK/hmdwarpd.log
# The panel defaults to HIL_PANEL=small: TCG runs the warp ~50x slower than the host, so the boards' 640x360 panel
# cannot keep 90 Hz in the VM; 128x64 (64x64 eyes) can. HIL_PANEL=board keeps the board file's size.
HIL_EYE=64x64
[ "${HIL_PANEL:-small}" = small ] || HIL_EYE=320x360    # tests/hil/boards' [eye]
hil_hmdwarpd() {
    rm -f "$HIL_STATS" "$HIL_CSV" "$HIL_LIVE"
    hil_log "hmdwarpd $*"
    if [ "${HIL_PANEL:-small}" = small ]; then
        set -- "$@" --set display.width=128 --set display.height=64 --set eye.width=64 --set eye.height=64 \
            --set lens.scale=32 --set "lens.center=33 32" --set lens.mesh=8
    fi
    HIL_HMD_T0=$(cut -d. -f1 /proc/uptime)
    # HIL_HMD_ARGS (kernel command line, via run.sh): extra hmdwarpd options for experiments, e.g.
    # HIL_HMD_ARGS=--set,vsync.backend=timer (commas for spaces).
    # shellcheck disable=SC2086
    hmdwarpd --stats "$HIL_STATS" --csv "$HIL_CSV" --set "telemetry.live_stats=$HIL_LIVE" "$@" $(echo "${HIL_HMD_ARGS:-}" | tr , ' ') >"$HIL_HMD_LOG" 2>&1 &
    HIL_HMD_PID=$!
}
# hil_run_until MIN_S CAP_S KEY N [KEY N...]: let a --duration 0 hmdwarpd run MIN_S seconds (a fault timeline's
# length), then on until every KEY in its live stats is >= N (CAP_S only guards against hangs), then stop it.
hil_run_until() {
    sleep "$1"; cap=$2; shift 2
    hil_live_wait "$cap" "$@"
    hil_live_wait_locked 60
    hil_hmdwarpd_stop 30
}
# hil_live_wait_locked CAP_S: while hmdwarpd's vsync source is a real line (gpio, kms) but it paces from its timer
# fallback, wait until it has relocked (vsync_on_timer=0), CAP_S seconds at most: on a busy machine the estimator
# can take longer than the run to gather the edges it locks on. HIL_LOCKED_SEEN says what the live stats showed:
# 1 paced from the line, 0 still on the timer after CAP_S, "none" for a source that is no line (hil_expect_locked).
hil_live_wait_locked() {
    unset HIL_LOCKED_SEEN; i=0
    hil_live_watch_locked
    while [ "$HIL_LOCKED_SEEN" = 0 ] && [ "$i" -lt $(($1 * 5)) ] && kill -0 "$HIL_HMD_PID" 2>/dev/null; do
        sleep 0.2; i=$((i + 1))
        hil_live_watch_locked
    done
}
# hil_live_watch_locked: one look of hil_live_wait_locked, for a scenario whose own loop runs beside hmdwarpd (04's
# soak): call it once per turn from a point after the line's last fault on; the first call starts the watch (its TE
# counts), each call records a lock the live stats show (vsync_on_timer=0) and where the TE player stands.
# hil_expect_locked judges it as it judges a wait: a lock seen any time after the fault, not only in the run's last
# second.
hil_live_watch_locked() {
    case "${HIL_LOCKED_SEEN:-}" in
    1 | none) return 0 ;;
    "") HIL_WAIT_TE0=$(hil_te_counts); HIL_LOCKED_SEEN=0
        case "$(hil_stat vsync_backend "$HIL_LIVE" 2>/dev/null)" in gpio | kms) ;; *) HIL_LOCKED_SEEN=none; return 0 ;; esac ;;
    esac
    [ "$(hil_stat vsync_on_timer "$HIL_LIVE" 2>/dev/null)" = 0 ] && HIL_LOCKED_SEEN=1
    HIL_WAIT_TE1=$(hil_te_counts)
}
# hil_te_counts: "PULSES DROPPED_LATE" of the TE player so far (its ready file, once a second), empty without one.
hil_te_counts() {
    awk -F= '$1 == "pulses" { p = $2 } $1 == "dropped_late" { d = $2 } END { if (p != "") print p + 0, d + 0 }' \
        "$HIL_WORK/te.ready" 2>/dev/null
}
# hil_te_wait_lockable: true when the TE player played at least HIL_TE_LOCKABLE of its pulses on time during the last
# hil_live_wait_locked (a relock needs that many edges then, whatever the line did before); notes the share.
hil_te_wait_lockable() {
    s=$(echo "$HIL_WAIT_TE0 $HIL_WAIT_TE1" | awk 'NF == 4 && ($3 - $1) + ($4 - $2) > 0 {
        printf "%.3f\n", ($3 - $1) / (($3 - $1) + ($4 - $2)) }')
    hil_note te_ontime_share_in_wait "${s:-unknown}"
    [ -n "$s" ] && hil_cmp "$s" '>=' "${HIL_TE_LOCKABLE:-0.6}"
}
# hil_te_ontime: the share of its pulses the TE player started on time so far (its ready file, once a second); the
# others the VM woke it too late for, and it dropped them (a panel's edge comes on time or not at all).
hil_te_ontime() {
    awk -F= '$1 == "pulses" { p = $2 } $1 == "dropped_late" { d = $2 }
        END { if (p + d > 0) printf "%.3f\n", p / (p + d); else print "" }' "$HIL_WORK/te.ready" 2>/dev/null
}
# hil_te_lockable: true when the TE player started at least HIL_TE_LOCKABLE (0.6) of its pulses on time: the
# estimator locks only on edges at 60 % of the vsyncs they span, as a panel at half the rate fits every other vsync
# (drivers/drv_vsync_est.c). Below that the line is no panel's, and whether hmdwarpd locks on it is a target, not a
# check (make test-busy: 16 % on time, beside a busy loop per core). Notes the share.
hil_te_lockable() {
    s=$(hil_te_ontime)
    hil_note te_ontime_share "${s:-unknown}"
    [ -n "$s" ] && hil_cmp "$s" '>=' "${HIL_TE_LOCKABLE:-0.6}"
}
# hil_kms_lockable: true when vkms delivered its vblanks at a lockable rate over the run (the stats file): at least
# HIL_TE_LOCKABLE (0.6) of the mode's 90 Hz, the share of the vsyncs the estimator locks on, as on the TE line. A
# starved VM runs vkms's hrtimer late (make test-busy beside six builds: 1651 vblanks in 46 s, 40 %, "vkms failure on
# handling vblank"), and the source then rightly stays on its timer. Notes the share.
hil_kms_lockable() {
    v=$(hil_stat kms_vblanks); t=$(hil_stat run_s)
    hil_note kms_vblank_share "$(awk -v v="$v" -v t="$t" 'BEGIN {
        if (v != "" && t > 0) printf "%.3f\n", v / (t * 90); else print "unknown" }')"
    [ -n "$t" ] && hil_cmp "$v" '>=' "$t * 90 * ${HIL_TE_LOCKABLE:-0.6}"
}
# hil_line_lockable: whether the vsync source's line was one to lock on (hil_expect_locked): the TE line during the
# last hil_live_wait_locked (hil_te_wait_lockable), vkms's vblanks over the run (hil_kms_lockable); any other, yes.
hil_line_lockable() {
    case "$(hil_stat vsync_backend)" in
    gpio) hil_te_wait_lockable ;;
    kms) hil_kms_lockable ;;
    *) true ;;
    esac
}
# hil_expect_te KEY OP VALUE WHY: hil_expect_stat on what needs a lock on the TE line (a fallback during its
# dropout, the lock at the end), judged while the TE player could play a lockable line, a target otherwise.
hil_expect_te() {
    if hil_te_lockable; then hil_expect_stat "$@"
    else hil_target "$@"
    fi
}
# hil_expect_locked WHY: the vsync source paced from its line (TE edges, vkms's vblanks) when hil_live_wait_locked
# looked, after the scenario's faults: the check. It is judged when the line was lockable (hil_line_lockable: a
# relock needs edges at 60 % of the vsyncs, which a starved VM's TE player may not play for a whole minute, make
# test-busy failed 03 so, its source having locked before; nor vkms's late hrtimer deliver); a target otherwise. That
# it did at the very end is a target: a starved VM can hold the player back for 3.5 periods at any moment, and the
# source then rightly falls back until the next edge (make test-busy ended 03 with vsync_on_timer=1).
hil_expect_locked() {
    hil_note vsync_locked_seen "${HIL_LOCKED_SEEN:-not waited for}"
    case "${HIL_LOCKED_SEEN:-}" in
    1 | none) ;;
    0) if hil_line_lockable; then
           hil_miss "$1: the vsync source stayed on its timer fallback all through hil_live_wait_locked"
       else
           hil_target_cmp 0 '==' 1 vsync_locked_seen "$1 (its line gave too few edges to lock on: hil_line_lockable)"
       fi ;;
    *) hil_miss "$1: hil_expect_locked without hil_live_wait_locked before it" ;;
    esac
    hil_target vsync_on_timer '==' 0 "$1, still at the end"
}
# hil_hmdwarpd_wait [TIMEOUT_S]: wait for hmdwarpd to end by itself (its --duration); fails on a crash, a
# non-zero exit, or a run without a stats file. Prints its log's last lines either way.
hil_hmdwarpd_wait() {
    lim=${1:-120}; i=0
    while kill -0 "$HIL_HMD_PID" 2>/dev/null; do
        i=$((i + 1))
        if [ "$i" -gt $((lim * 10)) ]; then
            kill "$HIL_HMD_PID"; sleep 1; kill -9 "$HIL_HMD_PID" 2>/dev/null
            tail -n 30 "$HIL_HMD_LOG"
            hil_fail "hmdwarpd still running after ${lim}s"
        fi
        sleep 0.1
    done
    wait "$HIL_HMD_PID"; rc=$?
    tail -n 40 "$HIL_HMD_LOG" | sed 's/^/  hmdwarpd| /'
    if [ "$rc" -ge 128 ]; then hil_fail "hmdwarpd crashed (signal $((rc - 128)))"; fi
    [ "$rc" -eq 0 ] || hil_fail "hmdwarpd exited with status $rc: $(grep -m1 -i 'error\|fail\|cannot' "$HIL_HMD_LOG")"
    [ -s "$HIL_STATS" ] || hil_fail "hmdwarpd wrote no stats file"
}
# hil_hmdwarpd_stop: SIGTERM (it writes its summary and stats), then the same checks as hil_hmdwarpd_wait.
hil_hmdwarpd_stop() {
    kill -TERM "$HIL_HMD_PID" 2>/dev/null
    hil_hmdwarpd_wait "${1:-20}"
}

# Runs that last until they have their data, not for a fixed time (a starved VM does less in a second): start
# hmdwarpd with --duration 0 (hil_hmdwarpd always writes the live stats to $HIL_LIVE, the --stats set rewritten
# each second), wait with hil_live_wait, then hil_hmdwarpd_stop; hil_run_until does all three.
# hil_live_wait CAP_S KEY N [KEY N...]: until every KEY in the live stats is >= N; fails (returns 1) after CAP_S
# seconds, a guard against hangs only, or when hmdwarpd has ended.
hil_live_wait() {
    lim=$(( $1 * 5 )); shift; i=0
    while :; do
        ok=1; a=$*
        set -- $a
        while [ $# -ge 2 ]; do
            v=$(hil_stat "$1" "$HIL_LIVE" 2>/dev/null)
            [ -n "$v" ] && hil_cmp "$v" '>=' "$2" || { ok=0; break; }
            shift 2
        done
        set -- $a
        [ "$ok" = 1 ] && return 0
        kill -0 "$HIL_HMD_PID" 2>/dev/null || return 1
        i=$((i + 1)); [ "$i" -le "$lim" ] || { hil_log "hil_live_wait: $* not reached"; return 1; }
        sleep 0.2
    done
}

# hil_live_now KEY: KEY's value in the live stats at their next rewrite (once a second), not the last one: a base for a
# relative wait ("+100 vsyncs") read from a file up to a second old would wait that many fewer vsyncs in fact.
# Any rewrite changes the file while hmdwarpd runs (its vsyncs count on); after 5 s, or once it has ended, the
# value as it stands.
hil_live_now() {
    hln0=$(cat "$HIL_LIVE" 2>/dev/null); hlni=0
    while [ "$hlni" -lt 25 ] && [ "$(cat "$HIL_LIVE" 2>/dev/null)" = "$hln0" ] && kill -0 "$HIL_HMD_PID" 2>/dev/null; do
        sleep 0.2; hlni=$((hlni + 1))
    done
    hil_stat "$1" "$HIL_LIVE"
}
# hil_stat KEY [FILE]: one value from a --stats file (key=value lines).
hil_stat() { sed -n "s/^$1=//p" "${2:-$HIL_STATS}" | head -n 1; }
# hil_expect_stat KEY OP VALUE [WHY]: check a stats value (VALUE may be "N * M + K"); a miss is recorded
# (hil_miss) and the scenario goes on, so one run reports every failed check, e.g. hil_expect_stat missed '<=' 2.
hil_expect_stat() {
    v=$(hil_stat "$1")
    hil_note "$1" "${v:-missing}"
    [ -n "$v" ] || { hil_miss "stats: no $1 in $HIL_STATS"; return 1; }
    hil_cmp "$v" "$2" "$3" || { hil_miss "${4:-stats}: $1=$v, expected $2 $3"; return 1; }
}
# hil_expect_one_present_per_vsync: every compositor pass presents once (a frame, a cleared image when no frame
# yet, or the previous image when no buffer is free), so the passes cannot outnumber the vsyncs; more passes
# than vsyncs mean the loop woke again for a vsync it had served.
hil_expect_one_present_per_vsync() {
    v=$(hil_stat vsyncs)
    # every method_* count (one per warp that ran), plus the passes that warped nothing
    m=$(awk -F= '/^method_/ { s += $2 } END { print s + 0 }' "$HIL_STATS")
    p=$(( m + $(hil_stat no_frame) + $(hil_stat no_buffer) ))
    hil_note presents "$p"
    hil_cmp "$p" '<=' "$v * 1.02 + 2" || hil_miss "compositor passes $p > vsyncs $v: more than one present per vsync (the loop spins on an already served vsync)"
}
# hil_expect_on_time [PREFIX]: presents are on time. hmdwarpd splits its misses by cause (missed_own: its own CPU
# work outran the time it planned; missed_late_wake / missed_descheduled: the VM's scheduler; missed_no_buffer).
# In a VM the guest counts time its vCPU thread was preempted on the host as CPU time, so on a busy host even
# "own" misses are the host's: the shares are targets (at most 2 + HIL_OWN_MAX = 0.02 of the vsyncs its own, all
# causes under HIL_MISSED_MAX = 0.05). What holds on any load is checked: the causes add up; and fewer than
# HIL_OWN_FAIL (0.5) of the vsyncs are its own (a warp too dear for the panel makes nearly every vsync "own"),
# judged only while the VM shows it had its CPUs: its SCHED_FIFO compositor woke late or was descheduled for
# under HIL_SCHED_QUIET (0.05) of the vsyncs. A starved VM shows both: measured beside three builds, own 4299 and
# the scheduler's 1537 of 7983 vsyncs, where a moderately busy host gave own 43 of 836.
hil_expect_on_time() {
    p=${1:+$1: }
    nvs=$(hil_stat vsyncs)
    sched=$(( $(hil_stat missed_late_wake) + $(hil_stat missed_descheduled) ))
    hil_note missed_scheduler "$sched"
    if hil_cmp "$sched" '<' "$nvs * ${HIL_SCHED_QUIET:-0.05}"; then
        hil_expect_stat missed_own '<' "$nvs * ${HIL_OWN_FAIL:-0.5} + 2" "${p}misses attributable to hmdwarpd (a warp too dear for the panel?)"
    else
        hil_log "${p}the VM was starved (the scheduler's misses: $sched of $nvs vsyncs): own misses reported, not judged"
    fi
    hil_target missed_own '<=' "$nvs * ${HIL_OWN_MAX:-0.02} + 2" "${p}misses attributable to hmdwarpd"
    hil_target missed '<=' "$nvs * ${HIL_MISSED_MAX:-0.05}" "${p}late presents (any cause)"
    sum=$(( $(hil_stat missed_own) + sched + $(hil_stat missed_no_buffer) ))
    [ "$sum" -eq "$(hil_stat missed)" ] || hil_miss "${p}miss causes sum to $sum, missed=$(hil_stat missed)"
}
# hil_expect_run_time D SLACK_S: hmdwarpd's --duration D run ended within D + SLACK_S seconds of wall time (a
# target: a starved VM starts and stops slowly; hil_hmdwarpd_wait's limit catches a run that never ends).
hil_expect_run_time() {
    dt=$(( $(cut -d. -f1 /proc/uptime) - HIL_HMD_T0 ))
    hil_note run_s "$dt"
    hil_target_cmp "$dt" '<=' "$1 + $2" run_s "hmdwarpd --duration $1 run time (its vsync clock fell behind real time?)"
}

# hil_expect_recovery COLUMN THRESHOLD FAULT_S RECOVER_S WHY: in the per-vsync CSV, the longest stretch of vsyncs
# whose COLUMN (m2p_ms, frame_age_ms, ...) exceeds THRESHOLD is the fault. Checked: it lasted at least FAULT_S / 4
# (the fault, real time on any load, was seen at all), and service came back: the stretch ended at least
# HIL_RECOVERED_VSYNCS (10) vsyncs before the run did. A target: it lasted at most FAULT_S + RECOVER_S (back within
# RECOVER_S seconds; on a busy host the IMU's reports or the feeder's frames come late for a while).
hil_expect_recovery() {
    col=$1; thr=$2; fault=$3; rec=$4; why=$5
    [ -s "$HIL_CSV" ] || { hil_miss "$why: no per-vsync CSV $HIL_CSV"; return 1; }
    # prints: longest stretch (s), rows after it, rows under THRESHOLD after it
    got=$(awk -F, -v name="$col" -v thr="$thr" '
        NR == 1 { for (i = 1; i <= NF; i++) if ($i == name) c = i; next }
        !c { next }
        { n++ }
        $c + 0 > thr { if (!on) { on = 1; t0 = $2 } t1 = $2; next }
        { if (on && t1 - t0 >= best) { best = t1 - t0; end = n - 1 } on = 0 }
        END { if (on && t1 - t0 >= best) { best = t1 - t0; end = n }
              if (!c) { print "nocol"; exit }
              printf "%.2f %d\n", best / 1e9, n - end }' "$HIL_CSV")
    set -- $got
    hil_note "longest_${col}_over_${thr}_s" "$1"
    hil_note "vsyncs_after_longest_${col}_over_${thr}" "${2:-}"
    [ "$1" != nocol ] || { hil_miss "$why: no column $col in $HIL_CSV"; return 1; }
    hil_cmp "$1" '>=' "$fault / 4" || { hil_miss "$why: $col > $thr for only ${1}s: the ${fault}s fault was not seen"; return 1; }
    [ "${2:-0}" -ge "${HIL_RECOVERED_VSYNCS:-10}" ] ||
        { hil_miss "$why: $col > $thr from the fault until the run ended (${2:-0} vsyncs after it): not recovered"; return 1; }
    hil_target_cmp "$1" '<=' "$fault + $rec" "longest_${col}_over_${thr}_s" "$why: back within ${rec}s of the ${fault}s fault"
}

# hil_expect_frames_resume STALL_S RECOVER_S WHY: a host stall in the per-vsync CSV: the longest stretch of vsyncs
# showing the same host frame (frame_seq) lasted at least STALL_S / 4 (the stall was seen) and at least
# HIL_RESUMED_FRAMES (3) newer frames were shown after it (the link resumed: counted in frames, on any load). A
# target: the stretch lasted at most STALL_S + RECOVER_S.
hil_expect_frames_resume() {
    stall=$1; rec=$2; why=$3
    [ -s "$HIL_CSV" ] || { hil_miss "$why: no per-vsync CSV $HIL_CSV"; return 1; }
    got=$(awk -F, '
        NR == 1 { for (i = 1; i <= NF; i++) if ($i == "frame_seq") c = i; next }
        !c || $c == "" || $c == 0 { next }   # 0: no host frame yet
        $c == seq { t1 = $2; next }
        { if (t1 - t0 > best) { best = t1 - t0; bseq = seq } seq = $c; t0 = t1 = $2 }
        END { if (!c) { print "nocol"; exit }
              if (t1 - t0 > best) { best = t1 - t0; bseq = seq }
              printf "%.2f %d\n", best / 1e9, bseq }' "$HIL_CSV")
    set -- $got
    [ "$1" != nocol ] || { hil_miss "$why: no column frame_seq in $HIL_CSV"; return 1; }
    newer=$(awk -F, -v s="$2" 'NR > 1 && $3 != "" && $3 > s { n[$3] = 1 } END { print length(n) }' "$HIL_CSV")
    hil_note longest_same_frame_s "$1"
    hil_note frames_shown_after_it "$newer"
    hil_cmp "$1" '>=' "$stall / 4" || { hil_miss "$why: one frame shown for at most ${1}s: the ${stall}s stall was not seen"; return 1; }
    [ "$newer" -ge "${HIL_RESUMED_FRAMES:-3}" ] ||
        { hil_miss "$why: $newer newer frames shown after the stall, expected >= ${HIL_RESUMED_FRAMES:-3}: the link did not resume"; return 1; }
    hil_target_cmp "$1" '<=' "$stall + $rec" longest_same_frame_s "$why: frames back within ${rec}s of the ${stall}s stall"
}

# hil_expect_backends IMU/FRAMES/VSYNC: the stats name these backends (first word of each: "i2c mpu6050 ..." is i2c).
hil_expect_backends() {
    got="$(hil_stat imu_backend | cut -d' ' -f1)/$(hil_stat frames_backend | cut -d' ' -f1)/$(hil_stat vsync_backend | cut -d' ' -f1)"
    [ "$got" = "$1" ]
}

# hil_log_has REGEX [WHY]: hmdwarpd's log must contain a line matching REGEX.
hil_log_has() {
    grep -qE "$1" "$HIL_HMD_LOG" || hil_miss "${2:-hmdwarpd log}: no line matching '$1'"
}

# hil_board NAME: path of a HIL board file (tests/hil/boards/NAME.ini).
hil_board() {
    [ -f "$HIL_BOARDS/$1.ini" ] || hil_fail "no board file $HIL_BOARDS/$1.ini"
    echo "$HIL_BOARDS/$1.ini"
}

# hil_rss_kb PID: resident memory of a process in KiB.
hil_rss_kb() { awk '/^VmRSS:/{print $2}' "/proc/$1/status" 2>/dev/null; }

# hil_cleanup: stop everything a scenario may have left behind (hil-run calls it after each scenario).
hil_cleanup() {
    [ -s "$HIL_CRC_PIDFILE" ] && kill "$(cat "$HIL_CRC_PIDFILE")" 2>/dev/null; rm -f "$HIL_CRC_PIDFILE"
    for p in hmdwarp-feed hil_uhid_imu hil_i2c_chip hil_te hil_kms_crc hmdwarpd; do
        pids=$(pidof "$p")
        [ -n "$pids" ] && kill $pids 2>/dev/null
    done
    sleep 0.3
    for p in hmdwarp-feed hil_uhid_imu hil_i2c_chip hil_te hil_kms_crc hmdwarpd; do
        pids=$(pidof "$p")
        [ -n "$pids" ] && kill -9 $pids 2>/dev/null
    done
    gadget.sh --ffs-dir "$FFS_DIR" stop >/dev/null 2>&1
    for g in "$CFS"/gpio-sim/*; do [ -d "$g" ] && hil_gpio_sim_remove "${g##*/}"; done
    hil_rmmod i2c_stub vivid gpio_sim usb_f_fs dummy_hcd uhid vkms
    return 0
}
