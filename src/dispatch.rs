//! Static dispatch over the scattering models (an enum `match`: no `dyn`, no
//! heap), and the guards every query passes through: directions normalised,
//! horizon and invalid directions give zero, non-finite results become zero.
//!
//! [`Inner`] is a material kept by value as the facets of a composition
//! (`FacetKind::Material`): the composite owns its copy, so destroying the
//! material it was built from cannot leave it dangling.

use crate::bsdf::{Sample, ScatterModel};
use crate::frame::is_valid_direction;
use crate::multiple::bitterli_deon::BitterliDeon;
use crate::multiple::compensation::Compensated;
use crate::multiple::heitz::Heitz;
use crate::multiple::invariance::Invariance;
use crate::multiple::position_free::PositionFree;
use crate::multiple::tabulated::Tabulated;
use crate::multiple::tabulated_dielectric::TabulatedDielectric;
use crate::multiple::vgroove::VGroove;
use crate::rng::Rng;
use crate::single::Single;
use crate::specular::Specular;
use glam::Vec3;

/// Every model except the null-scattering walk (which may hold an [`Inner`]
/// and so cannot be one).
// Variants are stored inline (the largest, ENERGY_COMPENSATED with its
// Fresnel tint table, is about 500 bytes): a material lives in caller storage
// (`msbsdf_material_init`) and never allocates, so boxing is not an option.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BaseModel {
    /// `MSBSDF_MODEL_SINGLE`.
    Single(Single),
    /// The specular regime of any model (alpha below `SPECULAR_ALPHA`).
    Specular(Specular),
    /// `MSBSDF_MODEL_ENERGY_COMPENSATED`.
    Compensated(Compensated),
    /// `MSBSDF_MODEL_HEITZ_RANDOM_WALK`.
    Heitz(Heitz),
    /// `MSBSDF_MODEL_POSITION_FREE`.
    PositionFree(PositionFree),
    /// `MSBSDF_MODEL_INVARIANCE`.
    Invariance(Invariance),
    /// `MSBSDF_MODEL_BITTERLI_DEON`.
    BitterliDeon(BitterliDeon),
    /// `MSBSDF_MODEL_VGROOVE` and `_NONSYMMETRIC`.
    VGroove(VGroove),
    /// `MSBSDF_MODEL_TABULATED`.
    Tabulated(Tabulated),
    /// `MSBSDF_MODEL_TABULATED` with dielectric facets.
    TabulatedDielectric(TabulatedDielectric),
}

macro_rules! base_dispatch {
    ($imp:expr, $m:ident => $body:expr) => {
        match $imp {
            BaseModel::Single($m) => $body,
            BaseModel::Specular($m) => $body,
            BaseModel::Compensated($m) => $body,
            BaseModel::Heitz($m) => $body,
            BaseModel::PositionFree($m) => $body,
            BaseModel::Invariance($m) => $body,
            BaseModel::BitterliDeon($m) => $body,
            BaseModel::VGroove($m) => $body,
            BaseModel::Tabulated($m) => $body,
            BaseModel::TabulatedDielectric($m) => $body,
        }
    };
}

impl BaseModel {
    /// True when eval is a Monte Carlo estimate (it then needs an [`Rng`]).
    pub fn is_stochastic(&self) -> bool {
        matches!(
            self,
            BaseModel::Heitz(_)
                | BaseModel::PositionFree(_)
                | BaseModel::Invariance(_)
                | BaseModel::BitterliDeon(_)
        )
    }
}

impl ScatterModel for BaseModel {
    #[inline]
    fn eval(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        base_dispatch!(self, m => m.eval(wi, wo, rng))
    }
    #[inline]
    fn sample(&self, wi: Vec3, rng: &mut Rng) -> Sample {
        base_dispatch!(self, m => m.sample(wi, rng))
    }
    #[inline]
    fn sample_with(&self, wi: Vec3, u: [f32; 3], rng: &mut Rng) -> Sample {
        base_dispatch!(self, m => m.sample_with(wi, u, rng))
    }
    #[inline]
    fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        base_dispatch!(self, m => m.pdf(wi, wo))
    }
}

/// A material used as the facets of a composition, kept by value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inner {
    /// The model.
    pub model: BaseModel,
    /// Evaluations averaged per eval (AUTO), at least 1.
    pub evaluations: u32,
}

impl Inner {
    /// `f(wi, wo) |wo.z|` as [`crate::Material::eval`] answers it.
    pub fn eval(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        eval_guarded(&self.model, self.evaluations, wi, wo, rng)
    }

    /// A sample as [`crate::Material::sample`] draws it.
    pub fn sample(&self, wi: Vec3, rng: &mut Rng) -> Sample {
        sample_guarded(wi, |wi| self.model.sample(wi, rng))
    }
}

/// Eval with the guards: normalised directions, zero at the horizon, the
/// mean of `evaluations` estimates (AUTO), non-finite channels zeroed.
#[inline]
pub fn eval_guarded<M: ScatterModel>(
    m: &M,
    evaluations: u32,
    wi: Vec3,
    wo: Vec3,
    rng: &mut Rng,
) -> Vec3 {
    let Some((wi, wo)) = prepare(wi, wo) else {
        return Vec3::ZERO;
    };
    finite_or_zero(eval_prepared(m, evaluations, wi, wo, rng))
}

/// Eval of unit, non-horizon directions (the mean of `evaluations`).
#[inline]
pub fn eval_prepared<M: ScatterModel>(
    m: &M,
    evaluations: u32,
    wi: Vec3,
    wo: Vec3,
    rng: &mut Rng,
) -> Vec3 {
    if evaluations <= 1 {
        m.eval(wi, wo, rng)
    } else {
        // AUTO with a stochastic model: the mean of n evaluations.
        let mut sum = Vec3::ZERO;
        for _ in 0..evaluations {
            sum += finite_or_zero(m.eval(wi, wo, rng));
        }
        sum / evaluations as f32
    }
}

/// Normalises `wi`, refuses horizon and invalid directions, runs `draw` and
/// turns a non-finite or negative result into an absorbed sample.
#[inline]
pub fn sample_guarded(wi: Vec3, draw: impl FnOnce(Vec3) -> Sample) -> Sample {
    let Some(wi) = prepare_one(wi) else {
        return Sample::ABSORBED;
    };
    let s = draw(wi);
    if !(s.weight.is_finite() && s.pdf.is_finite() && s.wo.is_finite())
        || s.weight.min_element() < 0.0
    {
        return Sample::ABSORBED;
    }
    s
}

/// Normalises one direction; `None` for invalid or horizon directions.
#[inline]
pub fn prepare_one(wi: Vec3) -> Option<Vec3> {
    if !is_valid_direction(wi) {
        return None;
    }
    let wi = wi.normalize();
    if wi.z == 0.0 || !wi.is_finite() {
        return None;
    }
    Some(wi)
}

/// Normalises both directions; `None` for invalid or horizon directions.
#[inline]
pub fn prepare(wi: Vec3, wo: Vec3) -> Option<(Vec3, Vec3)> {
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
pub fn finite_or_zero(v: Vec3) -> Vec3 {
    let f = |x: f32| if x.is_finite() && x > 0.0 { x } else { 0.0 };
    Vec3::new(f(v.x), f(v.y), f(v.z))
}
