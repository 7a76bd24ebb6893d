# SPDX-License-Identifier: MIT
# hmdwarp_host._native: ctypes declarations of libhmdwarp-host's C API (host/hmdwarp-host.h), field for field,
# and the loading of libhmdwarp-host.so.0: no compiled extension, so nothing to build against Python's headers.
import ctypes
import os

ABI_VERSION = 0  # HMDWARP_HOST_ABI_VERSION this binding was written for (the soname's number)

c_int64, c_uint32, c_double, c_size_t = ctypes.c_int64, ctypes.c_uint32, ctypes.c_double, ctypes.c_size_t


class Pose(ctypes.Structure):
    _fields_ = [("orientation", c_double * 4), ("position", c_double * 3)]


class PoseMsg(ctypes.Structure):
    _fields_ = [("seq", c_uint32), ("board_time_ns", c_int64), ("target_time_ns", c_int64),
                ("received_ns", c_int64), ("head", Pose), ("eye", Pose * 2)]


class Camera(ctypes.Structure):
    _fields_ = [("width", c_uint32), ("height", c_uint32), ("tan_left", c_double), ("tan_right", c_double),
                ("tan_up", c_double), ("tan_down", c_double), ("near_z", c_double), ("far_z", c_double)]


class Cameras(ctypes.Structure):
    _fields_ = [("seq", c_uint32), ("planes", ctypes.c_uint), ("depth_encoding", ctypes.c_int),
                ("max_frame_bytes", ctypes.c_uint64), ("refresh_hz", c_double), ("pose_rate_hz", c_double),
                ("cam", Camera * 2)]


class Fragment(ctypes.Structure):
    _fields_ = [("z", ctypes.c_float), ("rgba", ctypes.c_uint8 * 4), ("id", ctypes.c_uint16)]


class Eye(ctypes.Structure):
    _fields_ = [("color", ctypes.c_void_p), ("color_stride", c_size_t),
                ("depth", ctypes.c_void_p), ("depth_stride", c_size_t),
                ("ids", ctypes.c_void_p), ("ids_stride", c_size_t),
                ("motion", ctypes.c_void_p), ("motion_stride", c_size_t),
                ("layer_count", ctypes.c_void_p), ("layer_count_stride", c_size_t),
                ("fragments", ctypes.c_void_p), ("n_fragments", c_size_t),
                ("pose", Pose), ("camera", Camera)]


class Frame(ctypes.Structure):
    _fields_ = [("color_format", ctypes.c_int), ("depth_format", ctypes.c_int),
                ("depth_near", c_double), ("depth_far", c_double), ("eye", Eye * 2),
                ("pose_seq", c_uint32), ("pose_target_ns", c_int64), ("pose_board_ns", c_int64),
                ("pose_received_ns", c_int64), ("render_start_ns", c_int64), ("render_end_ns", c_int64),
                ("n_objects", ctypes.c_uint), ("object_poses", ctypes.POINTER(Pose)), ("scene_time", c_double),
                ("depth_unorm16", ctypes.c_int)]


class Stats(ctypes.Structure):
    _fields_ = [("frames_sent", ctypes.c_uint64), ("bytes_sent", ctypes.c_uint64), ("mb_per_s", c_double),
                ("send_ms_last", c_double), ("send_ms_mean", c_double), ("poses_received", ctypes.c_uint64),
                ("cameras_received", ctypes.c_uint64), ("messages_rejected", ctypes.c_uint64),
                ("frames_refused", ctypes.c_uint64), ("send_errors", ctypes.c_uint64),
                ("disconnects", ctypes.c_uint64), ("reconnects", ctypes.c_uint64), ("connected", ctypes.c_int)]


class CodecOptions(ctypes.Structure):
    _fields_ = [(name, ctypes.c_int) for name in ("color", "quality", "jpeg_subsampling", "slices", "video_kbps",
                                                  "refresh_frames", "depth", "depth_format", "depth_scale", "other")]


class CodecStats(ctypes.Structure):
    _fields_ = [("color", ctypes.c_int), ("depth", ctypes.c_int), ("other", ctypes.c_int),
                ("depth_format", ctypes.c_int), ("frames", ctypes.c_uint64), ("compressed_frames", ctypes.c_uint64),
                ("key_requests", ctypes.c_uint64), ("key_frames", ctypes.c_uint64), ("plane_bytes", ctypes.c_uint64),
                ("wire_bytes", ctypes.c_uint64), ("plane_bytes_last", c_double), ("wire_bytes_last", c_double),
                ("encode_ms_last", c_double), ("encode_ms_mean", c_double), ("board_codecs", ctypes.c_uint)]


def _load():
    # HMDWARP_HOST_LIB: a library outside the loader's path (the build tree in tests); else the installed soname.
    path = os.environ.get("HMDWARP_HOST_LIB") or "libhmdwarp-host.so.%d" % ABI_VERSION
    try:
        lib = ctypes.CDLL(path)
    except OSError as e:
        raise ImportError("hmdwarp_host: cannot load %s (%s): install libhmdwarp-host (the hmdwarp-host package, "
                          "or make install) or set HMDWARP_HOST_LIB to the library's path" % (path, e)) from None
    handle = ctypes.c_void_p
    protos = {
        "hmdwarp_host_abi_version": (ctypes.c_uint, []),
        "hmdwarp_host_version": (ctypes.c_char_p, []),
        "hmdwarp_host_last_error": (ctypes.c_char_p, []),
        "hmdwarp_host_error_str": (ctypes.c_char_p, [ctypes.c_int]),
        "hmdwarp_host_now_ns": (c_int64, []),
        "hmdwarp_host_open": (handle, [ctypes.c_char_p]),
        "hmdwarp_host_close": (None, [handle]),
        "hmdwarp_host_connected": (ctypes.c_int, [handle]),
        "hmdwarp_host_wait_pose": (ctypes.c_int, [handle, ctypes.c_int, ctypes.POINTER(PoseMsg)]),
        "hmdwarp_host_poll_pose": (ctypes.c_int, [handle, ctypes.POINTER(PoseMsg)]),
        "hmdwarp_host_get_cameras": (ctypes.c_int, [handle, ctypes.POINTER(Cameras)]),
        "hmdwarp_host_wait_cameras": (ctypes.c_int, [handle, ctypes.c_int, ctypes.POINTER(Cameras)]),
        "hmdwarp_host_set_cameras": (ctypes.c_int, [handle, ctypes.POINTER(Cameras)]),
        "hmdwarp_host_get_visibility_mask": (ctypes.c_int, [handle, ctypes.c_int, ctypes.POINTER(ctypes.c_float),
                                                            ctypes.c_int]),
        "hmdwarp_host_submit": (ctypes.c_int, [handle, ctypes.POINTER(Frame)]),
        "hmdwarp_host_encode": (c_int64, [handle, ctypes.POINTER(Frame), ctypes.c_void_p, c_size_t]),
        "hmdwarp_host_send_raw": (ctypes.c_int, [handle, ctypes.c_void_p, c_size_t]),
        "hmdwarp_host_get_stats": (ctypes.c_int, [handle, ctypes.POINTER(Stats)]),
        "hmdwarp_host_set_codec": (ctypes.c_int, [handle, ctypes.POINTER(CodecOptions)]),
        "hmdwarp_host_get_codec_stats": (ctypes.c_int, [handle, ctypes.POINTER(CodecStats)]),
    }
    for name, (res, args) in protos.items():
        fn = getattr(lib, name)
        fn.restype, fn.argtypes = res, args
    if lib.hmdwarp_host_abi_version() != ABI_VERSION:
        raise ImportError("hmdwarp_host: %s has ABI %d, this binding speaks %d"
                          % (path, lib.hmdwarp_host_abi_version(), ABI_VERSION))
    return lib


lib = _load()
