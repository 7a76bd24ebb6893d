/* SPDX-License-Identifier: MIT */
/* The summary and --stats print from one table (rt_summary): every counter meant for both outputs has a --stats key
 * and a summary line, and shows up in each; the values and formats scripts read stay as they were. */
#include <ctype.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "platform/plat_gles.h"
#include "runtime/rt_select.h"
#include "runtime/rt_summary.h"

typedef struct {
    rt_config cfg;
    rt_telemetry *tel;
    rt_hist *gles_ms;
    rt_eval_acc eval[RT_EVAL_METHODS];
    rt_eval_pose pose;
    uint64_t planes[5];
    rt_summary_src src;
} fixture;

/* A run in which every line of the summary and every optional key has something to say. */
static int setup(void **state)
{
    fixture *f = calloc(1, sizeof *f);
    rt_config_defaults(&f->cfg);
    f->cfg.method = RT_METHOD_AUTO;
    f->cfg.stall_reserve_ms = 2;
    f->tel = rt_telemetry_create();
    f->gles_ms = calloc(PLAT_GLES_PASSES, sizeof *f->gles_ms);
    if (!f->tel || !f->gles_ms) return -1;
    rt_telemetry *t = f->tel;
    t->vsyncs = 200;
    t->missed = 3 + 40;
    t->missed_by[RT_MISS_OWN] = 40;
    t->missed_by[RT_MISS_LATE_WAKE] = 3;
    t->no_buffer = 1;
    t->no_frame = 2;
    t->method_count[RT_METHOD_ROTATION] = 150;
    t->method_count[RT_METHOD_RAYTRACE] = 50;
    for (int i = 0; i < 150; i++) rt_hist_add(&t->warp_ms[RT_METHOD_ROTATION], 2.0);
    for (int i = 0; i < 50; i++) rt_hist_add(&t->warp_ms[RT_METHOD_RAYTRACE], 5.0);
    rt_hist_add(&t->m2p_ms, 20.0);
    rt_hist_add(&t->frame_age_ms, 30.0);
    rt_hist_add(&t->host_render_ms, 9.0);
    rt_hist_add(&t->prepare_ms, 3.0);
    for (int w = 0; w < RT_WHY_COUNT; w++) t->select_why[w] = (uint64_t)w + 1;
    t->method_switches = 4;
    t->frames_received = 20;
    t->frames_bytes = 1234567;
    t->new_frames_shown = 18;
    t->frames_dropped = 1;
    for (int e = 1; e < DRV_FRAME_ERR_COUNT; e++) t->frames_rejected[e] = (uint64_t)e;
    t->imu_samples = 1000;
    t->imu_read_errors = 1;
    t->imu_lost = 1;
    t->imu_stale = 5;
    for (int p = 0; p < PLAT_GLES_PASSES; p++) rt_hist_add(&f->gles_ms[p], 0.5);
    for (int m = 0; m < RT_EVAL_METHODS; m++) f->eval[m] = (rt_eval_acc){2, 60.0 + m, 1.8, 0.5, 30.0};
    f->pose = (rt_eval_pose){2, 1.0, 0.7, 2.0, 1.5};
    for (int p = 0; p < 5; p++) f->planes[p] = (uint64_t)p;

    rt_summary_src *s = &f->src;
    s->cfg = &f->cfg;
    s->tel = t;
    s->run_s = 2.25;
    s->gles = true;
    s->gles_depth = true;
    s->gl_renderer = "Test GPU";
    s->gl_version = "OpenGL ES 3.1";
    s->gles_timing = "timer queries";
    s->render_why = "renderer = gles";
    s->cpu_kernel = "scalar";
    s->threads = 2;
    s->gles_ms = f->gles_ms;
    s->gles_errors = 1;
    s->gles_last_error = "frame 3: texture upload failed";
    s->raytrace_fallbacks = 6;
    s->plane_fallbacks = 7;
    s->imu_name = "hid-mock";
    s->frames_name = "usb-mock";
    s->vsync_name = "gpio-mock";
    s->has_imu_stats = s->has_vsync_stats = s->kms = s->has_link_stats = true;
    s->link = (drv_frames_usb_stats){.connected = true, .connections = 2, .refused = 1, .disconnects = 1,
                                     .poses_sent = 500, .poses_dropped = 3, .cams_sent = 4, .masks_sent = 3,
                                     .usb_speed = "super-speed",
                                     .codecs = 0x7,
                                     .dec = {.compressed_frames = 40, .codec_errors = 2, .key_requests = 1,
                                             .wire_bytes = 1125000, .plane_bytes = 9000000,
                                             .video_decoder = "software"}};
    s->imu = (drv_imu_stats){100, 2, 1, 1, true, "bad report"};
    s->vsync = (drv_vsync_stats){180, 1, 2, 1, false, 11111111, 12.5, ""};
    s->kms_stats = (plat_kms_stats){.flips = 180, .failed = 1, .late = 2, .vblanks = 181, .api = "atomic",
                                    .format = "XRGB8888", .connector = "Virtual-1", .w = 1440, .h = 800, .hz = 90};
    s->output = "KMS Virtual-1";
    s->imu_rejected = 3;
    s->has_orientation = s->has_truth = true;
    s->orientation.q = (warp_quat){1, 0, 0, 0};
    s->orientation_error_deg = 0.25;
    s->sim_host = true;
    s->sim_plane_renders = f->planes;
    s->scene_effects = "rotation";
    s->accuracy = true;
    s->eval = f->eval;
    s->eval_pose = &f->pose;
    s->csv = "/tmp/run.csv";
    *state = f;
    return 0;
}

static int teardown(void **state)
{
    fixture *f = *state;
    rt_telemetry_destroy(f->tel);
    free(f->gles_ms);
    free(f);
    return 0;
}

static char *render(const rt_summary_src *s, bool summary)
{
    char *buf = NULL;
    size_t len = 0;
    FILE *m = open_memstream(&buf, &len);
    assert_non_null(m);
    if (summary)
        rt_summary_print(s, m);
    else
        rt_summary_kv(s, m);
    fclose(m);
    return buf;
}

/* A key=value line with this key (the whole key, at a line's start). */
static bool has_key(const char *kv, const char *key)
{
    size_t n = strlen(key);
    for (const char *p = kv; (p = strstr(p, key)) != NULL; p++)
        if ((p == kv || p[-1] == '\n') && p[n] == '=') return true;
    return false;
}

static void test_where_column(void **state)
{
    (void)state;
    for (int r = 0; r < rt_summary_table_len; r++) {
        const rt_summary_row *row = &rt_summary_table[r];
        bool key = row->key != NULL, label = row->label != NULL;
        switch (row->where) {
        case RT_SUM_BOTH:
            if (!key || !label) fail_msg("row %d (%s): meant for both outputs, lacks its %s", r,
                                         key ? row->key : row->label, key ? "summary line" : "--stats key");
            break;
        case RT_SUM_STATS:
            if (!key || label) fail_msg("row %d: --stats only, yet %s", r, key ? row->label : "no key");
            break;
        case RT_SUM_SUMMARY:
            if (key || !label) fail_msg("row %d: summary only, yet %s", r, key ? row->key : "no label");
            break;
        }
        if (row->kind == 'h' || row->kind == 'x') assert_int_equal(row->where, RT_SUM_SUMMARY);
    }
}

/* Each counter shows up where its row says: its key(s) in --stats, its line in the summary; and every line of the
 * summary is one of the table's. */
static void test_counters_in_both_outputs(void **state)
{
    fixture *f = *state;
    char *sum = render(&f->src, true), *kv = render(&f->src, false);
    int keys = 0;
    for (int r = 0; r < rt_summary_table_len; r++) {
        const rt_summary_row *row = &rt_summary_table[r];
        int n = rt_summary_members(&f->src, r);
        if (n == 0) fail_msg("row %d (%s) absent from a run that has everything", r, row->key ? row->key : row->label);
        if (row->label && !strstr(sum, row->label))
            fail_msg("row %d (%s): no summary line '%s'", r, row->key ? row->key : "-", row->label);
        for (int i = 0; row->key && i < n; i++) {
            char k[96];
            const char *m = rt_summary_member_key(r, i);
            snprintf(k, sizeof k, row->key, m ? m : "");
            for (char *p = k; *p; p++) /* as --stats has them: "I/O error" -> i_o_error */
                *p = isalnum((unsigned char)*p) ? (char)tolower((unsigned char)*p) : '_';
            if (!has_key(kv, k)) fail_msg("row %d: no --stats key %s", r, k);
            keys++;
        }
    }
    /* nothing printed beside the table */
    int lines = 0;
    for (const char *p = kv; *p; p++) lines += *p == '\n';
    assert_int_equal(lines, keys);
    for (char *line = strtok(sum, "\n"); line; line = strtok(NULL, "\n")) {
        if (line[0] != ' ') continue; /* section headings; the title and the two with a value carry a label */
        bool known = false;
        for (int r = 0; r < rt_summary_table_len && !known; r++) {
            if (rt_summary_table[r].label && strstr(line, rt_summary_table[r].label)) known = true;
            for (int i = 0; i < rt_summary_members(&f->src, r) && !known; i++) {
                const char *m = rt_summary_member_label(r, i);
                known = m && strstr(line, m);
            }
        }
        if (!known) fail_msg("summary line with no row in the table: '%s'", line);
    }
    free(sum);
    free(kv);
}

/* The formats scripts read (HIL scenarios, hmdwarp-top) and the summary's arithmetic. */
static void test_values_and_formats(void **state)
{
    fixture *f = *state;
    char *kv = render(&f->src, false), *sum = render(&f->src, true);
    const char *want[] = {"\nrunning=0\n", "\nrun_s=2.2\n", "\nvsyncs=200\n", "\nmissed=43\n",
                          "\nmissed_own=40\n", "\nmissed_late_wake=3\n", "\nmethod_rotation=150\n",
                          "\nwarp_ms_p50=2.005\nwarp_ms_p99=5.005\n", /* auto: every method's warp times */
                          "\nstall_reserve_ms=2.000\n", "\nframes_rejected_i_o_error=", "\nimu_connected=1\n",
                          "\nvsync_period_ns=11111111\n", "\nvsync_jitter_us=12.5\n", "\norientation_w=1.000000\n",
                          "\norientation_error_deg=0.2500\n",
                          "\ngles_upload_ms_p50=0.505\ngles_upload_ms_p99=0.505\ngles_pyramid_ms_p50=",
                          "\npsnr_none=30.000\nssim_none=0.90000\npsnr_rotation=30.500\n", "\nkms_api=atomic\n",
                          "\nrenderer=gles\ngl_renderer=Test GPU\n", "\nframes_bytes=1234567\n",
                          ("\nframes_link_poses_dropped=3\nframes_link_cams_sent=4\nframes_link_masks_sent=3\n"
                           "frames_link_usb_speed=super-speed\n"),
                          /* 1.125 MB in run_s 2.25 s; 9 MB of planes from 1.125 MB on the wire */
                          "\nframes_link_compressed_frames=40\n", "\nframes_link_codec_errors=2\n",
                          "\nframes_link_key_requests=1\n", "\nframes_link_wire_mb_s=0.50\n",
                          "\nframes_link_compression=8.00\n", "\nframes_link_video_decoder=software\n",
                          "\nframes_prepare_ms_p50=3.005\nframes_prepare_ms_p99=3.005\n"};
    for (size_t i = 0; i < sizeof want / sizeof want[0]; i++)
        if (!strstr(kv, want[i])) fail_msg("--stats lacks '%s':\n%s", want[i], kv);
    const char *lines[] = {
        "  vsyncs                     200, missed 43 (21.50 %) (some with no free swapchain image)\n",
        "  warp time (raytrace)       p50   5.00 ms",
        "  frame prepare              p50   3.00 ms",
        "    rejected as I/O error     ",
        "  KMS output                 Virtual-1 1440x800@90, atomic, XRGB8888: 180 page flips, 1 failed, 2 late\n",
        "  planes rendered            color 0, depth 1, ids 2, motion 3, layers 4 (scene effects: rotation)\n",
        "accuracy vs ground truth     left eye at photon time, before the lens; 2 frames sampled\n",
        "per-vsync CSV                /tmp/run.csv\n",
        ("  host link                  connected at usb super-speed, hosts 2 (refused 1), disconnects 1; poses sent "
         "500, dropped 3; camera messages 4, visibility masks 3"),
        ("  link codecs                announced raw zstd jpeg; 40 frames compressed, 0.50 MB/s on the wire (8.0:1), "
         "codec errors 2, key frames asked 1; video decoder software\n")};
    for (size_t i = 0; i < sizeof lines / sizeof lines[0]; i++)
        if (!strstr(sum, lines[i])) fail_msg("summary lacks '%s':\n%s", lines[i], sum);
    free(kv);
    free(sum);
}

/* Live, the evaluator's sums stay out (another thread writes them until the end); optional parts leave no keys. */
static void test_live_and_absent(void **state)
{
    fixture *f = *state;
    rt_summary_src s = f->src;
    s.live = true;
    s.gles = s.kms = s.has_imu_stats = s.has_vsync_stats = s.has_orientation = s.has_link_stats = false;
    s.kms_stats = (plat_kms_stats){.api = "", .format = ""};
    char *kv = render(&s, false);
    assert_non_null(strstr(kv, "\nrunning=1\n"));
    const char *gone[] = {"psnr_", "ssim_", "gles_", "imu_reports", "vsync_edges", "orientation_", "frames_link_"};
    for (size_t i = 0; i < sizeof gone / sizeof gone[0]; i++)
        if (strstr(kv, gone[i])) fail_msg("live --stats has %s", gone[i]);
    /* the KMS keys are always there, zeros offscreen, so scripts need not test for them */
    assert_non_null(strstr(kv, "\nkms_flips=0\n"));
    assert_non_null(strstr(kv, "\nkms_api=\n"));
    free(kv);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_where_column),
        cmocka_unit_test_setup_teardown(test_counters_in_both_outputs, setup, teardown),
        cmocka_unit_test_setup_teardown(test_values_and_formats, setup, teardown),
        cmocka_unit_test_setup_teardown(test_live_and_absent, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
