//! Release-mode timing of the V-groove models against SINGLE on the same
//! material: `cargo run --release --example vgroove_timing`.
use glam::Vec3;
use msbsdf::{Material, MaterialDesc, Model, NdfId, Rng};
use std::hint::black_box;
use std::time::Instant;

fn dirs(n: usize, seed: u64) -> Vec<Vec3> {
    let mut r = Rng::new(seed, 3);
    (0..n)
        .map(|_| {
            let z = r.next_f32().max(0.02);
            let phi = 6.2831855 * r.next_f32();
            let s = (1.0 - z * z).sqrt();
            Vec3::new(s * phi.cos(), s * phi.sin(), z)
        })
        .collect()
}

fn main() {
    // Optional filter: a substring of the printed material name.
    let filter = std::env::args().nth(1).unwrap_or_default();
    let n = 200_000;
    let wi = dirs(n, 1);
    let wo = dirs(n, 2);
    println!(
        "{:<34} {:>10} {:>10} {:>10} {:>8} {:>8}",
        "material", "eval ns", "sample ns", "pdf ns", "eval x", "sample x"
    );
    for ndf in [NdfId::Ggx, NdfId::Beckmann, NdfId::Phong] {
        for alpha in [0.2f32, 0.5, 1.0] {
            let mut base = (0.0, 0.0);
            for model in [Model::Single, Model::VGroove, Model::VGrooveNonsymmetric] {
                if model == Model::Single && ndf == NdfId::Phong {
                    continue;
                }
                let desc = MaterialDesc {
                    model,
                    ndf,
                    alpha_x: alpha,
                    alpha_y: alpha,
                    eta: Vec3::new(0.143, 0.374, 1.442),
                    k: Vec3::new(3.983, 2.385, 1.603),
                    ..MaterialDesc::default()
                };
                let name = format!("{model:?} {ndf:?} a={alpha}");
                if model != Model::Single && !name.contains(&filter) {
                    continue;
                }
                let m = Material::new(&desc).unwrap();
                let reps = if model == Model::VGrooveNonsymmetric {
                    n / 40
                } else {
                    n / 4
                };
                let mut rng = Rng::new(5, 5);
                // Minimum over 5 trials: the machine may be shared.
                let (mut te, mut ts, mut tp) = (f64::MAX, f64::MAX, f64::MAX);
                for _ in 0..5 {
                    let t = Instant::now();
                    let mut acc = Vec3::ZERO;
                    for j in 0..reps {
                        acc += m.eval(wi[j], wo[j], &mut rng);
                    }
                    black_box(acc);
                    te = te.min(t.elapsed().as_nanos() as f64 / reps as f64);
                    let t = Instant::now();
                    for w in &wi[..reps] {
                        acc += m.sample(*w, &mut rng).weight;
                    }
                    black_box(acc);
                    ts = ts.min(t.elapsed().as_nanos() as f64 / reps as f64);
                    let t = Instant::now();
                    let mut p = 0.0;
                    for j in 0..reps {
                        p += m.pdf(wi[j], wo[j]);
                    }
                    black_box(p);
                    tp = tp.min(t.elapsed().as_nanos() as f64 / reps as f64);
                }
                if model == Model::Single {
                    base = (te, ts);
                }
                let (xe, xs) = if base.0 > 0.0 {
                    (te / base.0, ts / base.1)
                } else {
                    (f64::NAN, f64::NAN)
                };
                println!(
                    "{:<34} {:>10.1} {:>10.1} {:>10.1} {:>8.2} {:>8.2}",
                    format!("{model:?} {ndf:?} a={alpha}"),
                    te,
                    ts,
                    tp,
                    xe,
                    xs
                );
            }
        }
    }
}
