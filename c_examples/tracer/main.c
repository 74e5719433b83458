/*
 * tracer: command line, single renders and --compare panel grids.
 * Usage: tracer [options] SCENE   (tracer --help lists the options)
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "tracer.h"

#define MAX_COMPARE 16

static void usage(FILE *f) {
    fprintf(f,
            "usage: tracer [options] SCENE\n"
            "  --spp N          samples per pixel (default: the scene's 'render spp')\n"
            "  --seconds T      render progressively for about T seconds (--spp caps it)\n"
            "  --threads N      worker threads (default: online CPUs); the image does not depend on it\n"
            "  --width W        image width (height follows the scene's aspect unless --height)\n"
            "  --height H       image height\n"
            "  --seed S         base seed (default: the scene's 'render seed')\n"
            "  --out PREFIX     output prefix (default out/<scene name>); writes PREFIX.png and PREFIX.pfm\n"
            "  --model NAME     render every material with this model\n"
            "  --compare LIST   comma-separated models: one render per model, a labelled panel grid\n"
            "                   PREFIX_compare.png and a difference grid PREFIX_compare_diff.png\n"
            "  --diff-scale S   difference image gain (default 1)\n"
            "  --alpha A        set the roughness (alpha_x = alpha_y) of every material\n"
            "  --nee on|off     next-event estimation (default: the scene's 'render nee')\n"
            "  --quiet          no progress bar\n"
            "exit status: 0 success, 1 scene/IO error, 2 bad command line,\n"
            "             3 a material's model is not supported by this msbsdf build\n"
            "models: single energy_compensated heitz_random_walk (heitz) position_free invariance\n"
            "        bitterli_deon vgroove vgroove_nonsymmetric null_scattering auto\n");
}

static int parse_long(const char *opt, const char *v, long lo, long hi, long *out) {
    char *end;
    errno = 0;
    long x = v ? strtol(v, &end, 10) : 0;
    if (!v || end == v || *end || errno || x < lo || x > hi) {
        fprintf(stderr, "tracer: %s expects an integer in [%ld, %ld], got '%s'\n", opt, lo, hi, v ? v : "");
        return -1;
    }
    *out = x;
    return 0;
}

static int parse_double(const char *opt, const char *v, double *out) {
    char *end;
    errno = 0;
    double x = v ? strtod(v, &end) : 0.0;
    if (!v || end == v || *end || errno || !isfinite(x) || x < 0.0) {
        fprintf(stderr, "tracer: %s expects a non-negative number, got '%s'\n", opt, v ? v : "");
        return -1;
    }
    *out = x;
    return 0;
}

static void mkdirs_for(const char *prefix) {
    char buf[PATH_LEN];
    snprintf(buf, sizeof buf, "%s", prefix);
    for (char *p = buf + 1; *p; p++)
        if (*p == '/') {
            *p = '\0';
            mkdir(buf, 0777);
            *p = '/';
        }
}

/* "{NAME}" in a label becomes the model material NAME was rendered with. */
static void expand_label(const scene *s, const char *in, char *out, size_t n) {
    size_t o = 0;
    while (*in && o + 1 < n) {
        const char *close = *in == '{' ? strchr(in, '}') : NULL;
        if (close) {
            char name[NAME_LEN];
            snprintf(name, sizeof name, "%.*s", (int)(close - in - 1), in + 1);
            for (int i = 0; i < s->nmats; i++)
                if (!strcmp(s->mats[i].name, name)) {
                    char rep[TEXT_LEN];
                    if (s->mats[i].fell_back)
                        snprintf(rep, sizeof rep, "%s (FALLBACK)", model_name(s->mats[i].used_model));
                    else
                        snprintf(rep, sizeof rep, "%s", model_name(s->mats[i].used_model));
                    int k = snprintf(out + o, n - o, "%s", rep);
                    o += k > 0 ? (size_t)k : 0;
                    if (o >= n) o = n - 1;
                    in = close + 1;
                    goto next;
                }
        }
        out[o++] = *in++;
    next:;
    }
    out[o] = '\0';
}

static void draw_labels(const scene *s, float *img, int w, int h, int x0, int y0, int pw, int ph) {
    for (int i = 0; i < s->nlabels; i++) {
        char text[TEXT_LEN];
        expand_label(s, s->labels[i].text, text, sizeof text);
        int sc = (int)s->labels[i].scale;
        if (pw < 400 && sc > 1) sc = sc / 2 > 1 ? sc / 2 : 1; /* small panels: smaller text */
        float fx = fminf(fmaxf(s->labels[i].x, -1.0f), 2.0f), fy = fminf(fmaxf(s->labels[i].y, -1.0f), 2.0f);
        draw_text(img, w, h, x0 + (int)(fx * (float)pw), y0 + (int)(fy * (float)ph), sc, text, rgb(8, 8, 8));
    }
}

static int write_outputs(const char *prefix, const char *suffix, const float *img, int w, int h, float exposure,
                         int tonemap, int png_only) {
    char path[PATH_LEN + 64];
    if (!png_only) {
        snprintf(path, sizeof path, "%s%s.pfm", prefix, suffix);
        if (write_pfm(path, img, w, h)) {
            fprintf(stderr, "tracer: cannot write %s: %s\n", path, strerror(errno));
            return -1;
        }
        printf("wrote %s\n", path);
    }
    snprintf(path, sizeof path, "%s%s.png", prefix, suffix);
    if (write_png(path, img, w, h, exposure, tonemap)) {
        fprintf(stderr, "tracer: cannot write %s\n", path);
        return -1;
    }
    printf("wrote %s\n", path);
    return 0;
}

static int write_pfm_checked(const char *prefix, const float *img, int w, int h) {
    char path[PATH_LEN + 64];
    snprintf(path, sizeof path, "%s.pfm", prefix);
    if (write_pfm(path, img, w, h)) {
        fprintf(stderr, "tracer: cannot write %s: %s\n", path, strerror(errno));
        return -1;
    }
    printf("wrote %s\n", path);
    return 0;
}

int main(int argc, char **argv) {
    const char *scene_path = NULL, *prefix_opt = NULL, *compare = NULL, *model_opt = NULL;
    long spp = 0, threads = 0, width = 0, height = 0, seed = -1;
    double seconds = 0.0, diff_scale = 1.0, alpha = -1.0; /* < 0: not set */
    int nee = -1;
    int quiet = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        int used = 1;
        if (!strcmp(a, "--spp")) {
            if (parse_long(a, v, 1, 1 << 20, &spp)) return 2;
        } else if (!strcmp(a, "--seconds")) {
            if (parse_double(a, v, &seconds)) return 2;
        } else if (!strcmp(a, "--threads")) {
            if (parse_long(a, v, 1, 1024, &threads)) return 2;
        } else if (!strcmp(a, "--width")) {
            if (parse_long(a, v, 1, 16384, &width)) return 2;
        } else if (!strcmp(a, "--height")) {
            if (parse_long(a, v, 1, 16384, &height)) return 2;
        } else if (!strcmp(a, "--seed")) {
            if (parse_long(a, v, 0, 0x7fffffffL, &seed)) return 2;
        } else if (!strcmp(a, "--diff-scale")) {
            if (parse_double(a, v, &diff_scale)) return 2;
        } else if (!strcmp(a, "--alpha")) {
            if (parse_double(a, v, &alpha)) return 2;
            if (!(alpha >= 0.0 && alpha <= 10.0)) return fprintf(stderr, "tracer: --alpha must be in [0, 10]\n"), 2;
        } else if (!strcmp(a, "--nee")) {
            if (v && !strcmp(v, "on"))
                nee = 1;
            else if (v && !strcmp(v, "off"))
                nee = 0;
            else
                return fprintf(stderr, "tracer: --nee expects 'on' or 'off'\n"), 2;
        } else if (!strcmp(a, "--out")) {
            if (!v) return fprintf(stderr, "tracer: --out expects a prefix\n"), 2;
            prefix_opt = v;
        } else if (!strcmp(a, "--compare")) {
            if (!v) return fprintf(stderr, "tracer: --compare expects a list of models\n"), 2;
            compare = v;
        } else if (!strcmp(a, "--model")) {
            if (!v) return fprintf(stderr, "tracer: --model expects a model name\n"), 2;
            model_opt = v;
        } else {
            used = 0;
            if (!strcmp(a, "--quiet")) {
                quiet = 1;
            } else if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
                usage(stdout);
                return 0;
            } else if (a[0] == '-') {
                fprintf(stderr, "tracer: unknown option '%s'\n", a);
                usage(stderr);
                return 2;
            } else if (scene_path) {
                fprintf(stderr, "tracer: more than one scene given ('%s' and '%s')\n", scene_path, a);
                return 2;
            } else {
                scene_path = a;
            }
        }
        i += used;
    }
    if (!scene_path) {
        usage(stderr);
        return 2;
    }
    int override = -1;
    if (model_opt && (override = model_from_name(model_opt)) < 0) {
        fprintf(stderr, "tracer: unknown model '%s' for --model\n", model_opt);
        return 2;
    }
    int cmp_models[MAX_COMPARE], ncmp = 0;
    if (compare) {
        char buf[512];
        snprintf(buf, sizeof buf, "%s", compare);
        for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ",")) {
            int m = model_from_name(tok);
            if (m < 0) return fprintf(stderr, "tracer: unknown model '%s' in --compare\n", tok), 2;
            if (ncmp == MAX_COMPARE) return fprintf(stderr, "tracer: at most %d models in --compare\n", MAX_COMPARE), 2;
            cmp_models[ncmp++] = m;
        }
        if (ncmp == 0) return fprintf(stderr, "tracer: --compare needs at least one model\n"), 2;
    }

    scene s;
    char err[1024];
    if (scene_load(&s, scene_path, err, sizeof err)) {
        fprintf(stderr, "tracer: %s\n", err);
        scene_free(&s);
        return 1;
    }
    if (width && !height) height = (long)((double)s.height * (double)width / (double)s.width + 0.5);
    if (height && !width) width = (long)((double)s.width * (double)height / (double)s.height + 0.5);
    if (width) s.width = (int)width;
    if (height) s.height = (int)(height > 0 ? height : 1);
    if (seed >= 0) s.seed = (uint64_t)seed;
    if (nee >= 0) s.nee = nee;
    for (int i = 0; alpha >= 0.0 && i < s.nmats; i++) {
        s.mats[i].desc.alpha_x = s.mats[i].desc.alpha_y = (float)alpha;
        if (s.mats[i].rough.data) s.mats[i].rough_lo = s.mats[i].rough_hi = (float)alpha;
    }
    if (scene_build_bvh(&s, err, sizeof err)) {
        fprintf(stderr, "tracer: %s\n", err);
        scene_free(&s);
        return 1;
    }

    char prefix[PATH_LEN];
    if (prefix_opt) {
        snprintf(prefix, sizeof prefix, "%s", prefix_opt);
    } else {
        const char *base = strrchr(scene_path, '/');
        base = base ? base + 1 : scene_path;
        const char *dot = strrchr(base, '.');
        snprintf(prefix, sizeof prefix, "out/%.*s", dot ? (int)(dot - base) : (int)strlen(base), base);
    }
    mkdirs_for(prefix);

    render_opts ro;
    memset(&ro, 0, sizeof ro);
    long ncpu = sysconf(_SC_NPROCESSORS_ONLN);
    ro.threads = threads > 0 ? (int)threads : (ncpu > 0 ? (int)ncpu : 1);
    ro.spp = (int)spp;
    ro.seconds = seconds;
    ro.quiet = quiet;
    size_t npix = (size_t)s.width * (size_t)s.height;
    int rc = 0;

    if (!compare) {
        int mrc = scene_create_materials(&s, override, 0, err, sizeof err);
        if (mrc) {
            fprintf(stderr, "tracer: %s\n", err);
            scene_free(&s);
            return mrc == 1 ? 3 : 1; /* 3: a model this msbsdf build does not support */
        }
        float *img = malloc(sizeof(float) * 3 * npix);
        render_stats st;
        ro.tag = scene_path;
        if (!img || render(&s, &ro, img, &st)) {
            fprintf(stderr, "tracer: rendering failed (out of memory or thread creation)\n");
            free(img);
            scene_free(&s);
            return 1;
        }
        printf("rendered %s: %dx%d, %d spp, %d threads, %.2f s, %.3f Msamples/s\n", scene_path, s.width, s.height,
               st.spp_done, ro.threads, st.seconds, (double)st.samples / st.seconds * 1e-6);
        /* the PFM is the plain linear render; the PNG carries the scene's labels */
        if (write_pfm_checked(prefix, img, s.width, s.height)) rc = 1;
        draw_labels(&s, img, s.width, s.height, 0, 0, s.width, s.height);
        if (!rc && write_outputs(prefix, "", img, s.width, s.height, s.exposure, s.tonemap, 1)) rc = 1;
        free(img);
        scene_free(&s);
        return rc;
    }

    /* --compare: one panel per model */
    int cols = ncmp <= 3 ? ncmp : (ncmp <= 4 ? 2 : (ncmp <= 9 ? 3 : 4));
    int rows = (ncmp + cols - 1) / cols, gap = 4;
    int gw = cols * s.width + (cols - 1) * gap, gh = rows * s.height + (rows - 1) * gap;
    float *grid = calloc((size_t)gw * (size_t)gh * 3, sizeof(float));
    float *diff = calloc((size_t)gw * (size_t)gh * 3, sizeof(float));
    float *panels = calloc(npix * 3 * (size_t)ncmp, sizeof(float));
    int ok[MAX_COMPARE] = {0}, ref = -1;
    if (!grid || !diff || !panels) {
        fprintf(stderr, "tracer: out of memory\n");
        free(grid), free(diff), free(panels);
        scene_free(&s);
        return 1;
    }
    for (int i = 0; i < ncmp && !rc; i++) {
        const char *mn = model_name((uint32_t)cmp_models[i]);
        float *img = panels + npix * 3 * (size_t)i;
        scene_destroy_materials(&s);
        /* A material the panel's model refuses uses its own fallback, if any. */
        int mrc = scene_create_materials(&s, cmp_models[i], 1, err, sizeof err);
        int x0 = (i % cols) * (s.width + gap), y0 = (i / cols) * (s.height + gap);
        char text[TEXT_LEN];
        if (mrc == 1) {
            fprintf(stderr, "note: skipping the '%s' panel: %s\n", mn, err);
            for (size_t k = 0; k < npix * 3; k++) img[k] = 0.05f;
            snprintf(text, sizeof text, "%s: UNSUPPORTED for this scene", mn);
        } else if (mrc) {
            fprintf(stderr, "tracer: %s\n", err);
            rc = 1;
            break;
        } else {
            render_stats st;
            ro.tag = mn;
            if (render(&s, &ro, img, &st)) {
                fprintf(stderr, "tracer: rendering failed\n");
                rc = 1;
                break;
            }
            double mss = (double)st.samples / st.seconds * 1e-6;
            printf("model %-22s %d spp, %.2f s, %.3f Msamples/s\n", mn, st.spp_done, st.seconds, mss);
            char suffix[64];
            snprintf(suffix, sizeof suffix, "_%s", mn);
            if (write_outputs(prefix, suffix, img, s.width, s.height, s.exposure, s.tonemap, 0)) rc = 1;
            ok[i] = 1;
            if (ref < 0) ref = i;
            snprintf(text, sizeof text, "%s  %d spp  %.1f s", mn, st.spp_done, st.seconds);
        }
        for (int y = 0; y < s.height; y++)
            memcpy(grid + 3 * ((size_t)(y0 + y) * (size_t)gw + (size_t)x0), img + 3 * (size_t)y * (size_t)s.width,
                   sizeof(float) * 3 * (size_t)s.width);
        draw_labels(&s, grid, gw, gh, x0, y0, s.width, s.height);
        int ls = s.width >= 400 ? 2 : 1;
        draw_text(grid, gw, gh, x0 + 4, y0 + s.height - 10 * ls, ls, text, rgb(8, 8, 2));
    }
    if (!rc) {
        for (int i = 0; i < ncmp; i++) {
            int x0 = (i % cols) * (s.width + gap), y0 = (i / cols) * (s.height + gap);
            const float *a = panels + npix * 3 * (size_t)i, *b = panels + npix * 3 * (size_t)(ref < 0 ? 0 : ref);
            for (int y = 0; y < s.height; y++)
                for (int x = 0; x < s.width; x++)
                    for (int c = 0; c < 3; c++) {
                        size_t k = 3 * ((size_t)y * (size_t)s.width + (size_t)x) + (size_t)c;
                        diff[3 * ((size_t)(y0 + y) * (size_t)gw + (size_t)(x0 + x)) + (size_t)c] =
                            ok[i] && ref >= 0 ? fabsf(a[k] - b[k]) * (float)diff_scale : 0.05f;
                    }
            char text[TEXT_LEN];
            if (!ok[i])
                snprintf(text, sizeof text, "%s: UNSUPPORTED", model_name((uint32_t)cmp_models[i]));
            else
                snprintf(text, sizeof text, "|%s - %s| x%g", model_name((uint32_t)cmp_models[i]),
                         model_name((uint32_t)cmp_models[ref]), diff_scale);
            draw_text(diff, gw, gh, x0 + 4, y0 + 4, s.width >= 400 ? 2 : 1, text, rgb(8, 8, 2));
        }
        if (write_outputs(prefix, "_compare", grid, gw, gh, s.exposure, s.tonemap, 1) ||
            write_outputs(prefix, "_compare_diff", diff, gw, gh, s.exposure, s.tonemap, 1))
            rc = 1;
    }
    free(grid), free(diff), free(panels);
    scene_free(&s);
    return rc;
}
