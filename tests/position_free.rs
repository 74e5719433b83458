//! MSBSDF_MODEL_POSITION_FREE (Wang et al. 2022): white furnace through eval and
//! sample, agreement of eval with sample, the single-bounce reduction to
//! uncorrelated Cook-Torrance, BDPT against PT variance, reciprocity, a
//! chi-square of sample against eval, and a stability sweep.

mod common;
use common::*;
use glam::Vec3;
use msbsdf::bsdf::ScatterModel;
use msbsdf::facet::Facet;
use msbsdf::ndf::{Ndf, NdfKind};
use msbsdf::single::{G2Form, Single};
use msbsdf::{Estimator, FacetKind, Material, MaterialDesc, Model, NdfId, Rng};
use std::f32::consts::PI;

fn pf(ndf: NdfId, ax: f32, ay: f32, est: Estimator) -> MaterialDesc {
    MaterialDesc {
        model: Model::PositionFree,
        estimator: est,
        ndf,
        alpha_x: ax,
        alpha_y: ay,
        ..MaterialDesc::default()
    }
}

fn dielectric(desc: MaterialDesc, eta: f32) -> MaterialDesc {
    MaterialDesc {
        facet: FacetKind::Dielectric,
        eta: Vec3::splat(eta),
        ..desc
    }
}

fn gold(desc: MaterialDesc) -> MaterialDesc {
    MaterialDesc {
        eta: Vec3::from(GOLD_ETA),
        k: Vec3::from(GOLD_K),
        ..desc
    }
}

fn ndf_kind(id: NdfId) -> NdfKind {
    match id {
        NdfId::Beckmann => NdfKind::Beckmann,
        NdfId::StudentT => NdfKind::StudentT,
        _ => NdfKind::Ggx,
    }
}

/// Cosine-distributed direction on the side of sign `side` (+1 or -1).
fn cosine_dir(u1: f32, u2: f32, side: f32) -> Vec3 {
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    Vec3::new(
        r * phi.cos(),
        r * phi.sin(),
        side * (1.0 - u1).max(0.0).sqrt(),
    )
}

/// Directional albedo `integral eval(wi, wo) dwo` by importance sampling a
/// mixture (independent of the model under test): half the samples from the
/// exact single-scattering sampler with its exact pdf, half from a cosine
/// lobe (both hemispheres for dielectrics). Returns mean and standard error
/// per channel (channel mean for the error).
fn albedo_by_eval(desc: &MaterialDesc, wi: Vec3, n: usize, seed: u64) -> (Vec3, f64) {
    albedo_by_eval_until(desc, wi, n, n, f64::INFINITY, seed)
}

/// [`albedo_by_eval`] in batches of `batch` samples until the standard error
/// is below `target` or `max_n` samples were drawn.
fn albedo_by_eval_until(
    desc: &MaterialDesc,
    wi: Vec3,
    batch: usize,
    max_n: usize,
    target: f64,
    seed: u64,
) -> (Vec3, f64) {
    let m = Material::new(desc).unwrap();
    let facet = match desc.facet {
        FacetKind::Dielectric => Facet::Dielectric { eta: desc.eta.x },
        _ => Facet::Conductor {
            eta: desc.eta,
            k: desc.k,
        },
    };
    let is_diel = desc.facet == FacetKind::Dielectric;
    let single = Single::new(
        Ndf::with_shape(ndf_kind(desc.ndf), desc.alpha_x, desc.alpha_y, desc.shape),
        facet,
        G2Form::HeightCorrelated,
    );
    let mut rng = Rng::new(seed, 17);
    let mut eval_rng = Rng::new(seed, 18);
    let (mut sum, mut s1, mut s2) = (Vec3::ZERO.as_dvec3(), 0.0f64, 0.0f64);
    let mut n = 0usize;
    loop {
        for _ in 0..batch {
            n += 1;
            let wo = if rng.next_f32() < 0.5 {
                let s = single.sample(wi, &mut rng);
                if s.flags & msbsdf::SAMPLE_ABSORBED != 0 {
                    continue;
                }
                s.wo
            } else {
                let side = if is_diel && rng.next_f32() < 0.5 {
                    -wi.z.signum()
                } else {
                    wi.z.signum()
                };
                cosine_dir(rng.next_f32(), rng.next_f32(), side)
            };
            if wo.z == 0.0 {
                continue;
            }
            let lambert = if is_diel {
                wo.z.abs() / (2.0 * PI)
            } else if wo.z * wi.z > 0.0 {
                wo.z.abs() / PI
            } else {
                0.0
            };
            let p = 0.5 * single.pdf(wi, wo) as f64 + 0.5 * lambert as f64;
            if p <= 0.0 {
                continue;
            }
            let v = m.eval(wi, wo, &mut eval_rng).as_dvec3() / p;
            sum += v;
            let x = (v.x + v.y + v.z) / 3.0;
            s1 += x;
            s2 += x * x;
        }
        let nf = n as f64;
        let mean = s1 / nf;
        let err = ((s2 / nf - mean * mean).max(0.0) / nf).sqrt();
        if err < target || n >= max_n {
            return ((sum / nf).as_vec3(), err);
        }
    }
}

/// Mean of the sample weights (the albedo `sample` reports) and its error.
fn albedo_by_sample(desc: &MaterialDesc, wi: Vec3, n: usize, seed: u64) -> (Vec3, f64) {
    let m = Material::new(desc).unwrap();
    let mut rng = Rng::new(seed, 23);
    let (mut sum, mut s1, mut s2) = (Vec3::ZERO.as_dvec3(), 0.0f64, 0.0f64);
    for _ in 0..n {
        let w = m.sample(wi, &mut rng).weight.as_dvec3();
        sum += w;
        let x = (w.x + w.y + w.z) / 3.0;
        s1 += x;
        s2 += x * x;
    }
    let nf = n as f64;
    let mean = s1 / nf;
    let var = (s2 / nf - mean * mean).max(0.0);
    ((sum / nf).as_vec3(), (var / nf).sqrt())
}

const THETAS: [f64; 5] = [0.0, 30.0, 60.0, 80.0, 89.0];

/// Runs `f` over the items on two threads, keeping the order.
fn par_map<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let half = items.len().div_ceil(2);
    std::thread::scope(|sc| {
        let (a, b) = items.split_at(half);
        let fa = &f;
        let h = sc.spawn(move || a.iter().map(fa).collect::<Vec<R>>());
        let mut rb: Vec<R> = b.iter().map(&f).collect();
        let mut ra = h.join().unwrap();
        ra.append(&mut rb);
        ra
    })
}

/// A direction over the whole sphere for the stability sweeps: 30% with a
/// polar angle in [89, 89.99] degrees (grazing), the rest uniform in angle.
fn sweep_dir(rng: &mut Rng) -> Vec3 {
    let th = if rng.next_f32() < 0.3 {
        89.0 + 0.99 * rng.next_f32()
    } else {
        180.0 * rng.next_f32()
    };
    let ph = 360.0 * rng.next_f32();
    let (t, p) = (th.to_radians(), ph.to_radians());
    Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

#[test]
fn furnace_conductor_white_eval_within_1_percent() {
    // Every (NDF, roughness) at every incidence; the truncation at the default
    // bounce limit drops < 0.1% (documented in default_max_bounces).
    let mut configs = Vec::new();
    for ndf in [NdfId::Ggx, NdfId::Beckmann] {
        for (ax, ay) in [
            (0.1f32, 0.1f32),
            (0.5, 0.5),
            (1.0, 1.0),
            (2.0, 2.0),
            (0.1, 1.0),
        ] {
            for th in THETAS {
                configs.push((ndf, ax, ay, th));
            }
        }
    }
    let results = par_map(&configs, |&(ndf, ax, ay, th)| {
        // PT's next-event terms are heavy-tailed for smooth isotropic
        // surfaces at grazing incidence (GGX 0.1 at 89 degrees: standard
        // error 0.0055 after 600k evals); BDPT is used for alpha 0.1.
        let est = if ax.max(ay) <= 0.1 {
            Estimator::Bdpt
        } else {
            Estimator::Pt
        };
        let desc = pf(ndf, ax, ay, est);
        // Until 4 sigma < 0.96%.
        let seed = 5 + th as u64 + (100.0 * ax) as u64 + (1000.0 * ay) as u64;
        let (e, err) = albedo_by_eval_until(&desc, dir_deg(th), 20_000, 600_000, 0.0024, seed);
        let (es, _) = albedo_by_sample(&desc, dir_deg(th), 20_000, 6);
        (e.x as f64, err, es.x as f64)
    });
    let mut fails = Vec::new();
    for (&(ndf, ax, ay, th), &(e, err, es)) in configs.iter().zip(&results) {
        println!("{ndf:?} ({ax},{ay}) theta {th}: eval {e:.4} +- {err:.4}  sample {es:.5}");
        // 4 sigma plus the documented truncation, and the test must resolve 1%.
        if (e - 1.0).abs() > 4.0 * err + 1e-3 || 4.0 * err > 0.01 || (e - 1.0).abs() > 0.01 {
            fails.push(format!("{ndf:?} ({ax},{ay}) {th}: {e} +- {err}"));
        }
        if !(es > 0.999 && es <= 1.0 + 1e-6) {
            fails.push(format!("{ndf:?} ({ax},{ay}) {th}: sample albedo {es}"));
        }
    }
    assert!(fails.is_empty(), "{fails:#?}");
}

#[test]
fn furnace_bdpt_eval_within_1_percent() {
    let configs = [
        (NdfId::Ggx, 1.0, 1.0, 0.0),
        (NdfId::Ggx, 1.0, 1.0, 80.0),
        (NdfId::Beckmann, 0.5, 0.5, 60.0),
        (NdfId::Ggx, 0.1, 1.0, 30.0),
        (NdfId::Ggx, 2.0, 2.0, 89.0),
    ];
    let results = par_map(&configs, |&(ndf, ax, ay, th)| {
        albedo_by_eval(&pf(ndf, ax, ay, Estimator::Bdpt), dir_deg(th), 20_000, 9)
    });
    for (&(ndf, ax, ay, th), &(e, err)) in configs.iter().zip(&results) {
        let e = e.x as f64;
        println!("BDPT {ndf:?} ({ax},{ay}) theta {th}: {e:.4} +- {err:.4}");
        assert!(
            (e - 1.0).abs() <= 4.0 * err + 1e-3 && (e - 1.0).abs() < 0.01,
            "{ndf:?} ({ax},{ay}) {th}: {e} +- {err}"
        );
    }
}

#[test]
fn furnace_dielectric_reflection_plus_transmission_both_sides() {
    // eta 1.5 from outside, and from inside (wi.z < 0 sees 1 / 1.5).
    let mut configs = Vec::new();
    for (ndf, a, th) in [
        (NdfId::Ggx, 0.1f32, 0.0),
        (NdfId::Ggx, 0.5, 70.0),
        (NdfId::Ggx, 1.0, 0.0),
        (NdfId::Beckmann, 0.5, 30.0),
    ] {
        for side in [1.0f32, -1.0] {
            configs.push((ndf, a, th, side));
        }
    }
    let results = par_map(&configs, |&(ndf, a, th, side)| {
        // PT's next-event terms are heavy-tailed for dielectrics at low and
        // moderate roughness (see the module docs): BDPT here; PT dielectrics
        // are checked by eval_integrates_to_the_sample_albedo and reciprocity.
        let desc = dielectric(pf(ndf, a, a, Estimator::Bdpt), 1.5);
        let mut wi = dir_deg(th);
        wi.z *= side;
        // Until 4 sigma < 0.45%.
        let seed = 11 + (a * 100.0) as u64 + th as u64 + (side > 0.0) as u64;
        let (e, err) = albedo_by_eval_until(&desc, wi, 20_000, 1_500_000, 0.001_15, seed);
        let (es, _) = albedo_by_sample(&desc, wi, 20_000, seed);
        (e.x as f64, err, es.x as f64)
    });
    for (&(ndf, a, th, side), &(e, err, es)) in configs.iter().zip(&results) {
        println!(
            "dielectric {ndf:?} {a} theta {th} side {side}: eval {e:.4} +- {err:.4} sample {es:.5}"
        );
        assert!(
            (e - 1.0).abs() <= 4.0 * err + 1e-3 && (e - 1.0).abs() < 0.005 && 4.0 * err < 0.005,
            "{ndf:?} {a} {th} {side}: {e} +- {err}"
        );
        assert!(es > 0.999, "{ndf:?} {a} {th} {side}: sample {es}");
    }
}

#[test]
fn eval_integrates_to_the_sample_albedo() {
    // Absorbing facets, so the albedo is not 1 by construction: the integral
    // of eval equals the mean sample weight within 4 combined sigma.
    let configs = [
        (gold(pf(NdfId::Ggx, 1.0, 1.0, Estimator::Pt)), 0.0),
        (gold(pf(NdfId::Ggx, 1.0, 1.0, Estimator::Bdpt)), 60.0),
        (gold(pf(NdfId::Beckmann, 0.3, 0.9, Estimator::Pt)), 75.0),
        (
            dielectric(pf(NdfId::Ggx, 0.8, 0.8, Estimator::Pt), 1.33),
            40.0,
        ),
        (
            dielectric(pf(NdfId::Beckmann, 0.4, 0.4, Estimator::Bdpt), 1.33),
            70.0,
        ),
    ];
    let results = par_map(&configs, |(desc, th)| {
        let (e, ee) = albedo_by_eval(desc, dir_deg(*th), 60_000, 31);
        let (s, se) = albedo_by_sample(desc, dir_deg(*th), 200_000, 32);
        (e, ee, s, se)
    });
    for ((desc, th), &(e, ee, s, se)) in configs.iter().zip(&results) {
        let (em, sm) = ((e.x + e.y + e.z) / 3.0, (s.x + s.y + s.z) / 3.0);
        println!("{:?} {th}: eval {e} sample {s}", desc.facet);
        let tol = 4.0 * (ee * ee + se * se).sqrt();
        // Decisive: a 3% disagreement is more than 4 combined sigma
        // (measured worst 4 sigma: 2.5%, rough glass eta 1.33).
        assert!(
            tol < 0.03 * sm as f64,
            "{desc:?} {th}: 4 sigma {tol} for {sm}"
        );
        assert!(
            ((em - sm) as f64).abs() < tol,
            "{desc:?} {th}: eval {em} sample {sm} tol {tol}"
        );
    }
}

#[test]
fn single_bounce_equals_uncorrelated_single() {
    // A path with one vertex is s_0 v_0 s_1 = F D G1(wi) G1(wo) / (4 ...):
    // the height-UNcorrelated Cook-Torrance (Wang et al. 2022 sec. 3.4), exactly.
    let mut rng = Rng::new(99, 1);
    let mut worst = 0.0f32;
    let mut max_corr_gap = 0.0f32;
    for (ndf, shape) in [
        (NdfId::Ggx, 2.0f32),
        (NdfId::Beckmann, 2.0),
        (NdfId::StudentT, 1.8),
        (NdfId::StudentT, 20.0),
    ] {
        for (ax, ay) in [(0.2, 0.2), (0.7, 0.7), (0.3, 1.2)] {
            for (facet, eta) in [(0, 0.0), (1, 1.5), (1, 1.0 / 1.5)] {
                for est in [Estimator::Pt, Estimator::Bdpt] {
                    let base = MaterialDesc {
                        max_bounces: 1,
                        shape,
                        ..pf(ndf, ax, ay, est)
                    };
                    let (desc, f) = if facet == 0 {
                        (
                            gold(base),
                            Facet::Conductor {
                                eta: Vec3::from(GOLD_ETA),
                                k: Vec3::from(GOLD_K),
                            },
                        )
                    } else {
                        (dielectric(base, eta), Facet::Dielectric { eta })
                    };
                    let m = Material::new(&desc).unwrap();
                    let n = Ndf::with_shape(ndf_kind(ndf), ax, ay, shape);
                    let unc = Single::new(n, f, G2Form::Uncorrelated);
                    let cor = Single::new(n, f, G2Form::HeightCorrelated);
                    for _ in 0..300 {
                        let wi = cosine_dir(rng.next_f32(), rng.next_f32(), 1.0);
                        let side = if facet == 1 && rng.next_f32() < 0.5 {
                            -1.0
                        } else {
                            1.0
                        };
                        let wo = cosine_dir(rng.next_f32(), rng.next_f32(), side);
                        let a = m.eval(wi, wo, &mut rng);
                        let b = unc.eval(wi, wo, &mut rng);
                        let c = cor.eval(wi, wo, &mut rng);
                        let scale = b.max_element().max(1e-3);
                        worst = worst.max((a - b).abs().max_element() / scale);
                        max_corr_gap = max_corr_gap.max((a - c).abs().max_element() / scale);
                    }
                }
            }
        }
    }
    println!("max rel. diff vs uncorrelated {worst:e}, vs height-correlated {max_corr_gap:e}");
    assert!(worst < 2e-4, "{worst}");
    // ... and clearly not the height-correlated form.
    assert!(max_corr_gap > 0.05, "{max_corr_gap}");
}

/// Mean and variance of `eval` (channel mean) over `n` calls.
fn eval_stats(m: &Material, wi: Vec3, wo: Vec3, n: usize, seed: u64) -> (f64, f64) {
    let mut rng = Rng::new(seed, 5);
    let (mut s1, mut s2) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let v = m.eval(wi, wo, &mut rng);
        let x = ((v.x + v.y + v.z) / 3.0) as f64;
        s1 += x;
        s2 += x * x;
    }
    let mean = s1 / n as f64;
    (mean, (s2 / n as f64 - mean * mean).max(0.0))
}

#[test]
fn bdpt_has_lower_variance_than_pt_rough_conductor() {
    // Rough conductor (gold, GGX alpha 1), theta_i 0 and 60; the variance of
    // one eval summed over a ring of outgoing directions, equal samples.
    // Measured ratios (200k evals per direction): see the module docs.
    let n = 60_000;
    for th in [0.0, 60.0] {
        let wi = dir_deg(th);
        let pt = Material::new(&gold(pf(NdfId::Ggx, 1.0, 1.0, Estimator::Pt))).unwrap();
        let bd = Material::new(&gold(pf(NdfId::Ggx, 1.0, 1.0, Estimator::Bdpt))).unwrap();
        let (mut vp, mut vb) = (0.0, 0.0);
        for (i, (to, po)) in [(20.0f32, 0.0f32), (45.0, 180.0), (70.0, 90.0), (45.0, 0.0)]
            .into_iter()
            .enumerate()
        {
            let (t, p) = (to.to_radians(), po.to_radians());
            let wo = Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
            let (mp, a) = eval_stats(&pt, wi, wo, n, 40 + i as u64);
            let (mb, b) = eval_stats(&bd, wi, wo, n, 50 + i as u64);
            // Both estimate the same value.
            let tol = 4.0 * ((a + b) / n as f64).sqrt();
            assert!(
                (mp - mb).abs() < tol,
                "theta {th} wo {to},{po}: {mp} vs {mb}"
            );
            vp += a;
            vb += b;
        }
        println!(
            "theta_i {th}: var PT {vp:.4e} BDPT {vb:.4e} ratio {:.3}",
            vb / vp
        );
        assert!(vb / vp < 1.0, "theta {th}: ratio {}", vb / vp);
    }
}

#[test]
fn reciprocity_within_noise() {
    // Reflection: f(wi, wo) = f(wo, wi), with eval = f |wo.z|. Transmission
    // (flux form): f(wi, wo) / eta_o^2 = f(wo, wi) / eta_i^2.
    let n = 20_000;
    let cases = [
        (gold(pf(NdfId::Ggx, 0.8, 0.8, Estimator::Pt)), 1.0f32),
        (gold(pf(NdfId::Beckmann, 0.3, 1.0, Estimator::Bdpt)), 1.0),
        (
            dielectric(pf(NdfId::Ggx, 0.7, 0.7, Estimator::Pt), 1.5),
            1.5,
        ),
        (
            dielectric(pf(NdfId::Beckmann, 1.0, 1.0, Estimator::Bdpt), 1.5),
            1.5,
        ),
    ];
    let mut rng = Rng::new(3, 3);
    let mut count = 0;
    for (desc, eta) in cases {
        let m = Material::new(&desc).unwrap();
        let diel = desc.facet == FacetKind::Dielectric;
        for _ in 0..6 {
            let wi = cosine_dir(rng.next_f32(), rng.next_f32(), 1.0);
            let side = if diel && rng.next_f32() < 0.5 {
                -1.0
            } else {
                1.0
            };
            let wo = cosine_dir(rng.next_f32(), rng.next_f32(), side);
            let (a, va) = eval_stats(&m, wi, wo, n, 60 + count);
            let (b, vb) = eval_stats(&m, wo, wi, n, 70 + count);
            count += 1;
            // f values with the eta weights of the generalised form.
            let (ei, eo) = (1.0f64, if wo.z < 0.0 { eta as f64 } else { 1.0 });
            let fa = a / wo.z.abs() as f64 / (eo * eo);
            let fb = b / wi.z.abs() as f64 / (ei * ei);
            let sa = (va / n as f64).sqrt() / wo.z.abs() as f64 / (eo * eo);
            let sb = (vb / n as f64).sqrt() / wi.z.abs() as f64;
            // Decisive: sigma below 2.5% of the value in reflection (a 10%
            // asymmetry fails), 15% in transmission (the effect there is a
            // lost or doubled eta^2: 125%; these random pairs can be far
            // from the refracted lobe, measured up to 10.7%).
            let bound = if wo.z < 0.0 { 0.15 } else { 0.025 };
            let sigma = (sa * sa + sb * sb).sqrt();
            println!(
                "reciprocity {:?} {wi} {wo}: {fa:.5} vs {fb:.5}, sigma {:.2}%",
                desc.facet,
                100.0 * sigma / fa.abs().max(fb.abs())
            );
            assert!(
                sigma < bound * fa.abs().max(fb.abs()),
                "{:?} {wi} {wo}: sigma {sigma} for {fa}",
                desc.facet
            );
            let tol = 4.0 * sigma + 1e-5 * fa.abs();
            assert!(
                (fa - fb).abs() < tol,
                "{:?} {wi} {wo}: {fa} vs {fb} (tol {tol})",
                desc.facet
            );
        }
    }
}

/// Sample against eval: the sphere split into `nt` bins uniform in cos theta
/// by `np` in phi per hemisphere; observed = sample counts (weights are 1 for
/// white facets), expected = n times the integral of eval over the bin by
/// jittered quadrature, whose own variance is added to the denominator.
fn chi2_sample_vs_eval(desc: &MaterialDesc, wi: Vec3, seed: u64) -> Chi2 {
    let m = Material::new(desc).unwrap();
    let (nt, np) = (8usize, 16usize);
    let sides = if desc.facet == FacetKind::Dielectric {
        2
    } else {
        1
    };
    let nbins = nt * np * sides;
    let bin_of = |w: Vec3| -> usize {
        let side = if w.z * wi.z > 0.0 { 0 } else { 1 };
        let ct = w.z.abs().min(1.0 - 1e-7);
        let it = ((ct * nt as f32) as usize).min(nt - 1);
        let mut phi = w.y.atan2(w.x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let ip = ((phi / (2.0 * PI) * np as f32) as usize).min(np - 1);
        (side * nt + it) * np + ip
    };
    let n_samples = 300_000usize;
    let white = desc.facet == FacetKind::Dielectric || desc.eta == Vec3::ZERO;
    // Weighted histogram (first channel) and the sum of squared weights,
    // the variance of a bin's weighted count.
    let (mut observed, mut observed_var) = (vec![0.0f64; nbins], vec![0.0f64; nbins]);
    let mut rng = Rng::new(seed, 1);
    for _ in 0..n_samples {
        let s = m.sample(wi, &mut rng);
        if s.flags & msbsdf::SAMPLE_ABSORBED != 0 {
            continue;
        }
        assert!(s.pdf > 0.0, "sample went where pdf is 0: {:?}", s.wo);
        if white {
            assert!((s.weight - Vec3::ONE).abs().max_element() < 1e-5);
        }
        let w = s.weight.x as f64;
        observed[bin_of(s.wo)] += w;
        observed_var[bin_of(s.wo)] += w * w;
    }
    let per_bin = 1500usize;
    let (mut expected, mut var) = (vec![0.0f64; nbins], vec![0.0f64; nbins]);
    let bin_area = 2.0 * std::f64::consts::PI / (nt * np) as f64;
    for b in 0..nbins {
        let side = b / (nt * np);
        let it = (b / np) % nt;
        let ip = b % np;
        let (mut s1, mut s2) = (0.0f64, 0.0f64);
        for k in 0..per_bin {
            // Stratified in phi within the bin.
            let u = (it as f32 + rng.next_f32()) / nt as f32;
            let v = (ip as f32 + (k as f32 + rng.next_f32()) / per_bin as f32) / np as f32;
            let phi = 2.0 * PI * v;
            let st = (1.0 - u * u).max(0.0).sqrt();
            let z = if side == 0 { u } else { -u } * wi.z.signum();
            let wo = Vec3::new(st * phi.cos(), st * phi.sin(), z);
            let x = m.eval(wi, wo, &mut rng).x as f64;
            s1 += x;
            s2 += x * x;
        }
        let mean = s1 / per_bin as f64;
        let v = (s2 / per_bin as f64 - mean * mean).max(0.0) / per_bin as f64;
        expected[b] = n_samples as f64 * bin_area * mean;
        var[b] = (n_samples as f64 * bin_area).powi(2) * v;
    }
    // Chi-square statistic with both variances (for unit weights the
    // expectation, as in Pearson's; for weighted counts the expectation
    // times the mean squared weight of the bin; plus the quadrature's):
    // pool the cells below 5 expected counts into one.
    let mut idx: Vec<usize> = (0..nbins).collect();
    idx.sort_by(|&a, &b| expected[a].partial_cmp(&expected[b]).unwrap());
    let (mut po, mut pe, mut pv) = (0.0, 0.0, 0.0);
    let (mut chi2, mut cells) = (0.0, 0usize);
    let count_var = |i: usize| {
        if white || observed[i] <= 0.0 {
            expected[i]
        } else {
            expected[i] * observed_var[i] / observed[i]
        }
    };
    for &i in &idx {
        if expected[i] < 5.0 || pe > 0.0 && pe < 5.0 {
            po += observed[i];
            pe += expected[i];
            pv += var[i] + count_var(i);
        } else {
            chi2 += (observed[i] - expected[i]).powi(2) / (var[i] + count_var(i));
            cells += 1;
        }
    }
    if pe > 0.0 {
        chi2 += (po - pe).powi(2) / pv;
        cells += 1;
    }
    let dof = cells.saturating_sub(1).max(1);
    Chi2 {
        chi2,
        dof,
        p: gamma_q(dof as f64 / 2.0, chi2 / 2.0),
    }
}

#[test]
fn sample_matches_eval_chi_square() {
    let cases = [
        (pf(NdfId::Ggx, 1.0, 1.0, Estimator::Bdpt), 60.0, 1.0f32),
        (pf(NdfId::Beckmann, 0.3, 0.8, Estimator::Bdpt), 30.0, 1.0),
        (
            dielectric(pf(NdfId::Ggx, 0.7, 0.7, Estimator::Bdpt), 1.5),
            45.0,
            1.0,
        ),
        (
            dielectric(pf(NdfId::Ggx, 0.7, 0.7, Estimator::Bdpt), 1.5),
            20.0,
            -1.0,
        ),
        (gold(pf(NdfId::Ggx, 0.8, 0.8, Estimator::Pt)), 50.0, 1.0),
    ];
    let level = sidak(0.01, cases.len());
    let results = par_map(&cases, |(desc, th, side)| {
        let mut wi = dir_deg(*th);
        wi.z *= side;
        chi2_sample_vs_eval(desc, wi, 77)
    });
    for ((desc, th, side), r) in cases.iter().zip(&results) {
        println!(
            "{:?} {:?} theta {th} side {side}: chi2 {:.1} dof {} p {:.4}",
            desc.ndf, desc.facet, r.chi2, r.dof, r.p
        );
        assert!(r.p > level, "{desc:?} {th}: p {} < {level}", r.p);
    }
}

#[test]
fn stability_sweep_no_nan_inf_or_negative() {
    let mut rng = Rng::new(2024, 7);
    let alphas = [1e-3f32, 0.01, 0.1, 0.5, 1.0, 3.0, 10.0];
    let mut n = 0;
    for ndf in [NdfId::Ggx, NdfId::Beckmann] {
        for est in [Estimator::Pt, Estimator::Bdpt] {
            for &ax in &alphas {
                let ay = alphas[(rng.next_u32() % alphas.len() as u32) as usize];
                let base = pf(ndf, ax, ay, est);
                let descs = [
                    base,
                    gold(base),
                    dielectric(base, 1.5),
                    dielectric(base, 1.0 / 1.5),
                    dielectric(base, 1.0001),
                    dielectric(base, 3.0),
                ];
                for desc in descs {
                    let m = Material::new(&desc).unwrap();
                    for _ in 0..40 {
                        let wi = sweep_dir(&mut rng);
                        let wo = cosine_dir(
                            rng.next_f32(),
                            rng.next_f32(),
                            if rng.next_f32() < 0.5 { 1.0 } else { -1.0 },
                        );
                        for (a, b) in [(wi, wo), (wo, wi)] {
                            let v = m.eval(a, b, &mut rng);
                            assert!(v.is_finite() && v.min_element() >= 0.0, "{desc:?} {a} {b}");
                            let p = m.pdf(a, b);
                            assert!(p.is_finite() && p >= 0.0, "{desc:?} {a} {b}");
                            let s = m.sample(a, &mut rng);
                            assert!(
                                s.weight.is_finite() && s.weight.min_element() >= 0.0,
                                "{desc:?} {a}"
                            );
                            if s.flags & msbsdf::SAMPLE_ABSORBED == 0 {
                                assert!(s.pdf > 0.0 && s.pdf.is_finite(), "{desc:?} {a} {s:?}");
                                assert!(m.pdf(a, s.wo) > 0.0);
                                if desc.facet == FacetKind::Conductor {
                                    assert!(s.wo.z * a.z > 0.0);
                                }
                            }
                            n += 1;
                        }
                    }
                }
            }
        }
    }
    assert!(n > 5000);
}

#[test]
fn material_validation() {
    use msbsdf::Error;
    let d = MaterialDesc {
        facet: FacetKind::Diffuse,
        ..pf(NdfId::Ggx, 0.5, 0.5, Estimator::Pt)
    };
    assert_eq!(Material::new(&d), Err(Error::Unsupported));
    // Student-T: accepted for shapes in (1.5, 1e4] (tests below), refused
    // outside that range like every model.
    let d = pf(NdfId::StudentT, 0.5, 0.5, Estimator::Pt);
    assert!(Material::new(&d).is_ok());
    for shape in [1.5, 1.1e4] {
        let d = MaterialDesc {
            shape,
            ..pf(NdfId::StudentT, 0.5, 0.5, Estimator::Bdpt)
        };
        assert_eq!(Material::new(&d), Err(Error::InvalidArgument));
    }
    let d = MaterialDesc {
        max_bounces: 257,
        ..pf(NdfId::Ggx, 0.5, 0.5, Estimator::Pt)
    };
    assert_eq!(Material::new(&d), Err(Error::InvalidArgument));
    let m = Material::new(&pf(NdfId::Ggx, 0.5, 0.5, Estimator::Bdpt)).unwrap();
    assert!(m.is_stochastic());
    // Conductors do not transmit; horizon directions give zero.
    let mut rng = Rng::new(1, 1);
    assert_eq!(m.eval(dir_deg(30.0), -dir_deg(40.0), &mut rng), Vec3::ZERO);
    assert_eq!(m.pdf(dir_deg(30.0), Vec3::X), 0.0);
}

/// POSITION_FREE minus HEITZ_RANDOM_WALK, eval at fixed direction pairs.
/// Returns (pf, pf error, heitz, heitz error) of the channel mean.
fn pf_minus_heitz(desc: &MaterialDesc, wi: Vec3, wo: Vec3, n: usize, seed: u64) -> [f64; 4] {
    let pf = Material::new(desc).unwrap();
    let hz = Material::new(&MaterialDesc {
        model: Model::HeitzRandomWalk,
        ..*desc
    })
    .unwrap();
    let (a, va) = eval_stats(&pf, wi, wo, n, seed);
    let (b, vb) = eval_stats(&hz, wi, wo, n, seed + 1);
    [a, (va / n as f64).sqrt(), b, (vb / n as f64).sqrt()]
}

fn dir2(theta_deg: f32, phi_deg: f32, side: f32) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), side * t.cos())
}

#[test]
fn position_free_minus_heitz_table() {
    // (label, desc, wi, wo)
    let mut cases = Vec::new();
    for (ndf, a) in [
        (NdfId::Ggx, 0.5f32),
        (NdfId::Ggx, 1.0),
        (NdfId::Beckmann, 1.0),
    ] {
        let d = pf(ndf, a, a, Estimator::Bdpt);
        for th in [0.0f32, 60.0, 85.0] {
            cases.push((format!("{ndf:?} {a} mirror"), d, th, dir2(th, 180.0, 1.0)));
            cases.push((
                format!("{ndf:?} {a} mirror"),
                d,
                th,
                dir2(th.max(30.0), 0.0, 1.0),
            ));
            cases.push((format!("{ndf:?} {a} mirror"), d, th, dir2(45.0, 90.0, 1.0)));
        }
    }
    let dg = dielectric(pf(NdfId::Ggx, 1.0, 1.0, Estimator::Bdpt), 1.5);
    for th in [0.0f32, 60.0, 85.0] {
        cases.push(("Ggx 1 glass".to_string(), dg, th, dir2(th, 180.0, 1.0)));
        cases.push(("Ggx 1 glass".to_string(), dg, th, dir2(30.0, 180.0, -1.0)));
    }
    let results = par_map(&cases, |(_, d, th, wo)| {
        pf_minus_heitz(d, dir2(*th, 0.0, 1.0), *wo, 40_000, 900)
    });
    println!(
        "| material | theta_i | wo (theta, phi) | POSITION_FREE | HEITZ | diff | diff / HEITZ |"
    );
    for ((label, _, th, wo), r) in cases.iter().zip(&results) {
        let t = wo.z.abs().acos().to_degrees();
        let p = wo.y.atan2(wo.x).to_degrees();
        let side = if wo.z < 0.0 { " T" } else { "" };
        let diff = r[0] - r[2];
        let err = (r[1] * r[1] + r[3] * r[3]).sqrt();
        println!(
            "| {label} | {th} | ({t:.0}, {p:.0}){side} | {:.4} +- {:.4} | {:.4} +- {:.4} | {diff:+.4} +- {err:.4} | {:+.3} |",
            r[0],
            r[1],
            r[2],
            r[3],
            if r[2] > 0.0 { diff / r[2] } else { 0.0 }
        );
    }
    // What is stable (Wang et al. 2022 sec. 5 and 6: the models differ through the
    // height-uncorrelated segments, most at grazing angles):
    let rel = |i: usize| (results[i][0] - results[i][2]) / results[i][2];
    let sigma = |i: usize| (results[i][1].powi(2) + results[i][3].powi(2)).sqrt();
    for (i, (label, _, th, wo)) in cases.iter().enumerate() {
        let mirror = wo.z > 0.0 && wo.x < 0.0 && (wo.z - dir2(*th, 0.0, 1.0).z).abs() < 1e-6;
        if *th == 85.0 && mirror {
            // 1. Grazing mirror direction: POSITION_FREE is darker by more
            //    than 30% (G1(wi) G1(wo) < 1 / (1 + Lambda_i + Lambda_o)).
            let d = results[i][0] - results[i][2];
            assert!(
                d < -4.0 * sigma(i) && rel(i) < -0.3,
                "{label} {th}: {}",
                rel(i)
            );
            // 2. ... and the gap is larger than at normal incidence.
            let j = cases
                .iter()
                .position(|(l, d, t, _)| l == label && *t == 0.0 && d.facet == cases[i].1.facet)
                .unwrap();
            assert!(
                rel(i).abs() > rel(j).abs() + 0.2,
                "{label}: {} vs {}",
                rel(i),
                rel(j)
            );
        }
        // 3. Away from grazing and from the mirror lobe the two agree closely.
        if *th == 60.0 && (wo.z - dir2(45.0, 90.0, 1.0).z).abs() < 1e-6 && wo.y > 0.5 {
            assert!(rel(i).abs() < 0.03, "{label} {th}: {}", rel(i));
        }
    }
}

#[test]
fn pdf_integrates_to_at_most_one() {
    // Mitsuba's chi2 rule: a pdf may not integrate above 1. Stratified
    // uniform sphere quadrature, 4 sigma.
    let cases = [
        (pf(NdfId::Ggx, 0.3, 0.3, Estimator::Pt), 30.0),
        (pf(NdfId::Beckmann, 1.0, 0.4, Estimator::Pt), 70.0),
        (
            dielectric(pf(NdfId::Ggx, 0.5, 0.5, Estimator::Pt), 1.5),
            0.0,
        ),
        (
            dielectric(pf(NdfId::Ggx, 1.0, 1.0, Estimator::Pt), 1.5),
            60.0,
        ),
    ];
    let mut rng = Rng::new(8, 8);
    for (desc, th) in cases {
        let m = Material::new(&desc).unwrap();
        let wi = dir_deg(th);
        let (nu, nv) = (600usize, 1200usize);
        let (mut s1, mut s2) = (0.0f64, 0.0f64);
        for i in 0..nu {
            for j in 0..nv {
                let z = 1.0 - 2.0 * (i as f32 + rng.next_f32()) / nu as f32;
                let phi = 2.0 * PI * (j as f32 + rng.next_f32()) / nv as f32;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let wo = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                let x = m.pdf(wi, wo) as f64 * 4.0 * std::f64::consts::PI;
                s1 += x;
                s2 += x * x;
            }
        }
        let n = (nu * nv) as f64;
        let mean = s1 / n;
        let err = ((s2 / n - mean * mean).max(0.0) / n).sqrt();
        println!("pdf integral {:?} {th}: {mean:.4} +- {err:.4}", desc.facet);
        assert!(
            mean <= 1.0 + 4.0 * err && mean > 0.8,
            "{desc:?} {th}: {mean} +- {err}"
        );
    }
}

/// Student-T (d'Eon 2023) white conductor, shapes 1.8 (heavier-tailed than
/// GGX), 3 and 20, alpha 0.3 and 1, incidences 0, 60 and 89 degrees: the
/// same claims and tolerances as `furnace_conductor_white_eval_within_1_percent`
/// (PT; eval integral within 4 sigma + 0.1% and 1% of 1, sample albedo
/// above 0.999 with the default bounce limit, which scales with the tail
/// for shapes below 2), and BDPT on a subset (as `furnace_bdpt_eval_within_1_percent`).
#[test]
fn furnace_student_t_conductor_white_eval_within_1_percent() {
    let mut configs = Vec::new();
    for g in [1.8f32, 3.0, 20.0] {
        for a in [0.3f32, 1.0] {
            for th in [0.0, 60.0, 89.0] {
                configs.push((g, a, th, Estimator::Pt));
            }
        }
    }
    for (g, a, th) in [
        (1.8f32, 1.0f32, 0.0),
        (1.8, 0.3, 89.0),
        (3.0, 1.0, 60.0),
        (20.0, 0.3, 0.0),
        (20.0, 1.0, 89.0),
    ] {
        configs.push((g, a, th, Estimator::Bdpt));
    }
    let results = par_map(&configs, |&(g, a, th, est)| {
        let desc = MaterialDesc {
            shape: g,
            ..pf(NdfId::StudentT, a, a, est)
        };
        let seed = 300 + th as u64 + (100.0 * a) as u64 + (10.0 * g) as u64;
        let (e, err) = if est == Estimator::Pt {
            albedo_by_eval_until(&desc, dir_deg(th), 20_000, 600_000, 0.0024, seed)
        } else {
            albedo_by_eval(&desc, dir_deg(th), 20_000, seed)
        };
        let (es, _) = albedo_by_sample(&desc, dir_deg(th), 20_000, seed);
        (e.x as f64, err, es.x as f64)
    });
    let mut fails = Vec::new();
    for (&(g, a, th, est), &(e, err, es)) in configs.iter().zip(&results) {
        println!(
            "Student-T {g} alpha {a} theta {th} {est:?}: eval {e:.4} +- {err:.4}  sample {es:.5}"
        );
        // PT: 4 sigma plus the truncation, resolving 1%; BDPT (20k evals):
        // 4 sigma plus the truncation and within 1%.
        let resolved = est == Estimator::Bdpt || 4.0 * err <= 0.01;
        if (e - 1.0).abs() > 4.0 * err + 1e-3 || !resolved || (e - 1.0).abs() > 0.01 {
            fails.push(format!(
                "Student-T {g} alpha {a} {th} {est:?}: {e} +- {err}"
            ));
        }
        if !(es > 0.999 && es <= 1.0 + 1e-6) {
            fails.push(format!("Student-T {g} alpha {a} {th}: sample albedo {es}"));
        }
    }
    assert!(fails.is_empty(), "{fails:#?}");
}

/// Student-T glass (eta 1.5, shape 1.8 and 20) from both sides, BDPT:
/// reflected plus transmitted albedo 1 within 4 sigma + 0.1% and 1%.
#[test]
fn furnace_student_t_dielectric_both_sides() {
    let mut configs = Vec::new();
    for (g, a, th) in [(1.8f32, 0.5f32, 30.0), (20.0, 1.0, 60.0)] {
        for side in [1.0f32, -1.0] {
            configs.push((g, a, th, side));
        }
    }
    let results = par_map(&configs, |&(g, a, th, side)| {
        let desc = dielectric(
            MaterialDesc {
                shape: g,
                ..pf(NdfId::StudentT, a, a, Estimator::Bdpt)
            },
            1.5,
        );
        let mut wi = dir_deg(th);
        wi.z *= side;
        let seed = 400 + (10.0 * g) as u64 + (side > 0.0) as u64;
        let (e, err) = albedo_by_eval_until(&desc, wi, 10_000, 200_000, 0.0024, seed);
        let (es, _) = albedo_by_sample(&desc, wi, 20_000, seed);
        (e.x as f64, err, es.x as f64)
    });
    for (&(g, a, th, side), &(e, err, es)) in configs.iter().zip(&results) {
        println!(
            "Student-T {g} glass alpha {a} theta {th} side {side}: eval {e:.4} +- {err:.4} sample {es:.5}"
        );
        assert!(
            (e - 1.0).abs() <= 4.0 * err + 1e-3 && (e - 1.0).abs() < 0.01,
            "Student-T {g} {a} {th} {side}: {e} +- {err}"
        );
        assert!(es > 0.999, "Student-T {g} {a} {th} {side}: sample {es}");
    }
}

/// No NaN, Inf or negative values with Student-T shapes down to 1.51,
/// roughness 1e-3 .. 3, conductor and glass, grazing directions.
#[test]
fn student_t_stability_sweep() {
    let mut rng = Rng::new(2025, 9);
    let mut n = 0;
    for est in [Estimator::Pt, Estimator::Bdpt] {
        for shape in [1.51f32, 1.7, 2.5, 20.0, 1e4] {
            for &ax in &[1e-3f32, 0.1, 1.0, 3.0] {
                let base = MaterialDesc {
                    shape,
                    ..pf(NdfId::StudentT, ax, ax.min(0.5), est)
                };
                for desc in [gold(base), dielectric(base, 1.5)] {
                    let m = Material::new(&desc).unwrap();
                    for _ in 0..12 {
                        let wi = sweep_dir(&mut rng);
                        let side = if rng.next_f32() < 0.5 { 1.0 } else { -1.0 };
                        let wo = cosine_dir(rng.next_f32(), rng.next_f32(), side);
                        let v = m.eval(wi, wo, &mut rng);
                        assert!(
                            v.is_finite() && v.min_element() >= 0.0,
                            "{desc:?} {wi} {wo}"
                        );
                        let p = m.pdf(wi, wo);
                        assert!(p.is_finite() && p >= 0.0, "{desc:?} {wi} {wo}");
                        let s = m.sample(wi, &mut rng);
                        assert!(s.weight.is_finite() && s.weight.min_element() >= 0.0);
                        if s.flags & msbsdf::SAMPLE_ABSORBED == 0 {
                            assert!(s.pdf > 0.0 && m.pdf(wi, s.wo) > 0.0, "{desc:?} {wi} {s:?}");
                        }
                        n += 1;
                    }
                }
            }
        }
    }
    assert_eq!(n, 2 * 5 * 4 * 2 * 12);
}
