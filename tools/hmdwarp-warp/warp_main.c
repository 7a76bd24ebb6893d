/* SPDX-License-Identifier: MIT */
/* hmdwarp-warp: scores any warp of the catalogue on frames from the user's own renderer (PNG colour, PFM/raw/16-bit
 * PNG depth, ids, motion, a view file with intrinsics and poses), or on the simulator's scenes; writes the result,
 * its mask and, given the true target view, PSNR/SSIM/error-%. Also generates the results table in docs/. */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "platform/plat_png.h"
#include "platform/plat_version.h"
#include "sim/sim_scene.h"
#include "warp/warp_err.h"
#include "warp/warp_metrics.h"
#include "tools/common/cat_warps.h"
#include "tools/common/warp_files.h"
#include "warp_table.h"
#include "warp_write.h"

typedef struct {
    const char *color, *depth, *ids, *motion, *layers, *view, *ref;
    const char *depth_kind, *depth_encoding;
    double depth_scale;
    const char *warp, *params;
    const char *out, *mask;
    const char *sim, *write_inputs, *write_sequence, *objects;
    int seq_frames;
    double seq_rate;
    double sim_time, dst_time;
    const char *table;
    bool table_quick;
} opts;

static void usage(FILE *f)
{
    fprintf(f,
            "Usage: hmdwarp-warp [options]\n"
            "Runs one warp of hmdwarp's catalogue on a rendered frame and scores it against the true target view.\n"
            "\n"
            "Input (your renderer's frame):\n"
            "  --color FILE.png       source colour (8- or 16-bit PNG, any channels)\n"
            "  --depth FILE           source depth: .pfm (1 channel float), .f32/.raw (float32 little-endian,\n"
            "                         colour's size, rows top to bottom) or .png (16-bit grey)\n"
            "  --depth-kind K         planar (view-space z, the default) or ray (distance along the pixel's ray)\n"
            "  --depth-encoding E     linear (metres after --depth-scale, the default), standard (window depth 0 at\n"
            "                         near .. 1 at far) or reversed (reversed-Z: 1 at near .. 0 at far); 16-bit PNG\n"
            "                         window depth is divided by 65535\n"
            "  --depth-scale S        multiply linear depth by S to get metres (e.g. 0.001 for millimetres)\n"
            "  --ids FILE.png         object ids, 16-bit grey PNG, 0 = static scene (002 §3.2)\n"
            "  --motion FILE.pfm      screen motion in pixels per second, 3-channel PFM (x, y, unused)\n"
            "  --layers FILE          transparent fragments (A-buffer), the binary format of docs/hmdwarp-warp.md\n"
            "  --objects FILE         object poses (id, world_from_object at the source and the target time) for the\n"
            "                         per-object warp; format: docs/hmdwarp-warp.md\n"
            "  --view FILE            intrinsics and the source and target poses (format: docs/hmdwarp-warp.md)\n"
            "  --ref FILE.png         the true target view: prints PSNR, SSIM and error-pixel %% (002 §4)\n"
            "Or the simulator:\n"
            "  --sim SCENE            render the source and the truth of a simulated scene at the view file's poses\n"
            "                         (camera and poses from --view); scenes: see hmdwarpd --list\n"
            "  --time T               scene time of the source frame (object motion), seconds (default 0)\n"
            "  --target-time T        scene time of the target view (default: the source's); per-object warps\n"
            "                         extrapolate object poses to it\n"
            "  --write-inputs DIR     with --sim: also write color.png, depth.pfm, ids.png, motion.pfm, layers.bin,\n"
            "                         objects.txt, view.txt, truth.png there (an example of every input format) and\n"
            "                         manifest.txt: the directory is a one-frame sequence (docs/sequences.md)\n"
            "  --write-sequence DIR   with --sim: write a stereo sequence for hmdwarp-feed --sequence instead of\n"
            "                         warping: the head moves from the view's source to its target pose over\n"
            "                         --frames N (default 30) frames at --rate HZ (default 90) from scene time --time\n"
            "Warp:\n"
            "  --warp NAME            which warp (default rotation); --list shows them with their parameters\n"
            "  --params K=V,K=V       the warp's knobs\n"
            "  --list                 list the warps\n"
            "Output:\n"
            "  --out FILE.png         the warped image\n"
            "  --mask FILE.png        its mask: 0 valid, 64 fringe (outside the source), 128 depth edge, 255 hole,\n"
            "                         192 hole filled\n"
            "Results table:\n"
            "  --table FILE.md        run every warp on every scene of the catalogue's cases and write the table\n"
            "  --quick                smaller images for the table (smoke runs)\n"
            "  -h, --help             this text\n"
            "  --version              print the version and exit\n");
}

static bool parse(int argc, char **argv, opts *o)
{
    *o = (opts){.seq_frames = 30, .seq_rate = 90, .dst_time = NAN, .depth_kind = "planar", .depth_encoding = "linear",
                .depth_scale = 1, .warp = "rotation"};
    enum { O_COLOR = 256, O_DEPTH, O_KIND, O_ENC, O_SCALE, O_IDS, O_MOTION, O_VIEW, O_REF, O_SIM, O_TIME, O_WRITE,
           O_WARP, O_PARAMS, O_LIST, O_OUT, O_MASK, O_TABLE, O_QUICK, O_TTIME, O_LAYERS,
           O_OBJECTS, O_WSEQ, O_FRAMES, O_RATE };
    static const struct option lo[] = {
        {"color", 1, 0, O_COLOR}, {"depth", 1, 0, O_DEPTH}, {"depth-kind", 1, 0, O_KIND},
        {"depth-encoding", 1, 0, O_ENC}, {"depth-scale", 1, 0, O_SCALE}, {"ids", 1, 0, O_IDS},
        {"motion", 1, 0, O_MOTION}, {"layers", 1, 0, O_LAYERS}, {"view", 1, 0, O_VIEW}, {"ref", 1, 0, O_REF}, {"sim", 1, 0, O_SIM},
        {"time", 1, 0, O_TIME}, {"target-time", 1, 0, O_TTIME}, {"write-inputs", 1, 0, O_WRITE}, {"warp", 1, 0, O_WARP},
        {"params", 1, 0, O_PARAMS}, {"list", 0, 0, O_LIST}, {"out", 1, 0, O_OUT}, {"mask", 1, 0, O_MASK},
        {"table", 1, 0, O_TABLE}, {"objects", 1, 0, O_OBJECTS}, {"write-sequence", 1, 0, O_WSEQ},
        {"frames", 1, 0, O_FRAMES}, {"rate", 1, 0, O_RATE},
        {"quick", 0, 0, O_QUICK}, {"help", 0, 0, 'h'}, {"version", 0, 0, 'V'}, {0, 0, 0, 0}};
    int c;
    while ((c = getopt_long(argc, argv, "h", lo, NULL)) != -1) {
        switch (c) {
        case O_COLOR: o->color = optarg; break;
        case O_DEPTH: o->depth = optarg; break;
        case O_KIND: o->depth_kind = optarg; break;
        case O_ENC: o->depth_encoding = optarg; break;
        case O_SCALE: o->depth_scale = atof(optarg); break;
        case O_IDS: o->ids = optarg; break;
        case O_MOTION: o->motion = optarg; break;
        case O_LAYERS: o->layers = optarg; break;
        case O_VIEW: o->view = optarg; break;
        case O_REF: o->ref = optarg; break;
        case O_SIM: o->sim = optarg; break;
        case O_TIME: o->sim_time = atof(optarg); break;
        case O_TTIME: o->dst_time = atof(optarg); break;
        case O_WRITE: o->write_inputs = optarg; break;
        case O_OBJECTS: o->objects = optarg; break;
        case O_WSEQ: o->write_sequence = optarg; break;
        case O_FRAMES:
            o->seq_frames = atoi(optarg);
            if (o->seq_frames < 1 || o->seq_frames > 100000) return fprintf(stderr, "--frames: 1..100000\n"), false;
            break;
        case O_RATE:
            o->seq_rate = atof(optarg);
            if (!(o->seq_rate > 0) || !isfinite(o->seq_rate))
                return fprintf(stderr, "--rate: a positive number\n"), false;
            break;
        case O_WARP: o->warp = optarg; break;
        case O_PARAMS: o->params = optarg; break;
        case O_LIST:
            /* the registry's methods, with the planes each needs and whether hmdwarpd runs it */
            for (const cat_warp *const *w = cat_all(); *w; w++) {
                unsigned n = (*w)->needs;
                printf("  %-16s %-10s %s%s%s%s%s%s\n", (*w)->name, (*w)->cite, (*w)->help, n ? " [needs" : "",
                       n & CAT_NEEDS_DEPTH ? " depth" : "", n & CAT_NEEDS_IDS ? " ids" : "",
                       n & CAT_NEEDS_LAYERS ? " layers" : "", n ? "]" : "");
            }
            exit(0);
        case O_OUT: o->out = optarg; break;
        case O_MASK: o->mask = optarg; break;
        case O_TABLE: o->table = optarg; break;
        case O_QUICK: o->table_quick = true; break;
        case 'h': usage(stdout); exit(0);
        case 'V': printf("hmdwarp-warp %s\n", plat_version()); exit(0);
        default: usage(stderr); return false;
        }
    }
    if (isnan(o->dst_time)) o->dst_time = o->sim_time;
    if (optind < argc) {
        fprintf(stderr, "hmdwarp-warp: unexpected argument '%s' (see --help)\n", argv[optind]);
        return false;
    }
    return true;
}

/* ---- scoring and output ---- */

static void mask_to_grey(const warp_image_u8 *m, warp_image_u8 *g)
{
    for (int y = 0; y < m->h; y++)
        for (int x = 0; x < m->w; x++) {
            uint8_t v = WARP_AT(m, x, y), o = 0;
            if (v & WARP_MASK_FRINGE) o = 64;
            if (v & WARP_MASK_EDGE) o = 128;
            if (v & WARP_MASK_HOLE) o = (v & WARP_MASK_FILLED) ? 192 : 255;
            WARP_AT(g, x, y) = o;
        }
}

static int fail_msg(const char *msg)
{
    fprintf(stderr, "hmdwarp-warp: %s\n", msg);
    return 1;
}

int main(int argc, char **argv)
{
    opts o;
    if (!parse(argc, argv, &o)) return 2;
    char err[512];
    if (o.table) return warp_table_write(o.table, o.table_quick) ? 0 : 1;

    const cat_warp *w = cat_find(o.warp);
    if (!w) return fprintf(stderr, "hmdwarp-warp: unknown warp '%s' (see --list)\n", o.warp), 2;
    if (!o.view) return fail_msg("--view FILE is required (intrinsics and poses; see docs/hmdwarp-warp.md)");
    warpfile_view vf;
    if (!warpfile_load_view(o.view, &vf, err, sizeof err)) return fail_msg(err);
    if (o.sim && o.objects) return fail_msg("--objects is for frames from files (--sim has the scene's own)");
    if (o.write_sequence) {
        const sim_scene *sc = o.sim ? sim_scene_find(o.sim) : NULL;
        if (!sc) return fail_msg("--write-sequence needs --sim SCENE (a scene of hmdwarpd --list)");
        if (!warp_write_sequence(o.write_sequence, sc, &vf, o.seq_frames, o.seq_rate, o.sim_time, err, sizeof err))
            return fail_msg(err);
        printf("sequence of %d frames written to %s\n", o.seq_frames, o.write_sequence);
        return 0;
    }

    warp_image_rgba8 color = {0}, ref = {0};
    warp_image_f32 depth = {0}, inv = {0};
    warp_image_u16 ids = {0};
    warp_image_vec2f motion = {0};
    warp_image_layers layers = {0};
    sim_buffers sb, tb;
    memset(&sb, 0, sizeof sb);
    memset(&tb, 0, sizeof tb);
    warp_view v = {.cam = vf.cam, .pose = vf.src, .time = o.sim_time};
    warp_depth_encoding enc = WARP_DEPTH_LINEAR;
    bool have_depth = false;

    if (o.sim) {
        const sim_scene *sc = sim_scene_find(o.sim);
        if (!sc) return fprintf(stderr, "hmdwarp-warp: unknown scene '%s' (see hmdwarpd --list)\n", o.sim), 2;
        unsigned planes = SIM_PLANE_COLOR | SIM_PLANE_DEPTH | SIM_PLANE_IDS | SIM_PLANE_MOTION | SIM_PLANE_LAYERS;
        if (!sim_buffers_alloc(&sb, vf.cam.width, vf.cam.height, planes, 8) ||
            !sim_buffers_alloc(&tb, vf.cam.width, vf.cam.height, SIM_PLANE_COLOR, 1))
            return fail_msg("out of memory");
        sim_render(sc, o.sim_time, vf.src, &vf.cam, planes, &sb);
        sim_render(sc, o.dst_time, vf.dst, &vf.cam, SIM_PLANE_COLOR, &tb);
        v.color = &sb.color;
        depth = sb.depth;
        have_depth = true;
        v.ids = &sb.ids;
        v.motion = &sb.motion;
        v.layers = &sb.layers;
        static warp_pose objs[64];
        v.n_objects = sim_scene_object_count(sc) < 64 ? sim_scene_object_count(sc) : 64;
        for (int i = 0; i < v.n_objects; i++) objs[i] = sim_scene_object_pose(sc, i + 1, o.sim_time);
        v.object_pose = objs;
        static warp_pose objs_dst[64];
        for (int i = 0; i < v.n_objects; i++) objs_dst[i] = sim_scene_object_pose(sc, i + 1, o.dst_time);
        cat_set_target_objects(objs_dst);
        if (o.write_inputs) {
            if (!warp_write_inputs(o.write_inputs, &vf, &sb, &tb, o.sim_time, v.n_objects, objs, objs_dst, err,
                                   sizeof err))
                return fail_msg(err);
            printf("inputs written to %s (color.png, depth.pfm, ids.png, motion.pfm, layers.bin, objects.txt, "
                   "view.txt, truth.png, manifest.txt)\n", o.write_inputs);
        }
    } else {
        if (!o.color) return fail_msg("--color FILE.png (or --sim SCENE) is required");
        if (!plat_png_read(o.color, &color, err, sizeof err)) return fail_msg(err);
        if (color.w != vf.cam.width || color.h != vf.cam.height)
            return fprintf(stderr, "hmdwarp-warp: %s is %dx%d, the view file says %dx%d\n", o.color, color.w, color.h,
                           vf.cam.width, vf.cam.height), 1;
        v.color = &color;
        if (o.depth) {
            bool ray;
            if (!warpfile_depth_encoding(o.depth_encoding, &enc))
                return fail_msg("--depth-encoding: linear, standard or reversed");
            if (!warpfile_depth_kind(o.depth_kind, &ray)) return fail_msg("--depth-kind: planar or ray");
            if (ray && enc != WARP_DEPTH_LINEAR) return fail_msg("--depth-kind ray needs --depth-encoding linear");
            if (!warpfile_load_depth(o.depth, &vf.cam, enc, ray, o.depth_scale, &depth, err, sizeof err))
                return fail_msg(err);
            have_depth = true;
        }
        if (o.ids) {
            if (!warpfile_load_ids(o.ids, &vf.cam, &ids, err, sizeof err)) return fail_msg(err);
            v.ids = &ids;
        }
        if (o.motion) {
            if (!warpfile_load_motion(o.motion, &vf.cam, &motion, err, sizeof err)) return fail_msg(err);
            v.motion = &motion;
        }
        if (o.objects) {
            /* Object poses from the user's renderer: the source's go with the frame, the target's to the warp. */
            static warpfile_objects ob;
            if (!warpfile_load_objects(o.objects, &ob, err, sizeof err)) return fail_msg(err);
            v.n_objects = ob.n;
            v.object_pose = ob.src;
            cat_set_target_objects(ob.has_target ? ob.dst : NULL);
        }
        if (o.layers) {
            if (!warpfile_read_layers(o.layers, &vf.cam, &layers, err, sizeof err)) return fail_msg(err);
            v.layers = &layers;
        }
        if (o.ref && !plat_png_read(o.ref, &ref, err, sizeof err)) return fail_msg(err);
    }
    if (have_depth) {
        if (!warp_image_f32_alloc(&inv, vf.cam.width, vf.cam.height)) return fail_msg("out of memory");
        long bad = warp_inverse_depth_from(&vf.cam, enc, &depth, &inv, &v.inv_depth_min, &v.inv_depth_max);
        if (bad) fprintf(stderr, "hmdwarp-warp: %ld depth values were NaN, zero or negative: taken as sky\n", bad);
        v.inv_depth = &inv;
    }
    if ((w->needs & CAT_NEEDS_DEPTH) && !v.inv_depth) return fail_msg("this warp needs --depth");
    if ((w->needs & CAT_NEEDS_IDS) && !v.ids) return fail_msg("this warp needs --ids");
    if ((w->needs & CAT_NEEDS_MOTION) && !v.motion) return fail_msg("this warp needs --motion");
    if ((w->needs & CAT_NEEDS_LAYERS) && !v.layers) return fail_msg("this warp needs --layers");

    warp_image_rgba8 out;
    warp_image_u8 mask, grey;
    if (!warp_image_rgba8_alloc(&out, vf.cam.width, vf.cam.height) ||
        !warp_image_u8_alloc(&mask, vf.cam.width, vf.cam.height) ||
        !warp_image_u8_alloc(&grey, vf.cam.width, vf.cam.height))
        return fail_msg("out of memory");
    warp_image_u8_fill(&mask, 0);
    cat_stats st;
    memset(&st, 0, sizeof st);
    const char *why = w->run(&v, &vf.cam, vf.dst, o.dst_time, o.params, &out, &mask, &st);
    if (why) return fprintf(stderr, "hmdwarp-warp: %s: %s\n", w->name, why), 1;
    printf("warp %s (%s): %dx%d, fringe %ld px, holes %ld px", w->name, w->cite, out.w, out.h, st.fringe, st.holes);
    if (st.primitives >= 0) printf(", primitives %ld", st.primitives);
    if (st.samples >= 0) printf(", samples %ld", st.samples);
    if (st.note[0]) printf(" (%s)", st.note);
    printf("\n");
    if (o.out && !plat_png_write(o.out, &out, true, err, sizeof err)) return fail_msg(err);
    if (o.mask) {
        mask_to_grey(&mask, &grey);
        if (!plat_png_write_u8(o.mask, &grey, err, sizeof err)) return fail_msg(err);
    }
    const warp_image_rgba8 *truth = o.sim ? &tb.color : (ref.px ? &ref : NULL);
    if (truth) {
        if (truth->w != out.w || truth->h != out.h) return fail_msg("--ref: size differs from the output's");
        printf("vs truth: PSNR %.2f dB, SSIM %.4f, error px %.3f %% (002 §4); away from fringes: PSNR %.2f dB\n",
               warp_psnr(&out, truth, NULL, 0), warp_ssim(&out, truth, NULL, 0),
               warp_error_pixel_percent(&out, truth, NULL, 0, 20), warp_psnr(&out, truth, &mask, WARP_MASK_FRINGE));
    }
    warp_image_free(&out);
    warp_image_free(&mask);
    warp_image_free(&grey);
    warp_image_free(&inv);
    if (o.sim) {
        sim_buffers_free(&sb);
        sim_buffers_free(&tb);
    } else {
        warp_image_free(&color);
        warp_image_free(&depth);
        warp_image_free(&ids);
        warp_image_free(&motion);
        warp_image_layers_free(&layers);
        warp_image_free(&ref);
    }
    return 0;
}
