#!/usr/bin/python3
# SPDX-License-Identifier: MIT
# gradient.py: the smallest hmdwarp host in Python, numpy only (no GPU): a colour gradient with a depth ramp,
# submitted for each pose the board predicts; the place to start before wiring in a real renderer.
"""Usage: gradient.py [CONNECTION] [FRAMES]   (default socket:/run/hmdwarp/frames.sock, 100 frames)"""
import sys

import numpy as np

import hmdwarp_host as hh


def images(cam: hh.Camera, seq: int):
    """An RGBA gradient (red across, green down, blue moving with seq) and planar depth from 1 m at the top of the
    image to 5 m at the bottom: enough for a depth-aware warp to show parallax."""
    y, x = np.mgrid[0:cam.height, 0:cam.width].astype(np.float32)
    color = np.empty((cam.height, cam.width, 4), np.uint8)
    color[..., 0] = x * 255 / max(cam.width - 1, 1)
    color[..., 1] = y * 255 / max(cam.height - 1, 1)
    color[..., 2] = (seq * 4) % 256
    color[..., 3] = 255
    depth = 1 + 4 * y / max(cam.height - 1, 1)
    return color, depth


def main():
    uri = sys.argv[1] if len(sys.argv) > 1 else "socket:/run/hmdwarp/frames.sock"
    frames = int(sys.argv[2]) if len(sys.argv) > 2 else 100
    with hh.Host(uri) as host:
        cams = host.wait_cameras(5.0)
        if cams is None:
            sys.exit("gradient.py: no camera message from %s in 5 s" % uri)
        sent = 0
        while sent < frames:
            pose = host.wait_pose(1.0)
            if pose is None:
                continue
            start = hh.now_ns()
            left, right = images(cams.cam[0], pose.seq), images(cams.cam[1], pose.seq)
            host.submit((left[0], right[0]), (left[1], right[1]), pose=pose, cameras=cams, render_start_ns=start,
                        render_end_ns=hh.now_ns())
            sent += 1
        print("gradient.py: %d frames, %.1f MB/s" % (host.stats().frames_sent, host.stats().mb_per_s))


if __name__ == "__main__":
    main()
