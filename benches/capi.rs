//! Time per call of eval, sample and pdf through the C entry points
//! (the functions a C renderer links), single thread. Prints the median of
//! several runs in ns per call, and for TABULATED the ratios to SINGLE's
//! times on the same material (issue 16's eval <= 1.5x and sample <= 2x;
//! wall clock on a shared machine: the instruction counts of
//! `gen_tabulated -- --dielectric-ir` and `gen_tabulated_aniso -- --ir`
//! are the load-independent figures).
//!
//! `cargo bench --bench capi` (add `-- MODEL` to filter by name).

use msbsdf::capi::*;
use std::hint::black_box;
use std::time::Instant;

struct Case {
    name: String,
    desc: msbsdf_material_desc,
}

/// `d` with anisotropic roughness `(ax, ay)`.
fn aniso(mut d: msbsdf_material_desc, ax: f32, ay: f32) -> msbsdf_material_desc {
    d.alpha_x = ax;
    d.alpha_y = ay;
    d
}

fn gold(model: u32, alpha: f32) -> msbsdf_material_desc {
    let mut d = msbsdf_material_desc_default();
    d.model = model;
    d.alpha_x = alpha;
    d.alpha_y = alpha;
    d.eta = msbsdf_rgb {
        r: 0.143,
        g: 0.374,
        b: 1.442,
    };
    d.k = msbsdf_rgb {
        r: 3.983,
        g: 2.385,
        b: 1.603,
    };
    d
}

fn glass(model: u32, alpha: f32) -> msbsdf_material_desc {
    let mut d = gold(model, alpha);
    d.facet = MSBSDF_FACET_DIELECTRIC;
    d.eta = msbsdf_rgb {
        r: 1.5,
        g: 1.5,
        b: 1.5,
    };
    d
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// Median over `runs` of the ns per call of `f` called `n` times.
fn time(runs: usize, n: usize, mut f: impl FnMut(usize)) -> f64 {
    median(
        (0..runs)
            .map(|_| {
                let t = Instant::now();
                for i in 0..n {
                    f(i);
                }
                t.elapsed().as_nanos() as f64 / n as f64
            })
            .collect(),
    )
}

fn main() {
    let filter = std::env::args().skip(1).find(|a| !a.starts_with('-'));
    // Each material with SINGLE and then TABULATED (whose row gives the
    // ratios to SINGLE's).
    let materials = [
        ("GGX gold alpha 0.5", gold(MSBSDF_MODEL_SINGLE, 0.5)),
        ("GGX glass alpha 0.5", glass(MSBSDF_MODEL_SINGLE, 0.5)),
        (
            "Beckmann gold alpha 0.5",
            msbsdf_material_desc {
                ndf: MSBSDF_NDF_BECKMANN,
                ..gold(MSBSDF_MODEL_SINGLE, 0.5)
            },
        ),
        (
            "GGX gold (0.1, 0.6)",
            aniso(gold(MSBSDF_MODEL_SINGLE, 0.5), 0.1, 0.6),
        ),
        (
            "GGX glass (0.1, 0.6)",
            aniso(glass(MSBSDF_MODEL_SINGLE, 0.5), 0.1, 0.6),
        ),
    ];
    let cases: Vec<Case> = materials
        .iter()
        .flat_map(|&(material, desc)| {
            [
                ("SINGLE", MSBSDF_MODEL_SINGLE),
                ("TABULATED", MSBSDF_MODEL_TABULATED),
            ]
            .map(|(model_name, model)| Case {
                name: format!("{model_name} {material}"),
                desc: msbsdf_material_desc { model, ..desc },
            })
        })
        .collect();
    // Fixed direction pairs spread over the hemisphere.
    let mut rng = msbsdf_rng::default();
    // SAFETY: rng is a valid local.
    unsafe { msbsdf_rng_seed(&mut rng, 1, 2) };
    let dirs: Vec<(msbsdf_vec3, msbsdf_vec3)> = (0..1024)
        .map(|_| {
            // SAFETY: rng is a valid local.
            let mut u = || unsafe { msbsdf_rng_next_float(&mut rng) };
            let (a, b) = (u() * std::f32::consts::TAU, u() * 0.95);
            let (c, d) = (u() * std::f32::consts::TAU, u() * 2.0 - 1.0);
            let wi = msbsdf_vec3 {
                x: b.sqrt() * a.cos(),
                y: b.sqrt() * a.sin(),
                z: (1.0 - b).sqrt(),
            };
            let r = (1.0 - d * d).max(0.0).sqrt();
            (
                wi,
                msbsdf_vec3 {
                    x: r * c.cos(),
                    y: r * c.sin(),
                    z: d,
                },
            )
        })
        .collect();
    println!(
        "{:<34} {:>10} {:>10} {:>10}  ratios to SINGLE",
        "material", "eval ns", "sample ns", "pdf ns"
    );
    // SINGLE's times by the rest of the case name (the material).
    let mut single: Vec<(&str, [f64; 3])> = Vec::new();
    for case in cases
        .iter()
        .filter(|c| filter.as_deref().is_none_or(|f| c.name.contains(f)))
    {
        let mut m: *mut msbsdf_material = std::ptr::null_mut();
        // SAFETY: desc and out are valid locals.
        let status = unsafe { msbsdf_material_create(&case.desc, &mut m) };
        if status != MSBSDF_STATUS_OK {
            println!("{:<34} unsupported (status {status})", case.name);
            continue;
        }
        let (runs, n) = (7, 200_000);
        let mut out = msbsdf_rgb::default();
        let mut s = msbsdf_sample_result::default();
        let mut p = 0.0f32;
        // SAFETY (all three closures): `m` is a live material, the outputs
        // and rng are valid locals.
        let eval = time(runs, n, |i| unsafe {
            let (wi, wo) = dirs[i & 1023];
            black_box(msbsdf_eval(m, wi, wo, &mut rng, &mut out));
        });
        let sample = time(runs, n, |i| unsafe {
            black_box(msbsdf_sample(m, dirs[i & 1023].0, &mut rng, &mut s));
        });
        let pdf = time(runs, n, |i| unsafe {
            let (wi, wo) = dirs[i & 1023];
            black_box(msbsdf_pdf(m, wi, wo, &mut p));
        });
        let material = case.name.split_once(' ').map_or("", |(_, m)| m);
        let ratios = match single.iter().find(|(m, _)| *m == material) {
            Some((_, [e, s, p])) if case.name.starts_with("TABULATED") => {
                format!("  {:.2}x {:.2}x {:.2}x", eval / e, sample / s, pdf / p)
            }
            _ => String::new(),
        };
        if case.name.starts_with("SINGLE") {
            single.push((material, [eval, sample, pdf]));
        }
        println!(
            "{:<34} {eval:>10.1} {sample:>10.1} {pdf:>10.1}{ratios}",
            case.name
        );
        // SAFETY: created above, not used afterwards.
        unsafe { msbsdf_material_destroy(m) };
    }
}
