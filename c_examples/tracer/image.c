/*
 * Image output (PFM, tone-mapped sRGB PNG), loading (HDR maps, roughness
 * textures) and text labels drawn with stb_easy_font.
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "tracer.h"

/* Third-party single-header libraries: compiled here, their own warnings off. */
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wimplicit-fallthrough"
#pragma GCC diagnostic ignored "-Wdouble-promotion"
#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_PNG
#define STBI_ONLY_HDR
#define STBI_ONLY_JPEG
#define STBI_ONLY_PNM
#include <stb/stb_image.h>
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>
#include <stb/stb_easy_font.h>
#pragma GCC diagnostic pop

int write_pfm(const char *path, const float *img, int w, int h) {
    FILE *f = fopen(path, "wb");
    if (!f) return -1;
    fprintf(f, "PF\n%d %d\n-1.0\n", w, h); /* negative scale: little endian */
    int ok = 1;
    for (int y = h - 1; y >= 0 && ok; y--) /* PFM rows go bottom to top */
        ok = fwrite(img + 3 * (size_t)y * (size_t)w, sizeof(float), 3 * (size_t)w, f) == 3 * (size_t)w;
    if (fclose(f) != 0) ok = 0;
    return ok ? 0 : -1;
}

static float aces(float x) {
    /* Narkowicz 2015 fit of the ACES filmic curve */
    float v = (x * (2.51f * x + 0.03f)) / (x * (2.43f * x + 0.59f) + 0.14f);
    return v < 0.0f ? 0.0f : (v > 1.0f ? 1.0f : v);
}

static unsigned char to_srgb8(float v) {
    v = v < 0.0f ? 0.0f : (v > 1.0f ? 1.0f : v);
    float s = v <= 0.0031308f ? 12.92f * v : 1.055f * powf(v, 1.0f / 2.4f) - 0.055f;
    return (unsigned char)(s * 255.0f + 0.5f);
}

int write_png(const char *path, const float *img, int w, int h, float exposure, int tonemap) {
    unsigned char *px = malloc((size_t)w * (size_t)h * 3);
    if (!px) return -1;
    for (size_t i = 0; i < (size_t)w * (size_t)h * 3; i++) {
        float v = img[i] * exposure;
        px[i] = to_srgb8(tonemap ? aces(v) : v);
    }
    int ok = stbi_write_png(path, w, h, 3, px, w * 3);
    free(px);
    return ok ? 0 : -1;
}

static void fill_rect(float *img, int w, int h, int x0, int y0, int x1, int y1, msbsdf_rgb c, float a) {
    for (int y = y0 < 0 ? 0 : y0; y < y1 && y < h; y++)
        for (int x = x0 < 0 ? 0 : x0; x < x1 && x < w; x++) {
            float *p = img + 3 * ((size_t)y * (size_t)w + (size_t)x);
            p[0] = p[0] * (1.0f - a) + c.r * a;
            p[1] = p[1] * (1.0f - a) + c.g * a;
            p[2] = p[2] * (1.0f - a) + c.b * a;
        }
}

/* Draws text into a linear float image (values are written so that they read
   as the given colour after tone mapping at exposure 1 is roughly neutral). */
void draw_text(float *img, int w, int h, int x, int y, int scale, const char *text, msbsdf_rgb color) {
    static char buf[64 * 1024]; /* ~270 bytes per character */
    char tmp[TEXT_LEN];
    snprintf(tmp, sizeof tmp, "%s", text);
    int tw = stb_easy_font_width(tmp) * scale, th = stb_easy_font_height(tmp) * scale;
    fill_rect(img, w, h, x - 2, y - 2, x + tw + 2, y + th + 1, rgb(0, 0, 0), 0.75f);
    int quads = stb_easy_font_print(0.0f, 0.0f, tmp, NULL, buf, (int)sizeof buf);
    for (int q = 0; q < quads; q++) {
        const float *v0 = (const float *)(buf + 64 * q);      /* 4 vertices of 16 bytes */
        const float *v2 = (const float *)(buf + 64 * q + 32);
        int x0 = x + (int)(v0[0] * (float)scale), y0 = y + (int)(v0[1] * (float)scale);
        int x1 = x + (int)(v2[0] * (float)scale), y1 = y + (int)(v2[1] * (float)scale);
        fill_rect(img, w, h, x0, y0, x1, y1, color, 1.0f);
    }
}

int load_texture(const char *path, texture *t, char *err, size_t errlen) {
    int n;
    errno = 0;
    unsigned char *d = stbi_load(path, &t->w, &t->h, &n, 1);
    if (!d) {
        snprintf(err, errlen, "cannot load texture '%s': %s", path,
                 errno ? strerror(errno) : stbi_failure_reason());
        return -1;
    }
    t->data = malloc(sizeof(float) * (size_t)t->w * (size_t)t->h);
    if (!t->data) {
        stbi_image_free(d);
        snprintf(err, errlen, "out of memory");
        return -1;
    }
    for (size_t i = 0; i < (size_t)t->w * (size_t)t->h; i++) t->data[i] = (float)d[i] / 255.0f;
    stbi_image_free(d);
    return 0;
}

float *load_hdr(const char *path, int *w, int *h, char *err, size_t errlen) {
    int n;
    errno = 0;
    FILE *f = fopen(path, "rb");
    if (!f) {
        snprintf(err, errlen, "cannot open HDR map '%s': %s", path, strerror(errno));
        return NULL;
    }
    float *d = stbi_loadf_from_file(f, w, h, &n, 3);
    fclose(f);
    if (!d) {
        snprintf(err, errlen, "cannot decode HDR map '%s': %s", path, stbi_failure_reason());
        return NULL;
    }
    /* copy into malloc'd memory so that free() is the only deallocator */
    float *out = malloc(sizeof(float) * 3 * (size_t)*w * (size_t)*h);
    if (out) memcpy(out, d, sizeof(float) * 3 * (size_t)*w * (size_t)*h);
    stbi_image_free(d);
    for (size_t i = 0; out && i < 3 * (size_t)*w * (size_t)*h; i++)
        if (!isfinite(out[i]) || out[i] < 0.0f) out[i] = 0.0f;
    if (!out) snprintf(err, errlen, "out of memory");
    return out;
}
