#!/bin/sh
# SPDX-License-Identifier: MIT
# Builds the HIL test VM's initramfs: busybox, /init (tests/hil/init), the kernel modules the mock devices need
# (from Debian's image package, dependencies resolved with its modules.dep, plus our out-of-tree gpio-sim.ko and
# vkms.ko),
# hmdwarpd, hmdwarp-feed and the in-VM device programs (build/hil/*), every shared library they load, the
# scenarios and the HIL board files. Also extracts the uncompressed vmlinux (qemu boots it directly via PVH,
# skipping the decompressor, which is slow under TCG).
# usage: tests/hil/build-initramfs.sh   (env: BUILD=build, HIL_CACHE=build/hil/cache)
# Output: $BUILD/hil/initramfs.cpio and $BUILD/hil/vmlinux
set -eu
PATH=$PATH:/sbin:/usr/sbin
BUILD=${BUILD:-build}
CACHE=${HIL_CACHE:-$BUILD/hil/cache}
here=$(cd "$(dirname "$0")" && pwd)
top=$(cd "$here/../.." && pwd)
die() { echo "hil-initramfs: $*" >&2; exit 1; }

[ -s "$CACHE/kabi" ] || die "no kernel cache in $CACHE (board/deps-hil.sh)"
KABI=$(cut -d' ' -f1 "$CACHE/kabi")
SERIES=${KABI%%.0-*}
KR=$(cd "$CACHE/root" && pwd)
for b in "$BUILD/hmdwarpd" "$BUILD/hmdwarp-feed"; do [ -x "$b" ] || die "$b not built (make all)"; done
BUSYBOX=$(command -v busybox) || die "no busybox (busybox-static)"
! ldd "$BUSYBOX" >/dev/null 2>&1 || die "$BUSYBOX is not statically linked (install busybox-static)"

# Modules the scenarios load (modprobe resolves the rest inside the VM from the depmod output below).
MODULES="configfs uhid hid hid-generic usbhid i2c-dev i2c-stub vivid dummy_hcd libcomposite usb_f_fs"

KOS=$("$here/kmod/build.sh" "$CACHE" "$BUILD/hil/kmod") || die "gpio-sim/vkms module build failed"
# The out-of-tree modules' dependencies (vkms: drm, drm_kms_helper, drm_shmem_helper) come from the image.
for ko in $KOS; do
    MODULES="$MODULES $(modinfo -F depends "$ko" | tr , ' ')"
done

S=$BUILD/hil/initramfs
rm -rf "$S"
mkdir -p "$S/bin" "$S/sbin" "$S/usr/bin" "$S/usr/sbin" "$S/lib64" "$S/dev" "$S/proc" "$S/sys" "$S/tmp" \
    "$S/run" "$S/etc" "$S/hil/bin" "$S/hil/scenarios" "$S/hil/boards" "$S/mnt" "$S/root"

# busybox and its applets (mountpoint is not one of Debian's: a shell stand-in from init/).
cp "$BUSYBOX" "$S/bin/busybox"
for a in $("$BUSYBOX" --list); do
    [ "$a" = busybox ] || ln -s busybox "$S/bin/$a"
done
for a in modprobe insmod rmmod lsmod depmod modinfo poweroff reboot halt; do
    rm -f "$S/bin/$a"; ln -s ../bin/busybox "$S/sbin/$a"
done

# Modules: the closure of $MODULES from the image's modules.dep, at their tree paths, then depmod on the subset.
M=$S/lib/modules/$KABI
mkdir -p "$M/extra"
for m in $MODULES; do
    modprobe -d "$KR" -S "$KABI" --show-depends "$m" 2>/dev/null | while read -r kind path _; do
        [ "$kind" = insmod ] || continue     # "builtin NAME" needs nothing
        rel=${path#"$KR"/}; rel=${rel#./}
        mkdir -p "$S/$(dirname "$rel")"
        cp "$path" "$S/$rel"
    done
    modprobe -d "$KR" -S "$KABI" --show-depends "$m" >/dev/null 2>&1 || die "module $m not in $KABI"
done
for ko in $KOS; do cp "$ko" "$M/extra/"; done
for f in modules.order modules.builtin modules.builtin.modinfo; do
    [ -f "$KR/lib/modules/$KABI/$f" ] && cp "$KR/lib/modules/$KABI/$f" "$M/"
done
depmod -b "$S" "$KABI"

# Programs and the libraries they load (ldd: libudev for hidapi/libusb, libgpiod, libi2c, ...).
progs="$BUILD/hmdwarpd $BUILD/hmdwarp-feed"
for p in "$BUILD"/hil/*; do
    [ -f "$p" ] && [ -x "$p" ] && case "$p" in *.cpio|*.sh) ;; *) progs="$progs $p" ;; esac
done
for p in $progs; do cp "$p" "$S/hil/bin/"; done
# hmdwarp-feed loads libhmdwarp-host from beside it (its rpath is $ORIGIN), as in the build tree.
cp "$BUILD/libhmdwarp-host.so.0" "$S/hil/bin/"
cp "$top/board/gadget.sh" "$S/hil/bin/gadget.sh"
# chrt (util-linux): the device stand-ins run at real-time priority (scenarios/lib.sh hil_device).
extra=$(command -v chrt) || die "no chrt (util-linux)"
cp "$extra" "$S/usr/bin/"
# Debugging aids when the host has them: v4l2-ctl sets vivid's controls, gpiomon/gpioget/gpioinfo show edges.
for t in v4l2-ctl gpiomon gpioget gpioset gpioinfo gpiodetect; do
    t=$(command -v "$t" 2>/dev/null) || continue
    cp "$t" "$S/usr/bin/"; extra="$extra $t"
done
# GLES on the KMS output (05-kms): hmdwarpd links glvnd's libEGL, which finds Mesa through its vendor JSON; Mesa's
# libEGL_mesa then loads the DRI driver (kms_swrast for GBM on vkms, swrast for the surfaceless offscreen
# display: one file, hard links in Debian and here) and libLLVM for llvmpipe. ldd of both brings the rest.
# Whenever 05-kms runs GLES (its default HIL_KMS_RENDERERS=cpu,gles, or one naming gles; HIL_GLES=1 forces it,
# HIL_GLES=0 or HIL_KMS=0 leaves it out): ~200 MB and ~4 s of boot.
mesa=""
[ "${HIL_KMS:-1}" = 0 ] && HIL_GLES=${HIL_GLES:-0}
case ",${HIL_KMS_RENDERERS:-cpu,gles}," in *,gles,*) HIL_GLES=${HIL_GLES:-1} ;; esac
if [ "${HIL_GLES:-0}" = 1 ]; then
    egl_mesa=$(ldconfig -p | awk '/libEGL_mesa.so.0 .*x86-64/{print $NF; exit}')
    dri=$(pkg-config --variable=dridriverdir dri 2>/dev/null) || dri=/usr/lib/x86_64-linux-gnu/dri   # dri.pc: mesa-common-dev
    json=/usr/share/glvnd/egl_vendor.d/50_mesa.json
    if [ -n "$egl_mesa" ] && [ -f "$dri/kms_swrast_dri.so" ] && [ -f "$json" ]; then
        mkdir -p "$S$dri" "$S$(dirname "$json")"
        cp "$json" "$S$json"
        cp "$dri/kms_swrast_dri.so" "$S$dri/"
        ln "$S$dri/kms_swrast_dri.so" "$S$dri/swrast_dri.so"
        mesa="$egl_mesa $dri/kms_swrast_dri.so"
        cp -L "$egl_mesa" "$S/lib64/" && mkdir -p "$S$(dirname "$egl_mesa")" && mv "$S/lib64/$(basename "$egl_mesa")" "$S$egl_mesa"
    else
        echo "hil-initramfs: no Mesa EGL/DRI on this host (libegl-mesa0, libgl1-mesa-dri): 05-kms runs without GLES"
    fi
fi
libs=$(for p in $progs $extra $mesa; do ldd "$p" 2>/dev/null; done | awk '/=> \//{print $3} /^\t\/.*ld-linux/{print $1}' | sort -u)
for l in $libs; do
    mkdir -p "$S$(dirname "$l")"
    cp -L "$l" "$S$l"
done
[ -e "$S/lib64/ld-linux-x86-64.so.2" ] || cp -L /lib64/ld-linux-x86-64.so.2 "$S/lib64/"

# /init, its helpers, the scenarios and board files.
cp "$here/init/init" "$S/init"
for f in "$here"/init/*; do
    [ "$(basename "$f")" = init ] || cp "$f" "$S/hil/bin/"
done
cp "$here"/scenarios/*.sh "$S/hil/scenarios/"
cp "$top/board/sim/board.ini" "$S/hil/sim-board.ini"   # base for boards that only override a few keys
if [ -d "$here/boards" ]; then cp "$here"/boards/* "$S/hil/boards/" 2>/dev/null || true; fi
chmod +x "$S/init" "$S"/hil/bin/* "$S"/hil/scenarios/*.sh
echo "hil" >"$S/etc/hostname"
echo "0123456789abcdef0123456789abcdef" >"$S/etc/machine-id"
echo "root:x:0:0:root:/root:/bin/sh" >"$S/etc/passwd"
echo "root:x:0:" >"$S/etc/group"
echo "$KABI" >"$S/hil/kabi"

(cd "$S" && find . | LC_ALL=C sort | cpio -o -H newc --quiet) >"$BUILD/hil/initramfs.cpio"

# The uncompressed kernel: extract-vmlinux from the same source tarball.
V=$BUILD/hil/vmlinux
if [ ! -s "$V" ] || [ "$(cat "$V.kabi" 2>/dev/null)" != "$KABI" ]; then
    src=$(ls "$KR/usr/src/linux-source-$SERIES.tar."* | head -n 1)
    tar -xf "$src" -O "linux-source-$SERIES/scripts/extract-vmlinux" >"$BUILD/hil/extract-vmlinux"
    sh "$BUILD/hil/extract-vmlinux" "$KR/boot/vmlinuz-$KABI" >"$V.tmp" || die "extract-vmlinux failed"
    mv "$V.tmp" "$V"; echo "$KABI" >"$V.kabi"
fi
echo "hil-initramfs: $BUILD/hil/initramfs.cpio ($(du -k "$BUILD/hil/initramfs.cpio" | cut -f1) KiB, kernel $KABI)"
