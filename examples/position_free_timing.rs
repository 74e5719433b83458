//! Release-mode timing of MSBSDF_MODEL_POSITION_FREE (PT and BDPT): ns per
//! eval and per sample, the variance of one eval, and the efficiency
//! 1 / (variance x time). Run: `cargo run --release --example position_free_timing`.
use glam::Vec3;
use msbsdf::{Estimator, Material, MaterialDesc, Model, Rng};
use std::hint::black_box;
use std::time::Instant;

fn dir(theta_deg: f32, phi_deg: f32) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

fn main() {
    let gold_eta = Vec3::new(0.143, 0.374, 1.442);
    let gold_k = Vec3::new(3.983, 2.385, 1.603);
    println!(
        "GGX gold; wo at theta_o 45 deg, phi 180 (forward side); variance of the channel mean"
    );
    println!("alpha theta_i est   ns/eval ns/sample  mean      rel.var   efficiency(1/(var*s))");
    for alpha in [0.5f32, 1.0] {
        for theta in [0.0f32, 60.0] {
            for est in [Estimator::Pt, Estimator::Bdpt] {
                let m = Material::new(&MaterialDesc {
                    model: Model::PositionFree,
                    estimator: est,
                    alpha_x: alpha,
                    alpha_y: alpha,
                    eta: gold_eta,
                    k: gold_k,
                    ..MaterialDesc::default()
                })
                .unwrap();
                let wi = dir(theta, 0.0);
                let wo = dir(45.0, 180.0);
                let mut rng = Rng::new(3, 4);
                let (chunks, per) = (10usize, 40_000usize);
                let n = chunks * per;
                // Variance of one eval; time = fastest chunk (the machine is shared).
                let (mut s, mut s2) = (0.0f64, 0.0f64);
                let mut t_eval = f64::INFINITY;
                for _ in 0..chunks {
                    let t0 = Instant::now();
                    for _ in 0..per {
                        let v = m.eval(wi, wo, &mut rng);
                        let x = ((v.x + v.y + v.z) / 3.0) as f64;
                        s += x;
                        s2 += x * x;
                    }
                    t_eval = t_eval.min(t0.elapsed().as_secs_f64() / per as f64);
                }
                let mean = s / n as f64;
                let var = s2 / n as f64 - mean * mean;
                let mut t_sample = f64::INFINITY;
                let mut acc = Vec3::ZERO;
                for _ in 0..chunks {
                    let t0 = Instant::now();
                    for _ in 0..per {
                        acc += m.sample(black_box(wi), &mut rng).weight;
                    }
                    t_sample = t_sample.min(t0.elapsed().as_secs_f64() / per as f64);
                }
                black_box(acc);
                println!(
                    "{alpha:<5} {theta:<7} {:<5} {:>7.0} {:>9.0} {:.6} {:.3e} {:.3e}",
                    format!("{est:?}"),
                    t_eval * 1e9,
                    t_sample * 1e9,
                    mean,
                    var / (mean * mean),
                    1.0 / (var * t_eval)
                );
            }
        }
    }
}
