#!/bin/sh
# SPDX-License-Identifier: MIT
# gadget.sh: sets up the board as a USB gadget for the host frame link (configfs + FunctionFS), starts hmdwarpd
# (which writes the FunctionFS descriptors), binds the UDC; and tears it all down again. See docs/framelink.md.
set -eu

GADGET=hmdwarp
CONFIGFS=/sys/kernel/config
FFS_DIR=/dev/ffs-hmdwarp
VID=0x1d6b          # Linux Foundation
PID=0x0104          # multifunction composite gadget (hmdwarp-feed's default --device)
SERIAL=
UDC=
CONFIG=/usr/local/share/hmdwarp/boards/sim/board.ini
HMDWARPD=hmdwarpd
PIDFILE=/run/hmdwarpd.pid
WAIT_S=10

usage() {
    cat <<EOF
Usage: hmdwarp-gadget [options] start|stop|status|setup|bind
(installed as hmdwarp-gadget; board/gadget.sh in the source tree)

  start   load libcomposite, create the configfs gadget "$GADGET" with an ffs.$GADGET function,
          mount FunctionFS at the ffs dir, start hmdwarpd (it writes the USB descriptors to ep0),
          wait until it has, then bind the UDC
  stop    unbind, stop hmdwarpd, unmount FunctionFS and remove the gadget (safe to repeat)
  status  show the gadget, its UDC and whether hmdwarpd runs
  setup   only the first half of start: the gadget and the FunctionFS mount (systemd: ExecStartPre)
  bind    only the second half: wait for the descriptors hmdwarpd wrote, bind the UDC (systemd: ExecStartPost)

options:
  --udc NAME        UDC to bind (default: the first in /sys/class/udc, e.g. dummy_udc.0 in tests)
  --vid HEX         idVendor (default $VID)
  --pid HEX         idProduct (default $PID)
  --serial STR      serial number string (default: /etc/machine-id prefix)
  --ffs-dir DIR     FunctionFS mount point (default $FFS_DIR; board.ini [frames] device must match)
  --config FILE     board.ini passed to hmdwarpd (default $CONFIG)
  --hmdwarpd PATH   hmdwarpd binary (default: $HMDWARPD from PATH)
  --no-daemon       do not start hmdwarpd (another process writes the descriptors); bind waits for them
  --wait S          seconds to wait for the descriptors before giving up (default $WAIT_S)
  --owner USER      mount FunctionFS owned by USER (the unprivileged service user, e.g. hmdwarp)
  -h, --help        this text

Needs root, configfs (CONFIG_USB_CONFIGFS_F_FS) and a UDC driver (or dummy_hcd for tests).
EOF
}

die() { echo "gadget.sh: $*" >&2; exit 1; }

DAEMON=1
ACTION=
OWNER=
while [ $# -gt 0 ]; do
    case "$1" in
        --udc) UDC=$2; shift 2 ;;
        --vid) VID=$2; shift 2 ;;
        --pid) PID=$2; shift 2 ;;
        --serial) SERIAL=$2; shift 2 ;;
        --ffs-dir) FFS_DIR=$2; shift 2 ;;
        --config) CONFIG=$2; shift 2 ;;
        --hmdwarpd) HMDWARPD=$2; shift 2 ;;
        --no-daemon) DAEMON=0; shift ;;
        --wait) WAIT_S=$2; shift 2 ;;
        --owner) OWNER=$2; shift 2 ;;
        -h|--help) usage; exit 0 ;;
        start|stop|status|setup|bind) ACTION=$1; shift ;;
        *) usage >&2; die "unknown argument '$1'" ;;
    esac
done
[ -n "$ACTION" ] || { usage >&2; exit 2; }

G=$CONFIGFS/usb_gadget/$GADGET

# The ep1/ep2 files appear once the descriptors are written to ep0: the gadget can only be bound after that.
wait_descriptors() {
    i=0
    while [ ! -e "$FFS_DIR/ep1" ]; do
        if [ "$DAEMON" -eq 1 ] && ! kill -0 "$(cat "$PIDFILE")" 2>/dev/null; then
            die "hmdwarpd exited before writing the USB descriptors (see its output above)"
        fi
        i=$((i + 1))
        [ "$i" -le $((WAIT_S * 10)) ] || die "no descriptors in $FFS_DIR after ${WAIT_S}s (hmdwarpd log? [frames] backend = usb?)"
        sleep 0.1
    done
}

do_setup() {
    [ "$(id -u)" -eq 0 ] || die "must run as root"
    modprobe libcomposite 2>/dev/null || true
    mountpoint -q "$CONFIGFS" || mount -t configfs none "$CONFIGFS"
    [ -d "$CONFIGFS/usb_gadget" ] || die "no $CONFIGFS/usb_gadget: kernel without USB configfs gadget support"
    [ ! -d "$G" ] || die "gadget $GADGET exists already (board/gadget.sh stop first)"

    if [ -z "$UDC" ]; then
        for u in /sys/class/udc/*; do [ -e "$u" ] && UDC=${u##*/} && break; done
        [ -n "$UDC" ] || die "no UDC in /sys/class/udc (load the controller driver, or dummy_hcd for tests)"
    fi
    [ -e "/sys/class/udc/$UDC" ] || die "UDC '$UDC' not found in /sys/class/udc"
    if [ -z "$SERIAL" ]; then
        SERIAL=$(cut -c1-16 /etc/machine-id 2>/dev/null || echo 0000000000000000)
    fi

    trap 'echo "gadget.sh: start failed half way; board/gadget.sh stop cleans up" >&2' EXIT
    mkdir "$G"
    echo "$VID" >"$G/idVendor"
    echo "$PID" >"$G/idProduct"
    echo 0x0100 >"$G/bcdDevice"
    echo 0x0200 >"$G/bcdUSB"
    mkdir "$G/strings/0x409"
    echo "$SERIAL" >"$G/strings/0x409/serialnumber"
    echo "hmdwarp" >"$G/strings/0x409/manufacturer"
    echo "hmdwarp HMD controller" >"$G/strings/0x409/product"
    mkdir "$G/configs/c.1"
    mkdir "$G/configs/c.1/strings/0x409"
    echo "frames" >"$G/configs/c.1/strings/0x409/configuration"
    echo 500 >"$G/configs/c.1/MaxPower"
    mkdir "$G/functions/ffs.$GADGET"
    ln -s "$G/functions/ffs.$GADGET" "$G/configs/c.1/"

    mkdir -p "$FFS_DIR"
    opts=
    if [ -n "$OWNER" ]; then
        opts="-o uid=$(id -u "$OWNER"),gid=$(id -g "$OWNER")"
    fi
    # shellcheck disable=SC2086
    mountpoint -q "$FFS_DIR" || mount -t functionfs $opts "$GADGET" "$FFS_DIR"
    echo "$UDC" >"/run/hmdwarp-gadget.udc"
    trap - EXIT
}

do_bind() {
    [ -d "$G" ] || die "gadget $GADGET is not set up (board/gadget.sh setup first)"
    [ -n "$UDC" ] || UDC=$(cat /run/hmdwarp-gadget.udc 2>/dev/null || true)
    [ -n "$UDC" ] || die "no UDC to bind (--udc NAME)"
    wait_descriptors
    echo "$UDC" >"$G/UDC"
    echo "gadget.sh: $GADGET bound to $UDC ($VID:$PID), FunctionFS at $FFS_DIR"
}

start() {
    do_setup
    trap 'echo "gadget.sh: start failed half way; board/gadget.sh stop cleans up" >&2' EXIT
    if [ "$DAEMON" -eq 1 ]; then
        command -v "$HMDWARPD" >/dev/null 2>&1 || die "hmdwarpd not found ('$HMDWARPD'; --hmdwarpd PATH)"
        "$HMDWARPD" --config "$CONFIG" --set frames.backend=usb --set "frames.device=$FFS_DIR" &
        echo $! >"$PIDFILE"
    fi
    do_bind
    trap - EXIT
}

stop() {
    if [ -d "$G" ]; then
        if [ -n "$(cat "$G/UDC" 2>/dev/null || true)" ]; then echo "" >"$G/UDC" || true; fi
    fi
    if [ -f "$PIDFILE" ]; then
        pid=$(cat "$PIDFILE")
        if kill -0 "$pid" 2>/dev/null; then
            kill "$pid"
            i=0
            while kill -0 "$pid" 2>/dev/null && [ "$i" -lt 50 ]; do sleep 0.1; i=$((i + 1)); done
        fi
        rm -f "$PIDFILE"
    fi
    if mountpoint -q "$FFS_DIR" 2>/dev/null; then umount "$FFS_DIR"; fi
    if [ -d "$FFS_DIR" ]; then rmdir "$FFS_DIR" 2>/dev/null || true; fi
    if [ -d "$G" ]; then
        rm -f "$G/configs/c.1/ffs.$GADGET"
        rmdir "$G/configs/c.1/strings/0x409" 2>/dev/null || true
        rmdir "$G/configs/c.1" 2>/dev/null || true
        rmdir "$G/functions/ffs.$GADGET" 2>/dev/null || true
        rmdir "$G/strings/0x409" 2>/dev/null || true
        rmdir "$G"
    fi
    rm -f /run/hmdwarp-gadget.udc
    echo "gadget.sh: $GADGET removed"
}

status() {
    if [ -d "$G" ]; then
        echo "gadget $GADGET: $(cat "$G/idVendor"):$(cat "$G/idProduct"), UDC '$(cat "$G/UDC")'"
    else
        echo "gadget $GADGET: not configured"
    fi
    if mountpoint -q "$FFS_DIR" 2>/dev/null; then echo "FunctionFS: $FFS_DIR"; else echo "FunctionFS: not mounted"; fi
    if [ -f "$PIDFILE" ] && kill -0 "$(cat "$PIDFILE")" 2>/dev/null; then
        echo "hmdwarpd: running (pid $(cat "$PIDFILE"))"
    else
        echo "hmdwarpd: not running"
    fi
}

case "$ACTION" in
    start) start ;;
    setup) DAEMON=0; do_setup ;;
    bind) DAEMON=0; do_bind ;;
    stop) stop ;;
    status) status ;;
esac
