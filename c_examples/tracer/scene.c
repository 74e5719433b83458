/*
 * Scene file parser, material creation, environment maps and the Embree scene.
 * The format is documented in README.md (section "Scene format").
 */
#include <ctype.h>
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "tracer.h"

/* ------------------------------------------------------------- model names */

static const char *const MODEL_NAMES[] = {
    "single",        "energy_compensated", "heitz_random_walk",    "position_free",
    "invariance",    "bitterli_deon",      "vgroove",              "vgroove_nonsymmetric",
    "null_scattering", "auto",              "tabulated",
};
#define NMODELS ((int)(sizeof MODEL_NAMES / sizeof MODEL_NAMES[0]))

const char *model_name(uint32_t model) {
    return model < (uint32_t)NMODELS ? MODEL_NAMES[model] : "unknown";
}

int model_from_name(const char *name) {
    if (!strcasecmp(name, "heitz")) return MSBSDF_MODEL_HEITZ_RANDOM_WALK;
    for (int i = 0; i < NMODELS; i++) {
        if (!strcasecmp(name, MODEL_NAMES[i])) return i;
        /* also accept the header's constant names, MSBSDF_MODEL_SINGLE etc. */
        if (!strncasecmp(name, "MSBSDF_MODEL_", 13) && !strcasecmp(name + 13, MODEL_NAMES[i]))
            return i;
    }
    return -1;
}

static int lookup(const char *name, const char *const *names, int n) {
    for (int i = 0; i < n; i++)
        if (!strcasecmp(name, names[i])) return i;
    return -1;
}
static const char *const NDF_NAMES[] = {"beckmann", "ggx", "student_t", "phong",
                                        "exponential", "bessel_k0", "vmf"};
static const char *const FACET_NAMES[] = {"conductor", "dielectric", "diffuse", "material"};
static const char *const ESTIMATOR_NAMES[] = {"pt", "bdpt"};

/* ---------------------------------------------------------------- textures */

static float wrap01(float x) {
    x = x - floorf(x);
    return x >= 1.0f ? 0.0f : x;
}

float texture_lookup(const texture *t, float u, float v) {
    if (!isfinite(u) || !isfinite(v)) u = v = 0.0f; /* bad uvs from a file: no UB in the casts */
    int x = (int)(wrap01(u) * (float)t->w);
    int y = (int)(wrap01(1.0f - v) * (float)t->h);
    if (x >= t->w) x = t->w - 1;
    if (y >= t->h) y = t->h - 1;
    return t->data[(size_t)y * (size_t)t->w + (size_t)x];
}

/* ------------------------------------------------------------- environment */

vec3 env_dir_from_uv(const envmap *e, float u, float v) {
    float theta = v * (float)M_PI;
    float phi = (u - 0.5f) * 2.0f * (float)M_PI + e->rotate;
    float st = sinf(theta);
    return v3(st * sinf(phi), cosf(theta), -st * cosf(phi));
}

static void env_uv_from_dir(const envmap *e, vec3 d, float *u, float *v) {
    float y = d.y < -1.0f ? -1.0f : (d.y > 1.0f ? 1.0f : d.y);
    float phi = atan2f(d.x, -d.z) - e->rotate;
    *u = wrap01(phi / (2.0f * (float)M_PI) + 0.5f);
    *v = acosf(y) / (float)M_PI;
}

static void env_pixel(const envmap *e, vec3 d, int *x, int *y) {
    float u, v;
    env_uv_from_dir(e, d, &u, &v);
    *x = (int)(u * (float)e->w);
    *y = (int)(v * (float)e->h);
    if (*x >= e->w) *x = e->w - 1;
    if (*y >= e->h) *y = e->h - 1;
    if (*x < 0) *x = 0;
    if (*y < 0) *y = 0;
}

msbsdf_rgb env_eval(const envmap *e, vec3 d) {
    if (e->kind == ENV_CONSTANT) return e->constant;
    if (e->kind == ENV_BLACK) return rgb(0, 0, 0);
    int x, y;
    env_pixel(e, d, &x, &y);
    const float *p = e->rgb + 3 * ((size_t)y * (size_t)e->w + (size_t)x);
    return rgb(p[0], p[1], p[2]);
}

static float pixel_weight(const envmap *e, int x, int y) {
    const float *p = e->rgb + 3 * ((size_t)y * (size_t)e->w + (size_t)x);
    float s = sinf(((float)y + 0.5f) / (float)e->h * (float)M_PI);
    return (rgb_lum(rgb(p[0], p[1], p[2])) + 1e-4f) * s;
}

float env_pdf(const envmap *e, vec3 d) {
    if (e->kind == ENV_CONSTANT) return 1.0f / (4.0f * (float)M_PI);
    if (e->kind == ENV_BLACK) return 0.0f;
    int x, y;
    env_pixel(e, d, &x, &y);
    float st = sqrtf(fmaxf(0.0f, 1.0f - d.y * d.y));
    if (st <= 0.0f) return 0.0f;
    float puv = pixel_weight(e, x, y) / e->total * (float)(e->w * e->h);
    return puv / (2.0f * (float)M_PI * (float)M_PI * st);
}

static int cdf_find(const float *cdf, int n, float u) {
    int lo = 0, hi = n - 1; /* largest i with cdf[i] <= u, cdf has n + 1 entries */
    while (lo < hi) {
        int mid = (lo + hi + 1) / 2;
        if (cdf[mid] <= u)
            lo = mid;
        else
            hi = mid - 1;
    }
    return lo;
}

msbsdf_rgb env_sample(const envmap *e, float u1, float u2, vec3 *d, float *pdf) {
    if (e->kind == ENV_BLACK) {
        *pdf = 0.0f;
        *d = v3(0, 1, 0);
        return rgb(0, 0, 0);
    }
    if (e->kind == ENV_CONSTANT) {
        float z = 1.0f - 2.0f * u1, r = sqrtf(fmaxf(0.0f, 1.0f - z * z));
        float phi = 2.0f * (float)M_PI * u2;
        *d = v3(r * cosf(phi), z, r * sinf(phi));
        *pdf = 1.0f / (4.0f * (float)M_PI);
        return e->constant;
    }
    int y = cdf_find(e->row_cdf, e->h, u1);
    float r0 = e->row_cdf[y], r1 = e->row_cdf[y + 1];
    float fy = r1 > r0 ? (u1 - r0) / (r1 - r0) : 0.5f;
    const float *cc = e->col_cdf + (size_t)y * (size_t)(e->w + 1);
    int x = cdf_find(cc, e->w, u2);
    float c0 = cc[x], c1 = cc[x + 1];
    float fx = c1 > c0 ? (u2 - c0) / (c1 - c0) : 0.5f;
    float u = ((float)x + fminf(fmaxf(fx, 0.0f), 0.999f)) / (float)e->w;
    float v = ((float)y + fminf(fmaxf(fy, 0.001f), 0.999f)) / (float)e->h;
    *d = env_dir_from_uv(e, u, v);
    *pdf = env_pdf(e, *d);
    return env_eval(e, *d);
}

static int env_build_cdf(envmap *e) {
    e->row_cdf = malloc(sizeof(float) * (size_t)(e->h + 1));
    e->col_cdf = malloc(sizeof(float) * (size_t)e->h * (size_t)(e->w + 1));
    if (!e->row_cdf || !e->col_cdf) return -1;
    double total = 0.0;
    e->row_cdf[0] = 0.0f;
    double *rows = malloc(sizeof(double) * (size_t)e->h);
    if (!rows) return -1;
    for (int y = 0; y < e->h; y++) {
        float *cc = e->col_cdf + (size_t)y * (size_t)(e->w + 1);
        double acc = 0.0;
        cc[0] = 0.0f;
        for (int x = 0; x < e->w; x++) {
            acc += pixel_weight(e, x, y);
            cc[x + 1] = (float)acc;
        }
        for (int x = 1; x <= e->w; x++) cc[x] = (float)(cc[x] / acc);
        cc[e->w] = 1.0f;
        rows[y] = acc;
        total += acc;
    }
    double acc = 0.0;
    for (int y = 0; y < e->h; y++) {
        acc += rows[y];
        e->row_cdf[y + 1] = (float)(acc / total);
    }
    e->row_cdf[e->h] = 1.0f;
    e->total = (float)total;
    free(rows);
    return 0;
}

typedef struct sky_params {
    msbsdf_rgb zenith, horizon, ground, sun;
    vec3 sun_dir;
    float sun_size_deg, scale;
} sky_params;

static int bake_sky(envmap *e, const sky_params *p) {
    e->kind = ENV_MAP;
    e->w = 512;
    e->h = 256;
    e->rgb = malloc(sizeof(float) * 3 * (size_t)e->w * (size_t)e->h);
    if (!e->rgb) return -1;
    vec3 sd = vnorm(p->sun_dir);
    float cos_sun = cosf(p->sun_size_deg * (float)M_PI / 180.0f);
    for (int y = 0; y < e->h; y++)
        for (int x = 0; x < e->w; x++) {
            vec3 d = env_dir_from_uv(e, ((float)x + 0.5f) / (float)e->w,
                                     ((float)y + 0.5f) / (float)e->h);
            msbsdf_rgb c;
            if (d.y >= 0.0f) {
                float t = powf(1.0f - d.y, 4.0f);
                c = rgb_add(rgb_scale(p->zenith, 1.0f - t), rgb_scale(p->horizon, t));
                float cs = vdot(d, sd);
                if (cs > cos_sun) c = rgb_add(c, p->sun);
                /* a soft glow around the sun */
                float g = powf(fmaxf(cs, 0.0f), 64.0f) * 0.02f;
                c = rgb_add(c, rgb_scale(p->sun, g));
            } else {
                float t = fminf(1.0f, -d.y * 20.0f);
                c = rgb_add(rgb_scale(p->horizon, 1.0f - t), rgb_scale(p->ground, t));
            }
            float *q = e->rgb + 3 * ((size_t)y * (size_t)e->w + (size_t)x);
            q[0] = c.r * p->scale;
            q[1] = c.g * p->scale;
            q[2] = c.b * p->scale;
        }
    return env_build_cdf(e);
}

/* ------------------------------------------------------------------ parser */

#define MAX_TOKENS 96

typedef struct parser {
    const char *file;
    int line;
    char *tok[MAX_TOKENS];
    int ntok, pos;
    char *err;
    size_t errlen;
    char dir[PATH_LEN]; /* directory of the scene file, for relative paths */
} parser;

static int perr(parser *p, const char *fmt, ...) {
    int n = snprintf(p->err, p->errlen, "%s:%d: ", p->file, p->line);
    if (n < 0) n = 0;
    if ((size_t)n < p->errlen) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(p->err + n, p->errlen - (size_t)n, fmt, ap);
        va_end(ap);
    }
    return -1;
}

static int tokenize(parser *p, char *s) {
    p->ntok = 0;
    p->pos = 0;
    while (*s) {
        while (*s && isspace((unsigned char)*s)) s++;
        if (!*s || *s == '#') break;
        if (p->ntok == MAX_TOKENS) return perr(p, "too many tokens on one line (max %d)", MAX_TOKENS);
        if (*s == '"') {
            s++;
            p->tok[p->ntok++] = s;
            while (*s && *s != '"') s++;
            if (*s != '"') return perr(p, "unterminated string");
            *s++ = '\0';
        } else {
            p->tok[p->ntok++] = s;
            while (*s && !isspace((unsigned char)*s)) s++;
            if (*s) *s++ = '\0';
        }
    }
    return 0;
}

static int more(const parser *p) { return p->pos < p->ntok; }

static int is_number(const char *t) {
    char *end;
    errno = 0;
    double v = strtod(t, &end);
    return end != t && *end == '\0' && errno == 0 && isfinite(v);
}

static int next_str(parser *p, const char *what, const char **out) {
    *out = "";
    if (!more(p)) return perr(p, "'%s' expects a value", what);
    *out = p->tok[p->pos++];
    return 0;
}

static int next_num(parser *p, const char *what, float *out) {
    if (!more(p)) return perr(p, "'%s' expects a number", what);
    const char *t = p->tok[p->pos++];
    char *end;
    errno = 0;
    double v = strtod(t, &end);
    if (end == t || *end != '\0' || errno != 0 || !isfinite(v) || fabs(v) > 3.0e38)
        return perr(p, "bad number '%s' for '%s'", t, what);
    *out = (float)v;
    return 0;
}

static int next_int(parser *p, const char *what, long long lo, long long hi, long long *out) {
    if (!more(p)) return perr(p, "'%s' expects an integer", what);
    const char *t = p->tok[p->pos++];
    char *end;
    errno = 0;
    long long v = strtoll(t, &end, 10);
    if (end == t || *end != '\0' || errno != 0)
        return perr(p, "bad integer '%s' for '%s'", t, what);
    if (v < lo || v > hi) return perr(p, "'%s' must be in [%lld, %lld], got %lld", what, lo, hi, v);
    *out = v;
    return 0;
}

static int next_vec(parser *p, const char *what, vec3 *out) {
    if (next_num(p, what, &out->x) || next_num(p, what, &out->y) || next_num(p, what, &out->z))
        return -1;
    return 0;
}

/* 1 or 3 numbers: one number is replicated to all channels. */
static int next_rgb(parser *p, const char *what, msbsdf_rgb *out) {
    float a;
    if (next_num(p, what, &a)) return -1;
    out->r = out->g = out->b = a;
    if (more(p) && is_number(p->tok[p->pos])) {
        if (next_num(p, what, &out->g) || next_num(p, what, &out->b)) return -1;
    }
    return 0;
}

static int expect_key(parser *p, const char *stmt, const char **key) {
    *key = p->tok[p->pos++];
    if (is_number(*key)) return perr(p, "unexpected number '%s' in '%s' (expected a key)", *key, stmt);
    return 0;
}

static void resolve_path(const parser *p, const char *rel, char *out, size_t n) {
    int r;
    if (rel[0] == '/' || p->dir[0] == '\0')
        r = snprintf(out, n, "%s", rel);
    else
        r = snprintf(out, n, "%s/%s", p->dir, rel);
    if (r < 0 || (size_t)r >= n) out[0] = '\0'; /* too long: reported as a missing file */
}

static int find_material(const scene *s, const char *name) {
    for (int i = 0; i < s->nmats; i++)
        if (!strcmp(s->mats[i].name, name)) return i;
    return -1;
}

static int ref_material(parser *p, scene *s, const char *stmt, int *out) {
    const char *name;
    if (next_str(p, "material", &name)) return -1;
    *out = find_material(s, name);
    if (*out < 0) return perr(p, "'%s' uses undefined material '%s' (define it above)", stmt, name);
    return 0;
}

#define GROW(arr, n)                                                                  \
    do {                                                                              \
        void *np_ = realloc((arr), sizeof(*(arr)) * (size_t)((n) + 1));              \
        if (!np_) return perr(p, "out of memory");                                    \
        (arr) = np_;                                                                  \
        memset(&(arr)[(n)], 0, sizeof(*(arr)));                                       \
    } while (0)

/* Conductor presets: linear-RGB complex IOR at roughly 650/550/450 nm. */
static int apply_preset(parser *p, material *m, const char *name) {
    msbsdf_material_desc *d = &m->desc;
    if (!strcasecmp(name, "gold")) {
        d->facet = MSBSDF_FACET_CONDUCTOR;
        d->eta = rgb(0.143f, 0.374f, 1.442f);
        d->k = rgb(3.983f, 2.385f, 1.603f);
    } else if (!strcasecmp(name, "copper")) {
        d->facet = MSBSDF_FACET_CONDUCTOR;
        d->eta = rgb(0.200f, 0.924f, 1.102f);
        d->k = rgb(3.912f, 2.452f, 2.142f);
    } else if (!strcasecmp(name, "aluminium") || !strcasecmp(name, "aluminum")) {
        d->facet = MSBSDF_FACET_CONDUCTOR;
        d->eta = rgb(1.657f, 0.880f, 0.521f);
        d->k = rgb(9.224f, 6.270f, 4.837f);
    } else if (!strcasecmp(name, "silver")) {
        d->facet = MSBSDF_FACET_CONDUCTOR;
        d->eta = rgb(0.155f, 0.117f, 0.138f);
        d->k = rgb(4.828f, 3.122f, 2.147f);
    } else if (!strcasecmp(name, "mirror")) {
        d->facet = MSBSDF_FACET_CONDUCTOR;
        d->eta = rgb(0.0f, 0.0f, 0.0f);
        d->k = rgb(1.0f, 1.0f, 1.0f);
    } else if (!strcasecmp(name, "glass")) {
        d->facet = MSBSDF_FACET_DIELECTRIC;
        d->eta = rgb(1.5f, 1.5f, 1.5f);
    } else {
        return perr(p, "unknown preset '%s' (gold, copper, aluminium, silver, mirror, glass)", name);
    }
    return 0;
}

static int parse_material(parser *p, scene *s) {
    const char *name;
    if (next_str(p, "material", &name)) return -1;
    if (is_number(name)) return perr(p, "material name '%s' must not be a number", name);
    if (strlen(name) >= NAME_LEN) return perr(p, "material name too long");
    if (find_material(s, name) >= 0) return perr(p, "material '%s' defined twice", name);
    GROW(s->mats, s->nmats);
    material *m = &s->mats[s->nmats];
    snprintf(m->name, NAME_LEN, "%s", name);
    m->line = p->line;
    msbsdf_material_desc_init(&m->desc);
    m->fallback_model = -1;
    m->inner = -1;
    m->rough_lo = m->rough_hi = -1.0f;
    msbsdf_material_desc *d = &m->desc;
    char texpath[PATH_LEN] = "";
    while (more(p)) {
        const char *k, *v;
        if (expect_key(p, "material", &k)) return -1;
        long long iv;
        int c;
        if (!strcmp(k, "model")) {
            if (next_str(p, k, &v)) return -1;
            if ((c = model_from_name(v)) < 0) return perr(p, "unknown model '%s'", v);
            d->model = (uint32_t)c;
        } else if (!strcmp(k, "fallback")) {
            if (next_str(p, k, &v)) return -1;
            if ((c = model_from_name(v)) < 0) return perr(p, "unknown model '%s'", v);
            m->fallback_model = c;
        } else if (!strcmp(k, "estimator")) {
            if (next_str(p, k, &v)) return -1;
            if ((c = lookup(v, ESTIMATOR_NAMES, 2)) < 0) return perr(p, "unknown estimator '%s' (pt, bdpt)", v);
            d->estimator = (uint32_t)c;
        } else if (!strcmp(k, "ndf")) {
            if (next_str(p, k, &v)) return -1;
            if ((c = lookup(v, NDF_NAMES, 7)) < 0)
                return perr(p, "unknown ndf '%s' (beckmann, ggx, student_t, phong, exponential, bessel_k0, vmf)", v);
            d->ndf = (uint32_t)c;
        } else if (!strcmp(k, "facet")) {
            if (next_str(p, k, &v)) return -1;
            if ((c = lookup(v, FACET_NAMES, 4)) < 0)
                return perr(p, "unknown facet '%s' (conductor, dielectric, diffuse, material)", v);
            d->facet = (uint32_t)c;
        } else if (!strcmp(k, "alpha")) {
            if (next_num(p, k, &d->alpha_x)) return -1;
            d->alpha_y = d->alpha_x;
        } else if (!strcmp(k, "alpha_x")) {
            if (next_num(p, k, &d->alpha_x)) return -1;
        } else if (!strcmp(k, "alpha_y")) {
            if (next_num(p, k, &d->alpha_y)) return -1;
        } else if (!strcmp(k, "shape")) {
            if (next_num(p, k, &d->shape)) return -1;
        } else if (!strcmp(k, "eta")) {
            if (next_rgb(p, k, &d->eta)) return -1;
        } else if (!strcmp(k, "k")) {
            if (next_rgb(p, k, &d->k)) return -1;
        } else if (!strcmp(k, "albedo")) {
            if (next_rgb(p, k, &d->albedo)) return -1;
        } else if (!strcmp(k, "max_bounces")) {
            if (next_int(p, k, 0, MSBSDF_MAX_BOUNCES, &iv)) return -1;
            d->max_bounces = (uint32_t)iv;
        } else if (!strcmp(k, "tolerance")) {
            if (next_num(p, k, &d->tolerance)) return -1;
        } else if (!strcmp(k, "inner")) {
            if (next_str(p, k, &v)) return -1;
            if ((m->inner = find_material(s, v)) < 0)
                return perr(p, "inner material '%s' is not defined above", v);
        } else if (!strcmp(k, "preset")) {
            if (next_str(p, k, &v) || apply_preset(p, m, v)) return -1;
        } else if (!strcmp(k, "roughness_map")) {
            if (next_str(p, k, &v)) return -1;
            resolve_path(p, v, texpath, sizeof texpath);
        } else if (!strcmp(k, "roughness_range")) {
            if (next_num(p, k, &m->rough_lo) || next_num(p, k, &m->rough_hi)) return -1;
            if (!(m->rough_lo > 0.0f && m->rough_hi > 0.0f && m->rough_lo <= 10.0f && m->rough_hi <= 10.0f))
                return perr(p, "roughness_range values must be in (0, 10]");
        } else {
            return perr(p, "unknown key '%s' in 'material' (model, fallback, estimator, ndf, facet, alpha, "
                           "alpha_x, alpha_y, shape, eta, k, albedo, max_bounces, tolerance, inner, preset, "
                           "roughness_map, roughness_range)", k);
        }
    }
    if (d->facet == MSBSDF_FACET_MATERIAL && m->inner < 0)
        return perr(p, "material '%s' has facet 'material' but no 'inner'", m->name);
    if (texpath[0]) {
        char terr[PATH_LEN + 64];
        if (load_texture(texpath, &m->rough, terr, sizeof terr)) return perr(p, "%s", terr);
        if (m->rough_lo < 0.0f) {
            m->rough_lo = 0.05f;
            m->rough_hi = d->alpha_x;
        }
    }
    s->nmats++;
    return 0;
}

static int parse_light(parser *p, scene *s) {
    const char *type;
    if (next_str(p, "light", &type)) return -1;
    GROW(s->lights, s->nlights);
    light *l = &s->lights[s->nlights];
    int have_v = 0, have_p = 0;
    if (!strcmp(type, "point"))
        l->type = LIGHT_POINT;
    else if (!strcmp(type, "directional"))
        l->type = LIGHT_DIRECTIONAL;
    else
        return perr(p, "unknown light type '%s' (point, directional)", type);
    while (more(p)) {
        const char *k;
        if (expect_key(p, "light", &k)) return -1;
        if (l->type == LIGHT_POINT && !strcmp(k, "position")) {
            if (next_vec(p, k, &l->v)) return -1;
            have_v = 1;
        } else if (l->type == LIGHT_DIRECTIONAL && !strcmp(k, "direction")) {
            if (next_vec(p, k, &l->v)) return -1;
            if (vlen(l->v) == 0.0f) return perr(p, "direction must not be zero");
            l->v = vnorm(l->v);
            have_v = 1;
        } else if ((l->type == LIGHT_POINT && !strcmp(k, "intensity")) ||
                   (l->type == LIGHT_DIRECTIONAL && !strcmp(k, "irradiance"))) {
            if (next_rgb(p, k, &l->power)) return -1;
            have_p = 1;
        } else {
            return perr(p, "unknown key '%s' in 'light %s' (%s)", k, type,
                        l->type == LIGHT_POINT ? "position, intensity" : "direction, irradiance");
        }
    }
    if (!have_v || !have_p)
        return perr(p, "'light %s' needs %s", type,
                    l->type == LIGHT_POINT ? "position and intensity" : "direction and irradiance");
    s->nlights++;
    return 0;
}

static int parse_env(parser *p, scene *s) {
    const char *type;
    if (next_str(p, "env", &type)) return -1;
    envmap *e = &s->env;
    if (e->rgb) return perr(p, "only one 'env' statement is allowed");
    float scale = 1.0f, rot = 0.0f;
    if (!strcmp(type, "none")) {
        e->kind = ENV_BLACK;
        if (more(p)) return perr(p, "'env none' takes no keys");
        return 0;
    }
    if (!strcmp(type, "constant")) {
        e->kind = ENV_CONSTANT;
        if (next_rgb(p, "constant", &e->constant)) return -1;
        if (more(p)) return perr(p, "unexpected '%s' after 'env constant r g b'", p->tok[p->pos]);
        return 0;
    }
    if (!strcmp(type, "hdr")) {
        const char *file;
        char path[PATH_LEN];
        if (next_str(p, "hdr", &file)) return -1;
        resolve_path(p, file, path, sizeof path);
        while (more(p)) {
            const char *k;
            if (expect_key(p, "env hdr", &k)) return -1;
            if (!strcmp(k, "scale")) {
                if (next_num(p, k, &scale)) return -1;
            } else if (!strcmp(k, "rotate")) {
                if (next_num(p, k, &rot)) return -1;
            } else {
                return perr(p, "unknown key '%s' in 'env hdr' (scale, rotate)", k);
            }
        }
        char herr[PATH_LEN + 64];
        e->rgb = load_hdr(path, &e->w, &e->h, herr, sizeof herr);
        if (!e->rgb) return perr(p, "%s", herr);
        for (size_t i = 0; i < (size_t)e->w * (size_t)e->h * 3; i++) e->rgb[i] *= scale;
        e->kind = ENV_MAP;
        e->rotate = rot * (float)M_PI / 180.0f;
        if (env_build_cdf(e)) return perr(p, "out of memory");
        return 0;
    }
    if (!strcmp(type, "sky")) {
        sky_params sp = {rgb(0.25f, 0.45f, 0.95f), rgb(0.95f, 0.95f, 1.0f), rgb(0.30f, 0.27f, 0.24f),
                         rgb(4000.0f, 3600.0f, 3000.0f), v3(0.3f, 0.6f, -0.5f), 1.5f, 1.0f};
        while (more(p)) {
            const char *k;
            if (expect_key(p, "env sky", &k)) return -1;
            if (!strcmp(k, "zenith")) {
                if (next_rgb(p, k, &sp.zenith)) return -1;
            } else if (!strcmp(k, "horizon")) {
                if (next_rgb(p, k, &sp.horizon)) return -1;
            } else if (!strcmp(k, "ground")) {
                if (next_rgb(p, k, &sp.ground)) return -1;
            } else if (!strcmp(k, "sun_radiance")) {
                if (next_rgb(p, k, &sp.sun)) return -1;
            } else if (!strcmp(k, "sun_direction")) {
                if (next_vec(p, k, &sp.sun_dir)) return -1;
                if (vlen(sp.sun_dir) == 0.0f) return perr(p, "sun_direction must not be zero");
            } else if (!strcmp(k, "sun_size")) {
                if (next_num(p, k, &sp.sun_size_deg)) return -1;
            } else if (!strcmp(k, "scale")) {
                if (next_num(p, k, &sp.scale)) return -1;
            } else {
                return perr(p, "unknown key '%s' in 'env sky' (zenith, horizon, ground, sun_radiance, "
                               "sun_direction, sun_size, scale)", k);
            }
        }
        if (bake_sky(e, &sp)) return perr(p, "out of memory");
        return 0;
    }
    return perr(p, "unknown env type '%s' (none, constant, hdr, sky)", type);
}

/* ---------------------------------------------------------- shape builders */

static shape *new_shape(parser *p, scene *s, enum shape_type t) {
    void *np = realloc(s->shapes, sizeof(shape) * (size_t)(s->nshapes + 1));
    if (!np) {
        perr(p, "out of memory");
        return NULL;
    }
    s->shapes = np;
    shape *sh = &s->shapes[s->nshapes];
    memset(sh, 0, sizeof *sh);
    sh->type = t;
    sh->line = p->line;
    return sh;
}

static int alloc_tris(parser *p, shape *sh, int ntris, int normals, int uvs) {
    sh->ntris = ntris;
    sh->pos = calloc((size_t)ntris * 9, sizeof(float));
    sh->nrm = normals ? calloc((size_t)ntris * 9, sizeof(float)) : NULL;
    sh->uv = uvs ? calloc((size_t)ntris * 6, sizeof(float)) : NULL;
    if (!sh->pos || (normals && !sh->nrm) || (uvs && !sh->uv)) return perr(p, "out of memory");
    return 0;
}

static void put_corner(shape *sh, int t, int c, vec3 pos, vec3 n, float u, float v) {
    float *q = sh->pos + 9 * t + 3 * c;
    q[0] = pos.x, q[1] = pos.y, q[2] = pos.z;
    if (sh->nrm) {
        q = sh->nrm + 9 * t + 3 * c;
        q[0] = n.x, q[1] = n.y, q[2] = n.z;
    }
    if (sh->uv) {
        q = sh->uv + 6 * t + 2 * c;
        q[0] = u, q[1] = v;
    }
}

/* A quad a b c d (counter-clockwise seen from the normal side) as two triangles. */
static void put_quad(shape *sh, int t, vec3 a, vec3 b, vec3 c, vec3 d, vec3 n) {
    put_corner(sh, t, 0, a, n, 0, 0);
    put_corner(sh, t, 1, b, n, 1, 0);
    put_corner(sh, t, 2, c, n, 1, 1);
    put_corner(sh, t + 1, 0, a, n, 0, 0);
    put_corner(sh, t + 1, 1, c, n, 1, 1);
    put_corner(sh, t + 1, 2, d, n, 0, 1);
}

static void onb(vec3 n, vec3 *t, vec3 *b) {
    /* Duff et al. 2017, "Building an orthonormal basis, revisited" */
    float sign = copysignf(1.0f, n.z);
    float a = -1.0f / (sign + n.z);
    float bb = n.x * n.y * a;
    *t = v3(1.0f + sign * n.x * n.x * a, sign * bb, -sign * n.x);
    *b = v3(bb, sign + n.y * n.y * a, -n.y);
}

/* A parametric surface f(u, v) tessellated into nu x nv quads with smooth normals. */
typedef vec3 (*param_fn)(const float *prm, float u, float v, vec3 *n);

static vec3 sphere_fn(const float *prm, float u, float v, vec3 *n) {
    float th = v * (float)M_PI, ph = u * 2.0f * (float)M_PI;
    *n = v3(sinf(th) * cosf(ph), cosf(th), sinf(th) * sinf(ph));
    return vadd(v3(prm[0], prm[1], prm[2]), vscale(*n, prm[3]));
}

static vec3 torus_fn(const float *prm, float u, float v, vec3 *n) {
    float ph = u * 2.0f * (float)M_PI, th = v * 2.0f * (float)M_PI;
    vec3 ring = v3(cosf(ph), 0.0f, sinf(ph));
    *n = vadd(vscale(ring, cosf(th)), v3(0.0f, sinf(th), 0.0f));
    return vadd(v3(prm[0], prm[1], prm[2]), vadd(vscale(ring, prm[3]), vscale(*n, prm[4])));
}

static int tessellate(parser *p, shape *sh, param_fn f, const float *prm, int nu, int nv) {
    if (alloc_tris(p, sh, 2 * nu * nv, 1, 1)) return -1;
    int t = 0;
    for (int j = 0; j < nv; j++)
        for (int i = 0; i < nu; i++) {
            float u0 = (float)i / (float)nu, u1 = (float)(i + 1) / (float)nu;
            float w0 = (float)j / (float)nv, w1 = (float)(j + 1) / (float)nv;
            vec3 n00, n10, n11, n01;
            vec3 p00 = f(prm, u0, w0, &n00), p10 = f(prm, u1, w0, &n10);
            vec3 p11 = f(prm, u1, w1, &n11), p01 = f(prm, u0, w1, &n01);
            /* orient each triangle so its winding normal agrees with the smooth normal */
            vec3 ng = vcross(vsub(p01, p00), vsub(p11, p00));
            int flip = vdot(ng, vadd(n00, n11)) < 0.0f;
            if (!flip) {
                put_corner(sh, t, 0, p00, n00, u0, w0);
                put_corner(sh, t, 1, p01, n01, u0, w1);
                put_corner(sh, t, 2, p11, n11, u1, w1);
                put_corner(sh, t + 1, 0, p00, n00, u0, w0);
                put_corner(sh, t + 1, 1, p11, n11, u1, w1);
                put_corner(sh, t + 1, 2, p10, n10, u1, w0);
            } else {
                put_corner(sh, t, 0, p00, n00, u0, w0);
                put_corner(sh, t, 1, p11, n11, u1, w1);
                put_corner(sh, t, 2, p01, n01, u0, w1);
                put_corner(sh, t + 1, 0, p00, n00, u0, w0);
                put_corner(sh, t + 1, 1, p10, n10, u1, w0);
                put_corner(sh, t + 1, 2, p11, n11, u1, w1);
            }
            t += 2;
        }
    return 0;
}

static int parse_sphere(parser *p, scene *s) {
    vec3 c = v3(0, 0, 0);
    float r = 1.0f;
    int mat = -1;
    long long tess = 0;
    while (more(p)) {
        const char *k;
        if (expect_key(p, "sphere", &k)) return -1;
        if (!strcmp(k, "center")) {
            if (next_vec(p, k, &c)) return -1;
        } else if (!strcmp(k, "radius")) {
            if (next_num(p, k, &r)) return -1;
            if (!(r > 0.0f)) return perr(p, "radius must be positive");
        } else if (!strcmp(k, "material")) {
            if (ref_material(p, s, "sphere", &mat)) return -1;
        } else if (!strcmp(k, "tessellate")) {
            if (next_int(p, k, 3, 4096, &tess)) return -1;
        } else {
            return perr(p, "unknown key '%s' in 'sphere' (center, radius, material, tessellate)", k);
        }
    }
    if (mat < 0) return perr(p, "'sphere' needs a material");
    shape *sh = new_shape(p, s, tess ? SHAPE_MESH : SHAPE_SPHERE);
    if (!sh) return -1;
    sh->material = mat;
    sh->center = c;
    sh->radius = r;
    s->nshapes++;
    if (tess) {
        float prm[4] = {c.x, c.y, c.z, r};
        return tessellate(p, sh, sphere_fn, prm, 2 * (int)tess, (int)tess);
    }
    return 0;
}

static int parse_torus(parser *p, scene *s) {
    float prm[5] = {0, 0, 0, 1.0f, 0.3f};
    int mat = -1;
    long long seg = 48;
    while (more(p)) {
        const char *k;
        if (expect_key(p, "torus", &k)) return -1;
        if (!strcmp(k, "center")) {
            if (next_num(p, k, &prm[0]) || next_num(p, k, &prm[1]) || next_num(p, k, &prm[2])) return -1;
        } else if (!strcmp(k, "major")) {
            if (next_num(p, k, &prm[3])) return -1;
        } else if (!strcmp(k, "minor")) {
            if (next_num(p, k, &prm[4])) return -1;
        } else if (!strcmp(k, "material")) {
            if (ref_material(p, s, "torus", &mat)) return -1;
        } else if (!strcmp(k, "segments")) {
            if (next_int(p, k, 3, 4096, &seg)) return -1;
        } else {
            return perr(p, "unknown key '%s' in 'torus' (center, major, minor, material, segments)", k);
        }
    }
    if (mat < 0) return perr(p, "'torus' needs a material");
    if (!(prm[3] > 0.0f && prm[4] > 0.0f)) return perr(p, "torus radii must be positive");
    shape *sh = new_shape(p, s, SHAPE_MESH);
    if (!sh) return -1;
    sh->material = mat;
    s->nshapes++;
    return tessellate(p, sh, torus_fn, prm, 2 * (int)seg, (int)seg);
}

static int parse_plane(parser *p, scene *s) {
    vec3 c = v3(0, 0, 0), n = v3(0, 1, 0);
    float size = 10.0f, uvs = 1.0f;
    int mat = -1;
    while (more(p)) {
        const char *k;
        if (expect_key(p, "plane", &k)) return -1;
        if (!strcmp(k, "center")) {
            if (next_vec(p, k, &c)) return -1;
        } else if (!strcmp(k, "normal")) {
            if (next_vec(p, k, &n)) return -1;
            if (vlen(n) == 0.0f) return perr(p, "normal must not be zero");
        } else if (!strcmp(k, "size")) {
            if (next_num(p, k, &size)) return -1;
            if (!(size > 0.0f)) return perr(p, "size must be positive");
        } else if (!strcmp(k, "uv_scale")) {
            if (next_num(p, k, &uvs)) return -1;
        } else if (!strcmp(k, "material")) {
            if (ref_material(p, s, "plane", &mat)) return -1;
        } else {
            return perr(p, "unknown key '%s' in 'plane' (center, normal, size, uv_scale, material)", k);
        }
    }
    if (mat < 0) return perr(p, "'plane' needs a material");
    shape *sh = new_shape(p, s, SHAPE_MESH);
    if (!sh) return -1;
    sh->material = mat;
    s->nshapes++;
    n = vnorm(n);
    vec3 t, b;
    onb(n, &t, &b);
    float h = 0.5f * size;
    vec3 a = vadd(c, vadd(vscale(t, -h), vscale(b, -h)));
    vec3 bb = vadd(c, vadd(vscale(t, h), vscale(b, -h)));
    vec3 cc = vadd(c, vadd(vscale(t, h), vscale(b, h)));
    vec3 d = vadd(c, vadd(vscale(t, -h), vscale(b, h)));
    if (alloc_tris(p, sh, 2, 0, 1)) return -1;
    put_quad(sh, 0, a, bb, cc, d, n);
    for (int i = 0; i < 12; i++) sh->uv[i] *= uvs * size;
    return 0;
}

static int parse_box(parser *p, scene *s) {
    vec3 lo = v3(-1, -1, -1), hi = v3(1, 1, 1);
    int mat = -1;
    while (more(p)) {
        const char *k;
        if (expect_key(p, "box", &k)) return -1;
        if (!strcmp(k, "min")) {
            if (next_vec(p, k, &lo)) return -1;
        } else if (!strcmp(k, "max")) {
            if (next_vec(p, k, &hi)) return -1;
        } else if (!strcmp(k, "material")) {
            if (ref_material(p, s, "box", &mat)) return -1;
        } else {
            return perr(p, "unknown key '%s' in 'box' (min, max, material)", k);
        }
    }
    if (mat < 0) return perr(p, "'box' needs a material");
    if (!(lo.x < hi.x && lo.y < hi.y && lo.z < hi.z)) return perr(p, "box min must be below max");
    shape *sh = new_shape(p, s, SHAPE_MESH);
    if (!sh) return -1;
    sh->material = mat;
    s->nshapes++;
    if (alloc_tris(p, sh, 12, 0, 1)) return -1;
    vec3 c[8];
    for (int i = 0; i < 8; i++) c[i] = v3(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z);
    /* faces counter-clockwise seen from outside */
    put_quad(sh, 0, c[0], c[4], c[6], c[2], v3(-1, 0, 0));
    put_quad(sh, 2, c[1], c[3], c[7], c[5], v3(1, 0, 0));
    put_quad(sh, 4, c[0], c[1], c[5], c[4], v3(0, -1, 0));
    put_quad(sh, 6, c[2], c[6], c[7], c[3], v3(0, 1, 0));
    put_quad(sh, 8, c[0], c[2], c[3], c[1], v3(0, 0, -1));
    put_quad(sh, 10, c[4], c[5], c[7], c[6], v3(0, 0, 1));
    return 0;
}

static int parse_obj(parser *p, scene *s) {
    const char *file;
    char path[PATH_LEN];
    if (next_str(p, "obj", &file)) return -1;
    resolve_path(p, file, path, sizeof path);
    vec3 tr = v3(0, 0, 0);
    float sc = 1.0f, ry = 0.0f;
    int mat = -1;
    while (more(p)) {
        const char *k;
        if (expect_key(p, "obj", &k)) return -1;
        if (!strcmp(k, "translate")) {
            if (next_vec(p, k, &tr)) return -1;
        } else if (!strcmp(k, "scale")) {
            if (next_num(p, k, &sc)) return -1;
            if (sc == 0.0f) return perr(p, "scale must not be zero");
        } else if (!strcmp(k, "rotate_y")) {
            if (next_num(p, k, &ry)) return -1;
        } else if (!strcmp(k, "material")) {
            if (ref_material(p, s, "obj", &mat)) return -1;
        } else {
            return perr(p, "unknown key '%s' in 'obj' (translate, scale, rotate_y, material)", k);
        }
    }
    if (mat < 0) return perr(p, "'obj' needs a material");
    obj_mesh om;
    char oerr[PATH_LEN + 256];
    if (obj_load(path, &om, oerr, sizeof oerr)) return perr(p, "%s", oerr);
    shape *sh = new_shape(p, s, SHAPE_MESH);
    if (!sh) {
        free(om.pos), free(om.nrm), free(om.uv);
        return -1;
    }
    sh->material = mat;
    sh->ntris = om.ntris;
    sh->pos = om.pos;
    sh->nrm = om.nrm;
    sh->uv = om.uv;
    s->nshapes++;
    float cr = cosf(ry * (float)M_PI / 180.0f), sr = sinf(ry * (float)M_PI / 180.0f);
    for (int i = 0; i < 3 * om.ntris; i++) {
        float *q = sh->pos + 3 * i;
        float x = q[0] * sc, y = q[1] * sc, z = q[2] * sc;
        q[0] = cr * x + sr * z + tr.x;
        q[1] = y + tr.y;
        q[2] = -sr * x + cr * z + tr.z;
        if (sh->nrm) {
            float *n = sh->nrm + 3 * i;
            float nx = n[0], nz = n[2];
            n[0] = cr * nx + sr * nz;
            n[2] = -sr * nx + cr * nz;
            if (sc < 0.0f) n[0] = -n[0], n[1] = -n[1], n[2] = -n[2];
        }
    }
    return 0;
}

static int parse_label(parser *p, scene *s) {
    GROW(s->labels, s->nlabels);
    label *l = &s->labels[s->nlabels];
    l->scale = 2.0f;
    int have_text = 0;
    while (more(p)) {
        const char *k, *v;
        if (expect_key(p, "label", &k)) return -1;
        if (!strcmp(k, "at")) {
            if (next_num(p, k, &l->x) || next_num(p, k, &l->y)) return -1;
        } else if (!strcmp(k, "scale")) {
            if (next_num(p, k, &l->scale)) return -1;
            if (!(l->scale >= 1.0f && l->scale <= 16.0f)) return perr(p, "label scale must be in [1, 16]");
        } else if (!strcmp(k, "text")) {
            if (next_str(p, k, &v)) return -1;
            snprintf(l->text, TEXT_LEN, "%s", v);
            have_text = 1;
        } else {
            return perr(p, "unknown key '%s' in 'label' (at, scale, text)", k);
        }
    }
    if (!have_text) return perr(p, "'label' needs text");
    s->nlabels++;
    return 0;
}

static int parse_camera(parser *p, scene *s) {
    while (more(p)) {
        const char *k;
        if (expect_key(p, "camera", &k)) return -1;
        if (!strcmp(k, "position")) {
            if (next_vec(p, k, &s->cam.pos)) return -1;
        } else if (!strcmp(k, "look_at")) {
            if (next_vec(p, k, &s->cam.look)) return -1;
        } else if (!strcmp(k, "up")) {
            if (next_vec(p, k, &s->cam.up)) return -1;
        } else if (!strcmp(k, "fov")) {
            if (next_num(p, k, &s->cam.fov_deg)) return -1;
            if (!(s->cam.fov_deg > 0.0f && s->cam.fov_deg < 180.0f)) return perr(p, "fov must be in (0, 180)");
        } else {
            return perr(p, "unknown key '%s' in 'camera' (position, look_at, up, fov)", k);
        }
    }
    if (vlen(vsub(s->cam.look, s->cam.pos)) == 0.0f) return perr(p, "camera position equals look_at");
    return 0;
}

static int parse_render(parser *p, scene *s) {
    while (more(p)) {
        const char *k, *v;
        long long iv;
        if (expect_key(p, "render", &k)) return -1;
        if (!strcmp(k, "width")) {
            if (next_int(p, k, 1, 16384, &iv)) return -1;
            s->width = (int)iv;
        } else if (!strcmp(k, "height")) {
            if (next_int(p, k, 1, 16384, &iv)) return -1;
            s->height = (int)iv;
        } else if (!strcmp(k, "spp")) {
            if (next_int(p, k, 1, 1 << 20, &iv)) return -1;
            s->spp = (int)iv;
        } else if (!strcmp(k, "max_depth")) {
            if (next_int(p, k, 1, 1000, &iv)) return -1;
            s->max_depth = (int)iv;
        } else if (!strcmp(k, "seed")) {
            if (next_int(p, k, 0, INT64_MAX, &iv)) return -1;
            s->seed = (uint64_t)iv;
        } else if (!strcmp(k, "exposure")) {
            if (next_num(p, k, &s->exposure)) return -1;
        } else if (!strcmp(k, "tonemap")) {
            if (next_str(p, k, &v)) return -1;
            if (!strcmp(v, "clamp"))
                s->tonemap = 0;
            else if (!strcmp(v, "aces"))
                s->tonemap = 1;
            else
                return perr(p, "unknown tonemap '%s' (clamp, aces)", v);
        } else if (!strcmp(k, "nee")) {
            if (next_str(p, k, &v)) return -1;
            if (!strcmp(v, "on"))
                s->nee = 1;
            else if (!strcmp(v, "off"))
                s->nee = 0;
            else
                return perr(p, "'nee' is 'on' or 'off', got '%s'", v);
        } else {
            return perr(p, "unknown key '%s' in 'render' (width, height, spp, max_depth, seed, exposure, "
                           "tonemap, nee)", k);
        }
    }
    return 0;
}

int scene_load(scene *s, const char *path, char *err, size_t errlen) {
    memset(s, 0, sizeof *s);
    snprintf(s->path, sizeof s->path, "%s", path);
    s->cam.pos = v3(0, 1, -5);
    s->cam.look = v3(0, 0, 0);
    s->cam.up = v3(0, 1, 0);
    s->cam.fov_deg = 40.0f;
    s->width = 320;
    s->height = 240;
    s->spp = 16;
    s->max_depth = 16;
    s->seed = 1;
    s->exposure = 1.0f;
    s->tonemap = 1;
    s->nee = 1;
    s->env.kind = ENV_BLACK;

    parser p;
    memset(&p, 0, sizeof p);
    p.file = path;
    p.err = err;
    p.errlen = errlen;
    const char *slash = strrchr(path, '/');
    if (slash) snprintf(p.dir, sizeof p.dir, "%.*s", (int)(slash - path), path);

    FILE *f = fopen(path, "r");
    if (!f) {
        snprintf(err, errlen, "%s: cannot open scene file: %s", path, strerror(errno));
        return -1;
    }
    char buf[8192];
    int rc = 0;
    while (fgets(buf, sizeof buf, f)) {
        p.line++;
        size_t n = strlen(buf);
        if (n == sizeof buf - 1 && buf[n - 1] != '\n') {
            rc = perr(&p, "line too long (max %d characters)", (int)sizeof buf - 2);
            break;
        }
        if (tokenize(&p, buf)) {
            rc = -1;
            break;
        }
        if (p.ntok == 0) continue;
        const char *st = p.tok[p.pos++];
        if (!strcmp(st, "camera"))
            rc = parse_camera(&p, s);
        else if (!strcmp(st, "render"))
            rc = parse_render(&p, s);
        else if (!strcmp(st, "material"))
            rc = parse_material(&p, s);
        else if (!strcmp(st, "light"))
            rc = parse_light(&p, s);
        else if (!strcmp(st, "env"))
            rc = parse_env(&p, s);
        else if (!strcmp(st, "sphere"))
            rc = parse_sphere(&p, s);
        else if (!strcmp(st, "torus"))
            rc = parse_torus(&p, s);
        else if (!strcmp(st, "plane"))
            rc = parse_plane(&p, s);
        else if (!strcmp(st, "box"))
            rc = parse_box(&p, s);
        else if (!strcmp(st, "obj"))
            rc = parse_obj(&p, s);
        else if (!strcmp(st, "label"))
            rc = parse_label(&p, s);
        else
            rc = perr(&p, "unknown statement '%s' (camera, render, material, light, env, sphere, torus, "
                          "plane, box, obj, label)", st);
        if (rc) break;
    }
    if (!rc && ferror(f)) rc = perr(&p, "read error");
    fclose(f);
    return rc;
}

/* ---------------------------------------------------------------- materials */

int scene_create_materials(scene *s, int model_override, int fallback_on_override, char *err, size_t errlen) {
    int warned[16] = {0}; /* fallback warnings per requested model */
    for (int i = 0; i < s->nmats; i++) {
        material *m = &s->mats[i];
        msbsdf_material_desc d = m->desc;
        if (model_override >= 0) d.model = (uint32_t)model_override;
        if (m->inner >= 0) d.inner = s->mats[m->inner].handle;
        if (m->rough.data) d.alpha_x = d.alpha_y = m->rough_hi;
        msbsdf_status st = msbsdf_material_create(&d, &m->handle);
        m->used_model = d.model;
        m->fell_back = 0;
        /* Fall back when the model does not support the combination or refuses
           this parameter range (e.g. NULL_SCATTERING below alpha 0.2). */
        if ((st == MSBSDF_STATUS_UNSUPPORTED || st == MSBSDF_STATUS_INVALID_ARGUMENT) &&
            (model_override < 0 || fallback_on_override) && m->fallback_model >= 0) {
            if (!warned[d.model & 15]++)
                fprintf(stderr,
                        "warning: %s:%d: material '%s': model '%s' refused this material "
                        "(%s); rendering it with the fallback model '%s'\n",
                        s->path, m->line, m->name, model_name(d.model), msbsdf_status_message(st),
                        model_name((uint32_t)m->fallback_model));
            d.model = (uint32_t)m->fallback_model;
            st = msbsdf_material_create(&d, &m->handle);
            m->used_model = d.model;
            m->fell_back = 1;
        }
        if (st != MSBSDF_STATUS_OK) {
            snprintf(err, errlen, "%s:%d: material '%s': msbsdf_material_create refused model '%s' "
                     "(facet %s, ndf %s): %s", s->path, m->line, m->name, model_name(d.model),
                     d.facet < 4 ? FACET_NAMES[d.facet] : "?", d.ndf < 7 ? NDF_NAMES[d.ndf] : "?",
                     msbsdf_status_message(st));
            return st == MSBSDF_STATUS_UNSUPPORTED ? 1 : 2;
        }
        if (m->rough.data) { /* validate the other end of the range too */
            msbsdf_material *tmp = NULL;
            d.alpha_x = d.alpha_y = m->rough_lo;
            st = msbsdf_material_create(&d, &tmp);
            msbsdf_material_destroy(tmp);
            if (st != MSBSDF_STATUS_OK) {
                snprintf(err, errlen, "%s:%d: material '%s': roughness_range low end refused: %s", s->path,
                         m->line, m->name, msbsdf_status_message(st));
                return 2;
            }
        }
    }
    for (int k = 0; k < 16; k++)
        if (warned[k] > 1)
            fprintf(stderr, "warning: %s: %d more materials asked for '%s' and use their fallback model\n", s->path,
                    warned[k] - 1, model_name((uint32_t)k));
    return 0;
}

void scene_destroy_materials(scene *s) {
    for (int i = s->nmats - 1; i >= 0; i--) {
        msbsdf_material_destroy(s->mats[i].handle);
        s->mats[i].handle = NULL;
    }
}

/* ------------------------------------------------------------------ embree */

int scene_build_bvh(scene *s, char *err, size_t errlen) {
    s->device = rtcNewDevice("threads=1");
    if (!s->device) {
        snprintf(err, errlen, "rtcNewDevice failed (error %d)", (int)rtcGetDeviceError(NULL));
        return -1;
    }
    s->rtc = rtcNewScene(s->device);
    for (int i = 0; i < s->nshapes; i++) {
        shape *sh = &s->shapes[i];
        RTCGeometry g;
        if (sh->type == SHAPE_SPHERE) {
            g = rtcNewGeometry(s->device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
            float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4,
                                               4 * sizeof(float), 1);
            if (!v) goto fail;
            v[0] = sh->center.x, v[1] = sh->center.y, v[2] = sh->center.z, v[3] = sh->radius;
        } else {
            g = rtcNewGeometry(s->device, RTC_GEOMETRY_TYPE_TRIANGLE);
            float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                               3 * sizeof(float), (size_t)sh->ntris * 3);
            unsigned *ix = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                   3 * sizeof(unsigned), (size_t)sh->ntris);
            if (!v || !ix) goto fail;
            memcpy(v, sh->pos, sizeof(float) * 9 * (size_t)sh->ntris);
            for (unsigned t = 0; t < 3u * (unsigned)sh->ntris; t++) ix[t] = t;
        }
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(s->rtc, g, (unsigned)i);
        rtcReleaseGeometry(g);
    }
    rtcCommitScene(s->rtc);
    if (rtcGetDeviceError(s->device) != RTC_ERROR_NONE) goto fail;
    return 0;
fail:
    snprintf(err, errlen, "%s: embree error %d while building the scene", s->path,
             (int)rtcGetDeviceError(s->device));
    return -1;
}

void scene_free(scene *s) {
    scene_destroy_materials(s);
    if (s->rtc) rtcReleaseScene(s->rtc);
    if (s->device) rtcReleaseDevice(s->device);
    for (int i = 0; i < s->nmats; i++) free(s->mats[i].rough.data);
    for (int i = 0; i < s->nshapes; i++) {
        free(s->shapes[i].pos);
        free(s->shapes[i].nrm);
        free(s->shapes[i].uv);
    }
    free(s->mats);
    free(s->lights);
    free(s->shapes);
    free(s->labels);
    free(s->env.rgb);
    free(s->env.row_cdf);
    free(s->env.col_cdf);
    memset(s, 0, sizeof *s);
}
