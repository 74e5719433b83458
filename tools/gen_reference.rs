//! Generates the converged HEITZ_RANDOM_WALK reference of the speed-vs-accuracy
//! harness: `data/reference_values.csv` (64 direction pairs per suite
//! material, see `tools/harness/suite.rs`) and `data/reference_albedo.csv`
//! (directional albedo tables), with the command, seeds, sample counts and
//! the accuracy reached in the header comments. Progress and ETA on stderr.
//!
//! `cargo run --release --example gen_reference -- [--budget SECONDS]
//! [--target REL_SE] [--pairs N] [--quick] [--out DIR] [--resume] [--plain]`
//!
//! `--budget` is the wall-clock time allowed for the main pass (default
//! 600 s); the target relative standard error per value (default 1e-3) is
//! relaxed to what the budget allows, and the header says what was reached.
//!
//! Estimator (see `tools/harness/walk.rs` and `reference.rs`): the analytic
//! SINGLE term plus the orders >= 2 of a forward and a reverse walk combined
//! by multiple importance sampling, with a forced collision after the first
//! vertex for conductors. It estimates the library's HEITZ_RANDOM_WALK
//! (same walk, NDF, heights, Fresnel, bounce limit) with 6.8x (suite total)
//! to 2100x (GGX gold 0.05) less work for 1e-3 than the first generator's
//! estimator, which `--plain` still runs.
//!
//! Other modes:
//! - `--resume`: read `DIR/reference_values.csv` (made by the same
//!   estimator: its header's `estimator-id`), pool its samples with a new
//!   pilot and second pass seeded above every seed its header names, and
//!   rewrite it (earlier header lines kept as `earlier run:`); the albedo
//!   table is left alone; materials appended to the suite since start from
//!   no samples. A bigger machine pushes the reference to the
//!   target with `--resume --budget SECONDS`.
//! - `--check [--samples N] [--items material:pair,...]`: the estimator against the library's HEITZ eval
//!   and its walks from `wi` and from `wo` on hard and easy pairs (z per
//!   channel, Sidak-corrected; exit status 1 on failure).
//! - `--estimate [--pilot N] [--top K] [--only SUBSTRING]`: pilot pass only;
//!   prints the samples and CPU time each material needs for `--target` and
//!   the wall time on the current number of threads.
//! - `--analyse material:pair,... [--samples N] [--one-way]`: variance per
//!   scattering order, tail weight and time of each walk variant.
//! - `--check-only`: only the order-1 check (`E[walk_1] = SINGLE`).
//! - `--albedo-only [--albedo-samples N]`: only `reference_albedo.csv`
//!   (default 1e6 HEITZ samples per row).

#[path = "harness/mod.rs"]
mod harness;

use harness::reference::{self, EstimatorKind, GenOptions};
use harness::suite;

/// Every option `main` reads (`harness::cli::check_options` rejects the
/// others).
const OPTIONS: &[&str] = &[
    "--albedo-only",
    "--albedo-samples",
    "--analyse",
    "--budget",
    "--check",
    "--check-only",
    "--estimate",
    "--forced-conductor",
    "--forced-dielectric",
    "--items",
    "--max-samples",
    "--no-albedo",
    "--one-way",
    "--only",
    "--out",
    "--pairs",
    "--pilot",
    "--plain",
    "--quick",
    "--resume",
    "--samples",
    "--seed",
    "--target",
    "--top",
];

const USAGE: &str = "gen_reference: the converged HEITZ_RANDOM_WALK reference of the speed-vs-accuracy harness\n(data/reference_values.csv, data/reference_albedo.csv; the module documentation of\ntools/gen_reference.rs has the details).\nOptions: --albedo-only --albedo-samples --analyse --budget --check --check-only --estimate --forced-conductor --forced-dielectric --items --max-samples --no-albedo --one-way --only --out --pairs --pilot --plain --quick --resume --samples --seed --target --top";

fn main() {
    harness::cli::check_options(OPTIONS, USAGE);
    let quick = harness::arg_flag("--quick");
    let parse = |name: &str, default: f64| {
        harness::arg_value(name)
            .and_then(|s| s.parse::<f64>().ok())
            .unwrap_or(default)
    };
    let out = harness::arg_value("--out").unwrap_or_else(|| "data".to_string());
    let suite = if quick {
        suite::quick_suite()
    } else {
        suite::full_suite()
    };
    if let Some(list) = harness::arg_value("--analyse") {
        analyse(&list, parse("--samples", 1e6) as u64);
        return;
    }
    let estimator = if harness::arg_flag("--plain") {
        EstimatorKind::Plain
    } else {
        let EstimatorKind::Reduced {
            forced_conductor,
            forced_dielectric,
        } = EstimatorKind::DEFAULT
        else {
            unreachable!()
        };
        EstimatorKind::Reduced {
            forced_conductor: parse("--forced-conductor", forced_conductor as f64) as u32,
            forced_dielectric: parse("--forced-dielectric", forced_dielectric as f64) as u32,
        }
    };
    let mut o = GenOptions {
        pairs: parse("--pairs", if quick { 16.0 } else { 64.0 }) as usize,
        seed: parse("--seed", 20_261_122.0) as u64,
        pilot: parse("--pilot", if quick { 500.0 } else { 4000.0 }) as u64,
        target: parse("--target", 1e-3),
        budget: parse("--budget", if quick { 5.0 } else { 600.0 }),
        max_samples: parse("--max-samples", 1e9) as u64,
        albedo_pilot: 0,
        threads: harness::threads(),
        quiet: false,
        estimator,
    };
    if harness::arg_flag("--check") {
        let n = parse("--samples", 2e5) as u64;
        // `--items name:pair,...` replaces the default list.
        let custom: Vec<(String, usize)> = harness::arg_value("--items")
            .map(|l| {
                l.split(',')
                    .filter_map(|s| {
                        let (n, p) = s.split_once(':')?;
                        Some((n.to_string(), p.parse().ok()?))
                    })
                    .collect()
            })
            .unwrap_or_default();
        let items: Vec<(&str, usize)> = if custom.is_empty() {
            reference::check_items()
        } else {
            custom.iter().map(|(n, p)| (n.as_str(), *p)).collect()
        };
        let r = reference::check_estimators(&items, n, o.seed + 5, &o);
        for l in &r.lines {
            println!("{l}");
        }
        if r.worst_z > r.sidak_z {
            std::process::exit(1);
        }
        return;
    }
    if harness::arg_flag("--estimate") {
        // `--only SUBSTRING`: estimate a part of the suite.
        let suite: Vec<_> = match harness::arg_value("--only") {
            Some(f) => suite.into_iter().filter(|m| m.name.contains(&f)).collect(),
            None => suite,
        };
        // Pilot only: the time the second pass would need for the target.
        o.budget = 0.0;
        let g = reference::generate(&suite, &o, None);
        let secs = g.work / (o.target * o.target) / o.threads as f64;
        let t2 = o.target * o.target;
        let mut order: Vec<usize> = (0..g.work_by_value.len()).collect();
        order.sort_by(|a, b| g.work_by_value[*b].total_cmp(&g.work_by_value[*a]));
        let per = o.pairs.min(64);
        for &i in order.iter().take(
            harness::arg_value("--top")
                .and_then(|s| s.parse().ok())
                .unwrap_or(0),
        ) {
            let p = &g.data[i / per].pairs[i % per];
            println!(
                "  top value: {} pair {} (wi.z {:.4}, wo.z {:.4}): core-seconds {:.3e}",
                suite[i / per].name,
                i % per,
                p.wi.z,
                p.wo.z,
                g.work_by_value[i] / t2
            );
        }
        for (m, (w, u)) in suite
            .iter()
            .zip(g.work_by_material.iter().zip(&g.unit_by_material))
        {
            println!(
                "  {:24} samples for the target {:.3e}, core-seconds {:.3e}",
                m.name,
                u / t2,
                w / t2
            );
        }
        println!(
            "estimator {}: pilot {} samples per value; estimated {secs:.0} s on {} threads for relative standard error {:.1e} on every value (median reached by the pilot {:.2e})",
            o.estimator.id(),
            o.pilot,
            o.threads,
            o.target,
            harness::median(&g.reached)
        );
        return;
    }
    let path = format!("{out}/reference_values.csv");
    let resume = harness::arg_flag("--resume");
    let (prior, prior_header) = if resume {
        let text = std::fs::read_to_string(&path).expect("--resume: read the existing values");
        let header = reference::header_lines(&text);
        let id = format!("estimator-id: {}", o.estimator.id());
        if !header.iter().any(|h| h.ends_with(&id)) {
            eprintln!(
                "--resume: {path} was not made with this estimator ({id}); its samples cannot be pooled"
            );
            std::process::exit(2);
        }
        let data = reference::read_values(&text).expect("--resume: parse the existing values");
        let names: Vec<&str> = data.iter().map(|m| m.mat.name.as_str()).collect();
        let want: Vec<&str> = suite.iter().map(|m| m.name.as_str()).collect();
        // Materials appended to the suite since (new ones go last) start
        // from no samples; any other difference is another suite.
        if !want.starts_with(&names) || data.iter().any(|m| m.pairs.len() != o.pairs) {
            eprintln!("--resume: {path} holds another suite or pair count");
            std::process::exit(2);
        }
        if harness::arg_value("--seed").is_none() {
            o.seed = reference::max_seed(&header) + 10;
        }
        (Some(data), header)
    } else {
        (None, Vec::new())
    };
    let command = harness::command_line("gen_reference");
    let t = std::time::Instant::now();
    if harness::arg_flag("--albedo-only") {
        albedo_table(&suite, &o, &command, &out, quick, t);
        return;
    }
    let check = reference::check_order_one(&suite, if quick { 2000 } else { 50_000 }, &o);
    if harness::arg_flag("--check-only") {
        for h in check {
            eprintln!("{h}");
        }
        return;
    }
    let generated = reference::generate(&suite, &o, prior.as_deref());
    let mut header = vec![
        "HEITZ_RANDOM_WALK reference values f(wi, wo) |wo.z| per RGB channel (msbsdf speed-vs-accuracy suite)".to_string(),
        format!("command: {command}"),
    ];
    header.extend(generated.header.iter().cloned());
    header.extend(check);
    header.push(format!(
        "wall time {:.0} s on {} threads",
        t.elapsed().as_secs_f64(),
        o.threads
    ));
    for h in prior_header.iter().skip(1) {
        if h.starts_with("earlier run: ") {
            header.push(h.clone());
        } else {
            header.push(format!("earlier run: {h}"));
        }
    }
    for h in &header {
        eprintln!("{h}");
    }
    reference::write_values(&path, &header, &generated.data).expect("write values");
    eprintln!("wrote {path}");
    if resume || harness::arg_flag("--no-albedo") {
        return;
    }
    albedo_table(&suite, &o, &command, &out, quick, t);
}

/// `--analyse name:pair,...`: where the variance of the given values comes
/// from (per scattering order, heavy tails) and how each walk variant
/// (forced collisions, MIS) changes variance and time.
fn analyse(list: &str, samples: u64) {
    use glam::Vec3;
    use harness::walk::{ORDERS, WalkOptions};
    let suite = suite::full_suite();
    let one_way = harness::arg_flag("--one-way");
    let configs: [(&str, WalkOptions); 5] = [
        ("old (analog, averaged)", WalkOptions::ANALOG),
        (
            "forced 1",
            WalkOptions {
                forced: 1,
                mis: false,
                order_one: false,
            },
        ),
        (
            "mis",
            WalkOptions {
                forced: 0,
                mis: true,
                order_one: false,
            },
        ),
        (
            "forced 1 + mis",
            WalkOptions {
                forced: 1,
                mis: true,
                order_one: false,
            },
        ),
        (
            "forced all + mis",
            WalkOptions {
                forced: 256,
                mis: true,
                order_one: false,
            },
        ),
    ];
    let items: Vec<(usize, usize)> = list
        .split(',')
        .filter_map(|s| {
            let (n, p) = s.split_once(':')?;
            let mi = suite.iter().position(|m| m.name == n)?;
            Some((mi, p.parse().ok()?))
        })
        .collect();
    for (mi, pi) in items {
        let m = &suite[mi];
        let (wi, wo) = suite::pairs(m.class, 64)[pi];
        let e = reference::RefEstimator::new(m);
        eprintln!("{} pair {pi}: wi {wi:.4} wo {wo:.4}", m.name);
        let list: Vec<(&str, WalkOptions, u8)> = if one_way {
            let f = |forced| WalkOptions {
                forced,
                mis: false,
                order_one: false,
            };
            vec![
                ("forward only", f(0), 1),
                ("reverse only", f(0), 2),
                ("forward only, forced 1", f(1), 1),
                ("reverse only, forced 1", f(1), 2),
            ]
        } else {
            configs.iter().map(|c| (c.0, c.1, 0)).collect()
        };
        for (name, opt, way) in list {
            let mut rng = msbsdf::Rng::new(99, (mi * 64 + pi) as u64);
            let mut tot = harness::Stats::default();
            let mut per = [harness::Stats::default(); ORDERS];
            let mut sq: Vec<f64> = Vec::with_capacity(samples as usize);
            let t = std::time::Instant::now();
            for _ in 0..samples {
                let o = match way {
                    0 => e.orders(wi, wo, &mut rng, opt),
                    w => e.one_way(wi, wo, &mut rng, opt.forced, w == 2),
                };
                let lum = |v: Vec3| [(v.x + v.y + v.z) as f64 / 3.0, 0.0, 0.0];
                let s: Vec3 = o.iter().copied().sum();
                tot.push(lum(s));
                for k in 0..ORDERS {
                    per[k].push(lum(o[k]));
                }
                sq.push(lum(s)[0]);
            }
            let secs = t.elapsed().as_secs_f64() / samples as f64;
            let nz = sq.iter().filter(|x| **x != 0.0).count() as f64 / samples as f64;
            let m2: f64 = sq.iter().map(|x| x * x).sum();
            sq.sort_by(|a, b| b.abs().total_cmp(&a.abs()));
            let top = (samples as usize / 1000).max(1);
            let top_share = sq[..top].iter().map(|x| x * x).sum::<f64>() / m2.max(1e-300);
            let v = tot.var()[0];
            let mean = tot.mean[0];
            eprintln!(
                "  {name:24} mean {mean:.5e} +- {:.1e}  var/mean^2 {:.3e}  t {:.0} ns  var*t/mean^2 {:.3e}  nonzero {nz:.2e}  top0.1% share of m2 {top_share:.2}",
                tot.se()[0],
                v / (mean * mean),
                secs * 1e9,
                v * secs / (mean * mean),
            );
            let mut line = String::from("      per order (mean, var share):");
            for (k, p) in per.iter().enumerate().skip(2) {
                line += &format!(" {k}: {:.2e} {:.2}", p.mean[0], p.var()[0] / v.max(1e-300));
            }
            eprintln!("{line}");
        }
    }
}

/// Writes `DIR/reference_albedo.csv`: HEITZ_RANDOM_WALK's directional
/// albedo (mean sample weight) per suite material and incident angle,
/// `--albedo-samples` per row (default 1e6: worst relative standard error
/// below 1e-3).
fn albedo_table(
    suite: &[suite::SuiteMaterial],
    o: &GenOptions,
    command: &str,
    out: &str,
    quick: bool,
    t: std::time::Instant,
) {
    let parse = |name: &str, default: f64| {
        harness::arg_value(name)
            .and_then(|s| s.parse::<f64>().ok())
            .unwrap_or(default)
    };
    let albedo_samples = parse("--albedo-samples", if quick { 2e4 } else { 1e6 }) as u64;
    let rows = reference::albedo(suite, albedo_samples, o);
    let worst = rows
        .iter()
        .map(|r| {
            (0..3)
                .map(|c| r.se[c] / r.albedo[c].max(1e-9))
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max);
    let aheader = vec![
        "HEITZ_RANDOM_WALK directional albedo (mean sample weight; reflected + transmitted; azimuth 0) of the suite materials".to_string(),
        format!("command: {command}"),
        format!(
            "seeds: Rng::new({}, stream = material_index * {} + angle_index); {albedo_samples} samples per row; worst relative standard error {worst:.2e}",
            o.seed + 3,
            reference::ALBEDO_THETAS.len()
        ),
    ];
    let apath = format!("{out}/reference_albedo.csv");
    reference::write_albedo(&apath, &aheader, &rows).expect("write albedo");
    eprintln!("wrote {apath} ({:.0} s total)", t.elapsed().as_secs_f64());
}
