#!/bin/sh
# SPDX-License-Identifier: MIT
# Installs the packages `make deb` built into a throwaway root (dpkg --root, an empty dpkg database) and checks
# what landed: unit enabled, udev rules, system user, conffile, man pages, --version, no calibration file; then that
# an edited conffile and the board's calibration file (/var/lib/hmdwarp, the unit's state) survive a reinstall and
# that a purge removes the conffile. TAP output. Maintainer scripts run chrootless with
# DPKG_ROOT set (the root has no shell; systemd-sysusers and deb-systemd-helper honour DPKG_ROOT), and the
# packages' library dependencies are not in the root (--force-depends); the programs run with this host's libraries.
# Not root: under fakeroot. Part of make test (after `make deb`, under a minute here) and of make deb-check.
# usage: tests/packaging/test_deb.sh [DIR]   (DIR: the .deb files; default $BUILD/deb/<this machine's arch>)
set -u
dir=${1:-${BUILD:-build}/deb/$(dpkg --print-architecture)}
if ! ls "$dir"/hmdwarpd_*.deb >/dev/null 2>&1; then
    echo "1..1"
    echo "not ok 1 - no hmdwarpd package in $dir (make deb builds it)"
    exit 1
fi
root=$(cd "$dir" && pwd)/root
fake=""
[ "$(id -u)" -eq 0 ] || fake=fakeroot
version=$(dpkg-parsechangelog -S Version)
# shellcheck source=tests/support/tap.sh
. "$(dirname "$0")/../support/tap.sh"
check() { d=$1; shift; if "$@" >"$dir/check.out" 2>&1; then ok "$d"; else not_ok "$d" "$(head -n 3 "$dir/check.out")"; fi; }
dpkg_root() { $fake dpkg --root="$root" --force-script-chrootless --force-depends "$@"; }
echo "1..20"

rm -rf "$root"
mkdir -p "$root/var/lib/dpkg/info" "$root/var/lib/dpkg/updates" "$root/etc"
touch "$root/var/lib/dpkg/status" "$root/var/lib/dpkg/available"
check "dpkg -i hmdwarpd and hmdwarp-host into $root" \
    dpkg_root -i "$dir"/hmdwarpd_"$version"_*.deb "$dir"/hmdwarp-host_"$version"_*.deb \
    "$dir"/libhmdwarp-host0_"$version"_*.deb "$dir"/libhmdwarp-host-dev_"$version"_*.deb
for p in hmdwarpd hmdwarp-host; do
    check "$p is installed" sh -c "$fake dpkg --root='$root' -s $p | grep -qx 'Status: install ok installed'"
done
check "the unit is installed and enabled" \
    sh -c "[ -f '$root/lib/systemd/system/hmdwarpd.service' ] && [ -L '$root/etc/systemd/system/multi-user.target.wants/hmdwarpd.service' ]"
check "the board's udev rules" grep -q 'SYMLINK+="hmdwarp-imu"' "$root/lib/udev/rules.d/99-hmdwarp.rules"
check "the host's udev rule: uaccess for 1d6b:0104" \
    grep -q 'ATTR{idVendor}=="1d6b", ATTR{idProduct}=="0104", TAG+="uaccess"' "$root/lib/udev/rules.d/60-hmdwarp-host.rules"
check "the system user hmdwarp (sysusers ran)" grep -q '^hmdwarp:' "$root/etc/passwd"
check "/etc/hmdwarp/board.ini is a conffile" grep -qx /etc/hmdwarp/board.ini "$root/var/lib/dpkg/info/hmdwarpd.conffiles"
check "/etc/hmdwarp/board.ini is the generic board's" cmp board/generic-aarch64/board.ini "$root/etc/hmdwarp/board.ini"
check "the installed board.ini is valid" \
    "$root/usr/bin/hmdwarpd" --check-config --config "$root/etc/hmdwarp/board.ini"
check "libhmdwarp-host0 and -dev: the library by its soname, the header, the .pc, hmdwarp-feed depends on it" \
    sh -c "ls '$root'/usr/lib/*/libhmdwarp-host.so.0 && [ -f '$root/usr/include/hmdwarp-host.h' ] &&
    ls '$root'/usr/lib/*/pkgconfig/hmdwarp-host.pc && $fake dpkg --root='$root' -s hmdwarp-host | grep -q '^Depends:.*libhmdwarp-host0'"
# hmdwarp-feed loads libhmdwarp-host0's library from the root (the dynamic loader's paths are this host's).
libdir=$root/usr/lib/$(dpkg-architecture -qDEB_HOST_MULTIARCH)
for p in hmdwarpd hmdwarp-feed; do
    check "installed $p --version prints '$p $version'" \
        sh -c "[ \"\$(LD_LIBRARY_PATH='$libdir' '$root/usr/bin/$p' --version)\" = '$p $version' ]"
done
check "man pages: seven in section 1 (hmdwarp-gadget and hmdwarp-top too), board.ini's in 5" sh -c "[ \$(ls '$root'/usr/share/man/man1/hmdwarp*.1.gz | wc -l) -eq 7 ] &&
    zcat '$root/usr/share/man/man5/hmdwarp-board.ini.5.gz' | grep -q '^\.TH HMDWARP-BOARD.INI 5'"
check "hmdwarp-gadget and the board definitions with the generic board's README" \
    sh -c "[ -x '$root/usr/bin/hmdwarp-gadget' ] && [ -f '$root/usr/share/hmdwarp/boards/rpi5/board.ini' ] &&
    grep -q 'FILL IN' '$root/usr/share/hmdwarp/boards/generic-aarch64/README.md'"
check "the project's README in /usr/share/doc/hmdwarpd" \
    sh -c "zcat -f '$root'/usr/share/doc/hmdwarpd/README.md* | head -n 1 | grep -qx '# hmdwarp'"

check "the package ships no calibration file (the unit's own, written on the board)" \
    sh -c "! dpkg-deb -c '$dir'/hmdwarpd_'$version'_*.deb | grep -q calibration && [ ! -e '$root/var/lib/hmdwarp/calibration.ini' ]"

# An edited conffile and the board's calibration survive a reinstall; a purge removes the conffile with the unit's
# enablement.
echo "; edited on the board" >>"$root/etc/hmdwarp/board.ini"
mkdir -p "$root/var/lib/hmdwarp"
printf '; this unit\n[imu]\ngyro_bias = 0.001 0.002 0.003\n' >"$root/var/lib/hmdwarp/calibration.ini"
cp "$root/var/lib/hmdwarp/calibration.ini" "$dir/calibration.before"
dpkg_root -i "$dir"/hmdwarpd_"$version"_*.deb >"$dir/check.out" 2>&1
check "an edited board.ini survives a reinstall" grep -qx '; edited on the board' "$root/etc/hmdwarp/board.ini"
check "the board's calibration file survives a reinstall unchanged" \
    cmp "$dir/calibration.before" "$root/var/lib/hmdwarp/calibration.ini"
dpkg_root --purge hmdwarpd >"$dir/check.out" 2>&1
check "a purge removes board.ini and the unit's enablement" sh -c "[ ! -e '$root/etc/hmdwarp/board.ini' ] &&
    [ ! -e '$root/etc/systemd/system/multi-user.target.wants/hmdwarpd.service' ] && [ ! -e '$root/usr/bin/hmdwarpd' ]"
echo "$((n - fails)) passed, $fails failed"
exit $((fails > 0))
