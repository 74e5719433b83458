//! `MSBSDF_MODEL_SINGLE`: the single-scattering microfacet baseline
//! (Cook-Torrance reflection; Walter et al. 2007 rough dielectric), sampled by
//! visible normals, with an exact pdf.
//!
//! Masking-shadowing is Smith's height-correlated form by default: reflection
//! `G2 = 1 / (1 + Lambda(wi) + Lambda(wo))`, transmission
//! `G2 = B(1 + Lambda(wi), 1 + Lambda(wo))` (Heitz 2014); the uncorrelated
//! product `G1(wi) G1(wo)` is available for comparisons ([`G2Form`]).
//!
//! Conductors are two-sided (a `wi` below the surface is mirrored with `wo`;
//! the material makes them one-sided on request).
//! Dielectrics with `wi` below see the inverse relative index. Transmission is
//! the flux-conserving form: `f(wi, wo) / eta_o^2 = f(wo, wi) / eta_i^2`, no
//! radiance scaling by `1 / eta^2`.
//!
//! Cost class: analytic; isotropic GGX reflection takes a closed form of its
//! own (`iso_ggx_reflection`): `msbsdf_eval` costs 1.6-2x the instructions
//! of the bare formula (`docs/single_cost.md`). Eval and pdf together
//! ([`Single::eval_pdf`]) share the half vector and D. Single scattering
//! loses energy with roughness (GGX alpha 1 keeps 31% at normal incidence):
//! the measured table is `docs/single_albedo.md`, written by
//! `cargo run --release --example single_albedo`.

use crate::bsdf::{LOBE_ALL, LOBE_REFLECTION, LOBE_TRANSMISSION, Sample, ScatterModel};
use crate::desc::MaterialDesc;
use crate::facet::Facet;
use crate::frame::{RefractionHalf, flip_z, reflect, refract, refraction_half};
use crate::fresnel;
use crate::ndf::{Ndf, NdfKind};
use crate::rng::Rng;
use crate::status::Error;
use glam::Vec3;

/// Below this `wi.m` of a sampled reflection, sample checks that eval and
/// pdf recompute a half vector facing `wi` (`half_vector_sees`): the f32
/// rounding of `wo` turns that half vector by about `6e-8 / (2 wi.m)`
/// radians, harmless against any roughness above the specular threshold
/// (1e-3) unless `wi.m` is below about 1e-4; the gate keeps the check off
/// the common path (it costs about 180 instructions).
const GRAZING_HALF_COS: f32 = 1e-2;

/// Which masking-shadowing function couples `wi` and `wo`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum G2Form {
    /// Smith height-correlated (default, what the random walks reduce to).
    HeightCorrelated,
    /// Product of the two masking terms.
    Uncorrelated,
}

/// The single-scattering microfacet BSDF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Single {
    ndf: Ndf,
    facet: Facet,
    g2: G2Form,
    /// A conductor other than the perfect reflector (eta 0, k 1, whose
    /// F = 1 is decided here once): its indices prepared for the Fresnel
    /// closed form.
    lanes: Option<fresnel::ConductorLanes>,
    /// `alpha^2` when the reflection of this material has the isotropic GGX
    /// closed form ([`iso_ggx_reflection`]): GGX, `alpha_x == alpha_y`,
    /// height-correlated `G2`; decided once.
    iso_ggx_a2: Option<f32>,
}

/// Isotropic GGX reflection with the height-correlated `G2` for unit `wi`,
/// `wo` with `wi.z > 0`, `wo.z > 0`: `(D(h), D G2 / (4 wi.z), pdf)` without
/// the Fresnel factor, from the unnormalised half vector `H = wi + wo`.
///
/// With `den = H.x^2 + H.y^2 + alpha^2 H.z^2`,
/// `D(h) = alpha^2 |H|^4 / (pi den^2)` (Walter et al. 2007, eq. 33, with
/// `cos^2 theta_h = H.z^2 / |H|^2`). Writing `q(w) = sqrt(alpha^2 (w.x^2 +
/// w.y^2) + w.z^2)`, GGX's `Lambda(w) = (q / w.z - 1) / 2` (Heitz 2014,
/// eq. 72), so `G2 = 1 / (1 + Lambda(wi) + Lambda(wo)) = 2 wi.z wo.z /
/// (wo.z q(wi) + wi.z q(wo))` and `f |wo.z| = F D wo.z / (2 (wo.z q(wi) +
/// wi.z q(wo)))`; the visible-normal pdf of the reflection is
/// `G1(wi) D / (4 wi.z) = D / (2 (wi.z + q(wi)))`. No normalisation, two
/// square roots, every denominator positive for directions above the
/// surface (`den >= min(alpha^2, 1) |H|^2`, `q >= min(alpha, 1)`).
#[inline(always)]
pub(crate) fn iso_ggx_reflection(a2: f32, wi: Vec3, wo: Vec3) -> (f32, f32, f32) {
    let hv = wi + wo;
    let hxy = hv.x * hv.x + hv.y * hv.y;
    let hh = hxy + hv.z * hv.z;
    let den = hxy + a2 * (hv.z * hv.z);
    let d = a2 * std::f32::consts::FRAC_1_PI * (hh * hh) / (den * den);
    let qi = (a2 * (wi.x * wi.x + wi.y * wi.y) + wi.z * wi.z).sqrt();
    let qo = (a2 * (wo.x * wo.x + wo.y * wo.y) + wo.z * wo.z).sqrt();
    let f = d * wo.z / (2.0 * (wo.z * qi + wi.z * qo));
    let pdf = d / (2.0 * (wi.z + qi));
    (d, f, pdf)
}

/// Relative index and directions in the frame where `wi.z > 0`.
#[inline]
fn orient(wi: Vec3, wo: Vec3, eta: f32) -> (Vec3, Vec3, f32, bool) {
    if wi.z < 0.0 {
        (flip_z(wi), flip_z(wo), 1.0 / eta, true)
    } else {
        (wi, wo, eta, false)
    }
}

/// `wi.h` (= `wo.h` for a reflection) computed symmetrically in `wi` and
/// `wo`, so that a Fresnel factor near total internal reflection, where its
/// slope is infinite, does not amplify f32 rounding into a reciprocity error.
#[inline]
fn sym_cos(wi: Vec3, wo: Vec3, h: Vec3) -> f32 {
    0.5 * (wi.dot(h) + wo.dot(h))
}

impl Single {
    /// A single-scattering BSDF; `facet` must be a conductor or a dielectric.
    pub fn new(ndf: Ndf, facet: Facet, g2: G2Form) -> Self {
        let white = facet
            == Facet::Conductor {
                eta: Vec3::ZERO,
                k: Vec3::ONE,
            };
        let iso_ggx_a2 = (ndf.kind == NdfKind::Ggx
            && ndf.alpha_x == ndf.alpha_y
            && g2 == G2Form::HeightCorrelated)
            .then_some(ndf.alpha_x * ndf.alpha_x);
        let lanes = match facet {
            Facet::Conductor { eta, k } if !white => Some(fresnel::ConductorLanes::new(eta, k)),
            _ => None,
        };
        Single {
            ndf,
            facet,
            g2,
            lanes,
            iso_ggx_a2,
        }
    }

    /// Conductor Fresnel for the cosine `ci` (exactly 1 for the perfect
    /// reflector, without comparing its indices on every call).
    #[inline(always)]
    fn conductor_fresnel(&self, ci: f32) -> Vec3 {
        match (&self.lanes, self.facet) {
            (Some(l), Facet::Conductor { eta, k }) => l.eval(ci, eta, k),
            _ => Vec3::ONE,
        }
    }

    #[inline]
    fn g2_reflection(&self, wi: Vec3, wo: Vec3) -> f32 {
        match self.g2 {
            G2Form::HeightCorrelated => self.ndf.g2_correlated(wi, wo),
            G2Form::Uncorrelated => self.ndf.g2_uncorrelated(wi, wo),
        }
    }

    #[inline]
    fn g2_transmission(&self, wi: Vec3, wo: Vec3) -> f32 {
        match self.g2 {
            G2Form::HeightCorrelated => self.ndf.g2_transmission_correlated(wi, wo),
            G2Form::Uncorrelated => self.ndf.g2_uncorrelated(wi, wo),
        }
    }

    /// True when eval and pdf see the reflection `wi -> wo` (`wi.z > 0`,
    /// `wo` as sampled, before the normalisation every query applies): the
    /// half vector they recompute from `wi + wo` faces `wi`. Within about
    /// 1e-5 of the horizon `wi + wo` nearly cancels and f32 rounding of `wo`
    /// can turn it away; such samples are absorbed, so that the pdf is
    /// positive wherever sample goes (5 of 4e5 glass queries with `wi.z`
    /// below 3e-6 had pdf 0 before). Called only for `wi.m` below
    /// [`GRAZING_HALF_COS`].
    #[inline]
    fn half_vector_sees(&self, wi: Vec3, wo: Vec3) -> bool {
        let h = (wi + wo.normalize()).normalize_or_zero();
        wi.dot(h) > 0.0 && self.ndf.d_visible(wi, h) > 0.0
    }

    /// `ndf.d_visible(wi, h)` from `d = ndf.d(h)` already computed (the
    /// same operations, so the same bits).
    #[inline(always)]
    fn d_visible_from(&self, wi: Vec3, h: Vec3, d: f32) -> f32 {
        let cos = wi.dot(h);
        if cos <= 0.0 {
            return 0.0;
        }
        let s = self.ndf.sigma(wi);
        if s <= 1e-30 { 0.0 } else { cos * d / s }
    }
}

impl Single {
    /// `(f |wo.z|, pdf)` restricted to `lobes` (`LOBE_*`), computing the half
    /// vector, D and the masking once for both. `want_f` / `want_pdf` are
    /// constants at every call site (the unused half is compiled out); eval
    /// and pdf are this function, so each half equals them bit for bit.
    #[inline(always)]
    pub fn eval_pdf(
        &self,
        wi: Vec3,
        wo: Vec3,
        lobes: u32,
        want_f: bool,
        want_pdf: bool,
    ) -> (Vec3, f32) {
        let (f, p, _) = self.eval_pdf_f1(wi, wo, lobes, want_f, want_pdf);
        (f, p)
    }

    /// [`Single::eval_pdf`] and, for a dielectric reflection pair
    /// (`want_f`), its value with F = 1, `D G2 / (4 |wi.z|)`, which it
    /// computes anyway (the peaked part of TABULATED's dielectric lobe); 0
    /// otherwise.
    #[inline(always)]
    pub fn eval_pdf_f1(
        &self,
        wi: Vec3,
        wo: Vec3,
        lobes: u32,
        want_f: bool,
        want_pdf: bool,
    ) -> (Vec3, f32, f32) {
        let both = lobes & LOBE_ALL == LOBE_ALL;
        match self.facet {
            Facet::Dielectric { eta } => {
                let (wi, wo, eta, _) = orient(wi, wo, eta);
                if wo.z > 0.0 {
                    if lobes & LOBE_REFLECTION == 0 {
                        return (Vec3::ZERO, 0.0, 0.0);
                    }
                    let h = (wi + wo).normalize_or_zero();
                    let ci = wi.dot(h);
                    if ci <= 0.0 {
                        return (Vec3::ZERO, 0.0, 0.0);
                    }
                    let fr = fresnel::dielectric(sym_cos(wi, wo, h), eta);
                    let d = self.ndf.d(h);
                    let f1 = if want_f {
                        d * self.g2_reflection(wi, wo) / (4.0 * wi.z)
                    } else {
                        0.0
                    };
                    let f = Vec3::splat(fr * f1);
                    let p = if want_pdf {
                        let p_lobe = if both { fr } else { 1.0 };
                        p_lobe * self.d_visible_from(wi, h, d) / (4.0 * ci)
                    } else {
                        0.0
                    };
                    (f, p, f1)
                } else {
                    if lobes & LOBE_TRANSMISSION == 0 {
                        return (Vec3::ZERO, 0.0, 0.0);
                    }
                    let Some(RefractionHalf {
                        h,
                        ci,
                        co,
                        jacobian: jac,
                    }) = refraction_half(wi, wo, eta)
                    else {
                        return (Vec3::ZERO, 0.0, 0.0);
                    };
                    let fr = fresnel::dielectric_pair(ci, co, eta);
                    let d = self.ndf.d(h);
                    let f = if want_f {
                        Vec3::splat((1.0 - fr) * d * self.g2_transmission(wi, wo) * ci * jac / wi.z)
                    } else {
                        Vec3::ZERO
                    };
                    let p = if want_pdf {
                        let p_lobe = if both { 1.0 - fr } else { 1.0 };
                        p_lobe * self.d_visible_from(wi, h, d) * jac
                    } else {
                        0.0
                    };
                    (f, p, 0.0)
                }
            }
            _ => {
                let (wi, wo) = if wi.z < 0.0 {
                    (flip_z(wi), flip_z(wo))
                } else {
                    (wi, wo)
                };
                if wo.z <= 0.0 || lobes & LOBE_REFLECTION == 0 {
                    return (Vec3::ZERO, 0.0, 0.0);
                }
                if let Some(a2) = self.iso_ggx_a2 {
                    let (_, f, p) = iso_ggx_reflection(a2, wi, wo);
                    let f = if want_f {
                        if self.lanes.is_none() {
                            Vec3::splat(f)
                        } else {
                            // wi.H = 1 + wi.wo > 0 for two directions above.
                            let hv = wi + wo;
                            self.conductor_fresnel(wi.dot(hv) / hv.length()) * f
                        }
                    } else {
                        Vec3::ZERO
                    };
                    return (f, if want_pdf { p } else { 0.0 }, 0.0);
                }
                let h = (wi + wo).normalize_or_zero();
                let ci = wi.dot(h);
                if ci <= 0.0 {
                    return (Vec3::ZERO, 0.0, 0.0);
                }
                let d = self.ndf.d(h);
                let f = if want_f {
                    self.conductor_fresnel(ci) * (d * self.g2_reflection(wi, wo) / (4.0 * wi.z))
                } else {
                    Vec3::ZERO
                };
                let p = if want_pdf {
                    self.d_visible_from(wi, h, d) / (4.0 * ci)
                } else {
                    0.0
                };
                (f, p, 0.0)
            }
        }
    }

    /// Samples `wo` restricted to `lobes`: `u[0]` picks reflection or
    /// refraction at the sampled facet (dielectrics, both lobes allowed),
    /// `u[1], u[2]` the visible normal. With one lobe only, that lobe is
    /// taken with probability 1 and the weight carries its Fresnel factor.
    #[inline]
    pub fn sample_lobes(&self, wi: Vec3, u: [f32; 3], lobes: u32) -> Sample {
        let (u1, u2) = (u[1], u[2]);
        let both = lobes & LOBE_ALL == LOBE_ALL;
        match self.facet {
            Facet::Dielectric { eta } => {
                let Some(d) = self.dielectric_direction(wi, u, lobes, eta) else {
                    return Sample::ABSORBED;
                };
                let (wi_l, wo, f, ci) = (d.wi_l, d.wo, d.f, d.ci);
                let g1 = self.ndf.g1(wi_l);
                let dvis = self.ndf.d_visible(wi_l, d.m);
                let (wo, weight, pdf) = if d.reflected {
                    let g = self.g2_reflection(wi_l, wo) / g1;
                    if both {
                        (wo, g, f * dvis / (4.0 * ci))
                    } else {
                        (wo, f * g, dvis / (4.0 * ci))
                    }
                } else {
                    let jac = match refraction_half(wi_l, wo, d.eta_l) {
                        Some(r) => r.jacobian,
                        None => 0.0, // index-matched: a Dirac lobe, no density
                    };
                    let g = self.g2_transmission(wi_l, wo) / g1;
                    if both {
                        (wo, g, (1.0 - f) * dvis * jac)
                    } else {
                        (wo, (1.0 - f) * g, dvis * jac)
                    }
                };
                let wo = if d.flipped { flip_z(wo) } else { wo };
                Sample::new(wi, wo, Vec3::splat(weight), pdf)
            }
            _ => {
                let Some((wi_l, m, ci, wo, flipped)) = self.conductor_direction(wi, u1, u2, lobes)
                else {
                    return Sample::ABSORBED;
                };
                let weight =
                    self.conductor_fresnel(ci) * self.g2_reflection(wi_l, wo) / self.ndf.g1(wi_l);
                let pdf = self.ndf.d_visible(wi_l, m) / (4.0 * ci);
                let wo = if flipped { flip_z(wo) } else { wo };
                Sample::new(wi, wo, weight, pdf)
            }
        }
    }
}

/// A direction sampled from the dielectric lobes ([`Single::dielectric_direction`]),
/// in the frame where `wi_l.z > 0`, with what its weight and pdf need.
struct DielectricDirection {
    wi_l: Vec3,
    /// The sampled visible normal and `wi_l . m`.
    m: Vec3,
    ci: f32,
    /// Fresnel reflectance at `ci`.
    f: f32,
    /// Relative index seen from `wi_l`'s side.
    eta_l: f32,
    reflected: bool,
    /// The sampled direction (local frame).
    wo: Vec3,
    /// The frame was flipped (`wi.z < 0`).
    flipped: bool,
}

impl Single {
    /// The direction part of [`Single::sample_lobes`] for dielectric facets
    /// of relative index `eta`: a visible normal from `u[1], u[2]`,
    /// reflection or refraction chosen by `u[0]` against the Fresnel
    /// reflectance (when both lobes are asked for), and the same refusals
    /// (`None`: absorbed).
    #[inline(always)]
    fn dielectric_direction(
        &self,
        wi: Vec3,
        u: [f32; 3],
        lobes: u32,
        eta: f32,
    ) -> Option<DielectricDirection> {
        if lobes & LOBE_ALL == 0 {
            return None;
        }
        let (wi_l, _, eta_l, flipped) = orient(wi, Vec3::Z, eta);
        let m = self.ndf.sample_visible(wi_l, u[1], u[2]);
        let ci = wi_l.dot(m);
        if ci <= 0.0 {
            return None;
        }
        let f = fresnel::dielectric(ci, eta_l);
        let reflected = if lobes & LOBE_ALL == LOBE_ALL {
            u[0] < f
        } else {
            lobes & LOBE_REFLECTION != 0
        };
        let wo = if reflected {
            self.reflected_direction(wi_l, m, ci)?
        } else {
            let wo = refract(wi_l, m, eta_l)?;
            if wo.z >= 0.0 {
                return None;
            }
            wo
        };
        Some(DielectricDirection {
            wi_l,
            m,
            ci,
            f,
            eta_l,
            reflected,
            wo,
            flipped,
        })
    }

    /// The direction part of [`Single::sample_lobes`] for reflecting
    /// facets: `(wi_l, m, wi_l . m, wo_l, flipped)` in the frame where
    /// `wi_l.z > 0` (`None`: absorbed).
    #[inline(always)]
    fn conductor_direction(
        &self,
        wi: Vec3,
        u1: f32,
        u2: f32,
        lobes: u32,
    ) -> Option<(Vec3, Vec3, f32, Vec3, bool)> {
        if lobes & LOBE_REFLECTION == 0 {
            return None;
        }
        let flipped = wi.z < 0.0;
        let wi_l = if flipped { flip_z(wi) } else { wi };
        let m = self.ndf.sample_visible(wi_l, u1, u2);
        let ci = wi_l.dot(m);
        if ci <= 0.0 {
            return None;
        }
        let wo = self.reflected_direction(wi_l, m, ci)?;
        Some((wi_l, m, ci, wo, flipped))
    }

    /// `wi_l` (`wi_l.z > 0`) reflected at the sampled visible normal `m`
    /// (`ci = wi_l . m > 0`), both facets' rule: `None` below the surface,
    /// or at a grazing half vector the pair's own half vector does not
    /// see.
    #[inline(always)]
    fn reflected_direction(&self, wi_l: Vec3, m: Vec3, ci: f32) -> Option<Vec3> {
        let wo = reflect(wi_l, m);
        if wo.z <= 0.0 || (ci < GRAZING_HALF_COS && !self.half_vector_sees(wi_l, wo)) {
            return None;
        }
        Some(wo)
    }

    /// The direction [`Single::sample_lobes`] gives from the same uniforms,
    /// without its weight and pdf (`None`: absorbed). For samplers that
    /// evaluate the pair anyway (TABULATED's glass mixture,
    /// ENERGY_COMPENSATED's conductor mixture): the weight's Fresnel
    /// factor, `D_visible` and `G2` (with its Beta function in
    /// transmission) are not computed twice. Where `sample_lobes` would
    /// give a pdf of 0 (a refraction without a half vector), this gives
    /// the direction; the caller's evaluation of the pair's pdf tells.
    pub fn sample_direction(&self, wi: Vec3, u: [f32; 3], lobes: u32) -> Option<Vec3> {
        match self.facet {
            Facet::Dielectric { eta } => {
                let d = self.dielectric_direction(wi, u, lobes, eta)?;
                Some(if d.flipped { flip_z(d.wo) } else { d.wo })
            }
            _ => {
                let (_, _, _, wo, flipped) = self.conductor_direction(wi, u[1], u[2], lobes)?;
                Some(if flipped { flip_z(wo) } else { wo })
            }
        }
    }
}

impl ScatterModel for Single {
    fn eval(&self, wi: Vec3, wo: Vec3, _rng: &mut Rng) -> Vec3 {
        self.eval_pdf(wi, wo, LOBE_ALL, true, false).0
    }

    fn sample(&self, wi: Vec3, rng: &mut Rng) -> Sample {
        let (u1, u2) = (rng.next_f32(), rng.next_f32());
        let u0 = match self.facet {
            Facet::Dielectric { .. } => rng.next_f32(),
            _ => 0.0,
        };
        self.sample_lobes(wi, [u0, u1, u2], LOBE_ALL)
    }

    fn sample_with(&self, wi: Vec3, u: [f32; 3], _rng: &mut Rng) -> Sample {
        self.sample_lobes(wi, u, LOBE_ALL)
    }

    fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.eval_pdf(wi, wo, LOBE_ALL, false, true).1
    }
}

impl Single {
    /// SINGLE for a validated description: Smith NDFs (Beckmann, GGX,
    /// Student-T), conductor or dielectric facets, the height-correlated
    /// `G2`; `Error::Unsupported` otherwise.
    pub(crate) fn from_desc(d: &MaterialDesc, facet: Facet) -> Result<Self, Error> {
        if matches!(facet, Facet::Diffuse { .. }) {
            return Err(Error::Unsupported);
        }
        Ok(Single::new(d.smith_ndf()?, facet, G2Form::HeightCorrelated))
    }
}
