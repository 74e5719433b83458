//! `MSBSDF_MODEL_VGROOVE` and `MSBSDF_MODEL_VGROOVE_NONSYMMETRIC`: the
//! kaleidoscopic V-groove BRDF of Lee, Jarabo, Jeon, Gutierrez and Kim,
//! *Practical Multiple Scattering for Rough Surfaces* (ACM TOG 37(6), 2018;
//! Lee et al. 2018). Analytic and deterministic: eval never touches the rng.
//!
//! # Model
//!
//! The microsurface is made of infinitely long V-grooves whose peaks lie on
//! the macro-surface; light reflects specularly inside one groove until it
//! leaves. For a pair `(i, o)` every reflection keeps the component along
//! the groove axis, so the groove's cross-section plane contains `n` and the
//! half vector `h` (Lee et al. 2018, eq. 27: `phi_h = phi_s`); the problem is 2D in
//! that plane ([`kaleido`]). Per reflection count `k`:
//!
//! - symmetric grooves (Lee et al. 2018, eqs. 14-17): the facet `s` hit first
//!   solves eq. (5) for `(theta_i, theta_o, k)`; the solutions are
//!   `a = (theta_i + theta_o + 2 pi m) / (2k)` (odd `k`) or
//!   `(theta_i - theta_o - pi + 2 pi m) / (2k)` (even `k`), of which only
//!   those inside the window where `k` reflections are possible (eq. 4)
//!   are tried (the paper's two solutions `s_1`, `s_2`);
//!   `f |o.n| = sum |i.s| D(s) G_k prod_j F_j sin(theta_s) / (k sin(theta_h) 4 |o.h| |i.n|)`;
//! - nonsymmetric grooves (Lee et al. 2018, eqs. 20-23): the other facet's angle
//!   `theta_r` is independent with density `P(theta_r)` (eq. 20), the first
//!   facet solves eq. (8) for each `theta_r`, and the `theta_r` integral is
//!   done by Gauss-Legendre quadrature over the interval where `k`
//!   reflections are possible (`NS_SEGMENTS` x 8 nodes per `(k, solution)`);
//!   the Jacobian uses `0.5 |0.5 - (-1)^k (k + 0.5)|` in place of `k`.
//!
//! `G_k` is the fraction of the first facet's projected width whose light
//! leaves after exactly `k` reflections ([`kaleido::Hit::g`]); Fresnel is
//! applied per reflection with the conductor reflectance at each
//! reflection's own cosine (eq. 11; complex IOR per RGB channel), in closed
//! form on the three channels at once ([`ftable`]; it replaced a
//! per-material table whose construction made creating a material cost
//! 7-8 us). `k = 1` is Cook-Torrance with the V-groove `G` (eq. 25), and
//! the symmetric eval computes it that way (see Cost).
//!
//! With F = 1 the model conserves energy exactly when no count is dropped:
//! the lit parts of the two walls of a groove fill its opening, so
//! `integral |i.s| D(s) lit(s) ds = |i.n|` for any centrally symmetric NDF
//! (symmetric grooves), and with independent wall angles drawn from
//! `P(theta) ∝ D sin^2` the groove population has left and right walls both
//! distributed as `D` (eq. 19), so the same holds for nonsymmetric grooves.
//!
//! # Number of reflections
//!
//! The sum over `k` stops at `N`, chosen from the roughness so that the
//! facets whose grooves allow more than `N` reflections carry at most 0.1%
//! of the projected facet area: the 99.9% point of Table 2's criterion
//! ([`dist::max_bounces_at_percentile`], which reproduces Table 2 exactly)
//! with the larger roughness of the two axes. Examples: GGX and Phong
//! alpha 1: 50; GGX 0.6: 30, 0.5: 25, 0.3: 15; Phong 0.6: 6, 0.5: 4;
//! Beckmann 1: 5, 0.5: 3. The energy actually dropped, measured with F = 1
//! (`tests/vgroove.rs`), is largest at normal incidence: 0.097% for GGX
//! alpha 1, 0.09% for GGX 0.6; at 80 degrees it is below 0.02%. GGX above
//! alpha ~5 would need more than `MAX_BOUNCES` = 256 and then drops more.
//! A nonzero `max_bounces` in the description overrides `N`. Table 2's own
//! 99% column (`N` = 16 for GGX alpha 1) would drop about 1% of the energy.
//!
//! # Sampling (Lee et al. 2018, sec. 6)
//!
//! The first facet is drawn from the visible normals (Beckmann, GGX; the
//! paper allows it) or from `D(s) s.z` (Phong), the partner angle
//! (nonsymmetric) from the tabulated inverse CDF of `P(theta_r | phi)`
//! (compile-time tables, `src/tables/vgroove_partner_*.bin`), and
//! `k` with probability `G_k / lit`; a count above `N` drops the sample (flag `ABSORBED`). `pdf` sums the same choices over all
//! `(k, facet)` solutions reaching `o`, so it is the exact density of
//! `sample` for the symmetric model and a quadrature of it for the
//! nonsymmetric one. The weight is `eval / pdf`.
//!
//! # Singularity at the mirror direction
//!
//! For `k >= 2` the Jacobian carries `1 / sin(theta_h)` (eq. 14): a genuine
//! integrable singularity at mirror reflection (Lee et al. 2018, sec. 8: multiple
//! scattering focuses towards the mirror direction). We evaluate it with
//! `sin(theta_h)` floored at [`SIN_THETA_H_MIN`] = 1e-4, which caps the value
//! at about 10^4 times its typical size and changes the albedo by less than
//! 1e-4 (the cone `theta_h < 1e-4` has solid angle 3e-8 sr).
//!
//! # Discontinuities (Lee et al. 2018, Fig. 14)
//!
//! Seed 002 attributes the bands of Fig. 14 to the V-groove shadowing and
//! masking. With `G_k` computed exactly from the zone offsets (module
//! [`kaleido`]), every term is a continuous function of `(i, o)`: offsets
//! are continuous, `clamp` and `min` are continuous, a zone shrinks to zero
//! width before it disappears, and a facet's contribution `|i.s| G_k` goes to
//! zero as it turns away. What remains are slope discontinuities (kinks),
//! which render as the sharp-edged bands of Fig. 14, and one singularity:
//!
//! | where (first facet `s`, in the groove plane) | what switches | kind | terms |
//! |---|---|---|---|
//! | `G1(i, h) = G1(o, h)` (eq. 3) | shadowing-limited to masking-limited | kink | `k = 1` |
//! | `T_m = f_lo` or `T_m = f_a` (eq. 6, 9: zone boundaries `f_k`) | a reflection count appears or vanishes (eq. 4 floor) | kink | `k`, `k + 1` |
//! | `psi_b = pi`, i.e. `theta_i = pi/2 - theta_r` (`theta_s` when symmetric) | the other wall starts shadowing (`f_b = 0`) | kink | all `k` |
//! | `psi_j = 0` (virtual wall `j` through the groove bottom) | threshold `t_j` reaches 0 | kink | `k > j` |
//! | `|theta_s - theta_i| = pi/2` | facet turns away from the light | kink (value -> 0) | all `k` |
//! | `theta_h = 0` (mirror direction) | `1 / sin(theta_h)` of eq. (14) | integrable singularity, floored | `k >= 2` |
//! | `k = N` | truncation | missing energy (< 0.1%), no jump | `k > N` |
//!
//! Measured (`tests/vgroove.rs`, GGX alpha 0.5, theta_i = 40 degrees,
//! theta_o scanned off the mirror plane, `k = 1..4`, both models): the
//! largest relative change between neighbouring samples falls 4x when the
//! step is 4x finer (e.g. symmetric `k = 2`: 5.6% -> 1.4% at theta_o = -70
//! degrees), i.e. steep kinks, no jump.
//!
//! # Cost
//!
//! The symmetric eval (second round) computes the `k = 1` term in 3D as
//! Cook-Torrance with the V-groove `G` (eq. 25; `symmetric_k1`: no groove
//! frame, no `atan2`), then runs an exact pre-test of the counts `k >= 2`
//! (`symmetric_tail_x`) for each of the two groove frames (`e`, `-e`) and
//! the two parities of `k`: over `k >= 2` only one `X_j` per frame and
//! parity can have solutions (`X = pi - ti - to` odd, `pi - ti + to`
//! even), and the conditions of eq. (4) at fixed `X` hold on a prefix of
//! the counts, so testing them at the smallest count (2 or 3) decides
//! whether any count of that parity has a solution (a few flops on the two
//! in-plane angles). Only the frames and parities that pass are scanned as
//! before: the counts that can have a solution for that `X` from a closed
//! form (`symmetric_k_range`, when `N >= 10`) or a scan that stops at the
//! first count out of the window, and per solution `D`, `G_k` without
//! trigonometry ([`kaleido::Hit::g_sines`] with the wall sines in closed
//! form, `symmetric_tail_sines`), a Taylor `sin`/`cos` of its facet angle
//! and `k` evaluations of the SIMD Fresnel reflectance ([`ftable`]). When
//! `N = 2` (Beckmann and Phong at low roughness) the pre-test is done
//! before the in-plane angles are computed, from the half-angle tangents
//! (`two_reflections_possible`: `k = 2` has a solution iff
//! `|3 ti + to| <= pi` and `|ti + 3 to| <= pi`), so a pair without one
//! pays no `atan2` at all. The pre-test lets through every pair with a
//! `k >= 2` solution and, for GGX and Phong, only those (Beckmann: it
//! also lets through pairs whose `k >= 2` facets have `D` underflowing to
//! 0, e.g. 44% skipped of 99% without a `k >= 2` term at alpha 0.05).
//! Fraction of pairs skipping the `k >= 2` scan, cosine-distributed `wi`
//! and `wo` (`tests/vgroove.rs`, 2000 pairs): 0.44-0.47 for `N = 2`
//! (Beckmann, Phong alpha <= 0.2), 0.27-0.29 otherwise (GGX at every
//! roughness, Beckmann and Phong from alpha 0.5); for the timing pairs
//! below (uniform over the hemisphere): 0.69 for `N = 2`, 0.50 otherwise.
//!
//! Every replacement is tested against what it replaces:
//! [`VGroove::with_full_scan`] keeps the first round's path (every count,
//! `k = 1` included, through the groove frames, no pre-test) and
//! `vgroove_fast_path_matches_full_scan` checks eval and pdf within 1e-6
//! relative (measured <= 1.2e-7) on 8000 pairs per material (uniform,
//! cosine, sampled, near mirror / normal / grazing) for Beckmann, GGX and
//! Phong at alpha 0.05 to 2 and anisotropic, gold and F = 1, and, by brute
//! force, that every skipped pair has no `k >= 2` contribution in the full
//! scan. On the 1024 timing pairs below, eval, pdf and sample outputs are
//! bit-identical to the first round for all nine materials. From the first
//! round: `atan2_pos` and `sin_cos_quadrant` within 5e-16 of libm, the
//! wall sines within 1e-12 of `sin`, `g_sines` within 1e-12 of
//! [`kaleido::Hit::g`], the count range against a brute-force scan of all
//! counts, the Fresnel table within 5e-5 of `conductor_rgb` per
//! reflection and end to end (`TABLE_M = 32`; 2.5e-6 and 1e-5 at the
//! first round's `TABLE_M = 104`); that round itself changed eval
//! by at most 1.3e-6 relative from the original implementation (exact
//! `conductor_rgb`, libm trigonometry, a scan of every `k <= N`).
//!
//! Measured on gold with the same material as SINGLE, 1024 random direction
//! pairs (uniform over the hemisphere, `z >= 0.02`). Instructions per call
//! from callgrind (`scripts/vgroove_ir.sh`; load-independent): original ->
//! first round -> second round (ratio to SINGLE's same call; SINGLE: GGX
//! eval 589, pdf 313, sample 820 / 786 / 732 at alpha 0.2 / 0.5 / 1;
//! Beckmann eval 1184 / 1117 / 1055, pdf 581 / 549 / 518, sample 3802 /
//! 3746 / 3543; SINGLE has no Phong):
//!
//! | NDF, alpha (N) | eval | pdf | sample |
//! |---|---|---|---|
//! | GGX 0.2 (11) | 6299 -> 3420 -> 2763 (4.7x) | 4599 -> 2684 -> 2024 (6.5x) | 11960 -> 6820 -> 6466 (7.9x) |
//! | GGX 0.5 (25) | 9497 -> 4328 -> 3685 (6.3x) | 6148 -> 2931 -> 2285 (7.3x) | 15851 -> 7969 -> 7545 (9.6x) |
//! | GGX 1 (50) | 14224 -> 5529 -> 4895 (8.3x) | 8297 -> 3122 -> 2485 (7.9x) | 31867 -> 13896 -> 13528 (18.5x) |
//! | Beckmann 0.2 (2) | 3020 -> 2228 -> 1380 (1.17x) | 2841 -> 2263 -> 1415 (2.4x) | 7933 -> 6468 -> 6075 (1.6x) |
//! | Beckmann 0.5 (3) | 3935 -> 2676 -> 2001 (1.8x) | 3465 -> 2569 -> 1894 (3.5x) | 8533 -> 6835 -> 6329 (1.7x) |
//! | Beckmann 1 (5) | 4834 -> 3145 -> 2378 (2.3x) | 4024 -> 2880 -> 2113 (4.1x) | 9882 -> 7514 -> 6864 (1.9x) |
//! | Phong 0.2 (2) | 2350 -> 1497 | 2104 -> 1247 | 4616 -> 4284 |
//! | Phong 0.5 (4) | 3004 -> 2281 | 2612 -> 1885 | 5085 -> 4697 |
//! | Phong 1 (50) | 5825 -> 5182 | 3369 -> 2721 | 11444 -> 11223 |
//!
//! (Phong: first -> second round only; later rounds of other work moved
//! these figures, e.g. GGX 0.5 eval 4045 and Beckmann 0.5 eval 2094 before
//! the facet `D` became the crate's single-precision `Ndf::d`, 4126 and
//! 2034 after, same script and pairs.) The `k = 1` term alone
//! (`max_bounces = 1`, `MAXB=1 scripts/vgroove_ir.sh`) went from 1701 /
//! 1775 / 1850 instructions (GGX / Beckmann / Phong) to 641 / 710 /
//! 706-780: 1.09x SINGLE's whole eval for GGX, 0.6-0.67x for Beckmann.
//!
//! Nanoseconds (`examples/vgroove_timing.rs`, minimum of 5 trials, first-
//! and second-round binaries run alternately on 2 shared cores at load
//! ~4, so +-20%): eval GGX 0.2 / 0.5 / 1: 420 / 514 / 623 -> 318 / 425 /
//! 556 ns (SINGLE 54-56 ns: 5.8x / 7.7x / 9.9x); Beckmann 0.2 / 0.5 / 1:
//! 259 / 315 / 362 -> 159 / 233 / 271 ns (SINGLE 129 / 118 / 109 ns:
//! 1.24x / 2.0x / 2.5x); Phong 0.2 / 0.5 / 1: 275 / 342 / 653 -> 160 /
//! 259 / 569 ns; pdf GGX 0.2 / 1: 342 / 357 -> 240 / 295 ns; sample GGX 1:
//! about 1600 ns either way (SINGLE 110 ns).
//!
//! So the 1.25x goal per eval is reached for Beckmann at alpha 0.2
//! (`N = 2`): 1.17x by instructions, 1.22x-1.24x in time (three runs),
//! and by no other measured material: Beckmann 0.5 / 1 are at 1.8x / 2.3x,
//! GGX at 4.7x-8.3x. What is left is the multiple scattering itself: for
//! GGX, 50-73% of the pairs (uniform / cosine) have `k >= 2` solutions
//! (the fraction barely depends on the roughness: GGX's `D` is nonzero at
//! every facet angle, so it is the groove geometry that decides), about 3
//! solutions per eval at alpha 1 (6 per pair that has any), each paying `k` Fresnel lookups
//! (about 50 instructions each, ~35 per eval at alpha 1: 40% of the
//! eval), `D`, `G_k`, the Taylor `sin`/`cos` (~45) and the groove set-up
//! (~50); the pre-test and the two `atan2` cost about 150 per pair. Even
//! the `k = 1` term alone is 1.09x SINGLE's GGX eval (Cook-Torrance with
//! an `f64` half vector and a table Fresnel against SINGLE's `f32`
//! Smith-GGX). Sampled directions sit near the mirror direction, where
//! every pair has long paths, so sample gains little (3-9%). The paper's
//! 15-20% is the overhead on a whole frame, which `scripts/vgroove_frame.sh`
//! measures with the Embree tracer (`c_examples/scenes/conductors.scene`,
//! nine conductor spheres, 32 spp, one thread, CPU time, minimum of 3
//! runs, every material forced to the model): VGROOVE / SINGLE with
//! Beckmann 1.40 after the second round (1.53 after the first, 1.62-1.80
//! originally), with every sphere at Beckmann alpha 0.2 (`N = 2`) 1.19
//! (1.53, 1.64), with GGX 3.0 (3.1-3.2, 4.6-4.9); 32 spp. That scene is nine spheres under a sky:
//! BSDF calls dominate its frame time, so the frame ratio stays close to
//! the per-call ratio; a scene with more geometry and texturing per path
//! vertex (the paper's) dilutes it.
//!
//! The nonsymmetric eval multiplies the solutions by its 16 quadrature
//! nodes per `(k, X)`: per node it now pays Taylor `sin`/`cos` of both wall
//! angles, the partner density from them, `G_k` from the wall-sine
//! recurrence and the Fresnel lookups. Instructions per eval: GGX 0.2 / 0.5
//! / 1: 227k / 388k / 657k -> 97k / 180k / 366k (165x / 306x / 622x
//! SINGLE); Beckmann: 61k / 98k / 142k -> 31k / 48k / 66k (27x / 43x /
//! 63x).
//!
//! These counts were taken with the per-material Fresnel table (33 nodes,
//! cubic interpolation) that [`ftable`]'s closed form replaced: eval now
//! costs about 10% more instructions (GGX, roughness 0.2-0.9: 4131 -> 4528
//! per eval, `cargo bench --bench init -- --callgrind VGROOVE`), creating a
//! material about 50x less (37962 -> 732 instructions), and
//! `size_of::<Material>()` no longer carries the 528-byte table.

// `!(x > 0.0)` is used on purpose: it is also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod dist;
pub mod ftable;
pub mod kaleido;

use crate::bsdf::{Sample, ScatterModel};
use crate::desc::{MIN_ALPHA, MaterialDesc, NdfId};
use crate::facet::Facet;
use crate::frame::flip_z;
use crate::rng::Rng;
use crate::status::Error;
use dist::{Family, GrooveNdf};
use ftable::FresnelTable;
use glam::{DVec3, Vec3, Vec3A};
use kaleido::Hit;
use std::f64::consts::{FRAC_PI_2, PI};

/// Floor of `sin(theta_h)` in the `1 / sin(theta_h)` factor of eq. (14).
pub const SIN_THETA_H_MIN: f64 = 1e-4;

/// Quantile of the projected facet area whose reflection count sets `N`.
pub const DEFAULT_QUANTILE: f64 = 0.999;

/// Gauss-Legendre segments per `theta_r` interval (8 nodes each).
pub const NS_SEGMENTS: usize = 2;

const GL8_X: [f64; 4] = [
    0.183_434_642_495_649_8,
    0.525_532_409_916_329,
    0.796_666_477_413_626_7,
    0.960_289_856_497_536_3,
];
const GL8_W: [f64; 4] = [
    0.362_683_783_378_362,
    0.313_706_645_877_887_3,
    0.222_381_034_453_374_5,
    0.101_228_536_290_376_3,
];

/// The V-groove BRDF (conductor facets), symmetric or nonsymmetric.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VGroove {
    ndf: GrooveNdf,
    /// Conductor reflectance over the cosine (Lee et al. 2018, eq. 11).
    fresnel: FresnelTable,
    /// `eta = 0, k = 1`: every reflection has F = 1 (skips Fresnel).
    mirror: bool,
    n_max: u32,
    symmetric: bool,
    /// Symmetric eval by the groove-frame scan for every count, `k = 1`
    /// included, with no pre-test (the reference for tests:
    /// [`VGroove::with_full_scan`]).
    full_scan: bool,
}

/// What one evaluation accumulates.
#[derive(Clone, Copy)]
struct Want {
    f: bool,
    pdf: bool,
    /// Only this count (0 = all counts up to `N`).
    only_k: u32,
}

impl VGroove {
    /// A V-groove BRDF. `max_bounces = 0` picks `N` from the roughness
    /// ([`DEFAULT_QUANTILE`]); otherwise it is used as given (at most 256).
    pub fn new(
        family: Family,
        alpha_x: f32,
        alpha_y: f32,
        eta: Vec3,
        k: Vec3,
        max_bounces: u32,
        symmetric: bool,
    ) -> Self {
        let ndf = GrooveNdf::new(family, alpha_x, alpha_y);
        let n_max = if max_bounces > 0 {
            max_bounces
        } else {
            let a = alpha_x.max(alpha_y) as f64;
            dist::max_bounces_at_percentile(family, a, DEFAULT_QUANTILE)
        }
        .clamp(1, crate::MAX_BOUNCES);
        VGroove {
            ndf,
            fresnel: FresnelTable::new(eta, k),
            mirror: eta == Vec3::ZERO && k == Vec3::ONE,
            n_max,
            symmetric,
            full_scan: false,
        }
    }

    /// The reflection count limit `N`.
    pub fn max_bounces(&self) -> u32 {
        self.n_max
    }

    /// True for the symmetric model.
    pub fn is_symmetric(&self) -> bool {
        self.symmetric
    }

    /// The facet distribution.
    pub fn ndf(&self) -> &GrooveNdf {
        &self.ndf
    }

    /// This BRDF with the Fresnel table bypassed (every reflection uses
    /// `crate::fresnel::conductor_rgb`): the reference the table is tested
    /// against.
    pub fn with_exact_fresnel(mut self) -> Self {
        self.fresnel = self.fresnel.exact();
        self
    }

    /// This BRDF evaluated as before the `k = 1` closed form and the
    /// `k >= 2` pre-test: every count, `k = 1` included, by the scan over
    /// the two groove frames and the two parities of `k`, for every pair
    /// (the reference the fast path is tested against; same values within
    /// rounding).
    pub fn with_full_scan(mut self) -> Self {
        self.full_scan = true;
        self
    }

    /// False when the pre-test of the symmetric eval proves that no count
    /// `k >= 2` has a solution for `(wi, wo)` (the eval is then the `k = 1`
    /// closed form alone); true otherwise, and always for the nonsymmetric
    /// model. For tests and analysis.
    pub fn multiple_possible(&self, wi: Vec3, wo: Vec3) -> bool {
        if !self.symmetric {
            return true;
        }
        let (wi, wo) = if wi.z < 0.0 {
            (flip_z(wi), flip_z(wo))
        } else {
            (wi, wo)
        };
        let i = wi.as_dvec3().normalize();
        let o = wo.as_dvec3().normalize();
        let h = (i + o).normalize();
        let sin_h = (h.x * h.x + h.y * h.y).sqrt();
        let e = if sin_h > 1e-300 {
            DVec3::new(h.x / sin_h, h.y / sin_h, 0.0)
        } else {
            DVec3::X
        };
        let (ie, oe) = (i.dot(e), o.dot(e));
        let (k0, k1) = (2, self.n_max);
        if k1 < 2 {
            return false;
        }
        if k1 == 2 {
            let rho = (ie * ie + i.z * i.z).sqrt();
            let rho_o = (oe * oe + o.z * o.z).sqrt();
            if !two_reflections_possible(ie, i.z, rho, oe, o.z, rho_o) {
                return false;
            }
        }
        let ti0 = atan2_pos(ie, i.z);
        let to0 = atan2_pos(oe, o.z);
        [1.0f64, -1.0].iter().any(|&sg| {
            let (ti, to) = (sg * ti0, sg * to0);
            [true, false]
                .iter()
                .any(|&odd| symmetric_tail_x(ti, to, odd, k0, k1).is_some())
        })
    }

    /// The conductor reflectance used per reflection.
    pub fn fresnel_table(&self) -> &FresnelTable {
        &self.fresnel
    }

    /// `f(wi, wo; k) |wo.z|` (F included): the `k`-resolved BRDF of eq. (16)
    /// / eq. (23) times the cosine, for tests and analysis.
    pub fn eval_k(&self, wi: Vec3, wo: Vec3, k: u32) -> Vec3 {
        if k == 0 {
            return Vec3::ZERO;
        }
        let w = Want {
            f: true,
            pdf: false,
            only_k: k,
        };
        self.eval_pdf(wi, wo, w).0
    }

    /// Product of the conductor Fresnel reflectances of the `k` reflections
    /// (Lee et al. 2018, eq. 11); `rho` is the in-plane length of the direction.
    #[inline]
    fn fresnel_product(&self, hit: &Hit, k: u32, rho: f64) -> DVec3 {
        if self.mirror {
            return DVec3::ONE;
        }
        let mut prod = Vec3A::ONE;
        // sin(psi_a - j theta_v) by the Chebyshev recurrence.
        let two_c = 2.0 * hit.cos_tv;
        let mut s_prev = hit.sin_psi(0);
        let mut s_cur = hit.sin_psi(1);
        prod *= self.fresnel.eval((rho * s_prev) as f32);
        for _ in 1..k {
            prod *= self.fresnel.eval((rho * s_cur) as f32);
            let next = two_c * s_cur - s_prev;
            s_prev = s_cur;
            s_cur = next;
        }
        Vec3::from(prod.clamp(Vec3A::ZERO, Vec3A::ONE)).as_dvec3()
    }

    /// `(f |o.z|, pdf)` for `wi.z > 0` (after the two-sided flip).
    fn eval_pdf(&self, wi: Vec3, wo: Vec3, want: Want) -> (Vec3, f32) {
        // Conductors are two-sided: a `wi` below mirrors both directions.
        let (wi, wo) = if wi.z < 0.0 {
            (flip_z(wi), flip_z(wo))
        } else {
            (wi, wo)
        };
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return (Vec3::ZERO, 0.0);
        }
        let i = wi.as_dvec3().normalize();
        let o = wo.as_dvec3().normalize();
        let hs = i + o;
        let hl = hs.length();
        if !(hl > 1e-12) {
            return (Vec3::ZERO, 0.0);
        }
        let h = hs / hl;
        let sin_h = (h.x * h.x + h.y * h.y).sqrt();
        let e = if sin_h > 1e-300 {
            DVec3::new(h.x / sin_h, h.y / sin_h, 0.0)
        } else {
            DVec3::X
        };
        let oh = o.dot(h);
        if !(oh > 0.0) {
            return (Vec3::ZERO, 0.0);
        }
        let sigma = if want.pdf { self.ndf.sigma(wi) } else { None };
        let inv_sin_h = 1.0 / sin_h.max(SIN_THETA_H_MIN);
        let mut f = DVec3::ZERO;
        let mut pdf = 0.0f64;
        // In-plane angles for the frame `e`; the frame `-e` negates them.
        let (ie0, oe0) = (i.dot(e), o.dot(e));
        let rho = (ie0 * ie0 + i.z * i.z).sqrt();
        // Grazing beyond what `ti = atan2(ie, i.z)` resolves in f64 (pi/2
        // has an ulp of 2.2e-16): the groove geometry then sees ti = pi/2
        // exactly, the lit fraction no longer vanishes with i.z, and the
        // `/ i.z` of eq. (14) made the nonsymmetric sum grow as 1/i.z (mean
        // sample weight 4e12 at i.z = 1e-30; found by fuzz/dirs_fuzz.c).
        // Treated as the horizon, as the symmetric sum already does.
        if !(i.z > 1e-15 * rho) {
            return (Vec3::ZERO, 0.0);
        }
        let (k0, k1) = self.k_range(want);
        let fast = self.symmetric && !self.full_scan;
        if fast && k0 == 1 {
            let (df, dp) = self.symmetric_k1(i, o, h, oh, sigma, want);
            f += df;
            pdf += dp;
        }
        if fast && k1 < 2 {
            return self.finish(f, pdf);
        }
        let rho_o = || (oe0 * oe0 + o.z * o.z).sqrt();
        if fast && k1 == 2 && !two_reflections_possible(ie0, i.z, rho, oe0, o.z, rho_o()) {
            // Only k = 2 is summed and it has no solution: no atan2 needed.
            return self.finish(f, pdf);
        }
        let (ti0, to0) = (atan2_pos(ie0, i.z), atan2_pos(oe0, o.z));
        // Symmetric, k >= 2: the one `X` per frame and parity that can
        // have solutions, if the pre-test lets it through.
        let mut xs = [[None; 2]; 2];
        if fast {
            let mut any = false;
            for (fr, sg) in [1.0f64, -1.0].iter().enumerate() {
                for (par, odd) in [true, false].iter().enumerate() {
                    let x = symmetric_tail_x(sg * ti0, sg * to0, *odd, k0.max(2), k1);
                    any |= x.is_some();
                    xs[fr][par] = x;
                }
            }
            if !any {
                return self.finish(f, pdf);
            }
        }
        let (inv_rho, inv_rho_o) = (1.0 / rho, 1.0 / rho_o());
        let (sti0, cti) = (ie0 * inv_rho, i.z * inv_rho);
        let (sto0, cto) = (oe0 * inv_rho_o, o.z * inv_rho_o);
        for (fr, sg) in [1.0f64, -1.0].iter().copied().enumerate() {
            if fast && xs[fr] == [None, None] {
                continue;
            }
            let ex = e * sg;
            let ctx = Ctx {
                i,
                ex,
                sti: sg * sti0,
                cti,
                ti: sg * ti0,
                to: sg * to0,
                sto: sg * sto0,
                cto,
                rho,
                oh,
                inv_sin_h,
                sin_h,
                cos_h: h.z,
                sigma,
                want,
            };
            let (df, dp) = if fast {
                self.sum_symmetric_tail(&ctx, xs[fr], k0.max(2), k1)
            } else if self.symmetric {
                self.sum_symmetric(&ctx)
            } else {
                self.sum_nonsymmetric(&ctx)
            };
            f += df;
            pdf += dp;
        }
        self.finish(f, pdf)
    }

    /// `(f |o.z|, pdf)` in the output precision, non-finite and negative
    /// values to 0.
    #[inline]
    fn finish(&self, f: DVec3, pdf: f64) -> (Vec3, f32) {
        let f = f.as_vec3();
        let f = if f.is_finite() {
            f.max(Vec3::ZERO)
        } else {
            Vec3::ZERO
        };
        let pdf = pdf as f32;
        (
            f,
            if pdf.is_finite() && pdf > 0.0 {
                pdf
            } else {
                0.0
            },
        )
    }

    #[inline]
    fn k_range(&self, want: Want) -> (u32, u32) {
        if want.only_k > 0 {
            (want.only_k, want.only_k)
        } else {
            (1, self.n_max)
        }
    }

    /// One solution's contribution: the first facet at angle `a` (given by
    /// its sine and cosine) lit by `hit`, `k` reflections with fraction `g`,
    /// `jac_k = d theta_h / d a`, `partner` the `P(theta_r) d theta_r`
    /// quadrature weight (1 for symmetric grooves).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn contribution(
        &self,
        ctx: &Ctx,
        hit: &Hit,
        (sa, ca): (f64, f64),
        k: u32,
        g: f64,
        jac_k: f64,
        partner: f64,
    ) -> (DVec3, f64) {
        if !(g > 0.0) {
            return (DVec3::ZERO, 0.0);
        }
        let s = ctx.ex * sa + DVec3::new(0.0, 0.0, ca);
        // Lee et al. 2018, eq. (13)/(30): |ds/do| = sin(theta_s) / (c_k sin(theta_h)) / (4 cos(theta_d));
        // for k = 1, s = h and the ratio is exactly 1 (eq. 25).
        let jac = if k == 1 {
            1.0
        } else {
            sa * ctx.inv_sin_h / jac_k
        } / (4.0 * ctx.oh);
        let is = ctx.i.dot(s);
        let d = self.ndf.d(s);
        let mut f = DVec3::ZERO;
        let mut p = 0.0;
        if ctx.want.f {
            // Lee et al. 2018, eq. (14) / (23) times |o.n|.
            let v = is * d * g * jac * partner / ctx.i.z;
            if v > 0.0 {
                f = self.fresnel_product(hit, k, ctx.rho) * v;
            }
        }
        if ctx.want.pdf {
            let lit = hit.lit();
            if lit > 0.0 {
                p = dist::first_pdf_from(is, s.z, d, ctx.sigma) * (g / lit) * jac * partner;
            }
        }
        (f, p)
    }

    /// Symmetric grooves, `k = 1` in 3D, without the groove frame: the
    /// facet is the half vector and the term is Cook-Torrance with the
    /// V-groove shadowing and masking, Lee et al. 2018, eq. (25):
    /// `f |o.z| = F(i.h) D(h) G / (4 i.z)`,
    /// `G = min(1, 2 h.z i.z / (i.h), 2 h.z o.z / (o.h))`, the first two
    /// terms being the lit fraction of the facet ([`Hit::lit`]). Written
    /// as [`VGroove::contribution`] writes it (`i.h / o.h = 1`).
    #[inline]
    fn symmetric_k1(
        &self,
        i: DVec3,
        o: DVec3,
        h: DVec3,
        oh: f64,
        sigma: Option<f64>,
        want: Want,
    ) -> (DVec3, f64) {
        let ih = i.dot(h);
        if !(ih > 0.0 && h.z > 0.0) {
            return (DVec3::ZERO, 0.0);
        }
        let two_hz = 2.0 * h.z;
        let lit = (two_hz * i.z / ih).min(1.0);
        let g = lit.min(two_hz * o.z / oh);
        if !(g > 0.0) {
            return (DVec3::ZERO, 0.0);
        }
        let d = self.ndf.d(h);
        let jac = 1.0 / (4.0 * oh);
        let mut f = DVec3::ZERO;
        let mut p = 0.0;
        if want.f {
            let v = ih * d * g * jac / i.z;
            if v > 0.0 {
                f = if self.mirror {
                    DVec3::splat(v)
                } else {
                    let fr = self.fresnel.eval(ih as f32);
                    Vec3::from(fr.clamp(Vec3A::ZERO, Vec3A::ONE)).as_dvec3() * v
                };
            }
        }
        if want.pdf {
            p = dist::first_pdf_from(ih, h.z, d, sigma) * (g / lit) * jac;
        }
        (f, p)
    }

    /// Symmetric grooves: the facet solutions of eq. (5) per count.
    ///
    /// Writing the first facet as `a = pi/2 - delta`, the solutions of eq.
    /// (5) are `2 k delta = X_j = pi j - base` with `j = k - 2m` of the
    /// parity of `k` (`base = theta_i + theta_o` for odd `k`,
    /// `theta_i - theta_o - pi` for even `k`), and `k` reflections are
    /// possible (eq. 4) only for `L_k <= X_j <= U_k`,
    /// `L_k = (pi/2 - theta_i) 2k / (2k + 1)` increasing and
    /// `U_k = (pi - theta_i) 2k / (2k - 1)` decreasing in `k`. So a handful
    /// of `j` serve every `k`, and each `j` serves a prefix of the counts:
    /// the loop needs no division per count.
    fn sum_symmetric(&self, ctx: &Ctx) -> (DVec3, f64) {
        let (k0, k1) = self.k_range(ctx.want);
        let (ti, to) = (ctx.ti, ctx.to);
        let lim_lo = FRAC_PI_2 - ti;
        let lim_hi = PI - ti;
        let mut f = DVec3::ZERO;
        let mut p = 0.0;
        for odd in [true, false] {
            let base = if odd { ti + to } else { ti - to - PI };
            // Over all k, X lies in [L_1, U_1] (odd) or [L_2, U_2] (even),
            // inside [lim_lo / 2, 2 lim_hi].
            let j_lo = ((base + 0.5 * lim_lo) / PI).ceil_i64();
            let j_hi = ((base + 2.0 * lim_hi) / PI).floor_i64();
            // j has the parity of k.
            let j_first = if (j_lo.rem_euclid(2) == 1) == odd {
                j_lo
            } else {
                j_lo + 1
            };
            for j in (j_first..=j_hi).step_by(2) {
                let x = PI * j as f64 - base;
                if !(x > 0.0) {
                    continue;
                }
                self.symmetric_solutions(ctx, x, odd, (k0, k1), (&mut f, &mut p));
            }
        }
        (f, p)
    }

    /// Symmetric grooves, counts `k >= 2` only, after the pre-test: the
    /// `X` of each parity that passed it ([`symmetric_tail_x`]; `None`
    /// for a parity without solutions), `k0 >= 2`.
    fn sum_symmetric_tail(
        &self,
        ctx: &Ctx,
        xs: [Option<f64>; 2],
        k0: u32,
        k1: u32,
    ) -> (DVec3, f64) {
        let mut f = DVec3::ZERO;
        let mut p = 0.0;
        for (x, odd) in xs.into_iter().zip([true, false]) {
            if let Some(x) = x {
                self.symmetric_solutions(ctx, x, odd, (k0, k1), (&mut f, &mut p));
            }
        }
        (f, p)
    }

    /// The solutions `a = pi/2 - x / 2k` of eq. (5) for one `X_j = x > 0`
    /// and the counts `k` in `k0..=k1` of its parity, added to `acc`.
    #[inline]
    fn symmetric_solutions(
        &self,
        ctx: &Ctx,
        x: f64,
        odd: bool,
        (k0, k1): (u32, u32),
        acc: (&mut DVec3, &mut f64),
    ) {
        let ti = ctx.ti;
        let lim_lo = FRAC_PI_2 - ti;
        let lim_hi = PI - ti;
        // sin u of `symmetric_tail_sines`.
        let su = if odd { ctx.sto } else { -ctx.sto };
        // Worth its division only when N is large (GGX, Phong).
        let (r_lo, r_hi) = if k1 - k0 >= 8 {
            symmetric_k_range(ti, x, k1)
        } else {
            (k0, k1)
        };
        let k_start = k0.max(r_lo);
        let k_end = k1.min(r_hi);
        let mut k = if (k_start % 2 == 1) == odd {
            k_start
        } else {
            k_start + 1
        };
        while k <= k_end {
            let kf = k as f64;
            let tk = 2.0 * kf;
            let eps = 1e-9 * tk;
            if x * (tk + 1.0) < lim_lo * tk - eps || x * (tk - 1.0) > lim_hi * tk + eps {
                break; // L_k only grows and U_k only shrinks with k
            }
            let a = FRAC_PI_2 - x / tk;
            if a > 0.0
                && a < FRAC_PI_2
                && symmetric_count_possible(ti, a, kf)
                // k = 1: the facet is the half vector (eq. 25), its
                // angle is known; else sin a = cos delta and
                // cos a = sin delta, delta = x / 2k in (0, pi/2).
                && let (sa, ca) = if k == 1 {
                    (ctx.sin_h, ctx.cos_h)
                } else {
                    let (sd, cd) = sin_cos_quadrant(x / tk);
                    (cd, sd)
                }
                && let Some(hit) = Hit::with_trig(ti, ctx.sti, ctx.cti, a, sa, ca, a, sa, ca)
            {
                let g = hit.g_sines(k, symmetric_tail_sines(su, ctx.cto, ca, sa));
                let (df, dp) = self.contribution(ctx, &hit, (sa, ca), k, g, kf, 1.0);
                *acc.0 += df;
                *acc.1 += dp;
            }
            k += 2;
        }
    }

    /// Nonsymmetric grooves: eq. (23), the `theta_r` integral by quadrature.
    fn sum_nonsymmetric(&self, ctx: &Ctx) -> (DVec3, f64) {
        let (k0, k1) = self.k_range(ctx.want);
        let (ti, to) = (ctx.ti, ctx.to);
        let shape = self.ndf.plane_shape(ctx.ex.x, ctx.ex.y);
        let norm = self.ndf.partner_norm(shape);
        let mut f = DVec3::ZERO;
        let mut p = 0.0;
        for k in k0..=k1 {
            let kf = k as f64;
            let odd = k % 2 == 1;
            // a(b) = a0 + a1 b from eq. (8); a0 = (base + 2 pi m) / den.
            let (base, den, a1) = if odd {
                (ti + to, kf + 1.0, -(kf - 1.0) / (kf + 1.0))
            } else {
                (ti - to - PI, kf, -1.0)
            };
            // a0 window: a, b in (0, pi/2) and (k - 1) theta_v <= psi_a.
            let (lo, hi) = if k == 1 {
                (0.0, FRAC_PI_2)
            } else if odd {
                (
                    (PI - PI / (kf - 1.0) - PI / (kf + 1.0)).max(0.0),
                    PI * kf / (kf + 1.0),
                )
            } else {
                ((PI - PI / (kf - 1.0)).max(0.0), PI)
            };
            let m_lo = ((den * (lo - 1e-9) - base) / (2.0 * PI)).ceil_i64();
            let m_hi = ((den * (hi + 1e-9) - base) / (2.0 * PI)).floor_i64();
            let jac_k = kaleido::dtheta_h(k, false);
            for m in m_lo..=m_hi {
                let a0 = (base + 2.0 * PI * m as f64) / den;
                let Some((b0, b1)) = beta_interval(a0, a1, kf, ti) else {
                    continue;
                };
                let half = 0.5 * (b1 - b0) / NS_SEGMENTS as f64;
                for seg in 0..NS_SEGMENTS {
                    let mid = b0 + (2 * seg + 1) as f64 * half;
                    for (x, w) in GL8_X.iter().zip(GL8_W.iter()) {
                        for b in [mid - half * x, mid + half * x] {
                            let a = a0 + a1 * b;
                            if !(0.0..FRAC_PI_2).contains(&a) {
                                continue;
                            }
                            // a, b in [0, pi/2]: no libm call.
                            let (sa, ca) = sin_cos_quadrant(a);
                            let (sb, cb) = sin_cos_quadrant(b);
                            let Some(hit) =
                                Hit::with_trig(ti, ctx.sti, ctx.cti, a, sa, ca, b, sb, cb)
                            else {
                                continue;
                            };
                            let g = hit.g_sines(k, wall_sines(&hit, k));
                            if !(g > 0.0) {
                                continue;
                            }
                            let pb = self.ndf.partner_pdf_trig(b, sb, cb, shape, norm) * w * half;
                            if !(pb > 0.0) {
                                continue;
                            }
                            let (df, dp) = self.contribution(ctx, &hit, (sa, ca), k, g, jac_k, pb);
                            f += df;
                            p += dp;
                        }
                    }
                }
            }
        }
        (f, p)
    }

    fn sample_impl(&self, wi: Vec3, rng: &mut Rng) -> Sample {
        let (u1, u2, u3, u4) = (
            rng.next_f32(),
            rng.next_f32(),
            rng.next_f32(),
            rng.next_f64(),
        );
        self.sample_from(wi, u1, u2, u3, u4)
    }

    /// Sampling from given uniforms: `u1, u2` the first facet, `u3` its
    /// partner, `u4` the number of bounces.
    fn sample_from(&self, wi: Vec3, u1: f32, u2: f32, u3: f32, u4: f64) -> Sample {
        let flipped = wi.z < 0.0;
        let wl = if flipped { flip_z(wi) } else { wi };
        let i = wl.as_dvec3().normalize();
        let s = self.ndf.sample_first(wl, u1, u2);
        if !(i.dot(s) > 0.0) {
            return Sample::ABSORBED;
        }
        let sxy = (s.x * s.x + s.y * s.y).sqrt();
        let (e, a) = if sxy > 1e-300 {
            (DVec3::new(s.x / sxy, s.y / sxy, 0.0), sxy.atan2(s.z))
        } else {
            (DVec3::X, 0.0)
        };
        let ie = i.dot(e);
        let ti = ie.atan2(i.z);
        let rho = (ie * ie + i.z * i.z).sqrt();
        let b = if self.symmetric {
            a
        } else {
            self.ndf.sample_partner(self.ndf.plane_shape(e.x, e.y), u3)
        };
        let Some(hit) = Hit::new(ti, a, b) else {
            return Sample::ABSORBED;
        };
        let Some(k) = hit.choose(u4, self.n_max) else {
            return Sample::ABSORBED;
        };
        let to = kaleido::exit_angle(ti, a, b, k);
        let (st, ct) = to.sin_cos();
        // The component along the groove axis is kept by every reflection.
        let iu = i - e * ie - DVec3::new(0.0, 0.0, i.z);
        let o = e * (rho * st) + DVec3::new(0.0, 0.0, rho * ct) - iu;
        let o = o.as_vec3().normalize_or_zero();
        if !(o.z > 0.0) {
            return Sample::ABSORBED;
        }
        let want = Want {
            f: true,
            pdf: true,
            only_k: 0,
        };
        let (f, pdf) = self.eval_pdf(wl, o, want);
        if !(pdf > 0.0) {
            return Sample::ABSORBED;
        }
        let wo = if flipped { flip_z(o) } else { o };
        Sample::new(wi, wo, f / pdf, pdf)
    }
}

/// `ceil` and `floor` to `i64` without a libm call (the baseline x86-64
/// target has no rounding instruction); arguments are small.
trait RoundI64 {
    fn ceil_i64(self) -> i64;
    fn floor_i64(self) -> i64;
}

impl RoundI64 for f64 {
    // Through i32 (the arguments are a few units): a cheaper saturating cast.
    #[inline]
    fn floor_i64(self) -> i64 {
        let t = self as i32; // truncates towards zero
        (if (t as f64) > self { t - 1 } else { t }) as i64
    }
    #[inline]
    fn ceil_i64(self) -> i64 {
        let t = self as i32;
        (if (t as f64) < self { t + 1 } else { t }) as i64
    }
}

/// Per-orientation evaluation context.
struct Ctx {
    i: DVec3,
    ex: DVec3,
    /// `sin` and `cos` of `ti`.
    sti: f64,
    cti: f64,
    ti: f64,
    to: f64,
    /// `sin` and `cos` of `to`.
    sto: f64,
    cto: f64,
    rho: f64,
    oh: f64,
    inv_sin_h: f64,
    /// `sin` and `cos` of the half vector's polar angle (the facet of the
    /// single-reflection solution).
    sin_h: f64,
    cos_h: f64,
    sigma: Option<f64>,
    want: Want,
}

/// Exact test (up to rounding; no trigonometry) that `k` reflections happen
/// for some lit ray of the symmetric groove `a` lit from `ti`: the count
/// `floor((psi_a - asin f) / theta_v) + 1` over `f` in `(f_lo, f_a)`, with
/// `asin f_a = min(psi_a, pi - psi_a)` and `asin f_lo = max(0, pi - psi_b)`
/// (Lee et al. 2018, eq. 4 and Appendix B).
#[inline]
fn symmetric_count_possible(ti: f64, a: f64, kf: f64) -> bool {
    let psi_a = a - ti + FRAC_PI_2;
    let tv = PI - 2.0 * a;
    if !(psi_a > 0.0 && psi_a < PI && tv > 0.0) {
        return false;
    }
    let psi_b = psi_a + tv;
    let hi_ang = psi_a.min(PI - psi_a);
    let lo_ang = (PI - psi_b).max(0.0);
    if lo_ang >= hi_ang + 1e-12 {
        return false; // the other wall shadows the whole facet
    }
    // k - 1 <= (psi_a - lo_ang) / tv and k >= (psi_a - hi_ang) / tv.
    let eps = 1e-9 * kf;
    (kf - 1.0) * tv <= psi_a - lo_ang + eps && kf * tv >= psi_a - hi_ang - eps
}

/// Pre-test of the symmetric counts `k >= 2` (`2 <= k0 <= k`, `k <= k1`)
/// of one parity in one groove frame: the only `X_j` of eq. (5) they can
/// use, or `None` when no count can have a solution there.
///
/// With `a = pi/2 - delta`, `2 k delta = X`, the conditions of
/// [`symmetric_count_possible`] read (`psi_a = pi - delta - ti`,
/// `theta_v = 2 delta`, `asin f_lo = max(0, ti - delta)`,
/// `asin f_a = min(psi_a, pi - psi_a)`): `delta > -ti`,
/// `X - delta <= pi - ti`, `X - 2 delta <= pi - 2 ti` (eq. 4, `k - 1`
/// reflections fit) and `X + 2 delta >= pi - 2 ti` (the `k`-th one
/// happens), and `0 < delta < pi/2`. At fixed `X`, `delta` falls with `k`,
/// so each of the first four holds on a prefix of the counts: some count
/// of the parity has a solution only if they hold at its smallest count
/// `k_min` (2 or 3 from `k0`). Over `k >= 2`, `X` lies in
/// `[0, 4 (pi - ti) / 3] ⊂ (0, 2 pi)`, which holds one `X_j = pi j - base`
/// of each parity: `j = 1` for odd counts (`X = pi - ti - to`) and `j = 0`
/// for even ones (`X = pi - ti + to`). Each bound is relaxed by
/// `1e-9 k1 + 1e-12`, more than the `eps` of the exact test, so the test
/// lets through every pair that test accepts (checked by brute force in
/// `tests/vgroove.rs`); a few flops, no trigonometry.
#[inline]
fn symmetric_tail_x(ti: f64, to: f64, odd: bool, k0: u32, k1: u32) -> Option<f64> {
    let k_min = if (k0 % 2 == 1) == odd { k0 } else { k0 + 1 };
    if k_min > k1 {
        return None;
    }
    // The same expressions as `sum_symmetric` (`PI * j - base`).
    let x = if odd { PI - (ti + to) } else { -(ti - to - PI) };
    let d0 = x / (2 * k_min) as f64;
    let slack = 1e-9 * k1 as f64 + 1e-12;
    let b = PI - 2.0 * ti;
    if x > 0.0
        && d0 + ti > -slack
        && x - d0 <= PI - ti + slack
        && x - 2.0 * d0 <= b + slack
        && x + 2.0 * d0 >= b - slack
    {
        Some(x)
    } else {
        None
    }
}

/// [`symmetric_tail_x`] for `k = 2` alone without the in-plane angles: in
/// either frame, with `ti`, `to` in `(-pi/2, pi/2)`, its conditions at
/// `k_min = 2` (`X = pi - ti + to`) read `-pi < 3 ti + to <= pi` and
/// `-pi <= ti + 3 to <= pi`, i.e. `cos(3 alpha + beta) >= 0` and
/// `cos(alpha + 3 beta) >= 0` with the half angles `alpha = ti / 2`,
/// `beta = to / 2` (the arguments stay in `(-pi, pi)`). Divided by the
/// positive `cos^3 alpha cos beta`, the first is
/// `1 - 3 u^2 - u (3 - u^2) v >= 0` in `u = tan alpha`, `v = tan beta`,
/// and `tan(ti / 2) = sin ti / (1 + cos ti) = ie / (rho + i.z)`. False only
/// when one of them fails by more than 1e-6 (the quotient by
/// `cos^3 alpha cos beta >= 1/4` keeps that a superset of the relaxed
/// bounds of [`symmetric_tail_x`]; checked by brute force in
/// `tests/vgroove.rs`).
#[inline]
fn two_reflections_possible(ie: f64, iz: f64, rho: f64, oe: f64, oz: f64, rho_o: f64) -> bool {
    let u = ie / (rho + iz);
    let v = oe / (rho_o + oz);
    let c1 = 1.0 - 3.0 * u * u - u * (3.0 - u * u) * v;
    let c2 = 1.0 - 3.0 * v * v - v * (3.0 - v * v) * u;
    c1 >= -1e-6 && c2 >= -1e-6
}

/// `[sin psi_{k-2}, sin psi_{k-1}, sin psi_k]` for the symmetric solution
/// `a = pi/2 - delta` of eq. (5) with `2 k delta = x = pi j - base`,
/// without trigonometry: `psi_{k-m} = psi_a - (k - m) theta_v` with
/// `psi_a = pi - delta - ti`, `theta_v = 2 delta` is
/// `pi (1 - j) + theta_o + (2m - 1) delta` (odd `k`) or
/// `-pi j - theta_o + (2m - 1) delta` (even `k`), and `j` has the parity of
/// `k`, so `sin psi_{k-m} = sin(u + (2m - 1) delta)` with `u = theta_o`
/// (odd `k`) or `u = -theta_o` (even `k`). Takes `sin u`,
/// `cos u = cos theta_o`, `sin delta = cos a` and `cos delta = sin a`.
#[inline]
fn symmetric_tail_sines(su: f64, cu: f64, sd: f64, cd: f64) -> [f64; 3] {
    // cos 3d = cos d (4 cos^2 d - 3), sin 3d = sin d (3 - 4 sin^2 d)
    let c3 = cd * (4.0 * cd * cd - 3.0);
    let s3 = sd * (3.0 - 4.0 * sd * sd);
    [su * c3 + cu * s3, su * cd + cu * sd, su * cd - cu * sd]
}

/// `[sin psi_{k-2}, sin psi_{k-1}, sin psi_k]` of any groove by the
/// Chebyshev recurrence `sin(x - t) = 2 cos t sin x - sin(x + t)` from
/// `sin psi_0` and `sin psi_1` (`k` multiply-adds instead of three `sin`
/// calls; entries with a negative index are not used by [`Hit::g_sines`]).
#[inline]
fn wall_sines(hit: &Hit, k: u32) -> [f64; 3] {
    let two_c = 2.0 * hit.cos_tv;
    let (mut s0, mut s1) = (0.0, hit.sin_psi_a); // psi_{-1} unused
    let mut s2 = hit.sin_psi1;
    if k <= 1 {
        return [s0, s1, s2];
    }
    for _ in 2..=k {
        let next = two_c * s2 - s1;
        s0 = s1;
        s1 = s2;
        s2 = next;
    }
    [s0, s1, s2]
}

/// `atan(j / 8)`, `j = 0..=8`.
const ATAN_EIGHTHS: [f64; 9] = [
    0.0,
    0.124_354_994_546_761_44,
    0.244_978_663_126_864_14,
    0.358_770_670_270_572_25,
    0.463_647_609_000_806_1,
    0.558_599_315_343_562_4,
    0.643_501_108_793_284_4,
    0.718_829_999_621_624_5,
    std::f64::consts::FRAC_PI_4,
];

/// `atan2(y, x)` for `x > 0` (or `x = y = 0`), without a libm call: the
/// ratio `r = min / max` of `|y|` and `x` in `[0, 1]` is reduced to
/// `u = (r - c) / (1 + r c)`, `|u| <= 1/16`, about the nearest `c = j / 8`,
/// `atan r = atan c + atan u`, and `atan u` is its Taylor series to `u^15`
/// (truncation below `(1/16)^17 / 17 < 2e-22`). Within `5e-16` of
/// `f64::atan2` (`atan2_pos_matches_libm`).
#[inline]
fn atan2_pos(y: f64, x: f64) -> f64 {
    let ay = y.abs();
    let swap = ay > x;
    let (num, den) = if swap { (x, ay) } else { (ay, x) };
    if !(den > 0.0) {
        return 0.0;
    }
    let r = num / den;
    // Nearest eighth, 0..=8 (an i32 cast is cheaper than a usize one).
    let j = ((r * 8.0 + 0.5) as i32).clamp(0, 8) as usize;
    let c = j as f64 * 0.125;
    let u = (r - c) / (1.0 + r * c);
    let u2 = u * u;
    // u (1 - u^2/3 + u^4/5 - ... - u^14/15)
    let mut p = -1.0 / 15.0;
    for d in [13.0, -11.0, 9.0, -7.0, 5.0, -3.0] {
        p = p * u2 + 1.0 / d;
    }
    let at = ATAN_EIGHTHS[j] + u * (p * u2 + 1.0);
    let at = if swap { FRAC_PI_2 - at } else { at };
    at.copysign(y)
}

/// `(sin d, cos d)` for `d` in `[0, pi/2]` (any `d` in `[-pi/4, 3pi/4]`),
/// without a libm call: Taylor polynomials of `sin` and `cos` about
/// `pi/4` to degree 17 and 16 (truncation below `(pi/4)^18 / 18! < 3e-18`),
/// then the rotation by `pi/4`. Within `4e-16` of `f64::sin_cos`
/// (`sin_cos_quadrant_matches_libm`).
#[inline]
fn sin_cos_quadrant(d: f64) -> (f64, f64) {
    const FRAC_1_SQRT_2: f64 = std::f64::consts::FRAC_1_SQRT_2;
    let y = d - std::f64::consts::FRAC_PI_4;
    let y2 = y * y;
    // 1/n! for the odd (sin) and even (cos) terms.
    const S: [f64; 9] = [
        1.0,
        -1.0 / 6.0,
        1.0 / 120.0,
        -1.0 / 5040.0,
        1.0 / 362_880.0,
        -1.0 / 39_916_800.0,
        1.0 / 6_227_020_800.0,
        -1.0 / 1_307_674_368_000.0,
        1.0 / 355_687_428_096_000.0,
    ];
    const C: [f64; 9] = [
        1.0,
        -0.5,
        1.0 / 24.0,
        -1.0 / 720.0,
        1.0 / 40_320.0,
        -1.0 / 3_628_800.0,
        1.0 / 479_001_600.0,
        -1.0 / 87_178_291_200.0,
        1.0 / 20_922_789_888_000.0,
    ];
    let mut sp = S[8];
    let mut cp = C[8];
    for n in (0..8).rev() {
        sp = sp * y2 + S[n];
        cp = cp * y2 + C[n];
    }
    let (sy, cy) = (sp * y, cp);
    ((sy + cy) * FRAC_1_SQRT_2, (cy - sy) * FRAC_1_SQRT_2)
}

/// Counts `k` for which [`symmetric_count_possible`] can hold at the
/// solution `a = pi/2 - x / 2k` of eq. (5) (`x > 0`): a superset, so that
/// the exact test runs only on a few counts instead of every `k <= N`.
///
/// With `delta = x / 2k` (`a = pi/2 - delta`, `theta_v = 2 delta`,
/// `psi_a = pi - delta - ti`), the conditions of that test read
/// `0 < delta < min(pi/2, pi - ti)`, `delta > -ti` and
/// `delta >= max((pi - 2 ti - x) / 2, x - pi + ti, (x - pi + 2 ti) / 2)`
/// (the count bounds, each relaxed by at most its `eps <= 1e-9 k_max`), so
/// `x / (2 delta_max) <= k <= x / (2 delta_min)`.
#[inline]
fn symmetric_k_range(ti: f64, x: f64, k_max: u32) -> (u32, u32) {
    let d_max = FRAC_PI_2.min(PI - ti);
    // k > x / (2 d_max); `ceil` of a slightly smaller value keeps an
    // integer bound itself (rounding may let the exact test accept it).
    let k_lo = (x / (2.0 * d_max) * (1.0 - 1e-9)).ceil_i64().max(0) as u32;
    let d_min = (-ti)
        .max(0.5 * (PI - 2.0 * ti - x))
        .max(x - PI + ti)
        .max(0.5 * (x - PI + 2.0 * ti))
        - 1e-9 * k_max as f64
        - 1e-12;
    let k_hi = if d_min > 0.0 {
        // Saturating cast; the slack in `d_min` covers rounding.
        ((x / (2.0 * d_min)) as u32).min(k_max)
    } else {
        k_max
    };
    (k_lo, k_hi)
}

/// The `theta_r` interval of a line `a = a0 + a1 b` inside `a, b` in
/// `(0, pi/2)` where `k` reflections are possible, `(k - 1) theta_v <= psi_a`
/// (Lee et al. 2018, eq. 7), and the first facet faces the light.
#[inline]
fn beta_interval(a0: f64, a1: f64, kf: f64, ti: f64) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (0.0f64, FRAC_PI_2);
    // c0 + c1 b >= 0 constraints.
    let mut clip = |c0: f64, c1: f64| {
        if c1 > 0.0 {
            lo = lo.max(-c0 / c1);
        } else if c1 < 0.0 {
            hi = hi.min(-c0 / c1);
        } else if c0 < 0.0 {
            hi = -1.0;
        }
    };
    clip(a0, a1); // a >= 0
    clip(FRAC_PI_2 - a0, -a1); // a <= pi/2
    clip(ti + FRAC_PI_2 - a0, -a1); // psi_a < pi
    // k a - ti + pi/2 - (k - 1) pi + (k - 1) b >= 0
    clip(
        kf * a0 - ti + FRAC_PI_2 - (kf - 1.0) * PI,
        kf * a1 + kf - 1.0,
    );
    if hi > lo { Some((lo, hi)) } else { None }
}

impl ScatterModel for VGroove {
    fn eval(&self, wi: Vec3, wo: Vec3, _rng: &mut Rng) -> Vec3 {
        let want = Want {
            f: true,
            pdf: false,
            only_k: 0,
        };
        self.eval_pdf(wi, wo, want).0
    }

    fn sample(&self, wi: Vec3, rng: &mut Rng) -> Sample {
        self.sample_impl(wi, rng)
    }

    fn sample_with(&self, wi: Vec3, u: [f32; 3], rng: &mut Rng) -> Sample {
        // u[0] picks the bounce count (the lobe), u[1], u[2] the first facet.
        self.sample_from(wi, u[1], u[2], rng.next_f32(), u[0] as f64)
    }

    fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        let want = Want {
            f: false,
            pdf: true,
            only_k: 0,
        };
        self.eval_pdf(wi, wo, want).1
    }
}

impl VGroove {
    /// VGROOVE (`symmetric`) or VGROOVE_NONSYMMETRIC for a validated
    /// description (Lee et al. 2018): conductor facets; Beckmann, GGX and
    /// Phong (`Error::Unsupported` otherwise); Phong roughness at most 1
    /// (its exponent `2 / alpha^2 - 2` must be >= 0; `Error::InvalidArgument`
    /// above).
    pub(crate) fn from_desc(
        d: &MaterialDesc,
        facet: Facet,
        symmetric: bool,
    ) -> Result<Self, Error> {
        let Facet::Conductor { eta, k } = facet else {
            return Err(Error::Unsupported);
        };
        let family = match d.ndf {
            NdfId::Beckmann => Family::Beckmann,
            NdfId::Ggx => Family::Ggx,
            NdfId::Phong if d.alpha_x > 1.0 || d.alpha_y > 1.0 => {
                return Err(Error::InvalidArgument);
            }
            NdfId::Phong => Family::Phong,
            _ => return Err(Error::Unsupported),
        };
        Ok(VGroove::new(
            family,
            d.alpha_x.max(MIN_ALPHA),
            d.alpha_y.max(MIN_ALPHA),
            eta,
            k,
            d.max_bounces,
            symmetric,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// [`atan2_pos`] agrees with libm for `x > 0`, including the
    /// extremes.
    #[test]
    fn atan2_pos_matches_libm() {
        let mut rng = Rng::new(13, 0);
        let mut worst = 0.0f64;
        for n in 0..1_000_000 {
            let x = rng.next_f64() * 10f64.powi((n % 7) - 3) + 1e-300;
            let y = (rng.next_f64() - 0.5) * 10f64.powi(((n / 7) % 9) - 4);
            worst = worst.max((atan2_pos(y, x) - y.atan2(x)).abs());
        }
        for (y, x) in [
            (0.0, 1.0),
            (1.0, 1.0),
            (-1.0, 1.0),
            (1.0, 1e-300),
            (-1e-300, 1.0),
        ] {
            worst = worst.max((atan2_pos(y, x) - f64::atan2(y, x)).abs());
        }
        assert!(worst < 5e-16, "{worst}");
    }

    /// [`sin_cos_quadrant`] agrees with libm on `[0, pi/2]`.
    #[test]
    fn sin_cos_quadrant_matches_libm() {
        let n = 1_000_000;
        let mut worst = 0.0f64;
        for j in 0..=n {
            let d = FRAC_PI_2 * j as f64 / n as f64;
            let (s, c) = sin_cos_quadrant(d);
            let (s0, c0) = d.sin_cos();
            worst = worst.max((s - s0).abs()).max((c - c0).abs());
        }
        assert!(worst < 4e-16, "{worst}");
    }

    /// [`symmetric_tail_sines`] equals `sin(psi_a - m theta_v)` computed
    /// from the angles, for the solutions the symmetric sum visits.
    #[test]
    fn symmetric_tail_sines_match_direct() {
        let mut rng = Rng::new(12, 0);
        let mut checked = 0;
        for _ in 0..20_000 {
            let ti = (rng.next_f64() - 0.5) * PI * 0.999;
            let to = (rng.next_f64() - 0.5) * PI * 0.999;
            let k = 1 + (rng.next_f64() * 60.0) as u32;
            let odd = k % 2 == 1;
            let base = if odd { ti + to } else { ti - to - PI };
            let j = ((base + 1e-3) / PI).ceil() as i64 + (rng.next_f64() * 4.0) as i64;
            if (j.rem_euclid(2) == 1) != odd {
                continue;
            }
            let x = PI * j as f64 - base;
            let delta = x / (2.0 * k as f64);
            if !(x > 0.0 && delta < FRAC_PI_2) {
                continue;
            }
            let a = FRAC_PI_2 - delta;
            let (sa, ca) = a.sin_cos();
            let su = if odd { to.sin() } else { -to.sin() };
            let got = symmetric_tail_sines(su, to.cos(), ca, sa);
            let psi_a = a - ti + FRAC_PI_2;
            let tv = PI - 2.0 * a;
            for (m, g) in got.iter().enumerate() {
                let want = (psi_a - (k as f64 - 2.0 + m as f64) * tv).sin();
                assert!((g - want).abs() < 1e-12, "k {k} m {m}: {g} vs {want}");
            }
            checked += 1;
        }
        assert!(checked > 5000, "{checked}");
    }

    /// [`symmetric_k_range`] contains every count the exact test accepts
    /// (brute force over all `k <= 256` on random `(ti, x)`, including `x`
    /// near the mirror configuration `x = pi - 2 ti` where the range is
    /// widest).
    #[test]
    fn symmetric_k_range_is_a_superset() {
        let mut rng = Rng::new(11, 0);
        let k_max = 256;
        let mut accepted = 0u64;
        let mut scanned = 0u64;
        for n in 0..20_000 {
            let ti = (rng.next_f64() - 0.5) * PI * 0.9999;
            let x = if n % 4 == 0 {
                PI - 2.0 * ti + (rng.next_f64() - 0.5) * 1e-3
            } else {
                rng.next_f64() * 2.0 * PI
            };
            if !(x > 0.0) {
                continue;
            }
            let (lo, hi) = symmetric_k_range(ti, x, k_max);
            for k in 1..=k_max {
                let kf = k as f64;
                let a = FRAC_PI_2 - x / (2.0 * kf);
                if a > 0.0 && a < FRAC_PI_2 && symmetric_count_possible(ti, a, kf) {
                    accepted += 1;
                    assert!(
                        lo <= k && k <= hi,
                        "ti {ti} x {x}: k {k} outside [{lo}, {hi}]"
                    );
                }
            }
            scanned += (hi + 1).saturating_sub(lo) as u64;
        }
        assert!(accepted > 10_000, "{accepted}");
        // The range is tight: at most a few counts beyond those accepted.
        assert!(
            scanned < 2 * accepted + 3 * 20_000,
            "{scanned} vs {accepted}"
        );
    }
}
