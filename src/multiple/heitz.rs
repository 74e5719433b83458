//! `MSBSDF_MODEL_HEITZ_RANDOM_WALK`: the height random walk of Heitz, Hanika,
//! d'Eon and Dachsbacher 2016 ("Multiple-Scattering Microfacet BSDFs with the
//! Smith Model"), the unbiased reference every other model is judged against.
//!
//! The microsurface is a volume of facets whose heights follow a distribution
//! `C1(h)`; the walk tracks the height and direction of a ray scattering in
//! it (seed 003, Sec. 3.1 and Fig. 2: the path is `(h_0, d_0, h_1, d_1, ...)`).
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
//!   seed 000 eqs. (8)-(9)); an upward ray that does not escape hits at the height
//!   this formula gives with `U` restricted to `[0, 1 - G1)`, never at the top;
//! - facet normal from the visible normals of the travel direction,
//!   `D_{-w}(m) = max(0, -w.m) D(m) / sigma(-w)`;
//! - facet scattering: conductor mirror with complex Fresnel per bounce,
//!   dielectric reflection with probability `F` else refraction (continuing
//!   on the other side with the height mirrored, `C1 -> 1 - C1`, and
//!   `eta -> 1 / eta`), or a Lambert lobe about `m` for diffuse facets.
//!
//! `eval` is next-event estimation at every vertex: the phase function
//! towards `wo` (seed 003, eq. (6), as defined by Heitz 2016:
//! `p(w, o) = F(o.m) D_{-w}(m) / (4 |o.m|)`, `m = normalize(o - w)`, and the
//! Walter 2007 refraction Jacobian for transmission) times the escape
//! probability towards `wo` from the vertex height. The estimate from `wi`
//! is averaged with the estimate from `wo` (roles swapped), scaled by the
//! generalised reciprocity `f(wi, wo) / eta_o^2 = f(wo, wi) / eta_i^2`, so the
//! estimate is reciprocal.
//!
//! `pdf` is an approximation (as in Heitz 2016, seed 000 Sec. 4.3 and
//! seed 003 Sec. 4.4): the
//! single-scattering visible-normal pdf (exactly SINGLE's) with weight
//! `1 - q`, plus a cosine lobe with weight `q` ([`cosine_weight`] of the
//! mean of the two roughnesses) for the multiply scattered part. For dielectrics the cosine lobe covers both hemispheres
//! (`|wo.z| / (2 pi)`); for diffuse facets, which SINGLE does not cover, the
//! pdf is the cosine lobe alone. It is positive wherever `sample` can go.
//!
//! Bounce limit: `max_bounces = 0` selects [`default_max_bounces`]. A walk
//! reaching one more vertex than the limit is absorbed (weight 0). The rule
//! comes from the measured truncated energy: the smallest limit `n` whose
//! fraction of white-furnace walks needing more than `n` vertices is below
//! 1e-3 (2 x 10^5 walks, GGX, worst of theta_i in {0, 60, 89} degrees;
//! Beckmann needs fewer; `cargo run --release --example heitz_measure trunc`):
//!
//! | alpha | mirror | glass 1.5 (from above) | glass 1/1.5 (from below) | glass 1/3 | diffuse, albedo 1 |
//! |-------|--------|------|------|------|------|
//! | 0.5   | 5      | 6    | 6    | 5    | 8    |
//! | 1.0   | 8      | 8    | 9    | 8    | 15   |
//! | 2.0   | 13     | 13   | 16   | 13   | 35   |
//! | 5.0   | 26     | 24   | 32   | 26   | 140  |
//! | 10.0  | 47     | 39   | 57   | 45   | > 256 |
//!
//! Diffuse facets with albedo 1 at alpha 10 keep more than 1e-3 of the
//! energy beyond [`MAX_BOUNCES`] = 256 vertices, so the 0.1% target is not
//! reachable there (with albedo below 1 the lost energy is far smaller).
//! With the default limit 10, the truncated energy of a GGX mirror is
//! 5e-6 at alpha 1 and 7.4e-3 at alpha 2 (normal incidence), so alpha
//! above 1 needs more.
//!
//! The walk keeps no path arrays: its whole state (direction, log height,
//! side, throughput) lives in a few registers.

use crate::bsdf::{Sample, ScatterModel, opposite_sides, same_side};
use crate::desc::MAX_BOUNCES;
use crate::facet::Facet;
use crate::frame::{RefractionHalf, flip_z, reflect, refract, refraction_half};
use crate::fresnel;
use crate::ndf::Ndf;
use crate::rng::Rng;
use crate::single::{G2Form, Single};
use glam::Vec3;
use std::f32::consts::PI;

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
/// scaled by the NDF's tail (`invariance::heavy_tail_bounce_scale`: 1 for
/// Beckmann, GGX and Student-T with shape >= 2; e.g. 28 bounces instead of
/// 10 for Student-T shape 1.6 at alpha 1, whose furnace was 0.917).
pub fn default_max_bounces(alpha_x: f32, alpha_y: f32, facet: &Facet) -> u32 {
    let a = alpha_x.max(alpha_y);
    let n = match facet {
        Facet::Conductor { .. } => 5.0 * a + 4.0,
        Facet::Dielectric { .. } => 7.5 * a + 6.0,
        Facet::Diffuse { .. } => 16.0 * a.powf(1.4),
    };
    (n.ceil().clamp(10.0, MAX_BOUNCES as f32)) as u32
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

/// The Heitz et al. 2016 height random walk over a Smith microsurface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Heitz {
    ndf: Ndf,
    facet: Facet,
    max_bounces: u32,
    /// Weight of the cosine lobe in `pdf`.
    q: f32,
    single: Single,
}

/// What a walk produced.
#[derive(Clone, Copy, Debug)]
struct WalkResult {
    /// Exit direction in the world frame (`None`: absorbed / cut).
    exit: Option<Vec3>,
    /// Throughput at exit.
    weight: Vec3,
    /// Sum of the next-event estimates towards the target.
    nee: Vec3,
    /// Number of scattering vertices visited.
    bounces: u32,
}

/// `ln(1 - exp(x))` for `x <= 0` without cancellation (Maechler 2012).
#[inline]
fn log1mexp(x: f64) -> f64 {
    if x > -std::f64::consts::LN_2 {
        (-x.exp_m1()).ln()
    } else {
        (-x.exp()).ln_1p()
    }
}

/// A uniform in the open interval `(0, 1)` (24-bit midpoints).
#[inline]
fn open_uniform(rng: &mut Rng) -> f64 {
    ((rng.next_u32() >> 8) as f64 + 0.5) * (1.0 / 16_777_216.0)
}

/// A cosine-distributed direction about the unit normal `n`.
#[inline]
fn cosine_about(n: Vec3, u1: f32, u2: f32) -> Vec3 {
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    let (s, c) = phi.sin_cos();
    let local = Vec3::new(r * c, r * s, (1.0 - u1).max(0.0).sqrt());
    // Orthonormal basis about n (Duff et al. 2017, "Building an orthonormal
    // basis, revisited").
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = Vec3::new(b, sign + n.y * n.y * a, -n.y);
    (local.x * t + local.y * bt + local.z * n).normalize_or_zero()
}

impl Heitz {
    /// A random walk over `ndf` with `facet`s; `max_bounces = 0` picks
    /// [`default_max_bounces`], larger values are capped at [`MAX_BOUNCES`].
    pub fn new(ndf: Ndf, facet: Facet, max_bounces: u32) -> Self {
        let max_bounces = if max_bounces == 0 {
            // Heavy-tailed NDFs (Student-T with shape below 2) keep light
            // longer: the roughness is scaled and the limit floored as for
            // INVARIANCE (`invariance::heavy_tail_bounce_scale`); Beckmann,
            // GGX and Student-T with shape >= 2 are unchanged.
            let (scale, floor) = crate::multiple::invariance::heavy_tail_bounce_scale(&ndf);
            default_max_bounces(ndf.alpha_x * scale, ndf.alpha_y * scale, &facet)
                .max(floor)
                .min(MAX_BOUNCES)
        } else {
            max_bounces.min(MAX_BOUNCES)
        };
        let alpha = 0.5 * (ndf.alpha_x + ndf.alpha_y);
        let q = cosine_weight(alpha, &facet);
        // The SINGLE pdf ignores conductor Fresnel; for diffuse facets it is
        // not used (q = 1), any facet will do.
        let single_facet = match facet {
            Facet::Dielectric { .. } => facet,
            _ => Facet::Conductor {
                eta: Vec3::ZERO,
                k: Vec3::ONE,
            },
        };
        Heitz {
            ndf,
            facet,
            max_bounces,
            q,
            single: Single::new(ndf, single_facet, G2Form::HeightCorrelated),
        }
    }

    /// The bounce limit in use (after resolving the default).
    pub fn max_bounces(&self) -> u32 {
        self.max_bounces
    }

    /// Relative index below / above in the frame of the current side.
    #[inline]
    fn eta_on_side(&self, flipped: bool) -> f32 {
        match self.facet {
            Facet::Dielectric { eta } => {
                if flipped {
                    1.0 / eta
                } else {
                    eta
                }
            }
            _ => 1.0,
        }
    }

    /// Phase function times escape probability towards `o` (local frame of
    /// the current side) from a vertex at log height `lc`, for a ray
    /// travelling along `w` that hit the sampled facet `m_sampled`.
    /// `sigma_i` is the projected area seen from `-w` and `lam_o` the
    /// Lambda of `o` taken on its escape side (both computed once by the
    /// caller).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn next_event(
        &self,
        w: Vec3,
        m_sampled: Vec3,
        lc: f64,
        eta: f32,
        o: Vec3,
        sigma_i: f32,
        lam_o: f64,
    ) -> Vec3 {
        let i = -w;
        // D_{-w}(m) = max(0, -w.m) D(m) / sigma(-w).
        let d_vis = |m: Vec3| {
            let c = i.dot(m);
            if c <= 0.0 || sigma_i <= 0.0 {
                0.0
            } else {
                c * self.ndf.d(m) / sigma_i
            }
        };
        if o.z > 0.0 {
            // Escape upward from the vertex: G1(o, h) = C1(h)^Lambda(o).
            let lam = lam_o;
            if !lam.is_finite() {
                return Vec3::ZERO;
            }
            let escape = (lam * lc).exp() as f32;
            if escape <= 0.0 {
                return Vec3::ZERO;
            }
            let phase = match self.facet {
                Facet::Diffuse { albedo } => albedo * (o.dot(m_sampled).max(0.0) / PI),
                _ => {
                    let m = (i + o).normalize_or_zero();
                    if m.z <= 0.0 {
                        return Vec3::ZERO;
                    }
                    let ci = i.dot(m);
                    if ci <= 0.0 {
                        return Vec3::ZERO;
                    }
                    // seed 003, eq. (6): p(w, o) = F(o.m) D_{-w}(m) / (4 |o.m|).
                    let p = d_vis(m) / (4.0 * ci);
                    let f = match self.facet {
                        Facet::Dielectric { .. } => Vec3::splat(fresnel::dielectric(ci, eta)),
                        Facet::Conductor { eta, k } => fresnel::conductor_rgb(ci, eta, k),
                        Facet::Diffuse { .. } => Vec3::ONE,
                    };
                    f * p
                }
            };
            phase * escape
        } else {
            // Only dielectrics reach the other side: refraction into it and
            // escape there, from the mirrored height (C1 -> 1 - C1).
            if !matches!(self.facet, Facet::Dielectric { .. }) {
                return Vec3::ZERO;
            }
            let Some(RefractionHalf {
                h: m,
                ci,
                co,
                jacobian: jac,
            }) = refraction_half(i, o, eta)
            else {
                return Vec3::ZERO;
            };
            if !lam_o.is_finite() {
                return Vec3::ZERO;
            }
            let escape = (lam_o * log1mexp(lc).max(-700.0)).exp() as f32;
            // Walter 2007 eq. (17) with the visible-normal density.
            let p = (1.0 - fresnel::dielectric_pair(ci, co, eta)) * d_vis(m) * jac;
            Vec3::splat(p * escape)
        }
    }

    /// Runs one walk from `wi` (world frame). With `target`, accumulates the
    /// next-event estimate of `f(wi, target) |target.z|`.
    fn walk(&self, wi: Vec3, target: Option<Vec3>, rng: &mut Rng) -> WalkResult {
        let mut flipped = wi.z < 0.0;
        let to_local = |v: Vec3, flipped: bool| if flipped { flip_z(v) } else { v };
        let mut w = -to_local(wi, flipped);
        let mut lc = 0.0f64; // ln C1(h): start above the surface, C1 = 1
        let mut eta = self.eta_on_side(flipped);
        let mut weight = Vec3::ONE;
        let mut nee = Vec3::ZERO;
        let mut bounces = 0u32;
        // Lambda of the target on the side it escapes to (|z|), fixed for the walk.
        let lam_target = match target {
            Some(t) => self.ndf.lambda(Vec3::new(t.x, t.y, t.z.abs())) as f64,
            None => 0.0,
        };
        loop {
            // Next event along w.
            let lam = self.ndf.lambda(w) as f64;
            let u = open_uniform(rng);
            if w.z > 0.0 {
                if lam.is_finite() {
                    let escape = (lam * lc).exp();
                    if u < escape {
                        let exit = to_local(w, flipped);
                        return WalkResult {
                            exit: Some(exit),
                            weight,
                            nee,
                            bounces,
                        };
                    }
                    // Hit below the top: C1(h') = C1(h) / (1 - U')^(1/Lambda)
                    // with U' = u - escape uniform on [0, 1 - G1).
                    lc = (lc - (1.0 - u + escape).ln() / lam).min(0.0);
                }
                // Lambda infinite (horizontal ray): hits where it is.
            } else if lam.is_finite() && lam < 0.0 {
                // Downward: always hits, C1(h') = C1(h) (1 - U)^(1/|Lambda|).
                lc += u.ln() / (-lam);
            }
            bounces += 1;
            if bounces > self.max_bounces {
                return WalkResult {
                    exit: None,
                    weight: Vec3::ZERO,
                    nee,
                    bounces,
                };
            }
            let i = -w;
            let m = self.ndf.sample_visible(i, rng.next_f32(), rng.next_f32());
            let ci = i.dot(m);
            if ci <= 0.0 || !m.is_finite() {
                // Numerically invisible facet: end the path.
                return WalkResult {
                    exit: None,
                    weight: Vec3::ZERO,
                    nee,
                    bounces,
                };
            }
            if let Some(t) = target {
                // sigma(-w) = (1 + Lambda(-w)) (-w.z) = Lambda(w) w.z by the
                // full-sphere symmetry Lambda(-w) = -1 - Lambda(w).
                let sigma_i = if lam.is_finite() {
                    (lam * w.z as f64) as f32
                } else {
                    self.ndf.sigma(i)
                };
                let o = to_local(t, flipped);
                nee += weight * self.next_event(w, m, lc, eta, o, sigma_i, lam_target);
            }
            match self.facet {
                Facet::Conductor { eta, k } => {
                    weight *= fresnel::conductor_rgb(ci, eta, k);
                    w = reflect(i, m);
                }
                Facet::Diffuse { albedo } => {
                    weight *= albedo;
                    w = cosine_about(m, rng.next_f32(), rng.next_f32());
                }
                Facet::Dielectric { .. } => {
                    let f = fresnel::dielectric(ci, eta);
                    let u3 = rng.next_f32();
                    let refracted = if u3 < f { None } else { refract(i, m, eta) };
                    match refracted {
                        Some(t) => {
                            // Continue on the other side: mirror direction
                            // and height, invert the relative index.
                            w = flip_z(t);
                            // Kept finite (C1 >= e^-700) so 0 * ln C1 never makes a NaN.
                            lc = log1mexp(lc).max(-700.0);
                            flipped = !flipped;
                            eta = 1.0 / eta;
                        }
                        None => w = reflect(i, m),
                    }
                }
            }
            if weight.max_element() <= 0.0 || !w.is_finite() || w == Vec3::ZERO {
                return WalkResult {
                    exit: None,
                    weight: Vec3::ZERO,
                    nee,
                    bounces,
                };
            }
        }
    }

    /// One unidirectional next-event estimate of `f(wi, wo) |wo.z|`.
    pub fn estimate(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        self.walk(wi, Some(wo), rng).nee
    }

    /// Samples the walk and also reports how many vertices it visited
    /// (for statistics and tests).
    pub fn sample_with_bounces(&self, wi: Vec3, rng: &mut Rng) -> (Sample, u32) {
        let r = self.walk(wi, None, rng);
        match r.exit {
            Some(wo) if wo.z != 0.0 => {
                let pdf = self.pdf(wi, wo);
                (Sample::new(wi, wo, r.weight, pdf), r.bounces)
            }
            _ => (Sample::ABSORBED, r.bounces),
        }
    }

    /// `eta_o^2 / eta_i^2` of the generalised reciprocity for a pair.
    #[inline]
    fn reciprocity_factor(&self, wi: Vec3, wo: Vec3) -> f32 {
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

impl ScatterModel for Heitz {
    // PLACEHOLDER(kernel branch): replaced at merge
    fn sample_with(&self, wi: Vec3, _u: [f32; 3], rng: &mut Rng) -> Sample {
        self.sample(wi, rng)
    }

    fn eval(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        if !same_side(wi, wo) && !matches!(self.facet, Facet::Dielectric { .. }) {
            return Vec3::ZERO;
        }
        let forward = self.estimate(wi, wo, rng);
        let backward = self.estimate(wo, wi, rng);
        // f(wi, wo) |wo.z| = f(wo, wi) |wi.z| * (|wo.z| / |wi.z|) * eta_o^2 / eta_i^2.
        let scale = wo.z.abs() / wi.z.abs() * self.reciprocity_factor(wi, wo);
        let backward = backward * scale;
        let v = 0.5 * (forward + backward);
        if v.is_finite() {
            v.max(Vec3::ZERO)
        } else {
            Vec3::ZERO
        }
    }

    fn sample(&self, wi: Vec3, rng: &mut Rng) -> Sample {
        self.sample_with_bounces(wi, rng).0
    }

    fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        let reflection = same_side(wi, wo);
        let cosine = match self.facet {
            Facet::Dielectric { .. } => wo.z.abs() / (2.0 * PI),
            _ if reflection => wo.z.abs() / PI,
            _ => 0.0,
        };
        let single = if self.q < 1.0 {
            self.single.pdf(wi, wo)
        } else {
            0.0
        };
        let p = (1.0 - self.q) * single + self.q * cosine;
        if p.is_finite() && p > 0.0 { p } else { 0.0 }
    }
}
