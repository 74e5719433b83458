//! HEITZ_RANDOM_WALK (Heitz et al. 2016): white furnaces through `sample` and
//! through `eval`, single scattering against SINGLE, reciprocity, sample
//! against eval (chi-square), and a stability sweep. Every tolerance is a
//! multiple of a measured standard error (stated at each assert) or, for the
//! furnaces, the stated energy bound with the standard error shown to be
//! several times smaller.

mod common;
use common::*;
use glam::Vec3;
use msbsdf::bsdf::ScatterModel;
use msbsdf::facet::Facet;
use msbsdf::multiple::heitz::{Heitz, cosine_weight, default_max_bounces};
use msbsdf::ndf::{Ndf, NdfKind};
use msbsdf::single::{G2Form, Single};
use msbsdf::{Material, MaterialDesc, Model, NdfId, Rng, SAMPLE_REFLECTION, SAMPLE_TRANSMISSION};
use std::f64::consts::PI;

const MIRROR: Facet = Facet::Conductor {
    eta: Vec3::ZERO,
    k: Vec3::ONE,
};

fn gold() -> Facet {
    Facet::Conductor {
        eta: Vec3::from_array(GOLD_ETA),
        k: Vec3::from_array(GOLD_K),
    }
}

fn heitz(kind: NdfKind, ax: f32, ay: f32, facet: Facet, max_bounces: u32) -> Heitz {
    Heitz::new(Ndf::new(kind, ax, ay), facet, max_bounces)
}

/// Unit direction from polar angle (degrees) and azimuth (radians).
fn dir(theta_deg: f64, phi: f64) -> Vec3 {
    let t = theta_deg.to_radians();
    Vec3::new(
        (t.sin() * phi.cos()) as f32,
        (t.sin() * phi.sin()) as f32,
        t.cos() as f32,
    )
}

/// Mean and standard error of the sample weights (first channel) for `n`
/// walks from `wi`, split over two threads.
fn sample_albedo(h: &Heitz, wi: Vec3, n: usize, seed: u64) -> (f64, f64) {
    let parts: Vec<(f64, f64)> = std::thread::scope(|s| {
        let hs: Vec<_> = (0..2u64)
            .map(|t| {
                s.spawn(move || {
                    let mut rng = Rng::new(seed, 100 + t);
                    let (mut s1, mut s2) = (0.0, 0.0);
                    for _ in 0..n / 2 {
                        let w = h.sample(wi, &mut rng).weight.x as f64;
                        s1 += w;
                        s2 += w * w;
                    }
                    (s1, s2)
                })
            })
            .collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    });
    let m = (n / 2 * 2) as f64;
    let s1: f64 = parts.iter().map(|p| p.0).sum();
    let s2: f64 = parts.iter().map(|p| p.1).sum();
    let mean = s1 / m;
    let var = (s2 / m - mean * mean).max(0.0);
    (mean, (var / m).sqrt())
}

#[test]
fn default_bounce_limits_follow_the_documented_rule() {
    assert_eq!(default_max_bounces(0.1, 0.1, &MIRROR), 10);
    assert_eq!(default_max_bounces(1.0, 1.0, &MIRROR), 10);
    assert_eq!(default_max_bounces(2.0, 0.5, &MIRROR), 14);
    assert_eq!(
        default_max_bounces(2.0, 2.0, &Facet::Dielectric { eta: 1.5 }),
        21
    );
    assert_eq!(
        default_max_bounces(2.0, 2.0, &Facet::Diffuse { albedo: Vec3::ONE }),
        43
    );
    assert_eq!(
        default_max_bounces(10.0, 10.0, &Facet::Diffuse { albedo: Vec3::ONE }),
        256
    );
}

/// White furnace through `sample`: perfect-mirror facets (weights 1 unless
/// the walk is cut), albedo 1 within 0.3% at every angle and roughness. With
/// 40 000 walks the standard error is below 0.03% (asserted), so the 0.3%
/// bound is decisive.
/// With F = 1 facets every sample weight is 1 by construction, so this
/// checks only the bounce truncation (paths still inside at the limit), not
/// the physics; the eval furnaces are the physics check.
#[test]
fn heitz_sample_truncation_loss_conductor_f1() {
    let thetas = [0.0, 30.0, 60.0, 80.0, 89.0];
    let mut cases: Vec<(NdfKind, f32, f32)> = Vec::new();
    for kind in [NdfKind::Ggx, NdfKind::Beckmann] {
        for a in [0.1, 0.5, 1.0, 2.0] {
            cases.push((kind, a, a));
        }
        cases.push((kind, 0.1, 1.0));
    }
    let mut seed = 1;
    for (kind, ax, ay) in cases {
        let h = heitz(kind, ax, ay, MIRROR, 0);
        for th in thetas {
            seed += 1;
            let (m, se) = sample_albedo(&h, dir(th, 0.4), 40_000, seed);
            println!("furnace conductor {kind:?} ({ax},{ay}) theta {th}: {m:.5} +- {se:.5}");
            assert!(se < 3e-4, "{kind:?} ({ax},{ay}) {th}: standard error {se}");
            assert!(
                (m - 1.0).abs() < 3e-3,
                "{kind:?} ({ax},{ay}) theta {th}: albedo {m} +- {se}"
            );
        }
    }
}

/// Heavy-tailed Student-T (shape below 2) keeps light in the surface
/// longer: the default bounce limit scales the roughness by the tail
/// (`invariance::heavy_tail_bounce_scale`), so the furnace holds within
/// 0.3% there too. Measured with the GGX rule alone (10 bounces at alpha
/// 1): 0.917 at shape 1.6, normal incidence; with the scaled limit 0.9999.
/// With F = 1 facets every sample weight is 1 by construction, so this
/// checks only the bounce truncation (paths still inside at the limit), not
/// the physics; the eval furnaces are the physics check.
#[test]
fn heitz_sample_truncation_loss_heavy_tailed_student_t() {
    let mut seed = 500;
    for (shape, alpha) in [(1.6f32, 1.0f32), (1.8, 1.0), (1.6, 0.3)] {
        let h = Heitz::new(
            Ndf::with_shape(NdfKind::StudentT, alpha, alpha, shape),
            MIRROR,
            0,
        );
        for th in [0.0, 60.0] {
            seed += 1;
            let (m, se) = sample_albedo(&h, dir(th, 0.4), 40_000, seed);
            println!(
                "furnace Student-T {shape} alpha {alpha} theta {th}: {m:.5} +- {se:.5} ({} bounces)",
                h.max_bounces()
            );
            assert!(se < 3e-4, "standard error {se}");
            assert!(
                (m - 1.0).abs() < 3e-3,
                "shape {shape} alpha {alpha} theta {th}: albedo {m} +- {se}"
            );
        }
    }
}

/// Dielectric facets (eta 1.5, no absorption): reflected plus transmitted
/// albedo 1 within 0.5%, entering from above and from below (total internal
/// reflection inside). Standard error < 0.05% (asserted).
/// With F = 1 facets every sample weight is 1 by construction, so this
/// checks only the bounce truncation (paths still inside at the limit), not
/// the physics; the eval furnaces are the physics check.
#[test]
fn heitz_sample_truncation_loss_dielectric_r_plus_t() {
    let mut seed = 1000;
    for kind in [NdfKind::Ggx, NdfKind::Beckmann] {
        for a in [0.1f32, 0.5, 1.0, 2.0] {
            let h = heitz(kind, a, a, Facet::Dielectric { eta: 1.5 }, 0);
            for th in [0.0, 45.0, 80.0, 89.0] {
                for below in [false, true] {
                    seed += 1;
                    let mut wi = dir(th, 1.1);
                    if below {
                        wi.z = -wi.z;
                    }
                    let (m, se) = sample_albedo(&h, wi, 20_000, seed);
                    println!(
                        "furnace dielectric {kind:?} {a} theta {th} below {below}: {m:.5} +- {se:.5}"
                    );
                    assert!(se < 5e-4, "standard error {se}");
                    assert!(
                        (m - 1.0).abs() < 5e-3,
                        "{kind:?} {a} theta {th} below {below}: R + T = {m} +- {se}"
                    );
                }
            }
        }
    }
}

/// Diffuse facets with albedo 1: the walk keeps all the energy (albedo 1
/// within 0.3%, standard error < 0.03% asserted).
/// With F = 1 facets every sample weight is 1 by construction, so this
/// checks only the bounce truncation (paths still inside at the limit), not
/// the physics; the eval furnaces are the physics check.
#[test]
fn heitz_sample_truncation_loss_white_diffuse_facets() {
    let mut seed = 2000;
    for kind in [NdfKind::Ggx, NdfKind::Beckmann] {
        for a in [0.1f32, 0.5, 1.0, 2.0] {
            let h = heitz(kind, a, a, Facet::Diffuse { albedo: Vec3::ONE }, 0);
            for th in [0.0, 60.0, 89.0] {
                seed += 1;
                let (m, se) = sample_albedo(&h, dir(th, 0.0), 20_000, seed);
                println!("furnace diffuse {kind:?} {a} theta {th}: {m:.5} +- {se:.5}");
                assert!(se < 4e-4, "standard error {se}");
                assert!(
                    (m - 1.0).abs() < 3e-3,
                    "{kind:?} {a} theta {th}: {m} +- {se}"
                );
            }
        }
    }
}

/// Draws `wo` from exactly the density `Heitz::pdf` reports (the SINGLE
/// visible-normal lobe with weight 1 - q, the cosine lobe with weight q), so
/// `eval / pdf` is an unbiased estimate of the integral of `eval`. Returns
/// `None` when the SINGLE lobe missed (its density integrates below 1).
fn draw_from_pdf(
    h: &Heitz,
    single: &Single,
    q: f32,
    two_sided: bool,
    wi: Vec3,
    rng: &mut Rng,
) -> Option<Vec3> {
    let u = rng.next_f32();
    if u < q {
        let (u1, u2) = (rng.next_f32(), rng.next_f32());
        let r = u1.sqrt();
        let phi = 2.0 * std::f32::consts::PI * u2;
        let mut wo = Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u1).max(0.0).sqrt());
        let same = if two_sided {
            rng.next_f32() < 0.5
        } else {
            true
        };
        if (wi.z < 0.0) == same {
            wo.z = -wo.z;
        }
        (wo.z != 0.0).then_some(wo)
    } else {
        let s = single.sample(wi, rng);
        let _ = h;
        (s.flags & (SAMPLE_REFLECTION | SAMPLE_TRANSMISSION) != 0 && s.wo.z != 0.0).then_some(s.wo)
    }
}

/// Integral of `eval` over the sphere (importance-sampled with the model's
/// own pdf) against the sample-weight albedo. Placing the hit height of an
/// upward ray at the top of the height range (the bug the notes describe)
/// was measured here: GGX alpha 1 mirror eval integral 0.924 +- 0.0035 at
/// theta 0 and 1.038 +- 0.0028 at 60 degrees (22 and 14 sigma) while the
/// mirror `sample` furnace still gives exactly 1; at alpha 0.5 the error is
/// about 1% (3-4 sigma). Tolerance: 4 sigma of the combined error, and the
/// combined sigma must be below 1% (asserted).
#[test]
fn furnace_heitz_eval_integrates_to_the_sample_albedo() {
    let cases = [
        (NdfKind::Ggx, 1.0f32, MIRROR, false),
        (NdfKind::Ggx, 0.5, MIRROR, false),
        (NdfKind::Beckmann, 1.0, MIRROR, false),
        (NdfKind::Ggx, 1.0, gold(), false),
        (NdfKind::Ggx, 0.5, Facet::Dielectric { eta: 1.5 }, false),
        (NdfKind::Ggx, 0.5, Facet::Dielectric { eta: 1.5 }, true),
        (
            NdfKind::Ggx,
            1.0,
            Facet::Diffuse {
                albedo: Vec3::splat(0.8),
            },
            false,
        ),
    ];
    let mut seed = 3000;
    for (kind, a, facet, below) in cases {
        let ndf = Ndf::new(kind, a, a);
        let h = Heitz::new(ndf, facet, 0);
        let dielectric = matches!(facet, Facet::Dielectric { .. });
        let single_facet = if dielectric { facet } else { MIRROR };
        let single = Single::new(ndf, single_facet, G2Form::HeightCorrelated);
        let q = cosine_weight(a, &facet);
        for th in [0.0, 60.0] {
            seed += 1;
            let mut wi = dir(th, 0.3);
            if below {
                wi.z = -wi.z;
            }
            let n = 60_000usize;
            let mut rng = Rng::new(seed, 1);
            let (mut s1, mut s2) = (0.0f64, 0.0f64);
            for _ in 0..n {
                let Some(wo) = draw_from_pdf(&h, &single, q, dielectric, wi, &mut rng) else {
                    continue;
                };
                let p = h.pdf(wi, wo);
                assert!(p > 0.0, "pdf 0 at a direction it samples: {wi} {wo}");
                let v = (h.eval(wi, wo, &mut rng).x / p) as f64;
                s1 += v;
                s2 += v * v;
            }
            let mean = s1 / n as f64;
            let se_eval = ((s2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
            let (albedo, se_s) = sample_albedo(&h, wi, 200_000, seed + 77);
            let sigma = (se_eval * se_eval + se_s * se_s).sqrt();
            println!(
                "eval furnace {kind:?} {a} {facet:?} theta {th} below {below}: eval {mean:.4} +- {se_eval:.4}, sample {albedo:.4} +- {se_s:.4}"
            );
            assert!(
                sigma < 0.01 * albedo,
                "{kind:?} {a} {th}: sigma {sigma} too large to decide"
            );
            assert!(
                (mean - albedo).abs() < 4.0 * sigma,
                "{kind:?} alpha {a} {facet:?} theta {th} below {below}: integral of eval {mean:.4} +- {se_eval:.4}, sample albedo {albedo:.4} +- {se_s:.4}"
            );
        }
    }
}

/// Mean and standard error of `n` evaluations.
fn eval_mean(h: &Heitz, wi: Vec3, wo: Vec3, n: usize, rng: &mut Rng) -> (Vec3, Vec3) {
    let (mut s1, mut s2) = (Vec3::ZERO, Vec3::ZERO);
    for _ in 0..n {
        let v = h.eval(wi, wo, rng);
        s1 += v;
        s2 += v * v;
    }
    let mean = s1 / n as f32;
    let var = (s2 / n as f32 - mean * mean).max(Vec3::ZERO);
    let se = var / n as f32;
    (mean, Vec3::new(se.x.sqrt(), se.y.sqrt(), se.z.sqrt()))
}

/// Random pair of directions on the sides requested.
fn random_pair(rng: &mut Rng, max_deg: f64, transmit: bool) -> (Vec3, Vec3) {
    let th_i = max_deg * rng.next_f64();
    let th_o = max_deg * rng.next_f64();
    let wi = dir(th_i, 2.0 * PI * rng.next_f64());
    let mut wo = dir(th_o, 2.0 * PI * rng.next_f64());
    if transmit {
        wo.z = -wo.z;
    }
    (wi, wo)
}

/// Restricted to one bounce, the walk's eval is SINGLE with the
/// height-correlated G2 (reflection `1 / (1 + Lambda_i + Lambda_o)`,
/// transmission `B(1 + Lambda_i, 1 + Lambda_o)`): within 4 standard errors
/// (plus 1e-4 relative for f32 rounding) on random pairs, for gold and for
/// glass reflection / transmission, from above and from below.
#[test]
fn heitz_order_one_equals_single_height_correlated() {
    let mut rng = Rng::new(77, 5);
    let mut checked = 0;
    let mut worst = 0.0f32;
    for kind in [NdfKind::Ggx, NdfKind::Beckmann] {
        for (ax, ay) in [(0.3f32, 0.3f32), (1.0, 1.0), (0.2, 0.8)] {
            let ndf = Ndf::new(kind, ax, ay);
            for facet in [gold(), Facet::Dielectric { eta: 1.5 }] {
                let h = Heitz::new(ndf, facet, 1);
                assert_eq!(h.max_bounces(), 1);
                let s = Single::new(ndf, facet, G2Form::HeightCorrelated);
                let dielectric = matches!(facet, Facet::Dielectric { .. });
                for k in 0..12 {
                    let transmit = dielectric && k % 2 == 1;
                    let (mut wi, mut wo) = random_pair(&mut rng, 80.0, transmit);
                    if dielectric && k % 4 >= 2 {
                        // Same pair seen from inside.
                        wi.z = -wi.z;
                        wo.z = -wo.z;
                    }
                    let expect = s.eval(wi, wo, &mut rng);
                    let (mean, se) = eval_mean(&h, wi, wo, 4_000, &mut rng);
                    for c in 0..3 {
                        // Decisive: a 4% error is more than 4 sigma.
                        assert!(
                            se[c] <= 0.01 * expect[c] + 1e-7,
                            "sigma {} for {}",
                            se[c],
                            expect[c]
                        );
                        let tol = 4.0 * se[c] + 1e-4 * expect[c] + 1e-6;
                        worst = worst.max((mean[c] - expect[c]).abs() / tol);
                        assert!(
                            (mean[c] - expect[c]).abs() < tol,
                            "{kind:?} ({ax},{ay}) {facet:?} wi {wi} wo {wo}: walk {} +- {}, single {}",
                            mean[c],
                            se[c],
                            expect[c]
                        );
                    }
                    if expect.x > 0.0 {
                        checked += 1;
                    }
                }
            }
        }
    }
    println!(
        "order one vs SINGLE: {checked} nonzero pairs, worst deviation {worst:.2} x tolerance"
    );
    assert!(checked > 80, "only {checked} pairs had a nonzero value");
}

/// Reciprocity of the walk itself: the unidirectional estimate from `wi`
/// of `f(wi, wo)` equals the one from `wo` of `f(wo, wi)` (reflection), and
/// `f(wi, wo) / eta_o^2 = f(wo, wi) / eta_i^2` for transmission; within 4
/// combined standard errors, full multiple scattering. (Not `eval`: it
/// averages the walks from both ends with the reciprocity scale, so its
/// expectation is reciprocal whether the walk is or not.)
#[test]
fn heitz_one_way_walk_is_reciprocal() {
    let mut rng = Rng::new(91, 3);
    let mut worst_rel_sigma: f64 = 0.0;
    let mut tested = 0;
    for kind in [NdfKind::Ggx, NdfKind::Beckmann] {
        for facet in [
            gold(),
            Facet::Dielectric { eta: 1.5 },
            Facet::Diffuse {
                albedo: Vec3::splat(0.7),
            },
        ] {
            let h = heitz(kind, 0.8, 0.8, facet, 0);
            let dielectric = matches!(facet, Facet::Dielectric { .. });
            for k in 0..6 {
                let transmit = dielectric && k % 2 == 1;
                // Transmission pairs near the refracted lobe (a random pair
                // far from it carries almost nothing and only noise): wi 20
                // to 60 degrees, wo 10 to 35 degrees from -z on the far side.
                let (wi, wo) = if transmit {
                    let phi = 2.0 * PI * rng.next_f64();
                    (
                        dir(20.0 + 40.0 * rng.next_f64(), phi),
                        dir(180.0 - 10.0 - 25.0 * rng.next_f64(), phi + PI),
                    )
                } else {
                    random_pair(&mut rng, 75.0, false)
                };
                // Glass reflects little and noisily: more walks.
                let n = if dielectric { 100_000 } else { 20_000 };
                let est = |a: Vec3, b: Vec3, rng: &mut Rng| {
                    let (mut s1, mut s2) = (0.0f64, 0.0f64);
                    for _ in 0..n {
                        let v = (h.estimate(a, b, rng).y / b.z.abs()) as f64;
                        s1 += v;
                        s2 += v * v;
                    }
                    let m = s1 / n as f64;
                    (m, ((s2 / n as f64 - m * m).max(0.0) / n as f64).sqrt())
                };
                let (f_io, se_io) = est(wi, wo, &mut rng);
                let (f_oi, se_oi) = est(wo, wi, &mut rng);
                // wi is above (eta_i = 1); below the index is 1.5.
                let ratio = if transmit { 1.5f64 * 1.5 } else { 1.0 };
                let (lhs, rhs) = (f_io, f_oi * ratio);
                let sigma = (se_io * se_io + (se_oi * ratio).powi(2)).sqrt();
                println!(
                    "reciprocity {kind:?} {facet:?} transmit {transmit}: {lhs:.5} vs {rhs:.5} ({:.2} sigma, sigma {:.2}% of the value)",
                    (lhs - rhs) / sigma,
                    100.0 * sigma / lhs.abs().max(rhs.abs())
                );
                // Decisive: in reflection a 10% asymmetry (a wrong masking
                // term at one end of the walk) is 4 sigma or more; in
                // transmission the effect to catch is a walk that drops or
                // doubles the eta^2 of refraction (a factor 2.25: 125%), and
                // 4 sigma stays below 40% (rough transmission is heavy-tailed).
                let bound = if transmit { 0.10 } else { 0.025 };
                worst_rel_sigma = worst_rel_sigma.max(sigma / lhs.abs().max(rhs.abs()));
                assert!(
                    sigma <= bound * lhs.abs().max(rhs.abs()),
                    "{kind:?} {facet:?} wi {wi} wo {wo}: sigma {sigma} too large for {lhs}"
                );
                assert!(
                    (lhs - rhs).abs() < 4.0 * sigma + 1e-6,
                    "{kind:?} {facet:?} wi {wi} wo {wo}: f(wi,wo) {lhs} vs {rhs} (sigma {sigma})"
                );
                tested += 1;
            }
        }
    }
    println!(
        "reciprocity: worst sigma {:.2}% of the value",
        100.0 * worst_rel_sigma
    );
    assert_eq!(tested, 2 * 3 * 6);
}

/// Weighted histogram of `sample` against the integral of `eval` over the
/// same theta-phi bins (equal solid angle in cos theta), chi-square with the
/// variance of both Monte Carlo estimates per bin; bins whose expected
/// number of samples is below 20 are pooled. p > 0.01 Sidak-corrected over
/// the configurations.
#[test]
fn heitz_sample_matches_eval_chi2() {
    let configs = [
        (NdfKind::Ggx, 0.5f32, 0.5f32, gold(), 30.0, false),
        (NdfKind::Ggx, 1.0, 1.0, gold(), 70.0, false),
        (NdfKind::Beckmann, 1.0, 1.0, MIRROR, 0.0, false),
        (NdfKind::Ggx, 0.2, 1.0, gold(), 50.0, false),
        (
            NdfKind::Ggx,
            0.6,
            0.6,
            Facet::Dielectric { eta: 1.5 },
            45.0,
            false,
        ),
        (
            NdfKind::Beckmann,
            0.6,
            0.6,
            Facet::Dielectric { eta: 1.5 },
            45.0,
            true,
        ),
        (
            NdfKind::Ggx,
            1.0,
            1.0,
            Facet::Diffuse {
                albedo: Vec3::splat(0.8),
            },
            40.0,
            false,
        ),
    ];
    let level = sidak(0.01, configs.len());
    let (n_theta, n_phi) = (8usize, 12usize);
    for (ci, (kind, ax, ay, facet, th, below)) in configs.into_iter().enumerate() {
        let h = heitz(kind, ax, ay, facet, 0);
        let dielectric = matches!(facet, Facet::Dielectric { .. });
        let mut wi = dir(th, 0.5);
        if below {
            wi.z = -wi.z;
        }
        // Bins over z in [-1, 1] for dielectrics, (0, 1] on wi's side otherwise.
        let sides = if dielectric { 2 } else { 1 };
        let nb = sides * n_theta * n_phi;
        let z_lo = if dielectric { -1.0 } else { 0.0 };
        let dz = (1.0 - z_lo) / (sides * n_theta) as f64;
        let dphi = 2.0 * PI / n_phi as f64;
        let to_bin = |w: Vec3| -> usize {
            let z = if dielectric || wi.z > 0.0 { w.z } else { -w.z } as f64;
            let it = (((z - z_lo) / dz) as usize).min(sides * n_theta - 1);
            let mut phi = (w.y as f64).atan2(w.x as f64);
            if phi < 0.0 {
                phi += 2.0 * PI;
            }
            it * n_phi + ((phi / dphi) as usize).min(n_phi - 1)
        };
        // Sample side: weighted histogram, mean and variance per bin.
        let ns = 600_000usize;
        let mut rng = Rng::new(500 + ci as u64, 1);
        let (mut o1, mut o2) = (vec![0.0f64; nb], vec![0.0f64; nb]);
        for _ in 0..ns {
            let s = h.sample(wi, &mut rng);
            // Blue channel: gold's Fresnel varies most there (0.26 to 1).
            if s.weight.z > 0.0 {
                assert!(s.pdf > 0.0, "pdf 0 where sample goes: {:?}", s);
                let b = to_bin(s.wo);
                let w = s.weight.z as f64;
                o1[b] += w;
                o2[b] += w * w;
            }
        }
        // Eval side: stratified uniform points per bin.
        let ne = 1_500usize;
        let (mut e1, mut e2) = (vec![0.0f64; nb], vec![0.0f64; nb]);
        for b in 0..nb {
            let (it, ip) = (b / n_phi, b % n_phi);
            let area = dz * dphi;
            let (mut s1, mut s2) = (0.0, 0.0);
            for _ in 0..ne {
                let z = z_lo + (it as f64 + rng.next_f64()) * dz;
                let phi = (ip as f64 + rng.next_f64()) * dphi;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let mut wo = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
                if !dielectric && wi.z < 0.0 {
                    wo.z = -wo.z;
                }
                if wo.z == 0.0 {
                    continue;
                }
                let v = h.eval(wi, wo, &mut rng).z as f64 * area;
                s1 += v;
                s2 += v * v;
            }
            e1[b] = s1 / ne as f64;
            e2[b] = (s2 / ne as f64 - e1[b] * e1[b]).max(0.0) / ne as f64;
        }
        // Per-bin means and variances of the two estimates of the same integral.
        let mut terms: Vec<(f64, f64, f64)> = Vec::new(); // (obs, exp, var)
        for b in 0..nb {
            let om = o1[b] / ns as f64;
            let ov = (o2[b] / ns as f64 - om * om).max(0.0) / ns as f64;
            terms.push((om, e1[b], ov + e2[b]));
        }
        // Pool bins expecting fewer than 20 samples (by the eval side's mass).
        let min_mass = 20.0 / ns as f64;
        let (mut po, mut pe, mut pv, mut pooled) = (0.0, 0.0, 0.0, 0usize);
        let (mut chi2, mut dof) = (0.0, 0usize);
        for &(o, e, v) in &terms {
            if e < min_mass || v <= 0.0 {
                po += o;
                pe += e;
                pv += v;
                pooled += 1;
            } else {
                chi2 += (o - e).powi(2) / v;
                dof += 1;
            }
        }
        if pooled > 0 && pv > 0.0 {
            chi2 += (po - pe).powi(2) / pv;
            dof += 1;
        }
        let p = gamma_q(dof as f64 / 2.0, chi2 / 2.0);
        let total_o: f64 = terms.iter().map(|t| t.0).sum();
        let total_e: f64 = terms.iter().map(|t| t.1).sum();
        println!(
            "chi2 config {ci} {kind:?} ({ax},{ay}) theta {th}: chi2 {chi2:.1} dof {dof} p {p:.3} (albedo sample {total_o:.4} eval {total_e:.4})"
        );
        assert!(dof > 20, "config {ci}: only {dof} bins");
        assert!(
            p > level,
            "config {ci} {kind:?} ({ax},{ay}) {facet:?} theta {th}: chi2 {chi2:.1} dof {dof} p {p:.2e} (albedo sample {total_o:.4} eval {total_e:.4})"
        );
    }
}

/// Random sweep: grazing to 89.99 degrees, alpha 1e-3 to 2, eta 1.01 to 3,
/// all facets and both NDFs through the public Material: eval, sample and
/// pdf never NaN, Inf or negative; a sampled direction has a positive pdf.
#[test]
fn heitz_stability_sweep() {
    let mut rng = Rng::new(4242, 7);
    let facets = [
        msbsdf::FacetKind::Conductor,
        msbsdf::FacetKind::Dielectric,
        msbsdf::FacetKind::Diffuse,
    ];
    for i in 0..20000 {
        let ndf = if i % 2 == 0 {
            NdfId::Ggx
        } else {
            NdfId::Beckmann
        };
        let facet = facets[(i / 2) % 3];
        let la = -3.0 + (2.0f64.log10() + 3.0) * rng.next_f64();
        let ax = 10f64.powf(la) as f32;
        let ay = if i % 5 == 0 { (ax * 0.3).max(1e-3) } else { ax };
        let eta = 1.01 + 1.99 * rng.next_f32();
        let m = Material::new(&MaterialDesc {
            model: Model::HeitzRandomWalk,
            ndf,
            facet,
            alpha_x: ax,
            alpha_y: ay,
            eta: if facet == msbsdf::FacetKind::Dielectric {
                Vec3::splat(eta)
            } else {
                Vec3::from_array(GOLD_ETA)
            },
            k: Vec3::from_array(GOLD_K),
            albedo: Vec3::splat(0.9),
            ..MaterialDesc::default()
        })
        .expect("valid material");
        assert!(m.is_stochastic());
        let pick = |rng: &mut Rng| {
            let u = rng.next_f64();
            let th = if u < 0.3 {
                89.0 + 0.99 * rng.next_f64()
            } else {
                89.99 * rng.next_f64()
            };
            let mut w = dir(th, 2.0 * PI * rng.next_f64());
            if rng.next_f32() < 0.3 {
                w.z = -w.z;
            }
            w
        };
        let (wi, wo) = (pick(&mut rng), pick(&mut rng));
        let v = m.eval(wi, wo, &mut rng);
        assert!(
            v.is_finite() && v.min_element() >= 0.0,
            "eval {v} {wi} {wo}"
        );
        let p = m.pdf(wi, wo);
        assert!(p.is_finite() && p >= 0.0);
        for _ in 0..4 {
            let s = m.sample(wi, &mut rng);
            assert!(
                s.weight.is_finite() && s.weight.min_element() >= 0.0,
                "{s:?}"
            );
            assert!(s.pdf.is_finite() && s.pdf >= 0.0);
            if s.weight.max_element() > 0.0 {
                assert!((s.wo.length() - 1.0).abs() < 1e-3, "{s:?}");
                assert!(
                    s.pdf > 0.0,
                    "sampled {:?} from {wi} with pdf 0 ({facet:?} {ax})",
                    s.wo
                );
                assert!(m.pdf(wi, s.wo) > 0.0);
                if facet != msbsdf::FacetKind::Dielectric {
                    assert!(s.wo.z * wi.z > 0.0, "opaque facets transmitted");
                }
            }
        }
    }
}

/// The material accepts exactly the documented combinations.
#[test]
fn heitz_material_validation() {
    let base = MaterialDesc {
        model: Model::HeitzRandomWalk,
        ..MaterialDesc::default()
    };
    for ndf in [NdfId::Ggx, NdfId::Beckmann] {
        for facet in [
            msbsdf::FacetKind::Conductor,
            msbsdf::FacetKind::Dielectric,
            msbsdf::FacetKind::Diffuse,
        ] {
            let d = MaterialDesc {
                ndf,
                facet,
                eta: Vec3::splat(1.5),
                ..base
            };
            assert!(Material::new(&d).is_ok(), "{ndf:?} {facet:?}");
        }
    }
    let d = MaterialDesc {
        alpha_x: 2.0,
        alpha_y: 2.0,
        max_bounces: 256,
        ..base
    };
    assert!(Material::new(&d).is_ok());
    let d = MaterialDesc {
        ndf: NdfId::Phong,
        ..base
    };
    assert_eq!(Material::new(&d), Err(msbsdf::Error::Unsupported));
    let d = MaterialDesc {
        facet: msbsdf::FacetKind::Material,
        ..base
    };
    assert_eq!(Material::new(&d), Err(msbsdf::Error::Unsupported));
    let d = MaterialDesc {
        max_bounces: 257,
        ..base
    };
    assert_eq!(Material::new(&d), Err(msbsdf::Error::InvalidArgument));
}
