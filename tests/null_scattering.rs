//! Null-scattering multiple scattering (seed 001, section 3): the Dirac-NDF
//! cross-section and its quadrature, white furnace for every NDF, eval
//! against sample, vMF against Beckmann with gold facets.

mod common;
use common::*;
use glam::Vec3;
use msbsdf::bsdf::ScatterModel;
use msbsdf::facet::Facet;
use msbsdf::multiple::null_scattering::{
    NullNdf, NullNdfKind, NullScattering, sigma_dirac, sigma_quadrature_with,
};
use msbsdf::ndf::{Ndf, NdfKind};
use msbsdf::{Error, Material, MaterialDesc, Model, NdfId, Rng};

const MIRROR: Facet = Facet::Conductor {
    eta: Vec3::ZERO,
    k: Vec3::ONE,
};

#[test]
fn dirac_cross_section_is_symmetric_and_normalised() {
    // seed 001, eqs. (31) and (32).
    for i in 0..=40 {
        let a = -1.0 + 2.0 * i as f64 / 40.0;
        for j in 0..=40 {
            let b = -1.0 + 2.0 * j as f64 / 40.0;
            let (x, y) = (sigma_dirac(a, b), sigma_dirac(b, a));
            assert!((x - y).abs() < 1e-12, "{a} {b}: {x} {y}");
            assert!(x >= 0.0);
        }
    }
    for un in [-0.99, -0.7, -0.3, 0.0, 0.2, 0.5, 0.9, 1.0] {
        // integral over u by piecewise Gauss-Legendre through the same routine:
        // with D(u') = delta ... use the symmetry: int sigma(u, un) du, kinks
        // at +-sqrt(1 - un^2); adaptive Simpson in the test instead.
        let s = (1.0f64 - un * un).sqrt();
        let pieces = [(-1.0, -s), (-s, s), (s, 1.0)];
        let mut total = 0.0;
        for (a, b) in pieces {
            let n = 20_000;
            let h = (b - a) / n as f64;
            let mut acc = 0.0;
            for k in 0..n {
                // midpoint in u = a + (b-a) (1 - cos(pi x)) / 2 to resolve sqrt edges
                let x0 = k as f64 / n as f64;
                let x1 = (k + 1) as f64 / n as f64;
                let map = |x: f64| a + (b - a) * 0.5 * (1.0 - (std::f64::consts::PI * x).cos());
                let (u0, u1) = (map(x0), map(x1));
                let um = map(0.5 * (x0 + x1));
                acc += sigma_dirac(um, un) * (u1 - u0);
                let _ = h;
            }
            total += acc;
        }
        assert!(
            (total - std::f64::consts::PI).abs() < 1e-6,
            "un {un}: {total}"
        );
    }
}

#[test]
fn quadrature_cross_section_equals_closed_forms() {
    for (kind, nk) in [
        (NullNdfKind::Ggx, NdfKind::Ggx),
        (NullNdfKind::Beckmann, NdfKind::Beckmann),
    ] {
        for alpha in [0.1f32, 0.4, 1.0, 4.0] {
            let ndf = NullNdf::new(kind, alpha, alpha, 2.0).unwrap();
            let closed = Ndf::new(nk, alpha, alpha);
            let mut worst = 0.0f64;
            for i in 0..=60 {
                let u = -0.999 + 1.998 * i as f64 / 60.0;
                let s = (1.0 - u * u).sqrt();
                let v = Vec3::new(s as f32, 0.0, u as f32);
                let q = ndf.sigma_quadrature(u);
                let c = closed.sigma(v) as f64; // (1 + Lambda(u)) u on the full sphere
                let err = (q - c).abs() / c.max(1e-3);
                worst = worst.max(err);
            }
            println!("{kind:?} alpha {alpha}: worst relative error {worst:.2e}");
            assert!(worst < 1e-4, "{kind:?} alpha {alpha}: {worst}");
        }
    }
    // K0: quadrature of eq. (36) against eq. (42) (corrected sign).
    for alpha in [0.4f32, 1.0, 4.0] {
        let ndf = NullNdf::new(NullNdfKind::BesselK0, alpha, alpha, 2.0).unwrap();
        let mut worst = 0.0f64;
        for i in 0..=40 {
            let u = -0.99 + 1.98 * i as f64 / 40.0;
            let q = sigma_quadrature_with(|x| ndf.d_iso(x), u);
            let c = msbsdf::multiple::null_scattering::k0_sigma(alpha as f64, u);
            worst = worst.max((q - c).abs() / c.max(1e-3));
        }
        println!("K0 alpha {alpha}: worst relative error {worst:.2e}");
        assert!(worst < 1e-3, "K0 alpha {alpha}: {worst}");
    }
}

const ALL: [NullNdfKind; 6] = [
    NullNdfKind::Beckmann,
    NullNdfKind::Ggx,
    NullNdfKind::StudentT,
    NullNdfKind::Vmf,
    NullNdfKind::Exponential,
    NullNdfKind::BesselK0,
];

/// Cosine-distributed direction on the upper hemisphere.
fn cosine_dir(rng: &mut Rng) -> Vec3 {
    let r = rng.next_f32().sqrt();
    let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
    Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - r * r).max(1e-6).sqrt())
}

/// Albedo by sample (mean weight) and by eval (cosine-weighted directions,
/// f cos / (cos / pi)), each with its standard error.
fn albedos(model: &NullScattering, wi: Vec3, n: usize, rng: &mut Rng) -> ((f64, f64), (f64, f64)) {
    let s = mean_and_error((0..n).map(|_| model.sample(wi, rng).weight.x as f64));
    let e = mean_and_error((0..n).map(|_| {
        let wo = cosine_dir(rng);
        model.eval(wi, wo, rng).x as f64 * std::f64::consts::PI / wo.z as f64
    }));
    (s, e)
}

#[test]
fn white_furnace_every_ndf() {
    let mut rng = Rng::new(17, 3);
    let wi = dir_deg(60.0);
    for kind in ALL {
        for alpha in [0.4f32, 1.0, 4.0] {
            let ndf = NullNdf::new(kind, alpha, alpha, 3.0).unwrap();
            let model = NullScattering::new(ndf, MIRROR, 0);
            let ((s, se), (e, ee)) = albedos(&model, wi, 20_000, &mut rng);
            println!("{kind:?} alpha {alpha}: sample {s:.4} +- {se:.4}  eval {e:.4} +- {ee:.4}");
        }
    }
}
