/*
 * A composition keeps its inner material by value: destroying the inner
 * material first and then using the outer one is safe (run under
 * AddressSanitizer by tests/c_conformance.rs, which reports any
 * use-after-free), and gives bit for bit what it gave before.
 */
#include <string.h>

#include "check.h"

int main(void)
{
    msbsdf_material_desc d, c;
    msbsdf_material *facets = NULL, *outer = NULL;
    msbsdf_rng rng;
    msbsdf_vec3 wi, wo;
    msbsdf_rgb before[64], after[64];
    msbsdf_sample_result s;
    int i, same = 1;
    double sum = 0.0;

    msbsdf_material_desc_init(&d);
    d.model = MSBSDF_MODEL_HEITZ_RANDOM_WALK;
    d.alpha_x = d.alpha_y = 0.4f;
    CHECK_STATUS(msbsdf_material_create(&d, &facets), MSBSDF_STATUS_OK);
    msbsdf_material_desc_init(&c);
    c.model = MSBSDF_MODEL_NULL_SCATTERING;
    c.facet = MSBSDF_FACET_MATERIAL;
    c.alpha_x = c.alpha_y = 1.0f;
    c.inner = facets;
    CHECK_STATUS(msbsdf_material_create(&c, &outer), MSBSDF_STATUS_OK);

    wi.x = 0.3f; wi.y = 0.0f; wi.z = 0.9f;
    wo.x = -0.2f; wo.y = 0.3f; wo.z = 0.8f;
    msbsdf_rng_seed(&rng, 9, 1);
    for (i = 0; i < 64; i++)
        CHECK_STATUS(msbsdf_eval(outer, wi, wo, &rng, &before[i]), MSBSDF_STATUS_OK);

    /* Destroy the inner material, overwrite the freed memory's neighbourhood
       by allocating again, then use the outer one. */
    msbsdf_material_destroy(facets);
    facets = NULL;
    CHECK_STATUS(msbsdf_material_create(&d, &facets), MSBSDF_STATUS_OK);
    msbsdf_material_destroy(facets);

    msbsdf_rng_seed(&rng, 9, 1);
    for (i = 0; i < 64; i++) {
        CHECK_STATUS(msbsdf_eval(outer, wi, wo, &rng, &after[i]), MSBSDF_STATUS_OK);
        same &= SAME_BITS(before[i], after[i]);
    }
    CHECK(same, "the outer material changed when its inner one was destroyed");
    for (i = 0; i < 2000; i++) {
        CHECK_STATUS(msbsdf_sample(outer, wi, &rng, &s), MSBSDF_STATUS_OK);
        sum += s.weight.g;
    }
    /* Mirror facets through an energy-conserving walk: every path exits. */
    CHECK(sum / 2000.0 > 1.0 - 1e-5 && sum / 2000.0 < 1.0 + 1e-5, "albedo %g", sum / 2000.0);
    msbsdf_material_destroy(outer);

    /* The same with the outer material in caller storage (msbsdf_material_init). */
    {
        static union {
            unsigned char bytes[4096];
            long double align_ld;
            void *align_p;
        } st;
        msbsdf_material *in_storage = NULL;
        msbsdf_rgb f0, f1;
        msbsdf_rng r0, r1;
        facets = NULL;
        CHECK_STATUS(msbsdf_material_create(&d, &facets), MSBSDF_STATUS_OK);
        c.inner = facets;
        CHECK_STATUS(msbsdf_material_init(&c, st.bytes, sizeof st.bytes, &in_storage), MSBSDF_STATUS_OK);
        msbsdf_rng_seed(&r0, 3, 3);
        r1 = r0;
        CHECK_STATUS(msbsdf_eval(in_storage, wi, wo, &r0, &f0), MSBSDF_STATUS_OK);
        msbsdf_material_destroy(facets);
        CHECK_STATUS(msbsdf_eval(in_storage, wi, wo, &r1, &f1), MSBSDF_STATUS_OK);
        CHECK(SAME_BITS(f0, f1) && f0.g > 0.0f, "init material changed after its inner one was destroyed");
    }
    return check_finish("inner_lifetime");
}
