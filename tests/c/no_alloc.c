/*
 * The hot path never allocates (DESIGN.md section 2): with the malloc
 * interposer of malloc_count.c, 10^5 rounds of rng / eval / sample / pdf calls
 * (valid and refused ones) on SINGLE conductor and dielectric materials, made
 * with create and with init, count zero allocations and zero frees. A
 * positive control shows that the interposer sees the library's own
 * allocations (msbsdf_material_create allocates).
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "check.h"
#include "malloc_count.h"

#define ROUNDS 100000

static msbsdf_vec3 v3(float x, float y, float z)
{
    msbsdf_vec3 v;
    v.x = x;
    v.y = y;
    v.z = z;
    return v;
}

static msbsdf_material_desc make_desc(int glass)
{
    msbsdf_material_desc d = msbsdf_material_desc_default();
    d.model = MSBSDF_MODEL_SINGLE;
    d.ndf = glass ? MSBSDF_NDF_BECKMANN : MSBSDF_NDF_GGX;
    if (glass) {
        d.facet = MSBSDF_FACET_DIELECTRIC;
        d.alpha_x = d.alpha_y = 0.3f;
        d.eta.r = d.eta.g = d.eta.b = 1.5f;
    } else {
        d.facet = MSBSDF_FACET_CONDUCTOR;
        d.alpha_x = d.alpha_y = 0.5f;
        d.eta.r = 0.143f, d.eta.g = 0.374f, d.eta.b = 1.442f;
        d.k.r = 3.983f, d.k.g = 2.385f, d.k.b = 1.603f;
    }
    return d;
}

typedef union storage {
    unsigned char bytes[4096];
    uint64_t u64;
    long double ld;
    void *p;
} storage;

/* Phase 2: every model / facet combination that msbsdf_material_init
   accepts, in caller storage. Each material gets a warm-up of a few calls
   first (tables that a model builds once, thread-safely, on first use are
   allowed to allocate then); after that, 2000 rounds of sample / eval / pdf
   must not touch the allocator. */
static void all_models_phase(void)
{
    static storage st;
    const uint32_t facets[3] = {MSBSDF_FACET_CONDUCTOR, MSBSDF_FACET_DIELECTRIC,
                                MSBSDF_FACET_DIFFUSE};
    uint32_t model, f, ndf;
    int tested = 0;
    for (model = 0; model <= MSBSDF_MODEL_TABULATED; model++) {
        for (f = 0; f < 3; f++) {
            for (ndf = 0; ndf <= MSBSDF_NDF_GGX; ndf++) {
                msbsdf_material_desc d = msbsdf_material_desc_default();
                msbsdf_material *m = NULL;
                msbsdf_rng rng;
                unsigned long allocs;
                double checksum = 0.0;
                int i;
                d.model = model;
                d.ndf = ndf;
                d.facet = facets[f];
                d.alpha_x = d.alpha_y = 0.6f;
                /* AUTO at a tight tolerance picks walks of thousands of
                   evaluations; a loose tolerance keeps this loop fast (its
                   averaging wrapper is the same code for any choice). */
                d.tolerance = 0.2f;
                if (facets[f] == MSBSDF_FACET_DIELECTRIC) {
                    d.eta.r = d.eta.g = d.eta.b = 1.5f;
                } else if (facets[f] == MSBSDF_FACET_CONDUCTOR) {
                    d.eta.r = 0.143f, d.eta.g = 0.374f, d.eta.b = 1.442f;
                    d.k.r = 3.983f, d.k.g = 2.385f, d.k.b = 1.603f;
                }
                if (msbsdf_material_init(&d, st.bytes, sizeof st, &m) != MSBSDF_STATUS_OK) {
                    continue;
                }
                msbsdf_rng_seed(&rng, model, f);
                for (i = 0; i < 2000 + 16; i++) {
                    msbsdf_vec3 wi = v3(0.3f, -0.2f, 0.8f), wo = v3(-0.4f, 0.1f, 0.6f);
                    msbsdf_sample_result smp;
                    msbsdf_rgb out;
                    float p;
                    msbsdf_context ctx;
                    msbsdf_sample_record rec;
                    msbsdf_context_init(&ctx);
                    msbsdf_sample_record_init(&rec);
                    if (i == 16) { /* warm-up done */
                        malloc_count_allocs = malloc_count_frees = 0;
                        malloc_count_enabled = 1;
                    }
                    if (msbsdf_sample(m, wi, &rng, &smp) == MSBSDF_STATUS_OK) {
                        checksum += smp.weight.r;
                    }
                    if (msbsdf_eval(m, wi, wo, &rng, &out) == MSBSDF_STATUS_OK) {
                        checksum += out.r;
                    }
                    if (msbsdf_pdf(m, wi, wo, &p) == MSBSDF_STATUS_OK) {
                        checksum += p;
                    }
                    /* The 0.3 calls with a context. */
                    ctx.rng = &rng;
                    if (msbsdf_eval_pdf(m, &ctx, wi, wo, &out, &p) == MSBSDF_STATUS_OK) {
                        checksum += out.r + p;
                    }
                    if (msbsdf_sample_with(m, &ctx, wi, 0.3f, 0.6f, 0.1f, &rec) == MSBSDF_STATUS_OK) {
                        checksum += rec.weight.r;
                    }
                }
                malloc_count_enabled = 0;
                allocs = malloc_count_allocs + malloc_count_frees;
                CHECK(allocs == 0, "model %u facet %u ndf %u: %lu allocator calls in 10000 hot-path calls",
                      (unsigned)model, (unsigned)facets[f], (unsigned)ndf, allocs);
                CHECK(isfinite(checksum), "model %u: checksum %g", (unsigned)model, checksum);
                tested++;
            }
        }
    }
    printf("all models: %d accepted model/facet/NDF combinations, 0 allocations after warm-up\n",
           tested);
    CHECK(tested >= 10, "only %d combinations accepted", tested);
}

int main(void)
{
    static storage st[2];
    msbsdf_material *created[2] = {NULL, NULL}, *inited[2] = {NULL, NULL};
    msbsdf_material_desc d[2];
    unsigned long create_allocs, destroy_frees, allocs, frees;
    long calls = 0;
    double checksum = 0.0;
    msbsdf_rng rng;
    int i, g;

    d[0] = make_desc(0);
    d[1] = make_desc(1);

    /* Positive control 1: the interposer is in place for this program. */
    malloc_count_allocs = malloc_count_frees = 0;
    malloc_count_enabled = 1;
    {
        void *volatile p = malloc(16);
        free(p);
    }
    malloc_count_enabled = 0;
    CHECK(malloc_count_allocs == 1 && malloc_count_frees == 1,
          "interposer self-test: %lu allocs, %lu frees (expected 1, 1)", malloc_count_allocs,
          malloc_count_frees);

    /* Positive control 2: it sees allocations made inside libmsbsdf. */
    malloc_count_allocs = malloc_count_frees = 0;
    malloc_count_enabled = 1;
    for (g = 0; g < 2; g++) {
        CHECK_STATUS(msbsdf_material_create(&d[g], &created[g]), MSBSDF_STATUS_OK);
    }
    malloc_count_enabled = 0;
    create_allocs = malloc_count_allocs;
    CHECK(create_allocs >= 2, "2 msbsdf_material_create calls counted %lu allocations: the "
          "interposer does not see the library", create_allocs);
    if (created[0] == NULL || created[1] == NULL) {
        return check_finish("no_alloc");
    }

    /* Everything below, from the first call on (no warm-up), must not touch
       the allocator: init, queries, refused calls, destroy of caller storage. */
    malloc_count_allocs = malloc_count_frees = 0;
    malloc_count_enabled = 1;
    for (g = 0; g < 2; g++) {
        CHECK_STATUS(msbsdf_material_init(&d[g], st[g].bytes, sizeof st[g], &inited[g]),
                     MSBSDF_STATUS_OK);
    }
    msbsdf_rng_seed(&rng, 2024, 7);
    for (i = 0; i < ROUNDS; i++) {
        float z = 2.0f * msbsdf_rng_next_float(&rng) - 1.0f;
        float phi = 6.2831853f * msbsdf_rng_next_float(&rng);
        float s = sqrtf(fmaxf(0.0f, 1.0f - z * z));
        msbsdf_vec3 wi = v3(s * cosf(phi), s * sinf(phi), z);
        msbsdf_vec3 wo = v3(msbsdf_rng_next_float(&rng) - 0.5f, msbsdf_rng_next_float(&rng) - 0.5f,
                            msbsdf_rng_next_float(&rng) - 0.5f);
        const msbsdf_material *m = (i & 1) ? inited[(i >> 1) & 1] : created[(i >> 1) & 1];
        msbsdf_sample_result smp;
        msbsdf_rgb f;
        float p;
        calls += 5;
        if (msbsdf_sample(m, wi, &rng, &smp) == MSBSDF_STATUS_OK) {
            checksum += smp.weight.g;
        }
        if (msbsdf_eval(m, wi, smp.wo, &rng, &f) == MSBSDF_STATUS_OK) {
            checksum += f.g;
        }
        if (msbsdf_eval(m, wi, wo, NULL, &f) == MSBSDF_STATUS_OK) {
            checksum += f.r;
        }
        if (msbsdf_pdf(m, wi, wo, &p) == MSBSDF_STATUS_OK) {
            checksum += p;
        }
        /* Refused calls take the error paths. */
        if ((i & 15) == 0) {
            calls += 4;
            checksum += msbsdf_eval(m, v3((float)NAN, 0.0f, 1.0f), wo, &rng, &f);
            checksum += msbsdf_pdf(NULL, wi, wo, &p);
            checksum += msbsdf_sample(m, wi, NULL, &smp);
            checksum += (double)msbsdf_status_message(msbsdf_sample(m, v3(0, 0, 0), &rng, &smp))[0];
        }
    }
    for (g = 0; g < 2; g++) {
        msbsdf_material_destroy(inited[g]); /* no-op on caller storage */
    }
    msbsdf_material_destroy(NULL);
    malloc_count_enabled = 0;
    allocs = malloc_count_allocs;
    frees = malloc_count_frees;
    printf("hot path: %ld library calls plus %d rng draws: %lu allocations, %lu frees "
           "(checksum %.6g)\n",
           calls, ROUNDS * 5, allocs, frees, checksum);
    CHECK(allocs == 0, "%lu allocations during %ld hot-path calls", allocs, calls);
    CHECK(frees == 0, "%lu frees during %ld hot-path calls", frees, calls);
    CHECK(isfinite(checksum) && checksum > 0.0, "checksum %g", checksum);

    malloc_count_allocs = malloc_count_frees = 0;
    malloc_count_enabled = 1;
    msbsdf_material_destroy(created[0]);
    msbsdf_material_destroy(created[1]);
    malloc_count_enabled = 0;
    destroy_frees = malloc_count_frees;
    printf("msbsdf_material_create: %lu allocations for 2 materials; destroy: %lu frees\n",
           create_allocs, destroy_frees);
    CHECK(destroy_frees == create_allocs, "create allocated %lu blocks, destroy freed %lu",
          create_allocs, destroy_frees);
    all_models_phase();
    return check_finish("no_alloc");
}
