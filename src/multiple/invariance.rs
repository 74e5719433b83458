//! `MSBSDF_MODEL_INVARIANCE`: multiple-bounce Smith microfacet BRDF from the
//! invariance principle (Cui et al. 2023, Cui et al. 2023), conductor facets.
//!
//! A path is a list of directions `d_0 = -wi, d_1, ..., d_k = wo` (Cui et al. 2023,
//! sec. 3.1); its contribution is the product of the position-free vertex
//! terms `v(d_i, d_{i+1}) = F D(h) / (4 |d_i.z|)` (Cui et al. 2023, eq. 2) and one
//! segment term `S_k(d_0, ..., d_k)` for the whole path (eq. 3). `S_k` is the
//! height-free transmittance of the path in the equivalent semi-infinite
//! medium whose collision rate per unit optical depth along `d` is
//! `|Lambda(d)|`:
//! `S_k = integral over the collision depths of exp(-sum_i Lambda(d_i) (tau_i - tau_{i+1})) exp(-Lambda(d_k) tau_k)`,
//! and `p_exit = prod |Lambda(d_i)| S_k` (supplement eq. 7).
//!
//! # What differs from the paper, and why
//! - **Eq. (14) and the paths it covers.** Its derivation keeps the cases
//!   where the thin top layer holds the first or the last collision. A path
//!   that turns from up to down (`... up, down ...`) could also have an
//!   *inner* collision in the layer (Ambartsumian's quadratic term
//!   `S(d_0..d_{c-1}) S(d_c..d_k)`), and literal eq. (14) gives `S = 0` for
//!   it. For conductor facets this never matters: an upward ray hits a facet
//!   with `m.z > 0` from below and leaves with
//!   `o.z = d.z + 2 |d.m| m.z > d.z`, so every path with a non-zero vertex
//!   product is `down* up*`, where eq. (14) is exact (the example
//!   `invariance_eq14` measures identical furnace albedos). The segment
//!   term below is exact for any sequence, so it would also serve paths that
//!   do turn (transmission, diffuse facets).
//! - **The O(k) programme (supplement Alg. 1/4)** is written in an
//!   equivalent form ([`SegmentTerm`]) with the same cost and the same
//!   freedom from singularities: the Laplace transform `R(s)` of the
//!   collision-depth density is held as a non-negative combination of suffix
//!   products `prod_{j >= m} 1 / (l_j + s)` over the downward directions'
//!   `l_j = |Lambda|`. A downward direction appends a factor (O(1)); an
//!   upward one with `Lambda = lambda` is the divided difference
//!   `(R(s) - R(lambda)) / (lambda - s)`, which the Leibniz rule maps back to
//!   suffix products with positive coefficients (O(N)); `S = R(Lambda(wo))`
//!   (O(N)). Every denominator is a sum `l_j + lambda >= 1`: no difference
//!   of two Lambdas, unlike the hyperexponential form of Bitterli and
//!   d'Eon. It equals `p_exit / prod |Lambda|` of
//!   [`crate::multiple::bitterli_deon`] to 1e-6 on random sequences (tests).
//! - **The walk** is the shared microsurface walk
//!   ([`crate::multiple::microsurface`]) with the segment term as its depth
//!   state, renormalised to `R(0) = 1` after every step: `R(s)` is then the
//!   exact conditional probability of leaving along a direction with
//!   `Lambda = s` given the directions so far. **Sample** follows Alg. 2
//!   (VNDF at each bounce, exit on upward directions) but exits with that
//!   probability instead of `G1`: the walk has the distribution of Heitz et
//!   al.'s height walk and its weight is the product of the Fresnel factors
//!   (exactly 1 in the white furnace), instead of `S_k / prod G1`.
//! - **Eval** (PT, Alg. 3) adds single scattering in closed form (the
//!   height-correlated SINGLE term, which order 1 of the segment term is),
//!   forces every upward segment to collide (weight the hit probability)
//!   and goes on past the vertex it reaches by Russian roulette with that
//!   probability after the vertex's next event (Alg. 3's Russian roulette,
//!   delayed by one vertex, from the first vertex on), with 8 walks whose
//!   first vertices are stratified. Below a mean
//!   roughness of 0.75 it runs half from `wi` and half from `wo`, weighted
//!   by the balance heuristic on their direction densities (unbiased for
//!   any weights that sum to 1; measured in `docs/efficiency.md`).
//! - **Hapke lobe** (eq. 15): `H(mu) = (1 + 2 mu) / (1 + 2 mu sqrt(1 - a))`
//!   (Hapke 1981; the extraction of the paper reads `sqrt(1 - a mu)`, which
//!   makes `H < 1` and the lobe negative), `a = min((alpha_x + alpha_y)/2, 1)`.
//!   The mixture of eq. (16) is divided by `1 + M(mu_i)`, `M` the lobe's
//!   integral (8-point Gauss-Legendre), so that `pdf` integrates to at most 1.
//!
//! `max_bounces` default: see [`default_max_bounces`] and, for heavy-tailed
//! NDFs (Student-T with shape below 2), [`default_max_bounces_for`].
//!
//! # Cost and variance
//! Measured by `examples/efficiency.rs` (instructions, variance and
//! efficiency per eval against HEITZ_RANDOM_WALK, GGX with F = 1) in
//! `docs/efficiency.md`. BDPT does not pay on it (0.6-2.7x HEITZ at
//! 9f91b5f against 2.3-15x for PT): its sub-paths are direction sequences
//! drawn from the phase functions alone, unaware of the segment term, so
//! both are sampled to the full bounce limit (18 scatterings per eval at
//! 10 bounces) and every one of the ~50 connections pays an O(t N) segment
//! term (16-19k instructions per eval against 2.0-3.5k for one PT walk),
//! for a variance per eval at most equal to that of PT with one walk per
//! direction at alpha 0.3 and 0.5 (where PT's two MIS walks are BDPT's two
//! end strategies) and 1.7x below it at alpha 1; PT with 8 stratified
//! walks (the default) has 8-12x less variance than BDPT at theta_i 60
//! (alpha 0.5 and 1) for 0.7-0.8x its instructions.
//! Russian roulette on the sub-paths past their first direction (survival
//! 0.5) cut `variance x instructions` 3.1x at alpha 0.5 and 2.3x at 1, still
//! 1.6x behind PT, and raised the variance per eval above PT's, which the
//! tests forbid (`bdpt_has_lower_variance_than_pt`, and a 2% standard error
//! with 2000 evals at alpha 3): not kept.

//! # Student-T (d'Eon 2023)
//! Beckmann, GGX and Student-T are accepted. Nothing here (nor in
//! [`crate::multiple::bitterli_deon`]) depends on the distribution beyond
//! the generic [`Ndf`] API: full-sphere `Lambda`, `D`, `sigma` and visible
//! normals seen from either hemisphere (Student-T's exact up-welling
//! sampler). The one NDF-dependent choice is the default bounce limit:
//! shapes below 2 keep light longer than GGX (10 bounces lose 9% at shape
//! 1.6, alpha 1), so [`default_max_bounces_for`] scales the roughness by
//! the tail ([`heavy_tail_bounce_scale`]). Where that limit exceeds
//! [`MAX_DEFAULT_BOUNCES`] (80: heavy tails with large roughness, e.g.
//! shape 1.6 from alpha 3.3 on, shape 1.51 from alpha 0.14) the material is
//! refused: on such walks the f64 arithmetic of both this model and
//! BITTERLI_DEON breaks down (measurements there). POSITION_FREE and
//! HEITZ_RANDOM_WALK take them. Measured (`tests/invariance.rs`,
//! shapes 1.8, 3, 20, alpha 0.3 and 1, theta_i 0, 60 and 89 degrees, white
//! mirror facets): sample albedo 1 minus at most 0.00045 (shape 1.8, alpha
//! 1, normal incidence; 20k walks); the integral of eval within 2.6
//! standard errors of 1 for PT, BDPT and BITTERLI_DEON (standard errors
//! 0.001 to 0.023); one bounce equals SINGLE (height-correlated G2) to
//! 3e-7 relative; against HEITZ_RANDOM_WALK on gold over 30 (material,
//! wi, wo) pairs the largest deviations are 3.2 (PT), 2.6 (BDPT) and 3.3
//! (BITTERLI_DEON) combined standard errors, at theta_i 89 degrees where
//! the HEITZ estimate is the noisier (heavy-tailed) one; in three reruns
//! with other seeds at most 2.6.
//!
//! Cost and variance per eval of the walks (GGX, F = 1): `docs/efficiency.md`,
//! written by `examples/efficiency.rs`.
//!
//! Student-T costs 6-18 times GGX (BDPT the most: it also needs `sigma`
//! twice per vertex): every bounce evaluates its `Lambda`
//! (an incomplete beta function) and samples a visible normal by gamma
//! superposition (0.7-0.9 us, more for large shapes seen from below, whose
//! rejection rate grows with the shape). Near Beckmann (shape 20 and up)
//! the Beckmann NDF gives nearly the same surface at a quarter of the cost.

use crate::bsdf::{Sample, ScatterModel};
use crate::desc::MaterialDesc;
use crate::desc::{Estimator, MAX_BOUNCES};
use crate::facet::Facet;
use crate::frame::flip_z;
use crate::multiple::microsurface::{self, BounceRule, DepthState, Microsurface, WalkOptions};
use crate::ndf::Ndf;
use crate::rng::Rng;
use crate::status::Error;
use glam::{DVec3, Vec3};

/// Capacity of the path arrays for any `max_bounces` (directions = bounces + 1).
pub(crate) const CAP_MAX: usize = MAX_BOUNCES as usize + 1;
/// Capacity used when `max_bounces < CAP_SMALL` (keeps the stack arrays small).
pub(crate) const CAP_SMALL: usize = 24;

/// The segment term of a growing path (Cui et al. 2023, eq. 14; exact for any
/// sequence of directions, see the module docs), in O(N) per upward bounce,
/// O(1) per downward bounce and O(N) per query, N the number of downward
/// directions so far, on fixed-size stack arrays of capacity `C`.
///
/// After `start(l_0)` and `push` of `d_1..d_n`, [`SegmentTerm::value`]`(Lambda(o))`
/// is `S(d_0, ..., d_n, o)` for any exit direction `o` with `Lambda(o) >= 0`,
/// and `value(0)` is the probability of reaching collision `n + 1` divided
/// by `prod_{i <= n} |Lambda(d_i)|`.
#[derive(Clone, Copy, Debug)]
pub struct SegmentTerm<const C: usize> {
    n: usize,
    l: [f64; C],
    c: [f64; C],
    /// Set when a push did not fit (more than `C` downward directions).
    overflow: bool,
}

impl<const C: usize> Default for SegmentTerm<C> {
    fn default() -> Self {
        SegmentTerm {
            n: 0,
            l: [0.0; C],
            c: [0.0; C],
            overflow: false,
        }
    }
}

impl<const C: usize> SegmentTerm<C> {
    /// A path entering along `d_0` with `l0 = |Lambda(d_0)| >= 1`:
    /// `R(s) = 1 / (l0 + s)`.
    #[inline]
    pub fn start(l0: f64) -> Self {
        let mut t = Self::default();
        t.reset(l0);
        t
    }

    /// Restarts as [`SegmentTerm::start`] without clearing the arrays.
    #[inline]
    pub fn reset(&mut self, l0: f64) {
        self.n = 1;
        self.l[0] = l0;
        self.c[0] = 1.0;
        self.overflow = false;
    }

    /// Copies the state of `o` (only the used entries).
    #[inline]
    pub fn copy_from(&mut self, o: &Self) {
        self.n = o.n;
        self.overflow = o.overflow;
        self.l[..o.n].copy_from_slice(&o.l[..o.n]);
        self.c[..o.n].copy_from_slice(&o.c[..o.n]);
    }

    /// Appends the travel direction `d` given its full-sphere `Lambda(d)`
    /// (negative, `<= -1`, for downward directions).
    #[inline]
    pub fn push(&mut self, lambda: f64) {
        if lambda < 0.0 {
            // Downward: R(s) <- R(s) / (l + s); a new suffix with coefficient 0.
            if self.n >= C {
                self.overflow = true;
                return;
            }
            self.l[self.n] = -lambda;
            self.c[self.n] = 0.0;
            self.n += 1;
        } else {
            // Upward: R(s) <- (R(s) - R(lambda)) / (lambda - s), by the
            // Leibniz rule c'_i = sum_{m <= i} c_m prod_{j=m..i} 1 / (l_j + lambda).
            let mut t = 0.0;
            for i in 0..self.n {
                t = (t + self.c[i]) / (self.l[i] + lambda);
                self.c[i] = t;
            }
        }
    }

    /// `R(s) = sum_m c_m prod_{j >= m} 1 / (l_j + s)` for `s >= 0`: the
    /// segment term of the path closed by an exit direction with `Lambda = s`.
    #[inline]
    pub fn value(&self, s: f64) -> f64 {
        if self.overflow {
            return 0.0;
        }
        let mut u = 0.0;
        for i in 0..self.n {
            u = (u + self.c[i]) / (self.l[i] + s);
        }
        u
    }
}

/// The segment term as the walk's depth state (Cui et al. 2023, eq. (14);
/// see [`microsurface::ExitTransform`]).
impl<const C: usize> microsurface::ExitTransform for SegmentTerm<C> {
    #[inline]
    fn start(l0: f64) -> Self {
        SegmentTerm::start(l0)
    }
    #[inline]
    fn push(&mut self, lambda: f64) {
        SegmentTerm::push(self, lambda)
    }
    #[inline]
    fn value(&self, s: f64) -> f64 {
        SegmentTerm::value(self, s)
    }
    #[inline]
    fn scale(&mut self, f: f64) {
        for c in &mut self.c[..self.n] {
            *c *= f;
        }
    }
    #[inline]
    fn overflowed(&self) -> bool {
        self.overflow
    }

    /// [`microsurface::ExitTransform::push_normalized`] in one pass for an
    /// upward direction (the Leibniz update and `R(0)` together) and
    /// without `R(0)` for a downward one (`R(0) = 1` before, so it is
    /// `1 / l` after): the same arithmetic as push, value and scale up to
    /// rounding, a third of the loops.
    #[inline]
    fn push_normalized(&mut self, lambda: f64) -> microsurface::Travel {
        use microsurface::Travel;
        let lambda = lambda.max(-f64::MAX);
        let r0 = if lambda < 0.0 {
            if self.n >= C {
                self.overflow = true;
                return Travel::Lost;
            }
            let l = -lambda;
            self.l[self.n] = l;
            self.c[self.n] = 0.0;
            self.n += 1;
            1.0 / l
        } else {
            let (mut t, mut u) = (0.0, 0.0);
            for i in 0..self.n {
                t = (t + self.c[i]) / (self.l[i] + lambda);
                self.c[i] = t;
                u = (u + t) / self.l[i];
            }
            u
        };
        if self.overflow || !(r0 > 0.0 && r0.is_finite()) {
            return Travel::Lost;
        }
        let f = 1.0 / r0;
        for c in &mut self.c[..self.n] {
            *c *= f;
        }
        Travel::Hit
    }
}

/// The walk options of the PT estimators of INVARIANCE and BITTERLI_DEON:
/// every upward segment is forced to collide (weight the hit probability)
/// and the walk goes on past the vertex it reaches by Russian roulette with
/// that probability, after that vertex's next event (Alg. 3's Russian
/// roulette, delayed by one vertex). At low roughness most walks escape
/// after one reflection, and the rare second collision would otherwise
/// carry the whole multiple-scattering estimate; measured against forcing
/// the first two segments without roulette (`efficiency orders`, GGX, F = 1,
/// theta_i 60): the same variance per order at alpha 0.3, 0.5 and 1, with
/// 2.2 / 2.4 / 2.9 vertices per walk instead of 3.0 / 3.0 / 3.1.
const PT_OPTIONS: WalkOptions = WalkOptions {
    forced: 0,
    mis: false,
    order_one: false,
    roulette: true,
};

/// Mean roughness below which the PT estimators of INVARIANCE and
/// BITTERLI_DEON run their walks from `wi` and from `wo` weighted by MIS on
/// their direction densities, and from which they run them all from `wi`.
///
/// Measured with [`PT_OPTIONS`] and [`microsurface::STRATIFIED_WALKS`] = 8
/// walks per eval (`examples/efficiency.rs`, GGX, F = 1, theta_i 60,
/// efficiency against HEITZ at 9f91b5f): both directions 8.19x at alpha 0.5
/// and 7.52x at alpha 1, 8 walks from `wi` 3.86x and 9.58x (at alpha 1,
/// theta_i 0: 16.5x both, 14.5x from `wi`). The paper's
/// one-walk PT stays available ([`Invariance::with_one_walk`]) for the
/// comparison of BDPT with it.
pub(crate) const TWO_WALKS_BELOW_ALPHA: f32 = 0.75;

/// The PT estimate with the depth state `S`: single scattering in closed
/// form plus, with `two_walks`, the MIS-weighted walks from `wi` and from
/// `wo` (the latter scaled by reciprocity, `f(wi, wo) |wo.z| = f(wo, wi)
/// |wi.z| |wo.z| / |wi.z|`), else the walks from `wi`; `walks` walks in
/// all (half per direction with `two_walks`), with stratified first
/// vertices ([`microsurface::stratified_walks`]); options [`PT_OPTIONS`].
pub(crate) fn eval_two_walks<S: DepthState>(
    ms: &Microsurface,
    wi: Vec3,
    wo: Vec3,
    two_walks: bool,
    walks: u32,
    rng: &mut Rng,
) -> Vec3 {
    let opt = WalkOptions {
        mis: two_walks,
        ..PT_OPTIONS
    };
    // The pair's Lambdas serve single scattering and both walks.
    let pair = microsurface::Pair::new(ms, wi, wo);
    let per_direction = if two_walks { walks.div_ceil(2) } else { walks };
    let mut f = microsurface::stratified_walks::<S>(ms, &pair, per_direction, rng, opt);
    if two_walks {
        let rev = pair.reversed();
        let bwd = microsurface::stratified_walks::<S>(ms, &rev, per_direction, rng, opt);
        f += bwd * (wo.z / wi.z);
    }
    let v = ms.single_pair(&pair) + f;
    if v.is_finite() {
        v.max(Vec3::ZERO)
    } else {
        Vec3::ZERO
    }
}

/// The signed full-sphere `Lambda(d)` of a travel direction (finite).
#[inline]
pub(crate) fn lambda_signed(ndf: &Ndf, d: Vec3) -> f64 {
    let l = ndf.lambda(d) as f64;
    if l.is_finite() {
        l
    } else if l < 0.0 {
        // A downward direction so close to the horizon that Lambda overflows.
        -f64::MAX
    } else {
        f64::MAX
    }
}

/// Largest sub-path throughput the BDPT estimator keeps (f64). The
/// throughputs grow like `prod |Lambda|` while the segment term shrinks
/// like its inverse; with Student-T shapes near 1.5 (`Lambda` about
/// `1 / (2 gamma - 3)` times GGX's) and the long bounce limits they need,
/// a sub-path of 100+ bounces can leave the f64 range, and one `inf * 0`
/// made the whole estimate 0 (measured: shape 1.5001, alpha 10, 256
/// bounces: every eval 0; with the cut, 9.1e-6, BITTERLI_DEON 6.4e-6).
/// Such a sub-path is cut where it leaves the range, and a connection whose
/// contribution is not finite is skipped (both drop only paths of
/// unmeasurably small energy).
const MAX_THROUGHPUT: f64 = 1e250;

/// True when every channel of a throughput is finite and at most
/// [`MAX_THROUGHPUT`].
#[inline]
fn within_range(t: DVec3) -> bool {
    let m = t.max_element();
    m.is_finite() && m <= MAX_THROUGHPUT
}

/// One scattering event of a ray travelling along `d`: a visible normal of
/// `D_{-d}` and the mirror direction. Returns the new direction and the
/// Fresnel factor (the VNDF sampling weight of the phase function).
#[inline]
pub(crate) fn scatter(ms: &Microsurface, d: Vec3, rng: &mut Rng) -> Option<(Vec3, Vec3)> {
    let v = -d;
    let m = ms.ndf.sample_visible(v, rng.next_f32(), rng.next_f32());
    let c = v.dot(m);
    if c <= 0.0 {
        return None;
    }
    let o = (2.0 * c * m - v).normalize_or_zero();
    if o.z == 0.0 || o == Vec3::ZERO || !o.is_finite() {
        return None;
    }
    Some((o, ms.fresnel(c)))
}

/// Position-free vertex term `v(d, o) = F D(h) / (4 |d.z|)`, `h` the half
/// vector of the travel direction `d` and the outgoing `o` (Cui et al. 2023, eq. 2),
/// and `D(h)` alone (for MIS).
#[inline]
pub(crate) fn vertex(ms: &Microsurface, d: Vec3, o: Vec3) -> (Vec3, f32) {
    let h = (o - d).normalize_or_zero();
    let c = -d.dot(h);
    if c <= 0.0 || h.z <= 0.0 || d.z == 0.0 {
        return (Vec3::ZERO, 0.0);
    }
    let dm = ms.ndf.d(h);
    (ms.fresnel(c) * (dm / (4.0 * d.z.abs())), dm)
}

/// The default bounce limit for a roughness: 10 (the choice of Wang et al. 2022 and Cui et al. 2023)
/// while the energy of longer paths stays below 0.1% at every incidence up to
/// 89 degrees, `ceil(5 alpha + 5)` beyond (`alpha` the larger of the two).
/// Measured with the exact-exit walk in the white furnace (fraction of
/// 400k walks still inside after K bounces, worst of theta_i = 0, 30, 60, 80,
/// 89; GGX, Beckmann loses less: 0 of 400k at alpha 2, K 10):
///
/// | GGX alpha | K = 10 | K = 12 | K = 14 | K = 16 | K = 20 | K = 30 | K = 50 |
/// |---|---|---|---|---|---|---|---|
/// | <= 1.0 | 0.001% | | | | | | |
/// | 1.5 | 0.055% | 0.004% | | | | | |
/// | 1.7 | 0.19% | 0.017% | 0.001% | | | | |
/// | 2.0 | 0.76% | 0.10% | 0.011% | 0.001% | | | |
/// | 3.0 | 11% | 3.6% | 0.90% | 0.18% | 0.003% | | |
/// | 5.0 | 61% | 44% | 28% | 15% | 2.8% | 0.003% | |
/// | 10.0 | 97% | 96% | 93% | 90% | 78% | 27% | 0.017% |
pub fn default_max_bounces(alpha_x: f32, alpha_y: f32) -> u32 {
    BOUNCES.limit_at(alpha_x.max(alpha_y))
}

/// The bounce-limit rule of INVARIANCE and BITTERLI_DEON
/// ([`default_max_bounces`]).
pub const BOUNCES: BounceRule = BounceRule {
    steps: &[(1.5, 10)],
    slope: 5.0,
    power: 1.0,
    offset: 5.0,
    beyond_floor: 10,
};

pub use crate::multiple::microsurface::heavy_tail_bounce_scale;

/// Largest default bounce limit ([`default_max_bounces_for`]) for which
/// INVARIANCE and BITTERLI_DEON accept an NDF: Student-T with a heavy tail
/// and a large roughness is refused beyond it (`Error::Unsupported`).
/// On such long walks `prod |Lambda|` and the segment term leave the f64
/// range separately (INVARIANCE), and the partial fractions of `p_exit`
/// lose their precision (BITTERLI_DEON), so the two, which agree sample by
/// sample elsewhere, part ways. Measured (10k to 40k evals, gold wi 30
/// degrees; default limit in brackets): shape 1.51, alpha 0.3 (171):
/// INVARIANCE 0.294 +- 0.003 against BITTERLI_DEON 0.331 +- 0.008 on the
/// same random numbers; shape 1.55, alpha 10 (256): 0.31 against 0.005;
/// shape 1.6, alpha 10 (238): 0.53 against 0.05; shape 1.7, alpha 10
/// (113): 0.51 against 0.41. Where they agree: shape 1.55, alpha 0.3 (22):
/// 0.6162 / 0.6160; shape 1.6, alpha 3 (75): 0.362 / 0.369; shape 1.7,
/// alpha 3 (38) and 1.8, alpha 3 (28) within 1 sigma; GGX alpha 10 (55):
/// 0.528 / 0.526. POSITION_FREE, whose path weights are probabilities,
/// has no such limit.
pub const MAX_DEFAULT_BOUNCES: u32 = 80;

/// [`default_max_bounces`] for an NDF: the roughness scaled and the limit
/// floored by [`heavy_tail_bounce_scale`] (the same as
/// `default_max_bounces(alpha_x, alpha_y)` for Beckmann, GGX and Student-T
/// with `gamma >= 2`).
pub fn default_max_bounces_for(ndf: &Ndf) -> u32 {
    BOUNCES.limit(ndf)
}

/// [`hapke_pdf`] for a two-sided conductor: `wi` below mirrors both
/// directions; transmission has density 0.
pub(crate) fn two_sided_hapke_pdf(ndf: &Ndf, wi: Vec3, wo: Vec3) -> f32 {
    let (wi, wo) = if wi.z < 0.0 {
        (flip_z(wi), flip_z(wo))
    } else {
        (wi, wo)
    };
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    hapke_pdf(ndf, wi, wo)
}

/// Hapke-based pdf of Cui et al. 2023, eqs. (15)-(16), for `wi.z > 0`, `wo.z > 0`,
/// normalised as described in the module docs.
pub(crate) fn hapke_pdf(ndf: &Ndf, wi: Vec3, wo: Vec3) -> f32 {
    let h = (wi + wo).normalize_or_zero();
    let ci = wi.dot(h);
    let single = if ci > 0.0 {
        ndf.d_visible(wi, h) / (4.0 * ci)
    } else {
        0.0
    };
    let a = (0.5 * (ndf.alpha_x + ndf.alpha_y)).clamp(1e-4, 1.0) as f64;
    let g = (1.0 - a).sqrt();
    let hh = |mu: f64| (1.0 + 2.0 * mu) / (1.0 + 2.0 * mu * g);
    let (mi, mo) = (wi.z as f64, wo.z as f64);
    let hi = hh(mi);
    let lobe = |mu: f64| a / (4.0 * std::f64::consts::PI) * (hi * hh(mu) - 1.0) / (mi + mu);
    // M = integral over the hemisphere = 2 pi integral_0^1 lobe(mu) dmu (Gauss-Legendre 8).
    const X: [f64; 4] = [
        0.183_434_642_5,
        0.525_532_409_9,
        0.796_666_477_4,
        0.960_289_856_5,
    ];
    const W: [f64; 4] = [
        0.362_683_783_4,
        0.313_706_645_9,
        0.222_381_034_5,
        0.101_228_536_3,
    ];
    let mut m = 0.0;
    for (x, w) in X.iter().zip(W.iter()) {
        m += w * (lobe(0.5 + 0.5 * x) + lobe(0.5 - 0.5 * x));
    }
    m *= 0.5 * 2.0 * std::f64::consts::PI;
    let p = (single as f64 + lobe(mo)) / (1.0 + m);
    if p.is_finite() && p > 0.0 {
        p as f32
    } else {
        0.0
    }
}

/// The invariance-principle BRDF (conductor facets).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Invariance {
    ndf: Ndf,
    facet: Facet,
    estimator: Estimator,
    max_bounces: u32,
    ms: Microsurface,
    /// PT runs walks from `wi` and `wo` (else from `wi`).
    two_walks: bool,
    /// PT's walks per eval (stratified first vertices), split over the
    /// directions.
    walks: u32,
}

impl Invariance {
    /// A model with the given NDF, conductor facet, estimator and bounce
    /// limit (0: [`default_max_bounces_for`]; at most [`MAX_BOUNCES`]).
    pub fn new(ndf: Ndf, facet: Facet, estimator: Estimator, max_bounces: u32) -> Self {
        let max_bounces = if max_bounces == 0 {
            default_max_bounces_for(&ndf)
        } else {
            max_bounces.min(MAX_BOUNCES)
        };
        Invariance {
            ndf,
            facet,
            estimator,
            max_bounces,
            ms: Microsurface::new(ndf, facet, max_bounces),
            two_walks: 0.5 * (ndf.alpha_x + ndf.alpha_y) < TWO_WALKS_BELOW_ALPHA,
            walks: microsurface::STRATIFIED_WALKS,
        }
    }

    /// The model with the paper's PT estimator (Cui et al. 2023, Alg. 3):
    /// one walk from `wi` at every roughness, where the default runs
    /// [`microsurface::STRATIFIED_WALKS`] walks with stratified first
    /// vertices, half from `wi` and half from `wo` (MIS-weighted) below a
    /// mean roughness of 0.75. The same expectation with more variance (8x
    /// at alpha 1) at a lower cost per eval; for comparisons with the paper's
    /// estimators, e.g. that its BDPT has the lower variance
    /// (`tests/invariance.rs`).
    pub fn with_one_walk(self) -> Self {
        Invariance {
            two_walks: false,
            walks: 1,
            ..self
        }
    }

    /// The bounce limit in use.
    pub fn max_bounces(&self) -> u32 {
        self.max_bounces
    }

    /// Unidirectional estimator with next-event estimation (Cui et al.
    /// 2023, Alg. 3) on the shared walk, the segment term as its state.
    fn eval_pt<const C: usize>(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        eval_two_walks::<SegmentTerm<C>>(&self.ms, wi, wo, self.two_walks, self.walks, rng)
    }

    /// Draws `wo` from caller uniforms: `u[0]` chooses the lobe at the first
    /// vertex, `u[1], u[2]` the 2D sample of the first visible-normal draw;
    /// stochastic models take the rest from `rng`.
    pub fn sample_with(&self, wi: Vec3, u: [f32; 3], rng: &mut Rng) -> Sample {
        if (self.max_bounces as usize) < CAP_SMALL {
            sample_exact_exit::<SegmentTerm<CAP_SMALL>>(&self.ms, wi, u, rng)
        } else {
            sample_exact_exit::<SegmentTerm<CAP_MAX>>(&self.ms, wi, u, rng)
        }
    }

    /// Bidirectional estimator (Wang et al. 2022, sec. 4.2, eqs. 14-16) with `S_k`
    /// as the segment term: a camera sub-path from `-wi` and a light
    /// sub-path from `-wo`, every connection of `s` camera and `t` light
    /// directions with `s + t - 1 <= max_bounces` bounces, balance heuristic.
    ///
    /// For the path `z_0..z_k`, strategy `s'` samples the forward edges
    /// `i < s' - 1` with pdf `D_i / (4 sigma(-z_i))` and the reverse edges
    /// `i >= s'` with pdf `D_i / (4 sigma(z_{i+1}))` (the VNDF reflection
    /// pdf). The balance-heuristic denominator `sum_{s'} p_{s'} / p_s` is
    /// `1 + rev_conn C_s + fwd_conn L_t` with per-sub-path sums `C_s`, `L_t`
    /// built once by recurrences, so each connection costs O(1) for MIS and
    /// O(t N) for the segment term. Both sub-paths are sampled to full
    /// length, so every strategy is available.
    fn eval_bdpt<const C: usize>(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        let kmax = self.max_bounces as usize;
        let ndf = &self.ndf;
        // Camera sub-path x_0 = -wi, ...; light sub-path y_0 = -wo, ...
        let mut x = [Vec3::ZERO; C];
        let mut y = [Vec3::ZERO; C];
        // Throughput ratios (f / pdf of the sampled part) per prefix length.
        let mut thr_c = [DVec3::ZERO; C];
        let mut thr_l = [DVec3::ZERO; C];
        // Signed Lambda(x_i) and Lambda(-y_j) for the segment term.
        let mut lam_x = [0.0f64; C];
        let mut lam_y = [0.0f64; C];
        // sigma(-x_i) and sigma(-y_j): projected areas seen by the rays.
        let mut sig_x = [0.0f64; C];
        let mut sig_y = [0.0f64; C];
        // MIS partial sums C_s and L_t (see above).
        let mut mis_c = [0.0f64; C];
        let mut mis_l = [0.0f64; C];
        let n = kmax.min(C - 1);
        x[0] = -wi;
        y[0] = -wo;
        thr_c[1] = DVec3::ONE;
        thr_l[1] = DVec3::ONE;
        lam_x[0] = lambda_signed(ndf, x[0]);
        lam_y[0] = lambda_signed(ndf, -y[0]);
        sig_x[0] = ndf.sigma(wi) as f64;
        sig_y[0] = ndf.sigma(wo) as f64;
        let mut nc = 1;
        while nc < n {
            let d = x[nc - 1];
            let Some((o, fr)) = scatter(&self.ms, d, rng) else {
                break;
            };
            x[nc] = o;
            lam_x[nc] = lambda_signed(ndf, o);
            sig_x[nc] = ndf.sigma(-o) as f64;
            let dm = ndf.d((o - d).normalize_or_zero()) as f64;
            // C_{s+1} = (1 + pr(s-1) C_s) / pc(s-1), pc = D / sigma(-x_{s-1}),
            // pr = D / sigma(x_s) (the reverse pdf of the same edge).
            let pc = dm / sig_x[nc - 1].max(1e-30);
            let pr = dm / (ndf.sigma(o) as f64).max(1e-30);
            mis_c[nc + 1] = if pc > 0.0 {
                (1.0 + pr * mis_c[nc]) / pc
            } else {
                0.0
            };
            thr_c[nc + 1] = thr_c[nc] * fr.as_dvec3() * lam_x[nc - 1].abs();
            if !within_range(thr_c[nc + 1]) {
                break;
            }
            nc += 1;
        }
        let mut nl = 1;
        while nl < n {
            let d = y[nl - 1];
            let Some((o, fr)) = scatter(&self.ms, d, rng) else {
                break;
            };
            y[nl] = o;
            lam_y[nl] = lambda_signed(ndf, -o);
            sig_y[nl] = ndf.sigma(-o) as f64;
            let dm = ndf.d((o - d).normalize_or_zero()) as f64;
            let pl = dm / sig_y[nl - 1].max(1e-30);
            let pr = dm / (ndf.sigma(o) as f64).max(1e-30);
            mis_l[nl + 1] = if pl > 0.0 {
                (1.0 + pr * mis_l[nl]) / pl
            } else {
                0.0
            };
            // v(-y_{j+1}, -y_j) / pdf(y_j -> y_{j+1}) = F sigma(-y_j) / |y_{j+1}.z|.
            thr_l[nl + 1] = thr_l[nl] * fr.as_dvec3() * (sig_y[nl - 1] / o.z.abs() as f64);
            if !within_range(thr_l[nl + 1]) {
                break;
            }
            nl += 1;
        }
        let lo = lambda_signed(ndf, wo);
        let mut cam = SegmentTerm::<C>::start(-lam_x[0]);
        let mut tmp = SegmentTerm::<C>::default();
        let mut f = DVec3::ZERO;
        for s in 1..=nc {
            if s > 1 {
                cam.push(lam_x[s - 1]);
            }
            if thr_c[s] == DVec3::ZERO {
                continue;
            }
            let xs = x[s - 1];
            for t in 1..=nl {
                if s + t - 1 > kmax {
                    break;
                }
                let yt = -y[t - 1];
                let (vc, dconn) = vertex(&self.ms, xs, yt);
                if vc == Vec3::ZERO || thr_l[t] == DVec3::ZERO {
                    continue;
                }
                let seg = if t == 1 {
                    cam.value(lo)
                } else {
                    tmp.copy_from(&cam);
                    for j in (1..t).rev() {
                        tmp.push(lam_y[j]);
                    }
                    tmp.value(lo)
                };
                if seg <= 0.0 {
                    continue;
                }
                // Balance heuristic: connection edge pdfs in both directions.
                let dc = dconn as f64;
                let fwd_conn = dc / sig_x[s - 1].max(1e-30);
                let rev_conn = dc / sig_y[t - 1].max(1e-30);
                let mis = 1.0 + rev_conn * mis_c[s] + fwd_conn * mis_l[t];
                if !(mis.is_finite() && mis >= 1.0) {
                    continue;
                }
                let term = thr_c[s] * vc.as_dvec3() * thr_l[t] * (seg / mis);
                if term.is_finite() {
                    f += term;
                }
            }
        }
        f.as_vec3()
    }
}

impl ScatterModel for Invariance {
    fn eval(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        let (wi, wo) = if wi.z < 0.0 {
            (flip_z(wi), flip_z(wo))
        } else {
            (wi, wo)
        };
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let small = (self.max_bounces as usize) < CAP_SMALL;
        match (self.estimator, small) {
            (Estimator::Pt, true) => self.eval_pt::<CAP_SMALL>(wi, wo, rng),
            (Estimator::Pt, false) => self.eval_pt::<CAP_MAX>(wi, wo, rng),
            (Estimator::Bdpt, true) => self.eval_bdpt::<CAP_SMALL>(wi, wo, rng),
            (Estimator::Bdpt, false) => self.eval_bdpt::<CAP_MAX>(wi, wo, rng),
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
        two_sided_hapke_pdf(&self.ndf, wi, wo)
    }
}

/// The exact-exit walk of Cui et al. 2023, Alg. 2, for a two-sided
/// conductor with the depth state `S` (exit with the exact conditional
/// probability, module docs), pdf the Hapke lobe.
pub(crate) fn sample_exact_exit<S: DepthState>(
    ms: &Microsurface,
    wi: Vec3,
    u: [f32; 3],
    rng: &mut Rng,
) -> Sample {
    match microsurface::sample_walk::<S, _>(ms, wi, u, rng, |_| {}) {
        Ok(e) if e.wo.z != 0.0 && crate::bsdf::same_side(wi, e.wo) => {
            let pdf = two_sided_hapke_pdf(&ms.ndf, wi, e.wo);
            Sample::new(wi, e.wo, e.weight, pdf)
        }
        _ => Sample::ABSORBED,
    }
}

impl Invariance {
    /// INVARIANCE for a validated description: Smith NDFs (the walk uses
    /// only the generic Smith API; tests/invariance.rs checks Student-T
    /// too), conductor facets, PT or BDPT. `Error::Unsupported` for other
    /// facets and for heavy Student-T tails whose walks would exceed
    /// [`MAX_DEFAULT_BOUNCES`] (too long for the estimators' f64 arithmetic).
    pub(crate) fn from_desc(d: &MaterialDesc, facet: Facet) -> Result<Self, Error> {
        let ndf = smith_conductor_walk_ndf(d, facet)?;
        Ok(Invariance::new(ndf, facet, d.estimator, d.max_bounces))
    }
}

/// The Smith NDF of a description for the invariance-family walks
/// (INVARIANCE and BITTERLI_DEON): conductor facets, walks no longer than
/// [`MAX_DEFAULT_BOUNCES`].
pub(crate) fn smith_conductor_walk_ndf(d: &MaterialDesc, facet: Facet) -> Result<Ndf, Error> {
    let ndf = d.smith_ndf()?;
    if !matches!(facet, Facet::Conductor { .. })
        || default_max_bounces_for(&ndf) > MAX_DEFAULT_BOUNCES
    {
        return Err(Error::Unsupported);
    }
    Ok(ndf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segment_term_single_bounce_is_height_correlated_g2() {
        // S_1 = 1 / (|Lambda(d_0)| + Lambda(o)).
        let s = SegmentTerm::<4>::start(1.3);
        assert!((s.value(0.4) - 1.0 / 1.7).abs() < 1e-15);
    }
}
