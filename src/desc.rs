//! The description of a material and its limits: plain data, shared by the
//! validation in `material.rs`, the C layer and the methods. A leaf module:
//! it imports none of the scattering methods (the methods import their
//! limits from here, never from `material.rs`).

use crate::Material;
use crate::ndf::{Ndf, NdfKind};
use crate::status::Error;
use glam::Vec3;

/// Largest number of scattering events any walk follows (path state on the
/// stack is bounded by it).
pub const MAX_BOUNCES: u32 = 256;

/// Below this roughness (along both axes) a conductor or dielectric surface
/// is smooth: a Dirac lobe with the SPECULAR flag, eval and pdf 0 elsewhere
/// (the threshold of pbrt-v4's `EffectivelySmooth`, Pharr et al. 2023).
pub const SPECULAR_ALPHA: f32 = 1e-3;

/// Smallest roughness used internally; smaller positive values are clamped
/// to it (the lobe is then a near-mirror in f32 anyway).
pub const MIN_ALPHA: f32 = 1e-4;
/// Largest roughness accepted.
pub const MAX_ALPHA: f32 = 10.0;

/// Largest relative index of a dielectric (and smallest, inverted): far
/// beyond any real material; larger values only overflow f32 arithmetic.
pub const MAX_ETA: f32 = 100.0;

/// Largest Student-T shape gamma (Beckmann to f32 precision beyond).
pub const MAX_SHAPE: f32 = 1e4;

/// The default error tolerance of [`Model::Auto`] (the knee of the
/// measured speed-accuracy fronts: analytic models only; see the C field
/// `msbsdf_material_desc::tolerance` for what it picks).
pub const DEFAULT_TOLERANCE: f32 = 0.03;

/// The scattering method (`MSBSDF_MODEL_*`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Model {
    /// Single scattering (Cook-Torrance / Walter 2007).
    Single,
    /// Kulla-Conty / Turquin energy compensation.
    EnergyCompensated,
    /// Heitz et al. 2016 height random walk.
    HeitzRandomWalk,
    /// Position-free path integral (Wang et al. 2022).
    PositionFree,
    /// Invariance principle (Cui et al. 2023).
    Invariance,
    /// Bitterli and d'Eon 2022 exit probability.
    BitterliDeon,
    /// Symmetric V-groove (Lee et al. 2018).
    VGroove,
    /// Nonsymmetric V-groove (Lee et al. 2018).
    VGrooveNonsymmetric,
    /// Null-scattering walk for general NDFs (d'Eon 2023).
    NullScattering,
    /// Picks the cheapest model meeting a tolerance.
    Auto,
    /// Exact single scattering plus the HEITZ walk's orders >= 2 from tables.
    Tabulated,
}

/// Estimator of the position-free models (`MSBSDF_ESTIMATOR_*`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Estimator {
    /// Unidirectional path tracing with next-event estimation.
    Pt,
    /// Bidirectional path tracing with MIS.
    Bdpt,
}

/// The NDF requested (`MSBSDF_NDF_*`); not all are implemented by every model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NdfId {
    /// Beckmann.
    Beckmann,
    /// GGX / Trowbridge-Reitz.
    Ggx,
    /// Student-T with shape gamma > 1.5.
    StudentT,
    /// Phong (V-groove models).
    Phong,
    /// Exponential (null scattering).
    Exponential,
    /// Bessel K0 (null scattering).
    BesselK0,
    /// von Mises-Fisher, full sphere (null scattering).
    Vmf,
}

/// The facet kind (`MSBSDF_FACET_*`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FacetKind {
    /// Conductor with complex IOR.
    Conductor,
    /// Dielectric interface.
    Dielectric,
    /// Lambertian facets.
    Diffuse,
    /// Facets scatter as another material (composition).
    Material,
}

/// Everything that describes a material, as plain Rust values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaterialDesc {
    /// Scattering method.
    pub model: Model,
    /// Estimator (position-free / invariance models).
    pub estimator: Estimator,
    /// Microfacet distribution.
    pub ndf: NdfId,
    /// Facet material.
    pub facet: FacetKind,
    /// Roughness along x (> 0).
    pub alpha_x: f32,
    /// Roughness along y (> 0).
    pub alpha_y: f32,
    /// NDF shape parameter (Student-T gamma).
    pub shape: f32,
    /// Conductor: real index per channel; dielectric: `eta.x` = inside / outside.
    pub eta: Vec3,
    /// Conductor extinction per channel.
    pub k: Vec3,
    /// Diffuse facet albedo per channel.
    pub albedo: Vec3,
    /// Bounce limit, 0 for the model default.
    pub max_bounces: u32,
    /// Error tolerance for [`Model::Auto`] ([`DEFAULT_TOLERANCE`]; see the C field
    /// `msbsdf_material_desc::tolerance` for what it picks).
    pub tolerance: f32,
    /// [`FacetKind::Material`]: the facets scatter as this material
    /// (composition, e.g. biscale roughness; d'Eon 2023, section 4). Only
    /// [`Model::NullScattering`] supports it, with an opaque (conductor or
    /// diffuse) inner material that is not itself a null-scattering one.
    /// The new material keeps a copy ([`Material::with_inner`] takes one
    /// that need not be `'static`).
    pub inner: Option<&'static Material>,
    /// Conductors only: true for a one-sided conductor (a `wi` below the
    /// surface is absorbed: eval, pdf and sample weight 0); false (the
    /// default) mirrors the back face onto the front face.
    pub one_sided: bool,
}

impl Default for MaterialDesc {
    /// GGX alpha 0.5, perfectly reflecting conductor facets, single scattering.
    fn default() -> Self {
        MaterialDesc {
            model: Model::Single,
            estimator: Estimator::Pt,
            ndf: NdfId::Ggx,
            facet: FacetKind::Conductor,
            alpha_x: 0.5,
            alpha_y: 0.5,
            shape: 2.0,
            eta: Vec3::ZERO,
            k: Vec3::ONE,
            albedo: Vec3::splat(0.8),
            max_bounces: 0,
            tolerance: DEFAULT_TOLERANCE,
            inner: None,
            one_sided: false,
        }
    }
}

impl MaterialDesc {
    /// The Smith microfacet distribution of the description (Beckmann, GGX
    /// or Student-T; roughness clamped to [`MIN_ALPHA`]; the shape matters
    /// for Student-T only): `Error::Unsupported` for the NDFs that have no
    /// Smith form here (vMF, exponential, K0, Phong).
    pub(crate) fn smith_ndf(&self) -> Result<Ndf, Error> {
        let kind = match self.ndf {
            NdfId::Beckmann => NdfKind::Beckmann,
            NdfId::Ggx => NdfKind::Ggx,
            NdfId::StudentT => NdfKind::StudentT,
            NdfId::Vmf | NdfId::Exponential | NdfId::BesselK0 | NdfId::Phong => {
                return Err(Error::Unsupported);
            }
        };
        Ok(Ndf::with_shape(
            kind,
            self.alpha_x.max(MIN_ALPHA),
            self.alpha_y.max(MIN_ALPHA),
            self.shape,
        ))
    }
}
