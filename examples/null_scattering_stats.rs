//! Measurements behind the null-scattering documentation (d'Eon 2023,
//! section 3): albedo, real / tentative collision ratio, ns per sample and
//! per eval, versus NDF and roughness. Run with
//! `cargo run --release --example null_scattering_stats [quick]`; the full
//! run writes the table to `docs/null_scattering.md`.

use glam::Vec3;
use msbsdf::Rng;
use msbsdf::bsdf::ScatterModel;
use msbsdf::facet::Facet;
use msbsdf::multiple::null_scattering::{NullNdf, NullNdfKind, NullScattering, WalkStats};

fn main() {
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
        let doc = format!(
            "# NULL_SCATTERING: cost versus NDF and roughness\n\n\
             Written by `cargo run --release --example null_scattering_stats`: F = 1 \
             conductor, `wi` at 45 degrees, thread CPU time (the machine may be shared); \
             albedo by sample weights and by eval over uniform hemisphere directions; \
             \"real/tent.\" is the fraction of tentative collisions that are real \
             (d'Eon 2023, section 3.3).\n\n{table}"
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
