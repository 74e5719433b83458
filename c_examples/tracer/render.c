/*
 * The integrator: unidirectional path tracing with next-event estimation to
 * point, directional and environment lights, MIS (power heuristic) between
 * environment sampling and BSDF sampling, and Russian roulette; pthreads over
 * tiles. Every (pixel, sample) pair has its own PCG32 stream, so the image is
 * bit-identical for any thread count.
 *
 * The msbsdf calls are the integrator ones of 0.3: a msbsdf_context in
 * radiance mode (transmission through glass carries the 1/eta^2 factor),
 * msbsdf_eval_pdf for light samples (value and pdf in one call),
 * msbsdf_sample_with with the tracer's own uniforms (a per-pixel rotated R2
 * low-discrepancy sequence over the samples of the pixel at the first
 * bounce, the path's PCG32 stream after it), and no next-event estimation on
 * materials flagged MSBSDF_MATERIAL_SPECULAR (their eval is 0 everywhere).
 */
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "tracer.h"

#define TILE 16
#define RR_DEPTH 3

/* Per-thread scratch: caller-owned storage for materials whose roughness
   comes from a texture (msbsdf_material_init, no allocation per hit). */
typedef struct thread_ctx {
    void *storage;
    size_t size;
    long long init_failures;   /* per-hit msbsdf_material_init refusals */
    msbsdf_status init_status; /* the first refusal's status */
} thread_ctx;

/* Per-hit init refusals over all threads (reported after the render). */
static atomic_llong g_init_failures;
static atomic_uint g_init_status;

typedef struct hit {
    vec3 p, ng, ns, t, b; /* position, geometric normal, shading frame */
    float u, v;
    int material;
} hit;

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void onb(vec3 n, vec3 *t, vec3 *b) {
    /* Duff et al. 2017, "Building an orthonormal basis, revisited" */
    float sign = copysignf(1.0f, n.z);
    float a = -1.0f / (sign + n.z);
    float bb = n.x * n.y * a;
    *t = v3(1.0f + sign * n.x * n.x * a, sign * bb, -sign * n.x);
    *b = v3(bb, sign + n.y * n.y * a, -n.y);
}

static msbsdf_vec3 to_local(const hit *h, vec3 w) {
    msbsdf_vec3 r = {vdot(w, h->t), vdot(w, h->b), vdot(w, h->ns)};
    return r;
}

static vec3 to_world(const hit *h, msbsdf_vec3 w) {
    return vadd(vadd(vscale(h->t, w.x), vscale(h->b, w.y)), vscale(h->ns, w.z));
}

static float offset_eps(vec3 p) { return 1e-4f * (1.0f + vmaxabs(p)); }

static vec3 offset_origin(const hit *h, vec3 dir) {
    float e = offset_eps(h->p);
    return vadd(h->p, vscale(h->ng, vdot(dir, h->ng) > 0.0f ? e : -e));
}

static void init_ray(struct RTCRay *r, vec3 o, vec3 d, float tfar) {
    r->org_x = o.x, r->org_y = o.y, r->org_z = o.z;
    r->dir_x = d.x, r->dir_y = d.y, r->dir_z = d.z;
    r->tnear = 0.0f;
    r->tfar = tfar;
    r->time = 0.0f;
    r->mask = 0xFFFFFFFFu;
    r->id = 0;
    r->flags = 0;
}

static int occluded(const scene *s, vec3 o, vec3 d, float tfar) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRay r;
    init_ray(&r, o, d, tfar);
    rtcOccluded1(s->rtc, &ctx, &r);
    return r.tfar < 0.0f;
}

static int intersect(const scene *s, vec3 o, vec3 d, hit *h) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRayHit rh;
    init_ray(&rh.ray, o, d, INFINITY);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(s->rtc, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return 0;
    const shape *sh = &s->shapes[rh.hit.geomID];
    h->material = sh->material;
    vec3 p = vadd(o, vscale(d, rh.ray.tfar));
    if (sh->type == SHAPE_SPHERE) {
        vec3 n = vnorm(vsub(p, sh->center));
        h->p = vadd(sh->center, vscale(n, sh->radius)); /* reproject onto the sphere */
        h->ng = h->ns = n;
        h->u = 0.5f + atan2f(n.x, -n.z) / (2.0f * (float)M_PI);
        h->v = acosf(fmaxf(-1.0f, fminf(1.0f, n.y))) / (float)M_PI;
        /* tangent along increasing longitude (consistent anisotropy direction) */
        vec3 t = v3(-n.z, 0.0f, n.x);
        if (vlen(t) < 1e-6f) {
            onb(n, &h->t, &h->b);
        } else {
            h->t = vnorm(t);
            h->b = vcross(n, h->t);
        }
        return 1;
    }
    unsigned tri = rh.hit.primID;
    const float *q = sh->pos + 9 * (size_t)tri;
    vec3 p0 = v3(q[0], q[1], q[2]), p1 = v3(q[3], q[4], q[5]), p2 = v3(q[6], q[7], q[8]);
    float bu = rh.hit.u, bv = rh.hit.v, bw = 1.0f - bu - bv;
    h->p = vadd(vadd(vscale(p0, bw), vscale(p1, bu)), vscale(p2, bv));
    h->ng = vnorm(vcross(vsub(p1, p0), vsub(p2, p0)));
    if (sh->nrm) {
        const float *n = sh->nrm + 9 * (size_t)tri;
        vec3 ns = vadd(vadd(vscale(v3(n[0], n[1], n[2]), bw), vscale(v3(n[3], n[4], n[5]), bu)),
                       vscale(v3(n[6], n[7], n[8]), bv));
        h->ns = vnorm(ns);
        if (vdot(h->ns, h->ng) < 0.0f) h->ng = vscale(h->ng, -1.0f); /* normals define outside */
    } else {
        h->ns = h->ng;
    }
    if (sh->uv) {
        const float *t = sh->uv + 6 * (size_t)tri;
        h->u = bw * t[0] + bu * t[2] + bv * t[4];
        h->v = bw * t[1] + bu * t[3] + bv * t[5];
    } else {
        h->u = bu, h->v = bv;
    }
    onb(h->ns, &h->t, &h->b);
    return 1;
}

/* The material at a hit: the shared handle, or one built in thread storage
   with the roughness from the material's texture. A refused per-hit init
   (the texture maps outside what the model accepts) is counted and reported
   after the render; the path is then ended (NULL) rather than shaded with
   the untextured material. */
static const msbsdf_material *material_at(const scene *s, const hit *h, thread_ctx *tc) {
    const material *m = &s->mats[h->material];
    if (!m->rough.data) return m->handle;
    float t = texture_lookup(&m->rough, h->u, h->v);
    msbsdf_material_desc d = m->desc;
    d.model = m->used_model;
    if (m->inner >= 0) d.inner = s->mats[m->inner].handle;
    d.alpha_x = d.alpha_y = m->rough_lo + t * (m->rough_hi - m->rough_lo);
    msbsdf_material *out = NULL;
    msbsdf_status st = msbsdf_material_init(&d, tc->storage, tc->size, &out);
    if (st != MSBSDF_STATUS_OK) {
        if (tc->init_failures++ == 0) tc->init_status = st;
        return NULL;
    }
    return out;
}

static float power_heuristic(float a, float b) {
    float a2 = a * a, b2 = b * b;
    if (!(a2 + b2 > 0.0f) || !isfinite(a2 + b2)) return a >= b ? 1.0f : 0.0f;
    return a2 / (a2 + b2);
}

static int finite_rgb(msbsdf_rgb c) { return isfinite(c.r) && isfinite(c.g) && isfinite(c.b); }

/* The uniforms of the first bounce: the R2 sequence (Roberts 2018, the
   plastic-number generalisation of the golden ratio) over the samples of a
   pixel, rotated by a per-pixel offset (Cranley-Patterson), and a golden-
   ratio sequence for the lobe choice. */
typedef struct first_uniforms {
    float lobe, u1, u2;
} first_uniforms;

static float frac_d(double x) {
    double f = x - floor(x);
    return f < 1.0 ? (float)f : 0.0f;
}

static first_uniforms first_bounce_uniforms(uint64_t seed, uint64_t pix, int k) {
    msbsdf_rng r;
    first_uniforms u;
    msbsdf_rng_seed(&r, seed ^ 0x5851f42d4c957f2dull, pix); /* the pixel's rotation */
    double o0 = msbsdf_rng_next_float(&r), o1 = msbsdf_rng_next_float(&r), o2 = msbsdf_rng_next_float(&r);
    u.lobe = frac_d(o0 + 0.6180339887498949 * k);
    u.u1 = frac_d(o1 + 0.7548776662466927 * k);
    u.u2 = frac_d(o2 + 0.5698402909980532 * k);
    return u;
}

/* Radiance along a camera ray; `first` drives the first BSDF sample. */
static msbsdf_rgb trace(const scene *s, vec3 o, vec3 d, msbsdf_rng *rng, thread_ctx *tc, first_uniforms first) {
    msbsdf_rgb L = rgb(0, 0, 0), beta = rgb(1, 1, 1);
    float prev_pdf = 0.0f; /* 0: camera ray or specular bounce, no MIS */
    msbsdf_context ctx;
    msbsdf_context_init(&ctx);
    ctx.transport = MSBSDF_TRANSPORT_RADIANCE;
    ctx.rng = rng;
    for (int depth = 0;; depth++) {
        hit h;
        if (!intersect(s, o, d, &h)) {
            msbsdf_rgb le = env_eval(&s->env, d);
            float w = 1.0f;
            if (prev_pdf > 0.0f && s->nee && s->env.kind != ENV_BLACK)
                w = power_heuristic(prev_pdf, env_pdf(&s->env, d));
            L = rgb_add(L, rgb_scale(rgb_mul(beta, le), w));
            break;
        }
        if (depth >= s->max_depth) break;
        const msbsdf_material *m = material_at(s, &h, tc);
        if (!m) break;
        vec3 wi_w = vscale(d, -1.0f);
        msbsdf_vec3 wi = to_local(&h, wi_w);
        if (wi.z == 0.0f || vdot(wi_w, h.ng) * wi.z <= 0.0f) break; /* shading-normal leak */
        uint32_t mflags = 0;
        if (msbsdf_material_flags(m, &mflags) != MSBSDF_STATUS_OK) break;

        /* Specular materials: eval is 0 everywhere, a light sample adds nothing. */
        if (s->nee && !(mflags & MSBSDF_MATERIAL_SPECULAR)) {
            /* delta lights */
            for (int i = 0; i < s->nlights; i++) {
                const light *l = &s->lights[i];
                vec3 wl;
                float dist;
                msbsdf_rgb li;
                if (l->type == LIGHT_POINT) {
                    vec3 dl = vsub(l->v, h.p);
                    dist = vlen(dl);
                    if (dist <= 0.0f) continue;
                    wl = vscale(dl, 1.0f / dist);
                    li = rgb_scale(l->power, 1.0f / (dist * dist));
                } else {
                    wl = vscale(l->v, -1.0f);
                    dist = INFINITY;
                    li = l->power;
                }
                msbsdf_vec3 wo = to_local(&h, wl);
                if (wo.z == 0.0f || vdot(wl, h.ng) * wo.z <= 0.0f) continue;
                /* visibility first: the stochastic models' eval costs more than a shadow ray */
                vec3 org = offset_origin(&h, wl);
                float tfar = isfinite(dist) ? dist * (1.0f - 1e-4f) : INFINITY;
                if (occluded(s, org, wl, tfar)) continue;
                msbsdf_rgb f;
                if (msbsdf_eval_pdf(m, &ctx, wi, wo, &f, NULL) != MSBSDF_STATUS_OK || rgb_max(f) <= 0.0f) continue;
                L = rgb_add(L, rgb_mul(rgb_mul(beta, f), li));
            }
            /* environment, MIS with the BSDF: value and pdf in one call */
            if (s->env.kind != ENV_BLACK) {
                vec3 wl;
                float pl;
                float u1 = msbsdf_rng_next_float(rng), u2 = msbsdf_rng_next_float(rng);
                msbsdf_rgb le = env_sample(&s->env, u1, u2, &wl, &pl);
                msbsdf_vec3 wo = to_local(&h, wl);
                if (pl > 0.0f && rgb_max(le) > 0.0f && wo.z != 0.0f && vdot(wl, h.ng) * wo.z > 0.0f) {
                    msbsdf_rgb f;
                    float pb = 0.0f;
                    if (!occluded(s, offset_origin(&h, wl), wl, INFINITY) &&
                        msbsdf_eval_pdf(m, &ctx, wi, wo, &f, &pb) == MSBSDF_STATUS_OK && rgb_max(f) > 0.0f) {
                        float w = power_heuristic(pl, pb) / pl;
                        L = rgb_add(L, rgb_scale(rgb_mul(rgb_mul(beta, f), le), w));
                    }
                }
            }
        }

        msbsdf_sample_record sr;
        msbsdf_sample_record_init(&sr);
        first_uniforms u = first;
        if (depth > 0) {
            u.lobe = msbsdf_rng_next_float(rng);
            u.u1 = msbsdf_rng_next_float(rng);
            u.u2 = msbsdf_rng_next_float(rng);
        }
        if (msbsdf_sample_with(m, &ctx, wi, u.lobe, u.u1, u.u2, &sr) != MSBSDF_STATUS_OK) break;
        if ((sr.flags & MSBSDF_SAMPLE_ABSORBED) || !(sr.pdf > 0.0f) || rgb_max(sr.weight) <= 0.0f) break;
        vec3 wo_w = to_world(&h, sr.wo);
        if (vdot(wo_w, h.ng) * sr.wo.z <= 0.0f) break; /* shading-normal leak */
        beta = rgb_mul(beta, sr.weight);
        /* A Dirac lobe: its pdf is a probability, the next light hit takes full weight. */
        prev_pdf = (sr.flags & MSBSDF_SAMPLE_SPECULAR) ? 0.0f : sr.pdf;
        if (depth + 1 >= RR_DEPTH) {
            float q = fminf(rgb_max(beta), 0.95f);
            if (msbsdf_rng_next_float(rng) >= q) break;
            beta = rgb_scale(beta, 1.0f / q);
        }
        o = offset_origin(&h, wo_w);
        d = vnorm(wo_w);
    }
    if (!finite_rgb(L)) return rgb(0, 0, 0);
    return L;
}

/* ------------------------------------------------------------------ threads */

typedef struct job {
    const scene *s;
    float *img;           /* running sums */
    int ntx, nty, ntiles;
    int sample0, nsamples; /* samples [sample0, sample0 + nsamples) of this pass */
    atomic_int next_tile;
    atomic_int tiles_done;
    vec3 cam_o, cam_f, cam_r, cam_u;
    float tan_half;
    int failed;
} job;

static void render_tile(job *j, int tile, thread_ctx *tc) {
    const scene *s = j->s;
    int tx = tile % j->ntx, ty = tile / j->ntx;
    int x1 = (tx + 1) * TILE < s->width ? (tx + 1) * TILE : s->width;
    int y1 = (ty + 1) * TILE < s->height ? (ty + 1) * TILE : s->height;
    float aspect = (float)s->width / (float)s->height;
    for (int y = ty * TILE; y < y1; y++)
        for (int x = tx * TILE; x < x1; x++) {
            uint64_t pix = (uint64_t)y * (uint64_t)s->width + (uint64_t)x;
            float *acc = j->img + 3 * pix;
            for (int k = j->sample0; k < j->sample0 + j->nsamples; k++) {
                msbsdf_rng rng;
                /* one stream per (pixel, sample): independent of threads and tiles */
                msbsdf_rng_seed(&rng, s->seed, ((uint64_t)k << 32) | pix);
                float jx = msbsdf_rng_next_float(&rng), jy = msbsdf_rng_next_float(&rng);
                float px = (2.0f * ((float)x + jx) / (float)s->width - 1.0f) * aspect * j->tan_half;
                float py = (1.0f - 2.0f * ((float)y + jy) / (float)s->height) * j->tan_half;
                vec3 d = vnorm(vadd(j->cam_f, vadd(vscale(j->cam_r, px), vscale(j->cam_u, py))));
                msbsdf_rgb c = trace(s, j->cam_o, d, &rng, tc, first_bounce_uniforms(s->seed, pix, k));
                acc[0] += c.r;
                acc[1] += c.g;
                acc[2] += c.b;
            }
        }
}

static void *worker(void *arg) {
    job *j = arg;
    thread_ctx tc;
    tc.size = msbsdf_material_size();
    size_t al = msbsdf_material_align();
    if (al < sizeof(void *)) al = sizeof(void *);
    tc.size = (tc.size + al - 1) / al * al;
    tc.storage = aligned_alloc(al, tc.size);
    tc.init_failures = 0;
    tc.init_status = MSBSDF_STATUS_OK;
    if (!tc.storage) {
        j->failed = 1;
        return NULL;
    }
    for (;;) {
        int t = atomic_fetch_add(&j->next_tile, 1);
        if (t >= j->ntiles) break;
        render_tile(j, t, &tc);
        atomic_fetch_add(&j->tiles_done, 1);
    }
    if (tc.init_failures > 0) {
        unsigned expected = MSBSDF_STATUS_OK;
        atomic_compare_exchange_strong(&g_init_status, &expected, (unsigned)tc.init_status);
        atomic_fetch_add(&g_init_failures, tc.init_failures);
    }
    free(tc.storage);
    return NULL;
}

static void progress(const char *tag, double frac, double elapsed, double eta) {
    int width = 30, fill = (int)(frac * width + 0.5);
    char bar[64];
    for (int i = 0; i < width; i++) bar[i] = i < fill ? '#' : '.';
    bar[width] = '\0';
    fprintf(stderr, "\r%-22.22s [%s] %5.1f%%  %6.1fs  ETA %6.1fs ", tag, bar, 100.0 * frac, elapsed, eta);
    fflush(stderr);
}

int render(const scene *s, const render_opts *o, float *img, render_stats *stats) {
    int nthreads = o->threads > 0 ? o->threads : 1;
    int spp = o->spp > 0 ? o->spp : s->spp;
    int cap = o->seconds > 0.0 ? (o->spp > 0 ? o->spp : 1 << 20) : spp;
    size_t npix = (size_t)s->width * (size_t)s->height;
    memset(img, 0, sizeof(float) * 3 * npix);

    job *j = calloc(1, sizeof *j);
    pthread_t *th = calloc((size_t)nthreads, sizeof *th);
    if (!j || !th) {
        free(j), free(th);
        return -1;
    }
    j->s = s;
    j->img = img;
    j->ntx = (s->width + TILE - 1) / TILE;
    j->nty = (s->height + TILE - 1) / TILE;
    j->ntiles = j->ntx * j->nty;
    j->cam_o = s->cam.pos;
    j->cam_f = vnorm(vsub(s->cam.look, s->cam.pos));
    j->cam_r = vnorm(vcross(j->cam_f, s->cam.up));
    j->cam_u = vcross(j->cam_r, j->cam_f);
    j->tan_half = tanf(0.5f * s->cam.fov_deg * (float)M_PI / 180.0f);

    double t0 = now(), last_print = -1.0;
    int done = 0;
    /* passes of a few samples per pixel; with --seconds the pass size adapts */
    int batch = o->seconds > 0.0 ? 1 : (spp < 4 ? spp : 4);
    int rc = 0;
    while (done < cap) {
        int n = batch < cap - done ? batch : cap - done;
        j->sample0 = done;
        j->nsamples = n;
        atomic_store(&j->next_tile, 0);
        atomic_store(&j->tiles_done, 0);
        double tp = now();
        for (int i = 0; i < nthreads; i++)
            if (pthread_create(&th[i], NULL, worker, j)) {
                nthreads = i;
                rc = -1;
                break;
            }
        while (!o->quiet && atomic_load(&j->tiles_done) < j->ntiles && rc == 0) {
            double el = now() - t0;
            double frac;
            if (o->seconds > 0.0)
                frac = fmin(1.0, el / o->seconds);
            else
                frac = ((double)done + (double)n * atomic_load(&j->tiles_done) / j->ntiles) / spp;
            double eta = o->seconds > 0.0 ? fmax(0.0, o->seconds - el) : (frac > 0 ? el / frac - el : 0.0);
            if (el - last_print >= 0.25) {
                progress(o->tag ? o->tag : "render", frac, el, eta);
                last_print = el;
            }
            struct timespec ts = {0, 5 * 1000 * 1000};
            nanosleep(&ts, NULL);
        }
        for (int i = 0; i < nthreads; i++) pthread_join(th[i], NULL);
        if (rc || j->failed) {
            rc = -1;
            break;
        }
        done += n;
        if (o->seconds > 0.0) {
            double el = now() - t0, pass = now() - tp;
            double left = o->seconds - el;
            if (left <= 0.0) break;
            /* grow the batch so each pass takes about a quarter of the remaining time */
            double per = pass / n;
            int want = (int)(0.25 * left / fmax(per, 1e-9));
            batch = want < 1 ? 1 : (want > 64 ? 64 : want);
            if (per * batch > left) batch = (int)(left / fmax(per, 1e-9));
            if (batch < 1) break;
        }
    }
    double el = now() - t0;
    if (!o->quiet) {
        progress(o->tag ? o->tag : "render", 1.0, el, 0.0);
        fprintf(stderr, "\n");
    }
    long long failures = atomic_exchange(&g_init_failures, 0);
    unsigned first_status = atomic_exchange(&g_init_status, MSBSDF_STATUS_OK);
    if (failures > 0)
        fprintf(stderr,
                "warning: %lld hits could not build their textured material (msbsdf_material_init: %s); "
                "those paths were ended\n",
                failures, msbsdf_status_message(first_status));
    float inv = done > 0 ? 1.0f / (float)done : 0.0f;
    for (size_t i = 0; i < 3 * npix; i++) img[i] *= inv;
    stats->seconds = el;
    stats->spp_done = done;
    stats->samples = (long long)done * (long long)npix;
    free(j);
    free(th);
    return rc;
}
