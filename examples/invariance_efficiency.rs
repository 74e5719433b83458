//! Time per call, variance of one evaluation and efficiency
//! `1 / (variance x time)` (seed 003, Figure 5) of INVARIANCE (PT, BDPT) and
//! BITTERLI_DEON (PT) on GGX gold, with HEITZ_RANDOM_WALK for reference.
//! Times are the fastest of 7 interleaved repetitions (shared machine);
//! the variance is the mean over 7 outgoing directions in the incidence
//! plane of the variance of one evaluation (green channel).
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

fn material(model: Model, est: Estimator, alpha: f32) -> Material {
    Material::new(&MaterialDesc {
        model,
        estimator: est,
        ndf: NdfId::Ggx,
        alpha_x: alpha,
        alpha_y: alpha,
        eta: Vec3::new(0.143, 0.374, 1.442),
        k: Vec3::new(3.983, 2.385, 1.603),
        ..MaterialDesc::default()
    })
    .unwrap()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let models = [
        ("INVARIANCE PT", Model::Invariance, Estimator::Pt),
        ("INVARIANCE BDPT", Model::Invariance, Estimator::Bdpt),
        ("BITTERLI_DEON PT", Model::BitterliDeon, Estimator::Pt),
        ("HEITZ", Model::HeitzRandomWalk, Estimator::Pt),
    ];
    if args.len() == 5 && args[1] == "count" {
        // `count <model index> <alpha> <theta_i>`: a fixed workload of
        // 7 x 2000 evaluations (or 14000 samples with a 6th argument), for
        // counting instructions under `valgrind --tool=cachegrind`, which
        // a loaded machine cannot disturb.
        let (_, model, est) = models[args[2].parse::<usize>().unwrap_or(0).min(3)];
        let alpha: f32 = args[3].parse().unwrap_or(1.0);
        let theta: f64 = args[4].parse().unwrap_or(0.0);
        let m = material(model, est, alpha);
        let wi = dir(theta, 0.0);
        let mut rng = Rng::new(1, 2);
        let mut sink = 0.0f32;
        for t in [-80.0, -60.0, -30.0, 0.0, 30.0, 60.0, 80.0f64] {
            let wo = if t < 0.0 { dir(-t, 180.0) } else { dir(t, 0.0) };
            for _ in 0..2000 {
                sink += m.eval(wi, wo, &mut rng).y;
            }
        }
        println!("{sink}");
        return;
    }
    if args.len() == 6 && args[1] == "count" {
        let (_, model, est) = models[args[2].parse::<usize>().unwrap_or(0).min(3)];
        let alpha: f32 = args[3].parse().unwrap_or(1.0);
        let theta: f64 = args[4].parse().unwrap_or(0.0);
        let m = material(model, est, alpha);
        let wi = dir(theta, 0.0);
        let mut rng = Rng::new(1, 2);
        let mut sink = 0.0f32;
        for _ in 0..14000 {
            sink += m.sample(wi, &mut rng).weight.y;
        }
        println!("{sink}");
        return;
    }
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
            // Timing: the machine is shared, so take the fastest of 7
            // interleaved repetitions.
            let mut best_eval = [f64::MAX; 4];
            let mut best_sample = [f64::MAX; 4];
            let mut sink = 0.0f32;
            let reps = 5_000usize;
            for _ in 0..7 {
                for (mi, &(_, model, est)) in models.iter().enumerate() {
                    let m = material(model, est, alpha);
                    let mut rng = Rng::new(9, mi as u64);
                    let t0 = Instant::now();
                    for &wo in &outs {
                        for _ in 0..reps {
                            sink += m.eval(wi, wo, &mut rng).y;
                        }
                    }
                    let t = t0.elapsed().as_secs_f64() * 1e9 / (reps * outs.len()) as f64;
                    best_eval[mi] = best_eval[mi].min(t);
                    let t1 = Instant::now();
                    for _ in 0..reps * 2 {
                        sink += m.sample(wi, &mut rng).weight.y;
                    }
                    let t = t1.elapsed().as_secs_f64() * 1e9 / (reps * 2) as f64;
                    best_sample[mi] = best_sample[mi].min(t);
                }
            }
            for (mi, &(name, model, est)) in models.iter().enumerate() {
                let m = material(model, est, alpha);
                let mut rng = Rng::new(1, 2);
                let (mut var_sum, mut mean_sum, mut rel_sum) = (0.0, 0.0, 0.0);
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
                }
                let k = outs.len() as f64;
                let var = var_sum / k;
                let (ns_eval, ns_sample) = (best_eval[mi], best_sample[mi]);
                let eff = 1.0 / (var * ns_eval * 1e-9);
                println!(
                    "{name:<18} {alpha:>5} {theta_i:>7} {ns_eval:>8.0} {ns_sample:>10.0} {:>11.4} {var:>12.3e} {:>17.4} {eff:>20.3e}",
                    mean_sum / k,
                    rel_sum / k
                );
            }
            std::hint::black_box(sink);
        }
    }
}
