//! Measurements behind the null-scattering documentation (d'Eon 2023,
//! section 3): albedo, real / tentative collision ratio, ns per sample and
//! per eval, versus NDF and roughness, and instructions per eval and per
//! sample (callgrind: load-independent) for a few materials. Run with
//! `cargo run --release --example null_scattering_stats [quick]`; the full
//! run writes both tables to `docs/null_scattering.md` (the instruction
//! table needs valgrind; without it the table says so).
//!
//! `null_scattering_stats ir CASE OP CALLS` makes CALLS calls of OP (`eval`
//! or `sample`) for the case numbered CASE of [`IR_CASES`] on 256 fixed
//! pairs; the driver runs it under `valgrind --tool=callgrind` with CALLS
//! and with 0 and divides the difference by CALLS.

use glam::Vec3;
use msbsdf::Rng;
use msbsdf::bsdf::ScatterModel;
use msbsdf::facet::Facet;
use msbsdf::multiple::null_scattering::{NullNdf, NullNdfKind, NullScattering, WalkStats};
use std::process::Command;

/// The materials of the instruction table: NDF, roughness, facet.
const IR_CASES: [(NullNdfKind, f32, &str); 7] = [
    (NullNdfKind::Ggx, 0.5, "gold"),
    (NullNdfKind::Beckmann, 1.0, "gold"),
    (NullNdfKind::StudentT, 0.5, "gold"),
    (NullNdfKind::Vmf, 1.0, "gold"),
    (NullNdfKind::Exponential, 1.0, "gold"),
    (NullNdfKind::BesselK0, 0.5, "gold"),
    (NullNdfKind::Ggx, 0.5, "glass"),
];

/// Calls per callgrind run (the count per call is a Monte Carlo mean over
/// the walks: about 0.5% relative noise at this size).
const IR_CALLS: usize = 10_000;

fn facet(name: &str) -> Facet {
    match name {
        "glass" => Facet::Dielectric { eta: 1.5 },
        _ => Facet::Conductor {
            eta: Vec3::new(0.143, 0.374, 1.442),
            k: Vec3::new(3.983, 2.385, 1.603),
        },
    }
}

fn ir_model(case: usize) -> NullScattering {
    let (kind, alpha, f) = IR_CASES[case.min(IR_CASES.len() - 1)];
    let ndf = NullNdf::new(kind, alpha, alpha, 3.0).expect("supported NDF");
    NullScattering::new(ndf, facet(f), 0)
}

/// `ir CASE OP CALLS`: the callgrind workload (256 fixed pairs; for glass
/// every other `wo` is below the surface).
fn ir_mode(args: &[String]) {
    let get = |i: usize| args.get(i).map(String::as_str).unwrap_or("");
    let case: usize = get(2).parse().unwrap_or(0);
    let calls: usize = get(4).parse().unwrap_or(0);
    let model = ir_model(case);
    let mut r = Rng::new(17, 3);
    let mut dir = || {
        let z = r.next_f32().max(0.05);
        let phi = 2.0 * std::f32::consts::PI * r.next_f32();
        let s = (1.0 - z * z).sqrt();
        Vec3::new(s * phi.cos(), s * phi.sin(), z)
    };
    let pairs: Vec<(Vec3, Vec3)> = (0..256)
        .map(|j| {
            let (wi, mut wo) = (dir(), dir());
            if IR_CASES[case.min(IR_CASES.len() - 1)].2 == "glass" && j % 2 == 1 {
                wo.z = -wo.z;
            }
            (wi, wo)
        })
        .collect();
    // An optional fifth argument changes the stream (to see the noise).
    let mut rng = Rng::new(get(5).parse().unwrap_or(5), 5);
    let mut acc = Vec3::ZERO;
    for j in 0..calls {
        let (wi, wo) = pairs[j & 255];
        if get(3) == "sample" {
            acc += model.sample(wi, &mut rng).weight;
        } else {
            acc += model.eval(wi, wo, &mut rng);
        }
    }
    std::hint::black_box(acc);
}

/// Instructions per call of `op` for case `case`, by callgrind (`IR_CALLS`
/// calls and none); `None` when valgrind cannot run.
fn instructions(case: usize, op: &str) -> Option<f64> {
    let exe = std::env::current_exe().ok()?;
    let count = |calls: usize| -> Option<f64> {
        let out = Command::new("valgrind")
            .args(["--tool=callgrind", "--callgrind-out-file=/dev/null"])
            .arg(&exe)
            .args(["ir", &case.to_string(), op, &calls.to_string()])
            .output()
            .ok()?;
        let err = String::from_utf8_lossy(&out.stderr);
        let line = err.lines().find(|l| l.contains("Collected :"))?;
        line.rsplit(':').next()?.trim().parse::<f64>().ok()
    };
    Some((count(IR_CALLS)? - count(0)?) / IR_CALLS as f64)
}

/// The instruction table (Markdown), also printed.
fn instruction_table() -> String {
    let mut t = String::from(
        "| NDF | alpha | facet | instructions / eval | instructions / sample |\n|---|---|---|---|---|\n",
    );
    println!("instructions per call (callgrind, {IR_CALLS} calls)");
    for (case, &(kind, alpha, f)) in IR_CASES.iter().enumerate() {
        let fmt =
            |v: Option<f64>| v.map_or("(valgrind missing)".to_string(), |v| format!("{v:.0}"));
        let (e, s) = (
            fmt(instructions(case, "eval")),
            fmt(instructions(case, "sample")),
        );
        println!(
            "{:11} {alpha:4} {f:5}  eval {e:>8}  sample {s:>8}",
            format!("{kind:?}")
        );
        t += &format!("| {kind:?} | {alpha} | {f} | {e} | {s} |\n");
    }
    t
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some("ir") {
        ir_mode(&args);
        return;
    }
    if args.get(1).map(String::as_str) == Some("callgrind") {
        instruction_table();
        return;
    }
    let mirror = Facet::Conductor {
        eta: Vec3::ZERO,
        k: Vec3::ONE,
    };
    let wi = Vec3::new(
        std::f32::consts::FRAC_1_SQRT_2,
        0.0,
        std::f32::consts::FRAC_1_SQRT_2,
    );
    let mut rng = Rng::new(5, 6);
    println!(
        "kind        alpha  albedo(sample)  real/tent  real/walk  ns/sample  albedo(eval)  ns/eval"
    );
    let kinds = [
        NullNdfKind::Ggx,
        NullNdfKind::Beckmann,
        NullNdfKind::StudentT,
        NullNdfKind::Vmf,
        NullNdfKind::Exponential,
        NullNdfKind::BesselK0,
    ];
    let quick = std::env::args().any(|a| a == "quick");
    let mut table = String::from(
        "| NDF | alpha | albedo (sample) | real/tent. | real per walk | ns/sample | albedo (eval) | ns/eval |\n|---|---|---|---|---|---|---|---|\n",
    );
    let alphas: &[f32] = if quick {
        &[0.5, 1.0]
    } else {
        &[0.05, 0.1, 0.2, 0.4, 0.5, 1.0, 4.0]
    };
    for kind in kinds {
        for &alpha in alphas {
            let Some(ndf) = NullNdf::new(kind, alpha, alpha, 3.0) else {
                continue;
            };
            let model = NullScattering::new(ndf, mirror, 0);
            let n = if alpha < 0.1 { 20_000 } else { 100_000 };
            let mut st = WalkStats::default();
            let t0 = cpu_ns();
            let mut sum = 0.0f64;
            for _ in 0..n {
                sum += model.sample_with_stats(wi, &mut rng, &mut st).weight.x as f64;
            }
            let ns_s = (cpu_ns() - t0) as f64 / n as f64;
            // eval albedo: uniform hemisphere directions, f cos / (1 / 2 pi).
            let ne = n / 4;
            let t0 = cpu_ns();
            let mut esum = 0.0f64;
            let mut st2 = WalkStats::default();
            for _ in 0..ne {
                let z = rng.next_f32().max(1e-4);
                let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
                let s = (1.0 - z * z).sqrt();
                let wo = Vec3::new(s * phi.cos(), s * phi.sin(), z);
                esum += model.eval_reciprocal(wi, wo, &mut rng, &mut st2).x as f64
                    * 2.0
                    * std::f64::consts::PI;
            }
            let ns_e = (cpu_ns() - t0) as f64 / ne as f64;
            table += &format!(
                "| {kind:?} | {alpha} | {:.4} | {:.3} | {:.2} | {ns_s:.0} | {:.4} | {ns_e:.0} |\n",
                sum / n as f64,
                st.real as f64 / st.tentative as f64,
                st.real as f64 / n as f64,
                esum / ne as f64,
            );
            println!(
                "{:11} {alpha:5}  {:.4}          {:.3}      {:.2}      {ns_s:8.0}   {:.4}        {ns_e:8.0}",
                format!("{kind:?}"),
                sum / n as f64,
                st.real as f64 / st.tentative as f64,
                st.real as f64 / n as f64,
                esum / ne as f64,
            );
            let _ = model.pdf(wi, wi);
        }
    }
    if !quick {
        let ir = instruction_table();
        let doc = format!(
            "# NULL_SCATTERING: cost versus NDF and roughness\n\n\
             Written by `cargo run --release --example null_scattering_stats`: F = 1 \
             conductor, `wi` at 45 degrees, thread CPU time (the machine may be shared); \
             albedo by sample weights and by eval over uniform hemisphere directions; \
             \"real/tent.\" is the fraction of tentative collisions that are real \
             (d'Eon 2023, section 3.3); Beckmann, GGX and Student-T draw the first \
             collision of a sample directly (one tentative collision, real).\n\n{table}\n\
             Instructions per call (callgrind: load-independent), `null_scattering_stats \
             callgrind` alone: {IR_CALLS} calls on 256 fixed pairs (uniform directions, \
             cosines >= 0.05; glass: every other `wo` below), minus a run with none; \
             gold is the conductor (eta 0.143, 0.374, 1.442; k 3.983, 2.385, 1.603), \
             glass eta 1.5; Student-T shape 3. Each figure is a Monte Carlo mean over \
             the walks (about 0.5% noise).\n\n{ir}"
        );
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/null_scattering.md");
        if let Err(e) = std::fs::write(path, doc) {
            eprintln!("cannot write {path}: {e}");
        }
    }
}

/// Thread CPU time in nanoseconds (unaffected by other processes sharing the cores).
fn cpu_ns() -> u128 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec through a valid pointer.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    ts.tv_sec as u128 * 1_000_000_000 + ts.tv_nsec as u128
}
