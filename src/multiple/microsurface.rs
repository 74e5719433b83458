//! The shared Smith microsurface walk: what every random-walk model does the
//! same way, whatever its paper.
//!
//! A path over a Smith microsurface (Heitz, Hanika, d'Eon and Dachsbacher
//! 2016) is a sequence of travel directions, each kept in the frame of the
//! side of the interface it travels on (z flipped below a dielectric, with
//! the relative index `eta` from outside and `1 / eta` from inside). At every
//! vertex the facet normal is drawn from the visible normals of the travel
//! direction `D_{-w}(m) = max(0, -w.m) D(m) / sigma(-w)` and the facet
//! scatters: conductor mirror with Fresnel weight, dielectric reflection with
//! probability `F` else refraction to the other side, or a Lambert lobe about
//! `m`. The phase function (value and sampling density) is the same for all
//! models: `p(w, o) = F D_{-w}(m) / (4 |o.m|)` (Heitz et al. 2016, eq. (6)
//! as restated by Cui et al. 2023) and `(1 - F) D_{-w}(m) J` with the
//! refraction Jacobian of Walter et al. 2007, eq. (17).
//!
//! What differs between the models is how a path's depth in the surface is
//! tracked, behind [`DepthState`]: Heitz et al.'s sampled height
//! (`heitz.rs`), the invariance segment term `S_k` (Cui et al. 2023, eq. (14),
//! `invariance.rs`), Bitterli and d'Eon's hyperexponential `p_exit`
//! (Bitterli and d'Eon 2022 as given by Cui et al. 2023, supplement eq. (6),
//! `bitterli_deon.rs`) and the memoryless exit term of the position-free
//! model (Wang et al. 2022, eqs. (6)-(7), `position_free.rs`). One estimator
//! ([`walk`]: next-event estimation at every vertex) and one sampler
//! ([`sample_walk`]) serve them all; the state decides whether a path leaves
//! along an upward direction (analog: the walk has the distribution of the
//! physical process, so its weight is the product of Fresnel factors) and
//! the probability that it leaves towards the next-event direction.

use crate::bsdf::opposite_sides;
use crate::facet::Facet;
use crate::frame::{RefractionHalf, basis, flip_z, reflect, refract, refraction_half};
use crate::fresnel;
use crate::ndf::Ndf;
use crate::rng::Rng;
use glam::Vec3;
use std::f32::consts::PI;

/// `ln(1 - exp(x))` for `x <= 0` without cancellation (Maechler 2012).
#[inline]
pub fn log1mexp(x: f64) -> f64 {
    if x > -std::f64::consts::LN_2 {
        (-x.exp_m1()).ln()
    } else {
        (-x.exp()).ln_1p()
    }
}

/// `ln 2` in two parts, the high one with 32 significant bits (exact
/// products with integers below 2^21).
const LN2_HI: f64 = 0.693_147_180_369_123_8;
const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;

/// `1 / n!`, n = 0..10: the Taylor coefficients of `exp`, highest last.
const EXP_TAYLOR: [f64; 11] = [
    1.0,
    1.0,
    1.0 / 2.0,
    1.0 / 6.0,
    1.0 / 24.0,
    1.0 / 120.0,
    1.0 / 720.0,
    1.0 / 5040.0,
    1.0 / 40_320.0,
    1.0 / 362_880.0,
    1.0 / 3_628_800.0,
];

/// `1 / (2n + 1)`, n = 0..5: `atanh(s) / s` as a series in `s^2`.
const ATANH_SERIES: [f64; 6] = [1.0, 1.0 / 3.0, 1.0 / 5.0, 1.0 / 7.0, 1.0 / 9.0, 1.0 / 11.0];

/// `sum c[n] x^n` by Horner's rule (coefficients from the constant term).
#[inline(always)]
fn horner(c: &[f64], x: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &k| acc * x + k)
}

/// `exp(x)` for `x <= 0` without a libm call (the walks draw heights and
/// escape probabilities with it at every vertex): `x = k ln 2 + r`,
/// `|r| <= ln 2 / 2`, Taylor series of `exp(r)` to `r^9` (remainder below
/// 3e-11 relative), times `2^k`. 0 below -708 (where `exp` leaves the
/// normal range); NaN stays NaN.
#[inline]
pub fn exp_nonpositive(x: f64) -> f64 {
    if x.is_nan() {
        return x;
    }
    if x <= -708.0 {
        return 0.0;
    }
    // Nearest integer of x / ln 2 by truncation (x <= 0).
    let k = (x * std::f64::consts::LOG2_E - 0.5) as i64;
    let kf = k as f64;
    let r = (x - kf * LN2_HI) - kf * LN2_LO;
    let p = horner(&EXP_TAYLOR, r);
    p * f64::from_bits(((k + 1023) as u64) << 52)
}

/// `exp(x) - 1` for `x <= 0` without cancellation: the Taylor series to
/// `x^10` for `x > -0.35` (remainder below 1e-12 relative), else
/// [`exp_nonpositive`]` - 1` (at most -0.29: no cancellation).
#[inline]
pub fn exp_m1_nonpositive(x: f64) -> f64 {
    if x > -0.35 {
        // (exp(x) - 1) / x = sum x^n / (n + 1)!, n = 0..9.
        x * horner(&EXP_TAYLOR[1..], x)
    } else {
        exp_nonpositive(x) - 1.0
    }
}

/// `2 atanh(s) = ln((1 + s) / (1 - s))` for `|s| <= 0.172` (series to
/// `s^11`, remainder below 2e-11 relative).
#[inline]
fn two_atanh(s: f64) -> f64 {
    2.0 * s * horner(&ATANH_SERIES, s * s)
}

/// `ln(x)` for `x > 0` without a libm call for normal `x`: `x = 2^e m`
/// with `m` in `[sqrt(1/2), sqrt(2))`, `ln m = 2 atanh((m - 1) / (m + 1))`
/// (relative error below 1e-11). Zero, subnormal, negative and non-finite
/// `x` go to libm.
#[inline]
pub fn ln_positive(x: f64) -> f64 {
    if !(f64::MIN_POSITIVE..f64::INFINITY).contains(&x) {
        return x.ln();
    }
    let bits = x.to_bits();
    let mut e = ((bits >> 52) & 0x7ff) as i64 - 1023;
    let mut m = f64::from_bits((bits & 0x000f_ffff_ffff_ffff) | 0x3ff0_0000_0000_0000);
    if m > std::f64::consts::SQRT_2 {
        m *= 0.5;
        e += 1;
    }
    let ef = e as f64;
    ef * LN2_HI + (two_atanh((m - 1.0) / (m + 1.0)) + ef * LN2_LO)
}

/// `ln(1 + y)` for `y > -1` without cancellation: `2 atanh(y / (2 + y))`
/// for `y` in `(-0.29, 0.41)` (no libm call), else [`ln_positive`]`(1 + y)`.
#[inline]
pub fn ln_1p(y: f64) -> f64 {
    if y > -0.29 && y < 0.41 {
        two_atanh(y / (2.0 + y))
    } else {
        ln_positive(1.0 + y)
    }
}

/// A uniform in the open interval `(0, 1)` (24-bit midpoints).
#[inline]
pub fn open_uniform(rng: &mut Rng) -> f64 {
    ((rng.next_u32() >> 8) as f64 + 0.5) * (1.0 / 16_777_216.0)
}

/// A cosine-distributed direction about the unit normal `n`.
#[inline]
pub fn cosine_about(n: Vec3, u1: f32, u2: f32) -> Vec3 {
    let r = u1.sqrt();
    let (s, c) = (2.0 * PI * u2).sin_cos();
    let (t, b) = basis(n);
    let z = (1.0 - u1).max(0.0).sqrt();
    (r * c * t + r * s * b + z * n).normalize_or_zero()
}

/// Roughness scale and bounce floor that carry the bounce limits measured
/// for GGX over to heavier-tailed NDFs (Student-T with shape `gamma < 2`),
/// from the generic Smith API only: `r = sigma_1(x) / sigma_GGX,1(x)`, the
/// projected area at the horizon of the NDF at unit roughness relative to
/// GGX's (`1/2`; `sigma = (1 + Lambda) z` there is the limit of `Lambda z`).
/// `r = 1` for GGX and Student-T `gamma = 2`, `1 / sqrt(pi)` for Beckmann and
/// below 1 for every Student-T `gamma > 2`: these keep the GGX rules
/// unchanged (scale 1, floor 10). Above 1 (Student-T `gamma < 2`:
/// `r = 1.11, 1.30, 1.67, 2.79, 5.04, 23.0` for
/// `gamma = 1.9, 1.8, 1.7, 1.6, 1.55, 1.51`; it diverges like
/// `1 / (2 gamma - 3)` because the mean slope does), the rules are applied
/// to the roughness `alpha r^1.5`, with at least `10 + floor(2.8 (r - 1))`
/// bounces.
///
/// Why: the walks' path length grows as the tail gets heavier. Fraction of
/// white-furnace walks (INVARIANCE, exact-exit `sample`, F = 1, 20k walks
/// per incidence, worst of theta_i = 0, 30, 60, 80, 89) still inside after
/// K bounces (the HEITZ walk loses the same: gamma 1.6, alpha 1: 9.3% at
/// K = 10, 1.2% at 16, 0.06% at 24):
///
/// | gamma | alpha | K = 10 | 16 | 24 | 32 | 64 | 128 | 256 |
/// |---|---|---|---|---|---|---|---|---|
/// | 1.9 | 1.5 | 0.21% | 0 | | | | | |
/// | 1.8 | 1 | 0.07% | 0 | | | | | |
/// | 1.8 | 1.5 | 1.1% | 0.005% | 0 | | | | |
/// | 1.8 | 3 | 30% | 3.6% | 0.06% | 0 | | | |
/// | 1.7 | 1 | 0.84% | 0.015% | 0 | | | | |
/// | 1.7 | 3 | 48% | 14% | 1.2% | 0.06% | 0 | | |
/// | 1.6 | 0.3 | 0.16% | 0.005% | 0 | | | | |
/// | 1.6 | 1 | 9.3% | 1.3% | 0.07% | 0 | | | |
/// | 1.6 | 3 | 75% | 50% | 21% | 6.4% | 0.005% | 0 | |
/// | 1.55 | 0.1 | 0.46% | 0.01% | 0 | | | | |
/// | 1.55 | 1 | 32% | 14% | 3.5% | 0.78% | 0.005% | 0 | |
/// | 1.51 | 0.1 | 30% | 15% | 6.1% | 2.5% | 0.08% | 0 | |
/// | 1.51 | 1 | 81% | 70% | 58% | 47% | 18% | 2.0% | 0 |
/// | 1.51 | 3 | 98% | 97% | 95% | 93% | 81% | 48% | 0.11% |
///
/// Over gamma = 1.51 .. 2 and alpha = 0.1 .. 3 the rule gives at least the
/// K that keeps the loss below 0.1% (interpolated in log loss between the
/// measured K), except where no limit can: gamma 1.51 from alpha 3 on needs
/// more than [`crate::desc::MAX_BOUNCES`].
pub fn heavy_tail_bounce_scale(ndf: &Ndf) -> (f32, u32) {
    let unit = Ndf::with_shape(ndf.kind, 1.0, 1.0, ndf.shape);
    let r = 2.0 * unit.sigma(Vec3::X);
    if !r.is_finite() || r <= 1.001 {
        return (1.0, 10);
    }
    let floor = (10.0 + (2.8 * (r - 1.0)).floor()).min(crate::desc::MAX_BOUNCES as f32);
    (r.powf(1.5), floor as u32)
}

/// A model's default bounce limit as a function of its roughness `a` (the
/// larger of the two, scaled by the NDF's tail, [`heavy_tail_bounce_scale`]):
/// the first step `(largest alpha, bounces)` with `a <= largest alpha`,
/// else `max(beyond_floor, ceil(slope a^power + offset))`; at least 10 and
/// the NDF's floor, at most [`crate::desc::MAX_BOUNCES`]. The one rule of
/// every walk; each model keeps its constants and their measurements
/// (`heitz::bounces`, `invariance::BOUNCES`, `position_free::bounces`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BounceRule {
    /// Measured limits `(largest alpha, bounces)`, increasing.
    pub steps: &'static [(f32, u32)],
    /// Beyond the steps: `slope a^power + offset`, rounded up.
    pub slope: f32,
    /// Exponent of the roughness beyond the steps.
    pub power: f32,
    /// Constant term beyond the steps.
    pub offset: f32,
    /// Least limit beyond the steps.
    pub beyond_floor: u32,
}

impl BounceRule {
    /// The limit at the roughness `a`, without the NDF's tail.
    pub fn limit_at(&self, a: f32) -> u32 {
        self.limit_scaled(a, 10)
    }

    /// The limit for `ndf`: the roughness scaled and the limit floored by
    /// [`heavy_tail_bounce_scale`] (unchanged for Beckmann, GGX and
    /// Student-T with shape >= 2).
    pub fn limit(&self, ndf: &Ndf) -> u32 {
        let (scale, floor) = heavy_tail_bounce_scale(ndf);
        self.limit_scaled(ndf.alpha_x.max(ndf.alpha_y) * scale, floor)
    }

    fn limit_scaled(&self, a: f32, floor: u32) -> u32 {
        let max = crate::desc::MAX_BOUNCES;
        let n = match self.steps.iter().find(|&&(limit, _)| a <= limit) {
            Some(&(_, n)) => n,
            None => {
                let x = if self.power == 1.0 {
                    a
                } else {
                    a.powf(self.power)
                };
                let n = (self.slope * x + self.offset).ceil().min(max as f32);
                (n as u32).max(self.beyond_floor)
            }
        };
        n.max(10).max(floor).min(max)
    }
}

/// The microsurface a walk runs over: distribution, facets, bounce limit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microsurface {
    /// The normal distribution.
    pub ndf: Ndf,
    /// What one facet does.
    pub facet: Facet,
    /// Largest number of vertices of a path (a path needing more is cut).
    pub max_bounces: u32,
    /// Conductor facets with `eta = 0, k = 1` (Fresnel exactly 1).
    white: bool,
}

/// What a facet did to a ray.
#[derive(Clone, Copy, Debug)]
pub struct Scattered {
    /// New travel direction, in the frame of the side it travels on (the
    /// other side's frame after a refraction).
    pub w: Vec3,
    /// Sampling weight (conductor Fresnel, diffuse albedo, else 1).
    pub weight: Vec3,
    /// The ray crossed the interface.
    pub refracted: bool,
    /// Cosine between the incoming ray (reversed) and the facet normal.
    pub cos: f32,
}

impl Microsurface {
    /// A microsurface; `max_bounces` as resolved by the model.
    pub fn new(ndf: Ndf, facet: Facet, max_bounces: u32) -> Self {
        let white =
            matches!(facet, Facet::Conductor { eta, k } if eta == Vec3::ZERO && k == Vec3::ONE);
        Microsurface {
            ndf,
            facet,
            max_bounces,
            white,
        }
    }

    /// Conductor Fresnel of a facet seen at cosine `c` (1 for other facets,
    /// and exactly 1 for the white conductor `eta = 0, k = 1`).
    #[inline]
    pub fn fresnel(&self, c: f32) -> Vec3 {
        match self.facet {
            Facet::Conductor { eta, k } if !self.white => fresnel::conductor_rgb(c, eta, k),
            _ => Vec3::ONE,
        }
    }

    /// True for dielectric facets (the only ones that transmit).
    #[inline]
    pub fn is_dielectric(&self) -> bool {
        matches!(self.facet, Facet::Dielectric { .. })
    }

    /// Relative index across the interface seen from outside (`inside =
    /// false`) or inside; 1 for opaque facets.
    #[inline]
    pub fn eta(&self, inside: bool) -> f32 {
        match self.facet {
            Facet::Dielectric { eta } if inside => 1.0 / eta,
            Facet::Dielectric { eta } => eta,
            _ => 1.0,
        }
    }

    /// Signed full-sphere `Lambda(w)` in f64.
    #[inline]
    pub fn lambda(&self, w: Vec3) -> f64 {
        self.ndf.lambda(w) as f64
    }

    /// Projected area `sigma(-w)` seen by a ray travelling along `w` whose
    /// signed `Lambda(w) = lam` is known: `sigma(-w) = Lambda(w) w.z` by the
    /// full-sphere symmetry `Lambda(-w) = -1 - Lambda(w)`.
    #[inline]
    pub fn sigma_seen(&self, w: Vec3, lam: f64) -> f32 {
        if lam.is_finite() {
            (lam * w.z as f64) as f32
        } else {
            self.ndf.sigma(-w)
        }
    }

    /// The facet at which a ray travelling along `w` scatters, drawn from
    /// `D_{-w}` with the uniforms `u1, u2`; `None` when numerically invisible.
    #[inline]
    pub fn facet_normal(&self, w: Vec3, u1: f32, u2: f32) -> Option<(Vec3, f32)> {
        let i = -w;
        let m = self.ndf.sample_visible(i, u1, u2);
        let ci = i.dot(m);
        if ci > 0.0 && m.is_finite() {
            Some((m, ci))
        } else {
            None
        }
    }

    /// Scatters a ray travelling along `w` (frame of its side, relative
    /// index `eta`) at the facet `m` with `ci = -w.m > 0`; `u` is the
    /// uniform choosing reflection or refraction (dielectric) and `rng`
    /// gives the diffuse lobe.
    #[inline]
    pub fn scatter_at(
        &self,
        w: Vec3,
        m: Vec3,
        ci: f32,
        eta: f32,
        u: f32,
        rng: &mut Rng,
    ) -> Option<Scattered> {
        let i = -w;
        let s = match self.facet {
            Facet::Conductor { .. } => {
                // The mirror direction with the known cosine; finite for a
                // finite unit `m` (facet_normal's contract).
                let o = 2.0 * ci * m - i;
                if o.z == 0.0 {
                    return None;
                }
                if self.white {
                    return Some(Scattered {
                        w: o,
                        weight: Vec3::ONE,
                        refracted: false,
                        cos: ci,
                    });
                }
                Scattered {
                    w: o,
                    weight: self.fresnel(ci),
                    refracted: false,
                    cos: ci,
                }
            }
            Facet::Diffuse { albedo } => Scattered {
                w: cosine_about(m, rng.next_f32(), rng.next_f32()),
                weight: albedo,
                refracted: false,
                cos: ci,
            },
            Facet::Dielectric { .. } => {
                let f = fresnel::dielectric(ci, eta);
                match if u < f { None } else { refract(i, m, eta) } {
                    Some(t) => Scattered {
                        w: flip_z(t),
                        weight: Vec3::ONE,
                        refracted: true,
                        cos: ci,
                    },
                    None => Scattered {
                        w: reflect(i, m),
                        weight: Vec3::ONE,
                        refracted: false,
                        cos: ci,
                    },
                }
            }
        };
        if s.w.is_finite() && s.w.z != 0.0 && s.weight.max_element() > 0.0 {
            Some(s)
        } else {
            None
        }
    }

    /// The phase function of a ray travelling along `w` (relative index
    /// `eta`, projected area `sigma_i = sigma(-w)`) towards `o` over this
    /// microsurface: [`Self::phase_over`] with its own NDF and the rate
    /// `sigma_i`, except for diffuse facets, whose phase function has no
    /// closed form: there the Lambert lobe about the already drawn facet
    /// `m_drawn` (an unbiased estimate of the phase function).
    #[inline]
    pub fn phase(&self, w: Vec3, o: Vec3, eta: f32, sigma_i: f32, m_drawn: Vec3) -> Vec3 {
        match self.facet {
            Facet::Diffuse { albedo } if o.z > 0.0 && sigma_i > 0.0 => {
                albedo * (o.dot(m_drawn).max(0.0) / PI)
            }
            Facet::Diffuse { .. } => Vec3::ZERO,
            _ => self.phase_over(&self.ndf, w, o, eta, sigma_i as f64),
        }
    }

    /// The phase function of conductor and dielectric facets whose normals
    /// have the density `ndf`, met at `rate` per unit length by a ray
    /// travelling along `w` (relative index `eta`): the density that such a
    /// collision sends the ray to `o` (frame of `w`'s side, `o.z < 0`:
    /// refraction), Fresnel included. Reflection `F D(h) / (4 rate)`,
    /// refraction `(1 - F) (i.h) D(h) J / rate` with the Jacobian of Walter
    /// et al. 2007, eq. (17); the half vector is the one facing `i = -w`, up
    /// or down. Zero for diffuse facets ([`Self::phase`]).
    ///
    /// The one phase function of the kernel. The height-field walks call it
    /// with their [`Ndf`] and `rate = sigma(-w)`, where it is
    /// `p(w, o) = F D_{-w}(m) / (4 |o.m|)` with the visible normals
    /// `D_{-w}(m) = (-w.m) D(m) / sigma(-w)` (Heitz et al. 2016, eq. (6) as
    /// restated by Cui et al. 2023); NULL_SCATTERING calls it with its
    /// full-sphere NDFs and the tentative rate `pi D_max` of its null
    /// collisions (d'Eon 2023, sec. 3.2).
    #[inline]
    pub fn phase_over<N: NormalDensity>(
        &self,
        ndf: &N,
        w: Vec3,
        o: Vec3,
        eta: f32,
        rate: f64,
    ) -> Vec3 {
        self.phase_and_density(ndf, w, o, eta, rate).0
    }

    /// [`Self::phase_over`], and for a reflection `F_d D(h)` at its half
    /// vector (`F_d` the dielectric Fresnel, 1 for conductors; 0 for a
    /// refraction), which the reverse walk's density of the same reflection
    /// needs: `D` is evaluated once.
    #[inline(always)]
    pub fn phase_and_density<N: NormalDensity>(
        &self,
        ndf: &N,
        w: Vec3,
        o: Vec3,
        eta: f32,
        rate: f64,
    ) -> (Vec3, f32) {
        let i = -w;
        if rate.is_nan() || rate <= 0.0 || matches!(self.facet, Facet::Diffuse { .. }) {
            return (Vec3::ZERO, 0.0);
        }
        if o.z > 0.0 {
            let h = (i + o).normalize_or_zero();
            let ci = i.dot(h);
            if ci <= 0.0 {
                return (Vec3::ZERO, 0.0);
            }
            let dm = ndf.density(h) as f32;
            let scale = 0.25 / rate as f32;
            return match self.facet {
                Facet::Dielectric { .. } => {
                    let fd = fresnel::dielectric(ci, eta) * dm;
                    (Vec3::splat(fd * scale), fd)
                }
                _ => (self.fresnel(ci) * (dm * scale), dm),
            };
        }
        if !self.is_dielectric() {
            return (Vec3::ZERO, 0.0);
        }
        // `refraction_half` returns the upward facet; a facet facing down
        // (full-sphere NDFs) is its mirror image in the mirrored frame.
        let half = refraction_half(i, o, eta).or_else(|| {
            refraction_half(flip_z(i), flip_z(o), eta).map(|r| RefractionHalf {
                h: flip_z(r.h),
                ..r
            })
        });
        let Some(RefractionHalf {
            h,
            ci,
            co,
            jacobian,
        }) = half
        else {
            return (Vec3::ZERO, 0.0);
        };
        let f = fresnel::dielectric_pair(ci, co, eta);
        let p = (1.0 - f) as f64 * (ci * jacobian) as f64 * ndf.density(h) / rate;
        (Vec3::splat(p as f32), 0.0)
    }

    /// Density with which a vertex seen from `i` (minus the travel
    /// direction) sends the walk along `o` (frame of `i`'s side;
    /// `refracted`: `o` is the refracted direction, pointing to the other
    /// side): the phase function without conductor Fresnel, the
    /// reflect/refract choice included. Conductor and dielectric facets.
    #[inline]
    pub fn phase_pdf(&self, i: Vec3, o: Vec3, eta: f32, refracted: bool) -> f64 {
        if refracted {
            let Some(RefractionHalf {
                h,
                ci,
                co,
                jacobian,
            }) = refraction_half(i, o, eta)
            else {
                return 0.0;
            };
            // Walter et al. 2007, eq. (17), with the visible-normal density.
            let f = fresnel::dielectric_pair(ci, co, eta);
            ((1.0 - f) * self.ndf.d_visible(i, h) * jacobian) as f64
        } else {
            let m = (i + o).normalize_or_zero();
            let m = if m.z < 0.0 { -m } else { m };
            let ci = i.dot(m);
            if ci <= 0.0 {
                return 0.0;
            }
            let p = self.ndf.d_visible(i, m) / (4.0 * ci);
            let f = match self.facet {
                Facet::Dielectric { .. } => fresnel::dielectric(ci, eta),
                _ => 1.0,
            };
            (f * p) as f64
        }
    }

    /// Density of the reverse walk choosing `-i` at a vertex that the
    /// forward walk left along `o` (`refracted`: `o` crossed to the other
    /// side, whose frame is the mirror image and whose index is `1 / eta`).
    #[inline]
    pub fn reverse_pdf(&self, i: Vec3, o: Vec3, eta: f32, refracted: bool) -> f64 {
        if refracted {
            self.phase_pdf(flip_z(o), flip_z(i), 1.0 / eta, true)
        } else {
            self.phase_pdf(o, i, eta, false)
        }
    }

    /// `eta_o^2 / eta_i^2` of the generalised reciprocity
    /// `f(wi, wo) / eta_o^2 = f(wo, wi) / eta_i^2` for a pair (1 unless a
    /// dielectric transmits).
    #[inline]
    pub fn reciprocity_factor(&self, wi: Vec3, wo: Vec3) -> f32 {
        match self.facet {
            Facet::Dielectric { eta } if opposite_sides(wi, wo) => {
                if wi.z > 0.0 {
                    eta * eta
                } else {
                    1.0 / (eta * eta)
                }
            }
            _ => 1.0,
        }
    }
}

impl Microsurface {
    /// Single scattering in closed form, `f_1(wi, wo) |wo.z|`: the first
    /// vertex's phase function towards `wo` times the escape probability
    /// integrated over the height of the first collision, height-correlated
    /// (Heitz et al. 2016): `(1 + Lambda_i) / (1 + Lambda_i + Lambda_o)` for
    /// reflection, `(1 + Lambda_i) B(1 + Lambda_i, 1 + Lambda_o)` for
    /// transmission. The same arithmetic as order 1 of the segment-term walk.
    pub fn single(&self, wi: Vec3, wo: Vec3) -> Vec3 {
        self.single_pair(&Pair::new(self, wi, wo))
    }

    /// [`Self::single`] with the pair's `Lambda`s already computed.
    pub fn single_pair(&self, pair: &Pair) -> Vec3 {
        let (wi, wo) = (pair.wi, pair.wo);
        let inside = wi.z < 0.0;
        let to_side = |v: Vec3| if inside { flip_z(v) } else { v };
        let (w, o) = (-to_side(wi), to_side(wo));
        if o.z < 0.0 && !self.is_dielectric() {
            return Vec3::ZERO;
        }
        let (lam0, lo) = (pair.lam_in(), pair.lam_o);
        if !(lam0.is_finite() && lo.is_finite()) {
            return Vec3::ZERO;
        }
        let l0 = -lam0;
        let exit = if o.z > 0.0 {
            l0 / (l0 + lo)
        } else {
            l0 * crate::math::beta(l0, 1.0 + lo)
        };
        let v = self.phase(w, o, self.eta(inside), self.sigma_seen(w, lam0), Vec3::Z) * exit as f32;
        if v.is_finite() { v } else { Vec3::ZERO }
    }
}

/// A pair of directions (world frame, away from the surface) with their
/// upper-side `Lambda`s, computed once for single scattering and the walks
/// in both directions: `lam_i = Lambda(|wi|)`, `lam_o = Lambda(|wo|)` (z
/// taken positive); the walk from `wi` enters along a direction with the
/// full-sphere `Lambda = -1 - lam_i`.
#[derive(Clone, Copy, Debug)]
pub struct Pair {
    /// Incident direction.
    pub wi: Vec3,
    /// Outgoing direction.
    pub wo: Vec3,
    /// `Lambda(wi)` on the upper side.
    pub lam_i: f64,
    /// `Lambda(wo)` on the upper side.
    pub lam_o: f64,
}

impl Pair {
    /// The pair and its `Lambda`s.
    #[inline]
    pub fn new(ms: &Microsurface, wi: Vec3, wo: Vec3) -> Self {
        let up = |v: Vec3| Vec3::new(v.x, v.y, v.z.abs());
        Pair {
            wi,
            wo,
            lam_i: ms.lambda(up(wi)),
            lam_o: ms.lambda(up(wo)),
        }
    }

    /// The pair with the roles swapped (the reverse walk's).
    #[inline]
    pub fn reversed(&self) -> Self {
        Pair {
            wi: self.wo,
            wo: self.wi,
            lam_i: self.lam_o,
            lam_o: self.lam_i,
        }
    }

    /// Full-sphere `Lambda` of the entering direction `-wi` (side frame),
    /// computed as [`Ndf::lambda`] does, `-1 - Lambda(|wi|)` in single
    /// precision.
    #[inline]
    pub fn lam_in(&self) -> f64 {
        (-1.0f32 - self.lam_i as f32) as f64
    }
}

/// What happened to a path leaving a vertex along a direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Travel {
    /// It hit the surface again: the next vertex.
    Hit,
    /// It left the surface (upward directions only).
    Escape,
    /// The state cannot follow it (capacity or precision): the path ends
    /// without leaving (absorbed).
    Lost,
}

/// How a model tracks a path's depth in the surface. The walk calls
/// [`DepthState::enter`] for the incident direction, then per vertex
/// [`DepthState::exit`] for the next event and [`DepthState::travel`] for
/// the sampled direction ([`DepthState::cross`] first after a refraction).
pub trait DepthState: Sized {
    /// The state at the first vertex of a path entering along a direction
    /// with signed `Lambda = lam0 <= -1` (the first hit is certain).
    fn enter(lam0: f64, rng: &mut Rng) -> Self;
    /// Probability that the path, at the current vertex, leaves the surface
    /// along a direction with `Lambda = lam_o >= 0` on the current side
    /// (`crossed = false`) or on the other side after a refraction.
    fn exit(&self, lam_o: f64, crossed: bool) -> f64;
    /// Leaves the current vertex along a direction with signed `Lambda = lam`.
    fn travel(&mut self, lam: f64, rng: &mut Rng) -> Travel;
    /// The path refracted at the current vertex: seen from the other side.
    fn cross(&mut self) {}
    /// Forced collision (variance reduction): travel along the upward
    /// direction with `Lambda = lam` conditioned on a hit; returns the hit
    /// probability (the weight), `None` when the state has no such form.
    fn travel_forced(&mut self, _lam: f64, _rng: &mut Rng) -> Option<f64> {
        None
    }
    /// For multiple importance sampling of the walks from `wi` and `wo`:
    /// `ln` of the density of the state at the first vertex, given the
    /// incident `Lambda = lam0`. The default, 0, with [`Self::exit_density`]
    /// 1 and [`Self::segment_ratio`] 1, weights the two walks by the
    /// densities of their direction choices alone: the balance heuristic on
    /// these pseudo-densities still sums to 1 over the two walks for every
    /// path, so it stays unbiased (Veach 1997, sec. 9.2), and it removes the
    /// spikes of a next event through a peaked `D` of a facet the walk did
    /// not choose.
    fn ln_entry_density(&self, _lam0: f64) -> f64 {
        0.0
    }
    /// `exp(`[`Self::ln_entry_density`]`)`; states override it when the
    /// density has a cheaper direct form.
    fn entry_density(&self, lam0: f64) -> f64 {
        let l = self.ln_entry_density(lam0);
        if l == 0.0 { 1.0 } else { l.exp() }
    }
    /// For MIS: the density of the reverse walk's state at the vertex of a
    /// next event whose exit probability towards `wo` (`Lambda = lam_o`) is `e`.
    fn exit_density(_lam_o: f64, _e: f64) -> f64 {
        1.0
    }
    /// For MIS: the ratio of the reverse to the forward density of the
    /// segment between two vertices along a direction with `Lambda = lam`.
    fn segment_ratio(_lam: f64) -> f64 {
        1.0
    }
}

/// A depth state held as the Laplace transform `R(s)` of the current
/// collision's depth density given the directions so far (Cui et al. 2023's
/// segment term, Bitterli and d'Eon 2022's hyperexponential `p_exit`),
/// renormalised after every step to `R(0) = 1`: then `R(s)` is the exact
/// conditional probability of leaving along a direction with `Lambda = s`,
/// the walk leaves with it (the distribution of Heitz et al.'s height walk
/// with the heights integrated out) and its weight is the product of the
/// Fresnel factors.
pub trait ExitTransform: Sized {
    /// `R(s) = l0 / (l0 + s)` up to a factor, after the incident direction
    /// with `l0 = |Lambda(d_0)|`.
    fn start(l0: f64) -> Self;
    /// The transform after travelling along a direction with signed
    /// `Lambda = lambda` (up to a factor).
    fn push(&mut self, lambda: f64);
    /// `R(s)`, `s >= 0`.
    fn value(&self, s: f64) -> f64;
    /// Multiplies `R` by `f`.
    fn scale(&mut self, f: f64);
    /// The state could not hold the path (capacity).
    fn overflowed(&self) -> bool;

    /// Pushes `lambda` and renormalises to `R(0) = 1`.
    #[inline]
    fn push_normalized(&mut self, lambda: f64) -> Travel {
        self.push(lambda.max(-f64::MAX));
        let r0 = self.value(0.0);
        if self.overflowed() || !(r0 > 0.0 && r0.is_finite()) {
            return Travel::Lost;
        }
        self.scale(1.0 / r0);
        Travel::Hit
    }
}

impl<T: ExitTransform> DepthState for T {
    #[inline]
    fn enter(lam0: f64, _rng: &mut Rng) -> Self {
        let mut t = T::start(-lam0);
        let r0 = t.value(0.0);
        t.scale(1.0 / r0);
        t
    }

    #[inline]
    fn exit(&self, lam_o: f64, _crossed: bool) -> f64 {
        let p = self.value(lam_o);
        if p.is_finite() {
            p.clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    #[inline]
    fn travel(&mut self, lam: f64, rng: &mut Rng) -> Travel {
        if lam >= 0.0 {
            if !lam.is_finite() {
                return Travel::Hit;
            }
            if open_uniform(rng) < self.exit(lam, false) {
                return Travel::Escape;
            }
        }
        self.push_normalized(lam)
    }

    #[inline]
    fn travel_forced(&mut self, lam: f64, _rng: &mut Rng) -> Option<f64> {
        if !lam.is_finite() {
            return Some(1.0);
        }
        let hit = 1.0 - self.exit(lam, false);
        match self.push_normalized(lam) {
            Travel::Hit => Some(hit),
            _ => Some(0.0),
        }
    }
}

/// MIS pseudo-density ratio of a segment along a direction with `Lambda =
/// lam` for depth states without heights: the hit probability of the
/// reverse over the forward walk with the height-uncorrelated escape
/// `G1 = 1 / (1 + Lambda)` of an upward ray (a downward ray always hits),
/// which is `(1 + L) / L` for either sign of `L`.
#[inline]
pub fn uncorrelated_segment_ratio(lam: f64) -> f64 {
    if lam.is_finite() {
        (1.0 + lam) / lam
    } else {
        1.0
    }
}

/// Variance-reduction switches of [`walk`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WalkOptions {
    /// Upward segments leaving vertices `1..=forced` always hit, weighted by
    /// the hit probability (states with [`DepthState::travel_forced`]).
    pub forced: u32,
    /// Balance-heuristic weight between this walk and the reverse walk from
    /// `wo` (see [`DepthState::ln_entry_density`]); the caller adds the two
    /// walks. Otherwise the caller averages them or uses one.
    pub mis: bool,
    /// Also estimate order 1 (off when the caller adds single scattering
    /// in closed form).
    pub order_one: bool,
    /// Upward segments after the forced ones also hit, weighted by the hit
    /// probability, and the walk goes on past the vertex they reach by
    /// Russian roulette with that probability (after its next event): the
    /// next event at every reached vertex keeps the exact factor.
    pub roulette: bool,
}

impl WalkOptions {
    /// The analog walk: next event at every vertex, no MIS.
    pub const ANALOG: WalkOptions = WalkOptions {
        forced: 0,
        mis: false,
        order_one: true,
        roulette: false,
    };
}

/// Receives a walk's next-event contributions by scattering order.
pub trait Tally {
    /// Adds the contribution `c` of a path of `order` vertices.
    fn add(&mut self, order: u32, c: Vec3);
}

impl Tally for Vec3 {
    #[inline]
    fn add(&mut self, _order: u32, c: Vec3) {
        *self += c;
    }
}

/// One walk from `wi` with next-event estimation towards `wo` at every
/// vertex (directions in the world frame, `wi` and `wo` away from the
/// surface): adds to `tally` the estimate of `f(wi, wo) |wo.z|` per order.
/// Returns the number of vertices visited.
pub fn walk<S: DepthState, T: Tally>(
    ms: &Microsurface,
    wi: Vec3,
    wo: Vec3,
    rng: &mut Rng,
    opt: WalkOptions,
    tally: &mut T,
) -> u32 {
    walk_pair::<S, T>(ms, &Pair::new(ms, wi, wo), rng, opt, tally)
}

/// [`walk`] with the pair's `Lambda`s already computed ([`Pair`]; the
/// reverse walk takes [`Pair::reversed`]).
pub fn walk_pair<S: DepthState, T: Tally>(
    ms: &Microsurface,
    pair: &Pair,
    rng: &mut Rng,
    opt: WalkOptions,
    tally: &mut T,
) -> u32 {
    walk_pair_from::<S, T>(ms, pair, None, rng, opt, tally)
}

/// [`walk_pair`] whose first visible-normal draw takes the uniforms
/// `first` (when given; the rest comes from `rng`): for stratified
/// first vertices of several walks within one estimate.
pub fn walk_pair_from<S: DepthState, T: Tally>(
    ms: &Microsurface,
    pair: &Pair,
    first: Option<[f32; 2]>,
    rng: &mut Rng,
    opt: WalkOptions,
    tally: &mut T,
) -> u32 {
    let (wi, wo) = (pair.wi, pair.wo);
    // Opaque facets are two-sided: a wi below mirrors the pair.
    let mut inside = wi.z < 0.0;
    let to_side = |v: Vec3, inside: bool| if inside { flip_z(v) } else { v };
    if !ms.is_dielectric() && !crate::bsdf::same_side(wi, wo) {
        return 0;
    }
    let mut w = -to_side(wi, inside);
    let mut eta = ms.eta(inside);
    let mut lam = pair.lam_in();
    let lam_target = pair.lam_o;
    if !lam_target.is_finite() || !lam.is_finite() {
        return 0;
    }
    let mut state = S::enter(lam, rng);
    let mut thr = Vec3::ONE;
    // MIS: P_reverse / P_forward of the path so far, without the reverse
    // walk's entry and first choice (multiplied in at each next event).
    let mis = opt.mis;
    let mut ratio = if mis {
        1.0 / state.entry_density(lam)
    } else {
        1.0
    };
    let diffuse = matches!(ms.facet, Facet::Diffuse { .. });
    // Hit probability of the segment that reached the current vertex, when
    // it was forced and is still to be rouletted.
    let mut p_last = 1.0f64;
    let mut k = 0u32;
    loop {
        k += 1;
        // Diffuse facets: the next event uses the drawn facet.
        let mut drawn = None;
        let uniforms = |rng: &mut Rng| match first {
            Some(u) if k == 1 => (u[0], u[1]),
            _ => (rng.next_f32(), rng.next_f32()),
        };
        if diffuse {
            let (u1, u2) = uniforms(rng);
            let Some(d) = ms.facet_normal(w, u1, u2) else {
                return k;
            };
            drawn = Some(d);
        }
        let m = drawn.map_or(Vec3::Z, |d| d.0);
        let sigma_i = ms.sigma_seen(w, lam);
        if k >= 2 || opt.order_one {
            let o = to_side(wo, inside);
            let e = state.exit(lam_target, o.z < 0.0);
            if e > 0.0 {
                let (p, fd_d) = if o.z > 0.0 && !diffuse {
                    ms.phase_and_density(&ms.ndf, w, o, eta, sigma_i as f64)
                } else {
                    // Diffuse facets (the reverse walk's first choice is still
                    // a visible-normal reflection: F_d = 1) and refraction.
                    let fd_d = if mis && o.z > 0.0 {
                        ms.ndf.d((o - w).normalize_or_zero())
                    } else {
                        0.0
                    };
                    (ms.phase(w, o, eta, sigma_i, m), fd_d)
                };
                let mut c = thr * p * e as f32;
                if mis && k >= 2 && c != Vec3::ZERO {
                    // The reverse walk's entry at this vertex (a state of
                    // the same kind entering along -wo) and its first
                    // choice, density pr.
                    let pr = if o.z > 0.0 {
                        // pr = F_d D(m) / (4 sigma(o)), sigma(o) = (1 + Lambda_o) o.z.
                        fd_d as f64 / (4.0 * o.z as f64 * (1.0 + lam_target))
                    } else {
                        ms.reverse_pdf(-w, o, eta, true)
                    };
                    let t = ratio * pr * S::exit_density(lam_target, e);
                    let wf = if t.is_nan() { 0.5 } else { 1.0 / (1.0 + t) };
                    c *= wf as f32;
                }
                if c.is_finite() {
                    tally.add(k, c);
                }
            }
        }
        if k >= ms.max_bounces {
            return k;
        }
        // Delayed Russian roulette on a forced segment: the next event above
        // had the hit probability in its weight; go on with that probability.
        if p_last < 1.0 {
            if (rng.next_f32() as f64) >= p_last {
                return k;
            }
            thr /= p_last as f32;
            p_last = 1.0;
        }
        let (m, ci) = match drawn {
            Some(d) => d,
            None => {
                let (u1, u2) = uniforms(rng);
                match ms.facet_normal(w, u1, u2) {
                    Some(d) => d,
                    None => return k,
                }
            }
        };
        let u = if ms.is_dielectric() {
            rng.next_f32()
        } else {
            0.0
        };
        let Some(s) = ms.scatter_at(w, m, ci, eta, u, rng) else {
            return k;
        };
        let w_old = w;
        let eta_old = eta;
        thr *= s.weight;
        if s.refracted {
            inside = !inside;
            eta = 1.0 / eta;
            state.cross();
        }
        w = s.w;
        lam = ms.lambda(w);
        if mis {
            if s.refracted {
                let o_dir = flip_z(s.w);
                ratio /= ms.phase_pdf(-w_old, o_dir, eta_old, true);
                if k > 1 {
                    ratio *= ms.reverse_pdf(-w_old, o_dir, eta_old, true);
                }
                ratio *= S::segment_ratio(lam);
            } else if k > 1 {
                // Reflection: pr / pf = sigma(-w_old) / sigma(w) with
                // sigma(w) = (1 + L) w.z (the facet density and dielectric
                // Fresnel cancel), times the segment ratio.
                ratio *= S::segment_ratio(lam) * sigma_i as f64 / ((1.0 + lam) * w.z as f64);
            } else {
                // First vertex: the forward choice only,
                // pf = F_d D(m) / (4 sigma(-w_old)).
                let fd = match ms.facet {
                    Facet::Dielectric { .. } => fresnel::dielectric(ci, eta_old),
                    _ => 1.0,
                };
                ratio *= 4.0 * sigma_i as f64 / (fd * ms.ndf.d(m)) as f64 * S::segment_ratio(lam);
            }
        }
        if w.z > 0.0 && (k <= opt.forced || opt.roulette) {
            match state.travel_forced(lam, rng) {
                Some(p) => {
                    thr *= p as f32;
                    if k > opt.forced {
                        p_last = p;
                    }
                }
                None => {
                    if state.travel(lam, rng) != Travel::Hit {
                        return k;
                    }
                }
            }
        } else if state.travel(lam, rng) != Travel::Hit {
            return k;
        }
        if thr.max_element().partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return k;
        }
    }
}

/// Walks per eval of HEITZ, INVARIANCE PT and BITTERLI_DEON PT, with
/// stratified first vertices ([`stratified_walks`]): half from `wi` and
/// half from `wo` where the two directions are combined by MIS, else all
/// from `wi`.
///
/// The first direction carries most of the variance of a walk's estimate
/// (at alpha 1 the orders covary: a walk that first turns down stays long;
/// forcing every segment to collide instead of Russian roulette changes the
/// variance by 5%), so stratifying it pays more than the walks cost.
/// Measured on INVARIANCE PT (`examples/efficiency.rs`, GGX, F = 1,
/// theta_i 60, efficiency against HEITZ at 9f91b5f, 2e5 evals per pair),
/// walks per direction with both directions:
///
/// | walks per direction | 1 | 2 | 3 | 4 | 8 |
/// |---|---|---|---|---|---|
/// | alpha 0.5: instructions per eval | 3418 | 6076 | 8723 | 11357 | 21931 |
/// | alpha 0.5: efficiency | 3.25x | 4.99x | 6.75x | 7.84x | 15.5x |
/// | alpha 1: instructions per eval | 4247 | 7645 | 11047 | 14478 | 28151 |
/// | alpha 1: efficiency | 2.55x | 5.68x | 6.93x | 7.25x | 8.62x |
///
/// 8 walks from `wi` alone: 9.58x at alpha 1, 3.86x at 0.5 and 7.66x at
/// alpha 0.3, theta_i 80 (22.6x with 4 per direction); hence one direction
/// from a mean roughness of 0.75 on (INVARIANCE, BITTERLI_DEON). The shift
/// of the second uniform matters: stratifying it in 2 instead of 4 (4
/// walks, lattice generator 2) gives 4.48x at alpha 1. At alpha 0.1 (theta_i
/// 60) 4 walks per direction have 4-5x less variance than 1 for 2.9x the
/// instructions. 8 keeps an eval near 2-3 us; more walks still gain by this
/// measure but make every eval dearer for a caller that needs fewer.
pub const STRATIFIED_WALKS: u32 = 8;

/// The mean of `n` walks from the pair ([`walk_pair_from`]) whose first
/// visible normals take the uniforms `((u1 + j / n) mod 1, (u2 + j / n) mod
/// 1)`, `j = 0..n`, for one uniform `(u1, u2)`: a randomly shifted lattice,
/// so each walk's first uniforms are uniform (unbiased) and together they
/// stratify both.
pub fn stratified_walks<S: DepthState>(
    ms: &Microsurface,
    pair: &Pair,
    n: u32,
    rng: &mut Rng,
    opt: WalkOptions,
) -> Vec3 {
    let (u1, u2) = (rng.next_f32(), rng.next_f32());
    let mut f = Vec3::ZERO;
    for j in 0..n {
        let shift = j as f32 / n as f32;
        let u = [(u1 + shift).fract(), (u2 + shift).fract()];
        walk_pair_from::<S, _>(ms, pair, Some(u), rng, opt, &mut f);
    }
    f / n.max(1) as f32
}

/// Where a sampled walk left the surface.
#[derive(Clone, Copy, Debug)]
pub struct Exit {
    /// Leaving direction, world frame.
    pub wo: Vec3,
    /// Product of the sampling weights (`f |wo.z| / pdf` of the walk).
    pub weight: Vec3,
    /// Vertices visited.
    pub bounces: u32,
}

/// One walk from `wi` sampling the leaving direction: the first vertex
/// takes `u[0]` (reflect or refract) and `u[1], u[2]` (visible normal),
/// everything after from `rng`. `visit` sees the cosine `|w.m|` of every
/// vertex. `Err(bounces)` when the path was absorbed or cut.
pub fn sample_walk<S: DepthState, V: FnMut(f32)>(
    ms: &Microsurface,
    wi: Vec3,
    u: [f32; 3],
    rng: &mut Rng,
    mut visit: V,
) -> Result<Exit, u32> {
    let mut inside = wi.z < 0.0;
    let to_side = |v: Vec3, inside: bool| if inside { flip_z(v) } else { v };
    let mut w = -to_side(wi, inside);
    let mut eta = ms.eta(inside);
    let lam0 = ms.lambda(w);
    if !lam0.is_finite() {
        return Err(0);
    }
    let mut state = S::enter(lam0, rng);
    let mut thr = Vec3::ONE;
    for k in 1..=ms.max_bounces {
        let (u0, u1, u2) = if k == 1 {
            (u[0], u[1], u[2])
        } else {
            let (u1, u2) = (rng.next_f32(), rng.next_f32());
            let u0 = if ms.is_dielectric() {
                rng.next_f32()
            } else {
                0.0
            };
            (u0, u1, u2)
        };
        let Some((m, ci)) = ms.facet_normal(w, u1, u2) else {
            return Err(k);
        };
        let Some(s) = ms.scatter_at(w, m, ci, eta, u0, rng) else {
            return Err(k);
        };
        visit(s.cos);
        thr *= s.weight;
        if s.refracted {
            inside = !inside;
            eta = 1.0 / eta;
            state.cross();
        }
        w = s.w;
        match state.travel(ms.lambda(w), rng) {
            Travel::Hit => {}
            Travel::Escape => {
                return Ok(Exit {
                    wo: to_side(w, inside),
                    weight: thr,
                    bounces: k,
                });
            }
            Travel::Lost => return Err(k),
        }
    }
    Err(ms.max_bounces + 1)
}

/// Three uniforms from `rng` for [`sample_walk`]'s first vertex.
#[inline]
pub fn first_uniforms(rng: &mut Rng) -> [f32; 3] {
    [rng.next_f32(), rng.next_f32(), rng.next_f32()]
}

/// The approximate pdf of the walks (as Heitz et al. 2016, sec. 4.3): the
/// exact density of a single visible-normal reflection or refraction (the
/// first vertex) with weight `1 - q`, plus a cosine lobe with weight `q`
/// (both hemispheres for dielectrics) for the multiply scattered light.
/// Diffuse facets: the cosine lobe alone. Positive wherever a walk can go.
pub fn approximate_pdf(ms: &Microsurface, q: f32, wi: Vec3, wo: Vec3) -> f32 {
    let reflection = crate::bsdf::same_side(wi, wo);
    let cosine = match ms.facet {
        Facet::Dielectric { .. } => wo.z.abs() / (2.0 * PI),
        _ if reflection => wo.z.abs() / PI,
        _ => 0.0,
    };
    let single = if q < 1.0 && !matches!(ms.facet, Facet::Diffuse { .. }) {
        first_vertex_pdf(ms, wi, wo)
    } else {
        0.0
    };
    let p = (1.0 - q) * single + q * cosine;
    if p.is_finite() && p > 0.0 { p } else { 0.0 }
}

/// Exact density of the first vertex sending `wi` to `wo` (world frame).
pub fn first_vertex_pdf(ms: &Microsurface, wi: Vec3, wo: Vec3) -> f32 {
    let inside = wi.z < 0.0;
    let to_side = |v: Vec3| if inside { flip_z(v) } else { v };
    let (i, o) = (to_side(wi), to_side(wo));
    if o.z == 0.0 || i.z <= 0.0 {
        return 0.0;
    }
    if o.z < 0.0 && !ms.is_dielectric() {
        return 0.0;
    }
    ms.phase_pdf(i, o, ms.eta(inside), o.z < 0.0) as f32
}

/// A density of facet normals over the whole sphere, `D(m)` per steradian:
/// what [`Microsurface::phase_over`] needs of a distribution. [`Ndf`] is
/// one (zero below the horizon); NULL_SCATTERING's full-sphere
/// distributions (d'Eon 2023, sec. 3) are others.
pub trait NormalDensity {
    /// `D(m)` for the unit normal `m`.
    fn density(&self, m: Vec3) -> f64;
}

impl NormalDensity for Ndf {
    #[inline]
    fn density(&self, m: Vec3) -> f64 {
        self.d(m) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::multiple::heitz::HeightState;
    use crate::ndf::NdfKind;

    fn gold() -> Facet {
        Facet::Conductor {
            eta: Vec3::new(0.143, 0.374, 1.442),
            k: Vec3::new(3.983, 2.385, 1.603),
        }
    }

    fn dir(theta_deg: f32, phi_deg: f32) -> Vec3 {
        let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
        Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
    }

    /// Mean and standard error.
    fn stats(v: impl Iterator<Item = f64>) -> (f64, f64) {
        let (mut n, mut s, mut s2) = (0.0, 0.0, 0.0);
        for x in v {
            n += 1.0;
            s += x;
            s2 += x * x;
        }
        let m = s / n;
        (m, ((s2 / n - m * m).max(0.0) / (n - 1.0)).sqrt())
    }

    /// The phase function integrated over the upper hemisphere (uniform
    /// directions) equals the facet albedo sent upward, estimated by
    /// scattering (the weight of the sampled directions that go up): gold
    /// conductor, glass reflection from outside and inside, within 4
    /// combined standard errors, each below 0.004.
    #[test]
    fn phase_integrates_to_the_upward_facet_albedo() {
        let cases = [
            (gold(), false, 0.5f32, 40.0f32),
            (Facet::Dielectric { eta: 1.5 }, false, 0.3, 70.0),
            (Facet::Dielectric { eta: 1.5 }, true, 0.8, 20.0),
        ];
        let n = 200_000;
        for (facet, inside, alpha, theta) in cases {
            let ms = Microsurface::new(Ndf::new(NdfKind::Ggx, alpha, alpha), facet, 10);
            let eta = ms.eta(inside);
            let w = -dir(theta, 30.0);
            let lam = ms.lambda(w);
            let sigma = ms.sigma_seen(w, lam);
            let mut rng = Rng::new(3, 1);
            let (integral, e1) = stats((0..n).map(|_| {
                let (u1, u2) = (rng.next_f32(), rng.next_f32());
                let z = u1;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let (s, c) = (2.0 * PI * u2).sin_cos();
                let o = Vec3::new(r * c, r * s, z);
                (ms.phase(w, o, eta, sigma, Vec3::Z).y * 2.0 * PI) as f64
            }));
            let (albedo, e2) = stats((0..n).map(|_| {
                let Some((m, ci)) = ms.facet_normal(w, rng.next_f32(), rng.next_f32()) else {
                    return 0.0;
                };
                let u = rng.next_f32();
                match ms.scatter_at(w, m, ci, eta, u, &mut rng) {
                    Some(s) if !s.refracted && s.w.z > 0.0 => s.weight.y as f64,
                    _ => 0.0,
                }
            }));
            assert!(e1 < 0.004 && e2 < 0.004, "standard errors {e1} {e2}");
            assert!(
                (integral - albedo).abs() <= 4.0 * (e1 * e1 + e2 * e2).sqrt(),
                "{facet:?} inside {inside}: phase integral {integral} +- {e1}, albedo {albedo} +- {e2}"
            );
        }
    }

    /// The one phase function, [`Microsurface::phase_over`] (here with
    /// height-field NDFs and `rate = sigma(-w)`), integrates to the facet
    /// albedo, both sides by deterministic quadrature: over the sphere of
    /// outgoing directions, the phase function; over the visible normals
    /// `D_{-w}(m)`, the Fresnel weight of the event reaching the same region
    /// (a reflection upward, a refraction downward). Anisotropic Beckmann,
    /// GGX and Student-T, gold and glass seen from outside and inside,
    /// travelling down (first vertex) and up (later vertices); midpoint
    /// rules on `(cos theta, phi)` grids, 1200 x 1200 over the sphere and
    /// 600 x 600 over the normals (whose `D_{-w}` integrates to 1 within
    /// 1e-4: asserted). Measured worst difference 2.4e-4; bound 2e-3
    /// against albedos of 0.44 to 1 (a lost Fresnel factor or refraction
    /// Jacobian moves them by 0.1 or more).
    #[test]
    fn phase_over_integrates_to_the_facet_albedo() {
        let (mut worst, mut cases) = (0.0f64, 0);
        for kind in [NdfKind::Beckmann, NdfKind::Ggx, NdfKind::StudentT] {
            let ndf = Ndf::with_shape(kind, 0.7, 0.4, 3.0);
            for facet in [gold(), Facet::Dielectric { eta: 1.5 }] {
                let ms = Microsurface::new(ndf, facet, 10);
                let sides: &[bool] = if ms.is_dielectric() {
                    &[false, true]
                } else {
                    &[false]
                };
                for &inside in sides {
                    let eta = ms.eta(inside);
                    for w in [-dir(35.0, 20.0), dir(70.0, 200.0)] {
                        let i = -w;
                        let sigma = ms.ndf.sigma(i) as f64;
                        // Over the outgoing sphere.
                        let n = 1200;
                        let mut phase = 0.0f64;
                        for a in 0..n {
                            let z = -1.0 + 2.0 * (a as f32 + 0.5) / n as f32;
                            let r = (1.0 - z * z).max(0.0).sqrt();
                            for b in 0..n {
                                let (s, c) = (2.0 * PI * (b as f32 + 0.5) / n as f32).sin_cos();
                                let o = Vec3::new(r * c, r * s, z);
                                phase += ms.phase_over(&ms.ndf, w, o, eta, sigma).y as f64;
                            }
                        }
                        phase *= 4.0 * std::f64::consts::PI / (n * n) as f64;
                        // Over the visible normals.
                        let n = 600;
                        let (mut albedo, mut total) = (0.0f64, 0.0f64);
                        for a in 0..n {
                            let z = (a as f32 + 0.5) / n as f32;
                            let r = (1.0 - z * z).max(0.0).sqrt();
                            for b in 0..n {
                                let (s, c) = (2.0 * PI * (b as f32 + 0.5) / n as f32).sin_cos();
                                let m = Vec3::new(r * c, r * s, z);
                                let ci = i.dot(m);
                                if ci <= 0.0 {
                                    continue;
                                }
                                let dv = ci as f64 * ms.ndf.d(m) as f64 / sigma;
                                total += dv;
                                let (reflected, transmitted) = match facet {
                                    Facet::Dielectric { .. } => {
                                        let f = fresnel::dielectric(ci, eta) as f64;
                                        let t = refract(i, m, eta).filter(|t| t.z < 0.0);
                                        (f, if t.is_some() { 1.0 - f } else { 0.0 })
                                    }
                                    _ => (ms.fresnel(ci).y as f64, 0.0),
                                };
                                let up = reflect(i, m).z > 0.0;
                                albedo += dv * (if up { reflected } else { 0.0 } + transmitted);
                            }
                        }
                        let dm = 2.0 * std::f64::consts::PI / (n * n) as f64;
                        total *= dm;
                        albedo *= dm;
                        assert!(
                            (total - 1.0).abs() < 1e-4,
                            "{kind:?} {w}: visible normals integrate to {total}"
                        );
                        worst = worst.max((phase - albedo).abs());
                        cases += 1;
                        assert!(
                            (phase - albedo).abs() < 2e-3,
                            "{kind:?} {facet:?} inside {inside} w {w}: phase integral {phase}, albedo {albedo}"
                        );
                    }
                }
            }
        }
        assert_eq!(cases, 18);
        eprintln!("worst difference {worst:.2e}");
    }

    /// The inline exp and ln of the height walk against libm, relative
    /// error below 1e-10 over their domains (sweeps of 20k points, log
    /// spaced towards 0 and the ends).
    #[test]
    fn inline_exp_and_ln_match_libm() {
        let rel = |a: f64, b: f64| ((a - b) / b.abs().max(1e-300)).abs();
        let mut worst = [0.0f64; 4];
        for i in 0..20_000 {
            let t = i as f64 / 20_000.0;
            // exp, expm1 on [-708, 0]: log spaced magnitudes 1e-12 .. 708.
            let x = -(1e-12f64.ln() + t * (708.0f64.ln() - 1e-12f64.ln())).exp();
            worst[0] = worst[0].max(rel(exp_nonpositive(x), x.exp()));
            worst[1] = worst[1].max(rel(exp_m1_nonpositive(x), x.exp_m1()));
            // ln on (1e-300, 1e3].
            let y = (-690.0 + t * 697.0f64).exp();
            worst[2] =
                worst[2].max(rel(ln_positive(y), y.ln()).min((ln_positive(y) - y.ln()).abs()));
            // ln_1p on (-1, 10]: y + 1 log spaced 1e-12 .. 11, and tiny |y|.
            let z = (1e-12f64.ln() + t * (11.0f64.ln() - 1e-12f64.ln())).exp() - 1.0;
            worst[3] = worst[3].max(rel(ln_1p(z), z.ln_1p()));
            let w = -(1e-15f64.ln() + t * (0.3f64.ln() - 1e-15f64.ln())).exp();
            worst[3] = worst[3].max(rel(ln_1p(w), w.ln_1p()));
        }
        assert!(
            worst.iter().all(|&e| e < 1e-10),
            "worst relative errors {worst:?}"
        );
        assert_eq!(exp_nonpositive(0.0), 1.0);
        assert_eq!(exp_nonpositive(-800.0), 0.0);
        assert_eq!(exp_nonpositive(f64::NEG_INFINITY), 0.0);
        assert!(exp_nonpositive(f64::NAN).is_nan());
        assert_eq!(ln_positive(1.0), 0.0);
        assert_eq!(ln_1p(0.0), 0.0);
        assert_eq!(ln_positive(0.0), f64::NEG_INFINITY);
    }

    /// `sin_cos_turn` against libm, within 2e-7 absolute on 100k angles.
    #[test]
    fn sin_cos_turn_matches_libm() {
        let mut worst = 0.0f64;
        for i in 0..100_000 {
            let u = i as f32 / 100_000.0;
            let (s, c) = crate::ndf::sin_cos_turn(u);
            let a = 2.0 * std::f64::consts::PI * u as f64;
            worst = worst
                .max((s as f64 - a.sin()).abs())
                .max((c as f64 - a.cos()).abs());
        }
        let (s, c) = crate::ndf::sin_cos_turn(1.0);
        assert!(s.abs() < 2e-7 && (c - 1.0).abs() < 2e-7);
        assert!(worst < 2e-7, "worst absolute error {worst}");
    }

    /// Reciprocity of the phase function: `sigma(i) p(-i -> o) =
    /// sigma(o) p(-o -> i)` for reflection, and with `eta^2` for refraction.
    #[test]
    fn phase_is_reciprocal() {
        let mut rng = Rng::new(5, 2);
        let mut tested = 0;
        for facet in [gold(), Facet::Dielectric { eta: 1.5 }] {
            let ms = Microsurface::new(Ndf::new(NdfKind::Beckmann, 0.6, 0.3), facet, 10);
            for _ in 0..500 {
                let i = dir(89.0 * rng.next_f32(), 360.0 * rng.next_f32());
                let mut o = dir(89.0 * rng.next_f32(), 360.0 * rng.next_f32());
                let transmit = ms.is_dielectric() && rng.next_f32() < 0.5;
                if transmit {
                    o = flip_z(o);
                }
                let eta = ms.eta(false);
                let si = ms.ndf.sigma(i);
                let a = si * ms.phase(-i, o, eta, si, Vec3::Z).y;
                // The reverse: from the side of o (flipped frame if below).
                let (ob, ib, etab) = if transmit {
                    (flip_z(o), flip_z(i), 1.0 / eta)
                } else {
                    (o, i, eta)
                };
                let so = ms.ndf.sigma(ob);
                let b = so * ms.phase(-ob, ib, etab, so, Vec3::Z).y;
                let b = if transmit { b * eta * eta } else { b };
                if a > 1e-6 || b > 1e-6 {
                    tested += 1;
                    assert!(
                        (a - b).abs() <= 1e-4 * a.max(b),
                        "{facet:?} {i} {o}: {a} vs {b}"
                    );
                }
            }
        }
        assert!(tested > 500, "only {tested} pairs tested");
    }

    /// A refraction flips the side: the new direction, in the frame of the
    /// other side, points away from the interface, and the relative index
    /// seen from there is `1 / eta`.
    #[test]
    fn refraction_flips_the_side() {
        let ms = Microsurface::new(
            Ndf::new(NdfKind::Ggx, 0.2, 0.2),
            Facet::Dielectric { eta: 1.5 },
            10,
        );
        let mut rng = Rng::new(7, 3);
        let mut refracted = 0;
        for _ in 0..1000 {
            let w = -dir(80.0 * rng.next_f32(), 360.0 * rng.next_f32());
            let Some((m, ci)) = ms.facet_normal(w, rng.next_f32(), rng.next_f32()) else {
                continue;
            };
            // u just below 1 refracts unless total internal reflection.
            if let Some(s) = ms.scatter_at(w, m, ci, ms.eta(false), 0.9999, &mut rng)
                && s.refracted
            {
                {
                    refracted += 1;
                    assert!(s.w.z > 0.0, "{w} -> {}", s.w);
                    // Refracted back with the inverse index: the same direction.
                    let back = refract(-s.w, flip_z(m), ms.eta(true)).map(flip_z);
                    let back = back.expect("no TIR on the way back");
                    assert!((back - w).length() < 1e-3, "{w} vs {back}");
                }
            }
        }
        assert!(refracted > 900, "{refracted}");
        assert_eq!(ms.eta(true), 1.0 / 1.5);
    }

    /// Grazing and subnormal directions give finite, non-negative results.
    #[test]
    fn grazing_and_subnormal_directions_are_finite() {
        let mut rng = Rng::new(9, 4);
        for facet in [gold(), Facet::Dielectric { eta: 1.5 }] {
            let ms = Microsurface::new(Ndf::new(NdfKind::Ggx, 0.05, 0.5), facet, 20);
            for wi in [
                Vec3::new(-1.0, 0.0, 1.4e-45),
                Vec3::new(0.0, 1.0, 1e-30),
                Vec3::new(1.0, 0.0, -1e-38),
                dir(89.99, 10.0),
            ] {
                let wo = dir(89.99, 200.0);
                for _ in 0..200 {
                    let mut f = Vec3::ZERO;
                    walk::<HeightState, _>(&ms, wi, wo, &mut rng, WalkOptions::ANALOG, &mut f);
                    assert!(f.is_finite() && f.min_element() >= 0.0, "{wi}: {f}");
                    let s = ms.single(wi, wo);
                    assert!(s.is_finite() && s.min_element() >= 0.0);
                    let u = first_uniforms(&mut rng);
                    if let Ok(e) = sample_walk::<HeightState, _>(&ms, wi, u, &mut rng, |_| {}) {
                        assert!(e.wo.is_finite() && e.weight.is_finite());
                        assert!(e.weight.min_element() >= 0.0);
                    }
                    let p = approximate_pdf(&ms, 0.3, wi, wo);
                    assert!(p.is_finite() && p >= 0.0);
                }
            }
        }
    }

    /// Caller uniforms: on a nearly smooth conductor the walk leaves after
    /// one reflection, in the mirror direction of the visible normal that
    /// `u[1], u[2]` select.
    #[test]
    fn first_vertex_follows_the_caller_uniforms() {
        let ms = Microsurface::new(Ndf::new(NdfKind::Ggx, 0.01, 0.01), gold(), 10);
        let wi = dir(40.0, 0.0);
        let mut rng = Rng::new(11, 5);
        let mut matched = 0;
        for i in 0..1000 {
            let u = [
                0.5,
                (i as f32 + 0.5) / 1000.0,
                ((i * 7919) % 1000) as f32 / 1000.0,
            ];
            let m = ms.ndf.sample_visible(wi, u[1], u[2]);
            let expect = reflect(wi, m);
            if let Ok(e) = sample_walk::<HeightState, _>(&ms, wi, u, &mut rng, |_| {})
                && (e.wo - expect).length() < 1e-5
            {
                matched += 1;
            }
        }
        assert!(matched >= 990, "{matched} of 1000");
    }

    /// Stratified caller uniforms lower the variance of the sample-weight
    /// furnace (gold: the weight is the Fresnel factor of the first
    /// reflection for most walks) against independent uniforms: variance of
    /// the mean of 256 samples (16 x 16 jittered strata of `u[1], u[2]`)
    /// over 200 repetitions, below half.
    #[test]
    fn stratified_uniforms_lower_the_furnace_variance() {
        let ms = Microsurface::new(Ndf::new(NdfKind::Ggx, 0.2, 0.2), gold(), 10);
        let wi = dir(30.0, 0.0);
        let mut rng = Rng::new(13, 6);
        let run = |stratified: bool, rng: &mut Rng| {
            stats((0..200).map(|_| {
                let mut s = 0.0;
                for j in 0..256 {
                    let u = if stratified {
                        let (a, b) = ((j % 16) as f32, (j / 16) as f32);
                        [
                            rng.next_f32(),
                            (a + rng.next_f32()) / 16.0,
                            (b + rng.next_f32()) / 16.0,
                        ]
                    } else {
                        first_uniforms(rng)
                    };
                    if let Ok(e) = sample_walk::<HeightState, _>(&ms, wi, u, rng, |_| {}) {
                        s += e.weight.x as f64;
                    }
                }
                s / 256.0
            }))
        };
        let (m1, e1) = run(false, &mut rng);
        let (m2, e2) = run(true, &mut rng);
        assert!(
            (m1 - m2).abs() <= 4.0 * (e1 * e1 + e2 * e2).sqrt(),
            "{m1} vs {m2}"
        );
        // Variance ratio measured 0.32; each variance has a relative
        // standard error of sqrt(2 / 200) = 0.1, so 0.5 is 3 sigma away.
        let ratio = (e2 / e1).powi(2);
        assert!(
            ratio < 0.5,
            "variance ratio {ratio}: stratified {e2}, independent {e1}"
        );
    }

    /// Order 1 of the segment-term walk and of the closed form agree to
    /// float precision (the closed form is what HEITZ adds).
    #[test]
    fn closed_single_scattering_is_order_one() {
        let ms = Microsurface::new(Ndf::new(NdfKind::Beckmann, 0.4, 0.7), gold(), 1);
        let mut rng = Rng::new(15, 7);
        for _ in 0..200 {
            let wi = dir(85.0 * rng.next_f32(), 360.0 * rng.next_f32());
            let wo = dir(85.0 * rng.next_f32(), 360.0 * rng.next_f32());
            let mut f = Vec3::ZERO;
            walk::<crate::multiple::invariance::SegmentTerm<4>, _>(
                &ms,
                wi,
                wo,
                &mut rng,
                WalkOptions::ANALOG,
                &mut f,
            );
            let s = ms.single(wi, wo);
            assert!(
                (f - s).abs().max_element() <= 1e-6 * s.max_element(),
                "{f} vs {s}"
            );
        }
    }
}
