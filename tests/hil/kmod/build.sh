#!/bin/sh
# Builds gpio-sim.ko for the cached Debian kernel (board/deps-hil.sh fetched it): extracts gpio-sim.c, its
# private gpiolib.h and irq_sim.c from Debian's linux-source tarball, patches them (patch.sh) and builds them as
# one out-of-tree module against the matching linux-headers. Nothing from the kernel tree lives in this repo.
# usage: tests/hil/kmod/build.sh [CACHE [OUTDIR]]   (defaults build/hil/cache, build/hil/kmod)
# Prints the path of the .ko on success.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
CACHE=${1:-build/hil/cache}
OUT=${2:-build/hil/kmod}

[ -s "$CACHE/kabi" ] || { echo "kmod: no kernel cache in $CACHE (run board/deps-hil.sh)" >&2; exit 1; }
KABI=$(cut -d' ' -f1 "$CACHE/kabi")
SERIES=${KABI%%.0-*}
HDR=$(cd "$CACHE/root/usr/src/linux-headers-$KABI" && pwd)
SRC=$(ls "$CACHE/root/usr/src/linux-source-$SERIES.tar."* | head -n 1)

ko=$OUT/gpio-sim.ko
# Up to date: built for this ABI and newer than the recipe.
if [ -f "$ko" ] && [ "$(cat "$OUT/kabi" 2>/dev/null)" = "$KABI" ] &&
   [ "$ko" -nt "$here/Kbuild" ] && [ "$ko" -nt "$here/patch.sh" ] && [ "$ko" -nt "$here/build.sh" ]; then
    echo "$ko"; exit 0
fi

rm -rf "$OUT"; mkdir -p "$OUT/src"
top=linux-source-$SERIES
tar -xf "$SRC" -C "$OUT/src" "$top/drivers/gpio/gpio-sim.c" "$top/drivers/gpio/gpiolib.h" "$top/kernel/irq/irq_sim.c"
cp "$OUT/src/$top/drivers/gpio/gpio-sim.c" "$OUT/gpio_sim_drv.c"
cp "$OUT/src/$top/drivers/gpio/gpiolib.h" "$OUT/gpiolib.h"
cp "$OUT/src/$top/kernel/irq/irq_sim.c" "$OUT/irq_sim.c"
rm -rf "$OUT/src"
"$here/patch.sh" "$OUT"
cp "$here/Kbuild" "$OUT/Kbuild"

absout=$(cd "$OUT" && pwd)
log=$OUT/build.log
if ! make -C "$HDR" M="$absout" modules >"$log" 2>&1; then
    tail -n 30 "$log" >&2
    echo "kmod: gpio-sim build failed (log: $log)" >&2
    exit 1
fi
modinfo -F vermagic "$ko" | grep -q "^$KABI " ||
    { echo "kmod: $ko has vermagic '$(modinfo -F vermagic "$ko")', expected $KABI" >&2; exit 1; }
echo "$KABI" >"$OUT/kabi"
echo "$ko"
