//! The microfacet distributions: normalisation, projected area over the full
//! sphere, and visible-normal sampling against its density (chi-square).

mod common;
use common::*;
use glam::{DVec3, Vec3};
use msbsdf::Rng;
use msbsdf::ndf::{Ndf, NdfKind};

const KINDS: [NdfKind; 2] = [NdfKind::Beckmann, NdfKind::Ggx];
const ROUGHNESS: [(f32, f32); 5] = [(0.05, 0.05), (0.3, 0.3), (1.0, 1.0), (0.1, 0.6), (2.0, 0.7)];

/// integral over normals of g(m) dm, by the GGX warp on an n x 2n midpoint grid.
fn integrate_normals(ax: f32, ay: f32, n: usize, g: impl Fn(Vec3) -> f64) -> f64 {
    let (nu, nv) = (n, 2 * n);
    let mut sum = 0.0;
    for i in 0..nu {
        for j in 0..nv {
            // u = 1 - (1 - s)^4 crowds points towards the heavy tail at u -> 1.
            let s = (i as f64 + 0.5) / nu as f64;
            let u = 1.0 - (1.0 - s).powi(4);
            let du_ds = 4.0 * (1.0 - s).powi(3);
            let v = (j as f64 + 0.5) / nv as f64;
            let (h, p) = ggx_warp(ax as f64, ay as f64, u, v);
            sum += g(h.as_vec3()) / p * du_ds;
        }
    }
    sum / (nu * nv) as f64
}

#[test]
fn d_is_normalised_projected_on_the_macro_normal() {
    for kind in KINDS {
        for (ax, ay) in ROUGHNESS {
            let ndf = Ndf::new(kind, ax, ay);
            let total = integrate_normals(ax, ay, 400, |m| (ndf.d(m) * m.z) as f64);
            assert!((total - 1.0).abs() < 2e-3, "{kind:?} {ax} {ay}: {total}");
        }
    }
}

#[test]
fn sigma_is_the_projected_area_on_the_whole_sphere() {
    for kind in KINDS {
        for (ax, ay) in ROUGHNESS {
            let ndf = Ndf::new(kind, ax, ay);
            for theta in [0.0, 30.0, 60.0, 85.0, 95.0, 120.0, 150.0] {
                for phi in [0.0f32, 0.7] {
                    let t = (theta as f32).to_radians();
                    let v = Vec3::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos());
                    let quad =
                        integrate_normals(ax, ay, 400, |m| (v.dot(m).max(0.0) * ndf.d(m)) as f64);
                    let s = ndf.sigma(v) as f64;
                    let tol = 2e-3 * s.max(1e-3) + 1e-6;
                    assert!(
                        (s - quad).abs() < tol,
                        "{kind:?} {ax},{ay} theta {theta}: sigma {s} quad {quad}"
                    );
                    // Lambda over the full sphere is consistent with sigma.
                    if v.z.abs() > 1e-3 {
                        let l = ndf.lambda(v) as f64;
                        let expect = s / v.z as f64 - 1.0;
                        assert!((l - expect).abs() < 1e-3 * (1.0 + l.abs()), "{l} {expect}");
                    }
                }
            }
        }
    }
}

#[test]
fn visible_normal_sampling_matches_its_density() {
    let views = [0.0, 45.0, 80.0, 89.0, 100.0, 135.0];
    let n_tests = KINDS.len() * ROUGHNESS.len() * views.len();
    let level = sidak(0.01, n_tests);
    let (nu, nv) = (24usize, 48usize);
    let n_samples = 200_000usize;
    let mut rng = Rng::new(7, 11);
    for kind in KINDS {
        for (ax, ay) in ROUGHNESS {
            let ndf = Ndf::new(kind, ax, ay);
            for theta in views {
                let t = (theta as f32).to_radians();
                let v = Vec3::new(t.sin() * 0.8, t.sin() * 0.6, t.cos());
                if ndf.sigma(v) < 1e-4 {
                    // Seen from below at low roughness almost nothing is
                    // visible (Beckmann 0.05 from 100 degrees: sigma ~ e^-13000);
                    // such rays escape with certainty and never sample a normal.
                    continue;
                }
                let mut observed = vec![0.0; nu * nv];
                for _ in 0..n_samples {
                    let m = ndf.sample_visible(v, rng.next_f32(), rng.next_f32());
                    assert!(m.is_finite() && (m.length() - 1.0).abs() < 1e-4);
                    assert!(m.z >= 0.0);
                    assert!(
                        ndf.d_visible(v, m) > 0.0,
                        "{kind:?} {ax},{ay} view {v}: sampled normal {m} has zero density (v.m {}, D {})",
                        v.dot(m),
                        ndf.d(m)
                    );
                    let (u, w) = tail_unwarp(ax as f64, ay as f64, m.as_dvec3());
                    let cell = ((u * nu as f64) as usize).min(nu - 1) * nv
                        + ((w * nv as f64) as usize).min(nv - 1);
                    observed[cell] += 1.0;
                }
                // Expected counts: density over the square, 4x4 midpoints per cell.
                let mut expected = vec![0.0; nu * nv];
                let sub = 12; // the visibility kink v.m = 0 cuts cells: resolve it finely
                let mut total = 0.0;
                for i in 0..nu {
                    for j in 0..nv {
                        let mut s = 0.0;
                        for a in 0..sub {
                            for b in 0..sub {
                                let u = (i as f64 + (a as f64 + 0.5) / sub as f64) / nu as f64;
                                let w = (j as f64 + (b as f64 + 0.5) / sub as f64) / nv as f64;
                                let (h, p) = tail_warp(ax as f64, ay as f64, u, w);
                                s += ndf.d_visible(v, h.as_vec3()) as f64 / p;
                            }
                        }
                        let e = s / (sub * sub * nu * nv) as f64;
                        total += e;
                        expected[i * nv + j] = e * n_samples as f64;
                    }
                }
                assert!(
                    (total - 1.0).abs() < 1e-2,
                    "{kind:?} {ax} theta {theta}: density integrates to {total}"
                );
                let r = chi2_test(&observed, &expected, 5.0);
                assert!(
                    r.p > level,
                    "{kind:?} ({ax},{ay}) theta {theta}: chi2 {:.1} dof {} p {:.2e}",
                    r.chi2,
                    r.dof,
                    r.p
                );
            }
        }
    }
    let _ = DVec3::ZERO;
}
