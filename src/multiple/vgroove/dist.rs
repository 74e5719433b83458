//! The facet distributions of the V-groove models: `D(s)` for Beckmann, GGX
//! and Phong, how the first facet is sampled, the partner-angle density
//! `P(theta_r)` of nonsymmetric grooves (Lee et al. 2018, eq. 20 and Appendix C)
//! with its tabulated inverse CDF, and the bounce-count percentiles of
//! Lee et al. 2018 Table 2.
//!
//! Beckmann and GGX are the crate's [`Ndf`]: `D`, the cross-section and
//! the visible normals of the first facet come from it. What stays here is
//! the V-groove's own: the partner density `P(theta_r)` of eq. 20 and its
//! inverse CDFs (the distribution of the groove angle in a groove plane: a
//! marginal of the slope distribution in `tan theta / alpha_phi`, not `D`),
//! the bounce-count quantiles, and Phong, which lives here privately (the
//! crate's `Ndf` has no Lambda for it, and the V-groove models need none). Roughness maps to the Phong exponent as
//! Walter et al. 2007 do, `e = 2 / alpha^2 - 2`, so `alpha` in `(0, 1]`
//! (`e >= 0`); anisotropy is Ashikhmin-Shirley's
//! `D(s) = sqrt((e_x + 2)(e_y + 2)) / (2 pi) cos^(e_x cos^2 phi + e_y sin^2 phi) theta`,
//! whose normalisation is exact because
//! `integral_0^{2 pi} dphi / (A cos^2 phi + B sin^2 phi) = 2 pi / sqrt(A B)`.
//! The paper does not print its mapping; this one reproduces all nine Phong
//! entries of Table 2 exactly (see [`max_bounces_at_percentile`]), and it
//! makes Phong alpha 1 (e = 0, `D = 1 / pi`) identical to GGX alpha 1.

// `!(x > 0.0)` is used on purpose: it is also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::multiple::bintable::{Q16, decode_q16};
use crate::ndf::{Ndf, NdfKind};
use glam::{DVec3, Vec3};
use std::f64::consts::{FRAC_PI_2, PI};

const FRAC_1_SQRT_PI: f64 = 0.564_189_583_547_756_3;

/// The distribution family.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// Beckmann.
    Beckmann,
    /// GGX / Trowbridge-Reitz.
    Ggx,
    /// Phong (exponent `2 / alpha^2 - 2`).
    Phong,
}

/// A facet distribution with its roughness.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GrooveNdf {
    family: Family,
    /// The crate's NDF (Beckmann, GGX); `None` for Phong.
    smith: Option<Ndf>,
    ax: f64,
    ay: f64,
    /// Phong exponents along x and y.
    ex: f64,
    ey: f64,
    /// Phong normalisation `sqrt((ex + 2)(ey + 2)) / (2 pi)`.
    phong_norm: f64,
}

/// Phong exponent for a roughness (Walter et al. 2007, `e = 2 / alpha^2 - 2`).
#[inline]
pub fn phong_exponent(alpha: f64) -> f64 {
    (2.0 / (alpha * alpha) - 2.0).max(0.0)
}

impl GrooveNdf {
    /// A distribution (roughness validated by the caller; Phong needs
    /// `alpha <= 1`).
    pub fn new(family: Family, ax: f32, ay: f32) -> Self {
        let smith = match family {
            Family::Beckmann => Some(Ndf::new(NdfKind::Beckmann, ax, ay)),
            Family::Ggx => Some(Ndf::new(NdfKind::Ggx, ax, ay)),
            Family::Phong => None,
        };
        let (ax, ay) = (ax as f64, ay as f64);
        let (ex, ey) = (phong_exponent(ax), phong_exponent(ay));
        GrooveNdf {
            family,
            smith,
            ax,
            ay,
            ex,
            ey,
            phong_norm: ((ex + 2.0) * (ey + 2.0)).sqrt() / (2.0 * PI),
        }
    }

    /// The family.
    pub fn family(&self) -> Family {
        self.family
    }

    /// The crate's NDF (Beckmann, GGX); `None` for Phong.
    pub fn smith(&self) -> Option<&Ndf> {
        self.smith.as_ref()
    }

    /// `D(s)` per steradian, `integral D(s) s.z ds = 1`; 0 for `s.z <= 0`.
    /// Beckmann and GGX: the crate's [`Ndf::d`] (single precision).
    #[inline]
    pub fn d(&self, s: DVec3) -> f64 {
        if s.z <= 0.0 {
            return 0.0;
        }
        if let Some(n) = &self.smith {
            return n.d(s.as_vec3()) as f64;
        }
        // Phong (Ashikhmin-Shirley).
        let r2 = s.x * s.x + s.y * s.y;
        let e = if r2 > 0.0 {
            (self.ex * s.x * s.x + self.ey * s.y * s.y) / r2
        } else {
            self.ex
        };
        self.phong_norm * s.z.powf(e)
    }

    /// Normaliser of the visible-normal density from `i` (`i.z > 0`):
    /// `sigma(i) = integral max(0, i.s) D(s) ds` for Beckmann and GGX, whose
    /// first facet is sampled from the visible normals; `None` for Phong,
    /// which samples `D(s) s.z` (Lee et al. 2018, sec. 6).
    #[inline]
    pub fn sigma(&self, i: Vec3) -> Option<f64> {
        self.smith.map(|n| n.sigma(i) as f64)
    }

    /// Density (per steradian) with which [`GrooveNdf::sample_first`] picks
    /// the first facet `s` for light from `i`; `sigma` from
    /// [`GrooveNdf::sigma`].
    #[inline]
    pub fn first_pdf(&self, i: DVec3, s: DVec3, sigma: Option<f64>) -> f64 {
        first_pdf_from(i.dot(s), s.z, self.d(s), sigma)
    }

    /// Samples the facet hit first: visible normals (Heitz and d'Eon 2014)
    /// for Beckmann and GGX, `D(s) s.z` for Phong (Lee et al. 2018, sec. 6). The
    /// caller rejects facets facing away from `i`.
    #[inline]
    pub fn sample_first(&self, i: Vec3, u1: f32, u2: f32) -> DVec3 {
        if let Some(n) = &self.smith {
            return n.sample_visible(i, u1, u2).as_dvec3().normalize();
        }
        // Ashikhmin-Shirley: phi with density ∝ 1 / (e(phi) + 2), then
        // cos theta = u^(1 / (e + 2)).
        let (a, b) = (self.ex + 2.0, self.ey + 2.0);
        let u = u1 as f64 * 4.0;
        let q = (u as u32).min(3);
        let frac = u - q as f64;
        let base = ((a / b).sqrt() * (FRAC_PI_2 * frac).tan()).atan();
        let phi = match q {
            0 => base,
            1 => PI - base,
            2 => PI + base,
            _ => 2.0 * PI - base,
        };
        let (sp, cp) = phi.sin_cos();
        let e = self.ex * cp * cp + self.ey * sp * sp;
        let cos_t = (1.0 - u2 as f64).powf(1.0 / (e + 2.0)).clamp(0.0, 1.0);
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        DVec3::new(sin_t * cp, sin_t * sp, cos_t)
    }

    /// Shape of the groove-angle distribution in the groove plane whose
    /// horizontal unit direction is `(cx, cy)`: the projected roughness for
    /// Beckmann/GGX (`D` depends on `theta` through `tan theta / alpha_phi`),
    /// the exponent `e(phi)` for Phong.
    #[inline]
    pub fn plane_shape(&self, cx: f64, cy: f64) -> f64 {
        match self.family {
            Family::Phong => self.ex * cx * cx + self.ey * cy * cy,
            _ => 1.0 / ((cx / self.ax).powi(2) + (cy / self.ay).powi(2)).sqrt(),
        }
    }

    /// `P(theta_r | phi)` per radian (Lee et al. 2018, eq. 20, with the azimuth
    /// dependence the paper allows after eq. 20):
    /// `D(theta_r, phi) sin^2 theta_r / integral_0^{pi/2} D sin^2`, for
    /// `theta_r` in `[0, pi/2)`; `shape` from [`GrooveNdf::plane_shape`].
    ///
    /// The closed forms (our normalisation; Appendix C prints the
    /// normalising integrals with other constants):
    /// Beckmann and GGX in `t = tan theta / alpha_phi` are roughness-free,
    /// `(4 / sqrt(pi)) t^2 exp(-t^2)` and `(4 / pi) t^2 / (1 + t^2)^2` per
    /// unit `t`; Phong is `cos^e sin^2 / Z(e)`,
    /// `Z(e) = sqrt(pi) Gamma((e + 1) / 2) / (4 Gamma((e + 4) / 2))`.
    #[inline]
    pub fn partner_pdf(&self, theta: f64, shape: f64) -> f64 {
        self.partner_pdf_normed(theta, shape, self.partner_norm(shape))
    }

    /// The normalising factor [`GrooveNdf::partner_pdf_normed`] needs (one
    /// per groove plane): `1 / Z(e)` for Phong, unused otherwise.
    #[inline]
    pub fn partner_norm(&self, shape: f64) -> f64 {
        match self.family {
            Family::Phong => 1.0 / phong_z(shape),
            _ => 1.0,
        }
    }

    /// [`GrooveNdf::partner_pdf`] with the factor of
    /// [`GrooveNdf::partner_norm`] precomputed.
    #[inline]
    pub fn partner_pdf_normed(&self, theta: f64, shape: f64, norm: f64) -> f64 {
        let (s, c) = theta.sin_cos();
        self.partner_pdf_trig(theta, s, c, shape, norm)
    }

    /// [`GrooveNdf::partner_pdf_normed`] given `sin theta` and `cos theta`.
    #[inline]
    pub fn partner_pdf_trig(&self, theta: f64, s: f64, c: f64, shape: f64, norm: f64) -> f64 {
        if !(0.0..FRAC_PI_2).contains(&theta) || !(c > 0.0) {
            return 0.0;
        }
        match self.family {
            Family::Beckmann | Family::Ggx => {
                let t = s / c / shape;
                let pt = if self.family == Family::Beckmann {
                    4.0 * FRAC_1_SQRT_PI * t * t * (-t * t).exp()
                } else {
                    let q = 1.0 + t * t;
                    4.0 / PI * t * t / (q * q)
                };
                pt / (shape * c * c)
            }
            Family::Phong => c.powf(shape) * s * s * norm,
        }
    }

    /// Samples `theta_r` from `P(theta_r | phi)` by the tabulated inverse CDF.
    #[inline]
    pub fn sample_partner(&self, shape: f64, u: f32) -> f64 {
        match self.family {
            Family::Beckmann => {
                let eta = lookup(&BECKMANN, u as f64);
                (shape * eta.tan()).atan()
            }
            Family::Ggx => {
                let eta = lookup(&GGX, u as f64);
                (shape * eta.tan()).atan()
            }
            Family::Phong => {
                let w = (2.0 / (shape + 2.0)).sqrt();
                let eta = lookup_phong(w, u as f64);
                (w * eta.tan()).atan()
            }
        }
    }
}

/// [`GrooveNdf::first_pdf`] from `i.s`, `s.z` and `D(s)`: for Beckmann and
/// GGX the visible-normal density of [`Ndf::d_visible`] with `D` and
/// `sigma` computed once per evaluation and reused over its facets.
#[inline]
pub fn first_pdf_from(is: f64, sz: f64, d: f64, sigma: Option<f64>) -> f64 {
    match sigma {
        Some(sg) if sg > 0.0 => is.max(0.0) * d / sg,
        Some(_) => 0.0,
        None => d * sz.max(0.0),
    }
}

/// `integral_0^{pi/2} cos^e sin^2 dtheta`.
#[inline]
fn phong_z(e: f64) -> f64 {
    use crate::math::ln_gamma;
    let lz = ln_gamma(0.5 * (e + 1.0)) - ln_gamma(0.5 * (e + 4.0));
    0.25 * PI.sqrt() * lz.exp()
}

/// Entries of each inverse-CDF table (u in `[0, 1]`) minus one.
pub const TABLE_N: usize = 1024;
/// Phong columns (w = sqrt(2 / (e + 2)) in `[0, 1]`).
pub const PHONG_W: usize = 64;
/// Entries of each inverse-CDF table.
pub const STRIDE: usize = TABLE_N + 1;

/// Inverse CDFs of `P(theta_r)` in the variable `eta = atan(tan theta / scale)`,
/// computed by `cargo run --release --example gen_vgroove_tables` with
/// [`fill_beckmann`], [`fill_ggx`] and [`fill_phong`] (deterministic) into
/// compact binary files (`src/tables/`, format
/// `crate::multiple::bintable`) decoded at compile time: nothing is built
/// at run time, and no call waits for a table. Held as 16-bit steps of
/// `pi / 2` ([`Q16`]: `eta` to 1.2e-5 rad, against a node spacing of
/// about 1.5e-3; the f32 Phong table was 266 kB of the library, 133 kB now).
/// The unit of the stored angles ([`Q16`] steps of it).
const ETA_UNIT: f32 = FRAC_PI_2 as f32;
static BECKMANN: [Q16; STRIDE] = decode_q16(
    include_bytes!("../../tables/vgroove_partner_beckmann.bin"),
    ETA_UNIT,
);
static GGX: [Q16; STRIDE] = decode_q16(
    include_bytes!("../../tables/vgroove_partner_ggx.bin"),
    ETA_UNIT,
);
/// `PHONG_W + 1` columns of `STRIDE` entries; column 0 is the Beckmann limit.
static PHONG: [Q16; PHONG_LEN] = decode_q16(
    include_bytes!("../../tables/vgroove_partner_phong.bin"),
    ETA_UNIT,
);

/// Entries of the Phong table.
pub const PHONG_LEN: usize = (PHONG_W + 1) * STRIDE;

/// Beckmann in `eta = atan t`: `CDF(t) = erf(t) - 2 t exp(-t^2) / sqrt(pi)`.
fn beckmann_cdf(eta: f64) -> f64 {
    let t = eta.tan();
    if !t.is_finite() || t > 30.0 {
        return 1.0;
    }
    crate::math::erf(t) - 2.0 * FRAC_1_SQRT_PI * t * (-t * t).exp()
}

/// GGX in `eta`: density `(4 / pi) sin^2 eta`, CDF `(2 eta - sin 2 eta) / pi`.
fn ggx_cdf(eta: f64) -> f64 {
    (2.0 * eta - (2.0 * eta).sin()) / PI
}

/// Computes the Beckmann partner table (`STRIDE` entries; the generator's).
pub fn fill_beckmann(out: &mut [f32]) {
    invert(beckmann_cdf, out);
}

/// Computes the GGX partner table (`STRIDE` entries; the generator's).
pub fn fill_ggx(out: &mut [f32]) {
    invert(ggx_cdf, out);
}

/// Computes the Phong partner table (`PHONG_LEN` entries; the generator's).
pub fn fill_phong(out: &mut [f32]) {
    invert(beckmann_cdf, &mut out[..STRIDE]);
    for c in 1..=PHONG_W {
        phong_column(
            c as f64 / PHONG_W as f64,
            &mut out[c * STRIDE..(c + 1) * STRIDE],
        );
    }
}

/// Inverse of a CDF on `[0, pi/2]` at `u_j = j / TABLE_N`, by bisection.
fn invert(cdf: fn(f64) -> f64, out: &mut [f32]) {
    for (j, slot) in out.iter_mut().enumerate() {
        let u = j as f64 / TABLE_N as f64;
        *slot = crate::math::invert_increasing(cdf, u, 0.0, FRAC_PI_2) as f32;
    }
}

/// Phong column: density in `eta = atan(tan theta / w)` of
/// `cos^e theta sin^2 theta dtheta`, `e = 2 / w^2 - 2`, integrated by the
/// trapezoid rule on a fine grid (twice: once for the total, once emitting
/// the inverse at each `u_j` by linear interpolation).
fn phong_column(w: f64, out: &mut [f32]) {
    let e = 2.0 / (w * w) - 2.0;
    const M: usize = 1 << 14;
    let dens = |eta: f64| {
        // theta = atan(w tan eta), dtheta/deta = w / (cos^2 eta + w^2 sin^2 eta)
        let (se, ce) = eta.sin_cos();
        let q = ce * ce + w * w * se * se;
        let th = (w * se).atan2(ce);
        let (st, ct) = th.sin_cos();
        let v = ct.powf(e) * st * st * w / q;
        if v.is_finite() { v } else { 0.0 }
    };
    let h = FRAC_PI_2 / M as f64;
    let integrate = |mut emit: Option<(&mut [f32], f64)>| {
        let mut acc = 0.0;
        let mut prev = dens(0.0);
        let mut next_j = 0usize;
        if let Some((out, _)) = emit.as_mut() {
            out[0] = 0.0;
            next_j = 1;
        }
        for step in 1..=M {
            let cur = dens(step as f64 * h);
            let inc = 0.5 * (prev + cur) * h;
            if let Some((out, total)) = emit.as_mut() {
                let total = *total;
                while next_j < STRIDE && acc + inc >= next_j as f64 / TABLE_N as f64 * total {
                    let target = next_j as f64 / TABLE_N as f64 * total;
                    let f = if inc > 0.0 {
                        ((target - acc) / inc).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    let eta = ((step - 1) as f64 + f) * h;
                    out[next_j] = eta as f32;
                    next_j += 1;
                }
            }
            acc += inc;
            prev = cur;
        }
        if let Some((out, _)) = emit {
            for slot in &mut out[next_j..] {
                *slot = FRAC_PI_2 as f32;
            }
        }
        acc
    };
    let total = integrate(None);
    integrate(Some((out, total)));
}

#[inline]
fn load(t: &[Q16], j: usize) -> f64 {
    t[j].get() as f64 * ETA_UNIT as f64
}

#[inline]
fn lookup(t: &[Q16], u: f64) -> f64 {
    let x = u.clamp(0.0, 1.0) * TABLE_N as f64;
    let j = (x as usize).min(TABLE_N - 1);
    let f = x - j as f64;
    let (a, b) = (load(t, j), load(t, j + 1));
    a + f * (b - a)
}

#[inline]
fn lookup_phong(w: f64, u: f64) -> f64 {
    let t = &PHONG;
    let x = w.clamp(0.0, 1.0) * PHONG_W as f64;
    let c = (x as usize).min(PHONG_W - 1);
    let f = x - c as f64;
    let a = lookup(&t[c * STRIDE..(c + 1) * STRIDE], u);
    let b = lookup(&t[(c + 1) * STRIDE..(c + 2) * STRIDE], u);
    a + f * (b - a)
}

/// The quantile `theta_p` of the facet angle under the projected-area
/// distribution `D(s) s.z ds` (isotropic roughness `alpha`), and from it the
/// largest reflection count in a symmetric groove of those facets,
/// `ceil(pi / theta_v)`, `theta_v = pi - 2 theta_p` (the count of Lee et al. 2018,
/// eq. 4, maximised over the incident angle and position).
///
/// This reproduces Lee et al. 2018 Table 2 entry by entry for Beckmann, Phong and
/// GGX at alpha 0.5, 0.7 and 1.0 and percentiles 90, 95 and 99.
pub fn max_bounces_at_percentile(family: Family, alpha: f64, p: f64) -> u32 {
    let p = p.clamp(0.0, 1.0 - 1e-12);
    let theta = match family {
        // 1 - exp(-tan^2 / alpha^2)
        Family::Beckmann => (alpha * (-(1.0 - p).ln()).sqrt()).atan(),
        // tan^2 / (alpha^2 + tan^2)
        Family::Ggx => (alpha * (p / (1.0 - p)).sqrt()).atan(),
        // 1 - cos^(e + 2)
        Family::Phong => (1.0 - p).powf(1.0 / (phong_exponent(alpha) + 2.0)).acos(),
    };
    let theta_v = PI - 2.0 * theta;
    let n = (PI / theta_v).ceil();
    if n.is_finite() && n < 1e9 {
        (n as u32).max(1)
    } else {
        u32::MAX
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `integral_0^theta P(t | shape) dt` by Simpson's rule.
    fn cdf(n: &GrooveNdf, theta: f64, shape: f64) -> f64 {
        let m = 4000;
        let h = theta / m as f64;
        let mut s = n.partner_pdf(0.0, shape) + n.partner_pdf(theta.min(FRAC_PI_2 - 1e-12), shape);
        for j in 1..m {
            let w = if j % 2 == 1 { 4.0 } else { 2.0 };
            s += w * n.partner_pdf(j as f64 * h, shape);
        }
        s * h / 3.0
    }

    /// The tabulated inverse CDFs invert the analytic `P(theta_r)` (eq. 20):
    /// the density is normalised and `CDF(sample(u)) = u`.
    #[test]
    fn partner_tables_invert_the_analytic_density() {
        let cases = [
            (Family::Beckmann, vec![0.05, 0.5, 1.0, 3.0]),
            (Family::Ggx, vec![0.05, 0.5, 1.0, 3.0]),
            // Phong: the exponent is the shape.
            (Family::Phong, vec![0.0, 0.7, 3.0, 20.0, 400.0]),
        ];
        for (fam, shapes) in cases {
            let n = GrooveNdf::new(fam, 0.5, 0.5);
            for shape in shapes {
                let total = cdf(&n, FRAC_PI_2, shape);
                assert!((total - 1.0).abs() < 1e-4, "{fam:?} {shape}: {total}");
                for j in 1..20 {
                    let u = j as f64 / 20.0;
                    let t = n.sample_partner(shape, u as f32);
                    let c = cdf(&n, t, shape);
                    assert!((c - u).abs() < 3e-4, "{fam:?} shape {shape} u {u}: cdf {c}");
                }
            }
        }
    }

    /// The 16-bit partner tables hold their files' f32 angles to half a
    /// step of `ETA_UNIT` (so none was clamped: every angle is in
    /// `[0, pi/2]`).
    #[test]
    fn partner_tables_hold_their_files_to_half_a_step() {
        let check = |name: &str, file: &[u8], q: &[Q16]| {
            let worst = crate::multiple::bintable::q16_file_error(name, file, q, ETA_UNIT);
            // `load` is the decoding eval uses.
            assert_eq!(load(q, 0), q[0].get() as f64 * ETA_UNIT as f64);
            println!("{name}: worst |stored - file| = {worst:.2e} rad");
            let bound = 0.5 * Q16::STEP as f64 * ETA_UNIT as f64 + 1e-7;
            assert!(worst <= bound, "{name}: {worst} > {bound}");
        };
        check(
            "beckmann",
            include_bytes!("../../tables/vgroove_partner_beckmann.bin"),
            &BECKMANN,
        );
        check(
            "ggx",
            include_bytes!("../../tables/vgroove_partner_ggx.bin"),
            &GGX,
        );
        check(
            "phong",
            include_bytes!("../../tables/vgroove_partner_phong.bin"),
            &PHONG,
        );
    }
}
