//! A variance-reduced copy of HEITZ_RANDOM_WALK's next-event walk
//! (`src/multiple/heitz.rs`) for the reference generator: the same
//! microsurface, NDF, height model, Fresnel and bounce limit, so it
//! estimates the same BSDF, with two unbiased changes switched by
//! [`WalkOptions`]:
//!
//! - **Forced collision** on the upward segments leaving the first
//!   `forced` vertices: instead of escaping with probability
//!   `G1 = C1(h)^Lambda(w)` (Heitz 2016; the escape adds nothing to the
//!   next-event estimates, which happen at vertices only), the walk always
//!   hits, at a height drawn from the hit distribution conditioned on a hit
//!   (`C1(h') = C1(h) / (1 - U (1 - G1))^(1 / Lambda)`), and the throughput
//!   is multiplied by the hit probability `1 - G1`. At low roughness the
//!   second collision is rare (`1 - G1 ~ 1e-3` for most first reflections),
//!   so the analog walk spends almost all samples on zero multiple
//!   scattering and a few on large values.
//! - **Multiple importance sampling** of the forward walk (from `wi`, next
//!   event towards `wo`) and the reverse walk (from `wo` towards `wi`),
//!   balance heuristic over the whole path. A path of order `k` has
//!   vertices at heights `x_1 .. x_k` (`x = C1(h)` in the frame of the
//!   side the walk is on) and travel directions `w_1 .. w_{k-1}` between
//!   them. The forward walk samples it with density
//!   `P_f = e_i(x_1) prod_{j<k} p_j(w_j | w_{j-1}) t(x_{j+1} | x_j, w_j)`
//!   (entry density `e_i(x) = (1 + Lambda_i) x^Lambda_i`, the facet sampling
//!   density `p_j` = the phase function without conductor Fresnel,
//!   reflect/refract choice included, and the hit-height density
//!   `t(y | x, w) = |L| x^L y^(-L-1)`, `L = Lambda(w)` of either sign), the
//!   reverse walk with `P_r = e_o(x_k) prod_{j>1} p_j(-w_{j-1} | -w_j)
//!   t(x_{j-1} | x_j, -w_{j-1})`. The heights cancel in `P_r / P_f` except
//!   at the ends: `t(x | y, -w) / t(y | x, w) = (1 + L) / L` for every pair
//!   of heights, so `P_r / P_f = (1 + Lambda_o) x_k^Lambda_o / ((1 +
//!   Lambda_i) x_1^Lambda_i) prod (1 + L_j) / L_j prod p_j^rev / p_j^fwd`,
//!   accumulated along the walk. The forward next event at vertex `k` is
//!   weighted `P_f / (P_f + P_r)`, the reverse one `P_r / (P_f + P_r)`,
//!   instead of `1/2` each. Unbiased because the walk's path contribution
//!   is reciprocal path by path (generalised reciprocity with `eta^2` for
//!   transmission; checked numerically: the height and direction factors of
//!   an order-2 conductor path agree term by term) and the two weights sum
//!   to 1 for every path either walk can produce (forced collisions only
//!   add support; the weights use the analog densities). At low roughness
//!   the facet densities are peaky (`D ~ 1 / (pi alpha^2)`): the forward
//!   walk's next event at vertex `k` pays `D(m_k)` of a facet it did not
//!   choose, the reverse walk `D(m_1)`, and one of the two meets its second
//!   collision very rarely; the weights keep whichever walk sampled the
//!   peak. Paths whose important part lies in the middle (grazing
//!   transmission into grazing directions of rough glass) stay hard for both
//!   walks: a bidirectional connection would be the next step.
//!
//! With `forced = 0` and `mis = false` the walk consumes the random numbers
//! exactly as the library's and its per-order sum is the library's
//! `Heitz::estimate` (checked in `tests/reference_estimator.rs`).
//!
//! Facets: conductor and dielectric (the suite's); diffuse facets are not
//! supported here.

use glam::Vec3;
use msbsdf::Rng;
use msbsdf::facet::Facet;
use msbsdf::frame::{RefractionHalf, flip_z, reflect, refract, refraction_half};
use msbsdf::fresnel;
use msbsdf::multiple::heitz::default_max_bounces;
use msbsdf::ndf::Ndf;

/// Orders kept separately in [`Contribution::by_order`] (index = order;
/// orders `>= ORDERS - 1` are pooled in the last slot).
pub const ORDERS: usize = 8;

/// Variance-reduction switches of [`RefWalk::run`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WalkOptions {
    /// Upward segments leaving vertices `1..=forced` always hit (weighted
    /// by the hit probability).
    pub forced: u32,
    /// Balance-heuristic weights between the forward and reverse walks
    /// (otherwise the caller averages them).
    pub mis: bool,
    /// Also compute the next event at vertex 1 (order 1: the analytic
    /// SINGLE term replaces it in the reference).
    pub order_one: bool,
}

impl WalkOptions {
    /// The library's walk (same random numbers).
    pub const ANALOG: WalkOptions = WalkOptions {
        forced: 0,
        mis: false,
        order_one: true,
    };
}

/// What one walk contributed, per scattering order.
#[derive(Clone, Copy, Debug, Default)]
pub struct Contribution {
    /// Next-event estimates (MIS-weighted when asked) per order.
    pub by_order: [Vec3; ORDERS],
    /// Vertices visited.
    pub vertices: u32,
}

/// `ln(1 - exp(x))` for `x <= 0` without cancellation (as the library).
#[inline]
fn log1mexp(x: f64) -> f64 {
    if x > -std::f64::consts::LN_2 {
        (-x.exp_m1()).ln()
    } else {
        (-x.exp()).ln_1p()
    }
}

/// A uniform in `(0, 1)` (24-bit midpoints, as the library).
#[inline]
fn open_uniform(rng: &mut Rng) -> f64 {
    ((rng.next_u32() >> 8) as f64 + 0.5) * (1.0 / 16_777_216.0)
}

/// The walk of one material.
#[derive(Clone, Copy, Debug)]
pub struct RefWalk {
    ndf: Ndf,
    facet: Facet,
    max_bounces: u32,
}

impl RefWalk {
    /// The walk with the library's default bounce limit (`max_bounces = 0`)
    /// or the given one.
    pub fn new(ndf: Ndf, facet: Facet, max_bounces: u32) -> Self {
        let max_bounces = if max_bounces == 0 {
            default_max_bounces(ndf.alpha_x, ndf.alpha_y, &facet)
        } else {
            max_bounces
        };
        RefWalk {
            ndf,
            facet,
            max_bounces,
        }
    }

    fn eta_on_side(&self, flipped: bool) -> f32 {
        match self.facet {
            Facet::Dielectric { eta } if flipped => 1.0 / eta,
            Facet::Dielectric { eta } => eta,
            _ => 1.0,
        }
    }

    /// Density (solid angle, discrete reflect/refract choice included for
    /// dielectrics) with which a vertex seen from `i` (= minus the travel
    /// direction, local frame of the side) sends the walk along `o`:
    /// reflection (`o` the new travel direction, same frame) or refraction
    /// (`o` the refracted direction in this frame, pointing to the other
    /// side). Exactly the phase function without conductor Fresnel
    /// (seed 003, eq. (6); Walter 2007 eq. (17) for refraction).
    fn dir_pdf(&self, i: Vec3, o: Vec3, eta: f32, refracted: bool) -> f64 {
        if refracted {
            let Some(RefractionHalf {
                h,
                ci,
                co,
                jacobian,
                ..
            }) = refraction_half(i, o, eta)
            else {
                return 0.0;
            };
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
    fn reverse_pdf(&self, i: Vec3, o: Vec3, eta: f32, refracted: bool) -> f64 {
        if refracted {
            self.dir_pdf(flip_z(o), flip_z(i), 1.0 / eta, true)
        } else {
            self.dir_pdf(o, i, eta, false)
        }
    }

    /// Phase function times escape probability towards `o` (as the
    /// library's `next_event`).
    fn next_event(&self, w: Vec3, lc: f64, eta: f32, o: Vec3, sigma_i: f32, lam_o: f64) -> Vec3 {
        let i = -w;
        let d_vis = |m: Vec3| {
            let c = i.dot(m);
            if c <= 0.0 || sigma_i <= 0.0 {
                0.0
            } else {
                c * self.ndf.d(m) / sigma_i
            }
        };
        if !lam_o.is_finite() {
            return Vec3::ZERO;
        }
        if o.z > 0.0 {
            let escape = (lam_o * lc).exp() as f32;
            if escape <= 0.0 {
                return Vec3::ZERO;
            }
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
                Facet::Diffuse { .. } => Vec3::ZERO,
            };
            f * p * escape
        } else {
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
            let escape = (lam_o * log1mexp(lc).max(-700.0)).exp() as f32;
            let p = (1.0 - fresnel::dielectric_pair(ci, co, eta)) * d_vis(m) * jac;
            Vec3::splat(p * escape)
        }
    }

    /// One walk from `wi` with next-event estimates towards `wo`, per order.
    pub fn run(&self, wi: Vec3, wo: Vec3, rng: &mut Rng, opt: WalkOptions) -> Contribution {
        let mut out = Contribution::default();
        if matches!(self.facet, Facet::Diffuse { .. }) {
            return out;
        }
        let mut flipped = wi.z < 0.0;
        let to_local = |v: Vec3, flipped: bool| if flipped { flip_z(v) } else { v };
        let mut w = -to_local(wi, flipped);
        let mut lc = 0.0f64;
        let mut eta = self.eta_on_side(flipped);
        let mut weight = Vec3::ONE;
        let mut bounces = 0u32;
        let lam_target = self.ndf.lambda(Vec3::new(wo.x, wo.y, wo.z.abs())) as f64;
        // MIS state: ln(P_r / P_f) of the path so far without the reverse
        // walk's first vertex and entry (added at each next event).
        let mut log_r = 0.0f64;
        loop {
            let lam = self.ndf.lambda(w) as f64;
            if opt.mis {
                if bounces == 0 {
                    // Entry of the forward walk: C1(h_1) has density
                    // (1 + Lambda_i) C1^Lambda_i, Lambda_i = -1 - lam.
                    log_r -= (-lam).ln();
                } else if lam.is_finite() {
                    // Segment between two vertices: the reverse walk's
                    // height density over the forward's is (1 + L) / L for
                    // any pair of heights (L = Lambda(w), either sign).
                    log_r += ((1.0 + lam) / lam).ln();
                }
            }
            let u = open_uniform(rng);
            if w.z > 0.0 {
                if lam.is_finite() {
                    if bounces >= 1 && bounces <= opt.forced {
                        // Forced collision: hit with probability 1 at a
                        // height drawn given a hit, weight 1 - C1^Lambda.
                        let p_hit = -(lam * lc).exp_m1();
                        if p_hit.is_nan() || p_hit <= 0.0 {
                            break;
                        }
                        weight *= p_hit as f32;
                        lc = (lc - (-u * p_hit).ln_1p() / lam).min(0.0);
                    } else {
                        let escape = (lam * lc).exp();
                        if u < escape {
                            break;
                        }
                        lc = (lc - (1.0 - u + escape).ln() / lam).min(0.0);
                    }
                }
            } else if lam.is_finite() && lam < 0.0 {
                lc += u.ln() / (-lam);
            }
            bounces += 1;
            if bounces > self.max_bounces {
                break;
            }
            if opt.mis && bounces == 1 {
                // ... times C1(h_1)^Lambda_i (the reverse walk's escape).
                log_r -= (-1.0 - lam) * lc;
            }
            let i = -w;
            let m = self.ndf.sample_visible(i, rng.next_f32(), rng.next_f32());
            let ci = i.dot(m);
            if ci <= 0.0 || !m.is_finite() {
                break;
            }
            let order = bounces as usize;
            let o = to_local(wo, flipped);
            if order >= 2 || opt.order_one {
                let sigma_i = if lam.is_finite() {
                    (lam * w.z as f64) as f32
                } else {
                    self.ndf.sigma(i)
                };
                let mut c = weight * self.next_event(w, lc, eta, o, sigma_i, lam_target);
                if opt.mis && order >= 2 && c != Vec3::ZERO {
                    // The reverse walk's entry at this vertex (density
                    // (1 + Lambda_o) C1^Lambda_o on wo's side) and its first
                    // facet choice.
                    let ln_esc = if o.z > 0.0 {
                        lam_target * lc
                    } else {
                        lam_target * log1mexp(lc).max(-700.0)
                    };
                    let pr = self.reverse_pdf(i, o, eta, o.z < 0.0);
                    let t = log_r + pr.ln() + (1.0 + lam_target).ln() + ln_esc;
                    let wf = if t.is_nan() {
                        0.5
                    } else {
                        1.0 / (1.0 + t.exp())
                    };
                    c *= wf as f32;
                }
                out.by_order[order.min(ORDERS - 1)] += c;
            }
            let old_eta = eta;
            let refracted = match self.facet {
                Facet::Conductor { eta, k } => {
                    weight *= fresnel::conductor_rgb(ci, eta, k);
                    w = reflect(i, m);
                    None
                }
                Facet::Dielectric { .. } => {
                    let f = fresnel::dielectric(ci, eta);
                    let u3 = rng.next_f32();
                    let refracted = if u3 < f { None } else { refract(i, m, eta) };
                    match refracted {
                        Some(t) => {
                            w = flip_z(t);
                            lc = log1mexp(lc).max(-700.0);
                            flipped = !flipped;
                            eta = 1.0 / eta;
                        }
                        None => w = reflect(i, m),
                    }
                    refracted
                }
                Facet::Diffuse { .. } => None,
            };
            if opt.mis && bounces < self.max_bounces {
                // Density of this choice, forward and reverse.
                let (o_dir, is_t) = match refracted {
                    Some(t) => (t, true),
                    None => (w, false),
                };
                let pf = self.dir_pdf(i, o_dir, old_eta, is_t);
                log_r -= pf.ln();
                if bounces > 1 {
                    log_r += self.reverse_pdf(i, o_dir, old_eta, is_t).ln();
                }
            }
            if weight.max_element() <= 0.0 || !w.is_finite() || w == Vec3::ZERO {
                break;
            }
        }
        out.vertices = bounces.min(self.max_bounces);
        out
    }
}
