#!/bin/sh
# SPDX-License-Identifier: MIT
# Patches the upstream gpio-sim.c and irq_sim.c (copied into DIR) so they build as one module against Debian's
# headers. Each edit is checked: if the upstream text changes, this fails instead of building something else.
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
