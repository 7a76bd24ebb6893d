#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
# Writes the reproducers of the findings of issue #16 into tests/fuzz/corpus/NAME/crash-*: each crashed or tripped
# a sanitizer or a harness invariant before its fix (see the commit messages) and must stay harmless. Frames are
# made from a seed of the project's encoder (build/fuzz/seeds, `make fuzz-build` then seeds_framelink) with
# fields patched and the CRCs recomputed. usage: tests/fuzz/make_repros.py [SEED_DIR]
import os
import struct
import sys
import zlib

seeds = sys.argv[1] if len(sys.argv) > 1 else "build/fuzz/seeds"
out = "tests/fuzz/corpus"


def save(name, fname, data):
    os.makedirs(f"{out}/{name}", exist_ok=True)
    with open(f"{out}/{name}/crash-{fname}", "wb") as f:
        f.write(data)


def repair(b):
    hdr = struct.unpack_from("<H", b, 6)[0]
    struct.pack_into("<I", b, hdr - 4, zlib.crc32(bytes(b[: hdr - 4])))
    total = struct.unpack_from("<I", b, 8)[0]
    struct.pack_into("<I", b, total - 4, zlib.crc32(bytes(b[hdr : total - 4])))
    return b


def frame(seed, **fields):
    b = bytearray(open(f"{seeds}/framelink/{seed}", "rb").read())
    offs = {"pose_t": 24, "pose_sent": 32, "host_pose_rx": 40, "host_start": 48}
    for k, v in fields.items():
        if k in offs:
            struct.pack_into("<q", b, offs[k], v)
        elif k == "eye0_px":  # eye 0 pose: w x y z, then px at +32 (eyes at 88)
            struct.pack_into("<d", b, 88 + 32, v)
        elif k == "obj0_px":  # object 1's position x (objects after the 312-byte fixed header)
            struct.pack_into("<d", b, 312 + 32, v)
    return repair(b)


# framelink: pose_sent_ns + (host_render_start_ns - host_pose_rx_ns) overflowed int64 (UBSan), with valid CRCs.
ovf = frame("seed-frame-0", pose_sent=1 << 62, host_pose_rx=1, host_start=(1 << 63) - 1)
sub = frame("seed-frame-0", pose_sent=1, host_pose_rx=1, host_start=-(1 << 63))
neg = frame("seed-frame-0", pose_t=-(1 << 63))
nan_obj = frame("seed-frame-1", obj0_px=float("nan"))
inf_eye = frame("seed-frame-0", eye0_px=float("inf"))
for name in ("framelink", "framelink_crc"):
    save(name, "render-start-overflow", ovf)
    save(name, "host-time-subtract-overflow", sub)
    save(name, "pose-time-negative", neg)
    save(name, "object-pose-nan", nan_obj)
    save(name, "eye-position-inf", inf_eye)
# ... and through the USB receiver (3 bytes of chunking, then the stream).
save("usb_stream", "render-start-overflow", b"\x00\x12\x34" + ovf + ovf)
save("usb_stream", "object-pose-nan", b"\x01\x00\x07" + nan_obj)

# pose message: board/target times outside [0, 2^62] were accepted (the host echoes them back as frame times).
p = bytearray(open(f"{seeds}/pose/seed-pose", "rb").read())
struct.pack_into("<q", p, 16, -(1 << 63))
struct.pack_into("<I", p, 200, zlib.crc32(bytes(p[:200])))
save("pose", "board-time-negative", p)

# V4L2 in-band metadata: pose_t_ns = INT64_MIN passed to the runtime unchecked.
m = bytearray(open(f"{seeds}/v4l2_meta/seed-meta-0", "rb").read())
struct.pack_into("<q", m, 10, -(1 << 63))
save("v4l2_meta", "pose-time-min", m)
m = bytearray(open(f"{seeds}/v4l2_meta/seed-meta-0", "rb").read())
struct.pack_into("<q", m, 18, (1 << 63) - 1)
save("v4l2_meta", "render-start-max", m)

# I2C rate plan: rate_hz = 1e-300 made lround(1000.0 / want) - 1 overflow (UBSan) on the MPU-6050 and MPU-9250.
for kind, who, name in ((1, 0x68, "mpu6050"), (2, 0x71, "mpu9250")):
    save("i2c", f"tiny-rate-{name}", bytes([kind]) + struct.pack("<d", 1e-300) + bytes(8) + bytes([who]))

# PNG: a 68-byte file declaring 32768 x 32768 pixels made plat_png_read allocate and zero 4.3 GB.
def chunk(t, d):
    return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))


ihdr = struct.pack(">IIBBBBB", 32768, 32768, 8, 6, 0, 0, 0)
png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 8)) + chunk(b"IEND", b"")
save("png", "32768x32768-in-68-bytes", png)
ihdr16 = struct.pack(">IIBBBBB", 20000, 20000, 16, 0, 0, 0, 0)
save("png", "u16-20000x20000", b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr16) + chunk(b"IEND", b""))

# PFM: the header alone made hmdwarp-warp allocate 2 x 3.2 GB before reading a value.
save("pfm", "16384x16384-rgb-header-only", b"PF\n16384 16384\n-1.0\n" + b"\0" * 16)

# Layers: a truncated file leaked the layers it had allocated (LeakSanitizer).
save("layers", "truncated-leak", b"HWLAYER1" + struct.pack("<III", 8, 6, 4) + b"\x04" + b"\0" * 50)

# View file: a NaN or infinite position reached the warps (the raytrace segfaulted on NaN).
save("view", "nan-position", b"size 64 48\ntan 1 1 0.75 0.75\nsource 1 0 0 0  nan 1.6 0\ntarget 1 0 0 0 0 0 0\n")
save("view", "inf-position", b"size 64 48\ntan 1 1 0.75 0.75\nsource 1 0 0 0  0 0 0\ntarget 1 0 0 0 inf 0 0\n")
