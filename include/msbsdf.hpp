/*
 * msbsdf.hpp: header-only C++ wrapper of the msbsdf C API (C++11 or later;
 * tested as C++17 with -Wall -Wextra -pedantic -Werror).
 *
 * Example (extracted and compiled by tests/c_conformance.rs):
 *
 *   float sampled_weight(std::uint64_t pixel, std::uint64_t sample) {
 *       msbsdf::Result<msbsdf::Material> gold = msbsdf::Material::create(
 *           msbsdf::Desc().model(MSBSDF_MODEL_SINGLE).alpha(0.5f)
 *               .eta(msbsdf::rgb(0.143f, 0.374f, 1.442f)).k(msbsdf::rgb(3.983f, 2.385f, 1.603f)));
 *       if (!gold) return -1.0f; // gold.message() says why
 *       msbsdf::Rng rng(pixel, sample);
 *       msbsdf::Vec3 wi = msbsdf::vec3(0.5f, 0.0f, 0.8660254f);
 *       msbsdf::Context ctx; // radiance, both lobes
 *       msbsdf::Result<msbsdf::SampleRecord> s =
 *           gold.value.sample_with(ctx, wi, rng.next_float(), rng.next_float(), rng.next_float());
 *       return s ? s.value.weight.g : 0.0f;
 *   }
 *
 * No exceptions: every call returns a Result<T> carrying the C status and the
 * value (zeroed on failure, as the C API guarantees). Material owns its
 * handle (move-only; destroyed with the object). All semantics, including
 * thread safety and the local frame, are those of msbsdf.h.
 */
#ifndef MSBSDF_HPP
#define MSBSDF_HPP

#include <cstddef>
#include <cstdint>

#include "msbsdf.h"

namespace msbsdf {

/** Local-frame direction (z = macro-surface normal). */
typedef msbsdf_vec3 Vec3;
/** Linear RGB triple. */
typedef msbsdf_rgb Rgb;
/** What sample returns: wo, weight = f |cos| / pdf, pdf, flags. */
typedef msbsdf_sample_result SampleResult;
/** What sample_with returns: flags, wo, weight, pdf and the relative eta. */
typedef msbsdf_sample_record SampleRecord;
/** A C status code (MSBSDF_STATUS_*). */
typedef msbsdf_status Status;

/** The static description of a status; never NULL. */
inline const char *status_message(Status s) noexcept { return msbsdf_status_message(s); }

/** The library version as (major << 16) | (minor << 8) | patch. */
inline std::uint32_t version() noexcept { return msbsdf_version(); }

/** A value with the status of the call that produced it. */
template <class T> struct Result {
    /** MSBSDF_STATUS_OK or the reason the call was refused. */
    Status status;
    /** The output (zero-initialised when status is not OK). */
    T value;

    /** True when status is MSBSDF_STATUS_OK. */
    bool ok() const noexcept { return status == MSBSDF_STATUS_OK; }
    /** Same as ok(). */
    explicit operator bool() const noexcept { return ok(); }
    /** The description of status. */
    const char *message() const noexcept { return msbsdf_status_message(status); }
};

/** PCG32 generator, a plain value (copy it to fork a stream). */
class Rng {
public:
    /** Seeded as pcg32_srandom_r(0, 0). */
    Rng() noexcept { msbsdf_rng_seed(&state_, 0, 0); }
    /** Seeded as pcg32_srandom_r(seed, stream). */
    Rng(std::uint64_t seed, std::uint64_t stream) noexcept { msbsdf_rng_seed(&state_, seed, stream); }
    /** Wraps an existing C generator state. */
    explicit Rng(const msbsdf_rng &state) noexcept : state_(state) {}

    /** Next uniform float in [0, 1). */
    float next_float() noexcept { return msbsdf_rng_next_float(&state_); }
    /** The C state (for calls to the C API). */
    msbsdf_rng *c() noexcept { return &state_; }
    /** The C state. */
    const msbsdf_rng &state() const noexcept { return state_; }

private:
    msbsdf_rng state_;
};

class Material;

/** Per-call options (msbsdf_context): transport mode, lobes, rng. */
class Context {
public:
    /** Radiance transport, both lobes, no generator. */
    Context() noexcept { msbsdf_context_init(&c_); }
    /** MSBSDF_TRANSPORT_RADIANCE or MSBSDF_TRANSPORT_IMPORTANCE. */
    Context &transport(std::uint32_t v) noexcept { c_.transport = v; return *this; }
    /** MSBSDF_LOBE_* bits. */
    Context &lobes(std::uint32_t v) noexcept { c_.lobes = v; return *this; }
    /** The generator of stochastic models (kept by pointer: keep it alive). */
    Context &rng(Rng &r) noexcept { c_.rng = r.c(); return *this; }
    /** The C context. */
    const msbsdf_context *c() const noexcept { return &c_; }

private:
    msbsdf_context c_;
};

/** Builder over msbsdf_material_desc, starting from msbsdf_material_desc_init. */
class Desc {
public:
    /** Every field at its default (single scattering, GGX 0.5, mirror conductor). */
    Desc() noexcept { msbsdf_material_desc_init(&d_); }
    /** Wraps an existing C description. */
    explicit Desc(const msbsdf_material_desc &d) noexcept : d_(d) {}

    /** MSBSDF_MODEL_*. */
    Desc &model(std::uint32_t v) noexcept { d_.model = v; return *this; }
    /** MSBSDF_ESTIMATOR_*. */
    Desc &estimator(std::uint32_t v) noexcept { d_.estimator = v; return *this; }
    /** MSBSDF_NDF_*. */
    Desc &ndf(std::uint32_t v) noexcept { d_.ndf = v; return *this; }
    /** MSBSDF_FACET_*. */
    Desc &facet(std::uint32_t v) noexcept { d_.facet = v; return *this; }
    /** Isotropic roughness. */
    Desc &alpha(float a) noexcept { d_.alpha_x = a; d_.alpha_y = a; return *this; }
    /** Anisotropic roughness. */
    Desc &alpha(float ax, float ay) noexcept { d_.alpha_x = ax; d_.alpha_y = ay; return *this; }
    /** NDF shape parameter (Student-T gamma). */
    Desc &shape(float v) noexcept { d_.shape = v; return *this; }
    /** Conductor: real IOR per channel; dielectric: eta.r = inside / outside. */
    Desc &eta(Rgb v) noexcept { d_.eta = v; return *this; }
    /** Dielectric: inside / outside index (all channels). */
    Desc &eta(float v) noexcept { d_.eta.r = v; d_.eta.g = v; d_.eta.b = v; return *this; }
    /** Conductor: imaginary IOR per channel. */
    Desc &k(Rgb v) noexcept { d_.k = v; return *this; }
    /** Diffuse facets: albedo. */
    Desc &albedo(Rgb v) noexcept { d_.albedo = v; return *this; }
    /** Bounce limit (0 = model default). */
    Desc &max_bounces(std::uint32_t v) noexcept { d_.max_bounces = v; return *this; }
    /** MSBSDF_MODEL_AUTO tolerance. */
    Desc &tolerance(float v) noexcept { d_.tolerance = v; return *this; }
    /** MSBSDF_CONDUCTOR_TWO_SIDED (default) or MSBSDF_CONDUCTOR_ONE_SIDED. */
    Desc &conductor_sides(std::uint32_t v) noexcept { d_.conductor_sides = v; return *this; }
    /** MSBSDF_FACET_MATERIAL: facets scatter as `m` (copied at create). */
    inline Desc &inner(const Material &m) noexcept;

    /** The C description. */
    const msbsdf_material_desc &c() const noexcept { return d_; }
    /** The C description, for fields the builder does not name. */
    msbsdf_material_desc &c() noexcept { return d_; }

private:
    msbsdf_material_desc d_;
};

/** Owns a material handle from msbsdf_material_create. Move-only. */
class Material {
public:
    /** An empty material (every query returns MSBSDF_STATUS_NULL_POINTER). */
    Material() noexcept : m_(nullptr) {}
    /** Takes ownership of a handle from msbsdf_material_create. */
    explicit Material(msbsdf_material *owned) noexcept : m_(owned) {}
    ~Material() { msbsdf_material_destroy(m_); }

    Material(const Material &) = delete;
    Material &operator=(const Material &) = delete;
    /** Takes the handle of `o`, which becomes empty. */
    Material(Material &&o) noexcept : m_(o.m_) { o.m_ = nullptr; }
    /** Destroys the current handle and takes the one of `o`. */
    Material &operator=(Material &&o) noexcept {
        if (this != &o) {
            msbsdf_material_destroy(m_);
            m_ = o.m_;
            o.m_ = nullptr;
        }
        return *this;
    }

    /** Validates `d` and creates the material; an empty one on failure. */
    static Result<Material> create(const Desc &d) noexcept { return create(d.c()); }
    /** Same, from a C description. */
    static Result<Material> create(const msbsdf_material_desc &d) noexcept {
        msbsdf_material *m = nullptr;
        Status s = msbsdf_material_create(&d, &m);
        Result<Material> r = {s, Material(m)};
        return r;
    }

    /** f(wi, wo) |cos theta_o| (stochastic models advance `rng`). */
    Result<Rgb> eval(Vec3 wi, Vec3 wo, Rng &rng) const noexcept {
        Result<Rgb> r = {MSBSDF_STATUS_OK, Rgb()};
        r.status = msbsdf_eval(m_, wi, wo, rng.c(), &r.value);
        return r;
    }
    /** Same without a generator (deterministic models only; others give
        MSBSDF_STATUS_NULL_POINTER). */
    Result<Rgb> eval(Vec3 wi, Vec3 wo) const noexcept {
        Result<Rgb> r = {MSBSDF_STATUS_OK, Rgb()};
        r.status = msbsdf_eval(m_, wi, wo, nullptr, &r.value);
        return r;
    }
    /** Samples an outgoing direction for `wi`. */
    Result<SampleResult> sample(Vec3 wi, Rng &rng) const noexcept {
        Result<SampleResult> r = {MSBSDF_STATUS_OK, SampleResult()};
        r.status = msbsdf_sample(m_, wi, rng.c(), &r.value);
        return r;
    }
    /** Density per solid angle with which sample picks `wo`. */
    Result<float> pdf(Vec3 wi, Vec3 wo) const noexcept {
        Result<float> r = {MSBSDF_STATUS_OK, 0.0f};
        r.status = msbsdf_pdf(m_, wi, wo, &r.value);
        return r;
    }

    /** f(wi, wo) |cos theta_o| and the pdf in one call, under `ctx`. */
    Result<Rgb> eval_pdf(const Context &ctx, Vec3 wi, Vec3 wo, float &pdf) const noexcept {
        Result<Rgb> r = {MSBSDF_STATUS_OK, Rgb()};
        r.status = msbsdf_eval_pdf(m_, ctx.c(), wi, wo, &r.value, &pdf);
        return r;
    }
    /** Samples from the caller's uniforms in [0, 1), under `ctx`. */
    Result<SampleRecord> sample_with(const Context &ctx, Vec3 wi, float u_lobe, float u1, float u2) const noexcept {
        Result<SampleRecord> r = {MSBSDF_STATUS_OK, SampleRecord()};
        msbsdf_sample_record_init(&r.value);
        r.status = msbsdf_sample_with(m_, ctx.c(), wi, u_lobe, u1, u2, &r.value);
        return r;
    }
    /** MSBSDF_MATERIAL_* bits. */
    Result<std::uint32_t> flags() const noexcept {
        Result<std::uint32_t> r = {MSBSDF_STATUS_OK, 0u};
        r.status = msbsdf_material_flags(m_, &r.value);
        return r;
    }

    /** The C handle (still owned by this object), or NULL. */
    const msbsdf_material *get() const noexcept { return m_; }
    /** True when a handle is held. */
    explicit operator bool() const noexcept { return m_ != nullptr; }
    /** Gives up ownership: the caller destroys the returned handle. */
    msbsdf_material *release() noexcept {
        msbsdf_material *m = m_;
        m_ = nullptr;
        return m;
    }

private:
    msbsdf_material *m_;
};

inline Desc &Desc::inner(const Material &m) noexcept {
    d_.inner = m.get();
    return *this;
}

/** A Vec3 from components. */
inline Vec3 vec3(float x, float y, float z) noexcept {
    Vec3 v = {x, y, z};
    return v;
}

/** An Rgb from components. */
inline Rgb rgb(float r, float g, float b) noexcept {
    Rgb c = {r, g, b};
    return c;
}

} // namespace msbsdf

#endif /* MSBSDF_HPP */
