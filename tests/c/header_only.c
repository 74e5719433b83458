/*
 * The header alone, twice (include guard), compiled as C99 and as C++11 with
 * -Wall -Wextra -pedantic -Werror by tests/c_conformance.rs. The function
 * uses every public type so the declarations are checked, not just parsed.
 */
#include "msbsdf.h"
#include "msbsdf.h"

unsigned header_only_uses_every_type(const msbsdf_material *m, msbsdf_rng *rng);

unsigned header_only_uses_every_type(const msbsdf_material *m, msbsdf_rng *rng)
{
    msbsdf_material_desc d = msbsdf_material_desc_default();
    msbsdf_vec3 wi = {0.0f, 0.0f, 1.0f};
    msbsdf_rgb f = {0.0f, 0.0f, 0.0f};
    msbsdf_sample_result s;
    unsigned version = MSBSDF_VERSION, bounces = MSBSDF_MAX_BOUNCES;
    msbsdf_status st = msbsdf_eval(m, wi, wi, rng, &f);
    st |= msbsdf_sample(m, wi, rng, &s);
    return st + d.struct_size + version + bounces;
}
