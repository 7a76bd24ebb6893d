/* SPDX-License-Identifier: MIT */
/* plat_gles: the warp on the GPU with OpenGL ES 3.0 (GLSL ES 3.00): host frame upload, the min-max depth pyramid,
 * the height-map raytrace with its edge fills, and the lens pass through the distortion mesh (with per-pixel rays in
 * raytrace_mesh's marked cells); per-pass GPU times. */
#include "platform/plat_gles.h"

#include <EGL/egl.h>
#include <GLES3/gl3.h>
#include <GLES2/gl2ext.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "platform/plat_clock.h"
#include "warp/warp_err.h"

/* ---- shaders (GLSL ES 3.00: nothing beyond what V3D and Mali-class GPUs run) ---- */

/* One triangle covering the viewport; no vertex buffer (gl_VertexID). */
static const char vs_full[] =
    "#version 300 es\n"
    "void main() {\n"
    "    vec2 p = vec2(float((gl_VertexID & 1) << 2) - 1.0, float((gl_VertexID & 2) << 1) - 1.0);\n"
    "    gl_Position = vec4(p, 0.0, 1.0);\n"
    "}\n";

#define GLSL_HEAD "#version 300 es\n" "precision highp float;\n" "precision highp int;\n"

/* The lens pass's uniforms and its interpolation (shared by the lens pass and the traced lens pass). */
#define LENS_BODY                                                                                                     \
    "uniform highp sampler2D u_src;\n"                                                                                \
    "uniform highp sampler2D u_mesh;\n"                                                                               \
    "uniform ivec2 u_vp;      /* viewport origin on the panel (x from the left, y from the top) */\n"                 \
    "uniform int u_flip_h;    /* 0: window row = panel row; else the window height (GL row 0 at the bottom) */\n"     \
    "uniform int u_vp_h, u_rows, u_cell_w;\n"                                                                         \
    "uniform vec2 u_src_size;\n"                                                                                      \
    "uniform highp isampler2D u_vis; /* the hidden-area mask: texel (y, 0) = row y's visible [x0, x1) */\n"           \
    "uniform int u_has_vis;\n"                                                                                        \
    "layout(location = 0) out vec4 o;\n"                                                                              \
    "int g_vx, g_vy; /* lens_cell's viewport pixel */\n"                                                              \
    "vec2 pos(highp sampler2D m, int i, int j, int c, float fx, float ty) {\n"                                        \
    "    vec2 p00 = texelFetch(m, ivec2(i * 3 + c, j), 0).xy;\n"                                                      \
    "    vec2 p10 = texelFetch(m, ivec2(i * 3 + 3 + c, j), 0).xy;\n"                                                  \
    "    vec2 p01 = texelFetch(m, ivec2(i * 3 + c, j + 1), 0).xy;\n"                                                  \
    "    vec2 p11 = texelFetch(m, ivec2(i * 3 + 3 + c, j + 1), 0).xy;\n"                                              \
    "    vec2 l = p00 + (p01 - p00) * ty, r = p10 + (p11 - p10) * ty;\n"                                              \
    "    return l + (r - l) * fx;\n"                                                                                  \
    "}\n"                                                                                                             \
    "/* the viewport pixel of this fragment, its cell (i, j) and its fractions across it; false where masked */\n"    \
    "bool lens_cell(out int i, out int j, out float fx, out float ty) {\n"                                            \
    "    ivec2 f = ivec2(gl_FragCoord.xy);\n"                                                                         \
    "    int x = f.x - u_vp.x;\n"                                                                                     \
    "    int y = (u_flip_h != 0 ? u_flip_h - 1 - f.y : f.y) - u_vp.y;\n"                                              \
    "    i = 0; j = 0; fx = 0.0; ty = 0.0; g_vx = x; g_vy = y;\n"                                                     \
    "    if (u_has_vis != 0) {\n"                                                                                     \
    "        ivec2 sp = texelFetch(u_vis, ivec2(y, 0), 0).xy;\n"                                                      \
    "        if (x < sp.x || x >= sp.y) return false;\n"                                                              \
    "    }\n"                                                                                                         \
    "    float gy = (float(y) + 0.5) * float(u_rows - 1) / float(u_vp_h);\n"                                          \
    "    j = min(int(gy), u_rows - 2);\n"                                                                             \
    "    ty = gy - float(j);\n"                                                                                       \
    "    i = x / u_cell_w;\n"                                                                                         \
    "    fx = (float(x - i * u_cell_w) + 0.5) / float(u_cell_w);\n"                                                   \
    "    return true;\n"                                                                                              \
    "}\n"                                                                                                             \
    "vec3 lens_sample(int i, int j, float fx, float ty) {\n"                                                          \
    "    vec2 inv = 1.0 / u_src_size;\n"                                                                              \
    "    float r = texture(u_src, pos(u_mesh, i, j, 0, fx, ty) * inv).r;\n"                                           \
    "    float g = texture(u_src, pos(u_mesh, i, j, 1, fx, ty) * inv).g;\n"                                           \
    "    float b = texture(u_src, pos(u_mesh, i, j, 2, fx, ty) * inv).b;\n"                                           \
    "    return vec3(r, g, b);\n"                                                                                     \
    "}\n"

/* The lens pass. Same interpolation as warp_mesh_resample (warp_mesh.h): rows evenly spread over the viewport,
 * columns cell_w apart, bilinear between the cell's four vertices, vertical first. The vertex positions are in an
 * RG32F texture, texel (i*3 + c, j) = source position of vertex (i, j) for channel c. */
static const char fs_lens[] = GLSL_HEAD LENS_BODY
    "void main() {\n"
    "    int i, j;\n"
    "    float fx, ty;\n"
    "    if (!lens_cell(i, j, fx, ty)) { o = vec4(0.0, 0.0, 0.0, 1.0); return; }\n"
    "    o = vec4(lens_sample(i, j, fx, ty), 1.0);\n"
    "}\n";

/* The pyramid's levels share one shader: level 0 holds the largest inverse depth a bilinear sample in each cell can
 * see (the cell's texel and its right and lower neighbours, step ""), level L > 0 the 2x2 maximum of level L-1
 * (step " * 2": sizes rounded up). */
#define FS_PYRAMID(step)                                                                                               \
    "#version 300 es\n"                                                                                               \
    "precision highp float;\n"                                                                                        \
    "precision highp int;\n"                                                                                          \
    "uniform highp sampler2D u_in;\n"                                                                                 \
    "uniform ivec2 u_in_size;\n"                                                                                      \
    "layout(location = 0) out vec4 o;\n"                                                                              \
    "void main() {\n"                                                                                                 \
    "    ivec2 c = ivec2(gl_FragCoord.xy)" step ";\n"                                                                 \
    "    ivec2 d = min(c + 1, u_in_size - 1);\n"                                                                      \
    "    float m = max(max(texelFetch(u_in, c, 0).r, texelFetch(u_in, ivec2(d.x, c.y), 0).r),\n"                      \
    "                  max(texelFetch(u_in, ivec2(c.x, d.y), 0).r, texelFetch(u_in, d, 0).r));\n"                     \
    "    o = vec4(m, 0.0, 0.0, 1.0);\n"                                                                               \
    "}\n"
static const char fs_pyr0[] = FS_PYRAMID("");
static const char fs_pyrn[] = FS_PYRAMID(" * 2");
#undef FS_PYRAMID

/* The raytrace of warp_raytrace.c, line for line where it decides anything (the same step grid, bracketing,
 * Illinois refinement and edge test), with one difference in how it walks: before taking the next step it asks
 * the pyramid whether the surface anywhere in the block of cells the ray is crossing comes as near as the ray
 * gets there; when not, every step inside that block is skipped at once (and the next, larger, block is tried).
 * Skipping is conservative (one step of margin at the block's exit) and the bracketing samples are recomputed
 * exactly, so the hit is the one the CPU's linear search finds; only empty space is skipped (000 §5.3).
 * trace_at(fc, h, a) is the ray through eye-buffer position fc (pixel units, centres at +0.5) under a setup: where
 * its colour is sampled, and its flag (0, FRINGE or EDGE); hit_colour that colour; trace(fc) both under u_h, u_a
 * (the raytrace pass). The traced lens pass calls trace_at and hit_colour itself. */
#define RT_BODY                                                                                                       \
    "uniform highp sampler2D u_color;\n"                                                                              \
    "uniform highp sampler2D u_depth;\n"                                                                              \
    "uniform highp sampler2D u_pyr;\n"                                                                                \
    "uniform mat3 u_h;\n"                                                                                             \
    "uniform vec3 u_a;\n"                                                                                             \
    "uniform vec2 u_drange;\n"                                                                                        \
    "uniform ivec2 u_size;\n"                                                                                         \
    "uniform int u_max_steps, u_refine, u_fill_far, u_levels;\n"                                                      \
    "uniform float u_jump;\n"                                                                                         \
    "uniform ivec2 u_lvl_off[16];\n"                                                                                  \
    "const float FRINGE = 1.0, EDGE = 2.0;\n"                                                                         \
    "float g_pix, g_piy, g_ex, g_ey, g_hi, g_lo, g_dd;\n"                                                             \
    "int g_n, g_samples = 0;\n"                                                                                       \
    "float inv_at(vec2 p) {\n"                                                                                        \
    "    vec2 f = clamp(p - 0.5, vec2(0.0), vec2(u_size - 1));\n"                                                     \
    "    ivec2 i0 = ivec2(f);\n"                                                                                      \
    "    ivec2 i1 = min(i0 + 1, u_size - 1);\n"                                                                       \
    "    vec2 a = f - vec2(i0);\n"                                                                                    \
    "    float d00 = texelFetch(u_depth, i0, 0).r, d10 = texelFetch(u_depth, ivec2(i1.x, i0.y), 0).r;\n"              \
    "    float d01 = texelFetch(u_depth, ivec2(i0.x, i1.y), 0).r, d11 = texelFetch(u_depth, i1, 0).r;\n"              \
    "    float mx = max(max(d00, d10), max(d01, d11)), mn = min(min(d00, d10), min(d01, d11));\n"                     \
    "    if (mx - mn > u_jump * mx) return a.y < 0.5 ? (a.x < 0.5 ? d00 : d10) : (a.x < 0.5 ? d01 : d11);\n"          \
    "    float top = d00 + (d10 - d00) * a.x, bot = d01 + (d11 - d01) * a.x;\n"                                       \
    "    return top + (bot - top) * a.y;\n"                                                                           \
    "}\n"                                                                                                             \
    "vec4 bilinear(vec2 p) { return texture(u_color, p / vec2(u_size)); }\n"                                          \
    "vec2 far_texel(vec2 p) { /* the centre of the farthest of the texels a bilinear sample at p reads */\n"          \
    "    ivec2 b0 = ivec2(floor(p - 0.5));\n"                                                                         \
    "    ivec2 bi = clamp(b0, ivec2(0), u_size - 1);\n"                                                               \
    "    float best = 3.0e38;\n"                                                                                      \
    "    for (int j = 0; j < 2; j++)\n"                                                                               \
    "        for (int i = 0; i < 2; i++) {\n"                                                                         \
    "            ivec2 q = clamp(b0 + ivec2(i, j), ivec2(0), u_size - 1);\n"                                          \
    "            float d = texelFetch(u_depth, q, 0).r;\n"                                                            \
    "            if (d < best) { best = d; bi = q; }\n"                                                               \
    "        }\n"                                                                                                     \
    "    return vec2(bi) + 0.5;\n"                                                                                    \
    "}\n"                                                                                                             \
    "void cell_range(vec2 p, inout float nd, inout float fd) {\n"                                                     \
    "    ivec2 b0 = ivec2(floor(p - 0.5));\n"                                                                         \
    "    for (int j = 0; j < 2; j++)\n"                                                                               \
    "        for (int i = 0; i < 2; i++) {\n"                                                                         \
    "            float d = texelFetch(u_depth, clamp(b0 + ivec2(i, j), ivec2(0), u_size - 1), 0).r;\n"                \
    "            nd = max(nd, d); fd = min(fd, d);\n"                                                                 \
    "        }\n"                                                                                                     \
    "}\n"                                                                                                             \
    "float texel_at(vec2 p, out vec2 c) {\n"                                                                          \
    "    ivec2 t = clamp(ivec2(floor(p)), ivec2(0), u_size - 1);\n"                                                   \
    "    c = vec2(t) + 0.5;\n"                                                                                        \
    "    return texelFetch(u_depth, t, 0).r;\n"                                                                       \
    "}\n"                                                                                                             \
    "bool clip_axis(float p, float e, float size, inout float lo, inout float hi) {\n"                                \
    "    if (abs(e) < 1e-12) return p >= 0.0 && p <= size;\n"                                                         \
    "    float d0 = (0.0 - p) / e, d1 = (size - p) / e;\n"                                                            \
    "    if (d0 > d1) { float t = d0; d0 = d1; d1 = t; }\n"                                                           \
    "    if (d0 > lo) lo = d0;\n"                                                                                     \
    "    if (d1 < hi) hi = d1;\n"                                                                                     \
    "    return lo <= hi;\n"                                                                                          \
    "}\n"                                                                                                             \
    "float dk(int k) { return k >= g_n ? g_lo : g_hi - g_dd * float(k); }\n"                                          \
    "vec2 at(float d) { return vec2(g_pix + d * g_ex, g_piy + d * g_ey); }\n"                                         \
    "/* First step index >= k whose sample may lie outside block [b0, b1) of cells along one axis. */\n"              \
    "int axis_exit(int k, float s, float v, int b0, int b1, int size) {\n"                                            \
    "    float lim = float(g_n + 2);\n"                                                                               \
    "    if (v > 0.0 && b1 < size) return k + int(min(ceil((float(b1) + 0.5 - s) / v), lim));\n"                      \
    "    if (v < 0.0 && b0 > 0) return k + int(min(floor((s - float(b0) - 0.5) / -v), lim)) + 1;\n"                   \
    "    return g_n + 2;\n"                                                                                           \
    "}\n"                                                                                                             \
    "/* the ray through fc under (h, a) (u_h and u_a, or a rolling panel's last line's): where its\n"                 \
    " * colour is sampled, and its flag */\n"                                                                         \
    "vec2 trace_at(vec2 fc, mat3 h, vec3 a, out float flag) {\n"                                                      \
    "    vec3 b = h * vec3(fc, 1.0);\n"                                                                               \
    "    float sw = float(u_size.x), sh = float(u_size.y);\n"                                                         \
    "    if (!(b.z > 1e-9 * (abs(b.x) + abs(b.y) + abs(b.z)))) {\n"                                                   \
    "        flag = FRINGE;\n"                                                                                        \
    "        return vec2(b.x > 0.0 ? sw : 0.0, b.y > 0.0 ? sh : 0.0);\n"                                              \
    "    }\n"                                                                                                         \
    "    g_pix = b.x / b.z; g_piy = b.y / b.z;\n"                                                                     \
    "    g_ex = a.x - a.z * g_pix; g_ey = a.y - a.z * g_piy;\n"                                                       \
    "    float hi = u_drange.y, lo = u_drange.x;\n"                                                                   \
    "    if (a.z > 0.0 && 1.0 / a.z < hi) hi = 1.0 / a.z;\n"                                                          \
    "    float hi0 = hi;\n"                                                                                           \
    "    bool inside = lo <= hi && clip_axis(g_pix, g_ex, sw, lo, hi) && clip_axis(g_piy, g_ey, sh, lo, hi);\n"       \
    "    if (!inside) {\n"                                                                                            \
    "        float d = clamp(lo, u_drange.x, u_drange.y); /* the CPU rule: within the frame's depth range */\n"       \
    "        flag = FRINGE;\n"                                                                                        \
    "        return at(d);\n"                                                                                         \
    "    }\n"                                                                                                         \
    "    bool near_clipped = hi < hi0;\n"                                                                             \
    "    float len = abs(hi - lo) * sqrt(g_ex * g_ex + g_ey * g_ey);\n"                                               \
    "    g_n = clamp(int(ceil(len)), 1, u_max_steps);\n"                                                              \
    "    g_hi = hi; g_lo = lo; g_dd = (hi - lo) / float(g_n);\n"                                                      \
    "    flag = 0.0;\n"                                                                                               \
    "    float da = hi, sa = inv_at(at(da)), fa = sa - da;\n"                                                         \
    "    float db = da, sb = sa, fb = fa, dfront = da;\n"                                                             \
    "    if (fa >= 0.0) {\n"                                                                                          \
    "        if (near_clipped) flag = FRINGE;\n"                                                                      \
    "    } else {\n"                                                                                                  \
    "        int k = 1, lvl = min(1, u_levels - 1);\n"                                                                \
    "        bool hit = false, prev_exact = true;\n"                                                                  \
    "        vec2 v = vec2(-g_dd * g_ex, -g_dd * g_ey); /* sample movement per step */\n"                             \
    "        for (int it = 0; it < 16384 && k <= g_n; it++) {\n"                                                      \
    "            vec2 s = at(dk(k));\n"                                                                               \
    "            ivec2 cell = clamp(ivec2(floor(s - 0.5)), ivec2(0), u_size - 1);\n"                                  \
    "            ivec2 blk = cell >> lvl;\n"                                                                          \
    "            int kx = axis_exit(k, s.x, v.x, blk.x << lvl, (blk.x + 1) << lvl, u_size.x);\n"                      \
    "            int ky = axis_exit(k, s.y, v.y, blk.y << lvl, (blk.y + 1) << lvl, u_size.y);\n"                      \
    "            int klast = min(min(kx, ky), g_n + 1) - 2; /* last step surely inside the block */\n"                \
    "            if (klast >= k) {\n"                                                                                 \
    "                float m = texelFetch(u_pyr, u_lvl_off[lvl] + blk, 0).r;\n"                                       \
    "                if (m < dk(klast)) {\n"                                                                          \
    "                    k = klast + 1; prev_exact = false;\n"                                                        \
    "                    lvl = min(lvl + 1, u_levels - 1);\n"                                                         \
    "                    continue;\n"                                                                                 \
    "                }\n"                                                                                             \
    "                if (lvl > 0) { lvl--; continue; }\n"                                                             \
    "            }\n"                                                                                                 \
    "            db = dk(k); sb = inv_at(at(db)); fb = sb - db; g_samples++;\n"                                       \
    "            if (fb >= 0.0) { hit = true; break; }\n"                                                             \
    "            da = db; fa = fb; sa = sb; prev_exact = true;\n"                                                     \
    "            k++;\n"                                                                                              \
    "        }\n"                                                                                                     \
    "        if (!hit) {\n"                                                                                           \
    "            flag = FRINGE;\n"                                                                                    \
    "            da = g_lo;\n"                                                                                        \
    "        } else {\n"                                                                                              \
    "            if (!prev_exact) { da = dk(k - 1); sa = inv_at(at(da)); fa = sa - da; }\n"                           \
    "            dfront = da;\n"                                                                                      \
    "            int side = 0;\n"                                                                                     \
    "            float epx = sqrt(g_ex * g_ex + g_ey * g_ey);\n"                                                      \
    "            for (int it = 0; it < u_refine && abs(db - da) * epx > 1.0 / 64.0; it++) {\n"                        \
    "                float dm = da + (db - da) * (-fa) / (fb - fa);\n"                                                \
    "                float fm = inv_at(at(dm)) - dm;\n"                                                               \
    "                if (fm < 0.0) {\n"                                                                               \
    "                    da = dm; fa = fm;\n"                                                                         \
    "                    if (side == -1) fb *= 0.5;\n"                                                                \
    "                    side = -1;\n"                                                                                \
    "                } else {\n"                                                                                      \
    "                    db = dm; fb = fm;\n"                                                                         \
    "                    if (side == 1) fa *= 0.5;\n"                                                                 \
    "                    side = 1;\n"                                                                                 \
    "                }\n"                                                                                             \
    "            }\n"                                                                                                 \
    "            if (u_refine > 0) da = fb - fa != 0.0 ? da + (db - da) * (-fa) / (fb - fa) : db;\n"                  \
    "            else da = db;\n"                                                                                     \
    "        }\n"                                                                                                     \
    "    }\n"                                                                                                         \
    "    vec2 hp = at(da);\n"                                                                                         \
    "    if (flag == 0.0 && len * 64.0 > 1.0) {\n"                                                                    \
    "        float nd = 0.0, fd = 3.0e38;\n"                                                                          \
    "        vec2 c;\n"                                                                                               \
    "        cell_range(hp, nd, fd);\n"                                                                               \
    "        cell_range(at(dfront), nd, fd);\n"                                                                       \
    "        if (nd - fd > u_jump * nd) {\n"                                                                          \
    "            float near_lo = nd * (1.0 - u_jump);\n"                                                              \
    "            if (texel_at(at(nd), c) < near_lo && texel_at(hp, c) >= near_lo) flag = EDGE;\n"                     \
    "            else hp = c;\n"                                                                                      \
    "        }\n"                                                                                                     \
    "    }\n"                                                                                                         \
    "    return flag == EDGE && u_fill_far != 0 ? far_texel(hp) : hp;\n"                                              \
    "}\n"                                                                                                             \
    "/* the colour of a ray that trace_at put at p with flag (the far fill: that texel) */\n"                         \
    "vec4 hit_colour(vec2 p, float flag) {\n"                                                                         \
    "    return flag == EDGE && u_fill_far != 0 ? texelFetch(u_color, ivec2(p), 0) : bilinear(p);\n"                  \
    "}\n"                                                                                                             \
    "vec4 trace(vec2 fc) { /* its colour and its flag */\n"                                                           \
    "    float flag;\n"                                                                                               \
    "    vec2 p = trace_at(fc, u_h, u_a, flag);\n"                                                                    \
    "    return vec4(hit_colour(p, flag).rgb, flag);\n"                                                               \
    "}\n"

static const char fs_raytrace[] = GLSL_HEAD RT_BODY
    "uniform int u_count;     /* diagnostics: output the search's depth samples instead of colour */\n"
    "layout(location = 0) out vec4 o;\n"
    "void main() {\n"
    "    vec4 t = trace(gl_FragCoord.xy);\n"
    "    vec3 c = u_count != 0 ? vec3(float(g_samples & 255), float((g_samples >> 8) & 255), 0.0) / 255.0 : t.rgb;\n"
    "    o = vec4(c, t.a / 255.0);\n"
    "}\n";

/* The display path's depth warp (raytrace_mesh, warp_mesh_trace.h) in the lens pass: u_mesh holds the vertices'
 * raytraced source positions, interpolated as the lens pass does, except in the cells u_cells marks (a depth edge or
 * too much parallax between the vertices), where each channel's ray is traced from the pixel's own eye-buffer
 * position (u_eyepos: the vertices' lens directions in the eye buffer, interpolated alike). One pass, no eye-space
 * image: the traced pixels are sampled once, where the two-pass raytrace resamples its intermediate. */
static const char fs_lens_traced[] = GLSL_HEAD LENS_BODY RT_BODY
    "uniform highp usampler2D u_cells; /* texel (i, j) != 0: cell (i, j) traced per pixel */\n"
    "uniform highp sampler2D u_eyepos;\n"
    "uniform mat3 u_h2;       /* a rolling panel's last line's setup (u_h, u_a: its first line's) */\n"
    "uniform vec3 u_a2;\n"
    "uniform int u_roll;      /* 0: a global panel; else 1 + its warp_scan_dir */\n"
    "uniform ivec2 u_panel;   /* the panel's size (warp_scan's) */\n"
    "/* warp_scan_fraction of this fragment's panel position */\n"
    "float scan_fraction() {\n"
    "    int dir = u_roll - 1;\n"
    "    bool vertical = dir < 2;\n"
    "    float p = vertical ? float(u_vp.y + g_vy) + 0.5 : float(u_vp.x + g_vx) + 0.5;\n"
    "    int n = vertical ? u_panel.y : u_panel.x;\n"
    "    float f = n > 1 ? clamp((p - 0.5) / float(n - 1), 0.0, 1.0) : 0.5;\n"
    "    return dir == 1 || dir == 3 ? 1.0 - f : f;\n"
    "}\n"
    "void main() {\n"
    "    int i, j;\n"
    "    float fx, ty;\n"
    "    if (!lens_cell(i, j, fx, ty)) { o = vec4(0.0, 0.0, 0.0, 1.0); return; }\n"
    "    ivec2 nc = textureSize(u_cells, 0);\n"
    "    if (texelFetch(u_cells, min(ivec2(i, j), nc - 1), 0).r == 0u) {\n"
    "        o = vec4(lens_sample(i, j, fx, ty), 1.0);\n"
    "        return;\n"
    "    }\n"
    "    /* Each channel's ray; on a rolling panel traced under the first (k = 0) and the last line's setup (k = 1),\n"
    "     * the source positions interpolated at the pixel's scan fraction f, as warp_mesh_trace_rect does. One call\n"
    "     * of trace_at in loops: compilers inline a function at every call, and six copies of the search made the\n"
    "     * program slow to compile on a software rasterizer. */\n"
    "    bool roll = u_roll != 0;\n"
    "    float f = roll ? scan_fraction() : 0.0;\n"
    "    vec3 col = vec3(0.0);\n"
    "    for (int c = 0; c < 3; c++) {\n"
    "        vec2 e = pos(u_eyepos, i, j, c, fx, ty), p = vec2(0.0), q = vec2(0.0);\n"
    "        float flag = 0.0;\n"
    "        for (int k = 0; k < (roll ? 2 : 1); k++) {\n"
    "            if (roll && (k == 0 ? f >= 1.0 : f <= 0.0)) continue; /* its weight is 0 */\n"
    "            float fl;\n"
    "            vec2 r = trace_at(e, k == 0 ? u_h : u_h2, k == 0 ? u_a : u_a2, fl);\n"
    "            if (k == 0) { p = r; flag = fl; } else q = r;\n"
    "        }\n"
    "        vec4 v = roll ? bilinear(f <= 0.0 ? p : (f >= 1.0 ? q : p + (q - p) * f)) : hit_colour(p, flag);\n"
    "        if (c == 0) col.r = v.r; else if (c == 1) col.g = v.g; else col.b = v.b;\n"
    "    }\n"
    "    o = vec4(col, 1.0);\n"
    "}\n";

/* ---- state ---- */

enum { TIMING_OFF, TIMING_QUERY, TIMING_FINISH };
#define QSLOTS 4
#define QPER 24

typedef struct {
    GLuint q[QPER];
    int pass[QPER];
    int n;
    bool pending;
} qslot;

typedef struct {
    GLuint color, depth;             /* host frame: RGBA8, R32F */
    GLuint mesh;                     /* RG32F vertex source positions */
    GLuint vis;                      /* RG32I hidden-area mask rows (warp_mesh.visible), uploaded when it changes */
    const int32_t *vis_from;         /* the mask last uploaded */
    GLuint inter, inter_fbo;         /* raytrace output, RGBA8 */
    GLuint lvl[PLAT_GLES_MAX_LEVELS], lvl_fbo[PLAT_GLES_MAX_LEVELS]; /* pyramid levels (GPU build) */
    GLuint atlas, atlas_fbo;         /* every level side by side: what the raytrace reads */
    GLuint cells;                    /* R8UI per mesh cell: traced per pixel (the traced lens pass) */
    GLuint eyepos;                   /* RG32F per vertex and channel: where its lens direction meets the eye buffer */
    float *eyepos_px;                /* what eyepos holds, staged; uploaded only when it changes (lens or camera) */
    bool eyepos_sent;
} eye_res;

typedef struct {
    GLuint prog;
    GLint loc[32];
} program;

enum { L_SRC, L_MESH, L_VP, L_FLIP, L_VPH, L_ROWS, L_CELLW, L_SRCSIZE, L_VIS, L_HASVIS };
enum { P_IN, P_INSIZE };
enum { R_COLOR, R_DEPTH, R_PYR, R_H, R_A, R_DRANGE, R_SIZE, R_STEPS, R_REFINE, R_FILL, R_LEVELS, R_JUMP, R_OFF,
       R_COUNT };
/* the traced lens pass: the lens pass's uniforms (L_*), the raytrace's at T_RT + R_* (but u_count), its own */
enum { T_RT = L_HASVIS + 1, T_CELLS = T_RT + R_COUNT, T_EYEPOS, T_H2, T_A2, T_ROLL, T_PANEL };

struct plat_gles {
    plat_egl *egl;
    plat_gles_params p;
    program lens, pyr0, pyrn, rt, traced;
    GLuint vao;
    GLuint panel, panel_fbo;
    eye_res eye[2];
    int levels;
    int lvl_w[PLAT_GLES_MAX_LEVELS], lvl_h[PLAT_GLES_MAX_LEVELS];
    int lvl_x[PLAT_GLES_MAX_LEVELS], lvl_y[PLAT_GLES_MAX_LEVELS];
    int atlas_w, atlas_h;
    bool gpu_pyramid;
    bool count_samples;
    float *cpu_scratch, *cpu_level; /* CPU pyramid build */
    /* timing */
    int timing;
    qslot slots[QSLOTS];
    int cur;
    int active;      /* pass being timed, -1 none */
    int64_t t_begin; /* glFinish mode */
    double acc[PLAT_GLES_PASSES];
    bool acc_valid[PLAT_GLES_PASSES];
    plat_gles_times latest;
    PFNGLGETQUERYOBJECTUI64VEXTPROC get_u64;
};

const char *plat_gles_pass_name(plat_gles_pass p)
{
    static const char *const n[PLAT_GLES_PASSES] = {"upload", "pyramid", "raytrace", "lens", "readback"};
    return p >= 0 && p < PLAT_GLES_PASSES ? n[p] : "?";
}

/* ---- pyramid geometry and CPU reference ---- */

int plat_gles_pyramid_levels(int w, int h)
{
    int n = 1;
    while ((w > 1 || h > 1) && n < PLAT_GLES_MAX_LEVELS) {
        w = (w + 1) / 2;
        h = (h + 1) / 2;
        n++;
    }
    return n;
}

void plat_gles_pyramid_level_size(int w, int h, int level, int *lw, int *lh)
{
    for (int l = 0; l < level; l++) {
        w = (w + 1) / 2;
        h = (h + 1) / 2;
    }
    *lw = w;
    *lh = h;
}

static inline float max4(float a, float b, float c, float d)
{
    float m = a > b ? a : b, n = c > d ? c : d;
    return m > n ? m : n;
}

/* One reduction step from (w, h) values in `in` (row stride w) into out (stride ow). */
static void reduce(const float *in, int w, int h, int step, float *out, int ow, int oh)
{
    for (int y = 0; y < oh; y++)
        for (int x = 0; x < ow; x++) {
            int x0 = x * step, y0 = y * step;
            int x1 = x0 + 1 < w ? x0 + 1 : w - 1, y1 = y0 + 1 < h ? y0 + 1 : h - 1;
            out[(size_t)y * ow + x] = max4(in[(size_t)y0 * w + x0], in[(size_t)y0 * w + x1], in[(size_t)y1 * w + x0],
                                           in[(size_t)y1 * w + x1]);
        }
}

void plat_gles_pyramid_cpu(const warp_image_f32 *inv, int level, warp_image_f32 *out, float *scratch)
{
    int w = inv->w, h = inv->h;
    /* level 0 into scratch (dense rows), then halve in place: each output cell lies at or before its inputs */
    for (int y = 0; y < h; y++) {
        const float *r0 = &WARP_AT(inv, 0, y), *r1 = &WARP_AT(inv, 0, y + 1 < h ? y + 1 : y);
        for (int x = 0; x < w; x++) {
            int x1 = x + 1 < w ? x + 1 : x;
            scratch[(size_t)y * w + x] = max4(r0[x], r0[x1], r1[x], r1[x1]);
        }
    }
    for (int l = 1; l <= level; l++) {
        int ow = (w + 1) / 2, oh = (h + 1) / 2;
        reduce(scratch, w, h, 2, scratch, ow, oh);
        w = ow;
        h = oh;
    }
    for (int y = 0; y < h; y++) memcpy(&WARP_AT(out, 0, y), scratch + (size_t)y * w, sizeof(float) * (size_t)w);
}

/* ---- GL helpers ---- */

static GLuint compile(GLenum type, const char *src, const char *name, char *err, int errlen)
{
    GLuint s = glCreateShader(type);
    glShaderSource(s, 1, &src, NULL);
    glCompileShader(s);
    GLint ok = 0;
    glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        char log[600] = "";
        glGetShaderInfoLog(s, sizeof log, NULL, log);
        warp_err(err, errlen, "GLES: shader %s does not compile: %s", name, log);
        glDeleteShader(s);
        return 0;
    }
    return s;
}

static bool link(program *pr, const char *fs, const char *name, const char *const *uniforms, char *err, int errlen)
{
    GLuint v = compile(GL_VERTEX_SHADER, vs_full, "fullscreen vertex", err, errlen);
    GLuint f = v ? compile(GL_FRAGMENT_SHADER, fs, name, err, errlen) : 0;
    if (!f) {
        if (v) glDeleteShader(v);
        return false;
    }
    pr->prog = glCreateProgram();
    glAttachShader(pr->prog, v);
    glAttachShader(pr->prog, f);
    glLinkProgram(pr->prog);
    glDeleteShader(v);
    glDeleteShader(f);
    GLint ok = 0;
    glGetProgramiv(pr->prog, GL_LINK_STATUS, &ok);
    if (!ok) {
        char log[600] = "";
        glGetProgramInfoLog(pr->prog, sizeof log, NULL, log);
        return warp_err(err, errlen, "GLES: program %s does not link: %s", name, log);
    }
    for (int i = 0; uniforms[i]; i++) pr->loc[i] = glGetUniformLocation(pr->prog, uniforms[i]);
    return true;
}

static GLuint texture(GLenum ifmt, int w, int h, GLenum filter)
{
    GLuint t;
    glGenTextures(1, &t);
    glBindTexture(GL_TEXTURE_2D, t);
    glTexStorage2D(GL_TEXTURE_2D, 1, ifmt, w, h);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, (GLint)filter);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, (GLint)filter);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    return t;
}

static bool fbo_for(GLuint tex, GLuint *fbo)
{
    glGenFramebuffers(1, fbo);
    glBindFramebuffer(GL_FRAMEBUFFER, *fbo);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, tex, 0);
    return glCheckFramebufferStatus(GL_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE;
}

static const char *gl_err_str(GLenum e)
{
    switch (e) {
    case GL_INVALID_ENUM: return "GL_INVALID_ENUM";
    case GL_INVALID_VALUE: return "GL_INVALID_VALUE";
    case GL_INVALID_OPERATION: return "GL_INVALID_OPERATION";
    case GL_INVALID_FRAMEBUFFER_OPERATION: return "GL_INVALID_FRAMEBUFFER_OPERATION";
    case GL_OUT_OF_MEMORY: return "GL_OUT_OF_MEMORY";
    default: return "GL error";
    }
}

/* ---- timing ---- */

static void pass_begin(plat_gles *g, plat_gles_pass p)
{
    g->active = -1;
    if (g->timing == TIMING_QUERY) {
        qslot *s = &g->slots[g->cur];
        if (s->n >= QPER) return;
        glBeginQuery(GL_TIME_ELAPSED_EXT, s->q[s->n]);
        s->pass[s->n] = p;
        g->active = p;
    } else if (g->timing == TIMING_FINISH) {
        glFinish();
        g->t_begin = plat_now_ns();
        g->active = p;
    }
}

static void pass_end(plat_gles *g)
{
    if (g->active < 0) return;
    if (g->timing == TIMING_QUERY) {
        glEndQuery(GL_TIME_ELAPSED_EXT);
        g->slots[g->cur].n++;
    } else {
        glFinish();
        g->acc[g->active] += (double)(plat_now_ns() - g->t_begin) * 1e-6;
        g->acc_valid[g->active] = true;
    }
    g->active = -1;
}

/* Reads a finished slot into latest; false while its last query is not available. */
static bool collect(plat_gles *g, qslot *s)
{
    GLuint avail = 0;
    glGetQueryObjectuiv(s->q[s->n - 1], GL_QUERY_RESULT_AVAILABLE, &avail);
    if (!avail) return false;
    GLint disjoint = 0;
    glGetIntegerv(GL_GPU_DISJOINT_EXT, &disjoint);
    plat_gles_times t;
    memset(&t, 0, sizeof t);
    for (int i = 0; i < s->n; i++) {
        GLuint64 ns = 0;
        if (g->get_u64) {
            g->get_u64(s->q[i], GL_QUERY_RESULT, &ns);
        } else {
            GLuint v = 0;
            glGetQueryObjectuiv(s->q[i], GL_QUERY_RESULT, &v);
            ns = v;
        }
        /* llvmpipe sometimes answers a raw timestamp (seconds since boot) for a query begun before any work:
         * nothing in one vsync takes a second, so such a frame is dropped like a disjoint one. */
        if (ns > 1000000000ull) disjoint = 1;
        t.ms[s->pass[i]] += (double)ns * 1e-6 / plat_clock_slowdown(); /* the GPU's ns are real: virtual, as all times */
        t.valid[s->pass[i]] = true;
    }
    s->pending = false;
    s->n = 0;
    /* A disjoint event (frequency change, power state) makes the numbers meaningless: drop them. */
    if (disjoint) return true;
    t.seq = g->latest.seq + 1;
    g->latest = t;
    return true;
}

void plat_gles_end_frame(plat_gles *g)
{
    if (g->timing == TIMING_QUERY) {
        qslot *s = &g->slots[g->cur];
        s->pending = s->n > 0;
        /* oldest first */
        for (int k = 1; k <= QSLOTS; k++) {
            qslot *o = &g->slots[(g->cur + k) % QSLOTS];
            if (o->pending && !collect(g, o)) break;
        }
        g->cur = (g->cur + 1) % QSLOTS;
        qslot *n = &g->slots[g->cur];
        if (n->pending) {
            /* Four frames behind: drop rather than wait (the pass times come late, never the vsync). */
            n->pending = false;
        }
        n->n = 0;
    } else if (g->timing == TIMING_FINISH) {
        bool any = false;
        for (int p = 0; p < PLAT_GLES_PASSES; p++) any |= g->acc_valid[p];
        if (any) {
            uint64_t seq = g->latest.seq + 1;
            memcpy(g->latest.ms, g->acc, sizeof g->acc);
            memcpy(g->latest.valid, g->acc_valid, sizeof g->acc_valid);
            g->latest.seq = seq;
        }
        memset(g->acc, 0, sizeof g->acc);
        memset(g->acc_valid, 0, sizeof g->acc_valid);
    }
}

bool plat_gles_times_latest(const plat_gles *g, plat_gles_times *t)
{
    *t = g->latest;
    return g->timing != TIMING_OFF && g->latest.seq > 0;
}

const char *plat_gles_timing_method(const plat_gles *g)
{
    return g->timing == TIMING_QUERY ? "timer queries (EXT_disjoint_timer_query)"
           : g->timing == TIMING_FINISH ? "glFinish bracketing"
                                        : "off";
}

bool plat_gles_gpu_pyramid(const plat_gles *g) { return g->gpu_pyramid; }

void plat_gles_count_samples(plat_gles *g, bool on) { g->count_samples = on; }

/* ---- create / destroy ---- */

plat_gles *plat_gles_create(plat_egl *egl, const plat_gles_params *p, char *err, int errlen)
{
    if (p->panel_w <= 0 || p->panel_h <= 0 || p->src_w <= 0 || p->src_h <= 0 || p->mesh_cols < 2 ||
        p->mesh_rows < 2) {
        warp_err(err, errlen, "GLES: bad sizes (panel %dx%d, source %dx%d, mesh %dx%d)", p->panel_w, p->panel_h,
                 p->src_w, p->src_h, p->mesh_cols, p->mesh_rows);
        return NULL;
    }
    GLint max_tex = 0;
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_tex);
    if (p->mesh_cols * 3 > max_tex || p->panel_w > max_tex || p->panel_h > max_tex || 2 * p->src_w > max_tex) {
        warp_err(err, errlen, "GLES: textures up to %d pixels on a side; the panel is %dx%d, the mesh %d wide", max_tex,
                 p->panel_w, p->panel_h, p->mesh_cols * 3);
        return NULL;
    }
    plat_gles *g = calloc(1, sizeof *g);
    if (!g) {
        warp_err(err, errlen, "GLES: out of memory");
        return NULL;
    }
    g->egl = egl;
    g->p = *p;
    g->active = -1;
    static const char *const lens_u[] = {"u_src", "u_mesh", "u_vp",       "u_flip_h",  "u_vp_h", "u_rows",
                                         "u_cell_w", "u_src_size", "u_vis", "u_has_vis", NULL};
    static const char *const pyr_u[] = {"u_in", "u_in_size", NULL};
    static const char *const rt_u[] = {"u_color", "u_depth", "u_pyr", "u_h", "u_a", "u_drange", "u_size",
                                       "u_max_steps", "u_refine", "u_fill_far", "u_levels", "u_jump", "u_lvl_off",
                                       "u_count", NULL};
    /* the traced lens pass: the lens pass's uniforms, the raytrace's but u_count, then its own */
    const char *traced_u[32];
    int nu = 0;
    for (int i = 0; lens_u[i]; i++) traced_u[nu++] = lens_u[i];
    for (int i = 0; rt_u[i] && i < R_COUNT; i++) traced_u[nu++] = rt_u[i];
    traced_u[nu++] = "u_cells";
    traced_u[nu++] = "u_eyepos";
    traced_u[nu++] = "u_h2";
    traced_u[nu++] = "u_a2";
    traced_u[nu++] = "u_roll";
    traced_u[nu++] = "u_panel";
    traced_u[nu] = NULL;
    if (!link(&g->lens, fs_lens, "lens", lens_u, err, errlen)) goto fail;
    glGenVertexArrays(1, &g->vao);
    if (!p->to_window) {
        g->panel = texture(GL_RGBA8, p->panel_w, p->panel_h, GL_NEAREST);
        if (!fbo_for(g->panel, &g->panel_fbo)) {
            warp_err(err, errlen, "GLES: the %dx%d RGBA8 panel framebuffer is incomplete", p->panel_w, p->panel_h);
            goto fail;
        }
    }
    g->gpu_pyramid = !p->cpu_pyramid && plat_egl_has_extension(egl, "GL_EXT_color_buffer_float");
    if (p->depth) {
        if (!link(&g->rt, fs_raytrace, "raytrace", rt_u, err, errlen) ||
            !link(&g->traced, fs_lens_traced, "traced lens", traced_u, err, errlen))
            goto fail;
        for (int e = 0; e < 2; e++)
            g->eye[e].eyepos_px = calloc(6 * (size_t)p->mesh_cols * (size_t)p->mesh_rows, sizeof(float));
        if (!g->eye[0].eyepos_px || !g->eye[1].eyepos_px) {
            warp_err(err, errlen, "GLES: out of memory");
            goto fail;
        }
        if (g->gpu_pyramid && (!link(&g->pyr0, fs_pyr0, "pyramid level 0", pyr_u, err, errlen) ||
                               !link(&g->pyrn, fs_pyrn, "pyramid reduction", pyr_u, err, errlen)))
            goto fail;
        g->levels = plat_gles_pyramid_levels(p->src_w, p->src_h);
        int y = 0;
        for (int l = 0; l < g->levels; l++) {
            plat_gles_pyramid_level_size(p->src_w, p->src_h, l, &g->lvl_w[l], &g->lvl_h[l]);
            /* level 0 at the origin, level 1 to its right, the rest stacked below level 1 */
            g->lvl_x[l] = l == 0 ? 0 : p->src_w;
            g->lvl_y[l] = l == 0 ? 0 : y;
            if (l > 0) y += g->lvl_h[l];
        }
        g->atlas_w = p->src_w + (g->levels > 1 ? g->lvl_w[1] : 0);
        g->atlas_h = y > p->src_h ? y : p->src_h;
        if (!g->gpu_pyramid) {
            g->cpu_scratch = malloc(sizeof(float) * (size_t)p->src_w * (size_t)p->src_h);
            g->cpu_level = malloc(sizeof(float) * (size_t)p->src_w * (size_t)p->src_h);
            if (!g->cpu_scratch || !g->cpu_level) {
                warp_err(err, errlen, "GLES: out of memory");
                goto fail;
            }
        }
    }
    for (int e = 0; e < 2; e++) {
        eye_res *r = &g->eye[e];
        r->color = texture(GL_RGBA8, p->src_w, p->src_h, GL_LINEAR);
        r->mesh = texture(GL_RG32F, p->mesh_cols * 3, p->mesh_rows, GL_NEAREST);
        r->vis = texture(GL_RG32I, p->panel_h, 1, GL_NEAREST);
        if (!p->depth) continue;
        r->depth = texture(GL_R32F, p->src_w, p->src_h, GL_NEAREST);
        r->inter = texture(GL_RGBA8, p->src_w, p->src_h, GL_LINEAR);
        if (!fbo_for(r->inter, &r->inter_fbo)) {
            warp_err(err, errlen, "GLES: the raytrace framebuffer is incomplete");
            goto fail;
        }
        r->atlas = texture(GL_R32F, g->atlas_w, g->atlas_h, GL_NEAREST);
        r->cells = texture(GL_R8UI, p->mesh_cols - 1, p->mesh_rows - 1, GL_NEAREST);
        r->eyepos = texture(GL_RG32F, p->mesh_cols * 3, p->mesh_rows, GL_NEAREST);
        if (g->gpu_pyramid) {
            if (!fbo_for(r->atlas, &r->atlas_fbo)) {
                warp_err(err, errlen, "GLES: R32F is not renderable here although EXT_color_buffer_float is offered");
                goto fail;
            }
            for (int l = 0; l < g->levels; l++) {
                r->lvl[l] = texture(GL_R32F, g->lvl_w[l], g->lvl_h[l], GL_NEAREST);
                if (!fbo_for(r->lvl[l], &r->lvl_fbo[l])) {
                    warp_err(err, errlen, "GLES: pyramid level %d framebuffer is incomplete", l);
                    goto fail;
                }
            }
        }
    }
    if (p->timing) {
        if (plat_egl_has_extension(egl, "GL_EXT_disjoint_timer_query")) {
            g->timing = TIMING_QUERY;
            g->get_u64 = (PFNGLGETQUERYOBJECTUI64VEXTPROC)eglGetProcAddress("glGetQueryObjectui64vEXT");
            for (int s = 0; s < QSLOTS; s++) glGenQueries(QPER, g->slots[s].q);
        } else {
            g->timing = TIMING_FINISH;
        }
    }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    GLenum ge = glGetError();
    if (ge != GL_NO_ERROR) {
        warp_err(err, errlen, "GLES: setting up the renderer failed (%s)", gl_err_str(ge));
        goto fail;
    }
    return g;
fail:
    plat_gles_destroy(g);
    return NULL;
}

void plat_gles_destroy(plat_gles *g)
{
    if (!g) return;
    GLuint progs[5] = {g->lens.prog, g->pyr0.prog, g->pyrn.prog, g->rt.prog, g->traced.prog};
    for (int i = 0; i < 5; i++)
        if (progs[i]) glDeleteProgram(progs[i]);
    if (g->vao) glDeleteVertexArrays(1, &g->vao);
    if (g->panel_fbo) glDeleteFramebuffers(1, &g->panel_fbo);
    if (g->panel) glDeleteTextures(1, &g->panel);
    for (int e = 0; e < 2; e++) {
        eye_res *r = &g->eye[e];
        GLuint tex[8] = {r->color, r->depth, r->mesh, r->inter, r->atlas, r->vis, r->cells, r->eyepos};
        GLuint fbo[2] = {r->inter_fbo, r->atlas_fbo};
        for (int i = 0; i < 8; i++)
            if (tex[i]) glDeleteTextures(1, &tex[i]);
        for (int i = 0; i < 2; i++)
            if (fbo[i]) glDeleteFramebuffers(1, &fbo[i]);
        for (int l = 0; l < PLAT_GLES_MAX_LEVELS; l++) {
            if (r->lvl_fbo[l]) glDeleteFramebuffers(1, &r->lvl_fbo[l]);
            if (r->lvl[l]) glDeleteTextures(1, &r->lvl[l]);
        }
    }
    if (g->timing == TIMING_QUERY)
        for (int s = 0; s < QSLOTS; s++) glDeleteQueries(QPER, g->slots[s].q);
    free(g->cpu_scratch);
    free(g->cpu_level);
    for (int e = 0; e < 2; e++) free(g->eye[e].eyepos_px);
    free(g);
}

/* ---- passes ---- */

static void bind_tex(int unit, GLuint tex)
{
    glActiveTexture(GL_TEXTURE0 + (GLenum)unit);
    glBindTexture(GL_TEXTURE_2D, tex);
}

static void build_pyramid(plat_gles *g, int eye, const warp_image_f32 *inv)
{
    eye_res *r = &g->eye[eye];
    if (!g->gpu_pyramid) {
        glBindTexture(GL_TEXTURE_2D, r->atlas);
        glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
        for (int l = 0; l < g->levels; l++) {
            warp_image_f32 out = {g->lvl_w[l], g->lvl_h[l], g->lvl_w[l], g->cpu_level};
            plat_gles_pyramid_cpu(inv, l, &out, g->cpu_scratch);
            glTexSubImage2D(GL_TEXTURE_2D, 0, g->lvl_x[l], g->lvl_y[l], g->lvl_w[l], g->lvl_h[l], GL_RED, GL_FLOAT,
                            g->cpu_level);
        }
        return;
    }
    glBindVertexArray(g->vao);
    for (int l = 0; l < g->levels; l++) {
        const program *pr = l == 0 ? &g->pyr0 : &g->pyrn;
        glUseProgram(pr->prog);
        bind_tex(0, l == 0 ? r->depth : r->lvl[l - 1]);
        glUniform1i(pr->loc[P_IN], 0);
        glUniform2i(pr->loc[P_INSIZE], l == 0 ? g->p.src_w : g->lvl_w[l - 1], l == 0 ? g->p.src_h : g->lvl_h[l - 1]);
        glBindFramebuffer(GL_FRAMEBUFFER, r->lvl_fbo[l]);
        glViewport(0, 0, g->lvl_w[l], g->lvl_h[l]);
        glDrawArrays(GL_TRIANGLES, 0, 3);
    }
    /* Into the atlas the raytrace reads (a shader cannot pick one of several samplers by a computed index). */
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, r->atlas_fbo);
    for (int l = 0; l < g->levels; l++) {
        glBindFramebuffer(GL_READ_FRAMEBUFFER, r->lvl_fbo[l]);
        glBlitFramebuffer(0, 0, g->lvl_w[l], g->lvl_h[l], g->lvl_x[l], g->lvl_y[l], g->lvl_x[l] + g->lvl_w[l],
                          g->lvl_y[l] + g->lvl_h[l], GL_COLOR_BUFFER_BIT, GL_NEAREST);
    }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

bool plat_gles_upload(plat_gles *g, int eye, const warp_image_rgba8 *color, const warp_image_f32 *inv_depth)
{
    if (eye < 0 || eye > 1 || color->w != g->p.src_w || color->h != g->p.src_h) return false;
    if (inv_depth && (!g->p.depth || inv_depth->w != g->p.src_w || inv_depth->h != g->p.src_h)) return false;
    eye_res *r = &g->eye[eye];
    pass_begin(g, PLAT_GLES_UPLOAD);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, color->stride);
    glBindTexture(GL_TEXTURE_2D, r->color);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, color->w, color->h, GL_RGBA, GL_UNSIGNED_BYTE, color->px);
    if (inv_depth) {
        glPixelStorei(GL_UNPACK_ROW_LENGTH, inv_depth->stride);
        glBindTexture(GL_TEXTURE_2D, r->depth);
        glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, inv_depth->w, inv_depth->h, GL_RED, GL_FLOAT, inv_depth->px);
    }
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    pass_end(g);
    if (inv_depth) {
        pass_begin(g, PLAT_GLES_PYRAMID);
        build_pyramid(g, eye, inv_depth);
        pass_end(g);
    }
    return glGetError() == GL_NO_ERROR;
}

/* The part of a raytrace setup that depends on the target pose: u_h and u_a (or a rolling panel's u_h2, u_a2). */
static void pose_uniforms(GLint loc_h, GLint loc_a, const warp_raytrace_setup *s)
{
    /* GLSL matrices are column-major: column c holds h.m[0..2][c]. */
    GLfloat h[9];
    for (int c = 0; c < 3; c++)
        for (int rr = 0; rr < 3; rr++) h[c * 3 + rr] = (GLfloat)s->h.m[rr][c];
    glUniformMatrix3fv(loc_h, 1, GL_FALSE, h);
    glUniform3f(loc_a, (GLfloat)s->ax, (GLfloat)s->ay, (GLfloat)s->aw);
}

/* The raytrace's uniforms of program pr from loc[at + R_*]: the frame's textures on units unit (colour), unit + 1
 * (inverse depth) and unit + 2 (the pyramid's atlas), bound here, and setup s. */
static void raytrace_uniforms(plat_gles *g, eye_res *r, const program *pr, int at, int unit,
                              const warp_raytrace_setup *s)
{
    const GLint *loc = pr->loc + at;
    bind_tex(unit, r->color);
    bind_tex(unit + 1, r->depth);
    bind_tex(unit + 2, r->atlas);
    glUniform1i(loc[R_COLOR], unit);
    glUniform1i(loc[R_DEPTH], unit + 1);
    glUniform1i(loc[R_PYR], unit + 2);
    pose_uniforms(loc[R_H], loc[R_A], s);
    glUniform2f(loc[R_DRANGE], s->src->inv_depth_min, s->src->inv_depth_max);
    glUniform2i(loc[R_SIZE], g->p.src_w, g->p.src_h);
    glUniform1i(loc[R_STEPS], s->p.max_steps);
    glUniform1i(loc[R_REFINE], s->p.refine_iters);
    glUniform1i(loc[R_FILL], s->p.edge_fill == WARP_EDGE_FILL_FAR);
    glUniform1i(loc[R_LEVELS], g->levels);
    glUniform1f(loc[R_JUMP], s->p.edge_jump);
    GLint off[2 * PLAT_GLES_MAX_LEVELS] = {0};
    for (int l = 0; l < g->levels; l++) {
        off[2 * l] = g->lvl_x[l];
        off[2 * l + 1] = g->lvl_y[l];
    }
    glUniform2iv(loc[R_OFF], PLAT_GLES_MAX_LEVELS, off);
}

void plat_gles_raytrace(plat_gles *g, int eye, const warp_raytrace_setup *s)
{
    if (!g->p.depth || eye < 0 || eye > 1) return;
    eye_res *r = &g->eye[eye];
    const program *pr = &g->rt;
    pass_begin(g, PLAT_GLES_RAYTRACE);
    glUseProgram(pr->prog);
    glBindVertexArray(g->vao);
    raytrace_uniforms(g, r, pr, 0, 0, s);
    glUniform1i(pr->loc[R_COUNT], g->count_samples);
    glBindFramebuffer(GL_FRAMEBUFFER, r->inter_fbo);
    glViewport(0, 0, s->dst_w < g->p.src_w ? s->dst_w : g->p.src_w, s->dst_h < g->p.src_h ? s->dst_h : g->p.src_h);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    pass_end(g);
}

/* The lens pass's mesh and uniforms of program pr (loc[L_*]), its source texture on unit 0, the mesh on 1 and the
 * hidden-area mask on 2; then the viewport bound. */
static void lens_setup(plat_gles *g, eye_res *r, const program *pr, const warp_mesh *m, GLuint src)
{
    glBindTexture(GL_TEXTURE_2D, r->mesh);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, m->cols * 3, m->rows, GL_RG, GL_FLOAT, m->src);
    glUseProgram(pr->prog);
    glBindVertexArray(g->vao);
    bind_tex(0, src);
    bind_tex(1, r->mesh);
    glUniform1i(pr->loc[L_SRC], 0);
    glUniform1i(pr->loc[L_MESH], 1);
    /* Window rows: the FBO keeps panel row y at GL row y (glReadPixels then returns the panel top row first); a
     * KMS framebuffer scans out GL's top row first, so there the panel is drawn upside down in GL terms. */
    int win_y = g->p.to_window ? g->p.panel_h - (m->vp_y + m->vp_h) : m->vp_y;
    glUniform2i(pr->loc[L_VP], m->vp_x, m->vp_y);
    glUniform1i(pr->loc[L_FLIP], g->p.to_window ? g->p.panel_h : 0);
    glUniform1i(pr->loc[L_VPH], m->vp_h);
    glUniform1i(pr->loc[L_ROWS], m->rows);
    glUniform1i(pr->loc[L_CELLW], m->cell_w);
    glUniform2f(pr->loc[L_SRCSIZE], (GLfloat)g->p.src_w, (GLfloat)g->p.src_h);
    /* the mask is fixed per lens: uploaded once (the mesh's rows are at most the panel's, the texture's width) */
    const bool vis = m->visible && m->vp_h <= g->p.panel_h;
    bind_tex(2, r->vis);
    if (vis && r->vis_from != m->visible) {
        glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, m->vp_h, 1, GL_RG_INTEGER, GL_INT, m->visible);
        r->vis_from = m->visible;
    }
    glUniform1i(pr->loc[L_VIS], 2);
    glUniform1i(pr->loc[L_HASVIS], vis);
    glBindFramebuffer(GL_FRAMEBUFFER, g->p.to_window ? 0 : g->panel_fbo);
    glViewport(m->vp_x, win_y, m->vp_w, m->vp_h);
}

void plat_gles_lens(plat_gles *g, int eye, const warp_mesh *m, bool from_raytrace)
{
    if (eye < 0 || eye > 1 || m->cols != g->p.mesh_cols || m->rows != g->p.mesh_rows) return;
    if (from_raytrace && !g->p.depth) return;
    eye_res *r = &g->eye[eye];
    pass_begin(g, PLAT_GLES_LENS);
    lens_setup(g, r, &g->lens, m, from_raytrace ? r->inter : r->color);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    pass_end(g);
}

void plat_gles_lens_traced(plat_gles *g, int eye, const warp_mesh *m, const warp_mesh_trace *t,
                           const warp_camera *cam, const warp_raytrace_setup *s, const warp_raytrace_setup *last,
                           const warp_scan *scan)
{
    if (!g->p.depth || eye < 0 || eye > 1 || m->cols != g->p.mesh_cols || m->rows != g->p.mesh_rows ||
        t->cells_x != m->cols - 1 || t->cells_y != m->rows - 1)
        return;
    eye_res *r = &g->eye[eye];
    const program *pr = &g->traced;
    pass_begin(g, PLAT_GLES_LENS);
    /* where each vertex's lens directions meet the eye buffer (tan_to_pixel is affine, so interpolating these is
     * interpolating the directions: the positions warp_mesh_trace traces from); they change only with the lens or
     * the frame's camera, so the texture is re-sent only then (compared as computed: no key to go stale) */
    const size_t nv = (size_t)m->cols * (size_t)m->rows * 3;
    bool changed = !r->eyepos_sent;
    for (size_t v = 0; v < nv; v++) {
        double x, y;
        warp_camera_tan_to_pixel(cam, m->tan[v].x, m->tan[v].y, &x, &y);
        const float fx = (float)x, fy = (float)y;
        changed |= fx != r->eyepos_px[2 * v] || fy != r->eyepos_px[2 * v + 1];
        r->eyepos_px[2 * v] = fx;
        r->eyepos_px[2 * v + 1] = fy;
    }
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glBindTexture(GL_TEXTURE_2D, r->cells);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, t->cells_x, t->cells_y, GL_RED_INTEGER, GL_UNSIGNED_BYTE, t->cell);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    if (changed) {
        glBindTexture(GL_TEXTURE_2D, r->eyepos);
        glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, m->cols * 3, m->rows, GL_RG, GL_FLOAT, r->eyepos_px);
        r->eyepos_sent = true;
    }
    lens_setup(g, r, pr, m, r->color);
    raytrace_uniforms(g, r, pr, T_RT, 3, s); /* after the lens pass's units 0-2 */
    bind_tex(6, r->cells);
    bind_tex(7, r->eyepos);
    glUniform1i(pr->loc[T_CELLS], 6);
    glUniform1i(pr->loc[T_EYEPOS], 7);
    const bool rolling = last && scan && scan->rolling;
    glUniform1i(pr->loc[T_ROLL], rolling ? 1 + (int)scan->dir : 0);
    if (rolling) {
        pose_uniforms(pr->loc[T_H2], pr->loc[T_A2], last);
        glUniform2i(pr->loc[T_PANEL], scan->panel_w, scan->panel_h);
    }
    glDrawArrays(GL_TRIANGLES, 0, 3);
    pass_end(g);
}

void plat_gles_clear(plat_gles *g)
{
    glBindFramebuffer(GL_FRAMEBUFFER, g->p.to_window ? 0 : g->panel_fbo);
    glViewport(0, 0, g->p.panel_w, g->p.panel_h);
    glClearColor(0, 0, 0, 1);
    glClear(GL_COLOR_BUFFER_BIT);
}

bool plat_gles_read(plat_gles *g, warp_image_rgba8 *dst, char *err, int errlen)
{
    if (g->p.to_window) return warp_err(err, errlen, "GLES: the panel is on a window surface, nothing to read back");
    if (dst->w != g->p.panel_w || dst->h != g->p.panel_h)
        return warp_err(err, errlen, "GLES: readback into %dx%d, panel is %dx%d", dst->w, dst->h, g->p.panel_w,
                        g->p.panel_h);
    pass_begin(g, PLAT_GLES_READBACK);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, g->panel_fbo);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glPixelStorei(GL_PACK_ROW_LENGTH, dst->stride);
    glReadPixels(0, 0, dst->w, dst->h, GL_RGBA, GL_UNSIGNED_BYTE, dst->px);
    glPixelStorei(GL_PACK_ROW_LENGTH, 0);
    pass_end(g);
    GLenum e = glGetError();
    if (e != GL_NO_ERROR) return warp_err(err, errlen, "GLES: rendering or readback failed (%s)", gl_err_str(e));
    return true;
}

bool plat_gles_read_raytrace(plat_gles *g, int eye, warp_image_rgba8 *rgb, warp_image_u8 *mask)
{
    if (!g->p.depth || eye < 0 || eye > 1) return false;
    int w = g->p.src_w, h = g->p.src_h;
    warp_rgba8 *buf = malloc(sizeof *buf * (size_t)w * (size_t)h);
    if (!buf) return false;
    glBindFramebuffer(GL_READ_FRAMEBUFFER, g->eye[eye].inter_fbo);
    glPixelStorei(GL_PACK_ROW_LENGTH, 0);
    glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, buf);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            warp_rgba8 v = buf[(size_t)y * w + x];
            if (rgb) WARP_AT(rgb, x, y) = (warp_rgba8){v.r, v.g, v.b, 255};
            if (mask) WARP_AT(mask, x, y) = v.a;
        }
    free(buf);
    return glGetError() == GL_NO_ERROR;
}

bool plat_gles_read_pyramid(plat_gles *g, int eye, int level, warp_image_f32 *dst)
{
    if (!g->p.depth || eye < 0 || eye > 1 || level < 0 || level >= g->levels) return false;
    if (!g->gpu_pyramid) {
        /* the atlas is not renderable without EXT_color_buffer_float; the CPU built it anyway */
        return false;
    }
    int w = g->lvl_w[level], h = g->lvl_h[level];
    /* RGBA + FLOAT is the read format every float colour buffer supports (GLES 3.0 §4.3.2) */
    float *buf = malloc(sizeof(float) * 4 * (size_t)w * (size_t)h);
    if (!buf) return false;
    glBindFramebuffer(GL_READ_FRAMEBUFFER, g->eye[eye].atlas_fbo);
    glPixelStorei(GL_PACK_ROW_LENGTH, 0);
    glReadPixels(g->lvl_x[level], g->lvl_y[level], w, h, GL_RGBA, GL_FLOAT, buf);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) WARP_AT(dst, x, y) = buf[((size_t)y * w + x) * 4];
    free(buf);
    return glGetError() == GL_NO_ERROR;
}

/* plat_gles_bench and plat_gles_bench_traced: the lens pass traced (t not NULL) or after the raytrace (rt not NULL)
 * or through the rotation mesh. */
static bool bench_run(plat_gles *g, const warp_image_rgba8 *const color[2], const warp_image_f32 *const inv[2],
                      const warp_raytrace_setup *const rt[2], const warp_mesh *const mesh[2],
                      const warp_mesh_trace *const t[2], const warp_camera *const cam[2], int reps,
                      plat_gles_times *mean)
{
    memset(mean, 0, sizeof *mean);
    if (g->timing == TIMING_OFF || reps < 1 || g->p.to_window) return false;
    if (t && !(rt && inv && g->p.depth)) return false;
    warp_image_rgba8 out;
    if (!warp_image_rgba8_alloc(&out, g->p.panel_w, g->p.panel_h)) return false;
    char err[200];
    bool ok = true;
    int counted[PLAT_GLES_PASSES] = {0};
    uint64_t seq = g->latest.seq;
    /* two vsyncs more than asked: the first is warm-up (shader compilation, first touches) and results arrive a
     * vsync late, so vsyncs 1..reps are the ones counted */
    for (int r = 0; r <= reps + 1 && ok; r++) {
        for (int e = 0; e < 2 && ok; e++) ok = plat_gles_upload(g, e, color[e], g->p.depth && inv ? inv[e] : NULL);
        for (int e = 0; e < 2; e++) {
            if (t) {
                plat_gles_lens_traced(g, e, mesh[e], t[e], cam[e], rt[e], NULL, NULL);
                continue;
            }
            bool traced = rt && g->p.depth && inv;
            if (traced) plat_gles_raytrace(g, e, rt[e]);
            plat_gles_lens(g, e, mesh[e], traced);
        }
        ok = ok && plat_gles_read(g, &out, err, sizeof err);
        plat_gles_end_frame(g);
        /* the readback waited for the GPU: the previous vsync's queries are in */
        if (r >= 2 && g->latest.seq != seq) {
            seq = g->latest.seq;
            for (int p = 0; p < PLAT_GLES_PASSES; p++)
                if (g->latest.valid[p]) {
                    mean->ms[p] += g->latest.ms[p];
                    counted[p]++;
                }
        }
    }
    for (int p = 0; p < PLAT_GLES_PASSES; p++)
        if (counted[p]) {
            mean->ms[p] /= counted[p];
            mean->valid[p] = true;
        }
    mean->seq = seq;
    warp_image_free(&out);
    return ok;
}

bool plat_gles_bench(plat_gles *g, const warp_image_rgba8 *const color[2], const warp_image_f32 *const inv[2],
                     const warp_raytrace_setup *const rt[2], const warp_mesh *const mesh[2], int reps,
                     plat_gles_times *mean)
{
    return bench_run(g, color, inv, rt, mesh, NULL, NULL, reps, mean);
}

bool plat_gles_bench_traced(plat_gles *g, const warp_image_rgba8 *const color[2], const warp_image_f32 *const inv[2],
                            const warp_raytrace_setup *const rt[2], const warp_mesh *const mesh[2],
                            const warp_mesh_trace *const t[2], const warp_camera *const cam[2], int reps,
                            plat_gles_times *mean)
{
    return t && cam ? bench_run(g, color, inv, rt, mesh, t, cam, reps, mean) : false;
}
