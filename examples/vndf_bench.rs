//! Visible-normal sampling cost per NDF: `cargo run --release --example vndf_bench`.
//!
//! `vndf_bench count vndf|single N` runs exactly N Beckmann `sample_visible`
//! calls (or N SINGLE Beckmann conductor `Material::sample` calls) with views
//! over the whole sphere and prints nothing else, for instruction counts under
//! `valgrind --tool=callgrind` (subtract a run with N = 0 for the set-up).
use glam::Vec3;
use msbsdf::ndf::{Ndf, NdfKind};
use msbsdf::{Material, MaterialDesc, NdfId, Rng};

fn sphere_dirs(rng: &mut Rng) -> Vec<Vec3> {
    (0..1024)
        .map(|_| {
            let z = rng.next_f32() * 2.0 - 1.0;
            let p = rng.next_f32() * std::f32::consts::TAU;
            let r = (1.0 - z * z).sqrt();
            Vec3::new(r * p.cos(), r * p.sin(), z)
        })
        .collect()
}

fn count(what: &str, n: usize) {
    let mut rng = Rng::new(1, 2);
    let dirs = sphere_dirs(&mut rng);
    let mut acc = Vec3::ZERO;
    if what == "single" {
        let desc = MaterialDesc {
            ndf: NdfId::Beckmann,
            alpha_x: 0.5,
            alpha_y: 0.5,
            eta: Vec3::splat(0.2),
            k: Vec3::splat(3.0),
            ..MaterialDesc::default()
        };
        let m = Material::new(&desc).expect("valid material");
        for i in 0..n {
            acc += m.sample(dirs[i & 1023], &mut rng).wo;
        }
    } else {
        let ndf = Ndf::new(NdfKind::Beckmann, 0.5, 0.5);
        for i in 0..n {
            acc += ndf.sample_visible(dirs[i & 1023], rng.next_f32(), rng.next_f32());
        }
    }
    std::hint::black_box(acc);
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() == 4 && args[1] == "count" {
        count(&args[2], args[3].parse().unwrap_or(0));
        return;
    }
    for kind in [NdfKind::Ggx, NdfKind::Beckmann] {
        let ndf = Ndf::new(kind, 0.5, 0.5);
        let mut rng = Rng::new(1, 2);
        let dirs = sphere_dirs(&mut rng);
        let mut best = f64::MAX;
        for _ in 0..5 {
            let t = std::time::Instant::now();
            let mut acc = Vec3::ZERO;
            for i in 0..200_000 {
                acc += ndf.sample_visible(dirs[i & 1023], rng.next_f32(), rng.next_f32());
            }
            std::hint::black_box(acc);
            best = best.min(t.elapsed().as_nanos() as f64 / 200_000.0);
        }
        println!("{kind:?}: {best:.1} ns per visible-normal sample (views over the whole sphere)");
    }
}
