//! Stability where methods fail: sweeps every (model, estimator) the library
//! accepts over grazing incidence (theta_i up to 89.99 degrees), roughness
//! from 1e-3 to the model's largest accepted value, dielectric indices from
//! 1.001 to 3 and both NDFs, and records for each configuration the
//! directional albedo (mean sample weight) and its relative error against
//! HEITZ_RANDOM_WALK's (4x the samples), the relative standard deviation of
//! the sample weight and of eval at the mirror pair, the count of NaN, Inf
//! or negative outputs, and the failure rate (samples flagged ABSORBED:
//! walks cut or absorbed, rejections).
//!
//! `cargo run --release --example stability -- [--samples N] [--out DIR]`
//! writes `docs/stability.csv` (every configuration) and `docs/stability.md`
//! (summary tables).

#[path = "harness/mod.rs"]
mod harness;

use glam::Vec3;
use harness::suite::{self, Combo, GOLD, SuiteMaterial, model_name};
use msbsdf::{Estimator, Material, Model, NdfId, Rng, SAMPLE_ABSORBED};
use std::fmt::Write as _;
use std::time::Instant;

const THETAS: [f32; 6] = [0.0, 60.0, 85.0, 89.0, 89.9, 89.99];
const ALPHAS: [f32; 6] = [1e-3, 1e-2, 0.1, 0.5, 1.0, 2.0];
const ETAS: [f32; 4] = [1.001, 1.01, 1.5, 3.0];

#[derive(Clone, Debug, Default)]
struct Cell {
    model: String,
    facet: String,
    ndf: &'static str,
    alpha: f32,
    theta: f32,
    eta: f32,
    albedo: f64,
    heitz: f64,
    rel_err: f64,
    weight_rel_std: f64,
    eval_rel_std: f64,
    bad: u64,
    absorbed: f64,
    ns_per_sample: f64,
}

fn mat(ndf: NdfId, alpha: f32, eta: Option<f32>) -> SuiteMaterial {
    match eta {
        None => SuiteMaterial {
            name: "gold".into(),
            class: suite::Class::Conductor,
            ndf,
            alpha_x: alpha,
            alpha_y: alpha,
            eta: Vec3::from(GOLD.0),
            k: Vec3::from(GOLD.1),
        },
        Some(e) => SuiteMaterial {
            name: format!("glass {e}"),
            class: suite::Class::Dielectric,
            ndf,
            alpha_x: alpha,
            alpha_y: alpha,
            eta: Vec3::splat(e),
            k: Vec3::ZERO,
        },
    }
}

/// Albedo statistics of `m` at `wi`: (mean weight, rel std, bad, absorbed
/// fraction, ns per sample).
fn albedo(m: &Material, wi: Vec3, n: u64, seed: u64) -> (f64, f64, u64, f64, f64) {
    let mut st = harness::Stats::default();
    let mut rng = Rng::new(seed, 17);
    let mut bad = 0;
    let mut absorbed = 0u64;
    let t = Instant::now();
    for _ in 0..n {
        let s = m.sample(wi, &mut rng);
        let w = [s.weight.x as f64, s.weight.y as f64, s.weight.z as f64];
        if w.iter().any(|x| !x.is_finite() || *x < 0.0) || !s.pdf.is_finite() || s.pdf < 0.0 {
            bad += 1;
        }
        if s.flags & SAMPLE_ABSORBED != 0 {
            absorbed += 1;
        }
        st.push(w);
    }
    let ns = t.elapsed().as_nanos() as f64 / n as f64;
    let mean = st.mean[0];
    let rs = if mean > 0.0 {
        st.var()[0].sqrt() / mean
    } else {
        0.0
    };
    (mean, rs, bad, absorbed as f64 / n as f64, ns)
}

/// Every option `main` reads (`harness::cli::check_options` rejects the
/// others).
const OPTIONS: &[&str] = &["--out", "--samples"];

const USAGE: &str = "stability: sweeps every (model, estimator) over grazing incidence, roughness and index\n(--samples N, default 4000; --out DIR, default docs; the module documentation of\ntools/stability.rs has the details).\nOptions: --out --samples";

fn main() {
    harness::cli::check_options(OPTIONS, USAGE);
    let samples: u64 = harness::arg_value("--samples")
        .and_then(|s| s.parse().ok())
        .unwrap_or(4000);
    let out = harness::arg_value("--out").unwrap_or_else(|| "docs".into());
    let command = harness::command_line("stability");
    let probe_suite = suite::full_suite();
    let combos: Vec<Combo> = suite::discover(&probe_suite);
    let mut configs = Vec::new();
    for ndf in [NdfId::Ggx, NdfId::Beckmann] {
        for eta in [
            None,
            Some(ETAS[0]),
            Some(ETAS[1]),
            Some(ETAS[2]),
            Some(ETAS[3]),
        ] {
            let mut alphas = ALPHAS.to_vec();
            alphas.push(10.0);
            for &a in &alphas {
                for &t in &THETAS {
                    configs.push((ndf, eta, a, t));
                }
            }
        }
    }
    let threads = harness::threads();
    let mut bar = harness::Progress::new("stability", configs.len() as u64, false);
    let t0 = Instant::now();
    let cells: Vec<Vec<Cell>> = harness::reference::parallel(
        configs.len(),
        threads,
        &mut bar,
        |_| 1,
        |i| {
            let (ndf, eta, a, theta) = configs[i];
            let s = mat(ndf, a, eta);
            let th = theta.to_radians();
            let wi = Vec3::new(th.sin(), 0.0, th.cos());
            let wo_mirror = Vec3::new(-wi.x, 0.0, wi.z);
            let heitz = Material::new(&s.desc(Model::HeitzRandomWalk, Estimator::Pt))
                .ok()
                .map(|h| albedo(&h, wi, 4 * samples, 1 + i as u64))
                // The reference is unavailable where its own walks are cut
                // (more than 1% absorbed: bounce limit or invisible facets).
                .and_then(|(a, _, _, absorbed, _)| (absorbed <= 0.01).then_some(a));
            let mut row = Vec::new();
            for c in &combos {
                let Ok(m) = Material::new(&s.desc(c.model, c.estimator)) else {
                    continue;
                };
                let (al, rs, mut bad, absorbed, ns) = albedo(&m, wi, samples, 100 + i as u64);
                // eval at the mirror pair and pdf.
                let mut st = harness::Stats::default();
                let mut rng = Rng::new(7, i as u64);
                let k = if c.stochastic { 256 } else { 1 };
                for _ in 0..k {
                    let v = m.eval(wi, wo_mirror, &mut rng);
                    if !v.is_finite() || v.min_element() < 0.0 {
                        bad += 1;
                    }
                    st.push([v.x as f64, v.y as f64, v.z as f64]);
                }
                let p = m.pdf(wi, wo_mirror);
                if !p.is_finite() || p < 0.0 {
                    bad += 1;
                }
                let ers = if st.mean[0] > 0.0 {
                    st.var()[0].sqrt() / st.mean[0]
                } else {
                    0.0
                };
                let (h, err) = match heitz {
                    Some(h) if h > 0.0 => (h, (al - h) / h),
                    _ => (f64::NAN, f64::NAN),
                };
                row.push(Cell {
                    model: c.label(),
                    facet: if eta.is_some() {
                        "dielectric".into()
                    } else {
                        "gold".into()
                    },
                    ndf: suite::ndf_name(ndf),
                    alpha: a,
                    theta,
                    eta: eta.unwrap_or(0.0),
                    albedo: al,
                    heitz: h,
                    rel_err: err,
                    weight_rel_std: rs,
                    eval_rel_std: ers,
                    bad,
                    absorbed,
                    ns_per_sample: ns,
                });
            }
            row
        },
    );
    bar.finish();
    let cells: Vec<Cell> = cells.into_iter().flatten().collect();
    let mut csv = format!(
        "# stability sweep: {command}\n# {samples} samples per configuration (HEITZ reference albedo: {} samples); eval at the mirror pair 256 times for stochastic models\nmodel,facet,ndf,alpha,theta_i,eta,albedo_r,heitz_albedo_r,rel_error,weight_rel_std,eval_rel_std_mirror,nan_inf_negative,absorbed_fraction,ns_per_sample\n",
        4 * samples
    );
    for c in &cells {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{:.6},{:.6},{:.4e},{:.4e},{:.4e},{},{:.4e},{:.1}",
            c.model,
            c.facet,
            c.ndf,
            c.alpha,
            c.theta,
            c.eta,
            c.albedo,
            c.heitz,
            c.rel_err,
            c.weight_rel_std,
            c.eval_rel_std,
            c.bad,
            c.absorbed,
            c.ns_per_sample
        );
    }
    std::fs::create_dir_all(&out).expect("out dir");
    std::fs::write(format!("{out}/stability.csv"), csv).expect("write csv");
    // Markdown summary.
    let mut md = format!(
        "# Stability where methods fail (generated)\n\n`{command}` ({:.0} s). Every configuration: `stability.csv`.\n\nSweep: gold conductor and dielectrics with eta 1.001, 1.01, 1.5, 3 (light from outside); GGX and Beckmann; alpha 1e-3, 1e-2, 0.1, 0.5, 1, 2, 10 (each model up to the largest it accepts); theta_i 0, 60, 85, 89, 89.9, 89.99 degrees. Albedo = mean sample weight (red channel, {samples} samples); error = relative to HEITZ_RANDOM_WALK's albedo ({} samples; the HEITZ row compares two independent HEITZ runs, so it shows the noise level; no error where more than 1% of HEITZ's own walks are absorbed, i.e. the reference is unavailable: HEITZ with dielectric eta 1.001 or 1.01 at theta_i >= 85 degrees, see its row's absorbed column); weight std = relative standard deviation of one sample weight; eval std = of one eval at the mirror pair; bad = NaN, Inf or negative outputs of sample, eval or pdf; absorbed = fraction of samples flagged ABSORBED (cut or absorbed walks, rejections).\n\n",
        t0.elapsed().as_secs_f64(),
        4 * samples
    );
    md.push_str("## Per model\n\n| model | configurations | bad outputs | worst abs. albedo error (where) | mean / worst absorbed (where) | worst weight std (where) |\n|---|---|---|---|---|---|\n");
    let mut labels: Vec<String> = Vec::new();
    for c in &cells {
        if !labels.contains(&c.model) {
            labels.push(c.model.clone());
        }
    }
    let where_ = |c: &Cell| {
        let f = if c.facet == "dielectric" {
            format!("eta {}", c.eta)
        } else {
            "gold".to_string()
        };
        format!("{} {f} a={} ti={}", c.ndf, c.alpha, c.theta)
    };
    for l in &labels {
        let cs: Vec<&Cell> = cells.iter().filter(|c| &c.model == l).collect();
        let bad: u64 = cs.iter().map(|c| c.bad).sum();
        let we = cs
            .iter()
            .filter(|c| c.rel_err.is_finite())
            .max_by(|a, b| a.rel_err.abs().total_cmp(&b.rel_err.abs()));
        let wa = cs.iter().max_by(|a, b| a.absorbed.total_cmp(&b.absorbed));
        let mean_abs = cs.iter().map(|c| c.absorbed).sum::<f64>() / cs.len().max(1) as f64;
        let ws = cs
            .iter()
            .max_by(|a, b| a.weight_rel_std.total_cmp(&b.weight_rel_std));
        let _ = writeln!(
            md,
            "| {l} | {} | {bad} | {} | {:.2e} / {} | {} |",
            cs.len(),
            we.map(|c| format!("{:+.3} ({})", c.rel_err, where_(c)))
                .unwrap_or("-".into()),
            mean_abs,
            wa.map(|c| format!("{:.3} ({})", c.absorbed, where_(c)))
                .unwrap_or("-".into()),
            ws.map(|c| format!("{:.2} ({})", c.weight_rel_std, where_(c)))
                .unwrap_or("-".into()),
        );
    }
    md.push_str("\n## By regime (GGX; worst over the configurations of the regime)\n\nEach cell: worst |albedo error| / worst absorbed fraction / worst weight std.\n\n| model | normal (ti <= 60, 0.1 <= a <= 1, eta >= 1.5 or gold) | grazing (ti >= 89.9) | smooth (a <= 0.01) | rough (a >= 2) | eta near 1 (<= 1.01) |\n|---|---|---|---|---|---|\n");
    type Pred = Box<dyn Fn(&Cell) -> bool>;
    let regimes: [Pred; 5] = [
        Box::new(|c: &Cell| {
            c.theta <= 60.0 && (0.1..=1.0).contains(&c.alpha) && (c.facet == "gold" || c.eta >= 1.5)
        }),
        Box::new(|c: &Cell| c.theta >= 89.9),
        Box::new(|c: &Cell| c.alpha <= 0.01),
        Box::new(|c: &Cell| c.alpha >= 2.0),
        Box::new(|c: &Cell| c.facet == "dielectric" && c.eta <= 1.01),
    ];
    for l in &labels {
        let _ = write!(md, "| {l} ");
        for r in &regimes {
            let cs: Vec<&Cell> = cells
                .iter()
                .filter(|c| &c.model == l && c.ndf == "ggx" && r(c))
                .collect();
            if cs.is_empty() {
                md.push_str("| not accepted ");
                continue;
            }
            let e = cs
                .iter()
                .filter(|c| c.rel_err.is_finite())
                .map(|c| c.rel_err.abs())
                .fold(0.0, f64::max);
            let a = cs.iter().map(|c| c.absorbed).fold(0.0, f64::max);
            let s = cs.iter().map(|c| c.weight_rel_std).fold(0.0, f64::max);
            let _ = write!(md, "| {e:.3} / {a:.3} / {s:.2} ");
        }
        md.push_str("|\n");
    }
    let _ = writeln!(
        md,
        "\nModels swept: {}.",
        combos
            .iter()
            .map(|c| model_name(c.model).to_string()
                + if c.estimator == Estimator::Bdpt {
                    "/BDPT"
                } else {
                    ""
                })
            .collect::<Vec<_>>()
            .join(", ")
    );
    std::fs::write(format!("{out}/stability.md"), md).expect("write md");
    eprintln!("wrote {out}/stability.csv and {out}/stability.md");
}
