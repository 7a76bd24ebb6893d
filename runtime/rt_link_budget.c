/* SPDX-License-Identifier: MIT */
/* rt_link_budget: a configuration's [frames] backend, eyes, warp and host rate turned into drv_link_budget's input,
 * with the USB speed read where the kernel says it. */
#include "runtime/rt_link_budget.h"

#include <string.h>

#include "drivers/drv_codec.h"
#include "drivers/drv_frames.h"
#include "drivers/drv_link_budget.h"
#include "drivers/drv_usb_speed.h"
#include "warp/warp_registry.h"

bool rt_link_budget_line(const rt_config *c, char *line, size_t len)
{
    if (len) line[0] = 0;
    const bool mock = strcmp(c->frames_device, "mock") == 0;
    drv_link_budget_in in;
    memset(&in, 0, sizeof in);
    char udc[64] = "";
    if (strcmp(c->frames_backend, "usb") == 0 && !mock) {
        in.kind = DRV_LINK_USB;
        if (drv_usb_udc_of("", c->frames_device, udc, sizeof udc)) {
            in.usb_speed = drv_usb_udc_speed("", udc, false);
            in.usb_negotiated = in.usb_speed != DRV_USB_SPEED_UNKNOWN;
            if (!in.usb_negotiated) in.usb_speed = drv_usb_udc_speed("", udc, true);
            in.udc = udc;
        }
    } else if (strcmp(c->frames_backend, "usb") == 0 || strcmp(c->frames_backend, "socket") == 0) {
        in.kind = mock ? DRV_LINK_MOCK : DRV_LINK_SOCKET;
        in.link_mbps = c->link_mbps;
    } else if (strcmp(c->frames_backend, "v4l2") == 0) {
        in.kind = DRV_LINK_V4L2;
    } else {
        return true; /* the simulated host renders in-process */
    }
    in.eye_w = c->eye_w;
    in.eye_h = c->eye_h;
    /* colour and depth always; ids and layers when the warp takes them (auto may pick any), as rt_app asks hosts */
    unsigned needs = c->method == RT_METHOD_AUTO ? WARP_NEEDS_IDS | WARP_NEEDS_LAYERS
                                                 : warp_method_get(rt_method_warp(c->method))->needs;
    in.planes = DRV_PLANE_COLOR | DRV_PLANE_DEPTH | (needs & (WARP_NEEDS_IDS | WARP_NEEDS_LAYERS));
    in.host_hz = c->host_rate_hz;
    char e[160];
    if (!rt_config_frames_codecs(c, &in.codecs, e, sizeof e)) in.codecs = DRV_CODEC_BIT(DRV_CODEC_RAW);
    return drv_link_budget_line(&in, line, len);
}
