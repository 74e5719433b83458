//! MSBSDF_MODEL_ENERGY_COMPENSATED: white furnace through sample and eval,
//! dielectric furnace from both sides, sample against pdf, reciprocity of
//! the conductor lobe, and the committed tables against a fresh quadrature.

mod common;
use common::*;
use glam::Vec3;
use msbsdf::multiple::compensation::single_albedo;
use msbsdf::{FacetKind, Material, MaterialDesc, Model, NdfId, Rng};

const NDFS: [NdfId; 2] = [NdfId::Beckmann, NdfId::Ggx];

fn compensated(ndf: NdfId, ax: f32, ay: f32, facet: FacetKind, eta: f32) -> Material {
    Material::new(&MaterialDesc {
        model: Model::EnergyCompensated,
        ndf,
        facet,
        alpha_x: ax,
        alpha_y: ay,
        eta: if facet == FacetKind::Dielectric {
            Vec3::splat(eta)
        } else {
            Vec3::ZERO
        },
        k: Vec3::ONE,
        ..MaterialDesc::default()
    })
    .expect("valid material")
}

/// White furnace (F = 1) within 1% through sample and through a quadrature
/// of eval, theta_i up to 89 degrees (DESIGN's range; the issue asks 80).
/// Measured worst: 0.9959 (GGX alpha 1 at 89 degrees).
#[test]
fn white_furnace_conductor_within_one_percent() {
    let n = 200_000;
    let mut table = String::new();
    for ndf in NDFS {
        for (ax, ay) in [(0.1, 0.1), (0.3, 0.3), (0.6, 0.6), (1.0, 1.0)] {
            let m = compensated(ndf, ax, ay, FacetKind::Conductor, 0.0);
            for theta in [0.0, 30.0, 60.0, 80.0, 85.0, 89.0] {
                let wi = dir_deg(theta);
                let mut rng = Rng::new(11, theta as u64);
                let (mean, err) =
                    mean_and_error((0..n).map(|_| m.sample(wi, &mut rng).weight.x as f64));
                let mut r2 = Rng::new(0, 0);
                let quad = single_albedo(|a, b| m.eval(a, b, &mut r2).x, ax, ay, wi, None, 300);
                table += &format!(
                    "{ndf:?} ({ax},{ay}) {theta}: sample {mean:.4} +- {err:.4}, eval {quad:.4}\n"
                );
                assert!(
                    (mean - 1.0).abs() < 0.01,
                    "{ndf:?} ({ax},{ay}) theta {theta}: sampled albedo {mean}"
                );
                assert!(
                    (quad - 1.0).abs() < 0.01,
                    "{ndf:?} ({ax},{ay}) theta {theta}: eval albedo {quad}"
                );
                // Sample weights and eval describe the same lobe.
                assert!(
                    (mean - quad).abs() < 4.0 * err + 2e-3,
                    "{ndf:?} ({ax},{ay}) theta {theta}: {mean} vs {quad}"
                );
            }
        }
    }
    println!("{table}");
}

/// Anisotropic conductors read the 4D table (alpha_x, alpha_y, azimuth,
/// mu) with E_avg integrated from the same interpolant, so the furnace
/// error is the table's interpolation error alone. Measured (200k samples
/// each, standard error about 1e-4): worst 0.61% (Beckmann (0.1, 0.6), 80
/// degrees along the smooth axis); it was 23% with the isotropic tables read
/// at the RMS alpha. Bound: 1%, the isotropic requirement, over 0-80
/// degrees. At 89 degrees (not asserted) the worst measured is 1.0101
/// (Beckmann (0.05, 1) along the smooth axis), GGX within 0.51%.
#[test]
fn white_furnace_conductor_anisotropic() {
    let n = 200_000;
    let mut worst: f64 = 0.0;
    for ndf in NDFS {
        for (ax, ay) in [(0.1, 0.6), (0.2, 0.8), (0.05, 1.0)] {
            let m = compensated(ndf, ax, ay, FacetKind::Conductor, 0.0);
            for theta in [0.0, 30.0, 60.0, 80.0] {
                for phi in [0.0f32, 1.2] {
                    let t = (theta as f32).to_radians();
                    let wi = Vec3::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos());
                    let mut rng = Rng::new(12, theta as u64);
                    let (mean, _) =
                        mean_and_error((0..n).map(|_| m.sample(wi, &mut rng).weight.x as f64));
                    println!("{ndf:?} ({ax},{ay}) theta {theta} phi {phi}: albedo {mean:.4}");
                    worst = worst.max((mean - 1.0).abs());
                }
            }
        }
    }
    println!("anisotropic furnace: worst |albedo - 1| = {worst:.4}");
    assert!(worst < 0.01, "anisotropic furnace error {worst}");
}

#[test]
fn dielectric_furnace_from_both_sides() {
    let n = 200_000;
    for ndf in NDFS {
        for alpha in [0.1f32, 0.5, 1.0] {
            for eta in [1.5f32, 1.0 / 1.5, 1.33] {
                let m = compensated(ndf, alpha, alpha, FacetKind::Dielectric, eta);
                for theta in [0.0, 45.0, 80.0] {
                    for below in [false, true] {
                        let mut wi = dir_deg(theta);
                        if below {
                            wi.z = -wi.z;
                        }
                        let mut rng = Rng::new(5, theta as u64);
                        let (mean, err) =
                            mean_and_error((0..n).map(|_| m.sample(wi, &mut rng).weight.x as f64));
                        assert!(
                            (mean - 1.0).abs() < 0.01 + 4.0 * err,
                            "{ndf:?} alpha {alpha} eta {eta} theta {theta} below {below}: R + T = {mean} +- {err}"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn sample_matches_pdf_chi2() {
    let cases = [(0.1f32, 0.1f32), (0.5, 0.5), (1.0, 1.0), (0.1, 0.6)];
    let thetas = [0.0, 40.0, 80.0];
    let facets = [
        (FacetKind::Conductor, None),
        (FacetKind::Dielectric, Some(1.5f32)),
    ];
    let level = sidak(0.01, NDFS.len() * cases.len() * thetas.len() * facets.len());
    for ndf in NDFS {
        for (ax, ay) in cases {
            for (facet, eta) in facets {
                let m = compensated(ndf, ax, ay, facet, eta.unwrap_or(0.0));
                for theta in thetas {
                    let r = chi2_sample_vs_pdf(
                        &m,
                        dir_deg(theta),
                        ax,
                        ay,
                        eta,
                        200_000,
                        40 + theta as u64,
                    );
                    assert!(
                        r.p > level,
                        "{ndf:?} ({ax},{ay}) {facet:?} theta {theta}: chi2 {:.1} dof {} p {:.2e}",
                        r.chi2,
                        r.dof,
                        r.p
                    );
                }
            }
        }
    }
}

#[test]
fn conductor_lobe_is_reciprocal() {
    let gold = Material::new(&MaterialDesc {
        model: Model::EnergyCompensated,
        alpha_x: 0.7,
        alpha_y: 0.4,
        eta: Vec3::from(GOLD_ETA),
        k: Vec3::from(GOLD_K),
        ..MaterialDesc::default()
    })
    .expect("gold");
    let mut rng = Rng::new(3, 3);
    for _ in 0..10_000 {
        let a = Vec3::new(
            rng.next_f32() - 0.5,
            rng.next_f32() - 0.5,
            rng.next_f32() + 0.01,
        )
        .normalize();
        let b = Vec3::new(
            rng.next_f32() - 0.5,
            rng.next_f32() - 0.5,
            rng.next_f32() + 0.01,
        )
        .normalize();
        let fab = gold.eval(a, b, &mut rng) / b.z;
        let fba = gold.eval(b, a, &mut rng) / a.z;
        let rel = ((fab - fba).abs() / fab.max(fba).max(Vec3::splat(1e-30))).max_element();
        assert!(rel < 1e-5, "{a} {b}: {fab} vs {fba}");
    }
}

#[test]
fn committed_tables_match_a_fresh_quadrature() {
    use msbsdf::bsdf::ScatterModel;
    use msbsdf::facet::Facet;
    use msbsdf::multiple::compensation::{grid_alpha, grid_eta, grid_mu};
    use msbsdf::multiple::compensation_tables as t;
    use msbsdf::ndf::{Ndf, NdfKind};
    use msbsdf::single::{G2Form, Single};
    // Entries of each table recomputed exactly as the generator does (same
    // quadrature, same grid): a stale table or a changed SINGLE model fails.
    let albedo = |kind, alpha: f32, mu: f32, facet, eta: Option<f32>| {
        let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let s = Single::new(
            Ndf::new(kind, alpha, alpha),
            facet,
            G2Form::HeightCorrelated,
        );
        single_albedo(
            |a, b| s.eval(a, b, &mut Rng::new(0, 0)).x,
            alpha,
            alpha,
            wi,
            eta,
            128,
        ) as f32
    };
    let mirror = Facet::Conductor {
        eta: Vec3::ZERO,
        k: Vec3::ONE,
    };
    for (n, kind) in [NdfKind::Beckmann, NdfKind::Ggx].into_iter().enumerate() {
        for (j, i) in [(5usize, 3usize), (12, 16), (t::ALPHA_N - 1, t::MU_N - 1)] {
            let fresh = albedo(kind, grid_alpha(j), grid_mu(i), mirror, None);
            let table = t::CONDUCTOR_E[n][j][i];
            assert!(
                (fresh - table).abs() < 1e-5,
                "{kind:?} conductor [{j}][{i}]: table {table}, fresh {fresh}"
            );
        }
        for (k, j, i) in [(3usize, 8usize, 10usize), (t::ETA_N - 1, t::ALPHA_N - 1, 2)] {
            for side in 0..2 {
                let eta = if side == 0 {
                    grid_eta(k)
                } else {
                    1.0 / grid_eta(k)
                };
                let fresh = albedo(
                    kind,
                    grid_alpha(j),
                    grid_mu(i),
                    Facet::Dielectric { eta },
                    Some(eta),
                );
                let table = t::DIELECTRIC_E[n][side][k][j][i];
                assert!(
                    (fresh - table).abs() < 1e-5,
                    "{kind:?} dielectric [{side}][{k}][{j}][{i}]: table {table}, fresh {fresh}"
                );
            }
        }
    }
}

/// Entries of the anisotropic albedo table recomputed as the generator does
/// (same quadrature and grid): a stale table or a changed SINGLE fails. The
/// interpolation between nodes is what the anisotropic furnace measures.
#[test]
fn anisotropic_table_matches_a_fresh_quadrature() {
    use msbsdf::bsdf::ScatterModel;
    use msbsdf::facet::Facet;
    use msbsdf::multiple::compensation::{aniso_grid_alpha, aniso_grid_mu, aniso_grid_phi};
    use msbsdf::multiple::compensation_aniso_tables as an;
    use msbsdf::ndf::{Ndf, NdfKind};
    use msbsdf::single::{G2Form, Single};
    let albedo = |kind, ax: f32, ay: f32, wi: Vec3, n: usize| {
        let s = Single::new(
            Ndf::new(kind, ax, ay),
            Facet::Conductor {
                eta: Vec3::ZERO,
                k: Vec3::ONE,
            },
            G2Form::HeightCorrelated,
        );
        single_albedo(
            |a, b| s.eval(a, b, &mut Rng::new(0, 0)).x,
            ax,
            ay,
            wi,
            None,
            n,
        ) as f32
    };
    let dir = |mu: f32, phi: f32| {
        let st = (1.0 - mu * mu).max(0.0).sqrt();
        Vec3::new(st * phi.cos(), st * phi.sin(), mu)
    };
    for (n, kind) in [NdfKind::Beckmann, NdfKind::Ggx].into_iter().enumerate() {
        for (jx, jy, k, i) in [
            (3usize, 9usize, 0usize, 2usize),
            (10, 4, 4, 12),
            (15, 1, 6, 15),
        ] {
            let wi = dir(aniso_grid_mu(i), aniso_grid_phi(k));
            let fresh = albedo(kind, aniso_grid_alpha(jx), aniso_grid_alpha(jy), wi, 96);
            let table = an::CONDUCTOR_E_ANISO[n][jx][jy][k][i];
            assert!(
                (fresh - table).abs() < 1e-5,
                "{kind:?} [{jx}][{jy}][{k}][{i}]: table {table}, fresh {fresh}"
            );
        }
    }
}
