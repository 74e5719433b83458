/*
 * msbsdf_sample_with on the random-walk models: u1, u2 drive the first
 * visible-normal draw. With WALKS_TAKE_UNIFORMS (set by
 * tests/c_conformance.rs) a smooth-ish perfect conductor (alpha 0.05,
 * nearly all paths one bounce) must put its sample where SINGLE puts the
 * same uniforms; without it only statuses and flags are checked.
 */
#include <math.h>

#include "check.h"

#ifndef WALKS_TAKE_UNIFORMS
#error "compile with -DWALKS_TAKE_UNIFORMS=0 or 1"
#endif

int main(void)
{
    static const uint32_t walks[5] = {MSBSDF_MODEL_HEITZ_RANDOM_WALK, MSBSDF_MODEL_POSITION_FREE,
                                      MSBSDF_MODEL_INVARIANCE, MSBSDF_MODEL_BITTERLI_DEON,
                                      MSBSDF_MODEL_NULL_SCATTERING};
    msbsdf_material_desc d;
    msbsdf_material *single = NULL;
    msbsdf_context ctx;
    msbsdf_rng r;
    int k, i;
    msbsdf_vec3 wi;
    wi.x = 0.5f; wi.y = 0.0f; wi.z = 0.8660254f;
    msbsdf_material_desc_init(&d);
    d.alpha_x = d.alpha_y = 0.05f;
    CHECK_STATUS(msbsdf_material_create(&d, &single), MSBSDF_STATUS_OK);
    msbsdf_context_init(&ctx);
    msbsdf_rng_seed(&r, 51, 1);
    ctx.rng = &r;
    for (k = 0; k < 5; k++) {
        msbsdf_material *m = NULL;
        int follow = 0, valid = 0;
        d.model = walks[k];
        /* The null-scattering walk refuses alpha < 0.2. */
        d.alpha_x = d.alpha_y = walks[k] == MSBSDF_MODEL_NULL_SCATTERING ? 0.2f : 0.05f;
        CHECK_STATUS(msbsdf_material_create(&d, &m), MSBSDF_STATUS_OK);
        for (i = 0; i < 2000; i++) {
            msbsdf_sample_record a, b;
            float u1 = msbsdf_rng_next_float(&r), u2 = msbsdf_rng_next_float(&r);
            msbsdf_sample_record_init(&a);
            msbsdf_sample_record_init(&b);
            CHECK_STATUS(msbsdf_sample_with(m, &ctx, wi, 0.5f, u1, u2, &a), MSBSDF_STATUS_OK);
            CHECK_STATUS(msbsdf_sample_with(single, &ctx, wi, 0.5f, u1, u2, &b), MSBSDF_STATUS_OK);
            valid += a.flags == (MSBSDF_SAMPLE_REFLECTION | MSBSDF_SAMPLE_GLOSSY) || a.flags == MSBSDF_SAMPLE_ABSORBED;
            follow += fabsf(a.wo.x - b.wo.x) + fabsf(a.wo.y - b.wo.y) + fabsf(a.wo.z - b.wo.z) < 1e-3f;
        }
        CHECK(valid == 2000, "model %u: %d valid flags", (unsigned)walks[k], valid);
        if (WALKS_TAKE_UNIFORMS && walks[k] != MSBSDF_MODEL_NULL_SCATTERING) {
            /* At alpha 0.05 more than 99% of paths leave after one bounce. */
            CHECK(follow > 1800, "model %u: only %d of 2000 samples follow u", (unsigned)walks[k], follow);
        }
        printf("model %u: %d of 2000 samples follow the uniforms\n", (unsigned)walks[k], follow);
        msbsdf_material_destroy(m);
    }
    msbsdf_material_destroy(single);
    return check_finish("uniforms_walks");
}
