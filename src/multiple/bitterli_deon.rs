//! `MSBSDF_MODEL_BITTERLI_DEON`: the exit probability `p_exit` of Bitterli
//! and d'Eon 2022 as given in seed 003's supplement (eqs. 5-7, Alg. 5),
//! with the unidirectional (PT) estimator, conductor facets.
//!
//! A path `d_0 = -wi, d_1, ..., d_k = wo` contributes
//! `prod f_p(d_i, d_{i+1}) p_exit(d_0, ..., d_k)` (supplement eq. 3), `f_p`
//! the phase function of Heitz et al. (eq. 4). The collision-depth density
//! after each collision is hyperexponential, `sum_j a_j exp(-b_j tau)`
//! ([`HeightDistribution`], eq. 6), with one term per downward direction so
//! far (`b_j = |Lambda|` of that direction), and
//! `p_exit = sum_j a_j / (b_j + Lambda(d_k))` (eq. 5). It equals
//! `prod |Lambda(d_i)| S_k` (eq. 7), so this model has the same values and,
//! with the same random numbers, the same variance as INVARIANCE (PT); it
//! costs more per bounce (a partial-fraction update of all terms at every
//! downward bounce).
//!
//! # The singularity and its guard
//! A downward direction with `l = |Lambda(d)|` multiplies every coefficient
//! by `l / (l - b_j)`: the **difference of two Lambdas** in a denominator
//! (eq. 6). When two downward directions have nearly equal `|Lambda|`, the
//! coefficients blow up with opposite signs and cancel in eq. (5); at
//! equality the exact density has a repeated pole (`tau exp(-b tau)`), which
//! a sum of exponentials cannot represent. Guard: the new pole is kept at a
//! relative distance of at least half [`POLE_SEPARATION`] from every existing
//! pole (stepped upwards by `POLE_SEPARATION l` until it is). `p_exit` is a continuous
//! function of the poles, so this changes the value by `O(POLE_SEPARATION)`
//! relative, only on paths with such near-coincidences, while the
//! cancellation error stays near `eps / POLE_SEPARATION` per coincidence
//! (f64). The result is clamped to `[0, 1]` (it is a probability), so a
//! cluster of several near-equal poles can lose precision but never gives
//! NaN, Inf or a negative value. INVARIANCE's segment term has no such
//! denominator.
//!
//! NDFs: Beckmann, GGX and Student-T, through the generic Smith API only
//! (the walk, exit probability and bounce limit are INVARIANCE's; see
//! [`crate::multiple::invariance`] for the Student-T measurements, and
//! [`crate::multiple::invariance::MAX_DEFAULT_BOUNCES`] for the heavy-tailed,
//! very rough Student-T surfaces refused, where the partial fractions of
//! eq. 6 lose their precision). The BDPT estimator is INVARIANCE's alone:
//! refused here.

use crate::bsdf::{Sample, ScatterModel};
use crate::desc::MAX_BOUNCES;
use crate::facet::Facet;
use crate::frame::flip_z;
use crate::multiple::invariance::{
    CAP_MAX, CAP_SMALL, ExitState, RR_DEPTH, RR_MIN_Q, default_max_bounces_for, lambda_signed,
    sample_walk, scatter, two_sided_hapke_pdf,
};
use crate::ndf::Ndf;
use crate::rng::Rng;
use glam::Vec3;

/// Smallest relative distance kept between two poles `b_j` (see module docs).
pub const POLE_SEPARATION: f64 = 1e-5;

/// The hyperexponential collision-depth density of supplement eq. (6)
/// (Alg. 5), with positive poles `b_j = |Lambda|` and the `|Lambda|`
/// factors of `p_exit` folded into the coefficients `a_j`.
#[derive(Clone, Copy, Debug)]
pub struct HeightDistribution<const C: usize> {
    n: usize,
    a: [f64; C],
    b: [f64; C],
    overflow: bool,
}

impl<const C: usize> ExitState for HeightDistribution<C> {
    fn start(l0: f64) -> Self {
        HeightDistribution::start(l0)
    }
    fn push(&mut self, lambda: f64) {
        HeightDistribution::push(self, lambda)
    }
    fn exit_value(&self, s: f64) -> f64 {
        self.raw(s)
    }
}

impl<const C: usize> HeightDistribution<C> {
    /// The first collision of a path entering along `d_0`, `l0 = |Lambda(d_0)|`:
    /// `a_1 = b_1 = l0` (eq. 6).
    pub fn start(l0: f64) -> Self {
        let mut h = HeightDistribution {
            n: 1,
            a: [0.0; C],
            b: [0.0; C],
            overflow: false,
        };
        h.a[0] = l0;
        h.b[0] = l0;
        h
    }

    /// Appends the travel direction `d` given its signed full-sphere `Lambda(d)`.
    pub fn push(&mut self, lambda: f64) {
        if lambda < 0.0 {
            if self.n >= C {
                self.overflow = true;
                return;
            }
            let mut l = -lambda;
            // Guard (module docs): step l upwards by POLE_SEPARATION l until
            // it is at least half a step from every existing pole (poles made
            // this way are half a step apart, so n + 1 steps always suffice).
            let step = POLE_SEPARATION * l;
            for _ in 0..=self.n {
                if self.b[..self.n]
                    .iter()
                    .all(|&b| (l - b).abs() >= 0.5 * step)
                {
                    break;
                }
                l += step;
            }
            // eq. (6), downward: a_j <- a_j l / (l - b_j); new a = -sum, b = l.
            let mut sum = 0.0;
            for j in 0..self.n {
                self.a[j] *= l / (l - self.b[j]);
                sum += self.a[j];
            }
            self.a[self.n] = -sum;
            self.b[self.n] = l;
            self.n += 1;
        } else {
            // eq. (6), upward: a_j <- a_j Lambda / (b_j + Lambda).
            for j in 0..self.n {
                self.a[j] *= lambda / (self.b[j] + lambda);
            }
        }
    }

    /// `sum_j a_j / (b_j + s)`: for `s = Lambda(d_k) >= 0` the exit
    /// probability of eq. (5) (unclamped); for `s = 0`, times nothing, the
    /// probability of reaching the next collision divided by its `|Lambda|`.
    pub fn raw(&self, s: f64) -> f64 {
        if self.overflow {
            return 0.0;
        }
        let mut p = 0.0;
        for j in 0..self.n {
            p += self.a[j] / (self.b[j] + s);
        }
        p
    }

    /// `p_exit` (eq. 5) for the exit direction with `Lambda = s >= 0`,
    /// clamped to `[0, 1]`.
    pub fn p_exit(&self, s: f64) -> f64 {
        let p = self.raw(s);
        if p.is_finite() {
            p.clamp(0.0, 1.0)
        } else {
            0.0
        }
    }
}

/// The Bitterli-d'Eon model (conductor facets, PT estimator).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BitterliDeon {
    ndf: Ndf,
    facet: Facet,
    max_bounces: u32,
}

impl BitterliDeon {
    /// A model with the given NDF, conductor facet and bounce limit
    /// (0: the same default as INVARIANCE).
    pub fn new(ndf: Ndf, facet: Facet, max_bounces: u32) -> Self {
        let max_bounces = if max_bounces == 0 {
            default_max_bounces_for(&ndf)
        } else {
            max_bounces.min(MAX_BOUNCES)
        };
        BitterliDeon {
            ndf,
            facet,
            max_bounces,
        }
    }

    /// The bounce limit in use.
    pub fn max_bounces(&self) -> u32 {
        self.max_bounces
    }

    /// Phase function `f_p(d, o) = F D_{-d}(h) / (4 |d.h|)` (supplement eq. 4).
    fn phase(&self, d: Vec3, o: Vec3) -> Vec3 {
        let h = (o - d).normalize_or_zero();
        let c = -d.dot(h);
        if c <= 0.0 || h.z <= 0.0 {
            return Vec3::ZERO;
        }
        self.facet.conductor_fresnel(c) * (self.ndf.d_visible(-d, h) / (4.0 * c))
    }

    fn eval_pt<const C: usize>(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        let lo = lambda_signed(&self.ndf, wo);
        let mut d = -wi;
        let mut hd = HeightDistribution::<C>::start(-lambda_signed(&self.ndf, d));
        let mut w = Vec3::ONE;
        let mut f = Vec3::ZERO;
        let mut k = 0u32;
        // Probability of reaching the current collision (once RR starts).
        let mut mass = f64::NAN;
        loop {
            k += 1;
            // NEE: f_p(d_{k-1}, wo) p_exit(d_0..d_{k-1}, wo).
            let fp = self.phase(d, wo);
            if fp != Vec3::ZERO {
                f += w * fp * hd.p_exit(lo) as f32;
            }
            if k >= self.max_bounces {
                break;
            }
            let Some((o, fr)) = scatter(&self.ndf, &self.facet, d, rng) else {
                break;
            };
            let lam_o = lambda_signed(&self.ndf, o);
            w *= fr;
            if k >= RR_DEPTH {
                if mass.is_nan() {
                    mass = hd.raw(0.0);
                }
                hd.push(lam_o);
                // The same exact continuation probability as INVARIANCE
                // (1 after a downward direction).
                let (q, new_mass) = if lam_o < 0.0 {
                    (1.0, mass)
                } else {
                    let nm = hd.raw(0.0);
                    let q = if mass > 0.0 {
                        (nm / mass).clamp(RR_MIN_Q, 1.0)
                    } else {
                        0.0
                    };
                    (q, nm)
                };
                if q.is_nan() || q <= 0.0 || (q < 1.0 && (rng.next_f32() as f64) >= q) {
                    break;
                }
                w /= q as f32;
                mass = new_mass;
            } else {
                hd.push(lam_o);
            }
            d = o;
            if !w.is_finite() || w.max_element() <= 0.0 {
                break;
            }
        }
        f
    }
}

impl ScatterModel for BitterliDeon {
    // PLACEHOLDER(kernel branch): replaced at merge
    fn sample_with(&self, wi: Vec3, _u: [f32; 3], rng: &mut Rng) -> Sample {
        self.sample(wi, rng)
    }

    fn eval(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        let (wi, wo) = if wi.z < 0.0 {
            (flip_z(wi), flip_z(wo))
        } else {
            (wi, wo)
        };
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        if (self.max_bounces as usize) < CAP_SMALL {
            self.eval_pt::<CAP_SMALL>(wi, wo, rng)
        } else {
            self.eval_pt::<CAP_MAX>(wi, wo, rng)
        }
    }

    fn sample(&self, wi: Vec3, rng: &mut Rng) -> Sample {
        if (self.max_bounces as usize) < CAP_SMALL {
            sample_walk::<HeightDistribution<CAP_SMALL>>(
                &self.ndf,
                &self.facet,
                self.max_bounces,
                wi,
                rng,
            )
        } else {
            sample_walk::<HeightDistribution<CAP_MAX>>(
                &self.ndf,
                &self.facet,
                self.max_bounces,
                wi,
                rng,
            )
        }
    }

    fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        two_sided_hapke_pdf(&self.ndf, wi, wo)
    }
}
