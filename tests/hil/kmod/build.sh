#!/bin/sh
# SPDX-License-Identifier: MIT
# Builds gpio-sim.ko and vkms.ko for the cached Debian kernel (board/deps-hil.sh fetched it): extracts
# gpio-sim.c, its private gpiolib.h, irq_sim.c and drivers/gpu/drm/vkms/ from Debian's linux-source tarball (one
# pass: decompressing the tarball is most of the time), patches gpio-sim (patch.sh) and builds both as
# out-of-tree modules against the matching linux-headers. Nothing from the kernel tree lives in this repo.
# usage: tests/hil/kmod/build.sh [CACHE [OUTDIR]]   (defaults build/hil/cache, build/hil/kmod)
# Prints the paths of the .ko files on success, one a line.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
CACHE=${1:-build/hil/cache}
OUT=${2:-build/hil/kmod}

[ -s "$CACHE/kabi" ] || { echo "kmod: no kernel cache in $CACHE (run board/deps-hil.sh)" >&2; exit 1; }
KABI=$(cut -d' ' -f1 "$CACHE/kabi")
SERIES=${KABI%%.0-*}
HDR=$(cd "$CACHE/root/usr/src/linux-headers-$KABI" && pwd)
SRC=$(ls "$CACHE/root/usr/src/linux-source-$SERIES.tar."* | head -n 1)

KOS="$OUT/gpio-sim.ko $OUT/vkms.ko"
# Up to date: built for this ABI and newer than the recipe.
fresh=1
for ko in $KOS; do
    [ -f "$ko" ] && [ "$ko" -nt "$here/Kbuild" ] && [ "$ko" -nt "$here/patch.sh" ] && [ "$ko" -nt "$here/build.sh" ] ||
        fresh=0
done
if [ "$fresh" = 1 ] && [ "$(cat "$OUT/kabi" 2>/dev/null)" = "$KABI" ]; then
    for ko in $KOS; do echo "$ko"; done; exit 0
fi

rm -rf "$OUT"; mkdir -p "$OUT/src"
top=linux-source-$SERIES
vk=drivers/gpu/drm/vkms
tar -xf "$SRC" -C "$OUT/src" "$top/drivers/gpio/gpio-sim.c" "$top/drivers/gpio/gpiolib.h" "$top/kernel/irq/irq_sim.c" \
    "$top/$vk"
cp "$OUT/src/$top/drivers/gpio/gpio-sim.c" "$OUT/gpio_sim_drv.c"
cp "$OUT/src/$top/drivers/gpio/gpiolib.h" "$OUT/gpiolib.h"
cp "$OUT/src/$top/kernel/irq/irq_sim.c" "$OUT/irq_sim.c"
# vkms's files flat next to gpio-sim's (they include each other by bare name); Kbuild lists its objects.
cp "$OUT/src/$top/$vk"/*.c "$OUT/src/$top/$vk"/*.h "$OUT/"
rm -rf "$OUT/src"
"$here/patch.sh" "$OUT"
cp "$here/Kbuild" "$OUT/Kbuild"

absout=$(cd "$OUT" && pwd)
log=$OUT/build.log
if ! make -C "$HDR" M="$absout" modules >"$log" 2>&1; then
    tail -n 30 "$log" >&2
    echo "kmod: gpio-sim/vkms build failed (log: $log)" >&2
    exit 1
fi
for ko in $KOS; do
    modinfo -F vermagic "$ko" | grep -q "^$KABI " ||
        { echo "kmod: $ko has vermagic '$(modinfo -F vermagic "$ko")', expected $KABI" >&2; exit 1; }
done
echo "$KABI" >"$OUT/kabi"
for ko in $KOS; do echo "$ko"; done
