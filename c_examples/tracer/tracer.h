/*
 * tracer: a small Embree + msbsdf path tracer (see README.md next to this file).
 *
 * Shared types: vectors, the scene, the renderer's options and the image
 * helpers. Everything is plain C11.
 */
#ifndef TRACER_H
#define TRACER_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include <embree3/rtcore.h>

#include "msbsdf.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* ---------------------------------------------------------------- vectors */

typedef struct vec3 {
    float x, y, z;
} vec3;

static inline vec3 v3(float x, float y, float z) {
    vec3 r = {x, y, z};
    return r;
}
static inline vec3 vadd(vec3 a, vec3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline vec3 vsub(vec3 a, vec3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline vec3 vmul(vec3 a, vec3 b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
static inline vec3 vscale(vec3 a, float s) { return v3(a.x * s, a.y * s, a.z * s); }
static inline float vdot(vec3 a, vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline vec3 vcross(vec3 a, vec3 b) {
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline float vlen(vec3 a) { return sqrtf(vdot(a, a)); }
static inline vec3 vnorm(vec3 a) {
    float l = vlen(a);
    return l > 0.0f ? vscale(a, 1.0f / l) : v3(0.0f, 0.0f, 1.0f);
}
static inline float vmaxabs(vec3 a) {
    float m = fabsf(a.x);
    if (fabsf(a.y) > m) m = fabsf(a.y);
    if (fabsf(a.z) > m) m = fabsf(a.z);
    return m;
}

static inline msbsdf_rgb rgb(float r, float g, float b) {
    msbsdf_rgb c = {r, g, b};
    return c;
}
static inline msbsdf_rgb rgb_mul(msbsdf_rgb a, msbsdf_rgb b) {
    return rgb(a.r * b.r, a.g * b.g, a.b * b.b);
}
static inline msbsdf_rgb rgb_scale(msbsdf_rgb a, float s) { return rgb(a.r * s, a.g * s, a.b * s); }
static inline msbsdf_rgb rgb_add(msbsdf_rgb a, msbsdf_rgb b) {
    return rgb(a.r + b.r, a.g + b.g, a.b + b.b);
}
static inline float rgb_max(msbsdf_rgb a) {
    float m = a.r;
    if (a.g > m) m = a.g;
    if (a.b > m) m = a.b;
    return m;
}
static inline float rgb_lum(msbsdf_rgb a) { return 0.2126f * a.r + 0.7152f * a.g + 0.0722f * a.b; }

/* ------------------------------------------------------------------ scene */

#define NAME_LEN 64
#define TEXT_LEN 160
#define PATH_LEN 512

/** A single-channel texture in [0, 1], sampled with wrapping nearest lookup. */
typedef struct texture {
    int w, h;
    float *data;
} texture;

typedef struct material {
    char name[NAME_LEN];
    int line;                  /* scene line that defined it */
    msbsdf_material_desc desc; /* as written in the scene (model may be overridden) */
    int fallback_model;        /* -1: none; else model used when create says UNSUPPORTED */
    int inner;                 /* index of the inner material, -1 if none */
    texture rough;             /* data == NULL: constant roughness */
    float rough_lo, rough_hi;  /* alpha = lo + t * (hi - lo) with t from the texture */
    /* filled by scene_create_materials */
    msbsdf_material *handle;
    uint32_t used_model;       /* model the handle was created with */
    int fell_back;             /* 1 if the fallback model was used */
} material;

enum light_type { LIGHT_POINT, LIGHT_DIRECTIONAL };

typedef struct light {
    enum light_type type;
    vec3 v;             /* position (point) or direction the light travels (directional) */
    msbsdf_rgb power;   /* intensity W/sr (point) or irradiance (directional) */
} light;

enum env_kind { ENV_BLACK, ENV_CONSTANT, ENV_MAP };

/** Environment: constant, or an equirectangular map (HDR file or the procedural
    sky baked to a map) with luminance importance sampling. y is up. */
typedef struct envmap {
    enum env_kind kind;
    msbsdf_rgb constant;
    int w, h;
    float *rgb;         /* w * h * 3 */
    float *row_cdf;     /* h + 1 */
    float *col_cdf;     /* h * (w + 1) */
    float total;        /* sum of weights */
    float rotate;       /* radians about y */
} envmap;

enum shape_type { SHAPE_SPHERE, SHAPE_MESH };

typedef struct shape {
    enum shape_type type;
    int material;
    int line;
    vec3 center; /* sphere */
    float radius;
    /* triangle mesh, vertices not shared (3 per triangle) */
    int ntris;
    float *pos;  /* 9 per triangle */
    float *nrm;  /* 9 per triangle or NULL (flat shading) */
    float *uv;   /* 6 per triangle or NULL */
} shape;

typedef struct label {
    float x, y; /* fraction of the image size, top-left origin */
    float scale;
    char text[TEXT_LEN];
} label;

typedef struct camera {
    vec3 pos, look, up;
    float fov_deg;
} camera;

typedef struct scene {
    char path[PATH_LEN];
    camera cam;
    int width, height, spp, max_depth;
    uint64_t seed;
    float exposure;
    int tonemap; /* 0 = clamp, 1 = ACES filmic */
    int nee;     /* next-event estimation on (1) or off (0) */
    material *mats;
    int nmats;
    light *lights;
    int nlights;
    envmap env;
    shape *shapes;
    int nshapes;
    label *labels;
    int nlabels;
    RTCDevice device;
    RTCScene rtc;
} scene;

/* scene.c */
int scene_load(scene *s, const char *path, char *err, size_t errlen);
/* Creates every material handle; model_override < 0 keeps the scene's models.
   Returns 0 on success, 1 if a model is unsupported (err says where), 2 on other errors. */
int scene_create_materials(scene *s, int model_override, int fallback_on_override, char *err, size_t errlen);
void scene_destroy_materials(scene *s);
int scene_build_bvh(scene *s, char *err, size_t errlen);
void scene_free(scene *s);
const char *model_name(uint32_t model);
int model_from_name(const char *name); /* -1 if unknown */
vec3 env_dir_from_uv(const envmap *e, float u, float v);
msbsdf_rgb env_eval(const envmap *e, vec3 d);
/* Samples a direction; returns its radiance, the solid-angle pdf in *pdf. */
msbsdf_rgb env_sample(const envmap *e, float u1, float u2, vec3 *d, float *pdf);
float env_pdf(const envmap *e, vec3 d);
float texture_lookup(const texture *t, float u, float v);

/* obj.cpp */
typedef struct obj_mesh {
    int ntris;
    float *pos, *nrm, *uv; /* malloc'd, expanded per corner; nrm/uv may be NULL */
} obj_mesh;
#ifdef __cplusplus
extern "C" {
#endif
int obj_load(const char *path, obj_mesh *out, char *err, size_t errlen);
#ifdef __cplusplus
}
#endif

/* ----------------------------------------------------------------- render */

typedef struct render_opts {
    int threads;
    int spp;         /* 0: scene default */
    double seconds;  /* > 0: progressive until the time is spent (spp is then a cap) */
    int quiet;
    const char *tag; /* progress bar label */
} render_opts;

typedef struct render_stats {
    double seconds;
    long long samples; /* camera samples traced */
    int spp_done;
} render_stats;

/* render.c: fills img (w * h * 3 linear RGB, the mean over samples). */
int render(const scene *s, const render_opts *o, float *img, render_stats *stats);

/* image.c */
int write_pfm(const char *path, const float *img, int w, int h);
int write_png(const char *path, const float *img, int w, int h, float exposure, int tonemap);
void draw_text(float *img, int w, int h, int x, int y, int scale, const char *text,
               msbsdf_rgb color);
int load_texture(const char *path, texture *t, char *err, size_t errlen);
float *load_hdr(const char *path, int *w, int *h, char *err, size_t errlen);

#endif
