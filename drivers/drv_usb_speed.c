/* SPDX-License-Identifier: MIT */
/* drv_usb_speed: USB speed names and practical rates, and the sysfs/configfs walk from a FunctionFS mount to the UDC
 * it is bound to and the speed that UDC reports. */
#include "drivers/drv_usb_speed.h"

#include <dirent.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

static const char *const names[DRV_USB_SPEED_COUNT] = {"unknown", "full-speed", "high-speed", "super-speed",
                                                        "super-speed-plus"};
/* MB/s of bulk payload: FS and HS after protocol overhead (HS: the Pi 5's dwc2 port measures 35-40); SS: what USB 3
 * device controllers reach (field notes: 350-400); SS+: half its 10 Gbit/s line rate, unmeasured. */
static const double usable_mbps[DRV_USB_SPEED_COUNT] = {0, 1.2, 40, 400, 800};

const char *drv_usb_speed_name(drv_usb_speed s)
{
    return (unsigned)s < DRV_USB_SPEED_COUNT ? names[s] : names[0];
}

drv_usb_speed drv_usb_speed_parse(const char *s)
{
    size_t n = strcspn(s, "\n");
    for (int i = 1; i < DRV_USB_SPEED_COUNT; i++)
        if (strlen(names[i]) == n && strncmp(s, names[i], n) == 0) return (drv_usb_speed)i;
    return DRV_USB_SPEED_UNKNOWN;
}

double drv_usb_speed_mbps(drv_usb_speed s)
{
    return (unsigned)s < DRV_USB_SPEED_COUNT ? usable_mbps[s] : 0;
}

/* The first line of a small sysfs/configfs file, without its newline; false when unreadable or empty. */
static bool read_line(const char *path, char *buf, size_t len)
{
    FILE *f = fopen(path, "r");
    if (!f) return false;
    bool ok = fgets(buf, (int)len, f) != NULL;
    fclose(f);
    if (!ok) return false;
    buf[strcspn(buf, "\n")] = 0;
    return buf[0] != 0;
}

/* mountinfo writes space, tab, newline and backslash in paths as \ooo. */
static void unescape(char *s)
{
    char *w = s;
    for (char *r = s; *r; r++) {
        if (r[0] == '\\' && r[1] >= '0' && r[1] <= '3' && r[2] >= '0' && r[2] <= '7' && r[3] >= '0' && r[3] <= '7') {
            *w++ = (char)((r[1] - '0') * 64 + (r[2] - '0') * 8 + (r[3] - '0'));
            r += 3;
        } else {
            *w++ = *r;
        }
    }
    *w = 0;
}

/* The FunctionFS instance name mounted at dir ("hmdwarp" for `mount -t functionfs hmdwarp DIR`). */
static bool ffs_instance(const char *root, const char *dir, char *name, size_t len)
{
    char want[256], path[512], line[1024];
    snprintf(want, sizeof want, "%s", dir);
    for (size_t n = strlen(want); n > 1 && want[n - 1] == '/'; n--) want[n - 1] = 0;
    snprintf(path, sizeof path, "%s/proc/self/mountinfo", root);
    FILE *f = fopen(path, "r");
    if (!f) return false;
    bool found = false;
    while (!found && fgets(line, sizeof line, f)) {
        /* id parent major:minor root MOUNTPOINT options [optional...] - FSTYPE SOURCE superoptions */
        char mnt[256], fstype[64], source[128];
        const char *dash = strstr(line, " - ");
        if (!dash || sscanf(line, "%*s %*s %*s %*s %255s", mnt) != 1 ||
            sscanf(dash + 3, "%63s %127s", fstype, source) != 2)
            continue;
        unescape(mnt);
        if (strcmp(fstype, "functionfs") != 0 || strcmp(mnt, want) != 0) continue;
        unescape(source);
        snprintf(name, len, "%s", source);
        found = true;
    }
    fclose(f);
    return found;
}

bool drv_usb_udc_of(const char *root, const char *ffs_dir, char *udc, size_t len)
{
    char name[128], path[768];
    udc[0] = 0;
    if (ffs_instance(root, ffs_dir, name, sizeof name)) {
        snprintf(path, sizeof path, "%s/sys/kernel/config/usb_gadget", root);
        DIR *d = opendir(path);
        for (struct dirent *e; d && !udc[0] && (e = readdir(d));) {
            if (e->d_name[0] == '.') continue;
            struct stat sb;
            snprintf(path, sizeof path, "%s/sys/kernel/config/usb_gadget/%s/functions/ffs.%s", root, e->d_name, name);
            if (stat(path, &sb) != 0) continue;
            snprintf(path, sizeof path, "%s/sys/kernel/config/usb_gadget/%s/UDC", root, e->d_name);
            if (!read_line(path, udc, len)) udc[0] = 0;
        }
        if (d) closedir(d);
        if (udc[0]) return true;
    }
    /* Not bound yet: board/gadget.sh binds the first UDC (in name order, as its shell glob lists them). */
    snprintf(path, sizeof path, "%s/sys/class/udc", root);
    DIR *d = opendir(path);
    char first[sizeof ((struct dirent *)0)->d_name] = "";
    for (struct dirent *e; d && (e = readdir(d));)
        if (e->d_name[0] != '.' && (!first[0] || strcmp(e->d_name, first) < 0))
            snprintf(first, sizeof first, "%s", e->d_name);
    if (d) closedir(d);
    snprintf(udc, len, "%s", first);
    return udc[0] != 0;
}

drv_usb_speed drv_usb_udc_speed(const char *root, const char *udc, bool maximum)
{
    char path[512], val[64];
    snprintf(path, sizeof path, "%s/sys/class/udc/%s/%s", root, udc, maximum ? "maximum_speed" : "current_speed");
    return udc[0] && read_line(path, val, sizeof val) ? drv_usb_speed_parse(val) : DRV_USB_SPEED_UNKNOWN;
}
