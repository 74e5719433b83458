//! A validated material: the description, its checks, and the dispatch to the
//! scattering models (an enum `match`; no `dyn`, no heap).

use crate::bsdf::{
    Context, LOBE_ALL, MATERIAL_ANISOTROPIC, MATERIAL_APPROXIMATE_PDF, MATERIAL_GLOSSY,
    MATERIAL_REFLECTION, MATERIAL_SPECULAR, MATERIAL_STOCHASTIC_EVAL, MATERIAL_TRANSMISSION,
    SAMPLE_ABSORBED, SAMPLE_GLOSSY, SAMPLE_SPECULAR, SAMPLE_TRANSMISSION, Sample, SampleRecord,
    ScatterModel, Transport, opposite_sides,
};
use crate::dispatch::{
    BaseModel, Inner, eval_prepared, finite_or_zero, prepare, prepare_one, sample_guarded,
};
use crate::facet::Facet;
use crate::multiple::auto;
use crate::multiple::bitterli_deon::BitterliDeon;
use crate::multiple::compensation::Compensated;
use crate::multiple::heitz::Heitz;
use crate::multiple::invariance::Invariance;
use crate::multiple::null_scattering::NullScattering;
use crate::multiple::position_free::PositionFree;
use crate::multiple::tabulated::Tabulated;
use crate::multiple::tabulated_dielectric::TabulatedDielectric;
use crate::multiple::vgroove::VGroove;
use crate::rng::Rng;
use crate::single::Single;
use crate::specular::Specular;
use crate::status::Error;
use glam::Vec3;

pub use crate::desc::{
    DEFAULT_TOLERANCE, Estimator, FacetKind, MAX_ALPHA, MAX_BOUNCES, MAX_ETA, MAX_SHAPE, MIN_ALPHA,
    MaterialDesc, Model, NdfId, SPECULAR_ALPHA,
};

/// The model of a material: any base model, or the null-scattering walk
/// (which may hold a base model by value as its facets).
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
enum ModelImpl {
    Base(BaseModel),
    NullScattering(NullScattering),
}

impl ScatterModel for ModelImpl {
    #[inline]
    fn eval(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        match self {
            ModelImpl::Base(m) => m.eval(wi, wo, rng),
            ModelImpl::NullScattering(m) => m.eval(wi, wo, rng),
        }
    }
    #[inline]
    fn sample(&self, wi: Vec3, rng: &mut Rng) -> Sample {
        match self {
            ModelImpl::Base(m) => m.sample(wi, rng),
            ModelImpl::NullScattering(m) => m.sample(wi, rng),
        }
    }
    #[inline]
    fn sample_with(&self, wi: Vec3, u: [f32; 3], rng: &mut Rng) -> Sample {
        match self {
            ModelImpl::Base(m) => m.sample_with(wi, u, rng),
            ModelImpl::NullScattering(m) => m.sample_with(wi, u, rng),
        }
    }
    #[inline]
    fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        match self {
            ModelImpl::Base(m) => m.pdf(wi, wo),
            ModelImpl::NullScattering(m) => m.pdf(wi, wo),
        }
    }
}

/// A validated, immutable material. `Copy`, heap-free, `Send + Sync`: any
/// number of threads may query it at once, each with its own [`Rng`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    imp: ModelImpl,
    desc: MaterialDesc,
    /// The model actually built (differs from `desc.model` for AUTO).
    chosen: auto::Choice,
    /// `MATERIAL_*` flags, computed once at construction.
    flags: u32,
}

fn valid_rgb(v: Vec3, lo: f32) -> bool {
    v.is_finite() && v.min_element() >= lo
}

impl Material {
    /// Validates `desc` and builds the material.
    ///
    /// [`Model::NullScattering`] refuses with [`Error::InvalidArgument`] a
    /// roughness below [`crate::multiple::null_scattering::MIN_ALPHA`] (0.2:
    /// the delta-tracking rejection rate grows like `1 / alpha^2`, d'Eon 2023
    /// section 3.3), and with
    /// [`Error::Unsupported`] the Phong NDF, anisotropic vMF / exponential /
    /// Bessel K0, and Student-T with shape below 2 (unbounded at the horizon,
    /// so no constant majorant exists).
    ///
    /// A conductor or dielectric with roughness below [`SPECULAR_ALPHA`]
    /// along both axes (0 included) is smooth (see [`crate::specular`]) for
    /// every model that accepts the same description at that threshold;
    /// a dielectric's `eta.y` and `eta.z` must equal `eta.x` or be 0
    /// (unused), else [`Error::InvalidArgument`] (no dispersion).
    pub fn new(desc: &MaterialDesc) -> Result<Material, Error> {
        Material::with_inner(desc, desc.inner)
    }

    /// [`Material::new`] with the facets' material of a composition given
    /// apart from `desc` (whose own `inner` is ignored): the new material
    /// keeps a copy of what it needs, so `inner` need only live for this
    /// call.
    pub fn with_inner(desc: &MaterialDesc, inner: Option<&Material>) -> Result<Material, Error> {
        let d = *desc;
        for a in [d.alpha_x, d.alpha_y] {
            if !(0.0..=MAX_ALPHA).contains(&a) {
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
                // One index for all channels: the others equal it or are
                // unused (0, the conductor default).
                if [d.eta.y, d.eta.z].iter().any(|&e| e != 0.0 && e != d.eta.x) {
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
                let inner = inner.ok_or(Error::NullPointer)?;
                let opaque = matches!(inner.desc.facet, FacetKind::Conductor | FacetKind::Diffuse);
                if !opaque {
                    return Err(Error::Unsupported);
                }
                // Kept by value; a null-scattering inner (itself able to hold
                // one) is not supported.
                if !matches!(inner.imp, ModelImpl::Base(_)) {
                    return Err(Error::Unsupported);
                }
                // Placeholder: the null-scattering walk scatters by `inner`.
                Facet::Conductor {
                    eta: Vec3::ZERO,
                    k: Vec3::ONE,
                }
            }
        };
        let smooth = d.alpha_x.max(d.alpha_y) < SPECULAR_ALPHA;
        if smooth && matches!(facet, Facet::Conductor { .. } | Facet::Dielectric { .. }) {
            // The model must accept the description at the threshold.
            let rough = MaterialDesc {
                alpha_x: SPECULAR_ALPHA,
                alpha_y: SPECULAR_ALPHA,
                ..d
            };
            let at_threshold = Material::with_inner(&rough, inner)?;
            return Ok(Material::finish(
                ModelImpl::Base(BaseModel::Specular(Specular::new(facet))),
                d,
                auto::Choice {
                    evaluations: 1,
                    ..at_threshold.chosen
                },
            ));
        }
        Material::build(&d, facet, inner)
    }

    /// The model of a validated description `d` whose facet is `facet`:
    /// each arm holds one model's support checks (what it refuses) and
    /// calls its constructor. AUTO builds the model it picks through this
    /// same dispatch ([`auto::build`]), so a model refuses for AUTO exactly
    /// what it refuses when asked for by name.
    #[inline(always)]
    fn build(d: &MaterialDesc, facet: Facet, inner: Option<&Material>) -> Result<Material, Error> {
        if d.model == Model::Auto {
            // The choice comes from the measured table (multiple/auto.rs);
            // the material keeps AUTO's description and the choice. The
            // common case, shaped like the direct path below so that the
            // model is built in place: the precomputed fronts' pick,
            // accepted by its model. Otherwise (no fronts for `d`, or the
            // pick refused) the full lookup, which builds its candidates
            // through this dispatch in a closure.
            let pick = auto::best_from_fronts(d).flatten();
            if let Some(c) = pick {
                // The pick's model and estimator over AUTO's description
                // (no copy of it: only the walks' constructors read the
                // estimator).
                if let Ok(imp) = Material::build_model(c.model, c.estimator, d, facet, inner) {
                    return Ok(Material::finish(imp, *d, c));
                }
            }
            return auto::build(d, pick, |cd, c| {
                Material::build_model(cd.model, cd.estimator, cd, facet, inner)
                    .map(|imp| Material::finish(imp, *d, c))
            });
        }
        let imp = Material::build_model(d.model, d.estimator, d, facet, inner)?;
        let chosen = auto::Choice::own(d.model, d.estimator);
        Ok(Material::finish(imp, *d, chosen))
    }

    /// The model of [`Material::build`] for a concrete (not AUTO) `model`
    /// with `estimator`, from the description `d` (whose own model and
    /// estimator are ignored: AUTO's pick is built from AUTO's
    /// description).
    #[inline(always)]
    fn build_model(
        model: Model,
        estimator: Estimator,
        d: &MaterialDesc,
        facet: Facet,
        inner: Option<&Material>,
    ) -> Result<ModelImpl, Error> {
        // Each model's constructor from the description owns its support
        // checks (NDF, facet, ranges); this is dispatch only. The walks
        // that take an estimator read it from a description with `model`
        // and `estimator` in place; the other constructors read neither.
        let base = |m: BaseModel| ModelImpl::Base(m);
        let walk = || auto::concrete(d, model, estimator);
        let imp = match model {
            Model::Single => base(BaseModel::Single(Single::from_desc(d, facet)?)),
            Model::Invariance => base(BaseModel::Invariance(Invariance::from_desc(
                &walk(),
                facet,
            )?)),
            Model::BitterliDeon => base(BaseModel::BitterliDeon(BitterliDeon::from_desc(
                &walk(),
                facet,
            )?)),
            Model::NullScattering => {
                let model = NullScattering::from_desc(d, facet)?;
                ModelImpl::NullScattering(match inner.map(|m| m.imp) {
                    Some(ModelImpl::Base(base)) if d.facet == FacetKind::Material => model
                        .with_inner(Inner {
                            model: base,
                            evaluations: inner.map_or(1, |m| m.chosen.evaluations),
                        }),
                    _ => model,
                })
            }
            Model::EnergyCompensated => {
                base(BaseModel::Compensated(Compensated::from_desc(d, facet)?))
            }
            Model::Tabulated => base(match facet {
                Facet::Dielectric { .. } => {
                    BaseModel::TabulatedDielectric(TabulatedDielectric::from_desc(d, facet)?)
                }
                _ => BaseModel::Tabulated(Tabulated::from_desc(d, facet)?),
            }),
            Model::HeitzRandomWalk => base(BaseModel::Heitz(Heitz::from_desc(d, facet)?)),
            Model::PositionFree => base(BaseModel::PositionFree(PositionFree::from_desc(
                &walk(),
                facet,
            )?)),
            Model::VGroove | Model::VGrooveNonsymmetric => base(BaseModel::VGroove(
                VGroove::from_desc(d, facet, model == Model::VGroove)?,
            )),
            // AUTO is resolved by `build`; it never picks itself.
            Model::Auto => return Err(Error::Unsupported),
        };
        Ok(imp)
    }

    /// The material of a built model, with its flags.
    #[inline(always)]
    fn finish(imp: ModelImpl, desc: MaterialDesc, chosen: auto::Choice) -> Material {
        let stochastic = match &imp {
            ModelImpl::Base(b) => b.is_stochastic(),
            ModelImpl::NullScattering(_) => true,
        };
        let mut flags = MATERIAL_REFLECTION;
        if desc.facet == FacetKind::Dielectric {
            flags |= MATERIAL_TRANSMISSION;
        }
        if matches!(imp, ModelImpl::Base(BaseModel::Specular(_))) {
            flags |= MATERIAL_SPECULAR;
        } else {
            flags |= MATERIAL_GLOSSY;
            if desc.alpha_x != desc.alpha_y {
                flags |= MATERIAL_ANISOTROPIC;
            }
        }
        if stochastic {
            flags |= MATERIAL_STOCHASTIC_EVAL | MATERIAL_APPROXIMATE_PDF;
        }
        Material {
            imp,
            desc,
            chosen,
            flags,
        }
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
        self.flags & MATERIAL_STOCHASTIC_EVAL != 0
    }

    /// What the material does (`MATERIAL_*` of [`crate::bsdf`]).
    pub fn flags(&self) -> u32 {
        self.flags
    }

    /// True when `wi` (unit, off the horizon) hits the absorbing back face
    /// of a one-sided conductor.
    #[inline]
    fn back_face(&self, wi: Vec3) -> bool {
        self.desc.one_sided && wi.z < 0.0 && self.desc.facet == FacetKind::Conductor
    }

    /// Relative index of the side of `wo` over the side of `wi` for a
    /// transmission (1 for reflection or an opaque material).
    #[inline]
    fn eta_across(&self, wi: Vec3, wo: Vec3) -> f32 {
        if self.desc.facet != FacetKind::Dielectric || !opposite_sides(wi, wo) {
            return 1.0;
        }
        let eta = self.desc.eta.x;
        if wi.z > 0.0 { eta } else { 1.0 / eta }
    }

    /// Factor of `ctx`'s transport mode on a value or weight for `wi -> wo`.
    #[inline]
    fn transport_scale(&self, ctx: &Context, wi: Vec3, wo: Vec3) -> f32 {
        match ctx.transport {
            Transport::Importance => 1.0,
            Transport::Radiance => {
                let e = self.eta_across(wi, wo);
                1.0 / (e * e)
            }
        }
    }

    /// `f(wi, wo) |wo.z|` per RGB channel. Directions need not be normalised;
    /// invalid or horizon directions give zero.
    pub fn eval(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        match prepare(wi, wo) {
            Some((wi, wo)) => self.eval_unit(wi, wo, rng),
            None => Vec3::ZERO,
        }
    }

    /// [`Material::eval`] of directions already checked and normalised
    /// (finite, unit length), as the C layer passes them: the checks happen
    /// once, at the boundary. Horizon directions give zero.
    #[inline(always)]
    pub(crate) fn eval_unit(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        if wi.z == 0.0 || wo.z == 0.0 || self.back_face(wi) {
            return Vec3::ZERO;
        }
        match &self.imp {
            // The two analytic tiers inline, without the dispatch calls
            // (TABULATED is deterministic: one evaluation).
            ModelImpl::Base(BaseModel::Single(m)) => {
                finite_or_zero(m.eval_pdf(wi, wo, LOBE_ALL, true, false).0)
            }
            ModelImpl::Base(BaseModel::Tabulated(m)) => finite_or_zero(m.eval(wi, wo, rng)),
            ModelImpl::Base(BaseModel::TabulatedDielectric(m)) => {
                finite_or_zero(m.eval(wi, wo, rng))
            }
            _ => self.eval_dispatched(wi, wo, rng),
        }
    }

    /// [`Material::eval_unit`] for every model but SINGLE and TABULATED, out
    /// of line.
    #[inline(never)]
    fn eval_dispatched(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        finite_or_zero(eval_prepared(
            &self.imp,
            self.chosen.evaluations,
            wi,
            wo,
            rng,
        ))
    }

    /// Samples an outgoing direction for `wi` (need not be normalised).
    pub fn sample(&self, wi: Vec3, rng: &mut Rng) -> Sample {
        sample_guarded(wi, |wi| {
            if self.back_face(wi) {
                return Sample::ABSORBED;
            }
            self.imp.sample(wi, rng)
        })
    }

    /// Density with which [`Material::sample`] picks `wo` (exact for
    /// deterministic models; an approximation for stochastic ones).
    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        match prepare(wi, wo) {
            Some((wi, wo)) => self.pdf_unit(wi, wo),
            None => 0.0,
        }
    }

    /// [`Material::pdf`] of checked unit directions (see
    /// [`Material::eval_unit`]).
    #[inline]
    pub(crate) fn pdf_unit(&self, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z == 0.0 || wo.z == 0.0 || self.back_face(wi) {
            return 0.0;
        }
        positive_or_zero(self.imp.pdf(wi, wo))
    }

    /// `(f(wi, wo) |wo.z|, pdf(wi, wo))` under `ctx` in one call: with
    /// [`Context::PLAIN`] bit for bit what [`Material::eval`] and
    /// [`Material::pdf`] return (SINGLE computes the half vector, D and the
    /// masking once for both). Lobes outside `ctx.lobes` give 0; radiance
    /// transport divides transmission by the relative index squared. For
    /// SINGLE a restricted lobe has its own pdf (taken with probability 1);
    /// for the other models the pdf of a restricted query is that of the
    /// unrestricted sampler, whose samples in the other lobe
    /// [`Material::sample_ctx`] reports as absorbed.
    pub fn eval_pdf(&self, wi: Vec3, wo: Vec3, ctx: &Context, rng: &mut Rng) -> (Vec3, f32) {
        match prepare(wi, wo) {
            Some((wi, wo)) => self.eval_pdf_unit(wi, wo, ctx, rng),
            None => (Vec3::ZERO, 0.0),
        }
    }

    /// [`Material::eval_pdf`] of checked unit directions (see
    /// [`Material::eval_unit`]).
    #[inline]
    pub(crate) fn eval_pdf_unit(
        &self,
        wi: Vec3,
        wo: Vec3,
        ctx: &Context,
        rng: &mut Rng,
    ) -> (Vec3, f32) {
        if wi.z == 0.0 || wo.z == 0.0 || self.back_face(wi) || !ctx.allows(wi, wo) {
            return (Vec3::ZERO, 0.0);
        }
        let (f, p) = match &self.imp {
            ModelImpl::Base(BaseModel::Single(m)) => m.eval_pdf(wi, wo, ctx.lobes, true, true),
            imp => (
                eval_prepared(imp, self.chosen.evaluations, wi, wo, rng),
                imp.pdf(wi, wo),
            ),
        };
        let scale = self.transport_scale(ctx, wi, wo);
        let f = if scale == 1.0 { f } else { f * scale };
        (finite_or_zero(f), positive_or_zero(p))
    }

    /// Samples `wo` from the caller's uniforms under `ctx`: `u[0]` picks the
    /// lobe at the first vertex, `u[1], u[2]` the first visible normal;
    /// stochastic models draw the rest from `rng`. The record adds the
    /// specular / glossy flag and the relative index across the surface.
    pub fn sample_ctx(&self, wi: Vec3, u: [f32; 3], ctx: &Context, rng: &mut Rng) -> SampleRecord {
        // Into [0, 1): NaN to 0, 1 and above to the largest float below 1.
        let u = u.map(|x| {
            if x > 0.0 {
                x.min(1.0 - f32::EPSILON / 2.0)
            } else {
                0.0
            }
        });
        let mut specular = false;
        let s = sample_guarded(wi, |wi| {
            if self.back_face(wi) {
                return Sample::ABSORBED;
            }
            let lobes = ctx.lobes & LOBE_ALL;
            let s = match &self.imp {
                ModelImpl::Base(BaseModel::Single(m)) => m.sample_lobes(wi, u, lobes),
                ModelImpl::Base(BaseModel::Specular(m)) => {
                    specular = true;
                    m.sample_lobes(wi, u[0], lobes)
                }
                imp => {
                    let s = imp.sample_with(wi, u, rng);
                    if s.flags == SAMPLE_ABSORBED || !ctx.allows(wi, s.wo) {
                        return Sample::ABSORBED;
                    }
                    s
                }
            };
            if s.flags == SAMPLE_ABSORBED {
                return s;
            }
            let scale = self.transport_scale(ctx, wi, s.wo);
            Sample {
                weight: s.weight * scale,
                ..s
            }
        });
        if s.flags == SAMPLE_ABSORBED {
            return SampleRecord {
                sample: Sample::ABSORBED,
                flags: SAMPLE_ABSORBED,
                eta: 1.0,
            };
        }
        let kind = if specular {
            SAMPLE_SPECULAR
        } else {
            SAMPLE_GLOSSY
        };
        let eta = if s.flags & SAMPLE_TRANSMISSION != 0 {
            let wi = prepare_one(wi).unwrap_or(Vec3::Z);
            self.eta_across(wi, s.wo)
        } else {
            1.0
        };
        SampleRecord {
            sample: s,
            flags: s.flags | kind,
            eta,
        }
    }
}

/// A density that is finite and positive, else 0.
#[inline]
fn positive_or_zero(p: f32) -> f32 {
    if p.is_finite() && p > 0.0 { p } else { 0.0 }
}
