#!/usr/bin/python3
# SPDX-License-Identifier: MIT
# The Python binding and the host examples: the binding's checks and errors, the bytes a board decodes from what
# it submitted (tests/examples/fake_board), and render_gl.c, render_gl.py and gradient.py streaming to a board.
# TAP output for tests/run.sh; run from the repository root after `make all` (BUILD= the build tree).
import os
import subprocess
import sys
import tempfile
import time
import traceback
import zlib

BUILD = os.environ.get("BUILD", "build")
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
LIB = os.path.abspath(os.path.join(BUILD, "libhmdwarp-host.so.0"))
FAKE = os.path.abspath(os.path.join(BUILD, "tests/examples/fake_board"))
RENDER_GL = os.path.abspath(os.path.join(BUILD, "examples/render_gl"))
EXAMPLES = os.path.join(ROOT, "host/examples")
# No __pycache__ written into the source tree by the examples and the binding run from it.
ENV = dict(os.environ, HMDWARP_HOST_LIB=LIB, PYTHONPATH=os.path.join(ROOT, "host/python"), PYTHONDONTWRITEBYTECODE="1")
sys.dont_write_bytecode = True
os.environ.update(ENV)
sys.path.insert(0, ENV["PYTHONPATH"])

import numpy as np  # noqa: E402

import hmdwarp_host as hh  # noqa: E402

W, H = 64, 48
TMP = tempfile.mkdtemp(prefix="test_python.")
TESTS = []


def test(fn):
    TESTS.append(fn)
    return fn


def check(cond, what):
    if not cond:
        raise AssertionError(what)


def raises(code, fn, *needles):
    """fn() must raise HostError with code, its message containing every needle; returns the message."""
    try:
        fn()
    except hh.HostError as e:
        check(e.code == code, "error %d (%s), want %d: %s" % (e.code, e.name, code, e))
        for n in needles:
            check(n in str(e), "message %r lacks %r" % (str(e), n))
        return str(e)
    raise AssertionError("no HostError %d raised" % code)


def cams(w=W, h=H):
    cam = hh.Camera.symmetric(w, h, 90)
    return hh.Cameras((cam, cam))


def images(w=W, h=H, seed=1):
    rng = np.random.default_rng(seed)
    color = [rng.integers(0, 256, (h, w, 4), dtype=np.uint8) for _ in range(2)]
    depth = [rng.uniform(0.5, 20, (h, w)).astype(np.float32) for _ in range(2)]
    return color, depth


EYES = (hh.Pose((1, 0, 0, 0), (-0.032, 1.6, 0)), hh.Pose((1, 0, 0, 0), (0.032, 1.6, 0)))


def file_host(name):
    path = os.path.join(TMP, name)
    h = hh.Host("file:" + path)
    h.set_cameras(cams())
    return h, path


def crc(a):
    return "%08x" % zlib.crc32(np.ascontiguousarray(a).tobytes())


class FakeBoard:
    """tests/examples/fake_board on a socket in TMP: serves one host for `frames` frames."""

    def __init__(self, frames, size="%dx%d" % (W, H)):
        self.sock = os.path.join(TMP, "board%d.sock" % len(os.listdir(TMP)))
        self.p = subprocess.Popen([FAKE, self.sock, size, str(frames)], stdout=subprocess.PIPE, text=True)
        check(self.p.stdout.readline().startswith("listening"), "fake_board did not start")
        self.uri = "socket:" + self.sock

    def frames(self, timeout=120):
        """The frame lines, parsed: [{header fields..., "eye": [{fields}, {fields}]}]; rejects raise."""
        out, _ = self.p.communicate(timeout=timeout)
        check(self.p.returncode == 0 and "reject" not in out, "fake_board: exit %d, %s" % (self.p.returncode, out))
        frames = []
        for line in out.splitlines():
            if not line.startswith("frame "):
                continue
            parts = line.split(" | ")
            f = dict(kv.split("=", 1) for kv in parts[0].split()[1:])
            f["eye"] = [dict(kv.split("=", 1) for kv in p.split()[2:]) for p in parts[1:3]]
            frames.append(f)
        return frames

    def kill(self):
        if self.p.poll() is None:
            self.p.kill()
            self.p.wait()


# ---- the binding alone (a file transport: no board) ----

@test
def binding_loads_the_library():
    check(hh.version() != "", "version() is empty")
    check(hh._native.lib.hmdwarp_host_abi_version() == hh._native.ABI_VERSION, "ABI differs")
    check(hh.now_ns() > 0, "now_ns() is not positive")


@test
def file_transport_writes_what_encode_returns():
    h, path = file_host("a.bin")
    with h:
        color, depth = images()
        data = h.encode(color, depth, pose=EYES)
        h.submit(color, depth, pose=EYES)
        check(h.stats().frames_sent == 1, "stats().frames_sent %d" % h.stats().frames_sent)
    with open(path, "rb") as f:
        sent = f.read()
    check(sent[:4] == b"HWF1" and len(sent) == len(data),
          "file holds %d bytes, encode gave %d" % (len(sent), len(data)))
    check(len(data) > 2 * W * H * 8, "a %d-byte frame cannot hold two eyes' colour and depth" % len(data))


@test
def errors_name_the_field():
    h, _ = file_host("b.bin")
    with h:
        color, depth = images()
        raises(hh.ERR_SIZE, lambda: h.submit(color, [depth[0], depth[1][:-1]], pose=EYES), "eye[1].depth", "shape")
        raises(hh.ERR_FORMAT, lambda: h.submit([c.astype(np.float32) for c in color], depth, pose=EYES),
               "eye[0].color", "dtype")
        raises(hh.ERR_ARG, lambda: h.submit(color, [depth[0], np.asfortranarray(depth[1])], pose=EYES),
               "eye[1].depth", "not contiguous")
        raises(hh.ERR_ARG, lambda: h.submit(color[0], depth, pose=EYES), "color", "one per eye")
        odd = np.frombuffer(bytes(4 * W * H + 1), np.uint8)[1:].view(np.float32).reshape(H, W)  # 1 byte off
        raises(hh.ERR_ARG, lambda: h.submit(color, [depth[0], odd], pose=EYES), "eye[1].depth", "aligned")
        raises(hh.ERR_ARG, lambda: h.submit(color, depth, pose=None), "pose")
        raises(hh.ERR_FORMAT, lambda: h.submit(color, depth, pose=EYES, depth_format="inverse"), "depth_format")


@test
def library_refusals_carry_its_message_and_send_nothing():
    h, path = file_host("c.bin")
    with h:
        color, depth = images()
        depth[1][12, 40] = np.nan
        msg = raises(hh.ERR_NOT_FINITE, lambda: h.submit(color, depth, pose=EYES), "depth")
        check("eye[1]" in msg, "message %r does not name eye[1]" % msg)
        bad = (EYES[0], hh.Pose((float("nan"), 0, 0, 0), (0, 0, 0)))
        raises(hh.ERR_NOT_FINITE, lambda: h.submit(color, images()[1], pose=bad), "eye[1]", "orientation")
        check(h.stats().frames_refused == 2, "frames_refused %d, want 2" % h.stats().frames_refused)
    check(os.path.getsize(path) == 0, "a refused frame was written")


@test
def set_codec_compresses_and_names_bad_options():
    h, _ = file_host("codec.bin")
    with h:
        color, depth = images()
        raises(hh.ERR_ARG, lambda: h.set_codec("vp9"), "vp9")
        raises(hh.ERR_ARG, lambda: h.set_codec("jpeg", slices=17), "codec.slices")
        raises(hh.ERR_ARG, lambda: h.set_codec("zstd"), "codec.color")
        h.set_codec("raw", depth="raw", other="raw")
        data = h.encode(color, depth, pose=EYES)
        check(data[4] == 1, "an all-raw frame is version %d, want 1" % data[4])
        h.set_codec("jpeg", quality=90, depth="zstd")
        try:
            data = h.encode(color, depth, pose=EYES)
        except hh.HostError as e:
            if "not built yet" in str(e):
                return "SKIP the framelink encoder: " + str(e)
            raise
        check(data[4] == 2, "a compressed frame is version %d, want 2" % data[4])
        s = h.codec_stats()
        check(s.color == 2 and s.depth == 1 and s.compressed_frames == 1,  # encode sized it, then took it: once
              "codec_stats %r" % (s,))
        check(s.wire_bytes_last < s.plane_bytes_last, "compressed %d bytes, raw %d" % (s.wire_bytes_last,
                                                                                       s.plane_bytes_last))


@test
def no_cameras_and_bad_connections():
    with hh.Host("file:" + os.path.join(TMP, "d.bin")) as h:
        color, depth = images()
        raises(hh.ERR_NO_CAMERAS, lambda: h.submit(color, depth, pose=EYES), "no cameras")
        raises(hh.ERR_UNSUPPORTED, lambda: h.wait_pose(0.01))
    raises(hh.ERR_IO, lambda: hh.Host("socket:" + os.path.join(TMP, "nobody.sock")), "nobody.sock")
    raises(hh.ERR_IO, lambda: hh.Host("usb:zz"), "usb:zz")


@test
def close_is_final_and_context_manager_closes():
    h, _ = file_host("e.bin")
    with h:
        pass
    check(h._h is None, "the with block left the handle open")
    raises(hh.ERR_ARG, lambda: h.stats(), "closed")
    h.close()  # twice: no-op


# ---- what a board decodes ----

@test
def board_gets_cameras_poses_and_exact_planes():
    b = FakeBoard(1)
    try:
        with hh.Host(b.uri) as h:
            c = h.wait_cameras(10)
            check(c is not None and (c.cam[0].width, c.cam[0].height) == (W, H), "cameras %r" % (c,))
            check(c.planes & hh.PLANE_DEPTH and c.depth_encoding == "linear", "planes/encoding %r" % (c,))
            p = h.wait_pose(10)
            check(p is not None and p.seq > 0, "no pose message")
            m = h.visibility_mask(0)
            check(m == [(0.5, 0.0), (0.0, 0.25), (-0.5, 0.0), (0.0, -0.25)] and h.visibility_mask(1) == [],
                  "visibility masks %r %r" % (m, h.visibility_mask(1)))
            raises(hh.ERR_ARG, lambda: h.visibility_mask(2), "eye 2")
            color, depth = images()
            start = hh.now_ns()
            h.submit(color, depth, pose=p, render_start_ns=start, render_end_ns=start + 1000)
        f, = b.frames()
    finally:
        b.kill()
    check(int(f["pose_t"]) == p.target_time_ns and int(f["pose_sent"]) == p.board_time_ns,
          "pose times %s/%s, want %d/%d" % (f["pose_t"], f["pose_sent"], p.target_time_ns, p.board_time_ns))
    check(int(f["start"]) == start and int(f["end"]) == start + 1000, "render times %s %s" % (f["start"], f["end"]))
    for e in range(2):
        got = [float(v) for v in f["eye"][e]["pose"].split(",")]
        want = list(p.eye[e].orientation) + list(p.eye[e].position)
        check(np.allclose(got, want, atol=1e-8), "eye%d pose %s, want %s" % (e, got, want))
        check(f["eye"][e]["color"] == crc(color[e]), "eye%d colour bytes differ" % e)
        check(f["eye"][e]["depth"] == crc(depth[e]), "eye%d depth bytes differ" % e)


@test
def strided_bgra_rgb_ids_motion_arrive_converted():
    b = FakeBoard(2)
    try:
        with hh.Host(b.uri) as h:
            h.wait_cameras(10)
            p = h.wait_pose(10)
            rng = np.random.default_rng(7)
            big = rng.integers(0, 256, (2, H + 10, W + 20, 4), dtype=np.uint8)
            bgra = [big[e, 5:5 + H, 10:10 + W] for e in range(2)]  # crops: rows W + 20 pixels apart, no copy
            depth = [np.full((H, W), 2.5 + e, np.float32) for e in range(2)]
            ids = [rng.integers(0, 3, (H, W), dtype=np.uint16) for _ in range(2)]
            motion = [rng.normal(size=(H, W, 2)).astype(np.float32) for _ in range(2)]
            obj = [hh.Pose((1, 0, 0, 0), (0.5, 1, -2)), hh.Pose((1, 0, 0, 0), (-0.5, 1, -3))]
            h.submit(bgra, depth, pose=p, color_format="bgra8", ids=ids, motion=motion, object_poses=obj)
            rgb = [rng.integers(0, 256, (H, W, 3), dtype=np.uint8) for _ in range(2)]
            h.submit(rgb, pose=p)
        f1, f2 = b.frames()
    finally:
        b.kill()
    for e in range(2):
        check(f1["eye"][e]["color"] == crc(bgra[e][..., [2, 1, 0, 3]]), "eye%d: BGRA not swapped to RGBA" % e)
        check(f1["eye"][e]["ids"] == crc(ids[e]) and f1["eye"][e]["motion"] == crc(motion[e]), "ids/motion differ")
        rgba = np.concatenate([rgb[e], np.full((H, W, 1), 255, np.uint8)], axis=2)
        check(f2["eye"][e]["color"] == crc(rgba), "eye%d: RGB not sent opaque RGBA" % e)
    check(f1["objects"] == "2" and f2["planes"] == "1", "objects %s, planes %s" % (f1["objects"], f2["planes"]))


def run_example(cmd, board, timeout=300):
    r = subprocess.run(cmd, env=ENV, capture_output=True, text=True, timeout=timeout)
    check(r.returncode == 0, "%s: exit %d: %s" % (os.path.basename(cmd[1] if cmd[0] == sys.executable else cmd[0]),
                                                  r.returncode, (r.stdout + r.stderr)[-600:]))
    frames = board.frames() if board else []
    return r, frames


def example_streams(cmd, n=3):
    b = FakeBoard(n)
    try:
        r, frames = run_example(cmd + ["-n", str(n), b.uri], b)
    finally:
        b.kill()
    check(len(frames) == n, "the board decoded %d frames, want %d" % (len(frames), n))
    for f in frames:
        check(f["planes"] == "3" and f["enc"] == "0", "planes %s encoding %s: want colour + linear depth"
              % (f["planes"], f["enc"]))
        check(int(f["start"]) > 0 and int(f["end"]) >= int(f["start"]), "render times %s %s" % (f["start"], f["end"]))
    check(len({f["eye"][0]["color"] for f in frames}) == n, "the frames do not differ: poses ignored?")
    check("%d frames sent" % n in r.stdout, "no statistics line: %r" % r.stdout)


@test
def render_gl_c_streams_to_a_board():
    example_streams([RENDER_GL])


@test
def render_gl_py_streams_to_a_board():
    example_streams([sys.executable, os.path.join(EXAMPLES, "render_gl.py")])


@test
def gradient_py_streams_to_a_board():
    b = FakeBoard(2)
    try:
        run_example([sys.executable, os.path.join(EXAMPLES, "gradient.py"), b.uri, "2"], b)
    finally:
        b.kill()


@test
def c_and_python_examples_render_the_same_image():
    out = {}
    for name, cmd in (("c", [RENDER_GL]), ("py", [sys.executable, os.path.join(EXAMPLES, "render_gl.py")])):
        prefix = os.path.join(TMP, "synth-" + name)
        run_example(cmd + ["--synth", "-n", "1", "--eye", "160x120", "--save", prefix,
                           "file:" + os.path.join(TMP, name + ".bin")], None)
        with open(prefix + "-0.ppm", "rb") as f:
            out[name] = np.frombuffer(f.read()[-160 * 120 * 3:], np.uint8).astype(int)
        check(os.path.getsize(os.path.join(TMP, name + ".bin")) > 160 * 120 * 8, "%s wrote no frame" % name)
    diff = np.abs(out["c"] - out["py"])
    check(diff.mean() < 0.5 and out["c"].std() > 20, "mean difference %.2f, image spread %.1f"
          % (diff.mean(), out["c"].std()))


@test
def make_install_puts_the_module_where_python3_finds_it():
    path = subprocess.run([sys.executable, "-c", "import sys; print('\\n'.join(sys.path))"], capture_output=True,
                          text=True).stdout.split()
    for prefix in ("/usr", "/usr/local"):
        d = tempfile.mkdtemp(dir=TMP)
        r = subprocess.run(["make", "--no-print-directory", "install-python", "DESTDIR=" + d, "PREFIX=" + prefix,
                            "BUILD=" + BUILD], cwd=ROOT, capture_output=True, text=True)
        check(r.returncode == 0, "make install-python PREFIX=%s: %s" % (prefix, r.stdout + r.stderr))
        found = [p for p in path if os.path.isfile(d + p + "/hmdwarp_host/__init__.py")]
        check(found, "PREFIX=%s: hmdwarp_host in none of python3's directories %s" % (prefix, path))
        # from there, with the library found by the loader as an installed one is (no HMDWARP_HOST_LIB)
        env = {k: v for k, v in ENV.items() if k != "HMDWARP_HOST_LIB"}
        env.update(PYTHONPATH=d + found[0], LD_LIBRARY_PATH=os.path.dirname(LIB))
        r = subprocess.run([sys.executable, "-c", "import hmdwarp_host as h; print(h.__file__, h.version())"], cwd=d,
                           env=env, capture_output=True, text=True)
        check(r.returncode == 0 and r.stdout.startswith(d + found[0]), "import: %s" % (r.stdout + r.stderr))


# ---- hmdwarpd's socket backend (the simulated board: IMU, vsync, offscreen panel) ----

HMDWARPD = os.path.abspath(os.path.join(BUILD, "hmdwarpd"))
SKY = (115, 158, 217)  # the examples' clear colour, (0.45, 0.62, 0.85) in 8 bits; the simulated scenes have none
# The board shows a frame as rendered when the head is still and the lens maps panel pixel centres onto eye pixel
# centres: 160x120 eyes at tan 1 x 0.75, an undistorting lens of scale 80 px, both eyes side by side on 320x120.
EYE_W, EYE_H = 160, 120
PANEL_W, PANEL_H = 2 * EYE_W, EYE_H
IDENTITY_BOARD = ("eye.width=%d" % EYE_W, "eye.height=%d" % EYE_H, "eye.fov=45 45 36.869898 36.869898",
                  "display.width=%d" % PANEL_W, "display.height=%d" % PANEL_H, "lens.k_red=1 0 0 0",
                  "lens.k_green=1 0 0 0", "lens.k_blue=1 0 0 0", "lens.scale=%d" % (EYE_W // 2),
                  "lens.center=%d %d" % (EYE_W // 2, EYE_H // 2), "lens.visible_radius=100")  # every pixel shown


def kv(path):
    try:
        with open(path) as f:
            return dict(line.rstrip("\n").split("=", 1) for line in f if "=" in line)
    except OSError:
        return {}


def wait_for(cond, seconds):
    for _ in range(int(seconds * 20)):
        if cond():
            return True
        time.sleep(0.05)
    return cond()


def sky_share(img):
    return float((np.abs(img[..., :3].astype(int) - SKY).max(axis=2) <= 6).mean())


def read_ppm(path):
    with open(path, "rb") as f:
        magic, size, _, data = f.read().split(b"\n", 3)
    w, h = map(int, size.split())
    return np.frombuffer(data, np.uint8).reshape(h, w, 3)


def shows_on_hmdwarpd(cmd, n=12):
    """cmd streams n frames to hmdwarpd's socket backend: the board receives them all, rejects none, shows them
    (--stats), and its panel (the raw sink) shows what the example rendered, pixel by pixel (IDENTITY_BOARD)."""
    help_config = subprocess.run([HMDWARPD, "--help-config"], capture_output=True, text=True).stdout
    if "socket" not in help_config:
        return "SKIP hmdwarpd has no [frames] backend = socket"
    d = tempfile.mkdtemp(dir=TMP)
    sock, live, stats, frames = (os.path.join(d, n) for n in ("b.sock", "live", "stats", "frames"))
    raw = os.path.join(frames, "frames.rgba")
    os.mkdir(frames)
    # real time (the socket backend refuses virtual time); a still head and IDENTITY_BOARD, so the panel shows the
    # frame as rendered; every 45th vsync to the raw sink
    env = {k: v for k, v in ENV.items() if k != "HMDWARP_TIME_SLOWDOWN"}
    board = subprocess.Popen([HMDWARPD, "--config", "board/sim/board.ini", "--duration", "0", "--stats", stats] +
                             sum((["--set", s] for s in (
                                 "sim.trace=still", "sim.imu_rest_s=0.2", "sim.eval_every_ms=0", "render.rt_priority=0",
                                 "frames.backend=socket", "frames.device=" + sock) + IDENTITY_BOARD + (
                                 "telemetry.live_stats=" + live, "display.sink=raw", "display.sink_every=45",
                                 "display.sink_path=" + frames)), []),
                             cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        check(wait_for(lambda: int(kv(live).get("vsyncs", 0)) > 0, 30), "hmdwarpd's display did not start")
        prefix = os.path.join(d, "rendered")
        run_example(cmd + ["-n", str(n), "--save", prefix, "socket:" + sock], None)
        check(wait_for(lambda: int(kv(live).get("frames_received", 0)) >= n, 30), "the board did not get %d frames" % n)
        size = os.path.getsize(raw) if os.path.exists(raw) else 0
        check(wait_for(lambda: os.path.exists(raw) and os.path.getsize(raw) > size, 30), "no panel image after them")
    finally:
        board.terminate()
        out, _ = board.communicate(timeout=60)
    check(board.returncode == 0, "hmdwarpd exited %d: %s" % (board.returncode, out[-800:]))
    st = kv(stats)
    check(st.get("frames_backend") == "socket", "frames_backend=%s" % st.get("frames_backend"))
    check(int(st["frames_received"]) == n and int(st["frames_rejected"]) == 0 and int(st["frames_shown"]) >= 1,
          "received %s, rejected %s, shown %s" % (st["frames_received"], st["frames_rejected"], st["frames_shown"]))
    data, size = np.fromfile(raw, np.uint8), PANEL_W * PANEL_H * 4
    panel = data[(len(data) // size - 1) * size:][:size].reshape(PANEL_H, PANEL_W, 4)  # the last whole image
    rendered = np.concatenate([read_ppm(prefix + "-0.ppm"), read_ppm(prefix + "-1.ppm")], axis=1)
    check(rendered.shape == (PANEL_H, PANEL_W, 3), "rendered %s, panel %dx%d" % (rendered.shape, PANEL_W, PANEL_H))
    # The head is still, not frozen (the simulated IMU's noise turns it by hundredths of a degree), so edges may
    # move by a fraction of a pixel: judged on the share of pixels that differ visibly.
    diff = np.abs(panel[..., :3].astype(int) - rendered.astype(int)).max(axis=2)
    off = float((diff > 8).mean())
    check(sky_share(rendered) > 0.3 and off < 0.02,
          "%.1f %% of the panel's pixels differ from what was rendered by more than 8 (largest %d)" %
          (100 * off, diff.max()))


@test
def render_gl_py_shows_on_hmdwarpd():
    return shows_on_hmdwarpd([sys.executable, os.path.join(EXAMPLES, "render_gl.py")])


@test
def render_gl_c_shows_on_hmdwarpd():
    return shows_on_hmdwarpd([RENDER_GL])


def main():
    print("1..%d" % len(TESTS))
    failed = 0
    for i, fn in enumerate(TESTS, 1):
        name = fn.__name__.replace("_", " ")
        try:
            skip = fn()
            print("ok %d - %s%s" % (i, name, " # " + skip if skip else ""))
        except Exception as e:  # noqa: BLE001: every failure is reported, the run goes on
            failed += 1
            print("not ok %d - %s" % (i, name))
            for line in ("%s: %s" % (type(e).__name__, e)).splitlines() + traceback.format_exc().splitlines()[-3:]:
                print("#   " + line)
        sys.stdout.flush()
    subprocess.run(["rm", "-rf", TMP])
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
