#!/bin/sh
# SPDX-License-Identifier: MIT
# test_flash: `make install` and board/flash.sh against a fake merged-/usr board root (lib -> usr/lib, ...): the
# root's directory symlinks survive --root and --ssh, a calibrated board.ini is kept with board.ini.dist beside it,
# the board's calibration file (/var/lib/hmdwarp/calibration.ini) is never written or deleted, and a tree built for another architecture is refused before anything is written. TAP output for tests/run.sh.
# usage: tests/flash/test_flash.sh   (from anywhere; BUILD=build/... names the build tree, as make test sets it;
#        TEST_FLASH_KEEP=1 keeps the temporary roots and trees, for a look after a failure)
# shellcheck disable=SC2016 # (the checks are shell code for eval, single-quoted to run later)
set -u
cd "$(dirname "$0")/../.." || exit 1
BUILD=${BUILD:-build}
T=$(mktemp -d "${TMPDIR:-/tmp}/test_flash.XXXXXX") || exit 1
[ -n "${TEST_FLASH_KEEP:-}" ] || trap 'rm -rf "$T"' EXIT
PLAN=22
echo "1..$PLAN"

n=0
# check DESCRIPTION CODE: one TAP result from shell code (it sees this script's functions and variables); on failure
# its output and the last step's as comments.
check() {
    n=$((n + 1))
    if (eval "$2") >"$T/check.out" 2>&1; then
        echo "ok $n - $1"
    else
        echo "not ok $n - $1"
        sed 's/^/#   /' "$T/check.out" "$T/step.out" 2>/dev/null | tail -n 30
    fi
}
# step COMMAND...: runs a flash.sh or make step, its stdout in step.out, its stderr in step.err; returns its status.
step() { "$@" >"$T/step.out" 2>"$T/step.err"; rc=$?; cat "$T/step.err" >>"$T/step.out"; return $rc; }

elf_machine() { od -An -tu1 -j18 -N2 "$1" | awk '{ print $1 + 256 * $2 }'; }   # little-endian e_machine
native=$(elf_machine "$BUILD/hmdwarpd")
case "$native" in 183) native_name=aarch64 other=x86_64 ;; 62) native_name=x86_64 other=aarch64 ;;
    *) native_name=unknown other=aarch64 ;; esac
# fake_elf FILE ARCH: a 64-bit little-endian ELF header for ARCH, all the architecture check reads
fake_elf() {
    case "$2" in aarch64) m='\267' ;; x86_64) m='\076' ;; esac
    # shellcheck disable=SC2059 # (m is printf's octal escape for the e_machine byte)
    printf "\\177ELF\\002\\001\\001\\000\\000\\000\\000\\000\\000\\000\\000\\000\\002\\000$m\\000\\001\\000\\000\\000" >"$1"
}
# as_arch TREE ARCH: every ELF program of the tree replaced by a header for ARCH
as_arch() {
    for f in "$1"/usr/bin/*; do
        [ "$(od -An -c -N4 "$f" | tr -d ' ')" = '177ELF' ] && fake_elf "$f" "$2"
    done
    return 0
}

# mkroot DIR [noconf]: a board's root filesystem as Debian 12 lays it out, with a calibrated board.ini
mkroot() {
    mkdir -p "$1/usr/bin" "$1/usr/sbin" "$1/usr/lib" "$1/usr/lib64" "$1/etc/hmdwarp"
    ln -s usr/lib "$1/lib"; ln -s usr/bin "$1/bin"; ln -s usr/sbin "$1/sbin"; ln -s usr/lib64 "$1/lib64"
    printf 'stand-in for the dynamic loader\n' >"$1/usr/lib64/ld-linux-x86-64.so.2"
    # the root's own programs tell flash.sh its architecture: this machine's, as the native build's
    cp -L "$(command -v env)" "$1/usr/bin/env"
    if [ "${2:-}" != noconf ]; then
        sed 's/^scale = .*/scale = 731.25         ; calibrated on this unit/' board/sim/board.ini >"$1/etc/hmdwarp/board.ini"
        cp "$1/etc/hmdwarp/board.ini" "$1.calibrated"
        mkdir -p "$1/var/lib/hmdwarp"
        printf '; this unit\n[imu]\ngyro_bias = 0.001 0.002 0.003\n' >"$1/var/lib/hmdwarp/calibration.ini"
        cp "$1/var/lib/hmdwarp/calibration.ini" "$1.calib"
    fi
}
# merged DIR: the merged-/usr symlinks are still symlinks with their targets, and the loader still resolves
merged() {
    [ "$(readlink "$1/lib")" = usr/lib ] && [ "$(readlink "$1/bin")" = usr/bin ] &&
        [ "$(readlink "$1/sbin")" = usr/sbin ] && [ "$(readlink "$1/lib64")" = usr/lib64 ] &&
        [ -f "$1/lib64/ld-linux-x86-64.so.2" ] && [ -d "$1/lib/systemd/system" ]
}
snap() { (cd "$1" && find . -printf '%p %y %m %s %T@ %l\n' | sort); }
installed() {   # installed ROOT TREE: unit, udev rule, sysusers entry and hmdwarpd where the board wants them
    cmp "$1/usr/lib/systemd/system/hmdwarpd.service" "$2/usr/lib/systemd/system/hmdwarpd.service" &&
        cmp "$1/usr/lib/udev/rules.d/99-hmdwarp.rules" board/udev/99-hmdwarp.rules &&
        cmp "$1/usr/lib/sysusers.d/hmdwarp.conf" board/systemd/hmdwarp.sysusers.conf &&
        cmp "$1/usr/bin/hmdwarpd" "$2/usr/bin/hmdwarpd"
}
enabled() {   # enabled ROOT: the wants symlink names the unit's place on the board, and it is there
    l=$(readlink "$1/etc/systemd/system/multi-user.target.wants/hmdwarpd.service") &&
        [ "$l" = /usr/lib/systemd/system/hmdwarpd.service ] && [ -f "$1$l" ]
}
kept() {   # kept ROOT TREE: the calibrated board.ini byte for byte, the tree's beside it, and the line saying so
    cmp "$1/etc/hmdwarp/board.ini" "$1.calibrated" && cmp "$1/etc/hmdwarp/board.ini.dist" "$2/etc/hmdwarp/board.ini" &&
        grep -q "kept the board's .*/etc/hmdwarp/board.ini; the tree's one is beside it as " "$T/step.out"
}
calib_kept() {   # calib_kept ROOT: the board's calibration file byte for byte, and the line saying so
    cmp "$1/var/lib/hmdwarp/calibration.ini" "$1.calib" &&
        grep -q "kept the board's calibration .*/var/lib/hmdwarp/calibration.ini" "$T/step.out"
}
mk_install() { make -s --no-print-directory install BUILD="$BUILD" PREFIX=/usr "$@"; }

# Stand-ins for the board over ssh: `ssh TARGET CMD` runs CMD here with the board's / mapped to $FLASH_TEST_ROOT
# (flash.sh's remote commands name absolute paths after a blank), sudo runs its command, and systemd's tools log.
mkdir -p "$T/bin" "$T/remote"
cat >"$T/bin/ssh" <<'EOF'
#!/bin/sh
shift
cmd=$(printf '%s\n' "$*" | sed "s# /# $FLASH_TEST_ROOT/#g")
PATH=$FLASH_TEST_STUBS:$PATH exec sh -c "$cmd"
EOF
printf '#!/bin/sh\nexec "$@"\n' >"$T/remote/sudo"
for t in systemctl udevadm systemd-sysusers; do
    printf '#!/bin/sh\necho "%s${*:+ $*}" >>"$FLASH_TEST_ROOT.log"\n' "$t" >"$T/remote/$t"
done
chmod +x "$T/bin/ssh" "$T/remote/"*
export FLASH_TEST_STUBS="$T/remote"
flash_ssh() { r=$1; shift; PATH="$T/bin:$PATH" FLASH_TEST_ROOT=$r board/flash.sh --ssh pi@board "$@"; }

# ---- make install ----
step mk_install DESTDIR="$T/tree" BOARD=sim
check "make install: unit in usr/lib/systemd/system, udev rule in usr/lib/udev/rules.d, no real lib/ in the tree" '
    [ -f "$T/tree/usr/lib/systemd/system/hmdwarpd.service" ] && [ -f "$T/tree/usr/lib/udev/rules.d/99-hmdwarp.rules" ] &&
    [ -f "$T/tree/usr/lib/sysusers.d/hmdwarp.conf" ] && [ ! -e "$T/tree/lib" ] &&
    [ ! -e "$T/tree/var/lib/hmdwarp/calibration.ini" ]'
mk_install DESTDIR="$T/twice" BOARD=sim >/dev/null 2>&1
echo '; calibrated' >>"$T/twice/etc/hmdwarp/board.ini"
cp "$T/twice/etc/hmdwarp/board.ini" "$T/twice.calibrated"
step mk_install DESTDIR="$T/twice" BOARD=sim
check "make install twice keeps the first board.ini, writes board.ini.dist and says so in one line" '
    cmp "$T/twice/etc/hmdwarp/board.ini" "$T/twice.calibrated" &&
    cmp "$T/twice/etc/hmdwarp/board.ini.dist" board/sim/board.ini && [ "$(grep -c board.ini.dist "$T/step.out")" = 1 ]'

# ---- --root ----
mkroot "$T/r1"
step board/flash.sh --tree "$T/tree" --root "$T/r1"
check "--root: installs (exit 0)" '[ "$rc" = 0 ]'
check "--root: lib, bin, sbin, lib64 are still symlinks into usr/ and the loader resolves" 'merged "$T/r1"'
check "--root: the calibrated board.ini is unchanged, the tree's is beside it as board.ini.dist" 'kept "$T/r1" "$T/tree"'
check "--root: unit, udev rule, sysusers and programs under usr/, the unit enabled" \
    'installed "$T/r1" "$T/tree" && enabled "$T/r1"'
check "--root: the board's calibration file is unchanged and flash.sh says it kept it" 'calib_kept "$T/r1"'
# a tree that holds a calibration file (copied in by hand): neither over the board's nor onto a board without one
cp -a "$T/tree" "$T/ctree"
mkdir -p "$T/ctree/var/lib/hmdwarp"
printf '[imu]\ngyro_bias = 0.5 0.5 0.5\n' >"$T/ctree/var/lib/hmdwarp/calibration.ini"
mkroot "$T/c1"
step board/flash.sh --tree "$T/ctree" --root "$T/c1"
mkroot "$T/c2" noconf
board/flash.sh --tree "$T/ctree" --root "$T/c2" >"$T/c2.out" 2>&1
check "--root with a tree holding a calibration file: the board's stays, none is created where there was none" '
    [ "$rc" = 0 ] && calib_kept "$T/c1" && [ ! -e "$T/c2/var/lib/hmdwarp/calibration.ini" ] &&
    grep -q "the tree holds /var/lib/hmdwarp/calibration.ini: not installed" "$T/c2.out"'
mkroot "$T/r2" noconf
step board/flash.sh --tree "$T/tree" --root "$T/r2"
check "--root without a board.ini there: installs the tree's, no board.ini.dist" '
    [ "$rc" = 0 ] && cmp "$T/r2/etc/hmdwarp/board.ini" "$T/tree/etc/hmdwarp/board.ini" &&
    [ ! -e "$T/r2/etc/hmdwarp/board.ini.dist" ] && ! grep -q kept "$T/step.out"'
# a tree from before (or overriding) the usr/lib defaults, with a real lib/: unpacked through the root's lib symlink
step mk_install DESTDIR="$T/libtree" BOARD=sim UNITDIR=/lib/systemd/system UDEVDIR=/lib/udev/rules.d
mkroot "$T/r3"
step board/flash.sh --tree "$T/libtree" --root "$T/r3"
check "--root with a tree that has a real lib/: the root's lib stays a symlink, the unit lands in usr/lib" '
    [ "$rc" = 0 ] && [ -d "$T/libtree/lib/systemd" ] && merged "$T/r3" &&
    [ -f "$T/r3/usr/lib/systemd/system/hmdwarpd.service" ] && [ -f "$T/r3/usr/lib/udev/rules.d/99-hmdwarp.rules" ] &&
    [ -f "$T/r3$(readlink "$T/r3/etc/systemd/system/multi-user.target.wants/hmdwarpd.service")" ]'

# ---- --ssh ----
mkroot "$T/s1"
step flash_ssh "$T/s1" --tree "$T/tree"
check "--ssh: installs (exit 0); lib, bin, sbin, lib64 still symlinks, the loader resolves" '[ "$rc" = 0 ] && merged "$T/s1"'
check "--ssh: the calibrated board.ini is unchanged, the tree's is beside it as board.ini.dist" 'kept "$T/s1" "$T/tree"'
check "--ssh: the board's calibration file is unchanged and flash.sh says it kept it" 'calib_kept "$T/s1"'
check "--ssh: unit, udev rule, sysusers and programs under usr/; sysusers, udev reload, systemctl enable --now run" '
    installed "$T/s1" "$T/tree" && grep -qx systemd-sysusers "$T/s1.log" &&
    grep -qx "udevadm control --reload" "$T/s1.log" && grep -qx "systemctl enable --now hmdwarpd" "$T/s1.log"'
mkroot "$T/s2"
step flash_ssh "$T/s2" --tree "$T/libtree"
check "--ssh with a tree that has a real lib/: the board's lib stays a symlink, the unit lands in usr/lib" '
    [ "$rc" = 0 ] && merged "$T/s2" && [ -f "$T/s2/usr/lib/systemd/system/hmdwarpd.service" ]'

# ---- the wrong architecture ----
cp -a "$T/tree" "$T/wrong"
as_arch "$T/wrong" "$other"
mkroot "$T/w1"
snap "$T/w1" >"$T/w1.before"
step board/flash.sh --tree "$T/wrong" --root "$T/w1"
check "--root refuses a tree built for $other on a $native_name root: one line naming both, nothing written" '
    [ "$rc" != 0 ] && [ "$(wc -l <"$T/step.err")" = 1 ] &&
    grep -q "is $other but the root $T/w1 (its /usr/bin/env) is $native_name: rebuild" "$T/step.err" &&
    snap "$T/w1" | cmp - "$T/w1.before"'
mkroot "$T/w2"
snap "$T/w2" >"$T/w2.before"
step flash_ssh "$T/w2" --tree "$T/wrong"
check "--ssh refuses a tree built for $other on a $native_name board (uname -m): one line naming both, nothing written" '
    [ "$rc" != 0 ] && [ "$(wc -l <"$T/step.err")" = 1 ] &&
    grep -q "is $other but pi@board (uname -m) is $native_name: rebuild" "$T/step.err" &&
    snap "$T/w2" | cmp - "$T/w2.before" && [ ! -e "$T/w2.log" ]'
step mk_install DESTDIR="$T/rpi5" BOARD=rpi5
[ "$native_name" = x86_64 ] || as_arch "$T/rpi5" x86_64
step board/flash.sh --tree "$T/rpi5" --dry-run --board rpi5
check "--dry-run --board rpi5 refuses an x86-64 tree, naming both architectures" '
    [ "$rc" != 0 ] &&
    grep -q "hmdwarpd is x86_64 but the board rpi5 is aarch64: rebuild with CROSS_COMPILE=aarch64-linux-gnu-" "$T/step.err"'
as_arch "$T/rpi5" aarch64
step board/flash.sh --tree "$T/rpi5" --dry-run --board rpi5
check "--dry-run --board rpi5 accepts an aarch64 tree" '
    [ "$rc" = 0 ] && grep -q "programs are aarch64, as the board rpi5" "$T/step.out" &&
    grep -q "the tree is usable" "$T/step.out"'
step board/flash.sh --tree "$T/tree" --dry-run
check "--dry-run: the sim board runs on any architecture" '[ "$rc" = 0 ] && grep -q "arch = any" "$T/step.out"'

# ---- roots flash.sh must not write through ----
mkroot "$T/a1"
mkdir -p "$T/elsewhere"
ln -s "$T/elsewhere" "$T/a1/usr/lib/udev"
snap "$T/a1" >"$T/a1.before"
step board/flash.sh --tree "$T/tree" --root "$T/a1"
check "--root refuses a root whose directory symlink on the tree's path is absolute (tar would follow it here)" '
    [ "$rc" != 0 ] && grep -q "usr/lib/udev -> .* absolute" "$T/step.err" && snap "$T/a1" | cmp - "$T/a1.before" &&
    [ -z "$(ls -A "$T/elsewhere")" ]'
step "$BUILD/hmdwarpd" --check-config --config board/rpi5/board.ini --set board.arch=sparc
check "[board] arch: an unknown architecture is a configuration error naming the key" '
    [ "$rc" != 0 ] && grep -q "\[board\] arch = .sparc." "$T/step.out"'

[ "$n" = "$PLAN" ] || { echo "not ok $((n + 1)) - the plan says $PLAN tests, $n ran"; exit 1; }
