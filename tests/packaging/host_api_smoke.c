/* SPDX-License-Identifier: MIT */
/* host_api_smoke: a host application as a user writes one, built by test_host_install.sh against the installed
 * header and `pkg-config --libs hmdwarp-host`: waits for the board's cameras, renders at each pose, submits. */
#include <hmdwarp-host.h>
#include <stdio.h>
#include <stdlib.h>

int main(int argc, char **argv)
{
    if (argc != 4) return fprintf(stderr, "usage: host_api_smoke URI FRAMES OUT.rgba\n"), 2;
    int frames = atoi(argv[2]);
    hmdwarp_host *h = hmdwarp_host_open(argv[1]);
    if (!h) return fprintf(stderr, "open: %s\n", hmdwarp_host_last_error()), 1;
    hmdwarp_host_cameras cams;
    if (hmdwarp_host_wait_cameras(h, 10000, &cams) != 1) return fprintf(stderr, "no camera message\n"), 1;
    unsigned w = cams.cam[0].width, hh = cams.cam[0].height;
    unsigned char *bgra = malloc((size_t)w * hh * 4);
    float *depth = malloc((size_t)w * hh * sizeof(float));
    for (int i = 0; i < frames; i++) {
        hmdwarp_host_pose_msg pose;
        int rc = hmdwarp_host_wait_pose(h, 5000, &pose);
        if (rc != 1) return fprintf(stderr, "wait_pose: %d %s\n", rc, hmdwarp_host_last_error()), 1;
        int64_t start = hmdwarp_host_now_ns();
        for (unsigned y = 0; y < hh; y++)
            for (unsigned x = 0; x < w; x++) {
                unsigned char *p = bgra + ((size_t)y * w + x) * 4;
                p[0] = (unsigned char)(i * 40), p[1] = (unsigned char)(y * 255 / hh), p[2] = (unsigned char)(x * 255 / w);
                p[3] = 255;
                depth[(size_t)y * w + x] = 1.0f + 0.01f * (float)x;
            }
        hmdwarp_host_frame f = {.color_format = HMDWARP_HOST_COLOR_BGRA8, .depth_format = HMDWARP_HOST_DEPTH_LINEAR_F32,
                                .pose_seq = pose.seq, .render_start_ns = start};
        for (int e = 0; e < 2; e++) f.eye[e].color = bgra, f.eye[e].depth = depth;
        if (hmdwarp_host_submit(h, &f)) return fprintf(stderr, "submit: %s\n", hmdwarp_host_last_error()), 1;
    }
    /* What was rendered last, as RGBA: what the board must show. */
    FILE *out = fopen(argv[3], "wb");
    for (size_t i = 0; out && i < (size_t)w * hh; i++) {
        unsigned char rgba[4] = {bgra[4 * i + 2], bgra[4 * i + 1], bgra[4 * i], bgra[4 * i + 3]};
        fwrite(rgba, 4, 1, out);
    }
    if (!out || fclose(out)) return fprintf(stderr, "cannot write %s\n", argv[3]), 1;
    hmdwarp_host_stats st;
    hmdwarp_host_get_stats(h, &st);
    printf("sent %llu frames, %llu bytes, %llu poses received, abi %u, version %s\n",
           (unsigned long long)st.frames_sent, (unsigned long long)st.bytes_sent,
           (unsigned long long)st.poses_received, hmdwarp_host_abi_version(), hmdwarp_host_version());
    hmdwarp_host_close(h);
    free(bgra);
    free(depth);
    return st.frames_sent == (unsigned long long)frames ? 0 : 1;
}
