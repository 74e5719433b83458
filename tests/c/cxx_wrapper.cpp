// The C++ wrapper include/msbsdf.hpp (tests/install.rs builds this as C++11
// and C++17 with -Wall -Wextra -pedantic -Werror against the installed
// headers): Material is move-only and owns its handle, Result carries the C
// status with a zeroed value on failure, and every wrapper call returns the
// same bits as the C call it wraps.
#include <cstdio>
#include <cstring>
#include <type_traits>
#include <utility>

#include <msbsdf.hpp>

static_assert(!std::is_copy_constructible<msbsdf::Material>::value, "Material copies");
static_assert(!std::is_copy_assignable<msbsdf::Material>::value, "Material copy-assigns");
static_assert(std::is_nothrow_move_constructible<msbsdf::Material>::value, "Material moves");
static_assert(std::is_nothrow_move_assignable<msbsdf::Material>::value, "Material moves");
static_assert(std::is_trivially_copyable<msbsdf::Rng>::value, "Rng is a value type");
static_assert(sizeof(msbsdf::Rng) == sizeof(msbsdf_rng), "Rng is the C state");

static unsigned long checks, failures;

static void check(bool ok, const char *what, int line) {
    ++checks;
    if (!ok) {
        ++failures;
        std::printf("FAIL cxx_wrapper.cpp:%d: %s\n", line, what);
    }
}
#define CHECK(c) check((c), #c, __LINE__)

template <class T> static bool same_bits(const T &a, const T &b) {
    return std::memcmp(&a, &b, sizeof(T)) == 0;
}

int main() {
    const msbsdf::Vec3 wi = msbsdf::vec3(0.3f, 0.1f, 0.9f);
    const msbsdf::Vec3 wo = msbsdf::vec3(-0.4f, 0.2f, 0.8f);

    CHECK(msbsdf::version() == MSBSDF_VERSION);
    CHECK(std::strcmp(msbsdf::status_message(MSBSDF_STATUS_OK), "ok") == 0);

    // Rng: the C generator bit for bit.
    msbsdf::Rng r(42, 54);
    msbsdf_rng c;
    msbsdf_rng_seed(&c, 42, 54);
    CHECK(same_bits(r.state(), c));
    CHECK(r.next_float() == msbsdf_rng_next_float(&c));
    msbsdf::Rng copy = r;
    CHECK(copy.next_float() == r.next_float());

    // A refused description: status, empty material, message.
    msbsdf::Result<msbsdf::Material> bad = msbsdf::Material::create(msbsdf::Desc().alpha(-1.0f));
    CHECK(bad.status == MSBSDF_STATUS_INVALID_ARGUMENT);
    CHECK(!bad && !bad.value && bad.value.get() == nullptr);
    CHECK(std::strcmp(bad.message(), msbsdf_status_message(MSBSDF_STATUS_INVALID_ARGUMENT)) == 0);
    msbsdf::Result<msbsdf::Material> unknown =
        msbsdf::Material::create(msbsdf::Desc().model(12345u));
    CHECK(unknown.status == MSBSDF_STATUS_UNKNOWN_CONSTANT);

    // An empty material refuses queries with zeroed outputs.
    msbsdf::Material empty;
    msbsdf::Result<msbsdf::Rgb> fe = empty.eval(wi, wo, r);
    CHECK(fe.status == MSBSDF_STATUS_NULL_POINTER && fe.value.r == 0.0f);
    CHECK(empty.pdf(wi, wo).status == MSBSDF_STATUS_NULL_POINTER);
    CHECK(empty.sample(wi, r).status == MSBSDF_STATUS_NULL_POINTER);

    // A valid material: the same bits as the C API on the same handle.
    msbsdf::Desc d;
    d.model(MSBSDF_MODEL_SINGLE).ndf(MSBSDF_NDF_GGX).facet(MSBSDF_FACET_DIELECTRIC).alpha(0.3f, 0.2f).eta(1.5f);
    CHECK(d.c().eta.r == 1.5f && d.c().alpha_x == 0.3f && d.c().alpha_y == 0.2f);
    msbsdf::Result<msbsdf::Material> glass = msbsdf::Material::create(d);
    CHECK(glass.ok());
    const msbsdf_material *h = glass.value.get();
    {
        msbsdf::Rng a(7, 1);
        msbsdf_rng b;
        msbsdf_rng_seed(&b, 7, 1);
        msbsdf_sample_result sc;
        msbsdf::Result<msbsdf::SampleResult> sw = glass.value.sample(wi, a);
        CHECK(msbsdf_sample(h, wi, &b, &sc) == MSBSDF_STATUS_OK && sw.ok());
        CHECK(same_bits(sw.value, sc) && same_bits(a.state(), b));
        msbsdf_rgb fc;
        msbsdf::Result<msbsdf::Rgb> fw = glass.value.eval(wi, wo, a);
        CHECK(msbsdf_eval(h, wi, wo, &b, &fc) == MSBSDF_STATUS_OK && fw.ok());
        CHECK(same_bits(fw.value, fc));
        msbsdf::Result<msbsdf::Rgb> fn = glass.value.eval(wi, wo);
        CHECK(fn.ok() && same_bits(fn.value, fc));
        float pc = -1.0f;
        msbsdf::Result<float> pw = glass.value.pdf(wi, wo);
        CHECK(msbsdf_pdf(h, wi, wo, &pc) == MSBSDF_STATUS_OK && pw.ok() && pw.value == pc);
        msbsdf::Result<float> pbad = glass.value.pdf(wi, msbsdf::vec3(0.0f, 0.0f, 0.0f));
        CHECK(pbad.status == MSBSDF_STATUS_INVALID_DIRECTION && pbad.value == 0.0f);

        // The 0.3 calls: the wrapper gives the C bits.
        msbsdf::Context ctx;
        ctx.transport(MSBSDF_TRANSPORT_IMPORTANCE).lobes(MSBSDF_LOBE_ALL);
        float pe = -1.0f;
        msbsdf::Result<msbsdf::Rgb> fe2 = glass.value.eval_pdf(ctx, wi, wo, pe);
        CHECK(fe2.ok() && same_bits(fe2.value, fc) && pe == pc);
        msbsdf_context cc;
        msbsdf_context_init(&cc);
        msbsdf_sample_record rc;
        msbsdf_sample_record_init(&rc);
        msbsdf::Context radiance;
        msbsdf::Result<msbsdf::SampleRecord> rw = glass.value.sample_with(radiance, wi, 0.7f, 0.2f, 0.4f);
        CHECK(msbsdf_sample_with(h, &cc, wi, 0.7f, 0.2f, 0.4f, &rc) == MSBSDF_STATUS_OK && rw.ok());
        CHECK(same_bits(rw.value, rc) && rw.value.struct_size == sizeof(msbsdf_sample_record));
        msbsdf::Result<std::uint32_t> fl = glass.value.flags();
        CHECK(fl.ok() && fl.value == (MSBSDF_MATERIAL_REFLECTION | MSBSDF_MATERIAL_TRANSMISSION |
                                      MSBSDF_MATERIAL_GLOSSY | MSBSDF_MATERIAL_ANISOTROPIC));
        CHECK(d.c().eta.g == 1.5f && d.c().eta.b == 1.5f); // eta(float) sets every channel
    }

    // Moves transfer the handle; the source becomes empty.
    msbsdf::Material moved(std::move(glass.value));
    CHECK(moved.get() == h && !glass.value);
    msbsdf::Material assigned;
    assigned = std::move(moved);
    CHECK(assigned.get() == h && !moved);
    assigned = msbsdf::Material::create(msbsdf::Desc()).value; // frees the old handle
    CHECK(assigned && assigned.get() != nullptr);
    msbsdf_material *raw = assigned.release();
    CHECK(!assigned && raw != nullptr);
    msbsdf_material_destroy(raw);

    // Composition through the builder.
    msbsdf::Material base = msbsdf::Material::create(msbsdf::Desc()).value;
    msbsdf::Desc layered;
    layered.facet(MSBSDF_FACET_MATERIAL).inner(base);
    CHECK(layered.c().inner == base.get());

    if (failures == 0) {
        std::printf("cxx_wrapper: ALL %lu CHECKS PASSED\n", checks);
        return 0;
    }
    std::printf("cxx_wrapper: %lu OF %lu CHECKS FAILED\n", failures, checks);
    return 1;
}
