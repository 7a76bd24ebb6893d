#!/bin/sh
# SPDX-License-Identifier: MIT
# 00-devices: every kernel mock device the other scenarios use appears and works at the kernel level, before
# hmdwarpd is involved: uhid/hidraw, i2c-stub registers, gpio-sim edges seen by libgpiod, vivid's loop,
# dummy_hcd's UDC and USB host side, vkms's card, connector modes and CRCs (a pattern's equals hil_kms_crc's).
# hil-timeout: 90
. /hil/scenarios/lib.sh

# HID: uhid gives /dev/uhid; hidraw is built in.
hil_uhid
[ -d /sys/class/hidraw ] || hil_fail "no hidraw class (CONFIG_HIDRAW)"
if [ -x /hil/bin/hil_uhid_imu ]; then
    before=$(ls /sys/class/hidraw | wc -l)
    hil_uhid_imu --help >/dev/null 2>&1
    hil_uhid_imu --duration 3 >"$HIL_WORK/uhid.log" 2>&1 &
    up=$!
    hil_wait_until 10 sh -c "[ \$(ls /sys/class/hidraw | wc -l) -gt $before ]" ||
        { cat "$HIL_WORK/uhid.log"; hil_fail "uhid: hil_uhid_imu created no hidraw device"; }
    hr=$(ls -t /sys/class/hidraw | head -n 1)
    hil_log "uhid: $hr: $(grep HID_NAME /sys/class/hidraw/"$hr"/device/uevent)"
    hil_wait_for "/dev/$hr" 5 || hil_fail "uhid: no /dev/$hr node"
    kill "$up" 2>/dev/null; wait "$up" 2>/dev/null
fi

# I2C: i2c-stub's register file through i2c-dev (SMBus byte data).
bus=$(hil_i2c_stub 0x68)
n=${bus#/dev/i2c-}
i2cset -y "$n" 0x68 0x75 0x68 b || hil_fail "i2c-stub: i2cset on $bus failed"
v=$(i2cget -y "$n" 0x68 0x75 b) || hil_fail "i2c-stub: i2cget on $bus failed"
[ "$v" = 0x68 ] || hil_fail "i2c-stub: register 0x75 reads $v after writing 0x68"
hil_log "i2c-stub: $bus, register write/read ok"
hil_rmmod i2c_stub

# GPIO: a gpio-sim line toggled through its pull attribute gives edge events to libgpiod.
hil_gpio_sim hil00 1
pull=$(hil_gpio_pull 0)
[ -w "$pull" ] || hil_fail "gpio-sim: no pull attribute at $pull"
echo pull-down >"$pull"
if command -v gpiomon >/dev/null; then
    gpiomon -n 4 "$HIL_GPIO_CHIP" 0 >"$HIL_WORK/gpiomon.log" 2>&1 &
    mon=$!
    sleep 0.5
    for s in up down up down; do echo "pull-$s" >"$pull"; sleep 0.1; done
    i=0; while kill -0 "$mon" 2>/dev/null && [ $i -lt 30 ]; do sleep 0.1; i=$((i + 1)); done
    kill "$mon" 2>/dev/null
    cat "$HIL_WORK/gpiomon.log"
    edges=$(grep -c 'EDGE' "$HIL_WORK/gpiomon.log")
    [ "$edges" -eq 4 ] || hil_fail "gpio-sim: gpiomon saw $edges edges on $HIL_GPIO_CHIP line 0, expected 4"
    echo pull-up >"$pull"
    v=$(gpioget "$HIL_GPIO_CHIP" 0) || hil_fail "gpioget $HIL_GPIO_CHIP 0 failed"
    [ "$v" = 1 ] || hil_fail "gpio-sim: line 0 reads $v with pull-up"
fi
hil_log "gpio-sim: $HIL_GPIO_CHIP ($HIL_GPIO_DEV), edges ok"
hil_gpio_sim_remove hil00

# V4L2: vivid's capture and output nodes with the loop set up.
hil_vivid
hil_vivid_loop YUYV
hil_log "vivid: capture $HIL_VID_CAP, output $HIL_VID_OUT, $(v4l2-ctl -d "$HIL_VID_CAP" --get-fmt-video | grep 'Width/Height')"
# Byte-exact loop: a constant frame written to the output comes back unchanged.
sz=$((HIL_VID_W * HIL_VID_H * 2))
awk -v n="$sz" 'BEGIN { for (i = 0; i < n / 4; i++) printf "\x5a\x80\xa5\x80" }' >"$HIL_WORK/pat.yuv" 2>/dev/null ||
    head -c "$sz" /dev/zero | tr '\0' 'Z' >"$HIL_WORK/pat.yuv"
v4l2-ctl -d "$HIL_VID_OUT" --stream-out-mmap=3 --stream-from="$HIL_WORK/pat.yuv" --stream-loop --stream-count=200 >/dev/null 2>&1 &
out=$!
sleep 1
v4l2-ctl -d "$HIL_VID_CAP" --stream-mmap=3 --stream-count=4 --stream-to="$HIL_WORK/cap.yuv" >/dev/null 2>&1 ||
    hil_fail "vivid: capture streaming failed"
kill "$out" 2>/dev/null; wait "$out" 2>/dev/null
tail -c "$sz" "$HIL_WORK/cap.yuv" >"$HIL_WORK/last.yuv"
cmp -s "$HIL_WORK/last.yuv" "$HIL_WORK/pat.yuv" ||
    hil_fail "vivid: looped frame differs from the one written ($(cmp "$HIL_WORK/last.yuv" "$HIL_WORK/pat.yuv" 2>&1 | head -n 1))"
hil_log "vivid: loop byte-exact"
hil_rmmod vivid

# USB: dummy_hcd's UDC and its host-side root hub (usbfs nodes from devtmpfs, no udevd).
hil_usb_udc
hil_wait_for /dev/bus/usb/001/001 5 || hil_fail "dummy_hcd: no /dev/bus/usb/001/001 (root hub)"
[ -d "$CFS/usb_gadget" ] || hil_fail "libcomposite: no $CFS/usb_gadget"
hil_log "usb: $(ls /sys/class/udc), root hub $(cat /sys/bus/usb/devices/usb1/product 2>/dev/null)"

# KMS: vkms's card node, its virtual connector connected with the no-EDID modes (640x480 among them) and the
# HIL panel's, and the CRC capture files in debugfs.
hil_vkms
[ "$(cat "$HIL_DRI_CONN/status")" = connected ] || hil_fail "vkms: connector ${HIL_DRI_CONN##*/} is $(cat "$HIL_DRI_CONN/status")"
grep -qx 640x480 "$HIL_DRI_CONN/modes" || hil_fail "vkms: no 640x480 mode on ${HIL_DRI_CONN##*/} ($(head -n 5 "$HIL_DRI_CONN/modes" | tr '\n' ' '))"
# the HIL panel's mode, added by run.sh's video=Virtual-1:WxH@90 (05-kms shows the panel at it)
pm=128x64; [ "${HIL_PANEL:-small}" = small ] || pm=640x360
grep -qx "$pm" "$HIL_DRI_CONN/modes" || hil_fail "vkms: no $pm mode on ${HIL_DRI_CONN##*/} (video= on the kernel command line: $(cat /proc/cmdline))"
for f in control data; do
    [ -e "$HIL_DRI_DEBUG/crtc-0/crc/$f" ] || hil_fail "vkms: no $HIL_DRI_DEBUG/crtc-0/crc/$f (debugfs)"
done
hil_log "kms: $HIL_DRI_CARD ($(cat "$HIL_DRI_DEBUG/name")), ${HIL_DRI_CONN##*/} $(wc -l <"$HIL_DRI_CONN/modes") modes"
# vkms's CRC is the one hil_kms_crc predicts (05-kms relies on it): a test pattern shown at 640x480 by a bare
# dumb-buffer modeset, without hmdwarpd, CRCs as computed from the image.
hil_kms_crc pattern 640 480 >"$HIL_WORK/kms-pat.rgba" || hil_fail "hil_kms_crc pattern failed"
want=$(hil_kms_crc crc "$HIL_WORK/kms-pat.rgba" 640 480) || hil_fail "hil_kms_crc crc failed"
hil_kms_crc show "$HIL_DRI_CARD" "$HIL_WORK/kms-pat.rgba" 640 480 5 >"$HIL_WORK/kms-show.log" 2>&1 &
show=$!
hil_wait_until 10 grep -q '^shown=' "$HIL_WORK/kms-show.log" ||
    { cat "$HIL_WORK/kms-show.log"; hil_fail "vkms: hil_kms_crc show set no mode ($(tail -n 1 "$HIL_WORK/kms-show.log"))"; }
hil_vkms_crc_on
hil_wait_until 10 hil_vkms_crc_has 3
hil_vkms_crc_off
wait "$show"
n=$(wc -l <"$HIL_WORK/crc.txt")
got=$(tail -n 1 "$HIL_WORK/crc.txt" | cut -d' ' -f2)
hil_log "kms: $n CRCs of the pattern, last $got, predicted $want"
[ "$n" -ge 3 ] || hil_fail "vkms: $n CRC lines in 10 s with a pattern shown ($(cat "$HIL_WORK/crc.err"))"
[ "$got" = "$want" ] || { cat "$HIL_WORK/crc.txt"; hil_fail "vkms: CRC of the shown pattern $got, hil_kms_crc predicts $want"; }
hil_rmmod vkms

hil_pass
