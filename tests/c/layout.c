/*
 * Layout and version conformance: the C view of every public struct must be
 * the Rust view. tests/c_conformance.rs passes Rust's size_of / align_of /
 * offset_of! values as -DRUST_SIZEOF_<T>, -DRUST_ALIGNOF_<T> and
 * -DRUST_OFFSETOF_<T>_<field>; a mismatch fails at compile time. The program
 * is compiled as C99 (array-size trick, offsetof-based alignment) and as C11
 * (_Static_assert, _Alignof).
 */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "check.h"

#if !defined(RUST_SIZEOF_msbsdf_material_desc) || !defined(RUST_VERSION_PACKED)
#error "compile with the -D values tests/c_conformance.rs passes"
#endif

#if defined(__STDC_VERSION__) && __STDC_VERSION__ >= 201112L
#define STATIC_CHECK(cond, tag) _Static_assert(cond, #tag)
#define C_ALIGNOF(T) _Alignof(T)
#else
#define STATIC_CHECK(cond, tag) typedef char static_check_##tag[(cond) ? 1 : -1]
#define C_ALIGNOF(T) offsetof(struct align_probe_##T, t)
#endif

/* Alignment measured without C11: the offset of T after a char. */
#define ALIGN_PROBE(T) struct align_probe_##T { char c; T t; }
ALIGN_PROBE(msbsdf_vec3);
ALIGN_PROBE(msbsdf_rgb);
ALIGN_PROBE(msbsdf_rng);
ALIGN_PROBE(msbsdf_material_desc);
ALIGN_PROBE(msbsdf_sample_result);
ALIGN_PROBE(msbsdf_context);
ALIGN_PROBE(msbsdf_sample_record);
#define PROBE_ALIGNOF(T) offsetof(struct align_probe_##T, t)

#define ROUND_UP(x, a) ((((x) + (a) - 1) / (a)) * (a))
#define FIELD_SIZE(T, F) sizeof(((T *)0)->F)

#define CHECK_TYPE(T)                                                   \
    STATIC_CHECK(sizeof(T) == RUST_SIZEOF_##T, sizeof_##T);             \
    STATIC_CHECK(C_ALIGNOF(T) == RUST_ALIGNOF_##T, alignof_##T);        \
    STATIC_CHECK(PROBE_ALIGNOF(T) == RUST_ALIGNOF_##T, probe_alignof_##T)
#define CHECK_FIELD(T, F) \
    STATIC_CHECK(offsetof(T, F) == RUST_OFFSETOF_##T##_##F, offsetof_##T##_##F)
/* The listed last field ends the struct (up to tail padding): no field of
   the header is missing from the lists below. */
#define CHECK_LAST_FIELD(T, F)                                                    \
    STATIC_CHECK(ROUND_UP(offsetof(T, F) + FIELD_SIZE(T, F), C_ALIGNOF(T)) == sizeof(T), \
                 last_field_##T)

CHECK_TYPE(msbsdf_vec3);
CHECK_FIELD(msbsdf_vec3, x);
CHECK_FIELD(msbsdf_vec3, y);
CHECK_FIELD(msbsdf_vec3, z);
CHECK_LAST_FIELD(msbsdf_vec3, z);

CHECK_TYPE(msbsdf_rgb);
CHECK_FIELD(msbsdf_rgb, r);
CHECK_FIELD(msbsdf_rgb, g);
CHECK_FIELD(msbsdf_rgb, b);
CHECK_LAST_FIELD(msbsdf_rgb, b);

CHECK_TYPE(msbsdf_rng);
CHECK_FIELD(msbsdf_rng, state);
CHECK_FIELD(msbsdf_rng, inc);
CHECK_LAST_FIELD(msbsdf_rng, inc);

CHECK_TYPE(msbsdf_material_desc);
CHECK_FIELD(msbsdf_material_desc, struct_size);
CHECK_FIELD(msbsdf_material_desc, model);
CHECK_FIELD(msbsdf_material_desc, estimator);
CHECK_FIELD(msbsdf_material_desc, ndf);
CHECK_FIELD(msbsdf_material_desc, facet);
CHECK_FIELD(msbsdf_material_desc, alpha_x);
CHECK_FIELD(msbsdf_material_desc, alpha_y);
CHECK_FIELD(msbsdf_material_desc, shape);
CHECK_FIELD(msbsdf_material_desc, eta);
CHECK_FIELD(msbsdf_material_desc, k);
CHECK_FIELD(msbsdf_material_desc, albedo);
CHECK_FIELD(msbsdf_material_desc, max_bounces);
CHECK_FIELD(msbsdf_material_desc, tolerance);
CHECK_FIELD(msbsdf_material_desc, inner);
CHECK_FIELD(msbsdf_material_desc, conductor_sides);
CHECK_LAST_FIELD(msbsdf_material_desc, conductor_sides);

CHECK_TYPE(msbsdf_context);
CHECK_FIELD(msbsdf_context, struct_size);
CHECK_FIELD(msbsdf_context, transport);
CHECK_FIELD(msbsdf_context, lobes);
CHECK_FIELD(msbsdf_context, rng);
CHECK_LAST_FIELD(msbsdf_context, rng);

CHECK_TYPE(msbsdf_sample_record);
CHECK_FIELD(msbsdf_sample_record, struct_size);
CHECK_FIELD(msbsdf_sample_record, flags);
CHECK_FIELD(msbsdf_sample_record, wo);
CHECK_FIELD(msbsdf_sample_record, weight);
CHECK_FIELD(msbsdf_sample_record, pdf);
CHECK_FIELD(msbsdf_sample_record, eta);
CHECK_LAST_FIELD(msbsdf_sample_record, eta);

/* The 0.2 fields keep their 0.2 offsets (abi/layout.txt at 0.2.0): the
   first published layout ends with inner at 80, 88 bytes. */
STATIC_CHECK(offsetof(msbsdf_material_desc, inner) == 80, inner_offset_0_2);
STATIC_CHECK(offsetof(msbsdf_material_desc, conductor_sides) == 88, first_appended_field);

CHECK_TYPE(msbsdf_sample_result);
CHECK_FIELD(msbsdf_sample_result, wo);
CHECK_FIELD(msbsdf_sample_result, weight);
CHECK_FIELD(msbsdf_sample_result, pdf);
CHECK_FIELD(msbsdf_sample_result, flags);
CHECK_LAST_FIELD(msbsdf_sample_result, flags);

/* The status type and the struct_size field are 32-bit, as documented. */
STATIC_CHECK(sizeof(msbsdf_status) == 4, status_is_32_bit);
STATIC_CHECK(FIELD_SIZE(msbsdf_material_desc, struct_size) == 4, struct_size_is_32_bit);

/* Version macros: the packed macro against an independent packing done in
   Rust from CARGO_PKG_VERSION_*, and each part against Cargo's value. */
STATIC_CHECK(MSBSDF_VERSION_MAJOR == RUST_VERSION_MAJOR, version_major);
STATIC_CHECK(MSBSDF_VERSION_MINOR == RUST_VERSION_MINOR, version_minor);
STATIC_CHECK(MSBSDF_VERSION_PATCH == RUST_VERSION_PATCH, version_patch);
STATIC_CHECK(MSBSDF_VERSION == RUST_VERSION_PACKED, version_packed);
STATIC_CHECK(MSBSDF_VERSION_MINOR < 256 && MSBSDF_VERSION_PATCH < 256, version_fits);

#define PRINT_TYPE(T) \
    printf("layout %-22s size %3u align %u\n", #T, (unsigned)sizeof(T), (unsigned)PROBE_ALIGNOF(T))
#define PRINT_FIELD(T, F) printf("  %-14s offset %3u\n", #F, (unsigned)offsetof(T, F))

int main(void)
{
    uint32_t v = msbsdf_version();

    PRINT_TYPE(msbsdf_vec3);
    PRINT_TYPE(msbsdf_rgb);
    PRINT_TYPE(msbsdf_rng);
    PRINT_FIELD(msbsdf_rng, state);
    PRINT_FIELD(msbsdf_rng, inc);
    PRINT_TYPE(msbsdf_material_desc);
    PRINT_FIELD(msbsdf_material_desc, struct_size);
    PRINT_FIELD(msbsdf_material_desc, model);
    PRINT_FIELD(msbsdf_material_desc, estimator);
    PRINT_FIELD(msbsdf_material_desc, ndf);
    PRINT_FIELD(msbsdf_material_desc, facet);
    PRINT_FIELD(msbsdf_material_desc, alpha_x);
    PRINT_FIELD(msbsdf_material_desc, alpha_y);
    PRINT_FIELD(msbsdf_material_desc, shape);
    PRINT_FIELD(msbsdf_material_desc, eta);
    PRINT_FIELD(msbsdf_material_desc, k);
    PRINT_FIELD(msbsdf_material_desc, albedo);
    PRINT_FIELD(msbsdf_material_desc, max_bounces);
    PRINT_FIELD(msbsdf_material_desc, tolerance);
    PRINT_FIELD(msbsdf_material_desc, inner);
    PRINT_FIELD(msbsdf_material_desc, conductor_sides);
    PRINT_TYPE(msbsdf_context);
    PRINT_TYPE(msbsdf_sample_record);
    PRINT_TYPE(msbsdf_sample_result);
    PRINT_FIELD(msbsdf_sample_result, wo);
    PRINT_FIELD(msbsdf_sample_result, weight);
    PRINT_FIELD(msbsdf_sample_result, pdf);
    PRINT_FIELD(msbsdf_sample_result, flags);
    printf("material storage: size %u align %u\n", (unsigned)msbsdf_material_size(),
           (unsigned)msbsdf_material_align());
    printf("version 0x%06x (header %d.%d.%d)\n", (unsigned)v, MSBSDF_VERSION_MAJOR,
           MSBSDF_VERSION_MINOR, MSBSDF_VERSION_PATCH);

    /* Runtime: the library that is loaded is the one the header describes. */
    CHECK(v == (uint32_t)MSBSDF_VERSION, "msbsdf_version() = 0x%x, MSBSDF_VERSION = 0x%x",
          (unsigned)v, (unsigned)MSBSDF_VERSION);
    CHECK(v == (((uint32_t)MSBSDF_VERSION_MAJOR << 16) | ((uint32_t)MSBSDF_VERSION_MINOR << 8) |
                (uint32_t)MSBSDF_VERSION_PATCH),
          "msbsdf_version() = 0x%x does not pack MAJOR.MINOR.PATCH = %d.%d.%d", (unsigned)v,
          MSBSDF_VERSION_MAJOR, MSBSDF_VERSION_MINOR, MSBSDF_VERSION_PATCH);
    CHECK(v == (uint32_t)RUST_VERSION_PACKED, "msbsdf_version() = 0x%x, Cargo.toml gives 0x%x",
          (unsigned)v, (unsigned)RUST_VERSION_PACKED);
    CHECK(msbsdf_material_size() == (size_t)RUST_MATERIAL_SIZE,
          "msbsdf_material_size() = %u through C, %u through Rust",
          (unsigned)msbsdf_material_size(), (unsigned)RUST_MATERIAL_SIZE);
    return check_finish("layout");
}
