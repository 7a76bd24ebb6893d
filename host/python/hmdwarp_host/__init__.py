# SPDX-License-Identifier: MIT
# hmdwarp_host: Python binding of libhmdwarp-host (ctypes): connect to an hmdwarp board, receive its predicted poses
# and eye cameras, submit frames rendered into numpy arrays (checked here, converted and sent by the C library).
"""Stream frames from Python to an hmdwarp board.

    import hmdwarp_host as hh
    with hh.Host("socket:/run/hmdwarp/frames.sock") as host:
        cams = host.wait_cameras(5.0)
        while True:
            pose = host.wait_pose(1.0)
            if pose is None:
                continue
            color, depth = render(pose.eye, cams.cam)      # two (h, w, 4) uint8 and two (h, w) float32 arrays
            host.submit(color, depth, pose=pose)

Arrays are passed to the library by pointer with their row stride: nothing is copied here. Each array's rows must
be contiguous (a row slice, a C-contiguous array or a crop of one: yes; a transposed or column-strided view: no,
np.ascontiguousarray() it first), and its shape must match the eye camera it is submitted for. Every failure raises
HostError, whose message names the field ("eye[1].depth: NaN at pixel (12, 40)").
"""
import ctypes
import dataclasses
import math
from typing import List, Optional, Sequence, Tuple

import numpy as np

from . import _native
from ._native import lib

__all__ = ["Host", "HostError", "Pose", "PoseMsg", "Camera", "Cameras", "Stats", "CodecStats", "FRAGMENT_DTYPE",
           "now_ns", "version"]

# Error codes (hmdwarp_host_error).
ERR_ARG, ERR_SIZE, ERR_NOT_FINITE, ERR_FORMAT, ERR_NO_CAMERAS = -1, -2, -3, -4, -5
ERR_NOT_CONNECTED, ERR_DISCONNECTED, ERR_IO, ERR_NO_MEMORY, ERR_UNSUPPORTED = -6, -7, -8, -9, -10
PLANE_COLOR, PLANE_DEPTH, PLANE_IDS, PLANE_MOTION, PLANE_LAYERS = 1, 2, 4, 8, 16

MASK_MAX = 64  # HMDWARP_HOST_MASK_MAX: vertices per eye at most

_COLOR_FORMATS = {"rgba8": (1, 4), "bgra8": (2, 4), "rgb8": (3, 3), "rgbx8": (4, 4)}
# depth_format name -> (float32 format, uint16 format or None)
_DEPTH_FORMATS = {"linear": (1, None), "ray": (2, None), "standard": (3, 5), "reversed": (4, 6)}
_ENCODINGS = {0: "linear", 1: "standard", 2: "reversed"}
# Codec names (hmdwarp_host_codec) and 16-bit depth wire formats (hmdwarp_host_wire_depth) for Host.set_codec.
_CODECS = {"auto": -1, "raw": 0, "zstd": 1, "jpeg": 2, "h264": 3, "hevc": 4}
_WIRE_DEPTH = {"auto": 0, "f32": 1, "unorm16": 2, "inv16": 3}

# One transparent fragment of the layers plane, as the C struct lays it out (hmdwarp_host_fragment).
FRAGMENT_DTYPE = np.dtype([("z", "<f4"), ("rgba", "u1", (4,)), ("id", "<u2")], align=True)
assert FRAGMENT_DTYPE.itemsize == ctypes.sizeof(_native.Fragment)


class HostError(Exception):
    """A call refused or failed: code is one of the ERR_* values, message names what was wrong."""

    def __init__(self, code: int, message: str):
        super().__init__(message)
        self.code = code
        self.message = message

    @property
    def name(self) -> str:
        return lib.hmdwarp_host_error_str(self.code).decode()


def _fail(code: int):
    raise HostError(code, lib.hmdwarp_host_last_error().decode() or lib.hmdwarp_host_error_str(code).decode())


def now_ns() -> int:
    """The host clock render timestamps are measured with (CLOCK_MONOTONIC, ns)."""
    return lib.hmdwarp_host_now_ns()


def version() -> str:
    return lib.hmdwarp_host_version().decode()


@dataclasses.dataclass(frozen=True)
class Pose:
    """world_from_local: orientation a unit quaternion (w, x, y, z), position in metres; +Y up, eyes look down -Z."""
    orientation: Tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    position: Tuple[float, float, float] = (0.0, 0.0, 0.0)

    def matrix(self) -> np.ndarray:
        """The 4x4 world_from_local matrix (float64); its inverse is the view matrix of an eye pose."""
        w, x, y, z = self.orientation
        m = np.eye(4)
        m[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]
        m[:3, 3] = self.position
        return m

    def view_matrix(self) -> np.ndarray:
        """The inverse of matrix() (local_from_world), computed exactly for a rigid pose."""
        m = self.matrix()
        v = np.eye(4)
        v[:3, :3] = m[:3, :3].T
        v[:3, 3] = -m[:3, :3].T @ m[:3, 3]
        return v

    @staticmethod
    def _from_c(p) -> "Pose":
        return Pose(tuple(p.orientation), tuple(p.position))

    def _to_c(self, p) -> None:
        p.orientation[:] = [float(v) for v in self.orientation]
        p.position[:] = [float(v) for v in self.position]


@dataclasses.dataclass(frozen=True)
class PoseMsg:
    """A pose message from the board: render each eye at eye[0], eye[1] and submit with pose=this message."""
    seq: int
    board_time_ns: int
    target_time_ns: int
    received_ns: int
    head: Pose
    eye: Tuple[Pose, Pose]


@dataclasses.dataclass(frozen=True)
class Camera:
    """A pinhole eye camera: tangents of the image edges (u in [-tan_left, tan_right], v in [-tan_down, tan_up]),
    pixel centres at (i + 0.5, j + 0.5), rows top to bottom; far_z may be math.inf."""
    width: int
    height: int
    tan_left: float
    tan_right: float
    tan_up: float
    tan_down: float
    near_z: float = 0.05
    far_z: float = math.inf

    @staticmethod
    def symmetric(width: int, height: int, hfov_deg: float, near_z: float = 0.05, far_z: float = math.inf):
        """A camera with the horizontal FOV given and square pixels."""
        th = math.tan(math.radians(hfov_deg) / 2)
        tv = th * height / width
        return Camera(width, height, th, th, tv, tv, near_z, far_z)

    def gl_projection(self, flip_y: bool = False) -> np.ndarray:
        """The OpenGL projection matrix of this frustum (NDC z in [-1, 1]; infinite far when far_z is inf), row-major
        float32. flip_y: rows come out top first from glReadPixels, the order frames are sent in."""
        sx, sy, n, f = self.tan_left + self.tan_right, self.tan_up + self.tan_down, self.near_z, self.far_z
        m = np.zeros((4, 4), np.float32)
        m[0, 0], m[0, 2] = 2 / sx, (self.tan_right - self.tan_left) / sx
        m[1, 1], m[1, 2] = 2 / sy, (self.tan_up - self.tan_down) / sy
        m[2, 2], m[2, 3] = (-1.0, -2 * n) if math.isinf(f) else (-(f + n) / (f - n), -2 * f * n / (f - n))
        m[3, 2] = -1
        if flip_y:
            m[1] = -m[1]
        return m

    def _to_c(self, c) -> None:
        for f in dataclasses.fields(self):
            setattr(c, f.name, getattr(self, f.name))


@dataclasses.dataclass(frozen=True)
class Cameras:
    """What the board wants rendered (its camera message)."""
    cam: Tuple[Camera, Camera]
    planes: int = PLANE_COLOR | PLANE_DEPTH     # PLANE_* the board accepts
    depth_encoding: str = "linear"              # the board's preference: "linear", "standard" or "reversed"
    max_frame_bytes: int = 0
    refresh_hz: float = 0.0
    pose_rate_hz: float = 0.0
    seq: int = 0

    @staticmethod
    def _from_c(c) -> "Cameras":
        cams = tuple(Camera(*[getattr(k, f.name) for f in dataclasses.fields(Camera)]) for k in c.cam)
        return Cameras(cams, c.planes, _ENCODINGS.get(c.depth_encoding, str(c.depth_encoding)), c.max_frame_bytes,
                       c.refresh_hz, c.pose_rate_hz, c.seq)

    def _to_c(self) -> "_native.Cameras":
        c = _native.Cameras()
        c.seq, c.planes, c.max_frame_bytes = self.seq, self.planes, self.max_frame_bytes
        c.refresh_hz, c.pose_rate_hz = self.refresh_hz, self.pose_rate_hz
        enc = {v: k for k, v in _ENCODINGS.items()}
        if self.depth_encoding not in enc:
            raise HostError(ERR_ARG, "cameras.depth_encoding: %r is not one of %s" % (self.depth_encoding, sorted(enc)))
        c.depth_encoding = enc[self.depth_encoding]
        if len(self.cam) != 2:
            raise HostError(ERR_ARG, "cameras.cam: %d cameras, want 2" % len(self.cam))
        for k in range(2):
            self.cam[k]._to_c(c.cam[k])
        return c


Stats = dataclasses.make_dataclass("Stats", [name for name, _ in _native.Stats._fields_], frozen=True)
CodecStats = dataclasses.make_dataclass("CodecStats", [name for name, _ in _native.CodecStats._fields_], frozen=True)
Stats.__doc__ = "Link statistics (hmdwarp_host_stats): frames and bytes sent, MB/s, send times, poses received..."


def _plane(name: str, a, dtype, cam: Camera, comps: int):
    """(pointer, row stride) of array a after checking what the library cannot: its type, that its shape is the
    camera's (the library reads height x width pixels from the pointer) and that its rows are contiguous."""
    if not isinstance(a, np.ndarray):
        raise HostError(ERR_ARG, "%s: a numpy array is needed, not %s" % (name, type(a).__name__))
    want = np.dtype(dtype)
    if a.dtype != want:
        raise HostError(ERR_FORMAT, "%s: dtype %s, want %s (convert it with .astype(np.%s))"
                        % (name, a.dtype, want, want.name))
    shape = (cam.height, cam.width) + ((comps,) if comps > 1 else ())
    if a.shape != shape:
        raise HostError(ERR_SIZE, "%s: shape %s, but the eye camera is %dx%d: want %s"
                        % (name, a.shape, cam.width, cam.height, shape))
    if not a.flags.aligned:
        raise HostError(ERR_ARG, "%s: not aligned to its %d-byte elements: pass a.copy()" % (name, want.itemsize))
    item = want.itemsize
    inner = (a.strides[1] == comps * item) and (comps == 1 or a.strides[2] == item)
    if not inner or a.strides[0] < cam.width * comps * item:
        raise HostError(ERR_ARG, "%s: rows are not contiguous (strides %s): pass np.ascontiguousarray(...)"
                        % (name, a.strides))
    return a.ctypes.data, a.strides[0]


def _pair(name: str, v):
    if v is None:
        return None
    if len(v) != 2:
        raise HostError(ERR_ARG, "%s: give one per eye, (left, right)" % name)
    return v


class Host:
    """A connection to a board: "socket:PATH" (hmdwarpd's socket backend), "usb" or "usb:VID:PID", "file:PATH".

    Use it as a context manager, or call close(). The blocking calls (wait_pose, wait_cameras, submit) release the
    GIL: another Python thread can wait for poses while one submits. close() must not run while another thread is
    in a call on the same Host (the C library's rule)."""

    def __init__(self, uri: str):
        self._h = lib.hmdwarp_host_open(uri.encode())
        if not self._h:
            raise HostError(ERR_IO, lib.hmdwarp_host_last_error().decode())
        self._keep = None

    def close(self) -> None:
        if getattr(self, "_h", None):
            lib.hmdwarp_host_close(self._h)
            self._h = None

    def __enter__(self) -> "Host":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self):
        self.close()

    def _handle(self):
        if not self._h:
            raise HostError(ERR_ARG, "the connection is closed")
        return self._h

    @property
    def connected(self) -> bool:
        return lib.hmdwarp_host_connected(self._handle()) == 1

    # ---- board -> host ----

    @staticmethod
    def _ms(timeout: Optional[float]) -> int:
        return -1 if timeout is None else max(0, int(timeout * 1000))

    @staticmethod
    def _pose_msg(m) -> PoseMsg:
        return PoseMsg(m.seq, m.board_time_ns, m.target_time_ns, m.received_ns, Pose._from_c(m.head),
                       (Pose._from_c(m.eye[0]), Pose._from_c(m.eye[1])))

    def wait_pose(self, timeout: Optional[float] = None) -> Optional[PoseMsg]:
        """The next pose message (newer than the last one returned), or None after timeout seconds (None: wait for
        ever). Raises HostError (ERR_NOT_CONNECTED while the board is gone, ERR_UNSUPPORTED on a file)."""
        m = _native.PoseMsg()
        rc = lib.hmdwarp_host_wait_pose(self._handle(), self._ms(timeout), ctypes.byref(m))
        if rc < 0:
            _fail(rc)
        return self._pose_msg(m) if rc == 1 else None

    def poll_pose(self) -> Optional[PoseMsg]:
        """A newer pose message if one arrived, else None, without waiting."""
        m = _native.PoseMsg()
        rc = lib.hmdwarp_host_poll_pose(self._handle(), ctypes.byref(m))
        if rc < 0:
            _fail(rc)
        return self._pose_msg(m) if rc == 1 else None

    def cameras(self) -> Optional[Cameras]:
        """The latest camera message (or what set_cameras gave), None before any."""
        c = _native.Cameras()
        rc = lib.hmdwarp_host_get_cameras(self._handle(), ctypes.byref(c))
        if rc < 0:
            _fail(rc)
        return Cameras._from_c(c) if rc == 1 else None

    def wait_cameras(self, timeout: Optional[float] = None) -> Optional[Cameras]:
        """Waits until the board has sent its cameras; None after timeout seconds."""
        c = _native.Cameras()
        rc = lib.hmdwarp_host_wait_cameras(self._handle(), self._ms(timeout), ctypes.byref(c))
        if rc < 0:
            _fail(rc)
        return Cameras._from_c(c) if rc == 1 else None

    def visibility_mask(self, eye: int) -> List[Tuple[float, float]]:
        """The eye's hidden-area mask: a counter-clockwise line loop of (u, v) tangents outside which the board shows
        black (skip shading there); [] when the board sent none (every pixel is shown)."""
        buf = (ctypes.c_float * (2 * MASK_MAX))()
        rc = lib.hmdwarp_host_get_visibility_mask(self._handle(), eye, buf, MASK_MAX)
        if rc < 0:
            _fail(rc)
        n = min(rc, MASK_MAX)
        return [(buf[2 * k], buf[2 * k + 1]) for k in range(n)]

    def set_cameras(self, cams: Cameras) -> None:
        """Cameras for a file, or a board that sends none: as if the board had sent them."""
        rc = lib.hmdwarp_host_set_cameras(self._handle(), ctypes.byref(cams._to_c()))
        if rc < 0:
            _fail(rc)

    # ---- host -> board ----

    def _frame(self, color, depth, color_format, depth_format, depth_near, depth_far, depth_unorm16, ids, motion,
               layers, pose, pose_target_ns, pose_board_ns, pose_received_ns, render_start_ns, render_end_ns,
               object_poses, cameras):
        """The C frame for these arrays, and the objects that must outlive the call (pose arrays)."""
        cams = cameras if cameras is not None else self.cameras()
        if cams is None:
            raise HostError(ERR_NO_CAMERAS, "no cameras to check the frame against: the board sent none yet "
                                            "(wait_cameras()), and none were given (cameras= or set_cameras())")
        cam = cams.cam if isinstance(cams, Cameras) else tuple(cams)
        f = _native.Frame()
        color = _pair("color", color)
        if color is None:
            raise HostError(ERR_ARG, "color: required, one image per eye")
        if color_format is None:
            color_format = "rgb8" if color[0].ndim == 3 and color[0].shape[2] == 3 else "rgba8"
        if color_format not in _COLOR_FORMATS:
            raise HostError(ERR_FORMAT, "color_format: %r is not one of %s" % (color_format, sorted(_COLOR_FORMATS)))
        f.color_format, comps = _COLOR_FORMATS[color_format]
        depth = _pair("depth", depth)
        if depth is not None:
            if depth_format not in _DEPTH_FORMATS:
                raise HostError(ERR_FORMAT, "depth_format: %r is not one of %s"
                                % (depth_format, sorted(_DEPTH_FORMATS)))
            f32, u16 = _DEPTH_FORMATS[depth_format]
            dt = np.uint16 if isinstance(depth[0], np.ndarray) and depth[0].dtype == np.uint16 else np.float32
            if dt == np.uint16 and u16 is None:
                raise HostError(ERR_FORMAT, "depth: uint16 is window depth; depth_format %r needs float32"
                                % depth_format)
            f.depth_format = u16 if dt == np.uint16 else f32
        f.depth_near, f.depth_far, f.depth_unorm16 = depth_near, depth_far, int(bool(depth_unorm16))
        ids, motion, layers = _pair("ids", ids), _pair("motion", motion), _pair("layers", layers)
        for e in range(2):
            E, c, n = f.eye[e], cam[e], "eye[%d]." % e
            cam[e]._to_c(E.camera)  # the camera checked against: the library refuses it if the board's differs
            E.color, E.color_stride = _plane(n + "color", color[e], np.uint8, c, comps)
            if depth is not None:
                E.depth, E.depth_stride = _plane(n + "depth", depth[e], dt, c, 1)
            if ids is not None:
                E.ids, E.ids_stride = _plane(n + "ids", ids[e], np.uint16, c, 1)
            if motion is not None:
                E.motion, E.motion_stride = _plane(n + "motion", motion[e], np.float32, c, 2)
            if layers is not None:
                counts, frags = layers[e]
                E.layer_count, E.layer_count_stride = _plane(n + "layers count", counts, np.uint8, c, 1)
                if not isinstance(frags, np.ndarray) or frags.dtype != FRAGMENT_DTYPE or frags.ndim != 1 \
                        or not frags.flags.c_contiguous:
                    raise HostError(ERR_FORMAT, n + "layers fragments: a contiguous 1-D array of FRAGMENT_DTYPE")
                E.fragments, E.n_fragments = frags.ctypes.data, frags.shape[0]
        keep = []
        if isinstance(pose, PoseMsg):
            # The message whole (not its seq, which the library finds only among the last 1024 messages: 2 s at a
            # board's 500 Hz, more than a render should take, but a loaded host can outlast it).
            for e in range(2):
                pose.eye[e]._to_c(f.eye[e].pose)
            f.pose_target_ns, f.pose_board_ns, f.pose_received_ns = (pose.target_time_ns, pose.board_time_ns,
                                                                     pose.received_ns)
        elif pose is not None:
            if len(pose) != 2:
                raise HostError(ERR_ARG, "pose: a PoseMsg or two eye Poses")
            for e in range(2):
                pose[e]._to_c(f.eye[e].pose)
            f.pose_target_ns, f.pose_board_ns, f.pose_received_ns = pose_target_ns, pose_board_ns, pose_received_ns
        else:
            raise HostError(ERR_ARG, "pose: the PoseMsg rendered for, or the two eye Poses")
        f.render_start_ns, f.render_end_ns = render_start_ns, render_end_ns
        if object_poses:
            arr = (_native.Pose * len(object_poses))()
            for i, p in enumerate(object_poses):
                p._to_c(arr[i])
            f.n_objects, f.object_poses = len(object_poses), arr
            keep.append(arr)
        return f, keep

    def submit(self, color, depth=None, *, pose, color_format=None, depth_format="linear", depth_near=0.0,
               depth_far=0.0, depth_unorm16=False, ids=None, motion=None, layers=None, pose_target_ns=0,
               pose_board_ns=0, pose_received_ns=0, render_start_ns=0, render_end_ns=0, object_poses=None,
               cameras=None) -> None:
        """Checks, converts and sends one frame.

        color: (left, right) uint8 arrays (h, w, 4) (color_format "rgba8" (default), "bgra8", "rgbx8") or (h, w, 3)
        ("rgb8"). depth: (left, right) float32 (h, w) in depth_format "linear" (metres along -Z, inf = sky), "ray"
        (metres along the pixel's ray), "standard" or "reversed" (window depth; uint16 arrays for a 16-bit depth
        buffer; depth_near/depth_far: the projection's planes, 0 = the camera's). ids: uint16 (h, w); motion:
        float32 (h, w, 2) pixels/s; layers: per eye (uint8 counts (h, w), FRAGMENT_DTYPE fragments).
        pose: the PoseMsg rendered for, or two eye Poses (then pose_target_ns etc. as known). render_start_ns and
        render_end_ns: now_ns() around the render. cameras: what the arrays were rendered with (default: the
        board's latest). Raises HostError naming the field; nothing is sent then."""
        f, keep = self._frame(color, depth, color_format, depth_format, depth_near, depth_far, depth_unorm16, ids,
                              motion, layers, pose, pose_target_ns, pose_board_ns, pose_received_ns, render_start_ns,
                              render_end_ns, object_poses, cameras)
        rc = lib.hmdwarp_host_submit(self._handle(), ctypes.byref(f))
        del keep
        if rc < 0:
            _fail(rc)

    def encode(self, color, depth=None, **kw) -> bytes:
        """The framelink bytes submit() would send (same arguments), for captures and tests."""
        args = dict(pose=None, color_format=None, depth_format="linear", depth_near=0.0, depth_far=0.0,
                    depth_unorm16=False, ids=None, motion=None, layers=None, pose_target_ns=0, pose_board_ns=0,
                    pose_received_ns=0, render_start_ns=0, render_end_ns=0, object_poses=None, cameras=None)
        unknown = set(kw) - set(args)
        if unknown:
            raise TypeError("encode: unknown arguments %s" % sorted(unknown))
        args.update(kw)
        f, keep = self._frame(color, depth, **args)
        n = lib.hmdwarp_host_encode(self._handle(), ctypes.byref(f), None, 0)
        if n < 0:
            _fail(int(n))
        buf = ctypes.create_string_buffer(n)
        n = lib.hmdwarp_host_encode(self._handle(), ctypes.byref(f), buf, n)
        del keep
        if n < 0:
            _fail(int(n))
        return buf.raw[:n]

    def send_raw(self, data) -> None:
        """Sends bytes as they are (an encoded frame, possibly damaged on purpose)."""
        b = bytes(data)
        rc = lib.hmdwarp_host_send_raw(self._handle(), b, len(b))
        if rc < 0:
            _fail(rc)

    def stats(self) -> "Stats":
        s = _native.Stats()
        rc = lib.hmdwarp_host_get_stats(self._handle(), ctypes.byref(s))
        if rc < 0:
            _fail(rc)
        return Stats(*[getattr(s, name) for name, _ in _native.Stats._fields_])

    def set_codec(self, color: str = "auto", *, quality: int = 0, jpeg_subsampling: int = 0, slices: int = 0,
                  video_kbps: int = 0, refresh_frames: int = 0, depth: str = "auto", depth_format: str = "auto",
                  depth_scale: int = 0, other: str = "auto") -> None:
        """Compresses the frames sent from now on (framelink v2; docs/host-api.md). Codecs: "auto" (from what the
        board announces), "raw", "jpeg", "h264", "hevc" (colour), "zstd" (depth, other); depth_format "auto",
        "f32", "unorm16" or "inv16". set_codec("raw", depth="raw", other="raw") sends version 1 frames again."""
        try:
            o = _native.CodecOptions(_CODECS[color], quality, jpeg_subsampling, slices, video_kbps, refresh_frames,
                                     _CODECS[depth], _WIRE_DEPTH[depth_format], depth_scale, _CODECS[other])
        except KeyError as e:
            raise HostError(ERR_ARG, "set_codec: unknown name %s" % e) from None
        rc = lib.hmdwarp_host_set_codec(self._handle(), ctypes.byref(o))
        if rc < 0:
            _fail(rc)

    def codec_stats(self) -> "CodecStats":
        s = _native.CodecStats()
        rc = lib.hmdwarp_host_get_codec_stats(self._handle(), ctypes.byref(s))
        if rc < 0:
            _fail(rc)
        return CodecStats(*[getattr(s, name) for name, _ in _native.CodecStats._fields_])
