//! Compares Cui et al. 2023's eq. (14), taken literally, with the exact segment
//! term used by INVARIANCE, in the white furnace.
//!
//! Eq. (14): `S_k(d_0..d_k) = S_1(d_0, d_k) (S_{k-1}(d_0..d_{k-1}) + S_{k-1}(d_1..d_k))`,
//! 0 when the first direction points up or the last points down. It misses
//! the inner-collision terms of the invariance principle and gives 0 for
//! every path that turns from up to down, but conductor paths never do (an
//! upward ray leaves an upward-facing facet upwards), so both give the same
//! albedo (measured: equal to 4 digits). The estimator below is the same
//! PT walk (VNDF sampling, next-event estimation to `wo`, no Russian
//! roulette, 10 bounces) with either segment term; the albedo is the
//! integral of eval over the hemisphere with cosine-weighted directions.
//!
//! `cargo run --release --example invariance_eq14`

use glam::Vec3;
use msbsdf::Rng;
use msbsdf::multiple::invariance::SegmentTerm;
use msbsdf::ndf::{Ndf, NdfKind};
use std::f64::consts::PI;

/// Eq. (14) literally, by memoised recursion over sub-paths (signed Lambdas).
fn s_eq14(l: &[f64]) -> f64 {
    let n = l.len();
    let mut memo = [[f64::NAN; 12]; 12];
    fn rec(l: &[f64], i: usize, j: usize, memo: &mut [[f64; 12]; 12]) -> f64 {
        if !memo[i][j].is_nan() {
            return memo[i][j];
        }
        let v = if l[i] > 0.0 || l[j] < 0.0 {
            0.0
        } else {
            let s1 = 1.0 / (-l[i] + l[j]);
            if j == i + 1 {
                s1
            } else {
                s1 * (rec(l, i, j - 1, memo) + rec(l, i + 1, j, memo))
            }
        };
        memo[i][j] = v;
        v
    }
    rec(l, 0, n - 1, &mut memo)
}

fn main() {
    for kind in [NdfKind::Ggx, NdfKind::Beckmann] {
        for alpha in [0.5f32, 1.0, 2.0] {
            let ndf = Ndf::new(kind, alpha, alpha);
            for theta in [0.0f64, 60.0] {
                let t = theta.to_radians();
                let wi = Vec3::new(t.sin() as f32, 0.0, t.cos() as f32);
                let mut rng = Rng::new(7, 9);
                let n = 200_000;
                let (mut exact, mut lit) = (0.0f64, 0.0f64);
                for _ in 0..n {
                    // Cosine-weighted wo: eval / pdf = eval pi / wo.z.
                    let (u1, u2) = (rng.next_f64(), rng.next_f64());
                    let r = u1.sqrt();
                    let p = 2.0 * PI * u2;
                    let wo = Vec3::new(
                        (r * p.cos()) as f32,
                        (r * p.sin()) as f32,
                        (1.0 - u1).sqrt() as f32,
                    );
                    if wo.z <= 1e-6 {
                        continue;
                    }
                    let lo = ndf.lambda(wo) as f64;
                    let mut d = -wi;
                    let mut lams = [0.0f64; 12];
                    lams[0] = ndf.lambda(d) as f64;
                    let mut seg = SegmentTerm::<16>::start(-lams[0]);
                    let mut w = 1.0f64;
                    for k in 1..=10usize {
                        // NEE: v(d, wo) S(d_0..d_{k-1}, wo), F = 1.
                        let h = (wo - d).normalize();
                        if -d.dot(h) > 0.0 && h.z > 0.0 {
                            let v = ndf.d(h) as f64 / (4.0 * d.z.abs() as f64);
                            lams[k] = lo;
                            let (a, b) = (seg.value(lo), s_eq14(&lams[..=k]));
                            if (w * v * a).is_finite() && (w * v * b).is_finite() {
                                exact += w * v * a * PI / wo.z as f64;
                                lit += w * v * b * PI / wo.z as f64;
                            }
                        }
                        let m = ndf.sample_visible(-d, rng.next_f32(), rng.next_f32());
                        let c = -d.dot(m);
                        if c <= 0.0 {
                            break;
                        }
                        let o = (2.0 * c * m + d).normalize();
                        w *= (ndf.lambda(d) as f64).abs();
                        lams[k] = ndf.lambda(o) as f64;
                        seg.push(lams[k]);
                        d = o;
                    }
                }
                println!(
                    "{kind:?} alpha {alpha} theta_i {theta}: albedo exact S {:.4}, literal eq. (14) {:.4}",
                    exact / n as f64,
                    lit / n as f64
                );
            }
        }
    }
}
