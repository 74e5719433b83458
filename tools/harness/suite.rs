//! The fixed suite: materials, direction pairs, and the (model, estimator)
//! combinations the library accepts for them (discovered at run time).

use glam::Vec3;
use msbsdf::capi::*;
use msbsdf::{Estimator, FacetKind, Material, MaterialDesc, Model, NdfId, Rng};

/// Gold (eta, k) per RGB channel.
pub const GOLD: ([f32; 3], [f32; 3]) = ([0.143, 0.374, 1.442], [3.983, 2.385, 1.603]);
/// Copper.
pub const COPPER: ([f32; 3], [f32; 3]) = ([0.200, 0.924, 1.102], [3.912, 2.452, 2.142]);
/// Aluminium.
pub const ALUMINIUM: ([f32; 3], [f32; 3]) = ([1.657, 0.880, 0.521], [9.224, 6.270, 4.837]);

/// Material class of the charts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Class {
    /// Conductor facets.
    Conductor,
    /// Dielectric facets.
    Dielectric,
}

impl Class {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Class::Conductor => "conductor",
            Class::Dielectric => "dielectric",
        }
    }
}

/// The groups the harness reports (charts, Pareto tables, summary CSV
/// columns): conductors (isotropic and anisotropic together: the class
/// issue 16's targets are stated on), isotropic dielectrics (the same), and
/// anisotropic dielectrics, added later and reported apart so that the
/// first two keep their definition (`SuiteMaterial::group`).
pub const GROUPS: [&str; 3] = ["conductor", "dielectric", "dielectric_anisotropic"];

/// One material of the suite.
#[derive(Clone, Debug, PartialEq)]
pub struct SuiteMaterial {
    /// Short unique name, e.g. `ggx_gold_0.3` or `ggx_gold_0.1x0.6`.
    pub name: String,
    /// Class.
    pub class: Class,
    /// NDF.
    pub ndf: NdfId,
    /// Roughness x.
    pub alpha_x: f32,
    /// Roughness y.
    pub alpha_y: f32,
    /// Conductor eta per channel, or dielectric eta in `.x`.
    pub eta: Vec3,
    /// Conductor k.
    pub k: Vec3,
}

impl SuiteMaterial {
    /// Index of the material's reporting group in [`GROUPS`].
    pub fn group(&self) -> usize {
        match self.class {
            Class::Conductor => 0,
            Class::Dielectric if self.alpha_x == self.alpha_y => 1,
            Class::Dielectric => 2,
        }
    }

    /// The description of this material with the given model.
    pub fn desc(&self, model: Model, estimator: Estimator) -> MaterialDesc {
        MaterialDesc {
            model,
            estimator,
            ndf: self.ndf,
            facet: match self.class {
                Class::Conductor => FacetKind::Conductor,
                Class::Dielectric => FacetKind::Dielectric,
            },
            alpha_x: self.alpha_x,
            alpha_y: self.alpha_y,
            eta: self.eta,
            k: self.k,
            ..MaterialDesc::default()
        }
    }

    /// The same description for the C API.
    pub fn c_desc(&self, model: Model, estimator: Estimator) -> msbsdf_material_desc {
        c_desc(&self.desc(model, estimator))
    }
}

/// Converts a Rust description to the C one.
pub fn c_desc(d: &MaterialDesc) -> msbsdf_material_desc {
    let rgb = |v: Vec3| msbsdf_rgb {
        r: v.x,
        g: v.y,
        b: v.z,
    };
    msbsdf_material_desc {
        model: model_c(d.model),
        estimator: estimator_c(d.estimator),
        ndf: ndf_c(d.ndf),
        facet: match d.facet {
            FacetKind::Conductor => MSBSDF_FACET_CONDUCTOR,
            FacetKind::Dielectric => MSBSDF_FACET_DIELECTRIC,
            FacetKind::Diffuse => MSBSDF_FACET_DIFFUSE,
            FacetKind::Material => MSBSDF_FACET_MATERIAL,
        },
        alpha_x: d.alpha_x,
        alpha_y: d.alpha_y,
        shape: d.shape,
        eta: rgb(d.eta),
        k: rgb(d.k),
        albedo: rgb(d.albedo),
        max_bounces: d.max_bounces,
        tolerance: d.tolerance,
        ..msbsdf_material_desc_default()
    }
}

/// Every model with its C constant and name (AUTO excluded).
pub const MODELS: [(Model, u32, &str); 10] = [
    (Model::Single, MSBSDF_MODEL_SINGLE, "SINGLE"),
    (Model::Tabulated, MSBSDF_MODEL_TABULATED, "TABULATED"),
    (
        Model::EnergyCompensated,
        MSBSDF_MODEL_ENERGY_COMPENSATED,
        "ENERGY_COMPENSATED",
    ),
    (
        Model::HeitzRandomWalk,
        MSBSDF_MODEL_HEITZ_RANDOM_WALK,
        "HEITZ_RANDOM_WALK",
    ),
    (
        Model::PositionFree,
        MSBSDF_MODEL_POSITION_FREE,
        "POSITION_FREE",
    ),
    (Model::Invariance, MSBSDF_MODEL_INVARIANCE, "INVARIANCE"),
    (
        Model::BitterliDeon,
        MSBSDF_MODEL_BITTERLI_DEON,
        "BITTERLI_DEON",
    ),
    (Model::VGroove, MSBSDF_MODEL_VGROOVE, "VGROOVE"),
    (
        Model::VGrooveNonsymmetric,
        MSBSDF_MODEL_VGROOVE_NONSYMMETRIC,
        "VGROOVE_NONSYMMETRIC",
    ),
    (
        Model::NullScattering,
        MSBSDF_MODEL_NULL_SCATTERING,
        "NULL_SCATTERING",
    ),
];

/// C constant of a model.
pub fn model_c(m: Model) -> u32 {
    if m == Model::Auto {
        return MSBSDF_MODEL_AUTO;
    }
    MODELS.iter().find(|x| x.0 == m).map(|x| x.1).unwrap_or(0)
}

/// Name of a model (`AUTO` for [`Model::Auto`]).
pub fn model_name(m: Model) -> &'static str {
    if m == Model::Auto {
        return "AUTO";
    }
    MODELS.iter().find(|x| x.0 == m).map(|x| x.2).unwrap_or("?")
}

/// Model from its name.
pub fn model_from_name(s: &str) -> Option<Model> {
    MODELS.iter().find(|x| x.2 == s).map(|x| x.0)
}

/// C constant of an estimator.
pub fn estimator_c(e: Estimator) -> u32 {
    match e {
        Estimator::Pt => MSBSDF_ESTIMATOR_PT,
        Estimator::Bdpt => MSBSDF_ESTIMATOR_BDPT,
    }
}

/// Name of an estimator.
pub fn estimator_name(e: Estimator) -> &'static str {
    match e {
        Estimator::Pt => "PT",
        Estimator::Bdpt => "BDPT",
    }
}

/// Estimator from its name.
pub fn estimator_from_name(s: &str) -> Option<Estimator> {
    match s {
        "PT" => Some(Estimator::Pt),
        "BDPT" => Some(Estimator::Bdpt),
        _ => None,
    }
}

/// C constant of an NDF.
pub fn ndf_c(n: NdfId) -> u32 {
    match n {
        NdfId::Beckmann => MSBSDF_NDF_BECKMANN,
        NdfId::Ggx => MSBSDF_NDF_GGX,
        NdfId::StudentT => MSBSDF_NDF_STUDENT_T,
        NdfId::Phong => MSBSDF_NDF_PHONG,
        NdfId::Exponential => MSBSDF_NDF_EXPONENTIAL,
        NdfId::BesselK0 => MSBSDF_NDF_BESSEL_K0,
        NdfId::Vmf => MSBSDF_NDF_VMF,
    }
}

/// Name of an NDF.
pub fn ndf_name(n: NdfId) -> &'static str {
    match n {
        NdfId::Beckmann => "beckmann",
        NdfId::Ggx => "ggx",
        NdfId::StudentT => "student_t",
        NdfId::Phong => "phong",
        NdfId::Exponential => "exponential",
        NdfId::BesselK0 => "bessel_k0",
        NdfId::Vmf => "vmf",
    }
}

/// NDF from its name.
pub fn ndf_from_name(s: &str) -> Option<NdfId> {
    [NdfId::Beckmann, NdfId::Ggx, NdfId::StudentT, NdfId::Phong]
        .into_iter()
        .find(|n| ndf_name(*n) == s)
}

/// Isotropic roughness values of the conductor suite; the anisotropic
/// material is `ANISO`.
pub const CONDUCTOR_ALPHAS: [f32; 5] = [0.05, 0.1, 0.3, 0.6, 1.0];
/// Anisotropic roughness (x, y) of the suite.
pub const ANISO: (f32, f32) = (0.1, 0.6);
/// Roughness values of the GGX glass.
pub const GLASS_ALPHAS: [f32; 3] = [0.1, 0.5, 1.0];
/// Anisotropic glass of milder anisotropy than [`ANISO`] in the suite
/// (after it): `alpha_min / alpha_max` 0.909 and 0.5.
pub const GLASS_ANISO_MILD: [(f32, f32); 2] = [(0.5, 0.55), (0.3, 0.6)];
/// Glass index.
pub const GLASS_ETA: f32 = 1.5;

/// Roughness pairs of the table of AUTO's picks (`examples/auto_picks.rs`,
/// `docs/auto_picks.md`) and of the test of the default tolerance
/// (`tests/auto.rs`): isotropic from 0.02 to the tables' largest, 2, then
/// anisotropic pairs (both orientations of one; the last two mildly
/// anisotropic).
pub const AUTO_PICK_ROUGHNESS: [(f32, f32); 17] = [
    (0.02, 0.02),
    (0.05, 0.05),
    (0.1, 0.1),
    (0.2, 0.2),
    (0.3, 0.3),
    (0.4, 0.4),
    (0.5, 0.5),
    (0.7, 0.7),
    (1.0, 1.0),
    (1.5, 1.5),
    (2.0, 2.0),
    (0.05, 0.3),
    (0.1, 0.6),
    (0.6, 0.1),
    (0.3, 1.0),
    (0.5, 0.55),
    (0.4, 0.6),
];

/// An AUTO description of gold (conductor facets) or glass of index
/// [`GLASS_ETA`] (dielectric facets) at roughness `(ax, ay)` and
/// `tolerance`.
pub fn auto_pick_desc(
    ndf: NdfId,
    facet: FacetKind,
    (ax, ay): (f32, f32),
    tolerance: f32,
) -> MaterialDesc {
    let (eta, k) = match facet {
        FacetKind::Dielectric => (Vec3::splat(GLASS_ETA), Vec3::ZERO),
        _ => (Vec3::from(GOLD.0), Vec3::from(GOLD.1)),
    };
    MaterialDesc {
        model: Model::Auto,
        ndf,
        facet,
        alpha_x: ax,
        alpha_y: ay,
        eta,
        k,
        tolerance,
        ..MaterialDesc::default()
    }
}

fn metal(name: &str, ndf: NdfId, m: ([f32; 3], [f32; 3]), ax: f32, ay: f32) -> SuiteMaterial {
    let rough = if ax == ay {
        format!("{ax}")
    } else {
        format!("{ax}x{ay}")
    };
    SuiteMaterial {
        name: format!("{}_{name}_{rough}", ndf_name(ndf)),
        class: Class::Conductor,
        ndf,
        alpha_x: ax,
        alpha_y: ay,
        eta: Vec3::from(m.0),
        k: Vec3::from(m.1),
    }
}

fn glass(ndf: NdfId, ax: f32, ay: f32) -> SuiteMaterial {
    let rough = if ax == ay {
        format!("{ax}")
    } else {
        format!("{ax}x{ay}")
    };
    SuiteMaterial {
        name: format!("{}_glass_{rough}", ndf_name(ndf)),
        class: Class::Dielectric,
        ndf,
        alpha_x: ax,
        alpha_y: ay,
        eta: Vec3::splat(GLASS_ETA),
        k: Vec3::ZERO,
    }
}

/// The full suite: GGX and Beckmann gold, copper, aluminium at the five
/// isotropic roughnesses and (0.1, 0.6); GGX glass 1.5 at 0.1, 0.5, 1.0
/// and (0.1, 0.6), (0.5, 0.55), (0.3, 0.6) (the anisotropic glass, last:
/// its figures are reported apart from the dielectric class's, see
/// `speed_accuracy`).
pub fn full_suite() -> Vec<SuiteMaterial> {
    let mut v = Vec::new();
    for ndf in [NdfId::Ggx, NdfId::Beckmann] {
        for (name, m) in [("gold", GOLD), ("copper", COPPER), ("aluminium", ALUMINIUM)] {
            for a in CONDUCTOR_ALPHAS {
                v.push(metal(name, ndf, m, a, a));
            }
            v.push(metal(name, ndf, m, ANISO.0, ANISO.1));
        }
    }
    for a in GLASS_ALPHAS {
        v.push(glass(NdfId::Ggx, a, a));
    }
    // Last, so the earlier materials keep their indices (and the
    // reference's seeds and pooled samples).
    v.push(glass(NdfId::Ggx, ANISO.0, ANISO.1));
    // Milder anisotropy (AUTO brackets anisotropic rows by
    // `alpha_min / alpha_max`: 0.909 and 0.5 here, 1/6 above).
    for (ax, ay) in GLASS_ANISO_MILD {
        v.push(glass(NdfId::Ggx, ax, ay));
    }
    v
}

/// A small suite for quick runs: GGX gold 0.3 and 1.0, GGX glass 0.5.
pub fn quick_suite() -> Vec<SuiteMaterial> {
    vec![
        metal("gold", NdfId::Ggx, GOLD, 0.3, 0.3),
        metal("gold", NdfId::Ggx, GOLD, 1.0, 1.0),
        glass(NdfId::Ggx, 0.5, 0.5),
    ]
}

fn sph(theta_deg: f32, phi_deg: f32, up: bool) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    let z = t.cos();
    let v = Vec3::new(
        t.sin() * p.cos(),
        t.sin() * p.sin(),
        if up { z } else { -z },
    );
    v.normalize()
}

/// Incident polar angles (degrees) of the pairs: 8 of them, grazing included.
pub const THETA_I: [f32; 8] = [0.0, 20.0, 40.0, 55.0, 70.0, 80.0, 85.0, 89.0];

/// The 64 direction pairs of a material class: for each of the 8 incident
/// angles (azimuth turning by 37 degrees, so anisotropy is probed off-axis),
/// 8 outgoing directions: the mirror direction, five more in and near the
/// plane of incidence (0 to 89 degrees) and two off-plane; for dielectrics
/// four of the eight are transmitted (the refracted direction, its
/// neighbours and a grazing one). `n < 64` takes every (64 / n)-th pair.
pub fn pairs(class: Class, n: usize) -> Vec<(Vec3, Vec3)> {
    let mut v = Vec::with_capacity(64);
    for (a, &ti) in THETA_I.iter().enumerate() {
        let pi = 37.0 * a as f32;
        let wi = sph(ti, pi, true);
        let back = pi + 180.0;
        match class {
            Class::Conductor => {
                v.push((wi, sph(ti, back, true)));
                v.push((wi, sph((ti + 8.0).min(89.0), back + 4.0, true)));
                v.push((wi, sph(0.0, 0.0, true)));
                v.push((wi, sph(30.0, back, true)));
                v.push((wi, sph(60.0, back - 10.0, true)));
                v.push((wi, sph(85.0, back, true)));
                v.push((wi, sph(45.0, pi + 90.0, true)));
                v.push((wi, sph(89.0, pi + 30.0, true)));
            }
            Class::Dielectric => {
                // Snell: sin t = sin i / eta, continuing away on the far side.
                let tt = ((ti.to_radians().sin() / GLASS_ETA).asin()).to_degrees();
                v.push((wi, sph(ti, back, true)));
                v.push((wi, sph(50.0, pi + 90.0, true)));
                v.push((wi, sph(20.0, back + 10.0, true)));
                v.push((wi, sph(88.0, back, true)));
                v.push((wi, sph(tt, back, false)));
                v.push((wi, sph(tt + 12.0, back + 6.0, false)));
                v.push((wi, sph(60.0, pi, false)));
                v.push((wi, sph(87.0, back, false)));
            }
        }
    }
    let step = (64 / n.clamp(1, 64)).max(1);
    v.into_iter().step_by(step).collect()
}

/// One (model, estimator) the library accepts for some material of the suite.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Combo {
    /// Model.
    pub model: Model,
    /// Estimator.
    pub estimator: Estimator,
    /// True when eval is a Monte Carlo estimate.
    pub stochastic: bool,
}

impl Combo {
    /// `MODEL` or `MODEL/BDPT`-style label.
    pub fn label(&self) -> String {
        if self.estimator == Estimator::Pt {
            model_name(self.model).to_string()
        } else {
            format!(
                "{}/{}",
                model_name(self.model),
                estimator_name(self.estimator)
            )
        }
    }
}

/// Evaluates a few pairs with fixed seeds; used to tell an estimator that
/// changes the result from one the model ignores.
fn probe(m: &Material, class: Class) -> Vec<[u32; 3]> {
    pairs(class, 8)
        .iter()
        .enumerate()
        .map(|(i, &(wi, wo))| {
            let mut rng = Rng::new(7, i as u64);
            let v = m.eval(wi, wo, &mut rng);
            [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]
        })
        .collect()
}

/// Every (model, estimator) that `Material::new` accepts for at least one
/// material of `suite`, in model order. The BDPT estimator is listed only
/// when it changes the bits `eval` returns (models that ignore the
/// estimator appear once, as PT).
pub fn discover(suite: &[SuiteMaterial]) -> Vec<Combo> {
    let mut out = Vec::new();
    for &(model, _, _) in MODELS.iter() {
        for est in [Estimator::Pt, Estimator::Bdpt] {
            let mut accepted = false;
            let mut distinct = est == Estimator::Pt;
            let mut stochastic = false;
            for s in suite {
                let Ok(m) = Material::new(&s.desc(model, est)) else {
                    continue;
                };
                accepted = true;
                stochastic |= m.is_stochastic();
                if est == Estimator::Bdpt {
                    match Material::new(&s.desc(model, Estimator::Pt)) {
                        Ok(pt) => {
                            if probe(&pt, s.class) != probe(&m, s.class) {
                                distinct = true;
                            }
                        }
                        Err(_) => distinct = true,
                    }
                }
            }
            if accepted && distinct {
                out.push(Combo {
                    model,
                    estimator: est,
                    stochastic,
                });
            }
        }
    }
    out
}

/// A material created through the C API (destroyed on drop).
pub struct CMaterial(pub *mut msbsdf_material);

impl CMaterial {
    /// `msbsdf_material_create`; `None` when refused.
    pub fn new(d: &msbsdf_material_desc) -> Option<Self> {
        let mut m: *mut msbsdf_material = std::ptr::null_mut();
        // SAFETY: `d` and `m` are valid locals.
        let s = unsafe { msbsdf_material_create(d, &mut m) };
        (s == MSBSDF_STATUS_OK && !m.is_null()).then_some(CMaterial(m))
    }

    /// `msbsdf_eval` (the C entry point) as RGB doubles.
    #[inline]
    pub fn eval(&self, wi: Vec3, wo: Vec3, rng: &mut msbsdf_rng) -> [f64; 3] {
        let mut out = msbsdf_rgb::default();
        let v = |v: Vec3| msbsdf_vec3 {
            x: v.x,
            y: v.y,
            z: v.z,
        };
        // SAFETY: `self.0` is live; rng and out are valid.
        unsafe { msbsdf_eval(self.0, v(wi), v(wo), rng, &mut out) };
        [out.r as f64, out.g as f64, out.b as f64]
    }
}

impl Drop for CMaterial {
    fn drop(&mut self) {
        // SAFETY: created by msbsdf_material_create, dropped once.
        unsafe { msbsdf_material_destroy(self.0) };
    }
}

// SAFETY: materials are immutable after creation and documented as shareable
// across threads.
unsafe impl Send for CMaterial {}
// SAFETY: as above.
unsafe impl Sync for CMaterial {}

/// A seeded C generator.
pub fn c_rng(seed: u64, stream: u64) -> msbsdf_rng {
    let mut r = msbsdf_rng::default();
    // SAFETY: valid local.
    unsafe { msbsdf_rng_seed(&mut r, seed, stream) };
    r
}
