//! `MSBSDF_MODEL_HEITZ_RANDOM_WALK`: the height random walk of Heitz, Hanika,
//! d'Eon and Dachsbacher 2016 ("Multiple-Scattering Microfacet BSDFs with the
//! Smith Model"), the unbiased reference every other model is judged against.
//!
//! The microsurface is a volume of facets whose heights follow a distribution
//! `C1(h)`; the walk tracks the height and direction of a ray scattering in
//! it (Cui et al. 2023, sec. 3.1 and Fig. 2: the path is `(h_0, d_0, h_1, d_1, ...)`).
//! The result does not depend on the height distribution; this file uses
//! the uniform one on `[-1, 1]` and stores the state as `ln C1(h)`. Every
//! formula below involves heights only through `C1(h)`, and the mirror
//! across a dielectric interface maps `C1 -> 1 - C1` for any distribution
//! symmetric about 0, so the walk draws the same sequence of `C1` values
//! for every continuous symmetric height distribution: the independence
//! is exact, not statistical. The formulas:
//!
//! - escape of an upward ray from height `h`: `G1(w, h) = C1(h)^Lambda(w)`;
//! - next hit: `C1(h') = C1(h) / (1 - U)^(1 / Lambda(w))` for both signs of
//!   `Lambda` (the full-sphere `Lambda(w) = -1 - Lambda(-w)` for `w.z < 0`,
//!   Wang et al. 2022, eqs. (8)-(9)); an upward ray that does not escape hits at the height
//!   this formula gives with `U` restricted to `[0, 1 - G1)`, never at the top;
//! - facet normal from the visible normals of the travel direction,
//!   `D_{-w}(m) = max(0, -w.m) D(m) / sigma(-w)`;
//! - facet scattering: conductor mirror with complex Fresnel per bounce,
//!   dielectric reflection with probability `F` else refraction (continuing
//!   on the other side with the height mirrored, `C1 -> 1 - C1`, and
//!   `eta -> 1 / eta`), or a Lambert lobe about `m` for diffuse facets.
//!
//! `eval` is next-event estimation at every vertex of the shared walk
//! ([`crate::multiple::microsurface::walk`]): the phase function towards `wo`
//! times the escape probability towards `wo` from the vertex height. For
//! conductor and dielectric facets, single scattering is added in closed
//! form (SINGLE with the height-correlated `G2`, which is what order 1 of
//! the walk estimates) and the walks estimate orders 2 and up: four from
//! `wi` and four from `wo`, each four with stratified first vertices
//! ([`microsurface::stratified_walks`], [`microsurface::STRATIFIED_WALKS`];
//! the walks from `wo` with the roles swapped, scaled by the generalised reciprocity
//! `f(wi, wo) / eta_o^2 = f(wo, wi) / eta_i^2`), combined by the balance
//! heuristic on the densities of their direction choices (the kernel's
//! default, [`DepthState::ln_entry_density`]; still unbiased, since the two
//! weights of every path sum to 1), so neither walk's heavy tail (the next
//! event through a peaked `D` of a facet the walk did not choose) reaches
//! the estimate. For diffuse facets the two walks (all orders) are averaged.
//!
//! `pdf` is the walks' approximation
//! ([`crate::multiple::microsurface::approximate_pdf`], as in Heitz et al.
//! 2016, sec. 4.3): the first vertex's visible-normal density with weight
//! `1 - q`, plus a cosine lobe with weight `q` ([`cosine_weight`] of the
//! mean of the two roughnesses). It is positive wherever `sample` can go.
//!
//! Bounce limit: `max_bounces = 0` selects [`default_max_bounces`], the
//! smallest limit whose truncated white-furnace energy is below 1e-3
//! (measurements in `docs/heitz_bounces.md`). A walk reaching one more
//! vertex than the limit is absorbed (weight 0).
//!
//! The walk keeps no path arrays: its whole state (direction, log height,
//! side, throughput) lives in a few registers.

use crate::bsdf::{Sample, ScatterModel, same_side};
use crate::desc::MAX_BOUNCES;
use crate::desc::MaterialDesc;
use crate::facet::Facet;
use crate::multiple::microsurface::{
    self, BounceRule, DepthState, Microsurface, Travel, WalkOptions, exp_m1_nonpositive,
    exp_nonpositive, ln_1p, ln_positive, log1mexp, open_uniform,
};
use crate::ndf::Ndf;
use crate::rng::Rng;
use crate::status::Error;
use glam::Vec3;

/// Default bounce limit for the given roughness and facets: keeps the
/// truncated energy of the white furnace below 0.1% (measured, see the module
/// docs), with `alpha = max(alpha_x, alpha_y)`:
///
/// - conductor facets: `max(10, ceil(5 alpha + 4))` (14 at alpha 2, 54 at 10);
/// - dielectric facets: `max(10, ceil(7.5 alpha + 6))` (21 at alpha 2);
/// - diffuse facets (Lambert lobes send light down into the surface, a long
///   tail): `max(10, ceil(16 alpha^1.4))` (16 at alpha 1, 43 at alpha 2);
///
/// all capped at [`MAX_BOUNCES`]. [`Heitz::new`] applies it to the roughness
/// scaled by the NDF's tail (`microsurface::heavy_tail_bounce_scale`: 1 for
/// Beckmann, GGX and Student-T with shape >= 2; e.g. 28 bounces instead of
/// 10 for Student-T shape 1.6 at alpha 1, whose furnace was 0.917).
pub fn default_max_bounces(alpha_x: f32, alpha_y: f32, facet: &Facet) -> u32 {
    bounces(facet).limit_at(alpha_x.max(alpha_y))
}

/// The bounce-limit rule of the HEITZ walk for the facets
/// ([`default_max_bounces`]).
pub fn bounces(facet: &Facet) -> BounceRule {
    let (slope, power, offset) = match facet {
        Facet::Conductor { .. } => (5.0, 1.0, 4.0),
        Facet::Dielectric { .. } => (7.5, 1.0, 6.0),
        Facet::Diffuse { .. } => (16.0, 1.4, 0.0),
    };
    BounceRule {
        steps: &[],
        slope,
        power,
        offset,
        beyond_floor: 10,
    }
}

/// Weight of the cosine lobe in [`Heitz`]'s pdf for the mean roughness
/// `alpha`: `a = clamp(alpha^2 / (0.5 + alpha^2), 0.02, 0.9)` for conductors
/// (close to the multiply scattered share of a GGX mirror at normal
/// incidence, measured 0.31 at alpha 0.5 and 0.69 at alpha 1), `a / 2` for
/// dielectrics (most light leaves after one event: 1.04 to 1.14 mean
/// vertices at alpha 0.5 to 1), 1 for diffuse facets.
pub fn cosine_weight(alpha: f32, facet: &Facet) -> f32 {
    let a = (alpha * alpha / (0.5 + alpha * alpha)).clamp(0.02, 0.9);
    match facet {
        Facet::Conductor { .. } => a,
        Facet::Dielectric { .. } => 0.5 * a,
        Facet::Diffuse { .. } => 1.0,
    }
}

/// Heitz et al. 2016's depth state: the height of the current vertex, held
/// as `ln C1(h)` of the uniform height distribution (the walk does not
/// depend on the distribution, see the module docs).
///
/// For MIS between the walks from `wi` and `wo` it keeps the kernel's
/// defaults: the balance heuristic on the direction densities alone. The
/// height densities of the path (entry `(1 + Lambda_i) x_1^Lambda_i`, hit
/// densities `|L| x^L y^(-L-1)` per segment, exit `(1 + Lambda_o)
/// x_k^Lambda_o`, with `x = C1(h)`) were used until this session; dropping
/// them lowered the variance of one eval by 1.06-2.1x (geometric mean over
/// the 8 pairs of `docs/efficiency.md`, GGX, F = 1, 2e5 evals per pair:
/// alpha 1 at theta_i 0 / 60 / 80 5.0 / 3.7 / 2.8e-3 to 3.7 / 3.1 /
/// 2.7e-3, alpha 0.5 at 0 / 60 2.6 / 2.7e-3 to 1.5 / 2.3e-3, alpha 0.3 at
/// 0 / 80 1.07e-3 / 2.3e-3 to 5.2e-4 / 2.1e-3), with no heavier tail (the
/// 10 largest of 2e5 evals carry at most 11% of the second moment, 14%
/// before, at alpha 0.3, theta_i 80).
#[derive(Clone, Copy, Debug)]
pub struct HeightState {
    /// `ln C1(h)`, `<= 0`; kept `>= -700` across refractions so that
    /// `0 * ln C1` never makes a NaN.
    lc: f64,
}

impl HeightState {
    /// `ln C1` of the current vertex.
    pub fn ln_c1(&self) -> f64 {
        self.lc
    }
}

impl DepthState for HeightState {
    #[inline]
    fn enter(lam0: f64, rng: &mut Rng) -> Self {
        let mut s = HeightState { lc: 0.0 };
        s.travel(lam0, rng);
        s
    }

    #[inline]
    fn exit(&self, lam_o: f64, crossed: bool) -> f64 {
        // G1(o, h) = C1(h)^Lambda(o), from the mirrored height after a
        // refraction (C1 -> 1 - C1).
        let lc = if crossed {
            log1mexp(self.lc).max(-700.0)
        } else {
            self.lc
        };
        // Inline exp and ln (microsurface::exp_nonpositive and friends):
        // the libm calls were a quarter of a walk's instructions.
        exp_nonpositive(lam_o * lc)
    }

    #[inline]
    fn travel(&mut self, lam: f64, rng: &mut Rng) -> Travel {
        let u = open_uniform(rng);
        if lam >= 0.0 {
            if lam.is_finite() {
                let escape = exp_nonpositive(lam * self.lc);
                if u < escape {
                    return Travel::Escape;
                }
                // Hit below the top: C1(h') = C1(h) / (1 - U')^(1 / Lambda)
                // with U' = u - escape uniform on [0, 1 - G1).
                self.lc = (self.lc - ln_positive(1.0 - u + escape) / lam).min(0.0);
            }
            // Lambda infinite (horizontal ray): hits where it is.
        } else if lam.is_finite() {
            // Downward: always hits, C1(h') = C1(h) (1 - U)^(1 / |Lambda|).
            self.lc += ln_positive(u) / (-lam);
        }
        Travel::Hit
    }

    #[inline]
    fn cross(&mut self) {
        self.lc = log1mexp(self.lc).max(-700.0);
    }

    #[inline]
    fn travel_forced(&mut self, lam: f64, rng: &mut Rng) -> Option<f64> {
        if !lam.is_finite() {
            return Some(1.0);
        }
        // Hit with probability 1 at a height drawn given a hit, weight 1 - G1.
        let u = open_uniform(rng);
        let p_hit = -exp_m1_nonpositive(lam * self.lc);
        if p_hit.is_nan() || p_hit <= 0.0 {
            return Some(0.0);
        }
        self.lc = (self.lc - ln_1p(-u * p_hit) / lam).min(0.0);
        Some(p_hit)
    }
}

/// The Heitz et al. 2016 height random walk over a Smith microsurface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Heitz {
    ms: Microsurface,
    /// Weight of the cosine lobe in `pdf`.
    q: f32,
    /// Single scattering in closed form (conductor and dielectric facets).
    closed_single: bool,
}

impl Heitz {
    /// A random walk over `ndf` with `facet`s; `max_bounces = 0` picks
    /// [`default_max_bounces`], larger values are capped at [`MAX_BOUNCES`].
    pub fn new(ndf: Ndf, facet: Facet, max_bounces: u32) -> Self {
        let max_bounces = if max_bounces == 0 {
            // Heavy-tailed NDFs (Student-T with shape below 2) keep light
            // longer: the roughness is scaled and the limit floored
            // (`microsurface::heavy_tail_bounce_scale`); Beckmann, GGX and
            // Student-T with shape >= 2 are unchanged.
            bounces(&facet).limit(&ndf)
        } else {
            max_bounces.min(MAX_BOUNCES)
        };
        let alpha = 0.5 * (ndf.alpha_x + ndf.alpha_y);
        let closed_single = !matches!(facet, Facet::Diffuse { .. });
        Heitz {
            ms: Microsurface::new(ndf, facet, max_bounces),
            q: cosine_weight(alpha, &facet),
            closed_single,
        }
    }

    /// The bounce limit in use (after resolving the default).
    pub fn max_bounces(&self) -> u32 {
        self.ms.max_bounces
    }

    /// The microsurface the walk runs over.
    pub fn microsurface(&self) -> &Microsurface {
        &self.ms
    }

    /// One walk from `wi` with next-event estimates towards `wo` per order
    /// (the reference generator's hook: forced collisions, MIS weights,
    /// order 1 on or off). Returns the vertices visited.
    pub fn walk_with<T: microsurface::Tally>(
        &self,
        wi: Vec3,
        wo: Vec3,
        rng: &mut Rng,
        opt: WalkOptions,
        tally: &mut T,
    ) -> u32 {
        microsurface::walk::<HeightState, T>(&self.ms, wi, wo, rng, opt, tally)
    }

    /// One unidirectional next-event estimate of `f(wi, wo) |wo.z|` (every
    /// order, no MIS).
    pub fn estimate(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        let mut f = Vec3::ZERO;
        self.walk_with(wi, wo, rng, WalkOptions::ANALOG, &mut f);
        f
    }

    /// Samples the walk and also reports how many vertices it visited
    /// (for statistics and tests).
    pub fn sample_with_bounces(&self, wi: Vec3, rng: &mut Rng) -> (Sample, u32) {
        let u = microsurface::first_uniforms(rng);
        self.sample_counted(wi, u, rng)
    }

    fn sample_counted(&self, wi: Vec3, u: [f32; 3], rng: &mut Rng) -> (Sample, u32) {
        match microsurface::sample_walk::<HeightState, _>(&self.ms, wi, u, rng, |_| {}) {
            Ok(e) if e.wo.z != 0.0 => {
                let pdf = self.pdf(wi, e.wo);
                (Sample::new(wi, e.wo, e.weight, pdf), e.bounces)
            }
            Ok(e) => (Sample::ABSORBED, e.bounces),
            Err(b) => (Sample::ABSORBED, b),
        }
    }

    /// Draws `wo` from caller uniforms: `u[0]` chooses the lobe at the first
    /// vertex, `u[1], u[2]` the 2D sample of the first visible-normal draw;
    /// stochastic models take the rest from `rng`.
    pub fn sample_with(&self, wi: Vec3, u: [f32; 3], rng: &mut Rng) -> Sample {
        self.sample_counted(wi, u, rng).0
    }
}

impl ScatterModel for Heitz {
    fn eval(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        if !same_side(wi, wo) && !self.ms.is_dielectric() {
            return Vec3::ZERO;
        }
        // f(wi, wo) |wo.z| = f(wo, wi) |wi.z| * (|wo.z| / |wi.z|) * eta_o^2 / eta_i^2.
        let scale = wo.z.abs() / wi.z.abs() * self.ms.reciprocity_factor(wi, wo);
        let v = match self.closed_single {
            true => {
                let opt = WalkOptions {
                    forced: 0,
                    mis: true,
                    order_one: false,
                    roulette: true,
                };
                // The pair's Lambdas serve single scattering and both walks.
                // Half the walks from each direction, stratified first
                // vertices (microsurface::STRATIFIED_WALKS).
                let pair = microsurface::Pair::new(&self.ms, wi, wo);
                let n = microsurface::STRATIFIED_WALKS.div_ceil(2);
                let fwd =
                    microsurface::stratified_walks::<HeightState>(&self.ms, &pair, n, rng, opt);
                let rev = pair.reversed();
                let bwd =
                    microsurface::stratified_walks::<HeightState>(&self.ms, &rev, n, rng, opt);
                self.ms.single_pair(&pair) + fwd + bwd * scale
            }
            false => {
                let forward = self.estimate(wi, wo, rng);
                let backward = self.estimate(wo, wi, rng);
                0.5 * (forward + backward * scale)
            }
        };
        if v.is_finite() {
            v.max(Vec3::ZERO)
        } else {
            Vec3::ZERO
        }
    }

    fn sample(&self, wi: Vec3, rng: &mut Rng) -> Sample {
        self.sample_with_bounces(wi, rng).0
    }

    fn sample_with(&self, wi: Vec3, u: [f32; 3], rng: &mut Rng) -> Sample {
        Self::sample_with(self, wi, u, rng)
    }

    fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        microsurface::approximate_pdf(&self.ms, self.q, wi, wo)
    }
}

impl Heitz {
    /// HEITZ_RANDOM_WALK for a validated description: Smith NDFs and every
    /// facet (conductor, dielectric, diffuse).
    pub(crate) fn from_desc(d: &MaterialDesc, facet: Facet) -> Result<Self, Error> {
        Ok(Heitz::new(d.smith_ndf()?, facet, d.max_bounces))
    }
}
