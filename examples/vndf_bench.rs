//! Visible-normal sampling cost per NDF: `cargo run --release --example vndf_bench`.
use glam::Vec3;
use msbsdf::Rng;
use msbsdf::ndf::{Ndf, NdfKind};
fn main() {
    for kind in [NdfKind::Ggx, NdfKind::Beckmann] {
        let ndf = Ndf::new(kind, 0.5, 0.5);
        let mut rng = Rng::new(1, 2);
        let dirs: Vec<Vec3> = (0..1024)
            .map(|_| {
                let z = rng.next_f32() * 2.0 - 1.0;
                let p = rng.next_f32() * std::f32::consts::TAU;
                let r = (1.0 - z * z).sqrt();
                Vec3::new(r * p.cos(), r * p.sin(), z)
            })
            .collect();
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
