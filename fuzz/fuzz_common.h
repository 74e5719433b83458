/*
 * Shared helpers of the msbsdf fuzz harnesses (fuzz/desc_fuzz.c,
 * fuzz/dirs_fuzz.c): a byte reader that never reads past the input, float
 * decoders that favour edge cases (NaN, +-Inf, +-0, subnormals, FLT_MAX,
 * values around the validation limits), and the output contract of
 * DESIGN.md section 2 as assertions that abort() (so libFuzzer and the
 * corpus replay both see a crash).
 */
#ifndef MSBSDF_FUZZ_COMMON_H
#define MSBSDF_FUZZ_COMMON_H

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "msbsdf.h"

typedef struct fuzz_reader {
    const uint8_t *p;
    size_t n;
} fuzz_reader;

static uint8_t fz_u8(fuzz_reader *r)
{
    uint8_t b = 0;
    if (r->n > 0) {
        b = r->p[0];
        r->p++;
        r->n--;
    }
    return b;
}

static uint32_t fz_u32(fuzz_reader *r)
{
    uint32_t v = 0;
    int i;
    for (i = 0; i < 4; i++) {
        v |= (uint32_t)fz_u8(r) << (8 * i);
    }
    return v;
}

/* Reads are sequenced in separate statements: the evaluation order of
   function arguments and of `a | b` operands is unspecified, and gcc (the
   corpus replay) and clang (libFuzzer) pick different orders. */
static inline uint16_t fz_u16(fuzz_reader *r)
{
    uint16_t lo = fz_u8(r);
    return (uint16_t)(lo | (uint16_t)(fz_u8(r) << 8));
}

static void fz_seed(fuzz_reader *r, msbsdf_rng *rng)
{
    uint64_t seed = fz_u32(r);
    uint64_t stream = fz_u32(r);
    msbsdf_rng_seed(rng, seed, stream);
}

static float fz_bits(uint32_t u)
{
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

/* Values at and around every limit the library checks. */
static float fz_special(uint8_t i)
{
    static const float table[] = {
        0.0f, -0.0f, 1.0f, -1.0f, 0.5f, 1e-4f, 9.9e-5f, 1e-45f, 1.17549435e-38f,
        1e-20f, 10.0f, 10.0001f, 1.5f, 1.5000001f, 2.0f, 1e30f, FLT_MAX, -FLT_MAX,
        1e-7f, 0.999999f, 1.000001f, 3.0f, 100.0f, -1e-45f, 0.0f, 0.0f, 0.0f, 0.0f,
    };
    const size_t n = sizeof table / sizeof table[0];
    if (i % 32 == 28) {
        return NAN;
    }
    if (i % 32 == 29) {
        return -NAN;
    }
    if (i % 32 == 30) {
        return INFINITY;
    }
    if (i % 32 == 31) {
        return -INFINITY;
    }
    return table[(size_t)(i % 32) % n];
}

/* A float: a mode byte picks an edge value, raw bits, or an ordinary value
   in [lo, hi] (16-bit resolution). */
static float fz_float(fuzz_reader *r, float lo, float hi)
{
    uint8_t mode = fz_u8(r);
    switch (mode & 3u) {
    case 0:
        return fz_special(fz_u8(r));
    case 1:
        return fz_bits(fz_u32(r));
    default: {
        uint32_t u = fz_u8(r);
        u |= (uint32_t)fz_u8(r) << 8;
        return lo + (hi - lo) * ((float)u / 65535.0f);
    }
    }
}

static msbsdf_vec3 fz_dir(fuzz_reader *r)
{
    msbsdf_vec3 v;
    v.x = fz_float(r, -1.0f, 1.0f);
    v.y = fz_float(r, -1.0f, 1.0f);
    v.z = fz_float(r, -1.0f, 1.0f);
    return v;
}

#define FZ_ASSERT(cond, ...)                                                        \
    do {                                                                            \
        if (!(cond)) {                                                              \
            fprintf(stderr, "FUZZ CONTRACT VIOLATION %s:%d: %s: ", __FILE__, __LINE__, \
                    #cond);                                                         \
            fprintf(stderr, __VA_ARGS__);                                           \
            fputc('\n', stderr);                                                    \
            abort();                                                                \
        }                                                                           \
    } while (0)

static int fz_ok_value(float x)
{
    return isfinite(x) && x >= 0.0f;
}

/* Statuses a query may return for a live material: never PANIC, never an
   unknown value. */
static int fz_query_status(msbsdf_status s)
{
    return s == MSBSDF_STATUS_OK || s == MSBSDF_STATUS_NULL_POINTER ||
           s == MSBSDF_STATUS_INVALID_DIRECTION;
}

static int fz_dir_valid(msbsdf_vec3 v)
{
    return isfinite(v.x) && isfinite(v.y) && isfinite(v.z) &&
           (v.x != 0.0f || v.y != 0.0f || v.z != 0.0f);
}

/* Set by the harness: the material's model has an exact pdf (SINGLE,
   ENERGY_COMPENSATED, TABULATED), so sample's pdf must equal msbsdf_pdf of
   its wo. */
static int fz_exact_pdf;

/* Set by the harness: dielectric facets with |eta - 1| * alpha < 1e-5
   (alpha as in fz_alpha_min). At eta = 1 the refracted lobe is a Dirac
   delta straight through (src/single.rs:
   "index-matched: a Dirac lobe, no density"): sample reports pdf 0 for it and
   msbsdf_pdf is 0 there (or, a float rounding away from exactly straight
   through, a huge finite value), so neither pdf rule below applies. Near
   eta = 1 the generalised half vector -(wi + eta wo) of a pair close to
   straight through has length ~|eta - 1|, so float rounding (~1e-7) turns it
   by ~1e-7 / |eta - 1|: unresolved against alpha when |eta - 1| * alpha is
   below 1e-5 (found: eta 1.00002 at alpha 1e-4 gave pdf 0 where sample
   went). */
static int fz_index_matched;

/* Set by the harness: the smaller roughness of the material (values below
   1e-4 act as 1e-4). A unit vector in float resolves a direction to ~6e-8
   per component, so the half vector pdf rebuilds from a sampled (wi, wo)
   pair is off by ~1e-7 / (|wi.z| + |wo.z|) radians; when that is not small
   against alpha (grazing pairs on a near-mirror surface, e.g. wi.z = 1e-4
   with alpha = 1e-4), pdf can land outside the lobe and return 0 although
   sample just went there, or differ from the pdf sample reports (computed
   from the sampled normal itself). These two rules are checked only where the
   float directions resolve the lobe to ~0.1% of alpha: (|wi.z| + |wo.z|) *
   alpha >= 1e-4; the pdf agreement is then asked within 5%. */
static float fz_alpha_min = 1.0f;

static void fz_set_alpha(float ax, float ay)
{
    float a = fminf(ax, ay);
    fz_alpha_min = a > 1e-4f ? a : 1e-4f;
}

static int fz_model_has_exact_pdf(uint32_t model)
{
    return model == MSBSDF_MODEL_SINGLE || model == MSBSDF_MODEL_ENERGY_COMPENSATED ||
           model == MSBSDF_MODEL_TABULATED;
}

/* eval, pdf and sample of `m` at (wi, wo) with the output contract. */
static void fz_query(const msbsdf_material *m, msbsdf_vec3 wi, msbsdf_vec3 wo, msbsdf_rng *rng)
{
    msbsdf_rgb f;
    float p = -1.0f;
    msbsdf_sample_result s;
    msbsdf_status st;
    const int valid = fz_dir_valid(wi) && fz_dir_valid(wo);
    uint32_t mflags = 0;
    int specular;

    st = msbsdf_material_flags(m, &mflags);
    FZ_ASSERT(st == MSBSDF_STATUS_OK && (mflags & MSBSDF_MATERIAL_REFLECTION) &&
                  !(mflags & ~127u) && !(mflags & MSBSDF_MATERIAL_SPECULAR) == !!(mflags & MSBSDF_MATERIAL_GLOSSY),
              "material flags %u (status %u)", (unsigned)mflags, (unsigned)st);
    specular = (mflags & MSBSDF_MATERIAL_SPECULAR) != 0;

    memset(&f, 0xff, sizeof f);
    st = msbsdf_eval(m, wi, wo, rng, &f);
    FZ_ASSERT(fz_query_status(st), "eval status %u", (unsigned)st);
    FZ_ASSERT(fz_ok_value(f.r) && fz_ok_value(f.g) && fz_ok_value(f.b), "eval (%g %g %g)",
              f.r, f.g, f.b);
    if (st != MSBSDF_STATUS_OK) {
        FZ_ASSERT(f.r == 0.0f && f.g == 0.0f && f.b == 0.0f, "eval failure output not zero");
    }
    if (st == MSBSDF_STATUS_INVALID_DIRECTION) {
        FZ_ASSERT(!valid, "eval refused valid directions");
    }
    if (valid && rng != NULL) {
        FZ_ASSERT(st == MSBSDF_STATUS_OK, "eval status %u on valid input", (unsigned)st);
    }

    st = msbsdf_pdf(m, wi, wo, &p);
    FZ_ASSERT(st == MSBSDF_STATUS_OK || st == MSBSDF_STATUS_INVALID_DIRECTION,
              "pdf status %u", (unsigned)st);
    FZ_ASSERT((st == MSBSDF_STATUS_OK) == valid, "pdf status %u, valid %d", (unsigned)st, valid);
    FZ_ASSERT(fz_ok_value(p), "pdf %g", p);
    if (st != MSBSDF_STATUS_OK) {
        FZ_ASSERT(p == 0.0f, "pdf failure output not zero");
    }

    if (rng == NULL) {
        return;
    }
    memset(&s, 0xff, sizeof s);
    st = msbsdf_sample(m, wi, rng, &s);
    FZ_ASSERT(st == MSBSDF_STATUS_OK || st == MSBSDF_STATUS_INVALID_DIRECTION,
              "sample status %u", (unsigned)st);
    FZ_ASSERT((st == MSBSDF_STATUS_OK) == fz_dir_valid(wi), "sample status %u", (unsigned)st);
    FZ_ASSERT(fz_ok_value(s.weight.r) && fz_ok_value(s.weight.g) && fz_ok_value(s.weight.b),
              "sample weight (%g %g %g)", s.weight.r, s.weight.g, s.weight.b);
    FZ_ASSERT(fz_ok_value(s.pdf), "sample pdf %g", s.pdf);
    FZ_ASSERT(isfinite(s.wo.x) && isfinite(s.wo.y) && isfinite(s.wo.z), "sample wo not finite");
    if (st != MSBSDF_STATUS_OK) {
        FZ_ASSERT(s.flags == 0 && s.pdf == 0.0f && s.weight.r == 0.0f && s.wo.z == 0.0f,
                  "sample failure output not zero");
        return;
    }
    FZ_ASSERT(s.flags == MSBSDF_SAMPLE_REFLECTION || s.flags == MSBSDF_SAMPLE_TRANSMISSION ||
                  s.flags == MSBSDF_SAMPLE_ABSORBED,
              "sample flags %u", (unsigned)s.flags);
    if (s.flags == MSBSDF_SAMPLE_ABSORBED) {
        FZ_ASSERT(s.weight.r == 0.0f && s.weight.g == 0.0f && s.weight.b == 0.0f,
                  "absorbed sample with weight (%g %g %g)", s.weight.r, s.weight.g,
                  s.weight.b);
    } else {
        float len = sqrtf(s.wo.x * s.wo.x + s.wo.y * s.wo.y + s.wo.z * s.wo.z);
        FZ_ASSERT(fabsf(len - 1.0f) < 1e-3f, "sampled wo has length %g", len);
        /* Feed the sample back: eval and pdf of what sample produced. */
        st = msbsdf_eval(m, wi, s.wo, rng, &f);
        FZ_ASSERT(st == MSBSDF_STATUS_OK, "eval of sampled wo: status %u", (unsigned)st);
        FZ_ASSERT(fz_ok_value(f.r) && fz_ok_value(f.g) && fz_ok_value(f.b),
                  "eval of sampled wo (%g %g %g)", f.r, f.g, f.b);
        st = msbsdf_pdf(m, wi, s.wo, &p);
        FZ_ASSERT(st == MSBSDF_STATUS_OK && fz_ok_value(p), "pdf of sampled wo %g", p);
        if (specular) {
            /* Dirac lobes: no density anywhere; pdf is the lobe probability. */
            FZ_ASSERT(f.r == 0.0f && f.g == 0.0f && f.b == 0.0f && p == 0.0f,
                      "specular material: eval (%g %g %g) pdf %g off a Dirac lobe", f.r, f.g, f.b, p);
            FZ_ASSERT(s.pdf > 0.0f && s.pdf <= 1.0f, "specular sample pdf %g", s.pdf);
            return;
        }
        /* DESIGN.md: pdf is positive wherever sample can go. */
        /* Flags agree with the sides of wi and wo. */
        if (s.flags == MSBSDF_SAMPLE_REFLECTION) {
            FZ_ASSERT((wi.z > 0.0f) == (s.wo.z > 0.0f), "reflection flag, wi.z %g wo.z %g", wi.z,
                      s.wo.z);
        } else {
            FZ_ASSERT((wi.z > 0.0f) != (s.wo.z > 0.0f), "transmission flag, wi.z %g wo.z %g",
                      wi.z, s.wo.z);
        }
        double wlen = sqrt((double)wi.x * wi.x + (double)wi.y * wi.y + (double)wi.z * wi.z);
        double zsum = fabs((double)wi.z) / wlen + fabs((double)s.wo.z);
        int resolved = zsum * fz_alpha_min >= 1e-4;
        if (s.weight.r + s.weight.g + s.weight.b > 0.0f && !fz_index_matched && resolved) {
            FZ_ASSERT(p > 0.0f, "sample reached wo (%g %g %g) from wi (%g %g %g) with weight "
                      "(%g %g %g) but pdf there is 0", s.wo.x, s.wo.y, s.wo.z, wi.x, wi.y, wi.z,
                      s.weight.r, s.weight.g, s.weight.b);
        }
        if (fz_exact_pdf && resolved && !fz_index_matched && p < 1e6f && s.pdf < 1e6f) {
            FZ_ASSERT(fabsf(p - s.pdf) <= 5e-2f * fmaxf(1.0f, fmaxf(p, s.pdf)),
                      "sample pdf %g but msbsdf_pdf %g at wo (%g %g %g) from wi (%g %g %g)",
                      s.pdf, p, s.wo.x, s.wo.y, s.wo.z, wi.x, wi.y, wi.z);
        }
    }
}

/* The context calls of 0.3 at (wi, wo), with a context and uniforms read
   from the input: statuses, finite non-negative outputs, eval_pdf equal to
   eval and pdf under importance transport with both lobes, a sample record
   whose flags, eta and lobe agree with the context. */
static void fz_query_ctx(const msbsdf_material *m, msbsdf_vec3 wi, msbsdf_vec3 wo, msbsdf_rng *rng,
                         fuzz_reader *r)
{
    msbsdf_context ctx;
    msbsdf_sample_record rec;
    msbsdf_rgb f, f0;
    float p = -1.0f, p0 = -1.0f, u0, u1, u2;
    msbsdf_status st;
    msbsdf_rng a, b;
    uint8_t mode = fz_u8(r);
    const int valid = fz_dir_valid(wi) && fz_dir_valid(wo);
    uint32_t mflags = 0;
    int ctx_ok;

    msbsdf_material_flags(m, &mflags);
    msbsdf_context_init(&ctx);
    ctx.transport = (mode & 1u) ? MSBSDF_TRANSPORT_IMPORTANCE : MSBSDF_TRANSPORT_RADIANCE;
    ctx.lobes = (uint32_t)((mode >> 1) & 3u);
    if (mode & 0x80u) {
        ctx.lobes = fz_u32(r); /* mostly unknown bits */
    }
    ctx.rng = rng;
    ctx_ok = (ctx.lobes & ~3u) == 0;
    u0 = fz_float(r, 0.0f, 1.0f);
    u1 = fz_float(r, 0.0f, 1.0f);
    u2 = fz_float(r, 0.0f, 1.0f);

    /* eval_pdf under importance + both lobes is eval and pdf, bit for bit. */
    if (rng != NULL) {
        msbsdf_context plain;
        msbsdf_context_init(&plain);
        plain.transport = MSBSDF_TRANSPORT_IMPORTANCE;
        a = *rng;
        b = *rng;
        plain.rng = &b;
        st = msbsdf_eval_pdf(m, &plain, wi, wo, &f, &p);
        FZ_ASSERT(st == MSBSDF_STATUS_OK || st == MSBSDF_STATUS_INVALID_DIRECTION, "eval_pdf status %u",
                  (unsigned)st);
        FZ_ASSERT((st == MSBSDF_STATUS_OK) == valid, "eval_pdf status %u, valid %d", (unsigned)st, valid);
        msbsdf_eval(m, wi, wo, &a, &f0);
        msbsdf_pdf(m, wi, wo, &p0);
        FZ_ASSERT(memcmp(&f, &f0, sizeof f) == 0 && memcmp(&p, &p0, sizeof p) == 0 &&
                      memcmp(&a, &b, sizeof a) == 0,
                  "eval_pdf (%g %g %g, %g) != eval, pdf (%g %g %g, %g)", f.r, f.g, f.b, p, f0.r, f0.g, f0.b,
                  p0);
        *rng = a;
    }

    memset(&f, 0xff, sizeof f);
    st = msbsdf_eval_pdf(m, &ctx, wi, wo, &f, &p);
    FZ_ASSERT(fz_query_status(st) || st == MSBSDF_STATUS_UNKNOWN_CONSTANT, "eval_pdf status %u",
              (unsigned)st);
    FZ_ASSERT(fz_ok_value(f.r) && fz_ok_value(f.g) && fz_ok_value(f.b) && fz_ok_value(p),
              "eval_pdf (%g %g %g) pdf %g", f.r, f.g, f.b, p);
    if (st != MSBSDF_STATUS_OK) {
        FZ_ASSERT(f.r == 0.0f && f.g == 0.0f && f.b == 0.0f && p == 0.0f, "eval_pdf failure output not zero");
    } else if (ctx.lobes == 0) {
        FZ_ASSERT(f.r == 0.0f && p == 0.0f, "no lobe allowed but eval_pdf (%g, %g)", f.r, p);
    }
    if (!ctx_ok) {
        FZ_ASSERT(st == MSBSDF_STATUS_UNKNOWN_CONSTANT, "lobes %u accepted", (unsigned)ctx.lobes);
    }

    msbsdf_sample_record_init(&rec);
    st = msbsdf_sample_with(m, &ctx, wi, u0, u1, u2, &rec);
    FZ_ASSERT(fz_query_status(st) || st == MSBSDF_STATUS_UNKNOWN_CONSTANT, "sample_with status %u",
              (unsigned)st);
    FZ_ASSERT(rec.struct_size == sizeof rec, "sample_with changed struct_size to %u", (unsigned)rec.struct_size);
    FZ_ASSERT(fz_ok_value(rec.weight.r) && fz_ok_value(rec.weight.g) && fz_ok_value(rec.weight.b) &&
                  fz_ok_value(rec.pdf) && fz_ok_value(rec.eta),
              "sample_with weight (%g %g %g) pdf %g eta %g", rec.weight.r, rec.weight.g, rec.weight.b, rec.pdf,
              rec.eta);
    if (st != MSBSDF_STATUS_OK) {
        FZ_ASSERT(rec.flags == 0 && rec.pdf == 0.0f && rec.weight.g == 0.0f, "sample_with failure output not zero");
        return;
    }
    FZ_ASSERT(fz_dir_valid(wi) && ctx_ok, "sample_with accepted an invalid wi or context");
    if (rec.flags == MSBSDF_SAMPLE_ABSORBED) {
        FZ_ASSERT(rec.weight.r == 0.0f && rec.weight.g == 0.0f && rec.weight.b == 0.0f && rec.eta == 1.0f,
                  "absorbed record with weight (%g %g %g) eta %g", rec.weight.r, rec.weight.g, rec.weight.b,
                  rec.eta);
        return;
    }
    {
        uint32_t lobe = rec.flags & 3u, kind = rec.flags & ~3u;
        FZ_ASSERT((lobe == MSBSDF_SAMPLE_REFLECTION || lobe == MSBSDF_SAMPLE_TRANSMISSION) &&
                      (lobe & ctx.lobes) != 0,
                  "record flags %u with lobes %u", (unsigned)rec.flags, (unsigned)ctx.lobes);
        FZ_ASSERT(kind == ((mflags & MSBSDF_MATERIAL_SPECULAR) ? MSBSDF_SAMPLE_SPECULAR : MSBSDF_SAMPLE_GLOSSY),
                  "record flags %u, material flags %u", (unsigned)rec.flags, (unsigned)mflags);
        FZ_ASSERT(lobe == MSBSDF_SAMPLE_TRANSMISSION ? rec.eta > 0.0f : rec.eta == 1.0f, "record eta %g",
                  rec.eta);
        FZ_ASSERT(lobe == MSBSDF_SAMPLE_REFLECTION || (mflags & MSBSDF_MATERIAL_TRANSMISSION),
                  "an opaque material transmitted");
    }
}

#endif
