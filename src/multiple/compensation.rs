//! `MSBSDF_MODEL_ENERGY_COMPENSATED`: the cheapest energy-conserving tier.
//!
//! - Conductors: Kulla and Conty 2017. The single-scattering lobe plus a
//!   multiple-scattering lobe
//!   `f_ms(wi, wo) = (1 - E(mu_i)) (1 - E(mu_o)) / (pi (1 - E_avg))`
//!   tinted by `F_ms = F_avg^2 E_avg / (1 - F_avg (1 - E_avg))`, where `E(mu)` is
//!   the single-scattering directional albedo with F = 1, `E_avg = 2 int E mu dmu`
//!   its cosine-weighted average and `F_avg = 2 int F mu dmu` the average Fresnel
//!   reflectance per channel. With F = 1 the albedo is exactly 1; the lobe is
//!   reciprocal.
//! - Dielectrics: Turquin 2019-style scaling. The single-scattering lobe
//!   (reflection and transmission) divided by its own reflected + transmitted
//!   albedo `E(mu_i, alpha, eta)` for the side `wi` is on, so a non-absorbing
//!   interface conserves energy exactly. This scaling is not reciprocal.
//!
//! `E` comes from tables (`compensation_tables.rs`) that the committed tool
//! `cargo run --release --example gen_compensation` computes from the SINGLE
//! model by deterministic quadrature ([`single_albedo`]); they are Rust
//! constants, so there is no file I/O and no allocation. Anisotropic
//! roughness reads the isotropic tables at the RMS alpha
//! `sqrt((alpha_x^2 + alpha_y^2) / 2)`: an approximation whose furnace error
//! `tests/compensation.rs` measures (up to about 10% at grazing angles for
//! strongly anisotropic roughness such as (0.05, 1); 3% at normal
//! incidence). Use a stochastic model where that matters. The tables cover
//! alpha in [0, 2] and relative indices in [1/3, 3]; `Material::new`
//! refuses values outside.

use super::compensation_tables as t;
use crate::bsdf::{Sample, ScatterModel, same_side};
use crate::facet::Facet;
use crate::frame::{flip_z, reflect, refract};
use crate::fresnel;
use crate::ndf::{Ndf, NdfKind};
use crate::rng::Rng;
use crate::single::{G2Form, Single};
use glam::Vec3;
use std::f32::consts::PI;

/// Largest roughness the tables cover.
pub const MAX_ALPHA: f32 = 2.0;
/// Largest relative index (and smallest, inverted) the tables cover.
pub const MAX_ETA: f32 = 3.0;

/// Table abscissa of `mu` (cosine of the incident angle).
#[inline]
fn mu_coord(mu: f32) -> f32 {
    (mu - t::MU_MIN) / (1.0 - t::MU_MIN) * (t::MU_N - 1) as f32
}

/// Table abscissa of alpha (the grid is uniform in sqrt(alpha / MAX_ALPHA)).
#[inline]
fn alpha_coord(alpha: f32) -> f32 {
    (alpha / MAX_ALPHA).clamp(0.0, 1.0).sqrt() * (t::ALPHA_N - 1) as f32
}

/// Table abscissa of a relative index >= 1 (uniform in sqrt((eta - 1) / 2):
/// the albedo changes fastest near eta = 1).
#[inline]
fn eta_coord(eta: f32) -> f32 {
    ((eta - 1.0) / (MAX_ETA - 1.0)).clamp(0.0, 1.0).sqrt() * (t::ETA_N - 1) as f32
}

/// The grid value of each abscissa (used by the generator).
pub fn grid_mu(i: usize) -> f32 {
    t::MU_MIN + (1.0 - t::MU_MIN) * i as f32 / (t::MU_N - 1) as f32
}

/// Roughness of alpha-grid point `j`.
pub fn grid_alpha(j: usize) -> f32 {
    let s = j as f32 / (t::ALPHA_N - 1) as f32;
    MAX_ALPHA * s * s
}

/// Relative index of eta-grid point `k`.
pub fn grid_eta(k: usize) -> f32 {
    let s = k as f32 / (t::ETA_N - 1) as f32;
    1.0 + (MAX_ETA - 1.0) * s * s
}

#[inline]
fn split(x: f32, n: usize) -> (usize, usize, f32) {
    let x = x.clamp(0.0, (n - 1) as f32);
    let i0 = (x as usize).min(n - 2);
    (i0, i0 + 1, x - i0 as f32)
}

#[inline]
fn lerp(a: f32, b: f32, f: f32) -> f32 {
    a + (b - a) * f
}

/// Single-scattering albedo of a conductor with F = 1, bilinear in the tables.
fn conductor_e(ndf: usize, alpha_c: f32, mu: f32) -> f32 {
    let (a0, a1, fa) = split(alpha_c, t::ALPHA_N);
    let (m0, m1, fm) = split(mu_coord(mu), t::MU_N);
    let e = &t::CONDUCTOR_E[ndf];
    lerp(
        lerp(e[a0][m0], e[a0][m1], fm),
        lerp(e[a1][m0], e[a1][m1], fm),
        fa,
    )
}

/// Cosine-weighted average of [`conductor_e`].
fn conductor_e_avg(ndf: usize, alpha_c: f32) -> f32 {
    let (a0, a1, fa) = split(alpha_c, t::ALPHA_N);
    lerp(t::CONDUCTOR_E_AVG[ndf][a0], t::CONDUCTOR_E_AVG[ndf][a1], fa)
}

/// Reflected + transmitted single-scattering albedo of a dielectric for the
/// relative index `eta` seen from `wi`'s side, trilinear in the tables.
fn dielectric_e(ndf: usize, alpha_c: f32, eta: f32, mu: f32) -> f32 {
    let (side, eta) = if eta >= 1.0 { (0, eta) } else { (1, 1.0 / eta) };
    let e = &t::DIELECTRIC_E[ndf][side];
    let (k0, k1, fk) = split(eta_coord(eta), t::ETA_N);
    let (a0, a1, fa) = split(alpha_c, t::ALPHA_N);
    let (m0, m1, fm) = split(mu_coord(mu), t::MU_N);
    let at = |k: usize, a: usize| lerp(e[k][a][m0], e[k][a][m1], fm);
    lerp(
        lerp(at(k0, a0), at(k0, a1), fa),
        lerp(at(k1, a0), at(k1, a1), fa),
        fk,
    )
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    /// Kulla-Conty: `e_avg`, the tint `F_ms` per channel and the table column.
    Conductor { e_avg: f32, tint: Vec3 },
    /// Turquin-style scaling with the relative index.
    Dielectric { eta: f32 },
}

/// The energy-compensated microfacet BSDF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Compensated {
    single: Single,
    ndf_index: usize,
    /// Table coordinate of the RMS roughness.
    alpha_rms_coord: f32,
    kind: Kind,
}

/// Hemispherical average `2 int_0^1 F(mu) mu dmu` of a conductor's Fresnel
/// reflectance per channel (64-point midpoint rule in mu^2, at init only).
fn fresnel_average(eta: Vec3, k: Vec3) -> Vec3 {
    let n = 64;
    let mut acc = Vec3::ZERO;
    for i in 0..n {
        // With s = mu^2, 2 mu dmu = ds.
        let s = (i as f32 + 0.5) / n as f32;
        acc += fresnel::conductor(s.sqrt(), eta, k);
    }
    acc / n as f32
}

impl Compensated {
    /// Builds the model; `ndf` must be Beckmann or GGX with roughness up to
    /// [`MAX_ALPHA`], a conductor or dielectric facet (the latter with a
    /// relative index in [1/3, 3]). The caller validates those ranges.
    pub fn new(ndf: Ndf, facet: Facet) -> Self {
        let ndf_index = match ndf.kind {
            NdfKind::Beckmann => 0,
            _ => 1,
        };
        let (ax2, ay2) = (ndf.alpha_x * ndf.alpha_x, ndf.alpha_y * ndf.alpha_y);
        let alpha_c = alpha_coord((0.5 * (ax2 + ay2)).sqrt());
        let kind = match facet {
            Facet::Dielectric { eta } => Kind::Dielectric { eta },
            Facet::Conductor { eta, k } => {
                let e_avg = conductor_e_avg(ndf_index, alpha_c);
                let f_avg = fresnel_average(eta, k);
                // Kulla and Conty 2017: F_avg^2 E_avg / (1 - F_avg (1 - E_avg)).
                let tint = f_avg * f_avg * e_avg / (Vec3::ONE - f_avg * (1.0 - e_avg));
                Kind::Conductor { e_avg, tint }
            }
            Facet::Diffuse { .. } => Kind::Conductor {
                e_avg: 1.0,
                tint: Vec3::ZERO,
            },
        };
        Compensated {
            single: Single::new(ndf, facet, G2Form::HeightCorrelated),
            ndf_index,
            alpha_rms_coord: alpha_c,
            kind,
        }
    }

    /// Table coordinate of the isotropic roughness standing for an
    /// anisotropic one: the RMS alpha. (A blend towards the projected
    /// roughness of `w`'s azimuth at grazing angles was tried and measured
    /// worse: 36% furnace error for GGX (0.05, 1) at 80 degrees against 10%.)
    #[inline]
    fn alpha_coord_dir(&self, _w: Vec3) -> f32 {
        self.alpha_rms_coord
    }

    /// Single-scattering albedo with F = 1 seen from `w`.
    #[inline]
    fn e_dir(&self, w: Vec3) -> f32 {
        conductor_e(self.ndf_index, self.alpha_coord_dir(w), w.z.abs())
    }

    /// Multiple-scattering lobe times |cos theta_o| for two directions on the
    /// same side.
    #[inline]
    fn ms_lobe(&self, wi: Vec3, wo: Vec3, e_avg: f32, tint: Vec3) -> Vec3 {
        if e_avg >= 1.0 {
            return Vec3::ZERO;
        }
        let (ei, eo) = (self.e_dir(wi), self.e_dir(wo));
        tint * ((1.0 - ei).max(0.0) * (1.0 - eo).max(0.0) / (PI * (1.0 - e_avg)) * wo.z.abs())
    }

    /// Probability of sampling the single-scattering lobe from `wi`.
    #[inline]
    fn p_single(&self, wi: Vec3, e_avg: f32, tint: Vec3) -> f32 {
        let e = self.e_dir(wi);
        let ms =
            tint.element_sum() / 3.0 * (1.0 - e).max(0.0) * if e_avg < 1.0 { 1.0 } else { 0.0 };
        let ss = e.max(1e-4);
        ss / (ss + ms)
    }

    #[inline]
    fn dielectric_scale(&self, wi: Vec3, eta: f32) -> f32 {
        let ratio = if wi.z > 0.0 { eta } else { 1.0 / eta };
        let e = dielectric_e(self.ndf_index, self.alpha_coord_dir(wi), ratio, wi.z.abs());
        1.0 / e.max(1e-3)
    }
}

impl ScatterModel for Compensated {
    fn eval(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        let ss = self.single.eval(wi, wo, rng);
        match self.kind {
            Kind::Dielectric { eta } => ss * self.dielectric_scale(wi, eta),
            Kind::Conductor { e_avg, tint } => {
                if !same_side(wi, wo) {
                    return ss;
                }
                ss + self.ms_lobe(wi, wo, e_avg, tint)
            }
        }
    }

    fn sample(&self, wi: Vec3, rng: &mut Rng) -> Sample {
        match self.kind {
            Kind::Dielectric { eta } => {
                let mut s = self.single.sample(wi, rng);
                s.weight *= self.dielectric_scale(wi, eta);
                s
            }
            Kind::Conductor { e_avg, tint } => {
                let flipped = wi.z < 0.0;
                let wi_l = if flipped { flip_z(wi) } else { wi };
                let p_ss = self.p_single(wi_l, e_avg, tint);
                let wo = if rng.next_f32() < p_ss {
                    let s = self.single.sample(wi_l, rng);
                    if s.flags == crate::bsdf::SAMPLE_ABSORBED {
                        return Sample::ABSORBED;
                    }
                    s.wo
                } else {
                    // Cosine-weighted hemisphere (Malley).
                    let (u1, u2) = (rng.next_f32(), rng.next_f32());
                    let r = u1.sqrt();
                    let phi = 2.0 * PI * u2;
                    Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u1).max(0.0).sqrt())
                };
                if wo.z <= 0.0 {
                    return Sample::ABSORBED;
                }
                let pdf = self.pdf(wi_l, wo);
                if pdf <= 0.0 {
                    return Sample::ABSORBED;
                }
                let f = self.eval(wi_l, wo, rng);
                let wo = if flipped { flip_z(wo) } else { wo };
                Sample::new(wi, wo, f / pdf, pdf)
            }
        }
    }

    fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        match self.kind {
            Kind::Dielectric { .. } => self.single.pdf(wi, wo),
            Kind::Conductor { e_avg, tint } => {
                if !same_side(wi, wo) {
                    return 0.0;
                }
                let p_ss = self.p_single(wi, e_avg, tint);
                p_ss * self.single.pdf(wi, wo) + (1.0 - p_ss) * wo.z.abs() / PI
            }
        }
    }
}

/// Directional albedo of a lobe concentrated around the microfacet normals
/// (a single-scattering lobe) by deterministic quadrature over normals:
/// `eval(wi, wo)` is `f |wo.z|` of one channel; reflection (and, with
/// `transmission_eta = Some(eta)`, refraction with that relative index) for
/// `wi.z > 0`. Normals are mapped from an `n x n` midpoint grid on the unit
/// square by the GGX distribution of normals with the same roughness, with
/// points crowded towards large slopes, which keeps the integrand smooth for
/// any roughness. Used by the table generator and the tests; not for the
/// hot path.
pub fn single_albedo(
    mut eval: impl FnMut(Vec3, Vec3) -> f32,
    alpha_x: f32,
    alpha_y: f32,
    wi: Vec3,
    transmission_eta: Option<f32>,
    n: usize,
) -> f64 {
    let (ax, ay) = (alpha_x as f64, alpha_y as f64);
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            // u = 1 - (1 - s)^4 crowds points towards large slopes.
            let s = (i as f64 + 0.5) / n as f64;
            let u = 1.0 - (1.0 - s).powi(4);
            let du_ds = 4.0 * (1.0 - s).powi(3);
            let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / n as f64;
            let tan = (u / (1.0 - u)).sqrt();
            let h = glam::DVec3::new(-ax * tan * phi.cos(), -ay * tan * phi.sin(), 1.0).normalize();
            let tt = (h.x / ax).powi(2) + (h.y / ay).powi(2) + h.z * h.z;
            let density = h.z / (std::f64::consts::PI * ax * ay * tt * tt) / du_ds;
            let hf = h.as_vec3();
            let ci = wi.dot(hf);
            if ci <= 0.0 {
                continue;
            }
            let wo = reflect(wi, hf);
            if wo.z > 0.0 {
                sum += eval(wi, wo) as f64 * 4.0 * ci as f64 / density;
            }
            if let Some(eta) = transmission_eta
                && let Some(wt) = refract(wi, hf, eta)
                && wt.z < 0.0
            {
                let co = wt.dot(hf) as f64;
                let denom = ci as f64 + eta as f64 * co;
                let jac = denom * denom / ((eta * eta) as f64 * co.abs());
                sum += eval(wi, wt) as f64 * jac / density;
            }
        }
    }
    sum / (n * n) as f64
}
