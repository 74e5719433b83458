//! Composition (`MSBSDF_FACET_MATERIAL`, d'Eon 2023 section 4): a
//! NULL_SCATTERING microsurface whose facets scatter as another msbsdf
//! material. Furnace with energy-conserving inner facets, eval against
//! sample, the smooth-inner limit, and validation.

mod common;
use common::*;
use glam::Vec3;
use msbsdf::{Error, FacetKind, Material, MaterialDesc, Model, NdfId, Rng};

fn leak(m: Material) -> &'static Material {
    Box::leak(Box::new(m))
}

fn inner(model: Model, alpha: f32, gold: bool) -> &'static Material {
    leak(
        Material::new(&MaterialDesc {
            model,
            ndf: NdfId::Ggx,
            alpha_x: alpha,
            alpha_y: alpha,
            eta: if gold {
                Vec3::from(GOLD_ETA)
            } else {
                Vec3::ZERO
            },
            k: if gold { Vec3::from(GOLD_K) } else { Vec3::ONE },
            ..MaterialDesc::default()
        })
        .expect("inner material"),
    )
}

fn composite(ndf: NdfId, alpha: f32, inner: &'static Material) -> Material {
    Material::new(&MaterialDesc {
        model: Model::NullScattering,
        ndf,
        facet: FacetKind::Material,
        alpha_x: alpha,
        alpha_y: alpha,
        inner: Some(inner),
        ..MaterialDesc::default()
    })
    .expect("composite material")
}

/// Mean and standard error of the sampled albedo (green channel).
fn sampled_albedo(m: &Material, wi: Vec3, n: usize, seed: u64) -> (f64, f64) {
    let mut rng = Rng::new(seed, 3);
    mean_and_error((0..n).map(|_| m.sample(wi, &mut rng).weight.y as f64))
}

/// Integral of eval over the upper hemisphere from cosine-sampled directions.
fn eval_integral(m: &Material, wi: Vec3, n: usize, seed: u64) -> (f64, f64) {
    let mut rng = Rng::new(seed, 8);
    mean_and_error((0..n).map(|_| {
        let (u1, u2) = (rng.next_f32(), rng.next_f32());
        let r = u1.sqrt();
        let phi = std::f32::consts::TAU * u2;
        let wo = Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u1).max(1e-6).sqrt());
        let pdf = wo.z / std::f32::consts::PI;
        (m.eval(wi, wo, &mut rng).y / pdf) as f64
    }))
}

#[test]
fn furnace_with_energy_conserving_rough_conductor_facets() {
    // Inner: GGX alpha 0.5 mirror through the Heitz walk (albedo 1), on
    // macro-facets of GGX 1.0 and vMF 1.0: the composite keeps all energy.
    let facets = inner(Model::HeitzRandomWalk, 0.5, false);
    for ndf in [NdfId::Ggx, NdfId::Vmf] {
        let m = composite(ndf, 1.0, facets);
        for theta in [0.0, 45.0, 80.0] {
            let (a, e) = sampled_albedo(&m, dir_deg(theta), 100_000, theta as u64);
            println!("{ndf:?} theta {theta}: albedo {a:.5} +- {e:.5}");
            assert!(
                (a - 1.0).abs() < 0.005,
                "{ndf:?} theta {theta}: albedo {a} +- {e}"
            );
            // Sample weights are exactly 1 here; eval (next-event estimation
            // through the inner material's eval) must integrate to 1 too.
            let (q, qe) = eval_integral(&m, dir_deg(theta), 100_000, 100 + theta as u64);
            println!("{ndf:?} theta {theta}: eval integral {q:.4} +- {qe:.4}");
            // Decisive for a 2% loss: 0.1% + 4 sigma < 1.7%.
            assert!(qe < 0.004, "{ndf:?} theta {theta}: sigma {qe}");
            assert!(
                (q - 1.0).abs() < 4.0 * qe + 1e-3,
                "{ndf:?} theta {theta}: eval integral {q} +- {qe}"
            );
        }
    }
}

#[test]
fn eval_integrates_to_the_sampled_albedo() {
    // Gold facets (GGX 0.3 through the Heitz walk) on GGX 0.8 macro-facets.
    let facets = inner(Model::HeitzRandomWalk, 0.3, true);
    let m = composite(NdfId::Ggx, 0.8, facets);
    for theta in [0.0, 60.0] {
        let wi = dir_deg(theta);
        let (a, ae) = sampled_albedo(&m, wi, 100_000, 7);
        let (q, qe) = eval_integral(&m, wi, 60_000, 8 + theta as u64);
        println!("theta {theta}: sampled {a:.4} +- {ae:.4}, eval integral {q:.4} +- {qe:.4}");
        let tol = 4.0 * (ae * ae + qe * qe).sqrt();
        // Decisive: a 2% disagreement is more than 4 combined sigma.
        assert!(tol < 0.02 * a, "theta {theta}: 4 sigma {tol} for {a}");
        assert!(
            (a - q).abs() < tol,
            "theta {theta}: sampled {a} vs eval {q} (4 sigma {tol})"
        );
        assert!(a < 0.99 && a > 0.5, "gold composite albedo {a}");
    }
}

#[test]
fn smooth_inner_facets_equal_plain_conductor_facets() {
    // Inner SINGLE gold at alpha 1e-3 is a near-mirror: the composite must
    // match NULL_SCATTERING with plain gold facets.
    let facets = inner(Model::Single, 1e-3, true);
    let comp = composite(NdfId::Ggx, 0.7, facets);
    let plain = Material::new(&MaterialDesc {
        model: Model::NullScattering,
        ndf: NdfId::Ggx,
        alpha_x: 0.7,
        alpha_y: 0.7,
        eta: Vec3::from(GOLD_ETA),
        k: Vec3::from(GOLD_K),
        ..MaterialDesc::default()
    })
    .expect("plain");
    for theta in [0.0, 50.0] {
        let wi = dir_deg(theta);
        let (a, ae) = sampled_albedo(&comp, wi, 100_000, 11);
        let (b, be) = sampled_albedo(&plain, wi, 100_000, 12);
        println!("theta {theta}: composite {a:.4} +- {ae:.4}, plain facets {b:.4} +- {be:.4}");
        // 4 sigma plus the near-mirror's own masking loss at grazing local
        // incidence (a few 1e-3).
        assert!(
            (a - b).abs() < 4.0 * (ae * ae + be * be).sqrt() + 5e-3,
            "{a} vs {b}"
        );
    }
}

#[test]
fn composition_is_validated() {
    let base = MaterialDesc {
        model: Model::NullScattering,
        facet: FacetKind::Material,
        alpha_x: 0.5,
        alpha_y: 0.5,
        ..MaterialDesc::default()
    };
    assert_eq!(Material::new(&base), Err(Error::NullPointer));
    let glass = leak(
        Material::new(&MaterialDesc {
            facet: FacetKind::Dielectric,
            eta: Vec3::splat(1.5),
            ..MaterialDesc::default()
        })
        .expect("glass"),
    );
    let with_glass = MaterialDesc {
        inner: Some(glass),
        ..base
    };
    assert_eq!(Material::new(&with_glass), Err(Error::Unsupported));
    let gold = inner(Model::Single, 0.3, true);
    let heitz = MaterialDesc {
        model: Model::HeitzRandomWalk,
        inner: Some(gold),
        ..base
    };
    assert_eq!(Material::new(&heitz), Err(Error::Unsupported));
    let ok = MaterialDesc {
        inner: Some(gold),
        ..base
    };
    assert!(Material::new(&ok).is_ok());
}

#[test]
fn composition_through_the_c_api() {
    use msbsdf::capi::*;
    // SAFETY: every pointer below is a valid local or a handle created here
    // and destroyed after its last use.
    unsafe {
        let mut d = msbsdf_material_desc_default();
        d.model = MSBSDF_MODEL_HEITZ_RANDOM_WALK;
        d.alpha_x = 0.4;
        d.alpha_y = 0.4;
        let mut facets: *mut msbsdf_material = std::ptr::null_mut();
        assert_eq!(msbsdf_material_create(&d, &mut facets), MSBSDF_STATUS_OK);
        let mut c = msbsdf_material_desc_default();
        c.model = MSBSDF_MODEL_NULL_SCATTERING;
        c.facet = MSBSDF_FACET_MATERIAL;
        c.alpha_x = 1.0;
        c.alpha_y = 1.0;
        c.inner = facets;
        let mut outer: *mut msbsdf_material = std::ptr::null_mut();
        assert_eq!(msbsdf_material_create(&c, &mut outer), MSBSDF_STATUS_OK);
        let mut rng = msbsdf_rng::default();
        msbsdf_rng_seed(&mut rng, 1, 2);
        let wi = msbsdf_vec3 {
            x: 0.3,
            y: 0.0,
            z: 0.9,
        };
        let mut sum = 0.0f64;
        for _ in 0..10_000 {
            let mut s = msbsdf_sample_result::default();
            assert_eq!(msbsdf_sample(outer, wi, &mut rng, &mut s), MSBSDF_STATUS_OK);
            sum += s.weight.g as f64;
        }
        // Mirror facets through an energy-conserving walk: every path exits.
        assert!(
            (sum / 10_000.0 - 1.0).abs() < 1e-6,
            "albedo {}",
            sum / 10_000.0
        );
        c.inner = std::ptr::null();
        let mut bad: *mut msbsdf_material = std::ptr::null_mut();
        assert_eq!(
            msbsdf_material_create(&c, &mut bad),
            MSBSDF_STATUS_NULL_POINTER
        );
        assert!(bad.is_null());
        msbsdf_material_destroy(outer);
        msbsdf_material_destroy(facets);
    }
}
