//! Time per call, variance of one evaluation and efficiency
//! `1 / (variance x time)` (seed 003, Figure 5) of INVARIANCE (PT, BDPT) and
//! BITTERLI_DEON (PT) on GGX gold.
//!
//! `cargo run --release --example invariance_efficiency`

use glam::Vec3;
use msbsdf::{Estimator, Material, MaterialDesc, Model, NdfId, Rng};
use std::time::Instant;

fn dir(theta_deg: f64, phi_deg: f64) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    Vec3::new(
        (t.sin() * p.cos()) as f32,
        (t.sin() * p.sin()) as f32,
        t.cos() as f32,
    )
}

fn main() {
    let models = [
        ("INVARIANCE PT", Model::Invariance, Estimator::Pt),
        ("INVARIANCE BDPT", Model::Invariance, Estimator::Bdpt),
        ("BITTERLI_DEON PT", Model::BitterliDeon, Estimator::Pt),
    ];
    let n = 40_000usize;
    println!(
        "model              alpha theta_i  ns/eval  ns/sample  mean f.cos  var(1 eval)  rel.err(4 evals)  efficiency 1/(var*s)"
    );
    for alpha in [0.5f32, 1.0] {
        for theta_i in [0.0, 60.0] {
            let wi = dir(theta_i, 0.0);
            // Outgoing directions across the incidence plane (Figure 5's x axis).
            let outs: Vec<Vec3> = [-80.0, -60.0, -30.0, 0.0, 30.0, 60.0, 80.0]
                .iter()
                .map(
                    |&t: &f64| {
                        if t < 0.0 { dir(-t, 180.0) } else { dir(t, 0.0) }
                    },
                )
                .collect();
            for (name, model, est) in models {
                let m = Material::new(&MaterialDesc {
                    model,
                    estimator: est,
                    ndf: NdfId::Ggx,
                    alpha_x: alpha,
                    alpha_y: alpha,
                    eta: Vec3::new(0.143, 0.374, 1.442),
                    k: Vec3::new(3.983, 2.385, 1.603),
                    ..MaterialDesc::default()
                })
                .unwrap();
                let mut rng = Rng::new(1, 2);
                let (mut var_sum, mut mean_sum, mut rel_sum) = (0.0, 0.0, 0.0);
                let t0 = Instant::now();
                let mut sink = 0.0f32;
                for &wo in &outs {
                    let (mut s, mut s2) = (0.0f64, 0.0f64);
                    for _ in 0..n {
                        let v = m.eval(wi, wo, &mut rng).y as f64;
                        s += v;
                        s2 += v * v;
                    }
                    let mean = s / n as f64;
                    let var = (s2 / n as f64 - mean * mean).max(0.0);
                    var_sum += var;
                    mean_sum += mean;
                    rel_sum += (var / 4.0).sqrt() / mean.max(1e-30);
                    sink += mean as f32;
                }
                let ns_eval = t0.elapsed().as_secs_f64() * 1e9 / (n * outs.len()) as f64;
                let t1 = Instant::now();
                for _ in 0..n {
                    sink += m.sample(wi, &mut rng).weight.y;
                }
                let ns_sample = t1.elapsed().as_secs_f64() * 1e9 / n as f64;
                let k = outs.len() as f64;
                let var = var_sum / k;
                let eff = 1.0 / (var * ns_eval * 1e-9);
                println!(
                    "{name:<18} {alpha:>5} {theta_i:>7} {ns_eval:>8.0} {ns_sample:>10.0} {:>11.4} {var:>12.3e} {:>17.4} {eff:>20.3e}",
                    mean_sum / k,
                    rel_sum / k
                );
                std::hint::black_box(sink);
            }
        }
    }
}
