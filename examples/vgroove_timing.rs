//! Release-mode timing of the V-groove models against SINGLE on the same
//! material: `cargo run --release --example vgroove_timing [filter]`.
//!
//! Instruction counts (load-independent): `vgroove_timing ir MODEL NDF ALPHA
//! OP CALLS [MAX_BOUNCES]` (MODEL `single`, `vgroove`, `vgroove_ns`; NDF `ggx`,
//! `beckmann`, `phong`; OP `eval`, `sample`, `pdf`, or `dump` to print
//! eval, pdf and a sample for each of the 1024 pairs) makes CALLS calls on
//! 1024 fixed random pairs; run it under
//! `valgrind --tool=callgrind` with CALLS = 0 and CALLS = n and divide the
//! difference of the totals by n (`scripts/vgroove_ir.sh` does this;
//! `scripts/vgroove_frame.sh` measures whole frames with the Embree tracer).
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

fn desc(model: Model, ndf: NdfId, alpha: f32) -> MaterialDesc {
    MaterialDesc {
        model,
        ndf,
        alpha_x: alpha,
        alpha_y: alpha,
        eta: Vec3::new(0.143, 0.374, 1.442),
        k: Vec3::new(3.983, 2.385, 1.603),
        ..MaterialDesc::default()
    }
}

/// `ir MODEL NDF ALPHA OP CALLS`: CALLS calls of OP for callgrind.
fn ir_mode(args: &[String]) {
    let get = |i: usize| args.get(i).map(String::as_str).unwrap_or("");
    let model = match get(2) {
        "single" => Model::Single,
        "vgroove_ns" => Model::VGrooveNonsymmetric,
        "tabulated" => Model::Tabulated,
        "ec" => Model::EnergyCompensated,
        _ => Model::VGroove,
    };
    let ndf = match get(3) {
        "beckmann" => NdfId::Beckmann,
        "phong" => NdfId::Phong,
        _ => NdfId::Ggx,
    };
    let alpha: f32 = get(4).parse().unwrap_or(0.5);
    let op = get(5);
    let calls: usize = get(6).parse().unwrap_or(0);
    let mut d = desc(model, ndf, alpha);
    // Optional MAX_BOUNCES (e.g. 1: the k = 1 term alone).
    d.max_bounces = get(7).parse().unwrap_or(0);
    let m = Material::new(&d).expect("material");
    let wi = dirs(1024, 1);
    let wo = dirs(1024, 2);
    let mut rng = Rng::new(5, 5);
    let mut acc = Vec3::ZERO;
    if op == "dump" {
        // eval, pdf and one sample per pair, for before/after comparisons.
        for j in 0..1024 {
            let f = m.eval(wi[j], wo[j], &mut rng);
            let p = m.pdf(wi[j], wo[j]);
            let s = m.sample(wi[j], &mut rng);
            println!(
                "{:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e}",
                f.x, f.y, f.z, p, s.wo.x, s.wo.y, s.wo.z, s.weight.x, s.weight.y, s.pdf
            );
        }
        return;
    }
    for j in 0..calls {
        let (a, b) = (wi[j & 1023], wo[j & 1023]);
        match op {
            "sample" => acc += m.sample(a, &mut rng).weight,
            "pdf" => acc.x += m.pdf(a, b),
            "init" => {
                // Material::new with the roughness changing on every call.
                let alpha = 0.2 + (j & 63) as f32 * 0.01;
                let dd = MaterialDesc {
                    alpha_x: alpha,
                    alpha_y: alpha,
                    ..d
                };
                black_box(Material::new(&dd).ok());
            }
            _ => acc += m.eval(a, b, &mut rng),
        }
    }
    black_box(acc);
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some("ir") {
        ir_mode(&args);
        return;
    }
    // Optional filter: a substring of the printed material name.
    let filter = args.get(1).cloned().unwrap_or_default();
    println!(
        "msbsdf_material_size() = {} bytes",
        msbsdf::capi::msbsdf_material_size()
    );
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
                let desc = desc(model, ndf, alpha);
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
