//! MSBSDF_MODEL_SINGLE: energy (sample weights against a deterministic
//! quadrature of eval), sample against pdf (chi-square), reciprocity, the
//! smooth-dielectric limit, and a stability sweep.
//!
//! Quadratures integrate over microfacet normals through `tail_warp` (the
//! unit square mapped onto normals with the GGX distribution of the same
//! roughness), which keeps the integrand smooth even at alpha 0.05.

mod common;
use common::*;
use glam::Vec3;
use msbsdf::multiple::compensation::single_albedo;
use msbsdf::{FacetKind, Material, MaterialDesc, NdfId, Rng};

const THETAS: [f64; 5] = [0.0, 30.0, 60.0, 80.0, 89.0];
const ROUGH: [(f32, f32); 4] = [(0.05, 0.05), (0.3, 0.3), (1.0, 1.0), (0.1, 0.6)];
const NDFS: [NdfId; 2] = [NdfId::Beckmann, NdfId::Ggx];

fn material(ndf: NdfId, ax: f32, ay: f32, facet: FacetKind, eta: f32) -> Material {
    let desc = MaterialDesc {
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
    };
    Material::new(&desc).expect("valid material")
}

/// Deterministic directional albedo: integral of eval over reflected (and
/// for dielectrics transmitted) directions, as an integral over normals.
fn albedo_quadrature(m: &Material, wi: Vec3, ax: f32, ay: f32, eta: f32, transmit: bool) -> f64 {
    let mut rng = Rng::new(0, 0);
    // One lobe at a time: reflection alone, or transmission alone.
    let lobe = |a: Vec3, b: Vec3| {
        if (b.z < 0.0) == transmit {
            m.eval(a, b, &mut rng).x
        } else {
            0.0
        }
    };
    single_albedo(lobe, ax, ay, wi, transmit.then_some(eta), 500)
}

#[test]
fn conductor_albedo_from_samples_equals_quadrature_and_loses_energy() {
    let n = 1_000_000;
    let mut table =
        String::from("ndf      alpha      theta=0   30        60        80        89\n");
    for ndf in NDFS {
        let mut rows: Vec<[f64; 5]> = Vec::new();
        for (ax, ay) in ROUGH {
            let m = material(ndf, ax, ay, FacetKind::Conductor, 0.0);
            let mut row = [0.0; 5];
            for (t, &theta) in THETAS.iter().enumerate() {
                let wi = dir_deg(theta);
                let mut rng = Rng::new(1000 + t as u64, 17);
                let (mean, err) =
                    mean_and_error((0..n).map(|_| m.sample(wi, &mut rng).weight.x as f64));
                let quad = albedo_quadrature(&m, wi, ax, ay, 1.0, false);
                let diff = (mean - quad).abs();
                assert!(
                    diff <= 3.0 * err + 1e-5 && diff <= 1e-3,
                    "{ndf:?} ({ax},{ay}) theta {theta}: samples {mean:.6} +- {err:.1e}, quadrature {quad:.6}"
                );
                // No energy gain beyond the quadrature's own error (~1e-6).
                assert!(
                    quad < 1.0 + 1e-5,
                    "{ndf:?} ({ax},{ay}) theta {theta}: albedo {quad} > 1"
                );
                row[t] = quad;
            }
            table += &format!(
                "{:<8} {:<10} {}\n",
                format!("{ndf:?}"),
                format!("({ax},{ay})"),
                row.iter()
                    .map(|a| format!("{a:.4}"))
                    .collect::<Vec<_>>()
                    .join("    ")
            );
            rows.push(row);
        }
        println!("{table}");
        // Isotropic rows: energy loss grows with roughness up to 60 degrees.
        // (Not at grazing angles: there Lambda(wi) dominates the
        // height-correlated G2 / G1 = (1 + Li) / (1 + Li + Lo) -> 1 and
        // front-facing facets send light upwards, so rough surfaces keep
        // more energy than smooth ones; see docs/single_albedo.md.)
        for t in 0..3 {
            assert!(
                rows[0][t] > rows[1][t] && rows[1][t] > rows[2][t],
                "{ndf:?} theta {}: albedo does not decrease with alpha: {} {} {}",
                THETAS[t],
                rows[0][t],
                rows[1][t],
                rows[2][t]
            );
        }
        // Alpha 1 loses a visible share of the energy at normal incidence.
        assert!(rows[2][0] < 0.95, "{ndf:?}: alpha 1 albedo {}", rows[2][0]);
        if ndf == NdfId::Ggx {
            // Closed form: at alpha 1, D = 1 / pi and Lambda(wo) = (1 /
            // cos(theta_o) - 1) / 2, so with wi = z the albedo is
            // 2 * int_0^{pi/4} (2 cos^2 t - 1) tan t dt = 1 - ln 2.
            let exact = 1.0 - std::f64::consts::LN_2;
            assert!(
                (rows[2][0] - exact).abs() < 2e-5,
                "GGX alpha 1 normal incidence: {} vs 1 - ln 2 = {exact}",
                rows[2][0]
            );
        }
    }
    println!("{table}");
}

#[test]
fn dielectric_albedo_from_samples_equals_quadrature() {
    let n = 300_000;
    for ndf in NDFS {
        for (ax, ay) in ROUGH {
            for eta in [1.5f32, 1.0 / 1.5] {
                let m = material(ndf, ax, ay, FacetKind::Dielectric, eta);
                for (t, &theta) in THETAS.iter().enumerate() {
                    let wi = dir_deg(theta);
                    let mut rng = Rng::new(2000 + t as u64, 5);
                    let (mut r, mut tr) = (Vec::with_capacity(n), Vec::with_capacity(n));
                    for _ in 0..n {
                        let s = m.sample(wi, &mut rng);
                        let w = s.weight.x as f64;
                        let refl = s.flags == msbsdf::SAMPLE_REFLECTION;
                        r.push(if refl { w } else { 0.0 });
                        tr.push(if refl { 0.0 } else { w });
                    }
                    let (rm, re) = mean_and_error(r.into_iter());
                    let (tm, te) = mean_and_error(tr.into_iter());
                    let rq = albedo_quadrature(&m, wi, ax, ay, eta, false);
                    let tq = albedo_quadrature(&m, wi, ax, ay, eta, true);
                    for (what, mean, err, quad) in [("R", rm, re, rq), ("T", tm, te, tq)] {
                        let diff = (mean - quad).abs();
                        assert!(
                            diff <= 4.0 * err + 1e-5,
                            "{ndf:?} ({ax},{ay}) eta {eta} theta {theta} {what}: samples {mean:.6} +- {err:.1e}, quadrature {quad:.6}"
                        );
                    }
                    assert!(rq + tq < 1.0 + 1e-4, "R + T = {}", rq + tq);
                }
            }
        }
    }
}

#[test]
fn smooth_dielectric_limit_is_fresnel() {
    let n = 400_000;
    for eta in [1.5f32, 1.0 / 1.5] {
        let m = material(NdfId::Ggx, 0.001, 0.001, FacetKind::Dielectric, eta);
        for theta in [0.0, 30.0, 60.0, 75.0] {
            let wi = dir_deg(theta);
            let fresnel = msbsdf::fresnel::dielectric(wi.z, eta) as f64;
            let mut rng = Rng::new(77, 1);
            let (mean, err) = mean_and_error((0..n).map(|_| {
                let s = m.sample(wi, &mut rng);
                if s.flags == msbsdf::SAMPLE_REFLECTION {
                    s.weight.x as f64
                } else {
                    0.0
                }
            }));
            assert!(
                (mean - fresnel).abs() < 4.0 * err + 2e-3,
                "eta {eta} theta {theta}: reflectance {mean} +- {err} vs Fresnel {fresnel}"
            );
        }
    }
}

#[test]
fn sample_matches_pdf_chi2() {
    let facets = [
        (FacetKind::Conductor, 1.0f32),
        (FacetKind::Dielectric, 1.5),
        (FacetKind::Dielectric, 1.0 / 1.5),
    ];
    let n_tests = NDFS.len() * ROUGH.len() * THETAS.len() * facets.len();
    let level = sidak(0.01, n_tests);
    let mut worst: f64 = 1.0;
    for ndf in NDFS {
        for (ax, ay) in ROUGH {
            for (facet, eta) in facets {
                let m = material(ndf, ax, ay, facet, eta);
                for (t, &theta) in THETAS.iter().enumerate() {
                    let eta_t = (facet == FacetKind::Dielectric).then_some(eta);
                    let r = chi2_sample_vs_pdf(
                        &m,
                        dir_deg(theta),
                        ax,
                        ay,
                        eta_t,
                        250_000,
                        3000 + t as u64,
                    );
                    worst = worst.min(r.p);
                    assert!(
                        r.p > level,
                        "{ndf:?} ({ax},{ay}) {facet:?} eta {eta} theta {theta}: chi2 {:.1} dof {} p {:.2e}",
                        r.chi2,
                        r.dof,
                        r.p
                    );
                }
            }
        }
    }
    println!("{n_tests} chi-square tests, smallest p = {worst:.3e}, Sidak level {level:.2e}");
}

#[test]
fn reflection_is_reciprocal_and_transmission_obeys_eta_squared() {
    let mut rng = Rng::new(5, 5);
    let mut dummy = Rng::new(0, 0);
    let mut checked = (0, 0);
    for ndf in NDFS {
        for (ax, ay) in ROUGH {
            for eta in [1.5f32, 1.0 / 1.33] {
                let gold = Material::new(&MaterialDesc {
                    ndf,
                    alpha_x: ax,
                    alpha_y: ay,
                    eta: Vec3::new(0.143, 0.374, 1.442),
                    k: Vec3::new(3.983, 2.385, 1.603),
                    ..MaterialDesc::default()
                })
                .expect("gold");
                let glass = material(ndf, ax, ay, FacetKind::Dielectric, eta);
                for _ in 0..2000 {
                    let a = uniform_sphere(&mut rng);
                    let b = uniform_sphere(&mut rng);
                    if a.z.abs() < 0.02 || b.z.abs() < 0.02 {
                        continue;
                    }
                    let (a, b) = (Vec3::new(a.x, a.y, a.z.abs()), b);
                    for m in [&gold, &glass] {
                        let fab = m.eval(a, b, &mut dummy) / b.z.abs();
                        let fba = m.eval(b, a, &mut dummy) / a.z.abs();
                        // Far in Beckmann's Gaussian tail (f < 1e-10), D = exp(-e)
                        // with e ~ 50 carries a relative f32 error of ~e * 1e-7 that
                        // differs between the two orders: only values that can
                        // matter are compared.
                        if fab.x < 1e-10 && fba.x < 1e-10 {
                            continue;
                        }
                        if b.z > 0.0 {
                            let rel = ((fab - fba).abs() / fab.max(fba)).max_element();
                            assert!(rel <= 1e-5, "{ndf:?} reflection {a} {b}: {fab} vs {fba}");
                            checked.0 += 1;
                        } else {
                            // a above (index 1), b below (index eta):
                            // f(a, b) / eta^2 = f(b, a) / 1.
                            let lhs = fab.x / (eta * eta);
                            let rel = (lhs - fba.x).abs() / lhs.max(fba.x);
                            assert!(
                                rel <= 1e-3,
                                "{ndf:?} eta {eta} transmission {a} {b}: {lhs} vs {}",
                                fba.x
                            );
                            checked.1 += 1;
                        }
                    }
                }
            }
        }
    }
    // Coverage floor: random pairs rarely land in a low-roughness refraction
    // lobe above the 1e-10 floor (about 2000 of them do).
    assert!(checked.0 > 10_000 && checked.1 > 1_500, "{checked:?}");
}

fn uniform_sphere(rng: &mut Rng) -> Vec3 {
    let z = 1.0 - 2.0 * rng.next_f32();
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

fn check_finite(m: &Material, wi: Vec3, wo: Vec3, rng: &mut Rng) {
    let f = m.eval(wi, wo, rng);
    assert!(
        f.is_finite() && f.min_element() >= 0.0,
        "eval {f} at {wi} {wo}"
    );
    let p = m.pdf(wi, wo);
    assert!(p.is_finite() && p >= 0.0, "pdf {p} at {wi} {wo}");
    let s = m.sample(wi, rng);
    assert!(
        s.weight.is_finite()
            && s.weight.min_element() >= 0.0
            && s.pdf.is_finite()
            && s.pdf >= 0.0
            && s.wo.is_finite(),
        "sample {s:?} at {wi}"
    );
}

#[test]
fn stability_sweep_ten_million_inputs() {
    let per_thread = 5_000_000;
    std::thread::scope(|scope| {
        for t in 0..2u64 {
            scope.spawn(move || {
                let mut rng = Rng::new(99, t);
                for i in 0..per_thread {
                    let alpha = 1e-4f32 * (2e4f32).powf(rng.next_f32());
                    let alpha_y = if i % 3 == 0 {
                        alpha
                    } else {
                        1e-4f32 * (2e4f32).powf(rng.next_f32())
                    };
                    let eta = 1.01 + 1.99 * rng.next_f32();
                    let ndf = if i % 2 == 0 {
                        NdfId::Ggx
                    } else {
                        NdfId::Beckmann
                    };
                    let m = if i % 4 < 2 {
                        material(
                            ndf,
                            alpha,
                            alpha_y,
                            FacetKind::Dielectric,
                            if i % 8 < 4 { eta } else { 1.0 / eta },
                        )
                    } else {
                        Material::new(&MaterialDesc {
                            ndf,
                            alpha_x: alpha,
                            alpha_y,
                            eta: Vec3::new(0.143, 0.374, 1.442),
                            k: Vec3::new(3.983, 2.385, 1.603),
                            ..MaterialDesc::default()
                        })
                        .expect("gold")
                    };
                    // Grazing directions are over-represented.
                    let mut wi = uniform_sphere(&mut rng);
                    if i % 5 == 0 {
                        wi.z *= 1e-3;
                    }
                    let mut wo = uniform_sphere(&mut rng);
                    if i % 7 == 0 {
                        wo.z = 0.0;
                    }
                    check_finite(&m, wi, wo, &mut rng);
                }
            });
        }
    });
}

#[test]
fn known_division_by_zero_configurations() {
    let mut rng = Rng::new(1, 1);
    for ndf in NDFS {
        // Normal incidence at alpha 1e-4.
        let m = material(ndf, 1e-4, 1e-4, FacetKind::Dielectric, 1.5);
        check_finite(&m, Vec3::Z, Vec3::Z, &mut rng);
        check_finite(&m, Vec3::Z, -Vec3::Z, &mut rng);
        for _ in 0..1000 {
            check_finite(&m, Vec3::Z, uniform_sphere(&mut rng), &mut rng);
        }
        // eta = 1: index-matched, transmission is a Dirac (weight finite, pdf 0).
        let m = material(ndf, 0.3, 0.3, FacetKind::Dielectric, 1.0);
        let wi = dir_deg(40.0);
        check_finite(&m, wi, -wi, &mut rng);
        for _ in 0..1000 {
            check_finite(&m, wi, uniform_sphere(&mut rng), &mut rng);
        }
        // wi perpendicular to wo with the half vector facing away.
        let m = material(ndf, 0.5, 0.5, FacetKind::Dielectric, 1.5);
        check_finite(
            &m,
            Vec3::new(1.0, 0.0, 0.1),
            Vec3::new(-0.1, 0.0, -1.0),
            &mut rng,
        );
        check_finite(
            &m,
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 0.0),
            &mut rng,
        );
        // wo exactly at the horizon, wi exactly at the horizon.
        let gold = material(ndf, 0.5, 0.5, FacetKind::Conductor, 0.0);
        for m in [&gold, &material(ndf, 0.5, 0.5, FacetKind::Dielectric, 1.5)] {
            check_finite(m, dir_deg(30.0), Vec3::X, &mut rng);
            check_finite(m, Vec3::X, dir_deg(30.0), &mut rng);
            assert_eq!(m.eval(dir_deg(30.0), Vec3::X, &mut rng), Vec3::ZERO);
            assert_eq!(m.pdf(Vec3::X, dir_deg(30.0)), 0.0);
            // wi == -wo.
            check_finite(m, dir_deg(30.0), -dir_deg(30.0), &mut rng);
        }
    }
}

/// SINGLE evaluates isotropic GGX conductors by a closed form of its own
/// (unnormalised half vector, `G2 = 2 zi zo / (zo q(wi) + zi q(wo))`, see
/// `single.rs`). Checked here against the generic NDF code (`ndf::Ndf::d`,
/// `g2_correlated`, `d_visible`, `fresnel::conductor`) that every other
/// roughness and NDF uses: f and pdf within 2e-4 relative, from normal to
/// grazing directions (z down to 1e-4), roughness 1e-3 (the specular
/// threshold) to 2 (looser only where `wi + wo` nearly cancels), the perfect reflector and gold. A lost factor (pi, 2,
/// alpha^2), a swapped `q`, or a `Lambda` with `1 - z^2` in place of
/// `x^2 + y^2` at grazing angles shows at this tolerance.
#[test]
fn isotropic_ggx_closed_form_equals_generic_formulas() {
    use msbsdf::fresnel;
    use msbsdf::ndf::{Ndf, NdfKind};
    let gold = (
        Vec3::new(0.143, 0.374, 1.442),
        Vec3::new(3.983, 2.385, 1.603),
    );
    let mut rng = Rng::new(77, 5);
    let mut worst: f32 = 0.0;
    let mut worst_conditioned: f32 = 0.0;
    let mut compared = 0;
    for alpha in [1e-3f32, 0.05, 0.3, 0.5, 1.0, 2.0] {
        for (eta, k) in [(Vec3::ZERO, Vec3::ONE), gold] {
            let m = Material::new(&MaterialDesc {
                alpha_x: alpha,
                alpha_y: alpha,
                eta,
                k,
                ..MaterialDesc::default()
            })
            .expect("valid material");
            let ndf = Ndf::new(NdfKind::Ggx, alpha, alpha);
            for n in 0..4000 {
                let mut dir = || {
                    // Cosines spread in log scale from 1e-4 to 1.
                    let z = if n % 4 == 0 {
                        10f32.powf(-4.0 * rng.next_f32())
                    } else {
                        rng.next_f32().max(1e-4)
                    };
                    let p = rng.next_f32() * std::f32::consts::TAU;
                    let r = (1.0 - z * z).max(0.0).sqrt();
                    Vec3::new(r * p.cos(), r * p.sin(), z).normalize()
                };
                let (wi, wo) = (dir(), dir());
                let h = (wi + wo).normalize();
                // Near grazing backscatter `wi + wo` cancels: eval
                // normalises its inputs again, and one ulp of a direction
                // then moves the half vector by about 6e-8 / |wi + wo|
                // (both computations share this conditioning, measured
                // 7e-4 at |wi + wo| = 0.022, alpha 1e-3).
                let tol = 2e-4 + 2e-6 / (wi + wo).length_squared();
                let ci = wi.dot(h);
                let d = ndf.d(h);
                let fresnel = if k == Vec3::ONE && eta == Vec3::ZERO {
                    Vec3::ONE
                } else {
                    fresnel::conductor(ci, eta, k)
                };
                let f_ref = fresnel * (d * ndf.g2_correlated(wi, wo) / (4.0 * wi.z));
                let p_ref = ndf.d_visible(wi, h) / (4.0 * ci);
                let f = m.eval(wi, wo, &mut rng);
                let p = m.pdf(wi, wo);
                let rel = |a: f32, b: f32| (a - b).abs() / b.abs().max(1e-30);
                // Values below 1e-30 of the peak are f32 underflow noise.
                if f_ref.max_element() < 1e-30 {
                    continue;
                }
                compared += 1;
                let e = rel(f.x, f_ref.x)
                    .max(rel(f.y, f_ref.y))
                    .max(rel(f.z, f_ref.z))
                    .max(rel(p, p_ref));
                assert!(
                    e < tol,
                    "alpha {alpha} eta {eta} wi {wi} wo {wo}: f {f} vs {f_ref}, pdf {p} vs {p_ref}"
                );
                worst = worst.max(e);
                if (wi + wo).length_squared() > 0.25 {
                    worst_conditioned = worst_conditioned.max(e);
                }
            }
        }
    }
    println!(
        "isotropic GGX closed form: {compared} pairs, worst relative difference {worst:.2e} \
         ({worst_conditioned:.2e} where |wi + wo| > 0.5)"
    );
    assert!(compared > 40_000, "only {compared} pairs compared");
    assert!(
        worst_conditioned < 5e-5,
        "well-conditioned pairs differ by {worst_conditioned:.2e} (f32 rounding is ~1e-5)"
    );
}
