#!/bin/sh
# SPDX-License-Identifier: MIT
# Patches the upstream gpio-sim.c and irq_sim.c (copied into DIR) so they build as one module against Debian's
# headers, and vkms's vblank timer so that it cannot deadlock the VM (vkms_crtc.c, vkms_drv.c). Each edit is
# checked: if the upstream text changes, this fails instead of building something else.
# usage: tests/hil/kmod/patch.sh DIR
set -eu
dir=$1

# irq_sim.c fires the simulated interrupt with handle_simple_irq(irq_to_desc(irq)); irq_to_desc is not exported
# to modules. generic_handle_irq looks the descriptor up itself and runs its flow handler, which irq_sim's
# domain map set to handle_simple_irq: the same path.
grep -q 'handle_simple_irq(irq_to_desc(irqnum));' "$dir/irq_sim.c" ||
    { echo "kmod/patch.sh: irq_sim.c: expected handle_simple_irq(irq_to_desc(irqnum)) not found" >&2; exit 1; }
sed -i 's/handle_simple_irq(irq_to_desc(irqnum));/generic_handle_irq(irqnum);/' "$dir/irq_sim.c"
! grep -q 'irq_to_desc' "$dir/irq_sim.c" ||
    { echo "kmod/patch.sh: irq_sim.c still uses irq_to_desc" >&2; exit 1; }

# irq_sim.c is built into the kernel upstream and has no module licence; the driver's MODULE_LICENSE("GPL")
# covers the whole module, so nothing to add. gpio-sim.c includes the private "gpiolib.h", which build.sh copies
# next to it.
grep -q '#include "gpiolib.h"' "$dir/gpio_sim_drv.c" ||
    { echo "kmod/patch.sh: gpio-sim.c no longer includes gpiolib.h: check the recipe" >&2; exit 1; }
grep -q 'MODULE_LICENSE("GPL")' "$dir/gpio_sim_drv.c" ||
    { echo "kmod/patch.sh: gpio-sim.c without MODULE_LICENSE(\"GPL\")" >&2; exit 1; }

# vkms 6.1's vblank timer can deadlock both CPUs of an SMP machine (tests/hil/README.md, "the hang"): turning the
# vblank interrupt off (drm_vblank_disable_and_save: a CRTC switched off, or the vblank off delay expiring) holds
# drm's vblank_time_lock with interrupts off and calls vkms_disable_vblank, whose hrtimer_cancel waits for a
# running vkms_vblank_simulate; that callback, on the other CPU, spins in drm_handle_vblank on the same
# vblank_time_lock. Both CPUs spin with interrupts off for ever: a silent whole-VM hang (no NMI watchdog under
# TCG). The fix, as posted for the stable trees (mainline replaced this code with drm's generic vblank timer):
# disable only tries to cancel (never waits), and the callback stops re-arming once drm_handle_vblank reports
# the vblank off. The timer is set up once at CRTC init instead of at every enable, so an enable never
# re-initialises a timer whose callback is still running on the other CPU (hrtimer_start restarts it safely), and
# the device's release cancels it (no locks held there) so that no late tick runs after the module is gone.
c=$dir/vkms_crtc.c
# patch_line FILE OLD [NEW]: replace the one line equal to OLD (fixed string, leading tabs included) with NEW
# (lines; none: delete it). Fails when OLD is not there exactly once (upstream changed: check the recipe).
patch_line() {
    [ "$(grep -cxF "$2" "$1")" = 1 ] || { echo "kmod/patch.sh: $(basename "$1"): expected one line '$2'" >&2; exit 1; }
    OLD=$2 NEW=${3:-} DEL=${3+0} awk '$0 == ENVIRON["OLD"] { if (ENVIRON["DEL"] == "0") print ENVIRON["NEW"]; next } { print }' \
        "$1" >"$1.new" && mv "$1.new" "$1"
}
tab=$(printf '\t')
# (its own variable: `ret` is reused for queue_work's result, false whenever the CRC composer falls behind; a
# version returning `ret` stopped the timer with the vblank on during CRC capture: flip_done timed out)
patch_line "$c" "${tab}bool ret, fence_cookie;" "${tab}bool ret, handled, fence_cookie;"
patch_line "$c" "${tab}ret = drm_crtc_handle_vblank(crtc);" "${tab}ret = handled = drm_crtc_handle_vblank(crtc);"
patch_line "$c" "${tab}return HRTIMER_RESTART;" "${tab}return handled ? HRTIMER_RESTART : HRTIMER_NORESTART;"
patch_line "$c" "${tab}hrtimer_cancel(&out->vblank_hrtimer);" "${tab}hrtimer_try_to_cancel(&out->vblank_hrtimer);"
patch_line "$c" "${tab}hrtimer_init(&out->vblank_hrtimer, CLOCK_MONOTONIC, HRTIMER_MODE_REL);"
patch_line "$c" "${tab}out->vblank_hrtimer.function = &vkms_vblank_simulate;"
patch_line "$c" "${tab}spin_lock_init(&vkms_out->composer_lock);" "${tab}spin_lock_init(&vkms_out->composer_lock);
${tab}hrtimer_init(&vkms_out->vblank_hrtimer, CLOCK_MONOTONIC, HRTIMER_MODE_REL);
${tab}vkms_out->vblank_hrtimer.function = &vkms_vblank_simulate;"
patch_line "$dir/vkms_drv.c" "${tab}if (vkms->output.composer_workq)" "${tab}if (vkms->output.vblank_hrtimer.function)
${tab}${tab}hrtimer_cancel(&vkms->output.vblank_hrtimer);
${tab}if (vkms->output.composer_workq)"
