/* SPDX-License-Identifier: MIT */
/* drv_usb_speed: the USB speeds a gadget runs at, what each carries in practice, and where the kernel says which one a
 * FunctionFS function got (its UDC's current_speed / maximum_speed in sysfs, found through the mount and configfs). */
#ifndef DRV_USB_SPEED_H
#define DRV_USB_SPEED_H

#include <stdbool.h>
#include <stddef.h>

typedef enum {
    DRV_USB_SPEED_UNKNOWN = 0, /* not connected, or no UDC found */
    DRV_USB_SPEED_FULL,        /* USB 1.1, 12 Mbit/s */
    DRV_USB_SPEED_HIGH,        /* USB 2.0, 480 Mbit/s */
    DRV_USB_SPEED_SUPER,       /* USB 3.x Gen 1, 5 Gbit/s */
    DRV_USB_SPEED_SUPER_PLUS,  /* USB 3.x Gen 2 (x2), 10-20 Gbit/s */
    DRV_USB_SPEED_COUNT
} drv_usb_speed;

/* The kernel's names (usb_speed_string): "full-speed", "high-speed", "super-speed", "super-speed-plus";
 * "unknown" for DRV_USB_SPEED_UNKNOWN. */
const char *drv_usb_speed_name(drv_usb_speed s);
/* A sysfs value (trailing newline allowed) to its speed; UNKNOWN for "UNKNOWN", "low-speed", "wireless" and the
 * rest (low speed has no bulk endpoints: the function cannot run there). */
drv_usb_speed drv_usb_speed_parse(const char *s);
/* Bulk payload a board's link carries in practice at this speed, MB/s (10^6 bytes): FS 1.2, HS 40 (the Pi 5's dwc2
 * port measures 35-40), SS 400, SS+ 800; 0 for UNKNOWN (docs/link-budget.md). */
double drv_usb_speed_mbps(drv_usb_speed s);

/* Where the function mounted at ffs_dir is bound: the FunctionFS mount's instance name (root/proc/self/mountinfo),
 * the configfs gadget whose functions/ffs.NAME it is and that gadget's UDC (root/sys/kernel/config/usb_gadget); a
 * gadget not yet bound (hmdwarpd writes the descriptors before board/gadget.sh binds) falls back to the first UDC in
 * root/sys/class/udc, the one gadget.sh binds by default. `root` is "" on a board (a directory tree in tests).
 * False (udc "") when there is none. */
bool drv_usb_udc_of(const char *root, const char *ffs_dir, char *udc, size_t len);
/* The UDC's root/sys/class/udc/UDC/current_speed (the speed negotiated with the host; UNKNOWN while not
 * connected), or with `maximum` its maximum_speed (what the controller can do). */
drv_usb_speed drv_usb_udc_speed(const char *root, const char *udc, bool maximum);

#endif
