/*
 * Status and output rules of every function of the C ABI (DESIGN.md section 2,
 * "Status, not crashes"): NULL pointers, NaN / Inf / zero-length directions,
 * unknown constants, a struct_size too small and out-of-range parameters are
 * refused with the documented status, outputs are zeroed (or *out NULL), and
 * nothing else is written. Valid calls give finite, non-negative values.
 */
#define _DEFAULT_SOURCE /* mmap / MAP_ANONYMOUS for the guard-page test */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "check.h"

#define CANARY 0xA5

static msbsdf_vec3 v3(float x, float y, float z)
{
    msbsdf_vec3 v;
    v.x = x;
    v.y = y;
    v.z = z;
    return v;
}

static msbsdf_rgb rgb(float r, float g, float b)
{
    msbsdf_rgb c;
    c.r = r;
    c.g = g;
    c.b = b;
    return c;
}

/* Rough gold, GGX alpha 0.5. */
static msbsdf_material_desc gold_desc(void)
{
    msbsdf_material_desc d = msbsdf_material_desc_default();
    d.model = MSBSDF_MODEL_SINGLE;
    d.ndf = MSBSDF_NDF_GGX;
    d.facet = MSBSDF_FACET_CONDUCTOR;
    d.alpha_x = d.alpha_y = 0.5f;
    d.eta = rgb(0.143f, 0.374f, 1.442f);
    d.k = rgb(3.983f, 2.385f, 1.603f);
    return d;
}

/* Rough glass, Beckmann alpha 0.3, eta 1.5. */
static msbsdf_material_desc glass_desc(void)
{
    msbsdf_material_desc d = msbsdf_material_desc_default();
    d.model = MSBSDF_MODEL_SINGLE;
    d.ndf = MSBSDF_NDF_BECKMANN;
    d.facet = MSBSDF_FACET_DIELECTRIC;
    d.alpha_x = d.alpha_y = 0.3f;
    d.eta = rgb(1.5f, 1.5f, 1.5f);
    d.k = rgb(0.0f, 0.0f, 0.0f);
    return d;
}

/* Storage for msbsdf_material_init; size checked at run time. */
#define STORAGE_BYTES 4096
typedef union storage {
    unsigned char bytes[STORAGE_BYTES];
    uint64_t u64;
    double d;
    long double ld;
    void *p;
} storage;

/* A pointer value that is not NULL and not a material: *out canary. */
static int out_canary_object;
#define OUT_CANARY ((msbsdf_material *)(void *)&out_canary_object)

/*
 * create and init with `d` must both give `want` (create also OK when want is
 * OK); on failure *out is NULL and the init storage is untouched.
 */
static void expect_desc_status(const msbsdf_material_desc *d, msbsdf_status want, const char *what)
{
    msbsdf_material *m = OUT_CANARY;
    static storage st;
    msbsdf_status s = msbsdf_material_create(d, &m);
    CHECK(s == want, "create(%s) returned %u (%s), expected %u (%s)", what, (unsigned)s,
          msbsdf_status_message(s), (unsigned)want, msbsdf_status_message(want));
    if (want == MSBSDF_STATUS_OK) {
        CHECK(m != NULL && m != OUT_CANARY, "create(%s) OK but *out = %p", what, (void *)m);
    } else {
        CHECK(m == NULL, "create(%s) failed but *out = %p, not NULL", what, (void *)m);
    }
    if (s == MSBSDF_STATUS_OK && m != OUT_CANARY) {
        msbsdf_material_destroy(m);
    }

    memset(&st, CANARY, sizeof st);
    m = OUT_CANARY;
    s = msbsdf_material_init(d, st.bytes, sizeof st, &m);
    CHECK(s == want, "init(%s) returned %u (%s), expected %u (%s)", what, (unsigned)s,
          msbsdf_status_message(s), (unsigned)want, msbsdf_status_message(want));
    if (want == MSBSDF_STATUS_OK) {
        CHECK(m != NULL && m != OUT_CANARY, "init(%s) OK but *out = %p", what, (void *)m);
    } else {
        CHECK(m == NULL, "init(%s) failed but *out = %p, not NULL", what, (void *)m);
        CHECK(all_bytes_are(st.bytes, sizeof st, CANARY), "init(%s) failed but wrote its storage",
              what);
    }
}

static int finite_nonneg(float x) { return isfinite(x) && x >= 0.0f; }

static int rgb_ok(msbsdf_rgb c)
{
    return finite_nonneg(c.r) && finite_nonneg(c.g) && finite_nonneg(c.b);
}

/* ------------------------------------------------------------------------ */

static void test_desc_default(void)
{
    msbsdf_material_desc d = msbsdf_material_desc_default();
    CHECK(d.struct_size == sizeof(msbsdf_material_desc), "default struct_size %u, sizeof %u",
          (unsigned)d.struct_size, (unsigned)sizeof(msbsdf_material_desc));
    CHECK(d.model == MSBSDF_MODEL_SINGLE, "default model %u", (unsigned)d.model);
    CHECK(d.estimator == MSBSDF_ESTIMATOR_PT, "default estimator %u", (unsigned)d.estimator);
    CHECK(d.ndf == MSBSDF_NDF_GGX, "default ndf %u", (unsigned)d.ndf);
    CHECK(d.facet == MSBSDF_FACET_CONDUCTOR, "default facet %u", (unsigned)d.facet);
    CHECK(d.alpha_x == 0.5f && d.alpha_y == 0.5f, "default alpha %g %g", d.alpha_x, d.alpha_y);
    CHECK(d.shape == 2.0f, "default shape %g", d.shape);
    CHECK(d.eta.r == 0.0f && d.eta.g == 0.0f && d.eta.b == 0.0f, "default eta not 0");
    CHECK(d.k.r == 1.0f && d.k.g == 1.0f && d.k.b == 1.0f, "default k not 1");
    CHECK(d.albedo.r == 0.8f && d.albedo.g == 0.8f && d.albedo.b == 0.8f, "default albedo");
    CHECK(d.max_bounces == 0, "default max_bounces %u", (unsigned)d.max_bounces);
    CHECK(d.tolerance == 0.03f, "default tolerance %g", d.tolerance);
    CHECK(d.inner == NULL, "default inner not NULL");
    expect_desc_status(&d, MSBSDF_STATUS_OK, "default desc");
}

static void test_status_messages(void)
{
    const msbsdf_status known[] = {
        MSBSDF_STATUS_OK,                MSBSDF_STATUS_NULL_POINTER,
        MSBSDF_STATUS_INVALID_ARGUMENT,  MSBSDF_STATUS_UNSUPPORTED,
        MSBSDF_STATUS_OUT_OF_MEMORY,     MSBSDF_STATUS_PANIC,
        MSBSDF_STATUS_STRUCT_TOO_SMALL,  MSBSDF_STATUS_STORAGE_TOO_SMALL,
        MSBSDF_STATUS_STORAGE_MISALIGNED, MSBSDF_STATUS_INVALID_DIRECTION,
        MSBSDF_STATUS_UNKNOWN_CONSTANT,
    };
    const msbsdf_status unknown[] = {11, 12, 255, 1000, 0x7fffffffu, 0xffffffffu};
    const size_t nk = sizeof known / sizeof known[0];
    const char *unknown_text = msbsdf_status_message(0xffffffffu);
    size_t i, j;

    /* Status values never change: pin them. */
    for (i = 0; i < nk; i++) {
        CHECK(known[i] == (msbsdf_status)i, "status constant #%u has value %u", (unsigned)i,
              (unsigned)known[i]);
    }
    for (i = 0; i < nk; i++) {
        const char *a = msbsdf_status_message(known[i]);
        CHECK(a != NULL && a[0] != '\0', "status_message(%u) is NULL or empty", (unsigned)known[i]);
        if (a == NULL) {
            continue;
        }
        CHECK(unknown_text == NULL || strcmp(a, unknown_text) != 0,
              "status %u has the unknown-status text", (unsigned)known[i]);
        for (j = 0; j < i; j++) {
            const char *b = msbsdf_status_message(known[j]);
            CHECK(b == NULL || strcmp(a, b) != 0, "status %u and %u share the message \"%s\"",
                  (unsigned)known[i], (unsigned)known[j], a);
        }
    }
    for (i = 0; i < sizeof unknown / sizeof unknown[0]; i++) {
        const char *a = msbsdf_status_message(unknown[i]);
        CHECK(a != NULL && a[0] != '\0', "status_message(%u) is NULL or empty",
              (unsigned)unknown[i]);
    }
}

static void test_constants(void)
{
    /* Values are part of the ABI forever. */
    CHECK(MSBSDF_MODEL_SINGLE == 0 && MSBSDF_MODEL_ENERGY_COMPENSATED == 1 &&
              MSBSDF_MODEL_HEITZ_RANDOM_WALK == 2 && MSBSDF_MODEL_POSITION_FREE == 3 &&
              MSBSDF_MODEL_INVARIANCE == 4 && MSBSDF_MODEL_BITTERLI_DEON == 5 &&
              MSBSDF_MODEL_VGROOVE == 6 && MSBSDF_MODEL_VGROOVE_NONSYMMETRIC == 7 &&
              MSBSDF_MODEL_NULL_SCATTERING == 8 && MSBSDF_MODEL_AUTO == 9,
          "MSBSDF_MODEL_* values changed");
    CHECK(MSBSDF_ESTIMATOR_PT == 0 && MSBSDF_ESTIMATOR_BDPT == 1, "MSBSDF_ESTIMATOR_* changed");
    CHECK(MSBSDF_NDF_BECKMANN == 0 && MSBSDF_NDF_GGX == 1 && MSBSDF_NDF_STUDENT_T == 2 &&
              MSBSDF_NDF_PHONG == 3 && MSBSDF_NDF_EXPONENTIAL == 4 &&
              MSBSDF_NDF_BESSEL_K0 == 5 && MSBSDF_NDF_VMF == 6,
          "MSBSDF_NDF_* values changed");
    CHECK(MSBSDF_FACET_CONDUCTOR == 0 && MSBSDF_FACET_DIELECTRIC == 1 &&
              MSBSDF_FACET_DIFFUSE == 2 && MSBSDF_FACET_MATERIAL == 3,
          "MSBSDF_FACET_* values changed");
    CHECK(MSBSDF_SAMPLE_REFLECTION == 1 && MSBSDF_SAMPLE_TRANSMISSION == 2 &&
              MSBSDF_SAMPLE_ABSORBED == 4,
          "MSBSDF_SAMPLE_* values changed");
    CHECK(MSBSDF_MAX_BOUNCES == 256, "MSBSDF_MAX_BOUNCES changed");
}

static void test_null_pointers(const msbsdf_material *mat, const char *name)
{
    const msbsdf_vec3 wi = v3(0.3f, -0.2f, 0.9f), wo = v3(-0.4f, 0.1f, 0.8f);
    msbsdf_rng rng0;
    msbsdf_rgb ref_f;
    float ref_pdf = -1.0f;
    unsigned mask;
    msbsdf_rng_seed(&rng0, 7, 9);

    {
        msbsdf_rng r = rng0;
        CHECK_STATUS(msbsdf_eval(mat, wi, wo, &r, &ref_f), MSBSDF_STATUS_OK);
        CHECK_STATUS(msbsdf_pdf(mat, wi, wo, &ref_pdf), MSBSDF_STATUS_OK);
        CHECK(rgb_ok(ref_f) && ref_f.r > 0.0f && ref_pdf > 0.0f,
              "%s: reference eval/pdf not positive", name);
    }

    /* eval: bit 0 material NULL, bit 1 rng NULL, bit 2 out NULL. A
       deterministic model accepts rng == NULL. */
    for (mask = 0; mask < 8; mask++) {
        const msbsdf_material *m = (mask & 1) ? NULL : mat;
        msbsdf_rng r = rng0;
        msbsdf_rng *rp = (mask & 2) ? NULL : &r;
        msbsdf_rgb out;
        msbsdf_rgb *op = (mask & 4) ? NULL : &out;
        msbsdf_status want = (mask & 5) ? MSBSDF_STATUS_NULL_POINTER : MSBSDF_STATUS_OK;
        msbsdf_status s;
        memset(&out, CANARY, sizeof out);
        s = msbsdf_eval(m, wi, wo, rp, op);
        CHECK(s == want, "%s: eval NULL mask %u returned %u, expected %u", name, mask,
              (unsigned)s, (unsigned)want);
        if (op == NULL) {
            CHECK(all_bytes_are(&out, sizeof out, CANARY), "%s: eval wrote out", name);
        } else if (want == MSBSDF_STATUS_OK) {
            CHECK(SAME_BITS(out, ref_f), "%s: eval with rng %s differs from the reference",
                  name, rp ? "set" : "NULL");
        } else {
            CHECK(all_zero_bytes(&out, sizeof out), "%s: eval mask %u: out not zeroed", name,
                  mask);
        }
        if (want != MSBSDF_STATUS_OK) {
            CHECK(SAME_BITS(r, rng0), "%s: failed eval (mask %u) changed the rng", name, mask);
        }
    }

    /* sample: bit 0 material, bit 1 rng, bit 2 out; every pointer required. */
    for (mask = 0; mask < 8; mask++) {
        const msbsdf_material *m = (mask & 1) ? NULL : mat;
        msbsdf_rng r = rng0;
        msbsdf_rng *rp = (mask & 2) ? NULL : &r;
        msbsdf_sample_result out;
        msbsdf_sample_result *op = (mask & 4) ? NULL : &out;
        msbsdf_status want = mask ? MSBSDF_STATUS_NULL_POINTER : MSBSDF_STATUS_OK;
        msbsdf_status s;
        memset(&out, CANARY, sizeof out);
        s = msbsdf_sample(m, wi, rp, op);
        CHECK(s == want, "%s: sample NULL mask %u returned %u, expected %u", name, mask,
              (unsigned)s, (unsigned)want);
        if (op == NULL) {
            CHECK(all_bytes_are(&out, sizeof out, CANARY), "%s: sample wrote out", name);
        } else if (want != MSBSDF_STATUS_OK) {
            CHECK(all_zero_bytes(&out, sizeof out), "%s: sample mask %u: out not zeroed", name,
                  mask);
        }
        if (want != MSBSDF_STATUS_OK) {
            CHECK(SAME_BITS(r, rng0), "%s: failed sample (mask %u) changed the rng", name, mask);
        } else {
            CHECK(!SAME_BITS(r, rng0), "%s: sample did not advance the rng", name);
        }
    }

    /* pdf: bit 0 material, bit 1 out. */
    for (mask = 0; mask < 4; mask++) {
        const msbsdf_material *m = (mask & 1) ? NULL : mat;
        float out;
        float *op = (mask & 2) ? NULL : &out;
        msbsdf_status want = mask ? MSBSDF_STATUS_NULL_POINTER : MSBSDF_STATUS_OK;
        msbsdf_status s;
        memset(&out, CANARY, sizeof out);
        s = msbsdf_pdf(m, wi, wo, op);
        CHECK(s == want, "%s: pdf NULL mask %u returned %u, expected %u", name, mask,
              (unsigned)s, (unsigned)want);
        if (op == NULL) {
            CHECK(all_bytes_are(&out, sizeof out, CANARY), "%s: pdf wrote out", name);
        } else if (want != MSBSDF_STATUS_OK) {
            CHECK(all_zero_bytes(&out, sizeof out), "%s: pdf mask %u: out not zeroed", name,
                  mask);
        } else {
            CHECK(SAME_BITS(out, ref_pdf), "%s: pdf differs between calls", name);
        }
    }
}

static void test_null_create_init(void)
{
    const msbsdf_material_desc d = gold_desc();
    static storage st;
    unsigned mask;

    /* create: bit 0 desc NULL, bit 1 out NULL. */
    for (mask = 1; mask < 4; mask++) {
        msbsdf_material *m = OUT_CANARY;
        msbsdf_status s = msbsdf_material_create((mask & 1) ? NULL : &d, (mask & 2) ? NULL : &m);
        CHECK(s == MSBSDF_STATUS_NULL_POINTER, "create NULL mask %u returned %u", mask,
              (unsigned)s);
        if (mask & 2) {
            CHECK(m == OUT_CANARY, "create with out NULL changed the caller's pointer");
        } else {
            CHECK(m == NULL, "create NULL mask %u: *out not NULL", mask);
        }
    }

    /* init: bit 0 desc NULL, bit 1 storage NULL, bit 2 out NULL. */
    for (mask = 1; mask < 8; mask++) {
        msbsdf_material *m = OUT_CANARY;
        msbsdf_status s;
        memset(&st, CANARY, sizeof st);
        s = msbsdf_material_init((mask & 1) ? NULL : &d, (mask & 2) ? NULL : st.bytes, sizeof st,
                                 (mask & 4) ? NULL : &m);
        CHECK(s == MSBSDF_STATUS_NULL_POINTER, "init NULL mask %u returned %u", mask,
              (unsigned)s);
        CHECK(all_bytes_are(st.bytes, sizeof st, CANARY), "init NULL mask %u wrote storage",
              mask);
        if (mask & 4) {
            CHECK(m == OUT_CANARY, "init with out NULL changed the caller's pointer");
        } else {
            CHECK(m == NULL, "init NULL mask %u: *out not NULL", mask);
        }
    }

    /* FACET_MATERIAL needs an inner material. */
    {
        msbsdf_material_desc c = gold_desc();
        c.facet = MSBSDF_FACET_MATERIAL;
        c.inner = NULL;
        expect_desc_status(&c, MSBSDF_STATUS_NULL_POINTER, "facet MATERIAL, inner NULL");
    }

    /* The rng and destroy functions accept NULL. */
    msbsdf_rng_seed(NULL, 1, 2);
    CHECK(msbsdf_rng_next_float(NULL) == 0.0f, "rng_next_float(NULL) is not 0");
    msbsdf_material_destroy(NULL);
}

static void test_invalid_directions(const msbsdf_material *mat, const char *name)
{
    const float nan = (float)NAN, inf = (float)INFINITY;
    const msbsdf_vec3 bad[] = {
        v3(nan, 0.0f, 1.0f),  v3(0.0f, nan, 1.0f),   v3(0.0f, 0.0f, nan), v3(nan, nan, nan),
        v3(inf, 0.0f, 1.0f),  v3(0.0f, -inf, 1.0f),  v3(0.0f, 0.0f, inf), v3(0.0f, 0.0f, -inf),
        v3(0.0f, 0.0f, 0.0f), v3(-0.0f, -0.0f, -0.0f),
    };
    const msbsdf_vec3 good = v3(0.2f, 0.1f, 0.9f);
    size_t i;
    int side;
    msbsdf_rng rng0;
    msbsdf_rng_seed(&rng0, 3, 4);

    for (i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        for (side = 0; side < 2; side++) {
            msbsdf_vec3 wi = side ? good : bad[i], wo = side ? bad[i] : good;
            msbsdf_rng r = rng0;
            msbsdf_rgb f;
            float p;
            memset(&f, CANARY, sizeof f);
            memset(&p, CANARY, sizeof p);
            CHECK_STATUS(msbsdf_eval(mat, wi, wo, &r, &f), MSBSDF_STATUS_INVALID_DIRECTION);
            CHECK(all_zero_bytes(&f, sizeof f), "%s: eval bad dir %u/%d: out not zeroed", name,
                  (unsigned)i, side);
            CHECK(SAME_BITS(r, rng0), "%s: eval bad dir changed the rng", name);
            CHECK_STATUS(msbsdf_pdf(mat, wi, wo, &p), MSBSDF_STATUS_INVALID_DIRECTION);
            CHECK(all_zero_bytes(&p, sizeof p), "%s: pdf bad dir %u/%d: out not zeroed", name,
                  (unsigned)i, side);
        }
        {
            msbsdf_rng r = rng0;
            msbsdf_sample_result s;
            memset(&s, CANARY, sizeof s);
            CHECK_STATUS(msbsdf_sample(mat, bad[i], &r, &s), MSBSDF_STATUS_INVALID_DIRECTION);
            CHECK(all_zero_bytes(&s, sizeof s), "%s: sample bad dir %u: out not zeroed", name,
                  (unsigned)i);
            CHECK(SAME_BITS(r, rng0), "%s: sample bad dir changed the rng", name);
        }
    }
}

/* wi.z == 0 or wo.z == 0 is degenerate geometry, not an error. */
static void test_degenerate_geometry(const msbsdf_material *mat, const char *name)
{
    const msbsdf_vec3 horizon = v3(1.0f, 0.0f, 0.0f), up = v3(0.1f, 0.2f, 1.0f);
    msbsdf_rng r;
    msbsdf_rgb f;
    float p;
    msbsdf_sample_result s;
    msbsdf_rng_seed(&r, 5, 6);

    CHECK_STATUS(msbsdf_eval(mat, horizon, up, &r, &f), MSBSDF_STATUS_OK);
    CHECK(all_zero_bytes(&f, sizeof f), "%s: eval(wi.z = 0) not 0", name);
    CHECK_STATUS(msbsdf_eval(mat, up, horizon, &r, &f), MSBSDF_STATUS_OK);
    CHECK(all_zero_bytes(&f, sizeof f), "%s: eval(wo.z = 0) not 0", name);
    CHECK_STATUS(msbsdf_pdf(mat, horizon, up, &p), MSBSDF_STATUS_OK);
    CHECK(p == 0.0f, "%s: pdf(wi.z = 0) = %g", name, p);
    CHECK_STATUS(msbsdf_pdf(mat, up, horizon, &p), MSBSDF_STATUS_OK);
    CHECK(p == 0.0f, "%s: pdf(wo.z = 0) = %g", name, p);
    CHECK_STATUS(msbsdf_sample(mat, horizon, &r, &s), MSBSDF_STATUS_OK);
    CHECK(s.weight.r == 0.0f && s.weight.g == 0.0f && s.weight.b == 0.0f,
          "%s: sample(wi.z = 0) weight not 0", name);
    CHECK(s.flags == MSBSDF_SAMPLE_ABSORBED, "%s: sample(wi.z = 0) flags %u", name,
          (unsigned)s.flags);
}

/* Directions need not be normalised: scaled inputs give (nearly) the same
   values, including scales whose squared length leaves the float range
   (1e-25 used to be refused, 1e25 used to give f = 0 with status OK). */
static void test_unnormalised(const msbsdf_material *mat, const char *name)
{
    const msbsdf_vec3 wi = v3(0.3f, -0.2f, 0.9f), wo = v3(-0.4f, 0.1f, 0.8f);
    const float scales[] = {1e-3f, 0.25f, 3.0f, 1e3f, 1e15f, 1e-15f, 1e-25f, 1e25f, 1e-30f, 1e30f};
    msbsdf_rgb f0, f;
    float p0, p;
    size_t i;
    CHECK_STATUS(msbsdf_eval(mat, wi, wo, NULL, &f0), MSBSDF_STATUS_OK);
    CHECK_STATUS(msbsdf_pdf(mat, wi, wo, &p0), MSBSDF_STATUS_OK);
    for (i = 0; i < sizeof scales / sizeof scales[0]; i++) {
        const float a = scales[i], b = 1.0f / scales[i];
        const msbsdf_vec3 pairs[3][2] = {
            {v3(wi.x * a, wi.y * a, wi.z * a), v3(wo.x * b, wo.y * b, wo.z * b)},
            {v3(wi.x * a, wi.y * a, wi.z * a), wo},
            {wi, v3(wo.x * a, wo.y * a, wo.z * a)},
        };
        int k;
        for (k = 0; k < 3; k++) {
            msbsdf_rng r0, r1;
            msbsdf_sample_result s0, s1;
            CHECK_STATUS(msbsdf_eval(mat, pairs[k][0], pairs[k][1], NULL, &f), MSBSDF_STATUS_OK);
            CHECK_STATUS(msbsdf_pdf(mat, pairs[k][0], pairs[k][1], &p), MSBSDF_STATUS_OK);
            CHECK(fabsf(f.r - f0.r) <= 1e-4f * f0.r && fabsf(f.b - f0.b) <= 1e-4f * f0.b,
                  "%s: eval of directions scaled by %g (pair %d): %.9g vs %.9g", name, a, k, f.r,
                  f0.r);
            CHECK(fabsf(p - p0) <= 1e-4f * p0,
                  "%s: pdf of directions scaled by %g (pair %d): %.9g vs %.9g", name, a, k, p, p0);
            msbsdf_rng_seed(&r0, 1, 1);
            msbsdf_rng_seed(&r1, 1, 1);
            CHECK_STATUS(msbsdf_sample(mat, wi, &r0, &s0), MSBSDF_STATUS_OK);
            CHECK_STATUS(msbsdf_sample(mat, pairs[k][0], &r1, &s1), MSBSDF_STATUS_OK);
            CHECK(s0.flags == s1.flags && fabsf(s0.wo.z - s1.wo.z) <= 1e-4f &&
                      fabsf(s0.weight.g - s1.weight.g) <= 1e-4f * s0.weight.g,
                  "%s: sample of wi scaled by %g differs", name, a);
        }
    }
}

static void test_unknown_constants(void)
{
    const uint32_t bad_model[] = {11, 12, 0x7fffffffu, 0xffffffffu};
    const uint32_t bad_ndf[] = {7, 8, 0xffffffffu};
    const uint32_t bad_facet[] = {4, 5, 0xffffffffu};
    const uint32_t bad_estimator[] = {2, 3, 0xffffffffu};
    size_t i;
    char what[64];
    for (i = 0; i < sizeof bad_model / sizeof bad_model[0]; i++) {
        msbsdf_material_desc d = gold_desc();
        d.model = bad_model[i];
        sprintf(what, "model %u", (unsigned)bad_model[i]);
        expect_desc_status(&d, MSBSDF_STATUS_UNKNOWN_CONSTANT, what);
    }
    for (i = 0; i < sizeof bad_ndf / sizeof bad_ndf[0]; i++) {
        msbsdf_material_desc d = gold_desc();
        d.ndf = bad_ndf[i];
        sprintf(what, "ndf %u", (unsigned)bad_ndf[i]);
        expect_desc_status(&d, MSBSDF_STATUS_UNKNOWN_CONSTANT, what);
    }
    for (i = 0; i < sizeof bad_facet / sizeof bad_facet[0]; i++) {
        msbsdf_material_desc d = gold_desc();
        d.facet = bad_facet[i];
        sprintf(what, "facet %u", (unsigned)bad_facet[i]);
        expect_desc_status(&d, MSBSDF_STATUS_UNKNOWN_CONSTANT, what);
    }
    for (i = 0; i < sizeof bad_estimator / sizeof bad_estimator[0]; i++) {
        msbsdf_material_desc d = gold_desc();
        d.estimator = bad_estimator[i];
        sprintf(what, "estimator %u", (unsigned)bad_estimator[i]);
        expect_desc_status(&d, MSBSDF_STATUS_UNKNOWN_CONSTANT, what);
    }
}

/* A description followed by fields of a later minor version. */
typedef struct future_desc {
    msbsdf_material_desc base;
    uint64_t appended[4];
} future_desc;

static void test_struct_size(void)
{
    const uint32_t too_small[] = {
        0u, 1u, 4u, (uint32_t)offsetof(msbsdf_material_desc, alpha_x),
        (uint32_t)offsetof(msbsdf_material_desc, inner),
        87u, /* one below the first published (0.2) layout, 88 bytes */
    };
    size_t i;
    char what[64];
    for (i = 0; i < sizeof too_small / sizeof too_small[0]; i++) {
        msbsdf_material_desc d = gold_desc();
        d.struct_size = too_small[i];
        sprintf(what, "struct_size %u", (unsigned)too_small[i]);
        expect_desc_status(&d, MSBSDF_STATUS_STRUCT_TOO_SMALL, what);
    }
    /* A caller compiled against a later header (a larger struct) works. */
    {
        future_desc f;
        memset(&f, 0x5a, sizeof f);
        f.base = gold_desc();
        f.base.struct_size = (uint32_t)sizeof f;
        expect_desc_status(&f.base, MSBSDF_STATUS_OK, "larger struct_size");
    }
    /* Only struct_size bytes are read: a 4-byte "struct" with struct_size 4
       just before an inaccessible page is refused without a fault, and a
       full struct ending at the page boundary is accepted. */
    {
        long page = sysconf(_SC_PAGESIZE);
        unsigned char *mem = (unsigned char *)mmap(NULL, (size_t)page * 2, PROT_READ | PROT_WRITE,
                                                   MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        CHECK(mem != MAP_FAILED, "mmap failed");
        if (mem != MAP_FAILED) {
            unsigned char *end = mem + page;
            uint32_t four = 4;
            msbsdf_material_desc full = gold_desc();
            msbsdf_material *m = OUT_CANARY;
            CHECK(mprotect(end, (size_t)page, PROT_NONE) == 0, "mprotect failed");
            memcpy(end - 4, &four, 4);
            CHECK_STATUS(msbsdf_material_create((const msbsdf_material_desc *)(void *)(end - 4), &m),
                         MSBSDF_STATUS_STRUCT_TOO_SMALL);
            CHECK(m == NULL, "struct_size 4 at page end: *out not NULL");
            memcpy(end - sizeof full, &full, sizeof full);
            CHECK_STATUS(
                msbsdf_material_create((const msbsdf_material_desc *)(void *)(end - sizeof full), &m),
                MSBSDF_STATUS_OK);
            msbsdf_material_destroy(m);
            munmap(mem, (size_t)page * 2);
        }
    }
}

static void test_invalid_arguments(void)
{
    const float nan = (float)NAN, inf = (float)INFINITY;
    const float bad_alpha[] = {-0.5f, -1e-30f, nan, inf, -inf, 10.5f, 1e30f};
    /* 0 (and -0) is the specular regime since 0.3. */
    const float good_alpha[] = {0.0f, -0.0f, 1e-6f, 1e-4f, 0.5f, 1.0f, 10.0f};
    const float bad_eta[] = {0.0f, -0.0f, -1.5f, nan, inf, -inf};
    const uint32_t ndfs[] = {MSBSDF_NDF_BECKMANN, MSBSDF_NDF_GGX};
    size_t i, n, axis;
    char what[96];

    for (n = 0; n < 2; n++) {
        for (axis = 0; axis < 2; axis++) {
            for (i = 0; i < sizeof bad_alpha / sizeof bad_alpha[0]; i++) {
                msbsdf_material_desc d = n ? gold_desc() : glass_desc();
                d.ndf = ndfs[n];
                if (axis) {
                    d.alpha_y = bad_alpha[i];
                } else {
                    d.alpha_x = bad_alpha[i];
                }
                sprintf(what, "ndf %u alpha_%c = %g", (unsigned)ndfs[n], axis ? 'y' : 'x',
                        bad_alpha[i]);
                expect_desc_status(&d, MSBSDF_STATUS_INVALID_ARGUMENT, what);
            }
            for (i = 0; i < sizeof good_alpha / sizeof good_alpha[0]; i++) {
                msbsdf_material_desc d = n ? gold_desc() : glass_desc();
                d.ndf = ndfs[n];
                if (axis) {
                    d.alpha_y = good_alpha[i];
                } else {
                    d.alpha_x = good_alpha[i];
                }
                sprintf(what, "ndf %u alpha_%c = %g", (unsigned)ndfs[n], axis ? 'y' : 'x',
                        good_alpha[i]);
                expect_desc_status(&d, MSBSDF_STATUS_OK, what);
            }
        }
    }

    /* Dielectric: eta.r is the index ratio; <= 0 or non-finite is refused. */
    for (i = 0; i < sizeof bad_eta / sizeof bad_eta[0]; i++) {
        msbsdf_material_desc d = glass_desc();
        d.eta = rgb(bad_eta[i], bad_eta[i], bad_eta[i]);
        sprintf(what, "dielectric eta %g", bad_eta[i]);
        expect_desc_status(&d, MSBSDF_STATUS_INVALID_ARGUMENT, what);
    }
    {
        const float good_eta[] = {0.5f, 1.0f, 1.0001f, 1.5f, 4.0f};
        for (i = 0; i < sizeof good_eta / sizeof good_eta[0]; i++) {
            msbsdf_material_desc d = glass_desc();
            /* All channels: differing ones are refused since 0.3. */
            d.eta = rgb(good_eta[i], good_eta[i], good_eta[i]);
            sprintf(what, "dielectric eta %g", good_eta[i]);
            expect_desc_status(&d, MSBSDF_STATUS_OK, what);
        }
    }

    /* Conductor: eta < 0, k < 0, eta = k = 0 in a channel, non-finite. */
    {
        struct {
            msbsdf_rgb eta, k;
            msbsdf_status want;
            const char *what;
        } cases[8];
        size_t nc = 0;
        cases[nc].eta = rgb(-0.1f, 0.4f, 1.4f), cases[nc].k = rgb(4.0f, 2.4f, 1.6f);
        cases[nc].want = MSBSDF_STATUS_INVALID_ARGUMENT, cases[nc++].what = "conductor eta.r < 0";
        cases[nc].eta = rgb(0.1f, 0.4f, 1.4f), cases[nc].k = rgb(4.0f, -2.4f, 1.6f);
        cases[nc].want = MSBSDF_STATUS_INVALID_ARGUMENT, cases[nc++].what = "conductor k.g < 0";
        cases[nc].eta = rgb(0.0f, 0.0f, 0.0f), cases[nc].k = rgb(0.0f, 0.0f, 0.0f);
        cases[nc].want = MSBSDF_STATUS_INVALID_ARGUMENT, cases[nc++].what = "conductor eta = k = 0";
        cases[nc].eta = rgb(0.1f, 0.4f, 0.0f), cases[nc].k = rgb(4.0f, 2.4f, 0.0f);
        cases[nc].want = MSBSDF_STATUS_INVALID_ARGUMENT,
        cases[nc++].what = "conductor eta.b = k.b = 0";
        cases[nc].eta = rgb(nan, 0.4f, 1.4f), cases[nc].k = rgb(4.0f, 2.4f, 1.6f);
        cases[nc].want = MSBSDF_STATUS_INVALID_ARGUMENT, cases[nc++].what = "conductor eta NaN";
        cases[nc].eta = rgb(0.1f, 0.4f, 1.4f), cases[nc].k = rgb(4.0f, 2.4f, inf);
        cases[nc].want = MSBSDF_STATUS_INVALID_ARGUMENT, cases[nc++].what = "conductor k Inf";
        cases[nc].eta = rgb(0.0f, 0.0f, 0.0f), cases[nc].k = rgb(1.0f, 1.0f, 1.0f);
        cases[nc].want = MSBSDF_STATUS_OK, cases[nc++].what = "conductor mirror eta 0 k 1";
        cases[nc].eta = rgb(1.5f, 1.5f, 1.5f), cases[nc].k = rgb(0.0f, 0.0f, 0.0f);
        cases[nc].want = MSBSDF_STATUS_OK, cases[nc++].what = "conductor eta 1.5 k 0";
        for (i = 0; i < nc; i++) {
            msbsdf_material_desc d = gold_desc();
            d.eta = cases[i].eta;
            d.k = cases[i].k;
            expect_desc_status(&d, cases[i].want, cases[i].what);
        }
    }

    /* Bounce limit and Student-T shape. */
    {
        msbsdf_material_desc d = gold_desc();
        d.max_bounces = MSBSDF_MAX_BOUNCES + 1;
        expect_desc_status(&d, MSBSDF_STATUS_INVALID_ARGUMENT, "max_bounces 257");
        d.max_bounces = 0xffffffffu;
        expect_desc_status(&d, MSBSDF_STATUS_INVALID_ARGUMENT, "max_bounces 2^32-1");
        d.max_bounces = MSBSDF_MAX_BOUNCES;
        expect_desc_status(&d, MSBSDF_STATUS_OK, "max_bounces 256");
        d = gold_desc();
        d.ndf = MSBSDF_NDF_STUDENT_T;
        d.shape = 1.5f;
        expect_desc_status(&d, MSBSDF_STATUS_INVALID_ARGUMENT, "Student-T gamma 1.5");
        d.shape = 1.0f;
        expect_desc_status(&d, MSBSDF_STATUS_INVALID_ARGUMENT, "Student-T gamma 1");
        d.shape = nan;
        expect_desc_status(&d, MSBSDF_STATUS_INVALID_ARGUMENT, "Student-T gamma NaN");
    }

    /* Combinations outside the design table (DESIGN.md section 1). */
    {
        msbsdf_material_desc d = gold_desc();
        d.facet = MSBSDF_FACET_DIFFUSE;
        expect_desc_status(&d, MSBSDF_STATUS_UNSUPPORTED, "SINGLE with diffuse facets");
        d = glass_desc();
        d.model = MSBSDF_MODEL_INVARIANCE;
        expect_desc_status(&d, MSBSDF_STATUS_UNSUPPORTED, "INVARIANCE with dielectric facets");
        d = glass_desc();
        d.model = MSBSDF_MODEL_VGROOVE;
        expect_desc_status(&d, MSBSDF_STATUS_UNSUPPORTED, "VGROOVE with dielectric facets");
    }
}

/* Random valid queries: outputs finite and non-negative, flags consistent,
   sample agrees with eval and pdf (SINGLE is deterministic and exact). */
static void test_outputs_sane(const msbsdf_material *mat, const char *name, int transmits)
{
    msbsdf_rng r;
    int i, bad_values = 0, bad_flags = 0, bad_consistency = 0, transmitted = 0;
    msbsdf_rng_seed(&r, 11, 12);
    for (i = 0; i < 20000; i++) {
        float u1 = msbsdf_rng_next_float(&r), u2 = msbsdf_rng_next_float(&r);
        float z = 2.0f * u1 - 1.0f, s = sqrtf(fmaxf(0.0f, 1.0f - z * z));
        float phi = 6.2831853f * u2;
        msbsdf_vec3 wi = v3(s * cosf(phi), s * sinf(phi), z);
        msbsdf_vec3 wo = v3(msbsdf_rng_next_float(&r) - 0.5f, msbsdf_rng_next_float(&r) - 0.5f,
                            msbsdf_rng_next_float(&r) - 0.5f);
        msbsdf_sample_result smp;
        msbsdf_rgb f;
        float p;
        if (wi.z == 0.0f || wo.z == 0.0f || (wo.x == 0.0f && wo.y == 0.0f && wo.z == 0.0f)) {
            continue;
        }
        CHECK_STATUS(msbsdf_eval(mat, wi, wo, &r, &f), MSBSDF_STATUS_OK);
        CHECK_STATUS(msbsdf_pdf(mat, wi, wo, &p), MSBSDF_STATUS_OK);
        CHECK_STATUS(msbsdf_sample(mat, wi, &r, &smp), MSBSDF_STATUS_OK);
        bad_values += !rgb_ok(f) || !finite_nonneg(p) || !rgb_ok(smp.weight) ||
                      !finite_nonneg(smp.pdf) || !isfinite(smp.wo.x) || !isfinite(smp.wo.y) ||
                      !isfinite(smp.wo.z);
        if (smp.flags == MSBSDF_SAMPLE_ABSORBED) {
            bad_flags += smp.weight.r != 0.0f || smp.weight.g != 0.0f || smp.weight.b != 0.0f;
        } else if (smp.flags == MSBSDF_SAMPLE_REFLECTION ||
                   smp.flags == MSBSDF_SAMPLE_TRANSMISSION) {
            int same_side = (smp.wo.z > 0.0f) == (wi.z > 0.0f);
            float len = sqrtf(smp.wo.x * smp.wo.x + smp.wo.y * smp.wo.y + smp.wo.z * smp.wo.z);
            msbsdf_rgb fe;
            float pe;
            bad_flags += (smp.flags == MSBSDF_SAMPLE_REFLECTION) != same_side;
            bad_flags += fabsf(len - 1.0f) > 1e-5f;
            transmitted += smp.flags == MSBSDF_SAMPLE_TRANSMISSION;
            CHECK_STATUS(msbsdf_eval(mat, wi, smp.wo, NULL, &fe), MSBSDF_STATUS_OK);
            CHECK_STATUS(msbsdf_pdf(mat, wi, smp.wo, &pe), MSBSDF_STATUS_OK);
            /* weight = eval / pdf, and the sample's pdf is msbsdf_pdf. */
            bad_consistency += fabsf(smp.pdf - pe) > 1e-3f * pe + 1e-6f;
            bad_consistency +=
                fabsf(smp.weight.g * smp.pdf - fe.g) > 1e-3f * fe.g + 1e-6f;
        } else {
            bad_flags++;
        }
    }
    CHECK(bad_values == 0, "%s: %d queries gave NaN, Inf or negative outputs", name, bad_values);
    CHECK(bad_flags == 0, "%s: %d samples with inconsistent flags / direction / weight", name,
          bad_flags);
    CHECK(bad_consistency == 0, "%s: %d samples where weight * pdf != eval or pdf != msbsdf_pdf",
          name, bad_consistency);
    if (transmits) {
        CHECK(transmitted > 1000, "%s: only %d transmitted samples", name, transmitted);
    } else {
        CHECK(transmitted == 0, "%s: a conductor transmitted %d samples", name, transmitted);
    }
}

int main(void)
{
    msbsdf_material_desc gd = gold_desc(), dd = glass_desc();
    msbsdf_material *gold = NULL, *glass = NULL;

    test_constants();
    test_status_messages();
    test_desc_default();

    CHECK_STATUS(msbsdf_material_create(&gd, &gold), MSBSDF_STATUS_OK);
    CHECK_STATUS(msbsdf_material_create(&dd, &glass), MSBSDF_STATUS_OK);
    if (gold == NULL || glass == NULL) {
        return check_finish("api");
    }

    test_null_pointers(gold, "gold");
    test_null_pointers(glass, "glass");
    test_null_create_init();
    test_invalid_directions(gold, "gold");
    test_invalid_directions(glass, "glass");
    test_degenerate_geometry(gold, "gold");
    test_degenerate_geometry(glass, "glass");
    test_unnormalised(gold, "gold");
    test_unnormalised(glass, "glass");
    test_unknown_constants();
    test_struct_size();
    test_invalid_arguments();
    test_outputs_sane(gold, "gold", 0);
    test_outputs_sane(glass, "glass", 1);

    msbsdf_material_destroy(gold);
    msbsdf_material_destroy(glass);
    return check_finish("api");
}
