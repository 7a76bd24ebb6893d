#!/usr/bin/python3
# SPDX-License-Identifier: MIT
# render_gl.py: render_gl.c's loop in Python: EGL surfaceless + OpenGL ES 3 (PyOpenGL) render a textured,
# depth-tested scene at each pose the board predicts; colour and linear depth go to the board through hmdwarp_host.
"""Usage: render_gl.py [-n FRAMES] [--synth] [--eye WxH] [--fov DEG] [--save PREFIX] [CONNECTION]

CONNECTION: socket:PATH (hmdwarpd's [frames] backend = socket; default socket:/run/hmdwarp/frames.sock), usb, or
file:PATH (implies --synth). Needs python3-opengl and python3-numpy (Debian) and libhmdwarp-host.

Depth, as in render_gl.c: GLES 3 cannot read a depth buffer back, so the fragment shader writes the planar view
depth (metres along -Z) to an R32F colour attachment in the same pass; the depth renderbuffer only depth-tests.
"""
import argparse
import ctypes
import math
import os
import sys
import time

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")  # before OpenGL is imported: no X or Wayland needed

import numpy as np  # noqa: E402
from OpenGL import EGL  # noqa: E402
from OpenGL import GLES3 as gl  # noqa: E402
from OpenGL.EGL.EXT.platform_base import eglGetPlatformDisplayEXT  # noqa: E402

import hmdwarp_host as hh  # noqa: E402

EGL_PLATFORM_SURFACELESS_MESA = 0x31DD  # EGL_MESA_platform_surfaceless (PyOpenGL 3.1.6 has no module for it)
NO_POSE_GIVE_UP_S = 30  # a board silent this long is not coming back (the library reconnects to one that does)


def gl_open():
    """A surfaceless OpenGL ES 3 context (Mesa: a GPU or llvmpipe), made current."""
    client = (EGL.eglQueryString(EGL.EGL_NO_DISPLAY, EGL.EGL_EXTENSIONS) or b"").split()
    if b"EGL_MESA_platform_surfaceless" not in client:
        sys.exit("render_gl.py: EGL has no EGL_MESA_platform_surfaceless (Mesa's libEGL is needed: libegl-mesa0)")
    dpy = eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL.EGL_DEFAULT_DISPLAY, None)
    if not dpy or not EGL.eglInitialize(dpy, None, None):
        sys.exit("render_gl.py: no surfaceless EGL display")
    EGL.eglBindAPI(EGL.EGL_OPENGL_ES_API)
    cfg = EGL.EGLConfig()
    n = EGL.EGLint()
    want = (EGL.EGLint * 3)(EGL.EGL_RENDERABLE_TYPE, EGL.EGL_OPENGL_ES3_BIT, EGL.EGL_NONE)
    if not EGL.eglChooseConfig(dpy, want, ctypes.pointer(cfg), 1, ctypes.pointer(n)) or n.value < 1:
        cfg = None  # EGL_NO_CONFIG_KHR: Mesa's surfaceless display has no ES 3 configs, and needs none
    attrs = (EGL.EGLint * 3)(EGL.EGL_CONTEXT_CLIENT_VERSION, 3, EGL.EGL_NONE)
    ctx = EGL.eglCreateContext(dpy, cfg, EGL.EGL_NO_CONTEXT, attrs)
    if not ctx or not EGL.eglMakeCurrent(dpy, EGL.EGL_NO_SURFACE, EGL.EGL_NO_SURFACE, ctx):
        sys.exit("render_gl.py: no OpenGL ES 3 context")
    if b"GL_EXT_color_buffer_float" not in _gl_string(gl.GL_EXTENSIONS).split():
        sys.exit("render_gl.py: %s cannot render to float textures" % _gl_string(gl.GL_RENDERER).decode())
    return dpy, ctx


def _gl_string(name):
    return ctypes.string_at(gl.glGetString(name))


# Boxes (centre x, y, z, half sizes, tint), as in render_gl.c: near and far for parallax, one at eye height.
BOXES = [(-0.6, 0.25, -1.5, 0.25, 0.25, 0.25, 1.0, 0.55, 0.45),
         (0.7, 0.4, -2.5, 0.4, 0.4, 0.4, 0.5, 0.8, 1.0),
         (-1.5, 1.0, -4.0, 0.5, 1.0, 0.5, 0.6, 1.0, 0.55),
         (1.8, 0.6, -6.0, 0.6, 0.6, 0.6, 1.0, 0.9, 0.4),
         (0.0, 1.6, -5.0, 0.3, 0.3, 0.3, 0.9, 0.5, 1.0)]
FLOOR_HALF = 20.0


def build_scene():
    """Vertices (x y z u v r g b, float32) and uint16 indices of the floor and the boxes' faces."""
    verts, index = [], []

    def quad(corners, us, vs, tint):
        base = len(verts)
        for (x, y, z), (u, v) in zip(corners, [(0, 0), (1, 0), (1, 1), (0, 1)]):
            verts.append((x, y, z, u * us, v * vs) + tuple(tint))
        index.extend(base + i for i in (0, 1, 2, 0, 2, 3))

    F = FLOOR_HALF
    quad([(-F, 0, F), (F, 0, F), (F, 0, -F), (-F, 0, -F)], 2 * F, 2 * F, (1, 1, 1))
    for b in BOXES:
        c, half, tint = b[0:3], b[3:6], b[6:9]
        for f in range(6):
            ax, s = f // 2, (1 if f % 2 else -1)
            u, w = (ax + 1) % 3, (ax + 2) % 3
            corners = []
            for cu, cw in [(-1, -1), (1, -1), (1, 1), (-1, 1)]:
                p = [0.0, 0.0, 0.0]
                p[ax], p[u], p[w] = c[ax] + s * half[ax], c[u] + cu * half[u], c[w] + cw * half[w]
                corners.append(p)
            quad(corners, 2 * half[u], 2 * half[w], tint)
    return np.array(verts, np.float32), np.array(index, np.uint16)


def make_texture(size=256):
    """4x4 checker cells with a grid and a colour ramp (render_gl.c's texture)."""
    y, x = np.mgrid[0:size, 0:size]
    dark = ((x // 64) ^ (y // 64)) & 1
    line = (x % 64 < 3) | (y % 64 < 3)
    base = np.where(line, 30, np.where(dark, 110, 220))
    t = np.empty((size, size, 4), np.uint8)
    t[..., 0] = base * (192 + x // 4) // 255
    t[..., 1] = base
    t[..., 2] = base * (192 + y // 4) // 255
    t[..., 3] = 255
    return t


VS = """#version 300 es
uniform mat4 view, proj;
layout(location = 0) in vec3 pos;
layout(location = 1) in vec2 uv;
layout(location = 2) in vec3 tint;
out vec2 v_uv; out vec3 v_tint; out float v_z;
void main() {
    vec4 e = view * vec4(pos, 1.0);
    v_uv = uv; v_tint = tint; v_z = -e.z;
    gl_Position = proj * e;
}
"""
FS = """#version 300 es
precision highp float;
uniform sampler2D tex;
in vec2 v_uv; in vec3 v_tint; in float v_z;
layout(location = 0) out vec4 color;
layout(location = 1) out float depth;
void main() {
    color = vec4(texture(tex, v_uv).rgb * v_tint, 1.0);
    depth = v_z;
}
"""


def _shader(kind, src):
    s = gl.glCreateShader(kind)
    gl.glShaderSource(s, src)
    gl.glCompileShader(s)
    if not gl.glGetShaderiv(s, gl.GL_COMPILE_STATUS):
        sys.exit("render_gl.py: shader: %s" % gl.glGetShaderInfoLog(s))
    return s


class Renderer:
    def __init__(self):
        self.prog = gl.glCreateProgram()
        for kind, src in ((gl.GL_VERTEX_SHADER, VS), (gl.GL_FRAGMENT_SHADER, FS)):
            gl.glAttachShader(self.prog, _shader(kind, src))
        gl.glLinkProgram(self.prog)
        if not gl.glGetProgramiv(self.prog, gl.GL_LINK_STATUS):
            sys.exit("render_gl.py: the shaders do not link")
        self.u_view = gl.glGetUniformLocation(self.prog, "view")
        self.u_proj = gl.glGetUniformLocation(self.prog, "proj")
        verts, index = build_scene()
        self.n_index = len(index)
        self.vao = gl.glGenVertexArrays(1)
        gl.glBindVertexArray(self.vao)
        vbo, ibo = gl.glGenBuffers(2)
        gl.glBindBuffer(gl.GL_ARRAY_BUFFER, vbo)
        gl.glBufferData(gl.GL_ARRAY_BUFFER, verts.nbytes, verts, gl.GL_STATIC_DRAW)
        gl.glBindBuffer(gl.GL_ELEMENT_ARRAY_BUFFER, ibo)
        gl.glBufferData(gl.GL_ELEMENT_ARRAY_BUFFER, index.nbytes, index, gl.GL_STATIC_DRAW)
        for loc, n, off in ((0, 3, 0), (1, 2, 12), (2, 3, 20)):
            gl.glVertexAttribPointer(loc, n, gl.GL_FLOAT, gl.GL_FALSE, 32, ctypes.c_void_p(off))
            gl.glEnableVertexAttribArray(loc)
        tex = make_texture()
        self.tex = gl.glGenTextures(1)
        gl.glBindTexture(gl.GL_TEXTURE_2D, self.tex)
        gl.glTexImage2D(gl.GL_TEXTURE_2D, 0, gl.GL_RGBA8, tex.shape[1], tex.shape[0], 0, gl.GL_RGBA,
                        gl.GL_UNSIGNED_BYTE, tex)
        gl.glGenerateMipmap(gl.GL_TEXTURE_2D)
        gl.glTexParameteri(gl.GL_TEXTURE_2D, gl.GL_TEXTURE_MIN_FILTER, gl.GL_LINEAR_MIPMAP_LINEAR)
        gl.glTexParameteri(gl.GL_TEXTURE_2D, gl.GL_TEXTURE_MAG_FILTER, gl.GL_LINEAR)
        self.targets = [None, None]

    def _target(self, eye, w, h):
        """The eye's FBO (RGBA8 + R32F linear depth + a depth renderbuffer), made again when the size changes."""
        t = self.targets[eye]
        if t and t[0] == (w, h):
            return t[1]
        if t:
            gl.glDeleteFramebuffers(1, [t[1]])
            gl.glDeleteTextures(2, t[2])
            gl.glDeleteRenderbuffers(1, [t[3]])
        color, lin = gl.glGenTextures(2)
        for tex, fmt in ((color, gl.GL_RGBA8), (lin, gl.GL_R32F)):
            gl.glBindTexture(gl.GL_TEXTURE_2D, tex)
            gl.glTexStorage2D(gl.GL_TEXTURE_2D, 1, fmt, w, h)
        rb = gl.glGenRenderbuffers(1)
        gl.glBindRenderbuffer(gl.GL_RENDERBUFFER, rb)
        gl.glRenderbufferStorage(gl.GL_RENDERBUFFER, gl.GL_DEPTH_COMPONENT24, w, h)
        fbo = gl.glGenFramebuffers(1)
        gl.glBindFramebuffer(gl.GL_FRAMEBUFFER, fbo)
        gl.glFramebufferTexture2D(gl.GL_FRAMEBUFFER, gl.GL_COLOR_ATTACHMENT0, gl.GL_TEXTURE_2D, color, 0)
        gl.glFramebufferTexture2D(gl.GL_FRAMEBUFFER, gl.GL_COLOR_ATTACHMENT1, gl.GL_TEXTURE_2D, lin, 0)
        gl.glFramebufferRenderbuffer(gl.GL_FRAMEBUFFER, gl.GL_DEPTH_ATTACHMENT, gl.GL_RENDERBUFFER, rb)
        gl.glDrawBuffers(2, [gl.GL_COLOR_ATTACHMENT0, gl.GL_COLOR_ATTACHMENT1])
        if gl.glCheckFramebufferStatus(gl.GL_FRAMEBUFFER) != gl.GL_FRAMEBUFFER_COMPLETE:
            sys.exit("render_gl.py: a %dx%d RGBA8 + R32F framebuffer is not complete" % (w, h))
        self.targets[eye] = ((w, h), fbo, (color, lin), rb)
        return fbo

    def render(self, eye, pose: hh.Pose, cam: hh.Camera, color: np.ndarray, depth: np.ndarray):
        """Renders one eye into color ((h, w, 4) uint8) and depth ((h, w) float32, metres, inf = sky)."""
        gl.glBindFramebuffer(gl.GL_FRAMEBUFFER, self._target(eye, cam.width, cam.height))
        gl.glViewport(0, 0, cam.width, cam.height)
        gl.glClearBufferfv(gl.GL_COLOR, 0, np.array([0.45, 0.62, 0.85, 1.0], np.float32))
        gl.glClearBufferfv(gl.GL_COLOR, 1, np.array([np.inf, 0, 0, 0], np.float32))
        gl.glClearBufferfi(gl.GL_DEPTH_STENCIL, 0, 1.0, 0)
        gl.glEnable(gl.GL_DEPTH_TEST)
        gl.glUseProgram(self.prog)
        # numpy is row-major, GL column-major: transpose. flip_y: glReadPixels then returns the top row first.
        gl.glUniformMatrix4fv(self.u_view, 1, gl.GL_TRUE, pose.view_matrix().astype(np.float32))
        gl.glUniformMatrix4fv(self.u_proj, 1, gl.GL_TRUE, cam.gl_projection(flip_y=True))
        gl.glActiveTexture(gl.GL_TEXTURE0)
        gl.glBindTexture(gl.GL_TEXTURE_2D, self.tex)
        gl.glBindVertexArray(self.vao)
        gl.glDrawElements(gl.GL_TRIANGLES, self.n_index, gl.GL_UNSIGNED_SHORT, None)
        gl.glReadBuffer(gl.GL_COLOR_ATTACHMENT0)
        gl.glReadPixels(0, 0, cam.width, cam.height, gl.GL_RGBA, gl.GL_UNSIGNED_BYTE,
                        color.ctypes.data_as(ctypes.c_void_p))
        gl.glReadBuffer(gl.GL_COLOR_ATTACHMENT1)
        if (gl.glGetIntegerv(gl.GL_IMPLEMENTATION_COLOR_READ_FORMAT) == gl.GL_RED and
                gl.glGetIntegerv(gl.GL_IMPLEMENTATION_COLOR_READ_TYPE) == gl.GL_FLOAT):
            gl.glReadPixels(0, 0, cam.width, cam.height, gl.GL_RED, gl.GL_FLOAT, depth.ctypes.data_as(ctypes.c_void_p))
        else:  # GLES 3 guarantees only RGBA/FLOAT for float buffers
            tmp = np.empty((cam.height, cam.width, 4), np.float32)
            gl.glReadPixels(0, 0, cam.width, cam.height, gl.GL_RGBA, gl.GL_FLOAT, tmp.ctypes.data_as(ctypes.c_void_p))
            depth[...] = tmp[..., 0]


def synth_pose(i):
    """A slow head turn at eye height, eyes 64 mm apart (render_gl.c's --synth)."""
    t = i / 90.0
    yaw, pitch = 0.5 * math.sin(0.5 * t), 0.1 * math.sin(0.3 * t)
    cy, sy, cp, sp = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(pitch / 2), math.sin(pitch / 2)
    q = (cy * cp, cy * sp, sy * cp, -sy * sp)
    head = hh.Pose(q, (0.0, 1.6, 0.0))
    m = head.matrix()
    return tuple(hh.Pose(q, tuple(m[:3, :3] @ (off, 0, 0) + m[:3, 3])) for off in (-0.032, 0.032))


def parse_args(argv):
    ap = argparse.ArgumentParser(prog="render_gl.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("connection", nargs="?", default="socket:/run/hmdwarp/frames.sock")
    ap.add_argument("-n", "--frames", type=int, default=0, help="stop after N frames (default: until interrupted)")
    ap.add_argument("--synth", action="store_true", help="synthesise the poses (a slow head turn at 90 Hz)")
    ap.add_argument("--eye", default="640x480", help="eye size when the board sends no cameras (WxH)")
    ap.add_argument("--fov", type=float, default=90.0, help="horizontal FOV then, degrees")
    ap.add_argument("--save", metavar="PREFIX", help="the last frame's colour as PREFIX-0.ppm, PREFIX-1.ppm")
    a = ap.parse_args(argv)
    if a.connection.startswith("file:"):
        a.synth = True  # a file sends no poses back
    try:
        a.width, a.height = (int(v) for v in a.eye.split("x"))
    except ValueError:
        ap.error("--eye %s: want WxH" % a.eye)
    return a


def save_ppm(path, rgba):
    with open(path, "wb") as f:
        f.write(b"P6\n%d %d\n255\n" % (rgba.shape[1], rgba.shape[0]))
        f.write(np.ascontiguousarray(rgba[..., :3]).tobytes())


def main(argv=None):
    a = parse_args(argv)
    dpy, ctx = gl_open()
    r = Renderer()
    print("render_gl.py: rendering with %s" % _gl_string(gl.GL_RENDERER).decode(), file=sys.stderr)
    with hh.Host(a.connection) as host:
        if a.synth:
            cam = hh.Camera.symmetric(a.width, a.height, a.fov)
            host.set_cameras(hh.Cameras((cam, cam), refresh_hz=90, pose_rate_hz=90))
        elif host.wait_cameras(5.0) is None:
            sys.exit("render_gl.py: no camera message from %s in 5 s" % a.connection)
        done, last_pose_ns = 0, hh.now_ns()
        bufs = {}
        while a.frames == 0 or done < a.frames:
            if a.synth:
                pose, eyes = synth_pose(done), None
                time.sleep(1 / 90)
            else:
                try:
                    msg = host.wait_pose(1.0)
                except hh.HostError as e:
                    if e.code != hh.ERR_NOT_CONNECTED:
                        raise
                    msg = None
                    time.sleep(0.1)
                if msg is None:  # the board is slow to start, or gone for a while: reconnecting is the library's
                    if hh.now_ns() - last_pose_ns > NO_POSE_GIVE_UP_S * 1e9:
                        sys.exit("render_gl.py: no pose from the board for %d s: giving up" % NO_POSE_GIVE_UP_S)
                    continue
                last_pose_ns, pose, eyes = hh.now_ns(), msg, msg.eye
            cams = host.cameras()  # the board may have changed them: render with what it wants now
            start = hh.now_ns()
            color, depth = [], []
            for e in range(2):
                c = cams.cam[e]
                if bufs.get(e, (None,))[0] != (c.width, c.height):
                    bufs[e] = ((c.width, c.height), np.empty((c.height, c.width, 4), np.uint8),
                               np.empty((c.height, c.width), np.float32))
                _, col, dep = bufs[e]
                r.render(e, (eyes or pose)[e], c, col, dep)
                color.append(col)
                depth.append(dep)
            try:
                host.submit(color, depth, pose=pose, cameras=cams, render_start_ns=start, render_end_ns=hh.now_ns())
            except hh.HostError as e:
                # gone (the library reconnects), or the board changed its eye sizes since the render: the next pose
                resized = e.code == hh.ERR_SIZE and [(c.width, c.height) for c in host.cameras().cam] != \
                    [(c.width, c.height) for c in cams.cam]
                if e.code not in (hh.ERR_DISCONNECTED, hh.ERR_NOT_CONNECTED) and not resized:
                    raise
                print("render_gl.py: frame dropped: %s" % e, file=sys.stderr)
                continue
            done += 1
        if a.save and done:
            for e in range(2):
                save_ppm("%s-%d.ppm" % (a.save, e), color[e])
        s = host.stats()
        print("render_gl.py: %d frames sent, %.1f MB, %d poses received, %d refused, %d send errors"
              % (s.frames_sent, s.bytes_sent / 1e6, s.poses_received, s.frames_refused, s.send_errors))
    EGL.eglMakeCurrent(dpy, EGL.EGL_NO_SURFACE, EGL.EGL_NO_SURFACE, EGL.EGL_NO_CONTEXT)
    EGL.eglDestroyContext(dpy, ctx)
    EGL.eglTerminate(dpy)


if __name__ == "__main__":
    main()
