/*
 * msbsdf_sample_with on the random-walk models: u1, u2 drive the first
 * visible-normal draw. On a smooth-ish perfect conductor (alpha 0.05), where
 * nearly every path leaves after one bounce, HEITZ_RANDOM_WALK,
 * POSITION_FREE, INVARIANCE and BITTERLI_DEON must give the same direction
 * for the same uniforms drawn with two different generator states (the
 * first vertex follows u, whatever visible-normal sampler the walk uses),
 * and different directions for different uniforms. NULL_SCATTERING (alpha
 * 0.2, its smallest, GGX) draws its first vertex from the uniforms too, the
 * later collisions by rejection (d'Eon 2023, sec. 3.1); at alpha 0.2 about
 * 93% of its paths leave after one reflection, so it is held to the same
 * bounds. How often the walk's direction equals SINGLE's for the same
 * uniforms is printed.
 */
#include <math.h>

#include "check.h"

static float dist1(msbsdf_vec3 a, msbsdf_vec3 b)
{
    return fabsf(a.x - b.x) + fabsf(a.y - b.y) + fabsf(a.z - b.z);
}

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
        int follow = 0, valid = 0, differ = 0, like_single = 0;
        d.model = walks[k];
        /* The null-scattering walk refuses alpha < 0.2. */
        d.alpha_x = d.alpha_y = walks[k] == MSBSDF_MODEL_NULL_SCATTERING ? 0.2f : 0.05f;
        CHECK_STATUS(msbsdf_material_create(&d, &m), MSBSDF_STATUS_OK);
        for (i = 0; i < 2000; i++) {
            msbsdf_sample_record a, b, c, sg;
            msbsdf_rng other;
            float u1 = msbsdf_rng_next_float(&r), u2 = msbsdf_rng_next_float(&r);
            msbsdf_sample_record_init(&a);
            msbsdf_sample_record_init(&b);
            msbsdf_sample_record_init(&c);
            msbsdf_sample_record_init(&sg);
            ctx.rng = &r;
            CHECK_STATUS(msbsdf_sample_with(m, &ctx, wi, 0.5f, u1, u2, &a), MSBSDF_STATUS_OK);
            msbsdf_rng_seed(&other, 1000 + (uint64_t)i, 77);
            ctx.rng = &other; /* another generator state, the same uniforms */
            CHECK_STATUS(msbsdf_sample_with(m, &ctx, wi, 0.5f, u1, u2, &b), MSBSDF_STATUS_OK);
            /* other uniforms */
            CHECK_STATUS(msbsdf_sample_with(m, &ctx, wi, 0.5f, 1.0f - u1 * 0.999f, u2 * 0.5f, &c), MSBSDF_STATUS_OK);
            CHECK_STATUS(msbsdf_sample_with(single, &ctx, wi, 0.5f, u1, u2, &sg), MSBSDF_STATUS_OK);
            valid += a.flags == (MSBSDF_SAMPLE_REFLECTION | MSBSDF_SAMPLE_GLOSSY) || a.flags == MSBSDF_SAMPLE_ABSORBED;
            follow += dist1(a.wo, b.wo) < 1e-3f;
            differ += dist1(a.wo, c.wo) > 1e-3f;
            like_single += dist1(a.wo, sg.wo) < 1e-3f;
        }
        CHECK(valid == 2000, "model %u: %d valid flags", (unsigned)walks[k], valid);
        /* At these roughnesses more than 90% of paths leave after one bounce. */
        CHECK(follow > 1600, "model %u: only %d of 2000 samples follow u", (unsigned)walks[k], follow);
        CHECK(differ > 1600, "model %u: only %d of 2000 samples change with u", (unsigned)walks[k], differ);
        printf("model %u: %d of 2000 samples repeat for the same uniforms, %d change with them, %d equal SINGLE's\n",
               (unsigned)walks[k], follow, differ, like_single);
        msbsdf_material_destroy(m);
    }
    msbsdf_material_destroy(single);
    return check_finish("uniforms_walks");
}
