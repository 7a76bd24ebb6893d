#!/bin/sh
# SPDX-License-Identifier: MIT
# Hardware-in-the-loop tests: boots Debian's own kernel under qemu (TCG software emulation, no KVM needed) with an
# initramfs holding hmdwarpd, the in-VM device programs and the kernel mock devices' modules, runs the scenarios
# (tests/hil/scenarios) and reports one line per scenario. Exits non-zero if any scenario fails or the VM does
# not report.
#
# usage: tests/hil/run.sh [NAME...]        (names: 01-nominal, 01, nominal; default: all)
# env:   HIL_SCENARIO=NAME   same as naming it     HIL_SHELL=1   interactive shell in the VM (Ctrl-A x quits)
#        HIL_VERBOSE=1       stream scenario logs   HIL_TIMEOUT=S  whole-VM limit (default 900)
#        HIL_SOAK_S=S        soak length (04-soak)  HIL_SMP, HIL_MEM  VM CPUs (2) and MiB (1024)
#        HIL_NOMINAL_S, HIL_PANEL=small|board, HIL_MISSED_MAX, HIL_OWN_MAX, HIL_IMU_RATE_MIN, HIL_HMD_ARGS=--set,k=v,
#        HIL_STRICT=1 (missed timing targets fail), HIL_OWN_FAIL, HIL_SCHED_QUIET, HIL_USB_SPEED=high-speed:
#        scenario knobs passed to the VM (see tests/hil/README.md)
#        HIL_KERNEL=vmlinuz  boot the compressed image instead of the extracted vmlinux
#        HIL_MONITOR=1       qemu's monitor on $BUILD/hil/monitor.sock (a hung VM's registers and stacks)
#        BUILD=build         build tree (programs from `make all`)
# Needs board/deps-hil.sh to have run (qemu, busybox, the kernel cache) and `make all`.
set -eu
BUILD=${BUILD:-build}
here=$(cd "$(dirname "$0")" && pwd)
out=$BUILD/hil
CACHE=${HIL_CACHE:-$out/cache}
die() { echo "hil: $*" >&2; exit 2; }

command -v qemu-system-x86_64 >/dev/null || die "qemu-system-x86_64 missing (board/deps-hil.sh)"
[ -s "$CACHE/kabi" ] || die "no kernel cache in $CACHE (board/deps-hil.sh)"
KABI=$(cut -d' ' -f1 "$CACHE/kabi")

scen="${HIL_SCENARIO:-} $*"
"$here/build-initramfs.sh" >"$out/initramfs.log" 2>&1 || { cat "$out/initramfs.log" >&2; die "initramfs build failed"; }
tail -n 1 "$out/initramfs.log"

if [ "${HIL_KERNEL:-vmlinux}" = vmlinuz ]; then kernel=$CACHE/root/boot/vmlinuz-$KABI; else kernel=$out/vmlinux; fi

# Kernel parameters: NAME=VALUE words without dots become /init's environment.
append="console=ttyS0 panic=-1 loglevel=4 mitigations=off nokaslr tsc=reliable"
append="$append HIL_SHELL=${HIL_SHELL:-0} HIL_VERBOSE=${HIL_VERBOSE:-0}"
for v in HIL_SOAK_S HIL_NOMINAL_S HIL_HMD_ARGS HIL_PANEL HIL_USB_SPEED HIL_MISSED_MAX HIL_OWN_MAX HIL_IMU_RATE_MIN HIL_KMS HIL_KMS_RENDERERS HIL_VKMS_STRESS HIL_STRICT HIL_OWN_FAIL HIL_SCHED_QUIET HIL_TE_LOCKABLE; do
    eval "val=\${$v:-}"
    [ -n "$val" ] && append="$append $v=$val"
done
[ -n "${HIL_TIMEOUT_SCALE:-}" ] && append="$append HIL_TIMEOUT_SCALE=$HIL_TIMEOUT_SCALE"
# vkms's connector offers the no-EDID modes (640x480 and up, all 60 Hz), too many pixels for a warp under TCG
# (~0.5 s a pass at 640x480): the kernel's video= option adds the HIL panel's own mode to the connector's list (a
# GTF mode at 90 Hz, as an EDID would), so 05-kms shows the same small panel as the other scenarios.
if [ "${HIL_PANEL:-small}" = small ]; then append="$append video=Virtual-1:128x64@90"
else append="$append video=Virtual-1:640x360@90"; fi
[ "${HIL_MONITOR:-0}" = 1 ] && append="$append sysrq_always_enabled"
names=$(echo $scen | tr ' ' ',')
[ -n "$names" ] && append="$append HIL_SCENARIO=$names"

set -- qemu-system-x86_64 -accel tcg,thread=multi -cpu max -smp "${HIL_SMP:-2}" -m "${HIL_MEM:-1024}" \
    -kernel "$kernel" -initrd "$out/initramfs.cpio" -append "$append" \
    -nographic -no-reboot -nic none
# HIL_MONITOR=1: qemu's monitor on a socket ($out/monitor.sock), to look into a VM that stopped reporting from
# outside: `info registers -a` (each vCPU's RIP, RSP and interrupt flag), `cpu N` + `x /64gx RSP` (return addresses;
# symbols from /proc/kallsyms of a VM booted the same way: nokaslr, same module load order), `sendkey alt-sysrq-w`
# while the guest still takes interrupts (sysrq_always_enabled is set).
[ "${HIL_MONITOR:-0}" = 1 ] && set -- "$@" -monitor "unix:$out/monitor.sock,server,nowait"

if [ "${HIL_SHELL:-0}" = 1 ]; then
    echo "hil: interactive VM (kernel $KABI); Ctrl-A x quits qemu"
    exec "$@"
fi

log=$out/console.log
echo "hil: booting $KABI under qemu (TCG), console log: $log"
rc=0
# the log exists before tail looks for it: qemu's redirection happens in the background job, and a tail -f that
# starts first finds no file and quits, so the scenario lines (and the summary tests/run.sh reads) never showed
# (a fresh clone's first make test: "the VM did not report" after all scenarios had passed)
: >"$log"
timeout "${HIL_TIMEOUT:-900}" "$@" </dev/null >"$log" 2>&1 &
qpid=$!
# Echo the per-scenario lines as they come (and a failing scenario's log tail).
if [ "${HIL_VERBOSE:-0}" = 1 ]; then pat=""; else pat="^(hil: |    \\| )"; fi
tail -n +1 -f "$log" --pid="$qpid" 2>/dev/null | tr -d "\r" | grep --line-buffered -E "$pat" || true
wait "$qpid" || rc=$?
tr -d '\r' <"$log" >"$log.txt"

summary=$(grep -E '^hil: [0-9]+ passed, [0-9]+ failed' "$log.txt" | tail -n 1)
if [ -z "$summary" ]; then
    if [ "$rc" -eq 124 ]; then echo "hil: FAIL: the VM did not finish within ${HIL_TIMEOUT:-900}s"
    else echo "hil: FAIL: the VM ended (qemu status $rc) without reporting; last console lines:"; fi
    tail -n 25 "$log.txt" | sed 's/^/    | /'
    exit 1
fi
case "$summary" in *" 0 failed") exit 0 ;; *) exit 1 ;; esac
