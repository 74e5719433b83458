//! Null-scattering multiple scattering (d'Eon 2023, section 3): the Dirac-NDF
//! cross-section and its quadrature, white furnace for every NDF, eval
//! against sample, vMF against Beckmann with gold facets.

mod common;
use common::*;
use glam::Vec3;
use msbsdf::bsdf::ScatterModel;
use msbsdf::facet::Facet;
use msbsdf::multiple::null_scattering::{
    GL_NODES, GL_NODES_SMOOTH, NullNdf, NullNdfKind, NullScattering, WalkStats, sigma_dirac,
    sigma_quadrature_nodes, sigma_quadrature_with,
};
use msbsdf::ndf::{Ndf, NdfKind};
use msbsdf::{Error, Material, MaterialDesc, Model, NdfId, Rng};

const MIRROR: Facet = Facet::Conductor {
    eta: Vec3::ZERO,
    k: Vec3::ONE,
};
const GOLD: Facet = Facet::Conductor {
    eta: Vec3::new(GOLD_ETA[0], GOLD_ETA[1], GOLD_ETA[2]),
    k: Vec3::new(GOLD_K[0], GOLD_K[1], GOLD_K[2]),
};

#[test]
fn dirac_cross_section_is_symmetric_and_normalised() {
    // d'Eon 2023, eqs. (31) and (32).
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
        // eq. (32) by the midpoint rule on three pieces split at the kinks
        // u = +-sqrt(1 - un^2), in u = a + (b - a)(1 - cos(pi x)) / 2 to
        // resolve the square-root edges.
        let s = (1.0f64 - un * un).sqrt();
        let mut total = 0.0;
        for (a, b) in [(-1.0, -s), (-s, s), (s, 1.0)] {
            let n = 20_000;
            let map = |x: f64| a + (b - a) * 0.5 * (1.0 - (std::f64::consts::PI * x).cos());
            for k in 0..n {
                let (x0, x1) = (k as f64 / n as f64, (k + 1) as f64 / n as f64);
                total += sigma_dirac(map(0.5 * (x0 + x1)), un) * (map(x1) - map(x0));
            }
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
        (NullNdfKind::StudentT, NdfKind::StudentT),
    ] {
        for alpha in [0.1f32, 0.4, 1.0, 4.0] {
            let ndf = NullNdf::new(kind, alpha, alpha, 3.0).unwrap();
            let closed = Ndf::with_shape(nk, alpha, alpha, 3.0);
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

/// The smooth vMF NDF uses 20 nodes per piece: equal to 40 within 1e-5
/// (measured worst 4.9e-6 at alpha 0.2). The exponential NDF does not
/// qualify (1.3e-3 at alpha 4) and keeps 40.
#[test]
fn smooth_ndfs_need_fewer_nodes() {
    for kind in [NullNdfKind::Vmf] {
        for alpha in [0.2f32, 0.4, 1.0, 4.0, 10.0] {
            let ndf = NullNdf::new(kind, alpha, alpha, 2.0).unwrap();
            let mut worst = 0.0f64;
            for i in 0..=80 {
                let u = -0.999 + 1.998 * i as f64 / 80.0;
                let a = sigma_quadrature_nodes(|x| ndf.d_iso(x), u, GL_NODES);
                let b = sigma_quadrature_nodes(|x| ndf.d_iso(x), u, GL_NODES_SMOOTH);
                assert!((b - ndf.sigma_quadrature(u)).abs() <= 1e-15 * b);
                worst = worst.max((a - b).abs() / a.max(1e-3));
            }
            println!(
                "{kind:?} alpha {alpha}: 20 vs 40 nodes, worst relative difference {worst:.1e}"
            );
            assert!(worst < 1e-5, "{kind:?} {alpha}: {worst}");
        }
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

/// Importance sampling of outgoing directions for integrating eval: half
/// cosine lobes (both sides for dielectrics), half the SINGLE GGX model with
/// the same facets (exact pdf). Returns the direction and its density.
struct Proposal {
    single: Material,
    two_sided: bool,
}

impl Proposal {
    fn new(facet: Facet, alpha: f32) -> Self {
        let mut desc = MaterialDesc {
            model: Model::Single,
            ndf: NdfId::Ggx,
            alpha_x: alpha.min(1.0),
            alpha_y: alpha.min(1.0),
            ..MaterialDesc::default()
        };
        let two_sided = matches!(facet, Facet::Dielectric { .. });
        if let Facet::Dielectric { eta } = facet {
            desc.facet = msbsdf::FacetKind::Dielectric;
            desc.eta = Vec3::splat(eta);
        }
        Proposal {
            single: Material::new(&desc).unwrap(),
            two_sided,
        }
    }

    fn pdf(&self, wi: Vec3, wo: Vec3) -> f64 {
        let cos = if self.two_sided {
            0.5 * wo.z.abs() as f64 / std::f64::consts::PI
        } else if wo.z > 0.0 {
            wo.z as f64 / std::f64::consts::PI
        } else {
            0.0
        };
        0.5 * cos + 0.5 * self.single.pdf(wi, wo) as f64
    }

    fn sample(&self, wi: Vec3, rng: &mut Rng) -> Option<(Vec3, f64)> {
        let wo = if rng.next_f32() < 0.5 {
            let mut d = cosine_dir(rng);
            if self.two_sided && rng.next_f32() < 0.5 {
                d.z = -d.z;
            }
            d
        } else {
            let s = self.single.sample(wi, rng);
            if s.flags & msbsdf::SAMPLE_ABSORBED != 0 {
                return None;
            }
            s.wo
        };
        let p = self.pdf(wi, wo);
        (p > 0.0).then_some((wo, p))
    }
}

/// Albedo through eval with the proposal above: mean and standard error.
fn eval_albedo(
    model: &NullScattering,
    facet: Facet,
    alpha: f32,
    wi: Vec3,
    n: usize,
    rng: &mut Rng,
) -> (f64, f64) {
    let prop = Proposal::new(facet, alpha);
    mean_and_error((0..n).map(|_| match prop.sample(wi, rng) {
        Some((wo, p)) => model.eval(wi, wo, rng).x as f64 / p,
        None => 0.0,
    }))
}

fn sample_albedo(model: &NullScattering, wi: Vec3, n: usize, rng: &mut Rng) -> (f64, f64) {
    mean_and_error((0..n).map(|_| {
        let s = model.sample(wi, rng);
        (s.weight.x + s.weight.y + s.weight.z) as f64 / 3.0
    }))
}

/// Sample albedo with F = 1 facets: every path that escapes has weight 1,
/// so the loss is the bounce cap's (and nothing else); asserted below 0.5%.
/// With F = 1 facets every sample weight is 1 by construction, so this
/// checks only the bounce truncation (paths still inside at the limit), not
/// the physics; the eval furnaces are the physics check.
#[test]
fn sample_truncation_loss_f1_every_ndf() {
    let mut rng = Rng::new(17, 3);
    for kind in ALL {
        for alpha in [0.4f32, 1.0, 4.0] {
            let ndf = NullNdf::new(kind, alpha, alpha, 3.0).unwrap();
            let model = NullScattering::new(ndf, MIRROR, 0);
            for theta in [0.0, 60.0, 85.0] {
                let (s, se) = sample_albedo(&model, dir_deg(theta), 10_000, &mut rng);
                println!("{kind:?} alpha {alpha} theta {theta}: sample albedo {s:.5} +- {se:.5}");
                assert!(
                    (1.0 - s).abs() < 0.005,
                    "{kind:?} alpha {alpha} theta {theta}: {s}"
                );
            }
        }
    }
}

/// Albedo through eval (next-event estimation with the quadrature
/// cross-section) is 1 within 4 sigma, with sigma below 0.5% so that a 2%
/// energy loss (a lost or doubled collision term) fails (measured worst
/// sigma 0.42%, Beckmann alpha 0.4).
#[test]
fn white_furnace_every_ndf_eval() {
    let mut rng = Rng::new(19, 4);
    for kind in ALL {
        for alpha in [0.4f32, 1.0, 4.0] {
            let ndf = NullNdf::new(kind, alpha, alpha, 3.0).unwrap();
            let model = NullScattering::new(ndf, MIRROR, 0);
            let wi = dir_deg(50.0);
            let (e, ee) = eval_albedo(&model, MIRROR, alpha, wi, 100_000, &mut rng);
            println!("{kind:?} alpha {alpha}: eval albedo {e:.4} +- {ee:.4}");
            assert!(ee < 0.005, "{kind:?} alpha {alpha}: error {ee}");
            assert!(
                (e - 1.0).abs() < 4.0 * ee,
                "{kind:?} alpha {alpha}: {e} +- {ee}"
            );
        }
    }
}

/// Dielectric (R + T) and diffuse (albedo 1) facets conserve energy through
/// sample (loss below 0.5%), and eval agrees with sample on each side of
/// the surface within 4 combined sigma (eval of transmission from below is
/// noisy with this proposal: sigma up to 2.4%).
#[test]
fn white_furnace_dielectric_and_diffuse() {
    let mut rng = Rng::new(23, 5);
    let glass = Facet::Dielectric { eta: 1.5 };
    let white = Facet::Diffuse { albedo: Vec3::ONE };
    for (kind, alpha) in [
        (NullNdfKind::Ggx, 0.5f32),
        (NullNdfKind::Beckmann, 1.0),
        (NullNdfKind::Vmf, 1.0),
        (NullNdfKind::BesselK0, 0.7),
    ] {
        let ndf = NullNdf::new(kind, alpha, alpha, 3.0).unwrap();
        for facet in [glass, white] {
            let model = NullScattering::new(ndf, facet, 0);
            for theta in [30.0, 170.0] {
                let wi = dir_deg(theta);
                let n = 20_000;
                let (mut sr, mut st) = (Vec::with_capacity(n), Vec::with_capacity(n));
                for _ in 0..n {
                    let s = model.sample(wi, &mut rng);
                    let w = s.weight.x as f64;
                    let refl = s.flags & msbsdf::SAMPLE_REFLECTION != 0;
                    sr.push(if refl { w } else { 0.0 });
                    st.push(if refl { 0.0 } else { w });
                }
                let total: f64 = sr.iter().chain(st.iter()).sum::<f64>() / n as f64;
                assert!(
                    (1.0 - total).abs() < 0.005,
                    "{kind:?} {facet:?} theta {theta}: sample {total}"
                );
                let prop = Proposal::new(facet, alpha);
                let (mut er, mut et) = (Vec::new(), Vec::new());
                for _ in 0..100_000 {
                    let (r, t) = match prop.sample(wi, &mut rng) {
                        Some((wo, p)) => {
                            let v = model.eval(wi, wo, &mut rng).x as f64 / p;
                            if wo.z * wi.z > 0.0 {
                                (v, 0.0)
                            } else {
                                (0.0, v)
                            }
                        }
                        None => (0.0, 0.0),
                    };
                    er.push(r);
                    et.push(t);
                }
                for (name, smp, ev) in [("R", sr, er), ("T", st, et)] {
                    let (a, ae) = mean_and_error(smp.into_iter());
                    let (b, be) = mean_and_error(ev.into_iter());
                    let c = (ae * ae + be * be).sqrt();
                    println!(
                        "{kind:?} {alpha} {facet:?} theta {theta} {name}: sample {a:.4} +- {ae:.4} eval {b:.4} +- {be:.4}"
                    );
                    // Decisive for a 4% (absolute) shift of energy between
                    // R and T at 4 sigma (measured worst 0.0064 with 60k
                    // evaluations, and 0.0094 with another random stream:
                    // the estimate is heavy-tailed from below).
                    assert!(
                        be < 0.01,
                        "{kind:?} {facet:?} theta {theta} {name}: eval error {be}"
                    );
                    assert!(
                        (a - b).abs() < 4.0 * c + 1e-6,
                        "{kind:?} {facet:?} theta {theta} {name}: {a} vs {b}"
                    );
                }
            }
        }
    }
}

/// With one bounce the walk is single scattering: eval equals SINGLE
/// (height-correlated G2; for transmission B(1 + Lambda_i, 1 + Lambda_o))
/// within 4 sigma of the mean of many estimates.
#[test]
fn order_one_equals_single() {
    let mut rng = Rng::new(29, 6);
    let gold = Facet::Conductor {
        eta: Vec3::from(GOLD_ETA),
        k: Vec3::from(GOLD_K),
    };
    let cases = [
        (NullNdfKind::Ggx, NdfId::Ggx, 0.5f32, gold),
        (NullNdfKind::Beckmann, NdfId::Beckmann, 0.8, gold),
        (NullNdfKind::StudentT, NdfId::StudentT, 0.6, gold),
        (
            NullNdfKind::Ggx,
            NdfId::Ggx,
            0.7,
            Facet::Dielectric { eta: 1.5 },
        ),
    ];
    for (kind, id, alpha, facet) in cases {
        let ndf = NullNdf::new(kind, alpha, alpha, 3.0).unwrap();
        let model = NullScattering::new(ndf, facet, 1);
        let mut desc = MaterialDesc {
            model: Model::Single,
            ndf: id,
            shape: 3.0,
            alpha_x: alpha,
            alpha_y: alpha,
            eta: Vec3::from(GOLD_ETA),
            k: Vec3::from(GOLD_K),
            ..MaterialDesc::default()
        };
        if let Facet::Dielectric { eta } = facet {
            desc.facet = msbsdf::FacetKind::Dielectric;
            desc.eta = Vec3::splat(eta);
        }
        let single = Material::new(&desc).unwrap();
        for (ti, to, phi) in [
            (20.0f32, 40.0f32, 2.5f32),
            (60.0, 30.0, 3.1),
            (75.0, 70.0, 1.0),
            (40.0, 150.0, 3.0),
        ] {
            if to > 90.0 && !matches!(facet, Facet::Dielectric { .. }) {
                continue;
            }
            let wi = dir_deg(ti as f64);
            let (st, ct) = to.to_radians().sin_cos();
            let wo = Vec3::new(st * phi.cos(), st * phi.sin(), ct);
            let want = single.eval(wi, wo, &mut rng);
            let est: Vec<Vec3> = (0..40_000).map(|_| model.eval(wi, wo, &mut rng)).collect();
            for c in 0..3 {
                let (m, e) = mean_and_error(est.iter().map(|v| v[c] as f64));
                let w = want[c] as f64;
                assert!(
                    (m - w).abs() < 4.0 * e + 1e-4 * w,
                    "{kind:?} {facet:?} {ti} {to}: channel {c} walk {m} +- {e} single {w}"
                );
            }
        }
    }
}

/// Seed 001, Figure 7: with gold facets, the full-sphere vMF NDF at
/// roughness 4 is darker than Beckmann at 4 (light is trapped in the porous
/// layer and absorbed bounce after bounce).
#[test]
fn gold_vmf_is_darker_than_beckmann_at_roughness_4() {
    let gold = Facet::Conductor {
        eta: Vec3::from(GOLD_ETA),
        k: Vec3::from(GOLD_K),
    };
    let mut rng = Rng::new(31, 7);
    for theta in [0.0, 45.0, 75.0] {
        let wi = dir_deg(theta);
        let mut alb = Vec::new();
        for kind in [NullNdfKind::Vmf, NullNdfKind::Beckmann] {
            let model = NullScattering::new(NullNdf::new(kind, 4.0, 4.0, 2.0).unwrap(), gold, 0);
            alb.push(sample_albedo(&model, wi, 20_000, &mut rng));
        }
        let ((v, ve), (b, be)) = (alb[0], alb[1]);
        println!("theta {theta}: vMF {v:.4} +- {ve:.4}, Beckmann {b:.4} +- {be:.4}");
        assert!(
            b - v > 4.0 * (ve * ve + be * be).sqrt(),
            "theta {theta}: vMF {v} Beckmann {b}"
        );
    }
}

#[test]
fn material_validation() {
    let base = MaterialDesc {
        model: Model::NullScattering,
        ndf: NdfId::Vmf,
        alpha_x: 1.0,
        alpha_y: 1.0,
        ..MaterialDesc::default()
    };
    let m = Material::new(&base).unwrap();
    assert!(m.is_stochastic());
    // Below the supported roughness (rejection rate, d'Eon 2023 section 3.3).
    for a in [0.05f32, 0.199] {
        let d = MaterialDesc {
            alpha_x: a,
            alpha_y: a,
            ..base
        };
        assert_eq!(Material::new(&d), Err(Error::InvalidArgument));
    }
    // Anisotropic vMF, Student-T below 2 (unbounded at the horizon), Phong.
    let d = MaterialDesc {
        alpha_y: 0.5,
        ..base
    };
    assert_eq!(Material::new(&d), Err(Error::Unsupported));
    let d = MaterialDesc {
        ndf: NdfId::StudentT,
        shape: 1.8,
        ..base
    };
    assert_eq!(Material::new(&d), Err(Error::Unsupported));
    let d = MaterialDesc {
        ndf: NdfId::Phong,
        ..base
    };
    assert_eq!(Material::new(&d), Err(Error::Unsupported));
    // Anisotropic GGX is supported (closed-form cross-section).
    let d = MaterialDesc {
        ndf: NdfId::Ggx,
        alpha_y: 0.4,
        ..base
    };
    assert!(Material::new(&d).is_ok());
}

/// Stability: grazing directions, extreme roughness, index near 1, every
/// NDF and facet: finite, non-negative outputs.
#[test]
fn stability_sweep() {
    let mut rng = Rng::new(37, 9);
    let ndfs = [
        NdfId::Beckmann,
        NdfId::Ggx,
        NdfId::StudentT,
        NdfId::Vmf,
        NdfId::Exponential,
        NdfId::BesselK0,
    ];
    let facets = [
        (msbsdf::FacetKind::Conductor, Vec3::from(GOLD_ETA)),
        (msbsdf::FacetKind::Dielectric, Vec3::splat(1.0001)),
        (msbsdf::FacetKind::Dielectric, Vec3::splat(2.5)),
        (msbsdf::FacetKind::Diffuse, Vec3::ZERO),
    ];
    for ndf in ndfs {
        for alpha in [0.2f32, 2.0, 10.0] {
            for (facet, eta) in facets {
                let m = Material::new(&MaterialDesc {
                    model: Model::NullScattering,
                    ndf,
                    facet,
                    eta,
                    k: Vec3::from(GOLD_K),
                    alpha_x: alpha,
                    alpha_y: alpha,
                    shape: 2.5,
                    ..MaterialDesc::default()
                })
                .unwrap();
                for theta in [0.0, 89.99, 90.01, 179.0] {
                    let wi = dir_deg(theta);
                    for _ in 0..50 {
                        let s = m.sample(wi, &mut rng);
                        assert!(
                            s.weight.is_finite() && s.weight.min_element() >= 0.0 && s.pdf >= 0.0
                        );
                        let wo = dir_deg(rng.next_f32() as f64 * 180.0);
                        let f = m.eval(wi, wo, &mut rng);
                        assert!(
                            f.is_finite() && f.min_element() >= 0.0,
                            "{ndf:?} {alpha} {facet:?} {theta}: {f}"
                        );
                        if s.flags & msbsdf::SAMPLE_ABSORBED == 0 {
                            assert!(m.pdf(wi, s.wo) > 0.0);
                        }
                    }
                }
            }
        }
    }
}

/// Seed 001, section 3.1: "This procedure is equivalent to Smith's model in
/// the case that the NDF is restricted to the upper hemisphere." Null
/// scattering with Beckmann and GGX gives the albedo (through sample) and
/// eval values of HEITZ_RANDOM_WALK within 4 combined sigma (both walks
/// with 256 bounces).
#[test]
fn null_scattering_equals_heitz_random_walk() {
    let mut rng = Rng::new(41, 2);
    let cases = [
        (NdfId::Ggx, 0.5f32, msbsdf::FacetKind::Conductor),
        (NdfId::Ggx, 1.0, msbsdf::FacetKind::Conductor),
        (NdfId::Beckmann, 0.7, msbsdf::FacetKind::Conductor),
        (NdfId::Beckmann, 1.5, msbsdf::FacetKind::Conductor),
        (NdfId::Ggx, 0.7, msbsdf::FacetKind::Dielectric),
        (NdfId::Beckmann, 1.0, msbsdf::FacetKind::Diffuse),
        // Student-T (shape 3): the Heitz walk then uses the exact
        // gamma-superposition sampler, up-welling views included.
        (NdfId::StudentT, 0.8, msbsdf::FacetKind::Conductor),
    ];
    for (ndf, alpha, facet) in cases {
        let desc = |model| MaterialDesc {
            model,
            ndf,
            facet,
            alpha_x: alpha,
            alpha_y: alpha,
            eta: if facet == msbsdf::FacetKind::Dielectric {
                Vec3::splat(1.5)
            } else {
                Vec3::from(GOLD_ETA)
            },
            k: Vec3::from(GOLD_K),
            albedo: Vec3::new(0.9, 0.6, 0.3),
            shape: 3.0,
            max_bounces: 256,
            ..MaterialDesc::default()
        };
        let null = Material::new(&desc(Model::NullScattering)).unwrap();
        let heitz = Material::new(&desc(Model::HeitzRandomWalk)).unwrap();
        for theta in [30.0, 75.0] {
            let wi = dir_deg(theta);
            // Albedo per side and channel through sample.
            let n = 20_000;
            let mut acc = [
                [Vec::with_capacity(n), Vec::with_capacity(n)],
                [Vec::new(), Vec::new()],
            ];
            for (k, m) in [&null, &heitz].into_iter().enumerate() {
                for _ in 0..n {
                    let s = m.sample(wi, &mut rng);
                    let refl = s.flags & msbsdf::SAMPLE_REFLECTION != 0;
                    let w = s.weight;
                    acc[k][0].push(if refl { w } else { Vec3::ZERO });
                    acc[k][1].push(if refl { Vec3::ZERO } else { w });
                }
            }
            let [null_sides, heitz_sides] = &acc;
            for (side, (ns, hs)) in null_sides.iter().zip(heitz_sides).enumerate() {
                for c in 0..3 {
                    let (a, ae) = mean_and_error(ns.iter().map(|v| v[c] as f64));
                    let (b, be) = mean_and_error(hs.iter().map(|v| v[c] as f64));
                    let tol = 4.0 * (ae * ae + be * be).sqrt() + 1e-6;
                    assert!(
                        (a - b).abs() < tol,
                        "{ndf:?} {alpha} {facet:?} theta {theta} side {side} channel {c}: null {a} +- {ae}, heitz {b} +- {be}"
                    );
                }
            }
            // Eval at a few outgoing directions.
            for (to, phi) in [(20.0f32, 3.0f32), (60.0, 1.0), (150.0, 2.0)] {
                if to > 90.0 && facet != msbsdf::FacetKind::Dielectric {
                    continue;
                }
                let (st, ct) = to.to_radians().sin_cos();
                let wo = Vec3::new(st * phi.cos(), st * phi.sin(), ct);
                let ne = 20_000;
                let a: Vec<Vec3> = (0..ne).map(|_| null.eval(wi, wo, &mut rng)).collect();
                let b: Vec<Vec3> = (0..ne).map(|_| heitz.eval(wi, wo, &mut rng)).collect();
                for c in 0..3 {
                    let (x, xe) = mean_and_error(a.iter().map(|v| v[c] as f64));
                    let (y, ye) = mean_and_error(b.iter().map(|v| v[c] as f64));
                    let tol = 4.0 * (xe * xe + ye * ye).sqrt() + 1e-6;
                    println!(
                        "{ndf:?} {alpha} {facet:?} {theta}->{to}: null {x:.5} +- {xe:.5} heitz {y:.5} +- {ye:.5}"
                    );
                    assert!(
                        (x - y).abs() < tol,
                        "{ndf:?} {alpha} {facet:?} eval {theta} -> {to} channel {c}: null {x} +- {xe}, heitz {y} +- {ye}"
                    );
                }
            }
        }
    }
}

/// For the NDFs without a height-field reference (vMF, exponential), eval
/// integrated over bins of the outgoing cosine matches the weighted
/// histogram of sample, bin by bin within 4.5 combined sigma (about 7e-6
/// two-sided per bin: the family of 24 comparisons stays below 1e-3).
#[test]
fn eval_matches_sample_by_bins_for_full_sphere_ndfs() {
    let glass = Facet::Dielectric { eta: 1.5 };
    eval_matches_sample_by_bins(
        &[
            (NullNdfKind::Vmf, 1.0f32, GOLD),
            (NullNdfKind::Vmf, 4.0, GOLD),
            (NullNdfKind::Exponential, 0.7, GOLD),
            (NullNdfKind::Vmf, 1.0, glass),
        ],
        Rng::new(43, 8),
    );
}

/// The first vertex of Beckmann, GGX and Student-T is drawn directly (rate
/// `sigma(-w)`, visible normals by the kernel, caller uniforms) rather than
/// by null collisions: sample still matches eval bin by bin as above (18
/// comparisons, about 1.3e-4 family-wise), for conductor and glass
/// reflection.
#[test]
fn eval_matches_sample_by_bins_with_the_direct_first_vertex() {
    let glass = Facet::Dielectric { eta: 1.5 };
    eval_matches_sample_by_bins(
        &[
            (NullNdfKind::Ggx, 0.5f32, GOLD),
            (NullNdfKind::StudentT, 0.6, GOLD),
            (NullNdfKind::Beckmann, 0.7, glass),
        ],
        Rng::new(47, 9),
    );
}

/// Eval integrated over bins of the outgoing cosine against the weighted
/// histogram of sample, for each case (see the callers).
fn eval_matches_sample_by_bins(cases: &[(NullNdfKind, f32, Facet)], mut rng: Rng) {
    const BINS: usize = 6;
    for &(kind, alpha, facet) in cases {
        let model = NullScattering::new(NullNdf::new(kind, alpha, alpha, 3.0).unwrap(), facet, 0);
        let wi = dir_deg(40.0);
        // Dielectrics: reflection bins only. Transmission eval estimates are
        // heavy-tailed (the refraction Jacobian's pole at ci + eta co = 0),
        // so per-bin errors from 3e4 estimates are not trustworthy there (a
        // direct check found 0.0063 +- 0.0003 by uniform integration where
        // this proposal gave 0.0034 +- 0.0004, sample 0.0069); the
        // transmitted total is checked in the furnace test.
        let sides = 1;
        // bin of a direction: side * BINS + floor(|cos| * BINS)
        let bin = |wo: Vec3| {
            let side = usize::from(wo.z < 0.0);
            side * BINS + ((wo.z.abs() * BINS as f32) as usize).min(BINS - 1)
        };
        let n = 30_000;
        let mut smp = vec![Vec::new(); 2 * BINS];
        for _ in 0..n {
            let s = model.sample(wi, &mut rng);
            let w = (s.weight.x + s.weight.y + s.weight.z) as f64 / 3.0;
            let b = if s.flags & msbsdf::SAMPLE_ABSORBED != 0 {
                usize::MAX
            } else {
                bin(s.wo)
            };
            for (k, v) in smp.iter_mut().enumerate() {
                v.push(if k == b { w } else { 0.0 });
            }
        }
        let prop = Proposal::new(facet, alpha);
        let ne = 30_000;
        let mut ev = vec![Vec::new(); 2 * BINS];
        for _ in 0..ne {
            let (b, v) = match prop.sample(wi, &mut rng) {
                Some((wo, p)) => {
                    let f = model.eval(wi, wo, &mut rng);
                    (bin(wo), (f.x + f.y + f.z) as f64 / 3.0 / p)
                }
                None => (usize::MAX, 0.0),
            };
            for (k, e) in ev.iter_mut().enumerate() {
                e.push(if k == b { v } else { 0.0 });
            }
        }
        for k in 0..sides * BINS {
            let (a, ae) = mean_and_error(smp[k].iter().copied());
            let (b, be) = mean_and_error(ev[k].iter().copied());
            let c = (ae * ae + be * be).sqrt();
            println!(
                "{kind:?} {alpha} {facet:?} bin {k}: sample {a:.4} +- {ae:.4} eval {b:.4} +- {be:.4}"
            );
            assert!(
                (a - b).abs() < 4.5 * c + 1e-5,
                "{kind:?} {alpha} {facet:?} bin {k}: sample {a} +- {ae}, eval {b} +- {be}"
            );
        }
    }
}

/// Reciprocity of the one-way walk (`eval_with_stats`, a walk from `wi`
/// only): `f(wi, wo) = f(wo, wi)` in reflection and `f(wi, wo) / eta_o^2 =
/// f(wo, wi) / eta_i^2` in transmission, within 4 combined sigma. `eval`
/// itself averages the walks from both ends with that scale, so its
/// expectation is reciprocal whatever the walk does: it is not tested here.
/// Sigma is bounded so the test is decisive: below 2.5% of the value in
/// reflection (a 10% asymmetry fails), 10% in transmission (the effect to
/// catch there is a lost or doubled eta^2: 125%).
#[test]
fn one_way_walk_is_reciprocal() {
    let mut rng = Rng::new(37, 11);
    let glass = Facet::Dielectric { eta: 1.5 };
    let mut tested = 0;
    let mut worst_rel_sigma: f64 = 0.0;
    for (kind, alpha, facet) in [
        (NullNdfKind::Ggx, 0.8f32, GOLD),
        (NullNdfKind::Vmf, 1.0, GOLD),
        (NullNdfKind::Beckmann, 0.7, glass),
    ] {
        let ndf = NullNdf::new(kind, alpha, alpha, 3.0).unwrap();
        let model = NullScattering::new(ndf, facet, 0);
        let dielectric = matches!(facet, Facet::Dielectric { .. });
        for k in 0..4 {
            let transmit = dielectric && k % 2 == 1;
            // Transmission pairs near the refracted lobe (a random pair
            // far from it carries almost nothing): wi 20-50 degrees, wo
            // 15-30 degrees below on the far side.
            let (wi, wo) = if transmit {
                let ti = (20.0 + 30.0 * rng.next_f32()).to_radians();
                let to = (15.0 + 15.0 * rng.next_f32()).to_radians();
                (
                    Vec3::new(ti.sin(), 0.0, ti.cos()),
                    Vec3::new(-to.sin() * 0.9, to.sin() * 0.1f32.sqrt(), -to.cos()).normalize(),
                )
            } else {
                (cosine_dir(&mut rng), cosine_dir(&mut rng))
            };
            let n = if dielectric { 100_000 } else { 30_000 };
            let mut st = WalkStats::default();
            let mut one_way =
                |a: Vec3, b: Vec3| {
                    mean_and_error((0..n).map(|_| {
                        (model.eval_with_stats(a, b, &mut rng, &mut st).y / b.z.abs()) as f64
                    }))
                };
            let (f_io, se_io) = one_way(wi, wo);
            let (f_oi, se_oi) = one_way(wo, wi);
            // wi is above (index 1); below the surface it is 1.5.
            let ratio = if transmit { 1.5f64 * 1.5 } else { 1.0 };
            let (lhs, rhs) = (f_io, f_oi * ratio);
            let sigma = (se_io * se_io + (se_oi * ratio).powi(2)).sqrt();
            let scale = lhs.abs().max(rhs.abs());
            println!(
                "{kind:?} {alpha} {facet:?} transmit {transmit}: {lhs:.5} vs {rhs:.5} ({:.2} sigma, sigma {:.2}%)",
                (lhs - rhs) / sigma,
                100.0 * sigma / scale
            );
            worst_rel_sigma = worst_rel_sigma.max(sigma / scale);
            let bound = if transmit { 0.10 } else { 0.025 };
            assert!(
                scale > 0.0 && sigma <= bound * scale,
                "{kind:?} {facet:?}: sigma {sigma} for {scale}"
            );
            assert!(
                (lhs - rhs).abs() < 4.0 * sigma,
                "{kind:?} {facet:?} wi {wi} wo {wo}: {lhs} vs {rhs} (sigma {sigma})"
            );
            tested += 1;
        }
    }
    println!(
        "one-way reciprocity: worst sigma {:.2}%",
        100.0 * worst_rel_sigma
    );
    assert_eq!(tested, 12);
}

/// The majorant of Beckmann, GGX and Student-T (their `D` at the peak, by
/// the crate's `ndf::Ndf`) is the closed-form maximum of `D` over the
/// sphere within 2e-5 relative, and no `D` of 2e5 random normals (uniform
/// in the cosine, so grazing ones are frequent) exceeds it. Closed forms
/// along the rougher axis `a`, with `N = 1 / (pi a_x a_y)`: Beckmann
/// `N max(1, 4 a^4 e^(1 / a^2 - 2))` (peak at `tan^2 = 2 a^2 - 1` when
/// positive), GGX and Student-T 2 `N max(1, a^4)` (the top or the
/// horizon), Student-T `g > 2` `N max(1, (1 + x / ((g - 1) a^2))^-g (1 +
/// x)^2)` at `x = (2 (g - 1) a^2 - g) / (g - 2)` when positive.
#[test]
fn majorant_is_the_peak_of_d() {
    let mut rng = Rng::new(59, 6);
    let cases = [
        (NullNdfKind::Beckmann, 0.3f32, 0.3f32, 2.0f32),
        (NullNdfKind::Beckmann, 1.5, 0.8, 2.0),
        (NullNdfKind::Beckmann, 0.4, 4.0, 2.0),
        (NullNdfKind::Ggx, 0.5, 0.5, 2.0),
        (NullNdfKind::Ggx, 2.0, 0.7, 2.0),
        (NullNdfKind::StudentT, 1.5, 1.5, 2.0),
        (NullNdfKind::StudentT, 0.6, 0.6, 3.0),
        (NullNdfKind::StudentT, 2.0, 1.0, 3.0),
        (NullNdfKind::StudentT, 4.0, 4.0, 10.0),
    ];
    for (kind, ax, ay, g) in cases {
        let ndf = NullNdf::new(kind, ax, ay, g).unwrap();
        let (a, n) = (
            ax.max(ay) as f64,
            1.0 / (std::f64::consts::PI * ax as f64 * ay as f64),
        );
        let g = g as f64;
        let peak = match kind {
            NullNdfKind::Beckmann if 2.0 * a * a > 1.0 => {
                4.0 * a.powi(4) * (1.0 / (a * a) - 2.0).exp()
            }
            NullNdfKind::Ggx => a.powi(4),
            NullNdfKind::StudentT if g == 2.0 => a.powi(4),
            NullNdfKind::StudentT => {
                let x = ((2.0 * (g - 1.0) * a * a - g) / (g - 2.0)).max(0.0);
                (1.0 + x / ((g - 1.0) * a * a)).powf(-g) * (1.0 + x).powi(2)
            }
            _ => 1.0,
        };
        let expect = n * peak.max(1.0);
        let rel = ndf.d_max() / expect - 1.0;
        assert!(
            (0.0..=2e-5).contains(&rel),
            "{kind:?} {ax} {ay} {g}: d_max {} vs closed form {expect}",
            ndf.d_max()
        );
        let mut worst: f64 = 0.0;
        for _ in 0..200_000 {
            let z = rng.next_f32();
            let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
            let s = (1.0 - z * z).sqrt();
            let m = Vec3::new(s * phi.cos(), s * phi.sin(), z);
            worst = worst.max(ndf.d(m) / ndf.d_max());
        }
        println!(
            "{kind:?} {ax} {ay} {g}: d_max {:.6}, largest D / d_max {worst:.6}",
            ndf.d_max()
        );
        assert!(worst <= 1.0, "{kind:?} {ax} {ay} {g}: D / d_max = {worst}");
    }
}

/// `sample_with` takes the caller's uniforms at the first vertex for the
/// NDFs with a visible-normal sampler: at alpha 0.2 (the smallest accepted)
/// most GGX and Student-T walks on gold leave after one reflection, so the
/// same uniforms with two generator states give the same direction in more
/// than 80% of 2000 samples, and other uniforms a different one; vMF draws
/// its normals by rejection and follows the generator (fewer than 5%
/// repeat).
#[test]
fn first_vertex_takes_the_caller_uniforms() {
    let wi = dir_deg(30.0);
    for (kind, follows) in [
        (NullNdfKind::Ggx, true),
        (NullNdfKind::StudentT, true),
        (NullNdfKind::Vmf, false),
    ] {
        let model = NullScattering::new(NullNdf::new(kind, 0.2, 0.2, 3.0).unwrap(), GOLD, 0);
        let mut rng = Rng::new(61, 1);
        let (mut same, mut differ) = (0, 0);
        for i in 0..2000u64 {
            let u = [rng.next_f32(), rng.next_f32(), rng.next_f32()];
            let a = model.sample_with(wi, u, &mut Rng::new(1000 + i, 7));
            let b = model.sample_with(wi, u, &mut Rng::new(5000 + i, 9));
            let c = model.sample_with(
                wi,
                [u[0], 1.0 - u[1], u[2] * 0.5],
                &mut Rng::new(1000 + i, 7),
            );
            same += usize::from((a.wo - b.wo).length() < 1e-5);
            differ += usize::from((a.wo - c.wo).length() > 1e-5);
        }
        println!("{kind:?}: {same} of 2000 repeat, {differ} change with the uniforms");
        if follows {
            assert!(same > 1600 && differ > 1600, "{kind:?}: {same} {differ}");
        } else {
            assert!(same < 100, "{kind:?}: {same}");
        }
    }
}
