//! A validated material: the description, its checks, and the dispatch to the
//! scattering models (an enum `match`; no `dyn`, no heap).

use crate::bsdf::{Sample, ScatterModel};
use crate::facet::Facet;
use crate::frame::is_valid_direction;
use crate::multiple::auto;
use crate::multiple::bitterli_deon::BitterliDeon;
use crate::multiple::compensation::{self, Compensated};
use crate::multiple::heitz::Heitz;
use crate::multiple::invariance::{self, Invariance};
use crate::multiple::null_scattering::{self, NullNdf, NullNdfKind, NullScattering};
use crate::multiple::position_free::PositionFree;
use crate::multiple::tabulated::{self, Tabulated};
use crate::multiple::vgroove::{VGroove, dist::Family};
use crate::ndf::{Ndf, NdfKind};
use crate::rng::Rng;
use crate::single::{G2Form, Single};
use crate::status::Error;
use glam::Vec3;

/// Largest number of scattering events any walk follows (path state on the
/// stack is bounded by it).
pub const MAX_BOUNCES: u32 = 256;

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

/// The scattering method (`MSBSDF_MODEL_*`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Model {
    /// Single scattering (Cook-Torrance / Walter 2007).
    Single,
    /// Kulla-Conty / Turquin energy compensation.
    EnergyCompensated,
    /// Heitz et al. 2016 height random walk.
    HeitzRandomWalk,
    /// Position-free path integral (seed 000).
    PositionFree,
    /// Invariance principle (seed 003).
    Invariance,
    /// Bitterli and d'Eon 2022 exit probability.
    BitterliDeon,
    /// Symmetric V-groove (seed 002).
    VGroove,
    /// Nonsymmetric V-groove (seed 002).
    VGrooveNonsymmetric,
    /// Null-scattering walk for general NDFs (seed 001).
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
    /// Error tolerance for [`Model::Auto`] (default 0.1; see the C field
    /// `msbsdf_material_desc::tolerance` for what it picks).
    pub tolerance: f32,
    /// [`FacetKind::Material`]: the facets scatter as this material
    /// (composition, e.g. biscale roughness; seed 001 section 4). Only
    /// [`Model::NullScattering`] supports it, with an opaque (conductor or
    /// diffuse) inner material that is not itself a composition.
    pub inner: Option<&'static Material>,
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
            tolerance: 0.1,
            inner: None,
        }
    }
}

/// `match` over every model (static dispatch: no `dyn`, no heap).
macro_rules! dispatch {
    ($imp:expr, $m:ident => $body:expr) => {
        match $imp {
            ModelImpl::Single($m) => $body,
            ModelImpl::PositionFree($m) => $body,
            ModelImpl::Compensated($m) => $body,
            ModelImpl::Heitz($m) => $body,
            ModelImpl::Tabulated($m) => $body,
            ModelImpl::Invariance($m) => $body,
            ModelImpl::BitterliDeon($m) => $body,
            ModelImpl::NullScattering($m) => $body,
            ModelImpl::VGroove($m) | ModelImpl::VGrooveNonsymmetric($m) => $body,
        }
    };
}

// Variants are stored inline (the largest, ENERGY_COMPENSATED with its
// Fresnel tint table, is about 500 bytes): a material lives in caller storage
// (`msbsdf_material_init`) and never allocates, so boxing is not an option.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
enum ModelImpl {
    PositionFree(PositionFree),
    Single(Single),
    Invariance(Invariance),
    BitterliDeon(BitterliDeon),
    NullScattering(NullScattering),
    Compensated(Compensated),
    Heitz(Heitz),
    Tabulated(Tabulated),
    VGroove(VGroove),
    VGrooveNonsymmetric(VGroove),
}

/// A validated, immutable material. `Copy`, heap-free, `Send + Sync`: any
/// number of threads may query it at once, each with its own [`Rng`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    imp: ModelImpl,
    desc: MaterialDesc,
    /// The model actually built (differs from `desc.model` for AUTO).
    chosen: auto::Choice,
}

fn valid_rgb(v: Vec3, lo: f32) -> bool {
    v.is_finite() && v.min_element() >= lo
}

impl Material {
    /// Validates `desc` and builds the material.
    ///
    /// [`Model::NullScattering`] refuses with [`Error::InvalidArgument`] a
    /// roughness below [`null_scattering::MIN_ALPHA`] (0.2: the delta-tracking
    /// rejection rate grows like `1 / alpha^2`, seed 001 section 3.3), and with
    /// [`Error::Unsupported`] the Phong NDF, anisotropic vMF / exponential /
    /// Bessel K0, and Student-T with shape below 2 (unbounded at the horizon,
    /// so no constant majorant exists).
    pub fn new(desc: &MaterialDesc) -> Result<Material, Error> {
        let d = *desc;
        for a in [d.alpha_x, d.alpha_y] {
            if !(a.is_finite() && a > 0.0 && a <= MAX_ALPHA) {
                return Err(Error::InvalidArgument);
            }
        }
        if !d.shape.is_finite() || !d.tolerance.is_finite() || d.tolerance < 0.0 {
            return Err(Error::InvalidArgument);
        }
        if d.max_bounces > MAX_BOUNCES {
            return Err(Error::InvalidArgument);
        }
        // Student-T: gamma > 1.5 (finite variance of the slopes); above 1e4 it
        // is Beckmann to f32 precision, and huge values overflow its sampler.
        if d.ndf == NdfId::StudentT && !(d.shape > 1.5 && d.shape <= MAX_SHAPE) {
            return Err(Error::InvalidArgument);
        }
        let facet = match d.facet {
            FacetKind::Conductor => {
                if !valid_rgb(d.eta, 0.0) || !valid_rgb(d.k, 0.0) {
                    return Err(Error::InvalidArgument);
                }
                let both_zero = (d.eta.cmpeq(Vec3::ZERO) & d.k.cmpeq(Vec3::ZERO)).any();
                if both_zero {
                    return Err(Error::InvalidArgument);
                }
                Facet::Conductor { eta: d.eta, k: d.k }
            }
            FacetKind::Dielectric => {
                if !(d.eta.x.is_finite() && d.eta.x >= 1.0 / MAX_ETA && d.eta.x <= MAX_ETA) {
                    return Err(Error::InvalidArgument);
                }
                Facet::Dielectric { eta: d.eta.x }
            }
            FacetKind::Diffuse => {
                if !valid_rgb(d.albedo, 0.0) || d.albedo.max_element() > 1.0 {
                    return Err(Error::InvalidArgument);
                }
                Facet::Diffuse { albedo: d.albedo }
            }
            FacetKind::Material => {
                if d.model != Model::NullScattering {
                    return Err(Error::Unsupported);
                }
                let inner = d.inner.ok_or(Error::NullPointer)?;
                let opaque = matches!(inner.desc.facet, FacetKind::Conductor | FacetKind::Diffuse);
                if !opaque {
                    return Err(Error::Unsupported);
                }
                // Placeholder: the null-scattering walk scatters by `inner`.
                Facet::Conductor {
                    eta: Vec3::ZERO,
                    k: Vec3::ONE,
                }
            }
        };
        let ndf_kind = match d.ndf {
            NdfId::Beckmann => Some(NdfKind::Beckmann),
            NdfId::Ggx => Some(NdfKind::Ggx),
            NdfId::StudentT => Some(NdfKind::StudentT),
            _ => None,
        };
        // The Smith NDF of the description (roughness clamped to MIN_ALPHA;
        // the shape matters for Student-T only).
        let smith_ndf = |kind: NdfKind| {
            Ndf::with_shape(
                kind,
                d.alpha_x.max(MIN_ALPHA),
                d.alpha_y.max(MIN_ALPHA),
                d.shape,
            )
        };
        let imp = match d.model {
            Model::Single => {
                let kind = ndf_kind.ok_or(Error::Unsupported)?;
                if matches!(facet, Facet::Diffuse { .. }) {
                    return Err(Error::Unsupported);
                }
                let ndf = smith_ndf(kind);
                ModelImpl::Single(Single::new(ndf, facet, G2Form::HeightCorrelated))
            }
            Model::Invariance | Model::BitterliDeon => {
                // Beckmann, GGX and Student-T: the walks use only the generic
                // Smith API (tests/invariance.rs checks Student-T too).
                let kind = ndf_kind.ok_or(Error::Unsupported)?;
                if !matches!(facet, Facet::Conductor { .. }) {
                    return Err(Error::Unsupported);
                }
                let ndf = smith_ndf(kind);
                // Heavy Student-T tails at large roughness need walks too long
                // for these estimators' f64 arithmetic (MAX_DEFAULT_BOUNCES).
                if invariance::default_max_bounces_for(&ndf) > invariance::MAX_DEFAULT_BOUNCES {
                    return Err(Error::Unsupported);
                }
                if d.model == Model::Invariance {
                    ModelImpl::Invariance(Invariance::new(ndf, facet, d.estimator, d.max_bounces))
                } else {
                    if d.estimator != Estimator::Pt {
                        return Err(Error::Unsupported);
                    }
                    ModelImpl::BitterliDeon(BitterliDeon::new(ndf, facet, d.max_bounces))
                }
            }
            Model::NullScattering => {
                // Below null_scattering::MIN_ALPHA the rejection rate makes
                // the walk impractical (seed 001, section 3.3): refused.
                if d.alpha_x.min(d.alpha_y) < null_scattering::MIN_ALPHA {
                    return Err(Error::InvalidArgument);
                }
                let kind = match d.ndf {
                    NdfId::Beckmann => NullNdfKind::Beckmann,
                    NdfId::Ggx => NullNdfKind::Ggx,
                    NdfId::StudentT => NullNdfKind::StudentT,
                    NdfId::Vmf => NullNdfKind::Vmf,
                    NdfId::Exponential => NullNdfKind::Exponential,
                    NdfId::BesselK0 => NullNdfKind::BesselK0,
                    NdfId::Phong => return Err(Error::Unsupported),
                };
                let ndf =
                    NullNdf::new(kind, d.alpha_x, d.alpha_y, d.shape).ok_or(Error::Unsupported)?;
                let model = NullScattering::new(ndf, facet, d.max_bounces);
                ModelImpl::NullScattering(match d.inner {
                    Some(inner) if d.facet == FacetKind::Material => model.with_inner(inner),
                    _ => model,
                })
            }
            Model::EnergyCompensated => {
                let kind = ndf_kind.ok_or(Error::Unsupported)?;
                if kind == NdfKind::StudentT {
                    return Err(Error::Unsupported); // tables for Beckmann and GGX only
                }
                match facet {
                    Facet::Diffuse { .. } => return Err(Error::Unsupported),
                    Facet::Dielectric { eta }
                        if !(1.0 / compensation::MAX_ETA..=compensation::MAX_ETA)
                            .contains(&eta) =>
                    {
                        return Err(Error::InvalidArgument);
                    }
                    _ => {}
                }
                if d.alpha_x > compensation::MAX_ALPHA || d.alpha_y > compensation::MAX_ALPHA {
                    return Err(Error::InvalidArgument);
                }
                let ndf = smith_ndf(kind);
                ModelImpl::Compensated(Compensated::new(ndf, facet))
            }
            Model::Tabulated => {
                // Tables for Beckmann and GGX conductors up to tabulated::MAX_ALPHA.
                let kind = ndf_kind.ok_or(Error::Unsupported)?;
                if tabulated::ndf_index(kind).is_none() || !matches!(facet, Facet::Conductor { .. })
                {
                    return Err(Error::Unsupported);
                }
                if d.alpha_x > tabulated::MAX_ALPHA || d.alpha_y > tabulated::MAX_ALPHA {
                    return Err(Error::InvalidArgument);
                }
                ModelImpl::Tabulated(Tabulated::new(smith_ndf(kind), facet))
            }
            Model::HeitzRandomWalk => {
                let kind = ndf_kind.ok_or(Error::Unsupported)?;
                let ndf = smith_ndf(kind);
                ModelImpl::Heitz(Heitz::new(ndf, facet, d.max_bounces))
            }
            Model::PositionFree => {
                // Beckmann, GGX and Student-T (tests/position_free.rs).
                let kind = ndf_kind.ok_or(Error::Unsupported)?;
                if matches!(facet, Facet::Diffuse { .. }) {
                    return Err(Error::Unsupported);
                }
                let ndf = smith_ndf(kind);
                ModelImpl::PositionFree(PositionFree::new(ndf, facet, d.estimator, d.max_bounces))
            }
            Model::VGroove | Model::VGrooveNonsymmetric => {
                // seed 002: conductor facets; Beckmann, GGX and Phong NDFs.
                let Facet::Conductor { eta, k } = facet else {
                    return Err(Error::Unsupported);
                };
                let family = match d.ndf {
                    NdfId::Beckmann => Family::Beckmann,
                    NdfId::Ggx => Family::Ggx,
                    NdfId::Phong => {
                        // Phong exponent 2 / alpha^2 - 2 must be >= 0.
                        if d.alpha_x > 1.0 || d.alpha_y > 1.0 {
                            return Err(Error::InvalidArgument);
                        }
                        Family::Phong
                    }
                    _ => return Err(Error::Unsupported),
                };
                let symmetric = d.model == Model::VGroove;
                let m = VGroove::new(
                    family,
                    d.alpha_x.max(MIN_ALPHA),
                    d.alpha_y.max(MIN_ALPHA),
                    eta,
                    k,
                    d.max_bounces,
                    symmetric,
                );
                if symmetric {
                    ModelImpl::VGroove(m)
                } else {
                    ModelImpl::VGrooveNonsymmetric(m)
                }
            }
            Model::Auto => {
                // The choice comes from the measured table (multiple/auto.rs).
                let c = auto::choose(&d)?;
                let inner = Material::new(&auto::concrete(&d, c.model, c.estimator))?;
                return Ok(Material {
                    imp: inner.imp,
                    desc: d,
                    chosen: c,
                });
            }
        };
        let chosen = auto::Choice {
            model: d.model,
            estimator: d.estimator,
            evaluations: 1,
            error: f32::INFINITY,
            ns: f32::INFINITY,
        };
        Ok(Material {
            imp,
            desc: d,
            chosen,
        })
    }

    /// The model, estimator and evaluations per eval query actually used:
    /// the description's own, or what [`Model::Auto`] picked.
    pub fn chosen(&self) -> &auto::Choice {
        &self.chosen
    }

    /// The description this material was built from.
    pub fn desc(&self) -> &MaterialDesc {
        &self.desc
    }

    /// True when eval is a Monte Carlo estimate (it then needs an [`Rng`]).
    pub fn is_stochastic(&self) -> bool {
        match self.imp {
            ModelImpl::Single(_) | ModelImpl::Compensated(_) | ModelImpl::Tabulated(_) => false,
            ModelImpl::Invariance(_) | ModelImpl::BitterliDeon(_) => true,
            ModelImpl::NullScattering(_) => true,
            ModelImpl::Heitz(_) => true,
            ModelImpl::PositionFree(_) => true,
            ModelImpl::VGroove(_) | ModelImpl::VGrooveNonsymmetric(_) => false,
        }
    }

    /// `f(wi, wo) |wo.z|` per RGB channel. Directions need not be normalised;
    /// invalid or horizon directions give zero.
    pub fn eval(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        let Some((wi, wo)) = prepare(wi, wo) else {
            return Vec3::ZERO;
        };
        let n = self.chosen.evaluations;
        let v = if n <= 1 {
            dispatch!(&self.imp, m => m.eval(wi, wo, rng))
        } else {
            // AUTO with a stochastic model: the mean of n evaluations.
            let mut sum = Vec3::ZERO;
            for _ in 0..n {
                sum += finite_or_zero(dispatch!(&self.imp, m => m.eval(wi, wo, rng)));
            }
            sum / n as f32
        };
        finite_or_zero(v)
    }

    /// Samples an outgoing direction for `wi` (need not be normalised).
    pub fn sample(&self, wi: Vec3, rng: &mut Rng) -> Sample {
        if !is_valid_direction(wi) {
            return Sample::ABSORBED;
        }
        let wi = wi.normalize();
        if wi.z == 0.0 {
            return Sample::ABSORBED;
        }
        let s = dispatch!(&self.imp, m => m.sample(wi, rng));
        if !(s.weight.is_finite() && s.pdf.is_finite() && s.wo.is_finite())
            || s.weight.min_element() < 0.0
        {
            return Sample::ABSORBED;
        }
        s
    }

    /// Density with which [`Material::sample`] picks `wo` (exact for
    /// deterministic models; an approximation for stochastic ones).
    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        let Some((wi, wo)) = prepare(wi, wo) else {
            return 0.0;
        };
        let p = dispatch!(&self.imp, m => m.pdf(wi, wo));
        if p.is_finite() && p > 0.0 { p } else { 0.0 }
    }
}

/// Normalises both directions; `None` for invalid or horizon directions.
#[inline]
fn prepare(wi: Vec3, wo: Vec3) -> Option<(Vec3, Vec3)> {
    if !is_valid_direction(wi) || !is_valid_direction(wo) {
        return None;
    }
    let (wi, wo) = (wi.normalize(), wo.normalize());
    if wi.z == 0.0 || wo.z == 0.0 || !wi.is_finite() || !wo.is_finite() {
        return None;
    }
    Some((wi, wo))
}

/// Last line of defence: a non-finite or negative channel becomes 0.
#[inline]
fn finite_or_zero(v: Vec3) -> Vec3 {
    let f = |x: f32| if x.is_finite() && x > 0.0 { x } else { 0.0 };
    Vec3::new(f(v.x), f(v.y), f(v.z))
}
