//! Energy lost to the bounce cap for the vMF NDF at high roughness.
use glam::Vec3;
use msbsdf::Rng;
use msbsdf::facet::Facet;
use msbsdf::multiple::null_scattering::{NullNdf, NullNdfKind, NullScattering, WalkStats};
fn main() {
    let mirror = Facet::Conductor {
        eta: Vec3::ZERO,
        k: Vec3::ONE,
    };
    let mut rng = Rng::new(1, 1);
    for alpha in [1.0f32, 2.0, 4.0, 10.0] {
        let ndf = NullNdf::new(NullNdfKind::Vmf, alpha, alpha, 2.0).unwrap();
        for cap in [64u32, 256, 1024, 4096, 16384] {
            let m = NullScattering::new(ndf, mirror, cap);
            let n = 20_000;
            let mut st = WalkStats::default();
            let mut s = 0.0;
            for _ in 0..n {
                s += m
                    .sample_with_stats(Vec3::new(0.5, 0.0, 0.866), &mut rng, &mut st)
                    .weight
                    .x as f64;
            }
            println!(
                "vMF alpha {alpha} cap {cap}: albedo {:.4} mean real {:.1} ns-free",
                s / n as f64,
                st.real as f64 / n as f64
            );
        }
    }
}
