// minimal.cpp: the C++ wrapper (include/msbsdf.hpp) in a few lines.
//
// Creates rough gold with every model this build supports (the others
// answer MSBSDF_STATUS_UNSUPPORTED and are skipped), prints eval / pdf for
// one pair of directions and the directional albedo at 45 degrees from
// sample weights, with a fixed seed. Build after installing
// (scripts/install.sh PREFIX):
//   c++ -std=c++17 minimal.cpp $(pkg-config --cflags --libs msbsdf) -o minimal_cpp
#include <cmath>
#include <cstdio>
#include <utility>
#include <vector>

#include <msbsdf.hpp>

namespace {

msbsdf::Vec3 dir_deg(float theta_deg, float phi_deg) {
    const float d2r = 3.14159265f / 180.0f;
    return msbsdf::vec3(std::sin(theta_deg * d2r) * std::cos(phi_deg * d2r),
                        std::sin(theta_deg * d2r) * std::sin(phi_deg * d2r),
                        std::cos(theta_deg * d2r));
}

struct Named {
    const char *name;
    msbsdf::Material material;
};

} // namespace

int main() {
    const std::uint32_t models[] = {MSBSDF_MODEL_SINGLE, MSBSDF_MODEL_ENERGY_COMPENSATED,
                                    MSBSDF_MODEL_HEITZ_RANDOM_WALK};
    const char *names[] = {"single", "energy_compensated", "heitz_random_walk"};
    std::vector<Named> materials;
    for (int i = 0; i < 3; ++i) {
        msbsdf::Desc d;
        d.model(models[i])
            .ndf(MSBSDF_NDF_GGX)
            .facet(MSBSDF_FACET_CONDUCTOR)
            .alpha(0.5f)
            .eta(msbsdf::rgb(0.143f, 0.374f, 1.442f))
            .k(msbsdf::rgb(3.983f, 2.385f, 1.603f));
        msbsdf::Result<msbsdf::Material> m = msbsdf::Material::create(d);
        if (m.status == MSBSDF_STATUS_UNSUPPORTED) {
            std::printf("%-20s not in this build\n", names[i]);
            continue;
        }
        if (!m) {
            std::fprintf(stderr, "create %s: %s\n", names[i], m.message());
            return 1;
        }
        materials.push_back(Named{names[i], std::move(m.value)});
    }

    const int samples = 20000;
    const msbsdf::Vec3 wi = dir_deg(45.0f, 0.0f);
    const msbsdf::Vec3 wo = dir_deg(30.0f, 180.0f);
    std::printf("model                f|cos| (r g b) at 45 -> 30 deg      pdf    albedo_r at 45 deg\n");
    for (const Named &n : materials) {
        msbsdf::Rng rng(42, 54);
        msbsdf::Result<msbsdf::Rgb> f = n.material.eval(wi, wo, rng);
        msbsdf::Result<float> p = n.material.pdf(wi, wo);
        if (!f || !p) {
            std::fprintf(stderr, "%s: eval/pdf failed: %s\n", n.name, f ? p.message() : f.message());
            return 1;
        }
        double albedo = 0.0;
        for (int s = 0; s < samples; ++s) {
            msbsdf::Result<msbsdf::SampleResult> r = n.material.sample(wi, rng);
            if (!r) {
                std::fprintf(stderr, "%s: sample failed: %s\n", n.name, r.message());
                return 1;
            }
            albedo += r.value.weight.r;
        }
        albedo /= samples;
        std::printf("%-20s (%.4f %.4f %.4f)  %7.4f  %.4f\n", n.name, f.value.r, f.value.g,
                    f.value.b, p.value, albedo);
        if (!(albedo >= 0.0 && albedo <= 1.05)) {
            std::fprintf(stderr, "%s: albedo %g outside [0, 1.05]\n", n.name, albedo);
            return 1;
        }
    }
    if (materials.empty()) {
        std::fprintf(stderr, "no model available\n");
        return 1;
    }
    std::printf("minimal.cpp: OK (%zu models)\n", materials.size());
    return 0;
}
