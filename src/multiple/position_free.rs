//! `MSBSDF_MODEL_POSITION_FREE`: the position-free multiple-bounce Smith
//! microfacet BSDF of Wang, Jin, Fan, Yang, Holzschuch and Yan 2022 (Wang et al. 2022), with its two estimators: path tracing with
//! next-event estimation at every bounce (eqs. 11-13) and bidirectional path
//! tracing with balance-heuristic MIS over every split of a path (eqs. 14-16).
//!
//! # The path integral as implemented
//!
//! A path is `(d_0, b_0, d_1, ..., b_{k-1}, d_k)` with `d_0 = -wi` and
//! `d_k = wo` (directions follow the flow of light). Its contribution is the
//! product of vertex terms and segment terms (eq. 1) integrated over the
//! internal directions `d_1 .. d_{k-1}` (eqs. 3-4). The paper prints the
//! vertex term (eq. 2) with cosines against the half vector and a path
//! measure "sigma"; read with the cosines against the geometric normal and
//! sigma as the projected solid angle (so that a 2-direction path is
//! Cook-Torrance), the product of one vertex term with its entering segment
//! term is, per unit solid angle of the outgoing direction, the Smith phase
//! function of Heitz et al. 2016:
//!
//! ```text
//! v_i p_i |d_i.z|  ==  phase(d_i -> d_{i+1}) = F D_{-d_i}(m) / (4 |d_{i+1}.m|)      (reflection)
//!                                             = (1 - F) D_{-d_i}(m) J_t(m)          (refraction)
//! ```
//!
//! with `D_v(m) = <v.m> D(m) / sigma(v)` the visible normals over the full
//! sphere (`sigma(v) = |v.z| / G1_dist(v)`, eq. 9, so `p_i = G1_dist(-d_i)`,
//! eq. 10, is inside `D_{-d_i}`), and the local factors `chi+(.)` of eq. 8
//! enforced by the half-vector checks. The remaining segment factors are the
//! exit probabilities: `e_i = 1 - G1_dist(d_i)` for an internal direction
//! leaving upwards and 1 downwards (eq. 6), `e_k = G1_dist(wo)` (eq. 7).
//! The integrand over solid angle is thus
//!
//! ```text
//! f(wi, wo) |wo.z| = sum_k  int  prod_{i<k} phase(d_i -> d_{i+1})  prod_{0<i<k} e_i  G1_dist(wo)
//! ```
//!
//! which is a Markov chain that conserves energy exactly for `F = 1`
//! (a phase function integrates to 1 and `e_i + (1 - e_i) = 1`), and whose
//! segment factor `G1_dist(-d) e(d)` is the same for `d` and `-d`, which is
//! the paper's reciprocity argument (sec. 3.4). Each segment is
//! height-uncorrelated: a path with one vertex is Cook-Torrance with the
//! *uncorrelated* `G2 = G1(wi) G1(wo)` (sec. 3.4 "Height correlation"; the
//! test `single_bounce_equals_uncorrelated_single` checks it to float
//! precision), not the height-correlated `G2` that the Heitz walk reduces to.
//!
//! Dielectric facets keep a side with every direction: directions are stored
//! in the frame of the medium they travel in (z flipped inside), the facets
//! seen from inside are the same distribution, and the relative index is
//! `eta` from outside, `1 / eta` from inside. Transmission is the
//! flux-conserving form (see the crate docs). Conductors are two-sided: a
//! `wi` below the surface mirrors both directions.
//!
//! # Estimators
//!
//! * [`Estimator::Pt`]: from `d_0` the walk samples visible normals (and
//!   reflection/refraction by Fresnel for dielectrics) and at every vertex
//!   connects to `wo` (next-event estimation, eq. 12) with the path pdf of
//!   eq. 13. One walk per eval. The exit factor `e_i` of the direction that
//!   reached a vertex multiplies that vertex's next-event term exactly;
//!   going on past the vertex is then decided by Russian roulette with
//!   probability `e_i` (which cancels it from the throughput). The paper
//!   runs every walk to the bounce limit (sec. 4.1, "it would be easy to
//!   enable" roulette); with roulette an eval costs 3-4 times less at the
//!   same or lower variance per unit time (gold GGX 0.5: 5.8 us and
//!   relative variance 0.21 without, 1.5 us and 0.21 with, on the same
//!   loaded machine).
//! * [`Estimator::Bdpt`]: one walk from `wi` ("camera") and one from `wo`
//!   ("light"), each of at most `max_bounces - 1` sampled vertices; every pair
//!   of prefixes `(s, t)` with `s + t + 1 <= max_bounces` is joined at one
//!   vertex and weighted by the balance heuristic over the `s + t + 1` ways to
//!   sample a path of that length (eqs. 14-16). The MIS weights use the
//!   direction densities only; the subpaths use the same roulette as PT
//!   (the light subpath with the forward exit factor of each direction it
//!   samples), which keeps every strategy unbiased. The subpaths live in
//!   fixed-size stack arrays whose capacity is the smallest of 16, 64 or 256
//!   that holds `max_bounces` (no heap).
//!
//! `sample` is the paper's sec. 4.3 random walk: visible-normal sampling at
//! each vertex, Fresnel as the probability to reflect or refract (dielectric)
//! or as a weight (conductor), and `G1_dist(d)` as the probability to leave
//! on an upward direction. The weight is the product of conductor Fresnel
//! factors (1 for dielectrics); a walk that has not left after `max_bounces`
//! vertices is absorbed (weight 0), the same truncation eval uses, so eval
//! and sample describe the same BSDF. `pdf` is an approximation (sec. 4.3,
//! as Heitz et al. 2016): `(1 - c) p_single + c p_lambert` with `p_single` the
//! exact density of the first vertex (visible-normal density times the
//! Fresnel choice) and `p_lambert = |wo.z| / pi` on `wi`'s side for
//! conductors, `|wo.z| / (2 pi)` on each side for dielectrics, with the
//! Lambert weight `c = clamp(0.25 sqrt(alpha_x alpha_y), 0.05, 0.5)`; it is
//! positive wherever sample can go. It integrates to less than 1 (0.92
//! for GGX 0.3 and 0.65 for GGX 1 at theta_i 30 degrees, conductor): the
//! visible-normal reflections that go below the horizon carry no density.
//!
//! # Bounce limit
//!
//! `max_bounces = 0` selects [`default_max_bounces`]: 10 vertices (the
//! paper's choice) while that drops less than 0.1% of the energy of a white
//! furnace (F = 1), more for rougher surfaces. The fraction dropped by a
//! 10-vertex truncation (conductor F = 1, GGX, measured with `sample`,
//! worst incidence among 0..89 degrees) is recorded in the docs of
//! [`default_max_bounces`].
//!
//! # Measured white furnace and comparison with HEITZ_RANDOM_WALK
//!
//! Every white-furnace albedo (conductor and glass, GGX, Beckmann and
//! Student-T, theta_i up to 89 degrees) is within 1% of 1 and within 4
//! sigma plus 0.1% (the truncation); tables in `docs/position_free.md`,
//! with the differences to HEITZ_RANDOM_WALK: near normal incidence 2-13%,
//! in the grazing mirror direction POSITION_FREE is 50-70% darker
//! (height-uncorrelated segments, Wang et al. 2022, sec. 6), the energy
//! reappearing in the multiply scattered lobe.
//!
//! # Variance
//!
//! Next-event terms of PT are heavy-tailed where the phase function is
//! peaked: smooth surfaces at grazing incidence and smooth dielectrics
//! (GGX 0.1 glass, wi normal, wo transmitted at 30 degrees: single PT evals
//! reach 125 for a mean of 0.004, while BDPT's largest is 0.23). BDPT's MIS
//! removes these spikes; on rough conductors it lowers the variance of one
//! eval by 10-20% at equal samples (gold, GGX alpha 1: ratio 0.79 at
//! theta_i 0 and 0.89 at 60, summed over four outgoing directions) for
//! about 4-5 times the cost per eval, so PT is the more efficient
//! estimator for rough conductors and BDPT for smooth surfaces and
//! dielectrics.

use crate::bsdf::{Sample, ScatterModel};
use crate::desc::MaterialDesc;
use crate::desc::{Estimator, MAX_BOUNCES};
use crate::facet::Facet;
use crate::frame::{RefractionHalf, flip_z, reflect, refract, refraction_half};
use crate::fresnel;
use crate::multiple::microsurface::{
    self, BounceRule, DepthState, Microsurface, Travel, WalkOptions,
};
use crate::ndf::Ndf;
use crate::rng::Rng;
use crate::status::Error;
use glam::Vec3;

/// The bounce limit used when the description asks for the default (0):
/// 10 vertices (Wang et al. 2022 sec. 4.1) while that truncation drops less than 0.1%
/// of the white-furnace energy at any incidence, more for rougher surfaces.
///
/// Measured fraction of energy in paths longer than the limit (conductor
/// F = 1, GGX, worst theta_i among 0, 30, 60, 80, 89 degrees; Beckmann is
/// close), from `sample`:
///
/// | GGX alpha | mirror N=10 | 16 | 24 | 32 | 64 | glass 1.5 / 1/1.5 N=10 | 16 | 24 | 32 | 64 |
/// |---|---|---|---|---|---|---|---|---|---|---|
/// | 1.0 | 0 | 0 | 0 | 0 | 0 | 0.0006 | 0 | 0 | 0 | 0 |
/// | 1.5 | 0.0001 | 0 | 0 | 0 | 0 | 0.0105 | 0.0001 | 0 | 0 | 0 |
/// | 2.0 | 0.0017 | 0 | 0 | 0 | 0 | 0.047 | 0.0016 | 0.00002 | 0 | 0 |
/// | 3.0 | 0.041 | 0.0002 | 0 | 0 | 0 | 0.20 | 0.032 | 0.0009 | 0.00002 | 0 |
/// | 4.0 | 0.19 | 0.0059 | 0.00001 | 0 | 0 | 0.35 | 0.13 | 0.011 | 0.0005 | 0 |
/// | 6.0 | 0.61 | 0.14 | 0.0031 | 0.00002 | 0 | 0.59 | 0.35 | 0.14 | 0.027 | 0 |
/// | 10.0 | 0.94 | 0.73 | 0.25 | 0.030 | 0 | 0.84 | 0.65 | 0.42 | 0.30 | 0.0021 |
///
/// (1e5 walks per incidence for mirrors, 5e4 for glass, worst of eta 1.5
/// and 1/1.5; 0 means no walk was absorbed.) Beckmann needs fewer: at
/// alpha 2, 0.00000 (mirror) and 0.0002 (glass) with 10. The chosen limits:
/// mirror 10 up to alpha 1.5, 16 to 3, 24 to 4, 32 to 6, else 64; glass 10
/// up to alpha 1, 16 to 1.5, 24 to 2, 32 to 3, 64 to 6, else 128 (alpha
/// is the larger of the two roughnesses). Other indices of refraction
/// were not measured (a larger index contrast traps light longer).
///
/// Heavy-tailed NDFs (Student-T with shape below 2) keep light longer: the
/// table is read at the roughness scaled by
/// [`heavy_tail_bounce_scale`](crate::multiple::microsurface::heavy_tail_bounce_scale)
/// (1 for Beckmann, GGX and Student-T from shape 2 on), with its floor, and
/// beyond the table at `max(64, ceil(5 a + 5))` (mirror) or
/// `max(128, ceil(10 a + 10))` (glass; never reached by Beckmann or GGX,
/// whose alpha is at most 10). Measured for mirrors (fraction of 10k walks
/// per incidence still inside, worst of theta_i = 0, 30, 60, 80, 89):
/// Student-T gamma 1.8, alpha 1: 0.02% at 10; alpha 3: 16% at 10, 0.8% at
/// 16, 0.01% at 24; gamma 1.6, alpha 1: 6.1% at 10, 0.4% at 16, 0.02% at 24;
/// gamma 1.51, alpha 1: 17% at 64, 0.7% at 128, 0 at 256. Over
/// gamma = 1.51 .. 1.9 and alpha = 0.1 .. 3 the rule keeps the loss below
/// 0.1% except for gamma 1.51 with alpha 2 or more (more than
/// [`MAX_BOUNCES`] needed: 0.2% at alpha 2, 2.6% at alpha 3 with 256).
/// Student-T glass was not measured.
pub fn default_max_bounces(ndf: &Ndf, facet: &Facet) -> u32 {
    bounces(facet).limit(ndf)
}

/// The bounce-limit rule of POSITION_FREE for the facets
/// ([`default_max_bounces`]).
pub fn bounces(facet: &Facet) -> BounceRule {
    match facet {
        Facet::Dielectric { .. } => BounceRule {
            steps: &[(1.0, 10), (1.5, 16), (2.0, 24), (3.0, 32), (6.0, 64)],
            slope: 10.0,
            power: 1.0,
            offset: 10.0,
            beyond_floor: 128,
        },
        _ => BounceRule {
            steps: &[(1.5, 10), (3.0, 16), (4.0, 24), (6.0, 32)],
            slope: 5.0,
            power: 1.0,
            offset: 5.0,
            beyond_floor: 64,
        },
    }
}

/// The position-free multiple-bounce BSDF (Wang et al. 2022).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PositionFree {
    ndf: Ndf,
    facet: Facet,
    estimator: Estimator,
    max_bounces: u32,
    lambert_weight: f32,
    ms: Microsurface,
}

/// The position-free model's depth state: none. Each segment is
/// height-uncorrelated, so a path at a vertex leaves along an upward `d`
/// with `G1_dist(d) = 1 / (1 + Lambda(d))` whatever came before (Wang et al.
/// 2022, eqs. (6)-(7)); a downward one always hits again. Its MIS segment
/// ratio is exact: `(1 + L) / L` for either sign of `L`.
#[derive(Clone, Copy, Debug)]
pub struct ExitTerm;

impl DepthState for ExitTerm {
    #[inline]
    fn enter(_lam0: f64, _rng: &mut Rng) -> Self {
        ExitTerm
    }

    #[inline]
    fn exit(&self, lam_o: f64, _crossed: bool) -> f64 {
        1.0 / (1.0 + lam_o)
    }

    #[inline]
    fn travel(&mut self, lam: f64, rng: &mut Rng) -> Travel {
        if lam >= 0.0 && (rng.next_f32() as f64) * (1.0 + lam) < 1.0 {
            Travel::Escape
        } else {
            Travel::Hit
        }
    }

    #[inline]
    fn travel_forced(&mut self, lam: f64, _rng: &mut Rng) -> Option<f64> {
        // 1 - G1 = Lambda / (1 + Lambda), for precision.
        Some(if lam.is_finite() {
            lam / (1.0 + lam)
        } else {
            1.0
        })
    }

    #[inline]
    fn segment_ratio(lam: f64) -> f64 {
        microsurface::uncorrelated_segment_ratio(lam)
    }
}

/// A direction with the medium it travels in (`inside` = below the
/// macro-surface; always false for conductors). The vector is expressed in
/// the frame of that medium: z flipped inside, so `z > 0` always points
/// away from the interface.
#[derive(Clone, Copy, Debug, Default)]
struct Dir {
    v: Vec3,
    inside: bool,
}

/// The phase function value (RGB, conductor Fresnel included) and the density
/// with which the walk samples that outgoing direction.
#[derive(Clone, Copy, Debug)]
struct VertexEval {
    value: Vec3,
    pdf: f32,
}

const ZERO_VERTEX: VertexEval = VertexEval {
    value: Vec3::ZERO,
    pdf: 0.0,
};

/// `x > t`, false for NaN (reads better negated than `!(x > t)`).
#[inline(always)]
fn above(x: f32, t: f32) -> bool {
    x > t
}

/// Exit probability of a direction leaving a vertex (Wang et al. 2022, eqs. (7) and (9)):
/// `G1_dist(d)` upwards, 0 downwards.
#[inline]
fn exit_prob(ndf: &Ndf, d: Vec3) -> f32 {
    if d.z > 0.0 { ndf.g1(d) } else { 0.0 }
}

/// Probability to hit the surface again (Wang et al. 2022, eq. (6)): `1 - G1_dist(d)` upwards,
/// written `Lambda / (1 + Lambda)` for precision, 1 downwards.
#[inline]
fn continue_prob(ndf: &Ndf, d: Vec3) -> f32 {
    if d.z > 0.0 {
        let l = ndf.lambda(d);
        if l.is_finite() { l / (1.0 + l) } else { 1.0 }
    } else {
        1.0
    }
}

impl PositionFree {
    /// A position-free BSDF; `facet` must be a conductor or a dielectric.
    /// `max_bounces` = 0 selects [`default_max_bounces`]; larger values are
    /// clamped to [`MAX_BOUNCES`].
    pub fn new(ndf: Ndf, facet: Facet, estimator: Estimator, max_bounces: u32) -> Self {
        let max_bounces = if max_bounces == 0 {
            default_max_bounces(&ndf, &facet)
        } else {
            max_bounces.min(MAX_BOUNCES)
        };
        let lambert_weight = (0.25 * (ndf.alpha_x * ndf.alpha_y).sqrt()).clamp(0.05, 0.5);
        PositionFree {
            ndf,
            facet,
            estimator,
            max_bounces,
            lambert_weight,
            ms: Microsurface::new(ndf, facet, max_bounces),
        }
    }

    /// The bounce limit in use (the default resolved).
    pub fn max_bounces(&self) -> u32 {
        self.max_bounces
    }

    /// The estimator eval uses.
    pub fn estimator(&self) -> Estimator {
        self.estimator
    }

    /// Conductor Fresnel per channel (the kernel's: 1 for other facets and
    /// for the white conductor).
    #[inline]
    fn conductor_fresnel(&self, cos_i: f32) -> Vec3 {
        self.ms.fresnel(cos_i)
    }

    #[inline]
    fn is_dielectric(&self) -> bool {
        matches!(self.facet, Facet::Dielectric { .. })
    }

    /// Relative index `n_other / n_current` for a ray in the given medium.
    #[inline]
    fn eta_from(&self, inside: bool) -> f32 {
        match self.facet {
            Facet::Dielectric { eta } => {
                if inside {
                    1.0 / eta
                } else {
                    eta
                }
            }
            _ => 1.0,
        }
    }

    /// The vertex term times its entering segment term (Wang et al. 2022, eqs. (2, 8-10)) as a
    /// phase function: a ray travelling along `w` hits a facet and leaves
    /// along `o` (pointing away from the facet). Also returns the density with
    /// which [`Self::sample_vertex`] picks `o`.
    #[inline]
    fn vertex(&self, w: Dir, o: Dir) -> VertexEval {
        self.vertex_impl(w, o, true)
    }

    /// The density of [`Self::vertex`] alone (skips the conductor Fresnel).
    #[inline]
    fn vertex_pdf(&self, w: Dir, o: Dir) -> f32 {
        self.vertex_impl(w, o, false).pdf
    }

    #[inline(always)]
    fn vertex_impl(&self, w: Dir, o: Dir, with_value: bool) -> VertexEval {
        let v = -w.v; // the facets are seen from -w
        let sig = self.ndf.sigma(v);
        if !above(sig, 1e-30) {
            return ZERO_VERTEX;
        }
        if w.inside == o.inside {
            // Reflection: m is the half vector of v and o, facing up.
            let h = v + o.v;
            let len2 = h.length_squared();
            if !above(len2, 1e-20) {
                return ZERO_VERTEX;
            }
            let mut m = h / len2.sqrt();
            if m.z < 0.0 {
                m = -m;
            }
            let ci = v.dot(m);
            let co = o.v.dot(m);
            // chi+ on both sides of the facet (Wang et al. 2022, eq. (8)).
            if ci <= 0.0 || co <= 0.0 {
                return ZERO_VERTEX;
            }
            // D_v(m) / (4 |o.m|): the reflection Jacobian.
            let base = ci * self.ndf.d(m) / (sig * 4.0 * co);
            match self.facet {
                Facet::Dielectric { .. } => {
                    let p = fresnel::dielectric(ci, self.eta_from(w.inside)) * base;
                    VertexEval {
                        value: Vec3::splat(p),
                        pdf: p,
                    }
                }
                _ => VertexEval {
                    value: if with_value {
                        self.conductor_fresnel(ci) * base
                    } else {
                        Vec3::ZERO
                    },
                    pdf: base,
                },
            }
        } else {
            if !self.is_dielectric() {
                return ZERO_VERTEX;
            }
            // Refraction (Walter et al. 2007), o expressed in w's frame.
            let eta = self.eta_from(w.inside);
            let ot = flip_z(o.v);
            let Some(RefractionHalf {
                h: m,
                ci,
                co,
                jacobian,
            }) = refraction_half(v, ot, eta)
            else {
                return ZERO_VERTEX;
            };
            let f = fresnel::dielectric_pair(ci, co, eta);
            let p = (1.0 - f) * ci * self.ndf.d(m) / sig * jacobian;
            VertexEval {
                value: Vec3::splat(p),
                pdf: p,
            }
        }
    }

    /// Samples the outgoing direction of a vertex hit by a ray travelling
    /// along `w` (visible normals, then Fresnel: sec. 4.3). Returns it with the
    /// weight `phase / pdf` (conductor Fresnel, or 1 for dielectrics).
    #[inline]
    fn sample_vertex(&self, w: Dir, rng: &mut Rng) -> Option<(Dir, Vec3)> {
        let (u1, u2) = (rng.next_f32(), rng.next_f32());
        let v = -w.v;
        let m = self.ndf.sample_visible(v, u1, u2);
        let ci = v.dot(m);
        if !above(ci, 0.0) {
            return None;
        }
        match self.facet {
            Facet::Dielectric { .. } => {
                let eta = self.eta_from(w.inside);
                let f = fresnel::dielectric(ci, eta);
                if rng.next_f32() < f {
                    let o = reflect(v, m);
                    Some((
                        Dir {
                            v: o,
                            inside: w.inside,
                        },
                        Vec3::ONE,
                    ))
                } else {
                    let t = refract(v, m, eta)?;
                    if t == Vec3::ZERO {
                        return None;
                    }
                    Some((
                        Dir {
                            v: flip_z(t),
                            inside: !w.inside,
                        },
                        Vec3::ONE,
                    ))
                }
            }
            _ => {
                let o = reflect(v, m);
                Some((
                    Dir {
                        v: o,
                        inside: false,
                    },
                    self.conductor_fresnel(ci),
                ))
            }
        }
    }

    /// Maps a query pair to side frames: the first travel direction `d_0`
    /// and the last direction `d_k`; `None` when the pair cannot connect
    /// (conductor transmission).
    #[inline]
    fn endpoints(&self, wi: Vec3, wo: Vec3) -> Option<(Dir, Dir)> {
        if self.is_dielectric() {
            let wi_in = wi.z < 0.0;
            let wo_in = wo.z < 0.0;
            let to_side = |v: Vec3, inside: bool| if inside { flip_z(v) } else { v };
            Some((
                Dir {
                    v: to_side(-wi, wi_in),
                    inside: wi_in,
                },
                Dir {
                    v: to_side(wo, wo_in),
                    inside: wo_in,
                },
            ))
        } else {
            let (wi, wo) = if wi.z < 0.0 {
                (flip_z(wi), flip_z(wo))
            } else {
                (wi, wo)
            };
            if wo.z <= 0.0 {
                return None;
            }
            Some((
                Dir {
                    v: -wi,
                    inside: false,
                },
                Dir {
                    v: wo,
                    inside: false,
                },
            ))
        }
    }

    /// Bidirectional estimator with the balance heuristic (Wang et al. 2022, eqs. (14-16)),
    /// subpaths stored in arrays of `CAP` entries.
    fn eval_bdpt<const CAP: usize>(&self, d0: Dir, dk: Dir, rng: &mut Rng) -> Vec3 {
        let n_max = (self.max_bounces as usize).min(CAP);
        let exit = exit_prob(&self.ndf, dk.v);
        if exit <= 0.0 || n_max == 0 {
            return Vec3::ZERO;
        }
        let ndf = &self.ndf;
        // Camera subpath: state c has travel direction cam_dir[c] (= d_c)
        // and throughput cam_beta[c]; vertex j < c was sampled with density
        // cam_pf[j] and has reverse density cam_pb[j].
        let mut cam_dir = [Dir::default(); CAP];
        let mut cam_beta = [Vec3::ZERO; CAP];
        let mut cam_pf = [0.0f32; CAP];
        let mut cam_pb = [0.0f32; CAP];
        cam_dir[0] = d0;
        cam_beta[0] = Vec3::ONE;
        let mut n_cam = 1;
        // Exit factor of the last stored camera direction (in its beta).
        let mut e_last = 1.0f32;
        while n_cam < n_max {
            let c = n_cam - 1;
            let w = cam_dir[c];
            // Roulette on going past vertex c with the factor already in
            // cam_beta[c] (as in eval_pt).
            let mut beta = cam_beta[c];
            if e_last < 1.0 {
                if rng.next_f32() >= e_last {
                    break;
                }
                beta /= e_last;
            }
            let Some((o, weight)) = self.sample_vertex(w, rng) else {
                break;
            };
            let fwd = self.vertex_pdf(w, o);
            let rev = self.vertex_pdf(
                Dir {
                    v: -o.v,
                    inside: o.inside,
                },
                Dir {
                    v: -w.v,
                    inside: w.inside,
                },
            );
            e_last = continue_prob(ndf, o.v);
            let beta = beta * weight * e_last;
            if !(above(fwd, 0.0) && above(rev, 0.0) && above(beta.max_element(), 0.0)) {
                break;
            }
            cam_pf[c] = fwd;
            cam_pb[c] = rev;
            cam_dir[n_cam] = o;
            cam_beta[n_cam] = beta;
            n_cam += 1;
        }
        // Light subpath: the walk from wo. State q travels along lig_dir[q]
        // (the reverse of d_{n-q}); the forward vertex it sampled has
        // forward density lig_pf[q] and was sampled with lig_pb[q].
        let mut lig_dir = [Dir::default(); CAP];
        let mut lig_beta = [Vec3::ZERO; CAP];
        let mut lig_pf = [0.0f32; CAP];
        let mut lig_pb = [0.0f32; CAP];
        lig_dir[0] = Dir {
            v: -dk.v,
            inside: dk.inside,
        };
        lig_beta[0] = Vec3::splat(exit);
        let mut n_lig = 1;
        let mut e_last = 1.0f32;
        while n_lig < n_max {
            let q = n_lig - 1;
            let u = lig_dir[q];
            let mut beta = lig_beta[q];
            if e_last < 1.0 {
                if rng.next_f32() >= e_last {
                    break;
                }
                beta /= e_last;
            }
            let Some((o, weight)) = self.sample_vertex(u, rng) else {
                break;
            };
            // The forward vertex: in along -o, out along -u.
            let fwd_in = Dir {
                v: -o.v,
                inside: o.inside,
            };
            let fwd_out = Dir {
                v: -u.v,
                inside: u.inside,
            };
            let fwd_pdf = self.vertex_pdf(fwd_in, fwd_out);
            let walk_pdf = self.vertex_pdf(u, o);
            if !(above(walk_pdf, 0.0) && above(fwd_pdf, 0.0)) {
                break;
            }
            // The reversed vertex sees the same facet at the same angle, so
            // the forward phase is the walk's Fresnel weight times fwd_pdf.
            let fwd = VertexEval {
                value: weight * fwd_pdf,
                pdf: fwd_pdf,
            };
            // The forward exit factor e(-o) of the new direction.
            e_last = continue_prob(ndf, fwd_in.v);
            let beta = beta * fwd.value * (e_last / walk_pdf);
            if !(above(beta.max_element(), 0.0) && beta.is_finite()) {
                break;
            }
            lig_pf[q] = fwd.pdf;
            lig_pb[q] = walk_pdf;
            lig_dir[n_lig] = o;
            lig_beta[n_lig] = beta;
            n_lig += 1;
        }
        // Join camera state s with light state t at vertex s of a path of
        // n = s + t + 1 vertices.
        let mut sum = Vec3::ZERO;
        for s in 0..n_cam {
            let d_s = cam_dir[s];
            for t in 0..n_lig.min(n_max - s) {
                let out = Dir {
                    v: -lig_dir[t].v,
                    inside: lig_dir[t].inside,
                };
                let conn = self.vertex(d_s, out);
                if !above(conn.pdf, 0.0) {
                    continue;
                }
                let rev = self.vertex_pdf(
                    lig_dir[t],
                    Dir {
                        v: -d_s.v,
                        inside: d_s.inside,
                    },
                );
                let n = s + t + 1;
                // pf(j), pb(j) over the whole path (Wang et al. 2022, eq. (14)).
                let pf = |j: usize| -> f32 {
                    if j < s {
                        cam_pf[j]
                    } else if j == s {
                        conn.pdf
                    } else {
                        lig_pf[n - 1 - j]
                    }
                };
                let pb = |j: usize| -> f32 {
                    if j < s {
                        cam_pb[j]
                    } else if j == s {
                        rev
                    } else {
                        lig_pb[n - 1 - j]
                    }
                };
                // Balance heuristic (Wang et al. 2022, eq. (15)): sum over s' of p_{s'} / p_s.
                let mut denom = 1.0f32;
                let mut r = 1.0f32;
                for j in s..n - 1 {
                    r *= pf(j) / pb(j + 1);
                    denom += r;
                }
                r = 1.0;
                for j in (0..s).rev() {
                    r *= pb(j + 1) / pf(j);
                    denom += r;
                }
                if !denom.is_finite() {
                    continue;
                }
                let c = cam_beta[s] * conn.value * lig_beta[t] / denom;
                if c.is_finite() {
                    sum += c;
                }
            }
        }
        sum
    }
}

impl ScatterModel for PositionFree {
    fn eval(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        let Some((d0, dk)) = self.endpoints(wi, wo) else {
            return Vec3::ZERO;
        };
        match self.estimator {
            Estimator::Pt => {
                // The shared walk, next event at every vertex with the
                // exact exit factor, Russian roulette past it (module docs).
                let opt = WalkOptions {
                    forced: 0,
                    mis: false,
                    order_one: true,
                    roulette: true,
                };
                let mut f = Vec3::ZERO;
                microsurface::walk::<ExitTerm, _>(&self.ms, wi, wo, rng, opt, &mut f);
                f
            }
            Estimator::Bdpt => {
                if self.max_bounces <= 16 {
                    self.eval_bdpt::<16>(d0, dk, rng)
                } else if self.max_bounces <= 64 {
                    self.eval_bdpt::<64>(d0, dk, rng)
                } else {
                    self.eval_bdpt::<{ MAX_BOUNCES as usize }>(d0, dk, rng)
                }
            }
        }
    }

    fn sample(&self, wi: Vec3, rng: &mut Rng) -> Sample {
        let u = [rng.next_f32(), rng.next_f32(), rng.next_f32()];
        self.sample_with(wi, u, rng)
    }

    fn sample_with(&self, wi: Vec3, u: [f32; 3], rng: &mut Rng) -> Sample {
        // Sec. 4.3's walk on the shared kernel: visible normals, Fresnel as
        // the choice (dielectric) or the weight (conductor), G1_dist(d) as
        // the probability to leave along an upward d.
        match microsurface::sample_walk::<ExitTerm, _>(&self.ms, wi, u, rng, |_| {}) {
            Ok(e) if e.wo.z != 0.0 && e.wo.is_finite() => {
                Sample::new(wi, e.wo, e.weight, self.pdf(wi, e.wo))
            }
            _ => Sample::ABSORBED,
        }
    }

    fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        // The walks' approximate pdf: the first vertex with weight 1 - c, a
        // Lambert lobe (both hemispheres for dielectrics) with weight c.
        microsurface::approximate_pdf(&self.ms, self.lambert_weight, wi, wo)
    }
}

impl PositionFree {
    /// POSITION_FREE for a validated description: Smith NDFs (Beckmann,
    /// GGX and Student-T: tests/position_free.rs), conductor or dielectric
    /// facets.
    pub(crate) fn from_desc(d: &MaterialDesc, facet: Facet) -> Result<Self, Error> {
        if matches!(facet, Facet::Diffuse { .. }) {
            return Err(Error::Unsupported);
        }
        Ok(PositionFree::new(
            d.smith_ndf()?,
            facet,
            d.estimator,
            d.max_bounces,
        ))
    }
}
