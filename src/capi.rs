//! The C ABI: every `extern "C"` function, its plain-data types and constants.
//!
//! Each function checks its pointers, converts plain data to Rust types, calls
//! the Rust API and writes its outputs; a panic never crosses the boundary
//! (it becomes `MSBSDF_STATUS_PANIC`). Outputs are zeroed before anything
//! can fail, and nothing is ever written through a NULL pointer.
//!
//! This file is the input of cbindgen (`build.rs`), which generates
//! `include/msbsdf.h` from it.

#![allow(non_camel_case_types)]

use crate::bsdf::{Context, Sample, Transport};
use crate::desc::{Estimator, FacetKind, MaterialDesc, Model, NdfId};
use crate::material::Material;
use crate::rng::Rng;
use crate::status::Error;
use glam::Vec3;
use std::ffi::c_char;
use std::panic::{AssertUnwindSafe, catch_unwind};

/// A status code: `MSBSDF_STATUS_OK` (0) or the reason a call was refused.
pub type msbsdf_status = u32;

/// Success.
pub const MSBSDF_STATUS_OK: msbsdf_status = 0;
/// A required pointer argument was NULL.
pub const MSBSDF_STATUS_NULL_POINTER: msbsdf_status = 1;
/// A parameter is outside its valid range.
pub const MSBSDF_STATUS_INVALID_ARGUMENT: msbsdf_status = 2;
/// The model / facet / NDF combination is not supported.
pub const MSBSDF_STATUS_UNSUPPORTED: msbsdf_status = 3;
/// Memory could not be allocated.
pub const MSBSDF_STATUS_OUT_OF_MEMORY: msbsdf_status = 4;
/// An internal error was caught at the boundary (a bug: please report it).
pub const MSBSDF_STATUS_PANIC: msbsdf_status = 5;
/// `struct_size` is smaller than any supported layout of the struct.
pub const MSBSDF_STATUS_STRUCT_TOO_SMALL: msbsdf_status = 6;
/// Caller storage is smaller than `msbsdf_material_size()`.
pub const MSBSDF_STATUS_STORAGE_TOO_SMALL: msbsdf_status = 7;
/// Caller storage is not aligned to `msbsdf_material_align()`.
pub const MSBSDF_STATUS_STORAGE_MISALIGNED: msbsdf_status = 8;
/// A direction is NaN, infinite or of zero length.
pub const MSBSDF_STATUS_INVALID_DIRECTION: msbsdf_status = 9;
/// An unknown model, NDF, facet or estimator constant.
pub const MSBSDF_STATUS_UNKNOWN_CONSTANT: msbsdf_status = 10;

/// Single scattering (Cook-Torrance / Walter 2007), analytic baseline.
pub const MSBSDF_MODEL_SINGLE: u32 = 0;
/// Kulla-Conty 2017 / Turquin 2019 energy compensation.
pub const MSBSDF_MODEL_ENERGY_COMPENSATED: u32 = 1;
/// Heitz et al. 2016 height random walk (unbiased reference).
pub const MSBSDF_MODEL_HEITZ_RANDOM_WALK: u32 = 2;
/// Position-free path integral (Wang et al. 2022).
pub const MSBSDF_MODEL_POSITION_FREE: u32 = 3;
/// Invariance principle (Cui et al. 2023).
pub const MSBSDF_MODEL_INVARIANCE: u32 = 4;
/// Bitterli and d'Eon 2022 exit probability.
pub const MSBSDF_MODEL_BITTERLI_DEON: u32 = 5;
/// Symmetric V-groove (Lee et al. 2018).
pub const MSBSDF_MODEL_VGROOVE: u32 = 6;
/// Nonsymmetric V-groove (Lee et al. 2018).
pub const MSBSDF_MODEL_VGROOVE_NONSYMMETRIC: u32 = 7;
/// Null-scattering walk for general NDFs (d'Eon 2023).
pub const MSBSDF_MODEL_NULL_SCATTERING: u32 = 8;
/// Picks the cheapest model meeting `tolerance`.
pub const MSBSDF_MODEL_AUTO: u32 = 9;
/// Exact single scattering plus the HEITZ walk's orders >= 2 from compact
/// precomputed tables: the accurate production tier (Beckmann, GGX;
/// conductors, and dielectrics with eta or 1 / eta in [1.05, 3], reflection
/// and transmission from both sides; other dielectrics are UNSUPPORTED).
pub const MSBSDF_MODEL_TABULATED: u32 = 10;

/// Unidirectional path tracing with next-event estimation (default).
pub const MSBSDF_ESTIMATOR_PT: u32 = 0;
/// Bidirectional path tracing with MIS.
pub const MSBSDF_ESTIMATOR_BDPT: u32 = 1;

/// Beckmann NDF.
pub const MSBSDF_NDF_BECKMANN: u32 = 0;
/// GGX (Trowbridge-Reitz) NDF.
pub const MSBSDF_NDF_GGX: u32 = 1;
/// Student-T NDF, shape gamma > 1.5 (2 is GGX, infinity is Beckmann).
pub const MSBSDF_NDF_STUDENT_T: u32 = 2;
/// Phong NDF (V-groove models).
pub const MSBSDF_NDF_PHONG: u32 = 3;
/// Exponential NDF (null scattering).
pub const MSBSDF_NDF_EXPONENTIAL: u32 = 4;
/// Bessel K0 NDF (null scattering).
pub const MSBSDF_NDF_BESSEL_K0: u32 = 5;
/// von Mises-Fisher full-sphere NDF (null scattering).
pub const MSBSDF_NDF_VMF: u32 = 6;

/// Conductor facets (complex IOR `eta + i k` per channel).
pub const MSBSDF_FACET_CONDUCTOR: u32 = 0;
/// Dielectric facets (`eta.r` = inside / outside index).
pub const MSBSDF_FACET_DIELECTRIC: u32 = 1;
/// Lambertian facets (`albedo`).
pub const MSBSDF_FACET_DIFFUSE: u32 = 2;
/// Facets that scatter as the material `inner` (composition).
pub const MSBSDF_FACET_MATERIAL: u32 = 3;

/// `sample` went to the same side as `wi`.
pub const MSBSDF_SAMPLE_REFLECTION: u32 = 1;
/// `sample` went through the surface.
pub const MSBSDF_SAMPLE_TRANSMISSION: u32 = 2;
/// The path ended inside the surface; weight is zero.
pub const MSBSDF_SAMPLE_ABSORBED: u32 = 4;

/// `sample` took a Dirac lobe (`msbsdf_sample_record` only; `pdf` is then
/// the discrete probability of the lobe).
pub const MSBSDF_SAMPLE_SPECULAR: u32 = 8;
/// `sample` took a lobe with a density (`msbsdf_sample_record` only).
pub const MSBSDF_SAMPLE_GLOSSY: u32 = 16;

/// Conductor facets mirror the back face onto the front face (default, the
/// behaviour of 0.2): a `wi` below the surface scatters below it.
pub const MSBSDF_CONDUCTOR_TWO_SIDED: u32 = 0;
/// Conductor facets absorb from below: eval, pdf and sample weight are 0
/// for `wi.z < 0` (as Mitsuba 3's conductors).
pub const MSBSDF_CONDUCTOR_ONE_SIDED: u32 = 1;

/// Camera paths: transmission divided by the squared relative index
/// (`eta` of the side of `wo` over the side of `wi`); the context default.
pub const MSBSDF_TRANSPORT_RADIANCE: u32 = 0;
/// Light paths: the flux-conserving values the calls without a context return.
pub const MSBSDF_TRANSPORT_IMPORTANCE: u32 = 1;

/// Lobe mask bit: reflection (the side of `wi`).
pub const MSBSDF_LOBE_REFLECTION: u32 = 1;
/// Lobe mask bit: transmission (the other side).
pub const MSBSDF_LOBE_TRANSMISSION: u32 = 2;
/// Both lobes (the context default).
pub const MSBSDF_LOBE_ALL: u32 = 3;

/// Material flag: reflects.
pub const MSBSDF_MATERIAL_REFLECTION: u32 = 1;
/// Material flag: transmits (dielectric facets).
pub const MSBSDF_MATERIAL_TRANSMISSION: u32 = 2;
/// Material flag: smooth, Dirac lobes only (alpha below 1e-3 along both
/// axes, or 0): eval and pdf are 0, only sample finds the lobes; skip
/// next-event estimation.
pub const MSBSDF_MATERIAL_SPECULAR: u32 = 4;
/// Material flag: lobes with a density.
pub const MSBSDF_MATERIAL_GLOSSY: u32 = 8;
/// Material flag: alpha_x differs from alpha_y.
pub const MSBSDF_MATERIAL_ANISOTROPIC: u32 = 16;
/// Material flag: eval is a Monte Carlo estimate (needs an rng).
pub const MSBSDF_MATERIAL_STOCHASTIC_EVAL: u32 = 32;
/// Material flag: pdf approximates the sampling density (fine for MIS; it
/// may integrate to less than 1).
pub const MSBSDF_MATERIAL_APPROXIMATE_PDF: u32 = 64;

const _: () = {
    use crate::bsdf as b;
    assert!(
        MSBSDF_SAMPLE_SPECULAR == b::SAMPLE_SPECULAR && MSBSDF_SAMPLE_GLOSSY == b::SAMPLE_GLOSSY
    );
    assert!(MSBSDF_LOBE_REFLECTION == b::LOBE_REFLECTION);
    assert!(MSBSDF_LOBE_TRANSMISSION == b::LOBE_TRANSMISSION && MSBSDF_LOBE_ALL == b::LOBE_ALL);
    assert!(MSBSDF_MATERIAL_REFLECTION == b::MATERIAL_REFLECTION);
    assert!(MSBSDF_MATERIAL_TRANSMISSION == b::MATERIAL_TRANSMISSION);
    assert!(MSBSDF_MATERIAL_SPECULAR == b::MATERIAL_SPECULAR);
    assert!(MSBSDF_MATERIAL_GLOSSY == b::MATERIAL_GLOSSY);
    assert!(MSBSDF_MATERIAL_ANISOTROPIC == b::MATERIAL_ANISOTROPIC);
    assert!(MSBSDF_MATERIAL_STOCHASTIC_EVAL == b::MATERIAL_STOCHASTIC_EVAL);
    assert!(MSBSDF_MATERIAL_APPROXIMATE_PDF == b::MATERIAL_APPROXIMATE_PDF);
};

/// Largest allowed `max_bounces`.
pub const MSBSDF_MAX_BOUNCES: u32 = 256;
const _: () = assert!(MSBSDF_MAX_BOUNCES == crate::desc::MAX_BOUNCES);

/// A direction or vector in the local frame (z = macro-surface normal).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct msbsdf_vec3 {
    /// Along the tangent (the `alpha_x` direction).
    pub x: f32,
    /// Along the bitangent.
    pub y: f32,
    /// Along the macro-surface normal.
    pub z: f32,
}

/// Linear RGB triple.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct msbsdf_rgb {
    /// Red.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
}

/// PCG32 generator state, laid out as `pcg32_random_t`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct msbsdf_rng {
    /// LCG state.
    pub state: u64,
    /// LCG increment (odd).
    pub inc: u64,
}

/// Opaque material handle; immutable after creation, shareable across threads.
/// (Never constructed in Rust: handles point to a private struct.)
pub struct msbsdf_material {
    _private: [u8; 0],
}

/// Everything that describes a material. Initialise with
/// `msbsdf_material_desc_init(&desc)` (a macro passing `sizeof desc`, so it
/// writes exactly the struct this program compiled), then set fields.
/// Fields are appended in later minor versions, never reordered;
/// `struct_size` tells the library which layout the caller compiled against:
/// it reads `min(struct_size, its own size)` bytes over its defaults and
/// refuses only sizes below the first published layout (88 bytes, 0.2.0).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct msbsdf_material_desc {
    /// `sizeof(msbsdf_material_desc)` as the caller compiled it.
    pub struct_size: u32,
    /// `MSBSDF_MODEL_*`.
    pub model: u32,
    /// `MSBSDF_ESTIMATOR_*` (position-free and invariance models).
    pub estimator: u32,
    /// `MSBSDF_NDF_*`.
    pub ndf: u32,
    /// `MSBSDF_FACET_*`.
    pub facet: u32,
    /// Roughness along x, in [0, 10]. Conductors and dielectrics with alpha
    /// below 1e-3 along both axes (0 included) are smooth: Dirac lobes with
    /// `MSBSDF_MATERIAL_SPECULAR` (eval and pdf 0, sample finds the lobes);
    /// other facets use at least 1e-4.
    pub alpha_x: f32,
    /// Roughness along y, in [0, 10].
    pub alpha_y: f32,
    /// NDF shape parameter (Student-T gamma in (1.5, 1e4]).
    pub shape: f32,
    /// Conductor: real part of the complex IOR per channel (eta 0, k 1 is a
    /// perfect mirror); dielectric: `eta.r` = inside / outside index, in
    /// [0.01, 100]; `eta.g` and `eta.b` must equal `eta.r` or be 0 (no
    /// dispersion: differing channels give `MSBSDF_STATUS_INVALID_ARGUMENT`).
    pub eta: msbsdf_rgb,
    /// Conductor: imaginary part of the IOR per channel.
    pub k: msbsdf_rgb,
    /// Diffuse facets: albedo per channel in [0, 1].
    pub albedo: msbsdf_rgb,
    /// Bounce limit of the multiple-scattering models; 0 = model default;
    /// at most `MSBSDF_MAX_BOUNCES`.
    pub max_bounces: u32,
    /// `MSBSDF_MODEL_AUTO`: largest acceptable relative error (relative RMS
    /// error of f against the converged HEITZ_RANDOM_WALK over the
    /// measurement suite); AUTO takes the cheapest model meeting it, costs
    /// within 15% counting as equal (the smaller error wins). The default
    /// 0.03 picks analytic models for every conductor and isotropic glass:
    /// TABULATED for every Beckmann or GGX conductor (errors 0.005-0.016
    /// isotropic, about 0.025 anisotropic; 1.1 to 1.6x SINGLE's time, 1.9-2.2x
    /// anisotropic) and for isotropic glass from alpha 0.2 (0.005-0.016,
    /// 1.2-1.4x), SINGLE for glass up to alpha 0.1
    /// (0.006). 0.1 keeps SINGLE for GGX conductors up to alpha 0.3 and
    /// for glass up to 0.5;
    /// 0.01 picks walks averaged over 32 to 512 evaluations (0.1 to 3 ms
    /// per eval) for Beckmann conductors but alpha 1, anisotropic ones and
    /// GGX conductors at alpha 2: for references, not frames. The table of
    /// picks: `docs/auto_picks.md`. Anisotropic glass has measured rows at
    /// `alpha_min / alpha_max` 0.91, 0.5 and 1/6 (GGX glass 1.5 at (0.5,
    /// 0.55), (0.3, 0.6), (0.1, 0.6): TABULATED 0.008, 0.026, 0.039 at
    /// about 2.4x SINGLE's time), and each description is held to the
    /// mildest one at least as anisotropic as itself: the default picks
    /// TABULATED down to a ratio of 0.5 and HEITZ_RANDOM_WALK averaged over
    /// 16 to 128 evaluations (0.04 to 0.3 ms per eval) below it; 0.05
    /// keeps every anisotropic glass analytic (SINGLE or TABULATED).
    pub tolerance: f32,
    /// `MSBSDF_FACET_MATERIAL`: the facets scatter as this material. The new
    /// material keeps a copy: `inner` need only be alive during create/init
    /// and may be destroyed afterwards.
    pub inner: *const msbsdf_material,
    /// Since 0.3.0. `MSBSDF_CONDUCTOR_TWO_SIDED` (0, default) or
    /// `MSBSDF_CONDUCTOR_ONE_SIDED`; ignored for other facets.
    pub conductor_sides: u32,
}

/// Size of the first published layout of `msbsdf_material_desc` (0.2.0):
/// the fields up to `inner`.
const DESC_SIZE_0_2: usize = 88;
const _: () = assert!(std::mem::offset_of!(msbsdf_material_desc, conductor_sides) == DESC_SIZE_0_2);

/// Per-call options of `msbsdf_eval_pdf` and `msbsdf_sample_with` (since
/// 0.3.0). Initialise with `msbsdf_context_init(&ctx)`; a NULL context means
/// the defaults (radiance, both lobes, no rng).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct msbsdf_context {
    /// `sizeof(msbsdf_context)` as the caller compiled it.
    pub struct_size: u32,
    /// `MSBSDF_TRANSPORT_RADIANCE` (default) or `MSBSDF_TRANSPORT_IMPORTANCE`.
    pub transport: u32,
    /// Allowed lobes, `MSBSDF_LOBE_*` bits (default `MSBSDF_LOBE_ALL`).
    pub lobes: u32,
    /// Generator for stochastic models (advanced by the call); may be NULL
    /// for deterministic ones.
    pub rng: *mut msbsdf_rng,
}

/// The result of `msbsdf_sample_with` (since 0.3.0). Set `struct_size`
/// (`msbsdf_sample_record_init(&rec)`) before the call: the library writes
/// `min(struct_size, its own size)` bytes and zeroes the rest.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct msbsdf_sample_record {
    /// `sizeof(msbsdf_sample_record)` as the caller compiled it (kept).
    pub struct_size: u32,
    /// `MSBSDF_SAMPLE_REFLECTION` or `_TRANSMISSION`, with
    /// `MSBSDF_SAMPLE_SPECULAR` or `_GLOSSY`; or `MSBSDF_SAMPLE_ABSORBED`.
    pub flags: u32,
    /// Outgoing unit direction (zero when absorbed).
    pub wo: msbsdf_vec3,
    /// `f * |cos theta_o| / pdf` per channel under the context's transport
    /// mode (for a Dirac lobe: its Fresnel factor over its probability).
    pub weight: msbsdf_rgb,
    /// Density of `wo` per solid angle as `msbsdf_eval_pdf` reports it under
    /// the same context; for `MSBSDF_SAMPLE_SPECULAR` the discrete
    /// probability of the lobe.
    pub pdf: f32,
    /// Relative index of the side of `wo` over the side of `wi` (1 for
    /// reflection).
    pub eta: f32,
}

/// The result of `msbsdf_sample`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct msbsdf_sample_result {
    /// Outgoing unit direction (zero when absorbed).
    pub wo: msbsdf_vec3,
    /// `f * |cos theta_o| / pdf` per channel (an unbiased estimate for
    /// stochastic models).
    pub weight: msbsdf_rgb,
    /// Density of `wo` per solid angle as `msbsdf_pdf` reports it.
    pub pdf: f32,
    /// `MSBSDF_SAMPLE_REFLECTION`, `_TRANSMISSION` or `_ABSORBED`.
    pub flags: u32,
}

// ---------------------------------------------------------------------------
// Boundary helpers (the only place with pointer casts).

/// What a `msbsdf_material *` points to.
#[repr(C)]
struct Stored {
    /// True when allocated by `msbsdf_material_create` (destroy frees it).
    owned: bool,
    material: Material,
}

/// Runs `f`, turning a panic into `MSBSDF_STATUS_PANIC`.
#[inline]
fn guard(f: impl FnOnce() -> Result<(), Error>) -> msbsdf_status {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(())) => MSBSDF_STATUS_OK,
        Ok(Err(e)) => e as msbsdf_status,
        Err(_) => MSBSDF_STATUS_PANIC,
    }
}

/// Converts a handle to a material reference.
///
/// # Safety
/// `m` must be NULL or a handle returned by create/init that is still alive.
#[inline]
unsafe fn material_ref<'a>(m: *const msbsdf_material) -> Result<&'a Material, Error> {
    // SAFETY: the caller guarantees `m` is NULL or points to a live `Stored`
    // written by create/init; `as_ref` handles NULL.
    let stored = unsafe { (m as *const Stored).as_ref() }.ok_or(Error::NullPointer)?;
    Ok(&stored.material)
}

#[inline]
fn to_vec3(v: msbsdf_vec3) -> Vec3 {
    Vec3::new(v.x, v.y, v.z)
}

#[inline]
fn from_vec3(v: Vec3) -> msbsdf_vec3 {
    msbsdf_vec3 {
        x: v.x,
        y: v.y,
        z: v.z,
    }
}

#[inline]
fn to_rgb(v: msbsdf_rgb) -> Vec3 {
    Vec3::new(v.r, v.g, v.b)
}

#[inline]
fn from_rgb(v: Vec3) -> msbsdf_rgb {
    msbsdf_rgb {
        r: v.x,
        g: v.y,
        b: v.z,
    }
}

/// Checks a direction from C: finite and not all zero. A vector whose
/// squared length leaves the normal f32 range (all components below about
/// 1e-19, or one above about 1e19) is divided by its largest component first,
/// so that normalising it later neither divides by zero (it used to be
/// refused) nor collapses to the zero vector (it used to give f = 0 with
/// status OK). Other vectors pass unchanged, bit for bit.
#[inline]
fn direction(v: msbsdf_vec3) -> Result<Vec3, Error> {
    let v = to_vec3(v);
    // The common case in one test: a normal squared length excludes NaN,
    // infinities, zero and lengths that under- or overflow.
    let l2 = v.length_squared();
    if l2.is_normal() {
        return Ok(v * l2.sqrt().recip());
    }
    if !v.is_finite() {
        return Err(Error::InvalidDirection);
    }
    let largest = v.abs().max_element();
    if largest == 0.0 {
        return Err(Error::InvalidDirection);
    }
    // The one normalisation of the query: the Rust API's `*_unit` entry
    // points take it as it is (rescaled first when the squared length
    // under- or overflows).
    if v.length_squared().is_normal() {
        Ok(v.normalize())
    } else {
        Ok((v / largest).normalize())
    }
}

fn model_from_c(v: u32) -> Result<Model, Error> {
    Ok(match v {
        MSBSDF_MODEL_SINGLE => Model::Single,
        MSBSDF_MODEL_ENERGY_COMPENSATED => Model::EnergyCompensated,
        MSBSDF_MODEL_HEITZ_RANDOM_WALK => Model::HeitzRandomWalk,
        MSBSDF_MODEL_POSITION_FREE => Model::PositionFree,
        MSBSDF_MODEL_INVARIANCE => Model::Invariance,
        MSBSDF_MODEL_BITTERLI_DEON => Model::BitterliDeon,
        MSBSDF_MODEL_VGROOVE => Model::VGroove,
        MSBSDF_MODEL_VGROOVE_NONSYMMETRIC => Model::VGrooveNonsymmetric,
        MSBSDF_MODEL_NULL_SCATTERING => Model::NullScattering,
        MSBSDF_MODEL_AUTO => Model::Auto,
        MSBSDF_MODEL_TABULATED => Model::Tabulated,
        _ => return Err(Error::UnknownConstant),
    })
}

fn ndf_from_c(v: u32) -> Result<NdfId, Error> {
    Ok(match v {
        MSBSDF_NDF_BECKMANN => NdfId::Beckmann,
        MSBSDF_NDF_GGX => NdfId::Ggx,
        MSBSDF_NDF_STUDENT_T => NdfId::StudentT,
        MSBSDF_NDF_PHONG => NdfId::Phong,
        MSBSDF_NDF_EXPONENTIAL => NdfId::Exponential,
        MSBSDF_NDF_BESSEL_K0 => NdfId::BesselK0,
        MSBSDF_NDF_VMF => NdfId::Vmf,
        _ => return Err(Error::UnknownConstant),
    })
}

fn facet_from_c(v: u32) -> Result<FacetKind, Error> {
    Ok(match v {
        MSBSDF_FACET_CONDUCTOR => FacetKind::Conductor,
        MSBSDF_FACET_DIELECTRIC => FacetKind::Dielectric,
        MSBSDF_FACET_DIFFUSE => FacetKind::Diffuse,
        MSBSDF_FACET_MATERIAL => FacetKind::Material,
        _ => return Err(Error::UnknownConstant),
    })
}

fn estimator_from_c(v: u32) -> Result<Estimator, Error> {
    Ok(match v {
        MSBSDF_ESTIMATOR_PT => Estimator::Pt,
        MSBSDF_ESTIMATOR_BDPT => Estimator::Bdpt,
        _ => return Err(Error::UnknownConstant),
    })
}

/// C structs any bit pattern of which is a valid value (integers, floats and
/// raw pointers only), starting with their `u32 struct_size`.
///
/// # Safety
/// Implement only for such `repr(C)` structs.
unsafe trait Versioned: Copy {
    /// Size of the first published layout: smaller `struct_size` is refused.
    const OLDEST: usize;
}

// SAFETY: u32, f32, plain float structs and a raw pointer; starts with struct_size.
unsafe impl Versioned for msbsdf_material_desc {
    const OLDEST: usize = DESC_SIZE_0_2;
}
// SAFETY: u32 fields and a raw pointer; starts with struct_size.
unsafe impl Versioned for msbsdf_context {
    const OLDEST: usize = std::mem::size_of::<msbsdf_context>();
}
// SAFETY: u32 and f32 fields only; starts with struct_size.
unsafe impl Versioned for msbsdf_sample_record {
    const OLDEST: usize = std::mem::size_of::<msbsdf_sample_record>();
}

/// The caller's `struct_size` of a versioned struct, checked against the
/// oldest layout.
///
/// # Safety
/// `p` must be non-NULL and point to at least 4 readable bytes.
unsafe fn caller_size<T: Versioned>(p: *const T) -> Result<usize, Error> {
    // SAFETY: per the contract, `p` starts with a readable u32.
    let size = unsafe { (p as *const u32).read_unaligned() } as usize;
    if size < T::OLDEST {
        return Err(Error::StructTooSmall);
    }
    Ok(size)
}

/// Reads a caller's versioned struct: `min(struct_size, size_of::<T>())`
/// bytes over `defaults` (older layouts keep the defaults of the fields they
/// lack; newer layouts' extra fields are not read).
///
/// # Safety
/// `p` must be NULL or point to `struct_size` readable bytes.
unsafe fn read_versioned<T: Versioned>(p: *const T, defaults: T) -> Result<T, Error> {
    if p.is_null() {
        return Err(Error::NullPointer);
    }
    // SAFETY: forwarded contract.
    let n = unsafe { caller_size(p) }?.min(std::mem::size_of::<T>());
    let mut v = defaults;
    // SAFETY: the caller's struct has at least `n` readable bytes; `v` has
    // `size_of::<T>() >= n` writable bytes, and any bit pattern is a valid
    // `T` (`Versioned`).
    unsafe { std::ptr::copy_nonoverlapping(p as *const u8, &mut v as *mut T as *mut u8, n) };
    Ok(v)
}

/// Writes `v` into the caller's versioned struct of `size` bytes: its first
/// `min(size, size_of::<T>())` bytes, the rest zeroed, `struct_size` = `size`.
///
/// # Safety
/// `p` must be non-NULL and writable for `size` bytes; `size` must fit u32.
unsafe fn write_versioned<T: Versioned>(p: *mut T, v: T, size: usize) {
    let n = size.min(std::mem::size_of::<T>());
    // SAFETY: `p` is writable for `size >= n` bytes and `v` is readable for
    // `size_of::<T>() >= n` bytes; the tail `size - n` is inside the caller's
    // struct.
    unsafe {
        std::ptr::copy_nonoverlapping(&v as *const T as *const u8, p as *mut u8, n);
        std::ptr::write_bytes((p as *mut u8).add(n), 0, size - n);
        (p as *mut u32).write_unaligned(size as u32);
    }
}

/// Fills a versioned struct of the caller's `size` with `defaults`.
///
/// # Safety
/// `p` NULL or writable for `size` bytes.
unsafe fn init_versioned<T: Versioned>(p: *mut T, size: usize, defaults: T) -> msbsdf_status {
    guard(|| {
        if p.is_null() {
            return Err(Error::NullPointer);
        }
        if size < T::OLDEST {
            return Err(Error::StructTooSmall);
        }
        if size > u32::MAX as usize {
            return Err(Error::InvalidArgument); // struct_size is 32-bit
        }
        // SAFETY: forwarded contract; size checked.
        unsafe { write_versioned(p, defaults, size) };
        Ok(())
    })
}

fn sides_from_c(v: u32) -> Result<bool, Error> {
    match v {
        MSBSDF_CONDUCTOR_TWO_SIDED => Ok(false),
        MSBSDF_CONDUCTOR_ONE_SIDED => Ok(true),
        _ => Err(Error::UnknownConstant),
    }
}

/// Reads and validates a C description into a material. The inner material
/// of a composition is borrowed for this call only (the material keeps a
/// copy of it).
///
/// # Safety
/// `desc` must be NULL or point to at least `struct_size` readable bytes;
/// its `inner` NULL or a live handle.
unsafe fn material_from_c(desc: *const msbsdf_material_desc) -> Result<Material, Error> {
    // SAFETY: forwarded contract.
    let d = unsafe { read_versioned(desc, desc_defaults()) }?;
    let rust = MaterialDesc {
        model: model_from_c(d.model)?,
        estimator: estimator_from_c(d.estimator)?,
        ndf: ndf_from_c(d.ndf)?,
        facet: facet_from_c(d.facet)?,
        alpha_x: d.alpha_x,
        alpha_y: d.alpha_y,
        shape: d.shape,
        eta: to_rgb(d.eta),
        k: to_rgb(d.k),
        albedo: to_rgb(d.albedo),
        max_bounces: d.max_bounces,
        tolerance: d.tolerance,
        inner: None,
        one_sided: sides_from_c(d.conductor_sides)?,
    };
    let inner = if rust.facet == FacetKind::Material {
        // SAFETY: the caller guarantees `inner` is NULL or a live material
        // handle for the duration of this call; the reference does not
        // outlive it (`Material::with_inner` copies what it needs).
        Some(unsafe { material_ref(d.inner) }?)
    } else {
        None
    };
    Material::with_inner(&rust, inner)
}

/// The defaults of every field (0.2 callers get these for the fields
/// appended since).
fn desc_defaults() -> msbsdf_material_desc {
    let d = MaterialDesc::default();
    msbsdf_material_desc {
        struct_size: std::mem::size_of::<msbsdf_material_desc>() as u32,
        model: MSBSDF_MODEL_SINGLE,
        estimator: MSBSDF_ESTIMATOR_PT,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_CONDUCTOR,
        alpha_x: d.alpha_x,
        alpha_y: d.alpha_y,
        shape: d.shape,
        eta: from_rgb(d.eta),
        k: from_rgb(d.k),
        albedo: from_rgb(d.albedo),
        max_bounces: d.max_bounces,
        tolerance: d.tolerance,
        inner: std::ptr::null(),
        conductor_sides: MSBSDF_CONDUCTOR_TWO_SIDED,
    }
}

fn context_defaults() -> msbsdf_context {
    msbsdf_context {
        struct_size: std::mem::size_of::<msbsdf_context>() as u32,
        transport: MSBSDF_TRANSPORT_RADIANCE,
        lobes: MSBSDF_LOBE_ALL,
        rng: std::ptr::null_mut(),
    }
}

/// The Rust context and the rng of a C context (NULL: the defaults).
///
/// # Safety
/// `ctx` NULL or readable for its `struct_size`; its `rng` NULL or valid.
unsafe fn context_from_c<'a>(
    ctx: *const msbsdf_context,
) -> Result<(Context, Option<&'a mut msbsdf_rng>), Error> {
    let c = if ctx.is_null() {
        context_defaults()
    } else {
        // SAFETY: forwarded contract.
        unsafe { read_versioned(ctx, context_defaults()) }?
    };
    let transport = match c.transport {
        MSBSDF_TRANSPORT_RADIANCE => Transport::Radiance,
        MSBSDF_TRANSPORT_IMPORTANCE => Transport::Importance,
        _ => return Err(Error::UnknownConstant),
    };
    if c.lobes & !MSBSDF_LOBE_ALL != 0 {
        return Err(Error::UnknownConstant);
    }
    // SAFETY: the caller guarantees `rng` is NULL or valid for this call.
    let rng = unsafe { c.rng.as_mut() };
    Ok((
        Context {
            transport,
            lobes: c.lobes,
        },
        rng,
    ))
}

// ---------------------------------------------------------------------------
// Version and status.

const fn parse_u32(s: &str) -> u32 {
    let b = s.as_bytes();
    let mut i = 0;
    let mut v = 0u32;
    while i < b.len() {
        v = v * 10 + (b[i] - b'0') as u32;
        i += 1;
    }
    v
}

const VERSION_MAJOR: u32 = parse_u32(env!("CARGO_PKG_VERSION_MAJOR"));
const VERSION_MINOR: u32 = parse_u32(env!("CARGO_PKG_VERSION_MINOR"));
const VERSION_PATCH: u32 = parse_u32(env!("CARGO_PKG_VERSION_PATCH"));

/// The library version as `(major << 16) | (minor << 8) | patch`; compare
/// with the header's `MSBSDF_VERSION_*` macros.
#[unsafe(no_mangle)]
pub extern "C" fn msbsdf_version() -> u32 {
    (VERSION_MAJOR << 16) | (VERSION_MINOR << 8) | VERSION_PATCH
}

/// A static, NUL-terminated description of `status`; never NULL, for any value.
#[unsafe(no_mangle)]
pub extern "C" fn msbsdf_status_message(status: msbsdf_status) -> *const c_char {
    let s: &'static std::ffi::CStr = match status {
        MSBSDF_STATUS_OK => c"ok",
        MSBSDF_STATUS_NULL_POINTER => c"a required pointer argument is NULL",
        MSBSDF_STATUS_INVALID_ARGUMENT => c"a parameter is outside its valid range",
        MSBSDF_STATUS_UNSUPPORTED => c"this model / facet / NDF combination is not supported",
        MSBSDF_STATUS_OUT_OF_MEMORY => c"out of memory",
        MSBSDF_STATUS_PANIC => c"internal error (a panic was caught at the C boundary)",
        MSBSDF_STATUS_STRUCT_TOO_SMALL => {
            c"struct_size is smaller than any supported struct layout"
        }
        MSBSDF_STATUS_STORAGE_TOO_SMALL => c"storage is smaller than msbsdf_material_size()",
        MSBSDF_STATUS_STORAGE_MISALIGNED => c"storage is not aligned to msbsdf_material_align()",
        MSBSDF_STATUS_INVALID_DIRECTION => c"a direction is NaN, infinite or of zero length",
        MSBSDF_STATUS_UNKNOWN_CONSTANT => c"unknown model, NDF, facet or estimator constant",
        _ => c"unknown status code",
    };
    s.as_ptr()
}

// ---------------------------------------------------------------------------
// Random numbers.

/// Seeds `rng` exactly as the reference `pcg32_srandom_r(rng, seed, stream)`.
/// NULL: no-op.
///
/// # Safety
/// `rng` must be NULL or point to a writable `msbsdf_rng`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn msbsdf_rng_seed(rng: *mut msbsdf_rng, seed: u64, stream: u64) {
    let r = Rng::new(seed, stream);
    // SAFETY: the caller guarantees `rng` is NULL or valid for writes.
    if let Some(out) = unsafe { rng.as_mut() } {
        *out = msbsdf_rng {
            state: r.state,
            inc: r.inc,
        };
    }
}

/// Next uniform float in [0, 1) (24 random bits). NULL: returns 0.
///
/// # Safety
/// `rng` must be NULL or point to a valid `msbsdf_rng`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn msbsdf_rng_next_float(rng: *mut msbsdf_rng) -> f32 {
    // SAFETY: the caller guarantees `rng` is NULL or valid for reads and writes.
    match unsafe { rng.as_mut() } {
        Some(c) => {
            let mut r = Rng {
                state: c.state,
                inc: c.inc,
            };
            let x = r.next_f32();
            c.state = r.state;
            c.inc = r.inc;
            x
        }
        None => 0.0,
    }
}

// ---------------------------------------------------------------------------
// Materials.

/// A description with every field at its default: GGX alpha 0.5, perfectly
/// reflecting conductor facets (eta 0, k 1), single scattering, PT estimator,
/// shape 2, albedo 0.8, default bounces, tolerance 0.03, no inner material,
/// two-sided conductors, and `struct_size` set. Returned by value, it has
/// this library's size: a program compiled against an older header must use
/// `msbsdf_material_desc_init` instead (kept for 0.2 source compatibility).
#[unsafe(no_mangle)]
pub extern "C" fn msbsdf_material_desc_default() -> msbsdf_material_desc {
    desc_defaults()
}

/// Bytes of storage `msbsdf_material_init` needs.
#[unsafe(no_mangle)]
pub extern "C" fn msbsdf_material_size() -> usize {
    std::mem::size_of::<Stored>()
}

/// Alignment `msbsdf_material_init` needs for its storage.
#[unsafe(no_mangle)]
pub extern "C" fn msbsdf_material_align() -> usize {
    std::mem::align_of::<Stored>()
}

/// Validates `desc` and allocates a material. On failure `*out` is NULL.
/// Free with `msbsdf_material_destroy`.
///
/// # Safety
/// `desc` must be NULL or point to a description whose `struct_size` bytes
/// are readable; `out` must be NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn msbsdf_material_create(
    desc: *const msbsdf_material_desc,
    out: *mut *mut msbsdf_material,
) -> msbsdf_status {
    if out.is_null() {
        return MSBSDF_STATUS_NULL_POINTER;
    }
    // SAFETY: `out` is non-NULL and writable per the contract.
    unsafe { out.write(std::ptr::null_mut()) };
    guard(|| {
        // SAFETY: forwarded contract on `desc`.
        let material = unsafe { material_from_c(desc) }?;
        let layout = std::alloc::Layout::new::<Stored>();
        // SAFETY: `Stored` has non-zero size.
        let p = unsafe { std::alloc::alloc(layout) } as *mut Stored;
        if p.is_null() {
            return Err(Error::OutOfMemory);
        }
        // SAFETY: `p` is a fresh allocation with the layout of `Stored`;
        // `out` was checked above.
        unsafe {
            p.write(Stored {
                owned: true,
                material,
            });
            out.write(p as *mut msbsdf_material);
        }
        Ok(())
    })
}

/// Frees a material from `msbsdf_material_create`. NULL, or a material
/// initialised in caller storage by `msbsdf_material_init`: no-op.
///
/// # Safety
/// `material` must be NULL or a live handle not used after this call.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn msbsdf_material_destroy(material: *mut msbsdf_material) {
    let p = material as *mut Stored;
    // SAFETY: the caller guarantees a live handle or NULL.
    let Some(stored) = (unsafe { p.as_ref() }) else {
        return;
    };
    if stored.owned {
        // SAFETY: owned handles were allocated in `msbsdf_material_create`
        // with this layout; `Stored` has no drop glue.
        unsafe { std::alloc::dealloc(p as *mut u8, std::alloc::Layout::new::<Stored>()) };
    }
}

/// Validates `desc` and builds the material in caller storage of at least
/// `msbsdf_material_size()` bytes aligned to `msbsdf_material_align()`: no
/// allocation at all. The storage must outlive every use of `*out`; nothing
/// needs freeing (destroy on it is a no-op). On failure `*out` is NULL.
///
/// # Safety
/// `desc` as for create; `storage` NULL or writable for `size` bytes; `out`
/// NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn msbsdf_material_init(
    desc: *const msbsdf_material_desc,
    storage: *mut std::ffi::c_void,
    size: usize,
    out: *mut *mut msbsdf_material,
) -> msbsdf_status {
    if out.is_null() {
        return MSBSDF_STATUS_NULL_POINTER;
    }
    // SAFETY: `out` is non-NULL and writable per the contract.
    unsafe { out.write(std::ptr::null_mut()) };
    guard(|| {
        if storage.is_null() {
            return Err(Error::NullPointer);
        }
        if size < std::mem::size_of::<Stored>() {
            return Err(Error::StorageTooSmall);
        }
        if !(storage as usize).is_multiple_of(std::mem::align_of::<Stored>()) {
            return Err(Error::StorageMisaligned);
        }
        // SAFETY: forwarded contract on `desc`.
        let material = unsafe { material_from_c(desc) }?;
        let p = storage as *mut Stored;
        // SAFETY: size and alignment were checked; the caller owns the bytes.
        unsafe {
            p.write(Stored {
                owned: false,
                material,
            });
            out.write(p as *mut msbsdf_material);
        }
        Ok(())
    })
}

/// `f(wi, wo) * |cos theta_o|` per channel. Directions need not be
/// normalised. `rng` may be NULL for deterministic models (SINGLE, V-groove,
/// energy-compensated); stochastic models need it and advance it.
/// Flux-conserving (importance transport); 0 for a specular material
/// (`MSBSDF_MATERIAL_SPECULAR`: Dirac lobes have no density).
/// `*out` is zero on any failure.
///
/// # Safety
/// `material` NULL or live; `rng` NULL or valid; `out` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn msbsdf_eval(
    material: *const msbsdf_material,
    wi: msbsdf_vec3,
    wo: msbsdf_vec3,
    rng: *mut msbsdf_rng,
    out: *mut msbsdf_rgb,
) -> msbsdf_status {
    if out.is_null() {
        return MSBSDF_STATUS_NULL_POINTER;
    }
    let result = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: forwarded contract on `material`.
        let m = unsafe { material_ref(material) }?;
        let (wi, wo) = (direction(wi)?, direction(wo)?);
        if !m.is_stochastic() {
            // Deterministic models never draw: no generator to copy.
            return Ok(m.eval_unit(wi, wo, &mut Rng { state: 0, inc: 1 }));
        }
        // SAFETY: the caller guarantees `rng` is NULL or valid.
        let rng = unsafe { rng.as_mut() };
        with_rng(m, rng, |r| m.eval_unit(wi, wo, r))
    }));
    let (value, status) = match result {
        Ok(Ok(v)) => (from_rgb(v), MSBSDF_STATUS_OK),
        Ok(Err(e)) => (msbsdf_rgb::default(), e as msbsdf_status),
        Err(_) => (msbsdf_rgb::default(), MSBSDF_STATUS_PANIC),
    };
    // SAFETY: `out` is non-NULL and writable per the contract; written once,
    // zeros on any failure.
    unsafe { out.write(value) };
    status
}

/// Runs `f` with the caller's generator (copied in and back out) or, for a
/// deterministic material, a local one when `rng` is NULL.
fn with_rng<T>(
    m: &Material,
    rng: Option<&mut msbsdf_rng>,
    f: impl FnOnce(&mut Rng) -> T,
) -> Result<T, Error> {
    match rng {
        Some(c) => {
            let mut r = Rng {
                state: c.state,
                inc: c.inc,
            };
            let v = f(&mut r);
            c.state = r.state;
            c.inc = r.inc;
            Ok(v)
        }
        None if m.is_stochastic() => Err(Error::NullPointer),
        // Deterministic models never draw from it: no seeding cost.
        None => Ok(f(&mut Rng { state: 0, inc: 1 })),
    }
}

/// Samples an outgoing direction for `wi`. `rng` is required. For a
/// specular material the direction is the mirror or refracted one and `pdf`
/// the probability of that lobe (`msbsdf_sample_with` also flags it
/// `MSBSDF_SAMPLE_SPECULAR`). On failure `*out` is all zeros.
///
/// # Safety
/// `material` NULL or live; `rng` NULL or valid; `out` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn msbsdf_sample(
    material: *const msbsdf_material,
    wi: msbsdf_vec3,
    rng: *mut msbsdf_rng,
    out: *mut msbsdf_sample_result,
) -> msbsdf_status {
    if out.is_null() {
        return MSBSDF_STATUS_NULL_POINTER;
    }
    // SAFETY: `out` is non-NULL and writable per the contract.
    unsafe { out.write(msbsdf_sample_result::default()) };
    guard(|| {
        // SAFETY: forwarded contract on `material`.
        let m = unsafe { material_ref(material) }?;
        let wi = direction(wi)?;
        // SAFETY: the caller guarantees `rng` is NULL or valid.
        let c = unsafe { rng.as_mut() }.ok_or(Error::NullPointer)?;
        let s: Sample = with_rng(m, Some(c), |r| m.sample(wi, r))?;
        let result = msbsdf_sample_result {
            wo: from_vec3(s.wo),
            weight: from_rgb(s.weight),
            pdf: s.pdf,
            flags: s.flags,
        };
        // SAFETY: `out` checked above.
        unsafe { out.write(result) };
        Ok(())
    })
}

/// Density per solid angle with which `msbsdf_sample` picks `wo` given `wi`
/// (exact for deterministic models, an approximation positive wherever
/// sampling can go for stochastic ones; 0 everywhere for a specular
/// material). `*out` is 0 on failure.
///
/// # Safety
/// `material` NULL or live; `out` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn msbsdf_pdf(
    material: *const msbsdf_material,
    wi: msbsdf_vec3,
    wo: msbsdf_vec3,
    out: *mut f32,
) -> msbsdf_status {
    if out.is_null() {
        return MSBSDF_STATUS_NULL_POINTER;
    }
    // SAFETY: `out` is non-NULL and writable per the contract.
    unsafe { out.write(0.0) };
    guard(|| {
        // SAFETY: forwarded contract on `material`.
        let m = unsafe { material_ref(material) }?;
        let (wi, wo) = (direction(wi)?, direction(wo)?);
        let p = m.pdf_unit(wi, wo);
        // SAFETY: `out` checked above.
        unsafe { out.write(p) };
        Ok(())
    })
}

/// Fills `*desc` with the defaults of `msbsdf_material_desc_default()`,
/// writing exactly `size` bytes: the fields this library knows up to `size`,
/// zeros after them (every field appended later means its 0.2 behaviour at
/// 0), and `struct_size = size`. Call it through the macro
/// `msbsdf_material_desc_init(&desc)`, which passes `sizeof desc` as this
/// program compiled it. Sizes below the 0.2 layout (88 bytes):
/// `MSBSDF_STATUS_STRUCT_TOO_SMALL`, nothing written. Since 0.3.0.
///
/// # Safety
/// `desc` NULL or writable for `size` bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn msbsdf_material_desc_init_sized(
    desc: *mut msbsdf_material_desc,
    size: usize,
) -> msbsdf_status {
    // SAFETY: forwarded contract.
    unsafe { init_versioned(desc, size, desc_defaults()) }
}

/// Fills `*ctx` with the defaults (radiance transport, both lobes, no rng),
/// writing exactly `size` bytes as `msbsdf_material_desc_init_sized`; use the
/// macro `msbsdf_context_init(&ctx)`. Since 0.3.0.
///
/// # Safety
/// `ctx` NULL or writable for `size` bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn msbsdf_context_init_sized(
    ctx: *mut msbsdf_context,
    size: usize,
) -> msbsdf_status {
    // SAFETY: forwarded contract.
    unsafe { init_versioned(ctx, size, context_defaults()) }
}

/// Zeroes `*rec` and sets its `struct_size = size`, writing exactly `size`
/// bytes; use the macro `msbsdf_sample_record_init(&rec)`. Since 0.3.0.
///
/// # Safety
/// `rec` NULL or writable for `size` bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn msbsdf_sample_record_init_sized(
    rec: *mut msbsdf_sample_record,
    size: usize,
) -> msbsdf_status {
    // SAFETY: forwarded contract.
    unsafe { init_versioned(rec, size, msbsdf_sample_record::default()) }
}

/// What the material does: `MSBSDF_MATERIAL_*` bits. `*flags` is 0 on
/// failure. Since 0.3.0.
///
/// # Safety
/// `material` NULL or live; `flags` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn msbsdf_material_flags(
    material: *const msbsdf_material,
    flags: *mut u32,
) -> msbsdf_status {
    if flags.is_null() {
        return MSBSDF_STATUS_NULL_POINTER;
    }
    // SAFETY: `flags` is non-NULL and writable per the contract.
    unsafe { flags.write(0) };
    guard(|| {
        // SAFETY: forwarded contract on `material`.
        let m = unsafe { material_ref(material) }?;
        // SAFETY: checked above.
        unsafe { flags.write(m.flags()) };
        Ok(())
    })
}

/// `f(wi, wo) * |cos theta_o|` and the pdf of `wo` in one call (SINGLE
/// shares the half vector, D and masking), under `ctx` (NULL: radiance, both
/// lobes, no rng). With `MSBSDF_TRANSPORT_IMPORTANCE` and both lobes, bit for
/// bit what `msbsdf_eval` and `msbsdf_pdf` return; radiance divides
/// transmission by the squared relative index. Lobes outside `ctx->lobes`
/// give 0. For SINGLE and the specular regime a single allowed lobe is
/// sampled with probability 1 and its pdf says so; for the other models the
/// pdf is the unrestricted one (their restricted samples in the other lobe
/// come back absorbed). Either output may be NULL (not computed); the others
/// are zeroed on failure. Stochastic models need `ctx->rng`. Since 0.3.0.
///
/// # Safety
/// `material` NULL or live; `ctx` NULL or valid for its `struct_size`, its
/// `rng` NULL or valid; `value`, `pdf` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn msbsdf_eval_pdf(
    material: *const msbsdf_material,
    ctx: *const msbsdf_context,
    wi: msbsdf_vec3,
    wo: msbsdf_vec3,
    value: *mut msbsdf_rgb,
    pdf: *mut f32,
) -> msbsdf_status {
    // SAFETY: each output is NULL or writable per the contract.
    unsafe {
        if let Some(v) = value.as_mut() {
            *v = msbsdf_rgb::default();
        }
        if let Some(p) = pdf.as_mut() {
            *p = 0.0;
        }
    }
    guard(|| {
        // SAFETY: forwarded contracts.
        let m = unsafe { material_ref(material) }?;
        // SAFETY: forwarded contract on `ctx`.
        let (c, rng) = unsafe { context_from_c(ctx) }?;
        let (wi, wo) = (direction(wi)?, direction(wo)?);
        let (f, p) = with_rng(m, rng, |r| m.eval_pdf_unit(wi, wo, &c, r))?;
        // SAFETY: as above.
        unsafe {
            if let Some(v) = value.as_mut() {
                *v = from_rgb(f);
            }
            if let Some(o) = pdf.as_mut() {
                *o = p;
            }
        }
        Ok(())
    })
}

/// Samples `wo` for `wi` from the caller's uniforms in [0, 1) (values
/// outside are clamped into it, NaN acts as 0): `u_lobe` picks the lobe at
/// the first vertex (reflection or refraction of a dielectric, single or
/// multiple scattering of ENERGY_COMPENSATED, the bounce count of a
/// V-groove), `u1, u2` the first visible normal; stochastic models (and the
/// V-groove's partner facet) draw the rest from `ctx->rng`, which they then
/// need. NULL_SCATTERING follows them at the first vertex for the Beckmann,
/// GGX and Student-T NDFs; with vMF, exponential and Bessel K0 it draws every
/// facet normal by rejection (d'Eon 2023, sec. 3.1), which a fixed number of
/// uniforms cannot drive: it ignores them and takes every number from
/// `ctx->rng`.
/// Deterministic models give the same record for the same uniforms,
/// bit for bit. `*rec` must have its `struct_size` set
/// (`msbsdf_sample_record_init`); on failure it is zeroed (keeping
/// `struct_size`) unless `struct_size` is too small. Since 0.3.0.
///
/// # Safety
/// `material` NULL or live; `ctx` as for `msbsdf_eval_pdf`; `rec` NULL or
/// writable for its `struct_size`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn msbsdf_sample_with(
    material: *const msbsdf_material,
    ctx: *const msbsdf_context,
    wi: msbsdf_vec3,
    u_lobe: f32,
    u1: f32,
    u2: f32,
    rec: *mut msbsdf_sample_record,
) -> msbsdf_status {
    if rec.is_null() {
        return MSBSDF_STATUS_NULL_POINTER;
    }
    // SAFETY: `rec` is non-NULL and starts with its u32 size.
    let size = match unsafe { caller_size(rec) } {
        Ok(n) if n <= u32::MAX as usize => n,
        _ => return MSBSDF_STATUS_STRUCT_TOO_SMALL,
    };
    // SAFETY: `rec` is writable for `size` bytes per the contract.
    unsafe { write_versioned(rec, msbsdf_sample_record::default(), size) };
    guard(|| {
        // SAFETY: forwarded contracts.
        let m = unsafe { material_ref(material) }?;
        // SAFETY: forwarded contract on `ctx`.
        let (c, rng) = unsafe { context_from_c(ctx) }?;
        let wi = direction(wi)?;
        let r = with_rng(m, rng, |r| m.sample_ctx(wi, [u_lobe, u1, u2], &c, r))?;
        let out = msbsdf_sample_record {
            struct_size: 0,
            flags: r.flags,
            wo: from_vec3(r.sample.wo),
            weight: from_rgb(r.sample.weight),
            pdf: r.sample.pdf,
            eta: r.eta,
        };
        // SAFETY: as above.
        unsafe { write_versioned(rec, out, size) };
        Ok(())
    })
}

/// Which model, estimator and number of evaluations averaged per
/// `msbsdf_eval` call the material uses: its description's own (1
/// evaluation), or what `MSBSDF_MODEL_AUTO` picked from the measured
/// speed-vs-accuracy table. Any output pointer may be NULL (skipped); the
/// others are zeroed on failure.
///
/// # Safety
/// `material` NULL or live; each output NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn msbsdf_material_model(
    material: *const msbsdf_material,
    model: *mut u32,
    estimator: *mut u32,
    evaluations: *mut u32,
) -> msbsdf_status {
    for p in [model, estimator, evaluations] {
        // SAFETY: each output is NULL or writable per the contract.
        if let Some(p) = unsafe { p.as_mut() } {
            *p = 0;
        }
    }
    guard(|| {
        // SAFETY: forwarded contract on `material`.
        let m = unsafe { material_ref(material) }?;
        let c = m.chosen();
        for (p, v) in [
            (model, model_to_c(c.model)),
            (estimator, estimator_to_c(c.estimator)),
            (evaluations, c.evaluations),
        ] {
            // SAFETY: as above.
            if let Some(p) = unsafe { p.as_mut() } {
                *p = v;
            }
        }
        Ok(())
    })
}

fn model_to_c(m: Model) -> u32 {
    match m {
        Model::Single => MSBSDF_MODEL_SINGLE,
        Model::EnergyCompensated => MSBSDF_MODEL_ENERGY_COMPENSATED,
        Model::HeitzRandomWalk => MSBSDF_MODEL_HEITZ_RANDOM_WALK,
        Model::PositionFree => MSBSDF_MODEL_POSITION_FREE,
        Model::Invariance => MSBSDF_MODEL_INVARIANCE,
        Model::BitterliDeon => MSBSDF_MODEL_BITTERLI_DEON,
        Model::VGroove => MSBSDF_MODEL_VGROOVE,
        Model::VGrooveNonsymmetric => MSBSDF_MODEL_VGROOVE_NONSYMMETRIC,
        Model::NullScattering => MSBSDF_MODEL_NULL_SCATTERING,
        Model::Auto => MSBSDF_MODEL_AUTO,
        Model::Tabulated => MSBSDF_MODEL_TABULATED,
    }
}

fn estimator_to_c(e: Estimator) -> u32 {
    match e {
        Estimator::Pt => MSBSDF_ESTIMATOR_PT,
        Estimator::Bdpt => MSBSDF_ESTIMATOR_BDPT,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_codes_match_rust_errors() {
        for (e, code) in [
            (Error::NullPointer, MSBSDF_STATUS_NULL_POINTER),
            (Error::InvalidArgument, MSBSDF_STATUS_INVALID_ARGUMENT),
            (Error::Unsupported, MSBSDF_STATUS_UNSUPPORTED),
            (Error::OutOfMemory, MSBSDF_STATUS_OUT_OF_MEMORY),
            (Error::Panic, MSBSDF_STATUS_PANIC),
            (Error::StructTooSmall, MSBSDF_STATUS_STRUCT_TOO_SMALL),
            (Error::StorageTooSmall, MSBSDF_STATUS_STORAGE_TOO_SMALL),
            (Error::StorageMisaligned, MSBSDF_STATUS_STORAGE_MISALIGNED),
            (Error::InvalidDirection, MSBSDF_STATUS_INVALID_DIRECTION),
            (Error::UnknownConstant, MSBSDF_STATUS_UNKNOWN_CONSTANT),
        ] {
            assert_eq!(e as u32, code);
            // SAFETY: the message is a static NUL-terminated string.
            let c = unsafe { std::ffi::CStr::from_ptr(msbsdf_status_message(code)) };
            assert_eq!(c.to_str().ok(), Some(e.message()));
        }
    }

    #[test]
    fn guard_turns_panic_into_status() {
        let prev = std::panic::take_hook();
        std::panic::set_hook(Box::new(|_| {}));
        let s = guard(|| panic!("boom"));
        std::panic::set_hook(prev);
        assert_eq!(s, MSBSDF_STATUS_PANIC);
    }

    #[test]
    fn direction_accepts_every_finite_nonzero_scale() {
        let unit = Vec3::new(0.3, -0.2, 0.9).normalize();
        for scale in [1e-40_f32, 1e-30, 1e-20, 1e-3, 1.0, 1e3, 1e20, 1e30, 3e38] {
            let c = msbsdf_vec3 {
                x: 0.3 * scale,
                y: -0.2 * scale,
                z: 0.9 * scale,
            };
            let Ok(d) = direction(c) else {
                panic!("finite nonzero direction refused at scale {scale}");
            };
            // Subnormal inputs keep fewer significant bits.
            let tol = if scale < 1e-37 { 1e-3 } else { 1e-6 };
            assert!(
                (d - unit).abs().max_element() < tol && (d.length() - 1.0).abs() < 1e-6,
                "scale {scale}: {d:?}"
            );
        }
        let ordinary = msbsdf_vec3 {
            x: 0.3,
            y: -0.2,
            z: 0.9,
        };
        assert_eq!(
            direction(ordinary),
            Ok(Vec3::new(0.3, -0.2, 0.9).normalize())
        );
        for bad in [
            Vec3::ZERO,
            Vec3::new(f32::NAN, 0.0, 1.0),
            Vec3::new(0.0, 0.0, f32::INFINITY),
        ] {
            assert_eq!(direction(from_vec3(bad)), Err(Error::InvalidDirection));
        }
    }

    #[test]
    fn version_packs_cargo_version() {
        let v = msbsdf_version();
        assert_eq!(v >> 16, VERSION_MAJOR);
        assert_eq!((v >> 8) & 0xff, VERSION_MINOR);
        assert_eq!(v & 0xff, VERSION_PATCH);
        assert_eq!(
            format!("{}.{}.{}", v >> 16, (v >> 8) & 0xff, v & 0xff),
            env!("CARGO_PKG_VERSION")
        );
    }
}
