use glam::Vec3;
use msbsdf::Rng;
use msbsdf::bsdf::ScatterModel;
use msbsdf::multiple::vgroove::{VGroove, dist::Family};
use std::f64::consts::PI;

fn albedo(m: &VGroove, ti_deg: f64, n: usize) -> f64 {
    let t = ti_deg.to_radians();
    let wi = Vec3::new(t.sin() as f32, 0.0, t.cos() as f32);
    let mut rng = Rng::new(1, 1);
    let mut sum = 0.0;
    // integrate over h: albedo = ∫ f cos_o 4 (o.h) dh, dh = sin th dth dph
    for a in 0..n {
        let th = (a as f64 + 0.5) / n as f64 * PI / 2.0;
        for b in 0..2 * n {
            let ph = (b as f64 + 0.5) / (2 * n) as f64 * 2.0 * PI;
            let h = glam::DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
            let i = wi.as_dvec3();
            let ih = i.dot(h);
            if ih <= 0.0 {
                continue;
            }
            let o = 2.0 * ih * h - i;
            if o.z <= 0.0 {
                continue;
            }
            let f = m.eval(wi, o.as_vec3(), &mut rng).x as f64;
            sum += f * 4.0 * ih * th.sin() * (PI / 2.0 / n as f64) * (PI / n as f64);
        }
    }
    sum
}

fn main() {
    for sym in [true, false] {
        for fam in [Family::Ggx, Family::Beckmann, Family::Phong] {
            for alpha in [0.2f32, 0.5, 1.0] {
                let m = VGroove::new(fam, alpha, alpha, Vec3::ZERO, Vec3::ONE, 0, sym);
                let t0 = std::time::Instant::now();
                let n = if sym { 200 } else { 60 };
                let a: Vec<f64> = [0.0, 45.0, 80.0]
                    .iter()
                    .map(|&t| albedo(&m, t, n))
                    .collect();
                println!(
                    "sym {sym} {fam:?} a {alpha} N {} albedo {:?} ({:.2?})",
                    m.max_bounces(),
                    a,
                    t0.elapsed()
                );
            }
        }
    }
}
