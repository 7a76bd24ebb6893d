#!/bin/sh
# SPDX-License-Identifier: MIT
# Installs what `make hil` needs (qemu, busybox, module tools) and fetches Debian's own kernel into a cache:
# the linux-image, -headers (+ -common, linux-kbuild) and linux-source packages of one ABI, downloaded with
# `apt-get download` (never installed on this host) and unpacked under build/hil/cache.
#
# As root it runs apt-get install for missing tools; otherwise it prints the exact command and fails.
# Downloading the kernel packages needs no root. Re-running is cheap: a complete cache is left alone.
#
# Knobs: HIL_CACHE (default build/hil/cache), HIL_KABI (e.g. 6.1.0-57-amd64; default: the ABI that apt's
# linux-image-amd64 depends on, so image, headers and source all come from the same Debian upload).
set -eu

CACHE=${HIL_CACHE:-${BUILD:-build}/hil/cache}

# Tools on the host: qemu (TCG, no KVM needed), the initramfs parts (busybox, cpio, kmod for depmod),
# compression tools for the kernel packages, the out-of-tree module build (gcc/make + what kbuild calls),
# and debugging aids that also go into the VM (gpiod, v4l-utils).
PKGS="qemu-system-x86 busybox-static cpio kmod xz-utils zstd
gcc make libelf-dev bc flex bison binutils
gpiod v4l-utils"

. "$(dirname "$0")/deps-lib.sh"
deps_install deps-hil $PKGS

# A complete cache records its ABI in $CACHE/kabi (written last).
if [ -z "${HIL_KABI:-}" ] && [ -s "$CACHE/kabi" ] && [ -s "$CACHE/root/kver" ]; then
    exit 0
fi

# The ABI and package version: follow the linux-image-amd64 metapackage so all packages match.
dep_of_meta() {
    apt-cache show --no-all-versions linux-image-amd64 2>/dev/null |
        sed -n 's/^Depends:.*linux-image-\(6\.[0-9]*\.[0-9]*-[0-9]*-amd64\) (= \([^)]*\)).*/\1 \2/p' | head -n 1
}
if [ -n "${HIL_KABI:-}" ]; then
    KABI=$HIL_KABI
    VER=$(apt-cache show --no-all-versions "linux-image-$KABI" 2>/dev/null | sed -n 's/^Version: //p' | head -n 1)
else
    set -- $(dep_of_meta)
    if [ $# -ne 2 ] && [ "$(id -u)" -eq 0 ]; then
        apt-get update -qq
        set -- $(dep_of_meta)
    fi
    [ $# -eq 2 ] || { echo "deps-hil: apt knows no linux-image-amd64 (apt-get update?)" >&2; exit 1; }
    KABI=$1; VER=$2
fi
[ -n "$VER" ] || { echo "deps-hil: apt knows no linux-image-$KABI" >&2; exit 1; }
FLAVOUR=${KABI##*-}                 # amd64
COMMON=${KABI%-"$FLAVOUR"}-common   # 6.1.0-57-common
SERIES=${KABI%%.0-*}                # 6.1

# Image: the signed package when apt has it (same bits as -unsigned, plus the signature).
IMG=linux-image-$KABI
if ! apt-cache show "$IMG=$VER" >/dev/null 2>&1; then IMG=linux-image-$KABI-unsigned; fi
DEBS="$IMG=$VER linux-headers-$KABI=$VER linux-headers-$COMMON=$VER linux-kbuild-$SERIES=$VER
linux-source-$SERIES=$VER"

echo "deps-hil: kernel $KABI ($VER) into $CACHE"
mkdir -p "$CACHE/debs"
rm -rf "$CACHE/root" "$CACHE/kabi"
for d in $DEBS; do
    name=${d%%=*}
    # Debian's file names drop the epoch; the architecture part is amd64 or all.
    pat="$CACHE/debs/${name}_${VER#*:}_"
    if ! ls "$pat"*.deb >/dev/null 2>&1; then
        echo "deps-hil: downloading $d"
        (cd "$CACHE/debs" && apt-get download -qq "$d" 2>&1 | grep -v 'unsandboxed as root' >&2 || true)
    fi
    deb=$(ls "$pat"*.deb 2>/dev/null | head -n 1)
    [ -n "$deb" ] || { echo "deps-hil: download of $d failed (no ${pat}*.deb)" >&2; exit 1; }
    echo "deps-hil: unpacking $(basename "$deb")"
    dpkg-deb -x "$deb" "$CACHE/root"
done

# The headers' Makefile includes the -common one by its installed path (/usr/src/...): point it into the cache.
HDR=$CACHE/root/usr/src/linux-headers-$KABI
sed -i "s|^include /usr/src/|include $(cd "$CACHE/root/usr/src" && pwd)/|" "$HDR/Makefile"

# The image package leaves modules.dep to its postinst: generate it so module dependencies can be resolved.
depmod -b "$CACHE/root" -F "$CACHE/root/boot/System.map-$KABI" "$KABI"

# What the rest of the recipe reads: the ABI, the kernel, the module tree, the headers' build dir, the source.
R=$CACHE/root
[ -f "$R/boot/vmlinuz-$KABI" ] || { echo "deps-hil: no $R/boot/vmlinuz-$KABI" >&2; exit 1; }
[ -d "$R/lib/modules/$KABI/kernel" ] || { echo "deps-hil: no module tree in $R/lib/modules/$KABI" >&2; exit 1; }
[ -f "$R/usr/src/linux-headers-$KABI/Makefile" ] || { echo "deps-hil: no headers for $KABI" >&2; exit 1; }
ls "$R/usr/src/linux-source-$SERIES.tar."* >/dev/null 2>&1 || { echo "deps-hil: no linux-source tarball" >&2; exit 1; }
echo "$KABI" >"$R/kver"
echo "$KABI $VER" >"$CACHE/kabi"
echo "deps-hil: kernel cache ready: $KABI"
