/* rt_config: hmdwarpd's settings: defaults, board.ini parsing (inih) with errors naming line and key, command-line
 * overrides (section.key=value) and validation. One table defines every key, its range and its help text. */
#ifndef RT_CONFIG_H
#define RT_CONFIG_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "warp/warp_camera.h"
#include "warp/warp_lens.h"

typedef enum { RT_METHOD_NONE = 0, RT_METHOD_ROTATION = 1, RT_METHOD_RAYTRACE = 2, RT_METHOD_COUNT } rt_method;
const char *rt_method_name(rt_method m);

typedef struct {
    char board_name[64];
    /* [display] */
    int panel_w, panel_h;       /* whole panel; the left eye gets the left half, the right eye the right half */
    double refresh_hz;
    double photon_offset_ms;    /* vsync edge -> photons (e.g. half a frame for mid-scanout) */
    char sink[16];              /* null | png | raw */
    int sink_every;
    char sink_path[256];
    /* [render] */
    char renderer[16];          /* cpu */
    int threads;                /* compositor threads, caller included */
    int rt_priority;            /* SCHED_FIFO priority of the compositor when permitted; 0 = normal */
    /* [eye]: the host's eye buffers (left eye; the right eye is its mirror image) */
    int eye_w, eye_h;
    double fov_deg[4];          /* left, right, up, down half-angles in degrees */
    double near_z;
    double ipd;
    /* [lens] */
    int mesh_n;
    double k[3][WARP_LENS_TERMS];
    double lens_scale;          /* panel pixels per unit of normalised radius */
    double lens_center[2];      /* left eye, pixels within its half of the panel; mirrored for the right eye */
    /* [warp] */
    rt_method method;
    int raytrace_steps;
    int edge_fill;              /* warp_edge_fill */
    double edge_jump;
    /* [imu] [frames] [vsync] backends */
    char imu_backend[16], frames_backend[16], vsync_backend[16];
    /* [sim] */
    char scene[32], trace[32];
    double duration_s;
    uint64_t seed;
    double host_rate_hz;
    double host_latency_ms;     /* transport latency added after the simulated render */
    int host_threads;           /* threads the simulated host renders with */
    double imu_rate_hz;
    double imu_rest_s;          /* the simulated headset lies still this long before the motion starts */
    double gyro_noise, gyro_bias[3], accel_noise;
    double eval_every_ms;       /* accuracy sample period; 0 = off */
    /* [telemetry] */
    char csv[256];
} rt_config;

void rt_config_defaults(rt_config *c);

/* Error list filled by parsing and validation. */
typedef struct {
    int count;
    char msg[16][200];
} rt_config_errors;

/* Parses a board.ini file. Every problem (unknown section or key, bad value, syntax) is recorded with its line
 * number; returns true when there were none. */
bool rt_config_load(rt_config *c, const char *path, rt_config_errors *err);
/* Parses INI text (tests, embedded defaults); `name` is used in messages. */
bool rt_config_load_string(rt_config *c, const char *text, const char *name, rt_config_errors *err);
/* Applies one "section.key=value" override from the command line. */
bool rt_config_set(rt_config *c, const char *assignment, rt_config_errors *err);
/* Cross-key checks (camera, lens folding over the viewport, sizes). */
bool rt_config_validate(const rt_config *c, rt_config_errors *err);

/* Derived objects. eye = WARP_EYE_LEFT / WARP_EYE_RIGHT. */
warp_camera rt_config_eye_camera(const rt_config *c, int eye);
warp_lens rt_config_lens(const rt_config *c, int eye);

/* Writes every key with its default and meaning (for --help and the README). */
void rt_config_print_keys(FILE *out);
/* Writes the effective configuration as INI. */
void rt_config_print(const rt_config *c, FILE *out);

#endif
