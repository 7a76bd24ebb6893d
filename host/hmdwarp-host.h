/* SPDX-License-Identifier: MIT */
/* libhmdwarp-host: the host side of the hmdwarp frame link as a small C API: connect to a board (USB, Unix socket,
 * file), receive its pose and camera messages, submit rendered frames (converted and checked here), read stats. */
#ifndef HMDWARP_HOST_H
#define HMDWARP_HOST_H

/* The whole installed interface: plain C types only (no hmdwarp internals), every symbol prefixed hmdwarp_host_.
 *
 * Conventions
 *  - Calls that can fail return an int: 0 (HMDWARP_HOST_OK) or a positive "yes" where documented, or a negative
 *    hmdwarp_host_error. hmdwarp_host_open*() return NULL on failure.
 *  - After any failure hmdwarp_host_last_error() holds a message for the calling thread naming what was wrong,
 *    e.g. "frame.eye[1].depth: NaN at pixel (12, 40)" or "frame.eye[0].color_stride: 100 < width * 4 (128)".
 *  - Times: "board clock" values come from the board's messages and are only echoed back; "host clock" values are
 *    CLOCK_MONOTONIC nanoseconds (hmdwarp_host_now_ns()).
 *  - Poses are world_from_local: orientation a unit quaternion (w, x, y, z), position in metres; +Y up, the eye
 *    looks down -Z.
 *  - Threading: a handle runs one internal reader thread (USB and socket) that receives the board's messages.
 *    hmdwarp_host_submit(), _encode() and _send_raw() may be called from one thread while _wait_pose(), _poll_pose(),
 *    _get_cameras(), _wait_cameras() and _get_stats() run on others; concurrent submits on one handle are serialised
 *    (safe, but pointless). hmdwarp_host_close() must not race any other call on the same handle. Calls on different
 *    handles are independent. hmdwarp_host_last_error() is per thread.
 *  - The vsync-paced side is the board's: nothing here is real-time, but submit does no allocation after the first
 *    frame of a given size and layout. */

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Bumped (with the soname, libhmdwarp-host.so.N) on any incompatible change; additions keep it. */
#define HMDWARP_HOST_ABI_VERSION 0

/* Errors (negative). */
typedef enum {
    HMDWARP_HOST_OK = 0,
    HMDWARP_HOST_ERR_ARG = -1,           /* a NULL or out-of-range argument or field (named in the message) */
    HMDWARP_HOST_ERR_SIZE = -2,          /* an image size or stride that does not match the cameras, or a frame over
                                          * the board's max_frame_bytes */
    HMDWARP_HOST_ERR_NOT_FINITE = -3,    /* NaN or infinity where a finite value is needed (poses, depth, motion) */
    HMDWARP_HOST_ERR_FORMAT = -4,        /* an unknown format, a plane the board does not accept, or a depth value
                                          * outside its encoding's range */
    HMDWARP_HOST_ERR_NO_CAMERAS = -5,    /* no camera for the frame: the board sent none and the frame gives none */
    HMDWARP_HOST_ERR_NOT_CONNECTED = -6, /* the board is gone and not back yet (the reader thread keeps trying) */
    HMDWARP_HOST_ERR_DISCONNECTED = -7,  /* the board went away during this call (a frame cut short is dropped by
                                          * the board), or since the pose message frame.pose_seq names; the next
                                          * call reconnects or reports NOT_CONNECTED */
    HMDWARP_HOST_ERR_IO = -8,            /* opening or writing the transport failed otherwise (errno/libusb text) */
    HMDWARP_HOST_ERR_NO_MEMORY = -9,
    HMDWARP_HOST_ERR_UNSUPPORTED = -10,  /* not possible on this transport (e.g. waiting for poses from a file) */
} hmdwarp_host_error;

/* The library's ABI version (HMDWARP_HOST_ABI_VERSION it was built with) and hmdwarp's version string ("0.1.0"). */
unsigned hmdwarp_host_abi_version(void);
const char *hmdwarp_host_version(void);
/* The message of the calling thread's last failure ("" when none); valid until that thread's next call. */
const char *hmdwarp_host_last_error(void);
/* A constant name for an error code ("not connected"). */
const char *hmdwarp_host_error_str(int err);
/* The host clock (CLOCK_MONOTONIC, ns): what render timestamps are measured with. */
int64_t hmdwarp_host_now_ns(void);

/* ---- connection ---- */

typedef struct hmdwarp_host hmdwarp_host; /* opaque */

typedef enum {
    HMDWARP_HOST_TRANSPORT_USB = 1,    /* the board's USB gadget (libusb, bulk OUT frames, bulk IN messages) */
    HMDWARP_HOST_TRANSPORT_SOCKET = 2, /* a Unix-domain SOCK_STREAM socket hmdwarpd listens on ([frames] backend =
                                        * socket): the same byte streams as USB */
    HMDWARP_HOST_TRANSPORT_FILE = 3,   /* write the frame stream to a file ("-": standard output); no messages */
} hmdwarp_host_transport;

typedef struct {
    hmdwarp_host_transport transport;
    const char *path;      /* SOCKET: the socket path; FILE: the file ("-" = stdout, truncated/created) */
    uint16_t vid, pid;     /* USB: the board's ids (0: 1d6b:0104, what board/gadget.sh registers) */
    int interface;         /* USB: the hmdwarp function's interface number (0) */
    double wait_s;         /* USB/SOCKET: keep retrying the first connection this long (0: one try) */
} hmdwarp_host_options;

/* Opens a connection from a string:
 *   "usb" or "usb:VID:PID" (hex), "socket:PATH", "file:PATH", "-" (standard output), or a plain PATH (file).
 * USB and socket wait up to 5 s for the board to appear. NULL on failure (last_error says why: "no USB device
 * 1d6b:0104 after 5 s", "socket:/run/x.sock: connect: No such file or directory", "unknown transport 'tcp'"). */
hmdwarp_host *hmdwarp_host_open(const char *uri);
hmdwarp_host *hmdwarp_host_open_ex(const hmdwarp_host_options *opts);
/* Stops the reader thread, releases the device or closes the socket or file, frees h (NULL is a no-op). */
void hmdwarp_host_close(hmdwarp_host *h);
/* 1 while connected to a board (FILE: while the file is writable), 0 otherwise. */
int hmdwarp_host_connected(hmdwarp_host *h);

/* ---- board -> host: pose messages ---- */

typedef struct {
    double orientation[4]; /* w, x, y, z: unit quaternion */
    double position[3];    /* metres */
} hmdwarp_host_pose;

typedef struct {
    uint32_t seq;              /* the board's counter: echo it in hmdwarp_host_frame.pose_seq */
    int64_t board_time_ns;     /* board clock: when the board sent it */
    int64_t target_time_ns;    /* board clock: the display time the pose is predicted for */
    int64_t received_ns;       /* host clock: when it arrived */
    hmdwarp_host_pose head;    /* predicted world_from_head */
    hmdwarp_host_pose eye[2];  /* world_from_eye, left and right: render each eye at these */
} hmdwarp_host_pose_msg;

/* Waits up to timeout_ms (< 0: forever) for a pose message newer than the last one this handle returned and
 * stores it in *out. Returns 1 (stored), 0 (timeout), NOT_CONNECTED (the wait ended with the board away: it is
 * waited for meanwhile, as the library reconnects, so a retry loop does not spin), UNSUPPORTED (FILE transport)
 * or ARG. Any thread; with several waiters each new pose goes to one of them. */
int hmdwarp_host_wait_pose(hmdwarp_host *h, int timeout_ms, hmdwarp_host_pose_msg *out);
/* The same without waiting: 1 and *out when a newer pose is there, else 0 (or an error as above). */
int hmdwarp_host_poll_pose(hmdwarp_host *h, hmdwarp_host_pose_msg *out);

/* ---- board -> host: what the board wants rendered (the camera message) ---- */

/* Planes a frame can carry (bit mask). */
enum {
    HMDWARP_HOST_PLANE_COLOR = 1u << 0,
    HMDWARP_HOST_PLANE_DEPTH = 1u << 1,
    HMDWARP_HOST_PLANE_IDS = 1u << 2,
    HMDWARP_HOST_PLANE_MOTION = 1u << 3,
    HMDWARP_HOST_PLANE_LAYERS = 1u << 4,
};

/* Depth encodings as the board names them (its preference in the camera message). */
typedef enum {
    HMDWARP_HOST_ENCODING_LINEAR = 0,   /* planar view depth in metres */
    HMDWARP_HOST_ENCODING_STANDARD = 1, /* window depth, 0 at near, 1 at far */
    HMDWARP_HOST_ENCODING_REVERSED = 2, /* window depth, 1 at near, 0 at far (reversed-Z) */
} hmdwarp_host_depth_encoding;

/* A pinhole eye camera: the image covers tangents u in [-tan_left, tan_right], v in [-tan_down, tan_up]; pixel
 * (i, j) has its centre at (i + 0.5, j + 0.5), rows top to bottom. far_z may be INFINITY. */
typedef struct {
    uint32_t width, height;
    double tan_left, tan_right, tan_up, tan_down;
    double near_z, far_z;
} hmdwarp_host_camera;

typedef struct {
    uint32_t seq;
    unsigned planes;                /* HMDWARP_HOST_PLANE_* the board accepts (COLOR always) */
    hmdwarp_host_depth_encoding depth_encoding; /* the board's preference; any is accepted */
    uint64_t max_frame_bytes;       /* larger frames are refused (ERR_SIZE here, before sending) */
    double refresh_hz;              /* the panel's refresh */
    double pose_rate_hz;            /* pose messages per second */
    hmdwarp_host_camera cam[2];     /* render each eye with these (size, FOV, near/far) */
} hmdwarp_host_cameras;

/* The latest camera message: 1 and *out when one has arrived (or was set), 0 when none yet. Any thread. */
int hmdwarp_host_get_cameras(hmdwarp_host *h, hmdwarp_host_cameras *out);
/* Waits up to timeout_ms (< 0: forever) until a camera message has arrived: 1 and *out, 0 on timeout (at once
 * on a FILE transport without set_cameras), NOT_CONNECTED (the wait ended with the board away) or ARG. The board
 * sends one when a host connects and then once a second. */
int hmdwarp_host_wait_cameras(hmdwarp_host *h, int timeout_ms, hmdwarp_host_cameras *out);
/* Sets the cameras as if the board had sent them (a FILE transport, or a board that predates the camera message);
 * a later message from the board replaces them. ARG when a camera is unusable (named). */
int hmdwarp_host_set_cameras(hmdwarp_host *h, const hmdwarp_host_cameras *cams);

/* ---- board -> host: the hidden-area mask (the visibility mask message) ---- */

#define HMDWARP_HOST_MASK_MAX 64 /* vertices per eye at most */

/* The eye's (0 left, 1 right) visibility mask from the board: a counter-clockwise line loop of n vertices in the eye
 * camera's tangent space, vertex k at u = uv[2k], v = uv[2k + 1] (u = X/-Z right, v = Y/-Z up), as OpenXR's
 * XR_KHR_visibility_mask line loop. Outside it the board shows black (beyond the lens's visible disc, guard band
 * included), so a renderer may skip shading there (stencil it out, or clear those pixels). Copies min(n, max)
 * vertices into uv (2 * max floats) and returns n: 0 when the board sent no mask for this eye (every pixel is shown)
 * or none since its latest camera message (it follows each camera message). ARG: a bad eye, or uv NULL with max > 0.
 * Any thread. */
int hmdwarp_host_get_visibility_mask(hmdwarp_host *h, int eye, float *uv, int max);

/* ---- host -> board: frames ---- */

typedef enum {
    HMDWARP_HOST_COLOR_RGBA8 = 1, /* r, g, b, a bytes, straight alpha */
    HMDWARP_HOST_COLOR_BGRA8 = 2, /* b, g, r, a bytes */
    HMDWARP_HOST_COLOR_RGB8 = 3,  /* r, g, b bytes (sent opaque) */
    HMDWARP_HOST_COLOR_RGBX8 = 4, /* r, g, b, unused bytes (sent opaque) */
} hmdwarp_host_color_format;

typedef enum {
    HMDWARP_HOST_DEPTH_NONE = 0,
    HMDWARP_HOST_DEPTH_LINEAR_F32 = 1,        /* float metres along -Z (planar); +INFINITY = sky */
    HMDWARP_HOST_DEPTH_RAY_F32 = 2,           /* float metres along each pixel's ray (converted to planar) */
    HMDWARP_HOST_DEPTH_STANDARD_F32 = 3,      /* float window depth in [0, 1], 0 at near */
    HMDWARP_HOST_DEPTH_REVERSED_F32 = 4,      /* float window depth in [0, 1], 1 at near */
    HMDWARP_HOST_DEPTH_STANDARD_UNORM16 = 5,  /* uint16 window depth d * 65535 (a 16-bit depth buffer) */
    HMDWARP_HOST_DEPTH_REVERSED_UNORM16 = 6,
} hmdwarp_host_depth_format;

/* One transparent fragment (the layers plane): linear planar depth z (metres), straight-alpha colour, object id. */
typedef struct {
    float z;
    uint8_t rgba[4];
    uint16_t id;
} hmdwarp_host_fragment;

/* One eye's pixels. Strides are bytes between rows; 0 means tightly packed. Optional planes are NULL when absent;
 * a plane must be given for both eyes or neither. Only read during the call. */
typedef struct {
    const void *color;        /* required; frame.color_format */
    size_t color_stride;
    const void *depth;        /* frame.depth_format: float or uint16 per pixel */
    size_t depth_stride;
    const uint16_t *ids;      /* object id per pixel (0 = none; 1..n_objects) */
    size_t ids_stride;
    const float *motion;      /* screen-space motion per pixel: x, y floats, pixels per second */
    size_t motion_stride;
    /* Transparency layers: per pixel a fragment count (layer_count, uint8, rows layer_count_stride apart), and all
     * fragments back to back in pixel order (rows top to bottom), each pixel's nearest first: n_fragments in all
     * (the sum of the counts). */
    const uint8_t *layer_count;
    size_t layer_count_stride;
    const hmdwarp_host_fragment *fragments;
    size_t n_fragments;
    hmdwarp_host_pose pose;   /* the eye pose rendered with, when frame.pose_seq is 0 */
    hmdwarp_host_camera camera; /* width 0: the board's camera for this eye (camera message) */
} hmdwarp_host_eye;

typedef struct {
    hmdwarp_host_color_format color_format;
    hmdwarp_host_depth_format depth_format;
    /* Window-depth formats: the near/far planes of the projection that wrote the depth (far may be INFINITY);
     * 0 and 0: the eye camera's. */
    double depth_near, depth_far;
    hmdwarp_host_eye eye[2];
    /* The pose rendered for: the seq of a pose message this handle received (the library echoes its eye poses
     * unless eye[].pose is set (non-zero orientation), its target and board times), or 0: eye[].pose and the
     * times below. */
    uint32_t pose_seq;
    int64_t pose_target_ns;   /* pose_seq 0: board clock target time rendered for (0 unknown) */
    int64_t pose_board_ns;    /* pose_seq 0: board_time_ns of the pose message used (0 unknown) */
    int64_t pose_received_ns; /* pose_seq 0: host clock when it arrived (0 unknown) */
    int64_t render_start_ns;  /* host clock: when rendering began (0 unknown) */
    int64_t render_end_ns;    /* host clock: when it ended (0: now) */
    unsigned n_objects;       /* object poses (ids 1..n), at most 64 */
    const hmdwarp_host_pose *object_poses;
    double scene_time;        /* simulated scenes only; 0 */
    int depth_unorm16;        /* 1: send window depth as 16 bits on the wire (half the bytes, 1/65535 steps) */
} hmdwarp_host_frame;

/* Checks, converts and sends one frame (one framelink frame, docs/framelink.md). Returns 0, or: ARG (a NULL
 * pointer, a plane given for one eye only, pose_seq not among the last 1024 pose messages), SIZE (stride smaller
 * than a row, camera size different from the board's, too many fragments, frame over max_frame_bytes),
 * NOT_FINITE (a pose, depth, motion or fragment value), FORMAT (a format value, a plane the board's camera message
 * does not accept, window depth outside [0, 1] or a negative linear depth), NO_CAMERAS, NOT_CONNECTED,
 * DISCONNECTED, IO, NO_MEMORY. Nothing is sent when the frame is refused. Blocks until the transport took all the
 * bytes. Pixel data is read only during the call. */
int hmdwarp_host_submit(hmdwarp_host *h, const hmdwarp_host_frame *frame);
/* The same checks and conversions, into buf instead of the transport: returns the frame's size in bytes (> 0;
 * nothing written when it exceeds cap, so call with cap 0 to size buf) or an error. For tools and captures. With a
 * codec (hmdwarp_host_set_codec) a call that only sized buf keeps the frame it compressed, and the next encode of
 * the same frame pointer returns it without compressing again (a video stream advances once). */
int64_t hmdwarp_host_encode(hmdwarp_host *h, const hmdwarp_host_frame *frame, void *buf, size_t cap);
/* Sends bytes as they are (an encoded frame, possibly damaged on purpose for fault tests); counted as a frame. */
int hmdwarp_host_send_raw(hmdwarp_host *h, const void *buf, size_t len);

/* ---- statistics ---- */

typedef struct {
    uint64_t frames_sent;      /* submits and raw sends that completed */
    uint64_t bytes_sent;
    double mb_per_s;           /* frame bytes sent per second of wall time over the last second or so (1e6 B) */
    double send_ms_last;       /* how long the last frame took to hand to the transport */
    double send_ms_mean;       /* mean over all frames */
    uint64_t poses_received;
    uint64_t cameras_received;
    uint64_t messages_rejected; /* board messages that did not decode (CRC, size, unknown magic) */
    uint64_t frames_refused;   /* submits refused by the checks (nothing sent) */
    uint64_t send_errors;      /* submits that failed on the transport */
    uint64_t disconnects;      /* times the board went away */
    uint64_t reconnects;       /* times it came back */
    int connected;
} hmdwarp_host_stats;

/* Any thread. ARG when h or out is NULL. */
int hmdwarp_host_get_stats(hmdwarp_host *h, hmdwarp_host_stats *out);

/* ---- compression (framelink v2, docs/framelink.md) ---- */

/* A plane's codec; the numbers are the wire's. AUTO: chosen from what the board announces in its camera message. */
typedef enum {
    HMDWARP_HOST_CODEC_AUTO = -1,
    HMDWARP_HOST_CODEC_RAW = 0,  /* the plane as version 1 sends it */
    HMDWARP_HOST_CODEC_ZSTD = 1, /* lossless (zstd): depth, ids, motion, layers */
    HMDWARP_HOST_CODEC_JPEG = 2, /* colour: JPEG per horizontal slice of each eye */
    HMDWARP_HOST_CODEC_H264 = 3, /* colour: one low-delay H.264 stream per eye */
    HMDWARP_HOST_CODEC_HEVC = 4, /* colour: one low-delay HEVC stream per eye */
} hmdwarp_host_codec;

/* How depth goes on the wire. */
typedef enum {
    HMDWARP_HOST_WIRE_DEPTH_AUTO = 0,    /* with zstd: INV16 for linear depth, UNORM16 for window depth; else as sent */
    HMDWARP_HOST_WIRE_DEPTH_F32 = 1,     /* float32 in the frame's encoding */
    HMDWARP_HOST_WIRE_DEPTH_UNORM16 = 2, /* window depth * 65535 (standard and reversed window depth only) */
    HMDWARP_HOST_WIRE_DEPTH_INV16 = 3,   /* linear depth as 65535 * near / z: precision where parallax is */
} hmdwarp_host_wire_depth;

/* The codec per plane. Zero fields take the defaults noted; hmdwarp_host_codec_defaults() sets everything to auto,
 * which means: colour JPEG (quality 75, 4:2:0, 4 slices per eye) when the board decodes JPEG, depth zstd (wire
 * format auto, full resolution) and ids, motion and layers zstd when it decodes zstd, raw otherwise. */
typedef struct {
    int color;           /* hmdwarp_host_codec: AUTO, RAW, JPEG, H264 or HEVC */
    int quality;         /* JPEG 1..100 (0: 75); video: quantiser 1..51 when video_kbps is 0 (0: 23) */
    int jpeg_subsampling; /* 420 or 444 (0: 420) */
    int slices;          /* JPEG slices per eye 1..16 (0: 4), each decoded on its own thread */
    int video_kbps;      /* video: constant bit rate per eye stream in kbit/s; 0: constant quality */
    int refresh_frames;  /* video: intra refresh period in frames; 0: key frames only when the board asks */
    int depth;           /* AUTO, RAW or ZSTD */
    int depth_format;    /* hmdwarp_host_wire_depth */
    int depth_scale;     /* depth at 1/2^scale resolution per axis: 0, 1 or 2 (the board upsamples along edges) */
    int other;           /* ids, motion, layers: AUTO, RAW or ZSTD */
} hmdwarp_host_codec_options;

/* Everything auto (the recommended setting). */
void hmdwarp_host_codec_defaults(hmdwarp_host_codec_options *out);
/* Sets the codecs of the frames submitted (or encoded) from now on; NULL: all raw, version 1 frames. A handle
 * starts with hmdwarp_host_codec_defaults() (auto: what the board's camera message announces, raw before one came).
 * ARG names a field out of range; UNSUPPORTED a codec this library cannot encode. A codec the board did not
 * announce is refused at submit (FORMAT) when the board's camera message says what it decodes. With a video codec
 * each submit or encode is one frame of the stream; a board that lost a reference asks for a key frame (in its
 * pose messages) and the next frame is one. */
int hmdwarp_host_set_codec(hmdwarp_host *h, const hmdwarp_host_codec_options *opts);

typedef struct {
    int color, depth, other;       /* hmdwarp_host_codec of the last frame encoded (never AUTO) */
    int depth_format;              /* hmdwarp_host_wire_depth of the last frame (AUTO: as the frame was given) */
    uint64_t frames;               /* frames encoded (submitted or encoded) */
    uint64_t compressed_frames;    /* of them with a plane not RAW */
    uint64_t key_requests;         /* pose messages that asked for a key frame (WANT_KEY) */
    uint64_t key_frames;           /* frames encoded with key frames forced because of them */
    uint64_t plane_bytes, wire_bytes; /* all frames: bytes before (raw, version 1) and after compression */
    double plane_bytes_last, wire_bytes_last; /* the last frame's */
    double encode_ms_last, encode_ms_mean;    /* the framelink encode (compression included) */
    unsigned board_codecs;         /* bit (1 << hmdwarp_host_codec) for each codec the board announced; 0 unknown */
} hmdwarp_host_codec_stats;

/* Any thread. ARG when h or out is NULL. */
int hmdwarp_host_get_codec_stats(hmdwarp_host *h, hmdwarp_host_codec_stats *out);

#ifdef __cplusplus
}
#endif

#endif
