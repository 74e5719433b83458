//! MSBSDF_MODEL_ENERGY_COMPENSATED: white furnace through sample and eval,
//! dielectric furnace from both sides, sample against pdf, reciprocity of
//! the conductor lobe, and the committed tables against independent
//! estimates (SINGLE's sampled albedo) on random cells.

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

/// SINGLE's directional albedo with the given NDF and facet from `wi`
/// (mean sample weight, first channel) and its standard error: an estimate
/// independent of the tables' quadrature (`single_albedo`), through
/// SINGLE's visible-normal sampler.
fn single_albedo_sampled(
    kind: msbsdf::ndf::NdfKind,
    ax: f32,
    ay: f32,
    facet: msbsdf::facet::Facet,
    wi: Vec3,
    n: usize,
    seed: u64,
) -> (f64, f64) {
    use msbsdf::bsdf::ScatterModel;
    use msbsdf::ndf::Ndf;
    use msbsdf::single::{G2Form, Single};
    let s = Single::new(Ndf::new(kind, ax, ay), facet, G2Form::HeightCorrelated);
    let mut rng = Rng::new(seed, 17);
    mean_and_error((0..n).map(|_| s.sample(wi, &mut rng).weight.x as f64))
}

/// Samples per checked cell: the sample weights lie in [0, 1], so the
/// standard error is at most 0.5 / sqrt(N) = 7.9e-4.
const CELL_SAMPLES: usize = 400_000;

/// Checks one table entry against the sampled albedo: within 4 standard
/// errors plus `floor` (the table's own quadrature error), and the
/// standard error small enough that a 2% error of the entry would fail
/// (4 sigma + floor < 2% of the entry). Returns the difference in units of
/// the tolerance.
fn check_cell(what: &str, table: f32, (mean, se): (f64, f64), floor: f64) -> f64 {
    let table = table as f64;
    let tol = 4.0 * se + floor;
    assert!(
        tol < 0.02 * table,
        "{what}: tolerance {tol:.2e} cannot detect a 2% error of {table}"
    );
    println!("{what}: table {table:.6}, sampled {mean:.6} +- {se:.6}");
    assert!(
        (table - mean).abs() < tol,
        "{what}: table {table:.6}, sampled {mean:.6} +- {se:.6}"
    );
    (table - mean).abs() / tol
}

/// Quadrature error allowed for the isotropic tables (128^2 normals per
/// entry, rounded to 6 decimals).
const ISO_FLOOR: f64 = 2e-4;
/// The same for the anisotropic table (96^2 normals per entry; measured
/// up to 5.1e-4 at Beckmann (2, 0.57)).
const ANISO_FLOOR: f64 = 1e-3;

/// Cells of the isotropic albedo tables (conductor with F = 1, dielectric
/// from both sides) drawn at random (fixed seed), each against SINGLE's
/// albedo estimated by its sampler with another random stream: a stale
/// table, a changed SINGLE or a perturbed entry fails (a 2% perturbation
/// of one entry was checked to fail). Roughness 0 (where the entries are
/// 1 by definition) is not drawn.
#[test]
fn albedo_tables_match_sampled_single_on_random_cells() {
    use msbsdf::facet::Facet;
    use msbsdf::multiple::compensation::{grid_alpha, grid_eta, grid_mu};
    use msbsdf::multiple::compensation_tables as t;
    use msbsdf::ndf::NdfKind;
    let kinds = [NdfKind::Beckmann, NdfKind::Ggx];
    let dir = |mu: f32| Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let mut pick = Rng::new(2026, 11);
    let mut draw = |n: usize| ((pick.next_f32() * n as f32) as usize).min(n - 1);
    let (mut checked, mut worst_z) = (0, 0.0f64);
    for cell in 0..16u64 {
        let n = draw(2);
        let j = 1 + draw(t::ALPHA_N - 1);
        let i = draw(t::MU_N);
        let mirror = Facet::Conductor {
            eta: Vec3::ZERO,
            k: Vec3::ONE,
        };
        let (a, wi) = (grid_alpha(j), dir(grid_mu(i)));
        let est = single_albedo_sampled(kinds[n], a, a, mirror, wi, CELL_SAMPLES, 100 + cell);
        let what = format!("CONDUCTOR_E[{n}][{j}][{i}]");
        worst_z = worst_z.max(check_cell(&what, t::CONDUCTOR_E[n][j][i], est, ISO_FLOOR));
        checked += 1;
    }
    for cell in 0..16u64 {
        let (n, side) = (draw(2), draw(2));
        let k = 1 + draw(t::ETA_N - 1);
        let j = 1 + draw(t::ALPHA_N - 1);
        let i = draw(t::MU_N);
        let eta = if side == 0 {
            grid_eta(k)
        } else {
            1.0 / grid_eta(k)
        };
        let (a, wi) = (grid_alpha(j), dir(grid_mu(i)));
        let facet = Facet::Dielectric { eta };
        let est = single_albedo_sampled(kinds[n], a, a, facet, wi, CELL_SAMPLES, 200 + cell);
        let what = format!("DIELECTRIC_E[{n}][{side}][{k}][{j}][{i}]");
        worst_z = worst_z.max(check_cell(
            &what,
            t::DIELECTRIC_E[n][side][k][j][i].get(),
            est,
            ISO_FLOOR,
        ));
        checked += 1;
    }
    println!("{checked} cells, worst |table - sampled| = {worst_z:.2} of the tolerance");
    assert_eq!(checked, 32);
}

/// `CONDUCTOR_E_AVG = 2 int E(mu) mu dmu` against the same integral of the
/// (sampled-checked) `CONDUCTOR_E` rows, by the trapezoid rule on the mu
/// grid with E constant below its first node: the two quadratures differ by
/// the table's interpolation error in mu, measured below 1.5e-3 (alpha 2);
/// bound 3e-3, below 2% of every entry (E_avg >= 0.37), so a 2% error of
/// an entry fails.
#[test]
fn conductor_e_avg_is_the_average_of_conductor_e() {
    use msbsdf::multiple::compensation::grid_mu;
    use msbsdf::multiple::compensation_tables as t;
    let mut worst = 0.0f32;
    for n in 0..2 {
        for j in 0..t::ALPHA_N {
            let e = &t::CONDUCTOR_E[n][j];
            let m0 = grid_mu(0);
            let mut avg = e[0] * m0 * m0;
            for i in 0..t::MU_N - 1 {
                let (x0, x1) = (grid_mu(i), grid_mu(i + 1));
                avg += (x1 - x0) * (e[i] * x0 + e[i + 1] * x1);
            }
            let table = t::CONDUCTOR_E_AVG[n][j];
            assert!(0.02 * table > 3e-3, "[{n}][{j}]: bound cannot detect 2%");
            let d = (avg - table).abs();
            assert!(
                d < 3e-3,
                "CONDUCTOR_E_AVG[{n}][{j}] = {table}, quadrature {avg}"
            );
            worst = worst.max(d);
        }
    }
    println!("worst |E_avg - quadrature of E| = {worst:.2e}");
}

/// Cells of the anisotropic albedo table drawn at random (fixed seed)
/// against SINGLE's sampled albedo, as for the isotropic tables. Axes with
/// roughness 0 (stored at 1e-4, the quadrature's smallest) are not drawn.
#[test]
fn anisotropic_table_matches_sampled_single_on_random_cells() {
    use msbsdf::facet::Facet;
    use msbsdf::multiple::compensation::{aniso_grid_alpha, aniso_grid_mu, aniso_grid_phi};
    use msbsdf::multiple::compensation_aniso_tables as an;
    use msbsdf::ndf::NdfKind;
    let kinds = [NdfKind::Beckmann, NdfKind::Ggx];
    let mut pick = Rng::new(2026, 12);
    let mut draw = |n: usize| ((pick.next_f32() * n as f32) as usize).min(n - 1);
    let mirror = Facet::Conductor {
        eta: Vec3::ZERO,
        k: Vec3::ONE,
    };
    let (mut checked, mut worst_z) = (0, 0.0f64);
    for cell in 0..16u64 {
        let n = draw(2);
        let (jx, jy) = (1 + draw(an::AN_A - 1), 1 + draw(an::AN_A - 1));
        let (k, i) = (draw(an::AN_PHI), draw(an::AN_MU));
        let (mu, phi) = (aniso_grid_mu(i), aniso_grid_phi(k));
        let st = (1.0 - mu * mu).max(0.0).sqrt();
        let wi = Vec3::new(st * phi.cos(), st * phi.sin(), mu);
        let (ax, ay) = (aniso_grid_alpha(jx), aniso_grid_alpha(jy));
        let est = single_albedo_sampled(kinds[n], ax, ay, mirror, wi, CELL_SAMPLES, 300 + cell);
        let what = format!("CONDUCTOR_E_ANISO[{n}][{jx}][{jy}][{k}][{i}]");
        worst_z = worst_z.max(check_cell(
            &what,
            an::CONDUCTOR_E_ANISO[n][jx][jy][k][i].get(),
            est,
            ANISO_FLOOR,
        ));
        checked += 1;
    }
    println!("{checked} cells, worst |table - sampled| = {worst_z:.2} of the tolerance");
    assert_eq!(checked, 16);
}
