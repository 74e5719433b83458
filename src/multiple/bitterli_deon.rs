//! `MSBSDF_MODEL_BITTERLI_DEON`: the exit probability `p_exit` of Bitterli
//! and d'Eon 2022 as given in the supplement of Cui et al. 2023 (eqs. 5-7, Alg. 5),
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
//! with the same random numbers, the same variance as INVARIANCE (PT): the
//! two are one estimator on the shared walk
//! ([`crate::multiple::microsurface`]), differing only in the depth state
//! (renormalised to `raw(0) = 1` after every step, so that `p_exit` is the
//! conditional exit probability given the directions so far). This one
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
use crate::desc::{Estimator, MaterialDesc};
use crate::facet::Facet;
use crate::frame::flip_z;
use crate::multiple::invariance::smith_conductor_walk_ndf;
use crate::multiple::invariance::{
    CAP_MAX, CAP_SMALL, TWO_WALKS_BELOW_ALPHA, default_max_bounces_for, eval_two_walks,
    sample_exact_exit, two_sided_hapke_pdf,
};
use crate::multiple::microsurface::{self, Microsurface};
use crate::ndf::Ndf;
use crate::rng::Rng;
use crate::status::Error;
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

/// The collision-depth density as the walk's depth state (see
/// [`microsurface::ExitTransform`]): `raw(s)` is the exit transform.
impl<const C: usize> microsurface::ExitTransform for HeightDistribution<C> {
    #[inline]
    fn start(l0: f64) -> Self {
        HeightDistribution::start(l0)
    }
    #[inline]
    fn push(&mut self, lambda: f64) {
        HeightDistribution::push(self, lambda)
    }
    #[inline]
    fn value(&self, s: f64) -> f64 {
        self.raw(s)
    }
    #[inline]
    fn scale(&mut self, f: f64) {
        for a in &mut self.a[..self.n] {
            *a *= f;
        }
    }
    #[inline]
    fn overflowed(&self) -> bool {
        self.overflow
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
    max_bounces: u32,
    ms: Microsurface,
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
            max_bounces,
            ms: Microsurface::new(ndf, facet, max_bounces),
        }
    }

    /// The bounce limit in use.
    pub fn max_bounces(&self) -> u32 {
        self.max_bounces
    }

    /// The PT estimator (supplement eq. 3) on the shared walk, `p_exit`
    /// as its state.
    fn eval_pt<const C: usize>(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        let ndf = &self.ms.ndf;
        let two = 0.5 * (ndf.alpha_x + ndf.alpha_y) < TWO_WALKS_BELOW_ALPHA;
        let walks = microsurface::STRATIFIED_WALKS;
        eval_two_walks::<HeightDistribution<C>>(&self.ms, wi, wo, two, walks, rng)
    }

    /// Draws `wo` from caller uniforms: `u[0]` chooses the lobe at the first
    /// vertex, `u[1], u[2]` the 2D sample of the first visible-normal draw;
    /// stochastic models take the rest from `rng`.
    pub fn sample_with(&self, wi: Vec3, u: [f32; 3], rng: &mut Rng) -> Sample {
        if (self.max_bounces as usize) < CAP_SMALL {
            sample_exact_exit::<HeightDistribution<CAP_SMALL>>(&self.ms, wi, u, rng)
        } else {
            sample_exact_exit::<HeightDistribution<CAP_MAX>>(&self.ms, wi, u, rng)
        }
    }
}

impl ScatterModel for BitterliDeon {
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
        let u = microsurface::first_uniforms(rng);
        self.sample_with(wi, u, rng)
    }

    fn sample_with(&self, wi: Vec3, u: [f32; 3], rng: &mut Rng) -> Sample {
        Self::sample_with(self, wi, u, rng)
    }

    fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        two_sided_hapke_pdf(&self.ms.ndf, wi, wo)
    }
}

impl BitterliDeon {
    /// BITTERLI_DEON for a validated description: what INVARIANCE supports
    /// (`invariance::smith_conductor_walk_ndf`), with the path-tracing
    /// estimator only (the paper has no bidirectional form).
    pub(crate) fn from_desc(d: &MaterialDesc, facet: Facet) -> Result<Self, Error> {
        let ndf = smith_conductor_walk_ndf(d, facet)?;
        if d.estimator != Estimator::Pt {
            return Err(Error::Unsupported);
        }
        Ok(BitterliDeon::new(ndf, facet, d.max_bounces))
    }
}
