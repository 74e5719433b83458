//! Generates the converged HEITZ_RANDOM_WALK reference of the speed-vs-accuracy
//! harness: `data/reference_values.csv` (64 direction pairs per suite
//! material, see `tools/harness/suite.rs`) and `data/reference_albedo.csv`
//! (directional albedo tables), with the command, seeds, sample counts and
//! the accuracy reached in the header comments. Progress and ETA on stderr.
//!
//! `cargo run --release --example gen_reference -- [--budget SECONDS]
//! [--target REL_SE] [--pairs N] [--quick] [--out DIR]`
//!
//! `--budget` is the wall-clock time allowed for the main pass (default
//! 600 s); the target relative standard error per value (default 1e-3) is
//! relaxed to what the budget allows, and the header says what was reached.

#[path = "harness/mod.rs"]
mod harness;

use harness::reference::{self, GenOptions};
use harness::suite;

fn main() {
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
    let o = GenOptions {
        pairs: parse("--pairs", if quick { 16.0 } else { 64.0 }) as usize,
        seed: parse("--seed", 20_261_122.0) as u64,
        pilot: parse("--pilot", if quick { 500.0 } else { 4000.0 }) as u64,
        target: parse("--target", 1e-3),
        budget: parse("--budget", if quick { 5.0 } else { 600.0 }),
        max_samples: parse("--max-samples", 4e7) as u64,
        albedo_pilot: 0,
        threads: harness::threads(),
        quiet: false,
    };
    let albedo_samples = parse("--albedo-samples", if quick { 2e4 } else { 4e5 }) as u64;
    let command = harness::command_line("gen_reference");
    let t = std::time::Instant::now();
    let check = reference::check_order_one(&suite, if quick { 2000 } else { 50_000 }, &o);
    if harness::arg_flag("--check-only") {
        for h in check {
            eprintln!("{h}");
        }
        return;
    }
    let generated = reference::generate(&suite, &o);
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
    for h in &header {
        eprintln!("{h}");
    }
    let path = format!("{out}/reference_values.csv");
    reference::write_values(&path, &header, &generated.data).expect("write values");
    eprintln!("wrote {path}");
    let rows = reference::albedo(&suite, albedo_samples, &o);
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
