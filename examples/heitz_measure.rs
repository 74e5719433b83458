//! Measurements behind the HEITZ_RANDOM_WALK docs: truncated energy per
//! bounce limit, albedos, bounce counts, eval variance and timings.
//! `cargo run --release --example heitz_measure [ss | trunc [glass]]`;
//! without an argument: timings, albedo, eval variance and bounce counts
//! for GGX gold.

use glam::Vec3;
use msbsdf::bsdf::ScatterModel;
use msbsdf::facet::Facet;
use msbsdf::multiple::heitz::Heitz;
use msbsdf::ndf::{Ndf, NdfKind};
use msbsdf::{Material, MaterialDesc, Model, Rng};
use std::time::Instant;

fn dir(theta_deg: f32) -> Vec3 {
    let t = theta_deg.to_radians();
    Vec3::new(t.sin(), 0.0, t.cos())
}

fn truncation() {
    let mirror = Facet::Conductor {
        eta: Vec3::ZERO,
        k: Vec3::ONE,
    };
    let glass = Facet::Dielectric { eta: 1.5 };
    let only_glass = std::env::args().nth(2).is_some();
    for (name, facet) in [
        ("mirror", mirror),
        ("glass1.5", glass),
        ("glass3", Facet::Dielectric { eta: 3.0 }),
        ("glass1/1.5", Facet::Dielectric { eta: 1.0 / 1.5 }),
        ("glass1/3", Facet::Dielectric { eta: 1.0 / 3.0 }),
        ("diffuse", Facet::Diffuse { albedo: Vec3::ONE }),
    ] {
        if only_glass && name == "mirror" {
            continue;
        }
        for kind in [NdfKind::Ggx, NdfKind::Beckmann] {
            for alpha in (if only_glass {
                &[0.1f32, 0.5, 1.0, 2.0, 5.0][..]
            } else {
                &[0.5f32, 1.0, 1.5, 2.0, 3.0, 5.0, 10.0][..]
            })
            .iter()
            .copied()
            {
                let h = Heitz::new(Ndf::new(kind, alpha, alpha), facet, 256);
                for th in [0.0f32, 60.0, 89.0] {
                    let n = 200_000;
                    let mut hist = vec![0u64; 258];
                    let mut rng = Rng::new(1, 2);
                    for _ in 0..n {
                        let (_, b) = h.sample_with_bounces(dir(th), &mut rng);
                        hist[b as usize] += 1;
                    }
                    let frac_above = |k: usize| hist[k + 1..].iter().sum::<u64>() as f64 / n as f64;
                    let mean: f64 = hist
                        .iter()
                        .enumerate()
                        .map(|(i, c)| i as f64 * *c as f64)
                        .sum::<f64>()
                        / n as f64;
                    let need3 = (1..256).find(|&k| frac_above(k) < 1e-3).unwrap_or(256);
                    let need4 = (1..256).find(|&k| frac_above(k) < 1e-4).unwrap_or(256);
                    println!(
                        "{name} {kind:?} a {alpha} th {th}: mean {mean:.3} >10 {:.1e} n(1e-3) {need3} n(1e-4) {need4}",
                        frac_above(10)
                    );
                }
            }
        }
    }
}

fn main() {
    let what = std::env::args().nth(1).unwrap_or_default();
    if what == "ss" {
        for kind in [NdfKind::Ggx, NdfKind::Beckmann] {
            for alpha in [0.5f32, 1.0] {
                let ndf = Ndf::new(kind, alpha, alpha);
                let mirror = Facet::Conductor {
                    eta: Vec3::ZERO,
                    k: Vec3::ONE,
                };
                let h = Heitz::new(ndf, mirror, 256);
                let s = msbsdf::single::Single::new(
                    ndf,
                    mirror,
                    msbsdf::single::G2Form::HeightCorrelated,
                );
                let n = 400_000;
                let mut rng = Rng::new(3, 4);
                let (mut one, mut tot, mut es) = (0.0, 0.0, 0.0);
                for _ in 0..n {
                    let (smp, b) = h.sample_with_bounces(dir(0.0), &mut rng);
                    if b == 1 {
                        one += smp.weight.x as f64;
                    }
                    tot += smp.weight.x as f64;
                    es += s.sample(dir(0.0), &mut rng).weight.x as f64;
                }
                println!(
                    "{kind:?} {alpha}: walk order1 {:.4} total {:.4} single {:.4}",
                    one / n as f64,
                    tot / n as f64,
                    es / n as f64
                );
            }
        }
        return;
    }
    if what == "extreme" {
        // Furnace at the edges of the range: energy lost to numerically
        // invisible facets or the bounce limit.
        for kind in [NdfKind::Ggx, NdfKind::Beckmann] {
            for alpha in [1e-3f32, 1e-2, 0.05] {
                for facet in [
                    Facet::Conductor {
                        eta: Vec3::ZERO,
                        k: Vec3::ONE,
                    },
                    Facet::Dielectric { eta: 1.01 },
                    Facet::Dielectric { eta: 3.0 },
                    Facet::Diffuse { albedo: Vec3::ONE },
                ] {
                    let h = Heitz::new(Ndf::new(kind, alpha, alpha), facet, 0);
                    for th in [0.0f32, 80.0, 89.0, 89.9, 89.99] {
                        for below in [false, true] {
                            let mut wi = dir(th);
                            if below {
                                wi.z = -wi.z;
                            }
                            let n = 200_000;
                            let mut rng = Rng::new(5, 6);
                            let mut acc = 0.0f64;
                            for _ in 0..n {
                                acc += h.sample(wi, &mut rng).weight.x as f64;
                            }
                            let a = acc / n as f64;
                            if (a - 1.0).abs() > 1e-3 {
                                println!(
                                    "{kind:?} {alpha} {facet:?} th {th} below {below}: albedo {a:.5}"
                                );
                            }
                        }
                    }
                }
            }
        }
        return;
    }
    if what == "trunc" {
        truncation();
        return;
    }
    // Timing, eval variance and bounce counts: GGX gold.
    for (kind, ndf_id) in [
        (NdfKind::Ggx, msbsdf::NdfId::Ggx),
        (NdfKind::Beckmann, msbsdf::NdfId::Beckmann),
    ] {
        for alpha in [0.5f32, 1.0] {
            let m = Material::new(&MaterialDesc {
                model: Model::HeitzRandomWalk,
                ndf: ndf_id,
                alpha_x: alpha,
                alpha_y: alpha,
                eta: Vec3::new(0.143, 0.374, 1.442),
                k: Vec3::new(3.983, 2.385, 1.603),
                ..MaterialDesc::default()
            })
            .unwrap();
            let h = Heitz::new(
                Ndf::new(kind, alpha, alpha),
                Facet::Conductor {
                    eta: Vec3::new(0.143, 0.374, 1.442),
                    k: Vec3::new(3.983, 2.385, 1.603),
                },
                0,
            );
            for th in [0.0f32, 60.0] {
                let wi = dir(th);
                let wo = Vec3::new(-0.5, 0.3, 0.8).normalize();
                let n = 1_000_000;
                let mut rng = Rng::new(9, 9);
                // Minimum over batches of the time per call: robust to other
                // processes sharing the cores.
                let batches = 400;
                let per = n / batches;
                let time_min = |f: &mut dyn FnMut()| {
                    let mut best = f64::INFINITY;
                    for _ in 0..batches {
                        let t0 = Instant::now();
                        for _ in 0..per {
                            f();
                        }
                        best = best.min(t0.elapsed().as_nanos() as f64 / per as f64);
                    }
                    best
                };
                let mut acc = Vec3::ZERO;
                let ns_sample = time_min(&mut || acc += m.sample(wi, &mut rng).weight);
                let (mut s1, mut s2) = (0.0f64, 0.0f64);
                let mut rng2 = Rng::new(10, 10);
                let ns_eval = time_min(&mut || {
                    let v = m.eval(wi, wo, &mut rng2).y as f64;
                    s1 += v;
                    s2 += v * v;
                });
                let mean = s1 / n as f64;
                let var = s2 / n as f64 - mean * mean;
                let mut p = 0.0;
                let ns_pdf = time_min(&mut || p += m.pdf(wi, wo));
                let mut bsum = 0u64;
                for _ in 0..n / 4 {
                    bsum += h.sample_with_bounces(wi, &mut rng).1 as u64;
                }
                println!(
                    "gold {kind:?} a {alpha} th {th}: sample {ns_sample:.0} ns eval {ns_eval:.0} ns pdf {ns_pdf:.0} ns | albedo {:.4} {:.4} {:.4} | eval(wo=(-.5,.3,.8)) G mean {mean:.5} var {var:.3e} rel.std {:.3} | mean bounces {:.3} {p}",
                    acc.x / n as f32,
                    acc.y / n as f32,
                    acc.z / n as f32,
                    var.sqrt() / mean,
                    bsum as f64 / (n / 4) as f64
                );
            }
        }
    }
}
